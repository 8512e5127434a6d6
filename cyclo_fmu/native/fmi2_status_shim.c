/* FMI 2.0 co-simulation front of a pythonfmu FMU (cyclo-fmu; MIT license).
 *
 * pythonfmu 0.7's binary answers every Python exception with fmi2Fatal, which tells the host that
 * all instances of the FMU are unusable. Our slaves raise only for bad input or parameters (after
 * logging the reason), and a Python exception leaves the interpreter and the other instances
 * intact, so the right answer is fmi2Error (FMI 2.0, section 2.1.3: this instance cannot
 * continue; fmi2FreeInstance, and fmi2Reset, remain allowed).
 *
 * This library carries the FMU's model identifier, loads pythonfmu's binary, shipped next to it
 * as <modelIdentifier>.pythonfmu.so, and forwards every call, turning fmi2Fatal into fmi2Error.
 *
 * Logging as the native FMU does it: pythonfmu passes its messages on only with debug logging
 * on, so the front always switches it on underneath and itself drops the fmi2OK messages while
 * the host has logging off; warnings and errors (with their reason) always reach the host. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

#define SUFFIX ".pythonfmu.so"

static void *lib = NULL;
static char load_error[768] = "";

static void *load(void)
{
    Dl_info info;
    char path[4096];
    size_t n;
    if (lib) return lib;
    if (!dladdr((void *)&load, &info) || info.dli_fname == NULL) return NULL;
    n = strlen(info.dli_fname);
    if (n < 3 || n + sizeof(SUFFIX) > sizeof(path)) return NULL;
    memcpy(path, info.dli_fname, n - 3);          /* strip ".so" */
    memcpy(path + n - 3, SUFFIX, sizeof(SUFFIX));
    lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        const char *e = dlerror();
        snprintf(load_error, sizeof load_error, "%s", e ? e : path);
    }
    return lib;
}

/* unloaded with this library: pythonfmu's binary goes when ours goes, as without the front */
__attribute__((destructor)) static void unload(void)
{
    if (lib) dlclose(lib);
    lib = NULL;
}

static void *sym(const char *name)
{
    void *h = load();
    return h ? dlsym(h, name) : NULL;
}

static fmi2Status map(fmi2Status s) { return s == fmi2Fatal ? fmi2Error : s; }

#ifndef FAILED_VR
#define FAILED_VR 0
#endif

/* the slave's flag ``_failed``: set when the call just made failed (reason already logged);
 * fmi2Error then, else the call's own status */
static fmi2Status checked(fmi2Component c, fmi2Status s)
{
    static fmi2GetBooleanTYPE *get = NULL;
    const fmi2ValueReference vr = FAILED_VR;
    fmi2Boolean failed = fmi2False;
    if (s > fmi2Discard) return map(s);
    if (!get) get = (fmi2GetBooleanTYPE *)sym("fmi2GetBoolean");
    if (get && get(c, &vr, 1, &failed) == fmi2OK && failed) return fmi2Error;
    return s;
}

#define CHECKED_FN(name, params, args)                                             \
    FMI2_Export fmi2Status name params                                             \
    {                                                                              \
        static name##TYPE *f = NULL;                                               \
        if (!f) f = (name##TYPE *)sym(#name);                                      \
        if (!f) return fmi2Error;                                                  \
        return checked(c, f args);                                                 \
    }

#define STATUS_FN(name, params, args)                                              \
    FMI2_Export fmi2Status name params                                             \
    {                                                                              \
        static name##TYPE *f = NULL;                                               \
        if (!f) f = (name##TYPE *)sym(#name);                                      \
        if (!f) return fmi2Error;                                                  \
        return map(f args);                                                        \
    }

FMI2_Export const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
FMI2_Export const char *fmi2GetVersion(void) { return fmi2Version; }

/* one per instance: the host's callbacks and logging switch, and ours handed to pythonfmu */
typedef struct Wrap {
    fmi2CallbackFunctions cb;
    fmi2CallbackFunctions host;
    int on;
    fmi2Component comp;
    struct Wrap *next;
} Wrap;

static Wrap *wraps = NULL;

static Wrap *find(fmi2Component c)
{
    Wrap *w;
    for (w = wraps; w; w = w->next)
        if (w->comp == c) return w;
    return NULL;
}

static void wlog(fmi2ComponentEnvironment env, fmi2String name, fmi2Status st, fmi2String cat,
                 fmi2String fmt, ...)
{
    Wrap *w = (Wrap *)env;
    char buf[2048];
    va_list ap;
    if (w == NULL || w->host.logger == NULL) return;
    if ((st == fmi2OK || st == fmi2Pending) && !w->on) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt ? fmt : "", ap);
    va_end(ap);
    w->host.logger(w->host.componentEnvironment, name, map(st), cat, "%s", buf);
}

FMI2_Export fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType,
                                          fmi2String fmuGUID, fmi2String fmuResourceLocation,
                                          const fmi2CallbackFunctions *functions,
                                          fmi2Boolean visible, fmi2Boolean loggingOn)
{
    fmi2InstantiateTYPE *f = (fmi2InstantiateTYPE *)sym("fmi2Instantiate");
    Wrap *w;
    if (!f) {
        char buf[1024];
        size_t i;
        const char *why = load_error[0] ? load_error : NULL;
        snprintf(buf, sizeof buf, "cannot load the pythonfmu binary (%s): a non-Python host needs "
                 "libpython preloaded (LD_PRELOAD) and numpy/scipy on PYTHONPATH (README, Use it "
                 "in your tool)", why ? why : "not found");
        for (i = 0; buf[i]; i++)
            if (buf[i] == '%') buf[i] = '?';
        if (functions && functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error,
                              "logStatusError", buf);
        return NULL;
    }
    if (functions == NULL) return NULL;
    w = (Wrap *)calloc(1, sizeof *w);
    if (w == NULL) return NULL;
    w->host = *functions;
    w->cb = *functions;
    w->cb.logger = wlog;
    w->cb.componentEnvironment = w;
    w->on = loggingOn ? 1 : 0;
    w->comp = f(instanceName, fmuType, fmuGUID, fmuResourceLocation, &w->cb, visible, fmi2True);
    if (w->comp == NULL) { free(w); return NULL; }
    w->next = wraps;
    wraps = w;
    return w->comp;
}

FMI2_Export void fmi2FreeInstance(fmi2Component c)
{
    fmi2FreeInstanceTYPE *f = (fmi2FreeInstanceTYPE *)sym("fmi2FreeInstance");
    Wrap **p;
    if (f) f(c);
    for (p = &wraps; *p; p = &(*p)->next)
        if ((*p)->comp == c) {
            Wrap *w = *p;
            *p = w->next;
            free(w);
            break;
        }
}

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n,
                                           const fmi2String cat[])
{
    static fmi2SetDebugLoggingTYPE *f = NULL;
    Wrap *w = find(c);
    if (!f) f = (fmi2SetDebugLoggingTYPE *)sym("fmi2SetDebugLogging");
    if (!f) return fmi2Error;
    if (w) w->on = on ? 1 : 0;
    /* underneath logging stays on (all categories while the host's is off) */
    return map(on ? f(c, fmi2True, n, cat) : f(c, fmi2True, 0, NULL));
}
STATUS_FN(fmi2SetupExperiment, (fmi2Component c, fmi2Boolean tolDef, fmi2Real tol,
                                fmi2Real start, fmi2Boolean stopDef, fmi2Real stop),
          (c, tolDef, tol, start, stopDef, stop))
STATUS_FN(fmi2EnterInitializationMode, (fmi2Component c), (c))
CHECKED_FN(fmi2ExitInitializationMode, (fmi2Component c), (c))
STATUS_FN(fmi2Terminate, (fmi2Component c), (c))
STATUS_FN(fmi2Reset, (fmi2Component c), (c))
STATUS_FN(fmi2GetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
                        fmi2Real v[]), (c, vr, n, v))
STATUS_FN(fmi2GetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
                           fmi2Integer v[]), (c, vr, n, v))
STATUS_FN(fmi2GetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
                           fmi2Boolean v[]), (c, vr, n, v))
STATUS_FN(fmi2GetString, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
                          fmi2String v[]), (c, vr, n, v))
STATUS_FN(fmi2SetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
                        const fmi2Real v[]), (c, vr, n, v))
STATUS_FN(fmi2SetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
                           const fmi2Integer v[]), (c, vr, n, v))
STATUS_FN(fmi2SetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
                           const fmi2Boolean v[]), (c, vr, n, v))
STATUS_FN(fmi2SetString, (fmi2Component c, const fmi2ValueReference vr[], size_t n,
                          const fmi2String v[]), (c, vr, n, v))
STATUS_FN(fmi2GetFMUstate, (fmi2Component c, fmi2FMUstate *s), (c, s))
STATUS_FN(fmi2SetFMUstate, (fmi2Component c, fmi2FMUstate s), (c, s))
STATUS_FN(fmi2FreeFMUstate, (fmi2Component c, fmi2FMUstate *s), (c, s))
STATUS_FN(fmi2SerializedFMUstateSize, (fmi2Component c, fmi2FMUstate s, size_t *n), (c, s, n))
STATUS_FN(fmi2SerializeFMUstate, (fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n),
          (c, s, b, n))
STATUS_FN(fmi2DeSerializeFMUstate, (fmi2Component c, const fmi2Byte b[], size_t n,
                                    fmi2FMUstate *s), (c, b, n, s))
STATUS_FN(fmi2GetDirectionalDerivative, (fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                         const fmi2ValueReference z[], size_t nz,
                                         const fmi2Real dv[], fmi2Real df[]),
          (c, u, nu, z, nz, dv, df))
STATUS_FN(fmi2SetRealInputDerivatives, (fmi2Component c, const fmi2ValueReference vr[],
                                        size_t n, const fmi2Integer o[], const fmi2Real v[]),
          (c, vr, n, o, v))
STATUS_FN(fmi2GetRealOutputDerivatives, (fmi2Component c, const fmi2ValueReference vr[],
                                         size_t n, const fmi2Integer o[], fmi2Real v[]),
          (c, vr, n, o, v))
/* a failed step returns False from do_step (fmi2Discard from pythonfmu): only then is the flag
 * read, so a good step costs no extra call into Python */
FMI2_Export fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noPrior)
{
    static fmi2DoStepTYPE *f = NULL;
    fmi2Status s;
    if (!f) f = (fmi2DoStepTYPE *)sym("fmi2DoStep");
    if (!f) return fmi2Error;
    s = f(c, t, h, noPrior);
    return s == fmi2Discard ? checked(c, s) : map(s);
}
STATUS_FN(fmi2CancelStep, (fmi2Component c), (c))
STATUS_FN(fmi2GetStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Status *v), (c, k, v))
STATUS_FN(fmi2GetRealStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Real *v), (c, k, v))
STATUS_FN(fmi2GetIntegerStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Integer *v),
          (c, k, v))
STATUS_FN(fmi2GetBooleanStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Boolean *v),
          (c, k, v))
STATUS_FN(fmi2GetStringStatus, (fmi2Component c, const fmi2StatusKind k, fmi2String *v),
          (c, k, v))

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
 * The host holds our handle (Wrap), which holds pythonfmu's component.
 *
 * What the front refuses with fmi2Error before pythonfmu sees the call (as the native FMU does):
 * NULL component, value arrays, instance name, resource location or log categories; a GUID other
 * than the one this front was built for; Model Exchange; calls out of order (FMI 2.0 state
 * machine); a parameter set after fmi2ExitInitializationMode; a step size that is negative or not
 * finite; any call but fmi2Get*, fmi2Reset and fmi2FreeInstance after a failed
 * fmi2ExitInitializationMode. The model-specific lists (GUID, parameters) come from a header
 * generated at build time (cyclo_fmu/fmu_build.py, -DSHIM_VARS="file").
 *
 * Logging as the native FMU does it: pythonfmu passes its messages on only with debug logging
 * on, so the front always switches it on underneath and itself drops the fmi2OK messages while
 * the host has logging off; warnings and errors (with their reason) always reach the host.
 * A message is text, never a format: pythonfmu hands the slave's message over as the format
 * argument, so the front copies it (undoing the slaves' "%%" escape, slaves/base.py) and hands
 * the host that text with every '%' doubled (host_log), never formatting it itself.
 *
 * Thread safety: the library handle and the resolved functions are published with atomic
 * stores (loaded once under a mutex); the list of live handles is guarded by a mutex. Calls on
 * one instance must not overlap (FMI 2.0); calls on different instances may. */
#ifndef _WIN32
#define _GNU_SOURCE
#include <dlfcn.h>
#include <pthread.h>
#else
#define WIN32_LEAN_AND_MEAN
#include <windows.h>
#endif
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

/* -- the platform: a statically initialised lock, pythonfmu's binary next to ours ----------
 * Linux: <id>.so loads <id>.pythonfmu.so with dlopen; Windows (mingw-w64): <id>.dll loads
 * <id>.pythonfmu.dll with LoadLibraryEx (its folder searched for its dependencies), a slim
 * reader/writer lock in place of the pthread mutex. The library handle and the resolved
 * functions are published with GCC's __atomic builtins on both. */
#ifndef _WIN32
typedef pthread_mutex_t Lock;
#define LOCK_INIT PTHREAD_MUTEX_INITIALIZER
#define lock(l) pthread_mutex_lock(l)
#define unlock(l) pthread_mutex_unlock(l)
#define SUFFIX ".pythonfmu.so"
#define OWN_EXT ".so"
#define NEEDS_PYTHON "a non-Python host needs libpython preloaded (LD_PRELOAD) and " \
    "numpy/scipy on PYTHONPATH (README, Use it in your tool)"
#else
typedef SRWLOCK Lock;
#define LOCK_INIT SRWLOCK_INIT
#define lock(l) AcquireSRWLockExclusive(l)
#define unlock(l) ReleaseSRWLockExclusive(l)
#define SUFFIX L".pythonfmu.dll"
#define OWN_EXT L".dll"
#define NEEDS_PYTHON "pythonfmu's DLL needs python3.dll of a 64-bit Python with numpy and " \
    "scipy on PATH (docs/how-to/hosts.md)"
#endif

static Lock lib_lock = LOCK_INIT;
static void *lib = NULL;
static char load_error[768] = "";

#ifndef _WIN32
/* pythonfmu 0.7 keeps its interpreter state in a static std::shared_ptr and resets it again in
 * a library destructor. At process exit (library still loaded) the C++ exit handlers destroy
 * the shared_ptr first and the destructor then resets the destroyed object: a use-after-free
 * that glibc reports at random as "corrupted double-linked list" or "double free" (exit 134).
 * Our handler, registered after pythonfmu's binary is loaded, runs before its exit handlers
 * (LIFO) and releases the state through pythonfmu's own exported finalizePythonInterpreter,
 * leaving an empty shared_ptr that both later resets handle. A host's dlclose unloads neither
 * library (pythonfmu's is kept by glibc for its unique symbols, this one pins itself when it
 * loads pythonfmu's), so the handler always runs at exit, never at an unload, and a host that
 * loads the FMU again finds the interpreter as it left it. */
static void finalize_at_exit(void)
{
    void *h = __atomic_load_n(&lib, __ATOMIC_ACQUIRE);
    void (*fin)(void);
    if (h == NULL) return;
    *(void **)&fin = dlsym(h, "finalizePythonInterpreter");
    if (fin) fin();
}

/* pythonfmu's binary, loaded by the caller under lib_lock; NULL with load_error set */
static void *open_pythonfmu(void)
{
    Dl_info info;
    char path[4096];
    size_t n;
    void *h = NULL;
    if (!dladdr((void *)&open_pythonfmu, &info) || info.dli_fname == NULL) {
        snprintf(load_error, sizeof load_error, "cannot find the front's own file");
        return NULL;
    }
    n = strlen(info.dli_fname);
    if (n < 3 || n + sizeof(SUFFIX) > sizeof(path)) {
        snprintf(load_error, sizeof load_error, "path of %lu characters", (unsigned long)n);
        return NULL;
    }
    memcpy(path, info.dli_fname, n - 3);          /* strip ".so" */
    memcpy(path + n - 3, SUFFIX, sizeof(SUFFIX));
    h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (h) {
        /* stay loaded as pythonfmu's binary does (its unique C++ symbols make glibc keep it
         * to the end): the exit handler below must outlive a host's dlclose */
        dlopen(info.dli_fname, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
        atexit(finalize_at_exit);
    } else {
        const char *e = dlerror();
        snprintf(load_error, sizeof load_error, "%.700s", e ? e : path);
    }
    return h;
}

static void *lib_sym(void *h, const char *name) { return dlsym(h, name); }

/* at exit (this library pins itself once it has loaded pythonfmu's): drop our reference */
__attribute__((destructor)) static void unload(void)
{
    void *h = __atomic_exchange_n(&lib, NULL, __ATOMIC_ACQ_REL);
    if (h) dlclose(h);
}
#else
/* Windows: pythonfmu's DLL (built with MSVC) needs no exit fix and is never freed here. On
 * DLL_PROCESS_DETACH the MSVC runtime calls a DLL's DllMain first and runs its static
 * destructors after it, so pythonfmu's DllMain (which resets the interpreter state) finds the
 * shared_ptr alive, and if its DllMain is not the one linked (pythonfmu declares it in an
 * anonymous namespace) the static destructor alone resets the state once: either way no reset
 * of a destroyed object, the glibc order of the use-after-free above does not arise. Its
 * interpreter thread, started through the C runtime, holds a reference to the DLL, so a
 * FreeLibrary here would not unload it, and freeing a library from DllMain (under the loader
 * lock) is forbidden. */
static void *open_pythonfmu(void)
{
    HMODULE self = NULL, h;
    wchar_t path[4096];
    DWORD n;
    size_t ext = wcslen(OWN_EXT), suf = wcslen(SUFFIX);
    if (!GetModuleHandleExW(GET_MODULE_HANDLE_EX_FLAG_FROM_ADDRESS
                            | GET_MODULE_HANDLE_EX_FLAG_UNCHANGED_REFCOUNT,
                            (LPCWSTR)(void *)&open_pythonfmu, &self)) {
        snprintf(load_error, sizeof load_error, "cannot find the front's own DLL (error %lu)",
                 (unsigned long)GetLastError());
        return NULL;
    }
    n = GetModuleFileNameW(self, path, sizeof path / sizeof path[0]);
    if (n == 0 || n >= sizeof path / sizeof path[0] - suf || n < ext
        || _wcsicmp(path + n - ext, OWN_EXT) != 0) {
        snprintf(load_error, sizeof load_error, "cannot name the front's own DLL");
        return NULL;
    }
    memcpy(path + n - ext, SUFFIX, (suf + 1) * sizeof(wchar_t));
    /* the DLL's own folder is searched for its dependencies (python3.dll: the documented
     * Python on PATH) */
    h = LoadLibraryExW(path, NULL, LOAD_WITH_ALTERED_SEARCH_PATH);
    if (h == NULL) {
        DWORD e = GetLastError();
        char msg[512] = "";
        FormatMessageA(FORMAT_MESSAGE_FROM_SYSTEM | FORMAT_MESSAGE_IGNORE_INSERTS, NULL, e, 0,
                       msg, sizeof msg, NULL);
        msg[strcspn(msg, "\r\n")] = '\0';
        snprintf(load_error, sizeof load_error, "%ls: error %lu %s", path, (unsigned long)e,
                 msg);
    }
    return (void *)h;
}

static void *lib_sym(void *h, const char *name)
{
    return (void *)GetProcAddress((HMODULE)h, name);
}
#endif

static void *load(void)
{
    void *h = __atomic_load_n(&lib, __ATOMIC_ACQUIRE);
    if (h) return h;
    lock(&lib_lock);
    h = lib;
    if (h == NULL) {
        h = open_pythonfmu();
        __atomic_store_n(&lib, h, __ATOMIC_RELEASE);
    }
    unlock(&lib_lock);
    return h;
}

/* why the binary did not load, copied under the lock (another thread may be retrying) */
static void why_not_loaded(char *out, size_t n)
{
    lock(&lib_lock);
    snprintf(out, n, "%s", load_error[0] ? load_error : "not found");
    unlock(&lib_lock);
}

static void *sym(const char *name)
{
    void *h = load();
    return h ? lib_sym(h, name) : NULL;
}

/* a function of pythonfmu's binary, resolved once per process (atomic publication) */
#define RESOLVE(var, name)                                                         \
    do {                                                                           \
        var = __atomic_load_n(&cache_##name, __ATOMIC_ACQUIRE);                    \
        if (!var) {                                                                \
            var = (name##TYPE *)sym(#name);                                        \
            __atomic_store_n(&cache_##name, var, __ATOMIC_RELEASE);                \
        }                                                                          \
    } while (0)

static fmi2Status map(fmi2Status s) { return s == fmi2Fatal ? fmi2Error : s; }

#ifndef FAILED_VR
#define FAILED_VR 0
#endif

/* -- the instance handle -------------------------------------------------------------------- */
#define WRAP_MAGIC 0x43465752u   /* "CFWR" */

enum { PH_INSTANTIATED = 1, PH_INIT, PH_STEP, PH_TERMINATED, PH_FAILED };

typedef struct Wrap {
    unsigned int magic;
    fmi2CallbackFunctions cb;     /* ours, handed to pythonfmu */
    fmi2CallbackFunctions host;
    int on;
    int phase;
    fmi2Component comp;           /* pythonfmu's */
    char name[128];
    struct Wrap *next;
} Wrap;

static Lock list_lock = LOCK_INIT;
static Wrap *wraps = NULL;

/* A message to the host: text with every '%' doubled, given as the message and no arguments.
 * FMI 2.0 calls the message a format, but hosts differ: FMI Library and fmpy's proxy format
 * it, a plain C host or fmpy's Python callback print it as it is (a "%s" with the text as its
 * argument would print "%s" there). Doubled, no directive is left for a formatting host
 * (which prints one '%') and a printing host shows '%%'. */
static void host_log(const fmi2CallbackFunctions *host, const char *name, fmi2Status st,
                     const char *text)
{
    char buf[2048];
    size_t i, k = 0;
    const char *cat = st == fmi2Error || st == fmi2Fatal ? "logStatusError"
                    : st == fmi2Warning ? "logStatusWarning" : "logAll";
    if (host == NULL || host->logger == NULL) return;
    for (i = 0; text && text[i] && k + 2 < sizeof buf; i++) {
        buf[k++] = text[i];
        if (text[i] == '%') buf[k++] = '%';
    }
    buf[k] = '\0';
    host->logger(host->componentEnvironment, name ? name : "", st, cat, buf);
}

/* the front's own messages: our fixed formats, arguments quoted by the caller */
static fmi2Status fail(Wrap *w, const char *fmt, ...)
{
    char buf[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    if (w) host_log(&w->host, w->name, fmi2Error, buf);
    return fmi2Error;
}

/* A user's string for a message: printable ASCII, at most 40 characters. */
static void quote(const char *s, char *out, size_t n)
{
    size_t i = 0, k = 0;
    if (s == NULL) { snprintf(out, n, "NULL"); return; }
    out[k++] = '\'';
    for (; s[i] && k + 5 < n && i < 40; i++)
        out[k++] = (s[i] >= 32 && s[i] < 127) ? s[i] : '?';
    if (s[i]) { out[k++] = '.'; out[k++] = '.'; out[k++] = '.'; }
    out[k++] = '\'';
    out[k] = '\0';
}

/* the host's handle, or NULL (a handle this front did not give out, or one already freed) */
static Wrap *handle(fmi2Component c)
{
    Wrap *w = (Wrap *)c;
    if (w == NULL || w->magic != WRAP_MAGIC) return NULL;
    return w;
}

static const char *const PHASE_NAMES[] = {"?", "Instantiated", "Initialization Mode",
                                          "Step Mode", "Terminated",
                                          "Error (failed initialization)"};

static fmi2Status not_in_phase(Wrap *w, const char *fn)
{
    if (w->phase == PH_FAILED)
        return fail(w, "%s: the instance failed in fmi2ExitInitializationMode (the reason was "
                    "logged there); only fmi2Get*, fmi2Reset and fmi2FreeInstance remain", fn);
    return fail(w, "%s is not allowed in state %s", fn, PHASE_NAMES[w->phase]);
}

#define ALLOW(fn, cond) \
    if (!(cond)) return not_in_phase(w, fn)

/* -- the model's variables (generated header; without it only the generic checks run) ------- */
#ifdef SHIM_VARS
/* defines SHIM_GUID, and per type T in Real, Integer, Boolean, String:
 * SHIM_PARAM_T[] (value references of the parameters), SHIM_PARAM_T_NAME[], SHIM_N_PARAM_T */
#include SHIM_VARS
#else
static const char SHIM_GUID[] = "";
#define SHIM_N_PARAM_Real 0
#define SHIM_N_PARAM_Integer 0
#define SHIM_N_PARAM_Boolean 0
#define SHIM_N_PARAM_String 0
static const fmi2ValueReference SHIM_PARAM_Real[1], SHIM_PARAM_Integer[1],
    SHIM_PARAM_Boolean[1], SHIM_PARAM_String[1];
static const char *const SHIM_PARAM_Real_NAME[1], *const SHIM_PARAM_Integer_NAME[1],
    *const SHIM_PARAM_Boolean_NAME[1], *const SHIM_PARAM_String_NAME[1];
#endif

/* the name of the first fixed parameter among vr[0..n), or NULL */
static const char *fixed_parameter(const fmi2ValueReference *vr, size_t n,
                                   const fmi2ValueReference *params,
                                   const char *const *names, size_t np)
{
    size_t i, k;
    for (i = 0; i < n; i++)
        for (k = 0; k < np; k++)
            if (params[k] == vr[i]) return names[k];
    return NULL;
}

/* -- the slave's failure flag --------------------------------------------------------------- */
static fmi2GetBooleanTYPE *cache_failed_get = NULL;

/* the slave's flag ``_failed``: set when the call just made failed (reason already logged);
 * fmi2Error then, else the call's own status */
static fmi2Status checked(Wrap *w, fmi2Status s)
{
    fmi2GetBooleanTYPE *get;
    const fmi2ValueReference vr = FAILED_VR;
    fmi2Boolean failed = fmi2False;
    if (s > fmi2Discard) return map(s);
    get = __atomic_load_n(&cache_failed_get, __ATOMIC_ACQUIRE);
    if (!get) {
        get = (fmi2GetBooleanTYPE *)sym("fmi2GetBoolean");
        __atomic_store_n(&cache_failed_get, get, __ATOMIC_RELEASE);
    }
    if (get && get(w->comp, &vr, 1, &failed) == fmi2OK && failed) return fmi2Error;
    return s;
}

/* -- logging -------------------------------------------------------------------------------- */
static void wlog(fmi2ComponentEnvironment env, fmi2String name, fmi2Status st, fmi2String cat,
                 fmi2String message, ...)
{
    Wrap *w = (Wrap *)env;
    char buf[2048];
    size_t i = 0, k = 0;
    (void)cat;
    if (w == NULL || w->host.logger == NULL) return;
    if ((st == fmi2OK || st == fmi2Pending) && !w->on) return;
    /* the text as it is, "%%" (the slaves' escape) read as "%"; never a format */
    if (message)
        for (; message[i] && k + 1 < sizeof buf; i++, k++) {
            buf[k] = message[i];
            if (message[i] == '%' && message[i + 1] == '%') i++;
        }
    buf[k] = '\0';
    host_log(&w->host, name ? name : w->name, map(st), buf);
}

/* -- common functions ----------------------------------------------------------------------- */
FMI2_Export const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
FMI2_Export const char *fmi2GetVersion(void) { return fmi2Version; }

static fmi2InstantiateTYPE *cache_fmi2Instantiate = NULL;
static fmi2FreeInstanceTYPE *cache_fmi2FreeInstance = NULL;

FMI2_Export fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType,
                                          fmi2String fmuGUID, fmi2String fmuResourceLocation,
                                          const fmi2CallbackFunctions *functions,
                                          fmi2Boolean visible, fmi2Boolean loggingOn)
{
    fmi2InstantiateTYPE *f;
    Wrap *w;
    char buf[1024], q[64];
    const char *name = instanceName ? instanceName : "";
    if (functions == NULL) return NULL;         /* nowhere to say why */
    if (instanceName == NULL || instanceName[0] == '\0') {
        host_log(functions, name, fmi2Error, "fmi2Instantiate: instanceName must be a "
                 "non-empty string");
        return NULL;
    }
    if (fmuType != fmi2CoSimulation) {
        host_log(functions, name, fmi2Error, "fmi2Instantiate: this FMU supports "
                 "Co-Simulation only (fmuType fmi2CoSimulation)");
        return NULL;
    }
    if (SHIM_GUID[0] && (fmuGUID == NULL || strcmp(fmuGUID, SHIM_GUID) != 0)) {
        quote(fmuGUID, q, sizeof q);
        snprintf(buf, sizeof buf, "fmi2Instantiate: GUID %s does not match this binary's %s "
                 "(modelDescription.xml of another build?)", q, SHIM_GUID);
        host_log(functions, name, fmi2Error, buf);
        return NULL;
    }
    if (fmuResourceLocation == NULL || strncmp(fmuResourceLocation, "file:", 5) != 0) {
        quote(fmuResourceLocation, q, sizeof q);
        snprintf(buf, sizeof buf, "fmi2Instantiate: fmuResourceLocation %s: a pythonfmu FMU "
                 "needs the file: URI of its resources folder", q);
        host_log(functions, name, fmi2Error, buf);
        return NULL;
    }
    RESOLVE(f, fmi2Instantiate);
    if (!f) {
        char why[768];
        why_not_loaded(why, sizeof why);
        snprintf(buf, sizeof buf, "cannot load the pythonfmu binary (%s): %s", why, NEEDS_PYTHON);
        host_log(functions, name, fmi2Error, buf);
        return NULL;
    }
    w = (Wrap *)calloc(1, sizeof *w);
    if (w == NULL) {
        host_log(functions, name, fmi2Error, "fmi2Instantiate: out of memory");
        return NULL;
    }
    w->magic = WRAP_MAGIC;
    w->host = *functions;
    w->cb = *functions;
    w->cb.logger = wlog;
    w->cb.componentEnvironment = w;
    w->on = loggingOn ? 1 : 0;
    w->phase = PH_INSTANTIATED;
    snprintf(w->name, sizeof w->name, "%s", name);
    w->comp = f(instanceName, fmuType, fmuGUID, fmuResourceLocation, &w->cb, visible, fmi2True);
    if (w->comp == NULL) {
        w->magic = 0;
        free(w);
        return NULL;
    }
    lock(&list_lock);
    w->next = wraps;
    wraps = w;
    unlock(&list_lock);
    return w;
}

FMI2_Export void fmi2FreeInstance(fmi2Component c)
{
    fmi2FreeInstanceTYPE *f;
    Wrap **p, *w = NULL;
    if (c == NULL) return;
    lock(&list_lock);
    for (p = &wraps; *p; p = &(*p)->next)
        if (*p == (Wrap *)c) {
            w = *p;
            *p = w->next;
            break;
        }
    unlock(&list_lock);
    if (w == NULL) return;                  /* not ours, or freed already */
    RESOLVE(f, fmi2FreeInstance);
    if (f) f(w->comp);
    w->magic = 0;
    free(w);
}

static fmi2SetDebugLoggingTYPE *cache_fmi2SetDebugLogging = NULL;

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n,
                                           const fmi2String cat[])
{
    fmi2SetDebugLoggingTYPE *f;
    Wrap *w = handle(c);
    size_t i;
    if (w == NULL) return fmi2Error;
    if (n && cat == NULL)
        return fail(w, "fmi2SetDebugLogging: %lu categories but no array", (unsigned long)n);
    for (i = 0; i < n; i++)
        if (cat[i] == NULL)
            return fail(w, "fmi2SetDebugLogging: category %lu is NULL", (unsigned long)i);
    RESOLVE(f, fmi2SetDebugLogging);
    if (!f) return fmi2Error;
    w->on = on ? 1 : 0;
    /* underneath logging stays on (all categories while the host's is off) */
    return map(on ? f(w->comp, fmi2True, n, cat) : f(w->comp, fmi2True, 0, NULL));
}

static fmi2SetupExperimentTYPE *cache_fmi2SetupExperiment = NULL;

FMI2_Export fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDef, fmi2Real tol,
                                           fmi2Real start, fmi2Boolean stopDef, fmi2Real stop)
{
    fmi2SetupExperimentTYPE *f;
    Wrap *w = handle(c);
    if (w == NULL) return fmi2Error;
    ALLOW("fmi2SetupExperiment", w->phase == PH_INSTANTIATED);
    if (!isfinite(start) || (stopDef && !(isfinite(stop) && stop >= start)))
        return fail(w, "fmi2SetupExperiment: startTime = %g, stopTime = %g: need a finite start "
                    "and, if defined, a finite stop not before it", start, stop);
    RESOLVE(f, fmi2SetupExperiment);
    if (!f) return fmi2Error;
    return map(f(w->comp, tolDef, tol, start, stopDef, stop));
}

/* A call on the component alone, allowed while ``allowed`` holds: the instance goes to phase
 * ``next`` when pythonfmu answers fmi2OK or fmi2Warning. (fmi2ExitInitializationMode, which
 * also reads the slave's failure flag, is written out below.) */
#define PHASE_FN(name, allowed, next)                                                  \
    static name##TYPE *cache_##name = NULL;                                            \
    FMI2_Export fmi2Status name(fmi2Component c)                                       \
    {                                                                                  \
        name##TYPE *f;                                                                 \
        fmi2Status s;                                                                  \
        Wrap *w = handle(c);                                                           \
        if (w == NULL) return fmi2Error;                                               \
        ALLOW(#name, allowed);                                                         \
        RESOLVE(f, name);                                                              \
        if (!f) return fmi2Error;                                                      \
        s = map(f(w->comp));                                                           \
        if (s <= fmi2Warning) w->phase = next;                                         \
        return s;                                                                      \
    }

PHASE_FN(fmi2EnterInitializationMode, w->phase == PH_INSTANTIATED, PH_INIT)
PHASE_FN(fmi2Terminate, w->phase == PH_STEP || w->phase == PH_INIT, PH_TERMINATED)
PHASE_FN(fmi2Reset, 1, PH_INSTANTIATED)      /* allowed in every phase (FMI 2.0) */

static fmi2ExitInitializationModeTYPE *cache_fmi2ExitInitializationMode = NULL;

FMI2_Export fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    fmi2ExitInitializationModeTYPE *f;
    fmi2Status s;
    Wrap *w = handle(c);
    if (w == NULL) return fmi2Error;
    ALLOW("fmi2ExitInitializationMode", w->phase == PH_INIT);
    RESOLVE(f, fmi2ExitInitializationMode);
    if (!f) return fmi2Error;
    s = checked(w, f(w->comp));
    w->phase = s <= fmi2Warning ? PH_STEP : PH_FAILED;
    return s;
}

/* -- get and set ---------------------------------------------------------------------------- */
/* What fmi2Set<T> may set now: nothing once terminated or failed; a parameter only before
 * fmi2ExitInitializationMode (``params``/``names``: the model's parameters of the type).
 * fmi2Get<T> may read in every phase. */
static fmi2Status set_allowed(Wrap *w, const char *fn, const fmi2ValueReference *vr, size_t n,
                              const fmi2ValueReference *params, const char *const *names,
                              size_t np)
{
    const char *p;
    if (!(w->phase == PH_INSTANTIATED || w->phase == PH_INIT || w->phase == PH_STEP))
        return not_in_phase(w, fn);
    if (w->phase == PH_STEP && np && (p = fixed_parameter(vr, n, params, names, np)) != NULL)
        return fail(w, "%s is a fixed parameter: set it before fmi2ExitInitializationMode", p);
    return fmi2OK;
}

static fmi2Status get_allowed(Wrap *w, const char *fn, const fmi2ValueReference *vr, size_t n,
                              const fmi2ValueReference *params, const char *const *names,
                              size_t np)
{
    (void)w; (void)fn; (void)vr; (void)n; (void)params; (void)names; (void)np;
    return fmi2OK;
}

#define get_QUAL
#define set_QUAL const
/* fmi2Get<K> (DIR get) and fmi2Set<K> (DIR set) of the C type T: the arrays checked, then
 * DIR's rule, then pythonfmu's function */
#define VALUE_FN(DIR, name, T, K)                                                      \
    static name##TYPE *cache_##name = NULL;                                            \
    FMI2_Export fmi2Status name(fmi2Component c, const fmi2ValueReference vr[], size_t n, \
                                DIR##_QUAL T v[])                                      \
    {                                                                                  \
        name##TYPE *f;                                                                 \
        fmi2Status s;                                                                  \
        Wrap *w = handle(c);                                                           \
        if (w == NULL) return fmi2Error;                                               \
        if (n && (vr == NULL || v == NULL))                                            \
            return fail(w, #name ": %lu values but no array", (unsigned long)n);       \
        s = DIR##_allowed(w, #name, vr, n, SHIM_PARAM_##K, SHIM_PARAM_##K##_NAME,      \
                          SHIM_N_PARAM_##K);                                           \
        if (s != fmi2OK) return s;                                                     \
        RESOLVE(f, name);                                                              \
        if (!f) return fmi2Error;                                                      \
        return map(f(w->comp, vr, n, v));                                              \
    }

VALUE_FN(get, fmi2GetReal, fmi2Real, Real)
VALUE_FN(get, fmi2GetInteger, fmi2Integer, Integer)
VALUE_FN(get, fmi2GetBoolean, fmi2Boolean, Boolean)
VALUE_FN(get, fmi2GetString, fmi2String, String)
VALUE_FN(set, fmi2SetReal, fmi2Real, Real)
VALUE_FN(set, fmi2SetInteger, fmi2Integer, Integer)
VALUE_FN(set, fmi2SetBoolean, fmi2Boolean, Boolean)
VALUE_FN(set, fmi2SetString, fmi2String, String)

/* -- FMU state ------------------------------------------------------------------------------
 * The front's own state around pythonfmu's: the phase of the instance (a state taken in Step
 * Mode restores Step Mode, as FMI 2.0 and hosts such as fmusim's --initial-fmu-state-file
 * expect) and pythonfmu's state. Serialised: "CFST", the phase (4 bytes), then pythonfmu's
 * bytes (the slave's JSON, checked by the slave when it is set). */
#define STATE_MAGIC 0x54534643u   /* "CFST" */
#define STATE_HEADER 8

typedef struct {
    unsigned int magic;
    int phase;
    fmi2FMUstate inner;
} WState;

static WState *wstate(Wrap *w, fmi2FMUstate s, const char *fn)
{
    WState *ws = (WState *)s;
    if (ws == NULL || ws->magic != STATE_MAGIC) {
        fail(w, "%s: not a state of this FMU", fn);
        return NULL;
    }
    return ws;
}

static fmi2GetFMUstateTYPE *cache_fmi2GetFMUstate = NULL;

FMI2_Export fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s)
{
    fmi2GetFMUstateTYPE *f;
    fmi2Status st;
    WState *ws;
    int fresh = 0;
    Wrap *w = handle(c);
    if (w == NULL) return fmi2Error;
    if (s == NULL) return fail(w, "fmi2GetFMUstate: NULL argument");
    RESOLVE(f, fmi2GetFMUstate);
    if (!f) return fmi2Error;
    if (*s != NULL) {                       /* overwrite a state of ours */
        if ((ws = wstate(w, *s, "fmi2GetFMUstate")) == NULL) return fmi2Error;
    } else {
        ws = (WState *)calloc(1, sizeof *ws);
        if (ws == NULL) return fail(w, "fmi2GetFMUstate: out of memory");
        ws->magic = STATE_MAGIC;
        fresh = 1;
    }
    st = map(f(w->comp, &ws->inner));
    if (st > fmi2Warning) {
        if (fresh) { ws->magic = 0; free(ws); }
        return st;
    }
    ws->phase = w->phase;
    *s = ws;
    return st;
}

static fmi2SetFMUstateTYPE *cache_fmi2SetFMUstate = NULL;

/* the slave checks a state before it takes it and reports a bad one through _failed */
FMI2_Export fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s)
{
    fmi2SetFMUstateTYPE *f;
    fmi2Status st;
    WState *ws;
    Wrap *w = handle(c);
    if (w == NULL) return fmi2Error;
    if ((ws = wstate(w, s, "fmi2SetFMUstate")) == NULL) return fmi2Error;
    RESOLVE(f, fmi2SetFMUstate);
    if (!f) return fmi2Error;
    st = checked(w, f(w->comp, ws->inner));
    if (st <= fmi2Warning) w->phase = ws->phase;
    return st;
}

static fmi2FreeFMUstateTYPE *cache_fmi2FreeFMUstate = NULL;

FMI2_Export fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s)
{
    fmi2FreeFMUstateTYPE *f;
    fmi2Status st = fmi2OK;
    WState *ws;
    Wrap *w = handle(c);
    if (w == NULL) return fmi2Error;
    if (s == NULL || *s == NULL) return fmi2OK;          /* nothing to free (FMI 2.0) */
    if ((ws = wstate(w, *s, "fmi2FreeFMUstate")) == NULL) return fmi2Error;
    RESOLVE(f, fmi2FreeFMUstate);
    if (!f) return fmi2Error;
    if (ws->inner) st = map(f(w->comp, &ws->inner));
    ws->magic = 0;
    free(ws);
    *s = NULL;
    return st;
}

static fmi2SerializedFMUstateSizeTYPE *cache_fmi2SerializedFMUstateSize = NULL;

FMI2_Export fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n)
{
    fmi2SerializedFMUstateSizeTYPE *f;
    fmi2Status st;
    WState *ws;
    Wrap *w = handle(c);
    if (w == NULL) return fmi2Error;
    if (n == NULL) return fail(w, "fmi2SerializedFMUstateSize: NULL argument");
    if ((ws = wstate(w, s, "fmi2SerializedFMUstateSize")) == NULL) return fmi2Error;
    RESOLVE(f, fmi2SerializedFMUstateSize);
    if (!f) return fmi2Error;
    st = map(f(w->comp, ws->inner, n));
    if (st <= fmi2Warning) *n += STATE_HEADER;
    return st;
}

static fmi2SerializeFMUstateTYPE *cache_fmi2SerializeFMUstate = NULL;

FMI2_Export fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[],
                                             size_t n)
{
    fmi2SerializeFMUstateTYPE *f;
    WState *ws;
    unsigned int magic = STATE_MAGIC;
    Wrap *w = handle(c);
    if (w == NULL) return fmi2Error;
    if (b == NULL || n < STATE_HEADER)
        return fail(w, "fmi2SerializeFMUstate: no buffer or one of %lu bytes",
                    (unsigned long)n);
    if ((ws = wstate(w, s, "fmi2SerializeFMUstate")) == NULL) return fmi2Error;
    RESOLVE(f, fmi2SerializeFMUstate);
    if (!f) return fmi2Error;
    memcpy(b, &magic, 4);
    memcpy(b + 4, &ws->phase, 4);
    return map(f(w->comp, ws->inner, b + STATE_HEADER, n - STATE_HEADER));
}

static fmi2DeSerializeFMUstateTYPE *cache_fmi2DeSerializeFMUstate = NULL;

FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n,
                                               fmi2FMUstate *s)
{
    fmi2DeSerializeFMUstateTYPE *f;
    fmi2Status st;
    WState *ws;
    unsigned int magic;
    int phase;
    Wrap *w = handle(c);
    if (w == NULL) return fmi2Error;
    if (b == NULL || s == NULL) return fail(w, "fmi2DeSerializeFMUstate: NULL argument");
    if (n < STATE_HEADER) return fail(w, "fmi2DeSerializeFMUstate: %lu bytes", (unsigned long)n);
    memcpy(&magic, b, 4);
    memcpy(&phase, b + 4, 4);
    if (magic != STATE_MAGIC || phase < PH_INSTANTIATED || phase > PH_FAILED)
        return fail(w, "fmi2DeSerializeFMUstate: not a state of this FMU");
    RESOLVE(f, fmi2DeSerializeFMUstate);
    if (!f) return fmi2Error;
    ws = (WState *)calloc(1, sizeof *ws);
    if (ws == NULL) return fail(w, "fmi2DeSerializeFMUstate: out of memory");
    ws->magic = STATE_MAGIC;
    ws->phase = phase;
    st = map(f(w->comp, b + STATE_HEADER, n - STATE_HEADER, &ws->inner));
    if (st > fmi2Warning || ws->inner == NULL) {
        ws->magic = 0;
        free(ws);
        return st > fmi2Warning ? st : fmi2Error;
    }
    if (*s != NULL) fmi2FreeFMUstate(c, s);     /* the host's old state of ours */
    *s = ws;
    return st;
}

/* -- not provided by pythonfmu: answered here ----------------------------------------------- */
FMI2_Export fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[],
                                                    size_t nu, const fmi2ValueReference z[],
                                                    size_t nz, const fmi2Real dv[],
                                                    fmi2Real df[])
{
    Wrap *w = handle(c);
    (void)u; (void)nu; (void)z; (void)nz; (void)dv; (void)df;
    return fail(w, "fmi2GetDirectionalDerivative: not provided "
                "(providesDirectionalDerivative = false)");
}

FMI2_Export fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                                   size_t n, const fmi2Integer o[],
                                                   const fmi2Real v[])
{
    Wrap *w = handle(c);
    (void)vr; (void)n; (void)o; (void)v;
    return fail(w, "fmi2SetRealInputDerivatives: not supported (canInterpolateInputs = false)");
}

FMI2_Export fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                                    size_t n, const fmi2Integer o[],
                                                    fmi2Real v[])
{
    Wrap *w = handle(c);
    (void)vr; (void)n; (void)o; (void)v;
    return fail(w, "fmi2GetRealOutputDerivatives: not supported (maxOutputDerivativeOrder = 0)");
}

/* -- co-simulation -------------------------------------------------------------------------- */
static fmi2DoStepTYPE *cache_fmi2DoStep = NULL;

/* a failed step returns False from do_step (fmi2Discard from pythonfmu): only then is the flag
 * read, so a good step costs no extra call into Python */
FMI2_Export fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noPrior)
{
    fmi2DoStepTYPE *f;
    fmi2Status s;
    Wrap *w = handle(c);
    if (w == NULL) return fmi2Error;
    ALLOW("fmi2DoStep", w->phase == PH_STEP);
    if (!isfinite(t) || !isfinite(h) || h < 0)
        return fail(w, "fmi2DoStep: currentCommunicationPoint = %g, communicationStepSize = %g: "
                    "need finite values and a step >= 0", t, h);
    RESOLVE(f, fmi2DoStep);
    if (!f) return fmi2Error;
    s = f(w->comp, t, h, noPrior);
    return s == fmi2Discard ? checked(w, s) : map(s);
}

FMI2_Export fmi2Status fmi2CancelStep(fmi2Component c)
{
    return fail(handle(c), "fmi2CancelStep: steps never run asynchronously");
}

static fmi2Status no_status(fmi2Component c)
{
    fail(handle(c), "fmi2GetXXXStatus: steps never run asynchronously; nothing to ask");
    return fmi2Discard;
}

/* fmi2GetStatus and its typed kin: nothing to ask (no asynchronous steps) */
#define STATUS_FN(name, T)                                                             \
    FMI2_Export fmi2Status name(fmi2Component c, const fmi2StatusKind k, T *v)         \
    {                                                                                  \
        (void)k; (void)v;                                                              \
        return no_status(c);                                                           \
    }

STATUS_FN(fmi2GetStatus, fmi2Status)
STATUS_FN(fmi2GetRealStatus, fmi2Real)
STATUS_FN(fmi2GetIntegerStatus, fmi2Integer)
STATUS_FN(fmi2GetBooleanStatus, fmi2Boolean)
STATUS_FN(fmi2GetStringStatus, fmi2String)

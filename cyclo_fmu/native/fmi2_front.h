/* The FMI 2.0 co-simulation front shared by the native FMUs: the reducer (fmi2_cycloid.c) and
 * the bench components (rig_fmi2.c). Included once by each of them (it defines functions):
 * instances and the host's callbacks, logging, the call sequence's phases, the functions whose
 * behaviour does not depend on the model (instantiation, set-up, Initialization Mode's entry,
 * terminate, reset, FMU state copies, the serialised state's GUID, the calls not provided).
 * The model's front keeps what is its own: its state, get/set, fmi2ExitInitializationMode,
 * fmi2DoStep, the check of a restored state.
 *
 * Behaviour: every misuse is answered with fmi2Error and a log message, never a crash; no
 * user text reaches a format string (messages go to the host preformatted, without '%');
 * memory through the host's callbacks when it gives both, else calloc/free.
 *
 * Before including it, the front defines:
 *   FRONT_STATE       its state's type: plain data with fields magic, version, phase, t_start
 *   FRONT_GUID        the GUID string this binary was built for
 *   FRONT_GUID_BYTES  bytes of the GUID at the head of a serialised state
 *   FRONT_BOTH_ALLOCATORS (optional) refuse a host that gives allocateMemory or freeMemory
 *                     alone (else such a host's instance uses calloc/free)
 * and after it a function ``static void set_defaults(FRONT_STATE *s)`` (a fresh instance).
 * Written for cyclo-fmu (MIT license); FMI headers: Modelica Association (2-clause BSD). */
#ifndef FMI2_FRONT_H
#define FMI2_FRONT_H

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

/* the phases of the FMI 2.0 co-simulation state machine the fronts track */
enum { FRONT_PH_INSTANTIATED = 1, FRONT_PH_INIT, FRONT_PH_STEP, FRONT_PH_TERMINATED };

typedef struct {
    FRONT_STATE s;
    fmi2CallbackLogger logger;
    fmi2CallbackAllocateMemory allocate;
    fmi2CallbackFreeMemory release;
    fmi2ComponentEnvironment env;
    char name[128];
    int logging_on;
} Instance;

static void set_defaults(FRONT_STATE *s);

static void *mem_alloc(Instance *c, size_t n)
{
    /* the host's allocator only together with its free */
    return (c->allocate && c->release) ? c->allocate(1, n) : calloc(1, n);
}

static void mem_free(Instance *c, void *p)
{
    if (c->allocate && c->release) c->release(p); else free(p);
}

/* The message goes to the host's logger preformatted and without '%' (loggers differ: some
 * format it again, fmpy's prints it as it is). */
static void logmsg(Instance *c, fmi2Status status, const char *fmt, ...)
{
    char buf[768];
    const char *category;
    size_t i;
    va_list ap;
    if (c == NULL || c->logger == NULL) return;
    if (status == fmi2OK && !c->logging_on) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    for (i = 0; buf[i]; i++)
        if (buf[i] == '%') buf[i] = '?';
    category = status == fmi2Error ? "logStatusError"
             : status == fmi2Warning ? "logStatusWarning" : "logAll";
    c->logger(c->env, c->name, status, category, buf);   /* no '%' left in it */
}

/* A user's string, quoted for a log message: printable ASCII only, at most 40 characters. */
static void quote(const char *s, char *out, size_t n)
{
    size_t i = 0, k = 0;
    if (s == NULL) { snprintf(out, n, "NULL"); return; }
    out[k++] = '\'';
    for (; s[i] && k + 5 < n && i < 40; i++)
        out[k++] = (s[i] >= 32 && s[i] < 127 && s[i] != '%') ? s[i] : '?';
    if (s[i]) { out[k++] = '.'; out[k++] = '.'; out[k++] = '.'; }
    out[k++] = '\'';
    out[k] = '\0';
}

#define CHECK_INSTANCE(fn) \
    Instance *c = (Instance *)comp; \
    if (c == NULL) return fmi2Error

static fmi2Status not_in_phase(Instance *c, const char *fn)
{
    static const char *const names[] = {"?", "Instantiated", "Initialization Mode",
                                        "Step Mode", "Terminated"};
    int p = c->s.phase >= FRONT_PH_INSTANTIATED && c->s.phase <= FRONT_PH_TERMINATED
            ? c->s.phase : 0;
    logmsg(c, fmi2Error, "%s is not allowed in state %s", fn, names[p]);
    return fmi2Error;
}

/* fmi2DoStep's arguments: finite, a step >= 0 (fmi2OK), else fmi2Error with the reason */
static fmi2Status step_arguments(Instance *c, double t, double h)
{
    if (isfinite(t) && isfinite(h) && h >= 0) return fmi2OK;
    logmsg(c, fmi2Error, "fmi2DoStep: currentCommunicationPoint = %g, communicationStepSize = "
           "%g: need finite values and a step >= 0", t, h);
    return fmi2Error;
}

/* -- common functions ----------------------------------------------------------------------- */
FMI2_Export const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
FMI2_Export const char *fmi2GetVersion(void) { return fmi2Version; }

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component comp, fmi2Boolean loggingOn,
                                           size_t nCategories, const fmi2String categories[])
{
    size_t i;
    CHECK_INSTANCE(fmi2SetDebugLogging);
    for (i = 0; i < nCategories; i++) {
        const char *k = categories ? categories[i] : NULL;
        if (k == NULL || (strcmp(k, "logStatusError") && strcmp(k, "logStatusWarning")
                          && strcmp(k, "logAll"))) {
            char q[64];
            quote(k, q, sizeof q);
            logmsg(c, fmi2Error, "fmi2SetDebugLogging: unknown log category %s (known: "
                   "logStatusError, logStatusWarning, logAll)", q);
            return fmi2Error;
        }
    }
    c->logging_on = loggingOn != fmi2False;
    return fmi2OK;
}

FMI2_Export fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType,
                                          fmi2String fmuGUID, fmi2String fmuResourceLocation,
                                          const fmi2CallbackFunctions *functions,
                                          fmi2Boolean visible, fmi2Boolean loggingOn)
{
    Instance tmp, *c;
    (void)fmuResourceLocation;
    (void)visible;
    memset(&tmp, 0, sizeof tmp);
    if (functions) {
        tmp.logger = functions->logger;
        tmp.allocate = functions->allocateMemory;
        tmp.release = functions->freeMemory;
        tmp.env = functions->componentEnvironment;
    }
    snprintf(tmp.name, sizeof tmp.name, "%s", instanceName ? instanceName : "");
    tmp.logging_on = loggingOn != fmi2False;
    if (fmuType != fmi2CoSimulation) {
        logmsg(&tmp, fmi2Error, "fmi2Instantiate: this FMU supports Co-Simulation only");
        return NULL;
    }
#ifdef FRONT_BOTH_ALLOCATORS
    /* the host's allocator and ours never mix: a block from allocateMemory must go back
     * through freeMemory, so both or neither */
    if ((tmp.allocate == NULL) != (tmp.release == NULL)) {
        logmsg(&tmp, fmi2Error, "fmi2Instantiate: the callbacks give %s but not %s (both or "
               "neither)", tmp.allocate ? "allocateMemory" : "freeMemory",
               tmp.allocate ? "freeMemory" : "allocateMemory");
        return NULL;
    }
#endif
    if (fmuGUID == NULL || strcmp(fmuGUID, FRONT_GUID) != 0) {
        char q[64];
        quote(fmuGUID, q, sizeof q);
        logmsg(&tmp, fmi2Error, "fmi2Instantiate: GUID %s does not match this binary's %s "
               "(modelDescription.xml of another build?)", q, FRONT_GUID);
        return NULL;
    }
    c = (Instance *)mem_alloc(&tmp, sizeof *c);
    if (c == NULL) {
        logmsg(&tmp, fmi2Error, "fmi2Instantiate: out of memory");
        return NULL;
    }
    *c = tmp;
    set_defaults(&c->s);
    return c;
}

FMI2_Export void fmi2FreeInstance(fmi2Component comp)
{
    Instance *c = (Instance *)comp;
    if (c) {
        Instance copy = *c;      /* the callbacks, read after the block is gone */
        mem_free(&copy, c);
    }
}

FMI2_Export fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean toleranceDefined,
                                           fmi2Real tolerance, fmi2Real startTime,
                                           fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    CHECK_INSTANCE(fmi2SetupExperiment);
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    if (c->s.phase != FRONT_PH_INSTANTIATED) return not_in_phase(c, "fmi2SetupExperiment");
    if (!isfinite(startTime)) {
        logmsg(c, fmi2Error, "fmi2SetupExperiment: startTime = %g must be finite", startTime);
        return fmi2Error;
    }
    c->s.t_start = startTime;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2EnterInitializationMode(fmi2Component comp)
{
    CHECK_INSTANCE(fmi2EnterInitializationMode);
    if (c->s.phase != FRONT_PH_INSTANTIATED)
        return not_in_phase(c, "fmi2EnterInitializationMode");
    c->s.phase = FRONT_PH_INIT;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2Terminate(fmi2Component comp)
{
    CHECK_INSTANCE(fmi2Terminate);
    if (c->s.phase != FRONT_PH_STEP && c->s.phase != FRONT_PH_INIT)
        return not_in_phase(c, "fmi2Terminate");
    c->s.phase = FRONT_PH_TERMINATED;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2Reset(fmi2Component comp)
{
    CHECK_INSTANCE(fmi2Reset);
    set_defaults(&c->s);
    return fmi2OK;
}

static fmi2Status bad_vr(Instance *c, const char *fn, unsigned int vr)
{
    logmsg(c, fmi2Error, "%s: no variable with value reference %u", fn, vr);
    return fmi2Error;
}

/* -- FMU state: copies of FRONT_STATE; serialised as the GUID (fixed length, so a state of
 * another build is refused) followed by FRONT_STATE ------------------------------------------ */
FMI2_Export fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate *FMUstate)
{
    FRONT_STATE *copy;
    CHECK_INSTANCE(fmi2GetFMUstate);
    if (FMUstate == NULL) return fmi2Error;
    copy = (FRONT_STATE *)(*FMUstate ? *FMUstate : mem_alloc(c, sizeof *copy));
    if (copy == NULL) {
        logmsg(c, fmi2Error, "fmi2GetFMUstate: out of memory");
        return fmi2Error;
    }
    *copy = c->s;
    *FMUstate = copy;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2FreeFMUstate(fmi2Component comp, fmi2FMUstate *FMUstate)
{
    CHECK_INSTANCE(fmi2FreeFMUstate);
    if (FMUstate == NULL) return fmi2OK;
    if (*FMUstate) mem_free(c, *FMUstate);
    *FMUstate = NULL;
    return fmi2OK;
}

static void guid_bytes(char out[FRONT_GUID_BYTES])
{
    size_t n = strlen(FRONT_GUID);
    memset(out, 0, FRONT_GUID_BYTES);
    memcpy(out, FRONT_GUID, n < FRONT_GUID_BYTES ? n : FRONT_GUID_BYTES);
}

FMI2_Export fmi2Status fmi2SerializedFMUstateSize(fmi2Component comp, fmi2FMUstate FMUstate,
                                                  size_t *size)
{
    CHECK_INSTANCE(fmi2SerializedFMUstateSize);
    (void)FMUstate;
    if (size == NULL) return fmi2Error;
    *size = FRONT_GUID_BYTES + sizeof(FRONT_STATE);
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SerializeFMUstate(fmi2Component comp, fmi2FMUstate FMUstate,
                                             fmi2Byte serializedState[], size_t size)
{
    char guid[FRONT_GUID_BYTES];
    CHECK_INSTANCE(fmi2SerializeFMUstate);
    if (FMUstate == NULL || serializedState == NULL
        || size < FRONT_GUID_BYTES + sizeof(FRONT_STATE)) {
        logmsg(c, fmi2Error, "fmi2SerializeFMUstate: no state, or a buffer of %lu bytes "
               "smaller than %lu", (unsigned long)size,
               (unsigned long)(FRONT_GUID_BYTES + sizeof(FRONT_STATE)));
        return fmi2Error;
    }
    guid_bytes(guid);
    memcpy(serializedState, guid, FRONT_GUID_BYTES);
    memcpy(serializedState + FRONT_GUID_BYTES, FMUstate, sizeof(FRONT_STATE));
    return fmi2OK;
}

/* -- not provided ---------------------------------------------------------------------------- */
FMI2_Export fmi2Status fmi2GetDirectionalDerivative(fmi2Component comp,
        const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
        const fmi2ValueReference vKnown_ref[], size_t nKnown, const fmi2Real dvKnown[],
        fmi2Real dvUnknown[])
{
    CHECK_INSTANCE(fmi2GetDirectionalDerivative);
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown;
    (void)dvUnknown;
    logmsg(c, fmi2Error, "fmi2GetDirectionalDerivative: not provided "
           "(providesDirectionalDerivative = false)");
    return fmi2Error;
}

FMI2_Export fmi2Status fmi2SetRealInputDerivatives(fmi2Component comp,
        const fmi2ValueReference vr[], size_t nvr, const fmi2Integer order[],
        const fmi2Real value[])
{
    CHECK_INSTANCE(fmi2SetRealInputDerivatives);
    (void)vr; (void)nvr; (void)order; (void)value;
    logmsg(c, fmi2Error, "fmi2SetRealInputDerivatives: not supported "
           "(canInterpolateInputs = false)");
    return fmi2Error;
}

FMI2_Export fmi2Status fmi2GetRealOutputDerivatives(fmi2Component comp,
        const fmi2ValueReference vr[], size_t nvr, const fmi2Integer order[], fmi2Real value[])
{
    CHECK_INSTANCE(fmi2GetRealOutputDerivatives);
    (void)vr; (void)nvr; (void)order; (void)value;
    logmsg(c, fmi2Error, "fmi2GetRealOutputDerivatives: not supported "
           "(maxOutputDerivativeOrder = 0)");
    return fmi2Error;
}

FMI2_Export fmi2Status fmi2CancelStep(fmi2Component comp)
{
    CHECK_INSTANCE(fmi2CancelStep);
    logmsg(c, fmi2Error, "fmi2CancelStep: steps never run asynchronously");
    return fmi2Error;
}

static fmi2Status no_status(Instance *c)
{
    logmsg(c, fmi2Error, "fmi2GetXXXStatus: steps never run asynchronously; nothing to ask");
    return fmi2Discard;
}

#define STATUS_FN(fn, ctype) \
FMI2_Export fmi2Status fn(fmi2Component comp, const fmi2StatusKind s, ctype *value) \
{ \
    CHECK_INSTANCE(fn); \
    (void)s; (void)value; \
    return no_status(c); \
}

STATUS_FN(fmi2GetStatus, fmi2Status)
STATUS_FN(fmi2GetRealStatus, fmi2Real)
STATUS_FN(fmi2GetIntegerStatus, fmi2Integer)
STATUS_FN(fmi2GetBooleanStatus, fmi2Boolean)
STATUS_FN(fmi2GetStringStatus, fmi2String)

#endif

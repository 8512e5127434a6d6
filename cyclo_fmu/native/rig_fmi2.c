/* The FMI 2.0 co-simulation front shared by the native bench components (motor, brake,
 * transducers): instances, the call sequence, get/set over the generated variable table, FMU
 * state, logging. The physics is the component's (rig_model.h). Behaviour as the native
 * reducer's front: every misuse is answered with fmi2Error and a log message, never a crash;
 * no user text reaches a format string; memory through the host's callbacks when it gives
 * both, else calloc/free. Written for cyclo-fmu (MIT license); FMI headers: Modelica
 * Association (2-clause BSD). */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "rig_model.h"
#include "rig_table.h"

#define STATE_MAGIC 0x52494753u   /* "RIGS" */
#define STATE_VERSION 1u
#define GUID_BYTES 48

typedef struct {
    RigState s;
    fmi2CallbackLogger logger;
    fmi2CallbackAllocateMemory allocate;
    fmi2CallbackFreeMemory release;
    fmi2ComponentEnvironment env;
    char name[128];
    int logging_on;
} Instance;

static void *mem_alloc(Instance *c, size_t n)
{
    /* the host's allocator only together with its free */
    return (c->allocate && c->release) ? c->allocate(1, n) : calloc(1, n);
}

static void mem_free(Instance *c, void *p)
{
    if (c->allocate && c->release) c->release(p); else free(p);
}

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
    for (i = 0; buf[i]; i++)        /* loggers may format the message again */
        if (buf[i] == '%') buf[i] = '?';
    category = status == fmi2Error ? "logStatusError"
             : status == fmi2Warning ? "logStatusWarning" : "logAll";
    c->logger(c->env, c->name, status, category, buf);   /* no '%' left in it */
}

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

static void set_defaults(RigState *s)
{
    int k;
    memset(s, 0, sizeof *s);
    s->magic = STATE_MAGIC;
    s->version = STATE_VERSION;
    s->phase = RIG_PH_INSTANTIATED;
    s->n_schedule = -1;
    for (k = 0; k < RIG_NVARS; k++) {
        const RigVar *v = &RIG_VARS[k];
        if (v->type == 'R') s->r[v->slot] = v->start;
        else if (v->type == 'I') s->i[v->slot] = (int)v->start;
        else if (v->type == 'B') s->b[v->slot] = v->start != 0.0;
        else snprintf(s->s[v->slot], RIG_STRLEN, "%s", v->start_string ? v->start_string : "");
    }
}

static const RigVar *find(unsigned int vr, char type)
{
    int k;
    for (k = 0; k < RIG_NVARS; k++)
        if (RIG_VARS[k].vr == vr && RIG_VARS[k].type == type) return &RIG_VARS[k];
    return NULL;
}

static fmi2Status not_in_phase(Instance *c, const char *fn)
{
    static const char *const names[] = {"?", "Instantiated", "Initialization Mode",
                                        "Step Mode", "Terminated"};
    int p = c->s.phase >= RIG_PH_INSTANTIATED && c->s.phase <= RIG_PH_TERMINATED ? c->s.phase : 0;
    logmsg(c, fmi2Error, "%s is not allowed in state %s", fn, names[p]);
    return fmi2Error;
}

#define CHECK_INSTANCE(fn) \
    Instance *c = (Instance *)comp; \
    if (c == NULL) return fmi2Error

/* Initialization Mode: the outputs follow the inputs and parameters set so far (f_init); a
 * refusal is reported by fmi2ExitInitializationMode */
static void refresh(Instance *c)
{
    char msg[512];
    if (c->s.phase != RIG_PH_INIT && c->s.phase != RIG_PH_INSTANTIATED) return;
    msg[0] = '\0';
    if (rig_setup(&c->s, msg, sizeof msg) == 0) rig_init(&c->s, msg, sizeof msg);
}

/* -- common functions ----------------------------------------------------------------------- */
FMI2_Export const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
FMI2_Export const char *fmi2GetVersion(void) { return fmi2Version; }

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component comp, fmi2Boolean loggingOn,
                                           size_t nCategories, const fmi2String categories[])
{
    size_t i;
    CHECK_INSTANCE(fmi2SetDebugLogging);
    if (nCategories && categories == NULL) return fmi2Error;
    for (i = 0; i < nCategories; i++) {
        const char *k = categories[i];
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
    if (fmuGUID == NULL || strcmp(fmuGUID, RIG_GUID) != 0) {
        char q[64];
        quote(fmuGUID, q, sizeof q);
        logmsg(&tmp, fmi2Error, "fmi2Instantiate: GUID %s does not match this binary's %s "
               "(modelDescription.xml of another build?)", q, RIG_GUID);
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
        Instance copy = *c;
        mem_free(&copy, c);
    }
}

FMI2_Export fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean toleranceDefined,
                                           fmi2Real tolerance, fmi2Real startTime,
                                           fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    CHECK_INSTANCE(fmi2SetupExperiment);
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    if (c->s.phase != RIG_PH_INSTANTIATED) return not_in_phase(c, "fmi2SetupExperiment");
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
    if (c->s.phase != RIG_PH_INSTANTIATED) return not_in_phase(c, "fmi2EnterInitializationMode");
    c->s.phase = RIG_PH_INIT;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2ExitInitializationMode(fmi2Component comp)
{
    char msg[512];
    CHECK_INSTANCE(fmi2ExitInitializationMode);
    if (c->s.phase != RIG_PH_INIT) return not_in_phase(c, "fmi2ExitInitializationMode");
    msg[0] = '\0';
    if (rig_setup(&c->s, msg, sizeof msg) != 0) {
        logmsg(c, fmi2Error, "invalid parameter: %s", msg);
        return fmi2Error;
    }
    if (rig_init(&c->s, msg, sizeof msg) != 0) {
        logmsg(c, fmi2Error, "%s", msg);
        return fmi2Error;
    }
    c->s.phase = RIG_PH_STEP;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2Terminate(fmi2Component comp)
{
    CHECK_INSTANCE(fmi2Terminate);
    if (c->s.phase != RIG_PH_STEP && c->s.phase != RIG_PH_INIT)
        return not_in_phase(c, "fmi2Terminate");
    c->s.phase = RIG_PH_TERMINATED;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2Reset(fmi2Component comp)
{
    CHECK_INSTANCE(fmi2Reset);
    set_defaults(&c->s);
    return fmi2OK;
}

/* -- get and set ---------------------------------------------------------------------------- */
static fmi2Status bad_vr(Instance *c, const char *fn, unsigned int vr)
{
    logmsg(c, fmi2Error, "%s: no variable with value reference %u", fn, vr);
    return fmi2Error;
}

#define GETTER(fn, ctype, TYPE, expr) \
FMI2_Export fmi2Status fn(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, \
                          ctype value[]) \
{ \
    size_t k; \
    CHECK_INSTANCE(fn); \
    if (nvr == 0) return fmi2OK; \
    if (vr == NULL || value == NULL) { \
        logmsg(c, fmi2Error, #fn ": NULL value reference or value array"); \
        return fmi2Error; \
    } \
    if (c->s.phase == RIG_PH_INIT) refresh(c); \
    for (k = 0; k < nvr; k++) { \
        const RigVar *v = find(vr[k], TYPE); \
        if (v == NULL) return bad_vr(c, #fn, vr[k]); \
        value[k] = expr; \
    } \
    return fmi2OK; \
}

GETTER(fmi2GetReal, fmi2Real, 'R', c->s.r[v->slot])
GETTER(fmi2GetInteger, fmi2Integer, 'I', c->s.i[v->slot])
GETTER(fmi2GetBoolean, fmi2Boolean, 'B', c->s.b[v->slot] ? fmi2True : fmi2False)
GETTER(fmi2GetString, fmi2String, 'S', c->s.s[v->slot])

/* May v be set now? Parameters before Step Mode, inputs until Terminated. */
static int settable(Instance *c, const RigVar *v, const char *fn)
{
    if (c->s.phase == RIG_PH_TERMINATED) {
        not_in_phase(c, fn);
        return 0;
    }
    if (v->causality == RIG_INPUT) return 1;
    if (v->causality == RIG_PARAMETER) {
        if (c->s.phase == RIG_PH_INSTANTIATED || c->s.phase == RIG_PH_INIT) return 1;
        logmsg(c, fmi2Error, "%s is a fixed parameter: set it before fmi2ExitInitializationMode",
               v->name);
        return 0;
    }
    logmsg(c, fmi2Error, "%s: %s is an output, it cannot be set", fn, v->name);
    return 0;
}

static int in_range(Instance *c, const RigVar *v, double x)
{
    if (v->type == 'R' && !isfinite(x)) {
        logmsg(c, fmi2Error, "%s = %g: must be a finite number (kept %g)", v->name, x,
               c->s.r[v->slot]);
        return 0;
    }
    if ((v->has_min && x < v->min) || (v->has_max && x > v->max)) {
        logmsg(c, fmi2Error, "invalid parameter: %s = %g outside its declared range [%g, %g]",
               v->name, x, v->has_min ? v->min : -HUGE_VAL, v->has_max ? v->max : HUGE_VAL);
        return 0;
    }
    return 1;
}

#define SETTER(fn, ctype, TYPE, assign, number) \
FMI2_Export fmi2Status fn(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, \
                          const ctype value[]) \
{ \
    size_t k; \
    fmi2Status status = fmi2OK; \
    CHECK_INSTANCE(fn); \
    if (nvr == 0) return fmi2OK; \
    if (vr == NULL || value == NULL) { \
        logmsg(c, fmi2Error, #fn ": NULL value reference or value array"); \
        return fmi2Error; \
    } \
    for (k = 0; k < nvr; k++) { \
        const RigVar *v = find(vr[k], TYPE); \
        if (v == NULL) return bad_vr(c, #fn, vr[k]); \
        if (!settable(c, v, #fn) || !in_range(c, v, number)) { status = fmi2Error; continue; } \
        assign; \
    } \
    return status; \
}

SETTER(fmi2SetReal, fmi2Real, 'R', c->s.r[v->slot] = value[k], value[k])
SETTER(fmi2SetInteger, fmi2Integer, 'I', c->s.i[v->slot] = value[k], (double)value[k])
SETTER(fmi2SetBoolean, fmi2Boolean, 'B', c->s.b[v->slot] = value[k] != fmi2False, 0.0)

FMI2_Export fmi2Status fmi2SetString(fmi2Component comp, const fmi2ValueReference vr[],
                                     size_t nvr, const fmi2String value[])
{
    size_t k;
    fmi2Status status = fmi2OK;
    CHECK_INSTANCE(fmi2SetString);
    if (nvr == 0) return fmi2OK;
    if (vr == NULL || value == NULL) {
        logmsg(c, fmi2Error, "fmi2SetString: NULL value reference or value array");
        return fmi2Error;
    }
    for (k = 0; k < nvr; k++) {
        const RigVar *v = find(vr[k], 'S');
        if (v == NULL) return bad_vr(c, "fmi2SetString", vr[k]);
        if (!settable(c, v, "fmi2SetString")) { status = fmi2Error; continue; }
        if (value[k] == NULL || strlen(value[k]) >= RIG_STRLEN) {
            logmsg(c, fmi2Error, "%s: %s (at most %d bytes)", v->name,
                   value[k] == NULL ? "NULL string" : "string too long", RIG_STRLEN - 1);
            status = fmi2Error;
            continue;
        }
        snprintf(c->s.s[v->slot], RIG_STRLEN, "%s", value[k]);
    }
    return status;
}

/* -- FMU state ------------------------------------------------------------------------------ */
static int state_valid(const RigState *s)
{
    int k;
    char msg[256];
    RigState tmp;
    if (s->magic != STATE_MAGIC || s->version != STATE_VERSION) return 0;
    if (s->phase < RIG_PH_INSTANTIATED || s->phase > RIG_PH_TERMINATED) return 0;
    if (!isfinite(s->t_start)) return 0;
    for (k = 0; k < RIG_NR; k++) if (!isfinite(s->r[k])) return 0;
    for (k = 0; k < RIG_NX; k++) if (!isfinite(s->x[k])) return 0;
    for (k = 0; k < RIG_NS; k++) if (memchr(s->s[k], '\0', RIG_STRLEN) == NULL) return 0;
    for (k = 0; k < RIG_NVARS; k++) {
        const RigVar *v = &RIG_VARS[k];
        double x = v->type == 'R' ? s->r[v->slot] : v->type == 'I' ? s->i[v->slot] : 0.0;
        if ((v->has_min && x < v->min) || (v->has_max && x > v->max)) return 0;
    }
    if (s->n_schedule < -1 || s->n_schedule > RIG_MAX_SCHEDULE) return 0;
    /* the parameters pass the component's own check, and the schedule is the one they give */
    if (s->phase == RIG_PH_STEP) {
        tmp = *s;
        if (rig_setup(&tmp, msg, sizeof msg) != 0) return 0;
        if (tmp.n_schedule != s->n_schedule
            || (s->n_schedule > 0 && memcmp(tmp.schedule, s->schedule,
                                            sizeof(double) * 2 * (size_t)s->n_schedule) != 0))
            return 0;
    }
    return rig_state_valid(s);
}

FMI2_Export fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate *FMUstate)
{
    RigState *copy;
    CHECK_INSTANCE(fmi2GetFMUstate);
    if (FMUstate == NULL) return fmi2Error;
    copy = (RigState *)(*FMUstate ? *FMUstate : mem_alloc(c, sizeof *copy));
    if (copy == NULL) {
        logmsg(c, fmi2Error, "fmi2GetFMUstate: out of memory");
        return fmi2Error;
    }
    *copy = c->s;
    *FMUstate = copy;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate FMUstate)
{
    const RigState *s = (const RigState *)FMUstate;
    CHECK_INSTANCE(fmi2SetFMUstate);
    if (s == NULL || !state_valid(s)) {
        logmsg(c, fmi2Error, "fmi2SetFMUstate: not a state of this FMU");
        return fmi2Error;
    }
    c->s = *s;
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

static void guid_bytes(char out[GUID_BYTES])
{
    size_t n = strlen(RIG_GUID);
    memset(out, 0, GUID_BYTES);
    memcpy(out, RIG_GUID, n < GUID_BYTES ? n : GUID_BYTES);
}

FMI2_Export fmi2Status fmi2SerializedFMUstateSize(fmi2Component comp, fmi2FMUstate FMUstate,
                                                  size_t *size)
{
    CHECK_INSTANCE(fmi2SerializedFMUstateSize);
    (void)FMUstate;
    if (size == NULL) return fmi2Error;
    *size = GUID_BYTES + sizeof(RigState);
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SerializeFMUstate(fmi2Component comp, fmi2FMUstate FMUstate,
                                             fmi2Byte serializedState[], size_t size)
{
    char guid[GUID_BYTES];
    CHECK_INSTANCE(fmi2SerializeFMUstate);
    if (FMUstate == NULL || serializedState == NULL || size < GUID_BYTES + sizeof(RigState)) {
        logmsg(c, fmi2Error, "fmi2SerializeFMUstate: no state, or a buffer of %lu bytes "
               "smaller than %lu", (unsigned long)size,
               (unsigned long)(GUID_BYTES + sizeof(RigState)));
        return fmi2Error;
    }
    guid_bytes(guid);
    memcpy(serializedState, guid, GUID_BYTES);
    memcpy(serializedState + GUID_BYTES, FMUstate, sizeof(RigState));
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp,
                                               const fmi2Byte serializedState[], size_t size,
                                               fmi2FMUstate *FMUstate)
{
    char guid[GUID_BYTES];
    RigState *s, *dst;
    CHECK_INSTANCE(fmi2DeSerializeFMUstate);
    if (serializedState == NULL || FMUstate == NULL || size != GUID_BYTES + sizeof(RigState)) {
        logmsg(c, fmi2Error, "fmi2DeSerializeFMUstate: %lu bytes, expected %lu",
               (unsigned long)size, (unsigned long)(GUID_BYTES + sizeof(RigState)));
        return fmi2Error;
    }
    s = (RigState *)mem_alloc(c, sizeof *s);
    if (s == NULL) {
        logmsg(c, fmi2Error, "fmi2DeSerializeFMUstate: out of memory");
        return fmi2Error;
    }
    guid_bytes(guid);
    memcpy(s, serializedState + GUID_BYTES, sizeof *s);
    if (memcmp(serializedState, guid, GUID_BYTES) != 0 || !state_valid(s)) {
        mem_free(c, s);
        logmsg(c, fmi2Error, "fmi2DeSerializeFMUstate: not a state of this FMU (GUID %s)",
               RIG_GUID);
        return fmi2Error;
    }
    if (*FMUstate) {
        dst = (RigState *)*FMUstate;
        *dst = *s;
        mem_free(c, s);
    } else {
        *FMUstate = s;
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetDirectionalDerivative(fmi2Component comp,
        const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
        const fmi2ValueReference vKnown_ref[], size_t nKnown, const fmi2Real dvKnown[],
        fmi2Real dvUnknown[])
{
    CHECK_INSTANCE(fmi2GetDirectionalDerivative);
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown;
    (void)dvUnknown;
    logmsg(c, fmi2Error, "fmi2GetDirectionalDerivative: not provided");
    return fmi2Error;
}

/* -- co-simulation -------------------------------------------------------------------------- */
FMI2_Export fmi2Status fmi2SetRealInputDerivatives(fmi2Component comp,
        const fmi2ValueReference vr[], size_t nvr, const fmi2Integer order[],
        const fmi2Real value[])
{
    CHECK_INSTANCE(fmi2SetRealInputDerivatives);
    (void)vr; (void)nvr; (void)order; (void)value;
    logmsg(c, fmi2Error, "fmi2SetRealInputDerivatives: not supported (canInterpolateInputs = false)");
    return fmi2Error;
}

FMI2_Export fmi2Status fmi2GetRealOutputDerivatives(fmi2Component comp,
        const fmi2ValueReference vr[], size_t nvr, const fmi2Integer order[], fmi2Real value[])
{
    CHECK_INSTANCE(fmi2GetRealOutputDerivatives);
    (void)vr; (void)nvr; (void)order; (void)value;
    logmsg(c, fmi2Error, "fmi2GetRealOutputDerivatives: not supported");
    return fmi2Error;
}

FMI2_Export fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real currentCommunicationPoint,
                                  fmi2Real communicationStepSize,
                                  fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    char msg[512];
    CHECK_INSTANCE(fmi2DoStep);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (c->s.phase != RIG_PH_STEP) return not_in_phase(c, "fmi2DoStep");
    if (!isfinite(currentCommunicationPoint) || !isfinite(communicationStepSize)
        || communicationStepSize < 0) {
        logmsg(c, fmi2Error, "fmi2DoStep: currentCommunicationPoint = %g, "
               "communicationStepSize = %g: need finite values and a step >= 0",
               currentCommunicationPoint, communicationStepSize);
        return fmi2Error;
    }
    msg[0] = '\0';
    if (rig_step(&c->s, currentCommunicationPoint, communicationStepSize, msg, sizeof msg)) {
        logmsg(c, fmi2Error, "%s", msg);
        return fmi2Error;
    }
    return fmi2OK;
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

/* The FMI 2.0 co-simulation front of the native bench components (motor, brake, transducers):
 * get/set over the generated variable table, the call sequence's model steps, the check of a
 * restored state. The physics is the component's (rig_model.h); instances, logging, phases and
 * the model-independent calls are the front shared with the reducer (fmi2_front.h). Behaviour
 * as the native reducer's front: every misuse is answered with fmi2Error and a log message,
 * never a crash; no user text reaches a format string; memory through the host's callbacks
 * when it gives both, else calloc/free. Written for cyclo-fmu (MIT license); FMI headers:
 * Modelica Association (2-clause BSD). */
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

/* the FMI 2.0 front shared with the reducer (instances, logging, phases, the model-independent
 * calls): fmi2_front.h */
#define FRONT_STATE RigState
#define FRONT_GUID RIG_GUID
#define FRONT_GUID_BYTES 48
#include "fmi2_front.h"

/* the components' phases (rig_model.h) are the front's */
typedef char rig_phases_are_the_fronts[((int)RIG_PH_INSTANTIATED == (int)FRONT_PH_INSTANTIATED
                                        && (int)RIG_PH_INIT == (int)FRONT_PH_INIT
                                        && (int)RIG_PH_STEP == (int)FRONT_PH_STEP
                                        && (int)RIG_PH_TERMINATED == (int)FRONT_PH_TERMINATED)
                                       ? 1 : -1];

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

/* Initialization Mode: the outputs follow the inputs and parameters set so far (f_init); a
 * refusal is reported by fmi2ExitInitializationMode */
static void refresh(Instance *c)
{
    char msg[512];
    if (c->s.phase != RIG_PH_INIT && c->s.phase != RIG_PH_INSTANTIATED) return;
    msg[0] = '\0';
    if (rig_setup(&c->s, msg, sizeof msg) == 0) rig_init(&c->s, msg, sizeof msg);
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

/* -- get and set ---------------------------------------------------------------------------- */
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

FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp,
                                               const fmi2Byte serializedState[], size_t size,
                                               fmi2FMUstate *FMUstate)
{
    char guid[FRONT_GUID_BYTES];
    RigState *s, *dst;
    CHECK_INSTANCE(fmi2DeSerializeFMUstate);
    if (serializedState == NULL || FMUstate == NULL || size != FRONT_GUID_BYTES + sizeof(RigState)) {
        logmsg(c, fmi2Error, "fmi2DeSerializeFMUstate: %lu bytes, expected %lu",
               (unsigned long)size, (unsigned long)(FRONT_GUID_BYTES + sizeof(RigState)));
        return fmi2Error;
    }
    s = (RigState *)mem_alloc(c, sizeof *s);
    if (s == NULL) {
        logmsg(c, fmi2Error, "fmi2DeSerializeFMUstate: out of memory");
        return fmi2Error;
    }
    guid_bytes(guid);
    memcpy(s, serializedState + FRONT_GUID_BYTES, sizeof *s);
    if (memcmp(serializedState, guid, FRONT_GUID_BYTES) != 0 || !state_valid(s)) {
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

/* -- co-simulation -------------------------------------------------------------------------- */
FMI2_Export fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real currentCommunicationPoint,
                                  fmi2Real communicationStepSize,
                                  fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    char msg[512];
    CHECK_INSTANCE(fmi2DoStep);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (c->s.phase != RIG_PH_STEP) return not_in_phase(c, "fmi2DoStep");
    if (step_arguments(c, currentCommunicationPoint, communicationStepSize) != fmi2OK)
        return fmi2Error;
    msg[0] = '\0';
    if (rig_step(&c->s, currentCommunicationPoint, communicationStepSize, msg, sizeof msg)) {
        logmsg(c, fmi2Error, "%s", msg);
        return fmi2Error;
    }
    return fmi2OK;
}

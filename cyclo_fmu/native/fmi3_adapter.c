/* FMI 3.0 co-simulation on top of the FMI 2.0 front compiled into the same binary: the same
 * C core, the same value handling and checks, reached through FMI 3 calls. Value references:
 * FMI 3 needs them unique across types; here each is the variable's 1-based position in the
 * model description (the independent variable time is 1), and the generated table
 * fmi3_vrmap.c gives its FMI 2 type and value reference. (Positions, because OMSimulator reads
 * FMI 3 dependencies as positions; with value references equal to them both readings agree.)
 * Functions of FMI 3 this FMU does not provide are in the generated fmi3_stubs.c and answer
 * fmi3Error. Written for cyclo-fmu (MIT license); FMI headers: Modelica Association (BSD). */
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "fmi3Functions.h"

#define MAX_BATCH 256

/* fmi3_vrmap.c: by FMI 3 value reference, the FMI 2 type ('R', 'I', 'B', 'S'; 'T' time; 0
 * none) and value reference */
extern const unsigned int FMI3_N_VR;
extern const char FMI3_VR_TYPE[];
extern const unsigned int FMI3_VR2[];

typedef struct {
    fmi2Component c2;
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback log;
    fmi3Float64 time;
} Adapter;

static void logger2(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                    fmi2String category, fmi2String message, ...)
{
    /* the FMI 2 front hands over a preformatted message without '%' */
    Adapter *a = (Adapter *)env;
    (void)name;
    if (a && a->log) a->log(a->env, (fmi3Status)status, category, message);
}

static void log3(Adapter *a, const char *message)
{
    if (a && a->log) a->log(a->env, fmi3Error, "logStatusError", message);
}

FMI3_Export const char *fmi3GetVersion(void) { return fmi3Version; }

FMI3_Export fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn,
                                           size_t nCategories, const fmi3String categories[])
{
    Adapter *a = (Adapter *)instance;
    if (a == NULL) return fmi3Error;
    return (fmi3Status)fmi2SetDebugLogging(a->c2, loggingOn ? fmi2True : fmi2False, nCategories,
                                           categories);
}

FMI3_Export fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate)
{
    Adapter *a;
    fmi2CallbackFunctions cb;
    (void)earlyReturnAllowed; (void)requiredIntermediateVariables;
    (void)nRequiredIntermediateVariables; (void)intermediateUpdate;
    a = (Adapter *)calloc(1, sizeof *a);
    if (a == NULL) return NULL;
    a->env = instanceEnvironment;
    a->log = logMessage;
    if (eventModeUsed) {          /* hasEventMode = false */
        log3(a, "fmi3InstantiateCoSimulation: this FMU has no event mode (eventModeUsed)");
        free(a);
        return NULL;
    }
    memset(&cb, 0, sizeof cb);
    cb.logger = logger2;
    cb.componentEnvironment = a;
    a->c2 = fmi2Instantiate(instanceName, fmi2CoSimulation, instantiationToken, resourcePath,
                            &cb, visible ? fmi2True : fmi2False,
                            loggingOn ? fmi2True : fmi2False);
    if (a->c2 == NULL) {
        free(a);
        return NULL;
    }
    return a;
}

FMI3_Export void fmi3FreeInstance(fmi3Instance instance)
{
    Adapter *a = (Adapter *)instance;
    if (a == NULL) return;
    fmi2FreeInstance(a->c2);
    free(a);
}

FMI3_Export fmi3Status fmi3EnterInitializationMode(fmi3Instance instance,
        fmi3Boolean toleranceDefined, fmi3Float64 tolerance, fmi3Float64 startTime,
        fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    Adapter *a = (Adapter *)instance;
    fmi2Status s;
    if (a == NULL) return fmi3Error;
    s = fmi2SetupExperiment(a->c2, toleranceDefined ? fmi2True : fmi2False, tolerance,
                            startTime, stopTimeDefined ? fmi2True : fmi2False, stopTime);
    if (s > fmi2Warning) return (fmi3Status)s;
    a->time = startTime;
    return (fmi3Status)fmi2EnterInitializationMode(a->c2);
}

#define FORWARD(fn3, fn2) \
FMI3_Export fmi3Status fn3(fmi3Instance instance) \
{ \
    Adapter *a = (Adapter *)instance; \
    if (a == NULL) return fmi3Error; \
    return (fmi3Status)fn2(a->c2); \
}

FORWARD(fmi3ExitInitializationMode, fmi2ExitInitializationMode)
FORWARD(fmi3Terminate, fmi2Terminate)
FORWARD(fmi3Reset, fmi2Reset)

/* value references of one FMI 3 type back to FMI 2's, at most MAX_BATCH a call */
static int map_vrs(Adapter *a, const fmi3ValueReference vr[], size_t n, char type,
                   fmi2ValueReference out[], const char *fn)
{
    size_t k;
    if (n > MAX_BATCH || (n && vr == NULL)) {
        log3(a, fn);
        return 0;
    }
    for (k = 0; k < n; k++) {
        if (vr[k] >= FMI3_N_VR || FMI3_VR_TYPE[vr[k]] != type) {
            log3(a, "unknown value reference for this variable type");
            return 0;
        }
        out[k] = FMI3_VR2[vr[k]];
    }
    return 1;
}

FMI3_Export fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference vr[],
                                      size_t nvr, fmi3Float64 values[], size_t nValues)
{
    Adapter *a = (Adapter *)instance;
    size_t k;
    if (a == NULL || nValues != nvr || (nvr && values == NULL) || (nvr && vr == NULL))
        return fmi3Error;
    for (k = 0; k < nvr; k++) {
        fmi2Status s;
        fmi2ValueReference r;
        if (vr[k] < FMI3_N_VR && FMI3_VR_TYPE[vr[k]] == 'T') { values[k] = a->time; continue; }
        if (!map_vrs(a, &vr[k], 1, 'R', &r, "fmi3GetFloat64")) return fmi3Error;
        s = fmi2GetReal(a->c2, &r, 1, &values[k]);
        if (s > fmi2Warning) return (fmi3Status)s;
    }
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference vr[],
                                      size_t nvr, const fmi3Float64 values[], size_t nValues)
{
    Adapter *a = (Adapter *)instance;
    fmi2ValueReference r[MAX_BATCH];
    if (a == NULL || nValues != nvr || (nvr && values == NULL)) return fmi3Error;
    if (!map_vrs(a, vr, nvr, 'R', r, "fmi3SetFloat64: too many or NULL value references"))
        return fmi3Error;
    return (fmi3Status)fmi2SetReal(a->c2, r, nvr, values);
}

FMI3_Export fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference vr[],
                                    size_t nvr, fmi3Int32 values[], size_t nValues)
{
    Adapter *a = (Adapter *)instance;
    fmi2ValueReference r[MAX_BATCH];
    fmi2Integer v[MAX_BATCH];
    fmi2Status s;
    size_t k;
    if (a == NULL || nValues != nvr || (nvr && values == NULL)) return fmi3Error;
    if (!map_vrs(a, vr, nvr, 'I', r, "fmi3GetInt32: too many or NULL value references"))
        return fmi3Error;
    s = fmi2GetInteger(a->c2, r, nvr, v);
    for (k = 0; k < nvr && s <= fmi2Warning; k++) values[k] = v[k];
    return (fmi3Status)s;
}

FMI3_Export fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference vr[],
                                    size_t nvr, const fmi3Int32 values[], size_t nValues)
{
    Adapter *a = (Adapter *)instance;
    fmi2ValueReference r[MAX_BATCH];
    fmi2Integer v[MAX_BATCH];
    size_t k;
    if (a == NULL || nValues != nvr || (nvr && values == NULL)) return fmi3Error;
    if (!map_vrs(a, vr, nvr, 'I', r, "fmi3SetInt32: too many or NULL value references"))
        return fmi3Error;
    for (k = 0; k < nvr; k++) v[k] = values[k];
    return (fmi3Status)fmi2SetInteger(a->c2, r, nvr, v);
}

FMI3_Export fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference vr[],
                                      size_t nvr, fmi3Boolean values[], size_t nValues)
{
    Adapter *a = (Adapter *)instance;
    fmi2ValueReference r[MAX_BATCH];
    fmi2Boolean v[MAX_BATCH];
    fmi2Status s;
    size_t k;
    if (a == NULL || nValues != nvr || (nvr && values == NULL)) return fmi3Error;
    if (!map_vrs(a, vr, nvr, 'B', r, "fmi3GetBoolean: too many or NULL value references"))
        return fmi3Error;
    s = fmi2GetBoolean(a->c2, r, nvr, v);
    for (k = 0; k < nvr && s <= fmi2Warning; k++) values[k] = v[k] != fmi2False;
    return (fmi3Status)s;
}

FMI3_Export fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference vr[],
                                      size_t nvr, const fmi3Boolean values[], size_t nValues)
{
    Adapter *a = (Adapter *)instance;
    fmi2ValueReference r[MAX_BATCH];
    fmi2Boolean v[MAX_BATCH];
    size_t k;
    if (a == NULL || nValues != nvr || (nvr && values == NULL)) return fmi3Error;
    if (!map_vrs(a, vr, nvr, 'B', r, "fmi3SetBoolean: too many or NULL value references"))
        return fmi3Error;
    for (k = 0; k < nvr; k++) v[k] = values[k] ? fmi2True : fmi2False;
    return (fmi3Status)fmi2SetBoolean(a->c2, r, nvr, v);
}

FMI3_Export fmi3Status fmi3GetString(fmi3Instance instance, const fmi3ValueReference vr[],
                                     size_t nvr, fmi3String values[], size_t nValues)
{
    Adapter *a = (Adapter *)instance;
    fmi2ValueReference r[MAX_BATCH];
    if (a == NULL || nValues != nvr || (nvr && values == NULL)) return fmi3Error;
    if (!map_vrs(a, vr, nvr, 'S', r, "fmi3GetString: too many or NULL value references"))
        return fmi3Error;
    return (fmi3Status)fmi2GetString(a->c2, r, nvr, values);
}

FMI3_Export fmi3Status fmi3SetString(fmi3Instance instance, const fmi3ValueReference vr[],
                                     size_t nvr, const fmi3String values[], size_t nValues)
{
    Adapter *a = (Adapter *)instance;
    fmi2ValueReference r[MAX_BATCH];
    if (a == NULL || nValues != nvr || (nvr && values == NULL)) return fmi3Error;
    if (!map_vrs(a, vr, nvr, 'S', r, "fmi3SetString: too many or NULL value references"))
        return fmi3Error;
    return (fmi3Status)fmi2SetString(a->c2, r, nvr, values);
}

/* FMU state: the FMI 2 front's, plus the adapter's time (a block that holds both) */
typedef struct {
    fmi2FMUstate s2;
    fmi3Float64 time;
} State3;

FMI3_Export fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    Adapter *a = (Adapter *)instance;
    State3 *st;
    fmi2Status s;
    if (a == NULL || FMUState == NULL) return fmi3Error;
    st = (State3 *)(*FMUState ? *FMUState : calloc(1, sizeof(State3)));
    if (st == NULL) return fmi3Error;
    s = fmi2GetFMUstate(a->c2, &st->s2);
    if (s > fmi2Warning) {
        if (*FMUState == NULL) free(st);
        return (fmi3Status)s;
    }
    st->time = a->time;
    *FMUState = st;
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    Adapter *a = (Adapter *)instance;
    State3 *st = (State3 *)FMUState;
    fmi2Status s;
    if (a == NULL || st == NULL) return fmi3Error;
    s = fmi2SetFMUstate(a->c2, st->s2);
    if (s <= fmi2Warning) a->time = st->time;
    return (fmi3Status)s;
}

FMI3_Export fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    Adapter *a = (Adapter *)instance;
    State3 *st;
    if (a == NULL) return fmi3Error;
    if (FMUState == NULL || *FMUState == NULL) return fmi3OK;
    st = (State3 *)*FMUState;
    fmi2FreeFMUstate(a->c2, &st->s2);
    free(st);
    *FMUState = NULL;
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState,
                                                  size_t *size)
{
    Adapter *a = (Adapter *)instance;
    State3 *st = (State3 *)FMUState;
    fmi2Status s;
    if (a == NULL || st == NULL || size == NULL) return fmi3Error;
    s = fmi2SerializedFMUstateSize(a->c2, st->s2, size);
    if (s <= fmi2Warning) *size += sizeof(fmi3Float64);
    return (fmi3Status)s;
}

FMI3_Export fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState,
                                             fmi3Byte serializedState[], size_t size)
{
    Adapter *a = (Adapter *)instance;
    State3 *st = (State3 *)FMUState;
    if (a == NULL || st == NULL || serializedState == NULL || size < sizeof(fmi3Float64))
        return fmi3Error;
    memcpy(serializedState, &st->time, sizeof(fmi3Float64));
    return (fmi3Status)fmi2SerializeFMUstate(a->c2, st->s2,
                                             (fmi2Byte *)serializedState + sizeof(fmi3Float64),
                                             size - sizeof(fmi3Float64));
}

FMI3_Export fmi3Status fmi3DeserializeFMUState(fmi3Instance instance,
        const fmi3Byte serializedState[], size_t size, fmi3FMUState *FMUState)
{
    Adapter *a = (Adapter *)instance;
    State3 *st;
    fmi2Status s;
    if (a == NULL || serializedState == NULL || FMUState == NULL || size < sizeof(fmi3Float64))
        return fmi3Error;
    st = (State3 *)(*FMUState ? *FMUState : calloc(1, sizeof(State3)));
    if (st == NULL) return fmi3Error;
    s = fmi2DeSerializeFMUstate(a->c2, (const fmi2Byte *)serializedState + sizeof(fmi3Float64),
                                size - sizeof(fmi3Float64), &st->s2);
    if (s > fmi2Warning) {
        if (*FMUState == NULL) free(st);
        return (fmi3Status)s;
    }
    memcpy(&st->time, serializedState, sizeof(fmi3Float64));
    *FMUState = st;
    return fmi3OK;
}

FMI3_Export fmi3Status fmi3DoStep(fmi3Instance instance,
        fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
        fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
        fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
        fmi3Float64 *lastSuccessfulTime)
{
    Adapter *a = (Adapter *)instance;
    fmi2Status s;
    if (a == NULL) return fmi3Error;
    s = fmi2DoStep(a->c2, currentCommunicationPoint, communicationStepSize,
                   noSetFMUStatePriorToCurrentPoint ? fmi2True : fmi2False);
    if (s <= fmi2Warning) a->time = currentCommunicationPoint + communicationStepSize;
    if (eventHandlingNeeded) *eventHandlingNeeded = fmi3False;
    if (terminateSimulation) *terminateSimulation = fmi3False;
    if (earlyReturn) *earlyReturn = fmi3False;
    if (lastSuccessfulTime) *lastSuccessfulTime = a->time;
    return (fmi3Status)s;
}

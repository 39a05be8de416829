/* The FMI 3.0 co-simulation interface over the instance (caekf_fmu.c). The headers are the standard's own,
 * from the FMPy package (fmu/CMakeLists.txt finds them in the venv). Enumerations travel as Int64, the
 * settings' ints as Int32, booleans as fmi3Boolean; everything else is Float64. */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include "fmi3Functions.h"
#include "fmu_roles.h"
#include "caekf_fmu_vars.h"

/* FMI 3's callback takes the environment the importer gave: the instance keeps the callback and the
 * environment in its own logger slot (env points to a fmi3_env_t inside the instance's block). */
typedef struct {
    fmi3LogMessageCallback cb;
    fmi3InstanceEnvironment env;
} fmi3_log_t;

static void fmi3_log(void *ctx, const char *instance, int status, const char *category, const char *message)
{
    const fmi3_log_t *l = (const fmi3_log_t *)ctx;
    (void)instance;
    if (l != NULL && l->cb != NULL) {
        l->cb(l->env, (fmi3Status)status, category, message);
    }
}

typedef struct {
    fmi3_log_t log; /* first: its address is the logger's context */
    caekf_fmu_t *f;
} instance3_t;

#define F(inst) (((instance3_t *)(inst))->f)

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    (void)nCategories;
    (void)categories;
    caekf_fmu_set_logging(F(instance), loggingOn ? 1 : 0);
    return fmi3OK;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    (void)instanceName;
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    if (logMessage != NULL) {
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   CAEKF_FMU_MODEL_IDENTIFIER " is a co-simulation FMU only (no model exchange)");
    }
    return NULL;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate)
{
    instance3_t *inst;
    (void)resourcePath;
    (void)visible;
    (void)requiredIntermediateVariables;
    (void)intermediateUpdate;
    (void)earlyReturnAllowed;
    if (eventModeUsed || nRequiredIntermediateVariables > 0) {
        if (logMessage != NULL) {
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "event mode and intermediate variables are not supported (hasEventMode=false)");
        }
        return NULL;
    }
    inst = calloc(1, sizeof *inst);
    if (inst == NULL) {
        return NULL;
    }
    inst->log.cb = logMessage;
    inst->log.env = instanceEnvironment;
    inst->f = caekf_fmu_new(instanceName, instantiationToken, fmi3_log, &inst->log, loggingOn ? 1 : 0);
    if (inst->f == NULL) {
        free(inst);
        return NULL;
    }
    return inst;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName;
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    (void)clockUpdate;
    (void)lockPreemption;
    (void)unlockPreemption;
    if (logMessage != NULL) {
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   CAEKF_FMU_MODEL_IDENTIFIER " is a co-simulation FMU only (no scheduled execution)");
    }
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance)
{
    if (instance != NULL) {
        caekf_fmu_free(F(instance));
        free(instance);
    }
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    return (fmi3Status)caekf_fmu_enter_init(F(instance), startTime);
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) { return (fmi3Status)caekf_fmu_exit_init(F(instance)); }
fmi3Status fmi3Terminate(fmi3Instance instance) { return (fmi3Status)caekf_fmu_terminate(F(instance)); }
fmi3Status fmi3Reset(fmi3Instance instance) { return (fmi3Status)caekf_fmu_reset(F(instance)); }
fmi3Status fmi3EnterStepMode(fmi3Instance instance)
{
    (void)instance; /* exitInitializationMode enters step mode (no event mode) */
    return fmi3OK;
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime)
{
    caekf_fmu_t *f = F(instance);
    const int rc = caekf_fmu_do_step(f, currentCommunicationPoint, communicationStepSize);
    (void)noSetFMUStatePriorToCurrentPoint;
    *eventHandlingNeeded = fmi3False;
    *terminateSimulation = rc >= CAEKF_FMU_ERROR ? fmi3True : fmi3False;
    *earlyReturn = fmi3False;
    *lastSuccessfulTime = caekf_fmu_time(f);
    return (fmi3Status)rc;
}

/* ---- values: every type through caekf_fmu_get/set as double */

#define GETTER(Name, CType, FmuType)                                                             \
    fmi3Status fmi3Get##Name(fmi3Instance instance, const fmi3ValueReference valueReferences[],  \
                             size_t nValueReferences, CType values[], size_t nValues)            \
    {                                                                                            \
        size_t i;                                                                                \
        if (nValues != nValueReferences) {                                                       \
            return (fmi3Status)caekf_fmu_unsupported(F(instance), "fmi3Get" #Name " of arrays"); \
        }                                                                                        \
        for (i = 0; i < nValueReferences; ++i) {                                                 \
            double v;                                                                            \
            const int rc = caekf_fmu_get(F(instance), valueReferences[i], FmuType, &v);          \
            if (rc != CAEKF_FMU_OK) {                                                            \
                return (fmi3Status)rc;                                                           \
            }                                                                                    \
            values[i] = (CType)v;                                                                \
        }                                                                                        \
        return fmi3OK;                                                                           \
    }

#define SETTER(Name, CType, FmuType)                                                                   \
    fmi3Status fmi3Set##Name(fmi3Instance instance, const fmi3ValueReference valueReferences[],        \
                             size_t nValueReferences, const CType values[], size_t nValues)            \
    {                                                                                                  \
        size_t i;                                                                                      \
        if (nValues != nValueReferences) {                                                             \
            return (fmi3Status)caekf_fmu_unsupported(F(instance), "fmi3Set" #Name " of arrays");       \
        }                                                                                              \
        for (i = 0; i < nValueReferences; ++i) {                                                       \
            const int rc = caekf_fmu_set(F(instance), valueReferences[i], FmuType, (double)values[i]); \
            if (rc != CAEKF_FMU_OK) {                                                                  \
                return (fmi3Status)rc;                                                                 \
            }                                                                                          \
        }                                                                                              \
        return fmi3OK;                                                                                 \
    }

/* No variable has these types: any value reference is refused (caekf_fmu_get/set with a type no variable has). */
#define NO_TYPE 255

GETTER(Float64, fmi3Float64, CAEKF_FMU_REAL)
GETTER(Int32, fmi3Int32, CAEKF_FMU_INT)
GETTER(Int64, fmi3Int64, CAEKF_FMU_ENUM)
GETTER(Float32, fmi3Float32, NO_TYPE)
GETTER(Int8, fmi3Int8, NO_TYPE)
GETTER(UInt8, fmi3UInt8, NO_TYPE)
GETTER(Int16, fmi3Int16, NO_TYPE)
GETTER(UInt16, fmi3UInt16, NO_TYPE)
GETTER(UInt32, fmi3UInt32, NO_TYPE)
GETTER(UInt64, fmi3UInt64, NO_TYPE)
SETTER(Float64, fmi3Float64, CAEKF_FMU_REAL)
SETTER(Int32, fmi3Int32, CAEKF_FMU_INT)
SETTER(Int64, fmi3Int64, CAEKF_FMU_ENUM)
SETTER(Float32, fmi3Float32, NO_TYPE)
SETTER(Int8, fmi3Int8, NO_TYPE)
SETTER(UInt8, fmi3UInt8, NO_TYPE)
SETTER(Int16, fmi3Int16, NO_TYPE)
SETTER(UInt16, fmi3UInt16, NO_TYPE)
SETTER(UInt32, fmi3UInt32, NO_TYPE)
SETTER(UInt64, fmi3UInt64, NO_TYPE)

fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Boolean values[], size_t nValues)
{
    size_t i;
    if (nValues != nValueReferences) {
        return (fmi3Status)caekf_fmu_unsupported(F(instance), "fmi3GetBoolean of arrays");
    }
    for (i = 0; i < nValueReferences; ++i) {
        double v;
        const int rc = caekf_fmu_get(F(instance), valueReferences[i], CAEKF_FMU_BOOL, &v);
        if (rc != CAEKF_FMU_OK) {
            return (fmi3Status)rc;
        }
        values[i] = v != 0 ? fmi3True : fmi3False;
    }
    return fmi3OK;
}

fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Boolean values[], size_t nValues)
{
    size_t i;
    if (nValues != nValueReferences) {
        return (fmi3Status)caekf_fmu_unsupported(F(instance), "fmi3SetBoolean of arrays");
    }
    for (i = 0; i < nValueReferences; ++i) {
        const int rc = caekf_fmu_set(F(instance), valueReferences[i], CAEKF_FMU_BOOL, values[i] ? 1.0 : 0.0);
        if (rc != CAEKF_FMU_OK) {
            return (fmi3Status)rc;
        }
    }
    return fmi3OK;
}

/* ---- what a co-simulation FMU without FMU state, clocks, strings or derivatives does not support */

#define UNSUPPORTED(name) return (fmi3Status)caekf_fmu_unsupported(F(instance), name)

fmi3Status fmi3GetString(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         fmi3String values[], size_t nValues)
{
    (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;
    UNSUPPORTED("fmi3GetString");
}
fmi3Status fmi3SetString(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const fmi3String values[], size_t nValues)
{
    (void)valueReferences, (void)nValueReferences, (void)values, (void)nValues;
    UNSUPPORTED("fmi3SetString");
}
fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues)
{
    (void)valueReferences, (void)nValueReferences, (void)valueSizes, (void)values, (void)nValues;
    UNSUPPORTED("fmi3GetBinary");
}
fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues)
{
    (void)valueReferences, (void)nValueReferences, (void)valueSizes, (void)values, (void)nValues;
    UNSUPPORTED("fmi3SetBinary");
}
fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[])
{
    (void)valueReferences, (void)nValueReferences, (void)values;
    UNSUPPORTED("fmi3GetClock");
}
fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[])
{
    (void)valueReferences, (void)nValueReferences, (void)values;
    UNSUPPORTED("fmi3SetClock");
}
fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies)
{
    (void)valueReference, (void)nDependencies;
    UNSUPPORTED("fmi3GetNumberOfVariableDependencies");
}
fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies)
{
    (void)dependent, (void)elementIndicesOfDependent, (void)independents, (void)elementIndicesOfIndependents;
    (void)dependencyKinds, (void)nDependencies;
    UNSUPPORTED("fmi3GetVariableDependencies");
}
fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    (void)FMUState;
    UNSUPPORTED("fmi3GetFMUState");
}
fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    (void)FMUState;
    UNSUPPORTED("fmi3SetFMUState");
}
fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    (void)FMUState;
    UNSUPPORTED("fmi3FreeFMUState");
}
fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size)
{
    (void)FMUState, (void)size;
    UNSUPPORTED("fmi3SerializedFMUStateSize");
}
fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size)
{
    (void)FMUState, (void)serializedState, (void)size;
    UNSUPPORTED("fmi3SerializeFMUState");
}
fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState)
{
    (void)serializedState, (void)size, (void)FMUState;
    UNSUPPORTED("fmi3DeserializeFMUState");
}
fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity)
{
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed, (void)sensitivity;
    (void)nSensitivity;
    UNSUPPORTED("fmi3GetDirectionalDerivative");
}
fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity)
{
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed, (void)sensitivity;
    (void)nSensitivity;
    UNSUPPORTED("fmi3GetAdjointDerivative");
}
fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) { UNSUPPORTED("fmi3EnterConfigurationMode"); }
fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) { UNSUPPORTED("fmi3ExitConfigurationMode"); }
fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[])
{
    (void)valueReferences, (void)nValueReferences, (void)intervals, (void)qualifiers;
    UNSUPPORTED("fmi3GetIntervalDecimal");
}
fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[])
{
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions, (void)qualifiers;
    UNSUPPORTED("fmi3GetIntervalFraction");
}
fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[])
{
    (void)valueReferences, (void)nValueReferences, (void)shifts;
    UNSUPPORTED("fmi3GetShiftDecimal");
}
fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[])
{
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    UNSUPPORTED("fmi3GetShiftFraction");
}
fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[])
{
    (void)valueReferences, (void)nValueReferences, (void)intervals;
    UNSUPPORTED("fmi3SetIntervalDecimal");
}
fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    UNSUPPORTED("fmi3SetIntervalFraction");
}
fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[])
{
    (void)valueReferences, (void)nValueReferences, (void)shifts;
    UNSUPPORTED("fmi3SetShiftDecimal");
}
fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    (void)valueReferences, (void)nValueReferences, (void)counters, (void)resolutions;
    UNSUPPORTED("fmi3SetShiftFraction");
}
fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) { UNSUPPORTED("fmi3EvaluateDiscreteStates"); }
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime)
{
    (void)discreteStatesNeedUpdate, (void)terminateSimulation, (void)nominalsOfContinuousStatesChanged;
    (void)valuesOfContinuousStatesChanged, (void)nextEventTimeDefined, (void)nextEventTime;
    UNSUPPORTED("fmi3UpdateDiscreteStates");
}
fmi3Status fmi3EnterEventMode(fmi3Instance instance) { UNSUPPORTED("fmi3EnterEventMode"); }
fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues)
{
    (void)valueReferences, (void)nValueReferences, (void)orders, (void)values, (void)nValues;
    UNSUPPORTED("fmi3GetOutputDerivatives (maxOutputDerivativeOrder 0)");
}

/* ---- model exchange and scheduled execution: not this FMU's interfaces (instantiation refuses them) */

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) { UNSUPPORTED("fmi3EnterContinuousTimeMode"); }
fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation)
{
    (void)noSetFMUStatePriorToCurrentPoint, (void)enterEventMode, (void)terminateSimulation;
    UNSUPPORTED("fmi3CompletedIntegratorStep");
}
fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    (void)time;
    UNSUPPORTED("fmi3SetTime");
}
fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates)
{
    (void)continuousStates, (void)nContinuousStates;
    UNSUPPORTED("fmi3SetContinuousStates");
}
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[], size_t nContinuousStates)
{
    (void)derivatives, (void)nContinuousStates;
    UNSUPPORTED("fmi3GetContinuousStateDerivatives");
}
fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators)
{
    (void)eventIndicators, (void)nEventIndicators;
    UNSUPPORTED("fmi3GetEventIndicators");
}
fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates)
{
    (void)continuousStates, (void)nContinuousStates;
    UNSUPPORTED("fmi3GetContinuousStates");
}
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates)
{
    (void)nominals, (void)nContinuousStates;
    UNSUPPORTED("fmi3GetNominalsOfContinuousStates");
}
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators)
{
    (void)nEventIndicators;
    UNSUPPORTED("fmi3GetNumberOfEventIndicators");
}
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates)
{
    (void)nContinuousStates;
    UNSUPPORTED("fmi3GetNumberOfContinuousStates");
}
fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime)
{
    (void)clockReference, (void)activationTime;
    UNSUPPORTED("fmi3ActivateModelPartition");
}

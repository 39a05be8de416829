/* The FMI 2.0 co-simulation interface over the instance (caekf_fmu.c). The headers are the standard's own,
 * from the FMPy package (fmu/CMakeLists.txt finds them in the venv). Enumerations and the settings' ints
 * travel as fmi2Integer, booleans as fmi2Boolean; everything else is fmi2Real. */
#include <stddef.h>
#include <stdlib.h>

#include "fmi2Functions.h"
#include "fmu_roles.h"
#include "caekf_fmu_vars.h"

typedef struct {
    fmi2CallbackLogger cb;
    fmi2ComponentEnvironment env;
} log2_t;

typedef struct {
    log2_t log;
    caekf_fmu_t *f;
    double start_time;
} instance2_t;

#define F(c) (((instance2_t *)(c))->f)

static void fmi2_log(void *ctx, const char *instance, int status, const char *category, const char *message)
{
    const log2_t *l = (const log2_t *)ctx;
    if (l != NULL && l->cb != NULL) {
        l->cb(l->env, instance, (fmi2Status)status, category, "%s", message);
    }
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    (void)nCategories;
    (void)categories;
    caekf_fmu_set_logging(F(c), loggingOn ? 1 : 0);
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    instance2_t *inst;
    (void)fmuResourceLocation;
    (void)visible;
    if (fmuType != fmi2CoSimulation) {
        if (functions != NULL && functions->logger != NULL) {
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError",
                              "%s is a co-simulation FMU only (no model exchange)", CAEKF_FMU_MODEL_IDENTIFIER);
        }
        return NULL;
    }
    inst = calloc(1, sizeof *inst);
    if (inst == NULL) {
        return NULL;
    }
    if (functions != NULL) {
        inst->log.cb = functions->logger;
        inst->log.env = functions->componentEnvironment;
    }
    inst->f = caekf_fmu_new(instanceName, fmuGUID, fmi2_log, &inst->log, loggingOn ? 1 : 0);
    if (inst->f == NULL) {
        free(inst);
        return NULL;
    }
    return inst;
}

void fmi2FreeInstance(fmi2Component c)
{
    if (c != NULL) {
        caekf_fmu_free(F(c));
        free(c);
    }
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    ((instance2_t *)c)->start_time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    return (fmi2Status)caekf_fmu_enter_init(F(c), ((instance2_t *)c)->start_time);
}
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { return (fmi2Status)caekf_fmu_exit_init(F(c)); }
fmi2Status fmi2Terminate(fmi2Component c) { return (fmi2Status)caekf_fmu_terminate(F(c)); }
fmi2Status fmi2Reset(fmi2Component c)
{
    ((instance2_t *)c)->start_time = 0;
    return (fmi2Status)caekf_fmu_reset(F(c));
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    return (fmi2Status)caekf_fmu_do_step(F(c), currentCommunicationPoint, communicationStepSize);
}

/* fmi2Integer carries the settings' ints and the enumerations. */
static int int_type(fmi2ValueReference vr)
{
    return vr < CAEKF_FMU_VAR_COUNT && caekf_fmu_vars[vr].type == CAEKF_FMU_ENUM ? CAEKF_FMU_ENUM : CAEKF_FMU_INT;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    size_t i;
    for (i = 0; i < nvr; ++i) {
        const int rc = caekf_fmu_get(F(c), vr[i], CAEKF_FMU_REAL, &value[i]);
        if (rc != CAEKF_FMU_OK) {
            return (fmi2Status)rc;
        }
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[])
{
    size_t i;
    for (i = 0; i < nvr; ++i) {
        double v;
        const int rc = caekf_fmu_get(F(c), vr[i], int_type(vr[i]), &v);
        if (rc != CAEKF_FMU_OK) {
            return (fmi2Status)rc;
        }
        value[i] = (fmi2Integer)v;
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[])
{
    size_t i;
    for (i = 0; i < nvr; ++i) {
        double v;
        const int rc = caekf_fmu_get(F(c), vr[i], CAEKF_FMU_BOOL, &v);
        if (rc != CAEKF_FMU_OK) {
            return (fmi2Status)rc;
        }
        value[i] = v != 0 ? fmi2True : fmi2False;
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    size_t i;
    for (i = 0; i < nvr; ++i) {
        const int rc = caekf_fmu_set(F(c), vr[i], CAEKF_FMU_REAL, value[i]);
        if (rc != CAEKF_FMU_OK) {
            return (fmi2Status)rc;
        }
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[])
{
    size_t i;
    for (i = 0; i < nvr; ++i) {
        const int rc = caekf_fmu_set(F(c), vr[i], int_type(vr[i]), (double)value[i]);
        if (rc != CAEKF_FMU_OK) {
            return (fmi2Status)rc;
        }
    }
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[])
{
    size_t i;
    for (i = 0; i < nvr; ++i) {
        const int rc = caekf_fmu_set(F(c), vr[i], CAEKF_FMU_BOOL, value[i] ? 1.0 : 0.0);
        if (rc != CAEKF_FMU_OK) {
            return (fmi2Status)rc;
        }
    }
    return fmi2OK;
}

/* ---- what a co-simulation FMU without FMU state, strings or derivatives does not support */

#define UNSUPPORTED(name) return (fmi2Status)caekf_fmu_unsupported(F(c), name)

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[])
{
    (void)vr, (void)nvr, (void)value;
    UNSUPPORTED("fmi2GetString");
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[])
{
    (void)vr, (void)nvr, (void)value;
    UNSUPPORTED("fmi2SetString");
}
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    (void)FMUstate;
    UNSUPPORTED("fmi2GetFMUstate");
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    (void)FMUstate;
    UNSUPPORTED("fmi2SetFMUstate");
}
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    (void)FMUstate;
    UNSUPPORTED("fmi2FreeFMUstate");
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size)
{
    (void)FMUstate, (void)size;
    UNSUPPORTED("fmi2SerializedFMUstateSize");
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size)
{
    (void)FMUstate, (void)serializedState, (void)size;
    UNSUPPORTED("fmi2SerializeFMUstate");
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    (void)serializedState, (void)size, (void)FMUstate;
    UNSUPPORTED("fmi2DeSerializeFMUstate");
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[])
{
    (void)vUnknown_ref, (void)nUnknown, (void)vKnown_ref, (void)nKnown, (void)dvKnown, (void)dvUnknown;
    UNSUPPORTED("fmi2GetDirectionalDerivative");
}
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    (void)vr, (void)nvr, (void)order, (void)value;
    UNSUPPORTED("fmi2SetRealInputDerivatives (canInterpolateInputs false)");
}
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    (void)vr, (void)nvr, (void)order, (void)value;
    UNSUPPORTED("fmi2GetRealOutputDerivatives (maxOutputDerivativeOrder 0)");
}
fmi2Status fmi2CancelStep(fmi2Component c) { UNSUPPORTED("fmi2CancelStep (doStep is synchronous)"); }
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    (void)s, (void)value;
    UNSUPPORTED("fmi2GetStatus (doStep is synchronous)");
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    if (s == fmi2LastSuccessfulTime) {
        *value = caekf_fmu_time(F(c));
        return fmi2OK;
    }
    UNSUPPORTED("fmi2GetRealStatus");
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{
    (void)s, (void)value;
    UNSUPPORTED("fmi2GetIntegerStatus");
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    (void)s, (void)value;
    UNSUPPORTED("fmi2GetBooleanStatus");
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{
    (void)s, (void)value;
    UNSUPPORTED("fmi2GetStringStatus");
}

/* ---- model exchange: not this FMU's interface (fmi2Instantiate refuses it) */

fmi2Status fmi2EnterEventMode(fmi2Component c) { UNSUPPORTED("fmi2EnterEventMode"); }
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *fmi2eventInfo)
{
    (void)fmi2eventInfo;
    UNSUPPORTED("fmi2NewDiscreteStates");
}
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { UNSUPPORTED("fmi2EnterContinuousTimeMode"); }
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation)
{
    (void)noSetFMUStatePriorToCurrentPoint, (void)enterEventMode, (void)terminateSimulation;
    UNSUPPORTED("fmi2CompletedIntegratorStep");
}
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time)
{
    (void)time;
    UNSUPPORTED("fmi2SetTime");
}
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx)
{
    (void)x, (void)nx;
    UNSUPPORTED("fmi2SetContinuousStates");
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx)
{
    (void)derivatives, (void)nx;
    UNSUPPORTED("fmi2GetDerivatives");
}
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni)
{
    (void)eventIndicators, (void)ni;
    UNSUPPORTED("fmi2GetEventIndicators");
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx)
{
    (void)x, (void)nx;
    UNSUPPORTED("fmi2GetContinuousStates");
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx)
{
    (void)x_nominal, (void)nx;
    UNSUPPORTED("fmi2GetNominalsOfContinuousStates");
}

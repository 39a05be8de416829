/* The FMUs' instance (fmu/src/caekf_fmu.c), shared by the FMI 2.0 and FMI 3.0 front ends (fmi2.c, fmi3.c).
 * Every variable of the generated table (caekf_fmu_vars.h, from the settings schema by fmu_codegen.py) is
 * addressed by its value reference, its row; values travel as double whatever their FMI type. */
#ifndef CAEKF_FMU_ROLES_H
#define CAEKF_FMU_ROLES_H

#include <stddef.h>

/* A variable's FMI type. */
enum { CAEKF_FMU_REAL = 0, CAEKF_FMU_INT = 1, CAEKF_FMU_BOOL = 2, CAEKF_FMU_ENUM = 3 };

/* A variable's role: a parameter (a scenario key: index = its row in caekf_scenario_keys), an input or an
 * output (index = the element: body, contact, input, sensor or flag bit). */
enum {
    CAEKF_FMU_PARAM = 0,
    CAEKF_FMU_IN_U,
    CAEKF_FMU_IN_U_VALID,
    CAEKF_FMU_IN_Y,
    CAEKF_FMU_IN_Y_VALID,
    CAEKF_FMU_OUT_Q,
    CAEKF_FMU_OUT_V,
    CAEKF_FMU_OUT_GAMMA,
    CAEKF_FMU_OUT_N,
    CAEKF_FMU_OUT_LAMBDA,
    CAEKF_FMU_OUT_GAP,
    CAEKF_FMU_OUT_VAR_Q,
    CAEKF_FMU_OUT_VAR_V,
    CAEKF_FMU_OUT_VAR_GAMMA,
    CAEKF_FMU_OUT_VAR_N,
    CAEKF_FMU_OUT_VAR_LAMBDA,
    CAEKF_FMU_OUT_VAR_GAP,
    CAEKF_FMU_OUT_VAR_MECH_MASS,
    CAEKF_FMU_OUT_VAR_MECH_STIFFNESS,
    CAEKF_FMU_OUT_VAR_MECH_DAMPER,
    CAEKF_FMU_OUT_NIS,
    CAEKF_FMU_OUT_P_NORM,
    CAEKF_FMU_OUT_DELTA,
    CAEKF_FMU_OUT_T_SAMPLE,
    CAEKF_FMU_OUT_FLAGS,
    CAEKF_FMU_OUT_NEWTON,
    CAEKF_FMU_OUT_STATUS,
    CAEKF_FMU_OUT_FLAG,
    /* the plant's */
    CAEKF_FMU_OUT_U,
    CAEKF_FMU_OUT_Y,
    CAEKF_FMU_OUT_Y_VALID,
    CAEKF_FMU_OUT_EVENTS,
    CAEKF_FMU_OUT_STEPS
};

typedef struct {
    const char *name;
    unsigned char type;
    unsigned char role;
    unsigned index;
    double start;
} caekf_fmu_var_t;

typedef struct {
    unsigned key; /* row in caekf_scenario_keys */
    double value;
} caekf_fmu_given_t;

/* FMI status codes: the same numbers in FMI 2.0 and 3.0. */
enum { CAEKF_FMU_OK = 0, CAEKF_FMU_WARNING = 1, CAEKF_FMU_DISCARD = 2, CAEKF_FMU_ERROR = 3, CAEKF_FMU_FATAL = 4 };

/* Logs one message: status is a CAEKF_FMU_* code, category "logStatusError", "logStatusWarning", "logEvents". */
typedef void (*caekf_fmu_logger_t)(void *env, const char *instance, int status, const char *category,
                                   const char *message);

typedef struct caekf_fmu caekf_fmu_t;

/* A new instance in the instantiated state, its parameters at their start values (the scenario's), or NULL
 * (token mismatch, no memory: logged). */
caekf_fmu_t *caekf_fmu_new(const char *instance_name, const char *token, caekf_fmu_logger_t logger, void *env,
                           int logging_on);
void caekf_fmu_free(caekf_fmu_t *f);
void caekf_fmu_set_logging(caekf_fmu_t *f, int on);
int caekf_fmu_enter_init(caekf_fmu_t *f, double start_time);
/* Validates the parameters and starts the estimator or the plant: the mechanism's structure is fixed from
 * here on. */
int caekf_fmu_exit_init(caekf_fmu_t *f);
int caekf_fmu_do_step(caekf_fmu_t *f, double t, double h);
int caekf_fmu_terminate(caekf_fmu_t *f);
int caekf_fmu_reset(caekf_fmu_t *f);
/* Reads or writes variable vr, whose FMI type must be `type`. */
int caekf_fmu_get(caekf_fmu_t *f, unsigned vr, int type, double *v);
int caekf_fmu_set(caekf_fmu_t *f, unsigned vr, int type, double v);
/* FMI 3's independent variable: the current communication point. */
double caekf_fmu_time(const caekf_fmu_t *f);
/* Logs an error of a front-end call that the instance does not support. */
int caekf_fmu_unsupported(caekf_fmu_t *f, const char *function);

#endif

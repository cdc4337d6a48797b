/* Shared model core for every lfctl vehicle model.
 *
 * A model is a folder with config.h (identity, state count and the variable table as an
 * X-macro) and model.c (the equations). This core owns everything the FMI wrappers share:
 * the variable table, the instance state machine, checked set/get, fixed-step RK4 inside
 * doStep, FMU-state snapshots and logging. The FMI 2 and FMI 3 wrappers only translate
 * calling conventions; neither knows a model.
 */
#ifndef LFCTL_MODEL_CORE_H
#define LFCTL_MODEL_CORE_H

#include <stddef.h>

#include "config.h"

typedef enum {
    CAUSALITY_INDEPENDENT,
    CAUSALITY_PARAMETER,
    CAUSALITY_INPUT,
    CAUSALITY_OUTPUT
} Causality;

typedef enum { VARIABILITY_FIXED, VARIABILITY_TUNABLE, VARIABILITY_CONTINUOUS } Variability;

/* Value reference 0 is the independent variable `time`; the model's variables follow in the
 * order of MODEL_VARIABLES, starting at 1. */
enum {
    VR_time = 0,
#define LFCTL_VR_ENUM(name, causality, variability, start, unit, description) VR_##name,
    MODEL_VARIABLES(LFCTL_VR_ENUM)
#undef LFCTL_VR_ENUM
    N_VARIABLES
};

typedef struct {
    const char *name;
    Causality causality;
    Variability variability;
    double start;
    const char *unit;
} VariableInfo;

extern const VariableInfo lfctl_variables[N_VARIABLES];

/* Status codes equal to fmi2Status and fmi3Status (OK, Warning, Discard, Error, Fatal). */
enum { CORE_OK = 0, CORE_WARNING = 1, CORE_DISCARD = 2, CORE_ERROR = 3, CORE_FATAL = 4 };

typedef enum {
    STATE_INSTANTIATED,
    STATE_INITIALIZATION,
    STATE_STEP,
    STATE_TERMINATED,
    STATE_ERROR
} ModelState;

struct ModelInstance;
typedef void (*CoreEmitFn)(const struct ModelInstance *m, int status, const char *category,
                           const char *message);

typedef struct ModelInstance {
    char *instance_name;
    ModelState state;
    double v[N_VARIABLES]; /* every variable by value reference; v[0] is time */
    double x[N_STATES];    /* continuous states */
    int logging_on;
    CoreEmitFn emit;        /* set by the wrapper: forwards a message to the importer */
    void *fmi_env;          /* the wrapper's callback environment */
    const void *fmi_logger; /* the wrapper's logger callback */
} ModelInstance;

/* Provided by each model's model.c. All take the variable array indexed by value reference. */
void model_initialize(const double *v, double *x);
void model_derivatives(const double *v, const double *x, double *dx);
void model_outputs(double *v, const double *x);
void model_normalize(double *x);
/* Returns the value reference of the first invalid parameter (message written), or 0. */
int model_check_parameters(const double *v, char *message, size_t size);

/* Helpers for models. */
double core_wrap_pi(double angle_rad);          /* to (-pi, pi] */
double core_clamp(double value, double limit);  /* to [-limit, limit] */

/* Core API used by the wrappers. `call` names the FMI function for messages. */
ModelInstance *core_instantiate(const char *instance_name, const char *token, CoreEmitFn emit,
                                void *fmi_env, const void *fmi_logger, int logging_on);
void core_free(ModelInstance *m);
void core_log(const ModelInstance *m, int status, const char *category, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
int core_reset(ModelInstance *m);
int core_enter_initialization(ModelInstance *m, const char *call, double start_time);
int core_exit_initialization(ModelInstance *m, const char *call);
int core_terminate(ModelInstance *m, const char *call);
int core_set_real(ModelInstance *m, const char *call, const unsigned int *vr, size_t nvr,
                  const double *value);
int core_get_real(ModelInstance *m, const char *call, const unsigned int *vr, size_t nvr,
                  double *value);
int core_do_step(ModelInstance *m, const char *call, double current_time, double step_size);
int core_unsupported(ModelInstance *m, const char *call);
int core_no_variables_of_type(ModelInstance *m, const char *call, size_t nvr);

/* FMU state snapshots (get/set/serialize). */
typedef struct {
    ModelState state;
    double v[N_VARIABLES];
    double x[N_STATES];
} CoreSnapshot;
CoreSnapshot *core_snapshot_new(const ModelInstance *m);
int core_snapshot_restore(ModelInstance *m, const char *call, const CoreSnapshot *s);

#endif

/* Shared model core for every lfctl vehicle model.
 *
 * A model is a folder with config.h (identity, state count and the variable table as an
 * X-macro) and model.c (the equations). This core owns everything the FMI wrappers share:
 * the variable table, the instance states and the one state check, checked set/get,
 * fixed-step RK4 inside doStep, FMU-state snapshots and logging. The FMI 2 and FMI 3 wrappers
 * translate calling conventions and hold their standard's table of the states each call is
 * allowed in; neither knows a model.
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

/* Instance states, one bit each, so that a set of states (a mask) is one unsigned int. The
 * FMI 2 and FMI 3 Co-Simulation state machines both reduce to these five for an FMU whose
 * doStep is synchronous, never returns Discard and has no event, configuration or
 * intermediate-update mode. Each wrapper has a table of masks, one per FMI function, saying
 * in which of these states the function may be called (fmi2_wrapper.c, fmi3_wrapper.c).
 * STATE_ERROR is FMI 2's Error state; FMI 3 has none (an fmi3Error return leads to
 * Terminated), and its table treats STATE_ERROR as Terminated. */
typedef enum {
    STATE_INSTANTIATED = 1 << 0,
    STATE_INITIALIZATION = 1 << 1, /* InitializationMode */
    STATE_STEP = 1 << 2,           /* FMI 2 StepComplete, FMI 3 Step Mode */
    STATE_TERMINATED = 1 << 3,
    STATE_ERROR = 1 << 4
} ModelState;

#define STATE_ANY \
    (STATE_INSTANTIATED | STATE_INITIALIZATION | STATE_STEP | STATE_TERMINATED | STATE_ERROR)
/* An empty mask: the function belongs to no state this FMU can be in (a Model Exchange,
 * Scheduled Execution, event-mode or clock function); calling it is reported as unsupported. */
#define STATE_NONE 0u

struct ModelInstance;
typedef void (*CoreEmitFn)(const struct ModelInstance *m, int status, const char *category,
                           const char *message);

typedef struct ModelInstance {
    char *instance_name;
    ModelState state;
    double v[N_VARIABLES]; /* every variable by value reference; v[0] is time */
    double x[N_STATES];    /* continuous states */
    int logging_on;
    int error_is_terminated; /* set by the FMI 3 wrapper: messages name STATE_ERROR Terminated */
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

/* The one state check of every FMI call, run first by the wrappers' ASSERT_STATE. Returns 1
 * when `m` is not NULL and its state is in `allowed`. Otherwise returns 0 and, when `m` is not
 * NULL, logs an error naming `call`, the current state and the allowed ones, and moves the
 * instance to STATE_ERROR (an FMI call in a state the standard does not allow it in returns
 * Error, and an Error return puts the instance in FMI 2's Error / FMI 3's Terminated state).
 * An empty `allowed` (STATE_NONE) is logged as "not supported" and leaves the state as is, as
 * core_unsupported does. The core functions below assume this check has passed. */
int core_check_state(ModelInstance *m, const char *call, unsigned int allowed);

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
int core_terminate(ModelInstance *m);
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

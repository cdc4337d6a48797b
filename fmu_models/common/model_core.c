/* Shared model core: state check, checked access, RK4 sub-stepping. See model_core.h. */
#include "model_core.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define LFCTL_CAUSALITY(c) CAUSALITY_##c
#define LFCTL_VARIABILITY(v) VARIABILITY_##v

const VariableInfo lfctl_variables[N_VARIABLES] = {
    {"time", CAUSALITY_INDEPENDENT, VARIABILITY_CONTINUOUS, 0.0, "s"},
#define LFCTL_VAR_INFO(name, causality, variability, start, unit, description) \
    {#name, LFCTL_CAUSALITY(causality), LFCTL_VARIABILITY(variability), start, unit},
    MODEL_VARIABLES(LFCTL_VAR_INFO)
#undef LFCTL_VAR_INFO
};

#define LFCTL_PI 3.14159265358979323846

double core_wrap_pi(double a) {
    a = fmod(a + LFCTL_PI, 2.0 * LFCTL_PI);
    if (a <= 0.0) a += 2.0 * LFCTL_PI;
    return a - LFCTL_PI;
}

double core_clamp(double value, double limit) {
    return value > limit ? limit : (value < -limit ? -limit : value);
}

static const char *state_name(unsigned int s) {
    switch (s) {
    case STATE_INSTANTIATED: return "Instantiated";
    case STATE_INITIALIZATION: return "InitializationMode";
    case STATE_STEP: return "StepMode";
    case STATE_TERMINATED: return "Terminated";
    case STATE_ERROR: return "Error";
    }
    return "?";
}

/* Exactly one state bit, and one of `mask`. */
static int is_state_in(unsigned int s, unsigned int mask) {
    return s != 0 && (s & (s - 1)) == 0 && (s & mask) == s;
}

static const char *causality_name(Causality c) {
    switch (c) {
    case CAUSALITY_INDEPENDENT: return "independent";
    case CAUSALITY_PARAMETER: return "parameter";
    case CAUSALITY_INPUT: return "input";
    case CAUSALITY_OUTPUT: return "output";
    }
    return "?";
}

void core_log(const ModelInstance *m, int status, const char *category, const char *fmt, ...) {
    char message[512];
    va_list ap;
    if (!m || !m->emit) return;
    if (status == CORE_OK && !m->logging_on) return;
    va_start(ap, fmt);
    vsnprintf(message, sizeof message, fmt, ap);
    va_end(ap);
    m->emit(m, status, category, message);
}

static int fail(ModelInstance *m, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Log an error, move the instance to the Error state, return CORE_ERROR. */
static int fail(ModelInstance *m, const char *fmt, ...) {
    char message[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(message, sizeof message, fmt, ap);
    va_end(ap);
    core_log(m, CORE_ERROR, "logStatusError", "%s", message);
    m->state = STATE_ERROR;
    return CORE_ERROR;
}

int core_check_state(ModelInstance *m, const char *call, unsigned int allowed) {
    char names[96];
    size_t len = 0;
    unsigned int bit;
    if (!m) return 0; /* no instance, so no logger to tell: the Error status is all we have */
    if (is_state_in((unsigned int)m->state, allowed)) return 1;
    if (allowed == STATE_NONE) {
        core_unsupported(m, call);
        return 0;
    }
    names[0] = '\0';
    for (bit = 1; bit <= STATE_ERROR; bit <<= 1) {
        if (!(allowed & bit)) continue;
        if (bit == STATE_ERROR && m->error_is_terminated) continue; /* listed as Terminated */
        len += (size_t)snprintf(names + len, sizeof names - len, "%s%s", len ? ", " : "",
                                state_name(bit));
        if (len >= sizeof names) break;
    }
    core_log(m, CORE_ERROR, "logStatusError", "%s: not allowed in state %s (allowed in: %s)%s",
             call,
             m->state == STATE_ERROR && m->error_is_terminated ? "Terminated"
                                                                : state_name((unsigned int)m->state),
             names,
             m->state == STATE_ERROR ? "; an earlier call failed: reset or free the instance"
                                     : "");
    m->state = STATE_ERROR;
    return 0;
}

static void set_start_values(ModelInstance *m) {
    int i;
    for (i = 0; i < N_VARIABLES; i++) m->v[i] = lfctl_variables[i].start;
    model_initialize(m->v, m->x);
    model_outputs(m->v, m->x);
}

ModelInstance *core_instantiate(const char *instance_name, const char *token, CoreEmitFn emit,
                                void *fmi_env, const void *fmi_logger, int logging_on) {
    ModelInstance probe;
    ModelInstance *m;
    size_t len;

    memset(&probe, 0, sizeof probe);
    probe.emit = emit;
    probe.fmi_env = fmi_env;
    probe.fmi_logger = fmi_logger;
    probe.instance_name = (char *)(instance_name ? instance_name : "?");

    if (!instance_name || !*instance_name) {
        core_log(&probe, CORE_ERROR, "logStatusError", "Instantiate: instanceName is empty");
        return NULL;
    }
    if (!token || strcmp(token, INSTANTIATION_TOKEN) != 0) {
        core_log(&probe, CORE_ERROR, "logStatusError",
                 "Instantiate: GUID/instantiationToken '%s' does not match '%s' of model %s",
                 token ? token : "(null)", INSTANTIATION_TOKEN, MODEL_IDENTIFIER_STRING);
        return NULL;
    }
    m = (ModelInstance *)calloc(1, sizeof *m);
    if (!m) return NULL;
    len = strlen(instance_name);
    m->instance_name = (char *)malloc(len + 1);
    if (!m->instance_name) {
        free(m);
        return NULL;
    }
    memcpy(m->instance_name, instance_name, len + 1);
    m->emit = emit;
    m->fmi_env = fmi_env;
    m->fmi_logger = fmi_logger;
    m->logging_on = logging_on;
    m->state = STATE_INSTANTIATED;
    set_start_values(m);
    return m;
}

void core_free(ModelInstance *m) {
    if (!m) return;
    free(m->instance_name);
    free(m);
}

int core_reset(ModelInstance *m) {
    m->state = STATE_INSTANTIATED;
    set_start_values(m);
    return CORE_OK;
}

int core_enter_initialization(ModelInstance *m, const char *call, double start_time) {
    if (!isfinite(start_time))
        return fail(m, "%s: startTime must be finite, got %g", call, start_time);
    m->v[VR_time] = start_time;
    m->state = STATE_INITIALIZATION;
    return CORE_OK;
}

int core_exit_initialization(ModelInstance *m, const char *call) {
    char message[256];
    int bad;
    message[0] = '\0';
    bad = model_check_parameters(m->v, message, sizeof message);
    if (bad) return fail(m, "%s: parameter %s: %s", call, lfctl_variables[bad].name, message);
    model_initialize(m->v, m->x);
    model_outputs(m->v, m->x);
    m->state = STATE_STEP;
    return CORE_OK;
}

int core_terminate(ModelInstance *m) {
    m->state = STATE_TERMINATED;
    return CORE_OK;
}

int core_set_real(ModelInstance *m, const char *call, const unsigned int *vr, size_t nvr,
                  const double *value) {
    size_t i;
    if (nvr > 0 && (!vr || !value)) return fail(m, "%s: NULL array with nvr = %zu", call, nvr);
    /* Check every value before writing any, so a rejected call changes nothing. */
    for (i = 0; i < nvr; i++) {
        const VariableInfo *info;
        if (vr[i] >= N_VARIABLES)
            return fail(m, "%s: unknown value reference %u", call, vr[i]);
        info = &lfctl_variables[vr[i]];
        if (info->causality == CAUSALITY_INDEPENDENT || info->causality == CAUSALITY_OUTPUT)
            return fail(m, "%s: variable %s (causality %s) cannot be set", call, info->name,
                        causality_name(info->causality));
        if (info->causality == CAUSALITY_PARAMETER && info->variability == VARIABILITY_FIXED &&
            m->state != STATE_INSTANTIATED && m->state != STATE_INITIALIZATION)
            return fail(m, "%s: fixed parameter %s cannot be set after initialization", call,
                        info->name);
        if (!isfinite(value[i]))
            return fail(m, "%s: variable %s must be finite, got %g", call, info->name, value[i]);
    }
    for (i = 0; i < nvr; i++) m->v[vr[i]] = value[i];
    if (m->state != STATE_STEP) {
        /* Before step mode the outputs follow the (possibly new) start pose. */
        model_initialize(m->v, m->x);
        model_outputs(m->v, m->x);
    }
    return CORE_OK;
}

int core_get_real(ModelInstance *m, const char *call, const unsigned int *vr, size_t nvr,
                  double *value) {
    size_t i;
    if (nvr > 0 && (!vr || !value)) return fail(m, "%s: NULL array with nvr = %zu", call, nvr);
    for (i = 0; i < nvr; i++) {
        if (vr[i] >= N_VARIABLES)
            return fail(m, "%s: unknown value reference %u", call, vr[i]);
        value[i] = m->v[vr[i]];
    }
    return CORE_OK;
}

static void rk4(const double *v, double *x, double h) {
    double k1[N_STATES], k2[N_STATES], k3[N_STATES], k4[N_STATES], t[N_STATES];
    int i;
    model_derivatives(v, x, k1);
    for (i = 0; i < N_STATES; i++) t[i] = x[i] + 0.5 * h * k1[i];
    model_derivatives(v, t, k2);
    for (i = 0; i < N_STATES; i++) t[i] = x[i] + 0.5 * h * k2[i];
    model_derivatives(v, t, k3);
    for (i = 0; i < N_STATES; i++) t[i] = x[i] + h * k3[i];
    model_derivatives(v, t, k4);
    for (i = 0; i < N_STATES; i++) x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    model_normalize(x);
}

/* The most RK4 sub-steps one doStep takes (about two minutes of computing): a longer step is
 * refused rather than run for hours, and its count always fits a long (a cast of a larger
 * double is undefined behaviour). */
#define CORE_MAX_SUB_STEPS 1e9

int core_do_step(ModelInstance *m, const char *call, double current_time, double step_size) {
    double internal, h, tolerance, steps;
    long n, k;
    if (!(step_size > 0.0) || !isfinite(step_size))
        return fail(m, "%s: communicationStepSize must be > 0, got %g", call, step_size);
    tolerance = 1e-9 * fmax(1.0, fabs(current_time));
    if (!isfinite(current_time) || fabs(current_time - m->v[VR_time]) > tolerance)
        return fail(m, "%s: currentCommunicationPoint %.17g does not match the FMU time %.17g",
                    call, current_time, m->v[VR_time]);
    internal = m->v[VR_FIXED_STEP];
    steps = ceil(step_size / internal - 1e-9);
    if (!(steps <= CORE_MAX_SUB_STEPS)) /* (NaN too: an internal_step from a corrupt FMU state) */
        return fail(m, "%s: communicationStepSize %g s needs %.3g sub-steps of internal_step %g s, "
                       "more than %g: take smaller steps",
                    call, step_size, steps, internal, CORE_MAX_SUB_STEPS);
    n = steps < 1.0 ? 1 : (long)steps;
    h = step_size / (double)n;
    for (k = 0; k < n; k++) rk4(m->v, m->x, h);
    m->v[VR_time] = current_time + step_size;
    model_outputs(m->v, m->x);
    return CORE_OK;
}

int core_unsupported(ModelInstance *m, const char *call) {
    if (m) core_log(m, CORE_ERROR, "logStatusError", "%s: not supported by %s", call,
                    MODEL_IDENTIFIER_STRING);
    return CORE_ERROR;
}

int core_no_variables_of_type(ModelInstance *m, const char *call, size_t nvr) {
    if (nvr == 0) return CORE_OK;
    return fail(m, "%s: model %s has no variables of this type (%zu value references given)",
                call, MODEL_IDENTIFIER_STRING, nvr);
}

CoreSnapshot *core_snapshot_new(const ModelInstance *m) {
    /* calloc: the padding after `state` is serialized too, and must not carry heap bytes */
    CoreSnapshot *s = (CoreSnapshot *)calloc(1, sizeof *s);
    if (!s) return NULL;
    s->state = m->state;
    memcpy(s->v, m->v, sizeof s->v);
    memcpy(s->x, m->x, sizeof s->x);
    return s;
}

int core_snapshot_restore(ModelInstance *m, const char *call, const CoreSnapshot *s) {
    if (!s) return fail(m, "%s: FMU state is NULL", call);
    /* A snapshot taken in the Error state is refused: restoring it would not recover. */
    if (!is_state_in((unsigned int)s->state, STATE_ANY & ~(unsigned int)STATE_ERROR))
        return fail(m, "%s: FMU state is corrupt or was taken in state Error (state %u)", call,
                    (unsigned int)s->state);
    m->state = s->state;
    memcpy(m->v, s->v, sizeof m->v);
    memcpy(m->x, s->x, sizeof m->x);
    return CORE_OK;
}

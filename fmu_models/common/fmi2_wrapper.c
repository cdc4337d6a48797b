/* FMI 2.0 Co-Simulation wrapper, shared by every lfctl model: translates calls into the
 * model core (model_core.h). */
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "model_core.h"

/* The FMI signatures fix the parameter lists; unused ones are expected here. */
#if defined(__GNUC__)
#pragma GCC diagnostic ignored "-Wunused-parameter"
#endif

#define M ((ModelInstance *)c)

/* In which states each FMI 2.0 Co-Simulation function may be called: the FMI 2.0.x state
 * machine for Co-Simulation (section 4.2.4, the table of allowed calls per state), reduced to
 * the states this FMU can be in. StepMode is FMI 2's StepComplete; StepInProgress, StepFailed
 * and StepCanceled are never entered, since fmi2DoStep is synchronous and never returns
 * fmi2Pending or fmi2Discard, so they drop out of every mask. fmi2GetTypesPlatform and
 * fmi2GetVersion take no instance and are allowed always; fmi2FreeInstance is allowed in every
 * state (and ignores NULL). Functions this FMU does not provide are still checked against the
 * standard's mask first, then refused as unsupported. */
#define FMI2_SETUP (STATE_INSTANTIATED | STATE_INITIALIZATION | STATE_STEP)
#define FMI2_GETTABLE (STATE_INITIALIZATION | STATE_STEP | STATE_TERMINATED | STATE_ERROR)

#define MASK_fmi2SetDebugLogging STATE_ANY
#define MASK_fmi2FreeInstance STATE_ANY
#define MASK_fmi2SetupExperiment STATE_INSTANTIATED
#define MASK_fmi2EnterInitializationMode STATE_INSTANTIATED
#define MASK_fmi2ExitInitializationMode STATE_INITIALIZATION
#define MASK_fmi2Terminate STATE_STEP /* and StepFailed */
#define MASK_fmi2Reset STATE_ANY
#define MASK_fmi2GetReal FMI2_GETTABLE /* in Error: for diagnostics only */
#define MASK_fmi2GetInteger FMI2_GETTABLE
#define MASK_fmi2GetBoolean FMI2_GETTABLE
#define MASK_fmi2GetString FMI2_GETTABLE
#define MASK_fmi2SetReal FMI2_SETUP /* which variables: checked per variable by the core */
#define MASK_fmi2SetInteger FMI2_SETUP
#define MASK_fmi2SetBoolean FMI2_SETUP
#define MASK_fmi2SetString FMI2_SETUP
#define MASK_fmi2GetFMUstate STATE_ANY
#define MASK_fmi2SetFMUstate STATE_ANY
#define MASK_fmi2FreeFMUstate STATE_ANY
#define MASK_fmi2SerializedFMUstateSize STATE_ANY
#define MASK_fmi2SerializeFMUstate STATE_ANY
#define MASK_fmi2DeSerializeFMUstate STATE_ANY
#define MASK_fmi2GetDirectionalDerivative FMI2_GETTABLE
#define MASK_fmi2SetRealInputDerivatives FMI2_SETUP
#define MASK_fmi2GetRealOutputDerivatives (STATE_STEP | STATE_TERMINATED | STATE_ERROR)
#define MASK_fmi2DoStep STATE_STEP
#define MASK_fmi2CancelStep STATE_NONE /* StepInProgress only, never entered */
#define MASK_fmi2GetStatus (STATE_STEP | STATE_TERMINATED)
#define MASK_fmi2GetRealStatus MASK_fmi2GetStatus
#define MASK_fmi2GetIntegerStatus MASK_fmi2GetStatus
#define MASK_fmi2GetBooleanStatus MASK_fmi2GetStatus
#define MASK_fmi2GetStringStatus MASK_fmi2GetStatus

/* First statement of every FMI function that takes an instance: a NULL instance, or a call in
 * a state its mask does not hold, returns fmi2Error (core_check_state logs and sets Error).
 * `fn` is the function's unprefixed name, e.g. ASSERT_STATE(fmi2GetReal). */
#define ASSERT_STATE(fn)                                                     \
    do {                                                                     \
        if (!core_check_state(M, #fn, MASK_##fn)) return fmi2Error;          \
    } while (0)

static void emit2(const ModelInstance *m, int status, const char *category, const char *message) {
    fmi2CallbackLogger logger = (fmi2CallbackLogger)m->fmi_logger;
    char escaped[1024];
    size_t i, j = 0;
    if (!logger) return;
    /* The FMI 2 logger takes a printf format: escape '%' so the text arrives as written. */
    for (i = 0; message[i] && j + 2 < sizeof escaped; i++) {
        if (message[i] == '%') escaped[j++] = '%';
        escaped[j++] = message[i];
    }
    escaped[j] = '\0';
    logger((fmi2ComponentEnvironment)m->fmi_env, m->instance_name, (fmi2Status)status, category,
           escaped);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    (void)nCategories;
    (void)categories;
    ASSERT_STATE(fmi2SetDebugLogging);
    M->logging_on = loggingOn ? 1 : 0;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    ModelInstance *m;
    (void)fmuResourceLocation;
    (void)visible;
    if (!functions || !functions->logger) return NULL;
    if (fmuType != fmi2CoSimulation) {
        functions->logger(functions->componentEnvironment, instanceName, fmi2Error,
                          "logStatusError",
                          "fmi2Instantiate: %s supports Co-Simulation only", MODEL_IDENTIFIER_STRING);
        return NULL;
    }
    m = core_instantiate(instanceName, fmuGUID, emit2, functions->componentEnvironment,
                         (const void *)functions->logger, loggingOn ? 1 : 0);
    return (fmi2Component)m;
}

/* MASK_fmi2FreeInstance is every state, and NULL is ignored: nothing to check. */
void fmi2FreeInstance(fmi2Component c) { core_free(M); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined,
                               fmi2Real stopTime) {
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    ASSERT_STATE(fmi2SetupExperiment);
    M->v[VR_time] = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    ASSERT_STATE(fmi2EnterInitializationMode);
    return (fmi2Status)core_enter_initialization(M, "fmi2EnterInitializationMode", M->v[VR_time]);
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    ASSERT_STATE(fmi2ExitInitializationMode);
    return (fmi2Status)core_exit_initialization(M, "fmi2ExitInitializationMode");
}

fmi2Status fmi2Terminate(fmi2Component c) {
    ASSERT_STATE(fmi2Terminate);
    return (fmi2Status)core_terminate(M);
}

fmi2Status fmi2Reset(fmi2Component c) {
    ASSERT_STATE(fmi2Reset);
    return (fmi2Status)core_reset(M);
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    ASSERT_STATE(fmi2GetReal);
    return (fmi2Status)core_get_real(M, "fmi2GetReal", vr, nvr, value);
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    ASSERT_STATE(fmi2SetReal);
    return (fmi2Status)core_set_real(M, "fmi2SetReal", vr, nvr, value);
}

/* Typed access for the types no lfctl model has: fine for zero references, an error otherwise.
 * `name` is pasted (fmi2##name) so the function gets its (possibly prefixed) FMI name. */
#define LFCTL_NO_TYPE(name, ctype)                                                            \
    fmi2Status fmi2##name(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,         \
                          ctype value[]) {                                                    \
        (void)vr;                                                                             \
        (void)value;                                                                          \
        ASSERT_STATE(fmi2##name);                                                             \
        return (fmi2Status)core_no_variables_of_type(M, "fmi2" #name, nvr);                   \
    }
LFCTL_NO_TYPE(GetInteger, fmi2Integer)
LFCTL_NO_TYPE(GetBoolean, fmi2Boolean)
LFCTL_NO_TYPE(GetString, fmi2String)
LFCTL_NO_TYPE(SetInteger, const fmi2Integer)
LFCTL_NO_TYPE(SetBoolean, const fmi2Boolean)
LFCTL_NO_TYPE(SetString, const fmi2String)

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    ASSERT_STATE(fmi2GetFMUstate);
    if (!FMUstate) {
        core_log(M, CORE_ERROR, "logStatusError", "fmi2GetFMUstate: FMUstate is NULL");
        return fmi2Error;
    }
    if (*FMUstate) free(*FMUstate);
    *FMUstate = (fmi2FMUstate)core_snapshot_new(M);
    if (!*FMUstate) {
        core_log(M, CORE_ERROR, "logStatusError", "fmi2GetFMUstate: out of memory");
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    ASSERT_STATE(fmi2SetFMUstate);
    return (fmi2Status)core_snapshot_restore(M, "fmi2SetFMUstate", (const CoreSnapshot *)FMUstate);
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    ASSERT_STATE(fmi2FreeFMUstate);
    if (FMUstate && *FMUstate) {
        free(*FMUstate);
        *FMUstate = NULL;
    }
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    (void)FMUstate;
    ASSERT_STATE(fmi2SerializedFMUstateSize);
    if (!size) {
        core_log(M, CORE_ERROR, "logStatusError", "fmi2SerializedFMUstateSize: size is NULL");
        return fmi2Error;
    }
    *size = sizeof(CoreSnapshot);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size) {
    ASSERT_STATE(fmi2SerializeFMUstate);
    if (!FMUstate || !serializedState || size != sizeof(CoreSnapshot)) {
        core_log(M, CORE_ERROR, "logStatusError",
                 "fmi2SerializeFMUstate: needs an FMU state and a buffer of %zu bytes, got %s, "
                 "%s and size %zu",
                 sizeof(CoreSnapshot), FMUstate ? "a state" : "NULL",
                 serializedState ? "a buffer" : "NULL", size);
        return fmi2Error;
    }
    memcpy(serializedState, FMUstate, sizeof(CoreSnapshot));
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    CoreSnapshot *s;
    ASSERT_STATE(fmi2DeSerializeFMUstate);
    if (!FMUstate || !serializedState) {
        core_log(M, CORE_ERROR, "logStatusError",
                 "fmi2DeSerializeFMUstate: serializedState and FMUstate must not be NULL");
        return fmi2Error;
    }
    if (size != sizeof(CoreSnapshot)) {
        core_log(M, CORE_ERROR, "logStatusError",
                 "fmi2DeSerializeFMUstate: size %zu does not match %zu", size,
                 sizeof(CoreSnapshot));
        return fmi2Error;
    }
    s = (CoreSnapshot *)malloc(sizeof *s);
    if (!s) {
        core_log(M, CORE_ERROR, "logStatusError", "fmi2DeSerializeFMUstate: out of memory");
        return fmi2Error;
    }
    memcpy(s, serializedState, sizeof *s);
    if (*FMUstate) free(*FMUstate);
    *FMUstate = (fmi2FMUstate)s;
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    (void)vUnknown_ref, (void)nUnknown, (void)vKnown_ref, (void)nKnown, (void)dvKnown,
        (void)dvUnknown;
    ASSERT_STATE(fmi2GetDirectionalDerivative);
    return (fmi2Status)core_unsupported(M, "fmi2GetDirectionalDerivative");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr, (void)nvr, (void)order, (void)value;
    ASSERT_STATE(fmi2SetRealInputDerivatives);
    return (fmi2Status)core_unsupported(M, "fmi2SetRealInputDerivatives");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[], fmi2Real value[]) {
    (void)vr, (void)nvr, (void)order, (void)value;
    ASSERT_STATE(fmi2GetRealOutputDerivatives);
    return (fmi2Status)core_unsupported(M, "fmi2GetRealOutputDerivatives");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    (void)noSetFMUStatePriorToCurrentPoint;
    ASSERT_STATE(fmi2DoStep);
    return (fmi2Status)core_do_step(M, "fmi2DoStep", currentCommunicationPoint,
                                    communicationStepSize);
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    ASSERT_STATE(fmi2CancelStep); /* STATE_NONE: always refused as unsupported */
    return fmi2Error;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s, (void)value;
    ASSERT_STATE(fmi2GetStatus);
    return (fmi2Status)core_unsupported(M, "fmi2GetStatus");
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    ASSERT_STATE(fmi2GetRealStatus);
    if (s != fmi2LastSuccessfulTime)
        return (fmi2Status)core_unsupported(M, "fmi2GetRealStatus with a kind other than "
                                               "fmi2LastSuccessfulTime");
    if (!value) {
        core_log(M, CORE_ERROR, "logStatusError", "fmi2GetRealStatus: value is NULL");
        return fmi2Error;
    }
    *value = M->v[VR_time];
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s, (void)value;
    ASSERT_STATE(fmi2GetIntegerStatus);
    return (fmi2Status)core_unsupported(M, "fmi2GetIntegerStatus");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    (void)s, (void)value;
    ASSERT_STATE(fmi2GetBooleanStatus);
    return (fmi2Status)core_unsupported(M, "fmi2GetBooleanStatus");
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s, (void)value;
    ASSERT_STATE(fmi2GetStringStatus);
    return (fmi2Status)core_unsupported(M, "fmi2GetStringStatus");
}

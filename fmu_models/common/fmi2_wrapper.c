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
    if (!c) return fmi2Error;
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

void fmi2FreeInstance(fmi2Component c) { core_free(M); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined,
                               fmi2Real stopTime) {
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    if (!c) return fmi2Error;
    if (M->state != STATE_INSTANTIATED) {
        core_log(M, CORE_ERROR, "logStatusError",
                 "fmi2SetupExperiment: only allowed before fmi2EnterInitializationMode");
        M->state = STATE_ERROR;
        return fmi2Error;
    }
    M->v[VR_time] = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    if (!c) return fmi2Error;
    return (fmi2Status)core_enter_initialization(M, "fmi2EnterInitializationMode", M->v[VR_time]);
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    if (!c) return fmi2Error;
    return (fmi2Status)core_exit_initialization(M, "fmi2ExitInitializationMode");
}

fmi2Status fmi2Terminate(fmi2Component c) {
    if (!c) return fmi2Error;
    return (fmi2Status)core_terminate(M, "fmi2Terminate");
}

fmi2Status fmi2Reset(fmi2Component c) {
    if (!c) return fmi2Error;
    return (fmi2Status)core_reset(M);
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    if (!c) return fmi2Error;
    return (fmi2Status)core_get_real(M, "fmi2GetReal", vr, nvr, value);
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    if (!c) return fmi2Error;
    return (fmi2Status)core_set_real(M, "fmi2SetReal", vr, nvr, value);
}

#define LFCTL_NO_TYPE(fn, ctype)                                                              \
    fmi2Status fn(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, ctype value[]) { \
        (void)vr;                                                                             \
        (void)value;                                                                          \
        if (!c) return fmi2Error;                                                             \
        return (fmi2Status)core_no_variables_of_type(M, #fn, nvr);                            \
    }
LFCTL_NO_TYPE(fmi2GetInteger, fmi2Integer)
LFCTL_NO_TYPE(fmi2GetBoolean, fmi2Boolean)
LFCTL_NO_TYPE(fmi2GetString, fmi2String)
LFCTL_NO_TYPE(fmi2SetInteger, const fmi2Integer)
LFCTL_NO_TYPE(fmi2SetBoolean, const fmi2Boolean)
LFCTL_NO_TYPE(fmi2SetString, const fmi2String)

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    if (!c || !FMUstate) return fmi2Error;
    if (*FMUstate) free(*FMUstate);
    *FMUstate = (fmi2FMUstate)core_snapshot_new(M);
    return *FMUstate ? fmi2OK : fmi2Error;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    if (!c) return fmi2Error;
    return (fmi2Status)core_snapshot_restore(M, "fmi2SetFMUstate", (const CoreSnapshot *)FMUstate);
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    (void)c;
    if (FMUstate && *FMUstate) {
        free(*FMUstate);
        *FMUstate = NULL;
    }
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    (void)FMUstate;
    if (!c || !size) return fmi2Error;
    *size = sizeof(CoreSnapshot);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size) {
    if (!c || !FMUstate || size != sizeof(CoreSnapshot)) return fmi2Error;
    memcpy(serializedState, FMUstate, sizeof(CoreSnapshot));
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    CoreSnapshot *s;
    if (!c || !FMUstate) return fmi2Error;
    if (size != sizeof(CoreSnapshot)) {
        core_log(M, CORE_ERROR, "logStatusError",
                 "fmi2DeSerializeFMUstate: size %zu does not match %zu", size,
                 sizeof(CoreSnapshot));
        return fmi2Error;
    }
    s = (CoreSnapshot *)malloc(sizeof *s);
    if (!s) return fmi2Error;
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
    return (fmi2Status)core_unsupported(M, "fmi2GetDirectionalDerivative");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr, (void)nvr, (void)order, (void)value;
    return (fmi2Status)core_unsupported(M, "fmi2SetRealInputDerivatives");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[], fmi2Real value[]) {
    (void)vr, (void)nvr, (void)order, (void)value;
    return (fmi2Status)core_unsupported(M, "fmi2GetRealOutputDerivatives");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!c) return fmi2Error;
    return (fmi2Status)core_do_step(M, "fmi2DoStep", currentCommunicationPoint,
                                    communicationStepSize);
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    return (fmi2Status)core_unsupported(M, "fmi2CancelStep");
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s, (void)value;
    return (fmi2Status)core_unsupported(M, "fmi2GetStatus");
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    if (!c || !value) return fmi2Error;
    if (s != fmi2LastSuccessfulTime) return (fmi2Status)core_unsupported(M, "fmi2GetRealStatus");
    *value = M->v[VR_time];
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s, (void)value;
    return (fmi2Status)core_unsupported(M, "fmi2GetIntegerStatus");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    (void)s, (void)value;
    return (fmi2Status)core_unsupported(M, "fmi2GetBooleanStatus");
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s, (void)value;
    return (fmi2Status)core_unsupported(M, "fmi2GetStringStatus");
}

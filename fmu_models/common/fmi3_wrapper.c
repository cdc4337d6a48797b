/* FMI 3.0 Co-Simulation wrapper, shared by every lfctl model: translates calls into the
 * model core (model_core.h). Every fmi3* symbol is exported, because importers such as fmpy
 * bind them all on load; the ones a Co-Simulation FMU without clocks, events or non-Float64
 * variables cannot serve log a message and return fmi3Error. */
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "model_core.h"

/* The FMI signatures fix the parameter lists; unused ones are expected here. */
#if defined(__GNUC__)
#pragma GCC diagnostic ignored "-Wunused-parameter"
#endif

#define M ((ModelInstance *)instance)

static void emit3(const ModelInstance *m, int status, const char *category, const char *message) {
    fmi3LogMessageCallback log = (fmi3LogMessageCallback)m->fmi_logger;
    if (log) log((fmi3InstanceEnvironment)m->fmi_env, (fmi3Status)status, category, message);
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    if (!instance) return fmi3Error;
    M->logging_on = loggingOn ? 1 : 0;
    return fmi3OK;
}

fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate) {
    if (eventModeUsed) {
        if (logMessage)
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "fmi3InstantiateCoSimulation: eventModeUsed is not supported "
                       "(hasEventMode=false)");
        return NULL;
    }
    return (fmi3Instance)core_instantiate(instanceName, instantiationToken, emit3,
                                          instanceEnvironment, (const void *)logMessage,
                                          loggingOn ? 1 : 0);
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible,
                                          fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    if (logMessage)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "fmi3InstantiateModelExchange: " MODEL_IDENTIFIER_STRING
                   " supports Co-Simulation only");
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption) {
    if (logMessage)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "fmi3InstantiateScheduledExecution: " MODEL_IDENTIFIER_STRING
                   " supports Co-Simulation only");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) { core_free(M); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    if (!instance) return fmi3Error;
    return (fmi3Status)core_enter_initialization(M, "fmi3EnterInitializationMode", startTime);
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    if (!instance) return fmi3Error;
    return (fmi3Status)core_exit_initialization(M, "fmi3ExitInitializationMode");
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
    if (!instance) return fmi3Error;
    return (fmi3Status)core_terminate(M, "fmi3Terminate");
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    if (!instance) return fmi3Error;
    return (fmi3Status)core_reset(M);
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues) {
    if (!instance) return fmi3Error;
    if (nValues != nValueReferences)
        return (fmi3Status)core_unsupported(M, "fmi3GetFloat64 with arrays (nValues != nValueReferences)");
    return (fmi3Status)core_get_real(M, "fmi3GetFloat64", valueReferences, nValueReferences,
                                     values);
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float64 values[], size_t nValues) {
    if (!instance) return fmi3Error;
    if (nValues != nValueReferences)
        return (fmi3Status)core_unsupported(M, "fmi3SetFloat64 with arrays (nValues != nValueReferences)");
    return (fmi3Status)core_set_real(M, "fmi3SetFloat64", valueReferences, nValueReferences,
                                     values);
}

/* Typed access for the types no lfctl model has: fine for zero references, an error otherwise. */
#define LFCTL_GET_NONE(T)                                                                     \
    fmi3Status fmi3Get##T(fmi3Instance instance, const fmi3ValueReference valueReferences[],  \
                          size_t nValueReferences, fmi3##T values[], size_t nValues) {        \
        if (!instance) return fmi3Error;                                                      \
        return (fmi3Status)core_no_variables_of_type(M, "fmi3Get" #T, nValueReferences);      \
    }
#define LFCTL_SET_NONE(T)                                                                     \
    fmi3Status fmi3Set##T(fmi3Instance instance, const fmi3ValueReference valueReferences[],  \
                          size_t nValueReferences, const fmi3##T values[], size_t nValues) {  \
        if (!instance) return fmi3Error;                                                      \
        return (fmi3Status)core_no_variables_of_type(M, "fmi3Set" #T, nValueReferences);      \
    }
#define LFCTL_NONE(T) LFCTL_GET_NONE(T) LFCTL_SET_NONE(T)
LFCTL_NONE(Float32)
LFCTL_NONE(Int8)
LFCTL_NONE(UInt8)
LFCTL_NONE(Int16)
LFCTL_NONE(UInt16)
LFCTL_NONE(Int32)
LFCTL_NONE(UInt32)
LFCTL_NONE(Int64)
LFCTL_NONE(UInt64)
LFCTL_NONE(Boolean)
LFCTL_NONE(String)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, size_t valueSizes[], fmi3Binary values[],
                         size_t nValues) {
    if (!instance) return fmi3Error;
    return (fmi3Status)core_no_variables_of_type(M, "fmi3GetBinary", nValueReferences);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, const size_t valueSizes[],
                         const fmi3Binary values[], size_t nValues) {
    if (!instance) return fmi3Error;
    return (fmi3Status)core_no_variables_of_type(M, "fmi3SetBinary", nValueReferences);
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, fmi3Clock values[]) {
    if (!instance) return fmi3Error;
    return (fmi3Status)core_no_variables_of_type(M, "fmi3GetClock", nValueReferences);
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, const fmi3Clock values[]) {
    if (!instance) return fmi3Error;
    return (fmi3Status)core_no_variables_of_type(M, "fmi3SetClock", nValueReferences);
}

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    if (!instance || !FMUState) return fmi3Error;
    if (*FMUState) free(*FMUState);
    *FMUState = (fmi3FMUState)core_snapshot_new(M);
    return *FMUState ? fmi3OK : fmi3Error;
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    if (!instance) return fmi3Error;
    return (fmi3Status)core_snapshot_restore(M, "fmi3SetFMUState", (const CoreSnapshot *)FMUState);
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    if (FMUState && *FMUState) {
        free(*FMUState);
        *FMUState = NULL;
    }
    return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size) {
    if (!instance || !size) return fmi3Error;
    *size = sizeof(CoreSnapshot);
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState,
                                 fmi3Byte serializedState[], size_t size) {
    if (!instance || !FMUState || size != sizeof(CoreSnapshot)) return fmi3Error;
    memcpy(serializedState, FMUState, sizeof(CoreSnapshot));
    return fmi3OK;
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[],
                                   size_t size, fmi3FMUState *FMUState) {
    CoreSnapshot *s;
    if (!instance || !FMUState) return fmi3Error;
    if (size != sizeof(CoreSnapshot)) {
        core_log(M, CORE_ERROR, "logStatusError",
                 "fmi3DeserializeFMUState: size %zu does not match %zu", size,
                 sizeof(CoreSnapshot));
        return fmi3Error;
    }
    s = (CoreSnapshot *)malloc(sizeof *s);
    if (!s) return fmi3Error;
    memcpy(s, serializedState, sizeof *s);
    if (*FMUState) free(*FMUState);
    *FMUState = (fmi3FMUState)s;
    return fmi3OK;
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    int status;
    if (!instance) return fmi3Error;
    status = core_do_step(M, "fmi3DoStep", currentCommunicationPoint, communicationStepSize);
    if (eventHandlingNeeded) *eventHandlingNeeded = fmi3False;
    if (terminateSimulation) *terminateSimulation = fmi3False;
    if (earlyReturn) *earlyReturn = fmi3False;
    if (lastSuccessfulTime) *lastSuccessfulTime = M->v[VR_time];
    return (fmi3Status)status;
}

/* Everything below belongs to Model Exchange, Scheduled Execution, events, clocks or
 * derivatives, none of which these FMUs declare. */
#define LFCTL_UNSUPPORTED(name, params) \
    fmi3Status name params { return (fmi3Status)core_unsupported(M, #name); }

LFCTL_UNSUPPORTED(fmi3EnterEventMode, (fmi3Instance instance))
LFCTL_UNSUPPORTED(fmi3GetNumberOfVariableDependencies,
                  (fmi3Instance instance, fmi3ValueReference valueReference,
                   size_t *nDependencies))
LFCTL_UNSUPPORTED(fmi3GetVariableDependencies,
                  (fmi3Instance instance, fmi3ValueReference dependent,
                   size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                   size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                   size_t nDependencies))
LFCTL_UNSUPPORTED(fmi3GetDirectionalDerivative,
                  (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                   const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                   size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity))
LFCTL_UNSUPPORTED(fmi3GetAdjointDerivative,
                  (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                   const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                   size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity))
LFCTL_UNSUPPORTED(fmi3EnterConfigurationMode, (fmi3Instance instance))
LFCTL_UNSUPPORTED(fmi3ExitConfigurationMode, (fmi3Instance instance))
LFCTL_UNSUPPORTED(fmi3GetIntervalDecimal,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, fmi3Float64 intervals[],
                   fmi3IntervalQualifier qualifiers[]))
LFCTL_UNSUPPORTED(fmi3GetIntervalFraction,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                   fmi3IntervalQualifier qualifiers[]))
LFCTL_UNSUPPORTED(fmi3GetShiftDecimal,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, fmi3Float64 shifts[]))
LFCTL_UNSUPPORTED(fmi3GetShiftFraction,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[]))
LFCTL_UNSUPPORTED(fmi3SetIntervalDecimal,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, const fmi3Float64 intervals[]))
LFCTL_UNSUPPORTED(fmi3SetIntervalFraction,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, const fmi3UInt64 counters[],
                   const fmi3UInt64 resolutions[]))
LFCTL_UNSUPPORTED(fmi3SetShiftDecimal,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, const fmi3Float64 shifts[]))
LFCTL_UNSUPPORTED(fmi3SetShiftFraction,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, const fmi3UInt64 counters[],
                   const fmi3UInt64 resolutions[]))
LFCTL_UNSUPPORTED(fmi3EvaluateDiscreteStates, (fmi3Instance instance))
LFCTL_UNSUPPORTED(fmi3UpdateDiscreteStates,
                  (fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                   fmi3Boolean *terminateSimulation,
                   fmi3Boolean *nominalsOfContinuousStatesChanged,
                   fmi3Boolean *valuesOfContinuousStatesChanged,
                   fmi3Boolean *nextEventTimeDefined, fmi3Float64 *nextEventTime))
LFCTL_UNSUPPORTED(fmi3EnterContinuousTimeMode, (fmi3Instance instance))
LFCTL_UNSUPPORTED(fmi3CompletedIntegratorStep,
                  (fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                   fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation))
LFCTL_UNSUPPORTED(fmi3SetTime, (fmi3Instance instance, fmi3Float64 time))
LFCTL_UNSUPPORTED(fmi3SetContinuousStates,
                  (fmi3Instance instance, const fmi3Float64 continuousStates[],
                   size_t nContinuousStates))
LFCTL_UNSUPPORTED(fmi3GetContinuousStateDerivatives,
                  (fmi3Instance instance, fmi3Float64 derivatives[], size_t nContinuousStates))
LFCTL_UNSUPPORTED(fmi3GetEventIndicators,
                  (fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators))
LFCTL_UNSUPPORTED(fmi3GetContinuousStates,
                  (fmi3Instance instance, fmi3Float64 continuousStates[],
                   size_t nContinuousStates))
LFCTL_UNSUPPORTED(fmi3GetNominalsOfContinuousStates,
                  (fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates))
LFCTL_UNSUPPORTED(fmi3GetNumberOfEventIndicators,
                  (fmi3Instance instance, size_t *nEventIndicators))
LFCTL_UNSUPPORTED(fmi3GetNumberOfContinuousStates,
                  (fmi3Instance instance, size_t *nContinuousStates))
LFCTL_UNSUPPORTED(fmi3EnterStepMode, (fmi3Instance instance))
LFCTL_UNSUPPORTED(fmi3GetOutputDerivatives,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                   size_t nValues))
LFCTL_UNSUPPORTED(fmi3ActivateModelPartition,
                  (fmi3Instance instance, fmi3ValueReference clockReference,
                   fmi3Float64 activationTime))

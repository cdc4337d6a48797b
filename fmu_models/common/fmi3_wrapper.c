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

/* In which states each FMI 3.0 function may be called: the FMI 3.0 state machine for
 * Co-Simulation (the common states, section 2.3, and Co-Simulation, chapter 4),
 * reduced to this FMU: hasEventMode = false (instantiation refuses eventModeUsed), no
 * structural parameters (so no Configuration / Reconfiguration Mode), no intermediate update,
 * no early return, and fmi3DoStep never returns fmi3Discard (no Step Discarded).
 *
 * FMI 3 has no Error state: a call returning fmi3Error leaves the FMU in Terminated. The core
 * records that as STATE_ERROR (so that the FMI 2 and FMI 3 wrappers share one core, and
 * messages can add that an earlier call failed; they name the state Terminated), and every mask here that allows
 * Terminated allows STATE_ERROR too (FMI3_TERMINATED).
 *
 * fmi3GetVersion takes no instance; fmi3FreeInstance is allowed in every state (and ignores
 * NULL). STATE_NONE marks the functions of Model Exchange, Scheduled Execution, Event Mode and
 * clocks: no state of this FMU allows them, and they are refused as unsupported. Other
 * functions this FMU does not provide are checked against the standard's mask first. */
#define FMI3_TERMINATED (STATE_TERMINATED | STATE_ERROR)
#define FMI3_GETTABLE (STATE_INSTANTIATED | STATE_INITIALIZATION | STATE_STEP | FMI3_TERMINATED)
#define FMI3_SETTABLE (STATE_INSTANTIATED | STATE_INITIALIZATION | STATE_STEP)
#define FMI3_DERIVATIVES (STATE_INITIALIZATION | STATE_STEP | FMI3_TERMINATED)

/* Common functions */
#define MASK_fmi3SetDebugLogging STATE_ANY
#define MASK_fmi3FreeInstance STATE_ANY
#define MASK_fmi3EnterInitializationMode STATE_INSTANTIATED
#define MASK_fmi3ExitInitializationMode STATE_INITIALIZATION
#define MASK_fmi3EnterEventMode STATE_NONE /* Step Mode only when eventModeUsed */
#define MASK_fmi3Terminate STATE_STEP
#define MASK_fmi3Reset STATE_ANY
/* Get in Instantiated returns start values; in Terminated after an error, for diagnostics. */
#define MASK_fmi3GetFloat32 FMI3_GETTABLE
#define MASK_fmi3GetFloat64 FMI3_GETTABLE
#define MASK_fmi3GetInt8 FMI3_GETTABLE
#define MASK_fmi3GetUInt8 FMI3_GETTABLE
#define MASK_fmi3GetInt16 FMI3_GETTABLE
#define MASK_fmi3GetUInt16 FMI3_GETTABLE
#define MASK_fmi3GetInt32 FMI3_GETTABLE
#define MASK_fmi3GetUInt32 FMI3_GETTABLE
#define MASK_fmi3GetInt64 FMI3_GETTABLE
#define MASK_fmi3GetUInt64 FMI3_GETTABLE
#define MASK_fmi3GetBoolean FMI3_GETTABLE
#define MASK_fmi3GetString FMI3_GETTABLE
#define MASK_fmi3GetBinary FMI3_GETTABLE
/* Which variables may be set in which state is checked per variable by the core. */
#define MASK_fmi3SetFloat32 FMI3_SETTABLE
#define MASK_fmi3SetFloat64 FMI3_SETTABLE
#define MASK_fmi3SetInt8 FMI3_SETTABLE
#define MASK_fmi3SetUInt8 FMI3_SETTABLE
#define MASK_fmi3SetInt16 FMI3_SETTABLE
#define MASK_fmi3SetUInt16 FMI3_SETTABLE
#define MASK_fmi3SetInt32 FMI3_SETTABLE
#define MASK_fmi3SetUInt32 FMI3_SETTABLE
#define MASK_fmi3SetInt64 FMI3_SETTABLE
#define MASK_fmi3SetUInt64 FMI3_SETTABLE
#define MASK_fmi3SetBoolean FMI3_SETTABLE
#define MASK_fmi3SetString FMI3_SETTABLE
#define MASK_fmi3SetBinary FMI3_SETTABLE
#define MASK_fmi3GetNumberOfVariableDependencies STATE_ANY
#define MASK_fmi3GetVariableDependencies STATE_ANY
#define MASK_fmi3GetFMUState STATE_ANY
#define MASK_fmi3SetFMUState STATE_ANY
#define MASK_fmi3FreeFMUState STATE_ANY
#define MASK_fmi3SerializedFMUStateSize STATE_ANY
#define MASK_fmi3SerializeFMUState STATE_ANY
#define MASK_fmi3DeserializeFMUState STATE_ANY
#define MASK_fmi3GetDirectionalDerivative FMI3_DERIVATIVES
#define MASK_fmi3GetAdjointDerivative FMI3_DERIVATIVES
#define MASK_fmi3EnterConfigurationMode STATE_NONE /* needs structural parameters */
#define MASK_fmi3ExitConfigurationMode STATE_NONE  /* (Re)Configuration Mode never entered */
/* Clocks: Event Mode (Co-Simulation) or Scheduled Execution only */
#define MASK_fmi3GetClock STATE_NONE
#define MASK_fmi3SetClock STATE_NONE
#define MASK_fmi3GetIntervalDecimal STATE_NONE
#define MASK_fmi3GetIntervalFraction STATE_NONE
#define MASK_fmi3GetShiftDecimal STATE_NONE
#define MASK_fmi3GetShiftFraction STATE_NONE
#define MASK_fmi3SetIntervalDecimal STATE_NONE
#define MASK_fmi3SetIntervalFraction STATE_NONE
#define MASK_fmi3SetShiftDecimal STATE_NONE
#define MASK_fmi3SetShiftFraction STATE_NONE
#define MASK_fmi3EvaluateDiscreteStates STATE_STEP /* Co-Simulation without Event Mode */
#define MASK_fmi3UpdateDiscreteStates STATE_NONE   /* Event Mode only */
/* Model Exchange only */
#define MASK_fmi3EnterContinuousTimeMode STATE_NONE
#define MASK_fmi3CompletedIntegratorStep STATE_NONE
#define MASK_fmi3SetTime STATE_NONE
#define MASK_fmi3SetContinuousStates STATE_NONE
#define MASK_fmi3GetContinuousStateDerivatives STATE_NONE
#define MASK_fmi3GetEventIndicators STATE_NONE
#define MASK_fmi3GetContinuousStates STATE_NONE
#define MASK_fmi3GetNominalsOfContinuousStates STATE_NONE
#define MASK_fmi3GetNumberOfEventIndicators STATE_NONE
#define MASK_fmi3GetNumberOfContinuousStates STATE_NONE
/* Co-Simulation */
#define MASK_fmi3EnterStepMode STATE_NONE /* from Event Mode only */
#define MASK_fmi3GetOutputDerivatives (STATE_STEP | FMI3_TERMINATED)
#define MASK_fmi3DoStep STATE_STEP
/* Scheduled Execution only */
#define MASK_fmi3ActivateModelPartition STATE_NONE

/* First statement of every FMI function that takes an instance: a NULL instance, or a call in
 * a state its mask does not hold, returns fmi3Error (core_check_state logs and sets the error
 * state). `fn` is the function's unprefixed name, e.g. ASSERT_STATE(fmi3GetFloat64). */
#define ASSERT_STATE(fn)                                                     \
    do {                                                                     \
        if (!core_check_state(M, #fn, MASK_##fn)) return fmi3Error;          \
    } while (0)

static void emit3(const ModelInstance *m, int status, const char *category, const char *message) {
    fmi3LogMessageCallback log = (fmi3LogMessageCallback)m->fmi_logger;
    if (log) log((fmi3InstanceEnvironment)m->fmi_env, (fmi3Status)status, category, message);
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    ASSERT_STATE(fmi3SetDebugLogging);
    M->logging_on = loggingOn ? 1 : 0;
    return fmi3OK;
}

fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate) {
    ModelInstance *m;
    if (eventModeUsed) {
        if (logMessage)
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "fmi3InstantiateCoSimulation: eventModeUsed is not supported "
                       "(hasEventMode=false)");
        return NULL;
    }
    m = core_instantiate(instanceName, instantiationToken, emit3, instanceEnvironment,
                         (const void *)logMessage, loggingOn ? 1 : 0);
    if (m) m->error_is_terminated = 1;
    return (fmi3Instance)m;
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

/* MASK_fmi3FreeInstance is every state, and NULL is ignored: nothing to check. */
void fmi3FreeInstance(fmi3Instance instance) { core_free(M); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    ASSERT_STATE(fmi3EnterInitializationMode);
    return (fmi3Status)core_enter_initialization(M, "fmi3EnterInitializationMode", startTime);
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    ASSERT_STATE(fmi3ExitInitializationMode);
    return (fmi3Status)core_exit_initialization(M, "fmi3ExitInitializationMode");
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
    ASSERT_STATE(fmi3Terminate);
    return (fmi3Status)core_terminate(M);
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    ASSERT_STATE(fmi3Reset);
    return (fmi3Status)core_reset(M);
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues) {
    ASSERT_STATE(fmi3GetFloat64);
    if (nValues != nValueReferences)
        return (fmi3Status)core_unsupported(M, "fmi3GetFloat64 with arrays (nValues != nValueReferences)");
    return (fmi3Status)core_get_real(M, "fmi3GetFloat64", valueReferences, nValueReferences,
                                     values);
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float64 values[], size_t nValues) {
    ASSERT_STATE(fmi3SetFloat64);
    if (nValues != nValueReferences)
        return (fmi3Status)core_unsupported(M, "fmi3SetFloat64 with arrays (nValues != nValueReferences)");
    return (fmi3Status)core_set_real(M, "fmi3SetFloat64", valueReferences, nValueReferences,
                                     values);
}

/* Typed access for the types no lfctl model has: fine for zero references, an error otherwise. */
#define LFCTL_GET_NONE(T)                                                                     \
    fmi3Status fmi3Get##T(fmi3Instance instance, const fmi3ValueReference valueReferences[],  \
                          size_t nValueReferences, fmi3##T values[], size_t nValues) {        \
        ASSERT_STATE(fmi3Get##T);                                                             \
        return (fmi3Status)core_no_variables_of_type(M, "fmi3Get" #T, nValueReferences);      \
    }
#define LFCTL_SET_NONE(T)                                                                     \
    fmi3Status fmi3Set##T(fmi3Instance instance, const fmi3ValueReference valueReferences[],  \
                          size_t nValueReferences, const fmi3##T values[], size_t nValues) {  \
        ASSERT_STATE(fmi3Set##T);                                                             \
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
    ASSERT_STATE(fmi3GetBinary);
    return (fmi3Status)core_no_variables_of_type(M, "fmi3GetBinary", nValueReferences);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, const size_t valueSizes[],
                         const fmi3Binary values[], size_t nValues) {
    ASSERT_STATE(fmi3SetBinary);
    return (fmi3Status)core_no_variables_of_type(M, "fmi3SetBinary", nValueReferences);
}


fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    ASSERT_STATE(fmi3GetFMUState);
    if (!FMUState) {
        core_log(M, CORE_ERROR, "logStatusError", "fmi3GetFMUState: FMUState is NULL");
        return fmi3Error;
    }
    if (*FMUState) free(*FMUState);
    *FMUState = (fmi3FMUState)core_snapshot_new(M);
    if (!*FMUState) {
        core_log(M, CORE_ERROR, "logStatusError", "fmi3GetFMUState: out of memory");
        return fmi3Error;
    }
    return fmi3OK;
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    ASSERT_STATE(fmi3SetFMUState);
    return (fmi3Status)core_snapshot_restore(M, "fmi3SetFMUState", (const CoreSnapshot *)FMUState);
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    ASSERT_STATE(fmi3FreeFMUState);
    if (FMUState && *FMUState) {
        free(*FMUState);
        *FMUState = NULL;
    }
    return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size) {
    ASSERT_STATE(fmi3SerializedFMUStateSize);
    if (!size) {
        core_log(M, CORE_ERROR, "logStatusError", "fmi3SerializedFMUStateSize: size is NULL");
        return fmi3Error;
    }
    *size = sizeof(CoreSnapshot);
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState,
                                 fmi3Byte serializedState[], size_t size) {
    ASSERT_STATE(fmi3SerializeFMUState);
    if (!FMUState || !serializedState || size != sizeof(CoreSnapshot)) {
        core_log(M, CORE_ERROR, "logStatusError",
                 "fmi3SerializeFMUState: needs an FMU state and a buffer of %zu bytes, got %s, "
                 "%s and size %zu",
                 sizeof(CoreSnapshot), FMUState ? "a state" : "NULL",
                 serializedState ? "a buffer" : "NULL", size);
        return fmi3Error;
    }
    memcpy(serializedState, FMUState, sizeof(CoreSnapshot));
    return fmi3OK;
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[],
                                   size_t size, fmi3FMUState *FMUState) {
    CoreSnapshot *s;
    ASSERT_STATE(fmi3DeserializeFMUState);
    if (!FMUState || !serializedState) {
        core_log(M, CORE_ERROR, "logStatusError",
                 "fmi3DeserializeFMUState: serializedState and FMUState must not be NULL");
        return fmi3Error;
    }
    if (size != sizeof(CoreSnapshot)) {
        core_log(M, CORE_ERROR, "logStatusError",
                 "fmi3DeserializeFMUState: size %zu does not match %zu", size,
                 sizeof(CoreSnapshot));
        return fmi3Error;
    }
    s = (CoreSnapshot *)malloc(sizeof *s);
    if (!s) {
        core_log(M, CORE_ERROR, "logStatusError", "fmi3DeserializeFMUState: out of memory");
        return fmi3Error;
    }
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
    ASSERT_STATE(fmi3DoStep);
    status = core_do_step(M, "fmi3DoStep", currentCommunicationPoint, communicationStepSize);
    if (eventHandlingNeeded) *eventHandlingNeeded = fmi3False;
    if (terminateSimulation) *terminateSimulation = fmi3False;
    if (earlyReturn) *earlyReturn = fmi3False;
    if (lastSuccessfulTime) *lastSuccessfulTime = M->v[VR_time];
    return (fmi3Status)status;
}

/* Everything below belongs to Model Exchange, Scheduled Execution, events, clocks or
 * derivatives, none of which these FMUs declare. Each is checked against its mask first (an
 * empty mask reports it as unsupported), then refused as unsupported. `name` is the suffix
 * after fmi3, pasted so the function gets its (possibly prefixed) FMI name. */
#define LFCTL_UNSUPPORTED(name, params)                                \
    fmi3Status fmi3##name params {                                     \
        ASSERT_STATE(fmi3##name);                                      \
        return (fmi3Status)core_unsupported(M, "fmi3" #name);          \
    }

LFCTL_UNSUPPORTED(GetClock, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                             size_t nValueReferences, fmi3Clock values[]))
LFCTL_UNSUPPORTED(SetClock, (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                             size_t nValueReferences, const fmi3Clock values[]))

LFCTL_UNSUPPORTED(EnterEventMode, (fmi3Instance instance))
LFCTL_UNSUPPORTED(GetNumberOfVariableDependencies,
                  (fmi3Instance instance, fmi3ValueReference valueReference,
                   size_t *nDependencies))
LFCTL_UNSUPPORTED(GetVariableDependencies,
                  (fmi3Instance instance, fmi3ValueReference dependent,
                   size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                   size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                   size_t nDependencies))
LFCTL_UNSUPPORTED(GetDirectionalDerivative,
                  (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                   const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                   size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity))
LFCTL_UNSUPPORTED(GetAdjointDerivative,
                  (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                   const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                   size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity))
LFCTL_UNSUPPORTED(EnterConfigurationMode, (fmi3Instance instance))
LFCTL_UNSUPPORTED(ExitConfigurationMode, (fmi3Instance instance))
LFCTL_UNSUPPORTED(GetIntervalDecimal,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, fmi3Float64 intervals[],
                   fmi3IntervalQualifier qualifiers[]))
LFCTL_UNSUPPORTED(GetIntervalFraction,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                   fmi3IntervalQualifier qualifiers[]))
LFCTL_UNSUPPORTED(GetShiftDecimal,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, fmi3Float64 shifts[]))
LFCTL_UNSUPPORTED(GetShiftFraction,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[]))
LFCTL_UNSUPPORTED(SetIntervalDecimal,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, const fmi3Float64 intervals[]))
LFCTL_UNSUPPORTED(SetIntervalFraction,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, const fmi3UInt64 counters[],
                   const fmi3UInt64 resolutions[]))
LFCTL_UNSUPPORTED(SetShiftDecimal,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, const fmi3Float64 shifts[]))
LFCTL_UNSUPPORTED(SetShiftFraction,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, const fmi3UInt64 counters[],
                   const fmi3UInt64 resolutions[]))
LFCTL_UNSUPPORTED(EvaluateDiscreteStates, (fmi3Instance instance))
LFCTL_UNSUPPORTED(UpdateDiscreteStates,
                  (fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                   fmi3Boolean *terminateSimulation,
                   fmi3Boolean *nominalsOfContinuousStatesChanged,
                   fmi3Boolean *valuesOfContinuousStatesChanged,
                   fmi3Boolean *nextEventTimeDefined, fmi3Float64 *nextEventTime))
LFCTL_UNSUPPORTED(EnterContinuousTimeMode, (fmi3Instance instance))
LFCTL_UNSUPPORTED(CompletedIntegratorStep,
                  (fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                   fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation))
LFCTL_UNSUPPORTED(SetTime, (fmi3Instance instance, fmi3Float64 time))
LFCTL_UNSUPPORTED(SetContinuousStates,
                  (fmi3Instance instance, const fmi3Float64 continuousStates[],
                   size_t nContinuousStates))
LFCTL_UNSUPPORTED(GetContinuousStateDerivatives,
                  (fmi3Instance instance, fmi3Float64 derivatives[], size_t nContinuousStates))
LFCTL_UNSUPPORTED(GetEventIndicators,
                  (fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators))
LFCTL_UNSUPPORTED(GetContinuousStates,
                  (fmi3Instance instance, fmi3Float64 continuousStates[],
                   size_t nContinuousStates))
LFCTL_UNSUPPORTED(GetNominalsOfContinuousStates,
                  (fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates))
LFCTL_UNSUPPORTED(GetNumberOfEventIndicators,
                  (fmi3Instance instance, size_t *nEventIndicators))
LFCTL_UNSUPPORTED(GetNumberOfContinuousStates,
                  (fmi3Instance instance, size_t *nContinuousStates))
LFCTL_UNSUPPORTED(EnterStepMode, (fmi3Instance instance))
LFCTL_UNSUPPORTED(GetOutputDerivatives,
                  (fmi3Instance instance, const fmi3ValueReference valueReferences[],
                   size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                   size_t nValues))
LFCTL_UNSUPPORTED(ActivateModelPartition,
                  (fmi3Instance instance, fmi3ValueReference clockReference,
                   fmi3Float64 activationTime))

/* FaultyRover: a test-only vehicle (tests/fmu/test_containment.py), never shipped. A kinematic
 * unicycle that misbehaves on request from time `fault_at` on:
 *   fault 1: north is NaN          fault 2: speed is +inf        fault 3: east is 1e308
 *   fault 4: doStep never returns (it spins; writes its process id to $LFCTL_TEST_FMU_MARK first, if set)
 *   fault 5: north and east are 9e5 m (far, yet within lfctl's 1e6 m bound: no error)
 *   fault 6: doStep raises SIGSEGV  fault 7: doStep calls exit(0)  fault 8: doStep aborts
 *   fault 9: initialisation never returns (spins, as fault 4)
 * X(name, causality, variability, start, unit, description); value references from 1. */
#ifndef LFCTL_CONFIG_H
#define LFCTL_CONFIG_H

#define MODEL_IDENTIFIER FaultyRover
#define MODEL_IDENTIFIER_STRING "FaultyRover"
#define INSTANTIATION_TOKEN "{5b0d6c2e-9a41-4f7e-8c13-0e2f4a6b8d97}"
#define MODEL_DESCRIPTION_TEXT "Test-only unicycle whose outputs go bad or whose doStep hangs"
#define N_STATES 3

#define MODEL_VARIABLES(X)                                                                    \
    X(speed_cmd, INPUT, CONTINUOUS, 0.0, "m/s", "Commanded forward speed")                    \
    X(yaw_rate_cmd, INPUT, CONTINUOUS, 0.0, "rad/s", "Commanded yaw rate, positive clockwise") \
    X(north, OUTPUT, CONTINUOUS, 0.0, "m", "Position north of the local origin")              \
    X(east, OUTPUT, CONTINUOUS, 0.0, "m", "Position east of the local origin")                \
    X(yaw, OUTPUT, CONTINUOUS, 0.0, "rad", "Heading from north, clockwise")                   \
    X(speed, OUTPUT, CONTINUOUS, 0.0, "m/s", "Forward speed over ground")                     \
    X(yaw_rate, OUTPUT, CONTINUOUS, 0.0, "rad/s", "Yaw rate, positive clockwise")             \
    X(fault, PARAMETER, FIXED, 0.0, "1", "0 none, 1 NaN, 2 inf, 3 1e308, 4 hang, 5 far, 6 SIGSEGV, 7 exit, 8 abort, 9 init hang")\
    X(fault_at, PARAMETER, FIXED, 0.0, "s", "When the fault starts")                          \
    X(internal_step, PARAMETER, FIXED, 0.01, "s", "Fixed RK4 sub-step inside doStep")         \
    X(north_0, PARAMETER, FIXED, 0.0, "m", "Initial north position")                          \
    X(east_0, PARAMETER, FIXED, 0.0, "m", "Initial east position")                            \
    X(yaw_0, PARAMETER, FIXED, 0.0, "rad", "Initial heading")

#define VR_FIXED_STEP VR_internal_step

#endif

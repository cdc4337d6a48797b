/* KinematicUnicycle: an ideal rover that follows its speed and yaw-rate commands at once,
 * within limits. A reference for the controllers and a second model for the shared wrappers.
 * X(name, causality, variability, start, unit, description); value references from 1. */
#ifndef LFCTL_CONFIG_H
#define LFCTL_CONFIG_H

#define MODEL_IDENTIFIER KinematicUnicycle
#define MODEL_IDENTIFIER_STRING "KinematicUnicycle"
#define INSTANTIATION_TOKEN "{8d2e4b71-0c3a-4f95-b6d8-2a9e7c1f5b30}"
#define MODEL_DESCRIPTION_TEXT "Kinematic unicycle with speed and yaw-rate limits"
#define N_STATES 3

#define MODEL_VARIABLES(X)                                                                    \
    X(speed_cmd, INPUT, CONTINUOUS, 0.0, "m/s", "Commanded forward speed")                    \
    X(yaw_rate_cmd, INPUT, CONTINUOUS, 0.0, "rad/s", "Commanded yaw rate, positive clockwise") \
    X(north, OUTPUT, CONTINUOUS, 0.0, "m", "Position north of the local origin")              \
    X(east, OUTPUT, CONTINUOUS, 0.0, "m", "Position east of the local origin")                \
    X(yaw, OUTPUT, CONTINUOUS, 0.0, "rad", "Heading from north, clockwise, in (-pi, pi]")     \
    X(speed, OUTPUT, CONTINUOUS, 0.0, "m/s", "Forward speed over ground")                     \
    X(yaw_rate, OUTPUT, CONTINUOUS, 0.0, "rad/s", "Yaw rate, positive clockwise")             \
    X(max_speed, PARAMETER, FIXED, 0.6, "m/s", "Forward speed limit")                          \
    X(max_yaw_rate, PARAMETER, FIXED, 3.0, "rad/s", "Yaw-rate limit")                          \
    X(internal_step, PARAMETER, FIXED, 0.001, "s", "Fixed RK4 sub-step inside doStep")        \
    X(north_0, PARAMETER, FIXED, 0.0, "m", "Initial north position")                          \
    X(east_0, PARAMETER, FIXED, 0.0, "m", "Initial east position")                            \
    X(yaw_0, PARAMETER, FIXED, 0.0, "rad", "Initial heading")

#define VR_FIXED_STEP VR_internal_step

#endif

/* SkidSteerRover: the paper's Robokit 4-wheel skid-steer base (section 4).
 * See readme.md for the equations. This table is the single source of truth for the
 * variables: the C core reads it, and lfctl generates both modelDescription.xml files from it.
 * X(name, causality, variability, start, unit, description); value references 1, 2, ... in
 * this order (0 is time). Outputs and inputs first, parameters after. */
#ifndef LFCTL_CONFIG_H
#define LFCTL_CONFIG_H

#define MODEL_IDENTIFIER SkidSteerRover
#define MODEL_IDENTIFIER_STRING "SkidSteerRover"
#define INSTANTIATION_TOKEN "{3f0c9a52-6b8e-4d1f-9a2c-5e7b1d4c8a61}"
#define MODEL_DESCRIPTION_TEXT "Skid-steer rover: wheel-speed lag, limits and skid loss"
#define N_STATES 5

#define MODEL_VARIABLES(X)                                                                    \
    X(speed_cmd, INPUT, CONTINUOUS, 0.0, "m/s", "Commanded forward speed")                    \
    X(yaw_rate_cmd, INPUT, CONTINUOUS, 0.0, "rad/s", "Commanded yaw rate, positive clockwise") \
    X(north, OUTPUT, CONTINUOUS, 0.0, "m", "Position north of the local origin")              \
    X(east, OUTPUT, CONTINUOUS, 0.0, "m", "Position east of the local origin")                \
    X(yaw, OUTPUT, CONTINUOUS, 0.0, "rad", "Heading from north, clockwise, in (-pi, pi]")     \
    X(speed, OUTPUT, CONTINUOUS, 0.0, "m/s", "Forward speed over ground")                     \
    X(yaw_rate, OUTPUT, CONTINUOUS, 0.0, "rad/s", "Yaw rate, positive clockwise")             \
    X(wheel_speed_left, OUTPUT, CONTINUOUS, 0.0, "m/s", "Left track speed")                   \
    X(wheel_speed_right, OUTPUT, CONTINUOUS, 0.0, "m/s", "Right track speed")                 \
    X(track_width, PARAMETER, FIXED, 0.25, "m", "Distance between left and right wheels")     \
    X(tau, PARAMETER, FIXED, 0.15, "s", "Wheel-speed first-order lag time constant")          \
    X(max_wheel_speed, PARAMETER, FIXED, 0.6, "m/s", "Wheel speed limit")                      \
    X(max_wheel_accel, PARAMETER, FIXED, 2.0, "m/s2", "Wheel acceleration limit")              \
    X(skid_factor, PARAMETER, FIXED, 0.8, "1", "Achieved / kinematic yaw rate, in (0, 1]")    \
    X(internal_step, PARAMETER, FIXED, 0.001, "s", "Fixed RK4 sub-step inside doStep")        \
    X(north_0, PARAMETER, FIXED, 0.0, "m", "Initial north position")                          \
    X(east_0, PARAMETER, FIXED, 0.0, "m", "Initial east position")                            \
    X(yaw_0, PARAMETER, FIXED, 0.0, "rad", "Initial heading")

#define VR_FIXED_STEP VR_internal_step

#endif

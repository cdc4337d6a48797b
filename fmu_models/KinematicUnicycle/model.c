/* KinematicUnicycle equations (readme.md). States: north, east, yaw. */
#include <math.h>
#include <stdio.h>

#include "model_core.h"

enum { X_NORTH, X_EAST, X_YAW };

void model_initialize(const double *v, double *x) {
    x[X_NORTH] = v[VR_north_0];
    x[X_EAST] = v[VR_east_0];
    x[X_YAW] = core_wrap_pi(v[VR_yaw_0]);
}

void model_derivatives(const double *v, const double *x, double *dx) {
    const double speed = core_clamp(v[VR_speed_cmd], v[VR_max_speed]);
    dx[X_NORTH] = speed * cos(x[X_YAW]);
    dx[X_EAST] = speed * sin(x[X_YAW]);
    dx[X_YAW] = core_clamp(v[VR_yaw_rate_cmd], v[VR_max_yaw_rate]);
}

void model_outputs(double *v, const double *x) {
    v[VR_north] = x[X_NORTH];
    v[VR_east] = x[X_EAST];
    v[VR_yaw] = x[X_YAW];
    v[VR_speed] = core_clamp(v[VR_speed_cmd], v[VR_max_speed]);
    v[VR_yaw_rate] = core_clamp(v[VR_yaw_rate_cmd], v[VR_max_yaw_rate]);
}

void model_normalize(double *x) { x[X_YAW] = core_wrap_pi(x[X_YAW]); }

int model_check_parameters(const double *v, char *message, size_t size) {
    if (!(v[VR_max_speed] > 0.0)) {
        snprintf(message, size, "must be > 0 m/s, got %g", v[VR_max_speed]);
        return VR_max_speed;
    }
    if (!(v[VR_max_yaw_rate] > 0.0)) {
        snprintf(message, size, "must be > 0 rad/s, got %g", v[VR_max_yaw_rate]);
        return VR_max_yaw_rate;
    }
    /* at least 10 us: a smaller sub-step makes every doStep run for hours (1e-12 s: 1e10 of them) */
    if (!(v[VR_internal_step] >= 1e-5 && v[VR_internal_step] <= 1.0)) {
        snprintf(message, size, "must be in [1e-05, 1] s, got %g", v[VR_internal_step]);
        return VR_internal_step;
    }
    return 0;
}

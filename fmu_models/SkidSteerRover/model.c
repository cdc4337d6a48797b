/* SkidSteerRover equations (readme.md). States: north, east, yaw, left and right wheel speed. */
#include <math.h>
#include <stdio.h>

#include "model_core.h"

enum { X_NORTH, X_EAST, X_YAW, X_WL, X_WR };

void model_initialize(const double *v, double *x) {
    x[X_NORTH] = v[VR_north_0];
    x[X_EAST] = v[VR_east_0];
    x[X_YAW] = core_wrap_pi(v[VR_yaw_0]);
    x[X_WL] = 0.0;
    x[X_WR] = 0.0;
}

void model_derivatives(const double *v, const double *x, double *dx) {
    const double half_track = 0.5 * v[VR_track_width];
    const double w_max = v[VR_max_wheel_speed];
    const double a_max = v[VR_max_wheel_accel];
    /* Turning right (positive, clockwise yaw rate) needs the left track faster. */
    const double wl_cmd = core_clamp(v[VR_speed_cmd] + half_track * v[VR_yaw_rate_cmd], w_max);
    const double wr_cmd = core_clamp(v[VR_speed_cmd] - half_track * v[VR_yaw_rate_cmd], w_max);
    const double speed = 0.5 * (x[X_WL] + x[X_WR]);
    const double yaw_rate = v[VR_skid_factor] * (x[X_WL] - x[X_WR]) / v[VR_track_width];
    dx[X_NORTH] = speed * cos(x[X_YAW]);
    dx[X_EAST] = speed * sin(x[X_YAW]);
    dx[X_YAW] = yaw_rate;
    dx[X_WL] = core_clamp((wl_cmd - x[X_WL]) / v[VR_tau], a_max);
    dx[X_WR] = core_clamp((wr_cmd - x[X_WR]) / v[VR_tau], a_max);
}

void model_outputs(double *v, const double *x) {
    v[VR_north] = x[X_NORTH];
    v[VR_east] = x[X_EAST];
    v[VR_yaw] = x[X_YAW];
    v[VR_speed] = 0.5 * (x[X_WL] + x[X_WR]);
    v[VR_yaw_rate] = v[VR_skid_factor] * (x[X_WL] - x[X_WR]) / v[VR_track_width];
    v[VR_wheel_speed_left] = x[X_WL];
    v[VR_wheel_speed_right] = x[X_WR];
}

void model_normalize(double *x) { x[X_YAW] = core_wrap_pi(x[X_YAW]); }

int model_check_parameters(const double *v, char *message, size_t size) {
    if (!(v[VR_track_width] > 0.0)) {
        snprintf(message, size, "must be > 0 m, got %g", v[VR_track_width]);
        return VR_track_width;
    }
    if (!(v[VR_tau] > 0.0)) {
        snprintf(message, size, "must be > 0 s, got %g", v[VR_tau]);
        return VR_tau;
    }
    if (!(v[VR_max_wheel_speed] > 0.0)) {
        snprintf(message, size, "must be > 0 m/s, got %g", v[VR_max_wheel_speed]);
        return VR_max_wheel_speed;
    }
    if (!(v[VR_max_wheel_accel] > 0.0)) {
        snprintf(message, size, "must be > 0 m/s2, got %g", v[VR_max_wheel_accel]);
        return VR_max_wheel_accel;
    }
    if (!(v[VR_skid_factor] > 0.0 && v[VR_skid_factor] <= 1.0)) {
        snprintf(message, size, "must be in (0, 1], got %g", v[VR_skid_factor]);
        return VR_skid_factor;
    }
    /* at least 10 us: a smaller sub-step makes every doStep run for hours (1e-12 s: 1e10 of them) */
    if (!(v[VR_internal_step] >= 1e-5 && v[VR_internal_step] <= 1.0)) {
        snprintf(message, size, "must be in [1e-05, 1] s, got %g", v[VR_internal_step]);
        return VR_internal_step;
    }
    return 0;
}

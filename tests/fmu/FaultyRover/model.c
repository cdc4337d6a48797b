/* FaultyRover (config.h): a kinematic unicycle with faults on request. Test-only. */
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "model_core.h"

enum { X_NORTH, X_EAST, X_YAW };

static int faulty(const double *v, int kind) {
    return (int)v[VR_fault] == kind && v[VR_time] >= v[VR_fault_at];
}

static void hang(void) {
    volatile int forever = 1;
    const char *mark = getenv("LFCTL_TEST_FMU_MARK");
    if (mark) {
        FILE *f = fopen(mark, "w");
        if (f) {
            fprintf(f, "%ld", (long)getpid());
            fclose(f);
        }
    }
    while (forever) {
    }
}

/* stuck as the library is loaded (dlopen runs this), before any FMI call */
__attribute__((constructor)) static void hang_on_load(void) {
    if (getenv("LFCTL_TEST_FMU_LOAD_HANG")) hang();
}

void model_initialize(const double *v, double *x) {
    if ((int)v[VR_fault] == 9) hang();
    x[X_NORTH] = v[VR_north_0];
    x[X_EAST] = v[VR_east_0];
    x[X_YAW] = v[VR_yaw_0];
}

void model_derivatives(const double *v, const double *x, double *dx) {
    if (faulty(v, 4)) hang();
    if (faulty(v, 6)) raise(SIGSEGV);
    if (faulty(v, 7)) exit(0);
    if (faulty(v, 8)) abort();
    dx[X_NORTH] = v[VR_speed_cmd] * cos(x[X_YAW]);
    dx[X_EAST] = v[VR_speed_cmd] * sin(x[X_YAW]);
    dx[X_YAW] = v[VR_yaw_rate_cmd];
}

void model_outputs(double *v, const double *x) {
    v[VR_north] = x[X_NORTH];
    v[VR_east] = x[X_EAST];
    v[VR_yaw] = x[X_YAW];
    v[VR_speed] = v[VR_speed_cmd];
    v[VR_yaw_rate] = v[VR_yaw_rate_cmd];
    if (faulty(v, 1)) v[VR_north] = NAN;
    if (faulty(v, 2)) v[VR_speed] = INFINITY;
    if (faulty(v, 3)) v[VR_east] = 1e308;
    if (faulty(v, 5)) v[VR_north] = v[VR_east] = 9e5;
}

void model_normalize(double *x) { x[X_YAW] = core_wrap_pi(x[X_YAW]); }

int model_check_parameters(const double *v, char *message, size_t size) {
    if (!(v[VR_internal_step] > 0.0 && v[VR_internal_step] <= 1.0)) {
        snprintf(message, size, "must be in (0, 1] s, got %g", v[VR_internal_step]);
        return VR_internal_step;
    }
    return 0;
}

/* C test harness for the FMI wrappers: run under -fsanitize=address,undefined it checks that
 * instantiate / initialise / step / error paths / reset / FMU-state / free leak nothing and
 * touch no freed memory. Compiled against one wrapper (FMI_VERSION 2 or 3) and one model. */
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if FMI_VERSION == 2
#include "fmi2Functions.h"
#else
#include "fmi3Functions.h"
#endif
#include "model_core.h"

static int errors_logged = 0;

#define CHECK(cond)                                                        \
    do {                                                                   \
        if (!(cond)) {                                                     \
            fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond); \
            return 1;                                                      \
        }                                                                  \
    } while (0)

#if FMI_VERSION == 2
static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    (void)env, (void)name, (void)category, (void)message;
    if (status >= fmi2Error) errors_logged++;
}

int main(void) {
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2ValueReference in[2] = {VR_speed_cmd, VR_yaw_rate_cmd};
    fmi2Real cmd[2] = {0.3, 0.2}, bad[1] = {NAN}, out[1];
    fmi2ValueReference vr_north = VR_north;
    fmi2FMUstate state = NULL;
    size_t size = 0;
    fmi2Byte *bytes;
    int round;
    CHECK(fmi2Instantiate("x", fmi2CoSimulation, "{wrong}", "", &cb, 0, 0) == NULL);
    CHECK(errors_logged == 1);
    for (round = 0; round < 3; round++) {
        fmi2Component c = fmi2Instantiate("rover", fmi2CoSimulation, INSTANTIATION_TOKEN, "", &cb, 0, 0);
        int k;
        CHECK(c != NULL);
        CHECK(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0) == fmi2OK);
        CHECK(fmi2EnterInitializationMode(c) == fmi2OK);
        CHECK(fmi2ExitInitializationMode(c) == fmi2OK);
        CHECK(fmi2SetReal(c, in, 2, cmd) == fmi2OK);
        for (k = 0; k < 100; k++) CHECK(fmi2DoStep(c, k * 0.01, 0.01, 1) == fmi2OK);
        CHECK(fmi2GetFMUstate(c, &state) == fmi2OK);
        CHECK(fmi2SerializedFMUstateSize(c, state, &size) == fmi2OK);
        bytes = malloc(size);
        CHECK(fmi2SerializeFMUstate(c, state, bytes, size) == fmi2OK);
        /* no byte of the FMU's heap leaves in it: the padding after the state is zero (the
         * AddressSanitizer fills what malloc returns with 0xbe) */
        for (k = (int)sizeof(ModelState); k < (int)offsetof(CoreSnapshot, v); k++)
            CHECK(bytes[k] == 0);
        CHECK(fmi2FreeFMUstate(c, &state) == fmi2OK);
        CHECK(fmi2DeSerializeFMUstate(c, bytes, size, &state) == fmi2OK);
        free(bytes);
        CHECK(fmi2SetFMUstate(c, state) == fmi2OK);
        CHECK(fmi2FreeFMUstate(c, &state) == fmi2OK);
        CHECK(fmi2DoStep(c, 1.0, -0.01, 1) == fmi2Error);      /* bad step */
        CHECK(fmi2Reset(c) == fmi2OK);
        CHECK(fmi2EnterInitializationMode(c) == fmi2OK);
        CHECK(fmi2ExitInitializationMode(c) == fmi2OK);
        CHECK(fmi2GetReal(c, &vr_north, 1, out) == fmi2OK && out[0] == 0.0);
        CHECK(fmi2SetReal(c, in, 1, bad) == fmi2Error);         /* NaN input */
        CHECK(fmi2Reset(c) == fmi2OK);
        fmi2FreeInstance(c);
    }
    printf("fmi2 harness ok (%d errors logged as expected)\n", errors_logged);
    return 0;
}
#else
static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                   fmi3String message) {
    (void)env, (void)category, (void)message;
    if (status >= fmi3Error) errors_logged++;
}

int main(void) {
    fmi3ValueReference in[2] = {VR_speed_cmd, VR_yaw_rate_cmd};
    fmi3Float64 cmd[2] = {0.3, 0.2}, bad[1] = {INFINITY}, out[1];
    fmi3ValueReference vr_north = VR_north;
    fmi3Boolean ev, term, early;
    fmi3Float64 last;
    fmi3FMUState state = NULL;
    size_t size = 0;
    fmi3Byte *bytes;
    int round;
    CHECK(fmi3InstantiateCoSimulation("x", "{wrong}", "", 0, 0, 0, 0, NULL, 0, NULL, logger, NULL) == NULL);
    CHECK(errors_logged == 1);
    for (round = 0; round < 3; round++) {
        fmi3Instance c = fmi3InstantiateCoSimulation("rover", INSTANTIATION_TOKEN, "", 0, 0, 0, 0,
                                                     NULL, 0, NULL, logger, NULL);
        int k;
        CHECK(c != NULL);
        CHECK(fmi3EnterInitializationMode(c, 0, 0.0, 0.0, 0, 0.0) == fmi3OK);
        CHECK(fmi3ExitInitializationMode(c) == fmi3OK);
        CHECK(fmi3SetFloat64(c, in, 2, cmd, 2) == fmi3OK);
        for (k = 0; k < 100; k++)
            CHECK(fmi3DoStep(c, k * 0.01, 0.01, 1, &ev, &term, &early, &last) == fmi3OK);
        CHECK(fmi3GetFMUState(c, &state) == fmi3OK);
        CHECK(fmi3SerializedFMUStateSize(c, state, &size) == fmi3OK);
        bytes = malloc(size);
        CHECK(fmi3SerializeFMUState(c, state, bytes, size) == fmi3OK);
        /* as FMI 2's: no byte of the FMU's heap in the padding after the state */
        for (k = (int)sizeof(ModelState); k < (int)offsetof(CoreSnapshot, v); k++)
            CHECK(bytes[k] == 0);
        CHECK(fmi3FreeFMUState(c, &state) == fmi3OK);
        CHECK(fmi3DeserializeFMUState(c, bytes, size, &state) == fmi3OK);
        free(bytes);
        CHECK(fmi3SetFMUState(c, state) == fmi3OK);
        CHECK(fmi3FreeFMUState(c, &state) == fmi3OK);
        CHECK(fmi3GetInt32(c, &vr_north, 1, NULL, 1) == fmi3Error); /* no Int32 variables */
        CHECK(fmi3Reset(c) == fmi3OK);
        CHECK(fmi3EnterInitializationMode(c, 0, 0.0, 0.0, 0, 0.0) == fmi3OK);
        CHECK(fmi3ExitInitializationMode(c) == fmi3OK);
        CHECK(fmi3GetFloat64(c, &vr_north, 1, out, 1) == fmi3OK && out[0] == 0.0);
        CHECK(fmi3SetFloat64(c, in, 1, bad, 1) == fmi3Error);      /* infinite input */
        CHECK(fmi3EnterEventMode(c) == fmi3Error);                  /* unsupported */
        fmi3FreeInstance(c);
    }
    printf("fmi3 harness ok (%d errors logged as expected)\n", errors_logged);
    return 0;
}
#endif

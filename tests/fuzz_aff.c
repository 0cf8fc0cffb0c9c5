/* fuzz_aff.c -- a libFuzzer harness of the exported C API (aff_drive.h), compiled against an export folder:
 *
 *   clang -fsanitize=fuzzer,address,undefined -I EXPORT EXPORT/aff.c EXPORT/aff_config.c tests/fuzz_aff.c -lm
 *
 * (add -DAFF_FLOAT for the float build). Each input is a random sequence of calls with random values: aff_step,
 * aff_step_gated, aff_observe (in order or not), aff_transfer, aff_status and a restart by aff_init; the values are
 * plausible velocities and torques of several scales or the special ones a drive's bus can deliver (NaN, +-inf,
 * huge, subnormal, -0, just beyond the guard's bound). The compensator starts from one of five states reached by a
 * clean closed loop on a stub joint (the one of example_loop.c: Euler, eq. 3 friction) after 0, 0.5, 2, 6 and 12 s
 * (learning, the feedforward fading in, acting, the residual observer switched in). Every output must be finite and
 * within +-AFF_FF_MAX (the composite's bound: the feedforward's and the observer's sum is clipped to it), every
 * transfer too, and the sanitizers must find nothing; a violation aborts (a crash for libFuzzer).
 * Run by tests/adaptive_ff_layer/test_fuzz_c.py (a smoke of seconds) and benchmarks/fuzz_c.py (minutes, executions and coverage).
 */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "aff_config.h"

#define N_START 5

static aff starts[N_START]; /* the compensator after a clean closed loop of 0, 0.5, 2, 6 and 12 s */

/* One period of the stub joint (J = AFF_J_DESIGN, eq. 3 friction at a third and half of AFF_FF_MAX) under the
 * torque u: explicit Euler, static friction holds it at rest. */
static double joint_step(double w, double u)
{
    static const plant_stribeck friction = {(aff_real)(AFF_FF_MAX / 3.0), (aff_real)(AFF_FF_MAX / 6.0),
                                            (aff_real)AFF_VS, (aff_real)AFF_DELTA, (aff_real)(0.5 * AFF_KP),
                                            (aff_real)INFINITY};
    double fs = AFF_FF_MAX / 2.0;
    if (w == 0.0)
        return u > fs || u < -fs ? AFF_TC * (u - (u > 0.0 ? fs : -fs)) / AFF_J_DESIGN : 0.0;
    double w_next = w + AFF_TC * (u - (double)plant_stribeck_eval(&friction, (aff_real)w)) / AFF_J_DESIGN;
    return w_next * w < 0.0 ? 0.0 : w_next;
}

/* The clean closed loop (a PI of AFF_KP, AFF_KI with the compensation, a 0.2 Hz sine of 50*AFF_VS), its states kept
 * at the start periods. */
static void warm_up(void)
{
    static const long at[N_START] = {0, 500, 2000, 6000, 12000};
    static aff c;
    double w = 0.0, I = 0.0;
    long k = 0;
    if (aff_init(&c, &AFF_CONFIG) != AFF_OK)
        abort();
    for (int s = 0; s < N_START; s++) {
        for (; k < at[s]; k++) {
            double w_ref = 50.0 * AFF_VS * sin(2.0 * 3.14159265358979323846 * 0.2 * AFF_TC * (double)k);
            double uff = (double)aff_step(&c, (aff_real)w, (aff_real)w_ref);
            I += (double)aff_transfer(&c) + AFF_KI * AFF_TC * (w_ref - w);
            double u = AFF_KP * (w_ref - w) + I + uff;
            u = u > AFF_U_MAX ? AFF_U_MAX : (u < -AFF_U_MAX ? -AFF_U_MAX : u);
            aff_observe(&c, (aff_real)u, (aff_real)w);
            w = joint_step(w, u);
        }
        starts[s] = c;
    }
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    warm_up();
    return 0;
}

/* The next value of the input: a selector byte, then two bytes. Plausible values of four scales (1e-3 .. 1 times
 * an int16), or a special value. */
static aff_real next_value(const uint8_t **p, const uint8_t *end)
{
    uint8_t sel;
    int16_t v;
    if (end - *p < 3) {
        *p = end;
        return 0;
    }
    sel = (*p)[0];
    v = (int16_t)(uint16_t)((unsigned)(*p)[1] | ((unsigned)(*p)[2] << 8));
    *p += 3;
    if (sel < 208) {
        static const double scale[4] = {1e-4, 1e-3, 1e-2, 1.0};
        return (aff_real)((double)v * scale[sel % 4]);
    }
    switch (sel % 8) {
    case 0:
        return (aff_real)NAN;
    case 1:
        return (aff_real)INFINITY;
    case 2:
        return -(aff_real)INFINITY;
    case 3:
        return (aff_real)(v < 0 ? -1e30 : 1e30);
    case 4:
        return (aff_real)(v < 0 ? -1e-40 : 1e-40); /* subnormal in float; a small normal in double */
    case 5:
        return -(aff_real)0;
    case 6:
        return (aff_real)(1.0001 * AFF_W_MAX);
    default:
        return (aff_real)(1.0001 * AFF_U_GUARD);
    }
}

static void check(aff_real x)
{
    if (!isfinite(x) || x > (aff_real)AFF_FF_MAX || x < -(aff_real)AFF_FF_MAX)
        abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static aff c;
    const uint8_t *p = data + 1, *end = data + size;
    if (size < 1)
        return 0;
    c = starts[data[0] % N_START];
    while (p < end) {
        uint8_t op = *p++;
        aff_real a = next_value(&p, end), b = next_value(&p, end);
        switch (op % 6) {
        case 0: /* a period in order */
        case 1:
            check(aff_step(&c, a, b));
            check(aff_transfer(&c));
            aff_observe(&c, next_value(&p, end), a);
            break;
        case 2:
            check(aff_step_gated(&c, a, b, next_value(&p, end)));
            break;
        case 3: /* out of order: observe without a step */
            aff_observe(&c, a, b);
            break;
        case 4: {
            aff_status_report s = aff_status(&c);
            if ((unsigned)s.state > (unsigned)AFF_STATE_FAULT)
                abort();
            break;
        }
        default:
            if (op == 255 && aff_init(&c, &AFF_CONFIG) != AFF_OK)
                abort();
            break;
        }
    }
    return 0;
}

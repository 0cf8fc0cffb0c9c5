/* aff_real.h -- the floating-point type of the code that may run on a drive.
 *
 * aff_real is double unless AFF_FLOAT is defined (a build for an MCU with a
 * single-precision FPU: `-DAFF_FLOAT`). The AFF_EXP/AFF_FABS/... macros pick
 * the matching <math.h> function, so the same source compiles in both
 * precisions. The simulation (plant integrators, engine) is double only.
 * Counters of the drive's code (periods, updates, rejections: everything that grows with time) are int64_t and
 * count up by aff_count_up, saturating at INT64_MAX: on a 32-bit MCU a `long` period counter overflows after
 * 24.9 days at 1 kHz (2^31 periods), an int64_t one saturates after 2.9e8 years, and none ever overflows.
 */
#ifndef AFF_REAL_H
#define AFF_REAL_H
#include <math.h>
#include <stdint.h>

#ifdef AFF_FLOAT
typedef float aff_real;
#define AFF_EXP expf
#define AFF_POW powf
#define AFF_FABS fabsf
#define AFF_SQRT sqrtf
#define AFF_LOG logf
#define AFF_FLOOR floorf
#define AFF_CEIL ceilf
#define AFF_COPYSIGN copysignf
#else
typedef double aff_real;
#define AFF_EXP exp
#define AFF_POW pow
#define AFF_FABS fabs
#define AFF_SQRT sqrt
#define AFF_LOG log
#define AFF_FLOOR floor
#define AFF_CEIL ceil
#define AFF_COPYSIGN copysign
#endif

/* Python's min(a, b) and max(a, b) (the first argument unless the second compares smaller/larger): the
 * order of the comparison decides which of two equal or NaN arguments is returned, as in the Python code
 * the components were first written in. */
static inline aff_real aff_min2(aff_real a, aff_real b)
{
    return b < a ? b : a;
}

static inline aff_real aff_max2(aff_real a, aff_real b)
{
    return b > a ? b : a;
}

/* 1 if x is finite and > 0 (a configuration value that must be a positive number), else 0. */
static inline int aff_positive(aff_real x)
{
    return isfinite(x) && x > 0;
}

/* 1 if x is finite and >= 0, else 0. */
static inline int aff_nonnegative(aff_real x)
{
    return isfinite(x) && x >= 0;
}

/* 1 if x > 0, INFINITY included (a bound that INFINITY turns off), else 0 (NaN: 0). */
static inline int aff_positive_or_inf(aff_real x)
{
    return x > 0;
}

/* 1 if x >= 0, INFINITY included, else 0 (NaN: 0). */
static inline int aff_nonnegative_or_inf(aff_real x)
{
    return x >= 0;
}

/* 1 if the flag i of a configuration is 0 or 1, else 0. */
static inline int aff_flag(int i)
{
    return i == 0 || i == 1;
}

/* n + 1, or n if n is INT64_MAX: a counter that reached the maximum stays there (no signed overflow). */
static inline int64_t aff_count_up(int64_t n)
{
    return n < INT64_MAX ? n + 1 : n;
}

#endif

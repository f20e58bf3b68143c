/* A double rounded to the float below or above it (directed rounding
 * without changing the MXCSR mode): the bounds that must stay outside
 * the value they were computed from. */
#ifndef SPHERECULL_COMMON_SC_ROUND_H
#define SPHERECULL_COMMON_SC_ROUND_H

#include <math.h>

static inline float sc_f32_down(double x)
{
    const float f = (float)x;
    return (double)f > x ? nextafterf(f, -INFINITY) : f;
}

static inline float sc_f32_up(double x)
{
    const float f = (float)x;
    return (double)f < x ? nextafterf(f, INFINITY) : f;
}

#endif

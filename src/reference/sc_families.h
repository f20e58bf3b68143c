/* Triangle families for accuracy tests and the accuracy report: random
 * triangles and the hard cases that break naive formulas. Deterministic for
 * a given seed. Vertices come out as doubles; with `as_float` they are first
 * rounded to float, so float kernels and the reference see the same input.
 */
#ifndef SPHERECULL_SC_FAMILIES_H
#define SPHERECULL_SC_FAMILIES_H

#include "common/sc_rng.h"

typedef enum sc_family {
    SC_FAM_RANDOM,
    SC_FAM_CAP_1E4, SC_FAM_CAP_1E5, SC_FAM_CAP_1E6, SC_FAM_CAP_1E7,        /* apex height h/L */
    SC_FAM_NEEDLE_1E4, SC_FAM_NEEDLE_1E5, SC_FAM_NEEDLE_1E6, SC_FAM_NEEDLE_1E7, /* short edge w/L */
    SC_FAM_FAR_1E3, SC_FAM_FAR_1E4, SC_FAM_FAR_1E5,   /* size 1e-3 at that distance from 0 */
    SC_FAM_SCALE_1EM20, SC_FAM_SCALE_1EM30, SC_FAM_SCALE_1E18, /* random triangle scaled */
    SC_FAM_RIGHT,                                     /* exactly right-angled */
    SC_FAM_DUPLICATE,                                 /* two equal vertices */
    SC_FAM_COLLINEAR,                                 /* exactly collinear */
    SC_FAM_NONFINITE,                                 /* a NaN or +-Inf component */
    SC_FAM_SUBNORMAL,                                 /* coordinates in the subnormal range */
    SC_FAM_COUNT
} sc_family;

const char *sc_family_name(sc_family f);

/* What a correct kernel should report for every member of the family:
 * 0 = a proper triangle (some members may still round to degenerate),
 * 1 = always degenerate (circumsphere must fail), 2 = non-finite input. */
int sc_family_expected(sc_family f);

void sc_family_triangle(sc_family f, sc_rng *rng, int as_float, double V[3][3]);

#endif

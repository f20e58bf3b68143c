/* Medians of timing repeats and error samples, for the benchmarks: one
 * definition instead of one per benchmark. */
#ifndef SPHERECULL_COMMON_SC_MEDIAN_H
#define SPHERECULL_COMMON_SC_MEDIAN_H

#include <stdlib.h>

/* qsort order for doubles (NaNs are not expected). */
static inline int sc_cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Sorts v[0..n) in place and returns its median (n >= 1). */
static inline double sc_median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, sc_cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

#endif

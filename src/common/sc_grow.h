/* Growing an array in place: what every container of the library uses. */
#ifndef SPHERECULL_COMMON_SC_GROW_H
#define SPHERECULL_COMMON_SC_GROW_H

#include <stdint.h>
#include <stdlib.h>

/* Grows *p (capacity *cap elements of size elem) to hold at least need
 * elements: doubling for many small appends, exactly need for one big one
 * (no 2x overshoot on a 50M-triangle model), at least 16. Returns 0 (and
 * changes nothing) when out of memory or the size overflows. */
static inline int sc_grow(void **p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap)
        return 1;
    size_t c = *cap <= SIZE_MAX / 2 ? 2 * *cap : SIZE_MAX;
    if (c < need)
        c = need;
    if (c < 16)
        c = 16;
    if (c > SIZE_MAX / elem)
        return 0;
    void *q = realloc(*p, c * elem);
    if (!q)
        return 0;
    *p = q;
    *cap = c;
    return 1;
}

#endif

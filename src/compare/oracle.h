/* The exact ray oracle: the referee between spherecull and Embree.
 *
 * For every ray, all triangles are considered; a cheap double-precision
 * filter with generous error bounds (1e-12 relative, about 10^4 times the
 * worst rounding) discards only triangles that certainly miss or certainly
 * lie beyond the best exact hit so far, and every remaining candidate is
 * decided exactly by sc_ref_ray_triangle_mpfr (MPFR, exact rational t).
 * Triangles are grouped in clusters of 32 with padded double boxes purely to
 * skip work; the box test errs towards keeping a cluster. No part of this
 * depends on the tracers under test.
 *
 * Ties: all triangles whose exact t equals the smallest exact t (rays through
 * shared edges and vertices, coincident faces) are recorded; a tracer may
 * report any of them.
 */
#ifndef SPHERECULL_COMPARE_ORACLE_H
#define SPHERECULL_COMPARE_ORACLE_H

#include <stddef.h>
#include <stdint.h>

#include "spherecull/sc_rays.h"

enum { SC_ORACLE_MAX_TIES = 32 };

typedef struct sc_oracle_hit {
    int hit;                 /* 1 iff some triangle is hit in [tmin, tmax] */
    double t;                /* exact first-hit t rounded to double; +inf on a miss */
    int crosses;             /* with SC_ORACLE_LATER_HIT: some triangle is also hit
                                beyond t, so the ray passes through the surface
                                rather than touching it at one point */
    uint32_t tie_count;      /* triangles at exactly that t (>= 1 on a hit) */
    uint32_t ties[SC_ORACLE_MAX_TIES];   /* ascending; the first SC_ORACLE_MAX_TIES */
} sc_oracle_hit;

typedef struct sc_oracle {
    size_t count;
    sc_oracle_hit *hits;
    uint64_t candidates;     /* triangles that survived the double filter */
    uint64_t exact_calls;    /* MPFR decisions made */
} sc_oracle;

enum { SC_ORACLE_LATER_HIT = 1 };

/* threads >= 1; flags 0 or SC_ORACLE_LATER_HIT (also fill `crosses`, at the
 * cost of more exact decisions). SC_ERR_INVALID_ARGUMENT for a bad mesh or
 * arguments. */
sc_status sc_oracle_run(const sc_mesh_view *mesh, const sc_ray *rays, size_t n, int threads,
                        int flags, sc_oracle *out);
void sc_oracle_free(sc_oracle *o);

/* 1 iff prim is in ray i's tie set (also when the set overflowed and prim
 * might be among the unrecorded ties: then any prim the tracer reports at the
 * tied t is accepted). */
int sc_oracle_accepts(const sc_oracle *o, size_t i, uint32_t prim);

#endif

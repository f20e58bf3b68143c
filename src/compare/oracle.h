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
#include "spherecull/sc_scene.h"

enum { SC_ORACLE_MAX_TIES = 32 };

typedef struct sc_oracle_hit {
    int hit;                 /* 1 iff some triangle is hit in [tmin, tmax] */
    double t;                /* exact first-hit t rounded to double; +inf on a miss */
    int crosses;             /* with SC_ORACLE_LATER_HIT: some triangle is also hit
                                beyond t. A cheap hint only: a ray that touches a
                                silhouette and goes on to hit something else has
                                it too. SC_ORACLE_CROSSING tells them apart. */
    uint32_t tie_count;      /* triangles at exactly that t (>= 1 on a hit) */
    uint32_t ties[SC_ORACLE_MAX_TIES];   /* ascending; the first SC_ORACLE_MAX_TIES */
    /* With SC_ORACLE_CROSSING (exact, see crossing.h): */
    int first_kind;          /* sc_cross_kind of the first hit: cross, touch or ambiguous */
    double cross_t;          /* first transversal crossing, exact t rounded; +inf if none */
    uint32_t cross_tie_count;                 /* triangles at cross_t */
    uint32_t cross_ties[SC_ORACLE_MAX_TIES];  /* ascending; the first SC_ORACLE_MAX_TIES */
    uint32_t coplanar;       /* candidate triangles whose plane contains the line */
} sc_oracle_hit;

typedef struct sc_oracle {
    size_t count;
    sc_oracle_hit *hits;
    uint64_t candidates;     /* triangles that survived the double filter */
    uint64_t exact_calls;    /* MPFR decisions made */
} sc_oracle;

enum { SC_ORACLE_LATER_HIT = 1, SC_ORACLE_CROSSING = 2 };

/* threads >= 1; flags: any of SC_ORACLE_LATER_HIT (also fill `crosses`) and
 * SC_ORACLE_CROSSING (also fill first_kind, cross_t, cross_ties: every
 * candidate is decided exactly, with the symbolic perturbation of
 * crossing.h). The mesh is trusted (sc_mesh_check). SC_ERR_INVALID_ARGUMENT
 * for bad arguments. */
sc_status sc_oracle_run(const sc_checked_mesh *mesh, const sc_ray *rays, size_t n, int threads,
                        int flags, sc_oracle *out);

/* A scene with instances (sc_scene.h): the triangles no instance owns, in
 * world space (own, may be NULL; its triangle k is reported as own_prim[k]),
 * and the instances of objects, whose triangle t is reported as the
 * instance's first_triangle + t. object_ray gives instance i's object-space
 * ray for a world ray: the rounded ray a tracer through instances promises
 * the exact first hit of (sc_accel.h), so the oracle decides that ray
 * exactly, triangle by triangle in the object, and the scene's first hit
 * is the smallest exact t over the meshes. t equal as doubles across
 * meshes counts as a tie. */
typedef struct sc_oracle_scene {
    const sc_checked_mesh *own;
    const uint32_t *own_prim;
    const sc_checked_mesh *objects;
    size_t num_objects;
    const sc_scene_instance *instances;
    size_t num_instances;
    sc_status (*object_ray)(void *ctx, size_t inst, const sc_ray *world, sc_ray *object);
    void *ctx;
} sc_oracle_scene;

/* sc_oracle_run through instances; the same flags and results, ids as above. */
sc_status sc_oracle_run_scene(const sc_oracle_scene *scene, const sc_ray *rays, size_t n, int threads, int flags,
                              sc_oracle *out);
void sc_oracle_free(sc_oracle *o);

/* 1 iff prim is in ray i's tie set (also when the set overflowed and prim
 * might be among the unrecorded ties: then any prim the tracer reports at the
 * tied t is accepted). */
int sc_oracle_accepts(const sc_oracle *o, size_t i, uint32_t prim);

/* How a tracer's closest hit on ray i relates to the surface (needs
 * SC_ORACLE_CROSSING). A hit counts as "at" an exact event if its triangle is
 * in that event's tie set or its t is at most 1e-4 (relative) beyond it. */
typedef enum sc_oracle_verdict {
    SC_VERDICT_OK = 0,
    SC_VERDICT_HOLE,          /* the ray passes through the surface (a transversal
                                 crossing at cross_t) and the tracer misses, or
                                 reports something behind the crossing */
    SC_VERDICT_GRAZE_MISSED   /* the first exact hit is a tangential touch and the
                                 tracer does not report it (it misses, or stops at
                                 a later surface); no float test can promise it */
} sc_oracle_verdict;

/* prim == SC_HITREC_MISS for a miss. A hole takes precedence. */
sc_oracle_verdict sc_oracle_judge(const sc_oracle *o, size_t i, uint32_t prim, float t);

#endif

/* Does a ray pass THROUGH a surface where it meets it, or only touch it?
 *
 * A ray aimed exactly at a vertex or a shared edge meets several triangles at
 * one point P. Whether it enters (or leaves) the solid there, or only grazes
 * it (a silhouette vertex or edge, the fan lying on one side of the ray), is
 * decided here exactly, by symbolic perturbation: the line is moved by an
 * infinitesimal offset delta = e1*a + e2*b (e2 << e1 << 1, a and b two
 * coordinate axes that span a plane transverse to D). Every signed volume
 * D.(b x c) that is exactly zero takes the sign of its derivative
 *     d/d(delta) D.((B-O-delta) x (C-O-delta)) = D x (C - B),
 * first along a, then along b; the moved line then meets the triangles at P
 * in general position, and the number it crosses, mod 2, is the change of
 * the inside/outside parity across P: odd = a transversal crossing, even = a
 * tangential touch (0 or 2 triangles, entering and leaving within an
 * infinitesimal distance). On a closed manifold this does not depend on the
 * offset chosen; four offsets (+-a then b, +-b then a) are tried, and if they
 * disagree (a boundary edge of an open mesh) the point is "ambiguous".
 *
 * All inputs are floats, so every quantity below is an exact rational: the
 * MPFR precision is fixed from the float exponent range (see crossing.c).
 * Triangles whose plane contains the ray's line are never hit (as in
 * sc_ref_ray.h) and are reported in `coplanar`.
 */
#ifndef SPHERECULL_COMPARE_CROSSING_H
#define SPHERECULL_COMPARE_CROSSING_H

#include <stddef.h>
#include <stdint.h>

#include "spherecull/sc_prefilter.h"
#include "spherecull/sc_status.h"

typedef enum sc_cross_kind {
    SC_CROSS_NONE = 0,     /* no hit */
    SC_CROSS_CROSS,        /* transversal: the ray passes through the surface */
    SC_CROSS_TOUCH,        /* tangential: the ray touches the surface and stays on its side */
    SC_CROSS_AMBIG         /* the offsets disagree: a boundary edge or vertex of an open mesh */
} sc_cross_kind;

const char *sc_cross_kind_name(sc_cross_kind k);

enum { SC_CROSS_MAX_GROUP = 32, SC_CROSS_PERTURBATIONS = 4 };

/* The triangles met at one exact t. */
typedef struct sc_cross_group {
    double t;                        /* exact t rounded to nearest */
    sc_cross_kind kind;
    uint32_t count;                  /* triangles at this t (may exceed SC_CROSS_MAX_GROUP) */
    uint32_t tri[SC_CROSS_MAX_GROUP];    /* ids, in the order given */
    uint8_t pert[SC_CROSS_MAX_GROUP];    /* bit p: still hit under offset p */
    int8_t facing[SC_CROSS_MAX_GROUP];   /* sign of D.n, n = (B-A) x (C-A) */
} sc_cross_group;

typedef struct sc_cross_result {
    size_t ngroups;                  /* ascending exact t */
    sc_cross_group *groups;
    size_t coplanar;                 /* candidates whose plane contains the line and that it meets */
} sc_cross_result;

/* Conservative double-precision filter: 0 only if the triangle certainly
 * misses the ray within [tmin, tmax]. tri: A, B, C as 9 floats. */
int sc_cross_may_hit(const sc_ray *r, const float tri[9]);

/* Exact classification of the ray against the candidate triangles
 * tris[0..n) (9 floats each, ids[k] their ids). The candidates must include
 * every triangle the ray meets (e.g. all that pass sc_cross_may_hit), or groups
 * are incomplete. Frees nothing in *out on error; release with
 * sc_cross_result_free. */
sc_status sc_cross_classify(const sc_ray *r, const float (*tris)[9], const uint32_t *ids, size_t n,
                        sc_cross_result *out);
void sc_cross_result_free(sc_cross_result *x);

/* Index of the first group of kind SC_CROSS_CROSS, or ngroups if none. */
size_t sc_cross_result_first(const sc_cross_result *x);

#endif

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

typedef enum sc_xkind {
    SC_XK_NONE = 0,     /* no hit */
    SC_XK_CROSS,        /* transversal: the ray passes through the surface */
    SC_XK_TOUCH,        /* tangential: the ray touches the surface and stays on its side */
    SC_XK_AMBIG         /* the offsets disagree: a boundary edge or vertex of an open mesh */
} sc_xkind;

const char *sc_xkind_name(sc_xkind k);

enum { SC_X_MAX_GROUP = 32, SC_X_PERTURBATIONS = 4 };

/* The triangles met at one exact t. */
typedef struct sc_xgroup {
    double t;                        /* exact t rounded to nearest */
    sc_xkind kind;
    uint32_t count;                  /* triangles at this t (may exceed SC_X_MAX_GROUP) */
    uint32_t tri[SC_X_MAX_GROUP];    /* ids, in the order given */
    uint8_t pert[SC_X_MAX_GROUP];    /* bit p: still hit under offset p */
    int8_t facing[SC_X_MAX_GROUP];   /* sign of D.n, n = (B-A) x (C-A) */
} sc_xgroup;

typedef struct sc_xresult {
    size_t ngroups;                  /* ascending exact t */
    sc_xgroup *groups;
    size_t coplanar;                 /* candidates whose plane contains the line and that it meets */
} sc_xresult;

/* Conservative double-precision filter: 0 only if the triangle certainly
 * misses the ray within [tmin, tmax]. tri: A, B, C as 9 floats. */
int sc_x_may_hit(const sc_ray *r, const float tri[9]);

/* Exact classification of the ray against the candidate triangles
 * tris[0..n) (9 floats each, ids[k] their ids). The candidates must include
 * every triangle the ray meets (e.g. all that pass sc_x_may_hit), or groups
 * are incomplete. Frees nothing in *out on error; release with
 * sc_xresult_free. */
sc_status sc_x_classify(const sc_ray *r, const float (*tris)[9], const uint32_t *ids, size_t n,
                        sc_xresult *out);
void sc_xresult_free(sc_xresult *x);

/* Index of the first group of kind SC_XK_CROSS, or ngroups if none. */
size_t sc_xresult_first_cross(const sc_xresult *x);

#endif

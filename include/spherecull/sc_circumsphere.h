/* spherecull — bounding spheres of triangles (E3) and simplices (En).
 *
 * Three algebraically identical ways to get a triangle's circumsphere, which
 * differ only in operation order, cost and rounding (see docs/numerics.md):
 *
 *   SC_METHOD_TEXTBOOK            Q = C + (u x n) / (2|n|^2),  r^2 = |a|^2|b|^2|a-b|^2 / (4|n|^2)
 *                                 with a = A-C, b = B-C, n = a x b, u = |a|^2 b - |b|^2 a
 *                                 (Skala eq. 2, corrected).
 *   SC_METHOD_CRAMER              rows a, b, n; right-hand side (|a|^2/2, |b|^2/2, 0);
 *                                 Cramer's rule, det = |n|^2 (eq. 4-8, corrected).
 *   SC_METHOD_PROJECTIVE_LITERAL  the 4D extended cross product rhoA x rhoB x rho0 of the two
 *                                 bisector planes and the triangle's plane, evaluated as the
 *                                 paper's appendix does (four 3x3 determinants).
 *   SC_METHOD_PROJECTIVE_REDUCED  the same product with the known zero and the identities
 *                                 q'_w = -|n|^2, (D14, D24, D34) = u/2 folded in (eq. 16-17,
 *                                 corrected).
 *
 * All methods translate to the origin vertex C first and prescale a, b by an
 * exact power of two, so float works for triangle sizes of about 1e-18..1e18
 * instead of 1e-6..1e6. The result is unscaled exactly.
 *
 * Sphere kinds:
 *   circumsphere   — through all three vertices; fails on degenerate input.
 *   minimal        — smallest enclosing sphere: midpoint of the longest edge
 *                    when the triangle is right or obtuse (also for collinear
 *                    and duplicate vertices), else the circumsphere.
 *   prefilter      — conservative: after rounding, every vertex V satisfies
 *                    |V - c|^2 <= r2 in exact arithmetic. r2 is recomputed from
 *                    the stored (rounded) centre and padded; any non-finite
 *                    value becomes r2 = +inf, a sphere that never rejects.
 */
#ifndef SPHERECULL_SC_CIRCUMSPHERE_H
#define SPHERECULL_SC_CIRCUMSPHERE_H

#include "sc_api.h"
#include <stddef.h>
#include "sc_status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum sc_method {
    SC_METHOD_TEXTBOOK = 0,
    SC_METHOD_CRAMER,
    SC_METHOD_PROJECTIVE_LITERAL,
    SC_METHOD_PROJECTIVE_REDUCED,
    SC_METHOD_COUNT
} sc_method;

/* Which vertex becomes C (the origin of a and b). Opposite the longest edge
 * bounds the cancellation in u by a factor 2 and is the default. */
typedef enum sc_origin {
    SC_ORIGIN_OPPOSITE_LONGEST = 0,
    SC_ORIGIN_AS_GIVEN,
    SC_ORIGIN_COUNT
} sc_origin;

typedef enum sc_sphere_kind {
    SC_SPHERE_CIRCUM = 0,
    SC_SPHERE_MINIMAL,
    SC_SPHERE_KIND_COUNT
} sc_sphere_kind;

/* Centre and squared radius. 16 bytes (float) / 32 bytes (double). */
typedef struct sc_spheref { float  c[3]; float  r2; } sc_spheref;
typedef struct sc_sphered { double c[3]; double r2; } sc_sphered;

/* Stable lower-case names ("textbook", "cramer", "projective-literal",
 * "projective-reduced"; "opposite-longest", "as-given"; "circum", "minimal")
 * and their inverse; *_from_name returns SC_ERR_INVALID_ARGUMENT if unknown. */
SC_API const char *sc_method_name(sc_method method);
SC_API const char *sc_origin_name(sc_origin origin);
SC_API const char *sc_sphere_kind_name(sc_sphere_kind kind);
SC_API sc_status sc_method_from_name(const char *name, sc_method *out);
SC_API sc_status sc_sphere_kind_from_name(const char *name, sc_sphere_kind *out);

/* Circumsphere of triangle (A, B, C).
 * On SC_OK *out holds a finite centre and r2. On any error *out is set to
 * centre (0,0,0) and r2 = +inf, so a caller that ignores the status still
 * gets a sphere that rejects nothing — never a silent NaN.
 * Errors: SC_ERR_INVALID_ARGUMENT (NULL, bad enum), SC_ERR_NONFINITE,
 * SC_ERR_DEGENERATE (|n|^2 == 0 after prescaling), SC_ERR_RANGE (overflow). */
SC_API sc_status sc_circumsphere_f(const float A[3], const float B[3], const float C[3],
                                   sc_method method, sc_origin origin, sc_spheref *out);
SC_API sc_status sc_circumsphere_d(const double A[3], const double B[3], const double C[3],
                                   sc_method method, sc_origin origin, sc_sphered *out);

/* Minimal enclosing sphere. Degenerate triangles are fine (longest-edge
 * midpoint); only non-finite input or overflow fail. */
SC_API sc_status sc_minimal_sphere_f(const float A[3], const float B[3], const float C[3],
                                     sc_method method, sc_origin origin, sc_spheref *out);
SC_API sc_status sc_minimal_sphere_d(const double A[3], const double B[3], const double C[3],
                                     sc_method method, sc_origin origin, sc_sphered *out);

/* Conservative prefilter sphere of the given kind (circumsphere centre, or the
 * minimal sphere's). Always fills *out with a sphere that contains the three
 * vertices exactly; returns SC_OK unless an argument is invalid. A degenerate
 * circumsphere falls back to the minimal sphere's centre; non-finite input or
 * overflow yields r2 = +inf. */
/* MXCSR modes: the containment guarantee of the prefilter spheres (here,
 * sc_sphere_make_conservative_* and the SIMD batch kinds in sc_simd.h) holds
 * with gradual underflow and with flush-to-zero / denormals-are-zero (FTZ,
 * DAZ, as Embree asks renderers to set) alike, for the caller's vertices
 * even where DAZ reads a subnormal coordinate as 0. A triangle whose sphere
 * would be smaller than r2 = 16 MIN (edges below ~1e-19 in float) gets
 * r2 = 16 MIN: still contained, and too small for sc_reject* to reject
 * anything (it never rejects below allowance 2^-100, sc_prefilter.h).
 * sc_circumsphere_* and sc_minimal_sphere_* compute in the thread's mode: with
 * DAZ set and a subnormal coordinate in the input they return SC_ERR_RANGE
 * (the arithmetic would see another triangle) instead of a wrong sphere.
 * All functions here are reentrant: any number of threads may call them. */
SC_API sc_status sc_prefilter_sphere_f(const float A[3], const float B[3], const float C[3],
                                       sc_sphere_kind kind, sc_method method, sc_spheref *out);
SC_API sc_status sc_prefilter_sphere_d(const double A[3], const double B[3], const double C[3],
                                       sc_sphere_kind kind, sc_method method, sc_sphered *out);

/* Pads a sphere so it contains the vertices exactly after rounding:
 * r2 = max_i fl(|V_i - c|^2) * (1 + 8u) + 16 MIN; non-finite -> +inf
 * (MIN = FLT_MIN / DBL_MIN, the smallest normal number: the pad covers the
 * underflow of both MXCSR modes, and r2 >= 16 MIN is never subnormal).
 * Exposed so SIMD kernels and other tracers can share the one rule. */
SC_API void sc_sphere_make_conservative_f(const float A[3], const float B[3], const float C[3],
                                          sc_spheref *sphere);
SC_API void sc_sphere_make_conservative_d(const double A[3], const double B[3], const double C[3],
                                          sc_sphered *sphere);

/* The radius, on request: sqrt(r2) rounded up, so a sphere that contained
 * its vertices still does (+inf stays +inf). */
SC_API float sc_sphere_radius_f(const sc_spheref *sphere);
SC_API double sc_sphere_radius_d(const sc_sphered *sphere);

/* ---- n-simplex hyperspheres in En, double ------------------------------- */

enum { SC_SIMPLEX_MAX_DIM = 16 };

typedef enum sc_simplex_method {
    /* Generalized cross product of the bisector hyperplanes [e_i : -|e_i|^2/2]
     * (plus the simplex's own hyperplane [N : 0] when k = n-1): every
     * component a determinant, each by LU with partial pivoting. Needs
     * k = n or k = n-1; otherwise SC_ERR_UNSUPPORTED. */
    SC_SIMPLEX_CROSS = 0,
    /* Linear solve: k = n by LU with partial pivoting of E x = diag(E E^T)/2;
     * k < n by Householder QR of E^T (the Gram system G l = diag(G)/2,
     * G = E E^T, solved without forming G). */
    SC_SIMPLEX_SOLVE,
    SC_SIMPLEX_METHOD_COUNT
} sc_simplex_method;

SC_API const char *sc_simplex_method_name(sc_simplex_method method);

/* Circumscribed hypersphere of a k-simplex (k+1 vertices) in En.
 * vertices: (k+1) rows of n doubles, row-major. 2 <= n <= 16, 1 <= k <= n.
 * centre: n doubles. r2 may be NULL. On error centre is zeroed and *r2 = +inf.
 * Errors: INVALID_ARGUMENT, NONFINITE, DEGENERATE (affinely dependent
 * vertices), RANGE, UNSUPPORTED (CROSS with k < n-1). */
SC_API sc_status sc_simplex_sphere(int n, int k, const double *vertices,
                                   sc_simplex_method method, double *centre, double *r2);

#ifdef __cplusplus
}
#endif
#endif

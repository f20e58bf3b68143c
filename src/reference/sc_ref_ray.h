/* Exact ray-triangle decision (MPFR), the oracle for false-reject tests and
 * for the tracers' hit comparisons. Never linked into the core library.
 *
 * Signed volumes on exact differences: with a = A-O, b = B-O, c = C-O the
 * line O + tD meets the triangle iff D.(b x c), D.(c x a), D.(a x b) have no
 * two opposite signs and their sum D.n (n = (B-A) x (C-A)) is non-zero. The
 * hit parameter is t = a.n / D.n, compared against [tmin, tmax] exactly.
 * Every product is exact because the working precision is derived from the
 * exponent spread of the inputs.
 */
#ifndef SPHERECULL_SC_REF_RAY_H
#define SPHERECULL_SC_REF_RAY_H

#include <mpfr.h>

/* Exact (MPFR, precision chosen from the inputs so every product is exact): does the ray O + t D, t in
   [tmin, tmax], hit triangle (A,B,C) on either face, edges and vertices included? A ray parallel to the
   triangle's plane never hits. Returns 1/0; on a hit and if t_out != NULL, *t_out = t rounded to nearest. */
int sc_ref_ray_triangle(const double O[3], const double D[3], double tmin, double tmax,
                        const double A[3], const double B[3], const double C[3], double *t_out);

/* Same decision; on a hit sets t_exact (caller mpfr_init'ed; precision is set by the call) to the exact
   rational t rounded to >= 256 bits so first hits and ties can be compared. */
int sc_ref_ray_triangle_mpfr(const double O[3], const double D[3], double tmin, double tmax,
                             const double A[3], const double B[3], const double C[3], mpfr_t t_exact);

#endif

/* High-precision references (MPFR) for tests, the accuracy report and the
 * ray oracle. Never linked into the core library.
 *
 * Inputs are doubles (floats convert exactly). Working precision is chosen
 * per call from the inputs' exponent spread so that differences, cross
 * products and squared norms are exact; only the final division rounds, at
 * no fewer than SC_REF_MIN_PREC bits. Results are therefore exact to far
 * beyond double precision, whatever the input.
 */
#ifndef SPHERECULL_SC_REFERENCE_H
#define SPHERECULL_SC_REFERENCE_H

#include <mpfr.h>

#define SC_REF_MIN_PREC 256

typedef struct sc_ref_sphere {
    mpfr_t c[3];
    mpfr_t r2;
} sc_ref_sphere;

void sc_ref_sphere_init(sc_ref_sphere *s);
void sc_ref_sphere_clear(sc_ref_sphere *s);

/* Exact-input circumsphere; returns 0 if the triangle is exactly degenerate
 * (|n|^2 == 0 exactly) or an input is not finite. */
int sc_ref_circumsphere(const double A[3], const double B[3], const double C[3], sc_ref_sphere *out);

/* Minimal enclosing sphere (the obtuse/right test is exact); 0 on non-finite input. */
int sc_ref_minimal_sphere(const double A[3], const double B[3], const double C[3], sc_ref_sphere *out);

/* |c - c_ref| / r_ref and |r2 - r2_ref| / r2_ref, rounded to double.
 * +inf if c or r2 is not finite. A zero-radius reference gives |c - c_ref|. */
double sc_ref_centre_error(const sc_ref_sphere *ref, const double c[3]);
double sc_ref_r2_error(const sc_ref_sphere *ref, double r2);

/* Exact: 1 iff |V - c|^2 <= r2 (r2 = +inf contains everything finite). */
int sc_ref_contains(const double V[3], const double c[3], double r2);

/* Conditioning of the circumcentre: longest edge^2 / |a x b| (= L_max / h_min
 * up to a factor of 2). +inf for degenerate triangles. */
double sc_ref_condition(const double A[3], const double B[3], const double C[3]);

/* k-simplex in En (vertices: (k+1) x n, row-major). Solves the Gram system
 * G l = diag(G)/2 exactly-formed at high precision; centre has n entries
 * (caller inits them). Returns 0 if singular or non-finite. */
int sc_ref_simplex_sphere(int n, int k, const double *vertices, mpfr_t *centre, mpfr_t r2);

/* |c - c_ref| / r_ref for an n-dimensional centre. */
double sc_ref_simplex_centre_error(int n, const mpfr_t *centre_ref, const mpfr_t r2_ref, const double *c);

#endif

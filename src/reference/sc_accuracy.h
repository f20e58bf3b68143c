/* Evaluating the scalar sphere kernels against the MPFR reference: shared by
 * the accuracy tests (which assert bounds per triangle) and the
 * `spherecull accuracy` report (which summarises). */
#ifndef SPHERECULL_SC_ACCURACY_H
#define SPHERECULL_SC_ACCURACY_H

#include "spherecull/sc_circumsphere.h"
#include "sc_reference.h"

typedef enum sc_acc_kind {
    SC_ACC_CIRCUM,            /* sc_circumsphere_*            */
    SC_ACC_MINIMAL,           /* sc_minimal_sphere_*          */
    SC_ACC_PREFILTER_CIRCUM,  /* sc_prefilter_sphere_*(circum)  */
    SC_ACC_PREFILTER_MINIMAL, /* sc_prefilter_sphere_*(minimal) */
} sc_acc_kind;

typedef struct sc_acc_variant {
    sc_acc_kind kind;
    sc_method method;
    sc_origin origin;
    char name[48];            /* e.g. "projective-literal", "prefilter-minimal-cramer" */
} sc_acc_variant;

/* All variants the report covers, in a fixed order; returns the count. */
int sc_acc_variants(sc_acc_variant *out, int max);

/* The reference spheres of one triangle, computed once and shared. */
typedef struct sc_acc_ref {
    sc_ref_sphere circum, minimal;
    int circum_ok, minimal_ok;
    double condition;         /* longest edge^2 / |a x b|, +inf if degenerate */
} sc_acc_ref;

void sc_acc_ref_init(sc_acc_ref *r);
void sc_acc_ref_clear(sc_acc_ref *r);
void sc_acc_ref_compute(sc_acc_ref *r, const double V[3][3]);

typedef struct sc_acc_result {
    sc_status status;
    double centre[3], r2;     /* as returned, widened to double */
    double centre_err;        /* |Q - Q_ref| / r_ref (NaN if no reference or no result) */
    double r2_err;            /* |r2 - r2_ref| / r2_ref (NaN likewise) */
    int nonfinite;            /* a returned component is NaN or Inf (r2 = +inf counts) */
    int containment_failures; /* vertices outside the returned sphere, exact (0..3) */
} sc_acc_result;

/* Runs one variant on V (float kernels when as_float; V must then hold
 * float values) and measures it against ref. */
void sc_acc_eval(const sc_acc_variant *v, int as_float, const double V[3][3],
                 const sc_acc_ref *ref, sc_acc_result *out);

#endif

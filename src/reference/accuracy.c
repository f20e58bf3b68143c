#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "sc_accuracy.h"

int sc_acc_variants(sc_acc_variant *out, int max)
{
    int n = 0;
#define ADD(k, m, o, ...)                                                   \
    do {                                                                    \
        if (n < max) {                                                      \
            out[n].kind = (k), out[n].method = (m), out[n].origin = (o);    \
            snprintf(out[n].name, sizeof out[n].name, __VA_ARGS__);         \
        }                                                                   \
        n++;                                                                \
    } while (0)
    for (int o = 0; o < SC_ORIGIN_COUNT; o++)
        for (int m = 0; m < SC_METHOD_COUNT; m++)
            ADD(SC_ACC_CIRCUM, (sc_method)m, (sc_origin)o, "%s", sc_method_name((sc_method)m));
    for (int m = 0; m < SC_METHOD_COUNT; m++)
        ADD(SC_ACC_MINIMAL, (sc_method)m, SC_ORIGIN_OPPOSITE_LONGEST, "minimal-%s",
            sc_method_name((sc_method)m));
    for (int m = 0; m < SC_METHOD_COUNT; m++)
        ADD(SC_ACC_PREFILTER_CIRCUM, (sc_method)m, SC_ORIGIN_OPPOSITE_LONGEST,
            "prefilter-circum-%s", sc_method_name((sc_method)m));
    for (int m = 0; m < SC_METHOD_COUNT; m++)
        ADD(SC_ACC_PREFILTER_MINIMAL, (sc_method)m, SC_ORIGIN_OPPOSITE_LONGEST,
            "prefilter-minimal-%s", sc_method_name((sc_method)m));
#undef ADD
    return n;
}

void sc_acc_ref_init(sc_acc_ref *r)
{
    sc_ref_sphere_init(&r->circum);
    sc_ref_sphere_init(&r->minimal);
    r->circum_ok = r->minimal_ok = 0;
    r->condition = INFINITY;
}

void sc_acc_ref_clear(sc_acc_ref *r)
{
    sc_ref_sphere_clear(&r->circum);
    sc_ref_sphere_clear(&r->minimal);
}

void sc_acc_ref_compute(sc_acc_ref *r, const double V[3][3])
{
    r->circum_ok = sc_ref_circumsphere(V[0], V[1], V[2], &r->circum);
    r->minimal_ok = sc_ref_minimal_sphere(V[0], V[1], V[2], &r->minimal);
    r->condition = sc_ref_condition(V[0], V[1], V[2]);
}

/* (float)x, also for a float subnormal when the thread flushes subnormal
 * results to zero (MXCSR FTZ): the kernel must see the caller's input, and
 * only then run in the thread's mode. x is in float's range. */
static float float_of(double x)
{
    if (!(fabs(x) < FLT_MIN) || x == 0)
        return (float)x;
    uint32_t bits = (uint32_t)llrint(fabs(x) * 0x1p149) | (x < 0 ? 0x80000000u : 0);
    float f;
    memcpy(&f, &bits, sizeof f);
    return f;
}

void sc_acc_eval(const sc_acc_variant *v, int as_float, const double V[3][3],
                 const sc_acc_ref *ref, sc_acc_result *out)
{
    /* One call sequence for both precisions: SUF picks the kernel family. */
#define RUN_KERNEL(SUF, SPHERE, A, B, C)                                                   \
    do {                                                                                  \
        SPHERE s;                                                                         \
        if (v->kind == SC_ACC_CIRCUM)                                                     \
            out->status = sc_circumsphere_##SUF(A, B, C, v->method, v->origin, &s);       \
        else if (v->kind == SC_ACC_MINIMAL)                                               \
            out->status = sc_minimal_sphere_##SUF(A, B, C, v->method, v->origin, &s);     \
        else                                                                              \
            out->status = sc_prefilter_sphere_##SUF(A, B, C,                              \
                v->kind == SC_ACC_PREFILTER_CIRCUM ? SC_SPHERE_CIRCUM : SC_SPHERE_MINIMAL, \
                v->method, &s);                                                           \
        for (int i = 0; i < 3; i++)                                                       \
            out->centre[i] = s.c[i];                                                      \
        out->r2 = s.r2;                                                                   \
    } while (0)
    if (as_float) {
        float F[3][3];
        for (int k = 0; k < 3; k++)
            for (int i = 0; i < 3; i++)
                F[k][i] = float_of(V[k][i]);
        RUN_KERNEL(f, sc_spheref, F[0], F[1], F[2]);
    } else {
        RUN_KERNEL(d, sc_sphered, V[0], V[1], V[2]);
    }
#undef RUN_KERNEL

    out->nonfinite = !isfinite(out->r2) || !isfinite(out->centre[0]) ||
                     !isfinite(out->centre[1]) || !isfinite(out->centre[2]);
    out->containment_failures = 0;
    for (int k = 0; k < 3; k++)   /* a NaN vertex cannot be contained: not counted */
        if (isfinite(V[k][0]) && isfinite(V[k][1]) && isfinite(V[k][2]) &&
            !sc_ref_contains(V[k], out->centre, out->r2))
            out->containment_failures++;

    /* The prefilter's centre is the circumcentre unless the circumsphere
     * failed; it is judged against the sphere it was built from. */
    const sc_ref_sphere *rs = NULL;
    if (v->kind == SC_ACC_CIRCUM || v->kind == SC_ACC_PREFILTER_CIRCUM)
        rs = ref->circum_ok ? &ref->circum : NULL;
    else
        rs = ref->minimal_ok ? &ref->minimal : NULL;
    if (rs && out->status == SC_OK && !out->nonfinite) {
        out->centre_err = sc_ref_centre_error(rs, out->centre);
        out->r2_err = sc_ref_r2_error(rs, out->r2);
    } else {
        out->centre_err = NAN;
        out->r2_err = NAN;
    }
}

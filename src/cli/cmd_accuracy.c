/* spherecull accuracy: every scalar sphere kernel against the MPFR reference,
 * per method x precision x origin x triangle family. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "common/sc_names.h"
#include "sc_accuracy.h"
#include "sc_families.h"

enum { MAX_VARIANTS = 32 };

typedef struct row {
    const sc_acc_variant *variant;
    int as_float;
    sc_family family;
    int n;
    double err_median, err_p99, err_max, r2_median, r2_max;
    int nonfinite, containment_failures, errors;
} row;

typedef struct report {
    row *rows;
    int count;
} report;

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Quantile over the finite-or-inf values present; NaN (no result) excluded. */
static double quantile(double *v, int n, double q)
{
    if (n == 0)
        return NAN;
    int i = (int)ceil(q * n) - 1;
    if (i < 0) i = 0;
    if (i >= n) i = n - 1;
    return v[i];
}

static int collect(double *dst, const double *src, int n)
{
    int m = 0;
    for (int i = 0; i < n; i++)
        if (!isnan(src[i]))
            dst[m++] = src[i];
    qsort(dst, (size_t)m, sizeof *dst, cmp_double);
    return m;
}

static int write_csv(void *ctx, FILE *f)
{
    const report *rep = ctx;
    fprintf(f, "method,precision,origin,family,n,centre_err_median,centre_err_p99,centre_err_max,"
               "r2_err_median,r2_err_max,nonfinite,containment_failures,status_errors\n");
    for (int i = 0; i < rep->count; i++) {
        const row *r = &rep->rows[i];
        fprintf(f, "%s,%s,%s,%s,%d,%.3e,%.3e,%.3e,%.3e,%.3e,%d,%d,%d\n", r->variant->name,
                r->as_float ? "float" : "double", sc_origin_name(r->variant->origin),
                sc_family_name(r->family), r->n, r->err_median, r->err_p99, r->err_max,
                r->r2_median, r->r2_max, r->nonfinite, r->containment_failures, r->errors);
    }
    return 0;
}

static const row *find(const report *rep, int as_float, sc_family fam, const char *name, sc_origin o)
{
    for (int i = 0; i < rep->count; i++) {
        const row *r = &rep->rows[i];
        if (r->as_float == as_float && r->family == fam && r->variant->origin == o &&
            strcmp(r->variant->name, name) == 0)
            return r;
    }
    return NULL;
}

static void print_table(const report *rep)
{
    static const char *cols[] = { "textbook", "cramer", "projective-literal", "projective-reduced" };
    for (int pf = 1; pf >= 0; pf--) {
        printf("\n%s input — centre error |Q-Qref|/r, median / max (C opposite the longest edge)\n",
               pf ? "float" : "double");
        printf("%-12s", "family");
        for (int c = 0; c < 4; c++)
            printf(" %21s", cols[c]);
        printf(" %11s %9s %9s\n", "as-given tb", "minimal", "pf.fails");
        for (int f = 0; f < SC_FAM_COUNT; f++) {
            printf("%-12s", sc_family_name((sc_family)f));
            for (int c = 0; c < 4; c++) {
                const row *r = find(rep, pf, (sc_family)f, cols[c], SC_ORIGIN_OPPOSITE_LONGEST);
                char cell[32];
                if (!r || isnan(r->err_max))
                    snprintf(cell, sizeof cell, "(%d errors)", r ? r->errors : 0);
                else
                    snprintf(cell, sizeof cell, "%.1e / %.1e", r->err_median, r->err_max);
                printf(" %21s", cell);
            }
            const row *ag = find(rep, pf, (sc_family)f, "textbook", SC_ORIGIN_AS_GIVEN);
            const row *mn = find(rep, pf, (sc_family)f, "minimal-textbook", SC_ORIGIN_OPPOSITE_LONGEST);
            int fails = 0;
            for (int i = 0; i < rep->count; i++)
                if (rep->rows[i].as_float == pf && rep->rows[i].family == (sc_family)f &&
                    (rep->rows[i].variant->kind == SC_ACC_PREFILTER_CIRCUM ||
                     rep->rows[i].variant->kind == SC_ACC_PREFILTER_MINIMAL))
                    fails += rep->rows[i].containment_failures;
            printf(" %11.1e %9.1e %9d\n", ag ? ag->err_max : NAN, mn ? mn->err_max : NAN, fails);
        }
    }
    printf("\npf.fails = vertices outside a conservative prefilter sphere (all 8 prefilter variants), "
           "checked exactly; must be 0.\n(N errors) = every triangle was refused with a status "
           "(degenerate, non-finite input, or r2 outside the exponent range, as for subnormal input).\n");
}

enum { O_CSV, O_N, O_SEED };
static const sc_cli_opt opts[] = {
    [O_CSV] = { "csv", 0, "FILE", "write one row per method x precision x origin x family", NULL },
    [O_N] = { "n", 0, "N", "triangles per family, 1..10000000", "2000" },
    [O_SEED] = { "seed", 0, "S", "triangle seed", "1" },
};

typedef struct args {
    const char *csv;
    long n;
    unsigned long long seed;
} args;

static int on_option(void *ctx, int opt, const char *val)
{
    args *a = ctx;
    switch (opt) {
    case -1: sc_cli_error("accuracy", "takes no operands ('%s')", val); return 2;
    case O_CSV: a->csv = val; return 0;
    case O_N: return sc_cli_int("accuracy", "n", val, 1, 10000000, &a->n) ? 2 : 0;
    case O_SEED: return sc_cli_u64("accuracy", "seed", val, &a->seed) ? 2 : 0;
    }
    return 0;
}

static int run(int argc, char **argv)
{
    args a = { NULL, 2000, 1 };
    int prc = sc_cli_parse(&sc_cli_accuracy, argc, argv, on_option, &a);
    if (prc)
        return prc < 0 ? 0 : prc;
    const char *csv = a.csv;
    long n = a.n;
    unsigned long long seed = a.seed;
    if (sc_cli_check_output("accuracy", "--csv", csv) != 0)
        return 1;
    sc_acc_variant variants[MAX_VARIANTS];
    int nv = sc_acc_variants(variants, MAX_VARIANTS);
    report rep = { calloc((size_t)(2 * SC_FAM_COUNT * nv), sizeof(row)), 0 };
    double *errs = malloc(sizeof(double) * (size_t)(n * nv));
    double *r2errs = malloc(sizeof(double) * (size_t)(n * nv));
    double *sorted = malloc(sizeof(double) * (size_t)n);
    sc_acc_result *res = malloc(sizeof(sc_acc_result) * (size_t)nv);
    if (!rep.rows || !errs || !r2errs || !sorted || !res) {
        sc_cli_error("accuracy", "out of memory");
        free(rep.rows), free(errs), free(r2errs), free(sorted), free(res);
        return 1;
    }
    sc_acc_ref ref;
    sc_acc_ref_init(&ref);
    for (int pf = 1; pf >= 0; pf--)
        for (int f = 0; f < SC_FAM_COUNT; f++) {
            row *rows = &rep.rows[rep.count];
            for (int v = 0; v < nv; v++)
                rows[v] = (row){ .variant = &variants[v], .as_float = pf, .family = (sc_family)f, .n = (int)n };
            sc_rng rng;
            sc_rng_seed(&rng, seed * 1000003u + (unsigned)(f * 2 + pf));
            for (long t = 0; t < n; t++) {
                double V[3][3];
                sc_family_triangle((sc_family)f, &rng, pf, V);
                sc_acc_ref_compute(&ref, V);
                for (int v = 0; v < nv; v++) {
                    sc_acc_eval(&variants[v], pf, V, &ref, &res[v]);
                    errs[v * n + t] = res[v].centre_err;
                    r2errs[v * n + t] = res[v].r2_err;
                    rows[v].nonfinite += res[v].nonfinite;
                    rows[v].containment_failures += res[v].containment_failures;
                    rows[v].errors += res[v].status != SC_OK;
                }
            }
            for (int v = 0; v < nv; v++) {
                int m = collect(sorted, &errs[v * n], (int)n);
                rows[v].err_median = quantile(sorted, m, 0.5);
                rows[v].err_p99 = quantile(sorted, m, 0.99);
                rows[v].err_max = m ? sorted[m - 1] : NAN;
                m = collect(sorted, &r2errs[v * n], (int)n);
                rows[v].r2_median = quantile(sorted, m, 0.5);
                rows[v].r2_max = m ? sorted[m - 1] : NAN;
            }
            rep.count += nv;
        }
    sc_acc_ref_clear(&ref);

    printf("spherecull accuracy: %ld triangles per family, seed %llu, reference MPFR >= %d bits\n",
           n, seed, SC_REF_MIN_PREC);
    print_table(&rep);
    int rc = 0;
    if (csv) {
        if (sc_cli_write("accuracy", csv, write_csv, &rep) != 0) {
            rc = 1;
        } else {
            printf("wrote %s (%d rows)\n", csv, rep.count);
        }
    }
    free(rep.rows), free(errs), free(r2errs), free(sorted), free(res);
    return rc;
}

const sc_cli_cmd sc_cli_accuracy = {
    .name = "accuracy",
    .operands = "",
    .summary = "circumsphere accuracy of every method against MPFR",
    .details = "Measures every circumsphere method (float and double, both origin choices,\n"
               "circum/minimal/prefilter kinds) against a >= 256-bit MPFR reference on random\n"
               "and hard triangle families.\n",
    .opts = opts,
    .nopts = SC_NAMES_COUNT(opts),
    .run = run,
};

/* spherecull bench-spheres: batch-sphere and reject-mask throughput per
 * method x kind x ISA x precision x working set, against a memcpy of the
 * same bytes measured in the same run, beside each variant's centre error
 * against MPFR (the measuring is src/reference/bench_spheres.c). Table on
 * stdout, optional CSV and gnuplot PNG. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "common/sc_atomic_file.h"
#include "common/sc_gnuplot.h"
#include "common/sc_names.h"
#include "sc_bench_spheres.h"
#include "x86/cpu_features.h"

#define CMD "bench-spheres"

enum { O_CSV, O_PLOT, O_QUICK, O_ISA };
static const sc_cli_opt opts[] = {
    [O_CSV] = { "csv", 0, "FILE", "write every row", NULL },
    [O_PLOT] = { "plot", 0, "FILE.png", "speed against error, every method x kind (gnuplot)", NULL },
    [O_QUICK] = { "quick", 0, NULL, "shrink the DRAM set and the repeats (CI)", NULL },
    [O_ISA] = { "isa", 0, "LEVEL", "scalar|sse4|avx2|avx512: measure one level (and scalar, the baseline)", "all" },
};

typedef struct args {
    const char *csv, *png;
    int quick, only;
} args;

static int on_option(void *ctx, int opt, const char *val)
{
    args *a = ctx;
    sc_isa isa;
    switch (opt) {
    case -1: sc_cli_error(CMD, "takes no operands ('%s')", val); return 2;
    case O_CSV: a->csv = val; return 0;
    case O_PLOT: a->png = val; return 0;
    case O_QUICK: a->quick = 1; return 0;
    case O_ISA:
        if (sc_isa_from_name(val, &isa) != SC_OK) {
            sc_cli_error(CMD, "unknown ISA level '%s' (scalar, sse4, avx2, avx512)", val);
            return 2;
        }
        if (!sc_isa_supported(isa)) {
            sc_cli_error(CMD, "ISA level '%s' is not supported by this CPU or build", val);
            return 1;
        }
        a->only = (int)isa;
        return 0;
    }
    return 0;
}

static int write_csv(void *ctx, FILE *f)
{
    const sc_bsph_report *b = ctx;
    fprintf(f, "method,kind,isa,precision,working_set,source,mtri_per_s,ns_per_tri,copy_ratio,"
               "centre_err_median,centre_err_max\n");
    for (size_t i = 0; i < b->n; i++) {
        const sc_bsph_row *r = &b->rows[i];
        fprintf(f, "%s,%s,%s,%s,%s,%s,%.4g,%.4g,%.4g,%.4g,%.4g\n", sc_method_name((sc_method)r->method),
                sc_batch_kind_name((sc_batch_kind)r->kind), sc_isa_name((sc_isa)r->isa),
                r->dbl ? "double" : "float", r->ws, r->source, r->mtri, r->ns, r->copy_ratio, r->err_med,
                r->err_max);
    }
    return 0;
}

/* Speed against error at L1, one series per ISA x precision; the data
 * travel inside the script (a datablock), the picture out of gnuplot's
 * standard output into an atomic write. */
static int plot(const sc_bsph_report *b, const char *png)
{
    char *script = NULL;
    size_t len = 0;
    FILE *g = open_memstream(&script, &len);
    if (!g)
        return -1;
    fprintf(g, "$data << EOD\n");
    for (int isa = 0; isa < SC_ISA_COUNT; isa++)
        for (int dbl = 0; dbl < 2; dbl++) {
            fprintf(g, "# %s %s\n", sc_isa_name((sc_isa)isa), dbl ? "double" : "float");
            for (size_t i = 0; i < b->n; i++) {
                const sc_bsph_row *r = &b->rows[i];
                if (r->isa == isa && r->dbl == dbl && strcmp(r->ws, "L1") == 0 && strcmp(r->source, "soa") == 0)
                    fprintf(g, "%g %g %g\n", r->mtri, fmax(r->err_max, 1e-18), fmax(r->err_med, 1e-18));
            }
            fprintf(g, "\n\n");
        }
    fprintf(g, "EOD\nset terminal pngcairo size 1100,750\n");
    fprintf(g, "set logscale xy\nset xlabel 'throughput, million triangles/s (L1-resident, log)'\n"
               "set ylabel 'centre error / radius vs MPFR (log)'\nset grid\nset key outside right\n"
               "set title 'spherecull bench-spheres: speed vs error, every method x kind (max: filled, median: open)'\n"
               "plot ");
    int blk = 0;
    for (int isa = 0; isa < SC_ISA_COUNT; isa++)
        for (int dbl = 0; dbl < 2; dbl++, blk++) {
            const char *in = sc_isa_name((sc_isa)isa), *pn = dbl ? "double" : "float";
            fprintf(g, "%s$data index %d using 1:2 with points pt %d lc %d title '%s %s max', "
                       "$data index %d using 1:3 with points pt %d lc %d title '%s %s median'",
                    blk ? ", " : "", blk, 7 + 2 * dbl, isa + 1, in, pn, blk, 6 + 2 * dbl, isa + 1, in, pn);
        }
    fprintf(g, "\n");
    int rc = fclose(g) == 0 && script ? sc_write_atomic(png, sc_gnuplot_write, script) : -1;
    free(script);
    return rc;
}

static void print_note(void *ctx, const char *line)
{
    (void)ctx;
    fputs(line, stdout);
}

static int run(int argc, char **argv)
{
    args a = { NULL, NULL, 0, -1 };
    int prc = sc_cli_parse(&sc_cli_bench_spheres, argc, argv, on_option, &a);
    if (prc)
        return prc < 0 ? 0 : prc;
    if (sc_cli_check_output(CMD, "--csv", a.csv) != 0 || sc_cli_check_output(CMD, "--plot", a.png) != 0)
        return 1;
    sc_status st = sc_simd_init();
    if (st != SC_OK) {
        sc_cli_error(CMD, "SPHERECULL_ISA=%s: %s", getenv("SPHERECULL_ISA"), sc_strerror(st));
        return 1;
    }
    char brand[64];
    sc_x86_brand(brand);
    printf("compiler: %s\ncpu: %s (%ld online)\n", "gcc/clang " __VERSION__, brand, sysconf(_SC_NPROCESSORS_ONLN));
    printf("isa: active %s; supported:", sc_isa_name(sc_isa_active()));
    for (int i = 0; i < SC_ISA_COUNT; i++)
        if (sc_isa_supported((sc_isa)i))
            printf(" %s", sc_isa_name((sc_isa)i));
    printf("\nthreads: 1; timing: best of %d repeats (DRAM: copy and kernel alternate, best of each)\n"
           "sources: soa = SoA input (fast path for the prefilter kinds); soa-general = the general path only\n"
           "  (the kernels before the fast path); soa-noprescale = general path without prescaling;\n"
           "  soa-nostream = no streaming stores; indexed = vertex buffer + shuffled index buffer\n\n",
           a.quick ? 3 : 5);
    sc_bsph_report b;
    if ((st = sc_bsph_run(a.quick, a.only, &b, print_note, NULL)) != SC_OK) {
        sc_cli_error(CMD, "%s", sc_strerror(st));
        sc_bsph_free(&b);
        return 1;
    }
    const int quick = a.quick;

    printf("\n%-18s %-17s %-6s %-6s %-4s %-14s %9s %8s %7s %10s %10s\n", "method", "kind", "isa", "prec", "set",
           "source", "Mtri/s", "ns/tri", "copy", "err_med", "err_max");
    for (size_t i = 0; i < b.n; i++) {
        const sc_bsph_row *r = &b.rows[i];
        printf("%-18s %-17s %-6s %-6s %-4s %-14s %9.1f %8.2f %7.3f %10.2e %10.2e\n",
               sc_method_name((sc_method)r->method), sc_batch_kind_name((sc_batch_kind)r->kind),
               sc_isa_name((sc_isa)r->isa), r->dbl ? "double" : "float", r->ws, r->source, r->mtri, r->ns,
               r->copy_ratio, r->err_med, r->err_max);
    }

    printf("\nreject masks, ns per call (one ray vs block / one sphere vs packet):\n%-8s %8s %8s %8s %9s %9s\n",
           "isa", "block4", "block8", "block16", "packet8", "packet16");
    for (int ii = 0; ii < b.nisa; ii++) {
        const double *t = b.reject_ns[ii];
        printf("%-8s %8.2f %8.2f %8.2f %9.2f %9.2f\n", sc_isa_name((sc_isa)b.isas[ii]), t[0], t[1], t[2], t[3], t[4]);
    }

    printf("\nthe paper's claim (projective faster than textbook by 5-10%%, C#), circumsphere, float, L1:\n");
    for (int ii = 0; ii < b.nisa; ii++) {
        const sc_bsph_row *tb = sc_bsph_find(&b, SC_METHOD_TEXTBOOK, SC_BATCH_CIRCUM, b.isas[ii], 0, "L1", "soa");
        const sc_bsph_row *pl = sc_bsph_find(&b, SC_METHOD_PROJECTIVE_LITERAL, SC_BATCH_CIRCUM, b.isas[ii], 0, "L1", "soa");
        const sc_bsph_row *pr = sc_bsph_find(&b, SC_METHOD_PROJECTIVE_REDUCED, SC_BATCH_CIRCUM, b.isas[ii], 0, "L1", "soa");
        if (tb && pl && pr)
            printf("  %-7s projective-literal %.2fx, projective-reduced %.2fx the textbook speed\n",
                   sc_isa_name((sc_isa)b.isas[ii]), pl->mtri / tb->mtri, pr->mtri / tb->mtri);
    }

    printf("\nDRAM copy ratios (kernel bytes/s over memcpy's, paired; target >= 0.8), textbook, float:\n");
    for (int ii = 0; ii < b.nisa; ii++)
        for (int kind = SC_BATCH_PREFILTER_CIRCUM; kind <= SC_BATCH_PREFILTER_MINIMAL; kind++) {
            const sc_bsph_row *f = sc_bsph_find(&b, SC_METHOD_TEXTBOOK, kind, b.isas[ii], 0, "DRAM", "soa");
            const sc_bsph_row *g = sc_bsph_find(&b, SC_METHOD_TEXTBOOK, kind, b.isas[ii], 0, "DRAM", "soa-general");
            const sc_bsph_row *x = sc_bsph_find(&b, SC_METHOD_TEXTBOOK, kind, b.isas[ii], 0, "DRAM", "indexed");
            if (!f)
                continue;
            printf("  %-7s %-17s %.2f (%s)", sc_isa_name((sc_isa)b.isas[ii]), sc_batch_kind_name((sc_batch_kind)kind),
                   f->copy_ratio, f->copy_ratio >= 0.8 ? "met" : "NOT met");
            if (g)
                printf("; general path %.2f", g->copy_ratio);
            if (x)
                printf("; indexed %.3f", x->copy_ratio);
            printf("\n");
        }
    const sc_bsph_row *bi = sc_bsph_find(&b, SC_METHOD_TEXTBOOK, SC_BATCH_PREFILTER_MINIMAL, b.best, 0, "DRAM", "indexed");
    if (bi)
        printf("  indexed, %s: %.2f ns/triangle, %.2fx the time of a plain copy of the same vertices through the\n"
               "  same shuffled index buffer (%.2f ns/triangle): bound by the random vertex reads, not by memcpy\n",
               sc_isa_name((sc_isa)b.best), bi->ns, bi->ns / b.idx_copy_ns, b.idx_copy_ns);

    const sc_bsph_row *base = sc_bsph_find(&b, SC_METHOD_TEXTBOOK, SC_BATCH_PREFILTER_MINIMAL, SC_ISA_SCALAR, 0, "L1", "soa");
    const sc_bsph_row *base_c = sc_bsph_find(&b, SC_METHOD_TEXTBOOK, SC_BATCH_CIRCUM, SC_ISA_SCALAR, 0, "L1", "soa");
    const sc_bsph_row *top = sc_bsph_find(&b, SC_METHOD_TEXTBOOK, SC_BATCH_PREFILTER_MINIMAL, b.best, 0, "L1", "soa");
    const sc_bsph_row *nops = sc_bsph_find(&b, SC_METHOD_TEXTBOOK, SC_BATCH_PREFILTER_MINIMAL, b.best, 0, "L1", "soa-noprescale");
    const sc_bsph_row *gen = sc_bsph_find(&b, SC_METHOD_TEXTBOOK, SC_BATCH_PREFILTER_MINIMAL, b.best, 0, "L1", "soa-general");
    const sc_bsph_row *dr = sc_bsph_find(&b, SC_METHOD_TEXTBOOK, SC_BATCH_PREFILTER_MINIMAL, b.best, 0, "DRAM", "soa");
    const sc_bsph_row *dri = sc_bsph_find(&b, SC_METHOD_TEXTBOOK, SC_BATCH_PREFILTER_MINIMAL, b.best, 0, "DRAM", "indexed");
    printf("\ntargets (%s, textbook, prefilter-minimal, float):\n", sc_isa_name((sc_isa)b.best));
    if (base && top && base_c)
        printf("  in-cache speed-up vs scalar textbook: %.1fx same kind, %.1fx vs scalar circum (target >= 10x: %s)\n",
               top->mtri / base->mtri, top->mtri / base_c->mtri, top->mtri / base->mtri >= 10 ? "met" : "NOT met");
    if (dr)
        printf("  DRAM (%s triangles) copy ratio: %.2f SoA, %.2f indexed (target >= 0.8: %s)\n",
               quick ? "2e6" : "1e7", dr->copy_ratio, dri ? dri->copy_ratio : NAN,
               dr->copy_ratio >= 0.8 ? "met" : "NOT met");
    if (top && gen)
        printf("  fast path: %.2fx the general path in L1 (%.1f vs %.1f Mtri/s)\n", top->mtri / gen->mtri, top->mtri,
               gen->mtri);
    if (gen && nops)
        printf("  power-of-two prescaling costs the general path %.1f%% in L1 (%.1f vs %.1f Mtri/s without)\n",
               100 * (nops->mtri / gen->mtri - 1), gen->mtri, nops->mtri);

    int rc = 0;
    if (a.csv && sc_cli_write(CMD, a.csv, write_csv, &b) != 0)
        rc = 1;
    if (rc == 0 && a.png && plot(&b, a.png) != 0) {
        sc_cli_error(CMD, "gnuplot failed to write %s", a.png);
        rc = 1;
    }
    sc_bsph_free(&b);
    return rc;
}

const sc_cli_cmd sc_cli_bench_spheres = {
    .name = "bench-spheres",
    .operands = "",
    .summary = "SIMD batch-sphere and reject-mask throughput vs memcpy, speed vs error",
    .details = "Throughput of the batch-sphere kernels (method x kind x ISA x precision) at L1-, L2-\n"
               "and DRAM-sized working sets against a memcpy of the same bytes, reject-mask cost,\n"
               "and each variant's centre error against MPFR.\n",
    .opts = opts,
    .nopts = SC_NAMES_COUNT(opts),
    .run = run,
};

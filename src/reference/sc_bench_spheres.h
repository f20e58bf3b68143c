/* The measurements behind 'spherecull bench-spheres': batch-sphere and
 * reject-mask throughput per method x kind x ISA x precision x working set,
 * against a memcpy of the same bytes in the same run, beside each variant's
 * centre error against MPFR. It lives with the MPFR references because it
 * is a report that needs them (tests and reports only, never the library);
 * the CLI only parses, prints and writes. */
#ifndef SPHERECULL_REFERENCE_SC_BENCH_SPHERES_H
#define SPHERECULL_REFERENCE_SC_BENCH_SPHERES_H

#include <stddef.h>

#include "spherecull/sc_simd.h"

typedef struct sc_bsph_row {
    int method, kind, isa, dbl;
    const char *ws;          /* L1 | L2 | DRAM */
    const char *source;      /* soa | indexed | soa-general | soa-noprescale | soa-nostream */
    double mtri, ns, copy_ratio, err_med, err_max;
} sc_bsph_row;

enum { SC_BSPH_REJECT_COLS = 5 };   /* block4, block8, block16, packet8, packet16 */

typedef struct sc_bsph_report {
    sc_bsph_row *rows;
    size_t n, cap;
    int quick;
    int isas[SC_ISA_COUNT], nisa, best;              /* levels measured; best = the highest */
    double idx_copy_ns;                              /* DRAM copy through the index buffer, per triangle */
    double reject_ns[SC_ISA_COUNT][SC_BSPH_REJECT_COLS];   /* per isas[] entry, ns per call */
} sc_bsph_report;

/* Measures every level this CPU has (only: one level besides scalar, or
 * -1 for all). Progress lines (copy bandwidths) go to note when not NULL. */
sc_status sc_bsph_run(int quick, int only, sc_bsph_report *b, void (*note)(void *ctx, const char *line), void *ctx);
void sc_bsph_free(sc_bsph_report *b);
const sc_bsph_row *sc_bsph_find(const sc_bsph_report *b, int method, int kind, int isa, int dbl, const char *ws,
                                const char *src);

#endif

/* bench_leafcost — what one leaf costs: the exact triangle block test against
 * the sphere block test, per block width and ISA. The numbers behind the
 * "auto" prefilter rule (sc_bvh.h).
 *
 * A BVH of one leaf of W equal triangles (stacked in z) is traced by an
 * any-hit ray along -z that meets the leaf's box but no triangle:
 *   off,     ray through the spheres:  O + C_tri
 *   minimal, ray through the spheres:  O + C_sph + C_tri
 *   minimal, ray beside the spheres:   O + C_sph
 * (O: per-ray set-up and the root node), so C_tri and C_sph follow by
 * difference. Data stays in L1: these are lower bounds of both costs; in a
 * real tree each block also brings its cache lines (spheres: 16 B/triangle).
 *
 *   bench_leafcost [--isa scalar|sse4|avx2|avx512] [--iters N]
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/sc_clock.h"
#include "spherecull/sc_isa.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_trace.h"

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* ns per query: the fastest of 21 runs of iters queries (the machine may be
 * shared; interference only ever adds time). */
#define RUNS 21
static double time_any(const sc_bvh *b, const sc_ray *r, long iters)
{
    double t[RUNS];
    volatile int sink = 0;
    for (int k = 0; k < RUNS; k++) {
        double t0 = sc_now_seconds();
        for (long i = 0; i < iters; i++) {
            int occ;
            sc_trace_any(b, r, &occ, NULL);
            sink += occ;
        }
        t[k] = (sc_now_seconds() - t0) / (double)iters * 1e9;
    }
    (void)sink;
    qsort(t, RUNS, sizeof t[0], cmp);
    return t[0];
}

int main(int argc, char **argv)
{
    long iters = 200000;
    for (int i = 1; i + 1 < argc; i += 2) {
        sc_isa isa;
        if (strcmp(argv[i], "--isa") == 0 && sc_isa_from_name(argv[i + 1], &isa) == SC_OK &&
            sc_isa_force(isa) == SC_OK)
            continue;
        if (strcmp(argv[i], "--iters") == 0 && (iters = atol(argv[i + 1])) > 0)
            continue;
        fprintf(stderr, "usage: bench_leafcost [--isa ISA] [--iters N]\n");
        return 2;
    }
    printf("# W   isa      O+C_tri  O+C_sph+C_tri  O+C_sph   C_tri ns  C_sph ns  C_sph/C_tri\n");
    const int widths[3] = { 4, 8, 16 };
    for (int wi = 0; wi < 3; wi++) {
        int W = widths[wi];
        float pos[16 * 9];
        uint32_t idx[16 * 3];
        for (int t = 0; t < W; t++) {
            float z = 0.01f * (float)t;
            float v[9] = { 0, 0, z, 1, 0, z, 0.5f, 0.8660254f, z };
            memcpy(pos + 9 * t, v, sizeof v);
            for (int k = 0; k < 3; k++)
                idx[3 * t + k] = (uint32_t)(3 * t + k);
        }
        double ns[3];
        for (int c = 0; c < 3; c++) {
            sc_bvh_config cfg;
            sc_bvh_config_default(&cfg);
            cfg.leaf_size = W;
            cfg.prefilter = c == 0 ? SC_PREFILTER_OFF : SC_PREFILTER_MINIMAL;
            sc_bvh *b;
            if (sc_bvh_build(&(sc_mesh_view){ pos, (size_t)(3 * W), idx, (size_t)W, 0, 0 }, &cfg, &b) != SC_OK) {
                fprintf(stderr, "bench_leafcost: build failed\n");
                return 1;
            }
            sc_bvh_info info;
            sc_bvh_get_info(b, &info);
            /* (0.75, 0.6): inside the circumcircle, outside the triangle;
             * (0.02, 0.84): inside the box, outside every sphere. */
            sc_ray r = { { c == 2 ? 0.02f : 0.75f, c == 2 ? 0.84f : 0.6f, 10 }, 0, { 0, 0, -1 }, INFINITY };
            int occ = 1;
            sc_trace_any(b, &r, &occ, NULL);
            if (occ || info.leaves != 1) {
                fprintf(stderr, "bench_leafcost: set-up is wrong (occ %d, leaves %zu)\n", occ, info.leaves);
                return 1;
            }
            ns[c] = time_any(b, &r, iters);
            sc_bvh_free(b);
        }
        double ctri = ns[1] - ns[2], csph = ns[1] - ns[0];
        printf("%3d   %-7s %8.2f %14.2f %8.2f %9.2f %9.2f %12.2f\n", W, sc_isa_name(sc_isa_active()), ns[0], ns[1], ns[2],
               ctri, csph, csph / ctri);
    }
    return 0;
}

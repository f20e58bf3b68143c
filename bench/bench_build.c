/* BVH build time, spherecull's medium and high build qualities
 * (sc_bvh_build) against Embree's on the same mesh at the same thread
 * counts, and a check that our trees are the same bytes for every thread
 * count (docs/compare.md has the figures).
 *
 * Our time is the whole sc_bvh_build call (index check, boxes, SAH, the
 * 8-wide collapse, leaf encoding). Embree's is rtcCommitScene of a scene
 * holding one triangle geometry whose buffers were filled beforehand (its
 * whole build; the copy into its buffers is not counted). Each repeat
 * builds our medium and high and Embree's medium and high (or only the
 * medium or the high builds: --quality), ours first in even repeats and
 * Embree's first in odd ones; medians. A ratio above 1 means spherecull
 * builds faster. Both run with flush-to-zero / denormals-are-zero, as
 * Embree asks.
 *
 *   bench_build [--mesh SPEC] [--threads LIST] [--repeats R] [--quality medium|high|both] */
#define _GNU_SOURCE
#include <embree3/rtcore.h>
#include <getopt.h>
#include <pmmintrin.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <xmmintrin.h>

#include "bvh/bvh_internal.h"
#include "common/sc_clock.h"
#include "common/sc_median.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_embree.h"
#include "spherecull/sc_scene.h"

static void die(const char *what)
{
    fprintf(stderr, "bench_build: %s\n", what);
    exit(1);
}

/* FNV-1a over the nodes and leaves: equal trees give equal hashes. */
static uint64_t tree_hash(const sc_bvh *b)
{
    uint64_t h = 0xcbf29ce484222325ull;
    const unsigned char *p = (const unsigned char *)b->nodes;
    for (size_t i = 0; i < b->node_count * sizeof(sc_bvh_node8); i++)
        h = (h ^ p[i]) * 0x100000001b3ull;
    p = b->leaves;
    for (size_t i = 0; i < b->leaf_bytes; i++)
        h = (h ^ p[i]) * 0x100000001b3ull;
    return h;
}

/* One Embree build: the commit of a fresh scene over copied buffers. */
static double embree_build(RTCDevice dev, const sc_mesh_view *m, enum RTCBuildQuality q)
{
    RTCScene scene = rtcNewScene(dev);
    rtcSetSceneBuildQuality(scene, q);
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(g, q);
    float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                       m->vertex_count);
    unsigned *ix = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                           m->triangle_count);
    if (!v || !ix)
        die("Embree refused the buffers");
    for (size_t i = 0; i < m->vertex_count; i++)
        memcpy(v + 3 * i, sc_mesh_vertex(m, (uint32_t)i), 3 * sizeof(float));
    for (size_t t = 0; t < m->triangle_count; t++)
        memcpy(ix + 3 * t, sc_mesh_triangle(m, t), 3 * sizeof(unsigned));
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    const double t0 = sc_now_seconds();
    rtcCommitScene(scene);
    const double s = sc_now_seconds() - t0;
    if (rtcGetDeviceError(dev) != RTC_ERROR_NONE)
        die("Embree's build failed");
    rtcReleaseScene(scene);
    return s;
}

/* a table cell: v in fmt, or "-" when its quality was not built */
static void cell(char *out, int on, const char *fmt, double v)
{
    if (on)
        snprintf(out, 24, fmt, v);
    else
        snprintf(out, 24, "-");
}

int main(int argc, char **argv)
{
    const char *spec = "proc:grid:cache:bunny00.off:8M";
    char *list = "1,2";
    int repeats = 3;
    int qmask = 3;   /* bit 0: the medium builds, bit 1: the high ones */
    static const struct option opts[] = { { "mesh", required_argument, 0, 'm' },
                                          { "quality", required_argument, 0, 'q' },
                                          { "threads", required_argument, 0, 't' },
                                          { "repeats", required_argument, 0, 'r' },
                                          { 0, 0, 0, 0 } };
    int o;
    while ((o = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        switch (o) {
        case 'm': spec = optarg; break;
        case 't': list = optarg; break;
        case 'r': repeats = atoi(optarg); break;
        case 'q':
            qmask = !strcmp(optarg, "medium") ? 1 : !strcmp(optarg, "high") ? 2 : !strcmp(optarg, "both") ? 3 : 0;
            if (!qmask)
                die("--quality: medium, high or both");
            break;
        default: die("usage: bench_build [--mesh SPEC] [--threads LIST] [--repeats R] [--quality medium|high|both]");
        }
    }
    if (repeats < 1 || repeats > 1000)
        die("--repeats: 1..1000");
    int counts[16], nc = 0;
    for (char *s = list; *s && nc < 16;) {
        char *end;
        long v = strtol(s, &end, 10);
        if (end == s || v < 1 || v > SC_BVH_MAX_THREADS || (*end && *end != ','))
            die("--threads: a list of counts 1..256, e.g. 1,2");
        counts[nc++] = (int)v;
        s = *end ? end + 1 : end;
    }
    if (!nc)
        die("--threads: a list of counts 1..256, e.g. 1,2");
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
    sc_scene *scene;
    char err[256];
    if (sc_scene_load(spec, NULL, &scene, err, sizeof err) != SC_OK) {
        fprintf(stderr, "bench_build: %s\n", err);
        return 1;
    }
    sc_scene_view view;
    sc_scene_get_view(scene, &view);
    const sc_mesh_view *m = &view.mesh;
    char ver[512];
    sc_embree_version(ver, sizeof ver);
    printf("mesh %s (%zu triangles); embree: %s (FTZ|DAZ); %d repeats, median seconds\n", spec, m->triangle_count,
           ver, repeats);
    printf("threads    ours-medium    ours-high  embree-medium  embree-high  x-medium  x-high  SAH-medium  SAH-high  tree hashes\n");
    double *to = malloc(sizeof(double) * (size_t)repeats), *tm = malloc(sizeof(double) * (size_t)repeats),
           *th = malloc(sizeof(double) * (size_t)repeats), *toh = malloc(sizeof(double) * (size_t)repeats);
    if (!to || !tm || !th || !toh)
        die("out of memory");
    uint64_t first_hash[2] = { 0, 0 };
    int same = 1;
    for (int c = 0; c < nc; c++) {
        char cfg[64];
        snprintf(cfg, sizeof cfg, "verbose=0,threads=%d", counts[c]);
        RTCDevice dev = rtcNewDevice(cfg);
        if (!dev)
            die("no Embree device");
        sc_bvh_config bc;
        sc_bvh_config_default(&bc);
        bc.threads = counts[c];
        uint64_t hash[2] = { 0, 0 };
        double sah[2] = { 0, 0 };
        for (int r = 0; r < repeats; r++) {
            /* Who builds first alternates: each build's fresh memory is
             * faulted in, and huge pages (both of us ask for them) come
             * cheaply when the previous build just freed some, slowly when
             * the kernel must compact memory first. */
            if (r % 2) {
                if (qmask & 1)
                    tm[r] = embree_build(dev, m, RTC_BUILD_QUALITY_MEDIUM);
                if (qmask & 2)
                    th[r] = embree_build(dev, m, RTC_BUILD_QUALITY_HIGH);
            }
            for (int q = 0; q < 2; q++) {
                if (!(qmask >> q & 1))
                    continue;
                sc_bvh *b;
                bc.quality = q ? SC_BUILD_QUALITY_HIGH : SC_BUILD_QUALITY_MEDIUM;
                const double t0 = sc_now_seconds();
                if (sc_bvh_build(m, &bc, &b) != SC_OK)
                    die("our build failed");
                (q ? toh : to)[r] = sc_now_seconds() - t0;
                hash[q] = tree_hash(b);
                sah[q] = b->sah_cost;
                sc_bvh_free(b);
            }
            if (r % 2 == 0) {
                if (qmask & 1)
                    tm[r] = embree_build(dev, m, RTC_BUILD_QUALITY_MEDIUM);
                if (qmask & 2)
                    th[r] = embree_build(dev, m, RTC_BUILD_QUALITY_HIGH);
            }
        }
        rtcReleaseDevice(dev);
        for (int q = 0; q < 2; q++) {
            if (c == 0)
                first_hash[q] = hash[q];
            same &= hash[q] == first_hash[q];
        }
        /* a quality not built (--quality) prints "-" in its columns */
        const int qm = qmask & 1, qh = qmask >> 1 & 1;
        const double mo = qm ? sc_median(to, repeats) : 0, moh = qh ? sc_median(toh, repeats) : 0,
                     mm = qm ? sc_median(tm, repeats) : 0, mh = qh ? sc_median(th, repeats) : 0;
        char f[8][24];
        cell(f[0], qm, "%.3f", mo), cell(f[1], qh, "%.3f", moh), cell(f[2], qm, "%.3f", mm);
        cell(f[3], qh, "%.3f", mh), cell(f[4], qm, "%.3f", mm / mo), cell(f[5], qh, "%.3f", mh / moh);
        cell(f[6], qm, "%.3f", sah[0]), cell(f[7], qh, "%.3f", sah[1]);
        char hs[2][24];
        for (int q = 0; q < 2; q++) {
            if (qmask >> q & 1)
                snprintf(hs[q], sizeof hs[q], "%016llx", (unsigned long long)hash[q]);
            else
                snprintf(hs[q], sizeof hs[q], "%16s", "-");
        }
        printf("%7d %14s %12s %14s %12s %9s %7s %11s %9s  %s %s\n", counts[c], f[0], f[1], f[2], f[3], f[4], f[5], f[6],
               f[7], hs[0], hs[1]);
        fflush(stdout);
    }
    printf("# x-medium, x-high: Embree's build time over ours at the same quality (above 1: we build faster);\n"
           "# our trees %s for every thread count\n",
           same ? "are the same bytes" : "DIFFER");
    free(to), free(tm), free(th), free(toh);
    sc_scene_free(scene);
    return same ? 0 : 1;
}

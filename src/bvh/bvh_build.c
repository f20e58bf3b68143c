/* The BVH build: checks the input, boxes the triangles, builds a binary
 * tree by binned SAH over the boxes (build_binned_sah.c), collapses it into
 * the 8-wide layout (collapse_bvh8.c) whose leaves leaf_triangles.c
 * encodes; then the handle's lifecycle, its figures and the names of the
 * config's enums. */
#define _POSIX_C_SOURCE 200809L   /* sysconf, POSIX threads */
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "build_internal.h"
#include "build_spatial_sah.h"
#include "split_triangle.h"
#include "optimize_reinsertion.h"
#include "common/sc_clock.h"
#include "common/sc_mem.h"
#include "common/sc_names.h"

void sc_bvh_config_default(sc_bvh_config *cfg)
{
    if (!cfg)
        return;
    /* Leaf 8 with a node visit costed at two leaf blocks (the SAH then
     * fills leaves): faster shadow and primary rays and fewer bytes per
     * triangle than leaf 4 / cost 1 (docs/compare.md). */
    cfg->leaf_size = 8;
    cfg->prefilter = SC_PREFILTER_OFF;
    cfg->tri_test = SC_TRI_WATERTIGHT;
    cfg->sah_bins = 32;
    cfg->traversal_cost = 2.0f;
    cfg->threads = 1;
    cfg->quality = SC_BUILD_QUALITY_AUTO;
}

/* SC_BUILD_QUALITY_AUTO's rule (sc_bvh.h). The area of a box over the
 * scene box's is the chance that a random line through the scene passes
 * through it (Cauchy's formula for convex bodies), so the sum over the
 * large triangles is how many of their boxes such a line meets on average.
 * Measured on the shared scenes (docs/compare.md, thirty-first session):
 * 5.3-13.1 on the four where the high build traced incoherent rays 8-37 %
 * faster (Sibenik, featuretype, Sponza, the engine), at most 0.44 on the
 * scanned, terrain and foliage meshes where it gained nothing, and 1.6-1.7
 * on the scenes of a mesh on a two-triangle ground plane, whose plane is
 * all they have to split. */
#define SC_AUTO_LARGE_TRIANGLE 1e-3
#define SC_AUTO_HIGH_SUM 3.0
sc_build_quality sc_build_auto_quality(const box3 *pbox, size_t n)
{
    box3 root;
    box_empty(&root);
    for (size_t i = 0; i < n; i++)
        box_grow(&root, &pbox[i]);
    const double ra = box_area(&root);
    if (!(ra > 0))
        return SC_BUILD_QUALITY_MEDIUM;
    double sum = 0;
    for (size_t i = 0; i < n; i++) {
        const double a = box_area(&pbox[i]) / ra;
        if (a > SC_AUTO_LARGE_TRIANGLE)
            sum += a;
    }
    return sum >= SC_AUTO_HIGH_SUM ? SC_BUILD_QUALITY_HIGH : SC_BUILD_QUALITY_MEDIUM;
}

int sc_build_threads(int cfg_threads)
{
    if (cfg_threads != 0)
        return cfg_threads;
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    return cpus < 1 ? 1 : cpus > SC_BVH_MAX_THREADS ? SC_BVH_MAX_THREADS : (int)cpus;
}

void sc_build_run_workers(void *(*fn)(void *), void *arg, int threads, size_t extra)
{
    pthread_t th[SC_BVH_MAX_THREADS];
    int started = 0;
    for (int i = 1; i < threads && (size_t)i <= extra; i++) {
        if (pthread_create(&th[started], NULL, fn, arg) != 0)
            break;
        started++;
    }
    fn(arg);
    for (int i = 0; i < started; i++)
        pthread_join(th[i], NULL);
}

/* The triangles' boxes, BOX_CHUNK at a time from a shared counter. */
#define BOX_CHUNK 65536
typedef struct box_job {
    const bvh_builder *B;
    box3 *pbox;
    uint32_t *ids;           /* t, or UINT32_MAX for a triangle with a non-finite vertex */
    size_t n;
    atomic_size_t *next, *skipped;
} box_job;

static void *box_work(void *arg)
{
    box_job *j = arg;
    for (;;) {
        const size_t begin = atomic_fetch_add(j->next, BOX_CHUNK);
        if (begin >= j->n)
            return NULL;
        const size_t end = j->n - begin < BOX_CHUNK ? j->n : begin + BOX_CHUNK;
        size_t bad = 0;
        for (size_t t = begin; t < end; t++) {
            box3 b;
            box_empty(&b);
            int finite = 1;
            for (int corner = 0; corner < 3; corner++) {
                const float *p = vtx(j->B, (uint32_t)t, corner);
                finite &= isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]);
                box_grow_point(&b, p);
            }
            j->pbox[t] = b;
            j->ids[t] = finite ? (uint32_t)t : UINT32_MAX;
            bad += !finite;
        }
        if (bad)
            atomic_fetch_add(j->skipped, bad);
    }
}

/* sc_split_fn over the build's triangles (ctx: the bvh_builder). */
static void split_triangle(const void *ctx, uint32_t id, const box3 *box, int axis, float pos, box3 *left,
                           box3 *right)
{
    const bvh_builder *B = ctx;
    const float *v[3] = { vtx(B, id, 0), vtx(B, id, 1), vtx(B, id, 2) };
    sc_split_triangle(v, box, axis, pos, left, right);
}

sc_status sc_bvh_build(const sc_mesh_view *mesh, const sc_bvh_config *cfg_in, sc_bvh **out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    *out = NULL;
    if (!mesh)
        return SC_ERR_INVALID_ARGUMENT;
    return sc_bvh_build_set(mesh, 1, cfg_in, out);
}

sc_status sc_bvh_check_mesh(const sc_mesh_view *mesh)
{
    if (!sc_mesh_layout_ok(mesh))
        return SC_ERR_INVALID_ARGUMENT;
    if (mesh->triangle_count && (!mesh->positions || !mesh->indices))
        return SC_ERR_INVALID_ARGUMENT;
    const size_t vertex_count = mesh->vertex_count;
    for (size_t t = 0; t < mesh->triangle_count; t++) {
        const uint32_t *ix = sc_mesh_triangle(mesh, t);
        if (ix[0] >= vertex_count || ix[1] >= vertex_count || ix[2] >= vertex_count)
            return SC_ERR_INVALID_ARGUMENT;
    }
    return SC_OK;
}

sc_status sc_bvh_build_set(const sc_mesh_view *meshes, size_t mesh_count, const sc_bvh_config *cfg_in,
                           sc_bvh **out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    *out = NULL;
    if (!meshes || mesh_count == 0 || mesh_count > (size_t)INT32_MAX)
        return SC_ERR_INVALID_ARGUMENT;
    sc_bvh_config cfg;
    if (cfg_in)
        cfg = *cfg_in;
    else
        sc_bvh_config_default(&cfg);
    if (cfg.leaf_size < 1 || cfg.leaf_size > SC_BVH_MAX_LEAF || (unsigned)cfg.prefilter >= SC_PREFILTER_MODE_COUNT ||
        (unsigned)cfg.tri_test >= SC_TRI_TEST_COUNT ||
        cfg.sah_bins < 4 || cfg.sah_bins > SC_SAH_MAX_BINS || !(cfg.traversal_cost >= 0) || !isfinite(cfg.traversal_cost) ||
        cfg.threads < 0 || cfg.threads > SC_BVH_MAX_THREADS || (unsigned)cfg.quality >= SC_BUILD_QUALITY_COUNT)
        return SC_ERR_INVALID_ARGUMENT;
    size_t triangle_count = 0;
    for (size_t g = 0; g < mesh_count; g++) {
        if (!sc_mesh_layout_ok(&meshes[g]))
            return SC_ERR_INVALID_ARGUMENT;
        triangle_count += meshes[g].triangle_count;
        if (meshes[g].triangle_count > (size_t)INT32_MAX || triangle_count > (size_t)INT32_MAX)
            return SC_ERR_LIMIT;
    }
    for (size_t g = 0; g < mesh_count; g++) {
        sc_status cs = sc_bvh_check_mesh(&meshes[g]);
        if (cs != SC_OK)
            return cs;
    }
    sc_status st;

    double t0 = sc_now_seconds();
    sc_bvh *bvh = calloc(1, sizeof *bvh);
    bvh_builder B = { 0 };
    B.cfg = &cfg;
    B.meshes = meshes;
    B.mesh_count = mesh_count;
    uint32_t *first = malloc(sizeof(uint32_t) * (mesh_count + 1));
    if (first) {
        first[0] = 0;
        for (size_t g = 0; g < mesh_count; g++)
            first[g + 1] = first[g] + (uint32_t)meshes[g].triangle_count;
    }
    B.first = first;
    size_t n = triangle_count;
    box3 *pbox = malloc(sizeof(box3) * (n ? n : 1));
    uint32_t *ids = malloc(sizeof(uint32_t) * (n ? n : 1));
    sc_bnode *bn = NULL;         /* the binary tree: the SAH step's */
    B.ids = ids;
    st = SC_ERR_OUT_OF_MEMORY;
    if (!bvh || !first || !pbox || !ids)
        goto fail;
    bvh->cfg = cfg;
    bvh->first = first;
    bvh->mesh_count = mesh_count;
    first = NULL;

    const int threads = sc_build_threads(cfg.threads);
    /* Every triangle's box at its own index, in chunks on the threads; a
     * triangle with a non-finite vertex is marked and then left out (the
     * others keep their order). */
    atomic_size_t next, skipped;
    atomic_init(&next, 0);
    atomic_init(&skipped, 0);
    box_job bj = { &B, pbox, ids, n, &next, &skipped };
    sc_build_run_workers(box_work, &bj, n >= SC_SAH_PARALLEL_MIN ? threads : 1, n / BOX_CHUNK);
    size_t used = n;
    if (atomic_load(&skipped)) {
        used = 0;
        for (size_t t = 0; t < n; t++)
            if (ids[t] != UINT32_MAX) {
                pbox[used] = pbox[t];
                ids[used++] = (uint32_t)t;
            }
    }
    bvh->triangles = used;
    bvh->skipped = n - used;
    const sc_build_quality quality = cfg.quality == SC_BUILD_QUALITY_AUTO ? sc_build_auto_quality(pbox, used) : cfg.quality;
    bvh->quality = quality;

    size_t root_nodes = 0;
    if (used) {
        const sc_sah_params sah = { cfg.leaf_size, cfg.sah_bins, cfg.traversal_cost, threads };
        size_t bn_count;
        const uint32_t root = 0;
        if (quality == SC_BUILD_QUALITY_HIGH) {
            /* Embree's choices: a spatial split tried where the object
             * split's children overlap by 1e-5 of the root's area and a
             * tenth of the node's, 16 spatial bins, at most 20 % more
             * references (the budgets measured: docs/compare.md). */
            const sc_spatial_params sp = { sah, 1e-5f, 0.1f, 0.2f, 16, split_triangle, &B };
            uint32_t *sids;
            size_t refs;
            if (sc_build_spatial_sah(pbox, ids, used, &sp, &sids, &refs, &bn, &bn_count) != 0)
                goto fail;
            free(ids);
            B.ids = ids = sids;
            bvh->references = refs;
            /* Then up to 10 rounds of reinsertion over the 20 % largest
             * nodes: on Sponza and a CAD engine the SAH cost of a binned
             * SAH tree stops falling there (12 % and 6 % lower), at about
             * 1.7x its build time (docs/compare.md). */
            const sc_reinsertion_params rp = { 10, 0.2, threads };
            if (sc_reinsertion_optimize(bn, root, bn_count, &rp) != 0)
                goto fail;
        } else {
            if (!(bn = malloc(sizeof(sc_bnode) * (2 * used - 1))))
                goto fail;
            sc_build_binned_sah(pbox, ids, used, &sah, bn, &bn_count);
            bvh->references = used;
        }
        B.bn = bn;
        if (!(B.auto_use = calloc(bn_count, 1)))   /* per binary node: the auto rule's choice */
            goto fail;
        B.root_area = box_area(&B.bn[root].box);
        if (!(B.root_area > 0))
            B.root_area = 1;
        for (int k = 0; k < 3; k++) {
            bvh->root_lo[k] = B.bn[root].box.lo[k];
            bvh->root_hi[k] = B.bn[root].box.hi[k];
        }
        /* Measure, then write in the same order. A large tree does both
         * for its subtrees below the top levels as jobs on the threads
         * (build_internal.h): walks of the top levels record them, place
         * them after they are measured, and write around them. The jobs
         * and their places do not depend on the thread count, nor do the
         * figures, summed in tree order; so neither do the bytes. */
        B.bvh = bvh;
        const int jobs = used >= SC_SAH_PARALLEL_MIN;
        const sc_bnode *r = &B.bn[root];
        const uint32_t kids[2] = { r->a, r->b };
        const int walks = jobs ? 3 : 2;
        struct collapse_job jobs_mem[SC_COLLAPSE_JOBS];
        B.jobs = jobs_mem;
        B.njobs = 0;
        bvh_builder measured = B;
        for (int walk = 0; walk < walks; walk++) {
            /* jobs: record, place (measured), place and write; else measure, write */
            const int write = walk == walks - 1;
            B.dry = !write;
            B.record = jobs && walk == 0;
            B.defer = jobs && walk > 0;
            B.next_job = 0;
            B.node_used = B.leaf_used = B.sphere_used = B.leaves_emitted = B.leaves_spheres = 0;
            B.sah = 0;
            B.max_depth = 0;
            if (r->leaf)
                sc_collapse_bvh8(&B, &root, 1, 1);
            else
                sc_collapse_bvh8(&B, kids, 2, 1);
            if (B.record)
                sc_collapse_measure_jobs(&B, threads);
            if (write) {
                if (jobs)
                    sc_collapse_jobs(&B, threads);
                B.sah = measured.sah, B.max_depth = measured.max_depth;
                B.leaves_emitted = measured.leaves_emitted, B.leaves_spheres = measured.leaves_spheres;
                B.sphere_used = measured.sphere_used;
            } else if (walk == walks - 2) {
                measured = B;
                /* Nodes and leaves in one block: a tree of 2 MiB or more
                 * gets huge pages for its nodes too (sc_mem.h). */
                const size_t node_bytes = B.node_used * sizeof(sc_bvh_node8);
                const size_t leaf_bytes = (B.leaf_used + 63) / 64 * 64;
                unsigned char *block = sc_alloc_large(node_bytes + leaf_bytes);
                if (!block)
                    goto fail;
                bvh->nodes = (sc_bvh_node8 *)(void *)block;
                bvh->leaves = block + node_bytes;   /* zero: the gaps between leaves stay so */
                const size_t tree = node_bytes + leaf_bytes;
                bvh->prefetch = tree >= SC_PREFETCH_ALL_BYTES       ? SC_PREFETCH_ALL
                                : tree >= SC_PREFETCH_CLOSEST_BYTES ? SC_PREFETCH_CLOSEST
                                                                    : SC_PREFETCH_NONE;
                bvh->interleave = tree >= SC_INTERLEAVE_BYTES;
            }
        }
        root_nodes = B.node_used;
        bvh->has_root = 1;
    }
    bvh->node_count = root_nodes;
    bvh->leaf_count = B.leaves_emitted;
    bvh->leaves_with_spheres = B.leaves_spheres;
    bvh->leaf_bytes = B.leaf_used;
    bvh->sphere_bytes = B.sphere_used;
    bvh->depth = B.max_depth;
    bvh->sah_cost = bvh->built_sah_cost = B.sah;
    bvh->build_seconds = sc_now_seconds() - t0;
    free(pbox);
    free(ids);
    free(bn);
    free(B.auto_use);
    *out = bvh;
    return SC_OK;

fail:
    free(first);
    free(pbox);
    free(ids);
    free(bn);
    free(B.auto_use);
    sc_bvh_free(bvh);
    return st;
}

void sc_bvh_free(sc_bvh *bvh)
{
    if (!bvh)
        return;
    sc_free_large(bvh->nodes);   /* and the leaves, in the same block */
    free(bvh->first);
    free(bvh);
}

sc_status sc_bvh_get_info(const sc_bvh *bvh, sc_bvh_info *info)
{
    if (!bvh || !info)
        return SC_ERR_INVALID_ARGUMENT;
    memset(info, 0, sizeof *info);
    info->triangles = bvh->triangles;
    info->skipped_triangles = bvh->skipped;
    info->nodes = bvh->node_count;
    info->leaves = bvh->leaf_count;
    info->leaves_with_spheres = bvh->leaves_with_spheres;
    info->node_bytes = bvh->node_count * sizeof(sc_bvh_node8);
    info->leaf_bytes = bvh->leaf_bytes;
    info->sphere_bytes = bvh->sphere_bytes;
    info->total_bytes = info->node_bytes + info->leaf_bytes + sizeof *bvh + sizeof(uint32_t) * (bvh->mesh_count + 1);
    info->depth = bvh->depth;
    info->sah_cost = bvh->sah_cost;
    info->build_seconds = bvh->build_seconds;
    info->prefilter = bvh->cfg.prefilter;
    info->leaf_size = bvh->cfg.leaf_size;
    info->built_sah_cost = bvh->built_sah_cost;
    info->quality = bvh->quality;
    return SC_OK;
}

/* ---- names -------------------------------------------------------------- */

static const char *const mode_names[SC_PREFILTER_MODE_COUNT] = { "off", "circum", "minimal", "auto", "compact" };
static const char *const test_names[SC_TRI_TEST_COUNT] = { "watertight", "moller", "exact" };

const char *sc_prefilter_mode_name(sc_prefilter_mode m)
{
    return sc_enum_name(mode_names, SC_PREFILTER_MODE_COUNT, (int)m, "unknown");
}

const char *sc_tri_test_name(sc_tri_test t)
{
    return sc_enum_name(test_names, SC_TRI_TEST_COUNT, (int)t, "unknown");
}

sc_status sc_prefilter_mode_from_name(const char *name, sc_prefilter_mode *out)
{
    int v;
    if (!out || sc_enum_lookup(mode_names, SC_PREFILTER_MODE_COUNT, name, &v) != 0)
        return SC_ERR_INVALID_ARGUMENT;
    *out = (sc_prefilter_mode)v;
    return SC_OK;
}

sc_status sc_tri_test_from_name(const char *name, sc_tri_test *out)
{
    int v;
    if (!out || sc_enum_lookup(test_names, SC_TRI_TEST_COUNT, name, &v) != 0)
        return SC_ERR_INVALID_ARGUMENT;
    *out = (sc_tri_test)v;
    return SC_OK;
}

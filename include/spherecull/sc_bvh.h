/* spherecull — the acceleration structure: an 8-wide BVH built by binned SAH
 * whose leaves hold up to N triangles (pre-gathered SoA vertices, like
 * Embree's triangle4/8) and, optionally, their conservative prefilter spheres
 * in an SoA block (sc_sphere_block4/8/16 of sc_prefilter.h).
 *
 *   sc_bvh_config cfg;
 *   sc_bvh_config_default(&cfg);              // leaf 8, prefilter off
 *   cfg.prefilter = SC_PREFILTER_MINIMAL;
 *   sc_bvh *bvh;
 *   sc_mesh_view mesh = { pos, nverts, idx, ntris, 0, 0 };    // sc_mesh.h; 0: packed
 *   sc_status s = sc_bvh_build(&mesh, &cfg, &bvh);
 *   ... sc_trace_closest(bvh, &ray, &hit, NULL) ...   (sc_trace.h)
 *   sc_bvh_free(bvh);
 *
 * The BVH copies what it needs; positions and indices may be freed after the
 * build. A triangle with a non-finite vertex can never be hit and is left
 * out of the tree (counted in sc_bvh_info.skipped_triangles).
 *
 * Prefilter modes (what the leaf test does before the exact triangle test):
 *   off      no spheres are stored; every triangle in a visited leaf is tested.
 *   circum   circumsphere of each triangle (conservative, sc_prefilter_sphere_f).
 *   minimal  minimal enclosing sphere of each triangle (conservative).
 *   auto     per leaf: minimal spheres are stored and used only where they are
 *            expected to pay. A block of spheres pays for a leaf iff
 *            s * C_tri > C_sph, where s is the fraction of the rays reaching
 *            the leaf that every sphere rejects (so the triangle test is
 *            skipped) and C_tri, C_sph are the costs of the triangle and
 *            sphere block tests (measured by bench/bench_leafcost.c; the
 *            figures are in docs/compare.md). For blocks of 4 and 8 a sphere
 *            block costs more than the triangle block it could skip, so such
 *            leaves never get spheres; leaves of 9..16 triangles shoot
 *            SC_BVH_AUTO_SAMPLES isotropic random lines through their box at
 *            their spheres at build time and use them iff the fraction that
 *            all spheres reject is at least SC_BVH_AUTO_THRESHOLD16.
 *            Deterministic: the lines are seeded by leaf.
 *   compact  every leaf carries its minimal spheres quantised to 4 bytes each
 *            against the leaf's box (one cache line for a leaf of 8, against
 *            the 4.5 lines of its vertices), padded outward so each still
 *            contains its triangle; a ray that every sphere rejects skips the
 *            leaf's vertices without fetching them. For big scenes, where
 *            fetching a leaf costs more than testing it.
 * Every mode returns exactly the same hits; only the work differs.
 */
#ifndef SPHERECULL_SC_BVH_H
#define SPHERECULL_SC_BVH_H

#include "sc_api.h"
#include <stddef.h>
#include <stdint.h>

#include "sc_mesh.h"
#include "sc_status.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SC_BVH_MAX_LEAF 16
#define SC_BVH_MAX_THREADS 256
#define SC_BVH_AUTO_SAMPLES 32
#define SC_BVH_AUTO_THRESHOLD16 0.75   /* the upper end of the measured C_sph / C_tri for blocks of 16 */

typedef enum sc_prefilter_mode {
    SC_PREFILTER_OFF = 0,
    SC_PREFILTER_CIRCUM,
    SC_PREFILTER_MINIMAL,
    SC_PREFILTER_AUTO,
    SC_PREFILTER_COMPACT,
    SC_PREFILTER_MODE_COUNT
} sc_prefilter_mode;

/* The exact ray-triangle test behind the prefilter. */
typedef enum sc_tri_test {
    SC_TRI_WATERTIGHT = 0,   /* Woop, Benthin, Wald 2013; double fallback on zero edges */
    SC_TRI_MOLLER,           /* Moller-Trumbore 1997; not watertight, for comparison */
    SC_TRI_EXACT,            /* exact decisions (hit/miss, t range, closest) with a float
                                filter; see sc_trace.h */
    SC_TRI_TEST_COUNT
} sc_tri_test;

/* How hard the builder works for a tree that traces faster. */
typedef enum sc_build_quality {
    SC_BUILD_QUALITY_MEDIUM = 0,  /* binned SAH (32 bins by default) */
    SC_BUILD_QUALITY_HIGH,        /* SAH with spatial splits (Stich et al. 2009: large triangles cut
                                     into parts, each in its own leaf, at most 20 % more leaf
                                     slots), then reinsertion (Bittner et al. 2013: the inner nodes
                                     rearranged for a lower SAH cost); a longer build; the
                                     same hits as medium */
    SC_BUILD_QUALITY_AUTO,        /* high where the scene has large triangles, else medium: high
                                     when the boxes of the triangles that each cover more than
                                     1/1000 of the scene box's area add up to 3 or more times
                                     that area (a random line through the scene then passes
                                     through several large triangles' boxes, the overlap that
                                     spatial splits remove: architectural and CAD scenes), medium
                                     for scanned and tessellated meshes, where the high build
                                     costs 1.5-5x the time for nothing; sc_bvh_info.quality says
                                     which was built */
    SC_BUILD_QUALITY_COUNT
} sc_build_quality;

typedef struct sc_bvh_config {
    int leaf_size;               /* 1..SC_BVH_MAX_LEAF: most triangles per leaf */
    sc_prefilter_mode prefilter;
    sc_tri_test tri_test;
    int sah_bins;                /* 4..64 */
    float traversal_cost;        /* SAH cost of a node visit, relative to one leaf block test */
    int threads;                 /* build threads: 1 = the calling thread only (default),
                                    0 = one per online CPU, n = at most n; the tree is the
                                    same for every value */
    sc_build_quality quality;    /* default SC_BUILD_QUALITY_AUTO */
} sc_bvh_config;

typedef struct sc_bvh_info {
    size_t triangles;            /* in the tree */
    size_t skipped_triangles;    /* non-finite, left out */
    size_t nodes;                /* 8-wide inner nodes */
    size_t leaves;
    size_t leaves_with_spheres;  /* all leaves for circum/minimal/compact, the chosen ones for auto */
    size_t node_bytes;
    size_t leaf_bytes;           /* vertices + primitive ids + spheres + alignment */
    size_t sphere_bytes;         /* the part of leaf_bytes that holds spheres or summaries */
    size_t total_bytes;          /* everything the handle owns */
    int depth;                   /* of the 8-wide tree, root = 1 */
    double sah_cost;             /* of the 8-wide tree, in the config's cost units */
    double build_seconds;
    sc_prefilter_mode prefilter;
    int leaf_size;
    double built_sah_cost;       /* sah_cost when built; after sc_bvh_refit, sah_cost is the refitted
                                    tree's (their ratio: how far the tree has drifted from a fresh build) */
    sc_build_quality quality;    /* the quality built: medium or high (SC_BUILD_QUALITY_AUTO's choice) */
} sc_bvh_info;

typedef struct sc_bvh sc_bvh;

SC_API void sc_bvh_config_default(sc_bvh_config *cfg);

/* Threads: sc_bvh_build, sc_bvh_free and sc_bvh_get_info are reentrant. Any
 * number of threads may build and free distinct BVHs at once, while others
 * trace theirs (sc_trace.h). With cfg->threads != 1 the build starts up to
 * that many - 1 POSIX threads of its own for large subtrees and joins them
 * before it returns (no pool survives the call); the tree is bit for bit
 * the one a single thread builds. The input arrays are only read. A BVH may
 * be freed only when no thread traces it any more.
 *
 * mesh: a view of the caller's vertex and index arrays (sc_mesh.h; strides
 * allowed), each index < vertex_count; triangle_count may be 0 (every ray
 * misses; the arrays may then be NULL). cfg NULL: sc_bvh_config_default.
 * Errors: INVALID_ARGUMENT (NULL, bad layout, index out of range, bad config),
 * LIMIT (more than 2^31 triangles), OUT_OF_MEMORY.
 * Which kernels traverse the tree is not the BVH's business: the ISA level
 * (sc_isa.h) is chosen once for the whole library. */
SC_API sc_status sc_bvh_build(const sc_mesh_view *mesh, const sc_bvh_config *cfg, sc_bvh **out);
SC_API void sc_bvh_free(sc_bvh *bvh);

/* Refit after the mesh's vertices moved, its triangles the same: every box,
 * vertex row and sphere (or summary) of the tree recomputed bottom-up from
 * mesh (the same triangle count and indices the BVH was built from, new
 * positions), the tree itself kept. The result answers every ray exactly
 * as a fresh build over the new vertices does (the same hits, bit for bit,
 * except that SC_TRI_EXACT's rounded t, u, v may differ in the last bits; the
 * same guarantees: conservative boxes, spheres that contain their
 * triangles); only the work per ray can grow, as sc_bvh_info.sah_cost
 * against built_sah_cost says (sc_accel.h rebuilds past a measured
 * growth). Errors, the BVH left as it was: INVALID_ARGUMENT (NULL, another
 * triangle count, bad layout, index out of range), NONFINITE (a triangle
 * with a non-finite vertex now, or one left out of the build for it:
 * rebuild). Threads: no thread may trace the BVH during a refit; a tree of
 * 65,536 triangles or more is refitted on the configuration's build threads
 * (sc_bvh_config.threads), with the same result for any number of them. */
SC_API sc_status sc_bvh_refit(sc_bvh *bvh, const sc_mesh_view *mesh);
SC_API sc_status sc_bvh_get_info(const sc_bvh *bvh, sc_bvh_info *info);

/* "off", "circum", "minimal", "auto", "compact"; "watertight", "moller", "exact". */
SC_API const char *sc_prefilter_mode_name(sc_prefilter_mode mode);
SC_API sc_status sc_prefilter_mode_from_name(const char *name, sc_prefilter_mode *out);
SC_API const char *sc_tri_test_name(sc_tri_test test);
SC_API sc_status sc_tri_test_from_name(const char *name, sc_tri_test *out);

#ifdef __cplusplus
}
#endif
#endif

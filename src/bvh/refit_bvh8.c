/* Refit: the tree of a build kept, every box, vertex row and sphere
 * recomputed from the meshes' current vertices, bottom-up. The leaves hold
 * the same triangles, so a tree fitted to the new vertices is exactly as
 * conservative as a fresh build (exact float min/max boxes, spheres padded
 * as the builder pads them); only its SAH cost can grow, which sah_cost
 * reports against built_sah_cost. */
#include <math.h>
#include <string.h>

#include "build_internal.h"

typedef struct refit_ctx {
    bvh_builder B;
    double sah;   /* not yet divided by the root's area */
} refit_ctx;

static box3 refit_node(refit_ctx *R, size_t offset)
{
    sc_bvh_node8 *node = (sc_bvh_node8 *)(void *)((unsigned char *)R->B.bvh->nodes + offset);
    box3 all;
    box_empty(&all);
    for (int i = 0; i < SC_BVH_N; i++) {
        const uint64_t c = node->child[i];
        box3 b;
        box_empty(&b);
        if (c && sc_ref_is_leaf(c)) {
            sc_leaf_refit(&R->B, c, &b);
            R->sah += (double)box_area(&b) * leaf_blocks(sc_ref_count(c));
        } else if (c) {
            b = refit_node(R, sc_ref_offset(c));
        }
        for (int k = 0; k < 3; k++) {
            node->b[2 * k][i] = b.lo[k];
            node->b[2 * k + 1][i] = b.hi[k];
        }
        box_grow(&all, &b);
    }
    R->sah += (double)R->B.cfg->traversal_cost * box_area(&all);
    return all;
}

sc_status sc_bvh_refit_set(sc_bvh *bvh, const sc_mesh_view *meshes, size_t mesh_count)
{
    if (!bvh || !meshes || mesh_count != bvh->mesh_count)
        return SC_ERR_INVALID_ARGUMENT;
    /* Everything is checked before anything is written: a refit that
     * fails leaves the tree as it was. */
    for (size_t g = 0; g < mesh_count; g++) {
        const sc_mesh_view *m = &meshes[g];
        if (sc_bvh_check_mesh(m) != SC_OK || m->triangle_count != (size_t)(bvh->first[g + 1] - bvh->first[g]))
            return SC_ERR_INVALID_ARGUMENT;
        for (size_t t = 0; t < m->triangle_count; t++) {
            const uint32_t *ix = sc_mesh_triangle(m, t);
            for (int corner = 0; corner < 3; corner++) {
                const float *p = sc_mesh_vertex(m, ix[corner]);
                if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2]))
                    return SC_ERR_NONFINITE;
            }
        }
    }
    /* A triangle left out of the build (non-finite then) has no leaf to go
     * back into: only a rebuild can add it. */
    if (bvh->skipped)
        return SC_ERR_NONFINITE;
    if (!bvh->has_root)
        return SC_OK;
    refit_ctx R = { .B = { .cfg = &bvh->cfg, .meshes = meshes, .mesh_count = mesh_count, .first = bvh->first,
                           .bvh = bvh } };
    const box3 root = refit_node(&R, 0);
    float area = box_area(&root);
    if (!(area > 0))
        area = 1;
    for (int k = 0; k < 3; k++)
        bvh->root_lo[k] = root.lo[k], bvh->root_hi[k] = root.hi[k];
    bvh->sah_cost = R.sah / area;
    return SC_OK;
}

sc_status sc_bvh_refit(sc_bvh *bvh, const sc_mesh_view *mesh)
{
    if (!mesh)
        return SC_ERR_INVALID_ARGUMENT;
    return sc_bvh_refit_set(bvh, mesh, 1);
}

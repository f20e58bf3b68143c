/* Public entry points: argument checks, then the traversal kernels of the
 * active ISA level (src/isa) for the BVH's triangle test. A NULL stats
 * pointer selects the kernel compiled without counters. */
#include "bvh/bvh_internal.h"
#include "isa/isa_dispatch.h"
#include "ray_setup.h"

sc_status sc_trace_closest(const sc_bvh *bvh, const sc_ray *ray, sc_hitrec *hit, sc_trace_stats *stats)
{
    if (!bvh || !ray || !hit || !sc_ray_valid(ray))
        return SC_ERR_INVALID_ARGUMENT;
    const sc_trace_kernels *k = &sc_kernels_active()->trace[bvh->cfg.tri_test];
    if (stats)
        k->closest_stats(bvh, ray, hit, stats);
    else
        k->closest(bvh, ray, hit);
    return SC_OK;
}

sc_status sc_trace_any(const sc_bvh *bvh, const sc_ray *ray, int *occluded, sc_trace_stats *stats)
{
    if (!bvh || !ray || !occluded || !sc_ray_valid(ray))
        return SC_ERR_INVALID_ARGUMENT;
    const sc_trace_kernels *k = &sc_kernels_active()->trace[bvh->cfg.tri_test];
    *occluded = stats ? k->any_stats(bvh, ray, stats) : k->any(bvh, ray);
    return SC_OK;
}

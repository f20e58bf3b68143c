/* The sphere kernels of one ISA level: batch spheres and reject masks.
 * The ISA dispatch (src/isa/isa_dispatch.h) pairs each with the traversal
 * kernels of the same level. Private to the library, the tests and the
 * benchmarks. */
#ifndef SPHERECULL_SIMD_SPHERE_KERNELS_H
#define SPHERECULL_SIMD_SPHERE_KERNELS_H

#include <stddef.h>
#include <stdint.h>

#include "spherecull/sc_simd.h"

/* Triangles from a vertex + index buffer (indices != NULL) or SoA arrays. */
typedef struct sc_tri_source_f {
    const float *vertices;
    size_t vertex_count;
    const uint32_t *indices;
    const float *soa[3][3];                   /* [vertex][axis] */
} sc_tri_source_f;
typedef struct sc_tri_source_d {
    const double *vertices;
    size_t vertex_count;
    const uint32_t *indices;
    const double *soa[3][3];
} sc_tri_source_d;

/* Benchmark and test switches (the public API passes 0):
 *  NO_PRESCALE  the general path skips the power-of-two prescaling, to
 *               measure what it costs (float then only covers triangle
 *               sizes of about 1e-6..1e6);
 *  GENERAL      the conservative kinds skip their fast path (every lane
 *               through the general one, as before the fast path);
 *  NO_STREAM    plain stores even for outputs past SC_STREAM_MIN_COUNT. */
enum { SC_KFLAG_NO_PRESCALE = 1u, SC_KFLAG_GENERAL = 2u, SC_KFLAG_NO_STREAM = 4u };

/* From this many triangles on (float: 2 MiB of output, past L2) the
 * results are written with streaming stores if the four output arrays are
 * aligned to the vector width. */
#define SC_STREAM_MIN_COUNT ((size_t)1 << 17)
/* Indexed input, batches past SC_STREAM_MIN_COUNT: vertices are prefetched
 * this many triangles ahead. */
#define SC_PREFETCH_AHEAD ((size_t)64)

typedef struct sc_sphere_kernels {
    /* Fills [0, sc_simd_padded(count)) of out; returns the number of
     * triangles with an out-of-range index. method/kind already checked. */
    size_t (*spheres_f)(const sc_tri_source_f *src, size_t count, int method, int kind,
                        unsigned flags, const sc_spheres_soaf *out);
    size_t (*spheres_d)(const sc_tri_source_d *src, size_t count, int method, int kind,
                        unsigned flags, const sc_spheres_soad *out);
    uint32_t (*reject4)(const sc_ray *ray, const sc_sphere_block4 *b);
    uint32_t (*reject8)(const sc_ray *ray, const sc_sphere_block8 *b);
    uint32_t (*reject16)(const sc_ray *ray, const sc_sphere_block16 *b);
    uint32_t (*packet8)(const sc_ray_packet8 *rays, const float c[3], float r2);
    uint32_t (*packet16)(const sc_ray_packet16 *rays, const float c[3], float r2);
} sc_sphere_kernels;

extern const sc_sphere_kernels sc_sphere_kernels_scalar;
#if defined(__x86_64__) || defined(__i386__)
extern const sc_sphere_kernels sc_sphere_kernels_sse4, sc_sphere_kernels_avx2, sc_sphere_kernels_avx512;
#endif

#endif

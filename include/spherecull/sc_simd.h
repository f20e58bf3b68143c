/* spherecull — SIMD kernels with run-time dispatch: batch bounding spheres
 * and ray-vs-sphere reject masks on scalar, SSE4.1, AVX2+FMA and AVX-512.
 *
 * ISA selection: sc_isa.h (one choice for every kernel of the library).
 *
 * Threads. Every batch and mask function may run from any number of
 * threads at once; the ISA choice is process-wide (sc_isa.h).
 *
 * MXCSR modes. The guarantees of the conservative kinds (every vertex inside)
 * and of the masks hold with gradual underflow and with FTZ|DAZ set in the
 * calling thread (sc_circumsphere.h, sc_prefilter.h), for every ISA. The
 * plain kinds (SC_BATCH_CIRCUM, SC_BATCH_MINIMAL) compute in the thread's
 * mode: with DAZ a subnormal input coordinate is read as 0 and the sphere is
 * that of the zeroed triangle, where the scalar sc_circumsphere_* /
 * sc_minimal_sphere_* return SC_ERR_RANGE.
 *
 * Batch spheres. Triangles come from a vertex buffer + index buffer or from
 * pre-gathered SoA arrays; spheres go to SoA arrays cx, cy, cz, r2 that the
 * caller allocates with room for sc_simd_padded(count) entries (a multiple
 * of 16). Entries [count, padded) are written as empty lanes (centre 0,
 * r2 = -1), so 16 consecutive entries copy straight into an
 * sc_sphere_block16 / two block8 / four block4.
 *
 * Results follow the scalar specification in sc_circumsphere.h: vertex C is
 * moved opposite the longest edge and the edges are prescaled by a power of
 * two. A triangle whose sphere cannot be formed (degenerate circumsphere,
 * non-finite input, overflow, out-of-range index) gets centre (0,0,0) and
 * r2 = +inf, a sphere that never rejects. SSE4.1 kernels round exactly like
 * the scalar specification; AVX2 and AVX-512 kernels use FMA, which changes
 * the last bits of centre and r2 but none of the guarantees of the
 * conservative kinds (every vertex inside, checked exactly in the tests).
 *
 * Large batches. From 131072 triangles on, output arrays aligned to 64
 * bytes are written with streaming stores (they bypass the caches, as a
 * large memcpy does), and indexed input prefetches the vertices of the
 * triangles 64 ahead. Results are the same bits either way.
 *
 * Example:
 *
 *   size_t cap = sc_simd_padded(ntri);
 *   float *buf = aligned_alloc(64, 4 * cap * sizeof(float));
 *   sc_spheres_soaf out = { buf, buf + cap, buf + 2 * cap, buf + 3 * cap };
 *   sc_status st = sc_spheres_indexed_f(verts, nverts, idx, ntri, SC_METHOD_TEXTBOOK,
 *                                       SC_BATCH_PREFILTER_MINIMAL, &out);
 */
#ifndef SPHERECULL_SC_SIMD_H
#define SPHERECULL_SC_SIMD_H

#include <stddef.h>
#include <stdint.h>
#include "sc_api.h"
#include "sc_circumsphere.h"
#include "sc_isa.h"
#include "sc_prefilter.h"
#include "sc_ray.h"
#include "sc_status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- batch spheres -------------------------------------------------------- */

typedef enum sc_batch_kind {
    SC_BATCH_CIRCUM = 0,          /* sc_circumsphere_*, C opposite the longest edge */
    SC_BATCH_MINIMAL,             /* sc_minimal_sphere_* */
    SC_BATCH_PREFILTER_CIRCUM,    /* sc_prefilter_sphere_* (SC_SPHERE_CIRCUM): conservative */
    SC_BATCH_PREFILTER_MINIMAL,   /* sc_prefilter_sphere_* (SC_SPHERE_MINIMAL): conservative */
    SC_BATCH_KIND_COUNT
} sc_batch_kind;

/* "circum", "minimal", "prefilter-circum", "prefilter-minimal". */
SC_API const char *sc_batch_kind_name(sc_batch_kind kind);
SC_API sc_status sc_batch_kind_from_name(const char *name, sc_batch_kind *out);

/* count rounded up to a multiple of 16 (the length every output array needs). */
SC_API size_t sc_simd_padded(size_t count);

typedef struct sc_spheres_soaf { float *cx, *cy, *cz, *r2; } sc_spheres_soaf;
typedef struct sc_spheres_soad { double *cx, *cy, *cz, *r2; } sc_spheres_soad;

/* Pre-gathered triangles: vertex k of triangle i is (x[k][i], y[k][i], z[k][i]). */
typedef struct sc_triangles_soaf { const float *x[3], *y[3], *z[3]; } sc_triangles_soaf;
typedef struct sc_triangles_soad { const double *x[3], *y[3], *z[3]; } sc_triangles_soad;

/* From a vertex buffer (x, y, z per vertex, tightly packed) and an index
 * buffer (3 per triangle). vertex_count <= SC_SIMD_MAX_VERTICES.
 * Errors: SC_ERR_INVALID_ARGUMENT for NULL pointers (with count > 0), a bad
 * enum, or any index >= vertex_count (all other triangles are still
 * computed; those get r2 = +inf); SC_ERR_LIMIT for too many vertices. */
#define SC_SIMD_MAX_VERTICES ((size_t)0x2aaaaaaa)   /* 3 * count fits an int32 offset */
SC_API sc_status sc_spheres_indexed_f(const float *vertices, size_t vertex_count, const uint32_t *indices,
                                      size_t triangle_count, sc_method method, sc_batch_kind kind,
                                      const sc_spheres_soaf *out);
SC_API sc_status sc_spheres_indexed_d(const double *vertices, size_t vertex_count, const uint32_t *indices,
                                      size_t triangle_count, sc_method method, sc_batch_kind kind,
                                      const sc_spheres_soad *out);
SC_API sc_status sc_spheres_soa_f(const sc_triangles_soaf *triangles, size_t triangle_count,
                                  sc_method method, sc_batch_kind kind, const sc_spheres_soaf *out);
SC_API sc_status sc_spheres_soa_d(const sc_triangles_soad *triangles, size_t triangle_count,
                                  sc_method method, sc_batch_kind kind, const sc_spheres_soad *out);

/* ---- one sphere against a packet of rays ---------------------------------- */

/* The packets sc_ray_packet8/16 are in sc_ray.h. */
/* Bit i set iff sc_ray_sphere_reject(ray i, c, r2) would reject: the same
 * conservative test, lane for lane and bit for bit. 0 if an argument is NULL
 * (rejecting nothing is always safe). */
SC_API uint32_t sc_reject_packet8(const sc_ray_packet8 *rays, const float c[3], float r2);
SC_API uint32_t sc_reject_packet16(const sc_ray_packet16 *rays, const float c[3], float r2);

#ifdef __cplusplus
}
#endif
#endif

/* spherecull — the drop-in sphere prefilter: one ray against a block of
 * 4, 8 or 16 bounding spheres at once, returning a reject mask.
 *
 * A set bit means "this ray certainly misses sphere i within [tmin, tmax]",
 * so the triangle inside need not be tested. The test is conservative: a ray
 * that truly hits a triangle contained in the sphere is never rejected, also
 * for origins far from the sphere, grazing rays and rounding in oc = O - c.
 * Every condition is written "reject iff ..." so NaN never rejects, and a
 * sphere with r2 = +inf (what the builders emit for bad triangles) never
 * rejects.
 *
 * Reject iff, with oc = O - c, dd = D.D, and u = 2^-24:
 *   |oc x D|^2 > (r2 (1 + 2^-10) + 1025 (8u)^2 |oc|^2) dd      (misses the line)
 *   or the sphere lies wholly before tmin or wholly beyond tmax along the ray,
 *   each decided with a rounding allowance on oc.D.
 *
 * Example (any tracer, e.g. inside an Embree user-geometry callback):
 *
 *   sc_sphere_block8 blk;                          // built once per leaf/cluster
 *   sc_sphere_block8_init(&blk);                   // all lanes r2 = -1: empty
 *   for (int i = 0; i < n; i++) sc_sphere_block8_set(&blk, i, &spheres[i]);
 *   ...
 *   sc_ray ray = { {ox, oy, oz}, tnear, {dx, dy, dz}, tfar };
 *   unsigned live = ~sc_reject8(&ray, &blk) & 0xffu;
 *   while (live) { int i = __builtin_ctz(live); live &= live - 1; test_triangle(i); }
 *
 * Empty lanes (r2 < 0) always reject, so partly filled blocks need no count.
 * The scalar definitions here are the specification; sc_reject* dispatch to
 * the best SIMD kernel for this CPU (see sc_simd.h).
 *
 * MXCSR modes. The test is conservative with gradual underflow and with
 * flush-to-zero / denormals-are-zero (FTZ|DAZ) set in the calling thread:
 * nothing is rejected unless dd = D.D, the allowance (about r2) and
 * reach = allowance * dd are all >= 2^-100, and above that the absolute
 * error of a flushed or zeroed subnormal (< 2^-126 per operation) is far
 * inside the relative margins (docs/numerics.md, "Flush-to-zero and
 * denormals-are-zero"). A sphere from the builders (r2 >= 2^-122) is read
 * the same in both modes.
 *
 * Threads. Every function here is reentrant and touches only its arguments
 * (plus the kernel table, chosen once, atomically, see sc_simd.h): any
 * number of threads may test rays against the same blocks at once.
 * Writing a block (sc_sphere_block*_init / _set) while another thread reads
 * it is a data race, as for any plain struct.
 */
#ifndef SPHERECULL_SC_PREFILTER_H
#define SPHERECULL_SC_PREFILTER_H

#include <stdint.h>
#include "sc_api.h"
#include "sc_circumsphere.h"
#include "sc_ray.h"

#ifdef __cplusplus
extern "C" {
#endif

/* SoA sphere blocks. An empty lane has r2 < 0 and is always rejected. */
typedef struct sc_sphere_block4 {
    SC_ALIGNAS(16) float cx[4];
    float cy[4], cz[4], r2[4];
} sc_sphere_block4;
typedef struct sc_sphere_block8 {
    SC_ALIGNAS(32) float cx[8];
    float cy[8], cz[8], r2[8];
} sc_sphere_block8;
typedef struct sc_sphere_block16 {
    SC_ALIGNAS(64) float cx[16];
    float cy[16], cz[16], r2[16];
} sc_sphere_block16;

SC_STATIC_ASSERT(sizeof(sc_sphere_block4) == 64, "block4 is one cache line");
SC_STATIC_ASSERT(sizeof(sc_sphere_block8) == 128, "block8 is two cache lines");
SC_STATIC_ASSERT(sizeof(sc_sphere_block16) == 256, "block16 is four cache lines");

SC_API void sc_sphere_block4_init(sc_sphere_block4 *b);
SC_API void sc_sphere_block8_init(sc_sphere_block8 *b);
SC_API void sc_sphere_block16_init(sc_sphere_block16 *b);
SC_API void sc_sphere_block4_set(sc_sphere_block4 *b, int lane, const sc_spheref *s);
SC_API void sc_sphere_block8_set(sc_sphere_block8 *b, int lane, const sc_spheref *s);
SC_API void sc_sphere_block16_set(sc_sphere_block16 *b, int lane, const sc_spheref *s);

/* The scalar specification of one lane: 1 = reject. */
SC_API int sc_ray_sphere_reject(const sc_ray *ray, const float c[3], float r2);

/* Reject masks, bit i for lane i; dispatched to the best ISA. */
SC_API uint32_t sc_reject4(const sc_ray *ray, const sc_sphere_block4 *b);
SC_API uint32_t sc_reject8(const sc_ray *ray, const sc_sphere_block8 *b);
SC_API uint32_t sc_reject16(const sc_ray *ray, const sc_sphere_block16 *b);

#ifdef __cplusplus
}
#endif
#endif

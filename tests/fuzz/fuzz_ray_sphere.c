/* libFuzzer target: no false reject by the sphere prefilter.
 *
 * From the input: a float triangle, a ray (origin, direction, [tmin, tmax])
 * and a sphere kind/method. The conservative prefilter sphere of the
 * triangle is built with sc_prefilter_sphere_f; whenever the exact MPFR
 * oracle (sc_ref_ray_triangle) says the ray hits the triangle, the scalar
 * specification sc_ray_sphere_reject and every dispatched kernel
 * (sc_reject4/8/16 and the packet kernels, on every ISA this CPU runs) must
 * keep the sphere. Also, on every ISA: empty lanes (r2 < 0) always reject
 * and an r2 = +inf sphere never rejects.
 *
 * Layout: byte 0 kind/method/lane, byte 1 mode, then 17 floats: A, B, C,
 * origin, direction, tmin, tmax, then two 16-bit barycentric weights.
 * Mode bit 0 aims the ray at the point of the triangle with those weights
 * (otherwise hits are too rare to exercise anything); bit 1 makes the
 * interval [0, +inf); bit 2 scales the triangle by 2^(byte - 128) from a
 * last byte (1e-30 .. 1e30 coordinates without relying on bit flips). */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sc_ref_ray.h"
#include "spherecull/sc_circumsphere.h"
#include "spherecull/sc_prefilter.h"
#include "spherecull/sc_simd.h"

static void require_at(int ok, const char *what, int line)
{
    if (!ok) {
        fprintf(stderr, "fuzz_ray_sphere: requirement '%s' at line %d failed\n", what, line);
        abort();
    }
}
#define require(ok) require_at((ok), #ok, __LINE__)

static int all_finite(const float *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

/* Lane `lane` holds s, lane+1 an empty slot, lane+2 an infinite sphere. */
#define FILL_BLOCK(blk, N, lane, s)                                                    \
    do {                                                                               \
        sc_sphere_block##N##_init(&blk);                                               \
        sc_sphere_block##N##_set(&blk, (lane) % N, &s);                                \
        sc_spheref inf_ = { { 0, 0, 0 }, INFINITY };                                   \
        sc_sphere_block##N##_set(&blk, ((lane) + 2) % N, &inf_);                       \
    } while (0)

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    uint8_t buf[2 + 17 * 4 + 4 + 1] = { 0 };
    memcpy(buf, data, size < sizeof buf ? size : sizeof buf);
    float f[17];
    memcpy(f, buf + 2, sizeof f);
    uint16_t wu, wv;
    memcpy(&wu, buf + 2 + sizeof f, 2);
    memcpy(&wv, buf + 4 + sizeof f, 2);
    uint8_t sel = buf[0], mode = buf[1], scale_byte = buf[sizeof buf - 1];

    float A[3] = { f[0], f[1], f[2] }, B[3] = { f[3], f[4], f[5] }, C[3] = { f[6], f[7], f[8] };
    if (mode & 4) {
        int e = (int)scale_byte - 128;
        for (int k = 0; k < 3; k++) {
            A[k] = ldexpf(A[k], e);
            B[k] = ldexpf(B[k], e);
            C[k] = ldexpf(C[k], e);
        }
    }
    sc_ray ray = { { f[9], f[10], f[11] }, f[15], { f[12], f[13], f[14] }, f[16] };
    if (mode & 1) {
        /* Aim at A + u (B - A) + v (C - A), u + v <= 1; rounding may still
         * make it miss, the oracle decides. */
        double u = wu / 65535.0, v = wv / 65535.0;
        if (u + v > 1) {
            u = 1 - u;
            v = 1 - v;
        }
        for (int k = 0; k < 3; k++) {
            double p = A[k] + u * ((double)B[k] - A[k]) + v * ((double)C[k] - A[k]);
            ray.dir[k] = (float)(p - ray.org[k]);
        }
    }
    if (mode & 2) {
        ray.tmin = 0;
        ray.tmax = INFINITY;
    }

    sc_sphere_kind kind = (sc_sphere_kind)(sel % SC_SPHERE_KIND_COUNT);
    sc_method method = (sc_method)((sel >> 1) % SC_METHOD_COUNT);
    int lane = sel >> 3;
    sc_spheref s;
    require(sc_prefilter_sphere_f(A, B, C, kind, method, &s) == SC_OK);

    int hit = 0;
    float tri[9] = { A[0], A[1], A[2], B[0], B[1], B[2], C[0], C[1], C[2] };
    if (all_finite(tri, 9) && all_finite(ray.org, 3) && all_finite(ray.dir, 3) &&
        !isnan(ray.tmin) && !isnan(ray.tmax)) {
        double O[3] = { ray.org[0], ray.org[1], ray.org[2] };
        double D[3] = { ray.dir[0], ray.dir[1], ray.dir[2] };
        double Ad[3] = { A[0], A[1], A[2] }, Bd[3] = { B[0], B[1], B[2] }, Cd[3] = { C[0], C[1], C[2] };
        hit = sc_ref_ray_triangle(O, D, ray.tmin, ray.tmax, Ad, Bd, Cd, NULL);
    }
    if (hit)
        require(!sc_ray_sphere_reject(&ray, s.c, s.r2));
    static const float origin[3] = { 0, 0, 0 };
    require(!sc_ray_sphere_reject(&ray, origin, INFINITY));

    sc_isa active = sc_isa_active();
    for (int isa = 0; isa < SC_ISA_COUNT; isa++) {
        if (sc_isa_force((sc_isa)isa) != SC_OK)
            continue;
        sc_sphere_block4 b4;
        sc_sphere_block8 b8;
        sc_sphere_block16 b16;
        FILL_BLOCK(b4, 4, lane, s);
        FILL_BLOCK(b8, 8, lane, s);
        FILL_BLOCK(b16, 16, lane, s);
        uint32_t m4 = sc_reject4(&ray, &b4), m8 = sc_reject8(&ray, &b8), m16 = sc_reject16(&ray, &b16);
        if (hit) {
            require(!(m4 >> (lane % 4) & 1));
            require(!(m8 >> (lane % 8) & 1));
            require(!(m16 >> (lane % 16) & 1));
        }
        require(m4 >> ((lane + 1) % 4) & 1);
        require(m8 >> ((lane + 1) % 8) & 1);
        require(m16 >> ((lane + 1) % 16) & 1);
        require(!(m4 >> ((lane + 2) % 4) & 1));
        require(!(m8 >> ((lane + 2) % 8) & 1));
        require(!(m16 >> ((lane + 2) % 16) & 1));

        /* The same ray in one lane of a packet; the other lanes NaN rays,
         * which never reject. */
        sc_ray_packet8 p8;
        sc_ray_packet16 p16;
        float *f8[8] = { p8.ox, p8.oy, p8.oz, p8.tmin, p8.dx, p8.dy, p8.dz, p8.tmax };
        float *f16[8] = { p16.ox, p16.oy, p16.oz, p16.tmin, p16.dx, p16.dy, p16.dz, p16.tmax };
        const float r[8] = { ray.org[0], ray.org[1], ray.org[2], ray.tmin,
                             ray.dir[0], ray.dir[1], ray.dir[2], ray.tmax };
        for (int k = 0; k < 8; k++)
            for (int i = 0; i < 16; i++) {
                if (i < 8)
                    f8[k][i] = i == lane % 8 ? r[k] : NAN;
                f16[k][i] = i == lane % 16 ? r[k] : NAN;
            }
        uint32_t q8 = sc_reject_packet8(&p8, s.c, s.r2), q16 = sc_reject_packet16(&p16, s.c, s.r2);
        if (hit) {
            require(!(q8 >> (lane % 8) & 1));
            require(!(q16 >> (lane % 16) & 1));
        }
        require((q8 & ~(1u << (lane % 8))) == 0);
        require((q16 & ~(1u << (lane % 16))) == 0);
    }
    sc_isa_force(active);
    return 0;
}

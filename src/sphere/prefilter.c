/* The scalar specification of the ray-vs-sphere reject test, and block set-up.
 * SIMD kernels in src/simd/ must agree with sc_ray_sphere_reject lane by lane. */
#include <float.h>
#include <math.h>

#include "spherecull/sc_prefilter.h"

#define U (FLT_EPSILON / 2)

int sc_ray_sphere_reject(const sc_ray *ray, const float c[3], float r2)
{
    if (r2 < 0)                       /* empty lane */
        return 1;
    const float *O = ray->org, *D = ray->dir;
    float oc[3] = { O[0] - c[0], O[1] - c[1], O[2] - c[2] };
    float dd = D[0] * D[0] + D[1] * D[1] + D[2] * D[2];
    float ococ = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2];
    float x[3] = { oc[1] * D[2] - oc[2] * D[1], oc[2] * D[0] - oc[0] * D[2],
                   oc[0] * D[1] - oc[1] * D[0] };
    float cross2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
    /* The second term covers the absolute rounding of oc, which grows with
     * the distance to the sphere while r2 does not (docs/numerics.md). */
    float allowance = r2 * (1 + 0x1p-10f) + 1025 * (8 * U) * (8 * U) * ococ;
    float reach = allowance * dd;                 /* >= (r |D|)^2 */
    /* With dd, allowance or reach below 2^-100 the products behind them may
     * be subnormal (|D| < 2^-50, or r |D| < 2^-50): their absolute error is
     * no longer covered by the relative margins, so nothing is rejected.
     * Above it, an absolute error of up to 2^-126 per operation — what
     * gradual underflow (2^-150) and flush-to-zero / denormals-are-zero
     * (MXCSR FTZ|DAZ: a subnormal result or operand becomes 0) leave — is
     * below 2^-70 of the terms it touches, far inside the 2^-10 margins.
     * allowance >= 2^-100 also covers an r2 that DAZ reads as 0 (r2 <
     * 2^-126): the r2 lost is below 2^-26 of the allowance. The sphere
     * builders never emit such an r2 (their r2 >= 2^-122, sc_circumsphere.h). */
    if (!(dd >= 0x1p-100f && allowance >= 0x1p-100f && reach >= 0x1p-100f))
        return 0;
    if (cross2 > reach)
        return 1;

    /* Along the ray the sphere spans dd*t in [-b - r|D|, -b + r|D|], b = oc.D.
     * slack bounds the rounding of b (and of t*dd) so the interval tests
     * below can only err towards keeping the sphere. */
    float b = oc[0] * D[0] + oc[1] * D[1] + oc[2] * D[2];
    float babs = fabsf(oc[0] * D[0]) + fabsf(oc[1] * D[1]) + fabsf(oc[2] * D[2]);
    float before = b + ray->tmin * dd;            /* > 0: centre before tmin */
    float slack_min = 8 * U * (babs + fabsf(ray->tmin) * dd);
    float m = before - slack_min;
    if (m > 0 && m * m > reach)
        return 1;
    float beyond = -b - ray->tmax * dd;           /* > 0: centre beyond tmax */
    float slack_max = 8 * U * (babs + fabsf(ray->tmax) * dd);
    float p = beyond - slack_max;
    if (p > 0 && p * p > reach)
        return 1;
    return 0;
}

#define DEFINE_BLOCK(W)                                                          \
    void sc_sphere_block##W##_init(sc_sphere_block##W *blk)                     \
    {                                                                            \
        for (int i = 0; i < W; i++) {                                            \
            blk->cx[i] = blk->cy[i] = blk->cz[i] = 0;                            \
            blk->r2[i] = -1;                                                     \
        }                                                                        \
    }                                                                            \
    void sc_sphere_block##W##_set(sc_sphere_block##W *blk, int lane, const sc_spheref *s) \
    {                                                                            \
        if (lane < 0 || lane >= W || !s)                                         \
            return;                                                              \
        blk->cx[lane] = s->c[0], blk->cy[lane] = s->c[1], blk->cz[lane] = s->c[2]; \
        blk->r2[lane] = s->r2;                                                   \
    }
DEFINE_BLOCK(4)
DEFINE_BLOCK(8)
DEFINE_BLOCK(16)

/* libFuzzer target: the triangle-sphere API on arbitrary float and double bits.
 *
 * Whatever the bits, every call returns a status, never a NaN sphere, and the
 * conservative prefilter sphere contains every finite vertex exactly (or has
 * r2 = +inf). Input: 9 floats then 9 doubles (missing bytes read as zero),
 * the first byte also picks method and kind. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "sc_reference.h"
#include "spherecull/sc_circumsphere.h"

#include <stdio.h>

static void require_at(int ok, int line)
{
    if (!ok) {
        fprintf(stderr, "fuzz_circumsphere: requirement at line %d failed\n", line);
        abort();
    }
}
#define require(ok) require_at((ok), __LINE__)

static int finite3(const double v[3])
{
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    uint8_t buf[9 * sizeof(float) + 9 * sizeof(double)] = { 0 };
    memcpy(buf, data, size < sizeof buf ? size : sizeof buf);
    float F[3][3];
    double D[3][3];
    memcpy(F, buf, sizeof F);
    memcpy(D, buf + sizeof F, sizeof D);
    sc_method method = (sc_method)(buf[0] % SC_METHOD_COUNT);
    sc_sphere_kind kind = (sc_sphere_kind)((buf[0] >> 2) % SC_SPHERE_KIND_COUNT);
    sc_origin origin = (sc_origin)((buf[0] >> 3) % SC_ORIGIN_COUNT);

    sc_spheref sf;
    sc_status st = sc_circumsphere_f(F[0], F[1], F[2], method, origin, &sf);
    require(st == SC_OK || st == SC_ERR_DEGENERATE || st == SC_ERR_NONFINITE || st == SC_ERR_RANGE);
    require(!isnan(sf.r2) && !isnan(sf.c[0]) && !isnan(sf.c[1]) && !isnan(sf.c[2]));
    st = sc_minimal_sphere_f(F[0], F[1], F[2], method, origin, &sf);
    require(st == SC_OK || st == SC_ERR_NONFINITE || st == SC_ERR_RANGE);
    require(!isnan(sf.r2));

    require(sc_prefilter_sphere_f(F[0], F[1], F[2], kind, method, &sf) == SC_OK);
    require(!isnan(sf.r2));
    double c[3] = { sf.c[0], sf.c[1], sf.c[2] };
    for (int k = 0; k < 3; k++) {
        double V[3] = { F[k][0], F[k][1], F[k][2] };
        if (finite3(V))
            require(sc_ref_contains(V, c, sf.r2));
    }

    sc_sphered sd;
    st = sc_circumsphere_d(D[0], D[1], D[2], method, origin, &sd);
    require(st == SC_OK || st == SC_ERR_DEGENERATE || st == SC_ERR_NONFINITE || st == SC_ERR_RANGE);
    require(!isnan(sd.r2));
    require(sc_prefilter_sphere_d(D[0], D[1], D[2], kind, method, &sd) == SC_OK);
    for (int k = 0; k < 3; k++)
        if (finite3(D[k]))
            require(sc_ref_contains(D[k], sd.c, sd.r2));
    return 0;
}

/* A program outside the tree, as a user writes it: builds a BVH over a unit
 * cube and traces rays whose answers are known exactly (the cube's faces
 * lie on the coordinate planes x, y, z = 0 and 1 and every ray below meets
 * them at a t that is a small dyadic number), with single rays, packets and
 * a stream, on every ISA level this CPU has; and the circumsphere of a
 * right triangle, whose centre is the hypotenuse's midpoint. Exits 1 with
 * one line per failed check. Built against the installed package by
 * tests/package (find_package and pkg-config) and, in the core-only build,
 * against the in-tree shared library. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include <spherecull.h>

static int failures;
#define CHECK(cond)                                                            \
    do {                                                                       \
        if (!(cond)) {                                                         \
            fprintf(stderr, "consumer: %s:%d: check failed: %s\n", __FILE__,   \
                    __LINE__, #cond);                                          \
            failures++;                                                        \
        }                                                                      \
    } while (0)

static const float cube_pos[8 * 3] = {
    0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, /* z = 0 */
    0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1, /* z = 1 */
};
static const uint32_t cube_idx[12 * 3] = {
    0, 1, 2, 0, 2, 3, /* z = 0: triangles 0, 1 */
    4, 6, 5, 4, 7, 6, /* z = 1: 2, 3 */
    0, 5, 1, 0, 4, 5, /* y = 0: 4, 5 */
    3, 2, 6, 3, 6, 7, /* y = 1: 6, 7 */
    0, 3, 7, 0, 7, 4, /* x = 0: 8, 9 */
    1, 5, 6, 1, 6, 2, /* x = 1: 10, 11 */
};

/* The hit point from the reported triangle and barycentrics. */
static void hit_point(const sc_hitrec *h, float p[3])
{
    const float *a = cube_pos + 3 * cube_idx[3 * h->prim];
    const float *b = cube_pos + 3 * cube_idx[3 * h->prim + 1];
    const float *c = cube_pos + 3 * cube_idx[3 * h->prim + 2];
    for (int k = 0; k < 3; k++)
        p[k] = (1 - h->u - h->v) * a[k] + h->u * b[k] + h->v * c[k];
}

/* Ray i of 16 towards the z = 0 face from z = -2: a 4x4 grid of points
 * strictly inside the face's two triangles (off the diagonal). */
static sc_ray face_ray(int i)
{
    float x = 0.125f + 0.25f * (float)(i % 4), y = 0.0625f + 0.25f * (float)(i / 4);
    sc_ray r = { { x, y, -2.0f }, 0.0f, { 0.0f, 0.0f, 1.0f }, INFINITY };
    return r;
}

static void check_bvh(const sc_bvh *bvh)
{
    sc_hitrec h;
    int occ = -1;

    /* Straight at the z = 0 face: t = 2 exactly, on triangle 0 or 1. */
    sc_ray r = { { 0.25f, 0.5f, -2.0f }, 0.0f, { 0.0f, 0.0f, 1.0f }, INFINITY };
    CHECK(sc_trace_closest(bvh, &r, &h, NULL) == SC_OK);
    CHECK(h.t == 2.0f && (h.prim == 0 || h.prim == 1));
    /* Both triangles of the face have (V1 - V0) x (V2 - V0) = (0, 0, 1). */
    CHECK(h.ng[0] == 0.0f && h.ng[1] == 0.0f && h.ng[2] == 1.0f);
    CHECK(h.geom == 0 && h.inst == SC_INVALID_ID);
    if (h.prim != SC_HITREC_MISS) {
        float p[3];
        hit_point(&h, p);
        CHECK(fabsf(p[0] - 0.25f) < 1e-6f && fabsf(p[1] - 0.5f) < 1e-6f && p[2] == 0.0f);
    }
    /* The segment ends before the face: no hit, not occluded; longer: occluded. */
    r.tmax = 1.5f;
    CHECK(sc_trace_closest(bvh, &r, &h, NULL) == SC_OK && h.prim == SC_HITREC_MISS);
    CHECK(sc_trace_any(bvh, &r, &occ, NULL) == SC_OK && occ == 0);
    r.tmax = 3.0f;
    CHECK(sc_trace_any(bvh, &r, &occ, NULL) == SC_OK && occ == 1);

    /* From the centre along +x with |D| = 2: the x = 1 face at t = 1/4. */
    sc_ray in = { { 0.5f, 0.5f, 0.25f }, 0.0f, { 2.0f, 0.0f, 0.0f }, INFINITY };
    CHECK(sc_trace_closest(bvh, &in, &h, NULL) == SC_OK);
    CHECK(h.t == 0.25f && (h.prim == 10 || h.prim == 11));

    /* Beside the cube: a miss. */
    sc_ray out = { { 2.0f, 2.0f, 2.0f }, 0.0f, { 1.0f, 0.0f, 0.0f }, INFINITY };
    CHECK(sc_trace_closest(bvh, &out, &h, NULL) == SC_OK && h.prim == SC_HITREC_MISS);
    CHECK(h.geom == SC_INVALID_ID && h.ng[0] == 0.0f && h.ng[1] == 0.0f && h.ng[2] == 0.0f);

    /* A NaN direction is refused with a status, not a crash. */
    sc_ray bad = r;
    bad.dir[0] = NAN;
    CHECK(sc_trace_closest(bvh, &bad, &h, NULL) == SC_ERR_INVALID_ARGUMENT);

    /* A packet of 16 and a stream: every lane at t = 2 on the face, the same
     * triangle the single-ray call reports. */
    sc_ray_packet16 pk;
    sc_hit_packet16 ph;
    int32_t valid[16];
    sc_ray rays[16];
    sc_hitrec single[16], stream[16];
    for (int i = 0; i < 16; i++) {
        rays[i] = face_ray(i);
        valid[i] = -1;
        pk.ox[i] = rays[i].org[0], pk.oy[i] = rays[i].org[1], pk.oz[i] = rays[i].org[2];
        pk.dx[i] = rays[i].dir[0], pk.dy[i] = rays[i].dir[1], pk.dz[i] = rays[i].dir[2];
        pk.tmin[i] = rays[i].tmin, pk.tmax[i] = rays[i].tmax;
        CHECK(sc_trace_closest(bvh, &rays[i], &single[i], NULL) == SC_OK);
        CHECK(single[i].t == 2.0f && single[i].prim == (rays[i].org[0] > rays[i].org[1] ? 0u : 1u));
    }
    CHECK(sc_trace_closest16(bvh, valid, &pk, &ph, NULL) == SC_OK);
    CHECK(sc_trace_closest_n(bvh, rays, sizeof rays[0], stream, sizeof stream[0], 16, 0, NULL) == SC_OK);
    for (int i = 0; i < 16; i++) {
        CHECK(ph.t[i] == single[i].t && ph.prim[i] == single[i].prim && ph.ng_z[i] == 1.0f);
        CHECK(memcmp(&stream[i], &single[i], sizeof single[i]) == 0);
    }
}

int main(void)
{
    CHECK(strcmp(sc_version_string(), SPHERECULL_VERSION_STRING) == 0);
    CHECK(sc_strerror(SC_ERR_OUT_OF_MEMORY) != NULL);

    /* Right angle at A: the circumcentre is the midpoint of BC. */
    const float A[3] = { 0, 0, 0 }, B[3] = { 2, 0, 0 }, C[3] = { 0, 2, 0 };
    sc_spheref s;
    CHECK(sc_circumsphere_f(A, B, C, SC_METHOD_PROJECTIVE_REDUCED, SC_ORIGIN_OPPOSITE_LONGEST, &s) == SC_OK);
    CHECK(fabsf(s.c[0] - 1) < 1e-6f && fabsf(s.c[1] - 1) < 1e-6f && fabsf(s.c[2]) < 1e-6f);
    CHECK(fabsf(s.r2 - 2) < 1e-5f);
    /* The conservative sphere contains the vertices (checked in double). */
    CHECK(sc_prefilter_sphere_f(A, B, C, SC_SPHERE_MINIMAL, SC_METHOD_PROJECTIVE_REDUCED, &s) == SC_OK);
    const float *v[3] = { A, B, C };
    for (int i = 0; i < 3; i++) {
        double d2 = 0;
        for (int k = 0; k < 3; k++)
            d2 += ((double)v[i][k] - s.c[k]) * ((double)v[i][k] - s.c[k]);
        CHECK(d2 <= s.r2);
    }

    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    sc_bvh *bvh = NULL;
    CHECK(sc_bvh_build(&(sc_mesh_view){ cube_pos, 8, cube_idx, 12, 0, 0 }, &cfg, &bvh) == SC_OK);
    if (!bvh)
        return 1;
    int levels = 0;
    for (int isa = 0; isa < SC_ISA_COUNT; isa++) {
        if (!sc_isa_supported((sc_isa)isa))
            continue;
        CHECK(sc_isa_force((sc_isa)isa) == SC_OK);
        check_bvh(bvh);
        levels++;
    }
    sc_bvh_free(bvh);
    CHECK(levels >= 1);
    if (failures)
        return 1;
    printf("consumer (C): spherecull %s, %d ISA levels, all checks passed\n", sc_version_string(), levels);
    return 0;
}

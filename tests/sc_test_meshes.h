/* Procedural meshes and the shared-scene loop of the oracle tests
 * (test_exact_tri.c, test_holes.c). Static: each test includes it once. */
#ifndef SC_TEST_MESHES_H
#define SC_TEST_MESHES_H

#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "spherecull/sc_rays.h"
#include "spherecull/sc_scene.h"

typedef struct mesh {
    float *pos;
    uint32_t *idx;
    uint32_t nv, nt;
} mesh;

static void mesh_free(mesh *m)
{
    free(m->pos), free(m->idx);
    memset(m, 0, sizeof *m);
}

/* A fixed rotation, a scale and an offset, so no coordinate is round and no
 * edge is axis-aligned: float rounding of the vertices relative to the
 * origin bites. scale 1 is exact, so it leaves p unscaled. */
static void place(double p[3], const double off[3], double scale)
{
    const double c1 = cos(0.7), s1 = sin(0.7), c2 = cos(1.1), s2 = sin(1.1);
    double x = c1 * p[0] - s1 * p[1], y = s1 * p[0] + c1 * p[1], z = p[2];
    p[0] = scale * x + off[0];
    p[1] = scale * (c2 * y - s2 * z) + off[1];
    p[2] = scale * (s2 * y + c2 * z) + off[2];
}

static void torus(mesh *m, int nu, int nv, const double off[3], double scale)
{
    m->nv = (uint32_t)(nu * nv), m->nt = (uint32_t)(2 * nu * nv);
    m->pos = malloc(3 * (size_t)m->nv * sizeof *m->pos);
    m->idx = malloc(3 * (size_t)m->nt * sizeof *m->idx);
    for (int i = 0; i < nu; i++)
        for (int j = 0; j < nv; j++) {
            double u = 6.283185307179586 * i / nu, v = 6.283185307179586 * j / nv;
            double p[3] = { (1 + 0.35 * cos(v)) * cos(u), (1 + 0.35 * cos(v)) * sin(u), 0.35 * sin(v) };
            place(p, off, scale);
            for (int k = 0; k < 3; k++)
                m->pos[3 * (size_t)(i * nv + j) + k] = (float)p[k];
        }
    size_t t = 0;
    for (int i = 0; i < nu; i++)
        for (int j = 0; j < nv; j++) {
            uint32_t a = (uint32_t)(i * nv + j), b = (uint32_t)(((i + 1) % nu) * nv + j),
                     c = (uint32_t)(((i + 1) % nu) * nv + (j + 1) % nv), d = (uint32_t)(i * nv + (j + 1) % nv);
            const uint32_t q[6] = { a, b, c, a, c, d };
            memcpy(m->idx + 3 * t, q, sizeof q);
            t += 2;
        }
}

/* A box with every face an n x n grid: flat fans and 90-degree creases.
 * lattice: integer vertices 0..n, unplaced, every quad split the same way
 * (exactly zero edge functions for lattice rays). Else placed (see place)
 * with extents 1.3 x 0.7 x 1.0, diagonals alternating, faces outward. */
static void grid_box(mesh *m, int n, int lattice)
{
    int s = n + 1;
    uint32_t *id = malloc((size_t)s * s * s * sizeof *id);
    m->nv = 0, m->nt = (uint32_t)(12 * n * n);
    m->pos = malloc(3 * (size_t)s * s * s * sizeof *m->pos);
    m->idx = malloc(3 * (size_t)m->nt * sizeof *m->idx);
    const double off[3] = { 0.9, 0.1, -2.3 }, ext[3] = { 1.3, 0.7, 1.0 };
    for (int i = 0; i < s; i++)
        for (int j = 0; j < s; j++)
            for (int k = 0; k < s; k++) {
                size_t g = ((size_t)i * s + j) * s + k;
                id[g] = UINT32_MAX;
                if (i && j && k && i < n && j < n && k < n)
                    continue;
                double p[3] = { i, j, k };
                if (!lattice) {
                    p[0] = ext[0] * i / n, p[1] = ext[1] * j / n, p[2] = ext[2] * k / n;
                    place(p, off, 1.0);
                }
                for (int a = 0; a < 3; a++)
                    m->pos[3 * (size_t)m->nv + a] = (float)p[a];
                id[g] = m->nv++;
            }
    size_t t = 0;
    for (int axis = 0; axis < 3; axis++)
        for (int side = 0; side <= n; side += n)
            for (int u = 0; u < n; u++)
                for (int v = 0; v < n; v++) {
                    int c[4][3];
                    const int du[4] = { 0, 1, 1, 0 }, dv[4] = { 0, 0, 1, 1 };
                    for (int q = 0; q < 4; q++) {
                        c[q][axis] = side;
                        c[q][(axis + 1) % 3] = u + du[q];
                        c[q][(axis + 2) % 3] = v + dv[q];
                    }
                    uint32_t w[4];
                    for (int q = 0; q < 4; q++)
                        w[q] = id[((size_t)c[q][0] * s + c[q][1]) * s + c[q][2]];
                    int flip = !lattice && side == 0, diag = !lattice && (u + v) % 2;
                    uint32_t t0[3] = { w[0], w[1], w[2] }, t1[3] = { w[0], w[2], w[3] };
                    if (diag) {
                        t0[0] = w[1], t0[1] = w[2], t0[2] = w[3];
                        t1[0] = w[1], t1[1] = w[3], t1[2] = w[0];
                    }
                    if (flip) {
                        uint32_t x = t0[1]; t0[1] = t0[2], t0[2] = x;
                        x = t1[1]; t1[1] = t1[2], t1[2] = x;
                    }
                    memcpy(m->idx + 3 * t++, t0, sizeof t0);
                    memcpy(m->idx + 3 * t++, t1, sizeof t1);
                }
    free(id);
}

/* Runs fn on each of the named meshes found in $SC_TEST_SCENES (the real
 * meshes are never committed); skips the test when there is none. */
static void each_shared_scene(const char *const *names, size_t count,
                              void (*fn)(const char *name, const sc_mesh_view *m, void *ctx), void *ctx)
{
    const char *dir = getenv("SC_TEST_SCENES");
    int ran = 0;
    for (size_t f = 0; f < count; f++) {
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", dir ? dir : "", names[f]);
        FILE *fp = dir ? fopen(path, "rb") : NULL;
        if (!fp)
            continue;
        fclose(fp);
        sc_scene *scene;
        char err[256];
        assert_int_equal(sc_scene_load(path, NULL, &scene, err, sizeof err), SC_OK);
        sc_scene_view v;
        assert_int_equal(sc_scene_get_view(scene, &v), SC_OK);
        sc_mesh_view m = { v.mesh.positions, (uint32_t)v.mesh.vertex_count, v.mesh.indices, (uint32_t)v.mesh.triangle_count, 0, 0 };
        fn(names[f], &m, ctx);
        sc_scene_free(scene);
        ran++;
    }
    if (!ran) {
        print_message("no shared scenes in '%s': skipped\n", dir ? dir : "(SC_TEST_SCENES unset)");
        skip();
    }
}

#endif

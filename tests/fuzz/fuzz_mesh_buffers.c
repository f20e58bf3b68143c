/* libFuzzer target: raw-buffer ingestion (sc_scene_create + sc_scene_add_mesh).
 *
 * The input is a list of meshes: per mesh a 4-byte header (vertex count,
 * triangle count, flags, a cap selector on the first mesh), then float bits
 * for the vertices and 1- or 4-byte indices; missing bytes read as zero.
 * The expected status of every call is computed here independently: caps
 * on the claimed counts first (a claim beyond the cap must be refused
 * without reading the buffers, which are shorter than claimed: ASan checks
 * that), then out-of-range indices, then the cap on what is kept after
 * triangles touching NaN/Inf vertices are dropped. The scene must then
 * keep every invariant of scene_check.h and frame a camera. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "scene_check.h"

typedef struct cursor {
    const uint8_t *p;
    size_t n;
} cursor;

static uint8_t take8(cursor *c)
{
    if (!c->n)
        return 0;
    c->n--;
    return *c->p++;
}

static uint32_t take32(cursor *c)
{
    uint32_t v = 0;
    for (int i = 0; i < 4; i++)
        v |= (uint32_t)take8(c) << (8 * i);
    return v;
}

static float takef(cursor *c)
{
    uint32_t b = take32(c);
    float f;
    memcpy(&f, &b, sizeof f);
    return f;
}

static int finite3(const float *p)
{
    return isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    cursor c = { data, size };
    static const uint64_t caps[4] = { 0, 16, 200, 5000 };   /* 0: the default cap */
    size_t warnings = 0;
    sc_scene_options o;
    sc_scene_options_init(&o);
    o.max_triangles = caps[size ? data[0] & 3 : 0];
    o.warn = fz_on_warn;
    o.warn_ctx = &warnings;
    uint64_t max_t = o.max_triangles ? o.max_triangles : SC_SCENE_DEFAULT_MAX_TRIANGLES;
    uint64_t max_v = max_t > UINT32_MAX / 3 ? UINT32_MAX : 3 * max_t;
    sc_scene *s;
    fz_require(sc_scene_create(&o, &s) == SC_OK);
    size_t tris = 0, verts = 0, meshes = 0, dropped = 0;
    char err[256];
    for (int m = 0; m < 8 && c.n > 0; m++) {
        uint8_t hv = take8(&c), ht = take8(&c), flags = take8(&c);
        take8(&c);
        size_t nv = hv, nt = ht;
        float *pos = calloc(nv ? 3 * nv : 1, sizeof(float));
        uint32_t *idx = calloc(nt ? 3 * nt : 1, sizeof(uint32_t));
        fz_require(pos && idx);
        for (size_t i = 0; i < 3 * nv; i++)
            pos[i] = takef(&c);
        for (size_t i = 0; i < 3 * nt; i++)
            idx[i] = (flags & 1) ? take32(&c) : take8(&c);
        float color[3] = { takef(&c), takef(&c), takef(&c) };
        const float *col = (flags & 2) ? color : NULL;
        /* A claim far beyond what the buffers hold, only ever beyond a cap. */
        size_t claim_v = nv, claim_t = nt;
        if (flags & 4)
            claim_t = (size_t)(max_t + 1 + take32(&c));
        if (flags & 8)
            claim_v = (size_t)(max_v + 1 + take32(&c));

        sc_status want;
        size_t kept = 0;
        if (claim_t > 0 && claim_v == 0) {
            want = SC_ERR_INVALID_ARGUMENT;
        } else if (claim_t > max_t - tris || claim_v > max_v - verts) {
            want = SC_ERR_LIMIT;
        } else {
            want = SC_OK;
            for (size_t i = 0; i < 3 * nt; i++)
                if (idx[i] >= nv)
                    want = SC_ERR_INVALID_ARGUMENT;
            if (want == SC_OK)
                for (size_t t = 0; t < nt; t++)
                    kept += finite3(pos + 3 * idx[3 * t]) && finite3(pos + 3 * idx[3 * t + 1]) &&
                            finite3(pos + 3 * idx[3 * t + 2]);
        }
        err[0] = '\0';
        sc_status st = sc_scene_add_mesh(s, pos, claim_v, idx, claim_t, col, err, sizeof err);
        if (st != want)
            fprintf(stderr, "mesh %d: nv %zu nt %zu claims %zu/%zu: status %d, expected %d (%s)\n", m,
                    nv, nt, claim_v, claim_t, (int)st, (int)want, err);
        fz_require(st == want);
        if (st == SC_OK) {
            tris += kept;
            verts += nv;
            meshes++;
            dropped += nt - kept;
        } else {
            fz_check_error(err, sizeof err);
        }
        sc_scene_stats ss;
        fz_require(sc_scene_get_stats(s, &ss) == SC_OK);
        fz_require(ss.triangles == tris && ss.vertices == verts && ss.meshes == meshes &&
                   ss.dropped_nonfinite == dropped);
        free(pos);
        free(idx);
    }
    /* Framing a camera on whatever came in: finite, or a clean refusal. */
    double az = (double)take8(&c) * 3 - 360, el = (double)take8(&c) - 128;
    double fov = (double)take8(&c);
    int w = 1 + take8(&c), h = 1 + take8(&c);
    sc_status st = sc_scene_frame_camera(s, az, el, fov, w, h);
    /* A valid fov may still be refused: a tiny model at 1e38 leaves no
     * double between the eye and the target. */
    fz_require(st == SC_OK || st == SC_ERR_INVALID_ARGUMENT);
    if (!(fov > 0 && fov < 180))
        fz_require(st == SC_ERR_INVALID_ARGUMENT);
    fz_check_scene(s, max_t);
    if (st == SC_OK)
        fz_require(sc_scene_add_default_light(s) == SC_OK);
    /* Arguments checked, never trusted. */
    fz_require(sc_scene_add_mesh(NULL, NULL, 0, NULL, 0, NULL, err, sizeof err) == SC_ERR_INVALID_ARGUMENT);
    fz_require(sc_scene_add_mesh(s, NULL, 3, NULL, 1, NULL, err, sizeof err) == SC_ERR_INVALID_ARGUMENT);
    sc_scene_free(s);
    return 0;
}

/* Scene files (scenes/NAME.json) through cJSON. The format is documented in scenes/README.md;
 * every field is type- and range-checked and every failure names the file,
 * the field and what was expected. Unknown keys are warnings (typos should
 * not pass silently, but a newer file should still load). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <cjson/cJSON.h>

#include "common/sc_rng.h"
#include "load_json.h"

#define MAX_JSON_BYTES (16u << 20)
#define MAX_MESHES_IN_JSON 100000
#define MAX_LIGHTS 1024
#define MAX_INLINE_VERTICES 1000000
#define PI 3.14159265358979323846
#define MAX_INSTANCES 1000000

typedef struct jctx {
    sc_scene *s;
    const char *path;
    sc_scene_append_fn append_mesh;
    char *err;
    size_t errlen;
} jctx;

#define JERR(c, st, ...) sc_scene_errf((c)->err, (c)->errlen, (st), __VA_ARGS__)

static void warn_unknown_keys(jctx *c, const cJSON *obj, const char *where,
                              const char *const *known)
{
    /* Linear in the number of keys: a hostile file may hold a million of
     * them, so duplicates are looked for only among the known keys (a
     * duplicated unknown key is already reported as unknown). */
    enum { MAX_KNOWN = 16 };
    int seen[MAX_KNOWN] = { 0 };
    for (const cJSON *it = obj->child; it; it = it->next) {
        int k = 0;
        while (known[k] && k < MAX_KNOWN && !(it->string && strcmp(it->string, known[k]) == 0))
            k++;
        if (!known[k] || k == MAX_KNOWN)
            sc_scene_warnf(c->s, "%s: unknown key '%s' in %s ignored", c->path,
                           it->string ? it->string : "?", where);
        else if (seen[k]++ == 1)
            sc_scene_warnf(c->s, "%s: duplicate key '%s' in %s; the first one is used",
                           c->path, it->string, where);
    }
}

/* 1: found and valid; 0: absent; -1: error already formatted. */
static int get_number(jctx *c, const cJSON *obj, const char *key, const char *where,
                      double lo, double hi, int lo_open, double *out)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v)
        return 0;
    double d = cJSON_IsNumber(v) ? v->valuedouble : NAN;
    if (!cJSON_IsNumber(v) || !isfinite(d) || d < lo || d > hi || (lo_open && d == lo)) {
        if (cJSON_IsNumber(v))
            JERR(c, SC_ERR_PARSE, "%s: %s%s must be a number in %s%g, %g], got %g", c->path, where,
                 key, lo_open ? "(" : "[", lo, hi, d);
        else
            JERR(c, SC_ERR_PARSE, "%s: %s%s must be a number in %s%g, %g]", c->path, where, key,
                 lo_open ? "(" : "[", lo, hi);
        return -1;
    }
    *out = d;
    return 1;
}

static int get_vec3(jctx *c, const cJSON *obj, const char *key, const char *where,
                    double limit, double out[3])
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v)
        return 0;
    int ok = cJSON_IsArray(v) && cJSON_GetArraySize(v) == 3;
    for (int i = 0; ok && i < 3; i++) {
        const cJSON *e = cJSON_GetArrayItem(v, i);
        ok = cJSON_IsNumber(e) && isfinite(e->valuedouble) && fabs(e->valuedouble) <= limit;
        if (ok)
            out[i] = e->valuedouble;
    }
    if (!ok) {
        JERR(c, SC_ERR_PARSE, "%s: %s%s must be an array of 3 numbers with |x| <= %g", c->path,
             where, key, limit);
        return -1;
    }
    return 1;
}

static int get_color(jctx *c, const cJSON *obj, const char *key, const char *where, float out[3])
{
    double d[3];
    int r = get_vec3(c, obj, key, where, 1e9, d);
    if (r == 1) {
        for (int i = 0; i < 3; i++)
            if (d[i] < 0 || d[i] > 1) {
                JERR(c, SC_ERR_PARSE, "%s: %s%s components must be in [0, 1]", c->path, where, key);
                return -1;
            }
        for (int i = 0; i < 3; i++)
            out[i] = (float)d[i];
    }
    return r;
}

static int get_image_side(jctx *c, const cJSON *root, const char *key, int *out)
{
    double d;
    int r = get_number(c, root, key, "", 1, SC_SCENE_MAX_IMAGE_SIDE, 0, &d);
    if (r == 1 && d != floor(d)) {
        JERR(c, SC_ERR_PARSE, "%s: %s must be a whole number of pixels, got %g", c->path, key, d);
        return -1;
    }
    if (r == 1)
        *out = (int)d;
    return r;
}

/* Row-major 4x4: translate * Rz * Ry * Rx * scale. */
static int mesh_transform(jctx *c, const cJSON *m, const char *where, double xf[16], int *any)
{
    double s[3] = { 1, 1, 1 }, r[3] = { 0, 0, 0 }, t[3] = { 0, 0, 0 };
    *any = 0;
    const cJSON *sv = cJSON_GetObjectItemCaseSensitive(m, "scale");
    if (sv && cJSON_IsNumber(sv)) {
        double k;
        if (get_number(c, m, "scale", where, 0, 1e15, 1, &k) < 0)
            return -1;
        s[0] = s[1] = s[2] = k;
        *any = 1;
    } else if (sv) {
        int rr = get_vec3(c, m, "scale", where, 1e15, s);
        if (rr < 0)
            return -1;
        for (int i = 0; i < 3; i++)
            if (!(s[i] != 0)) {
                JERR(c, SC_ERR_PARSE, "%s: %sscale must not be zero", c->path, where);
                return -1;
            }
        *any = 1;
    }
    int rr = get_vec3(c, m, "rotate", where, 1e6, r);
    if (rr < 0)
        return -1;
    *any |= rr;
    rr = get_vec3(c, m, "translate", where, 1e30, t);
    if (rr < 0)
        return -1;
    *any |= rr;
    double cx = cos(r[0] * PI / 180), sx = sin(r[0] * PI / 180);
    double cy = cos(r[1] * PI / 180), sy = sin(r[1] * PI / 180);
    double cz = cos(r[2] * PI / 180), sz = sin(r[2] * PI / 180);
    /* R = Rz Ry Rx */
    double R[3][3] = {
        { cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx },
        { sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx },
        { -sy, cy * sx, cy * cx },
    };
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            xf[4 * i + j] = R[i][j] * s[j];
        xf[4 * i + 3] = t[i];
    }
    xf[12] = xf[13] = xf[14] = 0;
    xf[15] = 1;
    return 0;
}

/* Radiance: any non-negative value up to SC_SCENE_MAX_EMISSION. */
static int get_emission(jctx *c, const cJSON *obj, const char *where, float out[3])
{
    double d[3];
    int r = get_vec3(c, obj, "emission", where, SC_SCENE_MAX_EMISSION, d);
    if (r == 1) {
        for (int i = 0; i < 3; i++)
            if (d[i] < 0) {
                JERR(c, SC_ERR_PARSE, "%s: %semission components must be >= 0", c->path, where);
                return -1;
            }
        for (int i = 0; i < 3; i++)
            out[i] = (float)d[i];
    }
    return r;
}

/* A mesh written in the file: "vertices" [[x,y,z], ...] and "faces"
 * [[i,j,k] or [i,j,k,l], ...] (a quad is split along i-k), with the entry's
 * transform applied. For walls, boxes and area lights without a mesh file. */
static sc_status load_inline_mesh(jctx *c, const cJSON *m, const char *where, const double *xf,
                                  const float *color)
{
    const cJSON *vs = cJSON_GetObjectItemCaseSensitive(m, "vertices");
    const cJSON *fs = cJSON_GetObjectItemCaseSensitive(m, "faces");
    if (!cJSON_IsArray(vs) || !cJSON_IsArray(fs) || cJSON_GetArraySize(vs) == 0 ||
        cJSON_GetArraySize(fs) == 0)
        return JERR(c, SC_ERR_PARSE, "%s: %svertices and %sfaces must be non-empty arrays", c->path,
                    where, where);
    size_t nv = (size_t)cJSON_GetArraySize(vs), nf = (size_t)cJSON_GetArraySize(fs);
    if (nv > MAX_INLINE_VERTICES || nf > MAX_INLINE_VERTICES)
        return JERR(c, SC_ERR_LIMIT, "%s: %smore than %d vertices or faces written inline", c->path,
                    where, MAX_INLINE_VERTICES);
    float *pos = malloc(nv * 3 * sizeof(float));
    uint32_t *idx = malloc(nf * 6 * sizeof(uint32_t));
    sc_status st = SC_OK;
    if (!pos || !idx) {
        st = JERR(c, SC_ERR_OUT_OF_MEMORY, "%s: out of memory", c->path);
        goto done;
    }
    size_t i = 0;
    for (const cJSON *v = vs->child; v; v = v->next, i++) {
        double p[3];
        int ok = cJSON_IsArray(v) && cJSON_GetArraySize(v) == 3;
        for (int k = 0; ok && k < 3; k++) {
            const cJSON *e = cJSON_GetArrayItem(v, k);
            ok = cJSON_IsNumber(e) && isfinite(e->valuedouble) && fabs(e->valuedouble) <= 1e30;
            p[k] = ok ? e->valuedouble : 0;
        }
        if (!ok) {
            st = JERR(c, SC_ERR_PARSE, "%s: %svertices[%zu] must be an array of 3 numbers with |x| <= 1e+30",
                      c->path, where, i);
            goto done;
        }
        for (int r = 0; r < 3; r++)
            pos[3 * i + r] = (float)(xf ? xf[4 * r] * p[0] + xf[4 * r + 1] * p[1] + xf[4 * r + 2] * p[2] +
                                              xf[4 * r + 3]
                                        : p[r]);
    }
    size_t nt = 0, f = 0;
    for (const cJSON *face = fs->child; face; face = face->next, f++) {
        int n = cJSON_IsArray(face) ? cJSON_GetArraySize(face) : 0;
        uint32_t q[4];
        int ok = n == 3 || n == 4;
        for (int k = 0; ok && k < n; k++) {
            const cJSON *e = cJSON_GetArrayItem(face, k);
            ok = cJSON_IsNumber(e) && e->valuedouble >= 0 && e->valuedouble < (double)nv &&
                 e->valuedouble == floor(e->valuedouble);
            q[k] = ok ? (uint32_t)e->valuedouble : 0;
        }
        if (!ok) {
            st = JERR(c, SC_ERR_PARSE, "%s: %sfaces[%zu] must hold 3 or 4 vertex indices below %zu",
                      c->path, where, f, nv);
            goto done;
        }
        idx[3 * nt] = q[0], idx[3 * nt + 1] = q[1], idx[3 * nt + 2] = q[2], nt++;
        if (n == 4)
            idx[3 * nt] = q[0], idx[3 * nt + 1] = q[2], idx[3 * nt + 2] = q[3], nt++;
    }
    st = sc_scene_add_mesh(c->s, pos, nv, idx, nt, color, c->err, c->errlen);
done:
    free(pos);
    free(idx);
    return st;
}

/* A mesh entry's "instances": an array of placements ({"scale", "rotate",
 * "translate"}, as a mesh entry's own) or a grid ({"grid": [nx, ny, nz],
 * "spacing": s or [sx, sy, sz], "rotate_jitter": degrees about y,
 * "scale_jitter": fraction, "seed": n}). Returns the transforms (row-major
 * 3x4, malloc'd) and their count, or minus the status, the error set. */
static long parse_instances(jctx *c, const cJSON *v, const char *where, float (**out)[12])
{
    *out = NULL;
    long fail = -(long)SC_ERR_PARSE;
    if (cJSON_IsArray(v)) {
        long n = cJSON_GetArraySize(v);
        if (n < 1 || n > MAX_INSTANCES) {
            JERR(c, SC_ERR_PARSE, "%s: %sinstances must hold 1..%d placements", c->path, where, MAX_INSTANCES);
            return fail;
        }
        float (*x)[12] = malloc(sizeof *x * (size_t)n);
        if (!x) {
            JERR(c, SC_ERR_OUT_OF_MEMORY, "%s: out of memory", c->path);
            return -(long)SC_ERR_OUT_OF_MEMORY;
        }
        long i = 0;
        for (const cJSON *e = v->child; e; e = e->next, i++) {
            char w[80];
            snprintf(w, sizeof w, "%sinstances[%ld].", where, i);
            static const char *const known[] = { "scale", "rotate", "translate", NULL };
            if (!cJSON_IsObject(e)) {
                free(x);
                JERR(c, SC_ERR_PARSE, "%s: %sinstances[%ld] must be an object", c->path, where, i);
                return fail;
            }
            warn_unknown_keys(c, e, "an instance", known);
            double xf[16];
            int any;
            if (mesh_transform(c, e, w, xf, &any) < 0) {
                free(x);
                return fail;
            }
            for (int k = 0; k < 12; k++)
                x[i][k] = (float)xf[k];
        }
        *out = x;
        return n;
    }
    if (!cJSON_IsObject(v)) {
        JERR(c, SC_ERR_PARSE, "%s: %sinstances must be an array of placements or a {\"grid\": ...} object", c->path,
             where);
        return fail;
    }
    static const char *const known[] = { "grid", "spacing", "rotate_jitter", "scale_jitter", "seed", NULL };
    warn_unknown_keys(c, v, "an instance grid", known);
    char w[64];
    snprintf(w, sizeof w, "%sinstances.", where);
    double g[3], sp[3] = { 1, 1, 1 }, rj = 0, sj = 0, seed = 1;
    int r = get_vec3(c, v, "grid", w, MAX_INSTANCES, g);
    if (r <= 0) {
        if (r == 0)
            JERR(c, SC_ERR_PARSE, "%s: %sgrid is required: [nx, ny, nz]", c->path, w);
        return fail;
    }
    for (int k = 0; k < 3; k++)
        if (!(g[k] >= 1) || g[k] != floor(g[k])) {
            JERR(c, SC_ERR_PARSE, "%s: %sgrid must hold 3 whole numbers >= 1", c->path, w);
            return fail;
        }
    if (g[0] * g[1] * g[2] > MAX_INSTANCES) {
        JERR(c, SC_ERR_LIMIT, "%s: %sgrid makes more than %d instances", c->path, w, MAX_INSTANCES);
        return -(long)SC_ERR_LIMIT;
    }
    const cJSON *spv = cJSON_GetObjectItemCaseSensitive(v, "spacing");
    if (spv && cJSON_IsNumber(spv)) {
        if (get_number(c, v, "spacing", w, 0, 1e15, 1, &sp[0]) < 0)
            return fail;
        sp[1] = sp[2] = sp[0];
    } else if (get_vec3(c, v, "spacing", w, 1e15, sp) < 0) {
        return fail;
    }
    if (get_number(c, v, "rotate_jitter", w, 0, 360, 0, &rj) < 0 || get_number(c, v, "scale_jitter", w, 0, 0.99, 0, &sj) < 0 ||
        get_number(c, v, "seed", w, 0, 1e15, 0, &seed) < 0)
        return fail;
    const long nx = (long)g[0], ny = (long)g[1], nz = (long)g[2], n = nx * ny * nz;
    float (*x)[12] = malloc(sizeof *x * (size_t)n);
    if (!x) {
        JERR(c, SC_ERR_OUT_OF_MEMORY, "%s: out of memory", c->path);
        return -(long)SC_ERR_OUT_OF_MEMORY;
    }
    sc_rng rng;
    sc_rng_seed(&rng, (uint64_t)seed);
    for (long i = 0; i < n; i++) {
        const long ix = i % nx, iy = (i / nx) % ny, iz = i / (nx * ny);
        const double a = sc_rng_range(&rng, -rj, rj) * PI / 180, sc = 1 + sc_rng_range(&rng, -sj, sj);
        const double ca = cos(a), sa = sin(a);
        /* rotation about y, uniform scale, then the grid point (centred) */
        const double m[12] = { sc * ca, 0, sc * sa, ((double)ix - 0.5 * (double)(nx - 1)) * sp[0],
                               0, sc, 0, ((double)iy - 0.5 * (double)(ny - 1)) * sp[1],
                               -sc * sa, 0, sc * ca, ((double)iz - 0.5 * (double)(nz - 1)) * sp[2] };
        for (int k = 0; k < 12; k++)
            x[i][k] = (float)m[k];
    }
    *out = x;
    return n;
}

static sc_status load_meshes(jctx *c, const cJSON *root, const char *base_dir)
{
    const cJSON *meshes = cJSON_GetObjectItemCaseSensitive(root, "meshes");
    if (!meshes)
        return JERR(c, SC_ERR_PARSE, "%s: missing \"meshes\" (an array of {\"file\": ...})", c->path);
    if (!cJSON_IsArray(meshes) || cJSON_GetArraySize(meshes) == 0)
        return JERR(c, SC_ERR_PARSE, "%s: \"meshes\" must be a non-empty array", c->path);
    if (cJSON_GetArraySize(meshes) > MAX_MESHES_IN_JSON)
        return JERR(c, SC_ERR_LIMIT, "%s: more than %d meshes", c->path, MAX_MESHES_IN_JSON);
    static const char *const known[] = { "file", "vertices", "faces", "color", "emission", "scale",
                                         "rotate", "translate", "name", "instances", NULL };
    int i = 0;
    for (const cJSON *m = meshes->child; m; m = m->next, i++) {
        char where[48];
        snprintf(where, sizeof where, "meshes[%d].", i);
        if (!cJSON_IsObject(m))
            return JERR(c, SC_ERR_PARSE, "%s: meshes[%d] must be an object", c->path, i);
        warn_unknown_keys(c, m, "a mesh", known);
        const cJSON *f = cJSON_GetObjectItemCaseSensitive(m, "file");
        int inline_mesh = !f && cJSON_GetObjectItemCaseSensitive(m, "vertices");
        if (!inline_mesh && (!cJSON_IsString(f) || !f->valuestring[0]))
            return JERR(c, SC_ERR_PARSE, "%s: %sfile must be a non-empty string (or give vertices and faces)",
                        c->path, where);
        float color[3], emission[3];
        int has_color = get_color(c, m, "color", where, color);
        if (has_color < 0)
            return SC_ERR_PARSE;
        int has_emission = get_emission(c, m, where, emission);
        if (has_emission < 0)
            return SC_ERR_PARSE;
        double xf[16];
        int any;
        if (mesh_transform(c, m, where, xf, &any) < 0)
            return SC_ERR_PARSE;
        const cJSON *iv = cJSON_GetObjectItemCaseSensitive(m, "instances");
        if (iv) {
            /* the entry (with its own transform) is the object, loaded once */
            float (*xfm)[12];
            long n = parse_instances(c, iv, where, &xfm);
            if (n < 0)
                return (sc_status)-n;
            sc_scene *sub;
            sc_status st = sc_scene_create_nested(c->s, &sub);
            if (st != SC_OK) {
                free(xfm);
                return JERR(c, st, "%s: %s", c->path, sc_strerror(st));
            }
            if (inline_mesh) {
                sc_scene *keep = c->s;
                c->s = sub;
                st = load_inline_mesh(c, m, where, any ? xf : NULL, has_color == 1 ? color : NULL);
                c->s = keep;
            } else {
                st = c->append_mesh(sub, f->valuestring, base_dir, any ? xf : NULL, has_color == 1 ? color : NULL,
                                    c->err, c->errlen);
            }
            c->s->warnings += sub->warnings;
            if (st == SC_OK) {
                char what[600];
                snprintf(what, sizeof what, "%s: %sinstances", c->path, where);
                st = sc_scene_add_instances(c->s, sub, (const float (*)[12])xfm, (size_t)n, NULL,
                                            has_emission == 1 ? emission : NULL, what, c->err, c->errlen);
            }
            if (st == SC_OK && sub->num_triangles == 0)
                sc_scene_warnf(c->s, "%s: %s'%s' added no triangles", c->path, where,
                               inline_mesh ? "vertices" : f->valuestring);
            sc_scene_free(sub);
            free(xfm);
            if (st != SC_OK)
                return st;
            continue;
        }
        size_t before = c->s->num_triangles, first_mesh = c->s->num_meshes;
        sc_status st = inline_mesh ? load_inline_mesh(c, m, where, any ? xf : NULL, has_color == 1 ? color : NULL)
                                   : c->append_mesh(c->s, f->valuestring, base_dir, any ? xf : NULL,
                                                    has_color == 1 ? color : NULL, c->err, c->errlen);
        if (st != SC_OK)
            return st;
        if (c->s->num_triangles == before)
            sc_scene_warnf(c->s, "%s: %s'%s' added no triangles", c->path, where,
                           inline_mesh ? "vertices" : f->valuestring);
        for (size_t k = first_mesh; has_emission == 1 && k < c->s->num_meshes; k++)
            sc_scene_set_mesh_emission(c->s, k, emission);
    }
    return SC_OK;
}

static sc_status load_camera(jctx *c, const cJSON *root)
{
    int w = SC_SCENE_DEFAULT_WIDTH, h = SC_SCENE_DEFAULT_HEIGHT;
    if (get_image_side(c, root, "width", &w) < 0 || get_image_side(c, root, "height", &h) < 0)
        return SC_ERR_PARSE;
    if ((uint64_t)w * (uint64_t)h > c->s->max_pixels)
        return JERR(c, SC_ERR_LIMIT, "%s: %dx%d image exceeds the cap of %llu pixels", c->path, w, h,
                    (unsigned long long)c->s->max_pixels);
    const cJSON *cam = cJSON_GetObjectItemCaseSensitive(root, "camera");
    if (cam && !cJSON_IsObject(cam))
        return JERR(c, SC_ERR_PARSE, "%s: camera must be an object", c->path);
    static const cJSON empty = { 0 };
    if (!cam)
        cam = &empty;
    static const char *const known[] = { "eye", "target", "up", "fov", "azimuth", "elevation", NULL };
    warn_unknown_keys(c, cam, "camera", known);
    double fov = 40, eye[3], target[3] = { 0, 0, 0 }, up[3] = { 0, 1, 0 };
    if (get_number(c, cam, "fov", "camera.", 0, 180, 1, &fov) < 0)
        return SC_ERR_PARSE;
    if (fov >= 180)
        return JERR(c, SC_ERR_PARSE, "%s: camera.fov must be below 180 degrees", c->path);
    int has_eye = get_vec3(c, cam, "eye", "camera.", 1e30, eye);
    if (has_eye < 0)
        return SC_ERR_PARSE;
    if (!has_eye) {
        double az = 35, el = 25;
        if (get_number(c, cam, "azimuth", "camera.", -360, 360, 0, &az) < 0 ||
            get_number(c, cam, "elevation", "camera.", -89, 89, 0, &el) < 0)
            return SC_ERR_PARSE;
        if (cJSON_GetObjectItemCaseSensitive(cam, "target"))
            sc_scene_warnf(c->s, "%s: camera.target without camera.eye is ignored (auto framing)", c->path);
        sc_status st = sc_scene_frame_camera(c->s, az, el, fov, w, h);
        if (st != SC_OK)
            return JERR(c, st, "%s: cannot frame the camera on the scene", c->path);
        return SC_OK;
    }
    int r = get_vec3(c, cam, "target", "camera.", 1e30, target);
    if (r < 0)
        return SC_ERR_PARSE;
    if (r == 0)
        return JERR(c, SC_ERR_PARSE, "%s: camera.eye needs camera.target", c->path);
    if (get_vec3(c, cam, "up", "camera.", 1e30, up) < 0)
        return SC_ERR_PARSE;
    sc_camera camera = { .fov_y_deg = fov, .width = w, .height = h };
    memcpy(camera.eye, eye, sizeof eye);
    memcpy(camera.target, target, sizeof target);
    memcpy(camera.up, up, sizeof up);
    sc_status st = sc_scene_set_camera(c->s, &camera);
    if (st == SC_ERR_LIMIT)
        return JERR(c, st, "%s: %dx%d image exceeds the pixel cap", c->path, w, h);
    if (st != SC_OK)
        return JERR(c, SC_ERR_PARSE,
                    "%s: camera eye and target coincide, or up is parallel to the view", c->path);
    return SC_OK;
}

static sc_status load_ground(jctx *c, const cJSON *root)
{
    const cJSON *g = cJSON_GetObjectItemCaseSensitive(root, "ground");
    if (!g || cJSON_IsFalse(g) || cJSON_IsNull(g))
        return SC_OK;
    static const cJSON empty = { 0 };
    if (cJSON_IsTrue(g))
        g = &empty;
    else if (!cJSON_IsObject(g))
        return JERR(c, SC_ERR_PARSE, "%s: ground must be an object or true", c->path);
    static const char *const known[] = { "color", "size", NULL };
    warn_unknown_keys(c, g, "ground", known);
    float color[3] = { 0.7f, 0.7f, 0.7f };
    double size = 4;
    if (get_color(c, g, "color", "ground.", color) < 0 ||
        get_number(c, g, "size", "ground.", 0, 1e6, 1, &size) < 0)
        return SC_ERR_PARSE;
    /* A square under the meshes, perpendicular to +y, touching the lowest
     * point so that contact shadows show. */
    double lo[3], hi[3], r2 = 0;
    sc_scene_bounds(c->s, lo, hi);
    for (int i = 0; i < 3; i++)
        r2 += 0.25 * (hi[i] - lo[i]) * (hi[i] - lo[i]);
    double half = size * sqrt(r2), cx = 0.5 * (lo[0] + hi[0]), cz = 0.5 * (lo[2] + hi[2]);
    if (!(half > 0))
        half = size;
    float p[12] = {
        (float)(cx - half), (float)lo[1], (float)(cz - half),
        (float)(cx - half), (float)lo[1], (float)(cz + half),
        (float)(cx + half), (float)lo[1], (float)(cz + half),
        (float)(cx + half), (float)lo[1], (float)(cz - half),
    };
    static const uint32_t idx[6] = { 0, 1, 2, 0, 2, 3 };
    return sc_scene_add_mesh(c->s, p, 4, idx, 2, color, c->err, c->errlen);
}

static sc_status load_lights(jctx *c, const cJSON *root)
{
    const cJSON *lights = cJSON_GetObjectItemCaseSensitive(root, "lights");
    if (!lights) {
        sc_status st = sc_scene_add_default_light(c->s);
        return st == SC_OK ? st : JERR(c, st, "%s: cannot place the default light", c->path);
    }
    if (!cJSON_IsArray(lights))
        return JERR(c, SC_ERR_PARSE, "%s: lights must be an array", c->path);
    if (cJSON_GetArraySize(lights) > MAX_LIGHTS)
        return JERR(c, SC_ERR_LIMIT, "%s: more than %d lights", c->path, MAX_LIGHTS);
    static const char *const known[] = { "type", "direction", "position", "color", "intensity", NULL };
    int i = 0;
    for (const cJSON *l = lights->child; l; l = l->next, i++) {
        char where[48];
        snprintf(where, sizeof where, "lights[%d].", i);
        if (!cJSON_IsObject(l))
            return JERR(c, SC_ERR_PARSE, "%s: lights[%d] must be an object", c->path, i);
        warn_unknown_keys(c, l, "a light", known);
        const cJSON *type = cJSON_GetObjectItemCaseSensitive(l, "type");
        sc_light light = { .color = { 1, 1, 1 } };
        const char *vec_key;
        if (cJSON_IsString(type) && strcmp(type->valuestring, "directional") == 0)
            light.type = SC_LIGHT_DIRECTIONAL, vec_key = "direction";
        else if (cJSON_IsString(type) && strcmp(type->valuestring, "point") == 0)
            light.type = SC_LIGHT_POINT, vec_key = "position";
        else
            return JERR(c, SC_ERR_PARSE, "%s: %stype must be \"directional\" or \"point\"", c->path, where);
        double v[3], intensity = 1;
        int r = get_vec3(c, l, vec_key, where, 1e30, v);
        if (r < 0)
            return SC_ERR_PARSE;
        if (r == 0)
            return JERR(c, SC_ERR_PARSE, "%s: %s%s is required", c->path, where, vec_key);
        if (get_color(c, l, "color", where, light.color) < 0 ||
            get_number(c, l, "intensity", where, 0, 1e12, 0, &intensity) < 0)
            return SC_ERR_PARSE;
        for (int k = 0; k < 3; k++) {
            light.vec[k] = (float)v[k];
            light.color[k] = (float)(light.color[k] * intensity);
        }
        if (sc_scene_add_light(c->s, &light) != SC_OK)
            return JERR(c, SC_ERR_PARSE, "%s: %s%s must not be zero", c->path, where, vec_key);
    }
    return SC_OK;
}

static void line_col(const char *buf, size_t off, int *line, int *col)
{
    *line = 1;
    *col = 1;
    for (size_t i = 0; i < off && buf[i]; i++) {
        if (buf[i] == '\n')
            (*line)++, *col = 1;
        else
            (*col)++;
    }
}

static sc_status read_file(jctx *c, char **out, size_t *len)
{
    struct stat sb;
    if (stat(c->path, &sb) != 0)
        return JERR(c, SC_ERR_IO, "%s: %s", c->path, strerror(errno));
    if (S_ISDIR(sb.st_mode))
        return JERR(c, SC_ERR_IO, "%s: is a directory, not a scene file", c->path);
    if (!S_ISREG(sb.st_mode))
        return JERR(c, SC_ERR_IO, "%s: not a regular file", c->path);
    if (sb.st_size == 0)
        return JERR(c, SC_ERR_PARSE, "%s: empty file", c->path);
    if (sb.st_size > (off_t)MAX_JSON_BYTES)
        return JERR(c, SC_ERR_LIMIT, "%s: larger than %u MiB; scene files only reference meshes",
                    c->path, MAX_JSON_BYTES >> 20);
    FILE *f = fopen(c->path, "rb");
    if (!f)
        return JERR(c, SC_ERR_IO, "%s: %s", c->path, strerror(errno));
    char *buf = malloc((size_t)sb.st_size + 1);
    if (!buf) {
        fclose(f);
        return JERR(c, SC_ERR_OUT_OF_MEMORY, "%s: out of memory", c->path);
    }
    size_t n = fread(buf, 1, (size_t)sb.st_size, f);
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        free(buf);
        return JERR(c, SC_ERR_IO, "%s: read error", c->path);
    }
    buf[n] = '\0';
    *out = buf;
    *len = n;
    return SC_OK;
}

sc_status sc_scene_load_json_file(sc_scene *s, const char *path, sc_scene_append_fn append_mesh,
                                  char *err, size_t errlen)
{
    jctx c = { s, path, append_mesh, err, errlen };
    char *buf = NULL;
    size_t len = 0;
    sc_status st = read_file(&c, &buf, &len);
    if (st != SC_OK)
        return st;
    char *dir = strdup(path);
    if (!dir) {
        free(buf);
        return JERR(&c, SC_ERR_OUT_OF_MEMORY, "out of memory");
    }
    char *p = strrchr(dir, '/');
    if (p)
        *p = '\0';
    else
        strcpy(dir, ".");
    if (p == dir)
        strcpy(dir, "/");
    st = sc_scene_load_json_buffer(s, path, dir, buf, len, append_mesh, err, errlen);
    free(dir);
    free(buf);
    return st;
}

sc_status sc_scene_load_json_buffer(sc_scene *s, const char *path, const char *base_dir,
                                    const char *buf, size_t len, sc_scene_append_fn append_mesh,
                                    char *err, size_t errlen)
{
    jctx c = { s, path, append_mesh, err, errlen };
    sc_status st = SC_OK;
    if (len == 0)
        return JERR(&c, SC_ERR_PARSE, "%s: empty scene description", path);
    if (len > MAX_JSON_BYTES)
        return JERR(&c, SC_ERR_LIMIT, "%s: larger than %u MiB; scene files only reference meshes",
                    path, MAX_JSON_BYTES >> 20);
    if (memchr(buf, '\0', len))
        return JERR(&c, SC_ERR_PARSE, "%s: contains NUL bytes; not a JSON text file", path);
    const char *end = NULL;
    /* The length includes the terminating NUL: with require_null_terminated
     * cJSON looks for it inside the buffer. */
    cJSON *root = cJSON_ParseWithLengthOpts(buf, len + 1, &end, 1);
    if (!root) {
        int line, col;
        size_t off = end && end >= buf && end <= buf + len ? (size_t)(end - buf) : 0;
        line_col(buf, off, &line, &col);
        return JERR(&c, SC_ERR_PARSE, "%s:%d:%d: JSON syntax error", path, line, col);
    }
    if (!cJSON_IsObject(root)) {
        st = JERR(&c, SC_ERR_PARSE, "%s: the top level must be a JSON object", path);
    } else {
        static const char *const known[] = { "meshes", "camera", "width", "height", "lights",
                                             "background", "ambient", "ground", "description",
                                             NULL };
        warn_unknown_keys(&c, root, "the scene", known);
        st = load_meshes(&c, root, base_dir);
        float bg[3];
        double ambient;
        int r;
        if (st == SC_OK) {
            r = get_color(&c, root, "background", "", bg);
            if (r < 0)
                st = SC_ERR_PARSE;
            else if (r == 1)
                sc_scene_set_background(s, bg);
        }
        if (st == SC_OK) {
            r = get_number(&c, root, "ambient", "", 0, 1, 0, &ambient);
            if (r < 0)
                st = SC_ERR_PARSE;
            else if (r == 1)
                s->ambient = (float)ambient;
        }
        /* Camera before the ground: auto framing should show the models,
         * not a ground plane several times their size. */
        if (st == SC_OK)
            st = load_camera(&c, root);
        if (st == SC_OK)
            st = load_ground(&c, root);
        if (st == SC_OK)
            st = load_lights(&c, root);
        const cJSON *d = cJSON_GetObjectItemCaseSensitive(root, "description");
        if (st == SC_OK && d && !cJSON_IsString(d))
            sc_scene_warnf(s, "%s: description should be a string", path);
    }
    cJSON_Delete(root);
    return st;
}

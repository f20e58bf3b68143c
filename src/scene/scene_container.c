/* The scene container: flat arrays, caps, warnings, lights, camera
 * framing, views and stats. Knows no file format. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/sc_grow.h"
#include "scene_container.h"

void sc_scene_options_init(sc_scene_options *o)
{
    if (!o)
        return;
    memset(o, 0, sizeof *o);
    o->seed = 1;
}

/* One printable line: loader messages (assimp's, say) quote pieces of a
 * damaged file, newlines and terminal escape sequences included. */
static void one_line(char *s)
{
    for (unsigned char *p = (unsigned char *)s; *p; p++)
        if (*p == '\n' || *p == '\r' || *p == '\t')
            *p = ' ';
        else if (*p < 0x20 || *p == 0x7f)
            *p = '?';
}

sc_status sc_scene_errf(char *err, size_t errlen, sc_status st, const char *fmt, ...)
{
    if (err && errlen > 0) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
        one_line(err);
        size_t n = strlen(err);
        while (n > 0 && err[n - 1] == ' ')
            err[--n] = '\0';
    }
    return st;
}

void sc_scene_warnf(sc_scene *s, const char *fmt, ...)
{
    s->warnings++;
    if (!s->warn || s->warnings > SC_SCENE_MAX_WARNINGS)
        return;
    char buf[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    one_line(buf);
    size_t n = strlen(buf);
    while (n > 0 && buf[n - 1] == ' ')
        buf[--n] = '\0';
    s->warn(s->warn_ctx, buf);
}

static void default_camera(sc_camera *c)
{
    memset(c, 0, sizeof *c);
    c->eye[2] = 5;
    c->up[1] = 1;
    c->fov_y_deg = 40;
    c->width = SC_SCENE_DEFAULT_WIDTH;
    c->height = SC_SCENE_DEFAULT_HEIGHT;
}

/* The environment lets a pipeline change the import policy without a
 * new command-line option in every tool. */
static uint32_t env_timeout_ms(void)
{
    const char *e = getenv("SPHERECULL_IMPORT_TIMEOUT");
    if (e && *e) {
        char *end;
        double sec = strtod(e, &end);
        if (*end == '\0' && sec > 0 && sec <= 86400)
            return sec * 1000 < 1 ? 1u : (uint32_t)(sec * 1000);
    }
    return SC_SCENE_DEFAULT_IMPORT_TIMEOUT_MS;
}

static uint64_t env_import_bytes(void)
{
    const char *e = getenv("SPHERECULL_IMPORT_MEMORY");   /* MiB */
    if (e && *e) {
        char *end;
        unsigned long long mib = strtoull(e, &end, 10);
        if (*end == '\0' && mib > 0 && mib < (1ull << 40))
            return (uint64_t)mib << 20;
    }
    return 0;
}

static int env_in_process(void)
{
    const char *e = getenv("SPHERECULL_IMPORT");
    return e && strcmp(e, "in-process") == 0;
}

sc_status sc_scene_create(const sc_scene_options *options, sc_scene **out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    *out = NULL;
    sc_scene_options defaults;
    if (!options) {
        sc_scene_options_init(&defaults);
        options = &defaults;
    }
    sc_scene *s = calloc(1, sizeof *s);
    if (!s)
        return SC_ERR_OUT_OF_MEMORY;
    s->max_triangles = options->max_triangles ? options->max_triangles : SC_SCENE_DEFAULT_MAX_TRIANGLES;
    s->max_pixels = options->max_pixels ? options->max_pixels : SC_SCENE_DEFAULT_MAX_PIXELS;
    s->seed = options->seed;
    s->warn = options->warn;
    s->warn_ctx = options->warn_ctx;
    s->import_timeout_ms = options->import_timeout_ms ? options->import_timeout_ms : env_timeout_ms();
    s->import_in_process = options->import_in_process || env_in_process();
    s->max_import_bytes = options->max_import_bytes ? options->max_import_bytes : env_import_bytes();
    if (options->mesh_cache_dir) {
        s->cache_dir = strdup(options->mesh_cache_dir);
        if (!s->cache_dir) {
            free(s);
            return SC_ERR_OUT_OF_MEMORY;
        }
    }
    default_camera(&s->camera);
    s->background[0] = 0.05f;
    s->background[1] = 0.06f;
    s->background[2] = 0.08f;
    s->ambient = 0.15f;
    *out = s;
    return SC_OK;
}

sc_status sc_scene_create_nested(const sc_scene *parent, sc_scene **out)
{
    sc_scene_options o;
    sc_scene_options_init(&o);
    o.max_triangles = parent->max_triangles;
    o.mesh_cache_dir = parent->cache_dir;
    o.seed = parent->seed;
    o.warn = parent->warn;
    o.warn_ctx = parent->warn_ctx;
    o.import_timeout_ms = parent->import_timeout_ms;
    o.import_in_process = parent->import_in_process;
    o.max_import_bytes = parent->max_import_bytes;
    sc_status st = sc_scene_create(&o, out);
    if (st == SC_OK)
        (*out)->depth = parent->depth + 1;
    return st;
}

void sc_scene_free(sc_scene *s)
{
    if (!s)
        return;
    free(s->positions);
    free(s->indices);
    free(s->mesh_ids);
    free(s->mesh_colors);
    free(s->mesh_emission);
    free(s->lights);
    free(s->cache_dir);
    for (size_t i = 0; i < s->num_objects; i++)
        free((void *)s->objects[i].positions);
    free(s->objects);
    free(s->instances);
    free(s);
}

sc_status sc_scene_reserve(sc_scene *s, size_t more_v, size_t more_t, char *err, size_t errlen)
{
    uint64_t max_v = s->max_triangles > UINT32_MAX / 3 ? UINT32_MAX : 3 * s->max_triangles;
    if (more_t > s->max_triangles || s->num_triangles > s->max_triangles - more_t)
        return sc_scene_errf(err, errlen, SC_ERR_LIMIT,
                             "scene would have %llu triangles, more than the cap of %llu",
                             (unsigned long long)s->num_triangles + (unsigned long long)more_t,
                             (unsigned long long)s->max_triangles);
    if (more_v > max_v || s->num_vertices > max_v - more_v)
        return sc_scene_errf(err, errlen, SC_ERR_LIMIT,
                             "scene would have %llu vertices, more than the cap of %llu",
                             (unsigned long long)s->num_vertices + (unsigned long long)more_v,
                             (unsigned long long)max_v);
    size_t nv = s->num_vertices + more_v, nt = s->num_triangles + more_t;
    /* sc_grow() changes an array only on success, so a failure leaves a
     * consistent (if larger) scene behind. */
    if (!sc_grow((void **)&s->positions, &s->cap_vertices, nv, 3 * sizeof(float)) ||
        !sc_grow((void **)&s->indices, &s->cap_triangles, nt, 3 * sizeof(uint32_t)) ||
        !sc_grow((void **)&s->mesh_ids, &s->cap_mesh_ids, nt, sizeof(uint32_t)))
        return sc_scene_errf(err, errlen, SC_ERR_OUT_OF_MEMORY,
                             "out of memory for %zu triangles", nt);
    return SC_OK;
}

static float clamp01(float v, float fallback)
{
    if (!(v == v))
        return fallback;
    return v < 0 ? 0 : v > 1 ? 1 : v;
}

sc_status sc_scene_new_mesh(sc_scene *s, const float color[3], uint32_t *id)
{
    if (s->num_meshes >= UINT32_MAX)
        return SC_ERR_LIMIT;
    if (!sc_grow((void **)&s->mesh_colors, &s->cap_meshes, s->num_meshes + 1, 3 * sizeof(float)) ||
        !sc_grow((void **)&s->mesh_emission, &s->cap_emission, s->num_meshes + 1, 3 * sizeof(float)))
        return SC_ERR_OUT_OF_MEMORY;
    float *c = s->mesh_colors + 3 * s->num_meshes;
    for (int i = 0; i < 3; i++) {
        c[i] = color ? clamp01(color[i], SC_DEFAULT_GREY) : SC_DEFAULT_GREY;
        s->mesh_emission[3 * s->num_meshes + i] = 0.0f;
    }
    *id = (uint32_t)s->num_meshes++;
    return SC_OK;
}

static int is_degenerate(const float *a, const float *b, const float *c)
{
    /* Double holds the float products exactly enough that "zero" here means
     * collinear or coincident vertices, not an underflow. */
    double e0[3], e1[3];
    for (int i = 0; i < 3; i++) {
        e0[i] = (double)b[i] - a[i];
        e1[i] = (double)c[i] - a[i];
    }
    double nx = e0[1] * e1[2] - e0[2] * e1[1];
    double ny = e0[2] * e1[0] - e0[0] * e1[2];
    double nz = e0[0] * e1[1] - e0[1] * e1[0];
    return nx == 0 && ny == 0 && nz == 0;
}

static int vertex_finite(const float *p)
{
    return isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]);
}

sc_status sc_scene_append_triangles(sc_scene *s, const float *positions, size_t nv,
                                   const uint32_t *indices, size_t nt, uint32_t mesh,
                                   char *err, size_t errlen)
{
    if (!s || (nv > 0 && !positions) || (nt > 0 && !indices) || mesh >= s->num_meshes)
        return sc_scene_errf(err, errlen, SC_ERR_INVALID_ARGUMENT, "NULL scene or buffer");
    if (nt > 0 && nv == 0)
        return sc_scene_errf(err, errlen, SC_ERR_INVALID_ARGUMENT, "triangles without vertices");
    /* The caps come before the first read: a claimed count beyond them is
     * refused without touching a buffer that may not be that long. */
    uint64_t max_v = s->max_triangles > UINT32_MAX / 3 ? UINT32_MAX : 3 * s->max_triangles;
    if (nt > s->max_triangles || nt > SIZE_MAX / 3 || nt > s->max_triangles - s->num_triangles)
        return sc_scene_errf(err, errlen, SC_ERR_LIMIT,
                             "%zu more triangles would exceed the cap of %llu triangles", nt,
                             (unsigned long long)s->max_triangles);
    if (nv > max_v || nv > max_v - s->num_vertices)
        return sc_scene_errf(err, errlen, SC_ERR_LIMIT,
                             "%zu more vertices would exceed the cap of %llu vertices", nv,
                             (unsigned long long)max_v);
    for (size_t i = 0; i < 3 * nt; i++)
        if (indices[i] >= nv)
            return sc_scene_errf(err, errlen, SC_ERR_INVALID_ARGUMENT,
                                 "triangle %zu: vertex index %lu out of range (%zu vertices)",
                                 i / 3, (unsigned long)indices[i], nv);

    size_t bad_vertices = 0;
    for (size_t v = 0; v < nv; v++)
        bad_vertices += !vertex_finite(positions + 3 * v);
    size_t kept = nt;
    if (bad_vertices) {
        kept = 0;
        for (size_t t = 0; t < nt; t++) {
            const uint32_t *ix = indices + 3 * t;
            kept += vertex_finite(positions + 3 * (size_t)ix[0]) &&
                    vertex_finite(positions + 3 * (size_t)ix[1]) &&
                    vertex_finite(positions + 3 * (size_t)ix[2]);
        }
    }

    /* Nothing to copy; on a fresh scene the arrays are still NULL, and
     * NULL + 0 is undefined behaviour (UBSan, fuzz_mesh_buffers). */
    if (nv == 0)
        return SC_OK;
    sc_status st = sc_scene_reserve(s, nv, kept, err, errlen);
    if (st != SC_OK)
        return st;

    uint32_t base = (uint32_t)s->num_vertices;
    float *dst = s->positions + 3 * s->num_vertices;
    for (size_t v = 0; v < nv; v++) {
        const float *p = positions + 3 * v;
        int ok = vertex_finite(p);
        for (int i = 0; i < 3; i++)
            dst[3 * v + i] = ok ? p[i] : 0.0f;
    }
    size_t degenerate = 0, out = s->num_triangles;
    for (size_t t = 0; t < nt; t++) {
        const uint32_t *ix = indices + 3 * t;
        const float *a = positions + 3 * (size_t)ix[0], *b = positions + 3 * (size_t)ix[1],
                    *c = positions + 3 * (size_t)ix[2];
        if (bad_vertices && !(vertex_finite(a) && vertex_finite(b) && vertex_finite(c)))
            continue;
        degenerate += is_degenerate(a, b, c);
        for (int k = 0; k < 3; k++)
            s->indices[3 * out + k] = base + ix[k];
        s->mesh_ids[out] = mesh;
        out++;
    }
    s->num_vertices += nv;
    s->num_triangles = out;
    s->degenerate += degenerate;
    if (kept < nt) {
        s->dropped_nonfinite += nt - kept;
        sc_scene_warnf(s, "mesh %lu: dropped %zu triangles with NaN or infinite vertex coordinates",
                       (unsigned long)mesh, nt - kept);
    }
    return SC_OK;
}

sc_status sc_scene_add_mesh(sc_scene *s, const float *positions, size_t nv,
                            const uint32_t *indices, size_t nt, const float color[3],
                            char *err, size_t errlen)
{
    if (!s)
        return sc_scene_errf(err, errlen, SC_ERR_INVALID_ARGUMENT, "NULL scene");
    uint32_t mesh;
    sc_status st = sc_scene_new_mesh(s, color, &mesh);
    if (st != SC_OK)
        return sc_scene_errf(err, errlen, st, "cannot add another mesh: %s", sc_strerror(st));
    st = sc_scene_append_triangles(s, positions, nv, indices, nt, mesh, err, errlen);
    if (st != SC_OK)
        s->num_meshes--;   /* nothing refers to it yet */
    return st;
}

sc_status sc_scene_set_mesh_emission(sc_scene *s, size_t mesh, const float rgb[3])
{
    if (!s || !rgb || mesh >= s->num_meshes)
        return SC_ERR_INVALID_ARGUMENT;
    for (int i = 0; i < 3; i++)
        if (!(rgb[i] >= 0 && rgb[i] <= SC_SCENE_MAX_EMISSION))
            return SC_ERR_INVALID_ARGUMENT;
    memcpy(s->mesh_emission + 3 * mesh, rgb, 3 * sizeof(float));
    return SC_OK;
}

sc_status sc_scene_add_light(sc_scene *s, const sc_light *l)
{
    if (!s || !l || (l->type != SC_LIGHT_DIRECTIONAL && l->type != SC_LIGHT_POINT))
        return SC_ERR_INVALID_ARGUMENT;
    for (int i = 0; i < 3; i++)
        if (!isfinite(l->vec[i]) || !isfinite(l->color[i]) || l->color[i] < 0)
            return SC_ERR_INVALID_ARGUMENT;
    sc_light copy = *l;
    if (l->type == SC_LIGHT_DIRECTIONAL) {
        double n = sqrt((double)l->vec[0] * l->vec[0] + (double)l->vec[1] * l->vec[1] +
                        (double)l->vec[2] * l->vec[2]);
        if (!(n > 0) || !isfinite(n))
            return SC_ERR_INVALID_ARGUMENT;
        for (int i = 0; i < 3; i++)
            copy.vec[i] = (float)(l->vec[i] / n);
    }
    if (!sc_grow((void **)&s->lights, &s->cap_lights, s->num_lights + 1, sizeof(sc_light)))
        return SC_ERR_OUT_OF_MEMORY;
    s->lights[s->num_lights++] = copy;
    return SC_OK;
}

sc_status sc_scene_set_camera(sc_scene *s, const sc_camera *c)
{
    sc_camera_frame f;
    if (!s || !c || sc_camera_frame_make(c, &f) != SC_OK)
        return SC_ERR_INVALID_ARGUMENT;
    if (c->width > SC_SCENE_MAX_IMAGE_SIDE || c->height > SC_SCENE_MAX_IMAGE_SIDE ||
        (uint64_t)c->width * (uint64_t)c->height > s->max_pixels)
        return SC_ERR_LIMIT;
    s->camera = *c;
    return SC_OK;
}

sc_status sc_scene_set_background(sc_scene *s, const float rgb[3])
{
    if (!s || !rgb)
        return SC_ERR_INVALID_ARGUMENT;
    for (int i = 0; i < 3; i++)
        if (!isfinite(rgb[i]))
            return SC_ERR_INVALID_ARGUMENT;
    for (int i = 0; i < 3; i++)
        s->background[i] = clamp01(rgb[i], 0);
    return SC_OK;
}

void sc_scene_bounds(const sc_scene *s, double lo[3], double hi[3])
{
    for (int i = 0; i < 3; i++) {
        lo[i] = INFINITY;
        hi[i] = -INFINITY;
    }
    for (size_t k = 0; k < 3 * s->num_triangles; k++) {
        const float *p = s->positions + 3 * (size_t)s->indices[k];
        for (int i = 0; i < 3; i++) {
            if (p[i] < lo[i])
                lo[i] = p[i];
            if (p[i] > hi[i])
                hi[i] = p[i];
        }
    }
    if (!(lo[0] <= hi[0]))
        for (int i = 0; i < 3; i++) {
            lo[i] = -1;
            hi[i] = 1;
        }
}

sc_status sc_scene_frame_camera(sc_scene *s, double az, double el, double fov, int w, int h)
{
    if (!s || !isfinite(az) || !isfinite(el) || !(fov > 0 && fov < 180) || w < 1 || h < 1)
        return SC_ERR_INVALID_ARGUMENT;
    double lo[3], hi[3], c[3], r2 = 0;
    sc_scene_bounds(s, lo, hi);
    for (int i = 0; i < 3; i++) {
        c[i] = 0.5 * lo[i] + 0.5 * hi[i];
        double e = 0.5 * hi[i] - 0.5 * lo[i];
        r2 += e * e;
    }
    double r = sqrt(r2);
    if (!(r > 0) || !isfinite(r))
        r = 1;
    /* Straight up or down leaves no horizon to derive "right" from. */
    if (el > 89)
        el = 89;
    if (el < -89)
        el = -89;
    const double d2r = 3.14159265358979323846 / 180;
    double half_y = 0.5 * fov * d2r;
    double half_x = atan(tan(half_y) * w / h);
    double half = half_x < half_y ? half_x : half_y;
    double dist = 1.05 * r / sin(half);
    sc_camera cam;
    default_camera(&cam);
    cam.eye[0] = c[0] + dist * cos(el * d2r) * sin(az * d2r);
    cam.eye[1] = c[1] + dist * sin(el * d2r);
    cam.eye[2] = c[2] + dist * cos(el * d2r) * cos(az * d2r);
    memcpy(cam.target, c, sizeof c);
    cam.fov_y_deg = fov;
    cam.width = w;
    cam.height = h;
    return sc_scene_set_camera(s, &cam);
}

sc_status sc_scene_add_default_light(sc_scene *s)
{
    if (!s)
        return SC_ERR_INVALID_ARGUMENT;
    sc_camera_frame f;
    if (sc_camera_frame_make(&s->camera, &f) != SC_OK)
        return SC_ERR_INVALID_ARGUMENT;
    /* From above, a little left of and behind the viewer: shadows fall
     * visibly to the lower right without hiding the model. */
    sc_light l = { .type = SC_LIGHT_DIRECTIONAL, .color = { 0.9f, 0.9f, 0.9f } };
    for (int i = 0; i < 3; i++)
        l.vec[i] = (float)-(-0.45 * f.right[i] + 1.0 * f.up[i] - 0.6 * f.forward[i]);
    return sc_scene_add_light(s, &l);
}

sc_status sc_scene_get_view(const sc_scene *s, sc_scene_view *v)
{
    if (!s || !v)
        return SC_ERR_INVALID_ARGUMENT;
    memset(&v->mesh, 0, sizeof v->mesh);
    v->mesh.positions = s->positions;
    v->mesh.indices = s->indices;
    v->mesh_ids = s->mesh_ids;
    v->mesh_colors = s->mesh_colors;
    v->mesh_emission = s->mesh_emission;
    v->lights = s->lights;
    v->mesh.vertex_count = s->num_vertices;
    v->mesh.triangle_count = s->num_triangles;
    v->num_meshes = s->num_meshes;
    v->num_lights = s->num_lights;
    v->camera = s->camera;
    memcpy(v->background, s->background, sizeof v->background);
    v->ambient = s->ambient;
    v->objects = s->objects;
    v->instances = s->instances;
    v->num_objects = s->num_objects;
    v->num_instances = s->num_instances;
    return SC_OK;
}

sc_status sc_scene_add_instances(sc_scene *s, const sc_scene *sub, const float (*xfm)[12], size_t count,
                                 const float *color, const float *emission, const char *what, char *err,
                                 size_t errlen)
{
    const size_t nt = sub->num_triangles, nv = sub->num_vertices;
    if (!nt || !count)
        return SC_OK;
    if (count > s->max_triangles / nt || count * nt > s->max_triangles - s->num_triangles)
        return sc_scene_errf(err, errlen, SC_ERR_LIMIT,
                             "%s: %zu instances of %zu triangles exceed the cap of %llu triangles", what, count, nt,
                             (unsigned long long)s->max_triangles);
    if (nv > UINT32_MAX || count * nv > UINT32_MAX - s->num_vertices)
        return sc_scene_errf(err, errlen, SC_ERR_LIMIT, "%s: instances need more than 2^32 vertices", what);
    sc_status st = sc_scene_reserve(s, count * nv, count * nt, err, errlen);
    if (st != SC_OK)
        return st;
    if (!sc_grow((void **)&s->objects, &s->cap_objects, s->num_objects + 1, sizeof *s->objects) ||
        !sc_grow((void **)&s->instances, &s->cap_instances, s->num_instances + count, sizeof *s->instances))
        return sc_scene_errf(err, errlen, SC_ERR_OUT_OF_MEMORY, "%s: out of memory", what);
    /* the object: one block, positions then indices */
    float *block = malloc(12 * nv + 12 * nt);
    if (!block)
        return sc_scene_errf(err, errlen, SC_ERR_OUT_OF_MEMORY, "%s: out of memory", what);
    uint32_t *oidx = (uint32_t *)(void *)(block + 3 * nv);
    memcpy(block, sub->positions, 12 * nv);
    memcpy(oidx, sub->indices, 12 * nt);
    const size_t first_mesh = s->num_meshes;
    for (size_t m = 0; st == SC_OK && m < sub->num_meshes; m++) {
        uint32_t id;
        st = sc_scene_new_mesh(s, color ? color : sub->mesh_colors + 3 * m, &id);
        if (st == SC_OK && (emission || sub->mesh_emission))
            st = sc_scene_set_mesh_emission(s, id, emission ? emission : sub->mesh_emission + 3 * m);
    }
    if (st != SC_OK) {
        s->num_meshes = first_mesh;
        free(block);
        return sc_scene_errf(err, errlen, st, "%s: cannot add meshes: %s", what, sc_strerror(st));
    }
    const size_t v0 = s->num_vertices, t0 = s->num_triangles;
    for (size_t c = 0; c < count; c++) {
        const float *x = xfm[c];
        const uint32_t base = (uint32_t)(v0 + c * nv);
        for (size_t v = 0; v < nv; v++) {
            const float *q = sub->positions + 3 * v;
            for (int i = 0; i < 3; i++) {
                const float f = (float)((double)x[4 * i] * q[0] + (double)x[4 * i + 1] * q[1] +
                                        (double)x[4 * i + 2] * q[2] + x[4 * i + 3]);
                if (!isfinite(f)) {
                    s->num_meshes = first_mesh;
                    free(block);
                    return sc_scene_errf(err, errlen, SC_ERR_RANGE, "%s: instance %zu overflows float", what, c);
                }
                s->positions[3 * (base + v) + i] = f;
            }
        }
        for (size_t t = 0; t < nt; t++) {
            const size_t dst = t0 + c * nt + t;
            for (int k = 0; k < 3; k++)
                s->indices[3 * dst + k] = base + sub->indices[3 * t + k];
            s->mesh_ids[dst] = (uint32_t)first_mesh + sub->mesh_ids[t];
        }
        sc_scene_instance *in = &s->instances[s->num_instances + c];
        in->object = (uint32_t)s->num_objects;
        memcpy(in->xfm, x, sizeof in->xfm);
        in->first_triangle = t0 + c * nt;
    }
    s->objects[s->num_objects++] = (sc_mesh_view){ block, nv, oidx, nt, 0, 0 };
    s->num_instances += count;
    s->num_vertices = v0 + count * nv;
    s->num_triangles = t0 + count * nt;
    s->degenerate += count * sub->degenerate;
    s->dropped_nonfinite += count * sub->dropped_nonfinite;
    return SC_OK;
}

sc_status sc_scene_get_stats(const sc_scene *s, sc_scene_stats *st)
{
    if (!s || !st)
        return SC_ERR_INVALID_ARGUMENT;
    memset(st, 0, sizeof *st);
    st->triangles = s->num_triangles;
    st->vertices = s->num_vertices;
    st->meshes = s->num_meshes;
    st->degenerate_triangles = s->degenerate;
    st->dropped_nonfinite = s->dropped_nonfinite;
    st->skipped_primitives = s->skipped_primitives;
    st->warnings = s->warnings;
    st->bytes = s->num_vertices * 3 * sizeof(float) +
                s->num_triangles * (3 * sizeof(uint32_t) + sizeof(uint32_t));
    st->bytes_per_triangle = s->num_triangles ? (double)st->bytes / (double)s->num_triangles : 0;
    sc_scene_bounds(s, st->bounds_min, st->bounds_max);
    return SC_OK;
}

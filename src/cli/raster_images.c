/* See raster_images.h. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "common/sc_clock.h"
#include "common/sc_names.h"
#include "raster_images.h"

int raster_unavailable(const char *cmd)
{
    sc_cli_error(cmd, "this build has no OSMesa raster reference (configure with libosmesa6-dev)");
    return 1;
}

static const sc_name depth_modes[] = {
    { "auto", SC_RASTER_DEPTH_AUTO },
    { "float", SC_RASTER_DEPTH_FLOAT_REVERSED },
    { "fixed24", SC_RASTER_DEPTH_FIXED24 },
};

static int parse_vec3(const char *cmd, const char *opt, const char *s, double v[3])
{
    char *end;
    const char *p = s;
    for (int i = 0; i < 3; i++) {
        errno = 0;
        v[i] = strtod(p, &end);
        if (errno || end == p || !isfinite(v[i]) || (i < 2 && *end != ',') || (i == 2 && *end)) {
            sc_cli_error(cmd, "%s wants X,Y,Z, not '%s'", opt, s);
            return 0;
        }
        p = end + 1;
    }
    return 1;
}

int raster_common_option(const char *cmd, int which, const char *val, raster_args *a)
{
    long v;
    int m;
    switch (which) {
    case -1:
        if (a->scene) {
            sc_cli_error(cmd, "one scene only ('%s' and '%s')", a->scene, val);
            return 2;
        }
        a->scene = val;
        return 0;
    case 0:
    case 1:
        if (sc_cli_int(cmd, which ? "height" : "width", val, 1, SC_SCENE_MAX_IMAGE_SIDE, &v) != 0)
            return 2;
        *(which ? &a->height : &a->width) = (int)v;
        return 0;
    case 2:
        if (sc_name_lookup(depth_modes, SC_NAMES_COUNT(depth_modes), val, &m) != 0) {
            sc_cli_error(cmd, "--depth-mode is auto, float or fixed24, not '%s'", val);
            return 2;
        }
        a->depth_mode = (sc_raster_depth_mode)m;
        return 0;
    case 3:
        return (a->has_eye = parse_vec3(cmd, "--eye", val, a->eye)) ? 0 : 2;
    case 4:
        return (a->has_target = parse_vec3(cmd, "--target", val, a->target)) ? 0 : 2;
    case 5: {
        char *end;
        a->fov = strtod(val, &end);
        if (end == val || *end || !(a->fov > 0 && a->fov < 180)) {
            sc_cli_error(cmd, "--fov wants degrees in (0, 180), not '%s'", val);
            return 2;
        }
        return 0;
    }
    }
    return 0;
}

#ifdef SC_HAVE_OSMESA
const char *raster_depth_mode_name(sc_raster_depth_mode m)
{
    return m == SC_RASTER_DEPTH_FLOAT_REVERSED ? "float32 reversed-Z"
         : m == SC_RASTER_DEPTH_FIXED24        ? "fixed 24-bit"
                                               : "auto";
}


static void warn_cb(void *ctx, const char *message)
{
    fprintf(stderr, "spherecull: %s: warning: %s\n", (const char *)ctx, message);
}

static uint8_t to_byte(float v)
{
    double x = v * 255.0 + 0.5;
    return (uint8_t)(x < 0 ? 0 : x > 255 ? 255 : x);
}

int raster_load(const char *cmd, const raster_args *a, loaded *L)
{
    memset(L, 0, sizeof *L);
    sc_scene_options so;
    sc_scene_options_init(&so);
    so.warn = warn_cb;
    so.warn_ctx = (void *)cmd;
    char err[256] = "";
    sc_status st = sc_scene_load(a->scene, &so, &L->scene, err, sizeof err);
    if (st != SC_OK) {
        /* The loader's message already names the file. */
        if (err[0])
            sc_cli_error(cmd, "%s", err);
        else
            sc_cli_error(cmd, "%s: %s", a->scene, sc_strerror(st));
        return 0;
    }
    if ((st = sc_scene_get_view(L->scene, &L->view)) != SC_OK) {
        sc_cli_error(cmd, "%s: %s", a->scene, sc_strerror(st));
        return 0;
    }
    const sc_scene_view *v = &L->view;
    L->cam = v->camera;
    if (a->width)
        L->cam.width = a->width;
    if (a->height)
        L->cam.height = a->height;
    if (a->has_eye)
        memcpy(L->cam.eye, a->eye, sizeof a->eye);
    if (a->has_target)
        memcpy(L->cam.target, a->target, sizeof a->target);
    if (a->fov > 0)
        L->cam.fov_y_deg = a->fov;
    sc_camera_frame fr;
    if (sc_camera_frame_make(&L->cam, &fr) != SC_OK) {
        sc_cli_error(cmd, "camera: eye and target coincide, or the view is parallel to up");
        return 0;
    }
    L->colors = malloc((v->mesh.triangle_count ? v->mesh.triangle_count : 1) * 3 * sizeof *L->colors);
    if (!L->colors) {
        sc_cli_error(cmd, "out of memory for %zu triangle colours", v->mesh.triangle_count);
        return 0;
    }
    for (size_t t = 0; t < v->mesh.triangle_count; t++)
        memcpy(L->colors + 3 * t, v->mesh_colors + 3 * (size_t)v->mesh_ids[t], 3 * sizeof(float));
    L->mesh = v->mesh;
    sc_raster_options_default(&L->opt);
    L->opt.colors = L->colors;
    L->opt.depth_mode = a->depth_mode;
    for (int i = 0; i < 3; i++)
        L->opt.background[i] = to_byte(v->background[i]);
    /* The scene's first directional light; the preview wants the direction
     * towards it, the scene stores the direction it travels. */
    for (size_t k = 0; k < v->num_lights; k++)
        if (v->lights[k].type == SC_LIGHT_DIRECTIONAL) {
            for (int i = 0; i < 3; i++)
                L->opt.light_dir[i] = -(double)v->lights[k].vec[i];
            break;
        }
    return 1;
}

void raster_unload(loaded *L)
{
    free(L->colors);
    sc_scene_free(L->scene);
    memset(L, 0, sizeof *L);
}

int raster_render(const char *cmd, loaded *L, sc_raster_image *img, double *seconds)
{
    double t0 = sc_now_seconds();
    sc_status st = sc_raster_render(&L->mesh, &L->cam, &L->opt, img);
    *seconds = sc_now_seconds() - t0;
    if (st != SC_OK) {
        sc_cli_error(cmd, "raster: %s", img->error[0] ? img->error : sc_strerror(st));
        return 0;
    }
    return 1;
}

int raster_write_png(const char *cmd, const char *path, const sc_image *im)
{
    char err[256] = "";
    sc_status st = sc_png_write(path, im, err, sizeof err);
    if (st != SC_OK) {
        sc_cli_error(cmd, "%s: %s", path, err[0] ? err : sc_strerror(st));
        return 0;
    }
    return 1;
}

static int alloc_image(const char *cmd, sc_image *im, int w, int h)
{
    sc_status st = sc_image_alloc(im, w, h);
    if (st != SC_OK) {
        sc_cli_error(cmd, "%dx%d image: %s", w, h, sc_strerror(st));
        return 0;
    }
    return 1;
}

/* IDs as 24-bit RGB, lossless: R = bits 0-7, G = 8-15, B = 16-23. */
int raster_write_ids(const char *cmd, const char *path, const sc_raster_image *img, size_t ntri)
{
    if (ntri >= (1u << 24)) {
        sc_cli_error(cmd, "--ids: %zu triangles do not fit 24-bit RGB IDs", ntri);
        return 0;
    }
    sc_image im;
    if (!alloc_image(cmd, &im, img->width, img->height))
        return 0;
    for (size_t p = 0; p < (size_t)img->width * (size_t)img->height; p++) {
        uint32_t id = img->ids[p];
        im.rgb[3 * p + 0] = (uint8_t)(id & 0xff);
        im.rgb[3 * p + 1] = (uint8_t)((id >> 8) & 0xff);
        im.rgb[3 * p + 2] = (uint8_t)((id >> 16) & 0xff);
    }
    int ok = raster_write_png(cmd, path, &im);
    sc_image_free(&im);
    return ok;
}

/* Depth as a picture: 1/t mapped linearly between the nearest and farthest
 * visible pixel (near bright, far dark, background black). 1/t spreads
 * detail like the eye sees it; the range goes to stdout. */
int raster_write_depth(const char *cmd, const char *path, const sc_raster_image *img,
                       double *tmin_out, double *tmax_out)
{
    size_t n = (size_t)img->width * (size_t)img->height;
    double tmin = INFINITY, tmax = 0;
    for (size_t p = 0; p < n; p++)
        if (img->ids[p]) {
            double t = img->depth[p];
            tmin = t < tmin ? t : tmin;
            tmax = t > tmax ? t : tmax;
        }
    sc_image im;
    if (!alloc_image(cmd, &im, img->width, img->height))
        return 0;
    double a = 1 / tmax, b = 1 / tmin;
    for (size_t p = 0; p < n; p++) {
        if (!img->ids[p])
            continue;
        double s = b > a ? (1 / (double)img->depth[p] - a) / (b - a) : 1;
        uint8_t g = (uint8_t)(40 + 215 * (s < 0 ? 0 : s > 1 ? 1 : s) + 0.5);
        im.rgb[3 * p] = im.rgb[3 * p + 1] = im.rgb[3 * p + 2] = g;
    }
    int ok = raster_write_png(cmd, path, &im);
    sc_image_free(&im);
    *tmin_out = tmin;
    *tmax_out = tmax;
    return ok;
}

/* Grey, darkened preview with each disagreement painted over it as a 3x3
 * dot (single pixels vanish at full size), worse classes on top. */
int raster_write_map(const char *cmd, const char *path, const sc_raster_image *img, const uint8_t *cls)
{
    static const uint8_t paint[SC_RASTER_DIFF_COUNT][3] = {
        { 255, 200, 0 },         /* at-edge: amber */
        { 0, 170, 255 },         /* depth-tie: blue */
        { 255, 0, 40 },          /* elsewhere: red */
    };
    int w = img->width, h = img->height;
    sc_image im;
    if (!alloc_image(cmd, &im, w, h))
        return 0;
    for (size_t p = 0; p < (size_t)w * (size_t)h; p++) {
        const uint8_t *c = img->rgb + 3 * p;
        uint8_t g = (uint8_t)((c[0] * 77 + c[1] * 150 + c[2] * 29) >> 8);
        im.rgb[3 * p] = im.rgb[3 * p + 1] = im.rgb[3 * p + 2] = (uint8_t)(g * 2 / 5);
    }
    for (int k = 0; k < SC_RASTER_DIFF_COUNT; k++)
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                if (cls[(size_t)y * (size_t)w + (size_t)x] != 1 + k)
                    continue;
                for (int yy = y - 1; yy <= y + 1; yy++)
                    for (int xx = x - 1; xx <= x + 1; xx++)
                        if (xx >= 0 && yy >= 0 && xx < w && yy < h)
                            memcpy(im.rgb + 3 * ((size_t)yy * (size_t)w + (size_t)xx), paint[k], 3);
            }
    int ok = raster_write_png(cmd, path, &im);
    sc_image_free(&im);
    return ok;
}

/* "map.png" -> "map-embree.png" for the second and later tracers. */
char *raster_suffixed(const char *path, const char *name)
{
    size_t len = strlen(path), nl = strlen(name);
    char *s = malloc(len + nl + 2);
    if (!s)
        return NULL;
    const char *dot = strrchr(path, '.');
    const char *slash = strrchr(path, '/');
    size_t cut = dot && (!slash || dot > slash) ? (size_t)(dot - path) : len;
    memcpy(s, path, cut);
    s[cut] = '-';
    memcpy(s + cut + 1, name, nl);
    memcpy(s + cut + 1 + nl, path + cut, len - cut + 1);
    return s;
}

/* Perceptual ramp (inferno-like, 5 stops) for the sphere overlay. */
static void ramp(double s, uint8_t out[3])
{
    static const double stops[5][3] = {
        { 0, 0, 4 }, { 87, 16, 110 }, { 188, 55, 84 }, { 249, 142, 9 }, { 252, 255, 164 }
    };
    s = s < 0 ? 0 : s > 1 ? 1 : s;
    double f = s * 4;
    int i = f >= 4 ? 3 : (int)f;
    double u = f - i;
    for (int c = 0; c < 3; c++)
        out[c] = (uint8_t)(stops[i][c] + u * (stops[i + 1][c] - stops[i][c]) + 0.5);
}

/* Per-pixel sphere tests on a log scale, 75% over the grey preview. */
int raster_write_overlay(const char *cmd, const char *path, const sc_raster_image *img,
                         const uint32_t *tests, uint32_t *max_out)
{
    size_t n = (size_t)img->width * (size_t)img->height;
    uint32_t mx = 0;
    for (size_t p = 0; p < n; p++)
        mx = tests[p] > mx ? tests[p] : mx;
    sc_image im;
    if (!alloc_image(cmd, &im, img->width, img->height))
        return 0;
    double scale = mx > 0 ? log1p((double)mx) : 1;
    for (size_t p = 0; p < n; p++) {
        uint8_t col[3];
        ramp(log1p((double)tests[p]) / scale, col);
        const uint8_t *c = img->rgb + 3 * p;
        double g = (c[0] * 0.3 + c[1] * 0.59 + c[2] * 0.11);
        for (int k = 0; k < 3; k++)
            im.rgb[3 * p + k] = (uint8_t)(0.75 * col[k] + 0.25 * g + 0.5);
    }
    int ok = raster_write_png(cmd, path, &im);
    sc_image_free(&im);
    *max_out = mx;
    return ok;
}
#endif

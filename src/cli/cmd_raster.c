/* spherecull raster / raster-check: the OSMesa raster reference on a scene.
 *
 *   raster        the scene rasterized with the scene's camera: a lit preview,
 *                 optionally the triangle-ID buffer and a depth picture.
 *   raster-check  the ID buffer against primary-ray hits of our tracer (and
 *                 Embree when built in): agreement, every disagreement
 *                 classified (sc_raster_classify), a map of where they are,
 *                 and optionally the sphere-test overlay.
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/sc_clock.h"
#include "commands.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_image.h"
#include "spherecull/sc_rays.h"
#include "spherecull/sc_scene.h"
#include "spherecull/sc_trace.h"
#ifdef SC_HAVE_OSMESA
#include "spherecull/sc_raster.h"
#endif
#ifdef SC_HAVE_EMBREE
#include "spherecull/sc_embree.h"
#endif

#ifndef SC_HAVE_OSMESA
static int no_osmesa(const char *cmd)
{
    sc_cli_error(cmd, "this build has no OSMesa raster reference (configure with libosmesa6-dev)");
    return 1;
}
int sc_cmd_raster(int argc, char **argv)
{
    (void)argc;
    return no_osmesa(argv[0]);
}
int sc_cmd_raster_check(int argc, char **argv)
{
    (void)argc;
    return no_osmesa(argv[0]);
}
#else

/* Options both commands share. */
typedef struct common_args {
    const char *scene;
    int width, height;           /* 0: the scene's */
    sc_raster_depth_mode depth_mode;
    int has_eye, has_target;
    double eye[3], target[3], fov;   /* camera overrides; fov 0: the scene's */
} common_args;

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

static int parse_int(const char *cmd, const char *opt, const char *s, int lo, int hi, int *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) {
        sc_cli_error(cmd, "%s wants an integer in [%d, %d], not '%s'", opt, lo, hi, s);
        return 0;
    }
    *out = (int)v;
    return 1;
}

/* Returns 1 if argv[*i] was a shared option (consumed, with its value),
 * 0 if not, -1 on a bad value. */
static int parse_common(const char *cmd, int argc, char **argv, int *i, common_args *a)
{
    const char *o = argv[*i];
    int takes = strcmp(o, "--width") == 0 || strcmp(o, "--height") == 0 ||
                strcmp(o, "--depth-mode") == 0 || strcmp(o, "--eye") == 0 ||
                strcmp(o, "--target") == 0 || strcmp(o, "--fov") == 0;
    if (!takes)
        return 0;
    if (*i + 1 >= argc) {
        sc_cli_error(cmd, "%s needs a value", o);
        return -1;
    }
    const char *v = argv[++*i];
    if (strcmp(o, "--width") == 0)
        return parse_int(cmd, o, v, 1, SC_SCENE_MAX_IMAGE_SIDE, &a->width) ? 1 : -1;
    if (strcmp(o, "--height") == 0)
        return parse_int(cmd, o, v, 1, SC_SCENE_MAX_IMAGE_SIDE, &a->height) ? 1 : -1;
    if (strcmp(o, "--eye") == 0)
        return (a->has_eye = parse_vec3(cmd, o, v, a->eye)) ? 1 : -1;
    if (strcmp(o, "--target") == 0)
        return (a->has_target = parse_vec3(cmd, o, v, a->target)) ? 1 : -1;
    if (strcmp(o, "--fov") == 0) {
        char *end;
        a->fov = strtod(v, &end);
        if (end == v || *end || !(a->fov > 0 && a->fov < 180)) {
            sc_cli_error(cmd, "--fov wants degrees in (0, 180), not '%s'", v);
            return -1;
        }
        return 1;
    }
    if (strcmp(v, "auto") == 0)
        a->depth_mode = SC_RASTER_DEPTH_AUTO;
    else if (strcmp(v, "float") == 0)
        a->depth_mode = SC_RASTER_DEPTH_FLOAT_REVERSED;
    else if (strcmp(v, "fixed24") == 0)
        a->depth_mode = SC_RASTER_DEPTH_FIXED24;
    else {
        sc_cli_error(cmd, "--depth-mode is auto, float or fixed24, not '%s'", v);
        return -1;
    }
    return 1;
}

static const char *depth_mode_name(sc_raster_depth_mode m)
{
    return m == SC_RASTER_DEPTH_FLOAT_REVERSED ? "float32 reversed-Z"
         : m == SC_RASTER_DEPTH_FIXED24        ? "fixed 24-bit"
                                               : "auto";
}

/* A loaded scene as the raster reference wants it. */
typedef struct loaded {
    sc_scene *scene;
    sc_scene_view view;
    sc_camera cam;
    float *colors;               /* per triangle, from the mesh colours */
    sc_raster_mesh mesh;
    sc_raster_options opt;
} loaded;

static void warn_cb(void *ctx, const char *message)
{
    fprintf(stderr, "spherecull: %s: warning: %s\n", (const char *)ctx, message);
}

static uint8_t to_byte(float v)
{
    double x = v * 255.0 + 0.5;
    return (uint8_t)(x < 0 ? 0 : x > 255 ? 255 : x);
}

static int load(const char *cmd, const common_args *a, loaded *L)
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
    L->colors = malloc((v->num_triangles ? v->num_triangles : 1) * 3 * sizeof *L->colors);
    if (!L->colors) {
        sc_cli_error(cmd, "out of memory for %zu triangle colours", v->num_triangles);
        return 0;
    }
    for (size_t t = 0; t < v->num_triangles; t++)
        memcpy(L->colors + 3 * t, v->mesh_colors + 3 * (size_t)v->mesh_ids[t], 3 * sizeof(float));
    L->mesh.positions = v->positions;
    L->mesh.vertex_count = v->num_vertices;
    L->mesh.indices = v->indices;
    L->mesh.triangle_count = v->num_triangles;
    L->mesh.colors = L->colors;
    sc_raster_options_default(&L->opt);
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

static void unload(loaded *L)
{
    free(L->colors);
    sc_scene_free(L->scene);
    memset(L, 0, sizeof *L);
}

static int render(const char *cmd, loaded *L, sc_raster_image *img, double *seconds)
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

/* Atomic writers rename a temporary file over the target: over /dev/null or
 * a FIFO that would replace the device node, so only regular files (or new
 * names) are accepted as outputs. */
static int output_ok(const char *cmd, const char *path)
{
    struct stat sb;
    if (stat(path, &sb) == 0 && !S_ISREG(sb.st_mode)) {
        sc_cli_error(cmd, "%s: not a regular file; outputs replace their target", path);
        return 0;
    }
    return 1;
}

static int write_png(const char *cmd, const char *path, const sc_image *im)
{
    if (!output_ok(cmd, path))
        return 0;
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
static int write_ids(const char *cmd, const char *path, const sc_raster_image *img, size_t ntri)
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
    int ok = write_png(cmd, path, &im);
    sc_image_free(&im);
    return ok;
}

/* Depth as a picture: 1/t mapped linearly between the nearest and farthest
 * visible pixel (near bright, far dark, background black). 1/t spreads
 * detail like the eye sees it; the range goes to stdout. */
static int write_depth(const char *cmd, const char *path, const sc_raster_image *img,
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
    int ok = write_png(cmd, path, &im);
    sc_image_free(&im);
    *tmin_out = tmin;
    *tmax_out = tmax;
    return ok;
}

static void raster_usage(FILE *f)
{
    fprintf(f,
            "usage: spherecull raster SCENE -o PREVIEW.png [--ids IDS.png] [--depth DEPTH.png]\n"
            "                         [--width W] [--height H] [--depth-mode auto|float|fixed24]\n"
            "                         [--eye X,Y,Z] [--target X,Y,Z] [--fov DEG]\n"
            "Rasterizes SCENE (see 'spherecull --help' for scene specs) offscreen with OSMesa,\n"
            "with the scene's camera. PREVIEW: flat-shaded, one directional light.\n"
            "IDS: triangle index + 1 as 24-bit RGB (R low byte), black = background.\n"
            "DEPTH: 1/t between the nearest and farthest visible pixel, near bright.\n");
}

int sc_cmd_raster(int argc, char **argv)
{
    const char *cmd = argv[0];
    common_args a = { 0 };
    const char *out = NULL, *ids = NULL, *depth = NULL;
    for (int i = 1; i < argc; i++) {
        int c = parse_common(cmd, argc, argv, &i, &a);
        if (c < 0)
            return 2;
        if (c > 0)
            continue;
        const char *o = argv[i];
        if (strcmp(o, "--help") == 0 || strcmp(o, "-h") == 0) {
            raster_usage(stdout);
            return 0;
        }
        const char **dst = strcmp(o, "-o") == 0 || strcmp(o, "--output") == 0 ? &out
                         : strcmp(o, "--ids") == 0                           ? &ids
                         : strcmp(o, "--depth") == 0                         ? &depth
                                                                             : NULL;
        if (dst) {
            if (i + 1 >= argc) {
                sc_cli_error(cmd, "%s needs a file name", o);
                return 2;
            }
            *dst = argv[++i];
        } else if (o[0] == '-' && o[1] != '\0') {
            sc_cli_error(cmd, "unknown option '%s' (try --help)", o);
            return 2;
        } else if (!a.scene) {
            a.scene = o;
        } else {
            sc_cli_error(cmd, "one scene only ('%s' and '%s')", a.scene, o);
            return 2;
        }
    }
    if (!a.scene || !out) {
        sc_cli_error(cmd, "needs SCENE and -o PREVIEW.png (try --help)");
        return 2;
    }
    if (sc_cli_check_output(cmd, "-o", out) != 0 || sc_cli_check_output(cmd, "--ids", ids) != 0 ||
        sc_cli_check_output(cmd, "--depth", depth) != 0)
        return 1;
    loaded L;
    sc_raster_image img = { 0 };
    int rc = 1;
    double secs = 0;
    if (!load(cmd, &a, &L) || !render(cmd, &L, &img, &secs))
        goto done;
    sc_image prev = { img.width, img.height, img.rgb };
    if (!write_png(cmd, out, &prev))
        goto done;
    if (ids && !write_ids(cmd, ids, &img, L.mesh.triangle_count))
        goto done;
    double tmin = 0, tmax = 0;
    if (depth && !write_depth(cmd, depth, &img, &tmin, &tmax))
        goto done;
    size_t covered = 0;
    for (size_t p = 0; p < (size_t)img.width * (size_t)img.height; p++)
        covered += img.ids[p] != 0;
    printf("scene      %s: %zu triangles, %zu vertices\n", a.scene, L.mesh.triangle_count,
           L.mesh.vertex_count);
    printf("image      %dx%d, %.2f%% covered, raster %.3f s\n", img.width, img.height,
           100.0 * (double)covered / ((double)img.width * img.height), secs);
    printf("depth      %s (%d bits), near %.6g, far %.6g\n", depth_mode_name(img.depth_mode),
           img.depth_bits, img.near_dist, img.far_dist);
    printf("wrote      %s", out);
    if (ids)
        printf(", %s", ids);
    if (depth)
        printf(", %s (t from %.6g bright to %.6g dark)", depth, tmin, tmax);
    printf("\n");
    rc = 0;
done:
    sc_raster_image_free(&img);
    unload(&L);
    return rc;
}

/* ---- raster-check -------------------------------------------------------- */

typedef struct tracer_result {
    const char *name;
    uint32_t *ids;               /* per pixel, same encoding as the raster */
    double seconds;
    size_t agree, kinds[SC_RASTER_DIFF_COUNT];
    double max_edge_px;          /* over at-edge disagreements */
    uint8_t *cls;                /* per pixel: 0 agree, 1 + sc_raster_diff */
} tracer_result;

typedef struct check_report {
    const char *scene;
    const sc_raster_image *img;
    const tracer_result *tr;
    int ntr;
    const loaded *L;
} check_report;

static int write_summary_csv(void *ctx, FILE *f)
{
    const check_report *r = ctx;
    size_t n = (size_t)r->img->width * (size_t)r->img->height;
    fprintf(f, "scene,tracer,width,height,depth_mode,pixels,agree,agree_pct,at_edge,depth_tie,"
               "elsewhere,max_edge_px\n");
    for (int k = 0; k < r->ntr; k++) {
        const tracer_result *t = &r->tr[k];
        fprintf(f, "\"%s\",%s,%d,%d,%s,%zu,%zu,%.4f,%zu,%zu,%zu,%.4f\n", r->scene, t->name,
                r->img->width, r->img->height,
                r->img->depth_mode == SC_RASTER_DEPTH_FIXED24 ? "fixed24" : "float",
                n, t->agree, 100.0 * (double)t->agree / (double)n,
                t->kinds[SC_RASTER_DIFF_AT_EDGE], t->kinds[SC_RASTER_DIFF_DEPTH_TIE],
                t->kinds[SC_RASTER_DIFF_ELSEWHERE], t->max_edge_px);
    }
    return 0;
}

/* Every disagreement, one row each. */
static int write_pixels_csv(void *ctx, FILE *f)
{
    const check_report *r = ctx;
    const sc_raster_image *img = r->img;
    fprintf(f, "tracer,x,y,raster_prim,tracer_prim,class,edge_px\n");
    for (int k = 0; k < r->ntr; k++) {
        const tracer_result *t = &r->tr[k];
        for (int y = 0; y < img->height; y++)
            for (int x = 0; x < img->width; x++) {
                size_t p = (size_t)y * (size_t)img->width + (size_t)x;
                if (!t->cls[p])
                    continue;
                double dist = NAN;
                sc_raster_edge_distance(&r->L->mesh, &r->L->cam, img->near_dist, x, y,
                                        img->ids[p], t->ids[p], &dist);
                fprintf(f, "%s,%d,%d,%ld,%ld,%s,%.4f\n", t->name, x, y, (long)img->ids[p] - 1,
                        (long)t->ids[p] - 1, sc_raster_diff_name((sc_raster_diff)(t->cls[p] - 1)),
                        dist);
            }
    }
    return 0;
}

/* Grey, darkened preview with each disagreement painted over it as a 3x3
 * dot (single pixels vanish at full size), worse classes on top. */
static int write_map(const char *cmd, const char *path, const sc_raster_image *img,
                     const tracer_result *t)
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
                if (t->cls[(size_t)y * (size_t)w + (size_t)x] != 1 + k)
                    continue;
                for (int yy = y - 1; yy <= y + 1; yy++)
                    for (int xx = x - 1; xx <= x + 1; xx++)
                        if (xx >= 0 && yy >= 0 && xx < w && yy < h)
                            memcpy(im.rgb + 3 * ((size_t)yy * (size_t)w + (size_t)xx), paint[k], 3);
            }
    int ok = write_png(cmd, path, &im);
    sc_image_free(&im);
    return ok;
}

/* "map.png" -> "map-embree.png" for the second and later tracers. */
static char *suffixed(const char *path, const char *name)
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
static int write_overlay(const char *cmd, const char *path, const sc_raster_image *img,
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
    int ok = write_png(cmd, path, &im);
    sc_image_free(&im);
    *max_out = mx;
    return ok;
}

static int classify_all(const char *cmd, loaded *L, const sc_raster_image *img,
                        tracer_result *t)
{
    size_t n = (size_t)img->width * (size_t)img->height;
    t->cls = calloc(n, 1);
    if (!t->cls) {
        sc_cli_error(cmd, "out of memory");
        return 0;
    }
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++) {
            size_t p = (size_t)y * (size_t)img->width + (size_t)x;
            if (t->ids[p] == img->ids[p]) {
                t->agree++;
                continue;
            }
            sc_raster_diff kind;
            double dist;
            sc_status st = sc_raster_classify(&L->mesh, &L->cam, img, x, y, t->ids[p], &kind, &dist);
            if (st != SC_OK) {
                sc_cli_error(cmd, "classify pixel %d,%d: %s", x, y, sc_strerror(st));
                return 0;
            }
            t->kinds[kind]++;
            t->cls[p] = (uint8_t)(1 + kind);
            if (kind == SC_RASTER_DIFF_AT_EDGE && dist > t->max_edge_px)
                t->max_edge_px = dist;
        }
    return 1;
}

static void check_usage(FILE *f)
{
    fprintf(f,
            "usage: spherecull raster-check SCENE [--csv FILE] [--pixels FILE] [--map MAP.png]\n"
            "                               [--overlay FILE.png] [--prefilter off|circum|minimal|auto]\n"
            "                               [--no-embree] [--width W] [--height H]\n"
            "                               [--depth-mode auto|float|fixed24]\n"
            "                               [--eye X,Y,Z] [--target X,Y,Z] [--fov DEG]\n"
            "Compares the OSMesa triangle-ID buffer with the primary-ray hits of our tracer\n"
            "(and of Embree, when built in). Each disagreement is at-edge (pixel centre within\n"
            "half a pixel of a projected edge of either triangle), depth-tie (both triangles\n"
            "cover the centre at depths the raster cannot order) or elsewhere (a bug).\n"
            "CSV: one summary row per tracer; --pixels lists every disagreement.\n"
            "MAP: 3x3 dots, at-edge amber, depth-tie blue, elsewhere red, over a dark preview\n"
            "(Embree's map gets '-embree' before the extension).\n"
            "OVERLAY: our tracer's sphere tests per pixel, log colour scale over the preview.\n"
            "Exit status 1 if ours misses the target (>= 99.5%% agreement, 0 elsewhere).\n");
}

int sc_cmd_raster_check(int argc, char **argv)
{
    const char *cmd = argv[0];
    common_args a = { 0 };
    const char *csv = NULL, *map = NULL, *overlay = NULL, *pixels_path = NULL;
    int use_embree = 1;
    sc_prefilter_mode prefilter = SC_PREFILTER_MINIMAL;
    for (int i = 1; i < argc; i++) {
        int c = parse_common(cmd, argc, argv, &i, &a);
        if (c < 0)
            return 2;
        if (c > 0)
            continue;
        const char *o = argv[i];
        if (strcmp(o, "--help") == 0 || strcmp(o, "-h") == 0) {
            check_usage(stdout);
            return 0;
        }
        if (strcmp(o, "--no-embree") == 0) {
            use_embree = 0;
            continue;
        }
        const char **dst = strcmp(o, "--csv") == 0       ? &csv
                         : strcmp(o, "--map") == 0       ? &map
                         : strcmp(o, "--overlay") == 0   ? &overlay
                         : strcmp(o, "--pixels") == 0    ? &pixels_path
                                                         : NULL;
        if (dst || strcmp(o, "--prefilter") == 0) {
            if (i + 1 >= argc) {
                sc_cli_error(cmd, "%s needs a value", o);
                return 2;
            }
            const char *v = argv[++i];
            if (dst)
                *dst = v;
            else if (sc_prefilter_mode_from_name(v, &prefilter) != SC_OK) {
                sc_cli_error(cmd, "--prefilter is off, circum, minimal or auto, not '%s'", v);
                return 2;
            }
        } else if (o[0] == '-' && o[1] != '\0') {
            sc_cli_error(cmd, "unknown option '%s' (try --help)", o);
            return 2;
        } else if (!a.scene) {
            a.scene = o;
        } else {
            sc_cli_error(cmd, "one scene only ('%s' and '%s')", a.scene, o);
            return 2;
        }
    }
    if (!a.scene) {
        sc_cli_error(cmd, "needs a SCENE (try --help)");
        return 2;
    }
    if (sc_cli_check_output(cmd, "--csv", csv) != 0 || sc_cli_check_output(cmd, "--pixels", pixels_path) != 0 ||
        sc_cli_check_output(cmd, "--map", map) != 0 || sc_cli_check_output(cmd, "--overlay", overlay) != 0)
        return 1;

    loaded L;
    sc_raster_image img = { 0 };
    sc_rayset rays = { 0 };
    sc_bvh *bvh = NULL;
    uint32_t *tests = NULL;
    tracer_result tr[2];
    memset(tr, 0, sizeof tr);
    int ntr = 0, rc = 1;
    double raster_secs = 0;
    if (!load(cmd, &a, &L) || !render(cmd, &L, &img, &raster_secs))
        goto done;
    size_t npix = (size_t)img.width * (size_t)img.height;
    if (L.mesh.triangle_count > UINT32_MAX - 1) {
        sc_cli_error(cmd, "too many triangles for 32-bit primitive IDs");
        goto done;
    }
    sc_status st = sc_rayset_primary(&L.cam, &rays);
    if (st != SC_OK) {
        sc_cli_error(cmd, "primary rays: %s", sc_strerror(st));
        goto done;
    }

    /* Ours. */
    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    cfg.prefilter = prefilter;
    double t0 = sc_now_seconds();
    st = sc_bvh_build(L.mesh.positions, L.mesh.vertex_count, L.mesh.indices, L.mesh.triangle_count,
                      &cfg, &bvh);
    if (st != SC_OK) {
        sc_cli_error(cmd, "BVH build: %s", sc_strerror(st));
        goto done;
    }
    double build_secs = sc_now_seconds() - t0;
    tr[0].name = "ours";
    tr[0].ids = malloc(npix * sizeof *tr[0].ids);
    tests = overlay ? calloc(npix, sizeof *tests) : NULL;
    if (!tr[0].ids || (overlay && !tests)) {
        sc_cli_error(cmd, "out of memory");
        goto done;
    }
    ntr = 1;
    sc_trace_stats total = { 0 };
    t0 = sc_now_seconds();
    for (size_t i = 0; i < rays.count; i++) {
        sc_hitrec hit;
        sc_trace_stats s = { 0 };
        st = sc_trace_closest(bvh, &rays.rays[i], &hit, overlay ? &s : NULL);
        if (st != SC_OK) {
            sc_cli_error(cmd, "trace ray %zu: %s", i, sc_strerror(st));
            goto done;
        }
        size_t p = rays.target[i];
        tr[0].ids[p] = hit.prim == SC_HITREC_MISS ? 0 : hit.prim + 1;
        if (tests) {
            tests[p] = (uint32_t)s.sphere_tests;
            total.sphere_tests += s.sphere_tests;
            total.sphere_rejects += s.sphere_rejects;
            total.tri_tests += s.tri_tests;
            total.tri_hits += s.tri_hits;
        }
    }
    tr[0].seconds = sc_now_seconds() - t0;

#ifdef SC_HAVE_EMBREE
    if (use_embree) {
        sc_mesh_view mv = { L.mesh.positions, (uint32_t)L.mesh.vertex_count, L.mesh.indices,
                            (uint32_t)L.mesh.triangle_count };
        sc_embree_config ecfg;
        sc_embree_config_default(&ecfg);
        sc_embree *e = NULL;
        sc_hitrec *hits = malloc(rays.count * sizeof *hits);
        tr[1].name = "embree";
        tr[1].ids = malloc(npix * sizeof *tr[1].ids);
        ntr = 2;
        if (!hits || !tr[1].ids) {
            free(hits);
            sc_cli_error(cmd, "out of memory");
            goto done;
        }
        st = sc_embree_create(&mv, &ecfg, &e);
        if (st == SC_OK) {
            t0 = sc_now_seconds();
            st = sc_embree_intersect1(e, rays.rays, rays.count, hits, NULL);
            tr[1].seconds = sc_now_seconds() - t0;
        }
        sc_embree_destroy(e);
        if (st != SC_OK) {
            free(hits);
            sc_cli_error(cmd, "Embree: %s", sc_strerror(st));
            goto done;
        }
        for (size_t i = 0; i < rays.count; i++)
            tr[1].ids[rays.target[i]] = hits[i].prim == SC_HITREC_MISS ? 0 : hits[i].prim + 1;
        free(hits);
    }
#else
    (void)use_embree;
#endif

    for (int k = 0; k < ntr; k++)
        if (!classify_all(cmd, &L, &img, &tr[k]))
            goto done;

    printf("scene      %s: %zu triangles\n", a.scene, L.mesh.triangle_count);
    printf("raster     %dx%d, %s depth (%d bits), near %.6g, %.3f s\n", img.width, img.height,
           depth_mode_name(img.depth_mode), img.depth_bits, img.near_dist, raster_secs);
    printf("ours       BVH (prefilter %s) built in %.3f s, %zu rays traced in %.3f s\n",
           sc_prefilter_mode_name(prefilter), build_secs, rays.count, tr[0].seconds);
    printf("%-8s %10s %10s %9s %9s %9s %9s %12s\n", "tracer", "pixels", "agree", "agree%",
           "at-edge", "depth-tie", "elsewhere", "max-edge-px");
    for (int k = 0; k < ntr; k++) {
        const tracer_result *t = &tr[k];
        printf("%-8s %10zu %10zu %8.4f%% %9zu %9zu %9zu %12.4f\n", t->name, npix, t->agree,
               100.0 * (double)t->agree / (double)npix, t->kinds[SC_RASTER_DIFF_AT_EDGE],
               t->kinds[SC_RASTER_DIFF_DEPTH_TIE], t->kinds[SC_RASTER_DIFF_ELSEWHERE],
               t->max_edge_px);
    }
    /* The first few "elsewhere" pixels, to start debugging from. */
    for (int k = 0; k < ntr; k++) {
        int shown = 0;
        for (size_t p = 0; p < npix && shown < 5; p++)
            if (tr[k].cls[p] == 1 + SC_RASTER_DIFF_ELSEWHERE) {
                printf("  %s elsewhere: pixel %zu,%zu raster prim %ld, %s prim %ld\n", tr[k].name,
                       p % (size_t)img.width, p / (size_t)img.width, (long)img.ids[p] - 1,
                       tr[k].name, (long)tr[k].ids[p] - 1);
                shown++;
            }
    }
    check_report rep = { a.scene, &img, tr, ntr, &L };
    if ((csv && !output_ok(cmd, csv)) || (pixels_path && !output_ok(cmd, pixels_path)))
        goto done;
    if (csv && sc_cli_write_atomic(csv, write_summary_csv, &rep) != 0) {
        sc_cli_error(cmd, "%s: %s", csv, strerror(errno));
        goto done;
    }
    if (pixels_path && sc_cli_write_atomic(pixels_path, write_pixels_csv, &rep) != 0) {
        sc_cli_error(cmd, "%s: %s", pixels_path, strerror(errno));
        goto done;
    }
    for (int k = 0; map && k < ntr; k++) {
        char *path = k == 0 ? (char *)map : suffixed(map, tr[k].name);
        int ok = path && write_map(cmd, path, &img, &tr[k]);
        if (ok)
            printf("map        %s: %s\n", tr[k].name, path);
        if (k > 0)
            free(path);
        if (!ok)
            goto done;
    }
    if (overlay) {
        uint32_t mx = 0;
        if (!write_overlay(cmd, overlay, &img, tests, &mx))
            goto done;
        double passed = (double)(total.sphere_tests - total.sphere_rejects);
        printf("overlay    %s: sphere tests per pixel, log scale, max %u; mean %.2f tests, "
               "%.2f passed, %.2f triangle tests, %.3f hits per ray\n",
               overlay, (unsigned)mx, (double)total.sphere_tests / (double)npix, passed / (double)npix,
               (double)total.tri_tests / (double)npix, (double)total.tri_hits / (double)npix);
    }
    int target_ok = tr[0].agree * 1000 >= npix * 995 && tr[0].kinds[SC_RASTER_DIFF_ELSEWHERE] == 0;
    if (!target_ok) {
        sc_cli_error(cmd, "ours misses the target: %.4f%% agreement (>= 99.5%%), %zu elsewhere (0)",
                     100.0 * (double)tr[0].agree / (double)npix, tr[0].kinds[SC_RASTER_DIFF_ELSEWHERE]);
        goto done;
    }
    rc = 0;
done:
    for (int k = 0; k < 2; k++) {
        free(tr[k].ids);
        free(tr[k].cls);
    }
    free(tests);
    sc_bvh_free(bvh);
    sc_rayset_free(&rays);
    sc_raster_image_free(&img);
    unload(&L);
    return rc;
}
#endif

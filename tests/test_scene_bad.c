/* Bad input (issue 7): every case must come back as a status and one line
 * of text, never a crash, a hang or a half-built scene. */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmocka.h>

#include "common/sc_rng.h"
#include "spherecull/sc_scene.h"

#ifndef SC_TEST_DATA
#define SC_TEST_DATA "tests/data"
#endif
#define INVALID_DIR "/usr/share/assimp/models/invalid"
#define MODELS "/usr/share/assimp/models"

static char tmpdir[256];

static int setup(void **state)
{
    (void)state;
    snprintf(tmpdir, sizeof tmpdir, "/tmp/sc_scene_bad.XXXXXX");
    return mkdtemp(tmpdir) ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    DIR *d = opendir(tmpdir);
    if (d) {
        struct dirent *e;
        char p[600];
        while ((e = readdir(d)))
            if (e->d_name[0] != '.') {
                snprintf(p, sizeof p, "%s/%s", tmpdir, e->d_name);
                unlink(p);
            }
        closedir(d);
    }
    rmdir(tmpdir);
    return 0;
}

typedef struct warn_log {
    int count;
    char last[512];
} warn_log;

static void on_warn(void *ctx, const char *msg)
{
    warn_log *w = ctx;
    w->count++;
    snprintf(w->last, sizeof w->last, "%s", msg);
}

/* Loads spec; checks the error contract: status, NULL scene, one line. */
static sc_status try_load(const char *spec, const sc_scene_options *opt, char *err, size_t errlen)
{
    sc_scene *s = (sc_scene *)(uintptr_t)1;
    sc_status st = sc_scene_load(spec, opt, &s, err, errlen);
    if (st == SC_OK) {
        assert_non_null(s);
        sc_scene_free(s);
    } else {
        assert_null(s);
        assert_true(strlen(err) > 0);
        assert_null(strchr(err, '\n'));
    }
    return st;
}

static void write_bytes(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, n, f), n);
    assert_int_equal(fclose(f), 0);
}

static unsigned char *read_all(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc((size_t)len + 1);
    assert_non_null(b);
    assert_int_equal(fread(b, 1, (size_t)len, f), (size_t)len);
    fclose(f);
    *n = (size_t)len;
    return b;
}

static void test_assimp_invalid_dir(void **state)
{
    (void)state;
    DIR *d = opendir(INVALID_DIR);
    if (!d)
        skip();
    struct dirent *e;
    int files = 0;
    char path[600], err[512];
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.')
            continue;
        snprintf(path, sizeof path, "%s/%s", INVALID_DIR, e->d_name);
        warn_log w = { 0 };
        sc_scene_options o;
        sc_scene_options_init(&o);
        o.warn = on_warn;
        o.warn_ctx = &w;
        sc_scene *s = NULL;
        sc_status st = sc_scene_load(path, &o, &s, err, sizeof err);
        files++;
        if (strcmp(e->d_name, "malformed2.obj") == 0) {
            /* A valid cube whose material is missing: loads, default
             * colour, and says so. */
            assert_int_equal(st, SC_OK);
            sc_scene_view v;
            sc_scene_get_view(s, &v);
            assert_true(v.num_triangles >= 10);
            assert_true(v.mesh_colors[0] == v.mesh_colors[1] && v.mesh_colors[1] == v.mesh_colors[2]);
            assert_true(v.mesh_colors[0] == 0.75f);
            assert_true(w.count >= 1);
            sc_scene_free(s);
        } else {
            if (st == SC_OK)
                print_error("%s loaded\n", path);
            assert_int_not_equal(st, SC_OK);
            assert_null(s);
            assert_non_null(strstr(err, e->d_name));
        }
    }
    closedir(d);
    assert_true(files >= 14);
}

static void test_files_that_are_not_meshes(void **state)
{
    (void)state;
    char err[512], path[600];
    assert_int_equal(try_load(tmpdir, NULL, err, sizeof err), SC_ERR_IO);
    assert_non_null(strstr(err, "directory"));
    snprintf(path, sizeof path, "%s/empty.obj", tmpdir);
    write_bytes(path, "", 0);
    assert_int_equal(try_load(path, NULL, err, sizeof err), SC_ERR_PARSE);
    assert_non_null(strstr(err, "empty"));
    snprintf(path, sizeof path, "%s/missing.off", tmpdir);
    assert_int_equal(try_load(path, NULL, err, sizeof err), SC_ERR_IO);
    assert_int_equal(try_load("/dev/null", NULL, err, sizeof err), SC_ERR_IO);
    snprintf(path, sizeof path, "%s/noise.bin", tmpdir);
    unsigned char noise[4096];
    sc_rng r;
    sc_rng_seed(&r, 5);
    for (size_t i = 0; i < sizeof noise; i++)
        noise[i] = (unsigned char)sc_rng_next(&r);
    write_bytes(path, noise, sizeof noise);
    assert_int_equal(try_load(path, NULL, err, sizeof err), SC_ERR_PARSE);
    /* A file with only points or lines has no triangles to render. */
    snprintf(path, sizeof path, "%s/points.obj", tmpdir);
    const char *pts = "v 0 0 0\nv 1 0 0\nv 0 1 0\np 1 2 3\nl 1 2\n";
    write_bytes(path, pts, strlen(pts));
    assert_int_not_equal(try_load(path, NULL, err, sizeof err), SC_OK);
    assert_int_equal(try_load("", NULL, err, sizeof err), SC_ERR_INVALID_ARGUMENT);
    sc_scene *s;
    assert_int_equal(sc_scene_load(NULL, NULL, &s, err, sizeof err), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_scene_load("proc:sphere:10", NULL, NULL, err, sizeof err),
                     SC_ERR_INVALID_ARGUMENT);
}

/* NaN and huge coordinates in a real file: NaN triangles dropped with a
 * warning, 1e30 kept (finite), 1e39 overflows float and is dropped. */
static void test_nonfinite_in_files(void **state)
{
    (void)state;
    char path[600], err[512];
    snprintf(path, sizeof path, "%s/nan.obj", tmpdir);
    const char *obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv nan 0 0\nv 1e30 1e30 0\nv 0 1e39 0\n"
                      "f 1 2 3\nf 1 2 4\nf 1 2 5\nf 1 3 6\n";
    write_bytes(path, obj, strlen(obj));
    warn_log w = { 0 };
    sc_scene_options o;
    sc_scene_options_init(&o);
    o.warn = on_warn;
    o.warn_ctx = &w;
    sc_scene *s;
    sc_status st = sc_scene_load(path, &o, &s, err, sizeof err);
    assert_int_equal(st, SC_OK);
    sc_scene_stats ss;
    sc_scene_get_stats(s, &ss);
    assert_int_equal(ss.triangles, 2);
    assert_int_equal(ss.dropped_nonfinite, 2);
    assert_true(w.count >= 1);
    sc_scene_view v;
    sc_scene_get_view(s, &v);
    for (size_t i = 0; i < 3 * v.num_vertices; i++)
        assert_true(isfinite(v.positions[i]));
    sc_scene_free(s);
    /* All triangles bad: nothing left to render is an error. */
    snprintf(path, sizeof path, "%s/allnan.obj", tmpdir);
    const char *bad = "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    write_bytes(path, bad, strlen(bad));
    assert_int_equal(try_load(path, NULL, err, sizeof err), SC_ERR_PARSE);
    assert_non_null(strstr(err, "no triangles"));
}

typedef struct json_case {
    const char *text;
    sc_status status;
    const char *needle;   /* must appear in the message */
} json_case;

static void test_bad_json(void **state)
{
    (void)state;
    static const json_case cases[] = {
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ", SC_ERR_PARSE, "syntax" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"}, ] }", SC_ERR_PARSE, ":1:" },
        { "[1, 2, 3]", SC_ERR_PARSE, "top level" },
        { "{}", SC_ERR_PARSE, "meshes" },
        { "{ \"meshes\": [] }", SC_ERR_PARSE, "non-empty" },
        { "{ \"meshes\": {\"file\": \"x\"} }", SC_ERR_PARSE, "array" },
        { "{ \"meshes\": [ 42 ] }", SC_ERR_PARSE, "meshes[0]" },
        { "{ \"meshes\": [ {\"file\": 7} ] }", SC_ERR_PARSE, "file" },
        { "{ \"meshes\": [ {\"name\": \"x\"} ] }", SC_ERR_PARSE, "file" },
        { "{ \"meshes\": [ {\"file\": \"no_such_mesh.obj\"} ] }", SC_ERR_IO, "no_such_mesh.obj" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\", \"color\": [1, 2, 3]} ] }", SC_ERR_PARSE, "color" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\", \"color\": \"red\"} ] }", SC_ERR_PARSE, "color" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\", \"scale\": 0} ] }", SC_ERR_PARSE, "scale" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\", \"translate\": [1e999, 0, 0]} ] }", SC_ERR_PARSE, "translate" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"camera\": {\"fov\": 0} }", SC_ERR_PARSE, "fov" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"camera\": {\"fov\": 1e9} }", SC_ERR_PARSE, "fov" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"camera\": {\"fov\": 180} }", SC_ERR_PARSE, "fov" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"camera\": {\"fov\": \"wide\"} }", SC_ERR_PARSE, "fov" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"width\": 1e9, \"height\": 1e9 }", SC_ERR_PARSE, "width" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"width\": 30000, \"height\": 30000 }", SC_ERR_LIMIT, "cap" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"width\": -640 }", SC_ERR_PARSE, "width" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"height\": 0 }", SC_ERR_PARSE, "height" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"width\": 640.5 }", SC_ERR_PARSE, "whole" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"camera\": {\"eye\": [0, 0, 5]} }", SC_ERR_PARSE, "target" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"camera\": {\"eye\": [0, 0, 5], \"target\": [0, 0, 5]} }", SC_ERR_PARSE, "coincide" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"camera\": {\"eye\": [0, 5, 0], \"target\": [0, 0, 0]} }", SC_ERR_PARSE, "parallel" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"camera\": {\"eye\": [0, 0], \"target\": [0, 0, 0]} }", SC_ERR_PARSE, "eye" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"camera\": 5 }", SC_ERR_PARSE, "camera" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"lights\": [ {\"type\": \"spot\"} ] }", SC_ERR_PARSE, "type" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"lights\": [ {\"type\": \"point\"} ] }", SC_ERR_PARSE, "position" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"lights\": [ {\"type\": \"directional\", \"direction\": [0, 0, 0]} ] }", SC_ERR_PARSE, "zero" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"lights\": [ {\"type\": \"directional\", \"direction\": [0, -1, 0], \"intensity\": -1} ] }", SC_ERR_PARSE, "intensity" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"lights\": {} }", SC_ERR_PARSE, "lights" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"ambient\": 2 }", SC_ERR_PARSE, "ambient" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"ground\": 3 }", SC_ERR_PARSE, "ground" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:-5\"} ] }", SC_ERR_PARSE, "proc:sphere:-5" },
        { "{ \"meshes\": [ {\"file\": \"proc:cube:5\"} ] }", SC_ERR_PARSE, "unknown procedural" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:60M\"} ] }", SC_ERR_LIMIT, "cap" },
        { "{ \"meshes\": [ {\"file\": \"proc:grid:proc:sphere:1000:60M\"} ] }", SC_ERR_LIMIT, "cap" },
        { "{ \"meshes\": [ {\"file\": \"other.json\"} ] }", SC_ERR_PARSE, "scene file" },
        /* cJSON skips a UTF-8 byte-order mark; the content decides. */
        { "\xef\xbb\xbf{ \"meshes\": [] }", SC_ERR_PARSE, "non-empty" },
    };
    char path[600], err[512];
    snprintf(path, sizeof path, "%s/other.json", tmpdir);
    write_bytes(path, "{}", 2);
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        snprintf(path, sizeof path, "%s/case%zu.json", tmpdir, i);
        write_bytes(path, cases[i].text, strlen(cases[i].text));
        sc_status st = try_load(path, NULL, err, sizeof err);
        if (st != cases[i].status || !strstr(err, cases[i].needle))
            print_error("case %zu: status %d, message '%s'\n", i, (int)st, err);
        assert_int_equal(st, cases[i].status);
        assert_non_null(strstr(err, cases[i].needle));
    }
    /* A typo is a warning, not an error. */
    snprintf(path, sizeof path, "%s/typo.json", tmpdir);
    const char *typo = "{ \"meshes\": [ {\"file\": \"proc:sphere:100\"} ], \"camra\": {} }";
    write_bytes(path, typo, strlen(typo));
    warn_log w = { 0 };
    sc_scene_options o;
    sc_scene_options_init(&o);
    o.warn = on_warn;
    o.warn_ctx = &w;
    assert_int_equal(try_load(path, &o, err, sizeof err), SC_OK);
    assert_int_equal(w.count, 1);
    assert_non_null(strstr(w.last, "camra"));
    /* NUL bytes inside. */
    snprintf(path, sizeof path, "%s/nul.json", tmpdir);
    write_bytes(path, "{\0}", 3);
    assert_int_equal(try_load(path, NULL, err, sizeof err), SC_ERR_PARSE);
}

static void test_caps(void **state)
{
    (void)state;
    sc_scene_options o;
    sc_scene_options_init(&o);
    o.max_triangles = 1000;
    char err[512];
    assert_int_equal(try_load("proc:sphere:100k", &o, err, sizeof err), SC_ERR_LIMIT);
    assert_int_equal(try_load("proc:grid:proc:sphere:100:5000", &o, err, sizeof err), SC_ERR_LIMIT);
    assert_int_equal(try_load(SC_TEST_DATA "/tetra.obj", &o, err, sizeof err), SC_OK);
    o.max_triangles = 3;
    assert_int_equal(try_load(SC_TEST_DATA "/tetra.obj", &o, err, sizeof err), SC_ERR_LIMIT);
    assert_non_null(strstr(err, "cap"));
    /* Grids of grids stop before recursing far. */
    o.max_triangles = 0;
    assert_int_not_equal(try_load("proc:grid:proc:grid:proc:grid:proc:sphere:10:100:1000:2000", &o,
                                  err, sizeof err),
                         SC_OK);
}

/* Truncated and byte-flipped copies of real meshes: any outcome but a
 * crash, a hang or a malformed message. */
static void damage_and_load(const char *src, int variants, uint64_t seed)
{
    size_t n;
    unsigned char *data = read_all(src, &n);
    if (!data || n < 16) {
        free(data);
        return;
    }
    const char *ext = strrchr(src, '.');
    char path[600], err[512];
    sc_rng r;
    sc_rng_seed(&r, seed);
    unsigned char *copy = malloc(n);
    assert_non_null(copy);
    for (int k = 0; k < variants; k++) {
        snprintf(path, sizeof path, "%s/damaged%d%s", tmpdir, k, ext ? ext : "");
        if (k % 2 == 0) {
            write_bytes(path, data, 1 + sc_rng_next(&r) % (n - 1));
        } else {
            memcpy(copy, data, n);
            int flips = 1 + (int)(sc_rng_next(&r) % 16);
            for (int i = 0; i < flips; i++)
                copy[sc_rng_next(&r) % n] = (unsigned char)sc_rng_next(&r);
            write_bytes(path, copy, n);
        }
        try_load(path, NULL, err, sizeof err);
        unlink(path);
    }
    free(copy);
    free(data);
}

static void test_damaged_meshes(void **state)
{
    (void)state;
    damage_and_load(SC_TEST_DATA "/tetra.obj", 20, 1);
    damage_and_load(MODELS "/OFF/Wuson.off", 30, 2);
    damage_and_load(MODELS "/PLY/cube_binary.ply", 30, 3);
    damage_and_load(MODELS "/STL/Spider_binary.stl", 20, 4);
    damage_and_load(MODELS "/OBJ/spider.obj", 20, 5);
    char dir[4096], path[4200];
    if (sc_scene_mesh_cache_dir(NULL, dir, sizeof dir) == SC_OK) {
        snprintf(path, sizeof path, "%s/fandisk.off", dir);
        damage_and_load(path, 20, 6);
    }
}

/* Inputs that once aborted or hung the process inside assimp. */
static void test_assimp_regressions(void **state)
{
    (void)state;
    char path[600], err[512];
    size_t n;
    /* Truncated ASCII PLY: mPrimitiveTypes claims polygons, Triangulate's
     * ai_assert aborted. */
    unsigned char *ply = read_all(MODELS "/PLY/Wuson.ply", &n);
    if (ply && n > 114304) {
        snprintf(path, sizeof path, "%s/trunc.ply", tmpdir);
        write_bytes(path, ply, 114304);
        try_load(path, NULL, err, sizeof err);
    }
    free(ply);
    /* A binary PLY cut inside its header: endless loop in the PLY reader. */
    snprintf(path, sizeof path, "%s/cut.ply", tmpdir);
    const char *cut = "ply\nformat binary_little_endian 1.0\ncom";
    write_bytes(path, cut, strlen(cut));
    assert_int_equal(try_load(path, NULL, err, sizeof err), SC_ERR_PARSE);
    assert_non_null(strstr(err, "end_header"));
    /* A damaged keyword among the property lines: also an endless loop. */
    snprintf(path, sizeof path, "%s/keyword.ply", tmpdir);
    const char *kw = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\np/operty float y\n"
                     "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                     "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    write_bytes(path, kw, strlen(kw));
    assert_int_equal(try_load(path, NULL, err, sizeof err), SC_ERR_PARSE);
    /* Damaged 3MF (zip) archives: ai_asserts in the zip reader aborted;
     * now they throw (assimp_assert.cpp) and the import fails cleanly. */
    unsigned char *zip = read_all(MODELS "/3MF/box.3mf", &n);
    if (zip && n == 1416) {
        static const struct { int off; unsigned char v; } f2[] = { { 206, 88 }, { 585, 132 }, { 1391, 165 } };
        snprintf(path, sizeof path, "%s/box_a.3mf", tmpdir);
        unsigned char *c = malloc(n);
        assert_non_null(c);
        memcpy(c, zip, n);
        for (int i = 0; i < 3; i++)
            c[f2[i].off] = f2[i].v;
        write_bytes(path, c, n);
        assert_int_equal(try_load(path, NULL, err, sizeof err), SC_ERR_PARSE);
        memcpy(c, zip, n);
        c[252] = 17;
        snprintf(path, sizeof path, "%s/box_b.3mf", tmpdir);
        write_bytes(path, c, n);
        assert_int_equal(try_load(path, NULL, err, sizeof err), SC_ERR_PARSE);
        free(c);
    }
    free(zip);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_assimp_invalid_dir),
        cmocka_unit_test(test_files_that_are_not_meshes),
        cmocka_unit_test(test_nonfinite_in_files),
        cmocka_unit_test(test_bad_json),
        cmocka_unit_test(test_caps),
        cmocka_unit_test(test_damaged_meshes),
        cmocka_unit_test(test_assimp_regressions),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}

/* Bad input: every case must come back as a status and one line
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
#include <errno.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>

#include "common/sc_rng.h"
#include "spherecull/sc_scene.h"

/* Under AddressSanitizer a crash or an out-of-memory in the import child
 * is reported by ASan's own handlers (exit status or SIGABRT rather than
 * SIGSEGV or std::bad_alloc): the status and the one line still hold. */
#if defined(__SANITIZE_ADDRESS__)
#define UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define UNDER_ASAN 1
#endif
#endif
#ifndef UNDER_ASAN
#define UNDER_ASAN 0
#endif

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
        /* One printable line, whatever bytes the file had. */
        for (const unsigned char *p = (const unsigned char *)err; *p; p++)
            assert_true(*p >= 0x20 && *p != 0x7f);
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
            assert_true(v.mesh.triangle_count >= 10);
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
    for (size_t i = 0; i < 3 * v.mesh.vertex_count; i++)
        assert_true(isfinite(v.mesh.positions[i]));
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
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\", \"emission\": [1, -1, 0]} ] }", SC_ERR_PARSE, "emission" },
        { "{ \"meshes\": [ {\"file\": \"proc:sphere:100\", \"emission\": [1, 1e9, 0]} ] }", SC_ERR_PARSE, "emission" },
        { "{ \"meshes\": [ {\"vertices\": [[0,0,0],[1,0,0],[0,1,0]], \"faces\": [[0,1,3]]} ] }", SC_ERR_PARSE, "faces[0]" },
        { "{ \"meshes\": [ {\"vertices\": [[0,0,0],[1,0,0],[0,1,0]], \"faces\": [[0,1]]} ] }", SC_ERR_PARSE, "3 or 4" },
        { "{ \"meshes\": [ {\"vertices\": [[0,0,0],[1,0,0],[0,1,0]], \"faces\": [[0,1,1.5]]} ] }", SC_ERR_PARSE, "faces[0]" },
        { "{ \"meshes\": [ {\"vertices\": [[0,0,0],[1,0],[0,1,0]], \"faces\": [[0,1,2]]} ] }", SC_ERR_PARSE, "vertices[1]" },
        { "{ \"meshes\": [ {\"vertices\": [[0,0,0],[1,0,0],[0,1,0]]} ] }", SC_ERR_PARSE, "faces" },
        { "{ \"meshes\": [ {\"vertices\": [], \"faces\": []} ] }", SC_ERR_PARSE, "non-empty" },
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


static int count_open_fds(void)
{
    DIR *d = opendir("/proc/self/fd");
    if (!d)
        return -1;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        n += e->d_name[0] != '.';
    closedir(d);
    return n;
}

/* Writes src with the first len bytes (len 0: all) and the given byte
 * changes to tmpdir/name; 0 when the model is not installed. */
typedef struct flip { int off; unsigned char v; } flip;
static int make_damaged(const char *src, size_t len, const flip *flips, int nflips,
                        const char *name, char *path, size_t pathlen)
{
    size_t n;
    unsigned char *data = read_all(src, &n);
    if (!data)
        return 0;
    snprintf(path, pathlen, "%s/%s", tmpdir, name);
    for (int i = 0; i < nflips; i++)
        if ((size_t)flips[i].off < n)
            data[flips[i].off] = flips[i].v;
    write_bytes(path, data, len && len < n ? len : n);
    free(data);
    return 1;
}

/* Binary COB files cut short: assimp 5.2's COB reader throws from a
 * destructor while unwinding, so std::terminate aborted the whole process
 * whatever the caller did. In the import child the exception's message
 * comes back as the error line. */
static void test_isolated_cob_aborts(void **state)
{
    (void)state;
    static const struct { const char *file; size_t len; } cuts[] = {
        { "molecule.cob", 909 },     { "molecule.cob", 9098 },   { "molecule.cob", 35484 },
        { "dwarf.cob", 24072 },      { "dwarf.cob", 72218 },     { "spider_4_3.cob", 130523 },
        { "spider_4_3.cob", 175532 }, { "spider_6_6.cob", 1361 }, { "spider_6_6.cob", 27226 },
        { "spider_6_6.cob", 51730 },
    };
    int fds = count_open_fds(), ran = 0;
    char src[600], path[600], err[512];
    for (size_t i = 0; i < sizeof cuts / sizeof cuts[0]; i++) {
        snprintf(src, sizeof src, MODELS "/COB/%s", cuts[i].file);
        if (!make_damaged(src, cuts[i].len, NULL, 0, "cut.cob", path, sizeof path))
            continue;
        sc_status st = try_load(path, NULL, err, sizeof err);
        if (st != SC_ERR_PARSE || !strstr(err, path))
            print_error("%s cut at %zu: status %d, '%s'\n", cuts[i].file, cuts[i].len, (int)st, err);
        assert_int_equal(st, SC_ERR_PARSE);
        assert_non_null(strstr(err, path));
        if (!UNDER_ASAN)
            assert_non_null(strstr(err, "End of file"));
        ran++;
    }
    if (ran == 0)
        skip();
    /* Every child reaped, no pipe left open. */
    assert_int_equal(waitpid(-1, NULL, WNOHANG), -1);
    assert_int_equal(errno, ECHILD);
    assert_int_equal(count_open_fds(), fds);
}

/* Damaged binary .x files: wild pointers in assimp's X reader (SIGSEGV),
 * and element counts in the billions that made it allocate and touch
 * memory for seconds (tens of GB). */
static void test_isolated_x_crashes(void **state)
{
    (void)state;
    static const flip segv_a[] = { { 298575, 189 } };
    static const flip segv_b[] = { { 971, 235 }, { 5, 18 }, { 1922, 137 }, { 1531, 163 } };
    static const flip hog_a[] = { { 907, 164 },  { 1346, 211 }, { 1310, 233 }, { 2193, 208 },
                                  { 1608, 146 }, { 1350, 69 },  { 2450, 59 },  { 1289, 128 },
                                  { 1554, 239 }, { 1277, 255 } };
    static const flip hog_b[] = { { 242689, 61 }, { 305911, 252 }, { 356137, 227 }, { 49967, 115 } };
    char path[600], err[512];
    int fds = count_open_fds();
    if (make_damaged(MODELS "/X/fromtruespace_bin32.x", 0, segv_a, 1, "segv_a.x", path, sizeof path)) {
        assert_int_equal(try_load(path, NULL, err, sizeof err), SC_ERR_PARSE);
        assert_non_null(strstr(err, path));
        if (!UNDER_ASAN)
            assert_non_null(strstr(err, "crashed"));
    }
    if (make_damaged(MODELS "/X/test_cube_binary.x", 0, segv_b, 4, "segv_b.x", path, sizeof path)) {
        assert_int_equal(try_load(path, NULL, err, sizeof err), SC_ERR_PARSE);
        assert_non_null(strstr(err, path));
    }
    /* The memory cap refuses the runaway counts. */
    sc_scene_options o;
    sc_scene_options_init(&o);
    o.max_import_bytes = 256u << 20;
    const struct { const char *src; const flip *f; int n; } hogs[] = {
        { MODELS "/X/test_cube_binary.x", hog_a, 10 },
        { MODELS "/X/fromtruespace_bin32.x", hog_b, 4 },
    };
    for (int i = 0; i < 2; i++) {
        if (!make_damaged(hogs[i].src, 0, hogs[i].f, hogs[i].n, "hog.x", path, sizeof path))
            continue;
        sc_status st = try_load(path, &o, err, sizeof err);
        if (UNDER_ASAN) {
            assert_true(st == SC_ERR_LIMIT || st == SC_ERR_PARSE);
        } else {
            if (st != SC_ERR_LIMIT)
                print_error("hog %d: status %d '%s'\n", i, (int)st, err);
            assert_int_equal(st, SC_ERR_LIMIT);
            assert_non_null(strstr(err, "memory cap"));
        }
        /* The time limit stops it too, whatever the memory allowed. */
        sc_scene_options t;
        sc_scene_options_init(&t);
        t.max_import_bytes = 1ull << 40;
        t.import_timeout_ms = 200;
        assert_int_equal(try_load(path, &t, err, sizeof err), SC_ERR_LIMIT);
        assert_non_null(strstr(err, "longer than 0.2 s"));
    }
    assert_int_equal(waitpid(-1, NULL, WNOHANG), -1);
    assert_int_equal(errno, ECHILD);
    assert_int_equal(count_open_fds(), fds);
}

/* A 39-byte SMD cut inside its node list sends assimp's SMD reader into an
 * endless loop (in-process it never returns); the import time limit stops
 * it. A damaged ASE quotes raw file bytes (control characters) in its
 * error. */
static void test_isolated_hang_and_garbage(void **state)
{
    (void)state;
    char path[600], err[512];
    int fds = count_open_fds();
    if (make_damaged(MODELS "/SMD/triangle.smd", 39, NULL, 0, "cut.smd", path, sizeof path)) {
        sc_scene_options o;
        sc_scene_options_init(&o);
        o.import_timeout_ms = 300;
        assert_int_equal(try_load(path, &o, err, sizeof err), SC_ERR_LIMIT);
        assert_non_null(strstr(err, "longer than 0.3 s"));
    }
    static const flip ase[] = { { 1198, 209 }, { 2914, 211 }, { 4825, 14 },  { 5379, 62 },
                                { 8335, 27 },  { 6457, 101 }, { 977, 60 },   { 7505, 192 },
                                { 8518, 71 },  { 5837, 138 }, { 4776, 124 }, { 1516, 158 },
                                { 916, 12 },   { 1208, 214 } };
    if (make_damaged(MODELS "/ASE/ThreeCubesGreen.ASE", 0, ase, 14, "garbage.ase", path, sizeof path))
        assert_int_equal(try_load(path, NULL, err, sizeof err), SC_ERR_PARSE);
    assert_int_equal(waitpid(-1, NULL, WNOHANG), -1);
    assert_int_equal(count_open_fds(), fds);
}

/* The child's result, carried through the pipe, is the in-process result
 * bit for bit: geometry, colours, counters, warnings. */
static void compare_modes(const char *spec)
{
    sc_scene *sc[2] = { NULL, NULL };
    warn_log w[2] = { { 0 }, { 0 } };
    char err[512];
    for (int m = 0; m < 2; m++) {
        sc_scene_options o;
        sc_scene_options_init(&o);
        o.import_in_process = m;
        o.warn = on_warn;
        o.warn_ctx = &w[m];
        sc_status st = sc_scene_load(spec, &o, &sc[m], err, sizeof err);
        if (st != SC_OK)
            print_error("%s (%s): %s\n", spec, m ? "in-process" : "isolated", err);
        assert_int_equal(st, SC_OK);
    }
    sc_scene_view a, b;
    sc_scene_stats sa, sb;
    sc_scene_get_view(sc[0], &a);
    sc_scene_get_view(sc[1], &b);
    sc_scene_get_stats(sc[0], &sa);
    sc_scene_get_stats(sc[1], &sb);
    assert_int_equal(a.mesh.vertex_count, b.mesh.vertex_count);
    assert_int_equal(a.mesh.triangle_count, b.mesh.triangle_count);
    assert_int_equal(a.num_meshes, b.num_meshes);
    assert_true(a.mesh.triangle_count > 0);
    assert_memory_equal(a.mesh.positions, b.mesh.positions, a.mesh.vertex_count * 3 * sizeof(float));
    assert_memory_equal(a.mesh.indices, b.mesh.indices, a.mesh.triangle_count * 3 * sizeof(uint32_t));
    assert_memory_equal(a.mesh_ids, b.mesh_ids, a.mesh.triangle_count * sizeof(uint32_t));
    assert_memory_equal(a.mesh_colors, b.mesh_colors, a.num_meshes * 3 * sizeof(float));
    assert_memory_equal(&a.camera, &b.camera, sizeof a.camera);
    assert_int_equal(sa.degenerate_triangles, sb.degenerate_triangles);
    assert_int_equal(sa.dropped_nonfinite, sb.dropped_nonfinite);
    assert_int_equal(sa.skipped_primitives, sb.skipped_primitives);
    assert_int_equal(sa.warnings, sb.warnings);
    assert_int_equal(w[0].count, w[1].count);
    assert_string_equal(w[0].last, w[1].last);
    sc_scene_free(sc[0]);
    sc_scene_free(sc[1]);
}

static void test_isolated_equals_in_process(void **state)
{
    (void)state;
    char path[600];
    compare_modes(SC_TEST_DATA "/tetra.obj");
    compare_modes(INVALID_DIR "/malformed2.obj");   /* a warning crosses the pipe */
    struct stat sb;
    if (stat(MODELS "/COB/molecule.cob", &sb) == 0)
        compare_modes(MODELS "/COB/molecule.cob");
    if (stat(MODELS "/OBJ/spider.obj", &sb) == 0)
        compare_modes(MODELS "/OBJ/spider.obj");
    /* NaN vertices dropped in the child are counted in the parent. */
    snprintf(path, sizeof path, "%s/nan2.obj", tmpdir);
    const char *obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv nan 0 0\nv 0 0 0\nf 1 2 3\nf 1 2 4\nf 1 2 5\n"
                      "l 1 2\n";
    write_bytes(path, obj, strlen(obj));
    compare_modes(path);
    /* Two files, transformed, appended to one scene. */
    snprintf(path, sizeof path, "%s/two.json", tmpdir);
    char json[1200];
    snprintf(json, sizeof json,
             "{ \"meshes\": [ {\"file\": \"%s/tetra.obj\", \"scale\": 2, \"rotate\": [10, 20, 30]},"
             " {\"file\": \"proc:sphere:200\"}, {\"file\": \"%s/tetra.obj\", \"translate\": [3, 0, 0],"
             " \"color\": [1, 0, 0]} ] }",
             SC_TEST_DATA, SC_TEST_DATA);
    write_bytes(path, json, strlen(json));
    compare_modes(path);
}

/* The triangle cap applies across a JSON scene: the second file is
 * refused in the child, with the cap named. */
static void test_isolated_cap_across_files(void **state)
{
    (void)state;
    char path[600], err[512], json[1200];
    snprintf(path, sizeof path, "%s/cap.json", tmpdir);
    snprintf(json, sizeof json,
             "{ \"meshes\": [ {\"file\": \"%s/tetra.obj\"}, {\"file\": \"%s/tetra.obj\"} ] }",
             SC_TEST_DATA, SC_TEST_DATA);
    write_bytes(path, json, strlen(json));
    sc_scene_options o;
    sc_scene_options_init(&o);
    o.max_triangles = 6;
    size_t n;
    unsigned char *tetra = read_all(SC_TEST_DATA "/tetra.obj", &n);
    assert_non_null(tetra);
    free(tetra);
    sc_scene *s;
    sc_status st = sc_scene_load(path, &o, &s, err, sizeof err);
    if (st == SC_OK) {
        sc_scene_stats ss;
        sc_scene_get_stats(s, &ss);
        assert_true(ss.triangles <= 6);
        sc_scene_free(s);
    } else {
        assert_int_equal(st, SC_ERR_LIMIT);
        assert_non_null(strstr(err, "cap"));
    }
    o.max_triangles = 5;
    assert_int_equal(try_load(path, &o, err, sizeof err), SC_ERR_LIMIT);
    assert_non_null(strstr(err, "cap"));
}

/* Scene descriptions from memory take the same path as files. */
static void test_json_text(void **state)
{
    (void)state;
    char err[512];
    sc_scene *s = (sc_scene *)(uintptr_t)1;
    const char *good = "{ \"meshes\": [ {\"file\": \"tetra.obj\"} ] }";
    assert_int_equal(sc_scene_load_json_text(good, strlen(good), "mem.json", SC_TEST_DATA, NULL, &s,
                                             err, sizeof err),
                     SC_OK);
    sc_scene_free(s);
    /* Not NUL-terminated: the length is what counts. */
    char cut[64];
    memcpy(cut, "{ \"meshes\": [ {\"file\": \"proc:sphere:50\"} ] }XXXX", 48);
    assert_int_equal(sc_scene_load_json_text(cut, 44, NULL, NULL, NULL, &s, err, sizeof err), SC_OK);
    sc_scene_free(s);
    assert_int_equal(sc_scene_load_json_text(cut, 47, NULL, NULL, NULL, &s, err, sizeof err),
                     SC_ERR_PARSE);
    assert_null(s);
    assert_non_null(strstr(err, "<memory>:1:45: JSON syntax error"));
    assert_int_equal(sc_scene_load_json_text("", 0, NULL, NULL, NULL, &s, err, sizeof err), SC_ERR_PARSE);
    assert_int_equal(sc_scene_load_json_text(NULL, 3, NULL, NULL, NULL, &s, err, sizeof err),
                     SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_scene_load_json_text(good, strlen(good), NULL, NULL, NULL, NULL, err, sizeof err),
                     SC_ERR_INVALID_ARGUMENT);
    /* Many keys: linear time, one warning each, capped forwarding. */
    size_t cap = 2u << 20;
    char *big = malloc(cap);
    assert_non_null(big);
    size_t len = (size_t)snprintf(big, cap, "{ \"meshes\": [ {\"file\": \"proc:sphere:50\"} ]");
    for (int i = 0; i < 100000; i++)
        len += (size_t)snprintf(big + len, cap - len, ", \"k%d\": %d", i, i);
    len += (size_t)snprintf(big + len, cap - len, "}");
    warn_log w = { 0 };
    sc_scene_options o;
    sc_scene_options_init(&o);
    o.warn = on_warn;
    o.warn_ctx = &w;
    assert_int_equal(sc_scene_load_json_text(big, len, NULL, NULL, &o, &s, err, sizeof err), SC_OK);
    sc_scene_stats ss;
    sc_scene_get_stats(s, &ss);
    assert_int_equal(ss.warnings, 100000);
    assert_int_equal(w.count, SC_SCENE_MAX_WARNINGS + 1);
    sc_scene_free(s);
    free(big);
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
        cmocka_unit_test(test_isolated_cob_aborts),
        cmocka_unit_test(test_isolated_x_crashes),
        cmocka_unit_test(test_isolated_hang_and_garbage),
        cmocka_unit_test(test_isolated_equals_in_process),
        cmocka_unit_test(test_isolated_cap_across_files),
        cmocka_unit_test(test_json_text),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}

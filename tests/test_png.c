/* PNG output: a round trip through libpng is bit-exact, and a failed write
 * leaves nothing behind (no partial file, no temporary). */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
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
#include "spherecull/sc_image.h"

static char tmpdir[256];

static int setup(void **state)
{
    (void)state;
    snprintf(tmpdir, sizeof tmpdir, "/tmp/sc_png.XXXXXX");
    return mkdtemp(tmpdir) ? 0 : -1;
}

static int count_entries(const char *dir)
{
    DIR *d = opendir(dir);
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d)))
        n += e->d_name[0] != '.';
    if (d)
        closedir(d);
    return n;
}

static int teardown(void **state)
{
    (void)state;
    DIR *d = opendir(tmpdir);
    struct dirent *e;
    char p[600];
    while (d && (e = readdir(d)))
        if (e->d_name[0] != '.') {
            snprintf(p, sizeof p, "%s/%s", tmpdir, e->d_name);
            if (rmdir(p) != 0)
                unlink(p);
        }
    if (d)
        closedir(d);
    rmdir(tmpdir);
    return 0;
}

static void test_round_trip(void **state)
{
    (void)state;
    /* Odd sizes catch row-stride mistakes; random bytes defeat any
     * accidental match. */
    const int sizes[][2] = { { 1, 1 }, { 3, 7 }, { 257, 31 }, { 640, 480 } };
    sc_rng r;
    sc_rng_seed(&r, 42);
    char path[600], err[256];
    snprintf(path, sizeof path, "%s/rt.png", tmpdir);
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        sc_image a, b;
        assert_int_equal(sc_image_alloc(&a, sizes[k][0], sizes[k][1]), SC_OK);
        size_t n = 3 * (size_t)a.width * (size_t)a.height;
        for (size_t i = 0; i < n; i++)
            a.rgb[i] = (uint8_t)sc_rng_next(&r);
        assert_int_equal(sc_png_write(path, &a, err, sizeof err), SC_OK);
        assert_int_equal(sc_png_read(path, &b, err, sizeof err), SC_OK);
        assert_int_equal(b.width, a.width);
        assert_int_equal(b.height, a.height);
        assert_memory_equal(a.rgb, b.rgb, n);
        sc_image_free(&a);
        sc_image_free(&b);
        assert_null(b.rgb);
    }
    /* Only the output itself is left in the directory. */
    assert_int_equal(count_entries(tmpdir), 1);
    /* The magic bytes say PNG, whatever our reader thinks. */
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    unsigned char sig[8];
    assert_int_equal(fread(sig, 1, 8, f), 8);
    fclose(f);
    assert_memory_equal(sig, "\x89PNG\r\n\x1a\n", 8);
}

static void test_failed_writes_leave_nothing(void **state)
{
    (void)state;
    sc_image a;
    assert_int_equal(sc_image_alloc(&a, 8, 8), SC_OK);
    char path[600], err[256];
    int before = count_entries(tmpdir);
    snprintf(path, sizeof path, "%s/no/such/dir/x.png", tmpdir);
    assert_int_equal(sc_png_write(path, &a, err, sizeof err), SC_ERR_IO);
    assert_non_null(strstr(err, "x.png"));
    /* The target is a directory: rename fails, the temporary goes away. */
    snprintf(path, sizeof path, "%s/adir", tmpdir);
    assert_int_equal(mkdir(path, 0755), 0);
    assert_int_equal(sc_png_write(path, &a, err, sizeof err), SC_ERR_IO);
    assert_int_equal(count_entries(tmpdir), before + 1);
    rmdir(path);
    /* An existing good file survives a failed overwrite. */
    snprintf(path, sizeof path, "%s/keep.png", tmpdir);
    assert_int_equal(sc_png_write(path, &a, err, sizeof err), SC_OK);
    sc_image bad = { 8, 8, NULL };
    assert_int_equal(sc_png_write(path, &bad, err, sizeof err), SC_ERR_INVALID_ARGUMENT);
    sc_image back;
    assert_int_equal(sc_png_read(path, &back, err, sizeof err), SC_OK);
    sc_image_free(&back);
    unlink(path);
    sc_image_free(&a);
}

static void test_bad_reads_and_sizes(void **state)
{
    (void)state;
    char path[600], err[256];
    sc_image img;
    snprintf(path, sizeof path, "%s/not.png", tmpdir);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fputs("this is not a png", f);
    fclose(f);
    assert_int_equal(sc_png_read(path, &img, err, sizeof err), SC_ERR_PARSE);
    assert_null(img.rgb);
    /* A truncated PNG: header fine, data cut. */
    sc_image a;
    assert_int_equal(sc_image_alloc(&a, 64, 64), SC_OK);
    for (size_t i = 0; i < 3 * 64 * 64; i++)
        a.rgb[i] = (uint8_t)(i * 7);
    snprintf(path, sizeof path, "%s/cut.png", tmpdir);
    assert_int_equal(sc_png_write(path, &a, err, sizeof err), SC_OK);
    assert_int_equal(truncate(path, 100), 0);
    assert_int_equal(sc_png_read(path, &img, err, sizeof err), SC_ERR_PARSE);
    assert_null(img.rgb);
    sc_image_free(&a);
    assert_int_equal(sc_png_read(tmpdir, &img, err, sizeof err), SC_ERR_IO);
    snprintf(path, sizeof path, "%s/missing.png", tmpdir);
    assert_int_equal(sc_png_read(path, &img, err, sizeof err), SC_ERR_IO);
    assert_int_equal(sc_image_alloc(&img, 0, 10), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_image_alloc(&img, -5, 10), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_image_alloc(&img, 1000000000, 1000000000), SC_ERR_LIMIT);
    assert_int_equal(sc_image_alloc(&img, 30000, 30000), SC_ERR_LIMIT);
    assert_int_equal(sc_image_alloc(NULL, 1, 1), SC_ERR_INVALID_ARGUMENT);
    assert_int_equal(sc_png_write(NULL, &a, err, sizeof err), SC_ERR_INVALID_ARGUMENT);
    sc_image_free(NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip),
        cmocka_unit_test(test_failed_writes_leave_nothing),
        cmocka_unit_test(test_bad_reads_and_sizes),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}

/* PNG in and out through libpng's simplified API (no setjmp in our code). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <png.h>

#include "common/sc_atomic_file.h"
#include "spherecull/sc_image.h"

static sc_status fail(char *err, size_t errlen, sc_status st, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

static sc_status fail(char *err, size_t errlen, sc_status st, const char *fmt, ...)
{
    if (err && errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return st;
}

static int size_ok(int w, int h)
{
    return w >= 1 && h >= 1 && w <= SC_IMAGE_MAX_SIDE && h <= SC_IMAGE_MAX_SIDE &&
           (unsigned long long)w * (unsigned long long)h <= SC_IMAGE_MAX_PIXELS;
}

sc_status sc_image_alloc(sc_image *img, int w, int h)
{
    if (!img)
        return SC_ERR_INVALID_ARGUMENT;
    img->width = img->height = 0;
    img->rgb = NULL;
    if (w < 1 || h < 1)
        return SC_ERR_INVALID_ARGUMENT;
    if (!size_ok(w, h))
        return SC_ERR_LIMIT;
    img->rgb = calloc((size_t)w * (size_t)h, 3);
    if (!img->rgb)
        return SC_ERR_OUT_OF_MEMORY;
    img->width = w;
    img->height = h;
    return SC_OK;
}

void sc_image_free(sc_image *img)
{
    if (!img)
        return;
    free(img->rgb);
    img->rgb = NULL;
    img->width = img->height = 0;
}

typedef struct png_job {
    const sc_image *img;
    char why[128];               /* libpng's message when it fails */
} png_job;

static int png_write_fn(void *ctx, FILE *f)
{
    png_job *j = ctx;
    png_image pi;
    memset(&pi, 0, sizeof pi);
    pi.version = PNG_IMAGE_VERSION;
    pi.width = (png_uint_32)j->img->width;
    pi.height = (png_uint_32)j->img->height;
    pi.format = PNG_FORMAT_RGB;
    int ok = png_image_write_to_stdio(&pi, f, 0, j->img->rgb, 0, NULL) != 0;
    if (!ok)
        snprintf(j->why, sizeof j->why, "%s", pi.message[0] ? pi.message : "libpng failed");
    png_image_free(&pi);
    return ok ? 0 : -1;
}

sc_status sc_png_write(const char *path, const sc_image *img, char *err, size_t errlen)
{
    if (!path || !*path || !img || !img->rgb || !size_ok(img->width, img->height))
        return fail(err, errlen, SC_ERR_INVALID_ARGUMENT, "invalid PNG path or image");
    /* The rename would replace a device or a symlink to one (as root,
     * -o /dev/null would turn /dev/null into a PNG file): refuse instead. */
    struct stat sb;
    if (stat(path, &sb) == 0 && !S_ISREG(sb.st_mode))
        return fail(err, errlen, SC_ERR_IO, "%s: not a regular file; PNG outputs replace their target", path);
    png_job j = { img, "" };
    if (sc_write_atomic(path, png_write_fn, &j) != 0)
        return fail(err, errlen, SC_ERR_IO, "%s: %s", path, j.why[0] ? j.why : strerror(errno));
    return SC_OK;
}

sc_status sc_png_read(const char *path, sc_image *img, char *err, size_t errlen)
{
    if (!path || !img)
        return fail(err, errlen, SC_ERR_INVALID_ARGUMENT, "NULL path or image");
    img->width = img->height = 0;
    img->rgb = NULL;
    struct stat sb;
    if (stat(path, &sb) != 0)
        return fail(err, errlen, SC_ERR_IO, "%s: %s", path, strerror(errno));
    if (!S_ISREG(sb.st_mode))
        return fail(err, errlen, SC_ERR_IO, "%s: not a regular file", path);
    png_image pi;
    memset(&pi, 0, sizeof pi);
    pi.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&pi, path)) {
        sc_status st = fail(err, errlen, SC_ERR_PARSE, "%s: %s", path,
                            pi.message[0] ? pi.message : "not a PNG file");
        png_image_free(&pi);
        return st;
    }
    if (!size_ok((int)(pi.width > SC_IMAGE_MAX_SIDE ? 0 : pi.width),
                 (int)(pi.height > SC_IMAGE_MAX_SIDE ? 0 : pi.height))) {
        png_image_free(&pi);
        return fail(err, errlen, SC_ERR_LIMIT, "%s: %ux%u image is too large", path,
                    (unsigned)pi.width, (unsigned)pi.height);
    }
    pi.format = PNG_FORMAT_RGB;
    sc_status st = sc_image_alloc(img, (int)pi.width, (int)pi.height);
    if (st != SC_OK) {
        png_image_free(&pi);
        return fail(err, errlen, st, "%s: %s", path, sc_strerror(st));
    }
    png_color black = { 0, 0, 0 };
    if (!png_image_finish_read(&pi, &black, img->rgb, 0, NULL)) {
        st = fail(err, errlen, SC_ERR_PARSE, "%s: %s", path,
                  pi.message[0] ? pi.message : "corrupt PNG data");
        png_image_free(&pi);
        sc_image_free(img);
        return st;
    }
    png_image_free(&pi);
    return SC_OK;
}

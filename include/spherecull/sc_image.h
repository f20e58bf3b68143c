/* spherecull — RGB8 images and PNG files (libpng).
 *
 * sc_png_write never leaves a partial file under the target name: it writes a
 * temporary file in the same directory and renames it into place, so a full
 * disk, a bad path or an interrupted run leaves either the old file or none.
 *
 * Threads: reentrant; distinct images may be allocated, read and written in
 * several threads at once. sc_png_write writes a temporary file and renames
 * it, so a reader never sees half a PNG; two threads writing the same path
 * at once leave one of the two images.
 */
#ifndef SPHERECULL_SC_IMAGE_H
#define SPHERECULL_SC_IMAGE_H

#include "sc_api.h"
#include <stddef.h>
#include <stdint.h>

#include "sc_status.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SC_IMAGE_MAX_SIDE 32768
#define SC_IMAGE_MAX_PIXELS (1ull << 28)

typedef struct sc_image {
    int width, height;
    uint8_t *rgb;   /* 3 bytes per pixel, rows top to bottom, no padding */
} sc_image;

/* Zero-filled image; SC_ERR_LIMIT beyond SC_IMAGE_MAX_SIDE / _PIXELS. */
SC_API sc_status sc_image_alloc(sc_image *img, int width, int height);
SC_API void sc_image_free(sc_image *img);

/* err (optional) receives one line on failure. */
SC_API sc_status sc_png_write(const char *path, const sc_image *img, char *err, size_t errlen);

/* Reads any PNG, converted to RGB8 (alpha composited on black, 16-bit
 * reduced); img must be empty or freed. */
SC_API sc_status sc_png_read(const char *path, sc_image *img, char *err, size_t errlen);

#ifdef __cplusplus
}
#endif
#endif

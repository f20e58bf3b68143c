/* spherecull — status codes shared by every public call.
 *
 * Every public function that can fail returns an sc_status; 0 is success.
 * The library never aborts, exits or prints: the caller decides what an
 * error means (the CLI turns it into one line on stderr and a non-zero exit).
 *
 * Threads: sc_strerror returns static strings and may be called from any
 * thread at any time.
 */
#ifndef SPHERECULL_SC_STATUS_H
#define SPHERECULL_SC_STATUS_H

#include "sc_api.h"
#ifdef __cplusplus
extern "C" {
#endif

typedef enum sc_status {
    SC_OK = 0,
    SC_ERR_DEGENERATE,       /* duplicate or collinear vertices, zero area/volume */
    SC_ERR_NONFINITE,        /* a NaN or infinite input coordinate */
    SC_ERR_RANGE,            /* finite input, but the result is not representable */
    SC_ERR_INVALID_ARGUMENT, /* NULL pointer, bad enum, size out of range */
    SC_ERR_UNSUPPORTED,      /* valid request this build or CPU cannot serve */
    SC_ERR_OUT_OF_MEMORY,
    SC_ERR_IO,               /* a file could not be read or written */
    SC_ERR_PARSE,            /* a file was read but its content is malformed */
    SC_ERR_LIMIT,            /* input exceeds a configured cap (triangles, memory, pixels) */
    SC_ERR_CANCELLED,        /* the caller asked a long call to stop (sc_render_options.cancel) */
    SC_STATUS_COUNT
} sc_status;

/* A short English description; never NULL, also for out-of-range values. */
SC_API const char *sc_strerror(sc_status status);

#ifdef __cplusplus
}
#endif
#endif

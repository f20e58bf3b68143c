/* Every output file of the tools is written through here: into a temporary
 * file in the target's directory, flushed to disk (fsync), then renamed over
 * the target. A failed or interrupted run leaves the old file (or none) and
 * no temporary; readers never see half a file. While the temporary exists,
 * SIGINT, SIGTERM and SIGHUP delete it before ending the process (the
 * caller's handlers are put back afterwards; ignored signals stay ignored).
 * Not for use from several threads at once (the tools write from one). The new file gets the mode
 * fopen would give it (0666 minus the umask), not mkstemp's 0600. */
#ifndef SPHERECULL_COMMON_SC_ATOMIC_FILE_H
#define SPHERECULL_COMMON_SC_ATOMIC_FILE_H

#include <stddef.h>
#include <stdio.h>

/* write_fn writes the whole content to f and returns 0, or non-zero on
 * failure. Returns 0, or -1 with errno set (EISDIR / EINVAL when PATH
 * exists and is not a regular file: a rename would replace a directory,
 * device or FIFO, so that is refused). */
int sc_write_atomic(const char *path, int (*write_fn)(void *ctx, FILE *f), void *ctx);

/* The same for LEN bytes already in memory. */
int sc_write_atomic_bytes(const char *path, const void *data, size_t len);

#endif

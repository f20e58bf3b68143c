#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "sc_atomic_file.h"

/* umask cannot be read without setting it; the tools are single-threaded
 * when they write files, so the brief change is not observable. */
static mode_t default_file_mode(void)
{
    mode_t mask = umask(0);
    umask(mask);
    return 0666 & ~mask;
}

int sc_write_atomic(const char *path, int (*write_fn)(void *ctx, FILE *f), void *ctx)
{
    if (!path || !*path || !write_fn) {
        errno = EINVAL;
        return -1;
    }
    struct stat st;
    if (stat(path, &st) == 0 && !S_ISREG(st.st_mode)) {
        errno = S_ISDIR(st.st_mode) ? EISDIR : EINVAL;
        return -1;
    }
    size_t len = strlen(path);
    char *tmp = malloc(len + 16);
    if (!tmp)
        return -1;
    snprintf(tmp, len + 16, "%s.tmpXXXXXX", path);
    int fd = mkstemp(tmp);
    if (fd < 0) {
        free(tmp);
        return -1;
    }
    int ok = fchmod(fd, default_file_mode()) == 0;
    FILE *f = ok ? fdopen(fd, "wb") : NULL;
    if (f) {
        /* write_fn may fail without setting errno (a short write on a full
         * disk does); EIO is the honest default then. */
        errno = 0;
        ok = write_fn(ctx, f) == 0 && fflush(f) == 0 && !ferror(f) && fsync(fileno(f)) == 0;
        if (!ok && errno == 0)
            errno = EIO;
        int saved = errno;
        int closed = fclose(f) == 0;
        if (!ok)
            errno = saved;
        ok = ok && closed;
    } else {
        ok = 0;
        int saved = errno;
        close(fd);
        errno = saved;
    }
    if (ok)
        ok = rename(tmp, path) == 0;
    if (!ok) {
        int saved = errno;
        unlink(tmp);
        errno = saved;
    }
    free(tmp);
    return ok ? 0 : -1;
}

typedef struct bytes {
    const void *data;
    size_t len;
} bytes;

static int write_bytes(void *ctx, FILE *f)
{
    const bytes *b = ctx;
    return b->len && fwrite(b->data, 1, b->len, f) != b->len ? -1 : 0;
}

int sc_write_atomic_bytes(const char *path, const void *data, size_t len)
{
    bytes b = { data, len };
    return sc_write_atomic(path, write_bytes, &b);
}

#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <signal.h>
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

/* While a temporary file exists, SIGINT, SIGTERM and SIGHUP remove it and
 * then end the process as the signal would have: a run stopped while
 * writing leaves the old file and nothing else. Only async-signal-safe
 * calls in the handler; the path is set before the handlers go in. */
static const int cleanup_signals[3] = { SIGINT, SIGTERM, SIGHUP };
static const char *volatile pending_tmp;

static void remove_tmp_and_die(int sig)
{
    const char *tmp = pending_tmp;
    if (tmp)
        unlink(tmp);
    signal(sig, SIG_DFL);
    raise(sig);
}

static void guard_tmp(const char *tmp, struct sigaction old[3])
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = remove_tmp_and_die;
    sigemptyset(&sa.sa_mask);
    pending_tmp = tmp;
    for (int i = 0; i < 3; i++) {
        sigaction(cleanup_signals[i], NULL, &old[i]);
        /* a signal the caller ignores stays ignored */
        if (old[i].sa_handler != SIG_IGN)
            sigaction(cleanup_signals[i], &sa, NULL);
    }
}

static void unguard_tmp(const struct sigaction old[3])
{
    for (int i = 0; i < 3; i++)
        sigaction(cleanup_signals[i], &old[i], NULL);
    pending_tmp = NULL;
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
    struct sigaction old[3];
    guard_tmp(tmp, old);
    int fd = mkstemp(tmp);
    if (fd < 0) {
        int saved = errno;
        unguard_tmp(old);
        free(tmp);
        errno = saved;
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
    int saved = errno;
    unguard_tmp(old);
    errno = saved;
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

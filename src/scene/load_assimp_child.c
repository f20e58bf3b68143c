/* assimp in a child process.
 *
 * The Debian assimp 5.2 crashes on some damaged files in ways no caller can
 * intercept: binary COB files cut short throw from a destructor during
 * unwinding (std::terminate, abort), damaged binary .x files dereference
 * wild pointers (SIGSEGV) or loop forever. So the import runs in a forked
 * child: it loads into a scene of its own with the in-process loader and
 * streams the result back through a pipe; the parent reads it straight into
 * its arrays, checks it, and turns a crash, an incomplete stream or an
 * import past the time limit into one error line. The child is always
 * reaped (killed first on timeout) and nothing touches the file system.
 *
 * Why fork without exec: a library cannot rely on finding a helper binary,
 * and the child inherits the path, options and caps for free. The child is
 * single-threaded and runs only code that is safe after fork in glibc
 * (malloc, stdio and pthread state are reset by glibc's atfork handlers);
 * assimp itself is never initialised in the parent. */
#define _GNU_SOURCE   /* F_SETPIPE_SZ */
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "load_assimp.h"

/* assimp_assert.cpp: routes std::terminate's exception message and a
 * failed operator new to these reporters (which end the child). */
void sc_scene_assimp_child_hooks(void (*on_terminate)(const char *message),
                                 void (*on_out_of_memory)(void));

#define MAGIC_HEAD 0x53434d32u   /* "SCM2" */
#define MAGIC_TAIL 0x53434d45u   /* "SCME" */
#define MAX_ERR 1024
#define MAX_WARN_LEN 512
/* More meshes than this in one file is not a mesh file we can use anyway,
 * and it bounds what a garbled stream can make the parent allocate. */
#define MAX_MESHES (1u << 24)
#define EXIT_TERMINATE 70

typedef struct wire_head {
    uint32_t magic;
    int32_t status;
    uint64_t num_vertices, num_triangles, num_meshes;
    uint64_t warnings, degenerate, dropped_nonfinite, skipped_primitives;
    uint32_t num_warn_lines;
    uint32_t err_len;
} wire_head;

/* ---- child ------------------------------------------------------------ */

static int child_fd = -1;
static const char *child_path = "";
static uint64_t child_budget;

typedef struct warn_store {
    char lines[SC_SCENE_MAX_WARNINGS][MAX_WARN_LEN];
    uint32_t n;
} warn_store;

static void collect_warning(void *ctx, const char *msg)
{
    warn_store *w = ctx;
    if (w->n < SC_SCENE_MAX_WARNINGS)
        snprintf(w->lines[w->n++], MAX_WARN_LEN, "%s", msg);
}

static int write_all(int fd, const void *p, size_t n)
{
    const char *c = p;
    while (n > 0) {
        ssize_t k = write(fd, c, n > (1u << 30) ? (1u << 30) : n);
        if (k < 0 && errno == EINTR)
            continue;
        if (k <= 0)
            return -1;
        c += k;
        n -= (size_t)k;
    }
    return 0;
}

static int send_error(int fd, sc_status st, const char *msg, const warn_store *w, uint64_t warnings)
{
    size_t len = strlen(msg);
    if (len > MAX_ERR)
        len = MAX_ERR;
    wire_head h = { .magic = MAGIC_HEAD, .status = st, .err_len = (uint32_t)len,
                    .num_warn_lines = w ? w->n : 0, .warnings = warnings };
    uint32_t tail = MAGIC_TAIL;
    int bad = write_all(fd, &h, sizeof h) || write_all(fd, msg, len);
    for (uint32_t i = 0; !bad && w && i < w->n; i++) {
        uint32_t n = (uint32_t)strlen(w->lines[i]);
        bad = write_all(fd, &n, sizeof n) || write_all(fd, w->lines[i], n);
    }
    return bad || write_all(fd, &tail, sizeof tail);
}

/* std::terminate in the child (an exception assimp could not catch): the
 * exception's message is the best error line there is. */
static void on_terminate(const char *message)
{
    char msg[MAX_ERR];
    snprintf(msg, sizeof msg, "%s: assimp aborted the import: %s", child_path, message);
    send_error(child_fd, SC_ERR_PARSE, msg, NULL, 0);
    _exit(EXIT_TERMINATE);
}

static uint64_t memory_budget(const sc_scene *parent)
{
    if (parent->max_import_bytes)
        return parent->max_import_bytes;
    uint64_t b = (1ull << 30) + 2048 * parent->max_triangles;
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages > 0 && page > 0 && b > (uint64_t)pages * (uint64_t)page / 2)
        b = (uint64_t)pages * (uint64_t)page / 2;
    return b;
}

/* RLIMIT_DATA counts private writable mappings (heap, malloc's mmaps), the
 * memory a runaway element count grows. The limit is set relative to what
 * the child inherited, which under AddressSanitizer includes terabytes of
 * reserved shadow. */
static void limit_memory(uint64_t budget)
{
    FILE *f = fopen("/proc/self/statm", "r");
    unsigned long size, resident, shared, text, lib, data;
    if (!f)
        return;
    int n = fscanf(f, "%lu %lu %lu %lu %lu %lu", &size, &resident, &shared, &text, &lib, &data);
    fclose(f);
    long page = sysconf(_SC_PAGESIZE);
    if (n != 6 || page <= 0)
        return;
    uint64_t have = (uint64_t)data * (uint64_t)page;
    struct rlimit rl;
    if (getrlimit(RLIMIT_DATA, &rl) != 0)
        return;
    uint64_t want = have + budget < have ? UINT64_MAX : have + budget;
    if (rl.rlim_max != RLIM_INFINITY && want > rl.rlim_max)
        want = rl.rlim_max;
    rl.rlim_cur = want > (uint64_t)RLIM_INFINITY - 1 ? RLIM_INFINITY : (rlim_t)want;
    setrlimit(RLIMIT_DATA, &rl);
}

static void on_out_of_memory(void)
{
    char msg[MAX_ERR];
    snprintf(msg, sizeof msg,
             "%s: the import needs more than %llu MiB, the memory cap for importing "
             "(a damaged element count, or raise the triangle cap / max_import_bytes)",
             child_path, (unsigned long long)(child_budget >> 20));
    send_error(child_fd, SC_ERR_LIMIT, msg, NULL, 0);
    _exit(EXIT_TERMINATE);
}

static void run_child(int fd, const sc_scene *parent, const char *path, const double xform[16],
                      const float *color)
{
    child_fd = fd;
    child_path = path;
    /* assimp and the C++ runtime print to stdout/stderr on the way down;
     * the caller's one error line is built from what comes through fd. */
    int devnull = open("/dev/null", O_RDWR);
    if (devnull >= 0) {
        dup2(devnull, STDIN_FILENO);
        dup2(devnull, STDOUT_FILENO);
        dup2(devnull, STDERR_FILENO);
        if (devnull > STDERR_FILENO)
            close(devnull);
    }
    /* The caller's signal handlers are the caller's: a test harness that
     * longjmps out of SIGSEGV, or a SIGINT handler that removes outputs,
     * must not run in here. Default actions make a crash a crash (and a
     * SIGPIPE from a parent that stopped reading, a quiet death). */
    for (int sig = 1; sig < NSIG; sig++) {
        struct sigaction sa;
        if (sig == SIGKILL || sig == SIGSTOP || sigaction(sig, NULL, &sa) != 0)
            continue;
        if (sa.sa_handler != SIG_IGN || sig == SIGPIPE)
            signal(sig, SIG_DFL);
    }
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, NULL);
    child_budget = memory_budget(parent);
    sc_scene_assimp_child_hooks(on_terminate, on_out_of_memory);

    static warn_store warns;
    sc_scene_options o;
    sc_scene_options_init(&o);
    o.warn = collect_warning;
    o.warn_ctx = &warns;
    o.import_in_process = 1;
    sc_scene *s = NULL;
    char err[MAX_ERR] = "";
    sc_status st = sc_scene_create(&o, &s);
    if (st != SC_OK) {
        send_error(fd, st, "out of memory in the import process", NULL, 0);
        _exit(1);
    }
    /* Room left under the parent's caps: an oversize model is refused in
     * the child, before it is copied anywhere. */
    s->max_triangles = parent->max_triangles - parent->num_triangles;
    s->max_pixels = parent->max_pixels;
    limit_memory(child_budget);
    st = sc_scene_import_assimp(s, path, xform, color, 0, err, sizeof err);
    if (st == SC_ERR_OUT_OF_MEMORY || (st != SC_OK && strstr(err, "bad_alloc")))
        on_out_of_memory();
    if (st != SC_OK) {
        send_error(fd, st, err, &warns, s->warnings);
        _exit(0);
    }
    wire_head h = {
        .magic = MAGIC_HEAD, .status = SC_OK,
        .num_vertices = s->num_vertices, .num_triangles = s->num_triangles,
        .num_meshes = s->num_meshes, .warnings = s->warnings, .degenerate = s->degenerate,
        .dropped_nonfinite = s->dropped_nonfinite, .skipped_primitives = s->skipped_primitives,
        .num_warn_lines = warns.n,
    };
    uint32_t tail = MAGIC_TAIL;
    int bad = write_all(fd, &h, sizeof h);
    for (uint32_t i = 0; !bad && i < warns.n; i++) {
        uint32_t n = (uint32_t)strlen(warns.lines[i]);
        bad = write_all(fd, &n, sizeof n) || write_all(fd, warns.lines[i], n);
    }
    bad = bad || write_all(fd, s->positions, s->num_vertices * 3 * sizeof(float)) ||
          write_all(fd, s->indices, s->num_triangles * 3 * sizeof(uint32_t)) ||
          write_all(fd, s->mesh_ids, s->num_triangles * sizeof(uint32_t)) ||
          write_all(fd, s->mesh_colors, s->num_meshes * 3 * sizeof(float)) ||
          write_all(fd, s->mesh_emission, s->num_meshes * 3 * sizeof(float)) ||
          write_all(fd, &tail, sizeof tail);
    _exit(bad ? 1 : 0);
}

/* ---- parent ----------------------------------------------------------- */

typedef struct reader {
    int fd;
    struct timespec deadline;
    int timed_out;
} reader;

static long ms_left(const struct timespec *deadline)
{
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    double ms = (double)(deadline->tv_sec - now.tv_sec) * 1e3 +
                (double)(deadline->tv_nsec - now.tv_nsec) / 1e6;
    return ms <= 0 ? 0 : ms > 1e9 ? 1000000000L : (long)ms + 1;
}

/* 0: got all n bytes; -1: end of stream, read error or time limit. */
static int read_all(reader *r, void *p, size_t n)
{
    char *c = p;
    while (n > 0) {
        long left = ms_left(&r->deadline);
        if (left == 0) {
            r->timed_out = 1;
            return -1;
        }
        struct pollfd pfd = { .fd = r->fd, .events = POLLIN };
        int k = poll(&pfd, 1, left > 60000 ? 60000 : (int)left);
        if (k < 0 && errno != EINTR)
            return -1;
        if (k <= 0)
            continue;
        ssize_t got = read(r->fd, c, n > (1u << 30) ? (1u << 30) : n);
        if (got < 0 && (errno == EINTR || errno == EAGAIN))
            continue;
        if (got <= 0)
            return -1;
        c += got;
        n -= (size_t)got;
    }
    return 0;
}

static const char *signal_name(int sig)
{
    switch (sig) {
    case SIGSEGV: return "SIGSEGV, invalid memory access";
    case SIGBUS: return "SIGBUS, invalid memory access";
    case SIGABRT: return "SIGABRT, aborted";
    case SIGFPE: return "SIGFPE, arithmetic fault";
    case SIGILL: return "SIGILL, illegal instruction";
    case SIGKILL: return "SIGKILL, killed (out of memory?)";
    default: return "signal";
    }
}

/* Reaps the child; -1 when someone else reaped it (SIGCHLD ignored). */
static int reap(pid_t pid, int kill_first)
{
    if (kill_first)
        kill(pid, SIGKILL);
    int status;
    for (;;) {
        pid_t r = waitpid(pid, &status, 0);
        if (r == pid)
            return status;
        if (r < 0 && errno != EINTR)
            return -1;
    }
}

static sc_status describe_failure(const char *path, int status, int timed_out, uint32_t timeout_ms,
                                  char *err, size_t errlen)
{
    if (timed_out)
        return sc_scene_errf(err, errlen, SC_ERR_LIMIT,
                             "%s: import took longer than %.3g s and was stopped (damaged file? "
                             "raise SPHERECULL_IMPORT_TIMEOUT for a huge model)",
                             path, timeout_ms / 1000.0);
    if (status != -1 && WIFSIGNALED(status))
        return sc_scene_errf(err, errlen, SC_ERR_PARSE,
                             "%s: assimp crashed reading the file (signal %d: %s); the file is "
                             "damaged or not supported", path, WTERMSIG(status),
                             signal_name(WTERMSIG(status)));
    if (status != -1 && WIFEXITED(status))
        return sc_scene_errf(err, errlen, SC_ERR_PARSE,
                             "%s: the import process ended (exit status %d) without a result",
                             path, WEXITSTATUS(status));
    return sc_scene_errf(err, errlen, SC_ERR_PARSE,
                         "%s: the import process ended without a result", path);
}

/* Reads the success payload straight into s's arrays; commits nothing
 * unless the whole stream arrived and is consistent. Returns SC_OK without
 * setting *drained when the stream broke off. */
static sc_status receive_scene(sc_scene *s, reader *r, const wire_head *h, const char *path,
                               int *drained, char *err, size_t errlen)
{
    uint64_t nv = h->num_vertices, nt = h->num_triangles, nm = h->num_meshes;
    if (nv > UINT32_MAX || nm > MAX_MESHES || (nt > 0 && nm == 0))
        return sc_scene_errf(err, errlen, SC_ERR_PARSE, "%s: the import process sent a bad header",
                             path);
    sc_status st = sc_scene_reserve(s, (size_t)nv, (size_t)nt, err, errlen);
    if (st != SC_OK)
        return st;
    /* Colours then emission, 3 floats each per mesh. */
    float *colors = malloc(nm ? nm * 6 * sizeof(float) : 1);
    if (!colors)
        return sc_scene_errf(err, errlen, SC_ERR_OUT_OF_MEMORY, "%s: out of memory", path);
    float *pos = s->positions + 3 * s->num_vertices;
    uint32_t *idx = s->indices + 3 * s->num_triangles;
    uint32_t *ids = s->mesh_ids + s->num_triangles;
    uint32_t tail = 0;
    if (read_all(r, pos, nv * 3 * sizeof(float)) || read_all(r, idx, nt * 3 * sizeof(uint32_t)) ||
        read_all(r, ids, nt * sizeof(uint32_t)) || read_all(r, colors, nm * 6 * sizeof(float)) ||
        read_all(r, &tail, sizeof tail) || tail != MAGIC_TAIL) {
        free(colors);
        return SC_OK;   /* not drained: the caller describes the crash or the timeout */
    }
    *drained = 1;
    /* What the child promised (the scene invariants) is re-checked: a
     * stream garbled by a dying child must not reach the tracer. */
    int ok = 1;
    for (size_t i = 0; ok && i < 3 * nv; i++)
        ok = pos[i] - pos[i] == 0;   /* finite */
    for (size_t i = 0; ok && i < 3 * nt; i++)
        ok = idx[i] < nv;
    for (size_t i = 0; ok && i < nt; i++)
        ok = ids[i] < nm;
    if (!ok) {
        free(colors);
        return sc_scene_errf(err, errlen, SC_ERR_PARSE,
                             "%s: the import process sent inconsistent triangles", path);
    }
    size_t first_mesh = s->num_meshes;
    for (size_t m = 0; m < nm; m++) {
        uint32_t id;
        st = sc_scene_new_mesh(s, colors + 3 * m, &id);
        if (st == SC_OK && sc_scene_set_mesh_emission(s, id, colors + 3 * (nm + m)) != SC_OK)
            st = SC_ERR_PARSE;   /* out of range: a garbled stream */
        if (st != SC_OK) {
            s->num_meshes = first_mesh;
            free(colors);
            return sc_scene_errf(err, errlen, st, "%s: cannot add meshes: %s", path, sc_strerror(st));
        }
    }
    free(colors);
    uint32_t vbase = (uint32_t)s->num_vertices, mbase = (uint32_t)first_mesh;
    for (size_t i = 0; i < 3 * nt; i++)
        idx[i] += vbase;
    for (size_t i = 0; i < nt; i++)
        ids[i] += mbase;
    s->num_vertices += nv;
    s->num_triangles += nt;
    s->degenerate += h->degenerate;
    s->dropped_nonfinite += h->dropped_nonfinite;
    s->skipped_primitives += h->skipped_primitives;
    return SC_OK;
}

sc_status sc_scene_import_assimp_in_child(sc_scene *s, const char *path, const double xform[16],
                                          const float *color, char *err, size_t errlen)
{
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0)
        return sc_scene_errf(err, errlen, SC_ERR_IO, "%s: cannot create a pipe for the import: %s",
                             path, strerror(errno));
    /* Fewer wake-ups per megabyte for big meshes; best effort. */
    (void)fcntl(fds[1], F_SETPIPE_SZ, 1 << 20);
    pid_t pid = fork();
    if (pid < 0) {
        int e = errno;
        close(fds[0]);
        close(fds[1]);
        return sc_scene_errf(err, errlen, e == ENOMEM || e == EAGAIN ? SC_ERR_OUT_OF_MEMORY : SC_ERR_IO,
                             "%s: cannot start the import process: %s", path, strerror(e));
    }
    if (pid == 0) {
        close(fds[0]);
        run_child(fds[1], s, path, xform, color);
        _exit(1);
    }
    close(fds[1]);
    reader r = { .fd = fds[0] };
    clock_gettime(CLOCK_MONOTONIC, &r.deadline);
    r.deadline.tv_sec += s->import_timeout_ms / 1000;
    r.deadline.tv_nsec += (long)(s->import_timeout_ms % 1000) * 1000000L;
    if (r.deadline.tv_nsec >= 1000000000L) {
        r.deadline.tv_sec++;
        r.deadline.tv_nsec -= 1000000000L;
    }

    wire_head h;
    sc_status st = SC_OK;
    int drained = 0;   /* the whole stream, up to its tail marker, was read */
    char *msg = NULL;
    int ok = read_all(&r, &h, sizeof h) == 0 && h.magic == MAGIC_HEAD && h.err_len <= MAX_ERR &&
             h.num_warn_lines <= SC_SCENE_MAX_WARNINGS && h.status >= 0 &&
             h.status < SC_STATUS_COUNT;
    if (ok) {
        msg = calloc(1, MAX_ERR + 1);
        ok = msg && read_all(&r, msg, h.err_len) == 0;
    }
    /* Warnings first, in the order the loader gave them. */
    for (uint32_t i = 0; ok && i < h.num_warn_lines; i++) {
        uint32_t n;
        char line[MAX_WARN_LEN + 1];
        ok = read_all(&r, &n, sizeof n) == 0 && n <= MAX_WARN_LEN && read_all(&r, line, n) == 0;
        if (ok) {
            line[n] = '\0';
            sc_scene_warnf(s, "%s", line);
        }
    }
    if (ok && h.warnings > h.num_warn_lines)
        s->warnings += (size_t)(h.warnings - h.num_warn_lines);
    if (ok && h.status != SC_OK) {
        uint32_t tail = 0;
        drained = read_all(&r, &tail, sizeof tail) == 0 && tail == MAGIC_TAIL;
        if (drained)
            st = sc_scene_errf(err, errlen, (sc_status)h.status, "%s", msg);
    } else if (ok) {
        st = receive_scene(s, &r, &h, path, &drained, err, errlen);
    }
    free(msg);
    /* After the tail the child is exiting: wait for it. Anything else
     * (timeout, crash, cap refused mid-stream, garbage) kills it first, so
     * that neither side can wait on the other. */
    int status = reap(pid, !drained);
    close(fds[0]);
    if (!drained && st == SC_OK)
        return describe_failure(path, status, r.timed_out, s->import_timeout_ms, err, errlen);
    return st;
}

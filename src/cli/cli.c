/* Parsing, help, errors and output files for every command (see cli.h). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <getopt.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli.h"
#ifdef SC_HAVE_MPI
#include "mpi/sc_mpi.h"
#endif
#include "common/sc_atomic_file.h"
#include "spherecull/sc_isa.h"
#include "spherecull/sc_rays.h"
#include "spherecull/sc_scene.h"

enum { MAX_OPTS = 48, OPT_BASE = 256, HELP_COLUMN = 26 };

static int errors_quiet;

void sc_cli_quiet_errors(int quiet) { errors_quiet = quiet; }

int sc_cli_mpi_rank(void)
{
    static const char *const vars[] = { "OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK" };
    for (size_t i = 0; i < sizeof vars / sizeof vars[0]; i++) {
        const char *v = getenv(vars[i]);
        if (v && *v) {
            char *end;
            long r = strtol(v, &end, 10);
            if (*end == 0 && r >= 0 && r < 1L << 30)
                return (int)r;
        }
    }
    return -1;
}

int sc_cli_mpi_start(const char *cmd, int *argc, char ***argv, struct sc_mpi **mpi, int *rank, int *size)
{
    *mpi = NULL, *rank = 0, *size = 1;
    if (sc_cli_mpi_rank() < 0)
        return 0;
#ifdef SC_HAVE_MPI
    char err[256];
    if (sc_mpi_init(argc, argv, mpi, err, sizeof err) != SC_OK) {
        sc_cli_error(cmd, "%s", err);
        return 1;
    }
    *rank = sc_mpi_rank(*mpi), *size = sc_mpi_size(*mpi);
    return 0;
#else
    (void)argc, (void)argv;
    sc_cli_error(cmd, "started by an MPI launcher, but this spherecull was built without MPI "
                      "(install libopenmpi-dev and rebuild, or run it without mpirun)");
    return 2;
#endif
}

int sc_cli_mpi_failed(const char *cmd, struct sc_mpi *mpi, sc_status st, const char *line)
{
    int first = st == SC_OK ? -1 : 0, rank = 0;
#ifdef SC_HAVE_MPI
    if (mpi) {
        sc_mpi_agree(mpi, st, &first);
        rank = sc_mpi_rank(mpi);
    }
#else
    (void)mpi;
#endif
    if (first < 0)
        return 0;
    if (first == rank && line) {
        sc_cli_quiet_errors(0);
        sc_cli_error(cmd, "%s", line);
    }
    return 1;
}

void sc_cli_error(const char *command, const char *fmt, ...)
{
    if (errors_quiet)
        return;
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "spherecull: %s: ", command);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
}

static void help_line(FILE *f, int short_name, const char *name, const char *arg, const char *help,
                      const char *def)
{
    char left[96];
    snprintf(left, sizeof left, "  %c%c%s--%s%s%s", short_name ? '-' : ' ', short_name ? short_name : ' ',
             short_name ? ", " : "  ", name, arg ? " " : "", arg ? arg : "");
    if (strlen(left) < HELP_COLUMN)
        fprintf(f, "%-*s%s", HELP_COLUMN, left, help);
    else
        fprintf(f, "%s\n%-*s%s", left, HELP_COLUMN, "", help);
    if (def)
        fprintf(f, " (default: %s)", def);
    fputc('\n', f);
}

void sc_cli_help(const sc_cli_cmd *cmd, FILE *f)
{
    fprintf(f, "usage: spherecull %s%s%s [options]\n\n%s\n\noptions:\n", cmd->name, cmd->operands[0] ? " " : "",
            cmd->operands, cmd->summary);
    for (int i = 0; i < cmd->nopts; i++) {
        const sc_cli_opt *o = &cmd->opts[i];
        help_line(f, o->short_name, o->name, o->arg, o->help, o->def);
    }
    help_line(f, 'h', "help", NULL, "this help", NULL);
    if (cmd->details)
        fprintf(f, "\n%s", cmd->details);
    if (cmd->more)
        fputs(cmd->more(), f);
}

int sc_cli_parse(const sc_cli_cmd *cmd, int argc, char **argv, sc_cli_handler fn, void *ctx)
{
    struct option longs[MAX_OPTS + 2];
    char shorts[2 * MAX_OPTS + 4] = ":h";
    size_t ns = 2;
    if (cmd->nopts > MAX_OPTS) {
        sc_cli_error(cmd->name, "too many options for the parser");
        return 1;
    }
    for (int i = 0; i < cmd->nopts; i++) {
        const sc_cli_opt *o = &cmd->opts[i];
        longs[i] = (struct option){ o->name, o->arg ? required_argument : no_argument, NULL, OPT_BASE + i };
        if (o->short_name) {
            shorts[ns++] = (char)o->short_name;
            if (o->arg)
                shorts[ns++] = ':';
        }
    }
    shorts[ns] = 0;
    longs[cmd->nopts] = (struct option){ "help", no_argument, NULL, 'h' };
    longs[cmd->nopts + 1] = (struct option){ NULL, 0, NULL, 0 };
    opterr = 0;   /* our own one-line messages */
    optind = 1;
    int c;
    while ((c = getopt_long(argc, argv, shorts, longs, NULL)) != -1) {
        int rc = 0;
        if (c == 'h') {
            sc_cli_help(cmd, stdout);
            return -1;
        } else if (c == '?' || c == ':') {
            const char *what = argv[optind - 1];
            char shortopt[3] = { '-', (char)optopt, 0 };
            if (optopt && optopt < OPT_BASE && (strncmp(what, "--", 2) != 0))
                what = shortopt;
            sc_cli_error(cmd->name, c == '?' ? "unknown option '%s' (try --help)" : "option '%s' needs a value",
                         what);
            return 2;
        } else if (c >= OPT_BASE) {
            rc = fn(ctx, c - OPT_BASE, optarg);
        } else {
            for (int i = 0; i < cmd->nopts; i++)
                if (cmd->opts[i].short_name == c)
                    rc = fn(ctx, i, optarg);
        }
        if (rc)
            return rc;
    }
    for (int i = optind; i < argc; i++) {
        int rc = fn(ctx, -1, argv[i]);
        if (rc)
            return rc;
    }
    return 0;
}

int sc_cli_check_output(const char *command, const char *option, const char *path)
{
    if (!path)
        return 0;
    struct stat st;
    if (stat(path, &st) == 0 && !S_ISREG(st.st_mode)) {
        sc_cli_error(command, "%s '%s': not a regular file", option, path);
        return -1;
    }
    const char *slash = strrchr(path, '/');
    size_t dlen = slash ? (size_t)(slash - path) : 1;
    char *probe = malloc(dlen + 32);
    if (!probe) {
        sc_cli_error(command, "out of memory");
        return -1;
    }
    if (slash)
        snprintf(probe, dlen + 32, "%.*s/.spherecull-probe-XXXXXX", (int)(dlen ? dlen : 1), dlen ? path : "/");
    else
        snprintf(probe, dlen + 32, "./.spherecull-probe-XXXXXX");
    int fd = mkstemp(probe);
    if (fd < 0) {
        sc_cli_error(command, "%s '%s': cannot write there: %s", option, path, strerror(errno));
        free(probe);
        return -1;
    }
    close(fd);
    unlink(probe);
    free(probe);
    return 0;
}

int sc_cli_write(const char *command, const char *path, int (*write_fn)(void *ctx, FILE *f), void *ctx)
{
    if (sc_write_atomic(path, write_fn, ctx) == 0)
        return 0;
    sc_cli_error(command, "cannot write %s: %s", path, strerror(errno));
    return -1;
}

int sc_cli_int(const char *cmd, const char *opt, const char *s, long lo, long hi, long *out)
{
    char *end;
    errno = 0;
    long v = s && *s ? strtol(s, &end, 10) : 0;
    if (!s || !*s || errno || *end || v < lo || v > hi) {
        sc_cli_error(cmd, "--%s wants a whole number in %ld..%ld, not '%s'", opt, lo, hi, s ? s : "");
        return -1;
    }
    *out = v;
    return 0;
}

int sc_cli_double(const char *cmd, const char *opt, const char *s, double lo, double hi, double *out)
{
    char *end;
    errno = 0;
    double v = s && *s ? strtod(s, &end) : 0;
    if (!s || !*s || errno || *end || !isfinite(v) || v < lo || v > hi) {
        sc_cli_error(cmd, "--%s wants a number in [%g, %g], not '%s'", opt, lo, hi, s ? s : "");
        return -1;
    }
    *out = v;
    return 0;
}

int sc_cli_choice(const char *cmd, const char *opt, const char *s, const char *a, const char *b, int *out)
{
    if (s && strcmp(s, a) == 0)
        return *out = 0, 0;
    if (s && strcmp(s, b) == 0)
        return *out = 1, 0;
    sc_cli_error(cmd, "--%s: '%s' is not %s or %s", opt, s ? s : "", a, b);
    return -1;
}

int sc_cli_vec3(const char *cmd, const char *opt, const char *s, double lim, double out[3])
{
    const char *p = s ? s : "";
    int ok = 1;
    for (int i = 0; ok && i < 3; i++) {
        char *end;
        errno = 0;
        double v = strtod(p, &end);
        ok = end != p && !errno && isfinite(v) && fabs(v) <= lim && *end == (i < 2 ? ',' : '\0');
        out[i] = v;
        p = end + (i < 2);
    }
    if (!ok) {
        sc_cli_error(cmd, "--%s wants X,Y,Z (three numbers, |x| <= %g), not '%s'", opt, lim, s ? s : "");
        return -1;
    }
    return 0;
}

int sc_cli_u64(const char *cmd, const char *opt, const char *s, unsigned long long *out)
{
    char *end;
    errno = 0;
    unsigned long long v = s && *s && *s != '-' ? strtoull(s, &end, 10) : 0;
    if (!s || !*s || *s == '-' || errno || *end) {
        sc_cli_error(cmd, "--%s wants a non-negative whole number, not '%s'", opt, s ? s : "");
        return -1;
    }
    *out = v;
    return 0;
}

int sc_cli_int_list(const char *cmd, const char *opt, const char *s, int lo, int hi, int *out, int max)
{
    int n = 0;
    for (const char *p = s;;) {
        char *end;
        errno = 0;
        long v = strtol(p, &end, 10);
        if (errno || end == p || v < lo || v > hi || n >= max || (*end && *end != ','))
            break;
        out[n++] = (int)v;
        if (!*end)
            return n;
        p = end + 1;
    }
    sc_cli_error(cmd, "--%s wants a comma list of at most %d numbers in %d..%d, not '%s'", opt, max, lo, hi, s);
    return -1;
}

int sc_cli_load_mesh_msg(const char *spec, sc_scene **scene, sc_scene_view *v, sc_mesh_view *mesh, char *err,
                         size_t errlen)
{
    err[0] = 0;
    sc_status st = sc_scene_load(spec, NULL, scene, err, errlen);
    if (st != SC_OK) {
        if (!err[0])
            snprintf(err, errlen, "%s", sc_strerror(st));
        return 1;
    }
    sc_scene_get_view(*scene, v);
    if (v->mesh.triangle_count == 0 || v->mesh.triangle_count > UINT32_MAX || v->mesh.vertex_count > UINT32_MAX) {
        snprintf(err, errlen, "%s: %zu triangles: nothing to trace, or too many", spec, v->mesh.triangle_count);
        sc_scene_free(*scene);
        *scene = NULL;
        return 1;
    }
    *mesh = (sc_mesh_view){ v->mesh.positions, (uint32_t)v->mesh.vertex_count, v->mesh.indices, (uint32_t)v->mesh.triangle_count, 0, 0 };
    return 0;
}

int sc_cli_load_mesh(const char *cmd, const char *spec, sc_scene **scene, sc_scene_view *v, sc_mesh_view *mesh)
{
    char err[512];
    if (sc_cli_load_mesh_msg(spec, scene, v, mesh, err, sizeof err) != 0) {
        sc_cli_error(cmd, "%s", err);
        return 1;
    }
    return 0;
}

int sc_cli_isa(const char *cmd, const char *s)
{
    sc_isa isa;
    if (strcmp(s, "auto") == 0)
        return 0;
    if (sc_isa_from_name(s, &isa) != SC_OK) {
        sc_cli_error(cmd, "--isa takes %s, not '%s'", SC_CLI_ISA_VALUES, s);
        return 2;
    }
    if (sc_isa_force(isa) != SC_OK) {
        sc_cli_error(cmd, "this CPU cannot run the %s kernels", s);
        return 2;
    }
    return 0;
}

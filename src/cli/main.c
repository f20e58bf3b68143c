/* spherecull — command-line front end. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "commands.h"
#include "common/sc_atomic_file.h"

/* One row per subcommand; each subsystem adds its own. */
static const sc_command commands[] = {
    { "accuracy", "circumsphere accuracy of every method against MPFR", sc_cmd_accuracy },
    { "bench", "tracer Mrays/s per prefilter mode and leaf size, against Embree on the same rays", sc_cmd_bench },
    { "bench-spheres", "SIMD batch-sphere and reject-mask throughput vs memcpy, speed vs error", sc_cmd_bench_spheres },
    { "compare", "every tracer vs an exact oracle: speed, disagreements, prefilter work", sc_cmd_compare },
    { "raster", "rasterize a scene offscreen (OSMesa): preview, triangle IDs, depth", sc_cmd_raster },
    { "raster-check", "raster ID buffer vs tracer primary hits: agreement, map, overlay", sc_cmd_raster_check },
    { "render", "trace a scene to a PNG: Lambert, shadows, AO, debug views", sc_cmd_render },
};

void sc_cli_error(const char *command, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "spherecull: %s: ", command);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
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

int sc_cli_write_atomic(const char *path, int (*write_fn)(void *ctx, FILE *f), void *ctx)
{
    return sc_write_atomic(path, write_fn, ctx);
}

static void usage(FILE *out)
{
    fprintf(out, "usage: spherecull <command> [options]\n\ncommands:\n");
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        fprintf(out, "  %-14s %s\n", commands[i].name, commands[i].summary);
    fprintf(out, "\n'spherecull <command> --help' describes one command.\n");
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return 2;
    }
    if (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "help") == 0) {
        usage(stdout);
        return 0;
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (strcmp(argv[1], commands[i].name) == 0)
            return commands[i].run(argc - 1, argv + 1);
    fprintf(stderr, "spherecull: unknown command '%s' (try 'spherecull --help')\n", argv[1]);
    return 2;
}

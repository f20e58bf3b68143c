/* Subcommands of the spherecull CLI. Each returns the process exit status:
 * 0 on success, 1 on a runtime error (reported as one line on stderr),
 * 2 on a usage error. */
#ifndef SPHERECULL_CLI_COMMANDS_H
#define SPHERECULL_CLI_COMMANDS_H

#include <stdio.h>

typedef struct sc_command {
    const char *name;
    const char *summary;
    int (*run)(int argc, char **argv);   /* argv[0] is the command name */
} sc_command;

int sc_cmd_accuracy(int argc, char **argv);
int sc_cmd_bench(int argc, char **argv);
int sc_cmd_bench_spheres(int argc, char **argv);
int sc_cmd_compare(int argc, char **argv);
int sc_cmd_raster(int argc, char **argv);
int sc_cmd_raster_check(int argc, char **argv);
int sc_cmd_render(int argc, char **argv);

/* One line "spherecull: <command>: <message>" on stderr. */
void sc_cli_error(const char *command, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

/* Checks, before any work is done, that an output file can be written:
 * PATH is absent or a regular file, and its folder exists and accepts a new
 * file (tried for real, so permissions, read-only mounts and root are all
 * judged correctly). NULL passes. On failure prints one error line and
 * returns -1, so a run never fails at its end after minutes of work. */
int sc_cli_check_output(const char *command, const char *option, const char *path);

/* Writes through a temporary file in the same directory and renames it into
 * place, so a failed or interrupted run never leaves a half-written output.
 * write_fn returns 0 on success. */
int sc_cli_write_atomic(const char *path, int (*write_fn)(void *ctx, FILE *f), void *ctx);

/* --isa: "auto" gives -1 (keep the library's choice), a level name its
 * sc_isa value. Returns 0, or -1 for an unknown name. */
int sc_cli_parse_isa(const char *name, int *isa);

#endif

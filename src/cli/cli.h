/* The spherecull command line: each command is a table of options (which
 * drives getopt_long and the help text alike, so every command prints help
 * in one layout with its defaults) and a run function that parses, calls
 * the library and prints. Exit status: 0 on success, 1 on a runtime error,
 * 2 on a usage error; every error is one line on stderr. */
#ifndef SPHERECULL_CLI_CLI_H
#define SPHERECULL_CLI_CLI_H

#include <stddef.h>
#include <stdio.h>

#include "spherecull/sc_status.h"

typedef struct sc_cli_opt {
    const char *name;        /* long name, without "--" */
    int short_name;          /* a letter, or 0 */
    const char *arg;         /* value placeholder ("FILE"); NULL for a flag */
    const char *help;
    const char *def;         /* default shown in --help; NULL: none */
} sc_cli_opt;

typedef struct sc_cli_cmd {
    const char *name;
    const char *operands;    /* "SCENE...", "" */
    const char *summary;     /* one line, also in 'spherecull --help' */
    const char *details;     /* text after the options, or NULL */
    const char *(*more)(void);   /* text known only at run time, or NULL */
    const sc_cli_opt *opts;
    int nopts;
    int (*run)(int argc, char **argv);   /* argv[0] is the command name */
    int mpi;                 /* 1: shares its work across MPI ranks under mpirun */
} sc_cli_cmd;

extern const sc_cli_cmd sc_cli_accuracy, sc_cli_bench, sc_cli_bench_render, sc_cli_bench_spheres, sc_cli_compare, sc_cli_raster,
    sc_cli_raster_check, sc_cli_render;

/* Called per option (index into cmd->opts; val NULL for flags) and per
 * operand (opt -1). Returns 0 to go on, or an exit status after printing
 * the error line. */
typedef int (*sc_cli_handler)(void *ctx, int opt, const char *val);

/* getopt_long over argv (so --opt=value and -- work; operands may come
 * anywhere). Returns 0 when all was parsed, -1 after printing --help
 * (the command then exits 0), or an exit status after an error line. */
int sc_cli_parse(const sc_cli_cmd *cmd, int argc, char **argv, sc_cli_handler fn, void *ctx);

/* The help of one command, in the common layout. */
void sc_cli_help(const sc_cli_cmd *cmd, FILE *f);

/* One line "spherecull: <command>: <message>" on stderr. */
void sc_cli_error(const char *command, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* 1: sc_cli_error prints nothing (MPI ranks other than 0, for errors every
 * rank finds alike, so that one line is printed, not one per rank). */
void sc_cli_quiet_errors(int quiet);

/* The rank an MPI launcher gave this process (Open MPI's
 * OMPI_COMM_WORLD_RANK, PMIx's PMIX_RANK, PMI's PMI_RANK), or -1 when no
 * launcher started it. Read from the environment, so known before MPI_Init
 * and in builds without MPI. */
int sc_cli_mpi_rank(void);

/* Starts MPI when a launcher started this process (sc_cli_mpi_rank() >= 0):
 * *mpi, *rank and *size are set; without a launcher *mpi = NULL, rank 0,
 * size 1. Returns 0, or an exit status after one error line (MPI did not
 * start, or this build has no MPI driver). sc_mpi.h has the rest. */
struct sc_mpi;
int sc_cli_mpi_start(const char *cmd, int *argc, char ***argv, struct sc_mpi **mpi, int *rank, int *size);

/* A status every rank reaches (sc_mpi_agree; mpi NULL: the local status):
 * 0 if every rank succeeded, else 1, and the lowest failing rank prints
 * line (NULL: it has said so already). */
int sc_cli_mpi_failed(const char *cmd, struct sc_mpi *mpi, sc_status st, const char *line);

/* Checks, before any work is done, that an output file can be written:
 * PATH is absent or a regular file, and its folder exists and accepts a new
 * file (tried for real, so permissions, read-only mounts and root are all
 * judged correctly). NULL passes. On failure prints one error line and
 * returns -1, so a run never fails at its end after minutes of work. */
int sc_cli_check_output(const char *command, const char *option, const char *path);

/* Writes PATH atomically (common/sc_atomic_file.h); on failure prints one
 * error line and returns -1. */
int sc_cli_write(const char *command, const char *path, int (*write_fn)(void *ctx, FILE *f), void *ctx);

/* Loads SPEC for the tracers: the scene, its view, and a mesh view of at
 * least one triangle with 32-bit counts. 0, or 1 after an error line (the
 * scene is then freed). */
struct sc_scene;
struct sc_scene_view;
struct sc_mesh_view;
int sc_cli_load_mesh(const char *cmd, const char *spec, struct sc_scene **scene, struct sc_scene_view *v,
                     struct sc_mesh_view *mesh);
/* The same, the error line (without the command) in err instead of on stderr. */
int sc_cli_load_mesh_msg(const char *spec, struct sc_scene **scene, struct sc_scene_view *v,
                         struct sc_mesh_view *mesh, char *err, size_t errlen);

/* Value parsers: 0 on success, else an error line naming OPT and -1. */
int sc_cli_int(const char *cmd, const char *opt, const char *s, long lo, long hi, long *out);
/* --isa: "auto" keeps the library's choice (SPHERECULL_ISA or the widest
 * level); a level name switches every kernel to it. 0, or 2 after one error
 * line (unknown name, or a level this CPU cannot run). */
int sc_cli_isa(const char *cmd, const char *s);
#define SC_CLI_ISA_VALUES "auto|scalar|sse4|avx2|avx512"
int sc_cli_u64(const char *cmd, const char *opt, const char *s, unsigned long long *out);
/* A finite number in [lo, hi]; "X,Y,Z", three finite numbers of magnitude at most lim. */
int sc_cli_double(const char *cmd, const char *opt, const char *s, double lo, double hi, double *out);
int sc_cli_vec3(const char *cmd, const char *opt, const char *s, double lim, double out[3]);
/* One of two words: *out = 0 for a, 1 for b. */
int sc_cli_choice(const char *cmd, const char *opt, const char *s, const char *a, const char *b, int *out);
/* A comma list of integers in [lo, hi], at most max; returns the count or -1. */
int sc_cli_int_list(const char *cmd, const char *opt, const char *s, int lo, int hi, int *out, int max);

#endif

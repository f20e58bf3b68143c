/* spherecull — command-line front end: finds the command and hands it
 * argv; 'help CMD' and '--version' are answered here. */
#include <stdio.h>
#include <string.h>

#include <spherecull/sc_version.h>

#include "cli.h"

static const sc_cli_cmd *const commands[] = {
    &sc_cli_accuracy, &sc_cli_bench, &sc_cli_bench_render, &sc_cli_bench_spheres, &sc_cli_compare,
    &sc_cli_raster, &sc_cli_raster_check, &sc_cli_render,
};
enum { NCOMMANDS = sizeof commands / sizeof commands[0] };

static const sc_cli_cmd *find(const char *name)
{
    for (int i = 0; i < NCOMMANDS; i++)
        if (strcmp(name, commands[i]->name) == 0)
            return commands[i];
    return NULL;
}

static void usage(FILE *out)
{
    fprintf(out, "usage: spherecull <command> [options]\n       spherecull help <command>\n"
                 "       spherecull --version\n\ncommands:\n");
    for (int i = 0; i < NCOMMANDS; i++)
        fprintf(out, "  %-14s %s\n", commands[i]->name, commands[i]->summary);
    fprintf(out, "\n'spherecull <command> --help' describes one command.\n");
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return 2;
    }
    const char *a = argv[1];
    if (strcmp(a, "--version") == 0 || strcmp(a, "-V") == 0) {
        printf("spherecull %s\n", sc_version_string());
        return 0;
    }
    if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0 || strcmp(a, "help") == 0) {
        if (argc < 3) {
            usage(stdout);
            return 0;
        }
        const sc_cli_cmd *c = find(argv[2]);
        if (!c) {
            fprintf(stderr, "spherecull: help: unknown command '%s' (try 'spherecull --help')\n", argv[2]);
            return 2;
        }
        sc_cli_help(c, stdout);
        return 0;
    }
    const sc_cli_cmd *c = find(a);
    if (c && !c->mpi && sc_cli_mpi_rank() >= 0) {
        /* N copies of a command that does not share its work would time
         * each other and write the same files */
        if (sc_cli_mpi_rank() == 0)
            fprintf(stderr, "spherecull: %s: not under mpirun: only render, compare and bench share their work "
                            "across ranks (docs/scale-out.md)\n", c->name);
        return 2;
    }
    if (c)
        return c->run(argc - 1, argv + 1);
    fprintf(stderr, "spherecull: unknown command '%s' (try 'spherecull --help')\n", a);
    return 2;
}

#define _POSIX_C_SOURCE 200809L
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "sc_gnuplot.h"

extern char **environ;

int sc_gnuplot(const char *script, FILE *out)
{
    int p[2];
    if (fflush(out) != 0 || pipe(p) != 0)
        return -1;
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, p[0], 0);
    posix_spawn_file_actions_adddup2(&fa, fileno(out), 1);
    posix_spawn_file_actions_addopen(&fa, 2, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addclose(&fa, p[1]);
    char *argv[] = { "gnuplot", NULL };
    pid_t pid;
    int spawned = posix_spawnp(&pid, "gnuplot", &fa, NULL, argv, environ) == 0;
    posix_spawn_file_actions_destroy(&fa);
    close(p[0]);
    int ok = spawned;
    if (spawned) {
        /* a gnuplot that dies early must not kill us with SIGPIPE */
        struct sigaction ign = { 0 }, old;
        ign.sa_handler = SIG_IGN;
        sigaction(SIGPIPE, &ign, &old);
        size_t len = strlen(script), at = 0;
        while (at < len) {
            ssize_t w = write(p[1], script + at, len - at);
            if (w <= 0)
                break;
            at += (size_t)w;
        }
        sigaction(SIGPIPE, &old, NULL);
        ok = at == len;
    }
    close(p[1]);
    int status;
    if (spawned && waitpid(pid, &status, 0) == pid)
        ok = ok && WIFEXITED(status) && WEXITSTATUS(status) == 0;
    else
        ok = 0;
    return ok ? 0 : -1;
}

int sc_gnuplot_write(void *script, FILE *out)
{
    return sc_gnuplot(script, out);
}

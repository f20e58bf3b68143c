/* src/common: CSV quoting, name tables, and the atomic file write (content,
 * mode from the umask, nothing left behind on failure, non-regular targets
 * refused). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>
#include <dirent.h>
#include <cmocka.h>

#include "common/sc_atomic_file.h"
#include "common/sc_clock.h"
#include "common/sc_csv.h"
#include "common/sc_names.h"

static char *csv_of(const char *s)
{
    static char buf[256];
    memset(buf, 0, sizeof buf);
    FILE *f = fmemopen(buf, sizeof buf, "w");
    assert_non_null(f);
    sc_csv_str(f, s);
    fclose(f);
    return buf;
}

static void test_csv_quoting(void **state)
{
    (void)state;
    assert_string_equal(csv_of("bunny.json"), "bunny.json");
    assert_string_equal(csv_of(""), "");
    assert_string_equal(csv_of("a,b"), "\"a,b\"");
    assert_string_equal(csv_of("say \"hi\""), "\"say \"\"hi\"\"\"");
    assert_string_equal(csv_of("two\nlines"), "\"two\nlines\"");
    assert_string_equal(csv_of("cr\r"), "\"cr\r\"");
}

enum { RED = 3, GREEN = 7 };
static const sc_name colours[] = { { "red", RED }, { "green", GREEN }, { "rouge", RED } };

static void test_names(void **state)
{
    (void)state;
    int v = -1;
    assert_int_equal(sc_name_lookup(colours, SC_NAMES_COUNT(colours), "green", &v), 0);
    assert_int_equal(v, GREEN);
    assert_int_equal(sc_name_lookup(colours, SC_NAMES_COUNT(colours), "rouge", &v), 0);
    assert_int_equal(v, RED);
    v = -1;
    assert_int_equal(sc_name_lookup(colours, SC_NAMES_COUNT(colours), "Green", &v), -1);
    assert_int_equal(sc_name_lookup(colours, SC_NAMES_COUNT(colours), NULL, &v), -1);
    assert_int_equal(v, -1);
    assert_string_equal(sc_name_of(colours, SC_NAMES_COUNT(colours), RED), "red");
    assert_null(sc_name_of(colours, SC_NAMES_COUNT(colours), 99));
    char buf[64];
    assert_string_equal(sc_names_join(colours, SC_NAMES_COUNT(colours), "|", buf, sizeof buf), "red|green|rouge");
}

static void test_clock(void **state)
{
    (void)state;
    double a = sc_now_seconds(), b = sc_now_seconds();
    assert_true(a > 0 && b >= a);
}

static int write_text(void *ctx, FILE *f)
{
    return fputs(ctx, f) < 0 ? -1 : 0;
}

static int write_then_fail(void *ctx, FILE *f)
{
    fputs(ctx, f);
    return -1;
}

static char dir[] = "/tmp/sc_test_common_XXXXXX";

/* Entries in dir other than those named. */
static int others(const char *keep)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    int n = 0;
    for (struct dirent *e; (e = readdir(d));)
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..") && strcmp(e->d_name, keep))
            n++;
    closedir(d);
    return n;
}

static char *slurp(const char *path)
{
    static char buf[256];
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    buf[n] = 0;
    fclose(f);
    return buf;
}

static void test_atomic_write(void **state)
{
    (void)state;
    assert_non_null(mkdtemp(dir));
    char path[128];
    snprintf(path, sizeof path, "%s/out.csv", dir);
    mode_t old = umask(027);
    assert_int_equal(sc_write_atomic(path, write_text, "first\n"), 0);
    umask(old);
    assert_string_equal(slurp(path), "first\n");
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    assert_int_equal(st.st_mode & 0777, 0640);      /* as fopen would under umask 027, not mkstemp's 0600 */
    assert_int_equal(others("out.csv"), 0);

    /* A failing writer keeps the old content and leaves no temporary. */
    assert_int_equal(sc_write_atomic(path, write_then_fail, "half"), -1);
    assert_string_equal(slurp(path), "first\n");
    assert_int_equal(others("out.csv"), 0);

    assert_int_equal(sc_write_atomic_bytes(path, "second", 6), 0);
    assert_string_equal(slurp(path), "second");

    /* A directory or a device is never replaced. */
    errno = 0;
    assert_int_equal(sc_write_atomic(dir, write_text, "x"), -1);
    assert_int_equal(errno, EISDIR);
    char link[160];
    snprintf(link, sizeof link, "%s/full", dir);
    assert_int_equal(symlink("/dev/full", link), 0);
    assert_int_equal(sc_write_atomic(link, write_text, "x"), -1);
    assert_int_equal(lstat(link, &st), 0);
    assert_true(S_ISLNK(st.st_mode));
    assert_int_equal(others("out.csv") , 1);          /* only the link */

    /* A missing directory fails cleanly. */
    snprintf(path, sizeof path, "%s/no/such/dir.csv", dir);
    assert_int_equal(sc_write_atomic(path, write_text, "x"), -1);
    assert_int_equal(errno, ENOENT);

    unlink(link);
    snprintf(path, sizeof path, "%s/out.csv", dir);
    unlink(path);
    rmdir(dir);
}

/* Stops the process with SIGTERM in the middle of the write. */
static int write_then_terminate(void *ctx, FILE *f)
{
    fputs(ctx, f);
    fflush(f);
    raise(SIGTERM);
    return 0;
}

static void test_atomic_write_killed(void **state)
{
    (void)state;
    memcpy(dir + strlen(dir) - 6, "XXXXXX", 6);
    assert_non_null(mkdtemp(dir));
    char path[128];
    snprintf(path, sizeof path, "%s/out.png", dir);
    struct sigaction before, after;
    assert_int_equal(sigaction(SIGTERM, NULL, &before), 0);
    assert_int_equal(sc_write_atomic(path, write_text, "old\n"), 0);
    /* the caller's handlers are put back once the write is over */
    assert_int_equal(sigaction(SIGTERM, NULL, &after), 0);
    assert_true(after.sa_handler == before.sa_handler);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        sc_write_atomic(path, write_then_terminate, "half of the new");
        _exit(0);      /* not reached: SIGTERM ends the child */
    }
    int status = 0;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    assert_true(WIFSIGNALED(status));
    assert_int_equal(WTERMSIG(status), SIGTERM);
    assert_string_equal(slurp(path), "old\n");
    assert_int_equal(others("out.png"), 0);           /* the temporary is gone */
    unlink(path);
    rmdir(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_csv_quoting),
        cmocka_unit_test(test_names),
        cmocka_unit_test(test_clock),
        cmocka_unit_test(test_atomic_write),
        cmocka_unit_test(test_atomic_write_killed),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

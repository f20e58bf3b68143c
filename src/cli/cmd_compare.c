/* spherecull compare: every tracer on the same scenes and rays, judged by
 * the exact oracle (src/compare). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include "commands.h"
#include "compare/compare.h"
#include "spherecull/sc_scene.h"

#define CMD "compare"

extern char **environ;

static void usage(FILE *out)
{
    int n;
    const char *const *names = sc_cmp_tracer_names(&n);
    fprintf(out,
            "usage: spherecull compare SCENE... [--rays LIST] [--tracers LIST] [--threads LIST]\n"
            "         [--csv FILE] [--json FILE] [--plot DIR] [--oracle-rays N] [--repeats N]\n"
            "         [--width W] [--count N] [--seed S]\n\n"
            "Traces the same seeded ray sets with every tracer, checks a sample of each set\n"
            "against an exact (MPFR) oracle and prints speed, disagreements and prefilter work.\n\n"
            "  SCENE           a mesh file, scene .json, proc:KIND:N or cache:NAME (see sc_scene.h)\n"
            "  --rays LIST     comma list of primary,shadow,diffuse,random,adversarial (default all)\n"
            "  --tracers LIST  comma list of tracer names (default all of this build)\n"
            "  --threads LIST  thread counts to time, e.g. 1,2 (default 1,2)\n"
            "  --oracle-rays N rays per set checked by the oracle (default 10000; 0 = none)\n"
            "  --repeats N     timed runs per row, the median is reported (default 5)\n"
            "  --width W       primary image width; height keeps the camera's aspect (default 512)\n"
            "  --count N       random and adversarial rays per set (default 65536)\n"
            "  --seed S        ray seed (default 1)\n"
            "  --csv/--json    write all rows; --plot DIR writes gnuplot PNGs there\n\n"
            "tracers in this build:");
    for (int i = 0; i < n; i++)
        fprintf(out, " %s", names[i]);
    fprintf(out, "\n");
}

static int parse_size(const char *s, size_t *out)
{
    char *end;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || *end || end == s || s[0] == '-')
        return -1;
    *out = (size_t)v;
    return 0;
}

/* Splits a comma list in place into at most max items. */
static int split(char *s, const char **items, int max)
{
    int n = 0;
    for (char *tok = strtok(s, ","); tok; tok = strtok(NULL, ",")) {
        if (n == max)
            return -1;
        items[n++] = tok;
    }
    return n;
}

static int write_csv_cb(void *ctx, FILE *f)
{
    return sc_cmp_write_csv(ctx, f);
}

static int write_json_cb(void *ctx, FILE *f)
{
    return sc_cmp_write_json(ctx, f);
}

/* A point light for shadow rays: the scene's first point light, else a
 * point far along its first directional light, else above the box. */
static void pick_light(const sc_scene_view *v, const float lo[3], const float hi[3], float light[3])
{
    double c[3], diag = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5 * ((double)lo[k] + hi[k]);
        diag += ((double)hi[k] - lo[k]) * ((double)hi[k] - lo[k]);
    }
    diag = sqrt(diag);
    for (size_t i = 0; i < v->num_lights; i++)
        if (v->lights[i].type == SC_LIGHT_POINT) {
            memcpy(light, v->lights[i].vec, 3 * sizeof(float));
            return;
        }
    for (size_t i = 0; i < v->num_lights; i++)
        if (v->lights[i].type == SC_LIGHT_DIRECTIONAL) {
            for (int k = 0; k < 3; k++)
                light[k] = (float)(c[k] - 2 * diag * v->lights[i].vec[k]);
            return;
        }
    const double d[3] = { 0.3, 1.0, 0.2 };
    for (int k = 0; k < 3; k++)
        light[k] = (float)(c[k] + 2 * diag * d[k]);
}

static int run_gnuplot(const char *script)
{
    pid_t pid;
    char *argv[] = { "gnuplot", (char *)script, NULL };
    if (posix_spawnp(&pid, "gnuplot", NULL, NULL, argv, environ) != 0)
        return -1;
    int status;
    if (waitpid(pid, &status, 0) < 0)
        return -1;
    return WIFEXITED(status) && WEXITSTATUS(status) == 0 ? 0 : -1;
}

static int contains(const char **list, int n, const char *s)
{
    for (int i = 0; i < n; i++)
        if (strcmp(list[i], s) == 0)
            return 1;
    return 0;
}

/* One histogram per ray set (Mrays/s per scene per tracer, fewest threads)
 * and one scatter of speed against the oracle disagreement rate. */
static int write_plots(const sc_cmp_rows *rows, const char *dir)
{
    if (mkdir(dir, 0777) != 0 && errno != EEXIST)
        return -1;
    if (rows->count == 0)
        return 0;
    int thr = rows->rows[0].threads;
    for (size_t i = 0; i < rows->count; i++)
        if (rows->rows[i].threads < thr)
            thr = rows->rows[i].threads;
    const char *scenes[256], *tracers[64];
    int ns = 0, nt = 0;
    for (size_t i = 0; i < rows->count; i++) {
        if (!contains(scenes, ns, rows->rows[i].scene) && ns < 256)
            scenes[ns++] = rows->rows[i].scene;
        if (!contains(tracers, nt, rows->rows[i].tracer) && nt < 64)
            tracers[nt++] = rows->rows[i].tracer;
    }
    char path[4096];
    int rc = 0;
    for (int k = 0; k < SC_RAYS_KIND_COUNT; k++) {
        int any = 0;
        for (size_t i = 0; i < rows->count; i++)
            any |= rows->rows[i].rays == (sc_rayset_kind)k;
        if (!any)
            continue;
        const char *kn = sc_rayset_kind_name((sc_rayset_kind)k);
        /* only tracers with a value here: gnuplot stops on an empty column
         * (the packet tracers have no shadow rows) */
        const char *cols[64];
        int nc = 0;
        for (int t = 0; t < nt; t++)
            for (size_t i = 0; i < rows->count; i++)
                if (rows->rows[i].rays == (sc_rayset_kind)k && rows->rows[i].threads == thr &&
                    strcmp(rows->rows[i].tracer, tracers[t]) == 0) {
                    cols[nc++] = tracers[t];
                    break;
                }
        snprintf(path, sizeof path, "%s/speed_%s.dat", dir, kn);
        FILE *f = fopen(path, "w");
        if (!f)
            return -1;
        fprintf(f, "scene");
        for (int t = 0; t < nc; t++)
            fprintf(f, " \"%s\"", cols[t]);
        fprintf(f, "\n");
        for (int s = 0; s < ns; s++) {
            fprintf(f, "\"%s\"", scenes[s]);
            for (int t = 0; t < nc; t++) {
                double v = NAN;
                for (size_t i = 0; i < rows->count; i++) {
                    const sc_cmp_row *r = &rows->rows[i];
                    if (r->rays == (sc_rayset_kind)k && r->threads == thr && strcmp(r->scene, scenes[s]) == 0 &&
                        strcmp(r->tracer, cols[t]) == 0)
                        v = r->mrays_per_s;
                }
                if (isnan(v))
                    fprintf(f, " NaN");
                else
                    fprintf(f, " %.4f", v);
            }
            fprintf(f, "\n");
        }
        fclose(f);
        snprintf(path, sizeof path, "%s/speed_%s.gp", dir, kn);
        f = fopen(path, "w");
        if (!f)
            return -1;
        fprintf(f,
                "set terminal pngcairo size 1400,700 noenhanced\n"
                "set output '%s/speed_%s.png'\n"
                "set title 'Mrays/s, %s rays, %d thread(s) (median of repeats)'\n"
                "set style data histograms\nset style histogram clustered gap 1\n"
                "set style fill solid 0.8 border -1\nset boxwidth 0.9\n"
                "set key outside right top vertical\nset xtics rotate by -30\nset grid ytics\n"
                "set ylabel 'Mrays/s'\nset yrange [0:*]\n"
                "plot for [i=2:%d] '%s/speed_%s.dat' using i:xtic(1) title columnhead(i)\n",
                dir, kn, kn, thr, nc + 1, dir, kn);
        fclose(f);
        if (run_gnuplot(path) != 0)
            rc = -1;
    }
    /* speed against error: one point per scene x ray set, one series per tracer */
    snprintf(path, sizeof path, "%s/speed_vs_error.dat", dir);
    FILE *f = fopen(path, "w");
    if (!f)
        return -1;
    for (int t = 0; t < nt; t++) {
        fprintf(f, "# %s\n", tracers[t]);
        for (size_t i = 0; i < rows->count; i++) {
            const sc_cmp_row *r = &rows->rows[i];
            if (r->threads != thr || strcmp(r->tracer, tracers[t]) != 0 || r->oracle_rays == 0)
                continue;
            double rate = (double)(r->hit_miss_disagree + r->primid_disagree) / (double)r->oracle_rays;
            /* zero disagreement is drawn on the floor of the log axis */
            fprintf(f, "%.6e %.4f\n", rate > 1e-5 ? rate : 1e-5, r->mrays_per_s);
        }
        fprintf(f, "\n\n");
    }
    fclose(f);
    snprintf(path, sizeof path, "%s/speed_vs_error.gp", dir);
    f = fopen(path, "w");
    if (!f)
        return -1;
    fprintf(f,
            "set terminal pngcairo size 1100,700 noenhanced\n"
            "set output '%s/speed_vs_error.png'\n"
            "set title 'Speed against error: every scene x ray set, %d thread(s); 1e-5 = no disagreement'\n"
            "set logscale x\nset xrange [5e-6:1]\nset grid\n"
            "set xlabel '(hit/miss + primID disagreements) / oracle rays'\nset ylabel 'Mrays/s'\n"
            "set key outside right top vertical\nplot ",
            dir, thr);
    for (int t = 0; t < nt; t++)
        fprintf(f, "%s'%s/speed_vs_error.dat' index %d using 1:2 with points pt %d ps 1.5 title '%s'",
                t ? ", \\\n     " : "", dir, t, t % 13 + 1, tracers[t]);
    fprintf(f, "\n");
    fclose(f);
    if (run_gnuplot(path) != 0)
        rc = -1;
    return rc;
}

int sc_cmd_compare(int argc, char **argv)
{
    sc_cmp_options opt;
    sc_cmp_options_default(&opt);
    const char *csv = NULL, *json = NULL, *plot = NULL;
    const char *scenes[256];
    int nscenes = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int more = i + 1 < argc;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            return 0;
        } else if (strcmp(a, "--rays") == 0 && more) {
            const char *items[SC_RAYS_KIND_COUNT + 1];
            int n = split(argv[++i], items, SC_RAYS_KIND_COUNT);
            opt.ray_kinds = 0;
            for (int k = 0; k < n; k++) {
                sc_rayset_kind kind;
                if (sc_rayset_kind_from_name(items[k], &kind) != SC_OK) {
                    sc_cli_error(CMD, "unknown ray set '%s' (primary, shadow, diffuse, random, adversarial)",
                                 items[k]);
                    return 2;
                }
                opt.ray_kinds |= 1u << kind;
            }
            if (n <= 0) {
                sc_cli_error(CMD, "--rays needs a comma list of ray sets");
                return 2;
            }
        } else if (strcmp(a, "--tracers") == 0 && more) {
            int n = split(argv[++i], opt.tracers, SC_CMP_MAX_TRACERS);
            int known;
            const char *const *names = sc_cmp_tracer_names(&known);
            for (int k = 0; k < n; k++)
                if (!contains((const char **)names, known, opt.tracers[k])) {
                    sc_cli_error(CMD, "tracer '%s' is not in this build (see 'spherecull compare --help')",
                                 opt.tracers[k]);
                    return 2;
                }
            if (n <= 0) {
                sc_cli_error(CMD, "--tracers needs a comma list of tracer names");
                return 2;
            }
            opt.ntracers = n;
        } else if (strcmp(a, "--threads") == 0 && more) {
            const char *items[SC_CMP_MAX_THREADS + 1];
            int n = split(argv[++i], items, SC_CMP_MAX_THREADS);
            for (int k = 0; k < n; k++) {
                size_t v;
                if (parse_size(items[k], &v) != 0 || v < 1 || v > SC_CMP_MAX_THREADS) {
                    sc_cli_error(CMD, "--threads: '%s' is not a thread count in 1..%d", items[k],
                                 SC_CMP_MAX_THREADS);
                    return 2;
                }
                opt.threads[k] = (int)v;
            }
            if (n <= 0) {
                sc_cli_error(CMD, "--threads needs a comma list such as 1,2 (at most %d entries)",
                             SC_CMP_MAX_THREADS);
                return 2;
            }
            opt.nthreads = n;
        } else if ((strcmp(a, "--oracle-rays") == 0 || strcmp(a, "--repeats") == 0 ||
                    strcmp(a, "--width") == 0 || strcmp(a, "--count") == 0 || strcmp(a, "--seed") == 0) &&
                   more) {
            size_t v;
            if (parse_size(argv[++i], &v) != 0) {
                sc_cli_error(CMD, "%s: '%s' is not a non-negative integer", a, argv[i]);
                return 2;
            }
            if (strcmp(a, "--oracle-rays") == 0) {
                opt.oracle_rays = v;
            } else if (strcmp(a, "--repeats") == 0) {
                if (v < 1 || v > 64) {
                    sc_cli_error(CMD, "--repeats must be in 1..64");
                    return 2;
                }
                opt.repeats = (int)v;
            } else if (strcmp(a, "--width") == 0) {
                if (v < 1 || v > 8192) {
                    sc_cli_error(CMD, "--width must be in 1..8192");
                    return 2;
                }
                opt.width = (int)v;
            } else if (strcmp(a, "--count") == 0) {
                if (v < 1 || v > 100000000) {
                    sc_cli_error(CMD, "--count must be in 1..100000000");
                    return 2;
                }
                opt.random_rays = opt.adversarial_rays = v;
            } else {
                opt.seed = v;
            }
        } else if (strcmp(a, "--csv") == 0 && more) {
            csv = argv[++i];
        } else if (strcmp(a, "--json") == 0 && more) {
            json = argv[++i];
        } else if (strcmp(a, "--plot") == 0 && more) {
            plot = argv[++i];
        } else if (a[0] == '-' && a[1] == '-') {
            sc_cli_error(CMD, "unknown or incomplete option '%s' (try --help)", a);
            return 2;
        } else if (nscenes < 256) {
            scenes[nscenes++] = a;
        } else {
            sc_cli_error(CMD, "at most 256 scenes per run");
            return 2;
        }
    }
    if (nscenes == 0) {
        sc_cli_error(CMD, "no scene given (try --help)");
        return 2;
    }

    if (sc_cli_check_output(CMD, "--csv", csv) != 0 || sc_cli_check_output(CMD, "--json", json) != 0)
        return 1;
    sc_cmp_rows rows = { 0 };
    int rc = 0;
    for (int s = 0; s < nscenes && rc == 0; s++) {
        char err[512];
        sc_scene *scene = NULL;
        sc_status st = sc_scene_load(scenes[s], NULL, &scene, err, sizeof err);
        if (st != SC_OK) {
            sc_cli_error(CMD, "%s", err[0] ? err : sc_strerror(st));
            rc = 1;
            break;
        }
        sc_scene_view v;
        sc_scene_get_view(scene, &v);
        if (v.num_triangles == 0 || v.num_triangles > UINT32_MAX || v.num_vertices > UINT32_MAX) {
            sc_cli_error(CMD, "%s: %zu triangles: nothing to compare, or too many", scenes[s], v.num_triangles);
            sc_scene_free(scene);
            rc = 1;
            break;
        }
        sc_mesh_view mesh = { v.positions, (uint32_t)v.num_vertices, v.indices, (uint32_t)v.num_triangles };
        float lo[3], hi[3], light[3];
        sc_mesh_bounds(&mesh, lo, hi);
        pick_light(&v, lo, hi, light);
        const char *base = strrchr(scenes[s], '/');
        base = base ? base + 1 : scenes[s];
        fprintf(stderr, "%s: %zu triangles\n", base, v.num_triangles);
        st = sc_cmp_scene(base, &mesh, &v.camera, light, &opt, &rows, stderr, err, sizeof err);
        sc_scene_free(scene);
        if (st != SC_OK) {
            sc_cli_error(CMD, "%s", err[0] ? err : sc_strerror(st));
            rc = 1;
        }
    }
    if (rc == 0) {
        sc_cmp_print_table(&rows, stdout);
        printf("\nh/m = hit/miss disagreements with the exact oracle, prim = primID outside the tie set,\n"
               "holes = vertex/edge-aimed rays that pass through the surface (exact transversal crossing) where the tracer\n"
               "does not stop, grazes = rays whose first exact hit only touches the surface (tangent) and that the tracer\n"
               "does not report (adversarial rows), xEmbree = speed / "
               "embree (rtcIntersect1/rtcOccluded1) at the same threads;\nsph/ray, rej%%, fp%% (sphere passed, "
               "triangle missed, of the passes) and tri/ray are counted by the prefilter tracers.\n");
    }
    if (rc == 0 && csv && sc_cli_write_atomic(csv, write_csv_cb, &rows) != 0) {
        sc_cli_error(CMD, "cannot write %s: %s", csv, strerror(errno));
        rc = 1;
    }
    if (rc == 0 && json && sc_cli_write_atomic(json, write_json_cb, &rows) != 0) {
        sc_cli_error(CMD, "cannot write %s: %s", json, strerror(errno));
        rc = 1;
    }
    if (rc == 0 && plot && write_plots(&rows, plot) != 0) {
        sc_cli_error(CMD, "cannot write the plots into %s (is gnuplot installed?)", plot);
        rc = 1;
    }
    sc_cmp_rows_free(&rows);
    return rc;
}

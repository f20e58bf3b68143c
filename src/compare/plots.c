/* The comparison's gnuplot pictures (see compare.h). Data, script and
 * picture each go through an atomic write; the scripts are kept beside the
 * pictures so a plot can be restyled by hand. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/sc_atomic_file.h"
#include "common/sc_gnuplot.h"
#include "compare.h"

static int contains(const char **list, int n, const char *s)
{
    for (int i = 0; i < n; i++)
        if (strcmp(list[i], s) == 0)
            return 1;
    return 0;
}

/* Writes NAME.dat and NAME.gp (closed memstreams) into DIR and runs the
 * script into NAME.png. */
static int emit(const char *dir, const char *name, const char *dat, size_t dlen, const char *gp, size_t glen)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s.dat", dir, name);
    if (sc_write_atomic_bytes(path, dat, dlen) != 0)
        return -1;
    snprintf(path, sizeof path, "%s/%s.gp", dir, name);
    if (sc_write_atomic_bytes(path, gp, glen) != 0)
        return -1;
    snprintf(path, sizeof path, "%s/%s.png", dir, name);
    return sc_write_atomic(path, sc_gnuplot_write, (void *)gp);
}

typedef struct text {
    char *s;
    size_t len;
    FILE *f;
} text;

static int text_open(text *t)
{
    t->s = NULL, t->len = 0;
    t->f = open_memstream(&t->s, &t->len);
    return t->f ? 0 : -1;
}

static int text_close(text *t)
{
    return fclose(t->f) == 0 && t->s ? 0 : -1;
}

/* A data file and its script, both in memory until written. */
static int texts_open(text *d, text *g)
{
    if (text_open(d) != 0)
        return -1;
    if (text_open(g) != 0) {
        text_close(d), free(d->s);
        return -1;
    }
    return 0;
}

/* Mrays/s per scene per tracer for one ray set, at thread count thr. */
static int speed_plot(const sc_cmp_rows *rows, const char *dir, int k, int thr, const char **scenes, int ns,
                      const char **tracers, int nt)
{
    const char *kn = sc_rayset_kind_name((sc_rayset_kind)k);
    /* only tracers with a value here: gnuplot stops on an empty column (the
     * packet tracers have no shadow rows) */
    const char *cols[64];
    int nc = 0;
    for (int t = 0; t < nt; t++)
        for (size_t i = 0; i < rows->count; i++)
            if (rows->rows[i].rays == (sc_rayset_kind)k && rows->rows[i].threads == thr &&
                strcmp(rows->rows[i].tracer, tracers[t]) == 0) {
                cols[nc++] = tracers[t];
                break;
            }
    text d, g;
    if (texts_open(&d, &g) != 0)
        return -1;
    fprintf(d.f, "scene");
    for (int t = 0; t < nc; t++)
        fprintf(d.f, " \"%s\"", cols[t]);
    fprintf(d.f, "\n");
    for (int s = 0; s < ns; s++) {
        fprintf(d.f, "\"%s\"", scenes[s]);
        for (int t = 0; t < nc; t++) {
            double v = NAN;
            for (size_t i = 0; i < rows->count; i++) {
                const sc_cmp_row *r = &rows->rows[i];
                if (r->rays == (sc_rayset_kind)k && r->threads == thr && strcmp(r->scene, scenes[s]) == 0 &&
                    strcmp(r->tracer, cols[t]) == 0)
                    v = r->mrays_per_s;
            }
            if (isnan(v))
                fprintf(d.f, " NaN");
            else
                fprintf(d.f, " %.4f", v);
        }
        fprintf(d.f, "\n");
    }
    fprintf(g.f,
            "# gnuplot speed_%s.gp > speed_%s.png\n"
            "set terminal pngcairo size 1400,700 noenhanced\n"
            "set title 'Mrays/s, %s rays, %d thread(s) (median of repeats)'\n"
            "set style data histograms\nset style histogram clustered gap 1\n"
            "set style fill solid 0.8 border -1\nset boxwidth 0.9\n"
            "set key outside right top vertical\nset xtics rotate by -30\nset grid ytics\n"
            "set ylabel 'Mrays/s'\nset yrange [0:*]\n"
            "plot for [i=2:%d] '%s/speed_%s.dat' using i:xtic(1) title columnhead(i)\n",
            kn, kn, kn, thr, nc + 1, dir, kn);
    char name[64];
    snprintf(name, sizeof name, "speed_%s", kn);
    int rc = text_close(&d) == 0 && text_close(&g) == 0 ? emit(dir, name, d.s, d.len, g.s, g.len) : -1;
    free(d.s), free(g.s);
    return rc;
}

/* Speed against error: one point per scene x ray set, one series per tracer. */
static int error_plot(const sc_cmp_rows *rows, const char *dir, int thr, const char **tracers, int nt)
{
    text d, g;
    if (texts_open(&d, &g) != 0)
        return -1;
    for (int t = 0; t < nt; t++) {
        fprintf(d.f, "# %s\n", tracers[t]);
        for (size_t i = 0; i < rows->count; i++) {
            const sc_cmp_row *r = &rows->rows[i];
            if (r->threads != thr || strcmp(r->tracer, tracers[t]) != 0 || r->oracle_rays == 0)
                continue;
            double rate = (double)(r->hit_miss_disagree + r->primid_disagree) / (double)r->oracle_rays;
            /* zero disagreement is drawn on the floor of the log axis */
            fprintf(d.f, "%.6e %.4f\n", rate > 1e-5 ? rate : 1e-5, r->mrays_per_s);
        }
        fprintf(d.f, "\n\n");
    }
    fprintf(g.f,
            "# gnuplot speed_vs_error.gp > speed_vs_error.png\n"
            "set terminal pngcairo size 1100,700 noenhanced\n"
            "set title 'Speed against error: every scene x ray set, %d thread(s); 1e-5 = no disagreement'\n"
            "set logscale x\nset xrange [5e-6:1]\nset grid\n"
            "set xlabel '(hit/miss + primID disagreements) / oracle rays'\nset ylabel 'Mrays/s'\n"
            "set key outside right top vertical\nplot ",
            thr);
    for (int t = 0; t < nt; t++)
        fprintf(g.f, "%s'%s/speed_vs_error.dat' index %d using 1:2 with points pt %d ps 1.5 title '%s'",
                t ? ", \\\n     " : "", dir, t, t % 13 + 1, tracers[t]);
    fprintf(g.f, "\n");
    int rc = text_close(&d) == 0 && text_close(&g) == 0 ? emit(dir, "speed_vs_error", d.s, d.len, g.s, g.len) : -1;
    free(d.s), free(g.s);
    return rc;
}

int sc_cmp_write_plots(const sc_cmp_rows *rows, const char *dir)
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
    int rc = 0;
    for (int k = 0; k < SC_RAYS_KIND_COUNT; k++) {
        int any = 0;
        for (size_t i = 0; i < rows->count; i++)
            any |= rows->rows[i].rays == (sc_rayset_kind)k;
        if (any && speed_plot(rows, dir, k, thr, scenes, ns, tracers, nt) != 0)
            rc = -1;
    }
    if (error_plot(rows, dir, thr, tracers, nt) != 0)
        rc = -1;
    return rc;
}

/* The render's tile hook over MPI (sc_mpi.h). */
#include <limits.h>
#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>

#include <mpi.h>

#include "common/sc_clock.h"

#include "mpi_internal.h"
#include "sc_mpi.h"

struct sc_mpi_tiles {
    sc_mpi *m;
    MPI_Win win;
    int *counter;              /* the window's memory: one int on rank 0, none elsewhere */
    pthread_mutex_t lock;      /* MPI_THREAD_SERIALIZED: one render thread in MPI at a time */
    double combine_seconds;    /* the last combine's reductions */
    uint64_t *rank_rays;       /* rank 0: rays each rank traced (size entries) */
};

/* The next tile: fetch-and-add on rank 0's counter. Ranks that ask more
 * often (the faster ones) get more tiles. */
static int next_tile(void *ctx)
{
    sc_mpi_tiles *t = ctx;
    const int one = 1;
    int got = -1;
    pthread_mutex_lock(&t->lock);
    if (MPI_Fetch_and_op(&one, &got, MPI_INT, 0, 0, MPI_SUM, t->win) != MPI_SUCCESS ||
        MPI_Win_flush(0, t->win) != MPI_SUCCESS)
        got = -1;
    pthread_mutex_unlock(&t->lock);
    return got;
}

/* MPI_Reduce in place on rank 0, in pieces that fit an int count. */
static int reduce_sum(const sc_mpi *m, void *buf, size_t n, MPI_Datatype type, size_t size)
{
    for (size_t done = 0; done < n;) {
        size_t k = n - done < (size_t)INT_MAX / 2 ? n - done : (size_t)INT_MAX / 2;
        char *p = (char *)buf + done * size;
        int rc = m->rank == 0 ? MPI_Reduce(MPI_IN_PLACE, p, (int)k, type, MPI_SUM, 0, MPI_COMM_WORLD)
                              : MPI_Reduce(p, NULL, (int)k, type, MPI_SUM, 0, MPI_COMM_WORLD);
        if (rc != MPI_SUCCESS)
            return -1;
        done += k;
    }
    return 0;
}

static sc_status combine(void *ctx, sc_status local, float *color, float *value, size_t pixels,
                         sc_render_stats *stats)
{
    sc_mpi_tiles *t = ctx;
    sc_status st = sc_mpi_agree(t->m, local, NULL);
    if (st != SC_OK)
        return st;
    /* every rank succeeded, so every rank has its buffers */
    const double t0 = sc_now_seconds();
    uint64_t mine = stats->primary_rays + stats->shadow_rays + stats->ao_rays + stats->bounce_rays;
    if (MPI_Gather(&mine, 1, MPI_UINT64_T, t->rank_rays, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD) != MPI_SUCCESS)
        return SC_ERR_IO;
    uint64_t c[11] = { stats->primary_rays, stats->shadow_rays, stats->ao_rays, stats->bounce_rays,
                       stats->trace.rays, stats->trace.nodes, stats->trace.leaves, stats->trace.sphere_tests,
                       stats->trace.sphere_rejects, stats->trace.tri_tests, stats->trace.tri_hits };
    if (reduce_sum(t->m, color, 3 * pixels, MPI_FLOAT, sizeof(float)) != 0 ||
        reduce_sum(t->m, value, pixels, MPI_FLOAT, sizeof(float)) != 0 ||
        reduce_sum(t->m, c, 11, MPI_UINT64_T, sizeof(uint64_t)) != 0)
        return SC_ERR_IO;
    stats->primary_rays = c[0], stats->shadow_rays = c[1], stats->ao_rays = c[2], stats->bounce_rays = c[3];
    stats->trace.rays = c[4], stats->trace.nodes = c[5], stats->trace.leaves = c[6];
    stats->trace.sphere_tests = c[7], stats->trace.sphere_rejects = c[8];
    stats->trace.tri_tests = c[9], stats->trace.tri_hits = c[10];
    t->combine_seconds = sc_now_seconds() - t0;
    return SC_OK;
}

sc_status sc_mpi_tiles_new(sc_mpi *m, sc_mpi_tiles **out, sc_render_tiles *hook)
{
    *out = NULL;
    sc_mpi_tiles *t = calloc(1, sizeof *t);
    if (t && m->rank == 0 && !(t->rank_rays = calloc((size_t)m->size, sizeof *t->rank_rays))) {
        free(t);
        t = NULL;
    }
    /* the allocation is agreed first: window creation is collective */
    sc_status st = sc_mpi_agree(m, t ? SC_OK : SC_ERR_OUT_OF_MEMORY, NULL);
    if (st != SC_OK) {
        if (t)
            free(t->rank_rays);
        free(t);
        return st;
    }
    t->m = m;
    pthread_mutex_init(&t->lock, NULL);
    if (MPI_Win_allocate(m->rank == 0 ? (MPI_Aint)sizeof(int) : 0, sizeof(int), MPI_INFO_NULL, MPI_COMM_WORLD,
                         &t->counter, &t->win) != MPI_SUCCESS) {
        pthread_mutex_destroy(&t->lock);
        free(t->rank_rays);
        free(t);
        return SC_ERR_IO;
    }
    if (m->rank == 0)
        *t->counter = 0;
    /* the counter is 0 before any rank takes a tile */
    MPI_Barrier(MPI_COMM_WORLD);
    MPI_Win_lock_all(MPI_MODE_NOCHECK, t->win);
    hook->next = next_tile;
    hook->combine = combine;
    hook->ctx = t;
    *out = t;
    return SC_OK;
}

void sc_mpi_tiles_free(sc_mpi_tiles *t)
{
    if (!t)
        return;
    MPI_Win_unlock_all(t->win);
    MPI_Win_free(&t->win);
    pthread_mutex_destroy(&t->lock);
    free(t->rank_rays);
    free(t);
}

double sc_mpi_tiles_combine_seconds(const sc_mpi_tiles *t) { return t->combine_seconds; }
const uint64_t *sc_mpi_tiles_rank_rays(const sc_mpi_tiles *t) { return t->rank_rays; }

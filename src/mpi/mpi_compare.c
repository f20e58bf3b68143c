/* compare and bench over MPI (sc_mpi.h): the node-local timing lock and
 * the gather of the ranks' records in the single process's order. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <unistd.h>

#include <mpi.h>

#include "mpi_internal.h"
#include "sc_mpi.h"

struct sc_mpi_node_lock {
    MPI_Comm node;             /* the ranks sharing this node's memory */
    int node_rank;
    int fd;
    char path[256];
};

/* flock without EINTR surprises */
static void lock_fd(int fd, int op)
{
    while (flock(fd, op) != 0 && errno == EINTR)
        ;
}

sc_status sc_mpi_node_lock_new(sc_mpi *m, sc_mpi_node_lock **out)
{
    *out = NULL;
    sc_mpi_node_lock *l = calloc(1, sizeof *l);
    sc_status st = sc_mpi_agree(m, l ? SC_OK : SC_ERR_OUT_OF_MEMORY, NULL);
    if (st != SC_OK) {
        free(l);
        return st;
    }
    l->fd = -1;
    MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, m->rank, MPI_INFO_NULL, &l->node);
    MPI_Comm_rank(l->node, &l->node_rank);
    /* the node's first rank names the lock file; a node-local directory
     * (/dev/shm, else /tmp) makes it one lock per node */
    if (l->node_rank == 0) {
        const char *dir = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
        snprintf(l->path, sizeof l->path, "%s/spherecull-timing.XXXXXX", dir);
        int fd = mkstemp(l->path);
        if (fd >= 0)
            close(fd);
        else
            l->path[0] = 0;
    }
    MPI_Bcast(l->path, (int)sizeof l->path, MPI_CHAR, 0, l->node);
    if (l->path[0])
        l->fd = open(l->path, O_RDWR | O_CLOEXEC);
    st = sc_mpi_agree(m, l->fd >= 0 ? SC_OK : SC_ERR_IO, NULL);
    if (st != SC_OK) {
        sc_mpi_node_lock_free(l);
        return st;
    }
    /* untimed work holds the lock shared; see sc_mpi_node_lock_timing */
    lock_fd(l->fd, LOCK_SH);
    *out = l;
    return SC_OK;
}

void sc_mpi_node_lock_timing(void *ctx, int begin)
{
    sc_mpi_node_lock *l = ctx;
    /* shared -> exclusive is not atomic: let go first, so that two ranks
     * that both want to time cannot wait on each other */
    lock_fd(l->fd, LOCK_UN);
    lock_fd(l->fd, begin ? LOCK_EX : LOCK_SH);
}

void sc_mpi_node_lock_free(sc_mpi_node_lock *l)
{
    if (!l)
        return;
    if (l->fd >= 0) {
        lock_fd(l->fd, LOCK_UN);
        close(l->fd);
    }
    MPI_Barrier(l->node);
    if (l->node_rank == 0 && l->path[0])
        unlink(l->path);
    MPI_Comm_free(&l->node);
    free(l);
}

typedef struct {
    int item, rank, index;
} rec_key;

static int key_cmp(const void *a, const void *b)
{
    const rec_key *x = a, *y = b;
    if (x->item != y->item)
        return x->item < y->item ? -1 : 1;
    if (x->rank != y->rank)
        return x->rank < y->rank ? -1 : 1;
    return (x->index > y->index) - (x->index < y->index);
}

sc_status sc_mpi_gather_items(sc_mpi *m, const void *recs, size_t n, size_t size, const int *items, void **all,
                              size_t *all_n)
{
    if (size == 0 || n > (size_t)INT_MAX / size)
        return sc_mpi_agree(m, SC_ERR_LIMIT, NULL);
    int cnt = (int)n;
    int *counts = NULL, *displs = NULL, *bcounts = NULL, *bdispls = NULL, total = 0;
    char *bytes = NULL;
    int *ritems = NULL;
    sc_status st = SC_OK;
    if (m->rank == 0) {
        counts = calloc((size_t)m->size, sizeof *counts);
        displs = calloc((size_t)m->size, sizeof *displs);
        bcounts = calloc((size_t)m->size, sizeof *bcounts);
        bdispls = calloc((size_t)m->size, sizeof *bdispls);
        if (!counts || !displs || !bcounts || !bdispls)
            st = SC_ERR_OUT_OF_MEMORY;
    }
    if ((st = sc_mpi_agree(m, st, NULL)) != SC_OK)
        goto out;
    MPI_Gather(&cnt, 1, MPI_INT, counts, 1, MPI_INT, 0, MPI_COMM_WORLD);
    if (m->rank == 0) {
        size_t sum = 0;
        for (int r = 0; r < m->size; r++)
            sum += (size_t)counts[r];
        if (sum > (size_t)INT_MAX / size) {
            st = SC_ERR_LIMIT;
        } else {
            for (int r = 0; r < m->size; r++) {
                displs[r] = total;
                bdispls[r] = total * (int)size;
                bcounts[r] = counts[r] * (int)size;
                total += counts[r];
            }
            bytes = malloc(((size_t)total + 1) * size);
            ritems = malloc(((size_t)total + 1) * sizeof *ritems);
            if (!bytes || !ritems)
                st = SC_ERR_OUT_OF_MEMORY;
        }
    }
    if ((st = sc_mpi_agree(m, st, NULL)) != SC_OK)
        goto out;
    /* the same binary on every rank (replicated data): records travel as bytes */
    MPI_Gatherv(recs, cnt * (int)size, MPI_BYTE, bytes, bcounts, bdispls, MPI_BYTE, 0, MPI_COMM_WORLD);
    MPI_Gatherv(items, cnt, MPI_INT, ritems, counts, displs, MPI_INT, 0, MPI_COMM_WORLD);
    if (m->rank == 0) {
        rec_key *keys = malloc(((size_t)total + 1) * sizeof *keys);
        char *sorted = malloc(((size_t)total + 1) * size);
        if (!keys || !sorted) {
            free(keys);
            free(sorted);
            st = SC_ERR_OUT_OF_MEMORY;
            goto out;
        }
        for (int r = 0, i = 0; r < m->size; r++)
            for (int j = 0; j < counts[r]; j++, i++)
                keys[i] = (rec_key){ ritems[i], r, i };
        /* the single process's order: by work item, each item's records as made */
        qsort(keys, (size_t)total, sizeof *keys, key_cmp);
        for (int i = 0; i < total; i++)
            memcpy(sorted + (size_t)i * size, bytes + (size_t)keys[i].index * size, size);
        *all = sorted;
        *all_n = (size_t)total;
        free(keys);
    }
out:
    free(counts);
    free(displs);
    free(bcounts);
    free(bdispls);
    free(bytes);
    free(ritems);
    return st;
}

sc_status sc_mpi_gather_rows(sc_mpi *m, const sc_cmp_rows *mine, const int *items, sc_cmp_rows *all)
{
    void *rows = NULL;
    size_t n = 0;
    sc_status st = sc_mpi_gather_items(m, mine->rows, mine->count, sizeof(sc_cmp_row), items, &rows, &n);
    if (st == SC_OK && m->rank == 0) {
        all->rows = rows;
        all->count = all->cap = n;
    }
    return st;
}

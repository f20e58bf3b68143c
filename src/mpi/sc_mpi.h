/* The MPI driver of the spherecull command (Open MPI or any MPI-3): what
 * `mpirun -np N spherecull render` needs beyond one process. Private to the
 * CLI; the libraries never call MPI.
 *
 * Replicated data: every rank loads the scene and builds its own tree;
 * ranks share only work indices, statuses and the finished pixels.
 * Collectives: sc_mpi_agree and the tile hook's combine must be called by
 * every rank the same number of times and in the same order, so that a rank
 * that fails reports its failure in the next collective instead of leaving
 * the others waiting in it. */
#ifndef SPHERECULL_MPI_SC_MPI_H
#define SPHERECULL_MPI_SC_MPI_H

#include <stdint.h>

#include "compare/compare.h"
#include "spherecull/sc_render.h"
#include "spherecull/sc_status.h"

typedef struct sc_mpi sc_mpi;

/* MPI_Init_thread at MPI_THREAD_SERIALIZED (the render threads take turns
 * through a mutex). On error *out is NULL and err holds one line. */
sc_status sc_mpi_init(int *argc, char ***argv, sc_mpi **out, char *err, size_t errlen);
int sc_mpi_rank(const sc_mpi *m);
int sc_mpi_size(const sc_mpi *m);

/* Collective: every rank passes its own status; returns SC_OK if all
 * succeeded, else the status of the lowest failing rank, whose number goes
 * to *first_failed (-1 if none; may be NULL). */
sc_status sc_mpi_agree(sc_mpi *m, sc_status local, int *first_failed);

/* Finalises MPI and frees m (NULL is fine). */
void sc_mpi_finalize(sc_mpi *m);

/* The render's tile hook (sc_render_tiles): a tile counter in a window at
 * rank 0, taken by MPI_Fetch_and_op in one passive-target epoch, so that
 * faster ranks take more tiles and rank 0 needs no dispatcher loop; combine
 * agrees on the status and sums the accumulators and counters to rank 0
 * (MPI_Reduce; exact, as every pixel is nonzero on one rank only), where
 * the image is complete. Collective (window creation and freeing). */
typedef struct sc_mpi_tiles sc_mpi_tiles;
sc_status sc_mpi_tiles_new(sc_mpi *m, sc_mpi_tiles **out, sc_render_tiles *hook);
void sc_mpi_tiles_free(sc_mpi_tiles *t);
/* After a render: the seconds its combine took (gather and reductions),
 * and on rank 0 the rays each rank traced (sc_mpi_size entries; NULL on
 * other ranks), which show how the tiles were shared. */
double sc_mpi_tiles_combine_seconds(const sc_mpi_tiles *t);
const uint64_t *sc_mpi_tiles_rank_rays(const sc_mpi_tiles *t);


/* compare and bench: work items (scene x ray set; scene x leaf size x
 * prefilter mode) are dealt round-robin; every rank
 * times its own items, so ranks that share a node must not time at once,
 * nor time while another computes. The node lock (ranks of one node found
 * with MPI_Comm_split_type(MPI_COMM_TYPE_SHARED), an flock on a file in
 * /dev/shm named by the node's first rank) is held shared during untimed
 * work and exclusively for a timed block (sc_cmp_options.timing,
 * sc_bench_options.timing), so a
 * timed block runs alone on its node. Collective (new and free). */
typedef struct sc_mpi_node_lock sc_mpi_node_lock;
sc_status sc_mpi_node_lock_new(sc_mpi *m, sc_mpi_node_lock **out);
void sc_mpi_node_lock_timing(void *ctx, int begin);
void sc_mpi_node_lock_free(sc_mpi_node_lock *l);

/* Collective: every rank's n records of size bytes, each tagged with its
 * work item, to rank 0, in the order of a single process (by item, then
 * as made). On rank 0 *all (malloc'd, free it) and *all_n are set;
 * elsewhere they are untouched. sc_mpi_gather_rows: compare's rows
 * (free with sc_cmp_rows_free). */
sc_status sc_mpi_gather_items(sc_mpi *m, const void *recs, size_t n, size_t size, const int *items, void **all,
                              size_t *all_n);
sc_status sc_mpi_gather_rows(sc_mpi *m, const sc_cmp_rows *mine, const int *items, sc_cmp_rows *all);

#endif

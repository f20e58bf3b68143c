/* MPI start-up, status agreement and shutdown (sc_mpi.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mpi.h>

#include "sc_mpi.h"
#include "mpi_internal.h"

sc_status sc_mpi_init(int *argc, char ***argv, sc_mpi **out, char *err, size_t errlen)
{
    *out = NULL;
    int provided = 0;
    if (MPI_Init_thread(argc, argv, MPI_THREAD_SERIALIZED, &provided) != MPI_SUCCESS) {
        snprintf(err, errlen, "MPI_Init_thread failed");
        return SC_ERR_IO;
    }
    if (provided < MPI_THREAD_SERIALIZED) {
        snprintf(err, errlen, "this MPI does not allow calls from several threads in turn (MPI_THREAD_SERIALIZED)");
        MPI_Finalize();
        return SC_ERR_UNSUPPORTED;
    }
    sc_mpi *m = calloc(1, sizeof *m);
    if (!m) {
        MPI_Finalize();
        snprintf(err, errlen, "out of memory");
        return SC_ERR_OUT_OF_MEMORY;
    }
    MPI_Comm_rank(MPI_COMM_WORLD, &m->rank);
    MPI_Comm_size(MPI_COMM_WORLD, &m->size);
    *out = m;
    return SC_OK;
}

int sc_mpi_rank(const sc_mpi *m) { return m->rank; }
int sc_mpi_size(const sc_mpi *m) { return m->size; }

sc_status sc_mpi_agree(sc_mpi *m, sc_status local, int *first_failed)
{
    int mine = local == SC_OK ? m->size : m->rank, first = m->size;
    MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (first_failed)
        *first_failed = first < m->size ? first : -1;
    if (first >= m->size)
        return SC_OK;
    int code = (int)local;
    MPI_Bcast(&code, 1, MPI_INT, first, MPI_COMM_WORLD);
    return (sc_status)code;
}

void sc_mpi_finalize(sc_mpi *m)
{
    if (!m)
        return;
    MPI_Finalize();
    free(m);
}

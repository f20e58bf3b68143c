/* What the files of src/mpi share. */
#ifndef SPHERECULL_MPI_INTERNAL_H
#define SPHERECULL_MPI_INTERNAL_H

struct sc_mpi {
    int rank, size;
};

#endif

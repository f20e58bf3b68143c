/* Reinsertion optimisation of the binary SAH tree (the high build
 * quality): optimize_reinsertion.c. */
#ifndef SPHERECULL_BVH_OPTIMIZE_REINSERTION_H
#define SPHERECULL_BVH_OPTIMIZE_REINSERTION_H

#include <stddef.h>
#include <stdint.h>

#include "build_binned_sah.h"

typedef struct sc_reinsertion_params {
    int rounds;              /* at most this many rounds of moves */
    double batch_ratio;      /* of the nodes, the share with the largest boxes tried per round */
    int threads;             /* the searches of a round on up to this many threads (same tree) */
} sc_reinsertion_params;

/* Improves the tree below bn[root] in place (slots: the size of bn): the
 * same leaves, inner nodes rearranged, the binary depth kept below
 * SC_BVH_MAX_DEPTH. 0, or -1 when out of memory (the tree is then valid,
 * perhaps partly improved). */
int sc_reinsertion_optimize(sc_bnode *bn, uint32_t root, size_t slots, const sc_reinsertion_params *p);

#endif

/* The allocation of the big arrays (a BVH's nodes and leaves, the build's
 * boxes, ids and binary tree): 64-byte aligned, and from 2 MiB on aligned
 * to 2 MiB with the kernel asked for transparent huge pages. An incoherent
 * ray touches nodes and leaves all over the tree; with 4 KiB pages an 8M-
 * triangle tree (430 MB) spans 100,000 pages, far beyond the TLB, and
 * nearly every node load also walks the page table. With 2 MiB pages the
 * tree spans 215 and the walks go (docs/compare.md, twelfth session:
 * random rays 1.2-1.3x faster at 8M triangles). The build's first touch of
 * fresh memory takes one fault per 2 MiB instead of per 4 KiB. Embree asks
 * for the same on Linux (its `hugepages` device option, on by default).
 * Where the kernel has no transparent huge pages the advice is ignored.
 * The memory is zero-filled (from 2 MiB on, fresh mapped pages: no zeroing
 * pass, the first touch falls on the caller's writes). Free with
 * sc_free_large. */
#ifndef SPHERECULL_COMMON_SC_MEM_H
#define SPHERECULL_COMMON_SC_MEM_H

#include <stddef.h>

/* NULL when out of memory (bytes = 0 allocates a little). */
void *sc_alloc_large(size_t bytes);
void sc_free_large(void *p);   /* NULL: nothing */

#endif

/* Guard-page buffers for over-read / over-write tests: the usable bytes end
 * exactly where an inaccessible page begins, so a SIMD kernel touching even
 * one byte past the end faults (SIGSEGV) instead of passing silently. */
#ifndef SPHERECULL_TESTS_SC_GUARD_H
#define SPHERECULL_TESTS_SC_GUARD_H

#define _DEFAULT_SOURCE
#include <stddef.h>
#include <stdint.h>
#include <sys/mman.h>
#include <unistd.h>

typedef struct sc_guard {
    void *map;
    size_t map_len;
    void *ptr;            /* bytes [ptr, ptr + size) are usable */
} sc_guard;

/* size may be 0 (ptr then points right at the guard page). Returns NULL on failure. */
static inline void *sc_guard_alloc(sc_guard *g, size_t size)
{
    size_t page = (size_t)sysconf(_SC_PAGESIZE);
    size_t body = (size + page - 1) / page * page;
    g->map_len = body + page;
    g->map = mmap(NULL, g->map_len, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (g->map == MAP_FAILED) {
        g->map = NULL;
        return NULL;
    }
    if (mprotect((char *)g->map + body, page, PROT_NONE) != 0) {
        munmap(g->map, g->map_len);
        g->map = NULL;
        return NULL;
    }
    g->ptr = (char *)g->map + body - size;
    return g->ptr;
}

static inline void sc_guard_free(sc_guard *g)
{
    if (g->map)
        munmap(g->map, g->map_len);
    g->map = NULL;
}

#endif

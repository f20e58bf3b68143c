/* sc_alloc_large, sc_free_large (sc_mem.h). */
#define _DEFAULT_SOURCE   /* madvise, MADV_HUGEPAGE, MAP_ANONYMOUS */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#include "sc_mem.h"

#define SC_HUGE_PAGE ((size_t)2 << 20)

/* In the 64 bytes before every block: where its memory came from. */
typedef struct large_head {
    void *base;
    size_t mapped;   /* bytes mapped at base; 0: base is malloc's */
} large_head;

void *sc_alloc_large(size_t bytes)
{
    if (bytes > SIZE_MAX - 2 * SC_HUGE_PAGE)
        return NULL;                          /* no rounding up without overflow */
    if (bytes >= SC_HUGE_PAGE) {
        /* Mapped: fresh anonymous pages are zero, so the caller's first
         * writes are the first touch (no zeroing pass, and the page faults
         * fall where the writes are, on the threads that make them). */
        const size_t n = (bytes + SC_HUGE_PAGE - 1) & ~(SC_HUGE_PAGE - 1);
        const size_t mapped = n + SC_HUGE_PAGE;
        unsigned char *base = mmap(NULL, mapped, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (base == MAP_FAILED)
            return NULL;
        unsigned char *p = (unsigned char *)(((uintptr_t)base + 64 + SC_HUGE_PAGE - 1) & ~(uintptr_t)(SC_HUGE_PAGE - 1));
#ifdef MADV_HUGEPAGE
        (void)madvise(p, n, MADV_HUGEPAGE);   /* advice: refused or not, p is usable */
#endif
        const large_head h = { base, mapped };
        memcpy(p - 64, &h, sizeof h);
        return p;
    }
    const size_t n = (bytes + 63) / 64 * 64;
    unsigned char *base = malloc(n + 128);
    if (!base)
        return NULL;
    unsigned char *p = (unsigned char *)(((uintptr_t)base + 64 + 63) & ~(uintptr_t)63);
    memset(p, 0, n);
    const large_head h = { base, 0 };
    memcpy(p - 64, &h, sizeof h);
    return p;
}

void sc_free_large(void *p)
{
    if (!p)
        return;
    large_head h;
    memcpy(&h, (unsigned char *)p - 64, sizeof h);
    if (h.mapped)
        munmap(h.base, h.mapped);
    else
        free(h.base);
}

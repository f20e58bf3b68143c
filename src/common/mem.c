/* sc_alloc_large (sc_mem.h). */
#define _DEFAULT_SOURCE   /* madvise, MADV_HUGEPAGE */
#include <stdint.h>
#include <stdlib.h>
#include <sys/mman.h>

#include "sc_mem.h"

#define SC_HUGE_PAGE ((size_t)2 << 20)

void *sc_alloc_large(size_t bytes)
{
    if (bytes > SIZE_MAX - SC_HUGE_PAGE)
        return NULL;                          /* no rounding up without overflow */
    if (bytes >= SC_HUGE_PAGE) {
        const size_t n = (bytes + SC_HUGE_PAGE - 1) & ~(SC_HUGE_PAGE - 1);
        void *p = aligned_alloc(SC_HUGE_PAGE, n);
        if (!p)
            return NULL;
#ifdef MADV_HUGEPAGE
        (void)madvise(p, n, MADV_HUGEPAGE);   /* advice: refused or not, p is usable */
#endif
        return p;
    }
    const size_t n = (bytes + 63) / 64 * 64;
    return aligned_alloc(64, n ? n : 64);
}

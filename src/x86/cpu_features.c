/* CPUID + XGETBV. Written with inline asm rather than <cpuid.h> so that the
 * same code builds with GCC and Clang; compiles to stubs off x86. */
#include <string.h>

#include "cpu_features.h"

#if defined(__x86_64__) || defined(__i386__)

static void cpuid(uint32_t leaf, uint32_t sub, uint32_t r[4])
{
    __asm__ volatile("cpuid" : "=a"(r[0]), "=b"(r[1]), "=c"(r[2]), "=d"(r[3]) : "a"(leaf), "c"(sub));
}

/* Only valid when CPUID.1:ECX.OSXSAVE is set. */
static uint64_t xgetbv0(void)
{
    uint32_t lo, hi;
    __asm__ volatile("xgetbv" : "=a"(lo), "=d"(hi) : "c"(0));
    return ((uint64_t)hi << 32) | lo;
}

static uint32_t detect(void)
{
    uint32_t r[4], f = 0;
    cpuid(0, 0, r);
    uint32_t max_leaf = r[0];
    if (max_leaf < 1)
        return 0;
    cpuid(1, 0, r);
    if (r[2] & (1u << 19))
        f |= SC_X86_SSE41;
    if (r[2] & (1u << 23))
        f |= SC_X86_POPCNT;
    int osxsave = (r[2] >> 27) & 1;
    int avx = (r[2] >> 28) & 1, fma = (r[2] >> 12) & 1;
    uint64_t xcr0 = osxsave ? xgetbv0() : 0;
    int ymm_ok = (xcr0 & 0x6) == 0x6;             /* SSE + AVX state */
    int zmm_ok = (xcr0 & 0xe6) == 0xe6;           /* + opmask, ZMM_Hi256, Hi16_ZMM */
    if (avx && ymm_ok)
        f |= SC_X86_AVX;
    if (fma && ymm_ok)
        f |= SC_X86_FMA;
    if (max_leaf >= 7) {
        cpuid(7, 0, r);
        if (((r[1] >> 5) & 1) && ymm_ok)
            f |= SC_X86_AVX2;
        if ((r[1] >> 3) & 1)
            f |= SC_X86_BMI1;
        if ((r[1] >> 8) & 1)
            f |= SC_X86_BMI2;
        if (zmm_ok) {
            if ((r[1] >> 16) & 1) f |= SC_X86_AVX512F;
            if ((r[1] >> 17) & 1) f |= SC_X86_AVX512DQ;
            if ((r[1] >> 30) & 1) f |= SC_X86_AVX512BW;
            if ((r[1] >> 31) & 1) f |= SC_X86_AVX512VL;
        }
    }
    cpuid(0x80000000u, 0, r);
    if (r[0] >= 0x80000001u) {
        cpuid(0x80000001u, 0, r);
        if ((r[2] >> 5) & 1)
            f |= SC_X86_LZCNT;
    }
    return f;
}

uint32_t sc_x86_features(void)
{
    /* Racing first calls compute the same value; the atomic store keeps it
     * well-defined. The high bit marks "already detected". */
    static uint32_t cached;
    uint32_t v = __atomic_load_n(&cached, __ATOMIC_ACQUIRE);
    if (!(v & 0x80000000u)) {
        v = detect() | 0x80000000u;
        __atomic_store_n(&cached, v, __ATOMIC_RELEASE);
    }
    return v & 0x7fffffffu;
}

void sc_x86_brand(char out[64])
{
    uint32_t r[4];
    cpuid(0x80000000u, 0, r);
    if (r[0] < 0x80000004u) {
        strcpy(out, "unknown");
        return;
    }
    char buf[49];
    for (uint32_t i = 0; i < 3; i++) {
        cpuid(0x80000002u + i, 0, r);
        memcpy(buf + 16 * i, r, 16);
    }
    buf[48] = 0;
    const char *s = buf;
    while (*s == ' ')
        s++;
    strcpy(out, s);
}

#else

uint32_t sc_x86_features(void)
{
    return 0;
}

void sc_x86_brand(char out[64])
{
    strcpy(out, "unknown");
}

#endif

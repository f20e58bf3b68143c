/* x86 CPU feature detection: CPUID for what the CPU implements, XGETBV for
 * what the OS saves on a context switch (AVX needs YMM state, AVX-512 also
 * opmask and ZMM state). A feature counts only if both agree. */
#ifndef SPHERECULL_X86_CPU_FEATURES_H
#define SPHERECULL_X86_CPU_FEATURES_H

#include <stdint.h>

enum {
    SC_X86_SSE41    = 1u << 0,
    SC_X86_AVX      = 1u << 1,
    SC_X86_AVX2     = 1u << 2,
    SC_X86_FMA      = 1u << 3,
    SC_X86_AVX512F  = 1u << 4,
    SC_X86_AVX512VL = 1u << 5,
    SC_X86_AVX512DQ = 1u << 6,
    SC_X86_AVX512BW = 1u << 7,
    SC_X86_POPCNT   = 1u << 8,
    SC_X86_LZCNT    = 1u << 9,
    SC_X86_BMI1     = 1u << 10,
    SC_X86_BMI2     = 1u << 11,
};

/* Bit set of SC_X86_*; 0 on other architectures. Cheap after the first call. */
uint32_t sc_x86_features(void);

/* "AMD EPYC ..." style brand string (at least 49 bytes), or "unknown". */
void sc_x86_brand(char out[64]);

#endif

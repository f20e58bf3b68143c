/* The traversal for AVX2 + FMA CPUs (with BMI1/2, LZCNT, POPCNT, which
 * every AVX2 CPU has): see traverse_bvh8_x86.h. */
#if defined(__x86_64__) || defined(__i386__)
#define SC_TARGET __attribute__((target("avx2,fma,bmi,bmi2,popcnt,lzcnt")))
#define SC_X86_AVX512 0
#define SC_TOP_TABLE sc_trace_kernels_avx2
#include "traverse_bvh8_x86.h"

const sc_trace_kernels sc_trace_kernels_avx2[SC_TRI_TEST_COUNT] = SC_TRACE_KERNEL_TABLE;
#endif

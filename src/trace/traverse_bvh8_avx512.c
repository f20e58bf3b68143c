/* The traversal for AVX-512 (F, VL, BW, DQ) CPUs: the AVX2 code with
 * mask-register compares and EVEX encodings; see traverse_bvh8_x86.h. */
#if defined(__x86_64__) || defined(__i386__)
#define SC_TARGET __attribute__((target("avx2,fma,bmi,bmi2,popcnt,lzcnt,avx512f,avx512vl,avx512bw,avx512dq")))
#define SC_X86_AVX512 1
#define SC_TOP_TABLE sc_trace_kernels_avx512
#include "traverse_bvh8_x86.h"

const sc_trace_kernels sc_trace_kernels_avx512[SC_TRI_TEST_COUNT] = SC_TRACE_KERNEL_TABLE;
#endif

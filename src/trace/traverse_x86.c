/* x86 kernel sets: AVX2+FMA-capable CPUs get 8-wide box tests in ymm; the
 * AVX-512 set is the same code with mask-register compares and EVEX
 * encodings. The ISA is chosen per function (target attributes), so this
 * file needs no special compiler flags. */
#include <immintrin.h>

#include "trace_common.h"

#if defined(__x86_64__) || defined(__i386__)

#define KFN(name) name##_avx2
#define KATTR __attribute__((target("avx2,fma,bmi,bmi2,popcnt,lzcnt")))
#define SC_X86_AVX512 0
#include "traverse_x86_template.h"
#undef KFN
#undef KATTR
#undef SC_X86_AVX512

#define KFN(name) name##_avx512
#define KATTR __attribute__((target("avx2,fma,bmi,bmi2,popcnt,lzcnt,avx512f,avx512vl,avx512bw,avx512dq")))
#define SC_X86_AVX512 1
#include "traverse_x86_template.h"
#undef KFN
#undef KATTR
#undef SC_X86_AVX512

#else
/* Not x86: the tables exist but sc_trace_select never picks them. */
const sc_trace_kernels sc_trace_kernels_avx2[SC_TRI_TEST_COUNT];
const sc_trace_kernels sc_trace_kernels_avx512[SC_TRI_TEST_COUNT];
#endif

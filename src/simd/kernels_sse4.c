/* SSE4.1 kernels: 4 float / 2 double lanes, no FMA (bit-identical to the
 * scalar specification). */
#if defined(__x86_64__) || defined(__i386__)
#include <float.h>
#include <math.h>

#define SC_VEC_F32X4
#define SC_VEC_F64X2
#include "simd_vec.h"
#include "sphere_kernels.h"

#define ATTR SC_ATTR_SSE4

#define VP f32x4
#define REAL float
#define REAL_U (FLT_EPSILON / 2)
#define REAL_MIN FLT_MIN
#define FUNC spheres_f_sse4
#define SOURCE sc_tri_source_f
#define SOA sc_spheres_soaf
#include "sphere_batch_template.h"
#undef VP
#undef REAL
#undef REAL_U
#undef REAL_MIN
#undef FUNC
#undef SOURCE
#undef SOA

#define VP f64x2
#define REAL double
#define REAL_U (DBL_EPSILON / 2)
#define REAL_MIN DBL_MIN
#define FUNC spheres_d_sse4
#define SOURCE sc_tri_source_d
#define SOA sc_spheres_soad
#include "sphere_batch_template.h"
#undef VP

#define VP f32x4
#define W 4
#define RFUNC reject4_sse4
#include "reject_template.h"
#undef W
#undef RFUNC
#define W 8
#define RFUNC reject8_sse4
#define PFUNC packet8_sse4
#include "reject_template.h"
#undef W
#undef RFUNC
#undef PFUNC
#define W 16
#define RFUNC reject16_sse4
#define PFUNC packet16_sse4
#include "reject_template.h"

const sc_sphere_kernels sc_sphere_kernels_sse4 = {
    spheres_f_sse4, spheres_d_sse4, reject4_sse4, reject8_sse4, reject16_sse4,
    packet8_sse4, packet16_sse4,
};
#endif

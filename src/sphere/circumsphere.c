/* Triangle spheres in float and double: one template, two instantiations. */
#include <float.h>
#include <limits.h>
#include <math.h>
#include <string.h>

#include "common/sc_names.h"
#include "spherecull/sc_circumsphere.h"

#define REAL float
#define SUF f
#define SPHERE sc_spheref
#define REAL_U (FLT_EPSILON / 2)
#define REAL_MIN FLT_MIN
#define LDEXP ldexpf
#define ILOGB ilogbf
#define FABS fabsf
#define SQRT sqrtf
#define NEXTAFTER nextafterf
#define FMA fmaf
#define ISFINITE isfinite
#include "circumsphere_template.h"
#undef REAL
#undef SUF
#undef SPHERE
#undef REAL_U
#undef REAL_MIN
#undef LDEXP
#undef ILOGB
#undef FABS
#undef SQRT
#undef NEXTAFTER
#undef FMA

#define REAL double
#define SUF d
#define SPHERE sc_sphered
#define REAL_U (DBL_EPSILON / 2)
#define REAL_MIN DBL_MIN
#define LDEXP ldexp
#define ILOGB ilogb
#define FABS fabs
#define SQRT sqrt
#define NEXTAFTER nextafter
#define FMA fma
#include "circumsphere_template.h"

static const char *const method_names[SC_METHOD_COUNT] = {
    "textbook", "cramer", "projective-literal", "projective-reduced",
};
static const char *const origin_names[SC_ORIGIN_COUNT] = { "opposite-longest", "as-given" };
static const char *const kind_names[SC_SPHERE_KIND_COUNT] = { "circum", "minimal" };

const char *sc_method_name(sc_method m)
{
    return sc_enum_name(method_names, SC_METHOD_COUNT, (int)m, "unknown");
}

const char *sc_origin_name(sc_origin o)
{
    return (unsigned)o < SC_ORIGIN_COUNT ? origin_names[o] : "unknown";
}

const char *sc_sphere_kind_name(sc_sphere_kind k)
{
    return sc_enum_name(kind_names, SC_SPHERE_KIND_COUNT, (int)k, "unknown");
}

sc_status sc_method_from_name(const char *name, sc_method *out)
{
    int v;
    if (!out || sc_enum_lookup(method_names, SC_METHOD_COUNT, name, &v) != 0)
        return SC_ERR_INVALID_ARGUMENT;
    *out = (sc_method)v;
    return SC_OK;
}

sc_status sc_sphere_kind_from_name(const char *name, sc_sphere_kind *out)
{
    int v;
    if (!out || sc_enum_lookup(kind_names, SC_SPHERE_KIND_COUNT, name, &v) != 0)
        return SC_ERR_INVALID_ARGUMENT;
    *out = (sc_sphere_kind)v;
    return SC_OK;
}

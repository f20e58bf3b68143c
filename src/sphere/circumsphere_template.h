/* One body for the float and double triangle-sphere kernels.
 *
 * Included by circumsphere.c once per precision with
 *   REAL        float | double
 *   SUF         f | d            (name suffix)
 *   SPHERE      sc_spheref | sc_sphered
 *   REAL_U      unit roundoff (2^-24 | 2^-53)
 *   REAL_MIN       smallest positive normal number
 *   LDEXP, ILOGB, FABS, ISFINITE  the matching libm calls
 *
 * These scalar kernels are the specification the SIMD kernels are tested
 * against, so they favour clarity; each method keeps the operation order its
 * formula prescribes, because that order is what the accuracy report compares.
 */

#define CAT_(a, b) a##_##b
#define CAT(a, b) CAT_(a, b)
#define FN(name) CAT(name, SUF)

static inline REAL FN(dot3)(const REAL x[3], const REAL y[3])
{
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
}

static inline void FN(cross3)(REAL out[3], const REAL x[3], const REAL y[3])
{
    out[0] = x[1] * y[2] - x[2] * y[1];
    out[1] = x[2] * y[0] - x[0] * y[2];
    out[2] = x[0] * y[1] - x[1] * y[0];
}

static inline void FN(sub3)(REAL out[3], const REAL x[3], const REAL y[3])
{
    out[0] = x[0] - y[0];
    out[1] = x[1] - y[1];
    out[2] = x[2] - y[2];
}

static inline int FN(all_finite)(const REAL *x, int count)
{
    for (int i = 0; i < count; i++)
        if (!ISFINITE(x[i]))
            return 0;
    return 1;
}

static void FN(set_never_reject)(SPHERE *out)
{
    out->c[0] = out->c[1] = out->c[2] = 0;
    out->r2 = (REAL)INFINITY;
}

/* Picks the vertex that becomes C. With C opposite the longest edge, |a| and
 * |b| are the two shorter edges and cancellation in u = |a|^2 b - |b|^2 a is
 * bounded by a factor 2 (docs/numerics.md). Squared lengths are compared on
 * the raw differences; an overflow to +inf still orders correctly. */
static void FN(order_vertices)(const REAL *V[3], sc_origin origin,
                               const REAL *A, const REAL *B, const REAL *C)
{
    V[0] = A, V[1] = B, V[2] = C;
    if (origin != SC_ORIGIN_OPPOSITE_LONGEST)
        return;
    REAL e[3], ab, bc, ca;
    FN(sub3)(e, A, B); ab = FN(dot3)(e, e);
    FN(sub3)(e, B, C); bc = FN(dot3)(e, e);
    FN(sub3)(e, C, A); ca = FN(dot3)(e, e);
    if (bc > ab && bc >= ca) {        /* longest BC: A becomes the origin */
        V[0] = B, V[1] = C, V[2] = A;
    } else if (ca > ab && ca > bc) {  /* longest CA: B becomes the origin */
        V[0] = C, V[1] = A, V[2] = B;
    }
}

/* out[i] = P[i] - Q[i], all scaled by one exact power of two 2^-e so that the
 * largest component lies in [1, 2); returns e, or INT_MIN when every
 * difference is zero. Without the scaling, float |n|^2 ~ L^4 underflows below
 * L ~ 1e-10 and the literal 4D product overflows past L ~ 1e2. A difference
 * that overflows (coordinates near +-FLT_MAX) is formed from halved operands,
 * which is exact for all but subnormal components, negligible at that scale. */
static int FN(scaled_differences)(REAL (*out)[3], const REAL *const *P, const REAL *const *Q, int count)
{
    int extra = 0;
    REAL m = 0;
    for (int pass = 0; pass < 2; pass++) {
        m = 0;
        for (int i = 0; i < count; i++)
            for (int j = 0; j < 3; j++) {
                out[i][j] = pass ? P[i][j] / 2 - Q[i][j] / 2 : P[i][j] - Q[i][j];
                if (FABS(out[i][j]) > m)
                    m = FABS(out[i][j]);
            }
        if (ISFINITE(m))
            break;
        extra = 1;
    }
    if (m == 0)
        return INT_MIN;
    int e = ILOGB(m);
    for (int i = 0; i < count; i++)
        for (int j = 0; j < 3; j++)
            out[i][j] = LDEXP(out[i][j], -e);
    return e + extra;
}

/* Edge vectors a = V0 - V2, b = V1 - V2, prescaled as above. */
static int FN(edges_prescaled)(REAL a[3], REAL b[3], const REAL *V[3])
{
    REAL e[2][3];
    const REAL *P[2] = { V[0], V[1] }, *Q[2] = { V[2], V[2] };
    int scale = FN(scaled_differences)(e, P, Q, 2);
    for (int j = 0; j < 3; j++)
        a[j] = e[0][j], b[j] = e[1][j];
    return scale;
}

/* Circumcentre offset from C and r^2, both in the prescaled frame.
 * Returns 0 when the triangle is degenerate in that frame. */
static int FN(circum_scaled)(const REAL a[3], const REAL b[3], sc_method method,
                             REAL off[3], REAL *r2)
{
    REAL n[3];
    FN(cross3)(n, a, b);
    REAL aa = FN(dot3)(a, a), bb = FN(dot3)(b, b);

    switch (method) {
    case SC_METHOD_TEXTBOOK: {
        REAL nn = FN(dot3)(n, n);
        if (!(nn > 0))
            return 0;
        REAL u[3] = { aa * b[0] - bb * a[0], aa * b[1] - bb * a[1], aa * b[2] - bb * a[2] };
        REAL un[3], amb[3];
        FN(cross3)(un, u, n);
        REAL inv = 1 / (2 * nn);
        off[0] = un[0] * inv, off[1] = un[1] * inv, off[2] = un[2] * inv;
        FN(sub3)(amb, a, b);
        *r2 = aa * bb * FN(dot3)(amb, amb) / (4 * nn);
        return 1;
    }
    case SC_METHOD_CRAMER: {
        /* M = [a; b; n], h = (|a|^2/2, |b|^2/2, 0); M^-1 = [b x n, n x a, a x b] / det. */
        REAL bxn[3], nxa[3];
        FN(cross3)(bxn, b, n);
        FN(cross3)(nxa, n, a);
        REAL det = FN(dot3)(a, bxn);
        if (!(det > 0))
            return 0;
        REAL ha = aa / 2, hb = bb / 2;
        for (int i = 0; i < 3; i++)
            off[i] = (ha * bxn[i] + hb * nxa[i]) / det;
        *r2 = FN(dot3)(off, off);
        return 1;
    }
    case SC_METHOD_PROJECTIVE_LITERAL: {
        /* Skala's appendix: q = x1 x x2 x x3 in P3 with x1 = [a : -|a|^2/2],
         * x2 = [b : -|b|^2/2], x3 = [n : 0]; component j is (-1)^j times the
         * 3x3 minor without column j, each a dot of a cross. */
        const REAL x1[4] = { a[0], a[1], a[2], -aa / 2 };
        const REAL x2[4] = { b[0], b[1], b[2], -bb / 2 };
        const REAL x3[4] = { n[0], n[1], n[2], 0 };
        static const int keep[4][3] = { { 1, 2, 3 }, { 0, 2, 3 }, { 0, 1, 3 }, { 0, 1, 2 } };
        REAL q[4];
        for (int j = 0; j < 4; j++) {
            const int *k = keep[j];
            REAL p1[3] = { x1[k[0]], x1[k[1]], x1[k[2]] };
            REAL p2[3] = { x2[k[0]], x2[k[1]], x2[k[2]] };
            REAL p3[3] = { x3[k[0]], x3[k[1]], x3[k[2]] };
            REAL c23[3];
            FN(cross3)(c23, p2, p3);
            REAL minor = FN(dot3)(p1, c23);
            q[j] = (j & 1) ? -minor : minor;
        }
        if (!(q[3] < 0))        /* q_w = -|n|^2 (eq. 16 with the sign fixed) */
            return 0;
        REAL inv = 1 / q[3];
        off[0] = q[0] * inv, off[1] = q[1] * inv, off[2] = q[2] * inv;
        *r2 = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]) / (q[3] * q[3]);
        return 1;
    }
    case SC_METHOD_PROJECTIVE_REDUCED: {
        /* D_i4 = rhoA_i rhoB_4 - rhoA_4 rhoB_i = u_i / 2; q' = n x D; q'_w = -|n|^2. */
        REAL ha = -aa / 2, hb = -bb / 2;
        REAL D[3] = { a[0] * hb - ha * b[0], a[1] * hb - ha * b[1], a[2] * hb - ha * b[2] };
        REAL q[3];
        q[0] = n[1] * D[2] - n[2] * D[1];
        q[1] = n[2] * D[0] - n[0] * D[2];
        q[2] = n[0] * D[1] - n[1] * D[0];
        REAL qw = -FN(dot3)(n, n);
        if (!(qw < 0))
            return 0;
        REAL inv = 1 / qw;
        off[0] = q[0] * inv, off[1] = q[1] * inv, off[2] = q[2] * inv;
        /* r^2 from the divided offset, not eq. 15's |q'|^2 / q'_w^2: q'_w^2 ~ L^8
         * underflows for needles even after prescaling (the literal form keeps
         * the paper's expression and shows the failure). */
        *r2 = FN(dot3)(off, off);
        return 1;
    }
    default:
        return 0;
    }
}

/* Centre = C + 2^e off, r2 = 2^2e r2s. SC_ERR_RANGE if either overflows, or
 * if a positive r2 underflows to zero (subnormal triangles in float); the
 * centre is still stored then, for the prefilter, which recomputes r2. */
static sc_status FN(unscale)(SPHERE *out, const REAL *C, const REAL off[3], REAL r2s, int e)
{
    for (int i = 0; i < 3; i++)
        out->c[i] = C[i] + LDEXP(off[i], e);
    out->r2 = LDEXP(r2s, 2 * e);
    if (!FN(all_finite)(out->c, 3) || !ISFINITE(out->r2)) {
        FN(set_never_reject)(out);
        return SC_ERR_RANGE;
    }
    return (r2s > 0 && out->r2 == 0) ? SC_ERR_RANGE : SC_OK;
}

static sc_status FN(check_args)(const REAL *A, const REAL *B, const REAL *C,
                                sc_method method, sc_origin origin, const SPHERE *out)
{
    if (!A || !B || !C || !out || (unsigned)method >= SC_METHOD_COUNT ||
        (unsigned)origin >= SC_ORIGIN_COUNT)
        return SC_ERR_INVALID_ARGUMENT;
    if (!FN(all_finite)(A, 3) || !FN(all_finite)(B, 3) || !FN(all_finite)(C, 3))
        return SC_ERR_NONFINITE;
    return SC_OK;
}

static sc_status FN(circumsphere)(const REAL A[3], const REAL B[3], const REAL C[3],
                                  sc_method method, sc_origin origin, SPHERE *out)
{
    sc_status st = FN(check_args)(A, B, C, method, origin, out);
    if (st != SC_OK) {
        if (out)
            FN(set_never_reject)(out);
        return st;
    }
    const REAL *V[3];
    FN(order_vertices)(V, origin, A, B, C);
    REAL a[3], b[3], off[3], r2s;
    int e = FN(edges_prescaled)(a, b, V);
    if (e == INT_MIN || !FN(circum_scaled)(a, b, method, off, &r2s) ||
        !FN(all_finite)(off, 3) || !ISFINITE(r2s)) {
        FN(set_never_reject)(out);
        return SC_ERR_DEGENERATE;
    }
    return FN(unscale)(out, V[2], off, r2s, e);
}

/* The longest edge's midpoint sphere when the triangle is right or obtuse
 * (|a|^2 + |b|^2 <= |c|^2, c the longest edge), which covers collinear and
 * duplicate vertices too; the circumsphere otherwise. */
static sc_status FN(minimal_sphere)(const REAL A[3], const REAL B[3], const REAL C[3],
                                    sc_method method, sc_origin origin, SPHERE *out)
{
    sc_status st = FN(check_args)(A, B, C, method, origin, out);
    if (st != SC_OK) {
        if (out)
            FN(set_never_reject)(out);
        return st;
    }
    /* The triangle is right or obtuse at vertex X iff (P - X).(R - X) <= 0 for
     * the other two vertices P, R. Each of the three dots is tested directly:
     * choosing X as "opposite the longest edge" first fails on needles, whose
     * two long edges differ by less than their rounding while the angle at
     * the short edge is far from 90 degrees. Work in a prescaled frame so
     * the dots neither underflow nor overflow. */
    const REAL *P[3] = { A, B, C };
    const REAL *next[3] = { B, C, A };
    REAL e[3][3];                              /* e[i] = P[i+1] - P[i], prescaled */
    int scale = FN(scaled_differences)(e, next, P, 3);
    if (scale == INT_MIN) {                    /* all three vertices equal */
        out->c[0] = C[0], out->c[1] = C[1], out->c[2] = C[2];
        out->r2 = 0;
        return SC_OK;
    }
    int x = -1;
    REAL lowest = 0;
    for (int i = 0; i < 3; i++) {
        /* at P[i]: (P[i+1] - P[i]) . (P[i-1] - P[i]) = -e[i] . e[i-1] */
        REAL d = -FN(dot3)(e[i], e[(i + 2) % 3]);
        if (d <= lowest && (x < 0 || d < lowest)) {
            x = i;
            lowest = d;
        }
    }
    if (x >= 0) {
        /* Midpoint of the edge opposite P[x]: P[x+1] + e[x+1]/2, in the
         * prescaled frame so nothing overflows. */
        const REAL *e_opp = e[(x + 1) % 3];
        REAL off[3] = { e_opp[0] / 2, e_opp[1] / 2, e_opp[2] / 2 };
        return FN(unscale)(out, P[(x + 1) % 3], off, FN(dot3)(e_opp, e_opp) / 4, scale);
    }
    st = FN(circumsphere)(A, B, C, method, origin, out);
    if (st != SC_ERR_DEGENERATE)
        return st;
    /* Acute to working precision, yet too thin for the circumcentre formula
     * (the literal projective r^2 underflows on extreme needles): the sphere
     * about the longest edge's midpoint, widened to reach the third vertex,
     * still encloses the triangle and is within rounding of the minimal one. */
    int longest = 0;
    REAL len2[3];
    for (int i = 0; i < 3; i++) {
        len2[i] = FN(dot3)(e[i], e[i]);
        if (len2[i] > len2[longest])
            longest = i;
    }
    const REAL *el = e[longest];
    REAL off[3] = { el[0] / 2, el[1] / 2, el[2] / 2 };
    /* the third vertex, relative to the edge's start P[longest]: -e[longest - 1] */
    const REAL *eprev = e[(longest + 2) % 3];
    REAL d[3] = { -eprev[0] - off[0], -eprev[1] - off[1], -eprev[2] - off[2] };
    REAL r2s = FN(dot3)(d, d);
    if (len2[longest] / 4 > r2s)
        r2s = len2[longest] / 4;
    return FN(unscale)(out, P[longest], off, r2s, scale);
}

/* Public contract: on any error the sphere is (0,0,0) with r2 = +inf. */
/* 1 when some coordinate is subnormal and the calling thread reads
 * subnormal operands as zero (MXCSR DAZ): the arithmetic then sees another
 * triangle than the caller's. Decided on the bits, since under DAZ every
 * floating-point comparison of a subnormal says "zero". */
static int FN(subnormal_under_daz)(const REAL *const V[3])
{
    int any = 0;
    for (int k = 0; k < 3; k++)
        for (int i = 0; i < 3; i++) {
            unsigned char b[sizeof(REAL)];
            memcpy(b, &V[k][i], sizeof b);
            /* Little endian: the exponent sits in the top bits. */
            unsigned hi = (unsigned)b[sizeof b - 1] << 8 | b[sizeof b - 2];
            unsigned expo = sizeof(REAL) == 4 ? (hi >> 7) & 0xffu : (hi >> 4) & 0x7ffu;
            int zero = 1;
            for (size_t j = 0; j + 1 < sizeof b; j++)
                zero &= b[j] == 0;
            zero &= sizeof(REAL) == 4 ? (hi & 0x7fu) == 0 : (hi & 0xfu) == 0;
            any |= expo == 0 && !zero;
        }
    if (!any)
        return 0;
    volatile REAL tiny = REAL_MIN / 2;
    return tiny + 0 == 0;
}

sc_status FN(sc_circumsphere)(const REAL A[3], const REAL B[3], const REAL C[3],
                              sc_method method, sc_origin origin, SPHERE *out)
{
    sc_status st = FN(circumsphere)(A, B, C, method, origin, out);
    if (st == SC_OK && FN(subnormal_under_daz)((const REAL *const[3]){ A, B, C }))
        st = SC_ERR_RANGE;
    if (st != SC_OK && out)
        FN(set_never_reject)(out);
    return st;
}

sc_status FN(sc_minimal_sphere)(const REAL A[3], const REAL B[3], const REAL C[3],
                                sc_method method, sc_origin origin, SPHERE *out)
{
    sc_status st = FN(minimal_sphere)(A, B, C, method, origin, out);
    if (st == SC_OK && FN(subnormal_under_daz)((const REAL *const[3]){ A, B, C }))
        st = SC_ERR_RANGE;
    if (st != SC_OK && out)
        FN(set_never_reject)(out);
    return st;
}

void FN(sc_sphere_make_conservative)(const REAL A[3], const REAL B[3], const REAL C[3],
                                     SPHERE *s)
{
    const REAL *V[3] = { A, B, C };
    REAL worst = 0;
    for (int i = 0; i < 3; i++) {
        REAL d[3];
        FN(sub3)(d, V[i], s->c);
        REAL dd = FN(dot3)(d, d);
        if (!(dd <= worst))    /* also takes NaN, which then poisons worst */
            worst = dd;
    }
    /* fl(|V - c|^2) is within (1 +- 5u) of the exact value plus an absolute
     * underflow error. With gradual underflow that error is a few denorm_min;
     * with flush-to-zero / denormals-are-zero (MXCSR FTZ|DAZ) each difference
     * may lose a subnormal operand or result (< MIN), each square and the sum
     * may flush (< MIN each), and worst * (1 + 8u) may flush (< MIN): at most
     * about 5 MIN in all. The pad 16 MIN is a normal number, so it survives
     * DAZ where the sphere is read, and r2 >= 16 MIN in both modes
     * (docs/numerics.md, "Flush-to-zero and denormals-are-zero"). */
    REAL r2 = worst * (1 + 8 * REAL_U) + 16 * REAL_MIN;
    if (!ISFINITE(r2) || !FN(all_finite)(s->c, 3)) {
        FN(set_never_reject)(s);
        return;
    }
    s->r2 = r2;
}

sc_status FN(sc_prefilter_sphere)(const REAL A[3], const REAL B[3], const REAL C[3],
                                  sc_sphere_kind kind, sc_method method, SPHERE *out)
{
    if (!out || (unsigned)kind >= SC_SPHERE_KIND_COUNT || (unsigned)method >= SC_METHOD_COUNT) {
        if (out)
            FN(set_never_reject)(out);
        return SC_ERR_INVALID_ARGUMENT;
    }
    if (!A || !B || !C) {
        FN(set_never_reject)(out);
        return SC_ERR_INVALID_ARGUMENT;
    }
    /* Only the centre matters here: r2 is recomputed from it below, so an
     * r2 that underflowed (SC_ERR_RANGE with a finite centre) is fine. */
    sc_status st = kind == SC_SPHERE_CIRCUM
        ? FN(circumsphere)(A, B, C, method, SC_ORIGIN_OPPOSITE_LONGEST, out)
        : SC_ERR_DEGENERATE;
    if (st != SC_OK && !(st == SC_ERR_RANGE && ISFINITE(out->r2)))
        st = FN(minimal_sphere)(A, B, C, method, SC_ORIGIN_OPPOSITE_LONGEST, out);
    if (st != SC_OK && !(st == SC_ERR_RANGE && ISFINITE(out->r2))) {
        FN(set_never_reject)(out);   /* non-finite input or overflow */
        return SC_OK;
    }
    FN(sc_sphere_make_conservative)(A, B, C, out);
    return SC_OK;
}

REAL FN(sc_sphere_radius)(const SPHERE *s)
{
    if (!s || !(s->r2 >= 0))
        return (REAL)NAN;
    REAL r = SQRT(s->r2);
    if (FMA(r, r, -s->r2) < 0)  /* the sign of a fused result is exact */
        r = NEXTAFTER(r, (REAL)INFINITY);
    return r;
}

#undef FN
#undef CAT
#undef CAT_

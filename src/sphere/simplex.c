/* Circumscribed hyperspheres of k-simplices in En, double precision.
 *
 * With e_i = V_i - V0, the centre x = Q - V0 lies on every bisector
 * hyperplane e_i . x = |e_i|^2 / 2. For k = n those n hyperplanes fix x; for
 * k < n, x must also lie in span(e_i) (x = E^T l, so G l = diag(G)/2 with
 * G = E E^T). Skala's eq. (18) is the projective form of the same thing:
 * the generalized cross product of the homogeneous hyperplanes
 * [e_i : -|e_i|^2/2] (and, for k = n-1, the simplex's own hyperplane [N : 0]).
 */
#include <limits.h>
#include <math.h>
#include <string.h>

#include "spherecull/sc_circumsphere.h"

enum { MAXN = SC_SIMPLEX_MAX_DIM, MAXC = SC_SIMPLEX_MAX_DIM + 1 };

const char *sc_simplex_method_name(sc_simplex_method m)
{
    switch (m) {
    case SC_SIMPLEX_CROSS: return "cross";
    case SC_SIMPLEX_SOLVE: return "solve";
    default:               return "unknown";
    }
}

/* Gaussian elimination with partial pivoting of the m x m matrix a (row
 * stride MAXC), in place, carrying rhs along when it is not NULL. Returns the
 * determinant (0 when a pivot vanishes, and then the elimination stops). */
static double eliminate(double a[][MAXC], double rhs[], int m)
{
    double det = 1;
    for (int col = 0; col < m; col++) {
        int piv = col;
        for (int r = col + 1; r < m; r++)
            if (fabs(a[r][col]) > fabs(a[piv][col]))
                piv = r;
        if (a[piv][col] == 0)
            return 0;
        if (piv != col) {
            for (int c = 0; c < m; c++) {
                double t = a[col][c]; a[col][c] = a[piv][c]; a[piv][c] = t;
            }
            if (rhs) {
                double t = rhs[col]; rhs[col] = rhs[piv]; rhs[piv] = t;
            }
            det = -det;
        }
        det *= a[col][col];
        for (int r = col + 1; r < m; r++) {
            double f = a[r][col] / a[col][col];
            for (int c = col + 1; c < m; c++)
                a[r][c] -= f * a[col][c];
            if (rhs)
                rhs[r] -= f * rhs[col];
        }
    }
    return det;
}

/* Generalized cross product of the m rows of rows (each m+1 long):
 * out_j = (-1)^j det(rows without column j), so that rows . out = 0. */
static void generalized_cross(double out[], const double rows[][MAXC], int m)
{
    double minor[MAXN][MAXC];
    for (int j = 0; j <= m; j++) {
        for (int r = 0; r < m; r++)
            for (int c = 0, cc = 0; c <= m; c++)
                if (c != j)
                    minor[r][cc++] = rows[r][c];
        double d = eliminate(minor, NULL, m);
        out[j] = (j & 1) ? -d : d;
    }
}

static int solve_square_lu(double a[][MAXC], double rhs[], double x[], int m)
{
    if (eliminate(a, rhs, m) == 0)
        return 0;
    for (int r = m - 1; r >= 0; r--) {
        double s = rhs[r];
        for (int c = r + 1; c < m; c++)
            s -= a[r][c] * x[c];
        x[r] = s / a[r][r];
    }
    return 1;
}

/* x in span(e_1..e_k) with e_i . x = h_i, via Householder QR of E^T (n x k):
 * E^T = Q R gives R^T y = h and x = Q [y; 0]. Never forms the Gram matrix,
 * whose condition number is the square of E's. */
static int solve_span_qr(const double e[][MAXN], const double h[], double x[], int n, int k)
{
    double A[MAXN][MAXN];       /* A = E^T, n rows, k columns */
    double v[MAXN][MAXN];       /* Householder vectors, one per column */
    double beta[MAXN];
    for (int r = 0; r < n; r++)
        for (int c = 0; c < k; c++)
            A[r][c] = e[c][r];
    for (int c = 0; c < k; c++) {
        double norm = 0;
        for (int r = c; r < n; r++)
            norm = hypot(norm, A[r][c]);
        if (norm == 0)
            return 0;
        double alpha = A[c][c] > 0 ? -norm : norm;
        for (int r = 0; r < n; r++)
            v[c][r] = r < c ? 0 : A[r][c];
        v[c][c] -= alpha;
        double vv = 0;
        for (int r = c; r < n; r++)
            vv += v[c][r] * v[c][r];
        beta[c] = vv > 0 ? 2 / vv : 0;
        for (int cc = c; cc < k; cc++) {
            double s = 0;
            for (int r = c; r < n; r++)
                s += v[c][r] * A[r][cc];
            s *= beta[c];
            for (int r = c; r < n; r++)
                A[r][cc] -= s * v[c][r];
        }
    }
    double y[MAXN] = { 0 };
    for (int r = 0; r < k; r++) {            /* R^T y = h, R upper triangular */
        double s = h[r];
        for (int c = 0; c < r; c++)
            s -= A[c][r] * y[c];
        if (A[r][r] == 0)
            return 0;
        y[r] = s / A[r][r];
    }
    for (int r = 0; r < n; r++)
        x[r] = y[r];
    for (int c = k - 1; c >= 0; c--) {       /* x = H_0 ... H_{k-1} y */
        double s = 0;
        for (int r = c; r < n; r++)
            s += v[c][r] * x[r];
        s *= beta[c];
        for (int r = c; r < n; r++)
            x[r] -= s * v[c][r];
    }
    return 1;
}

static void fail(double *centre, double *r2, int n)
{
    if (centre)
        memset(centre, 0, sizeof(double) * (size_t)(n > 0 && n <= MAXN ? n : 0));
    if (r2)
        *r2 = INFINITY;
}

sc_status sc_simplex_sphere(int n, int k, const double *vertices,
                            sc_simplex_method method, double *centre, double *r2)
{
    if (!vertices || !centre || n < 2 || n > MAXN || k < 1 || k > n ||
        (unsigned)method >= SC_SIMPLEX_METHOD_COUNT) {
        fail(centre, r2, n);
        return SC_ERR_INVALID_ARGUMENT;
    }
    for (int i = 0; i < (k + 1) * n; i++)
        if (!isfinite(vertices[i])) {
            fail(centre, r2, n);
            return SC_ERR_NONFINITE;
        }
    if (method == SC_SIMPLEX_CROSS && k < n - 1) {
        fail(centre, r2, n);
        return SC_ERR_UNSUPPORTED;
    }

    /* Edges relative to V0, prescaled by an exact power of two (as for
     * triangles) so that determinants of degree n+1 stay in range. */
    const double *V0 = vertices;
    double e[MAXN][MAXN];
    double m = 0;
    for (int i = 0; i < k; i++)
        for (int j = 0; j < n; j++) {
            e[i][j] = vertices[(i + 1) * n + j] - V0[j];
            if (fabs(e[i][j]) > m)
                m = fabs(e[i][j]);
        }
    if (!isfinite(m)) {
        fail(centre, r2, n);
        return SC_ERR_RANGE;
    }
    if (m == 0) {
        fail(centre, r2, n);
        return SC_ERR_DEGENERATE;
    }
    int sc = ilogb(m);
    double h[MAXN];
    for (int i = 0; i < k; i++) {
        double s = 0;
        for (int j = 0; j < n; j++) {
            e[i][j] = ldexp(e[i][j], -sc);
            s += e[i][j] * e[i][j];
        }
        h[i] = s / 2;
    }

    double x[MAXN];
    int ok;
    if (method == SC_SIMPLEX_CROSS) {
        double rows[MAXN][MAXC];
        for (int i = 0; i < k; i++) {
            for (int j = 0; j < n; j++)
                rows[i][j] = e[i][j];
            rows[i][n] = -h[i];
        }
        if (k == n - 1) {
            /* The simplex's own hyperplane through V0 (the origin here):
             * [N : 0], N the generalized cross product of the n-1 edges. */
            double edges[MAXN][MAXC], N[MAXC];
            for (int i = 0; i < k; i++)
                for (int j = 0; j < n; j++)
                    edges[i][j] = e[i][j];
            generalized_cross(N, (const double(*)[MAXC])edges, k);
            for (int j = 0; j < n; j++)
                rows[k][j] = N[j];
            rows[k][n] = 0;
        }
        double q[MAXC];
        generalized_cross(q, (const double(*)[MAXC])rows, n);
        ok = q[n] != 0 && isfinite(q[n]);
        for (int j = 0; ok && j < n; j++)
            x[j] = q[j] / q[n];
    } else if (k == n) {
        double a[MAXN][MAXC], rhs[MAXN];
        for (int i = 0; i < n; i++) {
            for (int j = 0; j < n; j++)
                a[i][j] = e[i][j];
            rhs[i] = h[i];
        }
        ok = solve_square_lu(a, rhs, x, n);
    } else {
        ok = solve_span_qr(e, h, x, n, k);
    }
    double s = 0;
    for (int j = 0; ok && j < n; j++)
        s += x[j] * x[j];
    if (!ok || !isfinite(s)) {
        fail(centre, r2, n);
        return SC_ERR_DEGENERATE;
    }
    for (int j = 0; j < n; j++)
        centre[j] = V0[j] + ldexp(x[j], sc);
    double rr = ldexp(s, 2 * sc);
    for (int j = 0; j < n; j++)
        if (!isfinite(centre[j]))
            rr = INFINITY;
    if (!isfinite(rr)) {
        fail(centre, r2, n);
        return SC_ERR_RANGE;
    }
    if (r2)
        *r2 = rr;
    return SC_OK;
}

/* ======================================================================
   Layer 1: linear algebra
   ====================================================================== */

/* ---- 3-vectors and row-major 3x3 matrices (private helpers) ---- */
static double sqffd__dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void sqffd__sub3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[0] - b[0]; out[1] = a[1] - b[1]; out[2] = a[2] - b[2];
}

static void sqffd__cross3(const double a[3], const double b[3], double out[3])
{
    double x = a[1] * b[2] - a[2] * b[1];
    double y = a[2] * b[0] - a[0] * b[2];
    double z = a[0] * b[1] - a[1] * b[0];
    out[0] = x; out[1] = y; out[2] = z;
}

static double sqffd__dist2_3(const double a[3], const double b[3])
{
    double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}

/* out = M v (out may alias v) */
static void sqffd__mat3_vec(const double m[9], const double v[3], double out[3])
{
    double x = m[0] * v[0] + m[1] * v[1] + m[2] * v[2];
    double y = m[3] * v[0] + m[4] * v[1] + m[5] * v[2];
    double z = m[6] * v[0] + m[7] * v[1] + m[8] * v[2];
    out[0] = x; out[1] = y; out[2] = z;
}

/* out = M^T v (out may alias v) */
static void sqffd__mat3t_vec(const double m[9], const double v[3], double out[3])
{
    double x = m[0] * v[0] + m[3] * v[1] + m[6] * v[2];
    double y = m[1] * v[0] + m[4] * v[1] + m[7] * v[2];
    double z = m[2] * v[0] + m[5] * v[1] + m[8] * v[2];
    out[0] = x; out[1] = y; out[2] = z;
}

/* ---- Symmetric 3x3 eigen-decomposition (cyclic Jacobi) ---- */

/* Rotation in the (p, q) plane that zeroes m[p][q]; v accumulates columns. */
static void sqffd__la_jacobi3_rotate(double m[9], double v[9], int p, int q)
{
    double apq = m[3 * p + q], app = m[3 * p + p], aqq = m[3 * q + q];
    double theta, t, c, s;
    int k;
    theta = (aqq - app) / (2.0 * apq);
    /* t = tan of the rotation angle, the smaller root of t^2 + 2 theta t - 1 */
    if (fabs(theta) > 1e150) t = 0.5 / theta;
    else t = (theta >= 0.0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
    c = 1.0 / sqrt(t * t + 1.0);
    s = t * c;
    for (k = 0; k < 3; ++k) { /* columns p, q of m */
        double mkp = m[3 * k + p], mkq = m[3 * k + q];
        m[3 * k + p] = c * mkp - s * mkq;
        m[3 * k + q] = s * mkp + c * mkq;
    }
    for (k = 0; k < 3; ++k) { /* rows p, q of m */
        double mpk = m[3 * p + k], mqk = m[3 * q + k];
        m[3 * p + k] = c * mpk - s * mqk;
        m[3 * q + k] = s * mpk + c * mqk;
    }
    m[3 * p + q] = m[3 * q + p] = 0.0;
    m[3 * p + p] = app - t * apq;
    m[3 * q + q] = aqq + t * apq;
    for (k = 0; k < 3; ++k) {
        double vkp = v[3 * k + p], vkq = v[3 * k + q];
        v[3 * k + p] = c * vkp - s * vkq;
        v[3 * k + q] = s * vkp + c * vkq;
    }
}

/* Flip a column so that its component of largest magnitude is positive. */
static void sqffd__la_sign_column3(double v[9], int col)
{
    int k, big = 0;
    for (k = 1; k < 3; ++k)
        if (fabs(v[3 * k + col]) > fabs(v[3 * big + col])) big = k;
    if (v[3 * big + col] < 0.0)
        for (k = 0; k < 3; ++k) v[3 * k + col] = -v[3 * k + col];
}

SQFFD_DEF void sqffd_sym3_eigen(const double a[9], double values[3], double vectors[9])
{
    static const int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
    double m[9], v[9], c0[3], c1[3], c2[3];
    int sweep, i, j, k, order[3];
    for (i = 0; i < 3; ++i)
        for (j = 0; j < 3; ++j) {
            m[3 * i + j] = i <= j ? a[3 * i + j] : a[3 * j + i];
            v[3 * i + j] = i == j ? 1.0 : 0.0;
        }
    for (sweep = 0; sweep < 64; ++sweep) {
        int rotated = 0;
        for (k = 0; k < 3; ++k) {
            int p = pairs[k][0], q = pairs[k][1];
            double apq = m[3 * p + q], g = 100.0 * fabs(apq);
            if (apq == 0.0) continue;
            /* negligible next to both diagonal entries: drop it */
            if (fabs(m[3 * p + p]) + g == fabs(m[3 * p + p]) && fabs(m[3 * q + q]) + g == fabs(m[3 * q + q])) {
                m[3 * p + q] = m[3 * q + p] = 0.0;
                continue;
            }
            sqffd__la_jacobi3_rotate(m, v, p, q);
            rotated = 1;
        }
        if (!rotated) break;
    }
    /* ascending order */
    order[0] = 0; order[1] = 1; order[2] = 2;
    for (i = 0; i < 2; ++i)
        for (j = 0; j < 2 - i; ++j)
            if (m[3 * order[j + 1] + order[j + 1]] < m[3 * order[j] + order[j]]) {
                int t = order[j]; order[j] = order[j + 1]; order[j + 1] = t;
            }
    for (i = 0; i < 3; ++i) {
        values[i] = m[3 * order[i] + order[i]];
        for (k = 0; k < 3; ++k) vectors[3 * k + i] = v[3 * k + order[i]];
    }
    sqffd__la_sign_column3(vectors, 0);
    sqffd__la_sign_column3(vectors, 1);
    for (k = 0; k < 3; ++k) { c0[k] = vectors[3 * k]; c1[k] = vectors[3 * k + 1]; }
    sqffd__cross3(c0, c1, c2);
    for (k = 0; k < 3; ++k) vectors[3 * k + 2] = c2[k];
}

/* ---- Dense vector kernels ---- */

/* restrict lets compilers vectorise the kernels at -O2 (no alias checks) */
#ifdef __cplusplus
#define SQFFD__LA_RESTRICT __restrict
#else
#define SQFFD__LA_RESTRICT restrict
#endif

/* IEEE double constants (the core includes no <float.h>) */
#define SQFFD__LA_EPS 2.220446049250313080847e-16        /* DBL_EPSILON */
#define SQFFD__LA_MIN_NORMAL 2.225073858507201383090e-308 /* DBL_MIN */

/* x . y with four partial sums: fixed summation order (deterministic) and
   enough independent additions to keep the FPU busy without -ffast-math. */
static double sqffd__la_dot(const double *x, const double *y, size_t n)
{
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    size_t k;
    for (k = 0; k + 4 <= n; k += 4) {
        s0 += x[k] * y[k];
        s1 += x[k + 1] * y[k + 1];
        s2 += x[k + 2] * y[k + 2];
        s3 += x[k + 3] * y[k + 3];
    }
    for (; k < n; ++k) s0 += x[k] * y[k];
    return (s0 + s1) + (s2 + s3);
}

/* y += alpha x. Unrolled by four like the rotation below: GCC's -O2
   vectoriser turns the four statements into one SIMD operation, while it
   leaves the plain loop (which would need a remainder loop) scalar. */
static void sqffd__la_axpy(double *SQFFD__LA_RESTRICT y, double alpha, const double *SQFFD__LA_RESTRICT x, size_t n)
{
    size_t k;
    for (k = 0; k + 4 <= n; k += 4) {
        y[k] += alpha * x[k];
        y[k + 1] += alpha * x[k + 1];
        y[k + 2] += alpha * x[k + 2];
        y[k + 3] += alpha * x[k + 3];
    }
    for (; k < n; ++k) y[k] += alpha * x[k];
}

/* ---- Cholesky ---- */

SQFFD_DEF sqffd_result sqffd_cholesky_factor(double *a, int n)
{
    size_t nn, i, j;
    if (!a || n < 1) return SQFFD_ERROR_INVALID_ARGUMENT;
    nn = (size_t)n;
    for (i = 0; i < nn; ++i)
        for (j = 0; j <= i; ++j)
            if (!isfinite(a[i * nn + j])) return SQFFD_ERROR_NON_FINITE;
    /* Row by row (Cholesky-Crout): L[i][j] = (A[i][j] - L[i][:j].L[j][:j]) / L[j][j];
       both dot operands are contiguous rows. */
    for (i = 0; i < nn; ++i) {
        double *li = a + i * nn;
        for (j = 0; j <= i; ++j) {
            const double *lj = a + j * nn;
            double sum = li[j] - sqffd__la_dot(li, lj, j);
            if (j < i) {
                li[j] = sum / lj[j];
            } else {
                if (!(sum > 0.0) || !isfinite(sum)) return SQFFD_ERROR_NOT_POSITIVE_DEFINITE;
                li[i] = sqrt(sum);
            }
        }
        for (j = i + 1; j < nn; ++j) li[j] = 0.0;
    }
    return SQFFD_OK;
}

SQFFD_DEF void sqffd_cholesky_solve(const double *l, int n, double *b)
{
    size_t nn = (size_t)n, i;
    SQFFD_ASSERT(l && b && n >= 1);
    for (i = 0; i < nn; ++i) /* L y = b */
        b[i] = (b[i] - sqffd__la_dot(l + i * nn, b, i)) / l[i * nn + i];
    for (i = nn; i-- > 0;) { /* L^T x = y, column-oriented so rows of L are read */
        const double *li = l + i * nn;
        double xi = b[i] / li[i];
        b[i] = xi;
        sqffd__la_axpy(b, -xi, li, i);
    }
}

/* ---- SVD: Householder QR with column pivoting, then one-sided Jacobi on R^T ----
   A P = Q R. Jacobi rotations J orthogonalise the columns of X = R^T:
   X J = U1 diag(s), so R = J diag(s) U1^T and A = (Q J) diag(s) (P U1)^T.
   U is Q applied to J, V is the normalised columns of X J with rows permuted
   back. R^T converges in a few sweeps (Drmac & Veselic), and the n x n
   Jacobi costs far less than working on the m x n matrix. */

typedef struct sqffd__la_svd_work {
    double *qr;     /* m x n row-major: R on and above the diagonal, reflectors below */
    double *x;      /* n x n, column j contiguous: the columns of X = R^T being rotated */
    double *rot;    /* n x n, column j contiguous: accumulated right rotations J */
    double *tau;    /* n Householder scalars */
    double *norm2;  /* n squared column norms (of the QR columns, then of X) */
    double *norm2_ref; /* n: norm2 when last computed exactly (QR pivoting) */
    double *tmp;    /* n */
    int *perm;      /* n: column k of A P is column perm[k] of A */
} sqffd__la_svd_work;

static void sqffd__la_svd_layout(sqffd__arena *ar, size_t m, size_t n, sqffd__la_svd_work *w)
{
    w->qr = (double *)sqffd__arena_take(ar, m * n, sizeof(double));
    w->x = (double *)sqffd__arena_take(ar, n * n, sizeof(double));
    w->rot = (double *)sqffd__arena_take(ar, n * n, sizeof(double));
    w->tau = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->norm2 = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->norm2_ref = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->tmp = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->perm = (int *)sqffd__arena_take(ar, n, sizeof(int));
}

SQFFD_DEF size_t sqffd_svd_workspace_size(int m, int n)
{
    sqffd__arena ar;
    sqffd__la_svd_work w;
    size_t mm = (size_t)m, nn = (size_t)n;
    if (n < 1 || m < n) return 0;
    if (mm > (size_t)-1 / nn) return 0;
    sqffd__arena_init(&ar, NULL, 0);
    sqffd__la_svd_layout(&ar, mm, nn, &w);
    return sqffd__arena_required(&ar);
}

/* (x, y) <- (c x - s y, s x + c y) in Rutishauser's form with
   tau = s / (1 + c), 1 - c = s tau: for the small angles of late sweeps c
   rounds to 1 and the plain form would grow every norm by ~s^2/2, a bias that
   thousands of rotations turn into ~1e-13 of lost orthogonality. */
static void sqffd__la_rotate(double *SQFFD__LA_RESTRICT x, double *SQFFD__LA_RESTRICT y, size_t n, double s, double tau)
{
    size_t k = 0, j;
    for (; k + 4 <= n; k += 4) {
        double xk[4], yk[4];
        for (j = 0; j < 4; ++j) { xk[j] = x[k + j]; yk[j] = y[k + j]; }
        for (j = 0; j < 4; ++j) {
            x[k + j] = xk[j] - s * (yk[j] + tau * xk[j]);
            y[k + j] = yk[j] + s * (xk[j] - tau * yk[j]);
        }
    }
    for (; k < n; ++k) {
        double xk = x[k], yk = y[k];
        x[k] = xk - s * (yk + tau * xk);
        y[k] = yk + s * (xk - tau * yk);
    }
}

static void sqffd__la_swap(double *x, double *y, size_t n)
{
    size_t k;
    for (k = 0; k < n; ++k) { double t = x[k]; x[k] = y[k]; y[k] = t; }
}

/* Squared norm of column j of the row-major qr over rows from..m-1. */
static double sqffd__la_column_norm2(const double *qr, size_t m, size_t n, size_t j, size_t from)
{
    double sum = 0.0;
    size_t i;
    for (i = from; i < m; ++i) sum += qr[i * n + j] * qr[i * n + j];
    return sum;
}

/* a <- H_k a on columns c0..n-1 of the row-major m x n `a`, with the
   reflector H_k = I - tau v v^T stored in column k of qr (v_k = 1, v_i =
   qr[i][k] below). Computed as w = tau a^T v, a -= v w^T, row by row, so
   every inner loop is a contiguous axpy. wrow: n scratch doubles. */
static void sqffd__la_reflect(const double *qr, double tau, size_t m, size_t n, size_t k, double *a, size_t c0,
                              double *wrow)
{
    size_t i, j, len = n - c0;
    double *w = wrow + c0;
    memcpy(w, a + k * n + c0, len * sizeof(double));
    for (i = k + 1; i < m; ++i) sqffd__la_axpy(w, qr[i * n + k], a + i * n + c0, len);
    for (j = 0; j < len; ++j) w[j] *= tau;
    sqffd__la_axpy(a + k * n + c0, -1.0, w, len);
    for (i = k + 1; i < m; ++i) sqffd__la_axpy(a + i * n + c0, -qr[i * n + k], w, len);
}

/* Householder QR with column pivoting of the row-major m x n w->qr, in place
   (LAPACK xGEQP3 conventions: H_k = I - tau v v^T, v_k = 1, v below the
   diagonal). */
static void sqffd__la_qr_pivoted(sqffd__la_svd_work *w, size_t m, size_t n)
{
    double *qr = w->qr, *vn = w->norm2, *vn_ref = w->norm2_ref;
    size_t i, j, k;
    for (j = 0; j < n; ++j) { vn[j] = 0.0; w->perm[j] = (int)j; }
    for (i = 0; i < m; ++i)
        for (j = 0; j < n; ++j) vn[j] += qr[i * n + j] * qr[i * n + j];
    for (j = 0; j < n; ++j) vn_ref[j] = vn[j];
    for (k = 0; k < n; ++k) {
        size_t p = k;
        double alpha, tau, amax;
        for (j = k + 1; j < n; ++j)
            if (vn[j] > vn[p]) p = j;
        if (p != k) {
            int t = w->perm[p]; w->perm[p] = w->perm[k]; w->perm[k] = t;
            for (i = 0; i < m; ++i) {
                double s = qr[i * n + p]; qr[i * n + p] = qr[i * n + k]; qr[i * n + k] = s;
            }
            vn[p] = vn[k]; vn_ref[p] = vn_ref[k];
        }
        /* The reflector is computed on the column scaled by a power of two
           (exact) into [0.5, 1): squares of tiny entries would lose digits to
           underflow, and an inexact norm makes H non-orthogonal. v and tau do
           not depend on the scale. Columns below 1e-300 (the matrix is
           scaled to max |a_ij| < 1) are left alone: H_k = I. */
        amax = 0.0;
        for (i = k; i < m; ++i) amax = fmax(amax, fabs(qr[i * n + k]));
        tau = 0.0;
        if (amax > 1e-300) {
            double f, xnorm2 = 0.0;
            int e;
            (void)frexp(amax, &e);
            f = ldexp(1.0, -e);
            alpha = qr[k * n + k] * f;
            for (i = k + 1; i < m; ++i) xnorm2 += (qr[i * n + k] * f) * (qr[i * n + k] * f);
            if (xnorm2 > 0.0) {
                double beta = -copysign(sqrt(alpha * alpha + xnorm2), alpha), scale = f / (alpha - beta);
                tau = (beta - alpha) / beta;
                for (i = k + 1; i < m; ++i) qr[i * n + k] *= scale;
                qr[k * n + k] = beta / f;
            }
        }
        w->tau[k] = tau;
        if (tau == 0.0 || k + 1 == n) continue;
        sqffd__la_reflect(qr, tau, m, n, k, qr, k + 1, w->tmp);
        /* downdate the remaining column norms; recompute when cancellation
           has eaten most of the digits (LAPACK working note 176) */
        for (j = k + 1; j < n; ++j) {
            double r, left;
            if (vn[j] == 0.0) continue;
            r = qr[k * n + j];
            left = vn[j] - r * r;
            if (left <= 1e-4 * vn_ref[j]) {
                vn[j] = vn_ref[j] = sqffd__la_column_norm2(qr, m, n, j, k + 1);
            } else {
                vn[j] = left;
            }
        }
    }
}

/* Swap columns p and q of the Jacobi state (X, J when accumulated, norms). */
static void sqffd__la_svd_swap(sqffd__la_svd_work *w, size_t n, size_t p, size_t q, int with_rot)
{
    double t = w->norm2[p];
    w->norm2[p] = w->norm2[q];
    w->norm2[q] = t;
    sqffd__la_swap(w->x + p * n, w->x + q * n, n);
    if (with_rot) sqffd__la_swap(w->rot + p * n, w->rot + q * n, n);
}

/* Cyclic one-sided Jacobi on the columns of w->x with de Rijk pivoting (the
   largest remaining column leads each row of the sweep). Columns whose
   squared norm is below `zero2` count as zero and are left alone. Returns 1
   when a sweep found every pair orthogonal:
   |x_p . x_q| <= eps sqrt(n) ||x_p|| ||x_q||. */
static int sqffd__la_jacobi_sweeps(sqffd__la_svd_work *w, size_t n, int with_rot, double zero2)
{
    const double tol = SQFFD__LA_EPS * sqrt((double)n);
    double *x = w->x, *norm2 = w->norm2;
    size_t p, q, j;
    int sweep;
    for (sweep = 0; sweep < 80; ++sweep) {
        int rotated = 0;
        for (j = 0; j < n; ++j) norm2[j] = sqffd__la_dot(x + j * n, x + j * n, n);
        for (p = 0; p + 1 < n; ++p) {
            size_t big = p;
            for (q = p + 1; q < n; ++q)
                if (norm2[q] > norm2[big]) big = q;
            if (big != p) sqffd__la_svd_swap(w, n, p, big, with_rot);
            for (q = p + 1; q < n; ++q) {
                double a = norm2[p], b = norm2[q], c, zeta, t, cs, sn, tau;
                if (a < zero2 || b < zero2) continue;
                c = sqffd__la_dot(x + p * n, x + q * n, n);
                if (fabs(c) <= tol * sqrt(a) * sqrt(b)) continue;
                rotated = 1;
                /* t = tan(angle): the smaller root of t^2 + 2 zeta t - 1 = 0 */
                zeta = (b - a) / (2.0 * c);
                if (fabs(zeta) > 1e150) t = 0.5 / zeta;
                else t = (zeta >= 0.0 ? 1.0 : -1.0) / (fabs(zeta) + sqrt(1.0 + zeta * zeta));
                cs = 1.0 / sqrt(1.0 + t * t);
                sn = cs * t;
                tau = sn / (1.0 + cs);
                sqffd__la_rotate(x + p * n, x + q * n, n, sn, tau);
                if (with_rot) sqffd__la_rotate(w->rot + p * n, w->rot + q * n, n, sn, tau);
                /* exact updates of the norms; recompute where they cancel */
                norm2[p] = a - t * c;
                norm2[q] = b + t * c;
                if (norm2[p] < 0.125 * a) norm2[p] = sqffd__la_dot(x + p * n, x + p * n, n);
                if (norm2[q] < 0.125 * b) norm2[q] = sqffd__la_dot(x + q * n, x + q * n, n);
            }
        }
        if (!rotated) return 1;
    }
    return 0;
}

/* Columns rank..n-1 of the n x n column-contiguous `basis` (the first `rank`
   orthonormal) are replaced by an orthonormal completion: each starts from
   the unit vector least represented in the span so far (smallest row norm)
   and is Gram-Schmidt orthogonalised twice. row2: n scratch doubles. */
static void sqffd__la_complete_basis(double *basis, size_t n, size_t rank, double *row2)
{
    size_t i, j, c, pass;
    for (i = 0; i < n; ++i) row2[i] = 0.0;
    for (c = 0; c < rank; ++c)
        for (i = 0; i < n; ++i) row2[i] += basis[c * n + i] * basis[c * n + i];
    for (j = rank; j < n; ++j) {
        double *col = basis + j * n, len;
        size_t best = 0;
        for (i = 1; i < n; ++i)
            if (row2[i] < row2[best]) best = i;
        for (i = 0; i < n; ++i) col[i] = i == best ? 1.0 : 0.0;
        for (pass = 0; pass < 2; ++pass)
            for (c = 0; c < j; ++c) {
                const double *other = basis + c * n;
                sqffd__la_axpy(col, -sqffd__la_dot(other, col, n), other, n);
            }
        len = sqrt(sqffd__la_dot(col, col, n));
        for (i = 0; i < n; ++i) { col[i] /= len; row2[i] += col[i] * col[i]; }
    }
}

SQFFD_DEF sqffd_result sqffd_svd(const double *a, int m, int n, double *u, double *s, double *v,
                                 void *workspace, size_t workspace_size)
{
    /* Jacobi columns of squared norm below DBL_MIN (norm < 1.5e-154 with the
       matrix scaled to max |a_ij| < 1) are zero: their dot products would
       underflow */
    const double zero2 = SQFFD__LA_MIN_NORMAL;
    sqffd__arena ar;
    sqffd__la_svd_work w;
    size_t mm, nn, i, j, k, rank, required;
    double amax = 0.0;
    int exponent = 0, converged;
    if (!a || !s || n < 1 || m < n) return SQFFD_ERROR_INVALID_ARGUMENT;
    mm = (size_t)m;
    nn = (size_t)n;
    required = sqffd_svd_workspace_size(m, n);
    if (required == 0) return SQFFD_ERROR_TOO_LARGE;
    if (!workspace) return SQFFD_ERROR_WORKSPACE_TOO_SMALL;
    sqffd__arena_init(&ar, workspace, workspace_size);
    sqffd__la_svd_layout(&ar, mm, nn, &w);
    if (ar.overflow) return SQFFD_ERROR_WORKSPACE_TOO_SMALL;
    for (i = 0; i < mm * nn; ++i) {
        if (!isfinite(a[i])) return SQFFD_ERROR_NON_FINITE;
        if (fabs(a[i]) > amax) amax = fabs(a[i]);
    }
    /* scale by a power of two (exact) so that norms can neither overflow nor underflow */
    if (amax > 0.0) (void)frexp(amax, &exponent);
    for (i = 0; i < mm * nn; ++i) w.qr[i] = ldexp(a[i], -exponent);

    sqffd__la_qr_pivoted(&w, mm, nn);
    for (j = 0; j < nn; ++j) /* column j of X = row j of R */
        for (i = 0; i < nn; ++i) w.x[j * nn + i] = i >= j ? w.qr[j * nn + i] : 0.0;
    if (u) {
        for (i = 0; i < nn * nn; ++i) w.rot[i] = 0.0;
        for (i = 0; i < nn; ++i) w.rot[i * nn + i] = 1.0;
    }
    converged = sqffd__la_jacobi_sweeps(&w, nn, u != NULL, zero2);

    /* exact norms, descending order, zero columns last */
    for (j = 0; j < nn; ++j) w.norm2[j] = sqffd__la_dot(w.x + j * nn, w.x + j * nn, nn);
    for (j = 0; j + 1 < nn; ++j) {
        size_t big = j;
        for (k = j + 1; k < nn; ++k)
            if (w.norm2[k] > w.norm2[big]) big = k;
        if (big != j) sqffd__la_svd_swap(&w, nn, j, big, u != NULL);
    }
    rank = 0;
    for (j = 0; j < nn; ++j) {
        double sj = w.norm2[j] < zero2 ? 0.0 : sqrt(w.norm2[j]);
        if (sj > 0.0) rank = j + 1;
        s[j] = ldexp(sj, exponent);
        w.tmp[j] = sj;
    }

    if (v) { /* V = P U1: normalise the nonzero columns of X, complete the rest */
        for (j = 0; j < rank; ++j)
            for (i = 0; i < nn; ++i) w.x[j * nn + i] /= w.tmp[j];
        sqffd__la_complete_basis(w.x, nn, rank, w.norm2);
        for (i = 0; i < nn; ++i)
            for (j = 0; j < nn; ++j) v[(size_t)w.perm[i] * nn + j] = w.x[j * nn + i];
    }
    if (u) { /* U = Q [J; 0], reflectors applied last to first, row by row */
        for (i = 0; i < mm; ++i)
            for (j = 0; j < nn; ++j) u[i * nn + j] = i < nn ? w.rot[j * nn + i] : 0.0;
        for (k = nn; k-- > 0;)
            if (w.tau[k] != 0.0) sqffd__la_reflect(w.qr, w.tau[k], mm, nn, k, u, 0, w.tmp);
    }
    return converged ? SQFFD_OK : SQFFD_ERROR_NO_CONVERGENCE;
}

SQFFD_DEF int sqffd_svd_solve(const double *u, const double *s, const double *v, int m, int n,
                              double rcond, const double *b, double *x, double *scratch)
{
    size_t mm = (size_t)m, nn = (size_t)n, i, j;
    int rank = 0;
    SQFFD_ASSERT(u && s && v && b && x && scratch && n >= 1 && m >= n);
    while (rank < n && s[rank] > 0.0 && s[rank] > rcond * s[0]) ++rank;
    /* scratch = diag(1/s) U^T b over the kept values, accumulated row by row */
    for (j = 0; j < nn; ++j) scratch[j] = 0.0;
    for (i = 0; i < mm; ++i) sqffd__la_axpy(scratch, b[i], u + i * nn, (size_t)rank);
    for (j = 0; j < (size_t)rank; ++j) scratch[j] /= s[j];
    for (i = 0; i < nn; ++i) x[i] = sqffd__la_dot(v + i * nn, scratch, (size_t)rank);
    return rank;
}

/* ---- Linear conjugate gradient ---- */

SQFFD_DEF sqffd_cg_options sqffd_cg_options_default(void)
{
    sqffd_cg_options o;
    o.max_iterations = 0;
    o.tolerance = 1e-10;
    o.jacobi_diagonal = NULL;
    return o;
}

typedef struct sqffd__la_cg_work {
    double *r, *z, *p, *q; /* residual, preconditioned residual, direction, A p */
} sqffd__la_cg_work;

static void sqffd__la_cg_layout(sqffd__arena *ar, size_t n, sqffd__la_cg_work *w)
{
    w->r = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->z = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->p = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->q = (double *)sqffd__arena_take(ar, n, sizeof(double));
}

SQFFD_DEF size_t sqffd_cg_workspace_size(int n)
{
    sqffd__arena ar;
    sqffd__la_cg_work w;
    if (n < 1) return 0;
    sqffd__arena_init(&ar, NULL, 0);
    sqffd__la_cg_layout(&ar, (size_t)n, &w);
    return sqffd__arena_required(&ar);
}

/* 1 when all n entries are finite */
static int sqffd__la_all_finite(const double *x, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i)
        if (!isfinite(x[i])) return 0;
    return 1;
}

/* z = M^-1 r with the Jacobi preconditioner M = diag (NULL: z = r) */
static void sqffd__la_precondition(const double *diag, const double *r, double *z, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) z[i] = diag ? r[i] / diag[i] : r[i];
}

SQFFD_DEF sqffd_result sqffd_cg_solve(int n, sqffd_matvec_fn matvec, void *user, const double *b, double *x,
                                      const sqffd_cg_options *options, int *iterations, double *relative_residual,
                                      void *workspace, size_t workspace_size)
{
    sqffd_cg_options opt = options ? *options : sqffd_cg_options_default();
    sqffd__arena ar;
    sqffd__la_cg_work w;
    sqffd_result result = SQFFD_OK;
    size_t nn, i, required;
    double bnorm, rnorm, rz;
    int it = 0, max_it;
    if (iterations) *iterations = 0;
    if (relative_residual) *relative_residual = 0.0;
    if (n < 1 || !matvec || !b || !x || opt.max_iterations < 0 || !(opt.tolerance >= 0.0))
        return SQFFD_ERROR_INVALID_ARGUMENT;
    nn = (size_t)n;
    required = sqffd_cg_workspace_size(n);
    if (required == 0) return SQFFD_ERROR_TOO_LARGE;
    if (!workspace) return SQFFD_ERROR_WORKSPACE_TOO_SMALL;
    sqffd__arena_init(&ar, workspace, workspace_size);
    sqffd__la_cg_layout(&ar, nn, &w);
    if (ar.overflow) return SQFFD_ERROR_WORKSPACE_TOO_SMALL;
    if (!sqffd__la_all_finite(b, nn) || !sqffd__la_all_finite(x, nn)) return SQFFD_ERROR_NON_FINITE;
    if (opt.jacobi_diagonal) {
        if (!sqffd__la_all_finite(opt.jacobi_diagonal, nn)) return SQFFD_ERROR_NON_FINITE;
        for (i = 0; i < nn; ++i)
            if (!(opt.jacobi_diagonal[i] > 0.0)) return SQFFD_ERROR_NOT_POSITIVE_DEFINITE;
    }
    max_it = opt.max_iterations > 0 ? opt.max_iterations : (n > 0x3fffffff ? 0x7fffffff : 2 * n);
    bnorm = sqrt(sqffd__la_dot(b, b, nn));
    if (bnorm == 0.0) { /* A x = 0 has the solution 0 */
        for (i = 0; i < nn; ++i) x[i] = 0.0;
        return SQFFD_OK;
    }
    matvec(user, x, w.q);
    for (i = 0; i < nn; ++i) w.r[i] = b[i] - w.q[i];
    rnorm = sqrt(sqffd__la_dot(w.r, w.r, nn));
    if (!isfinite(rnorm)) return SQFFD_ERROR_NON_FINITE;
    sqffd__la_precondition(opt.jacobi_diagonal, w.r, w.z, nn);
    memcpy(w.p, w.z, nn * sizeof(double));
    rz = sqffd__la_dot(w.r, w.z, nn);
    while (rnorm > opt.tolerance * bnorm) {
        double pq, alpha, rz_next, beta;
        if (it == max_it) { result = SQFFD_ERROR_NO_CONVERGENCE; break; }
        matvec(user, w.p, w.q);
        pq = sqffd__la_dot(w.p, w.q, nn);
        if (!isfinite(pq)) return SQFFD_ERROR_NON_FINITE;
        if (!(pq > 0.0)) return SQFFD_ERROR_NOT_POSITIVE_DEFINITE;
        alpha = rz / pq;
        sqffd__la_axpy(x, alpha, w.p, nn);
        sqffd__la_axpy(w.r, -alpha, w.q, nn);
        rnorm = sqrt(sqffd__la_dot(w.r, w.r, nn));
        ++it;
        sqffd__la_precondition(opt.jacobi_diagonal, w.r, w.z, nn);
        rz_next = sqffd__la_dot(w.r, w.z, nn);
        beta = rz_next / rz;
        rz = rz_next;
        for (i = 0; i < nn; ++i) w.p[i] = w.z[i] + beta * w.p[i];
    }
    if (iterations) *iterations = it;
    if (relative_residual) { /* the true residual, not the recurrence's */
        matvec(user, x, w.q);
        for (i = 0; i < nn; ++i) w.r[i] = b[i] - w.q[i];
        *relative_residual = sqrt(sqffd__la_dot(w.r, w.r, nn)) / bnorm;
    }
    return result;
}

/* ---- Nonlinear conjugate gradient ---- */

typedef struct sqffd__la_ncg_work {
    double *g;      /* gradient at x */
    double *gr;     /* reduced gradient: zero where the projection blocks descent */
    double *gr_old; /* previous reduced gradient (Polak-Ribiere) */
    double *d;      /* search direction */
    double *xu;     /* unprojected trial point x + t d */
    double *xt, *gt; /* trial point and its gradient */
    double *xb, *gb; /* best point of the line search that passed Armijo */
} sqffd__la_ncg_work;

static void sqffd__la_ncg_layout(sqffd__arena *ar, size_t n, sqffd__la_ncg_work *w)
{
    w->g = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->gr = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->gr_old = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->d = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->xu = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->xt = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->gt = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->xb = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->gb = (double *)sqffd__arena_take(ar, n, sizeof(double));
}

SQFFD_DEF size_t sqffd_ncg_workspace_size(int n)
{
    sqffd__arena ar;
    sqffd__la_ncg_work w;
    if (n < 1) return 0;
    sqffd__arena_init(&ar, NULL, 0);
    sqffd__la_ncg_layout(&ar, (size_t)n, &w);
    return sqffd__arena_required(&ar);
}

typedef struct sqffd__la_ncg_problem {
    size_t n;
    sqffd_objective_fn f;
    sqffd_project_fn project;
    void *user;
} sqffd__la_ncg_problem;

/* Reduced gradient at x: g where a projected gradient step can move,
   0 where the projection holds the coordinate (a bound blocking descent).
   Returns ||project(x - g) - x||_inf, the optimality measure. Uses xt. */
static double sqffd__la_ncg_reduce(const sqffd__la_ncg_problem *pr, const double *x, sqffd__la_ncg_work *w)
{
    double worst = 0.0;
    size_t i;
    for (i = 0; i < pr->n; ++i) w->xt[i] = x[i] - w->g[i];
    if (pr->project) pr->project(pr->user, w->xt);
    for (i = 0; i < pr->n; ++i) {
        double step = w->xt[i] - x[i];
        w->gr[i] = step == 0.0 ? 0.0 : w->g[i];
        if (fabs(step) > worst) worst = fabs(step);
    }
    return worst;
}

/* Strong-Wolfe line search along the projected path x(t) = project(x + t d).
   phi(t) = f(x(t)); phi'(t) is measured on the coordinates the projection
   left free. A trial point is acceptable when it passes Armijo,
   phi(t) <= phi(0) + c1 g.(x(t) - x), or - where f is flat to rounding and
   Armijo cannot tell - the approximate Wolfe test of Hager & Zhang
   (phi(t) <= phi(0) + 1e-10 |phi(0)| and phi'(t) <= (1 - 2 c1) |phi'(0)|).
   The search ends at an acceptable point with |phi'(t)| <= c2 |phi'(0)|.
   [a, b] brackets the minimiser: phi'(a) < 0 at an acceptable a; b is an
   unacceptable step or one with phi'(b) >= 0. Next trials come from the
   secant on phi' (exact on quadratics) or a quadratic fit of phi, kept
   inside the bracket; without b the step grows 1.1x to 10x.
   On success x, g, *fx hold the new point and *t the step; returns 0 when no
   step was acceptable. */
static int sqffd__la_ncg_line_search(const sqffd__la_ncg_problem *pr, double *x, double *fx, double *t,
                                     sqffd__la_ncg_work *w)
{
    const double c1 = 1e-4, c2 = 0.1;
    size_t n = pr->n, i;
    double dg0 = sqffd__la_dot(w->g, w->d, n), step = *t;
    double a = 0.0, fa = *fx, da = dg0, a_prev = 0.0, da_prev = dg0; /* lower end */
    double b = -1.0, fb = 0.0, db = 0.0;                             /* upper end, b < 0: none yet */
    double best_t = 0.0, best_f = 0.0;
    int eval, found = 0, b_has_slope = 0;
    for (eval = 0; eval < 40; ++eval) {
        double ft, slope = 0.0, dphi = 0.0, next;
        int moved = 0, acceptable;
        for (i = 0; i < n; ++i) w->xu[i] = w->xt[i] = x[i] + step * w->d[i];
        if (pr->project) pr->project(pr->user, w->xt);
        for (i = 0; i < n; ++i) {
            slope += w->g[i] * (w->xt[i] - x[i]);
            if (w->xt[i] != x[i]) moved = 1;
        }
        if (!moved) break; /* the step vanished below the resolution of x */
        ft = pr->f(pr->user, w->xt, w->gt);
        for (i = 0; i < n; ++i)
            if (w->xt[i] == w->xu[i]) dphi += w->gt[i] * w->d[i];
        acceptable = isfinite(ft) && isfinite(dphi) && slope < 0.0 &&
                     (ft <= *fx + c1 * slope || (ft <= *fx + 1e-10 * fabs(*fx) && dphi <= -(1.0 - 2.0 * c1) * dg0));
        if (acceptable && (!found || ft <= best_f)) {
            memcpy(w->xb, w->xt, n * sizeof(double));
            memcpy(w->gb, w->gt, n * sizeof(double));
            best_t = step;
            best_f = ft;
            found = 1;
            if (fabs(dphi) <= -c2 * dg0) break;
        }
        if (acceptable && dphi < 0.0) {
            a_prev = a; da_prev = da;
            a = step; fa = ft; da = dphi;
        } else {
            b = step;
            fb = ft;
            db = dphi;
            b_has_slope = acceptable;
        }
        if (b < 0.0) { /* extrapolate: secant on phi' when it is rising, else x10 */
            next = da > da_prev ? a - da * (a - a_prev) / (da - da_prev) : 10.0 * a;
            if (!(next >= 1.1 * a)) next = 1.1 * a;
            if (next > 10.0 * a) next = 10.0 * a;
        } else {
            double width = b - a;
            if (b_has_slope) next = a - da * width / (db - da);
            else next = a - da * width * width / (2.0 * (fb - fa - da * width));
            if (!isfinite(next) || !(next >= a + 0.05 * width) || !(next <= b - 0.05 * width))
                next = a + 0.5 * width;
        }
        step = next;
    }
    if (!found) return 0;
    memcpy(x, w->xb, n * sizeof(double));
    memcpy(w->g, w->gb, n * sizeof(double));
    *fx = best_f;
    *t = best_t;
    return 1;
}

SQFFD_DEF sqffd_result sqffd_ncg_minimize(int n, sqffd_objective_fn f, sqffd_project_fn project, void *user, double *x,
                                          int max_iterations, double tolerance, int *iterations, double *fx,
                                          sqffd_progress_fn progress, void *progress_user,
                                          void *workspace, size_t workspace_size)
{
    sqffd__arena ar;
    sqffd__la_ncg_work w;
    sqffd__la_ncg_problem pr;
    sqffd_result result = SQFFD_ERROR_NO_CONVERGENCE;
    size_t nn, i, required;
    double value, step = 0.0, gd_old = 0.0;
    int it, since_restart = 0;
    if (iterations) *iterations = 0;
    if (n < 1 || !f || !x || max_iterations < 1 || !(tolerance >= 0.0)) return SQFFD_ERROR_INVALID_ARGUMENT;
    nn = (size_t)n;
    required = sqffd_ncg_workspace_size(n);
    if (required == 0) return SQFFD_ERROR_TOO_LARGE;
    if (!workspace) return SQFFD_ERROR_WORKSPACE_TOO_SMALL;
    sqffd__arena_init(&ar, workspace, workspace_size);
    sqffd__la_ncg_layout(&ar, nn, &w);
    if (ar.overflow) return SQFFD_ERROR_WORKSPACE_TOO_SMALL;
    if (!sqffd__la_all_finite(x, nn)) return SQFFD_ERROR_NON_FINITE;
    pr.n = nn; pr.f = f; pr.project = project; pr.user = user;
    if (project) project(user, x);
    value = f(user, x, w.g);
    if (fx) *fx = value;
    if (!isfinite(value) || !sqffd__la_all_finite(w.g, nn)) return SQFFD_ERROR_NON_FINITE;
    for (it = 0; it < max_iterations; ++it) {
        double gd, pgnorm = sqffd__la_ncg_reduce(&pr, x, &w);
        if (pgnorm <= tolerance * (1.0 + fabs(value))) { result = SQFFD_OK; break; }
        /* Polak-Ribiere+ on the reduced gradients, steepest descent on restart */
        if (since_restart > 0 && since_restart < n) {
            double num = 0.0, den = sqffd__la_dot(w.gr_old, w.gr_old, nn), beta;
            for (i = 0; i < nn; ++i) num += w.gr[i] * (w.gr[i] - w.gr_old[i]);
            beta = den > 0.0 && num > 0.0 ? num / den : 0.0;
            for (i = 0; i < nn; ++i) w.d[i] = -w.gr[i] + beta * w.d[i];
        } else {
            for (i = 0; i < nn; ++i) w.d[i] = -w.gr[i];
            since_restart = 0;
        }
        gd = sqffd__la_dot(w.g, w.d, nn);
        if (!(gd < 0.0)) { /* lost descent: restart */
            for (i = 0; i < nn; ++i) w.d[i] = -w.gr[i];
            gd = -sqffd__la_dot(w.gr, w.gr, nn);
            since_restart = 0;
        }
        /* first trial step: a unit move in x at the start, then the step that
           repeats the last decrease predicted by the slope (Nocedal & Wright 3.5) */
        if (step > 0.0) step = step * gd_old / gd;
        if (!(step > 0.0) || !isfinite(step)) step = 1.0 / sqrt(sqffd__la_dot(w.d, w.d, nn));
        memcpy(w.gr_old, w.gr, nn * sizeof(double));
        gd_old = gd;
        if (!sqffd__la_ncg_line_search(&pr, x, &value, &step, &w)) {
            if (since_restart == 0) { result = SQFFD_OK; break; } /* no decrease possible */
            since_restart = 0; /* retry along steepest descent */
            step = 0.0;
            continue;
        }
        ++since_restart;
        if (fx) *fx = value;
        if (iterations) *iterations = it + 1;
        if (progress && progress(progress_user, SQFFD_STAGE_SUPERQUADRIC, it + 1, value)) {
            result = SQFFD_ERROR_CANCELLED;
            break;
        }
    }
    if (fx) *fx = value;
    return result;
}

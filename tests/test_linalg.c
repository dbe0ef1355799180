/* Linear algebra layer: every result is checked against ground truth built
   independently (residuals, known factors, normal equations). */
#include "test.h"
#include "../examples/sqffd_synth.h"
#include <stdlib.h>
#include <string.h>

/* ---- helpers ---- */

static synth_rng la_state;

static void la_seed(unsigned long long s) { la_state = synth_rng_seed(s); }

/* uniform in [-1, 1) */
static double la_rand(void) { return synth_range(&la_state, -1.0, 1.0); }

static double *la_alloc(size_t count)
{
    double *p = (double *)malloc(count * sizeof(double) + 1);
    if (!p) { fprintf(stderr, "out of memory\n"); exit(1); }
    return p;
}

/* C = A (m x k) * B (k x n), all row-major */
static void la_matmul(const double *a, const double *b, double *c, int m, int k, int n)
{
    int i, j, l;
    for (i = 0; i < m; ++i)
        for (j = 0; j < n; ++j) {
            long double sum = 0.0L;
            for (l = 0; l < k; ++l) sum += (long double)a[i * k + l] * b[l * n + j];
            c[i * n + j] = (double)sum;
        }
}

/* max |Q^T Q - I| over the n columns of the m x n row-major Q */
static double la_orthogonality(const double *q, int m, int n)
{
    double worst = 0.0;
    int i, j, r;
    for (i = 0; i < n; ++i)
        for (j = i; j < n; ++j) {
            long double sum = 0.0L;
            double e;
            for (r = 0; r < m; ++r) sum += (long double)q[r * n + i] * q[r * n + j];
            e = fabs((double)sum - (i == j ? 1.0 : 0.0));
            if (e > worst) worst = e;
        }
    return worst;
}

/* Random orthogonal n x n matrix: Gram-Schmidt (twice) on random columns. */
static void la_random_orthogonal(double *q, int n)
{
    int i, j, r, pass;
    for (i = 0; i < n * n; ++i) q[i] = la_rand();
    for (j = 0; j < n; ++j) {
        double norm = 0.0;
        for (pass = 0; pass < 2; ++pass)
            for (i = 0; i < j; ++i) {
                double d = 0.0;
                for (r = 0; r < n; ++r) d += q[r * n + i] * q[r * n + j];
                for (r = 0; r < n; ++r) q[r * n + j] -= d * q[r * n + i];
            }
        for (r = 0; r < n; ++r) norm += q[r * n + j] * q[r * n + j];
        norm = sqrt(norm);
        for (r = 0; r < n; ++r) q[r * n + j] /= norm;
    }
}

/* ---- symmetric 3x3 eigen ---- */

/* Checks A v_i = l_i v_i, orthonormality, det = +1, ascending order. */
static void la_check_eigen3(const double a[9], const double expect[3])
{
    double values[3], vec[9], col[3], av[3], cr[3], scale = 0.0;
    int i, k;
    sqffd_sym3_eigen(a, values, vec);
    for (i = 0; i < 9; ++i) scale = fmax(scale, fabs(a[i]));
    if (scale == 0.0) scale = 1.0;
    CHECK(values[0] <= values[1] && values[1] <= values[2]);
    for (i = 0; i < 3; ++i) {
        double res = 0.0;
        for (k = 0; k < 3; ++k) col[k] = vec[3 * k + i];
        av[0] = a[0] * col[0] + a[1] * col[1] + a[2] * col[2];
        av[1] = a[3] * col[0] + a[4] * col[1] + a[5] * col[2];
        av[2] = a[6] * col[0] + a[7] * col[1] + a[8] * col[2];
        for (k = 0; k < 3; ++k) res = fmax(res, fabs(av[k] - values[i] * col[k]));
        CHECK_MSG(res <= 1e-13 * scale, "eigenpair %d residual %.3g", i, res);
        if (expect) CHECK_NEAR(values[i], expect[i], 1e-13 * scale);
    }
    CHECK(la_orthogonality(vec, 3, 3) <= 1e-14);
    { /* det = col0 . (col1 x col2) */
        double c0[3], c1[3], c2[3];
        for (k = 0; k < 3; ++k) { c0[k] = vec[3 * k]; c1[k] = vec[3 * k + 1]; c2[k] = vec[3 * k + 2]; }
        cr[0] = c1[1] * c2[2] - c1[2] * c2[1];
        cr[1] = c1[2] * c2[0] - c1[0] * c2[2];
        cr[2] = c1[0] * c2[1] - c1[1] * c2[0];
        CHECK_NEAR(c0[0] * cr[0] + c0[1] * cr[1] + c0[2] * cr[2], 1.0, 1e-14);
    }
}

/* A = R diag(d) R^T with a random rotation R (into r). */
static void la_rotated_diag(const double d[3], double a[9], double r[9])
{
    double rd[9], rt[9];
    int i, j;
    la_random_orthogonal(r, 3);
    for (i = 0; i < 3; ++i)
        for (j = 0; j < 3; ++j) { rd[3 * i + j] = r[3 * i + j] * d[j]; rt[3 * i + j] = r[3 * j + i]; }
    la_matmul(rd, rt, a, 3, 3, 3);
    for (i = 0; i < 3; ++i) /* exactly symmetric */
        for (j = 0; j < i; ++j) a[3 * i + j] = a[3 * j + i];
}

static void test_sym3_eigen_random(void)
{
    int t, i, j;
    la_seed(1);
    for (t = 0; t < 2000; ++t) {
        double a[9];
        for (i = 0; i < 3; ++i)
            for (j = i; j < 3; ++j) a[3 * i + j] = a[3 * j + i] = la_rand() * (t % 7 == 0 ? 1e6 : 1.0);
        la_check_eigen3(a, NULL);
    }
}

static void test_sym3_eigen_known(void)
{
    static const double diag[9] = {3, 0, 0, 0, -1, 0, 0, 0, 2};
    static const double diag_expect[3] = {-1, 2, 3};
    static const double zero[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    static const double zero_expect[3] = {0, 0, 0};
    static const double ident[9] = {5, 0, 0, 0, 5, 0, 0, 0, 5};
    static const double ident_expect[3] = {5, 5, 5};
    static const double d112[3] = {1, 1, 2}, d122[3] = {1, 2, 2}, d777[3] = {7, 7, 7};
    static const double dtiny[3] = {1e-12, 1, 1 + 1e-12};
    double a[9], r[9], values[3], vec[9];
    int t;
    la_check_eigen3(diag, diag_expect);
    sqffd_sym3_eigen(diag, values, vec); /* diagonal: axis vectors, sign convention */
    CHECK(vec[3 * 1 + 0] == 1.0 && vec[3 * 2 + 1] == 1.0 && vec[3 * 0 + 2] == 1.0);
    la_check_eigen3(zero, zero_expect);
    la_check_eigen3(ident, ident_expect);
    la_seed(2);
    for (t = 0; t < 200; ++t) { /* double and triple eigenvalues in random bases */
        la_rotated_diag(d112, a, r); la_check_eigen3(a, d112);
        la_rotated_diag(d122, a, r); la_check_eigen3(a, d122);
        la_rotated_diag(d777, a, r); la_check_eigen3(a, d777);
        la_rotated_diag(dtiny, a, r); la_check_eigen3(a, dtiny);
    }
    { /* rotated diag(1,1,2): the simple eigenvector is the rotated axis */
        la_rotated_diag(d112, a, r);
        sqffd_sym3_eigen(a, values, vec);
        CHECK_NEAR(fabs(vec[2] * r[2] + vec[5] * r[5] + vec[8] * r[8]), 1.0, 1e-13);
    }
}

/* ---- Cholesky ---- */

/* Random SPD n x n: B B^T + n I */
static void la_random_spd(double *a, int n)
{
    double *b = la_alloc((size_t)n * (size_t)n);
    int i, j, k;
    for (i = 0; i < n * n; ++i) b[i] = la_rand();
    for (i = 0; i < n; ++i)
        for (j = 0; j <= i; ++j) {
            double sum = 0.0;
            for (k = 0; k < n; ++k) sum += b[i * n + k] * b[j * n + k];
            a[i * n + j] = a[j * n + i] = sum + (i == j ? (double)n : 0.0);
        }
    free(b);
}

static void test_cholesky_known(void)
{
    /* A = L L^T with L = [[2,0,0],[6,1,0],[-8,5,3]] */
    double a[9] = {4, 12, -16, 12, 37, -43, -16, -43, 98};
    static const double l[9] = {2, 0, 0, 6, 1, 0, -8, 5, 3};
    double b[3] = {-20, -74, 96 + 47}; /* A (1, 2, ...) below */
    double x_true[3] = {1, -2, 0.5}, bb[3];
    int i;
    CHECK_RESULT(sqffd_cholesky_factor(a, 3), SQFFD_OK);
    for (i = 0; i < 9; ++i) CHECK_NEAR(a[i], l[i], 1e-15);
    bb[0] = 4 * x_true[0] + 12 * x_true[1] - 16 * x_true[2];
    bb[1] = 12 * x_true[0] + 37 * x_true[1] - 43 * x_true[2];
    bb[2] = -16 * x_true[0] - 43 * x_true[1] + 98 * x_true[2];
    memcpy(b, bb, sizeof b);
    CHECK_RESULT(sqffd_cholesky_solve(a, 3, b), SQFFD_OK);
    for (i = 0; i < 3; ++i) CHECK_NEAR(b[i], x_true[i], 1e-13);
}

static void test_cholesky_random(void)
{
    static const int sizes[4] = {1, 7, 64, 125};
    int t, i, j;
    la_seed(3);
    for (t = 0; t < 4; ++t) {
        int n = sizes[t];
        double *a = la_alloc((size_t)(n * n)), *l = la_alloc((size_t)(n * n));
        double *x = la_alloc((size_t)n), *b = la_alloc((size_t)n);
        la_random_spd(a, n);
        memcpy(l, a, (size_t)(n * n) * sizeof(double));
        for (i = 0; i < n; ++i)
            for (j = i + 1; j < n; ++j) l[i * n + j] = 12345.0; /* upper triangle is not read */
        for (i = 0; i < n; ++i) x[i] = la_rand();
        for (i = 0; i < n; ++i) {
            b[i] = 0.0;
            for (j = 0; j < n; ++j) b[i] += a[i * n + j] * x[j];
        }
        CHECK_RESULT(sqffd_cholesky_factor(l, n), SQFFD_OK);
        for (i = 0; i < n; ++i)
            for (j = i + 1; j < n; ++j) CHECK(l[i * n + j] == 0.0);
        CHECK_RESULT(sqffd_cholesky_solve(l, n, b), SQFFD_OK);
        for (i = 0; i < n; ++i) CHECK_NEAR(b[i], x[i], 1e-12);
        free(a); free(l); free(x); free(b);
    }
}

static void test_cholesky_errors(void)
{
    double indef[4] = {1, 2, 2, 1}; /* eigenvalues 3, -1 */
    double singular[4] = {1, 1, 1, 1};
    double neg[1] = {-1};
    double nan_m[4] = {1, 0, 0, 1};
    double inf_m[4] = {1, 0, 0, 1};
    nan_m[2] = nan("");
    inf_m[3] = HUGE_VAL;
    CHECK_RESULT(sqffd_cholesky_factor(indef, 2), SQFFD_ERROR_NOT_POSITIVE_DEFINITE);
    CHECK_RESULT(sqffd_cholesky_factor(singular, 2), SQFFD_ERROR_NOT_POSITIVE_DEFINITE);
    CHECK_RESULT(sqffd_cholesky_factor(neg, 1), SQFFD_ERROR_NOT_POSITIVE_DEFINITE);
    CHECK_RESULT(sqffd_cholesky_factor(nan_m, 2), SQFFD_ERROR_NON_FINITE);
    CHECK_RESULT(sqffd_cholesky_factor(inf_m, 2), SQFFD_ERROR_NON_FINITE);
    CHECK_RESULT(sqffd_cholesky_factor(NULL, 2), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_cholesky_factor(indef, 0), SQFFD_ERROR_INVALID_ARGUMENT);
    /* the solve refuses the same arguments, b untouched */
    {
        double l[4] = {2, 0, 1, 3}, b[2] = {5, 7};
        CHECK_RESULT(sqffd_cholesky_solve(NULL, 2, b), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_cholesky_solve(l, 2, NULL), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_cholesky_solve(l, 0, b), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK(b[0] == 5 && b[1] == 7);
    }
}

/* ---- SVD ---- */

/* Workspace in a larger buffer with canary bytes after the given size. */
#define LA_CANARY 64
static unsigned char *la_workspace(size_t size)
{
    unsigned char *w = (unsigned char *)malloc(size + LA_CANARY);
    if (!w) { fprintf(stderr, "out of memory\n"); exit(1); }
    memset(w + size, 0xA5, LA_CANARY);
    return w;
}

static int la_canary_intact(const unsigned char *w, size_t size)
{
    size_t i;
    for (i = 0; i < LA_CANARY; ++i)
        if (w[size + i] != 0xA5) return 0;
    return 1;
}

/* Runs sqffd_svd and checks reconstruction, orthogonality, order; the
   singular values go to s_out (n entries) when not NULL. */
static void la_check_svd(const double *a, int m, int n, double *s_out)
{
    size_t size = 0;
    unsigned char *work;
    double *u = la_alloc((size_t)m * (size_t)n), *s = la_alloc((size_t)n), *v = la_alloc((size_t)n * (size_t)n);
    double *s2 = la_alloc((size_t)n);
    double err = 0.0, norm = 0.0, scale = 0.0;
    int i, j, k;
    CHECK_RESULT(sqffd_svd_workspace_size((size_t)m, (size_t)n, &size), SQFFD_OK);
    work = la_workspace(size);
    CHECK(size > 0);
    CHECK_RESULT(sqffd_svd(a, m, n, u, s, v, work, size), SQFFD_OK);
    CHECK(la_canary_intact(work, size));
    /* in units of max |a_ij|, so matrices near the ends of the double range square safely */
    for (i = 0; i < m * n; ++i) scale = fabs(a[i]) > scale ? fabs(a[i]) : scale;
    if (scale == 0.0) scale = 1.0; /* the zero matrix */
    for (i = 0; i < m; ++i)
        for (j = 0; j < n; ++j) {
            double sum = 0.0, d;
            for (k = 0; k < n; ++k) sum += (u[i * n + k] * (s[k] / scale)) * v[j * n + k];
            d = sum - a[i * n + j] / scale;
            err += d * d;
            norm += (a[i * n + j] / scale) * (a[i * n + j] / scale);
        }
    if (norm > 0.0) CHECK_MSG(sqrt(err / norm) <= 1e-13, "%dx%d reconstruction %.3g", m, n, sqrt(err / norm));
    else CHECK(err == 0.0);
    CHECK_MSG(la_orthogonality(u, m, n) <= 1e-13, "%dx%d U orthogonality %.3g", m, n, la_orthogonality(u, m, n));
    CHECK_MSG(la_orthogonality(v, n, n) <= 1e-13, "%dx%d V orthogonality %.3g", m, n, la_orthogonality(v, n, n));
    for (k = 0; k < n; ++k) CHECK(s[k] >= 0.0 && (k == 0 || s[k] <= s[k - 1]));
    /* U or V left out: the rest is bit for bit the same */
    CHECK_RESULT(sqffd_svd(a, m, n, NULL, s2, NULL, work, size), SQFFD_OK);
    CHECK(memcmp(s, s2, (size_t)n * sizeof(double)) == 0);
    {
        double *u2 = la_alloc((size_t)m * (size_t)n), *v2 = la_alloc((size_t)n * (size_t)n);
        CHECK_RESULT(sqffd_svd(a, m, n, u2, s2, NULL, work, size), SQFFD_OK);
        CHECK(memcmp(u, u2, (size_t)m * (size_t)n * sizeof(double)) == 0);
        CHECK_RESULT(sqffd_svd(a, m, n, NULL, s2, v2, work, size), SQFFD_OK);
        CHECK(memcmp(v, v2, (size_t)n * (size_t)n * sizeof(double)) == 0);
        free(u2); free(v2);
    }
    if (s_out) memcpy(s_out, s, (size_t)n * sizeof(double));
    free(work); free(u); free(s); free(v); free(s2);
}

static void la_fill_random(double *a, size_t count)
{
    size_t i;
    for (i = 0; i < count; ++i) a[i] = la_rand();
}

static void test_svd_random(void)
{
    static const int dims[][2] = {{1, 1}, {5, 1}, {2, 2}, {7, 7}, {30, 20}, {64, 63}, {200, 17}, {125, 125}};
    size_t t;
    la_seed(10);
    for (t = 0; t < sizeof dims / sizeof dims[0]; ++t) {
        int m = dims[t][0], n = dims[t][1];
        double *a = la_alloc((size_t)(m * n));
        la_fill_random(a, (size_t)(m * n));
        la_check_svd(a, m, n, NULL);
        free(a);
    }
}

/* A = U0 diag(s0) V0^T with random orthogonal factors: the values come back. */
static void test_svd_known_values(void)
{
    const int m = 60, n = 40;
    double *q = la_alloc((size_t)(m * m)), *v0 = la_alloc((size_t)(n * n)), *us = la_alloc((size_t)(m * n));
    double *vt = la_alloc((size_t)(n * n)), *a = la_alloc((size_t)(m * n)), s0[40], s[40];
    int i, j;
    la_seed(11);
    la_random_orthogonal(q, m);
    la_random_orthogonal(v0, n);
    for (j = 0; j < n; ++j) s0[j] = pow(10.0, -8.0 * j / (n - 1)); /* 1 .. 1e-8 */
    for (i = 0; i < m; ++i)
        for (j = 0; j < n; ++j) us[i * n + j] = q[i * m + j] * s0[j];
    for (i = 0; i < n; ++i)
        for (j = 0; j < n; ++j) vt[i * n + j] = v0[j * n + i];
    la_matmul(us, vt, a, m, n, n);
    la_check_svd(a, m, n, s);
    for (j = 0; j < n; ++j) CHECK_MSG(fabs(s[j] - s0[j]) <= 1e-14, "s[%d] = %.17g, expected %.17g", j, s[j], s0[j]);
    /* scaled far from 1: the same values scaled */
    for (i = 0; i < m * n; ++i) a[i] *= 1e250;
    la_check_svd(a, m, n, s);
    for (j = 0; j < n; ++j) CHECK(fabs(s[j] / 1e250 - s0[j]) <= 1e-14);
    free(q); free(v0); free(us); free(vt); free(a);
}

static void test_svd_rank_deficient(void)
{
    const int m = 40, n = 12, r = 5;
    double *b = la_alloc((size_t)(m * r)), *c = la_alloc((size_t)(r * n)), *a = la_alloc((size_t)(m * n)), s[12];
    int i, j;
    la_seed(12);
    la_fill_random(b, (size_t)(m * r));
    la_fill_random(c, (size_t)(r * n));
    la_matmul(b, c, a, m, r, n); /* rank 5 */
    la_check_svd(a, m, n, s);
    for (j = r; j < n; ++j) CHECK(s[j] <= 1e-14 * s[0]);
    CHECK(s[r - 1] > 1e-3 * s[0]);
    /* zero columns (unreached lattice regions) and a duplicated column */
    la_fill_random(a, (size_t)(m * n));
    for (i = 0; i < m; ++i) { a[i * n + 3] = 0.0; a[i * n + 7] = 0.0; a[i * n + 9] = a[i * n + 1]; }
    la_check_svd(a, m, n, s);
    CHECK(s[n - 1] == 0.0 && s[n - 2] == 0.0);
    CHECK(s[n - 3] <= 1e-14 * s[0] && s[n - 4] > 1e-3 * s[0]);
    /* all zero: U, V still orthonormal, s = 0 */
    memset(a, 0, (size_t)(m * n) * sizeof(double));
    la_check_svd(a, m, n, s);
    for (j = 0; j < n; ++j) CHECK(s[j] == 0.0);
    /* one nonzero entry */
    a[17 * n + 5] = -3.0;
    la_check_svd(a, m, n, s);
    CHECK(s[0] == 3.0 && s[1] == 0.0);
    free(b); free(c); free(a);
}

/* The FFD use: a tall matrix whose lattice columns are partly unreached
   (zero) and partly nearly dependent. */
static void test_svd_lattice_like(void)
{
    const int m = 300, n = 125;
    double *a = la_alloc((size_t)(m * n)), *s = la_alloc((size_t)n);
    int i, j, zeros = 0;
    la_seed(15);
    for (i = 0; i < m; ++i)
        for (j = 0; j < n; ++j) a[i * n + j] = (j % 3 == 0) ? 0.0 : la_rand() * la_rand();
    for (j = 0; j < n; ++j) zeros += j % 3 == 0;
    for (i = 0; i < m; ++i) a[i * n + 4] = a[i * n + 5] + 1e-9 * la_rand(); /* s_min ~ 1e-9 sqrt(m / 6) */
    la_check_svd(a, m, n, s);
    for (j = 0; j < n; ++j) CHECK((j < n - zeros) == (s[j] > 0.0));
    CHECK_MSG(s[n - zeros - 1] < 1e-8 && s[n - zeros - 1] > 1e-11, "smallest nonzero %g", s[n - zeros - 1]);
    free(a); free(s);
}

/* Extreme magnitudes: the power-of-two scaling keeps every value exact. */
static void test_svd_scaling(void)
{
    const int m = 20, n = 6;
    double a[120], b[120], s[6], s_ref[6], u[120], v[36], u2[120], v2[36], s2[6];
    size_t size = 0;
    unsigned char *work;
    int i, j;
    CHECK_RESULT(sqffd_svd_workspace_size((size_t)m, (size_t)n, &size), SQFFD_OK);
    work = la_workspace(size);
    la_seed(16);
    la_fill_random(a, 120);
    la_check_svd(a, m, n, s_ref);
    for (i = 0; i < 120; ++i) b[i] = ldexp(a[i], -1000); /* ~1e-301, exact */
    la_check_svd(b, m, n, s);
    for (j = 0; j < n; ++j) CHECK(s[j] == ldexp(s_ref[j], -1000));
    for (i = 0; i < 120; ++i) b[i] = ldexp(a[i], 1000);
    la_check_svd(b, m, n, s);
    for (j = 0; j < n; ++j) CHECK(s[j] == ldexp(s_ref[j], 1000));
    /* graded columns 1, 1e-40, ..., 1e-200: the ones below 1e-154 count as
       zero, U and V stay orthonormal */
    for (i = 0; i < m; ++i)
        for (j = 0; j < n; ++j) b[i * n + j] = a[i * n + j] * pow(1e-40, j);
    la_check_svd(b, m, n, s);
    CHECK(s[3] > 0.0 && s[4] == 0.0 && s[5] == 0.0);
    { /* graded 1 .. 1e-125: high relative accuracy of the tiny values, checked
         through prod s_j = sqrt(det(A^T A)) = sqrt(det(B^T B)) prod d_j */
        double btb[36], log_det = 0.0, log_s = 0.0;
        int k;
        for (i = 0; i < m; ++i)
            for (j = 0; j < n; ++j) b[i * n + j] = a[i * n + j] * pow(1e-25, j);
        la_check_svd(b, m, n, s);
        for (i = 0; i < n; ++i)
            for (j = 0; j < n; ++j) {
                btb[i * n + j] = 0.0;
                for (k = 0; k < m; ++k) btb[i * n + j] += a[k * n + i] * a[k * n + j];
            }
        CHECK_RESULT(sqffd_cholesky_factor(btb, n), SQFFD_OK);
        for (j = 0; j < n; ++j) {
            log_det += log(btb[j * n + j]) + log(pow(1e-25, j));
            log_s += log(s[j]);
        }
        CHECK_NEAR(log_s, log_det, 1e-12);
        for (j = 0; j < n; ++j) CHECK(s[j] > 1e-2 * pow(1e-25, j) && s[j] < 1e1 * pow(1e-25, j));
    }
    /* deterministic: bit-identical on a second run */
    CHECK_RESULT(sqffd_svd(a, m, n, u, s, v, work, size), SQFFD_OK);
    CHECK_RESULT(sqffd_svd(a, m, n, u2, s2, v2, work, size), SQFFD_OK);
    CHECK(memcmp(u, u2, sizeof u) == 0 && memcmp(s, s2, sizeof s) == 0 && memcmp(v, v2, sizeof v) == 0);
    free(work);
}

static void test_svd_hilbert(void)
{
    double a[100], s[10];
    int i, j;
    for (i = 0; i < 10; ++i)
        for (j = 0; j < 10; ++j) a[i * 10 + j] = 1.0 / (i + j + 1);
    la_check_svd(a, 10, 10, s);
    CHECK_NEAR(s[0], 1.7519196702651775, 1e-14); /* largest singular value of hilb(10) */
    CHECK(s[9] > 1e-14 && s[9] < 1e-12);          /* 1.0931e-13, resolved from the noise */
}

static void test_svd_solve(void)
{
    const int m = 50, n = 8;
    double *a = la_alloc((size_t)(m * n)), *u = la_alloc((size_t)(m * n)), s[8], v[64], b[50], x[8];
    double ata[64], atb[8];
    size_t size = 0, solve_size = 0, rank;
    unsigned char *work, *solve_work;
    int i, j, k;
    CHECK_RESULT(sqffd_svd_workspace_size((size_t)m, (size_t)n, &size), SQFFD_OK);
    CHECK_RESULT(sqffd_svd_solve_workspace_size((size_t)n, &solve_size), SQFFD_OK);
    CHECK(solve_size > 0);
    work = la_workspace(size);
    solve_work = la_workspace(solve_size);
    la_seed(13);
    la_fill_random(a, (size_t)(m * n));
    for (i = 0; i < m; ++i) b[i] = la_rand();
    CHECK_RESULT(sqffd_svd(a, m, n, u, s, v, work, size), SQFFD_OK);
    rank = 99;
    CHECK_RESULT(sqffd_svd_solve(u, s, v, m, n, 1e-12, b, x, &rank, solve_work, solve_size), SQFFD_OK);
    CHECK(rank == (size_t)n);
    CHECK(la_canary_intact(solve_work, solve_size));
    /* least squares = normal equations A^T A x = A^T b (Cholesky) */
    for (i = 0; i < n; ++i) {
        atb[i] = 0.0;
        for (k = 0; k < m; ++k) atb[i] += a[k * n + i] * b[k];
        for (j = 0; j < n; ++j) {
            ata[i * n + j] = 0.0;
            for (k = 0; k < m; ++k) ata[i * n + j] += a[k * n + i] * a[k * n + j];
        }
    }
    CHECK_RESULT(sqffd_cholesky_factor(ata, n), SQFFD_OK);
    CHECK_RESULT(sqffd_cholesky_solve(ata, n, atb), SQFFD_OK);
    for (i = 0; i < n; ++i) CHECK_NEAR(x[i], atb[i], 1e-12);

    /* rank deficient: columns 6, 7 copy column 0 -> rank 6; the minimum-norm
       solution spreads column 0's weight evenly over the three copies */
    for (i = 0; i < m; ++i) { a[i * n + 6] = a[i * n]; a[i * n + 7] = a[i * n]; }
    CHECK_RESULT(sqffd_svd(a, m, n, u, s, v, work, size), SQFFD_OK);
    rank = 99;
    CHECK_RESULT(sqffd_svd_solve(u, s, v, m, n, 1e-10, b, x, &rank, solve_work, solve_size), SQFFD_OK);
    CHECK(rank == 6);
    CHECK_NEAR(x[0], x[6], 1e-12);
    CHECK_NEAR(x[0], x[7], 1e-12);
    { /* x agrees with the full-rank solve over columns 0..5, weight 0 split in 3 */
        double *a6 = la_alloc((size_t)(m * 6)), *u6 = la_alloc((size_t)(m * 6)), s6[6], v6[36], x6[6];
        size_t size6 = 0, solve_size6 = 0;
        unsigned char *work6, *solve_work6;
        CHECK_RESULT(sqffd_svd_workspace_size((size_t)m, 6, &size6), SQFFD_OK);
        CHECK_RESULT(sqffd_svd_solve_workspace_size(6, &solve_size6), SQFFD_OK);
        work6 = la_workspace(size6);
        solve_work6 = la_workspace(solve_size6);
        for (i = 0; i < m; ++i)
            for (j = 0; j < 6; ++j) a6[i * 6 + j] = a[i * n + j];
        CHECK_RESULT(sqffd_svd(a6, m, 6, u6, s6, v6, work6, size6), SQFFD_OK);
        rank = 99;
        CHECK_RESULT(sqffd_svd_solve(u6, s6, v6, m, 6, 1e-10, b, x6, &rank, solve_work6, solve_size6), SQFFD_OK);
        CHECK(rank == 6);
        CHECK(la_canary_intact(solve_work6, solve_size6));
        CHECK_NEAR(3.0 * x[0], x6[0], 1e-12);
        for (j = 1; j < 6; ++j) CHECK_NEAR(x[j], x6[j], 1e-12);
        free(a6); free(u6); free(work6); free(solve_work6);
    }
    /* everything cut: rank 0, x = 0 */
    rank = 99;
    CHECK_RESULT(sqffd_svd_solve(u, s, v, m, n, 2.0, b, x, &rank, solve_work, solve_size), SQFFD_OK);
    CHECK(rank == 0);
    for (i = 0; i < n; ++i) CHECK(x[i] == 0.0);
    /* rank may be NULL; bad arguments; too small a workspace */
    CHECK_RESULT(sqffd_svd_solve(u, s, v, m, n, 1e-10, b, x, NULL, solve_work, solve_size), SQFFD_OK);
    CHECK_RESULT(sqffd_svd_solve(NULL, s, v, m, n, 1e-10, b, x, &rank, solve_work, solve_size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_svd_solve(u, NULL, v, m, n, 1e-10, b, x, &rank, solve_work, solve_size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_svd_solve(u, s, NULL, m, n, 1e-10, b, x, &rank, solve_work, solve_size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_svd_solve(u, s, v, m, n, 1e-10, NULL, x, &rank, solve_work, solve_size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_svd_solve(u, s, v, m, n, 1e-10, b, NULL, &rank, solve_work, solve_size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_svd_solve(u, s, v, m, 0, 1e-10, b, x, &rank, solve_work, solve_size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_svd_solve(u, s, v, 4, 5, 1e-10, b, x, &rank, solve_work, solve_size), SQFFD_ERROR_INVALID_ARGUMENT); /* m < n */
    CHECK_RESULT(sqffd_svd_solve(u, s, v, m, n, 1e-10, b, x, &rank, solve_work, solve_size - 1), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
    CHECK_RESULT(sqffd_svd_solve(u, s, v, m, n, 1e-10, b, x, &rank, NULL, solve_size), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
    CHECK(la_canary_intact(solve_work, solve_size));
    free(a); free(u); free(work); free(solve_work);
}

static void test_svd_errors(void)
{
    double a[12], u[12], s[3], v[9];
    size_t size = 0, bad_size;
    unsigned char *work;
    int i;
    la_seed(14);
    la_fill_random(a, 12);
    CHECK_RESULT(sqffd_svd_workspace_size(4, 3, &size), SQFFD_OK);
    bad_size = 1;
    CHECK_RESULT(sqffd_svd_workspace_size(2, 3, &bad_size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK(bad_size == 0);
    bad_size = 1;
    CHECK_RESULT(sqffd_svd_workspace_size(0, 0, &bad_size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK(bad_size == 0);
    bad_size = 1;
    CHECK_RESULT(sqffd_svd_workspace_size(2000000000, 2000000000, &bad_size), SQFFD_ERROR_TOO_LARGE); /* 3.2e19 bytes */
    CHECK(bad_size == 0);
    CHECK_RESULT(sqffd_svd_workspace_size(4, 3, NULL), SQFFD_ERROR_INVALID_ARGUMENT);
    work = la_workspace(size - 1); /* one byte short */
    CHECK_RESULT(sqffd_svd(a, 4, 3, u, s, v, work, size - 1), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
    CHECK(la_canary_intact(work, size - 1));
    free(work);
    work = la_workspace(size);
    CHECK_RESULT(sqffd_svd(a, 4, 3, u, s, v, NULL, size), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
    CHECK_RESULT(sqffd_svd(a, 3, 4, u, s, v, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_svd(a, 4, 0, u, s, v, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_svd(NULL, 4, 3, u, s, v, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_svd(a, 4, 3, u, NULL, v, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_svd(a, 2000000000, 2000000000, u, s, v, work, size), SQFFD_ERROR_TOO_LARGE);
    a[7] = nan("");
    CHECK_RESULT(sqffd_svd(a, 4, 3, u, s, v, work, size), SQFFD_ERROR_NON_FINITE);
    a[7] = -HUGE_VAL;
    CHECK_RESULT(sqffd_svd(a, 4, 3, u, s, v, work, size), SQFFD_ERROR_NON_FINITE);
    /* unaligned workspace of exactly the reported size works */
    la_fill_random(a, 12);
    free(work);
    work = la_workspace(size + 1);
    for (i = 0; i < LA_CANARY; ++i) work[size + 1 + i] = 0xA5;
    CHECK_RESULT(sqffd_svd(a, 4, 3, u, s, v, work + 1, size), SQFFD_OK);
    CHECK(la_canary_intact(work + 1, size));
    free(work);
}

/* ---- linear conjugate gradient ---- */

typedef struct la_dense {
    const double *a;
    int n;
    int poison; /* > 0: the poison-th call returns NaN */
    int calls;
} la_dense;

static void la_dense_matvec(void *user, const double *x, double *y)
{
    la_dense *m = (la_dense *)user;
    int i, j;
    m->calls++;
    for (i = 0; i < m->n; ++i) {
        double sum = 0.0;
        for (j = 0; j < m->n; ++j) sum += m->a[i * m->n + j] * x[j];
        y[i] = sum;
    }
    if (m->poison && m->calls == m->poison) y[m->n / 2] = nan("");
}

static void test_cg_vs_cholesky(void)
{
    const int n = 80;
    double *a = la_alloc((size_t)(n * n)), *l = la_alloc((size_t)(n * n)), *b = la_alloc((size_t)n);
    double *x = la_alloc((size_t)n), *ref = la_alloc((size_t)n), *diag = la_alloc((size_t)n), *dscale = la_alloc((size_t)n);
    size_t size = 0;
    unsigned char *work;
    sqffd_cg_options opt = sqffd_cg_options_default();
    la_dense m;
    int i, j, it_plain = 0, it_jacobi = 0, pass;
    double rel = 1.0;
    CHECK_RESULT(sqffd_cg_workspace_size((size_t)n, &size), SQFFD_OK);
    work = la_workspace(size);
    la_seed(20);
    la_random_spd(a, n);
    /* badly scaled rows and columns: D A D with D spanning 1e-2..1e2 */
    for (i = 0; i < n; ++i) dscale[i] = pow(10.0, 4.0 * i / (n - 1) - 2.0);
    for (pass = 0; pass < 2; ++pass) {
        if (pass == 1)
            for (i = 0; i < n; ++i)
                for (j = 0; j < n; ++j) a[i * n + j] *= dscale[i] * dscale[j];
        for (i = 0; i < n; ++i) { b[i] = la_rand(); diag[i] = a[i * n + i]; }
        memcpy(l, a, (size_t)(n * n) * sizeof(double));
        memcpy(ref, b, (size_t)n * sizeof(double));
        CHECK_RESULT(sqffd_cholesky_factor(l, n), SQFFD_OK);
        CHECK_RESULT(sqffd_cholesky_solve(l, n, ref), SQFFD_OK);
        m.a = a; m.n = n; m.poison = 0; m.calls = 0;
        opt.tolerance = 1e-12;
        opt.max_iterations = 20 * n;
        opt.jacobi_diagonal = diag;
        memset(x, 0, (size_t)n * sizeof(double));
        CHECK_RESULT(sqffd_cg_solve(n, la_dense_matvec, &m, b, x, &opt, &it_jacobi, &rel, work, size), SQFFD_OK);
        CHECK(la_canary_intact(work, size));
        CHECK_MSG(rel <= 1e-11, "relative residual %.3g", rel);
        for (i = 0; i < n; ++i) CHECK_NEAR(x[i], ref[i], 1e-9 * fabs(ref[i]) + 1e-12);
        opt.jacobi_diagonal = NULL;
        memset(x, 0, (size_t)n * sizeof(double));
        if (pass == 0) { /* well conditioned: plain CG converges as well */
            CHECK_RESULT(sqffd_cg_solve(n, la_dense_matvec, &m, b, x, &opt, &it_plain, &rel, work, size), SQFFD_OK);
            CHECK_MSG(rel <= 1e-11, "relative residual %.3g", rel);
            for (i = 0; i < n; ++i) CHECK_NEAR(x[i], ref[i], 1e-9 * fabs(ref[i]) + 1e-12);
        } else { /* condition ~1e9: without the preconditioner 3x the budget is not enough */
            opt.max_iterations = 3 * it_jacobi;
            CHECK_RESULT(sqffd_cg_solve(n, la_dense_matvec, &m, b, x, &opt, &it_plain, &rel, work, size),
                         SQFFD_ERROR_NO_CONVERGENCE);
            CHECK(it_plain == opt.max_iterations && rel > 1e-11);
            opt.jacobi_diagonal = diag;
        }
        /* a good start converges at once */
        memcpy(x, ref, (size_t)n * sizeof(double));
        CHECK_RESULT(sqffd_cg_solve(n, la_dense_matvec, &m, b, x, &opt, &it_jacobi, &rel, work, size), SQFFD_OK);
        CHECK(it_jacobi <= 2);
    }
    free(a); free(l); free(b); free(x); free(ref); free(diag); free(dscale); free(work);
}

static void test_cg_errors(void)
{
    double a[4] = {2, 0, 0, 1}, indef[4] = {1, 0, 0, -1}, b[2] = {1, 1}, x[2] = {0, 0}, diag[2] = {2, 0};
    size_t size = 0, bad_size = 1;
    unsigned char *work;
    sqffd_cg_options opt = sqffd_cg_options_default();
    la_dense m;
    int it;
    double rel;
    CHECK_RESULT(sqffd_cg_workspace_size(2, &size), SQFFD_OK);
    CHECK_RESULT(sqffd_cg_workspace_size(0, &bad_size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK(bad_size == 0);
    work = la_workspace(size);
    m.a = a; m.n = 2; m.poison = 0; m.calls = 0;
    CHECK(opt.max_iterations == 0 && opt.tolerance == 1e-10 && opt.jacobi_diagonal == NULL);
    CHECK_RESULT(sqffd_cg_solve(2, la_dense_matvec, &m, b, x, NULL, &it, &rel, work, size), SQFFD_OK);
    CHECK_NEAR(x[0], 0.5, 1e-15);
    CHECK_NEAR(x[1], 1.0, 1e-15);
    b[1] = nan("");
    CHECK_RESULT(sqffd_cg_solve(2, la_dense_matvec, &m, b, x, NULL, &it, &rel, work, size), SQFFD_ERROR_NON_FINITE);
    b[1] = 1.0;
    x[0] = HUGE_VAL;
    CHECK_RESULT(sqffd_cg_solve(2, la_dense_matvec, &m, b, x, NULL, &it, &rel, work, size), SQFFD_ERROR_NON_FINITE);
    x[0] = 0.0;
    m.poison = 2; /* the first iteration's A p */
    m.calls = 0;
    CHECK_RESULT(sqffd_cg_solve(2, la_dense_matvec, &m, b, x, NULL, &it, &rel, work, size), SQFFD_ERROR_NON_FINITE);
    m.poison = 0;
    m.a = indef;
    b[0] = 0.0; x[0] = x[1] = 0.0; /* r = (0, 1): p^T A p = -1 */
    CHECK_RESULT(sqffd_cg_solve(2, la_dense_matvec, &m, b, x, NULL, &it, &rel, work, size), SQFFD_ERROR_NOT_POSITIVE_DEFINITE);
    m.a = a;
    opt.jacobi_diagonal = diag;
    CHECK_RESULT(sqffd_cg_solve(2, la_dense_matvec, &m, b, x, &opt, &it, &rel, work, size), SQFFD_ERROR_NOT_POSITIVE_DEFINITE);
    opt.jacobi_diagonal = NULL;
    opt.tolerance = -1.0;
    CHECK_RESULT(sqffd_cg_solve(2, la_dense_matvec, &m, b, x, &opt, &it, &rel, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    opt.tolerance = 0.0; /* unreachable for an inexact system: the limit */
    opt.max_iterations = 1;
    b[0] = 1.0; b[1] = 1.0; x[0] = x[1] = 0.0;
    CHECK_RESULT(sqffd_cg_solve(2, la_dense_matvec, &m, b, x, &opt, &it, &rel, work, size), SQFFD_ERROR_NO_CONVERGENCE);
    CHECK(it == 1);
    b[0] = b[1] = 0.0; x[0] = 5.0; /* b = 0: x = 0 */
    CHECK_RESULT(sqffd_cg_solve(2, la_dense_matvec, &m, b, x, NULL, &it, &rel, work, size), SQFFD_OK);
    CHECK(x[0] == 0.0 && x[1] == 0.0 && it == 0);
    CHECK_RESULT(sqffd_cg_solve(0, la_dense_matvec, &m, b, x, NULL, &it, &rel, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_cg_solve(2, NULL, &m, b, x, NULL, &it, &rel, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    free(work);
    work = la_workspace(size - 1);
    CHECK_RESULT(sqffd_cg_solve(2, la_dense_matvec, &m, b, x, NULL, &it, &rel, work, size - 1), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
    CHECK(la_canary_intact(work, size - 1));
    free(work);
}

/* ---- nonlinear conjugate gradient ---- */

static double la_rosenbrock(void *user, const double *x, double *g)
{
    double a = 1.0 - x[0], b = x[1] - x[0] * x[0];
    (void)user;
    g[0] = -2.0 * a - 400.0 * x[0] * b;
    g[1] = 200.0 * b;
    return a * a + 100.0 * b * b;
}

/* f = 1/2 x^T A x - b^T x with the dense SPD A of la_quadratic_a */
typedef struct la_quadratic {
    const double *a, *b;
    int n;
    int evaluations;
} la_quadratic;

static double la_quadratic_f(void *user, const double *x, double *g)
{
    la_quadratic *q = (la_quadratic *)user;
    double f = 0.0;
    int i, j;
    q->evaluations++;
    for (i = 0; i < q->n; ++i) {
        double ax = 0.0;
        for (j = 0; j < q->n; ++j) ax += q->a[i * q->n + j] * x[j];
        g[i] = ax - q->b[i];
        f += 0.5 * x[i] * ax - q->b[i] * x[i];
    }
    return f;
}

/* (x0 - 2)^2 + (x1 - c)^2 + 1/2 (x0 - x1)^2 */
static double la_coupled(void *user, const double *x, double *g)
{
    double c = *(const double *)user;
    g[0] = 2.0 * (x[0] - 2.0) + (x[0] - x[1]);
    g[1] = 2.0 * (x[1] - c) - (x[0] - x[1]);
    return (x[0] - 2.0) * (x[0] - 2.0) + (x[1] - c) * (x[1] - c) + 0.5 * (x[0] - x[1]) * (x[0] - x[1]);
}

static void la_unit_box(void *user, double *x)
{
    int i;
    (void)user;
    for (i = 0; i < 2; ++i) x[i] = x[i] < 0.0 ? 0.0 : x[i] > 1.0 ? 1.0 : x[i];
}

static void la_rosenbrock_box(void *user, double *x) /* x0 <= 0.5 */
{
    (void)user;
    if (x[0] > 0.5) x[0] = 0.5;
}

static int la_progress_calls;
static int la_cancel_at_3(void *user, int stage, int iteration, double error)
{
    (void)user; (void)error;
    la_progress_calls++;
    CHECK(stage == SQFFD_STAGE_SUPERQUADRIC && iteration == la_progress_calls);
    return iteration == 3;
}

/* NCG options: the defaults with the given iteration limit, tolerance and
   projection (NULL: none). */
static sqffd_ncg_options la_ncg_options(int max_iterations, double tolerance, sqffd_project_fn project)
{
    sqffd_ncg_options o = sqffd_ncg_options_default();
    o.max_iterations = max_iterations;
    o.tolerance = tolerance;
    o.project = project;
    return o;
}

/* extended Rosenbrock in n dimensions: minimum 0 at (1, ..., 1) */
static double la_rosenbrock_n(void *user, const double *x, double *g)
{
    int i, n = *(const int *)user;
    double f = 0.0;
    for (i = 0; i < n; ++i) g[i] = 0.0;
    for (i = 0; i + 1 < n; ++i) {
        double a = 1.0 - x[i], b = x[i + 1] - x[i] * x[i];
        f += a * a + 100.0 * b * b;
        g[i] += -2.0 * a - 400.0 * x[i] * b;
        g[i + 1] += 200.0 * b;
    }
    return f;
}

static void test_ncg_unconstrained(void)
{
    const int n = 12;
    size_t size = 0;
    unsigned char *work;
    double *a = la_alloc((size_t)(n * n)), b[12], ref[12], x[12], x2[12], fx, fx2;
    sqffd_ncg_options opt;
    la_quadratic q;
    int i, it, it2;
    CHECK_RESULT(sqffd_ncg_workspace_size((size_t)n, &size), SQFFD_OK);
    work = la_workspace(size);
    la_seed(30);
    la_random_spd(a, n);
    for (i = 0; i < n; ++i) b[i] = la_rand();
    memcpy(ref, b, sizeof b);
    {
        double *l = la_alloc((size_t)(n * n));
        memcpy(l, a, (size_t)(n * n) * sizeof(double));
        CHECK_RESULT(sqffd_cholesky_factor(l, n), SQFFD_OK);
        CHECK_RESULT(sqffd_cholesky_solve(l, n, ref), SQFFD_OK);
        free(l);
    }
    q.a = a; q.b = b; q.n = n; q.evaluations = 0;
    memset(x, 0, sizeof x);
    opt = la_ncg_options(500, 1e-13, NULL);
    CHECK_RESULT(sqffd_ncg_minimize(n, la_quadratic_f, &q, x, &opt, &it, &fx, work, size), SQFFD_OK);
    CHECK(la_canary_intact(work, size));
    for (i = 0; i < n; ++i) CHECK_NEAR(x[i], ref[i], 1e-10);
    CHECK_MSG(it <= 4 * n, "quadratic took %d iterations", it);
    /* deterministic: the same run again is bit-identical */
    memset(x2, 0, sizeof x2);
    CHECK_RESULT(sqffd_ncg_minimize(n, la_quadratic_f, &q, x2, &opt, &it2, &fx2, work, size), SQFFD_OK);
    CHECK(memcmp(x, x2, sizeof x) == 0 && fx == fx2 && it == it2);

    x[0] = -1.2; x[1] = 1.0;
    opt = la_ncg_options(5000, 1e-12, NULL);
    CHECK_RESULT(sqffd_ncg_minimize(2, la_rosenbrock, NULL, x, &opt, &it, &fx, work, size), SQFFD_OK);
    CHECK_NEAR(x[0], 1.0, 1e-6);
    CHECK_NEAR(x[1], 1.0, 1e-6);
    CHECK(fx < 1e-12);
    {
        int dim = 20;
        double xr[20];
        size_t size20 = 0;
        unsigned char *work20;
        CHECK_RESULT(sqffd_ncg_workspace_size((size_t)dim, &size20), SQFFD_OK);
        work20 = la_workspace(size20);
        for (i = 0; i < dim; ++i) xr[i] = i % 2 ? 1.0 : -1.2;
        opt = la_ncg_options(5000, 1e-10, NULL);
        CHECK_RESULT(sqffd_ncg_minimize((size_t)dim, la_rosenbrock_n, &dim, xr, &opt, &it, &fx, work20, size20), SQFFD_OK);
        CHECK(la_canary_intact(work20, size20));
        for (i = 0; i < dim; ++i) CHECK_NEAR(xr[i], 1.0, 1e-6);
        free(work20);
    }
    free(a); free(work);
}

static void test_ncg_projected(void)
{
    size_t size = 0;
    unsigned char *work;
    double x[2], fx, c;
    sqffd_ncg_options box = la_ncg_options(200, 1e-12, la_unit_box), rosenbrock_box;
    int it;
    CHECK_RESULT(sqffd_ncg_workspace_size(2, &size), SQFFD_OK);
    work = la_workspace(size);
    /* both coordinates end on the box: KKT point (1, 0) */
    c = -1.0; x[0] = 0.5; x[1] = 0.5;
    CHECK_RESULT(sqffd_ncg_minimize(2, la_coupled, &c, x, &box, &it, &fx, work, size), SQFFD_OK);
    CHECK_NEAR(x[0], 1.0, 1e-12);
    CHECK_NEAR(x[1], 0.0, 1e-12);
    /* one on the box, one inside: (1, 2/3) */
    c = 0.5; x[0] = 0.1; x[1] = 0.9;
    CHECK_RESULT(sqffd_ncg_minimize(2, la_coupled, &c, x, &box, &it, &fx, work, size), SQFFD_OK);
    CHECK_NEAR(x[0], 1.0, 1e-12);
    CHECK_NEAR(x[1], 2.0 / 3.0, 1e-9);
    /* start outside the box: projected first */
    c = 0.5; x[0] = 7.0; x[1] = -3.0;
    CHECK_RESULT(sqffd_ncg_minimize(2, la_coupled, &c, x, &box, &it, &fx, work, size), SQFFD_OK);
    CHECK_NEAR(x[0], 1.0, 1e-12);
    CHECK_NEAR(x[1], 2.0 / 3.0, 1e-9);
    /* Rosenbrock with x0 <= 0.5: the constrained minimum (0.5, 0.25) */
    x[0] = -1.2; x[1] = 1.0;
    rosenbrock_box = la_ncg_options(5000, 1e-12, la_rosenbrock_box);
    CHECK_RESULT(sqffd_ncg_minimize(2, la_rosenbrock, NULL, x, &rosenbrock_box, &it, &fx, work, size), SQFFD_OK);
    CHECK_NEAR(x[0], 0.5, 1e-12);
    CHECK_NEAR(x[1], 0.25, 1e-8);
    free(work);
}

static double la_nan_objective(void *user, const double *x, double *g)
{
    (void)user;
    g[0] = x[0];
    return nan("");
}

static void test_ncg_errors(void)
{
    size_t size = 0, bad_size = 1;
    unsigned char *work;
    double x[2], fx, f0;
    sqffd_ncg_options opt = sqffd_ncg_options_default();
    int it;
    /* the defaults */
    CHECK(opt.max_iterations == 100 && opt.tolerance == 1e-8 && opt.project == NULL && opt.progress == NULL &&
          opt.progress_user == NULL);
    CHECK_RESULT(sqffd_ncg_workspace_size(2, &size), SQFFD_OK);
    CHECK_RESULT(sqffd_ncg_workspace_size(0, &bad_size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK(bad_size == 0);
    work = la_workspace(size);
    { /* NULL options are the defaults, to the bit */
        double xd[2] = {-1.2, 1.0}, xn[2] = {-1.2, 1.0}, fd = 0.0, fn = 1.0;
        int itd = -1, itn = -2;
        sqffd_result rd = sqffd_ncg_minimize(2, la_rosenbrock, NULL, xd, &opt, &itd, &fd, work, size);
        sqffd_result rn = sqffd_ncg_minimize(2, la_rosenbrock, NULL, xn, NULL, &itn, &fn, work, size);
        CHECK(rd == SQFFD_OK || rd == SQFFD_ERROR_NO_CONVERGENCE);
        CHECK(rn == rd && itn == itd && fn == fd && memcmp(xn, xd, sizeof xd) == 0);
    }
    /* iteration limit: NO_CONVERGENCE but a usable, improved point */
    x[0] = -1.2; x[1] = 1.0;
    f0 = 24.2; /* rosenbrock(-1.2, 1) */
    opt = la_ncg_options(3, 1e-12, NULL);
    CHECK_RESULT(sqffd_ncg_minimize(2, la_rosenbrock, NULL, x, &opt, &it, &fx, work, size), SQFFD_ERROR_NO_CONVERGENCE);
    CHECK(it == 3 && fx < f0);
    { double g[2]; CHECK(la_rosenbrock(NULL, x, g) == fx); }
    /* cancelled by the progress callback at iteration 3 */
    x[0] = -1.2; x[1] = 1.0;
    la_progress_calls = 0;
    opt = la_ncg_options(100, 1e-12, NULL);
    opt.progress = la_cancel_at_3;
    CHECK_RESULT(sqffd_ncg_minimize(2, la_rosenbrock, NULL, x, &opt, &it, &fx, work, size), SQFFD_ERROR_CANCELLED);
    CHECK(la_progress_calls == 3 && it == 3);
    opt = la_ncg_options(100, 1e-12, NULL);
    x[0] = nan("");
    CHECK_RESULT(sqffd_ncg_minimize(2, la_rosenbrock, NULL, x, &opt, &it, &fx, work, size), SQFFD_ERROR_NON_FINITE);
    x[0] = 0.0;
    CHECK_RESULT(sqffd_ncg_minimize(1, la_nan_objective, NULL, x, &opt, &it, &fx, work, size), SQFFD_ERROR_NON_FINITE);
    opt = la_ncg_options(0, 1e-12, NULL);
    CHECK_RESULT(sqffd_ncg_minimize(2, la_rosenbrock, NULL, x, &opt, &it, &fx, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    opt = la_ncg_options(10, -1.0, NULL);
    CHECK_RESULT(sqffd_ncg_minimize(2, la_rosenbrock, NULL, x, &opt, &it, &fx, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    opt = la_ncg_options(10, 1e-6, NULL);
    CHECK_RESULT(sqffd_ncg_minimize(2, NULL, NULL, x, &opt, &it, &fx, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_ncg_minimize(0, la_rosenbrock, NULL, x, &opt, &it, &fx, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    free(work);
    work = la_workspace(size - 1);
    CHECK_RESULT(sqffd_ncg_minimize(2, la_rosenbrock, NULL, x, &opt, &it, &fx, work, size - 1), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
    CHECK(la_canary_intact(work, size - 1));
    free(work);
}

void suite_linalg(void)
{
    RUN_TEST(test_sym3_eigen_random);
    RUN_TEST(test_sym3_eigen_known);
    RUN_TEST(test_cholesky_known);
    RUN_TEST(test_cholesky_random);
    RUN_TEST(test_cholesky_errors);
    RUN_TEST(test_svd_random);
    RUN_TEST(test_svd_known_values);
    RUN_TEST(test_svd_rank_deficient);
    RUN_TEST(test_svd_lattice_like);
    RUN_TEST(test_svd_scaling);
    RUN_TEST(test_svd_hilbert);
    RUN_TEST(test_svd_solve);
    RUN_TEST(test_svd_errors);
    RUN_TEST(test_cg_vs_cholesky);
    RUN_TEST(test_cg_errors);
    RUN_TEST(test_ncg_unconstrained);
    RUN_TEST(test_ncg_projected);
    RUN_TEST(test_ncg_errors);
}

/* Superquadric layer: geometry against analytic values and brute force, and
   the fit against ground truth (random superquadrics, volumetric IoU). */
#include "test.h"
#include "../examples/sqffd_synth.h"
#include "../examples/sqffd_io.h"
#include <stdlib.h>
#include <string.h>

static sqffd_superquadric sq_make(double a1, double a2, double a3, double e1, double e2, double kx, double ky)
{
    sqffd_superquadric sq;
    memset(&sq, 0, sizeof sq);
    sq.size[0] = a1; sq.size[1] = a2; sq.size[2] = a3;
    sq.shape[0] = e1; sq.shape[1] = e2;
    sq.taper[0] = kx; sq.taper[1] = ky;
    sq.rotation[0] = sq.rotation[4] = sq.rotation[8] = 1.0;
    return sq;
}

/* The value-returning forms the checks below read best in: a call that
   fails fails the test and gives NaN. */
static double io_of(const sqffd_superquadric *sq, const double p[3])
{
    double f = NAN;
    CHECK_RESULT(sqffd_sq_inside_outside(sq, p, &f), SQFFD_OK);
    return f;
}

static double radial_of(const sqffd_superquadric *sq, const double p[3])
{
    double d = NAN;
    CHECK_RESULT(sqffd_sq_radial_distance(sq, p, &d), SQFFD_OK);
    return d;
}

static double volume_of(const sqffd_superquadric *sq)
{
    double v = NAN;
    CHECK_RESULT(sqffd_sq_volume(sq, &v), SQFFD_OK);
    return v;
}

static double iou_of(const sqffd_superquadric *a, const sqffd_superquadric *b, int resolution)
{
    double iou = NAN;
    CHECK_RESULT(sqffd_sq_iou(a, b, resolution, &iou), SQFFD_OK);
    return iou;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* ---- geometry ------------------------------------------------------------ */

static void test_sq_surface_points_have_f_one(void)
{
    synth_rng rng = synth_rng_seed(1);
    synth_sq_ranges ranges = synth_sq_ranges_default();
    int s, i, j;
    for (s = 0; s < 50; s++) {
        sqffd_superquadric sq;
        synth_superquadric(&rng, &ranges, &sq);
        for (i = 1; i < 12; i++)
            for (j = 0; j < 16; j++) {
                double p[3], eta = -1.5 + 3.0 * i / 12.0, omega = -3.1 + 6.2 * j / 16.0;
                double f;
                sqffd_sq_point(&sq, eta, omega, p, NULL);
                f = io_of(&sq, p);
                CHECK_MSG(fabs(f - 1.0) < 1e-9, "shape %d: F = %.15g at eta %g omega %g (e %g %g)", s, f, eta, omega,
                          sq.shape[0], sq.shape[1]);
                CHECK_MSG(radial_of(&sq, p) < 1e-9 * synth_mean_size(&sq), "radial distance on surface");
            }
    }
}

static void test_sq_normals_orthogonal_and_outward(void)
{
    synth_rng rng = synth_rng_seed(2);
    synth_sq_ranges ranges = synth_sq_ranges_default();
    int s, i, j;
    ranges.shape_min = 0.3; /* finite differences need some smoothness */
    ranges.shape_max = 1.7;
    for (s = 0; s < 40; s++) {
        sqffd_superquadric sq;
        double h = 1e-6;
        synth_superquadric(&rng, &ranges, &sq);
        for (i = 1; i < 8; i++)
            for (j = 0; j < 8; j++) {
                double eta = -1.4 + 2.8 * i / 8.0, omega = -3.0 + 6.0 * j / 8.0 + 0.1;
                double p[3], n[3], pa[3], pb[3], pc[3], pd[3], te[3], to[3], q[3], len, step;
                int k;
                sqffd_sq_point(&sq, eta, omega, p, n);
                sqffd_sq_point(&sq, eta + h, omega, pa, NULL);
                sqffd_sq_point(&sq, eta - h, omega, pb, NULL);
                sqffd_sq_point(&sq, eta, omega + h, pc, NULL);
                sqffd_sq_point(&sq, eta, omega - h, pd, NULL);
                for (k = 0; k < 3; k++) { te[k] = pa[k] - pb[k]; to[k] = pc[k] - pd[k]; }
                CHECK_NEAR(sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]), 1.0, 1e-12);
                len = sqrt(te[0] * te[0] + te[1] * te[1] + te[2] * te[2]);
                CHECK_MSG(fabs(n[0] * te[0] + n[1] * te[1] + n[2] * te[2]) < 1e-5 * len, "normal . d/deta");
                len = sqrt(to[0] * to[0] + to[1] * to[1] + to[2] * to[2]);
                CHECK_MSG(fabs(n[0] * to[0] + n[1] * to[1] + n[2] * to[2]) < 1e-5 * len, "normal . d/domega");
                step = 1e-3 * synth_mean_size(&sq);
                for (k = 0; k < 3; k++) q[k] = p[k] + step * n[k];
                CHECK(io_of(&sq, q) > 1.0);
                for (k = 0; k < 3; k++) q[k] = p[k] - step * n[k];
                CHECK(io_of(&sq, q) < 1.0);
            }
    }
}

static void test_sq_normals_finite_at_poles_and_small_e(void)
{
    sqffd_superquadric sq = sq_make(1, 2, 3, 0.1, 0.1, 0.5, -0.4);
    double p[3], n[3];
    int i, j;
    for (i = 0; i <= 8; i++)
        for (j = 0; j <= 8; j++) {
            double eta = -0.5 * SYNTH_PI + SYNTH_PI * i / 8.0, omega = -SYNTH_PI + 2.0 * SYNTH_PI * j / 8.0;
            sqffd_sq_point(&sq, eta, omega, p, n);
            CHECK(isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]));
            CHECK(isfinite(n[0]) && isfinite(n[1]) && isfinite(n[2]));
            CHECK_NEAR(n[0] * n[0] + n[1] * n[1] + n[2] * n[2], 1.0, 1e-12);
        }
    sqffd_sq_point(&sq, 0.5 * SYNTH_PI, 0.0, p, n);
    CHECK_NEAR(n[2], 1.0, 1e-6); /* top pole of a box: +z */
    sqffd_sq_point(&sq, -0.5 * SYNTH_PI, 0.0, p, n);
    CHECK_NEAR(n[2], -1.0, 1e-6);
}

/* Volume by counting cell centres of an n^3 grid over the box around the shape. */
static double volume_by_grid(const sqffd_superquadric *sq, int n)
{
    double ext[3], cell, count = 0;
    int i, j, k;
    ext[0] = sq->size[0] * (1 + fabs(sq->taper[0]));
    ext[1] = sq->size[1] * (1 + fabs(sq->taper[1]));
    ext[2] = sq->size[2];
    cell = 8.0 * ext[0] * ext[1] * ext[2] / ((double)n * n * n);
    for (i = 0; i < n; i++)
        for (j = 0; j < n; j++)
            for (k = 0; k < n; k++) {
                double p[3];
                p[0] = sq->center[0] + ext[0] * (-1.0 + (2.0 * i + 1.0) / n);
                p[1] = sq->center[1] + ext[1] * (-1.0 + (2.0 * j + 1.0) / n);
                p[2] = sq->center[2] + ext[2] * (-1.0 + (2.0 * k + 1.0) / n);
                count += io_of(sq, p) <= 1.0;
            }
    return count * cell;
}

static void test_sq_volume_closed_form(void)
{
    sqffd_superquadric sphere = sq_make(2, 2, 2, 1, 1, 0, 0);
    sqffd_superquadric ellipsoid = sq_make(1, 2, 3, 1, 1, 0, 0);
    sqffd_superquadric cases[5];
    int i;
    CHECK_NEAR(volume_of(&sphere), 4.0 / 3.0 * SYNTH_PI * 8.0, 1e-12);
    CHECK_NEAR(volume_of(&ellipsoid), 4.0 / 3.0 * SYNTH_PI * 6.0, 1e-12);
    /* a near-box: e -> 0 tends to 8 a1 a2 a3 */
    ellipsoid = sq_make(1, 2, 3, 0.01, 0.01, 0, 0);
    CHECK_NEAR(volume_of(&ellipsoid) / 48.0, 1.0, 0.02);
    /* octahedron: e1 = e2 = 2, volume 4/3 a1 a2 a3 */
    ellipsoid = sq_make(1, 2, 3, 2, 2, 0, 0);
    CHECK_NEAR(volume_of(&ellipsoid), 8.0, 1e-12);
    /* tapered and untapered against a grid count */
    cases[0] = sq_make(1, 2, 3, 0.5, 1.5, 0, 0);
    cases[1] = sq_make(1, 2, 3, 0.5, 1.5, 0.6, 0.5);
    cases[2] = sq_make(2, 1, 1.5, 1.8, 0.2, -0.7, 0.6);
    cases[3] = sq_make(1.5, 1, 2, 0.2, 1.0, 0.9, 0.9);
    cases[4] = sq_make(1, 1, 1, 1.0, 1.0, 0.8, -0.3);
    for (i = 0; i < 5; i++) {
        double exact = volume_of(&cases[i]), grid = volume_by_grid(&cases[i], 64);
        CHECK_MSG(fabs(grid / exact - 1.0) < 0.005, "case %d: volume %.6f, grid %.6f", i, exact, grid);
    }
    /* tapering with Kx Ky < 0 shrinks, > 0 grows */
    CHECK(volume_of(&cases[4]) < volume_of(&sphere) / 8.0);
}

static void test_sq_sphere_analytic(void)
{
    sqffd_superquadric sq = sq_make(2, 2, 2, 1, 1, 0, 0);
    synth_rng rng = synth_rng_seed(3);
    int i;
    synth_rotation(&rng, sq.rotation);
    sq.center[0] = 1; sq.center[1] = -2; sq.center[2] = 0.5;
    for (i = 0; i < 200; i++) {
        double d[3], p[3], len, r = synth_range(&rng, 0.1, 6.0);
        int k;
        for (k = 0; k < 3; k++) d[k] = synth_gaussian(&rng);
        len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        for (k = 0; k < 3; k++) p[k] = sq.center[k] + r * d[k] / len;
        CHECK_NEAR(io_of(&sq, p), r * r / 4.0, 1e-12 * r * r);
        CHECK_NEAR(radial_of(&sq, p), fabs(r - 2.0), 1e-12);
    }
}

static void test_sq_ellipsoid_points(void)
{
    sqffd_superquadric sq = sq_make(1, 2, 3, 1, 1, 0, 0);
    double p[3], n[3];
    sqffd_sq_point(&sq, 0.0, 0.0, p, n);
    CHECK_NEAR(p[0], 1.0, 1e-15); CHECK_NEAR(p[1], 0.0, 1e-15); CHECK_NEAR(n[0], 1.0, 1e-15);
    sqffd_sq_point(&sq, 0.0, 0.5 * SYNTH_PI, p, n);
    CHECK_NEAR(p[1], 2.0, 1e-15); CHECK_NEAR(n[1], 1.0, 1e-15);
    sqffd_sq_point(&sq, 0.5 * SYNTH_PI, 0.0, p, n);
    CHECK_NEAR(p[2], 3.0, 1e-15); CHECK_NEAR(n[2], 1.0, 1e-15);
    /* normal of an ellipsoid: proportional to (x/a1^2, y/a2^2, z/a3^2) */
    sqffd_sq_point(&sq, 0.4, 1.0, p, n);
    {
        double g[3] = {p[0] / 1.0, p[1] / 4.0, p[2] / 9.0}, len = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
        CHECK_NEAR(n[0], g[0] / len, 1e-14); CHECK_NEAR(n[1], g[1] / len, 1e-14); CHECK_NEAR(n[2], g[2] / len, 1e-14);
    }
    /* tapering: the top pole is unchanged, the equator is unchanged, z = a3/2 is scaled by 1 + K/2 */
    sq.taper[0] = 0.5;
    sqffd_sq_point(&sq, SYNTH_PI / 6.0, 0.0, p, NULL); /* z = 3 sin(pi/6) = 1.5, x = cos(pi/6) */
    CHECK_NEAR(p[0], cos(SYNTH_PI / 6.0) * 1.25, 1e-14);
    CHECK_NEAR(p[2], 1.5, 1e-14);
}

static void test_sq_grid_layout(void)
{
    sqffd_superquadric sq = sq_make(1, 2, 3, 0.7, 1.2, 0.2, 0.1);
    double pts[5 * 6 * 3], nrm[5 * 6 * 3], p[3], n[3];
    CHECK_RESULT(sqffd_sq_sample_grid(&sq, 5, 6, pts, nrm), SQFFD_OK);
    sqffd_sq_point(&sq, -0.5 * SYNTH_PI + SYNTH_PI * 3 / 4.0, -SYNTH_PI + 2 * SYNTH_PI * 2 / 6.0, p, n);
    CHECK_NEAR(pts[3 * (3 * 6 + 2) + 1], p[1], 1e-15);
    CHECK_NEAR(nrm[3 * (3 * 6 + 2) + 2], n[2], 1e-15);
    CHECK_NEAR(pts[2], -3.0, 1e-12); /* first row is the south pole */
    CHECK_NEAR(pts[3 * 24 + 2], 3.0, 1e-12);
    CHECK_RESULT(sqffd_sq_sample_grid(&sq, 1, 6, pts, NULL), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_sq_sample_grid(&sq, 5, 0, pts, NULL), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_sq_sample_grid(NULL, 5, 6, pts, NULL), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_sq_sample_grid(&sq, 5, 6, NULL, NULL), SQFFD_ERROR_INVALID_ARGUMENT);
}

/* Coefficient of variation of each point's nearest-neighbour distance (brute force). */
static double nn_spread(const double *p, size_t n, double *median_out)
{
    double *d = (double *)malloc(n * sizeof *d), mean = 0, var = 0;
    size_t i, j;
    for (i = 0; i < n; i++) {
        double best = 1e300;
        for (j = 0; j < n; j++) {
            double dx = p[3 * i] - p[3 * j], dy = p[3 * i + 1] - p[3 * j + 1], dz = p[3 * i + 2] - p[3 * j + 2];
            double d2 = dx * dx + dy * dy + dz * dz;
            if (j != i && d2 < best) best = d2;
        }
        d[i] = sqrt(best);
        mean += d[i];
    }
    mean /= (double)n;
    for (i = 0; i < n; i++) var += (d[i] - mean) * (d[i] - mean);
    if (median_out) {
        qsort(d, n, sizeof *d, cmp_double);
        *median_out = d[n / 2];
    }
    free(d);
    return sqrt(var / (double)n) / mean;
}

static void test_sq_uniform_sampling_even(void)
{
    sqffd_superquadric shapes[3];
    int s;
    shapes[0] = sq_make(1, 2, 3, 0.1, 0.1, 0, 0);   /* box */
    shapes[1] = sq_make(1, 2, 3, 1.9, 0.15, 0.4, -0.3); /* pointy, tapered */
    shapes[2] = sq_make(2, 1, 1, 0.2, 1.8, 0.0, 0.6);
    for (s = 0; s < 3; s++) {
        double spacing = 0.15, med, cv_uniform, cv_grid;
        size_t count = 0, again = 0, m;
        double *pts, *grid;
        int side;
        CHECK_RESULT(sqffd_sq_sample_uniform(&shapes[s], spacing, NULL, 0, &count), SQFFD_OK);
        pts = (double *)malloc(3 * count * sizeof *pts);
        CHECK_RESULT(sqffd_sq_sample_uniform(&shapes[s], spacing, pts, count, &again), SQFFD_OK);
        CHECK(again == count);
        CHECK(count > 100);
        cv_uniform = nn_spread(pts, count, &med);
        CHECK_MSG(med > 0.5 * spacing && med < 1.05 * spacing, "shape %d: median spacing %g for %g", s, med, spacing);
        memcpy(pts + 3 * (count - 1), pts, 3 * sizeof *pts); /* capacity below the count: nothing written */
        memset(pts, 0, 3 * (count - 1) * sizeof *pts);
        again = 0;
        CHECK_RESULT(sqffd_sq_sample_uniform(&shapes[s], spacing, pts, count - 1, &again), SQFFD_ERROR_OUTPUT_TOO_SMALL);
        CHECK(again == count && test_all_zero(pts, 3 * (count - 1)));
        /* a grid with about as many points */
        side = (int)sqrt((double)count / 2.0);
        m = (size_t)side * (size_t)(2 * side);
        grid = (double *)malloc(3 * m * sizeof *grid);
        CHECK_RESULT(sqffd_sq_sample_grid(&shapes[s], side, 2 * side, grid, NULL), SQFFD_OK);
        cv_grid = nn_spread(grid + 3 * (size_t)(2 * side), m - (size_t)(4 * side), NULL); /* without the pole rows */
        CHECK_MSG(cv_uniform < 0.6 * cv_grid, "shape %d: NN-distance spread %.3f (uniform) vs %.3f (grid)", s, cv_uniform,
                  cv_grid);
        free(pts);
        free(grid);
    }
    {
        size_t count = 1;
        CHECK_RESULT(sqffd_sq_sample_uniform(&shapes[0], 0.0, NULL, 0, &count), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK(count == 1); /* an error before the work: untouched */
        CHECK_RESULT(sqffd_sq_sample_uniform(&shapes[0], 1e-9, NULL, 0, &count), SQFFD_ERROR_TOO_LARGE);
        CHECK_RESULT(sqffd_sq_sample_uniform(&shapes[0], 0.1, NULL, 5, &count), SQFFD_ERROR_INVALID_ARGUMENT);
    }
}

static void test_sq_iou(void)
{
    sqffd_superquadric a = sq_make(1, 2, 3, 0.4, 1.3, 0.3, -0.2), b, c;
    synth_rng rng = synth_rng_seed(4);
    synth_rotation(&rng, a.rotation);
    CHECK_NEAR(iou_of(&a, &a, 40), 1.0, 0.0);
    b = sq_make(1, 1, 1, 1, 1, 0, 0);
    c = sq_make(1.5, 1.5, 1.5, 1, 1, 0, 0);
    CHECK_NEAR(iou_of(&b, &c, 64), 1.0 / 3.375, 0.01);
    CHECK_NEAR(iou_of(&c, &b, 64), 1.0 / 3.375, 0.01);
    c.center[0] = 10.0; /* disjoint */
    CHECK_NEAR(iou_of(&b, &c, 32), 0.0, 0.0);
    /* half-overlapping boxes: 1/3 */
    b = sq_make(1, 1, 1, 0.1, 0.1, 0, 0);
    c = b;
    c.center[0] = 1.0;
    CHECK_NEAR(iou_of(&b, &c, 60), 1.0 / 3.0, 0.02);
    {
        double iou = 0.5;
        CHECK_RESULT(sqffd_sq_iou(&b, &c, 0, &iou), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_sq_iou(&b, &c, 8, NULL), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK(iou == 0.5); /* untouched on failure */
    }
}

/* ---- fit -------------------------------------------------------------------- */

static sqffd_result fit_points(const double *pts, size_t n, const sqffd_sq_fit_options *o, sqffd_superquadric *sq,
                               sqffd_sq_fit_report *report)
{
    size_t size;
    void *work;
    sqffd_result r = sqffd_sq_fit_workspace_size(n, o, &size);
    if (r != SQFFD_OK) return r;
    work = malloc(size);
    r = sqffd_sq_fit(pts, n, o, sq, report, work, size);
    free(work);
    return r;
}

/* The kinds of test data: clean, noisy, cut by a plane, with outliers. */
enum { DATA_CLEAN, DATA_NOISE, DATA_CUT, DATA_OUTLIERS };

/* Random superquadric and n surface points of the given kind (pts holds
   1.25 n points). Returns the number of points. */
static size_t make_case(synth_rng *rng, int kind, size_t n, sqffd_superquadric *truth, double *pts)
{
    synth_sq_ranges ranges = synth_sq_ranges_default();
    size_t m;
    synth_superquadric(rng, &ranges, truth);
    m = synth_sq_surface(rng, truth, n, kind == DATA_NOISE ? 0.02 : 0.0, pts);
    if (kind == DATA_CUT) m = synth_cut_plane(rng, pts, m, 0.4);
    if (kind == DATA_OUTLIERS) {
        synth_outliers(rng, pts, m, m / 4, 1.5, pts + 3 * m); /* 20% of all points */
        m += m / 4;
    }
    return m;
}

/* Fits `cases` random cases of one kind; returns the IoUs sorted ascending. */
static void fit_statistics(int kind, int cases, size_t n, int robust, int resolution, double *iou, uint64_t seed)
{
    synth_rng rng = synth_rng_seed(seed);
    sqffd_sq_fit_options o = sqffd_sq_fit_options_default();
    double *pts = (double *)malloc(3 * (n + n / 4 + 1) * sizeof *pts);
    size_t size;
    void *work;
    int c;
    o.robust = robust;
    CHECK_RESULT(sqffd_sq_fit_workspace_size(n + n / 4 + 1, &o, &size), SQFFD_OK);
    work = malloc(size);
    for (c = 0; c < cases; c++) {
        sqffd_superquadric truth, fit;
        size_t m = make_case(&rng, kind, n, &truth, pts);
        sqffd_result r = sqffd_sq_fit(pts, m, &o, &fit, NULL, work, size);
        CHECK_MSG(r == SQFFD_OK, "case %d: %s", c, sqffd_result_string(r));
        iou[c] = r == SQFFD_OK ? iou_of(&truth, &fit, resolution) : 0.0;
    }
    qsort(iou, (size_t)cases, sizeof *iou, cmp_double);
    free(work);
    free(pts);
}

static void test_sq_fit_clean(void)
{
    enum { CASES = 200 };
    double iou[CASES];
    int c, good = 0;
    fit_statistics(DATA_CLEAN, CASES, 1000, 0, 48, iou, 100);
    for (c = 0; c < CASES; c++) good += iou[c] >= 0.995;
    printf("    clean: IoU >= 0.995 in %d of %d cases (%.1f%%), median %.4f, worst %.4f\n", good, CASES,
           100.0 * good / CASES, iou[CASES / 2], iou[0]);
    CHECK_MSG(good >= CASES * 98 / 100, "clean: IoU >= 0.995 in only %d of %d cases", good, CASES);
}

/* The median IoU over 60 random shapes of one kind of data reaches `floor`. */
static void check_median_iou(int kind, int robust, uint64_t seed, const char *label, double floor)
{
    enum { CASES = 60 };
    double iou[CASES];
    fit_statistics(kind, CASES, 1000, robust, 40, iou, seed);
    printf("    %s: median IoU %.4f (10th percentile %.4f)\n", label, iou[CASES / 2], iou[CASES / 10]);
    CHECK_MSG(iou[CASES / 2] >= floor, "%s: median IoU %.4f", label, iou[CASES / 2]);
}

static void test_sq_fit_noise(void) { check_median_iou(DATA_NOISE, 0, 200, "2% noise", 0.98); }
static void test_sq_fit_cut(void) { check_median_iou(DATA_CUT, 0, 300, "40% cut away", 0.95); }
static void test_sq_fit_outliers_robust(void) { check_median_iou(DATA_OUTLIERS, 1, 400, "20% outliers, robust", 0.98); }

/* The robust mode reports the inlier share and ignores the outliers. */
static void test_sq_fit_robust_report(void)
{
    synth_rng rng = synth_rng_seed(5);
    sqffd_sq_fit_options o = sqffd_sq_fit_options_default();
    sqffd_superquadric truth, fit;
    sqffd_sq_fit_report rep;
    double pts[3 * 1250];
    size_t m = make_case(&rng, DATA_OUTLIERS, 1000, &truth, pts);
    o.robust = 1;
    CHECK_RESULT(fit_points(pts, m, &o, &fit, &rep), SQFFD_OK);
    CHECK_MSG(rep.inlier_fraction > 0.75 && rep.inlier_fraction < 0.85, "inlier fraction %.3f of 0.8",
              rep.inlier_fraction);
    CHECK(rep.rms_radial < 0.01 * synth_mean_size(&truth));
    CHECK(iou_of(&truth, &fit, 40) > 0.98);
}

/* Untapered model: K stays 0; exact on an untapered shape; radial cost too. */
static void test_sq_fit_options_variants(void)
{
    synth_rng rng = synth_rng_seed(6);
    synth_sq_ranges ranges = synth_sq_ranges_default();
    sqffd_sq_fit_options o = sqffd_sq_fit_options_default();
    sqffd_superquadric truth, fit;
    sqffd_sq_fit_report rep;
    double pts[3 * 800];
    int c;
    ranges.taper_max = 0.0;
    for (c = 0; c < 5; c++) {
        synth_superquadric(&rng, &ranges, &truth);
        CHECK(synth_sq_surface(&rng, &truth, 800, 0.0, pts) == 800);
        o = sqffd_sq_fit_options_default();
        o.taper = 0;
        CHECK_RESULT(fit_points(pts, 800, &o, &fit, &rep), SQFFD_OK);
        CHECK(fit.taper[0] == 0.0 && fit.taper[1] == 0.0);
        CHECK_MSG(iou_of(&truth, &fit, 40) > 0.995, "11 parameters: IoU %.4f", iou_of(&truth, &fit, 40));
        CHECK(rep.converged);
        CHECK(rep.rms_radial < 1e-6 * synth_mean_size(&truth));
        CHECK(rep.iterations > 0);
        o = sqffd_sq_fit_options_default();
        o.cost = SQFFD_SQ_COST_RADIAL;
        CHECK_RESULT(fit_points(pts, 800, &o, &fit, &rep), SQFFD_OK);
        CHECK_MSG(iou_of(&truth, &fit, 40) > 0.99, "radial cost: IoU %.4f", iou_of(&truth, &fit, 40));
    }
}

/* final_points: 0 and n both mean all points (the same fit to the bit);
   384 or fewer, no last run (the same fit whatever the value, fewer
   iterations and less workspace than the default's run on 1,536, and the
   shape within 0.01 of its IoU on noisy data). */
static void test_sq_fit_final_points(void)
{
    synth_rng rng = synth_rng_seed(12);
    sqffd_sq_fit_options o = sqffd_sq_fit_options_default();
    sqffd_superquadric truth, fit[5];
    sqffd_sq_fit_report rep[5];
    static const size_t finals[5] = {1536, 0, 2000, 384, 1};
    size_t sizes[5];
    double *pts = (double *)malloc(3 * 2500 * sizeof *pts);
    size_t m = make_case(&rng, DATA_NOISE, 2000, &truth, pts);
    int k;
    CHECK(m == 2000);
    for (k = 0; k < 5; k++) {
        o.final_points = finals[k];
        CHECK_RESULT(sqffd_sq_fit_workspace_size(m, &o, &sizes[k]), SQFFD_OK);
        CHECK_RESULT(fit_points(pts, m, &o, &fit[k], &rep[k]), SQFFD_OK);
    }
    CHECK(memcmp(&fit[1], &fit[2], sizeof fit[1]) == 0 && sizes[1] == sizes[2]);
    CHECK(memcmp(&fit[3], &fit[4], sizeof fit[3]) == 0 && rep[3].iterations == rep[4].iterations);
    CHECK(memcmp(&fit[0], &fit[3], sizeof fit[0]) != 0);
    CHECK_MSG(rep[3].iterations < rep[0].iterations, "no last run: %d iterations, default %d", rep[3].iterations,
              rep[0].iterations);
    CHECK(sizes[3] < sizes[0]);
    CHECK_MSG(iou_of(&truth, &fit[3], 40) > iou_of(&truth, &fit[0], 40) - 0.01, "2%% noise: IoU %.4f, default %.4f",
              iou_of(&truth, &fit[3], 40), iou_of(&truth, &fit[0], 40)); /* (measured 0.9743 and 0.9766) */
    free(pts);
}

/* The paper's conjugate-gradient descent reaches the same shapes. */
static void test_sq_fit_cg(void)
{
    synth_rng rng = synth_rng_seed(7);
    sqffd_sq_fit_options o = sqffd_sq_fit_options_default();
    sqffd_superquadric truth, fit;
    double pts[3 * 1250];
    int c;
    o.optimizer = SQFFD_SQ_OPTIMIZER_CG;
    for (c = 0; c < 2; c++) {
        size_t m = make_case(&rng, DATA_CLEAN, 400, &truth, pts);
        CHECK_RESULT(fit_points(pts, m, &o, &fit, NULL), SQFFD_OK);
        CHECK_MSG(iou_of(&truth, &fit, 40) > 0.98, "CG: IoU %.4f", iou_of(&truth, &fit, 40));
    }
}

static void test_sq_fit_deterministic(void)
{
    synth_rng rng = synth_rng_seed(8);
    sqffd_sq_fit_options o = sqffd_sq_fit_options_default();
    sqffd_superquadric truth, a, b;
    double pts[3 * 1250];
    size_t m = make_case(&rng, DATA_OUTLIERS, 1000, &truth, pts);
    o.robust = 1;
    CHECK_RESULT(fit_points(pts, m, &o, &a, NULL), SQFFD_OK);
    CHECK_RESULT(fit_points(pts, m, &o, &b, NULL), SQFFD_OK);
    CHECK(memcmp(&a, &b, sizeof a) == 0);
}

/* Translation, rotation and scale of the data move the fit along. */
static void test_sq_fit_similarity(void)
{
    synth_rng rng = synth_rng_seed(9);
    sqffd_superquadric truth, fit;
    double pts[3 * 1000];
    size_t i;
    make_case(&rng, DATA_CLEAN, 1000, &truth, pts);
    for (i = 0; i < 3 * 1000; i++) pts[i] = 1e6 + 1e3 * pts[i]; /* far away and large */
    truth.center[0] = 1e6 + 1e3 * truth.center[0];
    truth.center[1] = 1e6 + 1e3 * truth.center[1];
    truth.center[2] = 1e6 + 1e3 * truth.center[2];
    for (i = 0; i < 3; i++) truth.size[i] *= 1e3;
    CHECK_RESULT(fit_points(pts, 1000, NULL, &fit, NULL), SQFFD_OK);
    CHECK_MSG(iou_of(&truth, &fit, 40) > 0.995, "IoU %.4f", iou_of(&truth, &fit, 40));
}

static int cancel_after_three(void *user, int stage, int iteration, double error)
{
    int *calls = (int *)user;
    CHECK(stage == SQFFD_STAGE_SUPERQUADRIC);
    CHECK(isfinite(error) && error >= 0.0);
    CHECK(iteration == *calls + 1);
    (*calls)++;
    return *calls >= 3;
}

static void test_sq_fit_progress_cancel(void)
{
    synth_rng rng = synth_rng_seed(10);
    sqffd_sq_fit_options o = sqffd_sq_fit_options_default();
    sqffd_superquadric truth, fit;
    double pts[3 * 500];
    int calls = 0;
    make_case(&rng, DATA_NOISE, 500, &truth, pts);
    o.progress = cancel_after_three;
    o.progress_user = &calls;
    CHECK_RESULT(fit_points(pts, 500, &o, &fit, NULL), SQFFD_ERROR_CANCELLED);
    CHECK(calls == 3);
    calls = 0;
    o.optimizer = SQFFD_SQ_OPTIMIZER_CG;
    CHECK_RESULT(fit_points(pts, 500, &o, &fit, NULL), SQFFD_ERROR_CANCELLED);
    CHECK(calls == 3);
}

/* Tight box around a superquadric, from a dense grid of surface points. */
static void sq_box(const sqffd_superquadric *sq, double lo[3], double hi[3])
{
    static double pts[3 * 65 * 128];
    CHECK_RESULT(sqffd_sq_sample_grid(sq, 65, 128, pts, NULL), SQFFD_OK);
    synth_bounds(pts, 65 * 128, lo, hi);
}

/* The fit of data that are no superquadric stays within the data's box
   enlarged by 25% (scaled by 1.25 about its centre). */
static void check_stays_in_box(const char *name, const double *pts, size_t n, int robust)
{
    sqffd_sq_fit_options o = sqffd_sq_fit_options_default();
    sqffd_superquadric fit;
    sqffd_sq_fit_report rep;
    double lo[3], hi[3], flo[3], fhi[3];
    int k;
    o.robust = robust;
    CHECK_RESULT(fit_points(pts, n, &o, &fit, &rep), SQFFD_OK);
    synth_bounds(pts, n, lo, hi);
    sq_box(&fit, flo, fhi);
    for (k = 0; k < 3; k++) {
        double mid = 0.5 * (lo[k] + hi[k]), half = 0.625 * (hi[k] - lo[k]);
        CHECK_MSG(flo[k] >= mid - half && fhi[k] <= mid + half,
                  "%s%s axis %d: fit spans [%.3g, %.3g], data [%.3g, %.3g] (sizes %.3g %.3g %.3g, e %.2f %.2f, K %.2f %.2f)",
                  name, robust ? " (robust)" : "", k, flo[k], fhi[k], lo[k], hi[k], fit.size[0], fit.size[1], fit.size[2],
                  fit.shape[0], fit.shape[1], fit.taper[0], fit.taper[1]);
    }
}

static void test_sq_fit_no_runaway(void)
{
    synth_rng rng = synth_rng_seed(11);
    double *pts = NULL, *shape = (double *)malloc(3 * 2000 * sizeof *shape);
    size_t n = 0, i;
    char err[256];
    int robust;
    if (sqffd_io_read_file("tests/data/bunny.ply", &pts, &n, err, sizeof err) != 0) {
        CHECK_MSG(0, "%s (run the tests from the repository root)", err);
    } else {
        for (robust = 0; robust < 2; robust++) check_stays_in_box("bunny", pts, n, robust);
    }
    free(pts);
    /* a torus: major radius 3, minor 1 */
    for (i = 0; i < 2000; i++) {
        double u = synth_range(&rng, 0, 2 * SYNTH_PI), v = synth_range(&rng, 0, 2 * SYNTH_PI);
        shape[3 * i] = (3 + cos(v)) * cos(u);
        shape[3 * i + 1] = (3 + cos(v)) * sin(u);
        shape[3 * i + 2] = sin(v);
    }
    for (robust = 0; robust < 2; robust++) check_stays_in_box("torus", shape, 2000, robust);
    /* an L: two boxes' surfaces, 4 x 1 x 1 and 1 x 3 x 1 */
    for (i = 0; i < 2000; i++) {
        double p[3];
        int face = (int)synth_index(&rng, 6), k;
        double ext[3] = {4, 1, 1};
        if (i % 2) { ext[0] = 1; ext[1] = 3; }
        for (k = 0; k < 3; k++) p[k] = synth_range(&rng, 0, ext[k]);
        p[face / 2] = face % 2 ? ext[face / 2] : 0.0;
        memcpy(shape + 3 * i, p, sizeof p);
    }
    for (robust = 0; robust < 2; robust++) check_stays_in_box("L-shape", shape, 2000, robust);
    /* a flat disc with a spike (a point far above it) */
    for (i = 0; i < 2000; i++) {
        double r = sqrt(synth_uniform(&rng)) * 5, a = synth_range(&rng, 0, 2 * SYNTH_PI);
        shape[3 * i] = r * cos(a);
        shape[3 * i + 1] = r * sin(a);
        shape[3 * i + 2] = synth_range(&rng, -0.05, 0.05);
    }
    shape[2] = 10.0;
    for (robust = 0; robust < 2; robust++) check_stays_in_box("disc with a spike", shape, 2000, robust);
    free(shape);
}

/* Sizes are bounded below by half the data's standard deviation along each
   local axis (a collapse: on thin, branched data the F-based cost can prefer
   a tiny, fully tapered shape), on hand-like data with one point left out
   at a time (one of these collapsed to sizes of 0.03-0.13 before). */
static void test_sq_fit_no_collapse(void)
{
    enum { N = 1500 };
    double *pts = (double *)malloc(3 * N * sizeof *pts), *sub = (double *)malloc(3 * N * sizeof *sub);
    sqffd_sq_fit_options o = sqffd_sq_fit_options_default();
    size_t size, i, d, k;
    void *ws;
    int seed;
    CHECK_RESULT(sqffd_sq_fit_workspace_size(N, &o, &size), SQFFD_OK);
    ws = malloc(size);
    for (seed = 1; seed <= 3; seed++) {
        synth_hand(N, (uint64_t)seed, pts);
        for (d = 0; d < 6; d++) {
            sqffd_superquadric sq;
            double mean[3] = {0.0, 0.0, 0.0}, cov[9] = {0.0};
            int a, b;
            for (i = 0, k = 0; i < N; i++)
                if (i != d * 250) memcpy(sub + 3 * k++, pts + 3 * i, 3 * sizeof(double));
            CHECK_RESULT(sqffd_sq_fit(sub, k, &o, &sq, NULL, ws, size), SQFFD_OK);
            for (i = 0; i < k; i++)
                for (a = 0; a < 3; a++) mean[a] += sub[3 * i + (size_t)a] / (double)k;
            for (i = 0; i < k; i++)
                for (a = 0; a < 3; a++)
                    for (b = 0; b < 3; b++)
                        cov[3 * a + b] += (sub[3 * i + (size_t)a] - mean[a]) * (sub[3 * i + (size_t)b] - mean[b]) / (double)k;
            for (a = 0; a < 3; a++) { /* the data's spread along local axis a (column a of the rotation) */
                double var = 0.0;
                for (b = 0; b < 9; b++) var += sq.rotation[3 * (b / 3) + a] * cov[b] * sq.rotation[3 * (b % 3) + a];
                CHECK_MSG(sq.size[a] >= 0.5 * sqrt(var) * (1.0 - 1e-9), "seed %d drop %zu: size %d = %g, spread %g", seed,
                          d, a, sq.size[a], sqrt(var));
            }
        }
    }
    free(ws); free(sub); free(pts);
}

/* ---- bad input ---------------------------------------------------------------- */

static void test_sq_fit_bad_input(void)
{
    synth_rng rng = synth_rng_seed(12);
    sqffd_sq_fit_options o = sqffd_sq_fit_options_default();
    sqffd_superquadric truth, fit, untouched;
    double pts[3 * 200], bad[3 * 200];
    size_t size, i;
    unsigned char *work;
    CHECK_RESULT(sqffd_sq_fit_workspace_size(200, NULL, &size), SQFFD_OK);
    work = (unsigned char *)malloc(size + 64);
    make_case(&rng, DATA_CLEAN, 200, &truth, pts);
    memset(&untouched, 0x5a, sizeof untouched);
    fit = untouched;
    /* too few points */
    CHECK_RESULT(sqffd_sq_fit(pts, SQFFD_SQ_FIT_MIN_POINTS - 1, NULL, &fit, NULL, work, size), SQFFD_ERROR_TOO_FEW_POINTS);
    CHECK_RESULT(sqffd_sq_fit(pts, 0, NULL, &fit, NULL, work, size), SQFFD_ERROR_TOO_FEW_POINTS);
    CHECK_RESULT(sqffd_sq_fit(pts, SQFFD_SQ_FIT_MIN_POINTS, NULL, &fit, NULL, work, size), SQFFD_OK);
    fit = untouched;
    /* NaN and Inf */
    memcpy(bad, pts, sizeof bad);
    bad[3 * 57 + 1] = NAN;
    CHECK_RESULT(sqffd_sq_fit(bad, 200, NULL, &fit, NULL, work, size), SQFFD_ERROR_NON_FINITE);
    bad[3 * 57 + 1] = -INFINITY;
    CHECK_RESULT(sqffd_sq_fit(bad, 200, NULL, &fit, NULL, work, size), SQFFD_ERROR_NON_FINITE);
    /* coincident, collinear, coplanar */
    for (i = 0; i < 200; i++) { bad[3 * i] = 1.5; bad[3 * i + 1] = -2.0; bad[3 * i + 2] = 7.0; }
    CHECK_RESULT(sqffd_sq_fit(bad, 200, NULL, &fit, NULL, work, size), SQFFD_ERROR_DEGENERATE);
    for (i = 0; i < 200; i++) { double t = synth_gaussian(&rng); bad[3 * i] = 1 + t; bad[3 * i + 1] = 2 - 3 * t; bad[3 * i + 2] = 0.5 * t; }
    CHECK_RESULT(sqffd_sq_fit(bad, 200, NULL, &fit, NULL, work, size), SQFFD_ERROR_DEGENERATE);
    for (i = 0; i < 200; i++) {
        double s = synth_gaussian(&rng), t = synth_gaussian(&rng);
        bad[3 * i] = s + t; bad[3 * i + 1] = 2 * s - t; bad[3 * i + 2] = 3 * s; /* spanned by (1, 2, 3) and (1, -1, 0) */
    }
    CHECK_RESULT(sqffd_sq_fit(bad, 200, NULL, &fit, NULL, work, size), SQFFD_ERROR_DEGENERATE);
    CHECK(memcmp(&fit, &untouched, sizeof fit) == 0); /* nothing written on failure */
    /* two clusters 1e12 apart: no overflow, a finite answer or DEGENERATE */
    memcpy(bad, pts, sizeof bad);
    for (i = 100; i < 200; i++) bad[3 * i] += 1e12;
    {
        sqffd_result r = sqffd_sq_fit(bad, 200, NULL, &fit, NULL, work, size);
        CHECK(r == SQFFD_OK || r == SQFFD_ERROR_DEGENERATE);
        if (r == SQFFD_OK) CHECK(isfinite(fit.size[0]) && isfinite(fit.center[0]) && isfinite(fit.shape[0]));
    }
    /* huge coordinates of a proper shape */
    for (i = 0; i < 3 * 200; i++) bad[i] = 1e150 * pts[i];
    CHECK_RESULT(sqffd_sq_fit(bad, 200, NULL, &fit, NULL, work, size), SQFFD_OK);
    CHECK(isfinite(fit.size[0]) && isfinite(fit.size[1]) && isfinite(fit.size[2]));
    CHECK_NEAR((fit.size[0] / truth.size[0] * 1e-150) * (fit.size[1] / truth.size[1] * 1e-150) * (fit.size[2] / truth.size[2] * 1e-150), 1.0, 0.05);
    /* NULL pointers and bad options */
    CHECK_RESULT(sqffd_sq_fit(NULL, 200, NULL, &fit, NULL, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_sq_fit(pts, 200, NULL, NULL, NULL, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_sq_fit(pts, 200, NULL, &fit, NULL, NULL, size), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
    o.shape_min = 1.5; o.shape_max = 1.0;
    CHECK_RESULT(sqffd_sq_fit(pts, 200, &o, &fit, NULL, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    o = sqffd_sq_fit_options_default(); o.taper_max = 1.0;
    CHECK_RESULT(sqffd_sq_fit(pts, 200, &o, &fit, NULL, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    o = sqffd_sq_fit_options_default(); o.max_iterations = 0;
    CHECK_RESULT(sqffd_sq_fit(pts, 200, &o, &fit, NULL, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    o = sqffd_sq_fit_options_default(); o.tolerance = NAN;
    CHECK_RESULT(sqffd_sq_fit(pts, 200, &o, &fit, NULL, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    o = sqffd_sq_fit_options_default(); o.robust = 1; o.robust_rounds = 0;
    CHECK_RESULT(sqffd_sq_fit(pts, 200, &o, &fit, NULL, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    o = sqffd_sq_fit_options_default(); o.cost = (sqffd_sq_cost)7;
    CHECK_RESULT(sqffd_sq_fit(pts, 200, &o, &fit, NULL, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    o = sqffd_sq_fit_options_default(); o.shape_min = 0.0;
    CHECK_RESULT(sqffd_sq_fit(pts, 200, &o, &fit, NULL, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    free(work);
}

/* Too small a workspace is refused; the exact size is enough and nothing
   beyond it is touched (canary bytes), also at an odd alignment. */
static void test_sq_fit_workspace(void)
{
    synth_rng rng = synth_rng_seed(13);
    sqffd_superquadric truth, fit;
    double pts[3 * 1250];
    int variant;
    size_t m = make_case(&rng, DATA_OUTLIERS, 1000, &truth, pts), too_large = 1;
    CHECK_RESULT(sqffd_sq_fit_workspace_size((size_t)-1 / 2, NULL, &too_large), SQFFD_ERROR_TOO_LARGE); /* not representable */
    CHECK(too_large == 0);
    for (variant = 0; variant < 3; variant++) {
        sqffd_sq_fit_options o = sqffd_sq_fit_options_default();
        size_t size, k;
        unsigned char *block;
        o.robust = variant == 1;
        o.optimizer = variant == 2 ? SQFFD_SQ_OPTIMIZER_CG : SQFFD_SQ_OPTIMIZER_LM;
        if (variant == 2) m = 300; /* keep the CG quick */
        CHECK_RESULT(sqffd_sq_fit_workspace_size(m, &o, &size), SQFFD_OK);
        CHECK(size > 0);
        block = (unsigned char *)malloc(size + 64 + 1);
        memset(block, 0xab, size + 64 + 1);
        CHECK_RESULT(sqffd_sq_fit(pts, m, &o, &fit, NULL, block + 1, size - 1), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
        CHECK_RESULT(sqffd_sq_fit(pts, m, &o, &fit, NULL, block + 1, size / 2), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
        memset(block, 0xab, size + 64 + 1);
        CHECK_RESULT(sqffd_sq_fit(pts, m, &o, &fit, NULL, block + 1, size), SQFFD_OK);
        for (k = size + 1; k < size + 64 + 1; k++) CHECK_MSG(block[k] == 0xab, "canary byte %zu overwritten", k - size - 1);
        CHECK(block[0] == 0xab);
        free(block);
    }
}

void suite_superquadric(void)
{
    RUN_TEST(test_sq_surface_points_have_f_one);
    RUN_TEST(test_sq_normals_orthogonal_and_outward);
    RUN_TEST(test_sq_normals_finite_at_poles_and_small_e);
    RUN_TEST(test_sq_volume_closed_form);
    RUN_TEST(test_sq_sphere_analytic);
    RUN_TEST(test_sq_ellipsoid_points);
    RUN_TEST(test_sq_grid_layout);
    RUN_TEST(test_sq_uniform_sampling_even);
    RUN_TEST(test_sq_iou);
    RUN_TEST(test_sq_fit_clean);
    RUN_TEST(test_sq_fit_noise);
    RUN_TEST(test_sq_fit_cut);
    RUN_TEST(test_sq_fit_outliers_robust);
    RUN_TEST(test_sq_fit_robust_report);
    RUN_TEST(test_sq_fit_options_variants);
    RUN_TEST(test_sq_fit_final_points);
    RUN_TEST(test_sq_fit_cg);
    RUN_TEST(test_sq_fit_deterministic);
    RUN_TEST(test_sq_fit_similarity);
    RUN_TEST(test_sq_fit_progress_cancel);
    RUN_TEST(test_sq_fit_no_runaway);
    RUN_TEST(test_sq_fit_no_collapse);
    RUN_TEST(test_sq_fit_bad_input);
    RUN_TEST(test_sq_fit_workspace);
}

/* Superquadric layer: geometry against analytic values and brute force, and
   the fit against ground truth (random superquadrics, volumetric IoU). */
#include "test.h"
#include "../examples/sqffd_synth.h"
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
                f = sqffd_sq_inside_outside(&sq, p);
                CHECK_MSG(fabs(f - 1.0) < 1e-9, "shape %d: F = %.15g at eta %g omega %g (e %g %g)", s, f, eta, omega,
                          sq.shape[0], sq.shape[1]);
                CHECK_MSG(sqffd_sq_radial_distance(&sq, p) < 1e-9 * synth_mean_size(&sq), "radial distance on surface");
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
                CHECK(sqffd_sq_inside_outside(&sq, q) > 1.0);
                for (k = 0; k < 3; k++) q[k] = p[k] - step * n[k];
                CHECK(sqffd_sq_inside_outside(&sq, q) < 1.0);
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
                count += sqffd_sq_inside_outside(sq, p) <= 1.0;
            }
    return count * cell;
}

static void test_sq_volume_closed_form(void)
{
    sqffd_superquadric sphere = sq_make(2, 2, 2, 1, 1, 0, 0);
    sqffd_superquadric ellipsoid = sq_make(1, 2, 3, 1, 1, 0, 0);
    sqffd_superquadric cases[5];
    int i;
    CHECK_NEAR(sqffd_sq_volume(&sphere), 4.0 / 3.0 * SYNTH_PI * 8.0, 1e-12);
    CHECK_NEAR(sqffd_sq_volume(&ellipsoid), 4.0 / 3.0 * SYNTH_PI * 6.0, 1e-12);
    /* a near-box: e -> 0 tends to 8 a1 a2 a3 */
    ellipsoid = sq_make(1, 2, 3, 0.01, 0.01, 0, 0);
    CHECK_NEAR(sqffd_sq_volume(&ellipsoid) / 48.0, 1.0, 0.02);
    /* octahedron: e1 = e2 = 2, volume 4/3 a1 a2 a3 */
    ellipsoid = sq_make(1, 2, 3, 2, 2, 0, 0);
    CHECK_NEAR(sqffd_sq_volume(&ellipsoid), 8.0, 1e-12);
    /* tapered and untapered against a grid count */
    cases[0] = sq_make(1, 2, 3, 0.5, 1.5, 0, 0);
    cases[1] = sq_make(1, 2, 3, 0.5, 1.5, 0.6, 0.5);
    cases[2] = sq_make(2, 1, 1.5, 1.8, 0.2, -0.7, 0.6);
    cases[3] = sq_make(1.5, 1, 2, 0.2, 1.0, 0.9, 0.9);
    cases[4] = sq_make(1, 1, 1, 1.0, 1.0, 0.8, -0.3);
    for (i = 0; i < 5; i++) {
        double exact = sqffd_sq_volume(&cases[i]), grid = volume_by_grid(&cases[i], 80);
        printf("    vol %.5f\n", grid/exact-1); CHECK_MSG(fabs(grid / exact - 1.0) < 0.005, "case %d: volume %.6f, grid %.6f", i, exact, grid);
    }
    /* tapering with Kx Ky < 0 shrinks, > 0 grows */
    CHECK(sqffd_sq_volume(&cases[4]) < sqffd_sq_volume(&sphere) / 8.0);
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
        CHECK_NEAR(sqffd_sq_inside_outside(&sq, p), r * r / 4.0, 1e-12 * r * r);
        CHECK_NEAR(sqffd_sq_radial_distance(&sq, p), fabs(r - 2.0), 1e-12);
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
        qsort(d, n, sizeof *d, synth__cmp_double);
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
        size_t count = sqffd_sq_sample_uniform(&shapes[s], spacing, NULL, 0), again, m;
        double *pts = (double *)malloc(3 * count * sizeof *pts);
        double *grid;
        int side;
        again = sqffd_sq_sample_uniform(&shapes[s], spacing, pts, count);
        CHECK(again == count);
        CHECK(count > 100);
        cv_uniform = nn_spread(pts, count, &med);
        CHECK_MSG(med > 0.5 * spacing && med < 1.05 * spacing, "shape %d: median spacing %g for %g", s, med, spacing);
        CHECK(sqffd_sq_sample_uniform(&shapes[s], spacing, pts, 10) == count); /* capacity respected, count kept */
        /* a grid with about as many points */
        side = (int)sqrt((double)count / 2.0);
        m = (size_t)side * (size_t)(2 * side);
        grid = (double *)malloc(3 * m * sizeof *grid);
        CHECK_RESULT(sqffd_sq_sample_grid(&shapes[s], side, 2 * side, grid, NULL), SQFFD_OK);
        cv_grid = nn_spread(grid + 3 * (size_t)(2 * side), m - (size_t)(4 * side), NULL); /* without the pole rows */
        printf("    spread %.3f vs %.3f\n", cv_uniform, cv_grid); CHECK_MSG(cv_uniform < 0.6 * cv_grid, "shape %d: NN-distance spread %.3f (uniform) vs %.3f (grid)", s, cv_uniform,
                  cv_grid);
        free(pts);
        free(grid);
    }
    CHECK(sqffd_sq_sample_uniform(&shapes[0], 0.0, NULL, 0) == 0);
    CHECK(sqffd_sq_sample_uniform(&shapes[0], 1e-9, NULL, 0) == 0);
}

static void test_sq_iou(void)
{
    sqffd_superquadric a = sq_make(1, 2, 3, 0.4, 1.3, 0.3, -0.2), b, c;
    synth_rng rng = synth_rng_seed(4);
    synth_rotation(&rng, a.rotation);
    CHECK_NEAR(sqffd_sq_iou(&a, &a, 40), 1.0, 0.0);
    b = sq_make(1, 1, 1, 1, 1, 0, 0);
    c = sq_make(1.5, 1.5, 1.5, 1, 1, 0, 0);
    CHECK_NEAR(sqffd_sq_iou(&b, &c, 64), 1.0 / 3.375, 0.01);
    CHECK_NEAR(sqffd_sq_iou(&c, &b, 64), 1.0 / 3.375, 0.01);
    c.center[0] = 10.0; /* disjoint */
    CHECK_NEAR(sqffd_sq_iou(&b, &c, 32), 0.0, 0.0);
    /* half-overlapping boxes: 1/3 */
    b = sq_make(1, 1, 1, 0.1, 0.1, 0, 0);
    c = b;
    c.center[0] = 1.0;
    CHECK_NEAR(sqffd_sq_iou(&b, &c, 60), 1.0 / 3.0, 0.02);
    CHECK(sqffd_sq_iou(&b, &c, 0) < 0.0);
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
}

/* The synthetic beating left ventricle (examples/sqffd_phantom.h): its
   motion, the hypokinetic zone, the closed cavity's volume and ejection
   fraction, random frames and the ground truth of a point, each against
   truth derived here (closed forms, the test's own meshes and quadratures). */
#include "test.h"
#include "../examples/sqffd_phantom.h"
#include <string.h>
#include <time.h>

/* ---- helpers ------------------------------------------------------------- */

static double dist(const double a[3], const double b[3])
{
    return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

static double tri_area(const double a[3], const double b[3], const double c[3])
{
    double e[3], f[3], n[3];
    int k;
    for (k = 0; k < 3; k++) { e[k] = b[k] - a[k]; f[k] = c[k] - a[k]; }
    n[0] = e[1] * f[2] - e[2] * f[1]; n[1] = e[2] * f[0] - e[0] * f[2]; n[2] = e[0] * f[1] - e[1] * f[0];
    return 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
}

/* Area of the cup's cell [u0, u1] x [t0, t1] at a phase (two triangles). */
static double cell_area(const phantom_lv *p, double phase, double u0, double u1, double t0, double t1)
{
    double a[3], b[3], c[3], d[3];
    phantom_lv_point(p, phase, u0, t0, a);
    phantom_lv_point(p, phase, u0, t1, b);
    phantom_lv_point(p, phase, u1, t1, c);
    phantom_lv_point(p, phase, u1, t0, d);
    return tri_area(a, b, c) + tri_area(a, c, d);
}

/* The share of the cup's area at a phase that is in the zone (cells by
   their centre), on an nu x 2nu grid. */
static double zone_share(const phantom_lv *p, double phase, int nu)
{
    double zone = 0.0, total = 0.0;
    int i, j, nt = 2 * nu;
    for (i = 0; i < nu; i++)
        for (j = 0; j < nt; j++) {
            double u0 = (double)i / nu, u1 = (i + 1.0) / nu;
            double t0 = -PHANTOM_PI + 2.0 * PHANTOM_PI * j / nt, t1 = -PHANTOM_PI + 2.0 * PHANTOM_PI * (j + 1) / nt;
            double a = cell_area(p, phase, u0, u1, t0, t1);
            total += a;
            if (phantom_lv_in_zone(p, 0.5 * (u0 + u1), 0.5 * (t0 + t1))) zone += a;
        }
    return zone / total;
}

/* Angle between the unit directions of two material points, straight from
   the definition (polar angle u base_angle from -z). */
static double sphere_angle(const phantom_lv *p, double u, double t, double u0, double t0)
{
    double a = u * p->base_angle, b = u0 * p->base_angle;
    double c = sin(a) * sin(b) * cos(t - t0) + cos(a) * cos(b);
    return acos(c > 1.0 ? 1.0 : c < -1.0 ? -1.0 : c);
}

static uint64_t rng_state; /* each test that draws sets it first */
static double rnd(void) /* xorshift64, uniform in [0, 1) */
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) / 9007199254740992.0;
}

/* The plain cup (no bumps, no zone) of the default's size. */
static phantom_lv plain(void)
{
    phantom_lv p = phantom_lv_default();
    p.bump_height = 0.0;
    p.low_motion_factor = 1.0;
    return p;
}

/* Area of the plain cup (a prolate spheroid's zone from the apex to polar
   angle base_angle): 2 pi R int_0^b sin(psi) sqrt(R^2 cos^2 + H^2 sin^2) dpsi,
   by Simpson's rule. */
static double plain_cup_area(const phantom_lv *p)
{
    enum { N = 2000 };
    double sum = 0.0, h = p->base_angle / N;
    int i;
    for (i = 0; i <= N; i++) {
        double psi = i * h, c = cos(psi), s = sin(psi);
        double f = s * sqrt(p->radius * p->radius * c * c + p->height * p->height * s * s);
        sum += (i == 0 || i == N ? 1.0 : i % 2 ? 4.0 : 2.0) * f;
    }
    return 2.0 * PHANTOM_PI * p->radius * sum * h / 3.0;
}

/* ---- the beat ------------------------------------------------------------ */

/* A material point keeps its (u, theta) through the beat: the apex stays,
   the hypokinetic zone moves a fraction of the opposite wall, a whole beat
   returns; phantom_lv_sample spans the cup. */
static void test_phantom_beat(void)
{
    phantom_lv p = phantom_lv_default();
    double a[3], b[3], apex[3], zone0[3], zone1[3], far0[3], far1[3], lo[3], hi[3], pts[3 * 2000];
    size_t i;
    int c;
    phantom_lv_point(&p, 0.0, 0.0, 0.3, apex);
    phantom_lv_point(&p, 0.5, 0.0, 1.7, a);
    CHECK(dist(apex, a) < 1e-12);
    CHECK(fabs(apex[0]) < 1e-12 && fabs(apex[1]) < 1e-12 && apex[2] < -0.9 * p.height);
    phantom_lv_point(&p, 0.0, p.low_motion[0], p.low_motion[1], zone0);
    phantom_lv_point(&p, 0.5, p.low_motion[0], p.low_motion[1], zone1);
    phantom_lv_point(&p, 0.0, p.low_motion[0], p.low_motion[1] + PHANTOM_PI, far0);
    phantom_lv_point(&p, 0.5, p.low_motion[0], p.low_motion[1] + PHANTOM_PI, far1);
    printf("      zone centre moves %.3f mm, the opposite wall %.3f mm (x %.3f)\n", dist(zone0, zone1),
           dist(far0, far1), dist(zone0, zone1) / dist(far0, far1));
    CHECK_MSG(dist(zone0, zone1) < 0.25 * dist(far0, far1), "zone moves %g, opposite wall %g", dist(zone0, zone1),
              dist(far0, far1));
    CHECK(dist(zone0, zone1) > 0.1 * dist(far0, far1)); /* 20% of normal motion, not none */
    phantom_lv_point(&p, 0.0, 0.5, 1.0, a);
    phantom_lv_point(&p, 1.0, 0.5, 1.0, b);
    CHECK(dist(a, b) < 1e-9); /* a whole beat returns */
    phantom_lv_sample(&p, 0.0, 2000, pts);
    for (c = 0; c < 3; c++) { lo[c] = HUGE_VAL; hi[c] = -HUGE_VAL; }
    for (i = 0; i < 2000; i++)
        for (c = 0; c < 3; c++) {
            if (pts[3 * i + c] < lo[c]) lo[c] = pts[3 * i + c];
            if (pts[3 * i + c] > hi[c]) hi[c] = pts[3 * i + c];
        }
    CHECK(lo[2] > apex[2] - 0.01 * p.height && hi[2] < 0.5 * p.height); /* from about the apex to the base rim */
    CHECK(hi[0] - lo[0] > 1.5 * p.radius && hi[1] - lo[1] > 1.5 * p.radius);
}

/* phantom_lv_sample at phase 0 is what it was before the heartbeat grew
   (values printed by the previous header), and the zone cannot change it. */
static void test_phantom_sample_unchanged(void)
{
    static const double before[4][3] = {
        {-0.47927234150911741, -5.8693933894899775e-17, -46.043819119891424},
        {10.882829285915641, -15.786852375216327, -30.464750618015433},
        {25.088299916283251, -2.836968574696241, -3.915264880460974},
        {20.399837798820045, -12.22040035737284, 13.902870808794873}};
    static const int index[4] = {0, 1234, 3999, 5999};
    static double pts[3 * 6000], other[3 * 6000];
    phantom_lv p = phantom_lv_default();
    int i, c;
    phantom_lv_sample(&p, 0.0, 6000, pts);
    for (i = 0; i < 4; i++)
        for (c = 0; c < 3; c++) CHECK_NEAR(pts[3 * index[i] + c], before[i][c], 1e-12 * 50.0);
    p.low_motion[0] = 0.2; p.low_motion[1] = 2.0; p.low_motion[2] = 0.9; p.low_motion_factor = 0.0;
    phantom_lv_sample(&p, 0.0, 6000, other);
    CHECK(memcmp(pts, other, sizeof pts) == 0);
}

/* ---- the hypokinetic zone ------------------------------------------------ */

/* The motion weight is low_motion_factor on the plateau, 1 beyond the ramp,
   continuous and monotone across it, halfway at the truth region's edge;
   the zone covers 12-18% of the ED wall. */
static void test_phantom_zone(void)
{
    phantom_lv p = phantom_lv_default();
    double r = p.low_motion[2], f = p.low_motion_factor, u0 = p.low_motion[0], t0 = p.low_motion[1];
    double prev = -1.0, max_jump = 0.0, share;
    int i, k, inside = 0, outside = 0;
    CHECK_NEAR(f, 0.2, 0.0);
    rng_state = 88172645463325252ULL;
    /* random material points: plateau, beyond, and in_zone against the angle */
    for (i = 0; i < 20000; i++) {
        double u = rnd(), t = -PHANTOM_PI + 2.0 * PHANTOM_PI * rnd(), angle = sphere_angle(&p, u, t, u0, t0);
        double w = phantom_lv_motion(&p, u, t);
        if (angle < r - 1e-9) { CHECK_NEAR(w, f, 1e-15); inside++; }
        if (angle > r + PHANTOM_ZONE_RAMP + 1e-9) { CHECK_NEAR(w, 1.0, 0.0); outside++; }
        CHECK(w >= f && w <= 1.0);
        if (fabs(angle - (r + 0.5 * PHANTOM_ZONE_RAMP)) > 1e-9)
            CHECK_MSG(phantom_lv_in_zone(&p, u, t) == (angle < r + 0.5 * PHANTOM_ZONE_RAMP), "u %g theta %g angle %g",
                      u, t, angle);
    }
    CHECK(inside > 100 && outside > 10000);
    /* across the ramp along the meridian theta = t0: steps of 1e-4 rad from
       the centre outward; a jump would show as a step far above the slope's */
    for (k = 0; k <= 10000; k++) {
        double angle = 1e-4 * k, w = phantom_lv_motion(&p, u0 + angle / p.base_angle, t0);
        if (prev >= 0.0) {
            if (fabs(w - prev) > max_jump) max_jump = fabs(w - prev);
            CHECK(w >= prev - 1e-15); /* monotone */
        }
        prev = w;
        if (fabs(angle - (r + 0.5 * PHANTOM_ZONE_RAMP)) < 5e-5) CHECK_NEAR(w, 0.5 * (1.0 + f), 1e-3);
    }
    /* the steepest slope of the cosine ramp is (1 - f) pi / 2 / ramp */
    CHECK_MSG(max_jump <= 1.01 * (1.0 - f) * PHANTOM_PI / 2.0 / PHANTOM_ZONE_RAMP * 1e-4, "jump %g", max_jump);
    CHECK(max_jump > 0.9 * (1.0 - f) * PHANTOM_PI / 2.0 / PHANTOM_ZONE_RAMP * 1e-4);
    share = zone_share(&p, 0.0, 200);
    printf("      zone: %.2f%% of the ED wall's area (plateau radius %.3f rad, ramp %.2f rad)\n", 100.0 * share, r,
           PHANTOM_ZONE_RAMP);
    CHECK_MSG(share > 0.12 && share < 0.18, "zone share %g", share);
    CHECK_NEAR(zone_share(&p, 0.0, 100), share, 1e-3); /* the quadrature has converged */
}

/* ---- the closed cavity --------------------------------------------------- */

/* The plain cup at ED closed by its flat lid is the prolate spheroid's cap
   below z = -H cos(b): integral of pi R^2 (1 - z^2 / H^2) from -H to
   -H cos(b) = pi R^2 H (1 - cos b)^2 (2 + cos b) / 3. With a uniform beat
   (no zone) every point - and the rim's centroid with them - moves by one
   affine map, x, y scaled by 1 - contraction, z toward the apex by
   1 - shortening: the ES volume is the ED one times their product. */
static void test_phantom_volume_closed_form(void)
{
    static const double angles[3] = {0.6 * PHANTOM_PI, 0.5 * PHANTOM_PI, 0.8 * PHANTOM_PI};
    phantom_lv p = plain(), q = phantom_lv_default();
    double cup, lid, uniform;
    int a;
    for (a = 0; a < 3; a++) {
        double c = cos(angles[a]), truth;
        p.base_angle = angles[a];
        truth = PHANTOM_PI * p.radius * p.radius * p.height * (1.0 - c) * (1.0 - c) * (2.0 + c) / 3.0;
        CHECK_MSG(fabs(phantom_lv_volume(&p, 0.0) / truth - 1.0) < 1e-6, "base angle %g: volume %.10g, closed form %.10g",
                  angles[a], phantom_lv_volume(&p, 0.0), truth);
        CHECK_NEAR(phantom_lv_volume(&p, 0.5) / truth, (1.0 - p.contraction) * (1.0 - p.contraction) * (1.0 - p.shortening),
                   1e-6);
    }
    p.base_angle = 0.6 * PHANTOM_PI; /* areas: the lid is the disc of radius R sin(b) */
    phantom_lv_areas(&p, 0.0, &cup, &lid);
    CHECK_NEAR(cup / plain_cup_area(&p), 1.0, 1e-5);
    CHECK_NEAR(lid / (PHANTOM_PI * pow(p.radius * sin(p.base_angle), 2)), 1.0, 1e-5);
    /* bumps, no zone: still one affine map */
    q.low_motion_factor = 1.0;
    uniform = (1.0 - q.contraction) * (1.0 - q.contraction) * (1.0 - q.shortening);
    CHECK_NEAR(phantom_lv_volume(&q, 0.5) / phantom_lv_volume(&q, 0.0), uniform, 1e-6);
    CHECK_NEAR(phantom_lv_ejection_fraction(&q, 2), 1.0 - uniform, 1e-6);
}

/* The raw meshes converge as 1 / resolution^2; phantom_lv_volume is their
   extrapolation from 128 x 256 and 256 x 512, and agrees with the one from
   twice that resolution to 1e-5 (relative), closer than the one from half. */
static void test_phantom_volume_convergence(void)
{
    static const double phases[3] = {0.0, 0.25, 0.5};
    phantom_lv p = phantom_lv_default();
    int k;
    for (k = 0; k < 3; k++) {
        double m1[3], m2[3], m4[3], m8[3], ratio, coarser, same, finer, v = phantom_lv_volume(&p, phases[k]);
        phantom_lv_measure_mesh(&p, phases[k], 64, 128, m1);
        phantom_lv_measure_mesh(&p, phases[k], 128, 256, m2);
        phantom_lv_measure_mesh(&p, phases[k], 256, 512, m4);
        phantom_lv_measure_mesh(&p, phases[k], 512, 1024, m8);
        ratio = (m2[0] - m1[0]) / (m4[0] - m2[0]);
        CHECK_MSG(ratio > 3.5 && ratio < 4.5, "phase %g: convergence ratio %g", phases[k], ratio);
        CHECK(m1[0] < m2[0] && m2[0] < m4[0] && m4[0] < m8[0]); /* inscribed: the meshes grow toward the truth */
        coarser = (4.0 * m2[0] - m1[0]) / 3.0;
        same = (4.0 * m4[0] - m2[0]) / 3.0;
        finer = (4.0 * m8[0] - m4[0]) / 3.0;
        printf("      phase %.2f: volume %.3f mm^3, relative to the extrapolation at twice the resolution %+.1e"
               " (at half: %+.1e)\n", phases[k], v, v / finer - 1.0, coarser / finer - 1.0);
        CHECK_NEAR(v / same, 1.0, 1e-14);
        CHECK_MSG(fabs(v / finer - 1.0) < 1e-5, "phase %g: %.10g against %.10g", phases[k], v, finer);
        CHECK(fabs(v / finer - 1.0) < fabs(coarser / finer - 1.0)); /* the error shrinks */
    }
}

/* ED > ES, the volume falls through systole and is periodic; the default's
   EF, and the EF over frames that miss ES. */
static void test_phantom_ejection_fraction(void)
{
    phantom_lv p = phantom_lv_default(), normal = phantom_lv_default();
    double prev = HUGE_VAL, ef, ef20, ef7, v0 = phantom_lv_volume(&p, 0.0), v5 = phantom_lv_volume(&p, 0.5);
    int k;
    for (k = 0; k <= 4; k++) {
        double v = phantom_lv_volume(&p, k / 8.0);
        CHECK_MSG(v < prev, "phase %g: volume %g after %g", k / 8.0, v, prev);
        prev = v;
    }
    CHECK(v0 > v5);
    CHECK_NEAR(phantom_lv_volume(&p, 0.3), phantom_lv_volume(&p, 1.3), 1e-12 * v0);
    CHECK_NEAR(phantom_lv_volume(&p, 0.3), phantom_lv_volume(&p, 0.7), 1e-12 * v0); /* systole mirrors diastole */
    ef = (v0 - v5) / v0;
    ef20 = phantom_lv_ejection_fraction(&p, 20);
    ef7 = phantom_lv_ejection_fraction(&p, 7);
    printf("      EDV %.1f mm^3, ESV %.1f mm^3, EF %.2f%% (7 frames: %.2f%%)\n", v0, v5, 100.0 * ef, 100.0 * ef7);
    CHECK_NEAR(ef20, ef, 1e-12);
    CHECK(ef > 0.40 && ef < 0.65);
    CHECK_NEAR(ef7, (v0 - phantom_lv_volume(&p, 3.0 / 7.0)) / v0, 1e-12); /* phases 3/7 and 4/7 are nearest ES */
    CHECK(ef7 < ef);
    normal.low_motion_factor = 1.0;
    CHECK(phantom_lv_ejection_fraction(&normal, 2) > ef + 0.01); /* the zone costs ejection */
    CHECK(phantom_lv_ejection_fraction(&p, 0) == 0.0);
}

/* ---- frames -------------------------------------------------------------- */

/* The rejection sampler's bound holds: the cup's area element over sin(psi)
   on a fine grid stays below it (default and a bumpier phantom, all phases). */
static void test_phantom_frame_bound(void)
{
    phantom_lv p = phantom_lv_default();
    int v, k, i, j;
    for (v = 0; v < 2; v++) {
        if (v == 1) { p.bump_height = 0.3; p.low_motion_factor = 0.0; }
        for (k = 0; k <= 4; k++) {
            phantom__state s;
            double most = 0.0, bound;
            phantom__prepare(&p, k / 8.0, &s);
            bound = phantom__cup_bound(&p, &s);
            for (i = 0; i < 200; i++)
                for (j = 0; j < 400; j++) {
                    double r = phantom__cup_ratio(&p, &s, (i + 0.5) / 200.0, -PHANTOM_PI + 2.0 * PHANTOM_PI * (j + 0.5) / 400.0);
                    if (r > most) most = r;
                }
            CHECK_MSG(most < bound, "variant %d phase %g: %g > bound %g", v, k / 8.0, most, bound);
        }
    }
}

/* Points are area-weighted at the frame's phase: the lid's share is its area
   share; the cup's points fall in bands of u and in the zone in proportion to
   the areas (the test's own mesh), at ED and at ES. */
static void test_phantom_frame_areas(void)
{
    enum { N = 20000, BANDS = 8, USED = 3000 };
    static double pts[3 * N];
    static unsigned char label[N];
    phantom_lv p = phantom_lv_default();
    int k, b;
    size_t i;
    for (k = 0; k < 2; k++) {
        double phase = 0.5 * k, cup, lid, share, zone, band_area[BANDS] = {0}, total = 0.0, s[2];
        int count[3] = {0, 0, 0}, band[BANDS] = {0}, ii, j, used;
        phantom_lv_frame(&p, phase, N, 0.0, 11 + (uint64_t)k, pts, label);
        for (i = 0; i < N; i++) {
            CHECK(label[i] <= 2);
            count[label[i] <= 2 ? label[i] : 0]++;
        }
        phantom_lv_areas(&p, phase, &cup, &lid);
        share = lid / (cup + lid);
        zone = zone_share(&p, phase, 100);
        printf("      phase %.1f: lid %.2f%% of the points, %.2f%% of the area; zone %.2f%% of the cup's points,"
               " %.2f%% of its area\n", phase, 100.0 * count[2] / N, 100.0 * share,
               100.0 * count[1] / (N - count[2]), 100.0 * zone);
        /* binomial standard deviations: ~0.25% and ~0.3%; 4 of them */
        CHECK_NEAR((double)count[2] / N, share, 0.01);
        CHECK_NEAR((double)count[1] / (N - count[2]), zone, 4.0 * sqrt(zone * (1.0 - zone) / (N - count[2])) + 0.002);
        /* bands of u: the cup's own mesh area per band, against the material
           u of the first USED cup points (their nearest material point) */
        for (ii = 0; ii < 80; ii++)
            for (j = 0; j < 160; j++) {
                double a = cell_area(&p, phase, ii / 80.0, (ii + 1) / 80.0, -PHANTOM_PI + 2.0 * PHANTOM_PI * j / 160,
                                     -PHANTOM_PI + 2.0 * PHANTOM_PI * (j + 1) / 160);
                band_area[ii * BANDS / 80] += a;
                total += a;
            }
        for (i = 0, used = 0; i < N && used < USED; i++)
            if (label[i] != PHANTOM_LID) {
                double d;
                phantom_lv_nearest(&p, phase, pts + 3 * i, s, &d);
                b = (int)(s[0] * BANDS);
                band[b < BANDS ? b : BANDS - 1]++;
                used++;
            }
        for (b = 0; b < BANDS; b++) {
            double expect = band_area[b] / total, got = (double)band[b] / USED;
            CHECK_MSG(fabs(got - expect) < 4.0 * sqrt(expect * (1.0 - expect) / USED) + 0.002,
                      "phase %g band %d: %.4f of the points, %.4f of the area", phase, b, got, expect);
        }
    }
}

/* The lid: its centre is the rim's mean (the test's own 1,000 rim points),
   f = 0 is the centre and f = 1 the rim. On the plain cup with a uniform beat
   the lid stays the flat disc of radius R sin(b) (1 - contraction): a frame's
   lid points lie on it, spread evenly by area (rings, halves). */
static void test_phantom_frame_lid(void)
{
    enum { N = 20000 };
    static double pts[3 * N];
    static unsigned char label[N];
    phantom_lv p = phantom_lv_default(), q = plain();
    double c[3], mean[3] = {0.0, 0.0, 0.0}, x[3], y[3], rho_rim, z_rim, worst = 0.0;
    int j, k, lid = 0, ring[3] = {0, 0, 0}, half = 0;
    size_t i;
    for (k = 0; k < 2; k++) {
        double phase = 0.5 * k;
        phantom_lv_rim_centroid(&p, phase, c);
        for (j = 0; j < 1000; j++) {
            phantom_lv_point(&p, phase, 1.0, -PHANTOM_PI + 2.0 * PHANTOM_PI * (j + 0.25) / 1000, x);
            mean[0] += x[0] / 1000; mean[1] += x[1] / 1000; mean[2] += x[2] / 1000;
        }
        CHECK(dist(mean, c) < 1e-9);
        mean[0] = mean[1] = mean[2] = 0.0;
        phantom_lv_lid_point(&p, phase, 0.0, 1.3, x);
        CHECK(dist(x, c) < 1e-12);
        phantom_lv_lid_point(&p, phase, 1.0, 1.3, x);
        phantom_lv_point(&p, phase, 1.0, 1.3, y);
        CHECK(dist(x, y) < 1e-12);
    }
    phantom_lv_frame(&q, 0.5, N, 0.0, 3, pts, label);
    rho_rim = q.radius * sin(q.base_angle) * (1.0 - q.contraction);
    phantom_lv_point(&q, 0.5, 1.0, 0.0, x);
    z_rim = x[2];
    for (i = 0; i < N; i++)
        if (label[i] == PHANTOM_LID) {
            double rho2 = (pts[3 * i] * pts[3 * i] + pts[3 * i + 1] * pts[3 * i + 1]) / (rho_rim * rho_rim);
            if (fabs(pts[3 * i + 2] - z_rim) > worst) worst = fabs(pts[3 * i + 2] - z_rim);
            CHECK(rho2 <= 1.0 + 1e-12);
            for (k = 0; k < 3; k++)
                if (rho2 < 0.25 * (k + 1)) ring[k]++;
            if (pts[3 * i] > 0.0) half++;
            lid++;
        }
    CHECK_MSG(worst < 1e-9, "a lid point %g mm off the valve plane", worst);
    CHECK(lid > 1000);
    for (k = 0; k < 3; k++) /* within 4 binomial standard deviations */
        CHECK_MSG(fabs((double)ring[k] / lid - 0.25 * (k + 1)) < 4.0 * sqrt(0.25 * (k + 1) * (0.75 - 0.25 * k) / lid),
                  "ring %d: %g of the lid points", k, (double)ring[k] / lid);
    CHECK(fabs((double)half / lid - 0.5) < 4.0 * sqrt(0.25 / lid));
}

/* Without noise every point lies on the closed surface at its phase, with
   the label of its material point; with noise the displacement from the
   noiseless frame of the same seed has standard deviation noise x scale;
   seeds differ, a seed repeats. */
static void test_phantom_frame_points(void)
{
    enum { N = 6000 };
    static double a[3 * N], b[3 * N], c[3 * N];
    static unsigned char la[N], lb[N];
    phantom_lv p = phantom_lv_default();
    double scale = phantom_lv_scale(&p), worst = 0.0, sum = 0.0, sum2 = 0.0, sd;
    int k, mismatched = 0, same = 0;
    size_t i;
    { /* the scale: the ED cup's bounding box over a finer grid */
        double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL}, x[3];
        int ii, j, c;
        for (ii = 0; ii <= 256; ii++)
            for (j = 0; j < 512; j++) {
                phantom_lv_point(&p, 0.0, ii / 256.0, -PHANTOM_PI + 2.0 * PHANTOM_PI * j / 512, x);
                for (c = 0; c < 3; c++) {
                    if (x[c] < lo[c]) lo[c] = x[c];
                    if (x[c] > hi[c]) hi[c] = x[c];
                }
            }
        printf("      scale (ED cup's bounding-box diagonal) %.4f mm, %.4f on a finer grid\n", scale, dist(lo, hi));
        CHECK_NEAR(scale / dist(lo, hi), 1.0, 1e-4);
    }
    for (k = 0; k < 3; k++) {
        double phase = 0.25 * k;
        phantom_lv_frame(&p, phase, N, 0.0, 5, a, la);
        for (i = 0; i < N; i += 3) {
            double m[2], d;
            int l = phantom_lv_nearest(&p, phase, a + 3 * i, m, &d);
            if (d > worst) worst = d;
            if (l != la[i]) mismatched++;
        }
    }
    CHECK_MSG(worst < 1e-9 * scale, "a noiseless point %g mm off the surface", worst);
    CHECK_MSG(mismatched == 0, "%d labels differ from the nearest material point's", mismatched);
    /* noise */
    phantom_lv_frame(&p, 0.5, N, 0.0, 99, a, la);
    phantom_lv_frame(&p, 0.5, N, 0.01, 99, b, lb);
    CHECK(memcmp(la, lb, N) == 0);
    for (i = 0; i < 3 * N; i++) {
        sum += b[i] - a[i];
        sum2 += (b[i] - a[i]) * (b[i] - a[i]);
    }
    sd = sqrt(sum2 / (3 * N));
    printf("      noise 0.01: measured standard deviation %.4f mm (0.01 x scale %.4f), mean %.4f mm\n", sd, 0.01 * scale,
           sum / (3 * N));
    CHECK_NEAR(sd / (0.01 * scale), 1.0, 0.03);
    CHECK(fabs(sum / (3 * N)) < 4.0 * 0.01 * scale / sqrt(3.0 * N));
    /* seeds */
    phantom_lv_frame(&p, 0.5, N, 0.01, 100, c, NULL);
    for (i = 0; i < N; i++)
        if (dist(b + 3 * i, c + 3 * i) < 1e-9) same++;
    CHECK_MSG(same == 0, "%d points equal across seeds", same);
    phantom_lv_frame(&p, 0.5, N, 0.01, 99, c, NULL);
    CHECK(memcmp(b, c, sizeof b) == 0);
    phantom_lv_frame(&p, 0.5, 0, 0.01, 99, NULL, NULL); /* nothing to draw: nothing touched */
}

/* ---- ground truth -------------------------------------------------------- */

/* Points on the ED surface from known material points (cup and lid): the
   right label, the displacement (and the motion vector) within 1e-3 x scale
   (in fact to rounding);
   from noisy points, never farther than the point they came from. */
static void test_phantom_locate(void)
{
    enum { N = 2000 };
    phantom_lv p = phantom_lv_default();
    double scale = phantom_lv_scale(&p), worst = 0.0, worst_noisy = 0.0, seconds;
    int wrong = 0, farther = 0, counts[3] = {0, 0, 0};
    size_t i;
    clock_t start = clock();
    rng_state = 2463534242ULL;
    for (i = 0; i < N; i++) {
        double x[3], y[3], got, truth, on_lid = rnd() < 0.2, a = rnd(), t = -PHANTOM_PI + 2.0 * PHANTOM_PI * rnd();
        int label, expect;
        if (on_lid) {
            phantom_lv_lid_point(&p, 0.0, a, t, x);
            phantom_lv_lid_point(&p, 0.5, a, t, y);
            expect = PHANTOM_LID;
        } else {
            phantom_lv_point(&p, 0.0, a, t, x);
            phantom_lv_point(&p, 0.5, a, t, y);
            expect = sphere_angle(&p, a, t, p.low_motion[0], p.low_motion[1]) < p.low_motion[2] + 0.5 * PHANTOM_ZONE_RAMP;
        }
        truth = dist(x, y);
        label = phantom_lv_locate(&p, x, &got);
        counts[expect]++;
        if (label != expect) wrong++;
        if (fabs(got - truth) > worst) worst = fabs(got - truth);
        if (i % 10 == 0) { /* the motion vector: ES - ED */
            double motion[3], moved[3];
            CHECK(phantom_lv_locate_motion(&p, x, motion) == label);
            moved[0] = x[0] + motion[0]; moved[1] = x[1] + motion[1]; moved[2] = x[2] + motion[2];
            if (dist(moved, y) > worst) worst = dist(moved, y);
            CHECK(phantom_lv_locate_motion(&p, x, NULL) == label && phantom_lv_locate(&p, x, NULL) == label);
        }
    }
    seconds = (double)(clock() - start) / CLOCKS_PER_SEC;
    printf("      %d wall, %d zone, %d lid points: %d labels wrong, displacement error at most %.2g mm; %.1f us a call\n",
           counts[0], counts[1], counts[2], wrong, worst, 1e6 * seconds / N);
    CHECK(counts[1] > 100 && counts[2] > 100);
    CHECK(wrong == 0);
    CHECK_MSG(worst < 1e-3 * scale, "displacement off by %g", worst);
    /* noisy points (0.5% of the scale): the nearest material point is at
       least as near as the one the point came from, and moves about as far */
    for (i = 0; i < 500; i++) {
        double x0[3], x[3], y[3], m[2], d, got, truth, u = rnd(), t = -PHANTOM_PI + 2.0 * PHANTOM_PI * rnd();
        int c;
        phantom_lv_point(&p, 0.0, u, t, x0);
        phantom_lv_point(&p, 0.5, u, t, y);
        truth = dist(x0, y);
        for (c = 0; c < 3; c++) x[c] = x0[c] + 0.005 * scale * (2.0 * rnd() - 1.0);
        phantom_lv_nearest(&p, 0.0, x, m, &d);
        if (d > dist(x, x0) + 1e-9) farther++;
        phantom_lv_locate(&p, x, &got);
        if (fabs(got - truth) > worst_noisy) worst_noisy = fabs(got - truth);
    }
    /* and at ES, 3% noise: where the zone's edge folds the wall */
    for (i = 0; i < 300; i++) {
        double x0[3], x[3], m[2], d, u = rnd(), t = p.low_motion[1] + 1.5 * (2.0 * rnd() - 1.0);
        int c;
        phantom_lv_point(&p, 0.5, u, t, x0);
        for (c = 0; c < 3; c++) x[c] = x0[c] + 0.03 * scale * (2.0 * rnd() - 1.0);
        phantom_lv_nearest(&p, 0.5, x, m, &d);
        if (d > dist(x, x0) + 1e-9) farther++;
    }
    printf("      noisy points: displacement off by at most %.3f mm\n", worst_noisy);
    CHECK_MSG(farther == 0, "%d nearest points farther than the point's own", farther);
    CHECK_MSG(worst_noisy < 0.02 * scale, "%g", worst_noisy);
}

void suite_phantom(void)
{
    RUN_TEST(test_phantom_beat);
    RUN_TEST(test_phantom_sample_unchanged);
    RUN_TEST(test_phantom_zone);
    RUN_TEST(test_phantom_volume_closed_form);
    RUN_TEST(test_phantom_volume_convergence);
    RUN_TEST(test_phantom_ejection_fraction);
    RUN_TEST(test_phantom_frame_bound);
    RUN_TEST(test_phantom_frame_areas);
    RUN_TEST(test_phantom_frame_lid);
    RUN_TEST(test_phantom_frame_points);
    RUN_TEST(test_phantom_locate);
}

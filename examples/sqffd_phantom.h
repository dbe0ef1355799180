/* sqffd_phantom.h - a synthetic left ventricle for the tests, the benchmarks
   and the demo.

   Header-only, every function `static inline`, no dependencies beyond <math.h>
   and <stddef.h>. The shape is a truncated prolate half-ellipsoid (a cup with
   a rounded apex and an open base plane, long axis along z, apex down) with a
   few smooth local bumps, so a superquadric fits it only roughly and a
   free-form deformation has something to recover.

   It is parameterised by material coordinates (u, theta): u in [0, 1] from
   the apex (u = 0) to the base rim (u = 1), theta in [-pi, pi) around the
   long axis. A material point keeps its (u, theta) through a heart beat:
   phase in [0, 1) runs end-diastole (0) -> end-systole (0.5) -> end-diastole;
   at end-systole the wall has moved inward by `contraction` (radially) and
   the base toward the apex by `shortening` (along z), both scaled by the
   motion weight, which drops to `low_motion_factor` in one region (a
   hypokinetic zone, e.g. an infarct). */
#ifndef SQFFD_PHANTOM_H
#define SQFFD_PHANTOM_H

#include <math.h>
#include <stddef.h>

#define PHANTOM_PI 3.14159265358979323846
#define PHANTOM_BUMPS 3

typedef struct phantom_lv {
    double radius;          /* short semi-axis (mm) */
    double height;          /* long semi-axis (mm): the apex is at z = -height */
    double base_angle;      /* polar angle of the base cut from the apex direction (pi/2: at the widest ring) */
    double bump_height;     /* relative amplitude of the bumps (0: a plain ellipsoidal cup) */
    double bump[PHANTOM_BUMPS][4]; /* each: u, theta, signed amplitude (x bump_height), angular width (rad) */
    double contraction;     /* end-systolic radial shrink fraction */
    double shortening;      /* end-systolic long-axis shrink fraction */
    double low_motion[3];   /* u, theta, angular width (rad) of the hypokinetic zone */
    double low_motion_factor; /* motion weight at its centre, in [0, 1] (1: no zone) */
} phantom_lv;

/* A ventricle of about 50 x 50 x 55 mm with three bumps and a hypokinetic
   zone on the lateral wall. */
static inline phantom_lv phantom_lv_default(void)
{
    phantom_lv p;
    p.radius = 25.0;
    p.height = 45.0;
    p.base_angle = 0.6 * PHANTOM_PI;
    p.bump_height = 0.12;
    p.bump[0][0] = 0.55; p.bump[0][1] = 0.5;  p.bump[0][2] = 1.0;  p.bump[0][3] = 0.35;
    p.bump[1][0] = 0.75; p.bump[1][1] = 2.4;  p.bump[1][2] = -0.8; p.bump[1][3] = 0.30;
    p.bump[2][0] = 0.35; p.bump[2][1] = -1.9; p.bump[2][2] = 0.7;  p.bump[2][3] = 0.40;
    p.contraction = 0.25;
    p.shortening = 0.12;
    p.low_motion[0] = 0.6; p.low_motion[1] = -0.8; p.low_motion[2] = 0.45;
    p.low_motion_factor = 0.1;
    return p;
}

/* Unit direction of material point (u, theta) on the sphere of polar angle
   psi = u * base_angle from the apex (-z). */
static inline void phantom__direction(const phantom_lv *p, double u, double theta, double d[3])
{
    double psi = u * p->base_angle;
    d[0] = sin(psi) * cos(theta);
    d[1] = sin(psi) * sin(theta);
    d[2] = -cos(psi);
}

/* Gaussian of the angle between the directions of (u, theta) and (u0, theta0). */
static inline double phantom__bell(const phantom_lv *p, double u, double theta, double u0, double theta0, double width)
{
    double a[3], b[3], c, angle;
    phantom__direction(p, u, theta, a);
    phantom__direction(p, u0, theta0, b);
    c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    angle = acos(c > 1.0 ? 1.0 : c < -1.0 ? -1.0 : c);
    return exp(-0.5 * angle * angle / (width * width));
}

/* Motion weight of a material point: 1 outside the hypokinetic zone,
   low_motion_factor at its centre. */
static inline double phantom_lv_motion(const phantom_lv *p, double u, double theta)
{
    double g = phantom__bell(p, u, theta, p->low_motion[0], p->low_motion[1], p->low_motion[2]);
    return 1.0 - (1.0 - p->low_motion_factor) * g;
}

/* Contraction state at a phase: 0 at end-diastole, 1 at end-systole. */
static inline double phantom_lv_beat(double phase)
{
    return 0.5 * (1.0 - cos(2.0 * PHANTOM_PI * phase));
}

/* Radial factor of the bumps at material point (u, theta). */
static inline double phantom__bumps(const phantom_lv *p, double u, double theta)
{
    double f = 1.0;
    int b;
    for (b = 0; b < PHANTOM_BUMPS; b++)
        f += p->bump_height * p->bump[b][2] * phantom__bell(p, u, theta, p->bump[b][0], p->bump[b][1], p->bump[b][3]);
    return f;
}

/* Position of material point (u, theta) at a phase of the beat. */
static inline void phantom_lv_point(const phantom_lv *p, double phase, double u, double theta, double out[3])
{
    double d[3], bump = phantom__bumps(p, u, theta), motion = phantom_lv_beat(phase) * phantom_lv_motion(p, u, theta);
    double apex = -p->height * phantom__bumps(p, 0.0, 0.0), z;
    phantom__direction(p, u, theta, d);
    out[0] = p->radius * d[0] * bump * (1.0 - p->contraction * motion);
    out[1] = p->radius * d[1] * bump * (1.0 - p->contraction * motion);
    z = p->height * d[2] * bump; /* the apex stays, the rest moves toward it */
    out[2] = apex + (z - apex) * (1.0 - p->shortening * motion);
}

/* n material points spread evenly over the undeformed cup (a Fibonacci
   spiral, area-weighted along u, so the same i is the same material point
   in every phase), written at the given phase: 3n doubles. Deterministic. */
static inline void phantom_lv_sample(const phantom_lv *p, double phase, size_t n, double *out)
{
    enum { STEPS = 512 };
    double cdf[STEPS + 1];
    const double golden = PHANTOM_PI * (3.0 - sqrt(5.0));
    size_t i, k = 0;
    int s;
    cdf[0] = 0.0; /* area of the surface of revolution up to u, up to a constant */
    for (s = 0; s < STEPS; s++) {
        double psi = (s + 0.5) / STEPS * p->base_angle;
        double ds = sqrt(pow(p->radius * cos(psi), 2) + pow(p->height * sin(psi), 2));
        cdf[s + 1] = cdf[s] + sin(psi) * ds;
    }
    for (i = 0; i < n; i++) {
        double target = ((double)i + 0.5) / (double)n * cdf[STEPS], u, theta;
        while (k < STEPS - 1 && cdf[k + 1] < target) k++;
        while (k > 0 && cdf[k] > target) k--;
        u = ((double)k + (target - cdf[k]) / (cdf[k + 1] - cdf[k])) / STEPS;
        theta = fmod((double)i * golden, 2.0 * PHANTOM_PI) - PHANTOM_PI;
        phantom_lv_point(p, phase, u, theta, out + 3 * i);
    }
}

#endif

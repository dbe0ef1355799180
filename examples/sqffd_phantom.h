/* sqffd_phantom.h - a synthetic beating left ventricle and its ground truth,
   for the tests, the benchmarks and the demo.

   Header-only, every function `static inline`, C99 and C++, nothing beyond
   <math.h>, <stddef.h> and <stdint.h>; no heap, no globals.

   The wall: a truncated prolate half-ellipsoid (a cup with a rounded apex and
   an open base rim, long axis along z, apex down) with three smooth local
   bumps, so a superquadric fits it only roughly and a free-form deformation
   has something to recover. Material coordinates (u, theta): u in [0, 1]
   from the apex (u = 0) to the base rim (u = 1), theta in [-pi, pi) around
   the long axis; the direction of (u, theta) is the unit vector at polar
   angle u * base_angle from -z. A material point keeps its (u, theta) through
   the beat: phase in [0, 1), periodic, runs end-diastole, ED (0) ->
   end-systole, ES (0.5) -> ED; by ES the wall has moved inward by
   `contraction` (radially) and toward the fixed apex by `shortening` (along
   z), both times the point's motion weight.

   The hypokinetic zone (an infarct, say): the motion weight is
   low_motion_factor (default 0.2, "20% of normal motion") where the angle
   between a point's direction and the zone centre's, (u, theta) =
   (low_motion[0], low_motion[1]), is below low_motion[2]; it rises along a
   cosine ramp over the next PHANTOM_ZONE_RAMP radians to 1 (normal wall).
   The truth region, phantom_lv_in_zone, is where the weight is at most
   halfway: angle < low_motion[2] + PHANTOM_ZONE_RAMP / 2, by default 14.8%
   of the ED wall's area.

   The closed cavity (the blood pool): the cup closed at the base by the
   "valve plane" lid, the fan of segments from the rim's centroid (the mean of
   the rim points at that phase) to the rim. A lid point's material
   coordinates are (f, theta): the fraction f in [0, 1] of the way from the
   centroid to the rim point at theta, the same in every phase. Its volume,
   phantom_lv_volume, is the divergence theorem on a fine (u, theta)
   triangulation of the cup plus the lid's fan (the sum of signed tetrahedra,
   det / 6), two resolutions extrapolated: relative error below 1e-6. The
   true ejection fraction over N frames at phases k / N is (EDV - ESV) / EDV
   with EDV at phase 0 and ESV the least of the frames' volumes
   (phantom_lv_ejection_fraction; 46.1% by default when a frame is at ES).

   A frame of a sequence, phantom_lv_frame: n points drawn at random (seeded)
   over the closed cavity surface at a phase, uniformly by area at that
   phase, cup and lid, plus isotropic Gaussian noise whose standard deviation
   is `noise` times phantom_lv_scale, the diagonal of the ED cup's bounding
   box (93.17 mm by default). Each point's label is that of the material
   point drawn: PHANTOM_WALL (0, normal wall), PHANTOM_ZONE (1, in the
   hypokinetic zone) or PHANTOM_LID (2, the valve plane).

   The truth for a measured point q near the ED surface: phantom_lv_locate
   finds the nearest material point (cup or lid) and returns its label and
   its displacement |position at ES - position at ED| (phantom_lv_locate_motion
   the vector); phantom_lv_nearest does the search at any phase.

   phantom_lv_sample (evenly spread material points, deterministic) predates
   the beat and is unchanged: its points at phase 0 are those it always gave.

   The heart wall: a myocardium of known thickness over the cup. Material
   point (u, theta) of the epicardium (the wall's outer border) lies
   wall_thickness x (1 + wall_thickening x weight x beat) out along the
   cavity surface's unit outward normal at (u, theta), weight the point's
   motion weight and beat the contraction state: a uniform wall (8 mm by
   default) at ED that thickens by wall_thickening (default 0.35, 35 %) at
   ES where the wall moves normally and by a fifth of that (7 %) on the
   hypokinetic zone's plateau, as an infarct thickens less than the wall
   pulling it along. The thickening is prescribed, not derived from
   incompressibility: it is then known exactly per point
   (phantom_lv_thickening); the default is the one that conserves the
   myocardial volume (phantom_lv_myocardium: 90.57 ml at ED, 0.6 % more at
   ES; 30 % would lose 3.4 %, 40 % gain 4.6 %), as a real myocardium's
   is. The thickness along the cavity's normal is exact (the offset
   surface does not fold: the wall is thinner than the cavity's radii of
   curvature). With `epicardium` 1 every function of the header gives the
   epicardium instead of the cavity: its frames (phantom_lv_frame, its lid
   the fan from its own rim's centroid), its contours, its closed volume;
   the noise unit, phantom_lv_scale, stays the cavity's. */
#ifndef SQFFD_PHANTOM_H
#define SQFFD_PHANTOM_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#define PHANTOM_PI 3.14159265358979323846
#define PHANTOM_BUMPS 3
#define PHANTOM_ZONE_RAMP 0.15   /* rad: the motion weight's ramp from the zone's plateau to 1 */
#define PHANTOM_RIM_SAMPLES 64   /* rim points averaged into the lid's centroid */
#define PHANTOM_MESH_MAX 1024    /* most theta steps of phantom_lv_measure_mesh */
#define PHANTOM_VOLUME_STEPS 128 /* u steps of phantom_lv_volume's coarser mesh */

/* Labels of a point of the closed surface. */
#define PHANTOM_WALL 0
#define PHANTOM_ZONE 1
#define PHANTOM_LID 2

typedef struct phantom_lv {
    double radius;          /* short semi-axis (mm) */
    double height;          /* long semi-axis (mm): the apex is at z = -height */
    double base_angle;      /* polar angle of the base cut from the apex direction (pi/2: at the widest ring) */
    double bump_height;     /* relative amplitude of the bumps (0: a plain ellipsoidal cup) */
    double bump[PHANTOM_BUMPS][4]; /* each: u, theta, signed amplitude (x bump_height), angular width (rad) */
    double contraction;     /* end-systolic radial shrink fraction */
    double shortening;      /* end-systolic long-axis shrink fraction */
    double low_motion[3];   /* u, theta, angular radius (rad) of the hypokinetic zone's plateau */
    double low_motion_factor; /* motion weight on the plateau, in [0, 1] (1: no zone) */
    double wall_thickness;  /* the myocardium's thickness at ED (mm), along the cavity's normal */
    double wall_thickening; /* its end-systolic thickening where the wall moves normally (x the motion weight) */
    int epicardium;         /* 0: the functions give the cavity's border (endocardium); 1: the epicardium */
} phantom_lv;

/* A ventricle of about 50 x 50 x 60 mm at ED with three bumps and a
   hypokinetic zone on the lateral wall, between two bumps: 20% of normal
   motion on a plateau of 0.55 rad, 14.8% of the ED wall's area. */
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
    p.low_motion[0] = 0.6; p.low_motion[1] = -0.8; p.low_motion[2] = 0.55;
    p.low_motion_factor = 0.2;
    p.wall_thickness = 8.0;
    p.wall_thickening = 0.35;
    p.epicardium = 0;
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

/* Angle between two unit directions. */
static inline double phantom__angle_between(const double a[3], const double b[3])
{
    double c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    return acos(c > 1.0 ? 1.0 : c < -1.0 ? -1.0 : c);
}

/* Angle between the directions of (u, theta) and (u0, theta0). */
static inline double phantom__angle(const phantom_lv *p, double u, double theta, double u0, double theta0)
{
    double a[3], b[3];
    phantom__direction(p, u, theta, a);
    phantom__direction(p, u0, theta0, b);
    return phantom__angle_between(a, b);
}

static inline void phantom__sub(const double a[3], const double b[3], double out[3])
{
    out[0] = a[0] - b[0]; out[1] = a[1] - b[1]; out[2] = a[2] - b[2];
}
static inline void phantom__cross(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1]; out[1] = a[2] * b[0] - a[0] * b[2]; out[2] = a[0] * b[1] - a[1] * b[0];
}
static inline double phantom__dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
static inline double phantom__dist2(const double a[3], const double b[3])
{
    double d[3];
    phantom__sub(a, b, d);
    return phantom__dot(d, d);
}

/* What a point's position needs besides its direction, the same for every
   point at a phase: the bumps' and the zone's centre directions, the apex
   and the contraction state. Prepared once for the many points of a mesh
   or a search (the per-point cost drops about fivefold). */
typedef struct phantom__state {
    double bump[PHANTOM_BUMPS][3];
    double zone[3];
    double apex;            /* z of the apex, fixed through the beat */
    double beat;            /* phantom_lv_beat(phase) */
} phantom__state;

/* Radial factor of the bumps along unit direction d. */
static inline double phantom__bumps_at(const phantom_lv *p, const phantom__state *s, const double d[3])
{
    double f = 1.0;
    int b;
    for (b = 0; b < PHANTOM_BUMPS; b++) {
        double angle = phantom__angle_between(d, s->bump[b]);
        f += p->bump_height * p->bump[b][2] * exp(-0.5 * angle * angle / (p->bump[b][3] * p->bump[b][3]));
    }
    return f;
}

/* Motion weight at a given angle from the zone's centre:
   low_motion_factor within the zone's angular radius, a cosine ramp (flat
   at both ends, so the wall stays smooth) over PHANTOM_ZONE_RAMP, 1 beyond. */
static inline double phantom__weight(const phantom_lv *p, double angle)
{
    double f = p->low_motion_factor, t = (angle - p->low_motion[2]) / PHANTOM_ZONE_RAMP;
    if (t <= 0.0) return f;
    if (t >= 1.0) return 1.0;
    return f + (1.0 - f) * 0.5 * (1.0 - cos(PHANTOM_PI * t));
}

/* Contraction state at a phase: 0 at end-diastole, 1 at end-systole. */
static inline double phantom_lv_beat(double phase)
{
    return 0.5 * (1.0 - cos(2.0 * PHANTOM_PI * phase));
}

/* The state at a phase. */
static inline void phantom__prepare(const phantom_lv *p, double phase, phantom__state *s)
{
    double down[3];
    int b;
    for (b = 0; b < PHANTOM_BUMPS; b++) phantom__direction(p, p->bump[b][0], p->bump[b][1], s->bump[b]);
    phantom__direction(p, p->low_motion[0], p->low_motion[1], s->zone);
    phantom__direction(p, 0.0, 0.0, down);
    s->apex = -p->height * phantom__bumps_at(p, s, down);
    s->beat = phantom_lv_beat(phase);
}

/* Position of the cavity's cup point along unit direction d (of some (u, theta)). */
static inline void phantom__cavity_at(const phantom_lv *p, const phantom__state *s, const double d[3], double out[3])
{
    double bump = phantom__bumps_at(p, s, d), motion = s->beat * phantom__weight(p, phantom__angle_between(d, s->zone)), z;
    out[0] = p->radius * d[0] * bump * (1.0 - p->contraction * motion);
    out[1] = p->radius * d[1] * bump * (1.0 - p->contraction * motion);
    z = p->height * d[2] * bump; /* the apex stays, the rest moves toward it */
    out[2] = s->apex + (z - s->apex) * (1.0 - p->shortening * motion);
}

/* The wall's thickness at a point of motion weight w in state s. */
static inline double phantom__thickness(const phantom_lv *p, const phantom__state *s, double w)
{
    return p->wall_thickness * (1.0 + p->wall_thickening * w * s->beat);
}

/* Position of the cup's point along unit direction d: the cavity's, or on
   the epicardium the thickness out along the cavity's unit normal there
   (central differences over two directions across d, (e1, e2, d)
   right-handed, so that their cross product points outward). */
static inline void phantom__point_at(const phantom_lv *p, const phantom__state *s, const double d[3], double out[3])
{
    const double h = 1e-5;
    double e[2][3], x[2][2][3], n[3], a[3], b[3], len, thick;
    int i, j, k;
    phantom__cavity_at(p, s, d, out);
    if (!p->epicardium) return;
    e[0][0] = -d[1]; e[0][1] = d[0]; e[0][2] = 0.0; /* across d: about z, or about x near the poles */
    if (d[0] * d[0] + d[1] * d[1] < 0.25) { e[0][0] = 0.0; e[0][1] = -d[2]; e[0][2] = d[1]; }
    len = sqrt(e[0][0] * e[0][0] + e[0][1] * e[0][1] + e[0][2] * e[0][2]);
    for (k = 0; k < 3; k++) e[0][k] /= len;
    e[1][0] = d[1] * e[0][2] - d[2] * e[0][1]; /* d x e1 */
    e[1][1] = d[2] * e[0][0] - d[0] * e[0][2];
    e[1][2] = d[0] * e[0][1] - d[1] * e[0][0];
    for (i = 0; i < 2; i++)
        for (j = 0; j < 2; j++) {
            double q[3];
            for (k = 0; k < 3; k++) q[k] = d[k] + (j ? -h : h) * e[i][k];
            len = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
            for (k = 0; k < 3; k++) q[k] /= len;
            phantom__cavity_at(p, s, q, x[i][j]);
        }
    phantom__sub(x[0][0], x[0][1], a);
    phantom__sub(x[1][0], x[1][1], b);
    phantom__cross(a, b, n);
    len = sqrt(phantom__dot(n, n));
    thick = phantom__thickness(p, s, phantom__weight(p, phantom__angle_between(d, s->zone)));
    for (k = 0; k < 3; k++) out[k] += thick * n[k] / len;
}

/* Position of material point (u, theta) of the cup, state prepared. */
static inline void phantom__point(const phantom_lv *p, const phantom__state *s, double u, double theta, double out[3])
{
    double d[3];
    phantom__direction(p, u, theta, d);
    phantom__point_at(p, s, d, out);
}

/* Motion weight of material point (u, theta): 1 outside the hypokinetic
   zone, low_motion_factor on its plateau (see phantom__weight). */
static inline double phantom_lv_motion(const phantom_lv *p, double u, double theta)
{
    return phantom__weight(p, phantom__angle(p, u, theta, p->low_motion[0], p->low_motion[1]));
}

/* 1 when material point (u, theta) of the cup is in the hypokinetic zone
   (its motion weight at most halfway from low_motion_factor to 1), else 0. */
static inline int phantom_lv_in_zone(const phantom_lv *p, double u, double theta)
{
    return phantom__angle(p, u, theta, p->low_motion[0], p->low_motion[1]) < p->low_motion[2] + 0.5 * PHANTOM_ZONE_RAMP;
}

/* Position of material point (u, theta) of the cup at a phase of the beat. */
static inline void phantom_lv_point(const phantom_lv *p, double phase, double u, double theta, double out[3])
{
    phantom__state s;
    phantom__prepare(p, phase, &s);
    phantom__point(p, &s, u, theta, out);
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
        double psi = (s + 0.5) / (double)STEPS * p->base_angle;
        double ds = sqrt(pow(p->radius * cos(psi), 2) + pow(p->height * sin(psi), 2));
        cdf[s + 1] = cdf[s] + sin(psi) * ds;
    }
    for (i = 0; i < n; i++) {
        double target = ((double)i + 0.5) / (double)n * cdf[STEPS], u, theta;
        while (k < STEPS - 1 && cdf[k + 1] < target) k++;
        while (k > 0 && cdf[k] > target) k--;
        u = ((double)k + (target - cdf[k]) / (cdf[k + 1] - cdf[k])) / (double)STEPS;
        theta = fmod((double)i * golden, 2.0 * PHANTOM_PI) - PHANTOM_PI;
        phantom_lv_point(p, phase, u, theta, out + 3 * i);
    }
}

/* ---- the closed cavity --------------------------------------------------- */

/* The j-th of n evenly spread angles, from -pi. */
static inline double phantom__theta(int j, int n)
{
    return -PHANTOM_PI + 2.0 * PHANTOM_PI * (double)j / (double)n;
}

/* The lid's centre: the mean of PHANTOM_RIM_SAMPLES rim points (u = 1)
   evenly spread in theta. The rim is smooth and periodic (the zone's ramp
   ends short of it by default), so this is its continuous mean to rounding. */
static inline void phantom__centroid(const phantom_lv *p, const phantom__state *s, double c[3])
{
    double x[3];
    int j;
    c[0] = c[1] = c[2] = 0.0;
    for (j = 0; j < PHANTOM_RIM_SAMPLES; j++) {
        phantom__point(p, s, 1.0, phantom__theta(j, PHANTOM_RIM_SAMPLES), x);
        c[0] += x[0]; c[1] += x[1]; c[2] += x[2];
    }
    c[0] /= PHANTOM_RIM_SAMPLES; c[1] /= PHANTOM_RIM_SAMPLES; c[2] /= PHANTOM_RIM_SAMPLES;
}

/* The lid's centre at a phase (the rim's centroid, see phantom__centroid). */
static inline void phantom_lv_rim_centroid(const phantom_lv *p, double phase, double c[3])
{
    phantom__state s;
    phantom__prepare(p, phase, &s);
    phantom__centroid(p, &s, c);
}

/* Lid point (f, theta) given the lid's centre c at the state's phase. */
static inline void phantom__lid(const phantom_lv *p, const phantom__state *s, const double c[3], double f, double theta,
                                double out[3])
{
    double rim[3];
    phantom__point(p, s, 1.0, theta, rim);
    out[0] = c[0] + f * (rim[0] - c[0]);
    out[1] = c[1] + f * (rim[1] - c[1]);
    out[2] = c[2] + f * (rim[2] - c[2]);
}

/* Position of lid (valve plane) material point (f, theta) at a phase: the
   fraction f of the way from the rim's centroid to the rim point at theta. */
static inline void phantom_lv_lid_point(const phantom_lv *p, double phase, double f, double theta, double out[3])
{
    phantom__state s;
    double c[3];
    phantom__prepare(p, phase, &s);
    phantom__centroid(p, &s, c);
    phantom__lid(p, &s, c, f, theta, out);
}

/* The closed surface at a phase triangulated on a grid of nu steps in u and
   nt (<= PHANTOM_MESH_MAX) in theta, the lid as the fan from the mean of the
   mesh's rim points: m[0] its enclosed volume (the sum over the triangles of
   the signed tetrahedra det / 6 they make with the apex), m[1] the cup's
   area, m[2] the lid's. Each converges as 1 / resolution^2. */
static inline void phantom_lv_measure_mesh(const phantom_lv *p, double phase, int nu, int nt, double m[3])
{
    double row[PHANTOM_MESH_MAX][3], ct[PHANTOM_MESH_MAX], st[PHANTOM_MESH_MAX];
    double o[3], c[3], volume = 0.0, cup = 0.0, lid = 0.0;
    phantom__state s;
    int i, j, k;
    if (nu < 1) nu = 1;
    if (nt < 3) nt = 3;
    if (nt > PHANTOM_MESH_MAX) nt = PHANTOM_MESH_MAX;
    phantom__prepare(p, phase, &s);
    for (j = 0; j < nt; j++) { /* the grid's trigonometry once */
        ct[j] = cos(phantom__theta(j, nt));
        st[j] = sin(phantom__theta(j, nt));
    }
    phantom__point(p, &s, 0.0, 0.0, o); /* the apex: ring 0 and the tetrahedra's common vertex */
    for (j = 0; j < nt; j++)
        for (k = 0; k < 3; k++) row[j][k] = o[k];
    /* row[] holds the previous ring of u; it is overwritten with the new
       ring as the quads between the two are summed */
    for (i = 1; i <= nu; i++) {
        double psi = (double)i / (double)nu * p->base_angle, sp = sin(psi), cp = cos(psi);
        double first_old[3], first_new[3], cur[3], next[3], d[3];
        for (k = 0; k < 3; k++) first_old[k] = row[0][k];
        d[0] = sp * ct[0]; d[1] = sp * st[0]; d[2] = -cp;
        phantom__point_at(p, &s, d, first_new);
        for (k = 0; k < 3; k++) cur[k] = first_new[k];
        for (j = 0; j < nt; j++) {
            const double *a = row[j], *b = j + 1 < nt ? row[j + 1] : first_old;
            const double *tri[2][3];
            int f;
            if (j + 1 < nt) {
                d[0] = sp * ct[j + 1]; d[1] = sp * st[j + 1]; d[2] = -cp;
                phantom__point_at(p, &s, d, next);
            } else
                for (k = 0; k < 3; k++) next[k] = first_new[k];
            /* quad a (old ring, j), b (old, j + 1), next (new, j + 1), cur
               (new, j): triangles (a, b, next) and (a, next, cur), outward */
            tri[0][0] = a; tri[0][1] = b; tri[0][2] = next;
            tri[1][0] = a; tri[1][1] = next; tri[1][2] = cur;
            for (f = 0; f < 2; f++) {
                double x[3], y[3], z[3], n[3];
                phantom__sub(tri[f][0], o, x); phantom__sub(tri[f][1], o, y); phantom__sub(tri[f][2], o, z);
                phantom__cross(y, z, n);
                volume += phantom__dot(x, n) / 6.0;
                phantom__sub(y, x, y); phantom__sub(z, x, z);
                phantom__cross(y, z, n);
                cup += 0.5 * sqrt(phantom__dot(n, n));
            }
            for (k = 0; k < 3; k++) { row[j][k] = cur[k]; cur[k] = next[k]; }
        }
    }
    c[0] = c[1] = c[2] = 0.0; /* the lid: row[] is now the rim */
    for (j = 0; j < nt; j++)
        for (k = 0; k < 3; k++) c[k] += row[j][k] / nt;
    for (j = 0; j < nt; j++) {
        const double *a = row[j], *b = row[j + 1 < nt ? j + 1 : 0];
        double x[3], y[3], z[3], n[3];
        phantom__sub(c, o, x); phantom__sub(a, o, y); phantom__sub(b, o, z);
        phantom__cross(y, z, n);
        volume += phantom__dot(x, n) / 6.0;
        phantom__sub(a, c, y); phantom__sub(b, c, z);
        phantom__cross(y, z, n);
        lid += 0.5 * sqrt(phantom__dot(n, n));
    }
    m[0] = fabs(volume);
    m[1] = cup;
    m[2] = lid;
}

/* The mesh measures on nu x 2nu and 2nu x 4nu grids, Richardson-extrapolated
   (their error is c / nu^2 to leading order). */
static inline void phantom__measure(const phantom_lv *p, double phase, int nu, double m[3])
{
    double coarse[3], fine[3];
    int k;
    phantom_lv_measure_mesh(p, phase, nu, 2 * nu, coarse);
    phantom_lv_measure_mesh(p, phase, 2 * nu, 4 * nu, fine);
    for (k = 0; k < 3; k++) m[k] = (4.0 * fine[k] - coarse[k]) / 3.0;
}

/* Volume of the closed cavity (cup + lid) at a phase: meshes of 128 x 256
   and 256 x 512, extrapolated; ~15 ms. Relative error below 1e-6 (against
   the extrapolation at twice the resolution: 3e-9 at ED, 2e-7 at ES, where
   the zone's ramp, smooth to the first derivative only, limits it). */
static inline double phantom_lv_volume(const phantom_lv *p, double phase)
{
    double m[3];
    phantom__measure(p, phase, PHANTOM_VOLUME_STEPS, m);
    return m[0];
}

/* Areas of the cup and of the lid at a phase: meshes of 64 x 128 and
   128 x 256, extrapolated. Relative error below 1e-4 (the cup's during the
   beat, the zone's ramp again; 1e-7 at ED and on the lid). */
static inline void phantom_lv_areas(const phantom_lv *p, double phase, double *cup, double *lid)
{
    double m[3];
    phantom__measure(p, phase, 64, m);
    if (cup) *cup = m[1];
    if (lid) *lid = m[2];
}

/* True ejection fraction (EDV - ESV) / EDV over `frames` frames at phases
   k / frames: EDV at phase 0, ESV the least of the frames' volumes (the
   beat is symmetric about ES, so the phases up to 1/2 are enough). */
static inline double phantom_lv_ejection_fraction(const phantom_lv *p, int frames)
{
    double edv, esv;
    int k;
    if (frames < 1) return 0.0;
    edv = esv = phantom_lv_volume(p, 0.0);
    for (k = 1; 2 * k <= frames; k++) {
        double v = phantom_lv_volume(p, (double)k / (double)frames);
        if (v < esv) esv = v;
    }
    return (edv - esv) / edv;
}

/* ---- the heart wall: truth --------------------------------------------- */

/* The wall's thickness at material point (u, theta) at a phase (along the
   cavity's normal there, to the epicardium). */
static inline double phantom_lv_thickness(const phantom_lv *p, double phase, double u, double theta)
{
    phantom__state s;
    phantom__prepare(p, phase, &s);
    return phantom__thickness(p, &s, phantom_lv_motion(p, u, theta));
}

/* Its thickening from ED to ES, thickness(ES) / thickness(ED) - 1. */
static inline double phantom_lv_thickening(const phantom_lv *p, double u, double theta)
{
    return p->wall_thickening * phantom_lv_motion(p, u, theta);
}

/* The myocardial volume at a phase: the closed epicardium's volume less the
   closed cavity's (phantom_lv_volume of each, relative error below 1e-6). */
static inline double phantom_lv_myocardium(const phantom_lv *p, double phase)
{
    phantom_lv q = *p;
    double cavity;
    q.epicardium = 0;
    cavity = phantom_lv_volume(&q, phase);
    q.epicardium = 1;
    return phantom_lv_volume(&q, phase) - cavity;
}

/* The unit of a frame's noise: the diagonal of the ED cavity cup's bounding box,
   measured over a 129 x 256 grid of material points (within ~1e-4 of the
   exact box). */
static inline double phantom_lv_scale(const phantom_lv *p)
{
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL}, x[3], d2 = 0.0;
    phantom__state s;
    phantom_lv cavity = *p; /* (the epicardium's frames too: one noise unit for both surfaces) */
    int i, j, k;
    cavity.epicardium = 0;
    phantom__prepare(&cavity, 0.0, &s);
    for (i = 0; i <= 128; i++)
        for (j = 0; j < 256; j++) {
            phantom__point(&cavity, &s, i / 128.0, phantom__theta(j, 256), x);
            for (k = 0; k < 3; k++) {
                if (x[k] < lo[k]) lo[k] = x[k];
                if (x[k] > hi[k]) hi[k] = x[k];
            }
        }
    for (k = 0; k < 3; k++) d2 += (hi[k] - lo[k]) * (hi[k] - lo[k]);
    return sqrt(d2);
}

/* A short-axis stack of the cup at a phase, as manual contours give it: on
   each plane z = levels[k] the closed section of the wall, per_slice points
   at evenly spread theta (the point of that meridian at height z, found by
   bisection in u: z grows from the apex to the rim along every meridian),
   each moved in-plane by shifts[2 k], shifts[2 k + 1] (NULL: none; a
   breath-hold's misregistration). A plane the meridian does not cross (below
   the apex, above the rim) gives no point there. Writes at most count x
   per_slice points (3 doubles each) and returns how many. */
static inline size_t phantom_lv_contours(const phantom_lv *p, double phase, const double *levels, int count,
                                         int per_slice, const double *shifts, double *out)
{
    phantom__state s;
    size_t n = 0;
    int k, j, it;
    phantom__prepare(p, phase, &s);
    for (k = 0; k < count; k++)
        for (j = 0; j < per_slice; j++) {
            double theta = phantom__theta(j, per_slice), lo = 0.0, hi = 1.0, x[3];
            phantom__point(p, &s, lo, theta, x);
            if (x[2] > levels[k]) continue;
            phantom__point(p, &s, hi, theta, x);
            if (x[2] < levels[k]) continue;
            for (it = 0; it < 60; it++) {
                double mid = 0.5 * (lo + hi);
                phantom__point(p, &s, mid, theta, x);
                if (x[2] < levels[k]) lo = mid; else hi = mid;
            }
            phantom__point(p, &s, 0.5 * (lo + hi), theta, out + 3 * n);
            out[3 * n + 2] = levels[k];
            if (shifts) {
                out[3 * n] += shifts[2 * k];
                out[3 * n + 1] += shifts[2 * k + 1];
            }
            n++;
        }
    return n;
}

/* ---- frames: random points on the closed surface ------------------------- */

/* splitmix64 (Steele, Lea & Flood 2014): small, and well mixed from any seed. */
static inline uint64_t phantom__next(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
}

/* Uniform in [0, 1). */
static inline double phantom__uniform(uint64_t *state)
{
    return (double)(phantom__next(state) >> 11) * (1.0 / 9007199254740992.0);
}

/* Standard normal (Box-Muller; 1 - uniform is in (0, 1], so the log is finite). */
static inline double phantom__gauss(uint64_t *state)
{
    double a = 1.0 - phantom__uniform(state), b = phantom__uniform(state);
    return sqrt(-2.0 * log(a)) * cos(2.0 * PHANTOM_PI * b);
}

/* The cup's area element |dX/du x dX/dtheta| at (u, theta) over
   sin(u base_angle), the density the sampler draws from (forward
   differences: an acceptance probability needs no more). */
static inline double phantom__cup_ratio(const phantom_lv *p, const phantom__state *s, double u, double theta)
{
    const double h = 1e-6;
    double x[3], a[3], b[3], n[3];
    phantom__point(p, s, u, theta, x);
    phantom__point(p, s, u + h, theta, a);
    phantom__point(p, s, u, theta + h, b);
    phantom__sub(a, x, a);
    phantom__sub(b, x, b);
    phantom__cross(a, b, n);
    return sqrt(phantom__dot(n, n)) / (h * h) / sin(u * p->base_angle);
}

/* The lid's area element in (f, theta) is f times this: |(rim - c) x rim'|. */
static inline double phantom__lid_density(const phantom_lv *p, const phantom__state *s, const double c[3], double theta)
{
    const double h = 1e-6;
    double x[3], a[3], n[3];
    phantom__point(p, s, 1.0, theta, x);
    phantom__point(p, s, 1.0, theta + h, a);
    phantom__sub(a, x, a);
    phantom__sub(x, c, x);
    phantom__cross(x, a, n);
    return sqrt(phantom__dot(n, n)) / h;
}

/* Bound on phantom__cup_ratio: its largest value at the centres of a
   24 x 48 grid, with a 25% margin for the peaks between them (the tests
   check it against a fine grid). */
static inline double phantom__cup_bound(const phantom_lv *p, const phantom__state *s)
{
    double best = 0.0;
    int i, j;
    for (i = 0; i < 24; i++)
        for (j = 0; j < 48; j++) {
            double r = phantom__cup_ratio(p, s, (i + 0.5) / 24.0, phantom__theta(2 * j + 1, 96));
            if (r > best) best = r;
        }
    return 1.25 * best;
}

/* One frame of a sequence: n points (3n doubles in out) drawn at random over
   the closed cavity surface at `phase`, uniformly by area at that phase: the
   lid with probability lid area / total area (phantom_lv_areas), the cup
   otherwise (material points drawn with density sin(u base_angle) and kept
   with probability proportional to the true area element over it: rejection
   sampling), each then moved by isotropic Gaussian noise of standard
   deviation noise x phantom_lv_scale(p). label (n bytes, may be NULL) gets
   PHANTOM_WALL, PHANTOM_ZONE or PHANTOM_LID, the material point's. The same
   seed gives the same points, whatever the noise (the same material points,
   the same noise directions); different seeds, different points. About
   10 ms for 6,000 points. */
static inline void phantom_lv_frame(const phantom_lv *p, double phase, size_t n, double noise, uint64_t seed,
                                    double *out, unsigned char *label)
{
    double cup, lid, c[3], cup_bound, lid_bound = 0.0, sigma, lid_share, cosb = cos(p->base_angle);
    phantom__state s;
    uint64_t state = seed;
    size_t i;
    int j, k;
    if (n == 0) return;
    phantom__prepare(p, phase, &s);
    sigma = noise != 0.0 ? noise * phantom_lv_scale(p) : 0.0; /* the scale evaluates 33,000 points: not when unused */
    phantom_lv_areas(p, phase, &cup, &lid);
    lid_share = lid / (cup + lid);
    phantom__centroid(p, &s, c);
    cup_bound = phantom__cup_bound(p, &s);
    for (j = 0; j < PHANTOM_RIM_SAMPLES; j++) {
        double l = phantom__lid_density(p, &s, c, phantom__theta(j, PHANTOM_RIM_SAMPLES));
        if (l > lid_bound) lid_bound = l;
    }
    lid_bound *= 1.25;
    for (i = 0; i < n; i++) {
        double *x = out + 3 * i;
        unsigned char lab;
        if (phantom__uniform(&state) < lid_share) {
            double theta;
            do theta = -PHANTOM_PI + 2.0 * PHANTOM_PI * phantom__uniform(&state);
            while (phantom__uniform(&state) * lid_bound > phantom__lid_density(p, &s, c, theta));
            /* density 2f on [0, 1]: the fan's area element grows with f */
            phantom__lid(p, &s, c, sqrt(phantom__uniform(&state)), theta, x);
            lab = PHANTOM_LID;
        } else {
            double u, theta;
            do {
                /* cos(psi) uniform on [cos(base_angle), 1]: psi has density sin(psi) */
                double cpsi = 1.0 - (1.0 - phantom__uniform(&state)) * (1.0 - cosb);
                u = acos(cpsi > 1.0 ? 1.0 : cpsi) / p->base_angle;
                theta = -PHANTOM_PI + 2.0 * PHANTOM_PI * phantom__uniform(&state);
            } while (u <= 0.0 || phantom__uniform(&state) * cup_bound > phantom__cup_ratio(p, &s, u, theta));
            phantom__point(p, &s, u, theta, x);
            lab = (unsigned char)phantom_lv_in_zone(p, u, theta);
        }
        for (k = 0; k < 3; k++) /* drawn even when sigma is 0: the noise never changes the points drawn */
            x[k] += sigma * phantom__gauss(&state);
        if (label) label[i] = lab;
    }
}

/* ---- ground truth for a point ------------------------------------------- */

/* A point of one patch of the closed surface: the cup (lid = 0, a = u) or
   the lid (lid = 1, a = f, c its centre). */
static inline void phantom__patch(const phantom_lv *p, const phantom__state *s, const double c[3], int lid, double a,
                                  double theta, double out[3])
{
    if (lid) phantom__lid(p, s, c, a, theta, out);
    else phantom__point(p, s, a, theta, out);
}

/* Keeps (a, theta) on the patch: theta in [-pi, pi); on the cup a < 0 is
   the point across the apex, (-a, theta + pi); a is clamped to [0, 1]. */
static inline void phantom__normalise(int lid, double *a, double *theta)
{
    if (*a < 0.0) {
        if (lid) *a = 0.0;
        else { *a = -*a; *theta += PHANTOM_PI; }
    }
    if (*a > 1.0) *a = 1.0;
    *theta -= 2.0 * PHANTOM_PI * floor((*theta + PHANTOM_PI) / (2.0 * PHANTOM_PI));
}

/* Nearest point of one patch to q from (a, theta): Levenberg-Marquardt on
   |X(a, theta) - q|^2, derivatives by forward differences, a held at its
   bound when the step would leave the patch. Returns the squared distance. */
static inline double phantom__descend(const phantom_lv *p, const phantom__state *s, const double c[3], int lid,
                                      const double q[3], double *a, double *theta)
{
    const double h = 1e-7;
    double x[3], xa[3] = {0.0, 0.0, 0.0}, xt[3] = {0.0, 0.0, 0.0}, r[3] = {0.0, 0.0, 0.0}, r2, lambda = 1e-3;
    int it, fresh = 1;
    phantom__normalise(lid, a, theta);
    phantom__patch(p, s, c, lid, *a, *theta, x);
    r2 = phantom__dist2(x, q);
    for (it = 0; it < 100 && lambda < 1e10 && r2 > 0.0; it++) {
        double haa, hat, htt, ga, gt, det, da, dt, na, nt, y[3], y2, tiny;
        if (fresh) { /* the Jacobian at the current point, stepping inward in a */
            double ha = *a + h <= 1.0 ? h : -h;
            phantom__patch(p, s, c, lid, *a + ha, *theta, xa);
            phantom__patch(p, s, c, lid, *a, *theta + h, xt);
            phantom__sub(xa, x, xa);
            phantom__sub(xt, x, xt);
            xa[0] /= ha; xa[1] /= ha; xa[2] /= ha;
            xt[0] /= h; xt[1] /= h; xt[2] /= h;
            phantom__sub(x, q, r);
            fresh = 0;
        }
        haa = phantom__dot(xa, xa); hat = phantom__dot(xa, xt); htt = phantom__dot(xt, xt);
        ga = phantom__dot(xa, r); gt = phantom__dot(xt, r);
        tiny = 1e-12 * (haa + htt); /* theta moves nothing at the apex or the lid's centre */
        haa = haa * (1.0 + lambda) + tiny;
        htt = htt * (1.0 + lambda) + tiny;
        det = haa * htt - hat * hat;
        da = -(htt * ga - hat * gt) / det;
        dt = -(haa * gt - hat * ga) / det;
        if ((*a >= 1.0 && da > 0.0) || (lid && *a <= 0.0 && da < 0.0)) { /* on the bound: slide along it */
            da = 0.0;
            dt = -gt / htt;
        }
        na = *a + da;
        nt = *theta + dt;
        phantom__normalise(lid, &na, &nt);
        phantom__patch(p, s, c, lid, na, nt, y);
        y2 = phantom__dist2(y, q);
        if (y2 <= r2) {
            int done = fabs(da) < 1e-12 && fabs(dt) < 1e-12;
            *a = na; *theta = nt;
            x[0] = y[0]; x[1] = y[1]; x[2] = y[2];
            r2 = y2;
            fresh = 1;
            if (lambda > 1e-9) lambda *= 0.1;
            if (done) break;
        } else
            lambda *= 10.0;
    }
    return r2;
}

/* phantom_lv_nearest, with the state prepared; c gets the lid's centre. */
static inline int phantom__nearest(const phantom_lv *p, const phantom__state *s, const double q[3], double material[2],
                                   double *distance, double c[3])
{
    double radial = 1.0 - p->contraction * s->beat, axial = 1.0 - p->shortening * s->beat;
    double x, y, z, ua, ta, fl, tl, dc, dl, rim[3], rho, rho_rim;
    phantom__centroid(p, s, c);
    /* the cup: undo a uniform beat, then follow the ray from the origin in
       coordinates scaled by the semi-axes (exact at ED for a point on the
       cup, as the bumps scale the ellipsoid radially) */
    x = radial > 1e-6 ? q[0] / radial : q[0];
    y = radial > 1e-6 ? q[1] / radial : q[1];
    z = axial > 1e-6 ? s->apex + (q[2] - s->apex) / axial : q[2];
    ta = atan2(y, x);
    ua = atan2(sqrt(x * x + y * y) / p->radius, -z / p->height) / p->base_angle;
    { /* then the best of a window of material points about it, +-0.4 rad on
         the unit sphere: during the beat the zone's edge folds the wall, and
         from off the surface the descent alone can stop in the wrong fold */
        double u0 = ua, t0 = ta, best = HUGE_VAL, du = 0.4 / p->base_angle, sp = sin(u0 * p->base_angle);
        double dt = sp > 0.4 / PHANTOM_PI ? 0.4 / sp : PHANTOM_PI;
        int i, j;
        for (i = -6; i <= 6; i++)
            for (j = -12; j <= 12; j++) {
                double a = u0 + du * i / 6.0, t = t0 + dt * j / 12.0, e[3], e2;
                phantom__normalise(0, &a, &t);
                phantom__point(p, s, a, t, e);
                e2 = phantom__dist2(e, q);
                if (e2 < best) { best = e2; ua = a; ta = t; }
            }
    }
    dc = phantom__descend(p, s, c, 0, q, &ua, &ta);
    /* the lid: the angle of q about its centre, the fraction of the way out */
    tl = atan2(q[1] - c[1], q[0] - c[0]);
    phantom__point(p, s, 1.0, tl, rim);
    rho = sqrt((q[0] - c[0]) * (q[0] - c[0]) + (q[1] - c[1]) * (q[1] - c[1]));
    rho_rim = sqrt((rim[0] - c[0]) * (rim[0] - c[0]) + (rim[1] - c[1]) * (rim[1] - c[1]));
    fl = rho_rim > 0.0 ? rho / rho_rim : 0.0;
    dl = phantom__descend(p, s, c, 1, q, &fl, &tl);
    if (distance) *distance = sqrt(dl < dc ? dl : dc);
    if (dl < dc) {
        material[0] = fl; material[1] = tl;
        return PHANTOM_LID;
    }
    material[0] = ua; material[1] = ta;
    return phantom_lv_in_zone(p, ua, ta) ? PHANTOM_ZONE : PHANTOM_WALL;
}

/* The nearest material point of the closed surface (cup or lid) at a phase
   to q, a point near that surface: returns its label (PHANTOM_WALL,
   PHANTOM_ZONE or PHANTOM_LID); material[] gets its (u, theta) on the cup or
   (f, theta) on the lid, *distance (may be NULL) the distance to it. A local
   search (Levenberg-Marquardt on each patch, the cup's from the best of a
   window of points about a first guess) for points within a few percent of
   the scale of the surface; ~50-70 microseconds. */
static inline int phantom_lv_nearest(const phantom_lv *p, double phase, const double q[3], double material[2],
                                     double *distance)
{
    phantom__state s;
    double c[3];
    phantom__prepare(p, phase, &s);
    return phantom__nearest(p, &s, q, material, distance, c);
}

/* Ground truth for q, a point near the ED (phase 0) closed surface: the
   label of its nearest material point (cup or lid), whose motion from ED to
   ES, position at phase 0.5 - position at phase 0, goes to motion[] (may be
   NULL; on the lid the material point is the same fraction of the way from
   the centroid to the rim at the same theta in both phases). */
static inline int phantom_lv_locate_motion(const phantom_lv *p, const double q[3], double motion[3])
{
    phantom__state ed, es;
    double m[2], c[3], a[3], b[3];
    int label;
    phantom__prepare(p, 0.0, &ed);
    label = phantom__nearest(p, &ed, q, m, NULL, c);
    if (motion) {
        phantom__prepare(p, 0.5, &es);
        if (label == PHANTOM_LID) {
            phantom__lid(p, &ed, c, m[0], m[1], a);
            phantom__centroid(p, &es, c);
            phantom__lid(p, &es, c, m[0], m[1], b);
        } else {
            phantom__point(p, &ed, m[0], m[1], a);
            phantom__point(p, &es, m[0], m[1], b);
        }
        phantom__sub(b, a, motion);
    }
    return label;
}

/* As phantom_lv_locate_motion, with the displacement's length,
   |position at ES - position at ED|, in *displacement (may be NULL). */
static inline int phantom_lv_locate(const phantom_lv *p, const double q[3], double *displacement)
{
    double motion[3];
    int label = phantom_lv_locate_motion(p, q, displacement ? motion : NULL);
    if (displacement) *displacement = sqrt(phantom__dot(motion, motion));
    return label;
}

#endif

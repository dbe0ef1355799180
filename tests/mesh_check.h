/* mesh_check.h - an independent check that a model does not fold, for the
   tests and the benches: it shares no code with the library's fold-free
   step (it only meshes the model and maps points through its lattice).

   Header-only, static functions, C99; include after sqffd.h. Uses malloc.

   meshcheck_self_intersections: the triangle pairs of a mesh that cross
     each other (a sort-and-sweep over the triangles' bounding boxes, then
     an exact-geometry pair test with a tolerance, below).
   meshcheck_winding: the generalised winding number of a point.
   meshcheck_folded_share: the share of random points in a mesh's box wound
     neither 0 nor 1 times.
   meshcheck_model_folds: the fold test: points drawn inside the model's
     superquadric mapped through its lattice, each image's winding number
     with respect to the model's mesh (1 where the model does not fold; by
     THE COLUMN COUNT, exact and fast), and the mesh's crossing pairs.

   THE PAIR TEST. Two triangles cross when an edge of one passes through the
   other: its ends lie on opposite sides of the other's plane, each more than
   eps away from it, and the point where it passes lies inside the other
   triangle, more than eps from each of its edge lines. Triangles that lie in
   one plane (every corner of one within eps of the other's plane) cross when
   they overlap in that plane: two edges cross (each one's ends more than eps
   on either side of the other's line), or a corner or the centroid of one
   lies inside the other, more than eps from its edge lines. eps is 1e-9 of
   the mesh's bounding-box diagonal: far above rounding (1e-16 of it) and far
   below any fold worth the name. Contacts within eps, and crossings that
   reach no further than eps past a plane or an edge, do not count.
   Neighbours need no special case: a corner two triangles share lies in
   both planes and on their edge lines, so the edges at it never pass
   "through" the other, and two triangles sharing a vertex (the fans at a
   pole) or an edge count only if another part of them crosses: the edge
   opposite the shared vertex passes through the other, or, in one plane,
   the two overlap (a fold over the shared edge). Identical triangles
   (centroid inside) count. Coordinates decide, not indices, so coincident
   vertices with different indices are the same point. Triangles of no area
   (within rounding) are skipped. */
#ifndef SQFFD_MESH_CHECK_H
#define SQFFD_MESH_CHECK_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "../examples/sqffd_synth.h"

#define MESHCHECK_EPS 1e-9           /* the pair test's tolerance, in mesh bounding-box diagonals */
#define MESHCHECK_SOLID_SCALE 0.95   /* meshcheck_model_folds draws inside the superquadric scaled by this */
#define MESHCHECK_SEED 20261201u     /* and from this seed */

/* One triangle as the pair test uses it. */
typedef struct meshcheck__tri {
    double p[3][3];  /* corners */
    double n[3];     /* unit normal */
    double m[3][3];  /* m[k]: unit in-plane normal of edge p[k] -> p[k+1], pointing inside */
    double lo[3], hi[3];
    size_t index;    /* in the caller's triangle list */
} meshcheck__tri;

static inline double meshcheck__dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static inline void meshcheck__cross(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static inline void meshcheck__sub(const double a[3], const double b[3], double out[3])
{
    out[0] = a[0] - b[0];
    out[1] = a[1] - b[1];
    out[2] = a[2] - b[2];
}

/* Fills t from three corners; 0 when the triangle has no area (twice its
   area at most 1e-12 of its longest edge squared: rounding-level). */
static inline int meshcheck__tri_init(meshcheck__tri *t, const double *a, const double *b, const double *c)
{
    double e[3][3], len2 = 0.0, area2;
    int k, i;
    memcpy(t->p[0], a, sizeof t->p[0]);
    memcpy(t->p[1], b, sizeof t->p[1]);
    memcpy(t->p[2], c, sizeof t->p[2]);
    for (k = 0; k < 3; k++) {
        meshcheck__sub(t->p[(k + 1) % 3], t->p[k], e[k]);
        if (meshcheck__dot(e[k], e[k]) > len2) len2 = meshcheck__dot(e[k], e[k]);
    }
    meshcheck__cross(e[0], e[1], t->n);
    area2 = sqrt(meshcheck__dot(t->n, t->n));
    if (!(area2 > 1e-12 * len2)) return 0;
    for (i = 0; i < 3; i++) t->n[i] /= area2;
    for (k = 0; k < 3; k++) {
        double len = sqrt(meshcheck__dot(e[k], e[k]));
        meshcheck__cross(t->n, e[k], t->m[k]);
        for (i = 0; i < 3; i++) t->m[k][i] /= len;
    }
    for (i = 0; i < 3; i++) {
        t->lo[i] = fmin(fmin(a[i], b[i]), c[i]);
        t->hi[i] = fmax(fmax(a[i], b[i]), c[i]);
    }
    return 1;
}

/* x lies inside t (in its plane), more than eps from each edge line. */
static inline int meshcheck__inside(const meshcheck__tri *t, const double x[3], double eps)
{
    int k;
    for (k = 0; k < 3; k++) {
        double d[3];
        meshcheck__sub(x, t->p[k], d);
        if (!(meshcheck__dot(t->m[k], d) > eps)) return 0;
    }
    return 1;
}

/* The segment p-q passes through t (THE PAIR TEST). */
static inline int meshcheck__segment_crosses(const double p[3], const double q[3], const meshcheck__tri *t, double eps)
{
    double dp[3], dq[3], x[3], a, b, s;
    int i;
    meshcheck__sub(p, t->p[0], dp);
    meshcheck__sub(q, t->p[0], dq);
    a = meshcheck__dot(t->n, dp);
    b = meshcheck__dot(t->n, dq);
    if (!((a > eps && b < -eps) || (a < -eps && b > eps))) return 0;
    s = a / (a - b);
    for (i = 0; i < 3; i++) x[i] = p[i] + s * (q[i] - p[i]);
    /* x is in t's plane up to rounding; the edge normals m lie in it */
    return meshcheck__inside(t, x, eps);
}

/* Signed distance of r from the line through p and q (2-D). */
static inline double meshcheck__side(const double p[2], const double q[2], const double r[2])
{
    double ux = q[0] - p[0], uy = q[1] - p[1];
    return (ux * (r[1] - p[1]) - uy * (r[0] - p[0])) / sqrt(ux * ux + uy * uy);
}

/* r inside the 2-D triangle t (corners x y each, either orientation), more
   than eps from each edge line. */
static inline int meshcheck__inside2(const double t[6], const double r[2], double eps)
{
    double s = meshcheck__side(t, t + 2, t + 4) > 0.0 ? 1.0 : -1.0;
    int k;
    for (k = 0; k < 3; k++)
        if (!(s * meshcheck__side(t + 2 * k, t + 2 * ((k + 1) % 3), r) > eps)) return 0;
    return 1;
}

/* Two triangles in one plane, the plane of `frame`: do they overlap? */
static inline int meshcheck__coplanar_overlap(const meshcheck__tri *frame, const meshcheck__tri *a, const meshcheck__tri *b,
                                       double eps)
{
    double u[3], w[3], ta[6], tb[6], ca[2] = {0.0, 0.0}, cb[2] = {0.0, 0.0}, len;
    int i, j;
    meshcheck__sub(frame->p[1], frame->p[0], u);
    len = sqrt(meshcheck__dot(u, u));
    for (i = 0; i < 3; i++) u[i] /= len;
    meshcheck__cross(frame->n, u, w);
    for (i = 0; i < 3; i++) {
        double d[3];
        meshcheck__sub(a->p[i], frame->p[0], d);
        ta[2 * i] = meshcheck__dot(d, u);
        ta[2 * i + 1] = meshcheck__dot(d, w);
        meshcheck__sub(b->p[i], frame->p[0], d);
        tb[2 * i] = meshcheck__dot(d, u);
        tb[2 * i + 1] = meshcheck__dot(d, w);
        for (j = 0; j < 2; j++) {
            ca[j] += ta[2 * i + j] / 3.0;
            cb[j] += tb[2 * i + j] / 3.0;
        }
    }
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) { /* edge p-q of a against edge r-s of b */
            const double *p = ta + 2 * i, *q = ta + 2 * ((i + 1) % 3), *r = tb + 2 * j, *s = tb + 2 * ((j + 1) % 3);
            double r1 = meshcheck__side(p, q, r), s1 = meshcheck__side(p, q, s);
            double p1 = meshcheck__side(r, s, p), q1 = meshcheck__side(r, s, q);
            if (((r1 > eps && s1 < -eps) || (r1 < -eps && s1 > eps)) && ((p1 > eps && q1 < -eps) || (p1 < -eps && q1 > eps)))
                return 1;
        }
    for (i = 0; i < 3; i++)
        if (meshcheck__inside2(tb, ta + 2 * i, eps) || meshcheck__inside2(ta, tb + 2 * i, eps)) return 1;
    return meshcheck__inside2(tb, ca, eps) || meshcheck__inside2(ta, cb, eps);
}

/* Every corner of b within eps of a's plane. */
static inline int meshcheck__in_plane(const meshcheck__tri *a, const meshcheck__tri *b, double eps)
{
    int i;
    for (i = 0; i < 3; i++) {
        double d[3];
        meshcheck__sub(b->p[i], a->p[0], d);
        if (!(fabs(meshcheck__dot(a->n, d)) <= eps)) return 0;
    }
    return 1;
}

/* THE PAIR TEST on two triangles. */
static inline int meshcheck__pair_crosses(const meshcheck__tri *a, const meshcheck__tri *b, double eps)
{
    int k;
    for (k = 0; k < 3; k++)
        if (meshcheck__segment_crosses(a->p[k], a->p[(k + 1) % 3], b, eps) ||
            meshcheck__segment_crosses(b->p[k], b->p[(k + 1) % 3], a, eps))
            return 1;
    if (meshcheck__in_plane(a, b, eps)) return meshcheck__coplanar_overlap(a, a, b, eps);
    if (meshcheck__in_plane(b, a, eps)) return meshcheck__coplanar_overlap(b, a, b, eps);
    return 0;
}

static inline int meshcheck__cmp_lo(const void *x, const void *y)
{
    double a = ((const meshcheck__tri *)x)->lo[0], b = ((const meshcheck__tri *)y)->lo[0];
    return (a > b) - (a < b);
}

/* The triangles of a mesh (nt triangles, 3 indices each into nv vertices,
   x y z each) that cross each other, pairwise (THE PAIR TEST above): their
   count, or -1 when an index is out of range or memory ran out. The first
   max_report crossing pairs go to pairs (2 triangle indices each, the
   smaller first; in no particular order; may be NULL when max_report is 0).
   Sorts the triangles along the axis of the box's longest side and sweeps:
   only the pairs whose boxes overlap are tested. */
static inline long meshcheck_self_intersections(const double *vertices, size_t nv, const uint32_t *triangles, size_t nt,
                                         size_t max_report, uint32_t *pairs)
{
    meshcheck__tri *t;
    double lo[3], hi[3], eps;
    size_t i, j, count = 0;
    long found = 0;
    int k, axis = 0;
    for (i = 0; i < 3 * nt; i++)
        if (triangles[i] >= nv) return -1;
    if (nt < 2) return 0;
    t = (meshcheck__tri *)malloc(nt * sizeof *t);
    if (!t) return -1;
    synth_bounds(vertices, nv, lo, hi);
    eps = MESHCHECK_EPS * sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                               (hi[2] - lo[2]) * (hi[2] - lo[2]));
    for (k = 1; k < 3; k++)
        if (hi[k] - lo[k] > hi[axis] - lo[axis]) axis = k;
    for (i = 0; i < nt; i++) {
        double c[3][3]; /* the corners, axes turned cyclically so that the sweep's runs first (a rotation) */
        int corner;
        for (corner = 0; corner < 3; corner++)
            for (k = 0; k < 3; k++) c[corner][k] = vertices[3 * (size_t)triangles[3 * i + (size_t)corner] + (size_t)((axis + k) % 3)];
        if (meshcheck__tri_init(&t[count], c[0], c[1], c[2])) t[count++].index = i;
    }
    qsort(t, count, sizeof *t, meshcheck__cmp_lo);
    for (i = 0; i < count; i++)
        for (j = i + 1; j < count && t[j].lo[0] <= t[i].hi[0]; j++) {
            for (k = 1; k < 3; k++)
                if (t[j].lo[k] > t[i].hi[k] || t[i].lo[k] > t[j].hi[k]) break;
            if (k < 3 || !meshcheck__pair_crosses(&t[i], &t[j], eps)) continue;
            if ((size_t)found < max_report) {
                size_t a = t[i].index < t[j].index ? t[i].index : t[j].index;
                pairs[2 * found] = (uint32_t)a;
                pairs[2 * found + 1] = (uint32_t)(t[i].index + t[j].index - a);
            }
            found++;
        }
    free(t);
    return found;
}

/* The generalised winding number of `point` with respect to a mesh: the sum
   of its triangles' signed solid angles seen from the point, over 4 pi
   (Van Oosterom & Strackee: tan(Omega / 2) = a . (b x c) / (|a| |b| |c| +
   (a . b) |c| + (b . c) |a| + (c . a) |b|), a, b, c the corners relative to
   the point). For a closed mesh whose triangles all face outward
   (counter-clockwise seen from outside): 1 inside, 0 outside, k where the
   surface wraps k times around the point; a fraction on the surface. The
   indices must be below nv (not checked). */
static inline double meshcheck_winding(const double *vertices, size_t nv, const uint32_t *triangles, size_t nt,
                                const double point[3])
{
    double sum = 0.0;
    size_t i;
    (void)nv;
    for (i = 0; i < nt; i++) {
        double a[3], b[3], c[3], bc[3], la, lb, lc;
        meshcheck__sub(vertices + 3 * (size_t)triangles[3 * i], point, a);
        meshcheck__sub(vertices + 3 * (size_t)triangles[3 * i + 1], point, b);
        meshcheck__sub(vertices + 3 * (size_t)triangles[3 * i + 2], point, c);
        la = sqrt(meshcheck__dot(a, a));
        lb = sqrt(meshcheck__dot(b, b));
        lc = sqrt(meshcheck__dot(c, c));
        meshcheck__cross(b, c, bc);
        sum += atan2(meshcheck__dot(a, bc),
                     la * lb * lc + meshcheck__dot(a, b) * lc + meshcheck__dot(b, c) * la + meshcheck__dot(c, a) * lb);
    }
    return sum / (2.0 * SYNTH_PI); /* each atan2 is half a solid angle */
}

/* THE COLUMN COUNT: the winding number of a point off the surface of a
   closed, consistently oriented mesh, exactly, as the signed count of the
   triangles the vertical ray up from it passes through (+1 where the
   triangle faces up, -1 down): the integer meshcheck_winding rounds to,
   at a few triangles' cost instead of every triangle's. The triangles are
   binned by their x-y boxes into a grid of columns. The ray's point lies
   in a triangle's x-y projection when it lies on the same side of its three
   edges; each edge's side is computed from its ends in one order (lower x,
   then y, first), so the two triangles sharing an edge take exactly
   opposite sides, and a point exactly on an edge is nudged to one side by
   the same rule (an infinitesimal move by (d, d^2)): no crossing is counted
   twice or missed at an edge. */
typedef struct meshcheck__columns {
    const double *v;
    const uint32_t *t;
    double lo[2], cell[2];
    size_t g;          /* g x g columns */
    size_t *start;     /* column c holds list[start[c]] .. list[start[c + 1] - 1] */
    uint32_t *list;
} meshcheck__columns;

/* The column range of a triangle (or of a point: the same corner thrice). */
static inline void meshcheck__column_range(const meshcheck__columns *c, const double *a, const double *b,
                                           const double *d, size_t from[2], size_t to[2])
{
    int k;
    for (k = 0; k < 2; k++) {
        double lo = (fmin(fmin(a[k], b[k]), d[k]) - c->lo[k]) / c->cell[k];
        double hi = (fmax(fmax(a[k], b[k]), d[k]) - c->lo[k]) / c->cell[k];
        from[k] = lo <= 0.0 ? 0 : lo >= (double)(c->g - 1) ? c->g - 1 : (size_t)lo;
        to[k] = hi <= 0.0 ? 0 : hi >= (double)(c->g - 1) ? c->g - 1 : (size_t)hi;
    }
}

/* Bins the mesh; 0 when memory ran out. */
static inline int meshcheck__columns_build(meshcheck__columns *c, const double *v, size_t nv, const uint32_t *t,
                                           size_t nt)
{
    double lo[3], hi[3];
    size_t i, x, y, from[2], to[2], cells;
    int pass, k;
    synth_bounds(v, nv, lo, hi);
    c->v = v;
    c->t = t;
    c->g = (size_t)sqrt((double)nt) / 2 + 1;
    for (k = 0; k < 2; k++) {
        c->lo[k] = lo[k];
        c->cell[k] = hi[k] > lo[k] ? (hi[k] - lo[k]) / (double)c->g : 1.0;
    }
    cells = c->g * c->g;
    c->start = (size_t *)calloc(cells + 1, sizeof *c->start);
    c->list = NULL;
    if (!c->start) return 0;
    for (pass = 0; pass < 2; pass++) { /* count, then fill */
        for (i = 0; i < nt; i++) {
            meshcheck__column_range(c, v + 3 * (size_t)t[3 * i], v + 3 * (size_t)t[3 * i + 1], v + 3 * (size_t)t[3 * i + 2],
                                    from, to);
            for (y = from[1]; y <= to[1]; y++)
                for (x = from[0]; x <= to[0]; x++)
                    if (pass) c->list[c->start[y * c->g + x + 1]++] = (uint32_t)i;
                    else c->start[y * c->g + x + 1]++;
        }
        if (pass) break;
        for (i = 0; i < cells; i++) c->start[i + 1] += c->start[i];
        c->list = (uint32_t *)malloc((c->start[cells] ? c->start[cells] : 1) * sizeof *c->list);
        if (!c->list) {
            free(c->start);
            return 0;
        }
        memmove(c->start + 1, c->start, cells * sizeof *c->start); /* fill from each column's start */
    }
    return 1;
}

/* The side of the edge p-r that q's x-y lies on (1 left, -1 right, ties
   broken as above) and the edge function's value (twice the signed area of
   p, r, q), both computed from the edge's ends in one order. */
static inline int meshcheck__edge_side(const double *p, const double *r, const double *q, double *value)
{
    int flip = p[0] > r[0] || (p[0] == r[0] && p[1] > r[1]), s;
    const double *a = flip ? r : p, *b = flip ? p : r;
    double e = (b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0]);
    if (e != 0.0) s = e > 0.0 ? 1 : -1;
    else if (b[1] != a[1]) s = b[1] > a[1] ? -1 : 1; /* moved by d in x */
    else s = b[0] > a[0] ? 1 : -1;                   /* then by d^2 in y */
    *value = flip ? -e : e;
    return flip ? -s : s;
}

/* THE COLUMN COUNT at q. */
static inline long meshcheck__column_winding(const meshcheck__columns *c, const double q[3])
{
    size_t from[2], to[2], i, column;
    long w = 0;
    if (q[0] < c->lo[0] || q[1] < c->lo[1] || q[0] > c->lo[0] + (double)c->g * c->cell[0] ||
        q[1] > c->lo[1] + (double)c->g * c->cell[1])
        return 0;
    meshcheck__column_range(c, q, q, q, from, to);
    column = from[1] * c->g + from[0];
    for (i = c->start[column]; i < c->start[column + 1]; i++) {
        const uint32_t *t = c->t + 3 * (size_t)c->list[i];
        const double *a = c->v + 3 * (size_t)t[0], *b = c->v + 3 * (size_t)t[1], *d = c->v + 3 * (size_t)t[2];
        double eab, ebd, eda, sum;
        int s = meshcheck__edge_side(a, b, q, &eab);
        if (meshcheck__edge_side(b, d, q, &ebd) != s || meshcheck__edge_side(d, a, q, &eda) != s) continue;
        sum = eab + ebd + eda; /* twice the projected area; the barycentric weights are the opposite edges' */
        if (sum != 0.0 && (ebd * a[2] + eda * b[2] + eab * d[2]) / sum > q[2]) w += s;
    }
    return w;
}

/* The share of `samples` random points (seeded) in a closed mesh's bounding
   box whose winding number, rounded, is neither 0 nor 1: where a surface
   passes through itself some region is wound -1 or 2 times; a surface that
   does not has none. */
static inline double meshcheck_folded_share(const double *vertices, size_t nv, const uint32_t *triangles, size_t nt,
                                     size_t samples, uint64_t seed)
{
    synth_rng r = synth_rng_seed(seed);
    double lo[3], hi[3];
    size_t i, folded = 0;
    synth_bounds(vertices, nv, lo, hi);
    for (i = 0; i < samples; i++) {
        double q[3];
        long wound;
        int k;
        for (k = 0; k < 3; k++) q[k] = synth_range(&r, lo[k], hi[k]);
        wound = lround(meshcheck_winding(vertices, nv, triangles, nt, q));
        folded += wound != 0 && wound != 1;
    }
    return (double)folded / (double)samples;
}

/* What meshcheck_model_folds found. */
typedef struct meshcheck_folds {
    long crossings;       /* triangle pairs of the model's mesh that cross (meshcheck_self_intersections) */
    int samples;          /* points drawn inside the superquadric (fewer than asked only for a shape that fills
                             almost none of its box) */
    int winding_failures; /* of their images, those whose winding number w is not 1 */
    long worst_winding;   /* the w farthest from 1 (1 when there are no samples) */
} meshcheck_folds;

/* The fold test: `samples` points drawn uniformly (seeded: the same points
   on every machine) inside the model's superquadric scaled by
   MESHCHECK_SOLID_SCALE about its centre (tapering included: the solid the
   model's surface and interior map from, less a skin that keeps the images
   clear of the mesh's chords), each mapped through the model's lattice
   (sqffd_ffd_deform: the map the model's surface points take), and the
   winding number of each image with respect to the model's n_eta x n_omega
   mesh (sqffd_model_mesh; the CLI writes 64 x 128), by THE COLUMN COUNT
   (meshcheck_winding's value rounded, exactly). Where the model does not
   fold, every image lies inside its surface once: w = 1. Where it folds, the
   folded region's images land outside (0) or in a part wound twice (2), or
   the whole surface turns inside out (-1). The mesh's crossing pairs too.
   Drawn by rejection in the superquadric's local box (at most 1,000 tries
   a sample). Results: what sqffd_model_mesh_size, sqffd_model_mesh and the
   superquadric functions return (INVALID_MODEL for a model that fails
   sqffd_model_validate, INVALID_ARGUMENT for a bad grid or samples < 0);
   TOO_LARGE when the mesh could not be allocated. */
static inline sqffd_result meshcheck_model_folds(const sqffd_model *model, int samples, int n_eta, int n_omega,
                                          meshcheck_folds *out)
{
    sqffd_superquadric solid;
    meshcheck__columns columns = {NULL, NULL, {0.0, 0.0}, {0.0, 0.0}, 0, NULL, NULL};
    synth_rng r = synth_rng_seed(MESHCHECK_SEED);
    double *v = NULL, half[3];
    uint32_t *t = NULL;
    size_t nv, nt;
    long tries, max_tries = 1000L * samples;
    sqffd_result res;
    int k;
    if (!model || !out || samples < 0) return SQFFD_ERROR_INVALID_ARGUMENT;
    memset(out, 0, sizeof *out);
    out->worst_winding = 1;
    res = sqffd_model_validate(model);
    if (res == SQFFD_OK) res = sqffd_model_mesh_size(n_eta, n_omega, &nv, &nt);
    if (res != SQFFD_OK) return res;
    v = (double *)malloc(3 * nv * sizeof *v);
    t = (uint32_t *)malloc(3 * nt * sizeof *t);
    if (!v || !t) res = SQFFD_ERROR_TOO_LARGE;
    if (res == SQFFD_OK) res = sqffd_model_mesh(model, n_eta, n_omega, v, t);
    if (res == SQFFD_OK && ((out->crossings = meshcheck_self_intersections(v, nv, t, nt, 0, NULL)) < 0 ||
                            !meshcheck__columns_build(&columns, v, nv, t, nt)))
        res = SQFFD_ERROR_TOO_LARGE;
    solid = model->sq;
    for (k = 0; k < 3; k++) solid.size[k] *= MESHCHECK_SOLID_SCALE;
    /* the tapered solid's local box: |x| <= a1 (1 + |Kx|), |y| <= a2 (1 + |Ky|), |z| <= a3 */
    half[0] = solid.size[0] * (1.0 + fabs(solid.taper[0]));
    half[1] = solid.size[1] * (1.0 + fabs(solid.taper[1]));
    half[2] = solid.size[2];
    for (tries = 0; res == SQFFD_OK && out->samples < samples && tries < max_tries; tries++) {
        double local[3], world[3], image[3], f;
        long w;
        int i;
        for (k = 0; k < 3; k++) local[k] = synth_range(&r, -half[k], half[k]);
        for (i = 0; i < 3; i++) /* rotation's columns are the local axes */
            world[i] = solid.center[i] + meshcheck__dot(solid.rotation + 3 * i, local);
        res = sqffd_sq_inside_outside(&solid, world, &f);
        if (res != SQFFD_OK || !(f <= 1.0)) continue;
        res = sqffd_ffd_deform(&model->ffd, world, image);
        if (res != SQFFD_OK) break;
        w = meshcheck__column_winding(&columns, image);
        out->samples++;
        out->winding_failures += w != 1;
        if (labs(w - 1) > labs(out->worst_winding - 1)) out->worst_winding = w;
    }
    free(columns.start);
    free(columns.list);
    free(v);
    free(t);
    return res;
}

#endif

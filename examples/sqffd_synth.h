/* sqffd_synth.h - synthetic data for the tests, the benchmarks and the demo.

   Header-only, every function `static inline`; include after sqffd.h (the
   surface sampler calls the library's sqffd_sq_sample_uniform). Uses the C
   library (malloc, qsort) freely. Everything is driven by synth_rng, a
   splitmix64 generator, so the same seed gives the same data on every
   machine. */
#ifndef SQFFD_SYNTH_H
#define SQFFD_SYNTH_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define SYNTH_PI 3.14159265358979323846

/* ---- deterministic random numbers ------------------------------------ */
typedef struct synth_rng {
    uint64_t state;
} synth_rng;

static inline synth_rng synth_rng_seed(uint64_t seed)
{
    synth_rng r;
    r.state = seed;
    return r;
}

/* splitmix64 */
static inline uint64_t synth_u64(synth_rng *r)
{
    uint64_t z = (r->state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* uniform in [0, 1), 53 random bits */
static inline double synth_uniform(synth_rng *r)
{
    return (double)(synth_u64(r) >> 11) * (1.0 / 9007199254740992.0);
}

/* uniform in [lo, hi) */
static inline double synth_range(synth_rng *r, double lo, double hi)
{
    return lo + (hi - lo) * synth_uniform(r);
}

/* uniform integer in [0, n), n > 0 */
static inline size_t synth_index(synth_rng *r, size_t n)
{
    return (size_t)(synth_uniform(r) * (double)n) % n;
}

/* standard normal (Box-Muller, one value per call: no hidden state) */
static inline double synth_gaussian(synth_rng *r)
{
    double u1 = 1.0 - synth_uniform(r); /* (0, 1]: log is finite */
    double u2 = synth_uniform(r);
    return sqrt(-2.0 * log(u1)) * cos(2.0 * SYNTH_PI * u2);
}

/* ---- geometry ------------------------------------------------------------ */

/* Uniformly distributed rotation (Shoemake's uniform unit quaternion), as a
   row-major matrix with det +1. */
static inline void synth_rotation(synth_rng *r, double rot[9])
{
    double u1 = synth_uniform(r), u2 = synth_uniform(r), u3 = synth_uniform(r);
    double s1 = sqrt(1.0 - u1), s2 = sqrt(u1);
    double x = s1 * sin(2.0 * SYNTH_PI * u2), y = s1 * cos(2.0 * SYNTH_PI * u2);
    double z = s2 * sin(2.0 * SYNTH_PI * u3), w = s2 * cos(2.0 * SYNTH_PI * u3);
    rot[0] = 1 - 2 * (y * y + z * z); rot[1] = 2 * (x * y - z * w);     rot[2] = 2 * (x * z + y * w);
    rot[3] = 2 * (x * y + z * w);     rot[4] = 1 - 2 * (x * x + z * z); rot[5] = 2 * (y * z - x * w);
    rot[6] = 2 * (x * z - y * w);     rot[7] = 2 * (y * z + x * w);     rot[8] = 1 - 2 * (x * x + y * y);
}

/* Ranges for a random superquadric. */
typedef struct synth_sq_ranges {
    double shape_min, shape_max; /* e1, e2 uniform in [min, max] */
    double size_min, size_max;   /* each a_i log-uniform in [min, max] */
    double taper_max;            /* Kx, Ky uniform in [-taper_max, taper_max] */
    double center_max;           /* centre uniform in [-center_max, center_max]^3 */
} synth_sq_ranges;

/* The tests' ranges: e in [0.1, 1.9], sizes spread 1:5, |K| <= 0.6. */
static inline synth_sq_ranges synth_sq_ranges_default(void)
{
    synth_sq_ranges g;
    g.shape_min = 0.1; g.shape_max = 1.9;
    g.size_min = 1.0; g.size_max = 5.0;
    g.taper_max = 0.6;
    g.center_max = 3.0;
    return g;
}

/* Random superquadric within the ranges, random rotation. */
static inline void synth_superquadric(synth_rng *r, const synth_sq_ranges *g, sqffd_superquadric *sq)
{
    int i;
    for (i = 0; i < 3; i++) sq->size[i] = g->size_min * pow(g->size_max / g->size_min, synth_uniform(r));
    for (i = 0; i < 2; i++) sq->shape[i] = synth_range(r, g->shape_min, g->shape_max);
    for (i = 0; i < 2; i++) sq->taper[i] = synth_range(r, -g->taper_max, g->taper_max);
    synth_rotation(r, sq->rotation);
    for (i = 0; i < 3; i++) sq->center[i] = synth_range(r, -g->center_max, g->center_max);
}

/* Mean of a1, a2, a3: the unit of the noise level. */
static inline double synth_mean_size(const sqffd_superquadric *sq)
{
    return (sq->size[0] + sq->size[1] + sq->size[2]) / 3.0;
}

/* Partial Fisher-Yates: moves a random choice of k of the n points
   (xyz each) to the front, in random order. */
static inline void synth_choose(synth_rng *r, double *points, size_t n, size_t k)
{
    size_t i;
    for (i = 0; i < k && i < n; i++) {
        size_t j = i + synth_index(r, n - i);
        double t[3];
        memcpy(t, points + 3 * i, sizeof t);
        memcpy(points + 3 * i, points + 3 * j, sizeof t);
        memcpy(points + 3 * j, t, sizeof t);
    }
}

/* n points spread evenly over the surface (a random choice among the
   library's near-equal-distance samples, so the density per area is about
   constant), each moved by isotropic Gaussian noise of standard deviation
   noise * mean size. Writes 3n doubles to out; returns n, or 0 when memory
   ran out or the surface could not be sampled. */
static inline size_t synth_sq_surface(synth_rng *r, const sqffd_superquadric *sq, size_t n, double noise,
                                      double *out)
{
    /* area of the ellipsoid with the same sizes (Thomsen's formula) sets the
       first spacing; aim for 2-8 times n candidates so the choice is even */
    double p = 1.6075, x = pow(sq->size[0], p), y = pow(sq->size[1], p), z = pow(sq->size[2], p);
    double area = 4.0 * SYNTH_PI * pow((x * y + y * z + z * x) / 3.0, 1.0 / p);
    double spacing = sqrt(area / (4.0 * (double)(n ? n : 1)));
    double sigma = noise * synth_mean_size(sq);
    size_t capacity = 8 * n, count = 0, i;
    int tries;
    double *all;
    if (n == 0) return 0;
    all = (double *)malloc(3 * capacity * sizeof *all);
    if (!all) return 0;
    for (tries = 0; tries < 20; tries++) {
        sqffd_result res = sqffd_sq_sample_uniform(sq, spacing, all, capacity, &count);
        if (res != SQFFD_OK && res != SQFFD_ERROR_OUTPUT_TOO_SMALL) count = 0; /* (too small: count is the need) */
        if (count >= 2 * n && count <= capacity) break;
        spacing *= count ? sqrt((double)count / (4.0 * (double)n)) : 0.5;
    }
    if (count < n || count > capacity) { free(all); return 0; }
    synth_choose(r, all, count, n);
    for (i = 0; i < 3 * n; i++) out[i] = all[i] + (sigma > 0 ? sigma * synth_gaussian(r) : 0.0);
    free(all);
    return n;
}

/* n points uniformly distributed by area over a triangle mesh (vertices:
   x y z each; triangles: three vertex indices each), written to out (3n
   doubles). Each point picks a triangle with probability proportional to
   its area (binary search in the cumulative areas), then a uniform point in
   it: barycentric weights 1 - sqrt(u), sqrt(u) (1 - v), sqrt(u) v for u, v
   uniform in [0, 1). Returns n, or 0 when memory ran out or the mesh has no
   area. */
static inline size_t synth_sample_triangles(synth_rng *r, const double *vertices, const uint32_t *triangles,
                                            size_t triangle_count, size_t n, double *out)
{
    double *cumulative, total = 0.0;
    size_t i, t;
    int k;
    if (n == 0 || triangle_count == 0) return 0;
    cumulative = (double *)malloc(triangle_count * sizeof *cumulative);
    if (!cumulative) return 0;
    for (t = 0; t < triangle_count; t++) {
        const double *a = vertices + 3 * (size_t)triangles[3 * t];
        const double *b = vertices + 3 * (size_t)triangles[3 * t + 1];
        const double *c = vertices + 3 * (size_t)triangles[3 * t + 2];
        double u[3], v[3], x, y, z;
        for (k = 0; k < 3; k++) {
            u[k] = b[k] - a[k];
            v[k] = c[k] - a[k];
        }
        x = u[1] * v[2] - u[2] * v[1];
        y = u[2] * v[0] - u[0] * v[2];
        z = u[0] * v[1] - u[1] * v[0];
        total += 0.5 * sqrt(x * x + y * y + z * z);
        cumulative[t] = total;
    }
    if (!(total > 0.0)) { free(cumulative); return 0; }
    for (i = 0; i < n; i++) {
        double target = synth_uniform(r) * total, root = sqrt(synth_uniform(r)), v = synth_uniform(r);
        double wa = 1.0 - root, wb = root * (1.0 - v), wc = root * v;
        size_t lo = 0, hi = triangle_count - 1;
        const double *a, *b, *c;
        while (lo < hi) { /* the first triangle whose cumulative area exceeds target: never one of no area */
            size_t mid = lo + (hi - lo) / 2;
            if (cumulative[mid] > target) hi = mid;
            else lo = mid + 1;
        }
        a = vertices + 3 * (size_t)triangles[3 * lo];
        b = vertices + 3 * (size_t)triangles[3 * lo + 1];
        c = vertices + 3 * (size_t)triangles[3 * lo + 2];
        for (k = 0; k < 3; k++) out[3 * i + (size_t)k] = wa * a[k] + wb * b[k] + wc * c[k];
    }
    free(cumulative);
    return n;
}

/* Axis-aligned bounding box of n points. */
static inline void synth_bounds(const double *points, size_t n, double lo[3], double hi[3])
{
    size_t i;
    int k;
    for (k = 0; k < 3; k++) lo[k] = hi[k] = n ? points[k] : 0.0;
    for (i = 1; i < n; i++)
        for (k = 0; k < 3; k++) {
            if (points[3 * i + (size_t)k] < lo[k]) lo[k] = points[3 * i + (size_t)k];
            if (points[3 * i + (size_t)k] > hi[k]) hi[k] = points[3 * i + (size_t)k];
        }
}

/* m outliers uniform in the bounding box of the n points scaled by `scale`
   about its centre (1.5 in the tests), written to out (3m doubles).
   The caller appends them (out may point just past the n points). */
static inline void synth_outliers(synth_rng *r, const double *points, size_t n, size_t m, double scale, double *out)
{
    double lo[3], hi[3];
    size_t i;
    int k;
    synth_bounds(points, n, lo, hi);
    for (i = 0; i < m; i++)
        for (k = 0; k < 3; k++) {
            double c = 0.5 * (lo[k] + hi[k]), h = 0.5 * scale * (hi[k] - lo[k]);
            out[3 * i + (size_t)k] = synth_range(r, c - h, c + h);
        }
}

static inline int synth__cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Removes the points on one side of a random plane, chosen so that the
   fraction `cut` (0..1) of them goes; the survivors are compacted in place
   (order kept). Returns how many remain (n when memory ran out). */
static inline size_t synth_cut_plane(synth_rng *r, double *points, size_t n, double cut)
{
    double dir[3], len, threshold, *proj;
    size_t i, kept = 0, removed;
    int k;
    if (n == 0 || cut <= 0.0) return n;
    do { /* uniform direction */
        for (k = 0; k < 3; k++) dir[k] = synth_gaussian(r);
        len = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    } while (len < 1e-9);
    proj = (double *)malloc(n * sizeof *proj);
    if (!proj) return n;
    for (i = 0; i < n; i++)
        proj[i] = (dir[0] * points[3 * i] + dir[1] * points[3 * i + 1] + dir[2] * points[3 * i + 2]) / len;
    removed = (size_t)(cut * (double)n + 0.5);
    if (removed >= n) removed = n - 1;
    {
        double *sorted = (double *)malloc(n * sizeof *sorted);
        if (!sorted) { free(proj); return n; }
        memcpy(sorted, proj, n * sizeof *sorted);
        qsort(sorted, n, sizeof *sorted, synth__cmp_double);
        threshold = sorted[n - removed - 1]; /* keep proj <= threshold */
        free(sorted);
    }
    for (i = 0; i < n && kept < n - removed; i++)
        if (proj[i] <= threshold) {
            memmove(points + 3 * kept, points + 3 * i, 3 * sizeof *points);
            kept++;
        }
    free(proj);
    return kept;
}

/* A thin, branched shape like a hand (the superquadric fit's hard case):
   points on a flat palm (an ellipsoid 0.5 x 0.6 x 0.12, 3 points in 8) and
   five fingers (cylinders of radius 0.06 and length 0.6 fanned out above
   it), n points from the seed. */
static inline void synth_hand(size_t n, uint64_t seed, double *out)
{
    synth_rng r = synth_rng_seed(seed);
    size_t i;
    for (i = 0; i < n; i++) {
        double *p = out + 3 * i, a = synth_range(&r, 0.0, 2.0 * SYNTH_PI), z = synth_range(&r, -1.0, 1.0);
        int part = (int)synth_index(&r, 8);
        if (part < 3) {
            double c = sqrt(1.0 - z * z);
            p[0] = 0.5 * c * cos(a); p[1] = 0.6 * c * sin(a); p[2] = 0.12 * z;
        } else {
            double angle = -0.9 + 0.45 * (double)(part - 3), len = synth_range(&r, 0.0, 0.6);
            double cx = 0.5 * sin(angle), cy = 0.55 * cos(angle);
            p[0] = cx + len * sin(angle) + 0.06 * cos(a) * cos(angle);
            p[1] = cy + len * cos(angle) - 0.06 * cos(a) * sin(angle);
            p[2] = 0.06 * sin(a);
        }
    }
}

/* A label map of a short-axis stack of closed contours, as a segmentation
   with thick slices gives it: labels[i + dims[0] (j + dims[1] k)] (u8) is
   `inside` where voxel (i, j, k)'s centre, origin + (i pixel, j pixel,
   k spacing), lies in slice k's contour (even-odd rule), `ring` within
   ring_pixels (a square around) of such a voxel, else 0. The points come
   slice by slice (consecutive points with the same z, each slice's in
   drawing order); a slice goes to the k nearest its z. */
static inline void synth_rasterise_stack(const double *points, size_t n, const double origin[3], double pixel,
                                         double spacing, const size_t dims[3], unsigned char inside,
                                         unsigned char ring, int ring_pixels, unsigned char *labels)
{
    size_t plane = dims[0] * dims[1], first = 0, last, i, j, e;
    memset(labels, 0, plane * dims[2]);
    for (; first < n; first = last) {
        double kf;
        unsigned char *s;
        for (last = first + 1; last < n && points[3 * last + 2] == points[3 * first + 2]; last++) {}
        kf = floor((points[3 * first + 2] - origin[2]) / spacing + 0.5);
        if (kf < 0.0 || kf >= (double)dims[2]) continue;
        s = labels + plane * (size_t)kf;
        for (j = 0; j < dims[1]; j++)
            for (i = 0; i < dims[0]; i++) {
                double x = origin[0] + pixel * (double)i, y = origin[1] + pixel * (double)j;
                int in = 0;
                for (e = first; e < last; e++) { /* edge e -> e + 1, the last back to the first */
                    const double *a = points + 3 * e, *b = points + 3 * (e + 1 < last ? e + 1 : first);
                    if ((a[1] > y) != (b[1] > y) && x < a[0] + (y - a[1]) * (b[0] - a[0]) / (b[1] - a[1])) in = !in;
                }
                if (in) s[i + dims[0] * j] = inside;
            }
        for (j = 0; j < dims[1]; j++)
            for (i = 0; i < dims[0]; i++) {
                long di, dj;
                if (s[i + dims[0] * j] == inside) continue;
                for (dj = -ring_pixels; dj <= ring_pixels; dj++)
                    for (di = -ring_pixels; di <= ring_pixels; di++) {
                        long ii = (long)i + di, jj = (long)j + dj;
                        if (ii >= 0 && jj >= 0 && ii < (long)dims[0] && jj < (long)dims[1] &&
                            s[(size_t)ii + dims[0] * (size_t)jj] == inside)
                            s[i + dims[0] * j] = ring;
                    }
            }
    }
}

/* The u8 volume view of such a label map: voxel (i, j, k) at origin + (i
   pixel, j pixel, k spacing). */
static inline sqffd_volume synth_label_volume(const unsigned char *labels, const size_t dims[3], const double origin[3],
                                              double pixel, double spacing)
{
    sqffd_volume v;
    memset(&v, 0, sizeof v);
    v.data = labels;
    v.type = SQFFD_VOXEL_U8;
    memcpy(v.dims, dims, sizeof v.dims);
    v.strides[0] = 1;
    v.strides[1] = (ptrdiff_t)dims[0];
    v.strides[2] = (ptrdiff_t)(dims[0] * dims[1]);
    v.affine[0] = pixel; v.affine[3] = origin[0];
    v.affine[5] = pixel; v.affine[7] = origin[1];
    v.affine[10] = spacing; v.affine[11] = origin[2];
    v.affine[15] = 1.0;
    return v;
}

#endif /* SQFFD_SYNTH_H */

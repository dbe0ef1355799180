/* Layer 7: volumes to points, against analytic volumes: a sphere's signed
   distance sampled on grids of every voxel type, with anisotropic spacing
   and a rotated affine, viewed through strides. */
#include "test.h"
#include <stdlib.h>
#include <string.h>

static const double pi = 3.14159265358979323846;

/* An affine: rotation about (1, 1, 1) by angle, spacing per axis, origin. */
static void make_affine(double angle, const double spacing[3], const double origin[3], double affine[16])
{
    double u[3], c = cos(angle), s = sin(angle), rot[9];
    int r, k;
    u[0] = u[1] = u[2] = 1.0 / sqrt(3.0);
    for (r = 0; r < 3; r++)
        for (k = 0; k < 3; k++) /* Rodrigues */
            rot[3 * r + k] = (r == k ? c : 0.0) + (1.0 - c) * u[r] * u[k] +
                             s * (r == k ? 0.0 : ((r + 1) % 3 == k ? -u[3 - r - k] : u[3 - r - k]));
    memset(affine, 0, 16 * sizeof(double));
    for (r = 0; r < 3; r++) {
        for (k = 0; k < 3; k++) affine[4 * r + k] = rot[3 * r + k] * spacing[k];
        affine[4 * r + 3] = origin[r];
    }
    affine[15] = 1.0;
}

static void voxel_to_world(const double affine[16], double i, double j, double k, double out[3])
{
    int r;
    for (r = 0; r < 3; r++) out[r] = affine[4 * r] * i + affine[4 * r + 1] * j + affine[4 * r + 2] * k + affine[4 * r + 3];
}

static size_t type_size(sqffd_voxel_type t)
{
    return t == SQFFD_VOXEL_U8 || t == SQFFD_VOXEL_I8 ? 1 : t == SQFFD_VOXEL_U16 || t == SQFFD_VOXEL_I16 ? 2 : t == SQFFD_VOXEL_F64 ? 8 : 4;
}

/* Stores value at voxel index in the type (rounded for integers). */
static void store(void *data, size_t index, sqffd_voxel_type t, double value)
{
    unsigned char *p = (unsigned char *)data + index * type_size(t);
    double r = floor(value + 0.5);
    switch (t) {
    case SQFFD_VOXEL_U8: { uint8_t x = (uint8_t)r; memcpy(p, &x, 1); } break;
    case SQFFD_VOXEL_I8: { int8_t x = (int8_t)r; memcpy(p, &x, 1); } break;
    case SQFFD_VOXEL_U16: { uint16_t x = (uint16_t)r; memcpy(p, &x, 2); } break;
    case SQFFD_VOXEL_I16: { int16_t x = (int16_t)r; memcpy(p, &x, 2); } break;
    case SQFFD_VOXEL_I32: { int32_t x = (int32_t)r; memcpy(p, &x, 4); } break;
    case SQFFD_VOXEL_F32: { float x = (float)value; memcpy(p, &x, 4); } break;
    case SQFFD_VOXEL_F64: memcpy(p, &value, 8); break;
    }
}

/* A sphere of radius R (world) at centre: the scaled value is R - |x - centre|
   (stored = (value - offset) / scale, clamped to the type's range). */
typedef struct sphere_volume {
    sqffd_volume v;
    void *data;
} sphere_volume;

static sphere_volume make_sphere(sqffd_voxel_type t, const size_t dims[3], const double affine[16], const double centre[3],
                                 double radius, double scale, double offset)
{
    sphere_volume s;
    size_t i, j, k, n = dims[0] * dims[1] * dims[2];
    double lo = t == SQFFD_VOXEL_U8 ? 0 : t == SQFFD_VOXEL_I8 ? -128 : t == SQFFD_VOXEL_U16 ? 0 : t == SQFFD_VOXEL_I16 ? -32768 : -2e9;
    double hi = t == SQFFD_VOXEL_U8 ? 255 : t == SQFFD_VOXEL_I8 ? 127 : t == SQFFD_VOXEL_U16 ? 65535 : t == SQFFD_VOXEL_I16 ? 32767 : 2e9;
    memset(&s, 0, sizeof s);
    s.data = malloc(n * type_size(t));
    for (k = 0; k < dims[2]; k++)
        for (j = 0; j < dims[1]; j++)
            for (i = 0; i < dims[0]; i++) {
                double x[3], d, stored;
                voxel_to_world(affine, (double)i, (double)j, (double)k, x);
                d = radius - sqrt((x[0] - centre[0]) * (x[0] - centre[0]) + (x[1] - centre[1]) * (x[1] - centre[1]) +
                                  (x[2] - centre[2]) * (x[2] - centre[2]));
                stored = (d - offset) / scale;
                if (t != SQFFD_VOXEL_F32 && t != SQFFD_VOXEL_F64) stored = stored < lo ? lo : stored > hi ? hi : stored;
                store(s.data, i + dims[0] * (j + dims[1] * k), t, stored);
            }
    s.v.data = s.data;
    s.v.type = t;
    memcpy(s.v.dims, dims, sizeof s.v.dims);
    s.v.strides[0] = (ptrdiff_t)type_size(t);
    s.v.strides[1] = (ptrdiff_t)(type_size(t) * dims[0]);
    s.v.strides[2] = (ptrdiff_t)(type_size(t) * dims[0] * dims[1]);
    memcpy(s.v.affine, affine, sizeof s.v.affine);
    s.v.scale = scale == 1.0 ? 0.0 : scale; /* 0: no scaling */
    s.v.offset = offset;
    return s;
}

static sqffd_result iso(const sqffd_volume *v, const sqffd_iso_options *o, double **points, double **normals, size_t *count)
{
    size_t size, n = 0;
    void *work;
    sqffd_result r = sqffd_iso_workspace_size(v, o, &size);
    *points = *normals = NULL;
    *count = 0;
    if (r != SQFFD_OK) return r;
    work = malloc(size ? size : 1);
    r = sqffd_iso_points(v, o, NULL, NULL, 0, &n, work, size);
    if (r == SQFFD_OK) {
        *points = (double *)malloc(3 * n * sizeof(double) + 1);
        *normals = (double *)malloc(3 * n * sizeof(double) + 1);
        r = sqffd_iso_points(v, o, *points, *normals, n, count, work, size);
        CHECK(*count == n);
    }
    free(work);
    return r;
}

/* Every type: each point within 1% of its edge's voxel spacing of the true
   sphere, its normal pointing out of it along that edge; a count-only call,
   a short capacity (nothing written past it) and the full call agree. */
static void test_iso_sphere(void)
{
    static const sqffd_voxel_type types[] = {SQFFD_VOXEL_U8, SQFFD_VOXEL_I8, SQFFD_VOXEL_U16, SQFFD_VOXEL_I16,
                                             SQFFD_VOXEL_I32, SQFFD_VOXEL_F32, SQFFD_VOXEL_F64};
    size_t t;
    for (t = 0; t < sizeof types / sizeof types[0]; t++) {
        int small = types[t] == SQFFD_VOXEL_U8 || types[t] == SQFFD_VOXEL_I8;
        /* 8-bit: 1 mm voxels, values (d + 1.28) / 0.01 (u8) or d / 0.01 (i8): edges near the surface are unclamped */
        double spacing[3], origin[3] = {-3.0, 5.0, 1.0}, affine[16], centre[3], radius = 40.0;
        double scale = small ? 0.01 : types[t] == SQFFD_VOXEL_U16 ? 0.001 : types[t] == SQFFD_VOXEL_I16 || types[t] == SQFFD_VOXEL_I32 ? 0.001 : 1.0;
        double offset = types[t] == SQFFD_VOXEL_U8 ? -1.28 : types[t] == SQFFD_VOXEL_U16 ? -30.0 : 0.0, worst = 0.0;
        size_t dims[3], n = 0, v, wrong_side = 0, grazing_wrong = 0, partial = 0, size;
        double *pts, *nrm, *part;
        sqffd_iso_options o = sqffd_iso_options_default();
        sphere_volume s;
        void *work;
        int a;
        if (small) { spacing[0] = spacing[1] = spacing[2] = 1.0; radius = 20.0; }
        else { spacing[0] = 1.0; spacing[1] = 1.5; spacing[2] = 2.0; }
        for (a = 0; a < 3; a++) dims[a] = (size_t)(2.0 * (radius + 6.0) / spacing[a]) + 1;
        make_affine(small ? 0.0 : 0.5, spacing, origin, affine);
        voxel_to_world(affine, 0.5 * (double)(dims[0] - 1) + 0.3, 0.5 * (double)(dims[1] - 1) - 0.2,
                       0.5 * (double)(dims[2] - 1) + 0.1, centre);
        s = make_sphere(types[t], dims, affine, centre, radius, scale, offset);
        CHECK_RESULT(iso(&s.v, &o, &pts, &nrm, &n), SQFFD_OK);
        CHECK_MSG(n > 1000, "type %d: %zu points", (int)types[t], n);
        for (v = 0; v < n; v++) {
            const double *p = pts + 3 * v, *q = nrm + 3 * v;
            double d[3], r, step = 0.0, along;
            for (a = 0; a < 3; a++) d[a] = p[a] - centre[a];
            r = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            for (a = 0; a < 3; a++) { /* the edge's axis: the voxel axis along the normal */
                along = fabs(q[0] * affine[a] + q[1] * affine[4 + a] + q[2] * affine[8 + a]) / spacing[a];
                if (along > 0.999) step = spacing[a];
            }
            if (step == 0.0) { CHECK_MSG(0, "type %d: point %zu's normal is along no voxel axis", (int)types[t], v); break; }
            if (fabs(r - radius) / step > worst) worst = fabs(r - radius) / step;
            if (q[0] * d[0] + q[1] * d[1] + q[2] * d[2] <= 0.0) wrong_side++; /* (only where an edge grazes the sphere) */
            if (q[0] * d[0] + q[1] * d[1] + q[2] * d[2] < -0.05 * r) grazing_wrong++;
        }
        printf("    type %d: %zu points, farthest %.4f of a voxel from the sphere; %zu normals inward, on grazing edges\n",
               (int)types[t], n, worst, wrong_side);
        CHECK_MSG(worst <= 0.01, "type %d: a point %.4f of a voxel off", (int)types[t], worst);
        CHECK(grazing_wrong == 0 && wrong_side * 200 < n);
        /* a short capacity: OUTPUT_TOO_SMALL, the count needed, not one point written; exactly
           the count: the same points */
        CHECK_RESULT(sqffd_iso_workspace_size(&s.v, &o, &size), SQFFD_OK);
        work = malloc(size);
        part = (double *)malloc((3 * n + 3) * sizeof(double));
        for (v = 0; v < 3 * n + 3; v++) part[v] = 12345.0;
        CHECK_RESULT(sqffd_iso_points(&s.v, &o, part, NULL, n - 1, &partial, work, size), SQFFD_ERROR_OUTPUT_TOO_SMALL);
        CHECK(partial == n);
        for (v = 0; v < 3 * n + 3 && part[v] == 12345.0; v++) {}
        CHECK_MSG(v == 3 * n + 3, "a buffer too small was written at %zu", v);
        CHECK_RESULT(sqffd_iso_points(&s.v, &o, part, NULL, n, &partial, work, size), SQFFD_OK);
        CHECK(partial == n && memcmp(part, pts, 3 * n * sizeof(double)) == 0 && part[3 * n] == 12345.0);
        CHECK_RESULT(sqffd_iso_points(&s.v, &o, part, NULL, 100, &partial, work, size - 1), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
        free(part);
        free(work);
        free(pts);
        free(nrm);
        free(s.data);
    }
}

/* Halving the voxel size about quadruples the crossings (a surface). */
static void test_iso_counts_scale(void)
{
    double counts[2], origin[3] = {0, 0, 0}, affine[16], centre[3] = {20.5, 19.7, 20.2};
    int h;
    for (h = 0; h < 2; h++) {
        double spacing[3], *pts, *nrm;
        size_t dims[3], n;
        sqffd_iso_options o = sqffd_iso_options_default();
        sphere_volume s;
        spacing[0] = spacing[1] = spacing[2] = h ? 0.5 : 1.0;
        dims[0] = dims[1] = dims[2] = (size_t)(41.0 / spacing[0]) + 1;
        make_affine(0.0, spacing, origin, affine);
        s = make_sphere(SQFFD_VOXEL_F32, dims, affine, centre, 15.0, 1.0, 0.0);
        CHECK_RESULT(iso(&s.v, &o, &pts, &nrm, &n), SQFFD_OK);
        counts[h] = (double)n;
        free(pts);
        free(nrm);
        free(s.data);
    }
    printf("    crossings at 1 and 0.5 voxel: %.0f, %.0f (ratio %.3f)\n", counts[0], counts[1], counts[1] / counts[0]);
    CHECK(counts[1] / counts[0] > 3.8 && counts[1] / counts[0] < 4.2);
    /* the surface area in voxel faces: a sphere of 15 voxels has ~1.5 x 4 pi r^2 crossings (3 axes, |n_a| summed) */
    CHECK(counts[0] > 1.3 * 4.0 * pi * 225.0 && counts[0] < 1.7 * 4.0 * pi * 225.0);
}

/* Views: frame 1 of a 4-D block, and an axis flipped by a negative stride
   (with the affine flipped to match), give the same points as the plain volume. */
static int cmp_point(const void *a, const void *b)
{
    const double *x = (const double *)a, *y = (const double *)b;
    int k;
    for (k = 0; k < 3; k++) {
        double dx = floor(x[k] * 1e6 + 0.5), dy = floor(y[k] * 1e6 + 0.5);
        if (dx != dy) return dx < dy ? -1 : 1;
    }
    return 0;
}

static void test_iso_views(void)
{
    double spacing[3] = {1.0, 1.2, 0.8}, origin[3] = {1, 2, 3}, affine[16], centre[3], *pts, *nrm, *block;
    size_t dims[3] = {30, 26, 34}, n, i, voxels = 30 * 26 * 34;
    sqffd_iso_options o = sqffd_iso_options_default();
    sqffd_volume view;
    sphere_volume s;
    int r;
    make_affine(0.3, spacing, origin, affine);
    voxel_to_world(affine, 14.6, 12.2, 16.9, centre);
    s = make_sphere(SQFFD_VOXEL_F64, dims, affine, centre, 9.0, 1.0, 0.0);
    CHECK_RESULT(iso(&s.v, &o, &pts, &nrm, &n), SQFFD_OK);
    /* frame 1 of two */
    block = (double *)malloc(2 * voxels * sizeof(double));
    for (i = 0; i < voxels; i++) block[i] = -5.0;
    memcpy(block + voxels, s.data, voxels * sizeof(double));
    view = s.v;
    view.data = block + voxels;
    {
        double *q, *qn;
        size_t m;
        CHECK_RESULT(iso(&view, &o, &q, &qn, &m), SQFFD_OK);
        CHECK(m == n && memcmp(q, pts, 3 * n * sizeof(double)) == 0);
        free(q);
        free(qn);
    }
    /* i flipped: data at the last voxel of each row, stride negative, affine's i column negated and moved */
    view = s.v;
    view.data = (const double *)s.data + (dims[0] - 1);
    view.strides[0] = -(ptrdiff_t)sizeof(double);
    for (r = 0; r < 3; r++) {
        view.affine[4 * r + 3] += view.affine[4 * r] * (double)(dims[0] - 1);
        view.affine[4 * r] = -view.affine[4 * r];
    }
    {
        double *q, *qn;
        size_t m;
        CHECK_RESULT(iso(&view, &o, &q, &qn, &m), SQFFD_OK);
        CHECK(m == n);
        if (m == n) {
            qsort(q, m, 3 * sizeof(double), cmp_point);
            qsort(pts, n, 3 * sizeof(double), cmp_point);
            for (i = 0; i < 3 * n; i++)
                if (fabs(q[i] - pts[i]) > 1e-9) { CHECK_MSG(0, "flipped view: coordinate %zu differs", i); break; }
        }
        free(q);
        free(qn);
    }
    free(block);
    free(pts);
    free(nrm);
    free(s.data);
}

/* Two spheres apart: all crossings, or only the larger one's. */
static void test_iso_largest_component(void)
{
    double spacing[3] = {1, 1, 1}, origin[3] = {0, 0, 0}, affine[16], big_c[3] = {15.3, 15.1, 15.7}, small_c[3] = {40.2, 15.4, 15.1};
    size_t dims[3] = {50, 32, 32}, n_all, n_big, n_small, i, voxels = 50 * 32 * 32;
    double *pts, *nrm, *field;
    sqffd_iso_options o = sqffd_iso_options_default();
    sphere_volume big, small;
    make_affine(0.0, spacing, origin, affine);
    big = make_sphere(SQFFD_VOXEL_F32, dims, affine, big_c, 10.0, 1.0, 0.0);
    small = make_sphere(SQFFD_VOXEL_F32, dims, affine, small_c, 4.0, 1.0, 0.0);
    CHECK_RESULT(iso(&big.v, &o, &pts, &nrm, &n_big), SQFFD_OK);
    free(pts); free(nrm);
    CHECK_RESULT(iso(&small.v, &o, &pts, &nrm, &n_small), SQFFD_OK);
    free(pts); free(nrm);
    field = (double *)malloc(voxels * sizeof(double));
    for (i = 0; i < voxels; i++) { /* the union of both: the larger of the two signed distances */
        float a, b;
        memcpy(&a, (const char *)big.data + 4 * i, 4);
        memcpy(&b, (const char *)small.data + 4 * i, 4);
        field[i] = a > b ? a : b;
    }
    big.v.data = field;
    big.v.type = SQFFD_VOXEL_F64;
    big.v.strides[0] = 8; big.v.strides[1] = 8 * 50; big.v.strides[2] = 8 * 50 * 32;
    CHECK_RESULT(iso(&big.v, &o, &pts, &nrm, &n_all), SQFFD_OK);
    free(pts); free(nrm);
    CHECK(n_all == n_big + n_small);
    o.largest_component = 1;
    CHECK_RESULT(iso(&big.v, &o, &pts, &nrm, &n_all), SQFFD_OK);
    free(pts); free(nrm);
    CHECK_MSG(n_all == n_big, "largest component: %zu points, the big sphere alone %zu", n_all, n_big);
    free(field);
    free(big.data);
    free(small.data);
}

/* Two labels together (labelled 2): a ball labelled 3 in a shell labelled 2
   beside a block labelled 1 (ACDC's cavity, myocardium, right ventricle)
   gives exactly the points of the map with the ball relabelled 2 (the
   outer border, none between ball and shell), fewer than the shell's own
   border, more than the ball's; a label2 that is not finite is refused. */
static void test_iso_label_union(void)
{
    enum { N = 24 };
    static unsigned char map[N * N * N], merged[N * N * N];
    double spacing[3] = {1, 1, 1.5}, origin[3] = {-3, 2, 1}, affine[16], *pts, *nrm, *ref, *ref_n;
    size_t dims[3] = {N, N, N}, i, j, k, n_union, n_merged, n_ball, n_shell;
    sqffd_iso_options o = sqffd_iso_options_default();
    sphere_volume v;
    make_affine(0.3, spacing, origin, affine);
    for (k = 0; k < N; k++)
        for (j = 0; j < N; j++)
            for (i = 0; i < N; i++) {
                double r2 = (i - 11.2) * (i - 11.2) + (j - 11.7) * (j - 11.7) + (k - 11.4) * (k - 11.4);
                size_t at = i + N * (j + N * k);
                map[at] = r2 < 25.0 ? 3 : r2 < 64.0 ? 2 : i > 19 && j > 4 && j < 18 && k > 4 && k < 18 ? 1 : 0;
                merged[at] = map[at] == 3 ? 2 : map[at];
            }
    memset(&v, 0, sizeof v);
    v.v.data = map;
    v.v.type = SQFFD_VOXEL_U8;
    memcpy(v.v.dims, dims, sizeof dims);
    v.v.strides[0] = 1; v.v.strides[1] = N; v.v.strides[2] = N * N;
    memcpy(v.v.affine, affine, sizeof affine);
    o.labelled = 2;
    o.label = 3.0;
    o.label2 = 2.0;
    CHECK_RESULT(iso(&v.v, &o, &pts, &nrm, &n_union), SQFFD_OK);
    v.v.data = merged;
    o.labelled = 1;
    o.label = 2.0;
    CHECK_RESULT(iso(&v.v, &o, &ref, &ref_n, &n_merged), SQFFD_OK);
    CHECK_MSG(n_union == n_merged && n_union > 0, "%zu points, the merged map's %zu", n_union, n_merged);
    if (n_union == n_merged) {
        CHECK(memcmp(pts, ref, 3 * n_union * sizeof *pts) == 0);
        CHECK(memcmp(nrm, ref_n, 3 * n_union * sizeof *nrm) == 0);
    }
    free(pts); free(nrm); free(ref); free(ref_n);
    v.v.data = map;
    CHECK_RESULT(iso(&v.v, &o, &pts, &nrm, &n_shell), SQFFD_OK); /* the shell's inner and outer border */
    free(pts); free(nrm);
    o.label = 3.0;
    CHECK_RESULT(iso(&v.v, &o, &pts, &nrm, &n_ball), SQFFD_OK);
    free(pts); free(nrm);
    CHECK_MSG(n_ball < n_union && n_union < n_shell, "ball %zu, union %zu, shell %zu", n_ball, n_union, n_shell);
    o.labelled = 2;
    o.label2 = NAN;
    CHECK_RESULT(iso(&v.v, &o, &pts, &nrm, &n_union), SQFFD_ERROR_INVALID_ARGUMENT);
    free(pts); free(nrm);
}

/* Otsu: two classes of values (with noise) split between them; the range. */
static void test_volume_otsu(void)
{
    enum { NX = 40, NY = 30, NZ = 20 };
    static uint16_t data[NX * NY * NZ];
    sqffd_volume v;
    double threshold = 0.0, lo, hi;
    size_t i;
    unsigned state = 12345;
    memset(&v, 0, sizeof v);
    for (i = 0; i < NX * NY * NZ; i++) {
        double noise;
        state = state * 1103515245u + 12345u;
        noise = (double)((state >> 16) % 21) - 10.0;
        data[i] = (uint16_t)((i % NX < 12 ? 300.0 : 1000.0) + noise); /* 30% dark, 70% bright */
    }
    v.data = data;
    v.type = SQFFD_VOXEL_U16;
    v.dims[0] = NX; v.dims[1] = NY; v.dims[2] = NZ;
    v.strides[0] = 2; v.strides[1] = 2 * NX; v.strides[2] = 2 * NX * NY;
    v.affine[0] = v.affine[5] = v.affine[10] = v.affine[15] = 1.0;
    CHECK_RESULT(sqffd_volume_range(&v, &lo, &hi), SQFFD_OK);
    CHECK(lo == 290.0 && hi == 1010.0);
    CHECK_RESULT(sqffd_volume_otsu(&v, &threshold), SQFFD_OK);
    printf("    Otsu threshold between classes at 300 and 1000: %.1f\n", threshold);
    CHECK(threshold > 320.0 && threshold < 980.0);
    CHECK_NEAR(threshold, 650.0, 60.0); /* the middle of the flat optimum between the classes */
    v.scale = 2.0; v.offset = -100.0; /* scaled values: the threshold follows */
    CHECK_RESULT(sqffd_volume_otsu(&v, &lo), SQFFD_OK);
    CHECK_NEAR(lo, 2.0 * threshold - 100.0, 1e-6 * threshold);
    for (i = 0; i < NX * NY * NZ; i++) data[i] = 7; /* one value: no threshold */
    v.scale = 0.0; v.offset = 0.0;
    CHECK_RESULT(sqffd_volume_otsu(&v, &threshold), SQFFD_ERROR_DEGENERATE);
}

/* Bad views and arguments, and the subsample. */
static void test_volume_bad_input(void)
{
    float data[8] = {0, 1, 0, 1, 0, 1, 0, 1}, nan_data[8];
    double lo, hi, pts[3 * 8], out[9];
    sqffd_volume v, bad;
    size_t n = 99, i, size;
    char work[4096];
    memset(&v, 0, sizeof v);
    v.data = data;
    v.type = SQFFD_VOXEL_F32;
    v.dims[0] = v.dims[1] = v.dims[2] = 2;
    v.strides[0] = 4; v.strides[1] = 8; v.strides[2] = 16;
    v.affine[0] = v.affine[5] = v.affine[10] = v.affine[15] = 1.0;
    CHECK_RESULT(sqffd_iso_points(&v, NULL, pts, NULL, 8, &n, work, sizeof work), SQFFD_OK);
    CHECK(n == 0); /* level 0: every voxel is inside */
    {
        sqffd_iso_options o = sqffd_iso_options_default();
        o.level = 0.5; /* the four i-edges from 0 to 1 cross, at their middles */
        CHECK_RESULT(sqffd_iso_points(&v, &o, pts, NULL, 8, &n, work, sizeof work), SQFFD_OK);
        CHECK(n == 4 && pts[0] == 0.5 && pts[1] == 0.0 && pts[2] == 0.0 && pts[3] == 0.5 && pts[4] == 1.0);
    }
    bad = v; bad.data = NULL;
    CHECK_RESULT(sqffd_volume_range(&bad, &lo, &hi), SQFFD_ERROR_INVALID_ARGUMENT);
    bad = v; bad.dims[1] = 0;
    CHECK_RESULT(sqffd_volume_range(&bad, &lo, &hi), SQFFD_ERROR_INVALID_ARGUMENT);
    bad = v; bad.strides[2] = 0;
    CHECK_RESULT(sqffd_iso_points(&bad, NULL, pts, NULL, 8, &n, work, sizeof work), SQFFD_ERROR_INVALID_ARGUMENT);
    bad = v; bad.type = (sqffd_voxel_type)99;
    CHECK_RESULT(sqffd_volume_otsu(&bad, &lo), SQFFD_ERROR_INVALID_ARGUMENT);
    bad = v; bad.affine[3] = NAN;
    CHECK_RESULT(sqffd_iso_points(&bad, NULL, pts, NULL, 8, &n, work, sizeof work), SQFFD_ERROR_NON_FINITE);
    bad = v; bad.affine[1] = 1e300; bad.affine[3] = 1e299; /* finite, but the world coordinates would overflow (fuzz_iso) */
    CHECK_RESULT(sqffd_iso_points(&bad, NULL, pts, NULL, 8, &n, work, sizeof work), SQFFD_ERROR_NON_FINITE);
    bad.affine[1] = 9e299 - 1e299; /* 8e299 + 1e299 = 9e299: within the bound */
    CHECK_RESULT(sqffd_iso_points(&bad, NULL, pts, NULL, 8, &n, work, sizeof work), SQFFD_OK);
    bad = v; bad.dims[0] = bad.dims[1] = bad.dims[2] = (size_t)1 << 31;
    CHECK_RESULT(sqffd_volume_range(&bad, &lo, &hi), SQFFD_ERROR_TOO_LARGE);
    size = 1;
    CHECK_RESULT(sqffd_iso_workspace_size(&bad, NULL, &size), SQFFD_ERROR_TOO_LARGE);
    CHECK(size == 0);
    bad = v; bad.dims[0] = (size_t)1 << 20; bad.dims[1] = (size_t)1 << 12; bad.dims[2] = 2; /* 2^33 voxels: no components */
    {
        sqffd_iso_options o = sqffd_iso_options_default();
        o.largest_component = 1;
        size = 1;
        CHECK_RESULT(sqffd_iso_workspace_size(&bad, &o, &size), SQFFD_ERROR_TOO_LARGE);
        CHECK(size == 0);
    }
    CHECK_RESULT(sqffd_iso_points(&v, NULL, pts, NULL, 8, NULL, work, sizeof work), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_iso_points(&v, NULL, NULL, NULL, 8, &n, work, sizeof work), SQFFD_ERROR_INVALID_ARGUMENT);
    for (i = 0; i < 8; i++) nan_data[i] = NAN;
    bad = v; bad.data = nan_data;
    CHECK_RESULT(sqffd_volume_range(&bad, &lo, &hi), SQFFD_ERROR_DEGENERATE);
    CHECK_RESULT(sqffd_iso_points(&bad, NULL, pts, NULL, 8, &n, work, sizeof work), SQFFD_OK);
    CHECK(n == 0);
    for (i = 0; i < 24; i++) pts[i] = (double)i;
    CHECK_RESULT(sqffd_points_subsample(pts, 8, 3, out), SQFFD_OK);
    CHECK(out[0] == 0.0 && out[3] == pts[3 * 2] && out[6] == pts[3 * 5]); /* points 0, 2, 5 of 8 */
    CHECK_RESULT(sqffd_points_subsample(pts, 2, 3, out), SQFFD_ERROR_INVALID_ARGUMENT); /* k > n */
    CHECK_RESULT(sqffd_points_subsample(NULL, 8, 3, out), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_points_subsample(pts, 8, 3, NULL), SQFFD_ERROR_INVALID_ARGUMENT);
}

void suite_volume(void)
{
    RUN_TEST(test_iso_sphere);
    RUN_TEST(test_iso_counts_scale);
    RUN_TEST(test_iso_views);
    RUN_TEST(test_iso_largest_component);
    RUN_TEST(test_iso_label_union);
    RUN_TEST(test_volume_otsu);
    RUN_TEST(test_volume_bad_input);
}

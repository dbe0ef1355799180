/* kd-tree: every query against brute force (distances, not indices, since
   ties may pick different points), tree invariants, error codes, workspace
   bounds and determinism. */
#include "test.h"
#include <stdlib.h>
#include <string.h>

/* ---- helpers ------------------------------------------------------------- */

static unsigned long long kd_rng_state;

static double kd_uniform(void) /* [0, 1) */
{
    kd_rng_state = kd_rng_state * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(kd_rng_state >> 11) * (1.0 / 9007199254740992.0);
}

static double kd_dist2(const double *a, const double *b)
{
    double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}

static int kd_cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static int kd_cmp_size(const void *a, const void *b)
{
    size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return (x > y) - (x < y);
}

/* A built tree with its own workspace. */
typedef struct kd_fixture {
    sqffd_kdtree tree;
    void *workspace;
} kd_fixture;

static int kd_build(kd_fixture *f, const double *points, size_t n)
{
    size_t size;
    sqffd_result r = sqffd_kdtree_workspace_size(n, &size);
    f->workspace = NULL;
    CHECK_RESULT(r, SQFFD_OK);
    if (r != SQFFD_OK) return 0;
    f->workspace = malloc(size);
    r = sqffd_kdtree_build(&f->tree, points, n, f->workspace, size);
    CHECK_RESULT(r, SQFFD_OK);
    return r == SQFFD_OK;
}

/* Walks the tree checking its invariants: leaves partition index[] in order,
   every point lies on its side of each gap (after a refit a gap may be an
   overlap), depth bound, leaf sizes (5..10, or identical points, or a lone
   root leaf), and index[] is a permutation. */
static void kd_check_node(const sqffd_kdtree *t, uint32_t node, unsigned depth, size_t *next_begin,
                          double lo[3], double hi[3], unsigned *max_depth, int refitted)
{
    const sqffd_kdtree_node *nd = &t->nodes[node];
    CHECK(node < t->node_count);
    if (depth > *max_depth) *max_depth = depth;
    if (nd->axis == SQFFD_KDTREE_LEAF) {
        size_t i, count = nd->u.leaf.end - nd->u.leaf.begin;
        const double *first = (const double *)t->points.xyz + 3 * (size_t)t->index[nd->u.leaf.begin];
        int identical = 1;
        CHECK(nd->u.leaf.begin == *next_begin);
        CHECK(nd->u.leaf.end > nd->u.leaf.begin);
        *next_begin = nd->u.leaf.end;
        for (i = nd->u.leaf.begin; i < nd->u.leaf.end; i++) {
            const double *p = (const double *)t->points.xyz + 3 * (size_t)t->index[i];
            int d;
            for (d = 0; d < 3; d++) CHECK(p[d] >= lo[d] && p[d] <= hi[d]);
            if (memcmp(p, first, 3 * sizeof(double)) != 0) identical = 0;
        }
        CHECK_MSG(identical || count <= 10, "leaf of %zu distinct points", count);
        CHECK_MSG(node == 0 || identical || refitted || count >= 5, "leaf of %zu points", count);
        return;
    }
    CHECK(depth < SQFFD_KDTREE_MAX_DEPTH);
    CHECK(nd->axis < 3);
    CHECK(refitted || nd->u.split.low <= nd->u.split.high);
    if (nd->axis >= 3 || depth >= SQFFD_KDTREE_MAX_DEPTH) return;
    {
        double l_hi[3], h_lo[3];
        memcpy(l_hi, hi, sizeof l_hi);
        memcpy(h_lo, lo, sizeof h_lo);
        if (nd->u.split.low < l_hi[nd->axis]) l_hi[nd->axis] = nd->u.split.low;
        if (nd->u.split.high > h_lo[nd->axis]) h_lo[nd->axis] = nd->u.split.high;
        kd_check_node(t, node + 1, depth + 1, next_begin, lo, l_hi, max_depth, refitted);
        kd_check_node(t, nd->high_child, depth + 1, next_begin, h_lo, hi, max_depth, refitted);
    }
}

static unsigned kd_check_tree(const sqffd_kdtree *t, int refitted)
{
    size_t next_begin = 0, i, n = t->count;
    unsigned max_depth = 0;
    unsigned char *seen = (unsigned char *)calloc(n, 1);
    double lo[3], hi[3];
    memcpy(lo, t->bbox[0], sizeof lo);
    memcpy(hi, t->bbox[1], sizeof hi);
    kd_check_node(t, 0, 0, &next_begin, lo, hi, &max_depth, refitted);
    CHECK(next_begin == n);
    for (i = 0; i < n; i++) {
        CHECK(t->index[i] < n);
        if (t->index[i] < n) seen[t->index[i]]++;
    }
    for (i = 0; i < n; i++) CHECK(seen[i] == 1);
    CHECK(t->node_count <= (n <= 10 ? 1 : 2 * (n / 5) - 1));
    free(seen);
    return max_depth;
}

/* All queries for one query point against its sorted brute-force distances. */
static void kd_check_query(const sqffd_kdtree *t, const double *points, size_t n, const double q[3],
                           double *sorted, size_t *idx, double *d2, size_t *brute_idx)
{
    static const size_t ks[4] = {1, 8, 64, 100000};
    size_t i, j, got, expect, nearest;
    double nd2 = NAN, r, r2;

    for (i = 0; i < n; i++) sorted[i] = kd_dist2(points + 3 * i, q);
    qsort(sorted, n, sizeof *sorted, kd_cmp_double);

    /* nearest */
    nearest = n;
    CHECK_RESULT(sqffd_kdtree_nearest(t, q, &nearest, &nd2), SQFFD_OK);
    CHECK(nearest < n);
    if (nearest < n) CHECK(nd2 == kd_dist2(points + 3 * nearest, q));
    CHECK_NEAR(nd2, sorted[0], 1e-12 * (1.0 + sorted[0]));

    /* k nearest: sorted, distinct, true distances, matching brute force */
    for (j = 0; j < 4; j++) {
        size_t k = ks[j], m = k < n ? k : n;
        got = (size_t)-1;
        CHECK_RESULT(sqffd_kdtree_knn(t, q, k, idx, d2, &got), SQFFD_OK);
        CHECK_MSG(got == m, "knn k=%zu returned %zu, expected %zu", k, got, m);
        if (got != m) continue;
        for (i = 0; i < m; i++) {
            CHECK(idx[i] < n);
            if (idx[i] >= n) return;
            CHECK(d2[i] == kd_dist2(points + 3 * idx[i], q));
            CHECK_NEAR(d2[i], sorted[i], 1e-12 * (1.0 + sorted[i]));
            if (i) CHECK(d2[i] >= d2[i - 1]);
        }
        memcpy(brute_idx, idx, m * sizeof *idx);
        qsort(brute_idx, m, sizeof *brute_idx, kd_cmp_size);
        for (i = 1; i < m; i++) CHECK(brute_idx[i] != brute_idx[i - 1]);
    }

    /* radius through the 8th nearest point (a point exactly on the sphere) */
    r = sqrt(sorted[n > 8 ? 7 : n - 1]);
    r2 = r * r;
    expect = 0;
    for (i = 0; i < n; i++)
        if (kd_dist2(points + 3 * i, q) <= r2) brute_idx[expect++] = i;
    got = (size_t)-1;
    CHECK_RESULT(sqffd_kdtree_radius(t, q, r, NULL, NULL, 0, &got), SQFFD_OK);
    CHECK_MSG(got == expect, "radius count %zu, brute force %zu", got, expect);
    got = (size_t)-1;
    CHECK_RESULT(sqffd_kdtree_radius(t, q, r, idx, d2, n, &got), SQFFD_OK);
    CHECK(got == expect);
    if (got == expect) {
        for (i = 0; i < got; i++) {
            CHECK(d2[i] == kd_dist2(points + 3 * idx[i], q));
            if (i) CHECK(d2[i] >= d2[i - 1]);
        }
        qsort(idx, got, sizeof *idx, kd_cmp_size);
        for (i = 0; i < got; i++) CHECK(idx[i] == brute_idx[i]);
    }
    /* capacity smaller than the count: OUTPUT_TOO_SMALL, the count needed, nothing written;
       exactly the count: all, the nearest first */
    if (expect > 1) {
        got = (size_t)-1;
        for (i = 0; i < expect; i++) idx[i] = (size_t)-1, d2[i] = -1.0;
        CHECK_RESULT(sqffd_kdtree_radius(t, q, r, idx, d2, expect - 1, &got), SQFFD_ERROR_OUTPUT_TOO_SMALL);
        CHECK(got == expect);
        for (i = 0; i < expect; i++) CHECK(idx[i] == (size_t)-1 && d2[i] == -1.0);
    }
    got = (size_t)-1;
    CHECK_RESULT(sqffd_kdtree_radius(t, q, r, idx, d2, expect, &got), SQFFD_OK);
    CHECK(got == expect);
    for (i = 0; i < expect; i++) CHECK_NEAR(d2[i], sorted[i], 1e-12 * (1.0 + sorted[i]));
}

/* Builds a tree over points and runs `queries` queries near them. */
static void kd_check_set(const double *points, size_t n, size_t queries, double noise)
{
    kd_fixture f;
    double *sorted = (double *)malloc(n * sizeof(double));
    double *d2 = (double *)malloc((n + 100000) * sizeof(double));
    size_t *idx = (size_t *)malloc((n + 100000) * sizeof(size_t));
    size_t *brute_idx = (size_t *)malloc((n + 100000) * sizeof(size_t));
    size_t qi;
    if (kd_build(&f, points, n)) {
        CHECK(kd_check_tree(&f.tree, 0) <= SQFFD_KDTREE_MAX_DEPTH);
        for (qi = 0; qi < queries; qi++) {
            const double *p = points + 3 * (size_t)(kd_uniform() * (double)n);
            double q[3];
            int d;
            for (d = 0; d < 3; d++) /* every 4th query exactly on a data point */
                q[d] = p[d] + (qi % 4 == 0 ? 0.0 : noise * (2.0 * kd_uniform() - 1.0));
            kd_check_query(&f.tree, points, n, q, sorted, idx, d2, brute_idx);
        }
    }
    free(f.workspace);
    free(sorted);
    free(d2);
    free(idx);
    free(brute_idx);
}

static double *kd_uniform_cube(size_t n, double side, double offset)
{
    double *p = (double *)malloc(3 * n * sizeof(double));
    size_t i;
    for (i = 0; i < 3 * n; i++) p[i] = offset + side * kd_uniform();
    return p;
}

static double *kd_sphere(size_t n)
{
    double *p = (double *)malloc(3 * n * sizeof(double));
    size_t i;
    for (i = 0; i < n; i++) {
        double v[3], len2;
        do {
            v[0] = 2 * kd_uniform() - 1; v[1] = 2 * kd_uniform() - 1; v[2] = 2 * kd_uniform() - 1;
            len2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        } while (len2 > 1.0 || len2 < 1e-6);
        p[3 * i] = v[0] / sqrt(len2); p[3 * i + 1] = v[1] / sqrt(len2); p[3 * i + 2] = v[2] / sqrt(len2);
    }
    return p;
}

/* ---- cases --------------------------------------------------------------- */

static void test_kdtree_uniform_cube(void)
{
    double *p;
    kd_rng_state = 1;
    p = kd_uniform_cube(2000, 1.0, 0.0);
    kd_check_set(p, 2000, 250, 0.05);
    free(p);
}

static void test_kdtree_sphere_surface(void)
{
    double *p;
    kd_rng_state = 2;
    p = kd_sphere(2000);
    kd_check_set(p, 2000, 250, 0.3);
    free(p);
}

static void test_kdtree_heavy_duplicates(void)
{
    /* 1500 points on 12 distinct positions, plus 500 on a 2x2x2 lattice */
    double *base, *p = (double *)malloc(3 * 2000 * sizeof(double));
    size_t i;
    kd_rng_state = 3;
    base = kd_uniform_cube(12, 1.0, 0.0);
    for (i = 0; i < 1500; i++) memcpy(p + 3 * i, base + 3 * (size_t)(kd_uniform() * 12), 3 * sizeof(double));
    for (i = 1500; i < 2000; i++) {
        p[3 * i] = (double)(i % 2); p[3 * i + 1] = (double)((i / 2) % 2); p[3 * i + 2] = (double)((i / 4) % 2);
    }
    kd_check_set(p, 2000, 250, 0.2);
    free(base);
    free(p);
}

static void test_kdtree_all_identical(void)
{
    double *p = (double *)malloc(3 * 1000 * sizeof(double));
    size_t i;
    kd_fixture f;
    for (i = 0; i < 1000; i++) { p[3 * i] = 1.5; p[3 * i + 1] = -2.0; p[3 * i + 2] = 1e-3; }
    kd_rng_state = 4;
    kd_check_set(p, 1000, 300, 1.0);
    if (kd_build(&f, p, 1000)) CHECK(f.tree.node_count == 1); /* one leaf, whatever its size */
    free(f.workspace);
    free(p);
}

static void test_kdtree_one_point(void)
{
    double p[3] = {3.0, -1.0, 2.0};
    kd_rng_state = 5;
    kd_check_set(p, 1, 300, 5.0);
}

static void test_kdtree_small_sets(void)
{
    size_t n;
    kd_rng_state = 6;
    for (n = 2; n <= 40; n += 3) {
        double *p = kd_uniform_cube(n, 1.0, 0.0);
        kd_check_set(p, n, 20, 0.3);
        free(p);
    }
}

static void test_kdtree_huge_coordinates(void)
{
    /* clusters ~1e8 apart around 1e12, and points spread over 1e9 */
    double *p = (double *)malloc(3 * 2000 * sizeof(double));
    size_t i;
    int d;
    kd_rng_state = 7;
    for (i = 0; i < 1000; i++)
        for (d = 0; d < 3; d++)
            p[3 * i + (size_t)d] = 1e12 + 1e8 * (double)(size_t)(kd_uniform() * 8) + 10.0 * kd_uniform();
    kd_check_set(p, 1000, 300, 30.0);
    for (i = 0; i < 3 * 2000; i++) p[i] = -5e8 + 1e9 * kd_uniform();
    kd_check_set(p, 2000, 300, 1e7);
    free(p);
}

static void test_kdtree_exponential_spacing(void)
{
    /* Midpoint cuts peel a few points off per level here; the median fallback
       must keep the depth within SQFFD_KDTREE_MAX_DEPTH. */
    size_t n = 3000, i;
    double *p = (double *)malloc(3 * n * sizeof(double));
    kd_fixture f;
    for (i = 0; i < n; i++) {
        p[3 * i] = pow(1.02, (double)i);
        p[3 * i + 1] = 1e-3 * (double)(i % 7);
        p[3 * i + 2] = 0.0;
    }
    if (kd_build(&f, p, n)) {
        unsigned depth = kd_check_tree(&f.tree, 0);
        CHECK_MSG(depth <= SQFFD_KDTREE_MAX_DEPTH, "depth %u", depth);
    }
    free(f.workspace);
    kd_rng_state = 8;
    kd_check_set(p, n, 300, 0.01);
    free(p);
}

/* A refit follows moves of every size, from rounding-level to points
   crossing the whole set: invariants and every query against brute force on
   the moved points; a refit back to the original points gives the built
   tree to the bit. */
static void test_kdtree_refit(void)
{
    static const double moves[5] = {1e-12, 1e-3, 0.05, 0.5, 3.0};
    size_t n = 2000, i, m, queries;
    double *p, *moved = (double *)malloc(3 * n * sizeof(double)), *sorted = (double *)malloc(n * sizeof(double));
    double *d2 = (double *)malloc((n + 100000) * sizeof(double));
    size_t *idx = (size_t *)malloc((n + 100000) * sizeof(size_t)), *brute = (size_t *)malloc((n + 100000) * sizeof(size_t));
    sqffd_kdtree_node *built = (sqffd_kdtree_node *)malloc(n * sizeof(sqffd_kdtree_node));
    double box[2][3];
    kd_fixture f;
    kd_rng_state = 12;
    p = kd_sphere(n);
    if (kd_build(&f, p, n)) {
        memcpy(built, f.tree.nodes, f.tree.node_count * sizeof *built);
        memcpy(box, f.tree.bbox, sizeof box);
        for (m = 0; m < 5; m++) {
            for (i = 0; i < 3 * n; i++) moved[i] = p[i] + moves[m] * (2.0 * kd_uniform() - 1.0);
            CHECK_RESULT(sqffd_kdtree_refit(&f.tree, moved), SQFFD_OK);
            CHECK(f.tree.points.xyz == moved);
            kd_check_tree(&f.tree, 1);
            for (queries = 0; queries < 60; queries++) {
                double q[3];
                const double *at = moved + 3 * (size_t)(kd_uniform() * (double)n);
                q[0] = at[0] + 0.1 * kd_uniform(); q[1] = at[1]; q[2] = at[2] - 0.1 * kd_uniform();
                kd_check_query(&f.tree, moved, n, q, sorted, idx, d2, brute);
            }
        }
        CHECK_RESULT(sqffd_kdtree_refit(&f.tree, p), SQFFD_OK);
        CHECK(memcmp(built, f.tree.nodes, f.tree.node_count * sizeof *built) == 0);
        CHECK(memcmp(box, f.tree.bbox, sizeof box) == 0);
    }
    free(f.workspace);
    free(p); free(moved); free(sorted); free(d2); free(idx); free(brute); free(built);
}

/* Refit errors leave the tree as it was. */
static void test_kdtree_refit_errors(void)
{
    size_t n = 1000, i, nearest;
    double *p = (double *)malloc(3 * n * sizeof(double)), *moved = (double *)malloc(3 * n * sizeof(double));
    double q[3] = {0.2, 0.1, 0.3}, d_before = NAN, d_after = NAN;
    sqffd_kdtree zero;
    kd_fixture f;
    memset(&zero, 0, sizeof zero);
    kd_rng_state = 13;
    for (i = 0; i < 3 * n; i++) p[i] = kd_uniform();
    CHECK_RESULT(sqffd_kdtree_refit(NULL, p), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_kdtree_refit(&zero, p), SQFFD_ERROR_INVALID_ARGUMENT);
    if (kd_build(&f, p, n)) {
        CHECK_RESULT(sqffd_kdtree_refit(&f.tree, NULL), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_kdtree_nearest(&f.tree, q, &nearest, &d_before), SQFFD_OK);
        memcpy(moved, p, 3 * n * sizeof(double));
        for (i = 0; i < 3 * n; i++) moved[i] += 0.01;
        moved[3 * 700 + 1] = NAN;
        CHECK_RESULT(sqffd_kdtree_refit(&f.tree, moved), SQFFD_ERROR_NON_FINITE);
        moved[3 * 700 + 1] = INFINITY;
        CHECK_RESULT(sqffd_kdtree_refit(&f.tree, moved), SQFFD_ERROR_NON_FINITE);
        CHECK(f.tree.points.xyz == p);
        CHECK_RESULT(sqffd_kdtree_nearest(&f.tree, q, &nearest, &d_after), SQFFD_OK);
        CHECK(d_after == d_before);
    }
    free(f.workspace);
    /* a pile of identical points is one leaf; it cannot follow them apart */
    for (i = 0; i < n; i++) { p[3 * i] = 1.0; p[3 * i + 1] = 2.0; p[3 * i + 2] = 3.0; }
    if (kd_build(&f, p, n)) {
        memcpy(moved, p, 3 * n * sizeof(double));
        CHECK_RESULT(sqffd_kdtree_refit(&f.tree, moved), SQFFD_OK);
        for (i = 0; i < 3 * n; i++) moved[i] += 1.0; /* still identical */
        CHECK_RESULT(sqffd_kdtree_refit(&f.tree, moved), SQFFD_OK);
        nearest = n;
        CHECK_RESULT(sqffd_kdtree_nearest(&f.tree, q, &nearest, &d_after), SQFFD_OK);
        CHECK(nearest < n && d_after == kd_dist2(moved, q));
        moved[3 * 10] += 1e-9;
        CHECK_RESULT(sqffd_kdtree_refit(&f.tree, moved), SQFFD_ERROR_DEGENERATE);
    }
    free(f.workspace);
    free(p); free(moved);
}

static void test_kdtree_errors(void)
{
    double p[3 * 20];
    size_t i, size = 0, bad_size = 1;
    sqffd_kdtree tree;
    void *ws;
    CHECK_RESULT(sqffd_kdtree_workspace_size(20, &size), SQFFD_OK);
    ws = malloc(size);
    for (i = 0; i < 60; i++) p[i] = (double)i;
    CHECK_RESULT(sqffd_kdtree_workspace_size(0, &bad_size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK(bad_size == 0);
    CHECK_RESULT(sqffd_kdtree_workspace_size(20, NULL), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK(size > 0);
    CHECK_RESULT(sqffd_kdtree_build(&tree, p, 0, ws, size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_kdtree_build(NULL, p, 20, ws, size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_kdtree_build(&tree, NULL, 20, ws, size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_kdtree_build(&tree, p, 20, NULL, size), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
    if (sizeof(size_t) > 4) {
        size_t huge = (size_t)UINT32_MAX + 1;
        bad_size = 1;
        CHECK_RESULT(sqffd_kdtree_workspace_size(huge, &bad_size), SQFFD_ERROR_TOO_LARGE);
        CHECK(bad_size == 0);
        CHECK_RESULT(sqffd_kdtree_build(&tree, p, huge, ws, size), SQFFD_ERROR_TOO_LARGE);
    }
    p[37] = NAN;
    CHECK_RESULT(sqffd_kdtree_build(&tree, p, 20, ws, size), SQFFD_ERROR_NON_FINITE);
    CHECK(tree.count == 0 && tree.nodes == NULL);
    p[37] = -INFINITY;
    CHECK_RESULT(sqffd_kdtree_build(&tree, p, 20, ws, size), SQFFD_ERROR_NON_FINITE);
    p[37] = 37.0;
    CHECK_RESULT(sqffd_kdtree_build(&tree, p, 20, ws, size), SQFFD_OK);
    { /* query arguments: NULL pointers, a tree never built */
        double q[3] = {0.5, 1.0, 2.0}, d2[4]; /* 0.5 from point 0, far from the others */
        size_t index = 99, idx[4], found, count;
        sqffd_kdtree unbuilt;
        memset(&unbuilt, 0, sizeof unbuilt);
        CHECK_RESULT(sqffd_kdtree_nearest(NULL, q, &index, d2), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_kdtree_nearest(&tree, NULL, &index, d2), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_kdtree_nearest(&tree, q, NULL, d2), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_kdtree_nearest(&unbuilt, q, &index, d2), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_kdtree_nearest(&tree, q, &index, NULL), SQFFD_OK); /* dist2 may be NULL */
        CHECK(index == 0);                                                     /* p[0 .. 3) = (0, 1, 2) */
        CHECK_RESULT(sqffd_kdtree_knn(NULL, q, 4, idx, d2, &found), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_kdtree_knn(&tree, NULL, 4, idx, d2, &found), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_kdtree_knn(&tree, q, 4, idx, d2, NULL), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_kdtree_knn(&tree, q, 4, NULL, NULL, &found), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_kdtree_knn(&tree, q, 4, NULL, d2, &found), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_kdtree_knn(&tree, q, 4, idx, NULL, &found), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_kdtree_knn(&unbuilt, q, 4, idx, d2, &found), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_kdtree_radius(NULL, q, 1.0, idx, d2, 4, &count), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_kdtree_radius(&tree, NULL, 1.0, idx, d2, 4, &count), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_kdtree_radius(&tree, q, 1.0, idx, d2, 4, NULL), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_kdtree_radius(&tree, q, 1.0, NULL, NULL, 4, &count), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_kdtree_radius(&unbuilt, q, 1.0, idx, d2, 4, &count), SQFFD_ERROR_INVALID_ARGUMENT);
        count = 99;
        CHECK_RESULT(sqffd_kdtree_radius(&tree, q, 1.0, NULL, NULL, 0, &count), SQFFD_OK); /* capacity 0: counts */
        CHECK(count == 1);
    }
    free(ws);
}

static void test_kdtree_nonfinite_query(void)
{
    double *p, q[3] = {0.5, NAN, 0.5}, d2[8], dist = 0.25;
    size_t idx[8], index = 7, found, count;
    kd_fixture f;
    kd_rng_state = 9;
    p = kd_uniform_cube(500, 1.0, 0.0);
    if (kd_build(&f, p, 500)) {
        CHECK_RESULT(sqffd_kdtree_nearest(&f.tree, q, &index, &dist), SQFFD_ERROR_NON_FINITE);
        CHECK(index == 7 && dist == 0.25); /* untouched */
        found = 99;
        CHECK_RESULT(sqffd_kdtree_knn(&f.tree, q, 8, idx, d2, &found), SQFFD_ERROR_NON_FINITE);
        CHECK(found == 99); /* untouched on an error */
        CHECK_RESULT(sqffd_kdtree_radius(&f.tree, q, 1.0, idx, d2, 8, &count), SQFFD_ERROR_NON_FINITE);
        q[1] = INFINITY;
        CHECK_RESULT(sqffd_kdtree_nearest(&f.tree, q, &index, &dist), SQFFD_ERROR_NON_FINITE);
        CHECK(index == 7 && dist == 0.25);
        found = 99;
        CHECK_RESULT(sqffd_kdtree_knn(&f.tree, q, 8, idx, d2, &found), SQFFD_ERROR_NON_FINITE);
        CHECK(found == 99); /* untouched on an error */
        CHECK_RESULT(sqffd_kdtree_radius(&f.tree, q, 1.0, idx, d2, 8, &count), SQFFD_ERROR_NON_FINITE);
        q[1] = 0.5; /* bad radii and k */
        CHECK_RESULT(sqffd_kdtree_radius(&f.tree, q, -1.0, idx, d2, 8, &count), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_kdtree_radius(&f.tree, q, NAN, idx, d2, 8, &count), SQFFD_ERROR_INVALID_ARGUMENT);
        count = 0;
        CHECK_RESULT(sqffd_kdtree_radius(&f.tree, q, INFINITY, NULL, NULL, 0, &count), SQFFD_OK);
        CHECK(count == 500);
        found = 99;
        CHECK_RESULT(sqffd_kdtree_knn(&f.tree, q, 0, idx, d2, &found), SQFFD_OK);
        CHECK(found == 0);
        found = 99;
        CHECK_RESULT(sqffd_kdtree_knn(&f.tree, q, 0, NULL, NULL, &found), SQFFD_OK); /* k == 0: no arrays needed */
        CHECK(found == 0);
    }
    free(f.workspace);
    free(p);
}

static void test_kdtree_workspace_bounds(void)
{
    /* One byte short is refused without writing; every alignment works; the
       tree never writes past the size it was given. */
    size_t n = 3000, size = 0, i, shift, nearest;
    double *p, q[3] = {0.3, 0.6, 0.2}, d_ref, d = NAN;
    unsigned char *block;
    sqffd_kdtree tree;
    CHECK_RESULT(sqffd_kdtree_workspace_size(n, &size), SQFFD_OK);
    block = (unsigned char *)malloc(size + 64);
    kd_rng_state = 10;
    p = kd_uniform_cube(n, 1.0, 0.0);
    CHECK_MSG((double)size / (double)n <= 48.0, "%.1f bytes per point", (double)size / (double)n);
    memset(block, 0xA5, size + 64);
    CHECK_RESULT(sqffd_kdtree_build(&tree, p, n, block, size - 1), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
    for (i = 0; i < size + 64; i++)
        if (block[i] != 0xA5) { CHECK_MSG(0, "byte %zu written", i); break; }
    CHECK_RESULT(sqffd_kdtree_nearest(&tree, q, &nearest, &d), SQFFD_ERROR_INVALID_ARGUMENT); /* a zeroed tree */
    d_ref = 0.0;
    for (shift = 0; shift < 16; shift++) {
        memset(block, 0xA5, size + 64);
        CHECK_RESULT(sqffd_kdtree_build(&tree, p, n, block + shift, size), SQFFD_OK);
        for (i = shift + size; i < size + 64; i++)
            if (block[i] != 0xA5) { CHECK_MSG(0, "shift %zu: byte %zu past the end written", shift, i); break; }
        CHECK_RESULT(sqffd_kdtree_nearest(&tree, q, &nearest, &d), SQFFD_OK);
        if (shift == 0) d_ref = d;
        CHECK(d == d_ref);
        kd_check_tree(&tree, 0);
        if (shift + 1 < 16) /* the same block one byte further is one byte short */
            CHECK_RESULT(sqffd_kdtree_build(&tree, p, n, block + shift + 1, size - 1),
                         SQFFD_ERROR_WORKSPACE_TOO_SMALL);
    }
    free(block);
    free(p);
}

static void test_kdtree_deterministic(void)
{
    size_t n = 5000, i, idx_a[16], idx_b[16];
    double *p, d_a[16], d_b[16];
    kd_fixture a, b;
    int built;
    kd_rng_state = 11;
    p = kd_sphere(n);
    for (i = 0; i < 3 * 500; i++) p[3 * 1000 + i] = p[i]; /* some duplicates */
    built = kd_build(&a, p, n);
    built &= kd_build(&b, p, n);
    if (built) {
        CHECK(a.tree.node_count == b.tree.node_count);
        CHECK(memcmp(a.tree.index, b.tree.index, n * sizeof(uint32_t)) == 0);
        CHECK(memcmp(a.tree.nodes, b.tree.nodes, a.tree.node_count * sizeof(sqffd_kdtree_node)) == 0);
        for (i = 0; i < 200; i++) {
            double q[3];
            size_t found_a = 0, found_b = 0;
            q[0] = 2 * kd_uniform() - 1; q[1] = 2 * kd_uniform() - 1; q[2] = 2 * kd_uniform() - 1;
            CHECK_RESULT(sqffd_kdtree_knn(&a.tree, q, 16, idx_a, d_a, &found_a), SQFFD_OK);
            CHECK_RESULT(sqffd_kdtree_knn(&b.tree, q, 16, idx_b, d_b, &found_b), SQFFD_OK);
            CHECK(found_a == 16 && found_b == 16);
            CHECK(memcmp(idx_a, idx_b, sizeof idx_a) == 0 && memcmp(d_a, d_b, sizeof d_a) == 0);
        }
    }
    free(a.workspace);
    free(b.workspace);
    free(p);
}

void suite_kdtree(void)
{
    RUN_TEST(test_kdtree_uniform_cube);
    RUN_TEST(test_kdtree_sphere_surface);
    RUN_TEST(test_kdtree_heavy_duplicates);
    RUN_TEST(test_kdtree_all_identical);
    RUN_TEST(test_kdtree_one_point);
    RUN_TEST(test_kdtree_small_sets);
    RUN_TEST(test_kdtree_huge_coordinates);
    RUN_TEST(test_kdtree_exponential_spacing);
    RUN_TEST(test_kdtree_refit);
    RUN_TEST(test_kdtree_refit_errors);
    RUN_TEST(test_kdtree_errors);
    RUN_TEST(test_kdtree_nonfinite_query);
    RUN_TEST(test_kdtree_workspace_bounds);
    RUN_TEST(test_kdtree_deterministic);
}

/* libFuzzer target: bytes -> a point set and queries -> the kd-tree (layer 2):
   sqffd_kdtree_workspace_size / _build, then nearest, knn (k from the bytes,
   0 and beyond n included), radius (exact boundaries, 0, negative, NaN,
   infinite; every capacity) and a refit to moved points, every answer
   checked against brute force (distances, not indices: ties may pick any of
   the tied points), plus the tree's invariants (index a permutation, leaves
   in order, each point on its side of every gap, leaf sizes, depth, bbox),
   determinism and the error paths (workspace one byte short, NaN point,
   refit to NaN or to split identical points leaves the tree unchanged).

   Layout (bytes past the end read as 0):
     0  encoding: 0 raw little-endian doubles (NaN, Inf, denormals, 1e300, ...),
        1 small ints in -r..r (many duplicates), 2 int16 scaled by 2^-shift,
        3 a table of special values (0, -0, denormals, 1e300, DBL_MAX, NaN,
        Inf, ...), 4 a geometric sequence (deep trees: the median splits),
        5 a line of duplicated clusters
     1  encoding parameter (range, shift, ratio)
     2,3 point count - 1, little-endian, modulo MAX_POINTS
     4  query count - 1 (modulo 24)
     5  refit: bit 0-1 0 none, 1 the same points, 2 jittered, 3 a NaN point;
        bits 2-4 the jitter's scale; bit 5 refit the identical leaves apart
     6  flags: bits 0-3 workspace misalignment, bit 4 workspace one byte
        short first, bit 5 NULL workspace first, bit 6 the determinism
        check's second tree built over a point view (the same points in
        40-byte records at an odd address) instead of the array
     then the points (as many as the encoding consumes; when the bytes run
     out the rest repeat the decoded ones: duplicates), then per query a kind
     byte, a data point's number, the kind's payload, a k byte, a radius byte
     and a capacity byte. */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include "fuzz_reader.h"
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define MAX_POINTS 400 /* enough for trees deeper than the median-split switch */
#define MAX_QUERIES 24


static double special_value(unsigned b)
{
    static const double table[] = {0.0, -0.0, 1.0, -1.0, 0.5, 1e300, -1e300, 1e154, -1e154, 4.9406564584124654e-324,
                                   -4.9406564584124654e-324, 2.2250738585072014e-308, 1.7976931348623157e308,
                                   -1.7976931348623157e308, 1e-300, 3.0, 1.0 + 2.220446049250313e-16, 1e16, 1e16 + 2.0};
    unsigned count = (unsigned)(sizeof table / sizeof table[0]);
    if (b == 253) return NAN;
    if (b == 254) return -HUGE_VAL;
    if (b == 255) return HUGE_VAL;
    return table[b % count];
}

/* Squared distance in the library's order of operations (documented: squared
   Euclidean in double), so exact comparisons hold. */
static double dist2(const double *a, const double *b)
{
    double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static int finite3(const double *p) { return isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]); }

static size_t decode_points(reader *r, unsigned encoding, unsigned param, size_t n, double *points)
{
    size_t i, decoded = 0;
    int d;
    for (i = 0; i < n; i++) {
        double *p = points + 3 * i;
        if (rd_exhausted(r) && decoded > 0 && encoding != 4 && encoding != 5) {
            memcpy(p, points + 3 * (i % decoded), 3 * sizeof(double)); /* duplicates */
            continue;
        }
        for (d = 0; d < 3; d++) {
            switch (encoding) {
            case 0: p[d] = rd_f64(r); break;
            case 1: {
                int range = (int)(param % 8u); /* -range .. range */
                p[d] = (double)((int)(rd_u8(r) % (unsigned)(2 * range + 1)) - range);
                break;
            }
            case 2: p[d] = ldexp((double)rd_i16(r), -(int)(param % 64u)); break;
            case 3: p[d] = special_value(rd_u8(r)); break;
            case 4: /* x = ratio^i on one axis, the others tiny noise: midpoint cuts peel off few points */
                p[d] = d == 0 ? pow(1.25 + 0.25 * (double)(param % 12u), (double)i - 40.0)
                              : ldexp((double)(int8_t)rd_u8(r), -40);
                break;
            default: /* clusters of identical points along a line */
                p[d] = d == 0 ? (double)(i / (1u + param % 32u)) : 0.0;
                break;
            }
        }
        decoded++;
    }
    return decoded;
}

/* ---- tree invariants ---------------------------------------------------- */

typedef struct walk {
    const sqffd_kdtree *tree;
    size_t next_begin;
    int refitted;
} walk;

/* Checks the subtree at node (leaves in index order, leaf sizes, depth, each
   stored gap the children's tight bounds on the cut axis) and returns its
   tight box. */
static void check_node(walk *w, uint32_t node, unsigned depth, double box[2][3])
{
    const sqffd_kdtree *t = w->tree;
    const sqffd_kdtree_node *nd;
    int d;
    if (node >= t->node_count || depth > SQFFD_KDTREE_MAX_DEPTH) abort();
    nd = &t->nodes[node];
    for (d = 0; d < 3; d++) { box[0][d] = HUGE_VAL; box[1][d] = -HUGE_VAL; }
    if (nd->axis == SQFFD_KDTREE_LEAF) {
        size_t i, count = (size_t)nd->u.leaf.end - nd->u.leaf.begin;
        const double *first;
        int identical = 1;
        if (nd->u.leaf.begin != w->next_begin || nd->u.leaf.end <= nd->u.leaf.begin || nd->u.leaf.end > t->count)
            abort();
        w->next_begin = nd->u.leaf.end;
        first = (const double *)t->points.xyz + 3 * (size_t)t->index[nd->u.leaf.begin];
        for (i = nd->u.leaf.begin; i < nd->u.leaf.end; i++) {
            const double *p = (const double *)t->points.xyz + 3 * (size_t)t->index[i];
            for (d = 0; d < 3; d++) {
                if (p[d] < box[0][d]) box[0][d] = p[d];
                if (p[d] > box[1][d]) box[1][d] = p[d];
                if (p[d] != first[d]) identical = 0;
            }
        }
        if (count > 10 && !identical) abort();               /* big leaves hold identical points only */
        if (!w->refitted && node != 0 && count < 5 && !identical) abort(); /* children keep 5 points */
        return;
    }
    if (nd->axis > 2 || depth >= SQFFD_KDTREE_MAX_DEPTH) abort();
    {
        double low[2][3], high[2][3];
        uint32_t axis = nd->axis;
        if (nd->high_child <= node + 1) abort();
        check_node(w, node + 1, depth + 1, low);
        check_node(w, nd->high_child, depth + 1, high);
        /* the gap is the low child's largest and the high child's smallest coordinate */
        if (nd->u.split.low != low[1][axis] || nd->u.split.high != high[0][axis]) abort();
        if (!w->refitted && !(nd->u.split.low <= nd->u.split.high)) abort();
        for (d = 0; d < 3; d++) {
            box[0][d] = low[0][d] < high[0][d] ? low[0][d] : high[0][d];
            box[1][d] = low[1][d] > high[1][d] ? low[1][d] : high[1][d];
        }
    }
}

static void check_tree(const sqffd_kdtree *t, const double *points, size_t n, int refitted, unsigned char *seen)
{
    size_t i;
    double box[2][3];
    walk w;
    int d;
    if (t->points.xyz != points || t->count != n || !t->index || !t->nodes) abort();
    if (t->node_count < 1 || t->node_count > (n <= 10 ? 1 : 2 * (n / 5) - 1)) abort();
    memset(seen, 0, n);
    for (i = 0; i < n; i++) {
        if (t->index[i] >= n || seen[t->index[i]]) abort();
        seen[t->index[i]] = 1;
    }
    w.tree = t;
    w.next_begin = 0;
    w.refitted = refitted;
    check_node(&w, 0, 0, box);
    if (w.next_begin != n) abort();
    for (d = 0; d < 3; d++)
        if (t->bbox[0][d] != box[0][d] || t->bbox[1][d] != box[1][d]) abort();
}

/* ---- queries against brute force ---------------------------------------- */

typedef struct scratch {
    double *all;      /* n distances, in point order */
    double *sorted;   /* the same, ascending */
    size_t *indices;  /* room for MAX_POINTS + 8 */
    double *d2;
    unsigned char *seen;
} scratch;

/* The first `got` answers are the `got` smallest distances, each the
   distance of the point it names, indices distinct. */
static void check_answers(const scratch *s, size_t n, const size_t *indices, const double *d2, size_t got)
{
    size_t i;
    memset(s->seen, 0, n);
    for (i = 0; i < got; i++) {
        if (indices[i] >= n || s->seen[indices[i]]) abort();
        s->seen[indices[i]] = 1;
        if (d2[i] != s->all[indices[i]] || d2[i] != s->sorted[i]) abort();
    }
}

/* Every query refused with `expected`: NON_FINITE for a NaN or infinite
   query, INVALID_ARGUMENT on a tree that is not built; on an error the
   outputs are untouched (documented). */
static void check_nothing(const sqffd_kdtree *t, const double q[3], sqffd_result expected, scratch *s)
{
    double d = 0.25;
    size_t index = 7, found = 99, count = 99;
    if (sqffd_kdtree_nearest(t, q, &index, &d) != expected) abort();
    if (sqffd_kdtree_knn(t, q, 3, s->indices, s->d2, &found) != expected) abort();
    if (sqffd_kdtree_radius(t, q, HUGE_VAL, s->indices, s->d2, 3, &count) != expected) abort();
    if (sqffd_kdtree_radius(t, q, 1.0, NULL, NULL, 0, &count) != expected) abort();
    if (index != 7 || d != 0.25 || found != 99 || count != 99) abort();
}

/* One query point with its k, radius and capacity choices. */
static void check_query(const sqffd_kdtree *t, const double *points, size_t n, const double q[3], unsigned kb,
                        unsigned rb, unsigned cb, scratch *s)
{
    size_t i, k, got, count, cap, expect, again;
    double d, radius, reach;
    size_t *idx;
    double *dd;

    if (!finite3(q)) {
        check_nothing(t, q, SQFFD_ERROR_NON_FINITE, s);
        return;
    }
    for (i = 0; i < n; i++) s->all[i] = s->sorted[i] = dist2(points + 3 * i, q);
    qsort(s->sorted, n, sizeof(double), cmp_double);

    /* nearest */
    if (sqffd_kdtree_nearest(t, q, &i, &d) != SQFFD_OK) abort();
    if (i >= n || d != s->sorted[0] || s->all[i] != d) abort();
    if (sqffd_kdtree_nearest(t, q, &again, NULL) != SQFFD_OK || again != i) abort(); /* deterministic, dist2 optional */

    /* knn: k in 0 .. n + 7, exact-size arrays (the sanitizer sees a write past k) */
    k = kb < 200 ? kb % (n + 8) : kb < 240 ? n : kb < 250 ? n + 1 + (kb & 3) : (size_t)(kb & 7);
    idx = (size_t *)malloc((k ? k : 1) * sizeof(size_t));
    dd = (double *)malloc((k ? k : 1) * sizeof(double));
    if (!idx || !dd) abort();
    if (sqffd_kdtree_knn(t, q, k, idx, dd, &got) != SQFFD_OK) abort();
    if (got != (k < n ? k : n)) abort();
    check_answers(s, n, idx, dd, got);
    if (got && dd[0] != d) abort(); /* (the nearest may be another tied point) */
    if (k > 0) { /* NULL arrays are refused; k == 0 needs none */
        if (sqffd_kdtree_knn(t, q, k, NULL, dd, &got) != SQFFD_ERROR_INVALID_ARGUMENT ||
            sqffd_kdtree_knn(t, q, k, idx, NULL, &got) != SQFFD_ERROR_INVALID_ARGUMENT)
            abort();
    } else if (sqffd_kdtree_knn(t, q, 0, NULL, NULL, &got) != SQFFD_OK || got != 0) {
        abort();
    }
    free(idx);
    free(dd);

    /* radius: exactly a point's distance (the boundary is inclusive), next to
       it, 0, raw, huge, negative, NaN */
    {
        double base = sqrt(s->sorted[(size_t)rb % n]);
        switch (rb >> 5) {
        case 0: radius = base; break;
        case 1: radius = nextafter(base, HUGE_VAL); break;
        case 2: radius = nextafter(base, 0.0); break;
        case 3: radius = 0.0; break;
        case 4: radius = base * 2.0 + 1.0; break;
        case 5: radius = (rb & 1) ? HUGE_VAL : 1e200; break;
        case 6: radius = (rb & 1) ? -1.0 : -0.0; break;
        default: radius = (rb & 1) ? NAN : ldexp(1.0, (int)(rb & 31) - 16); break;
        }
    }
    if (!(radius >= 0.0)) {
        if (sqffd_kdtree_radius(t, q, radius, s->indices, s->d2, n, &count) != SQFFD_ERROR_INVALID_ARGUMENT) abort();
    } else {
        reach = radius * radius;
        expect = 0;
        for (i = 0; i < n; i++) expect += s->all[i] <= reach;
        cap = cb < 128 ? cb % (expect + 3) : cb < 192 ? expect : cb < 224 ? n : 0;
        if (cap > n + 2) cap = n + 2;
        idx = (size_t *)malloc((cap ? cap : 1) * sizeof(size_t));
        dd = (double *)malloc((cap ? cap : 1) * sizeof(double));
        if (!idx || !dd) abort();
        for (i = 0; i < cap; i++) idx[i] = (size_t)-1, dd[i] = -1.0;
        if (sqffd_kdtree_radius(t, q, radius, idx, dd, cap, &count) !=
                (cap && cap < expect ? SQFFD_ERROR_OUTPUT_TOO_SMALL : SQFFD_OK) ||
            count != expect)
            abort();
        if (cap && cap < expect) { /* too small: nothing written */
            for (i = 0; i < cap; i++)
                if (idx[i] != (size_t)-1 || dd[i] != -1.0) abort();
        } else {
            check_answers(s, n, idx, dd, cap ? count : 0);
        }
        if (sqffd_kdtree_radius(t, q, radius, NULL, NULL, 0, &count) != SQFFD_OK || count != expect) abort();
        if (sqffd_kdtree_radius(t, q, radius, NULL, NULL, 5, &count) != SQFFD_ERROR_INVALID_ARGUMENT) /* NULL arrays, capacity 5 */
            abort();
        free(idx);
        free(dd);
    }
}

/* Queries from the bytes: kind, payload, k, radius, capacity. */
static void run_queries(const sqffd_kdtree *t, const double *points, size_t n, reader *r, size_t count, scratch *s)
{
    size_t qi;
    for (qi = 0; qi < count; qi++) {
        unsigned kind = rd_u8(r);
        double q[3];
        const double *p = points + 3 * ((size_t)rd_u8(r) % n);
        int d;
        switch (kind % 6) {
        case 0: for (d = 0; d < 3; d++) q[d] = rd_f64(r); break;                  /* raw */
        case 1: memcpy(q, p, sizeof q); break;                                    /* a data point */
        case 2:                                                                   /* near one */
            for (d = 0; d < 3; d++) q[d] = p[d] + ldexp((double)(int8_t)rd_u8(r), -(int)(kind >> 3));
            break;
        case 3: for (d = 0; d < 3; d++) q[d] = special_value(rd_u8(r)); break;   /* NaN, Inf, 1e300, ... */
        case 4: for (d = 0; d < 3; d++) q[d] = (double)(int8_t)rd_u8(r); break;  /* small ints */
        default:                                                                  /* midway between two points */
            {
                const double *p2 = points + 3 * ((size_t)rd_u8(r) % n);
                for (d = 0; d < 3; d++) q[d] = 0.5 * p[d] + 0.5 * p2[d];
            }
            break;
        }
        {
            unsigned kb = rd_u8(r), rb = rd_u8(r), cb = rd_u8(r);
            check_query(t, points, n, q, kb, rb, cb, s);
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    reader r;
    unsigned encoding, param, refit, flags;
    size_t n, queries, ws_size, i, query_start;
    double *points = NULL, *moved = NULL;
    unsigned char *block = NULL, *block2 = NULL, *ws, *ws2;
    sqffd_kdtree tree, tree2, saved;
    sqffd_kdtree_node *saved_nodes = NULL;
    scratch s;
    sqffd_result res;
    int has_nonfinite = 0;

    if (size < 7) return 0;
    r.data = data;
    r.size = size;
    r.at = 0;
    encoding = rd_u8(&r) % 6u;
    param = rd_u8(&r);
    n = 1 + (size_t)(rd_u8(&r) | rd_u8(&r) << 8) % MAX_POINTS;
    queries = 1 + rd_u8(&r) % MAX_QUERIES;
    refit = rd_u8(&r);
    flags = rd_u8(&r);

    if (sqffd_kdtree_workspace_size(0, &ws_size) != SQFFD_ERROR_INVALID_ARGUMENT || ws_size != 0) abort();
    points = (double *)malloc(3 * n * sizeof(double));
    moved = (double *)malloc(3 * n * sizeof(double));
    s.all = (double *)malloc(n * sizeof(double));
    s.sorted = (double *)malloc(n * sizeof(double));
    s.indices = (size_t *)malloc((n + 8) * sizeof(size_t));
    s.d2 = (double *)malloc((n + 8) * sizeof(double));
    s.seen = (unsigned char *)malloc(n);
    if (!points || !moved || !s.all || !s.sorted || !s.indices || !s.d2 || !s.seen) abort();
    decode_points(&r, encoding, param, n, points);
    for (i = 0; i < n; i++) has_nonfinite |= !finite3(points + 3 * i);
    query_start = r.at;

    if (sqffd_kdtree_workspace_size(n, &ws_size) != SQFFD_OK || ws_size == 0) abort();
    block = (unsigned char *)malloc(ws_size + 15);
    block2 = (unsigned char *)malloc(ws_size);
    if (!block || !block2) abort();
    ws = block + (flags & 15);
    ws2 = block2;

    /* error paths first: a zeroed tree afterwards, and no query finds anything in it */
    if (flags & 32) {
        memset(&tree, 0xAB, sizeof tree);
        res = sqffd_kdtree_build(&tree, points, n, NULL, ws_size);
        /* (documented INVALID_ARGUMENT for a NULL workspace; the arena says WORKSPACE_TOO_SMALL) */
        if (res != SQFFD_ERROR_INVALID_ARGUMENT && res != SQFFD_ERROR_WORKSPACE_TOO_SMALL) abort();
        if (tree.count != 0 || tree.nodes != NULL || tree.index != NULL) abort();
    }
    if (flags & 16) {
        memset(&tree, 0xAB, sizeof tree);
        res = sqffd_kdtree_build(&tree, points, n, ws, ws_size - 1);
        if (res != SQFFD_ERROR_WORKSPACE_TOO_SMALL) abort();
        if (tree.count != 0 || tree.nodes != NULL || tree.points.xyz != NULL) abort();
        {
            double q[3] = {0.0, 0.0, 0.0};
            check_nothing(&tree, q, SQFFD_ERROR_INVALID_ARGUMENT, &s);
        }
        if (sqffd_kdtree_refit(&tree, points) != SQFFD_ERROR_INVALID_ARGUMENT) abort();
    }
    if (sqffd_kdtree_build(&tree, points, 0, ws, ws_size) != SQFFD_ERROR_INVALID_ARGUMENT) abort();
    if (sqffd_kdtree_build(&tree, NULL, n, ws, ws_size) != SQFFD_ERROR_INVALID_ARGUMENT) abort();

    res = sqffd_kdtree_build(&tree, points, n, ws, ws_size);
    if (has_nonfinite) {
        if (res != SQFFD_ERROR_NON_FINITE || tree.count != 0 || tree.nodes != NULL) abort();
        goto done;
    }
    if (res != SQFFD_OK) abort();
    check_tree(&tree, points, n, 0, s.seen);

    /* determinism: the same points give the same tree, byte for byte, read
       from the array or in place from records */
    if (flags & 64) {
        unsigned char *records = (unsigned char *)malloc(40 * n + 1);
        if (!records) goto done;
        memset(records, 0xC3, 40 * n + 1);
        for (i = 0; i < n; i++) memcpy(records + 1 + 40 * i, points + 3 * i, 3 * sizeof(double));
        res = sqffd_kdtree_build_view(&tree2, sqffd_points_strided(records + 1, n, 40, SQFFD_SCALAR_DOUBLE), ws2,
                                      ws_size);
        if (res == SQFFD_OK)
            for (i = 0; i < n && i < 16; i++) { /* and answers as the array's tree */
                size_t a = 0, b = 0;
                double da = 0.0, db = 0.0;
                if (sqffd_kdtree_nearest(&tree, points + 3 * i, &a, &da) != SQFFD_OK ||
                    sqffd_kdtree_nearest(&tree2, points + 3 * i, &b, &db) != SQFFD_OK || a != b || !(da == db))
                    abort();
            }
        free(records);
    } else {
        res = sqffd_kdtree_build(&tree2, points, n, ws2, ws_size);
    }
    if (res != SQFFD_OK) abort();
    if (tree2.node_count != tree.node_count || memcmp(tree2.index, tree.index, n * sizeof(uint32_t)) != 0 ||
        memcmp(tree2.nodes, tree.nodes, tree.node_count * sizeof(sqffd_kdtree_node)) != 0)
        abort();

    run_queries(&tree, points, n, &r, queries, &s);

    /* refit */
    if (refit & 3) {
        const double *target = points;
        int expect_nonfinite, split = 0;
        memcpy(moved, points, 3 * n * sizeof(double));
        if ((refit & 3) >= 2) {
            double scale = ldexp(1.0, 4 * (int)((refit >> 2) & 7) - 16);
            reader jr;
            jr.data = data;
            jr.size = size;
            jr.at = query_start;
            for (i = 0; i < 3 * n; i++) moved[i] += scale * ((double)rd_u8(&jr) / 128.0 - 1.0);
            if ((refit & 3) == 3) moved[3 * (param % n) + param % 3] = (param & 8) ? NAN : -HUGE_VAL;
            target = moved;
        }
        if (refit & 32) { /* move one point of every big identical leaf: DEGENERATE, tree unchanged */
            for (i = 0; i < tree.node_count; i++) {
                const sqffd_kdtree_node *nd = &tree.nodes[i];
                if (nd->axis == SQFFD_KDTREE_LEAF && nd->u.leaf.end - nd->u.leaf.begin > 10) {
                    size_t p = tree.index[nd->u.leaf.begin];
                    if (target != moved) { memcpy(moved, points, 3 * n * sizeof(double)); target = moved; }
                    moved[3 * p] = nextafter(moved[3 * p], moved[3 * p] > 0.0 ? 0.0 : HUGE_VAL);
                }
            }
        }
        /* what the refit must say, from the moved points themselves */
        expect_nonfinite = 0;
        for (i = 0; i < 3 * n; i++) expect_nonfinite |= !isfinite(target[i]);
        for (i = 0; i < tree.node_count; i++) { /* a once-identical leaf whose points now differ in value */
            const sqffd_kdtree_node *nd = &tree.nodes[i];
            size_t k;
            if (nd->axis != SQFFD_KDTREE_LEAF || nd->u.leaf.end - nd->u.leaf.begin <= 10) continue;
            for (k = nd->u.leaf.begin + 1; k < nd->u.leaf.end; k++) {
                const double *pa = target + 3 * (size_t)tree.index[nd->u.leaf.begin];
                const double *pb = target + 3 * (size_t)tree.index[k];
                if (pa[0] != pb[0] || pa[1] != pb[1] || pa[2] != pb[2]) split = 1;
            }
        }
        saved = tree;
        saved_nodes = (sqffd_kdtree_node *)malloc(tree.node_count * sizeof(sqffd_kdtree_node));
        if (!saved_nodes) abort();
        memcpy(saved_nodes, tree.nodes, tree.node_count * sizeof(sqffd_kdtree_node));
        res = sqffd_kdtree_refit(&tree, target);
        if (expect_nonfinite) {
            if (res != SQFFD_ERROR_NON_FINITE && !(split && res == SQFFD_ERROR_DEGENERATE)) abort();
        } else if (split) {
            if (res != SQFFD_ERROR_DEGENERATE) abort();
        } else if (res != SQFFD_OK) {
            abort(); /* refused points whose identical leaves are still identical (by value) */
        }
        if (res == SQFFD_OK) {
            check_tree(&tree, target, n, 1, s.seen);
            r.at = query_start; /* the same queries, against the moved points */
            run_queries(&tree, target, n, &r, queries, &s);
        } else {
            /* on error the tree is unchanged */
            if (memcmp(&saved, &tree, sizeof tree) != 0 ||
                memcmp(saved_nodes, tree.nodes, tree.node_count * sizeof(sqffd_kdtree_node)) != 0)
                abort();
            r.at = query_start;
            run_queries(&tree, points, n, &r, queries < 4 ? queries : 4, &s);
        }
        if (sqffd_kdtree_refit(&tree, NULL) != SQFFD_ERROR_INVALID_ARGUMENT) abort();
        if (sqffd_kdtree_refit(NULL, points) != SQFFD_ERROR_INVALID_ARGUMENT) abort();
    }

done:
    free(saved_nodes);
    free(block);
    free(block2);
    free(points);
    free(moved);
    free(s.all);
    free(s.sorted);
    free(s.indices);
    free(s.d2);
    free(s.seen);
    return 0;
}

/* kd-tree benchmark: build time, 1-NN and 8-NN query time on 10^5 and 10^6
   points (uniform cube; noisy sphere surface), medians of repeated runs, and
   memory per point. With -DSQFFD_BENCH_NANOFLANN (make bench, when
   nanoflann is installed) the same data and queries through nanoflann, the
   ratio sqffd/nanoflann (<= 1.0: sqffd as fast or faster), and a check that
   both find the same nearest distances. */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include "bench.h"
#include <stdio.h>
#include <string.h>
#include <math.h>
#include <stddef.h>

#ifdef SQFFD_BENCH_NANOFLANN
void *peer_nanoflann_build(const double *points, size_t n);
void peer_nanoflann_free(void *handle);
size_t peer_nanoflann_memory(void *handle);
void peer_nanoflann_knn(void *handle, const double *queries, size_t nq, size_t k, uint32_t *indices,
                        double *dist2);
#endif

#define RUNS 7
#define QUERIES 100000
#define K 8

static unsigned long long rng_state = 12345;

static double uniform01(void)
{
    rng_state = rng_state * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(rng_state >> 11) * (1.0 / 9007199254740992.0);
}

/* Unit cube, or the unit sphere's surface with noise 0.002 (surface-like). */
static void make_points(double *p, size_t n, int surface)
{
    size_t i;
    for (i = 0; i < n; i++) {
        double *x = p + 3 * i;
        if (!surface) {
            x[0] = uniform01(); x[1] = uniform01(); x[2] = uniform01();
        } else {
            double len2, r;
            do {
                x[0] = 2 * uniform01() - 1; x[1] = 2 * uniform01() - 1; x[2] = 2 * uniform01() - 1;
                len2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
            } while (len2 > 1.0 || len2 < 1e-6);
            r = (1.0 + 0.002 * (2 * uniform01() - 1)) / sqrt(len2);
            x[0] *= r; x[1] *= r; x[2] *= r;
        }
    }
}

/* Queries near the data: a data point moved by up to about the point spacing. */
static void make_queries(double *q, const double *p, size_t n, size_t nq, double spacing)
{
    size_t i;
    int d;
    for (i = 0; i < nq; i++) {
        const double *x = p + 3 * (size_t)(uniform01() * (double)n);
        for (d = 0; d < 3; d++) q[3 * i + (size_t)d] = x[d] + spacing * (2 * uniform01() - 1);
    }
}

/* Seconds for one run: build, then per query 1-NN and 8-NN; memory. */
typedef struct timing {
    double build, nn, knn;
    double bytes_per_point;
} timing;

typedef struct sqffd_side {
    sqffd_kdtree tree;
    void *workspace;
    size_t size;
} sqffd_side;

static timing run_sqffd(sqffd_side *s, const double *p, size_t n, const double *q, double *nn_d2)
{
    size_t i, idx[K], nearest, found;
    double d2[K], sink = 0.0, t0 = bench_now();
    timing t;
    if (sqffd_kdtree_build(&s->tree, p, n, s->workspace, s->size) != SQFFD_OK) {
        fprintf(stderr, "build failed\n");
        exit(1);
    }
    t.build = bench_now() - t0;
    t0 = bench_now();
    for (i = 0; i < QUERIES; i++) sqffd_kdtree_nearest(&s->tree, q + 3 * i, &nearest, &nn_d2[i]);
    t.nn = (bench_now() - t0) / QUERIES;
    t0 = bench_now();
    for (i = 0; i < QUERIES; i++) {
        sqffd_kdtree_knn(&s->tree, q + 3 * i, K, idx, d2, &found);
        sink += d2[K - 1];
    }
    t.knn = (bench_now() - t0) / QUERIES;
    if (sink < 0) printf("impossible\n");
    t.bytes_per_point = (double)(n * sizeof(uint32_t) + s->tree.node_count * sizeof(sqffd_kdtree_node)) / (double)n;
    return t;
}

#ifdef SQFFD_BENCH_NANOFLANN
static timing run_nanoflann(const double *p, size_t n, const double *q, double *nn_d2, uint32_t *idx, double *d2)
{
    double t0 = bench_now();
    void *h = peer_nanoflann_build(p, n);
    timing t;
    t.build = bench_now() - t0;
    t0 = bench_now();
    peer_nanoflann_knn(h, q, QUERIES, 1, idx, nn_d2);
    t.nn = (bench_now() - t0) / QUERIES;
    t0 = bench_now();
    peer_nanoflann_knn(h, q, QUERIES, K, idx, d2);
    t.knn = (bench_now() - t0) / QUERIES;
    t.bytes_per_point = (double)peer_nanoflann_memory(h) / (double)n;
    peer_nanoflann_free(h);
    return t;
}
#endif

/* Median over the runs of one field of timing (given by offset). */
static double median_of(const timing *runs, size_t field)
{
    double v[RUNS];
    int r;
    for (r = 0; r < RUNS; r++) v[r] = *(const double *)((const char *)&runs[r] + field);
    return bench_median(v, RUNS);
}

int main(void)
{
    static const size_t sizes[2] = {100000, 1000000};
    static const char *names[2] = {"cube", "sphere"};
    double *q = (double *)malloc(3 * QUERIES * sizeof(double));
    double *d_ours = (double *)malloc(QUERIES * sizeof(double));
    int s, shape, ok = 1;
#ifdef SQFFD_BENCH_NANOFLANN
    int ok_speed = 1;
#endif
    double worst_bytes = 0.0;
    size_t million_size = 0;

    printf("kd-tree: median of %d runs, %d queries near the data, leaf size 10\n", RUNS, QUERIES);
#ifdef SQFFD_BENCH_NANOFLANN
    printf("%-7s %8s | %9s %9s %5s | %8s %8s %5s | %8s %8s %5s | %6s %6s | %s\n", "data", "points",
           "build ms", "nanoflann", "ratio", "1-NN us", "nanoflann", "ratio", "8-NN us", "nanoflann", "ratio",
           "B/pt", "nf B/pt", "same 1-NN");
#else
    printf("(nanoflann not installed: peer columns skipped)\n");
    printf("%-7s %8s | %9s | %8s | %8s | %6s\n", "data", "points", "build ms", "1-NN us", "8-NN us", "B/pt");
#endif
    for (shape = 0; shape < 2; shape++) {
        for (s = 0; s < 2; s++) {
            size_t n = sizes[s];
            double *p = (double *)malloc(3 * n * sizeof(double));
            double spacing = shape ? sqrt(4.0 * 3.14159 / (double)n) : pow((double)n, -1.0 / 3.0);
            sqffd_side side;
            timing ours[RUNS];
            int r;
            make_points(p, n, shape);
            make_queries(q, p, n, QUERIES, spacing);
            if (sqffd_kdtree_workspace_size(n, &side.size) != SQFFD_OK) {
                fprintf(stderr, "workspace size failed\n");
                exit(1);
            }
            side.workspace = malloc(side.size);
#ifdef SQFFD_BENCH_NANOFLANN
            {
                /* Runs alternate between the two, so load on the machine hits
                   both alike; each ratio is the median of per-run ratios. */
                double *d_peer = (double *)malloc(QUERIES * sizeof(double)), ratio[3][RUNS];
                uint32_t *pidx = (uint32_t *)malloc(QUERIES * K * sizeof(uint32_t));
                double *pd2 = (double *)malloc(QUERIES * K * sizeof(double));
                timing peer[RUNS];
                size_t i, same = 0;
                int slower;
                for (r = 0; r < RUNS; r++) {
                    ours[r] = run_sqffd(&side, p, n, q, d_ours);
                    peer[r] = run_nanoflann(p, n, q, d_peer, pidx, pd2);
                    ratio[0][r] = ours[r].build / peer[r].build;
                    ratio[1][r] = ours[r].nn / peer[r].nn;
                    ratio[2][r] = ours[r].knn / peer[r].knn;
                }
                for (i = 0; i < QUERIES; i++) same += d_ours[i] == d_peer[i];
                printf("%-7s %8zu | %9.1f %9.1f %5.2f | %8.3f %8.3f %5.2f | %8.3f %8.3f %5.2f | %6.1f %6.1f | %zu/%d\n",
                       names[shape], n, 1e3 * median_of(ours, offsetof(timing, build)),
                       1e3 * median_of(peer, offsetof(timing, build)), bench_median(ratio[0], RUNS),
                       1e6 * median_of(ours, offsetof(timing, nn)), 1e6 * median_of(peer, offsetof(timing, nn)),
                       bench_median(ratio[1], RUNS), 1e6 * median_of(ours, offsetof(timing, knn)),
                       1e6 * median_of(peer, offsetof(timing, knn)), bench_median(ratio[2], RUNS),
                       ours[0].bytes_per_point, peer[0].bytes_per_point, same, QUERIES);
                if (same != QUERIES) ok = 0;
                slower = bench_median(ratio[0], RUNS) > 1.0 || bench_median(ratio[1], RUNS) > 1.0;
                if (slower) ok_speed = 0;
                free(d_peer);
                free(pidx);
                free(pd2);
            }
#else
            for (r = 0; r < RUNS; r++) ours[r] = run_sqffd(&side, p, n, q, d_ours);
            printf("%-7s %8zu | %9.1f | %8.3f | %8.3f | %6.1f\n", names[shape], n,
                   1e3 * median_of(ours, offsetof(timing, build)), 1e6 * median_of(ours, offsetof(timing, nn)),
                   1e6 * median_of(ours, offsetof(timing, knn)), ours[0].bytes_per_point);
#endif
            if (ours[0].bytes_per_point > worst_bytes) worst_bytes = ours[0].bytes_per_point;
            free(side.workspace);
            free(p);
        }
    }
    if (sqffd_kdtree_workspace_size(1000000, &million_size) != SQFFD_OK) ok = 0;
    printf("memory: %.1f bytes/point used, workspace_size %.1f bytes/point at n = 10^6 (target <= 48): %s\n",
           worst_bytes, (double)million_size / 1e6,
           worst_bytes <= 48.0 && million_size != 0 && million_size <= 48000000 ? "met" : "MISSED");
#ifdef SQFFD_BENCH_NANOFLANN
    printf("speed: build and 1-NN ratio <= 1.0 on every row: %s\n", ok_speed ? "met" : "MISSED");
    printf("nearest distances identical to nanoflann's: %s\n", ok ? "yes" : "NO (MISMATCH)");
#endif
    free(q);
    free(d_ours);
    return ok ? 0 : 1;
}

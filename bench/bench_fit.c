/* The whole fit (superquadric + 33 FFD iterations, 25 of them coarse, 5x5x5)
   on the phantom left ventricle at 6,000, 10^5 and 10^6 points; the time of
   one FFD iteration on the grid (sqffd_fit_ffd's) next to one closest-point
   pass over the same data (the irreducible part of an iteration); workspace
   bytes per data point; without the model -> data term; the default stop
   (tolerance) instead of always every iteration. */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include "../examples/sqffd_phantom.h"
#include "bench.h"
#include <stdio.h>
#include <string.h>

#define MAX_RUNS 31 /* the 6,000-point rows: this VM's speed drifts by tens of percent for seconds at a time */

typedef struct row {
    double total, sq, ffd0, ffd, pass; /* medians, seconds */
    double sq_error, error, reverse;
    size_t workspace;
    int iterations;
} row;

static double reverse_rms(const sqffd_model *m, const double *pts, size_t n)
{
    sqffd_distance_stats s;
    size_t size;
    void *ws;
    if (sqffd_model_reverse_distances_workspace_size(n, m, &size) != SQFFD_OK) return -1.0;
    ws = malloc(size);
    if (!ws || sqffd_model_reverse_distances(m, pts, n, NULL, &s, ws, size) != SQFFD_OK) s.rms_relative = -1.0;
    free(ws);
    return s.rms_relative;
}

/* One closest-point pass: each point's nearest model point (kd-tree over
   the model's grid points, built once), over the points an FFD iteration
   uses (the subsample when there is one). */
static double closest_pass(const sqffd_model *m, const double *pts, size_t n)
{
    size_t count = 0, v = 0, i, size;
    double *x, t0, t1, sink = 0.0;
    void *ws;
    sqffd_kdtree tree;
    sqffd_model_mesh_size(m->grid[0], m->grid[1], &count, NULL);
    x = (double *)malloc(3 * count * sizeof *x);
    sqffd_model_mesh(m, m->grid[0], m->grid[1], x, NULL);
    if (sqffd_kdtree_workspace_size(count, &size) != SQFFD_OK) {
        free(x);
        return 0.0;
    }
    ws = malloc(size);
    sqffd_kdtree_build(&tree, x, count, ws, size);
    t0 = bench_now();
    for (i = 0; i < n; i++) {
        double d2;
        sqffd_kdtree_nearest(&tree, pts + 3 * i, &v, &d2);
        sink += d2 + (double)v;
    }
    t1 = bench_now();
    free(ws);
    free(x);
    return sink > 0.0 ? t1 - t0 : 0.0;
}

static int measure(const double *pts, size_t n, const sqffd_fit_options *o, int runs, row *r)
{
    double total[MAX_RUNS], sq[MAX_RUNS], ffd0[MAX_RUNS], ffd[MAX_RUNS], pass[MAX_RUNS];
    size_t size = 0, k, sq_size = 0;
    size_t sq_n = o->sq_max_points && n > o->sq_max_points ? o->sq_max_points : n;
    size_t ffd_n = o->ffd_max_points && n > o->ffd_max_points ? o->ffd_max_points : n;
    void *ws, *sq_ws;
    double *sample = (double *)malloc(3 * sq_n * sizeof *sample);
    double *ffd_pts = (double *)malloc(3 * ffd_n * sizeof *ffd_pts);
    sqffd_model m, start;
    sqffd_fit_report rep;
    sqffd_fit_options zero = *o;
    int i;
    sqffd_superquadric s;
    if (sqffd_fit_workspace_size(n, o, &size) != SQFFD_OK || sqffd_sq_fit_workspace_size(sq_n, &o->sq, &sq_size) != SQFFD_OK)
        return 0;
    ws = malloc(size);
    sq_ws = malloc(sq_size);
    if (!ws || !sq_ws || !sample || !ffd_pts) return 0;
    for (k = 0; k < sq_n; k++) /* the same subsamples sqffd_fit uses */
        memcpy(sample + 3 * k, pts + 3 * (k * (n / sq_n) + k * (n % sq_n) / sq_n), 3 * sizeof(double));
    for (k = 0; k < ffd_n; k++)
        memcpy(ffd_pts + 3 * k, pts + 3 * (k * (n / ffd_n) + k * (n % ffd_n) / ffd_n), 3 * sizeof(double));
    zero.max_iterations = 0;
    for (i = 0; i < runs; i++) {
        double t0 = bench_now();
        if (sqffd_fit(pts, n, o, &m, &rep, ws, size) != SQFFD_OK) return 0;
        total[i] = bench_now() - t0;
        t0 = bench_now();
        sqffd_sq_fit(sample, sq_n, &o->sq, &s, NULL, sq_ws, sq_size);
        sq[i] = bench_now() - t0;
        sqffd_model_init(&start, &s, o);
        m = start;
        t0 = bench_now(); /* prepare + one pass: what an FFD stage costs besides its iterations */
        sqffd_fit_ffd(pts, n, &zero, &m, NULL, ws, size);
        ffd0[i] = bench_now() - t0;
        m = start;
        t0 = bench_now();
        sqffd_fit_ffd(pts, n, o, &m, &rep, ws, size);
        ffd[i] = bench_now() - t0;
        pass[i] = closest_pass(&m, ffd_pts, ffd_n);
    }
    r->total = bench_median(total, runs);
    r->sq = bench_median(sq, runs);
    r->ffd0 = bench_median(ffd0, runs);
    r->ffd = bench_median(ffd, runs);
    r->pass = bench_median(pass, runs);
    r->sq_error = rep.sq_error.rms_relative;
    r->error = rep.error.rms_relative;
    r->reverse = reverse_rms(&m, pts, n);
    r->workspace = size;
    r->iterations = rep.iterations;
    free(ws); free(sq_ws); free(sample); free(ffd_pts);
    return 1;
}

static void print_row(const char *name, size_t n, const row *r)
{
    double per_iteration = (r->ffd - r->ffd0) / r->iterations;
    printf("%-22s %8zu %9.1f %8.1f %8.1f %4d %9.3f %9.3f %6.2f %9.1f %9.5f %9.5f %8.4f\n", name, n, 1e3 * r->total,
           1e3 * r->sq, 1e3 * r->ffd, r->iterations, 1e3 * per_iteration, 1e3 * r->pass, per_iteration / r->pass,
           (double)r->workspace / (double)n, r->sq_error, r->error, r->reverse);
}

int main(void)
{
    const size_t sizes[3] = {6000, 100000, 1000000};
    const int runs[3] = {MAX_RUNS, 5, 3};
    phantom_lv ph = phantom_lv_default();
    sqffd_fit_options o = sqffd_fit_options_default();
    row r;
    int s;
    o.tolerance = 0.0; /* always every iteration (but the "default tolerance" row) */
    printf("sqffd_fit on the phantom left ventricle: superquadric + %d FFD iterations (%d coarse), %dx%dx%d lattice, "
           "%dx%d grid\n", o.max_iterations, o.coarse_iterations, o.lattice[0], o.lattice[1], o.lattice[2], o.grid[0],
           o.grid[1]);
    printf("(medians; ms; stage 1 on at most %zu points, FFD iterations on at most %zu (\"all\": every point);\n"
           " ffd = sqffd_fit_ffd from the same superquadric, every iteration on the grid, its = its iterations,\n"
           " iter = one of them (ffd less its fixed part: preparing the system and the first pass),\n"
           " pass = one closest-point pass (kd-tree over the model points, from scratch) over the same points;\n"
           " errors over all points, relative to the bounding-box diagonal: sq = superquadric alone, err = model,\n"
           " rev = model -> data RMS; B/point = workspace bytes per data point)\n\n",
           o.sq_max_points, o.ffd_max_points);
    printf("%-22s %8s %9s %8s %8s %4s %9s %9s %6s %9s %9s %9s %8s\n", "case", "points", "total", "sq", "ffd", "its", "iter",
           "pass", "ratio", "B/point", "sq err", "err", "rev");
    for (s = 0; s < 3; s++) {
        double *pts = (double *)malloc(3 * sizes[s] * sizeof *pts);
        if (!pts) return 1;
        phantom_lv_sample(&ph, 0.0, sizes[s], pts);
        if (!measure(pts, sizes[s], &o, runs[s], &r)) { printf("fit failed\n"); return 1; }
        print_row(sizes[s] > o.ffd_max_points ? "default (subsample)" : "default", sizes[s], &r);
        if (s == 0) { /* without the model -> data term: what it changes; the default stop */
            sqffd_fit_options sym = o, stop = o;
            sym.model_to_data = 0.0;
            if (!measure(pts, sizes[s], &sym, runs[s], &r)) { printf("fit failed\n"); return 1; }
            print_row("no model->data term", sizes[s], &r);
            stop.tolerance = sqffd_fit_options_default().tolerance;
            if (!measure(pts, sizes[s], &stop, runs[s], &r)) { printf("fit failed\n"); return 1; }
            print_row("default tolerance", sizes[s], &r);
        }
        if (sizes[s] > o.ffd_max_points) { /* every point in every iteration */
            sqffd_fit_options all = o;
            all.ffd_max_points = 0;
            if (!measure(pts, sizes[s], &all, 1, &r)) { printf("fit failed\n"); return 1; }
            print_row("all points (1 run)", sizes[s], &r);
        }
        free(pts);
    }
    printf("\ntargets: 6,000 points total <= 20 ms; iter <= 2x pass; 10^6 points total <= 3 s with <= 200 B/point\n");
    return 0;
}

/* Real shapes: the whole fit at default settings on shapes that are no
   superquadric - the development meshes of ../shared/data/dev (their
   vertices, and 6,000 points resampled on their triangles), the Stanford
   bunny's vertices and the phantom left ventricle at 6,000 points - next to
   stored figures of the 2026-11-25 code: its error after up to 1,000
   iterations (the reference) and its error and model->data at default
   settings. */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include "../examples/sqffd_io.h"
#include "../examples/sqffd_phantom.h"
#include "../examples/sqffd_synth.h"
#include "bench.h"
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#define RUNS 11
#define DEV_DIR "../shared/data/dev"
#define SAMPLE_POINTS 6000      /* each mesh resampled, and the phantom */
#define RESAMPLE_SEED 20261125u /* every mesh is resampled from this seed */
#define ERROR_FACTOR 1.05       /* target: error <= this x the reference */
#define TIME_TARGET_MS 20.0     /* target: 6,000-point whole fit */

static const char *const dev_shapes[] = {"elephant", "femur", "head", "hand", "cow", "bones"};

typedef struct reference {
    const char *shape;
    size_t points;
    double error;         /* after up to 1,000 iterations, % of the diagonal */
    int iterations;       /* the iterations it used (1000: the cap) */
    double today_error;   /* at default settings, % */
    double today_reverse; /* model->data at default settings, % */
} reference;

/* Computed once, not at bench time, on 2026-11-25, by a throwaway pair of
   programs. The first, built on sqffd.h of commit 12b1035 (the old code),
   built the point sets with this file's own functions: each mesh's
   vertices as read; SAMPLE_POINTS (6,000) points on its triangles by
   synth_sample_triangles from synth_rng_seed(RESAMPLE_SEED = 20261125),
   reseeded per mesh; bunny.ply's vertices; phantom_lv_sample of
   phantom_lv_default() at phase 0.0, 6,000 points. It fitted each set with
   sqffd_fit_options_default() and max_iterations = 1000, all else default
   (tolerance 1e-4 stopped head and the phantom early: `iterations`), and
   with sqffd_fit_options_default() unchanged, and saved both models. The
   second, built on the new sqffd.h, measured those old models on their
   grid mesh: error by sqffd_model_distances, the exact point-to-triangle
   distance to the mesh (it equals a brute-force search over all the mesh's
   triangles to 1e-15), today_reverse by sqffd_model_reverse_distances over
   the same points. Why: the old code's error took the nearest of the
   triangles around the nearest mesh vertex, which misses the closest
   triangle on stretched meshes (elephant at default settings: 2.53%
   reported, 1.68% exact), so its own report.error figures overstated the
   error and are not comparable with today's. So every figure is the
   12b1035 code's model measured the exact way; today_error and
   today_reverse are that code's default-settings model, not today's. Percent
   of the bounding-box diagonal, rounded to 6 decimals. */
static const reference references[] = {
    {"elephant", 2775, 1.044777, 1000, 1.677703, 5.822096},
    {"elephant resampled", 6000, 0.751109, 1000, 1.361309, 3.276792},
    {"femur", 3897, 0.488217, 1000, 0.805555, 7.396258},
    {"femur resampled", 6000, 0.412721, 1000, 0.936356, 6.269692},
    {"head", 1487, 0.450653, 360, 0.648751, 2.234274},
    {"head resampled", 6000, 0.299301, 346, 0.385336, 1.629588},
    {"hand", 1197, 0.850230, 1000, 1.379420, 2.387801},
    {"hand resampled", 6000, 0.677276, 1000, 1.058998, 1.079932},
    {"cow", 2904, 0.712549, 1000, 1.127180, 10.193834},
    {"cow resampled", 6000, 0.631437, 1000, 1.142895, 7.548750},
    {"bones", 2154, 0.736457, 1000, 1.034489, 4.007777},
    {"bones resampled", 6000, 0.456560, 1000, 1.041539, 1.131485},
    {"bunny", 1839, 0.729769, 1000, 1.080699, 3.415821},
    {"phantom", 6000, 0.059366, 26, 0.059366, 10.099001},
};

static const reference *find_reference(const char *shape, size_t n)
{
    size_t i;
    for (i = 0; i < sizeof references / sizeof references[0]; i++)
        if (strcmp(references[i].shape, shape) == 0 && references[i].points == n) return &references[i];
    return NULL;
}

/* The mesh DEV_DIR/SHAPE.off; 0 on success. */
static int read_dev_mesh(const char *shape, double **vertices, size_t *vertex_count, uint32_t **triangles,
                         size_t *triangle_count, char *err, size_t err_size)
{
    char path[256];
    snprintf(path, sizeof path, "%s/%s.off", DEV_DIR, shape);
    return sqffd_io_read_off_mesh_file(path, vertices, vertex_count, triangles, triangle_count, err, err_size);
}

/* SAMPLE_POINTS points uniform by area on a mesh, the same for every run and
   machine (malloc'd; NULL when that failed). */
static double *resample(const double *vertices, const uint32_t *triangles, size_t triangle_count)
{
    synth_rng r = synth_rng_seed(RESAMPLE_SEED);
    double *pts = (double *)malloc(3 * SAMPLE_POINTS * sizeof *pts);
    if (pts && synth_sample_triangles(&r, vertices, triangles, triangle_count, SAMPLE_POINTS, pts) != SAMPLE_POINTS) {
        free(pts);
        pts = NULL;
    }
    return pts;
}

enum { TARGET_ERROR = 1, TARGET_TIME = 2 }; /* the targets a row is held to besides model->data */

static int met, checked, failed; /* targets met and checked; rows that could not be measured */

/* A row that could not be measured: its message instead of figures. */
static void row_failed(const char *shape, size_t n, const char *what, const char *detail)
{
    if (n) printf("%-19s %6zu  %s%s\n", shape, n, what, detail);
    else printf("%-19s %6s  %s%s\n", shape, "-", what, detail); /* the points were never read */
    failed++;
}

/* One target's flag: "-" where it does not apply, else ok or MISS (counted). */
static const char *flag(int applies, int ok)
{
    if (!applies) return "-";
    checked++;
    met += ok;
    return ok ? "ok" : "MISS";
}

/* Fits the n points RUNS times at default settings and prints their row. */
static void bench_row(const char *shape, const double *pts, size_t n, int targets)
{
    sqffd_fit_options o = sqffd_fit_options_default();
    size_t size, reverse_size;
    void *ws, *reverse_ws;
    const reference *ref = find_reference(shape, n);
    double ms[RUNS], err, time_ms;
    char its[24];
    sqffd_model m;
    sqffd_fit_report rep;
    sqffd_distance_stats reverse;
    sqffd_result r = sqffd_fit_workspace_size(n, &o, &size);
    int i;
    if (r != SQFFD_OK) {
        row_failed(shape, n, "workspace size failed: ", sqffd_result_string(r));
        return;
    }
    ws = malloc(size);
    if (!ws) {
        row_failed(shape, n, "out of memory", "");
        return;
    }
    for (i = 0; i < RUNS && r == SQFFD_OK; i++) {
        double t0 = bench_now();
        r = sqffd_fit(pts, n, &o, &m, &rep, ws, size);
        ms[i] = 1e3 * (bench_now() - t0);
    }
    free(ws);
    if (r != SQFFD_OK) {
        row_failed(shape, n, "fit failed: ", sqffd_result_string(r));
        return;
    }
    r = sqffd_model_reverse_distances_workspace_size(n, &m, &reverse_size);
    if (r != SQFFD_OK) {
        row_failed(shape, n, "model->data workspace size failed: ", sqffd_result_string(r));
        return;
    }
    reverse_ws = malloc(reverse_size);
    if (!reverse_ws) {
        row_failed(shape, n, "out of memory", "");
        return;
    }
    r = sqffd_model_reverse_distances(&m, pts, n, NULL, &reverse, reverse_ws, reverse_size);
    free(reverse_ws);
    if (r != SQFFD_OK) {
        row_failed(shape, n, "model->data failed: ", sqffd_result_string(r));
        return;
    }
    err = 100.0 * rep.error.rms_relative;
    time_ms = bench_median(ms, RUNS);
    snprintf(its, sizeof its, "%d+%d", rep.coarse_iterations, rep.iterations);
    printf("%-19s %6zu %7.4f %7.4f %7.4f %5s %6.1f", shape, n, 100.0 * rep.sq_error.rms_relative, err,
           100.0 * reverse.rms_relative, its, time_ms);
    if (ref)
        printf(" %7.4f %4d %7.3f %7.4f %7.4f", ref->error, ref->iterations, err / ref->error, ref->today_error,
               ref->today_reverse);
    else
        printf(" %7s %4s %7s %7s %7s", "-", "-", "-", "-", "-");
    /* the stored figures have 6 decimals: half a unit of the last counts as equal */
    printf("  %-4s %-4s %s\n", flag(ref && (targets & TARGET_ERROR), ref && err <= ERROR_FACTOR * ref->error),
           flag(ref != NULL, ref && 100.0 * reverse.rms_relative <= ref->today_reverse + 0.5e-6),
           flag(targets & TARGET_TIME, time_ms <= TIME_TARGET_MS));
}

int main(void)
{
    sqffd_fit_options o = sqffd_fit_options_default();
    phantom_lv ph = phantom_lv_default();
    struct stat st;
    double *pts;
    size_t n, i;
    char err[256];
    printf("sqffd_fit on real shapes, default settings: %dx%dx%d lattice, %dx%d grid, at most %d FFD iterations "
           "(%d coarse), tolerance %g\n", o.lattice[0], o.lattice[1], o.lattice[2], o.grid[0], o.grid[1],
           o.max_iterations, o.coarse_iterations, o.tolerance);
    printf("(errors in %% of the bounding-box diagonal, over all points: sq = superquadric alone, err = the model\n"
           " (data -> model RMS), m->d = model -> data RMS; its = FFD iterations used, coarse + grid; ms = whole fit,\n"
           " median of %d; stored, not recomputed, from 0.1.0 (commit 12b1035), measured with the exact error:\n"
           " ref = its error after up to 1,000 iterations, ref its = the iterations it used (tolerance 1e-4), today err and today\n"
           " m->d = 0.1.0 at default settings; flags: the targets below, ok or MISS, - where a target does not apply)\n\n",
           RUNS);
    printf("%-19s %6s %7s %7s %7s %5s %6s %7s %4s %7s %7s %7s  %-4s %-4s %s\n", "shape", "points", "sq err", "err",
           "m->d", "its", "ms", "ref", "ref", "err/ref", "today", "today", "err", "m->d", "ms");
    printf("%-19s %6s %7s %7s %7s %5s %6s %7s %4s %7s %7s %7s\n", "", "", "", "", "", "", "", "err", "its", "", "err",
           "m->d");
    if (stat(DEV_DIR, &st) != 0 || !S_ISDIR(st.st_mode))
        printf("(dev shapes skipped: %s is absent; the development meshes live outside the project, next to it)\n",
               DEV_DIR);
    else
        for (i = 0; i < sizeof dev_shapes / sizeof dev_shapes[0]; i++) {
            double *vertices;
            uint32_t *triangles;
            size_t vertex_count, triangle_count;
            char name[32];
            if (read_dev_mesh(dev_shapes[i], &vertices, &vertex_count, &triangles, &triangle_count, err, sizeof err)) {
                row_failed(dev_shapes[i], 0, err, "");
                continue;
            }
            bench_row(dev_shapes[i], vertices, vertex_count, TARGET_ERROR);
            snprintf(name, sizeof name, "%s resampled", dev_shapes[i]);
            pts = resample(vertices, triangles, triangle_count);
            if (pts) bench_row(name, pts, SAMPLE_POINTS, TARGET_ERROR | TARGET_TIME);
            else row_failed(name, SAMPLE_POINTS, "resampling failed (out of memory, or the mesh has no area)", "");
            free(pts);
            free(vertices);
            free(triangles);
        }
    if (sqffd_io_read_file("tests/data/bunny.ply", &pts, &n, err, sizeof err)) row_failed("bunny", 0, err, "");
    else bench_row("bunny", pts, n, TARGET_ERROR);
    free(pts);
    pts = (double *)malloc(3 * SAMPLE_POINTS * sizeof *pts);
    if (!pts) return 1;
    phantom_lv_sample(&ph, 0.0, SAMPLE_POINTS, pts);
    bench_row("phantom", pts, SAMPLE_POINTS, TARGET_TIME);
    free(pts);
    printf("\ntargets: err <= %.2fx ref on every dev shape and the bunny; m->d <= today m->d on every row;\n"
           "         6,000 points whole fit <= %.0f ms. Met: %d of %d", ERROR_FACTOR, TIME_TARGET_MS, met, checked);
    if (failed) printf("; %d row%s not measured (above)", failed, failed > 1 ? "s" : "");
    printf("\n");
    return 0;
}

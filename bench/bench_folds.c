/* Folds: the independent fold check of tests/mesh_check.h on the models the
   defaults make of real and phantom data: each development mesh of
   ../shared/data/dev (its vertices) and the bunny, fitted alone; each
   heart of ../shared/data/cardiac (the first contouring, ED and ES, each
   stack closed by its lids, spacing as stored) and four frames of the
   phantom's beat (6,000 points each, no noise), tracked as `sqffd track` tracks them.
   One row per model: the fit's error and the report's Jacobian bound (the
   library's own claim), then the check: triangle pairs of the model's
   64 x 128 mesh (the CLI's) that cross, the images of 12,000 points of the
   superquadric's solid not wound once by that mesh, and the check's time
   (median of 3). A model that does not fold has 0 and 0. The same again
   for the same data fitted or tracked without the floor (min_jacobian
   -HUGE_VAL): the folds the check must see, and the error the floor costs. */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include "../examples/sqffd_io.h"
#include "../examples/sqffd_phantom.h"
#include "../tests/mesh_check.h"
#include "bench.h"
#include <dirent.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#define DATA_DIR "../shared/data"
#define SAMPLES 12000
#define RUNS 3 /* the check's time: the median of this many */
#define MESH_ETA 64
#define MESH_OMEGA 128
#define MAX_NAMES 64
#define PHANTOM_POINTS 6000
#define PHANTOM_SEED 20261201u

static int models, folded, free_models, free_folded, capped, runs_counted;
static double log_error_ratio[2], log_time_ratio[2]; /* sums of logs: [0] scans (dev, bunny), [1] heart and phantom frames */
static int ratio_count[2];

/* The check of one model into `cell` (a table's cells: crossing pairs, not wound once, ms); 1 when it folds. */
static int check(const sqffd_model *m, char *cell, size_t size, int *folds)
{
    meshcheck_folds f;
    double ms[RUNS];
    sqffd_result r = SQFFD_OK;
    int k;
    for (k = 0; k < RUNS && r == SQFFD_OK; k++) {
        double t0 = bench_now();
        r = meshcheck_model_folds(m, SAMPLES, MESH_ETA, MESH_OMEGA, &f);
        ms[k] = 1e3 * (bench_now() - t0);
    }
    if (r != SQFFD_OK) {
        snprintf(cell, size, "check failed: %s | - | -", sqffd_result_string(r));
        return 0;
    }
    snprintf(cell, size, "%ld | %d / %d | %.0f", f.crossings, f.winding_failures, f.samples, bench_median(ms, RUNS));
    *folds = f.crossings != 0 || f.winding_failures != 0;
    return 1;
}

/* One row: the model of the defaults, then the one without the floor, and
   the price: error and time (ms[2], the fit's or the track's, median) of
   the floor against none. */
static void row(const char *name, const sqffd_model m[2], const sqffd_fit_report rep[2], const double ms[2], int kind)
{
    char cell[2][128];
    int folds[2] = {0, 0};
    models += check(&m[0], cell[0], sizeof cell[0], &folds[0]);
    free_models += check(&m[1], cell[1], sizeof cell[1], &folds[1]);
    folded += folds[0];
    free_folded += folds[1];
    capped += rep[0].stop == SQFFD_FIT_CAPPED;
    runs_counted++;
    log_error_ratio[kind] += log(rep[0].error.rms_relative / rep[1].error.rms_relative);
    log_time_ratio[kind] += log(ms[0] / ms[1]);
    ratio_count[kind]++;
    printf("| %s | %.3f | %.4f | %s | %d%s | %.3f | %.4g | %s | %.2f | %.2f |\n", name, 100.0 * rep[0].error.rms_relative,
           rep[0].min_jacobian, cell[0], rep[0].coarse_iterations + rep[0].iterations,
           rep[0].stop == SQFFD_FIT_CAPPED ? " (cap)" : rep[0].stop == SQFFD_FIT_STALLED ? " (stalled)" : "",
           100.0 * rep[1].error.rms_relative, rep[1].min_jacobian, cell[1],
           rep[0].error.rms_relative / rep[1].error.rms_relative, ms[0] / ms[1]);
}

/* Fits n points with the defaults and without the floor, then their row. */
static void fit_row(const char *name, const double *points, size_t n)
{
    sqffd_model m[2];
    sqffd_fit_report rep[2];
    sqffd_fit_options o = sqffd_fit_options_default();
    sqffd_result r = SQFFD_OK;
    double ms[2], t[RUNS];
    int pass, k;
    for (pass = 0; pass < 2 && r == SQFFD_OK; pass++) {
        size_t size;
        void *ws = NULL;
        o.min_jacobian = pass ? -HUGE_VAL : sqffd_fit_options_default().min_jacobian;
        r = sqffd_fit_workspace_size(n, &o, &size);
        if (r == SQFFD_OK && !(ws = malloc(size))) r = SQFFD_ERROR_TOO_LARGE;
        for (k = 0; k < RUNS && r == SQFFD_OK; k++) {
            double t0 = bench_now();
            r = sqffd_fit(points, n, &o, &m[pass], &rep[pass], ws, size);
            t[k] = bench_now() - t0;
        }
        ms[pass] = 1e3 * bench_median(t, RUNS);
        free(ws);
    }
    if (r != SQFFD_OK) printf("| %s | fit failed: %s |\n", name, sqffd_result_string(r));
    else row(name, m, rep, ms, 0);
}

/* Tracks the frames with the defaults and without the floor, then a row
   each ("NAME LABEL"). */
static void track_rows(const char *name, double *const *frames, const size_t *counts, size_t count,
                       const char *const *labels)
{
    sqffd_model m[4][2];
    sqffd_fit_report rep[4][2];
    sqffd_model out[4];
    sqffd_fit_report out_rep[4];
    sqffd_track_options o = sqffd_track_options_default();
    sqffd_result r = SQFFD_OK;
    size_t done = count, k;
    int pass, run;
    char title[64];
    double ms[2], t[RUNS];
    for (pass = 0; pass < 2 && r == SQFFD_OK && done == count; pass++) {
        size_t size;
        void *ws = NULL;
        o.fit.min_jacobian = pass ? -HUGE_VAL : sqffd_track_options_default().fit.min_jacobian;
        r = sqffd_track_workspace_size(counts, count, &o, &size);
        if (r == SQFFD_OK && !(ws = malloc(size))) r = SQFFD_ERROR_TOO_LARGE;
        for (run = 0; run < RUNS && r == SQFFD_OK; run++) {
            double t0 = bench_now();
            r = sqffd_track((const double *const *)frames, counts, count, &o, out, out_rep, &done, ws, size);
            t[run] = bench_now() - t0;
        }
        ms[pass] = 1e3 * bench_median(t, RUNS);
        free(ws);
        for (k = 0; k < count; k++) {
            m[k][pass] = out[k];
            rep[k][pass] = out_rep[k];
        }
    }
    if (r != SQFFD_OK) {
        printf("| %s | track failed: %s |\n", name, sqffd_result_string(r));
        return;
    }
    for (k = 0; k < count; k++) {
        snprintf(title, sizeof title, "%s %s", name, labels[k]);
        row(title, m[k], rep[k], ms, 1);
    }
}

static int cmp_name(const void *a, const void *b)
{
    return strcmp((const char *)a, (const char *)b);
}

/* The entries of a directory whose names end in `suffix` (the suffix cut
   off), sorted; their count (0 when the directory is absent). */
static size_t list_dir(const char *dir, const char *suffix, char names[MAX_NAMES][64])
{
    DIR *d = opendir(dir);
    struct dirent *e;
    size_t n = 0, len = strlen(suffix);
    if (!d) return 0;
    while ((e = readdir(d)) && n < MAX_NAMES) {
        size_t l = strlen(e->d_name);
        if (e->d_name[0] == '.' || l <= len || l - len >= 64 || strcmp(e->d_name + l - len, suffix) != 0) continue;
        memcpy(names[n], e->d_name, l - len);
        names[n++][l - len] = '\0';
    }
    closedir(d);
    qsort(names, n, sizeof names[0], cmp_name);
    return n;
}

/* A contour stack closed by its lids, as `sqffd track` closes each frame
   (malloc'd in *closed, *n updated); 0 on success. */
static int close_stack(const double *points, size_t *n, double **closed)
{
    sqffd_stack stack;
    size_t lids = 0;
    int found = 0;
    *closed = NULL;
    if (sqffd_stack_detect(points, *n, &stack, &found) != SQFFD_OK || !found ||
        sqffd_stack_lids(points, *n, &stack, NULL, 0, &lids) != SQFFD_OK ||
        !(*closed = (double *)malloc(3 * (*n + lids) * sizeof **closed)))
        return -1;
    memcpy(*closed, points, 3 * *n * sizeof **closed);
    if (sqffd_stack_lids(points, *n, &stack, *closed + 3 * *n, lids, &lids) != SQFFD_OK) return -1;
    *n += lids;
    return 0;
}

int main(void)
{
    static const char *const phases[2] = {"ED", "ES"}, *const beat[4] = {"0.00", "0.25", "0.50", "0.75"};
    char names[MAX_NAMES][64], path[256], err[256];
    phantom_lv ph = phantom_lv_default();
    double *points = NULL, *frames[4];
    size_t n, count, i, counts[4];
    int k;
    printf("## Folds: the models of the defaults, checked by tests/mesh_check.h\n\n"
           "(error: the fit's, %% of the data's diagonal; bound: the report's min_jacobian; crossing pairs: triangle\n"
           " pairs of the %d x %d mesh that cross; not wound once: of %d points drawn inside the superquadric (0.95 of\n"
           " its size), the images whose winding number is not 1; ms: the check, median of %d; iterations: coarse +\n"
           " grid, (cap) where the cap stopped them; no floor: the same data fitted or tracked with min_jacobian\n"
           " -HUGE_VAL; error x and time x: the floor's against none, the fit's or the whole track's time, median of %d)\n\n",
           MESH_ETA, MESH_OMEGA, SAMPLES, RUNS, RUNS);
    printf("| model | error %% | bound | crossing pairs | not wound once | ms | iterations | no floor: error %% | bound "
           "| crossing pairs | not wound once | ms | error x | time x |\n"
           "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
    count = list_dir(DATA_DIR "/dev", ".off", names);
    if (!count) printf("| (dev meshes skipped: %s/dev is absent) |\n", DATA_DIR);
    for (i = 0; i < count; i++) {
        uint32_t *triangles;
        size_t nt;
        snprintf(path, sizeof path, "%s/dev/%s.off", DATA_DIR, names[i]);
        if (sqffd_io_read_off_mesh_file(path, &points, &n, &triangles, &nt, err, sizeof err)) {
            printf("| %s | %s |\n", names[i], err);
            continue;
        }
        fit_row(names[i], points, n);
        free(points);
        free(triangles);
    }
    if (sqffd_io_read_file(DATA_DIR "/bunny.ply", &points, &n, err, sizeof err))
        printf("| (bunny skipped: %s) |\n", err);
    else fit_row("bunny", points, n);
    free(points);
    count = list_dir(DATA_DIR "/cardiac", "", names);
    for (i = 0; i < count; i++) {
        struct stat st;
        int ok = 1;
        snprintf(path, sizeof path, "%s/cardiac/%s/obs0_rep0/ed.xyz", DATA_DIR, names[i]);
        if (stat(path, &st) != 0) continue; /* not an exam */
        for (k = 0; k < 2; k++) {
            double *raw = NULL;
            frames[k] = NULL;
            snprintf(path, sizeof path, "%s/cardiac/%s/obs0_rep0/%s.xyz", DATA_DIR, names[i], k ? "es" : "ed");
            if (ok && sqffd_io_read_file(path, &raw, &counts[k], err, sizeof err) == 0) {
                if (close_stack(raw, &counts[k], &frames[k])) {
                    snprintf(err, sizeof err, "%.200s: no closed stack", path);
                    ok = 0;
                }
            } else ok = 0;
            free(raw);
        }
        if (ok) track_rows(names[i], frames, counts, 2, phases);
        else printf("| %s | skipped: %s |\n", names[i], err);
        free(frames[0]);
        free(frames[1]);
    }
    if (!count) printf("| (hearts skipped: %s/cardiac is absent) |\n", DATA_DIR);
    for (k = 0; k < 4; k++) {
        counts[k] = PHANTOM_POINTS;
        frames[k] = (double *)malloc(3 * PHANTOM_POINTS * sizeof(double));
        if (!frames[k]) return 1;
        phantom_lv_frame(&ph, 0.25 * k, PHANTOM_POINTS, 0.0, PHANTOM_SEED, frames[k], NULL);
    }
    track_rows("phantom", frames, counts, 4, beat);
    for (k = 0; k < 4; k++) free(frames[k]);
    printf("\n%d models of the defaults checked, %d fold; without the floor: %d checked, %d fold (crossing pairs or\n"
           "points not wound once). %d of %d default runs stopped at their iteration cap.\n", models, folded, free_models,
           free_folded, capped, runs_counted);
    for (k = 0; k < 2; k++)
        if (ratio_count[k])
            printf("The floor's price, geometric mean over the %d %s: error x %.2f, time x %.2f.\n", ratio_count[k],
                   k ? "heart and phantom frames (time: the whole track)" : "scans (dev meshes and bunny)",
                   exp(log_error_ratio[k] / ratio_count[k]), exp(log_time_ratio[k] / ratio_count[k]));
    return 0;
}

/* Superquadric fit: time per fit and the volumetric IoU reached, on random
   tapered superquadrics (the tests' ranges: e in [0.1, 1.9], sizes 1:5,
   |K| <= 0.6), clean and with 20% uniform outliers (robust mode).
   Targets: 1,000 points <= 2 ms, 6,000 points <= 10 ms (median, one core). */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include "../examples/sqffd_synth.h"
#include "bench.h"
#include <stdio.h>
#include <string.h>

#define SHAPES 11 /* random shapes per row */
#define RUNS 7    /* timed fits per shape */

typedef struct row {
    const char *name;
    size_t n;
    int outliers;
    sqffd_sq_fit_options options;
    int shapes;
} row;

static void run_row(const row *r)
{
    synth_rng rng = synth_rng_seed(2026);
    synth_sq_ranges ranges = synth_sq_ranges_default();
    size_t capacity = r->n + r->n / 4 + 1;
    double *pts = (double *)malloc(3 * capacity * sizeof *pts);
    size_t size;
    void *work;
    double times[SHAPES], ious[SHAPES], per_shape[RUNS], iterations = 0.0;
    int s, k, failures = 0;
    if (sqffd_sq_fit_workspace_size(capacity, &r->options, &size) != SQFFD_OK) {
        printf("| %-6zu | %-22s | workspace size failed |\n", r->n, r->name);
        free(pts);
        return;
    }
    work = malloc(size);
    for (s = 0; s < r->shapes; s++) {
        sqffd_superquadric truth, fit;
        sqffd_sq_fit_report report;
        size_t m;
        synth_superquadric(&rng, &ranges, &truth);
        m = synth_sq_surface(&rng, &truth, r->n, 0.0, pts);
        if (r->outliers) {
            synth_outliers(&rng, pts, m, m / 4, 1.5, pts + 3 * m);
            m += m / 4;
        }
        for (k = 0; k < RUNS; k++) {
            double t0 = bench_now();
            if (sqffd_sq_fit(pts, m, &r->options, &fit, &report, work, size) != SQFFD_OK) failures++;
            per_shape[k] = bench_now() - t0;
        }
        times[s] = bench_median(per_shape, RUNS);
        if (sqffd_sq_iou(&truth, &fit, 64, &ious[s]) != SQFFD_OK) ious[s] = 0.0;
        iterations += report.iterations;
    }
    {
        double median_time = bench_median(times, r->shapes), median_iou = bench_median(ious, r->shapes);
        /* bench_median sorted both: the last time is the slowest shape, the first IoU the worst */
        printf("| %-6zu | %-22s | %9.3f | %9.3f | %10.4f | %8.4f | %6.0f |%s\n", r->n, r->name, 1e3 * median_time,
               1e3 * times[r->shapes - 1], median_iou, ious[0], iterations / r->shapes, failures ? " FAILED FITS" : "");
    }
    free(work);
    free(pts);
}

int main(void)
{
    row rows[7];
    int i, count = 0;
    sqffd_sq_fit_options lm = sqffd_sq_fit_options_default(), robust = lm, cg = lm;
    robust.robust = 1;
    cg.optimizer = SQFFD_SQ_OPTIMIZER_CG;
    rows[count].name = "clean, LM"; rows[count].n = 1000; rows[count].outliers = 0; rows[count].options = lm; rows[count++].shapes = SHAPES;
    rows[count].name = "20% outliers, robust"; rows[count].n = 1000; rows[count].outliers = 1; rows[count].options = robust; rows[count++].shapes = SHAPES;
    rows[count].name = "clean, LM"; rows[count].n = 6000; rows[count].outliers = 0; rows[count].options = lm; rows[count++].shapes = SHAPES;
    rows[count].name = "20% outliers, robust"; rows[count].n = 6000; rows[count].outliers = 1; rows[count].options = robust; rows[count++].shapes = SHAPES;
    rows[count].name = "clean, CG (paper)"; rows[count].n = 1000; rows[count].outliers = 0; rows[count].options = cg; rows[count++].shapes = 5;
    printf("superquadric fit: median over random shapes of the median of %d timed fits each\n", RUNS);
    printf("| points | data, optimiser        | median ms | worst ms  | median IoU | min IoU  | iters  |\n");
    printf("|--------|------------------------|-----------|-----------|------------|----------|--------|\n");
    for (i = 0; i < count; i++) run_row(&rows[i]);
    printf("targets: 1,000 points <= 2 ms, 6,000 points <= 10 ms (median)\n");
    return 0;
}

/* Real hearts: sqffd track on the manual left-ventricle contours of
   ../shared/data/cardiac (pig cine MRI, ED and ES short-axis stacks, see its
   README), default options, against the clinical ejection fraction of the
   same contours (Simpson's method, simpson.csv). The slice spacing is not
   in the data (about 20 contour units): each exam is tracked with the
   stack's z scaled to spacings 15, 20 and 25. At 20 the table adds each
   frame's error, the lattice's Jacobian bound, the share of its mesh's box
   that the mesh folds over (generalised winding number not 0 or 1) and the
   17-segment low-motion count, and the in-plane slice shifts that
   sqffd_stack_shifts finds (breath-hold misregistration; RMS and largest,
   the same at every spacing); the observers' own differences close it. A
   second table tracks the stacks corrected by those shifts (`--slice-shifts`).
   A line counts the default's frames that end at the 100-iteration cap
   and gives the EF with a cap of 1,000.
   Tracked as `sqffd track` does: the stacks found in the points, each
   frame closed by its lids (sqffd_stack_lids: its outer contours filled in
   half a spacing beyond its outer slices), the volumes between its outer
   slices, the closed models' beside them; a line gives the stacks left
   open. A
   second table tracks the same stacks rasterised into thick-slice label
   maps (cavity 3 in a ring of 2; 4-unit pixels, 20-unit slices) through
   their label-3 surface, as `sqffd track --label 3` does. */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include "../examples/sqffd_io.h"
#include "../examples/sqffd_synth.h"
#include "../tests/mesh_check.h"
#include "bench.h"
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include "label_maps.h"

#define CARDIAC_DIR "../shared/data/cardiac"
#define MAX_EXAMS 32
#define FOLD_SAMPLES 1000
#define FOLD_SEED 20261128u

static const double spacings[3] = {15.0, 20.0, 25.0}; /* contour units between slices; the data's z is 20 */

typedef struct exam {
    char name[16], pig[16];
    double simpson[3]; /* obs0_rep0, obs0_rep1, obs1_rep0 (NaN: not contoured) */
} exam;

static int exam_index(exam *exams, int *count, const char *name, const char *pig)
{
    int i;
    for (i = 0; i < *count; i++)
        if (strcmp(exams[i].name, name) == 0) return i;
    if (*count == MAX_EXAMS) return -1;
    memset(&exams[i], 0, sizeof exams[i]);
    snprintf(exams[i].name, sizeof exams[i].name, "%s", name);
    snprintf(exams[i].pig, sizeof exams[i].pig, "%s", pig);
    exams[i].simpson[0] = exams[i].simpson[1] = exams[i].simpson[2] = NAN;
    ++*count;
    return i;
}

/* simpson.csv: exam,pig,observer,ed_area_sum,es_area_sum,simpson_ef_percent */
static int read_simpson(exam *exams)
{
    static const char *const observers[3] = {"obs0_rep0", "obs0_rep1", "obs1_rep0"};
    char line[256], name[16], pig[16], observer[16];
    double ed, es, ef;
    int count = 0, o;
    FILE *f = fopen(CARDIAC_DIR "/simpson.csv", "r");
    if (!f) return 0;
    while (fgets(line, sizeof line, f))
        if (sscanf(line, "%15[^,],%15[^,],%15[^,],%lf,%lf,%lf", name, pig, observer, &ed, &es, &ef) == 6)
            for (o = 0; o < 3; o++)
                if (strcmp(observer, observers[o]) == 0) {
                    int i = exam_index(exams, &count, name, pig);
                    if (i >= 0) exams[i].simpson[o] = ef;
                }
    fclose(f);
    return count;
}

static int read_frame(const char *exam_name, const char *phase, double spacing, double **points, size_t *count)
{
    char path[256], err[256];
    unsigned char *data;
    size_t size, i;
    snprintf(path, sizeof path, CARDIAC_DIR "/%s/obs0_rep0/%s.xyz", exam_name, phase);
    if (sqffd_io_load_file(path, &data, &size, err, sizeof err)) return -1;
    i = (size_t)sqffd_io_read_points(data, size, path, points, count, err, sizeof err);
    free(data);
    if (i) return -1;
    for (i = 0; i < *count; i++) (*points)[3 * i + 2] *= spacing / 20.0;
    return 0;
}

typedef struct result {
    double ef, closed_ef, error[2], jacobian[2], folded[2], ms, shift_rms, shift_max;
    int iterations[2], converged[2];
    int hypokinetic;
} result;

/* The folded share of a model's grid mesh. */
static double folded(const sqffd_model *m)
{
    size_t nv, nt;
    double *v, share = -1.0;
    uint32_t *t;
    if (sqffd_model_mesh_size(m->grid[0], m->grid[1], &nv, &nt) != SQFFD_OK) return -1.0;
    v = (double *)malloc(3 * nv * sizeof *v);
    t = (uint32_t *)malloc(3 * nt * sizeof *t);
    if (v && t && sqffd_model_mesh(m, m->grid[0], m->grid[1], v, t) == SQFFD_OK)
        share = meshcheck_folded_share(v, nv, t, nt, FOLD_SAMPLES, FOLD_SEED);
    free(v);
    free(t);
    return share;
}

/* ED and ES tracked with the defaults (cap > 0: both frames' iterations
   capped at cap instead), their EF with stacks (volumes between the
   slices) where given and closed; measure: the folded shares. */
static int track_pair(double *const points[2], const size_t counts[2], const sqffd_stack *stacks, int measure,
                      int cap, result *out)
{
    sqffd_track_options to = sqffd_track_options_default();
    size_t size = 0, motion_size = 0, done = 0;
    sqffd_model models[2];
    sqffd_fit_report reports[2];
    sqffd_motion_report m, closed;
    sqffd_motion_options mo = sqffd_motion_options_default();
    void *work = NULL, *motion_work = NULL;
    double start = bench_now();
    int k, status = -1;
    memset(out, 0, sizeof *out);
    mo.stacks = stacks;
    if (cap > 0) to.fit.max_iterations = to.frame_iterations = cap;
    if (sqffd_track_workspace_size(counts, 2, &to, &size) != SQFFD_OK || !(work = malloc(size))) goto done;
    if (sqffd_track((const double *const *)points, counts, 2, &to, models, reports, &done, work, size) != SQFFD_OK)
        goto done;
    if (sqffd_motion_workspace_size(models, 2, &motion_size) != SQFFD_OK || !(motion_work = malloc(motion_size)) ||
        sqffd_motion(models, 2, &mo, NULL, &m, motion_work, motion_size) != SQFFD_OK)
        goto done;
    out->ms = 1e3 * (bench_now() - start);
    if (sqffd_motion(models, 2, NULL, NULL, &closed, motion_work, motion_size) != SQFFD_OK) goto done;
    out->ef = 100.0 * m.ejection_fraction;
    out->closed_ef = 100.0 * closed.ejection_fraction;
    for (k = 0; k < 2; k++) {
        out->error[k] = 100.0 * reports[k].error.rms_relative;
        out->jacobian[k] = reports[k].min_jacobian;
        out->iterations[k] = reports[k].iterations;
        out->converged[k] = reports[k].converged;
        out->folded[k] = measure ? folded(&models[k]) : 0.0;
    }
    for (k = 0; k < SQFFD_SEGMENTS; k++) out->hypokinetic += m.segments[k].hypokinetic;
    status = 0;
done:
    free(work);
    free(motion_work);
    return status;
}

enum {
    RUN_LABELS = 1,  /* the stacks rasterised into label maps, their label-3 surface tracked */
    RUN_MEASURE = 2, /* the folded shares measured */
    RUN_SHIFT = 4,   /* the slice shifts found applied first (--slice-shifts) */
    RUN_OPEN = 8     /* the stacks not closed by their lids (--no-lids) */
};

/* An exam's first contouring at a spacing, tracked as `sqffd track` does
   (stacks closed by their lids) but for the flags; the slice shifts found
   (each frame's stack) reported; cap as track_pair's. */
static int run(const exam *e, double spacing, int flags, int cap, result *out)
{
    double *points[2] = {NULL, NULL}, *surface[2] = {NULL, NULL}, rms = 0.0, largest = 0.0;
    size_t counts[2], surface_counts[2], j;
    sqffd_stack stacks[2];
    sqffd_slice_shifts shifts;
    sqffd_points views[2];
    int k, found = 1, status = -1;
    if (read_frame(e->name, "ed", spacing, &points[0], &counts[0]) || read_frame(e->name, "es", spacing, &points[1], &counts[1]))
        goto done;
    if (flags & RUN_LABELS) {
        if (label_map_frames(points, counts, NULL, NULL, spacing, surface, surface_counts, NULL, NULL) == 0)
            status = track_pair(surface, surface_counts, NULL, flags & RUN_MEASURE, cap, out);
        goto done;
    }
    for (k = 0; k < 2 && found; k++)
        if (sqffd_stack_detect_view(views[k] = sqffd_points_packed(points[k], counts[k]), &stacks[k], &found) != SQFFD_OK)
            found = 0;
    if (!found || sqffd_stack_shifts_view(views, stacks, 2, &shifts) != SQFFD_OK) goto done;
    for (j = 0; j < shifts.slices; j++) {
        double s2 = shifts.shift[j][0] * shifts.shift[j][0] + shifts.shift[j][1] * shifts.shift[j][1] +
                    shifts.shift[j][2] * shifts.shift[j][2];
        rms += s2 / (double)shifts.slices;
        if (sqrt(s2) > largest) largest = sqrt(s2);
    }
    for (k = 0; k < 2 && (flags & RUN_SHIFT); k++)
        if (sqffd_stack_shifts_apply(&shifts, points[k], counts[k], NULL) != SQFFD_OK) goto done;
    for (k = 0; k < 2 && !(flags & RUN_OPEN); k++) { /* each frame closed by its lids */
        size_t n = 0;
        if (sqffd_stack_lids_view(views[k], &stacks[k], NULL, 0, &n) != SQFFD_OK ||
            !(surface[k] = (double *)malloc(3 * (counts[k] + n) * sizeof(double))))
            goto done;
        memcpy(surface[k], points[k], 3 * counts[k] * sizeof(double));
        if (sqffd_stack_lids_view(views[k], &stacks[k], surface[k] + 3 * counts[k], n, &n) != SQFFD_OK) goto done;
        surface_counts[k] = counts[k] + n;
    }
    status = flags & RUN_OPEN ? track_pair(points, counts, stacks, flags & RUN_MEASURE, cap, out)
                              : track_pair(surface, surface_counts, stacks, flags & RUN_MEASURE, cap, out);
    out->shift_rms = sqrt(rms);
    out->shift_max = largest;
done:
    for (k = 0; k < 2; k++) {
        free(points[k]);
        free(surface[k]);
    }
    return status;
}

int main(void)
{
    exam exams[MAX_EXAMS];
    struct stat st;
    double sum[3] = {0, 0, 0}, worst[3] = {0, 0, 0}, closed_sum[3] = {0, 0, 0}, obs[2] = {0, 0}, group[2] = {0, 0};
    double ms[MAX_EXAMS], label_sum = 0.0, label_worst = 0.0, error_sum[2] = {0, 0}, shifted[3] = {0, 0, 0};
    double shifted_worst[3] = {0, 0, 0};
    int count, i, s, n = 0, nobs[2] = {0, 0}, ngroup[2] = {0, 0}, fold_free = 1, capped = 0, converged = 0;
    if (stat(CARDIAC_DIR, &st) != 0 || !(count = read_simpson(exams))) {
        printf("(real hearts skipped: %s is absent; the cardiac contours live outside the project, next to it)\n",
               CARDIAC_DIR);
        return 0;
    }
    printf("## Real hearts: EF from `sqffd track` (defaults) against Simpson's EF of the same contours\n\n");
    printf("| exam | pig | Simpson %% | sqffd %% at 15 | at 20 | at 25 | ED / ES error %% | Jacobian bound ED / ES | "
           "folded ED / ES | low-motion segments | slice shifts RMS / max | ms |\n");
    printf("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
    for (i = 0; i < count; i++) {
        result r[3];
        const exam *e = &exams[i];
        if (isnan(e->simpson[0])) continue;
        for (s = 0; s < 3; s++)
            if (run(e, spacings[s], s == 1 ? RUN_MEASURE : 0, 0, &r[s])) break;
        if (s < 3) {
            printf("| %s | %s | failed |\n", e->name, e->pig);
            continue;
        }
        printf("| %s | %s | %.1f |", e->name, e->pig, e->simpson[0]);
        for (s = 0; s < 3; s++) {
            double d = r[s].ef - e->simpson[0];
            printf(" %.1f (%+.1f) |", r[s].ef, d);
            sum[s] += fabs(d);
            if (fabs(d) > worst[s]) worst[s] = fabs(d);
            closed_sum[s] += fabs(r[s].closed_ef - e->simpson[0]);
        }
        printf(" %.2f / %.2f | %.3f / %.3f | %.1f%% / %.1f%% | %d | %.1f / %.1f | %.0f |\n", r[1].error[0],
               r[1].error[1], r[1].jacobian[0], r[1].jacobian[1], 100.0 * r[1].folded[0], 100.0 * r[1].folded[1],
               r[1].hypokinetic, r[1].shift_rms, r[1].shift_max, r[1].ms);
        error_sum[0] += 0.5 * (r[1].error[0] + r[1].error[1]);
        capped += (r[1].iterations[0] == 100) + (r[1].iterations[1] == 100);
        converged += r[1].converged[0] + r[1].converged[1];
        fold_free &= r[1].jacobian[0] > 0.0 && r[1].jacobian[1] > 0.0 && r[1].folded[0] == 0.0 && r[1].folded[1] == 0.0;
        for (s = 1; s < 3; s++)
            if (!isnan(e->simpson[s])) {
                obs[s - 1] += fabs(e->simpson[s] - e->simpson[0]);
                nobs[s - 1]++;
            }
        s = strcmp(e->pig, "c1") == 0 ? 0 : 1; /* control, infarcted */
        group[s] += r[1].hypokinetic;
        ngroup[s]++;
        ms[n++] = r[1].ms;
    }
    if (!n) return 0;
    printf("\nMean absolute difference from Simpson (max): spacing 15: %.2f (%.1f), 20: %.2f (%.1f), 25: %.2f (%.1f) "
           "points; every model fold-free (bound > 0, nothing folded): %s; a two-frame track and its motion: median %.0f ms.\n",
           sum[0] / n, worst[0], sum[1] / n, worst[1], sum[2] / n, worst[2], fold_free ? "yes" : "NO", bench_median(ms, n));
    {
        double long_sum = 0.0, long_worst = 0.0, long_ms[MAX_EXAMS];
        int m = 0, iterations = 0;
        for (i = 0; i < count; i++) {
            result r;
            if (isnan(exams[i].simpson[0]) || run(&exams[i], 20.0, 0, 1000, &r)) continue;
            long_sum += fabs(r.ef - exams[i].simpson[0]);
            if (fabs(r.ef - exams[i].simpson[0]) > long_worst) long_worst = fabs(r.ef - exams[i].simpson[0]);
            iterations += r.iterations[0] + r.iterations[1];
            long_ms[m++] = r.ms;
        }
        if (m)
            printf("At spacing 20, %d of the %d frames stop at the 100-iteration cap (%d converge); with a cap of "
                   "1,000 (%.0f iterations a frame on average) the mean absolute difference is %.2f (max %.1f), a "
                   "track %.0f ms (median).\n", capped, 2 * n, converged, iterations / (2.0 * m), long_sum / m,
                   long_worst, bench_median(long_ms, m));
    }
    {
        double open_sum = 0.0, open_worst = 0.0;
        int m = 0;
        for (i = 0; i < count; i++) {
            result r;
            if (isnan(exams[i].simpson[0]) || run(&exams[i], 20.0, RUN_OPEN, 0, &r)) continue;
            open_sum += fabs(r.ef - exams[i].simpson[0]);
            if (fabs(r.ef - exams[i].simpson[0]) > open_worst) open_worst = fabs(r.ef - exams[i].simpson[0]);
            m++;
        }
        if (m)
            printf("The stacks left open (`--no-lids`): mean absolute difference %.2f (max %.1f) at spacing 20.\n",
                   open_sum / m, open_worst);
    }
    printf("The closed models' volumes instead: mean absolute difference %.2f / %.2f / %.2f points at spacings 15 / 20 "
           "/ 25.\n", closed_sum[0] / n, closed_sum[1] / n, closed_sum[2] / n);
    printf("The contours' own Simpson EF, mean absolute difference from the first contouring: the same observer "
           "again %.2f, a second observer %.2f points.\n",
           nobs[0] ? obs[0] / nobs[0] : 0.0, nobs[1] ? obs[1] / nobs[1] : 0.0);
    printf("Low-motion (hypokinetic) segments of 17, mean per exam: control pig %.1f (%d exams), infarcted pigs %.1f "
           "(%d exams).\n\n",
           ngroup[0] ? group[0] / ngroup[0] : 0.0, ngroup[0], ngroup[1] ? group[1] / ngroup[1] : 0.0, ngroup[1]);
    printf("## The stacks corrected for breath-hold misregistration first (`--slice-shifts`)\n\n");
    printf("| exam | Simpson %% | sqffd %% at 15 | at 20 | at 25 | ED / ES error %% at 20 |\n");
    printf("| --- | --- | --- | --- | --- | --- |\n");
    for (i = 0, n = 0; i < count; i++) {
        result r[3];
        const exam *e = &exams[i];
        if (isnan(e->simpson[0])) continue;
        for (s = 0; s < 3; s++)
            if (run(e, spacings[s], RUN_SHIFT, 0, &r[s])) break;
        if (s < 3) {
            printf("| %s | failed |\n", e->name);
            continue;
        }
        printf("| %s | %.1f |", e->name, e->simpson[0]);
        for (s = 0; s < 3; s++) {
            double d = r[s].ef - e->simpson[0];
            printf(" %.1f (%+.1f) |", r[s].ef, d);
            shifted[s] += fabs(d);
            if (fabs(d) > shifted_worst[s]) shifted_worst[s] = fabs(d);
        }
        printf(" %.2f / %.2f |\n", r[1].error[0], r[1].error[1]);
        error_sum[1] += 0.5 * (r[1].error[0] + r[1].error[1]);
        n++;
    }
    if (n)
        printf("\nCorrected: mean absolute difference from Simpson (max): spacing 15: %.2f (%.1f), 20: %.2f (%.1f), "
               "25: %.2f (%.1f) points; mean frame error at 20: %.3f %% (uncorrected %.3f %%).\n\n",
               shifted[0] / n, shifted_worst[0], shifted[1] / n, shifted_worst[1], shifted[2] / n, shifted_worst[2],
               error_sum[1] / n, error_sum[0] / n);
    printf("## The same stacks as thick-slice label maps, tracked through their label-3 surface (`--label 3`)\n\n");
    printf("| exam | Simpson %% | sqffd %% | difference | ED / ES error %% | Jacobian bound ED / ES |\n");
    printf("| --- | --- | --- | --- | --- | --- |\n");
    for (i = 0, n = 0; i < count; i++) {
        result r;
        const exam *e = &exams[i];
        if (isnan(e->simpson[0])) continue;
        if (run(e, 20.0, RUN_LABELS, 0, &r)) {
            printf("| %s | failed |\n", e->name);
            continue;
        }
        printf("| %s | %.1f | %.1f | %+.1f | %.2f / %.2f | %.3f / %.3f |\n", e->name, e->simpson[0], r.closed_ef,
               r.closed_ef - e->simpson[0], r.error[0], r.error[1], r.jacobian[0], r.jacobian[1]);
        label_sum += fabs(r.closed_ef - e->simpson[0]);
        if (fabs(r.closed_ef - e->simpson[0]) > label_worst) label_worst = fabs(r.closed_ef - e->simpson[0]);
        n++;
    }
    if (n) printf("\nLabel maps: mean absolute difference from Simpson %.2f points (max %.1f).\n\n", label_sum / n, label_worst);
    return 0;
}

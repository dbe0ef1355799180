/* Tracking a beating phantom (examples/sqffd_phantom.h): 16 frames x 6,000
   points, 1% noise. Speed: the whole sequence, frame 0 (the whole fit) and
   the frames after it, medians of repeated runs. Accuracy against the
   phantom's truth (tests/phantom_truth.h) as its parameters vary: the
   hypokinetic zone's position and size, the noise, the number of frames. */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include "../tests/phantom_truth.h"
#include "bench.h"
#include <stdio.h>

#define RUNS 7
#define POINTS 6000

typedef struct clock_frames {
    double start[1024];
    int count;
} clock_frames;

static int stamp(void *user, int stage, int iteration, double error)
{
    clock_frames *c = (clock_frames *)user;
    (void)error;
    if (stage == SQFFD_STAGE_FRAME && iteration < 1024) {
        c->start[iteration] = bench_now();
        c->count = iteration + 1;
    }
    return 0;
}

typedef struct sequence {
    double **points;
    size_t *counts;
    size_t frames;
} sequence;

static int make_sequence(const phantom_lv *p, size_t frames, double noise, sequence *s)
{
    size_t t;
    s->frames = frames;
    s->points = (double **)calloc(frames, sizeof *s->points);
    s->counts = (size_t *)calloc(frames, sizeof *s->counts);
    if (!s->points || !s->counts) return -1;
    for (t = 0; t < frames; t++) {
        s->points[t] = (double *)malloc(3 * POINTS * sizeof(double));
        if (!s->points[t]) return -1;
        s->counts[t] = POINTS;
        phantom_lv_frame(p, (double)t / (double)frames, POINTS, noise, 2026 + t, s->points[t], NULL);
    }
    return 0;
}

static void free_sequence(sequence *s)
{
    size_t t;
    for (t = 0; t < s->frames; t++) free(s->points[t]);
    free(s->points);
    free(s->counts);
}

/* One tracking run: total seconds, frame 0's, the mean of the others'. */
static int track(const sequence *s, const sqffd_track_options *options, sqffd_model *models, double times[3],
                 double *iterations)
{
    sqffd_track_options o = *options;
    sqffd_fit_report *reports = (sqffd_fit_report *)malloc(s->frames * sizeof *reports);
    size_t size, done, t;
    void *work;
    clock_frames c;
    double end;
    sqffd_result r;
    if (sqffd_track_workspace_size(s->counts, s->frames, &o, &size) != SQFFD_OK) {
        free(reports);
        return -1;
    }
    work = malloc(size);
    if (!reports || !work) return -1;
    c.count = 0;
    o.progress = stamp;
    o.progress_user = &c;
    r = sqffd_track((const double *const *)s->points, s->counts, s->frames, &o, models, reports, &done, work, size);
    end = bench_now();
    free(work);
    if (r != SQFFD_OK || c.count != (int)s->frames) {
        free(reports);
        return -1;
    }
    times[0] = end - c.start[0];
    times[1] = c.start[1] - c.start[0];
    times[2] = (end - c.start[1]) / (double)(s->frames - 1);
    *iterations = 0.0;
    for (t = 1; t < s->frames; t++) *iterations += reports[t].iterations;
    *iterations /= (double)(s->frames - 1);
    free(reports);
    return 0;
}

static void speed_row(const char *label, const sequence *s, const sqffd_track_options *o, sqffd_model *models)
{
    double total[RUNS], first[RUNS], later[RUNS], times[3], iterations = 0.0;
    int k;
    for (k = 0; k < RUNS; k++) {
        if (track(s, o, models, times, &iterations)) {
            printf("| %-28s | failed |\n", label);
            return;
        }
        total[k] = times[0];
        first[k] = times[1];
        later[k] = times[2];
    }
    printf("| %-28s | %8.1f | %8.1f | %10.1f | %10.1f |\n", label, 1e3 * bench_median(total, RUNS),
           1e3 * bench_median(first, RUNS), 1e3 * bench_median(later, RUNS), iterations);
}

typedef struct variant {
    const char *label;
    double u, theta, radius; /* the zone (0: the default's) */
    double noise;
    size_t frames;
} variant;

int main(void)
{
    static const variant variants[] = {
        {"default", 0, 0, 0, 0.01, 16},
        {"zone apical (u 0.35)", 0.35, 0, 0, 0.01, 16},
        {"zone basal (u 0.8)", 0.8, 0, 0, 0.01, 16},
        {"zone septal (theta 2.4)", 0, 2.4, 0, 0.01, 16},
        {"zone small (radius 0.25)", 0, 0, 0.25, 0.01, 16},
        {"zone large (radius 0.6)", 0, 0, 0.6, 0.01, 16},
        {"noise 0", 0, 0, 0, 0.0, 16},
        {"noise 2%", 0, 0, 0, 0.02, 16},
        {"8 frames", 0, 0, 0, 0.01, 8},
        {"32 frames", 0, 0, 0, 0.01, 32},
    };
    phantom_lv p = phantom_lv_default();
    sqffd_track_options o = sqffd_track_options_default();
    sqffd_motion_options mo = sqffd_motion_options_default();
    sqffd_model *models = (sqffd_model *)malloc(32 * sizeof *models);
    sequence s;
    size_t v;
    if (!models || make_sequence(&p, 16, 0.01, &s)) return 1;
    printf("## Tracking: 16 frames x %d points, 1%% noise (medians of %d runs)\n\n", POINTS, RUNS);
    printf("| options                      | total ms | frame 0 ms | later frame ms | iterations of a later frame |\n");
    printf("| ---------------------------- | -------- | ---------- | -------------- | --------------------------- |\n");
    speed_row("default (to the tolerance)", &s, &o, models);
    o.frame_iterations = 5;
    speed_row("later frames: at most 5", &s, &o, models);
    o.frame_iterations = 10;
    speed_row("later frames: at most 10", &s, &o, models);
    o = sqffd_track_options_default();
    o.fit.min_jacobian = -HUGE_VAL;
    speed_row("no Jacobian floor", &s, &o, models);
    free_sequence(&s);
    o = sqffd_track_options_default();
    mo.septum_direction[0] = -1.0;
    printf("\n## Tracking accuracy against the phantom's truth (default options, %d points a frame)\n\n", POINTS);
    printf("| phantom                      | zone share | Dice  | excursion / truth | EF %% (true) | segments right |\n");
    printf("| ---------------------------- | ---------- | ----- | ----------------- | ------------ | -------------- |\n");
    for (v = 0; v < sizeof variants / sizeof variants[0]; v++) {
        const variant *x = variants + v;
        phantom_lv q = phantom_lv_default();
        phantom_score score;
        double times[3], iterations;
        int k, right = 0, judged = 0;
        if (x->u > 0.0) q.low_motion[0] = x->u;
        if (x->theta != 0.0) q.low_motion[1] = x->theta;
        if (x->radius > 0.0) q.low_motion[2] = x->radius;
        if (make_sequence(&q, x->frames, x->noise, &s) || track(&s, &o, models, times, &iterations) ||
            phantom_score_track(&q, models, x->frames, &mo, &score)) {
            printf("| %-28s | failed |\n", x->label);
            continue;
        }
        for (k = 0; k < SQFFD_SEGMENTS; k++) /* covered mostly: flagged; barely: not; in between: either */
            if (score.coverage[k] >= 0.6 || score.coverage[k] <= 0.3) {
                judged++;
                right += score.hypokinetic[k] == (score.coverage[k] >= 0.6);
            }
        printf("| %-28s | %9.1f%% | %.3f | %17.3f | %5.1f (%4.1f) | %7d of %2d |\n", x->label,
               100.0 * score.zone_share, score.dice, score.excursion_ratio, 100.0 * score.ef,
               100.0 * score.true_ef, right, judged);
        free_sequence(&s);
    }
    free(models);
    return 0;
}

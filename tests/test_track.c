/* Layer 6: the prepared FFD system, tracking a sequence, and the motion
   analysis (volumes, ejection fraction, low motion, the 17 segments), on the
   beating phantom of examples/sqffd_phantom.h, whose truth is known. */
#include "test.h"
#include "phantom_truth.h"
#include <stdlib.h>
#include <string.h>

/* A phantom sequence: frames point sets of n points, one cycle, noise x scale. */
typedef struct sequence {
    size_t frames, n;
    double **points;
    size_t *counts;
    unsigned char **labels;
} sequence;

static sequence make_sequence(const phantom_lv *p, size_t frames, size_t n, double noise, uint64_t seed)
{
    sequence s;
    size_t t;
    s.frames = frames;
    s.n = n;
    s.points = (double **)test_malloc(frames * sizeof *s.points);
    s.labels = (unsigned char **)test_malloc(frames * sizeof *s.labels);
    s.counts = (size_t *)test_malloc(frames * sizeof *s.counts);
    for (t = 0; t < frames; t++) {
        s.points[t] = (double *)test_malloc(3 * n * sizeof(double));
        s.labels[t] = (unsigned char *)test_malloc(n);
        s.counts[t] = n;
        phantom_lv_frame(p, (double)t / (double)frames, n, noise, seed + t, s.points[t], s.labels[t]);
    }
    return s;
}

static void free_sequence(sequence *s)
{
    size_t t;
    for (t = 0; t < s->frames; t++) {
        free(s->points[t]);
        free(s->labels[t]);
    }
    free(s->points);
    free(s->labels);
    free(s->counts);
}

static sqffd_result run_track(const sequence *s, const sqffd_track_options *o, sqffd_model *models,
                              sqffd_fit_report *reports, size_t *done)
{
    size_t size;
    void *work;
    sqffd_result r = sqffd_track_workspace_size(s->counts, s->frames, o, &size);
    if (r != SQFFD_OK) return r;
    work = test_malloc(size);
    r = sqffd_track((const double *const *)s->points, s->counts, s->frames, o, models, reports, done, work, size);
    free(work);
    return r;
}

static sqffd_result run_motion(const sqffd_model *models, size_t frames, const sqffd_motion_options *o,
                               const sqffd_motion_outputs *out, sqffd_motion_report *rep)
{
    size_t size;
    void *work;
    sqffd_result r = sqffd_motion_workspace_size(models, frames, &size);
    if (r != SQFFD_OK) return r;
    work = test_malloc(size);
    r = sqffd_motion(models, frames, o, out, rep, work, size);
    free(work);
    return r;
}

/* The prepared system gives sqffd_fit_ffd's results to the bit, run after
   run on one system; it refuses a model it was not prepared for and too
   small a memory block. */
static void test_track_prepared_system(void)
{
    enum { N = 3000 };
    phantom_lv p = phantom_lv_default();
    sqffd_fit_options o = sqffd_fit_options_default();
    sqffd_fit_report rep, rep2;
    sqffd_model fitted, a, b;
    sqffd_ffd_system sys;
    double *ed = (double *)test_malloc(3 * N * sizeof *ed), *es = (double *)test_malloc(3 * N * sizeof *es);
    size_t size, ws;
    void *memory, *work;
    int robust, k;
    phantom_lv_frame(&p, 0.0, N, 0.01, 11, ed, NULL);
    phantom_lv_frame(&p, 0.5, N, 0.01, 12, es, NULL);
    CHECK_RESULT(sqffd_fit_workspace_size(N, &o, &ws), SQFFD_OK);
    work = test_malloc(ws);
    CHECK_RESULT(sqffd_fit(ed, N, &o, &fitted, NULL, work, ws), SQFFD_OK);
    free(work);
    CHECK_RESULT(sqffd_ffd_system_size(&fitted, &size), SQFFD_OK);
    CHECK(size > 0);
    memory = test_malloc(size);
    CHECK_RESULT(sqffd_ffd_system_init(&sys, &fitted, &o, memory, size - 1), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
    CHECK_RESULT(sqffd_ffd_system_init(&sys, &fitted, &o, memory, size), SQFFD_OK);
    for (robust = 0; robust < 2; robust++) {
        o.sq.robust = robust;
        for (k = 0; k < 2; k++) { /* the same system twice: it is read-only */
            a = b = fitted;
            CHECK_RESULT(sqffd_fit_ffd_workspace_size(N, &a, &o, &ws), SQFFD_OK);
            work = test_malloc(ws);
            CHECK_RESULT(sqffd_fit_ffd(es, N, &o, &a, &rep, work, ws), SQFFD_OK);
            free(work);
            CHECK_RESULT(sqffd_fit_prepared_workspace_size(N, &sys, &o, &ws), SQFFD_OK);
            work = test_malloc(ws);
            CHECK_RESULT(sqffd_fit_prepared(&sys, es, N, &o, &b, &rep2, work, ws - 1), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
            CHECK_RESULT(sqffd_fit_prepared(&sys, es, N, &o, &b, &rep2, work, ws), SQFFD_OK);
            free(work);
            CHECK_MSG(memcmp(a.ffd.control, b.ffd.control, sizeof a.ffd.control) == 0,
                      "robust %d: prepared control points differ from sqffd_fit_ffd's", robust);
            CHECK(rep.error.rms == rep2.error.rms && rep.iterations == rep2.iterations && rep.energy == rep2.energy);
            CHECK(rep.iterations > 0 && rep.error.rms_relative < 0.5 * rep.sq_error.rms_relative);
        }
    }
    o.sq.robust = 0;
    /* the options' alpha is the system's: changing it in the run changes nothing */
    o.alpha = 1.0;
    b = fitted;
    CHECK_RESULT(sqffd_fit_prepared_workspace_size(N, &sys, &o, &ws), SQFFD_OK);
    work = test_malloc(ws);
    CHECK_RESULT(sqffd_fit_prepared(&sys, es, N, &o, &b, &rep2, work, ws), SQFFD_OK);
    o.alpha = sys.alpha;
    a = fitted;
    CHECK_RESULT(sqffd_fit_prepared(&sys, es, N, NULL, &a, &rep, work, ws), SQFFD_OK);
    CHECK(memcmp(a.ffd.control, b.ffd.control, sizeof a.ffd.control) == 0);
    /* another superquadric, box or grid: refused */
    a = fitted;
    a.sq.center[0] += 1e-9;
    CHECK_RESULT(sqffd_fit_prepared(&sys, es, N, &o, &a, &rep, work, ws), SQFFD_ERROR_INVALID_ARGUMENT);
    a = fitted;
    a.ffd.edges[4] *= 1.5;
    CHECK_RESULT(sqffd_fit_prepared(&sys, es, N, &o, &a, &rep, work, ws), SQFFD_ERROR_INVALID_ARGUMENT);
    a = fitted;
    a.grid[1] += 1;
    CHECK_RESULT(sqffd_fit_prepared(&sys, es, N, &o, &a, &rep, work, ws), SQFFD_ERROR_INVALID_ARGUMENT);
    a = fitted;
    CHECK_RESULT(sqffd_fit_prepared(&sys, es, 3, &o, &a, &rep, work, ws), SQFFD_ERROR_TOO_FEW_POINTS);
    CHECK_RESULT(sqffd_fit_prepared(NULL, es, N, &o, &a, &rep, work, ws), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_ffd_system_init(&sys, NULL, &o, memory, size), SQFFD_ERROR_INVALID_ARGUMENT);
    o.alpha = -1.0;
    CHECK_RESULT(sqffd_ffd_system_init(&sys, &fitted, &o, memory, size), SQFFD_ERROR_INVALID_ARGUMENT);
    free(work);
    free(memory);
    free(ed);
    free(es);
}

/* Cancelling at frame 2 */
static int cancel_at_frame_2(void *user, int stage, int iteration, double error)
{
    int *frames = (int *)user;
    (void)error;
    if (stage == SQFFD_STAGE_FRAME) {
        CHECK(iteration == *frames);
        ++*frames;
        return iteration == 2;
    }
    return 0;
}

/* Bad frames stop the sequence with a clear code at their index; the frames
   before keep their models, the same as a clean run's. */
static void test_track_bad_input(void)
{
    enum { F = 4, N = 1500 };
    phantom_lv p = phantom_lv_default();
    sequence s = make_sequence(&p, F, N, 0.01, 100);
    sqffd_track_options o = sqffd_track_options_default();
    sqffd_model clean[F], models[F];
    sqffd_fit_report reports[F];
    double saved, *keep;
    size_t done = 99, size, bad_size, counts[F];
    void *work;
    int frames = 0, t;
    o.frame_iterations = 5;
    CHECK_RESULT(run_track(&s, &o, clean, reports, &done), SQFFD_OK);
    CHECK(done == F);
    for (t = 1; t < F; t++) /* frame 0's superquadric and box are every frame's */
        CHECK(memcmp(&clean[t].sq, &clean[0].sq, sizeof clean[0].sq) == 0 &&
              memcmp(clean[t].ffd.origin, clean[0].ffd.origin, sizeof clean[0].ffd.origin) == 0);
    /* too few points in frame 2: refused before any frame is fitted, no model written */
    s.counts[2] = 3;
    memset(models, 0xA5, sizeof models);
    CHECK_RESULT(run_track(&s, &o, models, reports, &done), SQFFD_ERROR_TOO_FEW_POINTS);
    CHECK(done == 2);
    for (t = 0; t < (int)sizeof models; t++) CHECK(((const unsigned char *)models)[t] == 0xA5);
    s.counts[2] = N;
    /* NaN in frame 1 */
    saved = s.points[1][7];
    s.points[1][7] = NAN;
    CHECK_RESULT(run_track(&s, &o, models, reports, &done), SQFFD_ERROR_NON_FINITE);
    CHECK(done == 1);
    s.points[1][7] = saved;
    /* every point of frame 3 in one place */
    keep = s.points[3];
    s.points[3] = (double *)test_malloc(3 * N * sizeof(double));
    for (t = 0; t < 3 * N; t++) s.points[3][t] = 1.0;
    CHECK_RESULT(run_track(&s, &o, models, reports, &done), SQFFD_ERROR_DEGENERATE);
    CHECK(done == 3);
    free(s.points[3]);
    s.points[3] = NULL; /* a missing frame */
    CHECK_RESULT(run_track(&s, &o, models, reports, &done), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK(done == 3);
    s.points[3] = keep;
    /* no frames, NULL arrays, bad options, a zero count */
    CHECK_RESULT(sqffd_track_workspace_size(s.counts, F, &o, &size), SQFFD_OK);
    work = test_malloc(size);
    CHECK_RESULT(sqffd_track((const double *const *)s.points, s.counts, 0, &o, models, reports, &done, work, size),
                 SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK(done == 0);
    CHECK_RESULT(sqffd_track(NULL, s.counts, F, &o, models, reports, &done, work, size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_track((const double *const *)s.points, NULL, F, &o, models, reports, &done, work, size),
                 SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_track((const double *const *)s.points, s.counts, F, &o, NULL, reports, &done, work, size),
                 SQFFD_ERROR_INVALID_ARGUMENT);
    o.frame_iterations = -1;
    CHECK_RESULT(sqffd_track((const double *const *)s.points, s.counts, F, &o, models, reports, &done, work, size),
                 SQFFD_ERROR_INVALID_ARGUMENT);
    o.frame_iterations = 5;
    memcpy(counts, s.counts, sizeof counts);
    counts[1] = 0;
    bad_size = 1;
    CHECK_RESULT(sqffd_track_workspace_size(counts, F, &o, &bad_size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK(bad_size == 0);
    bad_size = 1;
    CHECK_RESULT(sqffd_track_workspace_size(s.counts, 0, &o, &bad_size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK(bad_size == 0);
    /* a workspace one byte short: refused before any frame */
    CHECK_RESULT(sqffd_track((const double *const *)s.points, s.counts, F, &o, models, reports, &done, work, size - 1),
                 SQFFD_ERROR_WORKSPACE_TOO_SMALL);
    /* a larger later frame than the workspace was sized for: refused at that frame */
    counts[1] = N / 2;
    memcpy(counts + 2, s.counts + 2, 2 * sizeof *counts);
    counts[0] = N;
    counts[3] = N;
    {
        size_t small, big;
        CHECK_RESULT(sqffd_track_workspace_size(counts, 1, &o, &small), SQFFD_OK); /* frame 0's need only */
        CHECK_RESULT(sqffd_track_workspace_size(s.counts, F, &o, &big), SQFFD_OK);
        CHECK(big >= small);
    }
    /* cancelled at frame 2 by the progress callback */
    o.progress = cancel_at_frame_2;
    o.progress_user = &frames;
    CHECK_RESULT(sqffd_track((const double *const *)s.points, s.counts, F, &o, models, reports, &done, work, size),
                 SQFFD_ERROR_CANCELLED);
    CHECK(done == 2 && frames == 3);
    CHECK(memcmp(models[1].ffd.control, clean[1].ffd.control, sizeof clean[1].ffd.control) == 0);
    free(work);
    free_sequence(&s);
}

/* The same points in every frame: nothing moves (every grid point of every
   frame within 1e-3 of the diagonal of where it is in frame 0) and the
   ejection fraction is 0 (within 0.1%). */
static void test_track_identical_frames(void)
{
    enum { F = 4, N = 6000 };
    phantom_lv p = phantom_lv_default();
    sequence s = make_sequence(&p, 1, N, 0.01, 7);
    double *frames[F];
    size_t counts[F], m, v, done;
    sqffd_track_options o = sqffd_track_options_default();
    sqffd_model models[F];
    sqffd_fit_report reports[F];
    sqffd_motion_outputs out;
    sqffd_motion_report rep;
    double volumes[F], *traj, worst = 0.0, diagonal;
    int t;
    for (t = 0; t < F; t++) {
        frames[t] = s.points[0];
        counts[t] = N;
    }
    {
        size_t size;
        void *work;
        CHECK_RESULT(sqffd_track_workspace_size(counts, F, &o, &size), SQFFD_OK);
        work = test_malloc(size);
        CHECK_RESULT(sqffd_track((const double *const *)frames, counts, F, &o, models, reports, &done, work, size),
                     SQFFD_OK);
        free(work);
    }
    diagonal = reports[0].error.diagonal;
    m = (size_t)models[0].grid[0] * (size_t)models[0].grid[1] + 2;
    traj = (double *)test_malloc(3 * m * F * sizeof *traj);
    memset(&out, 0, sizeof out);
    out.volumes = volumes;
    out.trajectories = traj;
    CHECK_RESULT(run_motion(models, F, NULL, &out, &rep), SQFFD_OK);
    for (t = 1; t < F; t++)
        for (v = 0; v < m; v++) {
            const double *a = traj + 3 * v, *b = traj + 3 * (m * (size_t)t + v);
            double d = sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
            worst = d > worst ? d : worst;
        }
    printf("    identical frames: iterations %d, %d, %d, %d; largest move %.2e of the diagonal, EF %.4f%%\n",
           reports[0].iterations, reports[1].iterations, reports[2].iterations, reports[3].iterations,
           worst / diagonal, 100.0 * rep.ejection_fraction);
    CHECK_MSG(worst <= 1e-3 * diagonal, "a grid point moved %g (diagonal %g)", worst, diagonal);
    CHECK_MSG(fabs(rep.ejection_fraction) <= 1e-3, "EF %g", rep.ejection_fraction);
    free(traj);
    free_sequence(&s);
}

/* Volumes: exact for the grid mesh (a sphere's mesh volume converges to
   4/3 pi r^3 as O(h^2), and does not depend on where it is); trajectories
   are the frames' meshes; the AHA segments fall where their definition puts
   them on a prolate shape with given apex and septum directions. */
static void test_motion_geometry(void)
{
    sqffd_superquadric sq;
    sqffd_fit_options o = sqffd_fit_options_default();
    sqffd_motion_options mo = sqffd_motion_options_default();
    sqffd_motion_outputs out;
    sqffd_motion_report rep;
    sqffd_model models[2];
    double volumes[2], *traj, *mesh, prev_error = HUGE_VAL;
    unsigned char *segment;
    size_t m, v;
    int g, k, hits[SQFFD_SEGMENTS + 1];
    memset(&sq, 0, sizeof sq);
    sq.size[0] = sq.size[1] = sq.size[2] = 2.0;
    sq.shape[0] = sq.shape[1] = 1.0;
    sq.rotation[0] = sq.rotation[4] = sq.rotation[8] = 1.0;
    for (g = 8; g <= 64; g *= 2) { /* a sphere of radius 2: the error falls ~4x per halving of h */
        double exact = 4.0 / 3.0 * 3.14159265358979323846 * 8.0, error;
        o.grid[0] = g;
        o.grid[1] = 2 * g;
        sq.center[0] = 1000.0 * g; /* far from the origin: no difference */
        CHECK_RESULT(sqffd_model_init(&models[0], &sq, &o), SQFFD_OK);
        models[1] = models[0];
        memset(&out, 0, sizeof out);
        out.volumes = volumes;
        CHECK_RESULT(run_motion(models, 2, NULL, &out, &rep), SQFFD_OK);
        error = (exact - volumes[0]) / exact;
        CHECK_MSG(error > 0.0 && error < prev_error / 3.0, "grid %d: relative volume error %g (before %g)", g, error,
                  prev_error);
        CHECK(volumes[0] == volumes[1] && rep.ejection_fraction == 0.0 && rep.edv == volumes[0]);
        prev_error = error;
    }
    CHECK(prev_error < 2e-3);
    /* a prolate shape along z, apex toward -z, septum toward +y: anterior = septum x axis = -x */
    sq.size[0] = sq.size[1] = 2.0;
    sq.size[2] = 5.0;
    sq.center[0] = 0.0;
    o.grid[0] = 40;
    o.grid[1] = 72;
    CHECK_RESULT(sqffd_model_init(&models[0], &sq, &o), SQFFD_OK);
    models[1] = models[0];
    for (k = 0; k < SQFFD_MAX_LATTICE * SQFFD_MAX_LATTICE * SQFFD_MAX_LATTICE; k++) { /* ES: shrunk across the axis */
        models[1].ffd.control[k][0] *= 0.8;
        models[1].ffd.control[k][1] *= 0.8;
    }
    mo.apex_direction[2] = -1.0;
    mo.septum_direction[1] = 1.0;
    mo.septum_direction[2] = 0.3; /* (only the part across the axis counts) */
    m = (size_t)o.grid[0] * (size_t)o.grid[1] + 2;
    traj = (double *)test_malloc(2 * 3 * m * sizeof *traj);
    mesh = (double *)test_malloc(3 * m * sizeof *mesh);
    segment = (unsigned char *)test_malloc(m);
    memset(&out, 0, sizeof out);
    out.volumes = volumes;
    out.trajectories = traj;
    out.segment = segment;
    CHECK_RESULT(run_motion(models, 2, &mo, &out, &rep), SQFFD_OK);
    CHECK(rep.es_frame == 1);
    CHECK_NEAR(rep.ejection_fraction, 1.0 - 0.64, 1e-9); /* a linear map scales volume by its determinant */
    CHECK_NEAR(rep.anterior[0], -1.0, 1e-12);
    CHECK_NEAR(rep.septum[1], 1.0, 1e-12);
    CHECK_NEAR(rep.length, 10.0, 0.02);
    CHECK_RESULT(sqffd_model_mesh(&models[1], o.grid[0], o.grid[1], mesh, NULL), SQFFD_OK);
    CHECK(memcmp(mesh, traj + 3 * m, 3 * m * sizeof *mesh) == 0);
    memset(hits, 0, sizeof hits);
    for (v = 0; v < m; v++) {
        const double *x = traj + 3 * v;
        double f = (x[2] + 5.0) / 10.0, phi = atan2(x[1], -x[0]) * 180.0 / 3.14159265358979323846, g2;
        int expected;
        if (phi < 0.0) phi += 360.0;
        g2 = (f - 0.1) / 0.9;
        /* away from the borders (1 degree, 0.5% of the length): the definition, stated plainly */
        if (fabs(f - 0.1) < 0.005 || fabs(g2 - 1.0 / 3.0) < 0.005 || fabs(g2 - 2.0 / 3.0) < 0.005) continue;
        if (f < 0.1) expected = 17;
        else if (g2 < 1.0 / 3.0) {
            if (fmod(phi + 45.0, 90.0) < 1.0 || fmod(phi + 45.0, 90.0) > 89.0) continue;
            expected = 13 + (int)(fmod(phi + 45.0, 360.0) / 90.0); /* anterior, septal, inferior, lateral */
        } else {
            if (fmod(phi + 30.0, 60.0) < 1.0 || fmod(phi + 30.0, 60.0) > 59.0) continue;
            expected = (g2 < 2.0 / 3.0 ? 7 : 1) + (int)(fmod(phi + 30.0, 360.0) / 60.0);
        }
        if (segment[v] == 0) continue; /* the base cap: checked below */
        CHECK_MSG(segment[v] == expected, "vertex %zu at f %.3f, angle %.1f: segment %d, expected %d", v, f, phi,
                  segment[v], expected);
        hits[segment[v]]++;
    }
    for (k = 1; k <= SQFFD_SEGMENTS; k++) CHECK_MSG(hits[k] > 0, "segment %d has no vertex", k);
    /* the valve plane: only at the base end (f > 1/2), facing the base */
    for (v = 0; v < m; v++)
        if (segment[v] == 0) CHECK(traj[3 * v + 2] > 0.0);
    CHECK(segment[m - 1] == 0 && segment[m - 2] == 17); /* the north pole (base), the south pole (apex) */
    /* automatic axis: the taper makes the +z end narrower, so the apex is there */
    sq.taper[0] = sq.taper[1] = -0.5;
    CHECK_RESULT(sqffd_model_init(&models[0], &sq, &o), SQFFD_OK);
    models[1] = models[0];
    CHECK_RESULT(run_motion(models, 2, NULL, NULL, &rep), SQFFD_OK);
    CHECK_NEAR(rep.axis[2], 1.0, 1e-12);
    /* refused: frames of other superquadrics, an ED frame out of range, a zero septum across the axis */
    models[1].sq.size[0] *= 1.01;
    CHECK_RESULT(run_motion(models, 2, NULL, NULL, &rep), SQFFD_ERROR_INVALID_ARGUMENT);
    models[1] = models[0];
    mo = sqffd_motion_options_default();
    mo.ed_frame = 2;
    CHECK_RESULT(run_motion(models, 2, &mo, NULL, &rep), SQFFD_ERROR_INVALID_ARGUMENT);
    mo.ed_frame = 0;
    mo.apex_direction[2] = 1.0;
    mo.septum_direction[2] = -2.0;
    CHECK_RESULT(run_motion(models, 2, &mo, NULL, &rep), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_motion(models, 2, NULL, NULL, &rep, mesh, 16), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
    CHECK_RESULT(run_motion(NULL, 2, NULL, NULL, &rep), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_motion(NULL, 2, NULL, NULL, &rep, mesh, 16), SQFFD_ERROR_INVALID_ARGUMENT);
    free(traj);
    free(mesh);
    free(segment);
}

/* The bench's phantom: 16 frames x 6,000 points, 1% noise, a zone of ~15%
   of the wall at 20% of normal motion. The flagged surface overlaps the
   true zone (area-weighted Dice >= 0.8); segments the zone covers for the
   most part are flagged and those it barely touches are not; the inward
   excursion of the normal wall is within 10% of the truth's; the ejection
   fraction within 2 percentage points of the true one. */
static void test_track_phantom(void)
{
    enum { F = 16, N = 6000 };
    phantom_lv p = phantom_lv_default();
    sequence s = make_sequence(&p, F, N, 0.01, 2026);
    sqffd_track_options o = sqffd_track_options_default();
    sqffd_motion_options mo = sqffd_motion_options_default();
    sqffd_model *models = (sqffd_model *)test_malloc(F * sizeof *models);
    sqffd_fit_report reports[F];
    phantom_score score;
    size_t done;
    int k, flagged = 0;
    CHECK_RESULT(run_track(&s, &o, models, reports, &done), SQFFD_OK);
    mo.septum_direction[0] = -1.0; /* the phantom's convention */
    CHECK(phantom_score_track(&p, models, F, &mo, &score) == 0);
    printf("    phantom: Dice %.3f, excursion %.3f and displacement %.3f of the truth's, EF %.2f%% (true %.2f%%)\n",
           score.dice, score.excursion_ratio, score.displacement_ratio, 100.0 * score.ef, 100.0 * score.true_ef);
    CHECK_MSG(score.dice >= 0.8, "Dice %g", score.dice);
    CHECK_MSG(fabs(score.excursion_ratio - 1.0) <= 0.1, "normal wall excursion %g of the truth's", score.excursion_ratio);
    CHECK_MSG(fabs(score.ef_error) <= 0.02, "EF %g, true %g", score.ef, score.true_ef);
    /* (a valve-plane vertex at the rim, where the mesh rounds the corner, may
       fall either side of the 45-degree rule: 9 of 395 with the grid's rows
       at equal steps of arc length, which puts some on the rounded rim) */
    CHECK_MSG(score.lid_in_wall * 25 <= score.lid_vertices, "%d of %d lid vertices in the wall", score.lid_in_wall,
              score.lid_vertices);
    for (k = 0; k < SQFFD_SEGMENTS; k++) {
        if (score.coverage[k] >= 0.6)
            CHECK_MSG(score.hypokinetic[k], "segment %d: %.0f%% in the zone, not flagged", k + 1, 100.0 * score.coverage[k]);
        if (score.coverage[k] <= 0.3)
            CHECK_MSG(!score.hypokinetic[k], "segment %d: %.0f%% in the zone, flagged", k + 1, 100.0 * score.coverage[k]);
        flagged += score.hypokinetic[k];
    }
    CHECK(flagged > 0);
    free(models);
    free_sequence(&s);
}

/* A stream, one frame at a time (sqffd_fit, the system, then
   sqffd_track_frame or sqffd_track_frame_view per later frame), makes
   sqffd_track's models and reports to the bit; its workspace is sized
   without a system. */
static void test_track_frame_stream(void)
{
    enum { FRAMES = 4, N = 1500 };
    phantom_lv p = phantom_lv_default();
    sequence s = make_sequence(&p, FRAMES, N, 0.01, 70);
    sqffd_track_options opt = sqffd_track_options_default();
    sqffd_model tracked[FRAMES], streamed, other;
    sqffd_fit_report reports[FRAMES], rep;
    sqffd_ffd_system sys;
    size_t size = 0, frame_size = 0, sys_size = 0, done = 0, t;
    void *work, *frame_work, *memory;
    opt.fit.max_iterations = 20;
    opt.frame_iterations = 6;
    CHECK_RESULT(sqffd_track_workspace_size(s.counts, FRAMES, &opt, &size), SQFFD_OK);
    work = test_malloc(size);
    CHECK_RESULT(sqffd_track((const double *const *)s.points, s.counts, FRAMES, &opt, tracked, reports, &done, work,
                             size), SQFFD_OK);
    CHECK(done == FRAMES);
    free(work);

    CHECK_RESULT(sqffd_fit_workspace_size(N, &opt.fit, &size), SQFFD_OK);
    work = test_malloc(size);
    CHECK_RESULT(sqffd_fit(s.points[0], N, &opt.fit, &streamed, &rep, work, size), SQFFD_OK);
    free(work);
    CHECK(memcmp(&streamed, &tracked[0], sizeof streamed) == 0);
    CHECK_RESULT(sqffd_ffd_system_size(&streamed, &sys_size), SQFFD_OK);
    memory = test_malloc(sys_size);
    CHECK_RESULT(sqffd_ffd_system_init(&sys, &streamed, &opt.fit, memory, sys_size), SQFFD_OK);
    CHECK_RESULT(sqffd_track_frame_workspace_size(N, &opt, &frame_size), SQFFD_OK);
    frame_work = test_malloc(frame_size);
    for (t = 1; t < FRAMES; t++) {
        sqffd_points frame = sqffd_points_packed(s.points[t], N);
        other = streamed;
        CHECK_RESULT(sqffd_track_frame_view(&sys, frame, &opt, &other, &rep, frame_work, frame_size - 1),
                     SQFFD_ERROR_WORKSPACE_TOO_SMALL);
        CHECK_RESULT(sqffd_track_frame(&sys, s.points[t], N, &opt, &other, &rep, frame_work, frame_size - 1),
                     SQFFD_ERROR_WORKSPACE_TOO_SMALL);
        CHECK(memcmp(&other, &streamed, sizeof other) == 0);
        if (t % 2) /* the packed form and the view alternate */
            CHECK_RESULT(sqffd_track_frame(&sys, s.points[t], N, &opt, &streamed, &rep, frame_work, frame_size),
                         SQFFD_OK);
        else
            CHECK_RESULT(sqffd_track_frame_view(&sys, frame, &opt, &streamed, &rep, frame_work, frame_size), SQFFD_OK);
        CHECK_MSG(memcmp(&streamed.ffd.control, &tracked[t].ffd.control, sizeof streamed.ffd.control) == 0,
                  "frame %zu: streamed control points differ from sqffd_track's", t);
        CHECK(rep.error.rms == reports[t].error.rms && rep.iterations == reports[t].iterations);
        CHECK(rep.iterations <= opt.frame_iterations);
    }
    /* a model of another box is refused; a negative cap too */
    other = streamed;
    other.ffd.origin[1] += 1e-6;
    CHECK_RESULT(sqffd_track_frame(&sys, s.points[1], N, &opt, &other, NULL, frame_work, frame_size),
                 SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_track_frame(&sys, NULL, N, &opt, &streamed, NULL, frame_work, frame_size),
                 SQFFD_ERROR_INVALID_ARGUMENT);
    opt.frame_iterations = -1;
    CHECK_RESULT(sqffd_track_frame_workspace_size(N, &opt, &frame_size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_track_frame_view(&sys, sqffd_points_packed(s.points[1], N), &opt, &streamed, NULL, frame_work,
                                        frame_size), SQFFD_ERROR_INVALID_ARGUMENT);
    free(frame_work);
    free(memory);
    free_sequence(&s);
}

/* Every frame meets a lone fit's checks, whatever its place in the
   sequence: 12 points are too few and 13 enough in frame 0 and in a later
   frame alike (the later frames were held to 4 before); a flat, a
   collinear and a coincident later frame are refused before any fit; the
   stream's frames likewise. */
static void test_track_frame_checks(void)
{
    enum { F = 3, N = 600 };
    phantom_lv p = phantom_lv_default();
    sequence s = make_sequence(&p, F, N, 0.0, 300);
    sqffd_track_options o = sqffd_track_options_default();
    sqffd_model models[F];
    sqffd_fit_report reports[F];
    sqffd_ffd_system sys;
    double *keep = s.points[2], *bad = (double *)test_malloc(3 * N * sizeof(double));
    size_t done = 99, t, i, size = 0;
    void *memory, *work;
    int shape;
    o.fit.max_iterations = 5;
    o.frame_iterations = 3;
    for (t = 0; t < F; t++) { /* 12 points in one frame, then 13 */
        s.counts[t] = SQFFD_SQ_FIT_MIN_POINTS - 1;
        CHECK_RESULT(sqffd_fit_check_data(s.points[t], s.counts[t]), SQFFD_ERROR_TOO_FEW_POINTS);
        CHECK_RESULT(run_track(&s, &o, models, reports, &done), SQFFD_ERROR_TOO_FEW_POINTS);
        CHECK_MSG(done == t, "frame %zu of 12 points: done %zu", t, done);
        s.counts[t] = SQFFD_SQ_FIT_MIN_POINTS;
        CHECK_RESULT(sqffd_fit_check_data(s.points[t], s.counts[t]), SQFFD_OK);
        CHECK_RESULT(run_track(&s, &o, models, reports, &done), SQFFD_OK);
        s.counts[t] = N;
    }
    s.counts[2] = 4; /* what the later frames took before */
    CHECK_RESULT(run_track(&s, &o, models, reports, &done), SQFFD_ERROR_TOO_FEW_POINTS);
    s.counts[2] = N;
    for (shape = 0; shape < 3; shape++) { /* frame 2 flat (z = 0), on a line (the z axis), in one place */
        for (i = 0; i < 3 * N; i++) bad[i] = keep[i] * (i % 3 == 2 ? shape != 0 : shape == 0);
        for (i = 0; shape == 2 && i < 3 * N; i++) bad[i] = 1.5;
        s.points[2] = bad;
        CHECK_RESULT(sqffd_fit_check_data(bad, N), SQFFD_ERROR_DEGENERATE);
        CHECK_RESULT(run_track(&s, &o, models, reports, &done), SQFFD_ERROR_DEGENERATE);
        CHECK_MSG(done == 2, "shape %d: done %zu", shape, done);
        s.points[2] = keep;
    }
    bad[4] = INFINITY;
    CHECK_RESULT(sqffd_fit_check_data(bad, N), SQFFD_ERROR_NON_FINITE);
    CHECK_RESULT(sqffd_fit_check_data(NULL, N), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_fit_check_data_view(sqffd_points_packed(keep, N)), SQFFD_OK);
    /* the stream: a flat frame and a 12-point one refused before the workspace is looked at */
    CHECK_RESULT(run_track(&s, &o, models, reports, &done), SQFFD_OK);
    CHECK_RESULT(sqffd_ffd_system_size(models, &size), SQFFD_OK);
    memory = test_malloc(size);
    CHECK_RESULT(sqffd_ffd_system_init(&sys, models, &o.fit, memory, size), SQFFD_OK);
    for (i = 0; i < 3 * N; i++) bad[i] = keep[i] * (i % 3 != 2);
    work = test_malloc(1);
    CHECK_RESULT(sqffd_track_frame(&sys, bad, N, &o, models + 1, NULL, work, 1), SQFFD_ERROR_DEGENERATE);
    CHECK_RESULT(sqffd_track_frame(&sys, keep, SQFFD_SQ_FIT_MIN_POINTS - 1, &o, models + 1, NULL, work, 1),
                 SQFFD_ERROR_TOO_FEW_POINTS);
    CHECK_RESULT(sqffd_track_frame(&sys, keep, N, &o, models + 1, NULL, work, 1), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
    free(work);
    free(memory);
    free(bad);
    free_sequence(&s);
}

void suite_track(void)
{
    RUN_TEST(test_track_frame_checks);
    RUN_TEST(test_track_prepared_system);
    RUN_TEST(test_track_frame_stream);
    RUN_TEST(test_track_bad_input);
    RUN_TEST(test_track_identical_frames);
    RUN_TEST(test_track_phantom);
    RUN_TEST(test_motion_geometry);
}

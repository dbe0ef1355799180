/* The C side of tests/python/test_sqffd.py: the same calls the Python module
   makes, made from C against the same build/libsqffd.so, so the test can
   compare the results byte for byte.

   reference phantom DIR FRAMES POINTS
       the beating phantom (examples/sqffd_phantom.h, 1% noise) at FRAMES
       phases into DIR/frame_NN.f64 (POINTS x y z doubles, native order),
       its epicardium's into DIR/epi_frame_NN.f64 and its true myocardial
       volume at each phase into DIR/myocardium.f64 (FRAMES doubles)
   reference fit POINTS.f64 OUT [NAME=VALUE ...]
       sqffd_fit with the defaults changed by NAME=VALUE (sqffd_fit_options
       field names: lattice=L,M,N, grid=E,O, sq.robust=1, alpha=1e-4 ...;
       numbers only) into OUT.model (sqffd_model_save) and OUT.report
   reference track OUT FRAME.f64 ...
       sqffd_track with the defaults into OUT_NN.model and OUT_NN.report,
       then sqffd_motion (septum toward -x, as the phantom's) into
       OUT.motion and the arrays OUT.volumes, .trajectories, .displacement,
       .excursion (doubles), .low_motion and .segment (bytes)
   reference contours DIR
       the phantom's ED and ES short-axis stacks (8 slices, shifted in-plane
       by up to 2 mm) into DIR/contours_ed.f64 and DIR/contours_es.f64
   reference stack OUT FRAME.f64 ...
       each frame's sqffd_stack_detect, sqffd_stack_shifts into OUT.shifts
       (x y z doubles a slice), applied to every frame, each frame's
       sqffd_stack_lids into OUT_NN.lids, then `track` of the frames with
       their lids and sqffd_motion with the stacks
   A .report or .motion file has one "NAME VALUE" line per number of the
   report (%.17g, so it reads back exactly), named by the struct's fields
   (nested with '.', array elements by index). */
#include "../../sqffd.h"
#include "../../examples/sqffd_phantom.h"
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int fail(const char *what, const char *why)
{
    fprintf(stderr, "reference: %s: %s\n", what, why);
    return 1;
}

static int write_file(const char *path, const void *data, size_t size)
{
    FILE *f = fopen(path, "wb");
    int ok = f && fwrite(data, 1, size, f) == size;
    if (f && fclose(f) != 0) ok = 0;
    if (!ok) fail(path, strerror(errno));
    return ok;
}

/* x y z doubles of a .f64 file; *n points. NULL on failure (message printed). */
static double *read_points(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    long size;
    double *points = NULL;
    if (!f || fseek(f, 0, SEEK_END) != 0 || (size = ftell(f)) < 0 || fseek(f, 0, SEEK_SET) != 0) {
        fail(path, strerror(errno));
    } else if (size % (long)(3 * sizeof(double)) != 0) {
        fail(path, "not a whole number of x y z doubles");
    } else {
        *n = (size_t)size / (3 * sizeof(double));
        points = (double *)malloc((size_t)size + 1);
        if (!points || fread(points, 1, (size_t)size, f) != (size_t)size) {
            fail(path, "cannot read");
            free(points);
            points = NULL;
        }
    }
    if (f) fclose(f);
    return points;
}

static void put(FILE *f, const char *prefix, const char *name, double value)
{
    fprintf(f, "%s%s %.17g\n", prefix, name, value);
}

static void put_array(FILE *f, const char *prefix, const char *name, const double *values, int count)
{
    int i;
    for (i = 0; i < count; i++) fprintf(f, "%s%s.%d %.17g\n", prefix, name, i, values[i]);
}

static void put_stats(FILE *f, const char *prefix, const sqffd_distance_stats *s)
{
    put(f, prefix, "rms", s->rms);
    put(f, prefix, "mean", s->mean);
    put(f, prefix, "max", s->max);
    put(f, prefix, "diagonal", s->diagonal);
    put(f, prefix, "rms_relative", s->rms_relative);
    put(f, prefix, "mean_relative", s->mean_relative);
    put(f, prefix, "max_relative", s->max_relative);
}

static int write_report(const char *path, const sqffd_fit_report *r)
{
    FILE *f = fopen(path, "w");
    const sqffd_superquadric *b = &r->sq.best_start;
    if (!f) {
        fail(path, strerror(errno));
        return 0;
    }
    put(f, "sq.", "iterations", r->sq.iterations);
    put(f, "sq.", "cost", r->sq.cost);
    put(f, "sq.", "rms_radial", r->sq.rms_radial);
    put(f, "sq.", "start", r->sq.start);
    put(f, "sq.", "converged", r->sq.converged);
    put(f, "sq.", "inlier_fraction", r->sq.inlier_fraction);
    put_array(f, "sq.best_start.", "size", b->size, 3);
    put_array(f, "sq.best_start.", "shape", b->shape, 2);
    put_array(f, "sq.best_start.", "taper", b->taper, 2);
    put_array(f, "sq.best_start.", "rotation", b->rotation, 9);
    put_array(f, "sq.best_start.", "center", b->center, 3);
    put(f, "sq.", "fallback", r->sq.fallback);
    put_stats(f, "sq_error.", &r->sq_error);
    put_stats(f, "error.", &r->error);
    put(f, "", "coarse_iterations", r->coarse_iterations);
    put(f, "", "iterations", r->iterations);
    put(f, "", "converged", r->converged);
    put(f, "", "step", r->step);
    put_array(f, "", "history", r->history, r->history_count);
    put(f, "", "energy", r->energy);
    put_array(f, "", "energy_history", r->energy_history, r->history_count);
    put(f, "", "min_jacobian", r->min_jacobian);
    put(f, "", "stop", r->stop);
    if (fclose(f) != 0) {
        fail(path, strerror(errno));
        return 0;
    }
    return 1;
}

static int write_motion_report(const char *path, const sqffd_motion_report *m)
{
    FILE *f = fopen(path, "w");
    int k;
    if (!f) {
        fail(path, strerror(errno));
        return 0;
    }
    put(f, "", "ed_frame", (double)m->ed_frame);
    put(f, "", "es_frame", (double)m->es_frame);
    put(f, "", "edv", m->edv);
    put(f, "", "esv", m->esv);
    put(f, "", "ejection_fraction", m->ejection_fraction);
    put_array(f, "", "axis", m->axis, 3);
    put_array(f, "", "apex", m->apex, 3);
    put(f, "", "length", m->length);
    put_array(f, "", "anterior", m->anterior, 3);
    put_array(f, "", "septum", m->septum, 3);
    put(f, "", "apex_fraction", m->apex_fraction);
    put(f, "", "median_excursion", m->median_excursion);
    for (k = 0; k < SQFFD_SEGMENTS; k++) {
        char prefix[32];
        snprintf(prefix, sizeof prefix, "segments.%d.", k);
        put(f, prefix, "area", m->segments[k].area);
        put(f, prefix, "mean_displacement", m->segments[k].mean_displacement);
        put(f, prefix, "mean_excursion", m->segments[k].mean_excursion);
        put(f, prefix, "low_motion_share", m->segments[k].low_motion_share);
        put(f, prefix, "hypokinetic", m->segments[k].hypokinetic);
    }
    if (fclose(f) != 0) {
        fail(path, strerror(errno));
        return 0;
    }
    return 1;
}

static int write_model(const char *path, const sqffd_model *model)
{
    unsigned char bytes[32768];
    size_t size;
    sqffd_result r = sqffd_model_save_size(model, &size);
    if (r == SQFFD_OK) r = sqffd_model_save(model, bytes, sizeof bytes);
    if (r != SQFFD_OK) {
        fail(path, sqffd_result_string(r));
        return 0;
    }
    return write_file(path, bytes, size);
}

/* Comma-separated integers into values[count]; 1 on success. */
static int parse_ints(const char *text, int *values, int count)
{
    int i;
    for (i = 0; i < count; i++) {
        char *end;
        long v = strtol(text, &end, 10);
        if (end == text || (i + 1 < count ? *end != ',' : *end != '\0')) return 0;
        values[i] = (int)v;
        text = end + 1;
    }
    return 1;
}

/* One NAME=VALUE setting of sqffd_fit_options; 1 on success. */
static int set_option(sqffd_fit_options *o, const char *setting)
{
    const char *eq = strchr(setting, '=');
    const char *value = eq ? eq + 1 : "";
    size_t len = eq ? (size_t)(eq - setting) : 0;
    char *end;
    double number = strtod(value, &end);
    int numeric = end != value && *end == '\0';
#define NAME_IS(name) (len == strlen(name) && strncmp(setting, name, len) == 0)
    if (NAME_IS("lattice")) return parse_ints(value, o->lattice, 3);
    if (NAME_IS("grid")) return parse_ints(value, o->grid, 2);
    if (!numeric) return 0;
    if (NAME_IS("alpha")) o->alpha = number;
    else if (NAME_IS("tether")) o->tether = number;
    else if (NAME_IS("box_margin")) o->box_margin = number;
    else if (NAME_IS("model_to_data")) o->model_to_data = number;
    else if (NAME_IS("min_jacobian")) o->min_jacobian = number;
    else if (NAME_IS("tolerance")) o->tolerance = number;
    else if (NAME_IS("max_iterations")) o->max_iterations = (int)number;
    else if (NAME_IS("coarse_iterations")) o->coarse_iterations = (int)number;
    else if (NAME_IS("regularization")) o->regularization = (sqffd_regularization)(int)number;
    else if (NAME_IS("solver")) o->solver = (sqffd_solver)(int)number;
    else if (NAME_IS("sq_max_points")) o->sq_max_points = (size_t)number;
    else if (NAME_IS("ffd_max_points")) o->ffd_max_points = (size_t)number;
    else if (NAME_IS("sq.robust")) o->sq.robust = (int)number;
    else if (NAME_IS("sq.taper")) o->sq.taper = (int)number;
    else if (NAME_IS("sq.cost")) o->sq.cost = (sqffd_sq_cost)(int)number;
    else if (NAME_IS("sq.max_iterations")) o->sq.max_iterations = (int)number;
    else return 0;
#undef NAME_IS
    return 1;
}

static int with_suffix(char *path, size_t size, const char *prefix, const char *suffix)
{
    return snprintf(path, size, "%s%s", prefix, suffix) < (int)size;
}

static int cmd_phantom(int argc, char **argv)
{
    phantom_lv p = phantom_lv_default(), outer = p;
    int frames, t;
    size_t n;
    double *points, myocardium[1024];
    char path[4096];
    if (argc != 5) return fail("phantom", "usage: reference phantom DIR FRAMES POINTS");
    frames = atoi(argv[3]);
    n = (size_t)strtoul(argv[4], NULL, 10);
    if (frames < 1 || frames > 1024 || n < 1) return fail("phantom", "FRAMES (at most 1024) and POINTS must be positive");
    outer.epicardium = 1;
    points = (double *)malloc(3 * n * sizeof *points);
    if (!points) return fail("phantom", "out of memory");
    for (t = 0; t < 2 * frames; t++) { /* the cavity's frames, then the epicardium's */
        phantom_lv_frame(t < frames ? &p : &outer, (double)(t % frames) / frames, n, 0.01, 2026u + (uint64_t)t, points,
                         NULL);
        snprintf(path, sizeof path, "%s/%sframe_%02d.f64", argv[2], t < frames ? "" : "epi_", t % frames);
        if (!write_file(path, points, 3 * n * sizeof *points)) {
            free(points);
            return 1;
        }
        if (t < frames) myocardium[t] = phantom_lv_myocardium(&p, (double)t / frames);
    }
    free(points);
    snprintf(path, sizeof path, "%s/myocardium.f64", argv[2]);
    return write_file(path, myocardium, (size_t)frames * sizeof *myocardium) ? 0 : 1;
}

static int cmd_fit(int argc, char **argv)
{
    sqffd_fit_options o = sqffd_fit_options_default();
    sqffd_model model;
    sqffd_fit_report report;
    size_t n = 0, size = 0;
    double *points;
    void *ws = NULL;
    sqffd_result r;
    char path[4096];
    int i, ok;
    if (argc < 4) return fail("fit", "usage: reference fit POINTS.f64 OUT [NAME=VALUE ...]");
    for (i = 4; i < argc; i++)
        if (!set_option(&o, argv[i])) return fail(argv[i], "not an option this program sets");
    if (!(points = read_points(argv[2], &n))) return 1;
    r = sqffd_fit_workspace_size(n, &o, &size);
    if (r == SQFFD_OK && !(ws = malloc(size))) r = SQFFD_ERROR_TOO_LARGE;
    if (r == SQFFD_OK) r = sqffd_fit(points, n, &o, &model, &report, ws, size);
    free(ws);
    free(points);
    if (r != SQFFD_OK) return fail("fit", sqffd_result_string(r));
    ok = with_suffix(path, sizeof path, argv[3], ".model") && write_model(path, &model)
      && with_suffix(path, sizeof path, argv[3], ".report") && write_report(path, &report);
    return ok ? 0 : 1;
}

/* sqffd_track of the frames with the defaults, then sqffd_motion (septum
   toward -x, stacks: volumes between them, or NULL), written as
   `reference track` describes. */
static int track_and_write(const char *out_prefix, const double **points, const size_t *counts, size_t frames,
                           const sqffd_stack *stacks)
{
    size_t t, size = 0, vertices = 0, done = 0;
    sqffd_model *models = (sqffd_model *)malloc(frames * sizeof *models);
    sqffd_fit_report *reports = (sqffd_fit_report *)malloc(frames * sizeof *reports);
    sqffd_motion_options mopt = sqffd_motion_options_default();
    sqffd_motion_report motion;
    sqffd_motion_outputs out = {NULL, NULL, NULL, NULL, NULL, NULL};
    void *ws = NULL;
    sqffd_result r = models && reports ? SQFFD_OK : SQFFD_ERROR_TOO_LARGE;
    char path[4096];
    int ok = 0;
    if (r == SQFFD_OK) r = sqffd_track_workspace_size(counts, frames, NULL, &size);
    if (r == SQFFD_OK && !(ws = malloc(size))) r = SQFFD_ERROR_TOO_LARGE;
    if (r == SQFFD_OK) r = sqffd_track(points, counts, frames, NULL, models, reports, &done, ws, size);
    free(ws);
    ws = NULL;
    if (r == SQFFD_OK) r = sqffd_model_mesh_size(models[0].grid[0], models[0].grid[1], &vertices, NULL);
    if (r == SQFFD_OK) r = sqffd_motion_workspace_size(models, frames, &size);
    if (r == SQFFD_OK) {
        ws = malloc(size);
        out.volumes = (double *)malloc(frames * sizeof(double));
        out.trajectories = (double *)malloc(frames * vertices * 3 * sizeof(double));
        out.displacement = (double *)malloc(vertices * sizeof(double));
        out.excursion = (double *)malloc(vertices * sizeof(double));
        out.low_motion = (unsigned char *)malloc(vertices);
        out.segment = (unsigned char *)malloc(vertices);
        if (!ws || !out.volumes || !out.trajectories || !out.displacement || !out.excursion || !out.low_motion
            || !out.segment)
            r = SQFFD_ERROR_TOO_LARGE;
    }
    mopt.septum_direction[0] = -1.0;
    mopt.stacks = stacks;
    if (r == SQFFD_OK) r = sqffd_motion(models, frames, &mopt, &out, &motion, ws, size);
    if (r != SQFFD_OK) {
        fail("track", sqffd_result_string(r));
    } else {
        ok = 1;
        for (t = 0; ok && t < frames; t++) {
            char suffix[32];
            snprintf(suffix, sizeof suffix, "_%02d.model", (int)t);
            ok = with_suffix(path, sizeof path, out_prefix, suffix) && write_model(path, &models[t]);
            snprintf(suffix, sizeof suffix, "_%02d.report", (int)t);
            ok = ok && with_suffix(path, sizeof path, out_prefix, suffix) && write_report(path, &reports[t]);
        }
        ok = ok && with_suffix(path, sizeof path, out_prefix, ".motion") && write_motion_report(path, &motion);
        ok = ok && with_suffix(path, sizeof path, out_prefix, ".volumes") && write_file(path, out.volumes, frames * sizeof(double));
        ok = ok && with_suffix(path, sizeof path, out_prefix, ".trajectories")
          && write_file(path, out.trajectories, frames * vertices * 3 * sizeof(double));
        ok = ok && with_suffix(path, sizeof path, out_prefix, ".displacement")
          && write_file(path, out.displacement, vertices * sizeof(double));
        ok = ok && with_suffix(path, sizeof path, out_prefix, ".excursion") && write_file(path, out.excursion, vertices * sizeof(double));
        ok = ok && with_suffix(path, sizeof path, out_prefix, ".low_motion") && write_file(path, out.low_motion, vertices);
        ok = ok && with_suffix(path, sizeof path, out_prefix, ".segment") && write_file(path, out.segment, vertices);
    }
    free(models);
    free(reports);
    free(ws);
    free(out.volumes);
    free(out.trajectories);
    free(out.displacement);
    free(out.excursion);
    free(out.low_motion);
    free(out.segment);
    return ok ? 0 : 1;
}

static int cmd_track(int argc, char **argv)
{
    size_t frames = argc > 3 ? (size_t)(argc - 3) : 0, t;
    const double **points;
    size_t *counts;
    int status = 1;
    if (frames == 0) return fail("track", "usage: reference track OUT FRAME.f64 ...");
    points = (const double **)calloc(frames, sizeof *points);
    counts = (size_t *)calloc(frames, sizeof *counts);
    if (points && counts) {
        for (t = 0; t < frames; t++)
            if (!(points[t] = read_points(argv[3 + t], &counts[t]))) break;
        if (t == frames) status = track_and_write(argv[2], points, counts, frames, NULL);
    }
    for (t = 0; points && t < frames; t++) free((void *)points[t]);
    free(points);
    free(counts);
    return status;
}

/* The phantom's ED and ES short-axis stacks: 8 slices 7 mm apart from 3 mm
   above the ED apex, 96 points each, every slice shifted in-plane by up to
   +-2 mm (the same shifts in both frames, as breath-holds give them). */
static int cmd_contours(int argc, char **argv)
{
    phantom_lv p = phantom_lv_default();
    double levels[8], shifts[16], points[8 * 96 * 3];
    uint64_t state = 2026u;
    int k;
    if (argc != 3) return fail("contours", "usage: reference contours DIR");
    for (k = 0; k < 8; k++) levels[k] = -p.height + 3.0 + 7.0 * k;
    for (k = 0; k < 16; k++) shifts[k] = 4.0 * phantom__uniform(&state) - 2.0;
    for (k = 0; k < 2; k++) {
        char path[4096];
        size_t n = phantom_lv_contours(&p, 0.5 * k, levels, 8, 96, shifts, points);
        snprintf(path, sizeof path, "%s/contours_%s.f64", argv[2], k ? "es" : "ed");
        if (!write_file(path, points, 3 * n * sizeof(double))) return 1;
    }
    return 0;
}

/* Each frame's stack, the slice shifts (OUT.shifts: 3 doubles a slice),
   applied to every frame, each frame closed by its lids (OUT_NN.lids),
   then tracked with the stacks as `reference track`. */
static int cmd_stack(int argc, char **argv)
{
    size_t frames = argc > 3 ? (size_t)(argc - 3) : 0, t, count;
    double *points[8] = {NULL}, *closed[8] = {NULL};
    size_t counts[8], closed_counts[8];
    sqffd_points views[8];
    sqffd_stack stacks[8];
    sqffd_slice_shifts shifts;
    char path[4096], suffix[32];
    int found = 1, status = 1;
    if (frames == 0 || frames > 8) return fail("stack", "usage: reference stack OUT FRAME.f64 ... (at most 8)");
    for (t = 0; t < frames; t++) {
        if (!(points[t] = read_points(argv[3 + t], &counts[t]))) goto done;
        views[t] = sqffd_points_packed(points[t], counts[t]);
        if (sqffd_stack_detect_view(views[t], &stacks[t], &found) != SQFFD_OK || !found) {
            fail(argv[3 + t], "not a short-axis stack");
            goto done;
        }
    }
    if (sqffd_stack_shifts_view(views, stacks, frames, &shifts) != SQFFD_OK) {
        fail("stack", "sqffd_stack_shifts failed");
        goto done;
    }
    if (!with_suffix(path, sizeof path, argv[2], ".shifts") || !write_file(path, shifts.shift, shifts.slices * sizeof shifts.shift[0]))
        goto done;
    for (t = 0; t < frames; t++) {
        if (sqffd_stack_shifts_apply(&shifts, points[t], counts[t], NULL) != SQFFD_OK ||
            sqffd_stack_lids_view(views[t], &stacks[t], NULL, 0, &count) != SQFFD_OK ||
            !(closed[t] = (double *)malloc(3 * (counts[t] + count) * sizeof(double))) ||
            sqffd_stack_lids_view(views[t], &stacks[t], closed[t] + 3 * counts[t], count, &count) != SQFFD_OK) {
            fail("stack", "shifts or lids failed");
            goto done;
        }
        memcpy(closed[t], points[t], 3 * counts[t] * sizeof(double));
        closed_counts[t] = counts[t] + count;
        snprintf(suffix, sizeof suffix, "_%02d.lids", (int)t);
        if (!with_suffix(path, sizeof path, argv[2], suffix) || !write_file(path, closed[t] + 3 * counts[t], 3 * count * sizeof(double)))
            goto done;
    }
    status = track_and_write(argv[2], (const double **)closed, closed_counts, frames, stacks);
done:
    for (t = 0; t < frames; t++) {
        free(points[t]);
        free(closed[t]);
    }
    return status;
}

int main(int argc, char **argv)
{
    if (argc >= 2 && strcmp(argv[1], "phantom") == 0) return cmd_phantom(argc, argv);
    if (argc >= 2 && strcmp(argv[1], "fit") == 0) return cmd_fit(argc, argv);
    if (argc >= 2 && strcmp(argv[1], "track") == 0) return cmd_track(argc, argv);
    if (argc >= 2 && strcmp(argv[1], "contours") == 0) return cmd_contours(argc, argv);
    if (argc >= 2 && strcmp(argv[1], "stack") == 0) return cmd_stack(argc, argv);
    return fail("usage", "reference phantom DIR FRAMES POINTS | fit POINTS.f64 OUT [NAME=VALUE ...] | "
                         "track OUT FRAME.f64 ... | contours DIR | stack OUT FRAME.f64 ...");
}

/* libFuzzer target: bytes -> 2-4 small frames of points and options ->
   sqffd_track_workspace_size / sqffd_track, then sqffd_motion on its models.
   Small limits (<= 64 points a frame, lattice 2-4, grid <= 6 x 8, a few
   iterations) keep each input to milliseconds. Checks beyond "no crash":
   - track: only its documented codes; frames_done = frame_count on success,
     the failing frame's index (< frame_count) on error, and the code that
     frame's data call for when it is plainly bad (NaN, too few points, all
     in one place); a workspace one byte short fails cleanly; the progress
     callback sees frames 0, 1, ... in order with the previous frame's error,
     and cancelling returns CANCELLED; on success every model is finite and
     shares frame 0's superquadric, box and grid, the reports' iteration
     counts respect the limits and their errors are finite;
   - motion: only its documented codes (INVALID_ARGUMENT for ed_frame out of
     range or bad options); on success every output finite, displacement
     >= 0, low_motion 0 or 1 and 0 on the valve plane, segments 0-17,
     volumes[es] the least and = ESV, volumes[ed] = EDV, a unit axis, the
     segments' shares in [0, 1]; outputs NULL gives the same report;
   - wall (after a successful motion, on its report and segments): the
     epicardium is each frame's model with its control points scaled about
     the box's centre (outside, on, or inside the endocardium); only its
     documented codes (INVALID_ARGUMENT for a bad threshold or a segment
     label over 17, WORKSPACE_TOO_SMALL one byte short); nothing written on
     an error; on success measured > 0 and measured + unmeasured the wall
     vertices, every thickness finite and >= 0 or NaN, a vertex's
     thickening NaN where either thickness is, finite myocardial volumes,
     each segment's thickening NaN exactly where it has no thicknesses and
     dysfunctional 0 or 1 (1 only below the threshold).

   Layout (bytes past the end read as 0):
     0  frame count 2..4 (bits 0-1 mod 3); bit 2: motion with NULL outputs too
     1  lattice 2..4 (mod 3; at most 3 with bit 4 or 6); bits 2 robust,
        3 no taper, 4 SVD solver, 5 position regularisation, 6 alpha 0,
        7 model_to_data 0
     2  grid: n_eta 2..6 (low nibble mod 5), n_omega 3..8 (high nibble mod 6)
     3  bits 0-1 frame 0's max_iterations, 2-3 frame_iterations, 4 cancel,
        5 workspace one byte short first, 6 NULL reports, 7 tolerance 0
     4  cancel after this many progress calls
     5  motion: bits 0-2 ed_frame, 3 apex direction, 4 septum direction,
        5-6 apex_fraction (0.1, 0, 0.5, 1 = invalid), 7 low_motion_fraction NaN
     6-11 the shape: half-axes, two rotation angles, contraction per frame
     then per frame: a kind byte (0 jittered ellipsoid, 1 ellipsoid + raw
     double outliers, 2 raw int16 points, 3 flat ellipsoid (coplanar) or
     one point repeated), a count byte, and the kind's bytes;
     last, the wall's byte: bits 0-1 the epicardium's scale (1.3, 1.15, 1:
     the same surface, 0.8: inside), 2 its stacks, 3 the endocardium's,
     4-5 the threshold (0.2, 5, -1 or NaN: invalid), 6 workspace one byte
     short first, 7 a segment label made 18 (invalid). */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include "fuzz_reader.h"
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define MAX_FRAMES 4
#define MAX_POINTS 64


static int finite_n(const double *x, size_t n)
{
    size_t i;
    for (i = 0; i < n; i++)
        if (!isfinite(x[i])) return 0;
    return 1;
}

/* The progress callback: checks the frame sequence, may cancel. */
typedef struct progress_state {
    int calls, cancel_at; /* cancel_at < 0: never */
    int next_frame;
    int cancelled;
    double frame_error[MAX_FRAMES];
} progress_state;

static int on_progress(void *user, int stage, int iteration, double error)
{
    progress_state *p = (progress_state *)user;
    if (stage != SQFFD_STAGE_SUPERQUADRIC && stage != SQFFD_STAGE_FFD && stage != SQFFD_STAGE_FRAME) abort();
    if (stage == SQFFD_STAGE_FRAME) {
        if (iteration != p->next_frame || iteration >= MAX_FRAMES) abort();
        if (iteration == 0 ? error != 0.0 : !(error >= 0.0) || !isfinite(error)) abort();
        p->frame_error[iteration] = error;
        p->next_frame++;
    }
    p->calls++;
    if (p->cancel_at >= 0 && p->calls > p->cancel_at) {
        p->cancelled = 1;
        return 1;
    }
    return 0;
}

/* A frame's points from the bytes. Returns the count (0..MAX_POINTS). */
static size_t make_frame(reader *r, const double axes[3], const double rot[9], double shrink, size_t t, double *points,
                         int *has_nonfinite, int *alike)
{
    unsigned kind = rd_u8(r) % 4, count_byte = rd_u8(r);
    size_t n = 0, i;
    uint32_t seed = 2463534242u ^ (uint32_t)(count_byte * 2654435761u) ^ (uint32_t)t;
    double amp = (double)(rd_u8(r) % 16) / 200.0; /* jitter, relative */
    if (kind == 2) { /* raw int16 triples */
        int shift = (int)(count_byte >> 6);
        n = 1 + count_byte % MAX_POINTS;
        for (i = 0; i < 3 * n; i++) {
            int v = (int)(rd_u8(r) | rd_u8(r) << 8);
            points[i] = ldexp((double)(v >= 32768 ? v - 65536 : v), -4 * shift);
        }
    } else {
        n = kind == 3 ? (size_t)(count_byte % (MAX_POINTS + 1)) : 13 + count_byte % (MAX_POINTS - 12);
        for (i = 0; i < n; i++) {
            double eta, omega, local[3], s = 1.0 - shrink * (double)t;
            int d;
            seed ^= seed << 13; seed ^= seed >> 17; seed ^= seed << 5;
            eta = ((double)(seed % 10007) / 10006.0 - 0.5) * 3.14159265358979;
            seed ^= seed << 13; seed ^= seed >> 17; seed ^= seed << 5;
            omega = ((double)(seed % 10007) / 10006.0 * 2.0 - 1.0) * 3.14159265358979;
            seed ^= seed << 13; seed ^= seed >> 17; seed ^= seed << 5;
            local[0] = s * axes[0] * cos(eta) * cos(omega);
            local[1] = s * axes[1] * cos(eta) * sin(omega);
            local[2] = axes[2] * sin(eta) * (1.0 - 0.5 * shrink * (double)t);
            for (d = 0; d < 3; d++) local[d] *= 1.0 + amp * ((double)(seed % 1001) / 500.0 - 1.0);
            if (kind == 3 && (count_byte & 128)) local[2] = 0.0; /* flat: coplanar */
            if (kind == 3 && !(count_byte & 128)) { local[0] = local[1] = 0.0; local[2] = 1.0; } /* all alike */
            for (d = 0; d < 3; d++)
                points[3 * i + (size_t)d] = rot[3 * d] * local[0] + rot[3 * d + 1] * local[1] + rot[3 * d + 2] * local[2];
        }
        if (kind == 1) { /* outliers: raw doubles, NaN and 1e300 included */
            size_t extra = count_byte >> 5, e;
            for (e = 0; e < extra && n < MAX_POINTS; e++, n++) {
                int d;
                for (d = 0; d < 3; d++) points[3 * n + (size_t)d] = rd_f64(r);
            }
        }
    }
    *has_nonfinite = !finite_n(points, 3 * n);
    *alike = n > 0;
    for (i = 1; i < n; i++)
        if (points[3 * i] != points[0] || points[3 * i + 1] != points[1] || points[3 * i + 2] != points[2]) *alike = 0;
    return n;
}

static int documented_track_code(sqffd_result r)
{
    return r == SQFFD_OK || r == SQFFD_ERROR_INVALID_ARGUMENT || r == SQFFD_ERROR_TOO_FEW_POINTS ||
           r == SQFFD_ERROR_NON_FINITE || r == SQFFD_ERROR_DEGENERATE || r == SQFFD_ERROR_TOO_LARGE ||
           r == SQFFD_ERROR_WORKSPACE_TOO_SMALL || r == SQFFD_ERROR_CANCELLED;
}

static void check_model(const sqffd_model *m, const sqffd_model *first)
{
    size_t c, count = (size_t)m->ffd.dims[0] * (size_t)m->ffd.dims[1] * (size_t)m->ffd.dims[2];
    if (!finite_n(m->sq.size, 3) || !finite_n(m->sq.shape, 2) || !finite_n(m->sq.taper, 2) ||
        !finite_n(m->sq.rotation, 9) || !finite_n(m->sq.center, 3))
        abort();
    if (!(m->sq.size[0] > 0.0 && m->sq.size[1] > 0.0 && m->sq.size[2] > 0.0)) abort();
    for (c = 0; c < count; c++)
        if (!finite_n(m->ffd.control[c], 3)) abort();
    /* every frame keeps frame 0's superquadric, box and grid */
    if (memcmp(&m->sq, &first->sq, sizeof m->sq) != 0 || memcmp(m->ffd.dims, first->ffd.dims, sizeof m->ffd.dims) != 0 ||
        memcmp(m->ffd.origin, first->ffd.origin, sizeof m->ffd.origin) != 0 ||
        memcmp(m->ffd.edges, first->ffd.edges, sizeof m->ffd.edges) != 0 || m->grid[0] != first->grid[0] ||
        m->grid[1] != first->grid[1])
        abort();
}

static void check_stats(const sqffd_distance_stats *s)
{
    if (!(s->rms >= 0.0) || !(s->mean >= 0.0) || !(s->max >= 0.0) || !isfinite(s->rms) || !isfinite(s->max) ||
        !isfinite(s->rms_relative))
        abort();
}

/* A stack of three planes across the superquadric along its third axis,
   half its height apart, the middle one through its centre. */
static void planes_across(const sqffd_superquadric *q, sqffd_stack *st)
{
    double c = 0.0;
    int k;
    for (k = 0; k < 3; k++) {
        st->axis[k] = q->rotation[3 * k + 2];
        c += st->axis[k] * q->center[k];
    }
    st->planes = 3;
    st->spacing = 0.5 * q->size[2];
    for (k = 0; k < 3; k++) st->level[k] = c + (double)(k - 1) * st->spacing;
}

static void run_wall(const sqffd_model *models, size_t frames, const sqffd_motion_report *motion,
                     const unsigned char *segment, unsigned wb);

static void run_motion(const sqffd_model *models, size_t frames, unsigned mb, int also_null, unsigned wb)
{
    sqffd_motion_options mo = sqffd_motion_options_default();
    sqffd_motion_outputs out;
    sqffd_motion_report rep, rep2;
    size_t m = (size_t)models[0].grid[0] * (size_t)models[0].grid[1] + 2, ws_size, v, t;
    unsigned char *ws;
    sqffd_result res;
    int expect_invalid = 0, k;

    mo.ed_frame = mb & 7;
    if (mo.ed_frame >= frames) expect_invalid = 1;
    if (mb & 8) { /* along the superquadric's third axis, or its reverse */
        for (k = 0; k < 3; k++) mo.apex_direction[k] = models[0].sq.rotation[3 * k + 2] * ((mb & 64) ? -1.0 : 1.0);
    }
    if (mb & 16) {
        for (k = 0; k < 3; k++) mo.septum_direction[k] = models[0].sq.rotation[3 * k] + 0.25 * models[0].sq.rotation[3 * k + 1];
    }
    switch ((mb >> 5) & 3) {
    case 0: break;
    case 1: mo.apex_fraction = 0.0; break;
    case 2: mo.apex_fraction = 0.5; break;
    default: mo.apex_fraction = 1.0; expect_invalid = 1; break;
    }
    if (mb & 128) { mo.low_motion_fraction = NAN; expect_invalid = 1; }

    if (sqffd_motion_workspace_size(models, frames, &ws_size) != SQFFD_OK || ws_size == 0) abort();
    ws = (unsigned char *)malloc(ws_size);
    out.volumes = (double *)malloc(frames * sizeof(double));
    out.trajectories = (double *)malloc(frames * m * 3 * sizeof(double));
    out.displacement = (double *)malloc(m * sizeof(double));
    out.excursion = (double *)malloc(m * sizeof(double));
    out.low_motion = (unsigned char *)malloc(m);
    out.segment = (unsigned char *)malloc(m);
    if (!ws || !out.volumes || !out.trajectories || !out.displacement || !out.excursion || !out.low_motion || !out.segment)
        abort();
    if (sqffd_motion(models, frames, &mo, &out, &rep, ws, ws_size - 1) !=
        (expect_invalid ? SQFFD_ERROR_INVALID_ARGUMENT : SQFFD_ERROR_WORKSPACE_TOO_SMALL))
        abort();
    memset(&rep, 0, sizeof rep);
    res = sqffd_motion(models, frames, &mo, &out, &rep, ws, ws_size);
    if (expect_invalid) {
        if (res != SQFFD_ERROR_INVALID_ARGUMENT) abort();
    } else if (res == SQFFD_OK) {
        double least = HUGE_VAL, len2 = 0.0;
        if (!finite_n(out.volumes, frames) || !finite_n(out.trajectories, frames * m * 3) ||
            !finite_n(out.displacement, m) || !finite_n(out.excursion, m))
            abort();
        for (t = 0; t < frames; t++)
            if (out.volumes[t] < least) least = out.volumes[t];
        if (rep.ed_frame != mo.ed_frame || rep.es_frame >= frames || out.volumes[rep.es_frame] != least ||
            rep.esv != least || rep.edv != out.volumes[rep.ed_frame] || !(rep.edv > 0.0) ||
            !isfinite(rep.ejection_fraction) || !isfinite(rep.length) || !(rep.length > 0.0) ||
            !isfinite(rep.median_excursion))
            abort();
        for (k = 0; k < 3; k++) len2 += rep.axis[k] * rep.axis[k];
        if (fabs(len2 - 1.0) > 1e-9) abort();
        for (v = 0; v < m; v++) {
            if (!(out.displacement[v] >= 0.0) || out.low_motion[v] > 1 || out.segment[v] > SQFFD_SEGMENTS) abort();
            if (out.segment[v] == 0 && out.low_motion[v]) abort(); /* the valve plane is never low-motion */
        }
        for (k = 0; k < SQFFD_SEGMENTS; k++) {
            const sqffd_segment_motion *sg = &rep.segments[k];
            if (!(sg->area >= 0.0) || !isfinite(sg->area) || !(sg->low_motion_share >= 0.0) ||
                !(sg->low_motion_share <= 1.0 + 1e-12) || !isfinite(sg->mean_displacement) ||
                !isfinite(sg->mean_excursion) || (sg->hypokinetic != 0 && sg->hypokinetic != 1))
                abort();
        }
        if (also_null) { /* no outputs: the same report */
            memset(&rep2, 0, sizeof rep2);
            if (sqffd_motion(models, frames, &mo, NULL, &rep2, ws, ws_size) != SQFFD_OK) abort();
            if (rep2.edv != rep.edv || rep2.esv != rep.esv || rep2.es_frame != rep.es_frame ||
                memcmp(rep2.axis, rep.axis, sizeof rep.axis) != 0 || rep2.median_excursion != rep.median_excursion)
                abort();
        }
        run_wall(models, frames, &rep, out.segment, wb);
    } else if (res != SQFFD_ERROR_NON_FINITE && res != SQFFD_ERROR_DEGENERATE && res != SQFFD_ERROR_INVALID_ARGUMENT) {
        abort(); /* (INVALID_ARGUMENT: a given direction along the axis) */
    }
    if (sqffd_motion(models, 0, &mo, &out, &rep, ws, ws_size) != SQFFD_ERROR_INVALID_ARGUMENT) abort();
    { /* volumes between slices: three planes across each model's superquadric along its third axis */
        sqffd_motion_options ms = sqffd_motion_options_default();
        sqffd_stack st[MAX_FRAMES];
        for (t = 0; t < frames; t++) planes_across(&models[0].sq, &st[t]);
        ms.stacks = st;
        res = sqffd_motion(models, frames, &ms, NULL, &rep, ws, ws_size);
        if (res == SQFFD_OK ? !isfinite(rep.edv) || !isfinite(rep.ejection_fraction)
                            : res != SQFFD_ERROR_NON_FINITE && res != SQFFD_ERROR_DEGENERATE && res != SQFFD_ERROR_INVALID_ARGUMENT)
            abort();
        st[0].planes = 2; /* too few: refused */
        if (sqffd_motion(models, frames, &ms, NULL, &rep, ws, ws_size) != SQFFD_ERROR_INVALID_ARGUMENT) abort();
    }
    free(ws);
    free(out.volumes);
    free(out.trajectories);
    free(out.displacement);
    free(out.excursion);
    free(out.low_motion);
    free(out.segment);
}

/* The wall of the tracked models against an epicardium made from them (see the top). */
static void run_wall(const sqffd_model *models, size_t frames, const sqffd_motion_report *motion,
                     const unsigned char *segment, unsigned wb)
{
    static const double scales[4] = {1.3, 1.15, 1.0, 0.8}, thresholds[4] = {0.2, 5.0, -1.0, NAN};
    sqffd_model epi[MAX_FRAMES];
    sqffd_stack st[MAX_FRAMES];
    sqffd_wall_options wo = sqffd_wall_options_default();
    sqffd_wall_outputs out;
    sqffd_wall_report rep, untouched;
    size_t m = (size_t)models[0].grid[0] * (size_t)models[0].grid[1] + 2, ws_size, t, v, seen = 0;
    unsigned char *labels = (unsigned char *)malloc(m), *ws;
    sqffd_result res;
    int expect_invalid = (wb & 32) != 0, k, p, c; /* (thresholds -1 and NaN) */
    if (!labels) abort();
    memcpy(labels, segment, m);
    if (wb & 128) { labels[m / 2] = SQFFD_SEGMENTS + 1; expect_invalid = 1; }
    for (t = 0; t < frames; t++) { /* control points scaled about the box's centre: the surface scaled about it */
        const sqffd_ffd *f = &models[t].ffd;
        double centre[3];
        size_t count = (size_t)f->dims[0] * (size_t)f->dims[1] * (size_t)f->dims[2];
        epi[t] = models[t];
        for (k = 0; k < 3; k++) centre[k] = f->origin[k] + 0.5 * (f->edges[k] + f->edges[3 + k] + f->edges[6 + k]);
        for (v = 0; v < count; v++)
            for (k = 0; k < 3; k++)
                epi[t].ffd.control[v][k] = centre[k] + scales[wb & 3] * (f->control[v][k] - centre[k]);
        planes_across(&models[0].sq, &st[t]);
    }
    wo.stacks = (wb & 4) ? st : NULL;
    wo.endo_stacks = (wb & 8) ? st : NULL;
    wo.dysfunctional_thickening = thresholds[(wb >> 4) & 3];
    if (sqffd_wall_workspace_size(models, epi, frames, &ws_size) != SQFFD_OK || ws_size == 0) abort();
    ws = (unsigned char *)malloc(ws_size);
    out.myocardium = (double *)malloc(frames * sizeof(double));
    out.thickness_ed = (double *)malloc(m * sizeof(double));
    out.thickness_es = (double *)malloc(m * sizeof(double));
    out.thickening = (double *)malloc(m * sizeof(double));
    if (!ws || !out.myocardium || !out.thickness_ed || !out.thickness_es || !out.thickening) abort();
    for (p = 0; p < 2; p++) {
        size_t given = p == 0 ? ws_size - 1 : ws_size;
        if (p == 0 && !(wb & 64)) continue;
        memset(&rep, 0xA5, sizeof rep);
        untouched = rep;
        for (v = 0; v < m; v++) out.thickness_ed[v] = out.thickness_es[v] = out.thickening[v] = -7.0;
        for (t = 0; t < frames; t++) out.myocardium[t] = -7.0;
        res = sqffd_wall(models, epi, frames, motion, labels, &wo, &out, &rep, ws, given);
        if (res != SQFFD_OK) { /* nothing written */
            if (memcmp(&rep, &untouched, sizeof rep) != 0 || out.myocardium[0] != -7.0 || out.thickness_ed[0] != -7.0 ||
                out.thickening[m - 1] != -7.0)
                abort();
        }
        if (expect_invalid) {
            if (res != SQFFD_ERROR_INVALID_ARGUMENT) abort();
            continue;
        }
        if (p == 0) {
            if (res != SQFFD_ERROR_WORKSPACE_TOO_SMALL) abort();
            continue;
        }
        if (res != SQFFD_OK) {
            if (res != SQFFD_ERROR_NON_FINITE && res != SQFFD_ERROR_DEGENERATE) abort();
            continue;
        }
        if (rep.measured == 0 || !isfinite(rep.myocardium_ed) || !isfinite(rep.myocardium_es) || !finite_n(out.myocardium, frames) ||
            !(rep.thickness_ed >= 0.0) || !(rep.thickness_es >= 0.0) || !isfinite(rep.thickness_ed) || !isfinite(rep.thickness_es))
            abort();
        for (v = 0; v < m; v++) {
            double ed = out.thickness_ed[v], es = out.thickness_es[v], th = out.thickening[v];
            if (!(isnan(ed) || (ed >= 0.0 && isfinite(ed))) || !(isnan(es) || (es >= 0.0 && isfinite(es)))) abort();
            if ((isnan(ed) || isnan(es)) && !isnan(th)) abort();
            if (labels[v] && !isnan(th)) seen++;
        }
        if (seen != rep.measured) abort(); /* (the wall vertices with a thickening) */
        for (c = 0; c < SQFFD_SEGMENTS; c++) {
            const sqffd_segment_wall *g = &rep.segments[c];
            int none = g->thickness_ed == 0.0 && g->thickness_es == 0.0;
            if (g->dysfunctional != 0 && g->dysfunctional != 1) abort();
            if (none ? !isnan(g->thickening) || g->dysfunctional : !isfinite(g->thickening) || !(g->thickness_ed > 0.0))
                abort();
            if (g->dysfunctional && !(g->thickening < wo.dysfunctional_thickening)) abort();
        }
    }
    free(ws);
    free(labels);
    free(out.myocardium);
    free(out.thickness_ed);
    free(out.thickness_es);
    free(out.thickening);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    reader r;
    sqffd_track_options o = sqffd_track_options_default();
    unsigned b0, b1, b2, b3, b4, b5;
    size_t frames, counts[MAX_FRAMES], t, ws_size, done = 99, done_short = 99, refused;
    double *points[MAX_FRAMES], axes[3], rot[9], shrink, a1, a2;
    const double *frame_ptrs[MAX_FRAMES];
    int bad[MAX_FRAMES], alike[MAX_FRAMES];
    sqffd_model models[MAX_FRAMES];
    sqffd_fit_report reports[MAX_FRAMES];
    unsigned char *ws;
    sqffd_result res, res_short = SQFFD_OK, check = SQFFD_OK;
    progress_state ps;

    if (size < 12) return 0;
    r.data = data;
    r.size = size;
    r.at = 0;
    b0 = rd_u8(&r); b1 = rd_u8(&r); b2 = rd_u8(&r); b3 = rd_u8(&r); b4 = rd_u8(&r); b5 = rd_u8(&r);
    frames = 2 + (b0 & 3) % 3;
    o.fit.lattice[0] = o.fit.lattice[1] = o.fit.lattice[2] = 2 + (int)(b1 % 3);
    o.fit.sq.robust = (b1 & 4) != 0;
    o.fit.sq.taper = !(b1 & 8);
    o.fit.solver = (b1 & 16) ? SQFFD_SOLVER_SVD : SQFFD_SOLVER_CHOLESKY;
    o.fit.regularization = (b1 & 32) ? SQFFD_REG_POSITION : SQFFD_REG_DISPLACEMENT;
    if (b1 & 64) o.fit.alpha = 0.0;
    if ((b1 & (16 | 64)) && o.fit.lattice[0] > 3) /* SVD steps on 4^3 control points cost too much here */
        o.fit.lattice[0] = o.fit.lattice[1] = o.fit.lattice[2] = 3;
    if (b1 & 128) o.fit.model_to_data = 0.0;
    o.fit.grid[0] = 2 + (int)((b2 & 15) % 5);
    o.fit.grid[1] = 3 + (int)((b2 >> 4) % 6);
    o.fit.max_iterations = (int)(b3 & 3);
    o.frame_iterations = (int)((b3 >> 2) & 3);
    o.fit.sq.max_iterations = 8;
    o.fit.sq.robust_rounds = 2;
    if (b3 & 128) o.fit.tolerance = 0.0;
    memset(&ps, 0, sizeof ps);
    ps.cancel_at = (b3 & 16) ? (int)b4 : -1;
    o.progress = on_progress;
    o.progress_user = &ps;

    /* the shape: half-axes 1..8.5, rotated about z then x, shrinking per frame */
    axes[0] = 1.0 + (double)(rd_u8(&r) % 16) / 2.0;
    axes[1] = 1.0 + (double)(rd_u8(&r) % 16) / 2.0;
    axes[2] = 1.0 + (double)(rd_u8(&r) % 16) / 2.0;
    a1 = (double)rd_u8(&r) / 40.0;
    a2 = (double)rd_u8(&r) / 40.0;
    shrink = (double)(rd_u8(&r) % 32) / 100.0;
    rot[0] = cos(a1); rot[1] = -sin(a1) * cos(a2); rot[2] = sin(a1) * sin(a2);
    rot[3] = sin(a1); rot[4] = cos(a1) * cos(a2); rot[5] = -cos(a1) * sin(a2);
    rot[6] = 0.0; rot[7] = sin(a2); rot[8] = cos(a2);

    for (t = 0; t < frames; t++) {
        points[t] = (double *)malloc(3 * MAX_POINTS * sizeof(double));
        if (!points[t]) abort();
        counts[t] = make_frame(&r, axes, rot, shrink, t, points[t], &bad[t], &alike[t]);
        frame_ptrs[t] = points[t];
        { /* a frame is a short-axis stack or not; if it is, a well-formed one */
            sqffd_stack st;
            int found = 0;
            size_t k;
            sqffd_result sr = sqffd_stack_detect(points[t], counts[t], &st, &found);
            if (sr != SQFFD_OK && sr != SQFFD_ERROR_NON_FINITE) abort();
            if (found && (st.planes < 3 || st.planes > SQFFD_STACK_PLANES || !(st.spacing > 0.0) || !isfinite(st.spacing)))
                abort();
            for (k = 1; found && k < st.planes; k++)
                if (!(st.level[k] > st.level[k - 1])) abort();
            if (!found && counts[t] > 0) { /* else three planes across the points' z range */
                double lo = points[t][2], hi = lo;
                for (k = 1; k < counts[t]; k++) {
                    double z = points[t][3 * k + 2];
                    lo = z < lo ? z : lo;
                    hi = z > hi ? z : hi;
                }
                st.axis[0] = st.axis[1] = 0.0;
                st.axis[2] = 1.0;
                st.planes = 3;
                st.spacing = 0.5 * (hi - lo);
                for (k = 0; k < 3; k++) st.level[k] = lo + (double)k * st.spacing;
                found = st.spacing > 0.0 && isfinite(st.spacing) && st.level[1] > lo && st.level[2] > st.level[1];
            }
            if (found) { /* its lids: counted as written, each on a plane half a spacing beyond an outer one */
                size_t need = 0, got = 0, k2;
                sr = sqffd_stack_lids(points[t], counts[t], &st, NULL, 0, &need);
                if (sr == SQFFD_OK && need > 0) {
                    double *lid = (double *)malloc(3 * need * sizeof(double));
                    if (!lid) abort();
                    if (sqffd_stack_lids(points[t], counts[t], &st, lid, need, &got) != SQFFD_OK ||
                        got != need)
                        abort();
                    for (k2 = 0; k2 < got; k2++) { /* (to rounding: the point's size times a few ulps) */
                        const double *q = lid + 3 * k2;
                        double at = st.axis[0] * q[0] + st.axis[1] * q[1] + st.axis[2] * q[2];
                        double lo = st.level[0] - 0.5 * st.spacing, hi = st.level[st.planes - 1] + 0.5 * st.spacing;
                        double slack = 1e-9 * (fabs(q[0]) + fabs(q[1]) + fabs(q[2]) + st.spacing);
                        if (!(fabs(at - lo) <= slack || fabs(at - hi) <= slack)) abort();
                    }
                    free(lid);
                } else if (sr != SQFFD_OK && sr != SQFFD_ERROR_NON_FINITE) {
                    abort();
                }
            }
            if (found) { /* its slice shifts: finite, across the axis, and applying them moves slice points only */
                sqffd_points view = sqffd_points_packed(points[t], counts[t]);
                sqffd_slice_shifts sh;
                sr = sqffd_stack_shifts_view(&view, &st, 1, &sh);
                if (sr == SQFFD_OK) {
                    double *copy = (double *)malloc(3 * counts[t] * sizeof(double) + 1);
                    size_t moved = 0;
                    if (!copy) abort();
                    if (sh.slices < 1 || sh.slices > st.planes) abort(); /* (planes within a quarter spacing: one slice) */
                    for (k = 0; k < sh.slices; k++) { /* across the axis, to rounding */
                        const double *v = sh.shift[k];
                        double along = v[0] * st.axis[0] + v[1] * st.axis[1] + v[2] * st.axis[2];
                        double size = fabs(v[0]) + fabs(v[1]) + fabs(v[2]);
                        if (!isfinite(size) || !(fabs(along) <= 1e-9 * (size + st.spacing + fabs(sh.level[k])))) abort();
                    }
                    memcpy(copy, points[t], 3 * counts[t] * sizeof(double));
                    if (sqffd_stack_shifts_apply(&sh, copy, counts[t], &moved) != SQFFD_OK || moved > counts[t]) abort();
                    free(copy);
                } else if (sr != SQFFD_ERROR_NON_FINITE && sr != SQFFD_ERROR_INVALID_ARGUMENT) {
                    abort();
                }
            }
        }
    }

    res = sqffd_track_workspace_size(counts, frames, &o, &ws_size);
    for (t = 0; t < frames; t++)
        if (counts[t] == 0) break;
    if (t < frames) { /* an empty frame: no size for it */
        if (res != SQFFD_ERROR_INVALID_ARGUMENT || ws_size != 0) abort();
        res = sqffd_track_workspace_size(counts, t ? t : 1, &o, &ws_size);
        if (t == 0 && (res != SQFFD_ERROR_INVALID_ARGUMENT || ws_size != 0)) abort();
        if (res != SQFFD_OK) goto done;
    }
    if (res != SQFFD_OK || ws_size == 0) abort();
    ws = (unsigned char *)malloc(ws_size);
    if (!ws) abort();
    for (refused = 0; refused < frames; refused++) /* the frames' data are checked before anything is fitted */
        if ((check = sqffd_fit_check_data(frame_ptrs[refused], counts[refused])) != SQFFD_OK) break;

    if (b3 & 32) { /* one byte short: fails cleanly, at some frame */
        progress_state quiet = ps;
        o.progress_user = &quiet;
        res_short = sqffd_track(frame_ptrs, counts, frames, &o, models, NULL, &done_short, ws, ws_size - 1);
        if (!documented_track_code(res_short) || res_short == SQFFD_OK || done_short >= frames) abort();
        o.progress_user = &ps;
    }

    res = sqffd_track(frame_ptrs, counts, frames, &o, models, (b3 & 64) ? NULL : reports, &done, ws, ws_size);
    if (!documented_track_code(res)) abort();
    if (res == SQFFD_OK ? done != frames : done >= frames) abort();
    if (refused < frames) { /* refused up front: that frame's check, nothing fitted, the callback never called */
        if (res != check || done != refused || ps.next_frame != 0) abort();
    } else if ((size_t)ps.next_frame != (res == SQFFD_OK ? done : done + 1))
        abort(); /* the callback saw frames 0 .. done (the failing one included) */
    if (res == SQFFD_ERROR_CANCELLED && !ps.cancelled) abort();
    if (ps.cancelled && res != SQFFD_ERROR_CANCELLED) abort();
    if (b3 & 32) { /* short by one byte: WORKSPACE_TOO_SMALL, or the same failure before it mattered */
        if (res_short != SQFFD_ERROR_WORKSPACE_TOO_SMALL && !(res_short == res && done_short == done) &&
            !(res_short == SQFFD_ERROR_CANCELLED))
            abort();
        if (res_short == SQFFD_ERROR_WORKSPACE_TOO_SMALL && res != SQFFD_OK && done < done_short) abort();
    }
    if (res != SQFFD_OK && res != SQFFD_ERROR_CANCELLED) {
        /* plainly bad data in the failing frame say so */
        size_t f = done, least = SQFFD_SQ_FIT_MIN_POINTS; /* (every frame: a lone fit's least) */
        int few = counts[f] < least, alike_only = alike[f] && !bad[f];
        /* (where several apply, the order of the checks is not documented: any of them) */
        if ((few || bad[f] || alike_only) && !(few && res == SQFFD_ERROR_TOO_FEW_POINTS) &&
            !(bad[f] && res == SQFFD_ERROR_NON_FINITE) && !(alike_only && res == SQFFD_ERROR_DEGENERATE))
            abort();
    }
    if (res == SQFFD_OK) {
        for (t = 0; t < frames; t++) {
            check_model(&models[t], &models[0]);
            if (!(b3 & 64)) {
                int limit = t == 0 ? o.fit.max_iterations : o.frame_iterations;
                if (reports[t].iterations < 0 || reports[t].iterations > limit) abort();
                check_stats(&reports[t].error);
                if (t > 0 && ps.frame_error[t] != reports[t - 1].error.rms_relative) abort();
            }
        }
        run_motion(models, frames, b5, (b0 & 4) != 0, rd_u8(&r));
    }
    free(ws);

done:
    for (t = 0; t < frames; t++) free(points[t]);
    return 0;
}

/* The fold-free deformation: the lattice's Jacobian bound against its
   definition (affine maps, sampled determinants), and fits and tracks of
   short-axis stacks of the phantom (planar sections, ED and ES covering
   different slices: the data that fold an unconstrained lattice) that end
   with a positive bound, a surface that passes nowhere through itself and
   the phantom's ejection fraction; slices shifted in-plane (breath-hold
   misregistration) found again. */
#include "test.h"
#include "../examples/sqffd_phantom.h"
#include "../examples/sqffd_synth.h"
#include "mesh_check.h"
#include <stdlib.h>
#include <string.h>

/* sqffd_model_jacobian_bound with a malloc'd workspace. */
static sqffd_result region_bound(const sqffd_model *m, double floor, double *min)
{
    size_t size;
    void *ws;
    sqffd_result r = sqffd_model_jacobian_workspace_size(m->ffd.dims, &size);
    if (r != SQFFD_OK) return r;
    ws = test_malloc(size);
    r = sqffd_model_jacobian_bound(m, floor, min, ws, size);
    free(ws);
    return r;
}

/* The smallest J (sampled_jacobian) at `count` random points of the
   superquadric's solid. */
static double solid_jacobian_min(const sqffd_model *m, int count, unsigned seed);

/* sqffd_ffd_jacobian_bound with a malloc'd workspace. */
static sqffd_result jacobian_bound(const sqffd_ffd *f, double *min)
{
    size_t size;
    void *ws;
    sqffd_result r = sqffd_ffd_jacobian_workspace_size(f->dims, &size);
    if (r != SQFFD_OK) return r;
    ws = test_malloc(size);
    r = sqffd_ffd_jacobian_bound(f, min, ws, size);
    free(ws);
    return r;
}

/* det(d deformed / d x) at local (s, t, u) by central differences, over det(box). */
static double sampled_jacobian(const sqffd_ffd *f, const double stu[3])
{
    double j[3][3], box;
    const double *e = f->edges;
    int a, r;
    for (a = 0; a < 3; a++) {
        double hi[3], lo[3], xh[3], xl[3];
        for (r = 0; r < 3; r++) hi[r] = lo[r] = stu[r];
        hi[a] += 1e-6;
        lo[a] -= 1e-6;
        sqffd_ffd_eval(f, hi, xh);
        sqffd_ffd_eval(f, lo, xl);
        for (r = 0; r < 3; r++) j[r][a] = (xh[r] - xl[r]) / 2e-6;
    }
    box = e[0] * (e[4] * e[8] - e[5] * e[7]) - e[1] * (e[3] * e[8] - e[5] * e[6]) + e[2] * (e[3] * e[7] - e[4] * e[6]);
    return (j[0][0] * (j[1][1] * j[2][2] - j[1][2] * j[2][1]) - j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0]) +
            j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0])) / box;
}

/* The bound: 1 for the regular lattice, det A for an affine map A (J is
   then constant, so its bound is exact), and never above the determinant
   sampled on a 16^3 grid of the box for random lattices, folded or not,
   with equality where the minimum sits at a corner (a coefficient there is
   J's value). Bad input: result codes. */
static void test_jacobian_bound(void)
{
    static const int shapes[][3] = {{5, 5, 5}, {4, 5, 3}, {2, 2, 2}, {8, 3, 6}};
    const double origin[3] = {1.0, -2.0, 3.0}, edges[9] = {10.0, 1.0, 0.0, 0.0, 8.0, 2.0, 1.0, 0.0, 12.0};
    const double affine[9] = {0.9, 0.2, 0.0, -0.1, 1.1, 0.3, 0.05, 0.0, 0.7};
    synth_rng rng = synth_rng_seed(28);
    sqffd_ffd f;
    size_t g, p, size;
    double bound, det = affine[0] * (affine[4] * affine[8] - affine[5] * affine[7]) -
                        affine[1] * (affine[3] * affine[8] - affine[5] * affine[6]) +
                        affine[2] * (affine[3] * affine[7] - affine[4] * affine[6]);
    int c, trial, negative = 0;
    for (g = 0; g < sizeof shapes / sizeof shapes[0]; g++) {
        size_t l = (size_t)shapes[g][0] * (size_t)shapes[g][1] * (size_t)shapes[g][2];
        CHECK_RESULT(sqffd_ffd_init(&f, shapes[g], origin, edges), SQFFD_OK);
        CHECK_RESULT(jacobian_bound(&f, &bound), SQFFD_OK);
        CHECK_NEAR(bound, 1.0, 1e-12);
        for (p = 0; p < l; p++) { /* x -> origin + A (x - origin) */
            double d[3];
            for (c = 0; c < 3; c++) d[c] = f.control[p][c] - origin[c];
            for (c = 0; c < 3; c++)
                f.control[p][c] = origin[c] + affine[3 * c] * d[0] + affine[3 * c + 1] * d[1] + affine[3 * c + 2] * d[2];
        }
        CHECK_RESULT(jacobian_bound(&f, &bound), SQFFD_OK);
        CHECK_NEAR(bound, det, 1e-12);
        for (trial = 0; trial < 4; trial++) {
            double least = HUGE_VAL, stu[3];
            int i, j, k;
            CHECK_RESULT(sqffd_ffd_init(&f, shapes[g], origin, edges), SQFFD_OK);
            for (p = 0; p < l; p++)
                for (c = 0; c < 3; c++) f.control[p][c] += 2.5 * (double)trial * synth_range(&rng, -1.0, 1.0);
            CHECK_RESULT(jacobian_bound(&f, &bound), SQFFD_OK);
            for (i = 0; i <= 16; i++)
                for (j = 0; j <= 16; j++)
                    for (k = 0; k <= 16; k++) {
                        double v;
                        stu[0] = i / 16.0; stu[1] = j / 16.0; stu[2] = k / 16.0;
                        v = sampled_jacobian(&f, stu);
                        if (v < least) least = v;
                    }
            CHECK_MSG(bound <= least + 1e-6, "lattice %dx%dx%d, trial %d: bound %.9g above the sampled %.9g",
                      shapes[g][0], shapes[g][1], shapes[g][2], trial, bound, least);
            negative += bound < 0.0;
        }
    }
    CHECK(negative > 0); /* (the random lattices include folded ones) */
    CHECK_RESULT(sqffd_ffd_jacobian_workspace_size(f.dims, &size), SQFFD_OK);
    {
        void *ws = test_malloc(size);
        CHECK_RESULT(sqffd_ffd_jacobian_bound(&f, &bound, ws, size - 1), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
        CHECK_RESULT(sqffd_ffd_jacobian_bound(&f, NULL, ws, size), SQFFD_ERROR_INVALID_ARGUMENT);
        f.dims[1] = SQFFD_MAX_LATTICE + 1;
        CHECK_RESULT(sqffd_ffd_jacobian_bound(&f, &bound, ws, size), SQFFD_ERROR_INVALID_MODEL);
        CHECK_RESULT(sqffd_ffd_jacobian_workspace_size(f.dims, &size), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK(size == 0);
        free(ws);
    }
}

static double solid_jacobian_min(const sqffd_model *m, int count, unsigned seed)
{
    double least = HUGE_VAL, reach = 0.0;
    int k, found = 0;
    for (k = 0; k < 3; k++) reach = fmax(reach, m->sq.size[k] * (1.0 + fabs(k < 2 ? m->sq.taper[k] : 0.0)));
    srand(seed);
    for (k = 0; found < count && k < 1000 * count; k++) {
        double p[3], value, stu[3], j;
        int c;
        for (c = 0; c < 3; c++) p[c] = m->sq.center[c] + reach * (2.0 * rand() / RAND_MAX - 1.0);
        if (sqffd_sq_inside_outside(&m->sq, p, &value) != SQFFD_OK || value > 1.0) continue;
        CHECK_RESULT(sqffd_ffd_local(&m->ffd, p, stu), SQFFD_OK);
        j = sampled_jacobian(&m->ffd, stu);
        least = j < least ? j : least;
        found++;
    }
    CHECK(found == count);
    return least;
}

/* A short-axis stack of the phantom at a phase: `count` slices 7 mm apart
   from `first` above the ED apex, 96 points each. */
static size_t stack(const phantom_lv *p, double phase, int first, int count, double *out)
{
    double levels[16];
    int k;
    for (k = 0; k < count; k++) levels[k] = -p->height + 3.0 + 7.0 * (double)(first + k);
    return phantom_lv_contours(p, phase, levels, count, 96, NULL, out);
}

/* The folded share of a model's grid mesh (1,000 samples). */
static double model_folded(const sqffd_model *m)
{
    size_t nv, nt;
    double *v, share;
    uint32_t *t;
    if (sqffd_model_mesh_size(m->grid[0], m->grid[1], &nv, &nt) != SQFFD_OK) return 1.0;
    v = (double *)test_malloc(3 * nv * sizeof *v);
    t = (uint32_t *)test_malloc(3 * nt * sizeof *t);
    share = sqffd_model_mesh(m, m->grid[0], m->grid[1], v, t) == SQFFD_OK ? meshcheck_folded_share(v, nv, t, nt, 1000, 7) : 1.0;
    free(v);
    free(t);
    return share;
}

/* The report's energy history never rises. */
static void check_energy_never_rises(const sqffd_fit_report *rep)
{
    int k;
    for (k = 1; k < rep->history_count; k++)
        CHECK_MSG(rep->energy_history[k] <= rep->energy_history[k - 1], "energy rose at iteration %d", k + 1);
}

/* From a start that folds on its region (certified bound `start` under
   the floor), the floor's fit ends certified at or above the floor (the
   start drawn toward the regular lattice first), the report's bound the
   model's, the energy never rising, and the error near the fit of the
   same data from the regular lattice (`fresh`; measured 0.088 % against
   0.066 % of the diagonal: the two starts end the 33 iterations in
   different places). With no iterations the folded model is returned as
   given, its bound reported. */
static void untangle(const double *pts, size_t n, const sqffd_fit_options *o, const sqffd_model *folded, double start,
                     double fresh)
{
    sqffd_model m = *folded;
    sqffd_fit_options none = *o;
    sqffd_fit_report rep;
    size_t size;
    void *ws;
    double bound;
    CHECK_RESULT(region_bound(&m, o->min_jacobian, &bound), SQFFD_OK);
    CHECK_NEAR(bound, start, 1e-12);
    CHECK_RESULT(sqffd_fit_ffd_workspace_size(n, &m, o, &size), SQFFD_OK);
    ws = test_malloc(size);
    none.max_iterations = 0;
    CHECK_RESULT(sqffd_fit_ffd(pts, n, &none, &m, &rep, ws, size), SQFFD_OK);
    CHECK(memcmp(m.ffd.control, folded->ffd.control, sizeof m.ffd.control) == 0);
    CHECK_NEAR(rep.min_jacobian, start, 1e-12);
    CHECK_RESULT(sqffd_fit_ffd(pts, n, o, &m, &rep, ws, size), SQFFD_OK);
    free(ws);
    CHECK_MSG(rep.min_jacobian >= o->min_jacobian, "bound %g under the floor %g (the start's %g)", rep.min_jacobian,
              o->min_jacobian, start);
    CHECK_RESULT(region_bound(&m, o->min_jacobian, &bound), SQFFD_OK);
    CHECK_NEAR(bound, rep.min_jacobian, 1e-12);
    CHECK_MSG(model_folded(&m) == 0.0, "folded share %g", model_folded(&m));
    check_energy_never_rises(&rep);
    CHECK_MSG(rep.error.rms_relative <= 1.5 * fresh, "error %g from the folded start, %g from the regular lattice",
              rep.error.rms_relative, fresh);
}

/* A lone fit of a stack: with the bound off (min_jacobian -inf) the
   lattice folds (the data built to fold); from that folded model the
   floor's fit ends certified (untangle); from the start, the default ends at or
   above the floor on its region, the report's bound is the region's
   (sqffd_model_jacobian_bound), J sampled across the superquadric's solid
   is above the floor, its mesh folds nowhere, and the energy never rises. */
static void test_fit_stack_fold_free(void)
{
    phantom_lv p = phantom_lv_default();
    double *pts = (double *)test_malloc(16 * 96 * 3 * sizeof *pts), bound;
    size_t n = stack(&p, 0.0, 0, 8, pts);
    sqffd_fit_options o = sqffd_fit_options_default();
    sqffd_model m, folded;
    sqffd_fit_report rep;
    CHECK(n == 8 * 96);
    o.min_jacobian = -HUGE_VAL;
    CHECK_RESULT(test_fit(pts, n, &o, &folded, &rep), SQFFD_OK);
    CHECK_MSG(rep.min_jacobian < 0.0, "unconstrained bound %g: these data no longer fold the lattice", rep.min_jacobian);
    bound = rep.min_jacobian;
    o = sqffd_fit_options_default();
    CHECK_RESULT(test_fit(pts, n, &o, &m, &rep), SQFFD_OK);
    untangle(pts, n, &o, &folded, bound, rep.error.rms_relative);
    CHECK_MSG(rep.min_jacobian >= o.min_jacobian - 1e-12, "bound %g below the floor %g", rep.min_jacobian, o.min_jacobian);
    CHECK_RESULT(region_bound(&m, o.min_jacobian, &bound), SQFFD_OK);
    CHECK_NEAR(bound, rep.min_jacobian, 1e-12);
    bound = solid_jacobian_min(&m, 3000, 5);
    CHECK_MSG(bound >= o.min_jacobian - 1e-6, "J %g inside the solid, under the floor", bound);
    CHECK_MSG(model_folded(&m) == 0.0, "folded share %g", model_folded(&m));
    CHECK_MSG(rep.error.rms_relative < 0.02, "error %g", rep.error.rms_relative);
    check_energy_never_rises(&rep);
    o.min_jacobian = NAN;
    CHECK_RESULT(test_fit(pts, n, &o, &m, &rep), SQFFD_ERROR_INVALID_ARGUMENT);
    o.min_jacobian = 1.5;
    CHECK_RESULT(test_fit(pts, n, &o, &m, &rep), SQFFD_ERROR_INVALID_ARGUMENT);
    free(pts);
}

/* ED and ES tracked with the defaults: their ejection fraction (with
   stacks, of the volumes between their slices), and each model's Jacobian
   bound and folded share checked. */
static double track_ejection(double *const frames[2], const size_t counts[2], const sqffd_stack *stacks,
                             sqffd_fit_report reports[2])
{
    sqffd_model models[2];
    sqffd_motion_report m;
    sqffd_motion_options mo = sqffd_motion_options_default();
    size_t size, done;
    void *ws;
    int k;
    mo.stacks = stacks;
    CHECK_RESULT(sqffd_track_workspace_size(counts, 2, NULL, &size), SQFFD_OK);
    ws = test_malloc(size);
    CHECK_RESULT(sqffd_track((const double *const *)frames, counts, 2, NULL, models, reports, &done, ws, size), SQFFD_OK);
    free(ws);
    for (k = 0; k < 2; k++) {
        CHECK_MSG(reports[k].min_jacobian > 0.0, "frame %d: bound %g", k, reports[k].min_jacobian);
        CHECK_MSG(model_folded(&models[k]) == 0.0, "frame %d folds", k);
    }
    CHECK_RESULT(sqffd_motion_workspace_size(models, 2, &size), SQFFD_OK);
    ws = test_malloc(size);
    CHECK_RESULT(sqffd_motion(models, 2, &mo, NULL, &m, ws, size), SQFFD_OK);
    free(ws);
    return m.ejection_fraction;
}

/* A stack as a label map: slices 7 mm thick, 1 mm pixels, the cavity
   labelled 3 and a 3-pixel ring around it 2 (a myocardium), an empty slice
   beyond each end; its label-3 surface's points into out (at most `room`). */
static size_t label_map_points(const double *stack_points, size_t n, double first_level, int slices, double *out,
                               size_t room)
{
    const size_t dims[3] = {81, 81, (size_t)slices + 2};
    const double origin[3] = {-40.0, -40.0, first_level - 7.0};
    unsigned char *labels = (unsigned char *)test_malloc(dims[0] * dims[1] * dims[2]);
    sqffd_volume v;
    sqffd_iso_options o = sqffd_iso_options_default();
    size_t size, count = 0;
    void *ws;
    synth_rasterise_stack(stack_points, n, origin, 1.0, 7.0, dims, 3, 2, 3, labels);
    v = synth_label_volume(labels, dims, origin, 1.0, 7.0);
    o.labelled = 1;
    o.label = 3.0;
    o.largest_component = 1;
    CHECK_RESULT(sqffd_iso_workspace_size(&v, &o, &size), SQFFD_OK);
    ws = test_malloc(size);
    CHECK_RESULT(sqffd_iso_points(&v, &o, out, NULL, room, &count, ws, size), SQFFD_OK);
    CHECK(count > 0 && count <= room);
    free(ws);
    free(labels);
    return count < room ? count : room;
}

/* ED to ES in one step on stacks, the ES one a slice shorter at the base
   (it descends below the top plane): both models fold-free, their meshes fold
   nowhere, and the ejection fraction is the phantom's within 2 points, and
   so with the stacks closed by their lids;
   the same stacks as label maps (--label 3) give it within 2 points of
   the stacks' as points. */
static void test_track_stack_ejection(void)
{
    enum { ROOM = 60000 };
    phantom_lv p = phantom_lv_default();
    double *frames[2], *labelled[2], truth = phantom_lv_ejection_fraction(&p, 2), ef, ef_labels, ef_lids;
    size_t counts[2], label_counts[2];
    sqffd_fit_report reports[2];
    sqffd_stack stacks[2];
    int k, found;
    for (k = 0; k < 2; k++) {
        frames[k] = (double *)test_malloc(16 * 96 * 3 * sizeof(double));
        labelled[k] = (double *)test_malloc(ROOM * 3 * sizeof(double));
    }
    counts[0] = stack(&p, 0.0, 0, 8, frames[0]);
    counts[1] = stack(&p, 0.5, 0, 8, frames[1]); /* (the base descends: its top plane misses the ES cavity) */
    for (k = 0; k < 2; k++) {
        CHECK_RESULT(sqffd_stack_detect(frames[k], counts[k], &stacks[k], &found), SQFFD_OK);
        CHECK(found);
    }
    ef = track_ejection(frames, counts, stacks, reports);
    printf("    stack: EF %.2f%% (the phantom's %.2f%%), errors %.3f%% / %.3f%%\n", 100.0 * ef, 100.0 * truth,
           100.0 * reports[0].error.rms_relative, 100.0 * reports[1].error.rms_relative);
    CHECK_MSG(fabs(ef - truth) <= 0.02, "EF %g, the phantom's %g", ef, truth);
    for (k = 0; k < 2; k++) { /* closed by their lids (as sqffd track does) */
        size_t n = 0;
        CHECK_RESULT(sqffd_stack_lids(frames[k], counts[k], &stacks[k], NULL, 0, &n), SQFFD_OK);
        CHECK(counts[k] + n <= ROOM);
        if (counts[k] + n > ROOM) break;
        memcpy(labelled[k], frames[k], 3 * counts[k] * sizeof(double));
        CHECK_RESULT(sqffd_stack_lids(frames[k], counts[k], &stacks[k], labelled[k] + 3 * counts[k],
                                      n, &n), SQFFD_OK);
        label_counts[k] = counts[k] + n;
    }
    ef_lids = track_ejection(labelled, label_counts, stacks, reports);
    printf("    with lids: EF %.2f%%, errors %.3f%% / %.3f%%\n", 100.0 * ef_lids, 100.0 * reports[0].error.rms_relative,
           100.0 * reports[1].error.rms_relative);
    CHECK_MSG(fabs(ef_lids - truth) <= 0.02, "EF %g with lids, the phantom's %g", ef_lids, truth);
    label_counts[0] = label_map_points(frames[0], counts[0], -p.height + 3.0, 8, labelled[0], ROOM);
    label_counts[1] = label_map_points(frames[1], counts[1], -p.height + 3.0, 8, labelled[1], ROOM);
    ef_labels = track_ejection(labelled, label_counts, NULL, reports);
    printf("    label map: EF %.2f%% from %lu and %lu surface points\n", 100.0 * ef_labels, (unsigned long)label_counts[0],
           (unsigned long)label_counts[1]);
    CHECK_MSG(fabs(ef_labels - ef) <= 0.02, "EF %g from the label maps, %g from the points", ef_labels, ef);
    for (k = 0; k < 2; k++) {
        free(frames[k]);
        free(labelled[k]);
    }
}

/* Stacks found where points lie slice by slice on parallel planes, at any
   orientation and with slices shifted in-plane: the planes' normal, their
   levels and spacing; none in points off their planes, too few planes, or
   a surface; bad input: result codes. */
static void test_points_stack(void)
{
    phantom_lv p = phantom_lv_default();
    double *pts = (double *)test_malloc(16 * 96 * 3 * sizeof *pts), rot[9], shifts[16];
    size_t n, i;
    sqffd_stack s;
    int found, k, c;
    synth_rng rng = synth_rng_seed(5);
    for (k = 0; k < 16; k++) shifts[k] = synth_range(&rng, -2.0, 2.0);
    {
        double levels[8];
        for (k = 0; k < 8; k++) levels[k] = -p.height + 3.0 + 7.0 * (double)k;
        n = phantom_lv_contours(&p, 0.0, levels, 8, 96, shifts, pts);
    }
    synth_rotation(&rng, rot); /* an oblique stack: the points rotated */
    for (i = 0; i < n; i++) {
        double q[3];
        for (c = 0; c < 3; c++) q[c] = rot[3 * c] * pts[3 * i] + rot[3 * c + 1] * pts[3 * i + 1] + rot[3 * c + 2] * pts[3 * i + 2];
        memcpy(pts + 3 * i, q, sizeof q);
    }
    CHECK_RESULT(sqffd_stack_detect(pts, n, &s, &found), SQFFD_OK);
    CHECK(found && s.planes == 8);
    if (found) {
        double along = fabs(s.axis[0] * rot[2] + s.axis[1] * rot[5] + s.axis[2] * rot[8]); /* the rotated z */
        CHECK_NEAR(along, 1.0, 1e-9);
        CHECK_NEAR(s.spacing, 7.0, 1e-9);
        for (k = 1; k < (int)s.planes; k++) CHECK_NEAR(s.level[k] - s.level[k - 1], 7.0, 1e-9);
    }
    pts[3 * 100 + 0] += 0.5 * rot[2]; /* one point off its plane */
    pts[3 * 100 + 1] += 0.5 * rot[5];
    pts[3 * 100 + 2] += 0.5 * rot[8];
    CHECK_RESULT(sqffd_stack_detect(pts, n, &s, &found), SQFFD_OK);
    CHECK(!found);
    CHECK_RESULT(sqffd_stack_detect(pts, 2 * 96, &s, &found), SQFFD_OK); /* two planes */
    CHECK(!found);
    phantom_lv_sample(&p, 0.0, 500, pts); /* a surface */
    CHECK_RESULT(sqffd_stack_detect(pts, 500, &s, &found), SQFFD_OK);
    CHECK(!found);
    pts[7] = NAN;
    CHECK_RESULT(sqffd_stack_detect(pts, 500, &s, &found), SQFFD_ERROR_NON_FINITE);
    CHECK_RESULT(sqffd_stack_detect(pts, 500, NULL, &found), SQFFD_ERROR_INVALID_ARGUMENT);
    free(pts);
}

/* Per-slice jumps no quadratic in the slice index can absorb, for 8
   equally spaced slices: the discrete orthogonal polynomials of degree 3
   and 4 (Fisher & Yates' table), orthogonal to 1, k and k^2. */
static const double jump_cubic[8] = {-7, 5, 7, 3, -3, -7, -5, 7};
static const double jump_quartic[8] = {7, -13, -3, 9, 9, -3, -13, 7};

/* Slice k of a stack of circles: radius r, centre c (in the plane z = level), 64 points, counter-clockwise unless cw. */
static size_t circle_slice(double *out, const double c[2], double r, double level, int cw)
{
    int j;
    for (j = 0; j < 64; j++) {
        double a = (cw ? -1.0 : 1.0) * 2.0 * 3.14159265358979323846 * j / 64.0;
        out[3 * j] = c[0] + r * cos(a);
        out[3 * j + 1] = c[1] + r * sin(a);
        out[3 * j + 2] = level;
    }
    return 64;
}

/* Two frames of circles along bent centrelines (quadratics in the level,
   a different one a frame, and different radii, the second drawn
   clockwise), their slices jumped by the degree-3 and -4 patterns, the
   whole rotated: each slice's shift is minus its jump, exactly, in the
   rotated plane; applied, the circles' centres lie on their centrelines.
   Three planes: zeros. Bad input: result codes. */
static void test_stack_shifts_exact(void)
{
    double *frames[2], rot[9], jump[8][3];
    size_t counts[2] = {0, 0}, moved, i;
    sqffd_points views[2];
    sqffd_stack stacks[2];
    sqffd_slice_shifts s;
    synth_rng rng = synth_rng_seed(29);
    int t, k, c, found;
    synth_rotation(&rng, rot);
    for (k = 0; k < 8; k++) {
        double local[3] = {0.15 * jump_cubic[k], -0.1 * jump_quartic[k], 0.0};
        for (c = 0; c < 3; c++) jump[k][c] = rot[3 * c] * local[0] + rot[3 * c + 1] * local[1];
    }
    for (t = 0; t < 2; t++) {
        frames[t] = (double *)test_malloc(8 * 64 * 3 * sizeof(double));
        for (k = 0; k < 8; k++) {
            double z = 5.0 * k, centre[2];
            centre[0] = 1.0 + (t ? -0.3 : 0.2) * z + (t ? 0.01 : 0.02) * z * z + 0.15 * jump_cubic[k];
            centre[1] = -2.0 + (t ? 0.05 : -0.1) * z - (t ? 0.004 : 0.0) * z * z - 0.1 * jump_quartic[k];
            counts[t] += circle_slice(frames[t] + 3 * counts[t], centre, (t ? 12.0 : 15.0) + 0.2 * z, z + 100.0, t);
        }
        for (i = 0; i < counts[t]; i++) {
            double q[3], *p = frames[t] + 3 * i;
            for (c = 0; c < 3; c++) q[c] = rot[3 * c] * p[0] + rot[3 * c + 1] * p[1] + rot[3 * c + 2] * p[2];
            memcpy(p, q, sizeof q);
        }
        views[t] = sqffd_points_packed(frames[t], counts[t]);
        CHECK_RESULT(sqffd_stack_detect_view(views[t], &stacks[t], &found), SQFFD_OK);
        CHECK(found && stacks[t].planes == 8);
    }
    CHECK_RESULT(sqffd_stack_shifts_view(views, stacks, 2, &s), SQFFD_OK);
    CHECK(s.slices == 8);
    { /* the packed form: the same shifts, to the bit */
        sqffd_slice_shifts packed;
        memset(&packed, 0xff, sizeof packed);
        CHECK_RESULT(sqffd_stack_shifts((const double *const *)frames, counts, stacks, 2, &packed), SQFFD_OK);
        CHECK(memcmp(&packed, &s, sizeof s) == 0);
        CHECK_RESULT(sqffd_stack_shifts(NULL, counts, stacks, 2, &packed), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_stack_shifts((const double *const *)frames, NULL, stacks, 2, &packed),
                     SQFFD_ERROR_INVALID_ARGUMENT);
    }
    for (k = 0; k < 8; k++) {
        int at = s.axis[0] * rot[2] + s.axis[1] * rot[5] + s.axis[2] * rot[8] > 0.0 ? k : 7 - k; /* slice k's */
        for (c = 0; c < 3; c++) CHECK_NEAR(s.shift[k][c], -jump[at][c], 1e-9);
    }
    for (t = 0; t < 2; t++) {
        CHECK_RESULT(sqffd_stack_shifts_apply(&s, frames[t], counts[t], &moved), SQFFD_OK);
        CHECK(moved == counts[t]);
    }
    CHECK_RESULT(sqffd_stack_shifts_view(views, stacks, 2, &s), SQFFD_OK); /* nothing left to move */
    for (k = 0; k < 8; k++)
        for (c = 0; c < 3; c++) CHECK_NEAR(s.shift[k][c], 0.0, 1e-9);
    views[0].count = 3 * 64; /* three planes: a quadratic explains any centres */
    CHECK_RESULT(sqffd_stack_detect_view(views[0], &stacks[0], &found), SQFFD_OK);
    CHECK(found);
    frames[0][3 * 64] += 2.0;
    CHECK_RESULT(sqffd_stack_shifts_view(views, stacks, 1, &s), SQFFD_OK);
    CHECK(s.slices == 3);
    for (k = 0; k < 3; k++)
        for (c = 0; c < 3; c++) CHECK_NEAR(s.shift[k][c], 0.0, 1e-9);
    CHECK_RESULT(sqffd_stack_shifts_view(NULL, stacks, 1, &s), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_stack_shifts_view(views, stacks, 0, &s), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_stack_shifts_view(views, stacks, 1, NULL), SQFFD_ERROR_INVALID_ARGUMENT);
    stacks[1].axis[0] = stacks[0].axis[1]; /* planes not parallel */
    stacks[1].axis[1] = -stacks[0].axis[0];
    stacks[1].axis[2] = 0.0;
    for (c = 0, s.tolerance = 0.0; c < 3; c++) s.tolerance += stacks[1].axis[c] * stacks[1].axis[c];
    for (c = 0; c < 3; c++) stacks[1].axis[c] /= sqrt(s.tolerance);
    CHECK_RESULT(sqffd_stack_shifts_view(views, stacks, 2, &s), SQFFD_ERROR_INVALID_ARGUMENT);
    stacks[1] = stacks[0];
    stacks[1].level[1] = stacks[1].level[0]; /* levels not ascending */
    CHECK_RESULT(sqffd_stack_shifts_view(views, stacks, 2, &s), SQFFD_ERROR_INVALID_ARGUMENT);
    {
        double two[6] = {0.0, 0.0, 0.0, 1e308, 0.0, 0.0}; /* the second moved past DBL_MAX: neither moves */
        sqffd_slice_shifts big;
        memset(&big, 0, sizeof big);
        big.axis[2] = 1.0;
        big.slices = 1;
        big.tolerance = 1.0;
        big.shift[0][0] = 1.5e308;
        CHECK_RESULT(sqffd_stack_shifts_apply(&big, two, 2, &moved), SQFFD_ERROR_NON_FINITE);
        CHECK(moved == 0 && two[0] == 0.0 && two[3] == 1e308);
    }
    frames[0][5] = NAN;
    CHECK_RESULT(sqffd_stack_shifts_view(views, stacks, 1, &s), SQFFD_ERROR_NON_FINITE);
    CHECK_RESULT(sqffd_stack_shifts_apply(&s, frames[0], 4, &moved), SQFFD_ERROR_NON_FINITE);
    CHECK_RESULT(sqffd_stack_shifts_apply(&s, NULL, 4, &moved), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_stack_shifts_apply(&s, NULL, 0, NULL), SQFFD_OK);
    for (t = 0; t < 2; t++) free(frames[t]);
}

/* The lids of a rotated stack of circles (radii growing along the stack):
   on the planes half a spacing beyond the outer slices, the outer circle's
   points there and rings of every 2nd, 3rd and 4th of them at 3/4, 1/2 and
   1/4 of its radius about its centre (the area centroid of a regular
   polygon); counted alone the same; bad input: result codes. */
static void test_stack_lids(void)
{
    double *pts = (double *)test_malloc(6 * 64 * 3 * sizeof(double)), *lids, rot[9], centre[2] = {3.0, -4.0};
    size_t n = 0, count = 0, need = 0, i, at[2][4] = {{0}};
    sqffd_stack s;
    synth_rng rng = synth_rng_seed(31);
    int k, c, found;
    synth_rotation(&rng, rot);
    for (k = 0; k < 6; k++) n += circle_slice(pts + 3 * n, centre, 10.0 + k, 8.0 * k, 0);
    for (i = 0; i < n; i++) {
        double q[3], *p = pts + 3 * i;
        for (c = 0; c < 3; c++) q[c] = rot[3 * c] * p[0] + rot[3 * c + 1] * p[1] + rot[3 * c + 2] * p[2];
        memcpy(p, q, sizeof q);
    }
    CHECK_RESULT(sqffd_stack_detect(pts, n, &s, &found), SQFFD_OK);
    CHECK(found && s.planes == 6);
    CHECK_RESULT(sqffd_stack_lids(pts, n, &s, NULL, 0, &need), SQFFD_OK);
    CHECK(need == 2 * (64 + 32 + 22 + 16)); /* every point, every 2nd, 3rd (0, 3, .., 63: 22) and 4th */
    lids = (double *)test_malloc(3 * need * sizeof(double));
    CHECK_RESULT(sqffd_stack_lids(pts, n, &s, lids, need, &count), SQFFD_OK);
    CHECK(count == need);
    for (i = 0; i < count; i++) {
        double local[3], r;
        int end, ring;
        for (c = 0; c < 3; c++) local[c] = rot[c] * lids[3 * i] + rot[3 + c] * lids[3 * i + 1] + rot[6 + c] * lids[3 * i + 2];
        end = fabs(local[2] - 44.0) < 1e-9 ? 1 : fabs(local[2] + 4.0) < 1e-9 ? 0 : -1; /* 40 + 4, 0 - 4 */
        CHECK_MSG(end >= 0, "lid point %lu at %g along the stack", (unsigned long)i, local[2]);
        r = hypot(local[0] - centre[0], local[1] - centre[1]) / (end ? 15.0 : 10.0);
        ring = (int)floor(4.0 * (1.0 - r) + 0.5);
        CHECK_MSG(ring >= 0 && ring < 4 && fabs(r - (1.0 - ring / 4.0)) < 1e-9, "lid point %lu at %g of the radius",
                  (unsigned long)i, r);
        if (end >= 0 && ring >= 0 && ring < 4) at[end][ring]++;
    }
    for (k = 0; k < 2; k++) CHECK(at[k][0] == 64 && at[k][1] == 32 && at[k][2] == 22 && at[k][3] == 16);
    { /* the view form, over floats with a fourth field: the same lids as the floats' doubles */
        float *records = (float *)test_malloc(4 * n * sizeof(float));
        double *widened = (double *)test_malloc(3 * n * sizeof(double)), *again = (double *)test_malloc(3 * need * sizeof(double));
        size_t got = 0;
        for (i = 0; i < n; i++)
            for (c = 0; c < 4; c++) {
                records[4 * i + (size_t)c] = c < 3 ? (float)pts[3 * i + (size_t)c] : -1.0f;
                if (c < 3) widened[3 * i + (size_t)c] = (double)records[4 * i + (size_t)c];
            }
        CHECK_RESULT(sqffd_stack_lids(widened, n, &s, lids, need, &count), SQFFD_OK);
        CHECK_RESULT(sqffd_stack_lids_view(sqffd_points_strided(records, n, 4 * sizeof(float), SQFFD_SCALAR_FLOAT), &s,
                                           again, need, &got), SQFFD_OK);
        CHECK(got == count && memcmp(again, lids, 3 * count * sizeof(double)) == 0);
        free(records);
        free(widened);
        free(again);
        CHECK_RESULT(sqffd_stack_lids(pts, n, &s, lids, need, &count), SQFFD_OK);
    }
    /* one point short: OUTPUT_TOO_SMALL found before anything is written, the count needed */
    memset(lids, 0, 3 * need * sizeof(double));
    count = 0;
    CHECK_RESULT(sqffd_stack_lids(pts, n, &s, lids, need - 1, &count), SQFFD_ERROR_OUTPUT_TOO_SMALL);
    CHECK(count == need && test_all_zero(lids, 3 * need));
    CHECK_RESULT(sqffd_stack_lids(pts, n, &s, NULL, 1, &count), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_stack_lids(pts, n, &s, lids, need, NULL), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_stack_lids(pts, n, NULL, lids, need, &count), SQFFD_ERROR_INVALID_ARGUMENT);
    s.spacing = -1.0;
    CHECK_RESULT(sqffd_stack_lids(pts, n, &s, lids, need, &count), SQFFD_ERROR_INVALID_ARGUMENT);
    s.spacing = 8.0;
    for (i = 0; i < 3 * n; i++) pts[i] *= 1e300; /* areas past DBL_MAX: refused or finite, never NaN written */
    s.spacing *= 1e300;
    for (k = 0; k < 6; k++) s.level[k] *= 1e300;
    {
        sqffd_result r = sqffd_stack_lids(pts, n, &s, lids, need, &count);
        CHECK(r == SQFFD_OK || r == SQFFD_ERROR_NON_FINITE);
        for (i = 0; r == SQFFD_OK && i < 3 * count; i++) CHECK_MSG(isfinite(lids[i]), "lid coordinate %lu: %g", (unsigned long)i, lids[i]);
    }
    pts[4] = NAN; /* found before the work: outputs untouched */
    memset(lids, 0, 3 * need * sizeof(double));
    count = 7;
    CHECK_RESULT(sqffd_stack_lids(pts, n, &s, lids, need, &count), SQFFD_ERROR_NON_FINITE);
    CHECK(count == 7 && test_all_zero(lids, 3 * need));
    free(lids);
    free(pts);
}

/* The phantom's ED and ES stacks (a plain cup; ES a slice shorter at the base), each
   slice moved in-plane by the same random shift in both frames (one
   breath-hold a slice, up to 2 mm): the shifts found are the truth's jumps
   (its part no quadratic in the level explains, the only part that can be
   told from the anatomy) within a fifth of their size; corrected, both
   fits come closer to the points and the track keeps the phantom's
   ejection fraction within 2 points, fold-free. */
static void test_stack_shifts_phantom(void)
{
    static const double linear[8] = {-7, -5, -3, -1, 1, 3, 5, 7}, quadratic[8] = {7, 1, -3, -5, -5, -3, 1, 7};
    phantom_lv p = phantom_lv_default();
    double *frames[2], levels[8], truth[16], jumps[16], err2 = 0.0, size2 = 0.0, before[2], ef;
    size_t counts[2];
    sqffd_points views[2];
    sqffd_stack stacks[2];
    sqffd_slice_shifts s;
    sqffd_fit_report reports[2];
    synth_rng rng = synth_rng_seed(17);
    int t, k, c, found;
    p.bump_height = 0.0; /* a plain cup: the bumps bend its centreline faster than a quadratic (read as ~0.2 mm) */
    for (k = 0; k < 8; k++) {
        levels[k] = -p.height + 3.0 + 7.0 * (double)k;
        for (c = 0; c < 2; c++) truth[2 * k + c] = synth_range(&rng, -2.0, 2.0);
    }
    for (c = 0; c < 2; c++) { /* the jumps: the truth less its projection on 1, k and k^2 */
        double mean = 0.0, a = 0.0, b = 0.0;
        for (k = 0; k < 8; k++) {
            mean += truth[2 * k + c] / 8.0;
            a += truth[2 * k + c] * linear[k] / 168.0;
            b += truth[2 * k + c] * quadratic[k] / 168.0;
        }
        for (k = 0; k < 8; k++) jumps[2 * k + c] = truth[2 * k + c] - mean - a * linear[k] - b * quadratic[k];
    }
    for (t = 0; t < 2; t++) {
        frames[t] = (double *)test_malloc(8 * 96 * 3 * sizeof(double));
        counts[t] = phantom_lv_contours(&p, 0.5 * t, levels, t ? 7 : 8, 96, truth, frames[t]);
        views[t] = sqffd_points_packed(frames[t], counts[t]);
        CHECK_RESULT(sqffd_stack_detect_view(views[t], &stacks[t], &found), SQFFD_OK);
        CHECK(found);
    }
    ef = track_ejection(frames, counts, stacks, reports);
    for (t = 0; t < 2; t++) before[t] = reports[t].error.rms_relative;
    CHECK_RESULT(sqffd_stack_shifts_view(views, stacks, 2, &s), SQFFD_OK);
    CHECK(s.slices == 8 && s.axis[2] > 0.0);
    for (k = 0; k < 8; k++) {
        for (c = 0; c < 2; c++) {
            err2 += (s.shift[k][c] + jumps[2 * k + c]) * (s.shift[k][c] + jumps[2 * k + c]);
            size2 += jumps[2 * k + c] * jumps[2 * k + c];
        }
        CHECK_NEAR(s.shift[k][2], 0.0, 1e-9);
    }
    for (t = 0; t < 2; t++) CHECK_RESULT(sqffd_stack_shifts_apply(&s, frames[t], counts[t], NULL), SQFFD_OK);
    ef = track_ejection(frames, counts, stacks, reports);
    printf("    shifts: found within %.3f mm RMS of the jumps (%.3f mm RMS); errors %.3f%% / %.3f%% -> %.3f%% / %.3f%%, "
           "EF %.2f%% (the phantom's %.2f%%)\n", sqrt(err2 / 8.0), sqrt(size2 / 8.0), 100.0 * before[0],
           100.0 * before[1], 100.0 * reports[0].error.rms_relative, 100.0 * reports[1].error.rms_relative, 100.0 * ef,
           100.0 * phantom_lv_ejection_fraction(&p, 2));
    CHECK_MSG(err2 <= 0.04 * size2, "shifts off by %g mm RMS, the jumps %g", sqrt(err2 / 8.0), sqrt(size2 / 8.0));
    for (t = 0; t < 2; t++)
        CHECK_MSG(reports[t].error.rms_relative < before[t], "frame %d: error %g, %g before", t,
                  reports[t].error.rms_relative, before[t]);
    CHECK_MSG(fabs(ef - phantom_lv_ejection_fraction(&p, 2)) <= 0.02, "EF %g", ef);
    for (t = 0; t < 2; t++) free(frames[t]);
}

/* A superquadric the validation accepts at its extremes (e1 just above 0,
   a size 1e-284 of another's): its mesh (on the grid at equal arc length)
   is finite, its region certified or refused as NON_FINITE (never a
   walk over NaN cells), and F at its centre, which the logarithms cannot
   give, NON_FINITE rather than a NaN called a success. A lattice box too
   small and too far for the surface's deformation to be computed: its
   mesh NON_FINITE. With e = 4 the normals underflow at some points: those
   points NON_FINITE, never a NaN normal called a success. */
static void test_extreme_superquadric(void)
{
    sqffd_fit_options o = sqffd_fit_options_default();
    sqffd_superquadric sq;
    sqffd_model m;
    size_t v, count = 32 * 64 + 2;
    double *vertices = (double *)test_malloc(3 * count * sizeof(double)), value, bound;
    uint32_t *triangles = (uint32_t *)test_malloc(3 * 2 * 32 * 64 * sizeof(uint32_t));
    sqffd_result r;
    memset(&sq, 0, sizeof sq);
    sq.size[0] = 1.0; sq.size[1] = 1e-284; sq.size[2] = 0.5;
    sq.shape[0] = 3e-309; sq.shape[1] = 1.5;
    sq.taper[0] = 0.3;
    sq.rotation[1] = 1.0; sq.rotation[3] = -1.0; sq.rotation[8] = 1.0;
    sq.center[2] = 3.0;
    CHECK_RESULT(sqffd_sq_validate(&sq), SQFFD_OK);
    CHECK_RESULT(sqffd_model_init(&m, &sq, &o), SQFFD_OK);
    CHECK_RESULT(sqffd_model_mesh(&m, 32, 64, vertices, triangles), SQFFD_OK);
    for (v = 0; v < 3 * count; v++) CHECK_MSG(isfinite(vertices[v]), "vertex coordinate %zu: %g", v, vertices[v]);
    r = region_bound(&m, 0.0, &bound);
    CHECK_MSG(r == SQFFD_OK ? isfinite(bound) : r == SQFFD_ERROR_NON_FINITE, "region bound: %s, %g", sqffd_result_string(r), bound);
    r = sqffd_sq_inside_outside(&sq, sq.center, &value);
    CHECK_MSG(r == SQFFD_OK ? !isnan(value) : r == SQFFD_ERROR_NON_FINITE, "F at the centre: %s, %g", sqffd_result_string(r), value);
    { /* a lattice box 1e-100 across, 1e150 away: the surface in its coordinates overflows: NON_FINITE, not a NaN mesh */
        const int dims[3] = {5, 5, 5};
        const double origin[3] = {1e150, 0.0, 0.0}, edges[9] = {1e-100, 0, 0, 0, 1e-100, 0, 0, 0, 1e-100};
        CHECK_RESULT(sqffd_ffd_init(&m.ffd, dims, origin, edges), SQFFD_OK);
        CHECK_RESULT(sqffd_model_validate(&m), SQFFD_OK);
        CHECK_RESULT(sqffd_model_mesh(&m, 32, 64, vertices, triangles), SQFFD_ERROR_NON_FINITE);
        r = region_bound(&m, 0.0, &bound); /* (the surface's box coordinates are finite, far outside it) */
        CHECK_MSG(r == SQFFD_OK ? isfinite(bound) : r == SQFFD_ERROR_NON_FINITE, "region bound: %s", sqffd_result_string(r));
    }
    { /* e = 4 with a size 1e-284 of another's: a point and normal called a success are finite */
        const double pi = 3.14159265358979323846;
        double *grid = (double *)test_malloc(2 * 3 * 41 * 80 * sizeof(double));
        int i, j, refused = 0;
        sq.shape[0] = sq.shape[1] = 4.0;
        for (i = 0; i <= 40; i++)
            for (j = 0; j < 80; j++) {
                double p[3], n[3];
                r = sqffd_sq_point(&sq, -0.5 * pi + pi * i / 40.0, -pi + pi * j / 40.0, p, n);
                if (r == SQFFD_OK) CHECK(isfinite(p[0] + p[1] + p[2]) && isfinite(n[0] + n[1] + n[2]));
                else {
                    CHECK_RESULT(r, SQFFD_ERROR_NON_FINITE);
                    ++refused;
                }
            }
        r = sqffd_sq_sample_grid(&sq, 41, 80, grid, grid + 3 * 41 * 80);
        CHECK_RESULT(r, refused ? SQFFD_ERROR_NON_FINITE : SQFFD_OK);
        printf("    e = 4, sizes 1 : 1e-284: %d of 3,280 points refused\n", refused);
        free(grid);
    }
    free(vertices);
    free(triangles);
}

void suite_fold(void)
{
    RUN_TEST(test_points_stack);
    RUN_TEST(test_jacobian_bound);
    RUN_TEST(test_extreme_superquadric);
    RUN_TEST(test_fit_stack_fold_free);
    RUN_TEST(test_track_stack_ejection);
    RUN_TEST(test_stack_shifts_exact);
    RUN_TEST(test_stack_shifts_phantom);
    RUN_TEST(test_stack_lids);
}

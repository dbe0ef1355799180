/* Point views (sqffd_points): every function that takes points reads a
   float or double view of any stride and alignment in place, with the same
   results, to the bit, as its simple form on the same values packed as
   doubles (a float widens to double exactly); bad views are refused. */
#include "test.h"
#include "../examples/sqffd_phantom.h"
#include <stdlib.h>
#include <string.h>

#define VIEW_POINTS 1500
#define VIEW_FRAMES 3

/* A scanner-like record: x y z as floats inside 20 bytes (an intensity and
   a colour beside them), laid out from an odd address. */
#define FLOAT_STRIDE 20u
/* A double record: x y z and a fourth double, from an address 8k + 4. */
#define DOUBLE_STRIDE 32u

typedef struct views {
    size_t n;
    double *packed;          /* the values the views hold, packed (float-rounded for the float view) */
    unsigned char *float_buf, *double_buf;
    sqffd_points as_float;   /* of packed's values, rounded to float first */
    sqffd_points as_double;  /* of packed's values */
    double *packed_float;    /* the float view's values as packed doubles */
} views;

/* Phantom points at a phase, written three ways. */
static views make_views(double phase, size_t n, uint64_t seed)
{
    phantom_lv p = phantom_lv_default();
    views v;
    size_t i;
    int k;
    v.n = n;
    v.packed = (double *)test_malloc(3 * n * sizeof(double));
    v.packed_float = (double *)test_malloc(3 * n * sizeof(double));
    v.float_buf = (unsigned char *)test_malloc(n * FLOAT_STRIDE + 1);
    v.double_buf = (unsigned char *)test_malloc(n * DOUBLE_STRIDE + 4);
    phantom_lv_frame(&p, phase, n, 0.005, seed, v.packed, NULL);
    memset(v.float_buf, 0xA5, n * FLOAT_STRIDE + 1);
    memset(v.double_buf, 0x5A, n * DOUBLE_STRIDE + 4);
    for (i = 0; i < n; i++) {
        float f[3];
        for (k = 0; k < 3; k++) {
            f[k] = (float)v.packed[3 * i + (size_t)k];
            v.packed_float[3 * i + (size_t)k] = f[k];
        }
        memcpy(v.float_buf + 1 + i * FLOAT_STRIDE, f, sizeof f);
        memcpy(v.double_buf + 4 + i * DOUBLE_STRIDE, v.packed + 3 * i, 3 * sizeof(double));
    }
    v.as_float = sqffd_points_strided(v.float_buf + 1, n, FLOAT_STRIDE, SQFFD_SCALAR_FLOAT);
    v.as_double = sqffd_points_strided(v.double_buf + 4, n, DOUBLE_STRIDE, SQFFD_SCALAR_DOUBLE);
    return v;
}

static void free_views(views *v)
{
    free(v->packed);
    free(v->packed_float);
    free(v->float_buf);
    free(v->double_buf);
}

static int same_model(const sqffd_model *a, const sqffd_model *b)
{
    unsigned char sa[8192], sb[8192];
    size_t na, nb;
    return sqffd_model_save_size(a, &na) == SQFFD_OK && sqffd_model_save_size(b, &nb) == SQFFD_OK && na == nb &&
           na <= sizeof sa && sqffd_model_save(a, sa, sizeof sa) == SQFFD_OK &&
           sqffd_model_save(b, sb, sizeof sb) == SQFFD_OK && memcmp(sa, sb, na) == 0;
}

static int same_doubles(const double *a, const double *b, size_t count)
{
    return memcmp(a, b, count * sizeof(double)) == 0;
}

/* The kd-tree: the same nodes and the same answers as over packed doubles;
   a refit onto a moved view matches a refit onto the moved packed points. */
static void test_points_kdtree(void)
{
    views v = make_views(0.0, VIEW_POINTS, 31);
    size_t size = 0, i, k;
    void *ws_view, *ws_packed;
    sqffd_kdtree view_tree, packed_tree;
    int pass;
    CHECK_RESULT(sqffd_kdtree_workspace_size(v.n, &size), SQFFD_OK);
    ws_view = test_malloc(size);
    ws_packed = test_malloc(size);
    for (pass = 0; pass < 2; pass++) {
        const sqffd_points *view = pass ? &v.as_double : &v.as_float;
        const double *packed = pass ? v.packed : v.packed_float;
        CHECK_RESULT(sqffd_kdtree_build_view(&view_tree, *view, ws_view, size), SQFFD_OK);
        CHECK_RESULT(sqffd_kdtree_build(&packed_tree, packed, v.n, ws_packed, size), SQFFD_OK);
        CHECK(view_tree.node_count == packed_tree.node_count);
        CHECK(memcmp(view_tree.nodes, packed_tree.nodes, packed_tree.node_count * sizeof *packed_tree.nodes) == 0);
        CHECK(memcmp(view_tree.index, packed_tree.index, v.n * sizeof *packed_tree.index) == 0);
        CHECK(view_tree.points.xyz == view->xyz);
        for (i = 0; i < 50; i++) {
            double q[3], d_view[8], d_packed[8];
            size_t i_view[8], i_packed[8], found_view = 0, found_packed = 0;
            for (k = 0; k < 3; k++) q[k] = packed[3 * (i * 29 % v.n) + k] + 0.01 * (double)k;
            CHECK_RESULT(sqffd_kdtree_knn(&view_tree, q, 8, i_view, d_view, &found_view), SQFFD_OK);
            CHECK_RESULT(sqffd_kdtree_knn(&packed_tree, q, 8, i_packed, d_packed, &found_packed), SQFFD_OK);
            CHECK(found_view == 8 && found_packed == 8);
            CHECK(memcmp(i_view, i_packed, sizeof i_view) == 0 && same_doubles(d_view, d_packed, 8));
        }
    }
    { /* refit: both trees (over the double view and over v.packed) onto moved points */
        views moved = make_views(0.3, VIEW_POINTS, 31);
        double q[3] = {0.1, 0.2, 0.3}, d_view = 0.0, d_packed = 0.0;
        size_t n_view = 0, n_packed = 0;
        CHECK_RESULT(sqffd_kdtree_refit_view(&view_tree, moved.as_double), SQFFD_OK);
        CHECK_RESULT(sqffd_kdtree_refit(&packed_tree, moved.packed), SQFFD_OK);
        CHECK(memcmp(view_tree.nodes, packed_tree.nodes, packed_tree.node_count * sizeof *packed_tree.nodes) == 0);
        CHECK_RESULT(sqffd_kdtree_nearest(&view_tree, q, &n_view, &d_view), SQFFD_OK);
        CHECK_RESULT(sqffd_kdtree_nearest(&packed_tree, q, &n_packed, &d_packed), SQFFD_OK);
        CHECK(n_view == n_packed && d_view == d_packed);
        /* a view of another count is refused, the tree kept */
        moved.as_double.count--;
        CHECK_RESULT(sqffd_kdtree_refit_view(&view_tree, moved.as_double), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK(view_tree.points.count == v.n);
        free_views(&moved);
    }
    free(ws_view);
    free(ws_packed);
    free_views(&v);
}

/* Stage 1, the whole fit, the FFD stage, the prepared system, the
   distances both ways and the subsample: bit for bit. */
static void test_points_fit(void)
{
    views v = make_views(0.0, VIEW_POINTS, 32);
    sqffd_fit_options opt = sqffd_fit_options_default();
    size_t size = 0, sq_size = 0, m;
    void *ws;
    int pass;
    opt.max_iterations = 8;
    opt.ffd_max_points = 1000; /* the FFD stage on a subsample, the error on all points */
    CHECK_RESULT(sqffd_fit_workspace_size(v.n, &opt, &size), SQFFD_OK);
    CHECK_RESULT(sqffd_sq_fit_workspace_size(v.n, &opt.sq, &sq_size), SQFFD_OK);
    size = size > sq_size ? size : sq_size;
    ws = test_malloc(size);
    for (pass = 0; pass < 2; pass++) {
        const sqffd_points view = pass ? v.as_double : v.as_float;
        const double *packed = pass ? v.packed : v.packed_float;
        sqffd_superquadric sq_view, sq_packed;
        sqffd_sq_fit_report sr_view, sr_packed;
        sqffd_model m_view, m_packed, start;
        sqffd_fit_report r_view, r_packed;
        sqffd_distance_stats s_view, s_packed;
        sqffd_ffd_system system;
        size_t system_size = 0, dsize = 0;
        void *system_memory, *dws;
        double *per_view, *per_packed, *sub_view, *sub_packed;

        CHECK_RESULT(sqffd_sq_fit_view(view, &opt.sq, &sq_view, &sr_view, ws, size), SQFFD_OK);
        CHECK_RESULT(sqffd_sq_fit(packed, v.n, &opt.sq, &sq_packed, &sr_packed, ws, size), SQFFD_OK);
        CHECK(memcmp(&sq_view, &sq_packed, sizeof sq_view) == 0);

        CHECK_RESULT(sqffd_fit_view(view, &opt, &m_view, &r_view, ws, size), SQFFD_OK);
        CHECK_RESULT(sqffd_fit(packed, v.n, &opt, &m_packed, &r_packed, ws, size), SQFFD_OK);
        CHECK(same_model(&m_view, &m_packed));
        CHECK(r_view.error.rms == r_packed.error.rms && r_view.iterations == r_packed.iterations);
        CHECK(r_view.error.rms_relative < 0.02);

        start = m_view; /* the FFD stage again from the fitted model */
        CHECK_RESULT(sqffd_fit_ffd_view(view, &opt, &m_view, &r_view, ws, size), SQFFD_OK);
        m_packed = start;
        CHECK_RESULT(sqffd_fit_ffd(packed, v.n, &opt, &m_packed, &r_packed, ws, size), SQFFD_OK);
        CHECK(same_model(&m_view, &m_packed));

        CHECK_RESULT(sqffd_ffd_system_size(&start, &system_size), SQFFD_OK);
        system_memory = test_malloc(system_size);
        CHECK_RESULT(sqffd_ffd_system_init(&system, &start, &opt, system_memory, system_size), SQFFD_OK);
        m_view = m_packed = start;
        CHECK_RESULT(sqffd_fit_prepared_view(&system, view, &opt, &m_view, &r_view, ws, size), SQFFD_OK);
        CHECK_RESULT(sqffd_fit_prepared(&system, packed, v.n, &opt, &m_packed, &r_packed, ws, size), SQFFD_OK);
        CHECK(same_model(&m_view, &m_packed));
        free(system_memory);

        per_view = (double *)test_malloc(v.n * sizeof(double));
        per_packed = (double *)test_malloc(v.n * sizeof(double));
        CHECK_RESULT(sqffd_model_distances_workspace_size(v.n, &m_view, &dsize), SQFFD_OK);
        dws = test_malloc(dsize);
        CHECK_RESULT(sqffd_model_distances_view(&m_view, view, per_view, &s_view, dws, dsize), SQFFD_OK);
        CHECK_RESULT(sqffd_model_distances(&m_view, packed, v.n, per_packed, &s_packed, dws, dsize), SQFFD_OK);
        CHECK(same_doubles(per_view, per_packed, v.n) && s_view.rms == s_packed.rms);
        free(dws);
        CHECK_RESULT(sqffd_model_reverse_distances_workspace_size(v.n, &m_view, &dsize), SQFFD_OK);
        dws = test_malloc(dsize);
        m = (size_t)m_view.grid[0] * (size_t)m_view.grid[1] + 2;
        free(per_view);
        free(per_packed);
        per_view = (double *)test_malloc(m * sizeof(double));
        per_packed = (double *)test_malloc(m * sizeof(double));
        CHECK_RESULT(sqffd_model_reverse_distances_view(&m_view, view, per_view, &s_view, dws, dsize), SQFFD_OK);
        CHECK_RESULT(sqffd_model_reverse_distances(&m_view, packed, v.n, per_packed, &s_packed, dws, dsize), SQFFD_OK);
        CHECK(same_doubles(per_view, per_packed, m) && s_view.max == s_packed.max);
        free(dws);
        free(per_view);
        free(per_packed);

        sub_view = (double *)test_malloc(3 * 100 * sizeof(double));
        sub_packed = (double *)test_malloc(3 * 100 * sizeof(double));
        CHECK_RESULT(sqffd_points_subsample_view(view, 100, sub_view), SQFFD_OK);
        CHECK_RESULT(sqffd_points_subsample(packed, v.n, 100, sub_packed), SQFFD_OK);
        CHECK(same_doubles(sub_view, sub_packed, 300));
        free(sub_view);
        free(sub_packed);
    }
    free(ws);
    free_views(&v);
}

/* A sequence of float views tracks as its packed doubles do. */
static void test_points_track(void)
{
    views v[VIEW_FRAMES];
    sqffd_points frames[VIEW_FRAMES];
    const double *packed[VIEW_FRAMES];
    size_t counts[VIEW_FRAMES], t, size = 0, view_size = 1, done_view = 9, done_packed = 9;
    sqffd_model m_view[VIEW_FRAMES], m_packed[VIEW_FRAMES];
    sqffd_track_options opt = sqffd_track_options_default();
    void *ws;
    opt.fit.max_iterations = 10;
    opt.frame_iterations = 4;
    for (t = 0; t < VIEW_FRAMES; t++) {
        v[t] = make_views(0.2 * (double)t, VIEW_POINTS - 100 * t, 40 + t);
        frames[t] = v[t].as_float;
        packed[t] = v[t].packed_float;
        counts[t] = v[t].n;
    }
    CHECK_RESULT(sqffd_track_workspace_size(counts, VIEW_FRAMES, &opt, &size), SQFFD_OK);
    CHECK_RESULT(sqffd_track_view_workspace_size(frames, VIEW_FRAMES, &opt, &view_size), SQFFD_OK);
    CHECK(view_size == size); /* the size depends on the counts alone */
    ws = test_malloc(size);
    CHECK_RESULT(sqffd_track_view(frames, VIEW_FRAMES, &opt, m_view, NULL, &done_view, ws, size - 1),
                 SQFFD_ERROR_WORKSPACE_TOO_SMALL);
    CHECK_RESULT(sqffd_track_view(frames, VIEW_FRAMES, &opt, m_view, NULL, &done_view, ws, size), SQFFD_OK);
    CHECK_RESULT(sqffd_track(packed, counts, VIEW_FRAMES, &opt, m_packed, NULL, &done_packed, ws, size), SQFFD_OK);
    CHECK(done_view == VIEW_FRAMES && done_packed == VIEW_FRAMES);
    for (t = 0; t < VIEW_FRAMES; t++) CHECK_MSG(same_model(&m_view[t], &m_packed[t]), "frame %zu", t);
    /* a bad view in frame 1: its index, frame 0 kept */
    frames[1].stride = 4;
    CHECK_RESULT(sqffd_track_view(frames, VIEW_FRAMES, &opt, m_view, NULL, &done_view, ws, size),
                 SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK(done_view == 1 && same_model(&m_view[0], &m_packed[0]));
    CHECK_RESULT(sqffd_track_view(NULL, VIEW_FRAMES, &opt, m_view, NULL, &done_view, ws, size),
                 SQFFD_ERROR_INVALID_ARGUMENT);
    /* the size call refuses what the count decides: no frames, an empty frame */
    CHECK_RESULT(sqffd_track_view_workspace_size(NULL, VIEW_FRAMES, &opt, &view_size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK(view_size == 0);
    CHECK_RESULT(sqffd_track_view_workspace_size(frames, 0, &opt, &view_size), SQFFD_ERROR_INVALID_ARGUMENT);
    frames[2].count = 0;
    view_size = 1;
    CHECK_RESULT(sqffd_track_view_workspace_size(frames, VIEW_FRAMES, &opt, &view_size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK(view_size == 0);
    CHECK_RESULT(sqffd_track_view_workspace_size(frames, VIEW_FRAMES, &opt, NULL), SQFFD_ERROR_INVALID_ARGUMENT);
    free(ws);
    for (t = 0; t < VIEW_FRAMES; t++) free_views(&v[t]);
}

/* Bad views: refused with their code before anything is written. */
static void test_points_bad_views(void)
{
    views v = make_views(0.0, 200, 33);
    sqffd_fit_options opt = sqffd_fit_options_default();
    sqffd_model model, untouched;
    sqffd_kdtree tree;
    size_t size = 0, dsize = 0;
    void *ws;
    double out[6];
    float with_nan[3 * 50];
    size_t i;
    struct { sqffd_points view; sqffd_result expected; } cases[8];
    size_t c, count = 0;
    CHECK_RESULT(sqffd_fit_workspace_size(v.n, &opt, &size), SQFFD_OK);
    ws = test_malloc(size);
    for (i = 0; i < 150; i++) with_nan[i] = (float)v.packed[i];
    with_nan[77] = (float)NAN;

    cases[count].view = sqffd_points_strided(NULL, v.n, 12, SQFFD_SCALAR_FLOAT);
    cases[count++].expected = SQFFD_ERROR_INVALID_ARGUMENT;
    cases[count].view = sqffd_points_strided(v.float_buf, v.n, 12, (sqffd_scalar)7);
    cases[count++].expected = SQFFD_ERROR_INVALID_ARGUMENT;
    cases[count].view = sqffd_points_strided(v.float_buf, v.n, 11, SQFFD_SCALAR_FLOAT); /* < 3 floats */
    cases[count++].expected = SQFFD_ERROR_INVALID_ARGUMENT;
    cases[count].view = sqffd_points_strided(v.double_buf, v.n, 16, SQFFD_SCALAR_DOUBLE); /* < 3 doubles */
    cases[count++].expected = SQFFD_ERROR_INVALID_ARGUMENT;
    cases[count].view = sqffd_points_strided(v.double_buf, v.n, (size_t)-1 / 8, SQFFD_SCALAR_DOUBLE); /* past size_t */
    cases[count++].expected = SQFFD_ERROR_TOO_LARGE;
    cases[count].view = sqffd_points_strided(with_nan, 50, 12, SQFFD_SCALAR_FLOAT);
    cases[count++].expected = SQFFD_ERROR_NON_FINITE;

    memset(&model, 0x3C, sizeof model);
    untouched = model;
    for (c = 0; c < count; c++) {
        sqffd_result e = cases[c].expected;
        CHECK_RESULT(sqffd_fit_view(cases[c].view, &opt, &model, NULL, ws, size), e);
        CHECK_MSG(memcmp(&model, &untouched, sizeof model) == 0, "case %zu wrote the model", c);
        CHECK_RESULT(sqffd_kdtree_build_view(&tree, cases[c].view, ws, size), e);
        if (e != SQFFD_ERROR_NON_FINITE) CHECK_RESULT(sqffd_points_subsample_view(cases[c].view, 2, out), e);
    }
    /* the distance functions and stage 1, on one view of each kind */
    CHECK_RESULT(sqffd_fit_view(v.as_float, &opt, &model, NULL, ws, size), SQFFD_OK);
    CHECK_RESULT(sqffd_model_distances_workspace_size(v.n, &model, &dsize), SQFFD_OK);
    CHECK(dsize <= size);
    for (c = 0; c < count; c++) {
        sqffd_result e = cases[c].expected;
        CHECK_RESULT(sqffd_model_distances_view(&model, cases[c].view, NULL, NULL, ws, size), e);
        CHECK_RESULT(sqffd_model_reverse_distances_view(&model, cases[c].view, NULL, NULL, ws, size), e);
        CHECK_RESULT(sqffd_sq_fit_view(cases[c].view, NULL, &model.sq, NULL, ws, size), e);
    }
    /* k = 0 asks for nothing: no view needed */
    CHECK_RESULT(sqffd_points_subsample_view(sqffd_points_strided(NULL, 0, 0, SQFFD_SCALAR_DOUBLE), 0, NULL), SQFFD_OK);
    free(ws);
    free_views(&v);
}

void suite_points(void)
{
    RUN_TEST(test_points_kdtree);
    RUN_TEST(test_points_fit);
    RUN_TEST(test_points_track);
    RUN_TEST(test_points_bad_views);
}

/* Tests: stored models are data. Validation of superquadrics, lattices and
   models at every entry that takes them, and the saved byte form (layout,
   round trip, every byte flipped, truncation, other lattice builds). */
#include "test.h"
#include "../examples/sqffd_synth.h"
#include "../examples/sqffd_phantom.h"
#include <stdlib.h>
#include <string.h>

/* A model whose every field matters: a turned, tapered superquadric, a
   jiggled 5 x 5 x 5 lattice. */
static sqffd_model test_model(void)
{
    sqffd_fit_options o = sqffd_fit_options_default();
    sqffd_superquadric sq;
    sqffd_model m;
    synth_rng r = synth_rng_seed(21);
    int p, c;
    memset(&sq, 0, sizeof sq);
    sq.size[0] = 1.2; sq.size[1] = 0.7; sq.size[2] = 1.9;
    sq.shape[0] = 0.6; sq.shape[1] = 1.3;
    sq.taper[0] = 0.25; sq.taper[1] = -0.15;
    synth_rotation(&r, sq.rotation);
    sq.center[0] = -0.4; sq.center[1] = 2.5; sq.center[2] = 0.1;
    CHECK_RESULT(sqffd_model_init(&m, &sq, &o), SQFFD_OK);
    for (p = 0; p < 125; p++)
        for (c = 0; c < 3; c++) m.ffd.control[p][c] += 0.1 * synth_range(&r, -1.0, 1.0);
    return m;
}

/* CRC-32 (IEEE, reflected), written here from the definition (a byte table
   built bit by bit) so the tests can make records with a right checksum but
   wrong contents. */
static uint32_t crc32_of(const unsigned char *p, size_t n)
{
    static uint32_t table[256];
    uint32_t crc = 0xFFFFFFFFu;
    size_t i;
    if (!table[1])
        for (i = 0; i < 256; i++) {
            uint32_t c = (uint32_t)i;
            int b;
            for (b = 0; b < 8; b++) c = (c & 1u) ? (c >> 1) ^ 0xEDB88320u : c >> 1;
            table[i] = c;
        }
    for (i = 0; i < n; i++) crc = (crc >> 8) ^ table[(crc ^ p[i]) & 255u];
    return crc ^ 0xFFFFFFFFu;
}

static void put_u32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)v; p[1] = (unsigned char)(v >> 8); p[2] = (unsigned char)(v >> 16); p[3] = (unsigned char)(v >> 24);
}

static void reseal(unsigned char *bytes, size_t size)
{
    put_u32(bytes + size - 4, crc32_of(bytes, size - 4));
}

static int same_model(const sqffd_model *a, const sqffd_model *b)
{
    int k, used = a->ffd.dims[0] * a->ffd.dims[1] * a->ffd.dims[2];
    if (memcmp(&a->sq, &b->sq, sizeof a->sq) != 0 || memcmp(a->ffd.dims, b->ffd.dims, sizeof a->ffd.dims) != 0 ||
        memcmp(a->ffd.origin, b->ffd.origin, sizeof a->ffd.origin) != 0 ||
        memcmp(a->ffd.edges, b->ffd.edges, sizeof a->ffd.edges) != 0 ||
        memcmp(a->ffd.inverse, b->ffd.inverse, sizeof a->ffd.inverse) != 0 || a->grid[0] != b->grid[0] ||
        a->grid[1] != b->grid[1])
        return 0;
    for (k = 0; k < used; k++)
        if (memcmp(a->ffd.control[k], b->ffd.control[k], sizeof a->ffd.control[k]) != 0) return 0;
    return 1;
}

/* Every public function that takes a model, on one that fails validation:
   each returns INVALID_MODEL (the per-point one, for what it checks), and
   none crashes or writes out of bounds (the sanitizer build runs this). */
static void check_model_refused(const sqffd_model *bad, int per_point_sees_it, const char *what)
{
    sqffd_fit_options o = sqffd_fit_options_default();
    double pts[3 * 8], p[3], v[3 * 20];
    uint32_t tri[3 * 40];
    unsigned char bytes[4096];
    sqffd_model copy = *bad, out;
    sqffd_ffd_system system;
    sqffd_fit_report rep;
    void *ws = malloc(1 << 20);
    int i;
    for (i = 0; i < 24; i++) pts[i] = (double)((i * 7) % 5) - 2.0 + 0.1 * i;
    CHECK_MSG(sqffd_model_validate(bad) == SQFFD_ERROR_INVALID_MODEL, "%s: validate", what);
    CHECK_MSG(sqffd_model_mesh(bad, 3, 6, v, tri) == SQFFD_ERROR_INVALID_MODEL, "%s: mesh", what);
    CHECK_MSG(sqffd_model_distances(bad, pts, 8, NULL, NULL, ws, 1 << 20) == SQFFD_ERROR_INVALID_MODEL, "%s: distances",
              what);
    CHECK_MSG(sqffd_model_reverse_distances(bad, pts, 8, NULL, NULL, ws, 1 << 20) == SQFFD_ERROR_INVALID_MODEL,
              "%s: reverse distances", what);
    CHECK_MSG(sqffd_fit_ffd(pts, 8, &o, &copy, &rep, ws, 1 << 20) == SQFFD_ERROR_INVALID_MODEL, "%s: fit_ffd", what);
    CHECK_MSG(sqffd_ffd_system_init(&system, bad, NULL, ws, 1 << 20) == SQFFD_ERROR_INVALID_MODEL, "%s: system", what);
    CHECK_MSG(sqffd_motion(bad, 1, NULL, NULL, NULL, ws, 1 << 20) == SQFFD_ERROR_INVALID_MODEL, "%s: motion", what);
    CHECK_MSG(sqffd_model_save(bad, bytes, sizeof bytes) == SQFFD_ERROR_INVALID_MODEL, "%s: save", what);
    {
        size_t size = 1;
        sqffd_result r = sqffd_model_save_size(bad, &size);
        CHECK_MSG(r == SQFFD_ERROR_INVALID_MODEL && size == 0, "%s: save size %s", what, sqffd_result_string(r));
        size = 1;
        r = sqffd_model_distances_workspace_size(8, bad, &size);
        CHECK_MSG(r == SQFFD_ERROR_INVALID_MODEL && size == 0, "%s: distances workspace size %s", what,
                  sqffd_result_string(r));
        size = 1;
        r = sqffd_fit_ffd_workspace_size(8, bad, &o, &size);
        CHECK_MSG(r == SQFFD_ERROR_INVALID_MODEL && size == 0, "%s: fit_ffd workspace size %s", what,
                  sqffd_result_string(r));
        size = 1;
        r = sqffd_ffd_system_size(bad, &size);
        CHECK_MSG(r == SQFFD_ERROR_INVALID_MODEL && size == 0, "%s: system size %s", what, sqffd_result_string(r));
        size = 1;
        r = sqffd_motion_workspace_size(bad, 1, &size);
        CHECK_MSG(r == SQFFD_ERROR_INVALID_MODEL && size == 0, "%s: motion workspace size %s", what,
                  sqffd_result_string(r));
    }
    if (per_point_sees_it) {
        sqffd_result r = sqffd_model_point(bad, 0.3, 0.4, p);
        CHECK_MSG(r == SQFFD_ERROR_INVALID_MODEL || r == SQFFD_ERROR_NON_FINITE, "%s: model point %s", what,
                  sqffd_result_string(r));
    }
    CHECK_MSG(memcmp(&copy, bad, sizeof copy) == 0, "%s: fit_ffd changed the model it refused", what);
    (void)out;
    free(ws);
}

static void test_model_validation(void)
{
    sqffd_model good = test_model(), bad;
    double p[3];
    CHECK_RESULT(sqffd_model_validate(&good), SQFFD_OK);
    CHECK_RESULT(sqffd_model_validate(NULL), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_model_point(&good, 0.2, 0.3, p), SQFFD_OK);
#define BAD(field, value, per_point)      \
    do {                                  \
        bad = good;                       \
        bad.field = (value);              \
        check_model_refused(&bad, per_point, #field " = " #value); \
    } while (0)
    BAD(sq.size[1], 0.0, 1);
    BAD(sq.size[2], NAN, 1);
    BAD(sq.shape[0], 0.0, 1);
    BAD(sq.shape[1], 4.5, 1);
    BAD(sq.taper[0], 1.0, 1);
    BAD(sq.center[2], INFINITY, 1);
    BAD(sq.rotation[4], good.sq.rotation[4] + 1e-3, 1); /* not orthonormal */
    BAD(ffd.dims[0], 40, 1);                            /* a flipped byte */
    BAD(ffd.dims[1], 1, 1);
    BAD(ffd.dims[2], -3, 1);
    BAD(ffd.origin[0], NAN, 1);
    BAD(ffd.edges[3], INFINITY, 0);
    BAD(ffd.inverse[4], good.ffd.inverse[4] * 1.01, 0);  /* not the box's inverse */
    BAD(ffd.control[124][2], NAN, 1);                    /* the last one used */
    BAD(ffd.control[3][2], 1e280, 0);                   /* finite, but its squares overflow (found by fuzz_model) */
    BAD(sq.size[0], 1e151, 1);
    BAD(grid[0], 1, 0);
    BAD(grid[1], 2, 0);
    BAD(grid[1], 70000, 0);
#undef BAD
    bad = good; /* a mirror: orthonormal, det -1 */
    bad.sq.rotation[0] = -bad.sq.rotation[0]; bad.sq.rotation[3] = -bad.sq.rotation[3];
    bad.sq.rotation[6] = -bad.sq.rotation[6];
    check_model_refused(&bad, 1, "left-handed rotation");
    bad = good; /* a flat box, its inverse left as it was */
    memcpy(bad.ffd.edges + 6, bad.ffd.edges, 3 * sizeof(double));
    check_model_refused(&bad, 0, "flat box");
    bad = good; /* an unused control point is not read */
    bad.ffd.control[200][0] = NAN;
    CHECK_RESULT(sqffd_model_validate(&bad), SQFFD_OK);
    CHECK_RESULT(sqffd_model_point(&good, NAN, 0.3, p), SQFFD_ERROR_NON_FINITE);
    { /* a valid model and finite data too far apart to square their distances: a code, not a crash */
        double far[12] = {1e154, 1e154, 1e154, 1e154, 1e154, 1e154, 1e154, 1e154, 1e154, 0, 0, 0};
        size_t size;
        void *ws;
        sqffd_distance_stats st;
        CHECK_RESULT(sqffd_model_distances_workspace_size(4, &good, &size), SQFFD_OK);
        ws = malloc(size);
        CHECK_RESULT(sqffd_model_distances(&good, far, 3, NULL, &st, ws, size), SQFFD_ERROR_NON_FINITE);
        CHECK_RESULT(sqffd_model_distances(&good, far + 3, 3, NULL, &st, ws, size), SQFFD_ERROR_NON_FINITE);
        free(ws);
    }
}

static void test_model_superquadric_and_lattice_checks(void)
{
    sqffd_model m = test_model();
    sqffd_superquadric bad = m.sq;
    double p[3] = {0.1, 0.2, 0.3}, q[3], value = 7.0, w[125];
    int dims[3] = {5, 5, 5};
    size_t count = 9;
    CHECK_RESULT(sqffd_sq_validate(&m.sq), SQFFD_OK);
    bad.shape[0] = NAN;
    CHECK_RESULT(sqffd_sq_validate(&bad), SQFFD_ERROR_INVALID_MODEL);
    CHECK_RESULT(sqffd_sq_inside_outside(&bad, p, &value), SQFFD_ERROR_INVALID_MODEL);
    CHECK_RESULT(sqffd_sq_radial_distance(&bad, p, &value), SQFFD_ERROR_INVALID_MODEL);
    CHECK_RESULT(sqffd_sq_point(&bad, 0.1, 0.2, q, NULL), SQFFD_ERROR_INVALID_MODEL);
    CHECK_RESULT(sqffd_sq_sample_grid(&bad, 4, 4, w, NULL), SQFFD_ERROR_INVALID_MODEL);
    CHECK_RESULT(sqffd_sq_sample_uniform(&bad, 0.1, NULL, 0, &count), SQFFD_ERROR_INVALID_MODEL);
    CHECK_RESULT(sqffd_sq_volume(&bad, &value), SQFFD_ERROR_INVALID_MODEL);
    CHECK_RESULT(sqffd_sq_iou(&m.sq, &bad, 8, &value), SQFFD_ERROR_INVALID_MODEL);
    CHECK(value == 7.0); /* outputs untouched on failure */
    CHECK_RESULT(sqffd_model_init(&m, &bad, NULL), SQFFD_ERROR_INVALID_MODEL);
    p[1] = INFINITY;
    CHECK_RESULT(sqffd_sq_inside_outside(&m.sq, p, &value), SQFFD_ERROR_NON_FINITE);
    CHECK_RESULT(sqffd_ffd_deform(&m.ffd, p, q), SQFFD_ERROR_NON_FINITE);
    p[1] = 0.2;
    CHECK_RESULT(sqffd_ffd_validate(&m.ffd), SQFFD_OK);
    CHECK_RESULT(sqffd_ffd_deform(&m.ffd, p, q), SQFFD_OK);
    CHECK_RESULT(sqffd_ffd_weights(dims, p, w), SQFFD_OK);
    dims[1] = SQFFD_MAX_LATTICE + 1;
    CHECK_RESULT(sqffd_ffd_weights(dims, p, w), SQFFD_ERROR_INVALID_ARGUMENT);
    m.ffd.dims[2] = 0;
    CHECK_RESULT(sqffd_ffd_eval(&m.ffd, p, q), SQFFD_ERROR_INVALID_MODEL);
    CHECK_RESULT(sqffd_ffd_local(&m.ffd, p, q), SQFFD_ERROR_INVALID_MODEL);
    m = test_model();
    m.ffd.control[7][1] = NAN; /* the per-point functions see it in their result */
    CHECK_RESULT(sqffd_ffd_eval(&m.ffd, p, q), SQFFD_ERROR_NON_FINITE);
    CHECK_RESULT(sqffd_ffd_validate(&m.ffd), SQFFD_ERROR_INVALID_MODEL);
}

/* The saved size of a model that must be valid. */
static size_t saved_size(const sqffd_model *m)
{
    size_t size = 0;
    CHECK_RESULT(sqffd_model_save_size(m, &size), SQFFD_OK);
    return size;
}

/* The layout the header documents, byte by byte where it is fixed. */
static void test_model_save_layout(void)
{
    sqffd_model m = test_model();
    unsigned char bytes[4000];
    size_t size = saved_size(&m);
    uint64_t bits;
    int i;
    CHECK(size == 3288);
    CHECK_RESULT(sqffd_model_save_size(NULL, &size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK(size == 0);
    CHECK_RESULT(sqffd_model_save_size(&m, NULL), SQFFD_ERROR_INVALID_ARGUMENT);
    size = saved_size(&m);
    memset(bytes, 0xA5, sizeof bytes);
    m.sq.size[0] = 1.0; /* 0x3FF0000000000000 */
    CHECK_RESULT(sqffd_model_save(&m, bytes, size - 1), SQFFD_ERROR_OUTPUT_TOO_SMALL);
    CHECK(bytes[0] == 0xA5);
    CHECK_RESULT(sqffd_model_save(&m, bytes, size), SQFFD_OK);
    CHECK(memcmp(bytes, "SQFFDMDL", 8) == 0);
    CHECK(bytes[8] == 1 && bytes[9] == 0 && bytes[10] == 0 && bytes[11] == 0);
    CHECK(bytes[12] == (3288 & 255) && bytes[13] == 3288 >> 8 && bytes[14] == 0 && bytes[15] == 0);
    for (i = 0; i < 6; i++) CHECK(bytes[16 + i] == 0);
    CHECK(bytes[22] == 0xF0 && bytes[23] == 0x3F);
    CHECK(bytes[168] == 5 && bytes[172] == 5 && bytes[176] == 5 && bytes[169] == 0);
    CHECK(bytes[276] == (unsigned char)m.grid[0] && bytes[280] == (unsigned char)m.grid[1]);
    bits = 0; /* the last control point's z, the last double before the checksum */
    for (i = 0; i < 8; i++) bits |= (uint64_t)bytes[size - 12 + (size_t)i] << (8 * i);
    CHECK(memcmp(&bits, &m.ffd.control[124][2], 8) == 0);
    CHECK(crc32_of(bytes, size - 4) == ((uint32_t)bytes[size - 4] | (uint32_t)bytes[size - 3] << 8 |
                                        (uint32_t)bytes[size - 2] << 16 | (uint32_t)bytes[size - 1] << 24));
    CHECK(bytes[size] == 0xA5); /* nothing past the record */
}

static void test_model_save_load_round_trip(void)
{
    sqffd_model m = test_model(), back;
    unsigned char bytes[4000], again[4000];
    size_t size = saved_size(&m);
    double a[3], b[3];
    CHECK_RESULT(sqffd_model_save(&m, bytes, sizeof bytes), SQFFD_OK);
    memset(&back, 0xCC, sizeof back);
    CHECK_RESULT(sqffd_model_load(&back, bytes, size), SQFFD_OK);
    CHECK(same_model(&m, &back));
    CHECK_RESULT(sqffd_model_point(&back, 0.4, -1.1, a), SQFFD_OK);
    CHECK_RESULT(sqffd_model_point(&m, 0.4, -1.1, b), SQFFD_OK);
    CHECK(memcmp(a, b, sizeof a) == 0);
    CHECK_RESULT(sqffd_model_save(&back, again, sizeof again), SQFFD_OK);
    CHECK(memcmp(bytes, again, size) == 0);
    /* a 2 x 3 x 4 lattice is 24 control points */
    {
        sqffd_fit_options o = sqffd_fit_options_default();
        sqffd_model small;
        o.lattice[0] = 2; o.lattice[1] = 3; o.lattice[2] = 4;
        CHECK_RESULT(sqffd_model_init(&small, &m.sq, &o), SQFFD_OK);
        CHECK(saved_size(&small) == 284 + 24 * 24 + 4);
        CHECK_RESULT(sqffd_model_save(&small, bytes, sizeof bytes), SQFFD_OK);
        CHECK_RESULT(sqffd_model_load(&back, bytes, saved_size(&small)), SQFFD_OK);
        CHECK(same_model(&small, &back));
    }
}

/* Every byte flipped in turn (three patterns): with the record's checksum
   left, each load fails with BAD_FORMAT; with a checksum made right again,
   each gives a code or a model that passes validation and meshes. Neither
   may crash or trip the sanitizers. */
static void test_model_load_every_byte_flipped(void)
{
    /* make test flips every bit of each byte; make check also its lowest and its highest alone */
    static const unsigned char flips[3] = {0xFF, 0x01, 0x80};
    sqffd_model m = test_model(), back;
    unsigned char bytes[4000], bad[4000];
    double v[3 * 20];
    size_t size = saved_size(&m), i;
    int f, accepted = 0, refused = 0, ways = test_thorough() ? 3 : 1;
    CHECK_RESULT(sqffd_model_save(&m, bytes, sizeof bytes), SQFFD_OK);
    for (i = 0; i < size; i++)
        for (f = 0; f < ways; f++) {
            sqffd_result r;
            memcpy(bad, bytes, size);
            bad[i] ^= flips[f];
            CHECK_MSG(sqffd_model_load(&back, bad, size) == SQFFD_ERROR_BAD_FORMAT, "byte %zu ^ %02x passed the checksum",
                      i, flips[f]);
            if (i >= size - 4) continue;
            reseal(bad, size);
            memset(&back, 0, sizeof back);
            r = sqffd_model_load(&back, bad, size);
            if (r == SQFFD_OK) {
                accepted++;
                CHECK_RESULT(sqffd_model_validate(&back), SQFFD_OK);
                CHECK_RESULT(sqffd_model_mesh(&back, 3, 6, v, NULL), SQFFD_OK);
            } else {
                refused++;
                CHECK_MSG(r == SQFFD_ERROR_BAD_FORMAT || r == SQFFD_ERROR_INVALID_MODEL || r == SQFFD_ERROR_TOO_LARGE,
                          "byte %zu ^ %02x: %s", i, flips[f], sqffd_result_string(r));
            }
        }
    /* the magic, version and length always fail; most flipped doubles of the
       control points are still a model */
    CHECK(refused > ways * 16 && accepted > ways * 1000);
}

static void test_model_load_truncated_and_crafted(void)
{
    sqffd_model m = test_model(), back;
    unsigned char bytes[4000];
    size_t size = saved_size(&m), n;
    CHECK_RESULT(sqffd_model_save(&m, bytes, sizeof bytes), SQFFD_OK);
    for (n = 0; n < size; n++) CHECK_RESULT(sqffd_model_load(&back, bytes, n), SQFFD_ERROR_BAD_FORMAT);
    bytes[size] = 0;
    CHECK_RESULT(sqffd_model_load(&back, bytes, size + 1), SQFFD_ERROR_BAD_FORMAT);
    CHECK_RESULT(sqffd_model_load(NULL, bytes, size), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(sqffd_model_load(&back, NULL, size), SQFFD_ERROR_INVALID_ARGUMENT);
    /* a lattice beyond this build's maximum: TOO_LARGE, once the record is whole */
    {
        unsigned char big[284 + 24 * 9 * 2 * 2 + 4];
        size_t big_size = sizeof big;
        memset(big, 0, big_size);
        memcpy(big, bytes, 284);
        put_u32(big + 12, (uint32_t)big_size);
        put_u32(big + 168, 9); put_u32(big + 172, 2); put_u32(big + 176, 2);
        reseal(big, big_size);
        CHECK_RESULT(sqffd_model_load(&back, big, big_size), SQFFD_MAX_LATTICE >= 9 ? SQFFD_ERROR_INVALID_MODEL
                                                                                    : SQFFD_ERROR_TOO_LARGE);
    }
    /* a length field that disagrees with the lattice */
    put_u32(bytes + 168, 4);
    reseal(bytes, size);
    CHECK_RESULT(sqffd_model_load(&back, bytes, size), SQFFD_ERROR_BAD_FORMAT);
}

/* tests/test_model_lattice6.c: the same header built with SQFFD_MAX_LATTICE 6. */
int lattice6_round_trip(const unsigned char *bytes, size_t size, unsigned char *out, size_t capacity);

static void test_model_other_lattice_build(void)
{
    sqffd_model m = test_model();
    sqffd_fit_options o = sqffd_fit_options_default();
    unsigned char bytes[16000], back[16000];
    size_t size = saved_size(&m);
    CHECK_RESULT(sqffd_model_save(&m, bytes, sizeof bytes), SQFFD_OK);
    CHECK(lattice6_round_trip(bytes, size, back, sizeof back) == SQFFD_OK);
    CHECK(memcmp(bytes, back, size) == 0);
    o.lattice[0] = 7; /* fits 8, not 6 */
    CHECK_RESULT(sqffd_model_init(&m, &m.sq, &o), SQFFD_OK);
    size = saved_size(&m);
    CHECK_RESULT(sqffd_model_save(&m, bytes, sizeof bytes), SQFFD_OK);
    CHECK(lattice6_round_trip(bytes, size, back, sizeof back) == SQFFD_ERROR_TOO_LARGE);
}

/* The header's failure rules for the fit. 1: errors found before the work
   leave the model and the report as they were. 2: a cancel in the FFD stage
   leaves a valid model (the last accepted iterate) and a report of the
   iterations done. */
static int cancel_ffd_at_three(void *user, int stage, int iteration, double error)
{
    (void)user; (void)error;
    return stage == SQFFD_STAGE_FFD && iteration >= 3;
}

static void test_model_failure_rules(void)
{
    enum { N = 800 };
    phantom_lv ph = phantom_lv_default();
    sqffd_fit_options o = sqffd_fit_options_default(), bad;
    sqffd_model m, before;
    sqffd_fit_report rep, rep_before;
    double *pts = (double *)malloc(3 * N * sizeof *pts);
    size_t size = 0;
    void *ws;
    CHECK_RESULT(sqffd_fit_workspace_size(N, &o, &size), SQFFD_OK);
    ws = malloc(size);
    phantom_lv_sample(&ph, 0.0, N, pts);
    memset(&m, 0x5A, sizeof m);
    memset(&rep, 0x6B, sizeof rep);
    before = m;
    rep_before = rep;
    CHECK_RESULT(sqffd_fit(pts, N, &o, &m, &rep, ws, size - 1), SQFFD_ERROR_WORKSPACE_TOO_SMALL);
    bad = o; bad.alpha = -1.0;
    CHECK_RESULT(sqffd_fit(pts, N, &bad, &m, &rep, ws, size), SQFFD_ERROR_INVALID_ARGUMENT);
    { /* bad stage-1 options: INVALID_ARGUMENT from the size calls and the fit, not TOO_LARGE */
        sqffd_track_options t = sqffd_track_options_default();
        size_t other = 1, counts[1] = {N};
        bad = o; bad.sq.taper_max = 1.5;
        CHECK_RESULT(sqffd_fit_workspace_size(N, &bad, &other), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK(other == 0);
        CHECK_RESULT(sqffd_fit(pts, N, &bad, &m, &rep, ws, size), SQFFD_ERROR_INVALID_ARGUMENT);
        t.fit.sq.shape_min = 0.0;
        CHECK_RESULT(sqffd_track_workspace_size(counts, 1, &t, &other), SQFFD_ERROR_INVALID_ARGUMENT);
        CHECK_RESULT(sqffd_track_frame_workspace_size(N, &t, &other), SQFFD_ERROR_INVALID_ARGUMENT);
    }
    pts[7] = NAN;
    CHECK_RESULT(sqffd_fit(pts, N, &o, &m, &rep, ws, size), SQFFD_ERROR_NON_FINITE);
    pts[7] = 0.25;
    CHECK(memcmp(&m, &before, sizeof m) == 0 && memcmp(&rep, &rep_before, sizeof rep) == 0);
    o.progress = cancel_ffd_at_three;
    CHECK_RESULT(sqffd_fit(pts, N, &o, &m, &rep, ws, size), SQFFD_ERROR_CANCELLED);
    CHECK_RESULT(sqffd_model_validate(&m), SQFFD_OK);
    CHECK_MSG(rep.iterations == 3 && rep.history_count == 3, "iterations %d, history %d", rep.iterations, rep.history_count);
    free(ws);
    free(pts);
}

/* The spring weight's and the model -> data weight's ranges: their ends fit,
   even on a lattice parts of which no data reach (alpha tiny: the step falls
   back to the SVD, where Cholesky failed before), and a value beyond them is
   INVALID_ARGUMENT. */
static void test_model_weight_ranges(void)
{
    enum { N = 25 };
    /* alpha, model_to_data, lattice: the ends of the ranges; 1e-20 on 8 x 8 x 8 failed to Cholesky before */
    const double cases[][3] = {{1e-20, 0.02, 8}, {0.0, SQFFD_FIT_MODEL_TO_DATA_MAX, 4},
                               {SQFFD_FIT_ALPHA_MAX, SQFFD_FIT_MODEL_TO_DATA_MAX, 2}, {SQFFD_FIT_ALPHA_MAX, 0.0, 5}};
    sqffd_fit_options o = sqffd_fit_options_default();
    double pts[3 * N];
    size_t i, size;
    for (i = 0; i < N; ++i) { /* a spiral of 25 points */
        double t = (double)i / (N - 1);
        pts[3 * i] = cos(12.0 * t) * (1.0 + t);
        pts[3 * i + 1] = sin(12.0 * t) * (1.0 + t);
        pts[3 * i + 2] = 3.0 * t;
    }
    o.max_iterations = 2;
    for (i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        sqffd_model m;
        sqffd_fit_report rep;
        void *ws;
        o.alpha = cases[i][0];
        o.model_to_data = cases[i][1];
        o.lattice[0] = o.lattice[1] = o.lattice[2] = (int)cases[i][2];
        CHECK_RESULT(sqffd_fit_workspace_size(N, &o, &size), SQFFD_OK);
        ws = malloc(size);
        CHECK_MSG(sqffd_fit(pts, N, &o, &m, &rep, ws, size) == SQFFD_OK, "alpha %g, model_to_data %g, lattice %d",
                  o.alpha, o.model_to_data, o.lattice[0]);
        free(ws);
    }
    o = sqffd_fit_options_default();
    o.alpha = SQFFD_FIT_ALPHA_MAX * 1.000001;
    CHECK_RESULT(sqffd_fit_workspace_size(N, &o, &size), SQFFD_ERROR_INVALID_ARGUMENT);
    o.alpha = 1e-6;
    o.model_to_data = SQFFD_FIT_MODEL_TO_DATA_MAX * 1.000001;
    CHECK_RESULT(sqffd_fit_workspace_size(N, &o, &size), SQFFD_ERROR_INVALID_ARGUMENT);
    o.model_to_data = INFINITY;
    CHECK_RESULT(sqffd_fit_workspace_size(N, &o, &size), SQFFD_ERROR_INVALID_ARGUMENT);
}

void suite_model(void)
{
    RUN_TEST(test_model_validation);
    RUN_TEST(test_model_superquadric_and_lattice_checks);
    RUN_TEST(test_model_save_layout);
    RUN_TEST(test_model_save_load_round_trip);
    RUN_TEST(test_model_load_every_byte_flipped);
    RUN_TEST(test_model_load_truncated_and_crafted);
    RUN_TEST(test_model_other_lattice_build);
    RUN_TEST(test_model_failure_rules);
    RUN_TEST(test_model_weight_ranges);
}

/* Tests: memory discipline: exact workspaces, canaries, odd alignments, read-only inputs, repeatability.

   1. Every operation that takes a workspace runs in exactly its
      _workspace_size() bytes, placed between canary bytes at offsets 0, 1,
      3, 7, 8 and 15 from a 16-aligned base, the workspace itself filled
      with a different pattern each time: it succeeds, the canaries stay,
      and its outputs are the same bits at every offset and whatever the
      workspace held. One byte less is WORKSPACE_TOO_SMALL, canaries intact.
   2. Inputs (points, options, models, frames, voxels, a prepared system, a
      built tree) in read-only pages followed by an inaccessible page: a
      write, or a read past an input's end, faults; the fault is caught and
      reported as a failure of that call.
   3. The same call twice gives the same bits (compared field by field: no
      struct padding).
   4. Outputs after an error or a cancel, where the header says what they
      are; output arrays are written up to their documented size and no
      further. */
#define _POSIX_C_SOURCE 200809L
#define _DEFAULT_SOURCE
#include "test.h"
#include "../examples/sqffd_phantom.h"
#include <stdlib.h>
#include <string.h>

#if defined(__unix__) || defined(__APPLE__)
#define MEM_READ_ONLY 1
#include <setjmp.h>
#include <signal.h>
#include <sys/mman.h>
#include <unistd.h>
#else
#define MEM_READ_ONLY 0
#endif

enum { GUARD = 64, CANARY = 0xA5, N_FIT = 400, FRAMES = 3, N_FRAME = 300, VOX = 14 };

static const size_t offsets[] = {0, 1, 3, 7, 8, 15};
static const unsigned char fills[] = {0x00, 0xFF, 0x5A, 0x7F, 0xC3, 0x81}; /* 0x7F..: NaN bits as doubles */
#define N_OFFSETS (sizeof offsets / sizeof offsets[0])

/* ---- hashing outputs bit for bit (FNV-1a), field by field ---------------- */

#define HASH0 14695981039346656037ull

static uint64_t hash_bytes(uint64_t h, const void *p, size_t n)
{
    const unsigned char *b = (const unsigned char *)p;
    while (n--) {
        h ^= *b++;
        h *= 1099511628211ull;
    }
    return h;
}

static size_t used_controls(const sqffd_ffd *f)
{
    int a;
    for (a = 0; a < 3; a++)
        if (f->dims[a] < 2 || f->dims[a] > SQFFD_MAX_LATTICE) return 0;
    return (size_t)f->dims[0] * (size_t)f->dims[1] * (size_t)f->dims[2];
}

static uint64_t hash_model(uint64_t h, const sqffd_model *m)
{
    h = hash_bytes(h, &m->sq, sizeof m->sq); /* doubles only: no padding */
    h = hash_bytes(h, m->ffd.dims, sizeof m->ffd.dims);
    h = hash_bytes(h, m->ffd.origin, sizeof m->ffd.origin);
    h = hash_bytes(h, m->ffd.edges, sizeof m->ffd.edges);
    h = hash_bytes(h, m->ffd.inverse, sizeof m->ffd.inverse);
    h = hash_bytes(h, m->ffd.control, used_controls(&m->ffd) * sizeof m->ffd.control[0]);
    return hash_bytes(h, m->grid, sizeof m->grid);
}

static uint64_t hash_fit_report(uint64_t h, const sqffd_fit_report *r)
{
    int count = r->history_count < 0 ? 0 : r->history_count > SQFFD_FIT_HISTORY ? SQFFD_FIT_HISTORY : r->history_count;
    h = hash_bytes(h, &r->sq_error, sizeof r->sq_error); /* doubles only */
    h = hash_bytes(h, &r->error, sizeof r->error);
    h = hash_bytes(h, &r->iterations, sizeof r->iterations);
    h = hash_bytes(h, &r->converged, sizeof r->converged);
    h = hash_bytes(h, &r->step, sizeof r->step);
    h = hash_bytes(h, &r->history_count, sizeof r->history_count);
    h = hash_bytes(h, r->history, (size_t)count * sizeof r->history[0]);
    h = hash_bytes(h, &r->energy, sizeof r->energy);
    return hash_bytes(h, r->energy_history, (size_t)count * sizeof r->energy_history[0]);
}

static uint64_t hash_sq_report(uint64_t h, const sqffd_sq_fit_report *r)
{
    h = hash_bytes(h, &r->iterations, sizeof r->iterations);
    h = hash_bytes(h, &r->cost, sizeof r->cost);
    h = hash_bytes(h, &r->rms_radial, sizeof r->rms_radial);
    h = hash_bytes(h, &r->start, sizeof r->start);
    h = hash_bytes(h, &r->converged, sizeof r->converged);
    h = hash_bytes(h, &r->inlier_fraction, sizeof r->inlier_fraction);
    h = hash_bytes(h, &r->best_start, sizeof r->best_start);
    return hash_bytes(h, &r->fallback, sizeof r->fallback);
}

/* ---- shared inputs (made once) ------------------------------------------- */

static struct {
    int ready;
    double ed[3 * N_FIT], es[3 * N_FIT];
    double frame[FRAMES][3 * N_FRAME];
    const double *frames[FRAMES];
    size_t counts[FRAMES];
    sqffd_fit_options fit;     /* short: a few FFD iterations */
    sqffd_track_options track;
    sqffd_model model;         /* fitted to ed */
    sqffd_model tracked[FRAMES];
    unsigned char voxels[VOX * VOX * VOX];
    sqffd_volume volume;
} D;

static int setup(void)
{
    phantom_lv ph;
    size_t t, i, j, k, size;
    void *ws;
    if (D.ready) return D.ready > 0;
    D.ready = -1;
    ph = phantom_lv_default();
    phantom_lv_sample(&ph, 0.0, N_FIT, D.ed);
    phantom_lv_sample(&ph, 0.5, N_FIT, D.es);
    for (t = 0; t < FRAMES; t++) {
        phantom_lv_sample(&ph, 0.5 * (double)t / (double)(FRAMES - 1), N_FRAME, D.frame[t]);
        D.frames[t] = D.frame[t];
        D.counts[t] = N_FRAME;
    }
    D.fit = sqffd_fit_options_default();
    D.fit.max_iterations = 3;
    D.fit.grid[0] = 12;
    D.fit.grid[1] = 16;
    D.track = sqffd_track_options_default();
    D.track.fit = D.fit;
    D.track.frame_iterations = 2;
    CHECK_RESULT(test_fit(D.ed, N_FIT, &D.fit, &D.model, NULL), SQFFD_OK);
    CHECK_RESULT(sqffd_track_workspace_size(D.counts, FRAMES, &D.track, &size), SQFFD_OK);
    ws = test_malloc(size);
    CHECK_RESULT(sqffd_track(D.frames, D.counts, FRAMES, &D.track, D.tracked, NULL, NULL, ws, size), SQFFD_OK);
    free(ws);
    /* a ball of radius 4.5 voxels and a lone speck, values 0 / 200 */
    for (k = 0; k < VOX; k++)
        for (j = 0; j < VOX; j++)
            for (i = 0; i < VOX; i++) {
                double x = (double)i - 6.5, y = (double)j - 6.0, z = (double)k - 7.0;
                D.voxels[(k * VOX + j) * VOX + i] = x * x + y * y + z * z <= 4.5 * 4.5 ? 200 : 0;
            }
    D.voxels[(1 * VOX + 1) * VOX + 12] = 200;
    memset(&D.volume, 0, sizeof D.volume);
    D.volume.data = D.voxels;
    D.volume.type = SQFFD_VOXEL_U8;
    D.volume.dims[0] = D.volume.dims[1] = D.volume.dims[2] = VOX;
    D.volume.strides[0] = 1;
    D.volume.strides[1] = VOX;
    D.volume.strides[2] = VOX * VOX;
    D.volume.affine[0] = 0.8; D.volume.affine[5] = 0.9; D.volume.affine[10] = 1.1; D.volume.affine[15] = 1.0;
    D.volume.affine[3] = -3.0;
    D.ready = 1;
    return 1;
}

/* ---- one operation, as a closure: run it in a given workspace; hash its
   outputs --------------------------------------------------------------------- */

typedef struct mem_op {
    const char *name;
    sqffd_result (*run)(void *ctx, void *ws, size_t size);
    uint64_t (*digest)(void *ctx);
    void *ctx;
    size_t size; /* its _workspace_size() */
} mem_op;

static size_t first_changed(const unsigned char *p, size_t n, unsigned char value)
{
    size_t i;
    for (i = 0; i < n; i++)
        if (p[i] != value) return i;
    return n;
}

/* Item 1: exact size at every offset (each with its own fill), canaries,
   the same outputs; one byte less refused. */
static void check_workspace(const mem_op *op)
{
    unsigned char *raw, *base;
    uint64_t first = 0;
    size_t k, size = op->size;
    CHECK_MSG(size > 0, "%s: _workspace_size() is 0", op->name);
    if (!size) return;
    raw = (unsigned char *)test_malloc(size + 2 * GUARD + 32);
    base = raw + (16 - (uintptr_t)raw % 16) % 16;
    for (k = 0; k < N_OFFSETS; k++) {
        unsigned char *ws = base + GUARD + offsets[k];
        size_t lead = GUARD + offsets[k], bad;
        sqffd_result r;
        memset(base, CANARY, lead);
        memset(ws, fills[k], size);
        memset(ws + size, CANARY, GUARD);
        r = op->run(op->ctx, ws, size);
        CHECK_MSG(r == SQFFD_OK, "%s: exact workspace at offset %zu: %s", op->name, offsets[k], sqffd_result_string(r));
        bad = first_changed(base, lead, CANARY);
        CHECK_MSG(bad == lead, "%s: offset %zu: canary byte %zu before the workspace overwritten", op->name, offsets[k],
                  lead - bad);
        bad = first_changed(ws + size, GUARD, CANARY);
        CHECK_MSG(bad == GUARD, "%s: offset %zu: canary byte %zu past the workspace overwritten", op->name, offsets[k],
                  bad);
        if (op->digest && r == SQFFD_OK) {
            uint64_t h = op->digest(op->ctx);
            if (k == 0) first = h;
            else
                CHECK_MSG(h == first, "%s: outputs at offset %zu (workspace filled with 0x%02X) differ from offset 0's",
                          op->name, offsets[k], fills[k]);
        }
        /* one byte less: the byte at ws[size - 1] is now outside the block */
        memset(base, CANARY, lead);
        memset(ws, fills[k], size - 1);
        memset(ws + size - 1, CANARY, GUARD + 1);
        r = op->run(op->ctx, ws, size - 1);
        CHECK_MSG(r == SQFFD_ERROR_WORKSPACE_TOO_SMALL, "%s: one byte short at offset %zu: %s", op->name, offsets[k],
                  sqffd_result_string(r));
        CHECK_MSG(first_changed(base, lead, CANARY) == lead, "%s: one byte short, offset %zu: canary before overwritten",
                  op->name, offsets[k]);
        CHECK_MSG(first_changed(ws + size - 1, GUARD + 1, CANARY) == GUARD + 1,
                  "%s: one byte short, offset %zu: canary past the block overwritten", op->name, offsets[k]);
    }
    free(raw);
}

/* ---- the operations -------------------------------------------------------- */

/* svd */
enum { SVD_M = 9, SVD_N = 6 };
typedef struct svd_ctx {
    const double *a;
    double u[SVD_M * SVD_N], s[SVD_N], v[SVD_N * SVD_N];
} svd_ctx;
static sqffd_result svd_run(void *c, void *ws, size_t size)
{
    svd_ctx *x = (svd_ctx *)c;
    return sqffd_svd(x->a, SVD_M, SVD_N, x->u, x->s, x->v, ws, size);
}
static uint64_t svd_digest(void *c)
{
    svd_ctx *x = (svd_ctx *)c;
    return hash_bytes(hash_bytes(hash_bytes(HASH0, x->u, sizeof x->u), x->s, sizeof x->s), x->v, sizeof x->v);
}
static void svd_matrix(double *a)
{
    int i;
    for (i = 0; i < SVD_M * SVD_N; i++) a[i] = sin(1.7 * i + 0.3) + (i % 7 == 0 ? 2.0 : 0.0);
}

/* cg: a tridiagonal SPD matrix as a mat-vec */
enum { CG_N = 24 };
typedef struct cg_ctx {
    const double *b;
    const sqffd_cg_options *opt;
    double x[CG_N], rel;
    int it;
} cg_ctx;
static void cg_matvec(void *user, const double *x, double *y)
{
    int i;
    (void)user;
    for (i = 0; i < CG_N; i++)
        y[i] = (2.5 + 0.1 * i) * x[i] - (i > 0 ? x[i - 1] : 0.0) - (i + 1 < CG_N ? x[i + 1] : 0.0);
}
static sqffd_result cg_run(void *c, void *ws, size_t size)
{
    cg_ctx *x = (cg_ctx *)c;
    memset(x->x, 0, sizeof x->x);
    return sqffd_cg_solve(CG_N, cg_matvec, NULL, x->b, x->x, x->opt, &x->it, &x->rel, ws, size);
}
static uint64_t cg_digest(void *c)
{
    cg_ctx *x = (cg_ctx *)c;
    return hash_bytes(hash_bytes(hash_bytes(HASH0, x->x, sizeof x->x), &x->rel, sizeof x->rel), &x->it, sizeof x->it);
}

/* ncg: a smooth convex function in a box */
enum { NCG_N = 5 };
static double ncg_f(void *user, const double *x, double *g)
{
    double s = 0.0, f = 0.0;
    int i;
    (void)user;
    for (i = 0; i < NCG_N; i++) s += x[i] * x[i];
    for (i = 0; i < NCG_N; i++) {
        f += (i + 1.0) * (x[i] - 1.0) * (x[i] - 1.0);
        g[i] = 2.0 * (i + 1.0) * (x[i] - 1.0) + 0.4 * s * x[i];
    }
    return f + 0.1 * s * s;
}
static void ncg_box(void *user, double *x)
{
    int i;
    (void)user;
    for (i = 0; i < NCG_N; i++) x[i] = x[i] > 0.7 ? 0.7 : x[i];
}
typedef struct ncg_ctx {
    double x[NCG_N], fx;
    int it;
} ncg_ctx;
static sqffd_result ncg_run(void *c, void *ws, size_t size)
{
    ncg_ctx *x = (ncg_ctx *)c;
    int i;
    sqffd_ncg_options o = sqffd_ncg_options_default();
    o.max_iterations = 200;
    o.tolerance = 1e-10;
    o.project = ncg_box;
    for (i = 0; i < NCG_N; i++) x->x[i] = -1.0 + 0.3 * i;
    return sqffd_ncg_minimize(NCG_N, ncg_f, NULL, x->x, &o, &x->it, &x->fx, ws, size);
}
static uint64_t ncg_digest(void *c)
{
    ncg_ctx *x = (ncg_ctx *)c;
    return hash_bytes(hash_bytes(hash_bytes(HASH0, x->x, sizeof x->x), &x->fx, sizeof x->fx), &x->it, sizeof x->it);
}

/* kd-tree: the permutation, node count, box and query answers (not the
   node bytes: a leaf leaves half of its union unused) */
typedef struct kd_ctx {
    const double *points;
    size_t n;
    sqffd_kdtree tree;
} kd_ctx;
static sqffd_result kd_run(void *c, void *ws, size_t size)
{
    kd_ctx *x = (kd_ctx *)c;
    return sqffd_kdtree_build(&x->tree, x->points, x->n, ws, size);
}
static sqffd_result kd_built(void *c, void *ws, size_t size) /* the tree as built: only the digest's queries run */
{
    (void)c; (void)ws; (void)size;
    return SQFFD_OK;
}
static uint64_t kd_digest(void *c)
{
    kd_ctx *x = (kd_ctx *)c;
    uint64_t h = hash_bytes(HASH0, &x->tree.node_count, sizeof x->tree.node_count);
    size_t q, idx[6];
    double d2[6];
    h = hash_bytes(h, x->tree.index, x->n * sizeof *x->tree.index);
    h = hash_bytes(h, x->tree.bbox, sizeof x->tree.bbox);
    for (q = 0; q < 40; q++) {
        double p[3];
        size_t found;
        p[0] = 30.0 * sin(0.37 * (double)q);
        p[1] = 30.0 * cos(0.61 * (double)q);
        p[2] = -45.0 + 2.0 * (double)q;
        CHECK_RESULT(sqffd_kdtree_nearest(&x->tree, p, &idx[0], &d2[0]), SQFFD_OK);
        h = hash_bytes(hash_bytes(h, idx, sizeof idx[0]), d2, sizeof d2[0]);
        found = 0;
        CHECK_RESULT(sqffd_kdtree_knn(&x->tree, p, 6, idx, d2, &found), SQFFD_OK);
        h = hash_bytes(hash_bytes(h, idx, found * sizeof idx[0]), d2, found * sizeof d2[0]);
    }
    return h;
}

/* superquadric fit */
typedef struct sq_ctx {
    const double *points;
    size_t n;
    const sqffd_sq_fit_options *opt;
    sqffd_superquadric sq;
    sqffd_sq_fit_report rep;
} sq_ctx;
static sqffd_result sq_run(void *c, void *ws, size_t size)
{
    sq_ctx *x = (sq_ctx *)c;
    return sqffd_sq_fit(x->points, x->n, x->opt, &x->sq, &x->rep, ws, size);
}
static uint64_t sq_digest(void *c)
{
    sq_ctx *x = (sq_ctx *)c;
    return hash_sq_report(hash_bytes(HASH0, &x->sq, sizeof x->sq), &x->rep);
}

/* whole fit; the FFD stage alone (from `start`); against a prepared system */
typedef struct fit_ctx {
    const double *points;
    size_t n;
    const sqffd_fit_options *opt;
    const sqffd_model *start;        /* fit_ffd, fit_prepared */
    const sqffd_ffd_system *system;  /* fit_prepared */
    sqffd_model model;
    sqffd_fit_report rep;
} fit_ctx;
static sqffd_result fit_run(void *c, void *ws, size_t size)
{
    fit_ctx *x = (fit_ctx *)c;
    return sqffd_fit(x->points, x->n, x->opt, &x->model, &x->rep, ws, size);
}
static sqffd_result fit_ffd_run(void *c, void *ws, size_t size)
{
    fit_ctx *x = (fit_ctx *)c;
    x->model = *x->start;
    return sqffd_fit_ffd(x->points, x->n, x->opt, &x->model, &x->rep, ws, size);
}
static sqffd_result fit_prepared_run(void *c, void *ws, size_t size)
{
    fit_ctx *x = (fit_ctx *)c;
    x->model = *x->start;
    return sqffd_fit_prepared(x->system, x->points, x->n, x->opt, &x->model, &x->rep, ws, size);
}
static uint64_t fit_digest(void *c)
{
    fit_ctx *x = (fit_ctx *)c;
    return hash_fit_report(hash_model(HASH0, &x->model), &x->rep);
}

/* data -> model and model -> data distances */
typedef struct dist_ctx {
    const sqffd_model *model;
    const double *points;
    size_t n, m; /* m: the model's grid mesh vertices */
    double *values;
    sqffd_distance_stats stats;
} dist_ctx;
static sqffd_result dist_run(void *c, void *ws, size_t size)
{
    dist_ctx *x = (dist_ctx *)c;
    return sqffd_model_distances(x->model, x->points, x->n, x->values, &x->stats, ws, size);
}
static sqffd_result reverse_run(void *c, void *ws, size_t size)
{
    dist_ctx *x = (dist_ctx *)c;
    return sqffd_model_reverse_distances(x->model, x->points, x->n, x->values, &x->stats, ws, size);
}
static uint64_t dist_digest(void *c)
{
    dist_ctx *x = (dist_ctx *)c;
    return hash_bytes(hash_bytes(HASH0, &x->stats, sizeof x->stats), x->values, x->n * sizeof(double));
}
static uint64_t reverse_digest(void *c)
{
    dist_ctx *x = (dist_ctx *)c;
    return hash_bytes(hash_bytes(HASH0, &x->stats, sizeof x->stats), x->values, x->m * sizeof(double));
}

/* a prepared system: its memory is the "workspace"; the digest runs the FFD
   stage against it */
typedef struct system_ctx {
    const sqffd_model *model;
    const sqffd_fit_options *opt;
    sqffd_ffd_system system;
    fit_ctx use;
} system_ctx;
static sqffd_result system_run(void *c, void *ws, size_t size)
{
    system_ctx *x = (system_ctx *)c;
    return sqffd_ffd_system_init(&x->system, x->model, x->opt, ws, size);
}
static uint64_t system_digest(void *c)
{
    system_ctx *x = (system_ctx *)c;
    size_t size;
    void *ws;
    sqffd_result r;
    x->use.system = &x->system;
    CHECK_RESULT(sqffd_fit_prepared_workspace_size(x->use.n, &x->system, x->use.opt, &size), SQFFD_OK);
    ws = test_malloc(size);
    r = fit_prepared_run(&x->use, ws, size);
    free(ws);
    CHECK_MSG(r == SQFFD_OK, "sqffd_fit_prepared on a system prepared at an odd address: %s", sqffd_result_string(r));
    return fit_digest(&x->use);
}

/* tracking and motion */
typedef struct track_ctx {
    const double *const *frames;
    const size_t *counts;
    const sqffd_track_options *opt;
    sqffd_model models[FRAMES];
    sqffd_fit_report reports[FRAMES];
    size_t done;
} track_ctx;
static sqffd_result track_run(void *c, void *ws, size_t size)
{
    track_ctx *x = (track_ctx *)c;
    return sqffd_track(x->frames, x->counts, FRAMES, x->opt, x->models, x->reports, &x->done, ws, size);
}
static uint64_t track_digest(void *c)
{
    track_ctx *x = (track_ctx *)c;
    uint64_t h = hash_bytes(HASH0, &x->done, sizeof x->done);
    int t;
    for (t = 0; t < FRAMES; t++) h = hash_fit_report(hash_model(h, &x->models[t]), &x->reports[t]);
    return h;
}

typedef struct motion_ctx {
    const sqffd_model *models;
    const sqffd_motion_options *opt;
    const sqffd_motion_outputs *out;
    size_t m;
    sqffd_motion_report rep;
} motion_ctx;
static sqffd_result motion_run(void *c, void *ws, size_t size)
{
    motion_ctx *x = (motion_ctx *)c;
    return sqffd_motion(x->models, FRAMES, x->opt, x->out, &x->rep, ws, size);
}
static uint64_t motion_digest(void *c)
{
    motion_ctx *x = (motion_ctx *)c;
    const sqffd_motion_report *r = &x->rep;
    uint64_t h = HASH0;
    int k;
    h = hash_bytes(h, &r->ed_frame, sizeof r->ed_frame);
    h = hash_bytes(h, &r->es_frame, sizeof r->es_frame);
    h = hash_bytes(h, &r->edv, 3 * sizeof(double)); /* edv, esv, ejection_fraction */
    h = hash_bytes(h, r->axis, sizeof r->axis);
    h = hash_bytes(h, r->apex, sizeof r->apex);
    h = hash_bytes(h, &r->length, sizeof r->length);
    h = hash_bytes(h, r->anterior, sizeof r->anterior);
    h = hash_bytes(h, r->septum, sizeof r->septum);
    h = hash_bytes(h, &r->median_excursion, sizeof r->median_excursion);
    for (k = 0; k < SQFFD_SEGMENTS; k++) {
        h = hash_bytes(h, &r->segments[k].area, 4 * sizeof(double)); /* area .. low_motion_share */
        h = hash_bytes(h, &r->segments[k].hypokinetic, sizeof(int));
    }
    if (x->out) {
        h = hash_bytes(h, x->out->volumes, FRAMES * sizeof(double));
        h = hash_bytes(h, x->out->trajectories, 3 * FRAMES * x->m * sizeof(double));
        h = hash_bytes(h, x->out->displacement, x->m * sizeof(double));
        h = hash_bytes(h, x->out->excursion, x->m * sizeof(double));
        h = hash_bytes(h, x->out->low_motion, x->m);
        h = hash_bytes(h, x->out->segment, x->m);
    }
    return h;
}

/* iso-surface points */
typedef struct iso_ctx {
    const sqffd_volume *volume;
    const sqffd_iso_options *opt;
    double *points, *normals;
    size_t capacity, count;
} iso_ctx;
static sqffd_result iso_run(void *c, void *ws, size_t size)
{
    iso_ctx *x = (iso_ctx *)c;
    return sqffd_iso_points(x->volume, x->opt, x->points, x->normals, x->capacity, &x->count, ws, size);
}
static uint64_t iso_digest(void *c)
{
    iso_ctx *x = (iso_ctx *)c;
    size_t k = x->count < x->capacity ? x->count : x->capacity;
    uint64_t h = hash_bytes(HASH0, &x->count, sizeof x->count);
    return hash_bytes(hash_bytes(h, x->points, 3 * k * sizeof(double)), x->normals, 3 * k * sizeof(double));
}

/* Every output array of sqffd_motion for FRAMES frames of nv vertices. */
static void motion_outputs_alloc(sqffd_motion_outputs *out, size_t nv)
{
    out->volumes = (double *)test_malloc(FRAMES * sizeof(double));
    out->trajectories = (double *)test_malloc(3 * FRAMES * nv * sizeof(double));
    out->displacement = (double *)test_malloc(nv * sizeof(double));
    out->excursion = (double *)test_malloc(nv * sizeof(double));
    out->low_motion = (unsigned char *)test_malloc(nv);
    out->segment = (unsigned char *)test_malloc(nv);
}

static void motion_outputs_free(sqffd_motion_outputs *out)
{
    free(out->volumes); free(out->trajectories); free(out->displacement); free(out->excursion);
    free(out->low_motion); free(out->segment);
}

static size_t grid_vertices(const sqffd_model *m)
{
    size_t nv = 0, nt = 0;
    CHECK_RESULT(sqffd_model_mesh_size(m->grid[0], m->grid[1], &nv, &nt), SQFFD_OK);
    return nv;
}

/* The digest of op with writable inputs (ctx as given). */
static uint64_t rw_digest(const mem_op *op)
{
    void *ws = test_malloc(op->size);
    sqffd_result r = op->run(op->ctx, ws, op->size);
    uint64_t h = r == SQFFD_OK && op->digest ? op->digest(op->ctx) : 0;
    free(ws);
    CHECK_MSG(r == SQFFD_OK, "%s: %s", op->name, sqffd_result_string(r));
    return h;
}

/* The operations as the sections below set them up: the context filled
   (from the shared inputs), op pointing at it with its workspace size. */
static void svd_op(mem_op *op, svd_ctx *s, double *a)
{
    svd_matrix(a);
    s->a = a;
    op->name = "sqffd_svd"; op->run = svd_run; op->digest = svd_digest; op->ctx = s;
    CHECK_RESULT(sqffd_svd_workspace_size(SVD_M, SVD_N, &op->size), SQFFD_OK);
}

/* (b, diag: CG_N each) */
static void cg_op(mem_op *op, cg_ctx *c, sqffd_cg_options *opt, double *b, double *diag)
{
    int i;
    for (i = 0; i < CG_N; i++) {
        b[i] = cos(0.9 * i);
        diag[i] = 2.5 + 0.1 * i;
    }
    opt->jacobi_diagonal = diag;
    c->b = b;
    c->opt = opt;
    op->name = "sqffd_cg_solve"; op->run = cg_run; op->digest = cg_digest; op->ctx = c;
    CHECK_RESULT(sqffd_cg_workspace_size(CG_N, &op->size), SQFFD_OK);
}

static void track_op(mem_op *op, track_ctx *t)
{
    t->frames = D.frames;
    t->counts = D.counts;
    t->opt = &D.track;
    op->name = "sqffd_track"; op->run = track_run; op->digest = track_digest; op->ctx = t;
    CHECK_RESULT(sqffd_track_workspace_size(D.counts, FRAMES, &D.track, &op->size), SQFFD_OK);
}

/* (out: allocated here, motion_outputs_free after) */
static void motion_op(mem_op *op, motion_ctx *m, const sqffd_motion_options *mo, sqffd_motion_outputs *out)
{
    size_t nv = grid_vertices(&D.tracked[0]);
    motion_outputs_alloc(out, nv);
    m->models = D.tracked;
    m->opt = mo;
    m->out = out;
    m->m = nv;
    op->name = "sqffd_motion"; op->run = motion_run; op->digest = motion_digest; op->ctx = m;
    CHECK_RESULT(sqffd_motion_workspace_size(D.tracked, FRAMES, &op->size), SQFFD_OK);
}

/* ---- 1. exact workspaces --------------------------------------------------- */

static void test_memory_linalg_exact_workspace(void)
{
    double a[SVD_M * SVD_N], b[CG_N];
    svd_ctx s;
    cg_ctx c;
    ncg_ctx g;
    sqffd_cg_options opt = sqffd_cg_options_default();
    double diag[CG_N];
    mem_op op;
    svd_op(&op, &s, a);
    check_workspace(&op);
    cg_op(&op, &c, &opt, b, diag);
    check_workspace(&op);
    op.name = "sqffd_ncg_minimize"; op.run = ncg_run; op.digest = ncg_digest; op.ctx = &g;
    CHECK_RESULT(sqffd_ncg_workspace_size(NCG_N, &op.size), SQFFD_OK);
    check_workspace(&op);
}

static void test_memory_kdtree_exact_workspace(void)
{
    kd_ctx k;
    mem_op op;
    if (!setup()) return;
    k.points = D.ed;
    k.n = N_FIT;
    op.name = "sqffd_kdtree_build"; op.run = kd_run; op.digest = kd_digest; op.ctx = &k;
    CHECK_RESULT(sqffd_kdtree_workspace_size(N_FIT, &op.size), SQFFD_OK);
    check_workspace(&op);
    k.n = 7; /* a lone root leaf */
    op.name = "sqffd_kdtree_build (7 points)";
    CHECK_RESULT(sqffd_kdtree_workspace_size(7, &op.size), SQFFD_OK);
    check_workspace(&op);
}

static void test_memory_sq_fit_exact_workspace(void)
{
    sqffd_sq_fit_options o[3];
    static const char *names[3] = {"sqffd_sq_fit (LM)", "sqffd_sq_fit (robust)", "sqffd_sq_fit (CG)"};
    sq_ctx c;
    mem_op op;
    int v;
    if (!setup()) return;
    for (v = 0; v < 3; v++) {
        o[v] = sqffd_sq_fit_options_default();
        o[v].robust = v == 1;
        o[v].optimizer = v == 2 ? SQFFD_SQ_OPTIMIZER_CG : SQFFD_SQ_OPTIMIZER_LM;
        if (v == 2) o[v].max_iterations = 5; /* the CG is slow; its workspace depends on neither */
        c.points = D.ed;
        c.n = v == 2 ? 30 : N_FIT;
        c.opt = &o[v];
        op.name = names[v]; op.run = sq_run; op.digest = sq_digest; op.ctx = &c;
        CHECK_RESULT(sqffd_sq_fit_workspace_size(c.n, &o[v], &op.size), SQFFD_OK);
        check_workspace(&op);
    }
}

static void test_memory_fit_exact_workspace(void)
{
    sqffd_fit_options o[2];
    static const char *names[2] = {"sqffd_fit", "sqffd_fit (robust, SVD, model_to_data, subsamples)"};
    fit_ctx c;
    mem_op op;
    int v;
    if (!setup()) return;
    for (v = 0; v < 2; v++) {
        o[v] = D.fit;
        if (v == 1) { /* every optional block of the layout */
            o[v].sq.robust = 1;
            o[v].solver = SQFFD_SOLVER_SVD;
            o[v].model_to_data = 1.0;
            o[v].sq_max_points = 200;
            o[v].ffd_max_points = 300;
            o[v].max_iterations = 2;
        }
        c.points = D.ed;
        c.n = N_FIT;
        c.opt = &o[v];
        op.name = names[v]; op.run = fit_run; op.digest = fit_digest; op.ctx = &c;
        CHECK_RESULT(sqffd_fit_workspace_size(N_FIT, &o[v], &op.size), SQFFD_OK);
        check_workspace(&op);
    }
}

static void test_memory_fit_ffd_exact_workspace(void)
{
    sqffd_fit_options o;
    fit_ctx c;
    mem_op op;
    int robust;
    if (!setup()) return;
    for (robust = 0; robust < 2; robust++) {
        o = D.fit;
        o.sq.robust = robust;
        c.points = D.es;
        c.n = N_FIT;
        c.opt = &o;
        c.start = &D.model;
        op.name = robust ? "sqffd_fit_ffd (robust)" : "sqffd_fit_ffd";
        op.run = fit_ffd_run; op.digest = fit_digest; op.ctx = &c;
        CHECK_RESULT(sqffd_fit_ffd_workspace_size(N_FIT, &D.model, &o, &op.size), SQFFD_OK);
        check_workspace(&op);
    }
}

static void test_memory_distances_exact_workspace(void)
{
    dist_ctx c;
    mem_op op;
    if (!setup()) return;
    c.model = &D.model;
    c.points = D.es;
    c.n = N_FIT;
    c.m = grid_vertices(&D.model);
    c.values = (double *)test_malloc((c.n > c.m ? c.n : c.m) * sizeof(double));
    op.name = "sqffd_model_distances"; op.run = dist_run; op.digest = dist_digest; op.ctx = &c;
    CHECK_RESULT(sqffd_model_distances_workspace_size(N_FIT, &D.model, &op.size), SQFFD_OK);
    check_workspace(&op);
    op.name = "sqffd_model_reverse_distances"; op.run = reverse_run; op.digest = reverse_digest;
    CHECK_RESULT(sqffd_model_reverse_distances_workspace_size(N_FIT, &D.model, &op.size), SQFFD_OK);
    check_workspace(&op);
    free(c.values);
}

static void test_memory_prepared_exact_workspace(void)
{
    system_ctx s;
    fit_ctx c;
    mem_op op;
    size_t size;
    void *memory;
    sqffd_ffd_system sys;
    if (!setup()) return;
    /* the system's memory block */
    s.model = &D.model;
    s.opt = &D.fit;
    s.use.points = D.es;
    s.use.n = N_FIT;
    s.use.opt = &D.fit;
    s.use.start = &D.model;
    op.name = "sqffd_ffd_system_init"; op.run = system_run; op.digest = system_digest; op.ctx = &s;
    CHECK_RESULT(sqffd_ffd_system_size(&D.model, &op.size), SQFFD_OK);
    check_workspace(&op);
    /* a run against a system */
    CHECK_RESULT(sqffd_ffd_system_size(&D.model, &size), SQFFD_OK);
    memory = test_malloc(size);
    CHECK_RESULT(sqffd_ffd_system_init(&sys, &D.model, &D.fit, memory, size), SQFFD_OK);
    c.points = D.es;
    c.n = N_FIT;
    c.opt = &D.fit;
    c.start = &D.model;
    c.system = &sys;
    op.name = "sqffd_fit_prepared"; op.run = fit_prepared_run; op.digest = fit_digest; op.ctx = &c;
    CHECK_RESULT(sqffd_fit_prepared_workspace_size(N_FIT, &sys, &D.fit, &op.size), SQFFD_OK);
    check_workspace(&op);
    free(memory);
}

static void test_memory_track_motion_exact_workspace(void)
{
    track_ctx *t = (track_ctx *)test_malloc(sizeof *t);
    motion_ctx m;
    sqffd_motion_options mo = sqffd_motion_options_default();
    sqffd_motion_outputs out;
    mem_op op;
    if (!setup()) { free(t); return; }
    track_op(&op, t);
    check_workspace(&op);
    motion_op(&op, &m, &mo, &out);
    check_workspace(&op);
    motion_outputs_free(&out);
    free(t);
}

static void test_memory_iso_exact_workspace(void)
{
    sqffd_iso_options o = sqffd_iso_options_default();
    iso_ctx c;
    mem_op op;
    int largest;
    if (!setup()) return;
    c.capacity = 2000;
    c.points = (double *)test_malloc(3 * c.capacity * sizeof(double));
    c.normals = (double *)test_malloc(3 * c.capacity * sizeof(double));
    c.volume = &D.volume;
    c.opt = &o;
    o.level = 100.0;
    for (largest = 0; largest < 2; largest++) {
        o.largest_component = largest;
        op.name = largest ? "sqffd_iso_points (largest component)" : "sqffd_iso_points";
        op.run = iso_run; op.digest = iso_digest; op.ctx = &c;
        CHECK_RESULT(sqffd_iso_workspace_size(&D.volume, &o, &op.size), SQFFD_OK);
        check_workspace(&op);
        CHECK(rw_digest(&op) != 0 && c.count > 100 && c.count <= c.capacity); /* (the short run above left count 0) */
    }
    free(c.points);
    free(c.normals);
}

/* ---- 2. read-only inputs ---------------------------------------------------- */
#if MEM_READ_ONLY

/* A copy of an input in read-only pages, flush against an inaccessible page. */
typedef struct ro_block {
    unsigned char *base;
    size_t length;
} ro_block;

static void *ro_copy(ro_block *b, const void *src, size_t bytes)
{
    size_t page = (size_t)sysconf(_SC_PAGESIZE), data = (bytes + page - 1) / page * page;
    unsigned char *p;
    if (data == 0) data = page;
    b->length = data + page;
    b->base = (unsigned char *)mmap(NULL, b->length, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (b->base == (unsigned char *)MAP_FAILED) {
        fprintf(stderr, "mmap failed\n");
        exit(2);
    }
    p = (unsigned char *)((uintptr_t)(b->base + data - bytes) & ~(uintptr_t)7); /* 8-aligned, at most 7 bytes short of the end */
    memcpy(p, src, bytes);
    if (mprotect(b->base, data, PROT_READ) != 0 || mprotect(b->base + data, page, PROT_NONE) != 0) {
        fprintf(stderr, "mprotect failed\n");
        exit(2);
    }
    return p;
}

static void ro_free(ro_block *b)
{
    munmap(b->base, b->length);
}

/* Pages for memory that is written once, then only read (a tree's or a
   system's memory), flush against an inaccessible page: writable until
   ro_seal. */
static void *ro_pages(ro_block *b, size_t bytes)
{
    size_t page = (size_t)sysconf(_SC_PAGESIZE), data = (bytes + page - 1) / page * page;
    if (data == 0) data = page;
    b->length = data + page;
    b->base = (unsigned char *)mmap(NULL, b->length, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (b->base == (unsigned char *)MAP_FAILED || mprotect(b->base + data, page, PROT_NONE) != 0) {
        fprintf(stderr, "mmap failed\n");
        exit(2);
    }
    return b->base + data - bytes;
}

static void ro_seal(ro_block *b)
{
    size_t page = (size_t)sysconf(_SC_PAGESIZE);
    if (mprotect(b->base, b->length - page, PROT_READ) != 0) {
        fprintf(stderr, "mprotect failed\n");
        exit(2);
    }
}

static sigjmp_buf ro_jump;
static volatile sig_atomic_t ro_armed;

static void ro_on_fault(int sig)
{
    if (ro_armed) {
        ro_armed = 0;
        siglongjmp(ro_jump, 1);
    }
    signal(sig, SIG_DFL);
    raise(sig);
}

/* Runs op in a fresh exact workspace with a fault guard: a write to a
   read-only input (or a read past one) fails the test instead of killing the
   runner. Returns the digest of the outputs (0 when it failed). */
static uint64_t ro_run(const mem_op *op)
{
    struct sigaction sa, old_segv, old_bus;
    void *ws = test_malloc(op->size);
    volatile uint64_t h = 0;
    volatile sqffd_result r = SQFFD_ERROR_INVALID_ARGUMENT;
    volatile int faulted = 0;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = ro_on_fault;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGSEGV, &sa, &old_segv);
    sigaction(SIGBUS, &sa, &old_bus);
    if (sigsetjmp(ro_jump, 1) == 0) {
        ro_armed = 1;
        r = op->run(op->ctx, ws, op->size);
        if (r == SQFFD_OK && op->digest) h = op->digest(op->ctx);
        ro_armed = 0;
    } else {
        faulted = 1;
    }
    sigaction(SIGSEGV, &old_segv, NULL);
    sigaction(SIGBUS, &old_bus, NULL);
    free(ws);
    CHECK_MSG(!faulted, "%s: fault on a read-only input (a write to it, or a read past its end)", op->name);
    CHECK_MSG(faulted || r == SQFFD_OK, "%s with read-only inputs: %s", op->name, sqffd_result_string(r));
    return h;
}

static void test_memory_read_only_inputs(void)
{
    ro_block b_ed, b_es, b_fit, b_sq, b_model, b_a, b_b, b_cg, b_diag, b_track, b_frames, b_frame[FRAMES], b_counts;
    ro_block b_models, b_motion, b_out, b_vox, b_vol, b_iso, b_tree, b_sys, b_sysmem;
    const double *ed, *es, *frame[FRAMES];
    const sqffd_fit_options *fo;
    const sqffd_model *model;
    sqffd_sq_fit_options sqo = sqffd_sq_fit_options_default();
    sqffd_cg_options cgo = sqffd_cg_options_default();
    sqffd_motion_options mo = sqffd_motion_options_default();
    sqffd_iso_options io = sqffd_iso_options_default();
    sqffd_motion_outputs out;
    sqffd_volume vol;
    double a[SVD_M * SVD_N], b[CG_N], diag[CG_N];
    svd_ctx sv;
    cg_ctx cg;
    kd_ctx kd;
    sq_ctx sq;
    fit_ctx fit;
    dist_ctx dist;
    system_ctx sys;
    track_ctx *tr = (track_ctx *)test_malloc(sizeof *tr);
    motion_ctx mot;
    iso_ctx iso;
    mem_op op;
    uint64_t want;
    size_t nv, t;
    if (!setup()) { free(tr); return; }
    ed = (const double *)ro_copy(&b_ed, D.ed, sizeof D.ed);
    es = (const double *)ro_copy(&b_es, D.es, sizeof D.es);
    fo = (const sqffd_fit_options *)ro_copy(&b_fit, &D.fit, sizeof D.fit);
    model = (const sqffd_model *)ro_copy(&b_model, &D.model, sizeof D.model);

    /* svd: the matrix */
    svd_op(&op, &sv, a);
    want = rw_digest(&op);
    sv.a = (const double *)ro_copy(&b_a, a, sizeof a);
    CHECK(ro_run(&op) == want);
    /* cg: b, the options and their diagonal */
    cg_op(&op, &cg, &cgo, b, diag);
    want = rw_digest(&op);
    cgo.jacobi_diagonal = (const double *)ro_copy(&b_diag, diag, sizeof diag);
    cg.opt = (const sqffd_cg_options *)ro_copy(&b_cg, &cgo, sizeof cgo);
    cg.b = (const double *)ro_copy(&b_b, b, sizeof b);
    CHECK(ro_run(&op) == want);

    /* kd-tree: the points; then the built tree's memory, read-only, queried */
    kd.points = D.ed;
    kd.n = N_FIT;
    op.name = "sqffd_kdtree_build"; op.run = kd_run; op.digest = kd_digest; op.ctx = &kd;
    CHECK_RESULT(sqffd_kdtree_workspace_size(N_FIT, &op.size), SQFFD_OK);
    want = rw_digest(&op);
    kd.points = ed;
    CHECK(ro_run(&op) == want);
    {
        void *mem = ro_pages(&b_tree, op.size);
        CHECK_RESULT(sqffd_kdtree_build(&kd.tree, ed, N_FIT, mem, op.size), SQFFD_OK);
        ro_seal(&b_tree);
        op.name = "sqffd_kdtree queries on a read-only tree";
        op.run = kd_built;
        CHECK(ro_run(&op) == want);
        ro_free(&b_tree);
    }

    /* superquadric fit: points and options */
    sq.points = D.ed;
    sq.n = N_FIT;
    sq.opt = &sqo;
    op.name = "sqffd_sq_fit"; op.run = sq_run; op.digest = sq_digest; op.ctx = &sq;
    CHECK_RESULT(sqffd_sq_fit_workspace_size(N_FIT, &sqo, &op.size), SQFFD_OK);
    want = rw_digest(&op);
    sq.points = ed;
    sq.opt = (const sqffd_sq_fit_options *)ro_copy(&b_sq, &sqo, sizeof sqo);
    CHECK(ro_run(&op) == want);

    /* whole fit, FFD stage: points and options */
    fit.points = D.ed;
    fit.n = N_FIT;
    fit.opt = &D.fit;
    fit.start = &D.model;
    op.name = "sqffd_fit"; op.run = fit_run; op.digest = fit_digest; op.ctx = &fit;
    CHECK_RESULT(sqffd_fit_workspace_size(N_FIT, &D.fit, &op.size), SQFFD_OK);
    want = rw_digest(&op);
    fit.points = ed;
    fit.opt = fo;
    CHECK(ro_run(&op) == want);
    fit.points = D.es;
    fit.opt = &D.fit;
    op.name = "sqffd_fit_ffd"; op.run = fit_ffd_run;
    CHECK_RESULT(sqffd_fit_ffd_workspace_size(N_FIT, &D.model, &D.fit, &op.size), SQFFD_OK);
    want = rw_digest(&op);
    fit.points = es;
    fit.opt = fo;
    fit.start = model;
    CHECK(ro_run(&op) == want);

    /* distances: model and points */
    nv = grid_vertices(&D.model);
    dist.model = &D.model;
    dist.points = D.es;
    dist.n = N_FIT;
    dist.m = nv;
    dist.values = (double *)test_malloc((N_FIT > nv ? N_FIT : nv) * sizeof(double));
    op.name = "sqffd_model_distances"; op.run = dist_run; op.digest = dist_digest; op.ctx = &dist;
    CHECK_RESULT(sqffd_model_distances_workspace_size(N_FIT, &D.model, &op.size), SQFFD_OK);
    want = rw_digest(&op);
    dist.model = model;
    dist.points = es;
    CHECK(ro_run(&op) == want);
    dist.model = &D.model;
    dist.points = D.es;
    op.name = "sqffd_model_reverse_distances"; op.run = reverse_run; op.digest = reverse_digest;
    CHECK_RESULT(sqffd_model_reverse_distances_workspace_size(N_FIT, &D.model, &op.size), SQFFD_OK);
    want = rw_digest(&op);
    dist.model = model;
    dist.points = es;
    CHECK(ro_run(&op) == want);
    free(dist.values);

    /* a prepared system: model and options read-only at init; then its
       memory and the struct itself read-only, two runs against it */
    sys.model = model;
    sys.opt = fo;
    {
        size_t size = 0;
        void *mem;
        const sqffd_ffd_system *sealed;
        CHECK_RESULT(sqffd_ffd_system_size(&D.model, &size), SQFFD_OK);
        mem = ro_pages(&b_sysmem, size);
        CHECK_RESULT(sqffd_ffd_system_init(&sys.system, model, fo, mem, size), SQFFD_OK);
        ro_seal(&b_sysmem);
        sealed = (const sqffd_ffd_system *)ro_copy(&b_sys, &sys.system, sizeof sys.system);
        fit.points = D.es;
        fit.opt = &D.fit;
        fit.start = &D.model;
        fit.system = &sys.system;
        op.name = "sqffd_fit_prepared"; op.run = fit_prepared_run; op.digest = fit_digest; op.ctx = &fit;
        CHECK_RESULT(sqffd_fit_prepared_workspace_size(N_FIT, &sys.system, &D.fit, &op.size), SQFFD_OK);
        fit.system = sealed;
        fit.points = es;
        fit.opt = fo;
        fit.start = model;
        want = ro_run(&op);
        CHECK(ro_run(&op) == want); /* twice: nothing of the system changed */
        {   /* the same as sqffd_fit_ffd's, to the bit */
            fit_ctx plain = fit;
            mem_op o2 = op;
            o2.ctx = &plain;
            o2.run = fit_ffd_run;
            CHECK_RESULT(sqffd_fit_ffd_workspace_size(N_FIT, &D.model, &D.fit, &o2.size), SQFFD_OK);
            CHECK(rw_digest(&o2) == want);
        }
        ro_free(&b_sys);
        ro_free(&b_sysmem);
    }

    /* tracking: the frame pointers, the frames, the counts, the options */
    track_op(&op, tr);
    want = rw_digest(&op);
    for (t = 0; t < FRAMES; t++) frame[t] = (const double *)ro_copy(&b_frame[t], D.frame[t], sizeof D.frame[t]);
    tr->frames = (const double *const *)ro_copy(&b_frames, frame, sizeof frame);
    tr->counts = (const size_t *)ro_copy(&b_counts, D.counts, sizeof D.counts);
    tr->opt = (const sqffd_track_options *)ro_copy(&b_track, &D.track, sizeof D.track);
    CHECK(ro_run(&op) == want);

    /* motion: the models, the options, the outputs struct (its arrays are written) */
    motion_op(&op, &mot, &mo, &out);
    want = rw_digest(&op);
    mot.models = (const sqffd_model *)ro_copy(&b_models, D.tracked, sizeof D.tracked);
    mot.opt = (const sqffd_motion_options *)ro_copy(&b_motion, &mo, sizeof mo);
    mot.out = (const sqffd_motion_outputs *)ro_copy(&b_out, &out, sizeof out);
    CHECK(ro_run(&op) == want);
    motion_outputs_free(&out);

    /* iso points: the voxels, the view, the options */
    io.level = 100.0;
    io.largest_component = 1;
    iso.capacity = 2000;
    iso.points = (double *)test_malloc(3 * iso.capacity * sizeof(double));
    iso.normals = (double *)test_malloc(3 * iso.capacity * sizeof(double));
    iso.volume = &D.volume;
    iso.opt = &io;
    op.name = "sqffd_iso_points"; op.run = iso_run; op.digest = iso_digest; op.ctx = &iso;
    CHECK_RESULT(sqffd_iso_workspace_size(&D.volume, &io, &op.size), SQFFD_OK);
    want = rw_digest(&op);
    vol = D.volume;
    vol.data = ro_copy(&b_vox, D.voxels, sizeof D.voxels);
    iso.volume = (const sqffd_volume *)ro_copy(&b_vol, &vol, sizeof vol);
    iso.opt = (const sqffd_iso_options *)ro_copy(&b_iso, &io, sizeof io);
    CHECK(ro_run(&op) == want);
    free(iso.points);
    free(iso.normals);

    ro_free(&b_ed); ro_free(&b_es); ro_free(&b_fit); ro_free(&b_sq); ro_free(&b_model); ro_free(&b_a);
    ro_free(&b_b); ro_free(&b_cg); ro_free(&b_diag); ro_free(&b_track); ro_free(&b_frames); ro_free(&b_counts);
    for (t = 0; t < FRAMES; t++) ro_free(&b_frame[t]);
    ro_free(&b_models); ro_free(&b_motion); ro_free(&b_out); ro_free(&b_vox); ro_free(&b_vol); ro_free(&b_iso);
    free(tr);
}
#endif

/* ---- 3. the same call twice, the same bits ---------------------------------- */

static int same_model(const sqffd_model *a, const sqffd_model *b)
{
    return memcmp(&a->sq, &b->sq, sizeof a->sq) == 0 && memcmp(a->ffd.dims, b->ffd.dims, sizeof a->ffd.dims) == 0 &&
           memcmp(a->ffd.origin, b->ffd.origin, sizeof a->ffd.origin) == 0 &&
           memcmp(a->ffd.edges, b->ffd.edges, sizeof a->ffd.edges) == 0 &&
           memcmp(a->ffd.control, b->ffd.control, used_controls(&a->ffd) * sizeof a->ffd.control[0]) == 0 &&
           memcmp(a->grid, b->grid, sizeof a->grid) == 0;
}

static void test_memory_fit_twice_bit_identical(void)
{
    sqffd_fit_options o;
    sqffd_model m1, m2;
    sqffd_fit_report r1, r2;
    size_t size;
    unsigned char *w1, *w2;
    int robust;
    if (!setup()) return;
    for (robust = 0; robust < 2; robust++) {
        o = D.fit;
        o.sq.robust = robust;
        CHECK_RESULT(sqffd_fit_workspace_size(N_FIT, &o, &size), SQFFD_OK);
        w1 = (unsigned char *)test_malloc(size);
        w2 = (unsigned char *)test_malloc(size + 3);
        memset(w1, 0x00, size);
        memset(w2, 0xFF, size + 3);
        memset(&m1, 0x11, sizeof m1);
        memset(&m2, 0x22, sizeof m2);
        CHECK_RESULT(sqffd_fit(D.ed, N_FIT, &o, &m1, &r1, w1, size), SQFFD_OK);
        CHECK_RESULT(sqffd_fit(D.ed, N_FIT, &o, &m2, &r2, w2 + 3, size), SQFFD_OK);
        CHECK_MSG(same_model(&m1, &m2), "robust %d: two fits of the same points differ", robust);
        CHECK(memcmp(&r1.error, &r2.error, sizeof r1.error) == 0 && r1.iterations == r2.iterations &&
              memcmp(&r1.energy, &r2.energy, sizeof r1.energy) == 0);
        CHECK(hash_fit_report(HASH0, &r1) == hash_fit_report(HASH0, &r2));
        CHECK(hash_sq_report(HASH0, &r1.sq) == hash_sq_report(HASH0, &r2.sq));
        /* the same in a dirty workspace, after another operation used it */
        CHECK_RESULT(sqffd_fit(D.es, N_FIT, &o, &m2, &r2, w2, size), SQFFD_OK);
        CHECK_RESULT(sqffd_fit(D.ed, N_FIT, &o, &m2, &r2, w2, size), SQFFD_OK);
        CHECK_MSG(same_model(&m1, &m2), "robust %d: a fit after another in the same workspace differs", robust);
        free(w1);
        free(w2);
    }
}

static void test_memory_track_twice_bit_identical(void)
{
    track_ctx *a = (track_ctx *)test_malloc(sizeof *a), *b = (track_ctx *)test_malloc(sizeof *b);
    size_t size;
    void *ws;
    int t;
    if (!setup()) { free(a); free(b); return; }
    a->frames = b->frames = D.frames;
    a->counts = b->counts = D.counts;
    a->opt = b->opt = &D.track;
    CHECK_RESULT(sqffd_track_workspace_size(D.counts, FRAMES, &D.track, &size), SQFFD_OK);
    ws = test_malloc(size);
    memset(ws, 0x00, size);
    CHECK_RESULT(track_run(a, ws, size), SQFFD_OK);
    memset(ws, 0xFF, size);
    CHECK_RESULT(track_run(b, ws, size), SQFFD_OK);
    for (t = 0; t < FRAMES; t++) {
        CHECK_MSG(same_model(&a->models[t], &b->models[t]), "frame %d: two tracks of the same frames differ", t);
        CHECK_MSG(same_model(&a->models[t], &D.tracked[t]), "frame %d: differs from the setup's track", t);
    }
    CHECK(track_digest(a) == track_digest(b));
    free(ws);
    free(a);
    free(b);
}

/* ---- 4. outputs after errors and cancels (where the header says) ----------- */

static int cancel_at_once(void *user, int stage, int iteration, double error)
{
    (void)user; (void)stage; (void)iteration; (void)error;
    return 1;
}

/* sqffd_sq_fit: "On failure *sq and *report are not written." */
static void test_memory_sq_fit_failure_writes_nothing(void)
{
    sqffd_sq_fit_options o = sqffd_sq_fit_options_default(), bad;
    sqffd_superquadric sq, sentinel_sq;
    sqffd_sq_fit_report rep, sentinel_rep;
    double flat[3 * 100], nan_pts[3 * 100];
    size_t size = 0, i;
    void *ws;
    CHECK_RESULT(sqffd_sq_fit_workspace_size(N_FIT, &o, &size), SQFFD_OK);
    ws = test_malloc(size);
    if (!setup()) { free(ws); return; }
    memset(&sentinel_sq, 0x5A, sizeof sentinel_sq);
    memset(&sentinel_rep, 0x5A, sizeof sentinel_rep);
#define SQ_FAILS(call, expected, what)                                                            \
    do {                                                                                          \
        sq = sentinel_sq;                                                                         \
        rep = sentinel_rep;                                                                       \
        CHECK_RESULT(call, expected);                                                             \
        CHECK_MSG(memcmp(&sq, &sentinel_sq, sizeof sq) == 0, "%s: *sq written on failure", what); \
        CHECK_MSG(memcmp(&rep, &sentinel_rep, sizeof rep) == 0, "%s: *report written on failure", what); \
    } while (0)
    bad = o;
    bad.progress = cancel_at_once;
    SQ_FAILS(sqffd_sq_fit(D.ed, N_FIT, &bad, &sq, &rep, ws, size), SQFFD_ERROR_CANCELLED, "cancelled (LM)");
    bad.optimizer = SQFFD_SQ_OPTIMIZER_CG;
    SQ_FAILS(sqffd_sq_fit(D.ed, 100, &bad, &sq, &rep, ws, size), SQFFD_ERROR_CANCELLED, "cancelled (CG)");
    bad = o;
    bad.robust = 1;
    bad.progress = cancel_at_once;
    SQ_FAILS(sqffd_sq_fit(D.ed, 100, &bad, &sq, &rep, ws, size), SQFFD_ERROR_CANCELLED, "cancelled (robust)");
    SQ_FAILS(sqffd_sq_fit(D.ed, N_FIT, &o, &sq, &rep, ws, size - 1), SQFFD_ERROR_WORKSPACE_TOO_SMALL, "workspace");
    SQ_FAILS(sqffd_sq_fit(D.ed, SQFFD_SQ_FIT_MIN_POINTS - 1, &o, &sq, &rep, ws, size), SQFFD_ERROR_TOO_FEW_POINTS,
             "too few points");
    bad = o;
    bad.shape_min = 1.5;
    bad.shape_max = 1.0;
    SQ_FAILS(sqffd_sq_fit(D.ed, N_FIT, &bad, &sq, &rep, ws, size), SQFFD_ERROR_INVALID_ARGUMENT, "bad options");
    memcpy(nan_pts, D.ed, sizeof nan_pts);
    nan_pts[3 * 99 + 2] = NAN;
    SQ_FAILS(sqffd_sq_fit(nan_pts, 100, &o, &sq, &rep, ws, size), SQFFD_ERROR_NON_FINITE, "NaN");
    for (i = 0; i < 100; i++) {
        flat[3 * i] = D.ed[3 * i];
        flat[3 * i + 1] = D.ed[3 * i + 1];
        flat[3 * i + 2] = 4.0;
    }
    SQ_FAILS(sqffd_sq_fit(flat, 100, &o, &sq, &rep, ws, size), SQFFD_ERROR_DEGENERATE, "coplanar");
#undef SQ_FAILS
    free(ws);
}

static int tree_is_zeroed(const sqffd_kdtree *t)
{
    int a, c;
    for (a = 0; a < 2; a++)
        for (c = 0; c < 3; c++)
            if (t->bbox[a][c] != 0.0) return 0;
    return !t->points.xyz && t->count == 0 && !t->index && !t->nodes && t->node_count == 0;
}

/* sqffd_kdtree_build: "on error *tree is zeroed"; sqffd_kdtree_refit: "on
   error the tree is unchanged" (the struct, its permutation and nodes). */
static void test_memory_kdtree_failure_outputs(void)
{
    enum { N = 300 };
    double *p = (double *)test_malloc(3 * N * sizeof *p), *moved = (double *)test_malloc(3 * N * sizeof *moved);
    size_t size = 0, i;
    unsigned char *ws, *nodes_before;
    uint32_t *index_before;
    sqffd_kdtree tree, before;
    CHECK_RESULT(sqffd_kdtree_workspace_size(N, &size), SQFFD_OK);
    ws = (unsigned char *)test_malloc(size);
    if (!setup()) { free(p); free(moved); free(ws); return; }
    memcpy(p, D.ed, 3 * 200 * sizeof *p);
    for (i = 200; i < N; i++) { p[3 * i] = 100.0; p[3 * i + 1] = 100.0; p[3 * i + 2] = 100.0; } /* a pile: one big leaf */
#define BUILD_FAILS(call, expected, what)                                            \
    do {                                                                             \
        memset(&tree, 0x5A, sizeof tree);                                            \
        CHECK_RESULT(call, expected);                                                \
        CHECK_MSG(tree_is_zeroed(&tree), "%s: the tree is not zeroed on error", what); \
    } while (0)
    BUILD_FAILS(sqffd_kdtree_build(&tree, p, N, ws, size - 1), SQFFD_ERROR_WORKSPACE_TOO_SMALL, "one byte short");
    BUILD_FAILS(sqffd_kdtree_build(&tree, p, N, NULL, size), SQFFD_ERROR_WORKSPACE_TOO_SMALL, "NULL workspace");
    BUILD_FAILS(sqffd_kdtree_build(&tree, p, 0, ws, size), SQFFD_ERROR_INVALID_ARGUMENT, "n = 0");
    BUILD_FAILS(sqffd_kdtree_build(&tree, NULL, N, ws, size), SQFFD_ERROR_INVALID_ARGUMENT, "NULL points");
    if (sizeof(size_t) > 4)
        BUILD_FAILS(sqffd_kdtree_build(&tree, p, (size_t)UINT32_MAX + 1, ws, size), SQFFD_ERROR_TOO_LARGE, "n > 2^32 - 1");
    p[3 * 150 + 1] = INFINITY;
    BUILD_FAILS(sqffd_kdtree_build(&tree, p, N, ws, size), SQFFD_ERROR_NON_FINITE, "infinity");
    p[3 * 150 + 1] = D.ed[3 * 150 + 1];
#undef BUILD_FAILS
    CHECK_RESULT(sqffd_kdtree_build(&tree, p, N, ws, size), SQFFD_OK);
    before = tree;
    index_before = (uint32_t *)test_malloc(N * sizeof *index_before);
    nodes_before = (unsigned char *)test_malloc(tree.node_count * sizeof *tree.nodes);
    memcpy(index_before, tree.index, N * sizeof *index_before);
    memcpy(nodes_before, tree.nodes, tree.node_count * sizeof *tree.nodes);
    memcpy(moved, p, 3 * N * sizeof *moved);
    for (i = 0; i < 3 * N; i++) moved[i] += 0.5;
    moved[3 * 250] += 1e-6; /* the pile comes apart */
    CHECK_RESULT(sqffd_kdtree_refit(&tree, moved), SQFFD_ERROR_DEGENERATE);
    CHECK(memcmp(&tree, &before, sizeof tree) == 0 && memcmp(index_before, tree.index, N * sizeof *index_before) == 0 &&
          memcmp(nodes_before, tree.nodes, tree.node_count * sizeof *tree.nodes) == 0);
    moved[3 * 250] -= 1e-6;
    moved[3 * 17 + 2] = NAN;
    CHECK_RESULT(sqffd_kdtree_refit(&tree, moved), SQFFD_ERROR_NON_FINITE);
    CHECK(memcmp(&tree, &before, sizeof tree) == 0 && memcmp(index_before, tree.index, N * sizeof *index_before) == 0 &&
          memcmp(nodes_before, tree.nodes, tree.node_count * sizeof *tree.nodes) == 0);
    moved[3 * 17 + 2] = p[3 * 17 + 2] + 0.5;
    CHECK_RESULT(sqffd_kdtree_refit(&tree, moved), SQFFD_OK);
    free(index_before); free(nodes_before); free(p); free(moved); free(ws);
}

/* sqffd_cholesky_factor: NON_FINITE writes nothing. */
static void test_memory_cholesky_nonfinite_writes_nothing(void)
{
    double a[16], keep[16];
    int i, j;
    for (i = 0; i < 4; i++)
        for (j = 0; j < 4; j++) a[4 * i + j] = i == j ? 4.0 + i : 1.0 / (1.0 + i + j);
    a[4 * 3 + 1] = NAN;
    memcpy(keep, a, sizeof a);
    CHECK_RESULT(sqffd_cholesky_factor(a, 4), SQFFD_ERROR_NON_FINITE);
    CHECK(memcmp(a, keep, sizeof a) == 0);
}

/* sqffd_ncg_minimize: cancelled, x is the last accepted point (the one whose
   f the progress callback saw last, and *fx). */
static int ncg_cancel_third(void *user, int stage, int iteration, double error)
{
    double *last = (double *)user;
    (void)stage;
    *last = error;
    return iteration == 3;
}

static void test_memory_ncg_cancel_last_point(void)
{
    size_t size = 0;
    void *ws;
    double x[NCG_N], g[NCG_N], fx = 0.0, last = -1.0;
    sqffd_ncg_options o = sqffd_ncg_options_default();
    int i, it = 0;
    CHECK_RESULT(sqffd_ncg_workspace_size(NCG_N, &size), SQFFD_OK);
    ws = test_malloc(size);
    o.max_iterations = 200;
    o.tolerance = 1e-12;
    o.project = ncg_box;
    o.progress = ncg_cancel_third;
    o.progress_user = &last;
    for (i = 0; i < NCG_N; i++) x[i] = -1.0 + 0.3 * i;
    CHECK_RESULT(sqffd_ncg_minimize(NCG_N, ncg_f, NULL, x, &o, &it, &fx, ws, size), SQFFD_ERROR_CANCELLED);
    CHECK(it == 3);
    CHECK_MSG(ncg_f(NULL, x, g) == last && fx == last, "f(x) = %.17g, progress saw %.17g, *fx = %.17g",
              ncg_f(NULL, x, g), last, fx);
    free(ws);
}

/* sqffd_cg_solve: at the iteration limit x is the last iterate and the
   residual reported is its true one. */
static void test_memory_cg_limit_last_iterate(void)
{
    size_t size = 0;
    void *ws;
    sqffd_cg_options o = sqffd_cg_options_default();
    double b[CG_N], x[CG_N], y[CG_N], r2 = 0.0, b2 = 0.0, rel = -1.0;
    int i, it = 0;
    CHECK_RESULT(sqffd_cg_workspace_size(CG_N, &size), SQFFD_OK);
    ws = test_malloc(size);
    for (i = 0; i < CG_N; i++) {
        b[i] = cos(0.9 * i);
        x[i] = 0.0;
    }
    o.max_iterations = 3;
    o.tolerance = 1e-14;
    CHECK_RESULT(sqffd_cg_solve(CG_N, cg_matvec, NULL, b, x, &o, &it, &rel, ws, size), SQFFD_ERROR_NO_CONVERGENCE);
    CHECK(it == 3);
    cg_matvec(NULL, x, y);
    for (i = 0; i < CG_N; i++) {
        r2 += (b[i] - y[i]) * (b[i] - y[i]);
        b2 += b[i] * b[i];
    }
    CHECK_NEAR(rel, sqrt(r2 / b2), 1e-12);
    CHECK(rel > 1e-6); /* 3 steps are not enough: x is a true intermediate iterate */
    free(ws);
}

/* sqffd_track refused for a workspace one byte short: "refused before any
   frame", so frames_done = 0 frames fitted. */
static void test_memory_track_short_workspace_no_frame(void)
{
    sqffd_model *models = (sqffd_model *)test_malloc(FRAMES * sizeof *models);
    size_t size, done = 99;
    void *ws;
    if (!setup()) { free(models); return; }
    CHECK_RESULT(sqffd_track_workspace_size(D.counts, FRAMES, &D.track, &size), SQFFD_OK);
    ws = test_malloc(size);
    CHECK_RESULT(sqffd_track(D.frames, D.counts, FRAMES, &D.track, models, NULL, &done, ws, size - 1),
                 SQFFD_ERROR_WORKSPACE_TOO_SMALL);
    CHECK_MSG(done == 0, "frames_done %zu", done);
    free(ws);
    free(models);
}

/* Output arrays: written up to their documented size, not one byte past. */
static int tail_intact(const void *array, size_t bytes)
{
    return first_changed((const unsigned char *)array + bytes, GUARD, CANARY) == GUARD;
}

static void *with_tail(size_t bytes)
{
    unsigned char *p = (unsigned char *)test_malloc(bytes + GUARD);
    memset(p, CANARY, bytes + GUARD);
    return p;
}

static void test_memory_output_arrays_exact(void)
{
    size_t nv, nt, size, count = 0, k, got;
    double *values, *points, *normals, *dist2;
    size_t *idx;
    uint32_t *tri;
    void *ws;
    sqffd_iso_options io = sqffd_iso_options_default();
    sqffd_kdtree tree;
    double q[3] = {1.0, 2.0, -3.0};
    if (!setup()) return;
    /* distances: n per point; reverse: one per grid vertex */
    nv = grid_vertices(&D.model);
    CHECK_RESULT(sqffd_model_distances_workspace_size(N_FIT, &D.model, &size), SQFFD_OK);
    ws = test_malloc(size);
    values = (double *)with_tail(N_FIT * sizeof(double));
    CHECK_RESULT(sqffd_model_distances(&D.model, D.es, N_FIT, values, NULL, ws, size), SQFFD_OK);
    CHECK_MSG(tail_intact(values, N_FIT * sizeof(double)), "sqffd_model_distances wrote past per_point[n]");
    free(values);
    free(ws);
    CHECK_RESULT(sqffd_model_reverse_distances_workspace_size(N_FIT, &D.model, &size), SQFFD_OK);
    ws = test_malloc(size);
    values = (double *)with_tail(nv * sizeof(double));
    CHECK_RESULT(sqffd_model_reverse_distances(&D.model, D.es, N_FIT, values, NULL, ws, size), SQFFD_OK);
    CHECK_MSG(tail_intact(values, nv * sizeof(double)), "sqffd_model_reverse_distances wrote past per_vertex[M]");
    free(values);
    free(ws);
    /* the mesh into buffers of exactly its size */
    CHECK_RESULT(sqffd_model_mesh_size(9, 11, &nv, &nt), SQFFD_OK);
    points = (double *)with_tail(3 * nv * sizeof(double));
    tri = (uint32_t *)with_tail(3 * nt * sizeof(uint32_t));
    (void)sqffd_model_mesh(&D.model, 9, 11, points, tri);
    CHECK_MSG(tail_intact(points, 3 * nv * sizeof(double)) && tail_intact(tri, 3 * nt * sizeof(uint32_t)),
              "sqffd_model_mesh wrote past its vertices or triangles");
    free(points);
    free(tri);
    /* iso points with room for one less than all of them (OUTPUT_TOO_SMALL, the count needed,
       nothing written), then for exactly all */
    io.level = 100.0;
    CHECK_RESULT(sqffd_iso_workspace_size(&D.volume, &io, &size), SQFFD_OK);
    ws = test_malloc(size);
    CHECK_RESULT(sqffd_iso_points(&D.volume, &io, NULL, NULL, 0, &count, ws, size), SQFFD_OK);
    CHECK(count > 10);
    k = count - 1;
    points = (double *)with_tail(3 * k * sizeof(double));
    normals = (double *)with_tail(3 * k * sizeof(double));
    memset(points, 0, 3 * k * sizeof(double));
    memset(normals, 0, 3 * k * sizeof(double));
    got = 0;
    CHECK_RESULT(sqffd_iso_points(&D.volume, &io, points, normals, k, &got, ws, size), SQFFD_ERROR_OUTPUT_TOO_SMALL);
    CHECK(got == count);
    CHECK_MSG(test_all_zero(points, 3 * k) && test_all_zero(normals, 3 * k) && tail_intact(points, 3 * k * sizeof(double)) &&
                  tail_intact(normals, 3 * k * sizeof(double)),
              "sqffd_iso_points wrote into a buffer too small");
    free(points);
    free(normals);
    points = (double *)with_tail(3 * count * sizeof(double));
    normals = (double *)with_tail(3 * count * sizeof(double));
    CHECK_RESULT(sqffd_iso_points(&D.volume, &io, points, normals, count, &got, ws, size), SQFFD_OK);
    CHECK(got == count);
    CHECK_MSG(tail_intact(points, 3 * count * sizeof(double)) && tail_intact(normals, 3 * count * sizeof(double)),
              "sqffd_iso_points wrote past capacity");
    free(points);
    free(normals);
    free(ws);
    /* kd-tree queries: k and capacity */
    CHECK_RESULT(sqffd_kdtree_workspace_size(N_FIT, &size), SQFFD_OK);
    ws = test_malloc(size);
    CHECK_RESULT(sqffd_kdtree_build(&tree, D.ed, N_FIT, ws, size), SQFFD_OK);
    idx = (size_t *)with_tail(7 * sizeof(size_t));
    dist2 = (double *)with_tail(7 * sizeof(double));
    got = 0;
    CHECK_RESULT(sqffd_kdtree_knn(&tree, q, 7, idx, dist2, &got), SQFFD_OK);
    CHECK(got == 7);
    CHECK(tail_intact(idx, 7 * sizeof(size_t)) && tail_intact(dist2, 7 * sizeof(double)));
    got = 0;
    memset(idx, 0, 7 * sizeof(size_t));
    memset(dist2, 0, 7 * sizeof(double));
    CHECK_RESULT(sqffd_kdtree_radius(&tree, q, 1e9, idx, dist2, 7, &got), SQFFD_ERROR_OUTPUT_TOO_SMALL);
    CHECK(got == N_FIT);
    CHECK(test_all_zero(dist2, 7) && tail_intact(idx, 7 * sizeof(size_t)) && tail_intact(dist2, 7 * sizeof(double)));
    for (got = 0; got < 7; got++) CHECK(idx[got] == 0);
    free(idx);
    free(dist2);
    free(ws);
    /* svd */
    {
        double a[SVD_M * SVD_N], *u = (double *)with_tail(SVD_M * SVD_N * sizeof(double));
        double *s = (double *)with_tail(SVD_N * sizeof(double)), *v = (double *)with_tail(SVD_N * SVD_N * sizeof(double));
        svd_matrix(a);
        CHECK_RESULT(sqffd_svd_workspace_size(SVD_M, SVD_N, &size), SQFFD_OK);
        ws = test_malloc(size);
        CHECK_RESULT(sqffd_svd(a, SVD_M, SVD_N, u, s, v, ws, size), SQFFD_OK);
        CHECK(tail_intact(u, SVD_M * SVD_N * sizeof(double)) && tail_intact(s, SVD_N * sizeof(double)) &&
              tail_intact(v, SVD_N * SVD_N * sizeof(double)));
        free(u); free(s); free(v); free(ws);
    }
    /* track: frame_count models and reports; motion: its arrays */
    {
        sqffd_model *models = (sqffd_model *)with_tail(FRAMES * sizeof(sqffd_model));
        sqffd_fit_report *reports = (sqffd_fit_report *)with_tail(FRAMES * sizeof(sqffd_fit_report));
        sqffd_motion_outputs out;
        sqffd_motion_report rep;
        CHECK_RESULT(sqffd_track_workspace_size(D.counts, FRAMES, &D.track, &size), SQFFD_OK);
        ws = test_malloc(size);
        CHECK_RESULT(sqffd_track(D.frames, D.counts, FRAMES, &D.track, models, reports, NULL, ws, size), SQFFD_OK);
        CHECK_MSG(tail_intact(models, FRAMES * sizeof(sqffd_model)) &&
                  tail_intact(reports, FRAMES * sizeof(sqffd_fit_report)), "sqffd_track wrote past its frames");
        free(ws);
        nv = grid_vertices(&models[0]);
        out.volumes = (double *)with_tail(FRAMES * sizeof(double));
        out.trajectories = (double *)with_tail(3 * FRAMES * nv * sizeof(double));
        out.displacement = (double *)with_tail(nv * sizeof(double));
        out.excursion = (double *)with_tail(nv * sizeof(double));
        out.low_motion = (unsigned char *)with_tail(nv);
        out.segment = (unsigned char *)with_tail(nv);
        CHECK_RESULT(sqffd_motion_workspace_size(models, FRAMES, &size), SQFFD_OK);
        ws = test_malloc(size);
        CHECK_RESULT(sqffd_motion(models, FRAMES, NULL, &out, &rep, ws, size), SQFFD_OK);
        CHECK_MSG(tail_intact(out.volumes, FRAMES * sizeof(double)) &&
                  tail_intact(out.trajectories, 3 * FRAMES * nv * sizeof(double)) &&
                  tail_intact(out.displacement, nv * sizeof(double)) && tail_intact(out.excursion, nv * sizeof(double)) &&
                  tail_intact(out.low_motion, nv) && tail_intact(out.segment, nv),
                  "sqffd_motion wrote past an output array");
        free(out.volumes); free(out.trajectories); free(out.displacement); free(out.excursion);
        free(out.low_motion); free(out.segment); free(ws); free(models); free(reports);
    }
}

void suite_memory(void)
{
    RUN_TEST(test_memory_linalg_exact_workspace);
    RUN_TEST(test_memory_kdtree_exact_workspace);
    RUN_TEST(test_memory_sq_fit_exact_workspace);
    RUN_TEST(test_memory_fit_exact_workspace);
    RUN_TEST(test_memory_fit_ffd_exact_workspace);
    RUN_TEST(test_memory_distances_exact_workspace);
    RUN_TEST(test_memory_prepared_exact_workspace);
    RUN_TEST(test_memory_track_motion_exact_workspace);
    RUN_TEST(test_memory_iso_exact_workspace);
#if MEM_READ_ONLY
    RUN_TEST(test_memory_read_only_inputs);
#endif
    RUN_TEST(test_memory_fit_twice_bit_identical);
    RUN_TEST(test_memory_track_twice_bit_identical);
    RUN_TEST(test_memory_sq_fit_failure_writes_nothing);
    RUN_TEST(test_memory_kdtree_failure_outputs);
    RUN_TEST(test_memory_cholesky_nonfinite_writes_nothing);
    RUN_TEST(test_memory_ncg_cancel_last_point);
    RUN_TEST(test_memory_cg_limit_last_iterate);
    RUN_TEST(test_memory_track_short_workspace_no_frame);
    RUN_TEST(test_memory_output_arrays_exact);
}

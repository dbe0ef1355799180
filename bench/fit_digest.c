/* A digest of fits and tracks, to prove a change that must not change
   results changes none to the bit: one line per case with the result code,
   FNV-1a hashes of the saved model (sqffd_model_save), of the whole report
   and of every progress call, and the report's main figures in %a. Cases:
   the phantom (sqffd_phantom.h) under the default and non-default options
   (robust, model_to_data 0, alpha 0, the SVD solver, ...) by sqffd_fit,
   sqffd_fit_ffd and sqffd_fit_prepared; the development meshes of
   ../shared/data/dev (as bench_shapes.c reads them) and the bunny; tracks of
   the beating phantom by sqffd_track and sqffd_track_frame. Run from the
   project's root, before and after the change, and compare:
     gcc -O2 -march=native -std=c99 -D_POSIX_C_SOURCE=200809L -o build/fit_digest bench/fit_digest.c -lm
     ./build/fit_digest > before.txt        (then after.txt; cmp before.txt after.txt)
   Built -std=gnu11 instead, FMA contraction is allowed: worth a second
   comparison, since restructured code may contract differently. */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include "../examples/sqffd_phantom.h"
#include "../examples/sqffd_io.h"
#include "../examples/sqffd_synth.h"
#include <stdio.h>
#include <string.h>
#include <stdint.h>

static uint64_t fnv(uint64_t h, const void *p, size_t n)
{
    const unsigned char *b = (const unsigned char *)p;
    size_t i;
    for (i = 0; i < n; i++) { h ^= b[i]; h *= 1099511628211ull; }
    return h;
}
#define FNV0 14695981039346656037ull

typedef struct prog { uint64_t h; int calls, cancel_at; } prog;
static int progress(void *user, int stage, int it, double err)
{
    prog *p = (prog *)user;
    p->h = fnv(p->h, &stage, sizeof stage);
    p->h = fnv(p->h, &it, sizeof it);
    p->h = fnv(p->h, &err, sizeof err);
    p->calls++;
    return p->cancel_at && stage == SQFFD_STAGE_FFD && it == p->cancel_at;
}

static uint64_t model_hash(const sqffd_model *m)
{
    unsigned char buf[1 << 16];
    size_t n = 0;
    if (sqffd_model_save_size(m, &n) != SQFFD_OK || n > sizeof buf || sqffd_model_save(m, buf, sizeof buf) != SQFFD_OK) return 0;
    return fnv(FNV0, buf, n);
}

static void print_report(const char *name, sqffd_result r, const sqffd_model *m, const sqffd_fit_report *rep,
                         const prog *p)
{
    printf("%-40s r=%d model=%016llx rep=%016llx prog=%016llx/%d its=%d+%d conv=%d hist=%d err=%a sq=%a step=%a E=%a\n",
           name, (int)r, (unsigned long long)(r == SQFFD_OK ? model_hash(m) : fnv(FNV0, m->ffd.control, sizeof m->ffd.control)),
           (unsigned long long)fnv(FNV0, rep, sizeof *rep), (unsigned long long)p->h, p->calls, rep->coarse_iterations,
           rep->iterations, rep->converged, rep->history_count, rep->error.rms, rep->sq_error.rms, rep->step, rep->energy);
}

static void *ws_of(size_t size) { return malloc(size ? size : 1); }

/* whole fit, then fit_ffd and fit_prepared from its superquadric with the same options */
static void fit_case(const char *name, const double *pts, size_t n, sqffd_fit_options o, int cancel_at, int also_ffd)
{
    char label[128];
    sqffd_model m, start;
    sqffd_fit_report rep;
    prog p = {FNV0, 0, cancel_at};
    size_t size = 0;
    void *ws;
    sqffd_result r;
    o.progress = progress;
    o.progress_user = &p;
    memset(&m, 0, sizeof m);
    memset(&rep, 0, sizeof rep);
    if (sqffd_fit_workspace_size(n, &o, &size) != SQFFD_OK) { printf("%s size failed\n", name); return; }
    ws = ws_of(size);
    r = sqffd_fit(pts, n, &o, &m, &rep, ws, size);
    free(ws);
    snprintf(label, sizeof label, "fit %s", name);
    print_report(label, r, &m, &rep, &p);
    if (!also_ffd || r != SQFFD_OK) return;
    /* stage 2 alone from the fitted superquadric */
    if (sqffd_model_init(&start, &m.sq, &o) != SQFFD_OK) { printf("init failed\n"); return; }
    m = start;
    p.h = FNV0; p.calls = 0;
    memset(&rep, 0, sizeof rep);
    sqffd_fit_ffd_workspace_size(n, &m, &o, &size);
    ws = ws_of(size);
    r = sqffd_fit_ffd(pts, n, &o, &m, &rep, ws, size);
    free(ws);
    snprintf(label, sizeof label, "fit_ffd %s", name);
    print_report(label, r, &m, &rep, &p);
    {
        sqffd_ffd_system sys;
        void *mem;
        m = start;
        sqffd_ffd_system_size(&m, &size);
        mem = ws_of(size);
        if (sqffd_ffd_system_init(&sys, &m, &o, mem, size) != SQFFD_OK) { printf("system failed\n"); free(mem); return; }
        p.h = FNV0; p.calls = 0;
        memset(&rep, 0, sizeof rep);
        sqffd_fit_prepared_workspace_size(n, &sys, &o, &size);
        ws = ws_of(size);
        r = sqffd_fit_prepared(&sys, pts, n, &o, &m, &rep, ws, size);
        free(ws);
        snprintf(label, sizeof label, "fit_prepared %s", name);
        print_report(label, r, &m, &rep, &p);
        /* a second run from the result (a warm start, as tracking does) */
        p.h = FNV0; p.calls = 0;
        memset(&rep, 0, sizeof rep);
        ws = ws_of(size);
        r = sqffd_fit_prepared(&sys, pts, n, &o, &m, &rep, ws, size);
        free(ws);
        snprintf(label, sizeof label, "fit_prepared again %s", name);
        print_report(label, r, &m, &rep, &p);
        free(mem);
    }
}

static void track_case(const char *name, size_t frames, sqffd_track_options o)
{
    phantom_lv ph = phantom_lv_default();
    double **pts = (double **)calloc(frames, sizeof *pts);
    size_t *counts = (size_t *)calloc(frames, sizeof *counts), t, size = 0, done = 0;
    sqffd_model *models = (sqffd_model *)calloc(frames, sizeof *models);
    sqffd_fit_report *reps = (sqffd_fit_report *)calloc(frames, sizeof *reps);
    prog p = {FNV0, 0, 0};
    void *ws;
    sqffd_result r;
    char label[128];
    for (t = 0; t < frames; t++) {
        counts[t] = 6000;
        pts[t] = (double *)malloc(3 * 6000 * sizeof(double));
        phantom_lv_frame(&ph, (double)t / (double)frames, 6000, 0.01, 2026 + t, pts[t], NULL);
    }
    o.progress = progress;
    o.progress_user = &p;
    if (sqffd_track_workspace_size(counts, frames, &o, &size) != SQFFD_OK) { printf("track size failed\n"); return; }
    ws = ws_of(size);
    r = sqffd_track((const double *const *)pts, counts, frames, &o, models, reps, &done, ws, size);
    free(ws);
    for (t = 0; t < frames; t++) {
        snprintf(label, sizeof label, "track %s frame %zu", name, t);
        print_report(label, r, models + t, reps + t, &p);
    }
    /* the stream form: frame 0's model, then sqffd_track_frame per frame */
    if (r == SQFFD_OK) {
        sqffd_ffd_system sys;
        sqffd_model m = models[0];
        void *mem;
        sqffd_ffd_system_size(&m, &size);
        mem = ws_of(size);
        sqffd_ffd_system_init(&sys, &m, &o.fit, mem, size);
        sqffd_track_frame_workspace_size(6000, &o, &size);
        ws = ws_of(size);
        for (t = 1; t < frames; t++) {
            sqffd_fit_report rep;
            p.h = FNV0; p.calls = 0;
            memset(&rep, 0, sizeof rep);
            r = sqffd_track_frame(&sys, pts[t], 6000, &o, &m, &rep, ws, size);
            snprintf(label, sizeof label, "track_frame %s frame %zu", name, t);
            print_report(label, r, &m, &rep, &p);
        }
        free(ws);
        free(mem);
    }
    for (t = 0; t < frames; t++) free(pts[t]);
    free(pts); free(counts); free(models); free(reps);
}

int main(void)
{
    static const char *const shapes[] = {"elephant", "femur", "head", "hand", "cow", "bones"};
    phantom_lv ph = phantom_lv_default();
    sqffd_fit_options d = sqffd_fit_options_default(), o;
    double *pts = (double *)malloc(3 * 20000 * sizeof *pts);
    size_t i;
    phantom_lv_sample(&ph, 0.0, 6000, pts);
    fit_case("phantom default", pts, 6000, d, 0, 1);
    o = d; o.tolerance = 0.0; fit_case("phantom tolerance 0", pts, 6000, o, 0, 1);
    o = d; o.sq.robust = 1; fit_case("phantom robust", pts, 6000, o, 0, 1);
    o = d; o.model_to_data = 0.0; fit_case("phantom model_to_data 0", pts, 6000, o, 0, 1);
    o = d; o.alpha = 0.0; fit_case("phantom alpha 0", pts, 6000, o, 0, 1);
    o = d; o.solver = SQFFD_SOLVER_SVD; fit_case("phantom svd", pts, 6000, o, 0, 1);
    o = d; o.regularization = SQFFD_REG_DISPLACEMENT; o.tether = 0.1; fit_case("phantom displacement tether", pts, 6000, o, 0, 1);
    o = d; o.coarse_iterations = 0; fit_case("phantom no coarse", pts, 6000, o, 0, 1);
    o = d; o.ffd_max_points = 2500; fit_case("phantom ffd subsample", pts, 6000, o, 0, 1);
    o = d; o.max_iterations = 1; fit_case("phantom 1 iteration", pts, 6000, o, 0, 1);
    o = d; o.max_iterations = 2; o.coarse_iterations = 1; fit_case("phantom 2 iterations", pts, 6000, o, 0, 1);
    o = d; o.max_iterations = 0; fit_case("phantom 0 iterations", pts, 6000, o, 0, 1);
    o = d; o.tolerance = 1e-2; fit_case("phantom tolerance 1e-2", pts, 6000, o, 0, 1);
    o = d; o.coarse_iterations = 0; fit_case("phantom cancel at 3", pts, 6000, o, 3, 0);
    o = d; o.sq.robust = 1; o.model_to_data = 0.0; o.alpha = 0.0; fit_case("phantom robust m2d 0 alpha 0", pts, 6000, o, 0, 1);
    o = d; o.lattice[0] = o.lattice[1] = o.lattice[2] = 8; fit_case("phantom lattice 8", pts, 6000, o, 0, 1);
    phantom_lv_sample(&ph, 0.3, 20000, pts);
    fit_case("phantom 20000 default", pts, 20000, d, 0, 1);
    o = d; o.sq.robust = 1; fit_case("phantom 20000 robust", pts, 20000, o, 0, 0);
    free(pts);
    for (i = 0; i < sizeof shapes / sizeof shapes[0]; i++) {
        double *v, *rs;
        uint32_t *tri;
        size_t vc, tc;
        char path[256], err[256], name[64];
        synth_rng rng = synth_rng_seed(20261125u);
        snprintf(path, sizeof path, "../shared/data/dev/%s.off", shapes[i]);
        if (sqffd_io_read_off_mesh_file(path, &v, &vc, &tri, &tc, err, sizeof err)) { printf("%s: %s\n", path, err); continue; }
        snprintf(name, sizeof name, "%s", shapes[i]); fit_case(name, v, vc, d, 0, 1);
        o = d; o.sq.robust = 1; snprintf(name, sizeof name, "%s robust", shapes[i]); fit_case(name, v, vc, o, 0, 1);
        o = d; o.model_to_data = 0.0; snprintf(name, sizeof name, "%s m2d 0", shapes[i]); fit_case(name, v, vc, o, 0, 0);
        o = d; o.alpha = 0.0; snprintf(name, sizeof name, "%s alpha 0", shapes[i]); fit_case(name, v, vc, o, 0, 0);
        rs = (double *)malloc(3 * 6000 * sizeof *rs);
        synth_sample_triangles(&rng, v, tri, tc, 6000, rs);
        snprintf(name, sizeof name, "%s resampled", shapes[i]); fit_case(name, rs, 6000, d, 0, 0);
        free(rs); free(v); free(tri);
    }
    {
        double *b; size_t n; char err[256];
        if (sqffd_io_read_file("tests/data/bunny.ply", &b, &n, err, sizeof err) == 0) { fit_case("bunny", b, n, d, 0, 1); free(b); }
        else printf("bunny: %s\n", err);
    }
    {
        sqffd_track_options t = sqffd_track_options_default();
        track_case("default", 8, t);
        t.fit.model_to_data = 0.0; track_case("model_to_data 0", 6, t);
        t = sqffd_track_options_default(); t.fit.sq.robust = 1; track_case("robust", 6, t);
        t = sqffd_track_options_default(); t.fit.alpha = 0.0; t.frame_iterations = 12; track_case("alpha 0 12 its", 6, t);
    }
    return 0;
}

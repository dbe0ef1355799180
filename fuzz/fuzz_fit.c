/* libFuzzer target: bytes -> a small point set -> the superquadric fit and
   the whole model fit with small limits, so each input takes milliseconds
   (the kd-tree has its own target, fuzz_kdtree.c).

   Layout: byte 0 options (bit 0 robust, 1 no taper, 2 model -> data weight 1, 3 SVD
   solver, 4 paper's regularisation, 5 radial cost, 6 CG optimiser, 7 alpha 0),
   byte 1 encoding (bit 0: raw little-endian doubles, may be NaN or huge;
   else int16 triples scaled by 2^-(byte 1 >> 1 & 15); bit 5: the points
   rounded to float, and the model fit run a second time on a float view of
   them, 16-byte records at an odd address, which must give the same result
   code and model bytes), byte 2 lattice size 2..4, then the points (at most 64). */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define MAX_POINTS 64

static size_t decode_points(const uint8_t *data, size_t size, int raw, int shift, double *points)
{
    size_t n = 0, i;
    if (raw) {
        for (; n < MAX_POINTS && (n + 1) * 24 <= size; n++)
            for (i = 0; i < 3; i++) {
                uint64_t bits = 0;
                int b;
                for (b = 0; b < 8; b++) bits |= (uint64_t)data[24 * n + 8 * i + (size_t)b] << (8 * b);
                memcpy(&points[3 * n + i], &bits, 8);
            }
    } else {
        for (; n < MAX_POINTS && (n + 1) * 6 <= size; n++)
            for (i = 0; i < 3; i++) {
                int v = (int)((unsigned)data[6 * n + 2 * i] | (unsigned)data[6 * n + 2 * i + 1] << 8);
                if (v >= 32768) v -= 65536;
                points[3 * n + i] = ldexp((double)v, -shift);
            }
    }
    return n;
}

static void fuzz_sq_fit(const double *points, size_t n, uint8_t flags)
{
    sqffd_sq_fit_options o = sqffd_sq_fit_options_default();
    sqffd_superquadric sq;
    size_t size;
    void *work;
    o.robust = flags & 1;
    o.taper = !(flags & 2);
    o.cost = (flags & 32) ? SQFFD_SQ_COST_RADIAL : SQFFD_SQ_COST_SOLINA;
    o.optimizer = (flags & 64) ? SQFFD_SQ_OPTIMIZER_CG : SQFFD_SQ_OPTIMIZER_LM;
    o.max_iterations = 8;
    o.robust_rounds = 2;
    if (sqffd_sq_fit_workspace_size(n, &o, &size) != SQFFD_OK) return;
    work = malloc(size);
    if (!work) return;
    if (sqffd_sq_fit(points, n, &o, &sq, NULL, work, size) == SQFFD_OK) {
        int k;
        for (k = 0; k < 3; k++)
            if (!(sq.size[k] > 0.0) || !isfinite(sq.center[k])) abort();
    }
    free(work);
}

/* The same fit on a float view of the (float-valued) points. */
static void fuzz_view_fit(const double *points, size_t n, const sqffd_fit_options *o, sqffd_result expected,
                          const sqffd_model *model, void *work, size_t size)
{
    unsigned char *records = (unsigned char *)malloc(16 * n + 1);
    sqffd_model again;
    size_t i;
    if (!records) return;
    memset(records, 0xEE, 16 * n + 1);
    for (i = 0; i < n; i++) {
        float f[3] = {(float)points[3 * i], (float)points[3 * i + 1], (float)points[3 * i + 2]};
        memcpy(records + 1 + 16 * i, f, sizeof f);
    }
    if (sqffd_fit_view(sqffd_points_strided(records + 1, n, 16, SQFFD_SCALAR_FLOAT), o, &again, NULL, work, size) !=
        expected)
        abort();
    if (expected == SQFFD_OK) {
        unsigned char a[4096], b[4096];
        size_t bytes;
        if (sqffd_model_save_size(model, &bytes) != SQFFD_OK || sqffd_model_save(model, a, sizeof a) != SQFFD_OK ||
            sqffd_model_save(&again, b, sizeof b) != SQFFD_OK ||
            memcmp(a, b, bytes) != 0)
            abort();
    }
    free(records);
}

static void fuzz_model_fit(const double *points, size_t n, uint8_t flags, int lattice, int view)
{
    sqffd_fit_options o = sqffd_fit_options_default();
    sqffd_model model;
    sqffd_fit_report report;
    sqffd_result result;
    size_t size;
    void *work;
    o.sq.robust = flags & 1;
    o.sq.taper = !(flags & 2);
    o.sq.max_iterations = 8;
    o.sq.robust_rounds = 2;
    o.model_to_data = (flags & 4) ? 1.0 : 0.0;
    o.solver = (flags & 8) ? SQFFD_SOLVER_SVD : SQFFD_SOLVER_CHOLESKY;
    o.regularization = (flags & 16) ? SQFFD_REG_POSITION : SQFFD_REG_DISPLACEMENT;
    if (flags & 128) o.alpha = 0.0;
    o.lattice[0] = o.lattice[1] = o.lattice[2] = lattice;
    o.grid[0] = (flags & 32) ? 12 : 6; /* 12 x 16: a 6 x 8 coarse stage for the 2 x 2 x 2 lattice */
    o.grid[1] = (flags & 32) ? 16 : 8;
    o.max_iterations = 3;
    if (sqffd_fit_workspace_size(n, &o, &size) != SQFFD_OK) return;
    work = malloc(size);
    if (!work) return;
    result = sqffd_fit(points, n, &o, &model, &report, work, size);
    if (result == SQFFD_OK) {
        double p[3];
        unsigned char saved[4096];
        sqffd_model back;
        size_t saved_size;
        if (sqffd_model_validate(&model) != SQFFD_OK) abort(); /* a fit gives a valid model ... */
        if (sqffd_model_point(&model, 0.3, -1.0, p) != SQFFD_OK) abort();
        if (sqffd_model_save(&model, saved, sizeof saved) != SQFFD_OK) abort(); /* ... that saves and loads */
        if (sqffd_model_save_size(&model, &saved_size) != SQFFD_OK ||
            sqffd_model_load(&back, saved, saved_size) != SQFFD_OK)
            abort();
        if (!isfinite(report.error.rms) || report.iterations < 0 || report.coarse_iterations < 0 ||
            report.coarse_iterations + report.iterations > 3)
            abort();
    }
    if (view) fuzz_view_fit(points, n, &o, result, &model, work, size);
    free(work);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    double *points;
    size_t n;
    uint8_t flags, encoding;
    int lattice;
    if (size < 3) return 0;
    flags = data[0];
    encoding = data[1];
    lattice = 2 + data[2] % 3;
    points = (double *)malloc(3 * MAX_POINTS * sizeof(double));
    if (!points) return 0;
    n = decode_points(data + 3, size - 3, encoding & 1, (encoding >> 1) & 15, points);
    if (encoding & 32) {
        size_t i;
        for (i = 0; i < 3 * n; i++) points[i] = (double)(float)points[i]; /* (huge doubles become infinite) */
    }
    fuzz_sq_fit(points, n, flags);
    fuzz_model_fit(points, n, flags, lattice, encoding & 32);
    free(points);
    return 0;
}

/* libFuzzer target: stored models are data.
   Byte 0 picks the mode:
     even: the rest is a saved model for sqffd_model_load. A model it accepts
           must validate, mesh, give finite points and save back to exactly
           the bytes it came from (the byte form has one spelling per model).
     odd:  the rest, with its checksum made right, is loaded (so the
           structural checks behind the checksum get exercised), then the
           rest is also read as the raw bytes of an in-memory sqffd_model
           (a corrupted struct) and handed to every function taking a model,
           which must refuse it or work without a sanitizer report.
   A valid model's mesh is finite or NON_FINITE; its certified Jacobian
   bound (sqffd_model_jacobian_bound, on small grids) is OK and finite or
   NON_FINITE; a workspace one byte short is refused; an invalid model gets
   sqffd_model_validate's code. A valid model of up to 64 control points (4 x 4 x 4),
   refitted under the floor on a 4 x 8 grid to its own mesh's vertices (sqffd_fit_ffd, which
   first draws a start that folds toward the regular lattice), ends with its
   certified bound at or above the floor whenever the fit succeeds. */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define MESH_ETA 3
#define MESH_OMEGA 5
#define MESH_POINTS (MESH_ETA * MESH_OMEGA + 2)

static void use_model(const sqffd_model *m, int must_be_valid)
{
    double v[3 * MESH_POINTS], p[3], pts[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    uint32_t tri[3 * 2 * MESH_ETA * MESH_OMEGA];
    static unsigned char ws[1 << 16];
    sqffd_result valid = sqffd_model_validate(m), r, meshed;
    size_t bytes = 1;
    if (must_be_valid && valid != SQFFD_OK) abort();
    if (sqffd_model_save_size(m, &bytes) != valid || (valid != SQFFD_OK && bytes != 0)) abort();
    r = meshed = sqffd_model_mesh(m, MESH_ETA, MESH_OMEGA, v, tri);
    if (valid != SQFFD_OK ? r != valid : r != SQFFD_OK && r != SQFFD_ERROR_NON_FINITE) abort();
    if (r == SQFFD_OK) {
        size_t k;
        for (k = 0; k < sizeof v / sizeof v[0]; k++)
            if (!isfinite(v[k])) abort(); /* (a mesh called a success is finite) */
    }
    r = sqffd_model_point(m, 0.25, 1.0, p);
    if (r == SQFFD_OK && (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2]))) abort();
    if (valid != SQFFD_OK) {
        double min;
        if (sqffd_model_distances(m, pts, 4, NULL, NULL, ws, sizeof ws) != valid) abort();
        if (sqffd_model_jacobian_bound(m, 0.0, &min, ws, sizeof ws) != valid) abort();
        return;
    }
    if ((size_t)m->grid[0] * (size_t)m->grid[1] <= 64) { /* on small grids only: milliseconds per input */
        size_t need = 0;
        double min = 0.0;
        unsigned char *jw;
        (void)sqffd_model_distances(m, pts, 4, NULL, NULL, ws, sizeof ws);
        if (sqffd_model_jacobian_workspace_size(m->ffd.dims, &need) != SQFFD_OK || need == 0 || !(jw = (unsigned char *)malloc(need)))
            abort();
        if (sqffd_model_jacobian_bound(m, 0.0, &min, jw, need - 1) != SQFFD_ERROR_WORKSPACE_TOO_SMALL) abort();
        r = sqffd_model_jacobian_bound(m, 0.0, &min, jw, need);
        if (r == SQFFD_OK ? !isfinite(min) : r != SQFFD_ERROR_NON_FINITE) abort();
        free(jw);
    }
    if (meshed == SQFFD_OK && m->ffd.dims[0] * m->ffd.dims[1] * m->ffd.dims[2] <= 64) {
        sqffd_fit_options o = sqffd_fit_options_default();
        sqffd_model fitted = *m;
        sqffd_fit_report rep;
        size_t need = 0;
        unsigned char *fw;
        fitted.grid[0] = 4; /* (a small grid: milliseconds per input) */
        fitted.grid[1] = 8;
        o.max_iterations = 2;
        if (sqffd_fit_ffd_workspace_size(MESH_POINTS, &fitted, &o, &need) != SQFFD_OK || !(fw = (unsigned char *)malloc(need)))
            abort();
        if (sqffd_fit_ffd(v, MESH_POINTS, &o, &fitted, &rep, fw, need) == SQFFD_OK && !(rep.min_jacobian >= o.min_jacobian))
            abort();
        free(fw);
    }
}

static uint32_t crc32_ieee(const uint8_t *p, size_t n)
{
    uint32_t crc = 0xFFFFFFFFu;
    size_t i;
    for (i = 0; i < n; i++) {
        int b;
        crc ^= p[i];
        for (b = 0; b < 8; b++) crc = (crc & 1u) ? (crc >> 1) ^ 0xEDB88320u : crc >> 1;
    }
    return ~crc;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static uint8_t copy[1 << 16], again[1 << 16];
    sqffd_model m;
    size_t saved;
    if (size < 1 || size - 1 > sizeof copy) return 0;
    memcpy(copy, data + 1, size - 1);
    size--;
    if (data[0] & 1) {
        if (size >= 4) {
            uint32_t crc = crc32_ieee(copy, size - 4);
            int i;
            for (i = 0; i < 4; i++) copy[size - 4 + (size_t)i] = (uint8_t)(crc >> (8 * i));
        }
        if (sqffd_model_load(&m, copy, size) == SQFFD_OK) use_model(&m, 1);
        memset(&m, 0, sizeof m);
        memcpy(&m, data + 1, size < sizeof m ? size : sizeof m);
        use_model(&m, 0);
        return 0;
    }
    if (sqffd_model_load(&m, copy, size) != SQFFD_OK) return 0;
    use_model(&m, 1);
    if (sqffd_model_save_size(&m, &saved) != SQFFD_OK || saved != size ||
        sqffd_model_save(&m, again, sizeof again) != SQFFD_OK ||
        memcmp(again, copy, size) != 0)
        abort();
    return 0;
}

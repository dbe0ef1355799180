/* libFuzzer target: bytes -> a small volume view (layer 7) -> sqffd_volume_range,
   sqffd_volume_otsu, sqffd_iso_workspace_size / sqffd_iso_points and
   sqffd_points_subsample, each checked against brute force over the same
   view:
   - the view: dims 1..24 each, every voxel type, strides contiguous,
     permuted, flipped (negative), padded, or raw from the bytes (overlapping,
     unaligned), or invalid (a zero stride, an unknown type, NULL data); the
     buffer is exactly as large as the view reaches, so the sanitizer sees any
     read outside it; an affine (identity, spacings, a general matrix, raw
     doubles), scale and offset (none, small, raw, extreme), NaN and Inf
     voxels for the float types;
   - range: the min and max of the finite scaled values, or DEGENERATE;
   - Otsu: OK with a finite threshold in [min, max] whenever max > min;
   - iso points: count = the crossing edges (both ends finite, one inside),
     every written point the interpolated crossing in voxel order (within
     rounding), finite and inside the affine image of the index box, the
     normals unit (or zero for a zero affine column) pointing inside ->
     outside; with largest_component the crossings of one largest 6-connected
     inside component (ties: any of them); the capacity contract (all
     written into an array of exactly that size, OUTPUT_TOO_SMALL and nothing
     written below the count, capacity 0 with NULL points counts only); only
     the documented return codes;
   - subsample: out[i] = point floor(i n / k).

   Layout (bytes past the end read as 0):
     0-2  dims - 1 (mod 24)
     3    voxel type (mod 7); bits 3-4 layout: 0 contiguous, 1 permuted /
          flipped / padded, 2 raw strides (int8, 0 -> 1), 3 invalid view
     4    permutation (mod 6) and flips (bits 3-5)
     5    padding (2 bits per axis, in voxels)
     6    fill: bits 0-1 0 raw bytes, 1 ellipsoid, 2 ellipsoid + raw noise,
          3 two blobs; bits 2-3 float specials (NaN, Inf, both)
     7    affine: 0 identity, 1 spacings, 2 general int8 / 2^k, 3 raw doubles
     8    scale/offset: 0 none, 1 small, 2 raw doubles, 3 extreme powers of 2
     9    options: bits 0-2 level (Otsu, mid-range, raw, int16 / 4, a voxel's
          value, NaN, min, max); bit 3 largest component; bits 4-5 capacity
          (count + 3, count / 2, 0 with NULL points, count - 1); bit 6
          normals; bit 7 workspace one byte short first
     10   workspace misalignment (bits 0-3); subsample k
     then the parameters each mode reads (strides, affine, scale/offset),
     8 level bytes, then the voxel bytes (cycled over the buffer). */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include "fuzz_reader.h"
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define MAX_DIM 24


static size_t type_size(int type)
{
    static const size_t sizes[7] = {1, 1, 2, 2, 4, 4, 8};
    return type >= 0 && type < 7 ? sizes[type] : 0;
}

static const char *voxel_at(const sqffd_volume *v, size_t i, size_t j, size_t k)
{
    return (const char *)v->data + (ptrdiff_t)i * v->strides[0] + (ptrdiff_t)j * v->strides[1] +
           (ptrdiff_t)k * v->strides[2];
}

/* The scaled value, as documented: scale * stored + offset (scale 0 means 1). */
static double value_at(const sqffd_volume *v, size_t i, size_t j, size_t k)
{
    const char *p = voxel_at(v, i, j, k);
    double scale = v->scale != 0.0 ? v->scale : 1.0, x = 0.0;
    switch (v->type) {
    case SQFFD_VOXEL_U8: { uint8_t t; memcpy(&t, p, 1); x = (double)t; break; }
    case SQFFD_VOXEL_I8: { int8_t t; memcpy(&t, p, 1); x = (double)t; break; }
    case SQFFD_VOXEL_U16: { uint16_t t; memcpy(&t, p, 2); x = (double)t; break; }
    case SQFFD_VOXEL_I16: { int16_t t; memcpy(&t, p, 2); x = (double)t; break; }
    case SQFFD_VOXEL_I32: { int32_t t; memcpy(&t, p, 4); x = (double)t; break; }
    case SQFFD_VOXEL_F32: { float t; memcpy(&t, p, 4); x = (double)t; break; }
    case SQFFD_VOXEL_F64: { double t; memcpy(&t, p, 8); x = t; break; }
    default: abort();
    }
    return scale * x + v->offset;
}

/* Stores v (clamped, rounded) as one voxel of the type at p. */
static void store(int type, char *p, double v)
{
    switch (type) {
    case SQFFD_VOXEL_U8: { uint8_t t = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v); memcpy(p, &t, 1); break; }
    case SQFFD_VOXEL_I8: { int8_t t = (int8_t)(v < -128 ? -128 : v > 127 ? 127 : v); memcpy(p, &t, 1); break; }
    case SQFFD_VOXEL_U16: { uint16_t t = (uint16_t)(v < 0 ? 0 : v > 65535 ? 65535 : v); memcpy(p, &t, 2); break; }
    case SQFFD_VOXEL_I16: { int16_t t = (int16_t)(v < -32768 ? -32768 : v > 32767 ? 32767 : v); memcpy(p, &t, 2); break; }
    case SQFFD_VOXEL_I32: { int32_t t = (int32_t)(v < -2e9 ? -2e9 : v > 2e9 ? 2e9 : v); memcpy(p, &t, 4); break; }
    case SQFFD_VOXEL_F32: { float t = (float)(v < -1e38 ? -1e38 : v > 1e38 ? 1e38 : v); memcpy(p, &t, 4); break; }
    case SQFFD_VOXEL_F64: memcpy(p, &v, 8); break;
    default: break;
    }
}

/* ---- brute force --------------------------------------------------------- */

typedef struct brute {
    const sqffd_volume *v;
    size_t nx, ny, nz, voxels;
    double *value;        /* scaled values, i fastest */
    unsigned char *in;    /* value >= level */
    int32_t *component;   /* 6-connected inside components: id, or -1 */
    size_t *queue;
    size_t *size_of;      /* voxels per component */
    size_t components;
} brute;

static void brute_values(brute *b)
{
    size_t i, j, k;
    for (k = 0; k < b->nz; k++)
        for (j = 0; j < b->ny; j++)
            for (i = 0; i < b->nx; i++) b->value[i + b->nx * (j + b->ny * k)] = value_at(b->v, i, j, k);
}

static void brute_components(brute *b, double level)
{
    size_t x, head, tail;
    b->components = 0;
    for (x = 0; x < b->voxels; x++) {
        b->in[x] = b->value[x] >= level;
        b->component[x] = -1;
    }
    for (x = 0; x < b->voxels; x++) {
        if (!b->in[x] || b->component[x] >= 0) continue;
        head = tail = 0;
        b->queue[tail++] = x;
        b->component[x] = (int32_t)b->components;
        while (head < tail) {
            size_t y = b->queue[head++], i = y % b->nx, j = (y / b->nx) % b->ny, k = y / (b->nx * b->ny), nb[6];
            int c = 0, e;
            if (i > 0) nb[c++] = y - 1;
            if (i + 1 < b->nx) nb[c++] = y + 1;
            if (j > 0) nb[c++] = y - b->nx;
            if (j + 1 < b->ny) nb[c++] = y + b->nx;
            if (k > 0) nb[c++] = y - b->nx * b->ny;
            if (k + 1 < b->nz) nb[c++] = y + b->nx * b->ny;
            for (e = 0; e < c; e++)
                if (b->in[nb[e]] && b->component[nb[e]] < 0) {
                    b->component[nb[e]] = (int32_t)b->components;
                    b->queue[tail++] = nb[e];
                }
        }
        b->size_of[b->components++] = tail;
    }
}

/* The crossings, in the documented order (voxel order, then the edge's axis),
   of component `keep` (-1: all): written to points/normals when not NULL
   (up to capacity); returns how many there are. */
static size_t brute_crossings(const brute *b, double level, int32_t keep, double axis[3][3], double *points,
                              double *normals, size_t capacity)
{
    const double *a = b->v->affine;
    size_t i, j, k, found = 0;
    int d, r;
    for (k = 0; k < b->nz; k++)
        for (j = 0; j < b->ny; j++)
            for (i = 0; i < b->nx; i++) {
                size_t x = i + b->nx * (j + b->ny * k);
                double here = b->value[x];
                for (d = 0; d < 3; d++) {
                    size_t y;
                    double there, t, p[3];
                    int inside;
                    if (d == 0 ? i + 1 >= b->nx : d == 1 ? j + 1 >= b->ny : k + 1 >= b->nz) continue;
                    y = d == 0 ? x + 1 : d == 1 ? x + b->nx : x + b->nx * b->ny;
                    there = b->value[y];
                    inside = here >= level;
                    if (inside == (there >= level) || !isfinite(here) || !isfinite(there)) continue;
                    if (keep >= 0 && b->component[inside ? x : y] != keep) continue;
                    if (found < capacity && points) {
                        t = (double)(((long double)level - here) / ((long double)there - here)); /* (x86: no overflow) */
                        p[0] = (double)i + (d == 0 ? t : 0.0);
                        p[1] = (double)j + (d == 1 ? t : 0.0);
                        p[2] = (double)k + (d == 2 ? t : 0.0);
                        for (r = 0; r < 3; r++)
                            points[3 * found + (size_t)r] = a[4 * r] * p[0] + a[4 * r + 1] * p[1] + a[4 * r + 2] * p[2] + a[4 * r + 3];
                        if (normals)
                            for (r = 0; r < 3; r++) normals[3 * found + (size_t)r] = inside ? axis[d][r] : -axis[d][r];
                    }
                    found++;
                }
            }
    return found;
}

static int close_to(double x, double y, double tol) { return x == y || fabs(x - y) <= tol; }

/* Compares the library's first `written` points (and normals) with the
   expected ones; per-axis tolerance tol[r]. */
static int same_points(const double *got, const double *want, const double *got_n, const double *want_n,
                       size_t written, const double tol[3])
{
    size_t i;
    int r;
    for (i = 0; i < written; i++)
        for (r = 0; r < 3; r++) {
            if (!close_to(got[3 * i + (size_t)r], want[3 * i + (size_t)r], tol[r])) return 0;
            if (got_n && !close_to(got_n[3 * i + (size_t)r], want_n[3 * i + (size_t)r], 1e-12)) return 0;
        }
    return 1;
}

/* ---- the view from the bytes ---------------------------------------------- */

typedef struct built {
    sqffd_volume v;
    unsigned char *buffer;
    size_t span;
    int valid;            /* the view passes the layer's checks (else `expect` is its code) */
    int borderline;       /* a world reach within rounding of the 1e300 bound: either answer is right */
    sqffd_result expect;
    uint8_t level_bytes[8]; /* the level's parameters */
} built;

static const int permutations[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};

static void build_view(reader *r, built *out)
{
    sqffd_volume *v = &out->v;
    unsigned layout_byte, type_byte = 0, perm, pad, fill, affine_mode, scale_mode;
    ptrdiff_t stride[3], low = 0, high = 0;
    size_t es, i, j, k;
    int a, type, layout, invalid_type = 0;

    memset(out, 0, sizeof *out);
    for (a = 0; a < 3; a++) v->dims[a] = 1 + rd_u8(r) % MAX_DIM;
    type_byte = rd_u8(r);
    type = (int)((type_byte & 7) % 7);
    layout = (int)((type_byte >> 3) & 3);
    layout_byte = rd_u8(r);
    perm = layout_byte % 6;
    pad = rd_u8(r);
    fill = rd_u8(r);
    affine_mode = rd_u8(r) & 3;
    scale_mode = rd_u8(r) & 3;
    es = type_size(type);
    v->type = (sqffd_voxel_type)type;

    /* strides */
    if (layout == 0) {
        stride[0] = (ptrdiff_t)es;
        stride[1] = stride[0] * (ptrdiff_t)v->dims[0];
        stride[2] = stride[1] * (ptrdiff_t)v->dims[1];
    } else if (layout == 1) {
        const int *o = permutations[perm];
        ptrdiff_t s = (ptrdiff_t)es * (1 + (ptrdiff_t)(pad & 3));
        for (a = 0; a < 3; a++) {
            int ax = o[a];
            stride[ax] = s;
            s = s * (ptrdiff_t)v->dims[ax] + (ptrdiff_t)es * (ptrdiff_t)((pad >> (2 * a + 2)) & 3);
        }
        for (a = 0; a < 3; a++)
            if (layout_byte & (8u << a)) stride[a] = -stride[a];
    } else {
        for (a = 0; a < 3; a++) {
            stride[a] = (ptrdiff_t)rd_i8(r);
            if (layout == 2 && stride[a] == 0) stride[a] = 1;
        }
        if (layout == 3 && (pad & 1)) invalid_type = 1;
    }
    for (a = 0; a < 3; a++) {
        ptrdiff_t reach = stride[a] * (ptrdiff_t)(v->dims[a] - 1);
        if (reach < 0) low += reach; else high += reach;
        v->strides[a] = stride[a];
    }
    out->span = (size_t)(high - low) + es;
    out->buffer = (unsigned char *)malloc(out->span);
    if (!out->buffer) abort();
    v->data = out->buffer - low;
    if (invalid_type) v->type = (sqffd_voxel_type)(7 + (pad >> 1) % 9);

    /* affine: rows 0-2 read, last row 0 0 0 1 */
    memset(v->affine, 0, sizeof v->affine);
    v->affine[0] = v->affine[5] = v->affine[10] = v->affine[15] = 1.0;
    if (affine_mode == 1) {
        for (a = 0; a < 3; a++) {
            v->affine[5 * a] = ldexp((double)rd_i8(r), -4);
            v->affine[4 * a + 3] = (double)rd_i8(r);
        }
    } else if (affine_mode == 2) {
        int shift = (int)(rd_u8(r) % 12);
        for (a = 0; a < 12; a++) v->affine[a] = ldexp((double)rd_i8(r), -shift);
    } else if (affine_mode == 3) {
        for (a = 0; a < 12; a++) v->affine[a] = rd_f64(r);
    }

    /* scale and offset */
    if (scale_mode == 1) {
        v->scale = ldexp((double)rd_i8(r), -4);
        v->offset = (double)rd_i8(r);
    } else if (scale_mode == 2) {
        v->scale = rd_f64(r);
        v->offset = rd_f64(r);
    } else if (scale_mode == 3) {
        v->scale = ldexp(rd_u8(r) & 1 ? -1.0 : 1.0, rd_i8(r) * 8);
        v->offset = ldexp(rd_u8(r) & 1 ? -1.0 : 1.0, rd_i8(r) * 8);
    }

    for (a = 0; a < 8; a++) out->level_bytes[a] = (uint8_t)rd_u8(r);

    /* voxels: the remaining bytes, cycled, then the synthetic shapes */
    {
        size_t start = r->at < r->size ? r->at : r->size, avail = r->size - start;
        for (i = 0; i < out->span; i++) out->buffer[i] = avail ? r->data[start + i % avail] : 0;
    }
    if ((fill & 3) != 0 && type_size(type) && !invalid_type) {
        double c[2][3], rad[2][3], inside_value = (double)(int8_t)(fill & 0xF0) + 100.0;
        int blobs = (fill & 3) == 3 ? 2 : 1, bl;
        for (bl = 0; bl < 2; bl++)
            for (a = 0; a < 3; a++) {
                unsigned cb = r->at + (size_t)(6 * bl + a) < r->size ? r->data[r->at + (size_t)(6 * bl + a)] : 128;
                unsigned rb = r->at + (size_t)(6 * bl + 3 + a) < r->size ? r->data[r->at + (size_t)(6 * bl + 3 + a)] : 96;
                c[bl][a] = (double)cb / 255.0 * (double)(v->dims[a] - 1);
                rad[bl][a] = 0.5 + (double)rb / 255.0 * 0.6 * (double)v->dims[a];
            }
        for (k = 0; k < v->dims[2]; k++)
            for (j = 0; j < v->dims[1]; j++)
                for (i = 0; i < v->dims[0]; i++) {
                    double best = 1e9, val;
                    char *p = (char *)voxel_at(v, i, j, k);
                    for (bl = 0; bl < blobs; bl++) {
                        double dx = ((double)i - c[bl][0]) / rad[bl][0], dy = ((double)j - c[bl][1]) / rad[bl][1];
                        double dz = ((double)k - c[bl][2]) / rad[bl][2], q = dx * dx + dy * dy + dz * dz;
                        if (q < best) best = q;
                    }
                    val = inside_value * (1.5 - best); /* a smooth ramp through the surface */
                    if ((fill & 3) == 2) {
                        unsigned char noise;
                        memcpy(&noise, p, 1); /* the raw byte already there */
                        val += (double)(noise % 16) - 8.0;
                    }
                    store(type, p, val);
                }
    }
    if ((fill & 12) && (type == SQFFD_VOXEL_F32 || type == SQFFD_VOXEL_F64) && !invalid_type) {
        /* every m-th voxel NaN or Inf */
        size_t m = 2 + (fill >> 4), x = 0;
        for (k = 0; k < v->dims[2]; k++)
            for (j = 0; j < v->dims[1]; j++)
                for (i = 0; i < v->dims[0]; i++, x++) {
                    double sv;
                    if (x % m) continue;
                    sv = (fill & 12) == 4 ? NAN : (fill & 12) == 8 ? ((x / m) & 1 ? HUGE_VAL : -HUGE_VAL)
                                                                     : ((x / m) % 3 == 0 ? NAN : HUGE_VAL);
                    if (type == SQFFD_VOXEL_F32) {
                        float f = (float)sv;
                        memcpy((char *)voxel_at(v, i, j, k), &f, 4);
                    } else {
                        memcpy((char *)voxel_at(v, i, j, k), &sv, 8);
                    }
                }
    }

    /* what the layer's checks must say */
    out->valid = 1;
    out->expect = SQFFD_OK;
    if (invalid_type || stride[0] == 0 || stride[1] == 0 || stride[2] == 0) {
        out->valid = 0;
        out->expect = SQFFD_ERROR_INVALID_ARGUMENT;
    } else {
        for (a = 0; a < 12; a++)
            if (!isfinite(v->affine[a])) out->valid = 0;
        if (!isfinite(v->scale) || !isfinite(v->offset)) out->valid = 0;
        for (a = 0; a < 3 && out->valid; a++) { /* world coordinates past 1e300 (the header's bound) */
            long double reach = fabsl((long double)v->affine[4 * a + 3]);
            int c;
            for (c = 0; c < 3; c++) reach += fabsl((long double)v->affine[4 * a + c]) * (long double)(v->dims[c] - 1);
            if (fabsl(reach - 1e300L) <= 1e286L) out->borderline = 1;
            if (!(reach <= 1e300L)) out->valid = 0;
        }
        if (!out->valid) out->expect = SQFFD_ERROR_NON_FINITE;
    }
}

/* ---- the checks ------------------------------------------------------------ */

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    reader r;
    built b;
    brute bf;
    sqffd_volume *v;
    sqffd_iso_options opt = sqffd_iso_options_default();
    unsigned options_byte, misc_byte;
    double lo = 0.0, hi = 0.0, want_lo = HUGE_VAL, want_hi = -HUGE_VAL, thr = 0.0, level, axis[3][3], tol[3];
    double *points = NULL, *normals = NULL, *want = NULL, *want_n = NULL;
    unsigned char *block = NULL;
    uint8_t *joined;
    sqffd_result res, range_res;
    size_t x, ws_size, total, capacity, count = 12345, expect_count, written;
    int d, rr, cap_mode;

    if (size < 11) return 0;
    options_byte = data[9];
    misc_byte = data[10];
    /* the view reads bytes 0-8, then its parameters and voxels from byte 11 on */
    joined = (uint8_t *)malloc(size - 2);
    if (!joined) abort();
    memcpy(joined, data, 9);
    memcpy(joined + 9, data + 11, size - 11);
    r.data = joined;
    r.size = size - 2;
    r.at = 0;
    build_view(&r, &b);
    v = &b.v;
    if (b.borderline) { /* the library sums in double, the check above in long double */
        free(b.buffer);
        free(joined);
        return 0;
    }

    /* every function validates the view the same way */
    range_res = sqffd_volume_range(v, &lo, &hi);
    if (!b.valid) {
        if (range_res != b.expect || sqffd_volume_otsu(v, &thr) != b.expect) abort();
        ws_size = 1;
        if (sqffd_iso_workspace_size(v, &opt, &ws_size) != b.expect || ws_size != 0) abort();
        if (sqffd_iso_points(v, &opt, NULL, NULL, 0, &count, NULL, 0) != b.expect) abort();
        free(b.buffer);
        free(joined);
        return 0;
    }
    {
        sqffd_volume nul = *v;
        nul.data = NULL;
        if (sqffd_volume_range(&nul, &lo, &hi) != SQFFD_ERROR_INVALID_ARGUMENT) abort();
        ws_size = 1;
        if (sqffd_iso_workspace_size(&nul, &opt, &ws_size) != SQFFD_ERROR_INVALID_ARGUMENT || ws_size != 0) abort();
        if (sqffd_volume_range(NULL, &lo, &hi) != SQFFD_ERROR_INVALID_ARGUMENT) abort();
        if (sqffd_volume_range(v, NULL, &hi) != SQFFD_ERROR_INVALID_ARGUMENT) abort();
    }

    bf.v = v;
    bf.nx = v->dims[0];
    bf.ny = v->dims[1];
    bf.nz = v->dims[2];
    bf.voxels = bf.nx * bf.ny * bf.nz;
    bf.value = (double *)malloc(bf.voxels * sizeof(double));
    bf.in = (unsigned char *)malloc(bf.voxels);
    bf.component = (int32_t *)malloc(bf.voxels * sizeof(int32_t));
    bf.queue = (size_t *)malloc(bf.voxels * sizeof(size_t));
    bf.size_of = (size_t *)malloc(bf.voxels * sizeof(size_t));
    if (!bf.value || !bf.in || !bf.component || !bf.queue || !bf.size_of) abort();
    brute_values(&bf);

    /* range */
    for (x = 0; x < bf.voxels; x++)
        if (isfinite(bf.value[x])) {
            if (bf.value[x] < want_lo) want_lo = bf.value[x];
            if (bf.value[x] > want_hi) want_hi = bf.value[x];
        }
    if (want_lo > want_hi) {
        if (range_res != SQFFD_ERROR_DEGENERATE) abort();
    } else if (range_res != SQFFD_OK || lo != want_lo || hi != want_hi) {
        abort();
    }

    /* Otsu: a finite threshold within the range whenever the range has width */
    res = sqffd_volume_otsu(v, &thr);
    if (range_res != SQFFD_OK) {
        if (res != range_res) abort();
    } else if (hi > lo) {
        if (res != SQFFD_OK || !isfinite(thr) || thr < lo || thr > hi) abort();
    } else if (res != SQFFD_ERROR_DEGENERATE) {
        abort();
    }
    if (range_res == SQFFD_OK && sqffd_volume_otsu(v, NULL) != SQFFD_ERROR_INVALID_ARGUMENT) abort();

    /* the level */
    switch (options_byte & 7) {
    case 0: level = res == SQFFD_OK ? thr : 0.0; break;
    case 1: level = range_res == SQFFD_OK ? 0.5 * lo + 0.5 * hi : 0.0; break;
    case 2: memcpy(&level, b.level_bytes, 8); break; /* (host byte order) */
    case 3: level = (double)(int16_t)(b.level_bytes[0] | b.level_bytes[1] << 8) / 4.0; break;
    case 4: level = bf.value[(size_t)(b.level_bytes[0] | b.level_bytes[1] << 8) % bf.voxels]; break;
    case 5: level = NAN; break;
    case 6: level = range_res == SQFFD_OK ? lo : 0.0; break;
    default: level = range_res == SQFFD_OK ? hi : 0.0; break;
    }
    opt.level = level;
    opt.largest_component = (options_byte & 8) != 0;
    cap_mode = (int)((options_byte >> 4) & 3);

    if (sqffd_iso_workspace_size(v, &opt, &ws_size) != SQFFD_OK || ws_size == 0) abort();
    block = (unsigned char *)malloc(ws_size + 15);
    if (!block) abort();
    if (!isfinite(level)) {
        if (sqffd_iso_points(v, &opt, NULL, NULL, 0, &count, block, ws_size) != SQFFD_ERROR_INVALID_ARGUMENT) abort();
        goto done;
    }

    /* the expected crossings */
    for (d = 0; d < 3; d++) { /* (long double: x86's exponent range keeps the squares finite) */
        long double len = 0.0L;
        for (rr = 0; rr < 3; rr++) len += (long double)v->affine[4 * rr + d] * v->affine[4 * rr + d];
        len = sqrtl(len);
        for (rr = 0; rr < 3; rr++) axis[d][rr] = len > 0.0L ? (double)(v->affine[4 * rr + d] / len) : 0.0;
    }
    brute_components(&bf, level);
    total = brute_crossings(&bf, level, -1, axis, NULL, NULL, 0);

    /* argument checks */
    if (sqffd_iso_points(v, &opt, NULL, NULL, 0, NULL, block, ws_size) != SQFFD_ERROR_INVALID_ARGUMENT) abort();
    if (sqffd_iso_points(v, &opt, NULL, NULL, 1, &count, block, ws_size) != SQFFD_ERROR_INVALID_ARGUMENT) abort();
    if ((options_byte & 128) &&
        sqffd_iso_points(v, &opt, NULL, NULL, 0, &count, block + (misc_byte & 15), ws_size - 1) !=
            SQFFD_ERROR_WORKSPACE_TOO_SMALL)
        abort();

    /* counting only */
    count = 12345;
    if (sqffd_iso_points(v, &opt, NULL, NULL, 0, &count, block + (misc_byte & 15), ws_size) != SQFFD_OK) abort();
    if (opt.largest_component) {
        if (count > total) abort();
        if (bf.components == 0 && count != 0) abort();
    } else if (count != total) {
        abort();
    }
    expect_count = count;

    /* with points, into arrays of exactly `capacity` */
    capacity = cap_mode == 0 ? expect_count + 3 : cap_mode == 1 ? expect_count / 2 : cap_mode == 2 ? 0
             : expect_count ? expect_count - 1 : 1;
    if (capacity) {
        points = (double *)malloc(3 * capacity * sizeof(double));
        if (!points) abort();
        if (options_byte & 64) {
            normals = (double *)malloc(3 * capacity * sizeof(double));
            if (!normals) abort();
        }
    }
    for (x = 0; x < 3 * capacity; x++) { /* a capacity below the count: OUTPUT_TOO_SMALL, nothing written */
        points[x] = -7.0;
        if (normals) normals[x] = -7.0;
    }
    count = 12345;
    res = sqffd_iso_points(v, &opt, points, normals, capacity, &count, block + (misc_byte & 15), ws_size);
    if (count != expect_count || res != (capacity && capacity < count ? SQFFD_ERROR_OUTPUT_TOO_SMALL : SQFFD_OK)) abort();
    if (res != SQFFD_OK)
        for (x = 0; x < 3 * capacity; x++)
            if (points[x] != -7.0 || (normals && normals[x] != -7.0)) abort();
    written = res == SQFFD_OK && capacity ? count : 0;

    /* tolerance: rounding of the affine over the index box */
    for (rr = 0; rr < 3; rr++)
        tol[rr] = 1e-12 * (fabs(v->affine[4 * rr]) * (double)bf.nx + fabs(v->affine[4 * rr + 1]) * (double)bf.ny +
                           fabs(v->affine[4 * rr + 2]) * (double)bf.nz + fabs(v->affine[4 * rr + 3])) + 1e-300;

    /* every written point finite and inside the affine image of the index box */
    {
        double box[2][3];
        int corner;
        for (rr = 0; rr < 3; rr++) { box[0][rr] = HUGE_VAL; box[1][rr] = -HUGE_VAL; }
        for (corner = 0; corner < 8; corner++) {
            double p[3];
            p[0] = corner & 1 ? (double)(bf.nx - 1) : 0.0;
            p[1] = corner & 2 ? (double)(bf.ny - 1) : 0.0;
            p[2] = corner & 4 ? (double)(bf.nz - 1) : 0.0;
            for (rr = 0; rr < 3; rr++) {
                double w = v->affine[4 * rr] * p[0] + v->affine[4 * rr + 1] * p[1] + v->affine[4 * rr + 2] * p[2] +
                           v->affine[4 * rr + 3];
                if (w < box[0][rr]) box[0][rr] = w;
                if (w > box[1][rr]) box[1][rr] = w;
            }
        }
        /* (an affine so large that the box itself overflows is the caller's) */
        if (isfinite(box[0][0] + box[0][1] + box[0][2] + box[1][0] + box[1][1] + box[1][2]) &&
            isfinite(tol[0] + tol[1] + tol[2]) && fabs(box[0][0]) < 1e300 && fabs(box[1][0]) < 1e300 &&
            fabs(box[0][1]) < 1e300 && fabs(box[1][1]) < 1e300 && fabs(box[0][2]) < 1e300 && fabs(box[1][2]) < 1e300)
            for (x = 0; x < written; x++)
                for (rr = 0; rr < 3; rr++) {
                    double w = points[3 * x + (size_t)rr];
                    if (!isfinite(w) || w < box[0][rr] - tol[rr] || w > box[1][rr] + tol[rr]) abort();
                }
        /* unit normals (0 for a zero column), whatever the columns' scale */
        if (normals)
            for (x = 0; x < written; x++) {
                double len2 = 0.0;
                for (rr = 0; rr < 3; rr++) len2 += normals[3 * x + (size_t)rr] * normals[3 * x + (size_t)rr];
                if (!(len2 == 0.0 || fabs(len2 - 1.0) < 1e-12)) abort();
            }
    }

    /* the points themselves, against brute force */
    if (written) {
        want = (double *)malloc(3 * written * sizeof(double));
        want_n = (double *)malloc(3 * written * sizeof(double));
        if (!want || !want_n) abort();
    }
    if (!opt.largest_component) {
        brute_crossings(&bf, level, -1, axis, want, want_n, written);
        if (!same_points(points, want, normals, want_n, written, tol)) abort();
    } else if (count > 0) {
        /* one of the largest components, whichever the tie-break picks */
        size_t largest = 0, c;
        int matched = 0;
        for (c = 0; c < bf.components; c++)
            if (bf.size_of[c] > largest) largest = bf.size_of[c];
        for (c = 0; c < bf.components && !matched; c++) {
            if (bf.size_of[c] != largest) continue;
            if (brute_crossings(&bf, level, (int32_t)c, axis, want, want_n, written) != count) continue;
            matched = same_points(points, want, normals, want_n, written, tol);
        }
        if (!matched) abort();
    } else {
        /* no crossing at all: then no largest component has one */
        size_t largest = 0, c;
        for (c = 0; c < bf.components; c++)
            if (bf.size_of[c] > largest) largest = bf.size_of[c];
        for (c = 0; c < bf.components; c++)
            if (bf.size_of[c] == largest && brute_crossings(&bf, level, (int32_t)c, axis, NULL, NULL, 0) == 0) break;
        if (bf.components && c == bf.components) abort();
    }

    /* the default options are level 0, all components */
    if (level == 0.0 && !opt.largest_component) {
        size_t count0 = 0;
        if (sqffd_iso_points(v, NULL, NULL, NULL, 0, &count0, block, ws_size) != SQFFD_OK || count0 != total) abort();
    }

    /* subsample of the written points */
    if (written) {
        size_t k = 1 + (size_t)misc_byte % written, i;
        double *sub = (double *)malloc(3 * k * sizeof(double));
        if (!sub) abort();
        if (sqffd_points_subsample(points, written, k, sub) != SQFFD_OK) abort();
        for (i = 0; i < k; i++)
            if (memcmp(sub + 3 * i, points + 3 * (i * written / k), 3 * sizeof(double)) != 0) abort();
        free(sub);
    }

    /* a label map's surface: the voxels that equal one voxel's value; any count, finite points */
    {
        sqffd_iso_options lab = opt;
        size_t n_lab = 0, i;
        double *at;
        lab.labelled = 1;
        lab.label = bf.value[(size_t)misc_byte % bf.voxels];
        if (!isfinite(lab.label)) {
            if (sqffd_iso_points(v, &lab, NULL, NULL, 0, &n_lab, block, ws_size) != SQFFD_ERROR_INVALID_ARGUMENT) abort();
        } else {
            if (sqffd_iso_points(v, &lab, NULL, NULL, 0, &n_lab, block, ws_size) != SQFFD_OK) abort();
            at = (double *)malloc(3 * (n_lab ? n_lab : 1) * sizeof(double));
            if (!at || sqffd_iso_points(v, &lab, at, NULL, n_lab, &n_lab, block, ws_size) != SQFFD_OK) abort();
            for (i = 0; i < 3 * n_lab; i++)
                if (!isfinite(at[i])) abort();
            free(at);
        }
    }

done:
    free(points);
    free(normals);
    free(want);
    free(want_n);
    free(block);
    free(bf.value);
    free(bf.in);
    free(bf.component);
    free(bf.queue);
    free(bf.size_of);
    free(b.buffer);
    free(joined);
    return 0;
}

/* sqffd_export.h - viewer and report outputs for the sqffd tools (not part of the library).

   Header-only, every function `static inline`; plain C99 (and C++) plus the
   C library (stdio, stdlib). Uses sqffd.h for its types (the model reader
   calls sqffd_ffd_init: link the implementation once, SQFFD_IMPLEMENTATION)
   and sqffd_io.h for sqffd_io_scalar and sqffd_io_load_file.

   - Legacy VTK polydata (".vtk", "# vtk DataFile Version 3.0", read by
     ParaView and VisIt): a triangle mesh, or a point cloud as VERTICES, with
     per-vertex scalars; binary (big endian, as the legacy format defines) or
     ASCII, float or double.
   - The model as JSON: every number that rebuilds an sqffd_model, printed
     with %.17g so it reads back to the same bits, and the fit report's main
     figures; a strict reader of that file.
   - SVG 1.1 plots (self-contained, no scripts): a line plot with 1-2-5
     ticks on linear or log axes, legend and markers, and three uses of it:
     the error per iteration, the error against alpha, the volume curve.
   - The AHA 17-segment bull's-eye (Cerqueira et al., Circulation 2002) of
     per-segment values and flags: a motion report's, a wall's thickening.

   Every writer comes as a pair: sqffd_export_X_stream(FILE *f, const char
   *name, ...) writes to an open stream (name is for messages only) and
   sqffd_export_X(const char *path, ...) creates the file at path. Both
   return
     0  on success, or
     1  with a message "NAME: what is wrong" in err (NAME: the name or path).
   The arguments are checked before anything is written, so an invalid call
   creates no file. Write errors (a full disk) are caught (ferror, fflush,
   fclose) and reported with the file's name.
   Numbers are printed and read by printf and strtod: in the C locale's
   decimal point, the default unless the program calls setlocale. */
#ifndef SQFFD_EXPORT_H
#define SQFFD_EXPORT_H

#include "../sqffd.h"
#include "sqffd_io.h"

#include <ctype.h>
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- messages and files -------------------------------------------------- */


/* Opens `path` for writing; 0 on success. */
static inline int sqffd_export__create(const char *path, FILE **f, char *err, size_t err_size)
{
    *f = NULL;
    if (!path || !*path) return sqffd_io__fail(err, err_size, path, "no file name");
    errno = 0;
    *f = fopen(path, "wb");
    if (!*f) return sqffd_io__fail(err, err_size, path, "cannot create: %s", errno ? strerror(errno) : "unknown error");
    return 0;
}

/* Closes a file that a _stream writer wrote with result r: a failed close
   (its last buffer not written) is a write error. */
static inline int sqffd_export__close(FILE *f, const char *path, int r, char *err, size_t err_size)
{
    errno = 0;
    if (fclose(f) != 0 && r == 0)
        r = sqffd_io__fail(err, err_size, path, "write error: %s", errno ? strerror(errno) : "unknown error");
    return r;
}

/* The end of every _stream writer: flushes, so that a full disk shows here
   and not at some later fclose. */
static inline int sqffd_export__flush(FILE *f, const char *name, char *err, size_t err_size)
{
    errno = 0;
    if (fflush(f) != 0 || ferror(f))
        return sqffd_io__fail(err, err_size, name, "write error: %s", errno ? strerror(errno) : "unknown error");
    return 0;
}

/* A name for a file format's header: one or more printable ASCII
   characters, no blanks. */
static inline int sqffd_export__is_word(const char *s)
{
    if (!s || !*s) return 0;
    for (; *s; s++)
        if ((unsigned char)*s <= 32 || (unsigned char)*s >= 127) return 0;
    return 1;
}

/* ---- legacy VTK ---------------------------------------------------------- */

#define SQFFD_EXPORT_VTK_ASCII 1  /* ASCII instead of binary */
#define SQFFD_EXPORT_VTK_DOUBLE 2 /* points and scalars as double instead of float */

static inline void sqffd_export__put_be32(unsigned char *out, uint32_t v)
{
    out[0] = (unsigned char)((v >> 24) & 0xffu);
    out[1] = (unsigned char)((v >> 16) & 0xffu);
    out[2] = (unsigned char)((v >> 8) & 0xffu);
    out[3] = (unsigned char)(v & 0xffu);
}

/* One value in the file's real type, big endian; returns its size. */
static inline size_t sqffd_export__put_real(unsigned char *out, double value, int as_double)
{
    if (as_double) {
        uint64_t bits;
        memcpy(&bits, &value, sizeof bits);
        sqffd_export__put_be32(out, (uint32_t)(bits >> 32));
        sqffd_export__put_be32(out + 4, (uint32_t)(bits & 0xffffffffu));
        return 8;
    } else {
        float single = (float)value;
        uint32_t bits;
        memcpy(&bits, &single, sizeof bits);
        sqffd_export__put_be32(out, bits);
        return 4;
    }
}

/* Checks a real for the file's type: finite, and within float's range when
   written as float. */
static inline int sqffd_export__vtk_real(double v, int as_double, const char *name, const char *what,
                                         unsigned long long index, char *err, size_t err_size)
{
    if (fabs(v) <= (as_double ? DBL_MAX : FLT_MAX)) return 0;
    if (!isfinite(v)) return sqffd_io__fail(err, err_size, name, "%s %llu is not finite", what, index);
    return sqffd_io__fail(err, err_size, name, "%s %llu (%g) is beyond the float range: write doubles", what,
                              index, v);
}

static inline int sqffd_export__vtk_check(const char *name, const char *title, const double *vertices,
                                          size_t vertex_count, const uint32_t *triangles, size_t triangle_count,
                                          const sqffd_io_scalar *scalars, int scalar_count, int flags, char *err,
                                          size_t err_size)
{
    int as_double = (flags & SQFFD_EXPORT_VTK_DOUBLE) != 0, k, j;
    size_t i;
    char what[96];
    if (flags & ~(SQFFD_EXPORT_VTK_ASCII | SQFFD_EXPORT_VTK_DOUBLE))
        return sqffd_io__fail(err, err_size, name, "unknown flags 0x%x", (unsigned)flags);
    if (title && (strlen(title) > 255 || strpbrk(title, "\r\n")))
        return sqffd_io__fail(err, err_size, name, "the title must be one line of at most 255 characters");
    if (!vertices || vertex_count == 0) return sqffd_io__fail(err, err_size, name, "no vertices to write");
    if (vertex_count > 0x7fffffffu)
        return sqffd_io__fail(err, err_size, name, "%llu vertices, more than the format's int indices reach",
                                  (unsigned long long)vertex_count);
    if (triangle_count && !triangles)
        return sqffd_io__fail(err, err_size, name, "%llu triangles but no index array",
                                  (unsigned long long)triangle_count);
    if (triangle_count > 0x7fffffffu / 4)
        return sqffd_io__fail(err, err_size, name, "%llu triangles, more than the format's int sizes reach",
                                  (unsigned long long)triangle_count);
    if (scalar_count < 0 || (scalar_count > 0 && !scalars))
        return sqffd_io__fail(err, err_size, name, "scalar count %d without scalars", scalar_count);
    for (k = 0; k < scalar_count; k++) {
        if (!sqffd_export__is_word(scalars[k].name))
            return sqffd_io__fail(err, err_size, name,
                                      "scalar %d: the name '%s' is not one word of printable ASCII (no blanks)", k,
                                      scalars[k].name ? scalars[k].name : "");
        if (!scalars[k].values) return sqffd_io__fail(err, err_size, name, "scalar '%s' has no values", scalars[k].name);
        for (j = 0; j < k; j++)
            if (strcmp(scalars[j].name, scalars[k].name) == 0)
                return sqffd_io__fail(err, err_size, name, "two scalars are named '%s'", scalars[k].name);
    }
    for (i = 0; i < 3 * vertex_count; i++)
        if (sqffd_export__vtk_real(vertices[i], as_double, name, "coordinate of vertex", (unsigned long long)(i / 3),
                                   err, err_size))
            return 1;
    for (i = 0; i < 3 * triangle_count; i++)
        if (triangles[i] >= vertex_count)
            return sqffd_io__fail(err, err_size, name, "triangle %llu uses vertex %lu of %llu",
                                      (unsigned long long)(i / 3), (unsigned long)triangles[i],
                                      (unsigned long long)vertex_count);
    for (k = 0; k < scalar_count; k++) {
        snprintf(what, sizeof what, "scalar '%s' at vertex", scalars[k].name);
        for (i = 0; i < vertex_count; i++)
            if (sqffd_export__vtk_real(scalars[k].values[i], as_double, name, what, (unsigned long long)i, err,
                                       err_size))
                return 1;
    }
    return 0;
}

/* Writes a legacy VTK polydata file: vertex_count points (x y z each), then
   triangle_count triangles as POLYGONS, or with no triangles every point as
   a VERTICES cell (a point cloud ParaView shows as such), then each scalar
   as POINT_DATA "SCALARS name float 1" with the default lookup table.
   flags: 0 = binary float; SQFFD_EXPORT_VTK_ASCII, SQFFD_EXPORT_VTK_DOUBLE
   (points and scalars as double). title: the header's second line (NULL:
   "sqffd"; one line, at most 255 characters). Scalar names: one word of
   printable ASCII, distinct. Refused: no vertices, a triangle index out of
   range, NaN or infinite values, values beyond float when writing floats. */
static inline int sqffd_export_vtk_stream(FILE *f, const char *name, const char *title, const double *vertices,
                                          size_t vertex_count, const uint32_t *triangles, size_t triangle_count,
                                          const sqffd_io_scalar *scalars, int scalar_count, int flags, char *err,
                                          size_t err_size)
{
    int ascii = (flags & SQFFD_EXPORT_VTK_ASCII) != 0, as_double = (flags & SQFFD_EXPORT_VTK_DOUBLE) != 0, k;
    const char *type = as_double ? "double" : "float";
    unsigned char record[24];
    size_t i, used;
    if (sqffd_export__vtk_check(name, title, vertices, vertex_count, triangles, triangle_count, scalars, scalar_count,
                                flags, err, err_size))
        return 1;
    fprintf(f, "# vtk DataFile Version 3.0\n%s\n%s\nDATASET POLYDATA\nPOINTS %llu %s\n", title ? title : "sqffd",
            ascii ? "ASCII" : "BINARY", (unsigned long long)vertex_count, type);
    for (i = 0; i < vertex_count; i++) {
        const double *p = vertices + 3 * i;
        if (ascii && as_double) fprintf(f, "%.17g %.17g %.17g\n", p[0], p[1], p[2]);
        /* %.9g: a float's decimal form that reads back to the same float */
        else if (ascii) fprintf(f, "%.9g %.9g %.9g\n", (double)(float)p[0], (double)(float)p[1], (double)(float)p[2]);
        else {
            used = 0;
            for (k = 0; k < 3; k++) used += sqffd_export__put_real(record + used, p[k], as_double);
            fwrite(record, 1, used, f);
        }
    }
    if (!ascii) fputc('\n', f); /* binary blocks end with a line break before the next keyword */
    if (triangle_count) {
        fprintf(f, "POLYGONS %llu %llu\n", (unsigned long long)triangle_count, 4 * (unsigned long long)triangle_count);
        for (i = 0; i < triangle_count; i++) {
            const uint32_t *t = triangles + 3 * i;
            if (ascii) fprintf(f, "3 %lu %lu %lu\n", (unsigned long)t[0], (unsigned long)t[1], (unsigned long)t[2]);
            else {
                sqffd_export__put_be32(record, 3);
                for (k = 0; k < 3; k++) sqffd_export__put_be32(record + 4 + 4 * k, t[k]);
                fwrite(record, 1, 16, f);
            }
        }
    } else {
        fprintf(f, "VERTICES %llu %llu\n", (unsigned long long)vertex_count, 2 * (unsigned long long)vertex_count);
        for (i = 0; i < vertex_count; i++) {
            if (ascii) fprintf(f, "1 %llu\n", (unsigned long long)i);
            else {
                sqffd_export__put_be32(record, 1);
                sqffd_export__put_be32(record + 4, (uint32_t)i);
                fwrite(record, 1, 8, f);
            }
        }
    }
    if (!ascii) fputc('\n', f);
    if (scalar_count > 0) fprintf(f, "POINT_DATA %llu\n", (unsigned long long)vertex_count);
    for (k = 0; k < scalar_count; k++) {
        const double *v = scalars[k].values;
        fprintf(f, "SCALARS %s %s 1\nLOOKUP_TABLE default\n", scalars[k].name, type);
        for (i = 0; i < vertex_count; i++) {
            if (ascii && as_double) fprintf(f, "%.17g\n", v[i]);
            else if (ascii) fprintf(f, "%.9g\n", (double)(float)v[i]);
            else fwrite(record, 1, sqffd_export__put_real(record, v[i], as_double), f);
        }
        if (!ascii) fputc('\n', f);
    }
    return sqffd_export__flush(f, name, err, err_size);
}

/* sqffd_export_vtk_stream into a new file at `path`. */
static inline int sqffd_export_vtk(const char *path, const char *title, const double *vertices, size_t vertex_count,
                                   const uint32_t *triangles, size_t triangle_count, const sqffd_io_scalar *scalars,
                                   int scalar_count, int flags, char *err, size_t err_size)
{
    FILE *f;
    int r;
    if (sqffd_export__vtk_check(path, title, vertices, vertex_count, triangles, triangle_count, scalars, scalar_count,
                                flags, err, err_size) ||
        sqffd_export__create(path, &f, err, err_size))
        return 1;
    r = sqffd_export_vtk_stream(f, path, title, vertices, vertex_count, triangles, triangle_count, scalars,
                                scalar_count, flags, err, err_size);
    return sqffd_export__close(f, path, r, err, err_size);
}

/* ---- the model as JSON: writer ------------------------------------------- */

/* Grid sizes the library meshes (sqffd_model_mesh_size). */
#define SQFFD_EXPORT_GRID_MAX 65536

/* A labelled run of doubles, for the checks and the writer. */
typedef struct sqffd_export__numbers {
    const char *label;
    const double *values;
    size_t count;
} sqffd_export__numbers;

/* A distance summary as an array, in the order the JSON writes it. */
static inline void sqffd_export__stats_array(const sqffd_distance_stats *s, double out[7])
{
    out[0] = s->rms;
    out[1] = s->mean;
    out[2] = s->max;
    out[3] = s->rms_relative;
    out[4] = s->mean_relative;
    out[5] = s->max_relative;
    out[6] = s->diagonal;
}

static inline int sqffd_export__model_check(const char *name, const sqffd_model *model, const sqffd_fit_report *report,
                                            char *err, size_t err_size)
{
    int a, history;
    size_t i, s;
    double error[7] = {0, 0, 0, 0, 0, 0, 0}, sq_error[7] = {0, 0, 0, 0, 0, 0, 0};
    if (!model) return sqffd_io__fail(err, err_size, name, "no model");
    for (a = 0; a < 3; a++)
        if (model->ffd.dims[a] < 2 || model->ffd.dims[a] > SQFFD_MAX_LATTICE)
            return sqffd_io__fail(err, err_size, name, "ffd.dims[%d] = %d is outside 2..%d", a, model->ffd.dims[a],
                                      SQFFD_MAX_LATTICE);
    if (model->grid[0] < 2 || model->grid[0] > SQFFD_EXPORT_GRID_MAX || model->grid[1] < 3 ||
        model->grid[1] > SQFFD_EXPORT_GRID_MAX)
        return sqffd_io__fail(err, err_size, name, "grid %d x %d is outside 2..%d x 3..%d", model->grid[0],
                                  model->grid[1], SQFFD_EXPORT_GRID_MAX, SQFFD_EXPORT_GRID_MAX);
    history = report ? report->history_count : 0;
    if (history < 0 || history > SQFFD_FIT_HISTORY)
        return sqffd_io__fail(err, err_size, name, "report history_count %d is outside 0..%d", history,
                                  SQFFD_FIT_HISTORY);
    {
        const sqffd_superquadric *sq = &model->sq;
        sqffd_export__numbers all[] = {
            {"superquadric.size", sq->size, 3},
            {"superquadric.shape", sq->shape, 2},
            {"superquadric.taper", sq->taper, 2},
            {"superquadric.rotation", sq->rotation, 9},
            {"superquadric.center", sq->center, 3},
            {"ffd.origin", model->ffd.origin, 3},
            {"ffd.edges", model->ffd.edges, 9},
            {"ffd.control", model->ffd.control[0],
             3 * (size_t)model->ffd.dims[0] * (size_t)model->ffd.dims[1] * (size_t)model->ffd.dims[2]},
            {"fit.error", error, 7},
            {"fit.superquadric_error", sq_error, 7},
            {"fit.history", report ? report->history : error, (size_t)history},
        };
        if (report) {
            sqffd_export__stats_array(&report->error, error);
            sqffd_export__stats_array(&report->sq_error, sq_error);
        }
        for (s = 0; s < sizeof all / sizeof all[0]; s++)
            for (i = 0; i < all[s].count; i++)
                if (!isfinite(all[s].values[i]))
                    return sqffd_io__fail(err, err_size, name, "%s: value %llu is %g, which JSON cannot hold",
                                              all[s].label, (unsigned long long)i, all[s].values[i]);
    }
    return 0;
}

/* The length of the well-formed UTF-8 sequence at s (1..4), or 0. */
static inline int sqffd_export__utf8_length(const unsigned char *s)
{
    int n = s[0] < 0x80 ? 1 : s[0] >= 0xC2 && s[0] <= 0xDF ? 2 : s[0] >= 0xE0 && s[0] <= 0xEF ? 3
          : s[0] >= 0xF0 && s[0] <= 0xF4 ? 4 : 0, k;
    unsigned char lo = s[0] == 0xE0 ? 0xA0 : s[0] == 0xF0 ? 0x90 : 0x80; /* no overlong forms, */
    unsigned char hi = s[0] == 0xED ? 0x9F : s[0] == 0xF4 ? 0x8F : 0xBF; /* surrogates or beyond U+10FFFF */
    if (n > 1 && (s[1] < lo || s[1] > hi)) return 0;
    for (k = 2; k < n; k++)
        if (s[k] < 0x80 || s[k] > 0xBF) return 0;
    return n;
}

/* A JSON string: quoted, '"', '\\' and the control characters escaped;
   well-formed UTF-8 as it is, any other byte as U+FFFD (a file name is
   bytes, a JSON text is Unicode). */
static inline void sqffd_export_json_string(FILE *f, const char *text)
{
    const unsigned char *s = (const unsigned char *)text;
    int n;
    fputc('"', f);
    for (; *s; s += n ? n : 1) {
        n = sqffd_export__utf8_length(s);
        if (*s == '"' || *s == '\\') fprintf(f, "\\%c", *s);
        else if (*s == '\n') fputs("\\n", f);
        else if (*s == '\t') fputs("\\t", f);
        else if (*s < 0x20 || *s == 0x7f) fprintf(f, "\\u%04x", *s);
        else if (n == 0) fputs("\\ufffd", f);
        else fwrite(s, 1, (size_t)n, f);
    }
    fputc('"', f);
}

/* A JSON number, %.17g (it reads back to the same bits), or null for NaN
   and the infinities, which JSON has no word for. */
static inline void sqffd_export_json_number(FILE *f, double v)
{
    if (isfinite(v)) fprintf(f, "%.17g", v);
    else fputs("null", f);
}

static inline void sqffd_export__json_numbers(FILE *f, const double *v, size_t count)
{
    size_t i;
    fputc('[', f);
    for (i = 0; i < count; i++) fprintf(f, "%s%.17g", i ? ", " : "", v[i]);
    fputc(']', f);
}

static inline void sqffd_export__json_stats(FILE *f, const char *key, const sqffd_distance_stats *s)
{
    fprintf(f,
            "    \"%s\": {\"rms\": %.17g, \"mean\": %.17g, \"max\": %.17g, \"rms_relative\": %.17g, "
            "\"mean_relative\": %.17g, \"max_relative\": %.17g, \"diagonal\": %.17g},\n",
            key, s->rms, s->mean, s->max, s->rms_relative, s->mean_relative, s->max_relative, s->diagonal);
}

/* Writes the model as JSON: "format": "sqffd-model", "version": 1,
   "library_version", then "superquadric" {size, shape, taper, rotation
   (row-major 9), center}, "ffd" {dims, origin, edges (row-major 9: S, T,
   U), control: the l m n used control points [x, y, z] in the library's
   order, (i m + j) n + k}, "grid" [n_eta, n_omega]; with a report (may be
   NULL) also "fit" {error and superquadric_error {rms, mean, max,
   rms_relative, mean_relative, max_relative, diagonal}, iterations,
   converged, history (relative RMS error after iteration 1, 2, ...)}.
   Numbers as %.17g (they read back to the same bits); NaN and infinities
   are refused (JSON has none), and so are dims outside 2..SQFFD_MAX_LATTICE
   and a grid outside 2..65536 x 3..65536. */
static inline int sqffd_export_model_json_stream(FILE *f, const char *name, const sqffd_model *model,
                                                 const sqffd_fit_report *report, char *err, size_t err_size)
{
    const sqffd_superquadric *sq;
    const sqffd_ffd *ffd;
    size_t i, points;
    if (sqffd_export__model_check(name, model, report, err, err_size)) return 1;
    sq = &model->sq;
    ffd = &model->ffd;
    points = (size_t)ffd->dims[0] * (size_t)ffd->dims[1] * (size_t)ffd->dims[2];
    fprintf(f, "{\n  \"format\": \"sqffd-model\",\n  \"version\": 1,\n  \"library_version\": \"%s\",\n",
            SQFFD_VERSION_STRING);
    fputs("  \"superquadric\": {\n    \"size\": ", f);
    sqffd_export__json_numbers(f, sq->size, 3);
    fputs(",\n    \"shape\": ", f);
    sqffd_export__json_numbers(f, sq->shape, 2);
    fputs(",\n    \"taper\": ", f);
    sqffd_export__json_numbers(f, sq->taper, 2);
    fputs(",\n    \"rotation\": ", f);
    sqffd_export__json_numbers(f, sq->rotation, 9);
    fputs(",\n    \"center\": ", f);
    sqffd_export__json_numbers(f, sq->center, 3);
    fprintf(f, "\n  },\n  \"ffd\": {\n    \"dims\": [%d, %d, %d],\n    \"origin\": ", ffd->dims[0], ffd->dims[1],
            ffd->dims[2]);
    sqffd_export__json_numbers(f, ffd->origin, 3);
    fputs(",\n    \"edges\": ", f);
    sqffd_export__json_numbers(f, ffd->edges, 9);
    fputs(",\n    \"control\": [\n", f);
    for (i = 0; i < points; i++) {
        fputs("      ", f);
        sqffd_export__json_numbers(f, ffd->control[i], 3);
        fputs(i + 1 < points ? ",\n" : "\n", f);
    }
    fprintf(f, "    ]\n  },\n  \"grid\": [%d, %d]", model->grid[0], model->grid[1]);
    if (report) {
        fputs(",\n  \"fit\": {\n", f);
        sqffd_export__json_stats(f, "error", &report->error);
        sqffd_export__json_stats(f, "superquadric_error", &report->sq_error);
        fprintf(f, "    \"iterations\": %d,\n    \"converged\": %s,\n    \"history\": ", report->iterations,
                report->converged ? "true" : "false");
        sqffd_export__json_numbers(f, report->history, (size_t)report->history_count);
        fputs("\n  }", f);
    }
    fputs("\n}\n", f);
    return sqffd_export__flush(f, name, err, err_size);
}

/* sqffd_export_model_json_stream into a new file at `path`. */
static inline int sqffd_export_model_json(const char *path, const sqffd_model *model, const sqffd_fit_report *report,
                                          char *err, size_t err_size)
{
    FILE *f;
    int r;
    if (sqffd_export__model_check(path, model, report, err, err_size) || sqffd_export__create(path, &f, err, err_size))
        return 1;
    r = sqffd_export_model_json_stream(f, path, model, report, err, err_size);
    return sqffd_export__close(f, path, r, err, err_size);
}

/* ---- the model as JSON: a strict parser ---------------------------------- */

/* Objects and arrays nest at most this deep (the parser recurses). */
#define SQFFD_EXPORT_JSON_MAX_DEPTH 32
/* Values a model file may hold at most: a model has about 600, and the
   parse tree takes 72 bytes a value, so an absurd file cannot take
   gigabytes. */
#define SQFFD_EXPORT_JSON_MAX_VALUES ((size_t)1 << 20)

enum {
    SQFFD_EXPORT__JSON_NULL,
    SQFFD_EXPORT__JSON_FALSE,
    SQFFD_EXPORT__JSON_TRUE,
    SQFFD_EXPORT__JSON_NUMBER,
    SQFFD_EXPORT__JSON_STRING,
    SQFFD_EXPORT__JSON_ARRAY,
    SQFFD_EXPORT__JSON_OBJECT
};

/* One value of the parsed tree. Nodes refer to each other by index + 1
   (0: none), as the node array moves when it grows. */
typedef struct sqffd_export__json_node {
    int type;
    size_t start, end;         /* its text; a string's between its quotes */
    size_t key_start, key_end; /* an object member's name, between its quotes */
    size_t first_child, next;  /* first element or member; next sibling */
    size_t count;              /* elements or members */
    double number;
} sqffd_export__json_node;

typedef struct sqffd_export__json {
    const char *text;
    size_t size, at;
    sqffd_export__json_node *nodes;
    size_t count, capacity;
    const char *name;
    char *err;
    size_t err_size;
} sqffd_export__json;

/* Blanks and JSON's punctuation: where a token quoted in a message ends. */
static inline int sqffd_export__json_delimiter(char c)
{
    return c != '\0' && strchr(" \t\r\n,:[]{}\"", c) != NULL;
}

/* The token at `at` quoted for messages: up to the next blank or
   punctuation (at least one character, at most 16). */
static inline const char *sqffd_export__json_found(const sqffd_export__json *j, size_t at, char out[32])
{
    size_t i, n = 1;
    if (at >= j->size) return "the end of the text";
    if (!sqffd_export__json_delimiter(j->text[at]))
        while (n < 16 && at + n < j->size && !sqffd_export__json_delimiter(j->text[at + n])) n++;
    out[0] = '\'';
    for (i = 0; i < n; i++) {
        unsigned char c = (unsigned char)j->text[at + i];
        out[i + 1] = (char)(c >= 32 && c < 127 ? c : '?');
    }
    out[n + 1] = '\'';
    out[n + 2] = '\0';
    return out;
}

#if defined(__GNUC__)
static inline int sqffd_export__json_error(const sqffd_export__json *j, size_t at, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
#endif
/* A syntax error at offset `at`: "NAME: line L, column C: message". */
static inline int sqffd_export__json_error(const sqffd_export__json *j, size_t at, const char *fmt, ...)
{
    char message[160];
    unsigned long long line = 1, column = 1;
    size_t i;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(message, sizeof message, fmt, ap);
    va_end(ap);
    for (i = 0; i < at && i < j->size; i++) {
        if (j->text[i] == '\n') { line++; column = 1; }
        else column++;
    }
    return sqffd_io__fail(j->err, j->err_size, j->name, "line %llu, column %llu: %s", line, column, message);
}

static inline void sqffd_export__json_space(sqffd_export__json *j)
{
    while (j->at < j->size) {
        char c = j->text[j->at];
        if (c != ' ' && c != '\t' && c != '\n' && c != '\r') break;
        j->at++;
    }
}

/* A new node of `type` starting here; *index its index. */
static inline int sqffd_export__json_node_new(sqffd_export__json *j, int type, size_t *index)
{
    sqffd_export__json_node *n;
    if (j->count == SQFFD_EXPORT_JSON_MAX_VALUES)
        return sqffd_export__json_error(j, j->at, "more than %llu values, more than a model file holds",
                                        (unsigned long long)SQFFD_EXPORT_JSON_MAX_VALUES);
    if (j->count == j->capacity) {
        size_t capacity = j->capacity ? 2 * j->capacity : 64;
        sqffd_export__json_node *grown;
        if (capacity > (size_t)-1 / sizeof *grown) return sqffd_export__json_error(j, j->at, "out of memory");
        grown = (sqffd_export__json_node *)realloc(j->nodes, capacity * sizeof *grown);
        if (!grown) return sqffd_export__json_error(j, j->at, "out of memory");
        j->nodes = grown;
        j->capacity = capacity;
    }
    n = &j->nodes[j->count];
    memset(n, 0, sizeof *n);
    n->type = type;
    n->start = j->at;
    *index = j->count++;
    return 0;
}

static inline int sqffd_export__json_hex(char c)
{
    return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F');
}

/* A string at j->at (its opening quote): checks escapes, control
   characters and UTF-8; [*start, *end) is its content. */
static inline int sqffd_export__json_string(sqffd_export__json *j, size_t *start, size_t *end)
{
    size_t open = j->at;
    char q[32];
    *start = ++j->at;
    while (j->at < j->size) {
        unsigned char c = (unsigned char)j->text[j->at];
        if (c == '"') {
            *end = j->at++;
            return 0;
        }
        if (c < 0x20) return sqffd_export__json_error(j, j->at, "control character (code %u) in a string", (unsigned)c);
        if (c == '\\') {
            char e = j->at + 1 < j->size ? j->text[j->at + 1] : '\0';
            if (e && strchr("\"\\/bfnrt", e)) j->at += 2;
            else if (e == 'u') {
                int k;
                for (k = 2; k < 6; k++)
                    if (j->at + (size_t)k >= j->size || !sqffd_export__json_hex(j->text[j->at + (size_t)k]))
                        return sqffd_export__json_error(j, j->at, "\\u must be followed by 4 hexadecimal digits");
                j->at += 6;
            } else if (j->at + 1 >= j->size) break;
            else return sqffd_export__json_error(j, j->at, "invalid escape %s in a string", sqffd_export__json_found(j, j->at, q));
        } else if (c >= 0x80) {
            /* UTF-8: a lead byte and its continuation bytes (no overlong 2-byte forms, nothing past U+10FFFF) */
            unsigned more = c >= 0xc2 && c <= 0xdf ? 1u : c >= 0xe0 && c <= 0xef ? 2u : c >= 0xf0 && c <= 0xf4 ? 3u : 0u, k;
            if (more == 0) return sqffd_export__json_error(j, j->at, "invalid UTF-8 in a string");
            for (k = 1; k <= more; k++)
                if (j->at + k >= j->size || ((unsigned char)j->text[j->at + k] & 0xc0) != 0x80)
                    return sqffd_export__json_error(j, j->at, "invalid UTF-8 in a string");
            j->at += more + 1;
        } else j->at++;
    }
    return sqffd_export__json_error(j, open, "the text ends inside this string");
}

static inline int sqffd_export__json_digit(const sqffd_export__json *j)
{
    return j->at < j->size && j->text[j->at] >= '0' && j->text[j->at] <= '9';
}

/* A number by JSON's grammar: -?(0|[1-9][0-9]*)(.[0-9]+)?([eE][+-]?[0-9]+)? */
static inline int sqffd_export__json_number(sqffd_export__json *j, double *value)
{
    size_t s = j->at, len;
    char buf[400], *stop, q[32];
    if (j->text[j->at] == '-') j->at++;
    if (j->at < j->size && j->text[j->at] == '0') j->at++;
    else if (sqffd_export__json_digit(j) && j->text[j->at] != '0')
        while (sqffd_export__json_digit(j)) j->at++;
    else return sqffd_export__json_error(j, s, "invalid number %s", sqffd_export__json_found(j, s, q));
    if (j->at < j->size && j->text[j->at] == '.') {
        j->at++;
        if (!sqffd_export__json_digit(j))
            return sqffd_export__json_error(j, s, "invalid number %s: digits must follow the point",
                                            sqffd_export__json_found(j, s, q));
        while (sqffd_export__json_digit(j)) j->at++;
    }
    if (j->at < j->size && (j->text[j->at] == 'e' || j->text[j->at] == 'E')) {
        j->at++;
        if (j->at < j->size && (j->text[j->at] == '+' || j->text[j->at] == '-')) j->at++;
        if (!sqffd_export__json_digit(j))
            return sqffd_export__json_error(j, s, "invalid number %s: digits must follow the exponent",
                                            sqffd_export__json_found(j, s, q));
        while (sqffd_export__json_digit(j)) j->at++;
    }
    if (j->at < j->size && (isalnum((unsigned char)j->text[j->at]) || strchr(".+-", j->text[j->at]) != NULL))
        return sqffd_export__json_error(j, s, "invalid number %s", sqffd_export__json_found(j, s, q));
    len = j->at - s;
    if (len >= sizeof buf) return sqffd_export__json_error(j, s, "number of %llu characters, too long", (unsigned long long)len);
    memcpy(buf, j->text + s, len);
    buf[len] = '\0';
    *value = strtod(buf, &stop);
    if (stop != buf + len) return sqffd_export__json_error(j, s, "invalid number %s", sqffd_export__json_found(j, s, q));
    if (!isfinite(*value))
        return sqffd_export__json_error(j, s, "number %s is out of range", sqffd_export__json_found(j, s, q));
    return 0;
}

static inline int sqffd_export__json_value(sqffd_export__json *j, int depth, size_t *index);

/* An array or object at j->at; elements or members linked under *index. */
static inline int sqffd_export__json_container(sqffd_export__json *j, int depth, size_t *index)
{
    int object = j->text[j->at] == '{';
    char close = object ? '}' : ']', q[32];
    size_t self = 0, last = 0;
    if (depth >= SQFFD_EXPORT_JSON_MAX_DEPTH)
        return sqffd_export__json_error(j, j->at, "nested deeper than %d levels", SQFFD_EXPORT_JSON_MAX_DEPTH);
    if (sqffd_export__json_node_new(j, object ? SQFFD_EXPORT__JSON_OBJECT : SQFFD_EXPORT__JSON_ARRAY, &self)) return 1;
    *index = self;
    j->at++;
    sqffd_export__json_space(j);
    if (j->at < j->size && j->text[j->at] == close) {
        j->nodes[self].end = ++j->at;
        return 0;
    }
    for (;;) {
        size_t key_start = 0, key_end = 0, child;
        sqffd_export__json_space(j);
        if (object) {
            if (j->at >= j->size || j->text[j->at] != '"')
                return sqffd_export__json_error(j, j->at, "expected a member name in quotes, found %s",
                                                sqffd_export__json_found(j, j->at, q));
            if (sqffd_export__json_string(j, &key_start, &key_end)) return 1;
            sqffd_export__json_space(j);
            if (j->at >= j->size || j->text[j->at] != ':')
                return sqffd_export__json_error(j, j->at, "expected ':' after the member name, found %s",
                                                sqffd_export__json_found(j, j->at, q));
            j->at++;
        }
        if (sqffd_export__json_value(j, depth + 1, &child)) return 1;
        j->nodes[child].key_start = key_start;
        j->nodes[child].key_end = key_end;
        if (last) j->nodes[last - 1].next = child + 1;
        else j->nodes[self].first_child = child + 1;
        last = child + 1;
        j->nodes[self].count++;
        sqffd_export__json_space(j);
        if (j->at < j->size && j->text[j->at] == ',') {
            j->at++;
            continue;
        }
        if (j->at < j->size && j->text[j->at] == close) break;
        return sqffd_export__json_error(j, j->at, "expected ',' or '%c' in %s, found %s", close,
                                        object ? "an object" : "an array", sqffd_export__json_found(j, j->at, q));
    }
    j->nodes[self].end = ++j->at;
    return 0;
}

/* Any value at j->at (after blanks); *index its node. */
static inline int sqffd_export__json_value(sqffd_export__json *j, int depth, size_t *index)
{
    static const char *const words[3] = {"null", "false", "true"};
    char c, q[32];
    int w;
    sqffd_export__json_space(j);
    if (j->at >= j->size) return sqffd_export__json_error(j, j->at, "expected a value, found the end of the text");
    c = j->text[j->at];
    if (c == '{' || c == '[') return sqffd_export__json_container(j, depth, index);
    if (c == '"') {
        size_t start, end;
        if (sqffd_export__json_node_new(j, SQFFD_EXPORT__JSON_STRING, index) || sqffd_export__json_string(j, &start, &end))
            return 1;
        j->nodes[*index].start = start;
        j->nodes[*index].end = end;
        return 0;
    }
    if (c == '-' || (c >= '0' && c <= '9')) {
        double v = 0.0;
        if (sqffd_export__json_node_new(j, SQFFD_EXPORT__JSON_NUMBER, index) || sqffd_export__json_number(j, &v)) return 1;
        j->nodes[*index].number = v;
        j->nodes[*index].end = j->at;
        return 0;
    }
    for (w = 0; w < 3; w++) {
        size_t len = strlen(words[w]);
        unsigned char after = (unsigned char)(j->size - j->at > len ? j->text[j->at + len] : ' ');
        if (j->size - j->at >= len && memcmp(j->text + j->at, words[w], len) == 0 && !isalnum(after) && after != '_') {
            if (sqffd_export__json_node_new(j, SQFFD_EXPORT__JSON_NULL + w, index)) return 1;
            j->at += len;
            j->nodes[*index].end = j->at;
            return 0;
        }
    }
    return sqffd_export__json_error(j, j->at, "expected a value, found %s", sqffd_export__json_found(j, j->at, q));
}

/* Parses the whole text into j->nodes (node 0 the top value); the caller frees j->nodes. */
static inline int sqffd_export__json_parse(sqffd_export__json *j)
{
    size_t top;
    char q[32];
    if (j->size >= 3 && memcmp(j->text, "\xef\xbb\xbf", 3) == 0) j->at = 3; /* a UTF-8 byte order mark */
    if (sqffd_export__json_value(j, 0, &top)) return 1;
    sqffd_export__json_space(j);
    if (j->at < j->size)
        return sqffd_export__json_error(j, j->at, "text after the end of the JSON value: %s",
                                        sqffd_export__json_found(j, j->at, q));
    return 0;
}

/* ---- the model as JSON: reading the tree --------------------------------- */

static inline const char *sqffd_export__json_type(const sqffd_export__json_node *n)
{
    switch (n->type) {
    case SQFFD_EXPORT__JSON_NULL: return "null";
    case SQFFD_EXPORT__JSON_FALSE: return "false";
    case SQFFD_EXPORT__JSON_TRUE: return "true";
    case SQFFD_EXPORT__JSON_NUMBER: return "a number";
    case SQFFD_EXPORT__JSON_STRING: return "a string";
    case SQFFD_EXPORT__JSON_ARRAY: return "an array";
    default: return "an object";
    }
}

/* Whether the JSON string text[start, end) (escapes and all) spells `word` (ASCII). */
static inline int sqffd_export__json_spells(const char *text, size_t start, size_t end, const char *word)
{
    size_t i = start;
    for (; *word; word++) {
        unsigned c;
        if (i >= end) return 0;
        if (text[i] != '\\') c = (unsigned char)text[i++];
        else {
            char e = text[i + 1];
            const char *from = "\"\\/bfnrt", *to = "\"\\/\b\f\n\r\t", *at = strchr(from, e);
            if (e == 'u') {
                char hex[5];
                memcpy(hex, text + i + 2, 4);
                hex[4] = '\0';
                c = (unsigned)strtoul(hex, NULL, 16);
                i += 6;
            } else {
                c = (unsigned char)to[at - from];
                i += 2;
            }
        }
        if (c != (unsigned char)*word) return 0;
    }
    return i == end;
}

/* The member `key` of object node `object`: *found = its index + 1, or 0
   when absent and not required. path names the object in messages. */
static inline int sqffd_export__json_member(sqffd_export__json *j, size_t object, const char *path, const char *key,
                                            int required, size_t *found)
{
    size_t c = j->nodes[object].first_child;
    *found = 0;
    for (; c; c = j->nodes[c - 1].next) {
        const sqffd_export__json_node *n = &j->nodes[c - 1];
        if (!sqffd_export__json_spells(j->text, n->key_start, n->key_end, key)) continue;
        if (*found)
            return sqffd_io__fail(j->err, j->err_size, j->name, "%s%s\"%s\" appears twice", path, *path ? ": " : "",
                                      key);
        *found = c;
    }
    if (!*found && required)
        return sqffd_io__fail(j->err, j->err_size, j->name, "missing \"%s%s%s\"", path, *path ? "." : "", key);
    return 0;
}

/* The `key` member of `object` as an object; path extended into sub_path. */
static inline int sqffd_export__json_object(sqffd_export__json *j, size_t object, const char *path, const char *key,
                                            size_t *found, char sub_path[64])
{
    if (sqffd_export__json_member(j, object, path, key, 1, found)) return 1;
    snprintf(sub_path, 64, "%s%s%s", path, *path ? "." : "", key);
    if (j->nodes[*found - 1].type != SQFFD_EXPORT__JSON_OBJECT)
        return sqffd_io__fail(j->err, j->err_size, j->name, "%s: expected an object, found %s", sub_path,
                                  sqffd_export__json_type(&j->nodes[*found - 1]));
    return 0;
}

/* Node `array` (named path) as exactly `count` numbers. */
static inline int sqffd_export__json_array_numbers(sqffd_export__json *j, size_t array, const char *path, size_t count,
                                                   double *out)
{
    const sqffd_export__json_node *a = &j->nodes[array];
    size_t c, i = 0;
    if (a->type != SQFFD_EXPORT__JSON_ARRAY)
        return sqffd_io__fail(j->err, j->err_size, j->name, "%s: expected an array of %llu numbers, found %s", path,
                                  (unsigned long long)count, sqffd_export__json_type(a));
    if (a->count != count)
        return sqffd_io__fail(j->err, j->err_size, j->name, "%s: expected %llu numbers, found %llu values", path,
                                  (unsigned long long)count, (unsigned long long)a->count);
    for (c = a->first_child; c; c = j->nodes[c - 1].next, i++) {
        if (j->nodes[c - 1].type != SQFFD_EXPORT__JSON_NUMBER)
            return sqffd_io__fail(j->err, j->err_size, j->name, "%s[%llu]: expected a number, found %s", path,
                                      (unsigned long long)i, sqffd_export__json_type(&j->nodes[c - 1]));
        out[i] = j->nodes[c - 1].number;
    }
    return 0;
}

/* The `key` member of `object` as exactly `count` numbers. */
static inline int sqffd_export__json_numbers_of(sqffd_export__json *j, size_t object, const char *path, const char *key,
                                                size_t count, double *out)
{
    char full[96]; /* an object's path (< 64) and a key */
    size_t found;
    if (sqffd_export__json_member(j, object, path, key, 1, &found)) return 1;
    snprintf(full, sizeof full, "%s%s%s", path, *path ? "." : "", key);
    return sqffd_export__json_array_numbers(j, found - 1, full, count, out);
}

/* The `key` member of `object` as `count` integers, the i-th within lo[i]..hi[i]. */
static inline int sqffd_export__json_ints_of(sqffd_export__json *j, size_t object, const char *path, const char *key,
                                             int count, const int *lo, const int *hi, int *out)
{
    double v[3];
    int i;
    if (sqffd_export__json_numbers_of(j, object, path, key, (size_t)count, v)) return 1;
    for (i = 0; i < count; i++) {
        if (v[i] != floor(v[i]))
            return sqffd_io__fail(j->err, j->err_size, j->name, "%s%s%s[%d] = %.17g is not an integer", path,
                                      *path ? "." : "", key, i, v[i]);
        if (v[i] < lo[i] || v[i] > hi[i])
            return sqffd_io__fail(j->err, j->err_size, j->name, "%s%s%s[%d] = %.17g is outside %d..%d", path,
                                      *path ? "." : "", key, i, v[i], lo[i], hi[i]);
        out[i] = (int)v[i];
    }
    return 0;
}

/* The model from a parsed tree (node 0), into *m. */
static inline int sqffd_export__json_model(sqffd_export__json *j, sqffd_model *m)
{
    static const int dims_lo[3] = {2, 2, 2}, dims_hi[3] = {SQFFD_MAX_LATTICE, SQFFD_MAX_LATTICE, SQFFD_MAX_LATTICE};
    static const int grid_lo[2] = {2, 3}, grid_hi[2] = {SQFFD_EXPORT_GRID_MAX, SQFFD_EXPORT_GRID_MAX};
    char sq_path[64], ffd_path[64];
    size_t format, version, sq, ffd, control, c, i, points;
    double det, worst = 0.0;
    const double *r;
    int a, b;
    sqffd_result res;
    if (j->nodes[0].type != SQFFD_EXPORT__JSON_OBJECT)
        return sqffd_io__fail(j->err, j->err_size, j->name, "not an sqffd model: the top level is %s, not an object",
                                  sqffd_export__json_type(&j->nodes[0]));
    if (sqffd_export__json_member(j, 0, "", "format", 0, &format)) return 1;
    if (!format || j->nodes[format - 1].type != SQFFD_EXPORT__JSON_STRING ||
        !sqffd_export__json_spells(j->text, j->nodes[format - 1].start, j->nodes[format - 1].end, "sqffd-model"))
        return sqffd_io__fail(j->err, j->err_size, j->name, "not an sqffd model: no \"format\": \"sqffd-model\"");
    if (sqffd_export__json_member(j, 0, "", "version", 1, &version)) return 1;
    if (j->nodes[version - 1].type != SQFFD_EXPORT__JSON_NUMBER)
        return sqffd_io__fail(j->err, j->err_size, j->name, "version: expected a number, found %s",
                                  sqffd_export__json_type(&j->nodes[version - 1]));
    if (j->nodes[version - 1].number != 1.0)
        return sqffd_io__fail(j->err, j->err_size, j->name, "version %.17g is not supported: this reader reads version 1",
                                  j->nodes[version - 1].number);

    if (sqffd_export__json_object(j, 0, "", "superquadric", &sq, sq_path) ||
        sqffd_export__json_numbers_of(j, sq - 1, sq_path, "size", 3, m->sq.size) ||
        sqffd_export__json_numbers_of(j, sq - 1, sq_path, "shape", 2, m->sq.shape) ||
        sqffd_export__json_numbers_of(j, sq - 1, sq_path, "taper", 2, m->sq.taper) ||
        sqffd_export__json_numbers_of(j, sq - 1, sq_path, "rotation", 9, m->sq.rotation) ||
        sqffd_export__json_numbers_of(j, sq - 1, sq_path, "center", 3, m->sq.center))
        return 1;
    for (a = 0; a < 3; a++)
        if (!(m->sq.size[a] > 0.0))
            return sqffd_io__fail(j->err, j->err_size, j->name, "superquadric.size[%d] = %.17g is not positive", a,
                                      m->sq.size[a]);
    for (a = 0; a < 2; a++) {
        if (!(m->sq.shape[a] > 0.0))
            return sqffd_io__fail(j->err, j->err_size, j->name, "superquadric.shape[%d] = %.17g is not positive", a,
                                      m->sq.shape[a]);
        if (!(fabs(m->sq.taper[a]) < 1.0))
            return sqffd_io__fail(j->err, j->err_size, j->name, "superquadric.taper[%d] = %.17g is outside (-1, 1)",
                                      a, m->sq.taper[a]);
    }
    /* a rotation: orthonormal columns and determinant +1 (a stored one is exact to ~1e-15) */
    r = m->sq.rotation;
    for (a = 0; a < 3; a++)
        for (b = 0; b < 3; b++) {
            double dot = r[a] * r[b] + r[3 + a] * r[3 + b] + r[6 + a] * r[6 + b] - (a == b ? 1.0 : 0.0);
            if (fabs(dot) > worst) worst = fabs(dot);
        }
    det = r[0] * (r[4] * r[8] - r[5] * r[7]) - r[1] * (r[3] * r[8] - r[5] * r[6]) + r[2] * (r[3] * r[7] - r[4] * r[6]);
    if (!(worst <= 1e-6) || !(det > 0.0))
        return sqffd_io__fail(j->err, j->err_size, j->name,
                                  "superquadric.rotation is not a rotation (orthonormal, determinant +1)");

    if (sqffd_export__json_object(j, 0, "", "ffd", &ffd, ffd_path) ||
        sqffd_export__json_ints_of(j, ffd - 1, ffd_path, "dims", 3, dims_lo, dims_hi, m->ffd.dims) ||
        sqffd_export__json_numbers_of(j, ffd - 1, ffd_path, "origin", 3, m->ffd.origin) ||
        sqffd_export__json_numbers_of(j, ffd - 1, ffd_path, "edges", 9, m->ffd.edges) ||
        sqffd_export__json_member(j, ffd - 1, ffd_path, "control", 1, &control) ||
        sqffd_export__json_ints_of(j, 0, "", "grid", 2, grid_lo, grid_hi, m->grid))
        return 1;
    {
        /* sqffd_ffd_init recomputes `inverse` and clears the lattice; the control points then replace it */
        int dims[3];
        double origin[3], edges[9];
        memcpy(dims, m->ffd.dims, sizeof dims);
        memcpy(origin, m->ffd.origin, sizeof origin);
        memcpy(edges, m->ffd.edges, sizeof edges);
        res = sqffd_ffd_init(&m->ffd, dims, origin, edges);
    }
    if (res == SQFFD_ERROR_DEGENERATE)
        return sqffd_io__fail(j->err, j->err_size, j->name, "ffd.edges: the box is flat");
    if (res != SQFFD_OK)
        return sqffd_io__fail(j->err, j->err_size, j->name, "ffd: %s", sqffd_result_string(res));
    points = (size_t)m->ffd.dims[0] * (size_t)m->ffd.dims[1] * (size_t)m->ffd.dims[2];
    if (j->nodes[control - 1].type != SQFFD_EXPORT__JSON_ARRAY || j->nodes[control - 1].count != points)
        return sqffd_io__fail(j->err, j->err_size, j->name,
                                  "ffd.control: expected an array of %llu control points (%d x %d x %d), found %s of %llu",
                                  (unsigned long long)points, m->ffd.dims[0], m->ffd.dims[1], m->ffd.dims[2],
                                  sqffd_export__json_type(&j->nodes[control - 1]),
                                  (unsigned long long)j->nodes[control - 1].count);
    for (c = j->nodes[control - 1].first_child, i = 0; c; c = j->nodes[c - 1].next, i++) {
        char path[64];
        snprintf(path, sizeof path, "ffd.control[%llu]", (unsigned long long)i);
        if (sqffd_export__json_array_numbers(j, c - 1, path, 3, m->ffd.control[i])) return 1;
    }
    res = sqffd_model_validate(m); /* the library's own rule, whatever the fields' checks above let through */
    if (res != SQFFD_OK) return sqffd_io__fail(j->err, j->err_size, j->name, "the model: %s", sqffd_result_string(res));
    return 0;
}

/* Reads a model written by sqffd_export_model_json from text[0 .. size)
   (not NUL-terminated; name for messages). Strict JSON (RFC 8259: objects,
   arrays, numbers, strings with their escapes and UTF-8, true, false, null;
   nesting at most SQFFD_EXPORT_JSON_MAX_DEPTH deep, at most
   SQFFD_EXPORT_JSON_MAX_VALUES values); every malformed input
   gives "NAME: line L, column C: what". Then: "format" must be
   "sqffd-model", "version" 1; superquadric, ffd (dims 2..SQFFD_MAX_LATTICE,
   origin, edges, l m n control points) and grid are required (sizes and
   shapes positive, |taper| < 1, a rotation, a box that is not flat); other
   members ("fit", "library_version", any unknown key) are ignored; a key
   that appears twice where one is read is an error. The derived field
   ffd.inverse is recomputed by sqffd_ffd_init, so the model is bit for bit
   the one written. On failure *model is not written. */
static inline int sqffd_export_read_model_json(const char *text, size_t size, const char *name, sqffd_model *model,
                                               char *err, size_t err_size)
{
    sqffd_export__json j;
    sqffd_model m;
    int r;
    if (!text || !model) return sqffd_io__fail(err, err_size, name, "no text or no model");
    memset(&j, 0, sizeof j);
    memset(&m, 0, sizeof m);
    j.text = text;
    j.size = size;
    j.name = name;
    j.err = err;
    j.err_size = err_size;
    r = sqffd_export__json_parse(&j) || sqffd_export__json_model(&j, &m);
    free(j.nodes);
    if (r == 0) *model = m;
    return r;
}

/* Reads the model JSON file at `path` (sqffd_export_read_model_json). */
static inline int sqffd_export_read_model_json_file(const char *path, sqffd_model *model, char *err, size_t err_size)
{
    unsigned char *data;
    size_t size;
    int r;
    if (sqffd_io_load_file(path, &data, &size, err, err_size)) return 1;
    r = sqffd_export_read_model_json((const char *)data, size, path, model, err, err_size);
    free(data);
    return r;
}

/* ---- SVG: common parts --------------------------------------------------- */

/* Text for XML content or a quoted attribute: the markup characters escaped,
   control characters (which XML 1.0 cannot hold) as blanks. */
static inline void sqffd_export__xml(FILE *f, const char *s)
{
    for (; s && *s; s++) {
        switch (*s) {
        case '&': fputs("&amp;", f); break;
        case '<': fputs("&lt;", f); break;
        case '>': fputs("&gt;", f); break;
        case '"': fputs("&quot;", f); break;
        case '\'': fputs("&apos;", f); break;
        default: fputc((unsigned char)*s < 32 ? ' ' : *s, f);
        }
    }
}

static inline void sqffd_export__svg_begin(FILE *f, int width, int height, const char *title)
{
    fprintf(f,
            "<?xml version=\"1.0\" encoding=\"UTF-8\" standalone=\"no\"?>\n"
            "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"%d\" height=\"%d\" "
            "viewBox=\"0 0 %d %d\" font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\" font-size=\"12\">\n",
            width, height, width, height);
    if (title && *title) {
        fputs("<title>", f);
        sqffd_export__xml(f, title);
        fputs("</title>\n", f);
    }
    fprintf(f, "<rect x=\"0\" y=\"0\" width=\"%d\" height=\"%d\" fill=\"white\"/>\n", width, height);
}

/* A text element: anchor "start", "middle" or "end"; extra attributes (may be ""). */
static inline void sqffd_export__svg_text(FILE *f, double x, double y, const char *anchor, const char *extra,
                                          const char *text)
{
    fprintf(f, "<text x=\"%.2f\" y=\"%.2f\" text-anchor=\"%s\"%s%s>", x, y, anchor, *extra ? " " : "", extra);
    sqffd_export__xml(f, text);
    fputs("</text>\n", f);
}

/* ---- SVG: axes ----------------------------------------------------------- */

#define SQFFD_EXPORT__MAX_TICKS 16
#define SQFFD_EXPORT__MAX_MINOR 64

/* One axis: its ends, in data units (log axes: log10 of them), and its
   labelled ticks and unlabelled grid lines in data units. */
typedef struct sqffd_export__axis {
    int log;
    double lo, hi;
    int tick_count, minor_count;
    double tick[SQFFD_EXPORT__MAX_TICKS], minor[SQFFD_EXPORT__MAX_MINOR];
    int decimals; /* linear: digits after the point in the labels */
} sqffd_export__axis;

/* Ticks for data in [min, max] (both finite; positive on a log axis).
   Linear: the finest 1-2-5 step whose multiples around the data make at
   most 7 intervals, the axis ending on them (a single value gets +-10%
   around it). Log: the ends on
   powers of ten, a label per decade (every k-th decade past 8), with 2 and
   5 labelled too when the axis spans one decade, and 2..9 as grid lines
   up to 6 decades. */
static inline void sqffd_export__axis_init(sqffd_export__axis *a, double min, double max, int log_scale)
{
    memset(a, 0, sizeof *a);
    a->log = log_scale;
    if (!log_scale) {
        static const double steps[3] = {1.0, 2.0, 5.0};
        double raw, magnitude, fraction, step, k0, k1, k;
        int exponent, m;
        if (!(max - min > 1e-300 + 1e-12 * fabs(min))) { /* one value (to 12 digits): +-10% around it, or +-1 */
            double centre = 0.5 * (min + max), pad = fabs(centre) > 1e-300 ? 0.1 * fabs(centre) : 1.0;
            min = centre - pad;
            max = centre + pad;
        }
        raw = (max - min) / 7; /* values are within +-1e300: no overflow */
        magnitude = pow(10.0, floor(log10(raw)));
        fraction = raw / magnitude;
        m = fraction <= 1.0 + 1e-9 ? 0 : fraction <= 2.0 + 1e-9 ? 1 : fraction <= 5.0 + 1e-9 ? 2 : 3;
        for (;;) { /* the first step at least a seventh of the range; the next if the ends add too much */
            step = steps[m % 3] * magnitude * pow(10.0, m / 3);
            k0 = floor(min / step + 1e-9);
            k1 = ceil(max / step - 1e-9);
            if (k1 - k0 <= 7.0 || m >= 12) break;
            m++;
        }
        a->lo = k0 * step;
        a->hi = k1 * step;
        for (k = k0; k <= k1 && a->tick_count < SQFFD_EXPORT__MAX_TICKS; k += 1.0)
            a->tick[a->tick_count++] = k == 0.0 ? 0.0 : k * step; /* no "-0" */
        exponent = (int)floor(log10(step) + 1e-9);
        a->decimals = exponent < 0 ? -exponent : 0;
    } else {
        double d0 = floor(log10(min) + 1e-9), d1 = ceil(log10(max) - 1e-9), d;
        int stride;
        if (d1 <= d0) { /* every value on one power of ten */
            d0 -= 1.0;
            d1 += 1.0;
        }
        a->lo = d0;
        a->hi = d1;
        stride = (int)ceil((d1 - d0) / 8.0);
        for (d = d0; d <= d1 && a->tick_count < SQFFD_EXPORT__MAX_TICKS; d += stride) {
            a->tick[a->tick_count++] = pow(10.0, d);
            if (d1 - d0 == 1.0 && d == d0) {
                a->tick[a->tick_count++] = 2.0 * pow(10.0, d);
                a->tick[a->tick_count++] = 5.0 * pow(10.0, d);
            }
        }
        if (d1 - d0 <= 6.0)
            for (d = d0; d < d1; d += 1.0) {
                int m;
                for (m = 2; m <= 9; m++)
                    if (!(d1 - d0 == 1.0 && (m == 2 || m == 5)) && a->minor_count < SQFFD_EXPORT__MAX_MINOR)
                        a->minor[a->minor_count++] = m * pow(10.0, d);
            }
    }
}

/* Position of a data value along the axis, 0 at lo and 1 at hi. */
static inline double sqffd_export__axis_fraction(const sqffd_export__axis *a, double v)
{
    return ((a->log ? log10(v) : v) - a->lo) / (a->hi - a->lo);
}

/* The label of tick value v. Log axes write powers beyond 10^+-3 as 10 with
   a superscript, which is why this writes markup, not text. */
static inline void sqffd_export__tick_label(FILE *f, const sqffd_export__axis *a, double v)
{
    if (a->log) {
        double d = floor(log10(v) + 0.5);
        if (fabs(v - pow(10.0, d)) <= 1e-9 * v && fabs(d) > 3.0)
            fprintf(f, "10<tspan dy=\"-5\" font-size=\"9\">%d</tspan>", (int)d);
        else fprintf(f, "%g", v);
    } else if (fabs(v) >= 1e6 || a->decimals > 6) fprintf(f, "%g", v);
    else fprintf(f, "%.*f", a->decimals, v);
}

/* ---- SVG: the line plot --------------------------------------------------- */

#define SQFFD_EXPORT_LOG_X 1 /* plot flags: logarithmic x axis */
#define SQFFD_EXPORT_LOG_Y 2 /* logarithmic y axis */

/* One line of a plot: count points (x[i], y[i]); x may be NULL for 0, 1, 2, ... */
typedef struct sqffd_export_series {
    const char *name; /* legend text; NULL or "": not in the legend */
    const double *x, *y;
    size_t count;
} sqffd_export_series;

/* A labelled point of a plot (e.g. "ED" and "ES" on a volume curve). */
typedef struct sqffd_export_mark {
    double x, y;
    const char *label;
} sqffd_export_mark;

/* The plot's canvas and plot area (SVG user units). */
#define SQFFD_EXPORT__PLOT_WIDTH 640
#define SQFFD_EXPORT__PLOT_HEIGHT 400
#define SQFFD_EXPORT__PLOT_LEFT 80.0
#define SQFFD_EXPORT__PLOT_RIGHT 620.0
#define SQFFD_EXPORT__PLOT_TOP 48.0
#define SQFFD_EXPORT__PLOT_BOTTOM 336.0

static inline double sqffd_export__series_x(const sqffd_export_series *s, size_t i)
{
    return s->x ? s->x[i] : (double)i;
}

/* Why a value cannot go on an axis, or NULL when it can: finite, within
   +-1e300, and on a log axis at least 1e-300. */
static inline const char *sqffd_export__unplaceable(double v, int log_scale)
{
    if (!isfinite(v)) return "is not finite";
    if (log_scale && !(v > 0.0)) return "cannot go on a log axis (values must be > 0)";
    if (fabs(v) > 1e300 || (log_scale && v < 1e-300)) return "is beyond what a plot shows (1e-300 to 1e300)";
    return NULL;
}

static inline int sqffd_export__plot_check(const char *name, const sqffd_export_series *series, int series_count,
                                           const sqffd_export_mark *marks, int mark_count, int flags, char *err,
                                           size_t err_size)
{
    int s, log_x = (flags & SQFFD_EXPORT_LOG_X) != 0, log_y = (flags & SQFFD_EXPORT_LOG_Y) != 0;
    size_t i, total = 0;
    if (flags & ~(SQFFD_EXPORT_LOG_X | SQFFD_EXPORT_LOG_Y))
        return sqffd_io__fail(err, err_size, name, "unknown flags 0x%x", (unsigned)flags);
    if (series_count < 1 || !series) return sqffd_io__fail(err, err_size, name, "no series to plot");
    if (mark_count < 0 || (mark_count > 0 && !marks))
        return sqffd_io__fail(err, err_size, name, "mark count %d without marks", mark_count);
    for (s = 0; s < series_count; s++) {
        const sqffd_export_series *e = &series[s];
        const char *label = e->name && *e->name ? e->name : "";
        if (e->count > 0 && !e->y)
            return sqffd_io__fail(err, err_size, name, "series %d '%s' has no y values", s, label);
        for (i = 0; i < e->count; i++) {
            double x = sqffd_export__series_x(e, i), y = e->y[i];
            const char *why = sqffd_export__unplaceable(x, log_x);
            if (!why) why = sqffd_export__unplaceable(y, log_y);
            if (why)
                return sqffd_io__fail(err, err_size, name, "series %d '%s', point %llu: (%g, %g) %s", s, label,
                                          (unsigned long long)i, x, y, why);
        }
        total += e->count;
    }
    if (total == 0) return sqffd_io__fail(err, err_size, name, "no points to plot");
    for (s = 0; s < mark_count; s++) {
        const char *why = sqffd_export__unplaceable(marks[s].x, log_x);
        if (!why) why = sqffd_export__unplaceable(marks[s].y, log_y);
        if (why)
            return sqffd_io__fail(err, err_size, name, "mark %d '%s' at (%g, %g) %s", s,
                                      marks[s].label ? marks[s].label : "", marks[s].x, marks[s].y, why);
    }
    return 0;
}

/* Series colours: distinct in hue and lightness (and markers differ in shape). */
static inline const char *sqffd_export__series_colour(int s)
{
    static const char *const colours[] = {"#2b5c8a", "#d1495b", "#3a8d4f", "#e08a1e", "#7b52a6", "#4d4d4d"};
    return colours[s % 6];
}

/* A marker at (x, y): circle, square, diamond or triangle by series. */
static inline void sqffd_export__marker(FILE *f, int s, double x, double y, const char *colour)
{
    switch (s % 4) {
    case 0: fprintf(f, "<circle cx=\"%.2f\" cy=\"%.2f\" r=\"3.5\"", x, y); break;
    case 1: fprintf(f, "<rect x=\"%.2f\" y=\"%.2f\" width=\"6.5\" height=\"6.5\"", x - 3.25, y - 3.25); break;
    case 2: fprintf(f, "<path d=\"M %.2f %.2f l 4.5 4.5 l -4.5 4.5 l -4.5 -4.5 Z\"", x, y - 4.5); break;
    default: fprintf(f, "<path d=\"M %.2f %.2f l 4.5 8 l -9 0 Z\"", x, y - 5.0); break;
    }
    fprintf(f, " fill=\"%s\" stroke=\"white\" stroke-width=\"0.8\"/>\n", colour);
}

/* Writes a line plot as SVG 1.1 (640 x 400, viewBox set, sans-serif):
   title (may be NULL), axis labels (may be NULL), every series as a line
   with markers (up to 60 points) in its own colour and marker shape, a
   legend of the named series in the plot corner that covers the fewest
   points, marks as labelled rings with a dashed drop line, axes with 1-2-5
   ticks or (flags SQFFD_EXPORT_LOG_X, _LOG_Y) logarithmic ones, grid
   lines. The axes span every point and mark. Refused: no points, a NaN or
   infinite value, a value <= 0 on a log axis, values beyond +-1e300 (or
   below 1e-300 on a log axis). */
static inline int sqffd_export_svg_plot_stream(FILE *f, const char *name, const char *title, const char *x_label,
                                               const char *y_label, const sqffd_export_series *series,
                                               int series_count, const sqffd_export_mark *marks, int mark_count,
                                               int flags, char *err, size_t err_size)
{
    const double left = SQFFD_EXPORT__PLOT_LEFT, right = SQFFD_EXPORT__PLOT_RIGHT;
    const double top = SQFFD_EXPORT__PLOT_TOP, bottom = SQFFD_EXPORT__PLOT_BOTTOM;
    double x_min = HUGE_VAL, x_max = -HUGE_VAL, y_min = HUGE_VAL, y_max = -HUGE_VAL;
    double legend_w = 0.0, legend_h, best_x = 0.0, best_y = 0.0;
    sqffd_export__axis ax, ay;
    int s, k, named = 0, corner;
    size_t i, longest = 0, best_covered = (size_t)-1;
    if (sqffd_export__plot_check(name, series, series_count, marks, mark_count, flags, err, err_size)) return 1;
    for (s = 0; s < series_count; s++) {
        for (i = 0; i < series[s].count; i++) {
            double x = sqffd_export__series_x(&series[s], i), y = series[s].y[i];
            x_min = x < x_min ? x : x_min;
            x_max = x > x_max ? x : x_max;
            y_min = y < y_min ? y : y_min;
            y_max = y > y_max ? y : y_max;
        }
        if (series[s].name && *series[s].name) {
            named++;
            if (strlen(series[s].name) > longest) longest = strlen(series[s].name);
        }
    }
    for (k = 0; k < mark_count; k++) {
        x_min = marks[k].x < x_min ? marks[k].x : x_min;
        x_max = marks[k].x > x_max ? marks[k].x : x_max;
        y_min = marks[k].y < y_min ? marks[k].y : y_min;
        y_max = marks[k].y > y_max ? marks[k].y : y_max;
    }
    sqffd_export__axis_init(&ax, x_min, x_max, (flags & SQFFD_EXPORT_LOG_X) != 0);
    sqffd_export__axis_init(&ay, y_min, y_max, (flags & SQFFD_EXPORT_LOG_Y) != 0);
#define SQFFD_EXPORT__PX(v) (left + (right - left) * sqffd_export__axis_fraction(&ax, (v)))
#define SQFFD_EXPORT__PY(v) (bottom - (bottom - top) * sqffd_export__axis_fraction(&ay, (v)))

    sqffd_export__svg_begin(f, SQFFD_EXPORT__PLOT_WIDTH, SQFFD_EXPORT__PLOT_HEIGHT, title);
    if (title && *title)
        sqffd_export__svg_text(f, 0.5 * SQFFD_EXPORT__PLOT_WIDTH, 28.0, "middle",
                               "class=\"title\" font-size=\"16\" font-weight=\"bold\"", title);
    /* grid lines, then the frame and the ticks with their labels */
    fputs("<g class=\"grid\" stroke-width=\"1\" fill=\"none\">\n", f);
    for (k = 0; k < ax.minor_count; k++)
        fprintf(f, "<line x1=\"%.2f\" y1=\"%.2f\" x2=\"%.2f\" y2=\"%.2f\" stroke=\"#f0f0f0\"/>\n",
                SQFFD_EXPORT__PX(ax.minor[k]), top, SQFFD_EXPORT__PX(ax.minor[k]), bottom);
    for (k = 0; k < ay.minor_count; k++)
        fprintf(f, "<line x1=\"%.2f\" y1=\"%.2f\" x2=\"%.2f\" y2=\"%.2f\" stroke=\"#f0f0f0\"/>\n", left,
                SQFFD_EXPORT__PY(ay.minor[k]), right, SQFFD_EXPORT__PY(ay.minor[k]));
    for (k = 0; k < ax.tick_count; k++)
        fprintf(f, "<line x1=\"%.2f\" y1=\"%.2f\" x2=\"%.2f\" y2=\"%.2f\" stroke=\"#dcdcdc\"/>\n",
                SQFFD_EXPORT__PX(ax.tick[k]), top, SQFFD_EXPORT__PX(ax.tick[k]), bottom);
    for (k = 0; k < ay.tick_count; k++)
        fprintf(f, "<line x1=\"%.2f\" y1=\"%.2f\" x2=\"%.2f\" y2=\"%.2f\" stroke=\"#dcdcdc\"/>\n", left,
                SQFFD_EXPORT__PY(ay.tick[k]), right, SQFFD_EXPORT__PY(ay.tick[k]));
    fputs("</g>\n", f);
    fprintf(f, "<rect class=\"frame\" x=\"%.2f\" y=\"%.2f\" width=\"%.2f\" height=\"%.2f\" fill=\"none\" "
               "stroke=\"#444444\" stroke-width=\"1\"/>\n",
            left, top, right - left, bottom - top);
    fputs("<g class=\"ticks\" stroke=\"#444444\" stroke-width=\"1\">\n", f);
    for (k = 0; k < ax.tick_count; k++)
        fprintf(f, "<line x1=\"%.2f\" y1=\"%.2f\" x2=\"%.2f\" y2=\"%.2f\"/>\n", SQFFD_EXPORT__PX(ax.tick[k]), bottom,
                SQFFD_EXPORT__PX(ax.tick[k]), bottom + 5.0);
    for (k = 0; k < ay.tick_count; k++)
        fprintf(f, "<line x1=\"%.2f\" y1=\"%.2f\" x2=\"%.2f\" y2=\"%.2f\"/>\n", left - 5.0, SQFFD_EXPORT__PY(ay.tick[k]),
                left, SQFFD_EXPORT__PY(ay.tick[k]));
    fputs("</g>\n", f);
    for (k = 0; k < ax.tick_count; k++) {
        fprintf(f, "<text class=\"tick-x\" x=\"%.2f\" y=\"%.2f\" text-anchor=\"middle\">", SQFFD_EXPORT__PX(ax.tick[k]),
                bottom + 19.0);
        sqffd_export__tick_label(f, &ax, ax.tick[k]);
        fputs("</text>\n", f);
    }
    for (k = 0; k < ay.tick_count; k++) {
        fprintf(f, "<text class=\"tick-y\" x=\"%.2f\" y=\"%.2f\" text-anchor=\"end\">", left - 8.0,
                SQFFD_EXPORT__PY(ay.tick[k]) + 4.0);
        sqffd_export__tick_label(f, &ay, ay.tick[k]);
        fputs("</text>\n", f);
    }
    if (x_label && *x_label)
        sqffd_export__svg_text(f, 0.5 * (left + right), bottom + 44.0, "middle", "class=\"label-x\" font-size=\"13\"",
                               x_label);
    if (y_label && *y_label) {
        fprintf(f, "<text class=\"label-y\" font-size=\"13\" text-anchor=\"middle\" "
                   "transform=\"translate(22 %.2f) rotate(-90)\">",
                0.5 * (top + bottom));
        sqffd_export__xml(f, y_label);
        fputs("</text>\n", f);
    }

    /* the series: a line, then markers when there are few points */
    for (s = 0; s < series_count; s++) {
        const sqffd_export_series *e = &series[s];
        const char *colour = sqffd_export__series_colour(s);
        fprintf(f, "<g class=\"series\" id=\"series-%d\">\n", s + 1);
        if (e->count > 1) {
            fprintf(f, "<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"2\" stroke-linejoin=\"round\" points=\"",
                    colour);
            for (i = 0; i < e->count; i++)
                fprintf(f, "%s%.2f,%.2f", i ? " " : "", SQFFD_EXPORT__PX(sqffd_export__series_x(e, i)),
                        SQFFD_EXPORT__PY(e->y[i]));
            fputs("\"/>\n", f);
        }
        if (e->count <= 60)
            for (i = 0; i < e->count; i++)
                sqffd_export__marker(f, s, SQFFD_EXPORT__PX(sqffd_export__series_x(e, i)), SQFFD_EXPORT__PY(e->y[i]),
                                     colour);
        fputs("</g>\n", f);
    }
    for (k = 0; k < mark_count; k++) {
        double px = SQFFD_EXPORT__PX(marks[k].x), py = SQFFD_EXPORT__PY(marks[k].y);
        fprintf(f, "<g class=\"mark\">\n<line x1=\"%.2f\" y1=\"%.2f\" x2=\"%.2f\" y2=\"%.2f\" stroke=\"#666666\" "
                   "stroke-dasharray=\"4 3\"/>\n<circle cx=\"%.2f\" cy=\"%.2f\" r=\"6\" fill=\"none\" stroke=\"#222222\" "
                   "stroke-width=\"1.5\"/>\n",
                px, py + 6.0, px, bottom, px, py);
        if (marks[k].label && *marks[k].label)
            sqffd_export__svg_text(f, px, py - 10.0 < top + 12.0 ? py + 22.0 : py - 10.0, "middle", "font-weight=\"bold\"",
                                   marks[k].label);
        fputs("</g>\n", f);
    }

    /* the legend, in the corner of the plot area that covers the fewest points */
    if (named > 0) {
        legend_w = 44.0 + 7.0 * (double)(longest > 40 ? 40 : longest);
        legend_h = 8.0 + 18.0 * named;
        for (corner = 0; corner < 4; corner++) {
            double lx = corner % 2 == 0 ? right - 10.0 - legend_w : left + 10.0;
            double ly = corner < 2 ? top + 10.0 : bottom - 10.0 - legend_h;
            size_t covered = 0;
            for (s = 0; s < series_count; s++)
                for (i = 0; i < series[s].count; i++) {
                    double px = SQFFD_EXPORT__PX(sqffd_export__series_x(&series[s], i)), py = SQFFD_EXPORT__PY(series[s].y[i]);
                    if (px >= lx && px <= lx + legend_w && py >= ly && py <= ly + legend_h) covered++;
                }
            if (covered < best_covered) {
                best_covered = covered;
                best_x = lx;
                best_y = ly;
            }
        }
        fprintf(f, "<g class=\"legend\">\n<rect x=\"%.2f\" y=\"%.2f\" width=\"%.2f\" height=\"%.2f\" fill=\"white\" "
                   "fill-opacity=\"0.9\" stroke=\"#bbbbbb\"/>\n",
                best_x, best_y, legend_w, legend_h);
        for (s = 0, k = 0; s < series_count; s++) {
            double ly;
            if (!series[s].name || !*series[s].name) continue;
            ly = best_y + 13.0 + 18.0 * k++;
            fprintf(f, "<line x1=\"%.2f\" y1=\"%.2f\" x2=\"%.2f\" y2=\"%.2f\" stroke=\"%s\" stroke-width=\"2\"/>\n",
                    best_x + 8.0, ly, best_x + 32.0, ly, sqffd_export__series_colour(s));
            sqffd_export__marker(f, s, best_x + 20.0, ly, sqffd_export__series_colour(s));
            sqffd_export__svg_text(f, best_x + 38.0, ly + 4.0, "start", "", series[s].name);
        }
        fputs("</g>\n", f);
    }
#undef SQFFD_EXPORT__PX
#undef SQFFD_EXPORT__PY
    fputs("</svg>\n", f);
    return sqffd_export__flush(f, name, err, err_size);
}

/* sqffd_export_svg_plot_stream into a new file at `path`. */
static inline int sqffd_export_svg_plot(const char *path, const char *title, const char *x_label, const char *y_label,
                                        const sqffd_export_series *series, int series_count,
                                        const sqffd_export_mark *marks, int mark_count, int flags, char *err,
                                        size_t err_size)
{
    FILE *f;
    int r;
    if (sqffd_export__plot_check(path, series, series_count, marks, mark_count, flags, err, err_size) ||
        sqffd_export__create(path, &f, err, err_size))
        return 1;
    r = sqffd_export_svg_plot_stream(f, path, title, x_label, y_label, series, series_count, marks, mark_count, flags,
                                     err, err_size);
    return sqffd_export__close(f, path, r, err, err_size);
}

/* ---- SVG: the three plots of a fit and a sequence ------------------------- */

static inline int sqffd_export__history_check(const char *name, const sqffd_fit_report *report, char *err,
                                              size_t err_size)
{
    if (!report) return sqffd_io__fail(err, err_size, name, "no fit report");
    if (report->history_count < 0 || report->history_count > SQFFD_FIT_HISTORY)
        return sqffd_io__fail(err, err_size, name, "report history_count %d is outside 0..%d",
                                  report->history_count, SQFFD_FIT_HISTORY);
    return 0;
}

/* The error per iteration (the paper's Fig. 3): relative RMS error in % of
   the diagonal against the iteration, 0 being the starting model (the
   superquadric alone for sqffd_fit: report->sq_error), then history[0 ..
   history_count). title NULL: "Error per iteration". */
static inline int sqffd_export_svg_history_stream(FILE *f, const char *name, const sqffd_fit_report *report,
                                                  const char *title, char *err, size_t err_size)
{
    double x[SQFFD_FIT_HISTORY + 1], y[SQFFD_FIT_HISTORY + 1];
    sqffd_export_series line;
    int k;
    if (sqffd_export__history_check(name, report, err, err_size)) return 1;
    x[0] = 0.0;
    y[0] = 100.0 * report->sq_error.rms_relative;
    for (k = 0; k < report->history_count; k++) {
        x[k + 1] = k + 1.0;
        y[k + 1] = 100.0 * report->history[k];
    }
    line.name = "relative RMS error";
    line.x = x;
    line.y = y;
    line.count = (size_t)report->history_count + 1;
    return sqffd_export_svg_plot_stream(f, name, title ? title : "Error per iteration",
                                        "iteration (0: the starting model)", "relative RMS error (% of the diagonal)",
                                        &line, 1, NULL, 0, 0, err, err_size);
}

/* sqffd_export_svg_history_stream into a new file at `path`. */
static inline int sqffd_export_svg_history(const char *path, const sqffd_fit_report *report, const char *title,
                                           char *err, size_t err_size)
{
    FILE *f;
    int r;
    if (sqffd_export__history_check(path, report, err, err_size) || sqffd_export__create(path, &f, err, err_size))
        return 1;
    r = sqffd_export_svg_history_stream(f, path, report, title, err, err_size);
    return sqffd_export__close(f, path, r, err, err_size);
}

typedef struct sqffd_export__pair {
    double x, y;
} sqffd_export__pair;

static inline int sqffd_export__pair_order(const void *a, const void *b)
{
    double x = ((const sqffd_export__pair *)a)->x, y = ((const sqffd_export__pair *)b)->x;
    return x < y ? -1 : x > y;
}

static inline int sqffd_export__alpha_check(const char *name, const double *alpha, const double *error, size_t count,
                                            char *err, size_t err_size)
{
    size_t i;
    if (!alpha || !error || count == 0) return sqffd_io__fail(err, err_size, name, "no alpha values to plot");
    for (i = 0; i < count; i++)
        if (!(alpha[i] > 0.0) || !isfinite(alpha[i]))
            return sqffd_io__fail(err, err_size, name, "alpha[%llu] = %g: the log axis needs finite alpha > 0",
                                      (unsigned long long)i, alpha[i]);
    return 0;
}

/* The error against the spring weight alpha (the paper's Table 1): error[i]
   (relative RMS error, a fraction as in report.error.rms_relative; plotted
   in %) against alpha[i] on a log axis, in increasing alpha whatever the
   order given. alpha must be > 0. title NULL: "Error against the spring
   weight alpha" (in Greek). */
static inline int sqffd_export_svg_alpha_stream(FILE *f, const char *name, const double *alpha, const double *error,
                                                size_t count, const char *title, char *err, size_t err_size)
{
    sqffd_export__pair *pairs;
    double *xy;
    sqffd_export_series line;
    size_t i;
    int r;
    if (sqffd_export__alpha_check(name, alpha, error, count, err, err_size)) return 1;
    if (count > (size_t)-1 / (2 * sizeof *pairs)) return sqffd_io__fail(err, err_size, name, "too many values");
    pairs = (sqffd_export__pair *)malloc(count * sizeof *pairs);
    xy = (double *)malloc(2 * count * sizeof *xy);
    if (!pairs || !xy) {
        free(pairs);
        free(xy);
        return sqffd_io__fail(err, err_size, name, "out of memory");
    }
    for (i = 0; i < count; i++) {
        pairs[i].x = alpha[i];
        pairs[i].y = 100.0 * error[i];
    }
    qsort(pairs, count, sizeof *pairs, sqffd_export__pair_order);
    for (i = 0; i < count; i++) {
        xy[i] = pairs[i].x;
        xy[count + i] = pairs[i].y;
    }
    line.name = "relative RMS error";
    line.x = xy;
    line.y = xy + count;
    line.count = count;
    r = sqffd_export_svg_plot_stream(f, name, title ? title : "Error against the spring weight \xce\xb1",
                                     "spring weight \xce\xb1", "relative RMS error (% of the diagonal)", &line, 1,
                                     NULL, 0, SQFFD_EXPORT_LOG_X, err, err_size);
    free(pairs);
    free(xy);
    return r;
}

/* sqffd_export_svg_alpha_stream into a new file at `path`. */
static inline int sqffd_export_svg_alpha(const char *path, const double *alpha, const double *error, size_t count,
                                         const char *title, char *err, size_t err_size)
{
    FILE *f;
    int r;
    if (sqffd_export__alpha_check(path, alpha, error, count, err, err_size) ||
        sqffd_export__create(path, &f, err, err_size))
        return 1;
    r = sqffd_export_svg_alpha_stream(f, path, alpha, error, count, title, err, err_size);
    return sqffd_export__close(f, path, r, err, err_size);
}

static inline int sqffd_export__volumes_check(const char *name, const double *volumes, size_t frames,
                                              const sqffd_motion_report *motion, char *err, size_t err_size)
{
    if (!volumes || frames == 0) return sqffd_io__fail(err, err_size, name, "no volumes to plot");
    if (motion && (motion->ed_frame >= frames || motion->es_frame >= frames))
        return sqffd_io__fail(err, err_size, name, "the motion report's ED frame %llu or ES frame %llu is not one of the %llu frames",
                                  (unsigned long long)motion->ed_frame, (unsigned long long)motion->es_frame,
                                  (unsigned long long)frames);
    return 0;
}

/* The volume curve of a sequence: volumes[t] against frame t; with a motion
   report (may be NULL) ED and ES marked on the curve and the ejection
   fraction in the default title. volume_unit (may be NULL) completes the
   y label, "volume (ml)". title NULL: "Volume over the sequence". */
static inline int sqffd_export_svg_volumes_stream(FILE *f, const char *name, const double *volumes, size_t frames,
                                                  const sqffd_motion_report *motion, const char *volume_unit,
                                                  const char *title, char *err, size_t err_size)
{
    char default_title[96], y_label[96];
    sqffd_export_series line;
    sqffd_export_mark marks[2];
    if (sqffd_export__volumes_check(name, volumes, frames, motion, err, err_size)) return 1;
    if (motion && isfinite(motion->ejection_fraction))
        snprintf(default_title, sizeof default_title, "Volume over the sequence (EF %.1f%%)",
                 100.0 * motion->ejection_fraction);
    else snprintf(default_title, sizeof default_title, "Volume over the sequence");
    if (volume_unit && *volume_unit) snprintf(y_label, sizeof y_label, "volume (%.80s)", volume_unit);
    else snprintf(y_label, sizeof y_label, "volume");
    line.name = "volume";
    line.x = NULL;
    line.y = volumes;
    line.count = frames;
    if (motion) {
        marks[0].x = (double)motion->ed_frame;
        marks[0].y = volumes[motion->ed_frame];
        marks[0].label = "ED";
        marks[1].x = (double)motion->es_frame;
        marks[1].y = volumes[motion->es_frame];
        marks[1].label = "ES";
    }
    return sqffd_export_svg_plot_stream(f, name, title ? title : default_title, "frame", y_label, &line, 1,
                                        motion ? marks : NULL, motion ? 2 : 0, 0, err, err_size);
}

/* sqffd_export_svg_volumes_stream into a new file at `path`. */
static inline int sqffd_export_svg_volumes(const char *path, const double *volumes, size_t frames,
                                           const sqffd_motion_report *motion, const char *volume_unit,
                                           const char *title, char *err, size_t err_size)
{
    FILE *f;
    int r;
    if (sqffd_export__volumes_check(path, volumes, frames, motion, err, err_size) ||
        sqffd_export__create(path, &f, err, err_size))
        return 1;
    r = sqffd_export_svg_volumes_stream(f, path, volumes, frames, motion, volume_unit, title, err, err_size);
    return sqffd_export__close(f, path, r, err, err_size);
}

/* ---- SVG: the 17-segment bull's-eye -------------------------------------- */

/* The colour map's control colours, evenly spaced from t = 0 to t = 1: a
   viridis-like ramp (dark blue-violet to yellow), ordered in lightness so
   that it reads in grey too. */
#define SQFFD_EXPORT_COLORMAP_STOPS 5
static inline const unsigned char *sqffd_export__colormap_stop(int k)
{
    static const unsigned char stops[SQFFD_EXPORT_COLORMAP_STOPS][3] = {
        {68, 1, 84}, {59, 82, 139}, {33, 145, 140}, {94, 201, 98}, {253, 231, 37}};
    return stops[k];
}

/* The bull's-eye's colour of t in [0, 1] (clamped; NaN as 0): linear
   between the control colours, each channel rounded to the nearest. */
static inline void sqffd_export_colormap(double t, unsigned char rgb[3])
{
    double position;
    int k, c;
    if (!(t > 0.0)) t = 0.0;
    if (t > 1.0) t = 1.0;
    position = t * (SQFFD_EXPORT_COLORMAP_STOPS - 1);
    k = (int)floor(position);
    if (k > SQFFD_EXPORT_COLORMAP_STOPS - 2) k = SQFFD_EXPORT_COLORMAP_STOPS - 2;
    position -= k;
    for (c = 0; c < 3; c++) {
        double a = sqffd_export__colormap_stop(k)[c], b = sqffd_export__colormap_stop(k + 1)[c];
        rgb[c] = (unsigned char)floor(a + position * (b - a) + 0.5);
    }
}

/* The bull's-eye's canvas: centre, ring radii (apex disc, apical, mid, basal). */
#define SQFFD_EXPORT__EYE_WIDTH 600
#define SQFFD_EXPORT__EYE_HEIGHT 500
#define SQFFD_EXPORT__EYE_CX 240.0
#define SQFFD_EXPORT__EYE_CY 262.0
#define SQFFD_EXPORT__EYE_RING 45.0 /* each ring's width; the disc's radius */
#define SQFFD_EXPORT__PI 3.14159265358979323846

/* The screen point at radius r and angle theta (radians, counter-clockwise
   on screen from the top: 0 is up, pi/2 is left). */
static inline void sqffd_export__polar(double r, double theta, double *x, double *y)
{
    *x = SQFFD_EXPORT__EYE_CX - r * sin(theta);
    *y = SQFFD_EXPORT__EYE_CY - r * cos(theta);
}

/* Segment k (1..17): inner and outer radius, centre angle and half width. */
static inline void sqffd_export__segment_shape(int k, double *r0, double *r1, double *centre, double *half)
{
    const double ring = SQFFD_EXPORT__EYE_RING, degree = SQFFD_EXPORT__PI / 180.0;
    int ring_index = k <= 6 ? 3 : k <= 12 ? 2 : k <= 16 ? 1 : 0;
    *r0 = ring_index ? ring * ring_index : 0.0;
    *r1 = ring * (ring_index + 1);
    if (k <= 12) { /* basal 1-6, mid 7-12: 60 degrees each, 1 and 7 (anterior) at the top */
        *centre = 60.0 * ((k - 1) % 6) * degree;
        *half = 30.0 * degree;
    } else if (k <= 16) { /* apical: 13 anterior, 14 septal, 15 inferior, 16 lateral */
        *centre = 90.0 * (k - 13) * degree;
        *half = 45.0 * degree;
    } else {
        *centre = 0.0;
        *half = SQFFD_EXPORT__PI;
    }
}

/* The outline of segment k as SVG path data: an annular sector (outer arc
   counter-clockwise on screen, SVG sweep-flag 0; inner arc back), or for 17
   the disc as two half circles. */
static inline void sqffd_export__segment_path(FILE *f, int k)
{
    double r0, r1, centre, half, x0, y0, x1, y1, x2, y2, x3, y3;
    sqffd_export__segment_shape(k, &r0, &r1, &centre, &half);
    if (k == 17) {
        fprintf(f, "M %.3f %.3f A %.3f %.3f 0 1 0 %.3f %.3f A %.3f %.3f 0 1 0 %.3f %.3f Z", SQFFD_EXPORT__EYE_CX - r1,
                SQFFD_EXPORT__EYE_CY, r1, r1, SQFFD_EXPORT__EYE_CX + r1, SQFFD_EXPORT__EYE_CY, r1, r1,
                SQFFD_EXPORT__EYE_CX - r1, SQFFD_EXPORT__EYE_CY);
        return;
    }
    sqffd_export__polar(r1, centre - half, &x0, &y0);
    sqffd_export__polar(r1, centre + half, &x1, &y1);
    sqffd_export__polar(r0, centre + half, &x2, &y2);
    sqffd_export__polar(r0, centre - half, &x3, &y3);
    fprintf(f, "M %.3f %.3f A %.3f %.3f 0 0 0 %.3f %.3f L %.3f %.3f A %.3f %.3f 0 0 1 %.3f %.3f Z", x0, y0, r1, r1, x1,
            y1, x2, y2, r0, r0, x3, y3);
}

static inline int sqffd_export__bullseye_check(const char *name, const sqffd_motion_report *motion, int use_excursion,
                                               char *err, size_t err_size)
{
    int k;
    if (!motion) return sqffd_io__fail(err, err_size, name, "no motion report");
    for (k = 0; k < SQFFD_SEGMENTS; k++) {
        double v = use_excursion ? motion->segments[k].mean_excursion : motion->segments[k].mean_displacement;
        if (!isfinite(v) || fabs(v) > 1e300)
            return sqffd_io__fail(err, err_size, name, "segment %d: the mean %s is %s", k + 1,
                                      use_excursion ? "excursion" : "displacement",
                                      isfinite(v) ? "beyond +-1e300" : "not finite");
    }
    return 0;
}

/* What a bull's-eye shows: per AHA segment (index k: segment k + 1) a
   value, finite and within +-1e300, and a flag; the values' name, the
   flags' (one word: the flagged segments' class, their outline's and the
   key's), and a line under the title (NULL: none). */
typedef struct sqffd_export_segments {
    double value[SQFFD_SEGMENTS];
    int flag[SQFFD_SEGMENTS];
    const char *measure;   /* "mean displacement" */
    const char *flag_name; /* "hypokinetic" */
    const char *subtitle;
} sqffd_export_segments;

/* The AHA 17-segment bull's-eye (SVG 1.1, 600 x 500) of per-segment
   values: the apex disc (17) in the centre, the apical ring (13 anterior
   at the top, 14 septal left, 15 inferior at the bottom, 16 lateral right),
   the mid (7-12) and the basal ring (1-6) outside, six 60-degree sectors
   each with 1 and 7 (anterior) at the top and then counter-clockwise on
   screen: anteroseptal, inferoseptal, inferior, inferolateral,
   anterolateral. Each segment is a <path id="segment-K" class="segment">
   filled by its value through sqffd_export_colormap, scaled from 0 to the
   largest over the segments (values below 0 take the bottom colour; when
   none is above 0 the scale is 0..1), with its number and value as text;
   flagged segments get class "segment FLAG" and a thick red, hatched
   outline (class "FLAG-outline") drawn over the rings. A colour bar with
   ticks, labelled with the measure and `unit` (may be NULL, e.g. "mm"), a
   key for the outline, the title and the subtitle. */
static inline int sqffd_export_svg_segments_stream(FILE *f, const char *name, const sqffd_export_segments *s,
                                                   const char *title, const char *unit, char *err, size_t err_size)
{
    const double bar_x = 500.0, bar_w = 18.0, bar_top = 92.0, bar_bottom = 432.0, ring = SQFFD_EXPORT__EYE_RING;
    double scale = 0.0;
    char text[160];
    sqffd_export__axis bar;
    int k, c;
    if (!s || !s->measure || !s->flag_name || !title) return sqffd_io__fail(err, err_size, name, "no segments to show");
    for (k = 0; k < SQFFD_SEGMENTS; k++) {
        double v = s->value[k];
        if (!isfinite(v) || fabs(v) > 1e300)
            return sqffd_io__fail(err, err_size, name, "segment %d: the %s is %s", k + 1, s->measure,
                                  isfinite(v) ? "beyond +-1e300" : "not finite");
        if (v > scale) scale = v;
    }
    if (!(scale > 1e-300)) scale = 1.0;

    sqffd_export__svg_begin(f, SQFFD_EXPORT__EYE_WIDTH, SQFFD_EXPORT__EYE_HEIGHT, title);
    fputs("<defs>\n<pattern id=\"hatch\" patternUnits=\"userSpaceOnUse\" width=\"8\" height=\"8\">"
          "<path d=\"M -2 2 L 2 -2 M 0 8 L 8 0 M 6 10 L 10 6\" stroke=\"black\" stroke-opacity=\"0.45\" "
          "stroke-width=\"1.5\"/></pattern>\n<linearGradient id=\"colour-scale\" x1=\"0\" y1=\"1\" x2=\"0\" y2=\"0\">\n",
          f);
    for (k = 0; k < SQFFD_EXPORT_COLORMAP_STOPS; k++) {
        const unsigned char *rgb = sqffd_export__colormap_stop(k);
        fprintf(f, "<stop offset=\"%g\" stop-color=\"#%02x%02x%02x\"/>\n", (double)k / (SQFFD_EXPORT_COLORMAP_STOPS - 1),
                rgb[0], rgb[1], rgb[2]);
    }
    fputs("</linearGradient>\n</defs>\n", f);
    sqffd_export__svg_text(f, 0.5 * SQFFD_EXPORT__EYE_WIDTH, 30.0, "middle",
                           "class=\"title\" font-size=\"16\" font-weight=\"bold\"", title);
    if (s->subtitle)
        sqffd_export__svg_text(f, 0.5 * SQFFD_EXPORT__EYE_WIDTH, 52.0, "middle", "class=\"subtitle\" fill=\"#444444\"",
                               s->subtitle);

    /* the segments, then the flagged outlines over them (not hidden by their neighbours) */
    fputs("<g class=\"segments\" stroke=\"white\" stroke-width=\"1.5\">\n", f);
    for (k = 1; k <= SQFFD_SEGMENTS; k++) {
        unsigned char rgb[3];
        sqffd_export_colormap(s->value[k - 1] / scale, rgb);
        fprintf(f, "<path id=\"segment-%d\" class=\"segment%s%s\" fill=\"#%02x%02x%02x\" d=\"", k,
                s->flag[k - 1] ? " " : "", s->flag[k - 1] ? s->flag_name : "", rgb[0], rgb[1], rgb[2]);
        sqffd_export__segment_path(f, k);
        fputs("\"/>\n", f);
    }
    fprintf(f, "</g>\n<g class=\"%s-outlines\" fill=\"url(#hatch)\" stroke=\"#e4002b\" stroke-width=\"3.5\" "
               "stroke-linejoin=\"round\">\n", s->flag_name);
    for (k = 1; k <= SQFFD_SEGMENTS; k++) {
        if (!s->flag[k - 1]) continue;
        fprintf(f, "<path class=\"%s-outline\" d=\"", s->flag_name);
        sqffd_export__segment_path(f, k);
        fputs("\"/>\n", f);
    }
    fputs("</g>\n<g class=\"segment-labels\" text-anchor=\"middle\">\n", f);
    for (k = 1; k <= SQFFD_SEGMENTS; k++) {
        double r0, r1, centre, half, x, y;
        unsigned char rgb[3];
        const char *ink;
        sqffd_export__segment_shape(k, &r0, &r1, &centre, &half);
        sqffd_export__polar(k == 17 ? 0.0 : 0.5 * (r0 + r1), centre, &x, &y);
        sqffd_export_colormap(s->value[k - 1] / scale, rgb);
        /* white on the dark end of the map, black on the light end */
        ink = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2] < 128.0 ? "white" : "black";
        fprintf(f, "<text x=\"%.2f\" y=\"%.2f\" fill=\"%s\" font-size=\"13\" font-weight=\"bold\">%d</text>\n", x,
                y - 2.0, ink, k);
        fprintf(f, "<text x=\"%.2f\" y=\"%.2f\" fill=\"%s\" font-size=\"11\">%.3g</text>\n", x, y + 12.0, ink,
                s->value[k - 1]);
    }
    fputs("</g>\n<g class=\"orientation\" fill=\"#444444\" font-style=\"italic\">\n", f);
    sqffd_export__svg_text(f, SQFFD_EXPORT__EYE_CX, SQFFD_EXPORT__EYE_CY - 4.0 * ring - 8.0, "middle", "", "anterior");
    sqffd_export__svg_text(f, SQFFD_EXPORT__EYE_CX, SQFFD_EXPORT__EYE_CY + 4.0 * ring + 18.0, "middle", "", "inferior");
    sqffd_export__svg_text(f, SQFFD_EXPORT__EYE_CX - 4.0 * ring - 8.0, SQFFD_EXPORT__EYE_CY + 4.0, "end", "", "septal");
    sqffd_export__svg_text(f, SQFFD_EXPORT__EYE_CX + 4.0 * ring + 8.0, SQFFD_EXPORT__EYE_CY + 4.0, "start", "", "lateral");
    fputs("</g>\n", f);

    /* the colour bar: 0 at the bottom, the scale's top at the top */
    fprintf(f, "<g class=\"colour-bar\">\n<rect x=\"%.2f\" y=\"%.2f\" width=\"%.2f\" height=\"%.2f\" "
               "fill=\"url(#colour-scale)\" stroke=\"#444444\"/>\n",
            bar_x, bar_top, bar_w, bar_bottom - bar_top);
    sqffd_export__axis_init(&bar, 0.0, scale, 0);
    for (k = 0; k < bar.tick_count; k++) {
        double y;
        if (bar.tick[k] < 0.0) continue;
        if (bar.tick[k] > scale * (1.0 + 1e-9)) break;
        y = bar_bottom - (bar_bottom - bar_top) * bar.tick[k] / scale;
        fprintf(f, "<line x1=\"%.2f\" y1=\"%.2f\" x2=\"%.2f\" y2=\"%.2f\" stroke=\"#444444\"/>\n", bar_x + bar_w, y,
                bar_x + bar_w + 5.0, y);
        fprintf(f, "<text x=\"%.2f\" y=\"%.2f\">", bar_x + bar_w + 8.0, y + 4.0);
        sqffd_export__tick_label(f, &bar, bar.tick[k]);
        fputs("</text>\n", f);
    }
    if (unit && *unit) snprintf(text, sizeof text, "%.60s (%.80s)", s->measure, unit);
    else snprintf(text, sizeof text, "%.150s", s->measure);
    fprintf(f, "<text class=\"colour-bar-label\" font-size=\"13\" text-anchor=\"middle\" "
               "transform=\"translate(%.2f %.2f) rotate(-90)\">",
            bar_x - 10.0, 0.5 * (bar_top + bar_bottom));
    sqffd_export__xml(f, text);
    fputs("</text>\n</g>\n", f);

    /* the key to the outline */
    c = 0;
    for (k = 0; k < SQFFD_SEGMENTS; k++) c += s->flag[k] != 0;
    fprintf(f, "<g class=\"key\">\n<rect x=\"20\" y=\"474\" width=\"22\" height=\"14\" fill=\"url(#hatch)\" "
               "stroke=\"#e4002b\" stroke-width=\"3\"/>\n");
    snprintf(text, sizeof text, "%.100s (%d of 17 segments)", s->flag_name, c);
    sqffd_export__svg_text(f, 52.0, 486.0, "start", "", text);
    fputs("</g>\n</svg>\n", f);
    return sqffd_export__flush(f, name, err, err_size);
}


/* The bull's-eye of a motion report (sqffd_export_svg_segments_stream):
   each segment's mean displacement (or, use_excursion non-zero, its mean
   inward excursion: outward motion takes the bottom colour), hypokinetic
   segments flagged, and EF, EDV and ESV under the title (title NULL: a
   default naming the measure). */
static inline int sqffd_export_svg_bullseye_stream(FILE *f, const char *name, const sqffd_motion_report *motion,
                                                   int use_excursion, const char *title, const char *unit, char *err,
                                                   size_t err_size)
{
    sqffd_export_segments s;
    char subtitle[160];
    int k;
    if (sqffd_export__bullseye_check(name, motion, use_excursion, err, err_size)) return 1;
    for (k = 0; k < SQFFD_SEGMENTS; k++) {
        s.value[k] = use_excursion ? motion->segments[k].mean_excursion : motion->segments[k].mean_displacement;
        s.flag[k] = motion->segments[k].hypokinetic;
    }
    s.measure = use_excursion ? "mean inward excursion" : "mean displacement";
    s.flag_name = "hypokinetic";
    s.subtitle = NULL;
    if (isfinite(motion->ejection_fraction)) {
        snprintf(subtitle, sizeof subtitle, "EF %.1f%%   EDV %.6g   ESV %.6g   (ED frame %llu, ES frame %llu)",
                 100.0 * motion->ejection_fraction, motion->edv, motion->esv, (unsigned long long)motion->ed_frame,
                 (unsigned long long)motion->es_frame);
        s.subtitle = subtitle;
    }
    if (!title)
        title = use_excursion ? "Mean inward excursion per segment, ED to ES" : "Mean displacement per segment, ED to ES";
    return sqffd_export_svg_segments_stream(f, name, &s, title, unit, err, err_size);
}

/* sqffd_export_svg_bullseye_stream into a new file at `path`. */
static inline int sqffd_export_svg_bullseye(const char *path, const sqffd_motion_report *motion, int use_excursion,
                                            const char *title, const char *unit, char *err, size_t err_size)
{
    FILE *f;
    int r;
    if (sqffd_export__bullseye_check(path, motion, use_excursion, err, err_size) ||
        sqffd_export__create(path, &f, err, err_size))
        return 1;
    r = sqffd_export_svg_bullseye_stream(f, path, motion, use_excursion, title, unit, err, err_size);
    return sqffd_export__close(f, path, r, err, err_size);
}

#endif /* SQFFD_EXPORT_H */

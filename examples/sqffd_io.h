/* sqffd_io.h - point-cloud and mesh files for the sqffd tools (not part of the library).

   Header-only, every function `static inline`; plain C99 plus the C library
   (stdio, stdlib) and sqffd_inflate.h beside it. Independent of sqffd.h.

   Reading: XYZ, PLY (ascii, binary_little_endian, binary_big_endian), OFF,
   the vertices of Wavefront OBJ, PCD (the Point Cloud Library's format:
   ascii, binary, binary_compressed), the POINTS of legacy VTK POLYDATA,
   UNSTRUCTURED_GRID and STRUCTURED_GRID files (ASCII and BINARY), and the
   vertices of STL (ASCII and binary), each shared vertex once.
   Every reader takes a memory buffer and its size, checks every count and
   offset against that size before using or allocating anything, and returns
     0  with *points = malloc'd x y z triples (free() them) and *count, or
     1  with *points = NULL, *count = 0 and a message "NAME: what is wrong"
        in err (NAME is the file name the caller passed, for messages only).
   A file that holds no points is an error; so are NaN and infinite
   coordinates, except that a PCD point with a NaN coordinate (PCL's mark
   of an invalid depth pixel) is dropped and counted in sqffd_io_info
   (sqffd_io_read_points_info, sqffd_io_read_file_info). gzip-compressed input (any of these formats) is decompressed
   first, with sqffd_inflate.h, up to SQFFD_IO_MAX_FILE_SIZE bytes (the
   format then comes from the content, or the name without its .gz).
   A file of a format no reader here takes (DICOM, INRIMAGE, Analyze
   7.5, HDF5, zip) is refused with one sentence that names it and says what
   to do (sqffd_io_foreign_format); binary bytes in what would be read as
   XYZ make it "not a text point file".
   Element indices in messages count from 0 (like PLY face
   indices), line numbers from 1. Coordinates keep the precision of their
   source: a PLY float property gives a float's value, in ascii files too.
   sqffd_io_read_off_mesh also reads an OFF file's faces, as triangles.

   Writing: PLY (binary little endian, or ascii) of a point set or a triangle
   mesh, float x y z plus up to SQFFD_IO_MAX_SCALARS per-vertex float
   scalars, faces as `property list uchar int vertex_indices` (the PLY
   spec's classic type names, read by VTK/ParaView, MeshLab, CloudCompare). */
#ifndef SQFFD_IO_H
#define SQFFD_IO_H

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sqffd_inflate.h"

/* sqffd_io_read_file refuses larger files, and larger decompressed data. */
#define SQFFD_IO_MAX_FILE_SIZE ((size_t)1 << 31)
/* The writer's limit on per-vertex scalars. */
#define SQFFD_IO_MAX_SCALARS 16

typedef enum sqffd_io_format {
    SQFFD_IO_XYZ = 0,
    SQFFD_IO_PLY = 1,
    SQFFD_IO_OFF = 2,
    SQFFD_IO_OBJ = 3,
    SQFFD_IO_PCD = 4,
    SQFFD_IO_VTK = 5,
    SQFFD_IO_STL = 6
} sqffd_io_format;

/* A PCD file's header, as sqffd_io_read_pcd read it. */
typedef struct sqffd_io_pcd_header {
    char version[8];        /* "0.7" or "0.6" (".7" reads as "0.7"); "" when the file has no VERSION line */
    const char *encoding;   /* "ascii", "binary" or "binary_compressed" */
    char fields[256];       /* each field as NAME TYPE SIZE [xCOUNT]: "x F4, y F4, z F4, rgba U4" ("..." when cut) */
    uint64_t width, height; /* height > 1: an organised cloud, an image of width x height pixels */
    uint64_t points;        /* POINTS, invalid (NaN) points included */
    double viewpoint[7];    /* VIEWPOINT tx ty tz qw qx qy qz (0 0 0 1 0 0 0 when absent); not applied */
} sqffd_io_pcd_header;

/* What a read found besides the points; filled on success. */
typedef struct sqffd_io_info {
    sqffd_io_format format;  /* the format read */
    int gzip;                /* the file was gzip-compressed */
    size_t dropped_nan;      /* PCD points left out for a NaN coordinate (invalid depth); other formats refuse NaN */
    sqffd_io_pcd_header pcd; /* format SQFFD_IO_PCD: its header */
    int binary;              /* VTK, STL: binary (else ASCII) */
    char vtk_version[8];     /* VTK: the header's version ("3.0", "5.1", ...) */
    char vtk_dataset[24];    /* VTK: POLYDATA, UNSTRUCTURED_GRID or STRUCTURED_GRID */
    size_t stl_triangles;    /* STL: the triangles, whose 3 vertices each, merged, are the points */
} sqffd_io_info;

/* One per-vertex scalar for the writer: `name` becomes a float property. */
typedef struct sqffd_io_scalar {
    const char *name;
    const double *values; /* one per vertex */
} sqffd_io_scalar;

/* ---- messages ------------------------------------------------------------ */

#if defined(__GNUC__)
static inline int sqffd_io__fail(char *err, size_t err_size, const char *name, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
#endif
/* Writes "NAME: message" into err; returns 1 so readers can `return sqffd_io__fail(...)`. */
static inline int sqffd_io__fail(char *err, size_t err_size, const char *name, const char *fmt, ...)
{
    va_list ap;
    size_t used;
    if (!err || err_size == 0) return 1;
    snprintf(err, err_size, "%s: ", name ? name : "input");
    used = strlen(err);
    va_start(ap, fmt);
    vsnprintf(err + used, err_size - used, fmt, ap);
    va_end(ap);
    return 1;
}

/* A token quoted for a message: at most 24 characters, unprintable bytes as '?'. */
static inline const char *sqffd_io__quote(const char *text, size_t len, char out[32])
{
    size_t i, n = len > 24 ? 24 : len;
    out[0] = '\'';
    for (i = 0; i < n; i++) {
        unsigned char c = (unsigned char)text[i];
        out[i + 1] = (char)(c >= 32 && c < 127 ? c : '?');
    }
    if (len > n) { out[n + 1] = '.'; out[n + 2] = '.'; out[n + 3] = '.'; n += 3; }
    out[n + 1] = '\'';
    out[n + 2] = '\0';
    return out;
}

/* ---- numbers and tokens -------------------------------------------------- */

enum { SQFFD_IO__NUMBER = 0, SQFFD_IO__NOT_NUMBER = 1, SQFFD_IO__NOT_FINITE = 2 };

/* Parses exactly [text, text + len) as a double (strtod on a bounded copy:
   the buffer is not NUL-terminated). NaN, infinities and overflow are
   SQFFD_IO__NOT_FINITE (with the value in *out, so a caller can tell NaN
   from infinity). */
static inline int sqffd_io__parse_double(const char *text, size_t len, double *out)
{
    char buf[128];
    char *stop;
    double v;
    if (len == 0 || len >= sizeof buf) return SQFFD_IO__NOT_NUMBER;
    memcpy(buf, text, len);
    buf[len] = '\0';
    v = strtod(buf, &stop);
    if (stop != buf + len) return SQFFD_IO__NOT_NUMBER;
    *out = v;
    return isfinite(v) ? SQFFD_IO__NUMBER : SQFFD_IO__NOT_FINITE;
}

/* Parses exactly [text, text + len) as an unsigned decimal integer; 0 on success. */
static inline int sqffd_io__parse_count(const char *text, size_t len, uint64_t *out)
{
    uint64_t v = 0;
    size_t i;
    if (len == 0) return 1;
    for (i = 0; i < len; i++) {
        unsigned digit = (unsigned)((unsigned char)text[i] - '0');
        if (digit > 9) return 1;
        if (v > (UINT64_MAX - digit) / 10) return 1;
        v = v * 10 + digit;
    }
    *out = v;
    return 0;
}

static inline int sqffd_io__is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f';
}

/* Whether [text, text + len) is `word`, ignoring the case of ASCII letters. */
static inline int sqffd_io__is(const char *text, size_t len, const char *word)
{
    size_t i;
    if (strlen(word) != len) return 0;
    for (i = 0; i < len; i++) {
        int a = (unsigned char)text[i], b = (unsigned char)word[i];
        if (a >= 'A' && a <= 'Z') a += 'a' - 'A';
        if (b >= 'A' && b <= 'Z') b += 'a' - 'A';
        if (a != b) return 0;
    }
    return 1;
}

/* A cursor over text, for the line-oriented formats (XYZ, OFF, PLY header)
   and the whitespace-separated token stream of an ascii PLY body. */
typedef struct sqffd_io__text {
    const char *p, *end;
    unsigned long long line; /* line of p, from 1 */
} sqffd_io__text;

/* The next content line: skips blank lines and '#' comments; the line is
   [*start, *stop) with any trailing comment cut off. 0 at the end of the text. */
static inline int sqffd_io__next_line(sqffd_io__text *t, const char **start, const char **stop)
{
    while (t->p < t->end) {
        const char *s = t->p, *e, *hash;
        const char *nl = (const char *)memchr(s, '\n', (size_t)(t->end - s));
        e = nl ? nl : t->end;
        t->p = nl ? nl + 1 : t->end;
        hash = (const char *)memchr(s, '#', (size_t)(e - s));
        if (hash) e = hash;
        while (s < e && sqffd_io__is_space(*s)) s++;
        t->line++;
        if (s < e) {
            *start = s;
            *stop = e;
            return 1;
        }
    }
    return 0;
}

/* The next token of a line [*p, stop); separators are blanks and commas. */
static inline int sqffd_io__line_token(const char **p, const char *stop, const char **tok, size_t *len)
{
    const char *s = *p, *e;
    while (s < stop && (sqffd_io__is_space(*s) || *s == ',')) s++;
    if (s == stop) { *p = s; return 0; }
    e = s;
    while (e < stop && !sqffd_io__is_space(*e) && *e != ',') e++;
    *tok = s;
    *len = (size_t)(e - s);
    *p = e;
    return 1;
}

/* The next whitespace-separated token anywhere (ascii PLY body), counting lines. */
static inline int sqffd_io__token(sqffd_io__text *t, const char **tok, size_t *len)
{
    const char *s = t->p;
    while (s < t->end && sqffd_io__is_space(*s)) {
        if (*s == '\n') t->line++;
        s++;
    }
    t->p = s;
    if (s == t->end) return 0;
    while (t->p < t->end && !sqffd_io__is_space(*t->p)) t->p++;
    *tok = s;
    *len = (size_t)(t->p - s);
    return 1;
}

/* The x y z of one point from the first three tokens of [s, e); extra
   tokens are ignored. `what` names the point for messages ("line 7",
   "vertex 3 (line 9)"). */
static inline int sqffd_io__line_xyz(const char *s, const char *e, double xyz[3], const char *name,
                                     const char *what, char *err, size_t err_size)
{
    int k;
    for (k = 0; k < 3; k++) {
        const char *tok;
        size_t len;
        char q[32];
        int r;
        if (!sqffd_io__line_token(&s, e, &tok, &len))
            return sqffd_io__fail(err, err_size, name, "%s: expected 3 numbers (x y z), found %d", what, k);
        r = sqffd_io__parse_double(tok, len, &xyz[k]);
        if (r == SQFFD_IO__NOT_FINITE)
            return sqffd_io__fail(err, err_size, name, "%s: %s is not a finite number", what,
                                  sqffd_io__quote(tok, len, q));
        if (r != SQFFD_IO__NUMBER)
            return sqffd_io__fail(err, err_size, name, "%s: expected a number, found %s", what,
                                  sqffd_io__quote(tok, len, q));
    }
    return 0;
}

/* ---- the output array ---------------------------------------------------- */

typedef struct sqffd_io__points {
    double *xyz;
    size_t count, capacity;
} sqffd_io__points;

/* Room for `capacity` points; 0 on success. */
static inline int sqffd_io__reserve(sqffd_io__points *pts, size_t capacity)
{
    double *grown;
    if (capacity <= pts->capacity) return 0;
    if (capacity > (size_t)-1 / (3 * sizeof(double))) return 1;
    grown = (double *)realloc(pts->xyz, capacity * 3 * sizeof(double));
    if (!grown) return 1;
    pts->xyz = grown;
    pts->capacity = capacity;
    return 0;
}

/* Hands the points to the caller, or frees them and reports an empty file. */
static inline int sqffd_io__finish(sqffd_io__points *pts, double **points, size_t *count, const char *name,
                                   char *err, size_t err_size)
{
    if (pts->count == 0) {
        free(pts->xyz);
        return sqffd_io__fail(err, err_size, name, "holds no points");
    }
    *points = pts->xyz;
    *count = pts->count;
    return 0;
}

/* ---- XYZ ----------------------------------------------------------------- */

/* Reads one point per line from the lines that carry one: every line for
   XYZ, the "v" statements for OBJ (obj_vertices non-zero), whose x y z come
   first after the keyword; blank lines and '#' comments are skipped. */
static inline int sqffd_io__read_point_lines(const void *data, size_t size, int obj_vertices, const char *name,
                                             double **points, size_t *count, char *err, size_t err_size)
{
    sqffd_io__text t;
    sqffd_io__points pts = {NULL, 0, 0};
    const char *s, *e, *tok;
    size_t len;
    *points = NULL;
    *count = 0;
    t.p = (const char *)data;
    t.end = t.p + size;
    t.line = 0;
    while (sqffd_io__next_line(&t, &s, &e)) {
        char what[48];
        if (obj_vertices && (!sqffd_io__line_token(&s, e, &tok, &len) || len != 1 || tok[0] != 'v')) continue;
        if (pts.count == pts.capacity &&
            sqffd_io__reserve(&pts, pts.capacity ? 2 * pts.capacity : 1024)) {
            free(pts.xyz);
            return sqffd_io__fail(err, err_size, name, "out of memory at line %llu", t.line);
        }
        snprintf(what, sizeof what, "line %llu", t.line);
        if (sqffd_io__line_xyz(s, e, pts.xyz + 3 * pts.count, name, what, err, err_size)) {
            free(pts.xyz);
            return 1;
        }
        pts.count++;
    }
    return sqffd_io__finish(&pts, points, count, name, err, err_size);
}

/* XYZ: one point per line, x y z first (blanks or commas between), extra
   columns ignored, blank lines and '#' comments skipped. A control byte
   other than white space (NUL, ...) anywhere makes it "not a text point
   file": the XYZ reader is where unrecognised files end up. */
static inline int sqffd_io_read_xyz(const void *data, size_t size, const char *name, double **points,
                                    size_t *count, char *err, size_t err_size)
{
    const unsigned char *b = (const unsigned char *)data;
    unsigned long long line = 1;
    size_t i;
    for (i = 0; i < size; i++) {
        if (b[i] == '\n') line++;
        else if ((b[i] < 32 && !sqffd_io__is_space((char)b[i])) || b[i] == 127) {
            *points = NULL;
            *count = 0;
            return sqffd_io__fail(err, err_size, name, "not a text point file (binary byte 0x%02x at line %llu)",
                                  b[i], line);
        }
    }
    return sqffd_io__read_point_lines(data, size, 0, name, points, count, err, err_size);
}

/* ---- OFF ----------------------------------------------------------------- */

/* "OFF" with the optional prefixes ST (texture), C (colour), N (normal);
   4OFF and nOFF (other dimensions) are recognised so they can be refused. */
static inline int sqffd_io__off_keyword(const char *tok, size_t len, int *other_dimension)
{
    size_t i = 0;
    if (len >= 2 && tok[0] == 'S' && tok[1] == 'T') i = 2;
    if (i < len && tok[i] == 'C') i++;
    if (i < len && tok[i] == 'N') i++;
    *other_dimension = i < len && (tok[i] == '4' || tok[i] == 'n');
    if (*other_dimension) i++;
    return len - i == 3 && memcmp(tok + i, "OFF", 3) == 0;
}

/* Triangles as vertex index triples, the output of the OFF mesh reader. */
typedef struct sqffd_io__triangles {
    uint32_t *index;
    size_t count, capacity;
} sqffd_io__triangles;

/* Appends the triangle (a, b, c); 0 on success. */
static inline int sqffd_io__add_triangle(sqffd_io__triangles *tris, uint32_t a, uint32_t b, uint32_t c)
{
    if (tris->count == tris->capacity) {
        size_t capacity = tris->capacity ? 2 * tris->capacity : 1024;
        uint32_t *grown;
        if (capacity > (size_t)-1 / (3 * sizeof(uint32_t))) return 1;
        grown = (uint32_t *)realloc(tris->index, capacity * 3 * sizeof(uint32_t));
        if (!grown) return 1;
        tris->index = grown;
        tris->capacity = capacity;
    }
    tris->index[3 * tris->count] = a;
    tris->index[3 * tris->count + 1] = b;
    tris->index[3 * tris->count + 2] = c;
    tris->count++;
    return 0;
}

/* The OFF parser behind both OFF readers: keyword, counts line "vertices
   faces [edges]" (may follow the keyword on its line), then one vertex per
   line (first three numbers; colours and normals after them ignored) into
   pts. With tris non-NULL, then one face per line, "n i0 ... i(n-1)"
   (colours after the indices ignored), as the fan of triangles
   (i0, i(k-1), ik), k = 2 .. n-1; with tris NULL the faces are not read.
   On failure the caller frees pts->xyz and tris->index. */
static inline int sqffd_io__read_off(const void *data, size_t size, const char *name, sqffd_io__points *pts,
                                     sqffd_io__triangles *tris, char *err, size_t err_size)
{
    sqffd_io__text t;
    const char *s, *e, *tok;
    size_t len, remaining;
    uint64_t counts[2], i;
    int other_dimension, k;
    char q[32];
    t.p = (const char *)data;
    t.end = t.p + size;
    t.line = 0;
    if (!sqffd_io__next_line(&t, &s, &e) || !sqffd_io__line_token(&s, e, &tok, &len) ||
        !sqffd_io__off_keyword(tok, len, &other_dimension))
        return sqffd_io__fail(err, err_size, name, "not an OFF file: the first word is not OFF");
    if (other_dimension)
        return sqffd_io__fail(err, err_size, name, "%s: only 3-D OFF files are supported",
                              sqffd_io__quote(tok, len, q));
    if (!sqffd_io__line_token(&s, e, &tok, &len)) { /* counts on their own line */
        if (!sqffd_io__next_line(&t, &s, &e))
            return sqffd_io__fail(err, err_size, name, "file ends before the counts line");
        if (!sqffd_io__line_token(&s, e, &tok, &len))
            return sqffd_io__fail(err, err_size, name, "line %llu: expected the vertex count", t.line);
    }
    for (k = 0; k < 2; k++) {
        if (k == 1 && !sqffd_io__line_token(&s, e, &tok, &len))
            return sqffd_io__fail(err, err_size, name, "line %llu: expected vertex and face counts", t.line);
        if (sqffd_io__parse_count(tok, len, &counts[k]))
            return sqffd_io__fail(err, err_size, name, "line %llu: %s is not a valid %s count", t.line,
                                  sqffd_io__quote(tok, len, q), k == 0 ? "vertex" : "face");
    }
    /* each vertex line holds at least "x y z" and a line break */
    remaining = (size_t)(t.end - t.p);
    if (counts[0] > (uint64_t)(remaining + 1) / 6)
        return sqffd_io__fail(err, err_size, name, "header says %llu vertices, file holds %llu bytes of data",
                              (unsigned long long)counts[0], (unsigned long long)remaining);
    if (sqffd_io__reserve(pts, (size_t)counts[0]))
        return sqffd_io__fail(err, err_size, name, "out of memory for %llu vertices", (unsigned long long)counts[0]);
    for (i = 0; i < counts[0]; i++) {
        char what[64];
        if (!sqffd_io__next_line(&t, &s, &e))
            return sqffd_io__fail(err, err_size, name, "file ends after %llu of %llu vertices",
                                  (unsigned long long)i, (unsigned long long)counts[0]);
        snprintf(what, sizeof what, "vertex %llu (line %llu)", (unsigned long long)i, t.line);
        if (sqffd_io__line_xyz(s, e, pts->xyz + 3 * i, name, what, err, err_size)) return 1;
        pts->count++;
    }
    if (!tris) return 0;
    if (counts[0] > UINT32_MAX)
        return sqffd_io__fail(err, err_size, name, "%llu vertices, more than 32-bit indices reach",
                              (unsigned long long)counts[0]);
    /* each face line holds at least "3 a b c" and a line break */
    remaining = (size_t)(t.end - t.p);
    if (counts[1] > (uint64_t)(remaining + 1) / 8)
        return sqffd_io__fail(err, err_size, name, "header says %llu faces, file holds %llu bytes after the vertices",
                              (unsigned long long)counts[1], (unsigned long long)remaining);
    for (i = 0; i < counts[1]; i++) {
        char what[64];
        uint64_t n, j, index, first = 0, previous = 0;
        if (!sqffd_io__next_line(&t, &s, &e))
            return sqffd_io__fail(err, err_size, name, "file ends after %llu of %llu faces", (unsigned long long)i,
                                  (unsigned long long)counts[1]);
        snprintf(what, sizeof what, "face %llu (line %llu)", (unsigned long long)i, t.line);
        if (!sqffd_io__line_token(&s, e, &tok, &len))
            return sqffd_io__fail(err, err_size, name, "%s: expected the face's vertex count", what);
        if (sqffd_io__parse_count(tok, len, &n))
            return sqffd_io__fail(err, err_size, name, "%s: %s is not a valid vertex count", what,
                                  sqffd_io__quote(tok, len, q));
        if (n < 3)
            return sqffd_io__fail(err, err_size, name, "%s: %llu vertices, a face needs at least 3", what,
                                  (unsigned long long)n);
        /* n is not trusted: the indices are read one by one up to the line's end */
        for (j = 0; j < n; j++) {
            if (!sqffd_io__line_token(&s, e, &tok, &len))
                return sqffd_io__fail(err, err_size, name, "%s: expected %llu vertex indices, found %llu", what,
                                      (unsigned long long)n, (unsigned long long)j);
            if (sqffd_io__parse_count(tok, len, &index))
                return sqffd_io__fail(err, err_size, name, "%s: %s is not a valid vertex index", what,
                                      sqffd_io__quote(tok, len, q));
            if (index >= counts[0])
                return sqffd_io__fail(err, err_size, name, "%s: vertex index %llu out of range (%llu vertices)",
                                      what, (unsigned long long)index, (unsigned long long)counts[0]);
            if (j == 0) first = index;
            if (j >= 2 && sqffd_io__add_triangle(tris, (uint32_t)first, (uint32_t)previous, (uint32_t)index))
                return sqffd_io__fail(err, err_size, name, "%s: out of memory", what);
            previous = index;
        }
    }
    return 0;
}

/* OFF: the vertices (see sqffd_io__read_off); faces are not read
   (sqffd_io_read_off_mesh reads them). */
static inline int sqffd_io_read_off(const void *data, size_t size, const char *name, double **points,
                                    size_t *count, char *err, size_t err_size)
{
    sqffd_io__points pts = {NULL, 0, 0};
    *points = NULL;
    *count = 0;
    if (sqffd_io__read_off(data, size, name, &pts, NULL, err, err_size)) {
        free(pts.xyz);
        return 1;
    }
    return sqffd_io__finish(&pts, points, count, name, err, err_size);
}

/* An OFF triangle mesh: the vertices as sqffd_io_read_off reads them, and
   the faces as triangles (three vertex indices each; a face of n > 3
   vertices becomes the n - 2 triangles of a fan from its first vertex),
   every index checked against the vertex count. Returns 0 with *vertices
   and *triangles malloc'd (free() both), or 1 with both NULL, both counts
   0 and a message. A file without vertices or without faces is an error. */
static inline int sqffd_io_read_off_mesh(const void *data, size_t size, const char *name, double **vertices,
                                         size_t *vertex_count, uint32_t **triangles, size_t *triangle_count,
                                         char *err, size_t err_size)
{
    sqffd_io__points pts = {NULL, 0, 0};
    sqffd_io__triangles tris = {NULL, 0, 0};
    *vertices = NULL;
    *vertex_count = 0;
    *triangles = NULL;
    *triangle_count = 0;
    if (sqffd_io__read_off(data, size, name, &pts, &tris, err, err_size)) {
        free(pts.xyz);
        free(tris.index);
        return 1;
    }
    if (sqffd_io__finish(&pts, vertices, vertex_count, name, err, err_size)) {
        free(tris.index);
        return 1;
    }
    if (tris.count == 0) {
        free(*vertices);
        *vertices = NULL;
        *vertex_count = 0;
        return sqffd_io__fail(err, err_size, name, "holds no faces");
    }
    *triangles = tris.index;
    *triangle_count = tris.count;
    return 0;
}

/* ---- OBJ ----------------------------------------------------------------- */

/* The first word of an OBJ statement that may start a file. */
static inline int sqffd_io__obj_keyword(const char *tok, size_t len)
{
    static const char *const words[] = {"v", "vn", "vt", "vp", "f", "l", "o", "g", "s", "mtllib", "usemtl"};
    size_t i;
    for (i = 0; i < sizeof words / sizeof words[0]; i++)
        if (strlen(words[i]) == len && memcmp(words[i], tok, len) == 0) return 1;
    return 0;
}

/* Wavefront OBJ: the "v x y z [w | r g b]" lines; every other statement
   (faces, normals, texture coordinates, groups, materials) is skipped. */
static inline int sqffd_io_read_obj(const void *data, size_t size, const char *name, double **points,
                                    size_t *count, char *err, size_t err_size)
{
    return sqffd_io__read_point_lines(data, size, 1, name, points, count, err, err_size);
}

/* ---- PLY ----------------------------------------------------------------- */

/* value as a float; beyond the float range it becomes an infinity (a plain
   cast would be undefined behaviour). */
static inline float sqffd_io__to_float(double value)
{
    if (value > FLT_MAX) return (float)HUGE_VAL;
    if (value < -FLT_MAX) return (float)-HUGE_VAL;
    return (float)value;
}

/* Binary value types; the 64-bit integers occur in PCD only. */
enum { SQFFD_IO__I8, SQFFD_IO__U8, SQFFD_IO__I16, SQFFD_IO__U16, SQFFD_IO__I32, SQFFD_IO__U32,
       SQFFD_IO__F32, SQFFD_IO__F64, SQFFD_IO__I64, SQFFD_IO__U64 };
enum { SQFFD_IO__PLY_ASCII, SQFFD_IO__PLY_LE, SQFFD_IO__PLY_BE };
#define SQFFD_IO__PLY_MAX_ELEMENTS 64
#define SQFFD_IO__PLY_MAX_PROPERTIES 1024

static inline size_t sqffd_io__type_size(int type)
{
    static const unsigned char sizes[] = {1, 1, 2, 2, 4, 4, 4, 8, 8, 8};
    return sizes[type];
}

/* A PLY scalar type name (both the classic names and the sized aliases); -1 if unknown. */
static inline int sqffd_io__ply_type(const char *tok, size_t len)
{
    static const char *const names[] = {"char", "int8", "uchar", "uint8", "short", "int16", "ushort", "uint16",
                                        "int", "int32", "uint", "uint32", "float", "float32", "double", "float64"};
    int i;
    for (i = 0; i < 16; i++)
        if (strlen(names[i]) == len && memcmp(names[i], tok, len) == 0) return i / 2;
    return -1;
}

typedef struct sqffd_io__ply_property {
    int type;       /* the scalar type, or the item type of a list */
    int count_type; /* the list's count type; -1 for a scalar */
    int role;       /* 0 skipped, 1..3: x, y, z of the vertex element */
} sqffd_io__ply_property;

typedef struct sqffd_io__ply_element {
    char name[32];
    uint64_t count;
    int first, properties; /* its properties in the header's property array */
} sqffd_io__ply_element;

typedef struct sqffd_io__ply {
    int format;
    int elements, properties, vertex; /* vertex: index of the vertex element, -1 if none */
    sqffd_io__ply_element element[SQFFD_IO__PLY_MAX_ELEMENTS];
    sqffd_io__ply_property property[SQFFD_IO__PLY_MAX_PROPERTIES];
    size_t data_offset; /* first byte after end_header */
} sqffd_io__ply;

/* Reads the header lines up to end_header into h; 0 on success. */
static inline int sqffd_io__ply_header(const char *text, size_t size, sqffd_io__ply *h, const char *name,
                                       char *err, size_t err_size)
{
    const char *p = text, *end = text + size;
    unsigned long long line = 0;
    int have_format = 0;
    char q[32];
    h->elements = h->properties = 0;
    h->vertex = -1;
    for (;;) {
        const char *nl, *e, *s, *tok[6];
        size_t len[6];
        int n = 0;
        if (p == end)
            return sqffd_io__fail(err, err_size, name, "file ends inside the header (no end_header line)");
        nl = (const char *)memchr(p, '\n', (size_t)(end - p));
        e = nl ? nl : end;
        s = p;
        p = nl ? nl + 1 : end;
        line++;
        if (e > s && e[-1] == '\r') e--;
        if (line == 1) {
            if (e - s != 3 || memcmp(s, "ply", 3) != 0)
                return sqffd_io__fail(err, err_size, name, "not a PLY file: the first line is not 'ply'");
            continue;
        }
        if (!sqffd_io__line_token(&s, e, &tok[0], &len[0])) continue; /* blank line */
        if ((len[0] == 7 && memcmp(tok[0], "comment", 7) == 0) || (len[0] == 8 && memcmp(tok[0], "obj_info", 8) == 0))
            continue;
        for (n = 1; n < 6 && sqffd_io__line_token(&s, e, &tok[n], &len[n]); n++) {}
        if (len[0] == 10 && memcmp(tok[0], "end_header", 10) == 0) {
            if (!have_format)
                return sqffd_io__fail(err, err_size, name, "header has no format line");
            h->data_offset = (size_t)(p - text);
            return 0;
        } else if (len[0] == 6 && memcmp(tok[0], "format", 6) == 0) {
            if (n != 3)
                return sqffd_io__fail(err, err_size, name, "header line %llu: expected 'format TYPE 1.0'", line);
            if (len[1] == 5 && memcmp(tok[1], "ascii", 5) == 0) h->format = SQFFD_IO__PLY_ASCII;
            else if (len[1] == 20 && memcmp(tok[1], "binary_little_endian", 20) == 0) h->format = SQFFD_IO__PLY_LE;
            else if (len[1] == 17 && memcmp(tok[1], "binary_big_endian", 17) == 0) h->format = SQFFD_IO__PLY_BE;
            else
                return sqffd_io__fail(err, err_size, name, "header line %llu: unknown format %s", line,
                                      sqffd_io__quote(tok[1], len[1], q));
            have_format = 1;
        } else if (len[0] == 7 && memcmp(tok[0], "element", 7) == 0) {
            sqffd_io__ply_element *el = &h->element[h->elements];
            if (n != 3)
                return sqffd_io__fail(err, err_size, name, "header line %llu: expected 'element NAME COUNT'", line);
            if (h->elements == SQFFD_IO__PLY_MAX_ELEMENTS)
                return sqffd_io__fail(err, err_size, name, "header line %llu: more than %d elements", line,
                                      SQFFD_IO__PLY_MAX_ELEMENTS);
            if (sqffd_io__parse_count(tok[2], len[2], &el->count))
                return sqffd_io__fail(err, err_size, name, "header line %llu: element count %s is not a number below 2^64",
                                      line, sqffd_io__quote(tok[2], len[2], q));
            snprintf(el->name, sizeof el->name, "%.*s", (int)(len[1] < 31 ? len[1] : 31), tok[1]);
            el->first = h->properties;
            el->properties = 0;
            if (len[1] == 6 && memcmp(tok[1], "vertex", 6) == 0) {
                if (h->vertex >= 0)
                    return sqffd_io__fail(err, err_size, name, "header line %llu: a second vertex element", line);
                h->vertex = h->elements;
            }
            h->elements++;
        } else if (len[0] == 8 && memcmp(tok[0], "property", 8) == 0) {
            sqffd_io__ply_property *pr = &h->property[h->properties];
            int is_list = n >= 2 && len[1] == 4 && memcmp(tok[1], "list", 4) == 0;
            int type_tok = is_list ? 3 : 1;
            const char *pname;
            size_t plen;
            if (h->elements == 0)
                return sqffd_io__fail(err, err_size, name, "header line %llu: property before any element", line);
            if (n != (is_list ? 5 : 3))
                return sqffd_io__fail(err, err_size, name, "header line %llu: expected 'property TYPE NAME' or "
                                      "'property list COUNT_TYPE TYPE NAME'", line);
            if (h->properties == SQFFD_IO__PLY_MAX_PROPERTIES)
                return sqffd_io__fail(err, err_size, name, "header line %llu: more than %d properties", line,
                                      SQFFD_IO__PLY_MAX_PROPERTIES);
            pr->type = sqffd_io__ply_type(tok[type_tok], len[type_tok]);
            if (pr->type < 0)
                return sqffd_io__fail(err, err_size, name, "header line %llu: unknown property type %s", line,
                                      sqffd_io__quote(tok[type_tok], len[type_tok], q));
            pr->count_type = -1;
            if (is_list) {
                pr->count_type = sqffd_io__ply_type(tok[2], len[2]);
                if (pr->count_type < 0 || pr->count_type >= SQFFD_IO__F32)
                    return sqffd_io__fail(err, err_size, name, "header line %llu: list count type %s is not an integer type",
                                          line, sqffd_io__quote(tok[2], len[2], q));
            }
            pname = tok[n - 1];
            plen = len[n - 1];
            pr->role = 0;
            if (h->vertex == h->elements - 1 && plen == 1 && pname[0] >= 'x' && pname[0] <= 'z') {
                int i, role = pname[0] - 'x' + 1;
                sqffd_io__ply_element *el = &h->element[h->elements - 1];
                for (i = el->first; i < h->properties; i++)
                    if (h->property[i].role == role)
                        return sqffd_io__fail(err, err_size, name, "header line %llu: a second vertex property '%c'",
                                              line, pname[0]);
                if (is_list)
                    return sqffd_io__fail(err, err_size, name, "header line %llu: vertex property '%c' is a list",
                                          line, pname[0]);
                pr->role = role;
            }
            h->element[h->elements - 1].properties++;
            h->properties++;
        } else {
            return sqffd_io__fail(err, err_size, name, "header line %llu: unknown keyword %s", line,
                                  sqffd_io__quote(tok[0], len[0], q));
        }
    }
}

/* A binary scalar at p as a double (exact for every PLY type; 64-bit
   integers are rounded to the nearest double). */
static inline double sqffd_io__ply_load(const unsigned char *p, int type, int big_endian)
{
    size_t size = sqffd_io__type_size(type), i;
    uint64_t u = 0;
    for (i = 0; i < size; i++) u |= (uint64_t)p[big_endian ? size - 1 - i : i] << (8 * i);
    switch (type) {
    case SQFFD_IO__I8: return (double)u - (u >= 0x80u ? 256.0 : 0.0);
    case SQFFD_IO__I16: return (double)u - (u >= 0x8000u ? 65536.0 : 0.0);
    case SQFFD_IO__I32: return (double)u - (u >= 0x80000000u ? 4294967296.0 : 0.0);
    case SQFFD_IO__I64: return u >> 63 ? -(double)(~u) - 1.0 : (double)u;
    case SQFFD_IO__F32: {
        uint32_t bits = (uint32_t)u;
        float f;
        memcpy(&f, &bits, sizeof f);
        return (double)f;
    }
    case SQFFD_IO__F64: {
        double d;
        memcpy(&d, &u, sizeof d);
        return d;
    }
    default: return (double)u; /* unsigned types */
    }
}

/* The least number of bytes (binary) or tokens (ascii) one instance of an element takes. */
static inline uint64_t sqffd_io__ply_min_record(const sqffd_io__ply *h, const sqffd_io__ply_element *el)
{
    uint64_t bytes = 0;
    int i;
    if (h->format == SQFFD_IO__PLY_ASCII) return (uint64_t)el->properties;
    for (i = el->first; i < el->first + el->properties; i++) {
        const sqffd_io__ply_property *pr = &h->property[i];
        bytes += sqffd_io__type_size(pr->count_type >= 0 ? pr->count_type : pr->type);
    }
    return bytes;
}

/* One property of instance i of element el in an ascii body: *value gets
   its number when it is x, y or z; a list's items are skipped. 0 on success. */
static inline int sqffd_io__ply_ascii_property(sqffd_io__text *t, const sqffd_io__ply_property *pr,
                                               const sqffd_io__ply_element *el, uint64_t i, double *value,
                                               const char *name, char *err, size_t err_size)
{
    const char *tok;
    size_t len;
    uint64_t n, j;
    char q[32];
    int r;
    if (!sqffd_io__token(t, &tok, &len))
        return sqffd_io__fail(err, err_size, name, "%s %llu: file ends inside it", el->name, (unsigned long long)i);
    if (pr->count_type < 0 && !pr->role) return 0; /* a skipped scalar */
    r = sqffd_io__parse_double(tok, len, value);
    /* a float property holds a float, as in the binary formats */
    if (r == SQFFD_IO__NUMBER && pr->count_type < 0 && pr->type == SQFFD_IO__F32) {
        *value = (double)sqffd_io__to_float(*value);
        if (!isfinite(*value)) r = SQFFD_IO__NOT_FINITE;
    }
    if (r == SQFFD_IO__NOT_FINITE)
        return sqffd_io__fail(err, err_size, name, "%s %llu (line %llu): %s is not a finite number", el->name,
                              (unsigned long long)i, t->line, sqffd_io__quote(tok, len, q));
    if (r != SQFFD_IO__NUMBER)
        return sqffd_io__fail(err, err_size, name, "%s %llu (line %llu): expected a number, found %s", el->name,
                              (unsigned long long)i, t->line, sqffd_io__quote(tok, len, q));
    if (pr->count_type < 0) return 0;
    if (*value < 0.0 || *value != floor(*value))
        return sqffd_io__fail(err, err_size, name, "%s %llu (line %llu): list count %s is not a count", el->name,
                              (unsigned long long)i, t->line, sqffd_io__quote(tok, len, q));
    if (*value > (double)(t->end - t->p)) /* each item takes at least a byte */
        return sqffd_io__fail(err, err_size, name, "%s %llu (line %llu): list of %s values, file holds %llu more bytes",
                              el->name, (unsigned long long)i, t->line, sqffd_io__quote(tok, len, q),
                              (unsigned long long)(t->end - t->p));
    n = (uint64_t)*value;
    for (j = 0; j < n; j++)
        if (!sqffd_io__token(t, &tok, &len))
            return sqffd_io__fail(err, err_size, name, "%s %llu: file ends inside its list", el->name,
                                  (unsigned long long)i);
    return 0;
}

/* The same for a binary body, the next byte being bytes[*at]. */
static inline int sqffd_io__ply_binary_property(const unsigned char *bytes, size_t size, size_t *at, int big_endian,
                                                const sqffd_io__ply_property *pr, const sqffd_io__ply_element *el,
                                                uint64_t i, double *value, const char *name, char *err,
                                                size_t err_size)
{
    size_t first = sqffd_io__type_size(pr->count_type >= 0 ? pr->count_type : pr->type);
    double n;
    size_t item;
    if (size - *at < first)
        return sqffd_io__fail(err, err_size, name, "%s %llu: file ends inside it", el->name, (unsigned long long)i);
    if (pr->count_type < 0) {
        if (pr->role) {
            *value = sqffd_io__ply_load(bytes + *at, pr->type, big_endian);
            if (!isfinite(*value))
                return sqffd_io__fail(err, err_size, name, "%s %llu: %c is not finite (%g)", el->name,
                                      (unsigned long long)i, 'x' + pr->role - 1, *value);
        }
        *at += first;
        return 0;
    }
    n = sqffd_io__ply_load(bytes + *at, pr->count_type, big_endian);
    *at += first;
    item = sqffd_io__type_size(pr->type);
    if (n < 0.0)
        return sqffd_io__fail(err, err_size, name, "%s %llu: negative list count %.0f", el->name,
                              (unsigned long long)i, n);
    if (n > (double)((size - *at) / item))
        return sqffd_io__fail(err, err_size, name, "%s %llu: list of %.0f values of %llu bytes, file holds %llu more bytes",
                              el->name, (unsigned long long)i, n, (unsigned long long)item,
                              (unsigned long long)(size - *at));
    *at += (size_t)n * item;
    return 0;
}

/* Reads the vertex element's x y z into pts and skips every other element,
   checking the whole body against its size. */
static inline int sqffd_io__ply_body(const char *text, size_t size, const sqffd_io__ply *h, sqffd_io__points *pts,
                                     const char *name, char *err, size_t err_size)
{
    const unsigned char *bytes = (const unsigned char *)text;
    size_t at = h->data_offset; /* binary: the next byte to read */
    sqffd_io__text t;           /* ascii: the token cursor */
    int big = h->format == SQFFD_IO__PLY_BE, ascii = h->format == SQFFD_IO__PLY_ASCII, e;
    t.p = text + h->data_offset;
    t.end = text + size;
    t.line = 1; /* line numbers of an ascii body continue the header's */
    if (ascii) {
        const char *c;
        for (c = text; c < t.p; c++) t.line += *c == '\n';
    }
    for (e = 0; e < h->elements; e++) {
        const sqffd_io__ply_element *el = &h->element[e];
        uint64_t min_record = sqffd_io__ply_min_record(h, el), i;
        size_t remaining = ascii ? (size_t)(t.end - t.p) : size - at;
        int is_vertex = e == h->vertex;
        if (el->properties == 0) continue; /* instances of nothing take no room */
        /* ascii: a value is at least one byte plus a separator */
        if (el->count > (ascii ? (uint64_t)(remaining + 1) / (2 * min_record) : (uint64_t)remaining / min_record))
            return sqffd_io__fail(err, err_size, name,
                                  "header says %llu %s%s%s of at least %llu %s each, file holds %llu bytes of data%s",
                                  (unsigned long long)el->count, is_vertex ? "vertices" : "'", is_vertex ? "" : el->name,
                                  is_vertex ? "" : "' elements", (unsigned long long)min_record,
                                  ascii ? "values" : "bytes", (unsigned long long)remaining,
                                  remaining == size - h->data_offset ? "" : " after the elements before it");
        if (is_vertex && sqffd_io__reserve(pts, (size_t)el->count))
            return sqffd_io__fail(err, err_size, name, "out of memory for %llu vertices", (unsigned long long)el->count);
        for (i = 0; i < el->count; i++) {
            double xyz[4] = {0.0, 0.0, 0.0, 0.0}; /* [0] takes the values of skipped properties */
            int k;
            for (k = el->first; k < el->first + el->properties; k++) {
                const sqffd_io__ply_property *pr = &h->property[k];
                double *value = &xyz[pr->role];
                if (ascii ? sqffd_io__ply_ascii_property(&t, pr, el, i, value, name, err, err_size)
                          : sqffd_io__ply_binary_property(bytes, size, &at, big, pr, el, i, value, name, err, err_size))
                    return 1;
            }
            if (is_vertex) {
                memcpy(pts->xyz + 3 * pts->count, xyz + 1, 3 * sizeof(double));
                pts->count++;
            }
        }
    }
    return 0;
}

/* PLY: ascii, binary_little_endian or binary_big_endian. The vertex
   element's x, y, z are read whatever their type and place among its
   properties; every other property and element is skipped, but the whole
   file is checked (a truncated file is an error even past the vertices). */
static inline int sqffd_io_read_ply(const void *data, size_t size, const char *name, double **points,
                                    size_t *count, char *err, size_t err_size)
{
    sqffd_io__points pts = {NULL, 0, 0};
    sqffd_io__ply *h;
    int role;
    *points = NULL;
    *count = 0;
    h = (sqffd_io__ply *)malloc(sizeof *h);
    if (!h) return sqffd_io__fail(err, err_size, name, "out of memory");
    if (sqffd_io__ply_header((const char *)data, size, h, name, err, err_size)) {
        free(h);
        return 1;
    }
    if (h->vertex < 0) {
        free(h);
        return sqffd_io__fail(err, err_size, name, "header has no vertex element");
    }
    for (role = 1; role <= 3; role++) {
        const sqffd_io__ply_element *el = &h->element[h->vertex];
        int i, found = 0;
        for (i = el->first; i < el->first + el->properties; i++) found |= h->property[i].role == role;
        if (!found) {
            free(h);
            return sqffd_io__fail(err, err_size, name, "vertex element has no '%c' property", 'x' + role - 1);
        }
    }
    if (sqffd_io__ply_body((const char *)data, size, h, &pts, name, err, err_size)) {
        free(h);
        free(pts.xyz);
        return 1;
    }
    free(h);
    return sqffd_io__finish(&pts, points, count, name, err, err_size);
}

/* ---- PCD ----------------------------------------------------------------- */

/* PCD, the Point Cloud Library's format (versions 0.6 and 0.7): header lines
   VERSION, FIELDS, SIZE, TYPE, COUNT, WIDTH, HEIGHT, VIEWPOINT, POINTS (any
   order, FIELDS before SIZE, TYPE and COUNT), then DATA and the points:
     ascii              a line per point, COUNT values for each field;
     binary             point after point, each field's values in turn, little endian;
     binary_compressed  uint32 compressed size, uint32 uncompressed size (little
                        endian), then LZF data that decompress to the fields one
                        after the other (all points' values of field 0, then of
                        field 1, ...); padding fields '_' take no bytes there, as
                        PCL writes and reads them. */

enum { SQFFD_IO__PCD_ASCII, SQFFD_IO__PCD_BINARY, SQFFD_IO__PCD_COMPRESSED };
#define SQFFD_IO__PCD_MAX_FIELDS 1024
/* The most an LZF stream expands: a 3-byte back-reference gives 264 bytes. */
#define SQFFD_IO__LZF_MAX_EXPANSION 88

typedef struct sqffd_io__pcd_field {
    const char *name; /* in the header text */
    size_t name_len;
    unsigned size;    /* SIZE: 1, 2, 4 or 8 */
    char kind;        /* TYPE: 'I', 'U' or 'F' */
    int type;         /* SQFFD_IO__I8 ... SQFFD_IO__U64, from SIZE and TYPE */
    uint64_t count;   /* COUNT: values a point holds */
    int role;         /* 1..3: x, y, z; 0: skipped */
} sqffd_io__pcd_field;

typedef struct sqffd_io__pcd {
    int encoding, fields;
    sqffd_io__pcd_field field[SQFFD_IO__PCD_MAX_FIELDS];
    sqffd_io__text body; /* the text after the DATA line; line numbers go on from the header's */
    sqffd_io_pcd_header header;
} sqffd_io__pcd;

static inline int sqffd_io__pcd_padding(const sqffd_io__pcd_field *f)
{
    return f->name_len == 1 && f->name[0] == '_';
}

/* The next token of a line when it is the line's last one. */
static inline int sqffd_io__last_token(const char **s, const char *e, const char **tok, size_t *len)
{
    const char *extra;
    size_t extra_len;
    return sqffd_io__line_token(s, e, tok, len) && !sqffd_io__line_token(s, e, &extra, &extra_len);
}

/* The value type of a field of SIZE size and TYPE kind; -1 if PCD has none. */
static inline int sqffd_io__pcd_type(char kind, unsigned size)
{
    static const int integers[2][4] = {{SQFFD_IO__I8, SQFFD_IO__I16, SQFFD_IO__I32, SQFFD_IO__I64},
                                       {SQFFD_IO__U8, SQFFD_IO__U16, SQFFD_IO__U32, SQFFD_IO__U64}};
    int size_log2 = size == 1 ? 0 : size == 2 ? 1 : size == 4 ? 2 : size == 8 ? 3 : -1;
    if (size_log2 < 0) return -1;
    if (kind == 'F') return size == 4 ? SQFFD_IO__F32 : size == 8 ? SQFFD_IO__F64 : -1;
    if (kind == 'I' || kind == 'U') return integers[kind == 'U'][size_log2];
    return -1;
}

/* The fields as "x F4, y F4, z F4, rgba U4, fpfh F4x33" into h->header.fields. */
static inline void sqffd_io__pcd_describe(sqffd_io__pcd *h)
{
    char *out = h->header.fields;
    size_t cap = sizeof h->header.fields, used = 0;
    int f;
    out[0] = '\0';
    for (f = 0; f < h->fields; f++) {
        const sqffd_io__pcd_field *fd = &h->field[f];
        char item[96], label[33];
        size_t i, n = fd->name_len < 32 ? fd->name_len : 32, len;
        for (i = 0; i < n; i++) {
            unsigned char c = (unsigned char)fd->name[i];
            label[i] = (char)(c >= 32 && c < 127 ? c : '?');
        }
        label[n] = '\0';
        if (fd->count == 1) snprintf(item, sizeof item, "%s%s %c%u", f ? ", " : "", label, fd->kind, fd->size);
        else snprintf(item, sizeof item, "%s%s %c%ux%llu", f ? ", " : "", label, fd->kind, fd->size,
                      (unsigned long long)fd->count);
        len = strlen(item);
        if (used + len + 6 > cap) { /* room is always left for ", ..." */
            memcpy(out + used, ", ...", 6);
            return;
        }
        memcpy(out + used, item, len + 1);
        used += len;
    }
}

/* Reads the header lines up to DATA into h; 0 on success. */
static inline int sqffd_io__pcd_header(const char *text, size_t size, sqffd_io__pcd *h, const char *name, char *err,
                                       size_t err_size)
{
    enum { kw_version, kw_fields, kw_size, kw_type, kw_count, kw_width, kw_height, kw_viewpoint, kw_points, kw_data,
           kw_keywords };
    static const char *const keywords[kw_keywords] = {"VERSION", "FIELDS", "SIZE", "TYPE", "COUNT",
                                                   "WIDTH", "HEIGHT", "VIEWPOINT", "POINTS", "DATA"};
    static const double identity[7] = {0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0};
    sqffd_io__text t;
    const char *s, *e, *tok;
    size_t len;
    uint64_t width = 0, height = 1, points = 0;
    int seen[kw_keywords] = {0}, key, f, k;
    char q[32];
    t.p = text;
    t.end = text + size;
    t.line = 0;
    h->fields = 0;
    memset(&h->header, 0, sizeof h->header);
    memcpy(h->header.viewpoint, identity, sizeof identity);
    for (;;) {
        if (!sqffd_io__next_line(&t, &s, &e))
            return sqffd_io__fail(err, err_size, name, "file ends inside the header (no DATA line)");
        if (!sqffd_io__line_token(&s, e, &tok, &len))
            return sqffd_io__fail(err, err_size, name, "header line %llu: expected a keyword", t.line);
        for (key = 0; key < kw_keywords; key++)
            if (strlen(keywords[key]) == len && memcmp(keywords[key], tok, len) == 0) break;
        if (key == kw_keywords)
            return sqffd_io__fail(err, err_size, name, "header line %llu: unknown keyword %s", t.line,
                                  sqffd_io__quote(tok, len, q));
        if (seen[key]++)
            return sqffd_io__fail(err, err_size, name, "header line %llu: a second %s line", t.line, keywords[key]);
        if ((key == kw_size || key == kw_type || key == kw_count) && !seen[kw_fields])
            return sqffd_io__fail(err, err_size, name, "header line %llu: %s before FIELDS", t.line, keywords[key]);
        if (key == kw_fields) {
            for (f = 0; sqffd_io__line_token(&s, e, &tok, &len); f++) {
                sqffd_io__pcd_field *fd = &h->field[f];
                if (f == SQFFD_IO__PCD_MAX_FIELDS)
                    return sqffd_io__fail(err, err_size, name, "header line %llu: more than %d fields", t.line,
                                          SQFFD_IO__PCD_MAX_FIELDS);
                fd->name = tok;
                fd->name_len = len;
                fd->size = 4; /* PCL's defaults for files without SIZE, TYPE or COUNT */
                fd->kind = 'F';
                fd->count = 1;
                fd->role = len == 1 && tok[0] >= 'x' && tok[0] <= 'z' ? tok[0] - 'x' + 1 : 0;
                for (k = 0; k < f && fd->role; k++)
                    if (h->field[k].role == fd->role)
                        return sqffd_io__fail(err, err_size, name, "header line %llu: a second field '%c'", t.line,
                                              tok[0]);
                h->fields = f + 1;
            }
            if (h->fields == 0)
                return sqffd_io__fail(err, err_size, name, "header line %llu: FIELDS names no field", t.line);
        } else if (key == kw_size || key == kw_type || key == kw_count) {
            for (f = 0; sqffd_io__line_token(&s, e, &tok, &len); f++) {
                sqffd_io__pcd_field *fd = &h->field[f];
                uint64_t v = 0;
                if (f == h->fields)
                    return sqffd_io__fail(err, err_size, name, "header line %llu: more %s entries than the %d FIELDS",
                                          t.line, keywords[key], h->fields);
                if (key == kw_type) {
                    if (len != 1 || (tok[0] != 'I' && tok[0] != 'U' && tok[0] != 'F'))
                        return sqffd_io__fail(err, err_size, name, "header line %llu: TYPE %s is not I, U or F",
                                              t.line, sqffd_io__quote(tok, len, q));
                    fd->kind = tok[0];
                    continue;
                }
                if (sqffd_io__parse_count(tok, len, &v) || (key == kw_size && v != 1 && v != 2 && v != 4 && v != 8))
                    return sqffd_io__fail(err, err_size, name, "header line %llu: %s %s is not %s", t.line,
                                          keywords[key], sqffd_io__quote(tok, len, q),
                                          key == kw_size ? "1, 2, 4 or 8" : "a count below 2^64");
                if (key == kw_count && v == 0)
                    return sqffd_io__fail(err, err_size, name, "header line %llu: COUNT 0: a field holds at least "
                                          "one value", t.line);
                if (key == kw_size) fd->size = (unsigned)v;
                else fd->count = v;
            }
            if (f != h->fields)
                return sqffd_io__fail(err, err_size, name, "header line %llu: %d %s entries for %d FIELDS", t.line, f,
                                      keywords[key], h->fields);
        } else if (key == kw_width || key == kw_height || key == kw_points) {
            uint64_t *v = key == kw_width ? &width : key == kw_height ? &height : &points;
            if (!sqffd_io__last_token(&s, e, &tok, &len) || sqffd_io__parse_count(tok, len, v))
                return sqffd_io__fail(err, err_size, name, "header line %llu: expected '%s N', N a count below 2^64",
                                      t.line, keywords[key]);
        } else if (key == kw_version) {
            if (!sqffd_io__last_token(&s, e, &tok, &len))
                return sqffd_io__fail(err, err_size, name, "header line %llu: expected 'VERSION 0.7'", t.line);
            if ((len == 3 || len == 2) && memcmp(tok + len - 2, ".7", 2) == 0 && (len == 2 || tok[0] == '0'))
                memcpy(h->header.version, "0.7", 4);
            else if ((len == 3 || len == 2) && memcmp(tok + len - 2, ".6", 2) == 0 && (len == 2 || tok[0] == '0'))
                memcpy(h->header.version, "0.6", 4);
            else
                return sqffd_io__fail(err, err_size, name, "header line %llu: VERSION %s: only PCD 0.6 and 0.7 are "
                                      "read", t.line, sqffd_io__quote(tok, len, q));
        } else if (key == kw_viewpoint) {
            for (k = 0; k < 7; k++)
                if (!sqffd_io__line_token(&s, e, &tok, &len) ||
                    sqffd_io__parse_double(tok, len, &h->header.viewpoint[k]) != SQFFD_IO__NUMBER)
                    return sqffd_io__fail(err, err_size, name, "header line %llu: VIEWPOINT takes 7 finite numbers "
                                          "(tx ty tz qw qx qy qz)", t.line);
            if (sqffd_io__line_token(&s, e, &tok, &len))
                return sqffd_io__fail(err, err_size, name, "header line %llu: VIEWPOINT takes 7 numbers, found more",
                                      t.line);
        } else { /* DATA: the header's last line */
            if (!sqffd_io__last_token(&s, e, &tok, &len))
                return sqffd_io__fail(err, err_size, name, "header line %llu: expected 'DATA ENCODING'", t.line);
            if (len == 5 && memcmp(tok, "ascii", 5) == 0) h->encoding = SQFFD_IO__PCD_ASCII;
            else if (len == 6 && memcmp(tok, "binary", 6) == 0) h->encoding = SQFFD_IO__PCD_BINARY;
            else if (len == 17 && memcmp(tok, "binary_compressed", 17) == 0) h->encoding = SQFFD_IO__PCD_COMPRESSED;
            else
                return sqffd_io__fail(err, err_size, name, "header line %llu: DATA %s is not ascii, binary or "
                                      "binary_compressed", t.line, sqffd_io__quote(tok, len, q));
            h->header.encoding = h->encoding == SQFFD_IO__PCD_ASCII    ? "ascii"
                                 : h->encoding == SQFFD_IO__PCD_BINARY ? "binary"
                                                                       : "binary_compressed";
            h->body = t;
            break;
        }
    }
    if (!seen[kw_fields]) return sqffd_io__fail(err, err_size, name, "header has no FIELDS line");
    if (seen[kw_size] != seen[kw_type])
        return sqffd_io__fail(err, err_size, name, "header has %s but no %s line", seen[kw_size] ? "SIZE" : "TYPE",
                              seen[kw_size] ? "TYPE" : "SIZE");
    for (f = 0; f < h->fields; f++) {
        sqffd_io__pcd_field *fd = &h->field[f];
        fd->type = sqffd_io__pcd_type(fd->kind, fd->size);
        if (fd->type < 0)
            return sqffd_io__fail(err, err_size, name, "field %s: TYPE %c of SIZE %u is not a PCD type",
                                  sqffd_io__quote(fd->name, fd->name_len, q), fd->kind, fd->size);
        if (fd->role && fd->count != 1)
            return sqffd_io__fail(err, err_size, name, "field '%c' has COUNT %llu; a coordinate is 1 value",
                                  'x' + fd->role - 1, (unsigned long long)fd->count);
    }
    for (k = 1; k <= 3; k++) {
        for (f = 0; f < h->fields && h->field[f].role != k; f++) {}
        if (f == h->fields) return sqffd_io__fail(err, err_size, name, "FIELDS has no '%c'", 'x' + k - 1);
    }
    if (seen[kw_width]) {
        if (width != 0 && height > UINT64_MAX / width)
            return sqffd_io__fail(err, err_size, name, "WIDTH %llu x HEIGHT %llu overflows", (unsigned long long)width,
                                  (unsigned long long)height);
        if (!seen[kw_points]) points = width * height; /* old files */
        else if (width * height != points)
            return sqffd_io__fail(err, err_size, name, "WIDTH x HEIGHT = %llu x %llu, but POINTS %llu",
                                  (unsigned long long)width, (unsigned long long)height, (unsigned long long)points);
    } else if (seen[kw_height]) {
        return sqffd_io__fail(err, err_size, name, "header has HEIGHT but no WIDTH");
    } else if (!seen[kw_points]) {
        return sqffd_io__fail(err, err_size, name, "header has neither POINTS nor WIDTH");
    } else {
        width = points;
    }
    if (points == 0) return sqffd_io__fail(err, err_size, name, "header says 0 points");
    h->header.width = width;
    h->header.height = height;
    h->header.points = points;
    sqffd_io__pcd_describe(h);
    return 0;
}

/* Decompresses LZF data (LibLZF's format) in[0, in_size) into exactly
   out_size bytes at out. Returns 0, or 1 with *problem, the input offset
   where it was found in *at and the bytes decompressed by then in *done.
   Where input and output have room, copies go in fixed blocks of 16 bytes
   past the run's end (overwritten by what follows): PCD data come in short
   runs, and a copy of variable length costs more than the extra bytes. */
static inline int sqffd_io__lzf_decompress(const unsigned char *in, size_t in_size, unsigned char *out,
                                           size_t out_size, const char **problem, size_t *at, size_t *done)
{
    size_t ip = 0, op = 0;
    while (ip < in_size) {
        size_t ctrl = in[ip], len;
        *at = ip++;
        *done = op;
        if (ctrl < 32) { /* a literal run of ctrl + 1 bytes */
            len = ctrl + 1;
            if (in_size - ip < len) { *problem = "a literal run passes the end of the compressed data"; return 1; }
            if (out_size - op < len) { *problem = "more bytes than the uncompressed size"; return 1; }
            if (in_size - ip >= 32 && out_size - op >= 32) memcpy(out + op, in + ip, 32);
            else memcpy(out + op, in + ip, len);
            ip += len;
        } else { /* a back-reference: length ctrl >> 5 (7: plus the next byte) + 2, 13-bit distance - 1 */
            size_t distance, i;
            len = ctrl >> 5;
            if (len == 7 && ip < in_size) len += in[ip++];
            if (ip == in_size) { *problem = "a back-reference is cut off by the end of the compressed data"; return 1; }
            distance = ((ctrl & 31) << 8 | in[ip++]) + 1;
            len += 2;
            if (distance > op) { *problem = "a back-reference reaches before the start of the data"; return 1; }
            if (out_size - op < len) { *problem = "more bytes than the uncompressed size"; return 1; }
            if (len == 3 && distance >= 2) {
                /* the commonest length, copied exactly: a 4-byte block would
                   also read the byte after the source, which a repeated
                   4-byte value (a literal byte, then 3 bytes from 4 back)
                   has just written in the next token's block, and a load
                   spanning two recent stores stalls until both are written */
                memcpy(out + op, out + op - distance, 2);
                out[op + 2] = out[op + 2 - distance];
            } else if (distance >= 16 && out_size - op >= len + 15) { /* each block is read before it is written */
                for (i = 0; i < len; i += 16) memcpy(out + op + i, out + op - distance + i, 16);
            } else if (distance >= 8 && out_size - op >= len + 7) {
                for (i = 0; i < len; i += 8) memcpy(out + op + i, out + op - distance + i, 8);
            } else if (distance >= 4 && out_size - op >= len + 3) { /* a float repeated: distance 4 */
                for (i = 0; i < len; i += 4) memcpy(out + op + i, out + op - distance + i, 4);
            } else { /* overlapping: bytes written by this copy are copied again */
                for (i = 0; i < len; i++) out[op + i] = out[op - distance + i];
            }
        }
        op += len;
    }
    *at = ip;
    *done = op;
    if (op != out_size) { *problem = "fewer bytes than the uncompressed size"; return 1; }
    return 0;
}

/* A little-endian float at p, as a double. */
static inline double sqffd_io__le_f32(const unsigned char *p)
{
    uint32_t bits = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
    float f;
    memcpy(&f, &bits, sizeof f);
    return (double)f;
}

/* Whether point i (x y z) is kept: 1 when every coordinate is finite, 0
   when one is NaN (the point is dropped); an infinite coordinate is an
   error (-1, message in err). */
static inline int sqffd_io__pcd_valid(const double xyz[3], uint64_t i, const char *name, char *err, size_t err_size)
{
    int k;
    if (isfinite(xyz[0]) && isfinite(xyz[1]) && isfinite(xyz[2])) return 1;
    if (isnan(xyz[0]) || isnan(xyz[1]) || isnan(xyz[2])) return 0;
    for (k = 0; isfinite(xyz[k]); k++) {}
    sqffd_io__fail(err, err_size, name, "point %llu: %c is infinite (PCL marks invalid points with NaN: an infinity "
                   "is corrupt data)", (unsigned long long)i, 'x' + k);
    return -1;
}

/* The points of binary data into pts (which has room), NaN ones counted in
   *dropped: coordinate k of point i is the value of type type[k] at
   base + offset[k] + i * stride[k]. */
static inline int sqffd_io__pcd_extract(const unsigned char *base, uint64_t n, const size_t offset[3],
                                        const size_t stride[3], const int type[3], sqffd_io__points *pts,
                                        size_t *dropped, const char *name, char *err, size_t err_size)
{
    int floats = type[0] == SQFFD_IO__F32 && type[1] == SQFFD_IO__F32 && type[2] == SQFFD_IO__F32;
    double *out = pts->xyz + 3 * pts->count;
    size_t kept = 0, invalid = 0, i;
    for (i = 0; i < (size_t)n; i++) {
        double *xyz = out + 3 * kept; /* written in place, kept or not */
        int k, valid;
        for (k = 0; k < 3; k++) {
            const unsigned char *p = base + offset[k] + i * stride[k];
            xyz[k] = floats ? sqffd_io__le_f32(p) : sqffd_io__ply_load(p, type[k], 0);
        }
        valid = sqffd_io__pcd_valid(xyz, i, name, err, err_size);
        if (valid < 0) return 1;
        kept += (size_t)valid;
        invalid += (size_t)!valid;
    }
    pts->count += kept;
    *dropped += invalid;
    return 0;
}

/* One ascii value of field fd, point i: NaN is let through (the point is
   dropped); anything else must be a finite value of the field's type (a
   float field's value is rounded to float, as binary files hold it). */
static inline int sqffd_io__pcd_ascii_value(const char *tok, size_t len, const sqffd_io__pcd_field *fd, uint64_t i,
                                            unsigned long long line, double *value, const char *name, char *err,
                                            size_t err_size)
{
    char q[32];
    char c = (char)('x' + fd->role - 1);
    if (sqffd_io__parse_double(tok, len, value) == SQFFD_IO__NOT_NUMBER)
        return sqffd_io__fail(err, err_size, name, "point %llu (line %llu): expected a number for %c, found %s",
                              (unsigned long long)i, line, c, sqffd_io__quote(tok, len, q));
    if (fd->kind != 'F') {
        int bits = 8 * (int)fd->size;
        double lo = fd->kind == 'I' ? -ldexp(1.0, bits - 1) : 0.0, hi = ldexp(1.0, fd->kind == 'I' ? bits - 1 : bits);
        if (!(*value == floor(*value) && *value >= lo && *value < hi))
            return sqffd_io__fail(err, err_size, name, "point %llu (line %llu): %c %s is not %s integer of %d bits",
                                  (unsigned long long)i, line, c, sqffd_io__quote(tok, len, q),
                                  fd->kind == 'I' ? "a signed" : "an unsigned", bits);
        return 0;
    }
    if (fd->size == 4 && !isnan(*value)) *value = (double)sqffd_io__to_float(*value);
    if (isinf(*value))
        return sqffd_io__fail(err, err_size, name, "point %llu (line %llu): %c %s is not finite%s (PCL marks invalid "
                              "points with NaN: an infinity is corrupt data)", (unsigned long long)i, line, c,
                              sqffd_io__quote(tok, len, q), fd->size == 4 ? " as a float" : "");
    return 0;
}

/* The points of an ascii body: a line per point (blank lines and '#'
   comments skipped), at least as many values as the fields' COUNTs add up
   to; more values, and lines after the last point, are ignored (as PCL does). */
static inline int sqffd_io__pcd_ascii(sqffd_io__pcd *h, sqffd_io__points *pts, size_t *dropped, const char *name,
                                      char *err, size_t err_size)
{
    sqffd_io__text t = h->body;
    uint64_t values = 0, n = h->header.points, i;
    size_t remaining = (size_t)(t.end - t.p);
    int f;
    for (f = 0; f < h->fields; f++) {
        if (values > UINT64_MAX - h->field[f].count)
            return sqffd_io__fail(err, err_size, name, "the fields' COUNTs add up past 2^64");
        values += h->field[f].count;
    }
    /* a value is at least one byte plus a separator */
    if (n > ((uint64_t)remaining + 1) / 2 / values)
        return sqffd_io__fail(err, err_size, name, "header says %llu points of %llu values each, file holds %llu bytes "
                              "of data", (unsigned long long)n, (unsigned long long)values,
                              (unsigned long long)remaining);
    if (sqffd_io__reserve(pts, (size_t)n))
        return sqffd_io__fail(err, err_size, name, "out of memory for %llu points", (unsigned long long)n);
    for (i = 0; i < n; i++) {
        const char *s, *e, *tok;
        size_t len;
        double xyz[3] = {0.0, 0.0, 0.0};
        uint64_t v = 0, c;
        int valid;
        if (!sqffd_io__next_line(&t, &s, &e))
            return sqffd_io__fail(err, err_size, name, "file ends after %llu of %llu points", (unsigned long long)i,
                                  (unsigned long long)n);
        for (f = 0; f < h->fields; f++) {
            const sqffd_io__pcd_field *fd = &h->field[f];
            for (c = 0; c < fd->count; c++, v++) {
                if (!sqffd_io__line_token(&s, e, &tok, &len))
                    return sqffd_io__fail(err, err_size, name, "point %llu (line %llu): expected %llu values, found "
                                          "%llu", (unsigned long long)i, t.line, (unsigned long long)values,
                                          (unsigned long long)v);
                if (fd->role &&
                    sqffd_io__pcd_ascii_value(tok, len, fd, i, t.line, &xyz[fd->role - 1], name, err, err_size))
                    return 1;
            }
        }
        valid = sqffd_io__pcd_valid(xyz, i, name, err, err_size);
        if (valid < 0) return 1;
        if (valid) memcpy(pts->xyz + 3 * pts->count++, xyz, sizeof xyz);
        else (*dropped)++;
    }
    return 0;
}

/* The points of a binary or binary_compressed body, checked against the
   bytes present before anything is allocated. */
static inline int sqffd_io__pcd_binary(const unsigned char *bytes, size_t size, sqffd_io__pcd *h,
                                       sqffd_io__points *pts, size_t *dropped, const char *name, char *err,
                                       size_t err_size)
{
    size_t start = (size_t)(h->body.p - (const char *)bytes), remaining = size - start;
    size_t offset[3] = {0, 0, 0}, stride[3] = {0, 0, 0}, at, done;
    int type[3] = {0, 0, 0}, f, compressed = h->encoding == SQFFD_IO__PCD_COMPRESSED, r;
    uint64_t n = h->header.points, record = 0, compressed_size, uncompressed_size;
    unsigned char *raw;
    const char *problem;
    for (f = 0; f < h->fields; f++) { /* a point's bytes; compressed data hold no padding */
        const sqffd_io__pcd_field *fd = &h->field[f];
        if (compressed && sqffd_io__pcd_padding(fd)) continue;
        if (fd->count > (UINT64_MAX - record) / fd->size)
            return sqffd_io__fail(err, err_size, name, "the fields' SIZE x COUNT add up past 2^64 bytes a point");
        if (fd->role) { /* offsets below `record`, checked against the data's size before any use */
            offset[fd->role - 1] = (size_t)record;
            stride[fd->role - 1] = fd->size; /* compressed: the next point's value follows; binary: set below */
            type[fd->role - 1] = fd->type;
        }
        record += fd->size * fd->count;
    }
    if (!compressed) {
        if (n > (uint64_t)remaining / record)
            return sqffd_io__fail(err, err_size, name, "header says %llu points of %llu bytes each, file holds %llu "
                                  "bytes of data", (unsigned long long)n, (unsigned long long)record,
                                  (unsigned long long)remaining);
        for (f = 0; f < 3; f++) stride[f] = (size_t)record;
        if (sqffd_io__reserve(pts, (size_t)n))
            return sqffd_io__fail(err, err_size, name, "out of memory for %llu points", (unsigned long long)n);
        return sqffd_io__pcd_extract(bytes + start, n, offset, stride, type, pts, dropped, name, err, err_size);
    }
    if (remaining < 8)
        return sqffd_io__fail(err, err_size, name, "file ends before the binary_compressed sizes (8 bytes after DATA)");
    compressed_size = (uint64_t)bytes[start] | (uint64_t)bytes[start + 1] << 8 | (uint64_t)bytes[start + 2] << 16 |
                      (uint64_t)bytes[start + 3] << 24;
    uncompressed_size = (uint64_t)bytes[start + 4] | (uint64_t)bytes[start + 5] << 8 |
                        (uint64_t)bytes[start + 6] << 16 | (uint64_t)bytes[start + 7] << 24;
    if (compressed_size > remaining - 8)
        return sqffd_io__fail(err, err_size, name, "%llu bytes of compressed data, file holds %llu after the sizes",
                              (unsigned long long)compressed_size, (unsigned long long)(remaining - 8));
    if (n > uncompressed_size / record || n * record != uncompressed_size)
        return sqffd_io__fail(err, err_size, name, "uncompressed size %llu bytes, but %llu points of %llu bytes take "
                              "%s%llu", (unsigned long long)uncompressed_size, (unsigned long long)n,
                              (unsigned long long)record, n > UINT64_MAX / record ? "more than " : "",
                              (unsigned long long)(n > UINT64_MAX / record ? UINT64_MAX : n * record));
    if (uncompressed_size > compressed_size * SQFFD_IO__LZF_MAX_EXPANSION)
        return sqffd_io__fail(err, err_size, name, "%llu compressed bytes cannot hold %llu (LZF expands at most "
                              "%d-fold)", (unsigned long long)compressed_size, (unsigned long long)uncompressed_size,
                              SQFFD_IO__LZF_MAX_EXPANSION);
    raw = (unsigned char *)malloc((size_t)uncompressed_size);
    if (!raw)
        return sqffd_io__fail(err, err_size, name, "out of memory for %llu uncompressed bytes",
                              (unsigned long long)uncompressed_size);
    if (sqffd_io__lzf_decompress(bytes + start + 8, (size_t)compressed_size, raw, (size_t)uncompressed_size, &problem,
                                 &at, &done)) {
        free(raw);
        return sqffd_io__fail(err, err_size, name, "binary_compressed data: %s (compressed byte %llu, %llu of %llu "
                              "bytes decompressed)", problem, (unsigned long long)at, (unsigned long long)done,
                              (unsigned long long)uncompressed_size);
    }
    for (f = 0; f < 3; f++) offset[f] *= (size_t)n; /* field by field: each field's block is n values long */
    r = sqffd_io__reserve(pts, (size_t)n)
            ? sqffd_io__fail(err, err_size, name, "out of memory for %llu points", (unsigned long long)n)
            : sqffd_io__pcd_extract(raw, n, offset, stride, type, pts, dropped, name, err, err_size);
    free(raw);
    return r;
}

/* PCD: ascii, binary or binary_compressed (see above), versions 0.6 and
   0.7. x, y and z are read whatever their type (I, U, F of any size) and
   place; every other field is skipped. A point with a NaN coordinate
   (PCL's invalid depth pixel) is dropped and counted; an infinite one is
   an error, and so is a cloud without a valid point. Binary data are read
   as little endian (PCL writes the host's order: little endian on every
   platform it is used on). Bytes after the last point are ignored (PCL's
   binary writer may pad its files). info may be NULL. */
static inline int sqffd_io_read_pcd(const void *data, size_t size, const char *name, double **points, size_t *count,
                                    sqffd_io_info *info, char *err, size_t err_size)
{
    sqffd_io__points pts = {NULL, 0, 0};
    sqffd_io__pcd *h;
    size_t dropped = 0;
    int r;
    *points = NULL;
    *count = 0;
    h = (sqffd_io__pcd *)malloc(sizeof *h);
    if (!h) return sqffd_io__fail(err, err_size, name, "out of memory");
    r = sqffd_io__pcd_header((const char *)data, size, h, name, err, err_size);
    if (!r)
        r = h->encoding == SQFFD_IO__PCD_ASCII
                ? sqffd_io__pcd_ascii(h, &pts, &dropped, name, err, err_size)
                : sqffd_io__pcd_binary((const unsigned char *)data, size, h, &pts, &dropped, name, err, err_size);
    if (!r && pts.count == 0)
        r = sqffd_io__fail(err, err_size, name, "all %llu points have NaN coordinates (invalid depth): no point to "
                           "read", (unsigned long long)h->header.points);
    if (r) {
        free(h);
        free(pts.xyz);
        return 1;
    }
    if (info) {
        memset(info, 0, sizeof *info);
        info->format = SQFFD_IO_PCD;
        info->dropped_nan = dropped;
        info->pcd = h->header;
    }
    free(h);
    return sqffd_io__finish(&pts, points, count, name, err, err_size);
}

/* ---- legacy VTK ---------------------------------------------------------- */

/* The legacy VTK format (VTK's "File Formats" chapter): a line "# vtk
   DataFile Version x.y", a title line, ASCII or BINARY, "DATASET TYPE",
   then keyword sections in any order, each keyword line followed by its
   values: white-space separated numbers (ASCII), or big-endian binary
   values right after the keyword line's line break (BINARY). Keywords and
   type names are read in any case, as VTK does. The parts below are shared
   with the STRUCTURED_POINTS volume reader of sqffd_image.h: the header,
   the value types, reading or skipping a block of values, and skipping
   the sections neither reader takes (FIELD data, attributes, cells,
   METADATA), checked against the file's size as they go. */

typedef struct sqffd_io__vtk {
    sqffd_io__text t;  /* the cursor, at the next keyword */
    const char *start; /* the file's first byte */
    int binary;
    int major;         /* the version's major number: 5 and later write cells as OFFSETS and CONNECTIVITY */
    char version[8];   /* "3.0", "5.1", ... ("" when the line gives none) */
    char dataset[24];  /* STRUCTURED_POINTS, POLYDATA, ... as VTK spells them */
    int section;       /* 0 before any attribute section, else 'P' (POINT_DATA) or 'C' (CELL_DATA) */
    uint64_t tuples;   /* the current attribute section's count */
} sqffd_io__vtk;

/* Whether data start with VTK's first line, "# vtk DataFile Version" (any case). */
static inline int sqffd_io__vtk_magic(const void *data, size_t size)
{
    return size >= 22 && sqffd_io__is((const char *)data, 22, "# vtk DataFile Version");
}

/* The next token of the file, or a message that it ends before `what`. */
static inline int sqffd_io__vtk_word(sqffd_io__vtk *v, const char **tok, size_t *len, const char *what,
                                     const char *name, char *err, size_t err_size)
{
    *tok = v->t.end; /* set either way: the callers' compilers see every path */
    *len = 0;
    if (sqffd_io__token(&v->t, tok, len)) return 0;
    return sqffd_io__fail(err, err_size, name, "file ends before %s (line %llu)", what, v->t.line);
}

/* The next token as a count (a whole number below 2^64) into *count, or,
   count NULL, as a finite number into *number. */
static inline int sqffd_io__vtk_value(sqffd_io__vtk *v, uint64_t *count, double *number, const char *what,
                                      const char *name, char *err, size_t err_size)
{
    const char *tok;
    size_t len;
    char q[32];
    if (sqffd_io__vtk_word(v, &tok, &len, what, name, err, err_size)) return 1;
    if (count ? sqffd_io__parse_count(tok, len, count) != 0
              : sqffd_io__parse_double(tok, len, number) != SQFFD_IO__NUMBER)
        return sqffd_io__fail(err, err_size, name, "line %llu: %s: %s is not a %s", v->t.line, what,
                              sqffd_io__quote(tok, len, q), count ? "count" : "finite number");
    return 0;
}

static inline int sqffd_io__vtk_count(sqffd_io__vtk *v, uint64_t *count, const char *what, const char *name, char *err,
                                      size_t err_size)
{
    return sqffd_io__vtk_value(v, count, NULL, what, name, err, err_size);
}

/* Reads the header: the version line, the title line, ASCII or BINARY and
   "DATASET TYPE"; v is then at the first section's keyword. */
static inline int sqffd_io__vtk_header(const void *data, size_t size, sqffd_io__vtk *v, const char *name, char *err,
                                       size_t err_size)
{
    static const char *const datasets[] = {"STRUCTURED_POINTS", "STRUCTURED_GRID", "UNSTRUCTURED_GRID", "POLYDATA",
                                           "RECTILINEAR_GRID"};
    const char *text = (const char *)data, *s, *e, *tok, *nl;
    size_t len, i;
    char q[32];
    memset(v, 0, sizeof *v);
    v->start = text;
    if (!sqffd_io__vtk_magic(data, size))
        return sqffd_io__fail(err, err_size, name, "not a legacy VTK file: the first line is not '# vtk DataFile "
                              "Version x.y'");
    nl = (const char *)memchr(text, '\n', size);
    s = text + 22;
    e = nl ? nl : text + size;
    if (sqffd_io__line_token(&s, e, &tok, &len)) {
        snprintf(v->version, sizeof v->version, "%.*s", (int)(len < 7 ? len : 7), tok);
        v->major = tok[0] >= '0' && tok[0] <= '9' ? tok[0] - '0' : 0;
    }
    nl = nl ? (const char *)memchr(nl + 1, '\n', (size_t)(text + size - nl - 1)) : NULL; /* the title line's end */
    if (!nl) return sqffd_io__fail(err, err_size, name, "file ends inside the header (after the title line)");
    v->t.p = nl + 1;
    v->t.end = text + size;
    v->t.line = 3;
    if (sqffd_io__vtk_word(v, &tok, &len, "ASCII or BINARY", name, err, err_size)) return 1;
    if (sqffd_io__is(tok, len, "BINARY")) v->binary = 1;
    else if (!sqffd_io__is(tok, len, "ASCII"))
        return sqffd_io__fail(err, err_size, name, "line %llu: expected ASCII or BINARY, found %s", v->t.line,
                              sqffd_io__quote(tok, len, q));
    if (sqffd_io__vtk_word(v, &tok, &len, "the DATASET line", name, err, err_size)) return 1;
    if (sqffd_io__is(tok, len, "FIELD"))
        return sqffd_io__fail(err, err_size, name, "a VTK data object (FIELD data only): no DATASET, no points");
    if (!sqffd_io__is(tok, len, "DATASET"))
        return sqffd_io__fail(err, err_size, name, "line %llu: expected DATASET, found %s", v->t.line,
                              sqffd_io__quote(tok, len, q));
    if (sqffd_io__vtk_word(v, &tok, &len, "the dataset type", name, err, err_size)) return 1;
    for (i = 0; i < sizeof datasets / sizeof datasets[0]; i++)
        if (sqffd_io__is(tok, len, datasets[i])) {
            snprintf(v->dataset, sizeof v->dataset, "%s", datasets[i]);
            return 0;
        }
    return sqffd_io__fail(err, err_size, name, "line %llu: unknown DATASET type %s", v->t.line,
                          sqffd_io__quote(tok, len, q));
}

/* A VTK value type (SQFFD_IO__I8 ... SQFFD_IO__U64) from its name; -1 with a
   message for names VTK has that carry no number this reader can size
   (bit, string, a binary long), or that VTK does not have. */
static inline int sqffd_io__vtk_type(const sqffd_io__vtk *v, const char *tok, size_t len, const char *name,
                                     char *err, size_t err_size)
{
    /* vtkIdType: VTK writes it as int in legacy files */
    static const struct { const char *name; int type; } types[] = {
        {"unsigned_char", SQFFD_IO__U8}, {"char", SQFFD_IO__I8},          {"signed_char", SQFFD_IO__I8},
        {"unsigned_short", SQFFD_IO__U16}, {"short", SQFFD_IO__I16},      {"unsigned_int", SQFFD_IO__U32},
        {"int", SQFFD_IO__I32},          {"vtkIdType", SQFFD_IO__I32},    {"float", SQFFD_IO__F32},
        {"double", SQFFD_IO__F64},       {"vtktypeint64", SQFFD_IO__I64}, {"vtktypeuint64", SQFFD_IO__U64},
        {"long", SQFFD_IO__I64},         {"unsigned_long", SQFFD_IO__U64}};
    size_t i;
    char q[32];
    for (i = 0; i < sizeof types / sizeof types[0]; i++)
        if (sqffd_io__is(tok, len, types[i].name)) {
            if (!v->binary || len < 4 || !sqffd_io__is(tok + len - 4, 4, "long")) return types[i].type;
            sqffd_io__fail(err, err_size, name, "line %llu: binary %s values: their size is the writing platform's "
                           "(write vtktypeint64)", v->t.line, sqffd_io__quote(tok, len, q));
            return -1;
        }
    sqffd_io__fail(err, err_size, name, "line %llu: value type %s is not read (unsigned_char, char, unsigned_short, "
                   "short, unsigned_int, int, float, double, vtktypeint64 are)", v->t.line,
                   sqffd_io__quote(tok, len, q));
    return -1;
}

/* Moves a binary file's cursor past the rest of the keyword line: the
   values start after its line break. */
static inline void sqffd_io__vtk_data_start(sqffd_io__vtk *v)
{
    const char *nl;
    if (!v->binary) return;
    nl = (const char *)memchr(v->t.p, '\n', (size_t)(v->t.end - v->t.p));
    v->t.p = nl ? nl + 1 : v->t.end;
    v->t.line++;
}

/* Moves to the values of the block `what` (for messages) and checks that
   the bytes left can hold `count` values of `type`: as many times its size
   (binary), at least a character and a separator each (ASCII). */
static inline int sqffd_io__vtk_room(sqffd_io__vtk *v, int type, uint64_t count, const char *what, const char *name,
                                     char *err, size_t err_size)
{
    size_t left, item = sqffd_io__type_size(type);
    sqffd_io__vtk_data_start(v);
    left = (size_t)(v->t.end - v->t.p);
    if (v->binary && count > (uint64_t)(left / item))
        return sqffd_io__fail(err, err_size, name, "%s: %llu values of %u bytes, the file holds %llu bytes after "
                              "line %llu", what, (unsigned long long)count, (unsigned)item, (unsigned long long)left,
                              v->t.line - 1);
    if (!v->binary && count > (uint64_t)(left / 2 + 1))
        return sqffd_io__fail(err, err_size, name, "%s: %llu values, the file holds %llu bytes after line %llu", what,
                              (unsigned long long)count, (unsigned long long)left, v->t.line);
    return 0;
}

/* Reads (out not NULL: into out, every value finite) or skips the `count`
   values of `type` sqffd_io__vtk_room found room for. A float value read
   from ASCII is rounded to float, as the binary file would hold it. */
static inline int sqffd_io__vtk_read(sqffd_io__vtk *v, int type, uint64_t count, double *out, const char *what,
                                     const char *name, char *err, size_t err_size)
{
    size_t i;
    if (v->binary) {
        size_t item = sqffd_io__type_size(type);
        const unsigned char *p = (const unsigned char *)v->t.p;
        if (out)
            for (i = 0; i < (size_t)count; i++) {
                out[i] = sqffd_io__ply_load(p + i * item, type, 1);
                if (!isfinite(out[i]))
                    return sqffd_io__fail(err, err_size, name, "%s: value %llu is not finite (%g)", what,
                                          (unsigned long long)i, out[i]);
            }
        for (i = 0; i < (size_t)count * item; i++) v->t.line += p[i] == '\n'; /* line numbers stay the file's */
        v->t.p += (size_t)count * item;
        return 0;
    }
    for (i = 0; i < (size_t)count; i++) {
        const char *tok;
        size_t len;
        char q[32];
        int r;
        if (!sqffd_io__token(&v->t, &tok, &len))
            return sqffd_io__fail(err, err_size, name, "%s: file ends after %llu of %llu values", what,
                                  (unsigned long long)i, (unsigned long long)count);
        if (!out) continue;
        r = sqffd_io__parse_double(tok, len, &out[i]);
        if (r == SQFFD_IO__NUMBER && type == SQFFD_IO__F32) {
            out[i] = (double)sqffd_io__to_float(out[i]);
            if (!isfinite(out[i])) r = SQFFD_IO__NOT_FINITE;
        }
        if (r != SQFFD_IO__NUMBER)
            return sqffd_io__fail(err, err_size, name, "%s: value %llu (line %llu), %s, is not a finite number", what,
                                  (unsigned long long)i, v->t.line, sqffd_io__quote(tok, len, q));
    }
    return 0;
}

/* sqffd_io__vtk_room, then sqffd_io__vtk_read. */
static inline int sqffd_io__vtk_values(sqffd_io__vtk *v, int type, uint64_t count, double *out, const char *what,
                                       const char *name, char *err, size_t err_size)
{
    return sqffd_io__vtk_room(v, type, count, what, name, err, err_size) ||
           sqffd_io__vtk_read(v, type, count, out, what, name, err, err_size);
}

/* Skips `count` x `per` values of `type` (the product checked for overflow). */
static inline int sqffd_io__vtk_skip_values(sqffd_io__vtk *v, int type, uint64_t count, uint64_t per,
                                            const char *what, const char *name, char *err, size_t err_size)
{
    if (per && count > UINT64_MAX / per)
        return sqffd_io__fail(err, err_size, name, "%s: %llu x %llu values overflow", what, (unsigned long long)count,
                              (unsigned long long)per);
    return sqffd_io__vtk_values(v, type, count * per, NULL, what, name, err, err_size);
}

/* Skips `count` x `per` values of the type named by the next token. */
static inline int sqffd_io__vtk_skip_typed(sqffd_io__vtk *v, uint64_t count, uint64_t per, const char *what,
                                           const char *name, char *err, size_t err_size)
{
    const char *tok;
    size_t len;
    int type;
    if (sqffd_io__vtk_word(v, &tok, &len, "a value type", name, err, err_size)) return 1;
    type = sqffd_io__vtk_type(v, tok, len, name, err, err_size);
    return type < 0 || sqffd_io__vtk_skip_values(v, type, count, per, what, name, err, err_size);
}

/* The rest of a SCALARS line and its LOOKUP_TABLE line: "name type
   [components] LOOKUP_TABLE table" (VTK requires the table's name). */
static inline int sqffd_io__vtk_scalars(sqffd_io__vtk *v, int *type, uint64_t *components, const char *what,
                                        const char *name, char *err, size_t err_size)
{
    const char *w, *type_name;
    size_t wl, type_len;
    char q[32];
    *components = 1;
    if (sqffd_io__vtk_word(v, &w, &wl, "the SCALARS name", name, err, err_size) ||
        sqffd_io__vtk_word(v, &type_name, &type_len, "the SCALARS type", name, err, err_size) ||
        sqffd_io__vtk_word(v, &w, &wl, "LOOKUP_TABLE", name, err, err_size))
        return 1;
    if (!sqffd_io__is(w, wl, "LOOKUP_TABLE")) {
        if (sqffd_io__parse_count(w, wl, components) || *components == 0)
            return sqffd_io__fail(err, err_size, name, "%s: %s is neither a component count nor LOOKUP_TABLE", what,
                                  sqffd_io__quote(w, wl, q));
        if (sqffd_io__vtk_word(v, &w, &wl, "LOOKUP_TABLE", name, err, err_size)) return 1;
        if (!sqffd_io__is(w, wl, "LOOKUP_TABLE"))
            return sqffd_io__fail(err, err_size, name, "%s: expected LOOKUP_TABLE, found %s", what,
                                  sqffd_io__quote(w, wl, q));
    }
    if (sqffd_io__vtk_word(v, &w, &wl, "the lookup table's name", name, err, err_size)) return 1;
    *type = sqffd_io__vtk_type(v, type_name, type_len, name, err, err_size);
    return *type < 0;
}

/* Skips the section whose keyword [tok, tok + len) was just read, when it
   is one neither reader takes values from: FIELD data, the attributes of
   POINT_DATA and CELL_DATA (SCALARS with their LOOKUP_TABLE, COLOR_SCALARS,
   LOOKUP_TABLE, VECTORS, NORMALS, TEXTURE_COORDINATES, TENSORS, TENSORS6,
   GLOBAL_IDS, PEDIGREE_IDS), the cells (VERTICES, LINES, POLYGONS,
   TRIANGLE_STRIPS, CELLS: in files of version 5 and later as OFFSETS and
   CONNECTIVITY arrays; CELL_TYPES) and METADATA (lines up to a blank one).
   POINT_DATA and CELL_DATA set the section. Returns 0, 1 after a message,
   or 2 when the keyword is none of these (nothing read). */
static inline int sqffd_io__vtk_skip(sqffd_io__vtk *v, const char *tok, size_t len, const char *name, char *err,
                                     size_t err_size)
{
    static const char *const cells[] = {"VERTICES", "LINES", "POLYGONS", "TRIANGLE_STRIPS", "CELLS"};
    /* name [components] type, then tuples x components values; 0 components: given on the line */
    static const struct { const char *name; unsigned components; } arrays[] = {
        {"VECTORS", 3}, {"NORMALS", 3}, {"TENSORS", 9}, {"TENSORS6", 6}, {"GLOBAL_IDS", 1}, {"PEDIGREE_IDS", 1},
        {"TEXTURE_COORDINATES", 0}};
    char what[48], q[32];
    const char *w;
    size_t wl, i;
    uint64_t n, m;
    int type = 0, colours = sqffd_io__is(tok, len, "COLOR_SCALARS"), table = sqffd_io__is(tok, len, "LOOKUP_TABLE");
    snprintf(what, sizeof what, "%.*s (line %llu)", (int)(len < 24 ? len : 24), tok, v->t.line);
    if (sqffd_io__is(tok, len, "POINT_DATA") || sqffd_io__is(tok, len, "CELL_DATA")) {
        v->section = tok[0] == 'P' || tok[0] == 'p' ? 'P' : 'C';
        return sqffd_io__vtk_count(v, &v->tuples, what, name, err, err_size);
    }
    if (sqffd_io__is(tok, len, "METADATA")) { /* the rest of its line, then lines up to a blank one */
        const char *s = v->t.p, *e;
        int first = 1, blank;
        do {
            e = (const char *)memchr(s, '\n', (size_t)(v->t.end - s));
            if (!e) return sqffd_io__fail(err, err_size, name, "%s: file ends before the blank line that ends it", what);
            while (s < e && sqffd_io__is_space(*s)) s++;
            blank = s == e && !first;
            first = 0;
            s = e + 1;
            v->t.line++;
        } while (!blank);
        v->t.p = s;
        return 0;
    }
    if (sqffd_io__is(tok, len, "FIELD")) {
        uint64_t count, a;
        if (sqffd_io__vtk_word(v, &w, &wl, "the FIELD's name", name, err, err_size) ||
            sqffd_io__vtk_count(v, &count, what, name, err, err_size))
            return 1;
        for (a = 0; a < count; a++) {
            if (sqffd_io__vtk_word(v, &w, &wl, "a FIELD array", name, err, err_size)) return 1;
            if (sqffd_io__is(w, wl, "NULL_ARRAY")) continue;
            snprintf(what, sizeof what, "FIELD array %s", sqffd_io__quote(w, wl, q));
            if (sqffd_io__vtk_count(v, &n, what, name, err, err_size) ||
                sqffd_io__vtk_count(v, &m, what, name, err, err_size) ||
                sqffd_io__vtk_skip_typed(v, n, m, what, name, err, err_size))
                return 1;
        }
        return 0;
    }
    if (sqffd_io__is(tok, len, "CELL_TYPES"))
        return sqffd_io__vtk_count(v, &n, what, name, err, err_size) ||
               sqffd_io__vtk_values(v, SQFFD_IO__I32, n, NULL, what, name, err, err_size);
    for (i = 0; i < sizeof cells / sizeof cells[0]; i++) {
        if (!sqffd_io__is(tok, len, cells[i])) continue;
        if (sqffd_io__vtk_count(v, &n, what, name, err, err_size) ||
            sqffd_io__vtk_count(v, &m, what, name, err, err_size))
            return 1;
        if (v->major < 5) return sqffd_io__vtk_values(v, SQFFD_IO__I32, m, NULL, what, name, err, err_size);
        if (sqffd_io__vtk_word(v, &w, &wl, "OFFSETS", name, err, err_size)) return 1;
        if (!sqffd_io__is(w, wl, "OFFSETS"))
            return sqffd_io__fail(err, err_size, name, "%s: expected OFFSETS (a version %s file), found %s", what,
                                  v->version, sqffd_io__quote(w, wl, q));
        if (sqffd_io__vtk_skip_typed(v, n, 1, what, name, err, err_size) ||
            sqffd_io__vtk_word(v, &w, &wl, "CONNECTIVITY", name, err, err_size))
            return 1;
        if (!sqffd_io__is(w, wl, "CONNECTIVITY"))
            return sqffd_io__fail(err, err_size, name, "%s: expected CONNECTIVITY, found %s", what,
                                  sqffd_io__quote(w, wl, q));
        return sqffd_io__vtk_skip_typed(v, m, 1, what, name, err, err_size);
    }
    if (table) /* LOOKUP_TABLE name size: size RGBA colours */
        return sqffd_io__vtk_word(v, &w, &wl, "the lookup table's name", name, err, err_size) ||
               sqffd_io__vtk_count(v, &n, what, name, err, err_size) ||
               sqffd_io__vtk_skip_values(v, v->binary ? SQFFD_IO__U8 : SQFFD_IO__F32, n, 4, what, name, err,
                                         err_size);
    if (!colours && !sqffd_io__is(tok, len, "SCALARS")) {
        for (i = 0; i < sizeof arrays / sizeof arrays[0] && !sqffd_io__is(tok, len, arrays[i].name); i++) {}
        if (i == sizeof arrays / sizeof arrays[0]) return 2;
    }
    if (!v->section) return sqffd_io__fail(err, err_size, name, "%s: an attribute before POINT_DATA or CELL_DATA", what);
    if (colours) /* COLOR_SCALARS name components: bytes in binary files, floats in ASCII */
        return sqffd_io__vtk_word(v, &w, &wl, "the COLOR_SCALARS name", name, err, err_size) ||
               sqffd_io__vtk_count(v, &n, what, name, err, err_size) ||
               sqffd_io__vtk_skip_values(v, v->binary ? SQFFD_IO__U8 : SQFFD_IO__F32, v->tuples, n, what, name, err,
                                         err_size);
    if (sqffd_io__is(tok, len, "SCALARS"))
        return sqffd_io__vtk_scalars(v, &type, &n, what, name, err, err_size) ||
               sqffd_io__vtk_skip_values(v, type, v->tuples, n, what, name, err, err_size);
    n = arrays[i].components;
    return sqffd_io__vtk_word(v, &w, &wl, "the attribute's name", name, err, err_size) ||
           (n == 0 && sqffd_io__vtk_count(v, &n, what, name, err, err_size)) ||
           sqffd_io__vtk_skip_typed(v, v->tuples, n, what, name, err, err_size);
}

/* Legacy VTK points: the POINTS of a POLYDATA, UNSTRUCTURED_GRID or
   STRUCTURED_GRID dataset (ASCII or big-endian BINARY, any numeric type;
   a float read from ASCII is rounded to float). The sections before POINTS
   are skipped (sqffd_io__vtk_skip), a STRUCTURED_GRID's DIMENSIONS must
   multiply to the point count, and the file is not read past the points.
   A STRUCTURED_POINTS dataset is a volume: sqffd_image.h reads it.
   info (may be NULL) gets the version, the dataset and the encoding. */
static inline int sqffd_io_read_vtk(const void *data, size_t size, const char *name, double **points, size_t *count,
                                    sqffd_io_info *info, char *err, size_t err_size)
{
    sqffd_io__points pts = {NULL, 0, 0};
    sqffd_io__vtk v;
    const char *tok;
    size_t len;
    uint64_t n, dims[3] = {0, 0, 0};
    char q[32], what[48];
    int type, k, has_dims = 0;
    *points = NULL;
    *count = 0;
    if (sqffd_io__vtk_header(data, size, &v, name, err, err_size)) return 1;
    if (strcmp(v.dataset, "STRUCTURED_POINTS") == 0)
        return sqffd_io__fail(err, err_size, name, "DATASET STRUCTURED_POINTS is a volume, not points (read it as a "
                              "volume, with an iso level or a label)");
    if (strcmp(v.dataset, "RECTILINEAR_GRID") == 0)
        return sqffd_io__fail(err, err_size, name, "DATASET RECTILINEAR_GRID is not read (the POINTS of POLYDATA, "
                              "UNSTRUCTURED_GRID and STRUCTURED_GRID are)");
    for (;;) {
        int r;
        if (!sqffd_io__token(&v.t, &tok, &len))
            return sqffd_io__fail(err, err_size, name, "DATASET %s without POINTS: no points", v.dataset);
        snprintf(what, sizeof what, "%.*s (line %llu)", (int)(len < 24 ? len : 24), tok, v.t.line);
        if (sqffd_io__is(tok, len, "DIMENSIONS") && strcmp(v.dataset, "STRUCTURED_GRID") == 0) {
            for (k = 0; k < 3; k++)
                if (sqffd_io__vtk_count(&v, &dims[k], what, name, err, err_size)) return 1;
            has_dims = 1;
            continue;
        }
        if (sqffd_io__is(tok, len, "POINTS")) break;
        r = sqffd_io__vtk_skip(&v, tok, len, name, err, err_size);
        if (r == 1) return 1;
        if (r == 2)
            return sqffd_io__fail(err, err_size, name, "line %llu: unknown keyword %s in DATASET %s", v.t.line,
                                  sqffd_io__quote(tok, len, q), v.dataset);
    }
    if (sqffd_io__vtk_count(&v, &n, what, name, err, err_size) ||
        sqffd_io__vtk_word(&v, &tok, &len, "the POINTS type", name, err, err_size))
        return 1;
    type = sqffd_io__vtk_type(&v, tok, len, name, err, err_size);
    if (type < 0) return 1;
    if (n == 0) return sqffd_io__fail(err, err_size, name, "%s: 0 points", what);
    if (has_dims && (dims[0] == 0 || dims[1] == 0 || dims[1] > UINT64_MAX / dims[0] || dims[2] > UINT64_MAX / (dims[0] * dims[1]) ||
                     dims[0] * dims[1] * dims[2] != n))
        return sqffd_io__fail(err, err_size, name, "DIMENSIONS %llu x %llu x %llu do not make the %llu POINTS",
                              (unsigned long long)dims[0], (unsigned long long)dims[1], (unsigned long long)dims[2],
                              (unsigned long long)n);
    /* the room first: the allocation is bounded by the file's size */
    if (n > UINT64_MAX / 3 || sqffd_io__vtk_room(&v, type, 3 * n, what, name, err, err_size)) {
        if (n > UINT64_MAX / 3) sqffd_io__fail(err, err_size, name, "%s: %llu points overflow", what, (unsigned long long)n);
        return 1;
    }
    if (sqffd_io__reserve(&pts, (size_t)n))
        return sqffd_io__fail(err, err_size, name, "out of memory for %llu points", (unsigned long long)n);
    if (sqffd_io__vtk_read(&v, type, 3 * n, pts.xyz, what, name, err, err_size)) {
        free(pts.xyz);
        return 1;
    }
    pts.count = (size_t)n;
    if (info) {
        info->format = SQFFD_IO_VTK;
        info->binary = v.binary;
        memcpy(info->vtk_version, v.version, sizeof v.version);
        memcpy(info->vtk_dataset, v.dataset, sizeof v.dataset);
    }
    return sqffd_io__finish(&pts, points, count, name, err, err_size);
}

/* ---- STL ----------------------------------------------------------------- */

/* STL, binary: an 80-byte header, a uint32 triangle count, then per
   triangle a normal and three vertices (12 little-endian floats) and a
   2-byte attribute: 84 + 50 n bytes. ASCII: "solid NAME", then facets
   "facet normal nx ny nz / outer loop / vertex x y z (3 times) / endloop /
   endfacet", then "endsolid NAME" (several solids may follow one another);
   coordinates are floats in both (ASCII ones are rounded to float, so both
   versions of a file give the same points).
   Binary files may start with "solid" too: a file is read as ASCII when
   its first word is "solid" and it is all text (no control byte other than
   white space), as binary otherwise (a binary STL's zero attribute bytes
   and float bytes are not text). */

/* Whether a file of `size` bytes has the size of a binary STL whose count
   (bytes 80-83) is at least 1. A text file's bytes 80-83 give a count far
   beyond the file size limit, so no text file matches. */
static inline int sqffd_io__stl_binary_size(const unsigned char *b, size_t size)
{
    return size >= 134 && (uint64_t)sqffd_gz__load32_le(b + 80) * 50 + 84 == size;
}

/* Whether the first word is "solid" (after any white space). */
static inline int sqffd_io__stl_solid(const unsigned char *b, size_t size)
{
    size_t i = 0;
    while (i < size && sqffd_io__is_space((char)b[i])) i++;
    return size - i >= 5 && memcmp(b + i, "solid", 5) == 0 && (size - i == 5 || sqffd_io__is_space((char)b[i + 5]));
}

/* Whether every byte is text: no control byte other than white space. */
static inline int sqffd_io__all_text(const unsigned char *b, size_t size)
{
    size_t i;
    for (i = 0; i < size; i++)
        if ((b[i] < 32 && !sqffd_io__is_space((char)b[i])) || b[i] == 127) return 0;
    return 1;
}

/* Whether point a comes before point b: x, then y, then z. */
static inline int sqffd_io__xyz_less(const double *a, const double *b)
{
    return a[0] < b[0] || (a[0] == b[0] && (a[1] < b[1] || (a[1] == b[1] && a[2] < b[2])));
}

/* Merges equal points (the same x, y and z; -0 equals 0), keeping each
   one's first occurrence, in the order of first occurrences: a stable
   merge sort of the indices by coordinates (O(n log n)), then each run of
   equal points keeps its first index. 0, or 1 when out of memory. */
static inline int sqffd_io__merge_equal(sqffd_io__points *pts)
{
    size_t n = pts->count, width, lo, i, kept = 0;
    size_t *order, *other, *swap;
    unsigned char *keep;
    const double *xyz = pts->xyz;
    if (n > (size_t)-1 / (2 * sizeof(size_t))) return 1;
    order = (size_t *)malloc(2 * n * sizeof *order + 1);
    keep = (unsigned char *)calloc(n + 1, 1);
    if (!order || !keep) {
        free(order);
        free(keep);
        return 1;
    }
    other = order + n;
    for (i = 0; i < n; i++) order[i] = i;
    for (width = 1; width < n; width *= 2) {
        for (lo = 0; lo < n; lo += 2 * width) {
            size_t mid = lo + width < n ? lo + width : n, hi = mid + width < n ? mid + width : n;
            size_t a = lo, b = mid, out = lo;
            while (a < mid && b < hi) /* stable: the left run wins ties */
                other[out++] = sqffd_io__xyz_less(xyz + 3 * order[b], xyz + 3 * order[a]) ? order[b++] : order[a++];
            while (a < mid) other[out++] = order[a++];
            while (b < hi) other[out++] = order[b++];
        }
        swap = order;
        order = other;
        other = swap;
    }
    for (i = 0; i < n; i++)
        if (i == 0 || sqffd_io__xyz_less(xyz + 3 * order[i - 1], xyz + 3 * order[i])) keep[order[i]] = 1;
    for (i = 0; i < n; i++)
        if (keep[i]) {
            memmove(pts->xyz + 3 * kept, pts->xyz + 3 * i, 3 * sizeof(double));
            kept++;
        }
    pts->count = kept;
    free(order < other ? order : other); /* the block's start */
    free(keep);
    return 0;
}

/* The vertices of an ASCII STL into pts (3 a facet); *triangles counts the facets. */
static inline int sqffd_io__stl_ascii(const void *data, size_t size, sqffd_io__points *pts, size_t *triangles,
                                      const char *name, char *err, size_t err_size)
{
    sqffd_io__text t;
    const char *tok, *nl;
    size_t len;
    char q[32];
    int k, c;
    t.p = (const char *)data;
    t.end = t.p + size;
    t.line = 1;
    *triangles = 0;
    while (sqffd_io__token(&t, &tok, &len)) { /* "solid NAME": the name is the rest of the line */
        if (!sqffd_io__is(tok, len, "solid"))
            return sqffd_io__fail(err, err_size, name, "line %llu: expected solid, found %s", t.line,
                                  sqffd_io__quote(tok, len, q));
        nl = (const char *)memchr(t.p, '\n', (size_t)(t.end - t.p));
        t.p = nl ? nl : t.end;
        for (;;) {
            unsigned long long facet_line;
            if (!sqffd_io__token(&t, &tok, &len))
                return sqffd_io__fail(err, err_size, name, "file ends before endsolid (after %llu facets)",
                                      (unsigned long long)*triangles);
            if (sqffd_io__is(tok, len, "endsolid")) {
                nl = (const char *)memchr(t.p, '\n', (size_t)(t.end - t.p));
                t.p = nl ? nl : t.end;
                break;
            }
            if (!sqffd_io__is(tok, len, "facet"))
                return sqffd_io__fail(err, err_size, name, "line %llu: expected facet or endsolid, found %s", t.line,
                                      sqffd_io__quote(tok, len, q));
            facet_line = t.line;
            if (pts->count + 3 > pts->capacity && sqffd_io__reserve(pts, pts->capacity ? 2 * pts->capacity : 3072))
                return sqffd_io__fail(err, err_size, name, "out of memory at line %llu", t.line);
            /* normal nx ny nz outer loop, 3 x (vertex x y z), endloop endfacet; the normal is not used */
            for (k = 0; k < 18; k++) {
                static const char *const words[18] = {"normal", NULL, NULL, NULL, "outer", "loop",
                                                      "vertex", NULL, NULL, NULL, "vertex", NULL, NULL, NULL,
                                                      "vertex", NULL, NULL, NULL};
                double value;
                int r;
                if (!sqffd_io__token(&t, &tok, &len))
                    return sqffd_io__fail(err, err_size, name, "file ends inside facet %llu (line %llu)",
                                          (unsigned long long)*triangles, facet_line);
                if (words[k]) {
                    if (!sqffd_io__is(tok, len, words[k]))
                        return sqffd_io__fail(err, err_size, name, "facet %llu (line %llu): expected %s, found %s",
                                              (unsigned long long)*triangles, t.line, words[k],
                                              sqffd_io__quote(tok, len, q));
                    continue;
                }
                r = sqffd_io__parse_double(tok, len, &value);
                if (k > 3 && r == SQFFD_IO__NUMBER && !isfinite((double)sqffd_io__to_float(value)))
                    r = SQFFD_IO__NOT_FINITE; /* beyond float */
                if (r == SQFFD_IO__NOT_NUMBER || (k > 3 && r != SQFFD_IO__NUMBER))
                    return sqffd_io__fail(err, err_size, name, "facet %llu (line %llu): %s is not a %snumber",
                                          (unsigned long long)*triangles, t.line, sqffd_io__quote(tok, len, q),
                                          r == SQFFD_IO__NOT_FINITE ? "finite " : "");
                if (k > 3) pts->xyz[3 * pts->count + (size_t)(k - 7) / 4 * 3 + (size_t)(k - 7) % 4] =
                    (double)sqffd_io__to_float(value);
            }
            for (c = 0; c < 2; c++) {
                if (!sqffd_io__token(&t, &tok, &len))
                    return sqffd_io__fail(err, err_size, name, "file ends inside facet %llu (line %llu)",
                                          (unsigned long long)*triangles, facet_line);
                if (!sqffd_io__is(tok, len, c ? "endfacet" : "endloop"))
                    return sqffd_io__fail(err, err_size, name, "facet %llu (line %llu): expected %s, found %s (a "
                                          "facet has 3 vertices)", (unsigned long long)*triangles, t.line,
                                          c ? "endfacet" : "endloop", sqffd_io__quote(tok, len, q));
            }
            pts->count += 3;
            (*triangles)++;
        }
    }
    return 0;
}

/* The vertices of a binary STL into pts; *triangles gets the count. */
static inline int sqffd_io__stl_binary(const unsigned char *b, size_t size, sqffd_io__points *pts, size_t *triangles,
                                       const char *name, char *err, size_t err_size)
{
    uint64_t n;
    size_t i;
    if (size < 84)
        return sqffd_io__fail(err, err_size, name, "binary STL of %llu bytes: shorter than its 84-byte header",
                              (unsigned long long)size);
    n = sqffd_gz__load32_le(b + 80);
    if (n * 50 + 84 != size)
        return sqffd_io__fail(err, err_size, name, "binary STL: %llu triangles take 84 + 50 x %llu = %llu bytes, the "
                              "file has %llu", (unsigned long long)n, (unsigned long long)n,
                              (unsigned long long)(n * 50 + 84), (unsigned long long)size);
    if (sqffd_io__reserve(pts, 3 * (size_t)n))
        return sqffd_io__fail(err, err_size, name, "out of memory for %llu triangles", (unsigned long long)n);
    for (i = 0; i < 9 * (size_t)n; i++) { /* vertex coordinate i % 9 of triangle i / 9, after its normal */
        double value = sqffd_io__le_f32(b + 84 + 50 * (i / 9) + 12 + 4 * (i % 9));
        if (!isfinite(value))
            return sqffd_io__fail(err, err_size, name, "triangle %llu: vertex %d: %c is not finite (%g)",
                                  (unsigned long long)(i / 9), (int)(i % 9) / 3, 'x' + (int)(i % 3), value);
        pts->xyz[i] = value;
    }
    pts->count = 3 * (size_t)n;
    *triangles = (size_t)n;
    return 0;
}

/* STL, ASCII or binary (see above): the triangles' vertices, equal ones
   merged (sqffd_io__merge_equal: each point once, in the order of first
   use). A file without triangles is an error, and so is a vertex with a
   NaN or infinite coordinate (normals are not read: any number goes).
   info (may be NULL) gets the encoding and the triangle count. */
static inline int sqffd_io_read_stl(const void *data, size_t size, const char *name, double **points, size_t *count,
                                    sqffd_io_info *info, char *err, size_t err_size)
{
    const unsigned char *b = (const unsigned char *)data;
    sqffd_io__points pts = {NULL, 0, 0};
    size_t triangles = 0;
    int ascii = sqffd_io__stl_solid(b, size) && sqffd_io__all_text(b, size);
    *points = NULL;
    *count = 0;
    if (ascii ? sqffd_io__stl_ascii(data, size, &pts, &triangles, name, err, err_size)
              : sqffd_io__stl_binary(b, size, &pts, &triangles, name, err, err_size)) {
        free(pts.xyz);
        return 1;
    }
    if (triangles == 0) {
        free(pts.xyz);
        return sqffd_io__fail(err, err_size, name, "%s STL without triangles", ascii ? "ASCII" : "binary");
    }
    if (sqffd_io__merge_equal(&pts)) {
        free(pts.xyz);
        return sqffd_io__fail(err, err_size, name, "out of memory merging %llu vertices",
                              (unsigned long long)pts.count);
    }
    if (info) {
        info->format = SQFFD_IO_STL;
        info->binary = !ascii;
        info->stl_triangles = triangles;
    }
    return sqffd_io__finish(&pts, points, count, name, err, err_size);
}

/* ---- format detection and files ------------------------------------------ */

/* A file in a format these readers and sqffd_image.h do not take, told by
   its content: one sentence naming it and what to do instead, or NULL.
   DICOM ("DICM" at byte 128), INRIMAGE ("#INRIMAGE-4#{"), HDF5 (its
   signature at byte 0: MINC 2, .h5), a zip archive ("PK\3\4"), Analyze 7.5
   (a 348-byte header, either byte order, without NIfTI-1's magic at byte
   344). None of these can be a supported file: the supported formats'
   content starts otherwise. A gzip stream is none of them (NULL): its
   content is told once inflated. */
static inline const char *sqffd_io_foreign_format(const void *data, size_t size)
{
    const unsigned char *b = (const unsigned char *)data;
    if (size >= 2 && b[0] == 0x1f && b[1] == 0x8b) return NULL;
    if (size >= 132 && memcmp(b + 128, "DICM", 4) == 0)
        return "DICOM is not read by sqffd; convert it to NIfTI (e.g. with dcm2niix)";
    if (size >= 13 && memcmp(b, "#INRIMAGE-4#{", 13) == 0)
        return "INRIMAGE is not read by sqffd; convert it to NIfTI, MetaImage or NRRD";
    if (size >= 8 && memcmp(b, "\x89HDF\r\n\x1a\n", 8) == 0)
        return "HDF5 (e.g. MINC 2) is not read by sqffd; export the volume as NIfTI (e.g. with mnc2nii) or the points "
               "as PLY or XYZ";
    if (size >= 4 && memcmp(b, "PK\x03\x04", 4) == 0) return "a zip archive is not read by sqffd; unpack it first";
    if (size >= 348 && (sqffd_gz__load32_le(b) == 348 || sqffd_gz__load32_le(b) == 0x5C010000u) && /* either order */
        memcmp(b + 344, "n+1", 4) != 0 && memcmp(b + 344, "ni1", 4) != 0)
        return "Analyze 7.5 (a .hdr without the NIfTI-1 magic) is not read by sqffd; convert it to NIfTI (e.g. with "
               "nibabel or fslchfiletype)";
    return NULL;
}

/* Whether the first n characters of name end in ext, in any case. */
static inline int sqffd_io__has_extension(const char *name, size_t n, const char *ext)
{
    size_t m = strlen(ext);
    return n >= m && sqffd_io__is(name + n - m, m, ext);
}

/* The format of a file: by content (the PLY magic line; the "# .PCD"
   comment PCL writes first; VTK's "# vtk DataFile Version" line; the size
   of a binary STL, or "solid" as the first word; VERSION or FIELDS as the
   first keyword; an OFF keyword or an OBJ statement as the first word),
   else by the name's extension (.ply, .pcd, .off, .obj, .vtk, .stl; a final
   .gz is skipped: x.ply.gz is PLY), else XYZ. */
static inline sqffd_io_format sqffd_io_detect(const void *data, size_t size, const char *name)
{
    const char *text = (const char *)data, *s, *e, *tok;
    sqffd_io__text t;
    size_t len, name_len = name ? strlen(name) : 0;
    int other_dimension;
    if (size >= 4 && memcmp(text, "ply", 3) == 0 && (text[3] == '\n' || text[3] == '\r')) return SQFFD_IO_PLY;
    if (size >= 6 && memcmp(text, "# .PCD", 6) == 0) return SQFFD_IO_PCD;
    if (sqffd_io__vtk_magic(data, size)) return SQFFD_IO_VTK;
    if (sqffd_io__stl_binary_size((const unsigned char *)data, size) ||
        sqffd_io__stl_solid((const unsigned char *)data, size))
        return SQFFD_IO_STL;
    t.p = text;
    t.end = text + size;
    t.line = 0;
    if (sqffd_io__next_line(&t, &s, &e) && sqffd_io__line_token(&s, e, &tok, &len)) {
        if ((len == 7 && memcmp(tok, "VERSION", 7) == 0) || (len == 6 && memcmp(tok, "FIELDS", 6) == 0))
            return SQFFD_IO_PCD;
        if (sqffd_io__off_keyword(tok, len, &other_dimension)) return SQFFD_IO_OFF;
        if (sqffd_io__obj_keyword(tok, len)) return SQFFD_IO_OBJ;
    }
    if (sqffd_io__has_extension(name, name_len, ".gz")) name_len -= 3;
    if (sqffd_io__has_extension(name, name_len, ".ply")) return SQFFD_IO_PLY;
    if (sqffd_io__has_extension(name, name_len, ".pcd")) return SQFFD_IO_PCD;
    if (sqffd_io__has_extension(name, name_len, ".off")) return SQFFD_IO_OFF;
    if (sqffd_io__has_extension(name, name_len, ".obj")) return SQFFD_IO_OBJ;
    if (sqffd_io__has_extension(name, name_len, ".vtk")) return SQFFD_IO_VTK;
    if (sqffd_io__has_extension(name, name_len, ".stl")) return SQFFD_IO_STL;
    return SQFFD_IO_XYZ;
}

/* The format's name: "XYZ", "PLY", "OFF", "OBJ", "PCD", "VTK" or "STL". */
static inline const char *sqffd_io_format_name(sqffd_io_format format)
{
    static const char *const names[] = {"XYZ", "PLY", "OFF", "OBJ", "PCD", "VTK", "STL"};
    return (unsigned)format < sizeof names / sizeof names[0] ? names[format] : "unknown";
}

/* Reads plain (not compressed) points in the detected format; info (not
   NULL) gets the format, and from the PCD, VTK and STL readers what they
   tell. */
static inline int sqffd_io__read_detected(const void *data, size_t size, const char *name, double **points,
                                          size_t *count, sqffd_io_info *info, char *err, size_t err_size)
{
    sqffd_io_format format = sqffd_io_detect(data, size, name);
    const char *foreign = sqffd_io_foreign_format(data, size);
    if (foreign) return sqffd_io__fail(err, err_size, name, "%s", foreign);
    info->format = format;
    switch (format) {
    case SQFFD_IO_PLY: return sqffd_io_read_ply(data, size, name, points, count, err, err_size);
    case SQFFD_IO_OFF: return sqffd_io_read_off(data, size, name, points, count, err, err_size);
    case SQFFD_IO_OBJ: return sqffd_io_read_obj(data, size, name, points, count, err, err_size);
    case SQFFD_IO_PCD: return sqffd_io_read_pcd(data, size, name, points, count, info, err, err_size);
    case SQFFD_IO_VTK: return sqffd_io_read_vtk(data, size, name, points, count, info, err, err_size);
    case SQFFD_IO_STL: return sqffd_io_read_stl(data, size, name, points, count, info, err, err_size);
    default: return sqffd_io_read_xyz(data, size, name, points, count, err, err_size);
    }
}

/* sqffd_io_read_points, and what the read found besides the points into
   *info when info is not NULL: the format, gzip or not, the PCD header and
   the points dropped for NaN coordinates (filled on success). */
static inline int sqffd_io_read_points_info(const void *data, size_t size, const char *name, double **points,
                                            size_t *count, sqffd_io_info *info, char *err, size_t err_size)
{
    sqffd_io_info unused;
    *points = NULL;
    *count = 0;
    if (!info) info = &unused;
    memset(info, 0, sizeof *info);
    if (size == 0) return sqffd_io__fail(err, err_size, name, "file is empty");
    if (sqffd_gz_is_gzip(data, size)) {
        unsigned char *raw;
        size_t raw_size;
        int r;
        if (sqffd_gz__decompress(data, size, name, "gzip-compressed data", SQFFD_IO_MAX_FILE_SIZE, &raw, &raw_size,
                                 err, err_size))
            return 1;
        /* not sqffd_io_read_points again: gzip inside gzip is not a point file */
        if (raw_size == 0) r = sqffd_io__fail(err, err_size, name, "decompresses to nothing");
        else if (sqffd_gz_is_gzip(raw, raw_size)) r = sqffd_io__fail(err, err_size, name, "gzip-compressed twice");
        else r = sqffd_io__read_detected(raw, raw_size, name, points, count, info, err, err_size);
        free(raw);
        info->gzip = 1;
        return r;
    }
    return sqffd_io__read_detected(data, size, name, points, count, info, err, err_size);
}

/* Reads points from memory in the detected format; gzip-compressed data is
   decompressed first (messages "NAME: gzip-compressed data: ..." when that
   fails; those about the points count lines of the decompressed text). */
static inline int sqffd_io_read_points(const void *data, size_t size, const char *name, double **points,
                                       size_t *count, char *err, size_t err_size)
{
    return sqffd_io_read_points_info(data, size, name, points, count, NULL, err, err_size);
}

/* The whole file at `path` in a malloc'd buffer (free() it); refuses files
   over max_bytes. */
static inline int sqffd_io_load_file_limit(const char *path, size_t max_bytes, unsigned char **data, size_t *size,
                                           char *err, size_t err_size)
{
    FILE *f;
    unsigned char *buf = NULL;
    size_t used = 0, capacity = 0;
    *data = NULL;
    *size = 0;
    errno = 0;
    f = fopen(path, "rb");
    if (!f) return sqffd_io__fail(err, err_size, path, "cannot open: %s", errno ? strerror(errno) : "unknown error");
    for (;;) {
        size_t got;
        if (used == capacity) {
            unsigned char *grown;
            if (capacity == max_bytes) { /* full: one more byte means too large */
                if (fread(buf + used, 1, 1, f) == 1) {
                    free(buf);
                    fclose(f);
                    return sqffd_io__fail(err, err_size, path, "larger than %llu bytes, the limit",
                                          (unsigned long long)max_bytes);
                }
                break;
            }
            capacity = capacity ? 2 * capacity : (size_t)1 << 16;
            if (capacity > max_bytes) capacity = max_bytes;
            grown = (unsigned char *)realloc(buf, capacity + 1); /* +1: the probe byte above */
            if (!grown) {
                free(buf);
                fclose(f);
                return sqffd_io__fail(err, err_size, path, "out of memory after %llu bytes", (unsigned long long)used);
            }
            buf = grown;
        }
        got = fread(buf + used, 1, capacity - used, f);
        used += got;
        if (got == 0) break;
    }
    if (ferror(f)) {
        int code = errno;
        free(buf);
        fclose(f);
        return sqffd_io__fail(err, err_size, path, "read error: %s", code ? strerror(code) : "unknown error");
    }
    fclose(f);
    *data = buf;
    *size = used;
    return 0;
}

/* The whole file, up to SQFFD_IO_MAX_FILE_SIZE. */
static inline int sqffd_io_load_file(const char *path, unsigned char **data, size_t *size, char *err, size_t err_size)
{
    return sqffd_io_load_file_limit(path, SQFFD_IO_MAX_FILE_SIZE, data, size, err, err_size);
}

/* Reads the points of the file at `path` (any supported format); info
   may be NULL, else it gets what sqffd_io_read_points_info gives. */
static inline int sqffd_io_read_file_info(const char *path, double **points, size_t *count, sqffd_io_info *info,
                                          char *err, size_t err_size)
{
    unsigned char *data;
    size_t size;
    int r;
    *points = NULL;
    *count = 0;
    if (info) memset(info, 0, sizeof *info);
    if (sqffd_io_load_file(path, &data, &size, err, err_size)) return 1;
    r = sqffd_io_read_points_info(data, size, path, points, count, info, err, err_size);
    free(data);
    return r;
}

/* Reads the points of the file at `path` (any supported format). */
static inline int sqffd_io_read_file(const char *path, double **points, size_t *count, char *err, size_t err_size)
{
    return sqffd_io_read_file_info(path, points, count, NULL, err, err_size);
}

/* Reads the OFF triangle mesh at `path` (sqffd_io_read_off_mesh). */
static inline int sqffd_io_read_off_mesh_file(const char *path, double **vertices, size_t *vertex_count,
                                              uint32_t **triangles, size_t *triangle_count, char *err,
                                              size_t err_size)
{
    unsigned char *data;
    size_t size;
    int r;
    *vertices = NULL;
    *vertex_count = 0;
    *triangles = NULL;
    *triangle_count = 0;
    if (sqffd_io_load_file(path, &data, &size, err, err_size)) return 1;
    r = sqffd_io_read_off_mesh(data, size, path, vertices, vertex_count, triangles, triangle_count, err, err_size);
    free(data);
    return r;
}

/* ---- PLY writer ---------------------------------------------------------- */

static inline void sqffd_io__put_le32(unsigned char *out, uint32_t v)
{
    out[0] = (unsigned char)(v & 0xffu);
    out[1] = (unsigned char)((v >> 8) & 0xffu);
    out[2] = (unsigned char)((v >> 16) & 0xffu);
    out[3] = (unsigned char)((v >> 24) & 0xffu);
}

static inline void sqffd_io__put_float(unsigned char *out, double value)
{
    float f = sqffd_io__to_float(value);
    uint32_t bits;
    memcpy(&bits, &f, sizeof bits);
    sqffd_io__put_le32(out, bits);
}

/* Writes a PLY of vertex_count vertices (x y z as float, then each scalar as
   a float property) and triangle_count triangles (three vertex indices each;
   no face element when triangle_count is 0) to an open stream; binary little
   endian, or ascii when `ascii` is non-zero. `name` is for messages. */
static inline int sqffd_io_write_ply_stream(FILE *f, const char *name, const double *vertices, size_t vertex_count,
                                            const uint32_t *triangles, size_t triangle_count,
                                            const sqffd_io_scalar *scalars, int scalar_count, int ascii,
                                            char *err, size_t err_size)
{
    unsigned char record[4 * (3 + SQFFD_IO_MAX_SCALARS)];
    size_t i;
    int k;
    if (scalar_count < 0 || scalar_count > SQFFD_IO_MAX_SCALARS)
        return sqffd_io__fail(err, err_size, name, "%d scalars, at most %d", scalar_count, SQFFD_IO_MAX_SCALARS);
    if (vertex_count > 0x7fffffffu)
        return sqffd_io__fail(err, err_size, name, "%llu vertices, more than int indices reach",
                              (unsigned long long)vertex_count);
    for (k = 0; k < scalar_count; k++) {
        const char *c = scalars[k].name;
        if (!c || !*c || !scalars[k].values)
            return sqffd_io__fail(err, err_size, name, "scalar %d has no name or no values", k);
        for (; *c; c++)
            if (sqffd_io__is_space(*c))
                return sqffd_io__fail(err, err_size, name, "scalar name '%s' contains a blank", scalars[k].name);
    }
    for (i = 0; i < 3 * triangle_count; i++)
        if (triangles[i] >= vertex_count)
            return sqffd_io__fail(err, err_size, name, "triangle %llu uses vertex %lu of %llu",
                                  (unsigned long long)(i / 3), (unsigned long)triangles[i],
                                  (unsigned long long)vertex_count);
    fprintf(f, "ply\nformat %s 1.0\ncomment written by sqffd\nelement vertex %llu\n"
               "property float x\nproperty float y\nproperty float z\n",
            ascii ? "ascii" : "binary_little_endian", (unsigned long long)vertex_count);
    for (k = 0; k < scalar_count; k++) fprintf(f, "property float %s\n", scalars[k].name);
    if (triangle_count)
        fprintf(f, "element face %llu\nproperty list uchar int vertex_indices\n", (unsigned long long)triangle_count);
    fputs("end_header\n", f);
    for (i = 0; i < vertex_count; i++) {
        if (ascii) {
            /* %.9g: a float's decimal form that reads back to the same float */
            fprintf(f, "%.9g %.9g %.9g", (double)sqffd_io__to_float(vertices[3 * i]),
                    (double)sqffd_io__to_float(vertices[3 * i + 1]), (double)sqffd_io__to_float(vertices[3 * i + 2]));
            for (k = 0; k < scalar_count; k++) fprintf(f, " %.9g", (double)sqffd_io__to_float(scalars[k].values[i]));
            fputc('\n', f);
        } else {
            for (k = 0; k < 3; k++) sqffd_io__put_float(record + 4 * k, vertices[3 * i + (size_t)k]);
            for (k = 0; k < scalar_count; k++) sqffd_io__put_float(record + 12 + 4 * k, scalars[k].values[i]);
            fwrite(record, 1, 4 * (3 + (size_t)scalar_count), f);
        }
    }
    for (i = 0; i < triangle_count; i++) {
        const uint32_t *tri = triangles + 3 * i;
        if (ascii) {
            fprintf(f, "3 %lu %lu %lu\n", (unsigned long)tri[0], (unsigned long)tri[1], (unsigned long)tri[2]);
        } else {
            record[0] = 3;
            for (k = 0; k < 3; k++) sqffd_io__put_le32(record + 1 + 4 * k, tri[k]);
            fwrite(record, 1, 13, f);
        }
    }
    if (ferror(f)) return sqffd_io__fail(err, err_size, name, "write error");
    return 0;
}

/* sqffd_io_write_ply_stream into a new file at `path`. */
static inline int sqffd_io_write_ply(const char *path, const double *vertices, size_t vertex_count,
                                     const uint32_t *triangles, size_t triangle_count,
                                     const sqffd_io_scalar *scalars, int scalar_count, int ascii,
                                     char *err, size_t err_size)
{
    FILE *f;
    int r;
    errno = 0;
    f = fopen(path, "wb");
    if (!f) return sqffd_io__fail(err, err_size, path, "cannot create: %s", errno ? strerror(errno) : "unknown error");
    r = sqffd_io_write_ply_stream(f, path, vertices, vertex_count, triangles, triangle_count, scalars, scalar_count,
                                  ascii, err, err_size);
    errno = 0;
    if (fclose(f) != 0 && r == 0)
        r = sqffd_io__fail(err, err_size, path, "write error: %s", errno ? strerror(errno) : "unknown error");
    return r;
}

#endif /* SQFFD_IO_H */

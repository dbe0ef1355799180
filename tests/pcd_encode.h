/* A PCD writer for the tests and the bench, independent of the reader in
   examples/sqffd_io.h: the header, the three encodings (ascii, binary point
   after point, binary_compressed field after field), and an LZF compressor
   (LibLZF's stream format) for the compressed one. */
#ifndef SQFFD_PCD_ENCODE_H
#define SQFFD_PCD_ENCODE_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "test_bytes.h"

/* ---- LZF ------------------------------------------------------------------ */

#define LZF_MAX_LITERAL 32
#define LZF_MAX_MATCH 264        /* 7 + 255 + 2 */
#define LZF_MAX_DISTANCE 8192
#define LZF_HASH_BITS 14


/* Literal runs of at most 32 bytes for in[from, to). */
static inline void lzf_literals(bytes *out, const unsigned char *in, size_t from, size_t to)
{
    while (from < to) {
        size_t run = to - from < LZF_MAX_LITERAL ? to - from : LZF_MAX_LITERAL;
        bytes_byte(out, (unsigned)(run - 1));
        bytes_put(out, in + from, run);
        from += run;
    }
}

/* A back-reference: copy `length` (3..264) bytes from `distance` (1..8192) back. */
static inline void lzf_reference(bytes *out, size_t length, size_t distance)
{
    size_t l = length - 2, d = distance - 1;
    if (l < 7) {
        bytes_byte(out, (unsigned)(l << 5 | d >> 8));
    } else {
        bytes_byte(out, (unsigned)(7 << 5 | d >> 8));
        bytes_byte(out, (unsigned)(l - 7));
    }
    bytes_byte(out, (unsigned)(d & 255));
}

/* Greedy LZF: at each position the last earlier position with the same
   three bytes (a hash table), extended as far as it matches (overlapping
   the position itself when the distance is shorter than the match). */
static inline void lzf_compress(const unsigned char *in, size_t n, bytes *out)
{
    size_t *table = (size_t *)malloc(sizeof(size_t) << LZF_HASH_BITS);
    size_t ip = 0, literal = 0, h;
    if (!table) exit(2);
    for (h = 0; h < (size_t)1 << LZF_HASH_BITS; h++) table[h] = (size_t)-1;
    while (ip + 3 <= n) {
        size_t ref;
        h = ((size_t)in[ip] << 16 | (size_t)in[ip + 1] << 8 | in[ip + 2]) * 2654435761u >> 8 &
            (((size_t)1 << LZF_HASH_BITS) - 1);
        ref = table[h];
        table[h] = ip;
        if (ref != (size_t)-1 && ip - ref <= LZF_MAX_DISTANCE && memcmp(in + ref, in + ip, 3) == 0) {
            size_t length = 3, most = n - ip < LZF_MAX_MATCH ? n - ip : LZF_MAX_MATCH;
            while (length < most && in[ref + length] == in[ip + length]) length++;
            lzf_literals(out, in, literal, ip);
            lzf_reference(out, length, ip - ref);
            ip += length;
            literal = ip;
        } else {
            ip++;
        }
    }
    lzf_literals(out, in, literal, n);
    free(table);
}

/* ---- PCD ------------------------------------------------------------------ */

enum { PCD_ASCII, PCD_BINARY, PCD_COMPRESSED };
#define PCD_MAX_FIELDS 16

typedef struct pcd_spec {
    const char *version;  /* the VERSION line's value; NULL: no VERSION line */
    int viewpoint;        /* write "VIEWPOINT 0 0 0 1 0 0 0" */
    int fields;
    const char *name[PCD_MAX_FIELDS];
    int size[PCD_MAX_FIELDS];
    char type[PCD_MAX_FIELDS];
    int count[PCD_MAX_FIELDS];
    size_t width, height; /* POINTS = width x height */
    int encoding;
    const char *eol;      /* header line ends: NULL for "\n" */
} pcd_spec;

/* The value of element c of field f of point i. */
typedef double (*pcd_value_fn)(void *user, size_t i, int f, int c);

/* One value in the field's binary form, little endian. */
static inline void pcd_put_binary(bytes *b, int size, char type, double v)
{
    unsigned char raw[8];
    uint64_t bits = 0;
    int k;
    if (type == 'F' && size == 4) {
        float f = (float)v;
        uint32_t u;
        memcpy(&u, &f, 4);
        bits = u;
    } else if (type == 'F') {
        memcpy(&bits, &v, 8);
    } else if (type == 'I') {
        bits = (uint64_t)(int64_t)v;
    } else {
        bits = (uint64_t)v;
    }
    for (k = 0; k < size; k++) raw[k] = (unsigned char)(bits >> (8 * k));
    bytes_put(b, raw, (size_t)size);
}

static inline void pcd_put_ascii(bytes *b, int size, char type, double v)
{
    if (isnan(v)) bytes_text(b, "nan");
    else if (type == 'F' && size == 4) bytes_text(b, "%.9g", (double)(float)v);
    else if (type == 'F') bytes_text(b, "%.17g", v);
    else if (type == 'I') bytes_text(b, "%lld", (long long)v);
    else bytes_text(b, "%llu", (unsigned long long)v);
}

static inline int pcd_is_padding(const pcd_spec *s, int f)
{
    return strcmp(s->name[f], "_") == 0;
}

/* The header lines, up to and including DATA. */
static inline void pcd_header(bytes *b, const pcd_spec *s)
{
    static const char *const encodings[] = {"ascii", "binary", "binary_compressed"};
    const char *eol = s->eol ? s->eol : "\n";
    int f;
    bytes_text(b, "# .PCD v%s - Point Cloud Data file format%s", s->version ? s->version : "0.7", eol);
    if (s->version) bytes_text(b, "VERSION %s%s", s->version, eol);
    bytes_text(b, "FIELDS");
    for (f = 0; f < s->fields; f++) bytes_text(b, " %s", s->name[f]);
    bytes_text(b, "%sSIZE", eol);
    for (f = 0; f < s->fields; f++) bytes_text(b, " %d", s->size[f]);
    bytes_text(b, "%sTYPE", eol);
    for (f = 0; f < s->fields; f++) bytes_text(b, " %c", s->type[f]);
    bytes_text(b, "%sCOUNT", eol);
    for (f = 0; f < s->fields; f++) bytes_text(b, " %d", s->count[f]);
    bytes_text(b, "%sWIDTH %lu%sHEIGHT %lu%s", eol, (unsigned long)s->width, eol, (unsigned long)s->height, eol);
    if (s->viewpoint) bytes_text(b, "VIEWPOINT 0 0 0 1 0 0 0%s", eol);
    bytes_text(b, "POINTS %lu%sDATA %s%s", (unsigned long)(s->width * s->height), eol, encodings[s->encoding], eol);
}

/* A whole PCD file into b (appended). binary_compressed data leave out the
   padding fields '_', as PCL writes them. */
static inline void pcd_encode(bytes *b, const pcd_spec *s, pcd_value_fn value, void *user)
{
    size_t n = s->width * s->height, i;
    int f, c;
    pcd_header(b, s);
    if (s->encoding == PCD_ASCII) {
        for (i = 0; i < n; i++) {
            for (f = 0; f < s->fields; f++)
                for (c = 0; c < s->count[f]; c++) {
                    if (f || c) bytes_text(b, " ");
                    pcd_put_ascii(b, s->size[f], s->type[f], value(user, i, f, c));
                }
            bytes_text(b, "\n");
        }
    } else if (s->encoding == PCD_BINARY) {
        for (i = 0; i < n; i++)
            for (f = 0; f < s->fields; f++)
                for (c = 0; c < s->count[f]; c++) pcd_put_binary(b, s->size[f], s->type[f], value(user, i, f, c));
    } else {
        bytes raw = {NULL, 0, 0}, packed = {NULL, 0, 0};
        unsigned char sizes[8];
        int k;
        for (f = 0; f < s->fields; f++)
            if (!pcd_is_padding(s, f))
                for (i = 0; i < n; i++)
                    for (c = 0; c < s->count[f]; c++) pcd_put_binary(&raw, s->size[f], s->type[f], value(user, i, f, c));
        lzf_compress(raw.data, raw.size, &packed);
        for (k = 0; k < 4; k++) {
            sizes[k] = (unsigned char)(packed.size >> (8 * k));
            sizes[4 + k] = (unsigned char)(raw.size >> (8 * k));
        }
        bytes_put(b, sizes, 8);
        bytes_put(b, packed.data, packed.size);
        bytes_free(&raw);
        bytes_free(&packed);
    }
}

/* ---- a Kinect-like organised cloud ----------------------------------------- */

/* Pixel (u, v) of a width x height depth camera (pinhole, 525 px focal
   length at 640 pixels wide, like a Kinect's): a wall 2 m away with a
   sphere of 0.5 m radius in front of it, depth in whole millimetres; the
   leftmost 8 of every 640 columns and about 3% of the other pixels have no
   depth: x y z NaN, as PCL stores them. rgba: a colour from the depth. */
static inline void kinect_pixel(size_t width, size_t height, size_t u, size_t v, double xyz[3], uint32_t *rgba)
{
    double f = 525.0 * (double)width / 640.0, px = ((double)u - 0.5 * (double)width) / f,
           py = ((double)v - 0.5 * (double)height) / f, depth = 2.0, b, c, disc;
    uint32_t hash = (uint32_t)(u * 73856093u ^ v * 19349663u) * 2654435761u;
    /* the ray (px, py, 1) t meets the sphere centred (0, 0, 1.4), radius 0.5, at t = depth */
    b = 1.4;
    c = 1.4 * 1.4 - 0.25;
    disc = b * b - (px * px + py * py + 1.0) * c;
    if (disc >= 0.0) depth = (b - sqrt(disc)) / (px * px + py * py + 1.0);
    depth = floor(depth * 1000.0 + 0.5) / 1000.0;
    if (u * 640 < 8 * width || hash % 100 < 3) {
        xyz[0] = xyz[1] = xyz[2] = NAN;
    } else {
        xyz[0] = px * depth;
        xyz[1] = py * depth;
        xyz[2] = depth;
    }
    *rgba = 0xff000000u | (uint32_t)(depth * 100.0) << 16 | (uint32_t)(u & 255) << 8 | (uint32_t)(v & 255);
}

/* pcd_value_fn of the fields x y z rgba of a width x height Kinect-like cloud (user: the size_t width, height). */
static inline double kinect_value(void *user, size_t i, int f, int c)
{
    const size_t *dims = (const size_t *)user;
    double xyz[3];
    uint32_t rgba;
    (void)c;
    kinect_pixel(dims[0], dims[1], i % dims[0], i / dims[0], xyz, &rgba);
    return f < 3 ? xyz[f] : (double)rgba;
}

/* The spec of such a cloud: x y z rgba, F4 F4 F4 U4, PCL 0.7 header. */
static inline pcd_spec kinect_spec(size_t width, size_t height, int encoding)
{
    pcd_spec s;
    memset(&s, 0, sizeof s);
    s.version = "0.7";
    s.viewpoint = 1;
    s.fields = 4;
    s.name[0] = "x"; s.name[1] = "y"; s.name[2] = "z"; s.name[3] = "rgba";
    s.size[0] = s.size[1] = s.size[2] = s.size[3] = 4;
    s.type[0] = s.type[1] = s.type[2] = 'F';
    s.type[3] = 'U';
    s.count[0] = s.count[1] = s.count[2] = s.count[3] = 1;
    s.width = width;
    s.height = height;
    s.encoding = encoding;
    return s;
}

#endif

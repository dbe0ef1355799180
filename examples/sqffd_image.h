/* sqffd_image.h - medical volume files for the sqffd tools (not part of the library).

   Header-only, every function `static inline`; C99 or C++ plus the C library.
   Uses sqffd.h for its volume view (include it with SQFFD_IMPLEMENTATION in
   one file of the program, as usual) and sqffd_inflate.h for gzip and zlib.

   Reads 3-D and 4-D scalar images into one malloc'd buffer, in native byte
   order, and describes frame 0 as an sqffd_volume the core reads in place:
     NIfTI-1    .nii, .nii.gz, .hdr/.img pairs (either byte order)
     MetaImage  .mha (data attached, raw or zlib) and .mhd + its data file
     NRRD       .nrrd (data attached) and .nhdr + its data file; raw, gzip
                and ascii encodings
     VTK        legacy .vtk STRUCTURED_POINTS, ASCII or BINARY (big endian)
   Voxel types: int8, uint8, int16, uint16, int32, float32, float64 (and
   VTK's unsigned_int, widened to float64); other types are refused by name. Dimensions: MetaImage and NRRD 3 or 4; NIfTI
   dim[0] 1 to 7 as long as dim[5..dim[0]] are 1 (a 2-D image is one slice,
   dims past dim[0] are ignored, as the format says). Value scaling: NIfTI
   scl_slope/scl_inter (a zero or non-finite slope means none, as nibabel);
   the other formats have none (scale 0). Offsets: NIfTI vox_offset (0 in a
   .nii means 352); MetaImage HeaderSize counts from the start of the data
   file, or from the end of the header for LOCAL data, -1 meaning "the data
   are the file's last bytes"; NRRD line skip, then byte skip (-1 likewise,
   raw only; on gzip data it counts decompressed bytes, as teem does). Every size and offset a header states is
   checked, with overflow-safe arithmetic, against the bytes present before
   anything is allocated; gzip and zlib data must decompress to exactly the
   size the header promises. Failures return 1 with "NAME: what is wrong" in
   err (NAME is the file the problem is in) and leave the image empty.

   World coordinates (sqffd_image.volume.affine, voxel centre -> world) are
   in each file's own space, never converted:
     NIfTI-1    RAS+ (x to the right, y anterior, z superior), as nibabel
                gives it: the sform when sform_code != 0, else the qform when
                qform_code != 0, else nibabel's fall-back ("pixdim"):
                diag(-pixdim[1], pixdim[2], pixdim[3]) centred on the middle
                voxel, i.e. translation -(dim - 1) / 2 * that diagonal.
                In the qform, qfac is -1 when pixdim[0] < 0, else 1 (0 means
                1), and |pixdim[1..3]| are the voxel sizes.
     MetaImage  ITK's space, normally LPS (x to the left, y posterior, z
                superior): world = Offset + M diag(ElementSpacing) (i, j, k),
                where M's column c is TransformMatrix's numbers 3c .. 3c+2
                (MetaIO writes ITK's direction matrix transposed: each group
                of three numbers is one voxel axis's direction).
     NRRD       the "space" the file names (LPS for 3D Slicer's files, RAS,
                scanner-xyz...): world = space origin + the space directions
                as columns; without space directions, diag(spacings).
     VTK        world = ORIGIN + DIRECTION diag(SPACING) (i, j, k), VTK's
                defaults (0, the identity, 1) for what the file leaves out.
   A 4-D image's frames follow one another in the buffer (frame_stride
   apart); a NRRD's non-spatial axis may be any one of its four, marked by
   "none" in space directions (the last axis without them). */
#ifndef SQFFD_IMAGE_H
#define SQFFD_IMAGE_H

#include <errno.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "../sqffd.h"
#include "sqffd_io.h" /* the file loader, the message convention and sqffd_inflate.h */

/* The largest file, and the largest image, these readers take. */
#ifndef SQFFD_IMAGE_MAX_BYTES
#if SIZE_MAX > 0xffffffffu
#define SQFFD_IMAGE_MAX_BYTES ((size_t)1 << 34)
#else
#define SQFFD_IMAGE_MAX_BYTES ((size_t)1 << 30)
#endif
#endif

/* Deflate turns one input byte into at most 1032 output bytes (a 258-byte
   match coded in 2 bits); a header promising more than that is refused
   before any decompression. */
#define SQFFD_IMAGE__DEFLATE_RATIO 1032u

typedef struct sqffd_image {
    sqffd_volume volume;    /* frame 0 (a 3-D image: the image) */
    size_t frames;          /* the 4th dimension (1 for 3-D) */
    ptrdiff_t frame_stride; /* bytes from one frame to the next */
    double spacing[3];      /* voxel size along i, j, k (mm), as the file states it */
    double time_step;       /* 4th-axis spacing (NIfTI pixdim[4], 0 if none) */
    char format[16];        /* "NIfTI-1", "MetaImage", "NRRD" */
    char stored_type[16];   /* the file's own type name, e.g. "int16", "MET_SHORT", "float" */
    char affine_source[32]; /* "sform", "qform", "pixdim", "TransformMatrix", "ElementSpacing",
                               "space directions", "spacings", "none" (unit voxels at 0) */
    int big_endian;         /* the file's byte order (the data are converted to native on load) */
    void *buffer;           /* owned voxel memory */
} sqffd_image;

/* Messages: sqffd_io.h's "NAME: what is wrong" (sqffd_io__fail) and quoting (sqffd_io__quote). */

/* ---- text ---------------------------------------------------------------- */

/* Whether `name` ends in `suffix`, ignoring case. */
static inline int sqffd_image__has_suffix(const char *name, const char *suffix)
{
    return sqffd_io__has_extension(name, name ? strlen(name) : 0, suffix);
}

static inline int sqffd_image__is_blank(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

/* Cuts blanks (and a line's '\r') from both ends of [*s, *e). */
static inline void sqffd_image__trim(const char **s, const char **e)
{
    while (*s < *e && sqffd_image__is_blank(**s)) (*s)++;
    while (*e > *s && sqffd_image__is_blank((*e)[-1])) (*e)--;
}

/* The line at *p, up to '\n' or the end, as [*s, *e) without the '\n';
   moves *p past it. 0 when *p is at the end. */
static inline int sqffd_image__line(const char **p, const char *end, const char **s, const char **e)
{
    const char *nl;
    if (*p >= end) return 0;
    nl = (const char *)memchr(*p, '\n', (size_t)(end - *p));
    *s = *p;
    *e = nl ? nl : end;
    *p = nl ? nl + 1 : end;
    return 1;
}

/* The next token of [*p, end); blanks and commas separate tokens. */
static inline int sqffd_image__token(const char **p, const char *end, const char **tok, size_t *len)
{
    const char *s = *p, *e;
    while (s < end && (sqffd_image__is_blank(*s) || *s == ',' || *s == '\n')) s++;
    if (s == end) { *p = s; return 0; }
    e = s;
    while (e < end && !sqffd_image__is_blank(*e) && *e != ',' && *e != '\n') e++;
    *tok = s;
    *len = (size_t)(e - s);
    *p = e;
    return 1;
}

/* [text, text + len) as a finite double (strtod on a bounded copy: header
   text is not NUL-terminated); 0 on success. "nan" is accepted, as NAN,
   only when allow_nan is set. */
static inline int sqffd_image__number(const char *text, size_t len, int allow_nan, double *out)
{
    char buf[64];
    char *stop;
    double v;
    if (allow_nan && sqffd_io__is(text, len, "nan")) { *out = NAN; return 0; }
    if (len == 0 || len >= sizeof buf) return 1;
    memcpy(buf, text, len);
    buf[len] = '\0';
    v = strtod(buf, &stop);
    if (stop != buf + len || !isfinite(v)) return 1;
    *out = v;
    return 0;
}

/* [text, text + len) as a whole number with an optional sign, |value| < 2^62; 0 on success. */
static inline int sqffd_image__integer(const char *text, size_t len, long long *out)
{
    size_t i = 0;
    long long v = 0;
    int negative = 0;
    if (len > 0 && (text[0] == '-' || text[0] == '+')) { negative = text[0] == '-'; i = 1; }
    if (i == len) return 1;
    for (; i < len; i++) {
        unsigned digit = (unsigned)((unsigned char)text[i] - '0');
        if (digit > 9 || v > (((long long)1 << 62) - 9) / 10) return 1;
        v = v * 10 + (long long)digit;
    }
    *out = negative ? -v : v;
    return 0;
}

/* Exactly n numbers from the header value [s, e) of `field` (NaN allowed
   when allow_nan is set). */
static inline int sqffd_image__numbers(const char *s, const char *e, size_t n, int allow_nan, double *out,
                                       const char *name, const char *field, char *err, size_t err_size)
{
    const char *tok;
    size_t len, found = 0;
    char q[32];
    while (sqffd_image__token(&s, e, &tok, &len)) {
        if (found == n)
            return sqffd_io__fail(err, err_size, name, "%s: more than %u numbers", field, (unsigned)n);
        if (sqffd_image__number(tok, len, allow_nan, &out[found]))
            return sqffd_io__fail(err, err_size, name, "%s: %s is not a finite number", field,
                                     sqffd_io__quote(tok, len, q));
        found++;
    }
    if (found != n)
        return sqffd_io__fail(err, err_size, name, "%s: expected %u numbers, found %u", field, (unsigned)n,
                                 (unsigned)found);
    return 0;
}

/* Exactly n image sizes (whole numbers, at least 1) from [s, e). */
static inline int sqffd_image__sizes(const char *s, const char *e, size_t n, size_t *out, const char *name,
                                     const char *field, char *err, size_t err_size)
{
    const char *tok;
    size_t len, found = 0;
    long long v;
    char q[32];
    while (sqffd_image__token(&s, e, &tok, &len)) {
        if (found == n)
            return sqffd_io__fail(err, err_size, name, "%s: more than %u sizes", field, (unsigned)n);
        if (sqffd_image__integer(tok, len, &v) || v < 1)
            return sqffd_io__fail(err, err_size, name, "%s: %s is not a size (a whole number, at least 1)",
                                     field, sqffd_io__quote(tok, len, q));
        if ((unsigned long long)v > (unsigned long long)SQFFD_IMAGE_MAX_BYTES)
            return sqffd_io__fail(err, err_size, name, "%s: %lld is larger than any image this reader takes",
                                     field, v);
        out[found++] = (size_t)v;
    }
    if (found != n)
        return sqffd_io__fail(err, err_size, name, "%s: expected %u sizes, found %u", field, (unsigned)n,
                                 (unsigned)found);
    return 0;
}

/* ---- bytes --------------------------------------------------------------- */

static inline int sqffd_image__native_big_endian(void)
{
    const uint16_t one = 1;
    unsigned char first;
    memcpy(&first, &one, 1);
    return first == 0;
}

static inline uint32_t sqffd_image__u32(const unsigned char *p, int big_endian)
{
    return big_endian ? (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3]
                      : (uint32_t)p[3] << 24 | (uint32_t)p[2] << 16 | (uint32_t)p[1] << 8 | p[0];
}

static inline int sqffd_image__i16(const unsigned char *p, int big_endian)
{
    unsigned v = big_endian ? (unsigned)p[0] << 8 | p[1] : (unsigned)p[1] << 8 | p[0];
    return v >= 0x8000u ? (int)v - 0x10000 : (int)v;
}

static inline double sqffd_image__f32(const unsigned char *p, int big_endian)
{
    uint32_t bits = sqffd_image__u32(p, big_endian);
    float f;
    memcpy(&f, &bits, 4);
    return (double)f;
}

/* Reverses the bytes of each of `count` values of `size` bytes. */
static inline void sqffd_image__swap(unsigned char *data, size_t count, size_t size)
{
    size_t i, a;
    for (i = 0; i < count; i++, data += size)
        for (a = 0; a < size / 2; a++) {
            unsigned char t = data[a];
            data[a] = data[size - 1 - a];
            data[size - 1 - a] = t;
        }
}

static inline size_t sqffd_image__type_size(sqffd_voxel_type type)
{
    switch (type) {
    case SQFFD_VOXEL_U8: case SQFFD_VOXEL_I8: return 1;
    case SQFFD_VOXEL_U16: case SQFFD_VOXEL_I16: return 2;
    case SQFFD_VOXEL_I32: case SQFFD_VOXEL_F32: return 4;
    default: return 8;
    }
}

/* ---- where the voxels are: what each header parser hands the loader ------- */

enum { SQFFD_IMAGE__RAW = 0, SQFFD_IMAGE__GZIP = 1, SQFFD_IMAGE__ZLIB = 2, SQFFD_IMAGE__ASCII = 3 };

typedef struct sqffd_image__layout {
    sqffd_voxel_type type;
    size_t element_size;
    size_t dims[4];         /* file order, the first fastest; 1 for absent axes */
    int frame_axis;         /* the non-spatial axis: 3 except in some NRRDs */
    size_t total;           /* bytes of voxels: product of dims x element_size */
    int big_endian;
    int encoding;           /* SQFFD_IMAGE__RAW ... */
    size_t start;           /* where the data (or the lines to skip) begin in their source */
    size_t line_skip;       /* lines skipped first (NRRD) */
    int at_end;             /* the data (or stream) are the last bytes of the source */
    size_t skip_before;     /* bytes skipped in the source before the data or the stream */
    size_t skip_after;      /* bytes skipped after decompression (NRRD's byte skip) */
    size_t compressed_size; /* the stream's length; 0: to the end of the source */
    const char *data_file;  /* a separate data file the header names (not NUL-terminated), or NULL */
    size_t data_file_len;
    int pair;               /* a NIfTI .hdr: the data are in the .img beside it */
    int uint32;             /* uint32 voxels (VTK unsigned_int; type says int32): widened to float64 on load */
} sqffd_image__layout;

static inline void sqffd_image__layout_init(sqffd_image__layout *layout)
{
    memset(layout, 0, sizeof *layout);
    layout->dims[0] = layout->dims[1] = layout->dims[2] = layout->dims[3] = 1;
    layout->frame_axis = 3;
}

/* layout->total from the dims and the element size, refusing images over
   SQFFD_IMAGE_MAX_BYTES (every dim is already at least 1 and at most the limit). */
static inline int sqffd_image__total(sqffd_image__layout *layout, const char *name, char *err, size_t err_size)
{
    size_t total = layout->element_size;
    int a;
    for (a = 0; a < 4; a++) {
        if (layout->dims[a] > SQFFD_IMAGE_MAX_BYTES / total)
            return sqffd_io__fail(err, err_size, name,
                                     "%llu x %llu x %llu x %llu voxels of %u bytes: more than %llu bytes, the limit",
                                     (unsigned long long)layout->dims[0], (unsigned long long)layout->dims[1],
                                     (unsigned long long)layout->dims[2], (unsigned long long)layout->dims[3],
                                     (unsigned)layout->element_size, (unsigned long long)SQFFD_IMAGE_MAX_BYTES);
        total *= layout->dims[a];
    }
    layout->total = total;
    return 0;
}

static inline void sqffd_image__set_text(char *out, size_t size, const char *text)
{
    snprintf(out, size, "%s", text);
}

/* Decompresses `size` bytes of gzip (whole file, all members) or of one zlib
   stream into a malloc'd buffer of exactly `expected` bytes; the header's
   promise is checked against deflate's ratio before anything is inflated. */
static inline int sqffd_image__inflate(const unsigned char *data, size_t size, int zlib, size_t expected,
                                       const char *name, unsigned char **out, char *err, size_t err_size)
{
    size_t got = 0;
    *out = NULL;
    if (expected > 4096 && (expected - 4096) / SQFFD_IMAGE__DEFLATE_RATIO > size)
        return sqffd_io__fail(err, err_size, name,
                                 "data: the header promises %llu bytes, more than %llu compressed bytes can hold",
                                 (unsigned long long)expected, (unsigned long long)size);
    if ((zlib ? sqffd_gz_zlib_decompress(data, size, name, expected + 1, out, &got, err, err_size)
              : sqffd_gz_decompress(data, size, name, expected + 1, out, &got, err, err_size)) != 0) {
        /* "NAME: zlib: why" becomes "NAME: data (N bytes promised): zlib: why" */
        char why[256];
        size_t prefix = strlen(name) + 2;
        *out = NULL; /* the inflater keeps nothing on failure */
        if (err && err_size > 0) {
            snprintf(why, sizeof why, "%s", strlen(err) > prefix ? err + prefix : "decompression failed");
            sqffd_io__fail(err, err_size, name, "data (%llu bytes promised): %s", (unsigned long long)expected, why);
        }
        return 1;
    }
    if (got != expected) {
        free(*out);
        *out = NULL;
        return sqffd_io__fail(err, err_size, name, "data: the %s stream holds %s%llu bytes, the header promises %llu",
                                 zlib ? "zlib" : "gzip", got > expected ? "more than " : "",
                                 (unsigned long long)(got > expected ? expected : got), (unsigned long long)expected);
    }
    return 0;
}

/* Parses ascii voxels (whitespace- or comma-separated numbers) into out. */
static inline int sqffd_image__ascii(const char *text, size_t size, const sqffd_image__layout *layout,
                                     unsigned char *out, const char *name, char *err, size_t err_size)
{
    const char *p = text, *end = text + size, *tok;
    size_t count = layout->total / layout->element_size, i, len;
    char q[32];
    for (i = 0; i < count; i++) {
        double v;
        if (!sqffd_image__token(&p, end, &tok, &len))
            return sqffd_io__fail(err, err_size, name, "data: %llu of %llu values present",
                                     (unsigned long long)i, (unsigned long long)count);
        if (sqffd_image__number(tok, len, 0, &v))
            return sqffd_io__fail(err, err_size, name, "data: value %llu, %s, is not a finite number",
                                     (unsigned long long)i, sqffd_io__quote(tok, len, q));
        switch (layout->type) {
        case SQFFD_VOXEL_F64: memcpy(out + 8 * i, &v, 8); continue;
        case SQFFD_VOXEL_F32: {
            float f;
            if (fabs(v) > FLT_MAX)
                return sqffd_io__fail(err, err_size, name, "data: value %llu, %s, is beyond float range",
                                         (unsigned long long)i, sqffd_io__quote(tok, len, q));
            f = (float)v;
            memcpy(out + 4 * i, &f, 4);
            continue;
        }
        default: break;
        }
        {
            static const double lowest[] = {0, -128, 0, -32768, -2147483648.0};
            static const double highest[] = {255, 127, 65535, 32767, 2147483647.0};
            int t = (int)layout->type;
            if (v != floor(v) || v < (layout->uint32 ? 0 : lowest[t]) || v > (layout->uint32 ? 4294967295.0 : highest[t]))
                return sqffd_io__fail(err, err_size, name,
                                         "data: value %llu, %s, is not a whole number in the type's range",
                                         (unsigned long long)i, sqffd_io__quote(tok, len, q));
            switch (layout->type) {
            case SQFFD_VOXEL_U8: out[i] = (unsigned char)v; break;
            case SQFFD_VOXEL_I8: { int8_t x = (int8_t)v; memcpy(out + i, &x, 1); break; }
            case SQFFD_VOXEL_U16: { uint16_t x = (uint16_t)v; memcpy(out + 2 * i, &x, 2); break; }
            case SQFFD_VOXEL_I16: { int16_t x = (int16_t)v; memcpy(out + 2 * i, &x, 2); break; }
            default:
                if (layout->uint32) { uint32_t x = (uint32_t)v; memcpy(out + 4 * i, &x, 4); }
                else { int32_t x = (int32_t)v; memcpy(out + 4 * i, &x, 4); }
                break;
            }
        }
    }
    return 0;
}

/* Reads the voxels `layout` describes from the bytes of their source (the
   header's own file, or the data file it names: `name` in messages) into
   image->buffer and sets the views. Everything is checked before the one
   allocation. When `owner` is not NULL, *owner is the malloc'd block src
   points to: raw voxels are then moved to its start and the block kept (and
   *owner set to NULL) instead of copied, which saves a whole-image copy. */
static inline int sqffd_image__load(const unsigned char *src, size_t src_size, const char *name,
                                    const sqffd_image__layout *layout, unsigned char **owner, sqffd_image *image,
                                    char *err, size_t err_size)
{
    size_t pos = layout->start, avail, a, i, element = layout->element_size;
    unsigned char *voxels = NULL;
    ptrdiff_t strides[4];
    int axis;
    if (pos > src_size)
        return sqffd_io__fail(err, err_size, name, "data: the header ends past the end of the file");
    for (i = 0; i < layout->line_skip; i++) {
        const unsigned char *nl = (const unsigned char *)memchr(src + pos, '\n', src_size - pos);
        if (!nl)
            return sqffd_io__fail(err, err_size, name, "line skip %llu: the data hold only %llu lines",
                                     (unsigned long long)layout->line_skip, (unsigned long long)i);
        pos = (size_t)(nl - src) + 1;
    }
    if (layout->at_end) {
        size_t need = layout->encoding == SQFFD_IMAGE__RAW ? layout->total : layout->compressed_size;
        if (need > src_size - pos)
            return sqffd_io__fail(err, err_size, name,
                                     "data: the header promises %llu bytes at the end of the file, it holds %llu",
                                     (unsigned long long)need, (unsigned long long)(src_size - pos));
        pos = src_size - need;
    } else {
        if (layout->skip_before > src_size - pos)
            return sqffd_io__fail(err, err_size, name, "data: they start at byte %llu, past the end of the file (%llu bytes)",
                                     (unsigned long long)pos + (unsigned long long)layout->skip_before,
                                     (unsigned long long)src_size);
        pos += layout->skip_before;
    }
    avail = src_size - pos;
    switch (layout->encoding) {
    case SQFFD_IMAGE__RAW:
        if (layout->total > avail)
            return sqffd_io__fail(err, err_size, name,
                                     "data: the header promises %llu bytes from offset %llu, the file holds %llu",
                                     (unsigned long long)layout->total, (unsigned long long)pos,
                                     (unsigned long long)avail);
        if (owner && *owner == src) {
            unsigned char *shrunk;
            voxels = *owner;
            *owner = NULL;
            memmove(voxels, voxels + pos, layout->total);
            shrunk = (unsigned char *)realloc(voxels, layout->total);
            if (shrunk) voxels = shrunk;
            break;
        }
        voxels = (unsigned char *)malloc(layout->total);
        if (!voxels)
            return sqffd_io__fail(err, err_size, name, "out of memory for %llu bytes of voxels",
                                     (unsigned long long)layout->total);
        memcpy(voxels, src + pos, layout->total);
        break;
    case SQFFD_IMAGE__GZIP:
    case SQFFD_IMAGE__ZLIB: {
        size_t in_size = layout->compressed_size ? layout->compressed_size : avail;
        if (in_size > avail)
            return sqffd_io__fail(err, err_size, name,
                                     "data: the header promises %llu compressed bytes, the file holds %llu",
                                     (unsigned long long)in_size, (unsigned long long)avail);
        if (layout->skip_after > SQFFD_IMAGE_MAX_BYTES - layout->total)
            return sqffd_io__fail(err, err_size, name, "byte skip %llu: too large",
                                     (unsigned long long)layout->skip_after);
        if (sqffd_image__inflate(src + pos, in_size, layout->encoding == SQFFD_IMAGE__ZLIB,
                                 layout->skip_after + layout->total, name, &voxels, err, err_size))
            return 1;
        if (layout->skip_after) memmove(voxels, voxels + layout->skip_after, layout->total);
        break;
    }
    default: { /* ascii: every value takes a character and a separator (the last one maybe not) */
        size_t count = layout->total / layout->element_size;
        if (count - 1 > avail / 2)
            return sqffd_io__fail(err, err_size, name,
                                     "data: the header promises %llu values, %llu bytes of text cannot hold them",
                                     (unsigned long long)count, (unsigned long long)avail);
        voxels = (unsigned char *)malloc(layout->total);
        if (!voxels)
            return sqffd_io__fail(err, err_size, name, "out of memory for %llu bytes of voxels",
                                     (unsigned long long)layout->total);
        if (sqffd_image__ascii((const char *)src + pos, avail, layout, voxels, name, err, err_size)) {
            free(voxels);
            return 1;
        }
        break;
    }
    }
    if (layout->encoding != SQFFD_IMAGE__ASCII && layout->element_size > 1 &&
        layout->big_endian != sqffd_image__native_big_endian())
        sqffd_image__swap(voxels, layout->total / layout->element_size, layout->element_size);
    if (layout->uint32) { /* each value widened in place, from the last (it never overwrites one not yet read) */
        unsigned char *wide = (unsigned char *)realloc(voxels, 2 * layout->total);
        if (!wide) {
            free(voxels);
            return sqffd_io__fail(err, err_size, name, "out of memory for %llu bytes of voxels",
                                  2 * (unsigned long long)layout->total);
        }
        for (i = layout->total / 4; i-- > 0;) {
            uint32_t x;
            double d;
            memcpy(&x, wide + 4 * i, 4);
            d = (double)x;
            memcpy(wide + 8 * i, &d, 8);
        }
        voxels = wide;
        element = 8;
    }

    strides[0] = (ptrdiff_t)element;
    for (a = 1; a < 4; a++) strides[a] = strides[a - 1] * (ptrdiff_t)layout->dims[a - 1];
    image->buffer = voxels;
    image->volume.data = voxels;
    image->volume.type = layout->uint32 ? SQFFD_VOXEL_F64 : layout->type;
    for (axis = 0, a = 0; axis < 4; axis++) {
        if (axis == layout->frame_axis) continue;
        image->volume.dims[a] = layout->dims[axis];
        image->volume.strides[a] = strides[axis];
        a++;
    }
    image->frames = layout->dims[layout->frame_axis];
    image->frame_stride = strides[layout->frame_axis];
    return 0;
}

/* ---- NIfTI-1 ------------------------------------------------------------- */

/* The voxel type of NIfTI-1 datatype code `code`; 1 with a message for
   codes this reader does not take. */
static inline int sqffd_image__nifti_type(int code, sqffd_image__layout *layout, sqffd_image *image,
                                          const char *name, char *err, size_t err_size)
{
    static const struct { int code; int type; const char *text; } types[] = {
        {2, SQFFD_VOXEL_U8, "uint8"},         {4, SQFFD_VOXEL_I16, "int16"},
        {8, SQFFD_VOXEL_I32, "int32"},        {16, SQFFD_VOXEL_F32, "float32"},
        {64, SQFFD_VOXEL_F64, "float64"},     {256, SQFFD_VOXEL_I8, "int8"},
        {512, SQFFD_VOXEL_U16, "uint16"},     {1, -1, "binary (1 bit)"},
        {32, -1, "complex64"},                {128, -1, "RGB24"},
        {768, -1, "uint32"},                  {1024, -1, "int64"},
        {1280, -1, "uint64"},                 {1536, -1, "float128"},
        {1792, -1, "complex128"},             {2048, -1, "complex256"},
        {2304, -1, "RGBA32"}};
    size_t i;
    for (i = 0; i < sizeof types / sizeof types[0]; i++) {
        if (types[i].code != code) continue;
        if (types[i].type < 0)
            return sqffd_io__fail(err, err_size, name,
                                     "datatype %d (%s) is not supported (uint8, int8, uint16, int16, int32, "
                                     "float32 and float64 are)", code, types[i].text);
        layout->type = (sqffd_voxel_type)types[i].type;
        layout->element_size = sqffd_image__type_size(layout->type);
        sqffd_image__set_text(image->stored_type, sizeof image->stored_type, types[i].text);
        return 0;
    }
    return sqffd_io__fail(err, err_size, name, "datatype %d is not a NIfTI-1 datatype code", code);
}

/* The affine from the qform: rotation from the quaternion (b, c, d; a from
   unit length), times diag(|pixdim[1]|, |pixdim[2]|, qfac |pixdim[3]|),
   then the offsets. */
static inline void sqffd_image__qform(const unsigned char *h, int be, double affine[16])
{
    double b = sqffd_image__f32(h + 256, be), c = sqffd_image__f32(h + 260, be), d = sqffd_image__f32(h + 264, be);
    double a2 = 1.0 - (b * b + c * c + d * d), a = a2 > 0 ? sqrt(a2) : 0.0;
    double norm = a * a + b * b + c * c + d * d, s = norm > 0 ? 2.0 / norm : 0.0;
    double r[9], size[3];
    int row, col;
    r[0] = 1 - s * (c * c + d * d); r[1] = s * (b * c - a * d);     r[2] = s * (b * d + a * c);
    r[3] = s * (b * c + a * d);     r[4] = 1 - s * (b * b + d * d); r[5] = s * (c * d - a * b);
    r[6] = s * (b * d - a * c);     r[7] = s * (c * d + a * b);     r[8] = 1 - s * (b * b + c * c);
    for (col = 0; col < 3; col++) size[col] = fabs(sqffd_image__f32(h + 80 + 4 * col, be));
    if (sqffd_image__f32(h + 76, be) < 0) size[2] = -size[2];
    for (row = 0; row < 3; row++) {
        for (col = 0; col < 3; col++) affine[4 * row + col] = r[3 * row + col] * size[col];
        affine[4 * row + 3] = sqffd_image__f32(h + 268 + 4 * row, be);
    }
}

/* Parses a NIfTI-1 header (the first 348 bytes of `h`) into image and
   layout (offset of the data in their source, no data file yet). */
static inline int sqffd_image__nifti(const unsigned char *h, size_t size, const char *name, sqffd_image *image,
                                     sqffd_image__layout *layout, char *err, size_t err_size)
{
    int be, ndim, a, sform_code, qform_code;
    double vox_offset, slope, inter, pixdim[8];
    if (size < 4) return sqffd_io__fail(err, err_size, name, "file of %llu bytes: too short for a NIfTI-1 header",
                                           (unsigned long long)size);
    if (sqffd_image__u32(h, 0) == 348) be = 0;
    else if (sqffd_image__u32(h, 1) == 348) be = 1;
    else if (sqffd_image__u32(h, 0) == 540 || sqffd_image__u32(h, 1) == 540)
        return sqffd_io__fail(err, err_size, name, "a NIfTI-2 file (sizeof_hdr 540): only NIfTI-1 is supported");
    else
        return sqffd_io__fail(err, err_size, name, "not a NIfTI-1 file: sizeof_hdr is %lu, not 348",
                                 (unsigned long)sqffd_image__u32(h, 0));
    if (size < 348)
        return sqffd_io__fail(err, err_size, name, "truncated header: %llu bytes, a NIfTI-1 header has 348",
                                 (unsigned long long)size);
    /* the magic is "ni1" or "n+1": sqffd_image__header has refused any other (Analyze 7.5) */
    layout->pair = memcmp(h + 344, "ni1", 4) == 0;
    sqffd_image__set_text(image->format, sizeof image->format, "NIfTI-1");
    image->big_endian = be;
    layout->big_endian = be;

    ndim = sqffd_image__i16(h + 40, be);
    if (ndim < 1 || ndim > 7)
        return sqffd_io__fail(err, err_size, name, "dim[0] = %d: the number of dimensions must be 1 to 7", ndim);
    for (a = 1; a <= ndim; a++) {
        int n = sqffd_image__i16(h + 40 + 2 * a, be);
        if (n < 1) return sqffd_io__fail(err, err_size, name, "dim[%d] = %d: must be at least 1", a, n);
        if (a > 4 && n != 1)
            return sqffd_io__fail(err, err_size, name,
                                     "dim[%d] = %d: images of more than 4 dimensions are not supported", a, n);
        if (a <= 4) layout->dims[a - 1] = (size_t)n;
    }
    if (sqffd_image__nifti_type(sqffd_image__i16(h + 70, be), layout, image, name, err, err_size)) return 1;
    if (sqffd_image__total(layout, name, err, err_size)) return 1;

    for (a = 0; a < 8; a++) pixdim[a] = sqffd_image__f32(h + 76 + 4 * a, be);
    for (a = 1; a <= 3 || (a == 4 && ndim >= 4); a++)
        if (!isfinite(pixdim[a]))
            return sqffd_io__fail(err, err_size, name, "pixdim[%d] is not a finite number", a);
    for (a = 0; a < 3; a++) image->spacing[a] = pixdim[a + 1];
    image->time_step = ndim >= 4 ? pixdim[4] : 0.0;

    vox_offset = sqffd_image__f32(h + 108, be);
    if (!isfinite(vox_offset) || vox_offset < 0 || vox_offset != floor(vox_offset) ||
        vox_offset > (double)SQFFD_IMAGE_MAX_BYTES)
        return sqffd_io__fail(err, err_size, name, "vox_offset = %g is not a byte offset", vox_offset);
    if (!layout->pair) {
        if (vox_offset == 0) {
            /* unset (as in many files): the data follow the header and its
               4 extension bytes, unless extensions are flagged there */
            if (size >= 352 && h[348] != 0)
                return sqffd_io__fail(err, err_size, name,
                                         "vox_offset = 0 with header extensions present: the data start is unknown");
            vox_offset = 352;
        } else if (vox_offset < 352)
            return sqffd_io__fail(err, err_size, name,
                                     "vox_offset = %g: inside the 352 bytes of header of a .nii file", vox_offset);
    }
    layout->skip_before = (size_t)vox_offset;

    /* value = slope * stored + inter; a zero or non-finite slope means unscaled (as nibabel) */
    slope = sqffd_image__f32(h + 112, be);
    inter = sqffd_image__f32(h + 116, be);
    if (slope == 0 || !isfinite(slope)) {
        image->volume.scale = 0;
        image->volume.offset = 0;
    } else {
        if (!isfinite(inter))
            return sqffd_io__fail(err, err_size, name, "scl_inter is not finite while scl_slope is %g", slope);
        image->volume.scale = slope;
        image->volume.offset = inter;
    }

    memset(image->volume.affine, 0, sizeof image->volume.affine);
    image->volume.affine[15] = 1;
    qform_code = sqffd_image__i16(h + 252, be);
    sform_code = sqffd_image__i16(h + 254, be);
    if (sform_code != 0) {
        for (a = 0; a < 12; a++) image->volume.affine[a] = sqffd_image__f32(h + 280 + 4 * a, be);
        sqffd_image__set_text(image->affine_source, sizeof image->affine_source, "sform");
    } else if (qform_code != 0) {
        sqffd_image__qform(h, be, image->volume.affine);
        sqffd_image__set_text(image->affine_source, sizeof image->affine_source, "qform");
    } else {
        /* nibabel's fall-back: x flipped, the middle voxel at the origin */
        for (a = 0; a < 3; a++) {
            double zoom = a < ndim ? pixdim[a + 1] : 1.0, n = (double)layout->dims[a];
            if (a == 0) zoom = -zoom;
            image->volume.affine[5 * a] = zoom;
            image->volume.affine[4 * a + 3] = -(n - 1) / 2 * zoom;
        }
        sqffd_image__set_text(image->affine_source, sizeof image->affine_source, "pixdim");
    }
    for (a = 0; a < 12; a++)
        if (!isfinite(image->volume.affine[a]))
            return sqffd_io__fail(err, err_size, name, "the %s holds a value that is not finite",
                                     image->affine_source);
    return 0;
}

/* ---- MetaImage ----------------------------------------------------------- */

enum {
    SQFFD_IMAGE__MHA_OBJECT, SQFFD_IMAGE__MHA_NDIMS, SQFFD_IMAGE__MHA_DIMSIZE, SQFFD_IMAGE__MHA_TYPE,
    SQFFD_IMAGE__MHA_SPACING, SQFFD_IMAGE__MHA_SIZE, SQFFD_IMAGE__MHA_OFFSET, SQFFD_IMAGE__MHA_MATRIX,
    SQFFD_IMAGE__MHA_MSB, SQFFD_IMAGE__MHA_BINARY, SQFFD_IMAGE__MHA_COMPRESSED, SQFFD_IMAGE__MHA_COMPRESSED_SIZE,
    SQFFD_IMAGE__MHA_HEADER_SIZE, SQFFD_IMAGE__MHA_CHANNELS, SQFFD_IMAGE__MHA_DATA_FILE, SQFFD_IMAGE__MHA_KEYS
};

/* One header value: [s, e) and the key as the file spells it. */
typedef struct sqffd_image__value {
    const char *s, *e;
    const char *key;
} sqffd_image__value;

/* The key a MetaImage header line starts with, or -1 for keys this reader
   ignores (AnatomicalOrientation, CenterOfRotation, ElementMin...). */
static inline int sqffd_image__mha_key(const char *key, size_t len, const char **spelled)
{
    static const struct { const char *name; int key; } keys[] = {
        {"ObjectType", SQFFD_IMAGE__MHA_OBJECT},
        {"NDims", SQFFD_IMAGE__MHA_NDIMS},
        {"DimSize", SQFFD_IMAGE__MHA_DIMSIZE},
        {"ElementType", SQFFD_IMAGE__MHA_TYPE},
        {"ElementSpacing", SQFFD_IMAGE__MHA_SPACING},
        {"ElementSize", SQFFD_IMAGE__MHA_SIZE},
        {"Offset", SQFFD_IMAGE__MHA_OFFSET},
        {"Position", SQFFD_IMAGE__MHA_OFFSET},
        {"Origin", SQFFD_IMAGE__MHA_OFFSET},
        {"TransformMatrix", SQFFD_IMAGE__MHA_MATRIX},
        {"Rotation", SQFFD_IMAGE__MHA_MATRIX},
        {"Orientation", SQFFD_IMAGE__MHA_MATRIX},
        {"BinaryDataByteOrderMSB", SQFFD_IMAGE__MHA_MSB},
        {"ElementByteOrderMSB", SQFFD_IMAGE__MHA_MSB},
        {"BinaryData", SQFFD_IMAGE__MHA_BINARY},
        {"CompressedData", SQFFD_IMAGE__MHA_COMPRESSED},
        {"CompressedDataSize", SQFFD_IMAGE__MHA_COMPRESSED_SIZE},
        {"HeaderSize", SQFFD_IMAGE__MHA_HEADER_SIZE},
        {"ElementNumberOfChannels", SQFFD_IMAGE__MHA_CHANNELS},
        {"ElementDataFile", SQFFD_IMAGE__MHA_DATA_FILE}};
    size_t i;
    for (i = 0; i < sizeof keys / sizeof keys[0]; i++)
        if (sqffd_io__is(key, len, keys[i].name)) {
            *spelled = keys[i].name;
            return keys[i].key;
        }
    return -1;
}

/* Whether the text starts like a MetaImage header: its first line is
   "ObjectType = ..." or "NDims = ...". */
static inline int sqffd_image__looks_metaimage(const char *text, size_t size)
{
    const char *p = text, *end = text + size, *s, *e, *eq;
    while (sqffd_image__line(&p, end, &s, &e)) {
        sqffd_image__trim(&s, &e);
        if (s == e) continue;
        eq = (const char *)memchr(s, '=', (size_t)(e - s));
        if (!eq) return 0;
        e = eq;
        sqffd_image__trim(&s, &e);
        return sqffd_io__is(s, (size_t)(e - s), "ObjectType") || sqffd_io__is(s, (size_t)(e - s), "NDims");
    }
    return 0;
}

/* A MetaImage True/False (also 1/0); 0 on success. */
static inline int sqffd_image__bool(const sqffd_image__value *v, int *out, const char *name, char *err,
                                    size_t err_size)
{
    size_t len = (size_t)(v->e - v->s);
    char q[32];
    if (sqffd_io__is(v->s, len, "true") || sqffd_io__is(v->s, len, "1")) *out = 1;
    else if (sqffd_io__is(v->s, len, "false") || sqffd_io__is(v->s, len, "0")) *out = 0;
    else
        return sqffd_io__fail(err, err_size, name, "%s = %s: expected True or False", v->key,
                                 sqffd_io__quote(v->s, len, q));
    return 0;
}

/* One whole number from a MetaImage value, at least `lowest`. */
static inline int sqffd_image__mha_integer(const sqffd_image__value *v, long long lowest, long long *out,
                                           const char *name, char *err, size_t err_size)
{
    char q[32];
    if (sqffd_image__integer(v->s, (size_t)(v->e - v->s), out) || *out < lowest)
        return sqffd_io__fail(err, err_size, name, "%s = %s: expected a whole number, at least %lld", v->key,
                                 sqffd_io__quote(v->s, (size_t)(v->e - v->s), q), lowest);
    return 0;
}

static inline int sqffd_image__metaimage(const char *text, size_t size, const char *name, sqffd_image *image,
                                         sqffd_image__layout *layout, char *err, size_t err_size)
{
    sqffd_image__value v[SQFFD_IMAGE__MHA_KEYS];
    const char *p = text, *end = text + size, *s, *e;
    unsigned long long line = 0;
    double spacing[4] = {1, 1, 1, 1}, offset[4] = {0, 0, 0, 0}, matrix[16];
    long long number = 0;
    size_t ndims, r, c;
    int flag, header_ended = 0;
    char q[32];
    memset(v, 0, sizeof v);
    while (!header_ended && sqffd_image__line(&p, end, &s, &e)) {
        const char *eq, *ks, *ke, *spelled = NULL;
        int key;
        line++;
        sqffd_image__trim(&s, &e);
        if (s == e) continue;
        eq = (const char *)memchr(s, '=', (size_t)(e - s));
        if (!eq)
            return sqffd_io__fail(err, err_size, name, "line %llu: expected \"Key = Value\", found %s", line,
                                     sqffd_io__quote(s, (size_t)(e - s), q));
        ks = s;
        ke = eq;
        sqffd_image__trim(&ks, &ke);
        key = sqffd_image__mha_key(ks, (size_t)(ke - ks), &spelled);
        if (key < 0) continue;
        s = eq + 1;
        sqffd_image__trim(&s, &e);
        v[key].s = s;
        v[key].e = e;
        v[key].key = spelled;
        if (key == SQFFD_IMAGE__MHA_DATA_FILE) header_ended = 1; /* the data follow this line */
    }
    if (!header_ended)
        return sqffd_io__fail(err, err_size, name, "no ElementDataFile line (it ends a MetaImage header)");
    sqffd_image__set_text(image->format, sizeof image->format, "MetaImage");
    layout->start = (size_t)(p - text);

    if (v[SQFFD_IMAGE__MHA_OBJECT].key && !sqffd_io__is(v[SQFFD_IMAGE__MHA_OBJECT].s,
                                                          (size_t)(v[SQFFD_IMAGE__MHA_OBJECT].e - v[SQFFD_IMAGE__MHA_OBJECT].s),
                                                          "Image"))
        return sqffd_io__fail(err, err_size, name, "ObjectType = %s: not an image",
                                 sqffd_io__quote(v[SQFFD_IMAGE__MHA_OBJECT].s,
                                                    (size_t)(v[SQFFD_IMAGE__MHA_OBJECT].e - v[SQFFD_IMAGE__MHA_OBJECT].s), q));
    if (!v[SQFFD_IMAGE__MHA_NDIMS].key) return sqffd_io__fail(err, err_size, name, "no NDims");
    if (sqffd_image__mha_integer(&v[SQFFD_IMAGE__MHA_NDIMS], 1, &number, name, err, err_size)) return 1;
    if (number != 3 && number != 4)
        return sqffd_io__fail(err, err_size, name, "NDims = %lld: only 3-D and 4-D images are supported", number);
    ndims = (size_t)number;
    if (!v[SQFFD_IMAGE__MHA_DIMSIZE].key) return sqffd_io__fail(err, err_size, name, "no DimSize");
    if (sqffd_image__sizes(v[SQFFD_IMAGE__MHA_DIMSIZE].s, v[SQFFD_IMAGE__MHA_DIMSIZE].e, ndims, layout->dims, name,
                           "DimSize", err, err_size))
        return 1;

    if (!v[SQFFD_IMAGE__MHA_TYPE].key) return sqffd_io__fail(err, err_size, name, "no ElementType");
    {
        static const struct { const char *name; int type; } types[] = {
            {"MET_UCHAR", SQFFD_VOXEL_U8},  {"MET_CHAR", SQFFD_VOXEL_I8},   {"MET_USHORT", SQFFD_VOXEL_U16},
            {"MET_SHORT", SQFFD_VOXEL_I16}, {"MET_INT", SQFFD_VOXEL_I32},   {"MET_FLOAT", SQFFD_VOXEL_F32},
            {"MET_DOUBLE", SQFFD_VOXEL_F64}};
        const sqffd_image__value *t = &v[SQFFD_IMAGE__MHA_TYPE];
        size_t i, len = (size_t)(t->e - t->s);
        for (i = 0; i < sizeof types / sizeof types[0]; i++)
            if (sqffd_io__is(t->s, len, types[i].name)) break;
        if (i == sizeof types / sizeof types[0])
            return sqffd_io__fail(err, err_size, name,
                                     "ElementType %s is not supported (MET_UCHAR, MET_CHAR, MET_USHORT, MET_SHORT, "
                                     "MET_INT, MET_FLOAT and MET_DOUBLE are)", sqffd_io__quote(t->s, len, q));
        layout->type = (sqffd_voxel_type)types[i].type;
        layout->element_size = sqffd_image__type_size(layout->type);
        sqffd_image__set_text(image->stored_type, sizeof image->stored_type, types[i].name);
    }
    if (v[SQFFD_IMAGE__MHA_CHANNELS].key) {
        if (sqffd_image__mha_integer(&v[SQFFD_IMAGE__MHA_CHANNELS], 1, &number, name, err, err_size)) return 1;
        if (number != 1)
            return sqffd_io__fail(err, err_size, name,
                                     "ElementNumberOfChannels = %lld: only single-channel images are supported",
                                     number);
    }
    if (v[SQFFD_IMAGE__MHA_BINARY].key) {
        if (sqffd_image__bool(&v[SQFFD_IMAGE__MHA_BINARY], &flag, name, err, err_size)) return 1;
        if (!flag)
            return sqffd_io__fail(err, err_size, name, "BinaryData = False (voxels as text) is not supported");
    }
    if (sqffd_image__total(layout, name, err, err_size)) return 1;

    if (v[SQFFD_IMAGE__MHA_MSB].key &&
        sqffd_image__bool(&v[SQFFD_IMAGE__MHA_MSB], &layout->big_endian, name, err, err_size))
        return 1;
    image->big_endian = layout->big_endian;
    if (v[SQFFD_IMAGE__MHA_COMPRESSED].key) {
        if (sqffd_image__bool(&v[SQFFD_IMAGE__MHA_COMPRESSED], &flag, name, err, err_size)) return 1;
        if (flag) layout->encoding = SQFFD_IMAGE__ZLIB;
    }
    if (v[SQFFD_IMAGE__MHA_COMPRESSED_SIZE].key && layout->encoding == SQFFD_IMAGE__ZLIB) {
        if (sqffd_image__mha_integer(&v[SQFFD_IMAGE__MHA_COMPRESSED_SIZE], 1, &number, name, err, err_size))
            return 1;
        if ((unsigned long long)number > (unsigned long long)SQFFD_IMAGE_MAX_BYTES)
            return sqffd_io__fail(err, err_size, name, "CompressedDataSize = %lld: larger than any file taken",
                                     number);
        layout->compressed_size = (size_t)number;
    }
    if (v[SQFFD_IMAGE__MHA_HEADER_SIZE].key) {
        if (sqffd_image__mha_integer(&v[SQFFD_IMAGE__MHA_HEADER_SIZE], -1, &number, name, err, err_size)) return 1;
        if (number == -1) {
            if (layout->encoding == SQFFD_IMAGE__ZLIB && !layout->compressed_size)
                return sqffd_io__fail(err, err_size, name,
                                         "HeaderSize = -1 with compressed data needs CompressedDataSize");
            layout->at_end = 1;
        } else if ((unsigned long long)number > (unsigned long long)SQFFD_IMAGE_MAX_BYTES)
            return sqffd_io__fail(err, err_size, name, "HeaderSize = %lld: larger than any file taken", number);
        else
            layout->skip_before = (size_t)number;
    }

    /* geometry */
    if (v[SQFFD_IMAGE__MHA_SPACING].key) {
        if (sqffd_image__numbers(v[SQFFD_IMAGE__MHA_SPACING].s, v[SQFFD_IMAGE__MHA_SPACING].e, ndims, 0, spacing,
                                 name, "ElementSpacing", err, err_size))
            return 1;
    } else if (v[SQFFD_IMAGE__MHA_SIZE].key &&
               sqffd_image__numbers(v[SQFFD_IMAGE__MHA_SIZE].s, v[SQFFD_IMAGE__MHA_SIZE].e, ndims, 0, spacing, name,
                                    "ElementSize", err, err_size))
        return 1;
    if (v[SQFFD_IMAGE__MHA_OFFSET].key &&
        sqffd_image__numbers(v[SQFFD_IMAGE__MHA_OFFSET].s, v[SQFFD_IMAGE__MHA_OFFSET].e, ndims, 0, offset, name,
                             v[SQFFD_IMAGE__MHA_OFFSET].key, err, err_size))
        return 1;
    for (r = 0; r < ndims; r++)
        for (c = 0; c < ndims; c++) matrix[r * ndims + c] = r == c;
    if (v[SQFFD_IMAGE__MHA_MATRIX].key &&
        sqffd_image__numbers(v[SQFFD_IMAGE__MHA_MATRIX].s, v[SQFFD_IMAGE__MHA_MATRIX].e, ndims * ndims, 0, matrix,
                             name, v[SQFFD_IMAGE__MHA_MATRIX].key, err, err_size))
        return 1;
    memset(image->volume.affine, 0, sizeof image->volume.affine);
    for (r = 0; r < 3; r++) {
        for (c = 0; c < 3; c++) image->volume.affine[4 * r + c] = matrix[c * ndims + r] * spacing[c];
        image->volume.affine[4 * r + 3] = offset[r];
        image->spacing[r] = spacing[r];
    }
    image->volume.affine[15] = 1;
    image->time_step = ndims == 4 ? spacing[3] : 0.0;
    for (r = 0; r < 12; r++)
        if (!isfinite(image->volume.affine[r]))
            return sqffd_io__fail(err, err_size, name, "the affine from %s holds a value that is not finite",
                                     v[SQFFD_IMAGE__MHA_MATRIX].key ? v[SQFFD_IMAGE__MHA_MATRIX].key : "ElementSpacing");
    sqffd_image__set_text(image->affine_source, sizeof image->affine_source,
                          v[SQFFD_IMAGE__MHA_MATRIX].key ? "TransformMatrix"
                          : v[SQFFD_IMAGE__MHA_SPACING].key || v[SQFFD_IMAGE__MHA_SIZE].key ? "ElementSpacing" : "none");

    /* the data: LOCAL (right after this header) or a file beside it */
    {
        const sqffd_image__value *f = &v[SQFFD_IMAGE__MHA_DATA_FILE];
        size_t len = (size_t)(f->e - f->s);
        if (len == 0) return sqffd_io__fail(err, err_size, name, "ElementDataFile is empty");
        if (sqffd_io__is(f->s, len, "LIST"))
            return sqffd_io__fail(err, err_size, name, "ElementDataFile = LIST (one file per slice) is not supported");
        if (memchr(f->s, '%', len))
            return sqffd_io__fail(err, err_size, name,
                                     "ElementDataFile = %s: a file-name pattern (one file per slice) is not supported",
                                     sqffd_io__quote(f->s, len, q));
        if (!sqffd_io__is(f->s, len, "LOCAL")) {
            layout->data_file = f->s;
            layout->data_file_len = len;
            layout->start = 0;
        }
    }
    return 0;
}

/* ---- NRRD ---------------------------------------------------------------- */

enum {
    SQFFD_IMAGE__NRRD_TYPE, SQFFD_IMAGE__NRRD_DIMENSION, SQFFD_IMAGE__NRRD_SIZES, SQFFD_IMAGE__NRRD_ENCODING,
    SQFFD_IMAGE__NRRD_ENDIAN, SQFFD_IMAGE__NRRD_SPACE, SQFFD_IMAGE__NRRD_SPACE_DIMENSION,
    SQFFD_IMAGE__NRRD_DIRECTIONS, SQFFD_IMAGE__NRRD_ORIGIN, SQFFD_IMAGE__NRRD_SPACINGS,
    SQFFD_IMAGE__NRRD_DATA_FILE, SQFFD_IMAGE__NRRD_LINE_SKIP, SQFFD_IMAGE__NRRD_BYTE_SKIP, SQFFD_IMAGE__NRRD_FIELDS
};

/* The field a NRRD header line names, or -1 for fields this reader ignores
   (kinds, centers, labels, units, content, min, max...). */
static inline int sqffd_image__nrrd_field(const char *field, size_t len, const char **spelled)
{
    static const struct { const char *name; int field; } fields[] = {
        {"type", SQFFD_IMAGE__NRRD_TYPE},
        {"dimension", SQFFD_IMAGE__NRRD_DIMENSION},
        {"sizes", SQFFD_IMAGE__NRRD_SIZES},
        {"encoding", SQFFD_IMAGE__NRRD_ENCODING},
        {"endian", SQFFD_IMAGE__NRRD_ENDIAN},
        {"space", SQFFD_IMAGE__NRRD_SPACE},
        {"space dimension", SQFFD_IMAGE__NRRD_SPACE_DIMENSION},
        {"space directions", SQFFD_IMAGE__NRRD_DIRECTIONS},
        {"space origin", SQFFD_IMAGE__NRRD_ORIGIN},
        {"spacings", SQFFD_IMAGE__NRRD_SPACINGS},
        {"data file", SQFFD_IMAGE__NRRD_DATA_FILE},
        {"datafile", SQFFD_IMAGE__NRRD_DATA_FILE},
        {"line skip", SQFFD_IMAGE__NRRD_LINE_SKIP},
        {"lineskip", SQFFD_IMAGE__NRRD_LINE_SKIP},
        {"byte skip", SQFFD_IMAGE__NRRD_BYTE_SKIP},
        {"byteskip", SQFFD_IMAGE__NRRD_BYTE_SKIP}};
    size_t i;
    for (i = 0; i < sizeof fields / sizeof fields[0]; i++)
        if (sqffd_io__is(field, len, fields[i].name)) {
            *spelled = fields[i].name;
            return fields[i].field;
        }
    return -1;
}

/* The voxel type of a NRRD type name (every spelling the format allows for
   the types the core reads); 1 for any other. */
static inline int sqffd_image__nrrd_type(const char *s, size_t len, sqffd_image__layout *layout, sqffd_image *image)
{
    static const struct { const char *name; int type; const char *canonical; } types[] = {
        {"signed char", SQFFD_VOXEL_I8, "int8"},        {"int8", SQFFD_VOXEL_I8, "int8"},
        {"int8_t", SQFFD_VOXEL_I8, "int8"},             {"uchar", SQFFD_VOXEL_U8, "uint8"},
        {"unsigned char", SQFFD_VOXEL_U8, "uint8"},     {"uint8", SQFFD_VOXEL_U8, "uint8"},
        {"uint8_t", SQFFD_VOXEL_U8, "uint8"},           {"short", SQFFD_VOXEL_I16, "int16"},
        {"short int", SQFFD_VOXEL_I16, "int16"},        {"signed short", SQFFD_VOXEL_I16, "int16"},
        {"signed short int", SQFFD_VOXEL_I16, "int16"}, {"int16", SQFFD_VOXEL_I16, "int16"},
        {"int16_t", SQFFD_VOXEL_I16, "int16"},          {"ushort", SQFFD_VOXEL_U16, "uint16"},
        {"unsigned short", SQFFD_VOXEL_U16, "uint16"},  {"unsigned short int", SQFFD_VOXEL_U16, "uint16"},
        {"uint16", SQFFD_VOXEL_U16, "uint16"},          {"uint16_t", SQFFD_VOXEL_U16, "uint16"},
        {"int", SQFFD_VOXEL_I32, "int32"},              {"signed int", SQFFD_VOXEL_I32, "int32"},
        {"int32", SQFFD_VOXEL_I32, "int32"},            {"int32_t", SQFFD_VOXEL_I32, "int32"},
        {"float", SQFFD_VOXEL_F32, "float"},            {"double", SQFFD_VOXEL_F64, "double"}};
    size_t i;
    for (i = 0; i < sizeof types / sizeof types[0]; i++)
        if (sqffd_io__is(s, len, types[i].name)) {
            layout->type = (sqffd_voxel_type)types[i].type;
            layout->element_size = sqffd_image__type_size(layout->type);
            sqffd_image__set_text(image->stored_type, sizeof image->stored_type, types[i].canonical);
            return 0;
        }
    return 1;
}

/* A NRRD vector "(x, y, z)" of exactly 3 finite numbers at *p (blanks
   before it skipped); moves *p past the ')'. */
static inline int sqffd_image__nrrd_vector(const char **p, const char *end, double out[3], const char *name,
                                           const char *field, char *err, size_t err_size)
{
    const char *s = *p, *close;
    while (s < end && sqffd_image__is_blank(*s)) s++;
    if (s == end || *s != '(')
        return sqffd_io__fail(err, err_size, name, "%s: expected a vector \"(x,y,z)\"", field);
    close = (const char *)memchr(s, ')', (size_t)(end - s));
    if (!close) return sqffd_io__fail(err, err_size, name, "%s: a vector without its ')'", field);
    if (sqffd_image__numbers(s + 1, close, 3, 0, out, name, field, err, err_size)) return 1;
    *p = close + 1;
    return 0;
}

static inline int sqffd_image__nrrd(const char *text, size_t size, const char *name, sqffd_image *image,
                                    sqffd_image__layout *layout, char *err, size_t err_size)
{
    sqffd_image__value v[SQFFD_IMAGE__NRRD_FIELDS];
    const char *p = text, *end = text + size, *s, *e;
    unsigned long long line = 1;
    double directions[4][3], origin[3] = {0, 0, 0}, spacings[4] = {1, 1, 1, 1};
    int blank_line = 0, a, r;
    long long number = 0;
    size_t dimension, len;
    char q[32];

    if (!sqffd_image__line(&p, end, &s, &e) || e - s < 8 || memcmp(s, "NRRD000", 7) != 0)
        return sqffd_io__fail(err, err_size, name, "not a NRRD file: no \"NRRD000X\" magic line");
    sqffd_image__trim(&s, &e);
    if (e - s != 8 || s[7] < '1' || s[7] > '5')
        return sqffd_io__fail(err, err_size, name, "magic %s: only NRRD0001 to NRRD0005 are known",
                                 sqffd_io__quote(s, (size_t)(e - s), q));
    sqffd_image__set_text(image->format, sizeof image->format, "NRRD");
    memset(v, 0, sizeof v);
    while (sqffd_image__line(&p, end, &s, &e)) {
        const char *colon, *fs, *fe, *spelled = NULL;
        int field;
        line++;
        sqffd_image__trim(&s, &e);
        if (s == e) { blank_line = 1; break; } /* attached data follow */
        if (*s == '#') continue;
        colon = (const char *)memchr(s, ':', (size_t)(e - s));
        if (!colon)
            return sqffd_io__fail(err, err_size, name, "line %llu: expected \"field: value\", found %s", line,
                                     sqffd_io__quote(s, (size_t)(e - s), q));
        if (colon + 1 < e && colon[1] == '=') continue; /* key:=value pairs carry nothing read here */
        fs = s;
        fe = colon;
        sqffd_image__trim(&fs, &fe);
        field = sqffd_image__nrrd_field(fs, (size_t)(fe - fs), &spelled);
        if (field < 0) continue;
        s = colon + 1;
        sqffd_image__trim(&s, &e);
        v[field].s = s;
        v[field].e = e;
        v[field].key = spelled;
    }
    layout->start = (size_t)(p - text);

    if (!v[SQFFD_IMAGE__NRRD_TYPE].key) return sqffd_io__fail(err, err_size, name, "no type field");
    len = (size_t)(v[SQFFD_IMAGE__NRRD_TYPE].e - v[SQFFD_IMAGE__NRRD_TYPE].s);
    if (sqffd_image__nrrd_type(v[SQFFD_IMAGE__NRRD_TYPE].s, len, layout, image))
        return sqffd_io__fail(err, err_size, name,
                                 "type %s is not supported (int8, uint8, int16, uint16, int32, float and double are)",
                                 sqffd_io__quote(v[SQFFD_IMAGE__NRRD_TYPE].s, len, q));
    if (!v[SQFFD_IMAGE__NRRD_DIMENSION].key) return sqffd_io__fail(err, err_size, name, "no dimension field");
    len = (size_t)(v[SQFFD_IMAGE__NRRD_DIMENSION].e - v[SQFFD_IMAGE__NRRD_DIMENSION].s);
    if (sqffd_image__integer(v[SQFFD_IMAGE__NRRD_DIMENSION].s, len, &number) || (number != 3 && number != 4))
        return sqffd_io__fail(err, err_size, name, "dimension %s: only 3-D and 4-D images are supported",
                                 sqffd_io__quote(v[SQFFD_IMAGE__NRRD_DIMENSION].s, len, q));
    dimension = (size_t)number;
    if (!v[SQFFD_IMAGE__NRRD_SIZES].key) return sqffd_io__fail(err, err_size, name, "no sizes field");
    if (sqffd_image__sizes(v[SQFFD_IMAGE__NRRD_SIZES].s, v[SQFFD_IMAGE__NRRD_SIZES].e, dimension, layout->dims, name,
                           "sizes", err, err_size))
        return 1;
    if (sqffd_image__total(layout, name, err, err_size)) return 1;

    if (!v[SQFFD_IMAGE__NRRD_ENCODING].key) return sqffd_io__fail(err, err_size, name, "no encoding field");
    s = v[SQFFD_IMAGE__NRRD_ENCODING].s;
    len = (size_t)(v[SQFFD_IMAGE__NRRD_ENCODING].e - s);
    if (sqffd_io__is(s, len, "raw")) layout->encoding = SQFFD_IMAGE__RAW;
    else if (sqffd_io__is(s, len, "gzip") || sqffd_io__is(s, len, "gz")) layout->encoding = SQFFD_IMAGE__GZIP;
    else if (sqffd_io__is(s, len, "ascii") || sqffd_io__is(s, len, "text") || sqffd_io__is(s, len, "txt"))
        layout->encoding = SQFFD_IMAGE__ASCII;
    else
        return sqffd_io__fail(err, err_size, name, "encoding %s is not supported (raw, gzip and ascii are)",
                                 sqffd_io__quote(s, len, q));
    if (v[SQFFD_IMAGE__NRRD_ENDIAN].key) {
        s = v[SQFFD_IMAGE__NRRD_ENDIAN].s;
        len = (size_t)(v[SQFFD_IMAGE__NRRD_ENDIAN].e - s);
        if (sqffd_io__is(s, len, "big")) layout->big_endian = 1;
        else if (!sqffd_io__is(s, len, "little"))
            return sqffd_io__fail(err, err_size, name, "endian %s: expected little or big",
                                     sqffd_io__quote(s, len, q));
    } else if (layout->element_size > 1 && layout->encoding != SQFFD_IMAGE__ASCII)
        return sqffd_io__fail(err, err_size, name, "no endian field (needed for %u-byte voxels)",
                                 (unsigned)layout->element_size);
    image->big_endian = layout->big_endian;

    if (v[SQFFD_IMAGE__NRRD_LINE_SKIP].key) {
        len = (size_t)(v[SQFFD_IMAGE__NRRD_LINE_SKIP].e - v[SQFFD_IMAGE__NRRD_LINE_SKIP].s);
        if (sqffd_image__integer(v[SQFFD_IMAGE__NRRD_LINE_SKIP].s, len, &number) || number < 0 ||
            (unsigned long long)number > (unsigned long long)SQFFD_IMAGE_MAX_BYTES)
            return sqffd_io__fail(err, err_size, name, "line skip %s: expected a line count",
                                     sqffd_io__quote(v[SQFFD_IMAGE__NRRD_LINE_SKIP].s, len, q));
        layout->line_skip = (size_t)number;
    }
    if (v[SQFFD_IMAGE__NRRD_BYTE_SKIP].key) {
        len = (size_t)(v[SQFFD_IMAGE__NRRD_BYTE_SKIP].e - v[SQFFD_IMAGE__NRRD_BYTE_SKIP].s);
        if (sqffd_image__integer(v[SQFFD_IMAGE__NRRD_BYTE_SKIP].s, len, &number) || number < -1 ||
            (number > 0 && (unsigned long long)number > (unsigned long long)SQFFD_IMAGE_MAX_BYTES))
            return sqffd_io__fail(err, err_size, name, "byte skip %s: expected a byte count or -1",
                                     sqffd_io__quote(v[SQFFD_IMAGE__NRRD_BYTE_SKIP].s, len, q));
        if (number == -1) {
            if (layout->encoding != SQFFD_IMAGE__RAW)
                return sqffd_io__fail(err, err_size, name, "byte skip -1 (data at the end) needs raw encoding");
            layout->at_end = 1;
        } else if (layout->encoding == SQFFD_IMAGE__GZIP)
            layout->skip_after = (size_t)number; /* skipped in the decompressed data */
        else
            layout->skip_before = (size_t)number;
    }

    /* geometry: the file's own space, never converted */
    if (v[SQFFD_IMAGE__NRRD_SPACE].key) {
        static const char *const spaces3[] = {"right-anterior-superior", "RAS", "left-anterior-superior", "LAS",
                                              "left-posterior-superior", "LPS", "scanner-xyz", "3D-right-handed",
                                              "3D-left-handed"};
        size_t i;
        s = v[SQFFD_IMAGE__NRRD_SPACE].s;
        len = (size_t)(v[SQFFD_IMAGE__NRRD_SPACE].e - s);
        for (i = 0; i < sizeof spaces3 / sizeof spaces3[0]; i++)
            if (sqffd_io__is(s, len, spaces3[i])) break;
        if (i == sizeof spaces3 / sizeof spaces3[0])
            return sqffd_io__fail(err, err_size, name, "space %s: only 3-D spaces are supported",
                                     sqffd_io__quote(s, len, q));
    }
    if (v[SQFFD_IMAGE__NRRD_SPACE_DIMENSION].key) {
        len = (size_t)(v[SQFFD_IMAGE__NRRD_SPACE_DIMENSION].e - v[SQFFD_IMAGE__NRRD_SPACE_DIMENSION].s);
        if (sqffd_image__integer(v[SQFFD_IMAGE__NRRD_SPACE_DIMENSION].s, len, &number) || number != 3)
            return sqffd_io__fail(err, err_size, name, "space dimension %s: only 3 is supported",
                                     sqffd_io__quote(v[SQFFD_IMAGE__NRRD_SPACE_DIMENSION].s, len, q));
    }
    if (v[SQFFD_IMAGE__NRRD_SPACINGS].key &&
        sqffd_image__numbers(v[SQFFD_IMAGE__NRRD_SPACINGS].s, v[SQFFD_IMAGE__NRRD_SPACINGS].e, dimension, 1, spacings,
                             name, "spacings", err, err_size))
        return 1;
    if (v[SQFFD_IMAGE__NRRD_DIRECTIONS].key) {
        const char *d = v[SQFFD_IMAGE__NRRD_DIRECTIONS].s, *de = v[SQFFD_IMAGE__NRRD_DIRECTIONS].e;
        int spatial = 0;
        for (a = 0; a < (int)dimension; a++) {
            while (d < de && sqffd_image__is_blank(*d)) d++;
            if (de - d >= 4 && sqffd_io__is(d, 4, "none") && (de - d == 4 || sqffd_image__is_blank(d[4]))) {
                layout->frame_axis = a;
                d += 4;
                continue;
            }
            if (sqffd_image__nrrd_vector(&d, de, directions[a], name, "space directions", err, err_size)) return 1;
            spatial++;
        }
        while (d < de && sqffd_image__is_blank(*d)) d++;
        if (d != de)
            return sqffd_io__fail(err, err_size, name, "space directions: more than %u entries",
                                     (unsigned)dimension);
        if (spatial != 3)
            return sqffd_io__fail(err, err_size, name,
                                     "space directions: %d vectors; exactly 3 axes must be spatial (the others "
                                     "\"none\")", spatial);
    } /* without them the 4th axis is the non-spatial one (frame_axis stays 3) */
    if (v[SQFFD_IMAGE__NRRD_ORIGIN].key) {
        const char *o = v[SQFFD_IMAGE__NRRD_ORIGIN].s;
        if (sqffd_image__nrrd_vector(&o, v[SQFFD_IMAGE__NRRD_ORIGIN].e, origin, name, "space origin", err, err_size))
            return 1;
    }
    memset(image->volume.affine, 0, sizeof image->volume.affine);
    for (a = 0, r = 0; a < (int)dimension; a++) { /* r: the spatial axis (i, j, k) axis a becomes */
        int row;
        if (a == layout->frame_axis && dimension == 4) {
            image->time_step = v[SQFFD_IMAGE__NRRD_SPACINGS].key && isfinite(spacings[a]) ? spacings[a] : 0.0;
            continue;
        }
        if (r == 3) break;
        if (v[SQFFD_IMAGE__NRRD_DIRECTIONS].key) {
            for (row = 0; row < 3; row++) image->volume.affine[4 * row + r] = directions[a][row];
            image->spacing[r] = sqrt(directions[a][0] * directions[a][0] + directions[a][1] * directions[a][1] +
                                     directions[a][2] * directions[a][2]);
        } else {
            if (!isfinite(spacings[a]))
                return sqffd_io__fail(err, err_size, name, "spacings: axis %d is spatial but its spacing is nan",
                                         a);
            image->volume.affine[5 * r] = spacings[a];
            image->spacing[r] = spacings[a];
        }
        r++;
    }
    for (r = 0; r < 3; r++) image->volume.affine[4 * r + 3] = origin[r];
    image->volume.affine[15] = 1;
    for (r = 0; r < 12; r++)
        if (!isfinite(image->volume.affine[r]))
            return sqffd_io__fail(err, err_size, name, "the space directions hold a value that is not finite");
    sqffd_image__set_text(image->affine_source, sizeof image->affine_source,
                          v[SQFFD_IMAGE__NRRD_DIRECTIONS].key ? "space directions"
                          : v[SQFFD_IMAGE__NRRD_SPACINGS].key ? "spacings" : "none");

    /* the data: after the blank line, or in the file "data file" names */
    if (v[SQFFD_IMAGE__NRRD_DATA_FILE].key) {
        const char *f = v[SQFFD_IMAGE__NRRD_DATA_FILE].s, *fe = v[SQFFD_IMAGE__NRRD_DATA_FILE].e;
        len = (size_t)(fe - f);
        if (len == 0) return sqffd_io__fail(err, err_size, name, "data file is empty");
        if (sqffd_io__is(f, len > 4 ? 4 : len, "LIST") && (len == 4 || sqffd_image__is_blank(f[4])))
            return sqffd_io__fail(err, err_size, name, "data file: LIST (several data files) is not supported");
        for (s = f; s < fe; s++)
            if (sqffd_image__is_blank(*s) || *s == '%')
                return sqffd_io__fail(err, err_size, name,
                                         "data file: %s: a file-name pattern (several data files) is not supported",
                                         sqffd_io__quote(f, len, q));
        layout->data_file = f;
        layout->data_file_len = len;
        layout->start = 0;
    } else if (!blank_line)
        return sqffd_io__fail(err, err_size, name,
                                 "no blank line after the header, and no data file field: where are the data?");
    return 0;
}

/* ---- legacy VTK ---------------------------------------------------------- */

/* A legacy VTK STRUCTURED_POINTS dataset, ASCII or BINARY (sqffd_io.h reads
   the header, the value types, and skips what is not read: FIELD data,
   CELL_DATA, other attributes, METADATA): DIMENSIONS nx ny nz, SPACING (or
   its old name ASPECT_RATIO), ORIGIN and DIRECTION (VTK 9's 3 x 3 matrix,
   row by row) in any order before the voxels, which are the first
   one-component SCALARS of POINT_DATA, x fastest, big-endian in a BINARY
   file. Voxel (i, j, k) is at ORIGIN + DIRECTION diag(SPACING) (i, j, k)
   (defaults: 0, the identity, 1). Types: unsigned_char, char, unsigned_short,
   short, int, float, double, and unsigned_int (widened to float64). */
static inline int sqffd_image__vtk(const char *text, size_t size, const char *name, sqffd_image *image,
                                   sqffd_image__layout *layout, char *err, size_t err_size)
{
    static const struct { int io; sqffd_voxel_type voxel; const char *text; } types[] = {
        {SQFFD_IO__U8, SQFFD_VOXEL_U8, "unsigned_char"},   {SQFFD_IO__I8, SQFFD_VOXEL_I8, "char"},
        {SQFFD_IO__U16, SQFFD_VOXEL_U16, "unsigned_short"}, {SQFFD_IO__I16, SQFFD_VOXEL_I16, "short"},
        {SQFFD_IO__I32, SQFFD_VOXEL_I32, "int"},           {SQFFD_IO__U32, SQFFD_VOXEL_I32, "unsigned_int"},
        {SQFFD_IO__F32, SQFFD_VOXEL_F32, "float"},         {SQFFD_IO__F64, SQFFD_VOXEL_F64, "double"}};
    sqffd_io__vtk v;
    double spacing[3] = {1, 1, 1}, origin[3] = {0, 0, 0}, direction[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    int dims_at = 0, geometry = 0, type, k, r;
    uint64_t components, dims[3] = {0, 0, 0};
    size_t t;
    const char *tok;
    size_t len;
    char what[48], q[32];
    if (sqffd_io__vtk_header(text, size, &v, name, err, err_size)) return 1;
    if (strcmp(v.dataset, "STRUCTURED_POINTS") != 0)
        return sqffd_io__fail(err, err_size, name, "DATASET %s holds points, not a volume (a volume is "
                              "STRUCTURED_POINTS)", v.dataset);
    for (;;) {
        if (!sqffd_io__token(&v.t, &tok, &len))
            return sqffd_io__fail(err, err_size, name, "no SCALARS in POINT_DATA: no voxel values");
        snprintf(what, sizeof what, "%.*s (line %llu)", (int)(len < 24 ? len : 24), tok, v.t.line);
        if (sqffd_io__is(tok, len, "DIMENSIONS")) {
            for (k = 0; k < 3; k++) {
                if (sqffd_io__vtk_count(&v, &dims[k], what, name, err, err_size)) return 1;
                if (dims[k] < 1 || dims[k] > (uint64_t)SQFFD_IMAGE_MAX_BYTES)
                    return sqffd_io__fail(err, err_size, name, "%s: %llu is not a size from 1 to %llu", what,
                                          (unsigned long long)dims[k], (unsigned long long)SQFFD_IMAGE_MAX_BYTES);
            }
            dims_at = 1;
        } else if (sqffd_io__is(tok, len, "SPACING") || sqffd_io__is(tok, len, "ASPECT_RATIO")) {
            for (k = 0; k < 3; k++) {
                if (sqffd_io__vtk_value(&v, NULL, &spacing[k], what, name, err, err_size)) return 1;
                if (spacing[k] == 0) return sqffd_io__fail(err, err_size, name, "%s: a spacing of 0", what);
            }
            geometry |= 1;
        } else if (sqffd_io__is(tok, len, "ORIGIN")) {
            for (k = 0; k < 3; k++)
                if (sqffd_io__vtk_value(&v, NULL, &origin[k], what, name, err, err_size)) return 1;
            geometry |= 1;
        } else if (sqffd_io__is(tok, len, "DIRECTION")) {
            for (k = 0; k < 9; k++)
                if (sqffd_io__vtk_value(&v, NULL, &direction[k], what, name, err, err_size)) return 1;
            geometry |= 2;
        } else if (sqffd_io__is(tok, len, "SCALARS") && v.section == 'P') {
            break;
        } else if ((r = sqffd_io__vtk_skip(&v, tok, len, name, err, err_size)) != 0) {
            if (r == 2)
                return sqffd_io__fail(err, err_size, name, "line %llu: unknown keyword %s in DATASET "
                                      "STRUCTURED_POINTS", v.t.line, sqffd_io__quote(tok, len, q));
            return 1;
        }
    }
    if (sqffd_io__vtk_scalars(&v, &type, &components, what, name, err, err_size)) return 1;
    if (!dims_at) return sqffd_io__fail(err, err_size, name, "%s: no DIMENSIONS before the voxels", what);
    if (components != 1)
        return sqffd_io__fail(err, err_size, name, "%s: %llu components a voxel; one is read", what,
                              (unsigned long long)components);
    for (t = 0; t < sizeof types / sizeof types[0] && types[t].io != type; t++) {}
    if (t == sizeof types / sizeof types[0])
        return sqffd_io__fail(err, err_size, name, "%s: 64-bit integer voxels are not read (unsigned_char, char, "
                              "unsigned_short, short, int, unsigned_int, float and double are)", what);
    sqffd_image__set_text(image->format, sizeof image->format, "VTK");
    sqffd_image__set_text(image->stored_type, sizeof image->stored_type, types[t].text);
    layout->type = types[t].voxel;
    layout->uint32 = type == SQFFD_IO__U32;
    layout->element_size = layout->uint32 ? 8 : sqffd_image__type_size(layout->type); /* the widened size, checked */
    for (k = 0; k < 3; k++) layout->dims[k] = (size_t)dims[k];
    if (sqffd_image__total(layout, name, err, err_size)) return 1;
    if (layout->uint32) {
        layout->element_size = 4;
        layout->total /= 2;
    }
    if (v.tuples != (uint64_t)layout->dims[0] * layout->dims[1] * layout->dims[2])
        return sqffd_io__fail(err, err_size, name, "POINT_DATA %llu, but DIMENSIONS %llu x %llu x %llu make %llu "
                              "points", (unsigned long long)v.tuples, (unsigned long long)dims[0],
                              (unsigned long long)dims[1], (unsigned long long)dims[2],
                              (unsigned long long)(layout->dims[0] * layout->dims[1] * layout->dims[2]));
    sqffd_io__vtk_data_start(&v);
    layout->start = (size_t)(v.t.p - text);
    layout->encoding = v.binary ? SQFFD_IMAGE__RAW : SQFFD_IMAGE__ASCII;
    layout->big_endian = image->big_endian = v.binary; /* BINARY is big-endian */
    memset(image->volume.affine, 0, sizeof image->volume.affine);
    for (r = 0; r < 3; r++) {
        for (k = 0; k < 3; k++) image->volume.affine[4 * r + k] = direction[3 * r + k] * spacing[k];
        image->volume.affine[4 * r + 3] = origin[r];
        image->spacing[r] = spacing[r];
    }
    image->volume.affine[15] = 1;
    for (r = 0; r < 12; r++)
        if (!isfinite(image->volume.affine[r]))
            return sqffd_io__fail(err, err_size, name, "DIRECTION x SPACING holds a value that is not finite");
    sqffd_image__set_text(image->affine_source, sizeof image->affine_source,
                          geometry & 2 ? "DIRECTION, SPACING, ORIGIN" : geometry ? "SPACING and ORIGIN" : "none");
    return 0;
}

/* ---- format detection ---------------------------------------------------- */

enum { SQFFD_IMAGE__UNKNOWN = 0, SQFFD_IMAGE__NIFTI = 1, SQFFD_IMAGE__METAIMAGE = 2, SQFFD_IMAGE__NRRD_FORMAT = 3,
       SQFFD_IMAGE__VTK = 4 };

/* The format of `size` bytes by content (a NIfTI-1 sizeof_hdr, or NIfTI-2's;
   the NRRD magic; VTK's first line; a first MetaImage key), else by the
   name's extension. */
static inline int sqffd_image__detect(const unsigned char *data, size_t size, const char *name)
{
    if (size >= 4) {
        uint32_t le = sqffd_image__u32(data, 0), be = sqffd_image__u32(data, 1);
        if (le == 348 || be == 348 || le == 540 || be == 540) return SQFFD_IMAGE__NIFTI;
        if (memcmp(data, "NRRD", 4) == 0) return SQFFD_IMAGE__NRRD_FORMAT;
    }
    if (sqffd_io__vtk_magic(data, size)) return SQFFD_IMAGE__VTK;
    if (sqffd_image__looks_metaimage((const char *)data, size)) return SQFFD_IMAGE__METAIMAGE;
    if (sqffd_image__has_suffix(name, ".nii") || sqffd_image__has_suffix(name, ".nii.gz") ||
        sqffd_image__has_suffix(name, ".hdr") || sqffd_image__has_suffix(name, ".hdr.gz"))
        return SQFFD_IMAGE__NIFTI;
    if (sqffd_image__has_suffix(name, ".mha") || sqffd_image__has_suffix(name, ".mhd"))
        return SQFFD_IMAGE__METAIMAGE;
    if (sqffd_image__has_suffix(name, ".nrrd") || sqffd_image__has_suffix(name, ".nhdr"))
        return SQFFD_IMAGE__NRRD_FORMAT;
    return SQFFD_IMAGE__UNKNOWN;
}

/* Parses whichever header `data` holds into image and layout; a file of a
   format no reader here takes (DICOM, Analyze 7.5, ...: sqffd_io_foreign_format)
   is refused by name. */
static inline int sqffd_image__header(const unsigned char *data, size_t size, const char *name, sqffd_image *image,
                                      sqffd_image__layout *layout, char *err, size_t err_size)
{
    const char *foreign = sqffd_io_foreign_format(data, size);
    sqffd_image__layout_init(layout);
    if (foreign) return sqffd_io__fail(err, err_size, name, "%s", foreign);
    switch (sqffd_image__detect(data, size, name)) {
    case SQFFD_IMAGE__NIFTI: return sqffd_image__nifti(data, size, name, image, layout, err, err_size);
    case SQFFD_IMAGE__METAIMAGE:
        return sqffd_image__metaimage((const char *)data, size, name, image, layout, err, err_size);
    case SQFFD_IMAGE__NRRD_FORMAT: return sqffd_image__nrrd((const char *)data, size, name, image, layout, err, err_size);
    case SQFFD_IMAGE__VTK: return sqffd_image__vtk((const char *)data, size, name, image, layout, err, err_size);
    default:
        return sqffd_io__fail(err, err_size, name, "not a NIfTI-1, MetaImage, NRRD or VTK file");
    }
}

/* The whole of a gzip file in a malloc'd buffer (at most deflate's ratio
   and the size limit allow). */
static inline int sqffd_image__gunzip(const unsigned char *data, size_t size, const char *name, unsigned char **out,
                                      size_t *out_size, char *err, size_t err_size)
{
    size_t cap = SQFFD_IMAGE_MAX_BYTES;
    if (size < (cap - 4096) / SQFFD_IMAGE__DEFLATE_RATIO) cap = size * SQFFD_IMAGE__DEFLATE_RATIO + 4096;
    *out = NULL;
    *out_size = 0;
    if (sqffd_gz_decompress(data, size, name, cap, out, out_size, err, err_size) != 0) {
        *out = NULL; /* the inflater keeps nothing on failure */
        *out_size = 0;
        return 1;
    }
    return 0;
}

/* ---- reading ------------------------------------------------------------- */

/* Releases the image's memory and empties it. */
static inline void sqffd_image_free(sqffd_image *image)
{
    if (!image) return;
    free(image->buffer);
    memset(image, 0, sizeof *image);
}

/* Reads a single-file image from memory: .nii, .nii.gz, .mha with LOCAL
   data, .nrrd with attached data (any of them gzip-compressed as a whole).
   `name` is for messages and the extension fall-back. A header that puts its
   voxels in another file is refused: sqffd_image_read_file reads those. */
static inline int sqffd_image_read_memory(const void *data, size_t size, const char *name, sqffd_image *image,
                                          char *err, size_t err_size)
{
    const unsigned char *bytes = (const unsigned char *)data;
    unsigned char *inflated = NULL;
    sqffd_image__layout layout;
    char q[32];
    int r = 1;
    memset(image, 0, sizeof *image);
    if (!name) name = "input";
    if (size == 0) return sqffd_io__fail(err, err_size, name, "file is empty");
    if (sqffd_gz_is_gzip(data, size)) {
        if (sqffd_image__gunzip(bytes, size, name, &inflated, &size, err, err_size)) return 1;
        bytes = inflated;
        if (sqffd_gz_is_gzip(bytes, size)) {
            free(inflated);
            return sqffd_io__fail(err, err_size, name, "gzip inside gzip");
        }
    }
    if (sqffd_image__header(bytes, size, name, image, &layout, err, err_size)) goto done;
    if (layout.pair) {
        sqffd_io__fail(err, err_size, name,
                          "a NIfTI .hdr (magic \"ni1\"): its voxels are in the .img beside it; read it as a file");
        goto done;
    }
    if (layout.data_file) {
        sqffd_io__fail(err, err_size, name, "the voxels are in the data file %s; read the header as a file",
                          sqffd_io__quote(layout.data_file, layout.data_file_len, q));
        goto done;
    }
    r = sqffd_image__load(bytes, size, name, &layout, inflated ? &inflated : NULL, image, err, err_size);
done:
    free(inflated);
    if (r) memset(image, 0, sizeof *image);
    return r;
}


/* A file's bytes, decompressed when it is a gzip file; *owned is what to free. */
static inline int sqffd_image__read_bytes(const char *path, unsigned char **owned, const unsigned char **bytes,
                                          size_t *size, char *err, size_t err_size)
{
    unsigned char *raw, *inflated;
    size_t raw_size;
    if (sqffd_io_load_file_limit(path, SQFFD_IMAGE_MAX_BYTES, &raw, &raw_size, err, err_size)) return 1;
    if (sqffd_gz_is_gzip(raw, raw_size)) {
        int r = sqffd_image__gunzip(raw, raw_size, path, &inflated, size, err, err_size);
        free(raw);
        if (r) return 1;
        raw = inflated;
    } else
        *size = raw_size;
    *owned = raw;
    *bytes = raw;
    return 0;
}

/* The path of `file` (len bytes) taken relative to the directory of
   `header_path` (absolute paths kept), malloc'd; NULL when out of memory. */
static inline char *sqffd_image__beside(const char *header_path, const char *file, size_t len)
{
    size_t dir = 0, i;
    char *path;
    if (len == 0 || file[0] != '/')
        for (i = 0; header_path[i]; i++)
            if (header_path[i] == '/' || header_path[i] == '\\') dir = i + 1;
    path = (char *)malloc(dir + len + 1);
    if (!path) return NULL;
    memcpy(path, header_path, dir);
    memcpy(path + dir, file, len);
    path[dir + len] = '\0';
    return path;
}

/* `path` with its extension `from` (.hdr or .img, optionally followed by .gz)
   replaced by `to`, keeping the case; NULL if it has no such extension. */
static inline char *sqffd_image__swap_extension(const char *path, const char *from, const char *to)
{
    size_t n = strlen(path), at, i;
    char gz[8], with_gz[16];
    char *out;
    snprintf(gz, sizeof gz, "%s", from);
    snprintf(with_gz, sizeof with_gz, "%s.gz", from);
    if (sqffd_image__has_suffix(path, gz)) at = n - 4;
    else if (sqffd_image__has_suffix(path, with_gz)) at = n - 7;
    else return NULL;
    out = (char *)malloc(n + 1);
    if (!out) return NULL;
    memcpy(out, path, n + 1);
    for (i = 1; i < 4; i++) {
        char c = to[i];
        if (path[at + i] >= 'A' && path[at + i] <= 'Z' && c >= 'a' && c <= 'z') c = (char)(c - 'a' + 'A');
        out[at + i] = c;
    }
    return out;
}

/* Reads the image at `path`: .nii, .nii.gz, .hdr (+ .img beside it, either
   maybe gzipped; naming the .img works too), .mha, .mhd + its data file,
   .nrrd, .nhdr + its data file (data files relative to the header's
   directory). The format is told by content, then by extension. */
static inline int sqffd_image_read_file(const char *path, sqffd_image *image, char *err, size_t err_size)
{
    unsigned char *owned = NULL, *data_owned = NULL;
    const unsigned char *bytes, *data_bytes;
    size_t size, data_size;
    sqffd_image__layout layout;
    char *header_path = NULL, *data_path = NULL;
    int r = 1;
    memset(image, 0, sizeof *image);
    if (sqffd_image__read_bytes(path, &owned, &bytes, &size, err, err_size)) return 1;
    if (size == 0) {
        sqffd_io__fail(err, err_size, path, "file is empty");
        goto done;
    }
    /* the .img of a pair named instead of its .hdr: read the .hdr */
    if (sqffd_image__detect(bytes, size, "") == SQFFD_IMAGE__UNKNOWN &&
        (header_path = sqffd_image__swap_extension(path, ".img", ".hdr")) != NULL) {
        free(owned);
        owned = NULL;
        if (sqffd_image__read_bytes(header_path, &owned, &bytes, &size, err, err_size)) goto done;
        path = header_path;
    }
    if (sqffd_image__header(bytes, size, path, image, &layout, err, err_size)) goto done;
    if (layout.pair) {
        data_path = sqffd_image__swap_extension(path, ".hdr", ".img");
        if (!data_path) {
            sqffd_io__fail(err, err_size, path,
                              "a NIfTI .hdr (magic \"ni1\") whose name does not end in .hdr: where is its .img?");
            goto done;
        }
    } else if (layout.data_file) {
        data_path = sqffd_image__beside(path, layout.data_file, layout.data_file_len);
        if (!data_path) {
            sqffd_io__fail(err, err_size, path, "out of memory");
            goto done;
        }
    }
    if (!data_path) {
        r = sqffd_image__load(bytes, size, path, &layout, &owned, image, err, err_size);
        goto done;
    }
    if (!layout.pair) { /* MetaImage and NRRD data files as they are: the loader decompresses */
        if (sqffd_io_load_file_limit(data_path, SQFFD_IMAGE_MAX_BYTES, &data_owned, &data_size, err, err_size)) goto done;
        data_bytes = data_owned;
    } else if (sqffd_image__read_bytes(data_path, &data_owned, &data_bytes, &data_size, err, err_size))
        goto done; /* a pair's .img may be gzipped as a whole (.img.gz) */
    r = sqffd_image__load(data_bytes, data_size, data_path, &layout, &data_owned, image, err, err_size);
done:
    free(owned);
    free(data_owned);
    free(header_path);
    free(data_path);
    if (r) memset(image, 0, sizeof *image);
    return r;
}

/* Frame t's view (t < frames); an empty view (data NULL, dims 0) otherwise. */
static inline sqffd_volume sqffd_image_frame(const sqffd_image *image, size_t t)
{
    sqffd_volume v = image->volume;
    if (t >= image->frames || !image->volume.data) {
        memset(&v, 0, sizeof v);
        return v;
    }
    v.data = (const char *)image->volume.data + (ptrdiff_t)t * image->frame_stride;
    return v;
}

/* Whether a file is one of these formats, from its name (may be NULL) and
   its first bytes: the NIfTI-1 magic "n+1"/"ni1" at byte 344 after a
   sizeof_hdr of 348, "NRRD000", a first line "ObjectType = " or "NDims = ",
   a VTK header whose DATASET is STRUCTURED_POINTS (other VTK files, .vtk
   too, hold points); gzip files and anything unrecognised by the extension
   (.nii, .nii.gz, .hdr, .img, .mha, .mhd, .nrrd, .nhdr). */
static inline int sqffd_image_is_volume_file(const char *path, const void *head, size_t head_size)
{
    const unsigned char *h = (const unsigned char *)head;
    static const char *const extensions[] = {".nii", ".nii.gz", ".hdr", ".hdr.gz", ".img", ".img.gz",
                                             ".mha", ".mhd", ".nrrd", ".nhdr"};
    size_t i;
    if (h && head_size >= 348 && (sqffd_image__u32(h, 0) == 348 || sqffd_image__u32(h, 1) == 348) &&
        (memcmp(h + 344, "n+1", 4) == 0 || memcmp(h + 344, "ni1", 4) == 0))
        return 1;
    if (h && head_size >= 8 && memcmp(h, "NRRD000", 7) == 0) return 1;
    if (h && sqffd_io__vtk_magic(h, head_size)) {
        sqffd_io__vtk v;
        return !sqffd_io__vtk_header(h, head_size, &v, NULL, NULL, 0) && strcmp(v.dataset, "STRUCTURED_POINTS") == 0;
    }
    if (h && sqffd_image__looks_metaimage((const char *)h, head_size)) return 1;
    for (i = 0; i < sizeof extensions / sizeof extensions[0]; i++)
        if (sqffd_image__has_suffix(path, extensions[i])) return 1;
    return 0;
}

#endif /* SQFFD_IMAGE_H */

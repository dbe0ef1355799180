/* suite_io: the file readers and the PLY writer of examples/sqffd_io.h.
   Every file is built here byte by byte (independently of the reader), so
   the expected points are known exactly. */
#include "test.h"
#include "test_bytes.h"
#include "../examples/sqffd_io.h"
#include "../examples/sqffd_export.h"

/* ---- a growing byte buffer and a PLY encoder independent of the reader ---- */


enum { ASCII, LE, BE };
static const char *const format_names[] = {"ascii", "binary_little_endian", "binary_big_endian"};

/* One value of PLY type `type` in format `format` (ascii: followed by a blank). */
static void put_value(bytes *b, int format, const char *type, double v)
{
    unsigned char raw[8];
    size_t size, i;
    uint64_t bits = 0;
    if (strstr(type, "float") == type || strcmp(type, "double") == 0) {
        if (strcmp(type, "double") == 0 || strcmp(type, "float64") == 0) {
            if (format == ASCII) { bytes_text(b, "%.17g ", v); return; }
            memcpy(&bits, &v, 8);
            size = 8;
        } else {
            float f = (float)v;
            uint32_t u;
            if (format == ASCII) { bytes_text(b, "%.9g ", (double)f); return; }
            memcpy(&u, &f, 4);
            bits = u;
            size = 4;
        }
    } else {
        long long iv = (long long)v;
        if (format == ASCII) { bytes_text(b, "%lld ", iv); return; }
        bits = (uint64_t)iv;
        size = strstr(type, "char") || strstr(type, "8") ? 1 : strstr(type, "short") || strstr(type, "16") ? 2 : 4;
    }
    for (i = 0; i < size; i++) raw[format == BE ? size - 1 - i : i] = (unsigned char)(bits >> (8 * i));
    bytes_put(b, raw, size);
}

static void end_record(bytes *b, int format)
{
    if (format == ASCII) bytes_put(b, "\n", 1);
}

/* The points of the mixed-type file: x double, y float, z int16. */
#define MIXED_N 5
static void mixed_point(int i, double p[3])
{
    p[0] = (i + 1) * 0.1 + 1.0 / 3.0;
    p[1] = (double)(float)(i * 0.37 - 1.1);
    p[2] = -300 + 123 * i;
}

/* A PLY with an element before the vertices (with a list), vertex x y z of
   three types in shuffled order among other properties (one a list), faces
   of three and four vertices, and an edge element after them. */
static void mixed_ply(bytes *b, int format, const char *eol)
{
    static const char *const header[] = {
        "ply", "FORMAT", "comment mixed types", "obj_info made by test_io.c", "element camera 2",
        "property float a", "property list ushort float b", "element vertex 5", "property uchar red",
        "property float32 y", "property double x", "property list uint8 int32 tags", "property int16 z",
        "property uint w", "property char c", "element face 3", "property list uchar int vertex_indices",
        "element edge 2", "property int v1", "property int v2", "end_header"};
    size_t h;
    int i, j;
    b->size = 0;
    for (h = 0; h < sizeof header / sizeof header[0]; h++) {
        if (strcmp(header[h], "FORMAT") == 0) bytes_text(b, "format %s 1.0%s", format_names[format], eol);
        else bytes_text(b, "%s%s", header[h], eol);
    }
    for (i = 0; i < 2; i++) { /* camera */
        put_value(b, format, "float", 0.5 * i);
        put_value(b, format, "ushort", 2);
        put_value(b, format, "float", 1.25);
        put_value(b, format, "float", -2.5);
        end_record(b, format);
    }
    for (i = 0; i < MIXED_N; i++) {
        double p[3];
        mixed_point(i, p);
        put_value(b, format, "uchar", 250 + i);
        put_value(b, format, "float32", p[1]);
        put_value(b, format, "double", p[0]);
        put_value(b, format, "uint8", i);
        for (j = 0; j < i; j++) put_value(b, format, "int32", -1000000 * j);
        put_value(b, format, "int16", p[2]);
        put_value(b, format, "uint", 4000000000.0 - i);
        put_value(b, format, "char", -5 + i);
        end_record(b, format);
    }
    for (i = 0; i < 3; i++) { /* faces: (0 1 2), (1 2 3 4), (2 3 4) */
        int n = i == 1 ? 4 : 3;
        put_value(b, format, "uchar", n);
        for (j = 0; j < n; j++) put_value(b, format, "int", i + j);
        end_record(b, format);
    }
    for (i = 0; i < 2; i++) {
        put_value(b, format, "int", i);
        put_value(b, format, "int", i + 1);
        end_record(b, format);
    }
}

/* ---- checks ---------------------------------------------------------------- */

/* Reading must fail with a message "NAME: ..." that contains `want`. */
static void expect_error(const void *data, size_t size, const char *name, const char *want, const char *file, int line)
{
    double *points = (double *)&size; /* must be reset to NULL */
    size_t count = 7;
    char err[256] = "";
    size_t name_len = strlen(name);
    int r = sqffd_io_read_points(data, size, name, &points, &count, err, sizeof err);
    if (r != 1) test_fail(file, line, "%s: read succeeded (%lu points), expected an error with \"%s\"", name,
                          (unsigned long)count, want);
    else if (points != NULL || count != 0) test_fail(file, line, "%s: failed read left points/count set", name);
    else if (strncmp(err, name, name_len) != 0 || strncmp(err + name_len, ": ", 2) != 0)
        test_fail(file, line, "message \"%s\" does not start with \"%s: \"", err, name);
    else if (!strstr(err, want)) test_fail(file, line, "message \"%s\" lacks \"%s\"", err, want);
    free(r == 0 ? points : NULL);
}
#define EXPECT_ERROR(text, name, want) expect_error(text, strlen(text), name, want, __FILE__, __LINE__)

/* Reads `text` and compares with the expected points exactly. */
static void expect_points(const void *data, size_t size, const char *name, const double *want, size_t n,
                          const char *file, int line)
{
    double *points;
    size_t count, i;
    char err[256] = "";
    if (sqffd_io_read_points(data, size, name, &points, &count, err, sizeof err)) {
        test_fail(file, line, "%s: %s", name, err);
        return;
    }
    if (count != n) test_fail(file, line, "%s: %lu points, expected %lu", name, (unsigned long)count, (unsigned long)n);
    else
        for (i = 0; i < 3 * n; i++)
            if (memcmp(&points[i], &want[i], sizeof(double)) != 0) {
                test_fail(file, line, "%s: point %lu coordinate %lu is %.17g, expected %.17g", name,
                          (unsigned long)(i / 3), (unsigned long)(i % 3), points[i], want[i]);
                break;
            }
    free(points);
}
#define EXPECT_POINTS(text, name, want, n) expect_points(text, strlen(text), name, want, n, __FILE__, __LINE__)

/* Reads the first len bytes of data from a malloc'd copy of exactly len
   bytes, so ASan sees any overread (a truncation test's reader). */
static int read_prefix(const void *data, size_t len, const char *name, double **points, size_t *count, char *err,
                       size_t err_size)
{
    unsigned char *copy = (unsigned char *)malloc(len ? len : 1);
    int r;
    if (len) memcpy(copy, data, len);
    r = sqffd_io_read_points(copy, len, name, points, count, err, err_size);
    free(copy);
    return r;
}

/* ---- cases ---------------------------------------------------------------- */

static void test_io_bunny(void)
{
    double *points;
    size_t count;
    char err[256];
    int r = sqffd_io_read_file("tests/data/bunny.ply", &points, &count, err, sizeof err);
    CHECK_MSG(r == 0, "%s", err);
    if (r) return;
    CHECK(count == 1839);
    /* the first and last lines of the vertex list in the file, as the floats the header declares
       (the casts round: with FLT_EVAL_METHOD 1, as on s390x, a float constant keeps double precision) */
    CHECK(points[0] == (float)1.301895f && points[1] == (float)0.122622f && points[2] == (float)2.550061f);
    CHECK(points[3 * 1838] == (float)-2.505459f && points[3 * 1838 + 1] == (float)1.492266f &&
          points[3 * 1838 + 2] == (float)1.19295f);
    free(points);
}

static void test_io_ply_all_formats(void)
{
    double want[3 * MIXED_N];
    bytes b = {NULL, 0, 0};
    int i, format;
    for (i = 0; i < MIXED_N; i++) mixed_point(i, want + 3 * i);
    for (format = ASCII; format <= BE; format++) {
        mixed_ply(&b, format, "\n");
        expect_points(b.data, b.size, format_names[format], want, MIXED_N, __FILE__, __LINE__);
        mixed_ply(&b, format, "\r\n"); /* CRLF header (and CRLF records in ascii) */
        expect_points(b.data, b.size, format_names[format], want, MIXED_N, __FILE__, __LINE__);
    }
    free(b.data);
}

/* Every proper prefix of a binary file is an error (never a shorter result);
   prefixes of the ascii file never crash. */
static void test_io_ply_truncated(void)
{
    bytes b = {NULL, 0, 0};
    int format;
    for (format = ASCII; format <= BE; format++) {
        size_t full, len;
        mixed_ply(&b, format, "\n");
        full = b.size;
        for (len = 0; len < full; len++) {
            double *points;
            size_t count;
            char err[256];
            int r = read_prefix(b.data, len, "cut.ply", &points, &count, err, sizeof err);
            if (format != ASCII) CHECK_MSG(r == 1, "%s prefix of %lu bytes read as %lu points", format_names[format],
                                           (unsigned long)len, (unsigned long)count);
            if (r == 0) {
                CHECK(count <= MIXED_N);
                free(points);
            }
        }
    }
    free(b.data);
}

static void test_io_ply_hostile_counts(void)
{
    bytes b = {NULL, 0, 0};
    char text[512];
    static const char *const formats[] = {"ascii", "binary_little_endian", "binary_big_endian"};
    int f;
    for (f = 0; f < 3; f++) {
        snprintf(text, sizeof text, "ply\nformat %s 1.0\nelement vertex 1000000000000000000\n"
                 "property float x\nproperty float y\nproperty float z\nend_header\n0 0 0 1 1 1 2 2 2\n", formats[f]);
        EXPECT_ERROR(text, "x.ply", "header says 1000000000000000000 vertices");
        EXPECT_ERROR(text, "x.ply", "file holds 18 bytes of data");
    }
    EXPECT_ERROR("ply\nformat ascii 1.0\nelement vertex 99999999999999999999\nproperty float x\nend_header\n",
                 "x.ply", "element count '99999999999999999999' is not a number below 2^64");
    EXPECT_ERROR("ply\nformat ascii 1.0\nelement vertex -3\nproperty float x\nend_header\n", "x.ply", "'-3'");
    /* a list count larger than the rest of the file, binary and ascii */
    b.size = 0;
    bytes_text(&b, "ply\nformat binary_big_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
               "property float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n");
    put_value(&b, BE, "float", 1);
    put_value(&b, BE, "float", 2);
    put_value(&b, BE, "float", 3);
    put_value(&b, BE, "uint", 4000000000.0);
    put_value(&b, BE, "int", 0);
    expect_error(b.data, b.size, "l.ply", "face 0: list of 4000000000 values of 4 bytes, file holds 4 more bytes",
                 __FILE__, __LINE__);
    EXPECT_ERROR("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                 "element face 1\nproperty list uint int vertex_indices\nend_header\n1 2 3\n4000000000 1 2 3\n",
                 "l.ply", "face 0 (line 11): list of '4000000000' values");
    EXPECT_ERROR("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                 "element face 1\nproperty list uchar int vertex_indices\nend_header\n1 2 3\n-1\n",
                 "l.ply", "face 0 (line 11): list count '-1' is not a count");
    /* a negative count in a signed binary count type */
    b.size = 0;
    bytes_text(&b, "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty list char float q\n"
               "property float x\nproperty float y\nproperty float z\nend_header\n");
    put_value(&b, LE, "char", -2);
    bytes_put(&b, "twelve bytes", 12);
    expect_error(b.data, b.size, "n.ply", "vertex 0: negative list count -2", __FILE__, __LINE__);
    /* elements without properties take no room, whatever their count */
    {
        static const char text2[] = "ply\nformat binary_little_endian 1.0\nelement nothing 18446744073709551615\n"
                                    "element vertex 1\nproperty double x\nproperty double y\nproperty double z\n"
                                    "end_header\n";
        double want[3] = {1.5, -2.5, 1e300};
        b.size = 0;
        bytes_put(&b, text2, strlen(text2));
        put_value(&b, LE, "double", want[0]);
        put_value(&b, LE, "double", want[1]);
        put_value(&b, LE, "double", want[2]);
        expect_points(b.data, b.size, "e.ply", want, 1, __FILE__, __LINE__);
    }
    free(b.data);
}

static void test_io_ply_bad_headers(void)
{
#define XYZ_PROPS "property float x\nproperty float y\nproperty float z\n"
    EXPECT_ERROR("ply\nformat ascii 1.0\nelement vertex 1\nproperty flaot x\nend_header\n1\n", "h.ply",
                 "header line 4: unknown property type 'flaot'");
    EXPECT_ERROR("ply\nformat ascii 1.0\nelement vertex 1\n" XYZ_PROPS "property list float int l\nend_header\n",
                 "h.ply", "list count type 'float' is not an integer type");
    EXPECT_ERROR("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float z\nend_header\n1 2\n",
                 "h.ply", "vertex element has no 'y' property");
    EXPECT_ERROR("ply\nformat ascii 1.0\nelement point 1\n" XYZ_PROPS "end_header\n1 2 3\n", "h.ply",
                 "header has no vertex element");
    EXPECT_ERROR("ply\nformat ascii 1.0\nelement vertex 1\n" XYZ_PROPS "property double x\nend_header\n", "h.ply",
                 "a second vertex property 'x'");
    EXPECT_ERROR("ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\nend_header\n", "h.ply",
                 "vertex property 'x' is a list");
    EXPECT_ERROR("ply\nformat binary_middle_endian 1.0\nelement vertex 1\n" XYZ_PROPS "end_header\n", "h.ply",
                 "unknown format 'binary_middle_endian'");
    EXPECT_ERROR("ply\nelement vertex 1\n" XYZ_PROPS "end_header\n1 2 3\n", "h.ply", "header has no format line");
    EXPECT_ERROR("ply\nformat ascii 1.0\nelement vertex 1\n" XYZ_PROPS, "h.ply", "no end_header line");
    EXPECT_ERROR("ply\nformat ascii 1.0\nproperty float x\nend_header\n", "h.ply", "property before any element");
    EXPECT_ERROR("ply\nformat ascii 1.0\nelements vertex 1\nend_header\n", "h.ply",
                 "header line 3: unknown keyword 'elements'");
    EXPECT_ERROR("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x y\nend_header\n", "h.ply",
                 "header line 4: expected 'property TYPE NAME'");
    EXPECT_ERROR("plyx\nformat ascii 1.0\n", "h.ply", "not a PLY file");
    EXPECT_ERROR("ply\nformat ascii 1.0\nelement vertex 2\n" XYZ_PROPS "end_header\n1 2 3\n4 five 6\n", "h.ply",
                 "vertex 1 (line 9): expected a number, found 'five'");
    EXPECT_ERROR("ply\nformat ascii 1.0\nelement vertex 2\n" XYZ_PROPS "end_header\n1 2 3\n40 50\n", "h.ply",
                 "vertex 1: file ends inside it");
    EXPECT_ERROR("ply\nformat ascii 1.0\nelement vertex 2\n" XYZ_PROPS "end_header\n1 2 3\n4 nan 6\n", "h.ply",
                 "vertex 1 (line 9): 'nan' is not a finite number");
    EXPECT_ERROR("ply\nformat ascii 1.0\nelement vertex 0\n" XYZ_PROPS "end_header\n", "h.ply", "holds no points");
    {   /* a binary infinity */
        bytes b = {NULL, 0, 0};
        bytes_text(&b, "ply\nformat binary_little_endian 1.0\nelement vertex 2\n" XYZ_PROPS "end_header\n");
        put_value(&b, LE, "float", 1);
        put_value(&b, LE, "float", 2);
        put_value(&b, LE, "float", 3);
        put_value(&b, LE, "float", 4);
        put_value(&b, LE, "float", 5);
        put_value(&b, LE, "float", HUGE_VAL);
        expect_error(b.data, b.size, "i.ply", "vertex 1: z is not finite (inf)", __FILE__, __LINE__);
        free(b.data);
    }
#undef XYZ_PROPS
}

static void test_io_xyz(void)
{
    static const double want[] = {1, 2, 3, -4.5, 5e-3, 6e10, 0.1, 0.2, 0.3, 7, 8, 9};
    EXPECT_POINTS("# scan 12\n1 2 3\n\n  -4.5\t5e-3   6e10 255 0 0\r\n0.1,0.2,0.3 # comma separated\n"
                  "   # indented comment\n7 8 9", "s.xyz", want, 4);
    EXPECT_ERROR("1 2 3\n4 5 6\n7 8\n", "s.xyz", "line 3: expected 3 numbers (x y z), found 2");
    EXPECT_ERROR("1 2 3\n4 nan 6\n", "s.xyz", "line 2: 'nan' is not a finite number");
    EXPECT_ERROR("1 2 3\n# c\n4 5 -inf\n", "s.xyz", "line 3: '-inf' is not a finite number");
    EXPECT_ERROR("1 2 1e999\n", "s.xyz", "line 1: '1e999' is not a finite number");
    EXPECT_ERROR("1 2 3\nx y z\n", "s.xyz", "line 2: expected a number, found 'x'");
    EXPECT_ERROR("1 2 3x\n", "s.xyz", "line 1: expected a number, found '3x'");
    EXPECT_ERROR("# only a comment\n\n", "s.xyz", "holds no points");
    EXPECT_ERROR("", "s.xyz", "file is empty");
    EXPECT_ERROR("\x1f\x8b\x08", "s.xyz.gz", "gzip-compressed");
}

static void test_io_off(void)
{
    static const double want[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1.5};
    EXPECT_POINTS("OFF\n# a tetrahedron\n4 4 6\n0 0 0\n1 0 0\n\n0 1 0\n0 0 1.5\n3 0 1 2\n3 0 1 3\n3 0 2 3\n3 1 2 3\n",
                  "t.off", want, 4);
    EXPECT_POINTS("OFF 4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1.5\n3 0 1 2\n", "t.off", want, 4);
    EXPECT_POINTS("COFF\n4 0 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 1 1 1 1\n0 0 1.5 0 0 0 0\n", "c.off",
                  want, 4);
    EXPECT_POINTS("NOFF\r\n4 0 0\r\n0 0 0 0 0 1\r\n1 0 0 0 0 1\r\n0 1 0 0 0 1\r\n0 0 1.5 0 0 1\r\n", "n.dat", want, 4);
    EXPECT_ERROR("4OFF\n1 0 0\n0 0 0 0\n", "t.off", "'4OFF': only 3-D OFF files are supported");
    EXPECT_ERROR("OFF\n3 1 0\n0.0 0.0 0.0\n1.0 0.0 0.0\n", "t.off", "file ends after 2 of 3 vertices");
    EXPECT_ERROR("OFF\n1000000000000 1 0\n0 0 0\n1 0 0\n", "t.off", "header says 1000000000000 vertices, file holds 12 bytes");
    EXPECT_ERROR("OFF\n2 1 0\n0 0 0\n1 zero 0\n", "t.off", "vertex 1 (line 4): expected a number, found 'zero'");
    EXPECT_ERROR("OFF\n2 1 0\n0 0 0\n1.0 0.0\n", "t.off", "vertex 1 (line 4): expected 3 numbers (x y z), found 2");
    EXPECT_ERROR("OFF\nmany 1 0\n", "t.off", "line 2: 'many' is not a valid vertex count");
    EXPECT_ERROR("OFF\n", "t.off", "file ends before the counts line");
    EXPECT_ERROR("hello\n", "t.off", "not an OFF file");
    EXPECT_ERROR("OFF\n0 0 0\n", "t.off", "holds no points");
}

/* Reading the OFF mesh must fail with a message "NAME: ..." that contains
   `want`, and leave every output empty. */
static void expect_mesh_error(const char *text, const char *want, const char *file, int line)
{
    double *vertices = (double *)&line; /* must be reset to NULL */
    uint32_t *triangles = (uint32_t *)&line;
    size_t vertex_count = 7, triangle_count = 7;
    char err[256] = "";
    if (sqffd_io_read_off_mesh(text, strlen(text), "m.off", &vertices, &vertex_count, &triangles, &triangle_count,
                               err, sizeof err) != 1)
        test_fail(file, line, "read succeeded, expected an error with \"%s\"", want);
    else if (vertices || triangles || vertex_count || triangle_count)
        test_fail(file, line, "failed read left vertices/triangles/counts set");
    else if (strncmp(err, "m.off: ", 7) != 0 || !strstr(err, want))
        test_fail(file, line, "message \"%s\" is not \"m.off: ...%s...\"", err, want);
}
#define EXPECT_MESH_ERROR(text, want) expect_mesh_error(text, want, __FILE__, __LINE__)

/* Reads `text` as an OFF mesh and compares vertices and triangles exactly. */
static void expect_mesh(const char *text, const double *want_vertices, size_t nv, const uint32_t *want_triangles,
                        size_t nt, const char *file, int line)
{
    double *vertices;
    uint32_t *triangles;
    size_t vertex_count, triangle_count;
    char err[256] = "";
    if (sqffd_io_read_off_mesh(text, strlen(text), "m.off", &vertices, &vertex_count, &triangles, &triangle_count,
                               err, sizeof err)) {
        test_fail(file, line, "%s", err);
        return;
    }
    if (vertex_count != nv || triangle_count != nt)
        test_fail(file, line, "%lu vertices, %lu triangles; expected %lu, %lu", (unsigned long)vertex_count,
                  (unsigned long)triangle_count, (unsigned long)nv, (unsigned long)nt);
    else if (memcmp(vertices, want_vertices, 3 * nv * sizeof *vertices) != 0)
        test_fail(file, line, "vertices differ");
    else if (memcmp(triangles, want_triangles, 3 * nt * sizeof *triangles) != 0)
        test_fail(file, line, "triangles differ: first is %lu %lu %lu", (unsigned long)triangles[0],
                  (unsigned long)triangles[1], (unsigned long)triangles[2]);
    free(vertices);
    free(triangles);
}

static void test_io_off_mesh(void)
{
    static const double tetrahedron[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1.5};
    static const uint32_t faces[] = {0, 1, 2, 0, 1, 3, 0, 2, 3, 1, 2, 3};
    static const double square[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0.5, 0.5, 1};
    /* the quad and the pentagon as fans from their first vertex, the triangle as it is */
    static const uint32_t fans[] = {0, 1, 2, 0, 2, 3, 4, 3, 2, 4, 2, 1, 4, 1, 0, 0, 1, 4};
    double *vertices;
    uint32_t *triangles;
    size_t vertex_count, triangle_count;
    char err[256];
    expect_mesh("OFF\n# a tetrahedron\n4 4 6\n0 0 0\n1 0 0\n\n0 1 0\n0 0 1.5\n3 0 1 2\n3 0 1 3 255 0 0\n"
                "3 0 2 3\n3 1 2 3", tetrahedron, 4, faces, 4, __FILE__, __LINE__);
    expect_mesh("COFF 5 3 0\r\n0 0 0 9 9 9\r\n1 0 0\r\n1 1 0\r\n0 1 0\r\n0.5 0.5 1\r\n4 0 1 2 3\r\n"
                "5 4 3 2 1 0\r\n3 0 1 4\r\n", square, 5, fans, 6, __FILE__, __LINE__);
    EXPECT_MESH_ERROR("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
                      "face 0 (line 6): vertex index 3 out of range (3 vertices)");
    EXPECT_MESH_ERROR("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n\n\n\n\n\n\n\n\n", "file ends after 1 of 2 faces");
    EXPECT_MESH_ERROR("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
                      "header says 2 faces, file holds 8 bytes after the vertices");
    EXPECT_MESH_ERROR("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n",
                      "face 0 (line 6): expected 4 vertex indices, found 3");
    EXPECT_MESH_ERROR("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1 # an edge\n",
                      "face 0 (line 6): 2 vertices, a face needs at least 3");
    EXPECT_MESH_ERROR("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n",
                      "face 0 (line 6): '-1' is not a valid vertex index");
    EXPECT_MESH_ERROR("OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n", "holds no faces");
    EXPECT_MESH_ERROR("OFF\n0 0 0\n", "holds no points");
    /* the point reader does not read faces, so their errors do not concern it */
    EXPECT_POINTS("OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1.5\n3 0 1 9\n", "t.off", tetrahedron, 4);
    CHECK(sqffd_io_read_off_mesh_file("tests/data/no-such-file.off", &vertices, &vertex_count, &triangles,
                                      &triangle_count, err, sizeof err) == 1);
    CHECK(!vertices && !triangles && vertex_count == 0 && triangle_count == 0);
    CHECK_MSG(strstr(err, "tests/data/no-such-file.off: cannot open: ") == err, "%s", err);
}

static void test_io_obj(void)
{
    static const double want[] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    EXPECT_POINTS("# made by hand\nmtllib a.mtl\no tri\nv 1 0 0\nvn 0 0 1\nvt 0.5 0.5\nv 0 1 0 1.0\n"
                  "v 0 0 1 0.2 0.3 0.4\nusemtl red\nf 1/1/1 2/1/1 3/1/1\n", "t.obj", want, 3);
    EXPECT_POINTS("v 1 0 0\nv 0 1 0\nv 0 0 1\n", "t.dat", want, 3);
    EXPECT_ERROR("v 1 0 0\nv 0 1\n", "t.obj", "line 2: expected 3 numbers (x y z), found 2");
    EXPECT_ERROR("o empty\nf 1 2 3\n", "t.obj", "holds no points");
    EXPECT_ERROR("v 1 0 0\nv 0 inf 0\n", "t.obj", "line 2: 'inf' is not a finite number");
}

static void test_io_detect(void)
{
    CHECK(sqffd_io_detect("ply\nformat", 10, "a.xyz") == SQFFD_IO_PLY);
    CHECK(sqffd_io_detect("ply\r\nformat", 11, NULL) == SQFFD_IO_PLY);
    CHECK(sqffd_io_detect("# comment\nOFF\n", 14, "a.txt") == SQFFD_IO_OFF);
    CHECK(sqffd_io_detect("STCNOFF\n", 8, "a.txt") == SQFFD_IO_OFF);
    CHECK(sqffd_io_detect("1 2 3\n", 6, "a.PLY") == SQFFD_IO_PLY);
    CHECK(sqffd_io_detect("1 2 3\n", 6, "a.Off") == SQFFD_IO_OFF);
    CHECK(sqffd_io_detect("1 2 3\n", 6, "a.pts") == SQFFD_IO_XYZ);
    CHECK(sqffd_io_detect("1 2 3\n", 6, "a.obj") == SQFFD_IO_OBJ);
    CHECK(sqffd_io_detect("# c\nmtllib x\n", 13, "a") == SQFFD_IO_OBJ);
    CHECK(sqffd_io_detect("plyfile 2 3\n", 12, "a") == SQFFD_IO_XYZ);
    EXPECT_ERROR("1 2 3\n", "points.ply", "not a PLY file");
}

/* Files of formats the readers do not take: one sentence naming the
   format, whatever the name says; one byte off and it is not that format. */
static void test_io_foreign_formats(void)
{
    static const char dicom_message[] = "DICOM is not read by sqffd; convert it to NIfTI (e.g. with dcm2niix)";
    static const char analyze_message[] = "Analyze 7.5 (a .hdr without the NIfTI-1 magic) is not read by sqffd; "
                                          "convert it to NIfTI (e.g. with nibabel or fslchfiletype)";
    static const double one[] = {1, 2, 3};
    unsigned char b[400];
    memset(b, 0, sizeof b);
    memcpy(b + 128, "DICM", 4);
    expect_error(b, 200, "scan.dcm", dicom_message, __FILE__, __LINE__);
    expect_error(b, 200, "scan.ply", dicom_message, __FILE__, __LINE__);
    CHECK(sqffd_io_foreign_format(b, 131) == NULL); /* "DICM" cut */
    memmove(b + 127, b + 128, 4);
    expect_error(b, 200, "scan.dcm", "not a text point file (binary byte 0x00 at line 1)", __FILE__, __LINE__);

    EXPECT_ERROR("#INRIMAGE-4#{\nXDIM=64\nYDIM=64\nZDIM=64\n##}\n", "skull.inr",
                 "INRIMAGE is not read by sqffd; convert it to NIfTI, MetaImage or NRRD");
    EXPECT_ERROR("#INRIMAGE-4#\n", "skull.inr", "holds no points"); /* a comment line: not the header */

    EXPECT_ERROR("solidity 1 2\n", "cube.xyz", "line 1: expected a number, found 'solidity'");
    memset(b, 0, sizeof b);
    b[0] = 0x1f; b[1] = 0x8b; b[80] = 2; /* a gzip stream sized like an STL: inflated, not named STL (fuzz_io) */
    expect_error(b, 184, "cube.stl", "gzip-compressed data", __FILE__, __LINE__);

    memset(b, 0, sizeof b);
    b[0] = 0x5C; b[1] = 1; /* sizeof_hdr 348, little-endian */
    expect_error(b, 348, "brain.hdr", analyze_message, __FILE__, __LINE__);
    CHECK(sqffd_io_foreign_format(b, 347) == NULL);
    memcpy(b + 344, "n+1", 4); /* NIfTI-1: a volume, not foreign (and not points) */
    CHECK(sqffd_io_foreign_format(b, 348) == NULL);
    memset(b, 0, sizeof b);
    b[2] = 1; b[3] = 0x5C; /* big-endian */
    expect_error(b, 348, "brain.dat", analyze_message, __FILE__, __LINE__);

    EXPECT_ERROR("\x89HDF\r\n\x1a\n", "volume.mnc", "HDF5 (e.g. MINC 2) is not read by sqffd");
    EXPECT_ERROR("PK\x03\x04", "points.zip", "a zip archive is not read by sqffd; unpack it first");
    CHECK(sqffd_io_foreign_format("PK\x03", 3) == NULL && sqffd_io_foreign_format("", 0) == NULL);

    /* binary bytes in what is taken for XYZ: not a number parse error */
    EXPECT_ERROR("1 2 3\n4 5 6\n\x01\x02\x03\n", "s.xyz", "not a text point file (binary byte 0x01 at line 3)");
    expect_error("1 2 3\n\0", 7, "s.xyz", "not a text point file (binary byte 0x00 at line 2)", __FILE__, __LINE__);
    EXPECT_ERROR("1 2 3 # \x7f\n", "s.xyz", "not a text point file (binary byte 0x7f at line 1)");
    EXPECT_POINTS("# caf\xc3\xa9, \xb5m\f\v\n1 2 3\n", "s.xyz", one, 1); /* UTF-8, Latin-1 and white space: text */
}

static void test_io_missing_file(void)
{
    double *points;
    size_t count;
    char err[256];
    CHECK(sqffd_io_read_file("tests/data/no-such-file.ply", &points, &count, err, sizeof err) == 1);
    CHECK(points == NULL && count == 0);
    CHECK_MSG(strstr(err, "tests/data/no-such-file.ply: cannot open: ") == err, "%s", err);
    CHECK(sqffd_io_read_file("tests/data", &points, &count, err, sizeof err) == 1);
    CHECK_MSG(strstr(err, "tests/data: ") == err, "%s", err);
}

/* Write a mesh with two scalars (binary and ascii), read it back: the same
   vertices (as floats); the header and the face records as the spec says. */
static void test_io_writer_round_trip(void)
{
    enum { NV = 6, NT = 8 };
    double vertices[3 * NV], error[NV], flag[NV], want[3 * NV];
    uint32_t triangles[3 * NT] = {0, 2, 4, 0, 4, 3, 0, 3, 5, 0, 5, 2, 1, 2, 5, 1, 5, 3, 1, 3, 4, 1, 4, 2};
    sqffd_io_scalar scalars[2];
    int ascii, i;
    for (i = 0; i < NV; i++) { /* an octahedron, slightly irregular */
        vertices[3 * i] = (i / 2 == 0) * (i % 2 ? -1.0 : 1.0) * (1 + 0.1 * i);
        vertices[3 * i + 1] = (i / 2 == 1) * (i % 2 ? -1.0 : 1.0) / 3.0;
        vertices[3 * i + 2] = (i / 2 == 2) * (i % 2 ? -1.0 : 1.0) * 1e-3;
        error[i] = 0.25 * i;
        flag[i] = i % 2;
    }
    for (i = 0; i < 3 * NV; i++) want[i] = (double)(float)vertices[i];
    scalars[0].name = "error";
    scalars[0].values = error;
    scalars[1].name = "flag";
    scalars[1].values = flag;
    for (ascii = 0; ascii <= 1; ascii++) {
        FILE *f = tmpfile();
        char err[256] = "", *end_header;
        unsigned char data[4096];
        size_t size;
        static const char binary_header[] =
            "ply\nformat binary_little_endian 1.0\ncomment written by sqffd\nelement vertex 6\n"
            "property float x\nproperty float y\nproperty float z\nproperty float error\nproperty float flag\n"
            "element face 8\nproperty list uchar int vertex_indices\nend_header\n";
        CHECK(f != NULL);
        if (!f) return;
        CHECK_MSG(sqffd_io_write_ply_stream(f, "m.ply", vertices, NV, triangles, NT, scalars, 2, ascii, err,
                                            sizeof err) == 0, "%s", err);
        rewind(f);
        size = fread(data, 1, sizeof data, f);
        fclose(f);
        expect_points(data, size, "m.ply", want, NV, __FILE__, __LINE__);
        end_header = strstr((char *)data, "end_header\n");
        CHECK(end_header != NULL);
        if (!end_header) continue;
        if (!ascii) {
            const unsigned char *faces = data + sizeof binary_header - 1 + NV * 20;
            CHECK(memcmp(data, binary_header, sizeof binary_header - 1) == 0);
            CHECK(size == sizeof binary_header - 1 + NV * 20 + NT * 13);
            for (i = 0; i < NT; i++) { /* count 3, then three little-endian int32 */
                const unsigned char *r = faces + 13 * i;
                CHECK(r[0] == 3);
                CHECK(r[1] == triangles[3 * i] && r[5] == triangles[3 * i + 1] && r[9] == triangles[3 * i + 2]);
                CHECK(r[2] == 0 && r[3] == 0 && r[4] == 0);
            }
            { /* the error scalar of vertex 3, little-endian float at offset 12 */
                float e;
                const unsigned char *r = data + sizeof binary_header - 1 + 3 * 20 + 12;
                uint32_t u = (uint32_t)r[0] | (uint32_t)r[1] << 8 | (uint32_t)r[2] << 16 | (uint32_t)r[3] << 24;
                memcpy(&e, &u, 4);
                CHECK(e == 0.75f);
            }
        } else {
            CHECK(strstr((char *)data, "format ascii 1.0\n") != NULL);
            CHECK(strstr(end_header, "\n3 0 2 4\n3 0 4 3\n") != NULL);
            CHECK(strstr(end_header, " 0.75 1\n") != NULL); /* vertex 3's scalars */
        }
    }
    { /* a bad index is refused before anything is written */
        FILE *f = tmpfile();
        char err[256] = "";
        triangles[5] = NV;
        CHECK(sqffd_io_write_ply_stream(f, "m.ply", vertices, NV, triangles, NT, NULL, 0, 0, err, sizeof err) == 1);
        CHECK_MSG(strstr(err, "m.ply: triangle 1 uses vertex 6 of 6") == err, "%s", err);
        CHECK(ftell(f) == 0);
        fclose(f);
    }
}

/* A point set (no faces) through a real file, with a value beyond float range. */
static void test_io_writer_points_file(void)
{
    double points[6] = {1, 2, 3, 4, 5, 6}, values[2] = {1e300, -0.5}, *back;
    sqffd_io_scalar s;
    size_t count;
    char err[256] = "", path[] = "sqffd_test_io_points.tmp";
    FILE *f = fopen(path, "wb");
    if (!f) { /* a read-only working directory: skip quietly */
        printf("    (skipped: cannot create %s)\n", path);
        return;
    }
    fclose(f);
    s.name = "error";
    s.values = values;
    CHECK_MSG(sqffd_io_write_ply(path, points, 2, NULL, 0, &s, 1, 0, err, sizeof err) == 0, "%s", err);
    CHECK_MSG(sqffd_io_read_file(path, &back, &count, err, sizeof err) == 0, "%s", err);
    if (back) {
        CHECK(count == 2 && memcmp(back, points, sizeof points) == 0);
        free(back);
    }
    remove(path);
    s.name = "two words";
    CHECK(sqffd_io_write_ply(path, points, 2, NULL, 0, &s, 1, 0, err, sizeof err) == 1);
    CHECK_MSG(strstr(err, "contains a blank") != NULL, "%s", err);
    remove(path);
}


/* ---- STL -------------------------------------------------------------------- */

/* A float's 4 bytes, little endian (binary STL) or big endian (binary VTK). */
static void put_f32(bytes *b, float f, int big_endian)
{
    unsigned char raw[4];
    uint32_t u;
    int i;
    memcpy(&u, &f, 4);
    for (i = 0; i < 4; i++) raw[big_endian ? 3 - i : i] = (unsigned char)(u >> (8 * i));
    bytes_put(b, raw, 4);
}

/* An STL of nt triangles whose corners are the points v[tri[...]]: ASCII
   (%.9g: each float reads back exactly) or binary, whose 80-byte header
   starts with `header` (space-padded); normals 0, attributes 0. */
static void stl_file(bytes *b, int binary, const char *header, const float *v, const int *tri, size_t nt)
{
    size_t t;
    int c, k;
    b->size = 0;
    if (binary) {
        char head[80];
        memset(head, ' ', sizeof head);
        memcpy(head, header, strlen(header));
        bytes_put(b, head, 80);
        for (k = 0; k < 4; k++) bytes_byte(b, (unsigned)(nt >> (8 * k)) & 0xffu);
    } else
        bytes_text(b, "solid %s\n", header);
    for (t = 0; t < nt; t++) {
        if (binary)
            for (k = 0; k < 3; k++) put_f32(b, 0.0f, 0);
        else
            bytes_text(b, "  facet normal 0 0 1\n    outer loop\n");
        for (c = 0; c < 3; c++) {
            const float *p = v + 3 * tri[3 * t + (size_t)c];
            if (binary)
                for (k = 0; k < 3; k++) put_f32(b, p[k], 0);
            else
                bytes_text(b, "      vertex %.9g %.9g %.9g\n", (double)p[0], (double)p[1], (double)p[2]);
        }
        if (binary) bytes_put(b, "\0\0", 2);
        else bytes_text(b, "    endloop\n  endfacet\n");
    }
    if (!binary) bytes_text(b, "endsolid %s\n", header);
}

/* The distinct corners of the triangles in order of first use, by brute
   force (every corner against every one kept): the reader's ground truth. */
static size_t distinct_corners(const float *v, const int *tri, size_t nt, double *out)
{
    size_t n = 0, i, j;
    for (i = 0; i < 3 * nt; i++) {
        const float *p = v + 3 * tri[i];
        for (j = 0; j < n; j++)
            if (out[3 * j] == p[0] && out[3 * j + 1] == p[1] && out[3 * j + 2] == p[2]) break;
        if (j == n) {
            out[3 * n] = p[0];
            out[3 * n + 1] = p[1];
            out[3 * n + 2] = p[2];
            n++;
        }
    }
    return n;
}

/* The unit cube's 8 corners as 12 triangles, then a random mesh of 2000
   triangles over 300 points (some equal in value under other indices, 0
   and -0 among them), each as ASCII, binary, and binary whose header
   starts with "solid": the corners merged, in order of first use. */
static void test_io_stl_round_trip(void)
{
    static const int cube_tri[36] = {0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1,
                                     2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3};
    float cube[24], *pool = (float *)test_malloc(300 * 3 * sizeof(float));
    int *tri = (int *)test_malloc(2000 * 3 * sizeof(int));
    double *want = (double *)test_malloc(6000 * 3 * sizeof(double));
    bytes b = {NULL, 0, 0};
    uint32_t state = 12345;
    size_t n, i;
    int kind;
    for (i = 0; i < 8; i++) {
        cube[3 * i] = (float)(i >> 2 & 1);
        cube[3 * i + 1] = (float)(i >> 1 & 1);
        cube[3 * i + 2] = (float)(i & 1);
    }
    for (i = 0; i < 900; i++) {
        state = state * 1664525u + 1013904223u;
        pool[i] = (float)((double)(state >> 8) / 16777216.0 * 20.0 - 10.0);
    }
    pool[0] = 0.0f;
    pool[3 * 1] = -0.0f; /* point 1 equals point 0 in value: -0 == 0 */
    pool[3 * 1 + 1] = pool[1];
    pool[3 * 1 + 2] = pool[2];
    for (i = 250; i < 300; i++) memcpy(pool + 3 * i, pool + 3 * (i - 250), 3 * sizeof(float)); /* equal values */
    for (i = 0; i < 6000; i++) {
        state = state * 1664525u + 1013904223u;
        tri[i] = (int)((state >> 8) % 300u);
    }
    for (kind = 0; kind < 3; kind++) {
        const char *label = kind == 0 ? "ascii.stl" : kind == 1 ? "binary.stl" : "solid_binary.stl";
        n = distinct_corners(cube, cube_tri, 12, want);
        CHECK(n == 8);
        stl_file(&b, kind > 0, kind == 2 ? "solid cube exported by a CAD tool" : "cube", cube, cube_tri, 12);
        expect_points(b.data, b.size, label, want, n, __FILE__, __LINE__);
        n = distinct_corners(pool, tri, 2000, want);
        CHECK(n < 250); /* the copies and -0 merged */
        stl_file(&b, kind > 0, kind == 2 ? "solid mesh" : "mesh", pool, tri, 2000);
        expect_points(b.data, b.size, label, want, n, __FILE__, __LINE__);
        /* and under a name that says nothing: found by content */
        expect_points(b.data, b.size, "mesh.dat", want, n, __FILE__, __LINE__);
    }
    {
        double *points;
        size_t count;
        sqffd_io_info info;
        char err[256];
        stl_file(&b, 1, "solid cube", cube, cube_tri, 12);
        CHECK_MSG(sqffd_io_read_points_info(b.data, b.size, "c.stl", &points, &count, &info, err, sizeof err) == 0,
                  "%s", err);
        CHECK(info.format == SQFFD_IO_STL && info.binary == 1 && info.stl_triangles == 12 && count == 8);
        free(points);
    }
    free(b.data);
    free(pool);
    free(tri);
    free(want);
}

/* Hostile STL: a count that does not give the size, every prefix of a
   binary and of an ASCII file, NaN and infinite vertices, no triangles,
   broken facets. Each is one message; a NaN normal is not read. */
static void test_io_stl_hostile(void)
{
    static const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    static const int tri[6] = {0, 1, 2, 2, 1, 0};
    static const double corners[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    bytes b = {NULL, 0, 0};
    size_t len, full;
    int binary;
    stl_file(&b, 1, "binary", v, tri, 2);
    CHECK(b.size == 184);
    expect_error(b.data, 183, "t.stl", "binary STL: 2 triangles take 84 + 50 x 2 = 184 bytes, the file has 183",
                 __FILE__, __LINE__);
    bytes_byte(&b, 0);
    expect_error(b.data, b.size, "t.stl", "the file has 185", __FILE__, __LINE__);
    b.data[80] = 0xff; b.data[81] = 0xff; b.data[82] = 0xff; b.data[83] = 0xff; /* 2^32 - 1 triangles */
    expect_error(b.data, 184, "t.stl", "4294967295 triangles take 84 + 50 x 4294967295 = 214748364834 bytes",
                 __FILE__, __LINE__);
    for (binary = 0; binary < 2; binary++) {
        stl_file(&b, binary, "tri", v, tri, 2);
        expect_points(b.data, b.size, "t.stl", corners, 3, __FILE__, __LINE__);
        full = b.size;
        for (len = 0; len < full; len++) {
            double *points;
            size_t count;
            char err[256];
            if (read_prefix(b.data, len, "t.stl", &points, &count, err, sizeof err) == 0) {
                /* ASCII: only whole facets and "endsolid" (its name may be cut) give points */
                CHECK_MSG(!binary && len >= full - strlen(" tri\n"), "%s prefix of %lu bytes read (%lu points)",
                          binary ? "binary" : "ascii", (unsigned long)len, (unsigned long)count);
                free(points);
            }
        }
    }
    stl_file(&b, 1, "binary", v, tri, 1);
    memcpy(b.data + 84 + 12 + 16, "\x00\x00\xc0\x7f", 4); /* triangle 0, vertex 1, y: NaN */
    expect_error(b.data, b.size, "t.stl", "triangle 0: vertex 1: y is not finite", __FILE__, __LINE__);
    memcpy(b.data + 84 + 12 + 16, "\x00\x00\x80\xff", 4); /* -infinity */
    expect_error(b.data, b.size, "t.stl", "triangle 0: vertex 1: y is not finite (-inf)", __FILE__, __LINE__);
    memcpy(b.data + 84 + 12 + 16, "\x00\x00\x00\x00", 4);
    memcpy(b.data + 84, "\x00\x00\xc0\x7f", 4); /* a NaN normal: not read */
    expect_points(b.data, b.size, "t.stl", corners, 3, __FILE__, __LINE__);
    memset(b.data, 0, 84);
    expect_error(b.data, 84, "t.stl", "binary STL without triangles", __FILE__, __LINE__);
    expect_error(b.data, 40, "t.stl", "binary STL of 40 bytes: shorter than its 84-byte header", __FILE__, __LINE__);
    EXPECT_ERROR("solid empty\nendsolid empty\n", "t.stl", "ASCII STL without triangles");
    EXPECT_ERROR("solid", "t.xyz", "file ends before endsolid (after 0 facets)");
    EXPECT_ERROR("\r\n  solid\n", "t.xyz", "file ends before endsolid");
    EXPECT_ERROR("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex nan 1 0\n", "t.stl",
                 "facet 0 (line 6): 'nan' is not a finite number");
    EXPECT_ERROR("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1e999 0 0\n", "t.stl",
                 "facet 0 (line 5): '1e999' is not a finite number");
    EXPECT_ERROR("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nvertex 1 1 0\n"
                 "endloop\nendfacet\nendsolid\n", "t.stl", "facet 0 (line 7): expected endloop, found 'vertex' (a facet "
                 "has 3 vertices)");
    EXPECT_ERROR("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0\nvertex 1 0 0\n", "t.stl",
                 "facet 0 (line 5): 'vertex' is not a number");
    EXPECT_ERROR("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n", "t.stl", "file ends inside facet 0 (line 2)");
    EXPECT_ERROR("solid x\nfacets normal 0 0 1\n", "t.stl", "line 2: expected facet or endsolid, found 'facets'");
    EXPECT_ERROR("solid x\nendsolid x\nmore\n", "t.stl", "line 3: expected solid, found 'more'");
    {   /* NaN and infinite normals are not read; two solids in one file, keywords in capitals */
        static const double two[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
        EXPECT_POINTS("solid a b c\nfacet normal nan inf -inf\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
                      "endloop\nendfacet\nendsolid a b c\nSOLID B\nFACET NORMAL 0 0 1\nOUTER LOOP\nVERTEX 0 1 0\n"
                      "VERTEX 1 0 0\nVERTEX 0 0 0\nENDLOOP\nENDFACET\nENDSOLID\n", "two.stl", two, 3);
    }
    free(b.data);
}

/* ---- legacy VTK ---------------------------------------------------------------- */

/* One value of VTK type `type` (the legacy names), big endian or ASCII
   (followed by a blank): an encoder independent of the reader. */
static void put_vtk_value(bytes *b, int binary, const char *type, double v)
{
    unsigned char raw[8];
    uint64_t bits = 0;
    size_t size, i;
    if (strcmp(type, "float") == 0 || strcmp(type, "double") == 0) {
        if (!binary) { bytes_text(b, strcmp(type, "float") == 0 ? "%.9g " : "%.17g ", v); return; }
        if (strcmp(type, "float") == 0) { put_f32(b, (float)v, 1); return; }
        memcpy(&bits, &v, 8);
        size = 8;
    } else {
        if (!binary) { bytes_text(b, "%lld ", (long long)v); return; }
        bits = (uint64_t)(long long)v;
        size = strstr(type, "char") ? 1 : strstr(type, "short") ? 2 : strstr(type, "64") ? 8 : 4;
    }
    for (i = 0; i < size; i++) raw[size - 1 - i] = (unsigned char)(bits >> (8 * i));
    bytes_put(b, raw, size);
}

/* n values; a binary block ends with a line break, as VTK writes it. */
static void put_vtk_values(bytes *b, int binary, const char *type, const double *v, size_t n)
{
    size_t i;
    for (i = 0; i < n; i++) put_vtk_value(b, binary, type, v[i]);
    bytes_put(b, "\n", 1);
}

/* The points of the VTK tests: x y z exact in every type used (small integers and halves). */
#define VTK_N 5
static const double vtk_xyz[3 * VTK_N] = {0, 1, 2, -3, 4.5, 5, 6, -7, 8.5, 9, 10, -11, 12.5, 13, 14};

/* Files a reader of the sections before and after POINTS must get through. */
static void vtk_file(bytes *b, int kind, int binary, const char *type)
{
    static const double field[4] = {1.5, -2, 3, 4}, ids[VTK_N] = {4, 3, 2, 1, 0};
    static const double offsets[3] = {0, 3, 5}, connectivity[5] = {0, 1, 2, 3, 4}, cell_types[2] = {5, 3};
    static const double colours[4 * VTK_N] = {10, 13, 32, 255, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
    const char *mode = binary ? "BINARY" : "ASCII";
    b->size = 0;
    switch (kind) {
    case 0: /* POLYDATA: FIELD data before the points, cells and attributes after them */
        bytes_text(b, "# vtk DataFile Version 3.0\npoly data\n%s\nDATASET POLYDATA\nFIELD FieldData 3\n", mode); /* NULL_ARRAY counts */
        bytes_text(b, "TIME 1 1 double\n");
        put_vtk_values(b, binary, "double", field, 1);
        bytes_text(b, "NULL_ARRAY\nlabels 3 1 float\n");
        put_vtk_values(b, binary, "float", field + 1, 3);
        bytes_text(b, "POINTS %d %s\n", VTK_N, type);
        put_vtk_values(b, binary, type, vtk_xyz, 3 * VTK_N);
        bytes_text(b, "POLYGONS 1 4\n");
        put_vtk_values(b, binary, "int", connectivity + 1, 4);
        break;
    case 1: /* UNSTRUCTURED_GRID of version 5.1: cells first (OFFSETS, CONNECTIVITY), METADATA, then attributes */
        bytes_text(b, "# vtk DataFile Version 5.1\nvtk output\n%s\nDATASET UNSTRUCTURED_GRID\nCELLS 3 5\n", mode);
        bytes_text(b, "OFFSETS vtktypeint64\n");
        put_vtk_values(b, binary, "vtktypeint64", offsets, 3);
        bytes_text(b, "CONNECTIVITY vtktypeint64\n");
        put_vtk_values(b, binary, "vtktypeint64", connectivity, 5);
        bytes_text(b, "CELL_TYPES 2\n");
        put_vtk_values(b, binary, "int", cell_types, 2);
        bytes_text(b, "CELL_DATA 2\nSCALARS cell_id int 1\nLOOKUP_TABLE default\n");
        put_vtk_values(b, binary, "int", cell_types, 2);
        bytes_text(b, "POINT_DATA %d\nVECTORS v double\n", VTK_N);
        put_vtk_values(b, binary, "double", vtk_xyz, 3 * VTK_N);
        bytes_text(b, "METADATA\nINFORMATION 1\nNAME L2_NORM_RANGE LOCATION vtkDataArray\nDATA 2 0 1\n\n");
        bytes_text(b, "GLOBAL_IDS ids unsigned_short\n");
        put_vtk_values(b, binary, "unsigned_short", ids, VTK_N);
        bytes_text(b, "TEXTURE_COORDINATES uv 2 float\n");
        put_vtk_values(b, binary, "float", vtk_xyz, 2 * VTK_N);
        bytes_text(b, "SCALARS rgb unsigned_char 3\nLOOKUP_TABLE default\n");
        put_vtk_values(b, binary, "unsigned_char", vtk_xyz, 3 * VTK_N);
        bytes_text(b, "COLOR_SCALARS rgba 4\n");
        put_vtk_values(b, binary, binary ? "unsigned_char" : "float", colours, 4 * VTK_N);
        bytes_text(b, "LOOKUP_TABLE table 2\n");
        put_vtk_values(b, binary, binary ? "unsigned_char" : "float", vtk_xyz, 8);
        bytes_text(b, "POINTS %d %s\n", VTK_N, type);
        put_vtk_values(b, binary, type, vtk_xyz, 3 * VTK_N);
        break;
    default: /* STRUCTURED_GRID */
        bytes_text(b, "# vtk DataFile Version 2.0\ngrid\n%s\nDATASET STRUCTURED_GRID\nDIMENSIONS %d 1 1\n", mode, VTK_N);
        bytes_text(b, "POINTS %d %s\n", VTK_N, type);
        put_vtk_values(b, binary, type, vtk_xyz, 3 * VTK_N);
        break;
    }
}

/* POINTS of every dataset and type, ASCII and binary, after and before
   other sections; sqffd's own --vtk output read back. */
static void test_io_vtk_points(void)
{
    static const char *const types[] = {"float", "double", "int", "short", "vtktypeint64"};
    static const double cloud[6] = {0.1, 0.2, 0.3, 1e-3, -2.5, 1e30};
    bytes b = {NULL, 0, 0};
    double *points, want[3 * VTK_N], values[2] = {1, 2};
    sqffd_io_scalar scalar;
    uint32_t triangle[3] = {0, 1, 1};
    size_t count, size, t;
    sqffd_io_info info;
    char err[256];
    int kind, binary, flags;
    for (kind = 0; kind < 3; kind++)
        for (binary = 0; binary < 2; binary++)
            for (t = 0; t < sizeof types / sizeof types[0]; t++) {
                int integer = strcmp(types[t], "float") != 0 && strcmp(types[t], "double") != 0;
                size_t i;
                vtk_file(&b, kind, binary, types[t]);
                for (i = 0; i < 3 * VTK_N; i++) want[i] = integer ? (double)(long long)vtk_xyz[i] : vtk_xyz[i];
                expect_points(b.data, b.size, "data.vtk", want, VTK_N, __FILE__, __LINE__);
            }
    vtk_file(&b, 2, 1, "float");
    CHECK_MSG(sqffd_io_read_points_info(b.data, b.size, "g.dat", &points, &count, &info, err, sizeof err) == 0, "%s",
              err);
    CHECK(info.format == SQFFD_IO_VTK && info.binary && strcmp(info.vtk_version, "2.0") == 0 &&
          strcmp(info.vtk_dataset, "STRUCTURED_GRID") == 0);
    free(points);
    /* sqffd_export_vtk's files: mesh or cloud, binary or ASCII, float or double */
    scalar.name = "error";
    scalar.values = values;
    for (flags = 0; flags < 4; flags++)
        for (t = 0; t < 2; t++) {
            FILE *f = tmpfile();
            unsigned char *data;
            size_t i;
            if (!f) { printf("    (skipped: no tmpfile)\n"); return; }
            CHECK_MSG(sqffd_export_vtk_stream(f, "own.vtk", "sqffd model", cloud, 2, t ? triangle : NULL, t, &scalar, 1,
                                              flags, err, sizeof err) == 0, "%s", err);
            size = (size_t)ftell(f);
            rewind(f);
            data = (unsigned char *)test_malloc(size);
            CHECK(fread(data, 1, size, f) == size);
            fclose(f);
            for (i = 0; i < 6; i++) want[i] = flags & SQFFD_EXPORT_VTK_DOUBLE ? cloud[i] : (double)(float)cloud[i];
            expect_points(data, size, "own.vtk", want, 2, __FILE__, __LINE__);
            free(data);
        }
    free(b.data);
}

/* Hostile VTK: counts beyond the data, every prefix, NaN, unknown words,
   a volume, no points; each one message. */
static void test_io_vtk_hostile(void)
{
    bytes b = {NULL, 0, 0};
    size_t len, points_end;
    EXPECT_ERROR("# vtk DataFile Version 3.0\n", "v.vtk", "file ends inside the header (after the title line)");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCI\nDATASET POLYDATA\n", "v.vtk",
                 "line 3: expected ASCII or BINARY, found 'ASCI'");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDAT\n", "v.vtk",
                 "line 4: unknown DATASET type 'POLYDAT'");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nFIELD f 0\n", "v.vtk", "a VTK data object (FIELD data only)");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTZ 1 float\n0 0 0\n", "v.vtk",
                 "line 5: unknown keyword 'POINTZ' in DATASET POLYDATA");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 1 bit\n0 0 0\n", "v.vtk",
                 "line 5: value type 'bit' is not read");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nBINARY\nDATASET POLYDATA\nPOINTS 1 long\n", "v.vtk",
                 "binary 'long' values: their size is the writing platform's");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 0 float\n", "v.vtk",
                 "POINTS (line 5): 0 points");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 99999999999 float\n0 0 0\n", "v.vtk",
                 "POINTS (line 5): 299999999997 values, the file holds 7 bytes after line 5");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nBINARY\nDATASET POLYDATA\nPOINTS 99999999999 float\n0 0 0\n", "v.vtk",
                 "POINTS (line 5): 299999999997 values of 4 bytes, the file holds 6 bytes after line 5");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 18446744073709551615 float\n", "v.vtk",
                 "points overflow");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 99999999999999999999 float\n", "v.vtk",
                 "'99999999999999999999' is not a count");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 2 float\n0 0 0\n1 nan 1\n", "v.vtk",
                 "POINTS (line 5): value 4 (line 7), 'nan', is not a finite number");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 1 float\n0 0 1e39\n", "v.vtk",
                 "value 2 (line 6), '1e39', is not a finite number"); /* beyond float */
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 2 float\n0 0 0\n1 1\n", "v.vtk",
                 "POINTS (line 5): file ends after 5 of 6 values");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nVERTICES 1 2\n1 0\n", "v.vtk",
                 "DATASET POLYDATA without POINTS: no points");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nSCALARS s float\nLOOKUP_TABLE default\n",
                 "v.vtk", "SCALARS (line 5): an attribute before POINT_DATA or CELL_DATA");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINT_DATA 1\nSCALARS s float 1 LOOKUP\n",
                 "v.vtk", "expected LOOKUP_TABLE, found 'LOOKUP'");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nMETADATA\nINFORMATION 0\n", "v.vtk",
                 "METADATA (line 5): file ends before the blank line that ends it");
    EXPECT_ERROR("# vtk DataFile Version 5.1\nt\nASCII\nDATASET POLYDATA\nPOLYGONS 2 3\n0 3\n0 1 2\n", "v.vtk",
                 "POLYGONS (line 5): expected OFFSETS (a version 5.1 file), found '0'");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_GRID\nDIMENSIONS 2 2 2\nPOINTS 1 float\n0 0 0\n",
                 "v.vtk", "DIMENSIONS 2 x 2 x 2 do not make the 1 POINTS");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_GRID\nDIMENSIONS 4294967296 4294967296 2\n"
                 "POINTS 1 float\n0 0 0\n", "v.vtk", "DIMENSIONS 4294967296 x 4294967296 x 2 do not make the 1 POINTS");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nBINARY\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 2\n", "v.vtk",
                 "DATASET STRUCTURED_POINTS is a volume, not points");
    EXPECT_ERROR("# vtk DataFile Version 3.0\nt\nASCII\nDATASET RECTILINEAR_GRID\n", "v.vtk",
                 "DATASET RECTILINEAR_GRID is not read");
    /* a binary NaN */
    b.size = 0;
    bytes_text(&b, "# vtk DataFile Version 3.0\nt\nBINARY\nDATASET POLYDATA\nPOINTS 1 double\n");
    put_vtk_value(&b, 1, "double", 1.0);
    bytes_put(&b, "\x7f\xf8\0\0\0\0\0\0", 8);
    put_vtk_value(&b, 1, "double", 1.0);
    expect_error(b.data, b.size, "v.vtk", "POINTS (line 5): value 1 is not finite (nan)", __FILE__, __LINE__);
    /* every prefix of a binary file: an error until the points are whole, then the points (the file is not
       read past them) */
    vtk_file(&b, 0, 1, "double");
    points_end = b.size - strlen("POLYGONS 1 4\n") - 16 - 1 - 1; /* the points' last byte + 1 */
    for (len = 0; len <= b.size; len++) {
        double *points;
        size_t count;
        char err[256];
        int r = read_prefix(b.data, len, "v.vtk", &points, &count, err, sizeof err);
        CHECK_MSG(r == (len < points_end), "prefix of %lu bytes (the points end at %lu): %s", (unsigned long)len,
                  (unsigned long)points_end, r ? err : "read");
        if (!r) {
            CHECK(count == VTK_N && memcmp(points, vtk_xyz, sizeof vtk_xyz) == 0);
            free(points);
        }
    }
    /* ASCII prefixes: never a crash; a success has all the points (the last number may be cut) */
    vtk_file(&b, 1, 0, "float");
    for (len = 0; len <= b.size; len++) {
        double *points;
        size_t count;
        char err[256];
        if (read_prefix(b.data, len, "v.vtk", &points, &count, err, sizeof err) == 0) {
            CHECK(count == VTK_N && memcmp(points, vtk_xyz, 3 * VTK_N * sizeof(double) - sizeof(double)) == 0);
            free(points);
        }
    }
    free(b.data);
}

void suite_io(void)
{
    RUN_TEST(test_io_bunny);
    RUN_TEST(test_io_ply_all_formats);
    RUN_TEST(test_io_ply_truncated);
    RUN_TEST(test_io_ply_hostile_counts);
    RUN_TEST(test_io_ply_bad_headers);
    RUN_TEST(test_io_xyz);
    RUN_TEST(test_io_off);
    RUN_TEST(test_io_off_mesh);
    RUN_TEST(test_io_obj);
    RUN_TEST(test_io_detect);
    RUN_TEST(test_io_foreign_formats);
    RUN_TEST(test_io_stl_round_trip);
    RUN_TEST(test_io_stl_hostile);
    RUN_TEST(test_io_vtk_points);
    RUN_TEST(test_io_vtk_hostile);
    RUN_TEST(test_io_missing_file);
    RUN_TEST(test_io_writer_round_trip);
    RUN_TEST(test_io_writer_points_file);
}

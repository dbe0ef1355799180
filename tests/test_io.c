/* suite_io: the file readers and the PLY writer of examples/sqffd_io.h.
   Every file is built here byte by byte (independently of the reader), so
   the expected points are known exactly. */
#include "test.h"
#include "test_bytes.h"
#include "../examples/sqffd_io.h"

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
            /* a malloc'd copy of exactly len bytes, so ASan sees any overread */
            unsigned char *copy = (unsigned char *)malloc(len ? len : 1);
            double *points;
            size_t count;
            char err[256];
            int r;
            memcpy(copy, b.data, len);
            r = sqffd_io_read_points(copy, len, "cut.ply", &points, &count, err, sizeof err);
            if (format != ASCII) CHECK_MSG(r == 1, "%s prefix of %lu bytes read as %lu points", format_names[format],
                                           (unsigned long)len, (unsigned long)count);
            if (r == 0) {
                CHECK(count <= MIXED_N);
                free(points);
            }
            free(copy);
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
    static const char stl_message[] = "STL is not read by sqffd; convert it to PLY, OFF or OBJ (e.g. with MeshLab or meshio)";
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

    EXPECT_ERROR("solid cube\n facet normal 0 0 1\n", "cube.stl", stl_message);
    EXPECT_ERROR("\r\n  solid\n", "cube.xyz", stl_message);
    EXPECT_ERROR("solid", "cube.xyz", stl_message);
    EXPECT_ERROR("solidity 1 2\n", "cube.xyz", "line 1: expected a number, found 'solidity'");
    memset(b, 0, sizeof b);
    memcpy(b, "solid but binary", 16);
    b[80] = 2; /* two 50-byte triangles after the 84-byte header */
    expect_error(b, 184, "cube.stl", stl_message, __FILE__, __LINE__);
    memcpy(b, "binary", 6);
    expect_error(b, 184, "cube.stl", stl_message, __FILE__, __LINE__);
    expect_error(b, 183, "cube.stl", "not a text point file", __FILE__, __LINE__); /* the count does not fit */
    b[80] = 0; /* no triangle: no STL */
    expect_error(b, 84, "cube.stl", "not a text point file", __FILE__, __LINE__);
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
    RUN_TEST(test_io_missing_file);
    RUN_TEST(test_io_writer_round_trip);
    RUN_TEST(test_io_writer_points_file);
}

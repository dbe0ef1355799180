/* suite_pcd: the PCD reader of examples/sqffd_io.h (ascii, binary,
   binary_compressed and its LZF decoder). Files are built by
   tests/pcd_encode.h, which shares no code with the reader, from values
   known here; tests/data holds files written by PCL's own tools. */
#include "test.h"
#include "pcd_encode.h"
#include "../examples/sqffd_io.h"

static const char *const encoding_names[] = {"ascii", "binary", "binary_compressed"};

/* ---- checks ---------------------------------------------------------------- */

/* Reads a PCD from memory (through the format detection); NULL on failure (reported). */
static double *read_pcd(const bytes *b, const char *name, size_t *count, sqffd_io_info *info, const char *file,
                        int line)
{
    double *points;
    char err[256] = "";
    if (sqffd_io_read_points_info(b->data, b->size, name, &points, count, info, err, sizeof err)) {
        test_fail(file, line, "%s: %s", name, err);
        return NULL;
    }
    if (info->format != SQFFD_IO_PCD) test_fail(file, line, "%s: read as %s", name, sqffd_io_format_name(info->format));
    return points;
}
#define READ_PCD(b, name, count, info) read_pcd(b, name, count, info, __FILE__, __LINE__)

/* Reading must fail with "NAME: ..." containing want, and leave no points. */
static void expect_error(const void *data, size_t size, const char *name, const char *want, const char *file, int line)
{
    double *points = (double *)&size;
    size_t count = 7, name_len = strlen(name);
    char err[256] = "";
    int r = sqffd_io_read_points(data, size, name, &points, &count, err, sizeof err);
    if (r != 1) {
        test_fail(file, line, "%s: read %lu points, expected an error with \"%s\"", name, (unsigned long)count, want);
        free(points);
    } else if (points != NULL || count != 0) {
        test_fail(file, line, "%s: a failed read left points or a count", name);
    } else if (strncmp(err, name, name_len) != 0 || strncmp(err + name_len, ": ", 2) != 0) {
        test_fail(file, line, "message \"%s\" does not start with \"%s: \"", err, name);
    } else if (!strstr(err, want)) {
        test_fail(file, line, "message \"%s\" lacks \"%s\"", err, want);
    }
}
#define EXPECT_ERROR(b, name, want) expect_error((b)->data, (b)->size, name, want, __FILE__, __LINE__)
#define EXPECT_TEXT_ERROR(text, want) expect_error(text, strlen(text), "bad.pcd", want, __FILE__, __LINE__)

/* The points a width x height Kinect-like cloud must read as (its non-NaN
   pixels in order, as floats); returns their count, *nan the others. */
static size_t kinect_truth(size_t width, size_t height, double *want, size_t *nan)
{
    size_t u, v, n = 0;
    *nan = 0;
    for (v = 0; v < height; v++)
        for (u = 0; u < width; u++) {
            double xyz[3];
            uint32_t rgba;
            int k;
            kinect_pixel(width, height, u, v, xyz, &rgba);
            if (isnan(xyz[0])) {
                (*nan)++;
                continue;
            }
            for (k = 0; k < 3; k++) want[3 * n + (size_t)k] = (double)(float)xyz[k];
            n++;
        }
    return n;
}

/* points (count of them) must equal want (n) bit for bit. */
static void compare_points(const double *points, size_t count, const double *want, size_t n, const char *what,
                           const char *file, int line)
{
    size_t i;
    if (count != n) {
        test_fail(file, line, "%s: %lu points, expected %lu", what, (unsigned long)count, (unsigned long)n);
        return;
    }
    for (i = 0; i < 3 * n; i++)
        if (memcmp(&points[i], &want[i], sizeof(double)) != 0) {
            test_fail(file, line, "%s: point %lu coordinate %lu is %.17g, expected %.17g", what, (unsigned long)(i / 3),
                      (unsigned long)(i % 3), points[i], want[i]);
            return;
        }
}
#define COMPARE_POINTS(points, count, want, n, what) compare_points(points, count, want, n, what, __FILE__, __LINE__)

/* ---- mixed fields -------------------------------------------------------------- */

/* rgb normal_x x _ y z intensity fpfh: x float, y double, z int16 among
   others, a padding field and a field of 5 values. */
static pcd_spec mixed_spec(int encoding, size_t n)
{
    static const char *const names[] = {"rgb", "normal_x", "x", "_", "y", "z", "intensity", "fpfh"};
    static const int sizes[] = {4, 4, 4, 1, 8, 2, 1, 4}, counts[] = {1, 1, 1, 4, 1, 1, 1, 5};
    static const char types[] = "UFFUFIUF";
    pcd_spec s;
    int f;
    memset(&s, 0, sizeof s);
    s.version = "0.7";
    s.viewpoint = 1;
    s.fields = 8;
    for (f = 0; f < 8; f++) {
        s.name[f] = names[f];
        s.size[f] = sizes[f];
        s.type[f] = types[f];
        s.count[f] = counts[f];
    }
    s.width = n;
    s.height = 1;
    s.encoding = encoding;
    return s;
}

static double mixed_value(void *user, size_t i, int f, int c)
{
    (void)user;
    switch (f) {
    case 0: return 4278255360.0 + (double)i;     /* rgb as PCL writes it, U4 */
    case 1: return 0.5 - (double)i;              /* normal_x */
    case 2: return (double)i * 0.37 - 1.1;       /* x, F4 */
    case 3: return 171.0;                        /* padding */
    case 4: return (double)i / 3.0 + 1e-9;       /* y, F8 */
    case 5: return -300.0 + 123.0 * (double)i;   /* z, I2 */
    case 6: return (double)(i % 256);            /* intensity */
    default: return (double)i + 0.25 * c;        /* fpfh[c] */
    }
}

static void mixed_want(size_t n, double *want)
{
    size_t i;
    for (i = 0; i < n; i++) {
        want[3 * i] = (double)(float)mixed_value(NULL, i, 2, 0);
        want[3 * i + 1] = mixed_value(NULL, i, 4, 0);
        want[3 * i + 2] = mixed_value(NULL, i, 5, 0);
    }
}

static void test_pcd_mixed_fields(void)
{
    enum { N = 9 };
    static const char *const eols[] = {"\n", "\r\n", "  \r\n"};
    double want[3 * N];
    int encoding, e;
    mixed_want(N, want);
    for (encoding = PCD_ASCII; encoding <= PCD_COMPRESSED; encoding++)
        for (e = 0; e < 3; e++) {
            pcd_spec s = mixed_spec(encoding, N);
            bytes b = {NULL, 0, 0};
            sqffd_io_info info;
            double *points;
            size_t count;
            char what[64];
            s.eol = eols[e];
            pcd_encode(&b, &s, mixed_value, NULL);
            snprintf(what, sizeof what, "%s, header lines ending %d", encoding_names[encoding], e);
            points = READ_PCD(&b, "mixed.pcd", &count, &info);
            if (points) COMPARE_POINTS(points, count, want, N, what);
            CHECK(info.dropped_nan == 0 && info.gzip == 0);
            CHECK_MSG(strcmp(info.pcd.fields, "rgb U4, normal_x F4, x F4, _ U1x4, y F8, z I2, intensity U1, fpfh F4x5") == 0,
                      "fields '%s'", info.pcd.fields);
            CHECK(strcmp(info.pcd.version, "0.7") == 0);
            CHECK(info.pcd.encoding && strcmp(info.pcd.encoding, encoding_names[encoding]) == 0);
            CHECK(info.pcd.width == N && info.pcd.height == 1 && info.pcd.points == N);
            CHECK(info.pcd.viewpoint[3] == 1.0 && info.pcd.viewpoint[0] == 0.0 && info.pcd.viewpoint[6] == 0.0);
            free(points);
            bytes_free(&b);
        }
}

/* ---- every value type as coordinates ------------------------------------------ */

static const char type_kinds[] = "IIIIUUUUFF";
static const int type_sizes[] = {1, 2, 4, 8, 1, 2, 4, 8, 4, 8};

static double typed_value(void *user, size_t i, int f, int c)
{
    int t = *(const int *)user;
    (void)c;
    if (i == 0 && t == 3) return -4611686018427387904.0;           /* I8: -2^62 */
    if (i == 0 && t == 7) return 9223372036854777856.0;            /* U8: 2^63 + 2^11 */
    if (type_kinds[t] == 'I') return -100.0 + 37.0 * (double)i - f;
    if (type_kinds[t] == 'U') return 3.0 + 40.0 * (double)i + f;
    return (double)i * 0.1 - 0.3 + f;
}

static void test_pcd_value_types(void)
{
    enum { N = 7 };
    int t, encoding, f;
    for (t = 0; t < 10; t++)
        for (encoding = PCD_ASCII; encoding <= PCD_COMPRESSED; encoding++) {
            pcd_spec s;
            bytes b = {NULL, 0, 0};
            sqffd_io_info info;
            double want[3 * N], *points;
            size_t count, i;
            char what[64];
            memset(&s, 0, sizeof s);
            s.version = ".7";
            s.fields = 3;
            for (f = 0; f < 3; f++) {
                s.name[f] = f == 0 ? "x" : f == 1 ? "y" : "z";
                s.size[f] = type_sizes[t];
                s.type[f] = type_kinds[t];
                s.count[f] = 1;
            }
            s.width = N;
            s.height = 1;
            s.encoding = encoding;
            pcd_encode(&b, &s, typed_value, &t);
            for (i = 0; i < N; i++)
                for (f = 0; f < 3; f++) {
                    double v = typed_value(&t, i, f, 0);
                    want[3 * i + (size_t)f] = type_kinds[t] == 'F' && type_sizes[t] == 4 ? (double)(float)v : v;
                }
            snprintf(what, sizeof what, "x y z %c%d, %s", type_kinds[t], type_sizes[t], encoding_names[encoding]);
            points = READ_PCD(&b, "typed.pcd", &count, &info);
            if (points) COMPARE_POINTS(points, count, want, N, what);
            CHECK_MSG(strcmp(info.pcd.version, "0.7") == 0, "%s: version '%s'", what, info.pcd.version);
            free(points);
            bytes_free(&b);
        }
}

/* ---- organised clouds with invalid pixels ------------------------------------- */

static void test_pcd_organised_nan(void)
{
    size_t dims[2] = {64, 48};
    double *want = (double *)test_malloc(3 * dims[0] * dims[1] * sizeof(double));
    size_t nan, n = kinect_truth(dims[0], dims[1], want, &nan);
    int encoding;
    CHECK(nan > 64 && n > 2000); /* the left band and the scattered holes */
    for (encoding = PCD_ASCII; encoding <= PCD_COMPRESSED; encoding++) {
        pcd_spec s = kinect_spec(dims[0], dims[1], encoding);
        bytes b = {NULL, 0, 0};
        sqffd_io_info info;
        double *points;
        size_t count;
        pcd_encode(&b, &s, kinect_value, dims);
        points = READ_PCD(&b, "kinect.pcd", &count, &info);
        if (points) COMPARE_POINTS(points, count, want, n, encoding_names[encoding]);
        CHECK_MSG(info.dropped_nan == nan, "%s: %lu dropped, expected %lu", encoding_names[encoding],
                  (unsigned long)info.dropped_nan, (unsigned long)nan);
        CHECK(info.pcd.width == 64 && info.pcd.height == 48 && info.pcd.points == 64 * 48);
        free(points);
        /* the same without the info: NaN points dropped all the same */
        if (sqffd_io_read_points(b.data, b.size, "kinect.pcd", &points, &count, NULL, 0) == 0) {
            CHECK(count == n);
            free(points);
        } else {
            CHECK(0);
        }
        bytes_free(&b);
    }
    free(want);
}

/* Every point NaN: an error, whatever the encoding. */
static double all_nan_value(void *user, size_t i, int f, int c)
{
    (void)user;
    (void)i;
    (void)c;
    return f < 3 ? NAN : 7.0;
}

static void test_pcd_all_nan(void)
{
    int encoding;
    for (encoding = PCD_ASCII; encoding <= PCD_COMPRESSED; encoding++) {
        pcd_spec s = kinect_spec(4, 3, encoding);
        bytes b = {NULL, 0, 0};
        pcd_encode(&b, &s, all_nan_value, NULL);
        EXPECT_ERROR(&b, "holes.pcd", "all 12 points have NaN coordinates (invalid depth)");
        bytes_free(&b);
    }
}

/* ---- headers: versions, defaults, order, comments ------------------------------ */

static void test_pcd_headers(void)
{
    static const double two[6] = {1.5, -2, 3.25, 4, 5, 6};
    static const char *const files[] = {
        /* 0.6 as PCL wrote it: no VERSION line (the comment only), no VIEWPOINT */
        "# .PCD v.6 - Point Cloud Data file format\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
        "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n1.5 -2 3.25\n4 5 6\n",
        /* VERSION .6, trailing blanks, CRLF, comments and blank lines among the lines */
        "# .PCD v.6 - Point Cloud Data file format \r\nVERSION .6 \r\n\r\nFIELDS x y z   # the coordinates\r\n"
        "# a comment\r\nSIZE 4 4 4\r\nTYPE F F F\r\nCOUNT 1 1 1\r\nWIDTH 2\r\nHEIGHT 1\r\nPOINTS 2\r\nDATA ascii\r\n"
        "1.5 -2 3.25\r\n\r\n4 5 6\r\n",
        /* no POINTS: WIDTH x HEIGHT (an organised 1 x 2) */
        "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 2\nDATA ascii\n1.5 -2 3.25\n4 5 6\n",
        /* no WIDTH and HEIGHT; no SIZE, TYPE or COUNT: float x y z (PCL's defaults) */
        "FIELDS x y z\nPOINTS 2\nDATA ascii\n1.5 -2 3.25\n4 5 6\n",
        /* another order, tabs, more values and more lines than needed (ignored, as PCL does) */
        "VERSION 0.7\nFIELDS\tz y x\nPOINTS 2\nCOUNT 1 1 1\nTYPE F F F\nSIZE 4 4 4\nVIEWPOINT 1 2 3 0 1 0 0\n"
        "HEIGHT 1\nWIDTH 2\nDATA ascii\n3.25\t-2 1.5 99 98\n6 5 4\n7 8 9\n",
    };
    size_t k;
    for (k = 0; k < sizeof files / sizeof files[0]; k++) {
        double *points;
        size_t count;
        char err[256] = "";
        sqffd_io_info info;
        if (sqffd_io_read_points_info(files[k], strlen(files[k]), "h.txt", &points, &count, &info, err, sizeof err)) {
            CHECK_MSG(0, "file %lu: %s", (unsigned long)k, err);
            continue;
        }
        COMPARE_POINTS(points, count, two, 2, "header variant");
        CHECK(info.format == SQFFD_IO_PCD && info.pcd.points == 2);
        free(points);
        if (k == 0) CHECK(info.pcd.version[0] == '\0');
        if (k == 1) CHECK(strcmp(info.pcd.version, "0.6") == 0);
        if (k == 2) CHECK(info.pcd.width == 1 && info.pcd.height == 2);
        if (k == 3) CHECK(info.pcd.width == 2 && info.pcd.height == 1 && strcmp(info.pcd.fields, "x F4, y F4, z F4") == 0);
        if (k == 4) CHECK(info.pcd.viewpoint[0] == 1.0 && info.pcd.viewpoint[2] == 3.0 && info.pcd.viewpoint[4] == 1.0);
    }
}

static void test_pcd_detect(void)
{
    CHECK(sqffd_io_detect("# .PCD v0.7 - Point", 19, "a.xyz") == SQFFD_IO_PCD);
    CHECK(sqffd_io_detect("VERSION .7\n", 11, NULL) == SQFFD_IO_PCD);
    CHECK(sqffd_io_detect("\n# made by hand\n  FIELDS x y z\n", 31, "a.txt") == SQFFD_IO_PCD);
    CHECK(sqffd_io_detect("1 2 3\n", 6, "scan.pcd") == SQFFD_IO_PCD);
    CHECK(sqffd_io_detect("1 2 3\n", 6, "SCAN.PCD.GZ") == SQFFD_IO_PCD);
    CHECK(sqffd_io_detect("1 2 3\n", 6, "scan.pcd.txt") == SQFFD_IO_XYZ);
    CHECK(sqffd_io_detect("FIELDSx 1 2\n", 12, NULL) == SQFFD_IO_XYZ);
    CHECK(strcmp(sqffd_io_format_name(SQFFD_IO_PCD), "PCD") == 0 && strcmp(sqffd_io_format_name(SQFFD_IO_XYZ), "XYZ") == 0);
    /* an XYZ file named .pcd reads as PCD, and says what is wrong */
    EXPECT_TEXT_ERROR("1 2 3\n", "header line 1: unknown keyword '1'");
}

/* ---- files written by PCL ------------------------------------------------------- */

static void test_pcd_pcl_files(void)
{
    static const char *const files[] = {"tests/data/pcd_kinect_ascii.pcd.gz", "tests/data/pcd_kinect_binary.pcd",
                                        "tests/data/pcd_kinect_binary_compressed.pcd"};
    static const char *const encodings[] = {"ascii", "binary", "binary_compressed"};
    size_t dims[2] = {24, 18}, nan, n, k;
    double want[3 * 24 * 18];
    pcd_spec s = kinect_spec(24, 18, PCD_ASCII);
    bytes source = {NULL, 0, 0};
    unsigned char *gz, *text;
    size_t gz_size, text_size;
    char err[256] = "";
    n = kinect_truth(24, 18, want, &nan);
    /* the gzipped ascii source is what tests/pcd_encode.h writes */
    pcd_encode(&source, &s, kinect_value, dims);
    if (sqffd_io_load_file(files[0], &gz, &gz_size, err, sizeof err) == 0) {
        if (sqffd_gz_decompress(gz, gz_size, files[0], 0, &text, &text_size, err, sizeof err) == 0) {
            CHECK(text_size == source.size && memcmp(text, source.data, text_size) == 0);
            free(text);
        } else {
            CHECK_MSG(0, "%s", err);
        }
        free(gz);
    } else {
        CHECK_MSG(0, "%s", err);
    }
    bytes_free(&source);
    /* PCL's binary and binary_compressed conversions of it read as the same points */
    for (k = 0; k < 3; k++) {
        double *points;
        size_t count;
        sqffd_io_info info;
        if (sqffd_io_read_file_info(files[k], &points, &count, &info, err, sizeof err)) {
            CHECK_MSG(0, "%s", err);
            continue;
        }
        COMPARE_POINTS(points, count, want, n, files[k]);
        CHECK(info.format == SQFFD_IO_PCD && info.gzip == (k == 0) && info.dropped_nan == nan);
        CHECK(strcmp(info.pcd.encoding, encodings[k]) == 0 && info.pcd.width == 24 && info.pcd.height == 18);
        free(points);
    }
}

/* pcl_ply2pcd and pcl_convert_pcd_ascii_binary's file of the first 500 bunny vertices. */
static void test_pcd_pcl_bunny(void)
{
    double *bunny, *points;
    size_t bunny_n, count;
    sqffd_io_info info;
    char err[256] = "";
    if (sqffd_io_read_file("tests/data/bunny.ply", &bunny, &bunny_n, err, sizeof err)) {
        CHECK_MSG(0, "%s", err);
        return;
    }
    if (sqffd_io_read_file_info("tests/data/pcd_bunny500_binary_compressed.pcd", &points, &count, &info, err,
                                sizeof err) == 0) {
        COMPARE_POINTS(points, count, bunny, 500, "bunny, first 500 vertices");
        CHECK(strcmp(info.pcd.encoding, "binary_compressed") == 0 && strcmp(info.pcd.fields, "x F4, y F4, z F4") == 0);
        free(points);
    } else {
        CHECK_MSG(0, "%s", err);
    }
    free(bunny);
}

/* ---- LZF ----------------------------------------------------------------------- */

/* Decompresses `stream` into exactly `want` (or, with problem non-NULL,
   expects that failure). */
static void expect_lzf(const char *stream, size_t size, size_t out_size, const char *want, const char *problem,
                       const char *file, int line)
{
    unsigned char out[9000];
    const char *found = NULL;
    size_t at = 0, done = 0;
    int r = sqffd_io__lzf_decompress((const unsigned char *)stream, size, out, out_size, &found, &at, &done);
    if (problem) {
        if (r != 1 || !found || !strstr(found, problem))
            test_fail(file, line, "expected \"%s\", got %d (%s)", problem, r, found ? found : "no problem");
    } else if (r != 0) {
        test_fail(file, line, "failed: %s at %lu", found, (unsigned long)at);
    } else if (memcmp(out, want, out_size) != 0) {
        test_fail(file, line, "wrong bytes");
    }
}
#define EXPECT_LZF(stream, out_size, want) expect_lzf(stream, sizeof stream - 1, out_size, want, NULL, __FILE__, __LINE__)
#define EXPECT_LZF_ERROR(stream, out_size, problem) \
    expect_lzf(stream, sizeof stream - 1, out_size, NULL, problem, __FILE__, __LINE__)

static void test_pcd_lzf_decoder(void)
{
    unsigned char far[8192 + 3], *out = (unsigned char *)test_malloc(sizeof far);
    char run[300];
    const char *problem;
    size_t at, done, i;
    bytes stream = {NULL, 0, 0};
    EXPECT_LZF("\x02" "abc", 3, "abc");
    EXPECT_LZF("\x03" "abcd" "\x40\x03", 8, "abcdabcd");              /* length 4, distance 4 */
    EXPECT_LZF("\x01" "ab" "\xa0\x01", 9, "ababababa");               /* overlapping: length 7, distance 2 */
    EXPECT_LZF("\x00" "a" "\xe0\x00\x00", 10, "aaaaaaaaaa");          /* length 9 (7 + 0 + 2), distance 1 */
    memset(run, 'z', sizeof run);
    EXPECT_LZF("\x00" "z" "\xe0\xff\x00", 265, run);                  /* the longest: 264 from distance 1 */
    EXPECT_LZF("\x01" "xy" "\x20\x01" "\x00" "!", 6, "xyxyx!");       /* length 3, then a literal */
    /* the farthest reference, 8192 bytes back; with a byte less before it, too far */
    for (i = 0; i < 8192; i++) far[i] = (unsigned char)('A' + i % 23);
    memcpy(far + 8192, far, 3);
    lzf_literals(&stream, far, 0, 8192);
    bytes_byte(&stream, 0x3f); /* length 3, distance bits 31 << 8 | 255: 8192 */
    bytes_byte(&stream, 0xff);
    CHECK(sqffd_io__lzf_decompress(stream.data, stream.size, out, sizeof far, &problem, &at, &done) == 0);
    CHECK(memcmp(out, far, sizeof far) == 0);
    stream.size = 0;
    lzf_literals(&stream, far, 0, 8191);
    bytes_byte(&stream, 0x3f);
    bytes_byte(&stream, 0xff);
    CHECK(sqffd_io__lzf_decompress(stream.data, stream.size, out, sizeof far - 1, &problem, &at, &done) == 1 &&
          strstr(problem, "before the start") && done == 8191);
    bytes_free(&stream);
    EXPECT_LZF_ERROR("\x05" "ab", 6, "literal run passes the end");
    EXPECT_LZF_ERROR("\x00" "a" "\x40", 4, "cut off by the end");
    EXPECT_LZF_ERROR("\x00" "a" "\xe0", 12, "cut off by the end");     /* the length byte missing */
    EXPECT_LZF_ERROR("\x00" "a" "\xe0\x05", 12, "cut off by the end"); /* then the distance byte */
    EXPECT_LZF_ERROR("\x00" "a" "\x20\x01", 4, "before the start");    /* distance 2 after 1 byte */
    EXPECT_LZF_ERROR("\x20\x00", 3, "before the start");                 /* a reference first */
    EXPECT_LZF_ERROR("\x02" "abc", 2, "more bytes than the uncompressed size");
    EXPECT_LZF_ERROR("\x00" "a" "\xe0\xff\x00", 100, "more bytes than the uncompressed size");
    EXPECT_LZF_ERROR("\x02" "abc", 4, "fewer bytes than the uncompressed size");
    EXPECT_LZF_ERROR("", 1, "fewer bytes");
    /* where it failed: the reference at input byte 4, after 2 bytes of output */
    CHECK(sqffd_io__lzf_decompress((const unsigned char *)"\x00" "a" "\x00" "b" "\x20\x07", 6, out, 9, &problem, &at,
                                   &done) == 1 && at == 4 && done == 2);
    free(out);
}

/* Every distance class of the decoder's block copies (16, 8, 4 bytes, and
   byte by byte), overlapping or not, with room after the copy and at the
   very end of the output: the bytes must be those of a byte-by-byte copy. */
static void test_pcd_lzf_distances(void)
{
    static const size_t lengths[] = {3, 4, 7, 8, 9, 15, 16, 17, 31, 33, 100, 264};
    size_t distance, l, tail, bad = 0;
    for (distance = 1; distance <= 40; distance++)
        for (l = 0; l < sizeof lengths / sizeof lengths[0]; l++)
            for (tail = 0; tail <= 40; tail += 40) {
                unsigned char want[400], got[400 + 64], head[40], after[40];
                bytes stream = {NULL, 0, 0};
                size_t len = lengths[l], n = distance + len + tail, i;
                const char *problem;
                size_t at, done;
                for (i = 0; i < distance; i++) head[i] = (unsigned char)(17 * i + 3);
                for (i = 0; i < tail; i++) after[i] = (unsigned char)(200 - i);
                memcpy(want, head, distance);
                for (i = 0; i < len; i++) want[distance + i] = want[i];
                memcpy(want + distance + len, after, tail);
                lzf_literals(&stream, head, 0, distance);
                lzf_reference(&stream, len, distance);
                lzf_literals(&stream, after, 0, tail);
                memset(got, 0xee, sizeof got);
                if (sqffd_io__lzf_decompress(stream.data, stream.size, got, n, &problem, &at, &done) != 0 ||
                    memcmp(got, want, n) != 0 || got[n] != 0xee)
                    bad++;
                bytes_free(&stream);
            }
    CHECK_MSG(bad == 0, "%lu of the distance x length cases decode wrong", (unsigned long)bad);
}

/* The test compressor's streams decode to their input, and use what the
   decoder must handle: long and overlapping back-references. */
static void test_pcd_lzf_roundtrip(void)
{
    size_t n = 60000, i, ip, overlapping = 0, longest = 0;
    unsigned char *in = (unsigned char *)test_malloc(n), *out = (unsigned char *)test_malloc(n);
    uint32_t state = 12345u;
    bytes packed = {NULL, 0, 0};
    const char *problem;
    size_t at, done;
    for (i = 0; i < n; i++) {
        state = state * 1664525u + 1013904223u;
        /* noise, runs of one byte, and repeats of an earlier stretch */
        if (i % 5000 < 1000) in[i] = (unsigned char)(state >> 24);
        else if (i % 5000 < 2000) in[i] = 0x7f;
        else if (i % 5000 < 3000) in[i] = (unsigned char)(i % 7);
        else in[i] = in[i - 2500];
    }
    lzf_compress(in, n, &packed);
    CHECK(packed.size < n / 4);
    CHECK(sqffd_io__lzf_decompress(packed.data, packed.size, out, n, &problem, &at, &done) == 0);
    CHECK(memcmp(in, out, n) == 0);
    for (ip = 0, done = 0; ip < packed.size;) { /* walk the tokens */
        size_t ctrl = packed.data[ip++], len, distance;
        if (ctrl < 32) {
            ip += ctrl + 1;
            done += ctrl + 1;
            continue;
        }
        len = ctrl >> 5;
        if (len == 7) len += packed.data[ip++];
        distance = ((ctrl & 31) << 8 | packed.data[ip++]) + 1;
        len += 2;
        overlapping += distance < len;
        longest = len > longest ? len : longest;
        done += len;
    }
    CHECK(done == n);
    CHECK_MSG(overlapping > 10 && longest == 264, "%lu overlapping references, longest %lu", (unsigned long)overlapping,
              (unsigned long)longest);
    bytes_free(&packed);
    free(in);
    free(out);
}

/* ---- broken files ---------------------------------------------------------------- */

/* The offset of the binary data after the DATA line. */
static size_t data_start(const bytes *b)
{
    const unsigned char *p = b->data;
    size_t i;
    for (i = 0; i + 5 < b->size; i++)
        if (memcmp(p + i, "DATA ", 5) == 0) break;
    while (i < b->size && p[i] != '\n') i++;
    return i + 1;
}

static void put_le32(unsigned char *p, uint64_t v)
{
    int k;
    for (k = 0; k < 4; k++) p[k] = (unsigned char)(v >> (8 * k));
}

/* Every prefix of a binary file fails; of an ascii file, every prefix
   without its last line fails, and any that reads gives all the points. */
static void test_pcd_truncated(void)
{
    int encoding;
    for (encoding = PCD_ASCII; encoding <= PCD_COMPRESSED; encoding++) {
        size_t dims[2] = {encoding == PCD_ASCII ? 6 : 24, encoding == PCD_ASCII ? 4 : 18};
        pcd_spec s = kinect_spec(dims[0], dims[1], encoding);
        bytes b = {NULL, 0, 0};
        size_t cut, last_line, valid = 0, failures = 0, k;
        double want[3 * 24 * 18];
        size_t nan;
        pcd_encode(&b, &s, kinect_value, dims);
        valid = kinect_truth(dims[0], dims[1], want, &nan);
        for (last_line = b.size - 1; last_line > 0 && b.data[last_line - 1] != '\n'; last_line--) {}
        for (cut = 0; cut < b.size; cut++) {
            unsigned char *copy = (unsigned char *)test_malloc(cut);
            double *points = NULL;
            size_t count = 0;
            char err[256] = "";
            memcpy(copy, b.data, cut);
            if (sqffd_io_read_points(copy, cut, "cut.pcd", &points, &count, err, sizeof err) == 0) {
                if (encoding != PCD_ASCII || cut <= last_line || count != valid) failures++;
                free(points);
            } else if (points || count || strncmp(err, "cut.pcd: ", 9) != 0) {
                failures++;
            }
            free(copy);
        }
        CHECK_MSG(failures == 0, "%s: %lu prefixes misread", encoding_names[encoding], (unsigned long)failures);
        if (encoding == PCD_COMPRESSED) {
            /* the compressed stream cut short, its size field saying so */
            size_t start = data_start(&b), full = b.size - start - 8;
            for (k = 0; k < full; k++) {
                bytes c = {NULL, 0, 0};
                bytes_put(&c, b.data, start + 8 + k);
                put_le32(c.data + start, k);
                /* shorter than LZF can expand to the size: refused before decompressing */
                EXPECT_ERROR(&c, "cut.pcd", 88 * k < 24 * 18 * 16 ? "(LZF expands at most 88-fold)" : "binary_compressed data: ");
                bytes_free(&c);
            }
            /* any byte of the stream flipped: an error or finite points, never an overrun */
            for (k = start + 8; k < b.size; k++) {
                double *points;
                size_t count;
                sqffd_io_info info;
                b.data[k] ^= 0xa5;
                if (sqffd_io_read_points_info(b.data, b.size, "flip.pcd", &points, &count, &info, NULL, 0) == 0) {
                    CHECK(count + info.dropped_nan == dims[0] * dims[1]);
                    free(points);
                }
                b.data[k] ^= 0xa5;
            }
        }
        bytes_free(&b);
    }
}

static void test_pcd_broken_headers(void)
{
#define XYZ_HEAD "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
    EXPECT_TEXT_ERROR("VERSION 0.7\nFIELDS x y z\n", "file ends inside the header (no DATA line)");
    EXPECT_TEXT_ERROR("VERSION 0.5\n" XYZ_HEAD "POINTS 1\nDATA ascii\n1 2 3\n", "VERSION '0.5': only PCD 0.6 and 0.7");
    EXPECT_TEXT_ERROR("VERSION 0.7\nCOLOURS x y z\n", "header line 2: unknown keyword 'COLOURS'");
    EXPECT_TEXT_ERROR("VERSION 0.7\nfields x y z\n", "unknown keyword 'fields'");
    EXPECT_TEXT_ERROR("VERSION 0.7\nSIZE 4 4 4\n" XYZ_HEAD, "header line 2: SIZE before FIELDS");
    EXPECT_TEXT_ERROR(XYZ_HEAD "FIELDS x y z\n", "header line 5: a second FIELDS line");
    EXPECT_TEXT_ERROR("FIELDS x y z\nSIZE 4 4\nTYPE F F F\nPOINTS 1\nDATA ascii\n1 2 3\n", "2 SIZE entries for 3 FIELDS");
    EXPECT_TEXT_ERROR("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F F\nPOINTS 1\nDATA ascii\n1 2 3\n",
                      "more TYPE entries than the 3 FIELDS");
    EXPECT_TEXT_ERROR("FIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1\nPOINTS 1\nDATA ascii\n1 2 3 4\n",
                      "3 COUNT entries for 4 FIELDS");
    EXPECT_TEXT_ERROR("FIELDS x y z\nSIZE 4 4 3\nTYPE F F F\nPOINTS 1\nDATA ascii\n1 2 3\n", "SIZE '3' is not 1, 2, 4 or 8");
    EXPECT_TEXT_ERROR("FIELDS x y z\nSIZE 4 4 4\nTYPE F F D\nPOINTS 1\nDATA ascii\n1 2 3\n", "TYPE 'D' is not I, U or F");
    EXPECT_TEXT_ERROR("FIELDS x y z\nSIZE 4 4 2\nTYPE F F F\nPOINTS 1\nDATA ascii\n1 2 3\n",
                      "field 'z': TYPE F of SIZE 2 is not a PCD type");
    EXPECT_TEXT_ERROR("FIELDS x y z\nSIZE 4 4 4\nPOINTS 1\nDATA ascii\n1 2 3\n", "header has SIZE but no TYPE line");
    EXPECT_TEXT_ERROR("FIELDS x y z\nCOUNT 1 0 1\nPOINTS 1\nDATA ascii\n1 2 3\n", "COUNT 0");
    EXPECT_TEXT_ERROR("FIELDS x y z\nCOUNT 1 2 1\nPOINTS 1\nDATA ascii\n1 2 2 3\n", "field 'y' has COUNT 2");
    EXPECT_TEXT_ERROR("FIELDS x y rgb\nPOINTS 1\nDATA ascii\n1 2 3\n", "FIELDS has no 'z'");
    EXPECT_TEXT_ERROR("FIELDS x y z x\nPOINTS 1\nDATA ascii\n1 2 3 4\n", "a second field 'x'");
    EXPECT_TEXT_ERROR("FIELDS\nPOINTS 1\nDATA ascii\n1 2 3\n", "FIELDS names no field");
    EXPECT_TEXT_ERROR(XYZ_HEAD "DATA ascii\n1 2 3\n", "header has neither POINTS nor WIDTH");
    EXPECT_TEXT_ERROR(XYZ_HEAD "HEIGHT 2\nPOINTS 2\nDATA ascii\n1 2 3\n", "header has HEIGHT but no WIDTH");
    EXPECT_TEXT_ERROR(XYZ_HEAD "WIDTH 3\nHEIGHT 2\nPOINTS 5\nDATA ascii\n1 2 3\n", "WIDTH x HEIGHT = 3 x 2, but POINTS 5");
    EXPECT_TEXT_ERROR(XYZ_HEAD "WIDTH 4294967296\nHEIGHT 4294967296\nDATA ascii\n1 2 3\n",
                      "WIDTH 4294967296 x HEIGHT 4294967296 overflows");
    EXPECT_TEXT_ERROR(XYZ_HEAD "WIDTH 0\nHEIGHT 0\nPOINTS 0\nDATA ascii\n", "header says 0 points");
    EXPECT_TEXT_ERROR(XYZ_HEAD "POINTS -1\nDATA ascii\n1 2 3\n", "expected 'POINTS N'");
    EXPECT_TEXT_ERROR(XYZ_HEAD "POINTS 1 2\nDATA ascii\n1 2 3\n", "expected 'POINTS N'");
    EXPECT_TEXT_ERROR(XYZ_HEAD "VIEWPOINT 0 0 0 1 0 0\nPOINTS 1\nDATA ascii\n1 2 3\n", "VIEWPOINT takes 7 finite numbers");
    EXPECT_TEXT_ERROR(XYZ_HEAD "VIEWPOINT 0 0 nan 1 0 0 0\nPOINTS 1\nDATA ascii\n1 2 3\n", "VIEWPOINT takes 7");
    EXPECT_TEXT_ERROR(XYZ_HEAD "VIEWPOINT 0 0 0 1 0 0 0 0\nPOINTS 1\nDATA ascii\n1 2 3\n", "found more");
    EXPECT_TEXT_ERROR(XYZ_HEAD "POINTS 1\nDATA binary_lzf\n", "DATA 'binary_lzf' is not ascii, binary or binary_compressed");
    EXPECT_TEXT_ERROR(XYZ_HEAD "POINTS 1\nDATA\n", "expected 'DATA ENCODING'");
    /* absurd counts: refused before anything is allocated */
    EXPECT_TEXT_ERROR(XYZ_HEAD "POINTS 18446744073709551615\nDATA ascii\n1 2 3\n",
                      "header says 18446744073709551615 points of 3 values each, file holds 6 bytes");
    EXPECT_TEXT_ERROR(XYZ_HEAD "POINTS 1000000000000\nDATA binary\n123456789012",
                      "header says 1000000000000 points of 12 bytes each, file holds 12 bytes");
    EXPECT_TEXT_ERROR("FIELDS x y z big\nSIZE 4 4 4 8\nTYPE F F F U\nCOUNT 1 1 1 2305843009213693952\nPOINTS 1\n"
                      "DATA binary\n123456789012", "SIZE x COUNT add up past 2^64");
    EXPECT_TEXT_ERROR("FIELDS x y z big\nSIZE 4 4 4 8\nTYPE F F F U\nCOUNT 1 1 1 2305843009213693950\nPOINTS 1\n"
                      "DATA binary\n123456789012", "points of 18446744073709551612 bytes each");
    EXPECT_TEXT_ERROR("FIELDS x y z big\nCOUNT 1 1 1 18446744073709551615\nPOINTS 1\nDATA ascii\n1 2 3\n",
                      "COUNTs add up past 2^64");
#undef XYZ_HEAD
}

static void test_pcd_broken_data(void)
{
#define HEAD "FIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 2\nHEIGHT 1\nPOINTS 2\n"
    pcd_spec s = kinect_spec(16, 12, PCD_COMPRESSED);
    size_t dims[2] = {16, 12}, start;
    bytes b = {NULL, 0, 0}, c = {NULL, 0, 0};
    unsigned char inf_bits[4] = {0x00, 0x00, 0x80, 0x7f};
    int k;
    /* ascii */
    EXPECT_TEXT_ERROR(HEAD "DATA ascii\n10 20 30 40\n50 60 70\n", "point 1 (line 10): expected 4 values, found 3");
    EXPECT_TEXT_ERROR(HEAD "DATA ascii\n1.5 2.5 3.5 4.5\n", "file ends after 1 of 2 points");
    EXPECT_TEXT_ERROR(HEAD "DATA ascii\n1 2 3 4\n5 6 7\n", "header says 2 points of 4 values each, file holds 14 bytes");
    EXPECT_TEXT_ERROR(HEAD "DATA ascii\n1 2 3 4\n5 abc 7 8\n", "point 1 (line 10): expected a number for y, found 'abc'");
    EXPECT_TEXT_ERROR(HEAD "DATA ascii\n1 2 3 4\n5 6 inf 8\n", "point 1 (line 10): z 'inf' is not finite");
    EXPECT_TEXT_ERROR(HEAD "DATA ascii\n1 2 3 4\n5 6 1e39 8\n", "z '1e39' is not finite as a float");
    EXPECT_TEXT_ERROR("FIELDS x y z\nSIZE 4 4 1\nTYPE F F I\nPOINTS 1\nDATA ascii\n1 2 1.5\n",
                      "z '1.5' is not a signed integer of 8 bits");
    EXPECT_TEXT_ERROR("FIELDS x y z\nSIZE 4 4 2\nTYPE F F U\nPOINTS 1\nDATA ascii\n1 2 65536\n",
                      "z '65536' is not an unsigned integer of 16 bits");
    EXPECT_TEXT_ERROR("FIELDS x y z\nSIZE 4 4 2\nTYPE F F U\nPOINTS 1\nDATA ascii\n1 2 nan\n", "is not an unsigned integer");
    /* binary: an infinite coordinate; data cut short */
    bytes_text(&c, HEAD "DATA binary\n");
    for (k = 0; k < 8; k++) bytes_put(&c, k == 6 ? inf_bits : (const unsigned char *)"\0\0\0\0", 4);
    EXPECT_ERROR(&c, "inf.pcd", "point 1: z is infinite (PCL marks invalid points with NaN");
    c.size -= 1;
    EXPECT_ERROR(&c, "inf.pcd", "header says 2 points of 16 bytes each, file holds 31 bytes of data");
    bytes_free(&c);
    /* binary_compressed */
    pcd_encode(&b, &s, kinect_value, dims);
    start = data_start(&b);
    bytes_put(&c, b.data, b.size);
    c.size = start + 5;
    EXPECT_ERROR(&c, "c.pcd", "file ends before the binary_compressed sizes");
    memcpy(c.data, b.data, b.size);
    c.size = b.size;
    put_le32(c.data + start, b.size - start - 8 + 1);
    EXPECT_ERROR(&c, "c.pcd", "bytes of compressed data, file holds");
    put_le32(c.data + start, 0xffffffffu);
    EXPECT_ERROR(&c, "c.pcd", "4294967295 bytes of compressed data, file holds");
    memcpy(c.data, b.data, b.size);
    put_le32(c.data + start + 4, 16 * 12 * 16 + 16);
    EXPECT_ERROR(&c, "c.pcd", "uncompressed size 3088 bytes, but 192 points of 16 bytes take 3072");
    put_le32(c.data + start + 4, 16 * 12 * 16 - 1);
    EXPECT_ERROR(&c, "c.pcd", "uncompressed size 3071 bytes");
    /* a header whose points ask for more than LZF can expand the stream to */
    bytes_free(&c);
    bytes_text(&c, "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1000\nHEIGHT 1000\nDATA binary_compressed\n");
    bytes_put(&c, "\x02\x00\x00\x00\x00\x1b\xb7\x00\x00z", 10);
    EXPECT_ERROR(&c, "c.pcd", "2 compressed bytes cannot hold 12000000 (LZF expands at most 88-fold)");
    /* the sizes right, the stream wrong: a reference before the start */
    bytes_free(&c);
    bytes_text(&c, "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 1\nDATA binary_compressed\n");
    bytes_put(&c, "\x02\x00\x00\x00\x0c\x00\x00\x00\x2a\x00", 10);
    EXPECT_ERROR(&c, "c.pcd", "binary_compressed data: a back-reference reaches before the start of the data");
    bytes_free(&c);
    bytes_free(&b);
#undef HEAD
}

void suite_pcd(void)
{
    RUN_TEST(test_pcd_mixed_fields);
    RUN_TEST(test_pcd_value_types);
    RUN_TEST(test_pcd_organised_nan);
    RUN_TEST(test_pcd_all_nan);
    RUN_TEST(test_pcd_headers);
    RUN_TEST(test_pcd_detect);
    RUN_TEST(test_pcd_pcl_files);
    RUN_TEST(test_pcd_pcl_bunny);
    RUN_TEST(test_pcd_lzf_decoder);
    RUN_TEST(test_pcd_lzf_distances);
    RUN_TEST(test_pcd_lzf_roundtrip);
    RUN_TEST(test_pcd_truncated);
    RUN_TEST(test_pcd_broken_headers);
    RUN_TEST(test_pcd_broken_data);
}

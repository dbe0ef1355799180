/* suite_export: the viewer and report outputs of examples/sqffd_export.h.
   Each output is read back by a small reader written here from the format's
   definition (legacy VTK, JSON through the header's own reader, SVG through
   a well-formedness checker and attribute lookups), and compared with what
   was written or with values derived by hand. Files go to a temporary
   directory that the suite removes. */
#define _POSIX_C_SOURCE 200809L
#include "test.h"
#include "../examples/sqffd_export.h"
#include "../examples/sqffd_phantom.h"
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char temp_dir[64];

/* A file name in the suite's temporary directory (one of four rotating buffers). */
static const char *temp_path(const char *file)
{
    static char paths[4][128];
    static int next;
    char *p = paths[next++ % 4];
    snprintf(p, sizeof paths[0], "%s/%s", temp_dir, file);
    return p;
}

static int file_exists(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (f) fclose(f);
    return f != NULL;
}

/* The whole file, NUL-terminated (binary content may hold other NULs). */
static char *load(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    char *data;
    long n;
    *size = 0;
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    n = ftell(f);
    fseek(f, 0, SEEK_SET);
    data = (char *)malloc((size_t)n + 1);
    if (data && fread(data, 1, (size_t)n, f) != (size_t)n) {
        free(data);
        data = NULL;
    }
    fclose(f);
    if (!data) return NULL;
    data[n] = '\0';
    *size = (size_t)n;
    return data;
}

/* The content of an open stream, from its start. */
static char *load_stream(FILE *f, size_t *size)
{
    long n;
    char *data;
    fflush(f);
    fseek(f, 0, SEEK_END);
    n = ftell(f);
    rewind(f);
    data = (char *)malloc((size_t)n + 1);
    *size = data ? fread(data, 1, (size_t)n, f) : 0;
    if (data) data[*size] = '\0';
    return data;
}

static int count_of(const char *text, const char *needle)
{
    int n = 0;
    size_t len = strlen(needle);
    for (text = strstr(text, needle); text; text = strstr(text + len, needle)) n++;
    return n;
}

static int starts_with(const char *s, const char *prefix)
{
    return strncmp(s, prefix, strlen(prefix)) == 0;
}

/* ---- legacy VTK: a reader written from the format's definition ------------ */

typedef struct vtk_file {
    char title[300];
    int binary, doubles, polygons;
    size_t points, cells, cell_ints;
    double *xyz;
    uint32_t *conn;
    int scalar_count;
    char scalar_name[4][64];
    double *scalar[4];
} vtk_file;

typedef struct cursor {
    const char *p, *end;
} cursor;

static void vtk_free(vtk_file *v)
{
    int k;
    free(v->xyz);
    free(v->conn);
    for (k = 0; k < v->scalar_count; k++) free(v->scalar[k]);
    memset(v, 0, sizeof *v);
}

/* The next line as it is (no blanks skipped); 0 at the end. */
static int raw_line(cursor *c, char *line, size_t size)
{
    size_t n = 0;
    if (c->p >= c->end) return 0;
    while (c->p < c->end && *c->p != '\n') {
        if (n + 1 < size) line[n++] = *c->p;
        c->p++;
    }
    if (c->p < c->end) c->p++;
    line[n] = '\0';
    return 1;
}

/* The next keyword line, after any blanks and line breaks. */
static int keyword_line(cursor *c, char *line, size_t size)
{
    while (c->p < c->end && (*c->p == ' ' || *c->p == '\n' || *c->p == '\r' || *c->p == '\t')) c->p++;
    return raw_line(c, line, size);
}

static uint32_t be32(const char *p)
{
    const unsigned char *b = (const unsigned char *)p;
    return (uint32_t)b[0] << 24 | (uint32_t)b[1] << 16 | (uint32_t)b[2] << 8 | (uint32_t)b[3];
}

/* One real in the file's encoding: ASCII text, or a big-endian float/double. */
static int read_real(cursor *c, const vtk_file *v, double *out)
{
    if (!v->binary) {
        char *stop;
        *out = strtod(c->p, &stop);
        if (stop == c->p || stop > c->end) return 1;
        c->p = stop;
        return 0;
    }
    if (v->doubles) {
        uint64_t bits;
        if (c->end - c->p < 8) return 1;
        bits = (uint64_t)be32(c->p) << 32 | be32(c->p + 4);
        memcpy(out, &bits, 8);
        c->p += 8;
    } else {
        uint32_t bits = 0;
        float f;
        if (c->end - c->p < 4) return 1;
        bits = be32(c->p);
        memcpy(&f, &bits, 4);
        *out = f;
        c->p += 4;
    }
    return 0;
}

static int read_int(cursor *c, const vtk_file *v, uint32_t *out)
{
    if (!v->binary) {
        char *stop;
        unsigned long x = strtoul(c->p, &stop, 10);
        if (stop == c->p || stop > c->end) return 1;
        *out = (uint32_t)x;
        c->p = stop;
        return 0;
    }
    if (c->end - c->p < 4) return 1;
    *out = be32(c->p);
    c->p += 4;
    return 0;
}

/* A binary block ends with exactly one line break. */
static int block_end(cursor *c, const vtk_file *v)
{
    if (!v->binary) return 0;
    if (c->p >= c->end || *c->p != '\n') return 1;
    c->p++;
    return 0;
}

/* Parses a legacy VTK polydata file as sqffd_export_vtk writes it; returns
   NULL or what is wrong. */
static const char *vtk_parse(const char *data, size_t size, vtk_file *v)
{
    cursor c;
    char line[400], type[16], name[64];
    unsigned long long a, b;
    size_t i;
    memset(v, 0, sizeof *v);
    c.p = data;
    c.end = data + size;
    if (!raw_line(&c, line, sizeof line) || strcmp(line, "# vtk DataFile Version 3.0") != 0) return "magic line";
    if (!raw_line(&c, v->title, sizeof v->title)) return "title";
    if (!raw_line(&c, line, sizeof line)) return "encoding";
    if (strcmp(line, "BINARY") == 0) v->binary = 1;
    else if (strcmp(line, "ASCII") != 0) return "encoding word";
    if (!raw_line(&c, line, sizeof line) || strcmp(line, "DATASET POLYDATA") != 0) return "dataset";
    if (!raw_line(&c, line, sizeof line) || sscanf(line, "POINTS %llu %15s", &a, type) != 2) return "POINTS line";
    if (strcmp(type, "double") == 0) v->doubles = 1;
    else if (strcmp(type, "float") != 0) return "POINTS type";
    v->points = (size_t)a;
    v->xyz = (double *)malloc(3 * v->points * sizeof(double));
    for (i = 0; i < 3 * v->points; i++)
        if (read_real(&c, v, &v->xyz[i])) return "point data";
    if (block_end(&c, v)) return "line break after the points";
    if (!keyword_line(&c, line, sizeof line)) return "cells line";
    if (sscanf(line, "POLYGONS %llu %llu", &a, &b) == 2) v->polygons = 1;
    else if (sscanf(line, "VERTICES %llu %llu", &a, &b) != 2) return "cells keyword";
    v->cells = (size_t)a;
    v->cell_ints = (size_t)b;
    v->conn = (uint32_t *)malloc((v->cell_ints ? v->cell_ints : 1) * sizeof(uint32_t));
    for (i = 0; i < v->cell_ints; i++)
        if (read_int(&c, v, &v->conn[i])) return "cell data";
    if (block_end(&c, v)) return "line break after the cells";
    if (!keyword_line(&c, line, sizeof line)) return NULL; /* no point data */
    if (sscanf(line, "POINT_DATA %llu", &a) != 1 || a != v->points) return "POINT_DATA line";
    while (keyword_line(&c, line, sizeof line)) {
        double *values;
        if (v->scalar_count == 4) return "too many scalars";
        if (sscanf(line, "SCALARS %63s %15s 1", name, type) != 2) return "SCALARS line";
        if (strcmp(type, v->doubles ? "double" : "float") != 0) return "SCALARS type";
        if (!raw_line(&c, line, sizeof line) || strcmp(line, "LOOKUP_TABLE default") != 0) return "LOOKUP_TABLE line";
        values = (double *)malloc(v->points * sizeof(double));
        strcpy(v->scalar_name[v->scalar_count], name);
        v->scalar[v->scalar_count++] = values;
        for (i = 0; i < v->points; i++)
            if (read_real(&c, v, &values[i])) return "scalar data";
        if (block_end(&c, v)) return "line break after the scalars";
    }
    return NULL;
}

/* A small mesh whose coordinates and scalars span many magnitudes, signs
   included, so that float rounding is exercised. */
enum { MESH_NV = 7, MESH_NT = 6 };
static void small_mesh(double xyz[3 * MESH_NV], uint32_t tri[3 * MESH_NT], double s0[MESH_NV], double s1[MESH_NV])
{
    static const uint32_t t[3 * MESH_NT] = {0, 1, 2, 0, 2, 3, 0, 3, 4, 6, 5, 4, 1, 6, 5, 2, 6, 3};
    int i;
    for (i = 0; i < 3 * MESH_NV; i++) xyz[i] = (i % 2 ? -1.0 : 1.0) * pow(10.0, (i % 9) - 4.0) * (1.0 + i / 7.0);
    for (i = 0; i < MESH_NV; i++) {
        s0[i] = 0.1 * i - 0.37;
        s1[i] = 1e-30 * (i + 1) + (i == 3 ? 123456.789 : 0.0);
    }
    memcpy(tri, t, sizeof t);
}

/* Binary and ASCII, float and double, mesh and point cloud: the file parses
   as the format defines, with the title, the triangles exactly, the points
   and scalars to the type written. */
static void test_export_vtk_round_trip(void)
{
    double xyz[3 * MESH_NV], s0[MESH_NV], s1[MESH_NV];
    uint32_t tri[3 * MESH_NT];
    sqffd_io_scalar scalars[2];
    int flags, cloud;
    small_mesh(xyz, tri, s0, s1);
    scalars[0].name = "error";
    scalars[0].values = s0;
    scalars[1].name = "low_motion";
    scalars[1].values = s1;
    for (cloud = 0; cloud < 2; cloud++)
        for (flags = 0; flags < 4; flags++) {
            const char *path = temp_path("mesh.vtk");
            char err[256] = "";
            size_t size, i;
            char *data;
            vtk_file v;
            const char *problem;
            int as_double = (flags & SQFFD_EXPORT_VTK_DOUBLE) != 0;
            CHECK_MSG(sqffd_export_vtk(path, "a test mesh", xyz, MESH_NV, cloud ? NULL : tri, cloud ? 0 : MESH_NT,
                                       scalars, 2 - cloud, flags, err, sizeof err) == 0,
                      "flags %d: %s", flags, err);
            data = load(path, &size);
            CHECK(data != NULL);
            if (!data) return;
            problem = vtk_parse(data, size, &v);
            CHECK_MSG(problem == NULL, "flags %d cloud %d: %s", flags, cloud, problem);
            if (!problem) {
                CHECK(strcmp(v.title, "a test mesh") == 0);
                CHECK(v.binary == !(flags & SQFFD_EXPORT_VTK_ASCII));
                CHECK(v.doubles == as_double);
                CHECK(v.points == MESH_NV);
                for (i = 0; i < 3 * MESH_NV; i++)
                    CHECK_MSG(as_double ? v.xyz[i] == xyz[i] : (float)v.xyz[i] == (float)xyz[i],
                              "flags %d: coordinate %d: %.17g read, %.17g written", flags, (int)i, v.xyz[i], xyz[i]);
                if (!cloud) {
                    CHECK(v.polygons && v.cells == MESH_NT && v.cell_ints == 4 * MESH_NT);
                    for (i = 0; i < MESH_NT; i++)
                        CHECK(v.conn[4 * i] == 3 && v.conn[4 * i + 1] == tri[3 * i] &&
                              v.conn[4 * i + 2] == tri[3 * i + 1] && v.conn[4 * i + 3] == tri[3 * i + 2]);
                } else {
                    CHECK(!v.polygons && v.cells == MESH_NV && v.cell_ints == 2 * MESH_NV);
                    for (i = 0; i < MESH_NV; i++) CHECK(v.conn[2 * i] == 1 && v.conn[2 * i + 1] == i);
                }
                CHECK(v.scalar_count == 2 - cloud);
                CHECK(strcmp(v.scalar_name[0], "error") == 0);
                if (!cloud) CHECK(strcmp(v.scalar_name[1], "low_motion") == 0);
                for (i = 0; i < MESH_NV; i++) {
                    CHECK(as_double ? v.scalar[0][i] == s0[i] : (float)v.scalar[0][i] == (float)s0[i]);
                    if (!cloud) CHECK(as_double ? v.scalar[1][i] == s1[i] : (float)v.scalar[1][i] == (float)s1[i]);
                }
                /* the binary float file is exactly its header lines plus 4-byte values */
                if (flags == 0 && !cloud)
                    CHECK(size == strlen("# vtk DataFile Version 3.0\na test mesh\nBINARY\nDATASET POLYDATA\n"
                                         "POINTS 7 float\n\nPOLYGONS 6 24\n\nPOINT_DATA 7\n"
                                         "SCALARS error float 1\nLOOKUP_TABLE default\n\n"
                                         "SCALARS low_motion float 1\nLOOKUP_TABLE default\n\n") +
                                      4 * (3 * MESH_NV + 4 * MESH_NT + 2 * MESH_NV));
            }
            vtk_free(&v);
            free(data);
            remove(path);
        }
}

/* The stream form writes the same bytes as the path form; no title gives "sqffd". */
static void test_export_vtk_stream(void)
{
    double xyz[3 * MESH_NV], s0[MESH_NV], s1[MESH_NV];
    uint32_t tri[3 * MESH_NT];
    sqffd_io_scalar scalar;
    const char *path = temp_path("stream.vtk");
    char err[256] = "", *a, *b;
    size_t na, nb;
    FILE *f = tmpfile();
    small_mesh(xyz, tri, s0, s1);
    scalar.name = "error";
    scalar.values = s0;
    CHECK(f != NULL);
    if (!f) return;
    CHECK(sqffd_export_vtk_stream(f, "memory", NULL, xyz, MESH_NV, tri, MESH_NT, &scalar, 1, 0, err, sizeof err) == 0);
    CHECK(sqffd_export_vtk(path, NULL, xyz, MESH_NV, tri, MESH_NT, &scalar, 1, 0, err, sizeof err) == 0);
    a = load_stream(f, &na);
    b = load(path, &nb);
    CHECK(a && b && na == nb && memcmp(a, b, na) == 0);
    CHECK(a && starts_with(a, "# vtk DataFile Version 3.0\nsqffd\nBINARY\n"));
    free(a);
    free(b);
    fclose(f);
    remove(path);
}

/* Every refusal names the file and what is wrong, and creates no file;
   a full disk is a write error with the file's name. */
static void test_export_vtk_refusals(void)
{
    double xyz[3 * MESH_NV], s0[MESH_NV], s1[MESH_NV];
    uint32_t tri[3 * MESH_NT];
    sqffd_io_scalar scalars[2];
    const char *path = temp_path("refused.vtk");
    char err[256];
    small_mesh(xyz, tri, s0, s1);
    scalars[0].name = "mean error";
    scalars[0].values = s0;
    scalars[1].name = "b";
    scalars[1].values = s1;
#define REFUSED(call, text)                                                                     \
    do {                                                                                       \
        err[0] = '\0';                                                                         \
        CHECK_MSG((call) == 1, "%s was accepted", #call);                                      \
        CHECK_MSG(starts_with(err, path) && strstr(err, text) != NULL, "message '%s' lacks '%s'", err, text); \
        CHECK_MSG(!file_exists(path), "%s created the file", #call);                          \
    } while (0)
    REFUSED(sqffd_export_vtk(path, NULL, xyz, MESH_NV, tri, MESH_NT, scalars, 1, 0, err, sizeof err), "'mean error'");
    scalars[0].name = "b";
    REFUSED(sqffd_export_vtk(path, NULL, xyz, MESH_NV, tri, MESH_NT, scalars, 2, 0, err, sizeof err), "two scalars");
    tri[7] = MESH_NV;
    REFUSED(sqffd_export_vtk(path, NULL, xyz, MESH_NV, tri, MESH_NT, NULL, 0, 0, err, sizeof err), "triangle 2 uses vertex 7");
    tri[7] = 3;
    REFUSED(sqffd_export_vtk(path, "two\nlines", xyz, MESH_NV, tri, MESH_NT, NULL, 0, 0, err, sizeof err), "title");
    REFUSED(sqffd_export_vtk(path, NULL, xyz, 0, NULL, 0, NULL, 0, 0, err, sizeof err), "no vertices");
    xyz[4] = NAN;
    REFUSED(sqffd_export_vtk(path, NULL, xyz, MESH_NV, tri, MESH_NT, NULL, 0, 0, err, sizeof err), "vertex 1 is not finite");
    xyz[4] = 1e39; /* beyond float, fine as double */
    REFUSED(sqffd_export_vtk(path, NULL, xyz, MESH_NV, tri, MESH_NT, NULL, 0, 0, err, sizeof err), "beyond the float range");
    CHECK(sqffd_export_vtk(path, NULL, xyz, MESH_NV, tri, MESH_NT, NULL, 0, SQFFD_EXPORT_VTK_DOUBLE, err, sizeof err) == 0);
    remove(path);
    xyz[4] = 1.0;
    s1[2] = INFINITY;
    scalars[0].name = "a";
    REFUSED(sqffd_export_vtk(path, NULL, xyz, MESH_NV, tri, MESH_NT, scalars, 2, 0, err, sizeof err), "scalar 'b' at vertex 2");
    REFUSED(sqffd_export_vtk(path, NULL, xyz, MESH_NV, tri, MESH_NT, NULL, 0, 4, err, sizeof err), "unknown flags");
#undef REFUSED
    err[0] = '\0';
    CHECK(sqffd_export_vtk(temp_path("no/such/dir.vtk"), NULL, xyz, MESH_NV, tri, MESH_NT, NULL, 0, 0, err, sizeof err) == 1);
    CHECK_MSG(strstr(err, "no/such/dir.vtk: cannot create") != NULL, "%s", err);
    if (file_exists("/dev/full")) {
        FILE *f = fopen("/dev/full", "wb");
        err[0] = '\0';
        CHECK(sqffd_export_vtk("/dev/full", NULL, xyz, MESH_NV, tri, MESH_NT, NULL, 0, 0, err, sizeof err) == 1);
        CHECK_MSG(starts_with(err, "/dev/full: write error"), "%s", err);
        if (f) {
            err[0] = '\0';
            CHECK(sqffd_export_vtk_stream(f, "full disk", NULL, xyz, MESH_NV, tri, MESH_NT, NULL, 0, 0, err, sizeof err) == 1);
            CHECK_MSG(starts_with(err, "full disk: write error"), "%s", err);
            fclose(f);
        }
    }
}

/* ---- the model as JSON ---------------------------------------------------- */

static sqffd_model fitted_model;
static sqffd_fit_report fitted_report;
static int fitted;

/* The phantom's end-diastolic frame fitted once for the JSON tests. */
static int fit_phantom(void)
{
    enum { N = 2000 };
    phantom_lv p = phantom_lv_default();
    sqffd_fit_options o = sqffd_fit_options_default();
    double *pts;
    sqffd_result r;
    if (fitted) return 1;
    pts = (double *)malloc(3 * N * sizeof *pts);
    phantom_lv_frame(&p, 0.0, N, 0.01, 21, pts, NULL);
    o.max_iterations = 12;
    r = test_fit(pts, N, &o, &fitted_model, &fitted_report);
    free(pts);
    CHECK_RESULT(r, SQFFD_OK);
    fitted = r == SQFFD_OK;
    return fitted;
}

/* The fields that define a model, compared bit for bit; `what` names the case. */
static void check_same_model(const sqffd_model *a, const sqffd_model *b, const char *what)
{
    size_t used = (size_t)a->ffd.dims[0] * (size_t)a->ffd.dims[1] * (size_t)a->ffd.dims[2];
    static const double where[][2] = {{0.0, 0.0}, {0.3, -2.0}, {-1.2, 1.0}, {1.5707963267948966, 0.0}, {-0.7, 3.1}};
    size_t k;
    CHECK_MSG(memcmp(&a->sq, &b->sq, sizeof a->sq) == 0, "%s: superquadric differs", what);
    CHECK_MSG(memcmp(a->ffd.dims, b->ffd.dims, sizeof a->ffd.dims) == 0, "%s: dims differ", what);
    CHECK_MSG(memcmp(a->ffd.origin, b->ffd.origin, sizeof a->ffd.origin) == 0, "%s: origin differs", what);
    CHECK_MSG(memcmp(a->ffd.edges, b->ffd.edges, sizeof a->ffd.edges) == 0, "%s: edges differ", what);
    CHECK_MSG(memcmp(a->ffd.inverse, b->ffd.inverse, sizeof a->ffd.inverse) == 0, "%s: inverse differs", what);
    CHECK_MSG(memcmp(a->ffd.control, b->ffd.control, used * sizeof a->ffd.control[0]) == 0,
              "%s: control points differ", what);
    CHECK_MSG(memcmp(a->grid, b->grid, sizeof a->grid) == 0, "%s: grid differs", what);
    for (k = 0; k < sizeof where / sizeof where[0]; k++) {
        double p[3], q[3];
        sqffd_model_point(a, where[k][0], where[k][1], p);
        sqffd_model_point(b, where[k][0], where[k][1], q);
        CHECK_MSG(memcmp(p, q, sizeof p) == 0, "%s: model point %d differs", what, (int)k);
    }
}

/* A fitted model written and read back is the same model to the bit; the
   report's figures are in the file. */
static void test_export_json_round_trip(void)
{
    const char *path = temp_path("model.json");
    char err[256] = "", *text, expect[128];
    size_t size;
    sqffd_model back;
    FILE *f;
    if (!fit_phantom()) return;
    CHECK(fitted_report.history_count > 0 && fitted_model.ffd.dims[0] == 5);
    CHECK_MSG(sqffd_export_model_json(path, &fitted_model, &fitted_report, err, sizeof err) == 0, "%s", err);
    memset(&back, 0xff, sizeof back);
    CHECK_MSG(sqffd_export_read_model_json_file(path, &back, err, sizeof err) == 0, "%s", err);
    check_same_model(&fitted_model, &back, "path form");
    text = load(path, &size);
    CHECK(text != NULL);
    if (text) {
        CHECK(strstr(text, "\"format\": \"sqffd-model\"") && strstr(text, "\"version\": 1,"));
        CHECK(strstr(text, "\"library_version\": \"" SQFFD_VERSION_STRING "\""));
        snprintf(expect, sizeof expect, "\"iterations\": %d,", fitted_report.iterations);
        CHECK(strstr(text, expect) != NULL);
        snprintf(expect, sizeof expect, "\"rms_relative\": %.17g,", fitted_report.error.rms_relative);
        CHECK(strstr(text, expect) != NULL);
        CHECK(strstr(text, fitted_report.converged ? "\"converged\": true" : "\"converged\": false") != NULL);
        /* "[" then 125 control points of 3 numbers, each on its line */
        CHECK(count_of(text, "\n      [") == 125);
    }
    free(text);
    remove(path);

    /* the stream form, without a report: no "fit" member, the same model */
    f = tmpfile();
    CHECK(f != NULL);
    if (!f) return;
    CHECK(sqffd_export_model_json_stream(f, "memory", &fitted_model, NULL, err, sizeof err) == 0);
    text = load_stream(f, &size);
    fclose(f);
    CHECK(text && strstr(text, "\"fit\"") == NULL);
    memset(&back, 0, sizeof back);
    CHECK_MSG(text && sqffd_export_read_model_json(text, size, "memory", &back, err, sizeof err) == 0, "%s", err);
    check_same_model(&fitted_model, &back, "stream form");
    free(text);
}

/* A copy of text with the first `old` replaced by `with` (NULL if absent). */
static char *replaced(const char *text, const char *old, const char *with)
{
    const char *at = strstr(text, old);
    size_t n = strlen(text), a, b = strlen(with);
    char *out;
    if (!at) return NULL;
    a = (size_t)(at - text);
    out = (char *)malloc(n - strlen(old) + b + 1);
    memcpy(out, text, a);
    memcpy(out + a, with, b);
    strcpy(out + a + b, at + strlen(old));
    return out;
}

/* Malformed and invalid files: each gives its message, and the model
   passed in is left as it was. */
static void test_export_json_malformed(void)
{
    static const struct {
        const char *old, *with, *message;
    } edits[] = {
        {"\"dims\": [5, 5, 5]", "\"dims\": \"5x5x5\"", "ffd.dims: expected an array of 3 numbers, found a string"},
        {"\"dims\": [5, 5, 5]", "\"dims\": [9, 5, 5]", "ffd.dims[0] = 9 is outside 2..8"},
        {"\"dims\": [5, 5, 5]", "\"dims\": [5, 5.5, 5]", "ffd.dims[1] = 5.5 is not an integer"},
        {"\"dims\": [5, 5, 5]", "\"dims\": [4, 5, 5]", "ffd.control: expected an array of 100 control points"},
        {"\"version\": 1", "\"version\": 2", "version 2 is not supported"},
        {"\"version\": 1", "\"version\": \"1\"", "version: expected a number, found a string"},
        {"\"format\": \"sqffd-model\"", "\"format\": \"other\"", "not an sqffd model"},
        {"\"grid\": [", "\"grud\": [", "missing \"grid\""},
        {"\"shape\": [", "\"shade\": [", "missing \"superquadric.shape\""},
        {"\"size\": [", "\"size\": [-1, 1, 1], \"x\": [", "superquadric.size[0] = -1 is not positive"},
        {"\"shape\": [", "\"shape\": [1, 0], \"x\": [", "superquadric.shape[1] = 0 is not positive"},
        {"\"taper\": [", "\"taper\": [1.5, 0], \"x\": [", "superquadric.taper[0] = 1.5 is outside (-1, 1)"},
        {"\"rotation\": [", "\"rotation\": [2, 0, 0, 0, 1, 0, 0, 0, 1], \"x\": [",
         "superquadric.rotation is not a rotation"},
        {"\"rotation\": [", "\"rotation\": [1, 0, 0, 0, 1, 0, 0, 0, -1], \"x\": [",
         "superquadric.rotation is not a rotation"},
        {"\"center\": [", "\"center\": [1, 2, 3, ", "superquadric.center: expected 3 numbers, found 6 values"},
        {"\"center\": [", "\"center\": [tru, ", "expected a value, found 'tru'"},
        {"\"center\": [", "\"center\": [0 0, ", "expected ',' or ']' in an array, found '0'"},
        {"\"center\": [", "\"center\": [null, 0, 0], \"x\": [", "superquadric.center[0]: expected a number, found null"},
        {"\"edges\": [", "\"edges\": [0, 0, 0, 0, 0, 0, 0, 0, 0], \"x\": [", "ffd.edges: the box is flat"},
        {"\"origin\": [", "\"origin\": [1e200, 0, 0], \"x\": [", "the model: superquadric, lattice or model out of range"},
        {"\"grid\": [", "\"grid\": [1, 2], \"grid\": [", "\"grid\" appears twice"},
        {"\"ffd\": {", "\"ffd\": [], \"x\": {", "ffd: expected an object, found an array"},
        {"\"origin\": [", "\"origin\": [1, ", "expected 3 numbers, found 4"},
        {"\"origin\": [", "\"origin\": [01, ", "invalid number '01'"},
        {"\"origin\": [", "\"origin\": [1., ", "digits must follow the point"},
        {"\"origin\": [", "\"origin\": [1e, ", "digits must follow the exponent"},
        {"\"origin\": [", "\"origin\": [-, ", "invalid number"},
        {"\"origin\": [", "\"origin\": [NaN, ", "expected a value, found 'NaN'"},
        {"\"origin\": [", "\"origin\": [Infinity, ", "expected a value, found 'Infinity'"},
        {"\"origin\": [", "\"origin\": [1e999, ", "number '1e999' is out of range"},
        {"\"origin\": [", "\"origin\": [0x10, ", "invalid number '0x10'"},
        {"\"origin\": [", "\"origin\": [truex, ", "expected a value, found 'truex'"},
        {"\"origin\": [", "\"origin\": [1, , ", "expected a value, found ','"},
        {"\"grid\": [32, 64]", "\"grid\": [32, 64, ]", "expected a value, found ']'"},
        {"\"grid\": [32, 64]", "\"grid\": [32, 64], }", "expected a member name in quotes, found '}'"},
        {"\"grid\"", "\"grid\\x\"", "invalid escape '\\x'"},
        {"\"grid\"", "\"grid\\u12\"", "\\u must be followed by 4 hexadecimal digits"},
        {"\"grid\"", "\"gr\tid\"", "control character (code 9) in a string"},
        {"\"grid\"", "\"gr\xc3(id\"", "invalid UTF-8 in a string"},
        {"\"grid\"", "\"gr\xffid\"", "invalid UTF-8 in a string"},
        {"\"grid\": ", "\"grid\" ", "expected ':' after the member name, found '['"},
        {"\"grid\": ", "grid: ", "expected a member name in quotes, found 'grid'"},
        {"\"grid\": [32, 64]", "\"grid\": [32, 64]}", "text after the end of the JSON value: ','"},
    };
    char err[256], *text;
    size_t size, k;
    sqffd_model back, untouched;
    FILE *f = tmpfile();
    if (!fit_phantom() || !f) return;
    CHECK(sqffd_export_model_json_stream(f, "memory", &fitted_model, &fitted_report, err, sizeof err) == 0);
    text = load_stream(f, &size);
    fclose(f);
    if (!text) return;
    memset(&untouched, 0x5a, sizeof untouched);
    for (k = 0; k < sizeof edits / sizeof edits[0]; k++) {
        char *bad = replaced(text, edits[k].old, edits[k].with);
        CHECK_MSG(bad != NULL, "edit %d: '%s' not in the file", (int)k, edits[k].old);
        if (!bad) continue;
        back = untouched;
        err[0] = '\0';
        CHECK_MSG(sqffd_export_read_model_json(bad, strlen(bad), "bad.json", &back, err, sizeof err) == 1,
                  "edit %d ('%s') was accepted", (int)k, edits[k].with);
        CHECK_MSG(starts_with(err, "bad.json: ") && strstr(err, edits[k].message) != NULL,
                  "edit %d: message '%s' lacks '%s'", (int)k, err, edits[k].message);
        CHECK(memcmp(&back, &untouched, sizeof back) == 0);
        free(bad);
    }

    /* truncated after a comma: the message points at the end of the text */
    for (k = size / 2; k > 0 && text[k - 1] != ','; k--) continue;
    err[0] = '\0';
    CHECK(sqffd_export_read_model_json(text, k, "half.json", &back, err, sizeof err) == 1);
    CHECK_MSG(starts_with(err, "half.json: line ") && strstr(err, "expected a value, found the end of the text"), "%s",
              err);
    err[0] = '\0';
    CHECK(sqffd_export_read_model_json(text, 0, "empty.json", &back, err, sizeof err) == 1);
    CHECK_MSG(strcmp(err, "empty.json: line 1, column 1: expected a value, found the end of the text") == 0, "%s", err);
    err[0] = '\0';
    CHECK(sqffd_export_read_model_json("{\"format\": \"sqf", 15, "cut.json", &back, err, sizeof err) == 1);
    CHECK_MSG(strcmp(err, "cut.json: line 1, column 12: the text ends inside this string") == 0, "%s", err);
    err[0] = '\0';
    CHECK(sqffd_export_read_model_json("[1, 2]", 6, "array.json", &back, err, sizeof err) == 1);
    CHECK_MSG(strstr(err, "the top level is an array, not an object") != NULL, "%s", err);

    /* nested 1000 deep: refused at the depth limit, inside a valid file too */
    {
        char *deep = (char *)malloc(2100), *inside;
        int d;
        for (d = 0; d < 1000; d++) {
            deep[d] = '[';
            deep[1000 + d] = ']';
        }
        deep[2000] = '\0';
        err[0] = '\0';
        CHECK(sqffd_export_read_model_json(deep, 2000, "deep.json", &back, err, sizeof err) == 1);
        CHECK_MSG(strcmp(err, "deep.json: line 1, column 33: nested deeper than 32 levels") == 0, "%s", err);
        /* the file with a member "deep" added last: the text less its final "\n}\n", then the member */
        inside = (char *)malloc(size + 2100);
        memcpy(inside, text, size - 3);
        strcpy(inside + size - 3, ", \"deep\": ");
        strcat(inside, deep);
        strcat(inside, "\n}\n");
        err[0] = '\0';
        CHECK(sqffd_export_read_model_json(inside, strlen(inside), "deep.json", &back, err, sizeof err) == 1);
        CHECK_MSG(strstr(err, "nested deeper than 32 levels") != NULL, "%s", err);
        deep[999] = '1'; /* 999 levels holding a number: still too deep */
        err[0] = '\0';
        CHECK(sqffd_export_read_model_json(deep, 2000, "deep.json", &back, err, sizeof err) == 1);
        CHECK_MSG(strstr(err, "nested deeper than 32 levels") != NULL, "%s", err);
        free(inside);
        free(deep);
    }
    /* more values than any model file holds: refused before the tree grows large */
    {
        /* "[0,0,...,0]" with 2^20 + 1 zeros: 2 (2^20 + 1) + 1 characters */
        size_t values = ((size_t)1 << 20) + 1, n = 2 * values + 1, i;
        char *many = (char *)malloc(n);
        many[0] = '[';
        for (i = 0; i < values; i++) {
            many[1 + 2 * i] = '0';
            many[2 + 2 * i] = i + 1 < values ? ',' : ']';
        }
        err[0] = '\0';
        CHECK(sqffd_export_read_model_json(many, n, "many.json", &back, err, sizeof err) == 1);
        CHECK_MSG(strstr(err, "more than 1048576 values") != NULL, "%s", err);
        free(many);
    }
    free(text);
}

/* What the reader accepts beyond the writer's own output: unknown members
   anywhere, escaped member names, other blanks, a byte order mark; and no
   input crashes it (every truncation, deterministic byte changes: run under
   the sanitizers by make test). */
static void test_export_json_lenient_and_robust(void)
{
    static const char pool[] = "{}[]\",:-.0e19tfnu\\ \xff\x01";
    char err[256], *text, *a, *b;
    size_t size, k;
    sqffd_model back;
    uint64_t state = 12345;
    FILE *f = tmpfile();
    if (!fit_phantom() || !f) return;
    CHECK(sqffd_export_model_json_stream(f, "memory", &fitted_model, &fitted_report, err, sizeof err) == 0);
    text = load_stream(f, &size);
    fclose(f);
    if (!text) return;
    a = replaced(text, "\"grid\"", "\"comment\": {\"list\": [1, -2.5e-3, {\"x\": null}, true, false, \"\\u00e9\\n\"]},\r\n\t\"\\u0067rid\"");
    /* and a byte order mark first */
    b = a ? (char *)malloc(strlen(a) + 4) : NULL;
    if (b) {
        strcpy(b, "\xef\xbb\xbf");
        strcat(b, a);
        memset(&back, 0, sizeof back);
        CHECK_MSG(sqffd_export_read_model_json(b, strlen(b), "extra.json", &back, err, sizeof err) == 0, "%s", err);
        check_same_model(&fitted_model, &back, "with unknown members");
    }
    CHECK(a != NULL);
    free(a);
    free(b);

    for (k = 0; k < size; k += 37) {
        err[0] = '\0';
        CHECK(sqffd_export_read_model_json(text, k, "cut.json", &back, err, sizeof err) == 1);
        CHECK(starts_with(err, "cut.json: "));
    }
    for (k = 0; k < 400; k++) {
        char *copy = (char *)malloc(size);
        int changes = 1 + (int)(k % 3), i, r;
        memcpy(copy, text, size);
        for (i = 0; i < changes; i++) {
            size_t at;
            state = state * 6364136223846793005ull + 1442695040888963407ull;
            at = (size_t)(state >> 33) % size;
            copy[at] = pool[(state >> 20) % (sizeof pool - 1)];
        }
        err[0] = '\0';
        r = sqffd_export_read_model_json(copy, size, "mutant.json", &back, err, sizeof err);
        CHECK(r == 0 || (r == 1 && starts_with(err, "mutant.json: ")));
        free(copy);
    }
    free(text);
}

/* NaN and infinities are refused (JSON has none) and create no file; so
   are lattices the reader would refuse. */
static void test_export_json_refusals(void)
{
    const char *path = temp_path("refused.json");
    char err[256];
    sqffd_model m;
    sqffd_fit_report rep;
    if (!fit_phantom()) return;
    m = fitted_model;
    m.sq.center[1] = NAN;
    err[0] = '\0';
    CHECK(sqffd_export_model_json(path, &m, NULL, err, sizeof err) == 1);
    CHECK_MSG(starts_with(err, path) && strstr(err, "superquadric.center: value 1 is nan, which JSON cannot hold"), "%s", err);
    CHECK(!file_exists(path));
    m = fitted_model;
    m.ffd.control[124][2] = INFINITY;
    err[0] = '\0';
    CHECK(sqffd_export_model_json(path, &m, NULL, err, sizeof err) == 1);
    CHECK_MSG(strstr(err, "ffd.control: value 374 is inf") != NULL, "%s", err);
    rep = fitted_report;
    rep.history[0] = NAN;
    err[0] = '\0';
    CHECK(sqffd_export_model_json(path, &fitted_model, &rep, err, sizeof err) == 1);
    CHECK_MSG(strstr(err, "fit.history: value 0 is nan") != NULL, "%s", err);
    rep = fitted_report;
    rep.error.diagonal = -INFINITY;
    err[0] = '\0';
    CHECK(sqffd_export_model_json(path, &fitted_model, &rep, err, sizeof err) == 1);
    CHECK_MSG(strstr(err, "fit.error: value 6 is -inf") != NULL, "%s", err);
    m = fitted_model;
    m.ffd.dims[2] = SQFFD_MAX_LATTICE + 1;
    err[0] = '\0';
    CHECK(sqffd_export_model_json(path, &m, NULL, err, sizeof err) == 1);
    CHECK_MSG(strstr(err, "ffd.dims[2] = 9 is outside 2..8") != NULL, "%s", err);
    CHECK(!file_exists(path));
    if (file_exists("/dev/full")) {
        err[0] = '\0';
        CHECK(sqffd_export_model_json("/dev/full", &fitted_model, &fitted_report, err, sizeof err) == 1);
        CHECK_MSG(starts_with(err, "/dev/full: write error"), "%s", err);
    }
}

/* ---- SVG: a well-formedness checker and lookups --------------------------- */

static int name_char(char c, int first)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_' || c == ':' ||
           (!first && ((c >= '0' && c <= '9') || c == '-' || c == '.'));
}

/* An entity reference at s ('&'): its length, or 0 if it is not one XML knows. */
static size_t entity(const char *s)
{
    static const char *const named[] = {"&amp;", "&lt;", "&gt;", "&quot;", "&apos;"};
    size_t k, n = 2;
    for (k = 0; k < 5; k++)
        if (starts_with(s, named[k])) return strlen(named[k]);
    if (s[1] != '#') return 0;
    while ((s[n] >= '0' && s[n] <= '9') || s[n] == 'x') n++;
    return n > 2 && s[n] == ';' ? n + 1 : 0;
}

/* NULL when text is well-formed XML as a writer of SVG needs it (prolog,
   one root element, tags nested and closed in order, attributes quoted and
   unique per tag, '&' only in entities, no '<' in values), else what is
   wrong. */
static const char *xml_check(const char *s)
{
    char stack[32][32];
    int depth = 0, roots = 0;
    if (starts_with(s, "<?xml")) {
        s = strstr(s, "?>");
        if (!s) return "unterminated prolog";
        s += 2;
    }
    while (*s) {
        if (*s == '&') {
            if (!entity(s)) return "bare '&' in text";
            s++;
        } else if (*s != '<') {
            if (depth == 0 && !(*s == ' ' || *s == '\n')) return "text outside the root element";
            s++;
        } else if (starts_with(s, "<!--")) {
            s = strstr(s, "-->");
            if (!s) return "unterminated comment";
            s += 3;
        } else if (s[1] == '/') {
            size_t n = 0;
            s += 2;
            while (name_char(s[n], n == 0)) n++;
            if (depth == 0 || n != strlen(stack[depth - 1]) || strncmp(s, stack[depth - 1], n) != 0)
                return "closing tag does not match the open one";
            depth--;
            s += n;
            if (*s != '>') return "junk in a closing tag";
            s++;
        } else {
            char names[32][32];
            int attrs = 0, k;
            size_t n = 0;
            s++;
            while (name_char(s[n], n == 0)) n++;
            if (n == 0 || n >= 32) return "bad element name";
            if (depth == 0 && roots++) return "more than one root element";
            if (depth == 32) return "too deep";
            memcpy(stack[depth], s, n);
            stack[depth][n] = '\0';
            s += n;
            for (;;) {
                char quote;
                size_t m = 0;
                if (*s != ' ' && *s != '/' && *s != '>') return "attributes must be separated by a blank";
                while (*s == ' ' || *s == '\n') s++;
                if (*s == '/') {
                    if (s[1] != '>') return "'/' not followed by '>'";
                    s += 2;
                    break;
                }
                if (*s == '>') {
                    depth++;
                    s++;
                    break;
                }
                while (name_char(s[m], m == 0)) m++;
                if (m == 0 || m >= 32 || attrs == 32) return "bad attribute name";
                memcpy(names[attrs], s, m);
                names[attrs][m] = '\0';
                for (k = 0; k < attrs; k++)
                    if (strcmp(names[k], names[attrs]) == 0) return "attribute repeated in a tag";
                attrs++;
                s += m;
                if (*s++ != '=') return "attribute without '='";
                quote = *s++;
                if (quote != '"' && quote != '\'') return "attribute value not quoted";
                while (*s && *s != quote) {
                    if (*s == '<') return "'<' in an attribute value";
                    if (*s == '&' && !entity(s)) return "bare '&' in an attribute value";
                    s++;
                }
                if (!*s) return "unterminated attribute value";
                s++;
            }
        }
    }
    if (depth != 0) return "an element is not closed";
    if (roots != 1) return "no root element";
    return NULL;
}

/* The tag (from its '<') that holds the attribute text `needle`, e.g. id="x". */
static const char *tag_with(const char *text, const char *needle)
{
    const char *at = strstr(text, needle);
    if (!at) return NULL;
    while (at > text && *at != '<') at--;
    return at;
}

/* The value of attribute `name` of the tag at `tag`, into out; 0 if absent. */
static int attribute(const char *tag, const char *name, char *out, size_t size)
{
    const char *end = strchr(tag, '>'), *at = tag;
    size_t n = strlen(name), len;
    while ((at = strstr(at, name)) != NULL && at < end) {
        if (at[-1] == ' ' && at[n] == '=' && at[n + 1] == '"') {
            const char *close = strchr(at + n + 2, '"');
            len = (size_t)(close - (at + n + 2));
            if (len >= size) len = size - 1;
            memcpy(out, at + n + 2, len);
            out[len] = '\0';
            return 1;
        }
        at += n;
    }
    return 0;
}

static double number_attribute(const char *tag, const char *name)
{
    char v[64];
    return tag && attribute(tag, name, v, sizeof v) ? atof(v) : NAN;
}

/* The texts of the <text class="CLASS"> elements in order, markup inside
   removed ("10<tspan ...>-6</tspan>" gives "10-6"), joined by '|'. */
static void texts_of_class(const char *svg, const char *cls, char *out, size_t size)
{
    char needle[64];
    const char *at = svg;
    size_t n = 0;
    snprintf(needle, sizeof needle, "<text class=\"%s\"", cls);
    out[0] = '\0';
    while ((at = strstr(at, needle)) != NULL) {
        const char *p = strchr(at, '>') + 1, *end = strstr(p, "</text>");
        int in_tag = 0;
        if (n && n + 1 < size) out[n++] = '|';
        for (; p < end && n + 1 < size; p++) {
            if (*p == '<') in_tag = 1;
            else if (*p == '>') in_tag = 0;
            else if (!in_tag) out[n++] = *p;
        }
        out[n] = '\0';
        at = end;
    }
}

/* The plot area from the frame rectangle. */
typedef struct frame {
    double x, y, w, h;
} frame;

static frame plot_frame(const char *svg)
{
    const char *tag = tag_with(svg, "class=\"frame\"");
    frame f;
    f.x = number_attribute(tag, "x");
    f.y = number_attribute(tag, "y");
    f.w = number_attribute(tag, "width");
    f.h = number_attribute(tag, "height");
    return f;
}

/* The points of series k's polyline (at most max). */
static size_t polyline_points(const char *svg, int k, double *px, double *py, size_t max)
{
    char id[32], *points = (char *)malloc(65536), *p;
    const char *group, *line;
    size_t n = 0;
    snprintf(id, sizeof id, "id=\"series-%d\"", k);
    group = strstr(svg, id);
    line = group ? strstr(group, "<polyline") : NULL;
    if (line && attribute(line, "points", points, 65536))
        for (p = points; n < max && sscanf(p, "%lf,%lf", &px[n], &py[n]) == 2; n++) {
            p = strchr(p, ' ');
            if (!p) {
                n++;
                break;
            }
            p++;
        }
    free(points);
    return n;
}

/* ---- SVG plots ------------------------------------------------------------- */

/* The generic plot: well-formed; axes with the 1-2-5 ticks worked out by
   hand; every point where the axes put it (read back through the frame
   and the hand-made axis ends); legend, markers, escaped title. */
static void test_export_svg_plot(void)
{
    const char *path = temp_path("plot.svg");
    double x[10], y1[10], y2[10], px[16], py[16];
    sqffd_export_series s[2];
    char err[256] = "", labels[256], *svg;
    const char *problem;
    size_t size, n, i;
    frame fr;
    for (i = 0; i < 10; i++) {
        x[i] = (double)i;
        y1[i] = 2.0 * i + 1.0;
        y2[i] = 0.5 * i + 3.0;
    }
    s[0].name = "2x + 1";
    s[0].x = x;
    s[0].y = y1;
    s[0].count = 10;
    s[1].name = "x/2 + 3";
    s[1].x = NULL; /* 0, 1, 2, ... */
    s[1].y = y2;
    s[1].count = 10;
    CHECK_MSG(sqffd_export_svg_plot(path, "Lines <a & b>", "x", "y", s, 2, NULL, 0, 0, err, sizeof err) == 0, "%s", err);
    svg = load(path, &size);
    if (!svg) {
        CHECK(svg != NULL);
        return;
    }
    problem = xml_check(svg);
    CHECK_MSG(problem == NULL, "not well-formed: %s", problem);
    CHECK(strstr(svg, "viewBox=\"0 0 640 400\"") && strstr(svg, "sans-serif") && !strstr(svg, "<script"));
    CHECK(strstr(svg, "<title>Lines &lt;a &amp; b&gt;</title>") != NULL);
    CHECK(count_of(svg, "<polyline") == 2);
    CHECK(count_of(svg, "<circle") == 10 + 1); /* series 1's markers and its legend entry */
    CHECK(strstr(svg, ">2x + 1</text>") && strstr(svg, ">x/2 + 3</text>"));
    /* x in [0, 9]: a fifth is 1.8, step 2, ends 0 and 10; y in [1, 19]: 3.6, step 5, ends 0 and 20 */
    texts_of_class(svg, "tick-x", labels, sizeof labels);
    CHECK_MSG(strcmp(labels, "0|2|4|6|8|10") == 0, "x ticks %s", labels);
    texts_of_class(svg, "tick-y", labels, sizeof labels);
    CHECK_MSG(strcmp(labels, "0|5|10|15|20") == 0, "y ticks %s", labels);
    fr = plot_frame(svg);
    CHECK(fr.w > 300 && fr.h > 200 && fr.x >= 0 && fr.y >= 0 && fr.x + fr.w <= 640 && fr.y + fr.h <= 400);
    n = polyline_points(svg, 1, px, py, 16);
    CHECK(n == 10);
    for (i = 0; i < n; i++) {
        CHECK_NEAR(10.0 * (px[i] - fr.x) / fr.w, x[i], 0.01);
        CHECK_NEAR(20.0 * (fr.y + fr.h - py[i]) / fr.h, y1[i], 0.02);
    }
    n = polyline_points(svg, 2, px, py, 16);
    CHECK(n == 10);
    for (i = 0; i < n; i++) CHECK_NEAR(20.0 * (fr.y + fr.h - py[i]) / fr.h, y2[i], 0.02);
    free(svg);
    remove(path);

    /* a log y axis: 10^(x/3) for x in 0..9 runs over decades 0..3, a straight line */
    for (i = 0; i < 10; i++) y1[i] = pow(10.0, x[i] / 3.0);
    CHECK_MSG(sqffd_export_svg_plot(path, NULL, NULL, NULL, s, 1, NULL, 0, SQFFD_EXPORT_LOG_Y, err, sizeof err) == 0,
              "%s", err);
    svg = load(path, &size);
    if (!svg) return;
    CHECK(xml_check(svg) == NULL);
    texts_of_class(svg, "tick-y", labels, sizeof labels);
    CHECK_MSG(strcmp(labels, "1|10|100|1000") == 0, "log y ticks %s", labels);
    fr = plot_frame(svg);
    n = polyline_points(svg, 1, px, py, 16);
    CHECK(n == 10);
    for (i = 0; i < n; i++) CHECK_NEAR(3.0 * (fr.y + fr.h - py[i]) / fr.h, x[i] / 3.0, 0.01);
    free(svg);
    remove(path);
}

/* Bad data are refused with the file name and no file: NaN, a value <= 0
   on a log axis, nothing to plot; a full disk is a write error. */
static void test_export_svg_plot_refusals(void)
{
    const char *path = temp_path("refused.svg");
    double y[3] = {1.0, NAN, 3.0};
    sqffd_export_series s;
    char err[256];
    s.name = "s";
    s.x = NULL;
    s.y = y;
    s.count = 3;
    err[0] = '\0';
    CHECK(sqffd_export_svg_plot(path, NULL, NULL, NULL, &s, 1, NULL, 0, 0, err, sizeof err) == 1);
    CHECK_MSG(starts_with(err, path) && strstr(err, "series 0 's', point 1: (1, nan) is not finite"), "%s", err);
    y[1] = 2.0;
    err[0] = '\0';
    CHECK(sqffd_export_svg_plot(path, NULL, NULL, NULL, &s, 1, NULL, 0, SQFFD_EXPORT_LOG_X, err, sizeof err) == 1);
    CHECK_MSG(strstr(err, "point 0: (0, 1) cannot go on a log axis") != NULL, "%s", err);
    err[0] = '\0';
    CHECK(sqffd_export_svg_plot(path, NULL, NULL, NULL, &s, 0, NULL, 0, 0, err, sizeof err) == 1);
    CHECK_MSG(strstr(err, "no series") != NULL, "%s", err);
    s.count = 0;
    err[0] = '\0';
    CHECK(sqffd_export_svg_plot(path, NULL, NULL, NULL, &s, 1, NULL, 0, 0, err, sizeof err) == 1);
    CHECK_MSG(strstr(err, "no points") != NULL, "%s", err);
    s.count = 3;
    y[1] = 2e300;
    err[0] = '\0';
    CHECK(sqffd_export_svg_plot(path, NULL, NULL, NULL, &s, 1, NULL, 0, 0, err, sizeof err) == 1);
    CHECK_MSG(strstr(err, "point 1: (1, 2e+300) is beyond what a plot shows") != NULL, "%s", err);
    y[1] = 1e-310;
    err[0] = '\0';
    CHECK(sqffd_export_svg_plot(path, NULL, NULL, NULL, &s, 1, NULL, 0, SQFFD_EXPORT_LOG_Y, err, sizeof err) == 1);
    CHECK_MSG(strstr(err, "is beyond what a plot shows") != NULL, "%s", err);
    CHECK(!file_exists(path));
    y[1] = 2.0;
    if (file_exists("/dev/full")) {
        err[0] = '\0';
        CHECK(sqffd_export_svg_plot("/dev/full", NULL, NULL, NULL, &s, 1, NULL, 0, 0, err, sizeof err) == 1);
        CHECK_MSG(starts_with(err, "/dev/full: write error"), "%s", err);
    }
}

/* Degenerate and extreme data still make a finite, well-formed plot (and
   the tick search ends): one point, a constant, a span at the last digits
   of a double, values near +-1e300, a single value on a log axis. A
   constant 5 gets +-10%: 4.5..5.5, a seventh 0.14, step 0.2, ends 4.4, 5.6. */
static void test_export_svg_plot_extremes(void)
{
    static const double cases[][3] = {
        {5.0, 5.0, 5.0}, {0.0, 0.0, 0.0}, {1.0, 1.0 + 2.2e-16, 1.0}, {-1e300, 1e300, 0.0},
        {1e300, 1e300, 1e300}, {1e-300, 2e-300, 1e-300}, {10.0, 10.0, 10.0}, {1e-300, 1e300, 1.0},
    };
    size_t c, size;
    for (c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        int log_y, count;
        for (log_y = 0; log_y < 2; log_y++)
            for (count = 1; count <= 3; count += 2) {
                sqffd_export_series s;
                char err[256] = "", *svg;
                FILE *f;
                int positive = cases[c][0] > 0.0 && (count == 1 || (cases[c][1] > 0.0 && cases[c][2] > 0.0));
                if (log_y && !positive) continue;
                f = tmpfile();
                if (!f) return;
                s.name = "s";
                s.x = NULL;
                s.y = cases[c];
                s.count = (size_t)count;
                CHECK_MSG(sqffd_export_svg_plot_stream(f, "memory", "t", "x", "y", &s, 1, NULL, 0,
                                                       log_y ? SQFFD_EXPORT_LOG_Y : 0, err, sizeof err) == 0,
                          "case %d: %s", (int)c, err);
                svg = load_stream(f, &size);
                fclose(f);
                if (!svg) continue;
                CHECK_MSG(xml_check(svg) == NULL, "case %d log %d count %d: %s", (int)c, log_y, count, xml_check(svg));
                CHECK_MSG(!strstr(svg, "nan") && !strstr(svg, "inf"), "case %d log %d count %d: a non-finite coordinate",
                          (int)c, log_y, count);
                if (c == 0 && !log_y) {
                    char labels[256];
                    texts_of_class(svg, "tick-y", labels, sizeof labels);
                    CHECK_MSG(strcmp(labels, "4.4|4.6|4.8|5.0|5.2|5.4|5.6") == 0, "constant: %s", labels);
                }
                free(svg);
            }
    }
}

/* The three wrappers: the history from iteration 0 (the superquadric's
   error) in %, alpha sorted on a log axis, the volume curve with ED and ES
   marked where they are. */
static void test_export_svg_wrappers(void)
{
    const char *path = temp_path("wrapper.svg");
    static const double alpha[4] = {1e-3, 1e-6, 1e-5, 1e-4}, error[4] = {0.03, 0.01, 0.015, 0.02};
    static const double sorted_error[4] = {1.0, 1.5, 2.0, 3.0}; /* % */
    double px[16], py[16], volumes[10];
    sqffd_fit_report rep;
    sqffd_motion_report motion;
    char err[256] = "", labels[256], *svg;
    const char *mark;
    size_t size, n, i;
    frame fr;

    memset(&rep, 0, sizeof rep);
    rep.sq_error.rms_relative = 0.1;
    rep.history[0] = 0.05;
    rep.history[1] = 0.03;
    rep.history[2] = 0.025;
    rep.history[3] = 0.024;
    rep.history_count = 4;
    CHECK_MSG(sqffd_export_svg_history(path, &rep, NULL, err, sizeof err) == 0, "%s", err);
    svg = load(path, &size);
    if (!svg) return;
    CHECK(xml_check(svg) == NULL && strstr(svg, "Error per iteration"));
    /* x 0..4: step 1; y 2.4..10 (%): a fifth 1.52, step 2, ends 2 and 10 */
    texts_of_class(svg, "tick-x", labels, sizeof labels);
    CHECK_MSG(strcmp(labels, "0|1|2|3|4") == 0, "%s", labels);
    texts_of_class(svg, "tick-y", labels, sizeof labels);
    CHECK_MSG(strcmp(labels, "2|4|6|8|10") == 0, "%s", labels);
    fr = plot_frame(svg);
    n = polyline_points(svg, 1, px, py, 16);
    CHECK(n == 5);
    for (i = 0; i < n; i++) {
        CHECK_NEAR(4.0 * (px[i] - fr.x) / fr.w, (double)i, 0.01);
        CHECK_NEAR(2.0 + 8.0 * (fr.y + fr.h - py[i]) / fr.h, 100.0 * (i ? rep.history[i - 1] : 0.1), 0.01);
    }
    free(svg);
    remove(path);

    CHECK_MSG(sqffd_export_svg_alpha(path, alpha, error, 4, NULL, err, sizeof err) == 0, "%s", err);
    svg = load(path, &size);
    if (!svg) return;
    CHECK(xml_check(svg) == NULL && strstr(svg, "\xce\xb1"));
    /* alpha 1e-6 .. 1e-3: decades -6..-3; error 1..3 %: step 0.5 */
    texts_of_class(svg, "tick-x", labels, sizeof labels);
    CHECK_MSG(strcmp(labels, "10-6|10-5|10-4|0.001") == 0, "%s", labels);
    texts_of_class(svg, "tick-y", labels, sizeof labels);
    CHECK_MSG(strcmp(labels, "1.0|1.5|2.0|2.5|3.0") == 0, "%s", labels);
    fr = plot_frame(svg);
    n = polyline_points(svg, 1, px, py, 16);
    CHECK(n == 4);
    for (i = 0; i < n; i++) {
        CHECK_NEAR(-6.0 + 3.0 * (px[i] - fr.x) / fr.w, -6.0 + (double)i, 0.01);
        CHECK_NEAR(1.0 + 2.0 * (fr.y + fr.h - py[i]) / fr.h, sorted_error[i], 0.01);
    }
    free(svg);
    remove(path);
    {
        double zero[2] = {0.0, 1e-4};
        err[0] = '\0';
        CHECK(sqffd_export_svg_alpha(path, zero, error, 2, NULL, err, sizeof err) == 1);
        CHECK_MSG(strstr(err, "alpha[0] = 0: the log axis needs finite alpha > 0") != NULL, "%s", err);
        CHECK(!file_exists(path));
    }

    /* volumes 100 + 40 cos(2 pi t / 10): ED frame 0 (140), ES frame 5 (60) */
    for (i = 0; i < 10; i++) volumes[i] = 100.0 + 40.0 * cos(2.0 * 3.14159265358979323846 * (double)i / 10.0);
    memset(&motion, 0, sizeof motion);
    motion.ed_frame = 0;
    motion.es_frame = 5;
    motion.edv = 140.0;
    motion.esv = 60.0;
    motion.ejection_fraction = 80.0 / 140.0;
    CHECK_MSG(sqffd_export_svg_volumes(path, volumes, 10, &motion, "ml", NULL, err, sizeof err) == 0, "%s", err);
    svg = load(path, &size);
    if (!svg) return;
    CHECK(xml_check(svg) == NULL);
    CHECK(strstr(svg, "Volume over the sequence (EF 57.1%)") && strstr(svg, ">volume (ml)</text>"));
    CHECK(strstr(svg, ">ED</text>") && strstr(svg, ">ES</text>") && count_of(svg, "<g class=\"mark\">") == 2);
    /* x 0..9: ends 0 and 10; y 60..140: a fifth 16, step 20, ends 60 and 140 */
    texts_of_class(svg, "tick-y", labels, sizeof labels);
    CHECK_MSG(strcmp(labels, "60|80|100|120|140") == 0, "%s", labels);
    fr = plot_frame(svg);
    mark = strstr(svg, "<g class=\"mark\">");
    for (i = 0; i < 2 && mark; i++) {
        const char *ring = strstr(mark, "<circle");
        size_t frame_index = i ? 5 : 0;
        CHECK_NEAR(10.0 * (number_attribute(ring, "cx") - fr.x) / fr.w, (double)frame_index, 0.01);
        CHECK_NEAR(60.0 + 80.0 * (fr.y + fr.h - number_attribute(ring, "cy")) / fr.h, volumes[frame_index], 0.02);
        mark = strstr(mark + 1, "<g class=\"mark\">");
    }
    free(svg);
    remove(path);
    motion.es_frame = 10;
    err[0] = '\0';
    CHECK(sqffd_export_svg_volumes(path, volumes, 10, &motion, NULL, NULL, err, sizeof err) == 1);
    CHECK_MSG(strstr(err, "ES frame 10 is not one of the 10 frames") != NULL, "%s", err);
    CHECK(!file_exists(path));
}

/* ---- the bull's-eye -------------------------------------------------------- */

/* Segment k's path: its outer arc's end points (or the disc's two half
   circles' ends for 17), its outer and inner radius as written. */
typedef struct sector {
    double x0, y0, x1, y1, x2, y2, x3, y3, r_outer, r_inner;
    char fill[16], cls[64];
} sector;

static int read_sector(const char *svg, int k, sector *s)
{
    char id[32], d[512];
    const char *tag;
    double ry;
    int a, b, c, e, g, h;
    snprintf(id, sizeof id, "id=\"segment-%d\"", k);
    tag = tag_with(svg, id);
    memset(s, 0, sizeof *s);
    if (!tag || !attribute(tag, "d", d, sizeof d) || !attribute(tag, "fill", s->fill, sizeof s->fill) ||
        !attribute(tag, "class", s->cls, sizeof s->cls))
        return 0;
    if (k == 17)
        return sscanf(d, "M %lf %lf A %lf %lf %d %d %d %lf %lf A %lf %lf %d %d %d %lf %lf Z", &s->x0, &s->y0, &s->r_outer,
                      &ry, &a, &b, &c, &s->x1, &s->y1, &s->r_inner, &ry, &e, &g, &h, &s->x2, &s->y2) == 16;
    return sscanf(d, "M %lf %lf A %lf %lf %d %d %d %lf %lf L %lf %lf A %lf %lf %d %d %d %lf %lf Z", &s->x0, &s->y0,
                  &s->r_outer, &ry, &a, &b, &c, &s->x1, &s->y1, &s->x2, &s->y2, &s->r_inner, &ry, &e, &g, &h, &s->x3,
                  &s->y3) == 18 &&
           a == 0 && b == 0 && c == 0 && e == 0 && g == 0 && h == 1; /* outer arc counter-clockwise on screen, inner back */
}

/* Angle of screen point (x, y) about (cx, cy): degrees counter-clockwise on
   screen from straight up (90 = left), in (-180, 180]. */
static double screen_angle(double x, double y, double cx, double cy)
{
    return atan2(-(x - cx), -(y - cy)) * 180.0 / 3.14159265358979323846;
}

static double angle_diff(double a, double b)
{
    double d = fmod(a - b + 540.0, 360.0) - 180.0;
    return fabs(d);
}

/* A motion report with displacements: segment 1 the least (1), 5 the most (8). */
static sqffd_motion_report bullseye_report(void)
{
    sqffd_motion_report m;
    int k;
    memset(&m, 0, sizeof m);
    for (k = 0; k < SQFFD_SEGMENTS; k++) {
        m.segments[k].mean_displacement = 2.0 + 0.3 * k; /* 2 .. 6.8 */
        m.segments[k].mean_excursion = 2.0;
        m.segments[k].area = 100.0;
    }
    m.segments[0].mean_displacement = 1.0;
    m.segments[4].mean_displacement = 8.0;
    m.segments[3].hypokinetic = m.segments[9].hypokinetic = m.segments[14].hypokinetic = 1;
    m.ed_frame = 0;
    m.es_frame = 7;
    m.edv = 120.0;
    m.esv = 60.0;
    m.ejection_fraction = 0.5;
    return m;
}

/* Well-formed; 17 segment paths; fills from the colour map (hand-derived
   colours); hypokinetic class and outlines; every sector where the AHA
   bull's-eye puts it: 1 and 7 at the top, 2 upper left (60 degrees
   counter-clockwise), ..., 14 (apical septal) on the left; the rings nest
   with 17 in the centre. */
static void test_export_bullseye(void)
{
    const char *path = temp_path("bullseye.svg");
    sqffd_motion_report m = bullseye_report();
    sector s[SQFFD_SEGMENTS + 1];
    char err[256] = "", *svg;
    const char *problem;
    double cx, cy, r17;
    size_t size;
    int k;
    CHECK_MSG(sqffd_export_svg_bullseye(path, &m, 0, NULL, "mm", err, sizeof err) == 0, "%s", err);
    svg = load(path, &size);
    if (!svg) {
        CHECK(svg != NULL);
        return;
    }
    problem = xml_check(svg);
    CHECK_MSG(problem == NULL, "not well-formed: %s", problem);
    CHECK(strstr(svg, "viewBox=") && !strstr(svg, "<script"));
    CHECK(count_of(svg, "id=\"segment-") == 17);
    CHECK(count_of(svg, "class=\"segment\"") == 14 && count_of(svg, "class=\"segment hypokinetic\"") == 3);
    CHECK(strstr(svg, "mean displacement (mm)") && strstr(svg, "EF 50.0%"));
    for (k = 1; k <= SQFFD_SEGMENTS; k++) {
        char label[64];
        CHECK_MSG(read_sector(svg, k, &s[k]), "segment %d: path not as expected", k);
        snprintf(label, sizeof label, ">%d</text>", k);
        CHECK_MSG(strstr(svg, label) != NULL, "segment %d: no number", k);
        snprintf(label, sizeof label, ">%.3g</text>", m.segments[k - 1].mean_displacement);
        CHECK_MSG(strstr(svg, label) != NULL, "segment %d: no value %s", k, label);
        CHECK_MSG((strstr(s[k].cls, "hypokinetic") != NULL) == (k == 4 || k == 10 || k == 15), "segment %d: class '%s'",
                  k, s[k].cls);
    }
    CHECK(count_of(svg, "class=\"hypokinetic-outline\"") == 3);
    /* the largest (8, segment 5) is the map's top colour; the smallest (1 of 8: 1/8, halfway between
       the first two control colours #440154 and #3b5289) is their mean, rounded: #402a70 */
    CHECK_MSG(strcmp(s[5].fill, "#fde725") == 0, "largest %s", s[5].fill);
    CHECK_MSG(strcmp(s[1].fill, "#402a70") == 0, "smallest %s", s[1].fill);

    /* geometry: the centre and the disc's radius from segment 17 */
    cx = 0.5 * (s[17].x0 + s[17].x1);
    cy = 0.5 * (s[17].y0 + s[17].y1);
    r17 = 0.5 * hypot(s[17].x1 - s[17].x0, s[17].y1 - s[17].y0);
    CHECK_NEAR(s[17].r_outer, r17, 1e-3);
    CHECK_NEAR(s[17].x2, s[17].x0, 1e-3); /* the second half circle closes the disc */
    for (k = 1; k <= 16; k++) {
        double a0 = screen_angle(s[k].x0, s[k].y0, cx, cy), a1 = screen_angle(s[k].x1, s[k].y1, cx, cy);
        double mid = screen_angle(0.5 * (s[k].x0 + s[k].x1), 0.5 * (s[k].y0 + s[k].y1), cx, cy);
        double expected = k <= 12 ? 60.0 * ((k - 1) % 6) : 90.0 * (k - 13);
        double span = k <= 12 ? 60.0 : 90.0;
        int ring = k <= 6 ? 4 : k <= 12 ? 3 : 2;
        CHECK_MSG(angle_diff(mid, expected) < 0.01, "segment %d centred at %.3f degrees, expected %.0f", k, mid, expected);
        CHECK_MSG(angle_diff(a1, a0) > span - 0.01 && angle_diff(a1, a0) < span + 0.01, "segment %d spans %.3f", k,
                  angle_diff(a1, a0));
        CHECK_NEAR(angle_diff(a1, expected + 0.5 * span), 0.0, 0.01); /* counter-clockwise from a0 to a1 */
        CHECK_NEAR(hypot(s[k].x0 - cx, s[k].y0 - cy), ring * r17, 1e-2);
        CHECK_NEAR(hypot(s[k].x3 - cx, s[k].y3 - cy), (ring - 1) * r17, 1e-2);
        CHECK_NEAR(s[k].r_outer, ring * r17, 1e-3);
        CHECK_NEAR(s[k].r_inner, (ring - 1) * r17, 1e-3);
    }
    /* the brief's cases in screen terms */
    CHECK(fabs(0.5 * (s[1].x0 + s[1].x1) - cx) < 1e-2 && 0.5 * (s[1].y0 + s[1].y1) < cy);   /* 1: top */
    CHECK(0.5 * (s[2].x0 + s[2].x1) < cx && 0.5 * (s[2].y0 + s[2].y1) < cy);                /* 2: upper left */
    CHECK(fabs(0.5 * (s[13].x0 + s[13].x1) - cx) < 1e-2 && 0.5 * (s[13].y0 + s[13].y1) < cy); /* 13: top */
    CHECK(0.5 * (s[14].x0 + s[14].x1) < cx && fabs(0.5 * (s[14].y0 + s[14].y1) - cy) < 1e-2); /* 14: left */
    CHECK(0.5 * (s[16].x0 + s[16].x1) > cx);                                                 /* 16: right */
    free(svg);
    remove(path);

    /* excursion: 14 the largest (3), 9 at half of it (the middle colour #21918c), 3 outward
       (-0.5: the bottom colour #440154) */
    m.segments[13].mean_excursion = 3.0;
    m.segments[8].mean_excursion = 1.5;
    m.segments[2].mean_excursion = -0.5;
    CHECK_MSG(sqffd_export_svg_bullseye(path, &m, 1, "Excursion", NULL, err, sizeof err) == 0, "%s", err);
    svg = load(path, &size);
    if (!svg) return;
    CHECK(xml_check(svg) == NULL && strstr(svg, ">Excursion</text>") && strstr(svg, ">mean inward excursion</text>"));
    CHECK(read_sector(svg, 14, &s[14]) && strcmp(s[14].fill, "#fde725") == 0);
    CHECK(read_sector(svg, 9, &s[9]) && strcmp(s[9].fill, "#21918c") == 0);
    CHECK(read_sector(svg, 3, &s[3]) && strcmp(s[3].fill, "#440154") == 0);
    CHECK(strstr(svg, ">-0.5</text>") != NULL);
    free(svg);
    remove(path);

    m.segments[6].mean_excursion = NAN;
    err[0] = '\0';
    CHECK(sqffd_export_svg_bullseye(path, &m, 1, NULL, NULL, err, sizeof err) == 1);
    CHECK_MSG(starts_with(err, path) && strstr(err, "segment 7: the mean excursion is not finite"), "%s", err);
    CHECK(!file_exists(path));
}

/* The colour map at its control points and halfway between two. */
static void test_export_colormap(void)
{
    unsigned char c[3];
    sqffd_export_colormap(0.0, c);
    CHECK(c[0] == 68 && c[1] == 1 && c[2] == 84);
    sqffd_export_colormap(-3.0, c);
    CHECK(c[0] == 68 && c[1] == 1 && c[2] == 84);
    sqffd_export_colormap(NAN, c);
    CHECK(c[0] == 68 && c[1] == 1 && c[2] == 84);
    sqffd_export_colormap(0.75, c);
    CHECK(c[0] == 94 && c[1] == 201 && c[2] == 98);
    sqffd_export_colormap(1.0, c);
    CHECK(c[0] == 253 && c[1] == 231 && c[2] == 37);
    sqffd_export_colormap(7.0, c);
    CHECK(c[0] == 253 && c[1] == 231 && c[2] == 37);
    sqffd_export_colormap(0.875, c); /* halfway between (94, 201, 98) and (253, 231, 37) */
    CHECK(c[0] == 174 && c[1] == 216 && c[2] == 68);
}

void suite_export(void)
{
    strcpy(temp_dir, "/tmp/sqffd_export_XXXXXX");
    if (!mkdtemp(temp_dir)) {
        test_fail(__FILE__, __LINE__, "mkdtemp failed");
        return;
    }
    RUN_TEST(test_export_vtk_round_trip);
    RUN_TEST(test_export_vtk_stream);
    RUN_TEST(test_export_vtk_refusals);
    RUN_TEST(test_export_json_round_trip);
    RUN_TEST(test_export_json_malformed);
    RUN_TEST(test_export_json_lenient_and_robust);
    RUN_TEST(test_export_json_refusals);
    RUN_TEST(test_export_svg_plot);
    RUN_TEST(test_export_svg_plot_refusals);
    RUN_TEST(test_export_svg_plot_extremes);
    RUN_TEST(test_export_svg_wrappers);
    RUN_TEST(test_export_bullseye);
    RUN_TEST(test_export_colormap);
    if (rmdir(temp_dir) != 0) printf("    suite_export: %s is not empty after the tests\n", temp_dir);
}

/* libFuzzer target: the bytes go to every reader of examples/sqffd_io.h
   (PLY, OFF, XYZ, OBJ, legacy VTK, STL; PCD has fuzz_pcd).
   Checks the readers' contract beyond "no crash": success means at least one
   point and finite coordinates; failure means no points and a message
   "NAME: ..."; a file of another format (sqffd_io_foreign_format) is refused
   with its own sentence. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "../examples/sqffd_io.h"

typedef int (*reader_fn)(const void *, size_t, const char *, double **, size_t *, char *, size_t);

/* The readers that also fill an sqffd_io_info, with it NULL. */
static int read_vtk(const void *d, size_t n, const char *name, double **p, size_t *c, char *err, size_t size)
{
    return sqffd_io_read_vtk(d, n, name, p, c, NULL, err, size);
}
static int read_stl(const void *d, size_t n, const char *name, double **p, size_t *c, char *err, size_t size)
{
    return sqffd_io_read_stl(d, n, name, p, c, NULL, err, size);
}

/* STL: a success holds no point twice (the merge), checked by brute force. */
static void check_stl(const uint8_t *data, size_t size)
{
    double *points = NULL;
    size_t count = 0, i, j;
    char err[256];
    if (sqffd_io_read_stl(data, size, "fuzz.stl", &points, &count, NULL, err, sizeof err) != 0) return;
    for (i = 1; i < count && i < 2000; i++) /* quadratic: the first 2000 points */
        for (j = 0; j < i; j++)
            if (points[3 * i] == points[3 * j] && points[3 * i + 1] == points[3 * j + 1] &&
                points[3 * i + 2] == points[3 * j + 2])
                abort();
    free(points);
}

static void check_reader(reader_fn read, const uint8_t *data, size_t size, const char *name)
{
    double *points = NULL;
    size_t count = 0, i;
    char err[256];
    if (read(data, size, name, &points, &count, err, sizeof err) == 0) {
        if (count == 0 || !points) abort();
        for (i = 0; i < 3 * count; i++)
            if (!isfinite(points[i])) abort();
        free(points);
    } else {
        if (points || count) abort();
        if (strncmp(err, name, strlen(name)) != 0 || strncmp(err + strlen(name), ": ", 2) != 0) abort();
    }
}

/* The OFF mesh reader: success also means at least one triangle, every
   index below the vertex count. */
static void check_mesh(const uint8_t *data, size_t size)
{
    double *vertices = NULL;
    uint32_t *triangles = NULL;
    size_t vertex_count = 0, triangle_count = 0, i;
    char err[256];
    if (sqffd_io_read_off_mesh(data, size, "fuzz.off", &vertices, &vertex_count, &triangles, &triangle_count, err,
                               sizeof err) == 0) {
        if (vertex_count == 0 || triangle_count == 0 || !vertices || !triangles) abort();
        for (i = 0; i < 3 * vertex_count; i++)
            if (!isfinite(vertices[i])) abort();
        for (i = 0; i < 3 * triangle_count; i++)
            if (triangles[i] >= vertex_count) abort();
        free(vertices);
        free(triangles);
    } else {
        if (vertices || triangles || vertex_count || triangle_count) abort();
        if (strncmp(err, "fuzz.off: ", 10) != 0) abort();
    }
}

/* A file of a format the readers do not take (DICOM, STL, ...) is refused
   with that format's sentence, whatever else it holds. */
static void check_foreign(const uint8_t *data, size_t size)
{
    const char *foreign = sqffd_io_foreign_format(data, size);
    double *points = NULL;
    size_t count = 0;
    char err[512];
    if (!foreign) return;
    if (sqffd_io_read_points(data, size, "fuzz.dat", &points, &count, err, sizeof err) == 0 ||
        strncmp(err, "fuzz.dat: ", 10) != 0 || strcmp(err + 10, foreign) != 0)
        abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    check_reader(sqffd_io_read_points, data, size, "fuzz.dat");
    check_reader(sqffd_io_read_ply, data, size, "fuzz.ply");
    check_reader(sqffd_io_read_off, data, size, "fuzz.off");
    check_reader(sqffd_io_read_xyz, data, size, "fuzz.xyz");
    check_reader(sqffd_io_read_obj, data, size, "fuzz.obj");
    check_reader(read_vtk, data, size, "fuzz.vtk");
    check_reader(read_stl, data, size, "fuzz.stl");
    check_stl(data, size);
    check_mesh(data, size);
    check_foreign(data, size);
    return 0;
}

/* libFuzzer target: the PCD reader of examples/sqffd_io.h, directly and
   through the format detection (and gzip). Checks its contract beyond "no
   crash": success means at least one point, every coordinate finite, and
   the points read plus those dropped for NaN make the header's POINTS;
   failure means no points and a message "NAME: ...". */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "../examples/sqffd_io.h"

static void check(int r, double *points, size_t count, const sqffd_io_info *info, const char *err, const char *name)
{
    size_t i;
    if (r == 0) {
        if (count == 0 || !points || info->format != SQFFD_IO_PCD) abort();
        for (i = 0; i < 3 * count; i++)
            if (!isfinite(points[i])) abort();
        if ((uint64_t)count + info->dropped_nan != info->pcd.points) abort();
        if (info->pcd.width * info->pcd.height != info->pcd.points) abort();
        free(points);
    } else {
        if (points || count) abort();
        if (strncmp(err, name, strlen(name)) != 0 || strncmp(err + strlen(name), ": ", 2) != 0) abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    double *points = NULL;
    size_t count = 0;
    sqffd_io_info info;
    char err[256];
    int r = sqffd_io_read_pcd(data, size, "fuzz.pcd", &points, &count, &info, err, sizeof err);
    check(r, points, count, &info, err, "fuzz.pcd");
    points = NULL;
    count = 0;
    r = sqffd_io_read_points_info(data, size, "fuzz.pcd", &points, &count, &info, err, sizeof err);
    /* detected as another format (content first), or gzip around anything: only PCD successes carry a header */
    if (r == 0 && info.format != SQFFD_IO_PCD) {
        free(points);
        return 0;
    }
    check(r, points, count, &info, err, "fuzz.pcd");
    return 0;
}

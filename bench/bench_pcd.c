/* PCD bench: examples/sqffd_io.h reading a 640 x 469 Kinect-like organised
   cloud (x y z rgba, F4 F4 F4 U4, 300,160 points, its invalid pixels NaN)
   from memory, binary and binary_compressed (LZF, written by
   tests/pcd_encode.h), and ascii for scale. Median of repeated runs of the
   thread's CPU time (the 2-core VM is often shared: wall clock scatters
   with its load), the encodings alternating so drifts hit all alike; each
   run allocates and frees its points; the points read are checked to be
   the same in every encoding. Target: binary_compressed in at most 2x the
   time of binary. */
#include "bench.h"
#include "../tests/pcd_encode.h"
#include "../examples/sqffd_io.h"
#include <stdio.h>

#define RUNS 15
#define WIDTH 640
#define HEIGHT 469

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* CPU seconds of one read (its wall-clock seconds in *wall); the points
   are checked against want (when given). */
static double time_read(const bytes *file, const double *want, size_t want_n, size_t *dropped, double *wall)
{
    double *points, w0 = bench_now(), t0 = cpu_now(), t;
    size_t count;
    sqffd_io_info info;
    char err[256];
    if (sqffd_io_read_points_info(file->data, file->size, "bench.pcd", &points, &count, &info, err, sizeof err)) {
        printf("%s\n", err);
        exit(1);
    }
    t = cpu_now() - t0;
    *wall = bench_now() - w0;
    if (want && (count != want_n || memcmp(points, want, 3 * count * sizeof *points) != 0)) {
        printf("bench: the encodings read as different points\n");
        exit(1);
    }
    *dropped = info.dropped_nan;
    free(points);
    return t;
}

int main(void)
{
    static const char *const names[] = {"ascii", "binary", "binary_compressed"};
    size_t dims[2] = {WIDTH, HEIGHT}, want_n, dropped = 0;
    bytes files[3] = {{NULL, 0, 0}, {NULL, 0, 0}, {NULL, 0, 0}};
    double samples[3][RUNS], walls[3][RUNS], median[3], wall, *want;
    char err[256];
    int e, r;
    for (e = 0; e < 3; e++) {
        pcd_spec s = kinect_spec(WIDTH, HEIGHT, e);
        pcd_encode(&files[e], &s, kinect_value, dims);
    }
    if (sqffd_io_read_points(files[1].data, files[1].size, "bench.pcd", &want, &want_n, err, sizeof err)) {
        printf("%s\n", err);
        return 1;
    }
    for (e = 0; e < 3; e++) time_read(&files[e], want, want_n, &dropped, &wall); /* warm-up, points checked */
    for (r = 0; r < RUNS; r++)
        for (e = 0; e < 3; e++) samples[e][r] = time_read(&files[e], NULL, 0, &dropped, &walls[e][r]);
    printf("== PCD reader: %dx%d Kinect-like organised cloud, x y z rgba (F4 F4 F4 U4), %lu points read, %lu NaN dropped; "
           "median CPU time of %d runs\n", WIDTH, HEIGHT, (unsigned long)want_n, (unsigned long)dropped, RUNS);
    printf("%-20s %10s %10s %10s %12s %10s\n", "encoding", "file MB", "cpu ms", "wall ms", "M points/s", "x binary");
    for (e = 0; e < 3; e++) median[e] = bench_median(samples[e], RUNS);
    for (e = 0; e < 3; e++)
        printf("%-20s %10.2f %10.2f %10.2f %12.1f %10.2f\n", names[e], (double)files[e].size / 1e6, 1e3 * median[e],
               1e3 * bench_median(walls[e], RUNS), (double)(WIDTH * HEIGHT) / 1e6 / median[e], median[e] / median[1]);
    printf("target (binary_compressed within 2x binary): %.2fx: %s\n", median[2] / median[1],
           median[2] <= 2.0 * median[1] ? "met" : "MISSED");
    for (e = 0; e < 3; e++) bytes_free(&files[e]);
    free(want);
    return 0;
}

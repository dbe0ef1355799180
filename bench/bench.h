/* Shared timing helpers for the benchmarks: wall-clock seconds and the median
   of repeated runs. */
#ifndef SQFFD_BENCH_H
#define SQFFD_BENCH_H

#include <stdlib.h>
#include <time.h>

static double bench_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int bench_cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Median of n samples (sorts them in place). */
static double bench_median(double *samples, int n)
{
    qsort(samples, (size_t)n, sizeof *samples, bench_cmp_double);
    return n % 2 ? samples[n / 2] : 0.5 * (samples[n / 2 - 1] + samples[n / 2]);
}

#endif

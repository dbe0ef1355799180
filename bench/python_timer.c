/* The C side of bench/bench_python.py, loaded into the same Python process
   (build/python_timer.so, linked to build/libsqffd.so): the phantom's points,
   and one fit as a C program makes it (workspace size, malloc, sqffd_fit,
   free) timed in C, so the Python wrapper's overhead is the difference from
   sqffd.fit() on the same points, same library, same process. */
#include "../sqffd.h"
#include "../examples/sqffd_phantom.h"
#include "bench.h"

/* n points evenly spread over the phantom ventricle at end-diastole (bench_fit's). */
void python_timer_phantom(size_t n, double *points)
{
    phantom_lv p = phantom_lv_default();
    phantom_lv_sample(&p, 0.0, n, points);
}

/* One sqffd_fit with the defaults, workspace malloc and free included:
   its wall-clock milliseconds, and *cpu_ms its thread's CPU milliseconds
   (what the run cost, however busy the machine); -1 when the fit fails. */
double python_timer_fit_ms(const double *points, size_t n, double *cpu_ms)
{
    sqffd_model model;
    sqffd_fit_report report;
    size_t size = 0;
    void *workspace = NULL;
    struct timespec cpu_start, cpu_stop;
    double start, stop;
    sqffd_result r;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &cpu_start);
    start = bench_now();
    r = sqffd_fit_workspace_size(n, NULL, &size);
    if (r == SQFFD_OK && !(workspace = malloc(size))) r = SQFFD_ERROR_TOO_LARGE;
    if (r == SQFFD_OK) r = sqffd_fit(points, n, NULL, &model, &report, workspace, size);
    free(workspace);
    stop = bench_now();
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &cpu_stop);
    *cpu_ms = 1e3 * (double)(cpu_stop.tv_sec - cpu_start.tv_sec) + 1e-6 * (double)(cpu_stop.tv_nsec - cpu_start.tv_nsec);
    return r == SQFFD_OK ? 1e3 * (stop - start) : -1.0;
}

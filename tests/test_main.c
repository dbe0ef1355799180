/* Test runner: every suite, then the line "N passed, N failed".
   Usage: sqffd_tests [SUBSTRING]   runs only the cases whose name contains it. */
#include "test.h"
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static int passed, failed, case_failures, deferred;
static const char *filter;

void test_fail(const char *file, int line, const char *fmt, ...)
{
    va_list ap;
    if (case_failures < 10) { /* a broken loop must not flood the log */
        fprintf(stdout, "    %s:%d: ", file, line);
        va_start(ap, fmt);
        vfprintf(stdout, fmt, ap);
        va_end(ap);
        fputc('\n', stdout);
    }
    case_failures++;
}

void test_run(const char *name, void (*fn)(void))
{
    clock_t start;
    if (filter && !strstr(name, filter)) return;
    case_failures = 0;
    start = clock();
    fn();
    if (case_failures) failed++; else passed++;
    printf("%-4s %-48s %8.1f ms%s\n", case_failures ? "FAIL" : "ok", name,
           1000.0 * (double)(clock() - start) / CLOCKS_PER_SEC,
           case_failures > 10 ? " (more failures not shown)" : "");
    fflush(stdout);
}

int test_thorough(void)
{
    const char *thorough = getenv("SQFFD_TESTS_THOROUGH");
    return thorough && *thorough;
}

void test_run_thorough(const char *name, void (*fn)(void))
{
    if (test_thorough()) test_run(name, fn);
    else if (!filter || strstr(name, filter)) deferred++;
}

int main(int argc, char **argv)
{
    filter = argc > 1 ? argv[1] : NULL;
    suite_linalg();
    suite_kdtree();
    suite_superquadric();
    suite_ffd();
    suite_fold();
    suite_mesh_check();
    suite_io();
    suite_internal();
    suite_phantom();
    suite_track();
    suite_wall();
    suite_inflate();
    suite_volume_io();
    suite_export();
    suite_volume();
    suite_model();
    suite_memory();
    suite_points();
    suite_pcd();
    if (deferred) printf("(%d thorough case%s left to make check: SQFFD_TESTS_THOROUGH=1 runs them)\n", deferred,
                        deferred == 1 ? "" : "s");
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

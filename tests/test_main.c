/* Test runner: every suite, then the line "N passed, N failed".
   Usage: sqffd_tests [--shard K/N] [SUBSTRING]
     SUBSTRING    runs only the cases whose name contains it;
     --shard K/N  of those, only every N-th from the K-th (0 <= K < N): N
                  runners, one a shard, run every case once between them. */
#include "test.h"
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static int passed, failed, case_failures, deferred, shard, shards = 1, seen;
static const char *filter;

/* The case is this runner's: its name matches the filter, and it falls in the shard. */
static int selected(const char *name)
{
    if (filter && !strstr(name, filter)) return 0;
    return seen++ % shards == shard;
}

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
    if (!selected(name)) return;
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
    else if (selected(name)) deferred++;
}

int main(int argc, char **argv)
{
    int arg = 1;
    if (argc > 2 && strcmp(argv[1], "--shard") == 0) {
        if (sscanf(argv[2], "%d/%d", &shard, &shards) != 2 || shards < 1 || shard < 0 || shard >= shards) {
            fprintf(stderr, "sqffd_tests: --shard K/N with 0 <= K < N\n");
            return 2;
        }
        arg = 3;
    }
    filter = argc > arg ? argv[arg] : NULL;
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

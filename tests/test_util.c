/* Helpers shared by the test files and tests/check_threads.c (declared in
   test.h): no test cases of their own. */
#include "test.h"
#include <stdlib.h>

int test_all_zero(const double *values, size_t n)
{
    size_t i;
    for (i = 0; i < n; i++)
        if (values[i] != 0.0) return 0;
    return 1;
}

void *test_malloc(size_t size)
{
    void *p = malloc(size ? size : 1);
    if (!p) {
        fprintf(stderr, "out of memory\n");
        exit(2);
    }
    return p;
}

sqffd_result test_fit(const double *points, size_t n, const sqffd_fit_options *options, sqffd_model *model,
                      sqffd_fit_report *report)
{
    size_t size;
    void *workspace;
    sqffd_result r = sqffd_fit_workspace_size(n, options, &size);
    if (r != SQFFD_OK) return r;
    workspace = test_malloc(size);
    r = sqffd_fit(points, n, options, model, report, workspace, size);
    free(workspace);
    return r;
}

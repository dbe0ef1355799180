/* Built by `make check` with ThreadSanitizer: the library keeps no hidden
   state, so calls on different threads (each with its own workspace and
   outputs) neither race nor change each other's results; a prepared FFD
   system and a built kd-tree are read-only and may be shared.
     1. two sqffd_fit calls at once on the same input points;
     2. two sqffd_fit_prepared calls at once against one prepared system;
     3. two threads querying one kd-tree.
   Every threaded result must equal the single-threaded one to the bit.
   Prints one status line; exit status 1 on a mismatch (TSan's own reports
   give exit status 66). */
#define _POSIX_C_SOURCE 200809L
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include "../examples/sqffd_phantom.h"
#include "test.h" /* test_malloc, test_fit (tests/test_util.c) */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { N = 2500, THREADS = 2, QUERIES = 4000 };

static pthread_barrier_t start_together;

/* The fields of a model, compared bit for bit (not the padding): the
   superquadric, the box, the used control points and the grid. */
static int same_model(const sqffd_model *a, const sqffd_model *b)
{
    size_t used = (size_t)a->ffd.dims[0] * (size_t)a->ffd.dims[1] * (size_t)a->ffd.dims[2];
    const sqffd_superquadric *p = &a->sq, *q = &b->sq;
    if (memcmp(a->ffd.dims, b->ffd.dims, sizeof a->ffd.dims) != 0) return 0;
    return memcmp(p->size, q->size, sizeof p->size) == 0 && memcmp(p->shape, q->shape, sizeof p->shape) == 0 &&
           memcmp(p->taper, q->taper, sizeof p->taper) == 0 &&
           memcmp(p->rotation, q->rotation, sizeof p->rotation) == 0 &&
           memcmp(p->center, q->center, sizeof p->center) == 0 &&
           memcmp(a->ffd.origin, b->ffd.origin, sizeof a->ffd.origin) == 0 &&
           memcmp(a->ffd.edges, b->ffd.edges, sizeof a->ffd.edges) == 0 &&
           memcmp(a->ffd.control, b->ffd.control, used * sizeof a->ffd.control[0]) == 0 &&
           memcmp(a->grid, b->grid, sizeof a->grid) == 0;
}

/* ---- 1. whole fits ---- */
typedef struct fit_job {
    const double *points;
    const sqffd_fit_options *options;
    sqffd_model model;
    double error;
    sqffd_result result;
} fit_job;

static sqffd_result run_fit(fit_job *j)
{
    sqffd_fit_report report;
    sqffd_result r = test_fit(j->points, N, j->options, &j->model, &report);
    j->error = r == SQFFD_OK ? report.error.rms_relative : 0.0;
    return r;
}

static void *fit_thread(void *arg)
{
    fit_job *j = (fit_job *)arg;
    pthread_barrier_wait(&start_together);
    j->result = run_fit(j);
    return NULL;
}

/* ---- 2. fits against one prepared system ---- */
typedef struct prepared_job {
    const sqffd_ffd_system *system;
    const double *points;
    const sqffd_fit_options *options;
    sqffd_model model; /* in: the start; out: the result */
    double error;
    sqffd_result result;
} prepared_job;

static sqffd_result run_prepared(prepared_job *j)
{
    size_t size;
    void *work;
    sqffd_fit_report report;
    sqffd_result r = sqffd_fit_prepared_workspace_size(N, j->system, j->options, &size);
    if (r != SQFFD_OK) return r;
    work = test_malloc(size);
    r = sqffd_fit_prepared(j->system, j->points, N, j->options, &j->model, &report, work, size);
    j->error = report.error.rms_relative;
    free(work);
    return r;
}

static void *prepared_thread(void *arg)
{
    prepared_job *j = (prepared_job *)arg;
    pthread_barrier_wait(&start_together);
    j->result = run_prepared(j);
    return NULL;
}

/* ---- 3. queries on one tree ---- */
typedef struct query_job {
    const sqffd_kdtree *tree;
    const double *queries;
    size_t nearest[QUERIES];
    size_t knn[QUERIES][4];
} query_job;

static void run_queries(query_job *j)
{
    size_t q;
    for (q = 0; q < QUERIES; q++) {
        double d2[4];
        size_t found;
        if (sqffd_kdtree_nearest(j->tree, j->queries + 3 * q, &j->nearest[q], NULL) != SQFFD_OK)
            j->nearest[q] = (size_t)-1;
        if (sqffd_kdtree_knn(j->tree, j->queries + 3 * q, 4, j->knn[q], d2, &found) != SQFFD_OK || found != 4)
            j->knn[q][0] = (size_t)-1;
    }
}

static void *query_thread(void *arg)
{
    query_job *j = (query_job *)arg;
    pthread_barrier_wait(&start_together);
    run_queries(j);
    return NULL;
}

static void run_threads(void *(*fn)(void *), void *jobs, size_t job_size)
{
    pthread_t t[THREADS];
    int k;
    pthread_barrier_init(&start_together, NULL, THREADS);
    for (k = 0; k < THREADS; k++)
        if (pthread_create(&t[k], NULL, fn, (char *)jobs + (size_t)k * job_size) != 0) {
            fprintf(stderr, "check_threads: pthread_create failed\n");
            exit(2);
        }
    for (k = 0; k < THREADS; k++) pthread_join(t[k], NULL);
    pthread_barrier_destroy(&start_together);
}

int main(void)
{
    phantom_lv ph = phantom_lv_default();
    sqffd_fit_options o = sqffd_fit_options_default();
    double *ed = (double *)test_malloc(3 * N * sizeof *ed), *es = (double *)test_malloc(3 * N * sizeof *es);
    fit_job ref, fits[THREADS];
    prepared_job pref, prep[THREADS];
    query_job *qref = (query_job *)test_malloc(sizeof *qref);
    query_job *queries = (query_job *)test_malloc(THREADS * sizeof *queries);
    sqffd_ffd_system system;
    sqffd_kdtree tree;
    void *system_memory, *tree_memory;
    size_t size;
    int k, bad = 0;

    phantom_lv_frame(&ph, 0.0, N, 0.01, 21, ed, NULL);
    phantom_lv_frame(&ph, 0.5, N, 0.01, 22, es, NULL);
    o.max_iterations = 12; /* a full two-stage fit, kept short under the sanitizer */

    /* 1. the reference fit alone, then two at once */
    ref.points = ed;
    ref.options = &o;
    if ((ref.result = run_fit(&ref)) != SQFFD_OK) {
        printf("threads: reference fit failed: %s\n", sqffd_result_string(ref.result));
        return 1;
    }
    for (k = 0; k < THREADS; k++) {
        fits[k].points = ed;
        fits[k].options = &o;
    }
    run_threads(fit_thread, fits, sizeof fits[0]);
    for (k = 0; k < THREADS; k++)
        if (fits[k].result != SQFFD_OK || !same_model(&fits[k].model, &ref.model) ||
            memcmp(&fits[k].error, &ref.error, sizeof ref.error) != 0) {
            printf("threads: concurrent sqffd_fit %d: %s, model %s the single-threaded one\n", k,
                   sqffd_result_string(fits[k].result), same_model(&fits[k].model, &ref.model) ? "equals" : "differs from");
            bad = 1;
        }

    /* 2. one prepared system (read-only after init), two fits against it */
    if (sqffd_ffd_system_size(&ref.model, &size) != SQFFD_OK) {
        printf("threads: sqffd_ffd_system_size failed\n");
        return 1;
    }
    system_memory = test_malloc(size);
    if (sqffd_ffd_system_init(&system, &ref.model, &o, system_memory, size) != SQFFD_OK) {
        printf("threads: sqffd_ffd_system_init failed\n");
        return 1;
    }
    pref.system = &system;
    pref.points = es;
    pref.options = &o;
    pref.model = ref.model;
    if ((pref.result = run_prepared(&pref)) != SQFFD_OK) {
        printf("threads: reference sqffd_fit_prepared failed: %s\n", sqffd_result_string(pref.result));
        return 1;
    }
    for (k = 0; k < THREADS; k++) {
        prep[k].system = &system;
        prep[k].points = es;
        prep[k].options = &o;
        prep[k].model = ref.model;
    }
    run_threads(prepared_thread, prep, sizeof prep[0]);
    for (k = 0; k < THREADS; k++)
        if (prep[k].result != SQFFD_OK || !same_model(&prep[k].model, &pref.model) ||
            memcmp(&prep[k].error, &pref.error, sizeof pref.error) != 0) {
            printf("threads: concurrent sqffd_fit_prepared %d on one system: %s, model %s the single-threaded one\n", k,
                   sqffd_result_string(prep[k].result),
                   same_model(&prep[k].model, &pref.model) ? "equals" : "differs from");
            bad = 1;
        }

    /* 3. one kd-tree, two readers (queries: the ES points, and a few far ones) */
    if (sqffd_kdtree_workspace_size(N, &size) != SQFFD_OK) {
        printf("threads: sqffd_kdtree_workspace_size failed\n");
        return 1;
    }
    tree_memory = test_malloc(size);
    if (sqffd_kdtree_build(&tree, ed, N, tree_memory, size) != SQFFD_OK) {
        printf("threads: sqffd_kdtree_build failed\n");
        return 1;
    }
    {
        double *q = (double *)test_malloc(3 * QUERIES * sizeof *q);
        size_t i;
        for (i = 0; i < QUERIES; i++) {
            q[3 * i] = es[3 * (i % N)] * (1.0 + (double)(i / N));
            q[3 * i + 1] = es[3 * (i % N) + 1];
            q[3 * i + 2] = es[3 * (i % N) + 2];
        }
        qref->tree = &tree;
        qref->queries = q;
        run_queries(qref);
        for (k = 0; k < THREADS; k++) {
            queries[k].tree = &tree;
            queries[k].queries = q;
        }
        run_threads(query_thread, queries, sizeof queries[0]);
        for (k = 0; k < THREADS; k++)
            if (memcmp(queries[k].nearest, qref->nearest, sizeof qref->nearest) != 0 ||
                memcmp(queries[k].knn, qref->knn, sizeof qref->knn) != 0) {
                printf("threads: concurrent kd-tree queries %d differ from the single-threaded ones\n", k);
                bad = 1;
            }
        free(q);
    }

    if (!bad)
        printf("threads: 2 concurrent sqffd_fit, 2 sqffd_fit_prepared on one system, 2 readers of one kd-tree: "
               "bit-identical to single-threaded\n");
    free(tree_memory);
    free(system_memory);
    free(queries);
    free(qref);
    free(ed);
    free(es);
    return bad;
}

/* Minimal test harness shared by every test file: checks count per test
   case, the runner prints "N passed, N failed" last. */
#ifndef SQFFD_TEST_H
#define SQFFD_TEST_H

#include <stdio.h>
#include <math.h>
#include "../sqffd.h"

/* Record a failed check (file:line and a printf-style message). */
void test_fail(const char *file, int line, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
/* malloc that never returns NULL (the program stops: a test cannot go on). */
void *test_malloc(size_t size);
/* sqffd_fit with its workspace from test_malloc, freed after (report may be NULL). */
sqffd_result test_fit(const double *points, size_t n, const sqffd_fit_options *options, sqffd_model *model,
                      sqffd_fit_report *report);
/* Whether the n doubles are all zero (an output left untouched after a zero fill). */
int test_all_zero(const double *values, size_t n);
/* Run one test case: it fails when any check inside it failed. */
void test_run(const char *name, void (*fn)(void));

#define CHECK(cond) \
    do { if (!(cond)) test_fail(__FILE__, __LINE__, "%s", #cond); } while (0)
#define CHECK_MSG(cond, ...) \
    do { if (!(cond)) test_fail(__FILE__, __LINE__, __VA_ARGS__); } while (0)
#define CHECK_NEAR(a, b, tol) \
    do { double a_ = (a), b_ = (b), t_ = (tol); \
         if (!(fabs(a_ - b_) <= t_)) test_fail(__FILE__, __LINE__, "%s = %.17g, %s = %.17g, |diff| %.3g > %.3g", \
                                                #a, a_, #b, b_, fabs(a_ - b_), t_); } while (0)
#define CHECK_RESULT(call, expected) \
    do { sqffd_result r_ = (call), e_ = (expected); \
         if (r_ != e_) test_fail(__FILE__, __LINE__, "%s returned %s, expected %s", #call, \
                                 sqffd_result_string(r_), sqffd_result_string(e_)); } while (0)
#define RUN_TEST(fn) test_run(#fn, fn)
/* A case that takes seconds: run only where SQFFD_TESTS_THOROUGH is set (make check sets it; make test
   leaves it out, to stay near a minute). */
void test_run_thorough(const char *name, void (*fn)(void));
/* 1 where SQFFD_TESTS_THOROUGH is set: a case may then widen its sweep */
int test_thorough(void);
#define RUN_THOROUGH_TEST(fn) test_run_thorough(#fn, fn)

/* Test suites, one per layer file; each calls RUN_TEST on its cases. */
void suite_linalg(void);
void suite_kdtree(void);
void suite_superquadric(void);
void suite_ffd(void);
void suite_io(void);
void suite_internal(void);
void suite_phantom(void);
void suite_track(void);
void suite_inflate(void);
void suite_volume_io(void);
void suite_export(void);
void suite_volume(void);
void suite_model(void);
void suite_memory(void);
void suite_points(void);
void suite_pcd(void);
void suite_fold(void);
void suite_mesh_check(void);
void suite_wall(void);

#endif

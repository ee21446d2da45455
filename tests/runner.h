/* tests/runner.h - the PDS test runner: no framework, a table of tests.

   A test is a function void fn(pds_test_ctx *t). CHECK(t, cond, fmt, ...)
   records a failure with a message and the file:line and carries on;
   REQUIRE does the same and returns from the test. Each test file exports
   one table:

       static const pds_test_case tests_bvh[] = {
           {"bvh_matches_brute_force_on_random_rays", test_bvh_random_rays},
       };

   and test_main.c lists the tables. Usage: test_pds [NAME-SUBSTRING...];
   the last line printed is "N passed, N failed". Test programs include
   pds.c itself, so static functions are testable.

   Progress: with PDS_TEST_VERBOSE=1 in the environment (or in a build
   with AddressSanitizer, whose tests take minutes), each test's name goes
   to stderr as it starts, "[ 12/172] bvh_matches_...", so a long run shows
   where it is; PDS_TEST_VERBOSE=0 turns that off. stdout stays as it is. */
#ifndef PDS_TEST_RUNNER_H
#define PDS_TEST_RUNNER_H

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct pds_test_ctx {
    const char *name;
    int failures;
    int checks;
} pds_test_ctx;

typedef struct pds_test_case {
    const char *name;
    void (*fn)(pds_test_ctx *t);
} pds_test_case;

typedef struct pds_test_suite {
    const pds_test_case *cases;
    size_t count;
} pds_test_suite;

#define PDS_SUITE(table) { table, sizeof(table) / sizeof(table[0]) }

static void pds_test_fail(pds_test_ctx *t, const char *file, int line, const char *fmt, ...)
{
    va_list ap;
    t->failures++;
    printf("FAIL %s: ", t->name);
    va_start(ap, fmt);
    vprintf(fmt, ap);
    va_end(ap);
    printf(" (%s:%d)\n", file, line);
    fflush(stdout);
}

#define CHECK(t, cond, ...)                                                   \
    do {                                                                      \
        (t)->checks++;                                                        \
        if (!(cond)) pds_test_fail((t), __FILE__, __LINE__, __VA_ARGS__);     \
    } while (0)

#define REQUIRE(t, cond, ...)                                                 \
    do {                                                                      \
        (t)->checks++;                                                        \
        if (!(cond)) {                                                        \
            pds_test_fail((t), __FILE__, __LINE__, __VA_ARGS__);              \
            return;                                                           \
        }                                                                     \
    } while (0)

/* |a - b| <= tol */
#define CHECK_NEAR(t, a, b, tol)                                              \
    CHECK((t), fabs((double)(a) - (double)(b)) <= (tol), "%s = %.9g, expected %.9g (tol %g)", \
          #a, (double)(a), (double)(b), (double)(tol))

/* Was this program built with AddressSanitizer (gcc and clang spell it
   differently)? */
#if defined(__SANITIZE_ADDRESS__)
#define PDS_TEST_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define PDS_TEST_SANITIZED 1
#endif
#endif
#ifndef PDS_TEST_SANITIZED
#define PDS_TEST_SANITIZED 0
#endif

static int pds_test_verbose(void)
{
    const char *v = getenv("PDS_TEST_VERBOSE");
    if (v && *v) return strcmp(v, "0") != 0;
    return PDS_TEST_SANITIZED;
}

static int pds_test_selected(const char *name, int argc, char **argv)
{
    int i;
    if (argc <= 1) return 1;
    for (i = 1; i < argc; i++)
        if (strstr(name, argv[i])) return 1;
    return 0;
}

/* Runs every selected test; a test with no check at all counts as failed,
   because a test that cannot fail is a defect. */
static int pds_test_run(const pds_test_suite *suites, size_t nsuites, int argc, char **argv)
{
    size_t s, i;
    int passed = 0, failed = 0, verbose = pds_test_verbose(), total = 0;
    for (s = 0; s < nsuites; s++)
        for (i = 0; i < suites[s].count; i++) total += pds_test_selected(suites[s].cases[i].name, argc, argv);
    for (s = 0; s < nsuites; s++) {
        for (i = 0; i < suites[s].count; i++) {
            pds_test_ctx t;
            const pds_test_case *c = &suites[s].cases[i];
            if (!pds_test_selected(c->name, argc, argv)) continue;
            if (verbose) {
                fprintf(stderr, "[%3d/%d] %s\n", passed + failed + 1, total, c->name);
                fflush(stderr);
            }
            t.name = c->name;
            t.failures = 0;
            t.checks = 0;
            c->fn(&t);
            if (t.checks == 0) pds_test_fail(&t, __FILE__, __LINE__, "test made no check");
            if (t.failures) failed++;
            else passed++;
        }
    }
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

#endif

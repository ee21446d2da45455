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
   where it is; PDS_TEST_VERBOSE=0 turns that off. stdout stays as it is.

   Workers: on a POSIX system the tests run in PDS_TEST_JOBS processes
   (default: one per processor online, at most 8; 1 runs them in this
   process, in order). Each worker takes the next test's number from a
   pipe the runner fills, so a long test holds up only its own worker,
   runs the test whole and sends its outcome back on a second pipe. A
   test is one process's from start to end, and the files tests write
   carry their process's number (getpid) or their own name, so tests in
   different workers do not meet. A worker that dies in a test (a crash,
   an abort) fails that test by name instead of ending the run; one that
   exits with a status other than 0 (LeakSanitizer's, after a leak
   report) fails the run. */
#ifndef PDS_TEST_RUNNER_H
#define PDS_TEST_RUNNER_H

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifndef _WIN32
#include <sys/wait.h>
#include <unistd.h>
#define PDS_TEST_WORKERS 1
#endif
#define PDS_TEST_MAX_JOBS 8 /* worker processes at most */

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

/* Runs test c; 1 if it failed. A test with no check at all fails,
   because a test that cannot fail is a defect. */
static int pds_test_one(const pds_test_case *c, int number, int total, int verbose)
{
    pds_test_ctx t;
    if (verbose) {
        fprintf(stderr, "[%3d/%d] %s\n", number, total, c->name);
        fflush(stderr);
    }
    t.name = c->name;
    t.failures = 0;
    t.checks = 0;
    c->fn(&t);
    if (t.checks == 0) pds_test_fail(&t, __FILE__, __LINE__, "test made no check");
    fflush(stdout);
    return t.failures != 0;
}

/* How many worker processes (PDS_TEST_JOBS, or the processors online). */
static int pds_test_jobs(void)
{
    const char *v = getenv("PDS_TEST_JOBS");
    long n = 1;
    if (v && *v) {
        n = strtol(v, NULL, 10);
    } else {
#ifdef PDS_TEST_WORKERS
        n = sysconf(_SC_NPROCESSORS_ONLN);
#endif
    }
    return n < 1 ? 1 : n > PDS_TEST_MAX_JOBS ? PDS_TEST_MAX_JOBS : (int)n;
}

#ifdef PDS_TEST_WORKERS
/* The selected tests (list[0..total)) in `jobs` worker processes; their
   outcomes counted into *passed and *failed. 0 if the workers could not
   be started (nothing has run then). */
static int pds_test_workers(const pds_test_case *const *list, int total, int jobs, int verbose, int *passed,
                            int *failed)
{
    int work[2], done[2], k, j, started = 0;
    pid_t pid[PDS_TEST_MAX_JOBS];
    char *reported = (char *)calloc((size_t)total, 1);
    if (!reported || pipe(work) != 0) {
        free(reported);
        return 0;
    }
    if (pipe(done) != 0) {
        close(work[0]);
        close(work[1]);
        free(reported);
        return 0;
    }
    fflush(stdout);
    fflush(stderr);
    for (j = 0; j < jobs; j++) {
        pid[j] = fork();
        if (pid[j] < 0) break;
        if (pid[j] == 0) {
            /* a worker: the next number, its test, its outcome; until the
               runner has no more */
            int number, out[2];
            close(work[1]);
            close(done[0]);
            while (read(work[0], &number, sizeof number) == (ssize_t)sizeof number) {
                out[0] = number;
                out[1] = pds_test_one(list[number], number + 1, total, verbose);
                if (write(done[1], out, sizeof out) != (ssize_t)sizeof out) break;
            }
            /* exit, not _exit: LeakSanitizer checks at exit, so the
               worker frees its copies of the runner's memory first */
            free(reported);
            free((void *)list);
            exit(0);
        }
        started++;
    }
    close(work[0]);
    close(done[1]);
    if (started == 0) {
        close(work[1]);
        close(done[0]);
        free(reported);
        return 0;
    }
    /* each number written whole (a few bytes, so no worker reads half of
       one); a worker that died leaves its numbers to the others */
    for (k = 0; k < total; k++)
        if (write(work[1], &k, sizeof k) != (ssize_t)sizeof k) break;
    close(work[1]);
    {
        int out[2];
        while (read(done[0], out, sizeof out) == (ssize_t)sizeof out)
            if (out[0] >= 0 && out[0] < total && !reported[out[0]]) {
                reported[out[0]] = 1;
                if (out[1]) (*failed)++;
                else (*passed)++;
            }
    }
    close(done[0]);
    for (j = 0; j < started; j++) {
        /* a worker that ends other than with status 0 fails the run: a
           signal (its test, which sent no outcome, is counted below), or
           a status such as LeakSanitizer's after its leak report */
        int status = 0;
        if (waitpid(pid[j], &status, 0) != pid[j]) continue;
        if (WIFSIGNALED(status)) {
            printf("FAIL a worker process died (signal %d)\n", WTERMSIG(status));
        } else if (WIFEXITED(status) && WEXITSTATUS(status) != 0) {
            printf("FAIL a worker process exited with status %d\n", WEXITSTATUS(status));
            (*failed)++;
        }
    }
    for (k = 0; k < total; k++)
        if (!reported[k]) {
            printf("FAIL %s: its worker process ended without its outcome\n", list[k]->name);
            (*failed)++;
        }
    free(reported);
    return 1;
}
#endif

/* Runs every selected test, in worker processes (pds_test_jobs) where
   the system has them; the last line is "N passed, N failed". */
static int pds_test_run(const pds_test_suite *suites, size_t nsuites, int argc, char **argv)
{
    size_t s, i, cases = 0;
    int passed = 0, failed = 0, verbose = pds_test_verbose(), total = 0, jobs = pds_test_jobs(), k;
    const pds_test_case **list;
    for (s = 0; s < nsuites; s++) cases += suites[s].count;
    list = (const pds_test_case **)malloc(sizeof *list * (cases > 0 ? cases : 1));
    if (!list) {
        printf("FAIL the test runner: out of memory\n");
        return 1;
    }
    for (s = 0; s < nsuites; s++)
        for (i = 0; i < suites[s].count; i++)
            if (pds_test_selected(suites[s].cases[i].name, argc, argv)) list[total++] = &suites[s].cases[i];
#ifdef PDS_TEST_WORKERS
    if (jobs > 1 && total > 1 && pds_test_workers(list, total, jobs < total ? jobs : total, verbose, &passed, &failed)) {
        free(list);
        printf("%d passed, %d failed\n", passed, failed);
        return failed ? 1 : 0;
    }
#endif
    (void)jobs;
    for (k = 0; k < total; k++) {
        if (pds_test_one(list[k], k + 1, total, verbose)) failed++;
        else passed++;
    }
    free(list);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

#endif

/* tests/test_main.c - the PDS test program. It includes the library itself,
   so static functions are testable, then every test file; each file
   contributes one table of tests. Usage: test_pds [NAME-SUBSTRING...]. */
#define PDS_TEST 1 /* keep the helpers the tests use in any build (pds.c >>config) */
#include "pds.c"
#include "runner.h"

#ifdef _WIN32
/* Windows (MinGW-w64; `make windows` runs it under wine): the tests that
   drive the pds tool through a POSIX shell and those of POSIX special
   files (FIFOs, /dev) are left out (PDS_TEST_POSIX); the rest run as they
   are. */
#include <direct.h>
#include <process.h>
#define getpid _getpid
#define mkdir(path, mode) _mkdir(path)
#else
#define PDS_TEST_POSIX 1
#endif

#include "test_scene.c"
#ifdef PDS_TEST_POSIX
#include "test_cli.c"
#include "test_harness.c"
#endif
#include "test_image.c"
#include "test_exr.c"
#include "test_obj.c"
#include "test_bvh.c"
#include "test_materials.c"
#include "test_lights.c"
#include "test_render.c"
#include "test_golden.c"
#include "test_kdtree.c"
#include "test_differentials.c"
#include "test_pds.c"
#include "test_baselines.c"
#include "test_budget.c"
#include "test_exact.c"
#include "test_limits.c"
#include "test_spectral.c"
#include "test_glossy.c"
#include "test_gi.c"
#include "test_streams.c" /* after test_gi.c: gi's streams use its helpers */
#include "test_shards.c"
#include "test_isc.c"
#include "test_teach.c"
#include "test_scenelang.c"
#include "test_envlight.c"

int main(int argc, char **argv)
{
    static const pds_test_suite suites[] = {
        PDS_SUITE(tests_scene),
#ifdef PDS_TEST_POSIX
        PDS_SUITE(tests_cli),
        PDS_SUITE(tests_harness),
#endif
        PDS_SUITE(tests_image),
        PDS_SUITE(tests_exr),
        PDS_SUITE(tests_obj),
        PDS_SUITE(tests_bvh),
        PDS_SUITE(tests_materials),
        PDS_SUITE(tests_lights),
        PDS_SUITE(tests_render),
        PDS_SUITE(tests_golden),
        PDS_SUITE(tests_kdtree),
        PDS_SUITE(tests_differentials),
        PDS_SUITE(tests_pds),
        PDS_SUITE(tests_baselines),
        PDS_SUITE(tests_budget),
        PDS_SUITE(tests_streams),
        PDS_SUITE(tests_exact),
        PDS_SUITE(tests_limits),
        PDS_SUITE(tests_spectral),
        PDS_SUITE(tests_glossy),
        PDS_SUITE(tests_gi),
        PDS_SUITE(tests_shards),
        PDS_SUITE(tests_isc),
        PDS_SUITE(tests_teach),
        PDS_SUITE(tests_scenelang),
        PDS_SUITE(tests_envlight),
    };
    return pds_test_run(suites, sizeof suites / sizeof suites[0], argc, argv);
}

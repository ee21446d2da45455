/* tests/test_core.c - the test program of the small core (`make core`):
   pds.c built with -DPDS_CORE (no PNG or OpenEXR, baselines, gi, isc,
   environment light, spectral rendering, partial files or benchmarks;
   README "A small core") and the suites that apply to it: the method's
   own tests, and in tests/test_teach.c one test per switch that what it
   leaves out is refused. The tool's command-line suites and those of
   what the core leaves out are the full build's. */
#define PDS_TEST 1 /* keep the helpers the tests use (pds.c >>config) */
#include "pds.c"
#include "runner.h"

#include "test_scene.c"
#include "test_render.c"
#include "test_obj.c"
#include "test_bvh.c"
#include "test_materials.c"
#include "test_lights.c"
#include "test_kdtree.c"
#include "test_differentials.c"
#include "test_pds.c"
#include "test_exact.c"
#include "test_teach.c"

int main(int argc, char **argv)
{
    static const pds_test_suite suites[] = {
        PDS_SUITE(tests_scene),
        PDS_SUITE(tests_render),
        PDS_SUITE(tests_obj),
        PDS_SUITE(tests_bvh),
        PDS_SUITE(tests_materials),
        PDS_SUITE(tests_lights),
        PDS_SUITE(tests_kdtree),
        PDS_SUITE(tests_differentials),
        PDS_SUITE(tests_pds),
        PDS_SUITE(tests_exact),
        PDS_SUITE(tests_teach),
    };
    return pds_test_run(suites, sizeof suites / sizeof suites[0], argc, argv);
}

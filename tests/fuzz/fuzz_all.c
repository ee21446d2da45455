/* fuzz_all.c - every libFuzzer harness of tests/fuzz/ in one program.

   Each harness compiles pds.c with the fuzzer and the sanitizers, some
   35 s of CPU apiece; this file includes them all, each under a name of
   its own (PDS_FUZZ_ENTRY), so that pds.c is compiled once. The program
   runs as the harness its name says: `make fuzz` links fuzz_TARGET to it
   (TARGET: scene, obj, mtl, pfm, partial or exr), or PDS_FUZZ_TARGET in
   the environment names the harness. */
#define PDS_FUZZ_ENTRY pds_fuzz_scene_input
#include "fuzz_scene.c"
#undef PDS_FUZZ_ENTRY
#define PDS_FUZZ_ENTRY pds_fuzz_obj_input
#include "fuzz_obj.c"
#undef PDS_FUZZ_ENTRY
#define PDS_FUZZ_ENTRY pds_fuzz_mtl_input
#include "fuzz_mtl.c"
#undef PDS_FUZZ_ENTRY
#define PDS_FUZZ_ENTRY pds_fuzz_pfm_input
#include "fuzz_pfm.c"
#undef PDS_FUZZ_ENTRY
#define PDS_FUZZ_ENTRY pds_fuzz_partial_input
#include "fuzz_partial.c"
#undef PDS_FUZZ_ENTRY
#define PDS_FUZZ_ENTRY pds_fuzz_exr_input
#include "fuzz_exr.c"
#undef PDS_FUZZ_ENTRY

static const struct {
    const char *name;
    int (*input)(const uint8_t *data, size_t size);
} pds_fuzz_harnesses[] = {
    {"scene", pds_fuzz_scene_input}, {"obj", pds_fuzz_obj_input},         {"mtl", pds_fuzz_mtl_input},
    {"pfm", pds_fuzz_pfm_input},     {"partial", pds_fuzz_partial_input}, {"exr", pds_fuzz_exr_input},
};

/* The harness chosen (LLVMFuzzerInitialize); the program's only state
   outside pds.c's values. */
static int (*pds_fuzz_input)(const uint8_t *data, size_t size);

int LLVMFuzzerInitialize(int *argc, char ***argv);

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    const char *name = getenv("PDS_FUZZ_TARGET"), *slash;
    size_t k;
    if (!name || !name[0]) {
        name = *argc > 0 ? (*argv)[0] : "";
        slash = strrchr(name, '/');
        if (slash) name = slash + 1;
        if (!strncmp(name, "fuzz_", 5)) name += 5;
    }
    for (k = 0; k < sizeof pds_fuzz_harnesses / sizeof pds_fuzz_harnesses[0]; k++)
        if (!strcmp(name, pds_fuzz_harnesses[k].name)) pds_fuzz_input = pds_fuzz_harnesses[k].input;
    if (!pds_fuzz_input) {
        fprintf(stderr, "fuzz_all: which harness? Run it as fuzz_TARGET (a link to it) or set PDS_FUZZ_TARGET, "
                        "TARGET one of scene, obj, mtl, pfm, partial, exr (not '%s')\n", name);
        exit(2);
    }
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    return pds_fuzz_input(data, size);
}

/* fuzz.h - what the libFuzzer harnesses in tests/fuzz/ share.

   Each harness is one C file that defines LLVMFuzzerTestOneInput and
   includes this header, which includes pds.c itself (as tests/test_main.c
   does). The loaders read files by path, so a harness writes its input into
   a private temporary directory (mkdtemp under $TMPDIR or /tmp, made on the
   first input, removed with everything the harnesses wrote when the process
   exits) and calls the public loader on that file.

   Guards (the only places a harness steps between the fuzzer and pds.c;
   PDS_FUZZ_UNGUARDED=1 in the environment turns both off, and the skips
   below too, to reproduce the findings they keep out of the way):

   1. Paths. pds.c opens files only through fopen, which is redirected to
   pds_fuzz_fopen. It refuses, with EACCES, every path outside the
   temporary directory and every path with a ".." component. Scene files
   (`mesh "PATH"`) and OBJ files (`mtllib PATH`) can name any file, and the
   reader of this pds.c has no size limit or regular-file check yet: a scene
   with `mesh "/dev/zero"` reads until memory runs out (finding
   /work/fuzz-findings/scene-mesh-dev-zero, in the fuzzing report). Without
   the guard every run stops at that input instead of looking further, and a
   fuzzer that can read the machine's files is not reproducible. What the
   loaders do with a file they may open is untouched.

   2. Memory. malloc, calloc and realloc in pds.c are redirected to
   versions that fail (return NULL, as when memory runs out) for any one
   block over PDS_FUZZ_MAX_BLOCK (4 MB). The scene format's documented
   limits let a few bytes ask for tens of millions of triangles (`quad {
   segments 4096 }`: 33.5 million): such a scene is valid and takes minutes
   and gigabytes to load, more still under the sanitizers, and every scene
   fuzzing run ended on one in its first minutes as a timeout (finding
   /work/fuzz-findings/scene-huge-tessellation). With the cap the mesh
   stops growing at about 350,000 triangles and the BVH build at about
   65,000 (its binning array takes 64 bytes a triangle), where the load
   fails with PDS_ERR_NOMEM; so the out-of-memory paths are fuzzed too: they
   must free what they allocated and report.

   Skips (inputs the text harnesses return -1 on, so that libFuzzer drops
   them, until pds.c is fixed; each blocked every run of the OBJ or MTL
   fuzzer within seconds). pds_fuzz_skip finds them with pds.c's own OBJ/MTL
   lexer and number parser, in the whole input, since any input file may be
   read as an OBJ or MTL file (a scene or an OBJ can name itself in `mesh`
   or `mtllib`):
   - `illum N` with N outside int's range: pds__mtl_load reports it as an
     error but converts it to int first, which is undefined behaviour
     (finding /work/fuzz-findings/mtl-illum-float-cast-overflow);
   - an `mtllib` with two or more names together with a `newmtl` whose name
     is two or more tokens: pds__obj_mtllib walks its names in the scratch
     token array s->ftok, which pds__mtl_load's `newmtl` refills with tokens
     of the MTL buffer it then frees; the next name is read from freed
     memory (finding /work/fuzz-findings/obj-mtllib-heap-use-after-free).

   Build: `make fuzz` (clang with libFuzzer; see the Makefile). */
#ifndef PDS_FUZZ_H
#define PDS_FUZZ_H

/* pds.c asks for POSIX before its first include; this header includes
   <stdio.h> before pds.c, so it must ask first (the same definition). */
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define PDS_FUZZ_MAX_BLOCK ((size_t)4 << 20)

static FILE *pds_fuzz_fopen(const char *path, const char *mode);
static void *pds_fuzz_malloc(size_t size);
static void *pds_fuzz_calloc(size_t count, size_t size);
static void *pds_fuzz_realloc(void *p, size_t size);

#define fopen pds_fuzz_fopen
#define malloc pds_fuzz_malloc
#define calloc pds_fuzz_calloc
#define realloc pds_fuzz_realloc
#include "../../pds.c"
#undef fopen
#undef malloc
#undef calloc
#undef realloc

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Is PDS_FUZZ_UNGUARDED=1 set (guards and skips off)? */
static int pds_fuzz_unguarded(void)
{
    static int unguarded = -1;
    if (unguarded < 0) {
        const char *e = getenv("PDS_FUZZ_UNGUARDED");
        unguarded = e && e[0] == '1';
    }
    return unguarded;
}

/* The temporary directory ("" until made) and the names written in it. */
static char pds_fuzz_dir[4096];
#define PDS_FUZZ_MAX_FILES 8
static char pds_fuzz_files[PDS_FUZZ_MAX_FILES][4096];
static int pds_fuzz_nfiles;

static void pds_fuzz_cleanup(void)
{
    int i;
    for (i = 0; i < pds_fuzz_nfiles; i++) remove(pds_fuzz_files[i]);
    if (pds_fuzz_dir[0]) rmdir(pds_fuzz_dir);
}

/* The temporary directory, made on the first call. Aborts if it cannot be
   made: no input can be tried without it. */
static const char *pds_fuzz_tmpdir(void)
{
    const char *base;
    if (pds_fuzz_dir[0]) return pds_fuzz_dir;
    base = getenv("TMPDIR");
    if (!base || !base[0]) base = "/tmp";
    if ((size_t)snprintf(pds_fuzz_dir, sizeof pds_fuzz_dir, "%s/pds-fuzz-XXXXXX", base) >= sizeof pds_fuzz_dir ||
        !mkdtemp(pds_fuzz_dir)) {
        fprintf(stderr, "pds fuzz: cannot make a temporary directory under %s\n", base);
        abort();
    }
    atexit(pds_fuzz_cleanup);
    return pds_fuzz_dir;
}

/* Full path of `name` in the temporary directory, into out[4096]. */
static const char *pds_fuzz_path(const char *name, char *out)
{
    snprintf(out, 4096, "%s/%s", pds_fuzz_tmpdir(), name);
    return out;
}

/* Write size bytes to `name` in the temporary directory and return its full
   path (in out[4096]). Aborts on failure: the input would be lost. */
static const char *pds_fuzz_write(const char *name, const void *data, size_t size, char *out)
{
    FILE *f;
    int i, known = 0;
    pds_fuzz_path(name, out);
    for (i = 0; i < pds_fuzz_nfiles; i++) known |= strcmp(pds_fuzz_files[i], out) == 0;
    if (!known) {
        if (pds_fuzz_nfiles == PDS_FUZZ_MAX_FILES) abort();
        memcpy(pds_fuzz_files[pds_fuzz_nfiles++], out, 4096);
    }
    f = fopen(out, "wb");
    if (!f || fwrite(data, 1, size, f) != size || fclose(f) != 0) {
        fprintf(stderr, "pds fuzz: cannot write %s\n", out);
        abort();
    }
    return out;
}

/* Is the input one of the skipped kinds (see above)? It is given as up to
   two parts, each read as a file of its own (the OBJ harness writes an OBJ
   and an MTL file); a combination of statements counts across the parts. */
int pds_fuzz_skip(const uint8_t *a, size_t na, const uint8_t *b, size_t nb);
int pds_fuzz_skip(const uint8_t *a, size_t na, const uint8_t *b, size_t nb)
{
    pds__obj_lexer lx;
    pds__obj_token kw, t;
    int multi_mtllib = 0, multi_newmtl = 0, part;
    if (pds_fuzz_unguarded()) return 0;
    for (part = 0; part < 2; part++) {
        if (part == 0) pds__obj_lexer_init(&lx, (const char *)a, na);
        else if (b) pds__obj_lexer_init(&lx, (const char *)b, nb);
        else break;
        while (lx.p < lx.end) {
            int n = 0;
            double v;
            if (pds__obj_next(&lx, &kw)) {
                while (pds__obj_next(&lx, &t)) {
                    if (n++ == 0 && pds__obj_is(&kw, "illum") && pds__obj_parse_double(t.s, t.len, &v) == 1 &&
                        !(v > -2147483649.0 && v < 2147483648.0))
                        return 1;
                }
                multi_mtllib |= n >= 2 && pds__obj_is(&kw, "mtllib");
                multi_newmtl |= n >= 2 && pds__obj_is(&kw, "newmtl");
            }
            pds__obj_end_statement(&lx);
        }
    }
    return multi_mtllib && multi_newmtl;
}

/* fopen for pds.c: the real one for paths inside the temporary directory
   without "..", EACCES for the rest (see the guard above). */
static FILE *pds_fuzz_fopen(const char *path, const char *mode)
{
    size_t n = strlen(pds_fuzz_tmpdir()), len = strlen(path);
    int inside = strncmp(path, pds_fuzz_dir, n) == 0 && path[n] == '/' && !strstr(path + n, "/../") &&
                 !(len >= 3 && strcmp(path + len - 3, "/..") == 0);
    if (!inside && !pds_fuzz_unguarded()) {
        errno = EACCES;
        return NULL;
    }
    return fopen(path, mode);
}

/* The allocators for pds.c: NULL for a block over PDS_FUZZ_MAX_BLOCK (see
   the guard above), else the C library's. */
static void *pds_fuzz_malloc(size_t size)
{
    return size > PDS_FUZZ_MAX_BLOCK && !pds_fuzz_unguarded() ? NULL : malloc(size);
}

static void *pds_fuzz_calloc(size_t count, size_t size)
{
    if (size && count > PDS_FUZZ_MAX_BLOCK / size && !pds_fuzz_unguarded()) return NULL;
    return calloc(count, size);
}

static void *pds_fuzz_realloc(void *p, size_t size)
{
    return size > PDS_FUZZ_MAX_BLOCK && !pds_fuzz_unguarded() ? NULL : realloc(p, size);
}

#endif

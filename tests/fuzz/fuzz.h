/* fuzz.h - what the libFuzzer harnesses in tests/fuzz/ share.

   Each harness is one C file that defines LLVMFuzzerTestOneInput (named
   PDS_FUZZ_ENTRY) and includes this header, which includes pds.c itself
   (as tests/test_main.c does). `make fuzz` builds them all into one
   program, fuzz_all.c (one build of pds.c with the sanitizers instead of
   six), which runs as the harness its name says (a link fuzz_TARGET). The loaders read files by path, so a harness writes its input into
   a private temporary directory (mkdtemp under $TMPDIR or /tmp, made on the
   first input, removed with everything the harnesses wrote when the process
   exits) and calls the public loader on that file.

   Guards (the only places a harness steps between the fuzzer and pds.c;
   PDS_FUZZ_UNGUARDED=1 in the environment turns both off):

   1. Paths. pds.c opens and examines input files only through open and
   stat, which are redirected to pds_fuzz_open and pds_fuzz_stat: they
   refuse, with EACCES, every path outside the temporary directory and
   every path with a ".." component. Scene files (`mesh "PATH"`) and OBJ
   files (`mtllib PATH`) can name any file; the readers refuse special
   files and files past their size limits, but a fuzzer that can read the
   machine's files is not reproducible, and a regular file of 60 MB takes
   long to read under the sanitizers. What the loaders do with a file they
   may open is untouched.

   2. Memory. malloc, calloc and realloc in pds.c are redirected to
   versions that fail (return NULL, as when memory runs out) for any one
   block over PDS_FUZZ_MAX_BLOCK (4 MB). The scene format's documented
   limits let a few bytes ask for tens of millions of triangles (`quad {
   segments 4096 }`: 33.5 million): such a scene is valid and takes minutes
   and gigabytes to load, more still under the sanitizers, and every scene
   fuzzing run ended on one in its first minutes as a timeout. With the cap
   the mesh stops growing at about 350,000 triangles and the BVH build at
   about 65,000 (its binning array takes 64 bytes a triangle), where the
   load fails with PDS_ERR_NOMEM; so the out-of-memory paths are fuzzed
   too: they must free what they allocated and report.

   The first long runs found four bugs, all fixed, whose inputs stay in the
   corpus as finding-*: an MTL `illum` beyond int's range converted to int
   before the range check; an `mtllib` of several names read from freed
   memory after an MTL with a multi-word `newmtl` (the names' tokens were
   refilled by the MTL reader); `mesh "/dev/zero"` and `mtllib /dev/zero`
   read until memory ran out.

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

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/types.h>

static int pds_fuzz_open(const char *path, int flags, ...);
static int pds_fuzz_stat(const char *path, struct stat *sb);
static void *pds_fuzz_malloc(size_t size);
static void *pds_fuzz_calloc(size_t count, size_t size);
static void *pds_fuzz_realloc(void *p, size_t size);

#define open(...) pds_fuzz_open(__VA_ARGS__)
#define stat(p, b) pds_fuzz_stat(p, b)
#define malloc pds_fuzz_malloc
#define calloc pds_fuzz_calloc
#define realloc pds_fuzz_realloc
#include "../../pds.c"
#undef open
#undef stat
#undef malloc
#undef calloc
#undef realloc

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* The name each harness gives its entry point: libFuzzer's own, unless
   fuzz_all.c, which holds every harness in one program, names them. */
#ifndef PDS_FUZZ_ENTRY
#define PDS_FUZZ_ENTRY LLVMFuzzerTestOneInput
#endif

/* Where the readers' harnesses store what they read (so that the reads
   are not optimised away and ASan checks every value). */
static volatile float pds_fuzz_sink;

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

/* Is path one pds.c may read (see the guard above)? */
static int pds_fuzz_allowed(const char *path)
{
    size_t n = strlen(pds_fuzz_tmpdir()), len = strlen(path);
    return pds_fuzz_unguarded() || (strncmp(path, pds_fuzz_dir, n) == 0 && path[n] == '/' &&
                                    !strstr(path + n, "/../") && !(len >= 3 && strcmp(path + len - 3, "/..") == 0));
}

/* open and stat for pds.c: the real ones for allowed paths, EACCES for
   the rest. */
static int pds_fuzz_open(const char *path, int flags, ...)
{
    if (!pds_fuzz_allowed(path)) {
        errno = EACCES;
        return -1;
    }
    return open(path, flags);
}

static int pds_fuzz_stat(const char *path, struct stat *sb)
{
    if (!pds_fuzz_allowed(path)) {
        errno = EACCES;
        return -1;
    }
    return stat(path, sb);
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

/* pds.c - the PDS library: photon differential splatting and its baselines.
   See pds.h for the public contract, README.md for the formats and the
   command line, and the papers cited section by section.

   Table of contents (grep for the tag); each section uses only those
   above it. "not in PDS_NO_X": the switch X (>>config) leaves it out;
   -DPDS_CORE, the small core, leaves out all of those but MTL:
     >>config     feature macros, includes, limits
     >>util       status strings, error reporting, growable arrays, the
                  system layer (threads, clock, files: POSIX or Win32),
                  bounded file reading, string map, exact order-free sums,
                  time
     >>math       3-vectors in double precision, orthonormal bases, transforms
     >>mesh       the triangle store every shape ends up in; material table;
                  glass and mirror normals averaged at footprint scales
     >>rng        counter-based random numbers: f(seed, purpose, index, dim);
                  Halton points; stratified pixel samples (correlated
                  multi-jittered, Kensler 2013)
     >>obj        Wavefront OBJ and MTL loader (MTL not in PDS_NO_MTL)
     >>shapes     generators: sphere, disk, quad, box, cylinder, torus,
                  revolve, heightfield
     >>bvh        binned-SAH BVH, watertight triangle test, traversal
     >>materials  Fresnel (dielectric, conductor), BSDF sampling, Beer
     >>spectral   wavelengths, RGB -> spectrum (Smits 1999), CIE 1931 fit
                  (Wyman et al. 2013) -> XYZ -> sRGB, dispersive materials
                  (not in PDS_NO_SPECTRAL)
     >>lights     light selection, next-event sampling, photon emission;
                  the environment light (constant, CIE clear sky, sun; not
                  in PDS_NO_ENV)
     >>kdtree     balanced kd-tree (eye-path map): the splats' ellipse query;
                  range and k-nearest queries (not in PDS_CORE)
     >>scene      the pds_scene value and its text format parser, with
                  include and variables (define, $NAME, -D); a bare OBJ
                  in its studio
     >>differentials  photon differentials: emission (eqs. 2-6), transfer,
                  reflection, refraction (Igehy 1999), the normal's
                  derivative at a footprint's scale, footprint, eq. 12
     >>image      PFM read/write (with a metadata trailer), PNG write (tEXt
                  metadata, tone curves: clamp, Reinhard 2002, Narkowicz's
                  ACES fit), OpenEXR write and read (deflate, inflate)
                  (PNG and OpenEXR not in PDS_NO_PNG)
     >>metrics    RMSE and SSIM
     >>partial    the exact state of a render or a shard of it: the image
                  from it, merging shards, the partial file (not in
                  PDS_NO_PARTIAL_FILE)
     >>render     camera (pinhole, thin lens), path tracer and eye pass (the
                  photon methods' eye chains split at glass; a pixel's
                  samples on one flat patch merged for the splats), preview,
                  row scheduler
     >>debug      teaching views: colour bars and a bitmap font, camera
                  projection and what the camera sees, the views'
                  per-thread counts, the photon path recorder and the
                  paths OBJ
     >>pds        photon differential splatting: aimed caustic photons,
                  tracing with differentials, splatting into the eye-path
                  map; progressive passes and their eye rounds
     >>baselines  pm, pdm, splat, ppm (not in PDS_NO_BASELINES)
     >>streams    streamed photon mapping (spm): streams of a leading photon
                  and associated photons, concentrated at specular surfaces,
                  gathered stream by stream (eqs. 1-2); for caustics (its
                  streams in gi's global map are in >>gi; spm's full image,
                  gi's with both, in >>api) (not in PDS_NO_BASELINES)
     >>photonpass the photon pass all photon methods share: time budgets
                  (the map methods' plan in rounds from probes, the
                  paper's PDS's a + b/N plan), tracing threads, gathers,
                  the caustic image
     >>gi         Jensen's two-pass global illumination: global photon map
                  (single photons less their first hits, or streams:
                  seed paper 003's streams where they mean something),
                  shadow photons, importance-sampled final gather whose
                  end x2 takes its direct light from a light sample and
                  the rest from the map (a short gather: the map's
                  caustic photons and one more bounce), precomputed
                  irradiance (Christensen 1999) from halves of the map,
                  caustics from any caustic method, spectral rays and
                  photons (not in PDS_NO_GI)
     >>isc        image-space caustics (Wyman and Davis 2006): light-space
                  photon buffer, points, quads, eye- and light-space
                  gathers, temporal filter, animation frames, static
                  lighting, spectral photons (not in PDS_NO_ISC)
     >>api        public entry points: render (spm's full image as gi's
                  with streams), options, teaching views, trace-photon,
                  benchmarks (not in PDS_NO_BENCH)
*/

/* ===================================================================== */
/* >>config                                                              */
/* ===================================================================== */
/* Everything is C99 but a few system services, each behind one small
   function in >>util (the thread layer, the clock, the processor count,
   the physical memory, reading a file and the process id): POSIX
   (open/fstat, clock_gettime, sysconf, pthreads) by default, Win32 when
   _WIN32 is defined (MinGW-w64 and MSVC). */
#ifndef _WIN32
#define _POSIX_C_SOURCE 200809L
#endif

/* The small core (README "A small core"): -DPDS_CORE leaves out every
   extra below but the MTL libraries; each can also be left out alone.
   What stays is the method: scenes, OBJ geometry, BVH, materials,
   lights, the eye pass and path tracer, photon differentials, splatting,
   PFM images, metrics and the teaching views. What is left out refuses
   at run time with a message that names its switch.
     PDS_NO_PNG        the PNG and OpenEXR writers, the OpenEXR reader
                       and their deflate coder (write .pfm)
     PDS_NO_BASELINES  pm, pdm, splat, ppm and spm (pds, pt stay)
     PDS_NO_GI         Jensen's two-pass global illumination (>>gi), and
                       with it spm's full image (spm caustics stay)
     PDS_NO_ISC        image-space caustics and animation frames (>>isc)
     PDS_NO_ENV        the environment light: constant, CIE clear sky and
                       sun (>>lights; the parser refuses 'light environment')
     PDS_NO_SPECTRAL   spectral rendering (>>spectral): a render with a
                       dispersive material or pds_options.spectral is
                       refused; the parser still reads dispersion laws
     PDS_NO_PARTIAL_FILE  writing and reading partial files (>>partial:
                       pds_partial_write and _read refuse; the state of
                       a render and merging shards in memory stay)
     PDS_NO_BENCH      pds_bench_* (they return PDS_ERR_INVALID_ARG)
     PDS_NO_MTL        MTL material libraries (OBJ faces get the default
                       material) */
#ifdef PDS_CORE
#define PDS_NO_PNG 1
#define PDS_NO_BASELINES 1
#define PDS_NO_BENCH 1
#define PDS_NO_GI 1
#define PDS_NO_ISC 1
#define PDS_NO_ENV 1
#define PDS_NO_SPECTRAL 1
#define PDS_NO_PARTIAL_FILE 1
#endif

#include "pds.h"

#include <ctype.h>
#include <errno.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <sys/stat.h>
#include <sys/types.h>
#ifdef _WIN32
#define WIN32_LEAN_AND_MEAN
#include <windows.h>
#include <fcntl.h>
#include <io.h>
#include <process.h>
#else
#include <fcntl.h>
#include <pthread.h>
#include <unistd.h>
#endif

#define PDS__PI 3.14159265358979323846

/* A PFM the readers accept: the header, the largest raster allowed and a
   metadata trailer (>>image). */
#define PDS__MAX_PFM_BYTES ((size_t)PDS_MAX_RESOLUTION * PDS_MAX_RESOLUTION * 12u + 65536u)

/* ===================================================================== */
/* >>util                                                                */
/* ===================================================================== */
/* Errors are values: every failing function fills a caller-owned
   pds_error (which may be NULL) and returns its status. */

const char *pds_status_string(pds_status status)
{
    switch (status) {
    case PDS_OK: return "ok";
    case PDS_ERR_IO: return "input/output error";
    case PDS_ERR_PARSE: return "parse error";
    case PDS_ERR_NOMEM: return "out of memory";
    case PDS_ERR_INVALID_ARG: return "invalid argument";
    case PDS_ERR_LIMIT: return "limit exceeded";
    }
    return "unknown status";
}

/* Fill *err (if any) and return status. file may be NULL; line/column 0
   mean unknown. err->text gets the printable "FILE:LINE:COLUMN: message". */
static pds_status pds__fail(pds_error *err, pds_status status, const char *file,
                            int line, int column, const char *fmt, ...)
{
    va_list ap;
    if (!err) return status;
    err->status = status;
    err->file[0] = '\0';
    if (file) {
        strncpy(err->file, file, sizeof err->file - 1);
        err->file[sizeof err->file - 1] = '\0';
    }
    err->line = line;
    err->column = column;
    va_start(ap, fmt);
    vsnprintf(err->message, sizeof err->message, fmt, ap);
    va_end(ap);
    if (err->file[0] == '\0')
        snprintf(err->text, sizeof err->text, "%s", err->message);
    else if (line > 0 && column > 0)
        snprintf(err->text, sizeof err->text, "%s:%d:%d: %s", err->file, line, column, err->message);
    else if (line > 0)
        snprintf(err->text, sizeof err->text, "%s:%d: %s", err->file, line, err->message);
    else
        snprintf(err->text, sizeof err->text, "%s: %s", err->file, err->message);
    return status;
}

static pds_status pds__nomem(pds_error *err)
{
    return pds__fail(err, PDS_ERR_NOMEM, NULL, 0, 0, "out of memory");
}

const char *pds_error_string(const pds_error *err)
{
    return err ? err->text : "no error information";
}

/* Grow *ptr (an array of elem-byte items with capacity *cap) so that it holds
   at least need items. Capacity doubles, so appends are amortised O(1).
   Returns 0 on success, -1 when memory runs out (the array is unchanged). */
static int pds__grow(void **ptr, size_t *cap, size_t need, size_t elem)
{
    size_t ncap;
    void *p;
    if (need <= *cap) return 0;
    ncap = *cap ? *cap : 16;
    while (ncap < need) {
        if (ncap > ((size_t)-1) / 2 / elem) return -1;
        ncap *= 2;
    }
    p = realloc(*ptr, ncap * elem);
    if (!p) return -1;
    *ptr = p;
    *cap = ncap;
    return 0;
}

/* Copy at most n-1 bytes and terminate. */
static void pds__strlcpy(char *dst, const char *src, size_t n)
{
    size_t len = strlen(src);
    if (len >= n) len = n - 1;
    memcpy(dst, src, len);
    dst[len] = '\0';
}

/* --- the system layer ------------------------------------------------------
   The few calls C99 lacks, for POSIX and for Windows (MinGW-w64, MSVC). */

#ifdef _WIN32
#define PDS__S_ISREG(m) (((m) & _S_IFMT) == _S_IFREG)
#define PDS__S_ISDIR(m) (((m) & _S_IFMT) == _S_IFDIR)
typedef struct _stat64 pds__stat;
static int pds__open_read(const char *path) { return _open(path, _O_RDONLY | _O_BINARY); }
static int pds__fstat(int fd, pds__stat *sb) { return _fstat64(fd, sb); }
static int pds__stat_path(const char *path, pds__stat *sb) { return _stat64(path, sb); }
static void pds__close(int fd) { _close(fd); }
static long pds__read_some(int fd, char *buf, size_t n)
{
    return (long)_read(fd, buf, (unsigned)(n > 0x40000000u ? 0x40000000u : n));
}
static long pds__process_id(void) { return (long)_getpid(); }
#else
#define PDS__S_ISREG(m) S_ISREG(m)
#define PDS__S_ISDIR(m) S_ISDIR(m)
typedef struct stat pds__stat;
/* non-blocking, so that even a FIFO does not stall before it is refused */
static int pds__open_read(const char *path) { return open(path, O_RDONLY | O_NONBLOCK); }
static int pds__fstat(int fd, pds__stat *sb) { return fstat(fd, sb); }
static int pds__stat_path(const char *path, pds__stat *sb) { return stat(path, sb); }
static void pds__close(int fd) { close(fd); }
static long pds__read_some(int fd, char *buf, size_t n) { return (long)read(fd, buf, n); }
static long pds__process_id(void) { return (long)getpid(); }
#endif

/* Threads: a mutex, the calling thread's identity, and n threads running
   one function (pds__threads_run). POSIX threads, or Win32 threads and
   critical sections. Nothing in PDS needs atomics: shared counters are
   guarded by a mutex. */
#ifdef _WIN32
typedef CRITICAL_SECTION pds__mutex;
typedef DWORD pds__thread_id;
static void pds__mutex_init(pds__mutex *m) { InitializeCriticalSection(m); }
static void pds__mutex_destroy(pds__mutex *m) { DeleteCriticalSection(m); }
static void pds__mutex_lock(pds__mutex *m) { EnterCriticalSection(m); }
static void pds__mutex_unlock(pds__mutex *m) { LeaveCriticalSection(m); }
static pds__thread_id pds__thread_self(void) { return GetCurrentThreadId(); }
static int pds__thread_equal(pds__thread_id a, pds__thread_id b) { return a == b; }
typedef struct pds__win_start { void *(*fn)(void *); void *arg; } pds__win_start;
static DWORD WINAPI pds__win_thread(LPVOID p)
{
    const pds__win_start *w = (const pds__win_start *)p;
    w->fn(w->arg);
    return 0;
}
#else
typedef pthread_mutex_t pds__mutex;
typedef pthread_t pds__thread_id;
static void pds__mutex_init(pds__mutex *m) { pthread_mutex_init(m, NULL); }
static void pds__mutex_destroy(pds__mutex *m) { pthread_mutex_destroy(m); }
static void pds__mutex_lock(pds__mutex *m) { pthread_mutex_lock(m); }
static void pds__mutex_unlock(pds__mutex *m) { pthread_mutex_unlock(m); }
static pds__thread_id pds__thread_self(void) { return pthread_self(); }
static int pds__thread_equal(pds__thread_id a, pds__thread_id b) { return pthread_equal(a, b) != 0; }
#endif

/* Run fn(arg) on n threads, at most 256 (the caller's thread is one of
   them). Returns the number of threads that ran. */
static int pds__threads_run(int n, void *(*fn)(void *), void *arg)
{
#ifdef _WIN32
    HANDLE tid[256];
    pds__win_start start;
#else
    pthread_t tid[256];
#endif
    int started = 0, i;
    if (n > 256) n = 256;
#ifdef _WIN32
    start.fn = fn;
    start.arg = arg;
    for (i = 1; i < n; i++) {
        tid[started] = CreateThread(NULL, 0, pds__win_thread, &start, 0, NULL);
        if (!tid[started]) break;
        started++;
    }
#else
    for (i = 1; i < n; i++) {
        if (pthread_create(&tid[started], NULL, fn, arg) != 0) break;
        started++;
    }
#endif
    fn(arg);
#ifdef _WIN32
    for (i = 0; i < started; i++) {
        WaitForSingleObject(tid[i], INFINITE);
        CloseHandle(tid[i]);
    }
#else
    for (i = 0; i < started; i++) pthread_join(tid[i], NULL);
#endif
    return started + 1;
}

/* Read a whole file into a NUL-terminated buffer, refusing what cannot be
   read in bounded time and memory: anything that is not a regular file (a
   FIFO would block forever, /dev/zero never ends; opened non-blocking so
   that even a FIFO does not stall before it is refused), and a file larger
   than max_bytes (checked before anything is allocated). kind names the
   file's role in messages ("scene file", "OBJ file", ...). */
static pds_status pds__read_file(const char *path, size_t max_bytes, const char *kind, char **out, size_t *size,
                                 pds_error *err)
{
    pds__stat sb;
    char *buf;
    size_t len = 0, want;
    int fd;
    *out = NULL;
    fd = pds__open_read(path);
    if (fd < 0) {
        int e = errno;
        /* Windows will not open a folder at all (EACCES): say what it is */
        if (pds__stat_path(path, &sb) == 0 && PDS__S_ISDIR(sb.st_mode))
            return pds__fail(err, PDS_ERR_IO, path, 0, 0, "is a directory");
        return pds__fail(err, PDS_ERR_IO, path, 0, 0, "cannot open: %s", strerror(e));
    }
    if (pds__fstat(fd, &sb) != 0) {
        int e = errno;
        pds__close(fd);
        return pds__fail(err, PDS_ERR_IO, path, 0, 0, "cannot read: %s", strerror(e));
    }
    if (!PDS__S_ISREG(sb.st_mode)) {
        pds__close(fd);
        return pds__fail(err, PDS_ERR_IO, path, 0, 0, "%s", PDS__S_ISDIR(sb.st_mode) ? "is a directory" : "not a regular file");
    }
    if (sb.st_size < 0 || (unsigned long long)sb.st_size > (unsigned long long)max_bytes) {
        pds__close(fd);
        return pds__fail(err, PDS_ERR_LIMIT, path, 0, 0, "%.0f bytes is larger than the limit of %.0f bytes for a %s",
                         (double)sb.st_size, (double)max_bytes, kind);
    }
    want = (size_t)sb.st_size;
    buf = (char *)malloc(want + 2);
    if (!buf) {
        pds__close(fd);
        return pds__nomem(err);
    }
    /* one byte more than the size: a file that grew while being read is
       refused rather than read in part */
    while (len < want + 1) {
        long n = pds__read_some(fd, buf + len, want + 1 - len);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) {
            int e = errno;
            pds__close(fd);
            free(buf);
            return pds__fail(err, PDS_ERR_IO, path, 0, 0, "read error: %s", strerror(e));
        }
        if (n == 0) break;
        len += (size_t)n;
    }
    pds__close(fd);
    if (len != want) {
        free(buf);
        return pds__fail(err, PDS_ERR_IO, path, 0, 0, "the file changed while it was read");
    }
    buf[len] = '\0';
    *out = buf;
    if (size) *size = len;
    return PDS_OK;
}

/* Can path be read as an input file? 0 if it is a regular file, else an
   errno value (stat's), or -1 for a FIFO, device, socket or directory.
   Never opens the file, so a FIFO cannot block it. */
static int pds__input_file_check(const char *path)
{
    pds__stat sb;
#ifdef _WIN32
    if (_stat64(path, &sb) != 0) return errno ? errno : ENOENT;
#else
    if (stat(path, &sb) != 0) return errno ? errno : ENOENT;
#endif
    return PDS__S_ISREG(sb.st_mode) ? 0 : -1;
}

/* The reason pds__input_file_check gave, as text. */
static const char *pds__input_file_problem(int code)
{
    return code == -1 ? "not a regular file" : strerror(code);
}

/* Refuse text whose longest line is longer than PDS_MAX_LINE_BYTES, naming
   the first such line. */
static pds_status pds__check_lines(const char *path, const char *text, size_t size, pds_error *err)
{
    const char *p = text, *end = text + size;
    int line = 1;
    while (p < end) {
        const char *nl = (const char *)memchr(p, '\n', (size_t)(end - p));
        size_t n = (size_t)((nl ? nl : end) - p);
        if (n > (size_t)PDS_MAX_LINE_BYTES)
            return pds__fail(err, PDS_ERR_LIMIT, path, line, 0, "line of %lu bytes is longer than the limit of %d",
                             (unsigned long)n, PDS_MAX_LINE_BYTES);
        if (!nl) break;
        p = nl + 1;
        if (line < INT_MAX) line++;
    }
    return PDS_OK;
}

/* Write size bytes to path atomically: to "path.tmp-PID" first (pds.h
   promises that name, so signal handlers can remove it), then
   rename, so readers never see a half-written file and a failure leaves no
   file behind. */
static pds_status pds__write_file_atomic(const char *path, const void *data, size_t size,
                                         pds_error *err)
{
    char tmp[4096];
    FILE *f;
    int ok;
    static const char suffix[] = ".tmp-";
    if (strlen(path) + sizeof suffix + 24 > sizeof tmp)
        return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "output path too long");
    snprintf(tmp, sizeof tmp, "%s%s%ld", path, suffix, pds__process_id());
    f = fopen(tmp, "wb");
    if (!f) return pds__fail(err, PDS_ERR_IO, path, 0, 0, "cannot write: %s", strerror(errno));
    ok = fwrite(data, 1, size, f) == size;
    ok = (fclose(f) == 0) && ok;
    if (!ok) {
        remove(tmp);
        return pds__fail(err, PDS_ERR_IO, path, 0, 0, "write failed: %s", strerror(errno));
    }
#ifdef _WIN32
    /* Windows' rename refuses an existing target: replace it in one call */
    if (!MoveFileExA(tmp, path, MOVEFILE_REPLACE_EXISTING)) {
        int e = EACCES;
#else
    if (rename(tmp, path) != 0) {
        int e = errno;
#endif
        remove(tmp);
        return pds__fail(err, PDS_ERR_IO, path, 0, 0, "cannot rename into place: %s", strerror(e));
    }
    return PDS_OK;
}

/* Directory part of a path including the trailing '/', or "" . */
static void pds__dirname(const char *path, char *dir, size_t n)
{
    const char *slash = strrchr(path, '/');
    size_t len = slash ? (size_t)(slash - path + 1) : 0;
    if (len >= n) len = n - 1;
    memcpy(dir, path, len);
    dir[len] = '\0';
}

/* dir + name, unless name is absolute. Returns -1 if it does not fit. */
static int pds__join_path(const char *dir, const char *name, char *out, size_t n)
{
    int w = name[0] == '/' ? snprintf(out, n, "%s", name) : snprintf(out, n, "%s%s", dir, name);
    return (w < 0 || (size_t)w >= n) ? -1 : 0;
}

/* --- string hash map ------------------------------------------------------- */

/* Open-addressing map from strings (owned copies) to ints; capacity is a
   power of two, at most half full. */
typedef struct pds__names {
    char **keys;
    int *vals;
    size_t cap, count;
} pds__names;

static size_t pds__names_hash(const char *s, size_t n)
{
    size_t i;
    unsigned long h = 2166136261UL; /* FNV-1a */
    for (i = 0; i < n; i++) h = ((h ^ (unsigned char)s[i]) * 16777619UL) & 0xFFFFFFFFUL;
    return (size_t)h;
}

/* Slot for key (s, n): where it is, or the empty slot where it would go. */
static size_t pds__names_slot(const pds__names *h, const char *s, size_t n)
{
    size_t i = pds__names_hash(s, n) & (h->cap - 1);
    while (h->keys[i] && !(strlen(h->keys[i]) == n && memcmp(h->keys[i], s, n) == 0))
        i = (i + 1) & (h->cap - 1);
    return i;
}

static int pds__names_find(const pds__names *h, const char *s, size_t n)
{
    size_t i;
    if (h->cap == 0) return -1;
    i = pds__names_slot(h, s, n);
    return h->keys[i] ? h->vals[i] : -1;
}

/* Insert (s, n) -> val unless present. Returns the stored key (the copy),
   or NULL when out of memory. */
static const char *pds__names_put(pds__names *h, const char *s, size_t n, int val)
{
    size_t i;
    if (2 * (h->count + 1) > h->cap) {
        size_t ncap = h->cap ? 2 * h->cap : 64, j;
        char **nk = (char **)calloc(ncap, sizeof *nk);
        int *nv = (int *)malloc(ncap * sizeof *nv);
        pds__names old = *h;
        if (!nk || !nv) {
            free(nk);
            free(nv);
            return NULL;
        }
        h->keys = nk;
        h->vals = nv;
        h->cap = ncap;
        for (j = 0; j < old.cap; j++) {
            if (old.keys[j]) {
                size_t k = pds__names_slot(h, old.keys[j], strlen(old.keys[j]));
                h->keys[k] = old.keys[j];
                h->vals[k] = old.vals[j];
            }
        }
        free(old.keys);
        free(old.vals);
    }
    i = pds__names_slot(h, s, n);
    if (!h->keys[i]) {
        char *copy = (char *)malloc(n + 1);
        if (!copy) return NULL;
        memcpy(copy, s, n);
        copy[n] = '\0';
        h->keys[i] = copy;
        h->vals[i] = val;
        h->count++;
    }
    return h->keys[i];
}

static void pds__names_free(pds__names *h)
{
    size_t i;
    for (i = 0; i < h->cap; i++) free(h->keys[i]);
    free(h->keys);
    free(h->vals);
    memset(h, 0, sizeof *h);
}

/* --- exact, order-free sums ----------------------------------------------
   The photon methods add millions of small positive terms into every pixel
   from several threads. Floating-point addition is not associative, so a
   float sum would depend on which thread added what first. Instead each
   pixel channel is a 128-bit unsigned integer counting "units": a term v
   becomes round(v * unit) on its own (the rounding depends on the term
   alone), and integer additions are exact and commutative, so the total is
   the same bit for bit whatever the order, the thread count or the split
   of the work.

   unit is a power of two chosen per render from the light powers and the
   scene's size (pds__sum_unit), so that the scene's typical radiance is
   about 2^64 units: 63 bits of headroom above it before a sum saturates
   (a focus 10^18 times brighter than the mean) and 64 below it, so a pixel
   at 10^-6 of the typical radiance still has 13 significant digits. Being
   a power of two tied to the light power, it makes the precision the same
   at any light level or scene scale (the fixed 2^-32 resolution this
   replaces lost all of a caustic lit 10^-9 times as brightly). */
typedef struct pds__sum128 {
    uint64_t lo, hi;
} pds__sum128;

#define PDS__TWO64 18446744073709551616.0 /* 2^64 */
#define PDS__TWO63 9223372036854775808.0  /* 2^63 */
#define PDS__SUM_ADDED 0
#define PDS__SUM_SATURATED 1
#define PDS__SUM_INVALID 2

/* a += (hi 2^64 + lo); on overflow a stays at its largest value and 1 is
   returned. */
static int pds__sum128_add_bits(pds__sum128 *a, uint64_t lo, uint64_t hi)
{
    uint64_t sum_lo = a->lo + lo, sum_hi = a->hi + hi;
    int over = sum_hi < a->hi;
    if (sum_lo < lo) {
        sum_hi++;
        over |= sum_hi == 0;
    }
    if (over) {
        a->lo = a->hi = UINT64_MAX;
        return 1;
    }
    a->lo = sum_lo;
    a->hi = sum_hi;
    return 0;
}

/* a += round(f), f already in units. Returns PDS__SUM_ADDED, or
   PDS__SUM_SATURATED when the term passed 2^127 or the total 2^128 (the
   sum then stays at its largest value), or PDS__SUM_INVALID for a
   negative, infinite or NaN term (not added). */
static int pds__sum128_add(pds__sum128 *a, double f)
{
    if (!(f >= 0.0) || f == HUGE_VAL) return PDS__SUM_INVALID;
    if (f < PDS__TWO63) /* f + 0.5 <= 2^63: fits */
        return pds__sum128_add_bits(a, (uint64_t)(f + 0.5), 0) ? PDS__SUM_SATURATED : PDS__SUM_ADDED;
    if (f < PDS__TWO64 * PDS__TWO63) {
        /* f >= 2^63 is a multiple of 2^11: floor(f / 2^64) and the
           remainder f - hi 2^64 (< 2^64, at most 53 bits) are exact */
        double h = floor(f / PDS__TWO64);
        return pds__sum128_add_bits(a, (uint64_t)(f - h * PDS__TWO64), (uint64_t)h) ? PDS__SUM_SATURATED
                                                                                   : PDS__SUM_ADDED;
    }
    a->lo = a->hi = UINT64_MAX;
    return PDS__SUM_SATURATED;
}

/* The sum in units, as a double (rounded once per half). */
static double pds__sum128_value(pds__sum128 a)
{
    return (double)a.hi * PDS__TWO64 + (double)a.lo;
}

/* The output image from the double sums: no output holds NaN or infinity.
   NaN becomes 0, a value beyond the float range the largest float of its
   sign; returns how many were replaced. */
static long pds__finite_floats(const double *in, float *out, size_t n)
{
    long replaced = 0;
    size_t i;
    for (i = 0; i < n; i++) {
        double v = in[i];
        if (v != v) {
            v = 0.0;
            replaced++;
        } else if (fabs(v) > FLT_MAX) {
            v = v > 0.0 ? FLT_MAX : -FLT_MAX;
            replaced++;
        }
        out[i] = (float)v;
    }
    return replaced;
}

/* Physical memory of this machine in bytes, 0 if the system does not say. */
static double pds__physical_memory(void)
{
#ifdef _WIN32
    MEMORYSTATUSEX ms;
    ms.dwLength = sizeof ms;
    if (GlobalMemoryStatusEx(&ms)) return (double)ms.ullTotalPhys;
#elif defined(_SC_PHYS_PAGES) && defined(_SC_PAGESIZE)
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages > 0 && page > 0) return (double)pages * (double)page;
#endif
    return 0.0;
}

double pds_time_now(void)
{
#ifdef _WIN32
    LARGE_INTEGER f, c;
    QueryPerformanceFrequency(&f);
    QueryPerformanceCounter(&c);
    return (double)c.QuadPart / (double)f.QuadPart;
#else
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
#endif
}

int pds_cpu_count(void)
{
#ifdef _WIN32
    SYSTEM_INFO si;
    long n;
    GetSystemInfo(&si);
    n = (long)si.dwNumberOfProcessors;
#else
    long n = sysconf(_SC_NPROCESSORS_ONLN);
#endif
    if (n < 1) return 1;
    if (n > 256) return 256;
    return (int)n;
}

/* ===================================================================== */
/* >>math                                                                */
/* ===================================================================== */
/* Double-precision 3-vectors for everything but the BVH's hot loop, which
   keeps its own float copies. */

typedef pds_vec3 pds__v3;

static pds__v3 pds__v(double x, double y, double z) { pds__v3 r; r.x = x; r.y = y; r.z = z; return r; }
static pds__v3 pds__add(pds__v3 a, pds__v3 b) { return pds__v(a.x + b.x, a.y + b.y, a.z + b.z); }
static pds__v3 pds__sub(pds__v3 a, pds__v3 b) { return pds__v(a.x - b.x, a.y - b.y, a.z - b.z); }
static pds__v3 pds__scale(pds__v3 a, double s) { return pds__v(a.x * s, a.y * s, a.z * s); }
#ifndef PDS_NO_BENCH
static pds__v3 pds__mul(pds__v3 a, pds__v3 b) { return pds__v(a.x * b.x, a.y * b.y, a.z * b.z); }
#endif
static double pds__dot(pds__v3 a, pds__v3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static pds__v3 pds__cross(pds__v3 a, pds__v3 b)
{
    return pds__v(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static double pds__length(pds__v3 a) { return sqrt(pds__dot(a, a)); }
/* Unit vector along a; the zero vector stays zero. */
static pds__v3 pds__normalize(pds__v3 a)
{
    double l = pds__length(a);
    return l > 0.0 ? pds__scale(a, 1.0 / l) : a;
}
static pds__v3 pds__vmin(pds__v3 a, pds__v3 b)
{
    return pds__v(a.x < b.x ? a.x : b.x, a.y < b.y ? a.y : b.y, a.z < b.z ? a.z : b.z);
}
static pds__v3 pds__vmax(pds__v3 a, pds__v3 b)
{
    return pds__v(a.x > b.x ? a.x : b.x, a.y > b.y ? a.y : b.y, a.z > b.z ? a.z : b.z);
}
static double pds__v3_get(pds__v3 a, int axis) { return axis == 0 ? a.x : axis == 1 ? a.y : a.z; }

/* Orthonormal basis (b1, b2) perpendicular to unit n, continuous except at
   n = -z (Frisvad 2012, "Building an orthonormal basis from a 3D unit
   vector without normalization", with the singularity branch). */
static void pds__onb(pds__v3 n, pds__v3 *b1, pds__v3 *b2)
{
    if (n.z < -0.9999999) {
        *b1 = pds__v(0.0, -1.0, 0.0);
        *b2 = pds__v(-1.0, 0.0, 0.0);
    } else {
        double a = 1.0 / (1.0 + n.z);
        double b = -n.x * n.y * a;
        *b1 = pds__v(1.0 - n.x * n.x * a, b, -n.x);
        *b2 = pds__v(b, 1.0 - n.y * n.y * a, -n.y);
    }
}

/* 3x4 affine transform: p' = M p + t, rows m[0..2] = (m00 m01 m02 t0). */
typedef struct pds__xform { double m[3][4]; } pds__xform;

static pds__xform pds__xform_identity(void)
{
    pds__xform x;
    int i, j;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 4; j++) x.m[i][j] = (i == j) ? 1.0 : 0.0;
    return x;
}

/* a after b: (a*b)(p) = a(b(p)). */
static pds__xform pds__xform_mul(const pds__xform *a, const pds__xform *b)
{
    pds__xform r;
    int i, j;
    for (i = 0; i < 3; i++) {
        for (j = 0; j < 4; j++) {
            r.m[i][j] = a->m[i][0] * b->m[0][j] + a->m[i][1] * b->m[1][j] + a->m[i][2] * b->m[2][j];
        }
        r.m[i][3] += a->m[i][3];
    }
    return r;
}

static pds__v3 pds__xform_point(const pds__xform *x, pds__v3 p)
{
    return pds__v(x->m[0][0] * p.x + x->m[0][1] * p.y + x->m[0][2] * p.z + x->m[0][3],
                  x->m[1][0] * p.x + x->m[1][1] * p.y + x->m[1][2] * p.z + x->m[1][3],
                  x->m[2][0] * p.x + x->m[2][1] * p.y + x->m[2][2] * p.z + x->m[2][3]);
}

/* Normals transform by the inverse transpose of the linear part; the
   cofactor matrix is that up to the (positive or negative) determinant,
   so the result is normalised and flipped if det < 0 keeps orientation
   consistent with the transformed triangle winding. */
static pds__v3 pds__xform_normal(const pds__xform *x, pds__v3 n)
{
    const double (*m)[4] = x->m;
    double c[3][3], det;
    pds__v3 r;
    c[0][0] = m[1][1] * m[2][2] - m[1][2] * m[2][1];
    c[0][1] = m[1][2] * m[2][0] - m[1][0] * m[2][2];
    c[0][2] = m[1][0] * m[2][1] - m[1][1] * m[2][0];
    c[1][0] = m[0][2] * m[2][1] - m[0][1] * m[2][2];
    c[1][1] = m[0][0] * m[2][2] - m[0][2] * m[2][0];
    c[1][2] = m[0][1] * m[2][0] - m[0][0] * m[2][1];
    c[2][0] = m[0][1] * m[1][2] - m[0][2] * m[1][1];
    c[2][1] = m[0][2] * m[1][0] - m[0][0] * m[1][2];
    c[2][2] = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    det = m[0][0] * c[0][0] + m[0][1] * c[0][1] + m[0][2] * c[0][2];
    r = pds__v(c[0][0] * n.x + c[0][1] * n.y + c[0][2] * n.z,
               c[1][0] * n.x + c[1][1] * n.y + c[1][2] * n.z,
               c[2][0] * n.x + c[2][1] * n.y + c[2][2] * n.z);
    if (det < 0.0) r = pds__scale(r, -1.0);
    return pds__normalize(r);
}

/* Determinant of the linear part (negative = mirroring). */
static double pds__xform_det(const pds__xform *x)
{
    const double (*m)[4] = x->m;
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
         - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
         + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

/* ===================================================================== */
/* >>mesh                                                                */
/* ===================================================================== */
/* Every shape, generated or loaded, ends up as indexed triangles in one
   pds__mesh: vertex positions and shading normals (float, 3 per vertex),
   3 vertex indices and one material index per triangle. A vertex carries
   exactly one normal, so loaders split vertices where normals differ.

   Layout: pos[3*i..3*i+2] position of vertex i (scene units), nrm[...] its
   unit shading normal; idx[3*t..3*t+2] the corners of triangle t, mat[t]
   its material. */

/* Normals at a footprint's scale (pds__mesh_smooth_normals) */
#define PDS__NORMAL_LEVELS 3   /* averaged fields, over about 2, 4 and 8 edges */
#define PDS__NORMAL_BEND 0.966 /* corners whose normals differ by more (15 degrees) are not averaged together */
#define PDS__NORMAL_NOISE 2.0  /* pds__mesh_normal_diff: the noise ratio above which the averaged fields count */
#define PDS__NORMAL_REACH 1.5  /* pds__mesh_normal_diff: the averaged field's reach over the footprint's width */

typedef struct pds__mesh {
    float *pos, *nrm;
    float *smooth;       /* PDS__NORMAL_LEVELS fields of 3 * nverts: the normals
                            at footprint scales (pds__mesh_smooth_normals);
                            NULL when the normals are smooth. One decision
                            for the whole scene's mesh: beside a noisy mesh a
                            smooth one gets fields too, which its own
                            derivatives, agreeing with them, then ignore */
    size_t nverts, cap_pos, cap_nrm;
    int *idx, *mat;
    size_t ntris, cap_idx, cap_mat;
    long degenerate_dropped; /* zero-area triangles refused by add_tri */
    long beyond_limit;       /* vertices past +-PDS_MAX_COORD (or not finite)
                                after their transform, stored as 0: the
                                loader that added them reports an error */
} pds__mesh;

static void pds__mesh_free(pds__mesh *m)
{
    free(m->pos);
    free(m->nrm);
    free(m->smooth);
    free(m->idx);
    free(m->mat);
    memset(m, 0, sizeof *m);
}

/* Append a vertex; returns its index or -1 (out of memory or limit). */
static long pds__mesh_add_vertex(pds__mesh *m, pds__v3 p, pds__v3 n)
{
    size_t i = m->nverts;
    if (i >= (size_t)INT_MAX / 4) return -1;
    if (pds__grow((void **)&m->pos, &m->cap_pos, 3 * (i + 1), sizeof(float))) return -1;
    if (pds__grow((void **)&m->nrm, &m->cap_nrm, 3 * (i + 1), sizeof(float))) return -1;
    if (!(fabs(p.x) <= PDS_MAX_COORD && fabs(p.y) <= PDS_MAX_COORD && fabs(p.z) <= PDS_MAX_COORD)) {
        /* converting such a value to float could overflow (undefined) */
        m->beyond_limit++;
        p = n = pds__v(0.0, 0.0, 0.0);
    }
    if (!(fabs(n.x) <= 2.0 && fabs(n.y) <= 2.0 && fabs(n.z) <= 2.0)) n = pds__v(0.0, 0.0, 0.0);
    m->pos[3 * i + 0] = (float)p.x;
    m->pos[3 * i + 1] = (float)p.y;
    m->pos[3 * i + 2] = (float)p.z;
    m->nrm[3 * i + 0] = (float)n.x;
    m->nrm[3 * i + 1] = (float)n.y;
    m->nrm[3 * i + 2] = (float)n.z;
    m->nverts = i + 1;
    return (long)i;
}

static pds__v3 pds__mesh_pos(const pds__mesh *m, long i)
{
    return pds__v(m->pos[3 * i], m->pos[3 * i + 1], m->pos[3 * i + 2]);
}

static pds__v3 pds__mesh_nrm(const pds__mesh *m, long i)
{
    return pds__v(m->nrm[3 * i], m->nrm[3 * i + 1], m->nrm[3 * i + 2]);
}

/* Twice the area of triangle (a, b, c) from the stored (float) positions. */
static double pds__mesh_tri_area2(const pds__mesh *m, long a, long b, long c)
{
    pds__v3 pa = pds__mesh_pos(m, a), pb = pds__mesh_pos(m, b), pc = pds__mesh_pos(m, c);
    return pds__length(pds__cross(pds__sub(pb, pa), pds__sub(pc, pa)));
}

/* Append triangle (a, b, c) with material mat. A triangle of zero area (as
   stored in float) is dropped and counted, never stored: it can only cause
   trouble (NaN normals, zero-area light sampling). Returns 1 if added, 0 if
   dropped, -1 when out of memory or over PDS_MAX_TRIANGLES. */
static int pds__mesh_add_tri(pds__mesh *m, long a, long b, long c, int mat)
{
    size_t t = m->ntris;
    double area2 = pds__mesh_tri_area2(m, a, b, c);
    if (!(area2 > 0.0) || a == b || b == c || a == c) {
        m->degenerate_dropped++;
        return 0;
    }
    if (t >= (size_t)PDS_MAX_TRIANGLES) return -1;
    if (pds__grow((void **)&m->idx, &m->cap_idx, 3 * (t + 1), sizeof(int))) return -1;
    if (pds__grow((void **)&m->mat, &m->cap_mat, t + 1, sizeof(int))) return -1;
    m->idx[3 * t + 0] = (int)a;
    m->idx[3 * t + 1] = (int)b;
    m->idx[3 * t + 2] = (int)c;
    m->mat[t] = mat;
    m->ntris = t + 1;
    return 1;
}

/* Material table shared by the scene parser and the OBJ/MTL loader. */
typedef struct pds__materials {
    pds_material *items;
    size_t count, cap;
    pds__names index;   /* name -> first material of that name */
} pds__materials;

/* Index of the material called name, or -1 (a hash look-up: 65,536
   materials parse in milliseconds, not the 43 s a linear search took). */
static int pds__materials_find(const pds__materials *ms, const char *name)
{
    return pds__names_find(&ms->index, name, strlen(name));
}

static void pds__materials_free(pds__materials *ms)
{
    free(ms->items);
    pds__names_free(&ms->index);
    memset(ms, 0, sizeof *ms);
}

/* Forget the materials from index n on (an OBJ that failed to load). */
static int pds__materials_truncate(pds__materials *ms, size_t n)
{
    size_t i;
    pds__names_free(&ms->index);
    ms->count = n;
    for (i = 0; i < n; i++)
        if (!pds__names_put(&ms->index, ms->items[i].name, strlen(ms->items[i].name), (int)i)) return -1;
    return 0;
}

/* A white diffuse material called name (the default for anything). */
static pds_material pds__material_default(const char *name)
{
    pds_material m;
    memset(&m, 0, sizeof m);
    pds__strlcpy(m.name, name, sizeof m.name);
    m.type = PDS_MAT_DIFFUSE;
    m.albedo[0] = m.albedo[1] = m.albedo[2] = 0.8;
    m.ior = 1.5;
    m.outside_ior = 1.0;
    m.roughness = 0.2;
    return m;
}

/* Append; returns the new index, or -1 out of memory / over the limit. */
static int pds__materials_add(pds__materials *ms, const pds_material *m)
{
    if (ms->count >= (size_t)PDS_MAX_MATERIALS) return -1;
    if (pds__grow((void **)&ms->items, &ms->cap, ms->count + 1, sizeof *ms->items)) return -1;
    if (!pds__names_put(&ms->index, m->name, strlen(m->name), (int)ms->count)) return -1;
    ms->items[ms->count] = *m;
    return (int)ms->count++;
}

/* Normals at the scale of a footprint (an extension). The vertex normals
   of a scanned or exported mesh carry noise from one triangle to the next,
   so the derivative of the interpolated normal within one triangle is the
   noise's, often many times the surface's curvature. A photon whose
   footprint spans many such triangles extrapolated it over the footprint
   and was spread as if the glass were that curved, though the light those
   normals really scatter is already in the photons' own directions: on a
   glass sphere whose vertex normals were tilted at random by 0.085 rad,
   the floor around its caustic got 21% too much light at 2 million
   photons, blurred out of the focus (light-traced reference), where pm
   converged. The derivative a footprint needs is that of the normal field
   at its own scale (pds__mesh_normal_diff). Field l (1 ..
   PDS__NORMAL_LEVELS) holds the vertex normals averaged 4^l times over
   their one-ring (each vertex with the vertices it shares a triangle
   with, then normalised): a diffusion over about 2^l edges. On a smooth
   tessellation the average keeps the normals (a circle's normals averaged
   over an arc are its normal at the arc's middle), so the derivative stays
   the curvature, while independent noise averages out. Two corners whose
   normals differ by more than PDS__NORMAL_BEND are not averaged together
   (a crease the loader did not split), and only the vertices of mirror,
   conductor and dielectric triangles, over those triangles: a photon's
   differentials turn nowhere else. Normals found smooth after the first
   field (pds__mesh_normals_noisy) keep none: m->smooth stays NULL and
   the per-triangle derivative serves at every scale. Returns -1 out of
   memory. */
/* Are the normals of the active triangles noisy? Along each edge (a, b)
   the normals turn by n_b - n_a, and the first averaged field s1 by
   s1_b - s1_a; smooth normals turn about as their average does, noise
   turns them by several times as much. Noisy when more than 5% of the
   edges turn by more than twice the average's turn plus its change. */
static int pds__mesh_normals_noisy(const pds__mesh *m, const unsigned char *active, const float *s1)
{
    size_t t, edges = 0, noisy = 0;
    for (t = 0; t < m->ntris; t++) {
        const int *ix = &m->idx[3 * t];
        int c, k;
        if (!active[t]) continue;
        for (c = 0; c < 3; c++) {
            size_t a = 3 * (size_t)ix[c], b = 3 * (size_t)ix[(c + 1) % 3];
            double d0 = 0.0, d1 = 0.0;
            for (k = 0; k < 3; k++) {
                double turn0 = (double)m->nrm[b + k] - m->nrm[a + k], turn1 = (double)s1[b + k] - s1[a + k];
                d0 += (turn0 - turn1) * (turn0 - turn1);
                d1 += turn1 * turn1;
            }
            edges++;
            noisy += d0 > PDS__NORMAL_NOISE * PDS__NORMAL_NOISE * d1;
        }
    }
    return noisy > edges / 20;
}

static int pds__mesh_smooth_normals(pds__mesh *m, const pds__materials *mats)
{
    size_t nv = m->nverts, t, i;
    unsigned char *active = NULL;
    double *acc = NULL;
    float *cur, *next;
    int level, any = 0, done = 0;
    free(m->smooth);
    m->smooth = NULL;
    if (nv == 0) return 0;
    active = (unsigned char *)calloc(m->ntris, 1);
    if (!active) return -1;
    for (t = 0; t < m->ntris; t++) {
        pds_material_type ty = m->mat[t] >= 0 && (size_t)m->mat[t] < mats->count ? mats->items[m->mat[t]].type
                                                                                  : PDS_MAT_DIFFUSE;
        active[t] = ty == PDS_MAT_MIRROR || ty == PDS_MAT_CONDUCTOR || ty == PDS_MAT_DIELECTRIC;
        any |= active[t];
    }
    if (!any) {
        free(active);
        return 0;
    }
    m->smooth = (float *)malloc(sizeof(float) * 3 * nv * PDS__NORMAL_LEVELS);
    acc = (double *)malloc(sizeof(double) * 3 * nv);
    next = (float *)malloc(sizeof(float) * 3 * nv);
    if (!m->smooth || !acc || !next) {
        free(m->smooth);
        m->smooth = NULL;
        free(acc);
        free(next);
        free(active);
        return -1;
    }
    cur = m->nrm;
    for (level = 1; level <= PDS__NORMAL_LEVELS; level++) {
        float *dst = m->smooth + 3 * nv * (size_t)(level - 1);
        int total = 1 << (2 * level); /* 4^level averagings from the normals */
        for (; done < total; done++) {
            for (i = 0; i < 3 * nv; i++) acc[i] = cur[i];
            for (t = 0; t < m->ntris; t++) {
                const int *ix = &m->idx[3 * t];
                int c, k;
                if (!active[t]) continue;
                for (c = 0; c < 3; c++) {
                    const float *na = cur + 3 * (size_t)ix[c];
                    int j;
                    for (j = 1; j <= 2; j++) {
                        const float *nb = cur + 3 * (size_t)ix[(c + j) % 3];
                        /* a bend sharper than PDS__NORMAL_BEND between two
                           corners is the shape, not noise: not averaged */
                        if ((double)na[0] * nb[0] + (double)na[1] * nb[1] + (double)na[2] * nb[2] < PDS__NORMAL_BEND) continue;
                        for (k = 0; k < 3; k++) acc[3 * (size_t)ix[c] + (size_t)k] += nb[k];
                    }
                }
            }
            for (i = 0; i < nv; i++) {
                double l = sqrt(acc[3 * i] * acc[3 * i] + acc[3 * i + 1] * acc[3 * i + 1] + acc[3 * i + 2] * acc[3 * i + 2]);
                int k;
                for (k = 0; k < 3; k++) next[3 * i + k] = l > 0.0 ? (float)(acc[3 * i + k] / l) : cur[3 * i + k];
            }
            memcpy(dst, next, sizeof(float) * 3 * nv);
            cur = dst;
        }
        if (level == 1 && !pds__mesh_normals_noisy(m, active, m->smooth)) {
            /* smooth normals: the per-triangle derivative serves at every
               scale, and the other fields are not needed */
            free(m->smooth);
            m->smooth = NULL;
            break;
        }
    }
    free(acc);
    free(next);
    free(active);
    return 0;
}

/* ===================================================================== */
/* >>rng                                                                 */
/* ===================================================================== */
/* Counter-based random numbers: every value is a pure function of
   (seed, purpose, index, dimension), so results never depend on which
   thread asked or in which order. The mixer is the SplitMix64 finaliser
   (Steele, Lea, Flood 2014), applied to a combination of the keys that
   keeps them from cancelling each other (each key is mixed before the
   next is added). */

enum pds__rng_purpose {
    PDS__RNG_PIXEL = 1,   /* index = pixel * spp + sample, dim = 0.. */
    PDS__RNG_BENCH = 2,   /* benchmark rays */
    PDS__RNG_TEST = 3,    /* test programs */
    PDS__RNG_PHOTON = 4,  /* index = photon number, dim = 0.. */
    /* 5: the Halton sequence's per-seed offsets (pds__halton) */
    PDS__RNG_SPLAT = 6,   /* index = photon number, dim = a hash of where it landed */
    PDS__RNG_GLOBAL = 7,  /* gi's global photons: index = photon number */
    PDS__RNG_GATHER = 8,  /* gi's final gather: index = camera sample */
    PDS__RNG_WAVELENGTH = 9, /* index = pixel: its samples' wavelength rotation */
    PDS__RNG_ISC = 10,    /* isc: index = frame, dim 0, 1 = the light-space grid's offset,
                             dim 2, 3 = the photons' and the pixels' wavelength shift */
    PDS__RNG_STRATA = 11, /* index = pixel, dim = pass: the pixel samples' stratification pattern */
    PDS__RNG_LENS = 12,   /* thin lens: index = camera sample (as PIXEL), dim 0, 1 = the lens point */
    PDS__RNG_ENV_NEE = 13, /* the environment's sky parts in next-event estimation:
                             index = camera sample, dim = 4 x the bounce's PIXEL dim + 0..3 */
    PDS__RNG_STREAM = 20  /* gi's streams: index = stream number, dim = PDS__GI_STREAM_DIMS
                             x the leader's bounce + 2 x associated photon + 0, 1 */
};

static uint64_t pds__mix64(uint64_t z)
{
    z += 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static uint64_t pds__rng_bits(uint64_t seed, uint64_t purpose, uint64_t index, uint64_t dim)
{
    uint64_t h = pds__mix64(seed);
    h = pds__mix64(h ^ purpose);
    h = pds__mix64(h ^ index);
    return pds__mix64(h ^ dim);
}

/* Uniform double in [0, 1): the top 53 bits. */
static double pds__rng_uniform(uint64_t seed, uint64_t purpose, uint64_t index, uint64_t dim)
{
    return (double)(pds__rng_bits(seed, purpose, index, dim) >> 11) * (1.0 / 9007199254740992.0);
}

/* Low-discrepancy numbers for photon emission: the Halton sequence (radical
   inverse of the index in the dim-th prime base), shifted modulo 1 by a
   per-(seed, dim) offset (Cranley-Patterson rotation) so that different
   seeds give different, equally well spread point sets. Still a pure
   function of (seed, index, dim). Spreading the photons evenly over the
   lights' area and directions removes most of the low-frequency noise of
   smooth caustics at no cost. dim < 8. */
/* The radical inverse of i in base b, sum_k d_k b^-(k+1) for the digits
   d_k of i. Written out once per base below so that the compiler turns
   the division by a constant into a multiplication (a 64-bit division by
   a variable costs tens of cycles, and each photon takes six of these
   loops); every version does the same arithmetic, so the values do not
   depend on which one runs. */
#define PDS__RADICAL_INVERSE(b)                                                                                        \
    do {                                                                                                               \
        const double inv = 1.0 / (b);                                                                                  \
        double f = inv, r = 0.0;                                                                                       \
        while (i > 0) {                                                                                                \
            r += f * (double)(i % (b));                                                                                \
            i /= (b);                                                                                                  \
            f *= inv;                                                                                                  \
        }                                                                                                              \
        return r;                                                                                                      \
    } while (0)

static double pds__radical_inverse(uint64_t i, int dim)
{
    switch (dim & 7) {
    case 0: PDS__RADICAL_INVERSE(2u);
    case 1: PDS__RADICAL_INVERSE(3u);
    case 2: PDS__RADICAL_INVERSE(5u);
    case 3: PDS__RADICAL_INVERSE(7u);
    case 4: PDS__RADICAL_INVERSE(11u);
    case 5: PDS__RADICAL_INVERSE(13u);
    case 6: PDS__RADICAL_INVERSE(17u);
    default: PDS__RADICAL_INVERSE(19u);
    }
}
#undef PDS__RADICAL_INVERSE

static double pds__halton(uint64_t seed, uint64_t index, int dim)
{
    /* index 0 would give 0 in every dimension */
    double u = pds__radical_inverse(index + 1, dim) + pds__rng_uniform(seed, 5, 0, (uint64_t)dim);
    return u >= 1.0 ? u - 1.0 : u;
}

/* Stratified pixel samples: Kensler's correlated multi-jittered sampling
   (A. Kensler, "Correlated Multi-Jittered Sampling", Pixar Technical Memo
   13-01, 2013). Sample s of n is put in a cell of an m x q grid (m =
   floor(sqrt n), q = ceil(n / m)) and in a row of a finer q x m sub-grid
   inside it, so that the n points are stratified in 2D and in each axis
   alone, for any n; the cells, sub-rows and the order of the samples are
   shuffled by permutations keyed by pattern, and (jx, jy) jitter the
   point within its sub-cell. A pure function of its arguments. */

/* A permutation of 0 .. l-1 keyed by key: three rounds of steps that are
   each a bijection on k-bit numbers (2^k the next power of two from l):
   xor with a key part, multiply by an odd number modulo 2^k, xor with
   itself shifted right, add a key part modulo 2^k; cycle-walked (applied
   again) until the value falls below l, which keeps it a bijection. */
static uint32_t pds__permute(uint32_t i, uint32_t l, uint32_t key)
{
    static const uint32_t odd[3] = {0x9e3779b1u, 0x85ebca77u, 0xc2b2ae3du};
    uint32_t w = l - 1;
    int bits = 0, r;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    while ((w >> bits) != 0) bits++;
    if (l <= 1) return 0;
    do {
        for (r = 0; r < 3; r++) {
            i = (i ^ (key >> (8 * r))) & w;
            i = (i * odd[r]) & w;
            i ^= i >> (bits / 2 + 1);
            i = (i + (key >> (5 + 9 * r))) & w;
        }
    } while (i >= l);
    return i;
}

static void pds__cmj(int s, int n, uint64_t pattern, double jx, double jy, double *x, double *y)
{
    uint32_t p = (uint32_t)pattern, p2 = (uint32_t)(pattern >> 32);
    int m, q, sx, sy, cx, cy;
    if (n <= 1) {
        *x = jx;
        *y = jy;
        return;
    }
    m = (int)sqrt((double)n);
    q = (n + m - 1) / m;
    s = (int)pds__permute((uint32_t)s, (uint32_t)n, p * 0x51633e2du);
    cx = s % m;
    cy = s / m;
    sx = (int)pds__permute((uint32_t)cx, (uint32_t)m, p2 * 0x68bc21ebu);
    sy = (int)pds__permute((uint32_t)cy, (uint32_t)q, p2 * 0x02e5be93u);
    *x = (cx + (sy + jx) / q) / m;
    *y = (cy + (sx + jy) / m) / q;
    if (*x >= 1.0) *x = 1.0 - DBL_EPSILON / 2; /* never 1: the pixel's far edge */
    if (*y >= 1.0) *y = 1.0 - DBL_EPSILON / 2;
}

/* ===================================================================== */
/* >>obj                                                                 */
/* ===================================================================== */
/* Wavefront OBJ and MTL loader: appends the polygons of one OBJ file (with
   the materials of its MTL libraries) to a pds__mesh.

   Format facts: the Wavefront "Object Files (.obj)" and "Material Library
   Files (.mtl)" appendices of the Advanced Visualizer manual.

   Reading (one pass over the file, kept in memory whole):
   - Statements are whitespace-separated tokens; `#` at the start of a token
     begins a comment that runs to the end of the physical line; a backslash
     followed only by blanks before the newline continues the statement on
     the next line; CRLF, tabs and a UTF-8 byte order mark are accepted.
     A backslash before a blank inside a token escapes it: `mtllib my\ lib.mtl`
     and `usemtl paint\ red` name "my lib.mtl" and "paint red".
   - Robustness, as tinyobjloader, Blender's and pbrt's importers do: a
     missing mtllib file (or one of several on a line) is a warning and its
     materials fall back to the default; a vt or vn index past the elements
     given is dropped with a warning (the corner's normal is then computed
     from the faces); only what cannot be read is refused.
   - Supported: v x y z [w] (w is ignored: it is a rational weight meaningful
     only for free-form geometry, and some exporters put vertex colours
     there), vt u [v [w]] (checked and counted, not stored), vn x y z, f/fo
     with v, v/vt, v//vn, v/vt/vn corners (mixable in one face; negative
     indices count back from the last element read so far), o, g (any
     number of names), s (off, 0, on, N), usemtl, mtllib; l (polylines)
     are counted, not stored. Known OBJ
     statements PDS has no use for (p, vp, curv, surf, cstype, ...) are
     skipped silently; unknown statements are skipped and counted.
   - Error locations are FILE:LINE:COLUMN of the offending token (1-based,
     bytes, CRLF is one line break). A token on a continuation line carries
     its own physical line; statement-level errors (a face with too few
     corners, missing coordinates) point at the statement's keyword. Index
     errors point at the offending number inside the corner (7/2/9: the 9).

   Geometry:
   - Positions and vn normals are transformed as they are read (positions
     by opt->xform, normals by its inverse transpose). A transform that
     mirrors (det < 0) reverses every face's corner order, so that the
     winding normal (P1-P0)x(P2-P0) keeps pointing to the same side of the
     surface as the transformed shading normals (outside stays outside,
     which dielectrics depend on).
   - Polygons are triangulated by ear clipping in the plane of their Newell
     normal (convex and simple concave polygons come out exactly); when no
     ear can be found (self-intersecting or degenerate polygons) the rest of
     the polygon becomes a fan.
   - One mesh vertex per distinct (position, normal source) used by faces:
     a vn index; a smoothing group (normal computed: angle-weighted mean of
     the unit normals of the triangles that share the position within that
     group, Thuermer and Wuethrich 1998); or, under `s off`, the face
     itself (flat: the face's Newell normal, vertices not shared between
     faces). A zero vn counts as absent. Faces before any `s` statement are
     smooth in one implicit group of their own: most exporters that omit
     `s` mean smooth meshes (note: a glass cube without normals and without
     `s off` gets rounded shading normals).
   - Zero-area triangles are refused by pds__mesh_add_tri and counted.

   MTL to PDS material mapping (first rule that applies wins):
     1. Ke with any channel > 0            -> EMISSIVE, radiance = Ke
     2. illum 4, 6 or 7; or transparent    -> DIELECTRIC, ior = Ni, or 1.5
        (d < 1, or Tr > 0 without d, or       when Ni is missing or <= 1;
        Tf given and not 1 1 1) with an       absorption 0 (MTL has no
        explicit Ni != 1                      length scale for Beer's law)
     3. illum 3 or 5 with max(Ks) > 0      -> MIRROR, reflectance = Ks
     4. anything else                      -> DIFFUSE, albedo = Kd (0.8 if
                                              no Kd)
   Colours are clamped to [0, 1] (radiance to >= 0). `Kd r` alone means
   r r r; `Kd xyz X Y Z` is converted to linear sRGB (D65); `Kd spectral`
   is ignored. Tr: exporters disagree (most write Tr = 1 - d, a few write
   Tr = d); Tr is read as 1 - d and only when the material has no `d`.
   Ka, map_*, bump, disp, refl, PBR extensions (Pr, Pm, ...) are ignored.
   Every newmtl material is added to the scene's table unless one of the
   same name exists already (the scene's wins) or opt->material_override
   is set (then the MTL files are only checked). Names longer than 63
   bytes are truncated like every pds_material name. */

typedef struct pds__obj_options {
    const pds__xform *xform;   /* applied to positions (pds__xform_point) and
                                  normals (pds__xform_normal); NULL = identity */
    int material_override;     /* >= 0: every triangle gets this material
                                  index, MTL files still parsed for errors;
                                  -1 = use usemtl */
    int default_material;      /* material index for faces before any usemtl
                                  or with an unknown name (must exist) */
    /* optional per-name overrides: usemtl name -> scene material index */
    const char *const *override_names;
    const int *override_materials;
    int override_count;
} pds__obj_options;

typedef struct pds__obj_stats {
    long vertices, normals, texcoords; /* v, vn, vt statements */
    long faces;                /* f statements */
    long triangles;            /* triangles added to the mesh */
    long degenerate_dropped;   /* zero-area triangles refused */
    long groups, objects;      /* g and o statements */
    long line_segments;        /* segments of l (polyline) statements:
                                  corners - 1 each, counted, not stored */
    int mtl_materials;         /* newmtl statements in all MTL files read */
    long ignored_statements;   /* unknown statements skipped (OBJ and MTL) */
    long unknown_materials;    /* distinct usemtl names that fell back to
                                  default_material */
    char ignored_example[640]; /* "FILE:LINE:COL: 'kw'" of the first
                                  unknown statement, "" if none */
    long bad_references;       /* vt or vn indices out of range, dropped */
    char bad_example[320];     /* "FILE:LINE:COL: normal index 9 of 4" */
    long missing_mtl;          /* mtllib files that do not exist (their
                                  materials fall back to the default) */
    char missing_example[640]; /* "FILE:LINE:COL: 'x.mtl' (looked for ...)"
                                  of the first, "" if none */
} pds__obj_stats;

/* ---------------------------------------------------------------- lexing */

/* Cursor over a whole file in memory. p never passes end; line_start is
   the first byte of the physical line p is on. */
typedef struct pds__obj_lexer {
    const char *p, *end, *line_start;
    int line;
} pds__obj_lexer;

/* One token: bytes [s, s+len), found at line:col (1-based). */
typedef struct pds__obj_token {
    const char *s;
    int len, line, col;
} pds__obj_token;

static int pds__obj_blank(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

/* q points at a backslash. If only blanks follow it up to a newline or the
   end of the buffer, it is a line continuation: return the position of
   that newline (or end); else NULL. */
static const char *pds__obj_continuation(const pds__obj_lexer *lx, const char *q)
{
    q++;
    while (q < lx->end && pds__obj_blank(*q)) q++;
    if (q == lx->end || *q == '\n') return q;
    return NULL;
}

static void pds__obj_lexer_init(pds__obj_lexer *lx, const char *buf, size_t size)
{
    lx->p = buf;
    lx->end = buf + size;
    if (size >= 3 && (unsigned char)buf[0] == 0xEF && (unsigned char)buf[1] == 0xBB &&
        (unsigned char)buf[2] == 0xBF)
        lx->p += 3; /* UTF-8 byte order mark */
    lx->line_start = lx->p;
    lx->line = 1;
}

/* Next token of the current statement into *tok. Returns 1, or 0 at the
   end of the statement (newline, comment or end of file; the newline is
   left for pds__obj_end_statement). Continuations are crossed silently. */
static int pds__obj_next(pds__obj_lexer *lx, pds__obj_token *tok)
{
    const char *p = lx->p, *start;
    for (;;) {
        while (p < lx->end && pds__obj_blank(*p)) p++;
        if (p == lx->end || *p == '\n') {
            lx->p = p;
            return 0;
        }
        if (*p == '#') {
            while (p < lx->end && *p != '\n') p++;
            lx->p = p;
            return 0;
        }
        if (*p == '\\') {
            const char *nl = pds__obj_continuation(lx, p);
            if (nl) {
                p = nl;
                if (p < lx->end) {
                    p++;
                    lx->line++;
                    lx->line_start = p;
                }
                continue;
            }
        }
        break;
    }
    start = p;
    while (p < lx->end && !pds__obj_blank(*p) && *p != '\n') {
        if (*p == '\\' && pds__obj_continuation(lx, p)) break;
        if (*p == '\\' && p + 1 < lx->end && (p[1] == ' ' || p[1] == '\t')) {
            p += 2; /* an escaped blank belongs to the token: "my\ lib.mtl" */
            continue;
        }
        p++;
    }
    tok->s = start;
    tok->len = (int)(p - start);
    tok->line = lx->line;
    tok->col = (int)(start - lx->line_start) + 1;
    lx->p = p;
    return 1;
}

/* Skip what is left of the statement and its newline. */
static void pds__obj_end_statement(pds__obj_lexer *lx)
{
    pds__obj_token t;
    while (pds__obj_next(lx, &t)) { /* discard */ }
    if (lx->p < lx->end) { /* at '\n' */
        lx->p++;
        lx->line++;
        lx->line_start = lx->p;
    }
}

static int pds__obj_is(const pds__obj_token *t, const char *word)
{
    size_t n = strlen(word);
    return (size_t)t->len == n && memcmp(t->s, word, n) == 0;
}

/* ------------------------------------------------------------- numbers */

/* Parse a whole token as a decimal number in the C locale:
   [+-] digits [. digits] [(e|E) [+-] digits], at least one mantissa digit.
   Returns 1 and *out; 0 if the token is not such a number; -1 if it names
   or overflows to a non-finite value (nan, inf, 1e999). The first 19
   significant digits are kept; with <= 2^53 and |exponent| <= 22 the
   result is correctly rounded (Clinger's fast path), else within a few
   ulps, far below the float precision the mesh stores. */
static int pds__obj_parse_double(const char *s, int len, double *out)
{
    static const double p10[23] = {1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10,
                                   1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19,
                                   1e20, 1e21, 1e22};
    int i = 0, neg = 0, any = 0, e = 0;
    unsigned long long m = 0;
    long exp10 = 0;
    double v;
    if (i < len && (s[i] == '+' || s[i] == '-')) neg = s[i++] == '-';
    if (len - i >= 3 && (tolower((unsigned char)s[i]) == 'n' || tolower((unsigned char)s[i]) == 'i')) {
        char w[9];
        int k, n = len - i;
        if (n <= 8) {
            for (k = 0; k < n; k++) w[k] = (char)tolower((unsigned char)s[i + k]);
            w[n] = '\0';
            if (!strcmp(w, "nan") || !strcmp(w, "inf") || !strcmp(w, "infinity")) return -1;
        }
        return 0;
    }
    while (i < len && s[i] >= '0' && s[i] <= '9') {
        if (m < 100000000000000000ULL) m = m * 10 + (unsigned)(s[i] - '0');
        else exp10++;
        any = 1;
        i++;
    }
    if (i < len && s[i] == '.') {
        i++;
        while (i < len && s[i] >= '0' && s[i] <= '9') {
            if (m < 100000000000000000ULL) {
                m = m * 10 + (unsigned)(s[i] - '0');
                exp10--;
            }
            any = 1;
            i++;
        }
    }
    if (!any) return 0;
    if (i < len && (s[i] == 'e' || s[i] == 'E')) {
        int eneg = 0, edig = 0;
        i++;
        if (i < len && (s[i] == '+' || s[i] == '-')) eneg = s[i++] == '-';
        while (i < len && s[i] >= '0' && s[i] <= '9') {
            if (e < 100000) e = e * 10 + (s[i] - '0');
            edig = 1;
            i++;
        }
        if (!edig) return 0;
        if (eneg) e = -e;
    }
    if (i != len) return 0;
    exp10 += e;
    if (m == 0) {
        v = 0.0;
    } else if (m <= (1ULL << 53) && exp10 >= -22 && exp10 <= 22) {
        v = exp10 >= 0 ? (double)m * p10[exp10] : (double)m / p10[-exp10];
    } else if (exp10 < -400) {
        v = 0.0;
    } else if (exp10 > 400) {
        return -1;
    } else {
        /* two factors so that neither underflows nor overflows early */
        long h = exp10 / 2;
        v = (double)m * pow(10.0, (double)h) * pow(10.0, (double)(exp10 - h));
    }
    if (!(v == v) || v > DBL_MAX) return -1;
    *out = neg ? -v : v;
    return 1;
}

/* Parse [+-]digits at s (not necessarily the whole of [s, s+len)).
   Returns the number of bytes used (0 if none); the value saturates at
   +-10^15, far outside any valid index. */
static int pds__obj_parse_int(const char *s, int len, long long *out)
{
    int i = 0, neg = 0, start;
    long long v = 0;
    if (i < len && (s[i] == '+' || s[i] == '-')) neg = s[i++] == '-';
    start = i;
    while (i < len && s[i] >= '0' && s[i] <= '9') {
        if (v < 1000000000000000LL) v = v * 10 + (s[i] - '0');
        i++;
    }
    if (i == start) return 0;
    *out = neg ? -v : v;
    return i;
}

/* ----------------------------------------------------------- loader state */

/* Sources of a mesh vertex's normal (see the prologue). */
enum { PDS__OBJ_KEY_VN = 0, PDS__OBJ_KEY_SMOOTH = 1, PDS__OBJ_KEY_FLAT = 2 };

/* Node of the per-position list of mesh vertices already made from that
   position: key (kind, val) -> mesh vertex, next node or -1. */
typedef struct pds__obj_vnode {
    long long val;
    int vert, next, kind;
} pds__obj_vnode;

typedef struct pds__obj_state {
    const char *path;          /* the OBJ file, as given */
    char dir[4096];            /* its directory, for mtllib names */
    pds__mesh *mesh;
    pds__materials *mats;
    const pds__obj_options *opt;
    pds__obj_stats *st;
    pds_error *err;
    pds__xform xf;             /* opt->xform or identity */
    int flip;                  /* xf mirrors: reverse corner order */

    pds__v3 *pos;              /* transformed positions */
    int *head;                 /* per position: first pds__obj_vnode or -1 */
    size_t npos, cap_pos, cap_head;
    pds__v3 *nrm;              /* transformed unit vn normals (0 if zero) */
    size_t nnrm, cap_nrm;
    long ntex;
    pds__obj_vnode *nodes;
    size_t nnodes, cap_nodes;
    pds__v3 *acc;              /* per new mesh vertex: smooth-normal sum */
    unsigned char *kind;       /* per new mesh vertex: PDS__OBJ_KEY_* */
    size_t cap_acc, cap_kind;

    /* scratch for one face, reused */
    int *fpos, *fnrm, *fvert;
    size_t cap_fpos, cap_fnrm, cap_fvert;
    pds__obj_token *ftok;
    size_t cap_ftok;
    double *u, *v;
    int *prev, *next, *tris;
    unsigned char *reflex;
    size_t cap_u, cap_v, cap_prev, cap_next, cap_tris, cap_reflex;

    long long group;           /* smoothing group: 0 off, -1 implicit */
    int slot;                  /* current usemtl slot, -1 none */
    pds__names slots;      /* usemtl name -> slot */
    const char **slot_names;   /* slot -> name (owned by slots) */
    size_t nslots, cap_slot_names;
    pds__names matnames;   /* material name -> index in mats */
    pds__names mtl_loaded; /* MTL paths already read */
    long face_no;

    size_t base_v, base_t, base_mats;
    long base_dropped;
} pds__obj_state;

static pds_status pds__obj_err(pds__obj_state *s, const pds__obj_token *t, const char *fmt, ...)
{
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return pds__fail(s->err, PDS_ERR_PARSE, s->path, t->line, t->col, "%s", msg);
}

/* Note an unknown statement (for the caller's warnings). */
static void pds__obj_ignore(pds__obj_state *s, const char *file, const pds__obj_token *kw)
{
    s->st->ignored_statements++;
    if (s->st->ignored_example[0] == '\0')
        snprintf(s->st->ignored_example, sizeof s->st->ignored_example, "%s:%d:%d: '%.*s'",
                 file, kw->line, kw->col, kw->len > 64 ? 64 : kw->len, kw->s);
}

/* Read exactly one number token of statement kw (in file) into *out.
   Missing, malformed and non-finite numbers are errors. */
static pds_status pds__obj_number(pds__obj_state *s, pds__obj_lexer *lx, const char *file,
                                  const pds__obj_token *kw, double *out)
{
    pds__obj_token t;
    int r;
    if (!pds__obj_next(lx, &t))
        return pds__fail(s->err, PDS_ERR_PARSE, file, kw->line, kw->col,
                         "'%.*s' needs more numbers", kw->len, kw->s);
    r = pds__obj_parse_double(t.s, t.len, out);
    if (r == 1) return PDS_OK;
    if (r < 0)
        return pds__fail(s->err, PDS_ERR_PARSE, file, t.line, t.col,
                         "'%.*s' is not a finite number", t.len > 64 ? 64 : t.len, t.s);
    return pds__fail(s->err, PDS_ERR_PARSE, file, t.line, t.col,
                     "expected a number for '%.*s', got '%.*s'", kw->len, kw->s,
                     t.len > 64 ? 64 : t.len, t.s);
}

/* A name as written, "my\ lib.mtl", to the name meant, "my lib.mtl": a
   backslash before a blank escapes it (exporters write names with spaces
   so). In place. */
static void pds__obj_unescape(char *s)
{
    char *w = s;
    for (; *s; s++) {
        if (s[0] == '\\' && (s[1] == ' ' || s[1] == '\t')) s++;
        *w++ = *s;
    }
    *w = '\0';
}

/* The remaining tokens of the statement, stored in s->ftok (count in *n),
   and as one string in buf: the raw bytes when all tokens sit on one
   physical line (inner spacing kept), else joined by single spaces.
   Returns 0, -1 when buf (size cap) is too small, -2 out of memory. */
static int pds__obj_rest(pds__obj_state *s, pds__obj_lexer *lx, char *buf, size_t cap, size_t *n)
{
    pds__obj_token t;
    size_t k = 0, len = 0, i;
    while (pds__obj_next(lx, &t)) {
        if (pds__grow((void **)&s->ftok, &s->cap_ftok, k + 1, sizeof *s->ftok)) return -2;
        s->ftok[k++] = t;
    }
    *n = k;
    buf[0] = '\0';
    if (k == 0) return 0;
    if (s->ftok[0].line == s->ftok[k - 1].line) {
        len = (size_t)(s->ftok[k - 1].s + s->ftok[k - 1].len - s->ftok[0].s);
        if (len + 1 > cap) return -1;
        memcpy(buf, s->ftok[0].s, len);
    } else {
        for (i = 0; i < k; i++) {
            size_t tl = (size_t)s->ftok[i].len;
            if (len + tl + 2 > cap) return -1;
            if (i) buf[len++] = ' ';
            memcpy(buf + len, s->ftok[i].s, tl);
            len += tl;
        }
    }
    buf[len] = '\0';
    pds__obj_unescape(buf);
    return 0;
}

#ifndef PDS_NO_MTL
/* ------------------------------------------------------------------ MTL */

/* An MTL material as read, before mapping to a pds_material. */
typedef struct pds__mtl_raw {
    char name[64];
    double kd[3], ks[3], ke[3], tf[3];
    double ni, d, tr;
    int has_kd, has_ks, has_ke, has_tf, has_ni, has_d, has_tr, illum;
} pds__mtl_raw;

static double pds__obj_clamp01(double x) { return x < 0.0 ? 0.0 : x > 1.0 ? 1.0 : x; }

/* Map an MTL material to a PDS material (table in the prologue). */
static pds_material pds__mtl_to_material(const pds__mtl_raw *r)
{
    pds_material m = pds__material_default(r->name);
    double opacity = r->has_d ? r->d : r->has_tr ? 1.0 - r->tr : 1.0;
    int tf_not_one = r->has_tf && (r->tf[0] != 1.0 || r->tf[1] != 1.0 || r->tf[2] != 1.0);
    int transparent = opacity < 1.0 || tf_not_one;
    int k;
    if (r->has_ke && (r->ke[0] > 0.0 || r->ke[1] > 0.0 || r->ke[2] > 0.0)) {
        m.type = PDS_MAT_EMISSIVE;
        for (k = 0; k < 3; k++) m.radiance[k] = r->ke[k] > 0.0 ? r->ke[k] : 0.0;
    } else if (r->illum == 4 || r->illum == 6 || r->illum == 7 ||
               (transparent && r->has_ni && r->ni != 1.0)) {
        m.type = PDS_MAT_DIELECTRIC;
        m.ior = (r->has_ni && r->ni > 1.0) ? r->ni : 1.5;
    } else if ((r->illum == 3 || r->illum == 5) && r->has_ks &&
               (r->ks[0] > 0.0 || r->ks[1] > 0.0 || r->ks[2] > 0.0)) {
        m.type = PDS_MAT_MIRROR;
        for (k = 0; k < 3; k++) m.reflectance[k] = pds__obj_clamp01(r->ks[k]);
    } else if (r->has_kd) {
        for (k = 0; k < 3; k++) m.albedo[k] = pds__obj_clamp01(r->kd[k]);
    }
    return m;
}

/* Finish the material being read: add it unless its name exists or the
   caller overrides all materials. */
static pds_status pds__mtl_commit(pds__obj_state *s, const pds__mtl_raw *r)
{
    pds_material m;
    int idx;
    size_t n = strlen(r->name);
    s->st->mtl_materials++;
    if (s->opt->material_override >= 0) return PDS_OK;
    if (pds__names_find(&s->matnames, r->name, n) >= 0) return PDS_OK;
    m = pds__mtl_to_material(r);
    idx = pds__materials_add(s->mats, &m);
    if (idx < 0) {
        if (s->mats->count >= (size_t)PDS_MAX_MATERIALS)
            return pds__fail(s->err, PDS_ERR_LIMIT, s->path, 0, 0,
                             "more than %d materials", PDS_MAX_MATERIALS);
        return pds__nomem(s->err);
    }
    if (!pds__names_put(&s->matnames, r->name, n, idx)) return pds__nomem(s->err);
    return PDS_OK;
}

/* Colour statement (Kd, Ks, Ke, Tf): "r [g b]", "xyz X [Y Z]" or
   "spectral file [factor]" (ignored: *has stays as it was). */
static pds_status pds__mtl_color(pds__obj_state *s, pds__obj_lexer *lx, const char *file,
                                 const pds__obj_token *kw, double c[3], int *has)
{
    pds__obj_lexer save = *lx;
    pds__obj_token t;
    double v[3];
    int n = 0, xyz = 0;
    pds_status st;
    if (pds__obj_next(lx, &t)) {
        if (pds__obj_is(&t, "spectral")) return PDS_OK;
        if (pds__obj_is(&t, "xyz")) xyz = 1;
        else *lx = save;
    }
    if ((st = pds__obj_number(s, lx, file, kw, &v[0])) != PDS_OK) return st;
    n = 1;
    save = *lx;
    if (pds__obj_next(lx, &t)) {
        *lx = save;
        if ((st = pds__obj_number(s, lx, file, kw, &v[1])) != PDS_OK) return st;
        if ((st = pds__obj_number(s, lx, file, kw, &v[2])) != PDS_OK) return st;
        n = 3;
    }
    if (n == 1) v[1] = v[2] = v[0];
    if (xyz) { /* CIE XYZ -> linear sRGB primaries, D65 white */
        c[0] = 3.2406 * v[0] - 1.5372 * v[1] - 0.4986 * v[2];
        c[1] = -0.9689 * v[0] + 1.8758 * v[1] + 0.0415 * v[2];
        c[2] = 0.0557 * v[0] - 0.2040 * v[1] + 1.0570 * v[2];
    } else {
        c[0] = v[0];
        c[1] = v[1];
        c[2] = v[2];
    }
    *has = 1;
    return PDS_OK;
}

/* Read one MTL file (path already resolved). */
static pds_status pds__mtl_load(pds__obj_state *s, const char *path)
{
    char *buf = NULL;
    size_t size = 0;
    pds__obj_lexer lx;
    pds__obj_token kw, t;
    pds__mtl_raw cur;
    int have = 0;
    char name[4096];
    pds_status st = PDS_OK;
    static const char *const ignored[] = {
        "Ka", "bump", "disp", "decal", "refl", "norm", "sharpness", "Pr", "Pm", "Ps", "Pc",
        "Pcr", "aniso", "anisor", "Km", "Tw"};

    if ((st = pds__read_file(path, PDS_MAX_TEXT_BYTES, "MTL file", &buf, &size, s->err)) != PDS_OK) return st;
    if ((st = pds__check_lines(path, buf, size, s->err)) != PDS_OK) {
        free(buf);
        return st;
    }
    pds__obj_lexer_init(&lx, buf, size);
    memset(&cur, 0, sizeof cur);
    while (st == PDS_OK && lx.p < lx.end) {
        if (!pds__obj_next(&lx, &kw)) {
            pds__obj_end_statement(&lx);
            continue;
        }
        if (pds__obj_is(&kw, "newmtl")) {
            size_t nt;
            int r;
            if (have && (st = pds__mtl_commit(s, &cur)) != PDS_OK) break;
            r = pds__obj_rest(s, &lx, name, sizeof name, &nt);
            if (r) {
                st = r == -2 ? pds__nomem(s->err)
                             : pds__fail(s->err, PDS_ERR_PARSE, path, kw.line, kw.col, "material name is too long");
                break;
            }
            if (nt == 0) {
                st = pds__fail(s->err, PDS_ERR_PARSE, path, kw.line, kw.col, "'newmtl' needs a material name");
                break;
            }
            memset(&cur, 0, sizeof cur);
            pds__strlcpy(cur.name, name, sizeof cur.name);
            have = 1;
        } else if (!have) {
            /* statements before the first newmtl have nothing to apply to */
        } else if (pds__obj_is(&kw, "Kd")) {
            st = pds__mtl_color(s, &lx, path, &kw, cur.kd, &cur.has_kd);
        } else if (pds__obj_is(&kw, "Ks")) {
            st = pds__mtl_color(s, &lx, path, &kw, cur.ks, &cur.has_ks);
        } else if (pds__obj_is(&kw, "Ke")) {
            st = pds__mtl_color(s, &lx, path, &kw, cur.ke, &cur.has_ke);
        } else if (pds__obj_is(&kw, "Tf")) {
            st = pds__mtl_color(s, &lx, path, &kw, cur.tf, &cur.has_tf);
        } else if (pds__obj_is(&kw, "Ns")) {
            double v; /* checked, not used: a Phong exponent is not mapped to the GGX glossy material */
            st = pds__obj_number(s, &lx, path, &kw, &v);
        } else if (pds__obj_is(&kw, "Ni")) {
            st = pds__obj_number(s, &lx, path, &kw, &cur.ni);
            cur.has_ni = 1;
        } else if (pds__obj_is(&kw, "d") || pds__obj_is(&kw, "Tr")) {
            pds__obj_lexer save = lx;
            double v = 1.0;
            if (!pds__obj_next(&lx, &t) || !pds__obj_is(&t, "-halo")) lx = save;
            st = pds__obj_number(s, &lx, path, &kw, &v);
            if (kw.s[0] == 'd') {
                cur.d = v;
                cur.has_d = 1;
            } else {
                cur.tr = v;
                cur.has_tr = 1;
            }
        } else if (pds__obj_is(&kw, "illum")) {
            double v = 0.0;
            pds__obj_lexer save = lx;
            st = pds__obj_number(s, &lx, path, &kw, &v);
            if (st == PDS_OK && (v != floor(v) || v < 0.0 || v > 10.0)) {
                pds__obj_next(&save, &t);
                st = pds__fail(s->err, PDS_ERR_PARSE, path, t.line, t.col,
                               "expected an illumination model number 0-10 for 'illum', got '%.*s'",
                               t.len > 64 ? 64 : t.len, t.s);
            }
            if (st == PDS_OK) cur.illum = (int)v; /* 0..10 now: the conversion is defined */
        } else if (kw.len > 4 && memcmp(kw.s, "map_", 4) == 0) {
            /* textures: not used */
        } else {
            size_t i;
            int known = 0;
            for (i = 0; i < sizeof ignored / sizeof ignored[0]; i++)
                if (pds__obj_is(&kw, ignored[i])) known = 1;
            if (!known) pds__obj_ignore(s, path, &kw);
        }
        if (st == PDS_OK) pds__obj_end_statement(&lx);
    }
    if (st == PDS_OK && have) st = pds__mtl_commit(s, &cur);
    free(buf);
    return st;
}

/* mtllib statement: every name is a file relative to the OBJ's directory;
   when the whole rest of the line names an existing file (a name with
   spaces), that file is read instead. A library named twice is read once. */
static pds_status pds__obj_mtllib(pds__obj_state *s, pds__obj_lexer *lx)
{
    char rest[4096], full[4096];
    size_t n, i;
    pds_status st;
    pds__obj_token *names;
    int e;
    int r = pds__obj_rest(s, lx, rest, sizeof rest, &n);
    if (r == -2) return pds__nomem(s->err);
    if (r) return pds__obj_err(s, &s->ftok[0], "material library name is too long");
    if (n > 1 && pds__join_path(s->dir, rest, full, sizeof full) == 0 && pds__input_file_check(full) == 0) {
        if (pds__names_find(&s->mtl_loaded, full, strlen(full)) >= 0) return PDS_OK;
        if (!pds__names_put(&s->mtl_loaded, full, strlen(full), 1)) return pds__nomem(s->err);
        return pds__mtl_load(s, full);
    }
    /* the names' tokens live in s->ftok, which loading an MTL refills (its
       `newmtl` lines are read the same way): walk a copy (found by
       fuzzing: the next name was read from the freed MTL text) */
    names = (pds__obj_token *)malloc(sizeof *names * (n ? n : 1));
    if (!names) return pds__nomem(s->err);
    if (n) memcpy(names, s->ftok, sizeof *names * n);
    for (i = 0, st = PDS_OK; i < n && st == PDS_OK; i++) {
        pds__obj_token t = names[i];
        char name[4096];
        memcpy(name, t.s, (size_t)t.len); /* t.len < sizeof rest <= sizeof name */
        name[t.len] = '\0';
        pds__obj_unescape(name);
        if (pds__join_path(s->dir, name, full, sizeof full))
            st = pds__obj_err(s, &t, "material library path is too long");
        else if (pds__names_find(&s->mtl_loaded, full, strlen(full)) >= 0)
            continue;
        else if ((e = pds__input_file_check(full)) == ENOENT) {
            /* downloads often lack their .mtl: warn and go on, as other
               importers do (its usemtl names then take the default) */
            if (s->st->missing_mtl++ == 0)
                snprintf(s->st->missing_example, sizeof s->st->missing_example, "%.200s:%d:%d: '%.100s' (looked for %.300s)",
                         s->path, t.line, t.col, name, full);
        } else if (e)
            st = pds__obj_err(s, &t, "cannot read material library %s: %s", full, pds__input_file_problem(e));
        else if (!pds__names_put(&s->mtl_loaded, full, strlen(full), 1))
            st = pds__nomem(s->err);
        else
            st = pds__mtl_load(s, full);
    }
    free(names);
    return st;
}

#endif /* PDS_NO_MTL */

/* ------------------------------------------------------- triangulation */

/* Newell's normal of the polygon P[0..n-1]: twice its vector area, along
   the normal that sees the corners counter-clockwise. Coordinates are
   taken relative to P[0] for precision far from the origin. */
static pds__v3 pds__obj_newell(const pds__v3 *pos, const int *idx, int n)
{
    pds__v3 r = pds__v(0.0, 0.0, 0.0), o = pos[idx[0]];
    int i;
    for (i = 0; i < n; i++) {
        pds__v3 a = pds__sub(pos[idx[i]], o), b = pds__sub(pos[idx[(i + 1) % n]], o);
        r.x += (a.y - b.y) * (a.z + b.z);
        r.y += (a.z - b.z) * (a.x + b.x);
        r.z += (a.x - b.x) * (a.y + b.y);
    }
    return r;
}

/* 2-D cross product (b - a) x (c - a): > 0 when a, b, c turn left. */
static double pds__obj_orient(const double *u, const double *v, int a, int b, int c)
{
    return (u[b] - u[a]) * (v[c] - v[a]) - (v[b] - v[a]) * (u[c] - u[a]);
}

/* Is corner i of the remaining polygon an ear: convex, and no non-convex
   corner inside or on the triangle (prev, i, next)? Corners at the very
   same spot as a triangle corner do not count (bridged holes repeat
   positions). Only non-convex corners need testing: if any polygon point
   lay inside, a reflex corner would too. */
static int pds__obj_is_ear(const pds__obj_state *s, int i, int nreflex)
{
    const double *u = s->u, *v = s->v;
    int a = s->prev[i], c = s->next[i], r;
    if (pds__obj_orient(u, v, a, i, c) <= 0.0) return 0;
    if (nreflex == 0) return 1;
    for (r = s->next[c]; r != a; r = s->next[r]) {
        if (!s->reflex[r]) continue;
        if ((u[r] == u[a] && v[r] == v[a]) || (u[r] == u[i] && v[r] == v[i]) ||
            (u[r] == u[c] && v[r] == v[c]))
            continue;
        if (pds__obj_orient(u, v, a, i, r) >= 0.0 && pds__obj_orient(u, v, i, c, r) >= 0.0 &&
            pds__obj_orient(u, v, c, a, r) >= 0.0)
            return 0;
    }
    return 1;
}

/* --- large faces: monotone decomposition, O(n log n) ------------------------
   Ear clipping tests every ear against the reflex corners, O(n^2) and worse
   (a 100,000-corner circle written with six decimals took 38 s). Faces of
   more than PDS__EAR_CLIP_MAX corners are triangulated by the plane sweep
   of Garey, Johnson, Preparata and Tarjan (1978), as de Berg et al.,
   Computational Geometry (3rd ed., 2008), ch. 3 present it: a sweep from
   top to bottom adds diagonals at split and merge corners so that every
   piece is y-monotone (sect. 3.2), and each monotone piece is triangulated
   in linear time with a stack (sect. 3.3). The sweep status is a treap of
   the edges with the interior to their right, ordered by x at the sweep
   line, so the whole is O(n log n). Corners are ordered "above" by (v
   descending, u ascending, index), a strict total order even where
   positions repeat (bridged holes). */
#define PDS__EAR_CLIP_MAX 64

typedef struct pds__sweep {
    const double *u, *v;
    int n;
    int *rank;                 /* corner -> position from the top */
    int *left, *right, *up;    /* treap of edges (edge i: corner i to i+1) */
    uint32_t *prio;
    int *helper;               /* de Berg's helper(e) */
    int root;
    int *diag;                 /* pairs of corners */
    int ndiag;
} pds__sweep;

typedef struct pds__sweep_key {
    double u, v;
    int i;
} pds__sweep_key;

static int pds__sweep_key_cmp(const void *pa, const void *pb)
{
    const pds__sweep_key *a = (const pds__sweep_key *)pa, *b = (const pds__sweep_key *)pb;
    if (a->v != b->v) return a->v > b->v ? -1 : 1;
    if (a->u != b->u) return a->u < b->u ? -1 : 1;
    return a->i - b->i;
}

/* x (here u) of edge e where the sweep line v = y crosses it. */
static double pds__sweep_edge_u(const pds__sweep *w, int e, double y)
{
    int a = e, b = e + 1 == w->n ? 0 : e + 1;
    double ua = w->u[a], va = w->v[a], ub = w->u[b], vb = w->v[b];
    if (va == vb) return ua < ub ? ua : ub;
    if (y >= (va > vb ? va : vb)) return va > vb ? ua : ub;
    if (y <= (va < vb ? va : vb)) return va < vb ? ua : ub;
    return ua + (ub - ua) * (y - va) / (vb - va);
}

static void pds__sweep_rotate_up(pds__sweep *w, int x)
{
    int p = w->up[x], g = w->up[p];
    if (w->left[p] == x) {
        w->left[p] = w->right[x];
        if (w->right[x] >= 0) w->up[w->right[x]] = p;
        w->right[x] = p;
    } else {
        w->right[p] = w->left[x];
        if (w->left[x] >= 0) w->up[w->left[x]] = p;
        w->left[x] = p;
    }
    w->up[p] = x;
    w->up[x] = g;
    if (g < 0) w->root = x;
    else if (w->left[g] == p) w->left[g] = x;
    else w->right[g] = x;
}

/* Insert edge e, which starts at corner c (its upper end): ordered by u at
   c's height, ties by where the edges go below it. */
static void pds__sweep_insert(pds__sweep *w, int e, int c)
{
    double y = w->v[c], x = w->u[c];
    int at = w->root, parent = -1, go_left = 0;
    int e_next = e + 1 == w->n ? 0 : e + 1;
    w->left[e] = w->right[e] = -1;
    while (at >= 0) {
        double ux = pds__sweep_edge_u(w, at, y);
        parent = at;
        if (x != ux) go_left = x < ux;
        else {
            /* both through c: the one whose lower end is further left */
            int a_low = w->v[at] < w->v[at + 1 == w->n ? 0 : at + 1] ? at : (at + 1 == w->n ? 0 : at + 1);
            go_left = w->u[e_next] < w->u[a_low];
        }
        at = go_left ? w->left[at] : w->right[at];
    }
    w->up[e] = parent;
    if (parent < 0) w->root = e;
    else if (go_left) w->left[parent] = e;
    else w->right[parent] = e;
    while (w->up[e] >= 0 && w->prio[w->up[e]] < w->prio[e]) pds__sweep_rotate_up(w, e);
}

static void pds__sweep_remove(pds__sweep *w, int e)
{
    int child, p;
    if (e < 0 || (w->up[e] < 0 && w->root != e)) return; /* not in the tree */
    /* rotate e down until it has at most one child, then splice it out */
    while (w->left[e] >= 0 && w->right[e] >= 0)
        pds__sweep_rotate_up(w, w->prio[w->left[e]] > w->prio[w->right[e]] ? w->left[e] : w->right[e]);
    child = w->left[e] >= 0 ? w->left[e] : w->right[e];
    p = w->up[e];
    if (child >= 0) w->up[child] = p;
    if (p < 0) w->root = child;
    else if (w->left[p] == e) w->left[p] = child;
    else w->right[p] = child;
    w->up[e] = w->left[e] = w->right[e] = -1;
}

/* The edge directly left of corner c (largest u at c's height that is
   still left of c), or -1. */
static int pds__sweep_left_of(const pds__sweep *w, int c)
{
    int at = w->root, best = -1;
    double y = w->v[c], x = w->u[c];
    while (at >= 0) {
        if (pds__sweep_edge_u(w, at, y) <= x && at != c && (at + 1 == w->n ? 0 : at + 1) != c) {
            best = at;
            at = w->right[at];
        } else {
            at = w->left[at];
        }
    }
    return best;
}

static int pds__sweep_above(const pds__sweep *w, int a, int b)
{
    return w->rank[a] < w->rank[b];
}

static void pds__sweep_diagonal(pds__sweep *w, int a, int b)
{
    if (a == b || w->ndiag >= 2 * w->n) return;
    w->diag[2 * w->ndiag] = a;
    w->diag[2 * w->ndiag + 1] = b;
    w->ndiag++;
}

/* Is the corner a merge corner (both neighbours above, reflex)? */
static int pds__sweep_is_merge(const pds__sweep *w, int c)
{
    int p = c == 0 ? w->n - 1 : c - 1, q = c + 1 == w->n ? 0 : c + 1;
    return c >= 0 && pds__sweep_above(w, p, c) && pds__sweep_above(w, q, c) &&
           pds__obj_orient(w->u, w->v, p, c, q) < 0.0;
}

/* Triangulate one y-monotone piece (corners in cyclic order) by the stack
   algorithm; appends its triangles to tris. */
static void pds__sweep_monotone(const pds__sweep *w, const int *piece, int m, int *chain, int *sorted, int *stack,
                                int *tris, int *k)
{
    int i, top = 0, low = 0, sp = 0, j;
    if (m < 3) return;
    for (i = 1; i < m; i++) {
        if (pds__sweep_above(w, piece[i], piece[top])) top = i;
        if (pds__sweep_above(w, piece[low], piece[i])) low = i;
    }
    /* the piece is counter-clockwise: from the top, forward runs down the
       left chain (0), backward down the right chain (1); merge them */
    {
        int a = top, b = top, n_out = 0;
        sorted[n_out] = piece[top];
        chain[n_out++] = 0;
        a = (a + 1) % m;
        b = (b + m - 1) % m;
        while (n_out < m) {
            int take_a = b == low || (a != low && pds__sweep_above(w, piece[a], piece[b]));
            if (n_out == m - 1) take_a = 1; /* the bottom corner */
            if (take_a) {
                sorted[n_out] = piece[a];
                chain[n_out++] = a == low ? 1 : 0;
                a = (a + 1) % m;
            } else {
                sorted[n_out] = piece[b];
                chain[n_out++] = 1;
                b = (b + m - 1) % m;
            }
        }
    }
    stack[sp++] = 0;
    stack[sp++] = 1;
    for (j = 2; j < m - 1; j++) {
        if (chain[j] != chain[stack[sp - 1]]) {
            for (i = 0; i + 1 < sp; i++) {
                tris[(*k)++] = sorted[j];
                tris[(*k)++] = sorted[stack[i]];
                tris[(*k)++] = sorted[stack[i + 1]];
            }
            stack[0] = j - 1;
            stack[1] = j;
            sp = 2;
        } else {
            int last = stack[--sp];
            while (sp > 0) {
                double o = pds__obj_orient(w->u, w->v, sorted[stack[sp - 1]], sorted[last], sorted[j]);
                if (chain[j] == 0 ? !(o > 0.0) : !(o < 0.0)) break;
                tris[(*k)++] = sorted[j];
                tris[(*k)++] = sorted[last];
                tris[(*k)++] = sorted[stack[sp - 1]];
                last = stack[--sp];
            }
            stack[sp++] = last;
            stack[sp++] = j;
        }
    }
    for (i = 0; i + 1 < sp; i++) {
        tris[(*k)++] = sorted[m - 1];
        tris[(*k)++] = sorted[stack[i]];
        tris[(*k)++] = sorted[stack[i + 1]];
    }
}

typedef struct pds__sweep_nb {
    double angle;
    int to;
} pds__sweep_nb;

static int pds__sweep_nb_cmp(const void *pa, const void *pb)
{
    const pds__sweep_nb *a = (const pds__sweep_nb *)pa, *b = (const pds__sweep_nb *)pb;
    if (a->angle != b->angle) return a->angle < b->angle ? -1 : 1;
    return a->to - b->to;
}

/* Triangulate the counter-clockwise polygon (u, v)[0..n-1]; writes n - 2
   corner triples (counter-clockwise) to tris. Returns 1 if done, 0 if the
   polygon defeated the sweep (it crosses itself): the caller falls back.
   -1 when out of memory. */
static int pds__obj_triangulate_sweep(const double *u, const double *v, int n, int *tris)
{
    pds__sweep w;
    pds__sweep_key *keys = (pds__sweep_key *)malloc(sizeof *keys * (size_t)n);
    int *ints = (int *)malloc(sizeof(int) * (size_t)n * 20);
    uint32_t *prio = (uint32_t *)malloc(sizeof(uint32_t) * (size_t)n);
    pds__sweep_nb *nb = NULL;
    int *off, *deg, *done, *piece, *chain, *sorted, *stack, i, k = 0, ok = 1, total;
    if (!keys || !ints || !prio) {
        free(keys);
        free(ints);
        free(prio);
        return -1;
    }
    memset(&w, 0, sizeof w);
    w.u = u;
    w.v = v;
    w.n = n;
    w.rank = ints;
    w.left = ints + n;
    w.right = ints + 2 * n;
    w.up = ints + 3 * n;
    w.helper = ints + 4 * n;
    w.diag = ints + 5 * n; /* 2n pairs: 4n ints */
    w.prio = prio;
    w.root = -1;
    for (i = 0; i < n; i++) {
        keys[i].u = u[i];
        keys[i].v = v[i];
        keys[i].i = i;
        w.left[i] = w.right[i] = w.up[i] = w.helper[i] = -1;
        prio[i] = (uint32_t)(pds__mix64((uint64_t)i + 0x9E3779B97F4A7C15ULL) >> 32);
    }
    qsort(keys, (size_t)n, sizeof *keys, pds__sweep_key_cmp);
    for (i = 0; i < n; i++) w.rank[keys[i].i] = i;
    /* the sweep (de Berg et al. 2008, algorithm MakeMonotone) */
    for (i = 0; i < n; i++) {
        int c = keys[i].i, p = c == 0 ? n - 1 : c - 1, q = c + 1 == n ? 0 : c + 1, e;
        int p_above = pds__sweep_above(&w, p, c), q_above = pds__sweep_above(&w, q, c);
        double turn = pds__obj_orient(u, v, p, c, q);
        if (!p_above && !q_above) {
            if (turn < 0.0) { /* split */
                e = pds__sweep_left_of(&w, c);
                if (e < 0) ok = 0;
                else {
                    pds__sweep_diagonal(&w, c, w.helper[e]);
                    w.helper[e] = c;
                }
            }
            pds__sweep_insert(&w, c, c); /* start or split: edge c leaves c downwards */
            w.helper[c] = c;
        } else if (p_above && q_above) {
            if (pds__sweep_is_merge(&w, w.helper[p])) pds__sweep_diagonal(&w, c, w.helper[p]);
            pds__sweep_remove(&w, p);
            if (turn < 0.0) { /* merge */
                e = pds__sweep_left_of(&w, c);
                if (e < 0) ok = 0;
                else {
                    if (pds__sweep_is_merge(&w, w.helper[e])) pds__sweep_diagonal(&w, c, w.helper[e]);
                    w.helper[e] = c;
                }
            }
        } else if (p_above) { /* regular, interior to the right: the left boundary going down */
            if (pds__sweep_is_merge(&w, w.helper[p])) pds__sweep_diagonal(&w, c, w.helper[p]);
            pds__sweep_remove(&w, p);
            pds__sweep_insert(&w, c, c);
            w.helper[c] = c;
        } else { /* regular on the right boundary */
            e = pds__sweep_left_of(&w, c);
            if (e < 0) ok = 0;
            else {
                if (pds__sweep_is_merge(&w, w.helper[e])) pds__sweep_diagonal(&w, c, w.helper[e]);
                w.helper[e] = c;
            }
        }
    }
    free(keys);
    /* split along the diagonals: every corner's neighbours sorted by angle;
       a piece is walked by turning, at each corner, to the neighbour just
       clockwise of the one it came from */
    total = 2 * (n + w.ndiag);
    deg = w.left; /* the tree is done with: reuse its arrays */
    off = w.right;
    done = NULL;
    nb = (pds__sweep_nb *)malloc(sizeof *nb * (size_t)total);
    done = (int *)calloc((size_t)total, sizeof *done);
    piece = (int *)malloc(sizeof(int) * (size_t)n * 5);
    if (!nb || !done || !piece) {
        free(nb);
        free(done);
        free(piece);
        free(ints);
        free(prio);
        return -1;
    }
    chain = piece + n;
    sorted = piece + 2 * n;
    stack = piece + 3 * n;
    for (i = 0; i < n; i++) deg[i] = 2;
    for (i = 0; i < w.ndiag; i++) {
        deg[w.diag[2 * i]]++;
        deg[w.diag[2 * i + 1]]++;
    }
    off[0] = 0;
    for (i = 1; i < n; i++) off[i] = off[i - 1] + deg[i - 1];
    for (i = 0; i < n; i++) deg[i] = 0;
#define PDS__SWEEP_LINK(a, b)                                                              \
    do {                                                                                   \
        pds__sweep_nb *x_ = &nb[off[a] + deg[a]++];                                        \
        x_->to = (b);                                                                      \
        x_->angle = atan2(v[b] - v[a], u[b] - u[a]);                                       \
    } while (0)
    for (i = 0; i < n; i++) {
        int q = i + 1 == n ? 0 : i + 1;
        PDS__SWEEP_LINK(i, q);
        PDS__SWEEP_LINK(q, i);
    }
    for (i = 0; i < w.ndiag; i++) {
        PDS__SWEEP_LINK(w.diag[2 * i], w.diag[2 * i + 1]);
        PDS__SWEEP_LINK(w.diag[2 * i + 1], w.diag[2 * i]);
    }
#undef PDS__SWEEP_LINK
    for (i = 0; i < n; i++) qsort(nb + off[i], (size_t)deg[i], sizeof *nb, pds__sweep_nb_cmp);
    /* the outside face is the walk along i+1 -> i: mark those done */
    for (i = 0; i < n; i++) {
        int q = i + 1 == n ? 0 : i + 1, j;
        for (j = 0; j < deg[q]; j++)
            if (nb[off[q] + j].to == i) done[off[q] + j] = 1;
    }
    for (i = 0; i < total && ok; i++) {
        int a, at, m = 0, steps = 0;
        if (done[i]) continue;
        for (a = 0; a + 1 < n && off[a + 1] <= i; a++) {}
        at = i;
        /* walk: half-edge (a -> b) at nb[at] */
        while (!done[at] && steps++ <= n && m < n) {
            int b = nb[at].to, j, back = -1;
            done[at] = 1;
            piece[m++] = a;
            for (j = 0; j < deg[b]; j++)
                if (nb[off[b] + j].to == a) back = j;
            if (back < 0) break;
            /* the neighbour of b just clockwise of a: the one before it */
            at = off[b] + (back + deg[b] - 1) % deg[b];
            a = b;
        }
        if (at != i || m < 3) {
            ok = 0;
            break;
        }
        if (k / 3 + m - 2 > n - 2) {
            ok = 0;
            break;
        }
        pds__sweep_monotone(&w, piece, m, chain, sorted, stack, tris, &k);
    }
    if (ok && k != 3 * (n - 2)) ok = 0;
    /* counter-clockwise, as the caller's normal expects */
    for (i = 0; ok && i < k; i += 3)
        if (pds__obj_orient(u, v, tris[i], tris[i + 1], tris[i + 2]) < 0.0) {
            int t = tris[i + 1];
            tris[i + 1] = tris[i + 2];
            tris[i + 2] = t;
        }
    free(nb);
    free(done);
    free(piece);
    free(ints);
    free(prio);
    return ok;
}

/* Triangulate the face in s->fpos[0..n-1] (n >= 3) whose Newell normal is
   nn. Writes n-2 corner triples to s->tris, counter-clockwise as seen
   from nn. Ear clipping (Meisters 1975) in the plane that drops nn's
   largest axis; a polygon with no ear left (self-intersecting or
   degenerate) is finished as a fan. Returns 0, or -1 out of memory. */
static int pds__obj_triangulate(pds__obj_state *s, int n, pds__v3 nn)
{
    int i, k = 0, remaining = n, nreflex = 0, stall = 0, axis;
    double an[3];
    if (pds__grow((void **)&s->tris, &s->cap_tris, 3 * (size_t)n, sizeof *s->tris)) return -1;
    if (n == 3) {
        s->tris[0] = 0;
        s->tris[1] = 1;
        s->tris[2] = 2;
        return 0;
    }
    if (pds__grow((void **)&s->u, &s->cap_u, (size_t)n, sizeof *s->u) ||
        pds__grow((void **)&s->v, &s->cap_v, (size_t)n, sizeof *s->v) ||
        pds__grow((void **)&s->prev, &s->cap_prev, (size_t)n, sizeof *s->prev) ||
        pds__grow((void **)&s->next, &s->cap_next, (size_t)n, sizeof *s->next) ||
        pds__grow((void **)&s->reflex, &s->cap_reflex, (size_t)n, 1))
        return -1;
    /* Project: drop the dominant axis; (u, v) in cyclic order after it is
       counter-clockwise when nn points along +axis, so swap when it is -. */
    an[0] = fabs(nn.x);
    an[1] = fabs(nn.y);
    an[2] = fabs(nn.z);
    axis = an[0] >= an[1] && an[0] >= an[2] ? 0 : an[1] >= an[2] ? 1 : 2;
    for (i = 0; i < n; i++) {
        pds__v3 p = s->pos[s->fpos[i]];
        double a = pds__v3_get(p, (axis + 1) % 3), b = pds__v3_get(p, (axis + 2) % 3);
        int neg = pds__v3_get(nn, axis) < 0.0;
        s->u[i] = neg ? b : a;
        s->v[i] = neg ? a : b;
        s->prev[i] = (i + n - 1) % n;
        s->next[i] = (i + 1) % n;
    }
    if (n > PDS__EAR_CLIP_MAX) {
        int r = pds__obj_triangulate_sweep(s->u, s->v, n, s->tris);
        if (r < 0) return -1;
        if (r > 0) return 0;
        /* a face that crosses itself: a fan, as ear clipping would end */
        for (i = 0; i + 2 < n; i++) {
            s->tris[3 * i] = 0;
            s->tris[3 * i + 1] = i + 1;
            s->tris[3 * i + 2] = i + 2;
        }
        return 0;
    }
    for (i = 0; i < n; i++) {
        s->reflex[i] = pds__obj_orient(s->u, s->v, s->prev[i], i, s->next[i]) <= 0.0;
        nreflex += s->reflex[i];
    }
    i = 0;
    while (remaining > 3) {
        if (pds__obj_is_ear(s, i, nreflex)) {
            int a = s->prev[i], c = s->next[i], j;
            s->tris[k++] = a;
            s->tris[k++] = i;
            s->tris[k++] = c;
            s->next[a] = c;
            s->prev[c] = a;
            remaining--;
            nreflex -= s->reflex[i];
            /* the neighbours' angles changed */
            for (j = 0; j < 2; j++) {
                int w = j ? c : a;
                unsigned char rf = pds__obj_orient(s->u, s->v, s->prev[w], w, s->next[w]) <= 0.0;
                nreflex += (int)rf - (int)s->reflex[w];
                s->reflex[w] = rf;
            }
            i = a;
            stall = 0;
        } else if (++stall > remaining) {
            /* no ear: fan from i over what is left */
            int b = s->next[i];
            while (s->next[b] != i) {
                s->tris[k++] = i;
                s->tris[k++] = b;
                s->tris[k++] = s->next[b];
                b = s->next[b];
            }
            return 0;
        } else {
            i = s->next[i];
        }
    }
    s->tris[k++] = s->prev[i];
    s->tris[k++] = i;
    s->tris[k++] = s->next[i];
    return 0;
}

/* ---------------------------------------------------------------- faces */

/* Mesh vertex (*out) for position p with normal source (kind, val);
   made, with normal n, the first time it is asked for. */
static pds_status pds__obj_vertex(pds__obj_state *s, int p, int kind, long long val, pds__v3 n,
                                  int *out)
{
    int j;
    long vi;
    size_t local;
    for (j = s->head[p]; j >= 0; j = s->nodes[j].next) {
        if (s->nodes[j].kind == kind && s->nodes[j].val == val) {
            *out = s->nodes[j].vert;
            return PDS_OK;
        }
    }
    if (s->mesh->nverts >= (size_t)INT_MAX / 4 - 1 || s->nnodes >= (size_t)INT_MAX - 1)
        return pds__fail(s->err, PDS_ERR_LIMIT, s->path, 0, 0, "too many vertices");
    vi = pds__mesh_add_vertex(s->mesh, s->pos[p], n);
    local = s->mesh->nverts - s->base_v;
    if (vi < 0 || pds__grow((void **)&s->nodes, &s->cap_nodes, s->nnodes + 1, sizeof *s->nodes) ||
        pds__grow((void **)&s->acc, &s->cap_acc, local, sizeof *s->acc) ||
        pds__grow((void **)&s->kind, &s->cap_kind, local, 1))
        return pds__nomem(s->err);
    s->acc[local - 1] = pds__v(0.0, 0.0, 0.0);
    s->kind[local - 1] = (unsigned char)kind;
    s->nodes[s->nnodes].val = val;
    s->nodes[s->nnodes].kind = kind;
    s->nodes[s->nnodes].vert = (int)vi;
    s->nodes[s->nnodes].next = s->head[p];
    s->head[p] = (int)s->nnodes++;
    *out = (int)vi;
    return PDS_OK;
}

/* Resolve a 1-based or negative OBJ index against count elements read so
   far into a 0-based index. what/plural name the element for errors. */
static pds_status pds__obj_index(pds__obj_state *s, const pds__obj_token *at, long long raw,
                                 size_t count, const char *what, const char *one,
                                 const char *many, int *out)
{
    long long r;
    if (raw == 0)
        return pds__obj_err(s, at, "%s index 0 is invalid: OBJ indices start at 1", what);
    r = raw > 0 ? raw - 1 : (long long)count + raw;
    if (r < 0 || r >= (long long)count)
        return pds__obj_err(s, at, "%s index %lld is out of range: %lu %s defined so far", what, raw,
                            (unsigned long)count, count == 1 ? one : many);
    *out = (int)r;
    return PDS_OK;
}

/* Parse one corner token "v", "v/vt", "v//vn", "v/vt/vn" (empty vt or vn
   fields allowed) into a position index and a normal index (-1: none). */
static pds_status pds__obj_corner(pds__obj_state *s, const pds__obj_token *t, int *p, int *nrm)
{
    int field = 0, i = 0;
    pds_status st;
    *nrm = -1;
    while (field < 3) {
        long long raw = 0;
        int used = pds__obj_parse_int(t->s + i, t->len - i, &raw);
        pds__obj_token at = *t;
        at.col += i;
        if (used == 0 && field == 0) break; /* malformed */
        if (used > 0) {
            if (field == 0) st = pds__obj_index(s, &at, raw, s->npos, "face", "vertex", "vertices", p);
            else {
                /* a vt or vn index out of range is dropped with a warning
                   (the normal is then computed), as other importers do:
                   only the position is needed to read the face */
                size_t count = field == 1 ? (size_t)s->ntex : s->nnrm;
                long long r = raw > 0 ? raw - 1 : (long long)count + raw;
                st = PDS_OK;
                if (raw == 0 || r < 0 || r >= (long long)count) {
                    if (s->st->bad_references++ == 0)
                        snprintf(s->st->bad_example, sizeof s->st->bad_example,
                                 "%.200s:%d:%d: %s index %lld of %lu", s->path, at.line, at.col,
                                 field == 1 ? "texture coordinate" : "normal", raw, (unsigned long)count);
                } else if (field == 2) {
                    *nrm = (int)r;
                }
            }
            if (st != PDS_OK) return st;
            i += used;
        }
        field++;
        if (i == t->len) return PDS_OK;
        if (t->s[i] != '/') break;
        i++;
        if (i == t->len && field < 3) return PDS_OK; /* "7/" or "7//" */
    }
    return pds__obj_err(s, t, "expected a vertex index like 7, 7/2, 7//3 or 7/2/3, got '%.*s'",
                        t->len > 64 ? 64 : t->len, t->s);
}

/* Angle-weighted smooth-normal sums of triangle (a, b, c) (corner indices
   into the face scratch) for the corners whose vertex is smooth. */
static void pds__obj_accumulate(pds__obj_state *s, int a, int b, int c)
{
    int cs[3], k;
    pds__v3 p[3], n;
    cs[0] = a;
    cs[1] = b;
    cs[2] = c;
    for (k = 0; k < 3; k++) p[k] = s->pos[s->fpos[cs[k]]];
    n = pds__normalize(pds__cross(pds__sub(p[1], p[0]), pds__sub(p[2], p[0])));
    for (k = 0; k < 3; k++) {
        size_t local = (size_t)s->fvert[cs[k]] - s->base_v;
        pds__v3 e1, e2;
        double ang;
        if (s->kind[local] != PDS__OBJ_KEY_SMOOTH) continue;
        e1 = pds__sub(p[(k + 1) % 3], p[k]);
        e2 = pds__sub(p[(k + 2) % 3], p[k]);
        ang = atan2(pds__length(pds__cross(e1, e2)), pds__dot(e1, e2));
        s->acc[local] = pds__add(s->acc[local], pds__scale(n, ang));
    }
}

/* f statement: corners, triangulation, vertices, triangles. */
static pds_status pds__obj_face(pds__obj_state *s, pds__obj_lexer *lx, const pds__obj_token *kw)
{
    pds__obj_token t;
    int n = 0, i, any_flat = 0, any_smooth = 0;
    pds__v3 nn = pds__v(0.0, 0.0, 0.0), flat;
    pds_status st;
    s->st->faces++;
    s->face_no++;
    while (pds__obj_next(lx, &t)) {
        if (n >= INT_MAX / 4) return pds__obj_err(s, &t, "face has too many corners");
        if (pds__grow((void **)&s->fpos, &s->cap_fpos, (size_t)n + 1, sizeof *s->fpos) ||
            pds__grow((void **)&s->fnrm, &s->cap_fnrm, (size_t)n + 1, sizeof *s->fnrm))
            return pds__nomem(s->err);
        if ((st = pds__obj_corner(s, &t, &s->fpos[n], &s->fnrm[n])) != PDS_OK) return st;
        n++;
    }
    if (n < 3)
        return pds__obj_err(s, kw, "a face needs at least 3 corners, got %d", n);
    if (pds__grow((void **)&s->fvert, &s->cap_fvert, (size_t)n, sizeof *s->fvert))
        return pds__nomem(s->err);
    if (s->flip) { /* mirrored: reverse to keep the winding's side */
        for (i = 0; i < n / 2; i++) {
            int a = s->fpos[i], b = s->fnrm[i];
            s->fpos[i] = s->fpos[n - 1 - i];
            s->fnrm[i] = s->fnrm[n - 1 - i];
            s->fpos[n - 1 - i] = a;
            s->fnrm[n - 1 - i] = b;
        }
    }
    for (i = 0; i < n; i++) {
        if (s->fnrm[i] >= 0 && pds__dot(s->nrm[s->fnrm[i]], s->nrm[s->fnrm[i]]) == 0.0) s->fnrm[i] = -1;
        if (s->fnrm[i] < 0 && s->group == 0) any_flat = 1;
        if (s->fnrm[i] < 0 && s->group != 0) any_smooth = 1;
    }
    if (n > 3 || any_flat) nn = pds__obj_newell(s->pos, s->fpos, n);
    flat = pds__normalize(nn);
    for (i = 0; i < n; i++) {
        pds__v3 zero = pds__v(0.0, 0.0, 0.0);
        if (s->fnrm[i] >= 0)
            st = pds__obj_vertex(s, s->fpos[i], PDS__OBJ_KEY_VN, s->fnrm[i], s->nrm[s->fnrm[i]], &s->fvert[i]);
        else if (s->group != 0)
            st = pds__obj_vertex(s, s->fpos[i], PDS__OBJ_KEY_SMOOTH, s->group, zero, &s->fvert[i]);
        else
            st = pds__obj_vertex(s, s->fpos[i], PDS__OBJ_KEY_FLAT, s->face_no, flat, &s->fvert[i]);
        if (st != PDS_OK) return st;
    }
    if (pds__obj_triangulate(s, n, nn)) return pds__nomem(s->err);
    for (i = 0; i < n - 2; i++) {
        int a = s->tris[3 * i], b = s->tris[3 * i + 1], c = s->tris[3 * i + 2], r;
        if (s->mesh->ntris >= (size_t)PDS_MAX_TRIANGLES)
            return pds__fail(s->err, PDS_ERR_LIMIT, s->path, kw->line, kw->col,
                             "more than %d triangles (the limit)", PDS_MAX_TRIANGLES);
        r = pds__mesh_add_tri(s->mesh, s->fvert[a], s->fvert[b], s->fvert[c], s->slot);
        if (r < 0) return pds__nomem(s->err);
        if (r > 0 && any_smooth) pds__obj_accumulate(s, a, b, c);
    }
    return PDS_OK;
}

/* v and vn: three finite numbers (extra values ignored); with limit,
   each must also be within +-PDS_MAX_COORD. */
static pds_status pds__obj_vec3(pds__obj_state *s, pds__obj_lexer *lx, const pds__obj_token *kw,
                                int limit, pds__v3 *out)
{
    double c[3];
    int k;
    pds_status st;
    for (k = 0; k < 3; k++) {
        pds__obj_lexer save = *lx;
        pds__obj_token t;
        if ((st = pds__obj_number(s, lx, s->path, kw, &c[k])) != PDS_OK) return st;
        if (limit && fabs(c[k]) > PDS_MAX_COORD) {
            pds__obj_next(&save, &t);
            return pds__fail(s->err, PDS_ERR_LIMIT, s->path, t.line, t.col,
                             "coordinate %g is larger than the limit %g", c[k], PDS_MAX_COORD);
        }
    }
    *out = pds__v(c[0], c[1], c[2]);
    return PDS_OK;
}

/* Statements PDS knows but has no use for (free-form geometry, lines,
   points, display attributes). */
static int pds__obj_known_unused(const pds__obj_token *kw)
{
    static const char *const words[] = {
        "p", "vp", "cstype", "deg", "bmat", "step", "curv", "curv2", "surf", "parm", "trim",
        "hole", "scrv", "sp", "end", "con", "mg", "bevel", "c_interp", "d_interp", "lod",
        "shadow_obj", "trace_obj", "ctech", "stech", "maplib", "usemap", "call", "csh", "res"};
    size_t i;
    for (i = 0; i < sizeof words / sizeof words[0]; i++)
        if (pds__obj_is(kw, words[i])) return 1;
    return 0;
}

/* One statement starting with keyword kw. */
static pds_status pds__obj_statement(pds__obj_state *s, pds__obj_lexer *lx, const pds__obj_token *kw)
{
    pds_status st;
    pds__obj_token t;
    if (pds__obj_is(kw, "v")) {
        pds__v3 p;
        if ((st = pds__obj_vec3(s, lx, kw, 1, &p)) != PDS_OK) return st;
        if (s->npos >= (size_t)INT_MAX / 4)
            return pds__fail(s->err, PDS_ERR_LIMIT, s->path, kw->line, kw->col, "too many vertices");
        if (pds__grow((void **)&s->pos, &s->cap_pos, s->npos + 1, sizeof *s->pos) ||
            pds__grow((void **)&s->head, &s->cap_head, s->npos + 1, sizeof *s->head))
            return pds__nomem(s->err);
        p = pds__xform_point(&s->xf, p);
        if (!(fabs(p.x) <= PDS_MAX_COORD && fabs(p.y) <= PDS_MAX_COORD && fabs(p.z) <= PDS_MAX_COORD))
            return pds__fail(s->err, PDS_ERR_LIMIT, s->path, kw->line, kw->col,
                             "the transform moves this vertex beyond the coordinate limit %g", PDS_MAX_COORD);
        s->pos[s->npos] = p;
        s->head[s->npos] = -1;
        s->npos++;
        s->st->vertices++;
    } else if (pds__obj_is(kw, "f") || pds__obj_is(kw, "fo")) {
        return pds__obj_face(s, lx, kw);
    } else if (pds__obj_is(kw, "vn")) {
        pds__v3 n;
        double m;
        if ((st = pds__obj_vec3(s, lx, kw, 0, &n)) != PDS_OK) return st;
        if (s->nnrm >= (size_t)INT_MAX / 4)
            return pds__fail(s->err, PDS_ERR_LIMIT, s->path, kw->line, kw->col, "too many normals");
        if (pds__grow((void **)&s->nrm, &s->cap_nrm, s->nnrm + 1, sizeof *s->nrm))
            return pds__nomem(s->err);
        /* scale by the largest component first: no overflow in the length */
        m = fabs(n.x) > fabs(n.y) ? fabs(n.x) : fabs(n.y);
        if (fabs(n.z) > m) m = fabs(n.z);
        s->nrm[s->nnrm++] = m > 0.0 ? pds__xform_normal(&s->xf, pds__scale(n, 1.0 / m)) : n;
        s->st->normals++;
    } else if (pds__obj_is(kw, "vt")) {
        double c;
        int k;
        if ((st = pds__obj_number(s, lx, s->path, kw, &c)) != PDS_OK) return st;
        for (k = 0; k < 2; k++) {
            pds__obj_lexer save = *lx;
            if (!pds__obj_next(lx, &t)) break;
            *lx = save;
            if ((st = pds__obj_number(s, lx, s->path, kw, &c)) != PDS_OK) return st;
        }
        s->ntex++;
        s->st->texcoords++;
    } else if (pds__obj_is(kw, "s")) {
        long long g = 0;
        if (!pds__obj_next(lx, &t))
            return pds__obj_err(s, kw, "'s' needs a smoothing group number or 'off'");
        if (pds__obj_is(&t, "off")) g = 0;
        else if (pds__obj_is(&t, "on")) g = 1;
        else if (pds__obj_parse_int(t.s, t.len, &g) != t.len || g < 0)
            return pds__obj_err(s, &t, "expected a smoothing group number or 'off' for 's', got '%.*s'",
                                t.len > 64 ? 64 : t.len, t.s);
        s->group = g;
    } else if (pds__obj_is(kw, "usemtl")) {
        char name[4096];
        size_t n;
        const char *key;
        int slot, r = pds__obj_rest(s, lx, name, sizeof name, &n);
        if (r == -2) return pds__nomem(s->err);
        if (r) return pds__obj_err(s, kw, "material name is too long");
        if (n == 0) {
            s->slot = -1; /* "usemtl" alone: back to the default material */
            return PDS_OK;
        }
        slot = pds__names_find(&s->slots, name, strlen(name));
        if (slot < 0) {
            slot = (int)s->nslots;
            key = pds__names_put(&s->slots, name, strlen(name), slot);
            if (!key || pds__grow((void **)&s->slot_names, &s->cap_slot_names, s->nslots + 1,
                                  sizeof *s->slot_names))
                return pds__nomem(s->err);
            s->slot_names[s->nslots++] = key;
        }
        s->slot = slot;
    } else if (pds__obj_is(kw, "mtllib")) {
#ifdef PDS_NO_MTL
        return PDS_OK; /* a build without MTL libraries: default materials */
#else
        return pds__obj_mtllib(s, lx);
#endif
    } else if (pds__obj_is(kw, "g")) {
        s->st->groups++;
    } else if (pds__obj_is(kw, "o")) {
        s->st->objects++;
    } else if (pds__obj_is(kw, "l")) {
        /* a polyline v1 v2 ... (v/vt corners): not geometry PDS renders;
           its segments are counted (the paths debug view writes them) */
        long n = 0;
        while (pds__obj_next(lx, &t)) n++;
        if (n < 2) return pds__obj_err(s, kw, "a line needs at least 2 vertices, got %ld", n);
        s->st->line_segments += n - 1;
    } else if (!pds__obj_known_unused(kw)) {
        pds__obj_ignore(s, s->path, kw);
    }
    return PDS_OK;
}

/* After the last face: material indices for the usemtl slots, final
   smooth normals, and a normal for any vertex that still has none. */
static pds_status pds__obj_finish(pds__obj_state *s)
{
    const pds__obj_options *o = s->opt;
    int *resolve = NULL;
    size_t i, t, nv = s->mesh->nverts - s->base_v;
    resolve = (int *)malloc((s->nslots + 1) * sizeof *resolve);
    if (!resolve) return pds__nomem(s->err);
    resolve[0] = o->material_override >= 0 ? o->material_override : o->default_material;
    for (i = 0; i < s->nslots; i++) {
        const char *name = s->slot_names[i];
        int m = -1, k;
        char trunc[64];
        if (o->material_override >= 0) {
            resolve[i + 1] = o->material_override;
            continue;
        }
        for (k = 0; k < o->override_count && m < 0; k++)
            if (o->override_names[k] && strcmp(o->override_names[k], name) == 0) m = o->override_materials[k];
        if (m < 0) {
            pds__strlcpy(trunc, name, sizeof trunc);
            m = pds__names_find(&s->matnames, trunc, strlen(trunc));
        }
        if (m < 0) {
            m = o->default_material;
            s->st->unknown_materials++;
        }
        resolve[i + 1] = m;
    }
    for (t = s->base_t; t < s->mesh->ntris; t++) s->mesh->mat[t] = resolve[s->mesh->mat[t] + 1];
    free(resolve);

    for (i = 0; i < nv; i++) {
        if (s->kind[i] == PDS__OBJ_KEY_SMOOTH) {
            pds__v3 n = pds__normalize(s->acc[i]);
            float *dst = s->mesh->nrm + 3 * (s->base_v + i);
            dst[0] = (float)n.x;
            dst[1] = (float)n.y;
            dst[2] = (float)n.z;
        }
    }
    /* Zero normals (smooth sums that cancel, degenerate flat faces, vertices
       of dropped triangles only): the winding normal of the first kept
       triangle using the vertex, else +z. */
    for (t = s->base_t; t < s->mesh->ntris; t++) {
        int k;
        for (k = 0; k < 3; k++) {
            long v = s->mesh->idx[3 * t + k];
            float *dst = s->mesh->nrm + 3 * v;
            if (dst[0] == 0.0f && dst[1] == 0.0f && dst[2] == 0.0f) {
                const int *c = s->mesh->idx + 3 * t;
                pds__v3 n = pds__cross(pds__sub(pds__mesh_pos(s->mesh, c[1]), pds__mesh_pos(s->mesh, c[0])),
                                       pds__sub(pds__mesh_pos(s->mesh, c[2]), pds__mesh_pos(s->mesh, c[0])));
                n = pds__normalize(n);
                dst[0] = (float)n.x;
                dst[1] = (float)n.y;
                dst[2] = (float)n.z;
            }
        }
    }
    for (i = s->base_v; i < s->mesh->nverts; i++) {
        float *dst = s->mesh->nrm + 3 * i;
        if (dst[0] == 0.0f && dst[1] == 0.0f && dst[2] == 0.0f) dst[2] = 1.0f;
    }
    return PDS_OK;
}

static void pds__obj_state_free(pds__obj_state *s)
{
    free(s->pos);
    free(s->head);
    free(s->nrm);
    free(s->nodes);
    free(s->acc);
    free(s->kind);
    free(s->fpos);
    free(s->fnrm);
    free(s->fvert);
    free(s->ftok);
    free(s->u);
    free(s->v);
    free(s->prev);
    free(s->next);
    free(s->tris);
    free(s->reflex);
    free(s->slot_names);
    pds__names_free(&s->slots);
    pds__names_free(&s->matnames);
    pds__names_free(&s->mtl_loaded);
}

/* Load the OBJ file at path into mesh (appending vertices and triangles)
   and its MTL materials into mats; see the prologue for the rules.
   stats (may be NULL) is filled on success and failure alike. On failure
   mesh and mats are restored to what they held before the call. */
static pds_status pds__obj_load(const char *path, pds__mesh *mesh, pds__materials *mats,
                                const pds__obj_options *opt, pds__obj_stats *stats, pds_error *err)
{
    pds__obj_state s;
    pds__obj_stats local_stats;
    pds__obj_lexer lx;
    pds__obj_token kw;
    char *buf = NULL;
    size_t size = 0;
    pds_status st = PDS_OK;
    size_t i;
    int k;

    if (!stats) stats = &local_stats;
    memset(stats, 0, sizeof *stats);
    if (!path || !mesh || !mats || !opt)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds__obj_load: missing argument");
    if (opt->material_override >= 0 ? (size_t)opt->material_override >= mats->count
                                    : (opt->default_material < 0 || (size_t)opt->default_material >= mats->count))
        return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "OBJ material index does not exist");
    for (k = 0; k < opt->override_count; k++)
        if (!opt->override_names || !opt->override_materials || opt->override_materials[k] < 0 ||
            (size_t)opt->override_materials[k] >= mats->count)
            return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "OBJ material override index does not exist");
    if (strlen(path) >= 4096) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "OBJ path is too long");

    memset(&s, 0, sizeof s);
    s.path = path;
    pds__dirname(path, s.dir, sizeof s.dir);
    s.mesh = mesh;
    s.mats = mats;
    s.opt = opt;
    s.st = stats;
    s.err = err;
    s.xf = opt->xform ? *opt->xform : pds__xform_identity();
    s.flip = pds__xform_det(&s.xf) < 0.0;
    s.group = -1;
    s.slot = -1;
    s.base_v = mesh->nverts;
    s.base_t = mesh->ntris;
    s.base_mats = mats->count;
    s.base_dropped = mesh->degenerate_dropped;
    for (i = 0; i < mats->count && st == PDS_OK; i++) {
        const char *nm = mats->items[i].name;
        if (!pds__names_put(&s.matnames, nm, strlen(nm), (int)i)) st = pds__nomem(err);
    }

    if (st == PDS_OK) st = pds__read_file(path, PDS_MAX_OBJ_BYTES, "OBJ file", &buf, &size, err);
    if (st == PDS_OK) st = pds__check_lines(path, buf, size, err);
    if (st == PDS_OK) {
        pds__obj_lexer_init(&lx, buf, size);
        while (st == PDS_OK && lx.p < lx.end) {
            if (pds__obj_next(&lx, &kw)) st = pds__obj_statement(&s, &lx, &kw);
            if (st == PDS_OK) pds__obj_end_statement(&lx);
        }
    }
    if (st == PDS_OK) st = pds__obj_finish(&s);

    stats->triangles = (long)(mesh->ntris - s.base_t);
    stats->degenerate_dropped = mesh->degenerate_dropped - s.base_dropped;
    if (st != PDS_OK) {
        mesh->nverts = s.base_v;
        mesh->ntris = s.base_t;
        mesh->degenerate_dropped = s.base_dropped;
        if (pds__materials_truncate(mats, s.base_mats)) st = pds__nomem(err);
    }
    free(buf);
    pds__obj_state_free(&s);
    return st;
}

/* ===================================================================== */
/* >>shapes                                                              */
/* ===================================================================== */
/* Built-in generators. Each one writes triangles with smooth vertex
   normals into a pds__mesh, in world space: every vertex goes through the
   shape's transform as it is emitted (positions by the affine map, normals
   by the inverse transpose), and every triangle's winding is made to agree
   with its vertex normals, so the geometric normal (P1-P0)x(P2-P0) points
   to the same side as the shading normal whatever the transform (mirroring
   included).

   Local frames (before the transform), y is "up" everywhere:
     sphere       centre at the origin
     disk, quad   in the plane y = 0, facing +y
     box          centred at the origin
     cylinder     axis +y, from y = 0 to y = height
     torus        around the y axis, in the plane y = 0
     revolve      profile (r, y) swept around the y axis
     heightfield  grid over x, z centred at the origin, y = h(x, z)
   Swept shapes start at angle 0 on +x and turn towards +z. */

typedef struct pds__emitter {
    pds__mesh *mesh;
    const pds__xform *xf;
    int material;
} pds__emitter;

/* Emit one vertex (local position and normal); -1 when out of memory. */
static long pds__emit_vertex(const pds__emitter *e, pds__v3 p, pds__v3 n)
{
    return pds__mesh_add_vertex(e->mesh, pds__xform_point(e->xf, p),
                                pds__xform_normal(e->xf, pds__normalize(n)));
}

/* Emit triangle (a, b, c), swapping b and c if the winding disagrees with
   the vertices' normals. Returns -1 only when out of memory / over the
   limit (a degenerate triangle is dropped and counted by the mesh). */
static int pds__emit_tri(const pds__emitter *e, long a, long b, long c)
{
    const pds__mesh *m = e->mesh;
    pds__v3 pa = pds__mesh_pos(m, a);
    pds__v3 ng = pds__cross(pds__sub(pds__mesh_pos(m, b), pa), pds__sub(pds__mesh_pos(m, c), pa));
    pds__v3 ns = pds__add(pds__add(pds__mesh_nrm(m, a), pds__mesh_nrm(m, b)), pds__mesh_nrm(m, c));
    if (pds__dot(ng, ns) < 0.0) {
        long t = b;
        b = c;
        c = t;
    }
    return pds__mesh_add_tri(e->mesh, a, b, c, e->material) < 0 ? -1 : 0;
}

/* Emit a grid of (nu+1) x (nv+1) vertices produced by fn(u_index, v_index)
   and the 2 nu nv triangles between them. The workhorse of every smooth
   surface below: fn writes the local position and normal. */
typedef void (*pds__grid_fn)(const void *ctx, int i, int j, pds__v3 *p, pds__v3 *n);

static int pds__emit_grid(const pds__emitter *e, int nu, int nv, pds__grid_fn fn, const void *ctx)
{
    long base = (long)e->mesh->nverts;
    int i, j;
    for (j = 0; j <= nv; j++) {
        for (i = 0; i <= nu; i++) {
            pds__v3 p, n;
            fn(ctx, i, j, &p, &n);
            if (pds__emit_vertex(e, p, n) < 0) return -1;
        }
    }
    for (j = 0; j < nv; j++) {
        for (i = 0; i < nu; i++) {
            long v00 = base + (long)j * (nu + 1) + i, v10 = v00 + 1;
            long v01 = v00 + (nu + 1), v11 = v01 + 1;
            if (pds__emit_tri(e, v00, v10, v11) < 0) return -1;
            if (pds__emit_tri(e, v00, v11, v01) < 0) return -1;
        }
    }
    return 0;
}

/* --- sphere: longitude i in [0, segments], latitude j in [0, rings] ---- */
typedef struct pds__sphere_ctx { double radius; int segments, rings; } pds__sphere_ctx;

static void pds__sphere_vertex(const void *vctx, int i, int j, pds__v3 *p, pds__v3 *n)
{
    const pds__sphere_ctx *c = (const pds__sphere_ctx *)vctx;
    double phi = 2.0 * PDS__PI * (double)(i % c->segments) / c->segments;
    double theta = PDS__PI * (double)j / c->rings;
    *n = pds__v(sin(theta) * cos(phi), cos(theta), sin(theta) * sin(phi));
    if (j == 0) *n = pds__v(0.0, 1.0, 0.0);
    if (j == c->rings) *n = pds__v(0.0, -1.0, 0.0);
    *p = pds__scale(*n, c->radius);
}

static int pds__gen_sphere(const pds__emitter *e, double radius, int segments, int rings)
{
    pds__sphere_ctx c;
    c.radius = radius;
    c.segments = segments;
    c.rings = rings;
    /* The pole rows are rings of coincident vertices: half of each pole
       quad has zero area and is dropped by the mesh, as intended. Those
       drops are not user errors, so they are not counted. */
    {
        long before = e->mesh->degenerate_dropped;
        int r = pds__emit_grid(e, segments, rings, pds__sphere_vertex, &c);
        e->mesh->degenerate_dropped = before;
        return r;
    }
}

/* --- annulus in a plane: disk (inner = 0), cylinder caps ---------------- */
typedef struct pds__annulus_ctx {
    double r0, r1, y, sweep_rad;
    int segments;
    double ny; /* normal is (0, ny, 0) */
} pds__annulus_ctx;

static void pds__annulus_vertex(const void *vctx, int i, int j, pds__v3 *p, pds__v3 *n)
{
    const pds__annulus_ctx *c = (const pds__annulus_ctx *)vctx;
    double phi = c->sweep_rad * (double)i / c->segments;
    double r = j == 0 ? c->r0 : c->r1;
    *p = pds__v(r * cos(phi), c->y, r * sin(phi));
    *n = pds__v(0.0, c->ny, 0.0);
}

/* A flat ring r0 <= r <= r1 at height y facing ny (+1 or -1). With r0 = 0
   the inner row collapses to the centre and its triangles' zero-area
   halves are dropped silently. */
static int pds__gen_annulus(const pds__emitter *e, double r0, double r1, double y, double ny,
                            int segments, double sweep_rad)
{
    pds__annulus_ctx c;
    long before = e->mesh->degenerate_dropped;
    int r;
    c.r0 = r0;
    c.r1 = r1;
    c.y = y;
    c.ny = ny;
    c.segments = segments;
    c.sweep_rad = sweep_rad;
    r = pds__emit_grid(e, segments, 1, pds__annulus_vertex, &c);
    e->mesh->degenerate_dropped = before;
    return r;
}

/* --- quad: size_x by size_z in y = 0, segments x segments cells --------- */
typedef struct pds__quad_ctx { double sx, sz; int nx, nz; } pds__quad_ctx;

static void pds__quad_vertex(const void *vctx, int i, int j, pds__v3 *p, pds__v3 *n)
{
    const pds__quad_ctx *c = (const pds__quad_ctx *)vctx;
    *p = pds__v(c->sx * ((double)i / c->nx - 0.5), 0.0, c->sz * ((double)j / c->nz - 0.5));
    *n = pds__v(0.0, 1.0, 0.0);
}

static int pds__gen_quad(const pds__emitter *e, double sx, double sz, int segments)
{
    pds__quad_ctx c;
    c.sx = sx;
    c.sz = sz;
    c.nx = segments;
    c.nz = segments;
    return pds__emit_grid(e, segments, segments, pds__quad_vertex, &c);
}

/* --- box: six flat faces, each its own vertices (sharp edges) ----------- */
static int pds__gen_box(const pds__emitter *e, pds__v3 size)
{
    int axis, side;
    pds__v3 h = pds__scale(size, 0.5);
    for (axis = 0; axis < 3; axis++) {
        for (side = -1; side <= 1; side += 2) {
            /* Face normal along axis; u, v span the face. */
            double nv[3] = {0, 0, 0}, uv[3] = {0, 0, 0}, vv[3] = {0, 0, 0};
            pds__v3 n, u, v, c;
            long k[4];
            int q;
            nv[axis] = side;
            uv[(axis + 1) % 3] = 1.0;
            vv[(axis + 2) % 3] = 1.0;
            n = pds__v(nv[0], nv[1], nv[2]);
            u = pds__v(uv[0] * h.x, uv[1] * h.y, uv[2] * h.z);
            v = pds__v(vv[0] * h.x, vv[1] * h.y, vv[2] * h.z);
            c = pds__v(nv[0] * h.x, nv[1] * h.y, nv[2] * h.z);
            for (q = 0; q < 4; q++) {
                double su = (q == 1 || q == 2) ? 1.0 : -1.0, sv = (q >= 2) ? 1.0 : -1.0;
                k[q] = pds__emit_vertex(e, pds__add(c, pds__add(pds__scale(u, su), pds__scale(v, sv))), n);
                if (k[q] < 0) return -1;
            }
            if (pds__emit_tri(e, k[0], k[1], k[2]) < 0 || pds__emit_tri(e, k[0], k[2], k[3]) < 0)
                return -1;
        }
    }
    return 0;
}

/* --- surfaces of revolution: cylinder walls, torus, revolve ------------- */
/* A profile is a polyline of (r, y) points with a normal (nr, ny) at each
   point; sweeping it around +y by sweep_rad in `segments` steps gives a
   grid. Profile vertex j is row j of the grid. */
typedef struct pds__profile_pt { double r, y, nr, ny; } pds__profile_pt;

typedef struct pds__sweep_ctx {
    const pds__profile_pt *pts;
    int segments;
    double sweep_rad;
} pds__sweep_ctx;

static void pds__sweep_vertex(const void *vctx, int i, int j, pds__v3 *p, pds__v3 *n)
{
    const pds__sweep_ctx *c = (const pds__sweep_ctx *)vctx;
    double phi = c->sweep_rad * (double)i / c->segments;
    /* A full turn closes exactly onto its first column. */
    double cp = cos(phi), sp = sin(phi);
    const pds__profile_pt *q = &c->pts[j];
    if (fabs(c->sweep_rad - 2.0 * PDS__PI) < 1e-12 && i == c->segments) {
        cp = 1.0;
        sp = 0.0;
    }
    *p = pds__v(q->r * cp, q->y, q->r * sp);
    *n = pds__v(q->nr * cp, q->ny, q->nr * sp);
}

/* Sweep npts profile points; zero-area triangles at the axis are dropped
   silently. */
static int pds__gen_sweep(const pds__emitter *e, const pds__profile_pt *pts, int npts,
                          int segments, double sweep_rad)
{
    pds__sweep_ctx c;
    long before = e->mesh->degenerate_dropped;
    int r;
    c.pts = pts;
    c.segments = segments;
    c.sweep_rad = sweep_rad;
    r = pds__emit_grid(e, segments, npts - 1, pds__sweep_vertex, &c);
    e->mesh->degenerate_dropped = before;
    return r;
}

/* Flat cut face of a partial sweep, at angle phi: the polygon of the
   profile between two curves is not needed here, only the rectangle of a
   tube wall (r0..r1 by 0..h), facing away from the swept solid. */
static int pds__gen_sweep_end(const pds__emitter *e, double r0, double r1, double h, double phi,
                              double side)
{
    pds__v3 n = pds__v(-sin(phi) * side, 0.0, cos(phi) * side);
    pds__v3 d = pds__v(cos(phi), 0.0, sin(phi));
    long k[4];
    k[0] = pds__emit_vertex(e, pds__scale(d, r0), n);
    k[1] = pds__emit_vertex(e, pds__scale(d, r1), n);
    k[2] = pds__emit_vertex(e, pds__add(pds__scale(d, r1), pds__v(0, h, 0)), n);
    k[3] = pds__emit_vertex(e, pds__add(pds__scale(d, r0), pds__v(0, h, 0)), n);
    if (k[0] < 0 || k[1] < 0 || k[2] < 0 || k[3] < 0) return -1;
    if (pds__emit_tri(e, k[0], k[1], k[2]) < 0 || pds__emit_tri(e, k[0], k[2], k[3]) < 0) return -1;
    return 0;
}

/* Cylinder of radius r around +y from y = 0 to height, optionally a tube
   (inner > 0: inner wall facing the axis), optionally capped (closed: disks
   or rings at both ends, plus the two cut faces of a partial sweep). */
static int pds__gen_cylinder(const pds__emitter *e, double radius, double inner, double height,
                             int segments, int closed, double sweep_rad)
{
    pds__profile_pt wall[2];
    wall[0].r = radius;
    wall[0].y = 0.0;
    wall[0].nr = 1.0;
    wall[0].ny = 0.0;
    wall[1] = wall[0];
    wall[1].y = height;
    if (pds__gen_sweep(e, wall, 2, segments, sweep_rad) < 0) return -1;
    if (inner > 0.0) {
        wall[0].r = wall[1].r = inner;
        wall[0].nr = wall[1].nr = -1.0;
        if (pds__gen_sweep(e, wall, 2, segments, sweep_rad) < 0) return -1;
    }
    if (closed) {
        if (pds__gen_annulus(e, inner, radius, 0.0, -1.0, segments, sweep_rad) < 0) return -1;
        if (pds__gen_annulus(e, inner, radius, height, 1.0, segments, sweep_rad) < 0) return -1;
        if (sweep_rad < 2.0 * PDS__PI - 1e-9) {
            if (pds__gen_sweep_end(e, inner, radius, height, 0.0, -1.0) < 0) return -1;
            if (pds__gen_sweep_end(e, inner, radius, height, sweep_rad, 1.0) < 0) return -1;
        }
    }
    return 0;
}

/* Torus: tube of radius minor around the circle of radius major in y = 0.
   The tube's cross-section is a profile of rings+1 points. */
static int pds__gen_torus(const pds__emitter *e, double major, double minor, int segments, int rings,
                          double sweep_rad)
{
    pds__profile_pt *pts = (pds__profile_pt *)malloc(sizeof *pts * (size_t)(rings + 1));
    int j, r;
    if (!pts) return -1;
    for (j = 0; j <= rings; j++) {
        double a = 2.0 * PDS__PI * (double)(j % rings) / rings;
        pts[j].nr = cos(a);
        pts[j].ny = sin(a);
        pts[j].r = major + minor * pts[j].nr;
        pts[j].y = minor * pts[j].ny;
    }
    r = pds__gen_sweep(e, pts, rings + 1, segments, sweep_rad);
    free(pts);
    return r;
}

/* Surface of revolution of the polyline (r_k, y_k). The normal of a
   segment points to the right of its direction of travel in the (r, y)
   plane: a profile drawn upwards on the outside of a vase faces outwards.
   At a vertex where the two segments' normals differ by more than
   crease_deg the vertex is split (a sharp rim); otherwise the normals are
   averaged (a smooth bend). */
static int pds__gen_revolve(const pds__emitter *e, const double *rz, int n, int segments,
                            double sweep_rad, double crease_deg)
{
    pds__profile_pt *pts = (pds__profile_pt *)malloc(sizeof *pts * (size_t)(2 * n));
    double cos_crease = cos(crease_deg * PDS__PI / 180.0);
    int k, m = 0, r = 0, start = 0;
    if (!pts) return -1;
    for (k = 0; k < n; k++) {
        pds__v3 nin = pds__v(0, 0, 0), nout = pds__v(0, 0, 0);
        if (k > 0) nin = pds__normalize(pds__v(rz[2 * k + 1] - rz[2 * k - 1], -(rz[2 * k] - rz[2 * k - 2]), 0));
        if (k + 1 < n) nout = pds__normalize(pds__v(rz[2 * k + 3] - rz[2 * k + 1], -(rz[2 * k + 2] - rz[2 * k]), 0));
        if (k == 0) nin = nout;
        if (k + 1 == n) nout = nin;
        pts[m].r = rz[2 * k];
        pts[m].y = rz[2 * k + 1];
        if (pds__dot(nin, nout) >= cos_crease) {
            pds__v3 avg = pds__normalize(pds__add(nin, nout));
            pts[m].nr = avg.x;
            pts[m].ny = avg.y;
            m++;
        } else {
            /* Sharp: end the current strip with the incoming normal and
               start a new one with the outgoing normal. */
            pts[m].nr = nin.x;
            pts[m].ny = nin.y;
            m++;
            if (m - start >= 2 && pds__gen_sweep(e, pts + start, m - start, segments, sweep_rad) < 0) {
                r = -1;
                break;
            }
            start = m;
            pts[m].r = rz[2 * k];
            pts[m].y = rz[2 * k + 1];
            pts[m].nr = nout.x;
            pts[m].ny = nout.y;
            m++;
        }
    }
    if (r == 0 && m - start >= 2 && pds__gen_sweep(e, pts + start, m - start, segments, sweep_rad) < 0)
        r = -1;
    free(pts);
    return r;
}

/* --- heightfield: y = sum of sine waves --------------------------------- */
/* Each wave: amplitude A, wavelength L, unit direction (dx, dz) in the
   xz plane, phase p (radians): h = A sin(2 pi (dx x + dz z) / L + p).
   The normal is analytic: n = (-h_x, 1, -h_z), normalised. */
typedef struct pds__wave { double amplitude, wavelength, dx, dz, phase; } pds__wave;

typedef struct pds__heightfield_ctx {
    double sx, sz;
    int nx, nz;
    const pds__wave *waves;
    int nwaves;
} pds__heightfield_ctx;

/* Height and gradient of a wave sum at (x, z). */
static double pds__waves_eval(const pds__wave *w, int nw, double x, double z, double *hx, double *hz)
{
    double h = 0.0;
    int i;
    *hx = *hz = 0.0;
    for (i = 0; i < nw; i++) {
        double k = 2.0 * PDS__PI / w[i].wavelength;
        double arg = k * (w[i].dx * x + w[i].dz * z) + w[i].phase;
        h += w[i].amplitude * sin(arg);
        *hx += w[i].amplitude * k * w[i].dx * cos(arg);
        *hz += w[i].amplitude * k * w[i].dz * cos(arg);
    }
    return h;
}

static void pds__heightfield_vertex(const void *vctx, int i, int j, pds__v3 *p, pds__v3 *n)
{
    const pds__heightfield_ctx *c = (const pds__heightfield_ctx *)vctx;
    double x = c->sx * ((double)i / c->nx - 0.5), z = c->sz * ((double)j / c->nz - 0.5), hx, hz;
    double y = pds__waves_eval(c->waves, c->nwaves, x, z, &hx, &hz);
    *p = pds__v(x, y, z);
    *n = pds__v(-hx, 1.0, -hz);
}

static int pds__gen_heightfield(const pds__emitter *e, double sx, double sz, int nx, int nz,
                                const pds__wave *waves, int nwaves)
{
    pds__heightfield_ctx c;
    c.sx = sx;
    c.sz = sz;
    c.nx = nx;
    c.nz = nz;
    c.waves = waves;
    c.nwaves = nwaves;
    return pds__emit_grid(e, nx, nz, pds__heightfield_vertex, &c);
}

/* ===================================================================== */
/* >>bvh                                                                 */
/* ===================================================================== */
/* A 4-wide bounding volume hierarchy over the scene's triangles, leaves
   of up to four triangles stored as one SoA block: built as a binary tree
   with the binned surface area heuristic, collapsed to four children per
   node, traversed nearest child first with an explicit stack; watertight
   ray/triangle test, four triangles at a time.

   Build (Wald, "On fast construction of SAH-based bounding volume
   hierarchies", 2007): each node bins its triangles' centroids into
   PDS__BVH_BINS equal bins along each axis, sweeps the bin boundaries, and
   takes the plane of least SAH cost
       C = C_trav + (A_L B_L + A_R B_R) / A_P,   B = ceil(N / 4),
   counting the 4-triangle blocks each side fills (a block test costs the
   same for 1 to 4 triangles; one block test = 1), against the leaf cost
   B = 1. Nodes with more than PDS__BVH_MAX_LEAF = 4 triangles are always
   split; when every centroid sits at one spot the node is split by count.
   From depth PDS__BVH_SAH_DEPTH on, the builder uses object median
   splits, so no leaf is deeper than 56 (PDS_MAX_TRIANGLES < 2^26): that
   bounds the traversal stack. The binary tree is then collapsed into
   4-wide nodes by repeatedly opening the child of largest area, which
   halves the levels a ray walks through and lets the compiler test four
   boxes with one vector operation; every binary leaf becomes one block.

   Memory layout (what the hot loop reads):
     nodes  pds__bvh_node, 128 bytes = two cache lines, array aligned to 64:
            bytes   0..95  float b[24]: b[4 row + k], rows 0..2 = child
                           k's box minimum x y z, rows 3..5 its maximum
                           (SoA, so the four slab tests are one loop over k)
            bytes  96..111 uint32 child[4]: inner child: its node index;
                           leaf child: PDS__BVH_LEAF | its block
            bytes 112..127 uint32 count[4]: a leaf child's triangles (for
                           checks; the queries do not read it). Unused
                           slots have an inverted box (min = FLT_MAX, max =
                           -FLT_MAX) that no ray hits.
            Node 0 is the root. Boxes are padded outward by an ulp (see
            pds__bvh_collapse).
     tri4   pds__bvh_tri4, 144 bytes per leaf: v[vertex][axis][lane], the
            vertices of four triangles, copied from the mesh in their
            original order; a leaf of n < 4 triangles repeats its last one
            in the spare lanes (a repeat never gives a closer hit). Blocks
            are numbered in the order the collapse meets the leaves, so a
            subtree's blocks lie together.
     tri_id int per lane, 4 per block: the original triangle index.

   Queries convert the ray to float once; the per-axis values the box test
   needs are kept four times over in 16-byte aligned unions, which vector
   instructions read straight from memory. Box test: slabs with
   precomputed reciprocal directions, the near and far plane rows picked by
   the direction's signs (a row of pds__bvh_rows). A zero direction
   component gets the reciprocal +-FLT_MAX (not infinity), so (plane -
   origin) * rcp is never 0 * inf = NaN. The far distances use the
   reciprocal scaled by 1 + 2^-20 > 1 + 2 gamma(4) (Ize, "Robust BVH ray
   traversal", JCGT 2013), so rounding never rejects a box the exact ray
   touches. (Precomputing origin * reciprocal, to make each slab one
   multiply-subtract, is not done: without FMA it is as many operations,
   and it would lose the relative error bound the slack relies on.) Of the
   children hit, the nearest is visited next; with exactly one hit (half
   the node visits) its reference comes from a vector OR over the hit
   lanes, which keeps the 4-bit hit mask off the chain of dependent loads
   from one node to the next.
   Triangle test: Woop, Benthin, Wald, "Watertight ray/triangle
   intersection", JCGT 2013, as in pbrt-v3: shear the triangles into the
   ray's frame and take the signs of the three 2D edge functions, in float,
   four lanes at once. Each edge function comes with a bound on its
   rounding error (valid with or without FMA contraction); a lane where
   some edge function is within that bound of 0 is redone in double, where
   the products of the very same float coordinates are exact. So every
   decision is that of the exact signs, and neighbouring triangles never
   both miss a ray through their shared edge or vertex: pbrt's "redo in
   double when 0" made independent of how the compiler contracts. The
   float test only decides which triangle is hit and where the search may
   stop; the closest hit's t and barycentrics are then computed once in
   double (Moller-Trumbore on the same float vertices) for precision.

   Invariants: queries never modify the bvh (thread-safe, deterministic);
   t is in units of |dir|; the float interval the loop uses lies inside
   the caller's (tmin, tmax), so a hit within about 1e-7 (relative) of
   tmin or tmax may be dropped, but none outside is ever reported. The box
   slack widens positive far distances: with a negative tmin, a box that
   ends within about 1e-6 (relative) behind the origin may be missed.
   Limits: vertex coordinates and ray origins within 1e30 in magnitude,
   largest |dir| component above 1e-300 (any larger length is fine: it is
   scaled by a power of two internally). A direction component below
   1 / FLT_MAX after that scaling (zero, say) ends its slab at (plane -
   origin) * FLT_MAX instead of never; thanks to the padding that is past
   t = 4e31 |plane| + 4 for an origin inside the unpadded box, so only a
   ray starting within a face's padding, or lying in a face plane at
   coordinate 0 and reaching past t = 4, can lose hits to it. */

#define PDS__BVH_BINS 16       /* bins per axis (fewer in small nodes) */
#define PDS__BVH_MAX_LEAF 4    /* triangles per leaf at most: one block */
#define PDS__BVH_C_TRAV 1.0f   /* SAH cost of a binary traversal step, in
                                  units of one 4-triangle block test */
#define PDS__BVH_SAH_DEPTH 32
#define PDS__BVH_MAX_DEPTH 64   /* > 56, the deepest leaf possible */
#define PDS__BVH_STACK (3 * PDS__BVH_MAX_DEPTH + 4)
#define PDS__BVH_LEAF 0x80000000u /* child reference flag: a triangle block */
/* SAH cost of n triangles: the blocks of 4 they fill */
#define PDS__BVH_BLOCKS(n) (((n) + 3) >> 2)

typedef struct pds__bvh_node {
    float b[24];        /* SoA child boxes: b[4 row + k], rows min x y z,
                           max x y z */
    uint32_t child[4];  /* node index (inner) or PDS__BVH_LEAF | block */
    uint32_t count[4];  /* triangles in a leaf child, 0 for an inner or
                           unused one (the queries do not read it) */
} pds__bvh_node;

/* Four triangles, SoA: v[vertex][axis][lane]. */
typedef struct pds__bvh_tri4 {
    float v[3][3][4];
} pds__bvh_tri4;

typedef struct pds__bvh {
    pds__bvh_node *nodes; /* 64-byte aligned view into nodes_mem */
    void *nodes_mem;
    size_t nnodes;
    pds__bvh_tri4 *tri4;  /* one block per leaf */
    int *tri_id;          /* 4 per block: each lane's original triangle */
    size_t nblocks;
    size_t ntris;
    int depth;            /* deepest leaf of the binary tree (root = 0) */
    long leaves;
} pds__bvh;

typedef struct pds__tri_hit {
    double t;    /* distance in units of |dir| */
    long tri;    /* original triangle index */
    double u, v; /* P = (1-u-v) P0 + u P1 + v P2 */
} pds__tri_hit;

/* ------------------------------------------------------------------ build */

/* Binary node of the build (32 bytes): box, and the left child's index
   (right = first + 1) or the leaf's first triangle; count 0 = inner. */
typedef struct pds__bvh2_node {
    float lo[3];
    uint32_t first;
    float hi[3];
    uint32_t count;
} pds__bvh2_node;

/* One triangle during the build: its box and original index. Records are
   swapped (not indices) while partitioning, so every pass reads memory in
   order. The centroid is used doubled, c2 = lo + hi, to save a multiply. */
typedef struct pds__bvh_prim {
    float lo[3];
    int id;
    float hi[3];
    float pad;
} pds__bvh_prim;

typedef struct pds__bvh_bin {
    float lo[3], hi[3];
    uint32_t count;
} pds__bvh_bin;

/* A node waiting to be split: prims [begin, end), its centroid bounds. */
typedef struct pds__bvh_task {
    uint32_t node, begin, end;
    int depth;
    float clo[3], chi[3];
} pds__bvh_task;

static float pds__bvh_half_area(const float lo[3], const float hi[3])
{
    float dx = hi[0] - lo[0], dy = hi[1] - lo[1], dz = hi[2] - lo[2];
    return dx * dy + dy * dz + dz * dx;
}

/* Bin of doubled centroid c given the node's centroid minimum and the scale
   K (1 - eps) / extent. Written so NaN lands in bin 0 and nothing can make
   the float-to-int conversion overflow; build and partition share it so
   they always agree. */
static int pds__bvh_bin_index(float c, float cmin, float scale)
{
    float f = (c - cmin) * scale;
    f = f > 0.0f ? f : 0.0f; /* also NaN -> 0 */
    f = f < (float)(PDS__BVH_BINS - 1) ? f : (float)(PDS__BVH_BINS - 1);
    return (int)f;
}

static void pds__bvh_box_empty(float lo[3], float hi[3])
{
    lo[0] = lo[1] = lo[2] = FLT_MAX;
    hi[0] = hi[1] = hi[2] = -FLT_MAX;
}

static void pds__bvh_box_grow(float lo[3], float hi[3], const float plo[3], const float phi[3])
{
    int k;
    for (k = 0; k < 3; k++) {
        lo[k] = plo[k] < lo[k] ? plo[k] : lo[k];
        hi[k] = phi[k] > hi[k] ? phi[k] : hi[k];
    }
}

/* Bounds of prims [b, e): their boxes into lo/hi, doubled centroids into
   clo/chi. */
static void pds__bvh_bounds(const pds__bvh_prim *p, uint32_t b, uint32_t e,
                            float lo[3], float hi[3], float clo[3], float chi[3])
{
    uint32_t i;
    int k;
    pds__bvh_box_empty(lo, hi);
    pds__bvh_box_empty(clo, chi);
    for (i = b; i < e; i++) {
        for (k = 0; k < 3; k++) {
            float c = p[i].lo[k] + p[i].hi[k];
            lo[k] = p[i].lo[k] < lo[k] ? p[i].lo[k] : lo[k];
            hi[k] = p[i].hi[k] > hi[k] ? p[i].hi[k] : hi[k];
            clo[k] = c < clo[k] ? c : clo[k];
            chi[k] = c > chi[k] ? c : chi[k];
        }
    }
}

/* Reorders prims [b, e) so that the one with the median doubled centroid
   along axis is at m = (b + e) / 2, smaller ones before it, larger after
   (Hoare's selection, middle pivot; deterministic). Returns m. */
static uint32_t pds__bvh_median_split(pds__bvh_prim *p, uint32_t b, uint32_t e, int axis)
{
    uint32_t m = b + (e - b) / 2, lo = b, hi = e - 1;
    while (lo < hi) {
        uint32_t i = lo, j = hi;
        float pivot = p[lo + (hi - lo) / 2].lo[axis] + p[lo + (hi - lo) / 2].hi[axis];
        for (;;) {
            pds__bvh_prim tmp;
            while (p[i].lo[axis] + p[i].hi[axis] < pivot) i++;
            while (p[j].lo[axis] + p[j].hi[axis] > pivot) j--;
            if (i >= j) break;
            tmp = p[i];
            p[i] = p[j];
            p[j] = tmp;
            i++;
            j--;
        }
        /* now [lo, j] <= pivot <= [j+1, hi] */
        if (m <= j) hi = j;
        else lo = j + 1;
    }
    return m;
}

/* Best binned SAH split of prims [b, e) with centroid bounds clo/chi and
   box area parent_area. Returns 1 and the axis and split bin (prims in bins
   <= split go left) if some plane separates the centroids, with *cost the
   SAH cost in units of one block test. */
static int pds__bvh_find_split(const pds__bvh_prim *p, uint32_t b, uint32_t e,
                               const float clo[3], const float chi[3], float parent_area,
                               int *axis_out, int *split_out, float scale_out[3], float *cost)
{
    pds__bvh_bin bins[3][PDS__BVH_BINS];
    float right_area[PDS__BVH_BINS];
    uint32_t right_count[PDS__BVH_BINS];
    float scale[3];
    int axis, k, found = 0;
    uint32_t i;
    float best = FLT_MAX;
    /* small nodes need no more bins than triangles */
    const int nb = e - b < PDS__BVH_BINS ? (e - b < 4 ? 4 : (int)(e - b)) : PDS__BVH_BINS;

    for (axis = 0; axis < 3; axis++) {
        float ext = chi[axis] - clo[axis];
        scale[axis] = ext > 0.0f ? (float)nb * (1.0f - 1e-6f) / ext : 0.0f;
        scale_out[axis] = scale[axis];
        for (k = 0; k < nb; k++) {
            pds__bvh_box_empty(bins[axis][k].lo, bins[axis][k].hi);
            bins[axis][k].count = 0;
        }
    }
    for (i = b; i < e; i++) {
        const float lx = p[i].lo[0], ly = p[i].lo[1], lz = p[i].lo[2];
        const float hx = p[i].hi[0], hy = p[i].hi[1], hz = p[i].hi[2];
        pds__bvh_bin *bn[3];
        bn[0] = &bins[0][pds__bvh_bin_index(lx + hx, clo[0], scale[0])];
        bn[1] = &bins[1][pds__bvh_bin_index(ly + hy, clo[1], scale[1])];
        bn[2] = &bins[2][pds__bvh_bin_index(lz + hz, clo[2], scale[2])];
        for (axis = 0; axis < 3; axis++) {
            pds__bvh_bin *q = bn[axis];
            q->count++;
            q->lo[0] = lx < q->lo[0] ? lx : q->lo[0];
            q->lo[1] = ly < q->lo[1] ? ly : q->lo[1];
            q->lo[2] = lz < q->lo[2] ? lz : q->lo[2];
            q->hi[0] = hx > q->hi[0] ? hx : q->hi[0];
            q->hi[1] = hy > q->hi[1] ? hy : q->hi[1];
            q->hi[2] = hz > q->hi[2] ? hz : q->hi[2];
        }
    }
    for (axis = 0; axis < 3; axis++) {
        float lo[3], hi[3], area;
        uint32_t n = 0;
        if (scale[axis] == 0.0f) continue;
        /* sweep from the right: area and count of bins k..K-1 (an empty
           bin changes neither) */
        pds__bvh_box_empty(lo, hi);
        area = 0.0f;
        for (k = nb - 1; k > 0; k--) {
            if (bins[axis][k].count) {
                n += bins[axis][k].count;
                pds__bvh_box_grow(lo, hi, bins[axis][k].lo, bins[axis][k].hi);
                area = pds__bvh_half_area(lo, hi);
            }
            right_count[k] = n;
            right_area[k] = area;
        }
        /* sweep from the left; plane after bin k (after an empty bin it
           is the same split as the plane before it) */
        pds__bvh_box_empty(lo, hi);
        n = 0;
        for (k = 0; k < nb - 1; k++) {
            float c;
            if (bins[axis][k].count == 0) continue;
            if (right_count[k + 1] == 0) break;
            n += bins[axis][k].count;
            pds__bvh_box_grow(lo, hi, bins[axis][k].lo, bins[axis][k].hi);
            c = pds__bvh_half_area(lo, hi) * (float)PDS__BVH_BLOCKS(n) +
                right_area[k + 1] * (float)PDS__BVH_BLOCKS(right_count[k + 1]);
            if (c < best) {
                best = c;
                *axis_out = axis;
                *split_out = k;
                found = 1;
            }
        }
    }
    if (found) *cost = PDS__BVH_C_TRAV + best / (parent_area > 0.0f ? parent_area : 1.0f);
    return found;
}

/* Partitions prims [b, e) so those whose bin on axis is <= split come
   first; returns the first index of the right part. */
static uint32_t pds__bvh_partition(pds__bvh_prim *p, uint32_t b, uint32_t e, int axis,
                                   int split, float cmin, float scale)
{
    uint32_t i = b, j = e;
    while (i < j) {
        if (pds__bvh_bin_index(p[i].lo[axis] + p[i].hi[axis], cmin, scale) <= split) {
            i++;
        } else {
            pds__bvh_prim tmp = p[i];
            j--;
            p[i] = p[j];
            p[j] = tmp;
        }
    }
    return i;
}

static void pds__bvh_free(pds__bvh *bvh)
{
    free(bvh->nodes_mem);
    free(bvh->tri4);
    free(bvh->tri_id);
    memset(bvh, 0, sizeof *bvh);
}

/* Binary SAH build over prims[0, n) into bin (room for 2n nodes: the root
   is node 0, node 1 is unused, children come in pairs from 2 on). Reorders
   prims into leaf order. Returns the number of nodes used; *leaves and
   *depth are set. */
static size_t pds__bvh_build_binary(pds__bvh_prim *prims, uint32_t n, pds__bvh2_node *bin,
                                    long *leaves, int *depth)
{
    pds__bvh_task stack[PDS__BVH_MAX_DEPTH + 2];
    int sp = 1;
    size_t next = 2;
    float clo[3], chi[3];

    pds__bvh_bounds(prims, 0, n, bin[0].lo, bin[0].hi, clo, chi);
    memset(&bin[1], 0, sizeof bin[1]);
    stack[0].node = 0;
    stack[0].begin = 0;
    stack[0].end = n;
    stack[0].depth = 0;
    memcpy(stack[0].clo, clo, sizeof clo);
    memcpy(stack[0].chi, chi, sizeof chi);
    *leaves = 0;
    *depth = 0;

    while (sp > 0) {
        pds__bvh_task task = stack[--sp];
        pds__bvh2_node *node = &bin[task.node];
        uint32_t cnt = task.end - task.begin, mid = 0;
        int axis = 0, split = 0, do_split = 0, k;
        float scale[3], cost = 0.0f;

        if (cnt > 1) {
            if (task.depth < PDS__BVH_SAH_DEPTH &&
                pds__bvh_find_split(prims, task.begin, task.end, task.clo, task.chi,
                                    pds__bvh_half_area(node->lo, node->hi),
                                    &axis, &split, scale, &cost) &&
                (cnt > PDS__BVH_MAX_LEAF || cost < 1.0f)) {
                mid = pds__bvh_partition(prims, task.begin, task.end, axis, split,
                                         task.clo[axis], scale[axis]);
                do_split = mid > task.begin && mid < task.end;
            }
            if (!do_split && cnt > PDS__BVH_MAX_LEAF) {
                /* deep, or all centroids at one spot: object median */
                float best = -1.0f;
                for (k = 0; k < 3; k++) {
                    if (task.chi[k] - task.clo[k] > best) {
                        best = task.chi[k] - task.clo[k];
                        axis = k;
                    }
                }
                mid = pds__bvh_median_split(prims, task.begin, task.end, axis);
                do_split = 1;
            }
        }
        /* (the depth test never fires: see the prologue) */
        if (!do_split || task.depth >= PDS__BVH_MAX_DEPTH - 1) {
            node->first = task.begin;
            node->count = cnt;
            ++*leaves;
            if (task.depth > *depth) *depth = task.depth;
            continue;
        }
        {
            pds__bvh2_node *l = &bin[next], *r = &bin[next + 1];
            pds__bvh_task lt, rt;
            node->first = (uint32_t)next;
            node->count = 0;
            lt.node = (uint32_t)next;
            rt.node = (uint32_t)next + 1;
            next += 2;
            lt.begin = task.begin;
            lt.end = mid;
            rt.begin = mid;
            rt.end = task.end;
            lt.depth = rt.depth = task.depth + 1;
            pds__bvh_bounds(prims, lt.begin, lt.end, l->lo, l->hi, lt.clo, lt.chi);
            pds__bvh_bounds(prims, rt.begin, rt.end, r->lo, r->hi, rt.clo, rt.chi);
            stack[sp++] = rt;
            stack[sp++] = lt;
        }
    }
    return next;
}

/* Collapses the binary tree bin into 4-wide nodes (room for as many as
   bin has inner nodes, at least one). Leaf children become triangle
   blocks, numbered in the order they are met (so a subtree's blocks lie
   close together); block_src[b] gets the binary leaf of block b. Returns
   the number of nodes; *nblocks gets the number of blocks. */
static size_t pds__bvh_collapse(const pds__bvh2_node *bin, pds__bvh_node *nodes, uint32_t *block_src,
                                size_t *nblocks)
{
    uint32_t jobs_bin[PDS__BVH_STACK], jobs_node[PDS__BVH_STACK];
    int sp = 0;
    size_t next = 1, nb = 0;

    jobs_bin[0] = 0;
    jobs_node[0] = 0;
    sp = 1;
    while (sp > 0) {
        uint32_t slot[4], b = jobs_bin[--sp];
        pds__bvh_node *q = &nodes[jobs_node[sp]];
        int ns, k, c;
        if (bin[b].count) {
            slot[0] = b; /* a leaf root: one leaf child */
            ns = 1;
        } else {
            slot[0] = bin[b].first;
            slot[1] = bin[b].first + 1;
            ns = 2;
        }
        /* open the inner slot of largest area while there is room */
        while (ns < 4) {
            int best = -1;
            float best_area = -1.0f;
            for (k = 0; k < ns; k++) {
                const pds__bvh2_node *s = &bin[slot[k]];
                float a = pds__bvh_half_area(s->lo, s->hi);
                if (s->count == 0 && a > best_area) {
                    best_area = a;
                    best = k;
                }
            }
            if (best < 0) break;
            slot[ns] = bin[slot[best]].first + 1;
            slot[best] = bin[slot[best]].first;
            ns++;
        }
        for (k = 0; k < 4; k++) {
            if (k >= ns) {
                for (c = 0; c < 3; c++) {
                    q->b[4 * c + k] = FLT_MAX;
                    q->b[4 * (3 + c) + k] = -FLT_MAX;
                }
                q->child[k] = 0;
                q->count[k] = 0;
                continue;
            }
            for (c = 0; c < 3; c++) {
                /* pad outward by at least one ulp: a ray lying in a box's
                   face plane with a zero direction component would get
                   (plane - origin) * FLT_MAX = 0 as its far distance and
                   miss; with the padding its origin is strictly inside */
                float lo = bin[slot[k]].lo[c], hi = bin[slot[k]].hi[c];
                q->b[4 * c + k] = lo - (fabsf(lo) * (1.0f / 8388608.0f) + FLT_MIN);
                q->b[4 * (3 + c) + k] = hi + (fabsf(hi) * (1.0f / 8388608.0f) + FLT_MIN);
            }
            if (bin[slot[k]].count) {
                block_src[nb] = slot[k];
                q->child[k] = PDS__BVH_LEAF | (uint32_t)nb;
                q->count[k] = bin[slot[k]].count;
                nb++;
            } else {
                q->child[k] = (uint32_t)next;
                q->count[k] = 0;
                jobs_bin[sp] = slot[k];
                jobs_node[sp] = (uint32_t)next;
                sp++;
                next++;
            }
        }
    }
    *nblocks = nb;
    return next;
}

/* Builds the BVH of ntris triangles: pos holds 3 floats per vertex, idx 3
   vertex indices per triangle (the pds__mesh layout). Indices must be valid
   for pos (the mesh guarantees it); negative ones and non-finite or huge
   (> 1e30) coordinates are refused with PDS_ERR_INVALID_ARG. ntris = 0
   gives an empty BVH that every ray misses. On failure *bvh is left empty
   (pds__bvh_free on it is harmless). */
static pds_status pds__bvh_build(pds__bvh *bvh, const float *pos, const int *idx, size_t ntris,
                                 pds_error *err)
{
    pds__bvh_prim *prims = NULL;
    pds__bvh2_node *bin = NULL;
    uint32_t *block_src = NULL;
    size_t i, nbin, ninner;
    uintptr_t a;

    memset(bvh, 0, sizeof *bvh);
    if (ntris == 0) return PDS_OK;
    if (ntris > (size_t)PDS_MAX_TRIANGLES)
        return pds__fail(err, PDS_ERR_LIMIT, NULL, 0, 0,
                         "%lu triangles is over the limit of %d", (unsigned long)ntris, PDS_MAX_TRIANGLES);

    prims = (pds__bvh_prim *)malloc(ntris * sizeof *prims);
    bin = (pds__bvh2_node *)malloc(2 * ntris * sizeof *bin);
    if (!prims || !bin) goto nomem;
    for (i = 0; i < ntris; i++) {
        int c, k;
        pds__bvh_box_empty(prims[i].lo, prims[i].hi);
        prims[i].id = (int)i;
        prims[i].pad = 0.0f;
        for (c = 0; c < 3; c++) {
            const float *v;
            if (idx[3 * i + c] < 0) {
                free(prims);
                free(bin);
                return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0,
                                 "triangle %lu has a negative vertex index", (unsigned long)i);
            }
            v = pos + 3 * (size_t)idx[3 * i + c];
            for (k = 0; k < 3; k++) {
                if (!(v[k] >= -1e30f && v[k] <= 1e30f)) {
                    free(prims);
                    free(bin);
                    return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0,
                                     "triangle %lu has a vertex coordinate that is not a number or too large",
                                     (unsigned long)i);
                }
                prims[i].lo[k] = v[k] < prims[i].lo[k] ? v[k] : prims[i].lo[k];
                prims[i].hi[k] = v[k] > prims[i].hi[k] ? v[k] : prims[i].hi[k];
            }
        }
    }

    nbin = pds__bvh_build_binary(prims, (uint32_t)ntris, bin, &bvh->leaves, &bvh->depth);

    /* 4-wide nodes: at most one per binary inner node, at least one; one
       block per binary leaf */
    ninner = nbin / 2;
    bvh->nodes_mem = malloc(ninner * sizeof(pds__bvh_node) + 64);
    bvh->tri4 = (pds__bvh_tri4 *)malloc((size_t)bvh->leaves * sizeof(pds__bvh_tri4));
    bvh->tri_id = (int *)malloc((size_t)bvh->leaves * 4 * sizeof(int));
    block_src = (uint32_t *)malloc((size_t)bvh->leaves * sizeof(uint32_t));
    if (!bvh->nodes_mem || !bvh->tri4 || !bvh->tri_id || !block_src) goto nomem;
    a = ((uintptr_t)bvh->nodes_mem + 63) & ~(uintptr_t)63;
    bvh->nodes = (pds__bvh_node *)a;
    bvh->nnodes = pds__bvh_collapse(bin, bvh->nodes, block_src, &bvh->nblocks);
    if (bvh->nnodes < ninner) {
        /* give back the unused tail; realloc may move the block, and with
           it the 64-byte alignment offset, so the nodes are moved to the
           new aligned start */
        size_t off = (size_t)(a - (uintptr_t)bvh->nodes_mem);
        void *mem = realloc(bvh->nodes_mem, bvh->nnodes * sizeof(pds__bvh_node) + 64);
        if (mem) {
            uintptr_t na = ((uintptr_t)mem + 63) & ~(uintptr_t)63;
            if ((size_t)(na - (uintptr_t)mem) != off)
                memmove((void *)na, (char *)mem + off, bvh->nnodes * sizeof(pds__bvh_node));
            bvh->nodes_mem = mem;
            bvh->nodes = (pds__bvh_node *)na;
        }
    }

    /* the blocks: a leaf of n < 4 triangles repeats its last one in the
       spare lanes (a repeated triangle never gives a closer hit) */
    bvh->ntris = ntris;
    for (i = 0; i < bvh->nblocks; i++) {
        const pds__bvh2_node *leaf = &bin[block_src[i]];
        int l, c, k;
        for (l = 0; l < 4; l++) {
            uint32_t p = leaf->first + ((uint32_t)l < leaf->count ? (uint32_t)l : leaf->count - 1);
            int id = prims[p].id;
            bvh->tri_id[4 * i + l] = id;
            for (c = 0; c < 3; c++) {
                const float *v = pos + 3 * (size_t)idx[3 * (size_t)id + c];
                for (k = 0; k < 3; k++) bvh->tri4[i].v[c][k][l] = v[k];
            }
        }
    }
    free(block_src);
    free(bin);
    free(prims);
    return PDS_OK;

nomem:
    free(prims);
    free(bin);
    free(block_src);
    pds__bvh_free(bvh);
    return pds__nomem(err);
}

/* Bytes owned by the bvh. */
static size_t pds__bvh_memory(const pds__bvh *bvh)
{
    if (!bvh->nodes_mem) return 0;
    return bvh->nnodes * sizeof(pds__bvh_node) + 64 + bvh->nblocks * (sizeof(pds__bvh_tri4) + 4 * sizeof(int));
}

/* -------------------------------------------------------------- queries */

/* Four floats, aligned as a long double: 16 bytes on the usual 64-bit
   targets, so vector code may read them as memory operands. */
typedef union pds__bvh_f4 {
    float v[4];
    long double align;
} pds__bvh_f4;

/* The ray as the hot loop sees it, all float. The box test reads four
   copies of each per-axis value so that it runs as vector operations. */
typedef struct pds__bvh_ray {
    pds__bvh_f4 o4[3];     /* origin */
    pds__bvh_f4 rn4[3];    /* 1 / dir (+-FLT_MAX for a (near) zero component),
                           for the near slab planes */
    pds__bvh_f4 rf4[3];    /* the same scaled up by PDS__BVH_FAR_SCALE, for
                           the far planes */
    pds__bvh_f4 tmin4;     /* tmin */
    const int *row;     /* offsets in node->b of the rows holding the near
                           slab planes x y z, then the far ones: 4 axis
                           (min) or 4 (3 + axis) (max); a row of
                           pds__bvh_rows */
    int kx, ky, kz;     /* watertight frame: kz = largest |dir| axis, kx,
                           ky the next two cyclically */
    float ox, oy, oz;   /* origin components kx, ky, kz */
    float sx, sy, sz;   /* shear: -d_kx / d_kz, -d_ky / d_kz, 1 / d_kz */
    float tmin, tmax;   /* inside the caller's (tmin, tmax) */
} pds__bvh_ray;

/* Slack on the far slab distances, applied to the reciprocal: 1 + 2^-20,
   above the 1 + 2 gamma(4) that covers the four roundings in each of the
   near and far distances (Ize, "Robust BVH ray traversal", JCGT 2013), so
   a box the exact ray touches is never missed. */
#define PDS__BVH_FAR_SCALE 1.00000095367431640625

/* Float just above x (|x| <= FLT_MAX): at least one ulp past (float)x when
   that rounded down, so the float interval never leaves (tmin, tmax). */
static float pds__bvh_float_above(double x)
{
    float f = (float)x;
    if ((double)f < x) f += fabsf(f) * (1.0f / 8388608.0f) + FLT_MIN;
    return f;
}

static float pds__bvh_float_below(double x)
{
    float f = (float)x;
    if ((double)f > x) f -= fabsf(f) * (1.0f / 8388608.0f) + FLT_MIN;
    return f;
}

/* Row offsets of the near and far slab planes (see pds__bvh_ray.row) for
   each combination of direction signs: bit k set = axis k negative. */
static const int pds__bvh_rows[8][6] = {
    {0, 4, 8, 12, 16, 20}, {12, 4, 8, 0, 16, 20}, {0, 16, 8, 12, 4, 20}, {12, 16, 8, 0, 4, 20},
    {0, 4, 20, 12, 16, 8}, {12, 4, 20, 0, 16, 8}, {0, 16, 20, 12, 4, 8}, {12, 16, 20, 0, 4, 8}};

/* One axis of pds__bvh_ray_setup: origin o, direction d. */
static inline void pds__bvh_setup_axis(pds__bvh_ray *r, int k, double o, double d)
{
    /* A component whose reciprocal (or, for the far planes, the scaled
       reciprocal) is beyond FLT_MAX gets +-FLT_MAX, never inf, so (plane
       - origin) * rcp is never 0 * inf = NaN (see the prologue's
       limits). */
    float rn = (float)copysign(FLT_MAX, d), rf = rn;
    if (fabs(d) > 2.0 / FLT_MAX) {
        const double rk = 1.0 / d;
        rn = (float)rk;
        rf = (float)(rk * PDS__BVH_FAR_SCALE);
    } else if (d != 0.0 && fabs(1.0 / d) <= FLT_MAX) {
        rn = (float)(1.0 / d);
    }
    r->o4[k].v[0] = r->o4[k].v[1] = r->o4[k].v[2] = r->o4[k].v[3] = (float)o;
    r->rn4[k].v[0] = r->rn4[k].v[1] = r->rn4[k].v[2] = r->rn4[k].v[3] = rn;
    r->rf4[k].v[0] = r->rf4[k].v[1] = r->rf4[k].v[2] = r->rf4[k].v[3] = rf;
}

/* Prepares the float ray. A direction whose largest component is outside
   [2^-60, 2^60] is first scaled by a power of two s (exact), so every
   float below stays finite; then t_caller = s t_internal, returned in
   *tscale. Returns 0 if no hit is possible (zero, below 1e-300 or
   non-finite direction, origin not finite or beyond 1e30, empty
   interval). */
static int pds__bvh_ray_setup(pds__bvh_ray *r, pds__v3 org, pds__v3 dir, double tmin, double tmax,
                              double *tscale)
{
    static const int next[3] = {1, 2, 0};
    double o[3], d[3], ad[3], m, inv;
    int kx, ky, kz;
    o[0] = org.x;
    o[1] = org.y;
    o[2] = org.z;
    d[0] = dir.x;
    d[1] = dir.y;
    d[2] = dir.z;
    ad[0] = fabs(d[0]);
    ad[1] = fabs(d[1]);
    ad[2] = fabs(d[2]);
    if (!(fabs(o[0]) <= 1e30 && fabs(o[1]) <= 1e30 && fabs(o[2]) <= 1e30)) return 0;
    if (!(ad[0] <= DBL_MAX && ad[1] <= DBL_MAX && ad[2] <= DBL_MAX)) return 0; /* inf, NaN */
    /* kz = argmax |d|; kx, ky follow cyclically (keeps the winding) */
    m = ad[1] > ad[0] ? ad[1] : ad[0];
    kz = ad[2] > m ? 2 : ad[1] > ad[0];
    m = ad[2] > m ? ad[2] : m;
    kx = next[kz];
    ky = next[kx];
    *tscale = 1.0;
    if (!(m >= 0x1p-60 && m <= 0x1p60)) {
        int e, k;
        double s;
        if (!(m >= 1e-300)) return 0;
        (void)frexp(m, &e);
        s = ldexp(1.0, -e);
        for (k = 0; k < 3; k++) {
            d[k] *= s;
            ad[k] *= s;
        }
        tmin /= s;
        tmax /= s;
        *tscale = s;
    }
    if (!(tmin < tmax) || tmin >= FLT_MAX || tmax <= -FLT_MAX) return 0;
    r->tmin = tmin < -FLT_MAX ? -FLT_MAX : pds__bvh_float_above(tmin);
    r->tmax = tmax > FLT_MAX ? FLT_MAX : pds__bvh_float_below(tmax);
    r->tmin4.v[0] = r->tmin4.v[1] = r->tmin4.v[2] = r->tmin4.v[3] = r->tmin;
    pds__bvh_setup_axis(r, 0, o[0], d[0]);
    pds__bvh_setup_axis(r, 1, o[1], d[1]);
    pds__bvh_setup_axis(r, 2, o[2], d[2]);
    /* a negative reciprocal meets the max plane first */
    r->row = pds__bvh_rows[(r->rn4[0].v[0] < 0.0f) | (r->rn4[1].v[0] < 0.0f) << 1 |
                           (r->rn4[2].v[0] < 0.0f) << 2];
    r->kx = kx;
    r->ky = ky;
    r->kz = kz;
    r->ox = (float)o[kx];
    r->oy = (float)o[ky];
    r->oz = (float)o[kz];
    inv = 1.0 / d[kz];
    r->sx = (float)(-d[kx] * inv);
    r->sy = (float)(-d[ky] * inv);
    r->sz = (float)inv;
    return r->tmin < r->tmax;
}

/* Bound on the rounding error of a float 2x2 determinant p - q (p, q the
   rounded products; with or without FMA contraction) relative to |p| +
   |q|: 2 u is enough, 4 u = 2^-22 leaves room for rounding the bound
   itself. */
#define PDS__BVH_EDGE_EPS 2.384185791e-7f

/* The exact-sign fallback of pds__bvh_tri4_test for lane l: the edge
   functions from the same float sheared coordinates, in double, where the
   products of floats are exact, so each has the exact sign and an edge
   shared by two triangles gets exactly the negated value. Returns 1 with
   *t in (tmin, tmax) on a hit. */
static int pds__bvh_tri_exact(const pds__bvh_ray *r, const float X[3][4], const float Y[3][4],
                              const float Z[3][4], int l, float tmin, float tmax, float *t)
{
    const double ax = X[0][l], ay = Y[0][l], bx = X[1][l], by = Y[1][l], cx = X[2][l], cy = Y[2][l];
    const double e0 = bx * cy - by * cx;
    const double e1 = cx * ay - cy * ax;
    const double e2 = ax * by - ay * bx;
    double det, td;
    float tt;
    if ((e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0)) return 0;
    det = e0 + e1 + e2;
    if (det == 0.0) return 0;
    td = (e0 * Z[0][l] + e1 * Z[1][l] + e2 * Z[2][l]) * r->sz / det;
    if (!(td > -FLT_MAX && td < FLT_MAX)) return 0; /* (float) of it must be defined */
    tt = (float)td;
    if (!(tt > tmin && tt < tmax)) return 0;
    *t = tt;
    return 1;
}

/* Watertight test of the ray against the four triangles of block q.
   Returns the lane of the closest hit with t in (tmin, tmax) and its t in
   *t_out, or -1 (the barycentrics are left to pds__bvh_refine). Woop,
   Benthin, Wald 2013: the vertices are translated to the origin, permuted
   (kz = dominant axis) and sheared so the ray runs along +z; then the
   signs of the three 2D edge functions decide. They are computed in float with a bound on
   their rounding error; a lane where some edge function is within that
   bound of 0 (the ray passes within rounding of an edge's line) is redone
   exactly by pds__bvh_tri_exact. Either way the decision is that of the
   exact signs, so two triangles sharing an edge or vertex never both miss
   a ray through it, whatever FP contraction (FMA) the compiler applies.
   The loop runs over the four lanes with masks, not branches, so the
   compiler turns it into vector operations. */
static inline int pds__bvh_tri4_test(const pds__bvh_ray *r, const pds__bvh_tri4 *q, float tmin,
                                     float tmax, float *t_out)
{
    const float *vx0 = q->v[0][r->kx], *vy0 = q->v[0][r->ky], *vz0 = q->v[0][r->kz];
    const float *vx1 = q->v[1][r->kx], *vy1 = q->v[1][r->ky], *vz1 = q->v[1][r->kz];
    const float *vx2 = q->v[2][r->kx], *vy2 = q->v[2][r->ky], *vz2 = q->v[2][r->kz];
    const float ox = r->ox, oy = r->oy, oz = r->oz, sx = r->sx, sy = r->sy, sz = r->sz;
    float X[3][4], Y[3][4], Z[3][4], T[4], m;
    int l, best;
    for (l = 0; l < 4; l++) {
        /* vertices relative to the origin, sheared */
        const float z0 = vz0[l] - oz, z1 = vz1[l] - oz, z2 = vz2[l] - oz;
        const float x0 = (vx0[l] - ox) + sx * z0, y0 = (vy0[l] - oy) + sy * z0;
        const float x1 = (vx1[l] - ox) + sx * z1, y1 = (vy1[l] - oy) + sy * z1;
        const float x2 = (vx2[l] - ox) + sx * z2, y2 = (vy2[l] - oy) + sy * z2;
        /* e_i = 2D cross product of the other two vertices; weights v_i */
        const float p0 = x1 * y2, q0 = y1 * x2;
        const float p1 = x2 * y0, q1 = y2 * x0;
        const float p2 = x0 * y1, q2 = y0 * x1;
        const float e0 = p0 - q0, e1 = p1 - q1, e2 = p2 - q2;
        const float b0 = PDS__BVH_EDGE_EPS * (fabsf(p0) + fabsf(q0)) + FLT_MIN;
        const float b1 = PDS__BVH_EDGE_EPS * (fabsf(p1) + fabsf(q1)) + FLT_MIN;
        const float b2 = PDS__BVH_EDGE_EPS * (fabsf(p2) + fabsf(q2)) + FLT_MIN;
        /* masks (0 or -1): every sign sure; the three signs agree */
        const int sure = -(fabsf(e0) > b0) & -(fabsf(e1) > b1) & -(fabsf(e2) > b2);
        const int n0 = -(e0 < 0.0f), n1 = -(e1 < 0.0f), n2 = -(e2 < 0.0f);
        int hit = sure & ~((n0 ^ n1) | (n1 ^ n2));
        float det = e0 + e1 + e2, adet = fabsf(det), inv, t;
        /* a hit has |det| > FLT_MIN (all three e_i are, with one sign):
           the clamp only keeps the other lanes from dividing by 0 */
        adet = adet > FLT_MIN ? adet : FLT_MIN;
        inv = 1.0f / copysignf(adet, det);
        t = (e0 * z0 + e1 * z1 + e2 * z2) * sz * inv;
        hit &= -(t > tmin) & -(t < tmax);
        /* T: t of a hit, tmax for a miss, -FLT_MAX (below any t) for a
           lane needing the exact signs (two statements: gcc vectorises
           those, not the nested conditional) */
        t = hit ? t : tmax;
        T[l] = sure ? t : -FLT_MAX;
        X[0][l] = x0;
        X[1][l] = x1;
        X[2][l] = x2;
        Y[0][l] = y0;
        Y[1][l] = y1;
        Y[2][l] = y2;
        Z[0][l] = z0;
        Z[1][l] = z1;
        Z[2][l] = z2;
    }
    m = T[0] < T[1] ? T[0] : T[1];
    m = T[2] < m ? T[2] : m;
    m = T[3] < m ? T[3] : m;
    if (!(m < tmax)) return -1;
    if (m == -FLT_MAX) {
        /* rare: some lane needs the exact signs */
        for (l = 0; l < 4; l++) {
            float t;
            if (T[l] != -FLT_MAX) continue;
            T[l] = tmax;
            if (pds__bvh_tri_exact(r, (const float(*)[4])X, (const float(*)[4])Y,
                                   (const float(*)[4])Z, l, tmin, tmax, &t))
                T[l] = t;
        }
        m = T[0] < T[1] ? T[0] : T[1];
        m = T[2] < m ? T[2] : m;
        m = T[3] < m ? T[3] : m;
        if (!(m < tmax)) return -1;
    }
    /* the first lane at the minimum (every T[l] >= m) */
    best = T[2] > m ? 3 : 2;
    best = T[1] > m ? best : 1;
    best = T[0] > m ? best : 0;
    *t_out = m;
    return best;
}

/* A box is culled only when its entry distance exceeds the closest hit t
   so far by 2^-20 |t|: entry distances and triangle distances are rounded
   differently, and a triangle lying in its box's face (a flat leaf,
   coplanar geometry) must not be culled by a box entry computed a few ulps
   too far. */
static float pds__bvh_cull(float t)
{
    return t + fabsf(t) * (1.0f / 1048576.0f);
}

/* Slab test of the ray against node n's four child boxes: d[k] = entry
   distance into child k (at least tmin); returns the mask of children hit
   (bit k) with entry no later than tlim[k] (four copies of one limit),
   and in *one the OR of the hit children's references: the child itself
   when exactly one is hit (the common case), found without going through
   the mask, which shortens the chain of dependent operations from one
   node to the next. Written as a branch-free loop over the SoA rows,
   results in locals, so compilers run the four tests as vector
   operations. */
static inline int pds__bvh_box4(const pds__bvh_ray *r, const pds__bvh_node *n, const float tlim[4],
                                float d[4], uint32_t *one)
{
    const int *row = r->row;
    const float *nx = n->b + row[0], *ny = n->b + row[1], *nz = n->b + row[2];
    const float *fx = n->b + row[3], *fy = n->b + row[4], *fz = n->b + row[5];
    float dd[4];
    uint32_t hc[4];
    int h[4], k;
    for (k = 0; k < 4; k++) {
        const float tnx = (nx[k] - r->o4[0].v[k]) * r->rn4[0].v[k];
        const float tny = (ny[k] - r->o4[1].v[k]) * r->rn4[1].v[k];
        const float tnz = (nz[k] - r->o4[2].v[k]) * r->rn4[2].v[k];
        const float tfx = (fx[k] - r->o4[0].v[k]) * r->rf4[0].v[k];
        const float tfy = (fy[k] - r->o4[1].v[k]) * r->rf4[1].v[k];
        const float tfz = (fz[k] - r->o4[2].v[k]) * r->rf4[2].v[k];
        const float tn0 = tnx > tny ? tnx : tny, tn1 = tnz > r->tmin4.v[k] ? tnz : r->tmin4.v[k];
        const float tf0 = tfx < tfy ? tfx : tfy, tf1 = tfz < tlim[k] ? tfz : tlim[k];
        const float tn = tn0 > tn1 ? tn0 : tn1, tf = tf0 < tf1 ? tf0 : tf1;
        dd[k] = tn;
        h[k] = -(tn <= tf);
        hc[k] = (uint32_t)h[k] & n->child[k];
    }
    for (k = 0; k < 4; k++) d[k] = dd[k];
    *one = (hc[0] | hc[1]) | (hc[2] | hc[3]);
    return (h[0] & 1) | (h[1] & 2) | (h[2] & 4) | (h[3] & 8);
}

/* Core traversal. any = 1 stops at the first hit (occlusion). Returns
   4 block + lane of the closest hit or -1, with its float t. At each
   node the four child boxes are tested at once; of the children hit
   (inner nodes and leaves alike) the nearest is visited next and the
   others pushed, farthest first. One hit, the common case, just descends;
   two need one comparison; three or four are sorted on the stack. The
   stack holds references and entry distances in two arrays; popped
   entries beyond the closest hit so far are skipped. */
static long pds__bvh_traverse(const pds__bvh *bvh, const pds__bvh_ray *r, int any, float *t_out)
{
    /* lowest set bit of a 4-bit mask */
    static const signed char first_bit[16] = {0, 0, 1, 0, 2, 0, 1, 0, 3, 0, 1, 0, 2, 0, 1, 0};
    uint32_t st_ref[PDS__BVH_STACK];
    float st_t[PDS__BVH_STACK];
    int sp = 0;
    const pds__bvh_node *nodes = bvh->nodes;
    uint32_t ref = 0;
    float tcur = r->tmax, tcull = pds__bvh_cull(r->tmax), tl4[4];
    long best = -1;

    tl4[0] = tl4[1] = tl4[2] = tl4[3] = tcull;
    for (;;) {
        while (!(ref & PDS__BVH_LEAF)) {
            const pds__bvh_node *n = nodes + ref;
            float d[4];
            uint32_t one;
            int m = pds__bvh_box4(r, n, tl4, d, &one), k0, k1;
            if (m == 0) goto pop;
            if ((m & (m - 1)) == 0) {
                ref = one;
                continue;
            }
            k0 = first_bit[m];
            m &= m - 1;
            k1 = first_bit[m];
            m &= m - 1;
            if (m == 0) {
                /* two: visit the nearer, push the farther; the swap is
                   done with a mask (x = c0 ^ c1 when the second child
                   is nearer) because compilers turn a conditional here
                   into a branch, which would mispredict */
                const float d0 = d[k0], d1 = d[k1];
                const uint32_t c0 = n->child[k0], c1 = n->child[k1];
                const uint32_t x = (c0 ^ c1) & (0u - (uint32_t)(d1 < d0));
                st_ref[sp] = c1 ^ x;
                st_t[sp] = d1 < d0 ? d0 : d1;
                sp++;
                ref = c0 ^ x;
                continue;
            }
            {
                /* three or four: push all, insertion-sort the pushed run
                   far to near, and take the nearest off the top */
                int base = sp, j, k;
                st_ref[sp] = n->child[k0];
                st_t[sp++] = d[k0];
                st_ref[sp] = n->child[k1];
                st_t[sp++] = d[k1];
                while (m) {
                    k = first_bit[m];
                    m &= m - 1;
                    st_ref[sp] = n->child[k];
                    st_t[sp++] = d[k];
                }
                for (k = base + 1; k < sp; k++) {
                    uint32_t xr = st_ref[k];
                    float xt = st_t[k];
                    for (j = k; j > base && st_t[j - 1] < xt; j--) {
                        st_ref[j] = st_ref[j - 1];
                        st_t[j] = st_t[j - 1];
                    }
                    st_ref[j] = xr;
                    st_t[j] = xt;
                }
                ref = st_ref[--sp];
            }
        }
        {
            /* a leaf: its block of four triangles */
            uint32_t b = ref & ~PDS__BVH_LEAF;
            float t;
            int lane = pds__bvh_tri4_test(r, bvh->tri4 + b, r->tmin, tcur, &t);
            if (lane >= 0) {
                tcur = t;
                tcull = pds__bvh_cull(t);
                tl4[0] = tl4[1] = tl4[2] = tl4[3] = tcull;
                best = 4 * (long)b + lane;
                if (any) goto done;
            }
        }
    pop:
        /* the nearest pending entry that can still hold a closer hit */
        for (;;) {
            if (sp == 0) goto done;
            sp--;
            if (st_t[sp] <= tcull) break;
        }
        ref = st_ref[sp];
    }
done:
    *t_out = tcur;
    return best;
}

/* Completes a hit on lane l of block q whose float t, scaled to the
   caller's units, is in hit->t: t, u, v in double with Moller-Trumbore on
   the caller's double ray. Keeps the float t if the double one leaves
   (tmin, tmax) (rounding at an end of the interval); a ray lying in the
   triangle's plane in double, which the float test may still have seen
   hitting, gets the centroid. */
static void pds__bvh_refine(const pds__bvh_tri4 *q, int l, pds__v3 org, pds__v3 dir, double tmin,
                            double tmax, pds__tri_hit *hit)
{
    pds__v3 p0 = pds__v(q->v[0][0][l], q->v[0][1][l], q->v[0][2][l]);
    pds__v3 e1 = pds__sub(pds__v(q->v[1][0][l], q->v[1][1][l], q->v[1][2][l]), p0);
    pds__v3 e2 = pds__sub(pds__v(q->v[2][0][l], q->v[2][1][l], q->v[2][2][l]), p0);
    pds__v3 p = pds__cross(dir, e2), s, qv;
    double det = pds__dot(e1, p), inv, u, w, t;
    if (det == 0.0) {
        hit->u = hit->v = 1.0 / 3.0;
        return;
    }
    inv = 1.0 / det;
    s = pds__sub(org, p0);
    qv = pds__cross(s, e1);
    u = pds__dot(s, p) * inv;
    w = pds__dot(dir, qv) * inv;
    t = pds__dot(e2, qv) * inv;
    /* the float test decided the hit; clamp rounding just outside an edge */
    if (u < 0.0) u = 0.0;
    if (w < 0.0) w = 0.0;
    if (u + w > 1.0) {
        double sum = u + w;
        u /= sum;
        w /= sum;
    }
    if (t > tmin && t < tmax) hit->t = t;
    hit->u = u;
    hit->v = w;
}

/* Closest hit with tmin < t < tmax (t in units of |dir|). Returns 1 and
   fills *hit, or 0. Thread-safe; does not modify the bvh. */
static int pds__bvh_intersect(const pds__bvh *bvh, pds__v3 org, pds__v3 dir, double tmin,
                              double tmax, pds__tri_hit *hit)
{
    pds__bvh_ray r;
    float t;
    double tscale;
    long i;
    if (bvh->ntris == 0 || !pds__bvh_ray_setup(&r, org, dir, tmin, tmax, &tscale)) return 0;
    i = pds__bvh_traverse(bvh, &r, 0, &t);
    if (i < 0) return 0;
    hit->t = t * tscale;
    hit->tri = bvh->tri_id[i];
    pds__bvh_refine(bvh->tri4 + i / 4, (int)(i % 4), org, dir, tmin, tmax, hit);
    return 1;
}

/* 1 if any triangle is hit with tmin < t < tmax. */
static int pds__bvh_occluded(const pds__bvh *bvh, pds__v3 org, pds__v3 dir, double tmin, double tmax)
{
    pds__bvh_ray r;
    float t;
    double tscale;
    if (bvh->ntris == 0 || !pds__bvh_ray_setup(&r, org, dir, tmin, tmax, &tscale)) return 0;
    return pds__bvh_traverse(bvh, &r, 1, &t) >= 0;
}

/* ===================================================================== */
/* >>materials                                                           */
/* ===================================================================== */
/* Scattering at a surface: Fresnel equations, BSDF sampling and evaluation,
   Beer-Lambert absorption and dispersion. Both the path tracer (eye paths,
   carrying radiance) and the photon tracer (light paths, carrying flux)
   call the same functions; pds__transport says which one is asking.

   Conventions (every function below relies on them):
   - wo is the unit direction from the surface point back toward the
     previous path vertex (minus the incoming ray direction); wi is the new
     direction, also pointing away from the surface.
   - ng is the geometric normal as stored. Its side is the FRONT: a
     dielectric's outside_ior/outside_absorption medium is in front, its
     ior/absorption medium behind. Which side a ray is on, and so whether
     it enters or leaves a dielectric, is decided by ng only, never by the
     interpolated shading normal ns, which may tilt past the surface.
   - Scattering uses ns turned onto wo's side of ng ("the frame normal",
     pds__bsdf_frame). When wo lies below that shading hemisphere (a
     grazing view of a strongly interpolated mesh) the geometric normal is
     used instead, so reflection and refraction formulas always see an
     incident direction on the correct side.
   - A sampled direction that ends up on the wrong side of ng (reflection
     below the surface, refraction back out) is dropped: it counts as
     absorption. That loses a little energy on smooth-shaded meshes but
     never leaks light through a surface.

   Formulas (Born and Wolf's Fresnel equations as Pharr, Jakob and Humphreys,
   "Physically Based Rendering", 3rd ed., sect. 8.2, write them):
   - Dielectric Fresnel, exact and unpolarised, from Snell's law:
     r_par = (nt ci - ni ct)/(nt ci + ni ct), r_perp = (ni ci - nt ct)/(ni ci
     + nt ct), R = (r_par^2 + r_perp^2)/2; sin t >= 1 is total internal
     reflection, R = 1.
   - Conductor Fresnel for the complex relative index eta + i k, in the
     closed form with a^2 + b^2 = |n^2 - sin^2| (Lagarde's write-up).
   - Refraction: T = eta D - mu N, mu = eta (D.N) - (T.N),
     T.N = -sqrt(1 - eta^2 (1 - (D.N)^2)), eta = n_incident/n_transmitted.
   - Radiance is not conserved across a refraction: L/n^2 is (etendue).
     An eye path carrying radiance from wi toward wo therefore picks up
     (n_wo_side / n_wi_side)^2 at a refraction; photon flux does not.
   - Diffuse: Lambertian f = albedo/pi, importance sampled with the cosine
     (Malley's method), so the sample weight f cos / pdf is the albedo.
   - Glossy: a rough conductor, the microfacet BRDF of Walter, Marschner,
     Li, Torrance ("Microfacet models for refraction through rough
     surfaces", EGSR 2007, eq. 20) with the GGX (Trowbridge-Reitz)
     distribution (their eq. 33) and Smith's height-correlated
     masking-shadowing (Heitz, "Understanding the masking-shadowing
     function in microfacet-based BRDFs", JCGT 3(2) 2014, eq. 99); see
     pds__ggx_* below. Sampled by the distribution of visible normals
     (Heitz, "Sampling the GGX distribution of visible normals", JCGT 7(4)
     2018). Glossy is non-specular: it ends an eye path's specular chain
     and a caustic photon lands on it, like a diffuse surface.
   - Beer-Lambert: transmittance exp(-sigma d) along a segment of length d.
   - Dispersion: Cauchy n = A + B/lambda^2 or Sellmeier n^2 = 1 + sum B_i
     lambda^2/(lambda^2 - C_i), lambda in micrometres. The sampling code
     reads m->ior; a spectral renderer passes a copy of the material whose
     ior is pds__ior_at(m, lambda). */

typedef enum pds__transport {
    PDS__RADIANCE = 0,  /* eye paths: refraction scales by (n_wo/n_wi)^2 */
    PDS__IMPORTANCE = 1 /* photon paths: no such factor, only the Fresnel T */
} pds__transport;

/* Exact unpolarised Fresnel reflectance of a dielectric interface.
   cos_i in [0,1] is the cosine of the angle of incidence on the incident
   side, eta_i the index of the incident medium, eta_t of the other one.
   Returns 1 on total internal reflection and at exactly grazing incidence. */
static double pds__fresnel_dielectric(double cos_i, double eta_i, double eta_t)
{
    double sin_i, sin_t, cos_t, r_par, r_perp, den_par, den_perp;
    if (!(eta_i > 0.0) || !(eta_t > 0.0)) return 1.0;
    if (!(cos_i > 0.0)) return 1.0;
    if (cos_i > 1.0) cos_i = 1.0;
    sin_i = sqrt(fmax(0.0, 1.0 - cos_i * cos_i));
    sin_t = eta_i / eta_t * sin_i;
    if (sin_t >= 1.0) return 1.0;
    cos_t = sqrt(fmax(0.0, 1.0 - sin_t * sin_t));
    den_par = eta_t * cos_i + eta_i * cos_t;
    den_perp = eta_i * cos_i + eta_t * cos_t;
    r_par = (eta_t * cos_i - eta_i * cos_t) / den_par;
    r_perp = (eta_i * cos_i - eta_t * cos_t) / den_perp;
    return 0.5 * (r_par * r_par + r_perp * r_perp);
}

/* Exact unpolarised Fresnel reflectance of a conductor with complex
   relative index eta + i k (metal index over the outside index), for
   cos_i in [0,1]. With t0 = eta^2 - k^2 - s^2 (s = sin i), the complex
   square root sqrt(n^2 - s^2) = a + i b has a^2 + b^2 = sqrt(t0^2 +
   4 eta^2 k^2) and a = sqrt((a^2 + b^2 + t0)/2); then
   Rs = (a^2+b^2 + c^2 - 2ac)/(a^2+b^2 + c^2 + 2ac) and
   Rp = Rs (c^2(a^2+b^2) + s^4 - 2ac s^2)/(c^2(a^2+b^2) + s^4 + 2ac s^2). */
static double pds__fresnel_conductor(double cos_i, double eta, double k)
{
    double c, c2, s2, t0, ab2, a, t1, t2, t3, t4, rs, rp;
    c = cos_i;
    if (!(c > 0.0)) c = 0.0;
    if (c > 1.0) c = 1.0;
    c2 = c * c;
    s2 = 1.0 - c2;
    t0 = eta * eta - k * k - s2;
    ab2 = sqrt(t0 * t0 + 4.0 * eta * eta * k * k);
    a = sqrt(fmax(0.0, 0.5 * (ab2 + t0)));
    t1 = ab2 + c2;
    t2 = 2.0 * a * c;
    if (!(t1 + t2 > 0.0)) return 1.0; /* eta = 1, k = 0 at grazing: 0/0 */
    rs = (t1 - t2) / (t1 + t2);
    t3 = c2 * ab2 + s2 * s2;
    t4 = t2 * s2;
    rp = (t3 + t4 > 0.0) ? rs * (t3 - t4) / (t3 + t4) : rs;
    return 0.5 * (rs + rp);
}

/* --- GGX microfacets ------------------------------------------------------
   In the local frame of the shading normal n (cos t = w.n), isotropic
   roughness alpha:
     D(h)    = alpha^2 / (pi ((h.n)^2 (alpha^2 - 1) + 1)^2)      (Walter 2007, eq. 33)
     Lambda(w) = (sqrt(1 + alpha^2 tan^2 t) - 1) / 2             (Heitz 2014, eq. 72)
     G1(w)   = 1 / (1 + Lambda(w))
     G2(o,i) = 1 / (1 + Lambda(o) + Lambda(i))                  (Heitz 2014, eq. 99)
     f(o,i)  = F(o.h) D(h) G2(o,i) / (4 cos_o cos_i),  h = (o + i)/|o + i|
   f is symmetric in o and i (reciprocal). Visible-normal sampling draws h
   with density D_o(h) = G1(o) max(0, o.h) D(h) / cos_o (Heitz 2014,
   eq. 38, which integrates to 1 over h: the "weak white furnace"), and
   i = reflect(-o, h); the Jacobian 1/(4 o.h) of the reflection gives
     pdf(i) = G1(o) D(h) / (4 cos_o),   weight f cos_i / pdf = F G2 / G1(o).
   With F = 1 the directional albedo is E[G2/G1] <= 1: what it lacks is the
   light that single scattering loses (it would scatter again between the
   microfacets). At normal incidence the facets steeper than 45 degrees,
   alpha^2 / (1 + alpha^2) of them, reflect below the horizon: the albedo
   there is 0.998 at alpha 0.05, 0.88 at 0.3, 0.59 at 0.6, 0.31 at 1. */

static double pds__ggx_d(double cos_h, double alpha)
{
    double a2 = alpha * alpha, t;
    if (!(cos_h > 0.0)) return 0.0;
    t = cos_h * cos_h * (a2 - 1.0) + 1.0;
    return a2 / (PDS__PI * t * t);
}

static double pds__ggx_lambda(double cos_t, double alpha)
{
    double c2 = cos_t * cos_t, tan2;
    if (!(c2 > 0.0)) return DBL_MAX;
    tan2 = fmax(0.0, 1.0 - c2) / c2;
    return 0.5 * (sqrt(1.0 + alpha * alpha * tan2) - 1.0);
}

static double pds__ggx_g1(double cos_t, double alpha)
{
    return 1.0 / (1.0 + pds__ggx_lambda(cos_t, alpha));
}

static double pds__ggx_g2(double cos_o, double cos_i, double alpha)
{
    return 1.0 / (1.0 + pds__ggx_lambda(cos_o, alpha) + pds__ggx_lambda(cos_i, alpha));
}

/* A visible normal for the local direction o (o.z > 0), from two uniforms
   (Heitz 2018, listing 1): stretch o to the hemisphere configuration,
   sample a point on the projected disc with the half of it that o's
   horizon hides folded over, lift it to the hemisphere and unstretch. */
static pds__v3 pds__ggx_sample_vndf(pds__v3 o, double alpha, double u1, double u2)
{
    pds__v3 vh = pds__normalize(pds__v(alpha * o.x, alpha * o.y, o.z)), t1, t2, nh;
    double len2 = vh.x * vh.x + vh.y * vh.y, r = sqrt(u1), phi = 2.0 * PDS__PI * u2, p1, p2, s;
    t1 = len2 > 0.0 ? pds__scale(pds__v(-vh.y, vh.x, 0.0), 1.0 / sqrt(len2)) : pds__v(1.0, 0.0, 0.0);
    t2 = pds__cross(vh, t1);
    p1 = r * cos(phi);
    p2 = r * sin(phi);
    s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * sqrt(fmax(0.0, 1.0 - p1 * p1)) + s * p2;
    nh = pds__add(pds__add(pds__scale(t1, p1), pds__scale(t2, p2)),
                  pds__scale(vh, sqrt(fmax(0.0, 1.0 - p1 * p1 - p2 * p2))));
    return pds__normalize(pds__v(alpha * nh.x, alpha * nh.y, fmax(0.0, nh.z)));
}

/* Fresnel factor of a glossy material at cos(o.h): its reflectance, times
   the conductor Fresnel of eta + i k if it has one. */
static void pds__glossy_fresnel(const pds_material *m, double cos_oh, double F[3])
{
    int c;
    for (c = 0; c < 3; c++)
        F[c] = m->reflectance[c] * (m->fresnel ? pds__fresnel_conductor(cos_oh, m->eta[c], m->k[c]) : 1.0);
}

/* The glossy BRDF f(wo, wi) and the sampler's pdf of wi, in the frame of
   the unit normal n; 0 unless both directions are above n. */
static void pds__glossy_eval(const pds_material *m, pds__v3 wo, pds__v3 wi, pds__v3 n, double f[3], double *pdf)
{
    double cos_o = pds__dot(wo, n), cos_i = pds__dot(wi, n), cos_h, cos_oh, d, F[3];
    pds__v3 h;
    int c;
    f[0] = f[1] = f[2] = 0.0;
    *pdf = 0.0;
    if (!(cos_o > 0.0) || !(cos_i > 0.0)) return;
    h = pds__normalize(pds__add(wo, wi));
    cos_h = pds__dot(h, n);
    cos_oh = pds__dot(wo, h);
    d = pds__ggx_d(cos_h, m->roughness);
    if (!(d > 0.0) || !(cos_oh > 0.0)) return;
    pds__glossy_fresnel(m, cos_oh, F);
    for (c = 0; c < 3; c++) f[c] = F[c] * d * pds__ggx_g2(cos_o, cos_i, m->roughness) / (4.0 * cos_o * cos_i);
    *pdf = pds__ggx_g1(cos_o, m->roughness) * d / (4.0 * cos_o);
}

/* Mirror, conductor and dielectric scatter only into delta directions. */
static int pds__material_is_specular(const pds_material *m)
{
    return m->type == PDS_MAT_MIRROR || m->type == PDS_MAT_CONDUCTOR ||
           m->type == PDS_MAT_DIELECTRIC;
}

/* Mirror direction of d about the unit normal n (either orientation). */
static pds__v3 pds__reflect(pds__v3 d, pds__v3 n)
{
    return pds__sub(d, pds__scale(n, 2.0 * pds__dot(d, n)));
}

/* Refract the unit incident direction d (travelling toward the surface)
   through the unit normal n facing against it (d.n < 0); eta =
   n_incident / n_transmitted. Returns 0 on total internal reflection,
   else 1 with *t the unit transmitted direction T = eta d - mu n,
   mu = eta (d.n) - (T.n), T.n = -sqrt(1 - eta^2 (1 - (d.n)^2)). */
static int pds__refract(pds__v3 d, pds__v3 n, double eta, pds__v3 *t)
{
    double dn = pds__dot(d, n);
    double rad = 1.0 - eta * eta * (1.0 - dn * dn);
    double tn, mu;
    if (!(rad >= 0.0)) return 0;
    tn = -sqrt(rad);
    mu = eta * dn - tn;
    *t = pds__sub(pds__scale(d, eta), pds__scale(n, mu));
    return 1;
}

/* Result of pds__bsdf_sample. (The struct tag matches the function name;
   the typedef cannot, since C puts typedefs and functions in one name
   space.) */
typedef struct pds__bsdf_sample {
    pds__v3 wi;        /* unit sampled direction, away from the surface */
    double weight[3];  /* throughput multiplier: f |cos| / pdf (diffuse);
                          reflectance, Fresnel, or the radiance eta^2 factor
                          (specular; the dielectric Fresnel choice cancels) */
    double pdf;        /* solid-angle pdf (diffuse); probability of the
                          chosen event (specular: 1, or F / 1-F) */
    int delta;         /* 1 for specular events */
    int transmitted;   /* 1 if wi is across the geometric normal from wo */
    int side;          /* +1: wi in front of ng (dot(wi,ng) > 0), -1 behind */
} pds__bsdf_result;

/* The frame a scattering event at this point uses, seen from wo.
   Outputs: *n, the unit shading normal turned onto wo's side of ng (or the
   geometric normal on wo's side when wo is not above the shading
   hemisphere, or when ns is missing or tangent); *ngw, the unit geometric
   normal on wo's side; *side, +1 if wo is in front of ng, -1 behind.
   Returns 0 (and leaves the outputs undefined) when wo is tangent to the
   surface or a vector is NaN: no scattering is possible then.
   Callers that evaluate the diffuse BSDF for light sampling should take
   the cosine factor as dot(wi, n) with this n, which is what the sampler
   divides by. */
static int pds__bsdf_frame(pds__v3 wo, pds__v3 ns, pds__v3 ng, pds__v3 *n, pds__v3 *ngw,
                           int *side)
{
    double cg, cs;
    pds__v3 g = pds__normalize(ng), s = pds__normalize(ns);
    cg = pds__dot(wo, g);
    if (cg > 0.0) {
        *side = 1;
    } else if (cg < 0.0) {
        *side = -1;
        g = pds__scale(g, -1.0);
    } else {
        return 0; /* tangent, or NaN */
    }
    *ngw = g;
    /* Orient ns with the (already flipped) geometric normal: this also
       repairs a stored shading normal that points against ng. */
    cs = pds__dot(s, g);
    if (cs < 0.0) s = pds__scale(s, -1.0);
    if (cs != 0.0 && pds__dot(wo, s) > 0.0) *n = s;
    else *n = g;
    return 1;
}

/* The albedo of a diffuse material at the point x of a surface with
   normal ng. Tiled materials (tile_size > 0) draw grout lines of width
   tile_grout (albedo grout_albedo) every tile_size along the two world
   axes that lie most nearly in the surface: a floor is tiled in x and z, a
   wall facing z in x and y. */
static void pds__albedo_at(const pds_material *m, pds__v3 x, pds__v3 ng, double albedo[3])
{
    int c, grout = 0;
    if (m->tile_size > 0.0) {
        double a[3], n[3];
        int skip = 0, i;
        a[0] = x.x, a[1] = x.y, a[2] = x.z;
        n[0] = fabs(ng.x), n[1] = fabs(ng.y), n[2] = fabs(ng.z);
        if (n[1] > n[skip]) skip = 1;
        if (n[2] > n[skip]) skip = 2;
        for (i = 0; i < 3; i++) {
            double f;
            if (i == skip) continue;
            f = a[i] / m->tile_size - floor(a[i] / m->tile_size); /* in [0, 1) */
            if (fmin(f, 1.0 - f) * m->tile_size < 0.5 * m->tile_grout) grout = 1;
        }
    }
    for (c = 0; c < 3; c++) albedo[c] = grout ? m->grout_albedo[c] : m->albedo[c];
}

/* Sample the BSDF of material m for the outgoing direction wo.
   Inputs: wo (unit, toward the previous vertex), ns (shading normal) and
   ng (geometric normal as stored, defines the front), u = three uniforms
   in [0,1) (u[0]: event choice / first diffuse or glossy coordinate,
   u[1]: the second one, u[2]: unused, reserved), mode (eye or photon path).
   Output *out (see pds__bsdf_result). Returns 0 when nothing scatters:
   emitters absorb, zero albedo/reflectance, wo tangent, or the sample
   fell on the wrong side of ng (absorbed). */
static int pds__bsdf_sample(const pds_material *m, pds__v3 x, pds__v3 wo, pds__v3 ns, pds__v3 ng,
                            const double u[3], pds__transport mode, pds__bsdf_result *out)
{
    pds__v3 n, g, wi;
    int side, c;
    double cos_o;
    if (!pds__bsdf_frame(wo, ns, ng, &n, &g, &side)) return 0;
    cos_o = pds__dot(wo, n);
    out->delta = 1;
    out->transmitted = 0;
    out->side = side;
    out->pdf = 1.0;

    switch (m->type) {
    case PDS_MAT_DIFFUSE: {
        /* Malley: uniform on the unit disk, lifted to the hemisphere;
           cos = sqrt(1 - u0) and cos^2 is uniform. */
        double r = sqrt(u[0]), phi = 2.0 * PDS__PI * u[1];
        double z = sqrt(fmax(0.0, 1.0 - u[0]));
        pds__v3 b1, b2;
        double albedo[3];
        pds__albedo_at(m, x, ng, albedo);
        if (!(albedo[0] > 0.0 || albedo[1] > 0.0 || albedo[2] > 0.0)) return 0;
        pds__onb(n, &b1, &b2);
        wi = pds__add(pds__add(pds__scale(b1, r * cos(phi)), pds__scale(b2, r * sin(phi))),
                      pds__scale(n, z));
        wi = pds__normalize(wi);
        z = pds__dot(wi, n);
        if (!(z > 0.0) || !(pds__dot(wi, g) > 0.0)) return 0;
        out->wi = wi;
        out->pdf = z / PDS__PI;
        out->delta = 0;
        for (c = 0; c < 3; c++) out->weight[c] = albedo[c];
        return 1;
    }
    case PDS_MAT_MIRROR:
    case PDS_MAT_CONDUCTOR:
        wi = pds__reflect(pds__scale(wo, -1.0), n);
        if (!(pds__dot(wi, g) > 0.0)) return 0;
        for (c = 0; c < 3; c++) {
            out->weight[c] = m->type == PDS_MAT_MIRROR
                                 ? m->reflectance[c]
                                 : pds__fresnel_conductor(cos_o, m->eta[c], m->k[c]);
        }
        if (!(out->weight[0] > 0.0 || out->weight[1] > 0.0 || out->weight[2] > 0.0)) return 0;
        out->wi = wi;
        return 1;
    case PDS_MAT_DIELECTRIC: {
        /* Front: coming from the outside medium into the ior medium. */
        double eta_i = side > 0 ? m->outside_ior : m->ior;
        double eta_t = side > 0 ? m->ior : m->outside_ior;
        double f = pds__fresnel_dielectric(cos_o, eta_i, eta_t);
        if (u[0] < f) {
            wi = pds__reflect(pds__scale(wo, -1.0), n);
            if (!(pds__dot(wi, g) > 0.0)) return 0;
            out->wi = wi;
            out->pdf = f;
            for (c = 0; c < 3; c++) out->weight[c] = 1.0;
            return 1;
        }
        if (!pds__refract(pds__scale(wo, -1.0), n, eta_i / eta_t, &wi)) return 0;
        if (!(pds__dot(wi, g) < 0.0)) return 0;
        out->wi = wi;
        out->pdf = 1.0 - f;
        out->transmitted = 1;
        out->side = -side;
        for (c = 0; c < 3; c++)
            out->weight[c] = mode == PDS__RADIANCE ? (eta_i * eta_i) / (eta_t * eta_t) : 1.0;
        return 1;
    }
    case PDS_MAT_GLOSSY: {
        /* visible-normal sampling in the frame (b1, b2, n) */
        pds__v3 b1, b2, ol, h;
        double cos_i, cos_oh, F[3], shadowing;
        pds__onb(n, &b1, &b2);
        ol = pds__v(pds__dot(wo, b1), pds__dot(wo, b2), cos_o);
        h = pds__ggx_sample_vndf(ol, m->roughness, u[0], u[1]);
        h = pds__normalize(pds__add(pds__add(pds__scale(b1, h.x), pds__scale(b2, h.y)), pds__scale(n, h.z)));
        cos_oh = pds__dot(wo, h);
        if (!(cos_oh > 0.0)) return 0;
        wi = pds__reflect(pds__scale(wo, -1.0), h);
        cos_i = pds__dot(wi, n);
        if (!(cos_i > 0.0) || !(pds__dot(wi, g) > 0.0)) return 0;
        pds__glossy_fresnel(m, cos_oh, F);
        shadowing = pds__ggx_g2(cos_o, cos_i, m->roughness) / pds__ggx_g1(cos_o, m->roughness);
        for (c = 0; c < 3; c++) out->weight[c] = F[c] * shadowing;
        if (!(out->weight[0] > 0.0 || out->weight[1] > 0.0 || out->weight[2] > 0.0)) return 0;
        out->wi = wi;
        out->pdf = pds__ggx_g1(cos_o, m->roughness) * pds__ggx_d(pds__dot(h, n), m->roughness) / (4.0 * cos_o);
        out->delta = 0;
        return 1;
    }
    case PDS_MAT_EMISSIVE:
    default:
        return 0;
    }
}

/* The non-delta part of the BSDF (no cosine factor): for a diffuse
   material f = albedo/pi when wo and wi are both on the same side of ng
   and wi is above the frame normal of pds__bsdf_frame (the hemisphere the
   sampler draws from), with *pdf = dot(wi, n)/pi, the density
   pds__bsdf_sample would have drawn wi with; for a glossy one the GGX
   BRDF and its visible-normal pdf under the same conditions. Anything
   else: f = 0, *pdf = 0. f is symmetric in wo and wi whenever both lie
   above the shading normal (the usual case; shading normals cannot be
   reciprocal everywhere). */
static void pds__bsdf_eval(const pds_material *m, pds__v3 x, pds__v3 wo, pds__v3 wi, pds__v3 ns, pds__v3 ng,
                           double f[3], double *pdf)
{
    pds__v3 n, g;
    int side, c;
    double cos_i, albedo[3];
    f[0] = f[1] = f[2] = 0.0;
    *pdf = 0.0;
    if (m->type != PDS_MAT_DIFFUSE && m->type != PDS_MAT_GLOSSY) return;
    if (!pds__bsdf_frame(wo, ns, ng, &n, &g, &side)) return;
    cos_i = pds__dot(wi, n);
    if (!(cos_i > 0.0) || !(pds__dot(wi, g) > 0.0)) return;
    if (m->type == PDS_MAT_GLOSSY) {
        pds__glossy_eval(m, wo, wi, n, f, pdf);
        return;
    }
    pds__albedo_at(m, x, ng, albedo);
    for (c = 0; c < 3; c++) f[c] = albedo[c] / PDS__PI;
    *pdf = cos_i / PDS__PI;
}

/* Beer-Lambert coefficients (per scene unit, RGB) of the medium on `side`
   of a dielectric: +1 the front (outside) medium, -1 the one behind.
   NULL for other materials and for media that do not absorb, so callers
   can skip the exponentials. */
static const double *pds__medium_absorption(const pds_material *m, int side)
{
    const double *s;
    if (m->type != PDS_MAT_DIELECTRIC) return NULL;
    s = side > 0 ? m->outside_absorption : m->absorption;
    if (s[0] > 0.0 || s[1] > 0.0 || s[2] > 0.0) return s;
    return NULL;
}

/* Attenuate w by the transmittance exp(-sigma dist) of a segment of
   length dist (scene units) in a medium with coefficients sigma (may be
   NULL: clear medium). */
static void pds__beer(const double *sigma, double dist, double w[3])
{
    int c;
    if (!sigma) return;
    for (c = 0; c < 3; c++)
        if (sigma[c] != 0.0) w[c] *= exp(-sigma[c] * dist);
}

/* Index of refraction of the medium behind a dielectric at the given
   wavelength (nm): Cauchy or Sellmeier with lambda in micrometres when
   the material has dispersion, else m->ior. A formula that gives no real
   index (at a Sellmeier pole) falls back to m->ior. */
/* n(lambda) of the material's dispersion law as it stands (NaN where a
   Sellmeier law gives n^2 < 0; huge near its poles); the parser refuses
   laws that leave [1, 10] in the visible range. */
static double pds__dispersion_law(const pds_material *m, double wavelength_nm)
{
    double l = wavelength_nm * 1e-3, l2 = l * l;
    const double *c = m->dispersion_coef;
    if (m->dispersion == PDS_DISPERSION_CAUCHY) return c[0] + c[1] / l2;
    if (m->dispersion == PDS_DISPERSION_SELLMEIER) {
        double n2 = 1.0 + c[0] * l2 / (l2 - c[3]) + c[1] * l2 / (l2 - c[4]) + c[2] * l2 / (l2 - c[5]);
        return n2 >= 0.0 ? sqrt(n2) : NAN;
    }
    return m->ior;
}

static double pds__ior_at(const pds_material *m, double wavelength_nm)
{
    double n = pds__dispersion_law(m, wavelength_nm);
    if (!(n > 0.0) || !(n < 1e6)) return m->ior;
    return n;
}

#ifndef PDS_NO_SPECTRAL
/* ===================================================================== */
/* >>spectral                                                            */
/* ===================================================================== */
/* Spectral light transport: light of one wavelength per path, so that
   refraction and Fresnel can use the index n(lambda) of a dispersive
   material (>>materials, pds__dispersion_law), and a white beam through a
   prism fans out into a rainbow.

   When. A render is spectral when the scene has a dielectric with a
   Cauchy or Sellmeier law, or when pds_options.spectral asks for it
   (pds__render_is_spectral); otherwise none of this runs and images are
   those of the RGB renderer bit for bit. Tested in
   tests/test_spectral.c.

   Wavelengths. Every camera sample and every photon carries one
   wavelength lambda, uniform on [380, 780] nm (pdf 1/400 per nm), drawn
   stratified: a pixel's samples take a rotated golden-ratio sequence
   (lambda_k = frac(u_pixel + k 0.618...)), photons the seventh Halton
   dimension next to the six of their emission (>>rng), so a pixel's or a
   caustic's wavelengths cover the range evenly. (Hero wavelengths, Wilkie
   et al. 2014, carry four per path and cut colour noise further, but a
   dispersive refraction must drop all but one of them; one per path keeps
   every integrator's code a scalar chain.)

   Colours. Scene colours stay RGB; a path at lambda turns an RGB triple
   into a spectral value with Smits' method (B. Smits, "An RGB-to-spectrum
   conversion for reflectances", JGT 4(4), 1999): the smallest channel
   times a white spectrum, plus the middle minus the smallest times the
   spectrum of the two-channel mixture (cyan, magenta or yellow), plus the
   largest minus the middle times the one-channel spectrum (red, green or
   blue). The seven spectra are Smits' published 10-bin tables over
   380-720 nm (piecewise constant; above 720 nm the last bin). The map is
   linear on each of the six orderings of the channels and homogeneous,
   so a light's spectral power is its RGB power's uplift whatever the
   geometric factors are. Its limits: the spectra were fitted for
   reflectances, not illuminants, they are boxy, and the round trip RGB ->
   spectrum -> RGB is not the identity for saturated colours (measured in
   spectral_smits_uplift_round_trips_within_its_accuracy: primaries and
   secondaries come back within 0.013 per channel, grey exactly, since a
   grey triple maps to a flat spectrum here by construction: Smits' white
   table is 1 within 0.0008, and exactly 1 is used for it). Beer coefficients are uplifted as spectra of
   their own (sigma(lambda)), so transmittance stays exp(-sigma d).

   Film. The sensor integrates with the CIE 1931 2-degree colour matching
   functions, here the multi-lobe Gaussian fit of Wyman, Sloan and Shirley
   ("Simple analytic approximations to the CIE XYZ color matching
   functions", JCGT 2(2), 2013, their eq. 2):
       g(l; mu, a, b) = exp(-((l - mu) s)^2 / 2), s = a below mu, b above,
       xbar = 1.056 g(599.8; .0264, .0323) + 0.362 g(442.0; .0624, .0374)
              - 0.065 g(501.1; .0490, .0382)
       ybar = 0.821 g(568.8; .0213, .0247) + 0.286 g(530.9; .0613, .0322)
       zbar = 1.217 g(437.0; .0845, .0278) + 0.681 g(459.0; .0385, .0725)
   (within about 0.01 of the CIE table; tested at five wavelengths), then XYZ -> linear sRGB with the D65 matrix of IEC
   61966-2-1 (as Lindbloom prints it to seven digits). A flat spectrum
   (equal-energy white, which Smits' white is) would come out slightly
   pink in D65 sRGB; each channel is divided by its integral over
   [380, 780] nm, a diagonal white balance in linear sRGB, so that the
   flat spectrum is (1, 1, 1) exactly and a white reflector under a
   white light is as white as in the RGB renderer. A camera sample at
   lambda with spectral radiance L therefore adds
       W(lambda) L,   W_c(lambda) = 400 nm (M cmf(lambda))_c / N_c,
   whose mean over the uniform lambda is (1, 1, 1). W has negative parts
   (colours of the spectrum locus lie outside the sRGB gamut), so the
   photon images keep their negative terms in sums of their own.

   When a path turns spectral. A camera path or a photon carries RGB, as
   in the RGB renderer, until it first meets a dispersive material (with
   pds_options.spectral: from its first vertex); there its RGB throughput
   (a photon: its flux) is replaced by its spectral value at its lambda,
   which it keeps from then on. Light that never meets dispersion is thus
   computed as in RGB, with no colour noise; the choice of the vertex
   where the spectrum is taken is a sampling choice like any other (the
   expected value of W(lambda) S(lambda) is the colour of S). From there,
   materials are asked at lambda through pds__spectral_material (index
   n(lambda), Beer sigma(lambda)); the RGB weights the BSDF returns and the
   lights' RGB quantities are uplifted at lambda (pds__spectral_value), so
   the throughput is one number times W(lambda).

   Where photons meet eye vertices (pds__spectral_meet). If the specular
   chain from the camera to a vertex met no dispersive material, its
   geometry is the same at every wavelength: the vertex keeps the chain's
   RGB weight (as the RGB renderer does; exact for clear glass and white
   mirrors, an RGB filter for tinted ones) and every photon adds to it, a
   spectral photon at its own wavelength. Otherwise (a caustic seen
   through a prism or a gem) the vertex is where it is only at its own
   wavelength lambda_e: an RGB photon adds its spectrum's value at
   lambda_e; a spectral photon adds only if it is in the same one of
   PDS__SPECTRAL_BINS equal wavelength bins, weighted by the bin count, a
   box kernel in wavelength (consistent as bins narrow; it blurs the
   rainbow seen through glass by one bin, 25 nm).

   Photon differentials are traced at the photon's own wavelength:
   position and direction differentials with n(lambda) (Igehy's refraction
   with that index). No wavelength differential is added. A thin white
   beam through a prism spreads into a fan because its photons have
   different wavelengths: the fan is the union of many one-wavelength
   beams, each with its own narrow footprint, and sampling wavelengths
   over the photons fills it in, as sampling positions fills in a wide
   beam. A wavelength differential (d lambda of the photon's share of the
   spectrum) would stretch each footprint along the fan to smooth it with
   fewer photons, as the positional differential does over the emitter;
   that is a variance choice, not needed for a correct limit, and left
   out. */

#define PDS__LAMBDA_MIN 380.0   /* nm: the sampled range */
#define PDS__LAMBDA_MAX 780.0
#define PDS__SPECTRAL_BINS 16   /* wavelength bins for eye vertices seen
                                   through dispersive glass */

/* Smits 1999, table 1: spectra of white, cyan, magenta, yellow, red,
   green and blue in 10 bins of 34 nm from 380 to 720 nm. */
static const double pds__smits[7][10] = {
    {1.0000, 1.0000, 0.9999, 0.9993, 0.9992, 0.9998, 1.0000, 1.0000, 1.0000, 1.0000}, /* white */
    {0.9710, 0.9426, 1.0007, 1.0007, 1.0007, 1.0007, 0.1564, 0.0000, 0.0000, 0.0000}, /* cyan */
    {1.0000, 1.0000, 0.9685, 0.2229, 0.0000, 0.0458, 0.8369, 1.0000, 1.0000, 0.9959}, /* magenta */
    {0.0001, 0.0000, 0.1088, 0.6651, 1.0000, 1.0000, 0.9996, 0.9586, 0.9685, 0.9840}, /* yellow */
    {0.1012, 0.0515, 0.0000, 0.0000, 0.0000, 0.0000, 0.8325, 1.0149, 1.0149, 1.0149}, /* red */
    {0.0000, 0.0000, 0.0273, 0.7937, 1.0000, 0.9418, 0.1719, 0.0000, 0.0000, 0.0025}, /* green */
    {1.0000, 1.0000, 0.8916, 0.3323, 0.0000, 0.0000, 0.0003, 0.0369, 0.0483, 0.0496}  /* blue */
};
enum { PDS__SMITS_WHITE, PDS__SMITS_CYAN, PDS__SMITS_MAGENTA, PDS__SMITS_YELLOW,
       PDS__SMITS_RED, PDS__SMITS_GREEN, PDS__SMITS_BLUE };

/* The value at lambda (nm) of the spectrum Smits' method gives the RGB
   triple rgb (negative channels count as 0). A grey triple gives the flat
   spectrum exactly. */
static double pds__spectral_value(const double rgb[3], double lambda_nm)
{
    double r = rgb[0] > 0.0 ? rgb[0] : 0.0, g = rgb[1] > 0.0 ? rgb[1] : 0.0, b = rgb[2] > 0.0 ? rgb[2] : 0.0;
    double t = (lambda_nm - PDS__LAMBDA_MIN) / 34.0;
    int k = t > 0.0 ? (t < 9.0 ? (int)t : 9) : 0; /* also NaN -> 0 */
    const double(*S)[10] = pds__smits;
    if (r == g && g == b) return r;
    if (r <= g && r <= b) {
        if (g <= b) return r + (g - r) * S[PDS__SMITS_CYAN][k] + (b - g) * S[PDS__SMITS_BLUE][k];
        return r + (b - r) * S[PDS__SMITS_CYAN][k] + (g - b) * S[PDS__SMITS_GREEN][k];
    }
    if (g <= r && g <= b) {
        if (r <= b) return g + (r - g) * S[PDS__SMITS_MAGENTA][k] + (b - r) * S[PDS__SMITS_BLUE][k];
        return g + (b - g) * S[PDS__SMITS_MAGENTA][k] + (r - b) * S[PDS__SMITS_RED][k];
    }
    if (r <= g) return b + (r - b) * S[PDS__SMITS_YELLOW][k] + (g - r) * S[PDS__SMITS_GREEN][k];
    return b + (g - b) * S[PDS__SMITS_YELLOW][k] + (r - g) * S[PDS__SMITS_RED][k];
}

/* Replace an RGB weight by its spectral value at lambda in all three
   channels (lambda 0: RGB render, nothing to do). */
static void pds__spectral_uplift(double lambda_nm, double w[3])
{
    double v;
    if (!(lambda_nm > 0.0)) return;
    v = pds__spectral_value(w, lambda_nm);
    w[0] = w[1] = w[2] = v;
}

/* One lobe of the Wyman-Sloan-Shirley fit: piecewise Gaussian of inverse
   widths a (below mu) and b (above), in nm^-1. */
static double pds__cie_lobe(double l, double mu, double a, double b)
{
    double t = (l - mu) * (l < mu ? a : b);
    return exp(-0.5 * t * t);
}

/* CIE 1931 colour matching functions xbar, ybar, zbar at lambda (nm):
   Wyman, Sloan, Shirley 2013, eq. 2 (see the prologue). */
static void pds__cie_xyz(double l, double xyz[3])
{
    xyz[0] = 1.056 * pds__cie_lobe(l, 599.8, 0.0264, 0.0323) + 0.362 * pds__cie_lobe(l, 442.0, 0.0624, 0.0374) -
             0.065 * pds__cie_lobe(l, 501.1, 0.0490, 0.0382);
    xyz[1] = 0.821 * pds__cie_lobe(l, 568.8, 0.0213, 0.0247) + 0.286 * pds__cie_lobe(l, 530.9, 0.0613, 0.0322);
    xyz[2] = 1.217 * pds__cie_lobe(l, 437.0, 0.0845, 0.0278) + 0.681 * pds__cie_lobe(l, 459.0, 0.0385, 0.0725);
}

/* XYZ -> linear sRGB, D65 white (IEC 61966-2-1; Lindbloom's digits). */
static void pds__xyz_to_srgb(const double xyz[3], double rgb[3])
{
    rgb[0] = 3.2404542 * xyz[0] - 1.5371385 * xyz[1] - 0.4985314 * xyz[2];
    rgb[1] = -0.9692660 * xyz[0] + 1.8760108 * xyz[1] + 0.0415560 * xyz[2];
    rgb[2] = 0.0556434 * xyz[0] - 0.2040259 * xyz[1] + 1.0572252 * xyz[2];
}

/* Integrals over [380, 780] nm of the three channels of
   pds__xyz_to_srgb(pds__cie_xyz(lambda)), in nm (midpoint rule at
   0.001 nm; spectral_film_weights_average_to_white recomputes them). */
static const double pds__film_norm[3] = {128.167043732, 101.632215868, 97.036924154};

/* Film weight W(lambda) of the prologue: the linear sRGB a camera sample
   adds per unit of spectral radiance at lambda, when lambda is uniform on
   [380, 780] nm. Its mean over that range is (1, 1, 1). */
static void pds__film_weight(double lambda_nm, double w[3])
{
    double xyz[3];
    int c;
    pds__cie_xyz(lambda_nm, xyz);
    pds__xyz_to_srgb(xyz, w);
    for (c = 0; c < 3; c++) w[c] *= (PDS__LAMBDA_MAX - PDS__LAMBDA_MIN) / pds__film_norm[c];
}

/* Does the scene hold a dispersive material? */
static int pds__material_is_dispersive(const pds_material *m)
{
    return m->type == PDS_MAT_DIELECTRIC && m->dispersion != PDS_DISPERSION_NONE;
}

/* The material as a path at lambda sees it: the index behind a dielectric
   at lambda (its dispersion law), Beer coefficients uplifted to
   sigma(lambda) on both sides. Every other field (the RGB colours the
   BSDF returns, which the caller uplifts) is copied. */
static void pds__spectral_material(const pds_material *m, double lambda_nm, pds_material *out)
{
    *out = *m;
    if (m->type != PDS_MAT_DIELECTRIC) return;
    out->ior = pds__ior_at(m, lambda_nm);
    pds__spectral_uplift(lambda_nm, out->absorption);
    pds__spectral_uplift(lambda_nm, out->outside_absorption);
}

/* lambda of camera sample `sample` of a pixel: a golden-ratio sequence
   rotated by a per-pixel uniform. */
static double pds__eye_wavelength(uint64_t seed, uint64_t pixel, uint64_t sample)
{
    double u = pds__rng_uniform(seed, PDS__RNG_WAVELENGTH, pixel, 0) + 0.6180339887498949 * (double)sample;
    u -= floor(u);
    return PDS__LAMBDA_MIN + (PDS__LAMBDA_MAX - PDS__LAMBDA_MIN) * u;
}

/* lambda of photon number i: the seventh Halton dimension (the first six
   place and aim it). */
static double pds__photon_wavelength(uint64_t seed, long i)
{
    return PDS__LAMBDA_MIN + (PDS__LAMBDA_MAX - PDS__LAMBDA_MIN) * pds__halton(seed, (uint64_t)i, 6);
}

/* Weight of a photon of wavelength lambda_p at an eye vertex traced at
   lambda_e: 1 if the vertex does not depend on the wavelength (lambda_e
   = 0: its specular chain was not dispersive), else the box kernel of the
   prologue: the bin count if both are in the same bin, 0 if not. */
static double pds__wavelength_match(double lambda_e, double lambda_p)
{
    double w = (PDS__LAMBDA_MAX - PDS__LAMBDA_MIN) / PDS__SPECTRAL_BINS;
    if (!(lambda_e > 0.0)) return 1.0;
    return floor((lambda_e - PDS__LAMBDA_MIN) / w) == floor((lambda_p - PDS__LAMBDA_MIN) / w) ? PDS__SPECTRAL_BINS
                                                                                            : 0.0;
}

/* A photon meets an eye vertex (photon methods, spectral renders). The
   photon is spectral (lambda_p > 0: e, its flux or flux density, is its
   value at lambda_p times W(lambda_p)) or still RGB (lambda_p = 0); the
   vertex holds at one wavelength (lambda_e > 0, importance at lambda_e)
   or at all (lambda_e = 0, RGB importance). e and f (the vertex's BSDF
   value, RGB) become what the pair adds per channel, times the vertex's
   importance:
     spectral photon: f at lambda_p, times the wavelength match;
     RGB photon, vertex at lambda_e: e and f at lambda_e, times W(lambda_e);
     both RGB: unchanged (the RGB renderer's product).
   Returns 0 if the pair adds nothing. */
static int pds__spectral_meet(double lambda_p, double lambda_e, double e[3], double f[3])
{
    int c;
    if (lambda_p > 0.0) {
        double w = pds__wavelength_match(lambda_e, lambda_p);
        if (w == 0.0) return 0;
        pds__spectral_uplift(lambda_p, f);
        for (c = 0; c < 3; c++) f[c] *= w;
    } else if (lambda_e > 0.0) {
        double film[3], v = pds__spectral_value(e, lambda_e);
        pds__film_weight(lambda_e, film);
        for (c = 0; c < 3; c++) e[c] = v * film[c];
        pds__spectral_uplift(lambda_e, f);
    }
    return 1;
}
#else /* PDS_NO_SPECTRAL */
/* This build leaves spectral rendering out: pds__camera_check refuses a
   render that would be spectral (a dispersive material in the scene, or
   pds_options.spectral), so every path and photon is RGB (lambda = 0).
   The stand-ins do what the spectral functions do at lambda = 0. */
#define PDS__LAMBDA_MIN 380.0   /* nm: the range >>isc's bins name */
#define PDS__LAMBDA_MAX 780.0
#define PDS__SPECTRAL_BINS 16
static int pds__material_is_dispersive(const pds_material *m)
{
    return m->type == PDS_MAT_DIELECTRIC && m->dispersion != PDS_DISPERSION_NONE;
}
static double pds__spectral_value(const double rgb[3], double lambda_nm)
{
    (void)lambda_nm;
    return (rgb[0] + rgb[1] + rgb[2]) / 3.0;
}
static void pds__spectral_uplift(double lambda_nm, double w[3]) { (void)lambda_nm, (void)w; }
static void pds__film_weight(double lambda_nm, double w[3])
{
    (void)lambda_nm;
    w[0] = w[1] = w[2] = 1.0;
}
static void pds__spectral_material(const pds_material *m, double lambda_nm, pds_material *out)
{
    (void)lambda_nm;
    *out = *m;
}
static double pds__eye_wavelength(uint64_t seed, uint64_t pixel, uint64_t sample)
{
    (void)seed, (void)pixel, (void)sample;
    return 0.0;
}
static double pds__photon_wavelength(uint64_t seed, long i)
{
    (void)seed, (void)i;
    return 0.0;
}
#ifndef PDS_NO_BASELINES
static double pds__wavelength_match(double lambda_e, double lambda_p)
{
    (void)lambda_e, (void)lambda_p;
    return 1.0;
}
#endif
static int pds__spectral_meet(double lambda_p, double lambda_e, double e[3], double f[3])
{
    (void)lambda_p, (void)lambda_e, (void)e, (void)f;
    return 1;
}
#endif /* PDS_NO_SPECTRAL */

/* A photon turns spectral where it first meets a dispersive material (or,
   with --spectral, as it leaves the light): from there it carries its
   power at lambda times the film weight W(lambda) that turns spectral
   radiance into sRGB, and the Beer coefficients of the medium it is in
   (sigma, if it is in one) at lambda. */
static void pds__photon_turn_spectral(double lambda, double flux[3], double *sigma)
{
    double film[3], phi = pds__spectral_value(flux, lambda);
    int c;
    pds__film_weight(lambda, film);
    for (c = 0; c < 3; c++) flux[c] = phi * film[c];
    if (sigma) pds__spectral_uplift(lambda, sigma);
}

/* ===================================================================== */
/* >>lights                                                              */
/* ===================================================================== */
/* Light sources, for next-event estimation in the path tracer and for
   photon emission (PDS and the photon-mapping baselines). Units: powers in
   W, irradiance in W/m^2, intensity in W/sr, radiance in W/m^2/sr, per RGB
   channel; "m" is the scene unit.

   Conventions (one per pds_light_type):
   - point: power P emitted uniformly, intensity I = P / (4 pi); irradiance
     at distance r, normal incidence: I / r^2.
   - spot: at `position`, unit axis `direction`. With ci = cos(inner),
     co = cos(outer) and x = (cos theta - co) / (ci - co) clamped to [0,1],
     I(theta) = I0 s(x), s(x) = 3x^2 - 2x^3 (smoothstep): I0 inside the
     inner cone, 0 outside the outer one (inner == outer: a hard cone).
     As the integral of s over [0,1] is 1/2,
         P = 2 pi I0 [(1 - ci) + (ci - co) / 2],
     which gives I0 from the power.
   - directional: travel direction d, irradiance E across the beam. The
     beam is the emitter (a disk of `radius` centred at `position` and
     perpendicular to d when emitter_shape == 0, or the parallelogram
     position +- edge1/2 +- edge2/2 when emitter_shape == 1, which need not
     be perpendicular to d) swept along d. A point receives E exactly when
     its backward ray (from the point along -d) crosses the emitter. Beam
     cross-section A = pi R^2 or |(e1 x e2).d|; power E A.
   - disk (centre `position`, unit normal `direction`, radius) and quad
     (centre `position`, corners position +- edge1/2 +- edge2/2, normal
     normalize(edge1 x edge2)): one-sided Lambertian emitters of radiance L
     on the normal side, P = pi L A. They are analytic (not in the BVH) and
     never block light; pds__light_intersect finds them.
   - mesh: triangles first_triangle .. first_triangle + triangle_count - 1
     of the scene mesh, radiance L on the side of each triangle's geometric
     normal (P1 - P0) x (P2 - P0). They are in the BVH.
   - environment: radiance L(w) from infinitely far along every direction w
     (constant part, CIE clear sky, ground, sun disk; "the environment
     light" below); power pi R^2 times the integral of L, R the radius of
     the scene's bounding sphere. Not a delta light: next-event estimation
     samples a direction with a pdf, and rays that leave the scene see it.
   The selection weight of a light is the sum of its three channels of
   power (directional: E A from the irradiance and the beam geometry; the
   others: l->power). Geometric quantities (areas, normals) are recomputed
   from the geometry here rather than trusted from the light record; they
   agree with what the scene parser stores.

   Sampling (pdfs are per unit area on the light, per unit solid angle for
   directions and for the environment): area lights are sampled uniformly
   by area (disk: Shirley and Chiu's concentric square-to-disk map; mesh:
   a triangle by area through a CDF, then uniform inside it), so the
   solid-angle pdf seen from p is
   dist^2 / (A |cos theta_x|). Delta lights (point, spot, directional)
   return pdf 1 and the irradiance at normal incidence.

   Photon emission returns the flux a photon would carry if it were the only
   one from its light; the caller divides by the photon count and by the
   light's pick probability. A sample that returns 0 (no flux) must still be
   counted in the photon count, or the estimate is biased upwards.
   pds__light_emission_extent gives the emitting area Ae and emission solid
   angle omega_e of eqs 5-6 of Frisvad et al. 2014 (photon differentials):
   point (0, 4 pi), spot (0, 2 pi (1 - co)), directional (beam cross-section,
   0), and for Lambertian area lights (A, 2 pi): the paper gives no omega_e
   for them; the hemisphere is our choice. The environment: (pi R^2, 0),
   each photon a thin parallel beam as from a directional light (its
   footprint starts as its share of the disk it leaves from). */

typedef struct pds__light_table {
    size_t nlights;
    int *type;          /* per light: its pds_light_type (to check calls) */
    double *pmf;        /* per light: pick probability, cdf[i+1] - cdf[i] */
    double *cdf;        /* nlights + 1 entries: cdf[0] = 0, 1 from the last
                           light with power on */
    double *area;       /* per light: emitting area (mesh: sum of triangles;
                           directional: beam cross-section; 0 for point/spot) */
    size_t *tri_off;    /* per light: where its triangle CDF starts in tri_cdf */
    size_t *tri_n;      /* per light: its number of triangles (0 unless mesh) */
    double *tri_cdf;    /* per mesh light, triangle_count entries: running
                           area / light area, the last exactly 1 */
    int *tri_light;     /* per mesh triangle: its light, or -1 */
    size_t ntris;       /* length of tri_light */
    size_t pick_end;    /* 1 + the last light with pmf > 0; 0 if no light has
                           power (so a zeroed table picks nothing) */
    double *env_p;      /* 3 per light: an environment light's probabilities
                           of sampling its sun, its upper and its lower
                           hemisphere (0 0 0 for other lights) */
} pds__light_table;

typedef struct pds__light_li {
    pds__v3 wi;     /* unit direction from the shading point p toward the sampled light point */
    double dist;    /* distance to the sampled point (directional: to the emitter along -d);
                       the caller's shadow ray tests (eps, dist * (1 - 1e-4)) */
    double li[3];   /* area lights: radiance L toward p; delta lights: irradiance at
                       normal incidence at p (I / dist^2 or E) */
    double pdf;     /* solid-angle pdf of wi (area lights); 1 for delta lights */
    int delta;      /* 1 for point, spot, directional */
} pds__light_li;

typedef struct pds__light_emit {
    pds__v3 pos;        /* emission point */
    pds__v3 dir;        /* unit emission direction */
    pds__v3 normal;     /* unit surface normal at pos (area lights: the emitter's;
                           directional: d; point/spot: the zero vector = no normal) */
    double flux[3];     /* W carried if this were the light's only photon */
    double pdf_pos;     /* area density of pos: 1/A (directional: per unit beam
                           cross-section), 1 for point/spot */
    double pdf_dir;     /* solid-angle density of dir, 1 for directional */
} pds__light_emit;

static int pds__light_is_area(int type)
{
    return type == PDS_LIGHT_DISK || type == PDS_LIGHT_QUAD || type == PDS_LIGHT_MESH;
}

/* Unit geometric normal and area of mesh triangle tri (float positions
   widened to double, as everywhere else). */
static double pds__lights_tri_geom(const pds__mesh *mesh, long tri, pds__v3 *p0, pds__v3 *p1,
                                   pds__v3 *p2, pds__v3 *n)
{
    const int *v = &mesh->idx[3 * tri];
    pds__v3 c;
    double len;
    *p0 = pds__mesh_pos(mesh, v[0]);
    *p1 = pds__mesh_pos(mesh, v[1]);
    *p2 = pds__mesh_pos(mesh, v[2]);
    c = pds__cross(pds__sub(*p1, *p0), pds__sub(*p2, *p0));
    len = pds__length(c);
    *n = len > 0.0 ? pds__scale(c, 1.0 / len) : pds__v(0.0, 0.0, 0.0);
    return 0.5 * len;
}

/* Emitting area of a light that needs no mesh: disk pi R^2, quad
   |e1 x e2|, directional: its beam cross-section. 0 for point, spot and
   mesh (a mesh light's area comes from the table). */
static double pds__light_geom_area(const pds_light *l)
{
    switch (l->type) {
    case PDS_LIGHT_DISK: return PDS__PI * l->radius * l->radius;
    case PDS_LIGHT_QUAD: return pds__length(pds__cross(l->edge1, l->edge2));
    case PDS_LIGHT_DIRECTIONAL:
        if (l->emitter_shape == 0) return PDS__PI * l->radius * l->radius;
        return fabs(pds__dot(pds__cross(l->edge1, l->edge2), pds__normalize(l->direction)));
    case PDS_LIGHT_ENVIRONMENT: return PDS__PI * l->radius * l->radius;
    default: return 0.0;
    }
}

/* Unit normal of a disk or quad light (the side it emits on). */
static pds__v3 pds__light_plane_normal(const pds_light *l)
{
    if (l->type == PDS_LIGHT_QUAD) return pds__normalize(pds__cross(l->edge1, l->edge2));
    return pds__normalize(l->direction);
}

/* Selection weight: total power summed over the channels. */
static double pds__light_total_power(const pds_light *l, double area)
{
    if (l->type == PDS_LIGHT_DIRECTIONAL)
        return (l->irradiance[0] + l->irradiance[1] + l->irradiance[2]) * area;
    return l->power[0] + l->power[1] + l->power[2];
}

/* Bytes the table owns. */
static size_t pds__lights_memory(const pds__light_table *lt)
{
    size_t i, tris = 0, n = lt->nlights;
    for (i = 0; lt->tri_n && i < n; i++) tris += lt->tri_n[i];
    return n * (sizeof(int) + 6 * sizeof(double) + 2 * sizeof(size_t)) + (n ? sizeof(double) : 0) +
           tris * sizeof(double) + lt->ntris * sizeof(int);
}

static void pds__lights_free(pds__light_table *lt)
{
    free(lt->type);
    free(lt->pmf);
    free(lt->cdf);
    free(lt->area);
    free(lt->tri_off);
    free(lt->tri_n);
    free(lt->tri_cdf);
    free(lt->tri_light);
    free(lt->env_p);
    memset(lt, 0, sizeof *lt);
}

/* --- the environment light ------------------------------------------------ */
#ifndef PDS_NO_ENV
/* A light at infinity whose radiance depends on the direction only. w is
   a unit direction toward the sky: a ray leaving the scene along w sees
     L(w) = radiance + [w.up > 0] sky Y(w) + [w.up <= 0] ground
            + [w inside the sun's disk] Ls.
   The sky's shape Y is the CIE standard clear sky (CIE S 011/E:2003, sky
   type 12; Kittler, Perez and Darula 1998), relative to the zenith:
     Y(w) = f(chi) phi(Z) / (f(Zs) phi(0)),
     phi(Z) = 1 + a exp(b / cos Z)                           (gradation)
     f(chi) = 1 + c (exp(d chi) - exp(d pi / 2)) + e cos^2 chi  (indicatrix)
   with a = -1, b = -0.32, c = 10, d = -3, e = 0.45; Z is the zenith angle
   of w, chi its angle to the sun, Zs the sun's zenith angle. It is a
   luminance distribution: one colour (sky[], the zenith's radiance)
   scales it, so this sky has no blue-to-white gradient (Preetham et al.
   1999 would add one). The sun is a disk of angular radius alpha and
   uniform radiance Ls. A surface facing it receives the integral of
   Ls cos(theta) over the disk, E = Ls pi sin^2(alpha), so the sun is given
   by its irradiance E and Ls = E / (pi sin^2 alpha).

   Sampling, for next-event estimation and for photons: a mixture of three
   parts, each picked with its share of the integral of L (summed over the
   channels): the sun's cone (uniform in its solid angle
   Omega_s = 2 pi (1 - cos alpha)), the upper and the lower hemisphere
   (uniform, 2 pi each):
     pdf(w) = p_sun [w in the sun] / Omega_s + p_up [w.up > 0] / (2 pi)
              + p_down [w.up <= 0] / (2 pi).
   The scene parser (pds__scene_finish) sets position and radius to the
   bounding sphere (C, R) of the scene's triangles, area = pi R^2 and
   power = pi R^2 times the integral of L over the sphere: the flux that
   crosses the sphere's cross-section, summed over all directions. */

static const double pds__cie_clear[5] = {-1.0, -0.32, 10.0, -3.0, 0.45}; /* a b c d e */

/* The sun's cone: cos alpha, Omega_s and its radiance Ls (0 without a sun). */
static void pds__env_sun(const pds_light *l, double *cos_a, double *omega, double ls[3])
{
    double a = l->sun_radius_deg * (PDS__PI / 180.0), s = sin(a);
    int c;
    *cos_a = cos(a);
    *omega = 2.0 * PDS__PI * (1.0 - *cos_a);
    for (c = 0; c < 3; c++) ls[c] = s > 0.0 ? l->sun_irradiance[c] / (PDS__PI * s * s) : 0.0;
}

/* The indicatrix f(chi) and the gradation phi(cos Z) of the CIE sky. */
static double pds__cie_indicatrix(double chi)
{
    const double *k = pds__cie_clear;
    double ce = cos(chi);
    return 1.0 + k[2] * (exp(k[3] * chi) - exp(k[3] * PDS__PI / 2.0)) + k[4] * ce * ce;
}

static double pds__cie_gradation(double cos_z)
{
    const double *k = pds__cie_clear;
    return cos_z > 0.0 ? 1.0 + k[0] * exp(k[1] / cos_z) : 1.0;
}

/* Y(w) of the clear sky for unit w with w.up > 0 (1 at the zenith). */
static double pds__env_sky_shape(const pds_light *l, pds__v3 w)
{
    pds__v3 up = pds__normalize(l->up), sun = pds__normalize(l->sun_direction);
    double cz = pds__dot(w, up), czs = pds__dot(sun, up);
    double chi = acos(fmax(-1.0, fmin(1.0, pds__dot(w, sun))));
    double zs = acos(fmax(-1.0, fmin(1.0, czs)));
    return pds__cie_indicatrix(chi) * pds__cie_gradation(cz) / (pds__cie_indicatrix(zs) * pds__cie_gradation(1.0));
}

/* L(w) into L[3] (W/m^2/sr); w unit, toward the sky. */
static void pds__env_radiance(const pds_light *l, pds__v3 w, double L[3])
{
    double cos_a, omega, ls[3], y = 0.0;
    int c, above = pds__dot(w, pds__normalize(l->up)) > 0.0;
    int in_sun;
    pds__env_sun(l, &cos_a, &omega, ls);
    in_sun = pds__dot(w, pds__normalize(l->sun_direction)) >= cos_a;
    if (above && (l->sky[0] != 0.0 || l->sky[1] != 0.0 || l->sky[2] != 0.0)) y = pds__env_sky_shape(l, w);
    for (c = 0; c < 3; c++)
        L[c] = l->radiance[c] + (above ? l->sky[c] * y : l->ground[c]) + (in_sun ? ls[c] : 0.0);
}

/* The integral of L over the sphere, per channel, into total[3] (if not
   NULL), and the mixture's probabilities p[3] (sun, upper, lower; if not
   NULL). The sky's integral of Y over the upper hemisphere is a midpoint
   rule in (cos Z, azimuth about the sun's vertical plane), 96 x 192
   cells: Y is smooth, and the sum only sets the mixture weights and the
   light's power (the estimates stay unbiased whatever it is). */
static void pds__env_parts(const pds_light *l, double total[3], double p[3])
{
    pds__v3 up = pds__normalize(l->up), b1, b2;
    double cos_a, omega, ls[3], iy = 0.0, part[3] = {0.0, 0.0, 0.0}, sum;
    int c, i, j;
    const int nz = 96, nphi = 192;
    pds__env_sun(l, &cos_a, &omega, ls);
    if (l->sky[0] != 0.0 || l->sky[1] != 0.0 || l->sky[2] != 0.0) {
        pds__onb(up, &b1, &b2);
        for (i = 0; i < nz; i++) {
            double cz = (i + 0.5) / nz, sz = sqrt(fmax(0.0, 1.0 - cz * cz));
            for (j = 0; j < nphi; j++) {
                double phi = 2.0 * PDS__PI * (j + 0.5) / nphi;
                pds__v3 w = pds__add(pds__scale(up, cz),
                                     pds__add(pds__scale(b1, sz * cos(phi)), pds__scale(b2, sz * sin(phi))));
                iy += pds__env_sky_shape(l, w);
            }
        }
        iy *= 2.0 * PDS__PI / ((double)nz * nphi);
    }
    for (c = 0; c < 3; c++) {
        double up_c = 2.0 * PDS__PI * l->radiance[c] + iy * l->sky[c];
        double down_c = 2.0 * PDS__PI * (l->radiance[c] + l->ground[c]);
        double sun_c = omega * ls[c];
        if (total) total[c] = up_c + down_c + sun_c;
        part[0] += fabs(sun_c);
        part[1] += fabs(up_c);
        part[2] += fabs(down_c);
    }
    if (!p) return;
    sum = part[0] + part[1] + part[2];
    for (i = 0; i < 3; i++) p[i] = sum > 0.0 && sum <= DBL_MAX ? part[i] / sum : 0.0;
}

/* Solid-angle pdf of direction w (unit, toward the sky) under the mixture
   with probabilities p[3]. */
static double pds__env_pdf(const pds_light *l, const double p[3], pds__v3 w)
{
    double cos_a, omega, ls[3], pdf = 0.0;
    pds__env_sun(l, &cos_a, &omega, ls);
    if (p[0] > 0.0 && omega > 0.0 && pds__dot(w, pds__normalize(l->sun_direction)) >= cos_a) pdf += p[0] / omega;
    if (pds__dot(w, pds__normalize(l->up)) > 0.0) pdf += p[1] / (2.0 * PDS__PI);
    else pdf += p[2] / (2.0 * PDS__PI);
    return pdf;
}

/* A direction *w of part `part` (0 the sun's cone, 1 the upper, 2 the
   lower hemisphere), uniform in that part's solid angle, from u1, u2 in
   [0,1). */
static void pds__env_sample_part(const pds_light *l, int part, double u1, double u2, pds__v3 *w)
{
    double cos_a, omega, ls[3], ct, st, phi;
    pds__v3 axis, b1, b2;
    if (u1 >= 1.0) u1 = 1.0 - DBL_EPSILON;
    if (part == 0) {
        pds__env_sun(l, &cos_a, &omega, ls);
        axis = pds__normalize(l->sun_direction);
        ct = 1.0 - u1 * (1.0 - cos_a); /* cos uniform in [cos alpha, 1] */
    } else {
        axis = pds__normalize(l->up);
        ct = (part == 1 ? 1.0 : -1.0) * (1.0 - u1); /* |cos| uniform in (0, 1] */
    }
    st = sqrt(fmax(0.0, 1.0 - ct * ct));
    phi = 2.0 * PDS__PI * u2;
    pds__onb(axis, &b1, &b2);
    *w = pds__normalize(pds__add(pds__scale(axis, ct),
                                 pds__add(pds__scale(b1, st * cos(phi)), pds__scale(b2, st * sin(phi)))));
}

/* A direction from the mixture p[3] with uniforms u1, u2 in [0,1): u1
   picks the part and is then stretched back to [0,1) inside it. Returns
   the pdf of *w (0 when nothing can be sampled). */
static double pds__env_sample(const pds_light *l, const double p[3], double u1, double u2, pds__v3 *w)
{
    int part;
    if (!(p[0] + p[1] + p[2] > 0.0)) return 0.0;
    if (u1 < p[0]) {
        part = 0;
        u1 /= p[0];
    } else if (u1 < p[0] + p[1] || !(p[2] > 0.0)) {
        part = 1;
        u1 = p[1] > 0.0 ? (u1 - p[0]) / p[1] : 0.0;
    } else {
        part = 2;
        u1 = (u1 - p[0] - p[1]) / p[2];
    }
    pds__env_sample_part(l, part, u1, u2, w);
    return pds__env_pdf(l, p, *w);
}
#else /* PDS_NO_ENV */
/* This build leaves the environment light out: the scene parser refuses
   it, so no scene has one. What the other sections name of it stays,
   inert: no radiance, nothing to sample. */
static void pds__env_sun(const pds_light *l, double *cos_a, double *omega, double ls[3])
{
    (void)l;
    *cos_a = 1.0;
    *omega = 0.0;
    ls[0] = ls[1] = ls[2] = 0.0;
}
static void pds__env_radiance(const pds_light *l, pds__v3 w, double L[3])
{
    (void)l, (void)w;
    L[0] = L[1] = L[2] = 0.0;
}
static void pds__env_parts(const pds_light *l, double total[3], double p[3])
{
    (void)l;
    if (total) total[0] = total[1] = total[2] = 0.0;
    if (p) p[0] = p[1] = p[2] = 0.0;
}
static double pds__env_pdf(const pds_light *l, const double p[3], pds__v3 w)
{
    (void)l, (void)p, (void)w;
    return 0.0;
}
static double pds__env_sample(const pds_light *l, const double p[3], double u1, double u2, pds__v3 *w)
{
    (void)l, (void)p, (void)u1, (void)u2;
    *w = pds__v(0.0, 0.0, 1.0);
    return 0.0;
}
#endif /* PDS_NO_ENV */

/* Build the light table: pick distribution by power, per-mesh-light
   triangle CDFs by area, and the triangle -> light map. mesh may be NULL
   when there are no mesh lights. Fails (INVALID_ARG) on mesh lights whose
   triangle range lies outside the mesh or overlaps another mesh light, and
   on powers that are not finite. On failure *lt owns nothing. */
static pds_status pds__lights_prepare(pds__light_table *lt, const pds_light *lights, size_t nlights,
                                      const pds__mesh *mesh, pds_error *err)
{
    size_t i, k, nemit = 0, cursor = 0, ntris = mesh ? mesh->ntris : 0, n1;
    double total = 0.0, run = 0.0;
    pds_status st = PDS_OK;
    memset(lt, 0, sizeof *lt);
    if (nlights > (size_t)PDS_MAX_LIGHTS)
        return pds__fail(err, PDS_ERR_LIMIT, NULL, 0, 0, "%lu lights (the limit is %d)",
                         (unsigned long)nlights, PDS_MAX_LIGHTS);
    if (nlights > 0 && !lights)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "no light array given for %lu lights",
                         (unsigned long)nlights);
    for (i = 0; i < nlights; i++) {
        const pds_light *l = &lights[i];
        if (l->type != PDS_LIGHT_MESH) continue;
        if (l->first_triangle < 0 || l->triangle_count < 0 || (size_t)l->first_triangle > ntris
            || (size_t)l->triangle_count > ntris - (size_t)l->first_triangle)
            return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0,
                             "mesh light %lu uses triangles %d..%ld but the mesh has %lu triangles",
                             (unsigned long)i, l->first_triangle,
                             (long)l->first_triangle + (long)l->triangle_count - 1, (unsigned long)ntris);
        nemit += (size_t)l->triangle_count;
    }
    /* allocate at least one item so a light-less scene is not a special case */
    n1 = nlights ? nlights : 1;
    lt->nlights = nlights;
    lt->ntris = ntris;
    lt->type = (int *)calloc(n1, sizeof *lt->type);
    lt->pmf = (double *)calloc(n1, sizeof *lt->pmf);
    lt->cdf = (double *)calloc(nlights + 1, sizeof *lt->cdf);
    lt->area = (double *)calloc(n1, sizeof *lt->area);
    lt->tri_off = (size_t *)calloc(n1, sizeof *lt->tri_off);
    lt->tri_n = (size_t *)calloc(n1, sizeof *lt->tri_n);
    lt->tri_cdf = (double *)calloc(nemit ? nemit : 1, sizeof *lt->tri_cdf);
    lt->tri_light = (int *)malloc((ntris ? ntris : 1) * sizeof *lt->tri_light);
    lt->env_p = (double *)calloc(3 * n1, sizeof *lt->env_p);
    if (!lt->type || !lt->pmf || !lt->cdf || !lt->area || !lt->tri_off || !lt->tri_n || !lt->tri_cdf || !lt->tri_light
        || !lt->env_p) {
        pds__lights_free(lt);
        return pds__nomem(err);
    }
    for (k = 0; k < ntris; k++) lt->tri_light[k] = -1;

    /* areas, triangle CDFs, weights (kept in pmf until normalised) */
    for (i = 0; i < nlights && !st; i++) {
        const pds_light *l = &lights[i];
        double area, w;
        lt->type[i] = (int)l->type;
        if (l->type == PDS_LIGHT_MESH) {
            double acc = 0.0;
            size_t count = (size_t)l->triangle_count;
            lt->tri_off[i] = cursor;
            lt->tri_n[i] = count;
            for (k = 0; k < count; k++) {
                long tri = (long)l->first_triangle + (long)k;
                pds__v3 p0, p1, p2, n;
                if (lt->tri_light[tri] != -1) {
                    st = pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0,
                                   "triangle %ld belongs to mesh lights %d and %lu", tri,
                                   lt->tri_light[tri], (unsigned long)i);
                    break;
                }
                lt->tri_light[tri] = (int)i;
                acc += pds__lights_tri_geom(mesh, tri, &p0, &p1, &p2, &n);
                lt->tri_cdf[cursor + k] = acc;
            }
            if (acc > 0.0) {
                for (k = 0; k < count; k++) lt->tri_cdf[cursor + k] /= acc;
                lt->tri_cdf[cursor + count - 1] = 1.0;
            }
            cursor += count;
            if (st) break;
            area = acc;
        } else {
            area = pds__light_geom_area(l);
        }
        lt->area[i] = area;
        if (l->type == PDS_LIGHT_ENVIRONMENT) pds__env_parts(l, NULL, &lt->env_p[3 * i]);
        w = pds__light_total_power(l, area);
        if (w != w || w > DBL_MAX || !(area == area) || area > DBL_MAX) {
            st = pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0,
                           "light %lu has a power or size that is not a finite number", (unsigned long)i);
            break;
        }
        /* a light without emitting area or without power is never picked */
        if ((pds__light_is_area(l->type) || l->type == PDS_LIGHT_DIRECTIONAL || l->type == PDS_LIGHT_ENVIRONMENT)
            && !(area > 0.0))
            w = 0.0;
        if (!(w > 0.0)) w = 0.0;
        lt->pmf[i] = w;
        total += w;
    }
    if (!st && !(total <= DBL_MAX))
        st = pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "the lights' total power overflows");
    if (st) {
        pds__lights_free(lt);
        return st;
    }

    /* CDF; pmf[i] = cdf[i+1] - cdf[i] so picking and pmf agree exactly */
    lt->cdf[0] = 0.0;
    for (i = 0; i < nlights; i++) {
        run += lt->pmf[i];
        lt->cdf[i + 1] = total > 0.0 ? run / total : 0.0;
    }
    for (i = 0; i < nlights; i++) {
        lt->pmf[i] = lt->cdf[i + 1] - lt->cdf[i];
        if (lt->pmf[i] > 0.0) lt->pick_end = i + 1;
    }
    if (lt->pick_end > 0) {
        for (i = lt->pick_end; i <= nlights; i++) lt->cdf[i] = 1.0;
        lt->pmf[lt->pick_end - 1] = 1.0 - lt->cdf[lt->pick_end - 1];
    }
    return PDS_OK;
}

/* Light index for a uniform u in [0,1), chosen with probability
   proportional to power; *pmf (optional) gets that probability. -1 (and
   pmf 0) when no light has power. */
static int pds__lights_pick(const pds__light_table *lt, double u, double *pmf)
{
    size_t lo, hi;
    if (lt->pick_end == 0) {
        if (pmf) *pmf = 0.0;
        return -1;
    }
    if (!(u >= 0.0)) u = 0.0; /* also NaN */
    if (u >= 1.0) {
        lo = lt->pick_end - 1;
    } else {
        /* smallest i with u < cdf[i+1]; a zero-power light has
           cdf[i+1] == cdf[i], so it can never be the smallest */
        lo = 0;
        hi = lt->pick_end - 1;
        while (lo < hi) {
            size_t mid = lo + (hi - lo) / 2;
            if (u < lt->cdf[mid + 1]) hi = mid;
            else lo = mid + 1;
        }
    }
    if (pmf) *pmf = lt->pmf[lo];
    return (int)lo;
}

static double pds__lights_pmf(const pds__light_table *lt, int light)
{
    if (light < 0 || (size_t)light >= lt->nlights) return 0.0;
    return lt->pmf[light];
}

static int pds__light_of_triangle(const pds__light_table *lt, long tri)
{
    if (tri < 0 || (size_t)tri >= lt->ntris) return -1;
    return lt->tri_light[tri];
}

/* --- cone profile of the spot light ------------------------------------- */

/* cos of the inner and outer half-angles; inner is clamped to at most
   outer so that ci >= co. */
static void pds__light_spot_cones(const pds_light *l, double *ci, double *co)
{
    double inner = l->cone_inner_deg, outer = l->cone_outer_deg;
    if (inner > outer) inner = outer;
    *ci = cos(inner * (PDS__PI / 180.0));
    *co = cos(outer * (PDS__PI / 180.0));
    if (*ci < *co) *ci = *co;
}

/* s(x) for the cosine c of the angle to the axis: 1 inside the inner
   cone, 0 outside the outer one, smoothstep 3x^2 - 2x^3 between. */
static double pds__light_spot_falloff(double c, double ci, double co)
{
    double x;
    if (c >= ci) return 1.0;
    if (c <= co) return 0.0;
    x = (c - co) / (ci - co);
    return x * x * (3.0 - 2.0 * x);
}

/* Axial intensity I0 (W/sr) of channel ch: P / (2 pi [(1-ci) + (ci-co)/2]). */
static double pds__light_spot_i0(const pds_light *l, int ch, double ci, double co)
{
    double denom = 2.0 * PDS__PI * ((1.0 - ci) + 0.5 * (ci - co));
    return denom > 0.0 ? l->power[ch] / denom : 0.0;
}

/* --- surface sampling ----------------------------------------------------- */

/* Shirley and Chiu's concentric map: [0,1)^2 -> unit disk, area
   preserving up to a constant, with low distortion. */
static void pds__lights_concentric(double u1, double u2, double *dx, double *dy)
{
    double a = 2.0 * u1 - 1.0, b = 2.0 * u2 - 1.0, r, phi;
    if (a == 0.0 && b == 0.0) {
        *dx = *dy = 0.0;
        return;
    }
    if (fabs(a) > fabs(b)) {
        r = a;
        phi = (PDS__PI / 4.0) * (b / a);
    } else {
        r = b;
        phi = PDS__PI / 2.0 - (PDS__PI / 4.0) * (a / b);
    }
    *dx = r * cos(phi);
    *dy = r * sin(phi);
}

/* Checks that light_index names a light of l's type in the table and,
   for a mesh light, that its triangles exist in mesh. */
static int pds__light_table_ok(const pds__light_table *lt, const pds_light *l, int light_index,
                               const pds__mesh *mesh)
{
    if (!lt || light_index < 0 || (size_t)light_index >= lt->nlights) return 0;
    if (lt->type[light_index] != (int)l->type) return 0;
    if (l->type == PDS_LIGHT_MESH) {
        if (!mesh || l->triangle_count <= 0 || l->first_triangle < 0) return 0;
        if ((size_t)l->first_triangle + (size_t)l->triangle_count > mesh->ntris) return 0;
        if ((size_t)l->triangle_count != lt->tri_n[light_index]) return 0; /* not the light prepared */
        if (!(lt->area[light_index] > 0.0)) return 0;
    }
    return 1;
}

/* A point uniformly distributed by area on an area light: *x, its unit
   normal *n (the emitting side) and the light's area *area. u1, u2 in
   [0,1). Returns 0 when the light has no area or the call is invalid. */
static int pds__light_sample_surface(const pds__light_table *lt, const pds_light *l, int light_index,
                                     const pds__mesh *mesh, double u1, double u2, pds__v3 *x,
                                     pds__v3 *n, double *area)
{
    if (l->type == PDS_LIGHT_DISK) {
        pds__v3 b1, b2;
        double dx, dy;
        *n = pds__light_plane_normal(l);
        *area = pds__light_geom_area(l);
        if (!(*area > 0.0) || !(pds__length(*n) > 0.0)) return 0;
        pds__onb(*n, &b1, &b2);
        pds__lights_concentric(u1, u2, &dx, &dy);
        *x = pds__add(l->position, pds__add(pds__scale(b1, dx * l->radius), pds__scale(b2, dy * l->radius)));
        return 1;
    }
    if (l->type == PDS_LIGHT_QUAD) {
        *n = pds__light_plane_normal(l);
        *area = pds__light_geom_area(l);
        if (!(*area > 0.0)) return 0;
        *x = pds__add(l->position, pds__add(pds__scale(l->edge1, u1 - 0.5), pds__scale(l->edge2, u2 - 0.5)));
        return 1;
    }
    if (l->type == PDS_LIGHT_MESH) {
        const double *cdf;
        size_t lo = 0, hi, count;
        double prev, su, b0, b1;
        pds__v3 p0, p1, p2;
        if (!pds__light_table_ok(lt, l, light_index, mesh)) return 0;
        count = (size_t)l->triangle_count;
        cdf = lt->tri_cdf + lt->tri_off[light_index];
        /* the triangle: smallest k with u1 < cdf[k] (zero-area ones never) */
        hi = count - 1;
        if (!(u1 >= 0.0)) u1 = 0.0;
        while (lo < hi) {
            size_t mid = lo + (hi - lo) / 2;
            if (u1 < cdf[mid]) hi = mid;
            else lo = mid + 1;
        }
        /* reuse u1 within the chosen bin */
        prev = lo > 0 ? cdf[lo - 1] : 0.0;
        u1 = cdf[lo] > prev ? (u1 - prev) / (cdf[lo] - prev) : 0.5;
        if (u1 < 0.0) u1 = 0.0;
        if (u1 > 1.0) u1 = 1.0;
        pds__lights_tri_geom(mesh, (long)l->first_triangle + (long)lo, &p0, &p1, &p2, n);
        /* uniform in the triangle: sqrt warp of the first coordinate */
        su = sqrt(u1);
        b0 = 1.0 - su;
        b1 = su * (1.0 - u2);
        *x = pds__add(pds__add(pds__scale(p0, b0), pds__scale(p1, b1)), pds__scale(p2, 1.0 - b0 - b1));
        *area = lt->area[light_index];
        return 1;
    }
    return 0;
}

/* Where the backward ray from p (along -d) crosses a directional light's
   emitter: returns 1 and the distance *t > 0 when it does. */
static int pds__light_beam_hit(const pds_light *l, pds__v3 p, double *t)
{
    pds__v3 d = pds__normalize(l->direction), n, q, r;
    double denom, tt;
    n = l->emitter_shape == 0 ? d : pds__cross(l->edge1, l->edge2);
    denom = pds__dot(d, n);
    if (!(fabs(denom) > 0.0)) return 0;
    /* q = p - t d on the plane dot(q - c, n) = 0 */
    tt = pds__dot(pds__sub(p, l->position), n) / denom;
    if (!(tt > 0.0)) return 0;
    q = pds__sub(p, pds__scale(d, tt));
    r = pds__sub(q, l->position);
    if (l->emitter_shape == 0) {
        if (!(pds__dot(r, r) <= l->radius * l->radius)) return 0;
    } else {
        /* r = a e1 + b e2  =>  a = (r x e2).n / |n|^2, b = (e1 x r).n / |n|^2 */
        double nn = pds__dot(n, n);
        double a = pds__dot(pds__cross(r, l->edge2), n) / nn;
        double b = pds__dot(pds__cross(l->edge1, r), n) / nn;
        if (!(fabs(a) <= 0.5 && fabs(b) <= 0.5)) return 0;
    }
    *t = tt;
    return 1;
}

/* --- next-event estimation ---------------------------------------------- */

/* Sample light l (index light_index in lt) as seen from point p with
   uniforms u1, u2 in [0,1). Fills *out; returns 0 when this sample brings
   nothing to p: p behind a one-sided emitter (or behind the sampled
   triangle of a mesh light), outside the spot cone or the directional
   beam, at the light itself, or an invalid call. */
static int pds__light_sample_li(const pds__light_table *lt, const pds_light *l, int light_index,
                                const pds__mesh *mesh, pds__v3 p, double u1, double u2, pds__light_li *out)
{
    int c;
    memset(out, 0, sizeof *out);
    switch (l->type) {
    case PDS_LIGHT_POINT:
    case PDS_LIGHT_SPOT: {
        pds__v3 d = pds__sub(l->position, p);
        double dist = pds__length(d), s = 1.0, ci = 1.0, co = 1.0, any = 0.0;
        if (!(dist > 0.0)) return 0;
        out->wi = pds__scale(d, 1.0 / dist);
        out->dist = dist;
        out->pdf = 1.0;
        out->delta = 1;
        if (l->type == PDS_LIGHT_SPOT) {
            pds__v3 axis = pds__normalize(l->direction);
            pds__light_spot_cones(l, &ci, &co);
            s = pds__light_spot_falloff(-pds__dot(out->wi, axis), ci, co);
        }
        for (c = 0; c < 3; c++) {
            double I = l->type == PDS_LIGHT_POINT ? l->power[c] / (4.0 * PDS__PI)
                                                  : pds__light_spot_i0(l, c, ci, co) * s;
            out->li[c] = I / (dist * dist);
            any += fabs(out->li[c]);
        }
        return any > 0.0;
    }
    case PDS_LIGHT_DIRECTIONAL: {
        double t;
        if (!pds__light_beam_hit(l, p, &t)) return 0;
        out->wi = pds__scale(pds__normalize(l->direction), -1.0);
        out->dist = t;
        out->pdf = 1.0;
        out->delta = 1;
        for (c = 0; c < 3; c++) out->li[c] = l->irradiance[c];
        return 1;
    }
    case PDS_LIGHT_DISK:
    case PDS_LIGHT_QUAD:
    case PDS_LIGHT_MESH: {
        pds__v3 x, n, d;
        double area, dist2, dist, cosl;
        if (!pds__light_sample_surface(lt, l, light_index, mesh, u1, u2, &x, &n, &area)) return 0;
        d = pds__sub(x, p);
        dist2 = pds__dot(d, d);
        dist = sqrt(dist2);
        if (!(dist > 0.0)) return 0;
        out->wi = pds__scale(d, 1.0 / dist);
        out->dist = dist;
        cosl = -pds__dot(n, out->wi); /* > 0 when p is on the emitting side */
        if (!(cosl > 0.0)) return 0;
        out->pdf = dist2 / (area * cosl);
        for (c = 0; c < 3; c++) out->li[c] = l->radiance[c];
        return out->pdf > 0.0 && out->pdf <= DBL_MAX;
    }
    case PDS_LIGHT_ENVIRONMENT: {
        /* a direction from the mixture; the shadow ray goes to infinity */
        if (!lt || light_index < 0 || (size_t)light_index >= lt->nlights) return 0;
        out->pdf = pds__env_sample(l, &lt->env_p[3 * light_index], u1, u2, &out->wi);
        if (!(out->pdf > 0.0)) return 0;
        out->dist = DBL_MAX;
        pds__env_radiance(l, out->wi, out->li);
        return out->li[0] != 0.0 || out->li[1] != 0.0 || out->li[2] != 0.0;
    }
    }
    return 0;
}

/* Solid-angle pdf with which pds__light_sample_li(p) produces the point x
   (geometric normal nx) on area light l: dist^2 / (A |cos theta_x|), for
   MIS when a BSDF ray hits the light. 0 for delta lights. */
static double pds__light_pdf_li(const pds__light_table *lt, const pds_light *l, int light_index,
                                const pds__mesh *mesh, pds__v3 p, pds__v3 x, pds__v3 nx)
{
    pds__v3 d = pds__sub(x, p);
    double area, dist2 = pds__dot(d, d), cosl;
    if (!pds__light_is_area(l->type)) return 0.0;
    if (l->type == PDS_LIGHT_MESH) {
        if (!pds__light_table_ok(lt, l, light_index, mesh)) return 0.0;
        area = lt->area[light_index];
    } else {
        area = pds__light_geom_area(l);
    }
    if (!(area > 0.0) || !(dist2 > 0.0)) return 0.0;
    cosl = fabs(pds__dot(pds__normalize(nx), d)) / sqrt(dist2);
    if (!(cosl > 0.0)) return 0.0;
    return dist2 / (area * cosl);
}

/* Ray against a disk or quad light (the analytic emitters that are not in
   the BVH), from either side, t in the open interval (tmin, tmax) in units
   of |dir|. Fills *t and the emitter's unit normal *nx (never flipped).
   0 for a miss and for every other light type. */
static int pds__light_intersect(const pds_light *l, pds__v3 org, pds__v3 dir, double tmin, double tmax,
                                double *t, pds__v3 *nx)
{
    pds__v3 n, r;
    double denom, tt;
    if (l->type != PDS_LIGHT_DISK && l->type != PDS_LIGHT_QUAD) return 0;
    n = pds__light_plane_normal(l);
    denom = pds__dot(dir, n);
    if (!(fabs(denom) > 0.0)) return 0;
    tt = pds__dot(pds__sub(l->position, org), n) / denom;
    if (!(tt > tmin && tt < tmax)) return 0;
    r = pds__sub(pds__add(org, pds__scale(dir, tt)), l->position);
    if (l->type == PDS_LIGHT_DISK) {
        /* r lies in the plane (up to rounding), so |r| is the radius */
        if (!(pds__dot(r, r) <= l->radius * l->radius)) return 0;
    } else {
        pds__v3 m = pds__cross(l->edge1, l->edge2);
        double mm = pds__dot(m, m);
        double a = pds__dot(pds__cross(r, l->edge2), m) / mm;
        double b = pds__dot(pds__cross(l->edge1, r), m) / mm;
        if (!(fabs(a) <= 0.5 && fabs(b) <= 0.5)) return 0;
    }
    *t = tt;
    *nx = n;
    return 1;
}

/* Radiance leaving an area light's surface of normal nx in direction w:
   L on the emitting side (dot(nx, w) > 0), else 0; 0 for delta lights. */
static void pds__light_le(const pds_light *l, pds__v3 nx, pds__v3 w, double le[3])
{
    int c, lit = pds__light_is_area(l->type) && pds__dot(nx, w) > 0.0;
    for (c = 0; c < 3; c++) le[c] = lit ? l->radiance[c] : 0.0;
}

/* --- photon emission ----------------------------------------------------- */

/* One photon from light l with uniforms u[0..3] in [0,1):
   point: uniform sphere (u0, u1); spot: uniform over the outer cone's solid
   angle (u0, u1); area lights: uniform position (u0, u1), cosine-weighted
   direction about the normal (u2, u3); directional: uniform position on
   the emitter (u0, u1), dir = d. Returns 0 when the photon carries no flux
   (e.g. the rim of a spot cone) or the call is invalid; the caller still
   counts such a photon. */
static int pds__light_emit_sample(const pds__light_table *lt, const pds_light *l, int light_index,
                                  const pds__mesh *mesh, const double u[4], pds__light_emit *out)
{
    int c;
    double any = 0.0;
    memset(out, 0, sizeof *out);
    switch (l->type) {
    case PDS_LIGHT_POINT: {
        double z = 1.0 - 2.0 * u[0], s = sqrt(fmax(0.0, 1.0 - z * z)), phi = 2.0 * PDS__PI * u[1];
        out->pos = l->position;
        out->dir = pds__v(s * cos(phi), s * sin(phi), z);
        out->pdf_pos = 1.0;
        out->pdf_dir = 1.0 / (4.0 * PDS__PI);
        for (c = 0; c < 3; c++) out->flux[c] = l->power[c]; /* (P / 4 pi) / pdf_dir */
        break;
    }
    case PDS_LIGHT_SPOT: {
        pds__v3 axis = pds__normalize(l->direction), b1, b2;
        double ci, co, ct, st, phi, s;
        pds__light_spot_cones(l, &ci, &co);
        if (!(1.0 - co > 0.0) || !(pds__length(axis) > 0.0)) return 0;
        /* uniform in solid angle: cos theta uniform on [co, 1] */
        ct = 1.0 - u[0] * (1.0 - co);
        st = sqrt(fmax(0.0, 1.0 - ct * ct));
        phi = 2.0 * PDS__PI * u[1];
        pds__onb(axis, &b1, &b2);
        out->pos = l->position;
        out->dir = pds__normalize(pds__add(pds__scale(axis, ct),
                                           pds__add(pds__scale(b1, st * cos(phi)), pds__scale(b2, st * sin(phi)))));
        out->pdf_pos = 1.0;
        out->pdf_dir = 1.0 / (2.0 * PDS__PI * (1.0 - co));
        s = pds__light_spot_falloff(ct, ci, co);
        for (c = 0; c < 3; c++) out->flux[c] = pds__light_spot_i0(l, c, ci, co) * s / out->pdf_dir;
        break;
    }
    case PDS_LIGHT_DIRECTIONAL: {
        pds__v3 d = pds__normalize(l->direction);
        double area = pds__light_geom_area(l);
        if (!(area > 0.0) || !(pds__length(d) > 0.0)) return 0;
        if (l->emitter_shape == 0) {
            pds__v3 b1, b2;
            double dx, dy;
            pds__onb(d, &b1, &b2);
            pds__lights_concentric(u[0], u[1], &dx, &dy);
            out->pos = pds__add(l->position, pds__add(pds__scale(b1, dx * l->radius), pds__scale(b2, dy * l->radius)));
        } else {
            out->pos = pds__add(l->position, pds__add(pds__scale(l->edge1, u[0] - 0.5), pds__scale(l->edge2, u[1] - 0.5)));
        }
        out->dir = d;
        out->normal = d;
        out->pdf_pos = 1.0 / area;
        out->pdf_dir = 1.0;
        for (c = 0; c < 3; c++) out->flux[c] = l->irradiance[c] * area;
        break;
    }
    case PDS_LIGHT_DISK:
    case PDS_LIGHT_QUAD:
    case PDS_LIGHT_MESH: {
        pds__v3 x, n, b1, b2;
        double area, r, phi, z;
        if (!pds__light_sample_surface(lt, l, light_index, mesh, u[0], u[1], &x, &n, &area)) return 0;
        /* cosine-weighted hemisphere (Malley): uniform disk point lifted */
        r = sqrt(u[2]);
        phi = 2.0 * PDS__PI * u[3];
        z = sqrt(fmax(0.0, 1.0 - u[2]));
        if (!(z > 0.0)) return 0;
        pds__onb(n, &b1, &b2);
        out->pos = x;
        out->normal = n;
        out->dir = pds__normalize(pds__add(pds__scale(n, z),
                                           pds__add(pds__scale(b1, r * cos(phi)), pds__scale(b2, r * sin(phi)))));
        out->pdf_pos = 1.0 / area;
        out->pdf_dir = z / PDS__PI;
        /* L cos / (pdf_pos pdf_dir) = pi L A, whatever the direction */
        for (c = 0; c < 3; c++) out->flux[c] = PDS__PI * l->radiance[c] * area;
        break;
    }
    case PDS_LIGHT_ENVIRONMENT: {
        /* pbrt's infinite-light emission (Pharr, Jakob, Humphreys,
           "Physically Based Rendering", 3rd ed., 12.6): w from the
           mixture (u0, u1), then a uniform point (u2, u3) on the disk of
           radius R across w, centred at C + R w; the photon travels
           along -w and carries L(w) / (pdf_pos pdf_dir) = L(w) pi R^2 /
           pdf(w). Every line that meets the bounding sphere crosses the
           disk, so the photons carry all the flux that enters it. */
        pds__v3 w, b1, b2, centre;
        double area = PDS__PI * l->radius * l->radius, dx, dy, L[3];
        if (!lt || light_index < 0 || (size_t)light_index >= lt->nlights || !(area > 0.0)) return 0;
        out->pdf_dir = pds__env_sample(l, &lt->env_p[3 * light_index], u[0], u[1], &w);
        if (!(out->pdf_dir > 0.0)) return 0;
        pds__onb(w, &b1, &b2);
        pds__lights_concentric(u[2], u[3], &dx, &dy);
        centre = pds__add(l->position, pds__scale(w, l->radius));
        out->pos = pds__add(centre, pds__add(pds__scale(b1, dx * l->radius), pds__scale(b2, dy * l->radius)));
        out->dir = pds__scale(w, -1.0);
        out->normal = out->dir;
        out->pdf_pos = 1.0 / area;
        pds__env_radiance(l, w, L);
        for (c = 0; c < 3; c++) out->flux[c] = L[c] * area / out->pdf_dir;
        break;
    }
    default:
        return 0;
    }
    for (c = 0; c < 3; c++) any += fabs(out->flux[c]);
    return any > 0.0;
}

/* Emitting area Ae and emission solid angle omega_e of a light, for the
   initial photon differentials (Frisvad et al. 2014, eqs 5-6). Area
   lights use the hemisphere, 2 pi (the paper gives no value for them). */
static void pds__light_emission_extent(const pds_light *l, double *area, double *solid_angle)
{
    double ci, co;
    switch (l->type) {
    case PDS_LIGHT_POINT:
        *area = 0.0;
        *solid_angle = 4.0 * PDS__PI;
        return;
    case PDS_LIGHT_SPOT:
        pds__light_spot_cones(l, &ci, &co);
        *area = 0.0;
        *solid_angle = 2.0 * PDS__PI * (1.0 - co);
        return;
    case PDS_LIGHT_DIRECTIONAL:
        *area = pds__light_geom_area(l);
        *solid_angle = 0.0;
        return;
    case PDS_LIGHT_DISK:
    case PDS_LIGHT_QUAD:
        *area = pds__light_geom_area(l);
        *solid_angle = 2.0 * PDS__PI;
        return;
    case PDS_LIGHT_MESH:
        *area = l->area;
        *solid_angle = 2.0 * PDS__PI;
        return;
    case PDS_LIGHT_ENVIRONMENT:
        /* each photon is a thin parallel beam, as from a directional
           light: the disk's share of area, no spread in direction */
        *area = PDS__PI * l->radius * l->radius;
        *solid_angle = 0.0;
        return;
    }
    *area = 0.0;
    *solid_angle = 0.0;
}

/* ===================================================================== */
/* >>kdtree                                                              */
/* ===================================================================== */
/* A balanced 3-d tree over points, for the two neighbour searches of the
   renderer: the range query of photon differential splatting (every
   eye-path vertex within r of a photon) and the k-nearest-neighbour
   query of standard photon mapping (Jensen 1996; k nearest photons,
   optionally within a maximum radius).

   Layout (implicit, no pointers): the points are stored in tree order.
   A node is a range [lo, hi) of that order; its own point is the median
   element m = lo + (hi - lo) / 2, its children are [lo, m) and
   [m + 1, hi). A range of at most PDS__KD_LEAF points is a leaf (a
   bucket, scanned linearly). axis[m] is the split axis of the inner node
   whose median is m; every point in [lo, m) has that coordinate
   <= s = pts[3m + axis[m]], every point in [m + 1, hi) has it >= s.
   Subtrees are contiguous in memory, so the few subtrees a small query
   touches share cache lines.

     pts   float x, y, z per point, in tree order (12 bytes each)
     perm  size_t: perm[i] = the caller's index of the point at slot i
     axis  unsigned char per slot: split axis 0..2 (meaningful only at
           inner-node medians; 0 elsewhere)
   21 bytes per point in all.

   Build: each node takes the axis of largest extent of its points'
   bounding box (the lowest axis on ties) and places its median by
   quickselect (three-way partition, so duplicates cost nothing; pivot =
   median of three samples at positions drawn from a counter hash, so the
   tree is a pure function of the input). Each level costs O(n), there
   are log2(n) levels: O(n log n). Coordinates are compared in a total
   order with NaN above everything: a NaN point can never be found (its
   distance is NaN) but cannot break the partition for the others.

   Queries: squared distances are computed in double from the float
   point, d2 = dx*dx + dy*dy + dz*dz with dx = p.x - c.x, and a point is
   in if d2 <= r*r. Traversal is iterative (explicit stack; each level
   pushes at most one entry and there are fewer than 64 levels), nearer
   child first. Each cell carries its offset vector o: per axis, the
   signed distance fl(c - s) from the query to the split plane that
   bounds the cell on that axis (0 if none); a cell is skipped when
   |o|^2 > r^2 (incremental distance, Arya and Mount 1993; in 3-d this
   prunes about a fifth more than the last plane alone). This never loses
   a point: for p in the cell, |fl(p_k - c_k)| >= |o_k| on every axis
   since rounding is monotone, so d2(p), the same rounded expression of
   larger arguments, is >= |o|^2. (With -ffp-contract=fast the compiler
   may fuse the two copies of the expression differently; then only a
   point within an ulp or two of the radius can be misjudged.)

   The median of a node is tested together with its far child, not on
   the way down: it lies on the split plane inside the parent cell, so
   the far cell's bound covers it too, and the medians above a small
   query are mostly far away. Per node the loops avoid unpredictable
   branches (the far entry is always written and kept only if within
   reach; a leaf's hits are collected, then reported). Leaves of up to
   16 points (so 8 to 16 in practice) measured best for radii holding 10
   to 100 points, on a par with 32 and about 1.5 times faster than 6.

   k-NN keeps a bounded max-heap of (dist2, index) pairs in the caller's
   output arrays, ordered lexicographically, so equal distances are
   ranked by smaller original index exactly as a brute-force sort would;
   a cell is skipped only if its bound exceeds the current k-th distance
   (strictly: an equal distance with a smaller index could still enter).
   The heap is finally heap-sorted in place. A query may start with a
   bound known to hold its k nearest (pds__kdtree_knn_hint: the k-th
   distance of the query before it plus the step between the two, by the
   triangle inequality); it then finds the same points, sooner. The
   photon-map gathers ask neighbouring eye vertices in turn, and a query
   far from every photon, which would otherwise search wide until its
   heap held k good candidates, prunes from the start (the Cornell box
   at 512 x 512, 2.1 million queries at k = 8: 1.6 times quicker; at
   k = 50, 2 times).

   Invariants: read-only after the build, so concurrent queries are safe;
   results (sets, order, ties) depend only on the points and the query. */

#define PDS__KD_LEAF 16    /* ranges of at most this many points are leaves */
#define PDS__KD_STACK 72   /* > 64 > tree depth for any size_t count */

typedef struct pds__kdtree {
    float *pts;           /* 3 per point, tree order */
    size_t *perm;         /* tree slot -> caller's index */
    unsigned char *axis;  /* split axis at inner-node medians */
    size_t n;
    double lo[3], hi[3];  /* bounding box of the points (NaN coordinates left out) */
} pds__kdtree;

typedef void (*pds__kd_visit)(void *ctx, size_t index, double dist2);

/* Squared length in double, and the squared distance from float point p
   to (qx, qy, qz). Every point distance and every cell bound goes
   through pds__kd_len2, one expression in one order, as the rounding
   argument in the prologue needs (the tests' brute force uses it too). */
static double pds__kd_len2(double x, double y, double z)
{
    return x * x + y * y + z * z;
}

static double pds__kd_dist2(const float *p, double qx, double qy, double qz)
{
    return pds__kd_len2((double)p[0] - qx, (double)p[1] - qy, (double)p[2] - qz);
}

/* Total order on floats for partitioning: the usual one, NaN last. */
static int pds__kd_less(float a, float b)
{
    return a < b || (b != b && a == a);
}

/* The middle one of three values in that order. */
static float pds__kd_median3(float a, float b, float c)
{
    if (pds__kd_less(b, a)) {
        float t = a;
        a = b;
        b = t;
    }
    /* now a <= b: the median is b, unless c is below it */
    if (pds__kd_less(c, b)) return pds__kd_less(c, a) ? a : c;
    return b;
}

static void pds__kd_swap(pds__kdtree *kd, size_t i, size_t j)
{
    float *a = kd->pts + 3 * i, *b = kd->pts + 3 * j;
    float t0 = a[0], t1 = a[1], t2 = a[2];
    size_t ti = kd->perm[i];
    a[0] = b[0];
    a[1] = b[1];
    a[2] = b[2];
    b[0] = t0;
    b[1] = t1;
    b[2] = t2;
    kd->perm[i] = kd->perm[j];
    kd->perm[j] = ti;
}

/* Rearrange slots [lo, hi) so that slot m holds the element that would be
   there if the range were sorted on coordinate a (total order above),
   with no larger element before it and no smaller one after it.
   *counter feeds the pivot hash; it advances by 3 per partition step. */
static void pds__kd_select(pds__kdtree *kd, size_t lo, size_t hi, size_t m, int a,
                           uint64_t *counter)
{
    const float *p = kd->pts;
    while (hi - lo > 1) {
        size_t len = hi - lo, lt, i, gt;
        float v, s0, s1, s2;
        /* Median of three samples at hashed positions: expected linear
           time on any input not built against this hash, and the same
           positions on every run. */
        s0 = p[3 * (lo + (size_t)(pds__mix64(*counter) % len)) + a];
        s1 = p[3 * (lo + (size_t)(pds__mix64(*counter + 1) % len)) + a];
        s2 = p[3 * (lo + (size_t)(pds__mix64(*counter + 2) % len)) + a];
        *counter += 3;
        v = pds__kd_median3(s0, s1, s2);
        /* Dijkstra's three-way partition: [lo, lt) < v, [lt, i) == v,
           [gt, hi) > v, [i, gt) not yet seen. */
        lt = lo;
        i = lo;
        gt = hi;
        while (i < gt) {
            float x = p[3 * i + a];
            if (pds__kd_less(x, v)) {
                if (lt != i) pds__kd_swap(kd, lt, i);
                lt++;
                i++;
            } else if (pds__kd_less(v, x)) {
                gt--;
                pds__kd_swap(kd, i, gt);
            } else {
                i++;
            }
        }
        if (m < lt) hi = lt;
        else if (m >= gt) lo = gt;
        else return;
    }
}

/* Build the subtree over slots [lo, hi): split axis from the bounding box
   of its points, median into place, then both halves. Recursion depth is
   the tree depth (< 64: each level at least halves the range). */
static void pds__kd_build_node(pds__kdtree *kd, size_t lo, size_t hi, uint64_t *counter)
{
    while (hi - lo > PDS__KD_LEAF) {
        float bmin[3], bmax[3];
        double ext, best = -1.0;
        size_t i, m = lo + (hi - lo) / 2;
        int k, a = 0;
        for (k = 0; k < 3; k++) {
            bmin[k] = FLT_MAX;
            bmax[k] = -FLT_MAX;
        }
        for (i = lo; i < hi; i++) {
            const float *p = kd->pts + 3 * i;
            for (k = 0; k < 3; k++) {
                if (p[k] < bmin[k]) bmin[k] = p[k];
                if (p[k] > bmax[k]) bmax[k] = p[k];
            }
        }
        /* Ties (and degenerate boxes) keep the lowest axis; extents are
           taken in double so huge coordinates cannot overflow to inf. */
        for (k = 0; k < 3; k++) {
            ext = (double)bmax[k] - (double)bmin[k];
            if (ext > best) {
                best = ext;
                a = k;
            }
        }
        pds__kd_select(kd, lo, hi, m, a, counter);
        kd->axis[m] = (unsigned char)a;
        /* Recurse into the left half, loop on the right one. */
        pds__kd_build_node(kd, lo, m, counter);
        lo = m + 1;
    }
}

static void pds__kdtree_free(pds__kdtree *kd)
{
    if (!kd) return;
    free(kd->pts);
    free(kd->perm);
    free(kd->axis);
    memset(kd, 0, sizeof *kd);
}

/* Build a tree over n points pos[i*stride + 0..2] (stride in floats,
   >= 3). *kd is overwritten (not freed first); on failure it is left
   empty and safe to free. n = 0 gives an empty tree. */
static pds_status pds__kdtree_build(pds__kdtree *kd, const float *pos, size_t stride, size_t n,
                                    pds_error *err)
{
    size_t i;
    uint64_t counter = 0;
    memset(kd, 0, sizeof *kd);
    if (n == 0) return PDS_OK;
    if (!pos || stride < 3)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0,
                         "kd-tree: point stride must be at least 3 floats (got %lu)",
                         (unsigned long)stride);
    if (n > ((size_t)-1) / (3 * sizeof(float)) || n > ((size_t)-1) / sizeof(size_t))
        return pds__nomem(err);
    kd->pts = (float *)malloc(3 * n * sizeof(float));
    kd->perm = (size_t *)malloc(n * sizeof(size_t));
    kd->axis = (unsigned char *)calloc(n, 1);
    if (!kd->pts || !kd->perm || !kd->axis) {
        pds__kdtree_free(kd);
        return pds__nomem(err);
    }
    for (i = 0; i < n; i++) {
        const float *p = pos + i * stride;
        kd->pts[3 * i + 0] = p[0];
        kd->pts[3 * i + 1] = p[1];
        kd->pts[3 * i + 2] = p[2];
        kd->perm[i] = i;
    }
    kd->n = n;
    for (i = 0; i < 3; i++) {
        kd->lo[i] = DBL_MAX;
        kd->hi[i] = -DBL_MAX;
    }
    for (i = 0; i < 3 * n; i++) {
        double x = kd->pts[i];
        if (x < kd->lo[i % 3]) kd->lo[i % 3] = x;
        if (x > kd->hi[i % 3]) kd->hi[i % 3] = x;
    }
    pds__kd_build_node(kd, 0, n, &counter);
    return PDS_OK;
}

/* Bytes of heap memory the tree owns. */
static size_t pds__kdtree_memory(const pds__kdtree *kd)
{
    return kd ? kd->n * (3 * sizeof(float) + sizeof(size_t) + 1) : 0;
}

/* A query point with a NaN coordinate matches nothing. */
static int pds__kd_query_ok(pds__v3 c)
{
    return c.x == c.x && c.y == c.y && c.z == c.z;
}

#if !defined(PDS_NO_BASELINES) || !defined(PDS_NO_GI) || !defined(PDS_NO_BENCH) || defined(PDS_TEST)
/* A node waiting on a query's stack: its median slot m and its far
   child's slot range [lo, hi), with o[] the far cell's offsets (per
   axis, the signed distance from the query to the nearest split plane
   bounding the cell on that axis, 0 if none) and rd = pds__kd_len2(o),
   a lower bound on dist2 for every point in the far cell and for the
   median itself (which lies on the far cell's boundary plane). */
typedef struct pds__kd_entry {
    size_t m, lo, hi;
    double o[3];
    double rd;
} pds__kd_entry;

/* Both queries' descent from node [lo, hi) (offset (ox, oy, oz) from the
   query to the cell) down to the leaf holding the query q: at each median
   m, the far child [.. ) waits on the stack with m itself and its offset,
   unless its squared distance rd exceeds `bound`. d is the signed distance
   to the split plane; d <= 0 means the query is on the low side, so
   [lo, m) is the near child (a NaN split, from NaN points, sends it high
   and never prunes, as every comparison with NaN fails). Returns the new
   stack size. */
static int pds__kd_descend(const float *pts, const unsigned char *axis, const double q[3], double bound,
                           pds__kd_entry *stk, int sp, size_t *plo, size_t *phi, double ox, double oy, double oz)
{
    size_t lo = *plo, hi = *phi;
    while (hi - lo > PDS__KD_LEAF) {
        size_t m = lo + (hi - lo) / 2;
        int a = axis[m];
        double d = q[a] - (double)pts[3 * m + a];
        double tx = a == 0 ? d : ox;
        double ty = a == 1 ? d : oy;
        double tz = a == 2 ? d : oz;
        double rd = pds__kd_len2(tx, ty, tz);
        int high = !(d <= 0.0);
        stk[sp].m = m;
        stk[sp].lo = high ? lo : m + 1;
        stk[sp].hi = high ? m : hi;
        stk[sp].o[0] = tx;
        stk[sp].o[1] = ty;
        stk[sp].o[2] = tz;
        stk[sp].rd = rd;
        sp += !(rd > bound);
        lo = high ? m + 1 : lo;
        hi = high ? hi : m;
    }
    *plo = lo;
    *phi = hi;
    return sp;
}

/* Call fn(ctx, caller's index, dist2) for every point with dist2 <= r*r
   (dist2 as pds__kd_dist2). Each point is reported exactly once; the
   order is that of the traversal (nearer child first), a function of the
   tree and c only. r < 0, NaN r or a NaN query report nothing; r =
   DBL_MAX reports every point with finite coordinates.

   Descent goes to the near child without testing the node's median; the
   median and the far child are pushed together and dropped together when
   their common bound rd exceeds r^2 (Arya and Mount's incremental
   distance: the full offset vector of the cell, not only the distance to
   the last plane). Most medians on a query's path are far away, so this
   skips their tests. The far child is always written to the stack and
   kept only if within reach, and a leaf's hits are collected before they
   are reported: both avoid unpredictable branches. */
static void pds__kdtree_range(const pds__kdtree *kd, pds__v3 c, double r, pds__kd_visit fn,
                              void *ctx)
{
    pds__kd_entry stk[PDS__KD_STACK];
    size_t lo = 0, hi;
    int sp = 0;
    double q[3], ox = 0.0, oy = 0.0, oz = 0.0, r2;
    const float *pts;
    const unsigned char *axis;
    if (!kd || kd->n == 0 || !(r >= 0.0) || !pds__kd_query_ok(c)) return;
    pts = kd->pts;
    axis = kd->axis;
    hi = kd->n;
    q[0] = c.x;
    q[1] = c.y;
    q[2] = c.z;
    r2 = r * r;
    for (;;) {
        sp = pds__kd_descend(pts, axis, q, r2, stk, sp, &lo, &hi, ox, oy, oz);
        {
            size_t hit[PDS__KD_LEAF], i;
            double hd[PDS__KD_LEAF];
            int nh = 0, j;
            for (i = lo; i < hi; i++) {
                double d2 = pds__kd_dist2(pts + 3 * i, q[0], q[1], q[2]);
                hit[nh] = i;
                hd[nh] = d2;
                nh += d2 <= r2;
            }
            for (j = 0; j < nh; j++) fn(ctx, kd->perm[hit[j]], hd[j]);
        }
        if (sp == 0) break;
        sp--;
        {
            size_t m = stk[sp].m;
            double d2 = pds__kd_dist2(pts + 3 * m, q[0], q[1], q[2]);
            if (d2 <= r2) fn(ctx, kd->perm[m], d2);
        }
        lo = stk[sp].lo;
        hi = stk[sp].hi;
        ox = stk[sp].o[0];
        oy = stk[sp].o[1];
        oz = stk[sp].o[2];
    }
}
#endif

/* The splat's query: every point x within r of c whose offset d = x - c
   lies in the slab |n . d| <= tol and in the elliptic cylinder
   y0^2 + y1^2 < 1, y = M d (M: the 2 x 3 matrix that maps an ellipse
   around c onto the unit disc, eq. 12 of the PDS paper); fn(ctx, caller's
   index, y0^2 + y1^2). The points reported are exactly those a range
   query of radius r would find and then keep by the slab and ellipse
   tests (the distance is the same pds__kd_dist2), but a needle-shaped
   ellipse is not searched as the ball of its major axis: a cell is
   skipped when its box [b_lo, b_hi] (centre b, half-widths h) lies
   beyond the ball, or outside the slab or either strip |y_j| < 1, which
   for a linear form w . d over the box spans w . (b - c) +- sum_k |w_k|
   h_k. A relative margin of 1e-9 keeps rounding from dropping a point on
   a cell's edge. Each entry of the explicit stack is a cell and its box;
   a node pushes at most two, so the depth (< 64) bounds it. */
#define PDS__KD_SLAB_STACK (2 * PDS__KD_STACK)

typedef struct pds__kd_cell {
    size_t lo, hi;
    double bl[3], bh[3];
} pds__kd_cell;

typedef struct pds__kd_slab {
    double c[3], r2, w[3][3], bound[3]; /* rows n, M0, M1 and their bounds tol, 1, 1 */
} pds__kd_slab;

/* 1 if no point of the cell's box can pass the query. */
static int pds__kd_cell_outside(const pds__kd_slab *q, const pds__kd_cell *cell)
{
    double b[3], h[3], d2 = 0.0;
    int k, j;
    for (k = 0; k < 3; k++) {
        double below = cell->bl[k] - q->c[k], above = q->c[k] - cell->bh[k];
        double out = below > 0.0 ? below : above > 0.0 ? above : 0.0;
        d2 += out * out;
        b[k] = 0.5 * (cell->bl[k] + cell->bh[k]) - q->c[k];
        h[k] = 0.5 * (cell->bh[k] - cell->bl[k]);
    }
    if (d2 > q->r2 * (1.0 + 1e-9)) return 1;
    for (j = 0; j < 3; j++) {
        const double *w = q->w[j];
        double centre = fabs(w[0] * b[0] + w[1] * b[1] + w[2] * b[2]);
        double spread = fabs(w[0]) * h[0] + fabs(w[1]) * h[1] + fabs(w[2]) * h[2];
        if (centre - spread > q->bound[j] * (1.0 + 1e-9) + 1e-9 * spread) return 1;
    }
    return 0;
}

/* Test the point in tree slot i; report it if it passes. */
static void pds__kd_slab_point(const pds__kdtree *kd, const pds__kd_slab *q, size_t i, pds__kd_visit fn, void *ctx)
{
    const float *p = kd->pts + 3 * i;
    double d[3], y0, y1;
    if (!(pds__kd_dist2(p, q->c[0], q->c[1], q->c[2]) <= q->r2)) return;
    d[0] = (double)p[0] - q->c[0];
    d[1] = (double)p[1] - q->c[1];
    d[2] = (double)p[2] - q->c[2];
    if (fabs(q->w[0][0] * d[0] + q->w[0][1] * d[1] + q->w[0][2] * d[2]) > q->bound[0]) return;
    y0 = q->w[1][0] * d[0] + q->w[1][1] * d[1] + q->w[1][2] * d[2];
    y1 = q->w[2][0] * d[0] + q->w[2][1] * d[1] + q->w[2][2] * d[2];
    if (y0 * y0 + y1 * y1 < 1.0) fn(ctx, kd->perm[i], y0 * y0 + y1 * y1);
}

static void pds__kdtree_range_ellipse(const pds__kdtree *kd, pds__v3 c, double r, const double M[2][3], pds__v3 n,
                                      double tol, pds__kd_visit fn, void *ctx)
{
    pds__kd_cell stk[PDS__KD_SLAB_STACK];
    pds__kd_slab q;
    int sp = 0, k;
    if (!kd || kd->n == 0 || !(r >= 0.0) || !(tol >= 0.0) || !pds__kd_query_ok(c)) return;
    q.c[0] = c.x;
    q.c[1] = c.y;
    q.c[2] = c.z;
    q.r2 = r * r;
    for (k = 0; k < 3; k++) {
        q.w[0][k] = pds__v3_get(n, k);
        q.w[1][k] = M[0][k];
        q.w[2][k] = M[1][k];
    }
    q.bound[0] = tol;
    q.bound[1] = q.bound[2] = 1.0;
    stk[0].lo = 0;
    stk[0].hi = kd->n;
    memcpy(stk[0].bl, kd->lo, sizeof stk[0].bl);
    memcpy(stk[0].bh, kd->hi, sizeof stk[0].bh);
    sp = 1;
    while (sp > 0) {
        pds__kd_cell cell = stk[--sp];
        size_t i, m;
        int a;
        if (pds__kd_cell_outside(&q, &cell)) continue;
        if (cell.hi - cell.lo <= PDS__KD_LEAF) {
            for (i = cell.lo; i < cell.hi; i++) pds__kd_slab_point(kd, &q, i, fn, ctx);
            continue;
        }
        m = cell.lo + (cell.hi - cell.lo) / 2;
        a = kd->axis[m];
        pds__kd_slab_point(kd, &q, m, fn, ctx);
        /* children: [lo, m) below the split, [m + 1, hi) above it */
        stk[sp] = cell;
        stk[sp].hi = m;
        stk[sp].bh[a] = kd->pts[3 * m + a];
        sp++;
        stk[sp] = cell;
        stk[sp].lo = m + 1;
        stk[sp].bl[a] = kd->pts[3 * m + a];
        sp++;
    }
}

#if !defined(PDS_NO_BASELINES) || !defined(PDS_NO_GI) || !defined(PDS_NO_BENCH) || defined(PDS_TEST)
/* Heap order on (dist2, index): 1 if a ranks after b. Written with &
   and | so that it compiles to flag arithmetic, not two branches: the
   outcome is unpredictable, so branches would mostly mispredict. */
static int pds__kd_after(double da, size_t ia, double db, size_t ib)
{
    return (da > db) | ((da == db) & (ia > ib));
}

/* Move the element at the root of a heap of cnt entries down to its
   place (after it replaced the worst candidate). */
static void pds__kd_sift_down(size_t *idx, double *dist2, size_t cnt)
{
    double d = dist2[0];
    size_t id = idx[0], i = 0, ch;
    while ((ch = 2 * i + 1) < cnt) {
        /* the larger child: the right one if it exists and ranks after */
        if (ch + 1 < cnt && pds__kd_after(dist2[ch + 1], idx[ch + 1], dist2[ch], idx[ch])) ch++;
        if (!pds__kd_after(dist2[ch], idx[ch], d, id)) break;
        dist2[i] = dist2[ch];
        idx[i] = idx[ch];
        i = ch;
    }
    dist2[i] = d;
    idx[i] = id;
}

/* Put (d, id) into the hole at slot i of the max-heap, moving parents
   that come before it down. */
static void pds__kd_sift_up(size_t *idx, double *dist2, size_t i, double d, size_t id)
{
    while (i > 0) {
        size_t parent = (i - 1) / 2;
        if (!pds__kd_after(d, id, dist2[parent], idx[parent])) break;
        dist2[i] = dist2[parent];
        idx[i] = idx[parent];
        i = parent;
    }
    dist2[i] = d;
    idx[i] = id;
}

/* The same, bottom-up (Floyd's variant), for the final heap sort: walk
   the hole down to a leaf along the larger children, one comparison per
   level, then move the element up from there. The element moved to the
   root in a heap sort step is a leaf, small, and belongs near the
   bottom, so the walk up is short. */
static void pds__kd_sift_down_bottom_up(size_t *idx, double *dist2, size_t cnt)
{
    double d = dist2[0];
    size_t id = idx[0], i = 0, ch;
    while ((ch = 2 * i + 1) < cnt) {
        if (ch + 1 < cnt && pds__kd_after(dist2[ch + 1], idx[ch + 1], dist2[ch], idx[ch])) ch++;
        dist2[i] = dist2[ch];
        idx[i] = idx[ch];
        i = ch;
    }
    pds__kd_sift_up(idx, dist2, i, d, id);
}

/* Offer a candidate to the bounded heap (cnt entries, capacity k); it has
   already passed dist2 <= rmax^2. */
static void pds__kd_offer(size_t *idx, double *dist2, size_t *cnt, size_t k, double d, size_t id)
{
    size_t i = *cnt;
    if (i < k) {
        /* room left: sift up from the end */
        pds__kd_sift_up(idx, dist2, i, d, id);
        *cnt += 1;
    } else if (pds__kd_after(dist2[0], idx[0], d, id)) {
        /* better than the worst kept: replace the root */
        dist2[0] = d;
        idx[0] = id;
        pds__kd_sift_down(idx, dist2, k);
    }
}

/* Up to k nearest points with dist2 <= bound2, into idx[] (caller's
   indices) and dist2[] sorted by increasing distance, ties by smaller
   index; the caller gives room for k. Returns the count. No allocation:
   the heap lives in idx[]/dist2[]. bound2 is the pruning distance until
   the heap is full; the answer is that of every point within bound2, so
   a bound2 known to hold the k nearest (pds__kdtree_knn_hint) finds the
   same points as a larger one, only sooner. */
static size_t pds__kdtree_knn_within(const pds__kdtree *kd, pds__v3 c, size_t k, double bound2, size_t *idx,
                                     double *dist2)
{
    pds__kd_entry stk[PDS__KD_STACK];
    size_t lo = 0, hi, i, cnt = 0;
    int sp = 0;
    double q[3], ox = 0.0, oy = 0.0, oz = 0.0, bound;
    const float *pts;
    const unsigned char *axis;
    if (!kd || kd->n == 0 || k == 0 || !(bound2 >= 0.0) || !pds__kd_query_ok(c)) return 0;
    pts = kd->pts;
    axis = kd->axis;
    hi = kd->n;
    q[0] = c.x;
    q[1] = c.y;
    q[2] = c.z;
    /* bound: the pruning distance, bound2 until the heap is full, then
       the k-th best so far (which is <= bound2) */
    bound = bound2;
    for (;;) {
        /* Down to the leaf holding the query, medians deferred as in the
           range query; each waiting node is re-checked against the
           (shrinking) bound when popped. Strict comparisons: a point at
           exactly the bound with a smaller index than the worst kept
           must still be seen. */
        sp = pds__kd_descend(pts, axis, q, bound, stk, sp, &lo, &hi, ox, oy, oz);
        for (i = lo; i < hi; i++) {
            double d2 = pds__kd_dist2(pts + 3 * i, q[0], q[1], q[2]);
            if (d2 <= bound) {
                pds__kd_offer(idx, dist2, &cnt, k, d2, kd->perm[i]);
                if (cnt == k) bound = dist2[0];
            }
        }
        /* the next waiting node still within reach */
        while (sp > 0 && stk[sp - 1].rd > bound) sp--;
        if (sp == 0) break;
        sp--;
        {
            size_t m = stk[sp].m;
            double d2 = pds__kd_dist2(pts + 3 * m, q[0], q[1], q[2]);
            if (d2 <= bound) {
                pds__kd_offer(idx, dist2, &cnt, k, d2, kd->perm[m]);
                if (cnt == k) bound = dist2[0];
            }
        }
        lo = stk[sp].lo;
        hi = stk[sp].hi;
        ox = stk[sp].o[0];
        oy = stk[sp].o[1];
        oz = stk[sp].o[2];
    }
    /* Heap sort in place: move the worst to the end, shrink, repeat. */
    for (i = cnt; i > 1; i--) {
        double td = dist2[0];
        size_t ti = idx[0];
        dist2[0] = dist2[i - 1];
        idx[0] = idx[i - 1];
        dist2[i - 1] = td;
        idx[i - 1] = ti;
        pds__kd_sift_down_bottom_up(idx, dist2, i - 1);
    }
    return cnt;
}

/* Up to k nearest points with dist2 <= rmax^2 (rmax may be DBL_MAX):
   pds__kdtree_knn_within with bound2 = rmax^2. */
static size_t pds__kdtree_knn(const pds__kdtree *kd, pds__v3 c, size_t k, double rmax,
                              size_t *idx, double *dist2)
{
    if (!(rmax >= 0.0)) return 0;
    return pds__kdtree_knn_within(kd, c, k, rmax * rmax, idx, dist2);
}

#if !defined(PDS_NO_BASELINES) || defined(PDS_TEST)
/* A bound on the k-th distance at c from a query made before at p that
   found k points (the k-th at squared distance pk2): those k points lie
   within sqrt(pk2) of p, so within sqrt(pk2) + |c - p| of c (the
   triangle inequality), and the k nearest of c no farther. Gathers ask
   neighbouring vertices one after another, so the bound is tight, and a
   query far from every point, which without it would search wide until
   its heap held k good candidates, starts pruning at once. The margin
   of 1e-9 covers the rounding of the distances (relative 1e-16): the
   bound must not fall below a k-th distance that pds__kd_dist2 rounds
   up. Returns min(bound, rmax^2); rmax^2 alone when there is no earlier
   query (pk2 < 0). */
static double pds__kdtree_knn_hint(pds__v3 c, pds__v3 p, double pk2, double rmax)
{
    double r2 = rmax * rmax, h;
    if (!(pk2 >= 0.0) || !pds__kd_query_ok(p)) return r2;
    h = sqrt(pk2) + pds__length(pds__sub(c, p));
    h = h * h * (1.0 + 1e-9);
    return h < r2 ? h : r2;
}
#endif
#endif

/* ===================================================================== */
/* >>scene                                                               */
/* ===================================================================== */
/* The pds_scene value and the text format that describes it (README.md,
   "Scene format", is the user's reference; keep the two in step).

   A scene file is a sequence of statements, each a keyword, maybe a name,
   and a block in braces holding `key value...` properties:

       camera { position 0 1 5  look_at 0 0 0  fov 40  resolution 512 512 }
       material glass dielectric { ior 1.5 }
       light point { position 0 4 0  power 100 }
       sphere { material glass  radius 1  translate 0 1 0 }
       mesh "bunny.obj" { material glass  scale 10 }

   Line breaks are white space like any other; `#` starts a comment that
   runs to the end of the line. `include "FILE"` and `define NAME VALUE`
   are statements too, and `$NAME` may stand for any token (see "variables
   and include" below). Numbers take any C form (decimal, exponent,
   hexadecimal, hexadecimal float, a leading-zero integer is octal, and an
   f/F/l/L/u/U suffix is ignored). NaN and infinity are refused. Every error
   carries FILE:LINE:COLUMN of the token at fault.

   Invariants after a successful load: every triangle's material index is
   valid, every light has finite positive extent where it needs one, the
   BVH is built, and nothing in the scene changes again (queries are
   thread-safe). */

struct pds_scene {
    char path[512];
    pds__mesh mesh;
    pds__materials materials;
    pds_light *lights;
    size_t nlights, cap_lights;
    pds_camera camera;
    pds__bvh bvh;
    pds__light_table light_table; /* light selection and sampling tables */
    double bvh_build_s;      /* seconds the BVH build took (one thread) */
    int shapes;
    char (*warnings)[256];
    size_t nwarnings, cap_warnings;
    pds__v3 bounds_min, bounds_max;
    int env_index1;          /* 1 + the environment light's index, 0 = none */
};

/* Record a warning; warnings that do not fit in memory are dropped (they
   are advice, never needed for correctness). */
static void pds__scene_warn(pds_scene *s, const char *fmt, ...)
{
    va_list ap;
    if (pds__grow((void **)&s->warnings, &s->cap_warnings, s->nwarnings + 1, sizeof *s->warnings))
        return;
    va_start(ap, fmt);
    vsnprintf(s->warnings[s->nwarnings], sizeof s->warnings[0], fmt, ap);
    va_end(ap);
    s->nwarnings++;
}

/* What an OBJ load found worth telling the user. */
static void pds__scene_warn_obj(pds_scene *s, const char *path, const pds__obj_stats *st)
{
    if (st->degenerate_dropped)
        pds__scene_warn(s, "%s: %ld degenerate (zero-area) triangles dropped", path, st->degenerate_dropped);
    if (st->ignored_statements)
        pds__scene_warn(s, "%s: %ld unknown statements ignored (first: %s)", path, st->ignored_statements,
                        st->ignored_example);
    if (st->bad_references)
        pds__scene_warn(s, "%s: %ld texture-coordinate or normal indices out of range were dropped (first: %s); "
                        "those corners get computed normals", path, st->bad_references, st->bad_example);
    if (st->missing_mtl)
        pds__scene_warn(s, "%s: %ld material libraries not found, first %s; their materials use the default", path,
                        st->missing_mtl, st->missing_example);
    if (st->unknown_materials)
        pds__scene_warn(s, "%s: %ld material names not found in its MTL files; they use the default material", path,
                        st->unknown_materials);
}

static pds_camera pds__camera_default(void)
{
    pds_camera c;
    c.position = pds__v(0.0, 0.0, 5.0);
    c.look_at = pds__v(0.0, 0.0, 0.0);
    c.up = pds__v(0.0, 1.0, 0.0);
    c.fov_deg = 40.0;
    c.width = 256;
    c.height = 256;
    c.spp = 4;
    c.filter = PDS_FILTER_BOX;
    c.aperture = 0.0; /* a pinhole */
    c.focus_distance = 0.0;
    return c;
}

static pds_scene *pds__scene_new(const char *path)
{
    pds_scene *s = (pds_scene *)calloc(1, sizeof *s);
    if (!s) return NULL;
    pds__strlcpy(s->path, path, sizeof s->path);
    s->camera = pds__camera_default();
    return s;
}

void pds_scene_free(pds_scene *s)
{
    if (!s) return;
    pds__mesh_free(&s->mesh);
    pds__materials_free(&s->materials);
    free(s->lights);
    free(s->warnings);
    pds__bvh_free(&s->bvh);
    pds__lights_free(&s->light_table);
    free(s);
}

/* Index of the material "default" (white diffuse), created on first use. */
static int pds__scene_default_material(pds_scene *s)
{
    int i = pds__materials_find(&s->materials, "default");
    pds_material m;
    if (i >= 0) return i;
    m = pds__material_default("default");
    return pds__materials_add(&s->materials, &m);
}

static int pds__scene_add_light(pds_scene *s, const pds_light *l)
{
    if (s->nlights >= (size_t)PDS_MAX_LIGHTS) return -1;
    if (pds__grow((void **)&s->lights, &s->cap_lights, s->nlights + 1, sizeof *s->lights)) return -1;
    s->lights[s->nlights++] = *l;
    return 0;
}

/* --- lexer -------------------------------------------------------------- */

typedef enum pds__tok_kind {
    PDS__TOK_END = 0, PDS__TOK_WORD, PDS__TOK_NUMBER, PDS__TOK_STRING, PDS__TOK_LBRACE, PDS__TOK_RBRACE
} pds__tok_kind;

typedef struct pds__token {
    pds__tok_kind kind;
    char text[512];
    int line, col;
    char var[64];         /* "$name" stood here: the variable's name, else "" */
} pds__token;

/* --- variables and include: what one load shares across its files ------- */
/* A variable is declared with a default, `define NAME VALUE`, and used as
   `$NAME` wherever a token may stand: the lexer hands out its value (a
   number, a word or a string) in place of `$NAME`, at the position of
   the `$`. A -D NAME=VALUE of the load options replaces the default where
   it is declared, so the loaded scene, and its content hash, is that of
   the overridden values. `include "FILE"` reads FILE (relative to the
   including file) as if its statements stood there; variables and the one
   camera are shared by all files of the load. */
typedef struct pds__var {
    char name[64];
    pds__tok_kind kind;
    char value[512];
    char file[256];       /* where it is defined, for messages */
    int line, col;
    int overridden;       /* 1: the value comes from a -D */
} pds__var;

typedef struct pds__load {
    const pds_define *defines; /* the -D overrides */
    int ndefines;
    unsigned char *define_used; /* per override: a `define` took it */
    pds__var *vars;
    size_t nvars, cap_vars;
    pds__names var_index;  /* name -> index in vars */
    const char *chain[PDS_MAX_INCLUDE_DEPTH + 1]; /* the files being read, outermost first */
    int site_line[PDS_MAX_INCLUDE_DEPTH], site_col[PDS_MAX_INCLUDE_DEPTH]; /* where chain[d + 1]
                              is included in chain[d] */
    int depth;             /* chain[depth] is the file being read */
    long includes;         /* include statements read so far */
    size_t bytes;          /* scene text read so far, all files (at most
                              PDS_MAX_TEXT_BYTES: bounds time and memory) */
    int camera_seen;
    int noted;             /* the error already says where it was included from */
} pds__load;

typedef struct pds__parser {
    const char *file;     /* scene path as given, for messages */
    char dir[512];        /* its directory, for relative mesh paths */
    const char *p;        /* read position */
    int line, col;        /* of *p */
    pds__token tok;       /* current token */
    pds__token brace;     /* the '{' of the block being read (blocks do not nest) */
    const char *keys[48]; /* the keys the block's reader tried for the current
                             key, in order: the ones valid here (for "did you mean") */
    int nkeys;
    pds_scene *scene;
    pds_error *err;
    pds__load *L;         /* shared by the files of one load */
} pds__parser;

/* An error at token `at`; a value that came from a variable says so. */
static pds_status pds__perr(pds__parser *P, const pds__token *at, pds_status st, const char *fmt, ...)
{
    char msg[512], note[400] = "";
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (at->var[0] && P->L) {
        int i = pds__names_find(&P->L->var_index, at->var, strlen(at->var));
        const pds__var *v = i >= 0 ? &P->L->vars[i] : NULL;
        if (v && v->overridden)
            snprintf(note, sizeof note, " (the value of $%s, set by -D %s=...)", v->name, v->name);
        else if (v)
            snprintf(note, sizeof note, " (the value of $%s, defined at %.200s:%d:%d)", v->name, v->file, v->line,
                     v->col);
    }
    return pds__fail(P->err, st, P->file, at->line, at->col, "%s%s", msg, note);
}

/* Append text to an error's message and printable text. */
static void pds__error_append(pds_error *err, const char *fmt, ...)
{
    char add[400];
    size_t m, t;
    va_list ap;
    if (!err) return;
    va_start(ap, fmt);
    vsnprintf(add, sizeof add, fmt, ap);
    va_end(ap);
    m = strlen(err->message);
    t = strlen(err->text);
    snprintf(err->message + m, sizeof err->message - m, "%s", add);
    snprintf(err->text + t, sizeof err->text - t, "%s", add);
}

static void pds__lex_advance(pds__parser *P)
{
    if (*P->p == '\n') {
        P->line++;
        P->col = 1;
    } else {
        P->col++;
    }
    P->p++;
}

static int pds__is_word_char(int c)
{
    return isalnum(c) || c == '_' || c == '-' || c == '.' || c == '/' || c == '+';
}

static int pds__edit_distance(const char *a, const char *b);

static int pds__is_var_char(int c)
{
    return isalnum(c) || c == '_';
}

/* The value of a variable, in its own kind (the token stays where the
   `$` was): an undefined variable is an error there. */
static pds_status pds__lex_variable(pds__parser *P)
{
    pds__token *t = &P->tok;
    pds__load *L = P->L;
    char name[64];
    size_t n = 0, k;
    int i;
    pds__lex_advance(P); /* the '$' */
    while (pds__is_var_char((unsigned char)*P->p)) {
        if (n + 1 >= sizeof name)
            return pds__perr(P, t, PDS_ERR_LIMIT, "variable name longer than %d characters", (int)sizeof name - 1);
        name[n++] = *P->p;
        pds__lex_advance(P);
    }
    name[n] = '\0';
    if (n == 0) return pds__perr(P, t, PDS_ERR_PARSE, "expected a variable name after '$'");
    i = L ? pds__names_find(&L->var_index, name, n) : -1;
    if (i < 0) {
        const char *closest = NULL;
        int best = 3, given = 0;
        for (k = 0; L && k < L->nvars; k++) {
            int d = pds__edit_distance(name, L->vars[k].name);
            if (d < best) {
                best = d;
                closest = L->vars[k].name;
            }
        }
        if (closest && best <= (n > 4 ? 2 : 1))
            return pds__perr(P, t, PDS_ERR_PARSE, "undefined variable '$%s' (did you mean '$%s'?)", name, closest);
        for (k = 0; L && k < (size_t)L->ndefines; k++) given |= !strcmp(L->defines[k].name, name);
        if (given)
            return pds__perr(P, t, PDS_ERR_PARSE, "undefined variable '$%s': -D gives it a value, but the scene must "
                             "declare it first with 'define %s DEFAULT'", name, name);
        return pds__perr(P, t, PDS_ERR_PARSE, "undefined variable '$%s' (declare it first: 'define %s VALUE')", name,
                         name);
    }
    t->kind = L->vars[i].kind;
    pds__strlcpy(t->text, L->vars[i].value, sizeof t->text);
    pds__strlcpy(t->var, name, sizeof t->var);
    return PDS_OK;
}

/* Read the next token into P->tok. */
static pds_status pds__lex_next(pds__parser *P)
{
    pds__token *t = &P->tok;
    size_t n = 0;
    for (;;) {
        while (*P->p && isspace((unsigned char)*P->p)) pds__lex_advance(P);
        if (*P->p != '#') break;
        while (*P->p && *P->p != '\n') pds__lex_advance(P);
    }
    t->line = P->line;
    t->col = P->col;
    t->text[0] = '\0';
    t->var[0] = '\0';
    if (*P->p == '$') return pds__lex_variable(P);
    if (!*P->p) {
        t->kind = PDS__TOK_END;
        pds__strlcpy(t->text, "end of file", sizeof t->text);
        return PDS_OK;
    }
    if (*P->p == '{' || *P->p == '}') {
        t->kind = *P->p == '{' ? PDS__TOK_LBRACE : PDS__TOK_RBRACE;
        t->text[0] = *P->p;
        t->text[1] = '\0';
        pds__lex_advance(P);
        return PDS_OK;
    }
    if (*P->p == '"') {
        t->kind = PDS__TOK_STRING;
        pds__lex_advance(P);
        while (*P->p && *P->p != '"' && *P->p != '\n') {
            if (n + 1 >= sizeof t->text)
                return pds__perr(P, t, PDS_ERR_LIMIT, "string longer than %d characters", (int)sizeof t->text - 1);
            t->text[n++] = *P->p;
            pds__lex_advance(P);
        }
        t->text[n] = '\0';
        if (*P->p != '"') return pds__perr(P, t, PDS_ERR_PARSE, "unterminated string");
        pds__lex_advance(P);
        return PDS_OK;
    }
    if (!pds__is_word_char((unsigned char)*P->p))
        return pds__perr(P, t, PDS_ERR_PARSE, "unexpected character '%c'", *P->p);
    while (*P->p && pds__is_word_char((unsigned char)*P->p)) {
        if (n + 1 >= sizeof t->text)
            return pds__perr(P, t, PDS_ERR_LIMIT, "word longer than %d characters", (int)sizeof t->text - 1);
        t->text[n++] = *P->p;
        pds__lex_advance(P);
    }
    t->text[n] = '\0';
    {
        char c0 = t->text[0], c1 = t->text[1];
        int numeric = isdigit((unsigned char)c0) || (c0 == '.' && isdigit((unsigned char)c1)) ||
                      ((c0 == '-' || c0 == '+') && (isdigit((unsigned char)c1) || c1 == '.'));
        t->kind = numeric ? PDS__TOK_NUMBER : PDS__TOK_WORD;
    }
    return PDS_OK;
}

/* Convert a C number literal. Returns 0 and sets *out, or -1 if the text
   is not one number. NaN and infinities are refused by the callers. */
static int pds__parse_c_number(const char *text, double *out)
{
    char buf[512];
    size_t len = strlen(text);
    const char *s = buf;
    char *end;
    int neg = 0, is_float;
    if (len == 0 || len >= sizeof buf) return -1;
    memcpy(buf, text, len + 1);
    /* Hexadecimal literals contain 'f' as a digit, so only a decimal
       literal loses an f/F suffix. */
    is_float = strchr(buf, '.') || ((buf[0] != '0' || (buf[1] != 'x' && buf[1] != 'X')) &&
                                    (strchr(buf, 'e') || strchr(buf, 'E')));
    while (len > 1 && strchr("uUlL", buf[len - 1])) buf[--len] = '\0';
    if (len > 1 && strchr("fF", buf[len - 1]) && !strstr(buf, "0x") && !strstr(buf, "0X"))
        buf[--len] = '\0';
    if (*s == '+' || *s == '-') {
        neg = *s == '-';
        s++;
    }
    if (!isdigit((unsigned char)*s) && *s != '.') return -1;
    if (!is_float && s[0] == '0' && isdigit((unsigned char)s[1])) {
        /* C octal integer */
        unsigned long long v;
        errno = 0;
        v = strtoull(s, &end, 8);
        if (*end || errno) return -1;
        *out = neg ? -(double)v : (double)v;
        return 0;
    }
    errno = 0;
    *out = strtod(s, &end);
    if (*end || end == s) return -1;
    if (neg) *out = -*out;
    return 0;
}

/* --- property readers --------------------------------------------------- */
/* Each reads the value(s) after a key; P->tok is the key on entry and the
   token after the value(s) on return. */

static pds_status pds__p_number(pds__parser *P, const char *key, double *out)
{
    pds_status st = pds__lex_next(P);
    if (st) return st;
    if (P->tok.kind != PDS__TOK_NUMBER || pds__parse_c_number(P->tok.text, out) != 0)
        return pds__perr(P, &P->tok, PDS_ERR_PARSE, "expected a number after '%s', got '%s'", key, P->tok.text);
    if (!isfinite(*out))
        return pds__perr(P, &P->tok, PDS_ERR_PARSE, "'%s' must be finite, got '%s'", key, P->tok.text);
    if (fabs(*out) > PDS_MAX_COORD)
        return pds__perr(P, &P->tok, PDS_ERR_LIMIT, "'%s' value %s is beyond the limit of %g", key,
                         P->tok.text, PDS_MAX_COORD);
    return PDS_OK;
}

/* A number in [lo, hi]; what says what the number is for messages. */
static pds_status pds__p_range(pds__parser *P, const char *key, double lo, double hi, double *out)
{
    pds_status st = pds__p_number(P, key, out);
    if (st) return st;
    if (*out < lo || *out > hi)
        return pds__perr(P, &P->tok, *out > hi && hi >= 1e3 ? PDS_ERR_LIMIT : PDS_ERR_PARSE,
                         "'%s' must be between %g and %g, got %s", key, lo, hi, P->tok.text);
    return PDS_OK;
}

static pds_status pds__p_positive(pds__parser *P, const char *key, double *out)
{
    pds_status st = pds__p_number(P, key, out);
    if (st) return st;
    if (!(*out > 0.0)) return pds__perr(P, &P->tok, PDS_ERR_PARSE, "'%s' must be positive, got %s", key, P->tok.text);
    return PDS_OK;
}

static pds_status pds__p_int(pds__parser *P, const char *key, int lo, int hi, int *out)
{
    double v;
    pds_status st = pds__p_number(P, key, &v);
    if (st) return st;
    if (v != floor(v)) return pds__perr(P, &P->tok, PDS_ERR_PARSE, "'%s' must be a whole number, got %s", key, P->tok.text);
    if (v < lo) return pds__perr(P, &P->tok, PDS_ERR_PARSE, "'%s' must be at least %d, got %s", key, lo, P->tok.text);
    if (v > hi) return pds__perr(P, &P->tok, PDS_ERR_LIMIT, "'%s' must be at most %d, got %s", key, hi, P->tok.text);
    *out = (int)v;
    return PDS_OK;
}

static pds_status pds__p_vec3(pds__parser *P, const char *key, pds__v3 *out)
{
    double v[3];
    int i;
    for (i = 0; i < 3; i++) {
        pds_status st = pds__p_number(P, key, &v[i]);
        if (st) return st;
    }
    *out = pds__v(v[0], v[1], v[2]);
    return PDS_OK;
}

/* An edge vector: three numbers, not all zero, kept as given. */
static pds_status pds__p_edge(pds__parser *P, const char *key, pds__v3 *out)
{
    pds_status st = pds__p_vec3(P, key, out);
    if (st) return st;
    if (!(pds__length(*out) > 0.0))
        return pds__perr(P, &P->tok, PDS_ERR_PARSE, "'%s' must not be a zero-length vector", key);
    return PDS_OK;
}

/* A direction: an edge vector, normalised. */
static pds_status pds__p_dir(pds__parser *P, const char *key, pds__v3 *out)
{
    pds_status st = pds__p_edge(P, key, out);
    if (!st) *out = pds__normalize(*out);
    return st;
}

/* RGB: one number (grey) or three, each >= 0. */
static pds_status pds__p_rgb(pds__parser *P, const char *key, double rgb[3])
{
    pds_status st = pds__p_number(P, key, &rgb[0]);
    int i;
    if (st) return st;
    rgb[1] = rgb[2] = rgb[0];
    /* peek: two more numbers make a colour */
    {
        pds__parser save = *P;
        st = pds__lex_next(P);
        if (st) return st;
        if (P->tok.kind == PDS__TOK_NUMBER) {
            *P = save;
            if ((st = pds__p_number(P, key, &rgb[1])) || (st = pds__p_number(P, key, &rgb[2]))) return st;
        } else {
            *P = save;
        }
    }
    for (i = 0; i < 3; i++)
        if (rgb[i] < 0.0)
            return pds__perr(P, &P->tok, PDS_ERR_PARSE, "'%s' must not be negative, got %g", key, rgb[i]);
    return PDS_OK;
}

static pds_status pds__p_word(pds__parser *P, const char *key, char *out, size_t n)
{
    pds_status st = pds__lex_next(P);
    if (st) return st;
    if (P->tok.kind != PDS__TOK_WORD && P->tok.kind != PDS__TOK_STRING)
        return pds__perr(P, &P->tok, PDS_ERR_PARSE, "expected a name after '%s', got '%s'", key, P->tok.text);
    pds__strlcpy(out, P->tok.text, n);
    return PDS_OK;
}

/* Material by name; unknown names are errors at the name's position. */
static pds_status pds__p_material_ref(pds__parser *P, const char *key, int *out)
{
    char name[64];
    pds_status st = pds__p_word(P, key, name, sizeof name);
    if (st) return st;
    *out = pds__materials_find(&P->scene->materials, P->tok.text);
    if (*out < 0) return pds__perr(P, &P->tok, PDS_ERR_PARSE, "unknown material '%s'", P->tok.text);
    return PDS_OK;
}

static pds_status pds__expect_lbrace(pds__parser *P, const char *what)
{
    pds_status st = pds__lex_next(P);
    if (st) return st;
    if (P->tok.kind != PDS__TOK_LBRACE)
        return pds__perr(P, &P->tok, PDS_ERR_PARSE, "expected '{' after %s, got '%s'", what, P->tok.text);
    P->brace = P->tok;
    return PDS_OK;
}

/* Block loop: advances to the next key; returns 1 for a key, 0 at '}'. */
static int pds__block_next(pds__parser *P, const char *what, pds_status *st)
{
    *st = pds__lex_next(P);
    if (*st) return 0;
    if (P->tok.kind == PDS__TOK_RBRACE) return 0;
    P->nkeys = 0;
    if (P->tok.kind == PDS__TOK_WORD) return 1;
    if (P->tok.kind == PDS__TOK_END) /* point at the brace left open, not at the end of the file */
        *st = pds__perr(P, &P->brace, PDS_ERR_PARSE, "this '{' of %s is never closed: the file ends first", what);
    else
        *st = pds__perr(P, &P->tok, PDS_ERR_PARSE, "expected a keyword in %s, got '%s'", what, P->tok.text);
    return 0;
}

/* Is key `name`? Notes name as a key valid at this point (the readers
   test a key only where it applies, so the notes are the valid keys). */
static int pds__key_is(pds__parser *P, const char *key, const char *name)
{
    if (P->nkeys < (int)(sizeof P->keys / sizeof P->keys[0])) P->keys[P->nkeys++] = name;
    return strcmp(key, name) == 0;
}

/* Levenshtein distance of a and b (each at most 63 characters; longer
   counts as far). */
static int pds__edit_distance(const char *a, const char *b)
{
    int row[64], i, j, la = (int)strlen(a), lb = (int)strlen(b);
    if (la > 63 || lb > 63) return 64;
    for (j = 0; j <= lb; j++) row[j] = j;
    for (i = 1; i <= la; i++) {
        int diag = row[0];
        row[0] = i;
        for (j = 1; j <= lb; j++) {
            int up = row[j], best = diag + (a[i - 1] != b[j - 1]);
            if (up + 1 < best) best = up + 1;
            if (row[j - 1] + 1 < best) best = row[j - 1] + 1;
            diag = up;
            row[j] = best;
        }
    }
    return row[lb];
}

static int pds__is_shape_kind(const char *w);

static pds_status pds__unknown_key(pds__parser *P, const char *what)
{
    const char *w = P->tok.text, *closest = NULL;
    int i, best = 3;
    for (i = 0; i < P->nkeys; i++) {
        int d = pds__edit_distance(w, P->keys[i]);
        if (d < best) {
            best = d;
            closest = P->keys[i];
        }
    }
    if (closest && best <= (strlen(w) > 4 ? 2 : 1))
        return pds__perr(P, &P->tok, PDS_ERR_PARSE, "unknown keyword '%s' in %s (did you mean '%s'?)", w, what, closest);
    if (!strcmp(w, "camera") || !strcmp(w, "material") || !strcmp(w, "light") || !strcmp(w, "include") ||
        !strcmp(w, "define") || pds__is_shape_kind(w))
        /* a statement inside a block: the block's '}' is most likely missing */
        return pds__perr(P, &P->tok, PDS_ERR_PARSE, "'%s' starts a statement, but %s opened at %d:%d is not closed "
                         "(a '}' missing?)", w, what, P->brace.line, P->brace.col);
    return pds__perr(P, &P->tok, PDS_ERR_PARSE, "unknown keyword '%s' in %s", w, what);
}

/* --- camera ------------------------------------------------------------- */

static pds_status pds__parse_camera(pds__parser *P)
{
    pds_camera *c = &P->scene->camera;
    pds__token start = P->tok;
    pds_status st = pds__expect_lbrace(P, "'camera'");
    double v;
    if (st) return st;
    while (pds__block_next(P, "the camera block", &st)) {
        const char *k = P->tok.text;
        char key[64];
        pds__strlcpy(key, k, sizeof key);
        if (pds__key_is(P, key, "position")) st = pds__p_vec3(P, key, &c->position);
        else if (pds__key_is(P, key, "look_at")) st = pds__p_vec3(P, key, &c->look_at);
        else if (pds__key_is(P, key, "up")) st = pds__p_dir(P, key, &c->up);
        else if (pds__key_is(P, key, "fov")) st = pds__p_number(P, key, &v), c->fov_deg = v;
        else if (pds__key_is(P, key, "resolution")) {
            if (!(st = pds__p_int(P, key, 1, PDS_MAX_RESOLUTION, &c->width)))
                st = pds__p_int(P, key, 1, PDS_MAX_RESOLUTION, &c->height);
        } else if (pds__key_is(P, key, "spp")) st = pds__p_int(P, key, 1, PDS_MAX_SPP, &c->spp);
        else if (pds__key_is(P, key, "aperture")) {
            if (!(st = pds__p_number(P, key, &v)) && !(v >= 0.0 && v <= 1e30))
                st = pds__perr(P, &P->tok, PDS_ERR_PARSE, "'aperture' (the lens radius) must be 0 or more, got %s",
                               P->tok.text);
            c->aperture = v;
        } else if (pds__key_is(P, key, "focus_distance")) {
            if (!(st = pds__p_number(P, key, &v)) && !(v > 0.0 && v <= 1e30))
                st = pds__perr(P, &P->tok, PDS_ERR_PARSE, "'focus_distance' must be above 0, got %s", P->tok.text);
            c->focus_distance = v;
        } else if (pds__key_is(P, key, "filter")) {
            char f[32];
            if (!(st = pds__p_word(P, key, f, sizeof f))) {
                if (!strcmp(f, "box")) c->filter = PDS_FILTER_BOX;
                else if (!strcmp(f, "tent")) c->filter = PDS_FILTER_TENT;
                else st = pds__perr(P, &P->tok, PDS_ERR_PARSE, "unknown filter '%s' (box or tent)", f);
            }
        } else st = pds__unknown_key(P, "the camera block");
        if (st) return st;
        if (pds__key_is(P, key, "fov") && !(c->fov_deg > 0.0 && c->fov_deg < 180.0))
            return pds__perr(P, &P->tok, PDS_ERR_PARSE, "'fov' must be between 0 and 180 degrees, got %s", P->tok.text);
    }
    if (st) return st;
    {
        pds__v3 view = pds__sub(c->look_at, c->position);
        if (!(pds__length(view) > 0.0))
            return pds__perr(P, &start, PDS_ERR_PARSE, "camera position and look_at are the same point");
        if (!(pds__length(pds__cross(pds__normalize(view), pds__normalize(c->up))) > 1e-9))
            return pds__perr(P, &start, PDS_ERR_PARSE, "camera up is parallel to the viewing direction");
    }
    if (c->focus_distance > 0.0 && !(c->aperture > 0.0))
        pds__scene_warn(P->scene, "%s:%d:%d: 'focus_distance' without 'aperture' does nothing (a pinhole sees "
                        "everything sharp)", P->file, start.line, start.col);
    return PDS_OK;
}

/* --- materials ---------------------------------------------------------- */

/* Complex indices of refraction (n + ik) at about 650, 550 and 450 nm, for
   conductor presets. Gold and silver: Johnson & Christy 1972 (659.5,
   548.6, 450.9 nm); aluminium: the RGB values OSPRay uses. */
static const struct { const char *name; double eta[3], k[3]; } pds__metal_presets[] = {
    {"gold", {0.14, 0.43, 1.38}, {3.697, 2.455, 1.914}},
    {"silver", {0.05, 0.237, 0.226}, {4.483, 3.09, 2.28}},
    {"aluminium", {1.47, 0.984, 0.602}, {7.64, 6.55, 5.36}},
};

static pds_status pds__parse_material(pds__parser *P)
{
    pds_material m;
    pds__token name_tok, type_tok;
    char type[32], what[128];
    pds_status st;
    int have_ior = 0;
    pds__token law_tok;
    memset(&law_tok, 0, sizeof law_tok);
    if ((st = pds__p_word(P, "material", m.name, sizeof m.name))) return st;
    name_tok = P->tok;
    if (strlen(P->tok.text) >= sizeof m.name)
        return pds__perr(P, &name_tok, PDS_ERR_LIMIT, "material name longer than %d characters", (int)sizeof m.name - 1);
    if (pds__materials_find(&P->scene->materials, m.name) >= 0)
        return pds__perr(P, &name_tok, PDS_ERR_PARSE, "material '%s' is defined twice", m.name);
    {
        char keep[64];
        pds__strlcpy(keep, m.name, sizeof keep);
        m = pds__material_default(keep);
    }
    if ((st = pds__p_word(P, "the material name", type, sizeof type))) return st;
    type_tok = P->tok;
    if (!strcmp(type, "diffuse")) m.type = PDS_MAT_DIFFUSE;
    else if (!strcmp(type, "mirror")) {
        m.type = PDS_MAT_MIRROR;
        m.reflectance[0] = m.reflectance[1] = m.reflectance[2] = 1.0;
    } else if (!strcmp(type, "conductor")) {
        m.type = PDS_MAT_CONDUCTOR;
        memcpy(m.eta, pds__metal_presets[0].eta, sizeof m.eta);
        memcpy(m.k, pds__metal_presets[0].k, sizeof m.k);
    } else if (!strcmp(type, "glossy")) {
        m.type = PDS_MAT_GLOSSY;
        m.reflectance[0] = m.reflectance[1] = m.reflectance[2] = 1.0;
    } else if (!strcmp(type, "dielectric")) m.type = PDS_MAT_DIELECTRIC;
    else if (!strcmp(type, "emissive")) {
        m.type = PDS_MAT_EMISSIVE;
        m.radiance[0] = m.radiance[1] = m.radiance[2] = 1.0;
    } else
        return pds__perr(P, &type_tok, PDS_ERR_PARSE,
                         "unknown material type '%s' (diffuse, mirror, conductor, glossy, dielectric or emissive)", type);
    snprintf(what, sizeof what, "the %s material block", type);
    if ((st = pds__expect_lbrace(P, "the material type"))) return st;
    while (pds__block_next(P, what, &st)) {
        char key[64];
        pds__strlcpy(key, P->tok.text, sizeof key);
        if (m.type == PDS_MAT_DIFFUSE && pds__key_is(P, key, "albedo")) {
            if (!(st = pds__p_rgb(P, key, m.albedo)) && (m.albedo[0] > 1 || m.albedo[1] > 1 || m.albedo[2] > 1))
                st = pds__perr(P, &P->tok, PDS_ERR_PARSE, "'albedo' must be at most 1 (energy conservation)");
        } else if (m.type == PDS_MAT_DIFFUSE && pds__key_is(P, key, "tiles")) {
            /* tiles SIZE GROUT_WIDTH GROUT_ALBEDO */
            if (!(st = pds__p_positive(P, key, &m.tile_size)) && !(st = pds__p_range(P, key, 0.0, m.tile_size, &m.tile_grout)) &&
                !(st = pds__p_rgb(P, key, m.grout_albedo)) &&
                (m.grout_albedo[0] > 1 || m.grout_albedo[1] > 1 || m.grout_albedo[2] > 1 || m.grout_albedo[0] < 0 ||
                 m.grout_albedo[1] < 0 || m.grout_albedo[2] < 0))
                st = pds__perr(P, &P->tok, PDS_ERR_PARSE, "the grout albedo of 'tiles' must be between 0 and 1");
        } else if ((m.type == PDS_MAT_MIRROR || m.type == PDS_MAT_GLOSSY) && pds__key_is(P, key, "reflectance")) {
            if (!(st = pds__p_rgb(P, key, m.reflectance)) &&
                (m.reflectance[0] > 1 || m.reflectance[1] > 1 || m.reflectance[2] > 1))
                st = pds__perr(P, &P->tok, PDS_ERR_PARSE, "'reflectance' must be at most 1 (energy conservation)");
        } else if (m.type == PDS_MAT_GLOSSY && pds__key_is(P, key, "roughness")) {
            st = pds__p_range(P, key, 0.001, 1.0, &m.roughness);
        } else if ((m.type == PDS_MAT_CONDUCTOR || m.type == PDS_MAT_GLOSSY) && pds__key_is(P, key, "eta")) {
            st = pds__p_rgb(P, key, m.eta);
            m.fresnel = 1;
        } else if ((m.type == PDS_MAT_CONDUCTOR || m.type == PDS_MAT_GLOSSY) && pds__key_is(P, key, "k")) {
            st = pds__p_rgb(P, key, m.k);
            m.fresnel = 1;
        } else if ((m.type == PDS_MAT_CONDUCTOR || m.type == PDS_MAT_GLOSSY) && pds__key_is(P, key, "preset")) {
            m.fresnel = 1;
            char pre[32];
            size_t i, n = sizeof pds__metal_presets / sizeof pds__metal_presets[0];
            if (!(st = pds__p_word(P, key, pre, sizeof pre))) {
                for (i = 0; i < n && strcmp(pre, pds__metal_presets[i].name); i++) {}
                if (i == n) st = pds__perr(P, &P->tok, PDS_ERR_PARSE, "unknown conductor preset '%s' (gold, silver or aluminium)", pre);
                else {
                    memcpy(m.eta, pds__metal_presets[i].eta, sizeof m.eta);
                    memcpy(m.k, pds__metal_presets[i].k, sizeof m.k);
                }
            }
        } else if (m.type == PDS_MAT_DIELECTRIC && pds__key_is(P, key, "ior")) {
            st = pds__p_range(P, key, 1.0, 10.0, &m.ior);
            have_ior = 1;
        } else if (m.type == PDS_MAT_DIELECTRIC && pds__key_is(P, key, "absorption")) st = pds__p_rgb(P, key, m.absorption);
        else if (m.type == PDS_MAT_DIELECTRIC && pds__key_is(P, key, "outside_ior")) st = pds__p_range(P, key, 1.0, 10.0, &m.outside_ior);
        else if (m.type == PDS_MAT_DIELECTRIC && pds__key_is(P, key, "outside_absorption")) st = pds__p_rgb(P, key, m.outside_absorption);
        else if (m.type == PDS_MAT_DIELECTRIC && pds__key_is(P, key, "cauchy")) {
            law_tok = P->tok;
            m.dispersion = PDS_DISPERSION_CAUCHY;
            if (!(st = pds__p_range(P, key, 1.0, 10.0, &m.dispersion_coef[0])))
                st = pds__p_range(P, key, 0.0, 1.0, &m.dispersion_coef[1]);
            /* n at 587.6 nm stands in for ior when none is given */
            if (!st && !have_ior) m.ior = m.dispersion_coef[0] + m.dispersion_coef[1] / (0.5876 * 0.5876);
        } else if (m.type == PDS_MAT_DIELECTRIC && pds__key_is(P, key, "sellmeier")) {
            int i;
            law_tok = P->tok;
            m.dispersion = PDS_DISPERSION_SELLMEIER;
            for (i = 0; i < 6 && !st; i++) st = pds__p_range(P, key, 0.0, 1e6, &m.dispersion_coef[i]);
            if (!st && !have_ior) {
                double l2 = 0.5876 * 0.5876, n2 = 1.0;
                for (i = 0; i < 3; i++) n2 += m.dispersion_coef[i] * l2 / (l2 - m.dispersion_coef[3 + i]);
                if (n2 > 1.0) m.ior = sqrt(n2);
            }
        } else if (m.type == PDS_MAT_EMISSIVE && pds__key_is(P, key, "radiance")) st = pds__p_rgb(P, key, m.radiance);
        else st = pds__unknown_key(P, what);
        if (st) return st;
    }
    if (st) return st;
    if (m.dispersion != PDS_DISPERSION_NONE) {
        /* a law must give an index in the ior's own range over the whole
           visible spectrum (a Sellmeier pole there gives n = 674, or NaN) */
        int nm;
        for (nm = 360; nm <= 830; nm++) {
            double n = pds__dispersion_law(&m, nm);
            if (!(n >= 1.0 && n <= 10.0))
                return pds__perr(P, &law_tok, PDS_ERR_PARSE,
                                 "this %s law gives n = %g at %d nm: it must stay within 1 to 10 from 360 to 830 nm",
                                 m.dispersion == PDS_DISPERSION_CAUCHY ? "Cauchy" : "Sellmeier", n, nm);
        }
    }
    if (pds__materials_add(&P->scene->materials, &m) < 0)
        return pds__perr(P, &name_tok, PDS_ERR_LIMIT, "more than %d materials", PDS_MAX_MATERIALS);
    return PDS_OK;
}

/* --- lights ------------------------------------------------------------- */

static pds_status pds__parse_light(pds__parser *P)
{
    pds_light l;
    char type[32], what[96];
    pds__token type_tok;
    pds_status st;
    int have_power = 0, have_radiance = 0, have_emitter = 0, have_dir = 0;
    memset(&l, 0, sizeof l);
    l.material = -1;
    if ((st = pds__p_word(P, "light", type, sizeof type))) return st;
    type_tok = P->tok;
    if (!strcmp(type, "point")) l.type = PDS_LIGHT_POINT;
    else if (!strcmp(type, "spot")) l.type = PDS_LIGHT_SPOT;
    else if (!strcmp(type, "directional")) l.type = PDS_LIGHT_DIRECTIONAL;
    else if (!strcmp(type, "disk")) l.type = PDS_LIGHT_DISK;
    else if (!strcmp(type, "quad")) l.type = PDS_LIGHT_QUAD;
    else if (!strcmp(type, "environment")) l.type = PDS_LIGHT_ENVIRONMENT;
    else
        return pds__perr(P, &type_tok, PDS_ERR_PARSE,
                         "unknown light type '%s' (point, spot, directional, disk, quad or environment)", type);
#ifdef PDS_NO_ENV
    if (l.type == PDS_LIGHT_ENVIRONMENT)
        return pds__perr(P, &type_tok, PDS_ERR_PARSE, "this build leaves the environment light out (PDS_NO_ENV)");
#endif
    if (l.type == PDS_LIGHT_ENVIRONMENT) {
        size_t i;
        for (i = 0; i < P->scene->nlights; i++)
            if (P->scene->lights[i].type == PDS_LIGHT_ENVIRONMENT)
                return pds__perr(P, &type_tok, PDS_ERR_PARSE,
                                 "a second environment light (a scene has one environment: add its parts in "
                                 "one block)");
    }
    /* defaults */
    l.direction = pds__v(0.0, -1.0, 0.0);
    l.cone_inner_deg = 20.0;
    l.cone_outer_deg = 30.0;
    l.radius = 1.0;
    l.edge1 = pds__v(1.0, 0.0, 0.0);
    l.edge2 = pds__v(0.0, 0.0, 1.0);
    l.up = pds__v(0.0, 1.0, 0.0);
    l.sun_direction = pds__v(0.0, 1.0, 0.0);
    l.sun_radius_deg = 0.265; /* the sun seen from the earth */
    snprintf(what, sizeof what, "the %s light block", type);
    if ((st = pds__expect_lbrace(P, "the light type"))) return st;
    while (pds__block_next(P, what, &st)) {
        char key[64];
        int T = l.type;
        pds__strlcpy(key, P->tok.text, sizeof key);
        if ((T == PDS_LIGHT_POINT || T == PDS_LIGHT_SPOT) && pds__key_is(P, key, "position")) st = pds__p_vec3(P, key, &l.position);
        else if ((T == PDS_LIGHT_DISK || T == PDS_LIGHT_QUAD) && pds__key_is(P, key, "center")) st = pds__p_vec3(P, key, &l.position);
        else if ((T == PDS_LIGHT_SPOT || T == PDS_LIGHT_DIRECTIONAL) && pds__key_is(P, key, "direction")) {
            st = pds__p_dir(P, key, &l.direction);
            have_dir = 1;
        } else if (T == PDS_LIGHT_SPOT && pds__key_is(P, key, "look_at")) {
            pds__v3 at;
            if (!(st = pds__p_vec3(P, key, &at))) {
                if (!(pds__length(pds__sub(at, l.position)) > 0.0))
                    st = pds__perr(P, &P->tok, PDS_ERR_PARSE, "spot light 'look_at' equals its position (give 'position' first)");
                else l.direction = pds__normalize(pds__sub(at, l.position));
            }
            have_dir = 1;
        } else if (T == PDS_LIGHT_SPOT && pds__key_is(P, key, "cone")) {
            if (!(st = pds__p_range(P, key, 0.0, 90.0, &l.cone_inner_deg)))
                st = pds__p_range(P, key, 0.0, 90.0, &l.cone_outer_deg);
            if (!st && !(l.cone_outer_deg > 0.0 && l.cone_inner_deg <= l.cone_outer_deg))
                st = pds__perr(P, &P->tok, PDS_ERR_PARSE, "'cone' needs 0 <= inner <= outer and outer > 0 (degrees)");
        } else if (T == PDS_LIGHT_DISK && pds__key_is(P, key, "normal")) st = pds__p_dir(P, key, &l.direction);
        else if (T == PDS_LIGHT_DISK && pds__key_is(P, key, "radius")) st = pds__p_positive(P, key, &l.radius);
        else if (T == PDS_LIGHT_QUAD && pds__key_is(P, key, "edge1")) st = pds__p_edge(P, key, &l.edge1);
        else if (T == PDS_LIGHT_QUAD && pds__key_is(P, key, "edge2")) st = pds__p_edge(P, key, &l.edge2);
        else if (T == PDS_LIGHT_DIRECTIONAL && pds__key_is(P, key, "irradiance")) {
            st = pds__p_rgb(P, key, l.irradiance);
            have_power = 1;
        } else if (T == PDS_LIGHT_DIRECTIONAL && pds__key_is(P, key, "disk")) {
            l.emitter_shape = 0;
            if (!(st = pds__p_vec3(P, key, &l.position))) st = pds__p_positive(P, key, &l.radius);
            have_emitter = 1;
        } else if (T == PDS_LIGHT_DIRECTIONAL && pds__key_is(P, key, "rect")) {
            l.emitter_shape = 1;
            if (!(st = pds__p_vec3(P, key, &l.position)) && !(st = pds__p_edge(P, key, &l.edge1)))
                st = pds__p_edge(P, key, &l.edge2);
            have_emitter = 1;
        } else if (T != PDS_LIGHT_DIRECTIONAL && pds__key_is(P, key, "power")) {
            st = pds__p_rgb(P, key, l.power);
            have_power = 1;
        } else if ((T == PDS_LIGHT_DISK || T == PDS_LIGHT_QUAD) && pds__key_is(P, key, "radiance")) {
            st = pds__p_rgb(P, key, l.radiance);
            have_radiance = 1;
        } else if (T == PDS_LIGHT_ENVIRONMENT && pds__key_is(P, key, "radiance")) st = pds__p_rgb(P, key, l.radiance);
        else if (T == PDS_LIGHT_ENVIRONMENT && pds__key_is(P, key, "sky")) st = pds__p_rgb(P, key, l.sky);
        else if (T == PDS_LIGHT_ENVIRONMENT && pds__key_is(P, key, "ground")) st = pds__p_rgb(P, key, l.ground);
        else if (T == PDS_LIGHT_ENVIRONMENT && pds__key_is(P, key, "up")) st = pds__p_dir(P, key, &l.up);
        else if (T == PDS_LIGHT_ENVIRONMENT && pds__key_is(P, key, "sun")) st = pds__p_rgb(P, key, l.sun_irradiance);
        else if (T == PDS_LIGHT_ENVIRONMENT && pds__key_is(P, key, "sun_direction"))
            st = pds__p_dir(P, key, &l.sun_direction);
        else if (T == PDS_LIGHT_ENVIRONMENT && pds__key_is(P, key, "sun_radius")) {
            st = pds__p_range(P, key, 0.0, 45.0, &l.sun_radius_deg);
            if (!st && !(l.sun_radius_deg > 0.0))
                st = pds__perr(P, &P->tok, PDS_ERR_PARSE, "'sun_radius' must be above 0 degrees (at most 45)");
        } else st = pds__unknown_key(P, what);
        if (st) return st;
    }
    if (st) return st;
    if (l.type == PDS_LIGHT_ENVIRONMENT) {
        /* its size and power come with the scene's bounds (pds__scene_finish) */
        int c, any = 0;
        for (c = 0; c < 3; c++)
            any |= l.radiance[c] != 0.0 || l.sky[c] != 0.0 || l.ground[c] != 0.0 || l.sun_irradiance[c] != 0.0;
        if (!any)
            return pds__perr(P, &type_tok, PDS_ERR_PARSE,
                             "environment light needs 'radiance', 'sky', 'ground' or 'sun' (all are 0 by default)");
        {
            double cos_a, omega, ls[3];
            pds__env_sun(&l, &cos_a, &omega, ls);
            for (c = 0; c < 3; c++)
                if (l.sun_irradiance[c] != 0.0 && (!isfinite(ls[c]) || !(omega > 0.0)))
                    return pds__perr(P, &type_tok, PDS_ERR_PARSE,
                                     "the sun's disk (sun_radius %g degrees) is too small: its radiance "
                                     "E / (pi sin^2 radius) is out of range", l.sun_radius_deg);
        }
        if (pds__scene_add_light(P->scene, &l) < 0)
            return pds__perr(P, &type_tok, PDS_ERR_LIMIT, "more than %d lights", PDS_MAX_LIGHTS);
        return PDS_OK;
    }
    if (have_power && have_radiance)
        return pds__perr(P, &type_tok, PDS_ERR_PARSE, "give either 'power' or 'radiance' for a %s light, not both", type);
    if (!have_power && !have_radiance)
        return pds__perr(P, &type_tok, PDS_ERR_PARSE, "%s light needs '%s'", type,
                         l.type == PDS_LIGHT_DIRECTIONAL ? "irradiance" : "power");
    if (l.type == PDS_LIGHT_DIRECTIONAL && !have_emitter)
        return pds__perr(P, &type_tok, PDS_ERR_PARSE,
                         "directional light needs an emitter: 'disk CENTER RADIUS' or 'rect CENTER EDGE1 EDGE2'");
    if (l.type == PDS_LIGHT_SPOT && !have_dir)
        return pds__perr(P, &type_tok, PDS_ERR_PARSE, "spot light needs 'direction' or 'look_at'");
    /* Emitting areas; one-sided Lambertian emitters have P = pi L A. */
    if (l.type == PDS_LIGHT_DISK) l.area = PDS__PI * l.radius * l.radius;
    if (l.type == PDS_LIGHT_QUAD) {
        pds__v3 n = pds__cross(l.edge1, l.edge2);
        l.area = pds__length(n);
        if (!(l.area > 0.0)) return pds__perr(P, &type_tok, PDS_ERR_PARSE, "quad light edges are parallel");
        l.direction = pds__normalize(n);
    }
    if (l.type == PDS_LIGHT_DIRECTIONAL) {
        /* cross-section of the beam: the emitter projected along direction */
        if (l.emitter_shape == 0) l.area = PDS__PI * l.radius * l.radius;
        else l.area = fabs(pds__dot(pds__cross(l.edge1, l.edge2), l.direction));
        if (!(l.area > 0.0))
            return pds__perr(P, &type_tok, PDS_ERR_PARSE, "directional light's rectangle has no area across the beam");
    }
    if (l.type == PDS_LIGHT_DISK || l.type == PDS_LIGHT_QUAD) {
        int c;
        for (c = 0; c < 3; c++) {
            if (have_radiance) l.power[c] = PDS__PI * l.radiance[c] * l.area;
            else l.radiance[c] = l.power[c] / (PDS__PI * l.area);
        }
    }
    if (l.type == PDS_LIGHT_DIRECTIONAL) {
        int c;
        for (c = 0; c < 3; c++) l.power[c] = l.irradiance[c] * l.area;
    }
    {
        /* a size so small that its area or radiance leaves the double
           range would render black (or infinite) without a word */
        int c, finite = 1;
        double total = 0.0;
        for (c = 0; c < 3; c++) {
            finite &= isfinite(l.power[c]) && isfinite(l.radiance[c]);
            total += l.power[c];
        }
        if (!finite || (l.type != PDS_LIGHT_POINT && l.type != PDS_LIGHT_SPOT && !(l.area > 0.0)))
            return pds__perr(P, &type_tok, PDS_ERR_PARSE,
                             "this %s light is too small: its area (%g) or radiance is out of range (a point light "
                             "stands for a tiny one)", type, l.area);
        if (!(total > 0.0))
            pds__scene_warn(P->scene, "%s:%d:%d: this %s light emits nothing (its power is 0)", P->file, type_tok.line,
                            type_tok.col, type);
    }
    if (pds__scene_add_light(P->scene, &l) < 0)
        return pds__perr(P, &type_tok, PDS_ERR_LIMIT, "more than %d lights", PDS_MAX_LIGHTS);
    return PDS_OK;
}

/* --- shapes ------------------------------------------------------------- */

/* Everything a shape block can say; each generator reads its part. */
typedef struct pds__shape_desc {
    int material;
    pds__xform xf;
    double radius, inner_radius, height, major, minor, sweep_deg, crease_deg;
    pds__v3 size;
    int segments, rings, res_x, res_z, closed;
    double *profile;        /* revolve: r y pairs */
    int nprofile;
    pds__wave waves[16];
    int nwaves;
    char *override_names;   /* mesh: 64 bytes per entry */
    int *override_mats;
    int noverrides;
    char file[512];         /* mesh: resolved path */
    int material_given;
} pds__shape_desc;

/* Rotation by angle_deg about axis (Rodrigues), as a transform. */
static pds__xform pds__xform_rotate(double angle_deg, pds__v3 axis)
{
    pds__xform r = pds__xform_identity();
    double a = angle_deg * PDS__PI / 180.0, c = cos(a), s = sin(a), t = 1.0 - c;
    pds__v3 u = pds__normalize(axis);
    r.m[0][0] = t * u.x * u.x + c;
    r.m[0][1] = t * u.x * u.y - s * u.z;
    r.m[0][2] = t * u.x * u.z + s * u.y;
    r.m[1][0] = t * u.x * u.y + s * u.z;
    r.m[1][1] = t * u.y * u.y + c;
    r.m[1][2] = t * u.y * u.z - s * u.x;
    r.m[2][0] = t * u.x * u.z - s * u.y;
    r.m[2][1] = t * u.y * u.z + s * u.x;
    r.m[2][2] = t * u.z * u.z + c;
    return r;
}

/* Transform keys shared by all shapes: each applies after the ones
   written before it. Returns 1 if the key was a transform. */
static int pds__parse_transform_key(pds__parser *P, const char *key, pds__xform *xf, pds_status *st)
{
    pds__xform op = pds__xform_identity();
    if (pds__key_is(P, key, "translate")) {
        pds__v3 t;
        if ((*st = pds__p_vec3(P, key, &t))) return 1;
        op.m[0][3] = t.x;
        op.m[1][3] = t.y;
        op.m[2][3] = t.z;
    } else if (pds__key_is(P, key, "rotate")) {
        double angle;
        pds__v3 axis;
        if ((*st = pds__p_number(P, key, &angle)) || (*st = pds__p_dir(P, key, &axis))) return 1;
        op = pds__xform_rotate(angle, axis);
    } else if (pds__key_is(P, key, "scale")) {
        double s[3];
        int i;
        if ((*st = pds__p_rgb(P, key, s))) return 1; /* one or three numbers */
        for (i = 0; i < 3; i++) {
            if (!(s[i] > 0.0)) {
                *st = pds__perr(P, &P->tok, PDS_ERR_PARSE, "'scale' factors must be positive (use 'rotate' to turn a shape over)");
                return 1;
            }
            op.m[i][i] = s[i];
        }
    } else {
        return 0;
    }
    *xf = pds__xform_mul(&op, xf);
    *st = PDS_OK;
    return 1;
}

static void pds__shape_desc_free(pds__shape_desc *d)
{
    free(d->profile);
    free(d->override_names);
    free(d->override_mats);
}

/* Parse the block of a shape statement (P->tok is the shape keyword). */
static pds_status pds__parse_shape_block(pds__parser *P, const char *kind, pds__shape_desc *d)
{
    char what[96];
    pds_status st;
    size_t cap_prof = 0, cap_names = 0, cap_mats = 0;
    snprintf(what, sizeof what, "the %s block", kind);
    if ((st = pds__expect_lbrace(P, kind[0] == 'm' ? "the mesh file name" : what + 4))) return st;
    while (pds__block_next(P, what, &st)) {
        char key[64];
        int sweep = !strcmp(kind, "cylinder") || !strcmp(kind, "torus") || !strcmp(kind, "revolve");
        pds__strlcpy(key, P->tok.text, sizeof key);
        if (pds__parse_transform_key(P, key, &d->xf, &st)) {
        } else if (pds__key_is(P, key, "material")) {
            st = pds__p_material_ref(P, key, &d->material);
            d->material_given = 1;
        } else if (!strcmp(kind, "mesh") && pds__key_is(P, key, "replace")) {
            char from[64];
            int to;
            if ((st = pds__p_word(P, key, from, sizeof from)) || (st = pds__p_material_ref(P, key, &to))) break;
            if (pds__grow((void **)&d->override_names, &cap_names, 64 * (size_t)(d->noverrides + 1), 1) ||
                pds__grow((void **)&d->override_mats, &cap_mats, (size_t)d->noverrides + 1, sizeof(int)))
                return pds__nomem(P->err);
            pds__strlcpy(d->override_names + 64 * d->noverrides, from, 64);
            d->override_mats[d->noverrides++] = to;
        } else if ((!strcmp(kind, "sphere") || !strcmp(kind, "disk") || !strcmp(kind, "cylinder")) && pds__key_is(P, key, "radius"))
            st = pds__p_positive(P, key, &d->radius);
        else if ((!strcmp(kind, "disk") || !strcmp(kind, "cylinder")) && pds__key_is(P, key, "inner_radius"))
            st = pds__p_range(P, key, 0.0, PDS_MAX_COORD, &d->inner_radius);
        else if (!strcmp(kind, "cylinder") && pds__key_is(P, key, "height")) st = pds__p_positive(P, key, &d->height);
        else if (!strcmp(kind, "cylinder") && (pds__key_is(P, key, "open") || pds__key_is(P, key, "closed")))
            d->closed = key[0] == 'c';
        else if (!strcmp(kind, "torus") && pds__key_is(P, key, "major")) st = pds__p_positive(P, key, &d->major);
        else if (!strcmp(kind, "torus") && pds__key_is(P, key, "minor")) st = pds__p_positive(P, key, &d->minor);
        else if (sweep && pds__key_is(P, key, "sweep")) {
            st = pds__p_range(P, key, 0.0, 360.0, &d->sweep_deg);
            if (!st && !(d->sweep_deg > 0.0)) st = pds__perr(P, &P->tok, PDS_ERR_PARSE, "'sweep' must be positive");
        } else if (!strcmp(kind, "revolve") && pds__key_is(P, key, "crease")) st = pds__p_range(P, key, 0.0, 180.0, &d->crease_deg);
        else if (!strcmp(kind, "revolve") && pds__key_is(P, key, "profile")) {
            /* pairs of numbers until the next keyword */
            pds__token key_tok = P->tok;
            d->nprofile = 0;
            for (;;) {
                pds__parser save = *P;
                if ((st = pds__lex_next(P))) return st;
                if (P->tok.kind != PDS__TOK_NUMBER) {
                    *P = save;
                    break;
                }
                *P = save;
                if (d->nprofile >= PDS_MAX_PROFILE_POINTS)
                    return pds__perr(P, &key_tok, PDS_ERR_LIMIT, "profile has more than %d points", PDS_MAX_PROFILE_POINTS);
                if (pds__grow((void **)&d->profile, &cap_prof, 2 * (size_t)(d->nprofile + 1), sizeof(double)))
                    return pds__nomem(P->err);
                if ((st = pds__p_range(P, "profile", 0.0, PDS_MAX_COORD, &d->profile[2 * d->nprofile]))) return st;
                if ((st = pds__p_number(P, "profile", &d->profile[2 * d->nprofile + 1]))) return st;
                d->nprofile++;
            }
            if (d->nprofile < 2)
                return pds__perr(P, &key_tok, PDS_ERR_PARSE, "'profile' needs at least two points (r y pairs)");
        } else if (!strcmp(kind, "box") && pds__key_is(P, key, "size")) {
            double s[3];
            if (!(st = pds__p_rgb(P, key, s))) {
                if (!(s[0] > 0.0 && s[1] > 0.0 && s[2] > 0.0))
                    st = pds__perr(P, &P->tok, PDS_ERR_PARSE, "box 'size' must be positive");
                d->size = pds__v(s[0], s[1], s[2]);
            }
        } else if (!strcmp(kind, "quad") && pds__key_is(P, key, "size")) {
            if (!(st = pds__p_positive(P, key, &d->size.x))) st = pds__p_positive(P, key, &d->size.z);
        } else if (!strcmp(kind, "heightfield") && pds__key_is(P, key, "size")) {
            if (!(st = pds__p_positive(P, key, &d->size.x))) st = pds__p_positive(P, key, &d->size.z);
        } else if (!strcmp(kind, "heightfield") && pds__key_is(P, key, "resolution")) {
            if (!(st = pds__p_int(P, key, 1, PDS_MAX_TESSELLATION, &d->res_x)))
                st = pds__p_int(P, key, 1, PDS_MAX_TESSELLATION, &d->res_z);
        } else if (!strcmp(kind, "heightfield") && pds__key_is(P, key, "wave")) {
            /* wave AMPLITUDE WAVELENGTH DX DZ [PHASE_DEG] */
            pds__wave *w = &d->waves[d->nwaves];
            pds__token key_tok = P->tok;
            double dx, dz, len;
            if (d->nwaves >= 16) return pds__perr(P, &key_tok, PDS_ERR_LIMIT, "more than 16 waves");
            if ((st = pds__p_number(P, key, &w->amplitude)) || (st = pds__p_positive(P, key, &w->wavelength)) ||
                (st = pds__p_number(P, key, &dx)) || (st = pds__p_number(P, key, &dz)))
                return st;
            len = sqrt(dx * dx + dz * dz);
            if (!(len > 0.0)) return pds__perr(P, &P->tok, PDS_ERR_PARSE, "wave direction must not be zero");
            w->dx = dx / len;
            w->dz = dz / len;
            w->phase = 0.0;
            {
                pds__parser save = *P;
                if ((st = pds__lex_next(P))) return st;
                if (P->tok.kind == PDS__TOK_NUMBER) {
                    *P = save;
                    if ((st = pds__p_number(P, key, &w->phase))) return st;
                    w->phase *= PDS__PI / 180.0;
                } else {
                    *P = save;
                }
            }
            d->nwaves++;
        } else if (strcmp(kind, "mesh") && strcmp(kind, "box") && strcmp(kind, "heightfield") && pds__key_is(P, key, "segments"))
            st = pds__p_int(P, key, !strcmp(kind, "quad") ? 1 : 3, PDS_MAX_TESSELLATION, &d->segments);
        else if ((!strcmp(kind, "sphere") || !strcmp(kind, "torus")) && pds__key_is(P, key, "rings"))
            st = pds__p_int(P, key, !strcmp(kind, "sphere") ? 2 : 3, PDS_MAX_TESSELLATION, &d->rings);
        else
            st = pds__unknown_key(P, what);
        if (st) return st;
    }
    return st;
}

/* Defaults for a shape of the given kind (tessellation chosen so the
   default looks smooth at 512x512). */
static void pds__shape_desc_init(pds__shape_desc *d, int material)
{
    memset(d, 0, sizeof *d);
    d->material = material;
    d->xf = pds__xform_identity();
    d->radius = 1.0;
    d->height = 1.0;
    d->major = 1.0;
    d->minor = 0.25;
    d->sweep_deg = 360.0;
    d->crease_deg = 30.0;
    d->size = pds__v(1.0, 1.0, 1.0);
    d->segments = 64;
    d->rings = 32;
    d->res_x = d->res_z = 128;
    d->closed = 1;
}

/* Generate (or load) the described shape into the scene's mesh. at is the
   statement's first token, for messages. */
static pds_status pds__shape_emit(pds__parser *P, const char *kind, pds__shape_desc *d, const pds__token *at)
{
    pds_scene *s = P->scene;
    pds__emitter e;
    double sweep = d->sweep_deg * PDS__PI / 180.0;
    int r = 0;
    long beyond = s->mesh.beyond_limit;
    e.mesh = &s->mesh;
    e.xf = &d->xf;
    e.material = d->material;
    if (!strcmp(kind, "mesh")) {
        pds__obj_options o;
        pds__obj_stats stats;
        const char **names = NULL;
        int i;
        pds_status st;
        memset(&o, 0, sizeof o);
        o.xform = &d->xf;
        o.material_override = d->material_given ? d->material : -1;
        o.default_material = d->material;
        if (d->noverrides) {
            names = (const char **)malloc(sizeof *names * (size_t)d->noverrides);
            if (!names) return pds__nomem(P->err);
            for (i = 0; i < d->noverrides; i++) names[i] = d->override_names + 64 * i;
        }
        o.override_names = names;
        o.override_materials = d->override_mats;
        o.override_count = d->noverrides;
        st = pds__obj_load(d->file, &s->mesh, &s->materials, &o, &stats, P->err);
        free((void *)names);
        if (st) return st;
        if (s->mesh.beyond_limit > beyond)
            return pds__perr(P, at, PDS_ERR_LIMIT, "%ld vertices of '%s' lie beyond +-%g once transformed",
                             s->mesh.beyond_limit - beyond, d->file, PDS_MAX_COORD);
        pds__scene_warn_obj(s, d->file, &stats);
        return PDS_OK;
    }
    if (!strcmp(kind, "sphere")) r = pds__gen_sphere(&e, d->radius, d->segments, d->rings);
    else if (!strcmp(kind, "disk")) {
        if (d->inner_radius >= d->radius)
            return pds__perr(P, at, PDS_ERR_PARSE, "disk 'inner_radius' must be smaller than 'radius'");
        r = pds__gen_annulus(&e, d->inner_radius, d->radius, 0.0, 1.0, d->segments, 2.0 * PDS__PI);
    } else if (!strcmp(kind, "quad")) r = pds__gen_quad(&e, d->size.x, d->size.z, d->segments == 64 ? 1 : d->segments);
    else if (!strcmp(kind, "box")) r = pds__gen_box(&e, d->size);
    else if (!strcmp(kind, "cylinder")) {
        if (d->inner_radius >= d->radius)
            return pds__perr(P, at, PDS_ERR_PARSE, "cylinder 'inner_radius' must be smaller than 'radius'");
        r = pds__gen_cylinder(&e, d->radius, d->inner_radius, d->height, d->segments, d->closed, sweep);
    } else if (!strcmp(kind, "torus")) {
        if (d->minor >= d->major)
            return pds__perr(P, at, PDS_ERR_PARSE, "torus 'minor' must be smaller than 'major'");
        r = pds__gen_torus(&e, d->major, d->minor, d->segments, d->rings, sweep);
    } else if (!strcmp(kind, "revolve")) {
        if (d->nprofile < 2) return pds__perr(P, at, PDS_ERR_PARSE, "revolve needs a 'profile' of r y pairs");
        r = pds__gen_revolve(&e, d->profile, d->nprofile, d->segments, sweep, d->crease_deg);
    } else if (!strcmp(kind, "heightfield")) {
        if (d->nwaves == 0) return pds__perr(P, at, PDS_ERR_PARSE, "heightfield needs at least one 'wave'");
        r = pds__gen_heightfield(&e, d->size.x, d->size.z, d->res_x, d->res_z, d->waves, d->nwaves);
    }
    if (r < 0) {
        if (s->mesh.ntris >= (size_t)PDS_MAX_TRIANGLES)
            return pds__perr(P, at, PDS_ERR_LIMIT, "scene has more than %d triangles", PDS_MAX_TRIANGLES);
        return pds__nomem(P->err);
    }
    if (s->mesh.beyond_limit > beyond)
        return pds__perr(P, at, PDS_ERR_LIMIT, "%ld vertices of this %s lie beyond +-%g once transformed",
                         s->mesh.beyond_limit - beyond, kind, PDS_MAX_COORD);
    return PDS_OK;
}

static int pds__is_shape_kind(const char *w)
{
    static const char *const kinds[] = {"mesh", "sphere", "disk", "quad", "box", "cylinder", "torus", "revolve", "heightfield"};
    size_t i;
    for (i = 0; i < sizeof kinds / sizeof kinds[0]; i++)
        if (!strcmp(w, kinds[i])) return 1;
    return 0;
}

static pds_status pds__parse_shape(pds__parser *P)
{
    pds__shape_desc d;
    pds__token at = P->tok;
    char kind[32];
    pds_status st;
    long tris_before = (long)P->scene->mesh.ntris;
    pds__strlcpy(kind, P->tok.text, sizeof kind);
    pds__shape_desc_init(&d, -1);
    if (!strcmp(kind, "mesh")) {
        int e;
        if ((st = pds__lex_next(P))) return st;
        if (P->tok.kind != PDS__TOK_STRING && P->tok.kind != PDS__TOK_WORD)
            return pds__perr(P, &P->tok, PDS_ERR_PARSE, "expected a file name after 'mesh', got '%s'", P->tok.text);
        if (pds__join_path(P->dir, P->tok.text, d.file, sizeof d.file))
            return pds__perr(P, &P->tok, PDS_ERR_LIMIT, "mesh path too long");
        e = pds__input_file_check(d.file);
        if (e) return pds__perr(P, &P->tok, PDS_ERR_IO, "cannot read mesh '%s': %s", d.file, pds__input_file_problem(e));
    }
    st = pds__parse_shape_block(P, kind, &d);
    if (!st && d.material < 0) {
        d.material = pds__scene_default_material(P->scene);
        if (d.material < 0) st = pds__nomem(P->err);
    }
    if (!st) st = pds__shape_emit(P, kind, &d, &at);
    pds__shape_desc_free(&d);
    if (st) return st;
    P->scene->shapes++;
    if ((long)P->scene->mesh.ntris == tris_before)
        pds__scene_warn(P->scene, "%s:%d:%d: %s produced no triangles", P->file, at.line, at.col, kind);
    return PDS_OK;
}

/* Triangles of emissive materials become mesh lights: each run of
   consecutive triangles sharing one emissive material is one light. Power
   of a one-sided Lambertian emitter: P = pi L A. */
static pds_status pds__scene_collect_mesh_lights(pds_scene *s, pds_error *err)
{
    size_t t = 0;
    while (t < s->mesh.ntris) {
        int m = s->mesh.mat[t];
        size_t end = t;
        pds_light l;
        int c;
        if (s->materials.items[m].type != PDS_MAT_EMISSIVE) {
            t++;
            continue;
        }
        memset(&l, 0, sizeof l);
        l.type = PDS_LIGHT_MESH;
        l.material = m;
        l.first_triangle = (int)t;
        while (end < s->mesh.ntris && s->mesh.mat[end] == m) {
            const int *v = &s->mesh.idx[3 * end];
            l.area += 0.5 * pds__mesh_tri_area2(&s->mesh, v[0], v[1], v[2]);
            end++;
        }
        l.triangle_count = (int)(end - t);
        for (c = 0; c < 3; c++) {
            l.radiance[c] = s->materials.items[m].radiance[c];
            l.power[c] = PDS__PI * l.radiance[c] * l.area;
        }
        if (pds__scene_add_light(s, &l) < 0)
            return pds__fail(err, PDS_ERR_LIMIT, s->path, 0, 0, "more than %d lights", PDS_MAX_LIGHTS);
        t = end;
    }
    return PDS_OK;
}

/* Bounds, mesh lights, BVH: everything after parsing. */
static pds_status pds__scene_finish(pds_scene *s, pds_error *err)
{
    size_t i;
    double t0;
    pds_status st;
    s->bounds_min = pds__v(0, 0, 0);
    s->bounds_max = pds__v(0, 0, 0);
    for (i = 0; i < s->mesh.nverts; i++) {
        pds__v3 p = pds__mesh_pos(&s->mesh, (long)i);
        s->bounds_min = i ? pds__vmin(s->bounds_min, p) : p;
        s->bounds_max = i ? pds__vmax(s->bounds_max, p) : p;
    }
    if ((st = pds__scene_collect_mesh_lights(s, err))) return st;
    for (i = 0; i < s->nlights; i++) {
        /* the environment surrounds the scene's bounding sphere (>>lights) */
        pds_light *l = &s->lights[i];
        double total[3], r;
        int c;
        if (l->type != PDS_LIGHT_ENVIRONMENT) continue;
        l->position = pds__scale(pds__add(s->bounds_min, s->bounds_max), 0.5);
        r = 0.5 * pds__length(pds__sub(s->bounds_max, s->bounds_min));
        l->radius = r > 0.0 ? r * 1.001 : 1.0;
        l->area = PDS__PI * l->radius * l->radius;
        pds__env_parts(l, total, NULL);
        for (c = 0; c < 3; c++) l->power[c] = l->area * total[c];
        s->env_index1 = (int)i + 1;
    }
    if ((st = pds__lights_prepare(&s->light_table, s->lights, s->nlights, &s->mesh, err))) return st;
    {
        /* the BVH build holds about 112 bytes a triangle on top of the mesh
           (measured: a 2.1M-triangle sphere peaks at 139 bytes a triangle
           in all); refuse before starting what cannot fit */
        double need = (double)s->mesh.ntris * 112.0 + (double)s->mesh.nverts * (24.0 + 12.0 * PDS__NORMAL_LEVELS) +
                      (double)s->mesh.ntris * 16.0;
        double have = pds__physical_memory();
        if (have > 0.0 && need > have)
            return pds__fail(err, PDS_ERR_LIMIT, s->path, 0, 0,
                             "%lu triangles need about %.1f GB to load, more than this machine's %.1f GB",
                             (unsigned long)s->mesh.ntris, need / 1e9, have / 1e9);
    }
    if (pds__mesh_smooth_normals(&s->mesh, &s->materials)) return pds__nomem(err);
    t0 = pds_time_now();
    st = pds__bvh_build(&s->bvh, s->mesh.pos, s->mesh.idx, s->mesh.ntris, err);
    s->bvh_build_s = pds_time_now() - t0;
    return st;
}

/* --- define and include --------------------------------------------------- */

/* The kind of token a -D value stands for: a number or a word as the
   lexer would read it, else (spaces, quotes, other characters) a string. */
static pds__tok_kind pds__value_kind(const char *v)
{
    char c0 = v[0], c1 = c0 ? v[1] : '\0';
    size_t i;
    if (!c0) return PDS__TOK_STRING;
    for (i = 0; v[i]; i++)
        if (!pds__is_word_char((unsigned char)v[i])) return PDS__TOK_STRING;
    if (isdigit((unsigned char)c0) || (c0 == '.' && isdigit((unsigned char)c1)) ||
        ((c0 == '-' || c0 == '+') && (isdigit((unsigned char)c1) || c1 == '.')))
        return PDS__TOK_NUMBER;
    return PDS__TOK_WORD;
}

/* A variable name: a letter or '_', then letters, digits and '_'. */
static int pds__is_var_name(const char *w)
{
    size_t i;
    if (!(isalpha((unsigned char)w[0]) || w[0] == '_')) return 0;
    for (i = 1; w[i]; i++)
        if (!pds__is_var_char((unsigned char)w[i])) return 0;
    return i < 64;
}

/* define NAME VALUE: declares $NAME with the default VALUE (one token: a
   number, a word or a "string"), or the value of the last -D NAME=... */
static pds_status pds__parse_define(pds__parser *P)
{
    pds__load *L = P->L;
    pds__var v;
    int k, i;
    pds_status st;
    memset(&v, 0, sizeof v);
    if ((st = pds__lex_next(P))) return st;
    if (P->tok.kind != PDS__TOK_WORD || P->tok.var[0] || !pds__is_var_name(P->tok.text))
        return pds__perr(P, &P->tok, PDS_ERR_PARSE, "expected a variable name after 'define' (a letter or '_', then "
                         "letters, digits or '_'), got '%s'", P->tok.text);
    pds__strlcpy(v.name, P->tok.text, sizeof v.name);
    pds__strlcpy(v.file, P->file, sizeof v.file);
    v.line = P->tok.line;
    v.col = P->tok.col;
    i = pds__names_find(&L->var_index, v.name, strlen(v.name));
    if (i >= 0)
        return pds__perr(P, &P->tok, PDS_ERR_PARSE, "variable '%s' is already defined at %s:%d:%d", v.name,
                         L->vars[i].file, L->vars[i].line, L->vars[i].col);
    if (L->nvars >= (size_t)PDS_MAX_DEFINES)
        return pds__perr(P, &P->tok, PDS_ERR_LIMIT, "more than %d variables", PDS_MAX_DEFINES);
    if ((st = pds__lex_next(P))) return st;
    if (P->tok.kind != PDS__TOK_NUMBER && P->tok.kind != PDS__TOK_WORD && P->tok.kind != PDS__TOK_STRING)
        return pds__perr(P, &P->tok, PDS_ERR_PARSE, "expected a value after 'define %s' (a number, a name or a "
                         "\"string\"), got '%s'", v.name, P->tok.text);
    v.kind = P->tok.kind;
    pds__strlcpy(v.value, P->tok.text, sizeof v.value);
    for (k = 0; k < L->ndefines; k++) {
        const pds_define *d = &L->defines[k];
        if (!d->name || !d->value || strcmp(d->name, v.name) != 0) continue;
        if (strlen(d->value) >= sizeof v.value)
            return pds__perr(P, &P->tok, PDS_ERR_LIMIT, "the -D value of '%s' is longer than %d characters", v.name,
                             (int)sizeof v.value - 1);
        v.kind = pds__value_kind(d->value);
        pds__strlcpy(v.value, d->value, sizeof v.value);
        v.overridden = 1;
        L->define_used[k] = 1;
    }
    if (pds__grow((void **)&L->vars, &L->cap_vars, L->nvars + 1, sizeof *L->vars) ||
        !pds__names_put(&L->var_index, v.name, strlen(v.name), (int)L->nvars))
        return pds__nomem(P->err);
    L->vars[L->nvars++] = v;
    return PDS_OK;
}

/* The path with "./" parts and "DIR/.." pairs taken out, so that one file
   named two ways is recognised in an include cycle. */
static void pds__path_normalize(const char *path, char *out, size_t n)
{
    size_t len = 0, start[256];
    int parts = 0;
    const char *p = path;
    if (n == 0) return;
    out[0] = '\0';
    if (*p == '/') {
        if (n > 1) out[len++] = '/';
        while (*p == '/') p++;
    }
    while (*p) {
        const char *e = strchr(p, '/');
        size_t k = e ? (size_t)(e - p) : strlen(p);
        if (k == 1 && p[0] == '.') {
            /* "." adds nothing */
        } else if (k == 2 && p[0] == '.' && p[1] == '.' && parts > 0 &&
                   !(len - start[parts - 1] == 3 && !strncmp(out + start[parts - 1], "../", 3))) {
            len = start[--parts];
        } else if (len + k + 2 <= n) {
            if (parts < 256) start[parts++] = len;
            memcpy(out + len, p, k);
            len += k;
            out[len++] = '/';
        }
        p += k;
        while (*p == '/') p++;
    }
    if (len > 1 && out[len - 1] == '/') len--;
    out[len] = '\0';
}

static pds_status pds__parse_text(pds__parser *P);

/* include "FILE": FILE's statements, read where the include stands. Errors
   inside it name FILE:LINE:COLUMN and where it was included from. */
static pds_status pds__parse_include(pds__parser *P)
{
    pds__load *L = P->L;
    pds__token at = P->tok;
    pds__parser C;
    char path[512], norm[512], other[512];
    char *src = NULL;
    size_t size = 0;
    int d, e;
    pds_status st;
    if ((st = pds__lex_next(P))) return st;
    if (P->tok.kind != PDS__TOK_STRING && P->tok.kind != PDS__TOK_WORD)
        return pds__perr(P, &P->tok, PDS_ERR_PARSE, "expected a file name after 'include', got '%s'", P->tok.text);
    if (pds__join_path(P->dir, P->tok.text, path, sizeof path))
        return pds__perr(P, &P->tok, PDS_ERR_LIMIT, "include path too long");
    pds__path_normalize(path, norm, sizeof norm);
    memcpy(path, norm, sizeof path); /* "parts/../floor.scene" is named "floor.scene" */
    for (d = 0; d <= L->depth; d++) {
        pds__path_normalize(L->chain[d], other, sizeof other);
        if (!strcmp(other, norm)) {
            /* name the whole chain, from the file that starts the cycle */
            char chain[400] = "";
            int k;
            for (k = d; k <= L->depth; k++)
                snprintf(chain + strlen(chain), sizeof chain - strlen(chain), "%s -> ", L->chain[k]);
            return pds__perr(P, &P->tok, PDS_ERR_PARSE, "include cycle: %s%s", chain, path);
        }
    }
    if (L->depth + 1 > PDS_MAX_INCLUDE_DEPTH)
        return pds__perr(P, &at, PDS_ERR_LIMIT, "includes nested more than %d deep", PDS_MAX_INCLUDE_DEPTH);
    if (++L->includes > PDS_MAX_INCLUDES)
        return pds__perr(P, &at, PDS_ERR_LIMIT, "more than %d include statements", PDS_MAX_INCLUDES);
    e = pds__input_file_check(path);
    if (e) return pds__perr(P, &P->tok, PDS_ERR_IO, "cannot read included file '%s': %s", path, pds__input_file_problem(e));
    if ((st = pds__read_file(path, PDS_MAX_TEXT_BYTES, "scene file", &src, &size, P->err))) return st;
    if (size > (size_t)PDS_MAX_TEXT_BYTES - L->bytes) {
        free(src);
        return pds__perr(P, &at, PDS_ERR_LIMIT, "the scene and its included files hold more than %d bytes in all",
                         PDS_MAX_TEXT_BYTES);
    }
    L->bytes += size;
    st = pds__check_lines(path, src, size, P->err);
    if (!st && memchr(src, '\0', size)) st = pds__fail(P->err, PDS_ERR_PARSE, path, 0, 0, "not a text file (contains a NUL byte)");
    if (!st) {
        memset(&C, 0, sizeof C);
        C.file = path;
        pds__dirname(path, C.dir, sizeof C.dir);
        C.p = src;
        C.line = 1;
        C.col = 1;
        C.scene = P->scene;
        C.err = P->err;
        C.L = L;
        L->site_line[L->depth] = at.line;
        L->site_col[L->depth] = at.col;
        L->chain[++L->depth] = path;
        st = pds__parse_text(&C);
        L->depth--;
    }
    if (st && !L->noted) {
        /* the chain of includes, innermost first, as compilers print it */
        pds__error_append(P->err, " (included from %s:%d:%d", P->file, at.line, at.col);
        for (d = L->depth - 1; d >= 0; d--)
            pds__error_append(P->err, ", from %s:%d:%d", L->chain[d], L->site_line[d], L->site_col[d]);
        pds__error_append(P->err, ")");
        L->noted = 1;
    }
    free(src);
    return st;
}

/* The statements of one file (P set up at its start). */
static pds_status pds__parse_text(pds__parser *P)
{
    static const char *const statements[] = {"camera", "material", "light", "include", "define", "mesh", "sphere",
                                             "disk", "quad", "box", "cylinder", "torus", "revolve", "heightfield"};
    pds_status st;
    /* A UTF-8 byte order mark is allowed and skipped. */
    if ((unsigned char)P->p[0] == 0xEF && (unsigned char)P->p[1] == 0xBB && (unsigned char)P->p[2] == 0xBF) P->p += 3;
    for (;;) {
        const char *w;
        if ((st = pds__lex_next(P))) return st;
        if (P->tok.kind == PDS__TOK_END) break;
        if (P->tok.kind != PDS__TOK_WORD)
            return pds__perr(P, &P->tok, PDS_ERR_PARSE, "expected a statement (camera, material, light or a shape), got '%s'", P->tok.text);
        w = P->tok.text;
        if (!strcmp(w, "camera")) {
            if (P->L->camera_seen) return pds__perr(P, &P->tok, PDS_ERR_PARSE, "the scene has two cameras");
            P->L->camera_seen = 1;
            st = pds__parse_camera(P);
        } else if (!strcmp(w, "material")) st = pds__parse_material(P);
        else if (!strcmp(w, "light")) st = pds__parse_light(P);
        else if (!strcmp(w, "include")) st = pds__parse_include(P);
        else if (!strcmp(w, "define")) st = pds__parse_define(P);
        else if (pds__is_shape_kind(w)) st = pds__parse_shape(P);
        else {
            const char *closest = NULL;
            size_t k;
            int best = 3;
            for (k = 0; k < sizeof statements / sizeof statements[0]; k++) {
                int dist = pds__edit_distance(w, statements[k]);
                if (dist < best) {
                    best = dist;
                    closest = statements[k];
                }
            }
            if (closest && best <= (strlen(w) > 4 ? 2 : 1))
                st = pds__perr(P, &P->tok, PDS_ERR_PARSE, "unknown keyword '%s' (did you mean '%s'?)", w, closest);
            else
                st = pds__perr(P, &P->tok, PDS_ERR_PARSE, "unknown keyword '%s' (expected camera, material, light, "
                               "include, define, mesh, sphere, disk, quad, box, cylinder, torus, revolve or "
                               "heightfield)", w);
        }
        if (st) return st;
    }
    return PDS_OK;
}

static void pds__load_free(pds__load *L)
{
    free(L->define_used);
    free(L->vars);
    pds__names_free(&L->var_index);
}

/* Point parser P (and its load state L) at the start of text, the
   outermost file of the scene s. */
static void pds__parser_begin(pds__parser *P, pds__load *L, const char *file, const char *text, pds_scene *s,
                              pds_error *err)
{
    L->chain[0] = file;
    P->file = file;
    P->p = text;
    P->line = 1;
    P->col = 1;
    P->scene = s;
    P->err = err;
    P->L = L;
}

/* Parse scene text src (from path) into s, with the -D overrides of lo (or
   none), and warn about what the scene lacks. */
static pds_status pds__scene_parse(pds_scene *s, const char *path, const char *src, const pds_load_options *lo,
                                   pds_error *err)
{
    pds__parser P;
    pds__load L;
    pds_status st;
    int k;
    memset(&P, 0, sizeof P);
    memset(&L, 0, sizeof L);
    if (lo && lo->define_count > 0 && lo->defines) {
        L.defines = lo->defines;
        L.ndefines = lo->define_count;
        L.define_used = (unsigned char *)calloc((size_t)L.ndefines, 1);
        if (!L.define_used) return pds__nomem(err);
    }
    pds__parser_begin(&P, &L, path, src, s, err);
    L.bytes = strlen(src);
    pds__dirname(path, P.dir, sizeof P.dir);
    st = pds__parse_text(&P);
    if (st) {
        pds__load_free(&L);
        return st;
    }
    if (!L.camera_seen) pds__scene_warn(s, "%s: no camera given; using the default camera", path);
    if (s->nlights == 0) {
        size_t i;
        int emissive = 0;
        for (i = 0; i < s->mesh.ntris && !emissive; i++)
            emissive = s->materials.items[s->mesh.mat[i]].type == PDS_MAT_EMISSIVE;
        if (!emissive) pds__scene_warn(s, "%s: the scene has no light", path);
    }
    for (k = 0; k < L.ndefines; k++) {
        const char *name = L.defines[k].name ? L.defines[k].name : "";
        const char *closest = NULL;
        size_t i;
        int best = 3, j, repeated = 0;
        if (L.define_used[k]) continue;
        for (j = 0; j < k; j++) repeated |= L.defines[j].name && !strcmp(L.defines[j].name, name);
        if (repeated) continue;
        for (i = 0; i < L.nvars; i++) {
            int d = pds__edit_distance(name, L.vars[i].name);
            if (d < best) {
                best = d;
                closest = L.vars[i].name;
            }
        }
        if (closest && best <= (strlen(name) > 4 ? 2 : 1))
            pds__scene_warn(s, "%s: -D %.100s: the scene defines no variable '%.100s' (did you mean '%s'?)", path,
                            name, name, closest);
        else
            pds__scene_warn(s, "%s: -D %.100s: the scene defines no variable '%.100s'; ignored", path, name, name);
    }
    pds__load_free(&L);
    return PDS_OK;
}

/* Parse scene text (size bytes, NUL-terminated) named path, and build. */
static pds_status pds__scene_from_text(const char *path, const char *src, size_t size, const pds_load_options *lo,
                                       pds_scene **out, pds_error *err)
{
    pds_scene *s;
    pds_status st = pds__check_lines(path, src, size, err);
    if (!st && memchr(src, '\0', size))
        st = pds__fail(err, PDS_ERR_PARSE, path, 0, 0, "not a text file (contains a NUL byte)");
    if (st) return st;
    s = pds__scene_new(path);
    if (!s) return pds__nomem(err);
    st = pds__scene_parse(s, path, src, lo, err);
    if (!st) st = pds__scene_finish(s, err);
    if (st) {
        pds_scene_free(s);
        return st;
    }
    *out = s;
    return PDS_OK;
}

static pds_status pds__scene_load_file(const char *path, const pds_load_options *lo, pds_scene **out,
                                       pds_error *err)
{
    char *src = NULL;
    size_t size = 0;
    pds_status st;
    if (!path || !out) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds_scene_load: NULL argument");
    *out = NULL;
    if ((st = pds__read_file(path, PDS_MAX_TEXT_BYTES, "scene file", &src, &size, err))) return st;
    st = pds__scene_from_text(path, src, size, lo, out, err);
    free(src);
    return st;
}

pds_status pds_scene_load(const char *path, pds_scene **out, pds_error *err)
{
    return pds__scene_load_file(path, NULL, out, err);
}

pds_status pds_scene_load_string_ex(const char *text, const char *name, const pds_load_options *lo,
                                    pds_scene **out, pds_error *err)
{
    size_t size;
    if (!text || !name || !out)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds_scene_load_string: NULL argument");
    *out = NULL;
    size = strlen(text);
    if (size > (size_t)PDS_MAX_TEXT_BYTES)
        return pds__fail(err, PDS_ERR_LIMIT, name, 0, 0, "%.0f bytes is larger than the limit of %.0f bytes for a scene",
                         (double)size, (double)PDS_MAX_TEXT_BYTES);
    return pds__scene_from_text(name, text, size, lo, out, err);
}

pds_status pds_scene_load_string(const char *text, const char *name, pds_scene **out, pds_error *err)
{
    return pds_scene_load_string_ex(text, name, NULL, out, err);
}

/* A camera that sees the whole box from +z (and a little above), at the
   default 40 degree field of view. */
static void pds__camera_frame_bounds(pds_camera *c, pds__v3 lo, pds__v3 hi)
{
    pds__v3 centre = pds__scale(pds__add(lo, hi), 0.5);
    double radius = 0.5 * pds__length(pds__sub(hi, lo));
    double dist = (radius > 0.0 ? radius : 1.0) / sin(0.5 * c->fov_deg * PDS__PI / 180.0) * 1.05;
    c->look_at = centre;
    c->position = pds__add(centre, pds__scale(pds__normalize(pds__v(0.0, 0.35, 1.0)), dist));
}

pds_status pds_scene_load_obj(const char *path, pds_scene **out, pds_error *err)
{
    pds_scene *s;
    pds_status st;
    pds__obj_options o;
    pds__obj_stats stats;
    pds__xform id = pds__xform_identity();
    if (!path || !out) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds_scene_load_obj: NULL argument");
    *out = NULL;
    s = pds__scene_new(path);
    if (!s) return pds__nomem(err);
    memset(&o, 0, sizeof o);
    o.xform = &id;
    o.material_override = -1;
    o.default_material = pds__scene_default_material(s);
    if (o.default_material < 0) {
        pds_scene_free(s);
        return pds__nomem(err);
    }
    st = pds__obj_load(path, &s->mesh, &s->materials, &o, &stats, err);
    if (!st) {
        s->shapes = 1;
        pds__scene_warn_obj(s, path, &stats);
        st = pds__scene_finish(s, err);
    }
    if (st) {
        pds_scene_free(s);
        return st;
    }
    pds__camera_frame_bounds(&s->camera, s->bounds_min, s->bounds_max);
    *out = s;
    return PDS_OK;
}

/* --- a bare OBJ in a studio --------------------------------------------- */
/* `pds render bunny.obj`: an OBJ has no light and no camera, so it is set
   in a studio that any mesh, at any scale, shows up in at once. With C the
   centre of the mesh's bounding box, R its half diagonal and y0 its lowest
   y (OBJ files put +y up):
   - a ground, white-grey diffuse (albedo 0.75), 40 R square, centred
     under C at y0 - R/1000 (just under the mesh: no coplanar faces);
   - a disk light of radius 0.3 R at C + 5 R w, w = (-0.75, 0.7, 0.3)
     normalised (up and to the left, a little towards the camera), facing
     C; it makes the ground under C, were it unshadowed, of radiance 0.6:
     a small Lambertian disk of area A and radiance Le seen at distance D
     gives E = Le A cos(theta_l) cos(theta_g) / D^2, and the ground's
     radiance is albedo E / pi, so Le = 0.6 pi D^2 / (albedo A cos(theta_l)
     cos(theta_g)): a number that does not depend on the mesh's scale
     (D and A scale with R), so meshes in any unit get the same light
     (and no power beyond the coordinate limit). Its shadow,
     and the caustic of a glass or metal mesh, fall to the right of the
     mesh, where the camera sees them;
   - a camera, 512 x 384 with a 40 degree vertical field of view, looking
     from +z and a little above (along (0, 0.35, 1)) at C, as near as it
     can be while every corner of the bounding box projects within 80% of
     the image's half-width and half-height: a corner at (x, y, z) in the
     camera's frame (z towards C) at distance dist is inside when
     |y| <= 0.8 tan(fov/2) (dist + z), and so for x with the aspect.
   The studio is scene text, parsed like a scene file (named "studio" in
   messages), so it reads as a scene would write it. An OBJ with emissive
   materials keeps its own lights and gets no studio light. */

static int pds__has_extension(const char *path, const char *ext);

/* The mesh's own material for the studio, before the OBJ is read. */
static const char *pds__studio_material_text(pds_obj_material m)
{
    switch (m) {
    case PDS_OBJ_MATERIAL_DIFFUSE: return "material studio_mesh diffuse { albedo 0.8 }\n";
    case PDS_OBJ_MATERIAL_GLASS: return "material studio_mesh dielectric { ior 1.5 }\n";
    case PDS_OBJ_MATERIAL_METAL: return "material studio_mesh conductor { preset silver }\n";
    case PDS_OBJ_MATERIAL_AUTO: break;
    }
    return "";
}

/* Parse studio text into s (no warnings about what it lacks). */
static pds_status pds__studio_parse(pds_scene *s, const char *text, pds_error *err)
{
    pds__parser P;
    pds__load L;
    pds_status st;
    memset(&P, 0, sizeof P);
    memset(&L, 0, sizeof L);
    pds__parser_begin(&P, &L, "studio", text, s, err);
    st = pds__parse_text(&P);
    pds__load_free(&L);
    return st;
}

static pds_status pds__scene_load_studio(const char *path, pds_obj_material material, pds_scene **out,
                                         pds_error *err)
{
    pds_scene *s;
    pds_status st;
    pds__obj_options o;
    pds__obj_stats stats;
    pds__xform id = pds__xform_identity();
    pds__v3 lo, hi, c, w, lc, q, v;
    double R, y0, D, cos_l, cos_g, radiance, dist;
    size_t i;
    int emissive = 0;
    char text[2048];
    *out = NULL;
    s = pds__scene_new(path);
    if (!s) return pds__nomem(err);
    memset(&o, 0, sizeof o);
    o.xform = &id;
    o.material_override = -1;
    o.default_material = pds__scene_default_material(s);
    st = o.default_material < 0 ? pds__nomem(err) : pds__studio_parse(s, pds__studio_material_text(material), err);
    if (!st && material != PDS_OBJ_MATERIAL_AUTO) o.material_override = pds__materials_find(&s->materials, "studio_mesh");
    if (!st) st = pds__obj_load(path, &s->mesh, &s->materials, &o, &stats, err);
    if (st) {
        pds_scene_free(s);
        return st;
    }
    s->shapes = 1;
    pds__scene_warn_obj(s, path, &stats);
    lo = hi = pds__v(0.0, 0.0, 0.0);
    for (i = 0; i < s->mesh.nverts; i++) {
        pds__v3 p = pds__mesh_pos(&s->mesh, (long)i);
        lo = i ? pds__vmin(lo, p) : p;
        hi = i ? pds__vmax(hi, p) : p;
    }
    for (i = 0; i < s->mesh.ntris && !emissive; i++)
        emissive = s->materials.items[s->mesh.mat[i]].type == PDS_MAT_EMISSIVE;
    c = pds__scale(pds__add(lo, hi), 0.5);
    R = 0.5 * pds__length(pds__sub(hi, lo));
    if (!(R > 0.0)) R = 1.0;
    y0 = lo.y - 1e-3 * R;
    w = pds__normalize(pds__v(-0.75, 0.7, 0.3));
    lc = pds__add(c, pds__scale(w, 5.0 * R));
    q = pds__v(c.x, y0, c.z);
    v = pds__sub(q, lc);
    D = pds__length(v);
    cos_l = pds__dot(pds__scale(w, -1.0), pds__scale(v, 1.0 / D));
    cos_g = -v.y / D;
    radiance = 0.6 * PDS__PI * D * D / (0.75 * PDS__PI * 0.09 * R * R * cos_l * cos_g);
    {
        pds__v3 back = pds__normalize(pds__v(0.0, 0.35, 1.0)), fwd = pds__scale(back, -1.0);
        pds__v3 right = pds__normalize(pds__cross(fwd, pds__v(0.0, 1.0, 0.0))), up = pds__cross(right, fwd);
        double ty = 0.8 * tan(0.5 * 40.0 * PDS__PI / 180.0), tx = ty * 512.0 / 384.0;
        pds__v3 at = c, eye;
        int k;
        dist = 0.0;
        for (k = 0; k < 8; k++) {
            pds__v3 o = pds__sub(pds__v(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z), at);
            double z = pds__dot(o, fwd), need_y = fabs(pds__dot(o, up)) / ty - z, need_x = fabs(pds__dot(o, right)) / tx - z;
            if (need_y > dist) dist = need_y;
            if (need_x > dist) dist = need_x;
        }
        if (dist < 1.5 * R) dist = 1.5 * R; /* never inside the mesh's bounding sphere */
        eye = pds__add(at, pds__scale(back, dist));
        int n = snprintf(text, sizeof text,
                         "material studio_ground diffuse { albedo 0.75 }\n"
                         "quad { material studio_ground  size %.9g %.9g  translate %.9g %.9g %.9g }\n"
                         "camera { position %.9g %.9g %.9g  look_at %.9g %.9g %.9g  fov 40  resolution 512 384  spp 4 }\n",
                         40.0 * R, 40.0 * R, c.x, y0, c.z, eye.x, eye.y, eye.z, at.x, at.y, at.z);
        if (!emissive)
            snprintf(text + n, sizeof text - (size_t)n,
                     "light disk { center %.9g %.9g %.9g  normal %.9g %.9g %.9g  radius %.9g  radiance %.9g }\n",
                     lc.x, lc.y, lc.z, -w.x, -w.y, -w.z, 0.3 * R, radiance);
    }
    st = pds__studio_parse(s, text, err);
    if (!st) st = pds__scene_finish(s, err);
    if (st) {
        pds_scene_free(s);
        return st;
    }
    *out = s;
    return PDS_OK;
}

void pds_load_options_default(pds_load_options *lo)
{
    memset(lo, 0, sizeof *lo);
    lo->defines = NULL;
    lo->define_count = 0;
    lo->obj_studio = 1;
    lo->obj_material = PDS_OBJ_MATERIAL_AUTO;
}

pds_status pds_scene_load_ex(const char *path, const pds_load_options *lo, pds_scene **out, pds_error *err)
{
    pds_load_options d;
    if (!path || !out) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds_scene_load_ex: NULL argument");
    *out = NULL;
    if (!lo) {
        pds_load_options_default(&d);
        lo = &d;
    }
    if (lo->define_count < 0 || (lo->define_count > 0 && !lo->defines) ||
        (unsigned)lo->obj_material > (unsigned)PDS_OBJ_MATERIAL_METAL)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds_scene_load_ex: bad load options");
    if (pds__has_extension(path, "obj"))
        return lo->obj_studio ? pds__scene_load_studio(path, lo->obj_material, out, err)
                              : pds_scene_load_obj(path, out, err);
    return pds__scene_load_file(path, lo, out, err);
}

void pds_scene_get_info(const pds_scene *s, pds_scene_info *info)
{
    size_t i;
    memset(info, 0, sizeof *info);
    info->triangles = (long)s->mesh.ntris;
    info->vertices = (long)s->mesh.nverts;
    info->materials = (int)s->materials.count;
    info->lights = (int)s->nlights;
    for (i = 0; i < s->nlights; i++) info->mesh_lights += s->lights[i].type == PDS_LIGHT_MESH;
    info->shapes = s->shapes;
    info->degenerate_dropped = s->mesh.degenerate_dropped;
    info->bounds_min = s->bounds_min;
    info->bounds_max = s->bounds_max;
    info->warnings = (int)s->nwarnings;
    info->memory_bytes = sizeof *s + pds__bvh_memory(&s->bvh) + s->mesh.cap_pos * sizeof(float) +
                         s->mesh.cap_nrm * sizeof(float) + (s->mesh.cap_idx + s->mesh.cap_mat) * sizeof(int) +
                         s->materials.cap * sizeof(pds_material) + s->cap_lights * sizeof(pds_light) +
                         pds__lights_memory(&s->light_table);
}

double pds_material_ior(const pds_material *m, double wavelength_nm)
{
    return pds__ior_at(m, wavelength_nm);
}

int pds_scene_emit(const pds_scene *s, int index, const double u[4], pds_emission *out)
{
    pds__light_emit e;
    const pds_light *l;
    if (!s || !out || index < 0 || (size_t)index >= s->nlights) return 0;
    l = &s->lights[index];
    memset(out, 0, sizeof *out);
    pds__light_emission_extent(l, &out->area, &out->solid_angle);
    if (!pds__light_emit_sample(&s->light_table, l, index, &s->mesh, u, &e)) return 0;
    out->position = e.pos;
    out->direction = e.dir;
    out->normal = e.normal;
    memcpy(out->flux, e.flux, sizeof out->flux);
    out->pdf_position = e.pdf_pos;
    out->pdf_direction = e.pdf_dir;
    return 1;
}

const char *pds_scene_warning(const pds_scene *s, int i)
{
    return (i >= 0 && (size_t)i < s->nwarnings) ? s->warnings[i] : NULL;
}

const pds_camera *pds_scene_camera(const pds_scene *s) { return &s->camera; }

const pds_material *pds_scene_material(const pds_scene *s, int i)
{
    return (i >= 0 && (size_t)i < s->materials.count) ? &s->materials.items[i] : NULL;
}

const pds_light *pds_scene_light(const pds_scene *s, int i)
{
    return (i >= 0 && (size_t)i < s->nlights) ? &s->lights[i] : NULL;
}

/* Largest extent of the scene's bounds (at least 1), for ray offsets. */
static double pds__scene_scale(const pds_scene *s)
{
    pds__v3 e = pds__sub(s->bounds_max, s->bounds_min);
    double m = fabs(s->bounds_max.x) + fabs(s->bounds_max.y) + fabs(s->bounds_max.z) + e.x + e.y + e.z;
    return m > 1.0 ? m : 1.0;
}

/* Fill the public hit from a BVH hit: position, unit geometric normal in
   the winding's direction, interpolated unit shading normal. */
static void pds__scene_fill_hit(const pds_scene *s, const pds__tri_hit *th, pds__v3 org, pds__v3 dir, pds_hit *hit)
{
    const int *v = &s->mesh.idx[3 * th->tri];
    pds__v3 p0 = pds__mesh_pos(&s->mesh, v[0]), p1 = pds__mesh_pos(&s->mesh, v[1]), p2 = pds__mesh_pos(&s->mesh, v[2]);
    pds__v3 n0 = pds__mesh_nrm(&s->mesh, v[0]), n1 = pds__mesh_nrm(&s->mesh, v[1]), n2 = pds__mesh_nrm(&s->mesh, v[2]);
    double w = 1.0 - th->u - th->v;
    pds__v3 ns = pds__add(pds__add(pds__scale(n0, w), pds__scale(n1, th->u)), pds__scale(n2, th->v));
    hit->t = th->t;
    hit->triangle = th->tri;
    hit->u = th->u;
    hit->v = th->v;
    hit->position = pds__add(org, pds__scale(dir, th->t));
    hit->ng = pds__normalize(pds__cross(pds__sub(p1, p0), pds__sub(p2, p0)));
    hit->ns = pds__length(ns) > 0.0 ? pds__normalize(ns) : hit->ng;
    hit->material = s->mesh.mat[th->tri];
}

int pds_scene_intersect(const pds_scene *s, const pds_ray *ray, pds_hit *hit)
{
    pds__tri_hit th;
    if (!pds__bvh_intersect(&s->bvh, ray->origin, ray->dir, ray->tmin, ray->tmax, &th)) return 0;
    pds__scene_fill_hit(s, &th, ray->origin, ray->dir, hit);
    return 1;
}

int pds_scene_occluded(const pds_scene *s, const pds_ray *ray)
{
    return pds__bvh_occluded(&s->bvh, ray->origin, ray->dir, ray->tmin, ray->tmax);
}

/* ===================================================================== */
/* >>differentials                                                       */
/* ===================================================================== */
/* Photon differentials (Frisvad, Schjoth, Erleben, Sporring, "Photon
   Differential Splatting for Rendering Caustics", CGF 2014, sections
   3.1-3.3 and appendices A-B) on top of Igehy's ray differentials
   ("Tracing Ray Differentials", SIGGRAPH 1999); every formula below is
   from those two papers, cited by equation at its function.

   A photon carries two ray differentials, one per footprint axis:
       pair u = (Du x + Dtheta x, Dtheta omega),  pair v = (Dv x + Dphi x, Dphi omega).
   Emission (eqs 2-3) chooses the four vectors so that after the first
   transfer Dtheta x' is parallel to Du x' and Dphi x' to Dv x' (appendix
   A); the pairs then add (eq 7) and each is an ordinary ray differential
   (DP, DD) that Igehy's transfer, reflection and refraction carry along.

   Conventions and invariants:
   - Directions are unit vectors; every directional differential DD stays
     perpendicular to its direction (D.DD = 0) through reflect/refract.
   - Transfer uses the plane the hit really lies in: for a triangle, its
     GEOMETRIC normal (either orientation). Reflection and refraction use
     the interpolated SHADING normal and its differential DN, which for a
     smooth-shaded triangle comes from pds__mesh_normal_diff.
   - Whoever flips a normal flips its differentials too: DN is the
     derivative of the normal actually used. If the scattering code falls
     back to the geometric normal (pds__bsdf_frame does when wo lies below
     the shading hemisphere), the normal is constant and DN = 0.
   - Footprint (eq 4): the ellipse with conjugate semi-diameters Du x / 2
     and Dv x / 2, area pi/4 |Du x X Dv x|. The filter matrix (eq 12) maps it
     to the unit disc; the Silverman kernel (eq 11) has unit mass on the
     unit disc, so pi K(|M y|) E_p integrates to the photon's flux. */

/* A photon (or ray) with two differentials, one per footprint axis. */
typedef struct pds__ray_diff {
    pds__v3 p, d;       /* position (origin or current hit point), unit direction */
    pds__v3 dpdu, dddu; /* positional and directional differential, axis u */
    pds__v3 dpdv, dddv; /* axis v */
} pds__ray_diff;

static int pds__diff_finite(pds__v3 a)
{
    return isfinite(a.x) && isfinite(a.y) && isfinite(a.z);
}

/* Initial length of the differential vectors, eqs 5-6:
   2 s sqrt(extent / (pi N)). extent is the emitting area Ae (positional
   vectors) or the emission solid angle omega_e (directional vectors), s
   the smoothing parameter, n_photons the photons emitted from this light.
   0 when the extent is 0 (point lights have no area, directional lights no
   solid angle) or an argument is not positive and finite. */
static double pds__photon_diff_length(double s, double extent, double n_photons)
{
    double l;
    if (!(extent > 0.0) || !(n_photons > 0.0) || !(s > 0.0)) return 0.0;
    l = 2.0 * s * sqrt(extent / (PDS__PI * n_photons));
    return isfinite(l) ? l : 0.0;
}

/* Emit a photon differential at x travelling along unit omega (eqs 2-3).
   n is the emitter's unit surface normal, or the zero vector when the
   light has none (point and spot lights). Output directions:
       u = theta = (n x omega)/|n x omega|,  v = u x n,  phi = theta x omega.
   n is first turned onto omega's side (n.omega >= 0): for a two-sided
   emitter this keeps Dv x' and Dphi x' pointing the same way after the
   first transfer (appendix A) instead of cancelling in pair v.
   When omega ~ n (|n x omega| < 1e-6) or there is no normal, u comes from
   the orthonormal basis of n (or of omega; Frisvad 2012, pds__onb), v = u
   x n (or u x omega), theta = u re-orthogonalised against omega, phi =
   theta x omega, which keeps the same pairing. Lengths: pos_len for both
   positional vectors (0 for point lights), dir_len for both directional
   ones (0 for directional lights); see pds__photon_diff_length. */
static void pds__photon_diff_init(pds__ray_diff *r, pds__v3 x, pds__v3 omega, pds__v3 n, double pos_len,
                                  double dir_len)
{
    pds__v3 u, v, th, ph, b2;
    int has_normal = pds__length(n) > 0.0;
    omega = pds__normalize(omega);
    if (has_normal) {
        n = pds__normalize(n);
        if (pds__dot(n, omega) < 0.0) n = pds__scale(n, -1.0);
        u = pds__cross(n, omega);
    } else {
        n = omega; /* the positional plane is then the one across the beam */
        u = pds__v(0.0, 0.0, 0.0);
    }
    if (pds__length(u) >= 1e-6) {
        u = pds__normalize(u);
        v = pds__cross(u, n);
        th = u;
    } else {
        pds__onb(n, &u, &b2);
        v = pds__cross(u, n);
        th = pds__normalize(pds__sub(u, pds__scale(omega, pds__dot(u, omega))));
        if (!(pds__length(th) > 0.0)) pds__onb(omega, &th, &b2);
    }
    ph = pds__cross(th, omega);
    r->p = x;
    r->d = omega;
    r->dpdu = pds__scale(u, pos_len);
    r->dpdv = pds__scale(pds__normalize(v), pos_len);
    r->dddu = pds__scale(th, dir_len);
    r->dddv = pds__scale(pds__normalize(ph), dir_len);
}

/* Igehy's transfer of one differential to the plane with normal ng at
   distance t along unit d: DP' = DP + t DD + Dt d with
   Dt = -((DP + t DD).ng) / (d.ng), so that DP'.ng = 0. */
static pds__v3 pds__diff_transfer_one(pds__v3 dp, pds__v3 dd, pds__v3 d, double t, pds__v3 ng, double dng)
{
    pds__v3 q = pds__add(dp, pds__scale(dd, t));
    double dt = -pds__dot(q, ng) / dng;
    return pds__add(q, pds__scale(d, dt));
}

/* Move the photon to its hit p + t d on the plane with normal ng (the
   triangle's geometric normal, either orientation, need not be unit) and
   transfer both positional differentials; directional ones are unchanged.
   Returns 0 and leaves r untouched when d is parallel to the plane
   (grazing: the caller drops the photon) or the result is not finite;
   1 otherwise. */
static int pds__diff_transfer(pds__ray_diff *r, double t, pds__v3 ng)
{
    double dng = pds__dot(r->d, ng);
    pds__v3 p, du, dv;
    if (dng == 0.0 || !isfinite(dng) || !isfinite(t)) return 0;
    p = pds__add(r->p, pds__scale(r->d, t));
    du = pds__diff_transfer_one(r->dpdu, r->dddu, r->d, t, ng, dng);
    dv = pds__diff_transfer_one(r->dpdv, r->dddv, r->d, t, ng, dng);
    if (!pds__diff_finite(p) || !pds__diff_finite(du) || !pds__diff_finite(dv)) return 0;
    r->p = p;
    r->dpdu = du;
    r->dpdv = dv;
    return 1;
}

/* Differential of the unit interpolated shading normal of triangle tri at
   barycentrics (u, v) (P = (1-u-v) P0 + u P1 + v P2) for a positional
   differential dp lying in the triangle's plane (a transferred DP').
   Igehy's normal-interpolated triangle: with e1 = P1-P0, e2 = P2-P0,
   g = e1 x e2, Lu = (e2 x g)/((e2 x g).e1), Lv = (e1 x g)/((e1 x g).e2)
   the barycentric differentials are Du = Lu.dp, Dv = Lv.dp; the
   unnormalised n = (1-u-v) N0 + u N1 + v N2 has Dn = Du (N1-N0) +
   Dv (N2-N0), and the unit normal DN = ((n.n) Dn - (n.Dn) n)/(n.n)^(3/2).
   Flat triangles (equal vertex normals) and degenerate data give 0. The
   result is for the normal as stored (pds__scene_fill_hit's ns): negate it
   wherever that normal is negated. */
/* The derivative along dp of the normalised interpolation of the normals
   nrm[3 * i ...] at the corners of triangle tri, at (u, v). */
static pds__v3 pds__tri_normal_diff(const pds__mesh *m, const float *nrm, long tri, double u, double v, pds__v3 dp)
{
    const int *ix = &m->idx[3 * tri];
    pds__v3 p0 = pds__mesh_pos(m, ix[0]), p1 = pds__mesh_pos(m, ix[1]), p2 = pds__mesh_pos(m, ix[2]);
    pds__v3 n0 = pds__v(nrm[3 * ix[0]], nrm[3 * ix[0] + 1], nrm[3 * ix[0] + 2]);
    pds__v3 n1 = pds__v(nrm[3 * ix[1]], nrm[3 * ix[1] + 1], nrm[3 * ix[1] + 2]);
    pds__v3 n2 = pds__v(nrm[3 * ix[2]], nrm[3 * ix[2] + 1], nrm[3 * ix[2] + 2]);
    pds__v3 e1 = pds__sub(p1, p0), e2 = pds__sub(p2, p0), g = pds__cross(e1, e2);
    pds__v3 a = pds__cross(e2, g), b = pds__cross(e1, g), n, dnu, dn;
    double ae = pds__dot(a, e1), be = pds__dot(b, e2), du, dv, nn, ndn, inv;
    if (ae == 0.0 || be == 0.0) return pds__v(0.0, 0.0, 0.0);
    du = pds__dot(a, dp) / ae;
    dv = pds__dot(b, dp) / be;
    n = pds__add(pds__add(pds__scale(n0, 1.0 - u - v), pds__scale(n1, u)), pds__scale(n2, v));
    dnu = pds__add(pds__scale(pds__sub(n1, n0), du), pds__scale(pds__sub(n2, n0), dv));
    nn = pds__dot(n, n);
    if (!(nn > 0.0)) return pds__v(0.0, 0.0, 0.0); /* the hit then uses the geometric normal: constant */
    ndn = pds__dot(n, dnu);
    inv = 1.0 / (nn * sqrt(nn));
    dn = pds__scale(pds__sub(pds__scale(dnu, nn), pds__scale(n, ndn)), inv);
    return pds__diff_finite(dn) ? dn : pds__v(0.0, 0.0, 0.0);
}

/* The shading normal's differential *dn along dp at (u, v) of triangle
   tri, for a footprint of half-width scale there along dp. Within a
   triangle (a footprint at most its size e = sqrt(2 area) across) and on
   smooth normals: the derivative of the interpolated vertex normals, as
   ray differentials take it (Igehy 1999). On noisy normals: the
   derivative of the averaged fields at the footprint's scale
   (pds__mesh_smooth_normals; field l at about 2^l edges, interpolated in
   log2(PDS__NORMAL_REACH 2 scale / e), the footprint's width in
   triangles, times 1.5: a field's one-ring averages reach about that
   much less far than the width they are named by. Measured on a glass
   sphere with noisy normals at 2M photons against light tracing: RMSE
   0.0137 at 1, 0.0050 at 1.5, 0.0049 at 2; the cognac glass's needles,
   whose coarse revolve counts as noisy, 0.0029, 0.0031, 0.0033.) Noise
   is told from shape by how far the one derivative lies from the other,
   rho = |DN - DN_avg| / |DN_avg|:
   on smooth normals averaging changes the derivative only where the
   curvature itself changes over the footprint (a few tens of percent on
   the cognac glass's coarse revolve), on noise by several times its
   size. The averaged derivative's weight rises from 0 at rho =
   PDS__NORMAL_NOISE to 1 at 1.5 times that; the blend keeps only its part
   across the shading normal, so that it stays the derivative of a unit
   vector. */
static void pds__mesh_normal_diff(const pds__mesh *m, long tri, double u, double v, pds__v3 dp, double scale,
                                  pds__v3 *dn)
{
    const int *ix = &m->idx[3 * tri];
    double e, lambda, f, rho, w;
    int l0;
    pds__v3 n, ds;
    *dn = pds__tri_normal_diff(m, m->nrm, tri, u, v, dp);
    if (!m->smooth || !(scale > 0.0)) return;
    e = sqrt(pds__mesh_tri_area2(m, ix[0], ix[1], ix[2]));
    if (!(PDS__NORMAL_REACH * 2.0 * scale > e)) return;
    lambda = log2(PDS__NORMAL_REACH * 2.0 * scale / e);
    if (lambda > PDS__NORMAL_LEVELS) lambda = PDS__NORMAL_LEVELS;
    l0 = (int)lambda;
    f = lambda - l0;
    ds = *dn;
    if (l0 > 0) ds = pds__tri_normal_diff(m, m->smooth + 3 * m->nverts * (size_t)(l0 - 1), tri, u, v, dp);
    if (f > 0.0)
        ds = pds__add(pds__scale(ds, 1.0 - f),
                      pds__scale(pds__tri_normal_diff(m, m->smooth + 3 * m->nverts * (size_t)l0, tri, u, v, dp), f));
    rho = pds__length(pds__sub(*dn, ds)) / (pds__length(ds) + 1e-300);
    w = (rho - PDS__NORMAL_NOISE) / (0.5 * PDS__NORMAL_NOISE);
    if (!(w > 0.0)) return;
    if (w > 1.0) w = 1.0;
    *dn = pds__add(pds__scale(*dn, 1.0 - w), pds__scale(ds, w));
    n = pds__add(pds__add(pds__scale(pds__mesh_nrm(m, ix[0]), 1.0 - u - v), pds__scale(pds__mesh_nrm(m, ix[1]), u)),
                 pds__scale(pds__mesh_nrm(m, ix[2]), v));
    if (pds__dot(n, n) > 0.0) {
        n = pds__normalize(n);
        *dn = pds__sub(*dn, pds__scale(n, pds__dot(n, *dn)));
    }
}

/* Igehy's reflected directional differential for incident unit d, unit
   normal n with differential dn, incident differential dd:
   DR = DD - 2 [ (d.n) DN + D(d.n) n ],  D(d.n) = DD.n + d.DN. */
static pds__v3 pds__diff_reflect_one(pds__v3 d, pds__v3 dd, pds__v3 n, pds__v3 dn)
{
    double dnn = pds__dot(d, n);
    double ddn = pds__dot(dd, n) + pds__dot(d, dn);
    return pds__sub(dd, pds__scale(pds__add(pds__scale(dn, dnn), pds__scale(n, ddn)), 2.0));
}

/* Mirror reflection of the photon: r->d (incident) becomes
   R = d - 2 (d.n) n (pds__reflect, the eye paths' formula) and the
   directional differentials become DR. n is the unit shading normal (either
   orientation; the formula is even in (n, DN)), dndu and dndv its
   differentials along the two axes. Positional differentials unchanged. */
static void pds__diff_reflect(pds__ray_diff *r, pds__v3 n, pds__v3 dndu, pds__v3 dndv)
{
    pds__v3 du = pds__diff_reflect_one(r->d, r->dddu, n, dndu);
    pds__v3 dv = pds__diff_reflect_one(r->d, r->dddv, n, dndv);
    r->d = pds__reflect(r->d, n);
    r->dddu = du;
    r->dddv = dv;
}

/* Igehy's refracted directional differential: DT = eta DD - (mu DN + Dmu n),
   Dmu = [eta - eta^2 (d.n)/(T.n)] D(d.n), D(d.n) = DD.n + d.DN. */
static pds__v3 pds__diff_refract_one(pds__v3 d, pds__v3 dd, pds__v3 n, pds__v3 dn, double eta, double mu,
                                     double dnn, double tn)
{
    double ddn = pds__dot(dd, n) + pds__dot(d, dn);
    double dmu = (eta - eta * eta * dnn / tn) * ddn;
    return pds__sub(pds__scale(dd, eta), pds__add(pds__scale(dn, mu), pds__scale(n, dmu)));
}

/* Refraction of the photon through the unit shading normal n, which must
   face AGAINST r->d (d.n < 0): a caller whose normal faces the other way
   (a photon leaving a dielectric) negates n AND dndu, dndv first.
   eta = n_incident / n_transmitted. The direction is pds__refract's, bit
   for bit, so photon and eye paths agree; the directional differentials
   become Igehy's DT. Returns 0 and leaves r untouched on total internal
   reflection, at exactly the critical angle (T.n = 0, where DT is
   infinite) and when the result is not finite; 1 otherwise. */
static int pds__diff_refract(pds__ray_diff *r, pds__v3 n, pds__v3 dndu, pds__v3 dndv, double eta)
{
    pds__v3 t, du, dv;
    double dnn = pds__dot(r->d, n), rad, tn, mu;
    if (!pds__refract(r->d, n, eta, &t)) return 0;
    /* the same T.n and mu as pds__refract computed */
    rad = 1.0 - eta * eta * (1.0 - dnn * dnn);
    tn = -sqrt(rad);
    mu = eta * dnn - tn;
    if (!(tn < 0.0)) return 0;
    du = pds__diff_refract_one(r->d, r->dddu, n, dndu, eta, mu, dnn, tn);
    dv = pds__diff_refract_one(r->d, r->dddv, n, dndv, eta, mu, dnn, tn);
    if (!pds__diff_finite(t) || !pds__diff_finite(du) || !pds__diff_finite(dv)) return 0;
    r->d = t;
    r->dddu = du;
    r->dddv = dv;
    return 1;
}

/* Photon footprint area, eq 4: pi/4 |Du x X Dv x| (the ellipse inscribed
   in the parallelogram spanned by the positional differentials). */
static double pds__footprint_area(pds__v3 dpdu, pds__v3 dpdv)
{
    return 0.25 * PDS__PI * pds__length(pds__cross(dpdu, dpdv));
}

/* Filter matrix, eq 12: the top two rows of the inverse of the change of
   basis [Du x / 2, Dv x / 2, np] (columns), i.e.
       M = 2 / (Du.(Dv x np)) [ (Dv x np)^T ; (np x Du)^T ].
   M maps Du/2 to (1,0), Dv/2 to (0,1) and np to (0,0), so the footprint
   ellipse becomes the unit circle. np: unit surface normal at the photon.
   Returns 0 and leaves M untouched when the footprint has collapsed (the
   denominator is 0 or not finite): the caller discards the photon. */
static int pds__filter_matrix(pds__v3 dpdu, pds__v3 dpdv, pds__v3 np, double M[2][3])
{
    pds__v3 a = pds__cross(dpdv, np), b = pds__cross(np, dpdu);
    double den = pds__dot(dpdu, a), s;
    if (den == 0.0 || !isfinite(den)) return 0;
    s = 2.0 / den;
    if (!isfinite(s) || !pds__diff_finite(pds__scale(a, s)) || !pds__diff_finite(pds__scale(b, s))) return 0;
    M[0][0] = s * a.x;
    M[0][1] = s * a.y;
    M[0][2] = s * a.z;
    M[1][0] = s * b.x;
    M[1][1] = s * b.y;
    M[1][2] = s * b.z;
    return 1;
}

#if !defined(PDS_NO_BENCH) || defined(PDS_TEST)
/* The slow reference for eq 12: the general 3x3 inverse of
   B = [Du/2, Dv/2, np] (columns) by cofactors, B^-1 = adj(B) / det(B),
   keeping its top two rows. Same contract as pds__filter_matrix; used by
   the tests and `pds bench filter` (the paper: 35.1 vs 2.59 M/s). */
static int pds__filter_matrix_general(pds__v3 dpdu, pds__v3 dpdv, pds__v3 np, double M[2][3])
{
    double B[3][3], C[3][3], det, inv;
    int i, j;
    for (i = 0; i < 3; i++) {
        B[i][0] = 0.5 * pds__v3_get(dpdu, i);
        B[i][1] = 0.5 * pds__v3_get(dpdv, i);
        B[i][2] = pds__v3_get(np, i);
    }
    /* C[i][j] = cofactor of B[i][j] = (-1)^(i+j) minor(i, j) */
    for (i = 0; i < 3; i++) {
        for (j = 0; j < 3; j++) {
            int r0 = (i + 1) % 3, r1 = (i + 2) % 3, c0 = (j + 1) % 3, c1 = (j + 2) % 3;
            /* cyclic index order builds the sign in */
            C[i][j] = B[r0][c0] * B[r1][c1] - B[r0][c1] * B[r1][c0];
        }
    }
    det = B[0][0] * C[0][0] + B[0][1] * C[0][1] + B[0][2] * C[0][2];
    if (det == 0.0 || !isfinite(det)) return 0;
    inv = 1.0 / det;
    if (!isfinite(inv)) return 0;
    /* (B^-1)[i][j] = C[j][i] / det */
    for (i = 0; i < 2; i++)
        for (j = 0; j < 3; j++)
            if (!isfinite(C[j][i] * inv)) return 0;
    for (i = 0; i < 2; i++)
        for (j = 0; j < 3; j++) M[i][j] = C[j][i] * inv;
    return 1;
}
#endif

/* Silverman's second-order kernel, eq 11, as a function of r^2 >= 0:
   3/pi (1 - r^2)^2 inside the unit disc, 0 outside (and for NaN). Its
   integral over the unit disc is 1. */
static double pds__kernel_silverman(double r2)
{
    double w;
    if (!(r2 < 1.0)) return 0.0;
    w = 1.0 - r2;
    return (3.0 / PDS__PI) * w * w;
}

/* True major semi-axis A of the footprint ellipse with conjugate
   semi-diameters a = Du/2, b = Dv/2 (the ellipse c + a cos s + b sin s):
   A^2 = (|a|^2+|b|^2)/2 + sqrt(((|a|^2-|b|^2)/2)^2 + (a.b)^2), the larger
   eigenvalue of a a^T + b b^T. max(|a|,|b|) <= A <= sqrt(|a|^2+|b|^2); the
   paper's r_max = max(|a|,|b|) under-covers skewed footprints. */
static double pds__footprint_major_axis(pds__v3 dpdu, pds__v3 dpdv)
{
    pds__v3 a = pds__scale(dpdu, 0.5), b = pds__scale(dpdv, 0.5);
    double aa = pds__dot(a, a), bb = pds__dot(b, b), ab = pds__dot(a, b);
    double h = 0.5 * (aa - bb);
    return sqrt(0.5 * (aa + bb) + sqrt(h * h + ab * ab));
}

/* Widen a needle footprint (an extension of the paper, --min-aspect): the
   ellipse x = a cos t + b sin t, a = dpdu/2, b = dpdv/2, has its principal
   semi-axes at tan 2t = 2 a.b / (a.a - b.b) (where |x|^2 is extremal):
   A = a cos t + b sin t (major), B = -a sin t + b cos t (minor, orthogonal
   to A). If |B| < min_aspect |A|, B is lengthened to min_aspect |A| (along
   np x A if it has collapsed) and the differentials replaced by 2A, 2B:
   the same ellipse, only wider. Returns 1 when it changed them. */
/* The same with a floor on both semi-axes: at least min_width (scene
   units) each, besides the minor one's min_aspect times the major. */
static int pds__footprint_widen_to(pds__v3 *dpdu, pds__v3 *dpdv, pds__v3 np, double min_aspect, double min_width)
{
    pds__v3 a = pds__scale(*dpdu, 0.5), b = pds__scale(*dpdv, 0.5), A, B, dir;
    double aa = pds__dot(a, a), bb = pds__dot(b, b), ab = pds__dot(a, b), t = 0.5 * atan2(2.0 * ab, aa - bb);
    double la, lb, want_a, want_b;
    if (!(min_aspect > 0.0) && !(min_width > 0.0)) return 0;
    A = pds__add(pds__scale(a, cos(t)), pds__scale(b, sin(t)));
    B = pds__add(pds__scale(a, -sin(t)), pds__scale(b, cos(t)));
    la = pds__length(A);
    lb = pds__length(B);
    if (!(la > 0.0) || !isfinite(la) || !isfinite(lb)) return 0;
    want_a = fmax(la, min_width);
    want_b = fmax(min_aspect * want_a, min_width);
    if (lb >= want_b && la >= want_a) return 0;
    if (want_b > want_a) want_b = want_a;
    dir = lb > 1e-12 * la ? pds__scale(B, 1.0 / lb) : pds__cross(np, pds__scale(A, 1.0 / la));
    if (!(pds__length(dir) > 0.5)) return 0; /* A along np: nothing sensible to do */
    *dpdu = pds__scale(A, 2.0 * want_a / la);
    *dpdv = pds__scale(pds__normalize(dir), 2.0 * fmax(lb, want_b));
    return 1;
}

#if !defined(PDS_NO_BASELINES) || defined(PDS_TEST)
static int pds__footprint_widen(pds__v3 *dpdu, pds__v3 *dpdv, pds__v3 np, double min_aspect)
{
    return pds__footprint_widen_to(dpdu, dpdv, np, min_aspect, 0.0);
}
#endif

/* Anisotropy metric m_a of appendix B: with Dmax / Dmin the longer /
   shorter positional vector, the part of Dmin perpendicular to Dmax over
   |Dmax|. In [0,1]; 1 = isotropic (equal orthogonal vectors), < 0.1
   "highly anisotropic"; 0 for a degenerate footprint. */
static double pds__footprint_anisotropy(pds__v3 dpdu, pds__v3 dpdv)
{
    pds__v3 mx = dpdu, mn = dpdv, perp;
    double l2, m;
    if (pds__dot(dpdv, dpdv) > pds__dot(dpdu, dpdu)) {
        mx = dpdv;
        mn = dpdu;
    }
    l2 = pds__dot(mx, mx);
    if (!(l2 > 0.0) || !isfinite(l2)) return 0.0;
    perp = pds__sub(mn, pds__scale(mx, pds__dot(mx, mn) / l2));
    m = pds__length(perp) / sqrt(l2);
    if (!isfinite(m)) return 0.0;
    return m > 1.0 ? 1.0 : m;
}

/* ===================================================================== */
/* >>image                                                               */
/* ===================================================================== */
/* Images in memory are linear RGB floats, rows top to bottom (pds_image).
   Three file formats go out (PFM, PNG, OpenEXR), two come in (PFM,
   OpenEXR), each carrying the image's metadata (pds_image_meta: see
   "metadata" below; the OpenEXR layout is described at its writer):

   PFM (netpbm "portable float map"): three ASCII header tokens, each ended
   by whitespace: "PF" (RGB) or "Pf" (grey), "W H", and a non-zero decimal
   scale whose sign gives the byte order of the raster (negative = little-
   endian, positive = big-endian; its magnitude is ignored here, as most
   readers do). Exactly one whitespace byte follows the scale, then the
   raster: IEEE-754 binary32 samples, pixels left to right, rows BOTTOM TO
   TOP. We write "PF\nW H\n-1.0\n" and a little-endian raster; we read
   either byte order and either channel count (grey is copied to R, G, B).
   Bytes are assembled with shifts from a uint32_t that shares the float's
   bits (memcpy), so the code does not depend on the host's byte order.

   PNG (ISO/IEC 15948), written without zlib: signature, IHDR (8-bit RGB),
   one IDAT holding a zlib stream (RFC 1950: header 0x78 0x9C, Adler-32
   of the raw stream as trailer, big-endian), then IEND. Each chunk ends
   with the CRC-32 (reflected polynomial 0xEDB88320) of its type and data.
   The raw stream is, per row, a filter type byte and the filtered R G B
   bytes; the filter (None, Sub, Up, Average, Paeth; ISO/IEC 15948 sec. 9)
   is chosen per row as the one whose output, read as signed bytes, has
   the least sum of absolute values (the heuristic of sec. 12.8).
   The deflate data (RFC 1951) comes from our own compressor: LZ77 over a
   32 KiB window (hash of the next 3 bytes, hash chains cut after
   PDS__LZ_CHAIN candidates, one-step lazy matching, lengths 3-258), its
   tokens cut into blocks of PDS__LZ_BLOCK_TOKENS; each block is written in
   whichever of the three encodings is shortest: dynamic Huffman (BTYPE 2;
   code lengths limited to 15 bits, 7 for the code-length code), fixed
   Huffman (BTYPE 1) or stored (BTYPE 0, for noise). The output depends
   only on the pixels and the exposure: same image, same bytes.
   Tone mapping: linear * 2^exposure_stops, the tone curve (clamp to
   [0,1] by default; see "tone curves" below), sRGB transfer curve
   (IEC 61966-2-1), round to the nearest 8-bit value; NaN gives 0.

   Every writer builds the whole file in memory and hands it to
   pds__write_file_atomic, so a failure never leaves a partial file. */

pds_status pds_image_alloc(pds_image *img, int width, int height)
{
    size_t n;
    if (!img) return PDS_ERR_INVALID_ARG;
    img->width = 0;
    img->height = 0;
    img->rgb = NULL;
    if (width <= 0 || height <= 0) return PDS_ERR_INVALID_ARG;
    if (width > PDS_MAX_RESOLUTION || height > PDS_MAX_RESOLUTION) return PDS_ERR_LIMIT;
    n = (size_t)width * (size_t)height;
    if (n > ((size_t)-1) / (3 * sizeof(float))) return PDS_ERR_NOMEM;
    img->rgb = (float *)calloc(n * 3, sizeof(float));
    if (!img->rgb) return PDS_ERR_NOMEM;
    img->width = width;
    img->height = height;
    return PDS_OK;
}

void pds_image_free(pds_image *img)
{
    if (!img) return;
    free(img->rgb);
    img->rgb = NULL;
    img->width = 0;
    img->height = 0;
}

/* Checks an image handed to a writer: non-empty and within the limits. */
static pds_status pds__image_check(const pds_image *img, const char *path, pds_error *err)
{
    if (!path || !path[0])
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "no output file name given");
    if (!img || !img->rgb || img->width <= 0 || img->height <= 0)
        return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "cannot write an empty image");
    if (img->width > PDS_MAX_RESOLUTION || img->height > PDS_MAX_RESOLUTION)
        return pds__fail(err, PDS_ERR_LIMIT, path, 0, 0,
                         "image size %dx%d exceeds the limit of %d pixels per side",
                         img->width, img->height, PDS_MAX_RESOLUTION);
    return PDS_OK;
}

/* ------------------------------------------------------------- metadata */

/* Metadata is a list of text entries (pds.h pds_image_meta). Keys follow
   PNG's keyword rules (ISO/IEC 15948 sec. 11.3.4.3: 1-79 Latin-1
   characters, no leading, trailing or consecutive spaces), narrowed to
   printable ASCII without '=' (the PFM trailer's separator) and to
   PDS_IMAGE_META_KEY - 1 characters; values are printable ASCII, which
   every container carries unchanged. */
static int pds__meta_key_ok(const char *key)
{
    size_t i, n;
    if (!key) return 0;
    n = strlen(key);
    if (n == 0 || n >= PDS_IMAGE_META_KEY || key[0] == ' ' || key[n - 1] == ' ') return 0;
    for (i = 0; i < n; i++) {
        unsigned char c = (unsigned char)key[i];
        if (c < 0x20 || c > 0x7e || c == '=') return 0;
        if (c == ' ' && key[i + 1] == ' ') return 0;
    }
    return 1;
}

static int pds__meta_value_ok(const char *value, size_t n)
{
    size_t i;
    if (n >= PDS_IMAGE_META_VALUE) return 0;
    for (i = 0; i < n; i++)
        if ((unsigned char)value[i] < 0x20 || (unsigned char)value[i] > 0x7e) return 0;
    return 1;
}

pds_status pds_image_meta_set(pds_image_meta *meta, const char *key, const char *value)
{
    int i;
    if (!meta || !value || !pds__meta_key_ok(key) || !pds__meta_value_ok(value, strlen(value)))
        return PDS_ERR_INVALID_ARG;
    if (meta->count < 0 || meta->count > PDS_IMAGE_META_MAX) return PDS_ERR_INVALID_ARG;
    for (i = 0; i < meta->count; i++)
        if (!strcmp(meta->key[i], key)) break;
    if (i == meta->count) {
        if (meta->count == PDS_IMAGE_META_MAX) return PDS_ERR_LIMIT;
        pds__strlcpy(meta->key[i], key, PDS_IMAGE_META_KEY);
        meta->count++;
    }
    pds__strlcpy(meta->value[i], value, PDS_IMAGE_META_VALUE);
    return PDS_OK;
}

const char *pds_image_meta_get(const pds_image_meta *meta, const char *key)
{
    int i;
    if (!meta || !key) return NULL;
    for (i = 0; i < meta->count && i < PDS_IMAGE_META_MAX; i++)
        if (!strcmp(meta->key[i], key)) return meta->value[i];
    return NULL;
}

/* Add key = value[0..n) read from a file: kept only if both are valid
   and there is room (a reader never fails on metadata it cannot keep). */
static void pds__meta_add_text(pds_image_meta *meta, const char *key, const char *value, size_t n)
{
    char v[PDS_IMAGE_META_VALUE];
    if (!meta || !pds__meta_value_ok(value, n)) return;
    memcpy(v, value, n);
    v[n] = '\0';
    (void)pds_image_meta_set(meta, key, v);
}

/* ---------------------------------------------------------- tone curves */

/* The tone curves a PNG may get after the exposure (README "Images"):

   clamp     min(max(x, 0), 1): what a display shows of a linear value.
   reinhard  Reinhard, Stark, Shirley and Ferwerda, "Photographic Tone
             Reproduction for Digital Images", SIGGRAPH 2002, eq. 3:
             L_d = L / (1 + L), on the luminance L = 0.2126 R + 0.7152 G
             + 0.0722 B (ITU-R BT.709); each channel is scaled by
             L_d / L = 1 / (1 + L), so hues stay. The exposure plays the
             role of the paper's key a / L_w (its eq. 2); no L_white
             (eq. 4): highlights approach 1 without reaching it.
   filmic    Narkowicz, "ACES Filmic Tone Mapping Curve" (2015), a
             rational fit of the ACES reference rendering and output
             transforms: f(x) = x (2.51 x + 0.03) / (x (2.43 x + 0.59)
             + 0.14), clamped to [0,1], per channel.

   The result is then sRGB-encoded as before. */
double pds_tonemap_curve(pds_tonemap tonemap, double x)
{
    double y;
    if (!(x > 0.0)) return 0.0; /* negative, zero and NaN */
    switch (tonemap) {
    case PDS_TONEMAP_REINHARD:
        return x < 1e300 ? x / (1.0 + x) : 1.0;
    case PDS_TONEMAP_FILMIC:
        if (x > 1e30) return 1.0;
        y = x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14);
        return y < 1.0 ? y : 1.0;
    case PDS_TONEMAP_CLAMP:
    default:
        return x < 1.0 ? x : 1.0;
    }
}

#ifndef PDS_NO_PNG
/* One pixel, rgb linear after the exposure, through the curve. Reinhard
   scales the three channels by one factor (see above); the others map
   each channel on its own. Results are in [0,1]; NaN gives 0. */
static void pds__tonemap_pixel(pds_tonemap tonemap, double rgb[3])
{
    int k;
    if (tonemap == PDS_TONEMAP_REINHARD) {
        double L = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
        double s = L > 0.0 && L < 1e300 ? 1.0 / (1.0 + L) : L > 0.0 ? 0.0 : 1.0;
        for (k = 0; k < 3; k++) rgb[k] = pds_tonemap_curve(PDS_TONEMAP_CLAMP, rgb[k] * s);
        return;
    }
    for (k = 0; k < 3; k++) rgb[k] = pds_tonemap_curve(tonemap, rgb[k]);
}
#endif

/* ------------------------------------------------------------------ PFM */

/* Bits of a float as an unsigned 32-bit integer, and back. The float and
   the integer share their byte order on every platform we care about, so
   shifting the integer gives a host-independent byte sequence. */
static uint32_t pds__float_bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

static float pds__bits_float(uint32_t u)
{
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

/* PFM header whitespace (netpbm: blanks, TABs, CRs, LFs; plus VT, FF). Not
   isspace(): the locale must not change what a file means. */
static int pds__pfm_is_space(unsigned char c)
{
    return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

/* 1-based line and column of byte offset pos in buf. */
static void pds__pfm_where(const unsigned char *buf, size_t pos, int *line, int *column)
{
    size_t i;
    int l = 1, c = 1;
    for (i = 0; i < pos; i++) {
        if (buf[i] == '\n') {
            l++;
            c = 1;
        } else {
            c++;
        }
    }
    *line = l;
    *column = c;
}

/* Copy a header token into a printable, NUL-terminated buffer (truncated
   with "..." if long; non-printable bytes become '?'). */
static void pds__pfm_token_text(const unsigned char *tok, size_t len, char *out, size_t n)
{
    size_t i, k = 0;
    for (i = 0; i < len && k + 4 < n; i++)
        out[k++] = (tok[i] >= 0x20 && tok[i] < 0x7f) ? (char)tok[i] : '?';
    if (i < len) {
        out[k++] = '.';
        out[k++] = '.';
        out[k++] = '.';
    }
    out[k] = '\0';
}

/* Header parser state: the file bytes, where we are, and the file name
   for messages. */
typedef struct pds__pfm_reader {
    const unsigned char *buf;
    size_t size, pos;
    const char *path;
    pds_error *err;
} pds__pfm_reader;

/* Fail with the location of byte offset pos. */
static pds_status pds__pfm_fail_at(pds__pfm_reader *r, pds_status status, size_t pos,
                                   const char *msg)
{
    int line, column;
    pds__pfm_where(r->buf, pos, &line, &column);
    return pds__fail(r->err, status, r->path, line, column, "%s", msg);
}

/* Skip whitespace and return the next token's start and length; returns 0
   if the file ends first (then *start is the end of the file). */
static int pds__pfm_token(pds__pfm_reader *r, size_t *start, size_t *len)
{
    while (r->pos < r->size && pds__pfm_is_space(r->buf[r->pos])) r->pos++;
    *start = r->pos;
    while (r->pos < r->size && !pds__pfm_is_space(r->buf[r->pos])) r->pos++;
    *len = r->pos - *start;
    return *len > 0;
}

/* Read one header dimension ("width" or "height"): a positive decimal
   integer no larger than PDS_MAX_RESOLUTION. */
static pds_status pds__pfm_dimension(pds__pfm_reader *r, const char *name, int *out)
{
    size_t start, len, i;
    long value = 0;
    char text[48], msg[160];
    if (!pds__pfm_token(r, &start, &len)) {
        snprintf(msg, sizeof msg, "the file ends inside the header (expected the image %s)", name);
        return pds__pfm_fail_at(r, PDS_ERR_PARSE, start, msg);
    }
    pds__pfm_token_text(r->buf + start, len, text, sizeof text);
    i = (r->buf[start] == '+' || r->buf[start] == '-') ? 1 : 0;
    if (i == len) {
        snprintf(msg, sizeof msg, "expected the image %s (a positive integer), got '%s'", name, text);
        return pds__pfm_fail_at(r, PDS_ERR_PARSE, start, msg);
    }
    for (; i < len; i++) {
        unsigned char c = r->buf[start + i];
        if (c < '0' || c > '9') {
            snprintf(msg, sizeof msg, "expected the image %s (a positive integer), got '%s'", name, text);
            return pds__pfm_fail_at(r, PDS_ERR_PARSE, start, msg);
        }
        /* Saturate instead of overflowing: anything past the limit is
           reported as too large. */
        if (value <= PDS_MAX_RESOLUTION) value = value * 10 + (c - '0');
    }
    if (r->buf[start] == '-' || value == 0) {
        snprintf(msg, sizeof msg, "the image %s must be positive, got '%s'", name, text);
        return pds__pfm_fail_at(r, PDS_ERR_PARSE, start, msg);
    }
    if (value > PDS_MAX_RESOLUTION) {
        snprintf(msg, sizeof msg, "the image %s %s exceeds the limit of %d pixels", name, text,
                 PDS_MAX_RESOLUTION);
        return pds__pfm_fail_at(r, PDS_ERR_LIMIT, start, msg);
    }
    *out = (int)value;
    return PDS_OK;
}

/* Read the scale token: a decimal number [+-]digits[.digits][(e|E)[+-]digits]
   with at least one mantissa digit, not zero. Only its sign is used:
   *little_endian = (scale < 0). Parsed by hand so the C locale's decimal
   point does not matter. */
static pds_status pds__pfm_scale(pds__pfm_reader *r, int *little_endian)
{
    size_t start, len, i = 0;
    int negative = 0, digits = 0, nonzero = 0;
    char text[48], msg[160];
    const unsigned char *t;
    if (!pds__pfm_token(r, &start, &len))
        return pds__pfm_fail_at(r, PDS_ERR_PARSE, start,
                                "the file ends inside the header (expected the scale)");
    t = r->buf + start;
    pds__pfm_token_text(t, len, text, sizeof text);
    if (t[i] == '+' || t[i] == '-') negative = t[i++] == '-';
    for (; i < len && t[i] >= '0' && t[i] <= '9'; i++, digits++) nonzero |= t[i] != '0';
    if (i < len && t[i] == '.') {
        for (i++; i < len && t[i] >= '0' && t[i] <= '9'; i++, digits++) nonzero |= t[i] != '0';
    }
    if (digits > 0 && i < len && (t[i] == 'e' || t[i] == 'E')) {
        int exp_digits = 0;
        i++;
        if (i < len && (t[i] == '+' || t[i] == '-')) i++;
        for (; i < len && t[i] >= '0' && t[i] <= '9'; i++) exp_digits++;
        if (exp_digits == 0) digits = 0;
    }
    if (digits == 0 || i != len) {
        snprintf(msg, sizeof msg, "expected the scale (a non-zero number, negative for "
                                  "little-endian data), got '%s'", text);
        return pds__pfm_fail_at(r, PDS_ERR_PARSE, start, msg);
    }
    if (!nonzero)
        return pds__pfm_fail_at(r, PDS_ERR_PARSE, start,
                                "the scale must not be zero (its sign gives the byte order: "
                                "negative = little-endian, positive = big-endian)");
    *little_endian = negative;
    return PDS_OK;
}

/* The metadata trailer pds writes after a PFM's raster (the format has no
   place for it): the line "# pds metadata", then one "key=value" line per
   entry. PFM readers read W x H x 3 floats after the header and stop, so
   the trailer does not change what they see (OpenImageIO's oiiotool and
   every earlier pds accept it; a reader that insists on the exact file
   size would not). Bytes after the raster that do not start so are
   ignored, as are lines that are not a valid entry. */
#define PDS__PFM_TRAILER "# pds metadata\n"

static void pds__pfm_read_trailer(const unsigned char *p, size_t n, pds_image_meta *meta)
{
    size_t tag = sizeof PDS__PFM_TRAILER - 1, i;
    if (!meta || n < tag || memcmp(p, PDS__PFM_TRAILER, tag) != 0) return;
    for (i = tag; i < n;) {
        size_t start = i, eq = 0;
        char key[PDS_IMAGE_META_KEY];
        while (i < n && p[i] != '\n') {
            if (p[i] == '=' && !eq) eq = i;
            i++;
        }
        if (i < n && eq > start && eq - start < sizeof key) {
            memcpy(key, p + start, eq - start);
            key[eq - start] = '\0';
            if (pds__meta_key_ok(key)) pds__meta_add_text(meta, key, (const char *)p + eq + 1, i - eq - 1);
        }
        i++;
    }
}

/* Read a PFM file into *img (allocated here; the caller frees it with
   pds_image_free). "PF" gives RGB, "Pf" grey copied into all three
   channels. Rows are flipped from the file's bottom-to-top order. On
   failure *img is left empty. */
static pds_status pds__pfm_read(const char *path, pds_image *img, pds_image_meta *meta, pds_error *err)
{
    char *data = NULL;
    size_t size = 0, raster, need, per_row, x, y;
    int width = 0, height = 0, channels, little_endian = 1;
    pds__pfm_reader r;
    pds_status st;
    if (meta) meta->count = 0;

    if (!img) return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "no image to read into");
    img->width = img->height = 0;
    img->rgb = NULL;
    if (!path || !path[0])
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "no input file name given");
    st = pds__read_file(path, PDS__MAX_PFM_BYTES, "PFM image", &data, &size, err);
    if (st != PDS_OK) return st;

    r.buf = (const unsigned char *)data;
    r.size = size;
    r.pos = 0;
    r.path = path;
    r.err = err;

    if (size < 2 || r.buf[0] != 'P' || (r.buf[1] != 'F' && r.buf[1] != 'f')) {
        free(data);
        return pds__fail(err, PDS_ERR_PARSE, path, 1, 1,
                         "not a PFM file (it must start with 'PF' or 'Pf')");
    }
    channels = r.buf[1] == 'F' ? 3 : 1;
    if (size < 3 || !pds__pfm_is_space(r.buf[2])) {
        st = pds__pfm_fail_at(&r, PDS_ERR_PARSE, 2,
                              "not a PFM file (expected whitespace after the 'PF' or 'Pf' magic)");
        free(data);
        return st;
    }
    r.pos = 2;
    st = pds__pfm_dimension(&r, "width", &width);
    if (st == PDS_OK) st = pds__pfm_dimension(&r, "height", &height);
    if (st == PDS_OK) st = pds__pfm_scale(&r, &little_endian);
    if (st != PDS_OK) {
        free(data);
        return st;
    }
    /* Exactly one whitespace byte separates the scale from the raster (the
       raster's first byte may itself look like whitespace). */
    if (r.pos >= size) {
        free(data);
        return pds__fail(err, PDS_ERR_PARSE, path, 0, 0,
                         "the file is truncated: it ends right after the header, "
                         "before the raster");
    }
    raster = r.pos + 1;
    per_row = (size_t)width * (size_t)channels * 4;
    need = per_row * (size_t)height; /* <= 16384^2 * 12: checked below for 32-bit size_t */
    if ((size_t)height > ((size_t)-1) / per_row || size - raster < need) {
        pds__fail(err, PDS_ERR_PARSE, path, 0, 0,
                  "the file is truncated: a %dx%d %s raster needs %llu bytes, "
                  "but only %llu follow the header",
                  width, height, channels == 3 ? "RGB" : "grey", (unsigned long long)need,
                  (unsigned long long)(size - raster));
        free(data);
        return PDS_ERR_PARSE;
    }
    st = pds_image_alloc(img, width, height);
    if (st != PDS_OK) {
        free(data);
        return st == PDS_ERR_NOMEM ? pds__nomem(err)
                                   : pds__fail(err, st, path, 0, 0, "bad image size %dx%d", width, height);
    }
    /* File row y (0 = bottom) is image row height-1-y. */
    for (y = 0; y < (size_t)height; y++) {
        const unsigned char *src = r.buf + raster + y * per_row;
        float *dst = img->rgb + ((size_t)height - 1 - y) * (size_t)width * 3;
        for (x = 0; x < (size_t)width * (size_t)channels; x++) {
            const unsigned char *b = src + 4 * x;
            uint32_t u;
            float f;
            if (little_endian)
                u = (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
            else
                u = (uint32_t)b[3] | (uint32_t)b[2] << 8 | (uint32_t)b[1] << 16 | (uint32_t)b[0] << 24;
            f = pds__bits_float(u);
            if ((u & 0x7F800000u) == 0x7F800000u) {
                /* x, y as a viewer shows them: from the top-left corner */
                size_t px = channels == 3 ? x / 3 : x;
                pds__fail(err, PDS_ERR_PARSE, path, 0, 0, "pixel (%lu, %lu) %s is %s: an image must hold finite values",
                          (unsigned long)px, (unsigned long)((size_t)height - 1 - y),
                          channels == 3 ? (x % 3 == 0 ? "red" : x % 3 == 1 ? "green" : "blue") : "grey",
                          (u & 0x007FFFFFu) ? "NaN" : (u >> 31) ? "-infinity" : "infinity");
                pds_image_free(img);
                free(data);
                return PDS_ERR_PARSE;
            }
            if (channels == 3) {
                dst[x] = f;
            } else {
                dst[3 * x + 0] = f;
                dst[3 * x + 1] = f;
                dst[3 * x + 2] = f;
            }
        }
    }
    pds__pfm_read_trailer(r.buf + raster + need, size - raster - need, meta);
    free(data);
    return PDS_OK;
}

pds_status pds_image_read_pfm(const char *path, pds_image *img, pds_error *err)
{
    return pds__pfm_read(path, img, NULL, err);
}

/* Write *img as a little-endian RGB PFM ("PF", scale -1.0), rows bottom to
   top. The float bits are stored unchanged, so a read gives them back bit
   for bit (NaN payloads and negative zero included). */
static pds_status pds__pfm_write(const char *path, const pds_image *img, const pds_image_meta *meta,
                                 pds_error *err)
{
    char header[64];
    int hlen, i, nmeta = meta ? meta->count : 0;
    size_t per_row, total, trailer = 0, x, y;
    unsigned char *buf, *p;
    pds_status st = pds__image_check(img, path, err);
    if (st != PDS_OK) return st;
    if (nmeta < 0 || nmeta > PDS_IMAGE_META_MAX)
        return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "bad metadata count %d", nmeta);
    for (i = 0; i < nmeta; i++) {
        if (!pds__meta_key_ok(meta->key[i]) || !pds__meta_value_ok(meta->value[i], strlen(meta->value[i])))
            return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "bad metadata entry %d", i);
        trailer += strlen(meta->key[i]) + strlen(meta->value[i]) + 2;
    }
    if (nmeta > 0) trailer += sizeof PDS__PFM_TRAILER - 1;
    hlen = snprintf(header, sizeof header, "PF\n%d %d\n-1.0\n", img->width, img->height);
    per_row = (size_t)img->width * 12;
    if ((size_t)img->height > (((size_t)-1) - (size_t)hlen - trailer) / per_row) return pds__nomem(err);
    total = (size_t)hlen + per_row * (size_t)img->height + trailer;
    buf = (unsigned char *)malloc(total);
    if (!buf) return pds__nomem(err);
    memcpy(buf, header, (size_t)hlen);
    p = buf + hlen;
    for (y = 0; y < (size_t)img->height; y++) {
        const float *src = img->rgb + ((size_t)img->height - 1 - y) * (size_t)img->width * 3;
        for (x = 0; x < (size_t)img->width * 3; x++) {
            uint32_t u = pds__float_bits(src[x]);
            p[0] = (unsigned char)(u & 0xffu);
            p[1] = (unsigned char)((u >> 8) & 0xffu);
            p[2] = (unsigned char)((u >> 16) & 0xffu);
            p[3] = (unsigned char)((u >> 24) & 0xffu);
            p += 4;
        }
    }
    if (nmeta > 0) {
        memcpy(p, PDS__PFM_TRAILER, sizeof PDS__PFM_TRAILER - 1);
        p += sizeof PDS__PFM_TRAILER - 1;
        for (i = 0; i < nmeta; i++) {
            size_t kn = strlen(meta->key[i]), vn = strlen(meta->value[i]);
            memcpy(p, meta->key[i], kn);
            p[kn] = '=';
            memcpy(p + kn + 1, meta->value[i], vn);
            p[kn + 1 + vn] = '\n';
            p += kn + vn + 2;
        }
    }
    st = pds__write_file_atomic(path, buf, total, err);
    free(buf);
    return st;
}

pds_status pds_image_write_pfm(const char *path, const pds_image *img, pds_error *err)
{
    return pds__pfm_write(path, img, NULL, err);
}

/* ------------------------------------------------------------------ PNG */

/* sRGB transfer curve (IEC 61966-2-1) of a linear value: clamp to [0,1]
   (NaN counts as 0), then 12.92 c below 0.0031308 and 1.055 c^(1/2.4) -
   0.055 above. Returns the encoded value in [0,1]. Shared by the PNG
   writer and SSIM. */
static double pds__srgb_encode(double linear)
{
    double c = linear;
    if (!(c > 0.0)) return 0.0; /* also catches NaN */
    if (c >= 1.0) return 1.0;
    if (c <= 0.0031308) return 12.92 * c;
    return 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

#ifndef PDS_NO_PNG
/* CRC-32 as used by PNG and zlib (ISO 3309 / ITU-T V.42): reflected
   polynomial 0xEDB88320, register preset to all ones and inverted at the
   end. Continue a running CRC by passing the previous result; start with 0.
   The 1 KiB table is rebuilt per call (a PNG needs four calls), which keeps
   the library free of mutable globals and of a 256-entry literal. */
static uint32_t pds__crc32_update(uint32_t crc, const void *data, size_t n)
{
    uint32_t table[256];
    const unsigned char *p = (const unsigned char *)data;
    uint32_t i, k;
    for (i = 0; i < 256; i++) {
        uint32_t c = i;
        for (k = 0; k < 8; k++) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
        table[i] = c;
    }
    crc ^= 0xFFFFFFFFu;
    while (n--) crc = table[(crc ^ *p++) & 0xffu] ^ (crc >> 8);
    return crc ^ 0xFFFFFFFFu;
}

/* Adler-32 (RFC 1950): a = 1 + sum of bytes, b = sum of the successive a,
   both mod 65521; value b << 16 | a. Start with 1. The modulo is taken
   every 5552 bytes, the most that cannot overflow 32 bits (as in zlib). */
static uint32_t pds__adler32_update(uint32_t adler, const void *data, size_t n)
{
    const unsigned char *p = (const unsigned char *)data;
    uint32_t a = adler & 0xffffu, b = (adler >> 16) & 0xffffu;
    while (n > 0) {
        size_t k = n < 5552 ? n : 5552;
        n -= k;
        while (k--) {
            a += *p++;
            b += a;
        }
        a %= 65521u;
        b %= 65521u;
    }
    return (b << 16) | a;
}

static void pds__put_u32_be(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)((v >> 24) & 0xffu);
    p[1] = (unsigned char)((v >> 16) & 0xffu);
    p[2] = (unsigned char)((v >> 8) & 0xffu);
    p[3] = (unsigned char)(v & 0xffu);
}

/* ------------------------------------------------------------ deflate */

/* The deflate compressor (RFC 1951) behind the PNG writer. Its stages:
   LZ77 turns the input into tokens (a literal byte, or a copy of len
   earlier bytes from dist back); each block of tokens is then coded with
   Huffman codes built from the block's own symbol counts (sec. 3.2.7),
   or the fixed codes (sec. 3.2.6), or stored raw (sec. 3.2.4). */

#define PDS__LZ_WINDOW 32768          /* RFC 1951's window; dist < this */
#define PDS__LZ_HASH_BITS 15          /* 2^15 hash chains */
#define PDS__LZ_CHAIN 128             /* candidates tried per position, at most */
#define PDS__LZ_LAZY 32               /* take a match this long without looking one byte on */
#define PDS__LZ_BLOCK_TOKENS 65536    /* tokens per deflate block, at most */

/* Bits are sent least significant first and packed into bytes from the
   low bit up (RFC 1951 sec. 3.1.1). Huffman codes are kept bit-reversed
   so that they go out by the same rule. The buffer grows as needed; when
   memory runs out, nomem is set and later output is dropped. */
typedef struct pds__bitout {
    unsigned char *buf;
    size_t len, cap;
    uint32_t acc; /* bits not yet in buf, the next to go out lowest */
    int nbits;    /* how many; below 8 between calls */
    int nomem;
} pds__bitout;

static void pds__out_bytes(pds__bitout *o, const void *data, size_t n)
{
    if (o->nomem || n == 0) return;
    if (pds__grow((void **)&o->buf, &o->cap, o->len + n, 1)) {
        o->nomem = 1;
        return;
    }
    memcpy(o->buf + o->len, data, n);
    o->len += n;
}

/* Append the low n bits of value (n <= 16). */
static void pds__out_bits(pds__bitout *o, uint32_t value, int n)
{
    o->acc |= value << o->nbits;
    o->nbits += n;
    while (o->nbits >= 8) {
        unsigned char b = (unsigned char)(o->acc & 0xffu);
        pds__out_bytes(o, &b, 1);
        o->acc >>= 8;
        o->nbits -= 8;
    }
}

/* Pad with zero bits to a byte boundary. */
static void pds__out_align(pds__bitout *o)
{
    if (o->nbits > 0) pds__out_bits(o, 0, 8 - o->nbits);
}

/* Length codes 257-285 and distance codes 0-29: the first value each
   stands for and its number of extra bits (RFC 1951 sec. 3.2.5). */
static const uint16_t pds__deflate_len_base[29] = {
    3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 15, 17, 19, 23, 27, 31,
    35, 43, 51, 59, 67, 83, 99, 115, 131, 163, 195, 227, 258};
static const unsigned char pds__deflate_len_extra[29] = {
    0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
static const uint16_t pds__deflate_dist_base[30] = {
    1, 2, 3, 4, 5, 7, 9, 13, 17, 25, 33, 49, 65, 97, 129, 193,
    257, 385, 513, 769, 1025, 1537, 2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577};
static const unsigned char pds__deflate_dist_extra[30] = {
    0, 0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13, 13};

/* The order in which the code-length code's lengths are sent (sec. 3.2.7). */
static const unsigned char pds__deflate_cl_order[19] = {
    16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15};

/* Index 0-28 of the length code for a match length 3-258 (258 has its
   own code, 285, although 284 could also reach it). */
static int pds__deflate_len_index(unsigned len)
{
    int i = 28;
    while (pds__deflate_len_base[i] > len) i--;
    return i;
}

/* Distance code 0-29 for a distance 1-32768. */
static int pds__deflate_dist_code(unsigned dist)
{
    int i = 29;
    while (pds__deflate_dist_base[i] > dist) i--;
    return i;
}

/* Code lengths of a length-limited Huffman code: n <= 288 symbols with
   the given counts; unused symbols get 0, a lone used symbol gets 1. A
   Huffman tree (the two-queue construction over the counts sorted
   ascending, ties by symbol number, so the result is deterministic) gives
   each symbol's depth. Leaves deeper than limit are then lifted by the
   Adjust_BITS procedure of ITU-T T.81 (JPEG) Annex K.3: take two leaves at
   the deepest level i, put one a level up in place of their parent, and
   hang the other with a leaf from level j <= i - 2 below that leaf's old
   place. Each step keeps the Kraft sum at exactly 1. Last, the lengths
   are dealt out again, shortest to the most frequent. Needs 2^limit >= the
   number of used symbols (true for deflate's alphabets). */
static void pds__huff_lengths(const uint32_t *freq, int n, int limit, unsigned char *len)
{
    int sym[288], parent[2 * 288], depth[2 * 288], count[2 * 288];
    uint64_t w[2 * 288];
    int m = 0, i, j, k, leaf, node, next, maxd = 0;
    for (i = 0; i < n; i++) {
        len[i] = 0;
        if (freq[i] > 0) sym[m++] = i;
    }
    if (m == 0) return;
    if (m == 1) {
        len[sym[0]] = 1;
        return;
    }
    for (i = 1; i < m; i++) { /* insertion sort: stable, so ties stay by symbol */
        int s = sym[i];
        for (j = i; j > 0 && freq[sym[j - 1]] > freq[s]; j--) sym[j] = sym[j - 1];
        sym[j] = s;
    }
    /* Leaves are nodes 0..m-1 in ascending weight; internal nodes m..2m-2
       are made in non-decreasing weight, so the two lightest are always at
       the heads of the two queues. */
    for (i = 0; i < m; i++) w[i] = freq[sym[i]];
    leaf = 0;
    node = m;
    for (next = m; next < 2 * m - 1; next++) {
        int pick[2];
        for (k = 0; k < 2; k++) {
            if (leaf < m && (node >= next || w[leaf] <= w[node])) pick[k] = leaf++;
            else pick[k] = node++;
        }
        w[next] = w[pick[0]] + w[pick[1]];
        parent[pick[0]] = next;
        parent[pick[1]] = next;
    }
    depth[2 * m - 2] = 0;
    for (i = 2 * m - 3; i >= 0; i--) depth[i] = depth[parent[i]] + 1; /* parents come later */
    for (i = 0; i <= m; i++) count[i] = 0;
    for (i = 0; i < m; i++) {
        count[depth[i]]++;
        if (depth[i] > maxd) maxd = depth[i];
    }
    /* Adjust_BITS. count[i] is even here: the Kraft sum is 1 and no leaf
       is deeper than i. A leaf at j <= i - 2 exists while m <= 2^limit. */
    for (i = maxd; i > limit; i--) {
        while (count[i] > 0) {
            j = i - 2;
            while (count[j] == 0) j--;
            count[i] -= 2;
            count[i - 1] += 1;
            count[j + 1] += 2;
            count[j] -= 1;
        }
    }
    k = 0;
    for (i = maxd < limit ? maxd : limit; i >= 1; i--)
        for (j = 0; j < count[i]; j++) len[sym[k++]] = (unsigned char)i;
}

/* Canonical Huffman codes from code lengths (RFC 1951 sec. 3.2.2), each
   bit-reversed for pds__out_bits. Lengths are at most 15. */
static void pds__huff_codes(const unsigned char *len, int n, uint16_t *code)
{
    int bl_count[16], next_code[16], i, b, c = 0;
    for (b = 0; b < 16; b++) bl_count[b] = 0;
    for (i = 0; i < n; i++) bl_count[len[i]]++;
    bl_count[0] = 0;
    for (b = 1; b < 16; b++) {
        c = (c + bl_count[b - 1]) << 1;
        next_code[b] = c;
    }
    for (i = 0; i < n; i++) {
        int v, r = 0;
        code[i] = 0;
        if (len[i] == 0) continue;
        v = next_code[len[i]]++;
        for (b = 0; b < len[i]; b++) {
            r = (r << 1) | (v & 1);
            v >>= 1;
        }
        code[i] = (uint16_t)r;
    }
}

/* Make sure at least two symbols have a count, giving the first unused
   ones a count of 1. A code with one used symbol would be one 1-bit
   code with one unused; with two it is complete, which every inflater
   accepts (zlib's deflate does the same). The added symbols never occur. */
static void pds__huff_two_used(uint32_t *freq, int n)
{
    int i, used = 0;
    for (i = 0; i < n; i++) used += freq[i] > 0;
    for (i = 0; i < n && used < 2; i++)
        if (freq[i] == 0) {
            freq[i] = 1;
            used++;
        }
}

/* An LZ77 token: a literal byte (dist 0, len = the byte) or a copy of len
   (3-258) bytes from dist (1-32767) back. */
typedef struct pds__lz_token {
    uint16_t len;
    uint16_t dist;
} pds__lz_token;

/* Hash chains over the input: head[h] is the latest position (plus 1;
   0 = none) whose next 3 bytes hash to h, and prev[p % WINDOW] the one
   before p with p's hash. Positions below `inserted` are in the chains. */
typedef struct pds__lz {
    const unsigned char *data;
    size_t n, inserted;
    uint32_t *head; /* 2^PDS__LZ_HASH_BITS entries */
    uint32_t *prev; /* PDS__LZ_WINDOW entries */
} pds__lz;

static uint32_t pds__lz_hash(const unsigned char *p)
{
    uint32_t v = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16;
    return (v * 2654435761u) >> (32 - PDS__LZ_HASH_BITS);
}

static void pds__lz_insert_until(pds__lz *z, size_t end)
{
    for (; z->inserted < end; z->inserted++) {
        size_t p = z->inserted;
        uint32_t h;
        if (p + 3 > z->n) continue;
        h = pds__lz_hash(z->data + p);
        z->prev[p & (PDS__LZ_WINDOW - 1)] = z->head[h];
        z->head[h] = (uint32_t)(p + 1);
    }
}

/* The longest match for the bytes at pos among the earlier positions in
   the chains (pos itself not yet in them), trying at most chain
   candidates, nearest first. Returns its length, or 0 if none reaches 3;
   *dist gets its distance. Only distances below PDS__LZ_WINDOW are tried:
   prev[] slots further back have been overwritten. */
static size_t pds__lz_find(const pds__lz *z, size_t pos, size_t chain, size_t *dist)
{
    const unsigned char *cur = z->data + pos;
    size_t max_len = z->n - pos, best = 2;
    uint32_t c;
    *dist = 0;
    if (max_len > 258) max_len = 258;
    if (max_len < 3) return 0;
    c = z->head[pds__lz_hash(cur)];
    while (c != 0 && chain-- > 0) {
        size_t cand = c - 1, k;
        const unsigned char *old = z->data + cand;
        if (pos - cand >= PDS__LZ_WINDOW) break;
        if (old[best] == cur[best] && old[0] == cur[0] && old[1] == cur[1]) {
            for (k = 2; k < max_len && old[k] == cur[k]; k++) {}
            if (k > best) {
                best = k;
                *dist = pos - cand;
                if (k == max_len) break;
            }
        }
        c = z->prev[cand & (PDS__LZ_WINDOW - 1)];
    }
    return *dist ? best : 0;
}

/* Send tokens[0..ntok) and end-of-block with the given codes. */
static void pds__deflate_put_tokens(pds__bitout *o, const pds__lz_token *tok, size_t ntok,
                                    const unsigned char *llen, const uint16_t *lcode,
                                    const unsigned char *dlen, const uint16_t *dcode)
{
    size_t t;
    for (t = 0; t < ntok; t++) {
        if (tok[t].dist == 0) {
            pds__out_bits(o, lcode[tok[t].len], llen[tok[t].len]);
        } else {
            int li = pds__deflate_len_index(tok[t].len), dc = pds__deflate_dist_code(tok[t].dist);
            pds__out_bits(o, lcode[257 + li], llen[257 + li]);
            pds__out_bits(o, (uint32_t)(tok[t].len - pds__deflate_len_base[li]), pds__deflate_len_extra[li]);
            pds__out_bits(o, dcode[dc], dlen[dc]);
            pds__out_bits(o, (uint32_t)(tok[t].dist - pds__deflate_dist_base[dc]), pds__deflate_dist_extra[dc]);
        }
    }
    pds__out_bits(o, lcode[256], llen[256]);
}

/* One deflate block (BFINAL = final) holding tokens[0..ntok), which
   encode raw[0..raw_len), in whichever encoding takes fewest bits:
   dynamic Huffman, fixed Huffman, or stored (as many stored blocks of
   at most 65535 bytes as needed; only the last can carry BFINAL).

   The dynamic block's header (sec. 3.2.7): HLIT - 257 (5 bits), HDIST - 1
   (5), HCLEN - 4 (4), HCLEN 3-bit lengths of the code-length code in
   pds__deflate_cl_order, then the HLIT + HDIST code lengths as one
   sequence in that code, runs shortened by symbols 16 (repeat the
   previous length 3-6 times, 2 extra bits), 17 (3-10 zeros, 3 bits) and
   18 (11-138 zeros, 7 bits). */
static void pds__deflate_block(pds__bitout *o, const pds__lz_token *tok, size_t ntok,
                               const unsigned char *raw, size_t raw_len, int final)
{
    uint32_t lfreq[288], dfreq[30], lf2[288], df2[30], cfreq[19];
    unsigned char llen[288], dlen[30], clen[19], seq[286 + 30], rle[286 + 30], rle_extra[286 + 30];
    uint16_t lcode[288], dcode[30], ccode[19];
    uint64_t extra_bits = 0, dyn_bits, fixed_bits, stored_bits;
    size_t t, nseq, nrle = 0, i, blocks;
    int hlit, hdist, hclen, s;

    /* Symbol counts, and the extra bits every Huffman encoding shares. */
    memset(lfreq, 0, sizeof lfreq);
    memset(dfreq, 0, sizeof dfreq);
    for (t = 0; t < ntok; t++) {
        if (tok[t].dist == 0) {
            lfreq[tok[t].len]++;
        } else {
            int li = pds__deflate_len_index(tok[t].len), dc = pds__deflate_dist_code(tok[t].dist);
            lfreq[257 + li]++;
            dfreq[dc]++;
            extra_bits += (uint64_t)pds__deflate_len_extra[li] + pds__deflate_dist_extra[dc];
        }
    }
    lfreq[256] = 1; /* end of block */

    /* Dynamic codes and their header. */
    memcpy(lf2, lfreq, sizeof lf2);
    memcpy(df2, dfreq, sizeof df2);
    pds__huff_two_used(lf2, 286);
    pds__huff_two_used(df2, 30);
    pds__huff_lengths(lf2, 286, 15, llen);
    pds__huff_lengths(df2, 30, 15, dlen);
    for (hlit = 286; hlit > 257 && llen[hlit - 1] == 0; hlit--) {}
    for (hdist = 30; hdist > 1 && dlen[hdist - 1] == 0; hdist--) {}
    memcpy(seq, llen, (size_t)hlit);
    memcpy(seq + hlit, dlen, (size_t)hdist);
    nseq = (size_t)(hlit + hdist);
    memset(cfreq, 0, sizeof cfreq);
    for (i = 0; i < nseq;) {
        size_t run = 1;
        while (i + run < nseq && run < 138 && seq[i + run] == seq[i]) run++;
        if (seq[i] == 0 && run >= 3) {
            rle[nrle] = (unsigned char)(run >= 11 ? 18 : 17);
            rle_extra[nrle] = (unsigned char)(run - (run >= 11 ? 11 : 3));
        } else if (i > 0 && seq[i - 1] == seq[i] && run >= 3) {
            if (run > 6) run = 6;
            rle[nrle] = 16;
            rle_extra[nrle] = (unsigned char)(run - 3);
        } else {
            run = 1;
            rle[nrle] = seq[i];
            rle_extra[nrle] = 0;
        }
        cfreq[rle[nrle]]++;
        nrle++;
        i += run;
    }
    pds__huff_two_used(cfreq, 19);
    pds__huff_lengths(cfreq, 19, 7, clen);
    for (hclen = 19; hclen > 4 && clen[pds__deflate_cl_order[hclen - 1]] == 0; hclen--) {}

    /* Sizes in bits of the three encodings. */
    dyn_bits = 3 + 5 + 5 + 4 + 3 * (uint64_t)hclen + extra_bits;
    for (i = 0; i < nrle; i++)
        dyn_bits += clen[rle[i]] + (rle[i] == 16 ? 2 : rle[i] == 17 ? 3 : rle[i] == 18 ? 7 : 0);
    for (s = 0; s < 286; s++) dyn_bits += (uint64_t)lfreq[s] * llen[s];
    for (s = 0; s < 30; s++) dyn_bits += (uint64_t)dfreq[s] * dlen[s];
    fixed_bits = 3 + extra_bits;
    for (s = 0; s < 286; s++) fixed_bits += (uint64_t)lfreq[s] * (s < 144 ? 8 : s < 256 ? 9 : s < 280 ? 7 : 8);
    for (s = 0; s < 30; s++) fixed_bits += (uint64_t)dfreq[s] * 5;
    blocks = raw_len == 0 ? 1 : (raw_len + 65534) / 65535;
    stored_bits = (uint64_t)blocks * (3 + 7 + 32) + 8 * (uint64_t)raw_len; /* 7: padding, at most */

    if (stored_bits < dyn_bits && stored_bits < fixed_bits) {
        do {
            size_t k = raw_len < 65535 ? raw_len : 65535;
            unsigned char lens[4];
            lens[0] = (unsigned char)(k & 0xffu);
            lens[1] = (unsigned char)(k >> 8);
            lens[2] = (unsigned char)(~k & 0xffu);
            lens[3] = (unsigned char)((~k >> 8) & 0xffu);
            pds__out_bits(o, final && k == raw_len ? 1u : 0u, 1);
            pds__out_bits(o, 0, 2); /* BTYPE 00 */
            pds__out_align(o);
            pds__out_bytes(o, lens, 4);
            pds__out_bytes(o, raw, k);
            raw += k;
            raw_len -= k;
        } while (raw_len > 0);
    } else if (fixed_bits <= dyn_bits) {
        for (s = 0; s < 288; s++) llen[s] = (unsigned char)(s < 144 ? 8 : s < 256 ? 9 : s < 280 ? 7 : 8);
        for (s = 0; s < 30; s++) dlen[s] = 5;
        pds__huff_codes(llen, 288, lcode);
        pds__huff_codes(dlen, 30, dcode);
        pds__out_bits(o, final ? 1u : 0u, 1);
        pds__out_bits(o, 1, 2); /* BTYPE 01 */
        pds__deflate_put_tokens(o, tok, ntok, llen, lcode, dlen, dcode);
    } else {
        pds__huff_codes(llen, 286, lcode);
        pds__huff_codes(dlen, 30, dcode);
        pds__huff_codes(clen, 19, ccode);
        pds__out_bits(o, final ? 1u : 0u, 1);
        pds__out_bits(o, 2, 2); /* BTYPE 10 */
        pds__out_bits(o, (uint32_t)(hlit - 257), 5);
        pds__out_bits(o, (uint32_t)(hdist - 1), 5);
        pds__out_bits(o, (uint32_t)(hclen - 4), 4);
        for (s = 0; s < hclen; s++) pds__out_bits(o, clen[pds__deflate_cl_order[s]], 3);
        for (i = 0; i < nrle; i++) {
            pds__out_bits(o, ccode[rle[i]], clen[rle[i]]);
            if (rle[i] >= 16) pds__out_bits(o, rle_extra[i], rle[i] == 16 ? 2 : rle[i] == 17 ? 3 : 7);
        }
        pds__deflate_put_tokens(o, tok, ntok, llen, lcode, dlen, dcode);
    }
}

/* Compress data[0..n) into a complete deflate stream appended to o,
   ending on a byte boundary. LZ77 with one-step lazy matching: a match
   found at pos is dropped for a literal if the match at pos + 1 is
   longer. Blocks end after about PDS__LZ_BLOCK_TOKENS tokens. Sets
   o->nomem when memory runs out. */
static void pds__deflate(pds__bitout *o, const unsigned char *data, size_t n)
{
    pds__lz z;
    pds__lz_token *tok;
    size_t ntok = 0, pos = 0, block_start = 0;
    z.data = data;
    z.n = n;
    z.inserted = 0;
    z.head = (uint32_t *)calloc((size_t)1 << PDS__LZ_HASH_BITS, sizeof(uint32_t));
    z.prev = (uint32_t *)calloc(PDS__LZ_WINDOW, sizeof(uint32_t));
    tok = (pds__lz_token *)malloc(PDS__LZ_BLOCK_TOKENS * sizeof *tok);
    if (!z.head || !z.prev || !tok) {
        o->nomem = 1;
        n = 0;
    }
    while (pos < n && !o->nomem) {
        size_t len, dist, len2, dist2;
        /* Room for one token more than the lazy loop below can add. */
        if (ntok + PDS__LZ_LAZY + 1 > PDS__LZ_BLOCK_TOKENS) {
            pds__deflate_block(o, tok, ntok, data + block_start, pos - block_start, 0);
            ntok = 0;
            block_start = pos;
        }
        pds__lz_insert_until(&z, pos);
        len = pds__lz_find(&z, pos, PDS__LZ_CHAIN, &dist);
        /* Each literal here makes len longer, so at most LAZY of them. */
        while (len >= 3 && len < PDS__LZ_LAZY && pos + 1 < n) {
            pds__lz_insert_until(&z, pos + 1);
            len2 = pds__lz_find(&z, pos + 1, PDS__LZ_CHAIN, &dist2);
            if (len2 <= len) break;
            tok[ntok].len = data[pos];
            tok[ntok].dist = 0;
            ntok++;
            pos++;
            len = len2;
            dist = dist2;
        }
        if (len >= 3) {
            tok[ntok].len = (uint16_t)len;
            tok[ntok].dist = (uint16_t)dist;
            pos += len;
        } else {
            tok[ntok].len = data[pos];
            tok[ntok].dist = 0;
            pos++;
        }
        ntok++;
    }
    if (!o->nomem) pds__deflate_block(o, tok, ntok, data + block_start, n - block_start, 1);
    pds__out_align(o);
    free(z.head);
    free(z.prev);
    free(tok);
}

/* ---------------------------------------------------------- PNG proper */

/* PNG's Paeth predictor (ISO/IEC 15948 sec. 9.4): of the left byte a,
   the one above b and the upper-left c, the one nearest to a + b - c,
   ties going to a, then b. */
static int pds__png_paeth(int a, int b, int c)
{
    int p = a + b - c;
    int pa = abs(p - a), pb = abs(p - b), pc = abs(p - c);
    if (pa <= pb && pa <= pc) return a;
    return pb <= pc ? b : c;
}

/* Apply filter type 0-4 (None, Sub, Up, Average, Paeth; ISO/IEC 15948
   sec. 9.2) to one row of n bytes, bpp bytes per pixel: out[i] = cur[i]
   minus the predictor, modulo 256. prior is the row above (zeros above
   the first row); bytes left of the row count as 0. */
static void pds__png_filter(int type, const unsigned char *cur, const unsigned char *prior,
                            size_t n, size_t bpp, unsigned char *out)
{
    size_t i;
    for (i = 0; i < n; i++) {
        int a = i >= bpp ? cur[i - bpp] : 0, b = prior[i], pred;
        switch (type) {
        case 0: pred = 0; break;
        case 1: pred = a; break;
        case 2: pred = b; break;
        case 3: pred = (a + b) / 2; break;
        default: pred = pds__png_paeth(a, b, i >= bpp ? prior[i - bpp] : 0); break;
        }
        out[i] = (unsigned char)((cur[i] - pred) & 0xff);
    }
}

/* The filter type for a row by the heuristic of ISO/IEC 15948 sec. 12.8:
   the one whose output, each byte read as signed (-128..127), has the
   least sum of absolute values; ties go to the lower type. All five sums
   are taken in one pass over the row. */
static int pds__png_pick_filter(const unsigned char *cur, const unsigned char *prior, size_t n, size_t bpp)
{
    size_t sum[5] = {0, 0, 0, 0, 0}, i;
    int type, best = 0;
    for (i = 0; i < n; i++) {
        int a = i >= bpp ? cur[i - bpp] : 0, b = prior[i], c = i >= bpp ? prior[i - bpp] : 0;
        int pred[5], k;
        pred[0] = 0;
        pred[1] = a;
        pred[2] = b;
        pred[3] = (a + b) / 2;
        pred[4] = pds__png_paeth(a, b, c);
        for (k = 0; k < 5; k++) {
            unsigned v = (unsigned)(cur[i] - pred[k]) & 0xffu;
            sum[k] += v < 128 ? v : 256 - v;
        }
    }
    for (type = 1; type < 5; type++)
        if (sum[type] < sum[best]) best = type;
    return best;
}

/* Write *img as an 8-bit RGB PNG, tone-mapped: value * 2^exposure_stops,
   the tone curve (clamp by default), sRGB-encoded, rounded. File layout
   (all integers big-endian):
     8  signature 89 50 4E 47 0D 0A 1A 0A
     25 IHDR: len 13 | "IHDR" | W, H, depth 8, colour 2, 0, 0, 0 | CRC
     tEXt, one per metadata entry: len | "tEXt" | key | 00 | value | CRC
          (ISO/IEC 15948 sec. 11.3.4.3; before IDAT, as sec. 5.6 allows)
     IDAT: len | "IDAT" | 78 9C | deflate blocks | Adler-32 | CRC
     12 IEND: len 0 | "IEND" | CRC
   The filtered raw stream (H * (1 + 3 W) bytes) is built whole before it
   is compressed. */
static pds_status pds__png_write(const char *path, const pds_image *img, double exposure_stops,
                                 pds_tonemap tonemap, const pds_image_meta *meta, pds_error *err)
{
    static const unsigned char signature[8] = {0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a};
    static const unsigned char zlib_header[2] = {
        0x78, /* CM 8 (deflate), CINFO 7 (32 KiB window) */
        0x9C  /* FLEVEL 2 (default), no dictionary; 0x789C = 31 * 996 */
    };
    size_t row_len, raw_len, idat_at, idat_len, x, y;
    unsigned char *raw, *rows, *cur, *prior, chunk[25];
    double gain;
    int i, nmeta = meta ? meta->count : 0;
    pds__bitout o;
    pds_status st = pds__image_check(img, path, err);
    if (st != PDS_OK) return st;
    if (!(exposure_stops > -1e300 && exposure_stops < 1e300))
        return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "the exposure must be a finite number");
    if (tonemap != PDS_TONEMAP_CLAMP && tonemap != PDS_TONEMAP_REINHARD && tonemap != PDS_TONEMAP_FILMIC)
        return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "unknown tone curve %d", (int)tonemap);
    if (nmeta < 0 || nmeta > PDS_IMAGE_META_MAX)
        return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "bad metadata count %d", nmeta);
    for (i = 0; i < nmeta; i++)
        if (!pds__meta_key_ok(meta->key[i]) || !pds__meta_value_ok(meta->value[i], strlen(meta->value[i])))
            return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "bad metadata entry %d", i);
    gain = pow(2.0, exposure_stops);

    /* Sizes: W, H <= 16384 keep raw_len under 2^30, so the IDAT length
       (raw_len plus 5 bytes per 65535 at worst) fits its 31 bits and
       nothing here overflows a 32-bit size_t. */
    row_len = 3 * (size_t)img->width;
    raw_len = (1 + row_len) * (size_t)img->height;
    raw = (unsigned char *)malloc(raw_len);
    rows = (unsigned char *)calloc(2, row_len); /* prior (zeros above row 0), cur */
    if (!raw || !rows) {
        free(raw);
        free(rows);
        return pds__nomem(err);
    }
    prior = rows;
    cur = rows + row_len;
    for (y = 0; y < (size_t)img->height; y++) {
        const float *src = img->rgb + y * row_len;
        unsigned char *dst = raw + y * (1 + row_len), *swap;
        if (tonemap == PDS_TONEMAP_CLAMP) {
            for (x = 0; x < row_len; x++) {
                double e = pds__srgb_encode((double)src[x] * gain);
                cur[x] = (unsigned char)(e * 255.0 + 0.5);
            }
        } else {
            for (x = 0; x < row_len; x += 3) {
                double c[3];
                int k;
                for (k = 0; k < 3; k++) c[k] = (double)src[x + (size_t)k] * gain;
                pds__tonemap_pixel(tonemap, c);
                for (k = 0; k < 3; k++) cur[x + (size_t)k] = (unsigned char)(pds__srgb_encode(c[k]) * 255.0 + 0.5);
            }
        }
        dst[0] = (unsigned char)pds__png_pick_filter(cur, prior, row_len, 3);
        pds__png_filter(dst[0], cur, prior, row_len, 3, dst + 1);
        swap = prior;
        prior = cur;
        cur = swap;
    }
    free(rows);

    memset(&o, 0, sizeof o);
    pds__out_bytes(&o, signature, 8);
    pds__put_u32_be(chunk, 13);
    memcpy(chunk + 4, "IHDR", 4);
    pds__put_u32_be(chunk + 8, (uint32_t)img->width);
    pds__put_u32_be(chunk + 12, (uint32_t)img->height);
    chunk[16] = 8; /* bit depth */
    chunk[17] = 2; /* colour type: RGB */
    chunk[18] = 0; /* compression: deflate */
    chunk[19] = 0; /* filter method 0 (the five types) */
    chunk[20] = 0; /* no interlace */
    pds__put_u32_be(chunk + 21, pds__crc32_update(0, chunk + 4, 4 + 13));
    pds__out_bytes(&o, chunk, 25);
    for (i = 0; i < nmeta && !o.nomem; i++) {
        size_t kn = strlen(meta->key[i]), vn = strlen(meta->value[i]), at = o.len;
        pds__put_u32_be(chunk, (uint32_t)(kn + 1 + vn));
        memcpy(chunk + 4, "tEXt", 4);
        pds__out_bytes(&o, chunk, 8);
        pds__out_bytes(&o, meta->key[i], kn + 1); /* with its NUL separator */
        pds__out_bytes(&o, meta->value[i], vn);
        if (o.nomem) break;
        pds__put_u32_be(chunk, pds__crc32_update(0, o.buf + at + 4, 4 + kn + 1 + vn));
        pds__out_bytes(&o, chunk, 4);
    }

    idat_at = o.len;
    pds__out_bytes(&o, "\0\0\0\0IDAT", 8); /* the length is filled in below */
    pds__out_bytes(&o, zlib_header, 2);
    pds__deflate(&o, raw, raw_len);
    pds__put_u32_be(chunk, pds__adler32_update(1, raw, raw_len));
    pds__out_bytes(&o, chunk, 4);
    free(raw);
    if (!o.nomem) {
        idat_len = o.len - idat_at - 8;
        pds__put_u32_be(o.buf + idat_at, (uint32_t)idat_len);
        pds__put_u32_be(chunk, pds__crc32_update(0, o.buf + idat_at + 4, 4 + idat_len));
        pds__out_bytes(&o, chunk, 4);
    }
    pds__put_u32_be(chunk, 0);
    memcpy(chunk + 4, "IEND", 4);
    pds__put_u32_be(chunk + 8, pds__crc32_update(0, chunk + 4, 4));
    pds__out_bytes(&o, chunk, 12);

    st = o.nomem ? pds__nomem(err) : pds__write_file_atomic(path, o.buf, o.len, err);
    free(o.buf);
    return st;
}

pds_status pds_image_write_png(const char *path, const pds_image *img,
                               double exposure_stops, pds_error *err)
{
    return pds__png_write(path, img, exposure_stops, PDS_TONEMAP_CLAMP, NULL, err);
}

/* ------------------------------------------------------------ inflate */

/* The deflate decoder (RFC 1951) behind the OpenEXR reader: stored
   (sec. 3.2.4), fixed Huffman (sec. 3.2.6) and dynamic Huffman blocks
   (sec. 3.2.7), decoded canonically one bit at a time (a code of length
   n is read MSB first and compared with the first code of that length,
   as RFC 1951 sec. 3.2.2 builds them). The output size is known in
   advance (an EXR block's), so the output buffer is fixed and a stream
   that would go past it is an error: no input, however made, makes the
   decoder use more memory or time than its output size allows. */

typedef struct pds__inflate {
    const unsigned char *in;
    size_t in_len, in_pos;
    uint32_t bits; /* bits not yet used, the next lowest */
    int nbits;
    unsigned char *out;
    size_t out_len, out_cap;
} pds__inflate;

/* A canonical Huffman code: how many codes of each length 1-15, and the
   symbols in code order. */
typedef struct pds__huffman {
    short count[16];
    short symbol[288];
} pds__huffman;

/* n bits (n <= 16), least significant first; -1 when the input ends. */
static long pds__inf_bits(pds__inflate *s, int n)
{
    long v;
    while (s->nbits < n) {
        if (s->in_pos >= s->in_len) return -1;
        s->bits |= (uint32_t)s->in[s->in_pos++] << s->nbits;
        s->nbits += 8;
    }
    v = (long)(s->bits & ((1u << n) - 1u));
    s->bits >>= n;
    s->nbits -= n;
    return v;
}

/* Build h from the code lengths of n symbols. 0, or -1 if the lengths
   ask for more codes than there are (over-subscribed). An incomplete
   code is accepted (RFC 1951 allows one distance code); its unused
   codes are errors when met. */
static int pds__huffman_build(pds__huffman *h, const unsigned char *length, int n)
{
    short offs[16];
    int len, sym, left = 1;
    for (len = 0; len < 16; len++) h->count[len] = 0;
    for (sym = 0; sym < n; sym++) h->count[length[sym]]++;
    for (len = 1; len < 16; len++) {
        left <<= 1;
        left -= h->count[len];
        if (left < 0) return -1;
    }
    offs[1] = 0;
    for (len = 1; len < 15; len++) offs[len + 1] = (short)(offs[len] + h->count[len]);
    for (sym = 0; sym < n; sym++)
        if (length[sym] != 0) h->symbol[offs[length[sym]]++] = (short)sym;
    return 0;
}

/* The next symbol of code h; -1 at the end of the input, -2 for a code
   the table does not have. */
static int pds__huffman_decode(pds__inflate *s, const pds__huffman *h)
{
    int code = 0, first = 0, index = 0, len;
    for (len = 1; len < 16; len++) {
        long b = pds__inf_bits(s, 1);
        int count = h->count[len];
        if (b < 0) return -1;
        code |= (int)b;
        if (code - first < count) return h->symbol[index + (code - first)];
        index += count;
        first = (first + count) << 1;
        code <<= 1;
    }
    return -2;
}

/* One block's literals and copies until its end-of-block symbol.
   NULL, or what is wrong. */
static const char *pds__inflate_codes(pds__inflate *s, const pds__huffman *lit, const pds__huffman *dist)
{
    for (;;) {
        int sym = pds__huffman_decode(s, lit);
        if (sym == -1) return "the data ends inside a block";
        if (sym < 0) return "a code that the block's table does not have";
        if (sym < 256) {
            if (s->out_len >= s->out_cap) return "more data than the block holds";
            s->out[s->out_len++] = (unsigned char)sym;
        } else if (sym == 256) {
            return NULL;
        } else {
            long extra, d;
            size_t len, back, i;
            int dsym;
            sym -= 257;
            if (sym >= 29) return "a length code out of range";
            extra = pds__inf_bits(s, pds__deflate_len_extra[sym]);
            if (extra < 0) return "the data ends inside a block";
            len = (size_t)pds__deflate_len_base[sym] + (size_t)extra;
            dsym = pds__huffman_decode(s, dist);
            if (dsym == -1) return "the data ends inside a block";
            if (dsym < 0 || dsym >= 30) return "a distance code out of range";
            d = pds__inf_bits(s, pds__deflate_dist_extra[dsym]);
            if (d < 0) return "the data ends inside a block";
            back = (size_t)pds__deflate_dist_base[dsym] + (size_t)d;
            if (back > s->out_len) return "a copy from before the start of the data";
            if (len > s->out_cap - s->out_len) return "more data than the block holds";
            for (i = 0; i < len; i++, s->out_len++) s->out[s->out_len] = s->out[s->out_len - back];
        }
    }
}

/* Decode the deflate stream in[0..in_len) into out[0..out_cap); *out_len
   gets the bytes made and *used the input bytes read. NULL, or what is
   wrong. */
static const char *pds__inflate_raw(const unsigned char *in, size_t in_len, unsigned char *out, size_t out_cap,
                                    size_t *out_len, size_t *used)
{
    static const unsigned char cl_order[19] = {16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15};
    pds__inflate s;
    pds__huffman lit, dist;
    unsigned char length[320];
    const char *why = NULL;
    long last = 0;
    memset(&s, 0, sizeof s);
    s.in = in;
    s.in_len = in_len;
    s.out = out;
    s.out_cap = out_cap;
    while (!last && !why) {
        long type;
        last = pds__inf_bits(&s, 1);
        type = pds__inf_bits(&s, 2);
        if (last < 0 || type < 0) {
            why = "the data ends before its last block";
        } else if (type == 0) {
            /* stored: to a byte boundary, LEN, NLEN = ~LEN, LEN bytes */
            size_t n;
            s.bits = 0;
            s.nbits = 0;
            if (s.in_len - s.in_pos < 4) {
                why = "the data ends inside a stored block";
                break;
            }
            n = (size_t)s.in[s.in_pos] | (size_t)s.in[s.in_pos + 1] << 8;
            if ((n ^ 0xffffu) != ((size_t)s.in[s.in_pos + 2] | (size_t)s.in[s.in_pos + 3] << 8))
                why = "a stored block's length does not match its complement";
            else if (s.in_len - s.in_pos - 4 < n)
                why = "the data ends inside a stored block";
            else if (n > s.out_cap - s.out_len)
                why = "more data than the block holds";
            if (why) break;
            memcpy(s.out + s.out_len, s.in + s.in_pos + 4, n);
            s.out_len += n;
            s.in_pos += 4 + n;
        } else if (type == 1) {
            /* fixed codes (RFC 1951 sec. 3.2.6) */
            int i;
            for (i = 0; i < 144; i++) length[i] = 8;
            for (; i < 256; i++) length[i] = 9;
            for (; i < 280; i++) length[i] = 7;
            for (; i < 288; i++) length[i] = 8;
            pds__huffman_build(&lit, length, 288);
            for (i = 0; i < 30; i++) length[i] = 5;
            pds__huffman_build(&dist, length, 30);
            why = pds__inflate_codes(&s, &lit, &dist);
        } else if (type == 2) {
            /* dynamic codes: HLIT, HDIST, HCLEN, then the code-length
               code's lengths, then the two codes' lengths with repeats
               16 (previous, 3-6 times), 17 (zero, 3-10), 18 (zero, 11-138) */
            long nlen = pds__inf_bits(&s, 5), ndist = pds__inf_bits(&s, 5), ncode = pds__inf_bits(&s, 4);
            int i, n;
            pds__huffman lencode;
            if (nlen < 0 || ndist < 0 || ncode < 0) {
                why = "the data ends inside a block header";
                break;
            }
            nlen += 257;
            ndist += 1;
            ncode += 4;
            if (nlen > 286 || ndist > 30) {
                why = "a block header with too many codes";
                break;
            }
            memset(length, 0, 19);
            for (i = 0; i < ncode; i++) {
                long v = pds__inf_bits(&s, 3);
                if (v < 0) break;
                length[cl_order[i]] = (unsigned char)v;
            }
            if (i < ncode) {
                why = "the data ends inside a block header";
                break;
            }
            if (pds__huffman_build(&lencode, length, 19) != 0) {
                why = "a block header whose code-length code is over-subscribed";
                break;
            }
            n = (int)(nlen + ndist);
            for (i = 0; i < n && !why;) {
                int sym = pds__huffman_decode(&s, &lencode), rep = 0;
                long r;
                unsigned char v = 0;
                if (sym < 0) {
                    why = sym == -1 ? "the data ends inside a block header" : "a bad code length in a block header";
                } else if (sym < 16) {
                    length[i++] = (unsigned char)sym;
                } else {
                    if (sym == 16) {
                        if (i == 0) why = "a block header repeats a length before the first";
                        else v = length[i - 1];
                        r = pds__inf_bits(&s, 2);
                        rep = 3 + (int)r;
                    } else if (sym == 17) {
                        r = pds__inf_bits(&s, 3);
                        rep = 3 + (int)r;
                    } else {
                        r = pds__inf_bits(&s, 7);
                        rep = 11 + (int)r;
                    }
                    if (!why && r < 0) why = "the data ends inside a block header";
                    else if (!why && i + rep > n) why = "a block header with more lengths than codes";
                    while (!why && rep-- > 0) length[i++] = v;
                }
            }
            if (why) break;
            if (length[256] == 0) {
                why = "a block without an end-of-block code";
                break;
            }
            if (pds__huffman_build(&lit, length, (int)nlen) != 0 ||
                pds__huffman_build(&dist, length + nlen, (int)ndist) != 0) {
                why = "a block header whose codes are over-subscribed";
                break;
            }
            why = pds__inflate_codes(&s, &lit, &dist);
        } else {
            why = "a block of the reserved type 3";
        }
    }
    *out_len = s.out_len;
    *used = s.in_pos;
    return why;
}

/* A zlib stream (RFC 1950): CMF, FLG (deflate, window <= 32 KiB, no
   preset dictionary, (CMF * 256 + FLG) % 31 == 0), the deflate data and
   the Adler-32 of the output, big-endian. Exactly out_cap bytes must come
   out. NULL, or what is wrong. */
static const char *pds__zlib_decode(const unsigned char *in, size_t in_len, unsigned char *out, size_t out_cap)
{
    size_t made = 0, used = 0;
    const char *why;
    uint32_t adler;
    if (in_len < 6) return "the zlib data is too short";
    if ((in[0] & 0x0fu) != 8 || (in[0] >> 4) > 7 || ((unsigned)in[0] * 256u + in[1]) % 31u != 0 || (in[1] & 0x20u))
        return "the zlib header is not deflate with a 32 KiB window";
    why = pds__inflate_raw(in + 2, in_len - 2, out, out_cap, &made, &used);
    if (why) return why;
    if (made != out_cap) return "the data holds fewer bytes than the block";
    if (in_len - 2 - used < 4) return "the zlib data ends before its Adler-32";
    adler = (uint32_t)in[2 + used] << 24 | (uint32_t)in[3 + used] << 16 | (uint32_t)in[4 + used] << 8 |
            (uint32_t)in[5 + used];
    if (adler != pds__adler32_update(1, out, made)) return "the Adler-32 of the data does not match";
    return NULL;
}

/* ------------------------------------------------------------- OpenEXR */

/* OpenEXR, as "OpenEXR File Layout" (openexr.com, Kainz, Bogart et al.)
   and "Technical Introduction to OpenEXR" describe it, for single-part
   scanline images. All integers little-endian.

     magic        76 2F 31 01 (20000630)
     version      4 bytes: 2, then flags (bit 9 tiled, 10 long names,
                  11 deep data, 12 multi-part; the reader takes none but
                  long names)
     header       attributes: name NUL, type NUL, int32 size, value;
                  ended by one NUL byte. Those every file has:
                    channels            chlist: per channel name NUL, int32
                                        pixel type (0 uint, 1 half, 2 float),
                                        uint8 pLinear, 3 reserved bytes,
                                        int32 xSampling, ySampling; a NUL
                                        ends the list; names sorted
                    compression         uint8: 0 none, 2 ZIPS, 3 ZIP (and
                                        others the reader refuses)
                    dataWindow          box2i: int32 xMin, yMin, xMax, yMax
                    displayWindow       box2i
                    lineOrder           uint8: 0 increasing y
                    pixelAspectRatio    float
                    screenWindowCenter  v2f
                    screenWindowWidth   float
                  and string attributes (the metadata): bytes, no NUL.
     offset table one uint64 per block of scanlines, in increasing y: the
                  block's file offset
     blocks       int32 y of the first line, int32 data size, data. The
                  data of a line: per channel in the list's order, its
                  values for x = xMin..xMax. A block holds 1 line (none,
                  ZIPS) or 16 (ZIP), the last fewer.

   ZIP and ZIPS data is the block's lines through two reversible steps,
   then a zlib stream (RFC 1950): the bytes are split, those at even
   positions first, then those at odd positions, and then each byte from
   the second on is replaced by (byte - previous byte + 128) mod 256 (the
   predictor of OpenEXR's ImfZip.cpp). When that is not smaller than the
   raw data, the raw data is stored (data size = raw size), which tells a
   reader that the block is not compressed.

   pds writes R, G, B as 32-bit floats (channel order B, G, R), data and
   display window (0, 0)-(W-1, H-1), increasing y (y = 0 is the top row,
   as in pds_image), aspect 1, screen window (0, 0) and 1, and its
   metadata as string attributes. */

#define PDS__EXR_MAGIC 20000630u
#define PDS__EXR_MAX_CHANNELS 64

static void pds__put_u32_le(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)(v & 0xffu);
    p[1] = (unsigned char)((v >> 8) & 0xffu);
    p[2] = (unsigned char)((v >> 16) & 0xffu);
    p[3] = (unsigned char)((v >> 24) & 0xffu);
}

static uint32_t pds__get_u32_le(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* A signed 32-bit little-endian integer, without implementation-defined
   conversions. */
static long pds__get_i32_le(const unsigned char *p)
{
    uint32_t u = pds__get_u32_le(p);
    return u < 0x80000000u ? (long)u : -(long)(0xffffffffu - u) - 1;
}

/* Append one attribute: name NUL, type NUL, int32 size, value. */
static void pds__exr_attribute(pds__bitout *o, const char *name, const char *type, const void *value, size_t n)
{
    unsigned char size[4];
    pds__out_bytes(o, name, strlen(name) + 1);
    pds__out_bytes(o, type, strlen(type) + 1);
    pds__put_u32_le(size, (uint32_t)n);
    pds__out_bytes(o, size, 4);
    pds__out_bytes(o, value, n);
}

/* The ZIP steps on n bytes of raw into tmp (see above): split, predict. */
static void pds__exr_zip_prepare(const unsigned char *raw, size_t n, unsigned char *tmp)
{
    size_t i, half = (n + 1) / 2;
    for (i = 0; i < n; i++) tmp[(i & 1) ? half + i / 2 : i / 2] = raw[i];
    for (i = n; i-- > 1;) tmp[i] = (unsigned char)((tmp[i] - tmp[i - 1] + 128) & 0xff);
}

/* Undo pds__exr_zip_prepare: tmp (changed) back into raw. */
static void pds__exr_zip_undo(unsigned char *tmp, size_t n, unsigned char *raw)
{
    size_t i, half = (n + 1) / 2;
    for (i = 1; i < n; i++) tmp[i] = (unsigned char)((tmp[i - 1] + tmp[i] - 128) & 0xff);
    for (i = 0; i < n; i++) raw[i] = tmp[(i & 1) ? half + i / 2 : i / 2];
}

pds_status pds_image_write_exr(const char *path, const pds_image *img, pds_exr_compression compression,
                               const pds_image_meta *meta, pds_error *err)
{
    unsigned char b[32];
    size_t W, H, lines, nblocks, line_bytes, block_bytes, table_at, blk, i;
    unsigned char *raw = NULL, *tmp = NULL;
    int nmeta = meta ? meta->count : 0, long_names = 0, k;
    pds__bitout o;
    pds_status st = pds__image_check(img, path, err);
    if (st != PDS_OK) return st;
    if (compression != PDS_EXR_NONE && compression != PDS_EXR_ZIPS && compression != PDS_EXR_ZIP)
        return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "unknown OpenEXR compression %d", (int)compression);
    if (nmeta < 0 || nmeta > PDS_IMAGE_META_MAX)
        return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "bad metadata count %d", nmeta);
    for (k = 0; k < nmeta; k++) {
        if (!pds__meta_key_ok(meta->key[k]) || !pds__meta_value_ok(meta->value[k], strlen(meta->value[k])))
            return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "bad metadata entry %d", k);
        if (strlen(meta->key[k]) > 31) long_names = 1; /* names past 31 bytes need flag bit 10 */
    }
    W = (size_t)img->width;
    H = (size_t)img->height;
    lines = compression == PDS_EXR_ZIP ? 16 : 1;
    nblocks = (H + lines - 1) / lines;
    line_bytes = 12 * W;              /* <= 196608 */
    block_bytes = lines * line_bytes; /* <= 3 MiB */
    raw = (unsigned char *)malloc(block_bytes);
    tmp = (unsigned char *)malloc(block_bytes);
    memset(&o, 0, sizeof o);
    if (!raw || !tmp) o.nomem = 1;

    pds__put_u32_le(b, PDS__EXR_MAGIC);
    b[4] = 2; /* version 2, single-part scanline */
    b[5] = (unsigned char)(long_names ? 0x04 : 0x00);
    b[6] = b[7] = 0;
    pds__out_bytes(&o, b, 8);
    {
        /* chlist: B, G, R (sorted), each float, pLinear 0, sampling 1 1 */
        unsigned char ch[3 * 18 + 1];
        const char *names = "BGR";
        for (k = 0; k < 3; k++) {
            unsigned char *c = ch + 18 * k;
            c[0] = (unsigned char)names[k];
            c[1] = 0;
            pds__put_u32_le(c + 2, 2);  /* FLOAT */
            pds__put_u32_le(c + 6, 0);  /* pLinear and reserved */
            pds__put_u32_le(c + 10, 1); /* xSampling */
            pds__put_u32_le(c + 14, 1); /* ySampling */
        }
        ch[54] = 0;
        pds__exr_attribute(&o, "channels", "chlist", ch, sizeof ch);
    }
    b[0] = (unsigned char)compression;
    pds__exr_attribute(&o, "compression", "compression", b, 1);
    pds__put_u32_le(b, 0);
    pds__put_u32_le(b + 4, 0);
    pds__put_u32_le(b + 8, (uint32_t)(W - 1));
    pds__put_u32_le(b + 12, (uint32_t)(H - 1));
    pds__exr_attribute(&o, "dataWindow", "box2i", b, 16);
    pds__exr_attribute(&o, "displayWindow", "box2i", b, 16);
    b[0] = 0; /* INCREASING_Y */
    pds__exr_attribute(&o, "lineOrder", "lineOrder", b, 1);
    pds__put_u32_le(b, pds__float_bits(1.0f));
    pds__exr_attribute(&o, "pixelAspectRatio", "float", b, 4);
    pds__put_u32_le(b, pds__float_bits(0.0f));
    pds__put_u32_le(b + 4, pds__float_bits(0.0f));
    pds__exr_attribute(&o, "screenWindowCenter", "v2f", b, 8);
    pds__put_u32_le(b, pds__float_bits(1.0f));
    pds__exr_attribute(&o, "screenWindowWidth", "float", b, 4);
    for (k = 0; k < nmeta; k++)
        pds__exr_attribute(&o, meta->key[k], "string", meta->value[k], strlen(meta->value[k]));
    b[0] = 0;
    pds__out_bytes(&o, b, 1); /* end of the header */

    /* The offset table, filled in as the blocks go out. */
    table_at = o.len;
    memset(b, 0, 8);
    for (blk = 0; blk < nblocks && !o.nomem; blk++) pds__out_bytes(&o, b, 8);

    for (blk = 0; blk < nblocks && !o.nomem; blk++) {
        size_t y0 = blk * lines, n = H - y0 < lines ? H - y0 : lines, raw_n = n * line_bytes, at = o.len, y, x;
        unsigned char *p = raw;
        uint64_t off = (uint64_t)at;
        for (y = y0; y < y0 + n; y++) {
            const float *row = img->rgb + y * W * 3;
            for (k = 2; k >= 0; k--) /* B, G, R */
                for (x = 0; x < W; x++, p += 4) pds__put_u32_le(p, pds__float_bits(row[3 * x + (size_t)k]));
        }
        for (i = 0; i < 8; i++) o.buf[table_at + 8 * blk + i] = (unsigned char)((off >> (8 * i)) & 0xffu);
        pds__put_u32_le(b, (uint32_t)y0);
        pds__out_bytes(&o, b, 8); /* y and a size filled in below */
        if (compression == PDS_EXR_NONE) {
            pds__out_bytes(&o, raw, raw_n);
        } else {
            static const unsigned char zlib_header[2] = {0x78, 0x9C}; /* as the PNG writer's */
            pds__exr_zip_prepare(raw, raw_n, tmp);
            pds__out_bytes(&o, zlib_header, 2);
            pds__deflate(&o, tmp, raw_n);
            pds__put_u32_be(b + 8, pds__adler32_update(1, tmp, raw_n));
            pds__out_bytes(&o, b + 8, 4);
            if (!o.nomem && o.len - at - 8 >= raw_n) {
                o.len = at + 8; /* not smaller: the raw lines instead */
                pds__out_bytes(&o, raw, raw_n);
            }
        }
        if (!o.nomem) pds__put_u32_le(o.buf + at + 4, (uint32_t)(o.len - at - 8));
    }
    free(raw);
    free(tmp);
    st = o.nomem ? pds__nomem(err) : pds__write_file_atomic(path, o.buf, o.len, err);
    free(o.buf);
    return st;
}

/* IEEE 754 binary16 bits to a float: sign, 5 exponent bits (bias 15),
   10 fraction bits; exponent 0 is subnormal (fraction * 2^-24), 31 is
   infinity or NaN. */
static float pds__half_to_float(unsigned h)
{
    unsigned e = (h >> 10) & 0x1fu, f = h & 0x3ffu;
    double v;
    if (e == 31) return pds__bits_float((h & 0x8000u) << 16 | 0x7f800000u | f << 13);
    v = e == 0 ? ldexp((double)f, -24) : ldexp((double)(f | 0x400u), (int)e - 25);
    return (float)((h & 0x8000u) ? -v : v);
}

/* One channel of the file's list. */
typedef struct pds__exr_channel {
    char name[256];
    int type;   /* 0 uint, 1 half, 2 float */
    int target; /* 0, 1, 2 for R, G, B; 3 for Y (grey); -1 unused */
} pds__exr_channel;

typedef struct pds__exr_reader {
    const unsigned char *buf;
    size_t size, pos;
    const char *path;
    pds_error *err;
} pds__exr_reader;

/* A NUL-terminated name of at most max bytes at r->pos into out; 0, or
   -1 when the file ends first or it is too long. */
static int pds__exr_name(pds__exr_reader *r, char *out, size_t max)
{
    size_t n = 0;
    while (r->pos + n < r->size && r->buf[r->pos + n] != 0) {
        if (n >= max) return -1;
        out[n] = (char)r->buf[r->pos + n];
        n++;
    }
    if (r->pos + n >= r->size) return -1;
    out[n] = '\0';
    r->pos += n + 1;
    return 0;
}

static pds_status pds__exr_bad(pds__exr_reader *r, const char *fmt, const char *detail)
{
    return pds__fail(r->err, PDS_ERR_PARSE, r->path, 0, 0, fmt, detail);
}

/* Parse the channel list value v[0..n). */
static pds_status pds__exr_channels(pds__exr_reader *r, const unsigned char *v, size_t n, pds__exr_channel *ch,
                                    int *count)
{
    pds__exr_reader sub = *r;
    *count = 0;
    sub.buf = v;
    sub.size = n;
    sub.pos = 0;
    for (;;) {
        pds__exr_channel *c;
        long type, xs, ys;
        if (sub.pos >= n) return pds__exr_bad(r, "%s", "the channel list ends without its closing NUL");
        if (v[sub.pos] == 0) break;
        if (*count == PDS__EXR_MAX_CHANNELS) return pds__exr_bad(r, "%s", "more than 64 channels");
        c = ch + *count;
        if (pds__exr_name(&sub, c->name, sizeof c->name - 1) != 0 || n - sub.pos < 16)
            return pds__exr_bad(r, "%s", "the channel list is cut short");
        type = pds__get_i32_le(v + sub.pos);
        xs = pds__get_i32_le(v + sub.pos + 8);
        ys = pds__get_i32_le(v + sub.pos + 12);
        sub.pos += 16;
        if (type < 0 || type > 2)
            return pds__exr_bad(r, "channel '%s' has an unknown pixel type (0 uint, 1 half, 2 float)", c->name);
        if (xs != 1 || ys != 1)
            return pds__exr_bad(r, "channel '%s' is subsampled: only full-resolution channels are supported",
                                c->name);
        c->type = (int)type;
        c->target = !strcmp(c->name, "R") ? 0 : !strcmp(c->name, "G") ? 1 : !strcmp(c->name, "B") ? 2
                  : !strcmp(c->name, "Y") ? 3 : -1;
        (*count)++;
    }
    return PDS_OK;
}

/* The index of channel prefix + c (c one of "RGB"), or -1. */
static int pds__exr_find(const pds__exr_channel *ch, int nch, const char *prefix, size_t n, char c)
{
    int k;
    for (k = 0; k < nch; k++)
        if (strlen(ch[k].name) == n + 1 && !strncmp(ch[k].name, prefix, n) && ch[k].name[n] == c) return k;
    return -1;
}

/* A file without plain R, G, B or Y channels may hold layers, channels
   named LAYER.R, LAYER.G, LAYER.B (as Blender's multilayer files and
   OpenEXR's naming convention for layers have them). Take the layer
   whose name ends in "Combined" (Blender's full image), else the first
   with all three; mark its channels. 1 if one was found. */
static int pds__exr_pick_layer(pds__exr_channel *ch, int nch)
{
    int k, best = -1, bestn = 0;
    for (k = 0; k < nch; k++) {
        size_t n = strlen(ch[k].name);
        const char *name = ch[k].name;
        int combined;
        if (n < 3 || name[n - 1] != 'R' || name[n - 2] != '.') continue;
        if (pds__exr_find(ch, nch, name, n - 1, 'G') < 0 || pds__exr_find(ch, nch, name, n - 1, 'B') < 0) continue;
        combined = n >= 10 && !strncmp(name + n - 10, "Combined", 8);
        if (best < 0 || (combined && !bestn)) {
            best = k;
            bestn = combined;
        }
    }
    if (best < 0) return 0;
    {
        size_t n = strlen(ch[best].name) - 1;
        ch[best].target = 0;
        ch[pds__exr_find(ch, nch, ch[best].name, n, 'G')].target = 1;
        ch[pds__exr_find(ch, nch, ch[best].name, n, 'B')].target = 2;
    }
    return 1;
}

/* Read an OpenEXR file (see the layout above) into *img; meta (may be
   NULL) gets its string attributes. */
static pds_status pds__exr_read(const char *path, pds_image *img, pds_image_meta *meta, pds_error *err)
{
    static const char *const comp_names[10] = {"none", "RLE", "ZIPS", "ZIP", "PIZ", "PXR24", "B44", "B44A",
                                               "DWAA", "DWAB"};
    pds__exr_channel *ch = NULL;
    pds__exr_reader r;
    char *data = NULL;
    unsigned char *raw = NULL, *tmp = NULL;
    char name[256], type[256];
    int nch = 0, have_ch = 0, have_win = 0, compression = -1, k, have[4] = {0, 0, 0, 0};
    long win[4] = {0, 0, 0, 0};
    size_t W = 0, H = 0, lines, nblocks, line_bytes = 0, blk, table;
    uint32_t flags;
    pds_status st;

    if (!img) return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "no image to read into");
    img->width = img->height = 0;
    img->rgb = NULL;
    if (meta) meta->count = 0;
    if (!path || !path[0]) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "no input file name given");
    st = pds__read_file(path, PDS__MAX_PFM_BYTES, "OpenEXR image", &data, &r.size, err);
    if (st != PDS_OK) return st;
    r.buf = (const unsigned char *)data;
    r.pos = 8;
    r.path = path;
    r.err = err;
    ch = (pds__exr_channel *)malloc(PDS__EXR_MAX_CHANNELS * sizeof *ch);
    if (!ch) {
        free(data);
        return pds__nomem(err);
    }
#define PDS__EXR_FAIL(...)                                               \
    do {                                                                 \
        st = pds__fail(err, PDS_ERR_PARSE, path, 0, 0, __VA_ARGS__);     \
        goto done;                                                       \
    } while (0)
    if (r.size < 8 || pds__get_u32_le(r.buf) != PDS__EXR_MAGIC)
        PDS__EXR_FAIL("not an OpenEXR file (it must start with the bytes 76 2F 31 01)");
    flags = pds__get_u32_le(r.buf + 4);
    if ((flags & 0xffu) != 2) PDS__EXR_FAIL("OpenEXR version %u is not supported (2 is)", (unsigned)(flags & 0xffu));
    if (flags & 0x200u) PDS__EXR_FAIL("a tiled OpenEXR file: only scanline files are supported");
    if (flags & 0x800u) PDS__EXR_FAIL("an OpenEXR file of deep data: only flat images are supported");
    if (flags & 0x1000u) PDS__EXR_FAIL("a multi-part OpenEXR file: only single-part files are supported");
    if (flags & ~0x4ffu) PDS__EXR_FAIL("unknown OpenEXR version flags 0x%x", (unsigned)(flags >> 8));

    /* The header's attributes, up to the NUL that ends them. */
    for (;;) {
        long size;
        const unsigned char *v;
        if (r.pos >= r.size) PDS__EXR_FAIL("the header is cut short");
        if (r.buf[r.pos] == 0) {
            r.pos++;
            break;
        }
        if (pds__exr_name(&r, name, 255) != 0 || pds__exr_name(&r, type, 255) != 0 || r.size - r.pos < 4)
            PDS__EXR_FAIL("the header is cut short (at byte %lu)", (unsigned long)r.pos);
        size = pds__get_i32_le(r.buf + r.pos);
        r.pos += 4;
        if (size < 0 || (unsigned long)size > r.size - r.pos)
            PDS__EXR_FAIL("attribute '%s' has a size of %ld bytes, past the end of the file", name, size);
        v = r.buf + r.pos;
        r.pos += (size_t)size;
        if (!strcmp(name, "channels")) {
            if (strcmp(type, "chlist")) PDS__EXR_FAIL("attribute 'channels' has type '%s', not chlist", type);
            if ((st = pds__exr_channels(&r, v, (size_t)size, ch, &nch)) != PDS_OK) goto done;
            have_ch = 1;
        } else if (!strcmp(name, "compression")) {
            if (strcmp(type, "compression") || size != 1) PDS__EXR_FAIL("attribute 'compression' is malformed");
            compression = v[0];
        } else if (!strcmp(name, "dataWindow")) {
            if (strcmp(type, "box2i") || size != 16) PDS__EXR_FAIL("attribute 'dataWindow' is malformed");
            for (k = 0; k < 4; k++) win[k] = pds__get_i32_le(v + 4 * k);
            have_win = 1;
        } else if (!strcmp(type, "string") && meta) {
            if (pds__meta_key_ok(name)) pds__meta_add_text(meta, name, (const char *)v, (size_t)size);
        }
    }
    if (!have_ch) PDS__EXR_FAIL("the header has no 'channels' attribute");
    if (!have_win) PDS__EXR_FAIL("the header has no 'dataWindow' attribute");
    if (compression < 0) PDS__EXR_FAIL("the header has no 'compression' attribute");
    if (compression != 0 && compression != 2 && compression != 3)
        PDS__EXR_FAIL("compression %s is not supported (none, ZIPS and ZIP are)",
                      compression < 10 ? comp_names[compression] : "(unknown)");
    if (win[2] < win[0] || win[3] < win[1] || (long long)win[2] - win[0] >= PDS_MAX_RESOLUTION ||
        (long long)win[3] - win[1] >= PDS_MAX_RESOLUTION)
        PDS__EXR_FAIL("the data window (%ld, %ld)-(%ld, %ld) is empty or wider than %d pixels", win[0], win[1],
                      win[2], win[3], PDS_MAX_RESOLUTION);
    W = (size_t)(win[2] - win[0] + 1);
    H = (size_t)(win[3] - win[1] + 1);
    for (k = 0; k < nch; k++) {
        if (ch[k].target >= 0) have[ch[k].target] = 1;
        line_bytes += W * (ch[k].type == 1 ? 2u : 4u);
    }
    if (!(have[0] && have[1] && have[2]) && !have[3]) {
        for (k = 0; k < nch; k++) ch[k].target = -1; /* a lone R or G is not an image */
        if (!pds__exr_pick_layer(ch, nch))
            PDS__EXR_FAIL("no R, G, B (or Y, or LAYER.R, .G, .B) channels: the file has %d channel%s, the "
                          "first '%s'", nch, nch == 1 ? "" : "s", nch > 0 ? ch[0].name : "");
    }
    if (have[0] && have[1] && have[2])
        for (k = 0; k < nch; k++)
            if (ch[k].target == 3) ch[k].target = -1; /* colour wins over grey */

    lines = compression == 3 ? 16 : 1;
    nblocks = (H + lines - 1) / lines;
    table = r.pos;
    /* Memory follows the file's size: raw lines fill the file, and deflate
       makes at most 1032 bytes of 1 (258 per 2 bits), so a small file
       cannot make the reader allocate a large image. */
    if (line_bytes * H / (compression == 0 ? 1 : 1032) > r.size - table)
        PDS__EXR_FAIL("the file is too short for a %lux%lu image (%lu bytes of lines)", (unsigned long)W,
                      (unsigned long)H, (unsigned long)(line_bytes * H));
    if ((r.size - table) / 8 < nblocks) PDS__EXR_FAIL("the file ends inside its offset table (%lu blocks)",
                                                      (unsigned long)nblocks);
    st = pds_image_alloc(img, (int)W, (int)H);
    if (st != PDS_OK) {
        st = st == PDS_ERR_NOMEM ? pds__nomem(err) : pds__fail(err, st, path, 0, 0, "bad image size");
        goto done;
    }
    raw = (unsigned char *)malloc(lines * line_bytes);
    tmp = (unsigned char *)malloc(lines * line_bytes);
    if (!raw || !tmp) {
        st = pds__nomem(err);
        goto done;
    }
    for (blk = 0; blk < nblocks; blk++) {
        const unsigned char *e = r.buf + table + 8 * blk, *d;
        uint64_t off = 0;
        size_t y0 = blk * lines, n = H - y0 < lines ? H - y0 : lines, want = n * line_bytes, y, x, at;
        long ly, ds;
        for (k = 7; k >= 0; k--) off = off << 8 | e[k];
        if (off < table + 8 * nblocks || off > (uint64_t)r.size || r.size - (size_t)off < 8)
            PDS__EXR_FAIL("the offset table points block %lu (line %lu) outside the file", (unsigned long)blk,
                          (unsigned long)y0);
        d = r.buf + (size_t)off;
        ly = pds__get_i32_le(d);
        ds = pds__get_i32_le(d + 4);
        if ((long long)ly - win[1] != (long long)y0)
            PDS__EXR_FAIL("block %lu says it starts at line %ld, not at %ld", (unsigned long)blk, ly,
                          win[1] + (long)y0);
        if (ds <= 0 || (unsigned long)ds > r.size - (size_t)off - 8)
            PDS__EXR_FAIL("block %lu (line %ld) has a data size of %ld bytes, past the end of the file",
                          (unsigned long)blk, ly, ds);
        if ((size_t)ds == want) {
            memcpy(raw, d + 8, want);
        } else if (compression == 0) {
            PDS__EXR_FAIL("block %lu (line %ld) holds %ld bytes; its lines need %lu", (unsigned long)blk, ly, ds,
                          (unsigned long)want);
        } else {
            const char *why = pds__zlib_decode(d + 8, (size_t)ds, tmp, want);
            if (why) PDS__EXR_FAIL("block %lu (line %ld): the ZIP data is corrupt: %s", (unsigned long)blk, ly, why);
            pds__exr_zip_undo(tmp, want, raw);
        }
        /* A line: each channel's W values in the list's order. */
        at = 0;
        for (y = 0; y < n; y++) {
            float *row = img->rgb + (y0 + y) * W * 3;
            for (k = 0; k < nch; k++) {
                size_t bytes = ch[k].type == 1 ? 2 : 4;
                int t = ch[k].target;
                for (x = 0; x < W; x++, at += bytes) {
                    const unsigned char *p = raw + at;
                    float f;
                    if (t < 0) continue;
                    if (ch[k].type == 1) f = pds__half_to_float((unsigned)p[0] | (unsigned)p[1] << 8);
                    else if (ch[k].type == 2) f = pds__bits_float(pds__get_u32_le(p));
                    else f = (float)pds__get_u32_le(p);
                    if (!(f - f == 0.0f))
                        PDS__EXR_FAIL("pixel (%lu, %lu) of channel '%s' is %s: an image must hold finite values",
                                      (unsigned long)x, (unsigned long)(y0 + y), ch[k].name,
                                      f != f ? "NaN" : f < 0 ? "-infinity" : "infinity");
                    if (t < 3) {
                        row[3 * x + (size_t)t] = f;
                    } else {
                        row[3 * x] = f;
                        row[3 * x + 1] = f;
                        row[3 * x + 2] = f;
                    }
                }
            }
        }
    }
    st = PDS_OK;
done:
#undef PDS__EXR_FAIL
    if (st != PDS_OK) {
        pds_image_free(img);
        if (meta) meta->count = 0;
    }
    free(ch);
    free(raw);
    free(tmp);
    free(data);
    return st;
}

pds_status pds_image_read_exr(const char *path, pds_image *img, pds_image_meta *meta, pds_error *err)
{
    return pds__exr_read(path, img, meta, err);
}

#else
pds_status pds_image_write_png(const char *path, const pds_image *img,
                               double exposure_stops, pds_error *err)
{
    (void)img, (void)exposure_stops;
    return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "this build leaves PNG out (PDS_NO_PNG): write a .pfm");
}

pds_status pds_image_write_exr(const char *path, const pds_image *img, pds_exr_compression compression,
                               const pds_image_meta *meta, pds_error *err)
{
    (void)img, (void)compression, (void)meta;
    return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0,
                     "this build leaves OpenEXR out (PDS_NO_PNG): write a .pfm");
}

pds_status pds_image_read_exr(const char *path, pds_image *img, pds_image_meta *meta, pds_error *err)
{
    if (img) img->width = img->height = 0, img->rgb = NULL;
    if (meta) meta->count = 0;
    return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0,
                     "this build leaves OpenEXR out (PDS_NO_PNG): read a .pfm");
}
#endif /* PDS_NO_PNG */

/* ASCII-only lower case, independent of the locale. */
static int pds__ascii_lower(int c)
{
    return (c >= 'A' && c <= 'Z') ? c - 'A' + 'a' : c;
}

/* 1 if the file name's extension (after the last '.' of the last path
   component) is ext, ignoring ASCII case. */
static int pds__has_extension(const char *path, const char *ext)
{
    const char *base = strrchr(path, '/');
    const char *dot;
    base = base ? base + 1 : path;
    dot = strrchr(base, '.');
    if (!dot) return 0;
    for (dot++; *dot && *ext; dot++, ext++)
        if (pds__ascii_lower((unsigned char)*dot) != *ext) return 0;
    return *dot == '\0' && *ext == '\0';
}

void pds_image_write_options_default(pds_image_write_options *o)
{
    if (!o) return;
    o->exposure_stops = 0.0;
    o->tonemap = PDS_TONEMAP_CLAMP;
    o->exr_compression = PDS_EXR_ZIP;
    o->meta = NULL;
}

pds_status pds_image_write_with(const char *path, const pds_image *img, const pds_image_write_options *o,
                                pds_error *err)
{
    pds_image_write_options d;
    if (!o) {
        pds_image_write_options_default(&d);
        o = &d;
    }
    if (!path || !path[0])
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "no output file name given");
    if (pds__has_extension(path, "pfm")) return pds__pfm_write(path, img, o->meta, err);
    if (pds__has_extension(path, "png")) {
#ifndef PDS_NO_PNG
        return pds__png_write(path, img, o->exposure_stops, o->tonemap, o->meta, err);
#else
        return pds_image_write_png(path, img, o->exposure_stops, err);
#endif
    }
    if (pds__has_extension(path, "exr")) return pds_image_write_exr(path, img, o->exr_compression, o->meta, err);
    return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0,
                     "cannot tell the image format from the file name: "
                     "it must end in .pfm, .png or .exr");
}

pds_status pds_image_write(const char *path, const pds_image *img,
                           double exposure_stops, pds_error *err)
{
    pds_image_write_options o;
    pds_image_write_options_default(&o);
    o.exposure_stops = exposure_stops;
    return pds_image_write_with(path, img, &o, err);
}

/* PFM or OpenEXR by the first bytes: "P" for PFM (whose reader says what
   is wrong with anything else), the EXR magic for OpenEXR. */
pds_status pds_image_read(const char *path, pds_image *img, pds_image_meta *meta, pds_error *err)
{
    unsigned char head[4] = {0, 0, 0, 0};
    FILE *f;
    if (meta) meta->count = 0;
    if (path && path[0] && (f = fopen(path, "rb")) != NULL) {
        size_t got = fread(head, 1, 4, f);
        fclose(f);
        if (got == 4 && head[0] == 0x76 && head[1] == 0x2f && head[2] == 0x31 && head[3] == 0x01)
            return pds_image_read_exr(path, img, meta, err);
    }
    return pds__pfm_read(path, img, meta, err);
}

/* ===================================================================== */
/* >>metrics                                                             */
/* ===================================================================== */
/* RMSE on the linear values, and SSIM as in Wang, Bovik, Sheikh and
   Simoncelli, "Image Quality Assessment: From Error Visibility to
   Structural Similarity", IEEE TIP 13(4), 2004, eq. 13 with their
   reference settings:

       SSIM(x, y) = (2 mu_x mu_y + C1)(2 sigma_xy + C2)
                    / ((mu_x^2 + mu_y^2 + C1)(sigma_x^2 + sigma_y^2 + C2)),
       C1 = (K1 L)^2, C2 = (K2 L)^2, K1 = 0.01, K2 = 0.03, L = 1,

   with local statistics under an 11x11 Gaussian window (sigma 1.5, weights
   summing to 1): mu = w*x, sigma_x^2 = w*x^2 - mu_x^2, sigma_xy = w*(xy) -
   mu_x mu_y (biased, as in Wang's code), at the 'valid' positions only,
   and the score is the mean of that map. No downsampling (that step came
   later than the paper).

   Colour: the comparison is on the luminance Y = 0.299 R + 0.587 G +
   0.114 B of the sRGB-encoded channels (pds__srgb_encode: clamped to [0,1],
   exposure 0, not quantised to 8 bits), i.e. on what a viewer sees.
   Images smaller than 11 pixels on a side use an n x n window, n =
   min(11, W, H) rounded down to odd, with the sigma-1.5 Gaussian
   renormalised over it.

   The Gaussian is separable, so each statistic is filtered along rows,
   then along columns. Rows are filtered as they are needed and kept in a
   ring of n rows, so memory is O(n W) whatever the image height. */

/* RMSE: sqrt of the mean over pixels and channels of (a - ref)^2, in
   double. -1 if the sizes differ or either image is empty. */
double pds_image_rmse(const pds_image *a, const pds_image *ref)
{
    size_t i, n;
    double sum = 0.0;
    if (!a || !ref || !a->rgb || !ref->rgb || a->width <= 0 || a->height <= 0) return -1.0;
    if (a->width != ref->width || a->height != ref->height) return -1.0;
    n = (size_t)a->width * (size_t)a->height * 3;
    for (i = 0; i < n; i++) {
        double d = (double)a->rgb[i] - (double)ref->rgb[i];
        sum += d * d;
    }
    return sqrt(sum / (double)n);
}

/* Luminance of one sRGB-encoded pixel (BT.601 weights, as Wang's ports). */
static double pds__ssim_luma(const float *rgb)
{
    return 0.299 * pds__srgb_encode(rgb[0]) + 0.587 * pds__srgb_encode(rgb[1])
         + 0.114 * pds__srgb_encode(rgb[2]);
}

/* The five statistics of one horizontally filtered row, wv values each. */
typedef struct pds__ssim_row {
    double *mx, *my, *xx, *yy, *xy;
} pds__ssim_row;

/* Horizontal pass for image row y: luminance of both images into lx, ly
   (W values each), then the n-tap weighted sums of x, y, x^2, y^2, xy at
   the wv = W - n + 1 valid column positions. */
static void pds__ssim_hfilter(const pds_image *a, const pds_image *b, int y, const double *w,
                              int n, int wv, double *lx, double *ly, pds__ssim_row *out)
{
    int x, k;
    const float *ra = a->rgb + (size_t)y * (size_t)a->width * 3;
    const float *rb = b->rgb + (size_t)y * (size_t)b->width * 3;
    for (x = 0; x < a->width; x++) {
        lx[x] = pds__ssim_luma(ra + 3 * x);
        ly[x] = pds__ssim_luma(rb + 3 * x);
    }
    for (x = 0; x < wv; x++) {
        double mx = 0.0, my = 0.0, xx = 0.0, yy = 0.0, xy = 0.0;
        for (k = 0; k < n; k++) {
            double vx = lx[x + k], vy = ly[x + k], wk = w[k];
            mx += wk * vx;
            my += wk * vy;
            xx += wk * vx * vx;
            yy += wk * vy * vy;
            xy += wk * (vx * vy); /* grouped so that swapping the images changes nothing */
        }
        out->mx[x] = mx;
        out->my[x] = my;
        out->xx[x] = xx;
        out->yy[x] = yy;
        out->xy[x] = xy;
    }
}

/* SSIM of a against ref into *out. Returns PDS_ERR_INVALID_ARG for empty
   or differently sized images, PDS_ERR_NOMEM if scratch memory fails. */
static pds_status pds__ssim(const pds_image *a, const pds_image *ref, double *out)
{
    const double K1 = 0.01, K2 = 0.03, L = 1.0, sigma = 1.5;
    const double C1 = (K1 * L) * (K1 * L), C2 = (K2 * L) * (K2 * L);
    double w[11], wsum = 0.0, total = 0.0;
    int n = 11, wv, hv, W, H, i, y, x, k;
    double *scratch;
    pds__ssim_row *ring;
    size_t per_row;

    if (!a || !ref || !a->rgb || !ref->rgb || a->width <= 0 || a->height <= 0)
        return PDS_ERR_INVALID_ARG;
    if (a->width != ref->width || a->height != ref->height) return PDS_ERR_INVALID_ARG;
    W = a->width;
    H = a->height;
    if (W < n) n = W;
    if (H < n) n = H;
    if (n % 2 == 0) n--;
    wv = W - n + 1;
    hv = H - n + 1;

    /* 1-D Gaussian taps normalised to sum 1; their outer product is the
       2-D window, which then sums to 1 too. */
    for (i = 0; i < n; i++) {
        double d = i - (n - 1) / 2;
        w[i] = exp(-d * d / (2.0 * sigma * sigma));
        wsum += w[i];
    }
    for (i = 0; i < n; i++) w[i] /= wsum;

    /* Scratch: two luminance rows of W, then n ring rows of 5 x wv. */
    per_row = 5 * (size_t)wv;
    ring = (pds__ssim_row *)malloc((size_t)n * sizeof *ring);
    scratch = (double *)malloc((2 * (size_t)W + (size_t)n * per_row) * sizeof(double));
    if (!ring || !scratch) {
        free(ring);
        free(scratch);
        return PDS_ERR_NOMEM;
    }
    for (i = 0; i < n; i++) {
        double *base = scratch + 2 * (size_t)W + (size_t)i * per_row;
        ring[i].mx = base;
        ring[i].my = base + wv;
        ring[i].xx = base + 2 * (size_t)wv;
        ring[i].yy = base + 3 * (size_t)wv;
        ring[i].xy = base + 4 * (size_t)wv;
    }

    for (y = 0; y < H; y++) {
        int oy = y - n + 1; /* the output row completed by input row y */
        double row_sum = 0.0;
        pds__ssim_hfilter(a, ref, y, w, n, wv, scratch, scratch + W, &ring[y % n]);
        if (oy < 0) continue;
        for (x = 0; x < wv; x++) {
            double mx = 0.0, my = 0.0, xx = 0.0, yy = 0.0, xy = 0.0;
            double vx, vy, cxy, num, den;
            for (k = 0; k < n; k++) {
                const pds__ssim_row *r = &ring[(oy + k) % n];
                mx += w[k] * r->mx[x];
                my += w[k] * r->my[x];
                xx += w[k] * r->xx[x];
                yy += w[k] * r->yy[x];
                xy += w[k] * r->xy[x];
            }
            vx = xx - mx * mx;
            vy = yy - my * my;
            cxy = xy - mx * my;
            num = (2.0 * mx * my + C1) * (2.0 * cxy + C2);
            den = (mx * mx + my * my + C1) * (vx + vy + C2);
            row_sum += num / den;
        }
        total += row_sum;
    }
    free(ring);
    free(scratch);
    *out = total / ((double)wv * (double)hv);
    return PDS_OK;
}

double pds_image_ssim(const pds_image *a, const pds_image *ref)
{
    double s;
    return pds__ssim(a, ref, &s) == PDS_OK ? s : -1.0;
}

pds_status pds_image_compare(const pds_image *a, const pds_image *ref,
                             pds_metrics *out, pds_error *err)
{
    pds_status st;
    if (!a || !ref || !out)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "compare needs two images and a result");
    if (!a->rgb || !ref->rgb || a->width <= 0 || a->height <= 0 || ref->width <= 0 || ref->height <= 0)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "cannot compare an empty image");
    if (a->width != ref->width || a->height != ref->height)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "image sizes differ: %dx%d vs %dx%d",
                         a->width, a->height, ref->width, ref->height);
    out->rmse = pds_image_rmse(a, ref);
    st = pds__ssim(a, ref, &out->ssim);
    if (st == PDS_ERR_NOMEM) return pds__nomem(err);
    if (st != PDS_OK) return pds__fail(err, st, NULL, 0, 0, "cannot compute SSIM");
    return PDS_OK;
}

/* ===================================================================== */
/* >>partial                                                             */
/* ===================================================================== */
/* The exact state of a render or of one shard of it (pds.h "shards,
   interrupt, resume"), the image made from it, and its file.

   A render's image is, pixel by pixel,

       image = E + (S+ - S-) / unit * (n_planned / emitted)

   E the eye pass's value (its sample sum over its samples, a double
   computed by one thread in sample order), S+ and S- the photon part's
   exact 128-bit sums (>>util) of its positive and negative splats (a
   spectral render's photon can add a negative amount to a channel, the
   XYZ-to-RGB matrix has negative entries, >>spectral; an RGB render's
   S- stays 0), unit their power of two, n_planned the photon count
   the photons were weighted for and emitted the photons actually in S.
   pds_render makes its image from this state too, with the same function
   (pds__partial_image), so a merge of shards that holds the same E, the
   same S and the same counts gives the same bits:
     - E of a row is computed by one shard, the one that owns the row;
     - S+ and S- of a merge are the integer sums of the parts', which do not
       depend on how the photons were split;
     - emitted is the sum of the parts' (photon-split methods) or, where
       every shard traces all photons (pm, pdm, ppm, spm), the same in each.

   Work units (the split of shard I of N, pds.h):
     split 0, rows:    eye rows I, I+N, ... (pt, preview, no caustics;
                       isc, whose shards each render the whole frame and
                       keep these rows of it)
     split 1, photons: batches of PDS__PHOTON_BATCH photons, or progressive
                       PDS's passes, I, I+N, ...; the eye rows as split 0
     split 2, gather:  one unit per shard: all photons, gathered at the
                       eye vertices of rows I, I+N, ... (pm, pdm, ppm, spm)
   gi splits as its caustic method (split 0 without caustics); every gi
   shard builds the whole global map, and only the rows it keeps get the
   final gather (>>api, pds__render_into). spm's photon count is its
   streams'.
   Within a shard the done units are always its first ones (work is
   handed out in order, and a stop lets what was handed out finish), so a
   count says which. */

#define PDS__PARTIAL_MAGIC "PDSPART\n"
#define PDS__PARTIAL_VERSION 6u
#define PDS__PARTIAL_MAX_SHARDS 1000000
#define PDS__PARTIAL_NOPT 48    /* options stored, 8 bytes each */
#define PDS__PARTIAL_NOPT_V5 47 /* format version 5's, still read */
#define PDS__PARTIAL_NOPT_V4 46 /* format version 4's, still read */
#define PDS__PARTIAL_NOPT_V3 44 /* format version 3's, still read */
#define PDS__PARTIAL_NOPT_V2 31 /* format version 2's, still read */

enum { PDS__SPLIT_ROWS = 0, PDS__SPLIT_PHOTONS = 1, PDS__SPLIT_GATHER = 2 };

struct pds_partial {
    char version[16];          /* PDS_VERSION_STRING of the library that rendered it */
    uint64_t scene_hash;       /* pds_scene_hash */
    char scene_path[512];
    pds_options opt;           /* the options that shape the image (others at defaults) */
    int width, height;
    int shard_index, shard_count;
    int split;                 /* PDS__SPLIT_* */
    long rows_own, rows_done;  /* eye rows of the shard, and the first ones done */
    long units_total;          /* photon units of the whole render */
    long units_own, units_done;
    double n_planned;          /* photon count the photons were weighted for */
    long emitted;              /* photons in photon[] */
    double unit;               /* pds__sum_unit of the scene */
    long splatted, degenerate, saturated, invalid, eye_vertices; /* stats, summed */
    double *eye;               /* width * height * 3: E of the rows done, else 0 */
    pds__sum128 *photon;       /* width * height * 3: S+; NULL for split 0 */
    pds__sum128 *neg;          /* width * height * 3: S-, spectral renders'
                                  negative sums (else 0); NULL for split 0 */
};

/* Content hash of a loaded scene: its triangles, materials, lights and
   camera (not the file names), so that parts of one render are recognised
   wherever the scene was loaded from. Every number goes in by value,
   through the rng's mixer (>>rng), never padding bytes. */
typedef struct pds__hasher {
    uint64_t h;
} pds__hasher;

static void pds__hash_u64(pds__hasher *hs, uint64_t v)
{
    hs->h = pds__mix64(hs->h ^ v);
}

static void pds__hash_f64(pds__hasher *hs, double d)
{
    uint64_t v;
    memcpy(&v, &d, sizeof v);
    pds__hash_u64(hs, v);
}

static void pds__hash_f64s(pds__hasher *hs, const double *d, size_t n)
{
    size_t i;
    for (i = 0; i < n; i++) pds__hash_f64(hs, d[i]);
}

static void pds__hash_v3(pds__hasher *hs, pds_vec3 v)
{
    pds__hash_f64(hs, v.x);
    pds__hash_f64(hs, v.y);
    pds__hash_f64(hs, v.z);
}

unsigned long long pds_scene_hash(const pds_scene *s)
{
    pds__hasher hs = {0x5044535343454e45ull}; /* "PDSSCENE" */
    size_t i;
    if (!s) return 0;
    pds__hash_u64(&hs, s->mesh.nverts);
    for (i = 0; i < 3 * s->mesh.nverts; i++) {
        uint32_t a, b;
        memcpy(&a, &s->mesh.pos[i], sizeof a);
        memcpy(&b, &s->mesh.nrm[i], sizeof b);
        pds__hash_u64(&hs, (uint64_t)a << 32 | b);
    }
    pds__hash_u64(&hs, s->mesh.ntris);
    for (i = 0; i < s->mesh.ntris; i++) {
        pds__hash_u64(&hs, (uint64_t)(uint32_t)s->mesh.idx[3 * i] << 32 | (uint32_t)s->mesh.idx[3 * i + 1]);
        pds__hash_u64(&hs, (uint64_t)(uint32_t)s->mesh.idx[3 * i + 2] << 32 | (uint32_t)s->mesh.mat[i]);
    }
    pds__hash_u64(&hs, s->materials.count);
    for (i = 0; i < s->materials.count; i++) {
        const pds_material *m = &s->materials.items[i];
        size_t c;
        for (c = 0; c < sizeof m->name && m->name[c]; c++) pds__hash_u64(&hs, (unsigned char)m->name[c]);
        pds__hash_u64(&hs, (uint64_t)m->type);
        pds__hash_f64s(&hs, m->albedo, 3);
        pds__hash_f64(&hs, m->tile_size);
        pds__hash_f64(&hs, m->tile_grout);
        pds__hash_f64s(&hs, m->grout_albedo, 3);
        pds__hash_f64s(&hs, m->reflectance, 3);
        pds__hash_f64s(&hs, m->eta, 3);
        pds__hash_f64s(&hs, m->k, 3);
        pds__hash_f64(&hs, m->ior);
        pds__hash_f64s(&hs, m->absorption, 3);
        pds__hash_f64(&hs, m->outside_ior);
        pds__hash_f64s(&hs, m->outside_absorption, 3);
        pds__hash_u64(&hs, (uint64_t)m->dispersion);
        pds__hash_f64s(&hs, m->dispersion_coef, 6);
        pds__hash_f64s(&hs, m->radiance, 3);
    }
    pds__hash_u64(&hs, s->nlights);
    for (i = 0; i < s->nlights; i++) {
        const pds_light *l = &s->lights[i];
        pds__hash_u64(&hs, (uint64_t)l->type);
        pds__hash_v3(&hs, l->position);
        pds__hash_v3(&hs, l->direction);
        pds__hash_v3(&hs, l->edge1);
        pds__hash_v3(&hs, l->edge2);
        pds__hash_f64(&hs, l->radius);
        pds__hash_f64(&hs, l->cone_inner_deg);
        pds__hash_f64(&hs, l->cone_outer_deg);
        pds__hash_f64s(&hs, l->power, 3);
        pds__hash_f64s(&hs, l->irradiance, 3);
        pds__hash_f64s(&hs, l->radiance, 3);
        pds__hash_u64(&hs, (uint64_t)(uint32_t)l->emitter_shape);
        pds__hash_u64(&hs, (uint64_t)(uint32_t)l->material);
        pds__hash_u64(&hs, (uint64_t)(uint32_t)l->first_triangle << 32 | (uint32_t)l->triangle_count);
        pds__hash_f64(&hs, l->area);
        if (l->type == PDS_LIGHT_ENVIRONMENT) {
            /* only for this type, so older scenes keep their hashes */
            pds__hash_f64s(&hs, l->sky, 3);
            pds__hash_f64s(&hs, l->ground, 3);
            pds__hash_v3(&hs, l->up);
            pds__hash_v3(&hs, l->sun_direction);
            pds__hash_f64s(&hs, l->sun_irradiance, 3);
            pds__hash_f64(&hs, l->sun_radius_deg);
        }
    }
    pds__hash_v3(&hs, s->camera.position);
    pds__hash_v3(&hs, s->camera.look_at);
    pds__hash_v3(&hs, s->camera.up);
    pds__hash_f64(&hs, s->camera.fov_deg);
    pds__hash_u64(&hs, (uint64_t)(uint32_t)s->camera.width << 32 | (uint32_t)s->camera.height);
    pds__hash_u64(&hs, (uint64_t)(uint32_t)s->camera.spp << 32 | (uint32_t)s->camera.filter);
    if (s->camera.aperture != 0.0 || s->camera.focus_distance != 0.0) {
        /* a thin lens; a pinhole hashes as before */
        pds__hash_f64(&hs, s->camera.aperture);
        pds__hash_f64(&hs, s->camera.focus_distance);
    }
    return hs.h;
}

/* The options that shape the image, in the file's order (README "Partial
   files"): integers as int64, reals as binary64, 8 bytes each. */
static void pds__partial_opt_encode(const pds_options *o, uint64_t v[PDS__PARTIAL_NOPT])
{
    const double d[] = {o->time_s, o->smoothing, o->plane_tolerance, o->min_aspect, o->pass_alpha,
                        o->pass_smoothing, o->pass_min_aspect, o->pass_min_width, o->min_width,
                        o->max_radius, o->radius, o->alpha, o->split_angle};
    int k;
    v[0] = (uint64_t)(int64_t)o->method;
    v[1] = (uint64_t)(int64_t)o->paths;
    v[2] = (uint64_t)(int64_t)o->width;
    v[3] = (uint64_t)(int64_t)o->height;
    v[4] = (uint64_t)(int64_t)o->spp;
    v[5] = (uint64_t)o->seed;
    v[6] = (uint64_t)(int64_t)o->max_depth;
    v[7] = (uint64_t)(int64_t)o->rr_depth;
    v[8] = (uint64_t)(int64_t)o->photons;
    v[9] = (uint64_t)(int64_t)o->progressive;
    v[10] = (uint64_t)(int64_t)o->pass_photons;
    v[11] = (uint64_t)(int64_t)o->photon_depth;
    v[12] = (uint64_t)(int64_t)o->k;
    v[13] = (uint64_t)(int64_t)o->kernel;
    v[14] = (uint64_t)(int64_t)o->passes;
    v[15] = (uint64_t)(int64_t)o->max_photons;
    for (k = 0; k < 13; k++) memcpy(&v[16 + k], &d[k], sizeof d[k]);
    v[29] = (uint64_t)(int64_t)o->split_depth;
    v[30] = (uint64_t)(int64_t)o->spectral;
    /* format version 3: spm's, gi's and isc's own options */
    v[31] = (uint64_t)(int64_t)o->streams;
    v[32] = (uint64_t)(int64_t)o->stream_photons;
    v[33] = (uint64_t)(int64_t)o->caustics;
    v[34] = (uint64_t)(int64_t)o->global_photons;
    v[35] = (uint64_t)(int64_t)o->global_k;
    v[36] = (uint64_t)(int64_t)o->gather;
    memcpy(&v[37], &o->gather_mix, sizeof o->gather_mix);
    v[38] = (uint64_t)(int64_t)o->shadow_photons;
    v[39] = (uint64_t)(int64_t)o->isc_gather;
    v[40] = (uint64_t)(int64_t)o->light_resolution;
    v[41] = (uint64_t)(int64_t)o->history;
    v[42] = (uint64_t)(int64_t)o->orbit;
    memcpy(&v[43], &o->orbit_deg, sizeof o->orbit_deg);
    /* format version 4: gi's streams */
    v[44] = (uint64_t)(int64_t)o->global_map;
    memcpy(&v[45], &o->stream_radius, sizeof o->stream_radius);
    /* format version 5: the eye paths' diffuse bounces */
    v[46] = (uint64_t)(int64_t)o->diffuse_bounces;
    v[47] = (uint64_t)(int64_t)o->eye_rounds;
}

/* nopt: how many the file holds (31 in format version 2, whose renders
   all had the later ones at their defaults: gi, spm and isc were not
   stored then; 44 in version 3, before gi's streams; 46 in version 4,
   before the diffuse bounces); the rest stay at their defaults. */
static void pds__partial_opt_decode(const uint64_t v[PDS__PARTIAL_NOPT], int nopt, pds_options *o)
{
    double d[13];
    int k;
    pds_options_default(o);
    /* out-of-range values come back as the nearest int; pds__options_check
       refuses them before they are used */
#define PDS__OPT_INT(x) ((int)((int64_t)(x) < INT_MIN ? INT_MIN : (int64_t)(x) > INT_MAX ? INT_MAX : (int64_t)(x)))
    o->method = (pds_method)PDS__OPT_INT(v[0]);
    o->paths = (pds_paths)PDS__OPT_INT(v[1]);
    o->width = PDS__OPT_INT(v[2]);
    o->height = PDS__OPT_INT(v[3]);
    o->spp = PDS__OPT_INT(v[4]);
    o->seed = v[5];
    o->max_depth = PDS__OPT_INT(v[6]);
    o->rr_depth = PDS__OPT_INT(v[7]);
    o->photons = (long)(int64_t)v[8];
    o->progressive = PDS__OPT_INT(v[9]);
    o->pass_photons = (long)(int64_t)v[10];
    o->photon_depth = PDS__OPT_INT(v[11]);
    o->k = PDS__OPT_INT(v[12]);
    o->kernel = (pds_kernel)PDS__OPT_INT(v[13]);
    o->passes = PDS__OPT_INT(v[14]);
    o->max_photons = (long)(int64_t)v[15];
    o->split_depth = PDS__OPT_INT(v[29]);
    o->spectral = PDS__OPT_INT(v[30]);
    if (nopt >= PDS__PARTIAL_NOPT_V3) {
        o->streams = (long)(int64_t)v[31];
        o->stream_photons = PDS__OPT_INT(v[32]);
        o->caustics = (pds_method)PDS__OPT_INT(v[33]);
        o->global_photons = (long)(int64_t)v[34];
        o->global_k = PDS__OPT_INT(v[35]);
        o->gather = PDS__OPT_INT(v[36]);
        memcpy(&o->gather_mix, &v[37], sizeof o->gather_mix);
        o->shadow_photons = PDS__OPT_INT(v[38]);
        o->isc_gather = (pds_isc_gather)PDS__OPT_INT(v[39]);
        o->light_resolution = PDS__OPT_INT(v[40]);
        o->history = PDS__OPT_INT(v[41]);
        o->orbit = (pds_orbit)PDS__OPT_INT(v[42]);
        memcpy(&o->orbit_deg, &v[43], sizeof o->orbit_deg);
    }
    if (nopt >= PDS__PARTIAL_NOPT_V4) {
        o->global_map = (pds_global_map)PDS__OPT_INT(v[44]);
        memcpy(&o->stream_radius, &v[45], sizeof o->stream_radius);
    }
    if (nopt >= PDS__PARTIAL_NOPT_V5) o->diffuse_bounces = PDS__OPT_INT(v[46]);
    if (nopt >= PDS__PARTIAL_NOPT) o->eye_rounds = PDS__OPT_INT(v[47]);
#undef PDS__OPT_INT
    for (k = 0; k < 13; k++) memcpy(&d[k], &v[16 + k], sizeof d[k]);
    o->time_s = d[0];
    o->smoothing = d[1];
    o->plane_tolerance = d[2];
    o->min_aspect = d[3];
    o->pass_alpha = d[4];
    o->pass_smoothing = d[5];
    o->pass_min_aspect = d[6];
    o->pass_min_width = d[7];
    o->min_width = d[8];
    o->max_radius = d[9];
    o->radius = d[10];
    o->alpha = d[11];
    o->split_angle = d[12];
}

unsigned long long pds_options_hash(const pds_options *opt)
{
    pds__hasher hs = {0x50445353484f5054ull}; /* "PDSSHOPT" */
    uint64_t v[PDS__PARTIAL_NOPT];
    int i;
    if (!opt) return 0;
    pds__partial_opt_encode(opt, v);
    for (i = 0; i < PDS__PARTIAL_NOPT; i++) pds__hash_u64(&hs, v[i]);
    return hs.h;
}

static int pds__partial_same_options(const pds_options *a, const pds_options *b)
{
    uint64_t va[PDS__PARTIAL_NOPT], vb[PDS__PARTIAL_NOPT];
    pds__partial_opt_encode(a, va);
    pds__partial_opt_encode(b, vb);
    return memcmp(va, vb, sizeof va) == 0;
}

/* Rows I, I+N, ... of h: how many. */
static long pds__shard_count_of(long total, int index, int count)
{
    return index < total ? (total - index + count - 1) / count : 0;
}

void pds_partial_free(pds_partial *p)
{
    if (!p) return;
    free(p->eye);
    free(p->photon);
    free(p->neg);
    free(p);
}

void pds_partial_get_info(const pds_partial *p, pds_partial_info *info)
{
    memset(info, 0, sizeof *info);
    if (!p) return;
    info->shard_index = p->shard_index;
    info->shard_count = p->shard_count;
    info->width = p->width;
    info->height = p->height;
    info->method = p->opt.method;
    info->paths = p->opt.paths;
    info->seed = p->opt.seed;
    info->photons = p->opt.photons;
    info->scene_hash = p->scene_hash;
    info->scene_path = p->scene_path;
    info->complete = p->rows_done == p->rows_own && p->units_done == p->units_own;
    if (p->split == PDS__SPLIT_ROWS) {
        info->units_done = p->rows_done;
        info->units_total = p->rows_own;
    } else {
        info->units_done = p->units_done;
        info->units_total = p->units_own;
    }
    info->done_fraction = info->units_total > 0 ? (double)info->units_done / (double)info->units_total : 1.0;
}

void pds_partial_options(const pds_partial *p, pds_options *opt)
{
    if (!p) {
        pds_options_default(opt);
        return;
    }
    *opt = p->opt;
    opt->shard_index = p->shard_index;
    opt->shard_count = p->shard_count;
}

/* The image of the state (eq. at the top of this section): for every
   pixel channel, E + (S+ - S-) / unit * (n_planned / emitted). Used by
   pds_render and by merges alike. */
static long pds__partial_image(const double *eye, const pds__sum128 *photon, const pds__sum128 *neg, double unit,
                               double n_planned, long emitted, size_t n, float *out)
{
    double *rgb = (double *)malloc(sizeof *rgb * (n ? n : 1));
    size_t i;
    long nonfinite;
    if (!rgb) return -1;
    for (i = 0; i < n; i++) {
        rgb[i] = eye[i];
        if (photon && emitted > 0)
            rgb[i] += (pds__sum128_value(photon[i]) - pds__sum128_value(neg[i])) / unit * (n_planned / (double)emitted);
    }
    nonfinite = pds__finite_floats(rgb, out, n);
    free(rgb);
    return nonfinite;
}

/* A part's name in messages: its file name if the caller gave names. */
static const char *pds__part_name(const char *const *names, int i, char *buf, size_t n)
{
    if (names && names[i]) return names[i];
    snprintf(buf, n, "part %d", i + 1);
    return buf;
}

/* Check that part i belongs to the same render as part 0. */
static pds_status pds__partial_compatible(const pds_partial *a, const pds_partial *b, const char *na, const char *nb,
                                          pds_error *err)
{
    if (strcmp(a->version, b->version) != 0)
        return pds__fail(err, PDS_ERR_INVALID_ARG, nb, 0, 0, "rendered by pds %s, %s by pds %s: versions may render differently",
                         b->version, na, a->version);
    if (a->scene_hash != b->scene_hash)
        return pds__fail(err, PDS_ERR_INVALID_ARG, nb, 0, 0,
                         "a part of another scene (%s, content hash %016llx) than %s (%s, %016llx)", b->scene_path,
                         (unsigned long long)b->scene_hash, na, a->scene_path, (unsigned long long)a->scene_hash);
    if (!pds__partial_same_options(&a->opt, &b->opt) || a->width != b->width || a->height != b->height ||
        a->split != b->split || a->unit != b->unit || a->n_planned != b->n_planned || a->units_total != b->units_total)
        return pds__fail(err, PDS_ERR_INVALID_ARG, nb, 0, 0, "a part of the same scene rendered with other options than %s",
                         na);
    if (a->shard_count != b->shard_count)
        return pds__fail(err, PDS_ERR_INVALID_ARG, nb, 0, 0, "one of %d shards, %s one of %d", b->shard_count, na,
                         a->shard_count);
    return PDS_OK;
}

/* The fraction of the render's work units that parts hold. */
static void pds__partial_fraction(const pds_partial *const *parts, int n, double *fraction)
{
    const pds_partial *p0 = parts[0];
    long rows = 0, units = 0;
    int i;
    for (i = 0; i < n; i++) {
        rows += parts[i]->rows_done;
        units += parts[i]->units_done;
    }
    *fraction = p0->split == PDS__SPLIT_ROWS ? (double)rows / (double)p0->height
                : p0->units_total > 0       ? (double)units / (double)p0->units_total
                                            : 1.0;
}

/* The merge itself, with names for the messages (NULL: "part K"). */
static pds_status pds__partial_merge(const pds_partial *const *parts, const char *const *names, int n,
                                     int allow_subset, pds_image *out, double *fraction, long *nonfinite,
                                     pds_error *err)
{
    const pds_partial *p0;
    int *owner = NULL, i, shards;
    size_t npix, k;
    double *eye = NULL;
    pds__sum128 *photon = NULL, *neg = NULL;
    long emitted = 0;
    char b0[32], b1[32];
    pds_status st = PDS_OK;
    if (!parts || n < 1 || !out) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds_partial_merge: no parts");
    p0 = parts[0];
    shards = p0->shard_count;
    for (i = 1; i < n; i++)
        if ((st = pds__partial_compatible(p0, parts[i], pds__part_name(names, 0, b0, sizeof b0),
                                          pds__part_name(names, i, b1, sizeof b1), err)))
            return st;
    owner = (int *)malloc(sizeof *owner * (size_t)shards);
    if (!owner) return pds__nomem(err);
    for (i = 0; i < shards; i++) owner[i] = -1;
    for (i = 0; i < n; i++) {
        int s = parts[i]->shard_index;
        if (owner[s] >= 0) {
            st = pds__fail(err, PDS_ERR_INVALID_ARG, pds__part_name(names, i, b1, sizeof b1), 0, 0,
                           "shard %d/%d again: %s is that shard too", s + 1, shards,
                           pds__part_name(names, owner[s], b0, sizeof b0));
            free(owner);
            return st;
        }
        owner[s] = i;
    }
    if (!allow_subset) {
        for (i = 0; i < shards; i++) {
            pds_partial_info info;
            if (owner[i] < 0) {
                st = pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0,
                               "shard %d/%d is missing (%d of %d given; --partial merges a subset)", i + 1, shards, n,
                               shards);
                break;
            }
            pds_partial_get_info(parts[owner[i]], &info);
            if (!info.complete) {
                st = pds__fail(err, PDS_ERR_INVALID_ARG, pds__part_name(names, owner[i], b1, sizeof b1), 0, 0,
                               "shard %d/%d is unfinished (%.1f%% done): continue it with --resume, or merge with "
                               "--partial", i + 1, shards, 100.0 * info.done_fraction);
                break;
            }
        }
    }
    free(owner);
    if (st) return st;
    npix = (size_t)p0->width * (size_t)p0->height * 3;
    if (n == 1) {
        /* one part: its own arrays are the merge (rows it does not hold are 0) */
        if (pds_image_alloc(out, p0->width, p0->height) != PDS_OK) return pds__nomem(err);
        if (fraction) pds__partial_fraction(parts, n, fraction);
        k = (size_t)pds__partial_image(p0->eye, p0->photon, p0->neg, p0->unit, p0->n_planned, p0->emitted, npix,
                                       out->rgb);
        if (k == (size_t)-1) {
            pds_image_free(out);
            return pds__nomem(err);
        }
        if (nonfinite) *nonfinite = (long)k;
        return PDS_OK;
    }
    eye = (double *)calloc(npix, sizeof *eye);
    if (p0->split != PDS__SPLIT_ROWS) {
        photon = (pds__sum128 *)calloc(npix, sizeof *photon);
        neg = (pds__sum128 *)calloc(npix, sizeof *neg);
    }
    if (!eye || (p0->split != PDS__SPLIT_ROWS && (!photon || !neg)) ||
        pds_image_alloc(out, p0->width, p0->height) != PDS_OK) {
        free(eye);
        free(photon);
        free(neg);
        return pds__nomem(err);
    }
    for (i = 0; i < n; i++) {
        const pds_partial *p = parts[i];
        long j;
        size_t row = (size_t)p->width * 3;
        for (j = 0; j < p->rows_done; j++) {
            size_t y = (size_t)p->shard_index + (size_t)j * (size_t)shards;
            memcpy(eye + y * row, p->eye + y * row, sizeof *eye * row);
        }
        if (photon) {
            for (k = 0; k < npix; k++) {
                pds__sum128_add_bits(&photon[k], p->photon[k].lo, p->photon[k].hi);
                pds__sum128_add_bits(&neg[k], p->neg[k].lo, p->neg[k].hi);
            }
            if (p->split == PDS__SPLIT_PHOTONS) emitted += p->emitted;
            else if (p->emitted > emitted) emitted = p->emitted;
        }
    }
    if (fraction) pds__partial_fraction(parts, n, fraction);
    k = (size_t)pds__partial_image(eye, photon, neg, p0->unit, p0->n_planned, emitted, npix, out->rgb);
    if (k == (size_t)-1) {
        pds_image_free(out);
        st = pds__nomem(err);
    } else if (nonfinite) {
        *nonfinite = (long)k;
    }
    free(eye);
    free(photon);
    free(neg);
    return st;
}

pds_status pds_partial_merge(const pds_partial *const *parts, const char *const *names, int n, int allow_subset,
                             pds_image *out, double *fraction, pds_error *err)
{
    return pds__partial_merge(parts, names, n, allow_subset, out, fraction, NULL, err);
}

#ifndef PDS_NO_PARTIAL_FILE
/* --- the partial file -----------------------------------------------------
   Little-endian throughout (README "Partial files" has the table):

     offset  bytes  field
     0       8      magic "PDSPART\n"
     8       4      format version (5)
     12      16     library version string, NUL-padded ("0.1.0")
     28      8      scene content hash (pds_scene_hash)
     36      512    scene path as loaded, NUL-padded
     548     4 x 5  width, height, shard index (0-based), shard count, split
     568     8 x 48 options (pds__partial_opt_encode's order)
     952     8 x 13 rows done, units total, units own, units done, n_planned
                    (binary64), emitted, unit (binary64), splatted,
                    degenerate, saturated, invalid, eye vertices, reserved 0
     1056    ...    eye values of the rows done (rows I, I+N, ...: each
                    width x 3 binary64), then, unless split is 0, the photon
                    sums S+ and then S- (each width x height x 3 of: low 64
                    bits, high 64 bits)
     end-8   8      check: FNV-1a 64 of every byte before it
   Format versions 2 to 5 are read too: the same with 31 options
   (counts at 816, eye values at 920), with 44 (counts at 920, eye values
   at 1024), with 46 (counts at 936, eye values at 1040) and with 47
   (counts at 944, eye values at 1048); version 1 is refused. */

/* Where the counts and the eye values begin, for a file of nopt options. */
#define PDS__PARTIAL_COUNTS_AT(nopt) (568u + 8u * (unsigned)(nopt))
#define PDS__PARTIAL_HEADER_AT(nopt) (PDS__PARTIAL_COUNTS_AT(nopt) + 8u * 13u)
#define PDS__PARTIAL_COUNTS PDS__PARTIAL_COUNTS_AT(PDS__PARTIAL_NOPT) /* 952: the counts */
#define PDS__PARTIAL_HEADER PDS__PARTIAL_HEADER_AT(PDS__PARTIAL_NOPT) /* 1056 */

static void pds__put_u32(unsigned char *b, uint32_t v)
{
    int i;
    for (i = 0; i < 4; i++) b[i] = (unsigned char)(v >> (8 * i));
}

static void pds__put_u64(unsigned char *b, uint64_t v)
{
    int i;
    for (i = 0; i < 8; i++) b[i] = (unsigned char)(v >> (8 * i));
}

static void pds__put_f64(unsigned char *b, double d)
{
    uint64_t v;
    memcpy(&v, &d, sizeof v);
    pds__put_u64(b, v);
}

static uint32_t pds__get_u32(const unsigned char *b)
{
    return (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
}

static uint64_t pds__get_u64(const unsigned char *b)
{
    uint64_t v = 0;
    int i;
    for (i = 7; i >= 0; i--) v = v << 8 | b[i];
    return v;
}

static double pds__get_f64(const unsigned char *b)
{
    uint64_t v = pds__get_u64(b);
    double d;
    memcpy(&d, &v, sizeof d);
    return d;
}

static uint64_t pds__fnv1a64(const unsigned char *b, size_t n)
{
    uint64_t h = 0xcbf29ce484222325ull;
    size_t i;
    for (i = 0; i < n; i++) h = (h ^ b[i]) * 0x100000001b3ull;
    return h;
}

/* Bytes of the file of a part with these counts; 0 if it would not fit
   in a size_t. */
static size_t pds__partial_file_size(int nopt, int width, int height, int split, long rows_done)
{
    double bytes = PDS__PARTIAL_HEADER_AT(nopt) + 8.0 + (double)rows_done * width * 3.0 * 8.0 +
                   (split != PDS__SPLIT_ROWS ? (double)width * height * 3.0 * 32.0 : 0.0);
    return bytes < (double)((size_t)-1) / 2 ? (size_t)bytes : 0;
}

pds_status pds_partial_write(const char *path, const pds_partial *p, pds_error *err)
{
    size_t size, at, row, k;
    unsigned char *b;
    uint64_t opt[PDS__PARTIAL_NOPT];
    long j;
    int i;
    pds_status st;
    if (!path || !p) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds_partial_write: NULL argument");
    size = pds__partial_file_size(PDS__PARTIAL_NOPT, p->width, p->height, p->split, p->rows_done);
    b = size ? (unsigned char *)calloc(size, 1) : NULL;
    if (!b) return pds__nomem(err);
    memcpy(b, PDS__PARTIAL_MAGIC, 8);
    pds__put_u32(b + 8, PDS__PARTIAL_VERSION);
    memcpy(b + 12, p->version, 16);
    pds__put_u64(b + 28, p->scene_hash);
    memcpy(b + 36, p->scene_path, 512);
    pds__put_u32(b + 548, (uint32_t)p->width);
    pds__put_u32(b + 552, (uint32_t)p->height);
    pds__put_u32(b + 556, (uint32_t)p->shard_index);
    pds__put_u32(b + 560, (uint32_t)p->shard_count);
    pds__put_u32(b + 564, (uint32_t)p->split);
    pds__partial_opt_encode(&p->opt, opt);
    for (i = 0; i < PDS__PARTIAL_NOPT; i++) pds__put_u64(b + 568 + 8 * (size_t)i, opt[i]);
    at = PDS__PARTIAL_COUNTS;
    pds__put_u64(b + at, (uint64_t)p->rows_done);
    pds__put_u64(b + at + 8, (uint64_t)p->units_total);
    pds__put_u64(b + at + 16, (uint64_t)p->units_own);
    pds__put_u64(b + at + 24, (uint64_t)p->units_done);
    pds__put_f64(b + at + 32, p->n_planned);
    pds__put_u64(b + at + 40, (uint64_t)p->emitted);
    pds__put_f64(b + at + 48, p->unit);
    pds__put_u64(b + at + 56, (uint64_t)p->splatted);
    pds__put_u64(b + at + 64, (uint64_t)p->degenerate);
    pds__put_u64(b + at + 72, (uint64_t)p->saturated);
    pds__put_u64(b + at + 80, (uint64_t)p->invalid);
    pds__put_u64(b + at + 88, (uint64_t)p->eye_vertices);
    at = PDS__PARTIAL_HEADER;
    row = (size_t)p->width * 3;
    for (j = 0; j < p->rows_done; j++) {
        size_t y = (size_t)p->shard_index + (size_t)j * (size_t)p->shard_count;
        for (k = 0; k < row; k++, at += 8) pds__put_f64(b + at, p->eye[y * row + k]);
    }
    if (p->split != PDS__SPLIT_ROWS)
        for (k = 0; k < row * (size_t)p->height; k++, at += 16) {
            pds__put_u64(b + at, p->photon[k].lo);
            pds__put_u64(b + at + 8, p->photon[k].hi);
        }
    if (p->split != PDS__SPLIT_ROWS)
        for (k = 0; k < row * (size_t)p->height; k++, at += 16) {
            pds__put_u64(b + at, p->neg[k].lo);
            pds__put_u64(b + at + 8, p->neg[k].hi);
        }
    pds__put_u64(b + at, pds__fnv1a64(b, at));
    st = pds__write_file_atomic(path, b, size, err);
    free(b);
    return st;
}

/* Options in a file of this format version; 0: a version not read. */
static int pds__partial_nopt(uint32_t version)
{
    return version == PDS__PARTIAL_VERSION ? PDS__PARTIAL_NOPT
           : version == 5u                 ? PDS__PARTIAL_NOPT_V5
           : version == 4u                 ? PDS__PARTIAL_NOPT_V4
           : version == 3u                 ? PDS__PARTIAL_NOPT_V3
           : version == 2u                 ? PDS__PARTIAL_NOPT_V2
                                           : 0;
}

/* The checks of a partial file's header (k bytes of it in head). */
static pds_status pds__partial_head_check(const char *path, const unsigned char *head, size_t k, pds_error *err)
{
    uint32_t version;
    long rows_done, rows_own;
    int width, height, shard, shards, split, nopt;
    if (k < 12 || memcmp(head, PDS__PARTIAL_MAGIC, 8) != 0)
        return pds__fail(err, PDS_ERR_PARSE, path, 0, 0, "not a PDS partial file (it does not begin with \"PDSPART\")");
    version = pds__get_u32(head + 8);
    nopt = pds__partial_nopt(version);
    if (!nopt)
        return pds__fail(err, PDS_ERR_PARSE, path, 0, 0,
                         "partial file format version %lu; this pds reads versions 2 to %u",
                         (unsigned long)version, PDS__PARTIAL_VERSION);
    if (k < PDS__PARTIAL_HEADER_AT(nopt))
        return pds__fail(err, PDS_ERR_PARSE, path, 0, 0, "truncated: %lu bytes", (unsigned long)k);
    if (head[27] != '\0' || head[547] != '\0')
        return pds__fail(err, PDS_ERR_PARSE, path, 0, 0, "damaged header (an unterminated name)");
    if (strcmp((const char *)head + 12, PDS_VERSION_STRING) != 0)
        return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0,
                         "written by pds %s, this is pds %s: versions may render differently", (const char *)head + 12,
                         PDS_VERSION_STRING);
    width = (int)pds__get_u32(head + 548);
    height = (int)pds__get_u32(head + 552);
    shard = (int)pds__get_u32(head + 556);
    shards = (int)pds__get_u32(head + 560);
    split = (int)pds__get_u32(head + 564);
    rows_done = (long)pds__get_u64(head + PDS__PARTIAL_COUNTS_AT(nopt));
    if (width < 1 || height < 1 || width > PDS_MAX_RESOLUTION || height > PDS_MAX_RESOLUTION || shards < 1 ||
        shards > PDS__PARTIAL_MAX_SHARDS || shard < 0 || shard >= shards || split < 0 || split > 2)
        return pds__fail(err, PDS_ERR_PARSE, path, 0, 0, "damaged header (size %dx%d, shard %d of %d, split %d)", width,
                         height, shard, shards, split);
    rows_own = pds__shard_count_of(height, shard, shards);
    if (rows_done < 0 || rows_done > rows_own)
        return pds__fail(err, PDS_ERR_PARSE, path, 0, 0, "damaged header (%ld rows done of %ld)", rows_done, rows_own);
    return PDS_OK;
}

pds_status pds_partial_read(const char *path, pds_partial **out, pds_error *err)
{
    unsigned char head[PDS__PARTIAL_HEADER];
    uint64_t opt[PDS__PARTIAL_NOPT];
    char *data = NULL;
    const unsigned char *b;
    size_t size = 0, expect, at, row, k;
    pds_partial *p;
    pds_status st;
    long rows_done, rows_own, j;
    int i, width, height, shard, shards, split, nopt;
    size_t counts;
    if (!path || !out) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds_partial_read: NULL argument");
    *out = NULL;
    /* at most the largest file the limits allow; then the header says
       how long this one must be */
    st = pds__read_file(path,
                        pds__partial_file_size(PDS__PARTIAL_NOPT, PDS_MAX_RESOLUTION, PDS_MAX_RESOLUTION, 1,
                                               PDS_MAX_RESOLUTION),
                        "partial file", &data, &size, err);
    if (st) return st;
    k = size < sizeof head ? size : sizeof head;
    memcpy(head, data, k);
    st = pds__partial_head_check(path, head, k, err);
    if (st) {
        free(data);
        return st;
    }
    width = (int)pds__get_u32(head + 548);
    height = (int)pds__get_u32(head + 552);
    shard = (int)pds__get_u32(head + 556);
    shards = (int)pds__get_u32(head + 560);
    split = (int)pds__get_u32(head + 564);
    nopt = pds__partial_nopt(pds__get_u32(head + 8));
    counts = PDS__PARTIAL_COUNTS_AT(nopt);
    rows_done = (long)pds__get_u64(head + counts);
    rows_own = pds__shard_count_of(height, shard, shards);
    expect = pds__partial_file_size(nopt, width, height, split, rows_done);
    b = (const unsigned char *)data;
    if (size != expect) {
        free(data);
        return pds__fail(err, PDS_ERR_PARSE, path, 0, 0, "%lu bytes, its header says %lu: truncated or damaged",
                         (unsigned long)size, (unsigned long)expect);
    }
    if (pds__get_u64(b + size - 8) != pds__fnv1a64(b, size - 8)) {
        free(data);
        return pds__fail(err, PDS_ERR_PARSE, path, 0, 0, "damaged (its check sum does not match its contents)");
    }
    p = (pds_partial *)calloc(1, sizeof *p);
    if (!p) {
        free(data);
        return pds__nomem(err);
    }
    memcpy(p->version, b + 12, 16);
    p->scene_hash = pds__get_u64(b + 28);
    memcpy(p->scene_path, b + 36, 512);
    p->width = width;
    p->height = height;
    p->shard_index = shard;
    p->shard_count = shards;
    p->split = split;
    memset(opt, 0, sizeof opt);
    for (i = 0; i < nopt; i++) opt[i] = pds__get_u64(b + 568 + 8 * (size_t)i);
    pds__partial_opt_decode(opt, nopt, &p->opt);
    p->rows_own = rows_own;
    p->rows_done = rows_done;
    p->units_total = (long)pds__get_u64(b + counts + 8);
    p->units_own = (long)pds__get_u64(b + counts + 16);
    p->units_done = (long)pds__get_u64(b + counts + 24);
    p->n_planned = pds__get_f64(b + counts + 32);
    p->emitted = (long)pds__get_u64(b + counts + 40);
    p->unit = pds__get_f64(b + counts + 48);
    p->splatted = (long)pds__get_u64(b + counts + 56);
    p->degenerate = (long)pds__get_u64(b + counts + 64);
    p->saturated = (long)pds__get_u64(b + counts + 72);
    p->invalid = (long)pds__get_u64(b + counts + 80);
    p->eye_vertices = (long)pds__get_u64(b + counts + 88);
    if (p->units_total < 0 || p->units_own < 0 || p->units_done < 0 || p->units_done > p->units_own ||
        p->units_own > p->units_total ||
        (split == PDS__SPLIT_PHOTONS && p->units_own != pds__shard_count_of(p->units_total, shard, shards)) ||
        (split == PDS__SPLIT_GATHER && (p->units_total != shards || p->units_own != 1)) ||
        (split == PDS__SPLIT_ROWS && p->units_total != 0) || p->emitted < 0 || !(p->unit > 0.0) || !isfinite(p->unit) ||
        !(p->n_planned >= 0.0) || !isfinite(p->n_planned)) {
        free(data);
        pds_partial_free(p);
        return pds__fail(err, PDS_ERR_PARSE, path, 0, 0, "damaged header (inconsistent counts)");
    }
    row = (size_t)width * 3;
    p->eye = (double *)calloc(row * (size_t)height, sizeof *p->eye);
    if (split != PDS__SPLIT_ROWS) {
        p->photon = (pds__sum128 *)malloc(sizeof *p->photon * row * (size_t)height);
        p->neg = (pds__sum128 *)malloc(sizeof *p->neg * row * (size_t)height);
    }
    if (!p->eye || (split != PDS__SPLIT_ROWS && (!p->photon || !p->neg))) {
        free(data);
        pds_partial_free(p);
        return pds__nomem(err);
    }
    at = PDS__PARTIAL_HEADER_AT(nopt);
    for (j = 0; j < rows_done; j++) {
        size_t y = (size_t)shard + (size_t)j * (size_t)shards;
        for (k = 0; k < row; k++, at += 8) p->eye[y * row + k] = pds__get_f64(b + at);
    }
    if (p->photon)
        for (k = 0; k < row * (size_t)height; k++, at += 16) {
            p->photon[k].lo = pds__get_u64(b + at);
            p->photon[k].hi = pds__get_u64(b + at + 8);
        }
    if (p->neg)
        for (k = 0; k < row * (size_t)height; k++, at += 16) {
            p->neg[k].lo = pds__get_u64(b + at);
            p->neg[k].hi = pds__get_u64(b + at + 8);
        }
    free(data);
    *out = p;
    return PDS_OK;
}
#else /* PDS_NO_PARTIAL_FILE */
/* This build leaves the partial file out: a render's state stays in
   memory (shards merge there; `pds` cannot checkpoint or resume). */
pds_status pds_partial_write(const char *path, const pds_partial *p, pds_error *err)
{
    (void)p;
    return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "this build leaves partial files out (PDS_NO_PARTIAL_FILE)");
}

pds_status pds_partial_read(const char *path, pds_partial **out, pds_error *err)
{
    if (out) *out = NULL;
    return pds__fail(err, PDS_ERR_INVALID_ARG, path, 0, 0, "this build leaves partial files out (PDS_NO_PARTIAL_FILE)");
}
#endif /* PDS_NO_PARTIAL_FILE */

/* ===================================================================== */
/* >>render                                                              */
/* ===================================================================== */
/* Camera rays, the integrators (path tracing, preview) and the thread
   scheduler.

   The pinhole camera maps pixel coordinates (x right, y down, in pixels)
   to a ray through the image plane at distance 1 whose half-height is
   tan(fov/2). Sample positions inside a pixel come from the counter-based
   generator keyed by (seed, pixel, sample), so an image never depends on
   the thread count: each pixel is computed by one thread, from its own
   numbers, and written once.

   Preview: "eye light" shading, a light at the eye: the surface colour
   times |cos| between the shading normal and the ray. It shows geometry,
   materials and normals at a glance. */

typedef struct pds__camera_frame {
    pds__v3 origin, forward, right, up;
    double tan_half_fov, aspect;
    int width, height;
    double aperture, focus; /* thin lens: lens radius (0 = pinhole) and the
                               distance of the plane in focus along forward */
} pds__camera_frame;

static pds__camera_frame pds__camera_setup(const pds_camera *c, int width, int height)
{
    pds__camera_frame f;
    f.origin = c->position;
    f.forward = pds__normalize(pds__sub(c->look_at, c->position));
    f.right = pds__normalize(pds__cross(f.forward, c->up));
    f.up = pds__cross(f.right, f.forward);
    f.tan_half_fov = tan(0.5 * c->fov_deg * PDS__PI / 180.0);
    f.width = width;
    f.height = height;
    f.aspect = (double)width / (double)height;
    f.aperture = c->aperture;
    f.focus = c->focus_distance > 0.0 ? c->focus_distance : pds__length(pds__sub(c->look_at, c->position));
    return f;
}

/* Unit direction through image point (px, py) in pixels, (0,0) = top left
   corner of the image. */
static pds__v3 pds__camera_dir(const pds__camera_frame *f, double px, double py)
{
    double sx = (2.0 * px / f->width - 1.0) * f->tan_half_fov * f->aspect;
    double sy = (1.0 - 2.0 * py / f->height) * f->tan_half_fov;
    return pds__normalize(pds__add(f->forward, pds__add(pds__scale(f->right, sx), pds__scale(f->up, sy))));
}

/* The camera ray through image point (px, py): its origin *org and unit
   direction. A pinhole (aperture 0) starts every ray at the eye. A thin
   lens of radius A focused at distance F (Kolb, Mitchell and Hanrahan
   1995; Pharr, Jakob, Humphreys, "Physically Based Rendering", 3rd ed.,
   6.2.3) starts it at a point of the lens disk, (u1, u2) through the
   concentric map, and aims it at the point where the pinhole ray meets
   the plane in focus (distance F along forward): points on that plane
   stay sharp, and a point at distance z along the axis spreads over a
   disk of radius A |z - F| / z on the plane in focus (the circle of
   confusion), A |z - F| / (z F tan(fov/2)) x height/2 pixels. */
static pds__v3 pds__camera_ray(const pds__camera_frame *f, double px, double py, double u1, double u2, pds__v3 *org)
{
    pds__v3 d = pds__camera_dir(f, px, py), focal;
    double dx, dy;
    *org = f->origin;
    if (!(f->aperture > 0.0)) return d;
    focal = pds__add(f->origin, pds__scale(d, f->focus / pds__dot(d, f->forward)));
    pds__lights_concentric(u1, u2, &dx, &dy);
    *org = pds__add(f->origin, pds__add(pds__scale(f->right, dx * f->aperture), pds__scale(f->up, dy * f->aperture)));
    return pds__normalize(pds__sub(focal, *org));
}

/* Offset in [-1, 1] with the tent density 1 - |x| (inverse CDF). */
static double pds__tent_sample(double u)
{
    return u < 0.5 ? sqrt(2.0 * u) - 1.0 : 1.0 - sqrt(2.0 - 2.0 * u);
}

/* A colour that stands for the material in the preview. */
static void pds__material_preview_colour(const pds_material *m, double rgb[3])
{
    int c;
    for (c = 0; c < 3; c++) {
        switch (m->type) {
        case PDS_MAT_DIFFUSE: rgb[c] = m->albedo[c]; break;
        case PDS_MAT_MIRROR: rgb[c] = m->reflectance[c]; break;
        case PDS_MAT_CONDUCTOR:
            /* normal-incidence reflectance ((n-1)^2 + k^2) / ((n+1)^2 + k^2) */
            rgb[c] = ((m->eta[c] - 1) * (m->eta[c] - 1) + m->k[c] * m->k[c]) /
                     ((m->eta[c] + 1) * (m->eta[c] + 1) + m->k[c] * m->k[c]);
            break;
        case PDS_MAT_DIELECTRIC: rgb[c] = 0.9 * exp(-m->absorption[c]); break;
        case PDS_MAT_EMISSIVE: rgb[c] = m->radiance[c]; break;
        case PDS_MAT_GLOSSY:
            rgb[c] = m->reflectance[c] * (m->fresnel ? pds__fresnel_conductor(1.0, m->eta[c], m->k[c]) : 1.0);
            break;
        }
    }
}

/* --- path tracing ------------------------------------------------------- */
/* Unidirectional path tracing (Kajiya 1986) with next-event estimation at
   non-specular vertices and multiple importance sampling (Veach 1997,
   power heuristic) between light sampling and BSDF sampling for area and
   mesh lights and the environment (which rays that leave the scene see).
   Delta lights (point, spot, directional) are reached only by next-event
   estimation from non-specular vertices, so a path tracer cannot
   render their caustics: a diffuse surface lit through glass by a point
   light stays dark, and the photon methods supply that light.

   The caustic split: a contribution belongs to a caustic path (L S+ D ...)
   when the light reaches the most recent non-specular vertex through one
   or more specular bounces. Next-event estimation connects a non-specular
   vertex straight to a light, so it is never caustic; an emitter found by
   BSDF sampling is caustic exactly when the path has a non-specular vertex
   and the vertices since the last one are all specular. The two classes
   partition every path, so ALL = NO_CAUSTICS + CAUSTICS_ONLY sample by
   sample (the same random numbers drive all three).

   Random numbers per camera sample (index = pixel * total_spp + sample):
   dimensions 0, 1 the position in the pixel; then 8 per bounce: light
   pick, light point (2), BSDF (3), Russian roulette, spare. */

#define PDS__DIMS_PER_BOUNCE 8

/* An eye-path vertex: where a camera path first meets a non-specular
   surface, after any number of specular bounces. The photon methods add
   their caustic light at these points (PDS paper section 3.3: position,
   ray direction, BRDF, importance, pixel). 112 bytes:
     pos, n, g, wo     position; the shading and geometric normals turned
                       to the side the eye path arrived from (the frame
                       pds__bsdf_frame gives the BSDF), so that a mesh's
                       winding does not matter; the direction back along
                       the eye path (unit); as floats
     importance        path throughput from the camera to here (Fresnel,
                       mirror and Beer factors) divided by the pixel's
                       samples, so a pixel's value is the sum over its
                       vertices of importance x reflected radiance
     weight, lambert   for a Lambertian surface (lambert = 1), whose BRDF
                       albedo(x) / pi does not depend on the directions,
                       weight = albedo(x) / pi x importance, computed once
                       here instead of at every photon that reaches it
     lambda            spectral renders: the wavelength (nm) the vertex
                       holds at, when its specular chain refracted through
                       a dispersive material (importance is then that
                       chain's spectral throughput at lambda); 0 when the
                       vertex holds at every wavelength (importance is the
                       chain's RGB weight), and in RGB renders (>>spectral)
     px, py            0 for a vertex of one camera sample; for a merged
                       one (pds__eye_merge), the half-axes of its pixel on
                       the surface, over which a splat averages its kernel
     material, pixel   indices */
typedef struct pds__eye_vertex {
    float pos[3], n[3], g[3], wo[3];
    float importance[3];
    float weight[3];
    float lambda;
    float px[3], py[3];
    int material;
    int pixel;
    int lambert;
} pds__eye_vertex;

static void pds__f3_set(float f[3], pds__v3 v)
{
    f[0] = (float)v.x;
    f[1] = (float)v.y;
    f[2] = (float)v.z;
}

static pds__v3 pds__f3_get(const float f[3])
{
    return pds__v(f[0], f[1], f[2]);
}

/* Is this render spectral (>>spectral)? When asked for, or when some
   material disperses light; never for the preview. */
static int pds__render_is_spectral(const pds_scene *s, const pds_options *opt)
{
    size_t i;
    if (opt->method == PDS_METHOD_PREVIEW) return 0;
    if (opt->spectral) return 1;
    for (i = 0; i < s->materials.count; i++)
        if (pds__material_is_dispersive(&s->materials.items[i])) return 1;
    return 0;
}

/* Record the eye vertex at x (material m, index material) seen from wo
   with path throughput beta. Returns 0 if wo grazes the surface (no frame:
   nothing can be reflected toward the eye). */
static int pds__eye_vertex_set(pds__eye_vertex *v, const pds_material *m, pds__v3 x, pds__v3 ns, pds__v3 ng,
                               pds__v3 wo, const double beta[3], int material)
{
    pds__v3 n, g;
    double albedo[3];
    int side, c;
    if (!pds__bsdf_frame(wo, ns, ng, &n, &g, &side)) return 0;
    pds__f3_set(v->pos, x);
    pds__f3_set(v->n, n);
    pds__f3_set(v->g, g);
    pds__f3_set(v->wo, wo);
    v->lambert = m->type == PDS_MAT_DIFFUSE;
    if (v->lambert) pds__albedo_at(m, x, ng, albedo);
    for (c = 0; c < 3; c++) {
        v->importance[c] = (float)beta[c];
        v->weight[c] = v->lambert ? (float)(albedo[c] / PDS__PI * beta[c]) : 0.0f;
    }
    v->material = material;
    v->px[0] = v->px[1] = v->px[2] = v->py[0] = v->py[1] = v->py[2] = 0.0f;
    return 1;
}

/* What eye vertex v passes to its pixel per unit of irradiance arriving
   from direction wi (unit, pointing away from the surface): fr(x, wi, wo)
   times the vertex's importance, into out[3]. 0 (and out untouched) when
   wi is below the shading or the geometric normal. Spectral renders: the
   photon's wavelength lambda_p (0 for an RGB photon) and its flux or flux
   density e[3], which may be changed, meet the vertex as
   pds__spectral_meet says (>>spectral); 0 if they do not meet. */
static int pds__eye_response(const pds_scene *s, const pds__eye_vertex *v, pds__v3 wi, double lambda_p, double e[3],
                             double out[3])
{
    pds__v3 n = pds__f3_get(v->n), g = pds__f3_get(v->g);
    double f[3], pdf;
    int c;
    if (!(pds__dot(wi, n) > 0.0) || !(pds__dot(wi, g) > 0.0)) return 0;
    if (lambda_p > 0.0 || v->lambda > 0.0f) {
        pds__bsdf_eval(&s->materials.items[v->material], pds__f3_get(v->pos), pds__f3_get(v->wo), wi, n, g, f, &pdf);
        if (!pds__spectral_meet(lambda_p, v->lambda, e, f)) return 0;
        for (c = 0; c < 3; c++) out[c] = f[c] * v->importance[c];
        return f[0] != 0.0 || f[1] != 0.0 || f[2] != 0.0;
    }
    if (v->lambert) {
        for (c = 0; c < 3; c++) out[c] = v->weight[c];
        return 1;
    }
    pds__bsdf_eval(&s->materials.items[v->material], pds__f3_get(v->pos), pds__f3_get(v->wo), wi, n, g, f, &pdf);
    for (c = 0; c < 3; c++) out[c] = f[c] * v->importance[c];
    return f[0] != 0.0 || f[1] != 0.0 || f[2] != 0.0;
}

/* Merged eye vertices (an extension; the paper stores one vertex per
   sample). Every eye vertex costs the photon pass work (a splat finds it
   in the kd-tree, weighs it and adds into its pixel), so the samples of a
   pixel that see the same flat patch of one Lambertian surface directly
   are merged into one vertex: the sum of their importances and weights,
   at their weight-averaged position, with the half-axes px, py of the
   pixel on the surface (the camera's half-pixel steps carried along the
   ray to the surface's tangent plane). A splat then averages its kernel
   over that parallelogram (pds__kernel_over_pixel) where the samples did
   so by being spread over it: the pixel's value is the box filter of the
   caustic, computed by quadrature instead of by its samples' positions.
   (Evaluating the kernel at the merged point alone doubled the refraction
   case's RMSE: at a caustic's cusps a footprint is a pixel or two wide.)
   The samples still stratify everything else: the direct light and path
   traced part of the pixel, and which surfaces and branches of the glass
   it sees. So raising --spp costs the photon pass only where the samples
   see different things (glass, edges). Merged when both vertices are
   Lambertian and RGB (no wavelength of their own), of one material, both
   seen straight from a pinhole camera or both not (through glass or a
   mirror; never through a lens), their shading and geometric normals
   within 2.6 degrees
   (cos > 0.999), the second within PDS__EYE_MERGE_PIXELS pixel widths of
   the first (seen through something: one width of the pixel seen directly
   at that distance, so a magnified view stays apart) and within 5% of that
   of its plane, with the box pixel filter (a tent's samples spread over
   four pixels). Seen through something, the pixel's half-axes on the
   surface are what its samples covered (pds__eye_merge). Greedy in sample
   order, so the same for any thread count. Only the splatting methods
   (progressive PDS and splat) merge: a gather (pm, pdm, ppm, spm) has no
   kernel to average; the paper's one-pass PDS keeps its vertices. */
#define PDS__EYE_MERGE_PIXELS 1.5

/* The half-axes of the camera's pixel at x on the plane with normal n
   (a pinhole f): the half-pixel steps of the ray's direction, scaled to
   x's depth, transferred to the plane along the ray. 0 if x is behind the
   camera or the ray grazes the plane. */
static int pds__pixel_axes(const pds__camera_frame *f, pds__v3 x, pds__v3 n, pds__v3 *ex, pds__v3 *ey)
{
    pds__v3 r = pds__sub(x, f->origin);
    double depth = pds__dot(r, f->forward), rn = pds__dot(r, n);
    pds__v3 a = pds__scale(f->right, depth * f->tan_half_fov * f->aspect / f->width);
    pds__v3 b = pds__scale(f->up, depth * f->tan_half_fov / f->height);
    if (!(depth > 0.0) || !(fabs(rn) > 1e-6 * pds__length(r))) return 0;
    *ex = pds__sub(a, pds__scale(r, pds__dot(a, n) / rn));
    *ey = pds__sub(b, pds__scale(r, pds__dot(b, n) / rn));
    return 1;
}

/* Was v seen straight from the camera's pinhole? */
static int pds__eye_direct(const pds__eye_vertex *v, const pds__camera_frame *f)
{
    pds__v3 to_eye = pds__sub(f->origin, pds__f3_get(v->pos));
    double d = pds__length(to_eye);
    return d > 0.0 && pds__dot(pds__f3_get(v->wo), to_eye) > 0.99999 * d;
}

static int pds__eye_mergeable(const pds__eye_vertex *a, const pds__eye_vertex *b, double h)
{
    pds__v3 d = pds__sub(pds__f3_get(b->pos), pds__f3_get(a->pos)), n = pds__f3_get(a->n);
    if (!b->lambert || b->lambda != 0.0f || a->material != b->material) return 0;
    if (!(pds__dot(n, pds__f3_get(b->n)) > 0.999) || !(pds__dot(pds__f3_get(a->g), pds__f3_get(b->g)) > 0.999))
        return 0;
    return pds__dot(d, d) <= h * h && fabs(pds__dot(d, n)) <= 0.05 * h;
}

/* Merge the n vertices one pixel recorded (in place); returns how many are
   left. f: the camera (a pinhole, box filter). */
static size_t pds__eye_merge(pds__eye_vertex *v, size_t n, const pds__camera_frame *f)
{
    size_t i, j, out = 0;
    for (i = 0; i < n; i++) {
        pds__eye_vertex m = v[i];
        pds__v3 x = pds__f3_get(m.pos), nm = pds__f3_get(m.n), sum, ex, ey, t1, t2;
        double w0 = m.weight[0] + m.weight[1] + m.weight[2], wsum = w0, h, m1[2] = {0.0, 0.0}, m2[3] = {0, 0, 0};
        double wpix = 2.0 * pds__length(pds__sub(x, f->origin)) * f->tan_half_fov / f->height;
        int c, merged = 0, direct = pds__eye_direct(&m, f);
        if (!m.lambert || m.lambda != 0.0f || (direct && !pds__pixel_axes(f, x, nm, &ex, &ey))) {
            v[out++] = m;
            continue;
        }
        /* seen directly: within PDS__EYE_MERGE_PIXELS pixel widths; through
           glass or a mirror: within one width of the pixel seen directly
           at that distance (a magnified view is left as it is) */
        h = direct ? PDS__EYE_MERGE_PIXELS * 2.0 * fmax(pds__length(ex), pds__length(ey)) : wpix;
        pds__onb(nm, &t1, &t2);
        sum = pds__scale(x, w0);
        for (j = i + 1; j < n; j++) {
            pds__v3 d;
            double w, a, b;
            if (pds__eye_direct(&v[j], f) != direct || !pds__eye_mergeable(&m, &v[j], h)) continue;
            w = v[j].weight[0] + v[j].weight[1] + v[j].weight[2];
            sum = pds__add(sum, pds__scale(pds__f3_get(v[j].pos), w));
            wsum += w;
            /* first and second moments in the tangent plane, about the first */
            d = pds__sub(pds__f3_get(v[j].pos), x);
            a = pds__dot(d, t1);
            b = pds__dot(d, t2);
            m1[0] += w * a;
            m1[1] += w * b;
            m2[0] += w * a * a;
            m2[1] += w * a * b;
            m2[2] += w * b * b;
            for (c = 0; c < 3; c++) {
                m.importance[c] += v[j].importance[c];
                m.weight[c] += v[j].weight[c];
            }
            v[j--] = v[--n]; /* taken: the last one moves into its place */
            merged = 1;
        }
        if (merged && direct) {
            /* black surfaces (all weights 0) keep the first vertex's position */
            if (wsum > 0.0) pds__f3_set(m.pos, pds__scale(sum, 1.0 / wsum));
            if (pds__pixel_axes(f, pds__f3_get(m.pos), nm, &ex, &ey)) {
                pds__f3_set(m.px, ex);
                pds__f3_set(m.py, ey);
            }
        } else if (merged && wsum > 0.0) {
            /* seen through something: the pixel's extent there is what its
               samples covered. Their weighted covariance C in the plane; a
               box of half-axis a has variance a^2 / 3 along it, so the
               half-axes are sqrt(3 lambda) along C's eigenvectors, at most
               1.5 half pixel widths (the splat's query reaches that far) */
            double ca = m1[0] / wsum, cb = m1[1] / wsum, sxx = m2[0] / wsum - ca * ca, sxy = m2[1] / wsum - ca * cb;
            double syy = m2[2] / wsum - cb * cb, mid = 0.5 * (sxx + syy);
            double r = sqrt(0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy), l1 = mid + r, l2 = mid - r, th, a1, a2;
            pds__v3 e1, e2;
            pds__f3_set(m.pos, pds__add(x, pds__add(pds__scale(t1, ca), pds__scale(t2, cb))));
            th = 0.5 * atan2(2.0 * sxy, sxx - syy);
            e1 = pds__add(pds__scale(t1, cos(th)), pds__scale(t2, sin(th)));
            e2 = pds__add(pds__scale(t1, -sin(th)), pds__scale(t2, cos(th)));
            a1 = fmin(sqrt(3.0 * fmax(l1, 0.0)), 0.75 * wpix);
            a2 = fmin(sqrt(3.0 * fmax(l2, 0.0)), 0.75 * wpix);
            pds__f3_set(m.px, pds__scale(e1, a1));
            pds__f3_set(m.py, pds__scale(e2, a2));
        }
        v[out++] = m;
    }
    return out;
}

typedef struct pds__tracer {
    const pds_scene *scene;
    pds_paths paths;
    int max_depth, rr_depth;
    int max_diffuse;  /* pds_options.diffuse_bounces (-1: no limit) */
    uint64_t seed;
    double eps;  /* ray offset, relative to the scene's size */
    int spectral; /* one wavelength per camera sample (>>spectral) */
    int spectral_all; /* ... and spectral from the camera on, not only
                         from the first dispersive material */
    int eye_splits;   /* levels of splitting at glass (pds__trace_path) */
    int vertices_only; /* record the eye vertices and compute no light (a
                         photon method's caustics-only image, whose eye
                         values are 0): a branch ends at its first
                         non-specular vertex */
} pds__tracer;

/* Power heuristic with exponent 2. */
static double pds__mis_power(double a, double b)
{
    return a * a / (a * a + b * b);
}

/* Add w * scale to acc when the contribution's class is wanted; film (if
   not NULL) is the film weight W(lambda) of a spectral sample. */
static void pds__accumulate(const pds__tracer *tr, int caustic, const double w[3], double scale, const double *film,
                            double acc[3])
{
    int c;
    if (tr->paths == PDS_PATHS_NO_CAUSTICS && caustic) return;
    if (tr->paths == PDS_PATHS_CAUSTICS_ONLY && !caustic) return;
    for (c = 0; c < 3; c++) acc[c] += w[c] * scale * (film ? film[c] : 1.0);
}

/* Offset a ray origin off the surface, to the side of ng that dir leaves on. */
static pds__v3 pds__offset(const pds__tracer *tr, pds__v3 p, pds__v3 ng, pds__v3 dir)
{
    double s = pds__dot(ng, dir) >= 0.0 ? tr->eps : -tr->eps;
    return pds__add(p, pds__scale(ng, s));
}

/* The nearest analytic (disk or quad) light along the ray before tmax. */
static int pds__hit_analytic_light(const pds_scene *s, pds__v3 org, pds__v3 dir, double tmax, double *t, pds__v3 *nx)
{
    size_t i;
    int found = -1;
    for (i = 0; i < s->nlights; i++) {
        double ti;
        pds__v3 ni;
        if (s->lights[i].type != PDS_LIGHT_DISK && s->lights[i].type != PDS_LIGHT_QUAD) continue;
        /* seen from behind, an analytic light is not there at all: it
           neither emits nor blocks, on camera rays as on shadow rays */
        if (pds__light_intersect(&s->lights[i], org, dir, 0.0, tmax, &ti, &ni) && pds__dot(ni, dir) < 0.0) {
            tmax = ti;
            *t = ti;
            *nx = ni;
            found = (int)i;
        }
    }
    return found;
}

#ifndef PDS_NO_ENV
/* Next-event estimation of the environment light k (picked with
   probability pmf) at a non-specular vertex: one direction from each part
   of its mixture (sun, upper, lower hemisphere; >>lights) instead of one
   from the mixture, each weighted by its part's probability p_i:
   sum_i p_i f(w_i) / (pmf q(w_i)), q the mixture's pdf, has the same
   expectation as one sample from q (integral of f / pmf), with the
   sun-or-sky choice taken out of the noise; the power heuristic weights
   against BSDF sampling use pmf q as a single light sample does. The
   second and third parts take their numbers from PDS__RNG_ENV_NEE. */
static void pds__direct_env(const pds__tracer *tr, const pds_material *m, pds__v3 p, pds__v3 wo, pds__v3 ns,
                            pds__v3 ng, const double beta[3], uint64_t idx, uint64_t dim, int k, double pmf,
                            double lambda, const double *film, double acc[3])
{
    const pds_scene *s = tr->scene;
    const pds_light *l = &s->lights[k];
    const double *parts = &s->light_table.env_p[3 * k];
    pds__v3 n, ngw;
    int side, part, c;
    if (!pds__bsdf_frame(wo, ns, ng, &n, &ngw, &side)) return;
    for (part = 0; part < 3; part++) {
        double u1, u2, q, f[3], L[3], w[3], pdf_bsdf, cosine;
        pds__v3 wi, org;
        if (!(parts[part] > 0.0)) continue;
        if (part == 0) {
            u1 = pds__rng_uniform(tr->seed, PDS__RNG_PIXEL, idx, dim + 1);
            u2 = pds__rng_uniform(tr->seed, PDS__RNG_PIXEL, idx, dim + 2);
        } else {
            u1 = pds__rng_uniform(tr->seed, PDS__RNG_ENV_NEE, idx, 4 * dim + 2 * (uint64_t)part - 2);
            u2 = pds__rng_uniform(tr->seed, PDS__RNG_ENV_NEE, idx, 4 * dim + 2 * (uint64_t)part - 1);
        }
        pds__env_sample_part(l, part, u1, u2, &wi);
        cosine = pds__dot(wi, n);
        if (!(cosine > 0.0)) continue;
        q = pds__env_pdf(l, parts, wi);
        if (!(q > 0.0)) continue;
        pds__bsdf_eval(m, p, wo, wi, ns, ng, f, &pdf_bsdf);
        if (!(f[0] + f[1] + f[2] > 0.0)) continue;
        pds__env_radiance(l, wi, L);
        if (!(L[0] != 0.0 || L[1] != 0.0 || L[2] != 0.0)) continue;
        org = pds__offset(tr, p, ng, wi);
        if (pds__bvh_occluded(&s->bvh, org, wi, 0.0, DBL_MAX)) continue;
        pds__spectral_uplift(lambda, f);
        pds__spectral_uplift(lambda, L);
        for (c = 0; c < 3; c++) w[c] = beta[c] * f[c] * L[c] * cosine * parts[part] / (pmf * q);
        pds__accumulate(tr, 0, w, pds__mis_power(pmf * q, pdf_bsdf), film, acc);
    }
}
#else /* PDS_NO_ENV: no scene has an environment light */
static void pds__direct_env(const pds__tracer *tr, const pds_material *m, pds__v3 p, pds__v3 wo, pds__v3 ns,
                            pds__v3 ng, const double beta[3], uint64_t idx, uint64_t dim, int k, double pmf,
                            double lambda, const double *film, double acc[3])
{
    (void)tr, (void)m, (void)p, (void)wo, (void)ns, (void)ng, (void)beta, (void)idx, (void)dim, (void)k, (void)pmf;
    (void)lambda, (void)film, (void)acc;
}
#endif

/* Next-event estimation at a non-specular vertex: one light picked by
   power, one point on it, shadow ray, MIS against BSDF sampling. A
   spectral sample (lambda > 0, film = W(lambda)) takes the BSDF and the
   light at lambda. */
static void pds__direct_light(const pds__tracer *tr, const pds_material *m, pds__v3 p, pds__v3 wo, pds__v3 ns,
                              pds__v3 ng, const double beta[3], uint64_t idx, uint64_t dim, double lambda,
                              const double *film, double acc[3])
{
    const pds_scene *s = tr->scene;
    double pmf, f[3], pdf_bsdf, cosine, w[3], mis = 1.0;
    pds__light_li li;
    pds__v3 n, ngw, org;
    int side, k, c;
    double u0 = pds__rng_uniform(tr->seed, PDS__RNG_PIXEL, idx, dim);
    double u1 = pds__rng_uniform(tr->seed, PDS__RNG_PIXEL, idx, dim + 1);
    double u2 = pds__rng_uniform(tr->seed, PDS__RNG_PIXEL, idx, dim + 2);
    if (tr->paths == PDS_PATHS_CAUSTICS_ONLY) return; /* a direct connection is never caustic */
    k = pds__lights_pick(&s->light_table, u0, &pmf);
    if (k < 0 || !(pmf > 0.0)) return;
    if (s->lights[k].type == PDS_LIGHT_ENVIRONMENT) {
        pds__direct_env(tr, m, p, wo, ns, ng, beta, idx, dim, k, pmf, lambda, film, acc);
        return;
    }
    if (!pds__light_sample_li(&s->light_table, &s->lights[k], k, &s->mesh, p, u1, u2, &li)) return;
    if (!pds__bsdf_frame(wo, ns, ng, &n, &ngw, &side)) return;
    pds__bsdf_eval(m, p, wo, li.wi, ns, ng, f, &pdf_bsdf);
    cosine = pds__dot(li.wi, n);
    if (!(cosine > 0.0) || !(f[0] + f[1] + f[2] > 0.0)) return;
    org = pds__offset(tr, p, ng, li.wi);
    if (pds__bvh_occluded(&s->bvh, org, li.wi, 0.0, li.dist * (1.0 - 1e-4))) return;
    if (!li.delta) mis = pds__mis_power(pmf * li.pdf, pdf_bsdf);
    pds__spectral_uplift(lambda, f);
    pds__spectral_uplift(lambda, li.li);
    for (c = 0; c < 3; c++) w[c] = beta[c] * f[c] * li.li[c] * cosine / (pmf * li.pdf);
    pds__accumulate(tr, 0, w, mis, film, acc);
}

/* One camera sample: radiance along the ray (org, dir), split by class,
   added to acc. If rec is not NULL (room for PDS__EYE_LEAVES vertices),
   the path's first non-specular vertices are written to it (importance
   not yet divided by the samples per pixel) and their number returned.
   lambda > 0: the sample's wavelength in a spectral render (>>spectral).
   The path turns spectral at its first dispersive material (or at once
   if the render is spectral throughout): its RGB throughput becomes its
   value at lambda, and from there on materials and lights are taken at
   lambda and what it sees is weighted by the film's W(lambda). Alongside,
   until the first non-specular vertex, the chain's RGB weight beta_rgb is
   kept for the vertex's importance, unless the chain met a dispersive
   material.

   Splitting at glass (tr->eye_splits > 0). Where the chain from the
   camera meets a dielectric before any non-specular vertex, picking one
   branch with the Fresnel probability F (as a path tracer does) makes
   glass salt-and-pepper noise: a sample sees either the reflection or the
   refraction, and the caustic behind the glass is found by a few samples
   with large weights. Instead both branches are followed, weighted F and
   1 - F (the expectation of the one-branch estimator, computed exactly),
   as Whitted's ray tracer and POV-Ray do, for eye_splits levels of the
   chain (at most 2^eye_splits first non-specular vertices per sample). A
   branch whose weight is below PDS__EYE_SPLIT_MIN goes on by Russian
   roulette (probability weight / PDS__EYE_SPLIT_MIN, weight divided by
   it), so faint reflections cost little. Branch b's children are 2b + 1
   (reflected) and 2b + 2 (transmitted); a branch's random numbers are its
   own dimensions (PDS__BRANCH_DIMS apart), so the camera's own path,
   branch 0, draws the numbers it drew before splitting existed. */

#define PDS__EYE_LEAVES 4        /* 2^PDS__EYE_SPLITS: vertices one camera sample may record */
#define PDS__EYE_SPLIT_MIN 0.1   /* below this branch weight, Russian roulette */
#define PDS__BRANCH_DIMS ((uint64_t)1 << 32)
#define PDS__EYE_SPLITS 2        /* levels of splitting in the photon methods' eye pass */

/* The levels of splitting at glass for a render's eye pass: the photon
   methods' (not the paper's one-pass PDS, kept as the paper describes
   it, nor the path tracer's), when the scene has glass. */
static int pds__is_photon_method(pds_method m);
static int pds__eye_splits(const pds_scene *s, const pds_options *opt)
{
    size_t i;
    if (!pds__is_photon_method(opt->method) || (opt->method == PDS_METHOD_PDS && !opt->progressive)) return 0;
    for (i = 0; i < s->materials.count; i++)
        if (s->materials.items[i].type == PDS_MAT_DIELECTRIC) return PDS__EYE_SPLITS;
    return 0;
}

/* Whether a render's eye pass merges each pixel's vertices
   (pds__eye_merge): progressive PDS's and splat's. */
static int pds__eye_merges(const pds_options *opt)
{
#ifdef PDS_NO_EYE_MERGE
    (void)opt;
    return 0; /* a build for measuring what merging does */
#else
    return (opt->method == PDS_METHOD_PDS && opt->progressive) || opt->method == PDS_METHOD_SPLAT;
#endif
}

/* A camera path between two bounces. */
typedef struct pds__eye_path {
    pds__v3 org, dir, prev_p;
    double beta[3], beta_rgb[3];
    double sigma[3];          /* Beer coefficients of the medium the ray is in, if has_sigma */
    const double *sigma_rgb;  /* spectral: the RGB ones for beta_rgb, or NULL */
    int has_sigma, depth, had_diffuse, specular_since, chromatic, splits_left;
    int diffuse;              /* non-specular vertices so far */
    int emission_only;        /* past the last diffuse bounce allowed: the
                                 next hit counts only if it emits */
    double prev_pdf;          /* solid-angle pdf of the last non-specular BSDF sample */
    double lam;               /* the wavelength once the path is spectral, else 0 */
    uint64_t branch;
} pds__eye_path;

/* What one camera sample shares between its branches. */
typedef struct pds__eye_sample {
    const pds__tracer *tr;
    uint64_t idx;
    double lambda, film[3];
    double *acc;
    pds__eye_vertex *rec;
    int nrec;
} pds__eye_sample;

static void pds__eye_continue(pds__eye_sample *es, pds__eye_path *ps);

/* Path ps leaves its vertex (hit, material m) by the BSDF sample bs whose
   weight already carries any branch factor: update the throughput, the
   medium and the last-sample pdf, play Russian roulette past rr_depth, and
   move to the next ray. 0 if the path ends. */
static int pds__eye_advance(const pds__eye_sample *es, pds__eye_path *ps, const pds_material *m, const pds_hit *hit,
                            pds__bsdf_result *bs)
{
    const pds__tracer *tr = es->tr;
    uint64_t dim = 2 + (uint64_t)ps->depth * PDS__DIMS_PER_BOUNCE + ps->branch * PDS__BRANCH_DIMS;
    int c;
    if (ps->lam > 0.0) {
        /* the chain's RGB weight: this material's RGB weight, with its
           RGB Beer coefficients on the side the path goes on */
        for (c = 0; c < 3; c++) ps->beta_rgb[c] *= bs->weight[c];
        if (m->type == PDS_MAT_DIELECTRIC)
            ps->sigma_rgb = pds__medium_absorption(&tr->scene->materials.items[hit->material], bs->side);
        pds__spectral_uplift(ps->lam, bs->weight);
    }
    for (c = 0; c < 3; c++) ps->beta[c] *= bs->weight[c];
    if (bs->delta) {
        ps->specular_since++;
    } else {
        ps->prev_pdf = bs->pdf;
        ps->prev_p = hit->position;
    }
    if (m->type == PDS_MAT_DIELECTRIC) {
        const double *a = pds__medium_absorption(m, bs->side);
        if (a) memcpy(ps->sigma, a, sizeof ps->sigma);
        ps->has_sigma = a != NULL;
    }
    /* Russian roulette: survive with probability min(1, max(beta)). */
    if (ps->depth + 1 >= tr->rr_depth) {
        double b = fmax(ps->beta[0], fmax(ps->beta[1], ps->beta[2])), q = b < 1.0 ? b : 1.0;
        if (!(q > 0.0) || pds__rng_uniform(tr->seed, PDS__RNG_PIXEL, es->idx, dim + 6) >= q) return 0;
        for (c = 0; c < 3; c++) {
            ps->beta[c] /= q;
            ps->beta_rgb[c] /= q;
        }
    }
    ps->org = pds__offset(tr, hit->position, hit->ng, bs->wi);
    ps->dir = bs->wi;
    ps->depth++;
    return 1;
}

/* One branch of a split at glass: branch code b, weight factor w (F or
   1 - F), pruned by Russian roulette below PDS__EYE_SPLIT_MIN. 0 if it is
   not followed. */
static int pds__eye_branch(const pds__eye_sample *es, pds__eye_path *ps, uint64_t b, double w, pds__bsdf_result *bs)
{
    int c;
    ps->branch = b;
    ps->splits_left--;
    if (w < PDS__EYE_SPLIT_MIN) {
        uint64_t dim = 2 + (uint64_t)ps->depth * PDS__DIMS_PER_BOUNCE + b * PDS__BRANCH_DIMS;
        if (!(w > 0.0) || pds__rng_uniform(es->tr->seed, PDS__RNG_PIXEL, es->idx, dim + 7) * PDS__EYE_SPLIT_MIN >= w)
            return 0;
        w = PDS__EYE_SPLIT_MIN;
    }
    for (c = 0; c < 3; c++) bs->weight[c] *= w;
    return 1;
}

static void pds__eye_continue(pds__eye_sample *es, pds__eye_path *ps)
{
    const pds__tracer *tr = es->tr;
    const pds_scene *s = tr->scene;
    pds_material m_lambda;
    for (; ps->depth <= tr->max_depth;) {
        uint64_t dim = 2 + (uint64_t)ps->depth * PDS__DIMS_PER_BOUNCE + ps->branch * PDS__BRANCH_DIMS;
        pds__tri_hit th;
        pds_hit hit;
        double tl = 0.0, le[3];
        const double *film_w = ps->lam > 0.0 ? es->film : NULL;
        const double *sigma = ps->has_sigma ? ps->sigma : NULL;
        pds__v3 nl = pds__v(0.0, 0.0, 0.0);
        int found = pds__bvh_intersect(&s->bvh, ps->org, ps->dir, 0.0, DBL_MAX, &th);
        int light_hit = pds__hit_analytic_light(s, ps->org, ps->dir, found ? th.t : DBL_MAX, &tl, &nl);
        const pds_material *m;
        pds__bsdf_result bs;
        double u[3];
        int c, caustic = ps->had_diffuse && ps->specular_since > 0;
        if (light_hit >= 0 || (found && s->materials.items[s->mesh.mat[th.tri]].type == PDS_MAT_EMISSIVE)) {
            /* An emitter ends the path; emitters do not reflect. */
            pds__v3 x, nx;
            int k;
            double mis = 1.0;
            if (light_hit >= 0) {
                k = light_hit;
                x = pds__add(ps->org, pds__scale(ps->dir, tl));
                nx = nl;
                pds__light_le(&s->lights[k], nx, pds__scale(ps->dir, -1.0), le);
            } else {
                pds__scene_fill_hit(s, &th, ps->org, ps->dir, &hit);
                k = pds__light_of_triangle(&s->light_table, th.tri);
                x = hit.position;
                nx = hit.ng;
                pds__light_le(&s->lights[k], nx, pds__scale(ps->dir, -1.0), le);
            }
            pds__spectral_uplift(ps->lam, le);
            pds__beer(sigma, light_hit >= 0 ? tl : th.t, ps->beta);
            if (ps->had_diffuse && ps->specular_since == 0) {
                /* next-event estimation could have found this point too */
                double pdf_light = pds__lights_pmf(&s->light_table, k) *
                                   pds__light_pdf_li(&s->light_table, &s->lights[k], k, &s->mesh, ps->prev_p, x, nx);
                mis = pds__mis_power(ps->prev_pdf, pdf_light);
            }
            for (c = 0; c < 3; c++) le[c] *= ps->beta[c];
            pds__accumulate(tr, caustic, le, mis, film_w, es->acc);
            return;
        }
        if (!found) {
            /* the ray leaves the scene: the environment sees it (black
               without one); weighted against next-event estimation as an
               area light is */
            if (s->env_index1) {
                int k = s->env_index1 - 1;
                double mis = 1.0;
                pds__env_radiance(&s->lights[k], ps->dir, le);
                if (ps->had_diffuse && ps->specular_since == 0)
                    mis = pds__mis_power(ps->prev_pdf,
                                         pds__lights_pmf(&s->light_table, k) *
                                             pds__env_pdf(&s->lights[k], &s->light_table.env_p[3 * k], ps->dir));
                pds__spectral_uplift(ps->lam, le);
                pds__beer(sigma, DBL_MAX, ps->beta);
                for (c = 0; c < 3; c++) le[c] *= ps->beta[c];
                pds__accumulate(tr, caustic, le, mis, film_w, es->acc);
            }
            return;
        }
        if (ps->emission_only) return;
        pds__scene_fill_hit(s, &th, ps->org, ps->dir, &hit);
        pds__beer(sigma, th.t, ps->beta);
        pds__beer(ps->sigma_rgb, th.t, ps->beta_rgb);
        m = &s->materials.items[hit.material];
        if (es->lambda > 0.0 && pds__material_is_dispersive(m)) {
            if (!ps->had_diffuse) ps->chromatic = 1;
            if (ps->lam == 0.0) {
                /* the path turns spectral here: its throughput and the
                   medium it is in, at lambda */
                ps->lam = es->lambda;
                film_w = es->film;
                pds__spectral_uplift(ps->lam, ps->beta);
                if (ps->has_sigma) pds__spectral_uplift(ps->lam, ps->sigma);
            }
        }
        if (ps->lam > 0.0) {
            pds__spectral_material(m, ps->lam, &m_lambda);
            m = &m_lambda;
        }
        if (!pds__material_is_specular(m)) {
            if (es->rec && !ps->had_diffuse && es->nrec < PDS__EYE_LEAVES) {
                pds__eye_vertex *v = &es->rec[es->nrec];
                const double *imp = ps->lam > 0.0 && !ps->chromatic ? ps->beta_rgb : ps->beta;
                if (pds__eye_vertex_set(v, m, hit.position, hit.ns, hit.ng, pds__scale(ps->dir, -1.0), imp,
                                        hit.material)) {
                    v->lambda = ps->chromatic ? (float)es->lambda : 0.0f;
                    es->nrec++;
                }
            }
            if (tr->vertices_only) return;
            pds__direct_light(tr, m, hit.position, pds__scale(ps->dir, -1.0), hit.ns, hit.ng, ps->beta, es->idx, dim,
                              ps->lam, film_w, es->acc);
            ps->had_diffuse = 1;
            ps->specular_since = 0;
            /* the last diffuse bounce allowed: one more ray, for the
               emitter it may hit (the BSDF sample's half of the direct
               light's multiple importance sampling) */
            if (tr->max_diffuse >= 0 && ++ps->diffuse > tr->max_diffuse) ps->emission_only = 1;
        }
        if (ps->depth == tr->max_depth) return;
        if (!ps->had_diffuse && ps->splits_left > 0 && m->type == PDS_MAT_DIELECTRIC) {
            /* both branches (u[0] below F reflects, 1 always transmits
               when it can); the sampler's weights divide by the choice's
               probability, which the branch weight F or 1 - F restores */
            static const double ur[3] = {0.0, 0.0, 0.0}, ut[3] = {1.0, 0.0, 0.0};
            pds__bsdf_result br, bt;
            pds__v3 wo = pds__scale(ps->dir, -1.0);
            if (pds__bsdf_sample(m, hit.position, wo, hit.ns, hit.ng, ur, PDS__RADIANCE, &br) && !br.transmitted &&
                pds__bsdf_sample(m, hit.position, wo, hit.ns, hit.ng, ut, PDS__RADIANCE, &bt) && bt.transmitted) {
                pds__eye_path child = *ps;
                uint64_t b = ps->branch;
                if (pds__eye_branch(es, &child, 2 * b + 1, br.pdf, &br) && pds__eye_advance(es, &child, m, &hit, &br))
                    pds__eye_continue(es, &child);
                if (!pds__eye_branch(es, ps, 2 * b + 2, bt.pdf, &bt) || !pds__eye_advance(es, ps, m, &hit, &bt)) return;
                continue;
            }
        }
        for (c = 0; c < 3; c++) u[c] = pds__rng_uniform(tr->seed, PDS__RNG_PIXEL, es->idx, dim + 3 + (uint64_t)c);
        if (!pds__bsdf_sample(m, hit.position, pds__scale(ps->dir, -1.0), hit.ns, hit.ng, u, PDS__RADIANCE, &bs)) return;
        if (!pds__eye_advance(es, ps, m, &hit, &bs)) return;
    }
}

static int pds__trace_path(const pds__tracer *tr, pds__v3 org, pds__v3 dir, uint64_t idx, double lambda,
                           double acc[3], pds__eye_vertex *rec)
{
    pds__eye_sample es;
    pds__eye_path ps;
    memset(&es, 0, sizeof es);
    memset(&ps, 0, sizeof ps);
    es.tr = tr;
    es.idx = idx;
    es.lambda = lambda;
    es.acc = acc;
    es.rec = rec;
    if (lambda > 0.0) pds__film_weight(lambda, es.film);
    ps.org = org;
    ps.dir = dir;
    ps.prev_p = org;
    ps.beta[0] = ps.beta[1] = ps.beta[2] = 1.0;
    ps.beta_rgb[0] = ps.beta_rgb[1] = ps.beta_rgb[2] = 1.0;
    ps.splits_left = tr->eye_splits;
    if (lambda > 0.0 && tr->spectral_all) ps.lam = lambda;
    pds__eye_continue(&es, &ps);
    return es.nrec;
}

/* A method's own eye path in place of pds__trace_path (gi, >>gi): the
   same contract, plus counts[0..3], the row's counters of the method's own
   events (summed in row order, so the totals do not depend on threads),
   and values: 0 when only the vertex is wanted, not acc (a row of another
   shard, or one whose value the part already holds, >>partial). */
typedef int (*pds__path_fn)(const void *ctx, const pds__tracer *tr, pds__v3 org, pds__v3 dir, uint64_t idx,
                            double lambda, double acc[3], pds__eye_vertex *rec, long counts[4], int values);

/* --- the render scheduler ----------------------------------------------- */
/* Rows (from a list: all of them, or a shard's, >>partial) are handed out
   to threads one at a time under a mutex; each pixel's samples are
   accumulated by the one thread that owns its row, in sample order, into a
   double-precision sum. So the image is the same whatever the thread
   count. A stop asked for by the progress callback hands out no more rows;
   the rows handed out are finished, so the rows done are the list's first. A progressive render (time budget) runs whole passes
   of spp samples per pixel; pass p uses sample indices p*spp .. p*spp+spp-1. */

typedef struct pds__render_job {
    const pds_scene *scene;
    pds__camera_frame frame;
    pds__tracer tracer;
    pds_method method;
    double *sum;           /* 3 doubles per pixel, all passes */
    int spp, pass, total_spp_max;
    pds_filter filter;
    uint64_t seed;
    const int *rows;       /* the rows to render, in this order */
    int nrows;
    pds__mutex lock;
    int next_row;          /* guarded by lock: index into rows */
    int rows_done;         /* guarded by lock */
    int stop;              /* guarded by lock: stop handing out rows */
    int stop_requested;    /* guarded by lock: the progress callback said stop */
    int stoppable;         /* a stop may end a pass early (not under a time
                              budget, whose passes must be whole) */
    pds__thread_id caller;
    pds_progress_fn progress;
    void *progress_user;
    double t0, progress_scale, progress_base;
    /* Eye-path vertices, when a photon method asked for them: one growable
       array per image row, filled by the thread that renders the row, so
       the concatenation in row order is the same for any thread count. */
    int record_eye;
    int record_pass;       /* ... in this pass only (-1: every pass) */
    int merge_eye;         /* merge each pixel's vertices (pds__eye_merge) */
    pds__eye_vertex **row_vertices;
    size_t *row_count, *row_cap;
    int out_of_memory;     /* guarded by lock */
    pds__path_fn path;     /* NULL: pds__trace_path */
    const void *path_ctx;
    long *row_counts;      /* with path: 4 counters per row */
    const unsigned char *row_values; /* with path: per row, 0 = its vertices
                              only (the path's values argument); NULL: all */
} pds__render_job;

static void pds__render_pixel(pds__render_job *job, int x, int y, double *out)
{
    uint64_t pixel = (uint64_t)y * (uint64_t)job->frame.width + (uint64_t)x;
    /* the stratification's permutations: one pattern per pixel and pass */
    uint64_t pattern = pds__rng_bits(job->seed, PDS__RNG_STRATA, pixel, (uint64_t)job->pass);
    int record = job->record_eye && (job->record_pass < 0 || job->record_pass == job->pass);
    size_t first = record ? job->row_count[y] : 0; /* the pixel's first vertex */
    int k, c;
    for (k = 0; k < job->spp; k++) {
        uint64_t sample = (uint64_t)job->pass * (uint64_t)job->spp + (uint64_t)k;
        uint64_t idx = pixel * (uint64_t)job->total_spp_max + sample;
        double u1, u2, ox, oy;
        pds__v3 org, dir;
        double acc[3] = {0.0, 0.0, 0.0};
        /* the pass's spp samples stratified over the pixel (pds__cmj), each
           jittered within its cell by the sample's own dimensions 0, 1 */
        pds__cmj(k, job->spp, pattern, pds__rng_uniform(job->seed, PDS__RNG_PIXEL, idx, 0),
                 pds__rng_uniform(job->seed, PDS__RNG_PIXEL, idx, 1), &u1, &u2);
        ox = job->filter == PDS_FILTER_TENT ? 0.5 + pds__tent_sample(u1) : u1;
        oy = job->filter == PDS_FILTER_TENT ? 0.5 + pds__tent_sample(u2) : u2;
        /* a thin lens takes its lens point from its own numbers; a pinhole
           none, so its images are those of a camera without the lens */
        if (job->frame.aperture > 0.0)
            dir = pds__camera_ray(&job->frame, x + ox, y + oy, pds__rng_uniform(job->seed, PDS__RNG_LENS, idx, 0),
                                  pds__rng_uniform(job->seed, PDS__RNG_LENS, idx, 1), &org);
        else
            dir = pds__camera_ray(&job->frame, x + ox, y + oy, 0.0, 0.0, &org);
        if (job->method != PDS_METHOD_PREVIEW) {
            pds__eye_vertex v[PDS__EYE_LEAVES];
            double lambda = job->tracer.spectral ? pds__eye_wavelength(job->seed, pixel, sample) : 0.0;
            int recorded, j;
            recorded = job->path ? job->path(job->path_ctx, &job->tracer, org, dir, idx, lambda, acc,
                                             record ? v : NULL, &job->row_counts[4 * (size_t)y],
                                             !job->row_values || job->row_values[y])
                                 : pds__trace_path(&job->tracer, org, dir, idx, lambda, acc, record ? v : NULL);
            if (recorded) {
                pds__eye_vertex **arr = &job->row_vertices[y];
                if (pds__grow((void **)arr, &job->row_cap[y], job->row_count[y] + (size_t)recorded, sizeof **arr) == 0) {
                    for (j = 0; j < recorded; j++) {
                        for (c = 0; c < 3; c++) {
                            v[j].importance[c] /= (float)job->spp;
                            v[j].weight[c] /= (float)job->spp;
                        }
                        v[j].pixel = (int)pixel;
                        (*arr)[job->row_count[y]++] = v[j];
                    }
                } else {
                    pds__mutex_lock(&job->lock);
                    job->out_of_memory = 1;
                    pds__mutex_unlock(&job->lock);
                }
            }
        } else {
            pds__tri_hit th;
            if (pds__bvh_intersect(&job->scene->bvh, org, dir, 0.0, DBL_MAX, &th)) {
                pds_hit hit;
                double rgb[3], cosine;
                pds__scene_fill_hit(job->scene, &th, org, dir, &hit);
                pds__material_preview_colour(&job->scene->materials.items[hit.material], rgb);
                cosine = fabs(pds__dot(hit.ns, dir));
                for (c = 0; c < 3; c++) acc[c] = rgb[c] * cosine;
            }
        }
        for (c = 0; c < 3; c++) out[c] += acc[c];
    }
    if (record && job->merge_eye && job->row_count[y] > first + 1)
        job->row_count[y] = first + pds__eye_merge(job->row_vertices[y] + first, job->row_count[y] - first, &job->frame);
}

static void *pds__render_worker(void *arg)
{
    pds__render_job *job = (pds__render_job *)arg;
    int is_caller = pds__thread_equal(pds__thread_self(), job->caller);
    for (;;) {
        int y, x, done, k;
        pds__mutex_lock(&job->lock);
        k = job->stop ? job->nrows : job->next_row++;
        pds__mutex_unlock(&job->lock);
        if (k >= job->nrows) break;
        y = job->rows[k];
        for (x = 0; x < job->frame.width; x++)
            pds__render_pixel(job, x, y, &job->sum[3 * ((size_t)y * job->frame.width + x)]);
        pds__mutex_lock(&job->lock);
        done = ++job->rows_done;
        pds__mutex_unlock(&job->lock);
        if (is_caller && job->progress &&
            job->progress(job->progress_user, PDS_PHASE_EYE, job->progress_base + job->progress_scale * done / job->nrows,
                          pds_time_now() - job->t0) &&
            !job->stop_requested) {
            pds__mutex_lock(&job->lock);
            job->stop_requested = 1;
            job->stop = job->stoppable; /* the rows handed out are finished: the done rows stay a prefix */
            pds__mutex_unlock(&job->lock);
        }
    }
    return NULL;
}

/* Run fn(arg) on n threads (the caller's thread is one of them). Returns
   the number of threads that ran. */
static int pds__run_threads(int n, void *(*fn)(void *), void *arg)
{
    return pds__threads_run(n, fn, arg);
}


/* ===================================================================== */
/* >>debug                                                               */
/* ===================================================================== */
/* Teaching views (pds_options.debug, `pds render --debug NAME`): pictures
   of what the method does, each with a colour bar and its scale drawn in a
   strip under the image, and the path recorder behind `pds trace-photon`
   and the paths view.

   None of it runs in a render that does not ask for it: the photon tracer
   and the splats test one pointer (NULL when off) per bounce and per
   splat term, and everything else happens after the render.

   Pictures are linear RGB in [0, 1]. Points in the scene are projected
   straight through the pinhole camera (>>render's camera_dir inverted)
   and drawn only where the camera sees them: when the straight segment
   from the camera to the point meets no opaque surface first
   (pds__camera_sees). Glass is looked through, refraction ignored: a
   landing point under a glass sphere is drawn where it would be seen
   without the glass; one under a table or behind a mirror is not drawn.
   Counts are exact integers, summed per thread and merged, so every view
   is the same for any thread count. */

/* --- a 3x5 bitmap font for the legends -------------------------------- */

static const char pds__font_chars[] = "0123456789.-+e/x ";
/* rows top to bottom, 3 bits each, the left pixel the high bit */
static const unsigned short pds__font_bits[] = {
    075557, 026227, 071747, 071717, 055711, 074717, 074757, 071111, 075757, 075717,
    000002, 000700, 002720, 007746, 011244, 005250, 000000};

/* Draw text at (x, y) (its top left pixel) in colour rgb; characters the
   font lacks are blanks. Clipped to the picture. */
static void pds__draw_text(pds_image *img, int x, int y, const char *text, const float rgb[3])
{
    for (; *text; text++, x += 4) {
        const char *f = strchr(pds__font_chars, *text);
        unsigned bits = f ? pds__font_bits[f - pds__font_chars] : 0u;
        int row, col, c;
        for (row = 0; row < 5; row++)
            for (col = 0; col < 3; col++) {
                int px = x + col, py = y + row;
                if (!((bits >> (3 * (4 - row) + (2 - col))) & 1u)) continue;
                if (px < 0 || py < 0 || px >= img->width || py >= img->height) continue;
                for (c = 0; c < 3; c++) img->rgb[3 * ((size_t)py * img->width + px) + c] = rgb[c];
            }
    }
}

/* --- colour maps ------------------------------------------------------- */

/* Counts and densities: black -> red -> yellow -> white over t in [0, 1]. */
static void pds__colour_heat(double t, float rgb[3])
{
    t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
    rgb[0] = (float)fmin(1.0, 3.0 * t);
    rgb[1] = (float)fmin(1.0, fmax(0.0, 3.0 * t - 1.0));
    rgb[2] = (float)fmin(1.0, fmax(0.0, 3.0 * t - 2.0));
}

/* Anisotropy m_a in [0, 1]: red (needle) to green (round). */
static void pds__colour_aniso(double t, float rgb[3])
{
    t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
    rgb[0] = (float)(1.0 - t);
    rgb[1] = (float)t;
    rgb[2] = 0.0f;
}

/* Format v in at most 7 characters the font has ("0.25", "1.2e+04"). */
static void pds__legend_number(double v, char *buf, size_t n)
{
    if (v == floor(v) && fabs(v) < 1e6) snprintf(buf, n, "%.0f", v);
    else if (fabs(v) >= 0.01 && fabs(v) < 1e4) snprintf(buf, n, "%.3g", v);
    else snprintf(buf, n, "%.1e", v);
}

/* Allocate picture as width x (h + PDS_DEBUG_LEGEND_ROWS) and draw the
   legend strip: a colour bar from map(0) to map(1) across the width, a
   tick and label at each of the nticks fractions ticks[] (value
   ticks[i] * vmax), and the bar's two ends labelled 0 and vmax. */
static pds_status pds__picture_alloc(pds_image *pic, int w, int h, void (*map)(double, float[3]), double vmax,
                                     const double *ticks, int nticks)
{
    static const float white[3] = {1.0f, 1.0f, 1.0f};
    int x, y, c, i, bar0 = h + 2, bar1 = h + 6;
    char label[32];
    if (pds_image_alloc(pic, w, h + PDS_DEBUG_LEGEND_ROWS) != PDS_OK) return PDS_ERR_NOMEM;
    for (x = 0; x < w; x++) {
        float rgb[3];
        map(w > 1 ? (double)x / (w - 1) : 1.0, rgb);
        for (y = bar0; y < bar1; y++)
            for (c = 0; c < 3; c++) pic->rgb[3 * ((size_t)y * w + x) + c] = rgb[c];
    }
    pds__draw_text(pic, 0, bar1 + 2, "0", white);
    pds__legend_number(vmax, label, sizeof label);
    pds__draw_text(pic, w - 4 * (int)strlen(label) + 1, bar1 + 2, label, white);
    for (i = 0; i < nticks; i++) {
        x = (int)floor(ticks[i] * (w - 1) + 0.5);
        if (x < 0 || x >= w) continue;
        for (y = bar0 - 1; y <= bar1; y++)
            for (c = 0; c < 3; c++) pic->rgb[3 * ((size_t)y * w + x) + c] = 1.0f;
        pds__legend_number(ticks[i] * vmax, label, sizeof label);
        if (label[0] == '0' && label[1] == '.') memmove(label, label + 1, strlen(label)); /* ".1" */
        pds__draw_text(pic, x - 2 * (int)strlen(label) + 1, bar1 + 2, label, white);
    }
    return PDS_OK;
}

/* A count image (value rgb all the count) as a heat picture, scaled to
   its largest count. */
static pds_status pds__picture_counts(const pds_image *val, pds_image *pic, double *vmax)
{
    size_t i, n = (size_t)val->width * val->height;
    double mx = 0.0;
    for (i = 0; i < n; i++) mx = fmax(mx, val->rgb[3 * i]);
    *vmax = mx;
    if (pds__picture_alloc(pic, val->width, val->height, pds__colour_heat, mx, NULL, 0)) return PDS_ERR_NOMEM;
    for (i = 0; i < n; i++)
        if (val->rgb[3 * i] > 0.0f) pds__colour_heat(val->rgb[3 * i] / mx, &pic->rgb[3 * i]);
    return PDS_OK;
}

/* --- projection and lines ---------------------------------------------- */

/* Image position (pixels, (0,0) the top left corner) of scene point p seen
   through the pinhole camera f: the inverse of pds__camera_dir. 0 when p
   is not in front of the camera. */
static int pds__camera_project(const pds__camera_frame *f, pds__v3 p, double *px, double *py)
{
    pds__v3 d = pds__sub(p, f->origin);
    double z = pds__dot(d, f->forward), sx, sy;
    if (!(z > 0.0)) return 0;
    sx = pds__dot(d, f->right) / z;
    sy = pds__dot(d, f->up) / z;
    *px = (sx / (f->tan_half_fov * f->aspect) + 1.0) * 0.5 * f->width;
    *py = (1.0 - sy / f->tan_half_fov) * 0.5 * f->height;
    return isfinite(*px) && isfinite(*py);
}

/* Pixel index of p, or -1 when it is outside the image. */
static long pds__camera_pixel(const pds__camera_frame *f, pds__v3 p)
{
    double px, py;
    if (!pds__camera_project(f, p, &px, &py)) return -1;
    if (!(px >= 0.0 && px < f->width && py >= 0.0 && py < f->height)) return -1;
    return (long)floor(py) * f->width + (long)floor(px);
}

/* Does the camera at f see scene point p? Yes when the segment from the
   camera to p meets no surface before p but dielectric ones (glass is
   looked through; refraction is ignored, as in the projection). The
   segment stops 1e-4 of its length short of p, so that the surface p lies
   on does not hide it. A point on the back of a single, open surface
   (a quad seen from the other side) counts as seen. Deterministic: at
   most 64 glass surfaces are passed, after that p counts as hidden. */
static int pds__camera_sees(const pds_scene *s, const pds__camera_frame *f, pds__v3 p)
{
    pds__v3 d = pds__sub(p, f->origin);
    double tmin = 0.0;
    int k;
    for (k = 0; k < 64; k++) {
        pds__tri_hit hit;
        if (!pds__bvh_intersect(&s->bvh, f->origin, d, tmin, 1.0 - 1e-4, &hit)) return 1;
        if (s->materials.items[s->mesh.mat[hit.tri]].type != PDS_MAT_DIELECTRIC) return 0;
        tmin = hit.t + 1e-9; /* on past this glass surface (t in units of |d|) */
    }
    return 0;
}

/* Pixel index of p when the camera sees it (pds__camera_sees), else -1. */
static long pds__camera_pixel_seen(const pds_scene *s, const pds__camera_frame *f, pds__v3 p)
{
    long px = pds__camera_pixel(f, p);
    return px >= 0 && pds__camera_sees(s, f, p) ? px : -1;
}

/* --- per-thread buffers of the views fed by the splats ------------------- */

/* A footprint to draw: photon number, centre, conjugate semi-diameters. */
typedef struct pds__ellipse {
    long photon;
    pds__v3 c, a, b;
} pds__ellipse;

typedef struct pds__debug_buf {
    const pds_scene *scene; /* for what the camera sees */
    pds__sum128 *aniso;     /* footprint: 2 per pixel, sum K m_a and sum K, x 2^64 */
    uint64_t *splats;       /* splats: terms per pixel */
    uint64_t *landings;     /* landings: photons per pixel */
    long landed, landed_in_frame;
    long ellipse_every;     /* ellipses: 0 = off */
    pds__ellipse *ell;
    size_t nell, cap_ell;
    int out_of_memory;
} pds__debug_buf;

/* One splat term reached eye vertex `pixel` with kernel value k; m_a is the
   footprint's anisotropy. */
static void pds__debug_visit(pds__debug_buf *d, int pixel, double k, double m_a)
{
    if (d->aniso) {
        pds__sum128_add(&d->aniso[2 * (size_t)pixel], k * m_a * PDS__TWO64);
        pds__sum128_add(&d->aniso[2 * (size_t)pixel + 1], k * PDS__TWO64);
    }
    if (d->splats) d->splats[pixel]++;
}

/* Photon number `photon` landed at p with the footprint (du, dv) it is
   splatted with. It counts, and its ellipse is drawn, only when the
   camera sees p. */
static void pds__debug_landing(pds__debug_buf *d, const pds__camera_frame *f, long photon, pds__v3 p, pds__v3 du,
                               pds__v3 dv)
{
    long px = pds__camera_pixel_seen(d->scene, f, p);
    d->landed++;
    if (px >= 0) {
        d->landed_in_frame++;
        if (d->landings) d->landings[px]++;
    }
    /* an ellipse whose centre is out of frame may still reach into it */
    if (d->ellipse_every > 0 && photon % d->ellipse_every == 0 && pds__camera_sees(d->scene, f, p)) {
        pds__ellipse *e;
        if (pds__grow((void **)&d->ell, &d->cap_ell, d->nell + 1, sizeof *d->ell)) {
            d->out_of_memory = 1;
            return;
        }
        e = &d->ell[d->nell++];
        e->photon = photon;
        e->c = p;
        e->a = pds__scale(du, 0.5);
        e->b = pds__scale(dv, 0.5);
    }
}

static int pds__ellipse_cmp(const void *a, const void *b)
{
    const pds__ellipse *x = (const pds__ellipse *)a, *y = (const pds__ellipse *)b;
    return (x->photon > y->photon) - (x->photon < y->photon);
}

/* Draw the ellipse c + a cos t + b sin t as 64 projected segments into
   the first h rows of pic (colour rgb), counting in cnt (w x h, may be
   NULL) the pixels it passes through, once per ellipse. Returns 1 if any
   of it is in the image. */
static int pds__draw_ellipse(pds_image *pic, int h, float *cnt, const pds__camera_frame *f, const pds__ellipse *e,
                             const float rgb[3])
{
    int k, any = 0, w = pic->width;
    double x0 = 0.0, y0 = 0.0;
    int ok0 = 0;
    for (k = 0; k <= 64; k++) {
        double t = 2.0 * PDS__PI * k / 64.0, x1, y1;
        pds__v3 p = pds__add(e->c, pds__add(pds__scale(e->a, cos(t)), pds__scale(e->b, sin(t))));
        int ok1 = pds__camera_project(f, p, &x1, &y1);
        if (ok0 && ok1) {
            /* a DDA line from (x0,y0) to (x1,y1), at most 4 w + 4 h steps */
            double dx = x1 - x0, dy = y1 - y0, len = fmax(fabs(dx), fabs(dy));
            int n = (int)fmin(ceil(len), 4.0 * (w + h)), j, c;
            for (j = 0; j <= n; j++) {
                double s = n > 0 ? (double)j / n : 0.0;
                long px = (long)floor(x0 + s * dx), py = (long)floor(y0 + s * dy);
                size_t i;
                if (px < 0 || py < 0 || px >= w || py >= h) continue;
                i = (size_t)py * w + (size_t)px;
                any = 1;
                for (c = 0; c < 3; c++) pic->rgb[3 * i + c] = rgb[c];
                if (cnt && cnt[3 * i + 1] != (float)(e->photon + 1)) {
                    /* green channel: the last ellipse counted here */
                    cnt[3 * i] += 1.0f;
                    cnt[3 * i + 1] = (float)(e->photon + 1);
                }
            }
        }
        x0 = x1;
        y0 = y1;
        ok0 = ok1;
    }
    return any;
}

/* --- the path recorder -------------------------------------------------- */

/* What `pds trace-photon` and the paths view see of a photon, recorded by
   the tracing loop when buf->path is set (NULL in every other render, so
   the loop pays one untaken branch per bounce). An event is a vertex of
   the path: the emission point, each specular bounce (position and
   positional differentials transferred to the hit, direction and
   directional differentials as they leave it) and the landing. */
typedef struct pds__path_event {
    long photon;
    int seq;            /* vertex number along the photon's path */
    int event;          /* pds_trace_event */
    int material;       /* -1 at emission */
    long triangle;      /* -1 at emission */
    pds__ray_diff r;
    double flux[3];
} pds__path_event;

typedef struct pds__path_rec {
    long photon_end;    /* record photons with numbers below this */
    pds__path_event *ev;
    size_t n, cap;
    int out_of_memory;
} pds__path_rec;

static void pds__path_note(pds__path_rec *rec, long photon, int seq, int event, int material, long tri,
                           const pds__ray_diff *r, const double flux[3])
{
    pds__path_event *e;
    if (pds__grow((void **)&rec->ev, &rec->cap, rec->n + 1, sizeof *rec->ev)) {
        rec->out_of_memory = 1;
        return;
    }
    e = &rec->ev[rec->n++];
    e->photon = photon;
    e->seq = seq;
    e->event = event;
    e->material = material;
    e->triangle = tri;
    e->r = *r;
    memcpy(e->flux, flux, sizeof e->flux);
}

static int pds__path_event_cmp(const void *a, const void *b)
{
    const pds__path_event *x = (const pds__path_event *)a, *y = (const pds__path_event *)b;
    if (x->photon != y->photon) return x->photon < y->photon ? -1 : 1;
    return (x->seq > y->seq) - (x->seq < y->seq);
}

/* The recorded paths (events sorted by photon and vertex) as OBJ text:
   per photon an `o photon_I`, its vertices and one `l` polyline through
   them; a photon with a single vertex (it met nothing) is left out.
   Returns NULL when memory runs out. */
static char *pds__paths_obj(const pds__path_event *ev, size_t n, long *paths, long *segments)
{
    char *text = NULL;
    size_t len = 0, cap = 0, i = 0, j, k;
    long vbase = 0;
    *paths = *segments = 0;
    /* at most 200 bytes per vertex line, per polyline corner and per header */
    if (pds__grow((void **)&text, &cap, 256 + n * 400, 1)) return NULL;
    len += (size_t)snprintf(text + len, cap - len, "# photon paths written by pds: emission, specular bounces, landing\n");
    while (i < n) {
        for (j = i; j < n && ev[j].photon == ev[i].photon; j++) continue;
        if (j - i >= 2) {
            len += (size_t)snprintf(text + len, cap - len, "o photon_%ld\n", ev[i].photon);
            for (k = i; k < j; k++)
                len += (size_t)snprintf(text + len, cap - len, "v %.9g %.9g %.9g\n", ev[k].r.p.x, ev[k].r.p.y,
                                        ev[k].r.p.z);
            len += (size_t)snprintf(text + len, cap - len, "l");
            for (k = i; k < j; k++) len += (size_t)snprintf(text + len, cap - len, " %ld", vbase + (long)(k - i) + 1);
            len += (size_t)snprintf(text + len, cap - len, "\n");
            vbase += (long)(j - i);
            *paths += 1;
            *segments += (long)(j - i) - 1;
        }
        i = j;
    }
    return text;
}

/* --- assembling the views ------------------------------------------------ */

static int pds__debug_wants(const pds_debug *d, pds_debug_view v)
{
    return d && (d->views & (1u << v)) != 0;
}

/* Allocate the threads' buffers for the views d asks of a photon pass of
   method m (w x h pixels) in scene s. Returns 0 when memory runs out. */
static int pds__debug_bufs_init(pds__debug_buf *b, const pds_scene *s, const pds_debug *d, pds_method m, long photons,
                                size_t npix)
{
    int splats = m == PDS_METHOD_PDS || m == PDS_METHOD_SPLAT;
    memset(b, 0, sizeof *b);
    b->scene = s;
    if (m == PDS_METHOD_PDS && pds__debug_wants(d, PDS_DEBUG_FOOTPRINT))
        if (!(b->aniso = (pds__sum128 *)calloc(npix * 2, sizeof *b->aniso))) return 0;
    if (splats && pds__debug_wants(d, PDS_DEBUG_SPLATS))
        if (!(b->splats = (uint64_t *)calloc(npix, sizeof *b->splats))) return 0;
    if (splats && pds__debug_wants(d, PDS_DEBUG_LANDINGS))
        if (!(b->landings = (uint64_t *)calloc(npix, sizeof *b->landings))) return 0;
    if (m == PDS_METHOD_PDS && pds__debug_wants(d, PDS_DEBUG_ELLIPSES)) {
        b->ellipse_every = d->ellipse_every > 0 ? d->ellipse_every : photons / 100;
        if (b->ellipse_every < 1) b->ellipse_every = 1;
    }
    return 1;
}

/* Forget what was recorded (a calibration run before the real pass). */
static void pds__debug_bufs_clear(pds__debug_buf *b, size_t npix)
{
    if (b->aniso) memset(b->aniso, 0, npix * 2 * sizeof *b->aniso);
    if (b->splats) memset(b->splats, 0, npix * sizeof *b->splats);
    if (b->landings) memset(b->landings, 0, npix * sizeof *b->landings);
    b->landed = b->landed_in_frame = 0;
    b->nell = 0;
}

static void pds__debug_bufs_free(pds__debug_buf *b)
{
    free(b->aniso);
    free(b->splats);
    free(b->landings);
    free(b->ell);
}

/* A count image from the threads' counts (an offset into each buffer's
   arrays picks the view). */
static pds_status pds__debug_count_view(pds_debug *d, pds_debug_view view, const pds__debug_buf *b, int nb, int w,
                                        int h, int landings)
{
    size_t i, n = (size_t)w * h;
    int t;
    if (pds_image_alloc(&d->value[view], w, h) != PDS_OK) return PDS_ERR_NOMEM;
    for (i = 0; i < n; i++) {
        uint64_t sum = 0;
        for (t = 0; t < nb; t++) sum += landings ? b[t].landings[i] : b[t].splats[i];
        d->value[view].rgb[3 * i] = d->value[view].rgb[3 * i + 1] = d->value[view].rgb[3 * i + 2] = (float)sum;
    }
    return pds__picture_counts(&d->value[view], &d->picture[view], &d->scale_max[view]);
}

/* After the photon pass: the views fed by the splats, from the threads'
   buffers b[0..nb); rgb (w x h x 3, the whole image) for the ellipses. */
static pds_status pds__debug_finish(pds_debug *d, pds__debug_buf *b, int nb, int w, int h, const double *rgb,
                                    const pds__camera_frame *f)
{
    size_t i, n = (size_t)w * h;
    int t;
    static const float yellow[3] = {1.0f, 1.0f, 0.0f}, white[3] = {1.0f, 1.0f, 1.0f};
    d->landings = d->landings_in_frame = 0;
    for (t = 0; t < nb; t++) {
        if (b[t].out_of_memory) return PDS_ERR_NOMEM;
        d->landings += b[t].landed;
        d->landings_in_frame += b[t].landed_in_frame;
    }
    if (b[0].aniso) {
        static const double tick[1] = {0.1}; /* appendix B: below 0.1 "highly anisotropic" */
        pds_image *val = &d->value[PDS_DEBUG_FOOTPRINT], *pic = &d->picture[PDS_DEBUG_FOOTPRINT];
        if (pds_image_alloc(val, w, h) != PDS_OK ||
            pds__picture_alloc(pic, w, h, pds__colour_aniso, 1.0, tick, 1) != PDS_OK)
            return PDS_ERR_NOMEM;
        d->scale_max[PDS_DEBUG_FOOTPRINT] = 1.0;
        for (i = 0; i < n; i++) {
            pds__sum128 swm = {0, 0}, sw = {0, 0};
            double wm, wk;
            for (t = 0; t < nb; t++) {
                pds__sum128_add_bits(&swm, b[t].aniso[2 * i].lo, b[t].aniso[2 * i].hi);
                pds__sum128_add_bits(&sw, b[t].aniso[2 * i + 1].lo, b[t].aniso[2 * i + 1].hi);
            }
            wm = pds__sum128_value(swm);
            wk = pds__sum128_value(sw);
            if (wk > 0.0) {
                val->rgb[3 * i] = (float)(1.0 - wm / wk);
                val->rgb[3 * i + 1] = (float)(wm / wk);
                val->rgb[3 * i + 2] = (float)(wk / PDS__TWO64);
                pds__colour_aniso(wm / wk, &pic->rgb[3 * i]);
            }
        }
    }
    if (b[0].landings && pds__debug_count_view(d, PDS_DEBUG_LANDINGS, b, nb, w, h, 1)) return PDS_ERR_NOMEM;
    if (b[0].splats && pds__debug_count_view(d, PDS_DEBUG_SPLATS, b, nb, w, h, 0)) return PDS_ERR_NOMEM;
    if (b[0].ellipse_every > 0) {
        pds_image *val = &d->value[PDS_DEBUG_ELLIPSES], *pic = &d->picture[PDS_DEBUG_ELLIPSES];
        pds__ellipse *all = NULL;
        size_t total = 0, k;
        char label[48];
        for (t = 0; t < nb; t++) total += b[t].nell;
        all = (pds__ellipse *)malloc(sizeof *all * (total ? total : 1));
        if (!all || pds_image_alloc(val, w, h) != PDS_OK ||
            pds_image_alloc(pic, w, h + PDS_DEBUG_LEGEND_ROWS) != PDS_OK) {
            free(all);
            return PDS_ERR_NOMEM;
        }
        for (t = 0, total = 0; t < nb; t++) {
            if (b[t].nell) memcpy(all + total, b[t].ell, sizeof *all * b[t].nell);
            total += b[t].nell;
        }
        qsort(all, total, sizeof *all, pds__ellipse_cmp);
        for (i = 0; i < n * 3; i++) pic->rgb[i] = (float)(rgb[i] > 0.0 ? (rgb[i] < 1.0 ? rgb[i] : 1.0) : 0.0);
        d->ellipses = 0;
        for (k = 0; k < total; k++) d->ellipses += pds__draw_ellipse(pic, h, val->rgb, f, &all[k], yellow);
        for (i = 0; i < n; i++) val->rgb[3 * i + 1] = val->rgb[3 * i + 2] = val->rgb[3 * i];
        d->scale_max[PDS_DEBUG_ELLIPSES] = (double)b[0].ellipse_every;
        /* legend: "1/N" (every N-th photon) and the number drawn */
        snprintf(label, sizeof label, "1/%ld", b[0].ellipse_every);
        pds__draw_text(pic, 0, h + 2, label, yellow);
        snprintf(label, sizeof label, "%ld", d->ellipses);
        pds__draw_text(pic, w - 4 * (int)strlen(label) + 1, h + 2, label, white);
        free(all);
    }
    return PDS_OK;
}

/* The eye-path view: every eye vertex the camera sees (pds__camera_sees),
   projected into the camera. */
static pds_status pds__debug_eye(pds_debug *d, const pds_scene *s, const pds__camera_frame *f,
                                 const pds__eye_vertex *v, size_t nv, int w, int h)
{
    pds_image *val = &d->value[PDS_DEBUG_EYE];
    size_t i;
    if (pds_image_alloc(val, w, h) != PDS_OK) return PDS_ERR_NOMEM;
    d->eye_vertices_in_frame = 0;
    for (i = 0; i < nv; i++) {
        long px = pds__camera_pixel_seen(s, f, pds__f3_get(v[i].pos));
        if (px < 0) continue;
        d->eye_vertices_in_frame++;
        val->rgb[3 * px] += 1.0f;
    }
    for (i = 0; i < (size_t)w * h; i++) val->rgb[3 * i + 1] = val->rgb[3 * i + 2] = val->rgb[3 * i];
    return pds__picture_counts(val, &d->picture[PDS_DEBUG_EYE], &d->scale_max[PDS_DEBUG_EYE]);
}

/* ===================================================================== */
/* >>pds                                                                 */
/* ===================================================================== */
/* Photon differential splatting (Frisvad, Schjoth, Erleben, Sporring,
   "Photon Differential Splatting for Rendering Caustics", CGF 2014).

   1. The eye pass (>>render) traces every pixel sample through specular
      surfaces and records its first non-specular vertex; the vertices go
      into a kd-tree, the eye-path map. The same pass computes every light
      path except the caustic ones (L S+ D ...).
   2. Caustic photons leave the lights aimed at the bounding sphere of the
      specular triangles, each carrying a photon differential (eqs. 2-6),
      and are traced through specular surfaces, the differential transferred
      (eqs. 7-9) and reflected or refracted with it (Igehy 1999).
   3. At the first non-specular surface after at least one specular bounce,
      the photon is splatted: its footprint (eq. 4) gives the irradiance
      Ep = flux / Ap, the filter matrix Mp (eq. 12) maps the footprint
      ellipse to the unit disc, and every eye vertex inside the ellipse
      (found by a range query of radius = the ellipse's true major
      semi-axis) gets pi K(|Mp (x - xp)|) fr Ep (eqs. 10, 11) times its
      importance, added to its pixel.

   No photon is stored: memory holds the eye-path map and one image per
   thread, whatever the photon count.

   Determinism: photon i is a pure function of (seed, i); photons go to
   threads in fixed batches, and each thread adds its splats into its own
   image of exact 128-bit sums (>>util), which do not depend on order, so
   the image is bit for bit the same for any thread count.

   Aiming: a photon whose first hit is not specular would be dropped, so
   photons are only sent where specular geometry is: towards the bounding
   sphere of the specular triangles, and the flux is weighted by the solid
   angle (or beam area) actually sampled. For eqs. 5-6 the emitting extent
   is the one sampled: the cone's solid angle for point, spot and area
   lights, the sphere's cross-section for directional lights. */

#define PDS__PHOTON_BATCH 1024

/* Progressive PDS splats a footprint over more eye samples than this
   (about a 32 x 32 pixel patch at 4 samples per pixel) by Russian roulette
   (pds__splat). */
#define PDS__SPLAT_ROULETTE 4096.0

/* Units per W/(m^2 sr) of the photon images' exact sums (>>util): a power
   of two near 2^64 / L, L the radiance of a diffuse white surface that
   spreads the lights' mean power per channel over the square of the
   scene's bounding-box diagonal, L = P / (pi D^2). A function of the scene
   alone, so every shard of a render and every thread count uses the same
   one. */
static double pds__sum_unit(const pds_scene *s)
{
    double power = 0.0, d2, radiance;
    pds__v3 e = pds__sub(s->bounds_max, s->bounds_min);
    size_t i;
    int exponent;
    for (i = 0; i < s->nlights; i++) power += pds__light_total_power(&s->lights[i], s->lights[i].area) / 3.0;
    d2 = pds__dot(e, e);
    radiance = power / (PDS__PI * (d2 > 0.0 ? d2 : 1.0));
    if (!(radiance > 0.0) || !isfinite(radiance)) radiance = 1.0;
    (void)frexp(radiance, &exponent); /* radiance in [2^(exponent-1), 2^exponent) */
    return ldexp(1.0, 64 - exponent);
}

/* Bounding sphere of the specular triangles (the photons' target). */
typedef struct pds__target {
    int any;
    pds__v3 centre;
    double radius;
} pds__target;

static pds__target pds__specular_target(const pds_scene *s)
{
    pds__target tg;
    pds__v3 lo = pds__v(0, 0, 0), hi = pds__v(0, 0, 0);
    size_t t;
    int k;
    memset(&tg, 0, sizeof tg);
    for (t = 0; t < s->mesh.ntris; t++) {
        if (!pds__material_is_specular(&s->materials.items[s->mesh.mat[t]])) continue;
        for (k = 0; k < 3; k++) {
            pds__v3 p = pds__mesh_pos(&s->mesh, s->mesh.idx[3 * t + k]);
            lo = tg.any ? pds__vmin(lo, p) : p;
            hi = tg.any ? pds__vmax(hi, p) : p;
            tg.any = 1;
        }
    }
    if (tg.any) {
        tg.centre = pds__scale(pds__add(lo, hi), 0.5);
        tg.radius = 0.5 * pds__length(pds__sub(hi, lo)) * 1.0001 + 1e-9;
    }
    return tg;
}

/* Uniform direction in the cone of half-angle acos(cos_max) about axis. */
static pds__v3 pds__cone_sample(pds__v3 axis, double cos_max, double u1, double u2)
{
    pds__v3 b1, b2;
    double ct = 1.0 - u1 * (1.0 - cos_max), st = sqrt(fmax(0.0, 1.0 - ct * ct)), phi = 2.0 * PDS__PI * u2;
    pds__onb(axis, &b1, &b2);
    return pds__normalize(pds__add(pds__scale(axis, ct),
                                   pds__add(pds__scale(b1, st * cos(phi)), pds__scale(b2, st * sin(phi)))));
}

/* The cone from x that holds the target sphere: axis and cos of the
   half-angle; 0 if x is inside the sphere (no aiming possible). */
static int pds__target_cone(const pds__target *tg, pds__v3 x, pds__v3 *axis, double *cos_max)
{
    pds__v3 d = pds__sub(tg->centre, x);
    double dist2 = pds__dot(d, d), r2 = tg->radius * tg->radius;
    if (dist2 <= r2 * 1.0001) return 0;
    *axis = pds__scale(d, 1.0 / sqrt(dist2));
    *cos_max = sqrt(1.0 - r2 / dist2);
    return 1;
}

/* A caustic photon as it leaves a light. */
typedef struct pds__photon_start {
    pds__v3 pos, dir, normal;  /* normal: emitter's, zero for point and spot lights */
    double flux[3];            /* as if it were the light's only photon (W) */
    double area, solid_angle;  /* emitting extent sampled (eqs. 5-6) */
} pds__photon_start;

/* Emit one photon from light k aimed at the specular target; u holds five
   uniforms. Returns 0 when the photon carries nothing (it still counts as
   emitted). */
static int pds__emit_caustic_photon(const pds_scene *s, const pds__target *tg, int k, const double u[5],
                                    pds__photon_start *ph)
{
    const pds_light *l = &s->lights[k];
    pds__light_emit e;
    pds__v3 axis;
    double cos_max, omega;
    int c;
    memset(ph, 0, sizeof *ph);
    if (l->type == PDS_LIGHT_DIRECTIONAL) {
        /* A disk across the beam, the target's shadow, sampled uniformly;
           traced back to the emitter, which must be there. */
        pds__v3 d = pds__normalize(l->direction), b1, b2;
        double r, t, disk_area = PDS__PI * tg->radius * tg->radius;
        if (l->area <= disk_area) {
            /* emitter smaller than the target's shadow: emit from all of it */
            if (!pds__light_emit_sample(&s->light_table, l, k, &s->mesh, u, &e)) return 0;
            ph->pos = e.pos;
            ph->dir = e.dir;
            memcpy(ph->flux, e.flux, sizeof ph->flux);
            ph->area = l->area;
        } else {
            pds__v3 q;
            pds__onb(d, &b1, &b2);
            r = tg->radius * sqrt(u[0]);
            q = pds__add(tg->centre, pds__add(pds__scale(b1, r * cos(2.0 * PDS__PI * u[1])),
                                              pds__scale(b2, r * sin(2.0 * PDS__PI * u[1]))));
            if (!pds__light_beam_hit(l, q, &t)) return 0;
            ph->pos = pds__sub(q, pds__scale(d, t));
            ph->dir = d;
            for (c = 0; c < 3; c++) ph->flux[c] = l->irradiance[c] * disk_area;
            ph->area = disk_area;
        }
        ph->normal = d;
        ph->solid_angle = 0.0;
        return ph->flux[0] + ph->flux[1] + ph->flux[2] > 0.0;
    }
    if (l->type == PDS_LIGHT_ENVIRONMENT) {
        /* As pbrt's infinite light (>>lights), but the disk across the
           sampled direction w is the target's shadow: radius r_t about
           the target's centre, pulled back along w out of the scene's
           bounding sphere. Flux L(w) pi r_t^2 / pdf(w); each photon is
           a thin parallel beam whose footprint is its share of the disk
           (Ae = pi r_t^2, omega_e = 0 in eqs. 5-6). */
        pds__v3 w, b1, b2, q;
        double pdf, dx, dy, L[3], disk_area, back;
        if (!tg->any || !(tg->radius < l->radius)) {
            if (!pds__light_emit_sample(&s->light_table, l, k, &s->mesh, u, &e)) return 0;
            ph->pos = e.pos;
            ph->dir = e.dir;
            ph->normal = e.normal;
            memcpy(ph->flux, e.flux, sizeof ph->flux);
            pds__light_emission_extent(l, &ph->area, &ph->solid_angle);
            return 1;
        }
        pdf = pds__env_sample(l, &s->light_table.env_p[3 * k], u[0], u[1], &w);
        if (!(pdf > 0.0)) return 0;
        pds__onb(w, &b1, &b2);
        pds__lights_concentric(u[2], u[3], &dx, &dy);
        q = pds__add(tg->centre, pds__add(pds__scale(b1, dx * tg->radius), pds__scale(b2, dy * tg->radius)));
        back = pds__length(pds__sub(tg->centre, l->position)) + l->radius;
        ph->pos = pds__add(q, pds__scale(w, back));
        ph->dir = pds__scale(w, -1.0);
        ph->normal = ph->dir;
        disk_area = PDS__PI * tg->radius * tg->radius;
        pds__env_radiance(l, w, L);
        for (c = 0; c < 3; c++) ph->flux[c] = L[c] * disk_area / pdf;
        ph->area = disk_area;
        ph->solid_angle = 0.0;
        return ph->flux[0] + ph->flux[1] + ph->flux[2] > 0.0;
    }
    if (l->type == PDS_LIGHT_POINT || l->type == PDS_LIGHT_SPOT) {
        if (!pds__target_cone(tg, l->position, &axis, &cos_max)) {
            if (!pds__light_emit_sample(&s->light_table, l, k, &s->mesh, u, &e)) return 0;
            ph->pos = e.pos;
            ph->dir = e.dir;
            memcpy(ph->flux, e.flux, sizeof ph->flux);
            pds__light_emission_extent(l, &ph->area, &ph->solid_angle);
            return 1;
        }
        omega = 2.0 * PDS__PI * (1.0 - cos_max);
        ph->pos = l->position;
        ph->dir = pds__cone_sample(axis, cos_max, u[0], u[1]);
        ph->solid_angle = omega;
        for (c = 0; c < 3; c++) {
            double intensity = l->power[c] / (4.0 * PDS__PI);
            if (l->type == PDS_LIGHT_SPOT) {
                double ci, co;
                pds__light_spot_cones(l, &ci, &co);
                intensity = pds__light_spot_i0(l, c, ci, co) *
                            pds__light_spot_falloff(pds__dot(ph->dir, pds__normalize(l->direction)), ci, co);
            }
            ph->flux[c] = intensity * omega; /* I / pdf, pdf = 1 / omega */
        }
        return ph->flux[0] + ph->flux[1] + ph->flux[2] > 0.0;
    }
    /* Area and mesh lights: a uniform point, then a direction in the cone
       towards the target; Le cos / (pdf_pos pdf_dir). */
    if (!pds__light_emit_sample(&s->light_table, l, k, &s->mesh, u, &e)) return 0;
    ph->pos = e.pos;
    ph->normal = e.normal;
    ph->area = pds__light_geom_area(l);
    if (l->type == PDS_LIGHT_MESH) ph->area = l->area;
    if (!pds__target_cone(tg, e.pos, &axis, &cos_max)) {
        ph->dir = e.dir;
        memcpy(ph->flux, e.flux, sizeof ph->flux);
        ph->solid_angle = 2.0 * PDS__PI;
        return 1;
    }
    omega = 2.0 * PDS__PI * (1.0 - cos_max);
    ph->dir = pds__cone_sample(axis, cos_max, u[2], u[3]);
    ph->solid_angle = omega;
    {
        double cosl = pds__dot(ph->dir, e.normal);
        if (!(cosl > 0.0)) return 0;
        for (c = 0; c < 3; c++) ph->flux[c] = l->radiance[c] * cosl * omega / e.pdf_pos;
    }
    return 1;
}

/* --- the eye-path map ---------------------------------------------------- */

/* The splats' eye vertices in two kd-trees: v[0, n_single) are single
   samples, v[n_single, n) merged vertices (pds__eye_merge), each part in
   its tree's order. A splat searches the single samples with the
   footprint itself and only the merged ones with the footprint grown by a
   pixel (pds__splat), so a scene whose merged vertices are few does not
   pay the wider query for all of them. */
typedef struct pds__eye_map {
    pds__eye_vertex *v;
    size_t n, n_single;
    pds__kdtree tree;          /* v[0, n_single) */
    pds__kdtree merged;        /* v[n_single, n), indices from n_single */
} pds__eye_map;

/* A merged vertex stands for a pixel: its half-axes are not zero. */
static int pds__eye_vertex_merged(const pds__eye_vertex *v)
{
    return v->px[0] != 0.0f || v->px[1] != 0.0f || v->px[2] != 0.0f;
}

/* Sort map->v[0, n) into its two parts, single samples first (in their
   order), and build each part's tree; each part is then put in its tree's
   order, so that a splat reads the vertices of one leaf from consecutive
   memory (half the splat time went to cache misses on vertices scattered
   in pixel order). */
static pds_status pds__eye_map_build(pds__eye_map *map, pds_error *err)
{
    size_t n = map->n, i, k, part;
    pds__eye_vertex *tmp = (pds__eye_vertex *)malloc(sizeof *tmp * (n ? n : 1));
    pds_status st;
    if (!tmp) return pds__nomem(err);
    for (i = k = 0; i < n; i++)
        if (!pds__eye_vertex_merged(&map->v[i])) tmp[k++] = map->v[i];
    map->n_single = k;
    for (i = 0; i < n; i++)
        if (pds__eye_vertex_merged(&map->v[i])) tmp[k++] = map->v[i];
    for (part = 0; part < 2; part++) {
        size_t first = part ? map->n_single : 0, count = part ? n - map->n_single : map->n_single;
        pds__kdtree *kd = part ? &map->merged : &map->tree;
        st = pds__kdtree_build(kd, count ? &tmp[first].pos[0] : NULL, sizeof *tmp / sizeof(float), count, err);
        if (st) {
            pds__kdtree_free(&map->tree);
            free(tmp);
            return st;
        }
        for (i = 0; i < count; i++) {
            map->v[first + i] = tmp[first + kd->perm[i]];
            kd->perm[i] = i;
        }
    }
    free(tmp);
    return PDS_OK;
}

/* --- splatting ------------------------------------------------------------ */

/* A photon where it landed, for the methods that store photons (>>baselines):
   position, travel direction, geometric normal of the surface (facing the
   photon), flux, its wavelength (spectral renders: the photon's lambda
   once it has met a dispersive material, its flux then that at lambda
   times W(lambda); 0 for an RGB photon, >>spectral) and its number (the
   store is sorted by it, so the map does not depend on which thread
   traced what). 64 bytes where long has 64 bits, 56 where it has 32. */
typedef struct pds__stored_photon {
    float pos[3], dir[3], ng[3], flux[3];
    float lambda;
    long index;
} pds__stored_photon;

/* A photon with its footprint, for photon differential mapping: Ep =
   flux / Ap, the eq. 12 filter matrix (rows M[0..2], M[3..5]), the
   footprint's major semi-axis, and lambda as for pds__stored_photon.
   88 bytes. */
typedef struct pds__diff_photon {
    float pos[3], dir[3], np[3], ep[3];
    float M[6];
    float major;
    float lambda;
    long index;
} pds__diff_photon;

/* One thread's share of the photon pass. */
typedef struct pds__splat_buf {
    pds__sum128 *sum;      /* 3 per pixel: radiance x unit, exact */
    pds__sum128 *neg;      /* spectral renders: 3 per pixel, the negative
                              terms' magnitudes (the film weight W(lambda)
                              has negative parts); NULL in RGB renders */
    double unit;           /* pds__sum_unit of the scene */
    long splatted, degenerate;
    long split;            /* photons (and sub-photons) split into four */
    long roulette;         /* splats skipped by the cost roulette */
    long saturated;        /* terms that saturated a pixel's sum */
    long invalid;          /* negative, infinite or NaN terms, dropped */
    pds__stored_photon *stored;   /* photon-map methods: landed photons */
    size_t nstored, cap_stored;
    pds__diff_photon *dstored;    /* pdm: landed photons with footprints */
    size_t ndstored, cap_dstored;
    struct pds__landing *pending; /* pds, splat: this batch's landings */
    size_t npending, cap_pending;
    pds__path_rec *path;   /* paths debug view, trace-photon; NULL if off */
    pds__debug_buf *dbg;   /* debug views fed by the splats; NULL if off */
    int out_of_memory;
} pds__splat_buf;

struct pds__photon_job;
/* What happens where a caustic photon lands: on a non-specular surface,
   after >= 1 specular bounce; r is transferred to the hit point. lambda:
   the photon's wavelength if it is spectral by now, else 0 (>>spectral). */
typedef void (*pds__land_fn)(const struct pds__photon_job *job, pds__splat_buf *buf, const pds__ray_diff *r,
                             pds__v3 ng, const double flux[3], double lambda, long photon);

/* Trace eye round `round` for the photon pass (pds__pds_passes): *v gets
   its vertices in place of the last ones (which it frees), *n their
   count; *v is left as it was when the round has no sample indices. */
typedef pds_status (*pds__retrace_fn)(void *ctx, long round, pds__eye_vertex **v, size_t *n, pds_error *err);

/* The eye rounds a photon pass may trace (pds__pds_passes): the function
   and its context, R (a photon budget's; a time budget's most, 0: no
   limit), the round the given vertices are of, and their eye pass's time. */
typedef struct pds__eye_rounds {
    pds__retrace_fn retrace;
    void *ctx;
    long rounds, round;
    double eye_s;
} pds__eye_rounds;

typedef struct pds__photon_job {
    const pds_scene *scene;
    const pds__eye_map *map;
    pds__target target;
    uint64_t seed;
    double smoothing, plane_tolerance, eps;
    double min_aspect;         /* pds, pdm: footprint widening (0 = off) */
    double min_width;          /* pds: widen to this many eye-sample spacings (0 = off) */
    pds__v3 eye;               /* camera position */
    pds__camera_frame frame;   /* the camera, for the debug views */
    int defocus_widen;         /* widen defocused needles (pds__defocus_widen) */
    double sample_angle;       /* angle between neighbouring eye samples (as a
                                  pinhole sees them: a thin lens moves each
                                  vertex by its circle of confusion but
                                  hardly changes how densely they cover a
                                  surface, so the same spacing serves) */
    int max_depth;
    int split_depth;           /* pds: most times a photon is split (0 = never) */
    double split_angle;        /* pds: split above this normal turn over the footprint (rad) */
    double roulette_vertices;  /* pds: a splat over more eye samples plays roulette (0 = never) */
    double n_planned;          /* photon count for eqs. 5-6 */
    long n_total;              /* photons to emit (upper bound in time mode) */
    double deadline;           /* pds_time_now() limit, 0 = none */
    pds__mutex lock;
    long next_batch, batches_done;   /* guarded by lock */
    int stop;                        /* guarded by lock */
    pds__splat_buf *bufs;
    int nbufs, next_buf;             /* guarded by lock */
    pds__thread_id caller;
    pds_progress_fn progress;
    void *progress_user;
    double t0;
    pds__land_fn land;         /* splat (pds, splat) or store (pm, ...) */
    int differentials;         /* trace photon differentials (pds) or not */
    int spectral;              /* one wavelength per photon (>>spectral) */
    int spectral_all;          /* ... spectral from the light on, not only
                                  from the first dispersive material */
    double fixed_radius;       /* splat: the isotropic footprint's radius */
    long index_offset;         /* ppm: the first photon number of this pass */
    long unit_first, unit_stride, unit_start; /* shards: the worker's b-th batch is
                                  batch unit_first + (unit_start + b) unit_stride
                                  of the render (0, 1, 0 for all of them) */
    long own_batches;          /* batches this call will run, for the progress */
    int cancelled;             /* guarded by lock: the progress callback said stop */
    double build_s, gather_s;  /* pm, pdm: time of the last map build and gather */
    double gather_deadline;    /* pm, pdm, spm: with a time budget, pds_time_now()
                                  by which the gather should end (>>baselines:
                                  pds__gather_run), else 0 */
    size_t gather_k;           /* pm, pdm, spm: the cap the last gather used */
    size_t probe_k2;           /* the map methods' probe (pds__map_probe_run), if
                                  > 0: pds__gather_run gathers three times on the
                                  one map, with the cap, with this cap, and with
                                  this cap within a bounded radius */
    double probe_s[3], probe_found[3]; /* ... the seconds and photons found of each */
    double gather_radius;      /* ... and the search radius a time budget bounded it by (0: none) */
    size_t nsums;              /* entries of each thread's exact image (3 a pixel) */
    double gather_found;       /* pm, pdm: photons its queries returned */
    size_t map_photons;        /* pm, pdm: photons in the last map built */
    /* progressive pds: eye rounds (pds__pds_passes), if retrace is set:
       eye_rounds R (a photon budget's; a time budget's most, 0: no
       limit), the round of the map in use, and how long its eye pass
       and map build took */
    pds__retrace_fn retrace;
    void *retrace_ctx;
    long eye_rounds, eye_round;
    double eye_round_s;
} pds__photon_job;

/* What a splat needs while it walks the eye vertices in range. */
typedef struct pds__splat_ctx {
    const pds__photon_job *job;
    pds__splat_buf *buf;
    pds__v3 xp, np, wi;        /* photon position, surface normal (facing the
                                  photon's arrival side), direction back to
                                  where it came from */
    double M[2][3];            /* eq. 12 */
    double ep[3];              /* Ep = flux / Ap, W / m^2 */
    double plane_max;          /* topological-bias guard distance */
    double aniso;              /* m_a of this footprint (debug views) */
    double lambda;             /* the photon's wavelength; 0 in RGB renders */
    size_t base;               /* the searched tree's first vertex in map->v */
    /* merged eye vertices (pds__eye_merge): the query searched the wider
       ellipse in M; M0 is the footprint's own */
    int spread;
    double M0[2][3];
} pds__splat_ctx;

/* Add radiance v (W/(m^2 sr)) into sum i of the thread's image (a
   negative v of a spectral render into the negative sums). */
static void pds__image_add(pds__splat_buf *b, size_t i, double v)
{
    int r = b->neg && v < 0.0 ? pds__sum128_add(&b->neg[i], -v * b->unit) : pds__sum128_add(&b->sum[i], v * b->unit);
    if (r == PDS__SUM_SATURATED) b->saturated++;
    if (r == PDS__SUM_INVALID) b->invalid++;
}

/* eq. 10 for one eye vertex x inside the footprint ellipse, r2 =
   |Mp (x - xp)|^2 < 1 (and near the photon's tangent plane: the query
   checked both): pi K(|Mp (x - xp)|) fr(x, wi, wo) Ep. */
/* Silverman's kernel (eq. 11, in the footprint's unit-disc coordinates)
   averaged over a pixel: the parallelogram u + a m1 + b m2, a, b in
   [-1, 1] (m1, m2: the pixel's half-axes in those coordinates; 0 for one
   point). A pixel small against the footprint (both half-axes under 1/8
   of its radius) takes one evaluation of the kernel convolved with the
   pixel matched in its first two moments: a box of half-axes m1, m2 has
   covariance C = (m1 m1^T + m2 m2^T) / 3, the kernel I / 8 (E[r^2] =
   2 / 8 for K = (3/pi)(1 - r^2)^2), so their sum is the kernel stretched
   by A = I + 8 C: K(u^T A^-1 u) / sqrt(det A), exact in the first two
   moments, and within 1% of the average for such pixels. A larger pixel
   (a footprint a few pixels across or a needle) takes the midpoint rule
   on n1 x n2 points, ni = ceil(8 |mi|), at most 4 x 4: the kernel's
   second derivative is bounded, so the rule's error falls as 1 / ni^2
   (tested against a fine quadrature). */
#define PDS__PIXEL_POINTS 4
static double pds__kernel_over_pixel(const double u[2], const double m1[2], const double m2[2])
{
    double l1 = sqrt(m1[0] * m1[0] + m1[1] * m1[1]), l2 = sqrt(m2[0] * m2[0] + m2[1] * m2[1]);
    double reach = 1.0 + l1 + l2, sum = 0.0;
    int n1, n2, i, j;
    if (!(u[0] * u[0] + u[1] * u[1] < reach * reach)) return 0.0;
    n1 = l1 * 8.0 < PDS__PIXEL_POINTS ? (int)ceil(l1 * 8.0) : PDS__PIXEL_POINTS;
    n2 = l2 * 8.0 < PDS__PIXEL_POINTS ? (int)ceil(l2 * 8.0) : PDS__PIXEL_POINTS;
    if (n1 <= 1 && n2 <= 1) {
        double a = 1.0 + 8.0 / 3.0 * (m1[0] * m1[0] + m2[0] * m2[0]);
        double b = 8.0 / 3.0 * (m1[0] * m1[1] + m2[0] * m2[1]);
        double c = 1.0 + 8.0 / 3.0 * (m1[1] * m1[1] + m2[1] * m2[1]), det = a * c - b * b;
        return pds__kernel_silverman((c * u[0] * u[0] - 2.0 * b * u[0] * u[1] + a * u[1] * u[1]) / det) / sqrt(det);
    }
    if (n1 < 1) n1 = 1;
    if (n2 < 1) n2 = 1;
    for (i = 0; i < n1; i++) {
        double a = (2.0 * i + 1.0) / n1 - 1.0;
        for (j = 0; j < n2; j++) {
            double b = (2.0 * j + 1.0) / n2 - 1.0;
            double x = u[0] + a * m1[0] + b * m2[0], y = u[1] + a * m1[1] + b * m2[1];
            sum += pds__kernel_silverman(x * x + y * y);
        }
    }
    return sum / (n1 * n2);
}

static void pds__splat_visit(void *vctx, size_t index, double r2)
{
    pds__splat_ctx *sc = (pds__splat_ctx *)vctx;
    const pds__eye_vertex *v = &sc->job->map->v[sc->base + index];
    double k, w[3], e[3];
    int c;
    /* topological bias: a surface seen from the other side (the back of a
       thin wall) */
    if (pds__dot(pds__f3_get(v->g), sc->np) <= 0.0) return;
    for (c = 0; c < 3; c++) e[c] = sc->ep[c];
    if (!pds__eye_response(sc->job->scene, v, sc->wi, sc->lambda, e, w)) return;
    if (sc->spread) {
        /* the query searched a wider ellipse: the footprint's own kernel,
           averaged over a merged vertex's pixel */
        pds__v3 d = pds__sub(pds__f3_get(v->pos), sc->xp), ex = pds__f3_get(v->px), ey = pds__f3_get(v->py);
        double u[2], m1[2], m2[2];
        int j;
        for (j = 0; j < 2; j++) {
            pds__v3 row = pds__v(sc->M0[j][0], sc->M0[j][1], sc->M0[j][2]);
            u[j] = pds__dot(row, d);
            m1[j] = pds__dot(row, ex);
            m2[j] = pds__dot(row, ey);
        }
        k = pds__kernel_over_pixel(u, m1, m2);
        if (!(k > 0.0)) return;
    } else {
        k = pds__kernel_silverman(r2);
    }
    for (c = 0; c < 3; c++) {
        double val = PDS__PI * k * w[c] * e[c];
        if (val != 0.0) pds__image_add(sc->buf, 3 * (size_t)v->pixel + (size_t)c, val);
    }
    if (sc->buf->dbg) pds__debug_visit(sc->buf->dbg, v->pixel, k, sc->aniso);
}

/* Merged eye vertices take the kernel averaged over their pixel
   (pds__splat_visit), so the query of the merged ones must find every
   vertex whose pixel meets the footprint: the footprint (semi-axes a >= b;
   hu, hv its semi-axis vectors) grown by rho, 1.5 times the half-diagonal
   of the pixel where the photon landed (the neighbours' distances and
   slants are about the same). That set, the points within rho of the
   ellipse, lies in both the footprint scaled by 1 + rho / b and the
   ellipse of semi-axes sqrt(2 a^2 + 2 rho^2), sqrt(2 b^2 + 2 rho^2) (the
   same axes; for a needle, a >> rho >> b, the latter is the smallest
   ellipse around the 2a x 2rho rectangle the set nearly is, pi/2 times
   the set's area); the query takes the smaller of the two, by the
   Cholesky factor of its matrix in a
   tangent basis t1, t2 (S: the footprint's). A footprint more than 8 rho
   across its minor axis needs none of this: the average over a pixel that
   small is the value at its centre within 1.5%. Sets sc->M to the grown
   query (the footprint's own kept in sc->M0), *major to its reach, and
   sc->spread. The guard against the topological bias (the slab around the
   tangent plane) keeps the footprint's own thickness: a merged vertex's
   samples lie on one flat patch, so the pixel widens it along the plane
   only. (Growing the slab with the query let a photon on the torus light
   the floor beneath it.) */
static void pds__splat_grow_for_pixels(const pds__photon_job *job, pds__splat_ctx *sc, pds__v3 hu, pds__v3 hv,
                                       double *major)
{
    pds__v3 t1, t2, ex, ey;
    double rho, au, av, bu, bv, s11, s12, s22, b2, g, q, l11, l21, l22;
    if (!pds__pixel_axes(&job->frame, sc->xp, sc->np, &ex, &ey)) return;
    rho = 1.5 * (pds__length(ex) + pds__length(ey));
    pds__onb(sc->np, &t1, &t2);
    au = pds__dot(hu, t1);
    av = pds__dot(hv, t1);
    bu = pds__dot(hu, t2);
    bv = pds__dot(hv, t2);
    s11 = au * au + av * av;
    s12 = au * bu + av * bv;
    s22 = bu * bu + bv * bv;
    b2 = 0.5 * (s11 + s22) - sqrt(0.25 * (s11 - s22) * (s11 - s22) + s12 * s12);
    if (b2 > 64.0 * rho * rho) return;
    g = b2 > 0.0 ? (1.0 + rho / sqrt(b2)) * (1.0 + rho / sqrt(b2)) : HUGE_VAL;
    q = 2.0 * rho * rho;
    /* det(g S) = g^2 det S against det(2 S + q I) */
    if (g * g * (s11 * s22 - s12 * s12) < (2.0 * s11 + q) * (2.0 * s22 + q) - 4.0 * s12 * s12) {
        s11 *= g;
        s12 *= g;
        s22 *= g;
    } else {
        s11 = 2.0 * s11 + q;
        s12 = 2.0 * s12;
        s22 = 2.0 * s22 + q;
    }
    l11 = sqrt(s11);
    l21 = s12 / l11;
    l22 = sqrt(fmax(s22 - l21 * l21, 0.0));
    memcpy(sc->M0, sc->M, sizeof sc->M);
    if (isfinite(l11) && isfinite(l21) && l22 > 0.0 && isfinite(l22) &&
        pds__filter_matrix(pds__add(pds__scale(t1, 2.0 * l11), pds__scale(t2, 2.0 * l21)), pds__scale(t2, 2.0 * l22),
                           sc->np, sc->M)) {
        sc->spread = 1;
        *major = pds__footprint_major_axis(pds__add(pds__scale(t1, 2.0 * l11), pds__scale(t2, 2.0 * l21)),
                                           pds__scale(t2, 2.0 * l22));
    }
}

/* Splat the photon r (already transferred to its hit on a non-specular
   surface with geometric normal ng) carrying flux. */
static void pds__splat(const pds__photon_job *job, pds__splat_buf *buf, const pds__ray_diff *r, pds__v3 ng,
                       const double flux[3], double lambda, long photon)
{
    pds__splat_ctx sc;
    pds__ray_diff wide; /* a widened footprint; r may point here */
    pds__v3 hu, hv;     /* the footprint's semi-axis vectors (Du/2, Dv/2) */
    double ap, major, spacing, keep = 1.0;
    int c;
    sc.lambda = lambda;
    sc.spread = 0;
    sc.np = pds__dot(ng, r->d) < 0.0 ? ng : pds__scale(ng, -1.0);
    if (job->fixed_radius > 0.0) {
        /* fixed-bandwidth splatting: a disc of radius R in the tangent
           plane, M = [t1; t2] / R */
        pds__v3 t1, t2;
        int k;
        pds__onb(sc.np, &t1, &t2);
        major = job->fixed_radius;
        ap = PDS__PI * major * major;
        for (k = 0; k < 3; k++) {
            sc.M[0][k] = pds__v3_get(t1, k) / major;
            sc.M[1][k] = pds__v3_get(t2, k) / major;
        }
        hu = pds__scale(t1, major);
        hv = pds__scale(t2, major);
    } else {
        /* the spacing of the eye samples where the photon landed, seen
           straight from the camera: distance times the angle between
           samples, stretched by the tilt (the geometric mean of the two
           directions' spacings) */
        pds__v3 to_eye = pds__sub(job->eye, r->p);
        double dist = pds__length(to_eye), tilt = dist > 0.0 ? fabs(pds__dot(to_eye, sc.np)) / dist : 1.0;
        spacing = dist * job->sample_angle / sqrt(fmax(tilt, 0.05));
        if (job->min_aspect > 0.0 || job->min_width > 0.0) {
            wide = *r;
            if (pds__footprint_widen_to(&wide.dpdu, &wide.dpdv, sc.np, job->min_aspect, job->min_width * spacing))
                r = &wide;
        }
        ap = pds__footprint_area(r->dpdu, r->dpdv);
        if (!(ap > 0.0) || !isfinite(ap) || !pds__filter_matrix(r->dpdu, r->dpdv, sc.np, sc.M)) {
            buf->degenerate++;
            return;
        }
        major = pds__footprint_major_axis(r->dpdu, r->dpdv);
        if (!(major > 0.0) || !isfinite(major)) {
            buf->degenerate++;
            return;
        }
        hu = pds__scale(r->dpdu, 0.5);
        hv = pds__scale(r->dpdv, 0.5);
        if (job->roulette_vertices > 0.0 && spacing > 0.0) {
            /* Russian roulette on the splat's cost: a footprint over more
               eye samples than roulette_vertices (from its area and their
               spacing) is splatted with probability p = roulette_vertices /
               samples and its irradiance divided by p. The expectation is
               unchanged, the cost bounded; the variance it adds, ~ Ep^2
               (1/p - 1), is that of a faint footprint (Ep = flux / Ap is
               small where Ap is large). The number comes from the photon's
               number and where it landed (sub-photons land apart). */
            double samples = ap / (spacing * spacing), u;
            if (samples > job->roulette_vertices) {
                uint64_t bits[3], h;
                memcpy(&bits[0], &r->p.x, sizeof bits[0]);
                memcpy(&bits[1], &r->p.y, sizeof bits[1]);
                memcpy(&bits[2], &r->p.z, sizeof bits[2]);
                h = pds__mix64(bits[0] ^ pds__mix64(bits[1] ^ pds__mix64(bits[2])));
                u = pds__rng_uniform(job->seed, PDS__RNG_SPLAT, (uint64_t)photon, h);
                keep = job->roulette_vertices / samples;
                if (u >= keep) {
                    buf->roulette++;
                    return;
                }
            }
        }
    }
    sc.job = job;
    sc.buf = buf;
    sc.xp = r->p;
    sc.wi = pds__scale(r->d, -1.0);
    for (c = 0; c < 3; c++) sc.ep[c] = flux[c] / (ap * keep);
    sc.plane_max = job->plane_tolerance * major;
    sc.aniso = !buf->dbg ? 0.0 : job->fixed_radius > 0.0 ? 1.0 : pds__footprint_anisotropy(r->dpdu, r->dpdv);
    buf->splatted++;
    if (buf->dbg) pds__debug_landing(buf->dbg, &job->frame, photon, r->p, r->dpdu, r->dpdv);
    /* the eye vertices within the major semi-axis that are inside the
       ellipse and near the tangent plane (topological bias): the single
       samples, then the merged vertices with the query grown by a pixel */
    sc.base = 0;
    pds__kdtree_range_ellipse(&job->map->tree, r->p, major, (const double(*)[3])sc.M, sc.np, sc.plane_max, pds__splat_visit, &sc);
    if (job->map->merged.n > 0) {
        sc.base = job->map->n_single;
        pds__splat_grow_for_pixels(job, &sc, hu, hv, &major);
        pds__kdtree_range_ellipse(&job->map->merged, r->p, major, (const double(*)[3])sc.M, sc.np, sc.plane_max,
                                  pds__splat_visit, &sc);
    }
}

/* Splatting in the order photons land jumps about the eye-path map; each
   batch's landings are kept and splatted in Morton order of their
   positions instead, so consecutive range queries walk nearby parts of the
   kd-tree and the eye vertices (which the photon pass stores in tree
   order). Refraction case, 256x256, 200k photons, one thread: 6.0 s of CPU
   before, 4.9 s with this order, 3.65 s with the vertices in tree order
   too. The images are exact sums (>>util), so the order changes nothing in
   them. */
typedef struct pds__landing {
    pds__ray_diff r;
    pds__v3 ng;
    double flux[3];
    double lambda;
    long photon;
    uint64_t key;   /* Morton code of r.p in the scene's bounds */
} pds__landing;

/* Spread the low 21 bits of v two bits apart (for a 63-bit Morton code). */
static uint64_t pds__morton_spread(uint64_t v)
{
    v &= 0x1fffffu;
    v = (v | v << 32) & 0x1f00000000ffffULL;
    v = (v | v << 16) & 0x1f0000ff0000ffULL;
    v = (v | v << 8) & 0x100f00f00f00f00fULL;
    v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
    v = (v | v << 2) & 0x1249249249249249ULL;
    return v;
}

static uint64_t pds__morton_key(const pds_scene *s, pds__v3 p)
{
    double q[3];
    uint64_t key = 0;
    int k;
    for (k = 0; k < 3; k++) {
        double lo = pds__v3_get(s->bounds_min, k), ext = pds__v3_get(s->bounds_max, k) - lo;
        double t = ext > 0.0 ? (pds__v3_get(p, k) - lo) / ext : 0.0;
        q[k] = t > 0.0 ? (t < 1.0 ? t * 2097151.0 : 2097151.0) : 0.0; /* NaN -> 0 */
        key |= pds__morton_spread((uint64_t)q[k]) << k;
    }
    return key;
}

static void pds__defer_splat(const pds__photon_job *job, pds__splat_buf *buf, const pds__ray_diff *r, pds__v3 ng,
                             const double flux[3], double lambda, long photon)
{
    pds__landing *l;
    if (pds__grow((void **)&buf->pending, &buf->cap_pending, buf->npending + 1, sizeof *buf->pending)) {
        pds__splat(job, buf, r, ng, flux, lambda, photon); /* no room to defer: splat now */
        return;
    }
    l = &buf->pending[buf->npending++];
    l->r = *r;
    l->ng = ng;
    memcpy(l->flux, flux, sizeof l->flux);
    l->lambda = lambda;
    l->photon = photon;
    l->key = pds__morton_key(job->scene, r->p);
}

static int pds__landing_cmp(const void *a, const void *b)
{
    const pds__landing *x = (const pds__landing *)a, *y = (const pds__landing *)b;
    if (x->key != y->key) return x->key < y->key ? -1 : 1;
    return (x->photon > y->photon) - (x->photon < y->photon);
}

static void pds__splat_pending(const pds__photon_job *job, pds__splat_buf *buf)
{
    size_t i;
    qsort(buf->pending, buf->npending, sizeof *buf->pending, pds__landing_cmp);
    for (i = 0; i < buf->npending; i++) {
        const pds__landing *l = &buf->pending[i];
        pds__splat(job, buf, &l->r, l->ng, l->flux, l->lambda, l->photon);
    }
    buf->npending = 0;
}

/* --- adaptive splitting ----------------------------------------------------
   Eqs. 7-9 carry the footprint to first order: across the footprint the
   surface normal is taken to turn linearly, n(p + a DP) ~ n + a DN for
   |a| <= 1/2 (the footprint's conjugate semi-diameters are DP / 2, eq. 4).
   Where the normal turns by a large angle over the footprint that is no
   longer true (a strongly curved or coarsely tessellated surface, or a
   scanned mesh whose interpolated normals turn by a tenth of a radian per
   triangle: there DN is the curvature of one triangle, not of the
   surface), and the footprint can grow without bound. The paper's remedy
   (sect. 5) is adaptive splitting: such a photon is split into sub-photons
   that are re-traced from the light with their own, smaller differentials,
   adaptive quadrature over the emission domain. Here the photon's share of
   that domain is the parallelogram its two differentials span about its
   start (its footprint's conjugate diameters, eq. 4); the four sub-photons
   start at its quarters' centres, x + a DuX + b DvX and omega + a Du omega
   + b Dv omega (a, b = +-1/4), with half the differentials and a quarter
   of the flux each, and follow their own paths (the same random numbers
   choose reflection or refraction, so each is an unbiased photon). The
   four together carry the parent's flux exactly and, where the optics is
   linear, cover the same footprint. A photon splits when at a specular
   event the normal's predicted turn over its footprint,
   tau = max(|DN_u|, |DN_v|) / 2, exceeds split_angle, or the spread of its
   direction afterwards, max(|DD_u|, |DD_v|) / 2, exceeds twice that; at
   most split_depth times (4^split_depth sub-photons). The default 0.2 rad
   keeps the neglected second-order term, ~ tau^2 / 2 of the turn, near 2%.
   At the last level a sub-photon that is still not linear keeps a normal
   turn of split_angle and a direction spread of twice it (its DN and DD
   scaled down to those bounds): at that scale the photons' positions, not
   their differentials, carry the focusing, as in photon mapping. Measured
   on the glass Stanford bunny (69,666 triangles, 20,000 photons, against a
   24M-photon ppm reference): RMSE 0.101 unsplit, 0.090 split once (the
   default), 0.083 split twice at 4x the photon pass's time (pm: 0.117); on
   the shipped water surface the defaults split nothing, while 0.1 rad
   splits its focal regions at 20,000 photons and costs RMSE there
   (0.082 -> 0.102). */

/* Sub-photon (a, b) of r: start moved by a, b times the differentials,
   differentials halved (the directional ones kept perpendicular to the
   new direction). */
static pds__ray_diff pds__sub_photon(const pds__ray_diff *r, double a, double b)
{
    pds__ray_diff q;
    q.p = pds__add(r->p, pds__add(pds__scale(r->dpdu, a), pds__scale(r->dpdv, b)));
    q.d = pds__normalize(pds__add(r->d, pds__add(pds__scale(r->dddu, a), pds__scale(r->dddv, b))));
    q.dpdu = pds__scale(r->dpdu, 0.5);
    q.dpdv = pds__scale(r->dpdv, 0.5);
    q.dddu = pds__scale(r->dddu, 0.5);
    q.dddv = pds__scale(r->dddv, 0.5);
    q.dddu = pds__sub(q.dddu, pds__scale(q.d, pds__dot(q.dddu, q.d)));
    q.dddv = pds__sub(q.dddv, pds__scale(q.d, pds__dot(q.dddv, q.d)));
    return q;
}

/* Half the larger of two differentials' lengths: the spread over the
   footprint's semi-diameters. */
static double pds__half_spread(pds__v3 a, pds__v3 b)
{
    return 0.5 * fmax(pds__length(a), pds__length(b));
}

static void pds__trace_from(const pds__photon_job *job, pds__splat_buf *buf, const pds__ray_diff *start,
                            const double flux0[3], long i, int level);

/* Defocused needles (progressive PDS; an extension). A convex mirror or
   the rim of a glass ball spreads a thin tube of light over a long, faint
   streak: its footprint is a needle, correct to first order, but a pass
   holds few such photons and the faint tail becomes radial streaks. The
   tube's cross-section A (|Du x Dv . d|) against the one it would have had
   without any specular surface, A0 = |Du0 x Dv0| + |Dd0u x Dd0v| L^2 (L
   the path's length), says how far the light was spread: m = A / A0 > 1
   defocused, < 1 focused. A defocused footprint's minor axis is widened
   to at least min_aspect m times its major one (round from m = 1 /
   min_aspect on): faint light is smooth on the scale of its footprints,
   while a focused needle (a caustic's focal line, m < 1) keeps the shape
   that draws the line. */
static void pds__defocus_widen(const pds__photon_job *job, const pds__ray_diff *start, double travel, pds__v3 ng,
                               pds__ray_diff *r)
{
    double a0 = pds__length(pds__cross(start->dpdu, start->dpdv)) +
                pds__length(pds__cross(start->dddu, start->dddv)) * travel * travel;
    double a = fabs(pds__dot(pds__cross(r->dpdu, r->dpdv), r->d)), m, aspect;
    pds__v3 np = pds__dot(ng, r->d) < 0.0 ? ng : pds__scale(ng, -1.0);
    if (!(a0 > 0.0) || !(a > a0)) return;
    m = a / a0;
    aspect = job->min_aspect * m < 1.0 ? job->min_aspect * m : 1.0;
    (void)pds__footprint_widen_to(&r->dpdu, &r->dpdv, np, aspect, 0.0);
}

/* Split the photon that left the light as (start, flux0) into four. */
static void pds__split_photon(const pds__photon_job *job, pds__splat_buf *buf, const pds__ray_diff *start,
                              const double flux0[3], long i, int level)
{
    static const double at[4][2] = {{-0.25, -0.25}, {0.25, -0.25}, {-0.25, 0.25}, {0.25, 0.25}};
    double flux[3];
    int k, c;
    for (c = 0; c < 3; c++) flux[c] = 0.25 * flux0[c];
    buf->split++;
    for (k = 0; k < 4; k++) {
        pds__ray_diff q = pds__sub_photon(start, at[k][0], at[k][1]);
        pds__trace_from(job, buf, &q, flux, i, level + 1);
    }
}

/* Trace photon i (or its sub-photon at split level `level`) from where it
   left the light: specular bounces with the differential, splat at the
   first non-specular surface after >= 1 specular bounce. */
static void pds__trace_from(const pds__photon_job *job, pds__splat_buf *buf, const pds__ray_diff *start,
                            const double flux0[3], long i, int level)
{
    const pds_scene *s = job->scene;
    const double *sigma = NULL;
    double sigma_buf[3];
    double flux[3];
    pds__ray_diff r = *start;
    pds_material m_lambda;
    /* lambda: the photon's wavelength (spectral renders; its sub-photons
       share it); lam: the same once the photon is spectral, 0 before
       (>>spectral) */
    double lambda = job->spectral ? pds__photon_wavelength(job->seed, i) : 0.0, lam = 0.0;
    int c, depth, can_split = job->differentials && level < job->split_depth;
    /* the path recorder (>>debug) follows the photon, not its sub-photons:
       a split photon's recorded path ends where it split */
    pds__path_rec *rec = level == 0 && buf->path && i < buf->path->photon_end ? buf->path : NULL;
    double travel = 0.0; /* the path's length so far */
    for (c = 0; c < 3; c++) flux[c] = flux0[c];
    for (depth = 0; depth <= job->max_depth; depth++) {
        pds__tri_hit th;
        pds_hit hit;
        const pds_material *m;
        pds__bsdf_result bs;
        pds__v3 n, ngw, dndu, dndv;
        double uu[3];
        int side;
        if (!pds__bvh_intersect(&s->bvh, r.p, r.d, 0.0, DBL_MAX, &th)) return;
        pds__scene_fill_hit(s, &th, r.p, r.d, &hit);
        if (job->differentials && !pds__diff_transfer(&r, th.t, hit.ng)) return;
        r.p = hit.position;
        travel += th.t;
        pds__beer(sigma, th.t, flux);
        m = &s->materials.items[hit.material];
        if (!pds__material_is_specular(m)) {
            if (depth > 0 && m->type != PDS_MAT_EMISSIVE) {
                if (job->defocus_widen) pds__defocus_widen(job, start, travel, hit.ng, &r);
                if (rec) pds__path_note(rec, i, depth + 1, PDS_TRACE_LAND, hit.material, th.tri, &r, flux);
                job->land(job, buf, &r, hit.ng, flux, lam, i);
            }
            return;
        }
        if (lambda > 0.0 && lam == 0.0 && (job->spectral_all || pds__material_is_dispersive(m))) {
            pds__photon_turn_spectral(lambda, flux, sigma ? sigma_buf : NULL);
            lam = lambda;
        }
        if (lam > 0.0) {
            pds__spectral_material(m, lam, &m_lambda);
            m = &m_lambda;
        }
        if (depth == job->max_depth) return;
        for (c = 0; c < 3; c++)
            uu[c] = pds__rng_uniform(job->seed, PDS__RNG_PHOTON, (uint64_t)i, 8 + 4 * (uint64_t)depth + (uint64_t)c);
        if (!pds__bsdf_sample(m, hit.position, pds__scale(r.d, -1.0), hit.ns, hit.ng, uu, PDS__IMPORTANCE, &bs)) return;
        pds__spectral_uplift(lam, bs.weight);
        if (!pds__bsdf_frame(pds__scale(r.d, -1.0), hit.ns, hit.ng, &n, &ngw, &side)) return;
        if (!job->differentials) {
            /* the baselines trace bare photons */
            for (c = 0; c < 3; c++) flux[c] *= bs.weight[c];
            if (m->type == PDS_MAT_DIELECTRIC) {
                const double *a = pds__medium_absorption(m, bs.side);
                if (a) memcpy(sigma_buf, a, sizeof sigma_buf);
                sigma = a ? sigma_buf : NULL;
            }
            r.d = bs.wi;
            if (rec)
                pds__path_note(rec, i, depth + 1, bs.transmitted ? PDS_TRACE_REFRACT : PDS_TRACE_REFLECT,
                               hit.material, th.tri, &r, flux);
            r.p = pds__add(hit.position, pds__scale(hit.ng, pds__dot(hit.ng, r.d) >= 0.0 ? job->eps : -job->eps));
            continue;
        }
        /* the normal's differentials, oriented like the normal the BSDF
           used; where it fell back to the geometric normal, that one is
           flat (no differential) */
        {
            pds__v3 nsu = pds__normalize(hit.ns);
            double agree = pds__dot(n, nsu);
            /* each derivative at the footprint's half-width along its
               own direction: a needle keeps the triangle's derivative
               across itself */
            pds__mesh_normal_diff(&s->mesh, th.tri, th.u, th.v, r.dpdu, 0.5 * pds__length(r.dpdu), &dndu);
            pds__mesh_normal_diff(&s->mesh, th.tri, th.u, th.v, r.dpdv, 0.5 * pds__length(r.dpdv), &dndv);
            if (agree < -0.999999) {
                dndu = pds__scale(dndu, -1.0);
                dndv = pds__scale(dndv, -1.0);
            } else if (agree <= 0.999999) {
                dndu = dndv = pds__v(0.0, 0.0, 0.0);
            }
        }
        if (job->split_angle > 0.0 && pds__half_spread(dndu, dndv) > job->split_angle) {
            double keep;
            if (can_split) {
                pds__split_photon(job, buf, start, flux0, i, level);
                return;
            }
            /* the last level: the normal's turn is held at split_angle */
            keep = job->split_angle / pds__half_spread(dndu, dndv);
            dndu = pds__scale(dndu, keep);
            dndv = pds__scale(dndv, keep);
        }
        if (bs.transmitted) {
            double eta_i = side > 0 ? m->outside_ior : m->ior, eta_t = side > 0 ? m->ior : m->outside_ior;
            if (!pds__diff_refract(&r, n, dndu, dndv, eta_i / eta_t)) return;
        } else {
            pds__diff_reflect(&r, n, dndu, dndv);
        }
        if (job->split_angle > 0.0 && pds__half_spread(r.dddu, r.dddv) > 2.0 * job->split_angle) {
            double keep;
            if (can_split) {
                pds__split_photon(job, buf, start, flux0, i, level);
                return;
            }
            /* the last level: the spread is limited to what is still linear */
            keep = 2.0 * job->split_angle / pds__half_spread(r.dddu, r.dddv);
            r.dddu = pds__scale(r.dddu, keep);
            r.dddv = pds__scale(r.dddv, keep);
        }
        for (c = 0; c < 3; c++) flux[c] *= bs.weight[c];
        if (m->type == PDS_MAT_DIELECTRIC) {
            const double *a = pds__medium_absorption(m, bs.side);
            if (a) memcpy(sigma_buf, a, sizeof sigma_buf);
            sigma = a ? sigma_buf : NULL;
        }
        if (rec)
            pds__path_note(rec, i, depth + 1, bs.transmitted ? PDS_TRACE_REFRACT : PDS_TRACE_REFLECT, hit.material,
                           th.tri, &r, flux);
        r.p = pds__add(hit.position, pds__scale(hit.ng, pds__dot(hit.ng, r.d) >= 0.0 ? job->eps : -job->eps));
    }
}

/* Emit photon number i with its differential (eqs. 2-6) into *r and *flux;
   0 if it carries nothing (it still counts as emitted). */
static int pds__emit_photon(const pds__photon_job *job, long i, pds__ray_diff *r, double flux[3])
{
    const pds_scene *s = job->scene;
    double u[5], pmf, pos_len, dir_len, n_light;
    pds__photon_start ph;
    int k, c;
    /* emission from a low-discrepancy sequence (>>rng): photon i's place in
       the light's area and directions is spread evenly with the others' */
    for (c = 0; c < 5; c++) u[c] = pds__halton(job->seed, (uint64_t)i, c);
    k = pds__lights_pick(&s->light_table, pds__halton(job->seed, (uint64_t)i, 5), &pmf);
    if (k < 0 || !(pmf > 0.0)) return 0;
    if (!pds__emit_caustic_photon(s, &job->target, k, u, &ph)) return 0;
    n_light = job->n_planned * pmf;
    for (c = 0; c < 3; c++) flux[c] = ph.flux[c] / (job->n_planned * pmf);
    pos_len = pds__photon_diff_length(job->smoothing, ph.area, n_light);
    dir_len = pds__photon_diff_length(job->smoothing, ph.solid_angle, n_light);
    pds__photon_diff_init(r, ph.pos, ph.dir, ph.normal, pos_len, dir_len);
    return 1;
}

/* Trace photon number i: emission (eqs. 2-6), then pds__trace_from. */
static void pds__trace_photon(const pds__photon_job *job, pds__splat_buf *buf, long i)
{
    pds__ray_diff r;
    double flux[3];
    if (!pds__emit_photon(job, i, &r, flux)) return;
    if (buf->path && i < buf->path->photon_end) pds__path_note(buf->path, i, 0, PDS_TRACE_EMIT, -1, -1, &r, flux);
    pds__trace_from(job, buf, &r, flux, i, 0);
}

static void *pds__photon_worker(void *arg)
{
    pds__photon_job *job = (pds__photon_job *)arg;
    int is_caller = pds__thread_equal(pds__thread_self(), job->caller);
    pds__splat_buf *buf;
    pds__mutex_lock(&job->lock);
    buf = &job->bufs[job->next_buf++];
    pds__mutex_unlock(&job->lock);
    for (;;) {
        long b, i, first, last, done;
        pds__mutex_lock(&job->lock);
        if (job->deadline > 0.0 && pds_time_now() >= job->deadline) job->stop = 1;
        b = job->stop ? -1 : job->next_batch++;
        if (b >= 0) b = job->unit_first + (job->unit_start + b) * job->unit_stride;
        if (b >= 0 && b * (long)PDS__PHOTON_BATCH >= job->n_total) b = -1;
        pds__mutex_unlock(&job->lock);
        if (b < 0) break;
        first = b * (long)PDS__PHOTON_BATCH;
        last = first + PDS__PHOTON_BATCH < job->n_total ? first + PDS__PHOTON_BATCH : job->n_total;
        for (i = first; i < last; i++) pds__trace_photon(job, buf, job->index_offset + i);
        if (buf->npending) pds__splat_pending(job, buf);
        pds__mutex_lock(&job->lock);
        done = ++job->batches_done;
        pds__mutex_unlock(&job->lock);
        if (is_caller && job->progress) {
            double frac = job->deadline > 0.0 ? (pds_time_now() - job->t0) / (job->deadline - job->t0)
                          : job->own_batches > 0 ? (double)done / (double)job->own_batches
                                                 : (double)done * PDS__PHOTON_BATCH / (double)job->n_total;
            if (job->progress(job->progress_user, PDS_PHASE_PHOTONS, frac > 1.0 ? 1.0 : frac, pds_time_now() - job->t0)) {
                /* stop: the batches handed out are finished, so the done
                   batches stay the first ones of the list */
                pds__mutex_lock(&job->lock);
                job->stop = job->cancelled = 1;
                pds__mutex_unlock(&job->lock);
            }
        }
    }
    return NULL;
}


/* --- progressive PDS ------------------------------------------------------
   The paper's PDS splats N photons whose footprints have radius
   r ~ s sqrt(A / (pi N)) (eqs. 5-6): with s fixed, about s^2 footprints
   cover each point whatever N is, so the noise does not fall as photons are
   added while the bias does. A kernel estimate converges when r -> 0 while
   the number of kernels over a point, ~ N r^2, grows without bound.
   Progressive PDS gets there as Knaus and Zwicker (2011, "Progressive
   photon mapping: a probabilistic approach", sect. 4) showed for photon
   mapping: K passes of M photons, each an independent PDS estimate with
   N = M, pass i (from 1) with smoothing s_i = s_1 i^((alpha - 1) / 2), so
   that its footprints' areas shrink as i^(alpha - 1); the image is the
   mean of the pass images. The variance of pass i is ~ 1 / (M r_i^2) ~
   i^(1 - alpha), so the mean's is ~ K^(-alpha); the bias is the mean of
   the passes' biases, ~ K^(alpha - 1) where the caustic is smooth (bias
   ~ r^2) and ~ K^((alpha - 1) / 2) at its edges (bias ~ r). alpha = 2/3
   balances them for a smooth caustic (MSE ~ K^(-2/3), RMSE ~ N^(-1/3)),
   alpha = 1/2 at edges (RMSE ~ N^(-1/4)). Every pass costs the same, so
   a time budget just runs passes until the time is spent, and the photon
   count never has to be planned before the first photon. Needle widening
   (min_aspect) widens each footprint to a fixed fraction of its major
   axis, which shrinks with the passes too, so it stays consistent. */

/* Trace photons index_offset .. index_offset + job->n_total - 1 on the
   threads (one pass of progressive PDS or of ppm). */
static void pds__photon_run(pds__photon_job *job, int threads, long index_offset)
{
    job->index_offset = index_offset;
    job->next_batch = job->batches_done = 0;
    job->stop = 0;
    job->next_buf = 0;
    pds__mutex_init(&job->lock);
    pds__run_threads(threads, pds__photon_worker, job);
    pds__mutex_destroy(&job->lock);
}

/* s_i of pass i (from 1). */
static double pds__pass_smoothing(double s1, double alpha, long pass)
{
    return s1 * pow((double)pass, 0.5 * (alpha - 1.0));
}

/* The pass plan of progressive PDS for N photons: K = ceil(N / pass_photons)
   passes of M = ceil(N / K) photons (photon numbers pass * M + j). */
static void pds__pds_pass_plan(const pds_options *opt, long *k_total, long *m)
{
    *k_total = (opt->photons + opt->pass_photons - 1) / opt->pass_photons;
    if (*k_total < 1) *k_total = 1;
    *m = (opt->photons + *k_total - 1) / *k_total;
    if (*m < 1) *m = 1;
}

/* Eye rounds (an extension; stochastic progressive photon mapping,
   Hachisuka and Jensen 2009, re-traces its eye pass for every photon
   pass). Where the camera sees the caustic through glass, most of the
   image's error is its eye samples' (which floor points, which Fresnel
   branch they reach), and photons added under one eye pass cannot reduce
   it. Every pass of progressive PDS is an independent estimate whatever
   eye samples it splats into (a vertex's importance carries 1/spp of its
   own eye pass), so the passes' mean stays the image when the passes
   splat into different eye passes, and the eye samples then add up as
   the photons do. Merged vertices (pds__eye_merge) keep a round's splats
   about as costly as one eye pass's, so the price of a round is its eye
   pass and map build, t_eye.
     A photon budget with R rounds (pds_options.eye_rounds) splits its K
   passes into R runs of consecutive passes, round r = floor(k R / K) for
   pass k, so the rounds a pass meets depend on its number alone (the
   same image for any split into shards). A time budget traces a new eye
   pass once the passes since the last one took PDS__EYE_ROUND_RATIO
   t_eye, about half of the time going to eye samples. (At 3 s on the
   shipped scenes, against ratios 2, 3 and 8, 1 had the lowest RMSE on
   the glass bunny, the cognac glass and the refraction case, and lost 3%
   on the reflection case.) */
#define PDS__EYE_ROUND_RATIO 1.0

/* The round pass k of k_total splats into, with `rounds` rounds. */
static long pds__eye_round_of(long k, long k_total, long rounds)
{
    if (rounds <= 1 || k_total <= 0) return 0;
    return (long)((long long)k * rounds / k_total);
}

/* Under a time budget: is an eye round due before the next pass? The
   passes since the last eye pass took t_photons, that eye pass (with its
   map) t_eye, the last pass t_pass; a round is traced only if a pass can
   still follow it (the passes' landing rule, pds__pds_passes). */
static int pds__eye_round_due(double t_photons, double t_eye, double t_pass, double now, double deadline)
{
    return t_photons >= PDS__EYE_ROUND_RATIO * t_eye && now + t_eye + 0.5 * t_pass <= deadline;
}

/* Run progressive PDS passes into the job's sums: the passes first,
   first + stride, ... of the plan above, from the start-th of those on
   (a shard, or the rest of an interrupted render), or with a deadline,
   whole passes while the end of one more, at the last pass's duration,
   is nearer the deadline than now is (so the pass lands within half a
   pass of it, early or late, rather than up to a whole pass early); with
   eye rounds between them if job->retrace is set (map: the eye-path map
   they rebuild). The progress callback may stop it between passes.
   Returns the photons emitted; *passes gets the passes run. */
static long pds__pds_passes(pds__photon_job *job, pds__eye_map *map, const pds_options *opt, int threads,
                            double deadline, long first, long stride, long start, long *passes, pds_status *st,
                            pds_error *err)
{
    long k_max, m, k, run = 0;
    double t_pass = 0.0, t_photons = 0.0; /* t_photons: the passes' time since the last eye pass */
    if (deadline > 0.0) {
        m = opt->pass_photons;
        k_max = LONG_MAX / m - 1;
    } else {
        pds__pds_pass_plan(opt, &k_max, &m);
    }
    job->n_total = m;
    job->n_planned = (double)m;
    for (k = first + start * stride; k < k_max; k += stride) {
        double t = pds_time_now();
        long r = -1; /* a new eye round before this pass */
        if (deadline > 0.0 && k > 0 && t + 0.5 * t_pass > deadline) break;
        if (job->retrace && deadline <= 0.0) {
            r = pds__eye_round_of(k, k_max, job->eye_rounds);
            if (r == job->eye_round) r = -1;
        } else if (job->retrace && run > 0 && (job->eye_rounds <= 0 || job->eye_round + 1 < job->eye_rounds) &&
                   pds__eye_round_due(t_photons, job->eye_round_s, t_pass, t, deadline)) {
            r = job->eye_round + 1;
        }
        if (r >= 0) {
            pds__eye_vertex *v = map->v;
            size_t n = map->n;
            if ((*st = job->retrace(job->retrace_ctx, r, &v, &n, err))) break;
            if (v == map->v) {
                job->retrace = NULL; /* no sample indices left for another */
            } else {
                pds__kdtree_free(&map->tree);
                pds__kdtree_free(&map->merged);
                memset(map, 0, sizeof *map);
                map->v = v;
                map->n = n;
                if ((*st = pds__eye_map_build(map, err))) break;
                job->eye_round = r;
                job->eye_round_s = pds_time_now() - t;
                t_photons = 0.0;
                t = pds_time_now();
            }
        }
        job->smoothing = pds__pass_smoothing(opt->pass_smoothing, opt->pass_alpha, k + 1);
        /* the width floor shrinks as the footprints do (s_i / s_1) */
        job->min_width = opt->pass_min_width * pds__pass_smoothing(1.0, opt->pass_alpha, k + 1);
        pds__photon_run(job, threads, k * m);
        t_pass = pds_time_now() - t;
        t_photons += t_pass;
        run++;
        if (opt->progress) {
            double frac = deadline > 0.0 ? (pds_time_now() - job->t0) / (deadline - job->t0)
                                         : (double)(start + run) / (double)((k_max - first + stride - 1) / stride);
            if (opt->progress(opt->progress_user, PDS_PHASE_PHOTONS, frac > 1.0 ? 1.0 : frac, pds_time_now() - job->t0) &&
                deadline <= 0.0) {
                job->cancelled = 1;
                break;
            }
        }
    }
    *passes = run;
    return run * m;
}

#ifndef PDS_NO_BASELINES
/* ===================================================================== */
/* >>baselines                                                           */
/* ===================================================================== */
/* The methods PDS is measured against, on the same eye pass, the same
   aimed caustic photons and the same exact images:

   splat  fixed-bandwidth photon splatting into the eye-path map
          (Lavignotte & Paulin 2003 splat with one bandwidth; Herzog et al.
          2007 splat into a map of eye vertices): the PDS splat with the
          footprint replaced by a disc of radius R in the tangent plane.
   pm     standard photon mapping of the caustic map (Jensen 1996): the
          landed photons are stored, sorted by photon number (so the map is
          the same for any thread count), put in a kd-tree, and each eye
          vertex gathers its k nearest photons within the maximum radius:
          L = sum fr Phi_p w_p / (c pi r^2), r the k-th distance, with the
          cone filter w = 1 - d / r (c = 1 - 2/3 for k_cone = 1), Jensen's
          Gaussian w = a [1 - (1 - e^(-b d^2 / (2 r^2))) / (1 - e^(-b))]
          (a = 0.918, b = 1.953; c = its exact integral over the disc, 0.531)
          or none (w = 1, c = 1). As in Jensen's code, fewer than
          min(8, k) photons give no estimate, and only photons that arrived
          on the vertex's side of a surface facing the same way count.
   pdm    photon differential mapping (Schjoth et al. 2007): photons are
          traced with differentials like PDS's and stored with their
          footprints; each eye vertex gathers every photon whose footprint
          covers it (eqs. 10-12), searching the largest footprint radius of
          all photons and keeping at most max_photons nearest (the cap the
          PDS paper used to make it competitive). Same image as PDS in the
          limit; slower, and its memory grows with the photon count.
   ppm    progressive photon mapping (Hachisuka, Ogaki, Jensen 2008): each
          eye vertex keeps a radius R, a photon count N and a flux tau; after
          each pass of photons, with M photons found within R carrying
          Phi_M = sum fr Phi_p: N' = N + alpha M, R'^2 = R^2 (N + alpha M) /
          (N + M), tau' = (tau + Phi_M)(N + alpha M)/(N + M); the radiance is
          tau / (pi R^2 N_emitted). It converges to the right answer, so it is
          the reference where a path tracer cannot go (point and directional
          lights).

   The photon pass these methods share comes after streamed photon
   mapping (>>photonpass). */

/* Exact integral of Jensen's Gaussian filter over the disc, over pi r^2:
   a [1 - (1 - (2/b)(1 - e^(-b/2))) / (1 - e^(-b))]. */
static double pds__gauss_filter_norm(void)
{
    const double a = 0.918, b = 1.953;
    return a * (1.0 - (1.0 - (2.0 / b) * (1.0 - exp(-0.5 * b))) / (1.0 - exp(-b)));
}

/* Filter weight of a photon at squared distance d2 in a gather of radius
   r (r2 = r^2), and the normalisation c of the estimate's c pi r^2. */
static double pds__pm_weight(pds_kernel kernel, double d2, double r2)
{
    const double a = 0.918, b = 1.953;
    switch (kernel) {
    case PDS_KERNEL_CONE: return r2 > 0.0 ? 1.0 - sqrt(d2 / r2) : 1.0;
    case PDS_KERNEL_GAUSSIAN: return a * (1.0 - (1.0 - exp(-b * d2 / (2.0 * r2))) / (1.0 - exp(-b)));
    case PDS_KERNEL_NONE: return 1.0;
    }
    return 1.0;
}

static double pds__pm_norm(pds_kernel kernel)
{
    switch (kernel) {
    case PDS_KERNEL_CONE: return 1.0 - 2.0 / 3.0;
    case PDS_KERNEL_GAUSSIAN: return pds__gauss_filter_norm();
    case PDS_KERNEL_NONE: return 1.0;
    }
    return 1.0;
}

/* Landing: store the photon (photon-map methods). */
static void pds__store_photon(const pds__photon_job *job, pds__splat_buf *buf, const pds__ray_diff *r, pds__v3 ng,
                              const double flux[3], double lambda, long photon)
{
    pds__stored_photon *p;
    (void)job;
    if (pds__grow((void **)&buf->stored, &buf->cap_stored, buf->nstored + 1, sizeof *buf->stored)) {
        buf->out_of_memory = 1;
        return;
    }
    p = &buf->stored[buf->nstored++];
    pds__f3_set(p->pos, r->p);
    pds__f3_set(p->dir, r->d);
    pds__f3_set(p->ng, pds__dot(ng, r->d) < 0.0 ? ng : pds__scale(ng, -1.0));
    p->flux[0] = (float)flux[0];
    p->flux[1] = (float)flux[1];
    p->flux[2] = (float)flux[2];
    p->lambda = (float)lambda;
    p->index = photon;
    buf->splatted++;
}

static int pds__photon_index_cmp(const void *a, const void *b)
{
    long x = ((const pds__stored_photon *)a)->index, y = ((const pds__stored_photon *)b)->index;
    return (x > y) - (x < y);
}

/* The gather of the photon-map methods (pm, pdm): every eye vertex asks
   the map for its k nearest photons within a radius, a method-specific
   estimate turns them into reflected radiance, and the vertex's importance
   times that goes into its pixel (exact sums, so the chunking of vertices
   over threads does not matter). */
typedef struct pds__gather {
    const pds_scene *scene;
    const pds__eye_vertex *v;
    size_t nv;
    const pds__kdtree *tree;
    const void *photons;       /* pds__stored_photon (pm) or pds__diff_photon (pdm) */
    size_t k;                  /* neighbours asked for */
    double radius;             /* search radius */
    pds_kernel kernel;         /* pm's filter */
    double plane_tolerance;    /* pdm's topological guard */
    void (*estimate)(const struct pds__gather *g, const pds__eye_vertex *v, const size_t *idx, const double *d2,
                     size_t n, double sum[3]);
    pds__splat_buf *bufs;
    pds__mutex lock;
    size_t next;               /* guarded by lock: next vertex chunk */
    int next_buf;              /* guarded by lock */
    int out_of_memory;         /* guarded by lock */
    double found;              /* guarded by lock: photons the queries returned */
    size_t sample;             /* S > 0: gather only the vertices of the sample
                                  (pds__gather_sampled: phase 1) or only the
                                  others (phase 2) */
    int sample_phase;
    double *kth;               /* phase 1, if not NULL: kth[pds__gather_sample_at(i,
                                  S)] = the squared distance of the farthest
                                  photon found at i (DBL_MAX: none) */
    float *nfound;             /* phase 1, if not NULL: nfound[pds__gather_sample_at(i,
                                  S)] = the photons found at i */
} pds__gather;

#define PDS__GATHER_CHUNK 1024 /* a whole number of PDS__SAMPLE_RUN */

/* A gather's sample (under a time budget, to measure its pace): runs of
   PDS__SAMPLE_RUN consecutive vertices, one run in every block of S runs,
   at a place in its block that a hash of the block's number picks.
   Consecutive vertices are neighbouring pixels' samples, whose queries
   visit the same kd-tree nodes, as the whole gather's do; a sample of
   single vertices far apart pays a cache miss at every node of every
   query and measured queries two to five times slower than the gather
   then ran (pm, k = 8, refraction case: 0.9 against 0.43 us), and runs of
   16 (one pixel's samples at 16 spp) still three times (the ring and
   octahedron: 1.57 against 0.48 us on two threads). The place
   moves from block to block because a block is often a whole number of
   image rows: at the same place in each, the sample would be a stripe of
   the image (one column of 4 pixels a row at 256 x 256 and 4 samples a
   pixel, S = 64), and the queries of a stripe are not the image's
   (reflection case: its k = 8 queries 2.5 times quicker). */
#define PDS__SAMPLE_RUN 64

/* The run of block b that the sample takes. */
static size_t pds__gather_sample_run(size_t b, size_t S)
{
    return (size_t)(pds__mix64((uint64_t)b + 0x5A17u) % (uint64_t)S);
}

static int pds__gather_sampled(size_t i, size_t S)
{
    size_t r = i / PDS__SAMPLE_RUN;
    return r % S == pds__gather_sample_run(r / S, S);
}

/* The place of sampled vertex i among the sample's, and the sample's size
   among nv vertices. */
static size_t pds__gather_sample_at(size_t i, size_t S)
{
    return i / (PDS__SAMPLE_RUN * S) * PDS__SAMPLE_RUN + i % PDS__SAMPLE_RUN;
}

static size_t pds__gather_sample_count(size_t nv, size_t S)
{
    size_t block = PDS__SAMPLE_RUN * S, last = nv / block, r = nv % block;
    size_t first = PDS__SAMPLE_RUN * pds__gather_sample_run(last, S); /* the last block's run, from its start */
    return last * PDS__SAMPLE_RUN + (r > first ? (r - first < PDS__SAMPLE_RUN ? r - first : PDS__SAMPLE_RUN) : 0);
}

static void *pds__gather_worker(void *arg)
{
    pds__gather *g = (pds__gather *)arg;
    pds__splat_buf *buf;
    size_t *idx = (size_t *)malloc(sizeof *idx * g->k);
    double *d2 = (double *)malloc(sizeof *d2 * g->k);
    size_t found = 0;
    pds__v3 prev = pds__v(0.0, 0.0, 0.0);
    double prev_k2 = -1.0; /* the last query's k-th squared distance (-1: none) */
    pds__mutex_lock(&g->lock);
    buf = &g->bufs[g->next_buf++];
    if (!idx || !d2) g->out_of_memory = 1;
    pds__mutex_unlock(&g->lock);
    for (;;) {
        size_t first, last, i;
        pds__mutex_lock(&g->lock);
        g->found += (double)found;
        found = 0;
        first = g->out_of_memory ? g->nv : g->next;
        g->next = first + PDS__GATHER_CHUNK;
        pds__mutex_unlock(&g->lock);
        if (first >= g->nv) break;
        last = first + PDS__GATHER_CHUNK < g->nv ? first + PDS__GATHER_CHUNK : g->nv;
        for (i = first; i < last; i++) {
            const pds__eye_vertex *v = &g->v[i];
            double sum[3] = {0, 0, 0};
            size_t n;
            int c;
            if (g->sample && i % PDS__SAMPLE_RUN == 0 && pds__gather_sampled(i, g->sample) != (g->sample_phase == 1)) {
                i += PDS__SAMPLE_RUN - 1; /* the whole run is not this phase's (chunks are whole runs) */
                continue;
            }
            /* the k nearest within the radius, searched within the
               bound the last query gives (the same photons, sooner) */
            n = pds__kdtree_knn_within(g->tree, pds__f3_get(v->pos), g->k,
                                       pds__kdtree_knn_hint(pds__f3_get(v->pos), prev, prev_k2, g->radius), idx, d2);
            prev = pds__f3_get(v->pos);
            prev_k2 = n == g->k ? d2[n - 1] : -1.0;
            found += n;
            if (g->kth && g->sample_phase == 1) g->kth[pds__gather_sample_at(i, g->sample)] = n ? d2[n - 1] : DBL_MAX;
            if (g->nfound && g->sample_phase == 1) g->nfound[pds__gather_sample_at(i, g->sample)] = (float)n;
            if (n == 0) continue;
            g->estimate(g, v, idx, d2, n, sum);
            for (c = 0; c < 3; c++)
                if (sum[c] != 0.0) pds__image_add(buf, 3 * (size_t)v->pixel + (size_t)c, sum[c]);
        }
    }
    free(idx);
    free(d2);
    return NULL;
}

/* One run of the gather workers over the vertices g->sample and
   g->sample_phase select. */
static void pds__gather_once(pds__gather *g, pds__photon_job *job, int threads)
{
    g->next = 0;
    g->next_buf = 0;
    pds__mutex_init(&g->lock);
    pds__run_threads(threads < job->nbufs ? threads : job->nbufs, pds__gather_worker, g);
    pds__mutex_destroy(&g->lock);
}

/* F(c): the photons a query finds on average with a cap of c, when the
   sample's queries with a larger cap found found[0..n-1] (each finds
   min(c, what it found)); c itself when found is NULL. */
static double pds__gather_found(const float *found, size_t n, double c)
{
    double sum = 0.0;
    size_t i;
    if (!found || n == 0) return c;
    for (i = 0; i < n; i++) sum += fmin(c, (double)found[i]);
    return sum / (double)n;
}

/* The gather under a time budget: the cap whose gather fits the time left,
   from measured samples of it. t0 and t1 are the seconds a query took
   (on all threads, on the final map) with caps c0 < c1 (8 and the cap
   asked for; then the cap chosen and one of those); a query's cost grows
   linearly with the photons it finds, so at a cap c between them it
   takes
     t(c) = t0 + (t1 - t0) (F(c) - F(c0)) / (F(c1) - F(c0)),
   F from the photons each query of the cap-k sample found
   (pds__gather_found; found NULL: F(c) = c, the line through the two).
   Most queries find the cap at small caps and what lies within reach at
   large ones, so t(c) bends down: the line through the two samples
   under-rated caps between them (pdm on the refraction case: 6.3 us
   a query planned, 8.4 us taken at a cap of 149). Returns the largest
   cap in [c0, c1] whose queries take at most `per_query` seconds; c0 if
   none does. */
static double pds__gather_cap_fit(double c0, double t0, double c1, double t1, double per_query, const float *found,
                                  size_t n)
{
    double lo = c0, hi = c1, f0, f1;
    if (t1 <= per_query) return c1;
    if (!(t1 > t0)) return per_query >= t0 ? c1 : c0;
    f0 = pds__gather_found(found, n, c0);
    f1 = pds__gather_found(found, n, c1);
    if (!(f1 > f0)) return per_query >= t0 ? c1 : c0;
    /* t(c) grows with c: bisect over whole caps for the largest that fits */
    while (hi - lo > 1.0) {
        double mid = floor(0.5 * (lo + hi));
        if (t0 + (t1 - t0) * (pds__gather_found(found, n, mid) - f0) / (f1 - f0) <= per_query) lo = mid;
        else hi = mid;
    }
    return lo;
}

static int pds__cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Zero the threads' exact images (pm, pdm, spm: only the gather writes
   them). */
static void pds__gather_clear(pds__photon_job *job, size_t nsums)
{
    int t;
    for (t = 0; t < job->nbufs; t++) {
        memset(job->bufs[t].sum, 0, nsums * sizeof(pds__sum128));
        if (job->bufs[t].neg) memset(job->bufs[t].neg, 0, nsums * sizeof(pds__sum128));
    }
}

/* The seconds of a measuring gather (a sample or a probe): the quickest
   of up to three runs while they are short (together under 10 ms), the
   images cleared between them, so that the last run's stay as one run's
   would. A sample of a few milliseconds is at the mercy of one scheduler
   slice of another process: on the demo scene at 256 x 256 a probe's
   cap-8 gather of 4096 queries took 2.1 ms in one run and 16 ms in the
   next, which planned the tracing to end after the budget. */
static double pds__gather_timed(pds__gather *g, pds__photon_job *job, int threads)
{
    double best = DBL_MAX, spent = 0.0;
    int r;
    for (r = 0; r < 3 && !(r > 0 && (spent >= 0.01 || g->out_of_memory)); r++) {
        double t;
        if (r > 0) pds__gather_clear(job, job->nsums);
        g->found = 0.0;
        t = pds_time_now();
        pds__gather_once(g, job, threads);
        t = pds_time_now() - t;
        spent += t;
        if (t < best) best = t;
    }
    return best;
}

/* Run the gather on the threads that own the photon pass's images. With a
   time budget (job->gather_deadline > 0) the cap g->k is measured rather
   than modelled (>>photonpass: step 3 of the plan): a sample of about
   2048 vertices (fewer for a cap above 50) is gathered first with that
   cap (and thrown away; the photons each query found are kept); if the
   whole gather at that pace ends by the deadline, it is made; else a
   64th of the vertices (at most about 4096: on the reflection case at
   512 x 512 a 64th, 15,808 queries at k = 8 far from every photon, took
   0.13 s, and the radius trials after it as much again, of a 3 s budget
   planned without them) is gathered with a cap of 8, the cap
   pds__gather_cap_fit gives is taken, measured on the same sample and
   fitted again, and the whole gather is made with it (the sample kept
   if the cap stood or is 8, and the rest gathered after it; a search
   radius bounded as below if even 8 cannot end in time). Samples are
   runs of neighbours (pds__gather_sampled). The images hold each
   vertex's estimate once, whatever was measured. */
static pds_status pds__gather_run(pds__gather *g, pds__photon_job *job, int threads, pds_error *err)
{
    const size_t S0 = 64;
    size_t S = g->nv / 4096 > S0 ? g->nv / 4096 : S0; /* the cap-8 sample: one run in S */
    double k0 = (double)g->k;
    float *nfound = NULL; /* the photons each query of the cap-k sample found */
    g->bufs = job->bufs;
    g->sample = 0;
    g->kth = NULL;
    job->gather_radius = 0.0;
    if (job->gather_deadline > 0.0 && g->k > 8 && g->nv >= 64 * S0) {
        double ns = (double)pds__gather_sample_count(g->nv, S), t_k, t_8, cap;
        /* about 2048 vertices at a cap of 50, fewer at a larger cap (at
           least 256: 2048 of pdm's queries at 500 took 0.28 s on the
           Cornell box at 512 x 512) */
        size_t want = (size_t)fmax(256.0, fmin(2048.0, 102400.0 / k0));
        size_t S2 = g->nv / want > S ? g->nv / want : S;
        size_t n2 = pds__gather_sample_count(g->nv, S2);
        /* the pace with the cap asked for, on a coarse sample (not kept:
           a query with a cap of 500 can cost a hundred of a cap of 8) */
        g->nfound = (float *)malloc(sizeof *g->nfound * n2); /* none: F(c) = c */
        g->sample = S2;
        g->sample_phase = 1;
        t_k = pds__gather_timed(g, job, threads) / (double)n2;
        nfound = g->nfound;
        g->nfound = NULL;
        pds__gather_clear(job, job->nsums);
        g->found = 0.0;
        g->sample = 0;
        if (!g->out_of_memory && t_k * (double)g->nv > job->gather_deadline - pds_time_now()) {
            g->kth = (double *)malloc(sizeof *g->kth * (size_t)ns); /* none: no radius bound */
            g->k = 8;
            g->sample = S;
            t_8 = pds__gather_timed(g, job, threads) / ns;
            cap = pds__gather_cap_fit(8.0, t_8, k0, t_k, (job->gather_deadline - pds_time_now()) / (double)g->nv,
                                      nfound, nfound ? n2 : 0);
            if (cap > 8.0) {
                /* the cap chosen, measured on the same sample: the fit
                   again between it and the nearer of the two (a query's
                   cost is not quite linear in the photons found: pdm's
                   cap of 66 on the demo scene took 6.6 us a query where
                   the line through caps 8 and 500 said 9.3); kept if
                   it stands */
                double t_c, c2, left_q;
                pds__gather_clear(job, job->nsums);
                g->k = (size_t)cap;
                t_c = pds__gather_timed(g, job, threads) / ns;
                left_q = (job->gather_deadline - pds_time_now()) / ((double)g->nv - ns);
                c2 = t_c <= left_q ? pds__gather_cap_fit(cap, t_c, k0, t_k, left_q, nfound, nfound ? n2 : 0)
                                   : pds__gather_cap_fit(8.0, t_8, cap, t_c, left_q, nfound, nfound ? n2 : 0);
                if (c2 != cap) {
                    pds__gather_clear(job, job->nsums);
                    g->found = 0.0;
                    g->sample = 0;
                    g->k = (size_t)c2;
                }
            } else if (g->kth && t_8 * ((double)g->nv - ns) > job->gather_deadline - pds_time_now()) {
                /* even k = 8 cannot end in time: the queries far from
                   every photon (whose k nearest lie far off, and whose
                   estimate is a faint blur) cost the most; bound the
                   search radius by the median, then the quartile, then
                   the tenth of the sample's 8th-photon distances, the
                   first whose sample's pace fits (the sample kept) */
                static const double q[3] = {0.5, 0.25, 0.1};
                double r0 = g->radius, *kth = g->kth;
                int j;
                g->kth = NULL; /* the trials below record nothing */
                qsort(kth, (size_t)ns, sizeof *kth, pds__cmp_double);
                for (j = 0; j < 3 && !g->out_of_memory; j++) {
                    double r = sqrt(kth[(size_t)(q[j] * (ns - 1.0))]);
                    if (!(r < r0) || !(r > 0.0)) continue;
                    pds__gather_clear(job, job->nsums);
                    g->radius = r;
                    job->gather_radius = r;
                    if (pds__gather_timed(g, job, threads) / ns * ((double)g->nv - ns) <=
                        job->gather_deadline - pds_time_now())
                        break;
                }
                free(kth);
            }
        }
        g->sample_phase = 2;
    }
    if (job->probe_k2 > 0) {
        /* the map probe: three gathers, each timed, on the one map: with
           the cap; with the cap probe_k2 (8), each query's farthest
           photon kept; and with that cap within the tenth of those
           distances, the radius the gather bounds its search by when
           nothing else fits (the last of its trials above), so that the
           plan knows what that gather costs */
        size_t k = g->k;
        double r0 = g->radius, *kth = (double *)malloc(sizeof *kth * (g->nv ? g->nv : 1));
        int j;
        for (j = 0; j < 3 && !g->out_of_memory; j++) {
            if (j == 2) {
                double r;
                if (!kth) break;
                qsort(kth, g->nv, sizeof *kth, pds__cmp_double);
                r = sqrt(kth[(size_t)(0.1 * ((double)g->nv - 1.0))]);
                if (!(r < r0) || !(r > 0.0)) break;
                g->radius = r;
            }
            g->k = j ? job->probe_k2 : k;
            g->found = 0.0;
            /* the second gather: every vertex (a sample of S = 1), kth[i]
               the 8th distance of vertex i */
            g->kth = j == 1 ? kth : NULL;
            g->sample = j == 1 && kth ? 1 : 0;
            g->sample_phase = 1;
            job->probe_s[j] = pds__gather_timed(g, job, threads);
            job->probe_found[j] = g->found;
        }
        g->k = k;
        g->radius = r0;
        g->kth = NULL;
        free(kth);
    } else if (!g->out_of_memory) {
        pds__gather_once(g, job, threads);
    }
    g->sample = 0;
    free(g->kth);
    g->kth = NULL;
    free(nfound);
    job->gather_k = g->k;
    return g->out_of_memory ? pds__nomem(err) : PDS_OK;
}

/* pm: L = sum fr Phi_p w_p / (c pi r^2), r = the k-th distance; nothing
   from fewer than min(8, k) photons (Jensen's code). */
static void pds__pm_estimate(const pds__gather *g, const pds__eye_vertex *v, const size_t *idx, const double *d2,
                             size_t n, double sum[3])
{
    const pds__stored_photon *photons = (const pds__stored_photon *)g->photons;
    pds__v3 gv = pds__f3_get(v->g);
    double r2 = d2[n - 1], area;
    size_t j;
    int c;
    if (n < (g->k < 8 ? g->k : 8) || !(r2 > 0.0)) return;
    for (j = 0; j < n; j++) {
        const pds__stored_photon *p = &photons[idx[j]];
        double f[3], w, e[3];
        if (pds__dot(pds__f3_get(p->ng), gv) <= 0.0) continue; /* the surface's other side */
        for (c = 0; c < 3; c++) e[c] = p->flux[c];
        if (!pds__eye_response(g->scene, v, pds__scale(pds__f3_get(p->dir), -1.0), p->lambda, e, f)) continue;
        w = pds__pm_weight(g->kernel, d2[j], r2);
        for (c = 0; c < 3; c++) sum[c] += f[c] * e[c] * w;
    }
    area = pds__pm_norm(g->kernel) * PDS__PI * r2;
    for (c = 0; c < 3; c++) sum[c] /= area;
}

/* Merge the threads' stored photons into one array sorted by photon
   number; frees the per-thread arrays. */
static pds__stored_photon *pds__merge_photons(pds__splat_buf *bufs, int nbufs, size_t *count)
{
    size_t total = 0, at = 0;
    pds__stored_photon *all;
    int t;
    for (t = 0; t < nbufs; t++) total += bufs[t].nstored;
    all = (pds__stored_photon *)malloc(sizeof *all * (total ? total : 1));
    for (t = 0; t < nbufs; t++) {
        if (all && bufs[t].nstored) memcpy(all + at, bufs[t].stored, sizeof *all * bufs[t].nstored);
        at += bufs[t].nstored;
        free(bufs[t].stored);
        bufs[t].stored = NULL;
        bufs[t].nstored = bufs[t].cap_stored = 0;
    }
    if (all) qsort(all, total, sizeof *all, pds__photon_index_cmp);
    *count = total;
    return all;
}

/* The estimate of one eye vertex from its nearest stored photons. */
typedef void (*pds__estimate_fn)(const pds__gather *g, const pds__eye_vertex *v, const size_t *idx,
                                 const double *d2, size_t n, double sum[3]);

/* Photon mapping's second half: the map of the stored photons (pm: the
   caustic map; spm: the stream map) and the gather into the threads'
   exact images with `estimate`. */
static pds_status pds__stored_gather(pds__photon_job *job, const pds_options *opt, const pds__eye_vertex *v, size_t nv,
                                     int threads, pds_render_stats *stats, pds_error *err, pds__estimate_fn estimate)
{
    pds__gather g;
    pds__kdtree tree;
    size_t np;
    pds_status st;
    double tb = pds_time_now(), tg;
    pds__stored_photon *photons = pds__merge_photons(job->bufs, job->nbufs, &np);
    if (!photons) return pds__nomem(err);
    st = pds__kdtree_build(&tree, np ? &photons[0].pos[0] : NULL, sizeof *photons / sizeof(float), np, err);
    if (st) {
        free(photons);
        return st;
    }
    tg = pds_time_now();
    job->build_s = tg - tb;
    job->map_photons = np;
    if (stats) {
        stats->map_bytes = np * sizeof *photons + pds__kdtree_memory(&tree);
        stats->splatted = (long)np;
    }
    memset(&g, 0, sizeof g);
    g.scene = job->scene;
    g.v = v;
    g.nv = nv;
    g.tree = &tree;
    g.photons = photons;
    g.k = (size_t)opt->k;
    g.radius = opt->max_radius > 0.0 ? opt->max_radius : DBL_MAX;
    g.kernel = opt->kernel;
    g.estimate = estimate;
    st = pds__gather_run(&g, job, threads, err);
    job->gather_s = pds_time_now() - tg;
    job->gather_found = g.found;
    pds__kdtree_free(&tree);
    free(photons);
    return st;
}

static pds_status pds__pm_gather(pds__photon_job *job, const pds_options *opt, const pds__eye_vertex *v, size_t nv,
                                 int threads, pds_render_stats *stats, pds_error *err)
{
    return pds__stored_gather(job, opt, v, nv, threads, stats, err, pds__pm_estimate);
}

/* --- photon differential mapping --------------------------------------- */

/* Landing: store the photon with its footprint (pdm). */
static void pds__store_diff_photon(const pds__photon_job *job, pds__splat_buf *buf, const pds__ray_diff *r,
                                   pds__v3 ng, const double flux[3], double lambda, long photon)
{
    pds__diff_photon *p;
    pds__v3 np = pds__dot(ng, r->d) < 0.0 ? ng : pds__scale(ng, -1.0);
    pds__ray_diff wide;
    double M[2][3], ap, major;
    int k;
    if (job->min_aspect > 0.0) {
        wide = *r;
        if (pds__footprint_widen(&wide.dpdu, &wide.dpdv, np, job->min_aspect)) r = &wide;
    }
    ap = pds__footprint_area(r->dpdu, r->dpdv);
    major = pds__footprint_major_axis(r->dpdu, r->dpdv);
    if (!(ap > 0.0) || !isfinite(ap) || !(major > 0.0) || !isfinite(major) ||
        !pds__filter_matrix(r->dpdu, r->dpdv, np, M)) {
        buf->degenerate++;
        return;
    }
    if (pds__grow((void **)&buf->dstored, &buf->cap_dstored, buf->ndstored + 1, sizeof *buf->dstored)) {
        buf->out_of_memory = 1;
        return;
    }
    p = &buf->dstored[buf->ndstored++];
    pds__f3_set(p->pos, r->p);
    pds__f3_set(p->dir, r->d);
    pds__f3_set(p->np, np);
    for (k = 0; k < 3; k++) {
        p->ep[k] = (float)(flux[k] / ap);
        p->M[k] = (float)M[0][k];
        p->M[3 + k] = (float)M[1][k];
    }
    p->major = (float)major;
    p->lambda = (float)lambda;
    p->index = photon;
    buf->splatted++;
}

static int pds__diff_photon_cmp(const void *a, const void *b)
{
    long x = ((const pds__diff_photon *)a)->index, y = ((const pds__diff_photon *)b)->index;
    return (x > y) - (x < y);
}

/* pdm: eqs. 10-12 for every gathered photon whose footprint covers v. */
static void pds__pdm_estimate(const pds__gather *g, const pds__eye_vertex *v, const size_t *idx, const double *d2,
                              size_t n, double sum[3])
{
    const pds__diff_photon *photons = (const pds__diff_photon *)g->photons;
    pds__v3 x = pds__f3_get(v->pos), gv = pds__f3_get(v->g);
    size_t j;
    int c;
    (void)d2;
    for (j = 0; j < n; j++) {
        const pds__diff_photon *p = &photons[idx[j]];
        pds__v3 np = pds__f3_get(p->np), d = pds__sub(x, pds__f3_get(p->pos));
        double y0 = p->M[0] * d.x + p->M[1] * d.y + p->M[2] * d.z;
        double y1 = p->M[3] * d.x + p->M[4] * d.y + p->M[5] * d.z, r2 = y0 * y0 + y1 * y1, f[3], k, e[3];
        /* the same guards as the PDS splat */
        if (r2 >= 1.0 || fabs(pds__dot(np, d)) > g->plane_tolerance * p->major || pds__dot(gv, np) <= 0.0) continue;
        for (c = 0; c < 3; c++) e[c] = p->ep[c];
        if (!pds__eye_response(g->scene, v, pds__scale(pds__f3_get(p->dir), -1.0), p->lambda, e, f)) continue;
        k = pds__kernel_silverman(r2);
        for (c = 0; c < 3; c++) sum[c] += PDS__PI * k * f[c] * e[c];
    }
}

/* Photon differential mapping's second half: the map of photons with their
   footprints, and the gather. */
static pds_status pds__pdm_gather(pds__photon_job *job, const pds_options *opt, const pds__eye_vertex *v, size_t nv,
                                  int threads, pds_render_stats *stats, pds_error *err)
{
    pds__gather g;
    pds__kdtree tree;
    pds__diff_photon *all;
    size_t total = 0, at = 0, i;
    pds_status st;
    int t;
    double tb = pds_time_now(), tg;
    for (t = 0; t < job->nbufs; t++) total += job->bufs[t].ndstored;
    all = (pds__diff_photon *)malloc(sizeof *all * (total ? total : 1));
    for (t = 0; t < job->nbufs; t++) {
        if (all && job->bufs[t].ndstored) memcpy(all + at, job->bufs[t].dstored, sizeof *all * job->bufs[t].ndstored);
        at += job->bufs[t].ndstored;
    }
    if (!all) return pds__nomem(err);
    qsort(all, total, sizeof *all, pds__diff_photon_cmp);
    st = pds__kdtree_build(&tree, total ? &all[0].pos[0] : NULL, sizeof *all / sizeof(float), total, err);
    if (st) {
        free(all);
        return st;
    }
    tg = pds_time_now();
    job->build_s = tg - tb;
    job->map_photons = total;
    if (stats) stats->map_bytes = total * sizeof *all + pds__kdtree_memory(&tree);
    memset(&g, 0, sizeof g);
    g.scene = job->scene;
    g.v = v;
    g.nv = nv;
    g.tree = &tree;
    g.photons = all;
    g.k = (size_t)opt->max_photons;
    g.plane_tolerance = opt->plane_tolerance;
    for (i = 0; i < total; i++)
        if (all[i].major > g.radius) g.radius = all[i].major;
    g.estimate = pds__pdm_estimate;
    st = pds__gather_run(&g, job, threads, err);
    job->gather_s = pds_time_now() - tg;
    job->gather_found = g.found;
    pds__kdtree_free(&tree);
    free(all);
    return st;
}

/* --- progressive photon mapping ----------------------------------------- */

/* Per eye vertex: R^2, N, tau (RGB, in the flux of one photon emitted
   alone, with the vertex's importance, so that its pixel gets
   tau / (pi R^2 N_emitted)). */
typedef struct pds__ppm_state {
    double r2, n, tau[3];
} pds__ppm_state;

typedef struct pds__ppm_job {
    const pds_scene *scene;
    const pds__eye_vertex *v;
    pds__ppm_state *state;
    size_t nv;
    const pds__stored_photon *photons;
    const pds__kdtree *tree;
    double alpha, photon_scale; /* photon_scale: stored flux -> flux alone */
    pds__mutex lock;
    size_t next;                /* guarded by lock */
} pds__ppm_job;

/* What one vertex gathers in one pass. */
typedef struct pds__ppm_gather {
    const pds__ppm_job *job;
    const pds__eye_vertex *v;
    long found;
    double phi[3];
} pds__ppm_gather;

static void pds__ppm_visit(void *ctx, size_t index, double dist2)
{
    pds__ppm_gather *g = (pds__ppm_gather *)ctx;
    const pds__stored_photon *p = &g->job->photons[index];
    double f[3], e[3];
    int c;
    (void)dist2;
    if (pds__dot(pds__f3_get(p->ng), pds__f3_get(g->v->g)) <= 0.0) return;
    /* spectral: a vertex seen through dispersive glass counts only the
       spectral photons of its wavelength bin, found and flux alike */
    if (p->lambda > 0.0f && pds__wavelength_match(g->v->lambda, p->lambda) == 0.0) return;
    g->found++;
    for (c = 0; c < 3; c++) e[c] = p->flux[c];
    if (!pds__eye_response(g->job->scene, g->v, pds__scale(pds__f3_get(p->dir), -1.0), p->lambda, e, f)) return;
    for (c = 0; c < 3; c++) g->phi[c] += f[c] * e[c] * g->job->photon_scale;
}

/* 1 if no photon of the pass lies within the radius of any vertex of
   the run of up to PDS__SAMPLE_RUN vertices from i (not past `last`):
   their range queries would each find none, and a vertex that finds
   none keeps R, N and tau (Hachisuka et al. 2008 update only the hit
   points with M > 0). One query for the nearest photon within R_max +
   h of the centre c of the run's bounding box (h its half diagonal,
   R_max the run's largest radius): a photon within R_i of vertex i is
   within R_i + |x_i - c| <= R_max + h of c (a margin of 1e-9 for the
   rounding). The image is the same bit for bit; a pass costs one query
   per run far from every photon instead of 64. */
static int pds__ppm_run_empty(const pds__ppm_job *job, size_t i, size_t last)
{
    double lo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, hi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX}, r2 = 0.0, h, d2;
    size_t end = i + PDS__SAMPLE_RUN < last ? i + PDS__SAMPLE_RUN : last, j, idx;
    int k;
    for (j = i; j < end; j++) {
        for (k = 0; k < 3; k++) {
            double x = job->v[j].pos[k];
            if (!(x == x)) return 0; /* a NaN vertex: left to its own query */
            lo[k] = fmin(lo[k], x);
            hi[k] = fmax(hi[k], x);
        }
        if (!(job->state[j].r2 <= r2)) r2 = job->state[j].r2;
    }
    if (!(r2 < DBL_MAX)) return 0;
    h = 0.5 * pds__length(pds__v(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]));
    return pds__kdtree_knn(job->tree, pds__v(0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])), 1,
                           (sqrt(r2) + h) * (1.0 + 1e-9), &idx, &d2) == 0;
}

static void *pds__ppm_worker(void *arg)
{
    pds__ppm_job *job = (pds__ppm_job *)arg;
    for (;;) {
        size_t first, last, i;
        pds__mutex_lock(&job->lock);
        first = job->next;
        job->next = first + PDS__GATHER_CHUNK;
        pds__mutex_unlock(&job->lock);
        if (first >= job->nv) break;
        last = first + PDS__GATHER_CHUNK < job->nv ? first + PDS__GATHER_CHUNK : job->nv;
        for (i = first; i < last; i++) {
            pds__ppm_state *s = &job->state[i];
            pds__ppm_gather g;
            double grow;
            int c;
            if (i % PDS__SAMPLE_RUN == 0 && pds__ppm_run_empty(job, i, last)) {
                i += PDS__SAMPLE_RUN - 1; /* no photon within reach of the run: nothing changes */
                continue;
            }
            g.job = job;
            g.v = &job->v[i];
            g.found = 0;
            g.phi[0] = g.phi[1] = g.phi[2] = 0.0;
            pds__kdtree_range(job->tree, pds__f3_get(g.v->pos), sqrt(s->r2), pds__ppm_visit, &g);
            if (g.found == 0) continue;
            /* Hachisuka et al. 2008, eqs. 6-11 */
            grow = (s->n + job->alpha * g.found) / (s->n + g.found);
            s->r2 *= grow;
            for (c = 0; c < 3; c++) s->tau[c] = (s->tau[c] + g.phi[c]) * grow;
            s->n += job->alpha * g.found;
        }
    }
    return NULL;
}

/* One progressive pass: the photons just traced update every vertex. */
static pds_status pds__ppm_update(pds__photon_job *job, const pds_options *opt, const pds__eye_vertex *v,
                                  pds__ppm_state *state, size_t nv, int threads, pds_render_stats *stats,
                                  pds_error *err)
{
    pds__ppm_job pj;
    pds__kdtree tree;
    size_t np;
    pds_status st;
    double tb = pds_time_now(), tg;
    pds__stored_photon *photons = pds__merge_photons(job->bufs, job->nbufs, &np);
    if (!photons) return pds__nomem(err);
    st = pds__kdtree_build(&tree, np ? &photons[0].pos[0] : NULL, sizeof *photons / sizeof(float), np, err);
    if (st) {
        free(photons);
        return st;
    }
    tg = pds_time_now();
    if (stats) stats->time_map_s += tg - tb;
    if (stats && np * sizeof *photons + pds__kdtree_memory(&tree) > stats->map_bytes)
        stats->map_bytes = np * sizeof *photons + pds__kdtree_memory(&tree);
    memset(&pj, 0, sizeof pj);
    pj.scene = job->scene;
    pj.v = v;
    pj.state = state;
    pj.nv = nv;
    pj.photons = photons;
    pj.tree = &tree;
    pj.alpha = opt->alpha;
    pj.photon_scale = job->n_planned;
    pds__mutex_init(&pj.lock);
    pds__run_threads(threads, pds__ppm_worker, &pj);
    pds__mutex_destroy(&pj.lock);
    if (stats) stats->time_gather_s += pds_time_now() - tg;
    pds__kdtree_free(&tree);
    free(photons);
    return PDS_OK;
}

/* Default splat radius: 1/200 of the scene's bounding-box diagonal. */
static double pds__default_radius(const pds_scene *s)
{
    double d = pds__length(pds__sub(s->bounds_max, s->bounds_min));
    return d > 0.0 ? d / 200.0 : 0.01;
}

/* Under a time budget: the photons of ppm's next pass, 0 for none, when
   `left` seconds remain, tracing `photons` photons takes trace_s and an
   update (the pass's map and the range queries of every vertex) takes
     update(n) = fixed_s + per_photon_s n
   for a pass of n photons: a fixed part for the queries of every vertex,
   even those no photon reaches, and a part for each photon a vertex
   finds, which is most of it wherever a vertex's disc holds many photons
   (the ring and octahedron at 256 x 256, 16 samples a pixel: 100,000
   photons traced in 0.022 s took 0.5 s to update, 1,024 took 0.025 s).
   A whole pass if it fits; else the pass whose tracing and update fill
   the time left, in whole batches (PDS__PHOTON_BATCH); if not one batch
   fits, one batch when that pass would end nearer T than stopping now
   (its overrun less than the time left); else none. Hachisuka et al.'s
   recurrence holds for passes of any size: the estimate is
   tau / (pi R^2 N_emitted) with N_emitted the photons of all passes. */
static long pds__ppm_pass_photons(double left, double trace_s, double fixed_s, double per_photon_s, long photons)
{
    double n, batch = (double)PDS__PHOTON_BATCH, c = trace_s / (double)(photons > 0 ? photons : 1) + per_photon_s;
    if (fixed_s + c * (double)photons <= left) return photons;
    if (!(c > 0.0) || !(left > 0.0)) return 0;
    n = floor((left - fixed_s) / c / batch) * batch;
    if (n >= batch) return (long)n;
    if (fixed_s + c * batch - left >= left) return 0;
    return photons < PDS__PHOTON_BATCH ? photons : PDS__PHOTON_BATCH;
}

/* The update's cost model of pds__ppm_pass_photons from the pass just
   made (n photons, its update took u seconds) and the one before it
   (n_prev, u_prev; n_prev 0: none): the line through the two when their
   sizes differ by a factor of 2 at least and it has no negative part
   gives the fixed part; else *fixed_s stays (0 at first: all of it per
   photon, the larger estimate for a larger pass). The per-photon part
   is then the rest of this pass's update, which follows the radii as
   they shrink (a vertex's disc holds fewer photons every pass). */
static void pds__ppm_update_model(double n, double u, double n_prev, double u_prev, double *fixed_s,
                                  double *per_photon_s)
{
    if (n_prev > 0.0 && (n >= 2.0 * n_prev || n_prev >= 2.0 * n)) {
        double b = (u - u_prev) / (n - n_prev), a = u - b * n;
        if (b >= 0.0 && a >= 0.0) *fixed_s = a;
    }
    if (*fixed_s > u) *fixed_s = u;
    *per_photon_s = n > 0.0 ? (u - *fixed_s) / n : 0.0;
}

/* Progressive photon mapping: passes of opt->photons photons, each
   updating every eye vertex, until opt->passes (or, with a time budget,
   until the time is spent: the first pass tracing for a 200th of it at
   most, a pass whose update is measured before much of the budget is
   gone (a pass's update grows with its photons, and a first pass of a
   quarter of T took 1.2 s to update on the ring and octahedron at 256 x
   256: 1.66 T), then each pass as long as pds__ppm_pass_photons finds
   room for, from the updates measured so far (pds__ppm_update_model),
   whole while they fit, then shorter ones; at least one pass of one
   batch). Adds the radiance of each
   vertex into the exact sums of job->bufs[0] (for a factor n_planned /
   emitted of 1), unless the progress callback stopped it (job->cancelled:
   then nothing). *emitted_out gets the photons emitted. */
static pds_status pds__ppm_passes(pds__photon_job *job, const pds_options *opt, const pds__eye_vertex *v, size_t nv,
                                  int threads, long *emitted_out, pds_render_stats *stats, pds_error *err)
{
    pds__ppm_state *state = (pds__ppm_state *)calloc(nv ? nv : 1, sizeof *state);
    double r0 = opt->radius > 0.0 ? opt->radius : pds__default_radius(job->scene);
    long emitted = 0, pass;
    size_t i;
    pds_status st = PDS_OK;
    int t;
    double fixed_s = 0.0, per_photon_s = 0.0; /* a time budget: the update's model */
    double n_prev = 0.0, u_prev = 0.0;        /* ... and the pass before */
    if (!state) return pds__nomem(err);
    for (i = 0; i < nv; i++) state[i].r2 = r0 * r0;
    for (pass = 0; !st; pass++) {
        long this_pass, next;
        double tt = pds_time_now(), tu;
        /* a time budget: the first pass traces a 200th of it at most,
           so that its update (which the next passes' sizes are planned
           from) comes in time too when one pass of --photons would not */
        job->deadline = opt->time_s > 0.0 && pass == 0 ? job->t0 + opt->time_s / 200.0 : 0.0;
        pds__photon_run(job, threads, pass * (long)opt->photons);
        job->deadline = 0.0;
        if (job->batches_done == 0 && !job->cancelled) {
            /* the quarter was gone before the first batch: one batch, so
               that the image has caustics (and the overrun shows) */
            long n = job->n_total;
            job->n_total = n < PDS__PHOTON_BATCH ? n : PDS__PHOTON_BATCH;
            pds__photon_run(job, threads, pass * (long)opt->photons);
            job->n_total = n;
        }
        this_pass = job->batches_done * (long)PDS__PHOTON_BATCH;
        if (this_pass > job->n_total) this_pass = job->n_total;
        emitted += this_pass;
        for (t = 0; t < job->nbufs; t++)
            if (job->bufs[t].out_of_memory) st = PDS_ERR_NOMEM;
        if (job->cancelled) break;
        tu = pds_time_now();
        if (!st) st = pds__ppm_update(job, opt, v, state, nv, threads, stats, err);
        if (opt->time_s <= 0.0) {
            if (pass + 1 >= opt->passes) {
                pass++;
                break;
            }
            continue;
        }
        /* a time budget: the next pass's size from this one's times */
        pds__ppm_update_model((double)this_pass, pds_time_now() - tu, n_prev, u_prev, &fixed_s, &per_photon_s);
        n_prev = (double)this_pass;
        u_prev = pds_time_now() - tu;
        next = pds__ppm_pass_photons(opt->time_s - (pds_time_now() - job->t0), (tu - tt) * (double)opt->photons /
                                     (double)(this_pass > 0 ? this_pass : 1), fixed_s, per_photon_s, opt->photons);
        if (next == 0) {
            pass++;
            break;
        }
        job->n_total = next;
    }
    if (!st && emitted > 0 && !job->cancelled) {
        /* L = tau / (pi R^2 N_emitted), times the vertex's importance */
        for (i = 0; i < nv; i++) {
            int c;
            if (!(state[i].r2 > 0.0)) continue;
            for (c = 0; c < 3; c++)
                pds__image_add(&job->bufs[0], 3 * (size_t)v[i].pixel + (size_t)c,
                               state[i].tau[c] / (PDS__PI * state[i].r2 * (double)emitted));
        }
    }
    *emitted_out = emitted;
    if (stats) {
        stats->photons = emitted;
        stats->passes = (int)pass;
    }
    free(state);
    return st == PDS_ERR_NOMEM ? pds__nomem(err) : st;
}

/* ===================================================================== */
/* >>streams                                                             */
/* ===================================================================== */
/* Streamed photon mapping (Guzek, Napieralski, "Efficient rendering of
   caustics with streamed photon mapping", Bull. Pol. Acad. Sci. Tech. Sci.
   65(3), 2017; seed paper 003), on the same eye pass, aimed photons and
   exact images as the other methods.

   The paper's method, sect. 3:
   - nfs streams leave the light; a stream is a leading photon, which
     gives the stream its direction, and nfa associated photons whose
     directions deviate from the leader's within a radius rs. A stream
     carries Es = Ez / nfs (eq. 1, Ez the light's energy), shared equally
     by its nfa + 1 photons.
   - Sect. 3.1, step 3: where the leader meets a diffuse surface, each
     associated photon gets a random point within rs of the leader's hit
     and the leader bounces diffusely (at most mr times); where the leader
     meets a specular or refractive surface, "all associated photons are
     eliminated and the sum of their energy values is assigned to the
     leading photon", which then reflects or refracts; this concentration
     is what makes caustics bright "without increasing the number of
     photons in a photon map".
   - Sect. 3.2: every diffuse hit of a leader is stored in a kd-tree of
     streams; the gather finds the k nearest leaders within R and
       L(x, wr) = 1/dA sum_{i=1..k} fr(x, wi, wr) Ei            (eq. 2)
     Ei the stream's energy (the sum of its photons'), dA the area of the
     circle of the search radius.

   In PDS the photon methods compute only the caustic paths L S+ D (the
   eye pass computes the rest, including everything a stream does after
   a diffuse bounce). A caustic path's first event is specular, so by the
   rule above every stream that makes a caustic has lost its associated
   photons before they did anything: it travels on as its leader alone
   with the whole Es, is reflected and refracted with the Fresnel weights
   of the shared photon tracing, and is stored where it lands. So here:
   - stream s is pds's photon number s (the shared aimed emission, >>pds):
     its leader carries Es = flux / nfs, which is eq. 1 per light (the
     light chosen with probability pmf, Es = Phi / (pmf nfs));
   - a stream that lands is stored as one record, its leader with the
     stream's energy (56 bytes; it has no associated photons left);
   - the gather is eq. 2 over those records (pds__spm_estimate).
   What nfa and rs shape (streams whose leader first meets a diffuse
   surface: direct light and what follows it) is not caustic light, so
   rs does not enter the caustic image at all, and nfa only says how
   many photons a stream stands for: a render of nfs streams counts
   nfs (nfa + 1) emitted photons, and with no stream count given spm emits
   photons / (nfa + 1) streams, as many photons as pm would. Those
   streams are gi's global map of streams (>>gi, "streams in the global
   map"), and spm's full image is the paper's whole system: gi's two
   passes with that map and these caustic streams (>>api,
   pds__spm_as_gi); with PDS_PATHS_CAUSTICS_ONLY spm is this section
   alone.

   Ambiguities and the choices made (README, "Streamed photon mapping"):
   - dA: "the circle with a radius equal to radius R of the nearest leading
     photons search sphere". Taken as in Jensen's photon map code: the
     sphere shrinks to the k-th leader once k are found, so dA = pi r_k^2
     when k leaders lie within R, else pi R^2 (R = max_radius; with no R
     and fewer than k leaders in the whole map, the farthest one found).
   - The kernel: none (eq. 2 is a plain sum; the paper leaves Gauss or
     Epanechnikov kernels to future work).
   - Like pm, only leaders that arrived on the vertex's side of a surface
     facing the same way count (Jensen's code; the paper does not say).
   - Photons per stream: nfa + 1 as sect. 3 says ("equally divided among
     all the photons in the stream (nfa+1)"), although Table 1 counts
     nfs x nfa photons. */

/* nfs: the streams a render without a time budget emits. */
static long pds__spm_streams(const pds_options *opt)
{
    if (opt->streams > 0) return opt->streams;
    return opt->photons / ((long)opt->stream_photons + 1);
}

/* eq. 2 at one eye vertex from the n <= k nearest leaders (idx, d2 sorted
   by distance): L = sum fr Ei / (pi r^2), r = the k-th distance when k
   were found, else the search radius R (or, with no R, the farthest);
   times the vertex's importance. */
static void pds__spm_estimate(const pds__gather *g, const pds__eye_vertex *v, const size_t *idx, const double *d2,
                              size_t n, double sum[3])
{
    const pds__stored_photon *streams = (const pds__stored_photon *)g->photons;
    pds__v3 gv = pds__f3_get(v->g);
    double r2 = n == g->k || !(g->radius < DBL_MAX) ? d2[n - 1] : g->radius * g->radius, area;
    size_t j;
    int c;
    if (!(r2 > 0.0)) return;
    for (j = 0; j < n; j++) {
        const pds__stored_photon *p = &streams[idx[j]];
        double f[3], e[3]; /* fr x the vertex's importance; the flux, at the vertex (>>spectral) */
        if (pds__dot(pds__f3_get(p->ng), gv) <= 0.0) continue; /* the surface's other side */
        for (c = 0; c < 3; c++) e[c] = p->flux[c];
        if (!pds__eye_response(g->scene, v, pds__scale(pds__f3_get(p->dir), -1.0), p->lambda, e, f)) continue;
        for (c = 0; c < 3; c++) sum[c] += f[c] * e[c];
    }
    area = PDS__PI * r2;
    for (c = 0; c < 3; c++) sum[c] /= area;
}

/* The stream map of the landed leaders and the gather of eq. 2. */
static pds_status pds__spm_gather(pds__photon_job *job, const pds_options *opt, const pds__eye_vertex *v, size_t nv,
                                  int threads, pds_render_stats *stats, pds_error *err)
{
    return pds__stored_gather(job, opt, v, nv, threads, stats, err, pds__spm_estimate);
}

/* ===================================================================== */
/* >>photonpass                                                          */
/* ===================================================================== */
/* The photon pass every photon method shares: the time planning of the
   map methods, the threads tracing photons, the methods' second halves,
   and the caustic image. */

/* pm, pdm and spm under a time budget: the map build and the gather come
   after the last photon, so the tracing must stop early enough for them.
   Probe them on the calibration photons (already stored in job->bufs)
   with every s-th eye vertex, and model, for a map of m stored photons,
     build(m)  = build_probe m log m / (m_probe log m_probe)
     gather(m) = nv (c0 + c1 f) sqrt(max(1, log m / log m_probe)) / P,
   c0 + c1 f the time of a query that finds f photons, fitted to two probe
   gathers, one with the cap and one with a cap of 8 (with one, or when
   they found about as many photons, c0 = c1 = the probe's time per query
   / (1 + its photons found per query)), f
   the photons a query will find: pm and spm min(cap, m); pdm the probe's
   count scaled by the planned / emitted photons of the calibration
   (footprints shrink as 1/N, so a finished map covers each vertex about
   as often as the probe map would have with its planned count), at most
   the cap; P the threads' speed-up over the one-thread probe. (The square
   root fits measured k-nearest queries better than log m does: the top of
   the tree stays in cache.) The cap is pm's and spm's k, pdm's
   max_photons.

   The plan runs in rounds, so that what a busy machine does to the
   threads is measured rather than assumed:
   1. calibration (one thread) and probe (one thread: a probe of tens of
      milliseconds on one core is not at the mercy of the other threads'
      scheduling; a 1 ms probe on two threads of a busy machine planned no
      tracing at all) give the one-thread rate and the model, with P = the
      thread count;
   2. the threads trace for half the planned tracing time; the photons
      traced so far are probed again, on all threads (P = 1) at about
      4096 vertices (fewer for a cap above 50; tens of milliseconds), so
      that the model's figures come from a map about half the final size
      on the machine as it is loaded now; and the plan is made again, for
      the photons traced and the rest, at the threads' measured rate;
   3. the gather measures rather than models (pds__gather_run): on the
      final map, on all threads, it gathers about 2048 vertices, and if
      the rest at that pace would end after the budget, it measures a
      sample of a 64th of the vertices with a cap of 8 and takes the
      largest cap whose pace fits (at least min(8, cap): Jensen's fewest
      photons for an estimate), from the photons each query found
      (pds__gather_cap_fit). Only a gather that could not fit otherwise
      gets a lower cap, and the render reports the cap it used
      (gather_cap).
   Every probe and sample is of runs of neighbouring vertices, scattered
   over the image (pds__gather_sampled): queries of single vertices far
   apart ran two to five times slower than the gather they were to
   foretell, and the plan undershot by as much (pm, pdm and spm landed at
   0.55-0.76 of T). A probe builds its map once for all of its gathers
   (a build of the half-size map had been a sixth of a 3 s budget).
   When not even a cap of 8 fits, the gather will bound its search radius
   (step 3), and its cost is then that of the bounded queries, not of
   the model above: a probe's third gather, a cap of 8 within the tenth
   of the probe's 8th-photon distances (the last radius step 3 tries),
   measures it, and the plan traces for that cost (gather3_s / queried a
   query, with the same sqrt(log m) and P). (Before, tracing got half
   of what was left, and pm and spm landed at 0.81 of T on the
   reflection case at 1 s, 1.3-1.7 on the Cornell box at 512 x 512.)
   Whatever the model says, tracing gets a quarter of the budget at least
   (half when not even a cap of 8 fits and the bounded gather was not
   probed): a render without caustics is no answer (and misses show in
   the time the render reports). */
/* What the probe measured (all times in seconds). */
typedef struct pds__map_probe {
    double build_s, gather_s;  /* the probe map's build, its gather */
    double found;              /* photons one probe query returned, on average */
    double gather2_s, found2;  /* the same with a cap of 8 (0, 0: not probed) */
    double gather3_s;          /* the same within the bounded radius (0: not probed) */
    double map_photons;        /* photons the probe map held */
    double emitted;            /* photons emitted to fill it */
    double planned;            /* the photon count the calibration planned for */
    double queried;            /* eye vertices the probe gathered at */
    double parallel;           /* P: the gather's speed-up over the one-thread probe */
} pds__map_probe;

/* The model above: seconds to build a map of m stored photons and gather
   it at nv vertices with this cap. pdm: is the method pdm. bounded (and
   a probe of it): the gather of a cap of 8 within the radius the gather
   bounds its search by (step 3), at the probe's pace, gather3_s /
   queried a query, times the same sqrt(log m / log m_probe) / P. */
static double pds__map_cost(const pds__map_probe *p, int pdm, double cap, int bounded, size_t nv, double m)
{
    double lm = log(fmax(2.0, m)) / log(p->map_photons);
    double t1 = p->gather_s / p->queried, c0 = t1 / (1.0 + p->found), c1 = c0;
    double f = pdm ? fmin(cap, p->found * p->planned / p->emitted) : fmin(cap, m);
    if (bounded && p->gather3_s > 0.0) {
        c0 = p->gather3_s / p->queried;
        c1 = f = 0.0;
    } else if (p->found - p->found2 >= 0.5 * p->found && p->found2 > 0.0) {
        /* the line through the two probes, its slope and intercept >= 0 */
        double t2 = p->gather2_s / p->queried;
        c1 = fmax(0.0, (t1 - t2) / (p->found - p->found2));
        c0 = fmax(0.0, t1 - c1 * p->found);
    }
    return p->build_s * m / p->map_photons * fmax(1.0, lm) +
           (double)nv * (c0 + c1 * f) * sqrt(fmax(1.0, lm)) / (p->parallel > 0.0 ? p->parallel : 1.0);
}

/* The model solved: the seconds of further tracing, at `rate` photons per
   second, after which that tracing and the build and gather of nv
   vertices fill `remaining`, `traced` photons having been traced already
   (0 if even the map of those cannot be made in time). */
static double pds__map_plan(const pds__map_probe *p, int pdm, double cap, int bounded, size_t nv, double rate,
                            double traced, double remaining)
{
    double share = p->map_photons / p->emitted, lo = 0.0, hi = rate * remaining;
    int i;
    /* bisect for the further photon count n whose tracing and map fill the budget */
    for (i = 0; i < 60; i++) {
        double n = 0.5 * (lo + hi);
        if (n / rate + pds__map_cost(p, pdm, cap, bounded, nv, (traced + n) * share) > remaining) hi = n;
        else lo = n;
    }
    return lo / rate;
}

/* Steps 1 and 2: the seconds of further tracing, and in *cap_out the cap
   planned for: the requested one if the tracing then keeps a quarter of
   `left`, else the largest in [min(8, cap), cap] that does (a bisection
   over whole numbers: the tracing time falls as the cap grows); tracing
   at least a quarter of `left` + `traced_s` (the tracing done so far)
   minus `traced_s`. When not even the smallest cap keeps a quarter, the
   gather will bound its search radius (step 3): the tracing is then
   planned for that gather's cost as the probe measured it (gather3_s),
   or, not probed, given half of the time (its cost unknown). */
static double pds__map_tracing(const pds__map_probe *p, int pdm, double cap, size_t nv, double rate, double traced,
                               double traced_s, double left, double *cap_out)
{
    double lo = fmin(8.0, cap), hi = cap, floor_share = 0.25;
    int bounded = 0;
    if (pds__map_plan(p, pdm, hi, 0, nv, rate, traced, left) < 0.25 * left) {
        while (hi - lo > 1.0) {
            double mid = floor(0.5 * (lo + hi));
            if (pds__map_plan(p, pdm, mid, 0, nv, rate, traced, left) >= 0.25 * left) lo = mid;
            else hi = mid;
        }
        cap = lo;
        if (pds__map_plan(p, pdm, cap, 0, nv, rate, traced, left) < 0.25 * left) {
            if (p->gather3_s > 0.0) bounded = 1;
            else floor_share = 0.5;
        }
    }
    *cap_out = cap;
    return fmax(floor_share * (left + traced_s) - traced_s, pds__map_plan(p, pdm, cap, bounded, nv, rate, traced, left));
}

/* The cap a map method's gather is asked for: pm's and spm's k, pdm's
   max_photons. */
static double pds__map_cap_requested(const pds_options *opt)
{
    return (double)(opt->method == PDS_METHOD_PDM ? opt->max_photons : opt->k);
}

/* P of the model: the gather's threads over the probe's threads that had
   work, a chunk of PDS__GATHER_CHUNK of its nsub vertices each (pdm's
   probe of 384 vertices at a cap of 500 is one chunk, gathered by one
   thread: its pace, taken as both threads', foretold twice the gather's
   time on the Cornell box at 512 x 512, and pdm landed at 0.75 of T). */
static double pds__probe_parallel(int threads, int probe_threads, size_t nsub)
{
    size_t chunks = (nsub + PDS__GATHER_CHUNK - 1) / PDS__GATHER_CHUNK;
    int busy = probe_threads > 0 ? probe_threads : 1;
    if (chunks < (size_t)busy) busy = chunks > 0 ? (int)chunks : 1;
    return (double)threads / (double)busy;
}

/* The probes of steps 1 and 2: fill *p from one build of the photons
   stored so far (`emitted` emitted) and two gathers at about max_vertices
   of the eye vertices (runs of neighbours, pds__gather_sampled), with the
   cap and with a cap of 8, on probe_threads threads (of `threads`). The
   stored photons are left as they were; the caller throws the probes'
   images away. 0 if nothing could be measured (no photon stored, say). */
static int pds__map_probe_run(pds__photon_job *job, const pds_options *opt, const pds__eye_vertex *v, size_t nv,
                              int threads, int probe_threads, size_t max_vertices, double emitted,
                              pds__map_probe *p)
{
    size_t step = nv / max_vertices + 1, nsub = 0, i, nkept = 0;
    pds__eye_vertex *sub = (pds__eye_vertex *)malloc(sizeof *sub * (pds__gather_sample_count(nv, step) + 1));
    pds__stored_photon *kept = NULL; /* pm, spm: the stored photons, which a gather consumes */
    pds_error ignored;
    pds_status st = PDS_OK;
    int t, ok = 1;
    if (!sub) return 0;
    for (i = 0; i < nv; i++)
        if (pds__gather_sampled(i, step)) sub[nsub++] = v[i]; /* runs of neighbours, as the gather meets them */
    if (opt->method != PDS_METHOD_PDM) {
        for (t = 0; t < job->nbufs; t++) nkept += job->bufs[t].nstored;
        kept = (pds__stored_photon *)malloc(sizeof *kept * (nkept ? nkept : 1));
        for (t = 0, nkept = 0; kept && t < job->nbufs; t++) {
            if (job->bufs[t].nstored) memcpy(kept + nkept, job->bufs[t].stored, sizeof *kept * job->bufs[t].nstored);
            nkept += job->bufs[t].nstored;
        }
        if (!kept) ok = 0;
    }
    /* one map, gathered with the cap and (if it is above 8) with a cap of 8 */
    job->probe_k2 = pds__map_cap_requested(opt) > 8.0 ? 8 : 0;
    job->probe_s[1] = job->probe_found[1] = job->probe_s[2] = job->probe_found[2] = 0.0;
    job->build_s = job->gather_s = job->gather_found = 0.0;
    job->map_photons = 0;
    if (ok)
        st = opt->method == PDS_METHOD_PM    ? pds__pm_gather(job, opt, sub, nsub, probe_threads, NULL, &ignored)
             : opt->method == PDS_METHOD_SPM ? pds__spm_gather(job, opt, sub, nsub, probe_threads, NULL, &ignored)
                                             : pds__pdm_gather(job, opt, sub, nsub, probe_threads, NULL, &ignored);
    job->probe_k2 = 0;
    if (st || job->map_photons < 2 || nsub == 0) ok = 0;
    if (ok) {
        p->build_s = job->build_s;
        p->gather_s = job->probe_s[0];
        p->found = job->probe_found[0] / (double)nsub;
        p->gather2_s = job->probe_s[1];
        p->found2 = job->probe_found[1] / (double)nsub;
        p->gather3_s = job->probe_s[2];
        p->map_photons = (double)job->map_photons;
    }
    if (kept) {
        /* the stored photons as they were (in one thread's store) */
        for (t = 0; t < job->nbufs; t++) {
            free(job->bufs[t].stored);
            job->bufs[t].stored = NULL;
            job->bufs[t].nstored = job->bufs[t].cap_stored = 0;
        }
        job->bufs[0].stored = kept;
        job->bufs[0].nstored = job->bufs[0].cap_stored = nkept;
    }
    free(sub);
    p->emitted = emitted;
    p->planned = job->n_planned;
    p->queried = (double)nsub;
    p->parallel = pds__probe_parallel(threads, probe_threads, nsub);
    return ok;
}

#endif /* PDS_NO_BASELINES */

/* The paper's PDS under a time budget: N, the photon count of eqs. 5-6,
   must be fixed before the first photon, and a photon's cost depends on
   it. Its footprint covers s^2 A / N of the lit area A (eqs. 5-6), so the
   eye vertices it splats to, and the cost of its splat, fall as 1/N:
     cost per photon = a + b / N
   (a: emission and tracing; b: all N splats of a render together, which
   with s fixed cost the same whatever N is). Two calibration batches on
   one thread, for N1 = 4 opt->photons and N2 = N1 / q photons, took t1
   and t2 seconds a photon (q = 4 when the first batch took at most a
   fortieth of the budget, else less, so that neither batch takes much
   more than a tenth of it: q = 0.1 T / (B t1); no second batch below
   q = 1.5, whose t2 is then taken as if nine tenths of the first were
   splats);
   solved for a and b (a at least a tenth of t1, b at least 0), tracing and
   splatting N photons on `threads` threads fills `left` seconds when
     N a + b = left threads,  N = (left threads - b) / a.
   When the splats alone (b) take more than three quarters of that, the
   smoothing cannot be held in the budget: N is then set as if tracing had
   a quarter of it, and the deadline stops the photons early (the render
   reports the photons emitted and the count planned, whose ratio is the
   footprints' share of s^2). The deadline is looked at between batches
   (PDS__PHOTON_BATCH photons on one thread), so N is at least the count
   whose batch, B (a + b / N), takes an eighth of `left`:
     N >= B b / (left / 8 - B a)
   (at 512 x 512 the quarter rule planned 6,132 photons for 0.22 s, whose
   batches of huge footprints took 1.3 s each: 3.4 s for a 1 s budget). */
static double pds__pds_plan(double t1, double n1, double t2, double n2, double left, int threads)
{
    double b = fmax(0.0, (t2 - t1) / (1.0 / n2 - 1.0 / n1)), a = fmax(0.1 * t1, t1 - b / n1);
    double cpu = left * (threads > 0 ? threads : 1), batch = (double)PDS__PHOTON_BATCH;
    double n = (cpu - b >= 0.25 * cpu ? cpu - b : 0.25 * cpu) / a;
    if (left / 8.0 > batch * a) n = fmax(n, batch * b / (left / 8.0 - batch * a));
    return n;
}

/* --- the photon pass --------------------------------------------------- */

/* After the eye pass: emit and trace the caustic photons for method m,
   the part's photon units that are not done yet (>>partial), and add the
   caustic light into the part's exact sums (importance already carries
   1/spp). debug, if not NULL, receives the teaching views it asks for
   (>>debug; a render in one go only). rounds, if not NULL, are the eye
   rounds progressive PDS may trace (pds__pds_passes; vertices are then
   round rounds->round's, owned by rounds->ctx, which frees them when a
   round replaces them). */
static pds_status pds__photon_pass(const pds_scene *s, const pds_options *opt, pds__eye_vertex *vertices,
                                   size_t nvertices, int width, int height, int threads, pds_partial *part,
                                   pds_debug *debug, const pds__eye_rounds *rounds, pds_render_stats *stats,
                                   pds_error *err)
{
    pds__eye_map map;
    pds__photon_job job;
    size_t npix = (size_t)width * (size_t)height, i;
    long emitted = 0;
    int t, splats = opt->method == PDS_METHOD_PDS || opt->method == PDS_METHOD_SPLAT;
    int progressive = opt->method == PDS_METHOD_PDS && opt->progressive;
    pds_status st = PDS_OK;
    double t0 = pds_time_now();
    pds__debug_buf *dbg = NULL;          /* one per thread, if debug views are on */
    pds__path_rec *paths = NULL;         /* one per thread, if the paths view is on */
    double rate1 = 0.0;                  /* a time budget: photons a second on one thread */
#ifndef PDS_NO_BASELINES
    pds__map_probe probe, probe2;        /* pm, pdm, spm under a time budget: the plan's model */
    int map_method = opt->method == PDS_METHOD_PM || opt->method == PDS_METHOD_PDM || opt->method == PDS_METHOD_SPM;
    int map_planned = 0;                 /* ... made from a probe */
    double cap = pds__map_cap_requested(opt);
    memset(&probe, 0, sizeof probe);
#endif
    memset(&map, 0, sizeof map);
    memset(&job, 0, sizeof job);
    map.v = vertices;
    map.n = nvertices;
    if (splats) {
        st = pds__eye_map_build(&map, err);
        if (st) return st;
    }
    if (rounds && progressive) {
        /* eye rounds (pds__pds_passes) */
        job.retrace = rounds->retrace;
        job.retrace_ctx = rounds->ctx;
        job.eye_rounds = rounds->rounds;
        job.eye_round = rounds->round;
        job.eye_round_s = rounds->eye_s + (pds_time_now() - t0);
    }
    job.scene = s;
    job.map = &map;
    job.target = pds__specular_target(s);
    job.seed = opt->seed;
    job.smoothing = opt->smoothing;
    job.plane_tolerance = opt->plane_tolerance;
    job.min_aspect = progressive ? opt->pass_min_aspect : opt->min_aspect;
    job.defocus_widen = progressive && job.min_aspect > 0.0;
    job.min_width = progressive ? opt->pass_min_width : opt->method == PDS_METHOD_PDS ? opt->min_width : 0.0;
    job.eye = pds__v(s->camera.position.x, s->camera.position.y, s->camera.position.z);
    job.frame = pds__camera_setup(&s->camera, width, height);
    job.sample_angle = 2.0 * tan(0.5 * s->camera.fov_deg * PDS__PI / 180.0) / height /
                       sqrt((double)(opt->spp > 0 ? opt->spp : s->camera.spp > 0 ? s->camera.spp : 1));
    job.eps = 1e-6 * pds__scene_scale(s);
    job.max_depth = opt->photon_depth;
    if (opt->method == PDS_METHOD_PDS && progressive) {
        job.split_depth = opt->split_depth;
        job.split_angle = opt->split_angle;
        job.roulette_vertices = PDS__SPLAT_ROULETTE;
    }
#ifndef PDS_NO_BASELINES
    job.n_total = opt->method == PDS_METHOD_SPM ? pds__spm_streams(opt) : opt->photons;
#else
    job.n_total = opt->photons;
#endif
    job.n_planned = (double)job.n_total;
    job.caller = pds__thread_self();
    job.progress = opt->progress;
    job.progress_user = opt->progress_user;
    job.t0 = t0;
#ifdef PDS_NO_BASELINES
    job.land = pds__defer_splat; /* pds alone (pds__options_check) */
#else
    job.land = splats ? pds__defer_splat : opt->method == PDS_METHOD_PDM ? pds__store_diff_photon : pds__store_photon;
    if (opt->method == PDS_METHOD_SPLAT) job.fixed_radius = opt->radius > 0.0 ? opt->radius : pds__default_radius(s);
#endif
    job.differentials = opt->method == PDS_METHOD_PDS || opt->method == PDS_METHOD_PDM;
    job.spectral = pds__render_is_spectral(s, opt);
    job.spectral_all = job.spectral && opt->spectral;
    job.nbufs = threads;
    job.bufs = (pds__splat_buf *)calloc((size_t)threads, sizeof *job.bufs);
    if (!job.bufs) {
        pds__kdtree_free(&map.tree);
        pds__kdtree_free(&map.merged);
        return pds__nomem(err);
    }
    if (debug && (debug->views & ~(1u << PDS_DEBUG_EYE) & ~(1u << PDS_DEBUG_PATHS))) {
        dbg = (pds__debug_buf *)calloc((size_t)threads, sizeof *dbg);
        if (!dbg) st = PDS_ERR_NOMEM;
    }
    if (pds__debug_wants(debug, PDS_DEBUG_PATHS)) {
        paths = (pds__path_rec *)calloc((size_t)threads, sizeof *paths);
        if (!paths) st = PDS_ERR_NOMEM;
    }
    for (t = 0; t < threads; t++) {
        job.bufs[t].sum = (pds__sum128 *)calloc(npix * 3, sizeof(pds__sum128));
        job.bufs[t].unit = pds__sum_unit(s);
        if (job.spectral) job.bufs[t].neg = (pds__sum128 *)calloc(npix * 3, sizeof(pds__sum128));
        if (!job.bufs[t].sum || (job.spectral && !job.bufs[t].neg)) st = PDS_ERR_NOMEM;
        if (dbg) {
            job.bufs[t].dbg = &dbg[t];
            if (!pds__debug_bufs_init(&dbg[t], s, debug, opt->method, opt->photons, npix)) st = PDS_ERR_NOMEM;
        }
        if (paths) {
            job.bufs[t].path = &paths[t];
            paths[t].photon_end = debug->path_photons;
        }
    }
    job.unit_stride = 1;
    job.nsums = npix * 3;
#ifndef PDS_NO_BASELINES
    if (!st && opt->method == PDS_METHOD_PPM) {
        st = pds__ppm_passes(&job, opt, vertices, nvertices, threads, &emitted, stats, err);
        job.n_planned = (double)emitted; /* the passes normalised their image themselves */
    } else
#endif
    if (!st && progressive) {
        long passes = 0;
        job.progress = NULL; /* the passes report progress themselves */
        emitted = pds__pds_passes(&job, &map, opt, threads, opt->time_s > 0.0 ? t0 + opt->time_s : 0.0,
                                  part->shard_index, part->shard_count, part->units_done, &passes, &st, err);
        job.progress = opt->progress;
        part->units_done += opt->time_s > 0.0 ? part->units_own - part->units_done : passes;
        if (stats) stats->passes = (int)(passes < INT_MAX ? passes : INT_MAX);
        for (t = 0; t < job.nbufs; t++)
            if (job.bufs[t].out_of_memory) st = PDS_ERR_NOMEM;
    } else if (!st && opt->time_s > 0.0) {
        /* PDS: the photon count enters eqs. 5-6, so it must be fixed before
           the first photon: time a calibration run of two batches (thrown
           away) and plan for the rate it shows over the remaining time.
           For every method the image is normalised by the photons actually
           emitted before the deadline. */
        double tc = pds_time_now(), remaining, rate, t_1 = 0.0, t_2, n_1 = 4.0 * (double)opt->photons, n_2 = 0.0, q;
        int paper = opt->method == PDS_METHOD_PDS; /* (not progressive: that branch is above) */
        int second = 1;                             /* run the second calibration batch */
        pds__mutex_init(&job.lock);
        job.n_total = 2 * PDS__PHOTON_BATCH;
        job.next_buf = 0;
        job.progress = NULL; /* the calibration is not the pass the caller waits for */
        if (paper) {
            /* the paper's PDS (pds__pds_plan): the first batch for four
               times opt->photons (small footprints: the cheaper one), the
               second for fewer (below) */
            job.n_total = PDS__PHOTON_BATCH;
            job.n_planned = n_1;
            pds__run_threads(1, pds__photon_worker, &job);
            t_1 = pds_time_now() - tc;
            /* the second batch's footprints q times the first's (q <= 4),
               so that it too takes about a tenth of the budget at most
               (all splats: q times t_1); none below q = 1.5, too near
               the first to tell a from b */
            q = fmin(4.0, 0.1 * opt->time_s / fmax(t_1, 1e-9));
            second = q >= 1.5;
            n_2 = n_1 / q;
            job.n_total = 2 * PDS__PHOTON_BATCH;
            job.n_planned = n_2;
            job.next_batch = 1; /* the run above counted past it */
            job.stop = 0;
            job.next_buf = 0;
        }
        if (second) pds__run_threads(1, pds__photon_worker, &job);
        job.progress = opt->progress;
        pds__mutex_destroy(&job.lock);
        t_2 = pds_time_now() - tc - t_1;
        /* no second batch: as if a tenth of the first were tracing and the
           rest splats, at opt->photons four times as costly */
        if (!second) t_2 = t_1 * (0.1 + 0.9 * 4.0);
        rate1 = (double)job.n_total / fmax(pds_time_now() - tc, 1e-6);
        rate = rate1 * threads;
        remaining = opt->time_s - (pds_time_now() - t0);
#ifndef PDS_NO_BASELINES
        if (map_method) {
            /* the plan's step 1 (see pds__map_probe) */
            /* 8192 vertices for a cap of 50, fewer for a larger cap (on
               the calibration's few photons a pdm query finds all of
               them: 8192 queries at a cap of 500 took half of a 1 s
               budget at 512 x 512) */
            map_planned = pds__map_probe_run(&job, opt, vertices, nvertices, threads, 1,
                                             (size_t)fmin(8192.0, fmax(512.0, 409600.0 / cap)), (double)job.n_total,
                                             &probe);
            remaining = opt->time_s - (pds_time_now() - t0);
            if (map_planned)
                remaining = pds__map_tracing(&probe, opt->method == PDS_METHOD_PDM, cap, nvertices, rate, 0.0, 0.0,
                                             fmax(remaining, 0.0), &cap);
        }
#endif
        for (t = 0; t < threads; t++) {
            memset(job.bufs[t].sum, 0, npix * 3 * sizeof(pds__sum128));
            if (job.bufs[t].neg) memset(job.bufs[t].neg, 0, npix * 3 * sizeof(pds__sum128));
            if (dbg) pds__debug_bufs_clear(&dbg[t], npix);
            if (paths) paths[t].n = 0;
            job.bufs[t].splatted = job.bufs[t].degenerate = job.bufs[t].saturated = job.bufs[t].invalid = 0;
            job.bufs[t].nstored = job.bufs[t].ndstored = 0;
        }
        job.n_planned = fmax(rate * fmax(remaining, 0.0), (double)PDS__PHOTON_BATCH);
        if (paper)
            job.n_planned = fmax(pds__pds_plan(t_1 / PDS__PHOTON_BATCH, n_1, t_2 / PDS__PHOTON_BATCH,
                                               second ? n_2 : (double)opt->photons, fmax(remaining, 0.0), threads),
                                 (double)PDS__PHOTON_BATCH);
        job.n_total = LONG_MAX - PDS__PHOTON_BATCH;
        job.deadline = pds_time_now() + fmax(remaining, 0.0);
        if (remaining <= 0.0 || job.n_planned <= (double)PDS__PHOTON_BATCH) {
            /* no time left (the calibration or pdm's gather alone can fill
               a small budget): one batch, so the image still has caustics,
               and say so in time; PDS's for 16 times opt->photons (small
               footprints: cheap splats) */
            job.n_total = PDS__PHOTON_BATCH;
            job.deadline = 0.0;
            if (paper) job.n_planned = 16.0 * (double)opt->photons;
        }
        job.next_batch = job.batches_done = 0;
        job.stop = 0;
    }
    if (!st && opt->method != PDS_METHOD_PPM && !progressive) {
        if (splats && opt->time_s <= 0.0) {
            /* this part's batches (>>partial) */
            job.unit_first = part->shard_index;
            job.unit_stride = part->shard_count;
            job.unit_start = part->units_done;
            job.own_batches = part->units_own - part->units_done;
        }
        pds__mutex_init(&job.lock);
        job.next_buf = 0;
#ifndef PDS_NO_BASELINES
        if (map_planned && job.deadline > 0.0) {
            /* the plan's step 2: half the tracing, then plan again from
               the threads' measured rate (not for the one batch of no
               time left) */
            double tr = pds_time_now(), tracing = job.deadline - tr, round_s, traced, rate_all, left;
            job.deadline = tr + 0.5 * tracing;
            pds__run_threads(threads, pds__photon_worker, &job);
            round_s = pds_time_now() - tr;
            traced = (double)job.batches_done * PDS__PHOTON_BATCH;
            rate_all = traced / fmax(round_s, 1e-6);
            /* the model again, from the map of the photons traced so far
               and a gather (its images thrown away) at 4096 vertices for a
               cap of 50, fewer for a larger cap (a query of pdm's 500 can
               take a hundred of pm's, 466 us on the Cornell box at 512 x
               512; a query far from every photon, 200 us; at least 256),
               on all threads, so that the pace is the threads' on the
               machine as loaded now (tens of milliseconds: long enough
               to measure) */
            if (!job.cancelled &&
                pds__map_probe_run(&job, opt, vertices, nvertices, threads, threads,
                                   (size_t)fmax(256.0, 204800.0 / pds__map_cap_requested(opt)), traced, &probe2))
                probe = probe2;
            pds__gather_clear(&job, job.nsums);
            left = opt->time_s - (pds_time_now() - t0);
            tracing = pds__map_tracing(&probe, opt->method == PDS_METHOD_PDM, pds__map_cap_requested(opt),
                                       nvertices, rate_all, traced, round_s, fmax(left, 0.0), &cap);
            job.deadline = pds_time_now() + fmax(tracing, 0.0);
            job.stop = 0;
            job.next_buf = 0;
        }
        if (!job.cancelled)
#endif
            threads = pds__run_threads(threads, pds__photon_worker, &job);
        pds__mutex_destroy(&job.lock);
        if (splats && opt->time_s <= 0.0) {
            long j;
            emitted = 0;
            for (j = 0; j < job.batches_done; j++) {
                long b = job.unit_first + (job.unit_start + j) * job.unit_stride;
                emitted += job.n_total - b * (long)PDS__PHOTON_BATCH < PDS__PHOTON_BATCH
                               ? job.n_total - b * (long)PDS__PHOTON_BATCH
                               : PDS__PHOTON_BATCH;
            }
            part->units_done += job.batches_done;
        } else {
            emitted = job.batches_done * (long)PDS__PHOTON_BATCH;
            if (emitted > job.n_total) emitted = job.n_total;
            if (opt->time_s > 0.0) part->units_done = part->units_own;
        }
        for (t = 0; t < job.nbufs; t++)
            if (job.bufs[t].out_of_memory) st = PDS_ERR_NOMEM;
    }
    if (!splats && job.cancelled) emitted = 0; /* pm, pdm, ppm, spm: all photons or none */
    if (opt->progress && !splats && !job.cancelled)
        (void)opt->progress(opt->progress_user, PDS_PHASE_GATHER, 0.0, pds_time_now() - t0); /* one unit: not stopped */
#ifndef PDS_NO_BASELINES
    /* the plan's step 3: the gather measures its cap on the final map */
    if (map_method && opt->time_s > 0.0) job.gather_deadline = t0 + opt->time_s;
    job.gather_k = (size_t)pds__map_cap_requested(opt);
    if (!st && !job.cancelled && opt->method == PDS_METHOD_PM)
        st = pds__pm_gather(&job, opt, vertices, nvertices, threads, stats, err);
    if (!st && !job.cancelled && opt->method == PDS_METHOD_PDM)
        st = pds__pdm_gather(&job, opt, vertices, nvertices, threads, stats, err);
    if (!st && !job.cancelled && opt->method == PDS_METHOD_SPM)
        st = pds__spm_gather(&job, opt, vertices, nvertices, threads, stats, err);
    if (stats && map_method) {
        stats->gather_cap = (long)job.gather_k;
        stats->gather_radius = job.gather_radius;
    }
#endif
    if (!st && !splats && !job.cancelled) part->units_done = part->units_own;
    if (!st && stats &&
        (opt->method == PDS_METHOD_PM || opt->method == PDS_METHOD_PDM || opt->method == PDS_METHOD_SPM)) {
        stats->time_map_s = job.build_s;
        stats->time_gather_s = job.gather_s;
    }
    if (!st) {
        /* The sums are exact and order-free: the part's are their sum.
           The photons were weighted for n_planned; the image divides by
           the count actually emitted (pds__partial_image). */
        long saturated = 0;
        if (!job.cancelled || splats)
            for (i = 0; i < npix * 3; i++)
                for (t = 0; t < job.nbufs; t++) {
                    saturated += pds__sum128_add_bits(&part->photon[i], job.bufs[t].sum[i].lo, job.bufs[t].sum[i].hi);
                    if (job.spectral)
                        saturated += pds__sum128_add_bits(&part->neg[i], job.bufs[t].neg[i].lo, job.bufs[t].neg[i].hi);
                }
        /* the count the photons were weighted for, as the pass set it (the
           same in every shard: the options fix it) */
        if (opt->time_s > 0.0 || (!splats && !job.cancelled)) part->n_planned = job.n_planned;
        if (splats) part->emitted += emitted;
        else part->emitted = emitted;
        if (dbg) {
            /* the ellipses are drawn over the image so far (a render in
               one go: the part is the whole render, its eye rows done) */
            float *img = (float *)malloc(sizeof *img * 3 * (npix ? npix : 1));
            double *rgb = (double *)malloc(sizeof *rgb * 3 * (npix ? npix : 1));
            if (!img || !rgb ||
                pds__partial_image(part->eye, part->photon, part->neg, part->unit, part->n_planned, part->emitted,
                                   npix * 3, img) < 0)
                st = PDS_ERR_NOMEM;
            for (i = 0; !st && i < npix * 3; i++) rgb[i] = img[i];
            if (!st && pds__debug_finish(debug, dbg, job.nbufs, width, height, rgb, &job.frame)) st = PDS_ERR_NOMEM;
            free(img);
            free(rgb);
        }
        if (!st && paths) {
            /* the threads' events, merged in photon and vertex order */
            size_t total = 0, k;
            pds__path_event *all;
            for (t = 0; t < job.nbufs; t++) {
                if (paths[t].out_of_memory) st = PDS_ERR_NOMEM;
                total += paths[t].n;
            }
            all = (pds__path_event *)malloc(sizeof *all * (total ? total : 1));
            if (!all) st = PDS_ERR_NOMEM;
            for (t = 0, k = 0; !st && t < job.nbufs; t++) {
                if (paths[t].n) memcpy(all + k, paths[t].ev, sizeof *all * paths[t].n);
                k += paths[t].n;
            }
            if (!st) {
                qsort(all, total, sizeof *all, pds__path_event_cmp);
                debug->paths_obj = pds__paths_obj(all, total, &debug->paths, &debug->path_segments);
                if (!debug->paths_obj) st = PDS_ERR_NOMEM;
            }
            free(all);
        }
        if (!st && pds__debug_wants(debug, PDS_DEBUG_EYE) &&
            pds__debug_eye(debug, s, &job.frame, vertices, nvertices, width, height))
            st = PDS_ERR_NOMEM;
        if (stats) {
            if (opt->method != PDS_METHOD_PPM) stats->photons = emitted;
            stats->photons_planned = job.n_planned;
            if (opt->method == PDS_METHOD_SPM) {
                /* a stream stands for its leader and nfa associated photons */
                stats->streams = emitted;
                stats->photons = emitted * ((long)opt->stream_photons + 1);
            }
            stats->eye_vertices = (long)nvertices;
            stats->saturated += saturated;
            for (t = 0; t < job.nbufs; t++) {
                if (opt->method != PDS_METHOD_PM && opt->method != PDS_METHOD_PPM && opt->method != PDS_METHOD_SPM)
                    stats->splatted += job.bufs[t].splatted;
                stats->dropped_degenerate += job.bufs[t].degenerate;
                stats->split += job.bufs[t].split;
                stats->saturated += job.bufs[t].saturated;
                stats->dropped_invalid += job.bufs[t].invalid;
            }
            stats->time_photons_s = pds_time_now() - t0;
            stats->memory_bytes += nvertices * sizeof *vertices + pds__kdtree_memory(&map.tree) + pds__kdtree_memory(&map.merged) + stats->map_bytes +
                                   (size_t)job.nbufs * npix * (3 + (dbg && dbg[0].aniso ? 2 : 0) + (job.spectral ? 3 : 0)) *
                                       sizeof(pds__sum128);
        }
    }
    for (t = 0; t < job.nbufs; t++) {
        free(job.bufs[t].sum);
        free(job.bufs[t].neg);
        if (dbg) pds__debug_bufs_free(&dbg[t]);
        if (paths) free(paths[t].ev);
        free(job.bufs[t].stored);
        free(job.bufs[t].dstored);
        free(job.bufs[t].pending);
    }
    free(job.bufs);
    free(dbg);
    free(paths);
    pds__kdtree_free(&map.tree);
    pds__kdtree_free(&map.merged);
    if (st == PDS_ERR_NOMEM) return pds__nomem(err);
    return st;
}

/* --- light tracing: the references' estimator --------------------------
   A reference for caustics seen directly must not come from a density
   estimate: every kernel, however small, blurs the focal lines, and a
   progressive photon map from a radius of a pixel is still 0.02-0.05 off
   (RMSE) on the refraction case's. Light tracing (the t = 1 strategy of
   bidirectional path tracing, Veach 1997, sect. 10.2) has no kernel: each
   caustic photon that lands where the pinhole camera sees it directly
   goes into the pixel it projects to, so the pixel is the exact box
   filter of the caustic, with noise only. A pixel's value is
     (1 / A_pix) integral over the pixel of L du
       = sum over photons p of f_r(wi, wo) Phi_p (du/dA)(x_p) / A_pix,
   du/dA = |cos theta_o| / (d^2 cos^3 theta_c): a surface patch dA at
   distance d, seen at theta_o from its normal, subtends the solid angle
   dA |cos theta_o| / d^2, which covers dOmega / cos^3 theta_c of the
   image plane at distance 1 at theta_c from the axis; A_pix is a pixel's
   area on that plane, (2 tan(fov/2) aspect / W)(2 tan(fov/2) / H).
   Caustics seen through glass or in a mirror get nothing (the view from
   the camera must meet the landing point first). Used by
   tests/ref_light.c to make the shipped references. */
static void pds__light_bin(const pds__photon_job *job, pds__splat_buf *buf, const pds__ray_diff *r, pds__v3 ng,
                           const double flux[3], double lambda, long photon)
{
    const pds__camera_frame *f = &job->frame;
    pds__v3 d = pds__sub(r->p, f->origin), wo;
    double dist = pds__length(d), depth = pds__dot(d, f->forward), cosc, jac, e[3], w[3], one[3] = {1.0, 1.0, 1.0};
    double apix = 4.0 * f->tan_half_fov * f->tan_half_fov * f->aspect / ((double)f->width * f->height);
    long px = pds__camera_pixel(f, r->p);
    pds__tri_hit th;
    pds_hit hit;
    pds__eye_vertex v;
    int c;
    (void)ng;
    (void)photon;
    if (px < 0 || !(depth > 0.0) || !(dist > 0.0)) return;
    /* the camera's ray to the landing point meets it first */
    if (!pds__bvh_intersect(&job->scene->bvh, f->origin, d, 0.0, 1.0 + 1e-4, &th) || th.t < 1.0 - 1e-4) return;
    pds__scene_fill_hit(job->scene, &th, f->origin, d, &hit);
    wo = pds__scale(d, -1.0 / dist);
    memset(&v, 0, sizeof v);
    if (!pds__eye_vertex_set(&v, &job->scene->materials.items[hit.material], r->p, hit.ns, hit.ng, wo, one,
                             hit.material))
        return;
    for (c = 0; c < 3; c++) e[c] = flux[c];
    if (!pds__eye_response(job->scene, &v, pds__scale(r->d, -1.0), lambda, e, w)) return;
    cosc = depth / dist;
    jac = fabs(pds__dot(hit.ng, wo)) / (dist * dist * cosc * cosc * cosc) / apix;
    for (c = 0; c < 3; c++) {
        double val = w[c] * e[c] * jac;
        if (val != 0.0) pds__image_add(buf, 3 * (size_t)px + (size_t)c, val);
    }
}

/* The caustics-only image of scene at width x height seen directly, by
   light tracing opt->photons caustic photons (opt->seed, opt->threads,
   opt->photon_depth; RGB or spectral as a render of opt would be): the
   same bits for any thread count (pds_render_light_traced). */
static pds_status pds__light_trace_image(const pds_scene *s, const pds_options *opt, int width, int height,
                                         pds_image *out, pds_error *err)
{
    pds__photon_job job;
    size_t npix = (size_t)width * (size_t)height, i;
    int threads = opt->threads > 0 ? opt->threads : pds_cpu_count(), t;
    pds_status st = PDS_OK;
    memset(&job, 0, sizeof job);
    job.scene = s;
    job.target = pds__specular_target(s);
    job.seed = opt->seed;
    job.eps = 1e-6 * pds__scene_scale(s);
    job.max_depth = opt->photon_depth;
    job.n_total = opt->photons;
    job.n_planned = (double)opt->photons;
    job.frame = pds__camera_setup(&s->camera, width, height);
    job.eye = pds__v(s->camera.position.x, s->camera.position.y, s->camera.position.z);
    job.land = pds__light_bin;
    job.spectral = pds__render_is_spectral(s, opt);
    job.spectral_all = job.spectral && opt->spectral;
    job.unit_stride = 1;
    job.nsums = npix * 3;
    job.caller = pds__thread_self();
    job.t0 = pds_time_now();
    job.nbufs = threads;
    job.bufs = (pds__splat_buf *)calloc((size_t)threads, sizeof *job.bufs);
    if (!job.bufs) return pds__nomem(err);
    for (t = 0; t < threads; t++) {
        job.bufs[t].sum = (pds__sum128 *)calloc(npix * 3, sizeof(pds__sum128));
        job.bufs[t].neg = (pds__sum128 *)calloc(npix * 3, sizeof(pds__sum128));
        job.bufs[t].unit = pds__sum_unit(s);
        if (!job.bufs[t].sum || !job.bufs[t].neg) st = PDS_ERR_NOMEM;
    }
    if (!st) {
        pds__mutex_init(&job.lock);
        pds__run_threads(threads, pds__photon_worker, &job);
        pds__mutex_destroy(&job.lock);
        st = pds_image_alloc(out, width, height);
    }
    if (!st) {
        /* the threads' exact sums into the first's, and the image from them
           as a render's (no eye part; every photon planned was emitted) */
        double *zero = (double *)calloc(npix * 3, sizeof *zero);
        for (i = 0; i < npix * 3; i++)
            for (t = 1; t < threads; t++) {
                pds__sum128_add_bits(&job.bufs[0].sum[i], job.bufs[t].sum[i].lo, job.bufs[t].sum[i].hi);
                pds__sum128_add_bits(&job.bufs[0].neg[i], job.bufs[t].neg[i].lo, job.bufs[t].neg[i].hi);
            }
        if (!zero || pds__partial_image(zero, job.bufs[0].sum, job.bufs[0].neg, job.bufs[0].unit, (double)opt->photons,
                                        opt->photons, npix * 3, out->rgb) < 0)
            st = PDS_ERR_NOMEM;
        free(zero);
        if (st) pds_image_free(out);
    }
    for (t = 0; t < threads; t++) {
        free(job.bufs[t].sum);
        free(job.bufs[t].neg);
        free(job.bufs[t].pending);
    }
    free(job.bufs);
    if (st == PDS_ERR_NOMEM) return pds__nomem(err);
    return st;
}

#ifndef PDS_NO_GI
/* ===================================================================== */
/* >>gi                                                                  */
/* ===================================================================== */
/* Jensen's two-pass global illumination (H. W. Jensen, "Global
   illumination using photon maps", Eurographics Rendering Workshop 1996),
   with the caustics from any caustic method above (progressive PDS by
   default).

   The rendering equation's reflected radiance is split by where the light
   came from (Jensen's eq. 2): Lr = direct (light sources) + caustics
   (light sources via specular surfaces) + soft indirect light (light that
   was reflected by a non-specular surface at least once). At the first
   non-specular vertex x1 of an eye path (reached from the eye through
   mirrors and glass, as in every method here):
   - Le: an emitter seen through the specular chain ends the path.
   - direct: one light sample (next-event estimation), its shadow ray
     skipped where the shadow photons decide it (sect. 4.1, below).
   - caustics (L S+ x1): the caustic method's estimate at the eye vertex
     x1, exactly as in the photon methods (>>pds, >>baselines).
   - indirect: a final gather (sect. 4.4): rays from x1, importance
     sampled from the incoming directions of the global map's photons
     near x1 (Jensen 1995, "Importance driven path tracing using the
     photon map"); each follows specular surfaces to the first
     non-specular x2 and returns the light leaving x2 towards x1, which
     ends the recursion (below).
     A gather ray that meets an emitter brings direct light (counted by
     the light sample) or a caustic (counted by the caustic method) and
     adds nothing, except at a glossy x1 (below).
   The four parts partition the light reflected at x1, so the image is
   complete: a caustic seen after a further diffuse bounce (L S+ D D E)
   comes through the gather.

   At x2 the light is split once more, by the vertex before x2 on the
   light path (x2 = D, any non-specular vertex):
   - L x2 (no vertex between the light and x2): one light sample with its
     shadow ray, as at x1 (at a glossy x2 weighted by MIS against one
     BSDF sample that meets the emitter);
   - L (S|D)* S x2 (a caustic on x2) and L (S|D)* D x2 (light that left
     a non-specular surface before): the global map's radiance estimate
     (eq. 3 with the cone filter, eq. 4, k = 1), or on a Lambertian x2
     the irradiance precomputed at the map's photons (Christensen 1999,
     below) where that pays. The map leaves out the direct photons (a
     photon's first hit, L D), so it holds exactly these paths.
   Jensen lets the estimate at x2 answer for all of it; that blurs the
   direct light, usually the largest part, by the estimate's disc and
   darkens it wherever the disc leaves the surface (corners, edges), and
   no number of camera samples removes that bias. Now the map's blur
   touches only light that was reflected or refracted on its way, a
   smaller and smoother share. Every eye path is thus split as
       E S* x1 ...: x1 = D, then
         L x1                      the light sample at x1
         L S+ x1                   the caustic method at x1
         L x2 S* x1                the light sample at x2 (gather)
         L (S|D)* (S|D) x2 S* x1   the global map at x2 (gather), but
                                   where the gather ray is short (Jensen's
                                   rule, pds__gi_bounce_on):
           L (S|D)* S x2             the map's caustic photons at x2
           L x3 x2                   one more bounce: x3's light sample
           L (S|D)* (S|D) x3 x2      ... and the global map at x3
       E S* L                      the emitter seen through the chain
   and each path L (S|D)* E is counted in exactly one line. A map of
   streams (global_map = PDS_GLOBAL_STREAMS, seed paper 003's system)
   keeps its direct streams, and there the estimate at x2 answers for
   all of the light leaving x2, as in Jensen's method.

   Glossy x1: its gather rays sample the GGX BRDF instead (Jensen treats
   highly glossy surfaces by Monte Carlo ray tracing, sect. 4.2), and
   direct light is combined from the light sample and the gather rays
   that hit an emitter straight away, by multiple importance sampling
   (Veach 1997, power heuristic with the sample counts). At x2 the map's
   part of a glossy surface is its estimate with its own BRDF: the
   indirect light on smooth glossy surfaces seen only in a gather is
   blurred by the density estimate (Jensen notes the same, sect. 5).

   Pass 1, the global photon map (sect. 3): photons leave the lights with
   the lights' own emission (not aimed), are stored at every non-specular
   hit but their first (at most PDS__GI_MAX_STORES per photon; a map of
   streams stores the first too) and continue by the BSDF
   with Russian roulette by the albedo: survive with q = the largest
   channel of the sampled weight (capped at 1), the flux divided by q, so
   stored flux stays of the same size. Specular surfaces reflect and
   refract them with their Fresnel choice and Beer absorption, so the
   map holds caustic photons too (for x2; at x1 the caustic method
   answers).

   Shadow photons (sect. 3, Fig. 1, after Jensen and Christensen 1995):
   the first ray of each global photon is followed through the whole
   scene: its first hit, if non-specular, stores a direct photon, every
   later non-specular hit a shadow photon (at most PDS__GI_MAX_SHADOW),
   each marked with its light. A light sample at x looks at the nearest
   PDS__GI_SHADOW_K of them from that light on x's side: if there are at
   least 8, all of one kind, and no photon of the other kind lies within
   twice their radius, the sample is taken as lit (direct photons) or
   blocked (shadow photons) without a shadow ray; otherwise (a mixture,
   a penumbra, or too few) the shadow ray is traced. The margin keeps the
   decision away from shadow boundaries; it is a heuristic (so is
   Jensen's), measured by the test that compares it with shadow rays
   everywhere. Delta-light shadows are exact on either side.

   Streams (global_map = PDS_GLOBAL_STREAMS): the global map of streamed
   photon mapping (seed paper 003, >>streams), where its streams mean
   something: their leaders first meet diffuse surfaces. See "streams in
   the global map" below.

   Spectral renders (>>spectral): global photons carry wavelengths and
   turn spectral at their first dispersive material, as caustic photons
   do; the eye paths and gather rays as the other methods' eye paths
   ("gi's rays in spectral renders" below).

   Determinism: global photon i is a pure function of (seed, i) (Halton
   points for its emission, PDS__RNG_GLOBAL for its bounces); threads
   take fixed batches and the stores are sorted by (photon, order) before
   the kd-trees are built, so the maps do not depend on the thread count.
   The eye pass draws its gather and light samples from (seed, camera
   sample), like the path tracer. */

#define PDS__GI_MAX_STORES 8   /* global-map photons one emitted photon stores, at most */
#define PDS__GI_MAX_SHADOW 4   /* shadow photons one emitted photon stores, at most */
#define PDS__GI_MAX_K 1000     /* largest global_k */
#define PDS__GI_GRID 8         /* gather directions: 8 x 8 cells of the cosine-mapped square */
#define PDS__GI_GUIDE_K 64     /* photons that shape a gather's directions */
#define PDS__GI_SHADOW_K 16    /* photons that decide a light sample */

/* A photon of the global map: position, travel direction, geometric
   normal of the surface facing the photon, flux (W), and where it stands
   among the stores: emitted photon (stream) number (at most 1e9, so 32
   bits), then order; with streams, a leader holds the number of photons
   of its stream (itself and the associated photons stored right after
   it), else 0; lambda: spectral renders, the photon's wavelength once it
   is spectral (its flux then its power at lambda times the film weight
   W(lambda), as the caustic photons', >>spectral), else 0; caustic: 1 if
   the bounce before it was specular (L (S|D)* S x), which a short gather
   takes from the map (pds__gi_bounce_on). 68 bytes. */
typedef struct pds__gi_photon {
    float pos[3], dir[3], ng[3], flux[3];
    int32_t index;
    int seq;
    int lead;
    float lambda;
    int caustic;
} pds__gi_photon;

/* A stream of the global map (streams only): its leader's position, the
   distance of its farthest photon from the leader, and its photons in the
   map (first the leader, count in all). 32 bytes (24 where long is 4). */
typedef struct pds__gi_stream {
    float pos[3];
    float reach;
    long first;
    long count;
} pds__gi_stream;

/* A point of precomputed irradiance (Christensen 1999, below): where a
   stored photon lies, its normal, the irradiance E (W/m^2) there and the
   squared radius of the estimate. 40 bytes. */
typedef struct pds__gi_irr {
    float pos[3], ng[3], E[3];
    float r2;
} pds__gi_irr;

/* A direct (first hit) or shadow photon: position, geometric normal
   facing the light it came from, that light. 48 bytes. */
typedef struct pds__gi_shadow_photon {
    float pos[3], ng[3];
    long index;
    int seq;
    int light;
    int shadow;          /* 0 direct photon, 1 shadow photon */
} pds__gi_shadow_photon;

/* One thread's stores while the maps are built. */
typedef struct pds__gi_buf {
    pds__gi_photon *p;
    size_t n, cap;
    pds__gi_shadow_photon *s;
    size_t ns, caps;
    int out_of_memory;
} pds__gi_buf;

/* The two maps and what the eye pass needs with them. */
typedef struct pds__gi_map {
    const pds_scene *scene;
    pds__gi_photon *photons;
    size_t n;
    pds__kdtree tree;    /* over the photons, or with streams the leaders */
    pds__gi_stream *streams; /* NULL: a map of single photons */
    size_t nstreams;
    double reach;        /* streams: the largest reach */
    int nfa;             /* streams: associated photons per stream */
    pds__gi_shadow_photon *shadow;
    size_t ns;
    pds__kdtree stree;
    pds__gi_irr *irr;    /* precomputed irradiance, or NULL */
    size_t nirr;
    pds__kdtree itree;
    int k;               /* photons per radiance estimate */
    int gather;          /* gather rays per eye sample */
    double mix;          /* share of cosine sampling in the gather */
    int use_shadow;      /* shadow photons decide light samples */
    int record_only;     /* caustics only: the eye pass only records vertices */
    uint64_t seed;
    long emitted;        /* photons (streams) emitted */
} pds__gi_map;

/* Pass 1's work, handed out in batches. */
typedef struct pds__gi_build {
    const pds_scene *scene;
    uint64_t seed, halton_seed;
    long n;              /* photons (streams) to emit */
    int max_depth;
    double eps;
    int streams;         /* 1: streams of a leader and nfa associated photons */
    int nfa;             /* streams: associated photons per stream */
    double rs;           /* streams: the stream radius */
    int spectral;        /* one wavelength per photon (>>spectral) */
    int spectral_all;    /* ... spectral from the light on, not only from
                            the first dispersive material */
    int shadow;          /* trace the shadow photons (only shadow_photons
                            asks them anything) */
    pds__gi_buf *bufs;
    pds__mutex lock;
    int next_buf;        /* guarded by lock */
    long next_batch;     /* guarded by lock */
} pds__gi_build;

static int pds__gi_push(pds__gi_buf *b, const pds__gi_photon *p)
{
    if (pds__grow((void **)&b->p, &b->cap, b->n + 1, sizeof *b->p)) {
        b->out_of_memory = 1;
        return 0;
    }
    b->p[b->n++] = *p;
    return 1;
}

static int pds__gi_push_shadow(pds__gi_buf *b, const pds__gi_shadow_photon *p)
{
    if (pds__grow((void **)&b->s, &b->caps, b->ns + 1, sizeof *b->s)) {
        b->out_of_memory = 1;
        return 0;
    }
    b->s[b->ns++] = *p;
    return 1;
}

/* The straight line of photon i's first ray (from org along dir, light
   k): a direct photon at its first hit if that is non-specular, shadow
   photons at the later non-specular hits. */
static void pds__gi_shadow_line(const pds__gi_build *b, pds__gi_buf *buf, long i, int k, pds__v3 org, pds__v3 dir)
{
    const pds_scene *s = b->scene;
    int hits, stored = 0, seq = 0;
    for (hits = 0; hits < 4 * PDS__GI_MAX_SHADOW && stored < PDS__GI_MAX_SHADOW; hits++) {
        pds__tri_hit th;
        pds_hit hit;
        const pds_material *m;
        if (!pds__bvh_intersect(&s->bvh, org, dir, 0.0, DBL_MAX, &th)) return;
        pds__scene_fill_hit(s, &th, org, dir, &hit);
        m = &s->materials.items[hit.material];
        if (!pds__material_is_specular(m) && m->type != PDS_MAT_EMISSIVE) {
            pds__gi_shadow_photon sp;
            memset(&sp, 0, sizeof sp); /* padding too: the maps compare bit for bit */
            pds__f3_set(sp.pos, hit.position);
            pds__f3_set(sp.ng, pds__dot(hit.ng, dir) < 0.0 ? hit.ng : pds__scale(hit.ng, -1.0));
            sp.index = i;
            sp.seq = seq++;
            sp.light = k;
            sp.shadow = hits > 0;
            if (!pds__gi_push_shadow(buf, &sp)) return;
            stored += hits > 0;
        }
        org = pds__add(hit.position, pds__scale(hit.ng, pds__dot(hit.ng, dir) >= 0.0 ? b->eps : -b->eps));
    }
}

/* --- streams in the global map (seed paper 003) -------------------------
   The paper's streams (>>streams for the paper's rules) where they mean
   something: in the global map, whose photons first meet diffuse
   surfaces. Stream s is global photon s of the single-photon map (the
   same emission and bounces, PDS__RNG_GLOBAL), its leader, which carries
   the stream's energy, Es = Ez / nfs at emission (eq. 1; Ez / pmf for the
   light picked with probability pmf), and nfa associated photons:
   - where the leader meets a diffuse (non-specular) surface at x, "each
     associated photon is assigned a random point within the region
     surrounding the new position of the leading photon of a radius
     denoting the stream's width" (sect. 3.1, 3a): a point y uniform by
     area in the disc of radius rs about x in x's tangent plane. It leaves
     from where the leader left (the light, or the leader's last diffuse
     hit) towards y, so its direction deviates from the leader's by the
     angle under which the disc is seen ("directions of propagation
     deviating from the direction of the leading photon in the area with
     a radius (rs)", sect. 3), and is stored where it really lands (y on a
     flat surface; elsewhere when a corner or an object is in the way,
     which gives the paper's colour bleeding between objects, sect. 4);
   - the stream's energy is "equally divided among all the photons in the
     stream (nfa+1)" (sect. 3): each photon stores the stream's flux over
     nfa + 1;
   - an associated photon that does not land on a non-specular surface
     within 2 rs of x (it meets glass, a mirror or a light, leaves the
     scene, or leaves its side of the surface) is eliminated and its
     energy given to the leader, the paper's rule for a specular event
     (3b), so a stream stores exactly its flux at every diffuse hit;
   - the leader then bounces on by the BSDF with Russian roulette, as a
     single photon, carrying the whole stream's energy, and at its next
     diffuse hit the associated photons are aimed anew ("the stream decay
     mechanism [18]", which the paper does not describe, is taken as this:
     the stream keeps its nfa photons while its leader is diffusely
     reflected and loses them all at the first specular event);
   - where the leader meets a specular surface "all associated photons are
     eliminated and the sum of their energy values is assigned to the
     leading photon" (3b): from there on the stream is its leader alone.
   The gather (pds__gi_stream_radiance) is eq. 2. */

/* Associated photon j of stream i at the leader's diffuse hit `hit`
   (bounce `depth`), leaving from o (n: the normal of the side it leaves
   from, or zero at a point light). Returns 1 and fills *p (flux set by
   the caller) if it lands on a non-specular surface within 2 rs of the
   leader's hit, else 0. */
#define PDS__GI_STREAM_DIMS 32768 /* RNG_STREAM dimensions per leader bounce: 2 x (nfa <= 10000) */
static int pds__gi_associate(const pds__gi_build *b, long i, int depth, int j, pds__v3 o, pds__v3 n,
                             const pds_hit *hit, pds__gi_photon *p)
{
    const pds_scene *s = b->scene;
    uint64_t dim = (uint64_t)depth * PDS__GI_STREAM_DIMS + 2 * (uint64_t)j;
    double u1 = pds__rng_uniform(b->seed, PDS__RNG_STREAM, (uint64_t)i, dim);
    double u2 = pds__rng_uniform(b->seed, PDS__RNG_STREAM, (uint64_t)i, dim + 1);
    double r = b->rs * sqrt(u1), phi = 2.0 * PDS__PI * u2;
    pds__v3 b1, b2, y, d;
    pds__tri_hit th;
    pds_hit h;
    const pds_material *m;
    pds__onb(hit->ng, &b1, &b2);
    y = pds__add(hit->position, pds__add(pds__scale(b1, r * cos(phi)), pds__scale(b2, r * sin(phi))));
    d = pds__sub(y, o);
    if (!(pds__dot(d, d) > 0.0)) return 0;
    d = pds__normalize(d);
    if (pds__dot(n, n) > 0.0 && !(pds__dot(d, n) > 0.0)) return 0;
    if (!pds__bvh_intersect(&s->bvh, o, d, 0.0, DBL_MAX, &th)) return 0;
    pds__scene_fill_hit(s, &th, o, d, &h);
    m = &s->materials.items[h.material];
    if (m->type == PDS_MAT_EMISSIVE || pds__material_is_specular(m)) return 0;
    if (pds__length(pds__sub(h.position, hit->position)) > 2.0 * b->rs) return 0;
    memset(p, 0, sizeof *p);
    pds__f3_set(p->pos, h.position);
    pds__f3_set(p->dir, d);
    pds__f3_set(p->ng, pds__dot(h.ng, d) < 0.0 ? h.ng : pds__scale(h.ng, -1.0));
    p->index = (int32_t)i;
    return 1;
}

/* Trace global photon i: emission, stores at non-specular hits, Russian
   roulette by the albedo (Jensen 1996, sect. 3). With streams, photon i
   is the leader of stream i, and at each of its stores the associated
   photons are aimed and stored after it (above). In a spectral render the
   photon carries wavelength lambda (the seventh Halton dimension, as the
   caustic photons) and turns spectral where it first meets a dispersive
   material (with --spectral: at its first hit), as in >>pds's tracing:
   its flux becomes its power at lambda times W(lambda), and from there on
   materials are taken at lambda (>>spectral). */
static void pds__gi_trace_photon(const pds__gi_build *b, pds__gi_buf *buf, long i)
{
    const pds_scene *s = b->scene;
    const double *sigma = NULL;
    double sigma_buf[3];
    pds_material m_lambda;
    pds__light_emit e;
    pds__v3 org, dir, nside;
    double u[4], pmf, flux[3];
    double lambda = b->spectral ? pds__photon_wavelength(b->halton_seed, i) : 0.0, lam = 0.0;
    int k, c, depth, stores = 0, seq = 0, live = b->streams ? b->nfa : 0, specular = 0;
    for (c = 0; c < 4; c++) u[c] = pds__halton(b->halton_seed, (uint64_t)i, c);
    k = pds__lights_pick(&s->light_table, pds__halton(b->halton_seed, (uint64_t)i, 4), &pmf);
    if (k < 0 || !(pmf > 0.0)) return;
    if (!pds__light_emit_sample(&s->light_table, &s->lights[k], k, &s->mesh, u, &e)) return;
    for (c = 0; c < 3; c++) flux[c] = e.flux[c] / ((double)b->n * pmf);
    dir = e.dir;
    org = pds__add(e.pos, pds__scale(e.normal, pds__dot(e.normal, dir) >= 0.0 ? b->eps : -b->eps));
    nside = pds__dot(e.normal, dir) >= 0.0 ? e.normal : pds__scale(e.normal, -1.0);
    if (b->shadow) pds__gi_shadow_line(b, buf, i, k, org, dir);
    for (depth = 0; depth <= b->max_depth; depth++) {
        pds__tri_hit th;
        pds_hit hit;
        const pds_material *m;
        pds__bsdf_result bs;
        double uu[3], q;
        if (!pds__bvh_intersect(&s->bvh, org, dir, 0.0, DBL_MAX, &th)) return;
        pds__scene_fill_hit(s, &th, org, dir, &hit);
        pds__beer(sigma, th.t, flux);
        m = &s->materials.items[hit.material];
        if (m->type == PDS_MAT_EMISSIVE) return;
        if (lambda > 0.0 && lam == 0.0 && (b->spectral_all || pds__material_is_dispersive(m))) {
            pds__photon_turn_spectral(lambda, flux, sigma ? sigma_buf : NULL);
            lam = lambda;
        }
        if (lam > 0.0) {
            pds__spectral_material(m, lam, &m_lambda);
            m = &m_lambda;
        }
        if (!pds__material_is_specular(m) && (depth > 0 || b->streams)) {
            /* a photon's first hit (L D) is not stored in a map of
               single photons: the light sample at x2 counts that light
               (the partition above; the shadow map keeps its own record
               of first hits, pds__gi_shadow_line) */
            pds__gi_photon p;
            size_t lead_at = buf->n;
            int j, landed = 0;
            if (stores++ == PDS__GI_MAX_STORES) return;
            memset(&p, 0, sizeof p);
            pds__f3_set(p.pos, hit.position);
            pds__f3_set(p.dir, dir);
            pds__f3_set(p.ng, pds__dot(hit.ng, dir) < 0.0 ? hit.ng : pds__scale(hit.ng, -1.0));
            for (c = 0; c < 3; c++) p.flux[c] = (float)flux[c];
            p.index = (int32_t)i;
            p.seq = seq++;
            p.lead = b->streams;
            p.lambda = (float)lam;
            p.caustic = specular;
            if (!pds__gi_push(buf, &p)) return;
            if (live > 0) {
                /* the stream's photons share its flux; the eliminated
                   associated photons' shares stay with the leader */
                double share[3];
                for (c = 0; c < 3; c++) share[c] = flux[c] / (live + 1.0);
                for (j = 0; j < live; j++) {
                    pds__gi_photon a;
                    if (!pds__gi_associate(b, i, depth, j, org, nside, &hit, &a)) continue;
                    for (c = 0; c < 3; c++) a.flux[c] = (float)share[c];
                    a.seq = seq++;
                    a.lambda = (float)lam;
                    if (!pds__gi_push(buf, &a)) return;
                    landed++;
                }
                for (c = 0; c < 3; c++)
                    buf->p[lead_at].flux[c] = (float)(share[c] + (double)(live - landed) * share[c]);
                buf->p[lead_at].lead = 1 + landed;
            }
        }
        if (depth == b->max_depth) return;
        for (c = 0; c < 3; c++)
            uu[c] = pds__rng_uniform(b->seed, PDS__RNG_GLOBAL, (uint64_t)i, 4 * (uint64_t)depth + (uint64_t)c);
        if (!pds__bsdf_sample(m, hit.position, pds__scale(dir, -1.0), hit.ns, hit.ng, uu, PDS__IMPORTANCE, &bs)) return;
        pds__spectral_uplift(lam, bs.weight);
        q = 1.0;
        if (!bs.delta) {
            q = fmax(bs.weight[0], fmax(bs.weight[1], bs.weight[2]));
            if (q > 1.0) q = 1.0;
            if (!(q > 0.0) ||
                pds__rng_uniform(b->seed, PDS__RNG_GLOBAL, (uint64_t)i, 4 * (uint64_t)depth + 3) >= q)
                return;
        }
        for (c = 0; c < 3; c++) flux[c] *= bs.weight[c] / q;
        if (m->type == PDS_MAT_DIELECTRIC) {
            /* a copy: m may be m_lambda, which the next hit overwrites */
            const double *a = pds__medium_absorption(m, bs.side);
            if (a) memcpy(sigma_buf, a, sizeof sigma_buf);
            sigma = a ? sigma_buf : NULL;
        }
        if (bs.delta) live = 0; /* a specular event: the stream is its leader alone */
        specular = bs.delta;
        dir = bs.wi;
        org = pds__add(hit.position, pds__scale(hit.ng, pds__dot(hit.ng, dir) >= 0.0 ? b->eps : -b->eps));
        nside = pds__dot(hit.ng, dir) >= 0.0 ? hit.ng : pds__scale(hit.ng, -1.0);
    }
}

static void *pds__gi_build_worker(void *arg)
{
    pds__gi_build *b = (pds__gi_build *)arg;
    pds__gi_buf *buf;
    pds__mutex_lock(&b->lock);
    buf = &b->bufs[b->next_buf++];
    pds__mutex_unlock(&b->lock);
    for (;;) {
        long batch, i, first, last;
        pds__mutex_lock(&b->lock);
        batch = b->next_batch++;
        pds__mutex_unlock(&b->lock);
        first = batch * (long)PDS__PHOTON_BATCH;
        if (first >= b->n || buf->out_of_memory) break;
        last = first + PDS__PHOTON_BATCH < b->n ? first + PDS__PHOTON_BATCH : b->n;
        for (i = first; i < last; i++) pds__gi_trace_photon(b, buf, i);
    }
    return NULL;
}

static int pds__gi_photon_cmp(const void *a, const void *b)
{
    const pds__gi_photon *x = (const pds__gi_photon *)a, *y = (const pds__gi_photon *)b;
    if (x->index != y->index) return (x->index > y->index) - (x->index < y->index);
    return (x->seq > y->seq) - (x->seq < y->seq);
}

static int pds__gi_shadow_cmp(const void *a, const void *b)
{
    const pds__gi_shadow_photon *x = (const pds__gi_shadow_photon *)a, *y = (const pds__gi_shadow_photon *)b;
    if (x->index != y->index) return (x->index > y->index) - (x->index < y->index);
    return (x->seq > y->seq) - (x->seq < y->seq);
}

static void pds__gi_map_free(pds__gi_map *g)
{
    free(g->photons);
    free(g->streams);
    free(g->shadow);
    free(g->irr);
    pds__kdtree_free(&g->tree);
    pds__kdtree_free(&g->stree);
    pds__kdtree_free(&g->itree);
    memset(g, 0, sizeof *g);
}

static size_t pds__gi_map_bytes(const pds__gi_map *g)
{
    return g->n * sizeof *g->photons + g->nstreams * sizeof *g->streams + pds__kdtree_memory(&g->tree) +
           g->ns * sizeof *g->shadow + pds__kdtree_memory(&g->stree) + g->nirr * sizeof *g->irr +
           pds__kdtree_memory(&g->itree);
}

/* rs in scene units: the option, or 1/16 of the largest side of the
   scene's bounds (README, "Streams in gi's global map"). */
static double pds__gi_stream_radius(const pds_scene *s, const pds_options *opt)
{
    pds__v3 e = pds__sub(s->bounds_max, s->bounds_min);
    double side = fmax(e.x, fmax(e.y, e.z));
    if (opt->stream_radius > 0.0) return opt->stream_radius;
    return side > 0.0 ? side / 16.0 : 1.0;
}

/* The streams of a map sorted in stream order (each leader followed by
   its associated photons): one record per leader, with its reach. */
static int pds__gi_streams_index(pds__gi_map *g)
{
    size_t i, ns = 0;
    for (i = 0; i < g->n; i++) ns += g->photons[i].lead > 0;
    g->streams = (pds__gi_stream *)malloc(sizeof *g->streams * (ns ? ns : 1));
    if (!g->streams) return 0;
    for (i = 0; i < g->n; i++) {
        const pds__gi_photon *p = &g->photons[i];
        pds__gi_stream *st;
        long j;
        double reach = 0.0;
        if (p->lead <= 0) continue;
        st = &g->streams[g->nstreams++];
        memset(st, 0, sizeof *st);
        memcpy(st->pos, p->pos, sizeof st->pos);
        st->first = (long)i;
        st->count = p->lead;
        for (j = 1; j < p->lead; j++) {
            pds__v3 d = pds__sub(pds__f3_get(g->photons[i + (size_t)j].pos), pds__f3_get(p->pos));
            reach = fmax(reach, pds__length(d));
        }
        st->reach = (float)reach;
        if ((double)st->reach < reach) st->reach = nextafterf(st->reach, FLT_MAX); /* never short */
        if (reach > g->reach) g->reach = reach;
    }
    return 1;
}

static pds_status pds__gi_irradiance_build(pds__gi_map *g, int threads, pds_error *err);

/* Does precomputing the irradiance (below) pay? One point costs one full
   estimate and a lookup then about a quarter of one, so it pays when the
   gathers ask for more than 4/3 of the map's size in estimates; with a
   margin (some gather rays end on glass, glossy surfaces or nothing):
   when pixels x samples x gathers exceed PDS__GI_IRR_PAYS times the
   stored photons. The render's own numbers, so every shard decides the
   same. */
#define PDS__GI_IRR_PAYS 1.5
static int pds__gi_irradiance_pays(const pds_scene *s, const pds_options *opt, size_t stored)
{
    double w = opt->width > 0 ? opt->width : s->camera.width;
    double h = opt->height > 0 ? opt->height : s->camera.height;
    double spp = opt->spp > 0 ? opt->spp : s->camera.spp;
    return w * h * spp * opt->gather > PDS__GI_IRR_PAYS * (double)stored;
}

/* Pass 1: emit n photons on the threads, merge the stores in photon
   order, build the two kd-trees and, where it pays, the precomputed
   irradiance. */
static pds_status pds__gi_map_build(pds__gi_map *g, const pds_scene *s, const pds_options *opt, int threads,
                                    pds_error *err)
{
    pds__gi_build b;
    size_t total = 0, totals = 0;
    int t, oom = 0;
    pds_status st;
    memset(g, 0, sizeof *g);
    memset(&b, 0, sizeof b);
    g->scene = s;
    g->k = opt->global_k;
    g->gather = opt->gather;
    g->mix = opt->gather_mix;
    g->use_shadow = opt->shadow_photons;
    g->seed = opt->seed;
    b.scene = s;
    b.seed = opt->seed;
    b.halton_seed = pds__rng_bits(opt->seed, PDS__RNG_GLOBAL, 0, 0);
    b.n = opt->global_photons;
    if (opt->global_map == PDS_GLOBAL_STREAMS) {
        /* nfs streams of nfa + 1 photons: as many photons as the
           single-photon map's */
        b.streams = 1;
        b.nfa = opt->stream_photons;
        b.rs = pds__gi_stream_radius(s, opt);
        b.n = opt->global_photons / (opt->stream_photons + 1L);
        g->nfa = opt->stream_photons;
    }
    g->emitted = b.n;
    b.max_depth = opt->max_depth;
    b.eps = 1e-6 * pds__scene_scale(s);
    b.spectral = pds__render_is_spectral(s, opt);
    b.spectral_all = b.spectral && opt->spectral;
    /* the shadow photons' lines cost as much as a third of pass 1 and
       answer nothing unless shadow_photons asks them (their rays take no
       random numbers: the global photons are the same either way) */
    b.shadow = opt->shadow_photons;
    b.bufs = (pds__gi_buf *)calloc((size_t)threads, sizeof *b.bufs);
    if (!b.bufs) return pds__nomem(err);
    pds__mutex_init(&b.lock);
    pds__run_threads(threads, pds__gi_build_worker, &b);
    pds__mutex_destroy(&b.lock);
    for (t = 0; t < threads; t++) {
        total += b.bufs[t].n;
        totals += b.bufs[t].ns;
        oom |= b.bufs[t].out_of_memory;
    }
    if (!oom) {
        g->photons = (pds__gi_photon *)malloc(sizeof *g->photons * (total ? total : 1));
        g->shadow = (pds__gi_shadow_photon *)malloc(sizeof *g->shadow * (totals ? totals : 1));
        oom = !g->photons || !g->shadow;
    }
    for (t = 0; t < threads; t++) {
        if (!oom) {
            if (b.bufs[t].n) memcpy(g->photons + g->n, b.bufs[t].p, sizeof *g->photons * b.bufs[t].n);
            if (b.bufs[t].ns) memcpy(g->shadow + g->ns, b.bufs[t].s, sizeof *g->shadow * b.bufs[t].ns);
            g->n += b.bufs[t].n;
            g->ns += b.bufs[t].ns;
        }
        free(b.bufs[t].p);
        free(b.bufs[t].s);
    }
    free(b.bufs);
    if (oom) {
        pds__gi_map_free(g);
        return pds__nomem(err);
    }
    qsort(g->photons, g->n, sizeof *g->photons, pds__gi_photon_cmp);
    qsort(g->shadow, g->ns, sizeof *g->shadow, pds__gi_shadow_cmp);
    if (b.streams) {
        if (!pds__gi_streams_index(g)) {
            pds__gi_map_free(g);
            return pds__nomem(err);
        }
        st = pds__kdtree_build(&g->tree, g->nstreams ? &g->streams[0].pos[0] : NULL,
                               sizeof *g->streams / sizeof(float), g->nstreams, err);
    } else {
        st = pds__kdtree_build(&g->tree, g->n ? &g->photons[0].pos[0] : NULL, sizeof *g->photons / sizeof(float),
                               g->n, err);
    }
    if (!st)
        st = pds__kdtree_build(&g->stree, g->ns ? &g->shadow[0].pos[0] : NULL, sizeof *g->shadow / sizeof(float),
                               g->ns, err);
    if (!st && pds__gi_irradiance_pays(s, opt, g->n)) st = pds__gi_irradiance_build(g, threads, err);
    if (st) pds__gi_map_free(g);
    return st;
}

/* The streams' estimate, eq. 2 of seed paper 003:
     L(x, wr) = 1/dA sum_{i=1..k} fr(x, wi, wr) Ei
   over the k nearest leaders, dA the circle of the search sphere's
   radius r, here the k-th leader's distance (as Jensen's k nearest;
   the paper's R is a fixed cap, which gi's map does not have).
   Ambiguity: Ei is "the energy of stream i ... the sum of the energies
   of the constituent photons". Counting a stream's whole energy at its
   leader would never use the associated photons' hit points, which the
   paper stores, and would be photon mapping with nfs photons; here Ei is
   the energy its photons bring into the circle, each with its own
   direction in fr, so a stream whose leader lies outside the circle adds
   the photons it has inside (the range query reaches r plus the largest
   stream reach). Each photon is weighted by the cone filter of the
   single-photon map (Jensen 1996, eq. 4, k = 1: w = 1 - d/r, dA times
   1 - 2/3), the kernel density the paper allows for streams (sect. 6),
   so that streams and single photons differ in nothing else. Nothing
   from fewer than min(8, k) leaders, like the single-photon estimate.
   Spectral photons and vertices meet as in pds__gi_estimate. */
typedef struct pds__gi_stream_sum {
    const pds__gi_map *g;
    const pds_material *m;
    pds__v3 x, wo, ns, ng, ngw;
    double r, r2;
    double lambda_e;
    double L[3];
} pds__gi_stream_sum;

static void pds__gi_stream_visit(void *vctx, size_t index, double dist2)
{
    pds__gi_stream_sum *a = (pds__gi_stream_sum *)vctx;
    const pds__gi_stream *st = &a->g->streams[index];
    long j;
    int c;
    if (st->count > 1 ? dist2 > (a->r + st->reach) * (a->r + st->reach) : dist2 > a->r2) return; /* none inside */
    for (j = 0; j < st->count; j++) {
        const pds__gi_photon *p = &a->g->photons[st->first + j];
        pds__v3 d = pds__sub(pds__f3_get(p->pos), a->x);
        double d2 = pds__dot(d, d), f[3], e[3], pdf, w;
        if (d2 > a->r2 || pds__dot(pds__f3_get(p->ng), a->ngw) <= 0.0) continue;
        pds__bsdf_eval(a->m, a->x, a->wo, pds__scale(pds__f3_get(p->dir), -1.0), a->ns, a->ng, f, &pdf);
        for (c = 0; c < 3; c++) e[c] = p->flux[c];
        if ((p->lambda > 0.0f || a->lambda_e > 0.0) && !pds__spectral_meet(p->lambda, a->lambda_e, e, f)) continue;
        w = 1.0 - sqrt(d2 / a->r2);
        for (c = 0; c < 3; c++) a->L[c] += f[c] * e[c] * w;
    }
}

static void pds__gi_stream_radiance(const pds__gi_map *g, const pds_material *m, pds__v3 x, pds__v3 wo, pds__v3 ns,
                                    pds__v3 ng, double lambda_e, double L[3], double *r2)
{
    size_t idx[PDS__GI_MAX_K], n;
    double d2[PDS__GI_MAX_K], area;
    pds__gi_stream_sum a;
    int c;
    L[0] = L[1] = L[2] = 0.0;
    n = pds__kdtree_knn(&g->tree, x, (size_t)g->k, DBL_MAX, idx, d2);
    if (n < (size_t)(g->k < 8 ? g->k : 8) || !(d2[n - 1] > 0.0)) return;
    memset(&a, 0, sizeof a);
    a.g = g;
    a.m = m;
    a.x = x;
    a.wo = wo;
    a.ns = ns;
    a.ng = ng;
    a.ngw = pds__dot(ng, wo) >= 0.0 ? ng : pds__scale(ng, -1.0);
    a.lambda_e = lambda_e;
    a.r2 = d2[n - 1];
    a.r = sqrt(a.r2);
    if (r2) *r2 = a.r2;
    pds__kdtree_range(&g->tree, x, a.r + g->reach, pds__gi_stream_visit, &a);
    area = (1.0 / 3.0) * PDS__PI * a.r2;
    for (c = 0; c < 3; c++) L[c] = a.L[c] / area;
}

/* The global map's radiance estimate (Jensen 1996, eq. 3, cone filter
   eq. 4 with k = 1): L(x, wo) = sum_p f(x, wo, wp) dPhi_p w_p /
   ((1 - 2/3) pi r^2), r the distance of the k-th nearest photon, photons
   from the other side of the surface skipped, nothing from fewer than
   min(8, k) photons. A map of streams gives the streams' estimate.
   caustic_only (single photons): only the photons whose bounce before
   was specular, in the same disc (the caustics' share of the estimate).
   Spectral renders: x is seen at every wavelength (lambda_e = 0) or, at
   the end of a chain through dispersive glass, at lambda_e only; each
   photon, RGB or spectral, meets it as a caustic photon meets an eye
   vertex (pds__spectral_meet: a spectral photon at its own wavelength,
   into a vertex at lambda_e only from its wavelength bin), so the
   estimate is already weighted by the film. */
static void pds__gi_estimate(const pds__gi_map *g, const pds_material *m, pds__v3 x, pds__v3 wo, pds__v3 ns,
                             pds__v3 ng, double lambda_e, int caustic_only, double L[3], double *r2_out)
{
    size_t idx[PDS__GI_MAX_K], n, j;
    double d2[PDS__GI_MAX_K], r2, area;
    pds__v3 ngw = pds__dot(ng, wo) >= 0.0 ? ng : pds__scale(ng, -1.0);
    int c;
    if (r2_out) *r2_out = 0.0;
    if (g->streams) {
        pds__gi_stream_radiance(g, m, x, wo, ns, ng, lambda_e, L, r2_out);
        return;
    }
    L[0] = L[1] = L[2] = 0.0;
    n = pds__kdtree_knn(&g->tree, x, (size_t)g->k, DBL_MAX, idx, d2);
    if (n < (size_t)(g->k < 8 ? g->k : 8)) return;
    r2 = d2[n - 1];
    if (!(r2 > 0.0)) return;
    if (r2_out) *r2_out = r2;
    for (j = 0; j < n; j++) {
        const pds__gi_photon *p = &g->photons[idx[j]];
        double f[3], e[3], pdf, w;
        if (pds__dot(pds__f3_get(p->ng), ngw) <= 0.0 || (caustic_only && !p->caustic)) continue;
        pds__bsdf_eval(m, x, wo, pds__scale(pds__f3_get(p->dir), -1.0), ns, ng, f, &pdf);
        for (c = 0; c < 3; c++) e[c] = p->flux[c];
        if ((p->lambda > 0.0f || lambda_e > 0.0) && !pds__spectral_meet(p->lambda, lambda_e, e, f)) continue;
        w = 1.0 - sqrt(d2[j] / r2);
        for (c = 0; c < 3; c++) L[c] += f[c] * e[c] * w;
    }
    area = (1.0 / 3.0) * PDS__PI * r2;
    for (c = 0; c < 3; c++) L[c] /= area;
}

#ifdef PDS_TEST
/* The estimate alone, without its radius (the tests' short name). */
static void pds__gi_radiance(const pds__gi_map *g, const pds_material *m, pds__v3 x, pds__v3 wo, pds__v3 ns,
                             pds__v3 ng, double lambda_e, double L[3])
{
    pds__gi_estimate(g, m, x, wo, ns, ng, lambda_e, 0, L, NULL);
}
#endif

/* --- precomputed irradiance (Christensen 1999) --------------------------
   P. H. Christensen, "Faster photon map global illumination", Journal of
   Graphics Tools 4(3), 1999: the final gather asks the global map for
   radiance at many points x2, each a k-nearest search and k BRDF
   evaluations; on Lambertian surfaces the radiance is the local albedo
   over pi times the irradiance E, which varies slowly, so E is estimated
   once at points where photons lie, and a gather ray that ends on a
   Lambertian surface takes the estimate of the nearest such point whose
   normal is within acos(PDS__GI_IRR_COS) of its own (and that lies
   within the radius of that point's own estimate): one nearest-point
   search instead of k. Then
       L(x2, wo) = albedo(x2) / pi E(p).

   Which photons, and from which: the map's emitted photons are split in
   two halves by number, the first n/2 and the rest (each half a run of
   the Halton sequence their emission follows, so each is as evenly
   spread over the lights as the whole; a split at random or by parity
   is not), a photon's stores along its path staying together; the
   points are the stores of the first half, and each point's E is
   estimated from the second half alone,
       E(p) = 2 sum_q dPhi_q w_q / ((1 - 2/3) pi r^2)
   over p's ceil(k/2) nearest photons q of the second half arriving on
   p's side, cone filter as in pds__gi_estimate (Jensen 1996, eqs. 3-4),
   r the last one's distance (about the radius of the full estimate's k
   nearest; the factor 2: the half carries half the map's flux). Two
   biases of Christensen's points estimated from all the photons,
   measured in the Cornell box against a long path-traced reference of
   single blocks (README "Global illumination"), are why:
   - an estimate at a photon counts that photon itself, at distance 0
     with the cone filter's largest weight, and its k-th neighbour is
     the (k-1)-th of the others: about (k + 1) / (k - 2) too bright (6%
     at k = 50);
   - the nearest point to x2 is more often a photon whose neighbours
     lie far away (its Voronoi cell is larger), and the same neighbours
     make its estimate: with the photon itself left out of its estimate
     the lookups are about 4% too dark.
   In the box the two nearly cancel (the image 0.45-0.6% brighter than
   the full estimate's on the walls beside the mirror, where the map's
   share is large). With the points and their estimates from disjoint
   halves of the map, which photon is nearest says nothing about its
   estimate. A point's estimate has the noise of k/2 photons, which the gather
   averages over many points; there are half as many points, each a
   half-size search. A map of streams keeps Christensen's points at
   every photon with the streams' own estimate (its photons come in
   streams of one path).
   The points cost one estimate each, so they are made only when the
   gathers will ask for more estimates (pds__gi_irradiance_pays). Where
   no point qualifies (a thin part, an edge) and on other surfaces the
   full estimate answers; so it does in maps holding spectral photons,
   whose contributions depend on the albedo at each photon's wavelength.
   Tested in gi_precomputed_irradiance_matches_the_full_estimate and
   gi_precomputed_irradiance_leaves_out_its_own_photons. */
#define PDS__GI_IRR_COS 0.9
#define PDS__GI_IRR_K 4     /* nearest points looked at for one with a matching normal */

typedef struct pds__gi_irr_job {
    pds__gi_map *g;
    pds_material white;   /* Lambertian, albedo 1 */
    const size_t *point;  /* the points' photons (nirr) */
    pds__kdtree half;     /* single photons: the second half's positions */
    const size_t *hidx;   /* ... and their photons */
    pds__mutex lock;
    size_t next; /* guarded by lock: the next batch's first point */
} pds__gi_irr_job;

/* Which half of the map photon p's stores belong to (0: points). */
static int pds__gi_half(const pds__gi_map *g, const pds__gi_photon *p)
{
    return (long)p->index >= g->emitted / 2;
}

/* Irradiance at p's position on its lit side (the record's ng): for a map
   of single photons from the second half (above), for a map of streams
   pi times the radiance the streams' estimate gives a white Lambertian
   surface there. */
static void pds__gi_irradiance_at(const pds__gi_irr_job *job, const pds__gi_photon *p, pds__gi_irr *out)
{
    const pds__gi_map *g = job->g;
    double L[3] = {0.0, 0.0, 0.0}, r2 = 0.0;
    pds__v3 x = pds__f3_get(p->pos), ng = pds__f3_get(p->ng);
    int c;
    memset(out, 0, sizeof *out);
    memcpy(out->pos, p->pos, sizeof out->pos);
    memcpy(out->ng, p->ng, sizeof out->ng);
    if (g->streams) {
        pds__gi_estimate(g, &job->white, x, ng, ng, ng, 0.0, 0, L, &r2);
        for (c = 0; c < 3; c++) out->E[c] = (float)(PDS__PI * L[c]);
    } else {
        size_t idx[PDS__GI_MAX_K], n, j, kh = ((size_t)g->k + 1) / 2;
        double d2[PDS__GI_MAX_K], area;
        n = pds__kdtree_knn(&job->half, x, kh, DBL_MAX, idx, d2);
        if (n < (kh < 4 ? kh : 4) || !(d2[n - 1] > 0.0)) return; /* as the full estimate's min(8, k) */
        r2 = d2[n - 1];
        for (j = 0; j < n; j++) {
            const pds__gi_photon *q = &g->photons[job->hidx[idx[j]]];
            double w = 1.0 - sqrt(d2[j] / r2);
            if (pds__dot(pds__f3_get(q->ng), ng) <= 0.0) continue;
            for (c = 0; c < 3; c++) L[c] += 2.0 * q->flux[c] * w;
        }
        area = (1.0 / 3.0) * PDS__PI * r2;
        for (c = 0; c < 3; c++) out->E[c] = (float)(L[c] / area);
    }
    out->r2 = (float)r2; /* 0 (no estimate): never chosen */
}

static void *pds__gi_irr_worker(void *arg)
{
    pds__gi_irr_job *job = (pds__gi_irr_job *)arg;
    pds__gi_map *g = job->g;
    for (;;) {
        size_t first, i;
        pds__mutex_lock(&job->lock);
        first = job->next;
        job->next += 1024;
        pds__mutex_unlock(&job->lock);
        if (first >= g->nirr) break;
        for (i = first; i < g->nirr && i < first + 1024; i++)
            pds__gi_irradiance_at(job, &g->photons[job->point[i]], &g->irr[i]);
    }
    return NULL;
}

/* The points and their kd-tree, for a map of RGB photons (each point a
   pure function of the map and the seed: the same for any thread
   count). */
static pds_status pds__gi_irradiance_build(pds__gi_map *g, int threads, pds_error *err)
{
    pds__gi_irr_job job;
    size_t i, np = 0, nh = 0, *point, *hidx = NULL;
    float *hpos = NULL;
    pds_status st = PDS_OK;
    if (g->n == 0) return PDS_OK;
    for (i = 0; i < g->n; i++)
        if (g->photons[i].lambda > 0.0f) return PDS_OK;
    memset(&job, 0, sizeof job);
    job.g = g;
    job.white.type = PDS_MAT_DIFFUSE;
    job.white.albedo[0] = job.white.albedo[1] = job.white.albedo[2] = 1.0;
    point = (size_t *)malloc(sizeof *point * g->n);
    if (!g->streams) {
        hidx = (size_t *)malloc(sizeof *hidx * g->n);
        hpos = (float *)malloc(sizeof *hpos * 3 * g->n);
    }
    if (!point || (!g->streams && (!hidx || !hpos))) {
        free(point);
        free(hidx);
        free(hpos);
        return pds__nomem(err);
    }
    for (i = 0; i < g->n; i++) {
        if (g->streams || pds__gi_half(g, &g->photons[i]) == 0) {
            point[np++] = i;
        } else {
            memcpy(&hpos[3 * nh], g->photons[i].pos, sizeof g->photons[i].pos);
            hidx[nh++] = i;
        }
    }
    if (!g->streams) st = pds__kdtree_build(&job.half, nh ? hpos : NULL, 3, nh, err);
    free(hpos);
    if (!st && np > 0) {
        g->nirr = np;
        g->irr = (pds__gi_irr *)malloc(sizeof *g->irr * np);
        if (!g->irr) {
            g->nirr = 0;
            st = pds__nomem(err);
        }
    }
    if (!st && np > 0) {
        job.point = point;
        job.hidx = hidx;
        pds__mutex_init(&job.lock);
        pds__run_threads(threads, pds__gi_irr_worker, &job);
        pds__mutex_destroy(&job.lock);
        st = pds__kdtree_build(&g->itree, &g->irr[0].pos[0], sizeof *g->irr / sizeof(float), g->nirr, err);
    }
    pds__kdtree_free(&job.half);
    free(point);
    free(hidx);
    return st;
}

/* L at x2 (Lambertian material m, geometric normal ngw facing wo) from
   the nearest point with a matching normal, and (r2, if not NULL) the
   squared radius of that point's estimate; 0 if there is none (then the
   caller asks the full estimate). */
static int pds__gi_irradiance_lookup(const pds__gi_map *g, const pds_material *m, pds__v3 x, pds__v3 ngw, double L[3],
                                     double *r2)
{
    size_t idx[PDS__GI_IRR_K], n, j;
    double d2[PDS__GI_IRR_K], albedo[3];
    int c;
    n = pds__kdtree_knn(&g->itree, x, PDS__GI_IRR_K, DBL_MAX, idx, d2);
    for (j = 0; j < n; j++) {
        const pds__gi_irr *q = &g->irr[idx[j]];
        if (!(q->r2 > 0.0f) || d2[j] > (double)q->r2) continue;
        if (pds__dot(pds__f3_get(q->ng), ngw) < PDS__GI_IRR_COS) continue;
        pds__albedo_at(m, x, ngw, albedo);
        for (c = 0; c < 3; c++) L[c] = albedo[c] / PDS__PI * q->E[c];
        if (r2) *r2 = q->r2;
        return 1;
    }
    return 0;
}

/* Count the direct and shadow photons of one light within a radius. */
typedef struct pds__gi_count {
    const pds__gi_map *g;
    pds__v3 ngw;
    int light;
    long direct, shadow;
} pds__gi_count;

static void pds__gi_count_visit(void *vctx, size_t index, double dist2)
{
    pds__gi_count *c = (pds__gi_count *)vctx;
    const pds__gi_shadow_photon *p = &c->g->shadow[index];
    (void)dist2;
    if (p->light != c->light || pds__dot(pds__f3_get(p->ng), c->ngw) <= 0.0) return;
    if (p->shadow) c->shadow++;
    else c->direct++;
}

/* What the shadow photons say about light `light` seen from x (ngw: the
   geometric normal on the side the light must be): 1 lit, 0 blocked, -1
   not known (trace a shadow ray). */
static int pds__gi_shadow_test(const pds__gi_map *g, pds__v3 x, pds__v3 ngw, int light)
{
    size_t idx[PDS__GI_SHADOW_K], n, j;
    double d2[PDS__GI_SHADOW_K];
    pds__gi_count cnt;
    long direct = 0, shadow = 0;
    n = pds__kdtree_knn(&g->stree, x, PDS__GI_SHADOW_K, DBL_MAX, idx, d2);
    for (j = 0; j < n; j++) {
        const pds__gi_shadow_photon *p = &g->shadow[idx[j]];
        if (p->light != light || pds__dot(pds__f3_get(p->ng), ngw) <= 0.0) continue;
        if (p->shadow) shadow++;
        else direct++;
    }
    if (direct + shadow < 8 || (direct > 0 && shadow > 0)) return -1;
    /* no photon of the other kind within twice that radius */
    memset(&cnt, 0, sizeof cnt);
    cnt.g = g;
    cnt.ngw = ngw;
    cnt.light = light;
    pds__kdtree_range(&g->stree, x, 2.0 * sqrt(d2[n - 1]), pds__gi_count_visit, &cnt);
    if (direct > 0 ? cnt.shadow > 0 : cnt.direct > 0) return -1;
    return direct > 0;
}

/* --- gi's rays in spectral renders ---------------------------------------
   gi's eye path (camera to x1) and its gather rays (x1 along specular
   surfaces to x2) are spectral as the other methods' eye paths are
   (>>spectral, pds__trace_path): a camera sample's wavelength lambda, the
   ray RGB until its chain first meets a dispersive material (with
   --spectral: from the camera on), there its throughput replaced by its
   value at lambda, materials and lights then taken at lambda and what it
   sees weighted by the film's W(lambda). Alongside, the chain's RGB
   weight is kept for a vertex whose chain met no dispersive material
   (the eye vertex x1, or the point x2 where a gather ends), which holds
   at every wavelength: the caustic method's photons meet x1, and the
   global map's photons x2, as caustic photons meet an eye vertex
   (pds__spectral_meet). A gather ray starts from x1's state, so a
   gather from a point seen through a prism stays at that point's
   wavelength. In RGB renders (lambda = 0) the state is the throughput
   alone and every step below is the RGB one. */
typedef struct pds__gi_ray {
    double beta[3];           /* throughput (at lam in all three channels once spectral) */
    double beta_rgb[3];       /* the chain's RGB weight, kept while lam > 0 */
    double sigma[3];          /* Beer coefficients of the medium it is in (at lam once spectral), if has_sigma */
    const double *sigma_rgb;  /* the RGB ones for beta_rgb, or NULL */
    int has_sigma;
    int chromatic;            /* its chain met a dispersive material: holds at lambda only */
    double lambda;            /* the camera sample's wavelength; 0 in RGB renders */
    double lam;               /* lambda once the ray is spectral, else 0 */
    double film[3];           /* W(lambda) */
    int stage;                /* 0 an eye path; 1 a gather ray from x1 (its end may
                                 bounce on, pds__gi_bounce_on); 2 that bounce's ray */
    double travelled;         /* a gather ray: its length from x1 so far */
} pds__gi_ray;

/* A camera ray's state: throughput 1, RGB unless --spectral. */
static void pds__gi_ray_start(pds__gi_ray *r, const pds__tracer *tr, double lambda)
{
    int c;
    memset(r, 0, sizeof *r);
    for (c = 0; c < 3; c++) r->beta[c] = r->beta_rgb[c] = 1.0;
    r->lambda = lambda;
    if (lambda > 0.0) {
        pds__film_weight(lambda, r->film);
        if (tr->spectral_all) r->lam = lambda;
    }
}

/* Travel dist through the medium the ray is in (Beer). */
static void pds__gi_ray_beer(pds__gi_ray *r, double dist)
{
    pds__beer(r->has_sigma ? r->sigma : NULL, dist, r->beta);
    pds__beer(r->sigma_rgb, dist, r->beta_rgb);
}

/* The ray meets material m (the scene's): where it is dispersive the ray
   becomes chromatic and, if still RGB, turns spectral. Returns the
   material as the ray sees it (at lam, in *buf, once spectral). */
static const pds_material *pds__gi_ray_meet(pds__gi_ray *r, const pds_material *m, pds_material *buf)
{
    if (r->lambda > 0.0 && pds__material_is_dispersive(m)) {
        r->chromatic = 1;
        if (r->lam == 0.0) {
            r->lam = r->lambda;
            pds__spectral_uplift(r->lam, r->beta);
            if (r->has_sigma) pds__spectral_uplift(r->lam, r->sigma);
        }
    }
    if (!(r->lam > 0.0)) return m;
    pds__spectral_material(m, r->lam, buf);
    return buf;
}

/* The ray leaves material m (as it sees it; scene_m the scene's) by a
   BSDF sample of RGB weight w (and side, for a dielectric's medium): its
   throughput times w (at lam once spectral). */
static void pds__gi_ray_scatter(pds__gi_ray *r, const pds_material *m, const pds_material *scene_m, double w[3],
                                int side)
{
    int c;
    if (r->lam > 0.0) {
        for (c = 0; c < 3; c++) r->beta_rgb[c] *= w[c];
        if (scene_m->type == PDS_MAT_DIELECTRIC) r->sigma_rgb = pds__medium_absorption(scene_m, side);
        pds__spectral_uplift(r->lam, w);
    }
    for (c = 0; c < 3; c++) r->beta[c] *= w[c];
    if (m->type == PDS_MAT_DIELECTRIC) {
        const double *a = pds__medium_absorption(m, side);
        if (a) memcpy(r->sigma, a, sizeof r->sigma);
        r->has_sigma = a != NULL;
    }
}

/* The weight a vertex at the end of the ray's chain takes (the RGB one
   if its chain met no dispersion) and the wavelength it holds at (0: at
   every wavelength). */
static const double *pds__gi_ray_weight(const pds__gi_ray *r, double *lambda_e)
{
    *lambda_e = r->chromatic ? r->lambda : 0.0;
    return r->lam > 0.0 && !r->chromatic ? r->beta_rgb : r->beta;
}

/* Emitted radiance le (RGB) seen by the ray: into acc, times its
   throughput, at lam and through the film once spectral. */
static void pds__gi_ray_sees(const pds__gi_ray *r, double le[3], double acc[3])
{
    int c;
    pds__spectral_uplift(r->lam, le);
    for (c = 0; c < 3; c++) acc[c] += r->beta[c] * le[c] * (r->lam > 0.0 ? r->film[c] : 1.0);
}

/* Direct light at a non-specular vertex: one light sample (light picked
   by power; numbers dim..dim+2 of PDS__RNG_GATHER), its shadow ray
   skipped where the shadow photons decide (counts[0] rays traced,
   counts[1] decided without one). With bsdf_rays > 0 rays sampling the
   BSDF (glossy vertices), the sample is weighted against them by the
   power heuristic with the sample counts; else it counts alone. ray: the
   state of the eye path (at x1) or of the gather ray (at x2), m the
   material as it sees it; a spectral path takes the BSDF and the light
   at its wavelength. */
static void pds__gi_direct(const pds__gi_map *g, const pds__tracer *tr, const pds_material *m, pds__v3 p, pds__v3 wo,
                           pds__v3 ns, pds__v3 ng, const pds__gi_ray *ray, uint64_t idx, uint64_t dim, int bsdf_rays,
                           double acc[3], long counts[4])
{
    const pds_scene *s = tr->scene;
    const double *beta = ray->beta;
    double pmf, f[3], pdf_bsdf, cosine, mis = 1.0;
    pds__light_li li;
    pds__v3 n, ngw, org;
    int side, k, c, known = -1;
    double u0 = pds__rng_uniform(tr->seed, PDS__RNG_GATHER, idx, dim);
    double u1 = pds__rng_uniform(tr->seed, PDS__RNG_GATHER, idx, dim + 1);
    double u2 = pds__rng_uniform(tr->seed, PDS__RNG_GATHER, idx, dim + 2);
    k = pds__lights_pick(&s->light_table, u0, &pmf);
    if (k < 0 || !(pmf > 0.0)) return;
    if (!pds__light_sample_li(&s->light_table, &s->lights[k], k, &s->mesh, p, u1, u2, &li)) return;
    if (!pds__bsdf_frame(wo, ns, ng, &n, &ngw, &side)) return;
    pds__bsdf_eval(m, p, wo, li.wi, ns, ng, f, &pdf_bsdf);
    cosine = pds__dot(li.wi, n);
    if (!(cosine > 0.0) || !(f[0] + f[1] + f[2] > 0.0)) return;
    if (g->use_shadow) known = pds__gi_shadow_test(g, p, ngw, k);
    if (known < 0) {
        counts[0]++;
        org = pds__offset(tr, p, ng, li.wi);
        if (pds__bvh_occluded(&s->bvh, org, li.wi, 0.0, li.dist * (1.0 - 1e-4))) return;
    } else {
        counts[1]++;
        if (!known) return;
    }
    if (!li.delta && bsdf_rays > 0) mis = pds__mis_power(pmf * li.pdf, bsdf_rays * pdf_bsdf);
    if (ray->lam > 0.0) {
        pds__spectral_uplift(ray->lam, f);
        pds__spectral_uplift(ray->lam, li.li);
        for (c = 0; c < 3; c++) f[c] *= ray->film[c];
    }
    for (c = 0; c < 3; c++) acc[c] += beta[c] * f[c] * li.li[c] * cosine / (pmf * li.pdf) * mis;
}

/* --- importance-sampled final gather ------------------------------------
   Directions are drawn on the square (u0, u1) that Malley's method maps
   to the cosine-weighted hemisphere (r = sqrt(u0), phi = 2 pi u1, cos =
   sqrt(1 - u0): density cos / pi). The square is cut into G x G cells; a
   cell's probability is (1 - mix) times its share of the flux of the
   PDS__GI_GUIDE_K nearest global photons arriving through it, plus mix /
   G^2 (so every direction keeps a density: unbiased), and the point is
   uniform in the cell. Then pdf(wi) = G^2 p_cell cos / pi, and a
   Lambertian x1's estimate f cos L / pdf = albedo L / (G^2 p_cell). A
   photon's flux through a cell is proportional to the integral of L cos
   over the cell's directions, and every cell covers the same cos dw, so
   the cells' shares follow the incoming radiance, which is the density
   that the product f L cos asks for (Jensen 1995). With mix = 1 this is
   cosine sampling. */

typedef struct pds__gi_guide {
    double cdf[PDS__GI_GRID * PDS__GI_GRID + 1];
} pds__gi_guide;

/* The cells' distribution at x, frame (b1, b2, n), side ngw. */
static void pds__gi_guide_build(const pds__gi_map *g, pds__v3 x, pds__v3 n, pds__v3 b1, pds__v3 b2, pds__v3 ngw,
                                double mix, pds__gi_guide *gd)
{
    enum { M = PDS__GI_GRID * PDS__GI_GRID };
    double h[M], total = 0.0;
    size_t idx[PDS__GI_GUIDE_K], guide[PDS__GI_GUIDE_K], cnt = 0, j;
    double d2[PDS__GI_GUIDE_K];
    int i;
    for (i = 0; i < M; i++) h[i] = 0.0;
    if (mix < 1.0 && g->streams) {
        /* streams: the photons of the nearest leaders, about as many */
        size_t ks = PDS__GI_GUIDE_K / ((size_t)g->nfa + 1), ls, l;
        ls = pds__kdtree_knn(&g->tree, x, ks ? ks : 1, DBL_MAX, idx, d2);
        for (l = 0; l < ls && cnt < PDS__GI_GUIDE_K; l++) {
            const pds__gi_stream *st = &g->streams[idx[l]];
            long q;
            for (q = 0; q < st->count && cnt < PDS__GI_GUIDE_K; q++) guide[cnt++] = (size_t)(st->first + q);
        }
    } else if (mix < 1.0) {
        cnt = pds__kdtree_knn(&g->tree, x, PDS__GI_GUIDE_K, DBL_MAX, idx, d2);
        for (j = 0; j < cnt; j++) guide[j] = idx[j];
    }
    for (j = 0; j < cnt; j++) {
        const pds__gi_photon *p = &g->photons[guide[j]];
        pds__v3 wi = pds__scale(pds__f3_get(p->dir), -1.0);
        double z = pds__dot(wi, n), u0, phi, w;
        int r, col;
        if (!(z > 0.0) || pds__dot(pds__f3_get(p->ng), ngw) <= 0.0) continue;
        u0 = 1.0 - z * z;
        phi = atan2(pds__dot(wi, b2), pds__dot(wi, b1));
        if (phi < 0.0) phi += 2.0 * PDS__PI;
        r = (int)(u0 * PDS__GI_GRID);
        col = (int)(phi / (2.0 * PDS__PI) * PDS__GI_GRID);
        if (r > PDS__GI_GRID - 1) r = PDS__GI_GRID - 1;
        if (r < 0) r = 0;
        if (col > PDS__GI_GRID - 1) col = PDS__GI_GRID - 1;
        if (col < 0) col = 0;
        w = (double)p->flux[0] + p->flux[1] + p->flux[2];
        if (!(w > 0.0) || !isfinite(w)) continue;
        h[r * PDS__GI_GRID + col] += w;
        total += w;
    }
    gd->cdf[0] = 0.0;
    for (i = 0; i < M; i++) {
        double pc = total > 0.0 ? (1.0 - mix) * h[i] / total + mix / M : 1.0 / M;
        gd->cdf[i + 1] = gd->cdf[i] + pc;
    }
}

/* A point of the square from the cells: ua picks the cell and, rescaled,
   places the point along u0 in it; ub places it along u1. Returns the
   cell's probability. */
static double pds__gi_guide_sample(const pds__gi_guide *gd, double ua, double ub, double *u0, double *u1)
{
    enum { M = PDS__GI_GRID * PDS__GI_GRID };
    int lo = 0, hi = M - 1;
    double target = ua * gd->cdf[M], p, frac;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (gd->cdf[mid + 1] <= target) lo = mid + 1;
        else hi = mid;
    }
    p = gd->cdf[lo + 1] - gd->cdf[lo];
    frac = p > 0.0 ? (target - gd->cdf[lo]) / p : 0.5;
    if (frac < 0.0) frac = 0.0;
    if (frac >= 1.0) frac = 1.0 - DBL_EPSILON;
    *u0 = ((lo / PDS__GI_GRID) + frac) / PDS__GI_GRID;
    *u1 = ((lo % PDS__GI_GRID) + ub) / PDS__GI_GRID;
    return p / gd->cdf[M];
}

/* What a ray from org along dir meets first, if that is an emitter (an
   analytic light at distance tl, normal nl, or an emissive triangle of
   the hit th; found: a triangle was hit at all) or, when it meets
   nothing, the environment: returns 1 with the light in *light (-1: an
   emissive triangle of no light, which brings nothing), its radiance
   towards the ray in le and, for the MIS weight, the point and normal in
   lx, ln. Returns 0 if the ray meets a surface that is no emitter (or
   nothing, in a scene without environment). */
static int pds__gi_emitter(const pds_scene *s, pds__v3 org, pds__v3 dir, int found, const pds__tri_hit *th, int lh,
                           double tl, pds__v3 nl, int *light, double le[3], pds__v3 *lx, pds__v3 *ln)
{
    pds_hit hit;
    *light = -1;
    if (lh >= 0) {
        *lx = pds__add(org, pds__scale(dir, tl));
        *ln = nl;
    } else if (found && s->materials.items[s->mesh.mat[th->tri]].type == PDS_MAT_EMISSIVE) {
        pds__scene_fill_hit(s, th, org, dir, &hit);
        lh = pds__light_of_triangle(&s->light_table, th->tri);
        *lx = hit.position;
        *ln = hit.ng;
        if (lh < 0) return 1;
    } else if (!found && s->env_index1) {
        *light = s->env_index1 - 1;
        pds__env_radiance(&s->lights[*light], dir, le);
        return 1;
    } else {
        return 0;
    }
    pds__light_le(&s->lights[lh], *ln, pds__scale(dir, -1.0), le);
    *light = lh;
    return 1;
}

/* The density of light `light` being sampled (pds__gi_direct: picked by
   power, then its own sample) in direction wi from x, which meets it at
   lx with normal ln: the other side of the MIS weights. */
static double pds__gi_light_pdf(const pds_scene *s, int light, pds__v3 x, pds__v3 wi, pds__v3 lx, pds__v3 ln)
{
    double pmf = pds__lights_pmf(&s->light_table, light);
    if (s->lights[light].type == PDS_LIGHT_ENVIRONMENT)
        return pmf * pds__env_pdf(&s->lights[light], &s->light_table.env_p[3 * light], wi);
    return pmf * pds__light_pdf_li(&s->light_table, &s->lights[light], light, &s->mesh, x, lx, ln);
}

/* Jensen's short gathers (pds__gi_bounce_on): a gather ray from x1 is
   short when it is shorter than this times the radius of the map's
   estimate where it ends. Measured beside a lit wall (test
   gi_gather_near_a_corner_agrees_with_path_tracing, 20,000 global
   photons): 0 (never) -0.86% against pt, 1 -0.37%, 2 -0.29%, 4 -0.29%;
   in the Cornell box the block at the blue wall's foot -0.5% -> -0.2%,
   no CPU time measurable (README "Global illumination"). */
#define PDS__GI_SHORT 2.0
static void pds__gi_bounce_on(const pds__gi_map *g, const pds__tracer *tr, const pds_material *m,
                              const pds_material *scene_m, const pds_hit *hit, pds__v3 wo, const pds__gi_ray *r,
                              uint64_t idx, uint64_t dim, double L[3], long counts[4]);

/* The light leaving the gather's end x2 (a non-specular hit, material m
   as the ray r sees it, scene_m the scene's) towards x1, times r's
   throughput, into L (the partition of the light at x2 in the section's
   prologue):
   - direct (L x2): one light sample, as at x1 (pds__gi_direct, numbers
     dim..dim+2); at a glossy x2 weighted by the power heuristic against
     one BSDF sample (numbers dim+3..dim+5) that counts the emitter it
     meets straight away;
   - the rest (L (S|D)* S x2 and L (S|D)* D x2: caustics on x2 and light
     that left a non-specular surface before) from the global map, which
     holds no direct photons: its estimate (Jensen 1996, eqs. 3-4) or on
     a Lambertian x2 the precomputed irradiance; but where a gather ray
     from x1 is short (a Lambertian x2 closer to x1 along the ray than
     PDS__GI_SHORT times the estimate's radius), one more bounce
     (pds__gi_bounce_on).
   A map of streams (seed paper 003's system) stores its direct streams
   too: there the estimate alone is all of it. */
static void pds__gi_leaving_x2(const pds__gi_map *g, const pds__tracer *tr, const pds_material *m,
                               const pds_material *scene_m, const pds_hit *hit, pds__v3 wo, pds__gi_ray *r,
                               uint64_t idx, uint64_t dim, double L[3], long counts[4])
{
    const pds_scene *s = tr->scene;
    pds__v3 ngw = pds__dot(hit->ng, wo) >= 0.0 ? hit->ng : pds__scale(hit->ng, -1.0);
    double est[3], lambda_e, r2 = 0.0;
    const double *w = pds__gi_ray_weight(r, &lambda_e);
    int c, glossy = m->type == PDS_MAT_GLOSSY;
    if (!(g->irr && m->type == PDS_MAT_DIFFUSE && lambda_e == 0.0 &&
          pds__gi_irradiance_lookup(g, m, hit->position, ngw, est, &r2)))
        pds__gi_estimate(g, m, hit->position, wo, hit->ns, hit->ng, lambda_e, 0, est, &r2);
    if (r->stage == 1 && !g->streams && m->type == PDS_MAT_DIFFUSE &&
        r->travelled * r->travelled < PDS__GI_SHORT * PDS__GI_SHORT * r2) {
        /* short: the caustics on x2 from the map's caustic photons, the
           light that left a non-specular surface by one more bounce */
        pds__gi_estimate(g, m, hit->position, wo, hit->ns, hit->ng, lambda_e, 1, est, NULL);
        pds__gi_bounce_on(g, tr, m, scene_m, hit, wo, r, idx, dim, L, counts);
        for (c = 0; c < 3; c++) L[c] += w[c] * est[c];
    } else {
        for (c = 0; c < 3; c++) L[c] = w[c] * est[c];
    }
    if (g->streams) return;
    pds__gi_direct(g, tr, m, hit->position, wo, hit->ns, hit->ng, r, idx, dim, glossy, L, counts);
    if (glossy) {
        double u[3], tl = 0.0, le[3], seen[3] = {0.0, 0.0, 0.0}, mis;
        pds__bsdf_result bs;
        pds__tri_hit th;
        pds__v3 org, nl = pds__v(0.0, 0.0, 0.0), lx, ln;
        pds__gi_ray rr = *r;
        int found, lh, light;
        for (c = 0; c < 3; c++) u[c] = pds__rng_uniform(tr->seed, PDS__RNG_GATHER, idx, dim + 3 + (uint64_t)c);
        if (!pds__bsdf_sample(m, hit->position, wo, hit->ns, hit->ng, u, PDS__RADIANCE, &bs) || !(bs.pdf > 0.0))
            return;
        org = pds__offset(tr, hit->position, hit->ng, bs.wi);
        found = pds__bvh_intersect(&s->bvh, org, bs.wi, 0.0, DBL_MAX, &th);
        lh = pds__hit_analytic_light(s, org, bs.wi, found ? th.t : DBL_MAX, &tl, &nl);
        if (!pds__gi_emitter(s, org, bs.wi, found, &th, lh, tl, nl, &light, le, &lx, &ln) || light < 0) return;
        mis = pds__mis_power(bs.pdf, pds__gi_light_pdf(s, light, hit->position, bs.wi, lx, ln));
        pds__gi_ray_scatter(&rr, m, scene_m, bs.weight, bs.side);
        pds__gi_ray_sees(&rr, le, seen);
        for (c = 0; c < 3; c++) L[c] += seen[c] * mis;
    }
}

/* Radiance arriving along (org, dir) from the scene as the gather sees
   it: through specular surfaces (Fresnel choice by the numbers of
   dimension dim on), at the first non-specular hit x2 the light leaving
   it (pds__gi_leaving_x2), times the ray's throughput r (pds__gi_ray;
   RGB renders start it at 1, spectral ones at the whole weight from the
   camera, so that it can turn spectral on the way). An emitter reached
   with no specular bounce before it is returned in *light (its index,
   else -1) with its radiance times the throughput in L, the point and
   normal for the MIS weight; one reached through a specular bounce is a
   caustic of x1 and brings nothing. counts as pds__gi_direct's. */
static void pds__gi_incoming(const pds__gi_map *g, const pds__tracer *tr, pds__v3 org, pds__v3 dir, uint64_t idx,
                             uint64_t dim, pds__gi_ray *r, double L[3], int *light, pds__v3 *lx, pds__v3 *ln,
                             long counts[4])
{
    const pds_scene *s = tr->scene;
    pds_material m_lambda;
    int depth, c;
    L[0] = L[1] = L[2] = 0.0;
    *light = -1;
    for (depth = 0; depth <= tr->max_depth; depth++) {
        pds__tri_hit th;
        pds_hit hit;
        double tl = 0.0, u[3], le[3];
        pds__v3 nl = pds__v(0.0, 0.0, 0.0);
        int found = pds__bvh_intersect(&s->bvh, org, dir, 0.0, DBL_MAX, &th);
        int lh = pds__hit_analytic_light(s, org, dir, found ? th.t : DBL_MAX, &tl, &nl);
        const pds_material *m, *scene_m;
        pds__bsdf_result bs;
        if (pds__gi_emitter(s, org, dir, found, &th, lh, tl, nl, light, le, lx, ln)) {
            /* through a specular bounce: a caustic of x1 (the caustic
               method's); on a short gather's bounce from x2 nothing (x2's
               light sample and the map's caustic photons count it) */
            if (depth > 0 || r->stage == 2) *light = -1;
            if (*light >= 0) pds__gi_ray_sees(r, le, L);
            return;
        }
        if (!found) return;
        pds__scene_fill_hit(s, &th, org, dir, &hit);
        pds__gi_ray_beer(r, th.t);
        r->travelled += th.t;
        scene_m = &s->materials.items[hit.material];
        m = pds__gi_ray_meet(r, scene_m, &m_lambda);
        if (r->stage == 2 && pds__material_is_specular(m)) return; /* L (S|D)* S x2: the map's caustic photons */
        if (!pds__material_is_specular(m)) {
            pds__gi_leaving_x2(g, tr, m, scene_m, &hit, pds__scale(dir, -1.0), r, idx, dim + 4 * (uint64_t)depth, L,
                               counts);
            return;
        }
        if (depth == tr->max_depth) return;
        for (c = 0; c < 3; c++) u[c] = pds__rng_uniform(tr->seed, PDS__RNG_GATHER, idx, dim + 4 * (uint64_t)depth + (uint64_t)c);
        if (!pds__bsdf_sample(m, hit.position, pds__scale(dir, -1.0), hit.ns, hit.ng, u, PDS__RADIANCE, &bs)) return;
        pds__gi_ray_scatter(r, m, scene_m, bs.weight, bs.side);
        org = pds__offset(tr, hit.position, hit.ng, bs.wi);
        dir = bs.wi;
    }
}

/* Jensen's short-gather rule (1996, sect. 4: the accurate evaluation
   "if the distance between the ray origin and the intersection point is
   below a small threshold value -- otherwise we might risk inaccurate
   colour bleeding effects in corners"): a gather ray from x1 whose end
   x2 (Lambertian) lies closer to x1, along the ray, than
   PDS__GI_SHORT times the radius of the map's estimate there takes from
   the map only the caustics on x2 (L (S|D)* S x2: its photons whose
   bounce before was specular, in the same estimate), and the light that
   left a non-specular surface x3 before (L (S|D)* D x2) by one more
   bounce: one cosine-distributed ray from x2 (numbers dim +
   PDS__GI_BOUNCE_DIMS on); where it meets a non-specular x3 straight
   away, the light leaving x3 (its light sample and the map's estimate,
   pds__gi_leaving_x2, no further bounce); where it meets an emitter
   (x2's direct light, its light sample's) or a specular surface (a
   caustic on x2, the photons') nothing. The light sample at x2 stays.
   This function: the bounce, into L, times r's throughput. */
#define PDS__GI_BOUNCE_DIMS ((uint64_t)1 << 32)
static void pds__gi_bounce_on(const pds__gi_map *g, const pds__tracer *tr, const pds_material *m,
                              const pds_material *scene_m, const pds_hit *hit, pds__v3 wo, const pds__gi_ray *r,
                              uint64_t idx, uint64_t dim, double L[3], long counts[4])
{
    uint64_t d1 = dim + PDS__GI_BOUNCE_DIMS;
    double ua = pds__rng_uniform(tr->seed, PDS__RNG_GATHER, idx, d1);
    double ub = pds__rng_uniform(tr->seed, PDS__RNG_GATHER, idx, d1 + 1);
    double f[3], pdf, cosine, wb[3], rad = sqrt(ua), phi = 2.0 * PDS__PI * ub;
    pds__v3 n, ngw, b1, b2, wi, lx, ln;
    pds__gi_ray rr = *r;
    int side, c, light;
    L[0] = L[1] = L[2] = 0.0;
    if (!pds__bsdf_frame(wo, hit->ns, hit->ng, &n, &ngw, &side)) return;
    pds__onb(n, &b1, &b2);
    wi = pds__normalize(pds__add(pds__add(pds__scale(b1, rad * cos(phi)), pds__scale(b2, rad * sin(phi))),
                                 pds__scale(n, sqrt(fmax(0.0, 1.0 - ua)))));
    cosine = pds__dot(wi, n);
    if (!(cosine > 0.0)) return;
    pds__bsdf_eval(m, hit->position, wo, wi, hit->ns, hit->ng, f, &pdf);
    for (c = 0; c < 3; c++) wb[c] = f[c] * PDS__PI; /* f cos / (cos / pi) */
    rr.stage = 2;
    rr.has_sigma = 0;
    rr.sigma_rgb = NULL;
    pds__gi_ray_scatter(&rr, m, scene_m, wb, 0);
    counts[2]++;
    pds__gi_incoming(g, tr, pds__offset(tr, hit->position, hit->ng, wi), wi, idx, d1 + 4, &rr, L, &light, &lx, &ln,
                     counts);
}

/* Dimensions of PDS__RNG_GATHER per camera sample: 0..2 the light sample,
   then PDS__GI_RAY_DIMS per gather ray (0..2 its direction, 4 on the
   specular bounces, 4 each). */
#define PDS__GI_RAY_DIMS 8192

/* Indirect light at the non-specular vertex (m, x, wo, ns, ng) by nrays
   gather rays, into acc, for an eye path of state ray (m is the material
   as it sees it); counts[2] += rays traced. Lambertian: directions from
   the guided cells (mix: share of cosine sampling); glossy: by the BSDF,
   with emitters hit straight away weighted against the light sample
   (power heuristic, counts 1 and nrays). */
static void pds__gi_gather(const pds__gi_map *g, const pds__tracer *tr, const pds_material *m, pds__v3 x, pds__v3 wo,
                           pds__v3 ns, pds__v3 ng, const pds__gi_ray *ray, uint64_t idx, int nrays, double mix,
                           double acc[3], long counts[4])
{
    const pds_scene *s = tr->scene;
    const double *beta = ray->beta;
    /* RGB renders: the gather ray's own throughput, times x1's weight at
       the end (the order of the products that the images' bits hang on);
       spectral ones: the whole weight travels with the ray */
    int whole = ray->lambda > 0.0;
    pds__v3 n, ngw, b1, b2;
    pds__gi_guide gd;
    int side, j, c, glossy = m->type == PDS_MAT_GLOSSY;
    if (nrays <= 0 || !pds__bsdf_frame(wo, ns, ng, &n, &ngw, &side)) return;
    pds__onb(n, &b1, &b2);
    if (!glossy) pds__gi_guide_build(g, x, n, b1, b2, ngw, mix, &gd);
    for (j = 0; j < nrays; j++) {
        uint64_t dim = 3 + (uint64_t)j * PDS__GI_RAY_DIMS;
        double ua = pds__rng_uniform(tr->seed, PDS__RNG_GATHER, idx, dim);
        double ub = pds__rng_uniform(tr->seed, PDS__RNG_GATHER, idx, dim + 1);
        double w[3], L[3], f[3], pdf;
        pds__v3 wi, lx, ln;
        pds__gi_ray gr;
        int light;
        if (glossy) {
            double u[3] = {ua, ub, 0.5};
            pds__bsdf_result bs;
            if (!pds__bsdf_sample(m, x, wo, ns, ng, u, PDS__RADIANCE, &bs)) continue;
            wi = bs.wi;
            pdf = bs.pdf;
            for (c = 0; c < 3; c++) w[c] = bs.weight[c];
        } else {
            double u0, u1, r, phi, z, cosine, pdf_cosine;
            double pc = pds__gi_guide_sample(&gd, ua, ub, &u0, &u1);
            r = sqrt(u0);
            phi = 2.0 * PDS__PI * u1;
            z = sqrt(fmax(0.0, 1.0 - u0));
            wi = pds__normalize(pds__add(pds__add(pds__scale(b1, r * cos(phi)), pds__scale(b2, r * sin(phi))),
                                         pds__scale(n, z)));
            cosine = pds__dot(wi, n);
            if (!(cosine > 0.0) || !(pc > 0.0)) continue;
            pds__bsdf_eval(m, x, wo, wi, ns, ng, f, &pdf_cosine);
            pdf = PDS__GI_GRID * PDS__GI_GRID * pc * cosine / PDS__PI;
            for (c = 0; c < 3; c++) w[c] = f[c] * cosine / pdf;
            if (!(w[0] > 0.0 || w[1] > 0.0 || w[2] > 0.0)) continue;
        }
        counts[2]++;
        if (whole) {
            gr = *ray;
            pds__gi_ray_scatter(&gr, m, m, w, 0);
        } else {
            pds__gi_ray_start(&gr, tr, 0.0);
        }
        gr.has_sigma = 0; /* x1's medium is not followed (as in RGB) */
        gr.sigma_rgb = NULL;
        gr.stage = 1;
        gr.travelled = 0.0;
        pds__gi_incoming(g, tr, pds__offset(tr, x, ng, wi), wi, idx, dim + 4, &gr, L, &light, &lx, &ln, counts);
        if (light >= 0) {
            /* direct light: only a glossy vertex counts it here, by MIS */
            double mis;
            if (!glossy) continue;
            mis = pds__mis_power(nrays * pdf, pds__gi_light_pdf(s, light, x, wi, lx, ln));
            for (c = 0; c < 3; c++) L[c] *= mis;
        }
        for (c = 0; c < 3; c++) acc[c] += (whole ? L[c] : beta[c] * w[c] * L[c]) / nrays;
    }
}

/* gi's eye path (a pds__path_fn): through specular surfaces to the first
   non-specular vertex x1, which is recorded for the caustic method; there
   the light sample and the final gather. An emitter seen through the
   specular chain gives its radiance. lambda: the camera sample's
   wavelength in a spectral render (pds__gi_ray), else 0. */
static int pds__gi_path(const void *ctx, const pds__tracer *tr, pds__v3 org, pds__v3 dir, uint64_t idx, double lambda,
                        double acc[3], pds__eye_vertex *rec, long counts[4], int values)
{
    const pds__gi_map *g = (const pds__gi_map *)ctx;
    const pds_scene *s = tr->scene;
    pds__gi_ray ray;
    pds_material m_lambda;
    int depth, c;
    pds__gi_ray_start(&ray, tr, lambda);
    for (depth = 0; depth <= tr->max_depth; depth++) {
        uint64_t dim = 2 + (uint64_t)depth * PDS__DIMS_PER_BOUNCE;
        pds__tri_hit th;
        pds_hit hit;
        double tl = 0.0, le[3], u[3], q;
        pds__v3 nl = pds__v(0.0, 0.0, 0.0);
        int found = pds__bvh_intersect(&s->bvh, org, dir, 0.0, DBL_MAX, &th);
        int lh = pds__hit_analytic_light(s, org, dir, found ? th.t : DBL_MAX, &tl, &nl);
        const pds_material *m, *scene_m;
        pds__bsdf_result bs;
        if (lh >= 0 || (found && s->materials.items[s->mesh.mat[th.tri]].type == PDS_MAT_EMISSIVE)) {
            double dist;
            if (g->record_only || !values) return 0;
            dist = lh >= 0 ? tl : th.t;
            if (lh < 0) {
                pds__scene_fill_hit(s, &th, org, dir, &hit);
                lh = pds__light_of_triangle(&s->light_table, th.tri);
                nl = hit.ng;
                if (lh < 0) return 0;
            }
            pds__light_le(&s->lights[lh], nl, pds__scale(dir, -1.0), le);
            pds__gi_ray_beer(&ray, dist);
            pds__gi_ray_sees(&ray, le, acc);
            return 0;
        }
        if (!found) {
            /* the environment seen through the specular chain */
            if (g->record_only || !s->env_index1) return 0;
            pds__env_radiance(&s->lights[s->env_index1 - 1], dir, le);
            pds__gi_ray_beer(&ray, DBL_MAX);
            pds__gi_ray_sees(&ray, le, acc);
            return 0;
        }
        pds__scene_fill_hit(s, &th, org, dir, &hit);
        pds__gi_ray_beer(&ray, th.t);
        scene_m = &s->materials.items[hit.material];
        m = pds__gi_ray_meet(&ray, scene_m, &m_lambda);
        if (!pds__material_is_specular(m)) {
            pds__v3 wo = pds__scale(dir, -1.0);
            double lambda_e;
            const double *imp = pds__gi_ray_weight(&ray, &lambda_e);
            int recorded = rec && pds__eye_vertex_set(rec, m, hit.position, hit.ns, hit.ng, wo, imp, hit.material);
            if (recorded) rec->lambda = (float)lambda_e;
            if (!g->record_only && values) {
                int glossy = m->type == PDS_MAT_GLOSSY;
                pds__gi_direct(g, tr, m, hit.position, wo, hit.ns, hit.ng, &ray, idx, 0, glossy ? g->gather : 0, acc,
                               counts);
                pds__gi_gather(g, tr, m, hit.position, wo, hit.ns, hit.ng, &ray, idx, g->gather, g->mix, acc, counts);
            }
            return recorded;
        }
        if (depth == tr->max_depth) return 0;
        for (c = 0; c < 3; c++) u[c] = pds__rng_uniform(tr->seed, PDS__RNG_PIXEL, idx, dim + 3 + (uint64_t)c);
        if (!pds__bsdf_sample(m, hit.position, pds__scale(dir, -1.0), hit.ns, hit.ng, u, PDS__RADIANCE, &bs)) return 0;
        pds__gi_ray_scatter(&ray, m, scene_m, bs.weight, bs.side);
        if (depth + 1 >= tr->rr_depth) {
            double b = fmax(ray.beta[0], fmax(ray.beta[1], ray.beta[2]));
            q = b < 1.0 ? b : 1.0;
            if (!(q > 0.0) || pds__rng_uniform(tr->seed, PDS__RNG_PIXEL, idx, dim + 6) >= q) return 0;
            for (c = 0; c < 3; c++) {
                ray.beta[c] /= q;
                ray.beta_rgb[c] /= q;
            }
        }
        org = pds__offset(tr, hit.position, hit.ng, bs.wi);
        dir = bs.wi;
    }
    return 0;
}
#else /* PDS_NO_GI */
/* This build leaves gi out: pds__options_check refuses the method. What
   >>api names of it stays, inert, so that >>api reads the same in every
   build; none of it is reached. */
#define PDS__GI_MAX_STORES 8
#define PDS__GI_MAX_SHADOW 4
#define PDS__GI_MAX_K 1000
typedef struct pds__gi_photon { float unused; } pds__gi_photon;
typedef struct pds__gi_shadow_photon { float unused; } pds__gi_shadow_photon;
typedef struct pds__gi_stream { float unused; } pds__gi_stream;
typedef struct pds__gi_map { int record_only; size_t n, ns, nstreams; } pds__gi_map;
static void pds__gi_map_free(pds__gi_map *g) { (void)g; }
static size_t pds__gi_map_bytes(const pds__gi_map *g) { (void)g; return 0; }
static pds_status pds__gi_map_build(pds__gi_map *g, const pds_scene *s, const pds_options *opt, int threads,
                                    pds_error *err)
{
    (void)g, (void)s, (void)opt, (void)threads;
    return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "this build leaves gi out (PDS_NO_GI)");
}
static int pds__gi_path(const void *ctx, const pds__tracer *tr, pds__v3 org, pds__v3 dir, uint64_t idx, double lambda,
                        double acc[3], pds__eye_vertex *rec, long counts[4], int values)
{
    (void)ctx, (void)tr, (void)org, (void)dir, (void)idx, (void)lambda, (void)acc, (void)rec, (void)counts, (void)values;
    return 0;
}
#endif /* PDS_NO_GI */

#ifndef PDS_NO_ISC
/* ===================================================================== */
/* >>isc                                                                 */
/* ===================================================================== */
/* Image-space caustics (Wyman and Davis, "Interactive Image-Space
   Techniques for Approximating Caustics", I3D 2006), on the CPU, on the
   scene, camera, lights and BVH of the other methods.

   1. Light-space photon buffer (sect. 3.1, Fig. 1c, Fig. 3): one photon per
      texel of an R x R pinhole view from each point or spot light, fitted
      around the specular triangles as the light sees them (the paper used
      a fixed 90-degree view). Photon (i, j) leaves through
      the image-plane point of texel coordinates (i + jx, j + jy), (jx, jy)
      this frame's sub-texel offset, and is traced through the specular
      surfaces. It stores where it first meets a non-specular surface after
      at least one specular bounce, that surface's normal, the light's
      intensity in its direction times the Fresnel and Beer factors of its
      path (W/sr), and a hash of its specular path. One path per texel, as
      a rasteriser draws one: a dielectric refracts (reflects only under
      total internal reflection), weighted by the Fresnel transmittance;
      the paper notes that both branches "would require multiple rendering
      passes".
   2. Eye buffer: one ray per pixel centre, through specular surfaces on
      the same one-path rule, to the first non-specular point. Direct light
      there comes from a shadow ray to each light (exact, where the paper
      used a shadow map); caustic radiance is the BRDF times the caustic
      irradiance E a gather gives, times the eye path's throughput.
   3. Gathers (each gives E in W/m^2 per pixel, and a photon count):
      points  each photon adds its flux to the pixel it projects to,
              E = sum Phi / A_p (sect. 3.2, Fig. 4), A_p the pixel's area
              on the surface, eq. 5: A_p = omega_V d_V^2 / (-V . N).
      quads   neighbouring photons (i,j), (i+1,j), (i+1,j+1), (i,j+1) that
              followed the same specular path span a caustic polygon P;
              the beam B between their four directions carries
              Phi_B = I omega_B (eq. 1 with E_L = 4 pi I), and P's
              irradiance is Phi_B / A_P: eqs. 2-3's ratio of solid angles
              R = omega_B / omega_P times the direct irradiance I omega_P /
              A_P. P is rasterised into the eye image (two triangles,
              fixed-point edge functions with a top-left rule, so shared
              edges are covered exactly once).
      eye     photons are counted into the eye-space pixels they project
              to; each pixel gathers its 7x7 neighbourhood with Gaussian
              weights (sect. 3.2.2 steps 1-4): E = sum_q G(q - p) Phi_q /
              A_q, only neighbours on the same surface counting, and no
              caustic where fewer than 3 photons hit the neighbourhood
              (step 5).
      light   the same in a light-space map (same light view, widened to
              hold every landing point, R x R): a texel's irradiance is
              sum Phi |cos| / (omega_texel d^2) (eqs. 6 and 8: the area a
              texel covers is omega d^2 / cos), smoothed 7x7, and looked
              up bilinearly at every eye point like a projective texture;
              eye points seen in mirrors or through glass get it too.
   4. Temporal filter (sect. 3.2.3): the estimates of the last H frames
      (H = history, the paper's 4) are averaged per pixel and the 3-photon
      threshold is applied to their summed counts. Each frame shifts the
      light-space grid by its own sub-texel offset, so a static scene's
      frames sample different photons and the filter averages them; with a
      moving light or camera it lags (ghosting), as the paper says.
   5. Static lighting (sect. 4: "the photon buffer does not need
      rerendering under static lighting"; Table 1's static columns): with
      pds_options.static_lighting, for frames whose light and scene stand
      still (the camera orbits, or nothing), each light's buffer is traced
      once, at frame 0's grid offset, and so is the light gather's map;
      later frames redo only the eye buffer and direct light (if the
      camera moved), the photons' projections and the gathers that depend
      on the eye, and the filter. Every frame is what rendering it anew
      with the option gives, bit for bit. The frames' own grid offsets are
      given up: a still camera's frames are all alike.
   6. Spectral renders (>>spectral; a dispersive material, or
      pds_options.spectral): photon (i, j) carries a wavelength, one in
      each of 16 strata per 4 x 4 block by a Bayer matrix, rotated by the
      frame's offset (pds__isc_wavelength), and goes on spectrally from its
      first dispersive material (with pds_options.spectral, its first
      specular one): its e becomes its value at lambda times the film
      weight W(lambda), and n(lambda) refracts it, so a prism fans the
      buffer out. The gathers sum these signed values as they sum RGB
      ones (in floating point: no separate negative sums are needed).
      Quads join photons 4 apart, which share a wavelength. The eye
      buffer's rays take the pixels' wavelengths the same way and turn
      spectral at dispersive glass only: such a pixel holds at its own
      wavelength, and takes its direct light and the gathered irradiance
      there (the irradiance as a colour, uplifted: the gathers do not keep
      the photons' wavelengths apart). A pixel seen through a prism thus
      shows one wavelength, in a 4 x 4 dither (a time budget's frames keep
      the first frame's eye buffer and so its wavelengths).
      The receiver's colour filters a spectral photon's light as RGB
      (exact for grey receivers).

   Approximations (README "Image-space caustics"): point and spot lights
   only; one specular path per photon and per pixel; no indirect diffuse
   light; points, quads and eye see only caustics on surfaces seen
   directly; the light map has no depth (a receiver behind another along a
   light ray gets the front one's caustic); aliasing at the light-space
   and eye-space resolutions.

   Determinism: the only random numbers are the frame offsets, (seed,
   PDS__RNG_ISC, frame) (frame 0 with static lighting), of the grid and
   of the wavelengths. Work is split over threads in fixed chunks that
   write only their own outputs; every sum over photons is done by one
   thread in photon order. So images do not depend on the thread count. */

/* The light's view: square pinhole frustum from origin along axis, image
   plane at distance 1 spanned by the unit vectors b1 (texel i) and b2
   (texel j), half-width tan_half; res texels per side. */
typedef struct pds__isc_view {
    pds__v3 origin, axis, b1, b2;
    double tan_half;
    int res;
    double jx, jy; /* this frame's photon offset in texels, [0, 1) */
} pds__isc_view;

/* Image-plane coordinate of texel coordinate u (texel i spans [i, i+1)). */
static double pds__isc_plane(const pds__isc_view *v, double u)
{
    return (2.0 * u / v->res - 1.0) * v->tan_half;
}

static pds__v3 pds__isc_view_dir(const pds__isc_view *v, double u, double w)
{
    return pds__normalize(pds__add(v->axis, pds__add(pds__scale(v->b1, pds__isc_plane(v, u)),
                                                     pds__scale(v->b2, pds__isc_plane(v, w)))));
}

/* Solid angle of the rectangle [x0,x1] x [y0,y1] of the plane at distance
   1 from the eye, the plane's foot at (0,0): the rectangle [0,a] x [0,b]
   subtends atan(a b / sqrt(1 + a^2 + b^2)) (the solid angle of a
   rectangular pyramid, e.g. Mathar, "Solid angle of a rectangular plate",
   2014), which is odd in a and in b, so any rectangle is four such terms. */
static double pds__rect_solid_angle(double x0, double x1, double y0, double y1)
{
    double a = atan(x1 * y1 / sqrt(1.0 + x1 * x1 + y1 * y1)), b = atan(x0 * y1 / sqrt(1.0 + x0 * x0 + y1 * y1));
    double c = atan(x1 * y0 / sqrt(1.0 + x1 * x1 + y0 * y0)), d = atan(x0 * y0 / sqrt(1.0 + x0 * x0 + y0 * y0));
    return fabs(a - b - c + d);
}

/* Intensity (W/sr per channel) of a point or spot light toward unit dir. */
static void pds__isc_intensity(const pds_light *l, pds__v3 dir, double I[3])
{
    int c;
    for (c = 0; c < 3; c++) {
        if (l->type == PDS_LIGHT_SPOT) {
            double ci, co;
            pds__light_spot_cones(l, &ci, &co);
            I[c] = pds__light_spot_i0(l, c, ci, co) *
                   pds__light_spot_falloff(pds__dot(dir, pds__normalize(l->direction)), ci, co);
        } else {
            I[c] = l->power[c] / (4.0 * PDS__PI);
        }
    }
}

/* Wavelengths of a spectral render (>>spectral): light-space photon
   (i, j), and pixel (x, y), take the value b in 0..15 of its place in the
   4 x 4 Bayer matrix (an ordered dither, Bayer 1973), rotated by the
   frame's uniform u: lambda = 380 nm + 25 nm ((b + 16 u) mod 16). So
   every 4 x 4 block of photons or pixels holds one wavelength in each of
   the PDS__SPECTRAL_BINS = 16 strata of the range (25 nm apart), the
   photons 4 apart that share one can span a caustic polygon (quads), and
   over frames (or seeds) each photon's and each pixel's wavelength is
   uniform on the whole range (a Cranley-Patterson rotation of the 16
   dither values), so no pixel keeps one part of the spectrum. */
#define PDS__ISC_LAMBDA_SIDE 4
typedef char pds__isc_bins_are_16[PDS__SPECTRAL_BINS == PDS__ISC_LAMBDA_SIDE * PDS__ISC_LAMBDA_SIDE ? 1 : -1];
static const unsigned char pds__isc_bayer[4][4] = {{0, 8, 2, 10}, {12, 4, 14, 6}, {3, 11, 1, 9}, {15, 7, 13, 5}};

static double pds__isc_wavelength(long i, long j, double u)
{
    double bin = (PDS__LAMBDA_MAX - PDS__LAMBDA_MIN) / PDS__SPECTRAL_BINS;
    double t = pds__isc_bayer[j & 3][i & 3] + PDS__SPECTRAL_BINS * u;
    if (t >= PDS__SPECTRAL_BINS) t -= PDS__SPECTRAL_BINS;
    return PDS__LAMBDA_MIN + bin * t;
}

/* The one specular continuation ISC follows (a rasteriser's single path):
   mirrors and conductors reflect, dielectrics refract, or reflect under
   total internal reflection. It is pds__bsdf_sample's event with the
   choice fixed (u0 just below 1 picks reflection only when F = 1), and
   the throughput of that event, weight x probability. Returns 0 when the
   path ends (absorbed, or a direction on the wrong side). */
static int pds__isc_specular(const pds_material *m, const pds_hit *hit, pds__v3 dir, pds__transport mode,
                             pds__bsdf_result *bs)
{
    const double u[3] = {1.0 - DBL_EPSILON, 0.5, 0.5};
    int c;
    if (!pds__bsdf_sample(m, hit->position, pds__scale(dir, -1.0), hit->ns, hit->ng, u, mode, bs)) return 0;
    for (c = 0; c < 3; c++) bs->weight[c] *= bs->pdf;
    return bs->weight[0] > 0.0 || bs->weight[1] > 0.0 || bs->weight[2] > 0.0;
}

/* A photon of the light-space buffer, 40 bytes:
     pos   where it landed (first non-specular surface after >= 1
           specular bounce)
     n     unit geometric normal there, on the side it arrived from
     e     W/sr: the light's intensity in its direction times the Fresnel
           and Beer factors of its path; its flux is e x the solid angle
           it stands for
     path  hash of its specular path (materials and sides); 0: no caustic
           photon (it missed, hit a non-specular surface first, or died) */
typedef struct pds__isc_photon {
    float pos[3], n[3], e[3];
    unsigned path;
} pds__isc_photon;

/* Trace the photon leaving light l's position in unit direction dir.
   Spectral renders: lambda (nm) is its wavelength, from which it goes on
   spectrally at its first dispersive material (spectral_all: its first
   specular one), as the other methods' photons do (>>spectral): its
   weight becomes its value at lambda times the film weight W(lambda),
   and materials are taken at lambda; 0 in RGB renders. */
static void pds__isc_trace(const pds_scene *s, const pds_light *l, pds__v3 dir, int max_depth, double eps,
                           double lambda, int spectral_all, pds__isc_photon *ph)
{
    double w[3], sigma_buf[3], lam = 0.0;
    const double *sigma = NULL;
    pds_material m_lambda;
    pds__v3 org = l->position;
    unsigned path = 2166136261u; /* FNV-1a offset basis */
    int depth, c;
    memset(ph, 0, sizeof *ph);
    pds__isc_intensity(l, dir, w);
    for (depth = 0; depth <= max_depth; depth++) {
        pds__tri_hit th;
        pds_hit hit;
        const pds_material *m;
        pds__bsdf_result bs;
        if (!pds__bvh_intersect(&s->bvh, org, dir, 0.0, DBL_MAX, &th)) return;
        m = &s->materials.items[s->mesh.mat[th.tri]];
        if (depth == 0 && !pds__material_is_specular(m)) return; /* direct light, not a caustic */
        pds__scene_fill_hit(s, &th, org, dir, &hit);
        pds__beer(sigma, th.t, w);
        if (!pds__material_is_specular(m)) {
            if (m->type != PDS_MAT_DIFFUSE) return;
            pds__f3_set(ph->pos, hit.position);
            pds__f3_set(ph->n, pds__dot(hit.ng, dir) < 0.0 ? hit.ng : pds__scale(hit.ng, -1.0));
            for (c = 0; c < 3; c++) ph->e[c] = (float)w[c];
            ph->path = path ? path : 1u;
            return;
        }
        if (lambda > 0.0 && lam == 0.0 && (spectral_all || pds__material_is_dispersive(m))) {
            double film[3], phi = pds__spectral_value(w, lambda);
            pds__film_weight(lambda, film);
            for (c = 0; c < 3; c++) w[c] = phi * film[c];
            if (sigma) {
                memcpy(sigma_buf, sigma, sizeof sigma_buf);
                pds__spectral_uplift(lambda, sigma_buf);
                sigma = sigma_buf;
            }
            lam = lambda;
        }
        if (lam > 0.0) {
            pds__spectral_material(m, lam, &m_lambda);
            m = &m_lambda;
        }
        if (depth == max_depth || !pds__isc_specular(m, &hit, dir, PDS__IMPORTANCE, &bs)) return;
        pds__spectral_uplift(lam, bs.weight);
        for (c = 0; c < 3; c++) w[c] *= bs.weight[c];
        if (m->type == PDS_MAT_DIELECTRIC) {
            sigma = pds__medium_absorption(m, bs.side);
            if (sigma && lam > 0.0) {
                /* m_lambda's, which the next material overwrites */
                memcpy(sigma_buf, sigma, sizeof sigma_buf);
                sigma = sigma_buf;
            }
        }
        path = (path ^ (unsigned)(2 * hit.material + bs.transmitted)) * 16777619u;
        path = (path ^ (unsigned)(bs.side > 0)) * 16777619u;
        org = pds__add(hit.position, pds__scale(hit.ng, pds__dot(hit.ng, bs.wi) >= 0.0 ? eps : -eps));
        dir = bs.wi;
    }
}

/* What the eye sees through pixel p's centre, 60 bytes:
     pos, n  first non-specular point, its unit geometric normal facing
             the eye path
     ns      the shading normal there, on the same side (pds__bsdf_frame)
     fr      the eye path's throughput times the BRDF there (1/sr):
             caustic radiance = fr x irradiance
     area    eq. 5: the pixel's area on the surface (m^2), when seen
             directly; 0 otherwise
     lambda  spectral renders: the pixel's wavelength (nm) when its path
             went through dispersive glass (fr is then the path's value at
             lambda times the film weight W(lambda), the same scalar in
             every channel before W); 0 otherwise
     kind    0: nothing; 1: seen directly; 2: through specular surfaces */
typedef struct pds__isc_pixel {
    float pos[3], n[3], ns[3], fr[3];
    float area;
    float lambda;
    int kind;
} pds__isc_pixel;

/* Per pixel and frame: caustic irradiance (W/m^2) and the photons behind it. */
typedef struct pds__isc_est {
    float e[3];
    float count;
} pds__isc_est;

/* A fragment of the quads gather: pixel and irradiance. */
typedef struct pds__isc_frag {
    int pixel;
    float e[3];
} pds__isc_frag;

#define PDS__ISC_MAX_HISTORY 64
#define PDS__ISC_RADIUS 3         /* the 7x7 neighbourhood */
#define PDS__ISC_SIGMA 1.5        /* its Gaussian, in pixels (the paper gives none) */
#define PDS__ISC_MIN_PHOTONS 3.0  /* sect. 3.2.2 step 5 */
#define PDS__ISC_QUAD_MAX_PIXELS 4096 /* a quad's screen box larger than this is skipped */
#define PDS__ISC_SUB 256          /* fixed-point subpixels of the quad rasteriser */
/* What is done for a light (pds__isc.state), kept across the frames of
   static lighting and cleared every frame otherwise. */
#define PDS__ISC_TRACED 1         /* its buffer (and light map) is traced */
#define PDS__ISC_NO_VIEW 2        /* no view holds its specular objects: no caustic */
#define PDS__ISC_FLUX 4           /* points, eye: its photons' e holds their flux (W) */

/* A render of one or more frames: the buffers live across frames (the
   temporal filter's history among them). */
typedef struct pds__isc {
    const pds_scene *scene;
    const pds_options *opt;
    pds_isc_gather gather;
    int w, h, threads, res, history;
    double eps, omega_pixel_scale;
    pds__camera_frame cam;
    pds__target target;
    pds_light *lights;          /* this frame's lights (orbit applied) */
    size_t nlights;
    const pds_light *light;     /* the light whose photons are in ph */
    size_t lk;                  /* its index */
    int fixed_grid;             /* static lighting: every frame takes frame 0's grid offset */
    int spectral, spectral_all; /* a spectral render (>>spectral); spectral photons from the light on */
    double photon_u, eye_u;     /* spectral: the photons' and the pixels' wavelength offset */
    int reuse;                  /* static lighting: each light's buffer (and light map) is
                                   traced once and kept for the frames after */
    unsigned char *state;       /* per light: PDS__ISC_TRACED, _NO_VIEW, _FLUX bits */
    pds__isc_view *views, *lviews; /* per light: its photon view and light-map view */
    pds__isc_pixel *px;         /* w x h */
    double *direct;             /* 3 per pixel: direct radiance */
    pds__isc_photon *ph_all;    /* res x res per light (reuse), else res x res */
    pds__isc_photon *ph;        /* the current light's res x res in ph_all */
    unsigned char *mask;        /* res x res: may the photon meet a specular surface first? */
    pds__isc_view view;         /* that light's view */
    int *ph_pixel;              /* points, eye: the pixel each photon deposits into, -1 none */
    long long *ph_xy;           /* quads: fixed-point screen position of each photon */
    signed char *ph_front;      /* quads: 1 if in front of the camera */
    float *dep;                 /* eye, light: 4 per cell (flux or irradiance x omega, count) */
    unsigned char *near_row;    /* eye: a photon within the gather radius in the row */
    float *lmap_all;            /* light: the gathered maps, 4 per texel, per light (reuse) */
    float *lmap;                /* light: the current light's map in lmap_all */
    pds__isc_view lview;        /* light: the map's view */
    pds__isc_est *est;          /* this frame's estimate */
    double *rgb;                /* the frame's image before conversion to float */
    long nonfinite;             /* image values that were NaN or beyond the float range */
    pds__isc_est *ring;         /* history frames of estimates */
    double *acc;                /* time budget: 4 per pixel, sums over every frame */
    int frames_done;
    pds__isc_frag **frags;      /* quads: one array per light-space row */
    size_t *nfrags, *capfrags;
    double gauss[2 * PDS__ISC_RADIUS + 1][2 * PDS__ISC_RADIUS + 1];
    long photons, landed, fragments;
    int out_of_memory;
    double time_eye, time_photons, time_gather;
    pds__mutex lock;
} pds__isc;

/* --- a parallel loop over fixed chunks ---------------------------------- */

typedef struct pds__isc_par {
    pds__isc *ctx;
    void (*fn)(pds__isc *ctx, long first, long last);
    long n, chunk, next;
    pds__mutex lock;
} pds__isc_par;

static void *pds__isc_par_worker(void *arg)
{
    pds__isc_par *p = (pds__isc_par *)arg;
    for (;;) {
        long first;
        pds__mutex_lock(&p->lock);
        first = p->next;
        p->next += p->chunk;
        pds__mutex_unlock(&p->lock);
        if (first >= p->n) break;
        p->fn(p->ctx, first, first + p->chunk < p->n ? first + p->chunk : p->n);
    }
    return NULL;
}

/* fn(ctx, first, last) over [0, n) in chunks; each item's output must not
   depend on which thread runs it. */
static void pds__isc_parallel(pds__isc *ctx, long n, long chunk, void (*fn)(pds__isc *, long, long))
{
    pds__isc_par p;
    p.ctx = ctx;
    p.fn = fn;
    p.n = n;
    p.chunk = chunk > 0 ? chunk : 1;
    p.next = 0;
    pds__mutex_init(&p.lock);
    pds__run_threads(ctx->threads < 1 ? 1 : ctx->threads, pds__isc_par_worker, &p);
    pds__mutex_destroy(&p.lock);
}

/* --- the eye buffer --------------------------------------------------- */

/* Points go to pixels by pds__camera_project (>>debug). */

/* Solid angle of pixel (x, y) seen from the camera. */
static double pds__isc_pixel_omega(const pds__camera_frame *f, int x, int y)
{
    double ax = f->tan_half_fov * f->aspect, ay = f->tan_half_fov;
    return pds__rect_solid_angle((2.0 * x / f->width - 1.0) * ax, (2.0 * (x + 1) / f->width - 1.0) * ax,
                                 (1.0 - 2.0 * (y + 1) / f->height) * ay, (1.0 - 2.0 * y / f->height) * ay);
}

/* The eye buffer's geometry: one ray through each pixel centre, through
   specular surfaces on the one-path rule, to the first diffuse point. It
   depends on the camera alone, so an animation whose camera stands still
   traces it once. Spectral renders: the ray carries the pixel's
   wavelength and goes on spectrally from its first dispersive material
   (>>spectral; even with pds_options.spectral, as one ray per pixel at one
   wavelength would leave a fixed colour dither on every surface, where
   the RGB ray gives the mean over the wavelengths). */
static void pds__isc_eye_rows(pds__isc *ctx, long first, long last)
{
    const pds_scene *s = ctx->scene;
    long y;
    int x, c;
    for (y = first; y < last; y++) {
        for (x = 0; x < ctx->w; x++) {
            size_t p = (size_t)y * (size_t)ctx->w + (size_t)x;
            pds__isc_pixel *out = &ctx->px[p];
            pds__v3 org = ctx->cam.origin, dir = pds__camera_dir(&ctx->cam, x + 0.5, y + 0.5);
            double beta[3] = {1.0, 1.0, 1.0}, sigma_buf[3], lam = 0.0;
            double lambda = ctx->spectral ? pds__isc_wavelength(x, y, ctx->eye_u) : 0.0;
            const double *sigma = NULL;
            pds_material m_lambda;
            int depth;
            memset(out, 0, sizeof *out);
            for (depth = 0; depth <= ctx->opt->max_depth; depth++) {
                pds__tri_hit th;
                pds_hit hit;
                const pds_material *m;
                pds__bsdf_result bs;
                pds__v3 wo = pds__scale(dir, -1.0), n, g;
                double f[3], pdf;
                int side;
                if (!pds__bvh_intersect(&s->bvh, org, dir, 0.0, DBL_MAX, &th)) break;
                pds__scene_fill_hit(s, &th, org, dir, &hit);
                pds__beer(sigma, th.t, beta);
                m = &s->materials.items[hit.material];
                if (lambda > 0.0 && lam == 0.0 && pds__material_is_dispersive(m)) {
                    /* the path turns spectral: its throughput and medium at lambda */
                    lam = lambda;
                    pds__spectral_uplift(lam, beta);
                    if (sigma) {
                        memcpy(sigma_buf, sigma, sizeof sigma_buf);
                        pds__spectral_uplift(lam, sigma_buf);
                        sigma = sigma_buf;
                    }
                }
                if (lam > 0.0) {
                    pds__spectral_material(m, lam, &m_lambda);
                    m = &m_lambda;
                }
                if (pds__material_is_specular(m)) {
                    if (depth == ctx->opt->max_depth || !pds__isc_specular(m, &hit, dir, PDS__RADIANCE, &bs)) break;
                    pds__spectral_uplift(lam, bs.weight);
                    for (c = 0; c < 3; c++) beta[c] *= bs.weight[c];
                    if (m->type == PDS_MAT_DIELECTRIC) {
                        sigma = pds__medium_absorption(m, bs.side);
                        if (sigma && lam > 0.0) {
                            memcpy(sigma_buf, sigma, sizeof sigma_buf);
                            sigma = sigma_buf;
                        }
                    }
                    org = pds__add(hit.position, pds__scale(hit.ng, pds__dot(hit.ng, bs.wi) >= 0.0 ? ctx->eps : -ctx->eps));
                    dir = bs.wi;
                    continue;
                }
                if (m->type != PDS_MAT_DIFFUSE || !pds__bsdf_frame(wo, hit.ns, hit.ng, &n, &g, &side)) break;
                /* Lambertian: f is the same for every wi above the frame
                   normal n and in front of g, so fr serves every light */
                pds__bsdf_eval(m, hit.position, wo, n, hit.ns, hit.ng, f, &pdf);
                pds__f3_set(out->pos, hit.position);
                pds__f3_set(out->n, g);
                pds__f3_set(out->ns, n);
                if (lam > 0.0) {
                    double film[3];
                    pds__film_weight(lam, film);
                    pds__spectral_uplift(lam, f);
                    for (c = 0; c < 3; c++) f[c] *= film[c];
                    out->lambda = (float)lam;
                }
                for (c = 0; c < 3; c++) out->fr[c] = (float)(beta[c] * f[c]);
                out->kind = depth == 0 ? 1 : 2;
                if (depth == 0)
                    out->area = (float)(pds__isc_pixel_omega(&ctx->cam, x, (int)y) * th.t * th.t / fabs(pds__dot(dir, g)));
                break;
            }
        }
    }
}

/* Direct light at each eye point: a shadow ray to each light,
   fr I cos / d^2 (the exact test a shadow map approximates). */
static void pds__isc_direct_rows(pds__isc *ctx, long first, long last)
{
    const pds_scene *s = ctx->scene;
    size_t p, k;
    int c;
    for (p = (size_t)first * ctx->w; p < (size_t)last * ctx->w; p++) {
        const pds__isc_pixel *px = &ctx->px[p];
        double *direct = &ctx->direct[3 * p];
        pds__v3 x = pds__f3_get(px->pos), g = pds__f3_get(px->n), n = pds__f3_get(px->ns);
        direct[0] = direct[1] = direct[2] = 0.0;
        if (!px->kind) continue;
        for (k = 0; k < ctx->nlights; k++) {
            const pds_light *l = &ctx->lights[k];
            pds__v3 d = pds__sub(l->position, x), wi;
            double d2 = pds__dot(d, d), I[3], cosine;
            if (!(d2 > 0.0)) continue;
            wi = pds__scale(d, 1.0 / sqrt(d2));
            cosine = pds__dot(wi, n);
            if (!(cosine > 0.0) || !(pds__dot(wi, g) > 0.0)) continue;
            if (pds__bvh_occluded(&s->bvh, pds__add(x, pds__scale(g, ctx->eps)), wi, 0.0, sqrt(d2) * (1.0 - 1e-4)))
                continue;
            pds__isc_intensity(l, pds__scale(wi, -1.0), I);
            pds__spectral_uplift(px->lambda, I); /* fr holds W(lambda) */
            for (c = 0; c < 3; c++) direct[c] += px->fr[c] * I[c] * cosine / d2;
        }
    }
}

/* --- the light-space photon buffer ---------------------------------------- */

/* mask[k]: can photon k meet a specular triangle first? Each specular
   triangle, all of whose corners are in front of the light, projects
   inside the box of its corners' projections; the photons whose image-
   plane points fall in that box (give or take a texel) are marked. A photon
   outside every box meets a diffuse surface or nothing first: no caustic,
   and no ray needed (the paper's sect. 5 asks for "avoiding processing on
   uninteresting photons"). The same photons as tracing them all. */
static void pds__isc_mask(pds__isc *ctx)
{
    const pds_scene *s = ctx->scene;
    const pds__isc_view *v = &ctx->view;
    size_t t, n = (size_t)v->res * (size_t)v->res;
    int k;
    memset(ctx->mask, 0, n);
    for (t = 0; t < s->mesh.ntris; t++) {
        double u0 = 0, u1 = 0, w0 = 0, w1 = 0;
        long i0, i1, j0, j1, i, j;
        if (!pds__material_is_specular(&s->materials.items[s->mesh.mat[t]])) continue;
        for (k = 0; k < 3; k++) {
            pds__v3 d = pds__sub(pds__mesh_pos(&s->mesh, s->mesh.idx[3 * t + k]), v->origin);
            double z = pds__dot(d, v->axis), u, w;
            if (!(z > 1e-9 * pds__length(d))) {
                memset(ctx->mask, 1, n); /* behind the light: trace everything */
                return;
            }
            /* texel coordinates: photon (i, j) is at (i + jx, j + jy) */
            u = (pds__dot(d, v->b1) / z / v->tan_half + 1.0) * 0.5 * v->res - v->jx;
            w = (pds__dot(d, v->b2) / z / v->tan_half + 1.0) * 0.5 * v->res - v->jy;
            if (k == 0 || u < u0) u0 = u;
            if (k == 0 || u > u1) u1 = u;
            if (k == 0 || w < w0) w0 = w;
            if (k == 0 || w > w1) w1 = w;
        }
        if (!(u1 >= -1.0 && w1 >= -1.0 && u0 <= v->res && w0 <= v->res)) continue;
        i0 = u0 < 0.0 ? 0 : (long)u0 - 1;
        j0 = w0 < 0.0 ? 0 : (long)w0 - 1;
        i1 = u1 >= v->res - 1 ? v->res - 1 : (long)u1 + 1;
        j1 = w1 >= v->res - 1 ? v->res - 1 : (long)w1 + 1;
        if (i0 < 0) i0 = 0;
        if (j0 < 0) j0 = 0;
        for (j = j0; j <= j1; j++)
            for (i = i0; i <= i1; i++) ctx->mask[(size_t)j * v->res + (size_t)i] = 1;
    }
}

static void pds__isc_photon_rows(pds__isc *ctx, long first, long last)
{
    long j;
    int i;
    for (j = first; j < last; j++)
        for (i = 0; i < ctx->res; i++) {
            size_t k = (size_t)j * ctx->res + i;
            pds__v3 dir;
            if (!ctx->mask[k]) {
                memset(&ctx->ph[k], 0, sizeof ctx->ph[k]);
                continue;
            }
            dir = pds__isc_view_dir(&ctx->view, i + ctx->view.jx, j + ctx->view.jy);
            pds__isc_trace(ctx->scene, ctx->light, dir, ctx->opt->photon_depth, ctx->eps,
                           ctx->spectral ? pds__isc_wavelength(i, j, ctx->photon_u) : 0.0, ctx->spectral_all,
                           &ctx->ph[k]);
        }
}

/* Half-extents (in b1, b2) and centre of the specular triangles' corners
   projected onto the view plane of v; 0 if a corner is not in front. */
static int pds__isc_view_extent(const pds_scene *s, const pds__isc_view *v, double *u0, double *u1, double *w0,
                                double *w1)
{
    size_t t;
    int k, any = 0;
    for (t = 0; t < s->mesh.ntris; t++) {
        if (!pds__material_is_specular(&s->materials.items[s->mesh.mat[t]])) continue;
        for (k = 0; k < 3; k++) {
            pds__v3 d = pds__sub(pds__mesh_pos(&s->mesh, s->mesh.idx[3 * t + k]), v->origin);
            double z = pds__dot(d, v->axis), u, w;
            if (!(z > 1e-9 * pds__length(d))) return 0;
            u = pds__dot(d, v->b1) / z;
            w = pds__dot(d, v->b2) / z;
            if (!any || u < *u0) *u0 = u;
            if (!any || u > *u1) *u1 = u;
            if (!any || w < *w0) *w0 = w;
            if (!any || w > *w1) *w1 = w;
            any = 1;
        }
    }
    return any;
}

/* The light's view for this frame: a square frustum around the specular
   triangles as the light sees them (their corners' projections, so every
   photon that can meet a specular surface is in it), widened by two
   texels so that the frame's offset keeps them inside. (Wyman and Davis
   used a fixed 90-degree view; focusing on the specular geometry is their
   sect. 5's future work, and puts more photons where caustics start.)
   Returns 0 when the light is inside the target sphere (one frustum
   cannot hold it; the paper would render several views). */
static int pds__isc_view_setup(const pds_scene *s, const pds__target *tg, pds__v3 pos, int res, double jx, double jy,
                               pds__isc_view *v)
{
    double cos_max, u0 = 0, u1 = 0, w0 = 0, w1 = 0, half;
    memset(v, 0, sizeof *v);
    if (!pds__target_cone(tg, pos, &v->axis, &cos_max) || !(cos_max > 1e-6)) return 0;
    v->origin = pos;
    pds__onb(v->axis, &v->b1, &v->b2);
    half = sqrt(fmax(0.0, 1.0 - cos_max * cos_max)) / cos_max;
    if (pds__isc_view_extent(s, v, &u0, &u1, &w0, &w1)) {
        /* aim at the middle of the projections, then measure again */
        v->axis = pds__normalize(pds__add(v->axis, pds__add(pds__scale(v->b1, 0.5 * (u0 + u1)),
                                                            pds__scale(v->b2, 0.5 * (w0 + w1)))));
        pds__onb(v->axis, &v->b1, &v->b2);
        if (pds__isc_view_extent(s, v, &u0, &u1, &w0, &w1))
            half = fmax(fmax(-u0, u1), fmax(-w0, w1)) * 1.0001;
    }
    v->tan_half = half * (1.0 + 2.0 / res);
    v->res = res;
    v->jx = jx;
    v->jy = jy;
    return 1;
}

/* The solid angle photon (i, j) stands for: the texel-sized cell centred
   on its image-plane point (the cells tile the plane, so the photons
   share the view's solid angle exactly). */
static double pds__isc_cell_omega(const pds__isc_view *v, int i, int j)
{
    double u = i + v->jx, w = j + v->jy;
    return pds__rect_solid_angle(pds__isc_plane(v, u - 0.5), pds__isc_plane(v, u + 0.5), pds__isc_plane(v, w - 0.5),
                                 pds__isc_plane(v, w + 0.5));
}

/* Is the point x (unit normal n) on the surface that pixel p sees
   directly? Normals within 60 degrees, and x within a slope of 1/4 of
   p's tangent plane give or take one pixel's size (a shadow map's bias,
   relative to the distance). */
static int pds__isc_same_surface(const pds__isc_pixel *p, pds__v3 x, pds__v3 n)
{
    pds__v3 pn, d;
    if (p->kind != 1) return 0;
    pn = pds__f3_get(p->n);
    d = pds__sub(x, pds__f3_get(p->pos));
    if (pds__dot(pn, n) < 0.5) return 0;
    return fabs(pds__dot(pn, d)) <= 0.25 * pds__length(d) + sqrt((double)p->area);
}

/* --- points and eye: photons into the eye-space pixels ----------------- */

/* Each photon's pixel (-1: none, or not on the surface seen there) and
   flux (W, in e's place: the gathers after this one need no intensity;
   once per traced buffer, PDS__ISC_FLUX). */
static void pds__isc_to_pixels(pds__isc *ctx, long first, long last)
{
    long j;
    int i, c, to_flux = !(ctx->state[ctx->lk] & PDS__ISC_FLUX);
    for (j = first; j < last; j++)
        for (i = 0; i < ctx->res; i++) {
            size_t k = (size_t)j * ctx->res + i;
            pds__isc_photon *ph = &ctx->ph[k];
            double px, py, omega;
            long q;
            ctx->ph_pixel[k] = -1;
            if (!ph->path) continue;
            if (to_flux) {
                omega = pds__isc_cell_omega(&ctx->view, i, (int)j);
                for (c = 0; c < 3; c++) ph->e[c] = (float)(ph->e[c] * omega);
            }
            if (!pds__camera_project(&ctx->cam, pds__f3_get(ph->pos), &px, &py)) continue;
            if (!(px >= 0.0 && py >= 0.0 && px < ctx->w && py < ctx->h)) continue;
            q = (long)py * ctx->w + (long)px;
            if (pds__isc_same_surface(&ctx->px[q], pds__f3_get(ph->pos), pds__f3_get(ph->n))) ctx->ph_pixel[k] = (int)q;
        }
}

/* Points (Fig. 4): E = sum Phi / A_p in the photons' pixels, in photon
   order. Eye: the same photons counted into dep for the 7x7 gather. */
static void pds__isc_points(pds__isc *ctx, int eye)
{
    size_t k, n = (size_t)ctx->res * (size_t)ctx->res;
    int c;
    for (k = 0; k < n; k++) {
        int q = ctx->ph_pixel[k];
        if (q < 0) continue;
        if (eye) {
            for (c = 0; c < 3; c++) ctx->dep[4 * (size_t)q + c] += ctx->ph[k].e[c];
            ctx->dep[4 * (size_t)q + 3] += 1.0f;
        } else {
            for (c = 0; c < 3; c++) ctx->est[q].e[c] += ctx->ph[k].e[c] / ctx->px[q].area;
            ctx->est[q].count += 1.0f;
        }
    }
}

/* near_row[p]: does a pixel of p's row within the gather radius hold a
   photon? (So the gather skips, with 7 tests, the pixels that no photon
   is near: most of them.) */
static void pds__isc_near_rows(pds__isc *ctx, long first, long last)
{
    long y;
    int x;
    for (y = first; y < last; y++) {
        const float *d = &ctx->dep[4 * (size_t)y * ctx->w];
        unsigned char *out = &ctx->near_row[(size_t)y * ctx->w];
        int last_photon = -1000000;
        for (x = 0; x < ctx->w; x++) out[x] = 0;
        for (x = 0; x < ctx->w + PDS__ISC_RADIUS; x++) {
            if (x < ctx->w && d[4 * x + 3] != 0.0f) last_photon = x;
            if (x - PDS__ISC_RADIUS >= 0) out[x - PDS__ISC_RADIUS] = x - last_photon <= 2 * PDS__ISC_RADIUS;
        }
    }
}

/* Eye-space gather (sect. 3.2.2): each directly seen pixel sums the
   irradiance Phi_q / A_q of the pixels q of its 7x7 neighbourhood that lie
   on its surface, weighted by the normalised Gaussian, and their counts. */
static void pds__isc_eye_gather(pds__isc *ctx, long first, long last)
{
    long y;
    int x, dx, dy, c;
    for (y = first; y < last; y++)
        for (x = 0; x < ctx->w; x++) {
            size_t p = (size_t)y * ctx->w + x;
            double e[3] = {0, 0, 0}, count = 0.0;
            int any = 0;
            if (ctx->px[p].kind != 1) continue;
            for (dy = -PDS__ISC_RADIUS; dy <= PDS__ISC_RADIUS && !any; dy++)
                any = y + dy >= 0 && y + dy < ctx->h && ctx->near_row[(size_t)(y + dy) * ctx->w + x];
            if (!any) continue;
            for (dy = -PDS__ISC_RADIUS; dy <= PDS__ISC_RADIUS; dy++) {
                long yy = y + dy;
                if (yy < 0 || yy >= ctx->h) continue;
                for (dx = -PDS__ISC_RADIUS; dx <= PDS__ISC_RADIUS; dx++) {
                    long xx = x + dx;
                    size_t q;
                    double g;
                    if (xx < 0 || xx >= ctx->w) continue;
                    q = (size_t)yy * ctx->w + (size_t)xx;
                    if (ctx->dep[4 * q + 3] == 0.0f) continue;
                    if (q != p && !pds__isc_same_surface(&ctx->px[p], pds__f3_get(ctx->px[q].pos), pds__f3_get(ctx->px[q].n)))
                        continue;
                    g = ctx->gauss[dy + PDS__ISC_RADIUS][dx + PDS__ISC_RADIUS] / ctx->px[q].area;
                    for (c = 0; c < 3; c++) e[c] += g * ctx->dep[4 * q + c];
                    count += ctx->dep[4 * q + 3];
                }
            }
            for (c = 0; c < 3; c++) ctx->est[p].e[c] += (float)e[c];
            ctx->est[p].count += (float)count;
        }
}

/* --- light: the light-space gather ------------------------------------- */

/* Each photon's texel of the light map (-1: none) and its
   Phi |cos| / d^2 (in e's place; the map divides by the texel's solid
   angle: eq. 6's area omega d^2 / cos). */
static void pds__isc_to_texels(pds__isc *ctx, long first, long last)
{
    const pds__isc_view *v = &ctx->lview;
    long j;
    int i, c;
    for (j = first; j < last; j++)
        for (i = 0; i < ctx->res; i++) {
            size_t k = (size_t)j * ctx->res + i;
            pds__isc_photon *ph = &ctx->ph[k];
            pds__v3 d = pds__sub(pds__f3_get(ph->pos), v->origin);
            double z = pds__dot(d, v->axis), d2 = pds__dot(d, d), u, w, cosine, omega;
            ctx->ph_pixel[k] = -1;
            if (!ph->path || !(z > 0.0)) continue;
            u = (pds__dot(d, v->b1) / z / v->tan_half + 1.0) * 0.5 * v->res;
            w = (pds__dot(d, v->b2) / z / v->tan_half + 1.0) * 0.5 * v->res;
            if (!(u >= 0.0 && w >= 0.0 && u < v->res && w < v->res)) continue;
            omega = pds__isc_cell_omega(&ctx->view, i, (int)j);
            cosine = fabs(pds__dot(pds__f3_get(ph->n), d)) / sqrt(d2);
            for (c = 0; c < 3; c++) ph->e[c] = (float)(ph->e[c] * omega * cosine / d2);
            ctx->ph_pixel[k] = (int)((long)w * v->res + (long)u);
        }
}

/* Texel irradiance: the deposits over the texels' solid angles. */
static void pds__isc_texel_irradiance(pds__isc *ctx, long first, long last)
{
    const pds__isc_view *v = &ctx->lview;
    long j;
    int i, c;
    for (j = first; j < last; j++)
        for (i = 0; i < v->res; i++) {
            size_t m = (size_t)j * v->res + i;
            double omega;
            if (ctx->dep[4 * m + 3] == 0.0f) continue;
            omega = pds__rect_solid_angle(pds__isc_plane(v, i), pds__isc_plane(v, i + 1), pds__isc_plane(v, j),
                                          pds__isc_plane(v, j + 1));
            for (c = 0; c < 3; c++) ctx->dep[4 * m + c] = (float)(ctx->dep[4 * m + c] / omega);
        }
}

/* The 7x7 Gaussian gather over the light map. */
static void pds__isc_light_gather(pds__isc *ctx, long first, long last)
{
    int res = ctx->lview.res, i, di, dj, c;
    long j;
    for (j = first; j < last; j++)
        for (i = 0; i < res; i++) {
            double e[3] = {0, 0, 0}, count = 0.0;
            float *out = &ctx->lmap[4 * ((size_t)j * res + i)];
            for (dj = -PDS__ISC_RADIUS; dj <= PDS__ISC_RADIUS; dj++) {
                long jj = j + dj;
                if (jj < 0 || jj >= res) continue;
                for (di = -PDS__ISC_RADIUS; di <= PDS__ISC_RADIUS; di++) {
                    long ii = i + di;
                    size_t m;
                    double g;
                    if (ii < 0 || ii >= res) continue;
                    m = (size_t)jj * res + (size_t)ii;
                    if (ctx->dep[4 * m + 3] == 0.0f) continue;
                    g = ctx->gauss[dj + PDS__ISC_RADIUS][di + PDS__ISC_RADIUS];
                    for (c = 0; c < 3; c++) e[c] += g * ctx->dep[4 * m + c];
                    count += ctx->dep[4 * m + 3];
                }
            }
            for (c = 0; c < 3; c++) out[c] = (float)e[c];
            out[3] = (float)count;
        }
}

/* Look the gathered map up at every eye point, bilinearly (a projective
   texture). */
static void pds__isc_light_lookup(pds__isc *ctx, long first, long last)
{
    const pds__isc_view *v = &ctx->lview;
    long y;
    int x, c, a, b;
    for (y = first; y < last; y++)
        for (x = 0; x < ctx->w; x++) {
            size_t p = (size_t)y * ctx->w + x;
            pds__v3 d;
            double z, u, w, fu, fw, acc[4] = {0, 0, 0, 0};
            long i0, j0;
            if (!ctx->px[p].kind) continue;
            d = pds__sub(pds__f3_get(ctx->px[p].pos), v->origin);
            z = pds__dot(d, v->axis);
            if (!(z > 0.0)) continue;
            u = (pds__dot(d, v->b1) / z / v->tan_half + 1.0) * 0.5 * v->res - 0.5;
            w = (pds__dot(d, v->b2) / z / v->tan_half + 1.0) * 0.5 * v->res - 0.5;
            if (!(u > -1.0 && w > -1.0 && u < v->res && w < v->res)) continue;
            i0 = (long)floor(u);
            j0 = (long)floor(w);
            fu = u - i0;
            fw = w - j0;
            for (b = 0; b < 2; b++)
                for (a = 0; a < 2; a++) {
                    long ii = i0 + a, jj = j0 + b;
                    double wt = (a ? fu : 1.0 - fu) * (b ? fw : 1.0 - fw);
                    const float *t;
                    if (ii < 0 || jj < 0 || ii >= v->res || jj >= v->res || wt == 0.0) continue;
                    t = &ctx->lmap[4 * ((size_t)jj * v->res + (size_t)ii)];
                    for (c = 0; c < 4; c++) acc[c] += wt * t[c];
                }
            for (c = 0; c < 3; c++) ctx->est[p].e[c] += (float)acc[c];
            ctx->est[p].count += (float)acc[3];
        }
}

/* The light map's view: the photon view's axes, widened to hold every
   landing point in front of the light (at most 64 times as wide). */
static void pds__isc_light_map_view(pds__isc *ctx)
{
    size_t k, n = (size_t)ctx->res * (size_t)ctx->res;
    double t = ctx->view.tan_half, cap = 64.0 * ctx->view.tan_half;
    ctx->lview = ctx->view;
    ctx->lview.jx = ctx->lview.jy = 0.0;
    for (k = 0; k < n; k++) {
        pds__v3 d;
        double z, a, b;
        if (!ctx->ph[k].path) continue;
        d = pds__sub(pds__f3_get(ctx->ph[k].pos), ctx->view.origin);
        z = pds__dot(d, ctx->view.axis);
        if (!(z > 0.0)) continue;
        a = fabs(pds__dot(d, ctx->view.b1)) / z;
        b = fabs(pds__dot(d, ctx->view.b2)) / z;
        if (a > t && a <= cap) t = a;
        if (b > t && b <= cap) t = b;
    }
    ctx->lview.tan_half = t * (1.0 + 2.0 / ctx->res);
}

/* --- quads: caustic polygons ------------------------------------------- */

/* Fixed-point screen position of each photon (PDS__ISC_SUB units per
   pixel; 0 in ph_front when behind the camera or absurdly far off). */
static void pds__isc_to_screen(pds__isc *ctx, long first, long last)
{
    long j;
    int i;
    for (j = first; j < last; j++)
        for (i = 0; i < ctx->res; i++) {
            size_t k = (size_t)j * ctx->res + i;
            double px, py, lim = 268435456.0; /* 2^28: edge products stay below 2^62 */
            ctx->ph_front[k] = 0;
            if (!ctx->ph[k].path || !pds__camera_project(&ctx->cam, pds__f3_get(ctx->ph[k].pos), &px, &py)) continue;
            px *= PDS__ISC_SUB;
            py *= PDS__ISC_SUB;
            if (!(fabs(px) < lim && fabs(py) < lim)) continue;
            ctx->ph_xy[2 * k] = (long long)floor(px + 0.5);
            ctx->ph_xy[2 * k + 1] = (long long)floor(py + 0.5);
            ctx->ph_front[k] = 1;
        }
}

/* Twice the signed area of (a, b, p) in fixed point, positive when p is
   to the left of a -> b in a y-down image... (b - a) x (p - a). */
static long long pds__isc_edge(const long long *a, const long long *b, long long px, long long py)
{
    return (b[0] - a[0]) * (py - a[1]) - (b[1] - a[1]) * (px - a[0]);
}

/* Does edge a -> b of a positively oriented triangle own the pixel
   centres exactly on it? Of an edge and its reverse exactly one does, so
   triangles that share an edge never both cover a centre on it. */
static int pds__isc_edge_owns(const long long *a, const long long *b)
{
    long long dy = b[1] - a[1], dx = b[0] - a[0];
    return dy > 0 || (dy == 0 && dx < 0);
}

/* Rasterise triangle (a, b, c) (fixed-point screen corners) with
   irradiance e on the surface through x0 with normal n0: a fragment for
   each pixel whose centre is inside and whose eye point is on that
   surface. Appends to row j's fragments. */
static void pds__isc_raster(pds__isc *ctx, long j, const long long *a, const long long *b, const long long *c,
                            const float e[3], pds__v3 x0, pds__v3 n0)
{
    long long area = pds__isc_edge(a, b, c[0], c[1]), x0p, x1p, y0p, y1p, xs, ys;
    long long minx, maxx, miny, maxy;
    int ob, oc, oa;
    if (area == 0) return;
    if (area < 0) {
        const long long *t = b;
        b = c;
        c = t;
    }
    minx = a[0] < b[0] ? (a[0] < c[0] ? a[0] : c[0]) : (b[0] < c[0] ? b[0] : c[0]);
    maxx = a[0] > b[0] ? (a[0] > c[0] ? a[0] : c[0]) : (b[0] > c[0] ? b[0] : c[0]);
    miny = a[1] < b[1] ? (a[1] < c[1] ? a[1] : c[1]) : (b[1] < c[1] ? b[1] : c[1]);
    maxy = a[1] > b[1] ? (a[1] > c[1] ? a[1] : c[1]) : (b[1] > c[1] ? b[1] : c[1]);
    /* pixel x's centre is at (x + 1/2) SUB: the pixels whose centres may be inside */
    x0p = (minx - PDS__ISC_SUB / 2 + PDS__ISC_SUB - 1) / PDS__ISC_SUB;
    if (minx - PDS__ISC_SUB / 2 < 0) x0p = -((PDS__ISC_SUB / 2 - minx) / PDS__ISC_SUB);
    x1p = (maxx - PDS__ISC_SUB / 2) >= 0 ? (maxx - PDS__ISC_SUB / 2) / PDS__ISC_SUB : -1;
    y0p = (miny - PDS__ISC_SUB / 2 + PDS__ISC_SUB - 1) / PDS__ISC_SUB;
    if (miny - PDS__ISC_SUB / 2 < 0) y0p = -((PDS__ISC_SUB / 2 - miny) / PDS__ISC_SUB);
    y1p = (maxy - PDS__ISC_SUB / 2) >= 0 ? (maxy - PDS__ISC_SUB / 2) / PDS__ISC_SUB : -1;
    if ((x1p - x0p + 1) * (y1p - y0p + 1) > PDS__ISC_QUAD_MAX_PIXELS) return;
    if (x0p < 0) x0p = 0;
    if (y0p < 0) y0p = 0;
    if (x1p >= ctx->w) x1p = ctx->w - 1;
    if (y1p >= ctx->h) y1p = ctx->h - 1;
    oa = pds__isc_edge_owns(b, c);
    ob = pds__isc_edge_owns(c, a);
    oc = pds__isc_edge_owns(a, b);
    for (ys = y0p; ys <= y1p; ys++)
        for (xs = x0p; xs <= x1p; xs++) {
            long long px = xs * PDS__ISC_SUB + PDS__ISC_SUB / 2, py = ys * PDS__ISC_SUB + PDS__ISC_SUB / 2;
            long long ea = pds__isc_edge(b, c, px, py), eb = pds__isc_edge(c, a, px, py), ec = pds__isc_edge(a, b, px, py);
            size_t q;
            pds__isc_frag *f;
            if (ea < 0 || eb < 0 || ec < 0 || (ea == 0 && !oa) || (eb == 0 && !ob) || (ec == 0 && !oc)) continue;
            q = (size_t)ys * ctx->w + (size_t)xs;
            if (!pds__isc_same_surface(&ctx->px[q], x0, n0)) continue;
            if (pds__grow((void **)&ctx->frags[j], &ctx->capfrags[j], ctx->nfrags[j] + 1, sizeof **ctx->frags)) {
                pds__mutex_lock(&ctx->lock);
                ctx->out_of_memory = 1;
                pds__mutex_unlock(&ctx->lock);
                return;
            }
            f = &ctx->frags[j][ctx->nfrags[j]++];
            f->pixel = (int)q;
            f->e[0] = e[0];
            f->e[1] = e[1];
            f->e[2] = e[2];
        }
}

/* The photons a caustic polygon's corners are apart: 1, or in spectral
   renders PDS__ISC_LAMBDA_SIDE, the nearest that share a wavelength. */
static int pds__isc_quad_step(const pds__isc *ctx)
{
    return ctx->spectral ? PDS__ISC_LAMBDA_SIDE : 1;
}

/* The caustic polygons of light-space rows j and j + 1: quad (i, j) joins
   photons (i,j), (i+1,j), (i+1,j+1), (i,j+1) when all four followed the
   same specular path to surfaces facing the same way (Sect. 3.2.1: quads
   that stretch between surfaces are culled). Its irradiance: the beam's
   flux Phi_B = I omega_B (eq. 1; I the mean of the corners' e) over the
   polygon's area (eqs. 2-3). Spectral renders join photons (i,j),
   (i+4,j), (i+4,j+4), (i,j+4) of one wavelength: each of the 16
   wavelengths' polygons tile the caustic, and each is given 1/16 of its
   irradiance (e is the flux at lambda times W(lambda), whose mean over
   the strata is the colour). */
static void pds__isc_quad_rows(pds__isc *ctx, long first, long last)
{
    const pds__isc_view *v = &ctx->view;
    long j;
    int i, c, r, step = pds__isc_quad_step(ctx);
    double share = 1.0 / ((double)step * step);
    for (j = first; j < last; j++) {
        ctx->nfrags[j] = 0;
        for (i = 0; i + step < ctx->res; i++) {
            size_t k[4];
            pds__v3 x[4], n0;
            double omega, area, e[3] = {0, 0, 0};
            float ef[3];
            int ok = 1;
            k[0] = (size_t)j * ctx->res + i;
            k[1] = k[0] + (size_t)step;
            k[2] = k[1] + (size_t)step * (size_t)ctx->res;
            k[3] = k[0] + (size_t)step * (size_t)ctx->res;
            for (r = 0; r < 4 && ok; r++)
                ok = ctx->ph[k[r]].path == ctx->ph[k[0]].path && ctx->ph[k[r]].path != 0 && ctx->ph_front[k[r]];
            if (!ok) continue;
            n0 = pds__f3_get(ctx->ph[k[0]].n);
            for (r = 0; r < 4 && ok; r++) {
                x[r] = pds__f3_get(ctx->ph[k[r]].pos);
                ok = pds__dot(pds__f3_get(ctx->ph[k[r]].n), n0) >= 0.9;
                for (c = 0; c < 3; c++) e[c] += 0.25 * ctx->ph[k[r]].e[c];
            }
            if (!ok) continue;
            area = 0.5 * (pds__length(pds__cross(pds__sub(x[1], x[0]), pds__sub(x[2], x[0]))) +
                          pds__length(pds__cross(pds__sub(x[2], x[0]), pds__sub(x[3], x[0]))));
            if (!(area > 0.0)) continue;
            omega = pds__rect_solid_angle(pds__isc_plane(v, i + v->jx), pds__isc_plane(v, i + step + v->jx),
                                          pds__isc_plane(v, j + v->jy), pds__isc_plane(v, j + step + v->jy));
            if (step > 1) omega *= share;
            for (c = 0; c < 3; c++) ef[c] = (float)(e[c] * omega / area);
            pds__isc_raster(ctx, j, &ctx->ph_xy[2 * k[0]], &ctx->ph_xy[2 * k[1]], &ctx->ph_xy[2 * k[2]], ef, x[0], n0);
            pds__isc_raster(ctx, j, &ctx->ph_xy[2 * k[0]], &ctx->ph_xy[2 * k[2]], &ctx->ph_xy[2 * k[3]], ef, x[0], n0);
        }
    }
}

/* The quads' fragments into the estimate, row by row (photon order). */
static void pds__isc_quads_add(pds__isc *ctx)
{
    long j;
    size_t f;
    int c;
    for (j = 0; j + pds__isc_quad_step(ctx) < ctx->res; j++)
        for (f = 0; f < ctx->nfrags[j]; f++) {
            const pds__isc_frag *fr = &ctx->frags[j][f];
            for (c = 0; c < 3; c++) ctx->est[fr->pixel].e[c] += fr->e[c];
            ctx->est[fr->pixel].count += 1.0f;
            ctx->fragments++;
        }
}

/* --- frames -------------------------------------------------------------- */

/* Rotate p about the vertical line through c by angle a (radians). */
static pds__v3 pds__isc_orbit(pds__v3 p, pds__v3 c, double a)
{
    double dx = p.x - c.x, dz = p.z - c.z;
    return pds__v(c.x + cos(a) * dx + sin(a) * dz, p.y, c.z - sin(a) * dx + cos(a) * dz);
}

/* Photons of light k for this frame, gathered into ctx->est. Static
   lighting (ctx->reuse) traces each light's buffer, and builds its light
   map, in the first frame only; the frames after redo only what depends
   on the eye (Wyman and Davis sect. 4: "the photon buffer does not need
   rerendering under static lighting"; their Table 1's static columns). */
static void pds__isc_light_photons(pds__isc *ctx, size_t k, int frame)
{
    size_t n = (size_t)ctx->res * (size_t)ctx->res, i;
    int grid = ctx->fixed_grid ? 0 : frame, fresh;
    double jx = pds__rng_uniform(ctx->opt->seed, PDS__RNG_ISC, (uint64_t)grid, 0);
    double jy = pds__rng_uniform(ctx->opt->seed, PDS__RNG_ISC, (uint64_t)grid, 1);
    double t0 = pds_time_now(), t1;
    ctx->light = &ctx->lights[k];
    ctx->lk = k;
    ctx->ph = ctx->reuse ? ctx->ph_all + k * n : ctx->ph_all;
    if (ctx->lmap_all) ctx->lmap = ctx->reuse ? ctx->lmap_all + 4 * k * n : ctx->lmap_all;
    if (!ctx->reuse) ctx->state[k] = 0;
    fresh = !(ctx->state[k] & PDS__ISC_TRACED);
    if (fresh) {
        ctx->state[k] = PDS__ISC_TRACED;
        if (ctx->spectral) ctx->photon_u = pds__rng_uniform(ctx->opt->seed, PDS__RNG_ISC, (uint64_t)grid, 2);
        if (!pds__isc_view_setup(ctx->scene, &ctx->target, ctx->light->position, ctx->res, jx, jy, &ctx->view)) {
            ctx->state[k] |= PDS__ISC_NO_VIEW;
            return;
        }
        ctx->views[k] = ctx->view;
        pds__isc_mask(ctx);
        pds__isc_parallel(ctx, ctx->res, 4, pds__isc_photon_rows);
        ctx->photons += (long)n;
        for (i = 0; i < n; i++) ctx->landed += ctx->ph[i].path != 0;
    } else {
        if (ctx->state[k] & PDS__ISC_NO_VIEW) return;
        ctx->view = ctx->views[k];
    }
    t1 = pds_time_now();
    ctx->time_photons += t1 - t0;
    switch (ctx->gather) {
    case PDS_ISC_POINTS:
    case PDS_ISC_EYE:
        pds__isc_parallel(ctx, ctx->res, 8, pds__isc_to_pixels);
        ctx->state[k] |= PDS__ISC_FLUX;
        if (ctx->gather == PDS_ISC_EYE) memset(ctx->dep, 0, sizeof *ctx->dep * 4 * (size_t)ctx->w * ctx->h);
        pds__isc_points(ctx, ctx->gather == PDS_ISC_EYE);
        if (ctx->gather == PDS_ISC_EYE) {
            pds__isc_parallel(ctx, ctx->h, 16, pds__isc_near_rows);
            pds__isc_parallel(ctx, ctx->h, 8, pds__isc_eye_gather);
        }
        break;
    case PDS_ISC_LIGHT:
        if (fresh) {
            /* the light map: the lighting's, not the eye's */
            pds__isc_light_map_view(ctx);
            pds__isc_parallel(ctx, ctx->res, 8, pds__isc_to_texels);
            memset(ctx->dep, 0, sizeof *ctx->dep * 4 * n);
            for (i = 0; i < n; i++) {
                int m = ctx->ph_pixel[i], c;
                if (m < 0) continue;
                for (c = 0; c < 3; c++) ctx->dep[4 * (size_t)m + c] += ctx->ph[i].e[c];
                ctx->dep[4 * (size_t)m + 3] += 1.0f;
            }
            pds__isc_parallel(ctx, ctx->res, 8, pds__isc_texel_irradiance);
            pds__isc_parallel(ctx, ctx->res, 8, pds__isc_light_gather);
            ctx->lviews[k] = ctx->lview;
        } else {
            ctx->lview = ctx->lviews[k];
        }
        pds__isc_parallel(ctx, ctx->h, 8, pds__isc_light_lookup);
        break;
    case PDS_ISC_QUADS:
        pds__isc_parallel(ctx, ctx->res, 8, pds__isc_to_screen);
        pds__isc_parallel(ctx, ctx->res - pds__isc_quad_step(ctx), 4, pds__isc_quad_rows);
        pds__isc_quads_add(ctx);
        break;
    }
    ctx->time_gather += pds_time_now() - t1;
}

/* Render frame `frame` into out (allocated by the caller, w x h): the
   orbit's lights and camera, the eye buffer, each light's photons and
   gather, the temporal filter, direct + caustic radiance. accumulate:
   average every frame so far instead of the last `history` (the time
   budget of a still). */
static void pds__isc_frame(pds__isc *ctx, int frame, int accumulate, pds_image *out)
{
    const pds_scene *s = ctx->scene;
    const pds_options *opt = ctx->opt;
    size_t npix = (size_t)ctx->w * ctx->h, i, k;
    /* a still's frames (time budget) do not turn */
    double angle = accumulate ? 0.0 : frame * opt->orbit_deg * (PDS__PI / 180.0), t0 = pds_time_now();
    pds_camera cam = s->camera;
    pds__isc_est *slot;
    int c, n_hist, h, threshold = ctx->gather == PDS_ISC_EYE || ctx->gather == PDS_ISC_LIGHT;
    for (k = 0; k < ctx->nlights; k++) {
        ctx->lights[k] = s->lights[k];
        if (opt->orbit == PDS_ORBIT_LIGHT) {
            ctx->lights[k].position = pds__isc_orbit(s->lights[k].position, cam.look_at, angle);
            ctx->lights[k].direction = pds__isc_orbit(s->lights[k].direction, pds__v(0, 0, 0), angle);
        }
    }
    if (opt->orbit == PDS_ORBIT_CAMERA) cam.position = pds__isc_orbit(cam.position, cam.look_at, angle);
    ctx->cam = pds__camera_setup(&cam, ctx->w, ctx->h);
    /* the eye buffer when the camera moved (or on the first frame), its
       direct light when anything moved */
    if (ctx->frames_done == 0 || (opt->orbit == PDS_ORBIT_CAMERA && angle != 0.0)) {
        if (ctx->spectral)
            ctx->eye_u = pds__rng_uniform(opt->seed, PDS__RNG_ISC, (uint64_t)(ctx->fixed_grid ? 0 : frame), 3);
        pds__isc_parallel(ctx, ctx->h, 4, pds__isc_eye_rows);
    }
    if (ctx->frames_done == 0 || (opt->orbit != PDS_ORBIT_NONE && angle != 0.0))
        pds__isc_parallel(ctx, ctx->h, 4, pds__isc_direct_rows);
    ctx->time_eye += pds_time_now() - t0;
    memset(ctx->est, 0, sizeof *ctx->est * npix);
    if (opt->paths != PDS_PATHS_NO_CAUSTICS && ctx->target.any)
        for (k = 0; k < ctx->nlights; k++) pds__isc_light_photons(ctx, k, frame);
    /* the temporal filter (sect. 3.2.3) */
    if (accumulate) {
        for (i = 0; i < npix; i++) {
            for (c = 0; c < 3; c++) ctx->acc[4 * i + c] += ctx->est[i].e[c];
            ctx->acc[4 * i + 3] += ctx->est[i].count;
        }
    } else {
        slot = &ctx->ring[(size_t)(frame % ctx->history) * npix];
        memcpy(slot, ctx->est, sizeof *slot * npix);
    }
    ctx->frames_done++;
    n_hist = accumulate ? ctx->frames_done : (ctx->frames_done < ctx->history ? ctx->frames_done : ctx->history);
    for (i = 0; i < npix; i++) {
        double e[3] = {0, 0, 0}, count = 0.0, *d = &ctx->direct[3 * i];
        if (accumulate) {
            for (c = 0; c < 3; c++) e[c] = ctx->acc[4 * i + c];
            count = ctx->acc[4 * i + 3];
        } else {
            for (h = 0; h < n_hist; h++) {
                const pds__isc_est *r = &ctx->ring[(size_t)((frame - h) % ctx->history) * npix + i];
                for (c = 0; c < 3; c++) e[c] += r->e[c];
                count += r->count;
            }
        }
        if (threshold && count < PDS__ISC_MIN_PHOTONS) e[0] = e[1] = e[2] = 0.0;
        if (ctx->px[i].lambda > 0.0f) {
            /* a pixel seen through dispersive glass holds at its own
               wavelength: the irradiance's value there (>>spectral's RGB
               photon at such a vertex; spectral photons' sums are taken
               as their colour, a light map not telling them apart) */
            double v = pds__spectral_value(e, ctx->px[i].lambda);
            e[0] = e[1] = e[2] = v;
        }
        for (c = 0; c < 3; c++) {
            double v = (opt->paths == PDS_PATHS_CAUSTICS_ONLY ? 0.0 : d[c]) + ctx->px[i].fr[c] * e[c] / n_hist;
            ctx->rgb[3 * i + c] = v;
        }
    }
    /* NaN -> 0, beyond the float range -> the largest float, counted */
    ctx->nonfinite += pds__finite_floats(ctx->rgb, out->rgb, npix * 3);
}

static void pds__isc_free(pds__isc *ctx)
{
    long j;
    if (ctx->frags)
        for (j = 0; j < ctx->res; j++) free(ctx->frags[j]);
    free(ctx->frags);
    free(ctx->nfrags);
    free(ctx->capfrags);
    free(ctx->lights);
    free(ctx->state);
    free(ctx->views);
    free(ctx->lviews);
    free(ctx->px);
    free(ctx->direct);
    free(ctx->ph_all);
    free(ctx->mask);
    free(ctx->ph_pixel);
    free(ctx->ph_xy);
    free(ctx->ph_front);
    free(ctx->dep);
    free(ctx->near_row);
    free(ctx->lmap_all);
    free(ctx->est);
    free(ctx->rgb);
    free(ctx->ring);
    free(ctx->acc);
    pds__mutex_destroy(&ctx->lock);
}

/* The light-space buffer's side: light_resolution, or the side whose
   square is nearest the photon count. */
static int pds__isc_resolution(const pds_options *opt)
{
    long r;
    if (opt->light_resolution > 0) return opt->light_resolution;
    r = (long)floor(sqrt((double)opt->photons) + 0.5);
    return r < 2 ? 2 : r > PDS_MAX_RESOLUTION ? PDS_MAX_RESOLUTION : (int)r;
}

/* Bytes an isc render holds: per pixel the eye buffer, direct light, the
   image in double, the estimate, its history (or the time budget's sums) and the deposits;
   per photon the buffer and its pixel, screen position or texel; the
   light map; with static lighting a buffer and a light map per light.
   (Quad fragments come on top: about one per covered pixel.) */
static double pds__isc_memory(const pds_scene *s, const pds_options *opt, double npix)
{
    double r2 = (double)pds__isc_resolution(opt) * pds__isc_resolution(opt);
    double kept = opt->static_lighting && s->nlights > 1 ? (double)s->nlights - 1.0 : 0.0;
    int hist = opt->time_s > 0.0 ? 2 : opt->history;
    return npix * (sizeof(pds__isc_pixel) + 6 * sizeof(double) + (1 + hist) * sizeof(pds__isc_est) +
                   4 * sizeof(float) + 3 * sizeof(float)) +
           r2 * (sizeof(pds__isc_photon) + sizeof(int) + 2 * sizeof(long long) + 2 + 8 * sizeof(float)) +
           kept * r2 * (sizeof(pds__isc_photon) + 4 * sizeof(float));
}

/* Set up a render of w x h pixels; the light checks of the method. */
static pds_status pds__isc_init(pds__isc *ctx, const pds_scene *s, const pds_options *opt, int w, int h, int threads,
                                pds_error *err)
{
    size_t npix = (size_t)w * h, n, k, nbuf;
    int x, y;
    double sum = 0.0;
    memset(ctx, 0, sizeof *ctx);
    pds__mutex_init(&ctx->lock);
    for (k = 0; k < s->nlights; k++)
        if (s->lights[k].type != PDS_LIGHT_POINT && s->lights[k].type != PDS_LIGHT_SPOT) {
            static const char *const kind[] = {"a point", "a spot", "a directional", "a disk", "a quad", "a mesh",
                                               "an environment"};
            return pds__fail(err, PDS_ERR_INVALID_ARG, s->path[0] ? s->path : NULL, 0, 0,
                             "image-space caustics (--method isc) take point and spot lights only, as Wyman and "
                             "Davis's method does; light %lu is %s light",
                             (unsigned long)k + 1, kind[(unsigned)s->lights[k].type % 7u]);
        }
    ctx->scene = s;
    ctx->opt = opt;
    ctx->gather = opt->isc_gather;
    ctx->w = w;
    ctx->h = h;
    ctx->threads = threads;
    ctx->res = pds__isc_resolution(opt);
    ctx->history = opt->history;
    ctx->eps = 1e-6 * pds__scene_scale(s);
    ctx->target = pds__specular_target(s);
    ctx->nlights = s->nlights;
    for (k = 0; ctx->target.any && k < s->nlights; k++) {
        pds__v3 axis;
        double cm;
        if (opt->paths != PDS_PATHS_NO_CAUSTICS && !pds__target_cone(&ctx->target, s->lights[k].position, &axis, &cm))
            return pds__fail(err, PDS_ERR_INVALID_ARG, s->path[0] ? s->path : NULL, 0, 0,
                             "--method isc: light %lu is inside the bounding sphere of the specular objects, which "
                             "one light-space view cannot hold",
                             (unsigned long)k + 1);
    }
    n = (size_t)ctx->res * ctx->res;
    ctx->fixed_grid = ctx->reuse = opt->static_lighting;
    ctx->spectral = pds__render_is_spectral(s, opt);
    ctx->spectral_all = ctx->spectral && opt->spectral;
    nbuf = ctx->reuse && s->nlights > 1 ? s->nlights : 1;
    ctx->lights = (pds_light *)malloc(sizeof *ctx->lights * (s->nlights ? s->nlights : 1));
    ctx->state = (unsigned char *)calloc(s->nlights ? s->nlights : 1, 1);
    ctx->views = (pds__isc_view *)calloc(s->nlights ? s->nlights : 1, sizeof *ctx->views);
    ctx->lviews = (pds__isc_view *)calloc(s->nlights ? s->nlights : 1, sizeof *ctx->lviews);
    ctx->px = (pds__isc_pixel *)calloc(npix, sizeof *ctx->px);
    ctx->direct = (double *)calloc(npix * 3, sizeof *ctx->direct);
    ctx->est = (pds__isc_est *)calloc(npix, sizeof *ctx->est);
    ctx->rgb = (double *)malloc(sizeof *ctx->rgb * 3 * npix);
    if (opt->time_s > 0.0) ctx->acc = (double *)calloc(npix * 4, sizeof *ctx->acc);
    else ctx->ring = (pds__isc_est *)calloc(npix * (size_t)ctx->history, sizeof *ctx->ring);
    if (n <= (size_t)-1 / sizeof *ctx->ph / nbuf) ctx->ph_all = (pds__isc_photon *)malloc(sizeof *ctx->ph * n * nbuf);
    ctx->ph = ctx->ph_all;
    ctx->mask = (unsigned char *)malloc(n);
    ctx->ph_pixel = (int *)malloc(sizeof *ctx->ph_pixel * n);
    if (ctx->gather == PDS_ISC_QUADS) {
        ctx->ph_xy = (long long *)malloc(sizeof *ctx->ph_xy * 2 * n);
        ctx->ph_front = (signed char *)malloc(n);
        ctx->frags = (pds__isc_frag **)calloc((size_t)ctx->res, sizeof *ctx->frags);
        ctx->nfrags = (size_t *)calloc((size_t)ctx->res, sizeof *ctx->nfrags);
        ctx->capfrags = (size_t *)calloc((size_t)ctx->res, sizeof *ctx->capfrags);
    }
    if (ctx->gather == PDS_ISC_EYE) {
        ctx->dep = (float *)malloc(sizeof *ctx->dep * 4 * npix);
        ctx->near_row = (unsigned char *)malloc(npix);
    }
    if (ctx->gather == PDS_ISC_LIGHT) {
        ctx->dep = (float *)malloc(sizeof *ctx->dep * 4 * n);
        if (n <= (size_t)-1 / (4 * sizeof *ctx->lmap) / nbuf)
            ctx->lmap_all = (float *)malloc(sizeof *ctx->lmap * 4 * n * nbuf);
        ctx->lmap = ctx->lmap_all;
    }
    if (!ctx->lights || !ctx->state || !ctx->views || !ctx->lviews || !ctx->px || !ctx->direct || !ctx->est || !ctx->rgb || !ctx->mask || (!ctx->acc && !ctx->ring) || !ctx->ph ||
        !ctx->ph_pixel || (ctx->gather == PDS_ISC_QUADS && (!ctx->ph_xy || !ctx->ph_front || !ctx->frags ||
                                                          !ctx->nfrags || !ctx->capfrags)) ||
        ((ctx->gather == PDS_ISC_EYE || ctx->gather == PDS_ISC_LIGHT) && !ctx->dep) ||
        (ctx->gather == PDS_ISC_EYE && !ctx->near_row) ||
        (ctx->gather == PDS_ISC_LIGHT && !ctx->lmap)) {
        pds__isc_free(ctx);
        return pds__nomem(err);
    }
    /* the normalised 7x7 Gaussian */
    for (y = -PDS__ISC_RADIUS; y <= PDS__ISC_RADIUS; y++)
        for (x = -PDS__ISC_RADIUS; x <= PDS__ISC_RADIUS; x++)
            sum += ctx->gauss[y + PDS__ISC_RADIUS][x + PDS__ISC_RADIUS] =
                exp(-(x * x + y * y) / (2.0 * PDS__ISC_SIGMA * PDS__ISC_SIGMA));
    for (y = 0; y < 2 * PDS__ISC_RADIUS + 1; y++)
        for (x = 0; x < 2 * PDS__ISC_RADIUS + 1; x++) ctx->gauss[y][x] /= sum;
    return PDS_OK;
}

/* Render `frames` frames (fn gets each; fn NULL: only the last into
   *last), or with a time budget one still from as many frames as fit. */
static pds_status pds__isc_render(const pds_scene *s, const pds_options *opt, int w, int h, int threads, int frames,
                                  pds_frame_fn fn, void *user, pds_image *last, pds_render_stats *stats,
                                  pds_error *err)
{
    pds__isc ctx;
    pds_image img;
    pds_error spare; /* the callback always gets somewhere to say why */
    pds_status st;
    double t0 = pds_time_now();
    int f, accumulate = opt->time_s > 0.0 && !fn;
    if ((st = pds__isc_init(&ctx, s, opt, w, h, threads, err))) return st;
    if ((st = pds_image_alloc(&img, w, h)) != PDS_OK) {
        pds__isc_free(&ctx);
        return pds__nomem(err);
    }
    for (f = 0; accumulate || f < frames; f++) {
        pds__isc_frame(&ctx, f, accumulate, &img);
        if (ctx.out_of_memory) {
            st = pds__nomem(err);
            break;
        }
        if (opt->progress && !accumulate) (void)opt->progress(opt->progress_user, PDS_PHASE_PHOTONS, (double)(f + 1) / frames, pds_time_now() - t0);
        if (fn && (st = fn(user, f, &img, err ? err : &spare)) != PDS_OK) break;
        if (accumulate) {
            double el = pds_time_now() - t0;
            if (opt->progress) (void)opt->progress(opt->progress_user, PDS_PHASE_PHOTONS, el / opt->time_s < 1.0 ? el / opt->time_s : 1.0, el);
            if (el >= opt->time_s) {
                f++;
                break;
            }
        }
    }
    if (stats) {
        size_t i, npix = (size_t)w * h;
        stats->passes = f;
        stats->photons = ctx.photons;
        stats->splatted = ctx.landed;
        stats->time_eye_s = ctx.time_eye;
        stats->time_photons_s = ctx.time_photons;
        stats->time_gather_s = ctx.time_gather;
        stats->memory_bytes = (size_t)pds__isc_memory(s, opt, (double)npix);
        for (i = 0; i < npix; i++) stats->eye_vertices += ctx.px[i].kind != 0;
        stats->spp = 1;
        stats->nonfinite = ctx.nonfinite;
        stats->spectral = ctx.spectral;
    }
    pds__isc_free(&ctx);
    if (!st && last) *last = img;
    else pds_image_free(&img);
    return st;
}
#else /* PDS_NO_ISC */
/* This build leaves isc out: pds__options_check refuses the method, and
   so pds_render_frames. What >>api names of it stays, inert. */
#define PDS__ISC_MAX_HISTORY 64
static double pds__isc_memory(const pds_scene *s, const pds_options *opt, double npix)
{
    (void)s, (void)opt, (void)npix;
    return 0.0;
}
static pds_status pds__isc_render(const pds_scene *s, const pds_options *opt, int w, int h, int threads, int frames,
                                  pds_frame_fn fn, void *user, pds_image *last, pds_render_stats *stats,
                                  pds_error *err)
{
    (void)s, (void)opt, (void)w, (void)h, (void)threads, (void)frames, (void)fn, (void)user, (void)last, (void)stats;
    return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "this build leaves isc out (PDS_NO_ISC)");
}
#endif /* PDS_NO_ISC */

/* ===================================================================== */
/* >>api                                                                 */
/* ===================================================================== */

void pds_options_default(pds_options *opt)
{
    memset(opt, 0, sizeof *opt);
    opt->method = PDS_METHOD_PDS;
    opt->paths = PDS_PATHS_ALL;
    opt->width = 0;
    opt->height = 0;
    opt->spp = 0;
    opt->threads = 0;
    opt->seed = 0;
    opt->max_depth = 32;
    opt->rr_depth = 3;
    opt->diffuse_bounces = -1;
    opt->time_s = 0.0;
    opt->progress = NULL;
    opt->progress_user = NULL;
    opt->photons = 100000;
    opt->smoothing = 12.0;
    opt->progressive = 1;
    opt->pass_photons = 16384;
    opt->pass_alpha = 2.0 / 3.0;
    opt->pass_smoothing = 2.0;
    opt->pass_min_aspect = 0.15;
    opt->pass_min_width = 1.5;
    opt->min_width = 0.0;
    opt->plane_tolerance = 0.25;
    opt->photon_depth = 16;
    opt->split_depth = 0;
    opt->split_angle = 0.2;
    opt->debug = NULL;
    opt->k = 50;
    opt->kernel = PDS_KERNEL_CONE;
    opt->max_radius = 0.0;
    opt->radius = 0.0;
    opt->alpha = 0.7;
    opt->passes = 10;
    opt->max_photons = 500;
    opt->shard_index = 0;
    opt->shard_count = 1;
    opt->spectral = 0;
    opt->isc_gather = PDS_ISC_EYE;
    opt->light_resolution = 0;
    opt->history = 4;
    opt->orbit = PDS_ORBIT_LIGHT;
    opt->orbit_deg = 2.0;
    opt->static_lighting = 0;
    opt->caustics = PDS_METHOD_PDS;
    opt->global_photons = 100000;
    opt->global_k = 50;
    /* one cosine-sampled gather per camera sample and a shadow ray for
       every light sample: the fastest to a given error in our scenes
       (README "Global illumination", measured against pt) */
    opt->gather = 1;
    opt->gather_mix = 1.0;
    opt->shadow_photons = 0;
    opt->streams = 0;
    opt->stream_photons = 10;
    opt->global_map = PDS_GLOBAL_PHOTONS;
    opt->stream_radius = 0.0;
}

void pds_debug_init(pds_debug *d)
{
    memset(d, 0, sizeof *d);
    d->views = 0;
    d->ellipse_every = 0;
    d->path_photons = 100;
}

void pds_debug_free(pds_debug *d)
{
    int v;
    if (!d) return;
    for (v = 0; v < PDS_DEBUG_VIEWS; v++) {
        pds_image_free(&d->value[v]);
        pds_image_free(&d->picture[v]);
        d->scale_max[v] = 0.0;
    }
    free(d->paths_obj);
    d->paths_obj = NULL;
    d->landings = d->landings_in_frame = d->ellipses = d->eye_vertices_in_frame = 0;
    d->paths = d->path_segments = 0;
}

const char *pds_debug_view_name(pds_debug_view view)
{
    static const char *const names[PDS_DEBUG_VIEWS] = {"footprint", "landings", "ellipses", "splats", "eye", "paths"};
    return (int)view >= 0 && view < PDS_DEBUG_VIEWS ? names[view] : "unknown";
}

/* --- one photon, for students: `pds trace-photon` -------------------------- */

/* Landing for a photon that is only watched: nothing to splat. */
static void pds__land_nowhere(const pds__photon_job *job, pds__splat_buf *buf, const pds__ray_diff *r, pds__v3 ng,
                              const double flux[3], double lambda, long photon)
{
    (void)job, (void)buf, (void)r, (void)ng, (void)flux, (void)lambda, (void)photon;
}

/* Trace from start (differentials ignored: zero) with the production loop
   and record its vertices into rec (emptied first). */
static void pds__trace_watch(const pds__photon_job *job, long photon, pds__v3 p, pds__v3 d, const double flux[3],
                             pds__path_rec *rec)
{
    pds__splat_buf buf;
    pds__ray_diff r;
    double f[3];
    memset(&buf, 0, sizeof buf);
    memset(&r, 0, sizeof r);
    r.p = p;
    r.d = pds__normalize(d);
    memcpy(f, flux, sizeof f);
    rec->n = 0;
    rec->photon_end = LONG_MAX;
    buf.path = rec;
    pds__path_note(rec, photon, 0, PDS_TRACE_EMIT, -1, -1, &r, f);
    pds__trace_from(job, &buf, &r, f, photon, 0);
}

static pds_vec3 pds__vec_out(pds__v3 v)
{
    pds_vec3 o;
    o.x = v.x;
    o.y = v.y;
    o.z = v.z;
    return o;
}

/* Central difference (a - b) / (2h) of two recorded vertices. */
static pds_vec3 pds__vec_fd(pds__v3 a, pds__v3 b, double h)
{
    return pds__vec_out(pds__scale(pds__sub(a, b), 0.5 / h));
}

pds_status pds_trace_photon(const pds_scene *scene, const pds_options *opt, long photon, pds_trace *out,
                            pds_error *err)
{
    pds__photon_job job;
    pds__path_rec base, nb[4];  /* neighbours +u, -u, +v, -v */
    pds__ray_diff r;
    double flux[3], scale, big;
    pds_status st = PDS_OK;
    size_t k;
    int j;
    if (!scene || !opt || !out) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds_trace_photon: NULL argument");
    memset(out, 0, sizeof *out);
    if (photon < 0) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "photon number %ld is negative", photon);
    if (opt->photons < 1 || !(opt->smoothing > 0.0) || !isfinite(opt->smoothing))
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "photons and smoothing must be positive");
    if (opt->photon_depth < 1 || opt->photon_depth > 1000)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "photon depth %d is outside 1..1000", opt->photon_depth);
    memset(&job, 0, sizeof job);
    job.scene = scene;
    job.target = pds__specular_target(scene);
    job.seed = opt->seed;
    job.smoothing = opt->smoothing;
    job.n_planned = (double)opt->photons;
    job.max_depth = opt->photon_depth;
    scale = pds__scene_scale(scene);
    job.eps = 1e-6 * scale;
    job.differentials = 1;
    job.land = pds__land_nowhere;
    out->photon = photon;
    out->smoothing = opt->smoothing;
    out->photons = (double)opt->photons;
    memset(&base, 0, sizeof base);
    memset(nb, 0, sizeof nb);
    if (!pds__emit_photon(&job, photon, &r, flux)) return PDS_OK; /* it carries nothing: no vertex */
    {
        pds__splat_buf buf;
        memset(&buf, 0, sizeof buf);
        base.photon_end = LONG_MAX;
        buf.path = &base;
        pds__path_note(&base, photon, 0, PDS_TRACE_EMIT, -1, -1, &r, flux);
        pds__trace_from(&job, &buf, &r, flux, photon, 0);
    }
    /* the step h: the neighbours start 1e-6 scene sizes away (or turned by
       1e-6 radians) along the larger differential */
    big = fmax(fmax(pds__length(r.dpdu), pds__length(r.dpdv)),
               scale * fmax(pds__length(r.dddu), pds__length(r.dddv)));
    out->step = big > 0.0 ? 1e-6 * scale / big : 0.0;
    if (out->step > 0.0) {
        double h = out->step;
        pds__trace_watch(&job, photon, pds__add(r.p, pds__scale(r.dpdu, h)), pds__add(r.d, pds__scale(r.dddu, h)), flux, &nb[0]);
        pds__trace_watch(&job, photon, pds__sub(r.p, pds__scale(r.dpdu, h)), pds__sub(r.d, pds__scale(r.dddu, h)), flux, &nb[1]);
        pds__trace_watch(&job, photon, pds__add(r.p, pds__scale(r.dpdv, h)), pds__add(r.d, pds__scale(r.dddv, h)), flux, &nb[2]);
        pds__trace_watch(&job, photon, pds__sub(r.p, pds__scale(r.dpdv, h)), pds__sub(r.d, pds__scale(r.dddv, h)), flux, &nb[3]);
    }
    for (j = 0; j < 4; j++)
        if (nb[j].out_of_memory) st = PDS_ERR_NOMEM;
    if (base.out_of_memory) st = PDS_ERR_NOMEM;
    if (!st && base.n > 0) {
        out->v = (pds_trace_vertex *)calloc(base.n, sizeof *out->v);
        if (!out->v) st = PDS_ERR_NOMEM;
    }
    for (k = 0; !st && k < base.n; k++) {
        const pds__path_event *e = &base.ev[k];
        pds_trace_vertex *v = &out->v[k];
        int same = out->step > 0.0;
        v->event = (pds_trace_event)e->event;
        v->material = e->material;
        v->triangle = e->triangle;
        v->position = pds__vec_out(e->r.p);
        v->direction = pds__vec_out(e->r.d);
        v->dxdu = pds__vec_out(e->r.dpdu);
        v->dxdv = pds__vec_out(e->r.dpdv);
        v->dwdu = pds__vec_out(e->r.dddu);
        v->dwdv = pds__vec_out(e->r.dddv);
        v->area = pds__footprint_area(e->r.dpdu, e->r.dpdv);
        v->major = pds__footprint_major_axis(e->r.dpdu, e->r.dpdv);
        v->minor = v->major > 0.0 ? v->area / (PDS__PI * v->major) : 0.0; /* area = pi A B */
        memcpy(v->flux, e->flux, sizeof v->flux);
        for (j = 0; j < 4 && same; j++)
            same = k < nb[j].n && nb[j].ev[k].event == e->event && nb[j].ev[k].triangle == e->triangle;
        v->fd_valid = same;
        if (same) {
            v->fd_dxdu = pds__vec_fd(nb[0].ev[k].r.p, nb[1].ev[k].r.p, out->step);
            v->fd_dwdu = pds__vec_fd(nb[0].ev[k].r.d, nb[1].ev[k].r.d, out->step);
            v->fd_dxdv = pds__vec_fd(nb[2].ev[k].r.p, nb[3].ev[k].r.p, out->step);
            v->fd_dwdv = pds__vec_fd(nb[2].ev[k].r.d, nb[3].ev[k].r.d, out->step);
        }
    }
    if (!st) out->count = (int)base.n;
    free(base.ev);
    for (j = 0; j < 4; j++) free(nb[j].ev);
    if (st) {
        pds_trace_free(out);
        return pds__nomem(err);
    }
    return PDS_OK;
}

void pds_trace_free(pds_trace *t)
{
    if (!t) return;
    free(t->v);
    t->v = NULL;
    t->count = 0;
}

/* Methods that add caustics with photons after an eye pass. */
static int pds__is_photon_method(pds_method m)
{
    return m == PDS_METHOD_PDS || m == PDS_METHOD_PM || m == PDS_METHOD_PDM || m == PDS_METHOD_SPLAT ||
           m == PDS_METHOD_PPM || m == PDS_METHOD_SPM;
}

/* spm's full image is seed paper 003's whole system. The paper's streams
   light the scene everywhere: nfs streams leave the light, a stream that
   meets a diffuse surface spreads its nfa associated photons within rs
   of its leader (sect. 3.1, step 3a) and every diffuse hit is stored
   (sect. 3.2), while a stream that meets glass or a mirror first loses
   its associated photons and becomes a caustic (step 3b). In PDS's
   split of the light (Jensen's eq. 2, >>gi) those are two parts:
     - the caustics (L S+ D): spm's caustic streams (>>streams), as
       --caustics-only renders them, bit for bit;
     - everything else: gi's two passes with the paper's streams in the
       global map (>>gi, "streams in the global map": nfs streams of
       nfa + 1 photons, radius rs, eq. 2 over the global_k nearest
       leaders), the direct light by light samples and the indirect light
       by the final gather.
   So an spm render without --caustics-only is a gi render with
   global_map = PDS_GLOBAL_STREAMS and caustics = PDS_METHOD_SPM and every
   other option as given, with one exception: a stream count given
   (streams > 0) is nfs of both maps, the global map's as well as the
   caustic streams, so the global map emits nfs (nfa + 1) photons instead
   of global_photons (with streams = 0 each map keeps its own photon
   count: photons / (nfa + 1) caustic streams, global_photons / (nfa + 1)
   global ones). pds__options_check keeps nfs (nfa + 1) within the global
   map's 1e9 photons. Returns opt itself when it is not an spm full
   image, else *gi filled. */
static const pds_options *pds__spm_as_gi(const pds_options *opt, pds_options *gi)
{
    if (opt->method != PDS_METHOD_SPM || opt->paths == PDS_PATHS_CAUSTICS_ONLY) return opt;
    *gi = *opt;
    gi->method = PDS_METHOD_GI;
    gi->caustics = PDS_METHOD_SPM;
    gi->global_map = PDS_GLOBAL_STREAMS;
    if (opt->streams > 0) gi->global_photons = opt->streams * (opt->stream_photons + 1L);
    return gi;
}

const char *pds_method_name(pds_method method)
{
    switch (method) {
    case PDS_METHOD_PT: return "pt";
    case PDS_METHOD_PREVIEW: return "preview";
    case PDS_METHOD_PDS: return "pds";
    case PDS_METHOD_PM: return "pm";
    case PDS_METHOD_SPLAT: return "splat";
    case PDS_METHOD_PDM: return "pdm";
    case PDS_METHOD_PPM: return "ppm";
    case PDS_METHOD_ISC: return "isc";
    case PDS_METHOD_GI: return "gi";
    case PDS_METHOD_SPM: return "spm";
    }
    return "unknown";
}

/* Check the options against the documented ranges. */
static pds_status pds__options_check(const pds_options *opt, int w, int h, pds_error *err)
{
    if (w < 1 || h < 1 || w > PDS_MAX_RESOLUTION || h > PDS_MAX_RESOLUTION || opt->width < 0 || opt->height < 0)
        return pds__fail(err, PDS_ERR_LIMIT, NULL, 0, 0, "resolution %dx%d is outside 1..%d", w, h, PDS_MAX_RESOLUTION);
    if (opt->spp < 0 || opt->spp > PDS_MAX_SPP)
        return pds__fail(err, PDS_ERR_LIMIT, NULL, 0, 0, "spp %d is outside 1..%d", opt->spp, PDS_MAX_SPP);
    if (opt->threads < 0) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "threads must not be negative");
    if (opt->max_depth < 0 || opt->max_depth > 1000)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "max depth %d is outside 0..1000", opt->max_depth);
    if (opt->rr_depth < 1) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "Russian roulette depth must be at least 1");
    if (opt->diffuse_bounces < -1 || opt->diffuse_bounces > 1000)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "diffuse bounces %d is outside -1..1000",
                         opt->diffuse_bounces);
    if (!(opt->time_s >= 0.0) || opt->time_s > 1e7)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "time budget must be between 0 and 1e7 seconds");
    if (opt->photons < 0)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "photon count must not be negative, got %ld", opt->photons);
    if (!(opt->smoothing > 0.0) || opt->smoothing > 1e6)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "smoothing must be positive");
    if (opt->eye_rounds < 0 || opt->eye_rounds > PDS_MAX_SPP)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "eye rounds %d is outside 0..%d", opt->eye_rounds,
                         PDS_MAX_SPP);
    if (opt->pass_photons < 1 || opt->pass_photons > 1000000000L)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "photons per pass %ld is outside 1..1e9", opt->pass_photons);
    if (!(opt->pass_alpha > 0.0 && opt->pass_alpha <= 1.0))
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "the passes' alpha must be above 0 and at most 1");
    if (!(opt->plane_tolerance > 0.0) || opt->plane_tolerance > 1e6)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "plane tolerance must be positive");
    if (!(opt->pass_smoothing > 0.0) || opt->pass_smoothing > 1e6)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "the first pass's smoothing must be positive");
    if (!(opt->pass_min_aspect >= 0.0) || opt->pass_min_aspect > 1.0 || !(opt->pass_min_width >= 0.0) ||
        opt->pass_min_width > 1e6)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "the passes' widening must be 0..1 (aspect), 0..1e6 (width)");
    if (!(opt->min_width >= 0.0) || opt->min_width > 1e6)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "minimum width must be between 0 and 1e6");
    if (!(opt->min_aspect >= 0.0) || opt->min_aspect > 1.0)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "minimum aspect must be between 0 and 1");
    if (opt->split_depth < 0 || opt->split_depth > 8)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "split depth %d is outside 0..8", opt->split_depth);
    if (!(opt->split_angle > 0.0) || opt->split_angle > 10.0)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "split angle must be above 0 and at most 10 radians");
    if (opt->photon_depth < 1 || opt->photon_depth > 1000)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "photon depth %d is outside 1..1000", opt->photon_depth);
    if (opt->k < 1 || opt->k > 100000)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "k %d is outside 1..100000", opt->k);
    if ((unsigned)opt->kernel > (unsigned)PDS_KERNEL_NONE)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "unknown photon-mapping kernel %d", (int)opt->kernel);
    if (!(opt->alpha > 0.0 && opt->alpha <= 1.0))
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "alpha must be above 0 and at most 1");
    if (opt->passes < 1) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "passes must be at least 1");
    if (opt->max_photons < 1) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "max photons must be at least 1");
    if (opt->stream_photons < 0 || opt->stream_photons > 10000)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "associated photons per stream %d is outside 0..10000",
                         opt->stream_photons);
    if (opt->streams < 0 || opt->streams > (LONG_MAX - PDS__PHOTON_BATCH) / (opt->stream_photons + 1L))
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "stream count %ld is outside 0..%ld", opt->streams,
                         (LONG_MAX - PDS__PHOTON_BATCH) / (opt->stream_photons + 1L));
    if (opt->method == PDS_METHOD_SPM && opt->paths != PDS_PATHS_CAUSTICS_ONLY &&
        opt->streams > 1000000000L / (opt->stream_photons + 1L))
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0,
                         "stream count %ld is outside 0..%ld: spm's full image also emits that many streams of %d "
                         "photons into its global map, at most 1e9 photons",
                         opt->streams, 1000000000L / (opt->stream_photons + 1L), opt->stream_photons + 1);
    if (!(opt->max_radius >= 0.0) || !(opt->radius >= 0.0) || opt->max_radius > 1e12 || opt->radius > 1e12)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "radii must be between 0 and 1e12");
    if ((unsigned)opt->isc_gather > (unsigned)PDS_ISC_LIGHT)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "unknown isc gather %d", (int)opt->isc_gather);
    if (opt->light_resolution < 0 || opt->light_resolution > PDS_MAX_RESOLUTION)
        return pds__fail(err, PDS_ERR_LIMIT, NULL, 0, 0, "light-space resolution %d is outside 0..%d",
                         opt->light_resolution, PDS_MAX_RESOLUTION);
    if (opt->history < 1 || opt->history > PDS__ISC_MAX_HISTORY)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "history %d is outside 1..%d", opt->history,
                         PDS__ISC_MAX_HISTORY);
    if ((unsigned)opt->orbit > (unsigned)PDS_ORBIT_CAMERA)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "unknown orbit %d", (int)opt->orbit);
    if (!(fabs(opt->orbit_deg) <= 360.0))
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "orbit step must be between -360 and 360 degrees");
    if (opt->static_lighting != 0 && opt->static_lighting != 1)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "static lighting must be 0 or 1, got %d",
                         opt->static_lighting);
    if (opt->method == PDS_METHOD_ISC && opt->static_lighting && opt->time_s > 0.0)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0,
                         "static lighting keeps one light-space grid, but a still with a time budget averages "
                         "differently offset grids: leave out one of the two");
    if (opt->method != PDS_METHOD_PT && opt->method != PDS_METHOD_PREVIEW && opt->method != PDS_METHOD_ISC &&
        opt->method != PDS_METHOD_GI &&
        !pds__is_photon_method(opt->method))
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "unknown rendering method %d", (int)opt->method);
    if (opt->method == PDS_METHOD_GI && !pds__is_photon_method(opt->caustics))
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0,
                         "the caustic method of gi must be pds, pm, pdm, splat, ppm or spm, got %d",
                         (int)opt->caustics);
    if (opt->global_photons < 0 || opt->global_photons > 1000000000L)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "global photons %ld is outside 0..1e9", opt->global_photons);
    if (opt->global_k < 1 || opt->global_k > PDS__GI_MAX_K)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "global k %d is outside 1..%d", opt->global_k,
                         PDS__GI_MAX_K);
    if (opt->gather < 0 || opt->gather > 4096)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "gather rays %d is outside 0..4096", opt->gather);
    if (!(opt->gather_mix > 0.0 && opt->gather_mix <= 1.0))
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "the gather's cosine share must be above 0 and at most 1");
    if (opt->shadow_photons != 0 && opt->shadow_photons != 1)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "shadow photons must be 0 or 1");
    if ((unsigned)opt->global_map > (unsigned)PDS_GLOBAL_STREAMS)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "unknown global map %d", (int)opt->global_map);
    if (!(opt->stream_radius >= 0.0 && opt->stream_radius <= 1e12))
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "the stream radius must be between 0 and 1e12");
    if ((unsigned)opt->paths > (unsigned)PDS_PATHS_CAUSTICS_ONLY)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "unknown light path selection %d", (int)opt->paths);
    if (opt->shard_count < 1 || opt->shard_count > PDS__PARTIAL_MAX_SHARDS || opt->shard_index < 0 ||
        opt->shard_index >= opt->shard_count)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "shard %d of %d: the index must be 0..count-1, the count 1..%d",
                         opt->shard_index, opt->shard_count, PDS__PARTIAL_MAX_SHARDS);
    if (opt->shard_count > 1 && opt->time_s > 0.0)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0,
                         "a render with a time budget cannot be split into shards: its photon count is not fixed");
    if (opt->shard_count > 1 && opt->debug && opt->debug->views)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "the teaching views are not made for shards");
#ifdef PDS_NO_BASELINES
    if (opt->method == PDS_METHOD_PM || opt->method == PDS_METHOD_PDM || opt->method == PDS_METHOD_SPLAT ||
        opt->method == PDS_METHOD_PPM || opt->method == PDS_METHOD_SPM)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "this build leaves the baselines out (PDS_NO_BASELINES): "
                         "method %s is not in it", pds_method_name(opt->method));
#endif
#ifdef PDS_NO_GI
    if (opt->method == PDS_METHOD_GI)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "this build leaves gi out (PDS_NO_GI)");
    if (opt->method == PDS_METHOD_SPM && opt->paths != PDS_PATHS_CAUSTICS_ONLY)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0,
                         "this build leaves gi out (PDS_NO_GI), whose two passes make spm's full image: render spm "
                         "with caustics only");
#endif
#ifdef PDS_NO_ISC
    if (opt->method == PDS_METHOD_ISC)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "this build leaves isc out (PDS_NO_ISC)");
#endif
    if (opt->debug) {
        if (opt->debug->views >= (1u << PDS_DEBUG_VIEWS))
            return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "unknown debug view in 0x%x", opt->debug->views);
        if (opt->debug->ellipse_every < 0)
            return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "ellipse_every %ld is negative",
                             opt->debug->ellipse_every);
        if (opt->debug->path_photons < 0 || opt->debug->path_photons > 1000000)
            return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "path_photons %ld is outside 0..1000000",
                             opt->debug->path_photons);
    }
    return PDS_OK;
}

/* What the scene's camera allows: image-space caustics and the teaching
   views project scene points straight into a pinhole camera, so a thin
   lens (aperture > 0) is refused for them rather than drawn wrong. */
static pds_status pds__camera_check(const pds_scene *scene, const pds_options *opt, pds_error *err)
{
#ifdef PDS_NO_SPECTRAL
    if (pds__render_is_spectral(scene, opt))
        return pds__fail(err, PDS_ERR_INVALID_ARG, scene->path[0] ? scene->path : NULL, 0, 0,
                         "this build leaves spectral rendering out (PDS_NO_SPECTRAL): %s",
                         opt->spectral ? "the options ask for it" : "the scene has a dispersive material");
#endif
    if (!(scene->camera.aperture > 0.0)) return PDS_OK;
    if (opt->method == PDS_METHOD_ISC)
        return pds__fail(err, PDS_ERR_INVALID_ARG, scene->path[0] ? scene->path : NULL, 0, 0,
                         "image-space caustics (--method isc) need a pinhole camera; this camera has 'aperture %g'",
                         scene->camera.aperture);
    if (opt->debug && opt->debug->views)
        return pds__fail(err, PDS_ERR_INVALID_ARG, scene->path[0] ? scene->path : NULL, 0, 0,
                         "the teaching views project points into a pinhole camera; this camera has 'aperture %g'",
                         scene->camera.aperture);
    return PDS_OK;
}

/* Join the per-row eye vertices in row order (then free the rows). */
static pds__eye_vertex *pds__join_rows(pds__render_job *job, size_t *count)
{
    size_t total = 0, at = 0;
    int y;
    pds__eye_vertex *all;
    for (y = 0; y < job->frame.height; y++) total += job->row_count[y];
    all = (pds__eye_vertex *)malloc(sizeof *all * (total ? total : 1));
    for (y = 0; all && y < job->frame.height; y++) {
        if (job->row_count[y]) memcpy(all + at, job->row_vertices[y], sizeof *all * job->row_count[y]);
        at += job->row_count[y];
    }
    for (y = 0; y < job->frame.height; y++) free(job->row_vertices[y]);
    *count = total;
    return all;
}

/* What a render will hold at once, beyond the scene, from its options
   alone (an upper bound: every eye sample is taken to record a vertex,
   every photon emitted to be stored). Per eye vertex: the vertex (112 bytes)
   in its row array, which grows by doubling (up to 2 x 112), and its copy in
   the joined array, 336 bytes in all (the kd-tree's 21 bytes and the
   tree-ordered copy come after the rows are freed). Per stored photon of
   pm: 64 bytes, twice while the threads' arrays are merged, plus 21 of
   kd-tree; pdm: 88 bytes, twice. spm's full image: gi's (pds__spm_as_gi). */
static pds_status pds__render_estimate(const pds_scene *scene, const pds_options *opt, pds_render_estimate *est,
                                       pds_error *err)
{
    const pds_camera *cam;
    int w, h, spp, threads;
    double npix, photons, vertex_bytes = 3.0 * sizeof(pds__eye_vertex), bytes;
    pds_status st;
    memset(est, 0, sizeof *est);
    cam = &scene->camera;
    w = opt->width > 0 ? opt->width : cam->width;
    h = opt->height > 0 ? opt->height : cam->height;
    if ((st = pds__options_check(opt, w, h, err))) return st;
    spp = opt->spp > 0 ? opt->spp : cam->spp;
    threads = opt->threads > 0 ? opt->threads : pds_cpu_count();
    if (threads > h) threads = h;
    npix = (double)w * (double)h;
    est->samples = npix * spp;
    /* the eye sums, the part's eye values, the output image */
    bytes = npix * 3.0 * (2.0 * sizeof(double) + sizeof(float));
    if (opt->method == PDS_METHOD_GI) {
        /* the global and shadow maps: at most PDS__GI_MAX_STORES and
           PDS__GI_MAX_SHADOW + 1 stores per photon, each twice while the
           threads' arrays are merged, plus 21 bytes of kd-tree; then the
           caustic method's own needs */
        pds_options copt = *opt;
        double gbytes = (double)opt->global_photons *
                        (PDS__GI_MAX_STORES * (2.0 * sizeof(pds__gi_photon) + 21.0) +
                         (PDS__GI_MAX_SHADOW + 1) * (2.0 * sizeof(pds__gi_shadow_photon) + 21.0));
        if (opt->global_map == PDS_GLOBAL_STREAMS)
            gbytes += (double)opt->global_photons * PDS__GI_MAX_STORES * sizeof(pds__gi_stream);
        copt.method = opt->caustics;
        if ((st = pds__render_estimate(scene, &copt, est, err))) return st;
        est->memory_bytes += gbytes;
        return PDS_OK;
    }
    if (pds__is_photon_method(opt->method) && opt->paths != PDS_PATHS_NO_CAUSTICS) {
        /* at most 2^splits first non-specular vertices per camera sample */
        est->eye_vertices = est->samples * (double)(1 << pds__eye_splits(scene, opt));
        bytes += est->eye_vertices * vertex_bytes;
        /* the partial state's two sums (>>partial), and each thread's */
        bytes += (double)npix * 6 * sizeof(pds__sum128) +
                 (double)threads * npix *
                     (3 + (pds__debug_wants(opt->debug, PDS_DEBUG_FOOTPRINT) ? 2 : 0) +
                      (pds__render_is_spectral(scene, opt) ? 3 : 0)) *
                     sizeof(pds__sum128);
        photons = opt->time_s > 0.0 ? 0.0 : (double)opt->photons; /* a time budget: not known in advance */
        if (opt->method == PDS_METHOD_PM) est->stored_photons = photons;
        if (opt->method == PDS_METHOD_PDM) est->stored_photons = photons;
#ifndef PDS_NO_BASELINES
        if (opt->method == PDS_METHOD_SPM && opt->time_s <= 0.0) est->stored_photons = (double)pds__spm_streams(opt);
        if (opt->method == PDS_METHOD_PPM) {
            est->stored_photons = (double)opt->photons;
            bytes += est->eye_vertices * sizeof(pds__ppm_state);
        }
#endif
        if (opt->method == PDS_METHOD_PDM) bytes += est->stored_photons * 2.0 * sizeof(pds__diff_photon);
        else bytes += est->stored_photons * (2.0 * sizeof(pds__stored_photon) + 21.0);
    }
    if (opt->method == PDS_METHOD_ISC) {
        est->samples = npix;
        bytes = npix * 3.0 * sizeof(float) + pds__isc_memory(scene, opt, npix);
    }
    est->memory_bytes = bytes;
    est->available_bytes = pds__physical_memory();
    return PDS_OK;
}

pds_status pds_render_estimate_get(const pds_scene *scene, const pds_options *opt, pds_render_estimate *est,
                                   pds_error *err)
{
    pds_options gi;
    if (!scene || !opt || !est)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds_render_estimate_get: NULL argument");
    if (opt->method == PDS_METHOD_SPM) {
        /* the checks of spm's own options (its stream count in the global map) */
        int w = opt->width > 0 ? opt->width : scene->camera.width;
        int h = opt->height > 0 ? opt->height : scene->camera.height;
        pds_status st = pds__options_check(opt, w, h, err);
        if (st) {
            memset(est, 0, sizeof *est);
            return st;
        }
    }
    return pds__render_estimate(scene, pds__spm_as_gi(opt, &gi), est, err);
}

/* A new partial for opt's shard of a render of scene at width x height:
   nothing done yet (>>partial). NULL when memory runs out. */
static pds_partial *pds__partial_new(const pds_scene *scene, const pds_options *opt, int width, int height)
{
    pds_partial *p = (pds_partial *)calloc(1, sizeof *p);
    size_t n = (size_t)width * (size_t)height * 3;
    /* gi's caustics come from its caustic method, split as that method's */
    pds_method cm = opt->method == PDS_METHOD_GI ? opt->caustics : opt->method;
    int photons = pds__is_photon_method(cm) && opt->paths != PDS_PATHS_NO_CAUSTICS;
    if (!p) return NULL;
    pds__strlcpy(p->version, PDS_VERSION_STRING, sizeof p->version);
    p->scene_hash = pds_scene_hash(scene);
    pds__strlcpy(p->scene_path, scene->path, sizeof p->scene_path);
    pds_options_default(&p->opt);
    {
        /* only what shapes the image; the rest stays at its default */
        uint64_t v[PDS__PARTIAL_NOPT];
        pds__partial_opt_encode(opt, v);
        pds__partial_opt_decode(v, PDS__PARTIAL_NOPT, &p->opt);
    }
    p->width = width;
    p->height = height;
    p->shard_index = opt->shard_index;
    p->shard_count = opt->shard_count;
    p->split = !photons                                      ? PDS__SPLIT_ROWS
               : cm == PDS_METHOD_PDS || cm == PDS_METHOD_SPLAT ? PDS__SPLIT_PHOTONS
                                                                : PDS__SPLIT_GATHER;
    p->rows_own = pds__shard_count_of(height, p->shard_index, p->shard_count);
    /* n_planned as the photon pass sets it (a time budget sets its own):
       every part of a render has the same */
    p->n_planned = (double)opt->photons;
#ifndef PDS_NO_BASELINES
    if (cm == PDS_METHOD_SPM) p->n_planned = (double)pds__spm_streams(opt); /* spm counts streams */
#endif
    if (p->split == PDS__SPLIT_PHOTONS) {
        long m;
        if (opt->time_s > 0.0) {
            p->units_total = 1; /* a time budget: one unit (never split) */
        } else if (cm == PDS_METHOD_PDS && opt->progressive) {
            pds__pds_pass_plan(opt, &p->units_total, &m);
            p->n_planned = (double)m;
        } else {
            p->units_total = opt->photons / PDS__PHOTON_BATCH + (opt->photons % PDS__PHOTON_BATCH != 0);
        }
        p->units_own = pds__shard_count_of(p->units_total, p->shard_index, p->shard_count);
    } else if (p->split == PDS__SPLIT_GATHER) {
        p->units_total = p->shard_count;
        p->units_own = 1;
        if (cm == PDS_METHOD_PPM) p->n_planned = (double)opt->photons * opt->passes;
    }
    p->unit = pds__sum_unit(scene);
    p->eye = (double *)calloc(n, sizeof *p->eye);
    if (p->split != PDS__SPLIT_ROWS) {
        p->photon = (pds__sum128 *)calloc(n, sizeof *p->photon);
        p->neg = (pds__sum128 *)calloc(n, sizeof *p->neg);
    }
    if (!p->eye || (p->split != PDS__SPLIT_ROWS && (!p->photon || !p->neg))) {
        pds_partial_free(p);
        return NULL;
    }
    return p;
}

/* Eye rounds (pds__pds_passes): the render's eye job runs pass `round`
   (sample indices round spp .. round spp + spp - 1 of every pixel) over
   every row, and the vertices it recorded replace the last round's. The
   values add into the job's sums; rc->traced counts the passes in them. */
typedef struct pds__retrace_ctx {
    pds__render_job *job;
    int threads;
    pds__eye_vertex *verts; /* the vertices in use (freed by the next round) */
    long traced;            /* eye passes whose values the job's sums hold */
} pds__retrace_ctx;

static pds_status pds__eye_retrace(void *vctx, long round, pds__eye_vertex **v, size_t *n, pds_error *err)
{
    pds__retrace_ctx *rc = (pds__retrace_ctx *)vctx;
    pds__render_job *job = rc->job;
    pds__eye_vertex *all;
    size_t count = 0;
    int y;
    if (((long long)round + 1) * job->spp > (long long)job->total_spp_max) return PDS_OK; /* no sample indices left */
    for (y = 0; y < job->frame.height; y++) {
        job->row_vertices[y] = NULL;
        job->row_count[y] = job->row_cap[y] = 0;
    }
    job->pass = job->record_pass = (int)round;
    job->next_row = job->rows_done = 0;
    job->progress = NULL; /* a round is part of the photon pass */
    pds__mutex_init(&job->lock);
    pds__run_threads(rc->threads, pds__render_worker, job);
    pds__mutex_destroy(&job->lock);
    rc->traced++;
    if (job->out_of_memory) {
        for (y = 0; y < job->frame.height; y++) free(job->row_vertices[y]);
        return pds__nomem(err);
    }
    all = pds__join_rows(job, &count);
    if (!all) return pds__nomem(err);
    free(rc->verts);
    rc->verts = *v = all;
    *n = count;
    return PDS_OK;
}

/* The rendering itself: the part's eye rows and photon units not done yet
   (>>partial), into the part. The eye pass renders
     - the part's remaining rows, in order (pt, preview, no caustics, and
       photon methods whose photon units are all done), or
     - the rows whose eye vertices the photon pass needs: all rows for pds
       and splat (every photon may land in any pixel), the part's rows for
       pm, pdm and ppm; the eye values of the part's rows are kept once
       the whole eye pass is done.
   spm's full image is rendered as the gi render it is (pds__spm_as_gi);
   the part keeps the options as given. */
static pds_status pds__render_into(const pds_scene *scene, const pds_options *given, pds_partial *part,
                                   pds_render_stats *stats, pds_error *err)
{
    pds_options spm_gi;
    const pds_options *opt = pds__spm_as_gi(given, &spm_gi);
    pds__render_job job;
    const pds_camera *cam = &scene->camera;
    int w = part->width, h = part->height, threads, max_passes, photons, own_list, completed, j, y, pass0 = 0;
    pds__eye_rounds rounds;  /* progressive pds: its eye rounds */
    pds__retrace_ctx rc;     /* ... their state */
    int I = part->shard_index, N = part->shard_count;
    int *rows;
    size_t i, npix, row;
    pds__gi_map gmap;
    unsigned char *row_values = NULL; /* gi: the rows whose values are wanted */
    pds_options copt;             /* gi: the options its caustic method sees */
    const pds_options *popt = opt; /* the options of the photon pass */
    int gi = 0;
    double gi_map_s = 0.0;        /* gi: pass 1's time */
    pds_status st = PDS_OK;
    memset(&job, 0, sizeof job);
    job.t0 = pds_time_now();
    job.scene = scene;
    job.frame = pds__camera_setup(cam, w, h);
    job.method = opt->method;
    job.spp = opt->spp > 0 ? opt->spp : cam->spp;
    job.filter = cam->filter;
    job.seed = opt->seed;
    job.tracer.scene = scene;
    job.tracer.paths = opt->paths;
    job.tracer.max_depth = opt->max_depth;
    job.tracer.rr_depth = opt->rr_depth;
    job.tracer.max_diffuse = opt->diffuse_bounces;
    job.tracer.seed = opt->seed;
    job.tracer.eps = 1e-6 * pds__scene_scale(scene);
    job.tracer.spectral = pds__render_is_spectral(scene, opt);
    job.tracer.spectral_all = job.tracer.spectral && opt->spectral;
    stats->spectral = job.tracer.spectral;
    job.progress = opt->progress;
    job.progress_user = opt->progress_user;
    photons = part->split != PDS__SPLIT_ROWS && part->units_done < part->units_own;
    memset(&gmap, 0, sizeof gmap);
    threads = opt->threads > 0 ? opt->threads : pds_cpu_count();
    if (threads > h) threads = h;
    if (pds__is_photon_method(opt->method)) {
        /* The eye pass computes everything but the caustics and records the
           eye-path vertices; the photon pass adds the caustics. */
        job.tracer.paths = PDS_PATHS_NO_CAUSTICS;
        job.tracer.vertices_only = photons && opt->paths == PDS_PATHS_CAUSTICS_ONLY;
        job.record_eye = photons;
        job.tracer.eye_splits = pds__eye_splits(scene, opt);
        job.merge_eye = pds__eye_merges(opt) && !(cam->aperture > 0.0) && cam->filter == PDS_FILTER_BOX;
    }
    if (opt->method == PDS_METHOD_GI) {
        /* Pass 1 builds the global and shadow maps; gi's eye path computes
           all but the caustics at its first non-specular vertex, which the
           caustic method then adds there, as for the photon methods. */
        double tm = pds_time_now();
        gi = 1;
        copt = *opt;
        copt.method = opt->caustics;
        popt = &copt;
        if ((st = pds__gi_map_build(&gmap, scene, opt, threads, err))) return st;
        gi_map_s = pds_time_now() - tm;
        gmap.record_only = opt->paths == PDS_PATHS_CAUSTICS_ONLY;
        job.path = pds__gi_path;
        job.path_ctx = &gmap;
        job.row_counts = (long *)calloc((size_t)h * 4, sizeof *job.row_counts);
        job.record_eye = photons;
        job.merge_eye = pds__eye_merges(popt) && !(cam->aperture > 0.0) && cam->filter == PDS_FILTER_BOX;
        /* The final gather is the costly part of gi's eye pass, and only
           the part's rows not yet kept need it; the other rows (every row
           is rendered when the caustic method is pds or splat, whose
           photons may land anywhere) only record their vertices, which do
           not depend on it. So a shard, or a resumed render, gathers only
           for the pixels it keeps, and the kept values are the same bits. */
        row_values = (unsigned char *)calloc((size_t)h, 1);
        for (y = 0; row_values && y < h; y++)
            row_values[y] = y % N == I && (y - I) / N >= part->rows_done;
        job.row_values = row_values;
    }
    /* Sample indices must not overlap between pixels: reserve room for the
       most passes a time budget could ever take (the photon methods spend
       their time budget on photons, after one eye pass). */
    max_passes = opt->time_s > 0.0 && !pds__is_photon_method(opt->method) && !gi ? PDS_MAX_SPP / job.spp : 1;
    if (max_passes < 1) max_passes = 1;
    job.total_spp_max = job.spp * max_passes;
    /* eye rounds (pds__pds_passes) of progressive PDS, without teaching
       views: under a photon budget R = eye_rounds (at most one a pass),
       under a time budget as many as the time allows (at most
       eye_rounds if above 1), in a render of one part. Round r's samples
       are pass r's, after those of the rounds before it. */
    job.record_pass = -1;
    memset(&rounds, 0, sizeof rounds);
    if (opt->method == PDS_METHOD_PDS && opt->progressive && photons && !opt->debug && opt->eye_rounds != 1) {
        long most = PDS_MAX_SPP / job.spp;
        if (opt->time_s > 0.0 && N == 1) {
            rounds.rounds = opt->eye_rounds > 1 && opt->eye_rounds < most ? opt->eye_rounds : most;
        } else if (opt->time_s <= 0.0 && opt->eye_rounds > 1) {
            rounds.rounds = opt->eye_rounds < part->units_total ? opt->eye_rounds : part->units_total;
            if (rounds.rounds > most) rounds.rounds = most;
        }
    }
    if (rounds.rounds > 1) {
        rounds.retrace = pds__eye_retrace;
        rounds.ctx = &rc;
        job.total_spp_max = job.spp * (int)rounds.rounds;
        if (opt->time_s <= 0.0) {
            /* a photon budget: the eye pass is the round of the part's first
               pass to run, and the values (while the part's rows are not
               kept, and the image has more than caustics) the mean of
               every round's, each eye pass traced again as its round comes */
            rounds.round = pds__eye_round_of(I + part->units_done * N, part->units_total, rounds.rounds);
            job.record_pass = (int)rounds.round;
            if (part->rows_done < part->rows_own && opt->paths != PDS_PATHS_CAUSTICS_ONLY) {
                pass0 = 0;
                max_passes = (int)rounds.rounds;
            } else {
                pass0 = (int)rounds.round;
                max_passes = pass0 + 1;
            }
        }
    }
    job.stoppable = max_passes - pass0 == 1;
    npix = (size_t)w * (size_t)h;
    row = (size_t)w * 3;
    /* the rows to render */
    rows = (int *)malloc(sizeof *rows * (size_t)h);
    own_list = !photons || part->split == PDS__SPLIT_GATHER;
    job.nrows = 0;
    if (rows && !photons) {
        for (j = (int)part->rows_done; j < (int)part->rows_own; j++) rows[job.nrows++] = I + j * N;
    } else if (rows && part->split == PDS__SPLIT_GATHER) {
        for (j = 0; j < (int)part->rows_own; j++) rows[job.nrows++] = I + j * N;
    } else if (rows) {
        for (y = 0; y < h; y++) rows[job.nrows++] = y;
    }
    job.rows = rows;
    job.sum = (double *)calloc(npix * 3, sizeof(double));
    if (job.record_eye) {
        job.row_vertices = (pds__eye_vertex **)calloc((size_t)h, sizeof *job.row_vertices);
        job.row_count = (size_t *)calloc((size_t)h, sizeof *job.row_count);
        job.row_cap = (size_t *)calloc((size_t)h, sizeof *job.row_cap);
    }
    if (!rows || !job.sum || (job.record_eye && (!job.row_vertices || !job.row_count || !job.row_cap)) ||
        (gi && (!job.row_counts || !row_values))) {
        free(rows);
        free(job.sum);
        free(job.row_vertices);
        free(job.row_count);
        free(job.row_cap);
        free(job.row_counts);
        free(row_values);
        pds__gi_map_free(&gmap);
        return pds__nomem(err);
    }
    pds__mutex_init(&job.lock);
    job.caller = pds__thread_self();
    for (job.pass = pass0; job.pass < max_passes; job.pass++) {
        double elapsed;
        job.next_row = 0;
        job.rows_done = 0;
        if (max_passes > 1 && !(opt->time_s > 0.0)) {
            /* a photon budget's eye rounds (their values): progress in passes */
            job.progress_base = (double)(job.pass - pass0) / (max_passes - pass0);
            job.progress_scale = 1.0 / (max_passes - pass0);
        } else if (max_passes > 1) {
            /* progress in time: this pass covers the time fraction so far */
            elapsed = pds_time_now() - job.t0;
            job.progress_base = elapsed / opt->time_s < 1.0 ? elapsed / opt->time_s : 1.0;
            job.progress_scale = 0.0;
        } else {
            job.progress_base = 0.0;
            job.progress_scale = 1.0;
        }
        if (job.nrows > 0) threads = pds__run_threads(threads, pds__render_worker, &job);
        elapsed = pds_time_now() - job.t0;
        if (job.pass + 1 >= max_passes || (opt->time_s > 0.0 && elapsed >= opt->time_s) || job.stop_requested) {
            job.pass++;
            break;
        }
    }
    rc.job = &job;
    rc.threads = threads;
    rc.verts = NULL;
    rc.traced = job.pass - pass0;
    pds__mutex_destroy(&job.lock);
    stats->time_eye_s = pds_time_now() - job.t0 - gi_map_s;
    stats->memory_bytes = npix * 3 * sizeof(double) * 2 + (part->photon ? npix * 6 * sizeof(pds__sum128) : 0);
    /* the rows handed out before a stop are all finished: a prefix (a stop
       in one of several passes of values keeps nothing) */
    completed = job.stop ? (job.next_row < job.nrows ? job.next_row : job.nrows) : job.nrows;
    if (job.stop_requested && max_passes - pass0 > 1 && pds__is_photon_method(opt->method)) completed = 0;
    /* keep the eye values (the average of the passes) of the part's rows */
    if (own_list || completed == job.nrows) {
        int zero = (pds__is_photon_method(opt->method) || gi) && opt->paths == PDS_PATHS_CAUSTICS_ONLY;
        for (j = 0; j < completed; j++) {
            long own;
            y = rows[j];
            if (y % N != I) continue;
            own = (y - I) / N;
            if (own < part->rows_done) continue;
            for (i = 0; i < row; i++)
                part->eye[(size_t)y * row + i] = zero ? 0.0 : job.sum[(size_t)y * row + i] / ((double)job.spp * job.pass);
        }
        if (!photons) part->rows_done += completed;
        else if (completed == job.nrows) part->rows_done = part->rows_own;
    }
    if (gi) {
        for (y = 0; y < h; y++) {
            stats->shadow_rays += job.row_counts[4 * (size_t)y];
            stats->shadow_rays_saved += job.row_counts[4 * (size_t)y + 1];
            stats->gather_rays += job.row_counts[4 * (size_t)y + 2];
        }
        stats->global_stored = (long)gmap.n;
        stats->global_streams = (long)gmap.nstreams;
        stats->shadow_stored = (long)gmap.ns;
        free(job.row_counts);
        free(row_values);
    }
    if (job.record_eye) {
        size_t nv = 0;
        pds__eye_vertex *verts = job.out_of_memory ? NULL : pds__join_rows(&job, &nv);
        rc.verts = verts;
        rounds.eye_s = stats->time_eye_s;
        if (job.out_of_memory) {
            for (y = 0; y < h; y++) free(job.row_vertices[y]);
        }
        if (!verts) st = pds__nomem(err);
        else if (completed == job.nrows)
            st = pds__photon_pass(scene, popt, verts, nv, w, h, threads, part, opt->debug,
                                  rounds.rounds > 1 ? &rounds : NULL, stats, err);
        if (!st && completed == job.nrows && rounds.rounds > 1 && opt->time_s > 0.0) {
            /* a time budget's rounds: the values are the mean of all
               (one part, every row its own) */
            int zero = opt->paths == PDS_PATHS_CAUSTICS_ONLY;
            for (i = 0; i < npix * 3; i++) part->eye[i] = zero ? 0.0 : job.sum[i] / ((double)job.spp * rc.traced);
            job.pass = (int)rc.traced;
        } else if (!st && completed == job.nrows && rounds.rounds > 1) {
            job.pass = (int)rounds.rounds; /* for stats->spp: the caustic's samples */
        }
        free(rc.verts);
        free(job.row_vertices);
        free(job.row_count);
        free(job.row_cap);
    }
    if (gi) {
        /* the caustic method's map (pm, pdm, ppm) and the global maps */
        size_t gbytes = pds__gi_map_bytes(&gmap);
        stats->time_map_s += gi_map_s;
        stats->map_bytes += gbytes;
        stats->memory_bytes += gbytes;
        pds__gi_map_free(&gmap);
    }
    free(job.sum);
    free(rows);
    if (st) return st;
    part->splatted += stats->splatted;
    part->degenerate += stats->dropped_degenerate;
    part->saturated += stats->saturated;
    part->invalid += stats->dropped_invalid;
    if (stats->eye_vertices > part->eye_vertices) part->eye_vertices = stats->eye_vertices;
    stats->threads = threads;
    stats->width = w;
    stats->height = h;
    stats->spp = job.spp * job.pass;
    if (popt->method != PDS_METHOD_PPM && !(popt->method == PDS_METHOD_PDS && popt->progressive))
        stats->passes = job.pass; /* ppm and progressive pds: their photon passes */
    return PDS_OK;
}

/* The checks before any work: the memory estimate. */
static pds_status pds__render_memory_check(const pds_scene *scene, const pds_options *opt, int w, int h,
                                           pds_error *err)
{
    pds_render_estimate est;
    double limit;
    pds_status st;
    if ((st = pds_render_estimate_get(scene, opt, &est, err))) return st;
    limit = opt->memory_limit > 0.0 ? opt->memory_limit : est.available_bytes;
    if (limit > 0.0 && est.memory_bytes > limit)
        return pds__fail(err, PDS_ERR_LIMIT, NULL, 0, 0,
                         "this render needs up to %.1f GB (%dx%d pixels, %.3g eye vertices, %.3g stored photons) "
                         "but %s %.1f GB: lower the resolution, spp or photon count",
                         est.memory_bytes / 1e9, w, h, est.eye_vertices, est.stored_photons,
                         opt->memory_limit > 0.0 ? "the memory limit is" : "this machine has", limit / 1e9);
    return PDS_OK;
}

pds_status pds_render_part(const pds_scene *scene, const pds_options *opt, pds_partial **part,
                           pds_render_stats *stats, pds_error *err)
{
    pds_render_stats local;
    pds_partial_info info;
    const pds_camera *cam;
    int w, h;
    pds_status st;
    double t0 = pds_time_now();
    if (!scene || !opt || !part) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds_render_part: NULL argument");
    cam = &scene->camera;
    w = opt->width > 0 ? opt->width : cam->width;
    h = opt->height > 0 ? opt->height : cam->height;
    if ((st = pds__options_check(opt, w, h, err))) return st;
    if ((st = pds__camera_check(scene, opt, err))) return st;
    if ((st = pds__render_memory_check(scene, opt, w, h, err))) return st;
    if (*part) {
        pds_partial *p = *part;
        if (opt->time_s > 0.0)
            return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0,
                             "a render with a time budget cannot be continued: its photon count is not fixed");
        if (opt->debug && opt->debug->views)
            return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0,
                             "the teaching views are made by a render in one go, not by a continued one");
        if (p->scene_hash != pds_scene_hash(scene))
            return pds__fail(err, PDS_ERR_INVALID_ARG, scene->path, 0, 0,
                             "not the scene this part was rendered from (%s): its content differs (the file changed, "
                             "or other -D values or OBJ material were given)", p->scene_path);
        if (!pds__partial_same_options(&p->opt, opt) || p->width != w || p->height != h ||
            p->shard_index != opt->shard_index || p->shard_count != opt->shard_count)
            return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0,
                             "these options are not the ones the part was rendered with (pds_partial_options)");
    } else {
        if (opt->debug) pds_debug_free(opt->debug); /* a previous render's views */
        *part = pds__partial_new(scene, opt, w, h);
        if (!*part) return pds__nomem(err);
    }
    if (!stats) stats = &local;
    memset(stats, 0, sizeof *stats);
    if (opt->method == PDS_METHOD_ISC) {
        /* isc renders its frame in one go: every pixel's value needs the
           eye buffer and the photons of the whole frame (its gathers look
           at neighbouring pixels, its quads cover any of them), and the
           frame cannot stop half way. So a shard renders the whole frame
           and keeps its rows I, I+N, ... as its eye values (split 0), and
           a merge takes each row from its shard: the same bits. A part
           holds all or none of its rows. */
        pds_partial *p = *part;
        pds_image img = {0, 0, NULL};
        size_t k, row = (size_t)w * 3;
        long j;
        int threads = opt->threads > 0 ? opt->threads : pds_cpu_count();
        if (p->rows_done < p->rows_own) {
            st = pds__isc_render(scene, opt, w, h, threads, 1, NULL, NULL, &img, stats, err);
            if (st) return st;
            for (j = 0; j < p->rows_own; j++) {
                size_t y = (size_t)p->shard_index + (size_t)j * (size_t)p->shard_count;
                for (k = 0; k < row; k++) p->eye[y * row + k] = img.rgb[y * row + k];
            }
            pds_image_free(&img);
            p->rows_done = p->rows_own;
        }
        if (opt->progress) (void)opt->progress(opt->progress_user, PDS_PHASE_PHOTONS, 1.0, pds_time_now() - t0);
        stats->threads = threads;
        stats->width = w;
        stats->height = h;
        stats->partial = 0;
        stats->done_fraction = 1.0;
        stats->time_total_s = pds_time_now() - t0;
        return PDS_OK;
    }
    st = pds__render_into(scene, opt, *part, stats, err);
    if (st) return st;
    pds_partial_get_info(*part, &info);
    stats->partial = !info.complete;
    stats->done_fraction = info.done_fraction;
    if (opt->progress && info.complete)
        (void)opt->progress(opt->progress_user,
                            (*part)->split == PDS__SPLIT_ROWS      ? PDS_PHASE_EYE
                            : (*part)->split == PDS__SPLIT_PHOTONS ? PDS_PHASE_PHOTONS
                                                                   : PDS_PHASE_GATHER,
                            1.0, pds_time_now() - t0);
    stats->time_total_s = pds_time_now() - t0;
    return PDS_OK;
}

pds_status pds_render_light_traced(const pds_scene *scene, const pds_options *opt, pds_image *out, pds_error *err)
{
    int w, h;
    pds_status st;
    if (!scene || !opt || !out)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds_render_light_traced: NULL argument");
    w = opt->width > 0 ? opt->width : scene->camera.width;
    h = opt->height > 0 ? opt->height : scene->camera.height;
    if ((st = pds__options_check(opt, w, h, err))) return st;
    return pds__light_trace_image(scene, opt, w, h, out, err);
}

pds_status pds_render(const pds_scene *scene, const pds_options *opt, pds_image *out,
                      pds_render_stats *stats, pds_error *err)
{
    pds_render_stats local;
    pds_partial *part = NULL;
    const pds_partial *parts[1];
    pds_status st;
    double t0 = pds_time_now();
    if (!scene || !opt || !out) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds_render: NULL argument");
    if (!stats) stats = &local;
    st = pds_render_part(scene, opt, &part, stats, err);
    if (st) {
        pds_partial_free(part);
        if (opt->debug) pds_debug_free(opt->debug);
        return st;
    }
    /* the image of the state, as a merge of shards makes it */
    parts[0] = part;
    st = pds__partial_merge(parts, NULL, 1, 1, out, NULL, &stats->nonfinite, err);
    pds_partial_free(part);
    stats->partial = stats->partial || opt->shard_count > 1;
    stats->time_total_s = pds_time_now() - t0;
    return st;
}

pds_status pds_render_frames(const pds_scene *scene, const pds_options *opt, int frames, pds_frame_fn fn,
                             void *user, pds_render_stats *stats, pds_error *err)
{
    pds_render_stats local;
    pds_options o;
    int w, h, threads;
    double t0 = pds_time_now();
    pds_status st;
    if (!scene || !opt || !fn) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds_render_frames: NULL argument");
    if (opt->method != PDS_METHOD_ISC)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0,
                         "animation frames are rendered by image-space caustics (method isc) only, not %s",
                         pds_method_name(opt->method));
    if (frames < 1 || frames > 1000000)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "frame count %d is outside 1..1000000", frames);
    if (opt->static_lighting && opt->orbit == PDS_ORBIT_LIGHT)
        return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0,
                         "static lighting keeps the photons of the first frame, so the light cannot orbit (orbit "
                         "the camera, or nothing)");
    w = opt->width > 0 ? opt->width : scene->camera.width;
    h = opt->height > 0 ? opt->height : scene->camera.height;
    if ((st = pds__options_check(opt, w, h, err))) return st;
    if ((st = pds__camera_check(scene, opt, err))) return st;
    o = *opt;
    o.time_s = 0.0; /* frames, not a still's time budget */
    {
        pds_render_estimate est;
        double limit;
        if ((st = pds_render_estimate_get(scene, &o, &est, err))) return st;
        limit = o.memory_limit > 0.0 ? o.memory_limit : est.available_bytes;
        if (limit > 0.0 && est.memory_bytes > limit)
            return pds__fail(err, PDS_ERR_LIMIT, NULL, 0, 0, "these frames need up to %.1f GB but %s %.1f GB",
                             est.memory_bytes / 1e9, o.memory_limit > 0.0 ? "the memory limit is" : "this machine has",
                             limit / 1e9);
    }
    if (!stats) stats = &local;
    memset(stats, 0, sizeof *stats);
    threads = o.threads > 0 ? o.threads : pds_cpu_count();
    st = pds__isc_render(scene, &o, w, h, threads, frames, fn, user, NULL, stats, err);
    stats->time_total_s = pds_time_now() - t0;
    stats->threads = threads;
    stats->width = w;
    stats->height = h;
    return st;
}

#ifndef PDS_NO_BENCH
/* `pds bench rays`: the rays are made before the clock starts, so only
   traversal is timed (best of three passes after a warm-up). Primary: an n x n grid from the bounding box centre
   + (0, 0, 1.5 x largest extent), looking down -z, 60 degree square field
   of view. Random: origins uniform in the box, directions uniform on the
   sphere. One thread. */
pds_status pds_bench_rays(const char *path, long rays, pds_bench_rays_result *out, pds_error *err)
{
    pds_scene *s = NULL;
    pds_status st;
    pds__v3 *org = NULL, *dir = NULL, lo, hi, ext, centre;
    long n, i, side, hits;
    int kind, rep;
    double largest;
    if (!path || !out || rays < 1) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds_bench_rays: bad argument");
    memset(out, 0, sizeof *out);
    st = pds__has_extension(path, "obj") ? pds_scene_load_obj(path, &s, err) : pds_scene_load(path, &s, err);
    if (st) return st;
    side = (long)floor(sqrt((double)rays));
    if (side < 1) side = 1;
    n = side * side;
    org = (pds__v3 *)malloc(sizeof *org * (size_t)n);
    dir = (pds__v3 *)malloc(sizeof *dir * (size_t)n);
    if (!org || !dir) {
        free(org);
        free(dir);
        pds_scene_free(s);
        return pds__nomem(err);
    }
    lo = s->bounds_min;
    hi = s->bounds_max;
    ext = pds__sub(hi, lo);
    centre = pds__scale(pds__add(lo, hi), 0.5);
    largest = ext.x > ext.y ? (ext.x > ext.z ? ext.x : ext.z) : (ext.y > ext.z ? ext.y : ext.z);
    out->triangles = (long)s->mesh.ntris;
    out->build_s = s->bvh_build_s;
    out->rays = n;
    for (kind = 0; kind < 2; kind++) {
        double t0, dt;
        for (i = 0; i < n; i++) {
            if (kind == 0) {
                double t = tan(30.0 * PDS__PI / 180.0);
                double sx = (2.0 * ((double)(i % side) + 0.5) / side - 1.0) * t;
                double sy = (2.0 * ((double)(i / side) + 0.5) / side - 1.0) * t;
                org[i] = pds__add(centre, pds__v(0.0, 0.0, 1.5 * largest));
                dir[i] = pds__normalize(pds__v(sx, sy, -1.0));
            } else {
                double u[5], z, r, phi;
                int k;
                for (k = 0; k < 5; k++) u[k] = pds__rng_uniform(0, PDS__RNG_BENCH, (uint64_t)i, (uint64_t)k);
                org[i] = pds__add(lo, pds__mul(ext, pds__v(u[0], u[1], u[2])));
                z = 1.0 - 2.0 * u[3];
                r = sqrt(1.0 - z * z > 0.0 ? 1.0 - z * z : 0.0);
                phi = 2.0 * PDS__PI * u[4];
                dir[i] = pds__v(r * cos(phi), r * sin(phi), z);
            }
        }
        /* one warm-up pass, then the best of three timed passes: the
           figure describes the code, not what else the machine was doing */
        dt = DBL_MAX;
        for (rep = 0; rep < 4; rep++) {
            double d;
            hits = 0;
            t0 = pds_time_now();
            for (i = 0; i < n; i++) {
                pds__tri_hit th;
                hits += pds__bvh_intersect(&s->bvh, org[i], dir[i], 0.0, DBL_MAX, &th);
            }
            d = pds_time_now() - t0;
            if (rep > 0 && d < dt) dt = d;
        }
        if (dt <= 0.0) dt = 1e-9;
        if (kind == 0) {
            out->primary_mrays = (double)n / dt * 1e-6;
            out->primary_hits = hits;
        } else {
            out->random_mrays = (double)n / dt * 1e-6;
            out->random_hits = hits;
        }
    }
    free(org);
    free(dir);
    pds_scene_free(s);
    return PDS_OK;
}

pds_status pds_bench_filter(long filters, pds_bench_filter_result *out, pds_error *err)
{
    pds__v3 *fp;
    long i;
    int rep;
    double t0, sink = 0.0, best[2] = {DBL_MAX, DBL_MAX};
    if (!out || filters < 1) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds_bench_filter: bad argument");
    memset(out, 0, sizeof *out);
    fp = (pds__v3 *)malloc(sizeof *fp * 3 * (size_t)filters);
    if (!fp) return pds__nomem(err);
    for (i = 0; i < filters; i++) {
        /* random footprint: two vectors in the plane of a random normal */
        double u[6];
        pds__v3 n, b1, b2;
        int k;
        for (k = 0; k < 6; k++) u[k] = pds__rng_uniform(0, PDS__RNG_BENCH, (uint64_t)i, (uint64_t)k);
        n = pds__normalize(pds__v(u[0] - 0.5, u[1] - 0.5, u[2] - 0.5 + 1e-3));
        pds__onb(n, &b1, &b2);
        fp[3 * i] = pds__add(pds__scale(b1, 0.1 + u[3]), pds__scale(b2, u[4] - 0.5));
        fp[3 * i + 1] = pds__add(pds__scale(b1, u[5] - 0.5), pds__scale(b2, 0.1 + u[3] * u[4]));
        fp[3 * i + 2] = n;
    }
    for (rep = 0; rep < 4; rep++) {
        int method;
        for (method = 0; method < 2; method++) {
            double d;
            t0 = pds_time_now();
            for (i = 0; i < filters; i++) {
                double M[2][3] = {{0, 0, 0}, {0, 0, 0}};
                if (method == 0) pds__filter_matrix(fp[3 * i], fp[3 * i + 1], fp[3 * i + 2], M);
                else pds__filter_matrix_general(fp[3 * i], fp[3 * i + 1], fp[3 * i + 2], M);
                sink += M[0][0] + M[1][2];
            }
            d = pds_time_now() - t0;
            if (rep > 0 && d < best[method]) best[method] = d;
        }
    }
    for (i = 0; i < filters; i++) {
        double A[2][3], B[2][3];
        int r, k;
        if (!pds__filter_matrix(fp[3 * i], fp[3 * i + 1], fp[3 * i + 2], A) ||
            !pds__filter_matrix_general(fp[3 * i], fp[3 * i + 1], fp[3 * i + 2], B))
            continue;
        for (r = 0; r < 2; r++)
            for (k = 0; k < 3; k++) {
                double rel = fabs(A[r][k] - B[r][k]) / (fabs(B[r][k]) + 1e-12);
                if (rel > out->max_rel_diff) out->max_rel_diff = rel;
            }
    }
    free(fp);
    out->filters = filters;
    out->eq12_mps = (double)filters / fmax(best[0], 1e-9) * 1e-6;
    out->general_mps = (double)filters / fmax(best[1], 1e-9) * 1e-6;
    /* the sink keeps the timed loops from being optimised away */
    if (sink == 12345.678) out->max_rel_diff += 0.0;
    return PDS_OK;
}

/* Range-query visitor of the benchmark: counts. */
static void pds__bench_count(void *ctx, size_t index, double dist2)
{
    (void)index;
    (void)dist2;
    (*(long *)ctx)++;
}

pds_status pds_bench_kdtree(long points, pds_bench_kdtree_result *out, pds_error *err)
{
    pds__kdtree kd;
    float *pos;
    size_t *idx;
    double *d2, t0, r;
    long i, queries = 200000, found = 0;
    pds_status st;
    if (!out || points < 1) return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "pds_bench_kdtree: bad argument");
    memset(out, 0, sizeof *out);
    pos = (float *)malloc(sizeof *pos * 3 * (size_t)points);
    idx = (size_t *)malloc(sizeof *idx * 32);
    d2 = (double *)malloc(sizeof *d2 * 32);
    if (!pos || !idx || !d2) {
        free(pos);
        free(idx);
        free(d2);
        return pds__nomem(err);
    }
    for (i = 0; i < 3 * points; i++) pos[i] = (float)pds__rng_uniform(1, PDS__RNG_BENCH, (uint64_t)i, 0);
    t0 = pds_time_now();
    st = pds__kdtree_build(&kd, pos, 3, (size_t)points, err);
    out->build_s = pds_time_now() - t0;
    if (st) {
        free(pos);
        free(idx);
        free(d2);
        return st;
    }
    /* radius holding about 32 points of the unit cube: 4/3 pi r^3 n = 32 */
    r = cbrt(32.0 * 3.0 / (4.0 * PDS__PI * (double)points));
    t0 = pds_time_now();
    for (i = 0; i < queries; i++) {
        pds__v3 c = pds__v(pds__rng_uniform(2, PDS__RNG_BENCH, (uint64_t)i, 0), pds__rng_uniform(2, PDS__RNG_BENCH, (uint64_t)i, 1),
                           pds__rng_uniform(2, PDS__RNG_BENCH, (uint64_t)i, 2));
        pds__kdtree_range(&kd, c, r, pds__bench_count, &found);
    }
    out->range_mqps = (double)queries / fmax(pds_time_now() - t0, 1e-9) * 1e-6;
    out->found_per_query = (double)found / (double)queries;
    t0 = pds_time_now();
    for (i = 0; i < queries; i++) {
        pds__v3 c = pds__v(pds__rng_uniform(2, PDS__RNG_BENCH, (uint64_t)i, 0), pds__rng_uniform(2, PDS__RNG_BENCH, (uint64_t)i, 1),
                           pds__rng_uniform(2, PDS__RNG_BENCH, (uint64_t)i, 2));
        pds__kdtree_knn(&kd, c, 32, DBL_MAX, idx, d2);
    }
    out->knn_mqps = (double)queries / fmax(pds_time_now() - t0, 1e-9) * 1e-6;
    out->points = points;
    out->queries = queries;
    pds__kdtree_free(&kd);
    free(pos);
    free(idx);
    free(d2);
    return PDS_OK;
}
#else
static pds_status pds__no_bench(pds_error *err)
{
    return pds__fail(err, PDS_ERR_INVALID_ARG, NULL, 0, 0, "this build leaves the benchmarks out (PDS_NO_BENCH)");
}
pds_status pds_bench_rays(const char *path, long rays, pds_bench_rays_result *out, pds_error *err)
{
    (void)path, (void)rays, (void)out;
    return pds__no_bench(err);
}
pds_status pds_bench_filter(long filters, pds_bench_filter_result *out, pds_error *err)
{
    (void)filters, (void)out;
    return pds__no_bench(err);
}
pds_status pds_bench_kdtree(long points, pds_bench_kdtree_result *out, pds_error *err)
{
    (void)points, (void)out;
    return pds__no_bench(err);
}
#endif /* PDS_NO_BENCH */

/* main.c - the `pds` command-line tool, built only on pds.h.

   Build: cc -std=c99 -O2 -o pds main.c pds.c -lm -lpthread

   Exit status: 0 success, 1 failure (bad input, I/O), 2 usage error.
   Every command ends with one machine-readable line of key=value pairs on
   stdout; errors go to stderr as FILE:LINE:COLUMN: message, usage errors as
   "pds COMMAND: what is wrong". Every command answers --help / -h.

   The options of render, sweep and race come from one table
   (option_table): option name -> setter, with the methods whose image the
   option changes and the commands that take it. An option's value follows
   it (--photons 1e6) or is joined to it (--photons=1e6); counts take
   exponents and the suffixes k, M and G. sweep and race (the comparison
   harness) keep every image in memory and create their output folder only
   after all renders have succeeded.

   Every output file is written under a temporary name and renamed into
   place (pds.h: "PATH.tmp-PID"), so a failure never leaves a half-written
   file. SIGINT, SIGTERM and SIGHUP are caught (>>signals): the handler
   removes the temporary file being written, if any, clears the progress
   bar and dies by the same signal. */
#ifndef _WIN32
#define _POSIX_C_SOURCE 200809L /* isatty, fileno, mkdir, access, strdup, sigaction */
#endif
#include "pds.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <time.h>
#ifdef _WIN32
/* Windows (MinGW-w64, MSVC): the POSIX calls below under their Microsoft
   C runtime names; no SIGHUP, no peak memory figure, no uname. */
#include <direct.h>
#include <io.h>
#include <process.h>
#define getpid _getpid
#define isatty _isatty
#define fileno _fileno
#define unlink _unlink
#define access _access
#define strdup _strdup
#define mkdir(path, mode) _mkdir(path)
#define write(fd, buf, n) _write(fd, buf, (unsigned)(n))
#ifndef W_OK
#define W_OK 2
#endif
#ifndef X_OK
#define X_OK 0 /* _access knows no execute bit: 0 checks existence */
#endif
#define STDERR_FILENO 2
#if defined(_MSC_VER) && !defined(_SSIZE_T_DEFINED)
#define _SSIZE_T_DEFINED /* MSVC's C runtime has no ssize_t (MinGW-w64's has) */
typedef long ssize_t;
#endif
#else
#include <sys/resource.h>
#include <sys/utsname.h>
#include <unistd.h>
#endif

#define EXIT_USAGE 2
#define PATH_MAX_LEN 4096

#if defined(__GNUC__)
#define PRINTF_LIKE(f, a) __attribute__((format(printf, f, a)))
#else
#define PRINTF_LIKE(f, a)
#endif

/* ------------------------------------------------------------------- help */

/* One command's help: `pds help` prints every entry (synopsis and summary
   on one line, then the details); `pds COMMAND --help` prints one. Each
   literal stays under the 4095 bytes C99 guarantees. */
typedef struct command_help {
    const char *name;     /* "render" */
    const char *synopsis; /* "render SCENE [options]" */
    const char *summary;  /* one line */
    const char *details;  /* options and notes, indented six spaces; may be "" */
    const char *more;     /* their continuation (a C99 compiler need not take a
                             string literal longer than 4095 characters) */
    const char *rest;     /* and its continuation; may be "" */
    int takes_options;    /* follows the option syntax of render (the footer applies) */
} command_help;

static const command_help help_table[] = {
    {"render", "render SCENE [options]", "render a scene file (or a bare .obj) to an image",
     "      -o, --output FILE       output image, .png (tone-mapped sRGB), .pfm or .exr (linear; OpenEXR\n"
     "                              float RGB), each with the render's metadata\n"
     "                              (default: the scene's name with .png, in the current folder)\n"
     "      --method NAME           pds (photon differential splatting, default), pt (path tracing),\n"
     "                              preview (eye-light shading), or a baseline: pm (photon mapping),\n"
     "                              pdm (photon differential mapping), splat (fixed-radius photon\n"
     "                              splatting), ppm (progressive photon mapping), spm (streamed\n"
     "                              photon mapping), or gi (Jensen's two-pass global illumination:\n"
     "                              global photon map, final gather, shadow photons, caustics from\n"
     "                              --caustics)\n"
     "                              isc: image-space caustics (see below)\n"
     "      --photons N             photon methods: caustic photons (default 100000; ppm: per pass;\n"
     "                              gi: pixels x samples / 16, 4096..4M)\n"
     "      --smoothing S           pdm, and pds: the paper's fixed-s PDS with smoothing s (default 12;\n"
     "                              5..40); as --min-aspect and --min-width, it turns progressive PDS off\n"
     "      --plane-tolerance F     pds, pdm, splat: ignore eye vertices farther than F x the footprint's\n"
     "                              major semi-axis from the photon's tangent plane (default 0.25)\n"
     "      --min-aspect A          pds, pdm: widen needle footprints to at least A x their length\n"
     "                              (default 0: never, as in the paper; try 0.1-0.3 with many photons)\n"
     "      --progressive           pds: progressive PDS (the default): passes whose footprints shrink so\n"
     "                              that the image converges as photons are added\n"
     "      --pass-smoothing S      progressive pds: the first pass's s (default 2)\n"
     "      --pass-min-aspect A     progressive pds: as --min-aspect (default 0.1)\n"
     "      --pass-min-width W      progressive pds: as --min-width (default 1.5)\n"
     "      --pass-photons N        progressive pds: photons per pass, at most (default 16384)\n"
     "      --eye-rounds R          progressive pds: passes splat into R eye passes of spp samples each\n"
     "                              (--photons: R runs of passes, 0 one per 1.5 x w h spp photons;\n"
     "                              --time: 0 re-traces it as time goes, R > 1 at most R; 1: one pass)\n"
     "      --split-depth N         progressive pds: split a photon whose footprint the surface's curvature\n"
     "                              makes non-linear into 4 sub-photons, at most N times (default 0: never)\n"
     "      --split-angle A         progressive pds: split above a normal turn of A radians over the\n"
     "                              footprint (default 0.2)\n"
     "      --no-walls              progressive pds: footprints reach under walls (default: folded there)\n"
     "      --no-pass-select        progressive pds: one scale for every pixel (default: pixels seen\n"
     "                              directly take the passes' scale, half of it, a blur or a blend, as\n"
     "                              independent light-traced photons say; pixels seen through glass a\n"
     "                              blur, as the passes' halves say)\n"
     "      --min-width W           pds: widen footprints to semi-axes of at least W eye-sample spacings\n"
     "      --pass-alpha A          progressive pds: pass i's footprint areas shrink as i^(A-1) (default 2/3)\n"
     "      --debug NAME            write a view OUT.NAME.png: footprint, landings, ellipses[=N], splats,\n"
     "                              eye, paths[=N] (.obj), scales; several allowed (README: Teaching views)\n"
     "      --k N                   pm: photons (spm: streams) per estimate (default 50)\n"
     "      --kernel NAME           pm: density kernel cone (default), gaussian or none (uniform disc)\n"
     "      --max-radius R          pm, spm: largest gather radius in scene units (default: no limit)\n"
     "      --streams N             spm: streams nfs (default photons / (stream-photons + 1)); below\n",
     "      --stream-photons N      spm, gi: associated photons per stream nfa (default 10)\n"
     "      --max-photons N         pdm: most photons gathered per estimate (default 500)\n"
     "      --radius R              splat: splat radius; ppm: initial radius (default: from the scene)\n"
     "      --alpha A               ppm: radius reduction, 0 < A <= 1 (default 0.7)\n"
     "      --passes N              ppm: photon passes (default 10; with --time, until the time is spent)\n"
     "                              memory: pm and pdm store every photon, spm every stream, so their\n"
     "                              memory grows with --photons (the final line reports map_bytes); ppm\n"
     "                              keeps one pass's photons, pds and splat none\n"
     "      -D NAME=VALUE           the scene's `define NAME` is VALUE\n"
     "      --obj-material M        a bare .obj in its studio: auto, diffuse, glass or metal\n"
     "      --spp N                 samples per pixel (per pass with --time; default: the scene's)\n"
     "      --res WxH               resolution (default: the scene camera's)\n"
     "      --threads N             worker threads (default: all cores); the image does not depend on it\n"
     "      --seed N                random seed (default 0); same seed, same image\n"
     "      --max-depth N           longest eye path in bounces (default 32) and, if given, longest\n"
     "                              photon path in specular bounces (default 16)\n"
     "      --diffuse-bounces N     eye paths bounce off at most N non-specular surfaces (default: no\n"
     "                              limit); 0: direct light and caustics, no indirect light\n"
     "      --time SECONDS          the render's time: pt: passes of --spp samples until it is spent;\n"
     "                              photon methods and gi: one eye pass, then caustic photons until it\n"
     "                              is spent (the eye pass counts)\n"
     "      --no-caustics           leave out caustic paths L S+ D... (what the photon methods add)\n"
     "      --caustics-only         only caustic paths (pt: the reference for photon methods)\n"
     "      --spectral              one wavelength per camera sample and photon, CIE 1931 film, from the\n"
     "                              first vertex on (a scene with a cauchy or sellmeier material is\n"
     "                              spectral anyway, from the first dispersive material on)\n"
     "      --exposure STOPS        PNG exposure in stops (default 0)\n"
     "      --tonemap CURVE         PNG tone curve: clamp (default), reinhard or filmic\n"
     "      --exr-compression C     OpenEXR compression: zip (default), zips or none\n"
     "      --progress              progress on stderr even when it is not a terminal (then one line\n"
     "                              every 2 seconds); default: a bar when stderr is a terminal\n"
     "      --quiet                 no progress, no scene warnings\n"
     "      --shard I/N             render only the I-th of N disjoint parts (1 <= I <= N) into\n"
     "                              -o PART.pdsp; pds merge makes the image, the single run's bit for bit\n"
     "      --checkpoint SECONDS    write OUT.pdsp and OUT every SECONDS (pt, pds, splat, gi; others: at the end)\n"
     "      --resume PART.pdsp      continue a stopped render or shard (scene, options and output from\n"
     "                              the file; -o, --threads, --exposure, --progress, --quiet may be given,\n"
     "                              and the render's own -D and --obj-material: they are not in the file)\n"
     "      The first Ctrl-C (SIGINT) or SIGTERM stops after the batch under way and writes OUT and\n"
     "      OUT.pdsp (exit status 130); a second one aborts.\n",
     "      --caustics NAME         gi: the caustic method, pds (default), pm, pdm, splat, ppm or spm,\n"
     "                              with its own options above\n"
     "      --global-photons N      gi: photons emitted for the global photon map (default pixels x\n"
     "                              samples / 16, 4096..1M; spm's full image: 100000)\n"
     "      --global-k K            gi: nearest photons (streams: leaders) per global radiance estimate\n"
     "                              (default 20; streams and spm: 50)\n"
     "      --gather N              gi: final-gather rays per eye sample (default 1)\n"
     "      --gather-mix F          gi: share of cosine-sampled gather directions, the rest following\n"
     "                              the global map's photons (default 1 = cosine sampling)\n"
     "      --shadow-photons        gi: shadow photons decide where shadow rays are needed\n"
     "      --no-shadow-photons     gi: a shadow ray for every light sample (the default)\n"
     "      --global-map M          gi: photons (default) or streams (streamed photon mapping)\n"
     "      --stream-radius R       gi streams, spm: rs (default: the scene's largest side / 16)\n"
     "                              spm's full image is gi's with --global-map streams --caustics spm:\n"
     "                              --global-photons to --no-shadow-photons and --stream-radius are\n"
     "                              spm's too (not with --caustics-only: rs never reaches a caustic\n"
     "                              stream), and --streams\n"
     "                              is also the global map's nfs (default global-photons / (nfa + 1))\n"
     "      --method isc            image-space caustics (Wyman and Davis 2006): interactive, approximate;\n"
     "                              --photons N: a light-space buffer of side sqrt(N) per light; --time:\n"
     "                              frames, each with its buffer offset anew, averaged until it is spent\n"
     "      --gather G              isc: points, quads, eye (default) or light (gi: a number)\n"
     "      --light-res N           isc: N x N photons per light in its light-space buffer (default: --photons)\n"
     "      --history N             isc: temporal filter, the last N frames averaged (default 4; 1 = off)\n"
     "      --frames N              isc: an animation of N frames, OUT.0000.png, OUT.0001.png, ...\n"
     "      --orbit WHAT            --frames: light (default), camera or none turns about the look-at point\n"
     "      --orbit-step DEG        --frames: degrees per frame, counter-clockwise from above (default 2)\n"
     "      --static-lighting       --frames: keep each light's photons of frame 0 (orbit camera or none)\n",
     1},
    {"merge", "merge -o OUT.png|OUT.pfm|OUT.exr [--partial] PART.pdsp...",
     "the image of the shards of one render (pds render --shard I/N)",
     "      -o, --output FILE       the image, .png, .pfm or .exr\n"
     "      --partial               merge a subset (missing or unfinished shards), and say what fraction\n"
     "      --exposure STOPS        PNG exposure in stops (default 0)\n"
     "      --tonemap CURVE         PNG tone curve: clamp (default), reinhard or filmic\n"
     "      --exr-compression C     OpenEXR compression: zip (default), zips or none\n"
     "      Parts of another scene, other options, another pds version or a shard given twice are\n"
     "      refused.\n",
     "", "", 0},
    {"sweep", "sweep SCENE --param NAME --values A,B,... --ref REF.pfm [options]",
     "render once per value of one parameter and compare each with REF",
     "      --method NAME           the method swept (default pds)\n"
     "      --param NAME            smoothing, min-aspect, k, radius, alpha, photons, spp, max-photons,\n"
     "                              passes, max-radius, streams, stream-photons, stream-radius, ...\n"
     "      --values A,B,...        the values, comma-separated\n"
     "      --ref REF.pfm           the reference (PFM or OpenEXR, the renders' resolution; a warning\n"
     "                              if its kind, full or caustics-only, is not the renders')\n"
     "      --mask MASK.pfm         RMSE and SSIM over the pixels MASK holds (first channel > 0)\n"
     "      -o DIR                  output folder (default sweep-SCENE-METHOD): sweep.csv, sweep.svg\n"
     "                              (RMSE and SSIM against the parameter), one PNG per value;\n"
     "                              each finished render is kept at once in DIR/entries\n"
     "      --resume                load the renders kept in DIR/entries (an interrupted sweep) and\n"
     "                              render only the others\n"
     "      and any render option, e.g. --photons N, --res WxH, --caustics-only\n",
     "", "", 1},
    {"race", "race SCENE --ref REF.pfm (--time T | --photons N | --budgets LIST) --methods LIST [options]",
     "every method on the same budget, side by side against REF",
     "      --methods LIST          e.g. pds,pm:k=50,pdm,splat:radius=0.05,ppm; options for one\n"
     "                              method follow it as :NAME=VALUE (k, kernel, radius, spp, ...)\n"
     "      --time T, --photons N   the budget of every method (ppm: N photons over all its passes);\n"
     "                              a time missed by more than 25% is flagged (stderr, race.csv, page)\n"
     "      --budgets A,B,...       several budgets (seconds; photons with --budget-kind photons):\n"
     "                              every method on each, and convergence.svg (error against time, log-log)\n"
     "      --tune                  choose each method's main parameter per budget by the lowest RMSE on a\n"
     "                              small grid, rendered with seed+1 (tune.csv); values given are kept\n"
     "      --diff-scale MODE       difference images: shared (one scale, default), each, or a number\n"
     "      --roi X,Y,W,H           region to crop (default: the 64x64 window of REF with the\n"
     "                              largest luminance variance)\n"
     "      --mask MASK.pfm         RMSE and SSIM (and --tune's choices) over the pixels MASK holds\n"
     "                              (first channel > 0), e.g. those a light-traced REF holds whole\n"
     "      -o DIR                  output folder (default race-SCENE): index.html, race.csv, images;\n"
     "                              each finished entry is kept at once in DIR/entries\n"
     "      --resume                load the entries kept in DIR/entries (an interrupted race) and\n"
     "                              render only the others\n"
     "      and any render option; it applies to every method it concerns\n",
     "", "", 1},
    {"compare", "compare A.pfm REF.pfm [--mask MASK.pfm]",
     "RMSE and SSIM of A against the reference REF (PFM or OpenEXR; a warning if their kinds differ); with\n"
     "  --mask, over the pixels MASK holds (first channel > 0), e.g. those a light-traced reference holds\n"
     "  whole (tests/ref_light --complete)", "", "", "", 0},
    {"pixel", "pixel IMAGE.pfm X Y [R]", "mean value of the pixels within R (default 0) of pixel X,Y (PFM or OpenEXR)", "", "", "", 0},
    {"trace-photon", "trace-photon SCENE --photon I [options]",
     "one caustic photon's path with its differentials beside finite differences",
     "      --photon I              the photon's number (0 = the first the renderer emits)\n"
     "      --photons N             N of the paper's eqs. 5-6 (default 100000)\n"
     "      --smoothing S           s of eqs. 5-6 (default 12)\n"
     "      --seed N                random seed (default 0)\n"
     "      --max-depth N           most specular bounces (default 16)\n"
     "      at every vertex: position x, direction omega, Du x, Dv x (positional; after the first\n"
     "      bounce Du x + Dtheta x and Dv x + Dphi x, eq. 7), Dtheta omega, Dphi omega, each beside\n"
     "      the central difference of neighbouring photons traced by the renderer, and the\n"
     "      footprint's semi-axes and area (eq. 4)\n",
     "", "", 0},
    {"info", "info FILE [-D NAME=VALUE] [--obj-material M]", "what a scene or OBJ file holds, and its warnings",
     "      -D NAME=VALUE, --obj-material M   as for render: the scene as render would load it\n", "", "", 0},
    {"bench", "bench WHAT [ARGS]", "micro-benchmarks (figures, never pass/fail):",
     "      rays MESH [N]           BVH build and ray throughput, one thread (N rays, default 1000000)\n"
     "      pt [SCENE]              path-traced samples per second, 1 thread and all threads\n"
     "      photons [SCENE]         PDS caustic photons per second, 1 thread and all threads\n"
     "      pass [--photons N] [SCENE...]  PDS's photon pass against pm's at N photons (default\n"
     "                              400k), 1 thread\n"
     "      memory [SCENE]          PDS working memory at 1e5 and at 1e7 photons\n"
     "      filter                  eq. 12 filter matrices per second against a general 3x3 inverse\n"
     "      kdtree                  eye-path map build, range and nearest-neighbour queries per second\n"
     "      isc [SCENE]             image-space caustics: frames per second per gather at 512x512 with\n"
     "                              512^2, 1024^2, 2048^2 photons, dynamic and static lighting, beside\n"
     "                              the paper's and PDS's times\n",
     "", "", 0},
    {"help", "help [COMMAND]", "this text, or one command's (as pds COMMAND --help)", "", "", "", 0},
};
#define N_COMMANDS (sizeof help_table / sizeof help_table[0])

static const char option_syntax_help[] =
    "      -h, --help              this text\n"
    "      an option's value follows it or is joined with '=': --photons 2M, --photons=2M;\n"
    "      counts (N) may be written 250000, 2.5e5 or 250k (k = 1e3, M = 1e6, G = 1e9)\n";

static const command_help *command_help_lookup(const char *name)
{
    size_t i;
    for (i = 0; i < N_COMMANDS; i++)
        if (!strcmp(help_table[i].name, name)) return &help_table[i];
    return NULL;
}

/* `pds --help`: every command with its options. */
static void print_overview(FILE *f)
{
    size_t i;
    fputs("usage: pds COMMAND [ARGS]     (pds COMMAND --help: one command's options)\n\ncommands:\n", f);
    for (i = 0; i < N_COMMANDS; i++) {
        const command_help *h = &help_table[i];
        if (strlen(h->synopsis) <= 26) fprintf(f, "  %-26s  %s\n%s%s%s", h->synopsis, h->summary, h->details, h->more, h->rest);
        else fprintf(f, "  %s\n%30s%s\n%s%s%s", h->synopsis, "", h->summary, h->details, h->more, h->rest);
    }
    fputs("  --help, -h                  this text\n"
          "  --version                   the version\n"
          "\n"
          "render, sweep and race: an option's value follows it or is joined with '=' (--photons 2M,\n"
          "--photons=2M); counts (N) may be written 250000, 2.5e5 or 250k (k = 1e3, M = 1e6, G = 1e9).\n",
          f);
}

/* `pds COMMAND --help`. */
static void print_command_help(const command_help *h, FILE *f)
{
    fprintf(f, "usage: pds %s\n  %s\n%s%s%s", h->synopsis, h->summary, h->details, h->more, h->rest);
    if (h->takes_options) fputs(option_syntax_help, f);
    else fputs("      -h, --help              this text\n", f);
}

/* Is a an argument asking for help? */
static int is_help(const char *a)
{
    return !strcmp(a, "--help") || !strcmp(a, "-h");
}

/* --------------------------------------------------------------- messages */

/* The command being run ("render"), for messages; NULL before one is known. */
static const char *current_command;
/* The whole command line (pds race writes it into its page). */
static int command_argc;
static char **command_argv;

/* "pds render: unknown option '--photon' (did you mean '--photons'?)" and a
   pointer to the help; status 2. */
static int usage_error(const char *fmt, ...) PRINTF_LIKE(1, 2);
static int usage_error(const char *fmt, ...)
{
    const char *cmd = current_command ? current_command : "";
    const char *space = current_command ? " " : "";
    va_list ap;
    fprintf(stderr, "pds%s%s: ", space, cmd);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fprintf(stderr, "\n(run 'pds%s%s --help' for usage)\n", space, cmd);
    return EXIT_USAGE;
}

/* A failure that is not a usage error ("FILE: what is wrong"): status 1. */
static int fail(const char *fmt, ...) PRINTF_LIKE(1, 2);
static int fail(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    return 1;
}

/* ------------------------------------------------------------ suggestions */

/* Edit distance between a and b: inserting, deleting or replacing a
   character, or swapping two neighbours, costs 1 each (the "optimal string
   alignment" distance; Damerau 1964 counted the same four typing errors).
   Words longer than 63 characters count as far from everything. */
static int edit_distance(const char *a, const char *b)
{
    int d[64][64], i, j;
    int n = (int)strlen(a), m = (int)strlen(b);
    if (n > 63 || m > 63) return 99;
    for (i = 0; i <= n; i++) d[i][0] = i;
    for (j = 0; j <= m; j++) d[0][j] = j;
    for (i = 1; i <= n; i++)
        for (j = 1; j <= m; j++) {
            int best = d[i - 1][j - 1] + (a[i - 1] != b[j - 1]);
            if (d[i - 1][j] + 1 < best) best = d[i - 1][j] + 1;
            if (d[i][j - 1] + 1 < best) best = d[i][j - 1] + 1;
            if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] && d[i - 2][j - 2] + 1 < best)
                best = d[i - 2][j - 2] + 1;
            d[i][j] = best;
        }
    return d[n][m];
}

/* The known names closest to a word the tool did not know: feed every
   candidate to suggest_consider(), then suggest_text() says "did you mean
   ...?". A name is close when it is at most 2 edits away (and fewer edits
   than the word has letters, so "-x" suggests nothing) or when the word
   begins it; more than three equally close names suggest nothing. */
typedef struct suggestion {
    const char *word;
    const char *names[3];
    int count, distance;
} suggestion;

static void suggest_init(suggestion *s, const char *word)
{
    s->word = word;
    s->count = 0;
    s->distance = 3;
}

static void suggest_consider(suggestion *s, const char *name)
{
    size_t len = strlen(s->word), letters = len - strspn(s->word, "-");
    int d = edit_distance(s->word, name);
    if (letters >= 2 && len < strlen(name) && !strncmp(name, s->word, len) && d > 1) d = 1;
    if (d == 0 || d > 2 || d >= (int)letters || d > s->distance) return;
    if (d < s->distance) {
        s->distance = d;
        s->count = 0;
    }
    if (s->count < 3) s->names[s->count] = name;
    s->count++;
}

/* " (did you mean 'a', 'b' or 'c'?)", or "" when nothing is close. */
static const char *suggest_text(const suggestion *s, char *buf, size_t n)
{
    int i;
    buf[0] = '\0';
    if (s->count < 1 || s->count > 3) return buf;
    snprintf(buf, n, " (did you mean ");
    for (i = 0; i < s->count; i++) {
        size_t used = strlen(buf);
        snprintf(buf + used, n - used, "%s'%s'", i == 0 ? "" : i == s->count - 1 ? " or " : ", ", s->names[i]);
    }
    if (strlen(buf) + 3 < n) strcat(buf, "?)");
    return buf;
}

/* ---------------------------------------------------------------- signals */
/* >>signals  Ctrl-C (SIGINT), kill (SIGTERM) and a closed terminal (SIGHUP)
   must not leave a half-written output file. The library writes every file
   to "PATH.tmp-PID" and renames it (pds.h), and so do write_text() here;
   before writing a file the tool arms a slot with that temporary name, and
   disarms it once the file is in place. The handler may only make
   async-signal-safe calls (POSIX.1-2008, 2.4.3): it unlinks the armed
   names, erases the progress bar with write(), restores the default action
   and raises the signal again, so the process dies by it and the shell
   sees "killed by SIGINT", not an exit status.

   The handler may interrupt the tool anywhere, even halfway through arming
   a slot: the names and flags are volatile, a slot's name is complete
   before its flag says so, and a name is never changed while armed. */

/* render writes at most the image and two files per debug view (the paths one) */
#define TEMP_SLOTS (1 + 2 * PDS_DEBUG_VIEWS)

static volatile char temp_name[TEMP_SLOTS][PATH_MAX_LEN + 32];
static volatile sig_atomic_t temp_armed[TEMP_SLOTS];
static volatile sig_atomic_t bar_on_screen; /* a progress bar is drawn on the terminal */
/* render: the first SIGINT or SIGTERM asks the render to stop after the
   batch under way (the progress callback passes it on), and render then
   writes the image and its partial file; a second one ends the process as
   any signal does. */
static volatile sig_atomic_t stop_gracefully; /* a render that can stop is running */
static volatile sig_atomic_t stop_requested;  /* the first signal came */

/* The temporary name the library and write_text() use for path. 0, or -1
   when it does not fit. */
static int temp_path(const char *path, char *out, size_t n)
{
    int len = snprintf(out, n, "%s.tmp-%ld", path, (long)getpid());
    return len < 0 || (size_t)len >= n ? -1 : 0;
}

/* From now on a signal removes path's temporary file. 0, or 1 after printing
   why the name does not fit. */
static int temp_arm(int slot, const char *path)
{
    char tmp[PATH_MAX_LEN + 32];
    size_t i;
    if (temp_path(path, tmp, sizeof tmp)) return fail("%s: path too long", path);
    temp_armed[slot] = 0;
    for (i = 0; tmp[i]; i++) temp_name[slot][i] = tmp[i];
    temp_name[slot][i] = '\0';
    temp_armed[slot] = 1;
    return 0;
}

static void temp_disarm(int slot)
{
    temp_armed[slot] = 0;
}

static void on_fatal_signal(int sig)
{
    int saved = errno, k;
    if (stop_gracefully && !stop_requested && (sig == SIGINT || sig == SIGTERM)) {
        static const char note[] = "\npds render: stopping after the batch under way (a second signal aborts)\n";
        ssize_t w = write(STDERR_FILENO, note, sizeof note - 1);
        (void)w;
        bar_on_screen = 0; /* the note ended the bar's line */
        stop_requested = 1;
#ifdef _WIN32
        signal(sig, on_fatal_signal); /* Windows resets a caught signal to its default: the second one must abort */
#endif
        errno = saved;
        return;
    }
    for (k = 0; k < TEMP_SLOTS; k++) {
        char name[PATH_MAX_LEN + 32];
        size_t i;
        if (!temp_armed[k]) continue;
        for (i = 0; i + 1 < sizeof name && temp_name[k][i]; i++) name[i] = temp_name[k][i];
        name[i] = '\0';
        unlink(name); /* fails harmlessly when the file is not there (yet or any more) */
    }
    if (bar_on_screen) {
        static const char erase[] = "\r\033[K"; /* carriage return, erase to the end of the line */
        ssize_t w = write(STDERR_FILENO, erase, sizeof erase - 1);
        (void)w;
    }
    signal(sig, SIG_DFL);
    raise(sig); /* blocked until the handler returns, then the default action: die */
    errno = saved;
}

/* Catch the signals that end a run, except those ignored when pds started
   (nohup, background jobs of a non-interactive shell): they stay ignored.
   Windows has neither sigaction nor SIGHUP: Ctrl-C (SIGINT) and SIGTERM by
   signal(). */
#ifdef _WIN32
static void catch_fatal_signals(void)
{
    signal(SIGINT, on_fatal_signal);
    signal(SIGTERM, on_fatal_signal);
}
#else
static void catch_fatal_signals(void)
{
    static const int sigs[] = {SIGINT, SIGTERM, SIGHUP};
    size_t i;
    for (i = 0; i < sizeof sigs / sizeof sigs[0]; i++) {
        struct sigaction sa, old;
        if (sigaction(sigs[i], NULL, &old) != 0 || old.sa_handler == SIG_IGN) continue;
        memset(&sa, 0, sizeof sa);
        sa.sa_handler = on_fatal_signal;
        sigemptyset(&sa.sa_mask);
        sigaddset(&sa.sa_mask, SIGINT); /* one handler at a time */
        sigaddset(&sa.sa_mask, SIGTERM);
        sigaddset(&sa.sa_mask, SIGHUP);
        sigaction(sigs[i], &sa, NULL);
    }
}
#endif

/* ---------------------------------------------------------------- parsing */

static int has_ext(const char *path, const char *ext)
{
    size_t n = strlen(path), m = strlen(ext), i;
    if (n < m) return 0;
    for (i = 0; i < m; i++) {
        char a = path[n - m + i], b = ext[i];
        if (a >= 'A' && a <= 'Z') a = (char)(a - 'A' + 'a');
        if (a != b) return 0;
    }
    return 1;
}

/* Parse a whole number in [lo, hi]; -1 on error. */
static int parse_int(const char *s, long lo, long hi, long *out)
{
    char *end;
    long v;
    errno = 0;
    v = strtol(s, &end, 10);
    if (end == s || *end || errno || v < lo || v > hi) return -1;
    *out = v;
    return 0;
}

/* Parse a count in [lo, hi]: a whole number written plainly (250000), with
   an exponent (2.5e5) or a suffix k, M or G (250k; k = 1e3, M = 1e6,
   G = 1e9). After scaling it must be whole: 1.5k is 1500, 1.5 is an error.
   0, or -1 on error. */
static int parse_count(const char *s, long lo, long hi, long *out)
{
    char num[64], *end;
    size_t n = strlen(s), i;
    double v, scale = 1.0;
    if (parse_int(s, lo, hi, out) == 0) return 0; /* the plain case, exact to the last digit */
    if (n == 0 || n >= sizeof num) return -1;
    memcpy(num, s, n + 1);
    switch (num[n - 1]) {
    case 'k': case 'K': scale = 1e3; break;
    case 'M': scale = 1e6; break;
    case 'G': scale = 1e9; break;
    default: break;
    }
    if (scale > 1.0) num[--n] = '\0';
    /* digits, a point and an exponent only: no sign in front, no hex, inf or nan */
    for (i = 0; i < n; i++) {
        char ch = num[i];
        int exponent_sign = (ch == '+' || ch == '-') && i > 0 && (num[i - 1] == 'e' || num[i - 1] == 'E');
        if (!(ch >= '0' && ch <= '9') && ch != '.' && ch != 'e' && ch != 'E' && !exponent_sign) return -1;
    }
    errno = 0;
    v = strtod(num, &end);
    if (n == 0 || end != num + n || errno) return -1;
    v *= scale;
    /* (double)LONG_MAX rounds up to 2^63, which no long holds */
    if (!(v >= (double)lo && v <= (double)hi) || v != floor(v) || v >= 9.2e18) return -1;
    *out = (long)v;
    return 0;
}

static int parse_double(const char *s, double *out)
{
    char *end;
    errno = 0;
    *out = strtod(s, &end);
    if (end == s || *end || errno || *out != *out || *out > 1e300 || *out < -1e300) return -1;
    return 0;
}

/* How scenes are loaded (-D NAME=VALUE, --obj-material): set while the
   command line is read, used by every load_any of the command. */
#define MAX_DEFINES 256
static pds_define load_defines[MAX_DEFINES];
static char load_define_text[MAX_DEFINES][64 + 512]; /* "NAME\0VALUE" */
static pds_load_options load_cfg = {load_defines, 0, 1, PDS_OBJ_MATERIAL_AUTO};

static pds_status load_any(const char *path, pds_scene **scene, pds_error *err)
{
    return pds_scene_load_ex(path, &load_cfg, scene, err);
}

/* -D NAME=VALUE (also -DNAME=VALUE, --define NAME=VALUE): a value for the
   scene's variable NAME in place of its `define` default. */
static int add_define(const char *shown, const char *v)
{
    const char *eq = strchr(v, '=');
    size_t i, n = eq ? (size_t)(eq - v) : 0;
    int ok = eq && n > 0 && n < 64 && ((v[0] >= 'a' && v[0] <= 'z') || (v[0] >= 'A' && v[0] <= 'Z') || v[0] == '_');
    for (i = 1; ok && i < n; i++)
        ok = (v[i] >= 'a' && v[i] <= 'z') || (v[i] >= 'A' && v[i] <= 'Z') || (v[i] >= '0' && v[i] <= '9') || v[i] == '_';
    if (!ok) return usage_error("%s needs NAME=VALUE (NAME: a letter or '_', then letters, digits or '_'), got '%s'", shown, v);
    if (eq[1] == '\0') return usage_error("%s %.*s= needs a value after '='", shown, (int)n, v);
    if (strlen(eq + 1) > 511) return usage_error("%s %.*s: the value is longer than 511 characters", shown, (int)n, v);
    if (load_cfg.define_count >= MAX_DEFINES) return usage_error("more than %d -D options", MAX_DEFINES);
    {
        char *t = load_define_text[load_cfg.define_count];
        memcpy(t, v, n);
        t[n] = '\0';
        strcpy(t + n + 1, eq + 1);
        load_defines[load_cfg.define_count].name = t;
        load_defines[load_cfg.define_count].value = t + n + 1;
        load_cfg.define_count++;
    }
    return 0;
}

static const char *const obj_material_names[] = {"auto", "diffuse", "glass", "metal"}; /* by pds_obj_material */

/* The scene's file name without folder and extension ("scenes/ring.scene"
   -> "ring"), cut to fit n bytes. */
static void scene_stem(const char *scene, char *out, size_t n)
{
    const char *base = strrchr(scene, '/');
    const char *dot;
    size_t len;
    base = base ? base + 1 : scene;
    dot = strrchr(base, '.');
    len = dot && dot != base ? (size_t)(dot - base) : strlen(base);
    if (len > n - 1) len = n - 1;
    memcpy(out, base, len);
    out[len] = '\0';
}

/* The scene's file name without folder and extension, + ".png". */
static void default_output(const char *scene, char *out, size_t n)
{
    scene_stem(scene, out, n - 4);
    strcat(out, ".png");
}

/* --------------------------------------------------------------- progress */

/* Progress on stderr. On a terminal one line, redrawn in place at most ten
   times a second,

       [########................]  33%  elapsed 4.1 s  ETA 8.2 s

   ("\r" goes back to its start, "\033[K" erases what a longer line left
   behind), erased when the render ends and by the signal handler. Anywhere
   else (--progress into a file or a pipe) a line every 2 seconds and a
   last one at 100%, each ending in a newline.

   Elapsed is the tool's own clock since the command started (the library's
   restarts between the eye and the photon pass). Under --time the fraction
   and the ETA come from that clock and the budget; otherwise the fraction
   is the library's and the ETA the rate since it began to move, shown once
   2% are done and a second has passed, when the rate has begun to mean
   something. */
#define BAR_WIDTH 24

typedef struct progress_state {
    int tty;                   /* stderr is a terminal */
    double t_command;          /* when the command started */
    double t_render;           /* when the current render started */
    double budget_s;           /* its --time, 0 if none */
    const char *label;         /* "race pm-k50", or NULL */
    double t_moving, f_moving; /* the first report with a fraction above 0 (t < 0: none yet) */
    double t_drawn;            /* when the last line was drawn (< 0: none yet) */
    int show;                  /* draw it (else the callback only passes a stop on) */
    int phase;                 /* the pds_phase last reported */
    double checkpoint_s;       /* render --checkpoint: stop every this many seconds (0: never) */
    double t_checkpoint;       /* when the last checkpoint was written (or the render began) */
    int checkpoint_due;        /* the callback asked for a stop to write a checkpoint */
    int checkpoint_phase;      /* the phase whose work a checkpoint keeps (pds_phase), -1 none */
} progress_state;

static progress_state progress;

/* A render begins: label (or NULL) names it, budget_s is its --time. */
static void progress_begin(const char *label, double budget_s)
{
    progress.t_render = pds_time_now();
    progress.budget_s = budget_s;
    progress.label = label;
    progress.t_moving = progress.t_drawn = -1.0;
    progress.phase = 0;
}

/* One line: "[####....]  42%  elapsed 3.1 s  ETA 4.2 s" (eta < 0: none). */
static void progress_draw(progress_state *p, double fraction, double now, double eta)
{
    char bar[BAR_WIDTH + 1], line[256];
    int i, filled = (int)(fraction * BAR_WIDTH + 0.5);
    for (i = 0; i < BAR_WIDTH; i++) bar[i] = i < filled ? '#' : '.';
    bar[BAR_WIDTH] = '\0';
    static const char *const phases[] = {"eye", "photons", "gather"};
    snprintf(line, sizeof line, "%s%s%-7s [%s] %3d%%  elapsed %.1f s", p->label ? p->label : "", p->label ? " " : "",
             (unsigned)p->phase < 3 ? phases[p->phase] : "", bar, (int)(fraction * 100.0 + 0.5), now - p->t_command);
    if (eta >= 0.0) snprintf(line + strlen(line), sizeof line - strlen(line), "  ETA %.1f s", eta);
    if (p->tty) {
        bar_on_screen = 1; /* before drawing: a signal halfway through still erases it */
        fprintf(stderr, "\r%s\033[K", line);
    } else {
        fprintf(stderr, "%s\n", line);
    }
    fflush(stderr);
    p->t_drawn = now;
}

/* The pds_progress_fn: the library calls it from one thread only. It
   returns nonzero, asking the render to stop, after the first signal
   (>>signals) or when a checkpoint is due. */
static int show_progress(void *user, pds_phase phase, double fraction, double library_elapsed_s)
{
    progress_state *p = (progress_state *)user;
    double now = pds_time_now(), eta = -1.0;
    (void)library_elapsed_s;
    if (stop_requested) return 1;
    if (p->checkpoint_s > 0.0 && (int)phase == p->checkpoint_phase && now - p->t_checkpoint >= p->checkpoint_s) {
        p->checkpoint_due = 1;
        return 1;
    }
    if (!p->show) return 0;
    if ((int)phase != p->phase) {
        /* a new phase: its own fraction, its own rate */
        p->phase = (int)phase;
        p->t_moving = -1.0;
    }
    if (p->budget_s > 0.0) {
        /* under --time the clock is the measure (the library's fraction
           also covers calibration runs that go 0 to 1 in a moment) */
        fraction = (now - p->t_render) / p->budget_s;
        eta = p->budget_s - (now - p->t_render);
        if (eta < 0.0) eta = 0.0;
    }
    if (!(fraction > 0.0)) fraction = 0.0;
    if (fraction > 1.0) fraction = 1.0;
    if (fraction > 0.0 && p->t_moving < 0.0) {
        p->t_moving = now;
        p->f_moving = fraction;
    }
    if (p->t_drawn >= 0.0 && now - p->t_drawn < (p->tty ? 0.1 : 2.0) && !(p->tty && fraction >= 1.0)) return 0;
    if (p->budget_s <= 0.0 && fraction < 1.0 && fraction >= 0.02 && p->t_moving >= 0.0 && now - p->t_moving >= 1.0 &&
        fraction > p->f_moving)
        eta = (now - p->t_moving) * (1.0 - fraction) / (fraction - p->f_moving);
    progress_draw(p, fraction, now, eta);
    return 0;
}

/* A render ended: erase the bar from the terminal; elsewhere, if it
   finished, write the last line, at 100%. */
static void progress_end(int finished)
{
    if (!progress.tty) {
        if (finished) progress_draw(&progress, 1.0, pds_time_now(), -1.0);
        return;
    }
    if (!bar_on_screen) return;
    fputs("\r\033[K", stderr);
    fflush(stderr);
    bar_on_screen = 0;
}

/* ------------------------------------------------------------------ methods */

typedef struct method_info {
    const char *name; /* as pds_method_name() returns it */
    pds_method method;
} method_info;

static const method_info method_table[] = {
    {"pds", PDS_METHOD_PDS}, {"pt", PDS_METHOD_PT},   {"preview", PDS_METHOD_PREVIEW}, {"pm", PDS_METHOD_PM},
    {"pdm", PDS_METHOD_PDM}, {"splat", PDS_METHOD_SPLAT}, {"ppm", PDS_METHOD_PPM}, {"gi", PDS_METHOD_GI},
    {"spm", PDS_METHOD_SPM},
    {"isc", PDS_METHOD_ISC},
};
#define N_METHODS (sizeof method_table / sizeof method_table[0])

#define MBIT(m) (1u << (unsigned)(m))
#define M_PHOTON                                                                                                     \
    (MBIT(PDS_METHOD_PDS) | MBIT(PDS_METHOD_PM) | MBIT(PDS_METHOD_PDM) | MBIT(PDS_METHOD_SPLAT) |                    \
     MBIT(PDS_METHOD_PPM) | MBIT(PDS_METHOD_SPM))
#define M_GI MBIT(PDS_METHOD_GI)
#define M_ALL (M_PHOTON | M_GI | MBIT(PDS_METHOD_PT) | MBIT(PDS_METHOD_PREVIEW) | MBIT(PDS_METHOD_ISC))
/* methods that keep a photon map, whose size stats.map_bytes reports */
#define M_MAP (MBIT(PDS_METHOD_PM) | MBIT(PDS_METHOD_PDM) | MBIT(PDS_METHOD_PPM) | MBIT(PDS_METHOD_SPM))

static const char *method_name(pds_method m)
{
    size_t i;
    for (i = 0; i < N_METHODS; i++)
        if (method_table[i].method == m) return method_table[i].name;
    return "?";
}

static int method_lookup(const char *name, pds_method *out)
{
    size_t i;
    for (i = 0; i < N_METHODS; i++)
        if (!strcmp(method_table[i].name, name)) {
            *out = method_table[i].method;
            return 0;
        }
    return -1;
}

static int is_photon_method(pds_method m)
{
    return (MBIT(m) & M_PHOTON) != 0;
}

/* The names of the methods in mask, in table order: "pm", "splat and ppm";
   with and_word NULL, all joined by ", ". */
static void method_join(unsigned mask, const char *and_word, char *out, size_t n)
{
    size_t i, count = 0, done = 0;
    out[0] = '\0';
    for (i = 0; i < N_METHODS; i++)
        if (mask & MBIT(method_table[i].method)) count++;
    for (i = 0; i < N_METHODS; i++) {
        size_t len = strlen(out);
        if (!(mask & MBIT(method_table[i].method))) continue;
        done++;
        snprintf(out + len, n - len, "%s%s", done == 1 ? "" : (done == count && and_word) ? and_word : ", ",
                 method_table[i].name);
    }
}

static int unknown_method(const char *name)
{
    char list[128], hint[256];
    suggestion sug;
    size_t i;
    suggest_init(&sug, name);
    for (i = 0; i < N_METHODS; i++) suggest_consider(&sug, method_table[i].name);
    if (suggest_text(&sug, hint, sizeof hint)[0]) return usage_error("unknown method '%s'%s", name, hint);
    method_join(M_ALL, NULL, list, sizeof list);
    return usage_error("unknown method '%s' (this version has: %s)", name, list);
}

static const char *const kernel_names[] = {"cone", "gaussian", "none"}; /* by pds_kernel */

static const char *kernel_name(pds_kernel k)
{
    return (unsigned)k < 3 ? kernel_names[k] : "?";
}

/* ------------------------------------------------------------------ options */

/* Everything the options of render, sweep and race set. */
typedef struct run_cfg {
    pds_options opt;
    double exposure;     /* PNG exposure in stops */
    int tonemap;         /* PNG tone curve (pds_tonemap) */
    int exr_compression; /* OpenEXR compression (pds_exr_compression) */
    const char *output;  /* render: the image file, NULL for the default */
    int progress;        /* 1 on, 0 off, -1 when stderr is a terminal */
    int quiet;           /* --quiet: no progress, no scene warnings */
    pds_debug debug;     /* render --debug NAME: the views asked for */
    unsigned char given[128]; /* given[i]: option_table[i] was on the command line */
    int frames;          /* render --frames: an animation of this many frames (0: a still) */
} run_cfg;

typedef struct opt_spec opt_spec;
/* Set the option from its value v (NULL for flags); shown is the name the
   user wrote ("--k", "-o", "pm:k"), for messages. 0, or EXIT_USAGE after
   printing why. */
typedef int (*opt_setter)(const opt_spec *s, run_cfg *c, const char *shown, const char *v);

enum {
    F_VALUE = 1,      /* takes a value */
    F_PER_METHOD = 2, /* race: may be set for one method, pm:k=50 */
    F_SWEEP = 4,      /* sweep: may be the --param swept */
    F_LO_OPEN = 8,    /* numbers: the lower bound itself is not allowed */
    F_SPM_FULL = 16   /* spm: shapes its full image only (gi's part of it), not --caustics-only */
};
enum { C_RENDER = 1, C_SWEEP = 2, C_RACE = 4, C_ALL = 7 };

struct opt_spec {
    const char *name;  /* "--max-photons" */
    const char *alias; /* "-o", or NULL */
    const char *key;   /* its key in output lines and CSV files: "max_photons" */
    opt_setter set;
    size_t field;      /* generic setters: offset of the field in run_cfg */
    double lo, hi;     /* generic setters: the allowed range (whole numbers: hi < 0 = no limit) */
    const char *what;  /* what the value must be, for messages */
    unsigned methods;  /* methods whose image the option changes (MBIT) */
    unsigned commands; /* commands that take it (C_...) */
    unsigned flags;    /* F_... */
};

#define OPTF(member) (offsetof(run_cfg, opt) + offsetof(pds_options, member))
#define FIELD(c, s, type) ((type *)(void *)((char *)(c) + (s)->field))

/* Counts: 250000, 2.5e5, 250k (parse_count). */
static int set_whole(const opt_spec *s, const char *shown, const char *v, long *n)
{
    if (parse_count(v, (long)s->lo, s->hi < 0 ? LONG_MAX : (long)s->hi, n))
        return usage_error("%s needs %s, got '%s'", shown, s->what, v);
    return 0;
}

static int set_int(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    long n = 0;
    if (set_whole(s, shown, v, &n)) return EXIT_USAGE;
    *FIELD(c, s, int) = (int)n; /* the table keeps int ranges within int */
    return 0;
}

/* A flag (no value): the int field gets the table's lo, e.g.
   --no-shadow-photons sets shadow_photons to 0, --shadow-photons to 1,
   --spectral spectral to 1. */
static int set_flag(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    (void)shown;
    (void)v;
    *FIELD(c, s, int) = (int)s->lo;
    return 0;
}

static int set_long(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    long n = 0;
    if (set_whole(s, shown, v, &n)) return EXIT_USAGE;
    *FIELD(c, s, long) = n;
    return 0;
}

static int set_double(const opt_spec *s, run_cfg *c, const char *shown, const char *v);
static int option_given(const run_cfg *c, const char *name);

/* --smoothing, --min-aspect and --min-width are the paper's PDS's own
   parameters: giving one selects it (the fixed-s method), unless
   --progressive was given before. */
static int set_paper_double(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    int r = set_double(s, c, shown, v);
    if (!r && !option_given(c, "--progressive")) c->opt.progressive = 0;
    return r;
}

static int set_double(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    double d;
    if (parse_double(v, &d) || ((s->flags & F_LO_OPEN) ? !(d > s->lo) : !(d >= s->lo)) || d > s->hi)
        return usage_error("%s needs %s, got '%s'", shown, s->what, v);
    *FIELD(c, s, double) = d;
    return 0;
}

static int set_output(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    (void)s;
    (void)shown;
    c->output = v;
    return 0;
}

static int set_method(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    (void)s;
    (void)shown;
    return method_lookup(v, &c->opt.method) ? unknown_method(v) : 0;
}

/* --caustics: gi's caustic method, one of the photon methods. */
static int set_caustics(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    pds_method m;
    (void)s;
    if (method_lookup(v, &m)) return unknown_method(v);
    if (!is_photon_method(m)) return usage_error("%s takes pds, pm, pdm, splat, ppm or spm, got '%s'", shown, v);
    c->opt.caustics = m;
    return 0;
}

static int set_kernel(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    char hint[256];
    suggestion sug;
    int k;
    (void)s;
    suggest_init(&sug, v);
    for (k = 0; k < 3; k++) {
        if (!strcmp(v, kernel_names[k])) {
            c->opt.kernel = (pds_kernel)k;
            return 0;
        }
        suggest_consider(&sug, kernel_names[k]);
    }
    return usage_error("%s knows cone, gaussian and none, got '%s'%s", shown, v, suggest_text(&sug, hint, sizeof hint));
}

static int set_res(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    long w, h;
    char buf[64], *x;
    (void)s;
    if (strlen(v) >= sizeof buf) return usage_error("%s needs WIDTHxHEIGHT, got '%s'", shown, v);
    strcpy(buf, v);
    x = strchr(buf, 'x');
    if (!x) return usage_error("%s needs WIDTHxHEIGHT, got '%s'", shown, v);
    *x = '\0';
    if (parse_int(buf, 1, PDS_MAX_RESOLUTION, &w) || parse_int(x + 1, 1, PDS_MAX_RESOLUTION, &h))
        return usage_error("%s needs WIDTHxHEIGHT with sides from 1 to 16384, got '%s'", shown, v);
    c->opt.width = (int)w;
    c->opt.height = (int)h;
    return 0;
}

static int set_seed(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    char *end;
    (void)s;
    errno = 0;
    c->opt.seed = strtoull(v, &end, 10);
    if (end == v || *end || errno || v[0] == '-')
        return usage_error("%s needs a non-negative whole number, got '%s'", shown, v);
    return 0;
}

/* --max-depth bounds eye paths and, when given, photon paths too. */
static int set_max_depth(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    long n = 0;
    if (set_whole(s, shown, v, &n)) return EXIT_USAGE;
    c->opt.max_depth = (int)n;
    c->opt.photon_depth = n > 0 ? (int)n : 1;
    return 0;
}

/* --debug NAME, NAME=N for ellipses (every N-th photon) and paths (the
   first N photons). */
static int set_debug(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    const char *eq = strchr(v, '=');
    size_t len = eq ? (size_t)(eq - v) : strlen(v);
    int k;
    (void)s;
    for (k = 0; k < PDS_DEBUG_VIEWS; k++) {
        const char *name = pds_debug_view_name((pds_debug_view)k);
        if (strlen(name) == len && !strncmp(v, name, len)) break;
    }
    if (k == PDS_DEBUG_VIEWS)
        return usage_error("%s knows footprint, landings, ellipses[=N], splats, eye, paths[=N] and scales, got '%s'",
                           shown, v);
    if (eq) {
        long n;
        if (k != PDS_DEBUG_ELLIPSES && k != PDS_DEBUG_PATHS)
            return usage_error("%s %.*s takes no number, got '%s'", shown, (int)len, v, v);
        if (parse_count(eq + 1, 1, 1000000, &n))
            return usage_error("%s %.*s=N needs a whole number from 1 to 1000000, got '%s'", shown, (int)len, v, eq + 1);
        if (k == PDS_DEBUG_ELLIPSES) c->debug.ellipse_every = n;
        else c->debug.path_photons = n;
    }
    c->debug.views |= 1u << k;
    return 0;
}

static int set_paths(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    pds_paths p = s->name[2] == 'n' ? PDS_PATHS_NO_CAUSTICS : PDS_PATHS_CAUSTICS_ONLY;
    (void)shown;
    (void)v;
    if (c->opt.paths != PDS_PATHS_ALL && c->opt.paths != p)
        return usage_error("%s", "--no-caustics and --caustics-only exclude each other");
    c->opt.paths = p;
    return 0;
}

/* --progressive, or in race's --methods pds:progressive=1 (or =0). */
static int set_progressive(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    (void)s;
    if (v && strcmp(v, "0") != 0 && strcmp(v, "1") != 0)
        return usage_error("%s takes 0 or 1, got '%s'", shown, v);
    c->opt.progressive = !v || v[0] == '1';
    return 0;
}


/* --progress and --quiet: the last one given wins. */
static int set_progress(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    (void)shown;
    (void)v;
    c->progress = s->name[2] == 'p';
    c->quiet = !c->progress;
    return 0;
}

#define M_PDS MBIT(PDS_METHOD_PDS)
#define M_PM MBIT(PDS_METHOD_PM)
#define M_PDM MBIT(PDS_METHOD_PDM)
#define M_SPLAT MBIT(PDS_METHOD_SPLAT)
#define M_PPM MBIT(PDS_METHOD_PPM)
#define M_SPM MBIT(PDS_METHOD_SPM)
#define M_ISC MBIT(PDS_METHOD_ISC)

static const char *const gather_names[] = {"points", "quads", "eye", "light"}; /* by pds_isc_gather */
static const char *const orbit_names[] = {"none", "light", "camera"};          /* by pds_orbit */

/* A value from a short list of names (--gather, --orbit). */
static int set_named(const char *shown, const char *v, const char *const *names, int n, int *out)
{
    char hint[256], list[128] = "";
    suggestion sug;
    int k;
    suggest_init(&sug, v);
    for (k = 0; k < n; k++) {
        if (!strcmp(v, names[k])) {
            *out = k;
            return 0;
        }
        suggest_consider(&sug, names[k]);
        snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s", k ? (k + 1 == n ? " or " : ", ") : "",
                 names[k]);
    }
    return usage_error("%s takes %s, got '%s'%s", shown, list, v, suggest_text(&sug, hint, sizeof hint));
}

/* --global-map photons|streams: the values of pds_global_map */
static const char *const global_map_names[] = {"photons", "streams"};

static int set_global_map(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    int k = 0, r = set_named(shown, v, global_map_names, 2, &k);
    (void)s;
    if (!r) c->opt.global_map = (pds_global_map)k;
    return r;
}

/* --gather: isc's gather by name, or gi's final-gather rays as a count. */
static int set_gather(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    int k = 0;
    if (v[0] >= '0' && v[0] <= '9') return set_int(s, c, shown, v);
    if (set_named(shown, v, gather_names, 4, &k)) return EXIT_USAGE;
    c->opt.isc_gather = (pds_isc_gather)k;
    return 0;
}

static int set_orbit(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    int k = 0, r = set_named(shown, v, orbit_names, 3, &k);
    (void)s;
    if (!r) c->opt.orbit = (pds_orbit)k;
    return r;
}

static int set_define(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    (void)s;
    (void)c;
    return add_define(shown, v);
}

static int set_obj_material(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    int k = 0, r = set_named(shown, v, obj_material_names, 4, &k);
    (void)s;
    (void)c;
    if (!r) load_cfg.obj_material = (pds_obj_material)k;
    return r;
}

static const char *const tonemap_names[] = {"clamp", "reinhard", "filmic"}; /* by pds_tonemap */
static const char *const exr_compression_names[] = {"none", "zips", "zip"};

static int set_tonemap(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    int k = 0, r = set_named(shown, v, tonemap_names, 3, &k);
    (void)s;
    if (!r) c->tonemap = k;
    return r;
}

/* --exr-compression none|zips|zip: the values of pds_exr_compression */
static int set_exr_compression(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    static const int codes[3] = {PDS_EXR_NONE, PDS_EXR_ZIPS, PDS_EXR_ZIP};
    int k = 0, r = set_named(shown, v, exr_compression_names, 3, &k);
    (void)s;
    if (!r) c->exr_compression = codes[k];
    return r;
}

static int set_frames(const opt_spec *s, run_cfg *c, const char *shown, const char *v)
{
    long n = 0;
    if (set_whole(s, shown, v, &n)) return EXIT_USAGE;
    c->frames = (int)n;
    return 0;
}

/* Every option of render, sweep and race. */
static const opt_spec option_table[] = {
    {"--output", "-o", "output", set_output, 0, 0, 0, "a file name", M_ALL, C_RENDER, F_VALUE},
    {"--method", NULL, "method", set_method, 0, 0, 0, "a method name", M_ALL, C_RENDER | C_SWEEP, F_VALUE},
    {"--photons", NULL, "photons", set_long, OPTF(photons), 0, -1, "a whole number of 0 or more", M_PHOTON | M_GI | M_ISC, C_ALL,
     F_VALUE | F_SWEEP},
    {"--smoothing", NULL, "smoothing", set_paper_double, OPTF(smoothing), 0, 1e6, "a positive number", M_PDS | M_PDM | M_GI, C_ALL,
     F_VALUE | F_LO_OPEN | F_SWEEP | F_PER_METHOD},
    {"--plane-tolerance", NULL, "plane_tolerance", set_double, OPTF(plane_tolerance), 0, 1e6, "a positive number",
     M_PDS | M_PDM | M_SPLAT | M_GI, C_ALL, F_VALUE | F_LO_OPEN | F_PER_METHOD},
    {"--min-aspect", NULL, "min_aspect", set_paper_double, OPTF(min_aspect), 0, 1, "a number from 0 to 1", M_PDS | M_PDM | M_GI,
     C_ALL, F_VALUE | F_SWEEP | F_PER_METHOD},
    {"--progressive", NULL, "progressive", set_progressive, 0, 0, 0, "", M_PDS | M_GI, C_ALL, F_PER_METHOD},
    {"--min-width", NULL, "min_width", set_paper_double, OPTF(min_width), 0, 1e6, "a number from 0 to 1e6", M_PDS | M_GI, C_ALL,
     F_VALUE | F_SWEEP | F_PER_METHOD},
    {"--pass-smoothing", NULL, "pass_smoothing", set_double, OPTF(pass_smoothing), 0, 1e6, "a positive number", M_PDS | M_GI,
     C_ALL, F_VALUE | F_LO_OPEN | F_SWEEP | F_PER_METHOD},
    {"--pass-min-aspect", NULL, "pass_min_aspect", set_double, OPTF(pass_min_aspect), 0, 1, "a number from 0 to 1",
     M_PDS | M_GI, C_ALL, F_VALUE | F_SWEEP | F_PER_METHOD},
    {"--pass-min-width", NULL, "pass_min_width", set_double, OPTF(pass_min_width), 0, 1e6, "a number from 0 to 1e6",
     M_PDS | M_GI, C_ALL, F_VALUE | F_SWEEP | F_PER_METHOD},
    {"--pass-photons", NULL, "pass_photons", set_long, OPTF(pass_photons), 1, 1e9, "a whole number from 1 to 1e9",
     M_PDS | M_GI, C_ALL, F_VALUE | F_SWEEP | F_PER_METHOD},
    {"--eye-rounds", NULL, "eye_rounds", set_int, OPTF(eye_rounds), 0, PDS_MAX_SPP, "a whole number from 0 to 65536",
     M_PDS, C_ALL, F_VALUE | F_SWEEP | F_PER_METHOD},
    {"--walls", NULL, "walls", set_flag, OPTF(walls), 1, 1, "", M_PDS | M_GI, C_ALL, F_PER_METHOD},
    {"--no-walls", NULL, "walls", set_flag, OPTF(walls), 0, 0, "", M_PDS | M_GI, C_ALL, F_PER_METHOD},
    {"--pass-select", NULL, "pass_select", set_flag, OPTF(pass_select), 1, 1, "", M_PDS, C_ALL, F_PER_METHOD},
    {"--no-pass-select", NULL, "pass_select", set_flag, OPTF(pass_select), 0, 0, "", M_PDS, C_ALL, F_PER_METHOD},
    {"--split-depth", NULL, "split_depth", set_int, OPTF(split_depth), 0, 8, "a whole number from 0 to 8", M_PDS | M_GI,
     C_ALL, F_VALUE | F_SWEEP | F_PER_METHOD},
    {"--split-angle", NULL, "split_angle", set_double, OPTF(split_angle), 0, 10, "an angle above 0 and at most 10 radians",
     M_PDS | M_GI, C_ALL, F_VALUE | F_LO_OPEN | F_SWEEP | F_PER_METHOD},
    {"--pass-alpha", NULL, "pass_alpha", set_double, OPTF(pass_alpha), 0, 1, "a number above 0 and at most 1", M_PDS | M_GI,
     C_ALL, F_VALUE | F_LO_OPEN | F_SWEEP | F_PER_METHOD},
    {"--debug", NULL, "debug", set_debug, 0, 0, 0, "a view name", M_PHOTON, C_RENDER, F_VALUE},
    {"--k", NULL, "k", set_int, OPTF(k), 1, 1000000, "a whole number from 1 to 1000000", M_PM | M_SPM | M_GI, C_ALL,
     F_VALUE | F_SWEEP | F_PER_METHOD},
    {"--kernel", NULL, "kernel", set_kernel, 0, 0, 0, "cone, gaussian or none", M_PM | M_GI, C_ALL, F_VALUE | F_PER_METHOD},
    {"--max-radius", NULL, "max_radius", set_double, OPTF(max_radius), 0, PDS_MAX_COORD,
     "a positive distance in scene units", M_PM | M_SPM | M_GI, C_ALL, F_VALUE | F_LO_OPEN | F_SWEEP | F_PER_METHOD},
    {"--streams", NULL, "streams", set_long, OPTF(streams), 0, -1, "a whole number of 0 or more", M_SPM, C_ALL,
     F_VALUE | F_SWEEP | F_PER_METHOD},
    {"--stream-photons", NULL, "stream_photons", set_int, OPTF(stream_photons), 0, 10000,
     "a whole number from 0 to 10000", M_SPM | M_GI, C_ALL, F_VALUE | F_SWEEP | F_PER_METHOD},
    {"--max-photons", NULL, "max_photons", set_long, OPTF(max_photons), 1, 100000000,
     "a whole number from 1 to 100000000", M_PDM | M_GI, C_ALL, F_VALUE | F_SWEEP | F_PER_METHOD},
    {"--radius", NULL, "radius", set_double, OPTF(radius), 0, PDS_MAX_COORD, "a positive distance in scene units",
     M_SPLAT | M_PPM | M_GI, C_ALL, F_VALUE | F_LO_OPEN | F_SWEEP | F_PER_METHOD},
    {"--alpha", NULL, "alpha", set_double, OPTF(alpha), 0, 1, "a number above 0 and at most 1", M_PPM | M_GI, C_ALL,
     F_VALUE | F_LO_OPEN | F_SWEEP | F_PER_METHOD},
    {"--passes", NULL, "passes", set_int, OPTF(passes), 1, 1000000, "a whole number from 1 to 1000000", M_PPM | M_GI, C_ALL,
     F_VALUE | F_SWEEP | F_PER_METHOD},
    {"--caustics", NULL, "caustics", set_caustics, 0, 0, 0, "a caustic method", M_GI, C_ALL, F_VALUE | F_PER_METHOD},
    {"--global-photons", NULL, "global_photons", set_long, OPTF(global_photons), 0, 1e9,
     "a whole number from 0 to 1e9", M_GI | M_SPM, C_ALL, F_VALUE | F_SWEEP | F_PER_METHOD | F_SPM_FULL},
    {"--global-k", NULL, "global_k", set_int, OPTF(global_k), 1, 1000, "a whole number from 1 to 1000", M_GI | M_SPM,
     C_ALL, F_VALUE | F_SWEEP | F_PER_METHOD | F_SPM_FULL},
    {"--gather", NULL, "gather", set_gather, OPTF(gather), 0, 4096,
     "points, quads, eye or light (isc), or a whole number from 0 to 4096 (gi, spm)", M_GI | M_SPM | M_ISC, C_ALL,
     F_VALUE | F_SWEEP | F_PER_METHOD | F_SPM_FULL},
    {"--gather-mix", NULL, "gather_mix", set_double, OPTF(gather_mix), 0, 1, "a number above 0 and at most 1",
     M_GI | M_SPM, C_ALL, F_VALUE | F_LO_OPEN | F_SWEEP | F_PER_METHOD | F_SPM_FULL},
    {"--shadow-photons", NULL, "shadow_photons", set_flag, OPTF(shadow_photons), 1, 1, "", M_GI | M_SPM, C_ALL,
     F_PER_METHOD | F_SPM_FULL},
    {"--no-shadow-photons", NULL, "shadow_photons", set_flag, OPTF(shadow_photons), 0, 0, "", M_GI | M_SPM, C_ALL,
     F_PER_METHOD | F_SPM_FULL},
    {"--global-map", NULL, "global_map", set_global_map, 0, 0, 0, "photons or streams", M_GI, C_ALL,
     F_VALUE | F_PER_METHOD},
    {"--stream-radius", NULL, "stream_radius", set_double, OPTF(stream_radius), 0, PDS_MAX_COORD,
     "a positive distance in scene units", M_GI | M_SPM, C_ALL,
     F_VALUE | F_LO_OPEN | F_SWEEP | F_PER_METHOD | F_SPM_FULL},
    {"--light-res", NULL, "light_res", set_int, OPTF(light_resolution), 1, PDS_MAX_RESOLUTION,
     "a whole number from 1 to 16384", M_ISC, C_ALL, F_VALUE | F_SWEEP | F_PER_METHOD},
    {"--history", NULL, "history", set_int, OPTF(history), 1, 64, "a whole number from 1 to 64", M_ISC, C_ALL,
     F_VALUE | F_SWEEP | F_PER_METHOD},
    {"--frames", NULL, "frames", set_frames, 0, 1, 1000000, "a whole number from 1 to 1000000", M_ISC, C_RENDER,
     F_VALUE},
    {"--orbit", NULL, "orbit", set_orbit, 0, 0, 0, "none, light or camera", M_ISC, C_RENDER, F_VALUE},
    {"--orbit-step", NULL, "orbit_step", set_double, OPTF(orbit_deg), -360, 360, "degrees from -360 to 360", M_ISC,
     C_RENDER, F_VALUE},
    {"--static-lighting", NULL, "static_lighting", set_flag, OPTF(static_lighting), 1, 1, "", M_ISC, C_RENDER, 0},
    {"--spp", NULL, "spp", set_int, OPTF(spp), 1, PDS_MAX_SPP, "a whole number from 1 to 65536", M_ALL & ~M_ISC, C_ALL,
     F_VALUE | F_SWEEP | F_PER_METHOD},
    {"--res", NULL, "res", set_res, 0, 0, 0, "WIDTHxHEIGHT", M_ALL, C_ALL, F_VALUE},
    {"--threads", NULL, "threads", set_int, OPTF(threads), 1, 256, "a whole number from 1 to 256", M_ALL, C_ALL,
     F_VALUE},
    {"--seed", NULL, "seed", set_seed, 0, 0, 0, "a non-negative whole number", M_ALL, C_ALL, F_VALUE | F_PER_METHOD},
    {"--max-depth", NULL, "max_depth", set_max_depth, 0, 0, 1000, "a whole number from 0 to 1000", M_ALL, C_ALL,
     F_VALUE | F_PER_METHOD},
    {"--diffuse-bounces", NULL, "diffuse_bounces", set_int, OPTF(diffuse_bounces), 0, 1000,
     "a whole number from 0 to 1000", (M_PHOTON & ~M_SPM) | MBIT(PDS_METHOD_PT) | MBIT(PDS_METHOD_PREVIEW), C_ALL,
     F_VALUE | F_PER_METHOD},
    {"--time", NULL, "time", set_double, OPTF(time_s), 0, 1e7, "a number of seconds above 0", M_ALL, C_ALL,
     F_VALUE | F_LO_OPEN},
    {"--no-caustics", NULL, "paths", set_paths, 0, 0, 0, "", M_ALL, C_ALL, 0},
    {"--caustics-only", NULL, "paths", set_paths, 0, 0, 0, "", M_ALL, C_ALL, 0},
    {"--spectral", NULL, "spectral", set_flag, OPTF(spectral), 1, 1, "", M_ALL, C_ALL, 0},
    {"--exposure", NULL, "exposure", set_double, offsetof(run_cfg, exposure), -64, 64,
     "a number of stops from -64 to 64", M_ALL, C_ALL, F_VALUE},
    {"--tonemap", NULL, "tonemap", set_tonemap, 0, 0, 0, "clamp, reinhard or filmic", M_ALL, C_ALL, F_VALUE},
    {"--exr-compression", NULL, "exr_compression", set_exr_compression, 0, 0, 0, "none, zips or zip", M_ALL,
     C_RENDER, F_VALUE},
    {"--progress", NULL, "progress", set_progress, 0, 0, 0, "", M_ALL, C_ALL, 0},
    {"--define", "-D", "define", set_define, 0, 0, 0, "NAME=VALUE", M_ALL, C_ALL, F_VALUE},
    {"--obj-material", NULL, "obj_material", set_obj_material, 0, 0, 0, "auto, diffuse, glass or metal", M_ALL, C_ALL,
     F_VALUE},
    {"--quiet", NULL, "progress", set_progress, 0, 0, 0, "", M_ALL, C_ALL, 0},
};
#define N_OPTIONS (sizeof option_table / sizeof option_table[0])
/* run_cfg.given has a flag per option */
typedef char option_table_fits_in_given[N_OPTIONS <= sizeof ((run_cfg *)0)->given ? 1 : -1];

static int option_index(const char *name)
{
    size_t i;
    for (i = 0; i < N_OPTIONS; i++)
        if (!strcmp(option_table[i].name, name) || (option_table[i].alias && !strcmp(option_table[i].alias, name)))
            return (int)i;
    return -1;
}

static int option_given(const run_cfg *c, const char *name)
{
    int i = option_index(name);
    return i >= 0 && c->given[i] != 0;
}

static void cfg_init(run_cfg *c)
{
    memset(c, 0, sizeof *c);
    pds_options_default(&c->opt);
    pds_debug_init(&c->debug);
    c->opt.method = PDS_METHOD_PDS;
    c->progress = -1;
    c->tonemap = PDS_TONEMAP_CLAMP;
    c->exr_compression = PDS_EXR_ZIP;
}

/* The length of an argument's option name: "--photons=5" -> 9, the
   length of "--photons"; the whole argument when it has no '=' or is not a
   long option. */
static size_t arg_name_length(const char *a)
{
    const char *eq = a[0] == '-' && a[1] == '-' ? strchr(a, '=') : NULL;
    return eq ? (size_t)(eq - a) : strlen(a);
}

/* Is argument a the option name, alone or as "name=VALUE"? */
static int arg_is(const char *a, const char *name)
{
    size_t n = arg_name_length(a);
    return n == strlen(name) && !strncmp(a, name, n);
}

/* The value of option argv[*i]: what follows its '=', or else the next
   argument (and *i moves on to it). 0, or EXIT_USAGE after saying that it
   is missing. */
static int option_value(int argc, char **argv, int *i, const char **v)
{
    const char *a = argv[*i];
    size_t n = arg_name_length(a);
    if (a[n] == '=') {
        *v = a + n + 1;
        return **v ? 0 : usage_error("%.*s needs a value", (int)n, a);
    }
    if (*i + 1 >= argc) return usage_error("%s needs a value", a);
    *v = argv[++*i];
    return 0;
}

/* "unknown option '--photon' (did you mean '--photons'?)". The names it may
   have meant: the table's options for command cmd, the command's own
   options (own: NULL-terminated, or NULL) and --help. EXIT_USAGE. */
static int unknown_option(const char *a, unsigned cmd, const char *const *own)
{
    char name[64], hint[256];
    suggestion sug;
    size_t i, n = arg_name_length(a);
    if (n >= sizeof name) n = sizeof name - 1;
    memcpy(name, a, n);
    name[n] = '\0';
    suggest_init(&sug, name);
    for (i = 0; i < N_OPTIONS; i++)
        if (option_table[i].commands & cmd) suggest_consider(&sug, option_table[i].name);
    for (i = 0; own && own[i]; i++) suggest_consider(&sug, own[i]);
    suggest_consider(&sug, "--help");
    return usage_error("unknown option '%s'%s", name, suggest_text(&sug, hint, sizeof hint));
}

/* argv[*i] as an option of the table for command cmd (C_RENDER, ...),
   "--name VALUE" or "--name=VALUE": 0 when taken (and *i moved past its
   value), -1 when it is not in the table, EXIT_USAGE after printing why it
   is wrong. */
static int parse_option(run_cfg *c, unsigned cmd, const char *cmd_name, int argc, char **argv, int *i)
{
    const char *a = argv[*i], *v = NULL;
    char name[64];
    size_t n = arg_name_length(a);
    const opt_spec *s;
    int idx, r;
    if (a[0] == '-' && a[1] == 'D' && a[2] != '\0') { /* -DNAME=VALUE, as compilers take it */
        idx = option_index("-D");
        c->given[idx] = 1;
        return add_define("-D", a + 2);
    }
    if (n >= sizeof name) return -1;
    memcpy(name, a, n);
    name[n] = '\0';
    idx = option_index(name);
    if (idx < 0) return -1;
    s = &option_table[idx];
    if (!(s->commands & cmd)) {
        if (cmd == C_RACE && !strcmp(s->name, "--method"))
            return usage_error("%s", "race takes a list of methods: --methods M1,M2,...");
        return usage_error("%s is not a %s option", name, cmd_name);
    }
    if (s->flags & F_VALUE) {
        if ((r = option_value(argc, argv, i, &v)) != 0) return r;
    } else if (a[n] == '=') {
        return usage_error("%s takes no value, got '%s'", name, a);
    }
    c->given[idx] = 1;
    return s->set(s, c, name, v);
}

/* The number an option of the table was set to in c (generic setters
   only: the options sweep may vary). */
static double option_number(const opt_spec *s, const run_cfg *c)
{
    if (s->set == set_int || s->set == set_gather) return *FIELD(c, s, int); /* gather: gi's count */
    if (s->set == set_long) return (double)*FIELD(c, s, long);
    return *FIELD(c, s, double);
}

/* Is option s one that does nothing for o because o is spm with
   --caustics-only? The options of gi's part of spm's full image (its
   global map of streams and final gather) do not reach the caustics. */
static int spm_caustics_idle(const opt_spec *s, const pds_options *o)
{
    return o->method == PDS_METHOD_SPM && o->paths == PDS_PATHS_CAUSTICS_ONLY && (s->flags & F_SPM_FULL);
}

/* Why, for spm_caustics_idle's options. */
static const char *spm_caustics_idle_why(const opt_spec *s)
{
    if (!strcmp(s->name, "--stream-radius"))
        return "rs spreads a stream's associated photons about its leader's diffuse hits, and a caustic stream loses "
               "them at its first specular hit";
    return "it shapes the global map and final gather of spm's full image; the caustics are spm's streams alone";
}

/* Options given that change nothing for the methods in mask get a note on
   stderr; not an error, since scripts hand one set of options to several
   methods. where: "with --method pt", "for any method raced". */
static void note_idle_options(const run_cfg *c, unsigned mask, const char *where)
{
    size_t i;
    for (i = 0; i < N_OPTIONS; i++) {
        char list[128];
        if (!c->given[i]) continue;
        if ((option_table[i].methods & mask) == M_SPM && c->opt.paths == PDS_PATHS_CAUSTICS_ONLY &&
            (option_table[i].flags & F_SPM_FULL)) {
            fprintf(stderr, "pds %s: note: %s has no effect %s and --caustics-only (%s)\n", current_command,
                    option_table[i].name, where, spm_caustics_idle_why(&option_table[i]));
            continue;
        }
        if (option_table[i].methods & mask) continue;
        method_join(option_table[i].methods, " and ", list, sizeof list);
        fprintf(stderr, "pds %s: note: %s has no effect %s (it is for %s)\n", current_command, option_table[i].name,
                where, list);
    }
}

static void cfg_apply_progress(run_cfg *c)
{
    progress.tty = isatty(fileno(stderr));
    if (c->progress < 0) c->progress = progress.tty;
    progress.show = c->progress;
    progress.checkpoint_phase = -1;
    /* always called: it passes a stop on (render) even when it draws nothing */
    c->opt.progress = show_progress;
    c->opt.progress_user = &progress;
}

/* The scene's load warnings on stderr, as `pds info` lists them, unless
   --quiet. */
static void print_scene_warnings(const pds_scene *scene, const run_cfg *c)
{
    pds_scene_info info;
    int i;
    if (c->quiet) return;
    pds_scene_get_info(scene, &info);
    for (i = 0; i < info.warnings; i++)
        fprintf(stderr, "pds %s: warning: %s\n", current_command, pds_scene_warning(scene, i));
}

/* A distance option for output: 0 means "chosen by the renderer". */
static const char *distance_text(double d, const char *zero, char *buf, size_t n)
{
    if (d == 0.0) return zero;
    snprintf(buf, n, "%g", d);
    return buf;
}

/* The options of the method that shape its image, as " key=value" pairs
   (none for pt and preview): what a reader needs to reproduce a result. */
static void format_params(const pds_options *o, char *buf, size_t n)
{
    char d[32];
    buf[0] = '\0';
    switch (o->method) {
    case PDS_METHOD_PDS:
        if (o->progressive)
            snprintf(buf, n, " progressive=1 pass_smoothing=%g pass_photons=%ld pass_alpha=%g pass_min_aspect=%g"
                     " pass_min_width=%g split_depth=%d split_angle=%g", o->pass_smoothing, o->pass_photons,
                     o->pass_alpha, o->pass_min_aspect, o->pass_min_width, o->split_depth, o->split_angle);
        if (o->progressive && !o->walls) snprintf(buf + strlen(buf), n - strlen(buf), " walls=0");
        if (o->progressive && !o->pass_select) snprintf(buf + strlen(buf), n - strlen(buf), " pass_select=0");
        if (o->progressive && o->eye_rounds)
            snprintf(buf + strlen(buf), n - strlen(buf), " eye_rounds=%d", o->eye_rounds);
        if (!o->progressive)
            snprintf(buf, n, " smoothing=%g", o->smoothing);
        break;
    case PDS_METHOD_PM:
        snprintf(buf, n, " k=%d kernel=%s max_radius=%s", o->k, kernel_name(o->kernel),
                 distance_text(o->max_radius, "none", d, sizeof d));
        break;
    case PDS_METHOD_PDM: snprintf(buf, n, " max_photons=%ld smoothing=%g", o->max_photons, o->smoothing); break;
    case PDS_METHOD_SPLAT: snprintf(buf, n, " radius=%s", distance_text(o->radius, "auto", d, sizeof d)); break;
    case PDS_METHOD_PPM:
        snprintf(buf, n, " radius=%s alpha=%g", distance_text(o->radius, "auto", d, sizeof d), o->alpha);
        break;
    case PDS_METHOD_SPM:
        snprintf(buf, n, " stream_photons=%d k=%d max_radius=%s", o->stream_photons, o->k,
                 distance_text(o->max_radius, "none", d, sizeof d));
        if (o->paths != PDS_PATHS_CAUSTICS_ONLY) {
            /* the full image's global map of streams and final gather; a
               stream count given is the global map's too */
            size_t used = strlen(buf);
            snprintf(buf + used, n - used, " stream_radius=%s global_photons=%ld global_k=%d gather=%d gather_mix=%g"
                     " shadow_photons=%d", distance_text(o->stream_radius, "auto", d, sizeof d),
                     o->streams > 0 ? o->streams * (o->stream_photons + 1L) : o->global_photons, o->global_k,
                     o->gather, o->gather_mix, o->shadow_photons);
        }
        break;
    case PDS_METHOD_ISC:
        snprintf(buf, n, " gather=%s history=%d%s", gather_names[o->isc_gather], o->history,
                 o->static_lighting ? " static_lighting=1" : "");
        break;
    default: break;
    }
    if (((o->method == PDS_METHOD_PDS && !o->progressive) || o->method == PDS_METHOD_PDM) && o->min_aspect > 0.0) {
        size_t used = strlen(buf);
        snprintf(buf + used, n - used, " min_aspect=%g", o->min_aspect);
    }
    if (o->method == PDS_METHOD_PDS && !o->progressive && o->min_width > 0.0) {
        size_t used = strlen(buf);
        snprintf(buf + used, n - used, " min_width=%g", o->min_width);
    }
}

static const char *paths_name(pds_paths p)
{
    return p == PDS_PATHS_ALL ? "all" : p == PDS_PATHS_NO_CAUSTICS ? "no-caustics" : "caustics-only";
}

/* Did a time budget lower pm's or spm's k or pdm's max_photons? */
static int gather_cap_lowered(const pds_options *o, const pds_render_stats *st)
{
    long asked = o->method == PDS_METHOD_PDM ? o->max_photons : (long)o->k;
    return (o->method == PDS_METHOD_PM || o->method == PDS_METHOD_PDM || o->method == PDS_METHOD_SPM) &&
           st->gather_cap > 0 && st->gather_cap < asked;
}

/* The pixels' choice of scale (pds_render_stats.scale_pixels: the
   passes' own footprints, half the smoothing, the five blurs), when they
   made one. */
static void print_scale_pixels(const long p[PDS_SCALE_ESTIMATES])
{
    long all = 0;
    int k;
    for (k = 0; k < PDS_SCALE_ESTIMATES; k++) all += p[k];
    if (all <= 0) return;
    for (k = 0; k < PDS_SCALE_ESTIMATES; k++) printf("%s%ld", k ? "/" : " scale_pixels=", p[k]);
}

/* The final line of render. */
static void print_render_line(const run_cfg *c, const pds_render_stats *st, const char *output)
{
    pds_method m = c->opt.method;
    printf("render method=%s paths=%s width=%d height=%d spp=%d", method_name(m), paths_name(c->opt.paths),
           st->width, st->height, st->spp);
    if (is_photon_method(m)) {
        char params[256];
        format_params(&c->opt, params, sizeof params);
        /* stats.splatted counts the photons splatted (pds, splat) or stored
           in the map (pm, pdm); ppm keeps no count of its own */
        printf(" photons=%ld", st->photons);
        if (m == PDS_METHOD_PDS)
            printf(" splatted=%ld dropped_degenerate=%ld split=%ld", st->splatted, st->dropped_degenerate, st->split);
        else if (m == PDS_METHOD_SPLAT)
            printf(" splatted=%ld", st->splatted);
        else if (m != PDS_METHOD_PPM)
            printf(" stored=%ld", st->splatted);
        if (m == PDS_METHOD_SPM) printf(" streams=%ld", st->streams);
        if (m == PDS_METHOD_PDS && !c->opt.progressive && c->opt.time_s > 0.0)
            printf(" photons_planned=%.0f", st->photons_planned);
        printf(" eye_vertices=%ld", st->eye_vertices);
        if (m == PDS_METHOD_PDS) printf(" eye_samples=%ld", st->eye_samples);
        if (m == PDS_METHOD_PPM) printf(" passes=%d", st->passes);
        printf("%s", params);
        if (MBIT(m) & M_MAP) printf(" map_bytes=%lu", (unsigned long)st->map_bytes);
        /* a time budget lowered the gather's cap so that the gather fits */
        if (gather_cap_lowered(&c->opt, st))
            printf(" %s_used=%ld", m == PDS_METHOD_PDM ? "max_photons" : "k", st->gather_cap);
        if (st->gather_radius > 0.0) printf(" max_radius_used=%g", st->gather_radius);
        printf(" time_eye=%.3f time_photons=%.3f", st->time_eye_s, st->time_photons_s);
        print_scale_pixels(st->scale_pixels);
        if (st->through_pixels > 0) printf(" through_pixels=%ld", st->through_pixels);
        if (m == PDS_METHOD_SPM && c->opt.paths != PDS_PATHS_CAUSTICS_ONLY) {
            /* the full image: gi's global map of streams and final gather
               (map_bytes above holds both maps, time_map both builds) */
            printf(" global_stored=%ld global_streams=%ld shadow_stored=%ld shadow_rays=%ld shadow_rays_saved=%ld"
                   " gather_rays=%ld time_map=%.3f", st->global_stored, st->global_streams, st->shadow_stored,
                   st->shadow_rays, st->shadow_rays_saved, st->gather_rays, st->time_map_s);
        }
    } else if (m == PDS_METHOD_GI) {
        char params[256];
        pds_options co = c->opt;
        co.method = c->opt.caustics;
        format_params(&co, params, sizeof params);
        printf(" caustics=%s photons=%ld eye_vertices=%ld%s global_photons=%ld global_k=%d gather=%d gather_mix=%g"
               " shadow_photons=%d global_stored=%ld shadow_stored=%ld shadow_rays=%ld shadow_rays_saved=%ld"
               " gather_rays=%ld map_bytes=%lu time_map=%.3f time_eye=%.3f time_photons=%.3f",
               method_name(co.method), st->photons, st->eye_vertices, params, c->opt.global_photons,
               c->opt.global_k, c->opt.gather, c->opt.gather_mix, c->opt.shadow_photons, st->global_stored,
               st->shadow_stored, st->shadow_rays, st->shadow_rays_saved, st->gather_rays,
               (unsigned long)st->map_bytes, st->time_map_s, st->time_eye_s, st->time_photons_s);
        if (c->opt.global_map == PDS_GLOBAL_STREAMS) {
            printf(" global_map=streams stream_photons=%d", c->opt.stream_photons);
            if (c->opt.stream_radius > 0.0) printf(" stream_radius=%g", c->opt.stream_radius);
            else printf(" stream_radius=auto");
            printf(" global_streams=%ld", st->global_streams);
        }
    } else if (m == PDS_METHOD_ISC) {
        char params[256];
        format_params(&c->opt, params, sizeof params);
        printf(" photons=%ld landed=%ld eye_vertices=%ld frames=%d%s time_eye=%.3f time_photons=%.3f time_gather=%.3f",
               st->photons, st->splatted, st->eye_vertices, st->passes, params, st->time_eye_s, st->time_photons_s,
               st->time_gather_s);
    } else {
        printf(" passes=%d", st->passes);
    }
    if (st->spectral) printf(" spectral=1");
    printf(" time_total=%.3f threads=%d saturated=%ld nonfinite=%ld output=%s\n", st->time_total_s, st->threads,
           st->saturated, st->nonfinite, output);
    if (st->saturated > 0)
        fprintf(stderr, "pds: warning: %ld photon terms overflowed their pixel's sum (the light is some 1e18 times "
                "brighter there than the scene's mean); those pixels hold the largest value\n", st->saturated);
    if (st->dropped_invalid > 0)
        fprintf(stderr, "pds: warning: %ld photon terms were negative, infinite or NaN and were dropped\n",
                st->dropped_invalid);
    if (st->nonfinite > 0)
        fprintf(stderr, "pds: warning: %ld image values were NaN or beyond the float range; written as 0 or the "
                "largest float\n", st->nonfinite);
}

/* ------------------------------------------------------------ images out */

/* How a command's images go out (--tonemap, --exr-compression), set once
   it has read its options, and the metadata of the image a render or a
   merge makes (README "Images"). Debug views and the race's and sweep's
   pictures carry no metadata. */
static pds_image_write_options image_out = {0.0, PDS_TONEMAP_CLAMP, PDS_EXR_ZIP, NULL};
static pds_image_meta image_meta;

static void image_out_set(const run_cfg *c)
{
    image_out.tonemap = (pds_tonemap)c->tonemap;
    image_out.exr_compression = (pds_exr_compression)c->exr_compression;
}

static pds_status image_write(const char *path, const pds_image *img, double exposure, const pds_image_meta *meta,
                              pds_error *err)
{
    pds_image_write_options o = image_out;
    o.exposure_stops = exposure;
    o.meta = meta;
    return pds_image_write_with(path, img, &o, err);
}

/* What kind of image a render with these paths makes (pds:kind). */
static const char *paths_kind(pds_paths p)
{
    return p == PDS_PATHS_ALL ? PDS_META_KIND_FULL
           : p == PDS_PATHS_CAUSTICS_ONLY ? PDS_META_KIND_CAUSTICS : PDS_META_KIND_NO_CAUSTICS;
}

/* A metadata entry; a value pds_image_meta refuses (a scene path outside
   printable ASCII, say) is left out rather than failing the render. */
static void meta_put(const char *key, const char *fmt, ...) PRINTF_LIKE(2, 3);
static void meta_put(const char *key, const char *fmt, ...)
{
    char v[PDS_IMAGE_META_VALUE];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(v, sizeof v, fmt, ap);
    va_end(ap);
    (void)pds_image_meta_set(&image_meta, key, v);
}

/* The metadata of a render's image into image_meta: its kind, its method
   and the options of the render line; with st (after the render) also
   the photons and times. */
static void render_meta(const run_cfg *c, const pds_render_stats *st, const char *scene_path)
{
    char params[256];
    image_meta.count = 0;
    meta_put("pds:version", "%s", PDS_VERSION_STRING);
    meta_put(PDS_META_KIND, "%s", paths_kind(c->opt.paths));
    meta_put(PDS_META_METHOD, "%s", method_name(c->opt.method));
    if (c->opt.method == PDS_METHOD_GI) meta_put("pds:caustics", "%s", method_name(c->opt.caustics));
    meta_put("pds:scene", "%s", scene_path);
    meta_put("pds:seed", "%llu", c->opt.seed);
    meta_put("pds:photons", "%ld", st ? st->photons : c->opt.photons);
    format_params(&c->opt, params, sizeof params);
    {
        char bounces[40] = "";
        if (c->opt.diffuse_bounces >= 0) snprintf(bounces, sizeof bounces, " diffuse_bounces=%d", c->opt.diffuse_bounces);
        meta_put("pds:options", "paths=%s spp=%d max_depth=%d%s%s%s", paths_name(c->opt.paths),
                 st ? st->spp : c->opt.spp, c->opt.max_depth, bounces, params, c->opt.spectral ? " spectral=1" : "");
    }
    if (st) {
        meta_put("pds:size", "%dx%d", st->width, st->height);
        meta_put("pds:time", "total=%.3f eye=%.3f photons=%.3f threads=%d", st->time_total_s, st->time_eye_s,
                 st->time_photons_s, st->threads);
    }
}

/* One stderr line when an image and its reference are of different kinds
   (a full render against a caustics-only reference, say): their
   difference is then mostly the light paths one has and the other lacks.
   Nothing when either kind is unknown. */
static void warn_kind_mismatch(const char *cmd, const char *what, const char *kind, const char *ref_path,
                               const char *ref_kind)
{
    if (!kind || !ref_kind || !strcmp(kind, ref_kind)) return;
    fprintf(stderr, "pds %s: warning: kinds differ: %s %s %s, the reference %s is %s (pds:kind); the error will "
            "measure the light paths one has and the other lacks\n", cmd, what,
            !strcmp(what, "the renders") ? "are" : "is", kind, ref_path, ref_kind);
}

/* Before loading or rendering anything: fail now if path could not be
   written later. Its folder must exist and let us create files in it (the
   image is written beside it under a temporary name, then renamed), and
   path must not be a folder. 0, or 1 after printing "PATH: why". */
static int check_out_file(const char *path)
{
    char dir[PATH_MAX_LEN];
    const char *slash = strrchr(path, '/');
    struct stat sb;
    if (strlen(path) >= sizeof dir) return fail("%s: path too long", path);
    if (!slash) {
        strcpy(dir, ".");
    } else if (slash == path) {
        strcpy(dir, "/");
    } else {
        memcpy(dir, path, (size_t)(slash - path));
        dir[slash - path] = '\0';
    }
    if (stat(dir, &sb) != 0) return fail("%s: cannot write: %s: %s", path, dir, strerror(errno));
    if (!S_ISDIR(sb.st_mode)) return fail("%s: cannot write: %s is not a folder", path, dir);
    if (access(dir, W_OK | X_OK) != 0) return fail("%s: cannot write in %s: %s", path, dir, strerror(errno));
    if (stat(path, &sb) == 0 && S_ISDIR(sb.st_mode)) return fail("%s: cannot write: it is a folder", path);
    return 0;
}

/* Say so before a render that would take days or most of the memory
   (pds_render itself refuses one that cannot fit). The speed is a round
   figure for this kind of machine: 2 million eye samples a second per
   core. */
static void warn_about_the_cost(const pds_scene *scene, const pds_options *opt)
{
    pds_render_estimate est;
    int threads = opt->threads > 0 ? opt->threads : pds_cpu_count();
    double hours;
    if (pds_render_estimate_get(scene, opt, &est, NULL) != PDS_OK) return;
    hours = est.samples / (2e6 * threads) / 3600.0;
    if (opt->time_s <= 0.0 && hours > 1.0)
        fprintf(stderr, "pds render: warning: %.3g pixel samples a pass: at about 2 million a second per core, some "
                "%.0f hours on %d threads\n", est.samples, hours, threads);
    if (est.available_bytes > 0.0 && est.memory_bytes > 0.5 * est.available_bytes &&
        est.memory_bytes <= est.available_bytes)
        fprintf(stderr, "pds render: warning: this render may hold up to %.1f GB of the machine's %.1f GB\n",
                est.memory_bytes / 1e9, est.available_bytes / 1e9);
}

/* The image of one part, as the merge makes it (a part not finished gives
   what it holds); st (or NULL) gets what the image tells of the render:
   its values replaced and the pixels' choice of scale, whose time it adds
   to the photon pass's. */
static pds_status part_image(const pds_partial *part, pds_image *img, pds_render_stats *st, pds_error *err)
{
    const pds_partial *parts[1];
    pds_merge_report report;
    pds_status s;
    int k;
    parts[0] = part;
    s = pds_partial_merge_report(parts, NULL, 1, 1, img, &report, err);
    if (s == PDS_OK && st) {
        st->nonfinite = report.nonfinite;
        for (k = 0; k < PDS_SCALE_ESTIMATES; k++) st->scale_pixels[k] = report.scale_pixels[k];
        st->through_pixels = report.through_pixels;
        /* the pixels' choice of scale is the photon pass's (as in pds_render) */
        st->time_photons_s += report.choice_s;
        st->time_total_s += report.choice_s;
    }
    return s;
}

/* Write the part's file and, unless image_path is NULL, its image; both
   atomically (a signal removes their temporary files). 0, or 1 after
   printing why. */
static int write_part(const pds_partial *part, const char *part_path, const char *image_path, double exposure)
{
    pds_image img = {0, 0, NULL};
    pds_error err;
    int rc = 0;
    if (temp_arm(0, part_path) || (image_path && temp_arm(1, image_path))) rc = 1;
    else if (pds_partial_write(part_path, part, &err) != PDS_OK ||
             (image_path && (part_image(part, &img, NULL, &err) != PDS_OK ||
                             image_write(image_path, &img, exposure, &image_meta, &err) != PDS_OK)))
        rc = fail("%s", pds_error_string(&err));
    temp_disarm(0);
    temp_disarm(1);
    pds_image_free(&img);
    return rc;
}

/* --shard I/N (1-based I, as job arrays count) into opt's 0-based fields. */
static int parse_shard(const char *v, pds_options *opt)
{
    long i, n;
    char a[32], *slash;
    if (strlen(v) >= sizeof a) return usage_error("--shard needs I/N, e.g. 2/8, got '%s'", v);
    strcpy(a, v);
    slash = strchr(a, '/');
    if (!slash) return usage_error("--shard needs I/N, e.g. 2/8, got '%s'", v);
    *slash = '\0';
    if (parse_int(slash + 1, 1, 1000000, &n) || parse_int(a, 1, n, &i))
        return usage_error("--shard needs I/N with 1 <= I <= N <= 1000000, got '%s'", v);
    opt->shard_index = (int)(i - 1);
    opt->shard_count = (int)n;
    return 0;
}

/* Write len bytes of text to path through its temporary name (armed in
   temp slot `slot` meanwhile). 0, or 1 after printing why not. */
static int write_text_file(int slot, const char *path, const char *text, size_t len)
{
    char tmp[PATH_MAX_LEN + 32];
    FILE *f;
    int ok, e;
    if (temp_arm(slot, path)) return 1;
    temp_path(path, tmp, sizeof tmp); /* the name just armed: it fits */
    f = fopen(tmp, "wb");
    if (!f) {
        e = errno;
        temp_disarm(slot);
        return fail("%s: cannot write: %s", path, strerror(e));
    }
    ok = fwrite(text, 1, len, f) == len;
    ok = (fclose(f) == 0) && ok;
    if (ok && rename(tmp, path) == 0) {
        temp_disarm(slot);
        return 0;
    }
    e = errno;
    remove(tmp);
    temp_disarm(slot);
    return fail("%s: cannot write: %s", path, strerror(e));
}

/* The methods each debug view is made for, and the file it goes to beside
   OUT ("OUT.NAME.png"; paths: "OUT.paths.obj"). */
static unsigned debug_methods(pds_debug_view v)
{
    switch (v) {
    case PDS_DEBUG_FOOTPRINT:
    case PDS_DEBUG_ELLIPSES:
    case PDS_DEBUG_SCALES: return MBIT(PDS_METHOD_PDS);
    case PDS_DEBUG_LANDINGS:
    case PDS_DEBUG_SPLATS: return MBIT(PDS_METHOD_PDS) | MBIT(PDS_METHOD_SPLAT);
    default: return M_PHOTON;
    }
}

static void debug_path(const char *output, pds_debug_view v, const char *ext, char *out, size_t n)
{
    const char *dot = strrchr(output, '.');
    snprintf(out, n, "%.*s.%s%s", (int)(dot - output), output, pds_debug_view_name(v), ext);
}

/* OUT.png -> OUT.0007.png: frame f of an animation (at least 4 digits). */
static void frame_path(const char *output, int frame, char *buf, size_t n)
{
    const char *dot = strrchr(output, '.');
    snprintf(buf, n, "%.*s.%04d%s", (int)(dot - output), output, frame, dot);
}

typedef struct frame_writer {
    const char *output;
    double exposure;
} frame_writer;

/* pds_render_frames' callback: each frame to its numbered file, through a
   temporary name as every image. */
static pds_status write_frame(void *user, int frame, const pds_image *img, pds_error *err)
{
    const frame_writer *fw = (const frame_writer *)user;
    char path[1100];
    pds_status st;
    frame_path(fw->output, frame, path, sizeof path);
    if (temp_arm(0, path)) {
        snprintf(err->text, sizeof err->text, "%.900s: cannot write frame %d", path, frame);
        err->status = PDS_ERR_IO;
        return PDS_ERR_IO;
    }
    st = image_write(path, img, fw->exposure, &image_meta, err);
    temp_disarm(0);
    return st;
}

static int cmd_render(int argc, char **argv)
{
    static const char *const own[] = {"--shard", "--resume", "--checkpoint", NULL};
    const char *scene_path = NULL, *output, *resume = NULL;
    char dpath[PDS_DEBUG_VIEWS][2][1100], default_out[1024], where[64], part_path[1100];
    run_cfg c;
    pds_scene *scene = NULL;
    pds_image img = {0, 0, NULL};
    pds_render_stats stats;
    pds_partial *part = NULL;
    pds_partial_info info;
    pds_error err, image_err;
    pds_status st, image_st = PDS_OK;
    double checkpoint_s = 0.0, t_start;
    int i, r, k, rc = 0, shard_given = 0, part_only, checkpoints = 0, pfm, interrupted;
    cfg_init(&c);
    for (i = 0; i < argc; i++) {
        const char *a = argv[i], *v;
        if (a[0] != '-' || a[1] == '\0') {
            if (scene_path) return usage_error("render takes one scene, got another: '%s'", a);
            scene_path = a;
            continue;
        }
        if (arg_is(a, "--shard") || arg_is(a, "--resume") || arg_is(a, "--checkpoint")) {
            if ((r = option_value(argc, argv, &i, &v)) != 0) return r;
            if (arg_is(a, "--shard")) {
                if ((r = parse_shard(v, &c.opt)) != 0) return r;
                shard_given = 1;
            } else if (arg_is(a, "--resume")) {
                resume = v;
            } else if (parse_double(v, &checkpoint_s) || !(checkpoint_s > 0.0) || checkpoint_s > 1e7) {
                return usage_error("--checkpoint needs a number of seconds above 0, got '%s'", v);
            }
            continue;
        }
        r = parse_option(&c, C_RENDER, "render", argc, argv, &i);
        if (r < 0) return unknown_option(a, C_RENDER, own);
        if (r) return r;
    }
    if (resume) {
        /* the options come from the partial file; only how to run may change */
        static const char *const allowed[] = {"--output", "--threads", "--progress", "--quiet", "--exposure",
                                              "--tonemap", "--exr-compression",
                                              "--define", "--obj-material"}; /* the same -D: the scene's hash checks it */
        size_t k;
        int threads = c.opt.threads;
        for (k = 0; k < N_OPTIONS; k++) {
            size_t j;
            int ok = 0;
            for (j = 0; j < sizeof allowed / sizeof allowed[0]; j++) ok |= !strcmp(option_table[k].name, allowed[j]);
            if (!ok && c.given[k])
                return usage_error("--resume takes the render's options from %s; %s cannot change them", resume,
                                   option_table[k].name);
        }
        if (shard_given) return usage_error("--resume takes the shard from %s; --shard cannot change it", resume);
        if (pds_partial_read(resume, &part, &err) != PDS_OK) return fail("%s", pds_error_string(&err));
        pds_partial_get_info(part, &info);
        pds_partial_options(part, &c.opt);
        c.opt.threads = threads;
        if (!scene_path) scene_path = info.scene_path;
    }
    if (!scene_path) return usage_error("%s", "render needs a scene file");
    for (k = 0; k < PDS_DEBUG_VIEWS; k++) {
        char names[128];
        if (!(c.debug.views & (1u << k)) || (debug_methods((pds_debug_view)k) & MBIT(c.opt.method))) continue;
        method_join(debug_methods((pds_debug_view)k), "or", names, sizeof names);
        return usage_error("--debug %s needs --method %s", pds_debug_view_name((pds_debug_view)k), names);
    }
    if (c.frames > 0 && c.opt.method != PDS_METHOD_ISC)
        return usage_error("%s", "--frames renders an animation with --method isc only");
    if (c.frames > 0 && c.opt.time_s > 0.0)
        return usage_error("%s", "--frames and --time exclude each other (a time budget is for a still)");
    if (c.opt.static_lighting && c.opt.method == PDS_METHOD_ISC && c.frames == 0)
        return usage_error("%s", "--static-lighting keeps the photons from frame to frame: it is for --frames");
    if (c.opt.static_lighting && c.frames > 0 && c.opt.orbit == PDS_ORBIT_LIGHT)
        return usage_error("%s", "--static-lighting keeps the light where it is: give --orbit camera or --orbit none");
    output = c.output;
    if (!output && resume) {
        /* OUT.png.pdsp continues OUT.png; a shard's file continues itself */
        size_t n = strlen(resume);
        if (c.opt.shard_count > 1) {
            output = resume;
        } else if (n > 5 && has_ext(resume, ".pdsp") && n - 5 < sizeof default_out) {
            memcpy(default_out, resume, n - 5);
            default_out[n - 5] = '\0';
            output = default_out;
        }
        if (!output) {
            pds_partial_free(part);
            return usage_error("say where the image goes: -o OUT.png (%s does not end in .pdsp)", resume);
        }
    }
    if (!output) {
        default_output(scene_path, default_out, sizeof default_out);
        output = default_out;
    }
    part_only = has_ext(output, ".pdsp");
    if (!has_ext(output, ".png") && !has_ext(output, ".pfm") && !has_ext(output, ".exr") && !part_only) {
        pds_partial_free(part);
        return usage_error("output must end in .png, .pfm, .exr or .pdsp, got '%s'", output);
    }
    if (c.opt.shard_count > 1 && !part_only) {
        pds_partial_free(part);
        return usage_error("a shard is written as a partial file: -o PART.pdsp (then pds merge), got '%s'", output);
    }
    if (c.opt.time_s > 0.0 && (part_only || checkpoint_s > 0.0)) {
        pds_partial_free(part);
        return usage_error("%s", "a render with --time cannot be split, continued or checkpointed: its photon count "
                           "is not fixed (give --photons)");
    }
    if (c.frames > 0 && (part_only || checkpoint_s > 0.0)) {
        pds_partial_free(part);
        return usage_error("%s", "--frames writes an animation frame by frame: it is not split into shards or "
                           "checkpointed (a shard or checkpoint is of one image)");
    }
    if (c.debug.views && (part_only || resume || checkpoint_s > 0.0)) {
        pds_partial_free(part);
        return usage_error("%s", "--debug views are made by a render in one go (no partial files or checkpoints)");
    }
    if (part_only) snprintf(part_path, sizeof part_path, "%s", output);
    else snprintf(part_path, sizeof part_path, "%s.pdsp", output);
    pfm = has_ext(output, ".pfm") || has_ext(output, ".exr"); /* raw values of the views too */
    if (c.debug.views) c.opt.debug = &c.debug;
    /* a typo in -o costs nothing: it is found before the render, not after */
    if (check_out_file(output)) {
        pds_partial_free(part);
        return 1;
    }
    for (k = 0; k < PDS_DEBUG_VIEWS; k++) {
        if (!(c.debug.views & (1u << k))) continue;
        debug_path(output, (pds_debug_view)k, k == PDS_DEBUG_PATHS ? ".obj" : ".png", dpath[k][0], sizeof dpath[k][0]);
        debug_path(output, (pds_debug_view)k, has_ext(output, ".exr") ? ".exr" : ".pfm", dpath[k][1],
                   sizeof dpath[k][1]);
        if (check_out_file(dpath[k][0]) || (pfm && k != PDS_DEBUG_PATHS && check_out_file(dpath[k][1]))) return 1;
    }
    snprintf(where, sizeof where, "with --method %s", method_name(c.opt.method));
    note_idle_options(&c, MBIT(c.opt.method), where);
    cfg_apply_progress(&c);
    if (load_any(scene_path, &scene, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", pds_error_string(&err));
        pds_partial_free(part);
        return 1;
    }
    print_scene_warnings(scene, &c);
    pds_options_resolve(scene, &c.opt); /* the photon counts the render line and metadata report */
    if (!c.quiet) warn_about_the_cost(scene, &c.opt);
    /* checkpoints stop the render where its state is kept: between eye
       rows (pt), photon batches or passes (pds, splat, and gi with their
       caustics); pm, pdm, ppm and spm keep nothing between photons, nor
       gi with their caustics, and isc renders its frame in one go, so
       they get none before the end */
    {
        pds_method cm = c.opt.method == PDS_METHOD_GI ? c.opt.caustics : c.opt.method;
        progress.checkpoint_s = checkpoint_s;
        progress.checkpoint_phase =
            c.opt.method == PDS_METHOD_ISC ? -1
            : (!is_photon_method(cm) && c.opt.method != PDS_METHOD_GI) || c.opt.paths == PDS_PATHS_NO_CAUSTICS
                ? PDS_PHASE_EYE
            : cm == PDS_METHOD_PDS || cm == PDS_METHOD_SPLAT ? PDS_PHASE_PHOTONS
                                                             : -1;
    }
    if (checkpoint_s > 0.0 && progress.checkpoint_phase < 0)
        fprintf(stderr, "pds render: note: --checkpoint: %s %s; it writes the partial file only at the end\n",
                method_name(c.opt.method),
                c.opt.method == PDS_METHOD_ISC ? "renders its frame in one go" : "keeps no state between photons");
    progress.t_checkpoint = pds_time_now();
    image_out_set(&c);
    render_meta(&c, NULL, scene_path); /* for checkpoints and frames; the final image's below */
    if (c.frames > 0) {
        /* an animation: numbered frames, written as they come */
        frame_writer fw;
        char pattern[1100];
        fw.output = output;
        fw.exposure = c.exposure;
        if (c.progress) progress_begin(NULL, 0.0);
        st = pds_render_frames(scene, &c.opt, c.frames, write_frame, &fw, &stats, &err);
        if (c.progress) progress_end(st == PDS_OK);
        pds_partial_free(part);
        pds_scene_free(scene);
        if (st != PDS_OK) return fail("%s", pds_error_string(&err));
        frame_path(output, 0, pattern, sizeof pattern);
        print_render_line(&c, &stats, pattern);
        return 0;
    }
    if (c.progress) progress_begin(NULL, c.opt.time_s);
    stop_gracefully = 1;
    t_start = pds_time_now();
    for (;;) {
        progress.checkpoint_due = 0;
        st = pds_render_part(scene, &c.opt, &part, &stats, &err);
        if (st != PDS_OK || !stats.partial || stop_requested || !progress.checkpoint_due) break;
        /* a checkpoint: the state and the image so far, then go on */
        if (write_part(part, part_path, part_only ? NULL : output, c.exposure)) {
            rc = 1;
            break;
        }
        checkpoints++;
        progress.t_checkpoint = pds_time_now();
    }
    /* from here a signal ends the process, removing the temporary files */
    stop_gracefully = 0;
    stats.time_total_s = pds_time_now() - t_start; /* every call's, checkpoints included */
    interrupted = stats.partial && stop_requested && c.opt.time_s <= 0.0 && !c.debug.views;
    if (st == PDS_OK && !rc && !interrupted && !part_only)
        image_st = part_image(part, &img, &stats, &image_err); /* before its metadata: it adds its choice's time */
    render_meta(&c, &stats, scene_path);
    if (c.progress) progress_end(st == PDS_OK && !stats.partial);
    if (rc) {
        /* the checkpoint's message is out */
    } else if (st != PDS_OK) {
        rc = fail("%s", pds_error_string(&err));
    } else if (interrupted) {
        /* interrupted: the image of what is done, and the state to go on */
        pds_partial_get_info(part, &info);
        rc = write_part(part, part_path, part_only ? NULL : output, c.exposure);
        if (!rc) {
            fprintf(stderr, "pds render: interrupted with %.1f%% of %s done; %s%s holds it; continue with\n"
                    "    pds render --resume %s%s%s\n", 100.0 * info.done_fraction,
                    c.opt.shard_count > 1 ? "the shard" : "the render", part_only ? "" : "the image so far is in ",
                    part_only ? part_path : output, part_path, part_only ? "" : " -o ", part_only ? "" : output);
            if (!part_only) fprintf(stderr, "    (%s holds the exact state)\n", part_path);
            rc = 130;
        }
    } else if (part_only) {
        rc = write_part(part, part_path, NULL, c.exposure);
    } else {
        /* from here until they are in place a signal removes the images'
           temporary files */
        if (image_st != PDS_OK) rc = fail("%s", pds_error_string(&image_err));
        else if (temp_arm(0, output)) rc = 1;
        else if (image_write(output, &img, c.exposure, &image_meta, &err) != PDS_OK)
            rc = fail("%s", pds_error_string(&err));
        temp_disarm(0);
        for (k = 0; k < PDS_DEBUG_VIEWS && rc == 0; k++) {
            if (!(c.debug.views & (1u << k))) continue;
            if (k == PDS_DEBUG_PATHS) {
                const char *text = c.debug.paths_obj ? c.debug.paths_obj : "";
                rc = write_text_file(1 + 2 * k, dpath[k][0], text, strlen(text));
                continue;
            }
            if (temp_arm(1 + 2 * k, dpath[k][0]) || (pfm && temp_arm(2 + 2 * k, dpath[k][1]))) rc = 1;
            else if (pds_image_write(dpath[k][0], &c.debug.picture[k], 0.0, &err) != PDS_OK ||
                     (pfm && pds_image_write(dpath[k][1], &c.debug.value[k], 0.0, &err) != PDS_OK))
                rc = fail("%s", pds_error_string(&err));
            temp_disarm(1 + 2 * k);
            temp_disarm(2 + 2 * k);
        }
        /* the render is whole: a partial file it was continued from, or
           its checkpoint, is spent */
        if (!rc && ((resume && !strcmp(resume, part_path)) || checkpoints > 0)) remove(part_path);
        if (!rc && checkpoints > 0 && !c.quiet)
            fprintf(stderr, "pds render: %d checkpoints written to %s (removed now that the render is whole)\n",
                    checkpoints, part_path);
        /* --time and teaching views: the image of the work done, and no
           partial file */
        if (stop_requested && !rc && (c.opt.time_s > 0.0 || c.debug.views)) rc = 130;
    }
    pds_image_free(&img);
    pds_partial_free(part);
    pds_scene_free(scene);
    if (rc == 0 || rc == 130) print_render_line(&c, &stats, part_only ? part_path : output);
    /* the paper's PDS whose splats did not fit its time budget */
    if (rc == 0 && !c.quiet && c.opt.method == PDS_METHOD_PDS && !c.opt.progressive && c.opt.time_s > 0.0 &&
        stats.photons < 0.8 * stats.photons_planned)
        fprintf(stderr, "pds render: note: the splats of --smoothing %g did not fit in the %g s budget: %.0f photons "
                "were planned, %ld emitted, so the footprints cover %.2f of s^2 (smoothing %.3g in effect)\n",
                c.opt.smoothing, c.opt.time_s, stats.photons_planned, stats.photons,
                (double)stats.photons / stats.photons_planned,
                c.opt.smoothing * sqrt((double)stats.photons / stats.photons_planned));
    /* a time budget that lowered the gather's cap */
    if (rc == 0 && !c.quiet && gather_cap_lowered(&c.opt, &stats))
        fprintf(stderr, "pds render: note: %s's gather with %s %ld would not have ended within the %g s budget; "
                "it used %ld (the most that fitted, and 8 at least)\n", method_name(c.opt.method),
                c.opt.method == PDS_METHOD_PDM ? "--max-photons" : "--k",
                c.opt.method == PDS_METHOD_PDM ? c.opt.max_photons : (long)c.opt.k, c.opt.time_s, stats.gather_cap);
    if (rc == 0 && !c.quiet && stats.gather_radius > 0.0)
        fprintf(stderr, "pds render: note: even 8 photons a query could not be gathered within the %g s budget; the "
                "search radius was bounded by %g (max_radius_used)\n", c.opt.time_s, stats.gather_radius);
    /* a budget the render missed by more than race's tolerance (25%):
       pm's or pdm's gather alone can outlast it at a high resolution */
    if (rc == 0 && c.opt.time_s > 0.0 && is_photon_method(c.opt.method) && !stop_requested &&
        stats.time_total_s > 1.25 * c.opt.time_s) {
        /* what cannot shrink with the budget, where it is known */
        const char *why = "", *eye = stats.time_eye_s > c.opt.time_s
                                         ? "; the eye pass alone outlasts it, and its cost grows with --res and --spp"
                                         : "";
        if (MBIT(c.opt.method) & M_MAP)
            why = "; the map's build and gather come after the last photon, and their cost grows with the eye "
                  "vertices (--res, --spp) and k or --max-photons";
        else if (c.opt.method == PDS_METHOD_PPM && stats.passes <= 1)
            why = "; every ppm pass updates every eye vertex (a range query each) whatever its photon count, and "
                  "at this --res and --spp one pass's update alone outlasts the budget";
        else if (c.opt.method == PDS_METHOD_PDS && !c.opt.progressive && stats.photons <= 1024)
            why = "; the paper's PDS builds its eye-path map (a kd-tree over every eye vertex) and calibrates in "
                  "the budget, and at this --res and --spp those alone outlast it";
        fprintf(stderr, "pds render: warning: the render took %.3g s of its %g s budget (%+.0f%%)%s%s\n",
                stats.time_total_s, c.opt.time_s, 100.0 * (stats.time_total_s / c.opt.time_s - 1.0), eye, why);
    }
    pds_debug_free(&c.debug);
    return rc;
}

/* pds merge -o OUT [--partial] PART.pdsp... */
static int cmd_merge(int argc, char **argv)
{
    static const char *const own[] = {"--output", "--partial", "--exposure", "--tonemap", "--exr-compression", NULL};
    const char *output = NULL;
    const char **names;
    pds_partial **parts;
    pds_image img = {0, 0, NULL};
    pds_error err;
    double exposure = 0.0, t0 = pds_time_now();
    pds_merge_report report; /* the merge's fraction, values replaced and choices of scale */
    int i, n = 0, subset = 0, rc = 0, r;
    memset(&report, 0, sizeof report);
    names = (const char **)malloc(sizeof *names * (size_t)(argc > 0 ? argc : 1));
    parts = (pds_partial **)calloc((size_t)(argc > 0 ? argc : 1), sizeof *parts);
    if (!names || !parts) {
        free(names);
        free(parts);
        return fail("%s", "out of memory");
    }
    for (i = 0; i < argc && !rc; i++) {
        const char *a = argv[i], *v;
        if (a[0] != '-' || a[1] == '\0') {
            names[n++] = a;
        } else if (arg_is(a, "--output") || arg_is(a, "-o")) {
            if ((r = option_value(argc, argv, &i, &v)) != 0) rc = r;
            else output = v;
        } else if (arg_is(a, "--exposure")) {
            if ((r = option_value(argc, argv, &i, &v)) != 0) rc = r;
            else if (parse_double(v, &exposure) || exposure < -64 || exposure > 64)
                rc = usage_error("--exposure needs a number of stops from -64 to 64, got '%s'", v);
        } else if (arg_is(a, "--tonemap") || arg_is(a, "--exr-compression")) {
            run_cfg c;
            cfg_init(&c);
            c.tonemap = (int)image_out.tonemap;
            c.exr_compression = (int)image_out.exr_compression;
            if ((r = option_value(argc, argv, &i, &v)) != 0) rc = r;
            else if (arg_is(a, "--tonemap")) rc = set_tonemap(NULL, &c, "--tonemap", v);
            else rc = set_exr_compression(NULL, &c, "--exr-compression", v);
            if (!rc) image_out_set(&c);
        } else if (!strcmp(a, "--partial")) {
            subset = 1;
        } else {
            rc = unknown_option(a, 0, own);
        }
    }
    if (!rc && !output) rc = usage_error("%s", "merge needs -o OUT.png, OUT.pfm or OUT.exr");
    if (!rc && n == 0) rc = usage_error("%s", "merge needs the partial files: pds merge -o OUT.png PART.pdsp...");
    if (!rc && !has_ext(output, ".png") && !has_ext(output, ".pfm") && !has_ext(output, ".exr"))
        rc = usage_error("output must end in .png, .pfm or .exr, got '%s'", output);
    if (!rc && check_out_file(output)) rc = 1;
    for (i = 0; i < n && !rc; i++)
        if (pds_partial_read(names[i], &parts[i], &err) != PDS_OK) rc = fail("%s", pds_error_string(&err));
    if (!rc && pds_partial_merge_report((const pds_partial *const *)parts, names, n, subset, &img, &report, &err) !=
                   PDS_OK)
        rc = fail("%s", pds_error_string(&err));
    if (!rc) {
        /* the parts agree on these (pds_partial_merge checks) */
        pds_partial_info pi;
        pds_partial_get_info(parts[0], &pi);
        image_meta.count = 0;
        meta_put("pds:version", "%s", PDS_VERSION_STRING);
        meta_put(PDS_META_KIND, "%s", paths_kind(pi.paths));
        meta_put(PDS_META_METHOD, "%s", method_name(pi.method));
        if (pi.scene_path) meta_put("pds:scene", "%s", pi.scene_path);
        meta_put("pds:seed", "%llu", pi.seed);
        meta_put("pds:photons", "%ld", pi.photons);
        meta_put("pds:merged", "parts=%d shards=%d fraction=%.6f", n, pi.shard_count, report.fraction);
        if (temp_arm(0, output)) rc = 1;
        else if (image_write(output, &img, exposure, &image_meta, &err) != PDS_OK)
            rc = fail("%s", pds_error_string(&err));
        temp_disarm(0);
    }
    if (!rc) {
        pds_partial_info info;
        pds_partial_get_info(parts[0], &info);
        if (report.fraction < 1.0)
            fprintf(stderr, "pds merge: note: %d part%s holding %.1f%% of the render's work (--partial)\n", n,
                    n == 1 ? "" : "s", 100.0 * report.fraction);
        printf("merge parts=%d shards=%d fraction=%.6f width=%d height=%d", n, info.shard_count, report.fraction,
               img.width, img.height);
        print_scale_pixels(report.scale_pixels);
        if (report.through_pixels > 0) printf(" through_pixels=%ld", report.through_pixels);
        printf(" time_total=%.3f nonfinite=%ld output=%s\n", pds_time_now() - t0, report.nonfinite, output);
    }
    for (i = 0; i < n; i++) pds_partial_free(parts[i]);
    free(parts);
    free(names);
    pds_image_free(&img);
    return rc;
}

/* --mask of compare, sweep and race: read it and check it against the reference
   (its size, a pixel held) before any render. 0, or 1 after saying why. */
static int load_mask(const char *mask_path, const pds_image *ref, pds_image *mask)
{
    pds_metrics mm;
    pds_error err;
    if (pds_image_read(mask_path, mask, NULL, &err) != PDS_OK ||
        pds_image_compare_masked(ref, ref, mask, &mm, &err) != PDS_OK) {
        const char *msg = pds_error_string(&err);
        int of_mask = !strncmp(msg, "the mask", 8); /* (the library's words name no file) */
        fprintf(stderr, "%s%s%s\n", of_mask ? mask_path : "", of_mask ? ": " : "", msg);
        return 1;
    }
    return 0;
}

static int cmd_compare(int argc, char **argv)
{
    static pds_image_meta ma, mb; /* 26 KB each */
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL}, mask = {0, 0, NULL};
    const char *files[2], *mask_path = NULL;
    pds_metrics m;
    pds_error err;
    int rc = 0, nfiles = 0, i;
    for (i = 0; i < argc; i++) {
        if (arg_is(argv[i], "--mask")) {
            if (option_value(argc, argv, &i, &mask_path)) return EXIT_USAGE;
        } else if (argv[i][0] == '-' && argv[i][1] != '\0') {
            return usage_error("compare knows --mask, got '%s'", argv[i]);
        } else if (nfiles < 2) {
            files[nfiles++] = argv[i];
        } else {
            nfiles = 3;
        }
    }
    if (nfiles != 2) return usage_error("%s", "compare needs two images: A.pfm REFERENCE.pfm (or .exr)");
    if (pds_image_read(files[0], &a, &ma, &err) != PDS_OK || pds_image_read(files[1], &b, &mb, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", pds_error_string(&err));
        rc = 1;
    } else if (mask_path && load_mask(mask_path, &b, &mask)) {
        rc = 1;
    } else if (pds_image_compare_masked(&a, &b, mask_path ? &mask : NULL, &m, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", pds_error_string(&err));
        rc = 1;
    } else {
        warn_kind_mismatch("compare", files[0], pds_image_meta_get(&ma, PDS_META_KIND), files[1],
                           pds_image_meta_get(&mb, PDS_META_KIND));
        printf("compare rmse=%.6f ssim=%.6f\n", m.rmse, m.ssim);
    }
    pds_image_free(&a);
    pds_image_free(&b);
    pds_image_free(&mask);
    return rc;
}

/* pds pixel IMAGE.pfm X Y [R]: the mean of the (2R+1)^2 pixels around
   (X, Y) (x right, y down from the top left, clipped to the image), for
   checking a render against a value worked out by hand. */
static int cmd_pixel(int argc, char **argv)
{
    pds_image img = {0, 0, NULL};
    pds_error err;
    long x, y, r = 0, i, j, n = 0;
    double sum[3] = {0, 0, 0};
    if (argc != 3 && argc != 4) return usage_error("%s", "pixel needs IMAGE.pfm X Y [R]");
    if (parse_int(argv[1], 0, PDS_MAX_RESOLUTION - 1, &x) || parse_int(argv[2], 0, PDS_MAX_RESOLUTION - 1, &y) ||
        (argc == 4 && parse_int(argv[3], 0, PDS_MAX_RESOLUTION, &r)))
        return usage_error("pixel needs whole numbers X Y [R] from 0 to %d", PDS_MAX_RESOLUTION - 1);
    if (pds_image_read(argv[0], &img, NULL, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", pds_error_string(&err));
        return 1;
    }
    if (x >= img.width || y >= img.height) {
        int w = img.width, h = img.height;
        pds_image_free(&img);
        return usage_error("pixel %ld,%ld is outside the %dx%d image", x, y, w, h);
    }
    for (j = y - r; j <= y + r; j++)
        for (i = x - r; i <= x + r; i++) {
            int c;
            if (i < 0 || j < 0 || i >= img.width || j >= img.height) continue;
            for (c = 0; c < 3; c++) sum[c] += img.rgb[3 * ((size_t)j * img.width + (size_t)i) + c];
            n++;
        }
    printf("pixel x=%ld y=%ld radius=%ld pixels=%ld r=%.6g g=%.6g b=%.6g\n", x, y, r, n, sum[0] / n, sum[1] / n,
           sum[2] / n);
    pds_image_free(&img);
    return 0;
}

static const char *material_type_name(pds_material_type t)
{
    static const char *const names[] = {"diffuse", "mirror", "conductor", "dielectric", "emissive", "glossy"};
    return (unsigned)t < 6 ? names[t] : "?";
}

static const char *light_type_name(pds_light_type t)
{
    static const char *const names[] = {"point", "spot", "directional", "disk", "quad", "mesh", "environment"};
    return (unsigned)t < 7 ? names[t] : "?";
}

static const char *trace_event_name(pds_trace_event e)
{
    static const char *const names[] = {"emitted", "reflected", "refracted", "landed"};
    return (int)e >= 0 && (int)e < 4 ? names[e] : "?";
}

/* One differential beside its finite difference; returns the relative
   difference (0 when both vanish). */
static double trace_row(const char *name, pds_vec3 a, pds_vec3 fd, int valid)
{
    double dx = a.x - fd.x, dy = a.y - fd.y, dz = a.z - fd.z;
    double na = sqrt(a.x * a.x + a.y * a.y + a.z * a.z), nd = sqrt(dx * dx + dy * dy + dz * dz);
    double rel = na > 0.0 ? nd / na : nd > 0.0 ? 1.0 : 0.0;
    printf("  %-9s (% .6e, % .6e, % .6e)", name, a.x, a.y, a.z);
    if (valid) printf("   fd (% .6e, % .6e, % .6e)   rel %.1e\n", fd.x, fd.y, fd.z, rel);
    else printf("   fd n/a\n");
    return valid ? rel : 0.0;
}

static int cmd_trace_photon(int argc, char **argv)
{
    const char *scene_path = NULL;
    pds_options opt;
    pds_scene *scene = NULL;
    pds_trace tr;
    pds_error err;
    long photon = -1, n;
    double worst = 0.0;
    int i, k, landed = 0;
    pds_options_default(&opt);
    for (i = 0; i < argc; i++) {
        const char *a = argv[i];
        double x;
        if (a[0] != '-') {
            if (scene_path) return usage_error("trace-photon takes one scene, got another: '%s'", a);
            scene_path = a;
            continue;
        }
        if (i + 1 >= argc) return usage_error("%s needs a value", a);
        if (!strcmp(a, "--photon")) {
            if (parse_count(argv[++i], 0, LONG_MAX / 2, &photon)) return usage_error("--photon needs a whole number of 0 or more, got '%s'", argv[i]);
        } else if (!strcmp(a, "--photons")) {
            if (parse_count(argv[++i], 1, LONG_MAX / 2, &opt.photons)) return usage_error("--photons needs a whole number of 1 or more, got '%s'", argv[i]);
        } else if (!strcmp(a, "--smoothing")) {
            if (parse_double(argv[++i], &x) || !(x > 0.0) || x > 1e6) return usage_error("--smoothing needs a positive number, got '%s'", argv[i]);
            opt.smoothing = x;
        } else if (!strcmp(a, "--seed")) {
            if (parse_count(argv[++i], 0, LONG_MAX, &n)) return usage_error("--seed needs a non-negative whole number, got '%s'", argv[i]);
            opt.seed = (unsigned long long)n;
        } else if (!strcmp(a, "--max-depth")) {
            if (parse_int(argv[++i], 1, 1000, &n)) return usage_error("--max-depth needs a whole number from 1 to 1000, got '%s'", argv[i]);
            opt.photon_depth = (int)n;
        } else {
            return usage_error("trace-photon knows --photon, --photons, --smoothing, --seed and --max-depth, got '%s'", a);
        }
    }
    if (!scene_path) return usage_error("%s", "trace-photon needs a scene file");
    if (photon < 0) return usage_error("%s", "trace-photon needs --photon I");
    if (load_any(scene_path, &scene, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", pds_error_string(&err));
        return 1;
    }
    if (pds_trace_photon(scene, &opt, photon, &tr, &err) != PDS_OK) {
        pds_scene_free(scene);
        return fail("%s", pds_error_string(&err));
    }
    printf("photon %ld: N = %.0f photons, s = %g (eqs. 5-6); finite differences with h = %.3e\n", photon, tr.photons,
           tr.smoothing, tr.step);
    for (k = 0; k < tr.count; k++) {
        const pds_trace_vertex *v = &tr.v[k];
        const pds_material *m = v->material >= 0 ? pds_scene_material(scene, v->material) : NULL;
        double rel;
        printf("vertex %d: %s", k, trace_event_name(v->event));
        if (m) printf(" on '%s' (triangle %ld)", m->name, v->triangle);
        printf("\n  x         (% .6e, % .6e, % .6e)\n  omega     (% .6e, % .6e, % .6e)\n", v->position.x,
               v->position.y, v->position.z, v->direction.x, v->direction.y, v->direction.z);
        rel = trace_row("Du x", v->dxdu, v->fd_dxdu, v->fd_valid);
        worst = rel > worst ? rel : worst;
        rel = trace_row("Dv x", v->dxdv, v->fd_dxdv, v->fd_valid);
        worst = rel > worst ? rel : worst;
        rel = trace_row("Dtheta w", v->dwdu, v->fd_dwdu, v->fd_valid);
        worst = rel > worst ? rel : worst;
        rel = trace_row("Dphi w", v->dwdv, v->fd_dwdv, v->fd_valid);
        worst = rel > worst ? rel : worst;
        printf("  footprint semi-axes %.6e, %.6e; area %.6e (eq. 4: pi/4 |Du x X Dv x|); flux %.4e %.4e %.4e W\n",
               v->major, v->minor, v->area, v->flux[0], v->flux[1], v->flux[2]);
        if (v->event == PDS_TRACE_LAND) landed = 1;
    }
    if (tr.count == 0) printf("(this photon carries no flux)\n");
    printf("trace-photon photon=%ld vertices=%d landed=%d max_rel_diff=%.3e\n", photon, tr.count, landed, worst);
    pds_trace_free(&tr);
    pds_scene_free(scene);
    return 0;
}

static int cmd_info(int argc, char **argv)
{
    pds_scene *scene = NULL;
    pds_scene_info info;
    pds_error err;
    const pds_camera *cam;
    const char *path = NULL;
    int i, r;
    for (i = 0; i < argc; i++) {
        const char *a = argv[i], *v;
        if (a[0] != '-' || a[1] == '\0') {
            if (path) return usage_error("%s", "info needs one scene or OBJ file");
            path = a;
        } else if (a[1] == 'D' && a[2] != '\0') {
            if ((r = add_define("-D", a + 2)) != 0) return r;
        } else if (arg_is(a, "-D") || arg_is(a, "--define") || arg_is(a, "--obj-material")) {
            if ((r = option_value(argc, argv, &i, &v)) != 0) return r;
            r = arg_is(a, "--obj-material") ? set_obj_material(NULL, NULL, "--obj-material", v) : add_define(a, v);
            if (r) return r;
        } else {
            static const char *const own[] = {"-D", "--define", "--obj-material", NULL};
            return unknown_option(a, 0, own);
        }
    }
    if (!path) return usage_error("%s", "info needs one scene or OBJ file");
    if (load_any(path, &scene, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", pds_error_string(&err));
        return 1;
    }
    pds_scene_get_info(scene, &info);
    cam = pds_scene_camera(scene);
    printf("file        %s\n", path);
    printf("triangles   %ld\nvertices    %ld\nshapes      %d\n", info.triangles, info.vertices, info.shapes);
    printf("bounds      (%g, %g, %g) .. (%g, %g, %g)\n", info.bounds_min.x, info.bounds_min.y, info.bounds_min.z,
           info.bounds_max.x, info.bounds_max.y, info.bounds_max.z);
    printf("camera      position (%g, %g, %g) look_at (%g, %g, %g) fov %g, %dx%d, %d spp", cam->position.x,
           cam->position.y, cam->position.z, cam->look_at.x, cam->look_at.y, cam->look_at.z, cam->fov_deg,
           cam->width, cam->height, cam->spp);
    if (cam->aperture > 0.0) {
        double dx = cam->look_at.x - cam->position.x, dy = cam->look_at.y - cam->position.y;
        double dz = cam->look_at.z - cam->position.z;
        printf(", thin lens of radius %g focused at %g", cam->aperture,
               cam->focus_distance > 0.0 ? cam->focus_distance : sqrt(dx * dx + dy * dy + dz * dz));
    }
    printf("\n");
    for (i = 0; i < info.materials; i++) {
        const pds_material *m = pds_scene_material(scene, i);
        printf("material    %-16s %s", m->name, material_type_name(m->type));
        if (m->type == PDS_MAT_DIELECTRIC) {
            printf(", ior %g (outside %g)", m->ior, m->outside_ior);
            if (m->dispersion != PDS_DISPERSION_NONE)
                printf(", n_F %.5f n_d %.5f n_C %.5f (486.1, 587.6, 656.3 nm)", pds_material_ior(m, 486.1),
                       pds_material_ior(m, 587.6), pds_material_ior(m, 656.3));
        }
        printf("\n");
    }
    for (i = 0; i < info.lights; i++) {
        const pds_light *l = pds_scene_light(scene, i);
        printf("light       %-11s power (%g, %g, %g) W", light_type_name(l->type), l->power[0], l->power[1], l->power[2]);
        if (l->type == PDS_LIGHT_MESH) printf(", %d triangles", l->triangle_count);
        if (l->area > 0) printf(", area %g", l->area);
        printf("\n");
    }
    for (i = 0; i < info.warnings; i++) printf("warning     %s\n", pds_scene_warning(scene, i));
    printf("memory      %.2f MB (geometry, BVH, light tables)\n", info.memory_bytes / 1048576.0);
    printf("info triangles=%ld vertices=%ld materials=%d lights=%d mesh_lights=%d shapes=%d "
           "degenerate_dropped=%ld warnings=%d memory_bytes=%lu bounds=%g,%g,%g:%g,%g,%g\n",
           info.triangles, info.vertices, info.materials, info.lights, info.mesh_lights, info.shapes,
           info.degenerate_dropped, info.warnings, (unsigned long)info.memory_bytes, info.bounds_min.x,
           info.bounds_min.y, info.bounds_min.z, info.bounds_max.x, info.bounds_max.y, info.bounds_max.z);
    pds_scene_free(scene);
    return 0;
}

/* Path-traced camera samples per second with one thread and with all,
   on a scene (default: the demo scene). */
static int bench_pt(int argc, char **argv)
{
    const char *path = argc >= 1 ? argv[0] : "scenes/demo.scene";
    pds_scene *scene = NULL;
    pds_error err;
    pds_options opt;
    pds_image img = {0, 0, NULL};
    pds_render_stats st;
    double rate[2];
    int threads[2], k;
    if (argc > 1) return usage_error("%s", "bench pt takes at most one scene");
    if (load_any(path, &scene, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", pds_error_string(&err));
        return 1;
    }
    threads[0] = 1;
    threads[1] = pds_cpu_count();
    /* best of three runs each: the figure describes the code, not what
       else the machine was doing */
    for (k = 0; k < 2; k++) {
        int rep;
        rate[k] = 0.0;
        for (rep = 0; rep < 3; rep++) {
            pds_options_default(&opt);
            opt.method = PDS_METHOD_PT;
            opt.threads = threads[k];
            opt.width = 256;
            opt.height = 192;
            opt.spp = 32;
            if (pds_render(scene, &opt, &img, &st, &err) != PDS_OK) {
                fprintf(stderr, "%s\n", pds_error_string(&err));
                pds_scene_free(scene);
                return 1;
            }
            pds_image_free(&img);
            if ((double)st.width * st.height * st.spp / st.time_total_s > rate[k])
                rate[k] = (double)st.width * st.height * st.spp / st.time_total_s;
        }
        threads[k] = st.threads;
    }
    pds_scene_free(scene);
    printf("bench pt scene=%s res=256x192 spp=32 samples_per_s_1=%.0f samples_per_s_%d=%.0f threads=%d speedup=%.2f\n",
           path, rate[0], threads[1], rate[1], threads[1], rate[1] / rate[0]);
    return 0;
}

/* Render a scene with PDS; returns 0 and fills *st, or prints the error. */
static int render_pds(pds_scene *scene, long photons, int threads, int width, pds_render_stats *st)
{
    pds_options opt;
    pds_image img = {0, 0, NULL};
    pds_error err;
    pds_options_default(&opt);
    opt.method = PDS_METHOD_PDS;
    opt.photons = photons;
    opt.threads = threads;
    opt.width = width;
    opt.height = width;
    opt.spp = 1;
    if (pds_render(scene, &opt, &img, st, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", pds_error_string(&err));
        return 1;
    }
    pds_image_free(&img);
    return 0;
}

/* --- bench isc ------------------------------------------------------------ */

/* The frame callback of bench isc: wall and CPU time at each frame's end. */
typedef struct isc_clock {
    double wall[64], cpu[64];
    int n;
} isc_clock;

static pds_status isc_clock_frame(void *user, int frame, const pds_image *img, pds_error *err)
{
    isc_clock *c = (isc_clock *)user;
    (void)img;
    (void)err;
    if (frame < 64) {
        c->wall[frame] = pds_time_now();
        c->cpu[frame] = (double)clock() / CLOCKS_PER_SEC;
        c->n = frame + 1;
    }
    return PDS_OK;
}

/* Wyman and Davis 2006, Table 1: frames per second at 512x512 (GeForce
   7800 GTX), static then dynamic lighting, points, quads, eye gather,
   light gather; by photon count 512^2, 1024^2, 2048^2 (0: "n/a"). */
static const double paper_octahedron[3][8] = {{159.1, 38.1, 53.9, 61.1, 38.9, 1.5, 33.7, 18.8},
                                              {58.4, 11.4, 35.1, 60.8, 12.4, 0.4, 15.3, 8.3},
                                              {18.1, 0.0, 14.7, 60.5, 2.7, 0.0, 4.8, 2.6}};
static const double paper_ring[3][8] = {{151.2, 39.6, 52.8, 59.3, 40.3, 1.5, 34.7, 18.9},
                                        {57.6, 11.7, 35.4, 59.0, 12.5, 0.4, 16.0, 8.4},
                                        {18.8, 0.0, 15.2, 58.3, 2.8, 0.0, 5.0, 2.6}};

/* Frames per second of an isc animation of n frames at 512x512 with
   res^2 photons: wall and CPU time of frames 1..n-1 (frame 0, which
   traces the eye buffer, and with static lighting the photon buffer, is
   timed apart as *first_s). 0 on success. */
static int isc_fps(const pds_scene *scene, int gather, int res, int threads, int still_light, int n, double *fps,
                   double *cpu_per_frame, double *first_s)
{
    pds_options opt;
    pds_render_stats st;
    pds_error err;
    isc_clock clk;
    double t0;
    pds_options_default(&opt);
    opt.method = PDS_METHOD_ISC;
    opt.isc_gather = (pds_isc_gather)gather;
    opt.light_resolution = res;
    opt.width = opt.height = 512;
    opt.threads = threads;
    opt.orbit = still_light ? PDS_ORBIT_CAMERA : PDS_ORBIT_LIGHT;
    opt.static_lighting = still_light;
    clk.n = 0;
    clk.wall[0] = 0.0;
    t0 = pds_time_now();
    if (pds_render_frames(scene, &opt, n, isc_clock_frame, &clk, &st, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", pds_error_string(&err));
        return 1;
    }
    *fps = (n - 1) / (clk.wall[n - 1] - clk.wall[0]);
    *cpu_per_frame = (clk.cpu[n - 1] - clk.cpu[0]) / (n - 1);
    *first_s = clk.wall[0] - t0;
    return 0;
}

/* Image-space caustics' frames per second at 512x512 with 512^2, 1024^2
   and 2048^2 photons, for each gather, in the paper's two settings:
   dynamic lighting, the light turning 2 degrees a frame (photons, gathers
   and direct light every frame; the camera stands still, so the eye
   buffer is traced once), and static lighting, the camera turning 2
   degrees a frame about a still light (the photon buffer and the light
   map traced once; eye buffer, direct light, projections and the eye's
   gathers every frame). Beside them the paper's Table 1 and PDS's time
   for one 512x512 image with as many photons (1 sample per pixel). */
static int bench_isc(int argc, char **argv)
{
    static const char *const gname[4] = {"points", "quads", "eye", "light"};
    static const int frames_for[3] = {13, 7, 4};
    const char *path = argc >= 1 ? argv[0] : "scenes/ring_octahedron.scene";
    pds_scene *scene = NULL;
    pds_error err;
    int r, g, threads = pds_cpu_count();
    if (argc > 1) return usage_error("%s", "bench isc takes at most one scene");
    if (load_any(path, &scene, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", pds_error_string(&err));
        return 1;
    }
    for (r = 0; r < 3; r++) {
        int res = 512 << r;
        pds_render_stats st;
        double pds_s;
        if (render_pds(scene, (long)res * res, threads, 512, &st)) {
            pds_scene_free(scene);
            return 1;
        }
        pds_s = st.time_total_s;
        for (g = 0; g < 4; g++) {
            double fps[2], cpu[2], first[2];
            char paper[96];
            int n = frames_for[r], k;
            for (k = 0; k < 2; k++)
                if (isc_fps(scene, g, res, threads, k, n, &fps[k], &cpu[k], &first[k])) {
                    pds_scene_free(scene);
                    return 1;
                }
            if (paper_ring[r][g] > 0.0)
                snprintf(paper, sizeof paper, "paper_fps_dynamic=%g/%g paper_fps_static=%g/%g",
                         paper_octahedron[r][4 + g], paper_ring[r][4 + g], paper_octahedron[r][g], paper_ring[r][g]);
            else
                snprintf(paper, sizeof paper, "paper_fps_dynamic=n/a paper_fps_static=n/a");
            printf("bench isc gather=%s photons=%d^2 res=512x512 frames=%d fps=%.2f fps_static=%.2f "
                   "cpu_s_per_frame=%.4f cpu_s_per_frame_static=%.4f first_s=%.3f first_s_static=%.3f threads=%d "
                   "%s pds_s=%.3f\n",
                   gname[g], res, n - 1, fps[0], fps[1], cpu[0], cpu[1], first[0], first[1], threads, paper, pds_s);
            fflush(stdout);
        }
    }
    pds_scene_free(scene);
    return 0;
}

/* Caustic photons emitted, traced and splatted per second (photon pass
   only), one thread and all threads. */
static int bench_photons(int argc, char **argv)
{
    const char *path = argc >= 1 ? argv[0] : "scenes/refraction.scene";
    pds_scene *scene = NULL;
    pds_error err;
    pds_render_stats st[2];
    int k, threads[2];
    if (argc > 1) return usage_error("%s", "bench photons takes at most one scene");
    if (load_any(path, &scene, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", pds_error_string(&err));
        return 1;
    }
    threads[0] = 1;
    threads[1] = pds_cpu_count();
    for (k = 0; k < 2; k++) {
        int rep;
        for (rep = 0; rep < 3; rep++) {
            pds_render_stats run;
            if (render_pds(scene, 400000, threads[k], 256, &run)) {
                pds_scene_free(scene);
                return 1;
            }
            if (rep == 0 || run.time_photons_s < st[k].time_photons_s) st[k] = run;
        }
    }
    pds_scene_free(scene);
    printf("bench photons scene=%s photons=%ld splatted=%ld photons_per_s_1=%.0f photons_per_s_%d=%.0f speedup=%.2f\n",
           path, st[0].photons, st[0].splatted, st[0].photons / st[0].time_photons_s, st[1].threads,
           st[1].photons / st[1].time_photons_s, st[0].time_photons_s / st[1].time_photons_s);
    return 0;
}

/* The photon pass of PDS (default settings) against photon mapping's
   (tracing, map build and k-nearest gather; k 50) at equal photons
   (--photons N, default 400,000), one thread, caustics only, 256 pixels
   wide at the scene's aspect and spp: the best of three runs of each, and
   their ratio; and PDS with one scale for every pixel (--no-pass-select:
   no second scale, no validation's photons), the splats alone. PDS's eye
   rounds are held to one (the default's at 400,000 on the shipped
   scenes), so that both passes splat into or gather at one eye pass. */
static int bench_pass(int argc, char **argv)
{
    static const char *defaults[] = {"scenes/refraction.scene", "scenes/reflection.scene"};
    const char *scenes[64], **paths = scenes, *v;
    int n = 0, i, rc;
    long photons = 400000;
    for (i = 0; i < argc; i++) {
        if (arg_is(argv[i], "--photons")) {
            if ((rc = option_value(argc, argv, &i, &v))) return rc;
            if (parse_count(v, 1000, 100000000L, &photons) != 0)
                return usage_error("bench pass: --photons needs a count from 1000 to 1e8, got '%s'", v);
        } else if (argv[i][0] == '-' && argv[i][1] != '\0') {
            return usage_error("bench pass: unknown option '%s' (--photons)", argv[i]);
        } else if (n == 64) {
            return usage_error("%s", "bench pass takes at most 64 scenes");
        } else {
            scenes[n++] = argv[i];
        }
    }
    if (n == 0) {
        paths = defaults;
        n = 2;
    }
    printf("bench pass photons=%ld threads=1 (photon pass seconds, best of 3)\n", photons);
    for (i = 0; i < n; i++) {
        pds_scene *scene = NULL;
        pds_error err;
        double best[3] = {0.0, 0.0, 0.0};
        long splatted = 0;
        int k, rep;
        if (load_any(paths[i], &scene, &err) != PDS_OK) {
            fprintf(stderr, "%s\n", pds_error_string(&err));
            return 1;
        }
        for (rep = 0; rep < 3; rep++) {
            for (k = 0; k < 3; k++) {
                pds_options opt;
                pds_image img = {0, 0, NULL};
                pds_render_stats st;
                const pds_camera *cam = pds_scene_camera(scene);
                pds_options_default(&opt);
                opt.method = k == 1 ? PDS_METHOD_PM : PDS_METHOD_PDS;
                if (k == 2) opt.pass_select = 0;
                opt.paths = PDS_PATHS_CAUSTICS_ONLY;
                opt.photons = photons;
                opt.eye_rounds = 1;
                opt.threads = 1;
                opt.width = 256;
                opt.height = cam->height * 256 / cam->width > 0 ? cam->height * 256 / cam->width : 1;
                if (pds_render(scene, &opt, &img, &st, &err) != PDS_OK) {
                    fprintf(stderr, "%s\n", pds_error_string(&err));
                    pds_scene_free(scene);
                    return 1;
                }
                pds_image_free(&img);
                if (rep == 0 || st.time_photons_s < best[k]) best[k] = st.time_photons_s;
                if (k == 1) splatted = st.splatted;
            }
        }
        printf("bench pass scene=%s landed=%ld pds_s=%.3f pm_s=%.3f pds_over_pm=%.2f pds_one_scale_s=%.3f "
               "one_scale_over_pm=%.2f\n",
               paths[i], splatted, best[0], best[1], best[0] / (best[1] > 0.0 ? best[1] : 1e-9), best[2],
               best[2] / (best[1] > 0.0 ? best[1] : 1e-9));
        pds_scene_free(scene);
    }
    return 0;
}

/* Peak memory of a PDS render at 1e5 and at 1e7 photons. */
static int bench_memory(int argc, char **argv)
{
    const char *path = argc >= 1 ? argv[0] : "scenes/refraction.scene";
    pds_scene *scene = NULL;
    pds_error err;
    pds_render_stats a, b;
    if (argc > 1) return usage_error("%s", "bench memory takes at most one scene");
    if (load_any(path, &scene, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", pds_error_string(&err));
        return 1;
    }
    long rss_a = 0, rss_b = 0; /* peak resident memory, KiB (not measured on Windows) */
#ifndef _WIN32
    struct rusage ru;
#endif
    if (render_pds(scene, 100000, 0, 256, &a)) {
        pds_scene_free(scene);
        return 1;
    }
#ifndef _WIN32
    getrusage(RUSAGE_SELF, &ru);
    rss_a = ru.ru_maxrss;
#endif
    if (render_pds(scene, 10000000, 0, 256, &b)) {
        pds_scene_free(scene);
        return 1;
    }
#ifndef _WIN32
    getrusage(RUSAGE_SELF, &ru);
    rss_b = ru.ru_maxrss;
#endif
    pds_scene_free(scene);
    /* ru_maxrss is the process's peak so far (KiB on Linux): if the second,
       100 times larger render needed more, the peak would have grown */
    printf("bench memory scene=%s render_bytes_1e5=%lu render_bytes_1e7=%lu peak_rss_kib_after_1e5=%ld "
           "peak_rss_kib_after_1e7=%ld growth=%.2f%% time_1e7=%.1f\n",
           path, (unsigned long)a.memory_bytes, (unsigned long)b.memory_bytes, rss_a, rss_b,
           100.0 * ((double)rss_b / (double)rss_a - 1.0), b.time_total_s);
    return 0;
}

/* --- bench budget --------------------------------------------------------- */

static int cmp_double(const void *a, const void *b);

/* Does each photon method hold its --time? For each scene, size (square,
   W x W) and budget T, render each method (caustics only, the scene's
   spp, all threads) `runs` times and print the median, least and most of
   landed / T, landed being the time the budget governs: the whole render,
   eye pass included (the eye pass is printed beside it). "paper" is the paper's
   PDS (--smoothing 12, not progressive); gi is Jensen's two-pass method,
   whose maps, eye pass and caustic pass (pds) the budget governs. The last line counts the
   cases whose median lands within 15% of T. */
typedef struct bench_budget_method {
    const char *name;
    pds_method method;
    int progressive;
} bench_budget_method;

static int bench_budget_list(const char *text, double *out, int max, double lo, double hi)
{
    int n = 0;
    const char *p = text;
    while (*p) {
        char *end;
        double v = strtod(p, &end);
        if (end == p || !(v >= lo && v <= hi) || n == max || (*end != ',' && *end != '\0')) return -1;
        out[n++] = v;
        p = *end == ',' ? end + 1 : end;
    }
    return n;
}

static int bench_budget(int argc, char **argv)
{
    static const bench_budget_method all[] = {
        {"pds", PDS_METHOD_PDS, 1}, {"paper", PDS_METHOD_PDS, 0}, {"pm", PDS_METHOD_PM, 0},
        {"pdm", PDS_METHOD_PDM, 0}, {"splat", PDS_METHOD_SPLAT, 0}, {"ppm", PDS_METHOD_PPM, 0},
        {"spm", PDS_METHOD_SPM, 0}, {"gi", PDS_METHOD_GI, 0},
    };
    static const char *default_scenes[] = {"scenes/refraction.scene", "scenes/reflection.scene"};
    double times[8] = {1, 3}, sizes[4] = {256, 512}, runs_d = 3;
    int ntimes = 2, nsizes = 2, runs = 3, nscenes = 0, i, cases = 0, held = 0;
    unsigned use = 0x7Fu; /* all but gi */
    const char *scenes[64];
    for (i = 0; i < argc; i++) {
        if (!strcmp(argv[i], "--times") && i + 1 < argc) {
            if ((ntimes = bench_budget_list(argv[++i], times, 8, 0.01, 3600)) < 1)
                return usage_error("bench budget: --times needs up to 8 seconds from 0.01 to 3600, got '%s'", argv[i]);
        } else if (!strcmp(argv[i], "--sizes") && i + 1 < argc) {
            if ((nsizes = bench_budget_list(argv[++i], sizes, 4, 8, 4096)) < 1)
                return usage_error("bench budget: --sizes needs up to 4 widths from 8 to 4096, got '%s'", argv[i]);
        } else if (!strcmp(argv[i], "--runs") && i + 1 < argc) {
            if (bench_budget_list(argv[++i], &runs_d, 1, 1, 99) != 1 || runs_d != floor(runs_d))
                return usage_error("bench budget: --runs needs a whole number from 1 to 99, got '%s'", argv[i]);
            runs = (int)runs_d;
        } else if (!strcmp(argv[i], "--methods") && i + 1 < argc) {
            char list[256], *tok;
            snprintf(list, sizeof list, "%s", argv[++i]);
            use = 0;
            for (tok = strtok(list, ","); tok; tok = strtok(NULL, ",")) {
                size_t k;
                for (k = 0; k < sizeof all / sizeof all[0] && strcmp(all[k].name, tok); k++) {}
                if (k == sizeof all / sizeof all[0])
                    return usage_error("bench budget: unknown method '%s' (pds, paper, pm, pdm, splat, ppm, spm, gi)", tok);
                use |= 1u << k;
            }
        } else if (argv[i][0] == '-') {
            return usage_error("bench budget: unknown option '%s' (--times, --sizes, --runs, --methods)", argv[i]);
        } else if (nscenes < 64) {
            scenes[nscenes++] = argv[i];
        } else {
            return usage_error("%s", "bench budget takes at most 64 scenes");
        }
    }
    if (nscenes == 0) {
        nscenes = 2;
        scenes[0] = default_scenes[0];
        scenes[1] = default_scenes[1];
    }
    printf("bench budget runs=%d (landed/T: the render over its --time T; median, least, most)\n", runs);
    for (i = 0; i < nscenes; i++) {
        pds_scene *scene = NULL;
        pds_error err;
        int si, ti;
        size_t k;
        if (load_any(scenes[i], &scene, &err) != PDS_OK) {
            fprintf(stderr, "%s\n", pds_error_string(&err));
            return 1;
        }
        for (si = 0; si < nsizes; si++)
            for (ti = 0; ti < ntimes; ti++)
                for (k = 0; k < sizeof all / sizeof all[0]; k++) {
                    double landed[99], eye[99];
                    long photons = 0;
                    int r;
                    if (!(use & (1u << k))) continue;
                    for (r = 0; r < runs; r++) {
                        pds_options opt;
                        pds_image img = {0, 0, NULL};
                        pds_render_stats st;
                        pds_options_default(&opt);
                        opt.method = all[k].method;
                        opt.progressive = all[k].progressive;
                        opt.paths = PDS_PATHS_CAUSTICS_ONLY;
                        opt.width = opt.height = (int)sizes[si];
                        opt.time_s = times[ti];
                        if (pds_render(scene, &opt, &img, &st, &err) != PDS_OK) {
                            fprintf(stderr, "%s (bench budget %s)\n", pds_error_string(&err), all[k].name);
                            pds_scene_free(scene);
                            return 1;
                        }
                        pds_image_free(&img);
                        landed[r] = st.time_total_s / times[ti];
                        eye[r] = st.time_eye_s;
                        photons = st.photons;
                    }
                    qsort(landed, (size_t)runs, sizeof landed[0], cmp_double);
                    qsort(eye, (size_t)runs, sizeof eye[0], cmp_double);
                    cases++;
                    held += fabs(landed[runs / 2] - 1.0) <= 0.15;
                    printf("bench budget scene=%s res=%dx%d T=%g method=%s landed_over_T=%.3f min=%.3f max=%.3f "
                           "eye_s=%.3f photons=%ld\n",
                           scenes[i], (int)sizes[si], (int)sizes[si], times[ti], all[k].name, landed[runs / 2],
                           landed[0], landed[runs - 1], eye[runs / 2], photons);
                    fflush(stdout);
                }
        pds_scene_free(scene);
    }
    printf("bench budget cases=%d within_15_percent=%d\n", cases, held);
    return 0;
}

static int cmd_bench(int argc, char **argv)
{
    pds_error err;
    if (argc < 1) return usage_error("%s", "bench needs a benchmark name (rays)");
    if (!strcmp(argv[0], "rays")) {
        pds_bench_rays_result r;
        long n = 1000000;
        if (argc < 2 || argc > 3) return usage_error("%s", "bench rays needs MESH.obj (or a scene) [RAYS]");
        if (argc == 3 && parse_count(argv[2], 1, 100000000, &n))
            return usage_error("bench rays: RAYS must be a whole number from 1 to 1e8, got '%s'", argv[2]);
        if (pds_bench_rays(argv[1], n, &r, &err) != PDS_OK) {
            fprintf(stderr, "%s\n", pds_error_string(&err));
            return 1;
        }
        printf("bench rays tris=%ld build_s=%.4f build_mtris=%.2f rays=%ld primary_mrays=%.3f random_mrays=%.3f "
               "primary_hits=%ld random_hits=%ld\n",
               r.triangles, r.build_s, r.build_s > 0 ? r.triangles / r.build_s * 1e-6 : 0.0, r.rays,
               r.primary_mrays, r.random_mrays, r.primary_hits, r.random_hits);
        return 0;
    }
    if (!strcmp(argv[0], "pt")) return bench_pt(argc - 1, argv + 1);
    if (!strcmp(argv[0], "photons")) return bench_photons(argc - 1, argv + 1);
    if (!strcmp(argv[0], "pass")) return bench_pass(argc - 1, argv + 1);
    if (!strcmp(argv[0], "memory")) return bench_memory(argc - 1, argv + 1);
    if (!strcmp(argv[0], "isc")) return bench_isc(argc - 1, argv + 1);
    if (!strcmp(argv[0], "budget")) return bench_budget(argc - 1, argv + 1);
    if (!strcmp(argv[0], "filter")) {
        pds_bench_filter_result r;
        if (pds_bench_filter(2000000, &r, &err) != PDS_OK) {
            fprintf(stderr, "%s\n", pds_error_string(&err));
            return 1;
        }
        printf("bench filter filters=%ld eq12_mps=%.2f general_mps=%.2f speedup=%.2f max_rel_diff=%.1e\n", r.filters,
               r.eq12_mps, r.general_mps, r.eq12_mps / r.general_mps, r.max_rel_diff);
        return 0;
    }
    if (!strcmp(argv[0], "kdtree")) {
        pds_bench_kdtree_result r;
        if (pds_bench_kdtree(1000000, &r, &err) != PDS_OK) {
            fprintf(stderr, "%s\n", pds_error_string(&err));
            return 1;
        }
        printf("bench kdtree points=%ld build_s=%.3f range_mqps=%.3f found_per_query=%.1f knn32_mqps=%.3f\n", r.points,
               r.build_s, r.range_mqps, r.found_per_query, r.knn_mqps);
        return 0;
    }
    {
        static const char *const names[] = {"rays", "pt", "photons", "pass", "memory", "filter", "kdtree", "isc",
                                            "budget"};
        char hint[256];
        suggestion sug;
        size_t i;
        suggest_init(&sug, argv[0]);
        for (i = 0; i < sizeof names / sizeof names[0]; i++) suggest_consider(&sug, names[i]);
        if (!suggest_text(&sug, hint, sizeof hint)[0])
            snprintf(hint, sizeof hint, " (rays, pt, photons, pass, memory, filter, kdtree, isc, budget)");
        return usage_error("unknown benchmark '%s'%s", argv[0], hint);
    }
}


/* ===================================================================== */
/* The comparison harness: pds sweep and pds race                        */
/* ===================================================================== */
/* Both render a scene several times with the same options but one, compare
   every image with a reference (RMSE of the linear values, SSIM of the
   sRGB luminance: pds_image_compare) and write a folder of results. The
   images are kept in memory until every render has succeeded; only then is
   the folder created and filled, each file written under a temporary name
   and renamed into place. */

#define MAX_SWEEP_VALUES 256
#define MAX_RACE_METHODS 32

/* A growing text buffer for the CSV, SVG and HTML files. */
typedef struct sbuf {
    char *s;
    size_t len, cap;
    int nomem;
} sbuf;

static void sb_printf(sbuf *b, const char *fmt, ...) PRINTF_LIKE(2, 3);
static void sb_printf(sbuf *b, const char *fmt, ...)
{
    va_list ap;
    int n;
    if (b->nomem) return;
    va_start(ap, fmt);
    n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (n < 0) {
        b->nomem = 1;
        return;
    }
    if (b->len + (size_t)n + 1 > b->cap) {
        size_t cap = b->cap ? b->cap : 4096;
        char *p;
        while (cap < b->len + (size_t)n + 1) cap *= 2;
        p = (char *)realloc(b->s, cap);
        if (!p) {
            b->nomem = 1;
            return;
        }
        b->s = p;
        b->cap = cap;
    }
    va_start(ap, fmt);
    vsnprintf(b->s + b->len, b->cap - b->len, fmt, ap);
    va_end(ap);
    b->len += (size_t)n;
}

/* Text for HTML and SVG: & < > " ' escaped. */
static void sb_xml(sbuf *b, const char *s)
{
    for (; *s; s++) {
        switch (*s) {
        case '&': sb_printf(b, "&amp;"); break;
        case '<': sb_printf(b, "&lt;"); break;
        case '>': sb_printf(b, "&gt;"); break;
        case '"': sb_printf(b, "&quot;"); break;
        case '\'': sb_printf(b, "&#39;"); break;
        default: sb_printf(b, "%c", *s); break;
        }
    }
}

/* A CSV field (RFC 4180): quoted when it holds a comma, quote or newline. */
static void sb_csv(sbuf *b, const char *s)
{
    if (!strpbrk(s, ",\"\r\n")) {
        sb_printf(b, "%s", s);
        return;
    }
    sb_printf(b, "\"");
    for (; *s; s++) sb_printf(b, *s == '"' ? "\"\"" : "%c", *s);
    sb_printf(b, "\"");
}

static int join_path(char *out, size_t n, const char *dir, const char *name)
{
    int len = snprintf(out, n, "%s/%s", dir, name);
    if (len < 0 || (size_t)len >= n) return fail("%s/%s: path too long", dir, name);
    return 0;
}

/* Write the buffer to dir/name under a temporary name, then rename it. */
static int write_text(const char *dir, const char *name, const sbuf *b)
{
    char path[PATH_MAX_LEN];
    if (join_path(path, sizeof path, dir, name)) return 1;
    if (b->nomem) return fail("%s: out of memory", path);
    return write_text_file(0, path, b->s ? b->s : "", b->len);
}

static int write_image(const char *dir, const char *name, const pds_image *img, double exposure)
{
    char path[PATH_MAX_LEN];
    pds_error err;
    pds_status st;
    if (join_path(path, sizeof path, dir, name) || temp_arm(0, path)) return 1;
    st = image_write(path, img, exposure, NULL, &err);
    temp_disarm(0);
    return st == PDS_OK ? 0 : fail("%s", pds_error_string(&err));
}

/* Before any render: fail now if the folder could not be made or written
   later. The folder, or its nearest existing ancestor, must be a folder we
   may write in. 0, or 1 after printing "DIR: why". */
static int check_out_dir(const char *dir)
{
    char path[PATH_MAX_LEN];
    struct stat sb;
    if (!dir[0]) return fail("%s", "the output folder name is empty");
    if (strlen(dir) >= sizeof path) return fail("%s: path too long", dir);
    strcpy(path, dir);
    for (;;) {
        char *slash;
        size_t n;
        if (stat(path, &sb) == 0) {
            if (!S_ISDIR(sb.st_mode)) {
                if (!strcmp(path, dir)) return fail("%s: exists and is not a folder", dir);
                return fail("%s: cannot create it: %s is not a folder", dir, path);
            }
            if (access(path, W_OK | X_OK) != 0) return fail("%s: cannot write in %s: %s", dir, path, strerror(errno));
            return 0;
        }
        if (errno != ENOENT && errno != ENOTDIR) return fail("%s: %s", dir, strerror(errno));
        n = strlen(path);
        while (n > 1 && path[n - 1] == '/') path[--n] = '\0';
        slash = strrchr(path, '/');
        if (!slash) strcpy(path, ".");
        else if (slash == path) path[1] = '\0';
        else *slash = '\0';
    }
}

/* mkdir -p */
static int make_dirs(const char *dir)
{
    char path[PATH_MAX_LEN];
    size_t i, n = strlen(dir);
    struct stat sb;
    if (n >= sizeof path) return fail("%s: path too long", dir);
    strcpy(path, dir);
    for (i = 1; i <= n; i++) {
        char c = path[i];
        if (c != '/' && c != '\0') continue;
        path[i] = '\0';
        if (mkdir(path, 0777) != 0 && errno != EEXIST) return fail("%s: cannot create %s: %s", dir, path, strerror(errno));
        path[i] = c;
    }
    if (stat(dir, &sb) != 0 || !S_ISDIR(sb.st_mode)) return fail("%s: cannot create the folder", dir);
    return 0;
}

/* A value as part of a file name: letters, digits, '.', '+' and '-' kept,
   anything else '_'. */
static void file_safe(const char *s, char *out, size_t n)
{
    size_t i;
    for (i = 0; s[i] && i + 1 < n; i++) {
        char ch = s[i];
        int ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '.' ||
                 ch == '+' || ch == '-';
        out[i] = ok ? ch : '_';
    }
    out[i] = '\0';
}

/* Load the scene and the reference, whose size must be the renders' size.
   0, or 1 after printing the error (nothing left to free). */
static int load_scene_and_ref(const char *cmd, const char *scene_path, const char *ref_path, const pds_options *opt,
                              pds_scene **scene, pds_image *ref)
{
    static pds_image_meta meta; /* 26 KB */
    pds_error err;
    const pds_camera *cam;
    int w, h;
    if (load_any(scene_path, scene, &err) != PDS_OK) return fail("%s", pds_error_string(&err));
    if (pds_image_read(ref_path, ref, &meta, &err) != PDS_OK) {
        pds_scene_free(*scene);
        *scene = NULL;
        return fail("%s", pds_error_string(&err));
    }
    cam = pds_scene_camera(*scene);
    w = opt->width > 0 ? opt->width : cam->width;
    h = opt->height > 0 ? opt->height : cam->height;
    if (ref->width != w || ref->height != h) {
        fail("%s: the reference is %dx%d but the renders are %dx%d (give --res %dx%d or a reference of that size)",
             ref_path, ref->width, ref->height, w, h, ref->width, ref->height);
        pds_image_free(ref);
        pds_scene_free(*scene);
        *scene = NULL;
        return 1;
    }
    warn_kind_mismatch(cmd, "the renders", paths_kind(opt->paths), ref_path, pds_image_meta_get(&meta, PDS_META_KIND));
    return 0;
}

/* Render with c and compare with ref; 0, or 1 after printing the error
   followed by context ("(sweep k=50)"), which also labels the progress bar. */
/* --- keeping finished entries ----------------------------------------------
   sweep and race keep each entry the moment it is rendered in
   DIR/entries/: LABEL.pfm, its image, and LABEL.txt, one line: what the
   entry is (KEY: its method, options and budget) and, after a tab, what
   came of it (the stats the pages and CSV files show, then any fields of
   the command's own). Run again with --resume, the command loads every
   entry whose files are there and say the same KEY, and renders only the
   others; the image and its stats are the ones first made, so the CSV and
   the page come out as if it had run in one go. An interrupted sweep or
   race thus loses no finished entry. */

/* Keep a finished entry; extra: the command's own fields (tab-separated,
   no newline). 0, or 1 after saying why not. */
static int keep_entry(const char *dir, const char *label, const char *key, const pds_image *img,
                      const pds_render_stats *s, const char *extra)
{
    char sub[PATH_MAX_LEN], name[160];
    sbuf line = {NULL, 0, 0, 0};
    int bad;
    if (snprintf(sub, sizeof sub, "%s/entries", dir) >= (int)sizeof sub) return fail("%s: path too long", dir);
    if (make_dirs(sub)) return 1;
    snprintf(name, sizeof name, "%s.pfm", label);
    if (write_image(sub, name, img, 0.0)) return 1;
    sb_printf(&line, "%s\t%ld %d %d %lu %.17g %.17g %.17g %.17g %.17g\t%s\n", key, s->photons, s->spp, s->passes,
              (unsigned long)s->map_bytes, s->time_total_s, s->time_eye_s, s->time_photons_s, s->time_map_s,
              s->time_gather_s, extra);
    snprintf(name, sizeof name, "%s.txt", label);
    bad = write_text(sub, name, &line);
    free(line.s);
    return bad;
}

/* Load a kept entry if DIR/entries holds one with this key: 1 loaded
   (image, stats, extra fields and the metrics against ref), 0 not there
   (or another entry's), -1 after printing an error. */
static int load_entry(const char *dir, const char *label, const char *key, const pds_image *ref,
                      const pds_image *mask, pds_image *img, pds_render_stats *s, pds_metrics *m, char *extra,
                      size_t extra_n)
{
    char path[PATH_MAX_LEN], text[2048], *tab, *rest;
    unsigned long map_bytes;
    pds_error err;
    FILE *fp;
    size_t len;
    if (snprintf(path, sizeof path, "%s/entries/%s.txt", dir, label) >= (int)sizeof path) return 0;
    fp = fopen(path, "r");
    if (!fp) return 0;
    len = fread(text, 1, sizeof text - 1, fp);
    fclose(fp);
    text[len] = '\0';
    if (len && text[len - 1] == '\n') text[len - 1] = '\0';
    tab = strchr(text, '\t');
    if (!tab || (size_t)(tab - text) != strlen(key) || strncmp(text, key, strlen(key)) != 0) return 0;
    rest = strchr(tab + 1, '\t');
    if (!rest) return 0;
    *rest++ = '\0';
    memset(s, 0, sizeof *s);
    if (sscanf(tab + 1, "%ld %d %d %lu %lf %lf %lf %lf %lf", &s->photons, &s->spp, &s->passes, &map_bytes,
               &s->time_total_s, &s->time_eye_s, &s->time_photons_s, &s->time_map_s, &s->time_gather_s) != 9)
        return 0;
    s->map_bytes = (size_t)map_bytes;
    snprintf(extra, extra_n, "%s", rest);
    snprintf(path, sizeof path, "%s/entries/%s.pfm", dir, label);
    if (pds_image_read_pfm(path, img, &err) != PDS_OK || pds_image_compare_masked(img, ref, mask, m, &err) != PDS_OK) {
        pds_image_free(img);
        fail("%s (kept entry %s; remove it to render it again)", pds_error_string(&err), label);
        return -1;
    }
    s->width = img->width;
    s->height = img->height;
    return 1;
}

/* What an entry is: what --resume compares (budget: race's, or ""), with
   the scene's content hash (a scene edited, or loaded with other -D
   values, since the entry was kept is another scene). */
static void entry_key(const pds_scene *scene, const pds_options *o, const char *budget, char *out, size_t n)
{
    char params[256];
    format_params(o, params, sizeof params);
    /* the readable part, then a hash of every option that may change the
       image (gi's global map, spm's streams, isc's light buffer, ...) */
    snprintf(out, n, "method=%s budget=%s seed=%llu res=%dx%d spp=%d photons=%ld passes=%d paths=%d depth=%d,%d "
             "time=%.17g%s options=%016llx scene=%016llx", method_name(o->method), budget, o->seed, o->width,
             o->height, o->spp, o->photons, o->passes, (int)o->paths, o->max_depth, o->photon_depth, o->time_s, params,
             pds_options_hash(o), pds_scene_hash(scene));
}

static int render_and_compare(const pds_scene *scene, const run_cfg *c, const pds_image *ref, const pds_image *mask,
                              pds_image *img,
                              pds_render_stats *st, pds_metrics *m, const char *context)
{
    pds_error err;
    pds_status s;
    if (c->progress) progress_begin(context, c->opt.time_s);
    s = pds_render(scene, &c->opt, img, st, &err);
    if (c->progress) progress_end(s == PDS_OK);
    if (s == PDS_OK) s = pds_image_compare_masked(img, ref, mask, m, &err);
    if (s != PDS_OK) return fail("%s (%s)", pds_error_string(&err), context);
    return 0;
}

/* ------------------------------------------------------------- sweep plot */

/* A round step (1, 2 or 5 x 10^n) for about `target` intervals over span. */
static double nice_step(double span, int target)
{
    double raw = span / target, mag, f;
    if (!(raw > 0.0) || !isfinite(raw)) return 1.0;
    mag = pow(10.0, floor(log10(raw)));
    f = raw / mag;
    return (f < 1.5 ? 1.0 : f < 3.0 ? 2.0 : f < 7.0 ? 5.0 : 10.0) * mag;
}

/* An axis [lo, hi] on multiples of a round step that holds [mn, mx]; a
   single value gets room around it; nonneg keeps lo at 0 or above. */
static void nice_range(double mn, double mx, int nonneg, double *lo, double *hi, double *step)
{
    if (!(mx - mn > 1e-9 * (fabs(mx) + fabs(mn)))) {
        double pad = mx != 0.0 ? fabs(mx) * 0.1 : 0.1;
        mn -= pad;
        mx += pad;
    }
    *step = nice_step(mx - mn, 5);
    *lo = floor(mn / *step) * *step;
    *hi = ceil(mx / *step) * *step;
    if (nonneg && *lo < 0.0) *lo = 0.0;
}

/* A tick label with as many decimals as the step needs. */
static void tick_text(double v, double step, char *buf, size_t n)
{
    int decimals = step >= 1.0 ? 0 : (int)ceil(-log10(step) - 1e-9);
    if (fabs(v) < step * 1e-6) v = 0.0; /* no "-0.00" */
    snprintf(buf, n, "%.*f", decimals, v);
}

typedef struct sweep_row {
    const char *value; /* as given on the command line */
    double x;
    pds_image img;
    pds_render_stats st;
    pds_metrics m;
} sweep_row;

typedef struct plot_frame {
    double left, right, top, bottom, pad;
    int logx;
    double xmin, xmax;
    int logy; /* sweep: the RMSE axis is logarithmic */
} plot_frame;

static double plot_x(const plot_frame *f, double x)
{
    double a = f->logx ? log10(x) : x, lo = f->logx ? log10(f->xmin) : f->xmin, hi = f->logx ? log10(f->xmax) : f->xmax;
    if (!(hi > lo)) return 0.5 * (f->left + f->right);
    return f->left + f->pad + (a - lo) / (hi - lo) * (f->right - f->left - 2.0 * f->pad);
}

static double plot_y(const plot_frame *f, double v, double lo, double hi)
{
    return f->bottom - (v - lo) / (hi - lo) * (f->bottom - f->top);
}

/* The same on a logarithmic axis (v, lo, hi > 0). */
static double plot_logy(const plot_frame *f, double v, double lo, double hi)
{
    return plot_y(f, log10(v), log10(lo), log10(hi));
}

/* A logarithmic axis [lo, hi] on whole decades that holds [mn, mx] (> 0). */
static void log_range(double mn, double mx, double *lo, double *hi)
{
    *lo = pow(10.0, floor(log10(mn) + 1e-9));
    *hi = pow(10.0, ceil(log10(mx) - 1e-9));
    if (!(*hi > *lo)) *hi = *lo * 10.0;
}

/* The RMSE axis position of v in the sweep figure, linear or logarithmic. */
static double rmse_y(const plot_frame *f, double v, double lo, double hi)
{
    return f->logy ? plot_logy(f, v, lo, hi) : plot_y(f, v, lo, hi);
}

/* The sweep's figure, after the PDS paper's Figure 6: RMSE (left axis,
   circles) and SSIM (right axis, squares) against the parameter, the
   optimum of each ringed. x is logarithmic when every value is positive and
   the largest is at least 10 times the smallest. rows with a non-finite
   metric are left out. With loglog (a sweep of photons) both x and the
   RMSE axis are logarithmic, so an error falling as a power of the photon
   count is a straight line. note, if not empty, is printed in red under
   the subtitle (an optimum at the edge of the values swept). */
static void sweep_svg(sbuf *b, const char *title, const char *subtitle, const char *xname, const sweep_row *rows,
                      int n, int best_r, int best_s, int loglog, const char *note)
{
    static const char rmse_col[] = "#c0392b", ssim_col[] = "#1f5fa8";
    plot_frame f;
    int order[MAX_SWEEP_VALUES], m = 0, i, j, first;
    double rmin = 0, rmax = 0, smin = 0, smax = 0, mid, rlo, rhi, rstep, slo, shi, sstep, last_label = -1e9;
    char t[64];
    f.left = 80;
    f.right = 640;
    f.top = 80;
    f.bottom = 370;
    f.pad = 20;
    /* finite points, sorted by x */
    for (i = 0; i < n; i++) {
        if (!isfinite(rows[i].m.rmse) || !isfinite(rows[i].m.ssim) || !isfinite(rows[i].x)) continue;
        for (j = m; j > 0 && rows[order[j - 1]].x > rows[i].x; j--) order[j] = order[j - 1];
        order[j] = i;
        m++;
    }
    f.xmin = m ? rows[order[0]].x : 0.0;
    f.xmax = m ? rows[order[m - 1]].x : 1.0;
    f.logx = m > 1 && f.xmin > 0.0 && f.xmax >= 10.0 * f.xmin;
    f.logy = 0;
    for (i = 0; i < m; i++) {
        const pds_metrics *q = &rows[order[i]].m;
        if (i == 0 || q->rmse < rmin) rmin = q->rmse;
        if (i == 0 || q->rmse > rmax) rmax = q->rmse;
        if (i == 0 || q->ssim < smin) smin = q->ssim;
        if (i == 0 || q->ssim > smax) smax = q->ssim;
    }
    if (loglog && m > 1 && f.xmin > 0.0 && f.xmax > f.xmin && rmin > 0.0) {
        f.logx = f.logy = 1;
        log_range(rmin, rmax, &rlo, &rhi);
        rstep = 0.0;
    } else {
        nice_range(rmin, rmax, 1, &rlo, &rhi, &rstep);
    }
    nice_range(smin, smax, 0, &slo, &shi, &sstep);

    sb_printf(b, "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"720\" height=\"440\" viewBox=\"0 0 720 440\" "
                 "font-family=\"Helvetica, Arial, sans-serif\" font-size=\"12\">\n<title>");
    sb_xml(b, title);
    sb_printf(b, "</title>\n<rect width=\"720\" height=\"440\" fill=\"white\"/>\n");
    sb_printf(b, "<text x=\"360\" y=\"26\" text-anchor=\"middle\" font-size=\"16\" font-weight=\"bold\">");
    sb_xml(b, title);
    sb_printf(b, "</text>\n<text x=\"360\" y=\"46\" text-anchor=\"middle\" fill=\"#444\">");
    sb_xml(b, subtitle);
    sb_printf(b, "</text>\n");
    if (note && note[0]) {
        sb_printf(b, "<text class=\"edge-note\" x=\"360\" y=\"%.0f\" text-anchor=\"middle\" fill=\"#c00\">",
                  f.bottom + 60);
        sb_xml(b, note);
        sb_printf(b, "</text>\n");
    }
    /* legend */
    sb_printf(b,
              "<g class=\"legend\"><line x1=\"250\" y1=\"64\" x2=\"280\" y2=\"64\" stroke=\"%s\" stroke-width=\"2\"/>"
              "<circle cx=\"265\" cy=\"64\" r=\"4\" fill=\"%s\"/><text x=\"286\" y=\"68\">RMSE (left axis)</text>"
              "<line x1=\"400\" y1=\"64\" x2=\"430\" y2=\"64\" stroke=\"%s\" stroke-width=\"2\" "
              "stroke-dasharray=\"6 3\"/><rect x=\"411\" y=\"60\" width=\"8\" height=\"8\" fill=\"%s\"/>"
              "<text x=\"436\" y=\"68\">SSIM (right axis)</text></g>\n",
              rmse_col, rmse_col, ssim_col, ssim_col);
    /* x ticks and vertical grid */
    sb_printf(b, "<g class=\"x-axis\" font-size=\"11\">\n");
    if (m > 0) {
        double cand[MAX_SWEEP_VALUES], xstep = 0.0;
        const char *cand_text[MAX_SWEEP_VALUES];
        int nc = 0;
        int distinct = 0;
        for (i = 0; i < m; i++)
            if (i == 0 || rows[order[i]].x != rows[order[i - 1]].x) distinct++;
        if (distinct <= 12) {
            /* few values: tick exactly the values swept */
            for (i = 0; i < m; i++)
                if (i == 0 || rows[order[i]].x != rows[order[i - 1]].x) {
                    cand_text[nc] = rows[order[i]].value;
                    cand[nc++] = rows[order[i]].x;
                }
        } else if (f.logx) {
            int e, e0 = (int)floor(log10(f.xmin)), e1 = (int)ceil(log10(f.xmax)), pass;
            static const double mult[3] = {1, 2, 5};
            /* 1-2-5 ticks per decade, or decades only when that is too many */
            for (pass = 0; pass < 2; pass++) {
                nc = 0;
                for (e = e0; e <= e1 && nc < 64; e++) {
                    int k;
                    for (k = 0; k < (pass ? 1 : 3) && nc < 64; k++) {
                        double v = mult[k] * pow(10.0, e);
                        if (v >= f.xmin * (1 - 1e-9) && v <= f.xmax * (1 + 1e-9)) {
                            cand_text[nc] = NULL;
                            cand[nc++] = v;
                        }
                    }
                }
                if (nc <= 10) break;
            }
        } else if (f.xmax > f.xmin) {
            double v;
            xstep = nice_step(f.xmax - f.xmin, 6);
            for (v = ceil(f.xmin / xstep - 1e-9) * xstep; v <= f.xmax + xstep * 1e-9 && nc < 64; v += xstep) {
                cand_text[nc] = NULL;
                cand[nc++] = v;
            }
        }
        for (i = 0; i < nc; i++) {
            double px = plot_x(&f, cand[i]), v = cand[i];
            if (cand_text[i]) snprintf(t, sizeof t, "%s", cand_text[i]);
            else if (xstep > 0.0) tick_text(v, xstep, t, sizeof t);
            else snprintf(t, sizeof t, "%g", v);
            sb_printf(b, "<line x1=\"%.1f\" y1=\"%.0f\" x2=\"%.1f\" y2=\"%.0f\" stroke=\"#e5e5e5\"/>", px, f.top, px,
                      f.bottom);
            sb_printf(b, "<line x1=\"%.1f\" y1=\"%.0f\" x2=\"%.1f\" y2=\"%.0f\" stroke=\"#444\"/>", px, f.bottom, px,
                      f.bottom + 5);
            if (px - last_label >= 40.0) {
                sb_printf(b, "<text x=\"%.1f\" y=\"%.0f\" text-anchor=\"middle\">", px, f.bottom + 18);
                sb_xml(b, t);
                sb_printf(b, "</text>");
                last_label = px;
            }
            sb_printf(b, "\n");
        }
    }
    sb_printf(b, "<text x=\"%.0f\" y=\"%.0f\" text-anchor=\"middle\" font-size=\"13\">", 0.5 * (f.left + f.right),
              f.bottom + 42);
    sb_xml(b, xname);
    sb_printf(b, "%s</text>\n</g>\n", f.logx ? " (log scale)" : "");
    /* left axis: RMSE */
    sb_printf(b, "<g class=\"rmse-axis%s\" font-size=\"11\" fill=\"%s\">\n", f.logy ? " log-y" : "", rmse_col);
    if (f.logy) {
        /* decades labelled, 2..9 times each as faint grid lines */
        double d;
        for (d = rlo; d <= rhi * (1 + 1e-9); d *= 10.0) {
            int k;
            double py = plot_logy(&f, d, rlo, rhi);
            sb_printf(b,
                      "<line x1=\"%.0f\" y1=\"%.1f\" x2=\"%.0f\" y2=\"%.1f\" stroke=\"#e5e5e5\"/>"
                      "<line x1=\"%.0f\" y1=\"%.1f\" x2=\"%.0f\" y2=\"%.1f\" stroke=\"%s\"/>"
                      "<text x=\"%.0f\" y=\"%.1f\" text-anchor=\"end\">%g</text>\n",
                      f.left, py, f.right, py, f.left - 5, py, f.left, py, rmse_col, f.left - 8, py + 4, d);
            for (k = 2; k <= 9 && d * k < rhi; k++) {
                py = plot_logy(&f, d * k, rlo, rhi);
                sb_printf(b, "<line x1=\"%.0f\" y1=\"%.1f\" x2=\"%.0f\" y2=\"%.1f\" stroke=\"#f3f3f3\"/>\n", f.left,
                          py, f.right, py);
            }
        }
    }
    for (i = 0; i <= 100 && !f.logy; i++) {
        double v = rlo + i * rstep, py;
        if (v > rhi + rstep * 1e-6) break;
        py = plot_y(&f, v, rlo, rhi);
        tick_text(v, rstep, t, sizeof t);
        sb_printf(b,
                  "<line x1=\"%.0f\" y1=\"%.1f\" x2=\"%.0f\" y2=\"%.1f\" stroke=\"#eeeeee\"/>"
                  "<line x1=\"%.0f\" y1=\"%.1f\" x2=\"%.0f\" y2=\"%.1f\" stroke=\"%s\"/>"
                  "<text x=\"%.0f\" y=\"%.1f\" text-anchor=\"end\">%s</text>\n",
                  f.left, py, f.right, py, f.left - 5, py, f.left, py, rmse_col, f.left - 8, py + 4, t);
    }
    sb_printf(b,
              "<text transform=\"translate(24 %.0f) rotate(-90)\" text-anchor=\"middle\" font-size=\"13\">RMSE "
              "(linear RGB)%s</text>\n</g>\n",
              0.5 * (f.top + f.bottom), f.logy ? ", log scale" : "");
    /* right axis: SSIM */
    sb_printf(b, "<g class=\"ssim-axis\" font-size=\"11\" fill=\"%s\">\n", ssim_col);
    for (i = 0; i <= 100; i++) {
        double v = slo + i * sstep, py;
        if (v > shi + sstep * 1e-6) break;
        py = plot_y(&f, v, slo, shi);
        tick_text(v, sstep, t, sizeof t);
        sb_printf(b,
                  "<line x1=\"%.0f\" y1=\"%.1f\" x2=\"%.0f\" y2=\"%.1f\" stroke=\"%s\"/>"
                  "<text x=\"%.0f\" y=\"%.1f\">%s</text>\n",
                  f.right, py, f.right + 5, py, ssim_col, f.right + 8, py + 4, t);
    }
    sb_printf(b,
              "<text transform=\"translate(%.0f %.0f) rotate(90)\" text-anchor=\"middle\" font-size=\"13\">SSIM "
              "(sRGB luminance)</text>\n</g>\n",
              696.0, 0.5 * (f.top + f.bottom));
    sb_printf(b, "<rect x=\"%.0f\" y=\"%.0f\" width=\"%.0f\" height=\"%.0f\" fill=\"none\" stroke=\"#444\"/>\n", f.left,
              f.top, f.right - f.left, f.bottom - f.top);
    /* the two series */
    sb_printf(b, "<polyline class=\"rmse-line\" fill=\"none\" stroke=\"%s\" stroke-width=\"2\" points=\"", rmse_col);
    for (i = 0, first = 1; i < m; i++, first = 0)
        sb_printf(b, "%s%.1f,%.1f", first ? "" : " ", plot_x(&f, rows[order[i]].x),
                  rmse_y(&f, rows[order[i]].m.rmse, rlo, rhi));
    sb_printf(b, "\"/>\n<polyline class=\"ssim-line\" fill=\"none\" stroke=\"%s\" stroke-width=\"2\" "
                 "stroke-dasharray=\"6 3\" points=\"", ssim_col);
    for (i = 0, first = 1; i < m; i++, first = 0)
        sb_printf(b, "%s%.1f,%.1f", first ? "" : " ", plot_x(&f, rows[order[i]].x),
                  plot_y(&f, rows[order[i]].m.ssim, slo, shi));
    sb_printf(b, "\"/>\n");
    for (i = 0; i < m; i++) {
        const sweep_row *r = &rows[order[i]];
        double px = plot_x(&f, r->x);
        sb_printf(b, "<circle class=\"rmse-marker\" cx=\"%.1f\" cy=\"%.1f\" r=\"4\" fill=\"%s\"><title>", px,
                  rmse_y(&f, r->m.rmse, rlo, rhi), rmse_col);
        sb_xml(b, xname);
        sb_printf(b, "=");
        sb_xml(b, r->value);
        sb_printf(b, ": RMSE %.6f</title></circle>\n", r->m.rmse);
        sb_printf(b, "<rect class=\"ssim-marker\" x=\"%.1f\" y=\"%.1f\" width=\"8\" height=\"8\" fill=\"%s\"><title>",
                  px - 4, plot_y(&f, r->m.ssim, slo, shi) - 4, ssim_col);
        sb_xml(b, xname);
        sb_printf(b, "=");
        sb_xml(b, r->value);
        sb_printf(b, ": SSIM %.6f</title></rect>\n", r->m.ssim);
    }
    /* the optima, on top:  a dashed vertical line, a ring and a label */
    mid = 0.5 * (f.left + f.right);
    if (best_r >= 0 && isfinite(rows[best_r].m.rmse)) {
        double px = plot_x(&f, rows[best_r].x), py = rmse_y(&f, rows[best_r].m.rmse, rlo, rhi);
        sb_printf(b,
                  "<g class=\"rmse-optimum\"><line x1=\"%.1f\" y1=\"%.0f\" x2=\"%.1f\" y2=\"%.0f\" stroke=\"%s\" "
                  "stroke-opacity=\"0.5\" stroke-dasharray=\"2 3\"/><circle cx=\"%.1f\" cy=\"%.1f\" r=\"9\" "
                  "fill=\"none\" stroke=\"%s\" stroke-width=\"2\"/><text x=\"%.1f\" y=\"%.1f\" text-anchor=\"%s\" "
                  "fill=\"%s\" font-size=\"11\" stroke=\"white\" stroke-width=\"3\" "
                  "paint-order=\"stroke\">min RMSE</text></g>\n",
                  px, f.top, px, f.bottom, rmse_col, px, py, rmse_col, px > mid ? px - 13 : px + 13, py - 10,
                  px > mid ? "end" : "start", rmse_col);
    }
    if (best_s >= 0 && isfinite(rows[best_s].m.ssim)) {
        double px = plot_x(&f, rows[best_s].x), py = plot_y(&f, rows[best_s].m.ssim, slo, shi);
        sb_printf(b,
                  "<g class=\"ssim-optimum\"><line x1=\"%.1f\" y1=\"%.0f\" x2=\"%.1f\" y2=\"%.0f\" stroke=\"%s\" "
                  "stroke-opacity=\"0.5\" stroke-dasharray=\"2 3\"/><rect x=\"%.1f\" y=\"%.1f\" width=\"18\" "
                  "height=\"18\" fill=\"none\" stroke=\"%s\" stroke-width=\"2\"/><text x=\"%.1f\" y=\"%.1f\" "
                  "text-anchor=\"%s\" fill=\"%s\" font-size=\"11\" stroke=\"white\" stroke-width=\"3\" "
                  "paint-order=\"stroke\">max SSIM</text></g>\n",
                  px, f.top, px, f.bottom, ssim_col, px - 9, py - 9, ssim_col, px > mid ? px - 13 : px + 13, py + 18,
                  px > mid ? "end" : "start", ssim_col);
    }
    sb_printf(b, "</svg>\n");
}

/* ------------------------------------------------------------------ sweep */

/* Is row `best` at the smallest or the largest x of two or more distinct
   finite values? */
static int sweep_at_edge(const sweep_row *rows, int n, int best)
{
    double lo = 0.0, hi = 0.0;
    int i, seen = 0;
    if (best < 0) return 0;
    for (i = 0; i < n; i++) {
        if (!isfinite(rows[i].x)) continue;
        if (!seen || rows[i].x < lo) lo = rows[i].x;
        if (!seen || rows[i].x > hi) hi = rows[i].x;
        seen = 1;
    }
    return hi > lo && (rows[best].x == lo || rows[best].x == hi);
}

static const char *const sweep_own_options[] = {"--param", "--values", "--ref", "--output", "--resume", "--mask", NULL};

static int cmd_sweep(int argc, char **argv)
{
    const char *scene_path = NULL, *param = NULL, *values = NULL, *ref_path = NULL, *dir = NULL, *mask_path = NULL;
    char dir_buf[1024], stem[256], where[64], name[64], list[512];
    run_cfg base;
    const opt_spec *ps;
    sweep_row *rows = NULL;
    pds_scene *scene = NULL;
    pds_image ref = {0, 0, NULL}, mask_img = {0, 0, NULL}; /* --mask: the pixels the metrics take */
    char *vbuf = NULL, *p, edge_note[160] = "";
    int i, r, n = 0, rc = 1, best_r = -1, best_s = -1, idx, photon, rmse_edge = 0, ssim_edge = 0, resume = 0;
    pds_method method;
    cfg_init(&base);
    for (i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (a[0] != '-' || a[1] == '\0') {
            if (scene_path) return usage_error("sweep takes one scene, got another: '%s'", a);
            scene_path = a;
            continue;
        }
        if (arg_is(a, "--resume")) {
            if (a[8] == '=') return usage_error("--resume takes no value, got '%s'", a);
            resume = 1;
            continue;
        }
        if (arg_is(a, "--param") || arg_is(a, "--values") || arg_is(a, "--ref") || arg_is(a, "-o") ||
            arg_is(a, "--output") || arg_is(a, "--mask")) {
            const char *v;
            if (option_value(argc, argv, &i, &v)) return EXIT_USAGE;
            if (arg_is(a, "--param")) param = v;
            else if (arg_is(a, "--mask")) mask_path = v;
            else if (arg_is(a, "--values")) values = v;
            else if (arg_is(a, "--ref")) ref_path = v;
            else dir = v;
            continue;
        }
        r = parse_option(&base, C_SWEEP, "sweep", argc, argv, &i);
        if (r < 0) return unknown_option(a, C_SWEEP, sweep_own_options);
        if (r) return r;
    }
    if (!scene_path) return usage_error("%s", "sweep needs a scene file");
    image_out_set(&base);
    if (!param) return usage_error("%s", "sweep needs --param NAME");
    if (!values) return usage_error("%s", "sweep needs --values A,B,...");
    if (!ref_path) return usage_error("%s", "sweep needs --ref REFERENCE.pfm");
    method = base.opt.method;
    photon = is_photon_method(method);
    snprintf(name, sizeof name, "--%s", param);
    idx = strlen(param) < 40 && param[0] != '-' ? option_index(name) : -1;
    if (idx < 0 || !(option_table[idx].flags & F_SWEEP)) {
        size_t k, count = 0, done = 0;
        char hint[256];
        suggestion sug;
        suggest_init(&sug, param);
        list[0] = '\0';
        for (k = 0; k < N_OPTIONS; k++) count += (option_table[k].flags & F_SWEEP) != 0;
        for (k = 0; k < N_OPTIONS; k++)
            if (option_table[k].flags & F_SWEEP) {
                done++;
                snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s",
                         done == 1 ? "" : done == count ? " and " : ", ", option_table[k].name + 2);
                suggest_consider(&sug, option_table[k].name + 2);
            }
        return usage_error("--param knows %s, got '%s'%s", list, param, suggest_text(&sug, hint, sizeof hint));
    }
    ps = &option_table[idx];
    if (base.given[idx])
        return usage_error("%s is the parameter swept: give its values with --values, not %s", param, ps->name);
    if (!(ps->methods & MBIT(method))) {
        method_join(ps->methods, " and ", list, sizeof list);
        return usage_error("--param %s has no effect with --method %s (%s is for %s)", param, method_name(method),
                           param, list);
    }
    if (spm_caustics_idle(ps, &base.opt))
        return usage_error("--param %s has no effect with --method spm and --caustics-only (%s)", param,
                           spm_caustics_idle_why(ps));
    if (!strcmp(param, "photons") && option_given(&base, "--time"))
        return usage_error("%s", "--param photons and --time exclude each other (the time decides the photon count)");
    /* the values: validated all before anything is rendered */
    vbuf = strdup(values);
    rows = (sweep_row *)calloc(MAX_SWEEP_VALUES, sizeof *rows);
    if (!vbuf || !rows) {
        free(vbuf);
        free(rows);
        return fail("%s", "out of memory");
    }
    for (p = vbuf;; p++) {
        char *comma = strchr(p, ',');
        run_cfg probe = base;
        if (comma) *comma = '\0';
        if (!*p) {
            rc = usage_error("--values needs a comma-separated list of values, got '%s'", values);
            goto done;
        }
        if (n == MAX_SWEEP_VALUES) {
            rc = usage_error("--values takes at most %d values", MAX_SWEEP_VALUES);
            goto done;
        }
        if (ps->set(ps, &probe, param, p)) {
            rc = EXIT_USAGE;
            goto done;
        }
        rows[n].value = p;
        rows[n].x = option_number(ps, &probe); /* "100k" is 100000 */
        n++;
        if (!comma) break;
        p = comma;
    }
    snprintf(where, sizeof where, "with --method %s", method_name(method));
    note_idle_options(&base, MBIT(method), where);
    scene_stem(scene_path, stem, sizeof stem);
    if (!dir) {
        snprintf(dir_buf, sizeof dir_buf, "sweep-%s-%s", stem, method_name(method));
        dir = dir_buf;
    }
    if (check_out_dir(dir)) goto done;
    if (load_scene_and_ref("sweep", scene_path, ref_path, &base.opt, &scene, &ref)) goto done;
    if (mask_path && load_mask(mask_path, &ref, &mask_img)) goto done;
    print_scene_warnings(scene, &base);
    cfg_apply_progress(&base);

    for (i = 0; i < n; i++) {
        run_cfg c = base;
        char context[128], key[600], label[160], extra[8];
        int loaded = 0;
        ps->set(ps, &c, param, rows[i].value);
        snprintf(context, sizeof context, "sweep %s=%s", ps->key, rows[i].value);
        /* kept entries (see "keeping finished entries") */
        entry_key(scene, &c.opt, "", key, sizeof key);
        snprintf(label, sizeof label, "%s-%s", ps->key, rows[i].value);
        if (resume && (loaded = load_entry(dir, label, key, &ref, mask_path ? &mask_img : NULL, &rows[i].img, &rows[i].st, &rows[i].m, extra,
                                           sizeof extra)) < 0)
            goto done;
        if (!loaded) {
            if (render_and_compare(scene, &c, &ref, mask_path ? &mask_img : NULL, &rows[i].img, &rows[i].st, &rows[i].m, context)) goto done;
            if (keep_entry(dir, label, key, &rows[i].img, &rows[i].st, "")) goto done;
        }
        printf("sweep method=%s %s=%s", method_name(method), ps->key, rows[i].value);
        if (photon && strcmp(ps->key, "photons")) printf(" photons=%ld", rows[i].st.photons);
        if (!photon && strcmp(ps->key, "spp")) printf(" spp=%d", rows[i].st.spp);
        printf(" rmse=%.6f ssim=%.6f time=%.3f%s\n", rows[i].m.rmse, rows[i].m.ssim, rows[i].st.time_total_s,
               loaded ? " resumed=1" : "");
        fflush(stdout);
        /* first best wins a tie; NaN never wins */
        if (isfinite(rows[i].m.rmse) && (best_r < 0 || rows[i].m.rmse < rows[best_r].m.rmse)) best_r = i;
        if (isfinite(rows[i].m.ssim) && (best_s < 0 || rows[i].m.ssim > rows[best_s].m.ssim)) best_s = i;
    }

    /* An optimum on the smallest or largest value swept may lie beyond
       it: say so. Not for the counts (photons, spp, passes), whose error
       falls as they grow, so that their best is the largest by design. */
    if (strcmp(ps->key, "photons") && strcmp(ps->key, "spp") && strcmp(ps->key, "passes")) {
        rmse_edge = sweep_at_edge(rows, n, best_r);
        ssim_edge = sweep_at_edge(rows, n, best_s);
    }
    if (rmse_edge || ssim_edge) {
        snprintf(edge_note, sizeof edge_note, "the %s%s%s optimum is at the edge of the values swept: widen --values",
                 rmse_edge ? "RMSE" : "", rmse_edge && ssim_edge ? " and the SSIM" : "", ssim_edge && !rmse_edge ? "SSIM" : "");
        fprintf(stderr, "pds sweep: warning: %s (lowest RMSE at %s=%s, highest SSIM at %s=%s)\n", edge_note, ps->key,
                best_r >= 0 ? rows[best_r].value : "none", ps->key, best_s >= 0 ? rows[best_s].value : "none");
    }

    /* every render succeeded: now the folder */
    if (make_dirs(dir)) goto done;
    {
        sbuf csv = {NULL, 0, 0, 0}, svg = {NULL, 0, 0, 0};
        char title[512], subtitle[512], file[128], safe[64];
        int bad = 0;
        sb_printf(&csv, "method,param,value,photons,spp,passes,map_bytes,rmse,ssim,time_s,image\n");
        for (i = 0; i < n && !bad; i++) {
            const sweep_row *w = &rows[i];
            file_safe(w->value, safe, sizeof safe);
            snprintf(file, sizeof file, "%s-%s.png", ps->key, safe);
            bad = write_image(dir, file, &w->img, base.exposure);
            sb_printf(&csv, "%s,%s,", method_name(method), ps->key);
            sb_csv(&csv, w->value);
            sb_printf(&csv, ",%ld,%d,%d,%lu,%.6f,%.6f,%.3f,", w->st.photons, w->st.spp, w->st.passes,
                      (unsigned long)w->st.map_bytes, w->m.rmse, w->m.ssim, w->st.time_total_s);
            sb_csv(&csv, file);
            sb_printf(&csv, "\n");
        }
        snprintf(title, sizeof title, "%s on %s: RMSE and SSIM against %s", method_name(method), stem, ps->key);
        {
            char ph[64] = "";
            pds_options used = base.opt;
            pds_options_resolve(scene, &used); /* the method's own photon count if not given */
            if (photon && strcmp(ps->key, "photons") && !option_given(&base, "--time"))
                snprintf(ph, sizeof ph, "%ld photons; ", used.photons);
            snprintf(subtitle, sizeof subtitle, "%s%dx%d; lowest RMSE %.4g at %s=%s; highest SSIM %.4g at %s=%s", ph,
                     ref.width, ref.height, best_r >= 0 ? rows[best_r].m.rmse : 0.0, ps->key,
                     best_r >= 0 ? rows[best_r].value : "-", best_s >= 0 ? rows[best_s].m.ssim : 0.0, ps->key,
                     best_s >= 0 ? rows[best_s].value : "-");
        }
        sweep_svg(&svg, title, subtitle, ps->key, rows, n, best_r, best_s, !strcmp(ps->key, "photons"), edge_note);
        if (!bad) bad = write_text(dir, "sweep.csv", &csv);
        if (!bad) bad = write_text(dir, "sweep.svg", &svg);
        free(csv.s);
        free(svg.s);
        if (bad) goto done;
    }
    printf("sweep best method=%s rmse_optimal_%s=%s rmse=%.6f ssim_optimal_%s=%s ssim=%.6f dir=%s rmse_at_edge=%d "
           "ssim_at_edge=%d\n",
           method_name(method), ps->key, best_r >= 0 ? rows[best_r].value : "none",
           best_r >= 0 ? rows[best_r].m.rmse : 0.0, ps->key, best_s >= 0 ? rows[best_s].value : "none",
           best_s >= 0 ? rows[best_s].m.ssim : 0.0, dir, rmse_edge, ssim_edge);
    rc = 0;
done:
    for (i = 0; rows && i < n; i++) pds_image_free(&rows[i].img);
    free(rows);
    free(vbuf);
    pds_image_free(&mask_img);
    pds_image_free(&ref);
    pds_scene_free(scene);
    return rc;
}

/* ------------------------------------------------------------------- race */

typedef struct roi_box {
    int x, y, w, h;
} roi_box;

/* Budget checks (race.csv's budget_flag, a warning on stderr, a mark on
   the page): under a time budget a render whose budgeted time
   (budget_spent) was more than 25% more or less than its budget, or a
   photon method that emitted fewer than RACE_MIN_PHOTONS photons or fewer
   than 1% of the most any photon method emitted on that budget, is not an
   equal-time result. */
enum { RACE_OVER_TIME = 1, RACE_UNDER_TIME = 2, RACE_FEW_PHOTONS = 4 };
#define RACE_TIME_TOLERANCE 0.25
#define RACE_MIN_PHOTONS 10000
#define RACE_MIN_PHOTON_SHARE 0.01
#define MAX_RACE_BUDGETS 16
#define MAX_RACE_ENTRIES 96

typedef struct race_entry {
    char label[96];   /* file stem, unique: "pm-k50"; with --budgets "pm-k50-2s" */
    char params[256]; /* " k=50 kernel=cone max_radius=none", after tuning */
    char tuned[96];   /* --tune: the values chosen, "k=20"; "" if none */
    char tuned_keys[48]; /* the parameters tuned, "radius+alpha" */
    int tuned_edge;   /* a chosen value is the first or last of its grid */
    int method;       /* its place in --methods: its series in the convergence plot */
    int budget;       /* its place in the budgets */
    unsigned flags;   /* RACE_OVER_TIME, ... */
    run_cfg cfg;
    pds_image img;
    pds_render_stats st;
    pds_metrics m;
    double diff_scale; /* |luminance error| shown at full colour */
} race_entry;

/* The budgets: --time T or --photons N (one), or --budgets A,B,... */
typedef struct race_budgets {
    int by_time;  /* 1: seconds, 0: photons */
    int listed;   /* from --budgets: labels carry the budget */
    int n;
    double value[MAX_RACE_BUDGETS];
    char text[MAX_RACE_BUDGETS][32]; /* for labels and tables: "2", "1e+05" */
} race_budgets;

/* sRGB transfer curve of a value clamped to [0, 1]. */
static double srgb_encode(double c)
{
    if (!(c > 0.0)) return 0.0;
    if (c >= 1.0) return 1.0;
    return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

/* The default region of interest: among the w x h windows (w, h = the
   image's sides, at most 64) at every multiple of min(w, h) / 8 pixels
   across and down, plus the windows flush with the right and bottom edges,
   the one where the reference's displayed luminance varies most. That
   luminance is what SSIM sees: Y = 0.299 R' + 0.587 G' + 0.114 B' of the
   sRGB-encoded values clamped to [0, 1], here rounded to 8 bits so the sums
   are exact and ties are decided by position alone: the top-most, then
   left-most window wins. Cost: one pass over the image, memory O(width). */
static int choose_roi(const pds_image *ref, roi_box *out)
{
    int W = ref->width, H = ref->height, w = W < 64 ? W : 64, h = H < 64 ? H : 64;
    int step = (w < h ? w : h) / 8, x, y, cy, found = 0;
    long long *col, *col2, *pre, *pre2, best = -1, cells = (long long)w * h;
    unsigned char *lum;
    size_t i, npix = (size_t)W * (size_t)H;
    if (step < 1) step = 1;
    col = (long long *)calloc((size_t)W * 4 + 2, sizeof *col);
    lum = (unsigned char *)malloc(npix);
    if (!col || !lum) {
        free(col);
        free(lum);
        return fail("%s", "out of memory");
    }
    col2 = col + W;
    pre = col2 + W;
    pre2 = pre + W + 1;
    for (i = 0; i < npix; i++) {
        const float *p = ref->rgb + 3 * i;
        double yv = 0.299 * srgb_encode(p[0]) + 0.587 * srgb_encode(p[1]) + 0.114 * srgb_encode(p[2]);
        lum[i] = (unsigned char)(yv * 255.0 + 0.5);
    }
    /* col[x], col2[x]: sums of Y and Y^2 over rows cy .. cy+h-1 of column x */
    for (y = 0; y < h; y++)
        for (x = 0; x < W; x++) {
            long long v = lum[(size_t)y * W + x];
            col[x] += v;
            col2[x] += v * v;
        }
    cy = 0;
    for (y = 0;;) {
        for (; cy < y; cy++)
            for (x = 0; x < W; x++) {
                long long a = lum[(size_t)cy * W + x], b = lum[(size_t)(cy + h) * W + x];
                col[x] += b - a;
                col2[x] += b * b - a * a;
            }
        pre[0] = pre2[0] = 0;
        for (x = 0; x < W; x++) {
            pre[x + 1] = pre[x] + col[x];
            pre2[x + 1] = pre2[x] + col2[x];
        }
        for (x = 0;;) {
            long long s = pre[x + w] - pre[x], s2 = pre2[x + w] - pre2[x];
            long long var = cells * s2 - s * s; /* cells^2 x the variance */
            if (var > best) {
                best = var;
                out->x = x;
                out->y = y;
                found = 1;
            }
            if (x == W - w) break;
            x = x + step < W - w ? x + step : W - w;
        }
        if (y == H - h) break;
        y = y + step < H - h ? y + step : H - h;
    }
    out->w = w;
    out->h = h;
    free(col);
    free(lum);
    return found ? 0 : fail("%s", "no region of interest found");
}

/* The region of img, scaled up by `scale` with nearest neighbour. */
static int make_crop(const pds_image *img, roi_box roi, int scale, pds_image *out)
{
    int x, y;
    if (pds_image_alloc(out, roi.w * scale, roi.h * scale) != PDS_OK) return fail("%s", "out of memory");
    for (y = 0; y < out->height; y++)
        for (x = 0; x < out->width; x++) {
            const float *s = img->rgb + 3 * ((size_t)(roi.y + y / scale) * img->width + (size_t)(roi.x + x / scale));
            float *d = out->rgb + 3 * ((size_t)y * out->width + x);
            d[0] = s[0];
            d[1] = s[1];
            d[2] = s[2];
        }
    return 0;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* The signed luminance error e = Y(img) - Y(ref), Y = 0.299 R + 0.587 G +
   0.114 B of the linear values, of pixel i. */
static double luminance_error(const pds_image *img, const pds_image *ref, size_t i)
{
    const float *a = img->rgb + 3 * i, *b = ref->rgb + 3 * i;
    return 0.299 * ((double)a[0] - b[0]) + 0.587 * ((double)a[1] - b[1]) + 0.114 * ((double)a[2] - b[2]);
}

/* *p99 = the 99th percentile of |e| over the pixels where e is a number
   (0: no error), so that 1% of them saturate at that scale. */
static int diff_percentile(const pds_image *img, const pds_image *ref, double *p99)
{
    size_t i, n = (size_t)ref->width * ref->height, nf = 0;
    double *mag = (double *)malloc((n ? n : 1) * sizeof *mag), s = 0.0;
    if (!mag) return fail("%s", "out of memory");
    for (i = 0; i < n; i++) {
        double e = luminance_error(img, ref, i);
        if (isfinite(e)) mag[nf++] = fabs(e);
    }
    if (nf > 0) {
        qsort(mag, nf, sizeof *mag, cmp_double);
        s = mag[(size_t)(0.99 * (double)(nf - 1))];
        if (!(s > 0.0)) s = mag[nf - 1]; /* fewer than 1% of the pixels differ */
    }
    free(mag);
    *p99 = s;
    return 0;
}

/* The error e as colour (the PDS paper's Fig. 14): green where e > 0 (too
   bright), red where e < 0 (too dark), with intensity |e| / scale clamped
   to 1; blue where e is not a number; black everywhere when scale is 0. */
static int make_diff(const pds_image *img, const pds_image *ref, double scale, pds_image *out)
{
    size_t i, n = (size_t)ref->width * ref->height;
    if (pds_image_alloc(out, ref->width, ref->height) != PDS_OK) return fail("%s", "out of memory");
    for (i = 0; i < n; i++) {
        float *d = out->rgb + 3 * i;
        double e = luminance_error(img, ref, i);
        double v = scale > 0.0 ? fabs(e) / scale : 0.0;
        if (v > 1.0) v = 1.0;
        d[0] = d[1] = d[2] = 0.0f;
        if (!isfinite(e)) d[2] = 1.0f;
        else if (e < 0.0) d[0] = (float)v;
        else d[1] = (float)v;
    }
    return 0;
}

/* "pm:k=50:kernel=gaussian,pds,..." -> entries (each a copy of base with
   its method and options set) and unique labels. 0 or EXIT_USAGE. */
static int parse_race_methods(const char *list, const run_cfg *base, race_entry *e, int *count)
{
    char *buf = strdup(list), *item, *next;
    int n = 0, rc = 0, i, j, dup[MAX_RACE_METHODS];
    if (!buf) return fail("%s", "out of memory");
    for (item = buf; item && !rc; item = next) {
        char *colon, *param, *nextp;
        race_entry *r = &e[n];
        next = strchr(item, ',');
        if (next) *next++ = '\0';
        if (!*item) {
            rc = usage_error("--methods needs a comma-separated list of methods, got '%s'", list);
            break;
        }
        if (n == MAX_RACE_METHODS) {
            rc = usage_error("--methods takes at most %d methods", MAX_RACE_METHODS);
            break;
        }
        r->cfg = *base;
        colon = strchr(item, ':');
        if (colon) *colon = '\0';
        if (method_lookup(item, &r->cfg.opt.method)) {
            rc = unknown_method(item);
            break;
        }
        snprintf(r->label, sizeof r->label, "%s", item);
        for (param = colon ? colon + 1 : NULL; param && !rc; param = nextp) {
            char *eq, oname[64], shown[128], safe[32], methods[128];
            const opt_spec *s;
            int idx = -1;
            size_t k;
            nextp = strchr(param, ':');
            if (nextp) *nextp++ = '\0';
            eq = strchr(param, '=');
            if (!eq || eq == param || !eq[1]) {
                rc = usage_error("--methods: '%s' after %s needs NAME=VALUE", param, item);
                break;
            }
            *eq = '\0';
            if (strlen(param) < 40 && param[0] != '-') {
                snprintf(oname, sizeof oname, "--%s", param);
                for (k = 2; oname[k]; k++)
                    if (oname[k] == '_') oname[k] = '-';
                idx = option_index(oname);
            }
            if (idx < 0) {
                char hint[256];
                suggestion sug;
                suggest_init(&sug, param);
                for (k = 0; k < N_OPTIONS; k++)
                    if (option_table[k].flags & F_PER_METHOD) suggest_consider(&sug, option_table[k].name + 2);
                rc = usage_error("--methods: unknown option '%s' for %s%s", param, item,
                                 suggest_text(&sug, hint, sizeof hint));
                break;
            }
            s = &option_table[idx];
            if (!(s->flags & F_PER_METHOD)) {
                rc = usage_error("--methods: %s cannot be set for one method; give it to all with %s", param, s->name);
                break;
            }
            if (!(s->methods & MBIT(r->cfg.opt.method))) {
                method_join(s->methods, " and ", methods, sizeof methods);
                rc = usage_error("--methods: %s has no effect with %s (%s is for %s)", param, item, param, methods);
                break;
            }
            if (spm_caustics_idle(s, &r->cfg.opt)) {
                rc = usage_error("--methods: %s has no effect with %s and --caustics-only (%s)", param, item,
                                 spm_caustics_idle_why(s));
                break;
            }
            snprintf(shown, sizeof shown, "%s:%s", item, param);
            if (s->set(s, &r->cfg, shown, eq + 1)) {
                rc = EXIT_USAGE;
                break;
            }
            r->cfg.given[idx] = 1; /* given: --tune keeps it */
            file_safe(eq + 1, safe, sizeof safe);
            snprintf(r->label + strlen(r->label), sizeof r->label - strlen(r->label), "-%s%s", s->key, safe);
        }
        if (!rc) n++;
    }
    free(buf);
    /* the same method twice with the same options: pt, pt-2, ... */
    for (i = 0; i < n; i++) {
        dup[i] = 1;
        for (j = 0; j < i; j++)
            if (!strcmp(e[j].label, e[i].label)) dup[i]++;
    }
    for (i = 0; i < n; i++)
        if (dup[i] > 1) snprintf(e[i].label + strlen(e[i].label), sizeof e[i].label - strlen(e[i].label), "-%d", dup[i]);
    *count = n;
    return rc;
}

/* One figure of index.html: the image at display width dw (CSS scales it,
   nearest neighbour), the region of interest framed if roi is not NULL. */
static void html_figure(sbuf *b, const char *src, const char *alt, const char *caption, int w, int h, int dw,
                        const roi_box *roi)
{
    sb_printf(b, "<figure><div class=\"frame\" style=\"width:%dpx\"><img src=\"", dw);
    sb_xml(b, src);
    sb_printf(b, "\" alt=\"");
    sb_xml(b, alt);
    sb_printf(b, "\" width=\"%d\" height=\"%d\">", dw, (int)((double)dw * h / w + 0.5));
    if (roi)
        sb_printf(b, "<div class=\"roi\" style=\"left:%.3f%%;top:%.3f%%;width:%.3f%%;height:%.3f%%\"></div>",
                  100.0 * roi->x / w, 100.0 * roi->y / h, 100.0 * roi->w / w, 100.0 * roi->h / h);
    sb_printf(b, "</div><figcaption>%s</figcaption></figure>\n", caption);
}

/* ------------------------------------------------------------- race: tune */

/* pds race --tune: each method's main parameter, chosen for each budget by
   the lowest RMSE over a small grid, rendered on seed + 1 (another photon
   and pixel sequence than the render reported, so the choice does not fit
   that render's own noise). A parameter given in --methods or as an option
   is kept. ppm is tuned one parameter at a time: R0 with alpha at its
   value, then alpha with the best R0; pm and spm likewise k, then R
   (max-radius: eye vertices far from every photon make k-nearest queries
   that grow with the map, which took pm's gather alone past the budget on
   the reflection case) with the best k (spm's stream_photons only says
   how many photons a stream stands for: under a time budget it changes
   nothing in the image). Radii are multiples of the pixel
   footprint at the camera's look-at distance (race_pixel_size), so the
   grid follows the scene's scale. Under a time budget a value whose
   render took more than RACE_TIME_TOLERANCE over the budget is not an
   equal-time result, so it is chosen only if every value overran (then
   the quickest wins, with a warning): a pm whose k = 160 gather alone
   takes three budgets must not win on the time it was not given. */
typedef struct tune_grid {
    pds_method method;
    int progressive; /* pds: the grid for progressive (1) or the paper's PDS (0); -1 any */
    const char *key; /* the option without its dashes */
    int n;
    double v[8];
    int in_pixels;   /* the values are multiples of the pixel footprint */
} tune_grid;

static const tune_grid tune_grids[] = {
    {PDS_METHOD_PDS, 0, "smoothing", 6, {4, 6, 8, 12, 16, 24}, 0},
    {PDS_METHOD_PDS, 1, "pass-smoothing", 7, {1, 1.5, 2, 3, 4, 6, 8}, 0},
    {PDS_METHOD_PDM, -1, "smoothing", 6, {4, 6, 8, 12, 16, 24}, 0},
    {PDS_METHOD_PM, -1, "k", 5, {10, 20, 40, 80, 160}, 0},
    {PDS_METHOD_PM, -1, "max-radius", 5, {1, 3, 10, 30, 100}, 1},
    {PDS_METHOD_SPLAT, -1, "radius", 5, {1, 2, 4, 8, 16}, 1},
    {PDS_METHOD_PPM, -1, "radius", 5, {1, 2, 4, 8, 16}, 1},
    {PDS_METHOD_PPM, -1, "alpha", 3, {0.5, 0.7, 0.9}, 0},
    {PDS_METHOD_SPM, -1, "k", 5, {10, 20, 40, 80, 160}, 0},
    {PDS_METHOD_SPM, -1, "max-radius", 5, {1, 3, 10, 30, 100}, 1},
};
#define N_TUNE_GRIDS (sizeof tune_grids / sizeof tune_grids[0])

/* The time a render's --time governs: the whole render, for every method
   (a photon method's eye pass is in its budget: ppm's at 16 samples a
   pixel costs it what PDS's eye rounds cost PDS). */
static double budget_spent(const pds_render_stats *st)
{
    return st->time_total_s;
}

/* One tuning render, for tune.csv. */
typedef struct tune_row {
    int entry;         /* the race entry it tuned */
    const char *key;   /* "k" */
    char value[32];    /* "20" */
    pds_metrics m;
    double time_s;     /* the time its budget governs (budget_spent) */
    long photons;
    int chosen;
} tune_row;

typedef struct tune_log {
    tune_row *rows;
    int n, cap;
} tune_log;

/* The side of a pixel, in scene units, on a plane facing the camera at
   its look-at point: 2 d tan(fov / 2) / height. */
static double race_pixel_size(const pds_scene *scene, const pds_options *opt)
{
    const pds_camera *cam = pds_scene_camera(scene);
    double dx = cam->look_at.x - cam->position.x, dy = cam->look_at.y - cam->position.y;
    double dz = cam->look_at.z - cam->position.z, d = sqrt(dx * dx + dy * dy + dz * dz);
    int h = opt->height > 0 ? opt->height : cam->height;
    double p = 2.0 * d * tan(0.5 * cam->fov_deg * 3.14159265358979323846 / 180.0) / (h > 0 ? h : 1);
    return p > 0.0 && isfinite(p) ? p : 1e-3;
}

/* Tune entry t (index: its place in the race) as the comment above says;
   every render goes to log. 0, or 1 after printing the error. */
static int race_tune(const pds_scene *scene, const pds_image *ref, const pds_image *mask, double pixel_m,
                     double budget_s, race_entry *t,
                     int index, tune_log *log)
{
    size_t g;
    for (g = 0; g < N_TUNE_GRIDS; g++) {
        const tune_grid *tg = &tune_grids[g];
        const opt_spec *s;
        char name[64];
        int idx, i, best = -1, quickest = -1, first = log->n;
        if (tg->method != t->cfg.opt.method) continue;
        if (tg->progressive >= 0 && tg->progressive != (t->cfg.opt.progressive != 0)) continue;
        snprintf(name, sizeof name, "--%s", tg->key);
        idx = option_index(name);
        if (idx < 0 || t->cfg.given[idx]) continue; /* given: kept as it is */
        s = &option_table[idx];
        for (i = 0; i < tg->n; i++) {
            run_cfg c = t->cfg;
            pds_image img = {0, 0, NULL};
            pds_render_stats st;
            pds_metrics m;
            tune_row *row;
            char value[32], context[200];
            snprintf(value, sizeof value, "%.4g", tg->in_pixels ? tg->v[i] * pixel_m : tg->v[i]);
            if (s->set(s, &c, name, value)) return 1;
            c.opt.seed = t->cfg.opt.seed + 1; /* not the reported render's sequence */
            snprintf(context, sizeof context, "race tune %s %s=%s", t->label, tg->key, value);
            if (render_and_compare(scene, &c, ref, mask, &img, &st, &m, context)) return 1;
            pds_image_free(&img);
            if (log->n == log->cap) {
                int cap = log->cap ? 2 * log->cap : 64;
                tune_row *p = (tune_row *)realloc(log->rows, (size_t)cap * sizeof *p);
                if (!p) return fail("%s", "out of memory");
                log->rows = p;
                log->cap = cap;
            }
            row = &log->rows[log->n++];
            row->entry = index;
            row->key = tg->key;
            snprintf(row->value, sizeof row->value, "%s", value);
            row->m = m;
            row->time_s = budget_spent(&st);
            row->photons = st.photons;
            row->chosen = 0;
            /* the first of equal RMSEs wins; NaN never does; nor does a
               render over its time budget */
            if (!isfinite(m.rmse)) continue;
            if (quickest < 0 || row->time_s < log->rows[first + quickest].time_s) quickest = i;
            if (budget_s > 0.0 && row->time_s > budget_s * (1.0 + RACE_TIME_TOLERANCE)) continue;
            if (best < 0 || m.rmse < log->rows[first + best].m.rmse) best = i;
        }
        if (best < 0 && quickest >= 0) {
            best = quickest;
            fprintf(stderr, "pds race: warning: %s: every %s of the grid took more than %.0f%% over the %g s budget; "
                    "kept the quickest, %s=%s\n", t->label, tg->key, 100.0 * RACE_TIME_TOLERANCE, budget_s, tg->key,
                    log->rows[first + best].value);
        }
        if (best < 0) {
            fprintf(stderr, "pds race: warning: %s: no %s of the grid gave a finite RMSE; kept %s's value\n", t->label,
                    tg->key, name);
            continue;
        }
        log->rows[first + best].chosen = 1;
        s->set(s, &t->cfg, name, log->rows[first + best].value); /* a value that was accepted above */
        snprintf(t->tuned + strlen(t->tuned), sizeof t->tuned - strlen(t->tuned), "%s%s=%s", t->tuned[0] ? " " : "",
                 tg->key, log->rows[first + best].value);
        snprintf(t->tuned_keys + strlen(t->tuned_keys), sizeof t->tuned_keys - strlen(t->tuned_keys), "%s%s",
                 t->tuned_keys[0] ? "+" : "", tg->key);
        if (best == 0 || best == tg->n - 1) t->tuned_edge = 1;
    }
    return 0;
}

/* ----------------------------------------------------------- race: budgets */

/* The photons a render traced: spm's streams (its photon count is what
   the streams stand for), the others' photons. */
static long race_traced(const race_entry *t)
{
    return t->cfg.opt.method == PDS_METHOD_SPM ? t->st.streams : t->st.photons;
}

/* Set the flags of every entry (see RACE_TIME_TOLERANCE) and warn on
   stderr about each flagged one. Returns how many are flagged. */
static int race_check_budgets(race_entry *e, int n, const race_budgets *bud)
{
    int i, j, flagged = 0;
    for (i = 0; i < n; i++) {
        race_entry *t = &e[i];
        double budget = bud->value[t->budget], ratio;
        long most = 0;
        t->flags = 0;
        if (!bud->by_time) continue; /* a photon budget is exact */
        ratio = budget_spent(&t->st) / budget;
        if (ratio > 1.0 + RACE_TIME_TOLERANCE) t->flags |= RACE_OVER_TIME;
        else if (ratio < 1.0 - RACE_TIME_TOLERANCE) t->flags |= RACE_UNDER_TIME;
        if (t->flags)
            fprintf(stderr, "pds race: warning: %s took %.3g s of its %g s budget (%+.0f%%): more than %.0f%% off, "
                    "not an equal-time result\n", t->label, budget_spent(&t->st), budget, 100.0 * (ratio - 1.0),
                    100.0 * RACE_TIME_TOLERANCE);
        if (!is_photon_method(t->cfg.opt.method) || t->cfg.opt.paths == PDS_PATHS_NO_CAUSTICS) continue;
        for (j = 0; j < n; j++)
            if (e[j].budget == t->budget && is_photon_method(e[j].cfg.opt.method) && race_traced(&e[j]) > most)
                most = race_traced(&e[j]);
        if (race_traced(t) < RACE_MIN_PHOTONS || (double)race_traced(t) < RACE_MIN_PHOTON_SHARE * (double)most) {
            t->flags |= RACE_FEW_PHOTONS;
            fprintf(stderr, "pds race: warning: %s %s %ld %s in its %g s (the most on that budget: %ld; "
                    "fewer than %d or 1%% of that is too few for a useful estimate)\n", t->label,
                    t->cfg.opt.method == PDS_METHOD_SPM ? "traced" : "emitted", race_traced(t),
                    t->cfg.opt.method == PDS_METHOD_SPM ? "streams" : "photons", budget, most, RACE_MIN_PHOTONS);
        }
    }
    for (i = 0; i < n; i++) flagged += e[i].flags != 0;
    return flagged;
}

/* "ok", or the flags joined by '+': "over-time+few-photons". */
static const char *race_flag_text(unsigned flags, char *out, size_t n)
{
    snprintf(out, n, "%s%s%s%s%s", flags ? "" : "ok", (flags & RACE_OVER_TIME) ? "over-time" : "",
             (flags & RACE_UNDER_TIME) ? "under-time" : "",
             (flags & RACE_FEW_PHOTONS) && (flags & (RACE_OVER_TIME | RACE_UNDER_TIME)) ? "+" : "",
             (flags & RACE_FEW_PHOTONS) ? "few-photons" : "");
    return out;
}

/* Parse --budgets: seconds above 0 (by_time) or photon counts of 1 or more
   (250000, 2.5e5, 250k). 0 or EXIT_USAGE. */
static int parse_budgets(const char *list, race_budgets *b)
{
    char buf[1024], *p = buf;
    b->n = 0;
    b->listed = 1;
    if (strlen(list) >= sizeof buf) return usage_error("%s", "--budgets: the list is too long");
    strcpy(buf, list);
    for (;;) {
        char *comma = strchr(p, ',');
        double v;
        long count;
        if (comma) *comma = '\0';
        if (b->n == MAX_RACE_BUDGETS) return usage_error("--budgets takes at most %d budgets", MAX_RACE_BUDGETS);
        if (b->by_time) {
            if (parse_double(p, &v) || !(v > 0.0) || v > 1e7)
                return usage_error("--budgets needs seconds above 0, comma-separated, got '%s'", list);
        } else {
            if (parse_count(p, 1, LONG_MAX, &count))
                return usage_error("--budgets needs photon counts of 1 or more, comma-separated, got '%s'", list);
            v = (double)count;
        }
        b->value[b->n] = v;
        snprintf(b->text[b->n], sizeof b->text[b->n], b->by_time ? "%g" : "%.0f", v);
        b->n++;
        if (!comma) break;
        p = comma + 1;
    }
    return 0;
}

/* ------------------------------------------------------- race: provenance */

/* The command line, as a shell would take it back: words of plain
   characters as they are, others in single quotes. */
static void sb_command_line(sbuf *b, int argc, char **argv)
{
    int i;
    for (i = 0; i < argc; i++) {
        const char *w = argv[i];
        int plain = w[0] != '\0';
        const char *q;
        for (q = w; *q && plain; q++)
            plain = (*q >= 'a' && *q <= 'z') || (*q >= 'A' && *q <= 'Z') || (*q >= '0' && *q <= '9') ||
                    strchr("_./:=,+-@%", *q) != NULL;
        if (i) sb_printf(b, " ");
        if (plain) {
            sb_printf(b, "%s", w);
            continue;
        }
        sb_printf(b, "'");
        for (q = w; *q; q++) sb_printf(b, *q == '\'' ? "'\\''" : "%c", *q);
        sb_printf(b, "'");
    }
}

/* The processor's name from /proc/cpuinfo ("model name"), or "unknown". */
static void cpu_model(char *out, size_t n)
{
    FILE *f = fopen("/proc/cpuinfo", "r");
    char line[512];
    snprintf(out, n, "unknown");
    if (!f) return;
    while (fgets(line, sizeof line, f)) {
        char *colon = strchr(line, ':'), *v;
        size_t len;
        if (strncmp(line, "model name", 10) != 0 || !colon) continue;
        for (v = colon + 1; *v == ' ' || *v == '\t'; v++) continue;
        len = strcspn(v, "\r\n");
        snprintf(out, n, "%.*s", (int)len, v);
        break;
    }
    fclose(f);
}

/* ------------------------------------------------------ race: convergence */

static const char *const series_colour[8] = {"#1f5fa8", "#c0392b", "#2e8b57", "#8e44ad",
                                             "#d35400", "#16a085", "#7f8c8d", "#b7950b"};

/* A marker of shape k mod 4 (circle, square, triangle, diamond) at (x, y),
   with a tooltip. */
static void svg_marker(sbuf *b, const char *cls, int k, double x, double y, const char *colour, const char *tip)
{
    switch (k % 4) {
    case 0: sb_printf(b, "<circle class=\"%s\" cx=\"%.1f\" cy=\"%.1f\" r=\"4\" fill=\"%s\">", cls, x, y, colour); break;
    case 1:
        sb_printf(b, "<rect class=\"%s\" x=\"%.1f\" y=\"%.1f\" width=\"8\" height=\"8\" fill=\"%s\">", cls, x - 4, y - 4,
                  colour);
        break;
    case 2:
        sb_printf(b, "<polygon class=\"%s\" points=\"%.1f,%.1f %.1f,%.1f %.1f,%.1f\" fill=\"%s\">", cls, x, y - 5, x - 5,
                  y + 4, x + 5, y + 4, colour);
        break;
    default:
        sb_printf(b, "<polygon class=\"%s\" points=\"%.1f,%.1f %.1f,%.1f %.1f,%.1f %.1f,%.1f\" fill=\"%s\">", cls, x,
                  y - 5, x + 5, y, x, y + 5, x - 5, y, colour);
        break;
    }
    sb_printf(b, "<title>");
    sb_xml(b, tip);
    sb_printf(b, "</title>");
    sb_printf(b, k % 4 == 0 ? "</circle>\n" : k % 4 == 1 ? "</rect>\n" : "</polygon>\n");
}

/* The value a convergence panel plots: RMSE, or 1 - SSIM. */
static double race_metric(const race_entry *t, int panel)
{
    return panel == 0 ? t->m.rmse : 1.0 - t->m.ssim;
}

/* convergence.svg: for each method of the race, RMSE (left panel) and
   1 - SSIM (right panel) against the render's measured time, both axes
   logarithmic (whole decades, ticks at 1-9 times each), one line and
   marker shape per method through its budgets. Points that are not
   positive and finite cannot be drawn on log axes and are left out. */
static void race_convergence_svg(sbuf *b, const char *title, const race_entry *e, int n, const char *const *names,
                                 int methods)
{
    static const char *const ylabel[2] = {"RMSE (linear RGB), log scale", "1 - SSIM (sRGB luminance), log scale"};
    double xmin = 0, xmax = 0, ymin[2] = {0, 0}, ymax[2] = {0, 0}, xlo, xhi;
    int seen[2] = {0, 0}, xseen = 0, i, p, k;
    for (i = 0; i < n; i++) {
        double x = e[i].st.time_total_s;
        if (!(x > 0.0) || !isfinite(x)) continue;
        for (p = 0; p < 2; p++) {
            double y = race_metric(&e[i], p);
            if (!(y > 0.0) || !isfinite(y)) continue;
            if (!xseen || x < xmin) xmin = x;
            if (!xseen || x > xmax) xmax = x;
            xseen = 1;
            if (!seen[p] || y < ymin[p]) ymin[p] = y;
            if (!seen[p] || y > ymax[p]) ymax[p] = y;
            seen[p] = 1;
        }
    }
    if (!xseen) xmin = xmax = 1.0;
    log_range(xmin, xmax, &xlo, &xhi);
    sb_printf(b, "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"960\" height=\"%d\" viewBox=\"0 0 960 %d\" "
                 "font-family=\"Helvetica, Arial, sans-serif\" font-size=\"12\">\n<title>",
              470 + 18 * ((methods + 3) / 4), 470 + 18 * ((methods + 3) / 4));
    sb_xml(b, title);
    sb_printf(b, "</title>\n<rect width=\"960\" height=\"100%%\" fill=\"white\"/>\n"
                 "<text x=\"480\" y=\"26\" text-anchor=\"middle\" font-size=\"16\" font-weight=\"bold\">");
    sb_xml(b, title);
    sb_printf(b, "</text>\n");
    for (p = 0; p < 2; p++) {
        plot_frame f;
        double ylo, yhi, d;
        f.left = 80 + 480 * p;
        f.right = f.left + 360;
        f.top = 60;
        f.bottom = 380;
        f.pad = 0;
        f.logx = 1;
        f.logy = 1;
        f.xmin = xlo;
        f.xmax = xhi;
        if (!seen[p]) ymin[p] = ymax[p] = 1.0;
        log_range(ymin[p], ymax[p], &ylo, &yhi);
        sb_printf(b, "<g class=\"panel %s log-x log-y\">\n", p == 0 ? "rmse" : "one-minus-ssim");
        /* grid and ticks: decades labelled */
        for (d = xlo; d <= xhi * (1 + 1e-9); d *= 10.0) {
            for (k = 1; k <= 9 && d * k <= xhi * (1 + 1e-9); k++) {
                double px = plot_x(&f, d * k);
                sb_printf(b, "<line x1=\"%.1f\" y1=\"%.0f\" x2=\"%.1f\" y2=\"%.0f\" stroke=\"%s\"/>", px, f.top, px,
                          f.bottom, k == 1 ? "#dddddd" : "#f3f3f3");
                if (k == 1)
                    sb_printf(b, "<text x=\"%.1f\" y=\"%.0f\" text-anchor=\"middle\" font-size=\"11\">%g</text>", px,
                              f.bottom + 16, d);
                sb_printf(b, "\n");
            }
        }
        for (d = ylo; d <= yhi * (1 + 1e-9); d *= 10.0) {
            for (k = 1; k <= 9 && d * k <= yhi * (1 + 1e-9); k++) {
                double py = plot_logy(&f, d * k, ylo, yhi);
                sb_printf(b, "<line x1=\"%.0f\" y1=\"%.1f\" x2=\"%.0f\" y2=\"%.1f\" stroke=\"%s\"/>", f.left, py,
                          f.right, py, k == 1 ? "#dddddd" : "#f3f3f3");
                if (k == 1)
                    sb_printf(b, "<text x=\"%.0f\" y=\"%.1f\" text-anchor=\"end\" font-size=\"11\">%g</text>",
                              f.left - 6, py + 4, d);
                sb_printf(b, "\n");
            }
        }
        sb_printf(b, "<rect x=\"%.0f\" y=\"%.0f\" width=\"%.0f\" height=\"%.0f\" fill=\"none\" stroke=\"#444\"/>\n",
                  f.left, f.top, f.right - f.left, f.bottom - f.top);
        sb_printf(b, "<text x=\"%.0f\" y=\"%.0f\" text-anchor=\"middle\" font-size=\"13\">time (s), log scale</text>\n",
                  0.5 * (f.left + f.right), f.bottom + 38);
        sb_printf(b, "<text transform=\"translate(%.0f %.0f) rotate(-90)\" text-anchor=\"middle\" font-size=\"13\">%s"
                     "</text>\n", f.left - 52, 0.5 * (f.top + f.bottom), ylabel[p]);
        /* one series per method, its points in order of time */
        for (k = 0; k < methods; k++) {
            int order[MAX_RACE_ENTRIES], m = 0, j;
            const char *col = series_colour[k % 8];
            for (i = 0; i < n; i++) {
                double x = e[i].st.time_total_s, y = race_metric(&e[i], p);
                if (e[i].method != k || !(x > 0.0) || !isfinite(x) || !(y > 0.0) || !isfinite(y)) continue;
                for (j = m; j > 0 && e[order[j - 1]].st.time_total_s > x; j--) order[j] = order[j - 1];
                order[j] = i;
                m++;
            }
            sb_printf(b, "<polyline class=\"series\" data-method=\"");
            sb_xml(b, names[k]);
            sb_printf(b, "\" fill=\"none\" stroke=\"%s\" stroke-width=\"2\" points=\"", col);
            for (j = 0; j < m; j++)
                sb_printf(b, "%s%.1f,%.1f", j ? " " : "", plot_x(&f, e[order[j]].st.time_total_s),
                          plot_logy(&f, race_metric(&e[order[j]], p), ylo, yhi));
            sb_printf(b, "\"/>\n");
            for (j = 0; j < m; j++) {
                const race_entry *t = &e[order[j]];
                char tip[256];
                snprintf(tip, sizeof tip, "%s: %s %.6g at %.3g s", t->label, p == 0 ? "RMSE" : "1 - SSIM",
                         race_metric(t, p), t->st.time_total_s);
                svg_marker(b, "point", k, plot_x(&f, t->st.time_total_s), plot_logy(&f, race_metric(t, p), ylo, yhi), col, tip);
            }
        }
        sb_printf(b, "</g>\n");
    }
    /* legend: four methods a row */
    sb_printf(b, "<g class=\"legend\">\n");
    for (k = 0; k < methods; k++) {
        double x = 80 + 220 * (k % 4), y = 450 + 18 * (k / 4);
        sb_printf(b, "<line x1=\"%.0f\" y1=\"%.0f\" x2=\"%.0f\" y2=\"%.0f\" stroke=\"%s\" stroke-width=\"2\"/>", x, y,
                  x + 28, y, series_colour[k % 8]);
        svg_marker(b, "legend-marker", k, x + 14, y, series_colour[k % 8], names[k]);
        sb_printf(b, "<text x=\"%.0f\" y=\"%.0f\">", x + 34, y + 4);
        sb_xml(b, names[k]);
        sb_printf(b, "</text>\n");
    }
    sb_printf(b, "</g>\n</svg>\n");
}

/* What race_html shows besides the entries. */
typedef struct race_page {
    const char *scene_path, *ref_path, *mask_path; /* mask_path: --mask, or NULL */
    const run_cfg *base;
    const race_budgets *bud;
    const pds_image *ref;
    roi_box roi;
    int roi_given, scale;
    double crop_exposure;   /* stops: the crops' exposure */
    const char *diff_mode;  /* "shared", "each" or a number */
    int tuned;              /* --tune */
    double pixel_m;         /* the tuning grid's radius unit */
    int methods;            /* entries of --methods */
} race_page;

/* A time cell: seconds, or a dash when the phase is not the method's. */
static void html_time(sbuf *b, int applies, double s)
{
    if (applies) sb_printf(b, "<td>%.3f</td>", s);
    else sb_printf(b, "<td>&ndash;</td>");
}

/* The image comparer: two images of the race (A, B) over each other in a
   slider (B right of the pointer), hover (B under the pointer) or flip
   (click or space) view, zoomed with nearest neighbour, the full images or
   the crops. Inline script, no network: the page stays one folder. */
static void html_comparer(sbuf *b, const race_entry *e, int n, const race_page *pg)
{
    int i, zoom, W = pg->ref->width, H = pg->ref->height;
    sb_printf(b, "<h2>Compare</h2>\n<div class=\"cmp\">\n<p class=\"meta\">Pick two images; in <b>slider</b> mode A "
                 "is left and B right of the pointer, in <b>hover</b> mode B shows under the pointer, in <b>flip</b> "
                 "mode a click (or the space bar) swaps them. Zoom enlarges pixels without smoothing.</p>\n");
    for (i = 0; i < 2; i++) {
        int k;
        sb_printf(b, "<label>%s <select id=\"cmp-%s\">", i ? "B" : "A", i ? "b" : "a");
        sb_printf(b, "<option value=\"ref.png\" data-crop=\"ref-crop.png\"%s>reference</option>", i ? "" : " selected");
        for (k = 0; k < n; k++) {
            sb_printf(b, "<option value=\"");
            sb_xml(b, e[k].label);
            sb_printf(b, ".png\" data-crop=\"");
            sb_xml(b, e[k].label);
            sb_printf(b, "-crop.png\"%s>", i && k == 0 ? " selected" : "");
            sb_xml(b, e[k].label);
            sb_printf(b, "</option>");
        }
        sb_printf(b, "</select></label>\n");
    }
    sb_printf(b, "<label>view <select id=\"cmp-mode\"><option value=\"slider\">slider</option>"
                 "<option value=\"hover\">hover</option><option value=\"flip\">flip</option></select></label>\n"
                 "<label>zoom <select id=\"cmp-zoom\">");
    /* at first, the smallest zoom that shows the image at least 256 pixels wide */
    for (i = 0, zoom = 1; zoom <= 16; zoom *= 2) {
        int pick = !i && (W * zoom >= 256 || zoom == 16);
        sb_printf(b, "<option value=\"%d\"%s>%dx</option>", zoom, pick ? " selected" : "", zoom);
        i |= pick;
    }
    sb_printf(b, "</select></label>\n"
                 "<label>images <select id=\"cmp-set\"><option value=\"full\">full</option>"
                 "<option value=\"crop\">region of interest</option></select></label>\n"
                 "<span id=\"cmp-label\" class=\"cmp-label\"></span>\n");
    sb_printf(b, "<div class=\"cmp-view\"><div id=\"cmp-stage\" class=\"cmp-stage\" data-w=\"%d\" data-h=\"%d\" "
                 "data-cw=\"%d\" data-ch=\"%d\" style=\"width:%dpx;height:%dpx\">"
                 "<img id=\"cmp-ia\" src=\"ref.png\" alt=\"A\">",
              W, H, pg->roi.w * pg->scale, pg->roi.h * pg->scale, W, H);
    sb_printf(b, "<img id=\"cmp-ib\" src=\"");
    sb_xml(b, n > 0 ? e[0].label : "ref");
    sb_printf(b, ".png\" alt=\"B\"><div id=\"cmp-bar\" class=\"cmp-bar\"></div></div></div>\n</div>\n");
    sb_printf(b,
              "<script>\n"
              "(function () {\n"
              "  'use strict';\n"
              "  function el(id) { return document.getElementById(id); }\n"
              "  var a = el('cmp-a'), b = el('cmp-b'), mode = el('cmp-mode'), zoom = el('cmp-zoom');\n"
              "  var set = el('cmp-set'), stage = el('cmp-stage'), ia = el('cmp-ia'), ib = el('cmp-ib');\n"
              "  var bar = el('cmp-bar'), label = el('cmp-label');\n"
              "  var split = 0.5, flipped = false, inside = false;\n"
              "  function pick(sel) {\n"
              "    var o = sel.options[sel.selectedIndex];\n"
              "    return set.value === 'crop' ? o.getAttribute('data-crop') : o.value;\n"
              "  }\n"
              "  function name(sel) { return sel.options[sel.selectedIndex].text; }\n"
              "  function draw() {\n"
              "    var crop = set.value === 'crop', z = Number(zoom.value), showB;\n"
              "    var w = Number(stage.getAttribute(crop ? 'data-cw' : 'data-w'));\n"
              "    var h = Number(stage.getAttribute(crop ? 'data-ch' : 'data-h'));\n"
              "    if (ia.getAttribute('src') !== pick(a)) ia.setAttribute('src', pick(a));\n"
              "    if (ib.getAttribute('src') !== pick(b)) ib.setAttribute('src', pick(b));\n"
              "    stage.style.width = (w * z) + 'px';\n"
              "    stage.style.height = (h * z) + 'px';\n"
              "    if (mode.value === 'slider') {\n"
              "      ib.style.visibility = 'visible';\n"
              "      ib.style.clipPath = 'inset(0 0 0 ' + (100 * split) + '%%)';\n"
              "      bar.style.display = 'block';\n"
              "      bar.style.left = (100 * split) + '%%';\n"
              "      label.textContent = 'left: ' + name(a) + ', right: ' + name(b);\n"
              "    } else {\n"
              "      showB = mode.value === 'flip' ? flipped : inside;\n"
              "      ib.style.clipPath = 'none';\n"
              "      ib.style.visibility = showB ? 'visible' : 'hidden';\n"
              "      bar.style.display = 'none';\n"
              "      label.textContent = 'showing ' + (showB ? name(b) : name(a));\n"
              "    }\n"
              "  }\n"
              "  stage.addEventListener('mousemove', function (ev) {\n"
              "    var r = stage.getBoundingClientRect();\n"
              "    split = Math.min(1, Math.max(0, (ev.clientX - r.left) / r.width));\n"
              "    if (mode.value === 'slider') draw();\n"
              "  });\n"
              "  stage.addEventListener('mouseenter', function () { inside = true; draw(); });\n"
              "  stage.addEventListener('mouseleave', function () { inside = false; draw(); });\n"
              "  stage.addEventListener('click', function () { flipped = !flipped; draw(); });\n"
              "  document.addEventListener('keydown', function (ev) {\n"
              "    if (mode.value === 'flip' && (ev.key === ' ' || ev.key === 'f')) {\n"
              "      flipped = !flipped;\n"
              "      draw();\n"
              "      ev.preventDefault();\n"
              "    }\n"
              "  });\n"
              "  [a, b, mode, zoom, set].forEach(function (s) { s.addEventListener('change', draw); });\n"
              "  draw();\n"
              "  document.body.setAttribute('data-comparer', 'ready');\n"
              "  /* for tests/check_race_page.sh: how many images failed to load */\n"
              "  window.addEventListener('load', function () {\n"
              "    var imgs = document.images, broken = 0, i;\n"
              "    for (i = 0; i < imgs.length; i++) if (!imgs[i].complete || imgs[i].naturalWidth === 0) broken++;\n"
              "    document.body.setAttribute('data-broken-images', String(broken));\n"
              "  });\n"
              "})();\n"
              "</script>\n");
}

/* index.html: provenance, warnings, the table, the convergence plot (with
   several budgets), the comparer, then rows of full images, crops and
   differences, reference first. Paths relative to the folder; the one
   script is inline. */
static void race_html(sbuf *b, const race_page *pg, const race_entry *e, int n, int argc, char **argv)
{
    const race_budgets *bud = pg->bud;
    const pds_image *ref = pg->ref;
    roi_box roi = pg->roi;
    int i, W = ref->width, H = ref->height, scale = pg->scale, warned = 0;
    int dw = W < 256 ? W * ((256 + W - 1) / W) : W > 640 ? 640 : W;
    int best_r[MAX_RACE_BUDGETS], best_s[MAX_RACE_BUDGETS];
    char src[160], alt[160], text[256], flag[64];
    sbuf c = {NULL, 0, 0, 0};
    time_t now = time(NULL);
    struct tm *utc = gmtime(&now);
#ifndef _WIN32
    struct utsname un;
#endif
    for (i = 0; i < bud->n; i++) best_r[i] = best_s[i] = -1;
    for (i = 0; i < n; i++) {
        int k = e[i].budget;
        if (isfinite(e[i].m.rmse) && (best_r[k] < 0 || e[i].m.rmse < e[best_r[k]].m.rmse)) best_r[k] = i;
        if (isfinite(e[i].m.ssim) && (best_s[k] < 0 || e[i].m.ssim > e[best_s[k]].m.ssim)) best_s[k] = i;
    }
    sb_printf(b, "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>pds race: ");
    sb_xml(b, pg->scene_path);
    sb_printf(b,
              "</title>\n<style>\n"
              "body { font-family: Helvetica, Arial, sans-serif; margin: 24px; color: #222; background: #fafafa; }\n"
              "h1 { font-size: 22px; } h2 { font-size: 17px; margin-top: 28px; }\n"
              "p.meta { color: #444; max-width: 980px; line-height: 1.5; }\n"
              "table { border-collapse: collapse; font-size: 14px; }\n"
              "th, td { border: 1px solid #ccc; padding: 4px 10px; text-align: right; }\n"
              "th { background: #eee; } .l { text-align: left; }\n"
              "td.best { font-weight: bold; background: #e3f2e6; }\n"
              "td.flag { color: #a00; font-weight: bold; text-align: left; }\n"
              ".warn { border: 2px solid #c00; background: #fff0f0; padding: 6px 14px; max-width: 980px; }\n"
              "pre.cmd { background: #f0f0f0; padding: 8px; white-space: pre-wrap; word-break: break-all; "
              "max-width: 980px; }\n"
              ".row { display: flex; flex-wrap: wrap; gap: 18px; align-items: flex-start; }\n"
              "figure { margin: 0; }\n"
              "figcaption { font-size: 13px; margin-top: 4px; max-width: 320px; }\n"
              ".frame { position: relative; line-height: 0; }\n"
              ".frame img { width: 100%%; height: auto; image-rendering: pixelated; "
              "image-rendering: crisp-edges; border: 1px solid #888; box-sizing: border-box; }\n"
              ".roi { position: absolute; border: 2px solid #ffd400; box-sizing: border-box; }\n"
              ".key span { display: inline-block; width: 12px; height: 12px; vertical-align: middle; }\n"
              ".cmp label { margin-right: 14px; } .cmp-label { color: #444; font-size: 13px; }\n"
              ".cmp-view { overflow: auto; max-width: 100%%; max-height: 80vh; margin-top: 8px; "
              "border: 1px solid #888; display: inline-block; }\n"
              ".cmp-stage { position: relative; cursor: crosshair; }\n"
              ".cmp-stage img { position: absolute; left: 0; top: 0; width: 100%%; height: 100%%; "
              "image-rendering: pixelated; image-rendering: crisp-edges; }\n"
              ".cmp-bar { position: absolute; top: 0; bottom: 0; width: 0; border-left: 2px solid #ffd400; }\n"
              "</style>\n</head>\n<body>\n<h1>pds race: ");
    sb_xml(b, pg->scene_path);
    sb_printf(b, "</h1>\n<p class=\"meta\">Reference <code>");
    sb_xml(b, pg->ref_path);
    sb_printf(b, "</code>, %dx%d, light paths: %s. ", W, H, paths_name(pg->base->opt.paths));
    if (pg->mask_path) {
        sb_printf(b, "RMSE and SSIM over the pixels the mask <code>");
        sb_xml(b, pg->mask_path);
        sb_printf(b, "</code> holds. ");
    }
    if (bud->by_time) sb_printf(b, "Budget%s: ", bud->n > 1 ? "s" : "");
    else sb_printf(b, "Photon budget%s: ", bud->n > 1 ? "s" : "");
    for (i = 0; i < bud->n; i++) sb_printf(b, "%s%s", i ? ", " : "", bud->text[i]);
    sb_printf(b, "%s for every method%s. ", bud->by_time ? " s" : " photons",
              bud->by_time ? "" : " (ppm: over all its passes; pt and preview emit none)");
    sb_printf(b, "RMSE over all pixels and channels of the linear values; SSIM (11x11 Gaussian window, "
                 "&sigma; 1.5) of the luminance of the sRGB-encoded values clamped to [0, 1]. ");
    sb_printf(b, "Region of interest: x %d, y %d, %dx%d pixels (%s), framed in yellow; crops enlarged %dx with "
                 "nearest neighbour. Data: <a href=\"race.csv\">race.csv</a>%s.</p>\n",
              roi.x, roi.y, roi.w, roi.h,
              pg->roi_given ? "given with --roi"
                            : "chosen: the window of at most 64x64 where the reference's luminance varies most",
              scale, pg->tuned ? ", the tuning renders: <a href=\"tune.csv\">tune.csv</a>" : "");
    if (pg->tuned)
        sb_printf(b, "<p class=\"meta\"><b>Tuned</b> (<code>--tune</code>): each method's main parameter was chosen "
                     "for each budget as the value of lowest RMSE on a fixed grid, rendered with seed %llu, not the "
                     "seed %llu of the renders shown, so the choice does not fit their own noise. Grids: pds and pdm "
                     "s in 4, 6, 8, 12, 16, 24; pm k in 10, 20, 40, 80, 160; splat R and ppm R0 in 1, 2, 4, 8, 16 "
                     "pixels (one pixel: %.4g scene units at the camera's look-at distance); ppm alpha in 0.5, 0.7, "
                     "0.9 after R0; spm k as pm, then R in 1, 3, 10, 30, 100 pixels. A value given on the command line is "
                     "kept.</p>\n",
                  pg->base->opt.seed + 1, pg->base->opt.seed, pg->pixel_m);
    /* provenance */
    sb_printf(b, "<h2>How this page was made</h2>\n<pre class=\"cmd\" id=\"command\">");
    {
        sbuf cmd = {NULL, 0, 0, 0};
        sb_command_line(&cmd, argc, argv);
        sb_xml(b, cmd.s ? cmd.s : "");
        if (cmd.nomem) b->nomem = 1;
        free(cmd.s);
    }
    sb_printf(b, "</pre>\n<table class=\"provenance\">\n");
    sb_printf(b, "<tr><th class=\"l\">pds version</th><td class=\"l\">%s</td></tr>\n", PDS_VERSION_STRING);
    sb_printf(b, "<tr><th class=\"l\">seed</th><td class=\"l\">%llu%s</td></tr>\n", pg->base->opt.seed,
              pg->tuned ? " (tuning renders: the seed + 1)" : "");
    sb_printf(b, "<tr><th class=\"l\">threads</th><td class=\"l\">%d used (%s)</td></tr>\n", n > 0 ? e[0].st.threads : 0,
              pg->base->opt.threads > 0 ? "given with --threads" : "all cores");
#ifdef _WIN32
    sb_printf(b, "<tr><th class=\"l\">machine</th><td class=\"l\" id=\"machine\">Windows</td></tr>\n");
#else
    if (uname(&un) == 0) {
        sb_printf(b, "<tr><th class=\"l\">machine</th><td class=\"l\" id=\"machine\">");
        sb_xml(b, un.sysname);
        sb_printf(b, " ");
        sb_xml(b, un.release);
        sb_printf(b, " ");
        sb_xml(b, un.version);
        sb_printf(b, " ");
        sb_xml(b, un.machine);
        sb_printf(b, "</td></tr>\n");
    }
#endif
    cpu_model(text, sizeof text);
    sb_printf(b, "<tr><th class=\"l\">CPU</th><td class=\"l\">");
    sb_xml(b, text);
    sb_printf(b, "</td></tr>\n<tr><th class=\"l\">cores</th><td class=\"l\">%d</td></tr>\n", pds_cpu_count());
    if (utc && strftime(text, sizeof text, "%Y-%m-%d %H:%M:%S UTC", utc) > 0)
        sb_printf(b, "<tr><th class=\"l\">finished</th><td class=\"l\">%s</td></tr>\n", text);
    sb_printf(b, "</table>\n");
    /* what is not a fair comparison, said first */
    for (i = 0; i < n; i++) {
        const race_entry *t = &e[i];
        if (!t->flags && !t->tuned_edge) continue;
        if (!warned++) sb_printf(b, "<div class=\"warn\" id=\"warnings\"><p><b>Not a fair comparison as it stands:</b></p><ul>\n");
        sb_printf(b, "<li>");
        sb_xml(b, t->label);
        if (t->flags & (RACE_OVER_TIME | RACE_UNDER_TIME))
            sb_printf(b, ": took %.3g s of its %s s budget (%+.0f%%, more than %.0f%% off)", budget_spent(&t->st),
                      bud->text[t->budget], 100.0 * (budget_spent(&t->st) / bud->value[t->budget] - 1.0),
                      100.0 * RACE_TIME_TOLERANCE);
        if (t->flags & RACE_FEW_PHOTONS)
            sb_printf(b, ": emitted only %ld photons (fewer than %d, or than 1%% of the most on its budget)",
                      t->st.photons, RACE_MIN_PHOTONS);
        if (t->tuned_edge) {
            sb_printf(b, ": its tuned value (");
            sb_xml(b, t->tuned);
            sb_printf(b, ") is at the edge of the grid; the optimum may lie beyond it");
        }
        sb_printf(b, "</li>\n");
    }
    if (warned) sb_printf(b, "</ul></div>\n");
    /* the table */
    sb_printf(b, "<h2>Results</h2>\n<table class=\"results\">\n<tr><th class=\"l\">image</th><th class=\"l\">method"
                 "</th><th>budget</th><th>photons</th><th>spp</th><th class=\"l\">parameters</th><th class=\"l\">tuned"
                 "</th><th>RMSE</th><th>SSIM</th><th>eye pass (s)</th><th>photon tracing (s)</th><th>map build (s)"
                 "</th><th>gather (s)</th><th>total (s)</th><th>photon map (MB)</th><th class=\"l\">budget check"
                 "</th></tr>\n");
    for (i = 0; i < n; i++) {
        const race_entry *r = &e[i];
        unsigned mb = MBIT(r->cfg.opt.method);
        sb_printf(b, "<tr><td class=\"l\"><a href=\"");
        sb_xml(b, r->label);
        sb_printf(b, ".pfm\">");
        sb_xml(b, r->label);
        sb_printf(b, "</a></td><td class=\"l\">%s</td><td>%s%s</td><td>%ld</td><td>%d</td><td class=\"l\">",
                  method_name(r->cfg.opt.method), bud->text[r->budget], bud->by_time ? " s" : "", r->st.photons,
                  r->st.spp);
        sb_xml(b, r->params[0] ? r->params + 1 : "");
        sb_printf(b, "</td><td class=\"l\">");
        if (r->tuned[0]) sb_xml(b, r->tuned);
        else sb_printf(b, "&ndash;");
        sb_printf(b, "</td><td%s>%.6f</td><td%s>%.6f</td>", i == best_r[r->budget] ? " class=\"best\"" : "",
                  r->m.rmse, i == best_s[r->budget] ? " class=\"best\"" : "", r->m.ssim);
        html_time(b, 1, r->st.time_eye_s);
        html_time(b, (mb & M_PHOTON) != 0, r->st.time_photons_s);
        html_time(b, (mb & M_MAP) != 0, r->st.time_map_s);
        html_time(b, (mb & M_MAP) != 0, r->st.time_gather_s);
        html_time(b, 1, r->st.time_total_s);
        if (mb & M_MAP) sb_printf(b, "<td>%.3f</td>", (double)r->st.map_bytes / 1048576.0);
        else sb_printf(b, "<td>&ndash;</td>");
        sb_printf(b, "<td class=\"%s\">%s</td></tr>\n", r->flags ? "flag" : "l",
                  race_flag_text(r->flags, flag, sizeof flag));
    }
    sb_printf(b, "</table>\n<p class=\"meta\">Phases: the eye pass (for pt, the whole render); photon tracing, "
                 "which for pds and splat includes the splats and for pm, pdm and ppm the map build and gather "
                 "after it; a time budget is the whole render's (total); the best RMSE and SSIM of each budget in bold.</p>\n");
    if (bud->n > 1)
        sb_printf(b, "<h2>Convergence</h2>\n<p class=\"meta\">RMSE and 1 &minus; SSIM against each render's "
                     "measured time, log-log (<a href=\"convergence.svg\">convergence.svg</a>).</p>\n"
                     "<img src=\"convergence.svg\" alt=\"RMSE and 1 - SSIM against time, log-log\" width=\"960\">\n");
    html_comparer(b, e, n, pg);
    /* full images */
    sb_printf(b, "<h2>Images</h2>\n<div class=\"row\">\n");
    html_figure(b, "ref.png", "reference", "reference", W, H, dw, &roi);
    for (i = 0; i < n; i++) {
        c.len = 0;
        sb_xml(&c, e[i].label);
        sb_printf(&c, "<br>RMSE %.5f, SSIM %.4f, %.2f s", e[i].m.rmse, e[i].m.ssim, e[i].st.time_total_s);
        snprintf(src, sizeof src, "%s.png", e[i].label);
        if (!c.nomem) html_figure(b, src, e[i].label, c.s, W, H, dw, &roi);
    }
    sb_printf(b, "</div>\n<h2>Region of interest</h2>\n<p class=\"meta\">Crops at exposure %+.2f stops, which "
                 "shows the reference's brightest value in the region as white, so the caustic's peak is not "
                 "clipped (full images: %+.2f stops, <code>--exposure</code>).</p>\n<div class=\"row\">\n",
              pg->crop_exposure, pg->base->exposure);
    html_figure(b, "ref-crop.png", "reference, region of interest", "reference", roi.w * scale, roi.h * scale,
                roi.w * scale, NULL);
    for (i = 0; i < n; i++) {
        c.len = 0;
        sb_xml(&c, e[i].label);
        snprintf(src, sizeof src, "%s-crop.png", e[i].label);
        snprintf(alt, sizeof alt, "%s, region of interest", e[i].label);
        if (!c.nomem) html_figure(b, src, alt, c.s, roi.w * scale, roi.h * scale, roi.w * scale, NULL);
    }
    sb_printf(b, "</div>\n<h2>Difference from the reference</h2>\n<p class=\"meta key\">Luminance of image minus "
                 "reference (linear): <span style=\"background:#0f0\"></span> green where the image is too bright, "
                 "<span style=\"background:#f00\"></span> red where it is too dark, blue where the value is not a "
                 "number. ");
    if (!strcmp(pg->diff_mode, "each"))
        sb_printf(b, "Each image on its own scale: full colour at the 99th percentile of its |error| (given under "
                     "it); colours do not compare across images.</p>\n");
    else if (!strcmp(pg->diff_mode, "shared"))
        sb_printf(b, "<b>One scale for all</b>: full colour at |error| %.4g, the largest of the images' 99th "
                     "percentiles of |error| (<code>--diff-scale each</code> gives each its own).</p>\n",
                  n > 0 ? e[0].diff_scale : 0.0);
    else
        sb_printf(b, "<b>One scale for all</b>: full colour at |error| %.4g (<code>--diff-scale</code>).</p>\n",
                  n > 0 ? e[0].diff_scale : 0.0);
    sb_printf(b, "<div class=\"row\">\n");
    for (i = 0; i < n; i++) {
        c.len = 0;
        sb_xml(&c, e[i].label);
        sb_printf(&c, "<br>full colour at |error| %.4g", e[i].diff_scale);
        snprintf(src, sizeof src, "%s-diff.png", e[i].label);
        snprintf(alt, sizeof alt, "%s, difference from the reference", e[i].label);
        if (!c.nomem) html_figure(b, src, alt, c.s, W, H, dw, &roi);
    }
    sb_printf(b, "</div>\n<p class=\"meta\">Made by <code>pds race</code> (pds %s).</p>\n</body>\n</html>\n",
              PDS_VERSION_STRING);
    if (c.nomem) b->nomem = 1;
    free(c.s);
}

/* Parse "X,Y,W,H"; 0 or -1. */
static int parse_roi(const char *s, roi_box *r)
{
    long v[4];
    char buf[128], *p = buf;
    int k;
    if (strlen(s) >= sizeof buf) return -1;
    strcpy(buf, s);
    for (k = 0; k < 4; k++) {
        char *comma = strchr(p, ',');
        if ((comma != NULL) != (k < 3)) return -1;
        if (comma) *comma = '\0';
        if (parse_int(p, k < 2 ? 0 : 1, PDS_MAX_RESOLUTION, &v[k])) return -1;
        p = comma ? comma + 1 : p;
    }
    r->x = (int)v[0];
    r->y = (int)v[1];
    r->w = (int)v[2];
    r->h = (int)v[3];
    return 0;
}

static const char *const race_own_options[] = {"--ref",        "--methods",    "--roi",    "--output", "--tune",
                                               "--budgets",    "--budget-kind", "--diff-scale", "--resume", "--mask",
                                               NULL};

/* race's entries (see "keeping finished entries"): the extra fields are
   the tuning's outcome and the parameters after it. */
static int race_keep_entry(const char *dir, const race_entry *t, const char *key)
{
    char extra[512];
    snprintf(extra, sizeof extra, "%d\t%s\t%s\t%s", t->tuned_edge, t->params, t->tuned, t->tuned_keys);
    return keep_entry(dir, t->label, key, &t->img, &t->st, extra);
}

static int race_load_entry(const char *dir, race_entry *t, const char *key, const pds_image *ref,
                           const pds_image *mask)
{
    char extra[512], *f[4];
    int k, r = load_entry(dir, t->label, key, ref, mask, &t->img, &t->st, &t->m, extra, sizeof extra);
    if (r <= 0) return r;
    f[0] = extra;
    for (k = 1; k < 4; k++) {
        f[k] = strchr(f[k - 1], '\t');
        if (!f[k]) {
            pds_image_free(&t->img);
            return 0; /* not a race entry's line: render it again */
        }
        *f[k]++ = '\0';
    }
    t->tuned_edge = atoi(f[0]);
    snprintf(t->params, sizeof t->params, "%s", f[1]);
    snprintf(t->tuned, sizeof t->tuned, "%s", f[2]);
    snprintf(t->tuned_keys, sizeof t->tuned_keys, "%s", f[3]);
    return 1;
}

/* The largest finite channel value of img in the region (0 if none). */
static double roi_peak(const pds_image *img, roi_box roi)
{
    double peak = 0.0;
    int x, y, k;
    for (y = roi.y; y < roi.y + roi.h; y++)
        for (x = roi.x; x < roi.x + roi.w; x++)
            for (k = 0; k < 3; k++) {
                double v = img->rgb[3 * ((size_t)y * img->width + x) + k];
                if (isfinite(v) && v > peak) peak = v;
            }
    return peak;
}

static int cmd_race(int argc, char **argv)
{
    const char *scene_path = NULL, *ref_path = NULL, *methods = NULL, *dir = NULL, *roi_text = NULL, *mask_path = NULL;
    const char *budgets_text = NULL, *kind_text = NULL, *diff_mode = "shared";
    const char *names[MAX_RACE_METHODS];
    char dir_buf[1024], stem[256];
    run_cfg base;
    race_entry *e = NULL, *proto = NULL;
    race_budgets bud;
    race_page pg;
    tune_log tlog = {NULL, 0, 0};
    pds_scene *scene = NULL;
    pds_image ref = {0, 0, NULL}, mask_img = {0, 0, NULL}; /* --mask: the pixels the metrics take */
    roi_box roi = {0, 0, 0, 0};
    int i, r, n = 0, n_methods = 0, rc = 1, by_photons, tune = 0, scale, flagged, resume = 0, resumed = 0;
    double diff_fixed = 0.0, pixel_m = 0.0, peak;
    unsigned mask = 0;
    cfg_init(&base);
    memset(&bud, 0, sizeof bud);
    for (i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (a[0] != '-' || a[1] == '\0') {
            if (scene_path) return usage_error("race takes one scene, got another: '%s'", a);
            scene_path = a;
            continue;
        }
        if (arg_is(a, "--tune")) {
            if (a[6] == '=') return usage_error("--tune takes no value, got '%s'", a);
            tune = 1;
            continue;
        }
        if (arg_is(a, "--resume")) {
            if (a[8] == '=') return usage_error("--resume takes no value, got '%s'", a);
            resume = 1;
            continue;
        }
        if (arg_is(a, "--ref") || arg_is(a, "--methods") || arg_is(a, "--roi") || arg_is(a, "-o") ||
            arg_is(a, "--output") || arg_is(a, "--budgets") || arg_is(a, "--budget-kind") ||
            arg_is(a, "--diff-scale") || arg_is(a, "--mask")) {
            const char *v;
            if (option_value(argc, argv, &i, &v)) return EXIT_USAGE;
            if (arg_is(a, "--ref")) ref_path = v;
            else if (arg_is(a, "--mask")) mask_path = v;
            else if (arg_is(a, "--methods")) methods = v;
            else if (arg_is(a, "--roi")) roi_text = v;
            else if (arg_is(a, "--budgets")) budgets_text = v;
            else if (arg_is(a, "--budget-kind")) kind_text = v;
            else if (arg_is(a, "--diff-scale")) diff_mode = v;
            else dir = v;
            continue;
        }
        r = parse_option(&base, C_RACE, "race", argc, argv, &i);
        if (r < 0) return unknown_option(a, C_RACE, race_own_options);
        if (r) return r;
    }
    if (!scene_path) return usage_error("%s", "race needs a scene file");
    image_out_set(&base);
    if (!ref_path) return usage_error("%s", "race needs --ref REFERENCE.pfm");
    if (!methods) return usage_error("%s", "race needs --methods M1,M2,... (for example pds,pm:k=50,ppm)");
    bud.by_time = option_given(&base, "--time");
    by_photons = option_given(&base, "--photons");
    if (bud.by_time && by_photons) return usage_error("%s", "race takes one budget: --time or --photons, not both");
    if (budgets_text && (bud.by_time || by_photons))
        return usage_error("--budgets replaces %s: give one of them", bud.by_time ? "--time" : "--photons");
    if (kind_text && !budgets_text) return usage_error("%s", "--budget-kind goes with --budgets");
    if (budgets_text) {
        if (kind_text && strcmp(kind_text, "time") && strcmp(kind_text, "photons"))
            return usage_error("--budget-kind knows time and photons, got '%s'", kind_text);
        bud.by_time = !kind_text || !strcmp(kind_text, "time");
        if (parse_budgets(budgets_text, &bud)) return EXIT_USAGE;
    } else if (bud.by_time || by_photons) {
        bud.n = 1;
        bud.value[0] = bud.by_time ? base.opt.time_s : (double)base.opt.photons;
        snprintf(bud.text[0], sizeof bud.text[0], bud.by_time ? "%g" : "%.0f", bud.value[0]);
    } else {
        return usage_error("%s", "race needs a budget: --time SECONDS, --photons N or --budgets LIST");
    }
    if (strcmp(diff_mode, "shared") && strcmp(diff_mode, "each") &&
        (parse_double(diff_mode, &diff_fixed) || !(diff_fixed > 0.0) || !isfinite(diff_fixed)))
        return usage_error("--diff-scale needs shared, each or a positive number, got '%s'", diff_mode);
    if (roi_text && parse_roi(roi_text, &roi))
        return usage_error("--roi needs X,Y,WIDTH,HEIGHT in pixels, got '%s'", roi_text);
    cfg_apply_progress(&base);
    proto = (race_entry *)calloc(MAX_RACE_METHODS, sizeof *proto);
    e = (race_entry *)calloc(MAX_RACE_ENTRIES, sizeof *e);
    if (!proto || !e) {
        free(proto);
        free(e);
        return fail("%s", "out of memory");
    }
    if ((rc = parse_race_methods(methods, &base, proto, &n_methods)) != 0) goto done;
    rc = 1;
    if (n_methods * bud.n > MAX_RACE_ENTRIES) {
        rc = usage_error("%d methods on %d budgets make %d renders; at most %d", n_methods, bud.n, n_methods * bud.n,
                         MAX_RACE_ENTRIES);
        goto done;
    }
    /* the entries: every method on every budget, budget by budget */
    for (r = 0; r < bud.n; r++)
        for (i = 0; i < n_methods; i++) {
            race_entry *t = &e[n++];
            pds_options *o = &t->cfg.opt;
            *t = proto[i];
            t->method = i;
            t->budget = r;
            if (bud.listed)
                snprintf(t->label + strlen(t->label), sizeof t->label - strlen(t->label), "-%s%s", bud.text[r],
                         bud.by_time ? "s" : "ph");
            if (bud.by_time) {
                o->time_s = bud.value[r];
            } else {
                /* a photon budget is the total: ppm spreads it over its passes */
                o->time_s = 0.0;
                o->photons = (long)bud.value[r];
                if (o->method == PDS_METHOD_PPM) {
                    o->photons /= o->passes > 0 ? o->passes : 1;
                    if (o->photons < 1) o->photons = 1;
                }
            }
            mask |= MBIT(o->method);
        }
    for (i = 0; i < n_methods; i++) names[i] = proto[i].label;
    note_idle_options(&base, mask, "for any method raced");
    scene_stem(scene_path, stem, sizeof stem);
    if (!dir) {
        snprintf(dir_buf, sizeof dir_buf, "race-%s", stem);
        dir = dir_buf;
    }
    if (check_out_dir(dir)) goto done;
    if (load_scene_and_ref("race", scene_path, ref_path, &base.opt, &scene, &ref)) goto done;
    if (mask_path && load_mask(mask_path, &ref, &mask_img)) goto done;
    print_scene_warnings(scene, &base);
    if (roi_text) {
        if (roi.x + roi.w > ref.width || roi.y + roi.h > ref.height) {
            rc = usage_error("--roi %s does not fit the %dx%d image", roi_text, ref.width, ref.height);
            goto done;
        }
    } else if (choose_roi(&ref, &roi)) {
        goto done;
    }
    /* crops at least 256 pixels wide, within the image size limit */
    scale = (256 + roi.w - 1) / roi.w;
    if (scale > PDS_MAX_RESOLUTION / roi.h) scale = PDS_MAX_RESOLUTION / roi.h;
    pixel_m = race_pixel_size(scene, &base.opt);

    for (i = 0; i < n; i++) {
        race_entry *t = &e[i];
        char context[160], key[600];
        int loaded = 0;
        entry_key(scene, &t->cfg.opt, bud.text[t->budget], key, sizeof key);
        if (resume && (loaded = race_load_entry(dir, t, key, &ref, mask_path ? &mask_img : NULL)) < 0) goto done;
        if (!loaded) {
            if (tune && race_tune(scene, &ref, mask_path ? &mask_img : NULL, pixel_m, bud.by_time ? bud.value[t->budget] : 0.0, t, i, &tlog))
                goto done;
            format_params(&t->cfg.opt, t->params, sizeof t->params);
            snprintf(context, sizeof context, "race %s", t->label);
            if (render_and_compare(scene, &t->cfg, &ref, mask_path ? &mask_img : NULL, &t->img, &t->st, &t->m, context)) goto done;
            /* kept at once: an interrupted race loses no finished entry */
            if (race_keep_entry(dir, t, key)) goto done;
        }
        resumed += loaded;
        printf("race method=%s label=%s photons=%ld spp=%d%s", method_name(t->cfg.opt.method), t->label,
               t->st.photons, t->st.spp, t->params);
        if (t->cfg.opt.method == PDS_METHOD_PPM) printf(" passes=%d", t->st.passes);
        if (t->cfg.opt.method == PDS_METHOD_SPM) printf(" streams=%ld", t->st.streams);
        if (MBIT(t->cfg.opt.method) & M_MAP) printf(" map_bytes=%lu", (unsigned long)t->st.map_bytes);
        if (gather_cap_lowered(&t->cfg.opt, &t->st))
            printf(" %s_used=%ld", t->cfg.opt.method == PDS_METHOD_PDM ? "max_photons" : "k", t->st.gather_cap);
        if (t->st.gather_radius > 0.0) printf(" max_radius_used=%g", t->st.gather_radius);
        printf(" rmse=%.6f ssim=%.6f time=%.3f budget=%s", t->m.rmse, t->m.ssim, t->st.time_total_s,
               bud.text[t->budget]);
        if (t->tuned_keys[0]) printf(" tuned=%s", t->tuned_keys);
        if (loaded) printf(" resumed=1");
        printf("\n");
        fflush(stdout);
        if (t->tuned_edge)
            fprintf(stderr, "pds race: warning: %s: the tuned %s is at the edge of its grid; the optimum may lie "
                    "beyond it\n", t->label, t->tuned);
    }
    flagged = race_check_budgets(e, n, &bud);

    /* one difference scale for all (default), each its own, or given */
    {
        double shared = 0.0;
        for (i = 0; i < n; i++) {
            if (diff_fixed > 0.0) e[i].diff_scale = diff_fixed;
            else if (diff_percentile(&e[i].img, &ref, &e[i].diff_scale)) goto done;
            if (e[i].diff_scale > shared) shared = e[i].diff_scale;
        }
        if (!strcmp(diff_mode, "shared"))
            for (i = 0; i < n; i++) e[i].diff_scale = shared;
    }
    /* crops: the reference's peak in the region shows as white */
    peak = roi_peak(&ref, roi);
    pg.crop_exposure = peak > 0.0 ? -log2(peak) : base.exposure;

    /* every render succeeded: now the folder */
    if (make_dirs(dir)) goto done;
    {
        pds_image crop = {0, 0, NULL}, diff = {0, 0, NULL};
        sbuf csv = {NULL, 0, 0, 0}, html = {NULL, 0, 0, 0}, tcsv = {NULL, 0, 0, 0}, svg = {NULL, 0, 0, 0};
        char file[160], flag[64];
        int bad = write_image(dir, "ref.png", &ref, base.exposure) || make_crop(&ref, roi, scale, &crop) ||
                  write_image(dir, "ref-crop.png", &crop, pg.crop_exposure);
        pds_image_free(&crop);
        for (i = 0; i < n && !bad; i++) {
            race_entry *t = &e[i];
            snprintf(file, sizeof file, "%s.pfm", t->label);
            bad = write_image(dir, file, &t->img, 0.0);
            snprintf(file, sizeof file, "%s.png", t->label);
            bad = bad || write_image(dir, file, &t->img, base.exposure);
            snprintf(file, sizeof file, "%s-crop.png", t->label);
            bad = bad || make_crop(&t->img, roi, scale, &crop) || write_image(dir, file, &crop, pg.crop_exposure);
            snprintf(file, sizeof file, "%s-diff.png", t->label);
            bad = bad || make_diff(&t->img, &ref, t->diff_scale, &diff) || write_image(dir, file, &diff, 0.0);
            pds_image_free(&crop);
            pds_image_free(&diff);
        }
        if (!bad) {
            sb_printf(&csv, "method,label,%s,photons,spp,passes,parameters,tuned,rmse,ssim,time_s,time_eye_s,"
                            "time_photons_s,time_map_s,time_gather_s,map_bytes,diff_scale,budget_flag\n",
                      bud.by_time ? "budget_s" : "budget_photons");
            for (i = 0; i < n; i++) {
                const race_entry *t = &e[i];
                sb_printf(&csv, "%s,", method_name(t->cfg.opt.method));
                sb_csv(&csv, t->label);
                sb_printf(&csv, ",%s,%ld,%d,%d,", bud.text[t->budget], t->st.photons, t->st.spp, t->st.passes);
                sb_csv(&csv, t->params[0] ? t->params + 1 : "");
                sb_printf(&csv, ",");
                sb_csv(&csv, t->tuned);
                sb_printf(&csv, ",%.6f,%.6f,%.3f,%.3f,%.3f,%.3f,%.3f,%lu,%.6g,%s\n", t->m.rmse, t->m.ssim,
                          t->st.time_total_s, t->st.time_eye_s, t->st.time_photons_s, t->st.time_map_s,
                          t->st.time_gather_s, (unsigned long)t->st.map_bytes, t->diff_scale,
                          race_flag_text(t->flags, flag, sizeof flag));
            }
            pg.scene_path = scene_path;
            pg.ref_path = ref_path;
            pg.mask_path = mask_path;
            pg.base = &base;
            pg.bud = &bud;
            pg.ref = &ref;
            pg.roi = roi;
            pg.roi_given = roi_text != NULL;
            pg.scale = scale;
            pg.diff_mode = diff_mode;
            pg.tuned = tune;
            pg.pixel_m = pixel_m;
            pg.methods = n_methods;
            race_html(&html, &pg, e, n, command_argc, command_argv);
            bad = write_text(dir, "race.csv", &csv) || write_text(dir, "index.html", &html);
        }
        if (!bad && tune) {
            sb_printf(&tcsv, "label,method,%s,param,value,seed,rmse,ssim,time_s,photons,chosen\n",
                      bud.by_time ? "budget_s" : "budget_photons");
            for (i = 0; i < tlog.n; i++) {
                const tune_row *w = &tlog.rows[i];
                const race_entry *t = &e[w->entry];
                sb_csv(&tcsv, t->label);
                sb_printf(&tcsv, ",%s,%s,%s,%s,%llu,%.6f,%.6f,%.3f,%ld,%d\n", method_name(t->cfg.opt.method),
                          bud.text[t->budget], w->key, w->value, t->cfg.opt.seed + 1, w->m.rmse, w->m.ssim, w->time_s,
                          w->photons, w->chosen);
            }
            bad = write_text(dir, "tune.csv", &tcsv);
        }
        if (!bad && bud.n > 1) {
            char title[512];
            snprintf(title, sizeof title, "%s: error against time, %dx%d, %s budgets", stem, ref.width, ref.height,
                     bud.by_time ? "time" : "photon");
            race_convergence_svg(&svg, title, e, n, names, n_methods);
            bad = write_text(dir, "convergence.svg", &svg);
        }
        free(csv.s);
        free(html.s);
        free(tcsv.s);
        free(svg.s);
        if (bad) goto done;
    }
    printf("race dir=%s methods=%d roi=%d,%d,%d,%d budgets=%d flagged=%d resumed=%d\n", dir, n_methods, roi.x, roi.y,
           roi.w, roi.h, bud.n, flagged, resumed);
    rc = 0;
done:
    for (i = 0; i < n; i++) pds_image_free(&e[i].img);
    free(e);
    free(proto);
    free(tlog.rows);
    pds_image_free(&mask_img);
    pds_image_free(&ref);
    pds_scene_free(scene);
    return rc;
}

static int unknown_command(const char *name)
{
    char hint[256];
    suggestion sug;
    size_t i;
    suggest_init(&sug, name);
    for (i = 0; i < N_COMMANDS; i++) suggest_consider(&sug, help_table[i].name);
    current_command = NULL;
    return usage_error("unknown command '%s'%s", name, suggest_text(&sug, hint, sizeof hint));
}

/* pds help [COMMAND] */
static int cmd_help(int argc, char **argv)
{
    const command_help *h;
    if (argc == 0) {
        print_overview(stdout);
        return 0;
    }
    if (argc > 1) return usage_error("%s", "help takes one command name");
    h = command_help_lookup(argv[0]);
    if (!h) return unknown_command(argv[0]);
    print_command_help(h, stdout);
    return 0;
}

int main(int argc, char **argv)
{
    static const struct {
        const char *name;
        int (*run)(int argc, char **argv);
    } commands[] = {
        {"render", cmd_render}, {"sweep", cmd_sweep}, {"race", cmd_race},   {"compare", cmd_compare},
        {"merge", cmd_merge},   {"info", cmd_info},   {"bench", cmd_bench}, {"help", cmd_help},
        {"trace-photon", cmd_trace_photon}, {"pixel", cmd_pixel},
    };
    size_t k;
    int i;
    progress.t_command = pds_time_now();
    command_argc = argc;
    command_argv = argv;
    catch_fatal_signals();
    if (argc < 2) {
        print_overview(stderr);
        return EXIT_USAGE;
    }
    if (is_help(argv[1])) {
        print_overview(stdout);
        return 0;
    }
    if (!strcmp(argv[1], "--version")) {
        printf("pds %s\n", PDS_VERSION_STRING);
        return 0;
    }
    for (k = 0; k < sizeof commands / sizeof commands[0]; k++) {
        if (strcmp(argv[1], commands[k].name) != 0) continue;
        current_command = commands[k].name;
        /* --help anywhere after the command: its help, whatever else is there */
        for (i = 2; i < argc; i++)
            if (is_help(argv[i])) {
                print_command_help(command_help_lookup(commands[k].name), stdout);
                return 0;
            }
        return commands[k].run(argc - 2, argv + 2);
    }
    return unknown_command(argv[1]);
}

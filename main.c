/* main.c - the `pds` command-line tool, built only on pds.h.

   Build: cc -std=c99 -O2 -o pds main.c pds.c -lm -lpthread

   Exit status: 0 success, 1 failure (bad input, I/O), 2 usage error.
   Every command ends with one machine-readable line of key=value pairs on
   stdout; errors go to stderr as FILE:LINE:COLUMN: message. */
#define _POSIX_C_SOURCE 200809L /* isatty, fileno */
#include "pds.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

#define EXIT_USAGE 2

static const char usage_text[] =
    "usage: pds COMMAND [ARGS]\n"
    "\n"
    "commands:\n"
    "  render SCENE [options]      render a scene file (or a bare .obj) to an image\n"
    "      -o, --output FILE       output image, .png (tone-mapped sRGB) or .pfm (linear)\n"
    "                              (default: the scene's name with .png, in the current folder)\n"
    "      --method NAME           pds (photon differential splatting, default), pt (path tracing)\n"
    "                              or preview (eye-light shading)\n"
    "      --photons N             pds: caustic photons to emit (default 100000)\n"
    "      --smoothing S           pds: smoothing parameter s of the footprints (default 12; 5..40 typical)\n"
    "      --plane-tolerance F     pds: ignore eye vertices farther than F x the footprint's major\n"
    "                              semi-axis from the photon's tangent plane (default 0.25)\n"
    "      --debug footprint       pds: also write OUT.footprint.png, footprint anisotropy (red = needle)\n"
    "      --spp N                 samples per pixel (per pass with --time; default: the scene's)\n"
    "      --res WxH               resolution (default: the scene camera's)\n"
    "      --threads N             worker threads (default: all cores); the image does not depend on it\n"
    "      --seed N                random seed (default 0); same seed, same image\n"
    "      --max-depth N           longest eye path in bounces (default 32) and, if given, longest\n"
    "                              photon path in specular bounces (default 16)\n"
    "      --time SECONDS          pt: passes of --spp samples until the time is spent;\n"
    "                              pds: one eye pass, then photon batches until the time is spent\n"
    "      --no-caustics           leave out caustic paths L S+ D... (what the photon methods add)\n"
    "      --caustics-only         only caustic paths (pt: the reference for photon methods)\n"
    "      --exposure STOPS        PNG exposure in stops (default 0)\n"
    "      --progress / --quiet    force the progress bar on stderr on / off (default: on if a terminal)\n"
    "  compare A.pfm REF.pfm       RMSE and SSIM of A against the reference REF\n"
    "  info FILE                   what a scene or OBJ file holds\n"
    "  bench rays MESH [N]         BVH build and ray throughput, one thread (N rays, default 1000000)\n"
    "  bench pt [SCENE]            path-traced samples per second, 1 thread and all threads\n"
    "  bench photons [SCENE]       PDS caustic photons per second, 1 thread and all threads\n"
    "  bench memory [SCENE]        PDS working memory at 1e5 and at 1e7 photons\n"
    "  bench filter                eq. 12 filter matrices per second against a general 3x3 inverse\n"
    "  bench kdtree                eye-path map build, range and nearest-neighbour queries per second\n"
    "  --help                      this text\n"
    "  --version                   the version\n";

static int usage_error(const char *fmt, const char *arg)
{
    fprintf(stderr, "pds: ");
    fprintf(stderr, fmt, arg);
    fprintf(stderr, "\n(run 'pds --help' for usage)\n");
    return EXIT_USAGE;
}

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

/* Parse a whole non-negative integer in [lo, hi]; -1 on error. */
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

static int parse_double(const char *s, double *out)
{
    char *end;
    errno = 0;
    *out = strtod(s, &end);
    if (end == s || *end || errno || *out != *out || *out > 1e300 || *out < -1e300) return -1;
    return 0;
}

static pds_status load_any(const char *path, pds_scene **scene, pds_error *err)
{
    return has_ext(path, ".obj") ? pds_scene_load_obj(path, scene, err) : pds_scene_load(path, scene, err);
}

/* The scene's file name without folder and extension, + ".png". */
static void default_output(const char *scene, char *out, size_t n)
{
    const char *base = strrchr(scene, '/');
    const char *dot;
    size_t len;
    base = base ? base + 1 : scene;
    dot = strrchr(base, '.');
    len = dot && dot != base ? (size_t)(dot - base) : strlen(base);
    if (len > n - 5) len = n - 5;
    memcpy(out, base, len);
    strcpy(out + len, ".png");
}

/* Progress bar on stderr: [#####.....]  42%  elapsed 3.1 s  ETA 4.2 s */
static void show_progress(void *user, double fraction, double elapsed)
{
    char bar[41];
    int i, n = (int)(fraction * 40.0 + 0.5);
    (void)user;
    for (i = 0; i < 40; i++) bar[i] = i < n ? '#' : '.';
    bar[40] = '\0';
    fprintf(stderr, "\r[%s] %3d%%  elapsed %.1f s", bar, (int)(fraction * 100.0 + 0.5), elapsed);
    if (fraction > 0.0 && fraction < 1.0) fprintf(stderr, "  ETA %.1f s ", elapsed * (1.0 - fraction) / fraction);
    else fprintf(stderr, "            ");
    fflush(stderr);
}

static int cmd_render(int argc, char **argv)
{
    const char *scene_path = NULL, *output = NULL, *method = "pds";
    int debug_footprint = 0;
    pds_image footprint = {0, 0, NULL};
    char footprint_path[1100];
    int progress = -1; /* -1: when stderr is a terminal */
    char default_out[1024];
    double exposure = 0.0;
    pds_options opt;
    pds_scene *scene = NULL;
    pds_image img = {0, 0, NULL};
    pds_render_stats stats;
    pds_error err;
    int i;
    pds_options_default(&opt);
    for (i = 0; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        long n;
        if (a[0] != '-' || a[1] == '\0') {
            if (scene_path) return usage_error("render takes one scene, got another: '%s'", a);
            scene_path = a;
            continue;
        }
        if (!strcmp(a, "-o") || !strcmp(a, "--output") || !strcmp(a, "--method") || !strcmp(a, "--spp") ||
            !strcmp(a, "--res") || !strcmp(a, "--threads") || !strcmp(a, "--seed") || !strcmp(a, "--exposure") ||
            !strcmp(a, "--max-depth") || !strcmp(a, "--time") || !strcmp(a, "--photons") ||
            !strcmp(a, "--smoothing") || !strcmp(a, "--plane-tolerance") || !strcmp(a, "--debug")) {
            if (!v) return usage_error("%s needs a value", a);
            i++;
        } else if (!strcmp(a, "--no-caustics") || !strcmp(a, "--caustics-only")) {
            pds_paths p = a[2] == 'n' ? PDS_PATHS_NO_CAUSTICS : PDS_PATHS_CAUSTICS_ONLY;
            if (opt.paths != PDS_PATHS_ALL && opt.paths != p)
                return usage_error("%s", "--no-caustics and --caustics-only exclude each other");
            opt.paths = p;
            continue;
        } else if (!strcmp(a, "--progress") || !strcmp(a, "--quiet")) {
            progress = a[2] == 'p';
            continue;
        } else {
            return usage_error("unknown render option '%s'", a);
        }
        if (!strcmp(a, "-o") || !strcmp(a, "--output")) output = v;
        else if (!strcmp(a, "--method")) method = v;
        else if (!strcmp(a, "--spp")) {
            if (parse_int(v, 1, PDS_MAX_SPP, &n)) return usage_error("--spp needs a whole number from 1 to 65536, got '%s'", v);
            opt.spp = (int)n;
        } else if (!strcmp(a, "--threads")) {
            if (parse_int(v, 1, 256, &n)) return usage_error("--threads needs a whole number from 1 to 256, got '%s'", v);
            opt.threads = (int)n;
        } else if (!strcmp(a, "--seed")) {
            char *end;
            errno = 0;
            opt.seed = strtoull(v, &end, 10);
            if (end == v || *end || errno || v[0] == '-') return usage_error("--seed needs a non-negative whole number, got '%s'", v);
        } else if (!strcmp(a, "--res")) {
            long w, h;
            char buf[64], *x;
            if (strlen(v) >= sizeof buf) return usage_error("--res needs WIDTHxHEIGHT, got '%s'", v);
            strcpy(buf, v);
            x = strchr(buf, 'x');
            if (!x) return usage_error("--res needs WIDTHxHEIGHT, got '%s'", v);
            *x = '\0';
            if (parse_int(buf, 1, PDS_MAX_RESOLUTION, &w) || parse_int(x + 1, 1, PDS_MAX_RESOLUTION, &h))
                return usage_error("--res needs WIDTHxHEIGHT with sides from 1 to 16384, got '%s'", v);
            opt.width = (int)w;
            opt.height = (int)h;
        } else if (!strcmp(a, "--max-depth")) {
            if (parse_int(v, 0, 1000, &n)) return usage_error("--max-depth needs a whole number from 0 to 1000, got '%s'", v);
            opt.max_depth = (int)n;
            opt.photon_depth = n > 0 ? (int)n : 1;
        } else if (!strcmp(a, "--photons")) {
            if (parse_int(v, 0, LONG_MAX, &n)) return usage_error("--photons needs a whole number of 0 or more, got '%s'", v);
            opt.photons = n;
        } else if (!strcmp(a, "--smoothing")) {
            if (parse_double(v, &opt.smoothing) || !(opt.smoothing > 0.0) || opt.smoothing > 1e6)
                return usage_error("--smoothing needs a positive number, got '%s'", v);
        } else if (!strcmp(a, "--plane-tolerance")) {
            if (parse_double(v, &opt.plane_tolerance) || !(opt.plane_tolerance > 0.0) || opt.plane_tolerance > 1e6)
                return usage_error("--plane-tolerance needs a positive number, got '%s'", v);
        } else if (!strcmp(a, "--debug")) {
            if (strcmp(v, "footprint") != 0) return usage_error("--debug knows 'footprint', got '%s'", v);
            debug_footprint = 1;
        } else if (!strcmp(a, "--time")) {
            if (parse_double(v, &opt.time_s) || !(opt.time_s > 0.0) || opt.time_s > 1e7)
                return usage_error("--time needs a number of seconds above 0, got '%s'", v);
        } else if (!strcmp(a, "--exposure")) {
            if (parse_double(v, &exposure) || exposure < -64 || exposure > 64)
                return usage_error("--exposure needs a number of stops from -64 to 64, got '%s'", v);
        }
    }
    if (!scene_path) return usage_error("%s", "render needs a scene file");
    if (!strcmp(method, "pds")) opt.method = PDS_METHOD_PDS;
    else if (!strcmp(method, "pt")) opt.method = PDS_METHOD_PT;
    else if (!strcmp(method, "preview")) opt.method = PDS_METHOD_PREVIEW;
    else return usage_error("unknown method '%s' (this version has: pds, pt, preview)", method);
    if (debug_footprint && opt.method != PDS_METHOD_PDS) return usage_error("%s", "--debug footprint needs --method pds");
    if (progress < 0) progress = isatty(fileno(stderr));
    if (progress) opt.progress = show_progress;
    if (!output) {
        default_output(scene_path, default_out, sizeof default_out);
        output = default_out;
    }
    if (!has_ext(output, ".png") && !has_ext(output, ".pfm"))
        return usage_error("output must end in .png or .pfm, got '%s'", output);
    if (load_any(scene_path, &scene, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", pds_error_string(&err));
        return 1;
    }
    if (debug_footprint) {
        /* OUT.png -> OUT.footprint.png */
        const char *dot = strrchr(output, '.');
        snprintf(footprint_path, sizeof footprint_path, "%.*s.footprint%s", (int)(dot - output), output, dot);
        opt.footprint = &footprint;
    }
    if (pds_render(scene, &opt, &img, &stats, &err) != PDS_OK ||
        pds_image_write(output, &img, exposure, &err) != PDS_OK ||
        (debug_footprint && pds_image_write(footprint_path, &footprint, 0.0, &err) != PDS_OK)) {
        fprintf(stderr, "%s\n", pds_error_string(&err));
        pds_image_free(&img);
        pds_image_free(&footprint);
        pds_scene_free(scene);
        return 1;
    }
    pds_image_free(&footprint);
    if (progress) fputc('\n', stderr);
    printf("render method=%s paths=%s width=%d height=%d spp=%d", method,
           opt.paths == PDS_PATHS_ALL ? "all" : opt.paths == PDS_PATHS_NO_CAUSTICS ? "no-caustics" : "caustics-only",
           stats.width, stats.height, stats.spp);
    if (opt.method == PDS_METHOD_PDS)
        printf(" photons=%ld splatted=%ld dropped_degenerate=%ld eye_vertices=%ld smoothing=%g time_eye=%.3f "
               "time_photons=%.3f", stats.photons, stats.splatted, stats.dropped_degenerate, stats.eye_vertices,
               opt.smoothing, stats.time_eye_s, stats.time_photons_s);
    else
        printf(" passes=%d", stats.passes);
    printf(" time_total=%.3f threads=%d output=%s\n", stats.time_total_s, stats.threads, output);
    pds_image_free(&img);
    pds_scene_free(scene);
    return 0;
}

static int cmd_compare(int argc, char **argv)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    pds_metrics m;
    pds_error err;
    int rc = 0;
    if (argc != 2) return usage_error("%s", "compare needs two images: A.pfm REFERENCE.pfm");
    if (pds_image_read_pfm(argv[0], &a, &err) != PDS_OK || pds_image_read_pfm(argv[1], &b, &err) != PDS_OK ||
        pds_image_compare(&a, &b, &m, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", pds_error_string(&err));
        rc = 1;
    } else {
        printf("compare rmse=%.6f ssim=%.6f\n", m.rmse, m.ssim);
    }
    pds_image_free(&a);
    pds_image_free(&b);
    return rc;
}

static const char *material_type_name(pds_material_type t)
{
    static const char *const names[] = {"diffuse", "mirror", "conductor", "dielectric", "emissive"};
    return (unsigned)t < 5 ? names[t] : "?";
}

static const char *light_type_name(pds_light_type t)
{
    static const char *const names[] = {"point", "spot", "directional", "disk", "quad", "mesh"};
    return (unsigned)t < 6 ? names[t] : "?";
}

static int cmd_info(int argc, char **argv)
{
    pds_scene *scene = NULL;
    pds_scene_info info;
    pds_error err;
    const pds_camera *cam;
    int i;
    if (argc != 1) return usage_error("%s", "info needs one scene or OBJ file");
    if (load_any(argv[0], &scene, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", pds_error_string(&err));
        return 1;
    }
    pds_scene_get_info(scene, &info);
    cam = pds_scene_camera(scene);
    printf("file        %s\n", argv[0]);
    printf("triangles   %ld\nvertices    %ld\nshapes      %d\n", info.triangles, info.vertices, info.shapes);
    printf("bounds      (%g, %g, %g) .. (%g, %g, %g)\n", info.bounds_min.x, info.bounds_min.y, info.bounds_min.z,
           info.bounds_max.x, info.bounds_max.y, info.bounds_max.z);
    printf("camera      position (%g, %g, %g) look_at (%g, %g, %g) fov %g, %dx%d, %d spp\n", cam->position.x,
           cam->position.y, cam->position.z, cam->look_at.x, cam->look_at.y, cam->look_at.z, cam->fov_deg,
           cam->width, cam->height, cam->spp);
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
    for (k = 0; k < 2; k++) {
        pds_options_default(&opt);
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
        rate[k] = (double)st.width * st.height * st.spp / st.time_total_s;
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
        if (render_pds(scene, 400000, threads[k], 256, &st[k])) {
            pds_scene_free(scene);
            return 1;
        }
    }
    pds_scene_free(scene);
    printf("bench photons scene=%s photons=%ld splatted=%ld photons_per_s_1=%.0f photons_per_s_%d=%.0f speedup=%.2f\n",
           path, st[0].photons, st[0].splatted, st[0].photons / st[0].time_photons_s, st[1].threads,
           st[1].photons / st[1].time_photons_s, st[0].time_photons_s / st[1].time_photons_s);
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
    struct rusage ru;
    long rss_a, rss_b;
    if (render_pds(scene, 100000, 0, 256, &a)) {
        pds_scene_free(scene);
        return 1;
    }
    getrusage(RUSAGE_SELF, &ru);
    rss_a = ru.ru_maxrss;
    if (render_pds(scene, 10000000, 0, 256, &b)) {
        pds_scene_free(scene);
        return 1;
    }
    getrusage(RUSAGE_SELF, &ru);
    rss_b = ru.ru_maxrss;
    pds_scene_free(scene);
    /* ru_maxrss is the process's peak so far (KiB on Linux): if the second,
       100 times larger render needed more, the peak would have grown */
    printf("bench memory scene=%s render_bytes_1e5=%lu render_bytes_1e7=%lu peak_rss_kib_after_1e5=%ld "
           "peak_rss_kib_after_1e7=%ld growth=%.2f%% time_1e7=%.1f\n",
           path, (unsigned long)a.memory_bytes, (unsigned long)b.memory_bytes, rss_a, rss_b,
           100.0 * ((double)rss_b / (double)rss_a - 1.0), b.time_total_s);
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
        if (argc == 3 && parse_int(argv[2], 1, 100000000, &n))
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
    if (!strcmp(argv[0], "memory")) return bench_memory(argc - 1, argv + 1);
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
    return usage_error("unknown benchmark '%s' (rays, pt, photons, memory, filter, kdtree)", argv[0]);
}

int main(int argc, char **argv)
{
    const char *cmd;
    if (argc < 2) {
        fputs(usage_text, stderr);
        return EXIT_USAGE;
    }
    cmd = argv[1];
    if (!strcmp(cmd, "--help") || !strcmp(cmd, "-h") || !strcmp(cmd, "help")) {
        fputs(usage_text, stdout);
        return 0;
    }
    if (!strcmp(cmd, "--version")) {
        printf("pds %s\n", PDS_VERSION_STRING);
        return 0;
    }
    if (!strcmp(cmd, "render")) return cmd_render(argc - 2, argv + 2);
    if (!strcmp(cmd, "compare")) return cmd_compare(argc - 2, argv + 2);
    if (!strcmp(cmd, "info")) return cmd_info(argc - 2, argv + 2);
    if (!strcmp(cmd, "bench")) return cmd_bench(argc - 2, argv + 2);
    return usage_error("unknown command '%s'", cmd);
}

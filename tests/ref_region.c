/* ref_region.c - a long path-traced reference of a few pixels: `pds render
   --method pt` restricted to a window of the image, so that a block of
   pixels can get many times the samples of a whole-image reference in the
   same time, and with many independent seeds, so that the reference's own
   standard error is known even where its noise is heavy-tailed (caustics
   through glass and off mirrors, which a path tracer finds only by
   chance). README "Global illumination: --method gi" uses it to settle
   whose error a disagreement between gi and pt is.

     tests/ref_region SCENE --res WxH --window X0 Y0 X1 Y1 --spp N
                      --seeds S0 K [--block B] [--threads T]
                      [--paths all|no-caustics|caustics-only] [--diffuse-bounces D]

   Renders pixels X0 <= x < X1, Y0 <= y < Y1 (x right, y down from the
   image's top left, as `pds pixel` counts) of the WxH image with pt, N
   samples a pixel, once for each seed S0 .. S0 + K - 1. Each pixel's
   samples are exactly those `pds render SCENE --method pt --res WxH --spp
   N --seed S` (with --paths and --diffuse-bounces as given) takes for it (the library's own pixel routine, job and
   tracer set up as pds_render sets them up for pt), so the window is a
   crop of that render, bit for bit.

   Prints, for every block of B x B pixels (default 16) in the window (the
   blocks of the whole image's grid, B x B from its top left) and every
   seed, the block's mean (over its pixels and the three channels):
     block BX BY seed S mean M
   then one line per block over the seeds:
     summary BX BY mean M se SE seeds K median-of-means MM
   SE the standard error of the mean from the spread of the K seeds'
   means (K - 1 degrees of freedom); the median of means (of 8 groups of
   K / 8 seeds, when K >= 16) is a check on heavy tails: far from M, a
   few samples carry the mean. */
#include "pds.c"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct ref_job {
    pds__render_job job;  /* the library's pt job, one per seed in turn */
    int x0, y0, x1, y1;
    double *sum;          /* 3 per window pixel */
    pds__mutex lock;
    int next;             /* guarded by lock: the next window row */
} ref_job;

static void *ref_worker(void *arg)
{
    ref_job *r = (ref_job *)arg;
    int w = r->x1 - r->x0;
    for (;;) {
        int y, x;
        pds__mutex_lock(&r->lock);
        y = r->y0 + r->next++;
        pds__mutex_unlock(&r->lock);
        if (y >= r->y1) break;
        for (x = r->x0; x < r->x1; x++)
            pds__render_pixel(&r->job, x, y, &r->sum[3 * ((size_t)(y - r->y0) * w + (x - r->x0))]);
    }
    return NULL;
}

static int usage(void)
{
    fprintf(stderr, "usage: ref_region SCENE --res WxH --window X0 Y0 X1 Y1 --spp N --seeds S0 K [--block B] "
                    "[--threads T] [--paths all|no-caustics|caustics-only] [--diffuse-bounces D]\n");
    return 2;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    const char *path = NULL;
    int width = 0, height = 0, x0 = -1, y0 = -1, x1 = -1, y1 = -1, spp = 0, block = 16, threads = 2, k, i;
    long seeds = 0;
    int diffuse = -1;
    pds_paths paths = PDS_PATHS_ALL;
    unsigned long long s0 = 0;
    pds_scene *scene = NULL;
    pds_error err;
    pds_options opt;
    ref_job r;
    int bx0, by0, bx1, by1, nbx, nby;
    double *means;
    for (i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--res") && i + 1 < argc) {
            if (sscanf(argv[++i], "%dx%d", &width, &height) != 2) return usage();
        } else if (!strcmp(a, "--window") && i + 4 < argc) {
            x0 = atoi(argv[i + 1]), y0 = atoi(argv[i + 2]), x1 = atoi(argv[i + 3]), y1 = atoi(argv[i + 4]);
            i += 4;
        } else if (!strcmp(a, "--spp") && i + 1 < argc) {
            spp = atoi(argv[++i]);
        } else if (!strcmp(a, "--seeds") && i + 2 < argc) {
            s0 = strtoull(argv[i + 1], NULL, 10);
            seeds = atol(argv[i + 2]);
            i += 2;
        } else if (!strcmp(a, "--block") && i + 1 < argc) {
            block = atoi(argv[++i]);
        } else if (!strcmp(a, "--threads") && i + 1 < argc) {
            threads = atoi(argv[++i]);
        } else if (!strcmp(a, "--paths") && i + 1 < argc) {
            const char *v = argv[++i];
            if (!strcmp(v, "all")) paths = PDS_PATHS_ALL;
            else if (!strcmp(v, "no-caustics")) paths = PDS_PATHS_NO_CAUSTICS;
            else if (!strcmp(v, "caustics-only")) paths = PDS_PATHS_CAUSTICS_ONLY;
            else return usage();
        } else if (!strcmp(a, "--diffuse-bounces") && i + 1 < argc) {
            diffuse = atoi(argv[++i]);
        } else if (a[0] != '-' && !path) {
            path = a;
        } else {
            return usage();
        }
    }
    if (!path || width < 1 || height < 1 || spp < 1 || seeds < 2 || block < 1 || threads < 1 || x0 < 0 ||
        y0 < 0 || x1 > width || y1 > height || x0 >= x1 || y0 >= y1 || width > PDS_MAX_RESOLUTION ||
        height > PDS_MAX_RESOLUTION || spp > PDS_MAX_SPP)
        return usage();
    if (pds_scene_load(path, &scene, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", err.text);
        return 1;
    }
    pds_options_default(&opt);
    opt.paths = paths;
    opt.diffuse_bounces = diffuse;
    memset(&r, 0, sizeof r);
    r.x0 = x0, r.y0 = y0, r.x1 = x1, r.y1 = y1;
    /* the blocks of the image's grid that lie wholly in the window */
    bx0 = (x0 + block - 1) / block, by0 = (y0 + block - 1) / block;
    bx1 = x1 / block, by1 = y1 / block;
    nbx = bx1 - bx0, nby = by1 - by0;
    if (nbx < 1 || nby < 1) {
        fprintf(stderr, "ref_region: the window holds no whole block of %d pixels\n", block);
        pds_scene_free(scene);
        return 2;
    }
    r.sum = (double *)malloc(sizeof *r.sum * 3 * (size_t)(x1 - x0) * (size_t)(y1 - y0));
    means = (double *)malloc(sizeof *means * (size_t)nbx * (size_t)nby * (size_t)seeds);
    if (!r.sum || !means) {
        fprintf(stderr, "ref_region: out of memory\n");
        free(r.sum);
        free(means);
        pds_scene_free(scene);
        return 1;
    }
    for (k = 0; k < seeds; k++) {
        pds__render_job *job = &r.job;
        int bx, by;
        /* pds__render_into's job for pt: one pass of spp samples */
        memset(job, 0, sizeof *job);
        job->scene = scene;
        job->frame = pds__camera_setup(&scene->camera, width, height);
        job->method = PDS_METHOD_PT;
        job->spp = spp;
        job->total_spp_max = spp;
        job->filter = scene->camera.filter;
        job->seed = s0 + (unsigned long long)k;
        job->record_pass = -1;
        job->tracer.scene = scene;
        job->tracer.paths = opt.paths;
        job->tracer.max_depth = opt.max_depth;
        job->tracer.rr_depth = opt.rr_depth;
        job->tracer.max_diffuse = opt.diffuse_bounces;
        job->tracer.seed = job->seed;
        job->tracer.eps = 1e-6 * pds__scene_scale(scene);
        job->tracer.spectral = pds__render_is_spectral(scene, &opt);
        job->tracer.spectral_all = 0;
        memset(r.sum, 0, sizeof *r.sum * 3 * (size_t)(x1 - x0) * (size_t)(y1 - y0));
        r.next = 0;
        pds__mutex_init(&r.lock);
        pds__run_threads(threads, ref_worker, &r);
        pds__mutex_destroy(&r.lock);
        for (by = 0; by < nby; by++)
            for (bx = 0; bx < nbx; bx++) {
                double m = 0.0;
                int x, y, c;
                for (y = (by0 + by) * block; y < (by0 + by + 1) * block; y++)
                    for (x = (bx0 + bx) * block; x < (bx0 + bx + 1) * block; x++)
                        for (c = 0; c < 3; c++) m += r.sum[3 * ((size_t)(y - y0) * (x1 - x0) + (x - x0)) + c];
                m /= 3.0 * spp * block * block;
                means[((size_t)by * nbx + bx) * seeds + k] = m;
                printf("block %d %d seed %llu mean %.7f\n", bx0 + bx, by0 + by, (unsigned long long)job->seed, m);
                fflush(stdout);
            }
    }
    for (i = 0; i < nbx * nby; i++) {
        double *v = &means[(size_t)i * seeds], m = 0.0, var = 0.0, mm = 0.0;
        for (k = 0; k < seeds; k++) m += v[k] / seeds;
        for (k = 0; k < seeds; k++) var += (v[k] - m) * (v[k] - m) / (seeds - 1);
        if (seeds >= 16) {
            /* median of 8 group means */
            double g[8];
            int j;
            long per = seeds / 8;
            for (j = 0; j < 8; j++) {
                g[j] = 0.0;
                for (k = 0; k < per; k++) g[j] += v[j * per + k] / per;
            }
            qsort(g, 8, sizeof *g, cmp_double);
            mm = 0.5 * (g[3] + g[4]);
        }
        printf("summary %d %d mean %.7f se %.7f seeds %ld median-of-means %.7f\n", bx0 + i % nbx, by0 + i / nbx, m,
               sqrt(var / seeds), seeds, mm);
    }
    free(r.sum);
    free(means);
    pds_scene_free(scene);
    return 0;
}

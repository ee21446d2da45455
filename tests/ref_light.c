/* ref_light.c - a reference for caustics seen directly, by light tracing
   (pds_render_light_traced): no density kernel, so focal lines are not
   blurred; noise only, falling as 1 / sqrt(photons). `make references`
   uses it for the case studies, whose floors the camera sees directly.

     tests/ref_light SCENE --photons N [--res WxH] [--seed S] [--threads T] -o OUT.pfm
     tests/ref_light SCENE [--res WxH] --complete MASK.pfm

   Prints the photons and the seconds taken.

   Light tracing bins a photon only where the camera sees its landing
   point directly, so a pixel that sees glass, a mirror or metal (even in
   part, at a silhouette) gets none of the caustic it shows there: its
   reference is incomplete, and an estimate that renders it (through the
   glass) is wrong against it. --complete writes the pixels where the
   reference is whole: 1 where every one of 8 x 8 rays through the
   pixel's sub-cells (the pinhole camera of pds_render) first meets a
   surface that is not specular, or nothing; 0 elsewhere. Compare over
   those pixels. */
/* pds.c itself, as tests/ref_region.c does: the mask takes the render's
   own camera (pds__camera_setup, pds__camera_dir) and its own test of
   which surfaces an eye path passes (pds__material_is_specular). */
#include "pds.c"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A count: a number with an optional k, M or G (1e3, 1e6, 1e9), the
   whole argument, from 1 to 1e13. 0 if it is not one. */
static int parse_count(const char *v, double *out)
{
    char *end;
    double x = strtod(v, &end), scale = 1.0;
    if (end == v) return 0;
    if (*end == 'k') scale = 1e3;
    else if (*end == 'M') scale = 1e6;
    else if (*end == 'G') scale = 1e9;
    if (scale > 1.0) end++;
    x *= scale;
    if (*end != '\0' || !(x >= 1.0 && x <= 1e13)) return 0;
    *out = x;
    return 1;
}

static int usage(void)
{
    fprintf(stderr, "usage: ref_light SCENE --photons N [--res WxH] [--seed S] [--threads T] -o OUT.pfm\n"
                    "       ref_light SCENE [--res WxH] --complete MASK.pfm\n");
    return 2;
}

/* The mask of --complete (the comment above), width x height pixels. */
static int complete_mask(const pds_scene *scene, int width, int height, pds_image *mask, pds_error *err)
{
    pds__camera_frame f = pds__camera_setup(pds_scene_camera(scene), width, height);
    int x, y, i, j;
    enum { S = 8 };
    if (pds_image_alloc(mask, width, height) != PDS_OK) {
        snprintf(err->text, sizeof err->text, "out of memory");
        return 0;
    }
    for (y = 0; y < height; y++)
        for (x = 0; x < width; x++) {
            int whole = 1;
            for (j = 0; j < S && whole; j++)
                for (i = 0; i < S && whole; i++) {
                    pds_ray ray;
                    pds_hit hit;
                    ray.origin = f.origin;
                    ray.dir = pds__camera_dir(&f, x + (i + 0.5) / S, y + (j + 0.5) / S);
                    ray.tmin = 0.0;
                    ray.tmax = DBL_MAX;
                    if (pds_scene_intersect(scene, &ray, &hit))
                        whole = !pds__material_is_specular(pds_scene_material(scene, hit.material));
                }
            for (i = 0; i < 3; i++) mask->rgb[3 * ((size_t)y * width + x) + i] = whole ? 1.0f : 0.0f;
        }
    return 1;
}

int main(int argc, char **argv)
{
    const char *scene_path = NULL, *out = NULL, *complete = NULL;
    pds_options opt;
    pds_image_write_options wo;
    static pds_image_meta meta; /* 25 kB: not on the stack */
    char text[64];
    pds_scene *scene = NULL;
    pds_image img = {0, 0, NULL};
    pds_error err;
    double t0;
    int i;
    pds_options_default(&opt);
    opt.photons = 0;
    for (i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "-o") && v) {
            out = v;
            i++;
        } else if (!strcmp(a, "--photons") && v) {
            double n;
            if (!parse_count(v, &n)) {
                fprintf(stderr, "ref_light: --photons needs a count from 1 to 1e13 (250000, 2.5e5, 250k, 200M), "
                                "got '%s'\n", v);
                return 2;
            }
            opt.photons = (long)n;
            i++;
        } else if (!strcmp(a, "--res") && v) {
            if (sscanf(v, "%dx%d", &opt.width, &opt.height) != 2) return usage();
            i++;
        } else if (!strcmp(a, "--seed") && v) {
            opt.seed = strtoull(v, NULL, 10);
            i++;
        } else if (!strcmp(a, "--complete") && v) {
            complete = v;
            i++;
        } else if (!strcmp(a, "--threads") && v) {
            double n;
            if (!parse_count(v, &n) || n > 4096.0 || n != floor(n)) {
                fprintf(stderr, "ref_light: --threads needs a whole number from 1 to 4096, got '%s'\n", v);
                return 2;
            }
            opt.threads = (int)n;
            i++;
        } else if (a[0] != '-' && !scene_path) {
            scene_path = a;
        } else {
            return usage();
        }
    }
    if (!scene_path || (!out && !complete) || (out && opt.photons < 1)) return usage();
    if (pds_scene_load(scene_path, &scene, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", err.text);
        return 1;
    }
    if (complete) {
        const pds_camera *cam = pds_scene_camera(scene);
        pds_image mask = {0, 0, NULL};
        long n = 0, k;
        if (!complete_mask(scene, opt.width > 0 ? opt.width : cam->width, opt.height > 0 ? opt.height : cam->height,
                           &mask, &err) ||
            pds_image_write(complete, &mask, 0.0, &err) != PDS_OK) {
            fprintf(stderr, "%s\n", err.text);
            pds_image_free(&mask);
            pds_scene_free(scene);
            return 1;
        }
        for (k = 0; k < (long)mask.width * mask.height; k++) n += mask.rgb[3 * k] > 0.5f;
        printf("ref_light complete=%ld of %ld pixels output=%s\n", n, (long)mask.width * mask.height, complete);
        pds_image_free(&mask);
        if (!out) {
            pds_scene_free(scene);
            return 0;
        }
    }
    t0 = pds_time_now();
    /* what the image is, as pds render writes it: a reference of the
       caustics alone */
    pds_image_write_options_default(&wo);
    wo.meta = &meta;
    pds_image_meta_set(&meta, PDS_META_KIND, PDS_META_KIND_CAUSTICS);
    pds_image_meta_set(&meta, PDS_META_METHOD, "light tracing (tests/ref_light)");
    pds_image_meta_set(&meta, "pds:version", PDS_VERSION_STRING);
    pds_image_meta_set(&meta, "pds:scene", scene_path);
    snprintf(text, sizeof text, "%ld", opt.photons);
    pds_image_meta_set(&meta, "pds:photons", text);
    snprintf(text, sizeof text, "%llu", opt.seed);
    pds_image_meta_set(&meta, "pds:seed", text);
    if (pds_render_light_traced(scene, &opt, &img, &err) != PDS_OK || pds_image_write_with(out, &img, &wo, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", err.text);
        pds_image_free(&img);
        pds_scene_free(scene);
        return 1;
    }
    printf("ref_light photons=%ld width=%d height=%d seed=%llu time=%.1f output=%s\n", opt.photons, img.width,
           img.height, opt.seed, pds_time_now() - t0, out);
    pds_image_free(&img);
    pds_scene_free(scene);
    return 0;
}

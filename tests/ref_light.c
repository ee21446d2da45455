/* ref_light.c - a reference for caustics seen directly, by light tracing
   (pds_render_light_traced): no density kernel, so focal lines are not
   blurred; noise only, falling as 1 / sqrt(photons). `make references`
   uses it for the case studies, whose floors the camera sees directly.

     tests/ref_light SCENE --photons N [--res WxH] [--seed S] [--threads T] -o OUT.pfm

   Prints the photons and the seconds taken. */
#include "pds.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int usage(void)
{
    fprintf(stderr, "usage: ref_light SCENE --photons N [--res WxH] [--seed S] [--threads T] -o OUT.pfm\n");
    return 2;
}

int main(int argc, char **argv)
{
    const char *scene_path = NULL, *out = NULL;
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
            opt.photons = (long)strtod(v, NULL);
            i++;
        } else if (!strcmp(a, "--res") && v) {
            if (sscanf(v, "%dx%d", &opt.width, &opt.height) != 2) return usage();
            i++;
        } else if (!strcmp(a, "--seed") && v) {
            opt.seed = strtoull(v, NULL, 10);
            i++;
        } else if (!strcmp(a, "--threads") && v) {
            opt.threads = atoi(v);
            i++;
        } else if (a[0] != '-' && !scene_path) {
            scene_path = a;
        } else {
            return usage();
        }
    }
    if (!scene_path || !out || opt.photons < 1) return usage();
    if (pds_scene_load(scene_path, &scene, &err) != PDS_OK) {
        fprintf(stderr, "%s\n", err.text);
        return 1;
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

/* ball_metrics.c - image errors for the POV-Ray comparison (README "PDS
   against POV-Ray"), over the whole image and over regions.

     cc -std=c99 -O2 -I. -o tests/ball_metrics tests/ball_metrics.c pds.c -lm -lpthread
     tests/ball_metrics IMAGE REF.pfm [--ball MASK.pfm] [--caustic REF_CAUSTIC.pfm]
                        [--threshold T] [--errmap OUT.pfm|OUT.png] [--exposure STOPS]
                        [--subtract PART.pfm]

   IMAGE and REF are PFM or OpenEXR (pds's reader: POV-Ray writes OpenEXR).
   Regions: all pixels; "ball", the pixels MASK marks (tests/ref_ball's
   --ball-mask: the camera ray meets the ball); "caustic", the pixels
   where the reference's caustic part (its --caustics image) exceeds T
   (default 0.02, radiance in the scene's units); "floor", the pixels not
   in the ball. For each region, one line:

     region=NAME pixels=N rmse=R rel4=Q mean_ratio=M

   rmse: the root mean square of the difference over the region's pixels
   and the three channels. rel4: the outside report's metric: both images
   averaged over 4 x 4 pixel blocks (and the channels), the root mean
   square difference of the blocks at least half in the region, divided
   by the reference's mean over those blocks. mean_ratio: IMAGE's sum over
   the region divided by REF's (1 = the right energy);
   median_pixel_ratio: the median over the region's pixels of IMAGE / REF
   (pixel means of the channels). --errmap writes
   |IMAGE - REF| per pixel (PNG: times 2^STOPS, clamped). --subtract
   takes PART from IMAGE first (POV-Ray's caustic part: its full image
   minus the reference's direct part, which its direct light matches). */
#include "pds.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int load(const char *path, pds_image *img)
{
    pds_error err;
    memset(&err, 0, sizeof err);
    if (pds_image_read(path, img, NULL, &err) != PDS_OK) {
        fprintf(stderr, "ball_metrics: %s\n", pds_error_string(&err));
        return -1;
    }
    return 0;
}

static double pixel_mean(const pds_image *im, size_t i)
{
    return (im->rgb[3 * i] + im->rgb[3 * i + 1] + im->rgb[3 * i + 2]) / 3.0;
}

static int cmp_double(const void *x, const void *y)
{
    double a = *(const double *)x, b = *(const double *)y;
    return (a > b) - (a < b);
}

/* One region's line; in[i] says whether pixel i belongs to it. */
static void region_report(const char *name, const pds_image *a, const pds_image *r, const unsigned char *in)
{
    size_t i, n = 0, nb = 0, nq = 0;
    double *q = malloc(sizeof(double) * (size_t)r->width * r->height);
    double se = 0.0, sa = 0.0, sr = 0.0, bse = 0.0, bref = 0.0;
    int bx, by, x, y, w = r->width, h = r->height;
    for (i = 0; i < (size_t)w * h; i++) {
        int c;
        if (!in[i]) continue;
        n++;
        if (q && pixel_mean(r, i) > 1e-6) q[nq++] = pixel_mean(a, i) / pixel_mean(r, i);
        for (c = 0; c < 3; c++) {
            double d = (double)a->rgb[3 * i + c] - r->rgb[3 * i + c];
            se += d * d;
            sa += a->rgb[3 * i + c];
            sr += r->rgb[3 * i + c];
        }
    }
    for (by = 0; by + 4 <= h; by += 4)
        for (bx = 0; bx + 4 <= w; bx += 4) {
            double ma = 0.0, mr = 0.0;
            int count = 0;
            for (y = by; y < by + 4; y++)
                for (x = bx; x < bx + 4; x++) {
                    i = (size_t)y * w + x;
                    count += in[i];
                    ma += pixel_mean(a, i);
                    mr += pixel_mean(r, i);
                }
            if (2 * count < 16) continue;
            ma /= 16.0;
            mr /= 16.0;
            bse += (ma - mr) * (ma - mr);
            bref += mr;
            nb++;
        }
    if (q && nq) qsort(q, nq, sizeof *q, cmp_double);
    printf("region=%s pixels=%lu rmse=%.5f rel4=%.4f mean_ratio=%.4f median_pixel_ratio=%.5f q25=%.5f q75=%.5f\n", name,
           (unsigned long)n, n ? sqrt(se / (3.0 * n)) : 0.0, nb && bref > 0.0 ? sqrt(bse / nb) / (bref / nb) : 0.0,
           sr > 0.0 ? sa / sr : 0.0, q && nq ? q[nq / 2] : 0.0, q && nq ? q[nq / 4] : 0.0, q && nq ? q[3 * nq / 4] : 0.0);
    free(q);
}

int main(int argc, char **argv)
{
    pds_image a, r, mask, caus;
    const char *mask_path = NULL, *caus_path = NULL, *errmap = NULL, *sub_path = NULL;
    double threshold = 0.02, exposure = 0.0;
    unsigned char *in;
    size_t i, np;
    int k;
    memset(&mask, 0, sizeof mask);
    memset(&caus, 0, sizeof caus);
    if (argc < 3) goto usage;
    for (k = 3; k < argc; k += 2) {
        if (k + 1 >= argc) goto usage;
        if (!strcmp(argv[k], "--ball")) mask_path = argv[k + 1];
        else if (!strcmp(argv[k], "--caustic")) caus_path = argv[k + 1];
        else if (!strcmp(argv[k], "--threshold")) threshold = atof(argv[k + 1]);
        else if (!strcmp(argv[k], "--errmap")) errmap = argv[k + 1];
        else if (!strcmp(argv[k], "--exposure")) exposure = atof(argv[k + 1]);
        else if (!strcmp(argv[k], "--subtract")) sub_path = argv[k + 1];
        else goto usage;
    }
    if (load(argv[1], &a) || load(argv[2], &r)) return 1;
    if ((mask_path && load(mask_path, &mask)) || (caus_path && load(caus_path, &caus))) return 1;
    if (a.width != r.width || a.height != r.height || (mask_path && (mask.width != r.width || mask.height != r.height)) ||
        (caus_path && (caus.width != r.width || caus.height != r.height))) {
        fprintf(stderr, "ball_metrics: the images differ in size\n");
        return 1;
    }
    np = (size_t)r.width * r.height;
    if (sub_path) {
        pds_image d;
        if (load(sub_path, &d)) return 1;
        if (d.width != r.width || d.height != r.height) {
            fprintf(stderr, "ball_metrics: the images differ in size\n");
            return 1;
        }
        for (i = 0; i < 3 * np; i++) a.rgb[i] -= d.rgb[i];
        pds_image_free(&d);
    }
    in = malloc(np);
    if (!in) return 1;
    memset(in, 1, np);
    region_report("all", &a, &r, in);
    if (mask_path) {
        for (i = 0; i < np; i++) in[i] = mask.rgb[3 * i] > 0.5f;
        region_report("ball", &a, &r, in);
        for (i = 0; i < np; i++) in[i] = !in[i];
        region_report("floor", &a, &r, in);
    }
    if (caus_path) {
        for (i = 0; i < np; i++) in[i] = pixel_mean(&caus, i) > threshold;
        region_report("caustic", &a, &r, in);
    }
    if (errmap) {
        pds_image e;
        pds_error err;
        memset(&err, 0, sizeof err);
        if (pds_image_alloc(&e, r.width, r.height) != PDS_OK) return 1;
        for (i = 0; i < 3 * np; i++) e.rgb[i] = (float)fabs((double)a.rgb[i] - r.rgb[i]);
        if (pds_image_write(errmap, &e, exposure, &err) != PDS_OK) {
            fprintf(stderr, "ball_metrics: %s\n", pds_error_string(&err));
            return 1;
        }
        pds_image_free(&e);
    }
    free(in);
    pds_image_free(&a);
    pds_image_free(&r);
    pds_image_free(&mask);
    pds_image_free(&caus);
    return 0;
usage:
    fprintf(stderr, "usage: ball_metrics IMAGE REF.pfm [--ball MASK.pfm] [--caustic REF_CAUSTIC.pfm] [--threshold T]\n"
                    "                    [--errmap OUT.pfm|OUT.png] [--exposure STOPS] [--subtract PART.pfm]\n");
    return 2;
}

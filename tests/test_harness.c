/* tests/test_harness.c - the comparison harness as a user meets it: `pds
   sweep` (one parameter against a reference: lines, sweep.csv, sweep.svg),
   `pds race` (methods on one budget: lines, race.csv, index.html, images,
   crops, difference images, the region of interest) and the baseline
   options of `pds render`. Runs $PDS_BIN through cli_run (test_cli.c);
   writes only under /tmp. */
#include <dirent.h>
#include <sys/stat.h>

/* text starts with the string literal lit */
#define HARNESS_STARTS(text, lit) (strncmp((text), (lit), sizeof(lit) - 1) == 0)

/* /tmp/pds_harness_PID_NAME */
static void harness_path(char *out, size_t n, const char *name)
{
    snprintf(out, n, "/tmp/pds_harness_%ld_%s", (long)getpid(), name);
}

/* Remove a folder of plain files and folders of them (what sweep and race
   write: race keeps its entries in DIR/entries). */
static void harness_rmtree(const char *dir)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    char path[1024];
    if (!d) return;
    while ((e = readdir(d)) != NULL) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        if (remove(path) != 0) harness_rmtree(path); /* a folder that is not empty */
    }
    closedir(d);
    rmdir(dir);
}

static int harness_dir_exists(const char *dir)
{
    struct stat sb;
    return stat(dir, &sb) == 0 && S_ISDIR(sb.st_mode);
}

/* Number of entries of dir whose name contains part (-1: no folder). */
static int harness_dir_count(const char *dir, const char *part)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    int n = 0;
    if (!d) return -1;
    while ((e = readdir(d)) != NULL)
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..") && strstr(e->d_name, part)) n++;
    closedir(d);
    return n;
}

/* The whole file as a NUL-terminated string (NULL if unreadable). */
static char *harness_slurp(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    char *buf;
    long n;
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    n = ftell(f);
    fseek(f, 0, SEEK_SET);
    buf = (char *)malloc((size_t)n + 1);
    if (buf && fread(buf, 1, (size_t)n, f) != (size_t)n) {
        free(buf);
        buf = NULL;
    }
    fclose(f);
    if (buf) buf[n] = '\0';
    if (size) *size = (size_t)n;
    return buf;
}

static int harness_count(const char *text, const char *needle)
{
    int n = 0;
    size_t len = strlen(needle);
    for (text = strstr(text, needle); text; text = strstr(text + len, needle)) n++;
    return n;
}

/* Lines of text that start with prefix, copied (one per row) into lines. */
static int harness_lines(const char *text, const char *prefix, char lines[][512], int max)
{
    int n = 0;
    const char *p = text;
    size_t plen = strlen(prefix);
    while (*p) {
        const char *end = strchr(p, '\n');
        size_t len = end ? (size_t)(end - p) : strlen(p);
        if (len >= plen && !strncmp(p, prefix, plen) && n < max) {
            if (len > 511) len = 511;
            memcpy(lines[n], p, len);
            lines[n][len] = '\0';
            n++;
        }
        if (!end) break;
        p = end + 1;
    }
    return n;
}

/* The number after " key=" in a key=value line (NAN if missing). */
static double harness_value(const char *line, const char *key)
{
    char pat[64];
    const char *p;
    snprintf(pat, sizeof pat, " %s=", key);
    p = strstr(line, pat);
    return p ? strtod(p + strlen(pat), NULL) : NAN;
}

/* Width, height and RGB bytes of a PNG file (caller frees), or NULL when
   it does not decode: the independent PNG reader of test_image.c. */
static unsigned char *timg_png_read_rgb(const char *path, int *w, int *h);

static unsigned char *harness_png(const char *path, int *w, int *h)
{
    return timg_png_read_rgb(path, w, h);
}

/* A PFM of w x h pixels, value(x, y) grey. */
static int harness_write_pfm(const char *path, int w, int h, float (*value)(int x, int y))
{
    pds_image img;
    int x, y, ok;
    if (pds_image_alloc(&img, w, h) != PDS_OK) return 0;
    for (y = 0; y < h; y++)
        for (x = 0; x < w; x++) {
            float *p = img.rgb + 3 * ((size_t)y * w + x);
            p[0] = p[1] = p[2] = value(x, y);
        }
    ok = pds_image_write_pfm(path, &img, NULL) == PDS_OK;
    pds_image_free(&img);
    return ok;
}

/* The reference both sweep and race tests compare with: the golden glass
   scene without caustic paths (so path tracing converges without fireflies
   at these sample counts), 32x24, 1024 spp, another seed than the renders. */
static int harness_reference(pds_test_ctx *t, char *ref, size_t n)
{
    char out[8192], args[1024];
    harness_path(ref, n, "ref.pfm");
    snprintf(args, sizeof args,
             "render tests/golden/glass.scene --method pt --no-caustics --res 32x24 --spp 1024 --seed 1 --quiet -o %s",
             ref);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "reference render failed: %s", out);
    return cli_file_exists(ref);
}

static void test_harness_sweep_over_spp_lowers_rmse_and_reports_the_best(pds_test_ctx *t)
{
    char out[16384], args[1024], ref[256], dir[256], path[512], lines[8][512], one[256];
    char *csv, *svg;
    const char *last;
    double rmse[3];
    int i, n;
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    REQUIRE(t, harness_reference(t, ref, sizeof ref), "no reference");
    harness_path(dir, sizeof dir, "sweep");
    harness_rmtree(dir);
    snprintf(args, sizeof args,
             "sweep tests/golden/glass.scene --method pt --param spp --values 1,4,16 --ref %s --res 32x24 "
             "--no-caustics --quiet -o %s",
             ref, dir);
    REQUIRE(t, cli_run(args, out, sizeof out) == 0, "sweep failed: %s", out);
    n = harness_lines(out, "sweep method=pt spp=", lines, 8);
    REQUIRE(t, n == 3, "three value lines expected, got %d: %s", n, out);
    for (i = 0; i < 3; i++) {
        static const char *const v[3] = {"1", "4", "16"};
        char prefix[64];
        snprintf(prefix, sizeof prefix, "sweep method=pt spp=%s rmse=", v[i]);
        CHECK(t, !strncmp(lines[i], prefix, strlen(prefix)), "line %d: %s", i, lines[i]);
        rmse[i] = harness_value(lines[i], "rmse");
        CHECK(t, harness_value(lines[i], "ssim") > 0.0 && harness_value(lines[i], "time") >= 0.0, "%s", lines[i]);
    }
    /* Monte Carlo error falls roughly as 1/sqrt(spp): each step quarters
       the variance, so each RMSE is well below the one before */
    CHECK(t, rmse[1] < 0.8 * rmse[0] && rmse[2] < 0.8 * rmse[1], "RMSE %g %g %g", rmse[0], rmse[1], rmse[2]);
    last = cli_last_line(out);
    CHECK(t, HARNESS_STARTS(last, "sweep best method=pt rmse_optimal_spp=16 rmse="), "best line: %s", last);
    CHECK(t, strstr(last, " ssim_optimal_spp=16 ssim=") != NULL, "best line: %s", last);
    CHECK_NEAR(t, harness_value(last, "rmse"), rmse[2], 1e-9);

    /* the metric is pds_image_rmse of the image pds render makes with the
       same options */
    harness_path(one, sizeof one, "spp16.pfm");
    snprintf(args, sizeof args,
             "render tests/golden/glass.scene --method pt --spp 16 --res 32x24 --no-caustics --quiet -o %s", one);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "render failed: %s", out);
    if (pds_image_read_pfm(one, &a, NULL) == PDS_OK && pds_image_read_pfm(ref, &b, NULL) == PDS_OK)
        CHECK_NEAR(t, pds_image_rmse(&a, &b), rmse[2], 5e-7);
    else
        CHECK(t, 0, "could not read %s or %s", one, ref);
    pds_image_free(&a);
    pds_image_free(&b);
    remove(one);

    snprintf(path, sizeof path, "%s/sweep.csv", dir);
    csv = harness_slurp(path, NULL);
    REQUIRE(t, csv != NULL, "no %s", path);
    CHECK(t, harness_count(csv, "\n") == 4, "header and 3 rows: %s", csv);
    CHECK(t, HARNESS_STARTS(csv, "method,param,value,photons,spp,passes,map_bytes,rmse,ssim,time_s,image\n"), "%s", csv);
    CHECK(t, strstr(csv, "\npt,spp,1,0,1,1,0,") && strstr(csv, "\npt,spp,4,0,4,1,0,") &&
                 strstr(csv, "\npt,spp,16,0,16,1,0,"),
          "rows: %s", csv);
    free(csv);
    snprintf(path, sizeof path, "%s/sweep.svg", dir);
    svg = harness_slurp(path, NULL);
    REQUIRE(t, svg != NULL, "no %s", path);
    CHECK(t, HARNESS_STARTS(svg, "<svg xmlns=\"http://www.w3.org/2000/svg\""), "SVG start");
    CHECK(t, strstr(svg, "</svg>\n") != NULL, "SVG end");
    CHECK(t, harness_count(svg, "class=\"rmse-marker\"") == 3, "three RMSE markers");
    CHECK(t, harness_count(svg, "class=\"ssim-marker\"") == 3, "three SSIM markers");
    CHECK(t, harness_count(svg, "<polyline") == 2, "two polylines");
    CHECK(t, strstr(svg, "class=\"rmse-optimum\"") && strstr(svg, "class=\"ssim-optimum\""), "optima marked");
    CHECK(t, strstr(svg, "spp=16: RMSE ") != NULL, "marker titles");
    CHECK(t, strstr(svg, "RMSE (linear RGB)") && strstr(svg, "SSIM (sRGB luminance)"), "axis labels");
    CHECK(t, strstr(svg, "spp (log scale)") != NULL, "1..16 spans more than a decade: log x axis");
    free(svg);
    for (i = 0; i < 3; i++) {
        static const char *const f[3] = {"spp-1.png", "spp-4.png", "spp-16.png"};
        snprintf(path, sizeof path, "%s/%s", dir, f[i]);
        CHECK(t, cli_file_exists(path), "%s written", path);
    }
    CHECK(t, harness_dir_count(dir, ".tmp") == 0, "no temporary files left");
    harness_rmtree(dir);
    remove(ref);
}

static void test_harness_sweep_checks_the_reference_before_writing_anything(pds_test_ctx *t)
{
    char out[8192], args[1024], ref[256], dir[256], missing[256], expect[512];
    REQUIRE(t, harness_reference(t, ref, sizeof ref), "no reference");
    harness_path(dir, sizeof dir, "sweep_bad");
    harness_path(missing, sizeof missing, "missing.pfm");
    harness_rmtree(dir);
    remove(missing);
    snprintf(args, sizeof args,
             "sweep tests/golden/glass.scene --method pt --param spp --values 1,2 --ref %s --res 32x24 -o %s", missing,
             dir);
    CHECK(t, cli_run(args, out, sizeof out) == 1, "missing reference: exit 1: %s", out);
    snprintf(expect, sizeof expect, "%s: cannot open", missing);
    CHECK(t, !strncmp(out, expect, strlen(expect)), "message: %s", out);
    CHECK(t, !harness_dir_exists(dir), "no folder after a failure");
    /* the scene's camera is 64x48, the reference 32x24 */
    snprintf(args, sizeof args, "sweep tests/golden/glass.scene --method pt --param spp --values 1,2 --ref %s -o %s",
             ref, dir);
    CHECK(t, cli_run(args, out, sizeof out) == 1, "size mismatch: exit 1: %s", out);
    snprintf(expect, sizeof expect,
             "%s: the reference is 32x24 but the renders are 64x48 (give --res 32x24 or a reference of that size)\n",
             ref);
    CHECK(t, !strcmp(out, expect), "message: %s", out);
    CHECK(t, !harness_dir_exists(dir), "no folder after a failure");
    /* the same for race */
    snprintf(args, sizeof args, "race tests/golden/glass.scene --methods pds --photons 10 --ref %s -o %s", ref, dir);
    CHECK(t, cli_run(args, out, sizeof out) == 1 && !strcmp(out, expect), "race size mismatch: %s", out);
    CHECK(t, !harness_dir_exists(dir), "no folder after a failure");
    remove(ref);
}

static void test_harness_race_writes_every_image_its_index_shows(pds_test_ctx *t)
{
    static const char *const labels[3] = {"pt", "pt-spp64", "pds"};
    char out[16384], args[1024], ref[256], dir[256], path[512], lines[8][512], expect[512];
    char *html, *csv, *p;
    const char *last;
    int i, n, w, h, srcs = 0;
    unsigned char *png;
    REQUIRE(t, harness_reference(t, ref, sizeof ref), "no reference");
    harness_path(dir, sizeof dir, "race");
    harness_rmtree(dir);
    snprintf(args, sizeof args,
             "race tests/golden/glass.scene --ref %s --photons 1000 --methods pt,pt:spp=64,pds --res 32x24 --spp 1 "
             "--no-caustics --quiet -o %s",
             ref, dir);
    REQUIRE(t, cli_run(args, out, sizeof out) == 0, "race failed: %s", out);
    n = harness_lines(out, "race method=", lines, 8);
    REQUIRE(t, n == 3, "one line per method, got %d: %s", n, out);
    CHECK(t, HARNESS_STARTS(lines[0], "race method=pt label=pt photons=0 spp=1 rmse="), "%s", lines[0]);
    CHECK(t, HARNESS_STARTS(lines[1], "race method=pt label=pt-spp64 photons=0 spp=64 rmse="), "%s", lines[1]);
    /* without caustic paths the photon methods have nothing to emit */
    CHECK(t, HARNESS_STARTS(lines[2], "race method=pds label=pds photons=0 spp=1 progressive=1 pass_smoothing=2 pass_photons=16384 pass_alpha=0.666667 pass_min_aspect=0.1 pass_min_width=1.5 split_depth=0 split_angle=0.2 rmse="), "%s", lines[2]);
    /* 64 times the samples: an eighth of the error, a firefly or not */
    CHECK(t, harness_value(lines[1], "rmse") < harness_value(lines[0], "rmse"), "64 spp beat 1 spp: %s / %s",
          lines[1], lines[0]);
    last = cli_last_line(out);
    snprintf(expect, sizeof expect, "race dir=%s methods=3 roi=0,0,32,24 budgets=1 flagged=0 resumed=0", dir);
    CHECK(t, !strcmp(last, expect), "final line: %s", last);

    snprintf(path, sizeof path, "%s/race.csv", dir);
    csv = harness_slurp(path, NULL);
    REQUIRE(t, csv != NULL, "no %s", path);
    CHECK(t, harness_count(csv, "\n") == 4, "header and 3 rows: %s", csv);
    CHECK(t, HARNESS_STARTS(csv, "method,label,budget_photons,photons,spp,passes,parameters,tuned,rmse,ssim,time_s,"
                                 "time_eye_s,time_photons_s,time_map_s,time_gather_s,map_bytes,diff_scale,budget_flag\n"),
          "header: %s", csv);
    CHECK(t, strstr(csv, "\npt,pt,1000,0,1,1,,,") && strstr(csv, "\npt,pt-spp64,1000,0,64,1,,,") &&
                 strstr(csv, "\npds,pds,1000,0,1,0,progressive=1 pass_smoothing=2 pass_photons=16384 pass_alpha=0.666667 pass_min_aspect=0.1 pass_min_width=1.5 split_depth=0 split_angle=0.2,,"),
          "rows: %s", csv);
    CHECK(t, harness_count(csv, ",ok\n") == 3, "a photon budget is met exactly: %s", csv);
    free(csv);

    snprintf(path, sizeof path, "%s/index.html", dir);
    html = harness_slurp(path, NULL);
    REQUIRE(t, html != NULL, "no %s", path);
    CHECK(t, HARNESS_STARTS(html, "<!DOCTYPE html>") && strstr(html, "</html>\n"), "an HTML document");
    CHECK(t, harness_count(html, "<script") == 1 && strstr(html, "<script>\n") != NULL, "one inline script");
    CHECK(t, strstr(html, "http://") == NULL && strstr(html, "https://") == NULL, "no network address");
    /* every image and link it names is in the folder */
    for (p = html; (p = strstr(p, "src=\"")) != NULL;) {
        char name[256];
        size_t len;
        p += 5;
        len = strcspn(p, "\"");
        snprintf(name, sizeof name, "%.*s", (int)len, p);
        CHECK(t, strchr(name, '/') == NULL, "relative path in the folder: %s", name);
        snprintf(path, sizeof path, "%s/%s", dir, name);
        CHECK(t, cli_file_exists(path), "index.html shows %s, which is missing", name);
        srcs++;
    }
    for (p = html; (p = strstr(p, "href=\"")) != NULL;) {
        char name[256];
        size_t len;
        p += 6;
        len = strcspn(p, "\"");
        snprintf(name, sizeof name, "%.*s", (int)len, p);
        snprintf(path, sizeof path, "%s/%s", dir, name);
        CHECK(t, cli_file_exists(path), "index.html links %s, which is missing", name);
    }
    /* reference: full and crop; each method: full, crop, difference */
    /* and the comparer's two images */
    CHECK(t, srcs == 2 + 3 * 3 + 2, "images shown: %d", srcs);
    CHECK(t, strstr(html, "src=\"ref.png\"") && strstr(html, "src=\"ref-crop.png\"") && strstr(html, "href=\"race.csv\""),
          "reference and table");
    for (i = 0; i < 3; i++) {
        const char *kind[3] = {".png", "-crop.png", "-diff.png"};
        int k;
        for (k = 0; k < 3; k++) {
            char needle[128];
            snprintf(needle, sizeof needle, "src=\"%s%s\"", labels[i], kind[k]);
            CHECK(t, strstr(html, needle) != NULL, "index shows %s", needle);
        }
        snprintf(path, sizeof path, "%s/%s.pfm", dir, labels[i]);
        CHECK(t, cli_file_exists(path), "%s written", path);
    }
    free(html);
    /* crops: the 32x24 region scaled 8x with nearest neighbour to 256 wide */
    snprintf(path, sizeof path, "%s/pt-crop.png", dir);
    png = harness_png(path, &w, &h);
    CHECK(t, png && w == 256 && h == 192, "crop size %dx%d", png ? w : -1, png ? h : -1);
    if (png) {
        int x, y, blocks_ok = 1;
        for (y = 0; y < h; y++)
            for (x = 0; x < w; x++)
                if (memcmp(png + 3 * ((size_t)y * w + x), png + 3 * ((size_t)(y / 8 * 8) * w + x / 8 * 8), 3))
                    blocks_ok = 0;
        CHECK(t, blocks_ok, "every 8x8 block of the crop is one source pixel");
    }
    free(png);
    CHECK(t, harness_dir_count(dir, ".tmp") == 0, "no temporary files left");
    harness_rmtree(dir);
    remove(ref);
}

static float harness_black(int x, int y)
{
    (void)x;
    (void)y;
    return 0.0f;
}

static float harness_bright(int x, int y)
{
    (void)x;
    (void)y;
    return 100.0f;
}

/* 128x96, black but for a 20x20 checkerboard of 1s and 0s at x 80..99,
   y 40..59. */
static float harness_patch(int x, int y)
{
    return x >= 80 && x < 100 && y >= 40 && y < 60 && (x + y) % 2 == 0 ? 1.0f : 0.0f;
}

/* Race against a reference PFM; returns the difference image's RGB bytes. */
static unsigned char *harness_race_diff(pds_test_ctx *t, const char *ref, const char *dir, int *w, int *h)
{
    char out[16384], args[1024], path[512];
    harness_rmtree(dir);
    snprintf(args, sizeof args,
             "race tests/golden/glass.scene --ref %s --photons 500 --methods pds --res 32x24 --spp 2 --quiet -o %s", ref,
             dir);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "race failed: %s", out);
    snprintf(path, sizeof path, "%s/pds-diff.png", dir);
    return harness_png(path, w, h);
}

static void test_harness_race_difference_is_green_where_too_bright_and_red_where_too_dark(pds_test_ctx *t)
{
    char ref[256], dir[256];
    unsigned char *px;
    int w, h, i, n, red = 0, green = 0, blue = 0, full = 0;
    harness_path(ref, sizeof ref, "black.pfm");
    harness_path(dir, sizeof dir, "race_diff");
    REQUIRE(t, harness_write_pfm(ref, 32, 24, harness_black), "could not write %s", ref);
    /* against black every pixel is too bright or right: only green */
    px = harness_race_diff(t, ref, dir, &w, &h);
    REQUIRE(t, px && w == 32 && h == 24, "pds-diff.png missing or not 32x24");
    n = w * h;
    for (i = 0; i < n; i++) {
        red += px[3 * i] != 0;
        green += px[3 * i + 1] != 0;
        blue += px[3 * i + 2] != 0;
        full += px[3 * i + 1] == 255;
    }
    CHECK(t, red == 0 && blue == 0, "red %d blue %d", red, blue);
    CHECK(t, green > 0 && full < n, "green %d full %d", green, full);
    /* the 99th percentile of |error| maps to full colour: at least the top
       1% of the 768 pixels (indices 759..767 of the sorted errors) */
    CHECK(t, full >= 9, "saturated pixels: %d", full);
    free(px);
    /* against 100 W/m^2/sr everywhere every pixel is too dark: only red */
    REQUIRE(t, harness_write_pfm(ref, 32, 24, harness_bright), "could not write %s", ref);
    px = harness_race_diff(t, ref, dir, &w, &h);
    REQUIRE(t, px && w == 32 && h == 24, "pds-diff.png missing or not 32x24");
    for (i = 0, red = green = blue = 0; i < n; i++) {
        red += px[3 * i] != 0;
        green += px[3 * i + 1] != 0;
        blue += px[3 * i + 2] != 0;
    }
    CHECK(t, red == n && green == 0 && blue == 0, "red %d green %d blue %d", red, green, blue);
    free(px);
    harness_rmtree(dir);
    remove(ref);
}

static void test_harness_race_region_of_interest_is_the_most_varied_window(pds_test_ctx *t)
{
    char out[16384], args[1024], ref[256], dir[256], path[512];
    unsigned char *px;
    const char *last;
    int w, h;
    harness_path(ref, sizeof ref, "patch.pfm");
    harness_path(dir, sizeof dir, "race_roi");
    harness_rmtree(dir);
    REQUIRE(t, harness_write_pfm(ref, 128, 96, harness_patch), "could not write %s", ref);
    /* 64x64 windows at multiples of 8 (and flush with the edges): those
       holding the whole patch have x in 40..64 and any y in 0..32; the
       variance ties among them, and the top-most, left-most wins */
    snprintf(args, sizeof args,
             "race tests/golden/glass.scene --ref %s --photons 200 --methods pds --res 128x96 --spp 1 --quiet -o %s",
             ref, dir);
    REQUIRE(t, cli_run(args, out, sizeof out) == 0, "race failed: %s", out);
    CHECK(t, strstr(out, "race method=pds label=pds photons=200 spp=1 progressive=1 pass_smoothing=2 pass_photons=16384 pass_alpha=0.666667 pass_min_aspect=0.1 pass_min_width=1.5 split_depth=0 split_angle=0.2 rmse=") != NULL, "%s", out);
    last = cli_last_line(out);
    CHECK(t, strstr(last, " roi=40,0,64,64") != NULL, "final line: %s", last);
    snprintf(path, sizeof path, "%s/ref-crop.png", dir);
    px = harness_png(path, &w, &h);
    REQUIRE(t, px && w == 256 && h == 256, "ref-crop.png: 64x64 scaled 4x");
    /* crop pixel (160, 160) is reference pixel (40 + 40, 0 + 40): white;
       (164, 160) is (81, 40): black; (0, 0) is (40, 0): black */
    CHECK(t, px[3 * (160 * 256 + 160)] == 255 && px[3 * (160 * 256 + 164)] == 0 && px[0] == 0,
          "crop content %d %d %d", px[3 * (160 * 256 + 160)], px[3 * (160 * 256 + 164)], px[0]);
    free(px);
    /* a given region is taken as it is */
    snprintf(args, sizeof args,
             "race tests/golden/glass.scene --ref %s --photons 200 --methods pds --res 128x96 --spp 1 --roi 8,4,16,8 "
             "--quiet -o %s",
             ref, dir);
    REQUIRE(t, cli_run(args, out, sizeof out) == 0, "race failed: %s", out);
    last = cli_last_line(out);
    CHECK(t, strstr(last, " roi=8,4,16,8") != NULL, "final line: %s", last);
    snprintf(path, sizeof path, "%s/pds-crop.png", dir);
    px = harness_png(path, &w, &h);
    CHECK(t, px && w == 256 && h == 128, "16x8 region scaled 16x: %dx%d", px ? w : -1, px ? h : -1);
    free(px);
    harness_rmtree(dir);
    remove(ref);
}

static void test_harness_bad_usage_exits_2_with_a_message(pds_test_ctx *t)
{
    static const char *const cases[][2] = {
        {"sweep", "sweep needs a scene file"},
        {"sweep S", "sweep needs --param NAME"},
        {"sweep S --param spp", "sweep needs --values A,B,..."},
        {"sweep S --param spp --values 1,2", "sweep needs --ref REFERENCE.pfm"},
        {"sweep S --param foo --values 1 --ref R",
         "--param knows photons, smoothing, min-aspect, min-width, pass-smoothing, pass-min-aspect, pass-min-width, pass-photons, eye-rounds, split-depth, split-angle, pass-alpha, k, max-radius, streams, stream-photons, max-photons, radius, alpha, passes, global-photons, global-k, gather, gather-mix, stream-radius, light-res, history and spp, got 'foo'"},
        {"sweep S --param k --values 1 --ref R", "--param k has no effect with --method pds (k is for pm, gi and spm)"},
        {"sweep S --method pt --param spp --values 1,,4 --ref R",
         "--values needs a comma-separated list of values, got '1,,4'"},
        {"sweep S --method pt --param spp --values 1,x --ref R", "spp needs a whole number from 1 to 65536, got 'x'"},
        {"sweep S --method pt --param spp --values 1 --ref R --spp 4",
         "spp is the parameter swept: give its values with --values, not --spp"},
        {"sweep S --param photons --values 1 --ref R --time 1",
         "--param photons and --time exclude each other (the time decides the photon count)"},
        {"sweep S --method pm --param k --values 10,0 --ref R", "k needs a whole number from 1 to 1000000, got '0'"},
        {"sweep S --param spp --values 1 --ref R --debug footprint", "--debug is not a sweep option"},
        {"race", "race needs a scene file"},
        {"race S", "race needs --ref REFERENCE.pfm"},
        {"race S --ref R", "race needs --methods M1,M2,... (for example pds,pm:k=50,ppm)"},
        {"race S --ref R --methods pt", "race needs a budget: --time SECONDS, --photons N or --budgets LIST"},
        {"race S --ref R --methods pt --time 1 --budgets 1,2", "--budgets replaces --time: give one of them"},
        {"race S --ref R --methods pt --budgets 1,x", "--budgets needs seconds above 0, comma-separated, got '1,x'"},
        {"race S --ref R --methods pt --budgets 1,0 --budget-kind photons",
         "--budgets needs photon counts of 1 or more, comma-separated, got '1,0'"},
        {"race S --ref R --methods pt --budgets 1 --budget-kind joules", "--budget-kind knows time and photons, got 'joules'"},
        {"race S --ref R --methods pt --time 1 --budget-kind time", "--budget-kind goes with --budgets"},
        {"race S --ref R --methods pt --time 1 --diff-scale big", "--diff-scale needs shared, each or a positive number, got 'big'"},
        {"race S --ref R --methods pt --time 1 --tune=yes", "--tune takes no value, got '--tune=yes'"},
        {"race S --ref R --methods pt --time 1 --photons 3", "race takes one budget: --time or --photons, not both"},
        {"race S --ref R --methods pt,bogus --photons 3",
         "unknown method 'bogus' (this version has: pds, pt, preview, pm, pdm, splat, ppm, gi, spm, isc)"},
        {"race S --ref R --methods pt, --photons 3", "--methods needs a comma-separated list of methods, got 'pt,'"},
        {"race S --ref R --methods pm:k --photons 3", "--methods: 'k' after pm needs NAME=VALUE"},
        {"race S --ref R --methods pds:k=5 --photons 3", "--methods: k has no effect with pds (k is for pm, gi and spm)"},
        {"race S --ref R --methods pt:photons=5 --photons 3",
         "--methods: photons cannot be set for one method; give it to all with --photons"},
        {"race S --ref R --methods pt:foo=5 --photons 3", "--methods: unknown option 'foo' for pt"},
        {"race S --ref R --methods pm:k=0 --photons 3", "pm:k needs a whole number from 1 to 1000000, got '0'"},
        {"race S --ref R --methods pt --photons 3 --roi 1,2,3", "--roi needs X,Y,WIDTH,HEIGHT in pixels, got '1,2,3'"},
        {"race S --ref R --methods pt --method pt --photons 3", "race takes a list of methods: --methods M1,M2,..."},
        {"render S --kernel box", "--kernel knows cone, gaussian and none, got 'box'"},
        {"render S --alpha 1.5", "--alpha needs a number above 0 and at most 1, got '1.5'"},
        {"render S --alpha 0", "--alpha needs a number above 0 and at most 1, got '0'"},
        {"render S --radius 0", "--radius needs a positive distance in scene units, got '0'"},
        {"render S --max-radius -1", "--max-radius needs a positive distance in scene units, got '-1'"},
        {"render S --k 0", "--k needs a whole number from 1 to 1000000, got '0'"},
        {"render S --passes 0", "--passes needs a whole number from 1 to 1000000, got '0'"},
        {"render S --max-photons 0", "--max-photons needs a whole number from 1 to 100000000, got '0'"},
        {"render S --method xyz", "unknown method 'xyz' (this version has: pds, pt, preview, pm, pdm, splat, ppm, gi, spm, isc)"},
    };
    char out[8192], args[1024], expect[512], ref[256], dir[256];
    size_t i;
    REQUIRE(t, harness_reference(t, ref, sizeof ref), "no reference");
    harness_path(dir, sizeof dir, "usage");
    harness_rmtree(dir);
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        /* S: the scene, R: the reference */
        const char *c = cases[i][0];
        size_t at = 0;
        for (; *c && at + 300 < sizeof args; c++) {
            if (*c == 'S' && (c[1] == ' ' || !c[1])) at += (size_t)sprintf(args + at, "tests/golden/glass.scene");
            else if (*c == 'R' && (c[1] == ' ' || !c[1])) at += (size_t)sprintf(args + at, "%s", ref);
            else args[at++] = *c;
        }
        args[at] = '\0';
        if (strncmp(args, "render", 6) && strchr(args, ' '))
            snprintf(args + at, sizeof args - at, " --res 32x24 -o %s", dir);
        {
            /* messages name the command: "pds race: ...", "(run 'pds race --help' ...)" */
            int cmd_len = (int)strcspn(cases[i][0], " ");
            snprintf(expect, sizeof expect, "pds %.*s: %s\n(run 'pds %.*s --help' for usage)\n", cmd_len, cases[i][0],
                     cases[i][1], cmd_len, cases[i][0]);
        }
        CHECK(t, cli_run(args, out, sizeof out) == 2, "exit 2 for: %s", args);
        CHECK(t, strstr(out, expect) != NULL, "%s\n  expected: %s  got: %s", args, expect, out);
        CHECK(t, !harness_dir_exists(dir), "no folder after: %s", args);
    }
    /* a region that does not fit is a usage error too, found once the
       image size is known */
    snprintf(args, sizeof args, "race tests/golden/glass.scene --ref %s --methods pt --time 1 --res 32x24 --roi 0,0,64,64 -o %s",
             ref, dir);
    CHECK(t, cli_run(args, out, sizeof out) == 2 && strstr(out, "pds race: --roi 0,0,64,64 does not fit the 32x24 image\n"),
          "%s", out);
    CHECK(t, !harness_dir_exists(dir), "no folder after a bad --roi");
    remove(ref);
}

/* A caustics-only reference for the race tests that need photons: the
   golden glass scene by ppm (a neutral method, not pds), 32x24. */
static int harness_caustics_reference(pds_test_ctx *t, char *ref, size_t n)
{
    char out[8192], args[1024];
    harness_path(ref, n, "caustics_ref.pfm");
    snprintf(args, sizeof args,
             "render tests/golden/glass.scene --method ppm --caustics-only --photons 20000 --passes 8 --res 32x24 "
             "--spp 4 --seed 9 --quiet -o %s",
             ref);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "reference render failed: %s", out);
    return cli_file_exists(ref);
}

/* The CSV field number `col` (0-based) of the line that starts with
   prefix, copied into out ("" if none). No quoted fields before it. */
static void harness_csv_field(const char *csv, const char *prefix, int col, char *out, size_t n)
{
    const char *p = csv;
    out[0] = '\0';
    while (p && *p) {
        if (!strncmp(p, prefix, strlen(prefix))) {
            int k;
            for (k = 0; k < col && p; k++) {
                p = strpbrk(p, ",\n");
                if (p && *p == ',') p++;
                else p = NULL;
            }
            if (p) snprintf(out, n, "%.*s", (int)strcspn(p, ",\n"), p);
            return;
        }
        p = strchr(p, '\n');
        if (p) p++;
    }
}

/* Run pds with args (a race or sweep writing into dir) and return the
   CSV file it wrote there (malloc'd), or NULL after a failed check. */
static char *harness_run_csv(pds_test_ctx *t, const char *args, const char *dir, const char *file)
{
    char out[16384], err[4096], path[512];
    int ok = cli_run_split(args, out, sizeof out, err, sizeof err) == 0;
    CHECK(t, ok, "pds %.40s... failed: %s%s", args, out, err);
    if (!ok) return NULL;
    snprintf(path, sizeof path, "%s/%s", dir, file);
    return harness_slurp(path, NULL);
}

/* race --mask, sweep --mask and compare --mask: a mask holding the
   reference's left half. race.csv's RMSE and SSIM of each entry are
   those of its kept image over the mask (pds_image_compare_masked), not
   over the whole image, and so are compare --mask's line and sweep.csv's
   RMSE; the race page says which pixels it measured. A mask of another
   size is refused before any render, naming the mask, and leaves no
   folder. */
static void test_harness_race_sweep_and_compare_take_a_mask(pds_test_ctx *t)
{
    static const char *const labels[2] = {"pds", "pm"};
    char out[16384], err[4096], args[1200], ref[256], dir[256], path[512], maskp[256], bad[256], field[128], want[64];
    char *csv, *html;
    pds_image mask, small, img, refimg;
    pds_metrics m, whole;
    pds_error e;
    int i, k;
    REQUIRE(t, harness_caustics_reference(t, ref, sizeof ref), "no reference");
    REQUIRE(t, pds_image_alloc(&mask, 32, 24) == PDS_OK && pds_image_alloc(&small, 16, 16) == PDS_OK, "alloc");
    for (i = 0; i < 32 * 24; i++)
        for (k = 0; k < 3; k++) mask.rgb[3 * i + k] = i % 32 < 16 ? 1.0f : 0.0f;
    harness_path(maskp, sizeof maskp, "race_mask.pfm");
    harness_path(bad, sizeof bad, "race_mask_small.pfm");
    REQUIRE(t, pds_image_write_pfm(maskp, &mask, &e) == PDS_OK && pds_image_write_pfm(bad, &small, &e) == PDS_OK,
            "write the masks: %s", e.text);
    harness_path(dir, sizeof dir, "race_mask");
    harness_rmtree(dir);
    snprintf(args, sizeof args,
             "race tests/golden/glass.scene --ref %s --mask %s --photons 4000 --methods pds,pm --res 32x24 --spp 4 "
             "--caustics-only --quiet -o %s",
             ref, maskp, dir);
    csv = harness_run_csv(t, args, dir, "race.csv");
    REQUIRE(t, csv != NULL && pds_image_read_pfm(ref, &refimg, &e) == PDS_OK, "race.csv and the reference");
    for (k = 0; k < 2; k++) {
        char prefix[64];
        snprintf(path, sizeof path, "%s/entries/%s.pfm", dir, labels[k]);
        REQUIRE(t, pds_image_read_pfm(path, &img, &e) == PDS_OK, "%s: %s", path, e.text);
        REQUIRE(t, pds_image_compare_masked(&img, &refimg, &mask, &m, &e) == PDS_OK &&
                       pds_image_compare(&img, &refimg, &whole, &e) == PDS_OK,
                "compare: %s", e.text);
        CHECK(t, fabs(m.rmse - whole.rmse) > 1e-6 * whole.rmse, "%s: the mask changed nothing", labels[k]);
        snprintf(prefix, sizeof prefix, "%s,%s,", k ? "pm" : "pds", labels[k]);
        harness_csv_field(csv, prefix, 8, field, sizeof field);
        snprintf(want, sizeof want, "%.6f", m.rmse);
        CHECK(t, !strcmp(field, want), "%s: race.csv's rmse %s, over the mask %s", labels[k], field, want);
        harness_csv_field(csv, prefix, 9, field, sizeof field);
        snprintf(want, sizeof want, "%.6f", m.ssim);
        CHECK(t, !strcmp(field, want), "%s: race.csv's ssim %s, over the mask %s", labels[k], field, want);
        if (k == 0) {
            char line[128];
            snprintf(args, sizeof args, "compare %s %s --mask %s", path, ref, maskp);
            REQUIRE(t, cli_run(args, out, sizeof out) == 0, "compare --mask: %s", out);
            snprintf(line, sizeof line, "compare rmse=%.6f ssim=%.6f", m.rmse, m.ssim);
            CHECK(t, strstr(out, line) != NULL, "compare --mask printed %s, want %s", out, line);
        }
        pds_image_free(&img);
    }
    free(csv);
    snprintf(path, sizeof path, "%s/index.html", dir);
    html = harness_slurp(path, NULL);
    CHECK(t, html && strstr(html, "RMSE and SSIM over the pixels the mask <code>"), "the page does not say so");
    free(html);
    harness_rmtree(dir);
    /* sweep --mask: its one value's figures over the mask too */
    snprintf(args, sizeof args,
             "sweep tests/golden/glass.scene --ref %s --mask %s --param photons --values 4000 --res 32x24 --spp 4 "
             "--caustics-only --quiet -o %s",
             ref, maskp, dir);
    csv = harness_run_csv(t, args, dir, "sweep.csv");
    snprintf(path, sizeof path, "%s/entries/photons-4000.pfm", dir);
    REQUIRE(t, csv != NULL && pds_image_read_pfm(path, &img, &e) == PDS_OK &&
                   pds_image_compare_masked(&img, &refimg, &mask, &m, &e) == PDS_OK,
            "sweep.csv and its entry: %s", e.text);
    harness_csv_field(csv, "pds,photons,4000,", 7, field, sizeof field);
    snprintf(want, sizeof want, "%.6f", m.rmse);
    CHECK(t, !strcmp(field, want), "sweep.csv's rmse %s, over the mask %s", field, want);
    pds_image_free(&img);
    free(csv);
    harness_rmtree(dir);
    snprintf(args, sizeof args,
             "race tests/golden/glass.scene --ref %s --mask %s --photons 4000 --methods pds --res 32x24 --quiet -o %s",
             ref, bad, dir);
    CHECK(t, cli_run_split(args, out, sizeof out, err, sizeof err) == 1 && strstr(err, bad) &&
                 strstr(err, ": the mask is 16x16, the images 32x24") && !cli_file_exists(dir),
          "a mask of another size: %s", err);
    pds_image_free(&mask);
    pds_image_free(&small);
    pds_image_free(&refimg);
    remove(maskp);
    remove(bad);
    remove(ref);
}

static void test_harness_race_flags_a_missed_time_budget(pds_test_ctx *t)
{
    char out[16384], err[16384], args[1024], ref[256], dir[256], path[512], field[128];
    char *csv, *html;
    const char *last;
    REQUIRE(t, harness_caustics_reference(t, ref, sizeof ref), "no reference");
    harness_path(dir, sizeof dir, "race_miss");
    harness_rmtree(dir);
    /* 5 ms: the eye pass of 32x24 x 64 samples alone takes longer, and pt's
       one pass of 256 samples too; the paper's pds gets no time for photons */
    snprintf(args, sizeof args,
             "race tests/golden/glass.scene --ref %s --time 0.005 --methods pds:progressive=0,pt:spp=256 --res 32x24 --spp 64 "
             "--caustics-only --quiet -o %s",
             ref, dir);
    REQUIRE(t, cli_run_split(args, out, sizeof out, err, sizeof err) == 0, "race failed: %s%s", out, err);
    last = cli_last_line(out);
    CHECK(t, strstr(last, " budgets=1 flagged=2") != NULL, "final line: %s", last);
    CHECK(t, strstr(err, "pds race: warning: pds-progressive0 took ") && strstr(err, "pds race: warning: pt-spp256 took ") &&
                 strstr(err, "of its 0.005 s budget (+") && strstr(err, "more than 25% off, not an equal-time result"),
          "stderr: %s", err);
    CHECK(t, strstr(err, "pds race: warning: pds-progressive0 emitted ") != NULL, "few photons on stderr: %s", err);
    snprintf(path, sizeof path, "%s/race.csv", dir);
    csv = harness_slurp(path, NULL);
    REQUIRE(t, csv != NULL, "no %s", path);
    CHECK(t, strstr(csv, ",budget_s,") != NULL, "header names the budget's unit: %s", csv);
    harness_csv_field(csv, "pds,pds-progressive0,", 17, field, sizeof field);
    CHECK(t, !strcmp(field, "over-time+few-photons"), "pds flag '%s': %s", field, csv);
    harness_csv_field(csv, "pt,pt-spp256,", 17, field, sizeof field);
    CHECK(t, !strcmp(field, "over-time"), "pt flag '%s': %s", field, csv);
    free(csv);
    snprintf(path, sizeof path, "%s/index.html", dir);
    html = harness_slurp(path, NULL);
    REQUIRE(t, html != NULL, "no %s", path);
    CHECK(t, strstr(html, "Not a fair comparison as it stands") && strstr(html, ">over-time+few-photons</td>") &&
                 strstr(html, ">over-time</td>"),
          "the page flags both");
    free(html);
    harness_rmtree(dir);
    remove(ref);
}

static void test_harness_race_tune_picks_the_lowest_rmse_of_its_grid_on_another_seed(pds_test_ctx *t)
{
    static const char *const methods[3] = {"pds", "pm", "ppm"};
    static const char *const labels[3] = {"pds", "pm", "ppm-alpha0.7"};
    /* pds is progressive by default: its grid is the first pass's s */
    static const char *const keys[3] = {"pass-smoothing", "k", "radius"};
    static const char *const param_keys[3] = {"pass_smoothing", "k", "radius"};
    static const int grid[3] = {7, 5, 5};
    char out[16384], args[1024], ref[256], dir[256], path[512], lines[8][512];
    char *csv, *tune, *html;
    int i, n;
    REQUIRE(t, harness_caustics_reference(t, ref, sizeof ref), "no reference");
    harness_path(dir, sizeof dir, "race_tune");
    harness_rmtree(dir);
    snprintf(args, sizeof args,
             "race tests/golden/glass.scene --ref %s --photons 2000 --methods pds,pm,ppm:alpha=0.7,pm:k=30:max-radius=0.5 --tune "
             "--res 32x24 --spp 4 --seed 5 --caustics-only --quiet -o %s",
             ref, dir);
    REQUIRE(t, cli_run_split(args, out, sizeof out, NULL, 0) == 0, "race failed: %s", out);
    n = harness_lines(out, "race method=", lines, 8);
    REQUIRE(t, n == 4, "one line per method: %s", out);
    CHECK(t, strstr(lines[0], " tuned=pass-smoothing") && strstr(lines[1], " tuned=k") && strstr(lines[2], " tuned=radius") &&
                 !strstr(lines[2], "tuned=radius+") && !strstr(lines[3], " tuned="),
          "tuned parameters: %s", out);
    CHECK(t, strstr(lines[3], " k=30 ") != NULL, "a value given in --methods is kept: %s", lines[3]);
    snprintf(path, sizeof path, "%s/tune.csv", dir);
    tune = harness_slurp(path, NULL);
    snprintf(path, sizeof path, "%s/race.csv", dir);
    csv = harness_slurp(path, NULL);
    REQUIRE(t, tune && csv, "tune.csv and race.csv written");
    CHECK(t, HARNESS_STARTS(tune, "label,method,budget_photons,param,value,seed,rmse,ssim,time_s,photons,chosen\n"),
          "tune.csv header: %s", tune);
    /* pds: 7 first-pass smoothings, pm: 5 k and 5 maximum radii, ppm: 5 radii (alpha given), pm:k=30 none */
    CHECK(t, harness_count(tune, "\n") == 1 + 7 + 10 + 5, "rows: %s", tune);
    CHECK(t, strstr(tune, "pm-k30") == NULL && strstr(tune, ",alpha,") == NULL, "given values are not tuned");
    for (i = 0; i < 3; i++) {
        char prefix[64], want[128], field[128], best_value[32] = "";
        const char *p;
        double best = 1e300;
        int rows = 0, chosen = 0, chosen_is_best = 0;
        snprintf(prefix, sizeof prefix, "%s,%s,2000,%s,", labels[i], methods[i], keys[i]);
        for (p = strstr(tune, prefix); p; p = strstr(p + 1, prefix)) {
            char value[32];
            int seed, ch;
            double rmse;
            if (p[-1] != '\n') continue;
            if (sscanf(p + strlen(prefix), "%31[^,],%d,%lf,%*f,%*f,%*d,%d", value, &seed, &rmse, &ch) != 4) continue;
            rows++;
            CHECK(t, seed == 6, "tuned on seed + 1 (6), not the reported seed 5: %d", seed);
            if (rmse < best) {
                best = rmse;
                snprintf(best_value, sizeof best_value, "%s", value);
                chosen_is_best = ch;
            }
            chosen += ch;
        }
        CHECK(t, rows == grid[i], "%s: %d grid rows", labels[i], rows);
        CHECK(t, chosen == 1 && chosen_is_best, "%s: the row of lowest RMSE (%s) is the one chosen", labels[i],
              best_value);
        /* race.csv's tuned column and the render's parameters show it */
        snprintf(want, sizeof want, "%s=%s", keys[i], best_value);
        snprintf(prefix, sizeof prefix, "%s,%s,", methods[i], labels[i]);
        harness_csv_field(csv, prefix, 7, field, sizeof field);
        /* pm's second parameter (max-radius) follows its k */
        CHECK(t, !strncmp(field, want, strlen(want)) && (field[strlen(want)] == '\0' || (i == 1 && field[strlen(want)] == ' ')),
              "%s: tuned '%s', want '%s'", labels[i], field, want);
        snprintf(want, sizeof want, " %s=%s", param_keys[i], best_value);
        CHECK(t, strstr(lines[i], want) != NULL, "%s rendered with %s: %s", labels[i], want, lines[i]);
    }
    snprintf(path, sizeof path, "%s/index.html", dir);
    html = harness_slurp(path, NULL);
    CHECK(t, html && strstr(html, "<b>Tuned</b>") && strstr(html, "rendered with seed 6, not the seed 5") &&
                 strstr(html, "href=\"tune.csv\""),
          "the page says how it was tuned");
    free(html);
    free(tune);
    free(csv);
    harness_rmtree(dir);
    remove(ref);
}

/* Under a time budget a tuning render that overran it is not an
   equal-time result: with a 1 ms budget every radius overruns, and the
   quickest is kept, with a warning. (The mixed case, some values within
   the budget and some over, needs a clock the test cannot control.) */
static void test_harness_race_tune_keeps_the_quickest_when_every_value_overruns(pds_test_ctx *t)
{
    char out[16384], err[4096], args[1024], ref[256], dir[256], path[512];
    char *tune;
    const char *p;
    int rows = 0, chosen = 0;
    double chosen_time = -1.0, least = 1e300;
    REQUIRE(t, harness_caustics_reference(t, ref, sizeof ref), "no reference");
    harness_path(dir, sizeof dir, "race_tune_over");
    harness_rmtree(dir);
    snprintf(args, sizeof args,
             "race tests/golden/glass.scene --ref %s --time 0.001 --methods splat --tune --res 32x24 --spp 4 "
             "--caustics-only --quiet -o %s",
             ref, dir);
    REQUIRE(t, cli_run_split(args, out, sizeof out, err, sizeof err) == 0, "race failed: %s %s", out, err);
    CHECK(t, strstr(err, "splat: every radius of the grid took more than 25% over the 0.001 s budget; kept the "
                         "quickest, radius=") != NULL,
          "the warning: %s", err);
    snprintf(path, sizeof path, "%s/tune.csv", dir);
    tune = harness_slurp(path, NULL);
    REQUIRE(t, tune != NULL, "tune.csv written");
    for (p = strstr(tune, "\nsplat,splat,"); p; p = strstr(p + 1, "\nsplat,splat,")) {
        double time_s;
        int ch;
        if (sscanf(p + 1, "splat,splat,%*[^,],radius,%*[^,],%*d,%*f,%*f,%lf,%*d,%d", &time_s, &ch) != 2) continue;
        rows++;
        chosen += ch;
        if (ch) chosen_time = time_s;
        if (time_s < least) least = time_s;
    }
    CHECK(t, rows == 5 && chosen == 1, "%d rows, %d chosen: %s", rows, chosen, tune);
    CHECK(t, chosen_time == least, "the chosen render took %g s, the quickest %g s: %s", chosen_time, least, tune);
    free(tune);
    harness_rmtree(dir);
    remove(ref);
}

/* pds render warns when the photon pass missed its --time by more than
   25%: 1 ms cannot hold even pm's calibration, map and gather. */
static void test_harness_render_warns_of_a_missed_time_budget(pds_test_ctx *t)
{
    char out[8192], err[4096], args[512], path[256];
    harness_path(path, sizeof path, "missed.pfm");
    snprintf(args, sizeof args,
             "render tests/golden/glass.scene --method pm --time 0.001 --res 32x24 --caustics-only --quiet -o %s", path);
    REQUIRE(t, cli_run_split(args, out, sizeof out, err, sizeof err) == 0, "render failed: %s %s", out, err);
    CHECK(t, strstr(err, "pds render: warning: the render took ") && strstr(err, "of its 0.001 s budget") &&
                 strstr(err, "the map's build and gather come after the last photon"),
          "the warning: %s", err);
    remove(path);
}

static void test_harness_race_budgets_draw_a_log_log_convergence_plot(pds_test_ctx *t)
{
    static const char *const labels[4] = {"pds-1000ph", "pm-k20-1000ph", "pds-4000ph", "pm-k20-4000ph"};
    char out[16384], args[1024], ref[256], dir[256], path[512], lines[8][512], field[64];
    char *csv, *svg, *html;
    int i, n;
    REQUIRE(t, harness_caustics_reference(t, ref, sizeof ref), "no reference");
    harness_path(dir, sizeof dir, "race_budgets");
    harness_rmtree(dir);
    snprintf(args, sizeof args,
             "race tests/golden/glass.scene --ref %s --budgets 1k,4000 --budget-kind photons --methods pds,pm:k=20 "
             "--res 32x24 --spp 2 --seed 7 --caustics-only --quiet -o %s",
             ref, dir);
    REQUIRE(t, cli_run_split(args, out, sizeof out, NULL, 0) == 0, "race failed: %s", out);
    n = harness_lines(out, "race method=", lines, 8);
    REQUIRE(t, n == 4, "one line per method and budget: %s", out);
    for (i = 0; i < 4; i++) {
        char prefix[128];
        snprintf(prefix, sizeof prefix, "race method=%s label=%s photons=%s ", i % 2 ? "pm" : "pds", labels[i],
                 i < 2 ? "1000" : "4000");
        CHECK(t, !strncmp(lines[i], prefix, strlen(prefix)), "line %d: %s", i, lines[i]);
    }
    CHECK(t, strstr(cli_last_line(out), " methods=2 ") && strstr(cli_last_line(out), " budgets=2 "), "%s", out);
    snprintf(path, sizeof path, "%s/race.csv", dir);
    csv = harness_slurp(path, NULL);
    REQUIRE(t, csv != NULL, "no race.csv");
    CHECK(t, harness_count(csv, "\n") == 5, "header and one row per method and budget: %s", csv);
    for (i = 0; i < 4; i++) {
        char prefix[64];
        snprintf(prefix, sizeof prefix, "%s,%s,", i % 2 ? "pm" : "pds", labels[i]);
        harness_csv_field(csv, prefix, 2, field, sizeof field);
        CHECK(t, !strcmp(field, i < 2 ? "1000" : "4000"), "%s budget '%s'", labels[i], field);
    }
    free(csv);
    snprintf(path, sizeof path, "%s/convergence.svg", dir);
    svg = harness_slurp(path, NULL);
    REQUIRE(t, svg != NULL, "no convergence.svg");
    CHECK(t, HARNESS_STARTS(svg, "<svg xmlns=\"http://www.w3.org/2000/svg\"") && strstr(svg, "</svg>\n"), "an SVG");
    CHECK(t, strstr(svg, "<g class=\"panel rmse log-x log-y\">") &&
                 strstr(svg, "<g class=\"panel one-minus-ssim log-x log-y\">"),
          "two log-log panels: RMSE and 1 - SSIM");
    CHECK(t, strstr(svg, "time (s), log scale") && strstr(svg, "RMSE (linear RGB), log scale"), "axis labels");
    CHECK(t, harness_count(svg, "<polyline class=\"series\"") == 4, "one line per method and panel");
    CHECK(t, harness_count(svg, "class=\"point\"") == 8, "one point per render and panel");
    CHECK(t, strstr(svg, "data-method=\"pm-k20\"") && strstr(svg, "<title>pds-4000ph: RMSE "), "series and tooltips");
    free(svg);
    snprintf(path, sizeof path, "%s/index.html", dir);
    html = harness_slurp(path, NULL);
    REQUIRE(t, html != NULL, "no index.html");
    CHECK(t, strstr(html, "<img src=\"convergence.svg\"") != NULL, "the page shows the plot");
    free(html);
    harness_rmtree(dir);
    remove(ref);
}

static void test_harness_race_page_says_how_it_was_made(pds_test_ctx *t)
{
    char out[16384], args[1024], ref[256], dir[256], path[512], expect[512];
    char *html, *csv, *p;
    REQUIRE(t, harness_caustics_reference(t, ref, sizeof ref), "no reference");
    harness_path(dir, sizeof dir, "race_page");
    harness_rmtree(dir);
    snprintf(args, sizeof args,
             "race tests/golden/glass.scene --ref %s --photons 1000 --methods pds,pm --res 32x24 --spp 2 --seed 11 "
             "--threads 2 --caustics-only --quiet -o %s",
             ref, dir);
    REQUIRE(t, cli_run_split(args, out, sizeof out, NULL, 0) == 0, "race failed: %s", out);
    snprintf(path, sizeof path, "%s/index.html", dir);
    html = harness_slurp(path, NULL);
    REQUIRE(t, html != NULL, "no index.html");
    /* the exact command line */
    snprintf(expect, sizeof expect, " race tests/golden/glass.scene --ref %s --photons 1000 --methods pds,pm --res 32x24",
             ref);
    CHECK(t, strstr(html, expect) != NULL, "the command line: %s", expect);
    CHECK(t, strstr(html, "<th class=\"l\">seed</th><td class=\"l\">11</td>") != NULL, "the seed");
    CHECK(t, strstr(html, "<th class=\"l\">threads</th><td class=\"l\">2 used (given with --threads)</td>") != NULL,
          "the threads");
    CHECK(t, strstr(html, "<td class=\"l\" id=\"machine\">") && strstr(html, "<th class=\"l\">CPU</th>") &&
                 strstr(html, "<th class=\"l\">cores</th>") && strstr(html, "<th class=\"l\">pds version</th><td class=\"l\">" PDS_VERSION_STRING),
          "machine, CPU, cores and version");
    CHECK(t, strstr(html, "<th>eye pass (s)</th><th>photon tracing (s)</th><th>map build (s)</th><th>gather (s)</th>") !=
                 NULL,
          "per-phase timings");
    /* one inline script, no network */
    CHECK(t, harness_count(html, "<script") == 1, "one script");
    p = strstr(html, "<script");
    CHECK(t, p && !strncmp(p, "<script>\n", 9), "inline, no src");
    CHECK(t, strstr(html, "http:") == NULL && strstr(html, "https:") == NULL && strstr(html, "//cdn") == NULL &&
                 strstr(html, "fetch(") == NULL && strstr(html, "XMLHttpRequest") == NULL,
          "no network address or request");
    CHECK(t, strstr(html, "id=\"cmp-stage\"") && strstr(html, "data-crop=\"pm-crop.png\""), "the comparer");
    /* one difference scale for all: every row of race.csv has the same */
    CHECK(t, strstr(html, "<b>One scale for all</b>") != NULL, "shared difference scale");
    free(html);
    snprintf(path, sizeof path, "%s/race.csv", dir);
    csv = harness_slurp(path, NULL);
    REQUIRE(t, csv != NULL, "no race.csv");
    {
        char a[64], b[64];
        harness_csv_field(csv, "pds,pds,", 16, a, sizeof a);
        harness_csv_field(csv, "pm,pm,", 16, b, sizeof b);
        CHECK(t, a[0] && !strcmp(a, b), "shared diff_scale: %s / %s", a, b);
    }
    free(csv);
    harness_rmtree(dir);
    remove(ref);
}

/* The 99th percentile of |Y(a) - Y(b)| of two PFMs (Y = 0.299 R + 0.587
   G + 0.114 B of the linear values), as the page's difference images are
   scaled; -1 if one cannot be read. */
static double harness_diff_p99(const char *a_path, const char *b_path)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    double *e = NULL, p = -1.0;
    size_t i, n;
    if (pds_image_read_pfm(a_path, &a, NULL) == PDS_OK && pds_image_read_pfm(b_path, &b, NULL) == PDS_OK &&
        a.width == b.width && a.height == b.height) {
        n = (size_t)a.width * a.height;
        e = (double *)malloc(sizeof *e * (n ? n : 1));
        for (i = 0; e && i < n; i++)
            e[i] = fabs(0.299 * ((double)a.rgb[3 * i] - b.rgb[3 * i]) +
                        0.587 * ((double)a.rgb[3 * i + 1] - b.rgb[3 * i + 1]) +
                        0.114 * ((double)a.rgb[3 * i + 2] - b.rgb[3 * i + 2]));
        if (e && n) {
            qsort(e, n, sizeof *e, pds__cmp_double);
            p = e[(size_t)(0.99 * (double)(n - 1))];
        }
    }
    free(e);
    pds_image_free(&a);
    pds_image_free(&b);
    return p;
}

/* The page's difference scale: shared by default (the largest of the
   images' 99th percentiles of |error|), each its own with --diff-scale
   each, a given number with --diff-scale 0.05; and the crops' exposure
   shows the reference's peak in the region of interest as white. */
static void test_harness_race_difference_scale_is_shared_each_or_given(pds_test_ctx *t)
{
    static const char *const modes[3] = {"shared", "each", "0.05"};
    char out[16384], args[1024], ref[256], dir[256], path[512], img[512], a[64], b[64];
    double p_pds = -1.0, p_pm = -1.0;
    int m;
    REQUIRE(t, harness_caustics_reference(t, ref, sizeof ref), "no reference");
    harness_path(dir, sizeof dir, "race_diff_scale");
    for (m = 0; m < 3; m++) {
        char *csv, *html, *at;
        const char *last;
        int x, y, w, h;
        harness_rmtree(dir);
        snprintf(args, sizeof args,
                 "race tests/golden/glass.scene --ref %s --photons 1000 --methods pds,pm --res 32x24 --spp 2 "
                 "--caustics-only --diff-scale %s --quiet -o %s",
                 ref, modes[m], dir);
        REQUIRE(t, cli_run_split(args, out, sizeof out, NULL, 0) == 0, "race failed: %s", out);
        snprintf(path, sizeof path, "%s/race.csv", dir);
        csv = harness_slurp(path, NULL);
        REQUIRE(t, csv != NULL, "no race.csv");
        harness_csv_field(csv, "pds,pds,", 16, a, sizeof a);
        harness_csv_field(csv, "pm,pm,", 16, b, sizeof b);
        free(csv);
        if (m == 0) {
            snprintf(img, sizeof img, "%s/pds.pfm", dir);
            p_pds = harness_diff_p99(img, ref);
            snprintf(img, sizeof img, "%s/pm.pfm", dir);
            p_pm = harness_diff_p99(img, ref);
            CHECK(t, p_pds > 0.0 && p_pm > 0.0 && fabs(p_pds - p_pm) > 1e-3 * fmax(p_pds, p_pm),
                  "the two images' own scales differ: %g %g", p_pds, p_pm);
            CHECK(t, fabs(atof(a) / fmax(p_pds, p_pm) - 1.0) < 1e-4 && !strcmp(a, b), "shared: %s %s, max(%g, %g)",
                  a, b, p_pds, p_pm);
            /* the crops' exposure: -log2 of the reference's peak in the region */
            last = cli_last_line(out);
            at = strstr(last, " roi=");
            REQUIRE(t, at && sscanf(at, " roi=%d,%d,%d,%d", &x, &y, &w, &h) == 4, "roi: %s", last);
            snprintf(path, sizeof path, "%s/index.html", dir);
            html = harness_slurp(path, NULL);
            REQUIRE(t, html != NULL, "no index.html");
            at = strstr(html, "Crops at exposure ");
            {
                pds_image r = {0, 0, NULL};
                double peak = 0.0, stops = 0.0;
                int i, j, k;
                REQUIRE(t, pds_image_read_pfm(ref, &r, NULL) == PDS_OK, "reference");
                for (j = y; j < y + h; j++)
                    for (i = x; i < x + w; i++)
                        for (k = 0; k < 3; k++) peak = fmax(peak, r.rgb[3 * ((size_t)j * r.width + i) + k]);
                pds_image_free(&r);
                CHECK(t, at && sscanf(at, "Crops at exposure %lf", &stops) == 1 && peak > 0.0 &&
                             fabs(stops + log2(peak)) < 0.006,
                      "crop exposure %g stops, the reference's peak in the region %g", stops, peak);
            }
            free(html);
        } else if (m == 1) {
            CHECK(t, fabs(atof(a) / p_pds - 1.0) < 1e-4 && fabs(atof(b) / p_pm - 1.0) < 1e-4,
                  "each: %s %s, expected %g %g", a, b, p_pds, p_pm);
        } else {
            CHECK(t, !strcmp(a, "0.05") && !strcmp(b, "0.05"), "given: %s %s", a, b);
        }
    }
    harness_rmtree(dir);
    remove(ref);
}

static void test_harness_sweep_flags_an_optimum_at_the_edge_and_draws_photons_log_log(pds_test_ctx *t)
{
    char out[16384], err[8192], args[1024], ref[256], dir[256], path[512];
    char *svg;
    const char *last;
    REQUIRE(t, harness_caustics_reference(t, ref, sizeof ref), "no reference");
    harness_path(dir, sizeof dir, "sweep_edge");
    harness_rmtree(dir);
    /* of two values one is the best: it is at an edge */
    snprintf(args, sizeof args,
             "sweep tests/golden/glass.scene --method pm --param k --values 5,10 --photons 2000 --ref %s --res 32x24 "
             "--spp 2 --caustics-only --quiet -o %s",
             ref, dir);
    REQUIRE(t, cli_run_split(args, out, sizeof out, err, sizeof err) == 0, "sweep failed: %s%s", out, err);
    last = cli_last_line(out);
    CHECK(t, strstr(last, " rmse_at_edge=1 ssim_at_edge=1") != NULL, "best line: %s", last);
    CHECK(t, strstr(err, "pds sweep: warning: the RMSE and the SSIM optimum is at the edge of the values swept: "
                         "widen --values") != NULL,
          "stderr: %s", err);
    snprintf(path, sizeof path, "%s/sweep.svg", dir);
    svg = harness_slurp(path, NULL);
    CHECK(t, svg && strstr(svg, "class=\"edge-note\"") && strstr(svg, "widen --values"), "the figure says so");
    free(svg);
    harness_rmtree(dir);
    /* photons: log-log, and the largest count being best is no warning */
    snprintf(args, sizeof args,
             "sweep tests/golden/glass.scene --method pm --param photons --values 500,2000,8000 --ref %s --res 32x24 "
             "--spp 2 --caustics-only --quiet -o %s",
             ref, dir);
    REQUIRE(t, cli_run_split(args, out, sizeof out, err, sizeof err) == 0, "sweep failed: %s%s", out, err);
    last = cli_last_line(out);
    CHECK(t, strstr(last, " rmse_at_edge=0 ssim_at_edge=0") != NULL, "best line: %s", last);
    CHECK(t, strstr(err, "widen") == NULL, "no warning for a count: %s", err);
    snprintf(path, sizeof path, "%s/sweep.svg", dir);
    svg = harness_slurp(path, NULL);
    CHECK(t, svg && strstr(svg, "photons (log scale)") && strstr(svg, "class=\"rmse-axis log-y\"") &&
                 strstr(svg, "RMSE (linear RGB), log scale"),
          "log-log axes");
    free(svg);
    harness_rmtree(dir);
    remove(ref);
}

/* The baseline methods' options reach the final line. */
static void test_harness_render_takes_the_baseline_options(pds_test_ctx *t)
{
    static const char *const cases[][3] = {
        {"pm", "--k 40 --kernel gaussian --max-radius 0.5", " k=40 kernel=gaussian max_radius=0.5 map_bytes="},
        {"pdm", "--max-photons 200 --smoothing 8", " max_photons=200 smoothing=8 map_bytes="},
        {"splat", "--radius 0.05", " radius=0.05 time_eye="},
        {"ppm", "--passes 3 --alpha 0.5 --radius 0.1", " passes=3 radius=0.1 alpha=0.5 map_bytes="},
        {"spm", "--streams 300 --stream-photons 4 --k 20 --max-radius 0.5 --stream-radius 0.2 --global-k 30 --gather 3",
         " stream_photons=4 k=20 max_radius=0.5 stream_radius=0.2 global_photons=1500 global_k=30 gather=3 "
         "gather_mix=1 shadow_photons=0 map_bytes="},
    };
    char out[32768], args[1024], png[256], prefix[128];
    size_t i;
    harness_path(png, sizeof png, "baseline.png");
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        int rc;
        snprintf(args, sizeof args,
                 "render tests/golden/glass.scene --method %s %s --photons 2000 --res 16x12 --spp 1 --quiet -o %s",
                 cases[i][0], cases[i][1], png);
        remove(png);
        rc = cli_run(args, out, sizeof out);
        CHECK(t, rc == 0, "%s: %s", args, out);
        snprintf(prefix, sizeof prefix, "render method=%s paths=all width=16 height=12 spp=1 photons=", cases[i][0]);
        CHECK(t, !strncmp(cli_last_line(out), prefix, strlen(prefix)), "final line: %s", out);
        CHECK(t, strstr(out, cases[i][2]) != NULL, "final line has '%s': %s", cases[i][2], out);
        CHECK(t, cli_file_exists(png), "image written");
    }
    remove(png);
    /* options the method does not use: a note, not an error */
    snprintf(args, sizeof args, "render tests/golden/glass.scene --method pt --k 50 --res 8x6 --spp 1 --quiet -o %s", png);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "%s", out);
    CHECK(t, strstr(out, "pds render: note: --k has no effect with --method pt (it is for pm, gi and spm)\n") != NULL, "%s", out);
    remove(png);
    CHECK(t, cli_run("--help", out, sizeof out) == 0, "--help");
    CHECK(t, strstr(out, "pm and pdm store every photon, spm every stream, so their") && strstr(out, "  sweep SCENE") &&
                 strstr(out, "  race SCENE") && strstr(out, "--max-photons N"),
          "--help describes the harness and the baselines");
}

/* The next documented command of a text: a line of a code block (four
   spaces in) whose text starts with "./pds " or "pds ", joined with the
   lines its trailing backslashes continue, into cmd; returns where to go
   on, NULL at the end. */
static const char *harness_doc_command(const char *text, char *cmd, size_t n)
{
    while (*text) {
        const char *line = text, *end = strchr(text, '\n');
        size_t len = 0;
        text = end ? end + 1 : line + strlen(line);
        if (!HARNESS_STARTS(line, "    ")) continue;
        while (*line == ' ') line++;
        if (!HARNESS_STARTS(line, "./pds ") && !HARNESS_STARTS(line, "pds ")) continue;
        for (;;) {
            size_t k = (size_t)((end ? end : line + strlen(line)) - line);
            int more = k > 0 && line[k - 1] == '\\';
            if (more) k--;
            if (len + k + 2 > n) return NULL;
            memcpy(cmd + len, line, k);
            len += k;
            cmd[len++] = ' ';
            if (!more || !end) break;
            line = text;
            end = strchr(text, '\n');
            text = end ? end + 1 : line + strlen(line);
            while (*line == ' ') line++;
        }
        cmd[len] = '\0';
        return text;
    }
    return NULL;
}

/* Does help text h name option o (not as the start of a longer one)? */
static int harness_help_names(const char *h, const char *o)
{
    size_t k = strlen(o);
    const char *p;
    for (p = strstr(h, o); p; p = strstr(p + 1, o))
        if (!isalnum((unsigned char)p[k]) && p[k] != '-') return 1;
    return 0;
}

/* The commands the texts print stay the tool's (the README's code blocks,
   and docs/tutorial.md and docs/exercises.md, which courses hand out):
   each names a command there is, every option it gives (in a usage line
   too: [--mask MASK.pfm]) is one that command's --help names (race and
   sweep take render's as well), and every shipped scene it names is
   there; and the scene the tutorial has the reader type is
   scenes/teaching.scene, as it says (less that file's comment lines).
   Lines of output ("pds render: unknown option ...") and `pds help` are
   left out. */
/* The lines of text from p on, each without its leading spaces, into out
   (NUL-terminated, at most size bytes). block: the lines of one indented
   code block (it ends at the first line not four spaces in; blank lines
   within it are skipped); else every line but blank ones and '#' comments.
   Returns the length. */
static size_t harness_trimmed_lines(const char *p, int block, char *out, size_t size)
{
    size_t n = 0;
    const char *q;
    for (; *p; p = q ? q + 1 : p + strlen(p)) {
        q = strchr(p, '\n');
        if ((q ? q : p + strlen(p)) == p) continue; /* a blank line */
        if (block && !HARNESS_STARTS(p, "    ")) break;
        while (*p == ' ') p++;
        if (!block && (*p == '#' || *p == '\n' || !*p)) continue;
        while (*p && *p != '\n' && n + 2 < size) out[n++] = *p++;
        out[n++] = '\n';
    }
    out[n] = '\0';
    return n;
}

/* `pds SUB --help` (its output into the cache's next slot the first time;
   NULL when SUB is no command or the cache is full). */
typedef struct harness_helps {
    char name[16][64];
    char text[16][32768];
    int n;
} harness_helps;

static const char *harness_help_of(harness_helps *h, const char *sub)
{
    char args[96];
    int i;
    for (i = 0; i < h->n; i++)
        if (!strcmp(h->name[i], sub)) return h->text[i];
    if (h->n == 16 || strlen(sub) >= sizeof h->name[0]) return NULL;
    snprintf(args, sizeof args, "%s --help", sub);
    if (cli_run(args, h->text[h->n], sizeof h->text[0]) != 0) return NULL;
    snprintf(h->name[h->n], sizeof h->name[0], "%s", sub);
    return h->text[h->n++];
}

static void test_harness_teaching_texts_commands_are_the_tools(pds_test_ctx *t)
{
    static const char *const docs[] = {"README.md", "docs/tutorial.md", "docs/exercises.md"};
    static harness_helps helps;
    const char *help = "", *render_help = harness_help_of(&helps, "render");
    char cmd[2048], sub[64];
    int d, commands = 0;
    REQUIRE(t, render_help != NULL, "pds render --help");
    for (d = 0; d < 3; d++) {
        char *text = harness_slurp(docs[d], NULL);
        const char *at = text;
        REQUIRE(t, text != NULL, "cannot read %s", docs[d]);
        while ((at = harness_doc_command(at, cmd, sizeof cmd)) != NULL) {
            char *tok, *save = cmd;
            int k = 0, both = 0;
            while ((tok = strtok(save, " ")) != NULL) {
                size_t len;
                save = NULL;
                if (k++ == 1) {
                    len = strlen(tok);
                    if ((len > 0 && tok[len - 1] == ':') || !strcmp(tok, "help")) break; /* output, or help's list */
                    commands++;
                    snprintf(sub, sizeof sub, "%s", tok);
                    help = harness_help_of(&helps, sub);
                    CHECK(t, help != NULL, "%s: 'pds %s' is no command", docs[d], sub);
                    if (!help) help = "";
                    both = !strcmp(sub, "race") || !strcmp(sub, "sweep");
                    continue;
                }
                if (k < 3) continue;
                if (tok[0] == '#') break; /* a comment to the end of the line */
                while (*tok == '[' || *tok == '(') tok++;
                len = strlen(tok);
                while (len > 0 && strchr("]),|.", tok[len - 1])) tok[--len] = '\0';
                if (tok[0] == '-' && (isalpha((unsigned char)tok[1]) || (tok[1] == '-' && isalpha((unsigned char)tok[2])))) {
                    char *eq = strchr(tok, '=');
                    if (eq) *eq = '\0';
                    CHECK(t, harness_help_names(help, tok) || (both && harness_help_names(render_help, tok)),
                          "%s: 'pds %s' has no option %s", docs[d], sub, tok);
                } else if (HARNESS_STARTS(tok, "scenes/")) {
                    FILE *f = fopen(tok, "rb");
                    CHECK(t, f != NULL, "%s: %s is not shipped", docs[d], tok);
                    if (f) fclose(f);
                }
            }
        }
        free(text);
    }
    CHECK(t, commands >= 60, "only %d commands found in the texts", commands);
    {
        /* the scene block after "Save this as", against the shipped file */
        char *tut = harness_slurp("docs/tutorial.md", NULL), *shipped = harness_slurp("scenes/teaching.scene", NULL);
        char a[4096], b[4096];
        const char *p;
        REQUIRE(t, tut && shipped, "cannot read the tutorial or scenes/teaching.scene");
        p = strstr(tut, "Save this as");
        REQUIRE(t, p != NULL && (p = strstr(p, "\n\n")) != NULL, "the tutorial no longer says where to save its scene");
        CHECK(t, harness_trimmed_lines(p + 2, 1, a, sizeof a) > 100 && harness_trimmed_lines(shipped, 0, b, sizeof b) > 0 && !strcmp(a, b),
              "the tutorial's scene:\n%s\nscenes/teaching.scene:\n%s", a, b);
        free(tut);
        free(shipped);
    }
}

static const pds_test_case tests_harness[] = {
    {"harness_sweep_over_spp_lowers_rmse_and_reports_the_best",
     test_harness_sweep_over_spp_lowers_rmse_and_reports_the_best},
    {"harness_sweep_checks_the_reference_before_writing_anything",
     test_harness_sweep_checks_the_reference_before_writing_anything},
    {"harness_race_writes_every_image_its_index_shows", test_harness_race_writes_every_image_its_index_shows},
    {"harness_race_difference_is_green_where_too_bright_and_red_where_too_dark",
     test_harness_race_difference_is_green_where_too_bright_and_red_where_too_dark},
    {"harness_race_region_of_interest_is_the_most_varied_window",
     test_harness_race_region_of_interest_is_the_most_varied_window},
    {"harness_bad_usage_exits_2_with_a_message", test_harness_bad_usage_exits_2_with_a_message},
    {"harness_render_takes_the_baseline_options", test_harness_render_takes_the_baseline_options},
    {"harness_race_flags_a_missed_time_budget", test_harness_race_flags_a_missed_time_budget},
    {"harness_race_sweep_and_compare_take_a_mask", test_harness_race_sweep_and_compare_take_a_mask},
    {"harness_race_tune_picks_the_lowest_rmse_of_its_grid_on_another_seed",
     test_harness_race_tune_picks_the_lowest_rmse_of_its_grid_on_another_seed},
    {"harness_race_tune_keeps_the_quickest_when_every_value_overruns",
     test_harness_race_tune_keeps_the_quickest_when_every_value_overruns},
    {"harness_render_warns_of_a_missed_time_budget", test_harness_render_warns_of_a_missed_time_budget},
    {"harness_race_budgets_draw_a_log_log_convergence_plot", test_harness_race_budgets_draw_a_log_log_convergence_plot},
    {"harness_race_page_says_how_it_was_made", test_harness_race_page_says_how_it_was_made},
    {"harness_sweep_flags_an_optimum_at_the_edge_and_draws_photons_log_log",
     test_harness_sweep_flags_an_optimum_at_the_edge_and_draws_photons_log_log},
    {"harness_race_difference_scale_is_shared_each_or_given",
     test_harness_race_difference_scale_is_shared_each_or_given},
    {"harness_teaching_texts_commands_are_the_tools", test_harness_teaching_texts_commands_are_the_tools},
};

/* tests/test_golden.c - golden images: every shipped scene (and three tiny
   test scenes) rendered small (96 x 96 or less, fixed seed, few samples,
   few photons) by each method that applies, compared with the stored PFMs
   under tests/golden/ (NAME.METHOD.pfm).

   How the tolerances were chosen. Rendering is deterministic, so on one
   machine and compiler an image matches its reference bit for bit; the
   tolerances only have to absorb floating-point differences between
   compilers, optimisation levels and libm versions (measured: none between
   gcc and clang at -O2 and the sanitizer builds on Debian 12; a last-bit
   change of one photon's direction moves its splat by far less than a
   pixel), and must catch every real change. A change of the lights' power
   by a factor 1 + e scales every pixel, so the RMSE becomes e times the
   image's root mean square, which is at least e times its mean: with the
   bound RMSE <= 0.5% of the mean, a 2% power change fails by a factor >= 4
   (the linear scaling is exact for every method: pt picks lights by their
   power ratios, which do not change). A 1-degree rotation of the specular
   objects moves their caustics: the bound SSIM >= 0.999 (computed on the
   display luminance) together with the RMSE bound catches it on every
   scene; test_golden_tolerances_catch_power_and_rotation re-renders each
   shipped scene both ways and checks that the comparison fails.

   Because the images are deterministic, tests/golden/MANIFEST also records
   a 64-bit FNV-1a hash of each golden image's pixels: an image within the
   tolerances but with another hash prints a note (a harmless numerical
   change, or a new compiler), a tolerance breach fails.

   On a failure the test writes tests/out/golden/NAME.METHOD.actual.pfm and
   .diff.pfm (|actual - reference|) and names them. PDS_UPDATE_GOLDEN=1
   (make update-golden) writes new references and a new MANIFEST instead;
   review them with git diff before committing. Run from the repository's
   top folder. */

#include <sys/stat.h>

typedef struct golden_case {
    const char *scene;   /* path of the scene file */
    const char *name;    /* golden image: tests/golden/NAME.METHOD.pfm */
    pds_method method;
    int size;            /* image width; the height follows the camera's aspect */
    int spp;             /* 0: the scene's */
    long photons;
    double param;        /* smoothing (pds), k (pm); 0: the default */
} golden_case;

#define GOLDEN_RMSE_OF_MEAN 0.005
#define GOLDEN_MIN_SSIM 0.999

static const golden_case golden_cases[] = {
    /* the tiny test scenes of the path tracer and the preview */
    {"tests/golden/cornell.scene", "box", PDS_METHOD_PT, 0, 0, 0, 0},
    {"tests/golden/glass.scene", "glass", PDS_METHOD_PT, 0, 0, 0, 0},
    {"tests/golden/shapes.scene", "shapes", PDS_METHOD_PREVIEW, 0, 0, 0, 0},
    /* the shipped scenes */
    {"scenes/demo.scene", "demo", PDS_METHOD_PDS, 96, 2, 20000, 0},
    {"scenes/demo.scene", "demo", PDS_METHOD_PM, 96, 2, 20000, 30},
    {"scenes/demo.scene", "demo", PDS_METHOD_PT, 96, 16, 0, 0},
    {"scenes/refraction.scene", "refraction", PDS_METHOD_PDS, 96, 1, 10000, 6},
    {"scenes/refraction.scene", "refraction", PDS_METHOD_PM, 96, 1, 10000, 20},
    {"scenes/reflection.scene", "reflection", PDS_METHOD_PDS, 96, 1, 10000, 6},
    {"scenes/reflection.scene", "reflection", PDS_METHOD_PM, 96, 1, 10000, 20},
    {"scenes/cardioid.scene", "cardioid", PDS_METHOD_PDS, 96, 2, 20000, 0},
    {"scenes/cardioid.scene", "cardioid", PDS_METHOD_PM, 96, 2, 20000, 30},
    {"scenes/cardioid.scene", "cardioid", PDS_METHOD_PT, 96, 16, 0, 0},
    {"scenes/cognac.scene", "cognac", PDS_METHOD_PDS, 96, 2, 20000, 8},
    {"scenes/cognac.scene", "cognac", PDS_METHOD_PM, 96, 2, 20000, 30},
    {"scenes/cognac.scene", "cognac", PDS_METHOD_PT, 96, 16, 0, 0},
    {"scenes/pool.scene", "pool", PDS_METHOD_PDS, 96, 2, 20000, 8},
    {"scenes/pool.scene", "pool", PDS_METHOD_PM, 96, 2, 20000, 30},
    {"scenes/torus.scene", "torus", PDS_METHOD_PDS, 96, 2, 20000, 8},
    {"scenes/torus.scene", "torus", PDS_METHOD_PM, 96, 2, 20000, 30},
    {"scenes/torus.scene", "torus", PDS_METHOD_PT, 96, 16, 0, 0},
    {"scenes/cornell.scene", "cornell", PDS_METHOD_PDS, 96, 2, 20000, 8},
    {"scenes/cornell.scene", "cornell", PDS_METHOD_PM, 96, 2, 20000, 30},
    {"scenes/cornell.scene", "cornell", PDS_METHOD_PT, 96, 16, 0, 0},
    {"scenes/ring_octahedron.scene", "ring_octahedron", PDS_METHOD_PDS, 96, 2, 20000, 8},
    {"scenes/ring_octahedron.scene", "ring_octahedron", PDS_METHOD_PM, 96, 2, 20000, 30},
    /* spectral: dispersion (prism: L S+ D; gem: also L S+ D S+ E) */
    {"scenes/prism.scene", "prism", PDS_METHOD_PDS, 96, 2, 20000, 0},
    {"scenes/prism.scene", "prism", PDS_METHOD_PM, 96, 2, 20000, 30},
    {"scenes/gem.scene", "gem", PDS_METHOD_PDS, 96, 2, 20000, 0},
    {"scenes/gem.scene", "gem", PDS_METHOD_PT, 96, 16, 0, 0},
    /* Jensen's two-pass method: global map, final gather, shadow photons
       and PDS's caustics (small maps and gathers: see golden_render) */
    {"scenes/cornell.scene", "cornell", PDS_METHOD_GI, 96, 2, 20000, 0},
    /* the environment light (sky and sun) and a thin-lens camera */
    {"scenes/sky.scene", "sky", PDS_METHOD_PDS, 96, 2, 20000, 0},
    {"scenes/sky.scene", "sky", PDS_METHOD_PT, 96, 16, 0, 0},
    /* image-space caustics: 65,536 photons is a 256 x 256 light-space buffer */
    {"scenes/ring_octahedron.scene", "ring_octahedron", PDS_METHOD_ISC, 96, 0, 65536, 0},
};

#define GOLDEN_NCASES (sizeof golden_cases / sizeof golden_cases[0])

static int golden_updating(void)
{
    const char *u = getenv("PDS_UPDATE_GOLDEN");
    return u && strcmp(u, "1") == 0;
}

static double golden_mean(const pds_image *img)
{
    double sum = 0.0;
    size_t i, n = (size_t)img->width * img->height * 3;
    for (i = 0; i < n; i++) sum += img->rgb[i];
    return n ? sum / (double)n : 0.0;
}

/* FNV-1a, 64 bits, over the pixels' float bit patterns. */
static uint64_t golden_hash(const pds_image *img)
{
    uint64_t h = 14695981039346656037ULL;
    size_t i, n = (size_t)img->width * img->height * 3;
    for (i = 0; i < n; i++) {
        uint32_t bits;
        int b;
        memcpy(&bits, &img->rgb[i], sizeof bits);
        for (b = 0; b < 4; b++) {
            h ^= (bits >> (8 * b)) & 0xffu;
            h *= 1099511628211ULL;
        }
    }
    return h;
}

/* The scene edits the tolerance test makes. */
typedef void (*golden_edit)(pds_scene *s, double amount);

/* Every light's power (and the emissive materials' radiance) times f. */
static void golden_scale_power(pds_scene *s, double f)
{
    size_t i;
    int c;
    for (i = 0; i < s->nlights; i++) {
        for (c = 0; c < 3; c++) {
            s->lights[i].power[c] *= f;
            s->lights[i].irradiance[c] *= f;
            s->lights[i].radiance[c] *= f;
            s->lights[i].sky[c] *= f; /* the environment's parts */
            s->lights[i].ground[c] *= f;
            s->lights[i].sun_irradiance[c] *= f;
        }
    }
    for (i = 0; i < s->materials.count; i++)
        if (s->materials.items[i].type == PDS_MAT_EMISSIVE)
            for (c = 0; c < 3; c++) s->materials.items[i].radiance[c] *= f;
    pds__lights_free(&s->light_table);
    (void)pds__lights_prepare(&s->light_table, s->lights, s->nlights, &s->mesh, NULL);
}

/* Turn the specular triangles (glass, metal, water) by `deg` degrees about
   the x axis through their centroid, and rebuild the BVH. */
static void golden_rotate_specular(pds_scene *s, double deg)
{
    size_t i, n = 0;
    unsigned char *moved = (unsigned char *)calloc(s->mesh.nverts ? s->mesh.nverts : 1, 1);
    pds__v3 centre = pds__v(0, 0, 0);
    double a = deg * PDS__PI / 180.0, ca = cos(a), sa = sin(a);
    if (!moved) return;
    for (i = 0; i < s->mesh.ntris; i++) {
        int k;
        if (!pds__material_is_specular(&s->materials.items[s->mesh.mat[i]])) continue;
        for (k = 0; k < 3; k++) moved[s->mesh.idx[3 * i + (size_t)k]] = 1;
    }
    for (i = 0; i < s->mesh.nverts; i++) {
        if (!moved[i]) continue;
        centre = pds__add(centre, pds__mesh_pos(&s->mesh, (long)i));
        n++;
    }
    if (n) centre = pds__scale(centre, 1.0 / (double)n);
    for (i = 0; i < s->mesh.nverts; i++) {
        float *p = &s->mesh.pos[3 * i], *nm = &s->mesh.nrm[3 * i];
        double y = p[1] - centre.y, z = p[2] - centre.z, ny = nm[1], nz = nm[2];
        if (!moved[i]) continue;
        p[1] = (float)(centre.y + ca * y - sa * z);
        p[2] = (float)(centre.z + sa * y + ca * z);
        nm[1] = (float)(ca * ny - sa * nz);
        nm[2] = (float)(sa * ny + ca * nz);
    }
    free(moved);
    pds__bvh_free(&s->bvh);
    (void)pds__bvh_build(&s->bvh, s->mesh.pos, s->mesh.idx, s->mesh.ntris, NULL);
}

/* Render case g (with an optional scene edit) into *img. */
static int golden_render(pds_test_ctx *t, const golden_case *g, golden_edit edit, double amount, pds_image *img)
{
    pds_scene *s = NULL;
    pds_error err;
    pds_options opt;
    if (pds_scene_load(g->scene, &s, &err) != PDS_OK) {
        CHECK(t, 0, "%s", err.text);
        return 0;
    }
    if (edit) edit(s, amount);
    pds_options_default(&opt);
    opt.method = g->method;
    opt.seed = 1;
    opt.threads = 2;
    if (g->size > 0) {
        const pds_camera *cam = pds_scene_camera(s);
        opt.width = g->size;
        opt.height = (int)floor((double)g->size * cam->height / cam->width + 0.5);
    }
    if (g->spp > 0) opt.spp = g->spp;
    if (g->photons > 0) opt.photons = g->photons;
    if (g->param > 0.0 && g->method == PDS_METHOD_PDS) opt.smoothing = g->param;
    if (g->param > 0.0 && g->method == PDS_METHOD_PM) opt.k = (int)g->param;
    if (g->method == PDS_METHOD_GI) {
        /* a fifth of the default global map, 4 gather rays: under a second */
        opt.global_photons = 20000;
        opt.gather = 4;
    }
    if (pds_render(s, &opt, img, NULL, &err) != PDS_OK) {
        CHECK(t, 0, "%s", err.text);
        pds_scene_free(s);
        return 0;
    }
    pds_scene_free(s);
    return 1;
}

/* Compare with the tolerances; 1 when within them. */
static int golden_within(const pds_image *img, const pds_image *ref, pds_metrics *m)
{
    pds_error err;
    if (pds_image_compare(img, ref, m, &err) != PDS_OK) return 0;
    return m->rmse <= GOLDEN_RMSE_OF_MEAN * golden_mean(ref) && m->ssim >= GOLDEN_MIN_SSIM;
}

/* The hash the manifest records for NAME.METHOD, or 0 when it has none. */
static uint64_t golden_manifest_hash(const char *key)
{
    FILE *f = fopen("tests/golden/MANIFEST", "r");
    char line[256], name[128];
    unsigned long long h;
    uint64_t found = 0;
    if (!f) return 0;
    while (fgets(line, sizeof line, f)) {
        if (line[0] == '#') continue;
        if (sscanf(line, "%127s %llx", name, &h) == 2 && strcmp(name, key) == 0) found = (uint64_t)h;
    }
    fclose(f);
    return found;
}

/* Write the actual image and |actual - reference| for a failing case; say
   where unless quiet (the self-test, which writes them on purpose). */
static void golden_write_failure(const char *key, pds_image *img, const pds_image *ref, int quiet)
{
    char path[256];
    pds_error err;
    size_t i, n = (size_t)img->width * img->height * 3;
    mkdir("tests/out", 0777);
    mkdir("tests/out/golden", 0777);
    snprintf(path, sizeof path, "tests/out/golden/%s.actual.pfm", key);
    if (pds_image_write_pfm(path, img, &err) == PDS_OK && !quiet) printf("  wrote %s\n", path);
    if (!ref || ref->width != img->width || ref->height != img->height) return;
    for (i = 0; i < n; i++) img->rgb[i] = (float)fabs((double)img->rgb[i] - (double)ref->rgb[i]);
    snprintf(path, sizeof path, "tests/out/golden/%s.diff.pfm", key);
    if (pds_image_write_pfm(path, img, &err) == PDS_OK && !quiet) printf("  wrote %s\n", path);
}

static void test_golden_images_match_their_references(pds_test_ctx *t)
{
    size_t i;
    FILE *manifest = NULL;
    if (golden_updating()) {
        manifest = fopen("tests/golden/MANIFEST", "w");
        REQUIRE(t, manifest != NULL, "cannot write tests/golden/MANIFEST");
        fprintf(manifest, "# NAME.METHOD  FNV-1a-64 of the image's float pixels (written by make update-golden)\n");
    }
    for (i = 0; i < GOLDEN_NCASES; i++) {
        const golden_case *g = &golden_cases[i];
        char key[128], ref_path[256];
        pds_image img = {0, 0, NULL}, ref = {0, 0, NULL};
        pds_metrics m;
        pds_error err;
        uint64_t h, recorded;
        snprintf(key, sizeof key, "%s.%s", g->name, pds_method_name(g->method));
        snprintf(ref_path, sizeof ref_path, "tests/golden/%s.pfm", key);
        if (!golden_render(t, g, NULL, 0.0, &img)) continue;
        h = golden_hash(&img);
        if (manifest) {
            CHECK(t, pds_image_write_pfm(ref_path, &img, &err) == PDS_OK, "%s", err.text);
            fprintf(manifest, "%s %016llx\n", key, (unsigned long long)h);
            printf("updated %s\n", ref_path);
        } else if (pds_image_read_pfm(ref_path, &ref, &err) != PDS_OK) {
            CHECK(t, 0, "%s (run make update-golden to create it)", err.text);
            golden_write_failure(key, &img, NULL, 0);
        } else {
            int within = golden_within(&img, &ref, &m);
            CHECK(t, within, "%s: rmse %g (max %g), ssim %.6f (min %g)", key, m.rmse,
                  GOLDEN_RMSE_OF_MEAN * golden_mean(&ref), m.ssim, GOLDEN_MIN_SSIM);
            if (!within) golden_write_failure(key, &img, &ref, 0);
            else if ((recorded = golden_manifest_hash(key)) != h)
                printf("  note: %s is within the tolerances (rmse %g, ssim %.6f) but its hash %016llx is not the "
                       "manifest's %016llx\n",
                       key, m.rmse, m.ssim, (unsigned long long)h, (unsigned long long)recorded);
        }
        pds_image_free(&img);
        pds_image_free(&ref);
    }
    if (manifest) fclose(manifest);
}

/* The tolerances catch real changes: every golden case of a shipped scene
   with 2% more light, and re-rendered with the specular objects turned by
   1 degree, must fall outside them. Light transport is linear in the
   lights' power and a seed draws the same numbers, so 2% more light is
   the image times 1.02: the first case is re-rendered so (its mean must
   rise by 2%, within 0.5%), the others' references are scaled (a
   re-render of each cost 10 s more of the sanitizers' run).
   (GOLDEN_MARGINS=1 prints the margins.) */
static void test_golden_tolerances_catch_power_and_rotation(pds_test_ctx *t)
{
    size_t i;
    int rendered_power = 0;
    if (golden_updating()) return;
    for (i = 0; i < GOLDEN_NCASES; i++) {
        const golden_case *g = &golden_cases[i];
        char ref_path[256];
        pds_image ref = {0, 0, NULL};
        pds_error err;
        int e;
        if (strncmp(g->scene, "scenes/", 7) != 0) continue;
        snprintf(ref_path, sizeof ref_path, "tests/golden/%s.%s.pfm", g->name, pds_method_name(g->method));
        REQUIRE(t, pds_image_read_pfm(ref_path, &ref, &err) == PDS_OK, "%s", err.text);
        for (e = 0; e < 2; e++) {
            pds_image img = {0, 0, NULL};
            pds_metrics m;
            int within;
            if (e == 0 && rendered_power) {
                size_t k, n = 3 * (size_t)ref.width * (size_t)ref.height;
                REQUIRE(t, pds_image_alloc(&img, ref.width, ref.height) == PDS_OK, "out of memory");
                for (k = 0; k < n; k++) img.rgb[k] = (float)(1.02 * ref.rgb[k]);
            } else if (!golden_render(t, g, e ? golden_rotate_specular : golden_scale_power, e ? 1.0 : 1.02, &img)) {
                continue;
            } else if (e == 0) {
                double rise = golden_mean(&img) / golden_mean(&ref);
                CHECK(t, fabs(rise - 1.02) < 0.005, "%s %s: 2%% more power raised the mean by %.4f", g->name,
                      pds_method_name(g->method), rise);
                rendered_power = 1;
            }
            within = golden_within(&img, &ref, &m);
            if (getenv("GOLDEN_MARGINS")) printf("%s %s e%d rmse%% %.3f ssim %.6f\n", g->name, pds_method_name(g->method), e, 100.0 * m.rmse / golden_mean(&ref), m.ssim);
            CHECK(t, !within, "%s %s: %s passes the tolerances (rmse %g = %.2f%% of the mean, ssim %.6f)", g->name,
                  pds_method_name(g->method), e ? "a 1-degree rotation" : "2% more light", m.rmse,
                  100.0 * m.rmse / golden_mean(&ref), m.ssim);
            pds_image_free(&img);
        }
        pds_image_free(&ref);
    }
}

/* A failure leaves the evidence where the message says: the actual image
   and |actual - reference| under tests/out/golden/ (git-ignored). */
static void test_golden_failure_writes_actual_and_difference(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL}, ref = {0, 0, NULL}, back = {0, 0, NULL};
    pds_error err;
    REQUIRE(t, pds_image_alloc(&img, 2, 1) == PDS_OK && pds_image_alloc(&ref, 2, 1) == PDS_OK, "alloc");
    img.rgb[0] = 3.0f;
    ref.rgb[0] = 1.0f;
    remove("tests/out/golden/selftest.case.actual.pfm");
    remove("tests/out/golden/selftest.case.diff.pfm");
    golden_write_failure("selftest.case", &img, &ref, 1);
    CHECK(t, pds_image_read_pfm("tests/out/golden/selftest.case.actual.pfm", &back, &err) == PDS_OK, "%s", err.text);
    pds_image_free(&back);
    REQUIRE(t, pds_image_read_pfm("tests/out/golden/selftest.case.diff.pfm", &back, &err) == PDS_OK, "%s", err.text);
    CHECK_NEAR(t, back.rgb[0], 2.0, 0.0);
    pds_image_free(&back);
    pds_image_free(&img);
    pds_image_free(&ref);
    remove("tests/out/golden/selftest.case.actual.pfm");
    remove("tests/out/golden/selftest.case.diff.pfm");
}

static const pds_test_case tests_golden[] = {
    {"golden_images_match_their_references", test_golden_images_match_their_references},
    {"golden_tolerances_catch_power_and_rotation", test_golden_tolerances_catch_power_and_rotation},
    {"golden_failure_writes_actual_and_difference", test_golden_failure_writes_actual_and_difference},
};

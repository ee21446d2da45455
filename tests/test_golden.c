/* tests/test_golden.c - golden images: small fixed-seed renders of the
   scenes in tests/golden/ compared with the stored PFMs by RMSE and SSIM.

   Rendering is deterministic, so on one machine and compiler the images
   match bit for bit; the tolerances only absorb floating-point differences
   between compilers and libm versions, far below any real change. The
   bounds: RMSE at most 0.5% of the reference's mean value, SSIM at least
   0.995.

   On a failure the test writes tests/out/NAME.actual.pfm and
   tests/out/NAME.diff.pfm (|actual - reference|) and names them.
   PDS_UPDATE_GOLDEN=1 (make update-golden) writes new references instead;
   review them with git diff before committing. Run from the repository's
   top folder. */

#include <sys/stat.h>

typedef struct golden_case {
    const char *name;    /* tests/golden/NAME.scene -> tests/golden/NAME.pfm */
    pds_method method;
} golden_case;

static const golden_case golden_cases[] = {
    {"cornell", PDS_METHOD_PT},
    {"glass", PDS_METHOD_PT},
    {"shapes", PDS_METHOD_PREVIEW},
};

static double golden_mean(const pds_image *img)
{
    double sum = 0.0;
    size_t i, n = (size_t)img->width * img->height * 3;
    for (i = 0; i < n; i++) sum += img->rgb[i];
    return n ? sum / (double)n : 0.0;
}

static void golden_check(pds_test_ctx *t, const golden_case *g)
{
    char scene_path[256], ref_path[256], out_path[256];
    pds_scene *s = NULL;
    pds_error err;
    pds_options opt;
    pds_image img = {0, 0, NULL}, ref = {0, 0, NULL};
    pds_metrics m;
    snprintf(scene_path, sizeof scene_path, "tests/golden/%s.scene", g->name);
    snprintf(ref_path, sizeof ref_path, "tests/golden/%s.pfm", g->name);
    REQUIRE(t, pds_scene_load(scene_path, &s, &err) == PDS_OK, "%s", err.text);
    pds_options_default(&opt);
    opt.method = g->method;
    opt.seed = 1;
    opt.threads = 2;
    REQUIRE(t, pds_render(s, &opt, &img, NULL, &err) == PDS_OK, "%s", err.text);
    pds_scene_free(s);
    if (getenv("PDS_UPDATE_GOLDEN") && strcmp(getenv("PDS_UPDATE_GOLDEN"), "1") == 0) {
        CHECK(t, pds_image_write_pfm(ref_path, &img, &err) == PDS_OK, "%s", err.text);
        printf("updated %s\n", ref_path);
        pds_image_free(&img);
        return;
    }
    if (pds_image_read_pfm(ref_path, &ref, &err) != PDS_OK) {
        CHECK(t, 0, "%s (run make update-golden to create it)", err.text);
        pds_image_free(&img);
        return;
    }
    if (pds_image_compare(&img, &ref, &m, &err) != PDS_OK) {
        CHECK(t, 0, "%s", err.text);
    } else {
        double tol = 0.005 * golden_mean(&ref);
        int ok = m.rmse <= tol && m.ssim >= 0.995;
        CHECK(t, ok, "%s: rmse %g (max %g), ssim %g (min 0.995)", g->name, m.rmse, tol, m.ssim);
        if (!ok) {
            size_t i, n = (size_t)img.width * img.height * 3;
            mkdir("tests/out", 0777);
            snprintf(out_path, sizeof out_path, "tests/out/%s.actual.pfm", g->name);
            if (pds_image_write_pfm(out_path, &img, &err) == PDS_OK) printf("  wrote %s\n", out_path);
            for (i = 0; i < n; i++) img.rgb[i] = (float)fabs((double)img.rgb[i] - (double)ref.rgb[i]);
            snprintf(out_path, sizeof out_path, "tests/out/%s.diff.pfm", g->name);
            if (pds_image_write_pfm(out_path, &img, &err) == PDS_OK) printf("  wrote %s\n", out_path);
        }
    }
    pds_image_free(&img);
    pds_image_free(&ref);
}

static void test_golden_images_match_their_references(pds_test_ctx *t)
{
    size_t i;
    for (i = 0; i < sizeof golden_cases / sizeof golden_cases[0]; i++) golden_check(t, &golden_cases[i]);
}

/* The tolerance is not so loose that a real change slips through: 5% more
   light in the glass scene must fail it. */
static void test_golden_tolerance_catches_a_five_percent_change(pds_test_ctx *t)
{
    pds_image ref = {0, 0, NULL}, changed = {0, 0, NULL};
    pds_error err;
    pds_metrics m;
    size_t i, n;
    REQUIRE(t, pds_image_read_pfm("tests/golden/glass.pfm", &ref, &err) == PDS_OK, "%s", err.text);
    REQUIRE(t, pds_image_alloc(&changed, ref.width, ref.height) == PDS_OK, "alloc");
    n = (size_t)ref.width * ref.height * 3;
    for (i = 0; i < n; i++) changed.rgb[i] = ref.rgb[i] * 1.05f;
    REQUIRE(t, pds_image_compare(&changed, &ref, &m, &err) == PDS_OK, "%s", err.text);
    CHECK(t, m.rmse > 0.005 * golden_mean(&ref), "rmse %g does not exceed the tolerance", m.rmse);
    pds_image_free(&ref);
    pds_image_free(&changed);
}

static const pds_test_case tests_golden[] = {
    {"golden_images_match_their_references", test_golden_images_match_their_references},
    {"golden_tolerance_catches_a_five_percent_change", test_golden_tolerance_catches_a_five_percent_change},
};

/* tests/test_gi.c - Jensen's two-pass global illumination (>>gi): the
   global map's radiance against the analytic irradiance of a point light
   over a plane, shadow photons against shadow rays everywhere, the final
   gather's importance sampling against cosine sampling (same mean, less
   variance), agreement with the path tracer, the caustic split and
   determinism. */

/* Options for a gi render in these tests. */
static void gi_options(pds_options *o, int threads)
{
    pds_options_default(o);
    o->method = PDS_METHOD_GI;
    o->threads = threads;
    o->global_photons = 40000;
    o->photons = 20000;
    o->gather = 8;
}

/* A diffuse plane (albedo 0.5) 1 above which hangs a point light of 100 W. */
static const char gi_plane_scene[] =
    "camera { position 0 3 0.000001 look_at 0 0 0 up 0 0 -1 fov 40 resolution 16 16 spp 1 }\n"
    "material floor diffuse { albedo 0.5 }\n"
    "quad { material floor size 20 20 }\n"
    "light point { position 0 1 0 power 100 }\n";

/* The global map's estimate L = sum f dPhi w / ((1 - 2/3) pi r^2) against
   L = (albedo / pi) E, E = P / (4 pi) h / d^3, at 121 points of the plane
   under the light. Photons that leave the plane escape, so the map holds
   exactly the first-hit photons. The map is built twice, on 1 and on 3
   threads, and must be the same. */
static void test_gi_global_map_radiance_matches_point_light_irradiance(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text(gi_plane_scene, &err);
    pds__gi_map g, g3;
    pds_options o;
    int i, j, bad = 0, n = 0;
    double sum_est = 0.0, sum_exact = 0.0, worst = 0.0;
    pds__v3 up = pds__v(0.0, 1.0, 0.0);
    REQUIRE(t, s, "scene: %s", err.text);
    gi_options(&o, 1);
    o.global_photons = 250000;
    o.global_k = 150;
    REQUIRE(t, pds__gi_map_build(&g, s, &o, 1, &err) == PDS_OK, "map: %s", err.text);
    REQUIRE(t, pds__gi_map_build(&g3, s, &o, 3, &err) == PDS_OK, "map on 3 threads: %s", err.text);
    CHECK(t, g.n == g3.n && g.n > 95000 && g.n < 130000, "stored %lu / %lu (about half the photons go down)",
          (unsigned long)g.n, (unsigned long)g3.n);
    CHECK(t, g.n == g3.n && memcmp(g.photons, g3.photons, g.n * sizeof *g.photons) == 0,
          "the map depends on the thread count");
    for (i = -5; i <= 5; i++) {
        for (j = -5; j <= 5; j++) {
            pds__v3 x = pds__v(0.12 * i, 0.0, 0.12 * j);
            double d2 = x.x * x.x + x.z * x.z + 1.0, E = 100.0 / (4.0 * PDS__PI) / (d2 * sqrt(d2));
            double exact = 0.5 / PDS__PI * E, L[3], rel;
            pds__gi_radiance(&g, &s->materials.items[0], x, pds__normalize(pds__v(0.2, 1.0, 0.1)), up, up, L);
            rel = fabs(L[1] / exact - 1.0);
            if (rel > worst) worst = rel;
            bad += rel > 0.08;
            sum_est += L[1];
            sum_exact += exact;
            n++;
        }
    }
    CHECK(t, bad == 0, "%d of %d estimates off by more than 8%%, worst %.4f", bad, n, worst);
    CHECK(t, fabs(sum_est / sum_exact - 1.0) < 0.015, "mean estimate / exact = %.4f", sum_est / sum_exact);
    pds__gi_map_free(&g);
    pds__gi_map_free(&g3);
    pds_scene_free(s);
}

/* A floor, a square blocker half-way up and a light above: with shadow
   photons deciding some light samples, no pixel may be darker than with a
   shadow ray for every sample (the same random numbers drive both), and
   for a point light (a hard shadow) no pixel brighter either. The
   decisions must actually be taken for most samples. */
static void gi_shadow_compare(pds_test_ctx *t, const char *light, int allow_brighter)
{
    char text[1024];
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    pds_render_stats sa, sb;
    pds_options o;
    size_t i, npx;
    int darker = 0, brighter = 0, lit = 0;
    snprintf(text, sizeof text,
             "camera { position 0 3 0.000001 look_at 0 0 0 up 0 0 -1 fov 60 resolution 32 32 spp 2 }\n"
             "material floor diffuse { albedo 0.5 }\n"
             "material block diffuse { albedo 0.3 }\n"
             "quad { material floor size 6 6 }\n"
             "box { material block size 0.8 0.1 0.8 translate 0.2 0.6 0 }\n"
             "%s\n", light);
    gi_options(&o, 2);
    o.gather = 0;
    o.paths = PDS_PATHS_NO_CAUSTICS;
    o.global_photons = 100000;
    REQUIRE(t, render_text(text, &o, &a, &sa), "render with shadow photons");
    o.shadow_photons = 0;
    REQUIRE(t, render_text(text, &o, &b, &sb), "render with shadow rays");
    npx = (size_t)a.width * a.height;
    for (i = 0; i < npx * 3; i++) {
        darker += a.rgb[i] < b.rgb[i] * (1.0f - 1e-6f);
        brighter += a.rgb[i] > b.rgb[i] * (1.0f + 1e-6f) + 1e-12f;
        lit += b.rgb[i] > 0.0f;
    }
    CHECK(t, lit > (int)npx, "the reference is dark (%d lit values)", lit);
    CHECK(t, darker == 0, "%s: %d values darker with shadow photons", light, darker);
    CHECK(t, allow_brighter || brighter == 0, "%s: %d values brighter with shadow photons", light, brighter);
    CHECK(t, sb.shadow_rays_saved == 0 && sa.shadow_rays_saved > 4 * sa.shadow_rays,
          "%s: saved %ld, traced %ld (without: saved %ld)", light, sa.shadow_rays_saved, sa.shadow_rays,
          sb.shadow_rays_saved);
    pds_image_free(&a);
    pds_image_free(&b);
}

static void test_gi_shadow_photons_never_darken_a_lit_point(pds_test_ctx *t)
{
    gi_shadow_compare(t, "light point { position 0 2 0 power 50 }", 0);
    gi_shadow_compare(t, "light quad { center 0 2 0 edge1 0.6 0 0 edge2 0 0 0.6 radiance 40 }", 1);
}

/* The final gather on a floor point lit indirectly by a wall that a point
   light shines on: directions from the global map's photons (mix 0.25)
   and plain cosine sampling (mix 1) must have the same mean (the guided
   pdf is exact), and the guided one a smaller variance (the light comes
   from the wall's part of the hemisphere). 4000 one-ray estimates each,
   independent seeds. */
static void test_gi_gather_importance_sampling_is_unbiased(pds_test_ctx *t)
{
    static const char text[] =
        "camera { position 0 3 3 look_at 0 0 0 fov 40 resolution 8 8 spp 1 }\n"
        "material floor diffuse { albedo 0.5 }\n"
        "material wall diffuse { albedo 0.8 }\n"
        "quad { material floor size 8 8 }\n"
        "quad { material wall size 2 2 rotate 90 0 0 1 translate 1 1 0 }\n"
        "light spot { position 0.2 1 0 direction 1 0 0 power 40 cone 60 70 }\n";
    pds_error err;
    pds_scene *s = scene_from_text(text, &err);
    pds__gi_map g;
    pds_options o;
    pds__tracer tr;
    double mean[2], var[2];
    int pass, i, n = 4000;
    long counts[4] = {0, 0, 0, 0};
    pds__v3 up = pds__v(0.0, 1.0, 0.0), x = pds__v(-0.2, 0.0, 0.1), wo = pds__normalize(pds__v(-0.3, 1.0, 0.2));
    REQUIRE(t, s, "scene: %s", err.text);
    gi_options(&o, 2);
    o.global_photons = 100000;
    REQUIRE(t, pds__gi_map_build(&g, s, &o, 2, &err) == PDS_OK, "map: %s", err.text);
    memset(&tr, 0, sizeof tr);
    tr.scene = s;
    tr.max_depth = 8;
    tr.rr_depth = 3;
    tr.eps = 1e-6 * pds__scene_scale(s);
    for (pass = 0; pass < 2; pass++) {
        double sum = 0.0, sum2 = 0.0;
        tr.seed = 11 + (uint64_t)pass;
        for (i = 0; i < n; i++) {
            double acc[3] = {0.0, 0.0, 0.0}, beta[3] = {1.0, 1.0, 1.0}, v;
            pds__gi_gather(&g, &tr, &s->materials.items[0], x, wo, up, up, beta, (uint64_t)i, 1, pass ? 1.0 : 0.25, acc,
                           counts);
            v = acc[0] + acc[1] + acc[2];
            sum += v;
            sum2 += v * v;
        }
        mean[pass] = sum / n;
        var[pass] = sum2 / n - mean[pass] * mean[pass];
    }
    CHECK(t, mean[1] > 0.0, "no indirect light reached the floor");
    CHECK(t, fabs(mean[0] - mean[1]) < 4.0 * sqrt((var[0] + var[1]) / n),
          "guided mean %.5f, cosine mean %.5f (standard errors %.5f, %.5f)", mean[0], mean[1], sqrt(var[0] / n),
          sqrt(var[1] / n));
    CHECK(t, var[0] < 0.5 * var[1], "guided variance %.3g is not well below cosine's %.3g", var[0], var[1]);
    CHECK(t, counts[2] == 2 * n, "gather rays counted %ld", counts[2]);
    pds__gi_map_free(&g);
    pds_scene_free(s);
}

/* A small closed box (white floor, ceiling and back wall, red and blue
   sides, an open front) with a glass ball and a glossy ball under a quad
   light: every kind of path. The camera does not see the light (a few
   samples more or less on a 20 W/m^2/sr emitter would be all the noise). */
static const char gi_box_scene[] =
    "camera { position 0 1 3.2 look_at 0 0.7 0 fov 36 resolution 24 24 spp 4 }\n"
    "material white diffuse { albedo 0.7 }\n"
    "material red diffuse { albedo 0.7 0.1 0.1 }\n"
    "material blue diffuse { albedo 0.1 0.1 0.7 }\n"
    "material glass dielectric { ior 1.5 }\n"
    "material shiny glossy { roughness 0.3 reflectance 0.9 0.8 0.6 }\n"
    "quad { material white size 2 2 }\n"
    "quad { material white size 2 2 rotate 180 1 0 0 translate 0 2 0 }\n"
    "quad { material white size 2 2 rotate 90 1 0 0 translate 0 1 -1 }\n"
    "quad { material red size 2 2 rotate -90 0 0 1 translate -1 1 0 }\n"
    "quad { material blue size 2 2 rotate 90 0 0 1 translate 1 1 0 }\n"
    "sphere { material glass radius 0.3 translate -0.4 0.3 0.2 }\n"
    "sphere { material shiny radius 0.3 translate 0.45 0.3 -0.3 }\n"
    "light quad { center 0 1.99 0 edge1 0.5 0 0 edge2 0 0 0.5 radiance 20 }\n";

/* gi's full image against a path-traced one of 1024 samples per pixel:
   the image means and the means of four quarters per channel within 3%
   (the path tracer's own noise there is under 1%; the global map's
   density estimate blurs, which these means do not see). */
static void test_gi_agrees_with_path_tracing_in_a_small_box(pds_test_ctx *t)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    pds_options o;
    int c, qx, qy, x, y;
    gi_options(&o, 2);
    o.global_photons = 60000;
    o.gather = 16;
    REQUIRE(t, render_text(gi_box_scene, &o, &a, NULL), "gi");
    pds_options_default(&o);
    o.method = PDS_METHOD_PT;
    o.spp = 1024;
    o.threads = 2;
    REQUIRE(t, render_text(gi_box_scene, &o, &b, NULL), "pt");
    for (c = 0; c < 3; c++) {
        double ma = image_mean(&a, c), mb = image_mean(&b, c);
        CHECK(t, fabs(ma / mb - 1.0) < 0.03, "channel %d: gi %.5f, pt %.5f", c, ma, mb);
        for (qy = 0; qy < 2; qy++) {
            for (qx = 0; qx < 2; qx++) {
                double sa = 0.0, sb = 0.0;
                for (y = 12 * qy; y < 12 * qy + 12; y++) {
                    for (x = 12 * qx; x < 12 * qx + 12; x++) {
                        sa += a.rgb[3 * (y * 24 + x) + c];
                        sb += b.rgb[3 * (y * 24 + x) + c];
                    }
                }
                CHECK(t, fabs(sa / sb - 1.0) < 0.05, "channel %d quarter %d,%d: gi %.4f, pt %.4f", c, qx, qy, sa / 144,
                      sb / 144);
            }
        }
    }
    pds_image_free(&a);
    pds_image_free(&b);
}

/* The same image bit for bit on 1 and 3 threads, and the same counts. */
static void test_gi_image_is_identical_for_any_thread_count(pds_test_ctx *t)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    pds_render_stats sa, sb;
    pds_options o;
    gi_options(&o, 1);
    REQUIRE(t, render_text(gi_box_scene, &o, &a, &sa), "1 thread");
    o.threads = 3;
    REQUIRE(t, render_text(gi_box_scene, &o, &b, &sb), "3 threads");
    CHECK(t, memcmp(a.rgb, b.rgb, sizeof(float) * 3 * (size_t)a.width * a.height) == 0, "bitwise equal");
    CHECK(t, sa.global_stored == sb.global_stored && sa.global_stored > 0 && sa.shadow_rays == sb.shadow_rays &&
             sa.shadow_rays_saved == sb.shadow_rays_saved && sa.gather_rays == sb.gather_rays && sa.gather_rays > 0,
          "counts differ: stored %ld/%ld, shadow rays %ld/%ld", sa.global_stored, sb.global_stored, sa.shadow_rays,
          sb.shadow_rays);
    CHECK(t, sa.map_bytes >= (size_t)sa.global_stored * sizeof(pds__gi_photon), "map_bytes %lu",
          (unsigned long)sa.map_bytes);
    pds_image_free(&a);
    pds_image_free(&b);
}

/* ALL = NO_CAUSTICS + CAUSTICS_ONLY: the eye pass and the caustic method
   never count the same light twice (pm as the caustic method here). */
static void test_gi_full_image_is_eye_pass_plus_caustics(pds_test_ctx *t)
{
    pds_image all = {0, 0, NULL}, nc = {0, 0, NULL}, co = {0, 0, NULL};
    pds_options o;
    size_t i, n;
    double worst = 0.0, caustic = 0.0;
    gi_options(&o, 2);
    o.caustics = PDS_METHOD_PM;
    REQUIRE(t, render_text(gi_box_scene, &o, &all, NULL), "all");
    o.paths = PDS_PATHS_NO_CAUSTICS;
    REQUIRE(t, render_text(gi_box_scene, &o, &nc, NULL), "no caustics");
    o.paths = PDS_PATHS_CAUSTICS_ONLY;
    REQUIRE(t, render_text(gi_box_scene, &o, &co, NULL), "caustics only");
    n = (size_t)all.width * all.height * 3;
    for (i = 0; i < n; i++) {
        double rel = fabs((double)all.rgb[i] - nc.rgb[i] - co.rgb[i]) / (1e-6 + all.rgb[i]);
        if (rel > worst) worst = rel;
        caustic += co.rgb[i];
    }
    CHECK(t, worst < 1e-5, "worst relative difference %g", worst);
    CHECK(t, caustic > 0.0, "no caustic light");
    pds_image_free(&all);
    pds_image_free(&nc);
    pds_image_free(&co);
}

static void test_gi_rejects_bad_options(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text(gi_plane_scene, &err);
    pds_image img = {0, 0, NULL};
    pds_options o;
    REQUIRE(t, s, "scene: %s", err.text);
    gi_options(&o, 1);
    o.caustics = PDS_METHOD_PT;
    CHECK(t, pds_render(s, &o, &img, NULL, &err) == PDS_ERR_INVALID_ARG && strstr(err.message, "caustic method"),
          "caustics pt: %s", err.message);
    gi_options(&o, 1);
    o.global_k = 0;
    CHECK(t, pds_render(s, &o, &img, NULL, &err) == PDS_ERR_INVALID_ARG, "global k 0");
    gi_options(&o, 1);
    o.gather_mix = 0.0;
    CHECK(t, pds_render(s, &o, &img, NULL, &err) == PDS_ERR_INVALID_ARG, "gather mix 0");
    gi_options(&o, 1);
    o.gather = -1;
    CHECK(t, pds_render(s, &o, &img, NULL, &err) == PDS_ERR_INVALID_ARG, "gather -1");
    CHECK(t, img.rgb == NULL, "no image for bad options");
    pds_scene_free(s);
}

static const pds_test_case tests_gi[] = {
    {"gi_global_map_radiance_matches_point_light_irradiance", test_gi_global_map_radiance_matches_point_light_irradiance},
    {"gi_shadow_photons_never_darken_a_lit_point", test_gi_shadow_photons_never_darken_a_lit_point},
    {"gi_gather_importance_sampling_is_unbiased", test_gi_gather_importance_sampling_is_unbiased},
    {"gi_agrees_with_path_tracing_in_a_small_box", test_gi_agrees_with_path_tracing_in_a_small_box},
    {"gi_image_is_identical_for_any_thread_count", test_gi_image_is_identical_for_any_thread_count},
    {"gi_full_image_is_eye_pass_plus_caustics", test_gi_full_image_is_eye_pass_plus_caustics},
    {"gi_rejects_bad_options", test_gi_rejects_bad_options},
};

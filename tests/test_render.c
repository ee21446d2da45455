/* tests/test_render.c - the path tracer against known answers, the caustic
   split, determinism across thread counts, and golden images. */

/* Render scene text with the given options; returns 1 on success. */
static int render_text(const char *text, const pds_options *opt, pds_image *img, pds_render_stats *stats)
{
    pds_error err;
    pds_scene *s = scene_from_text(text, &err);
    int ok;
    if (!s) {
        printf("  scene: %s\n", err.text);
        return 0;
    }
    ok = pds_render(s, opt, img, stats, &err) == PDS_OK;
    if (!ok) printf("  render: %s\n", err.text);
    pds_scene_free(s);
    return ok;
}

static double image_mean(const pds_image *img, int channel)
{
    double sum = 0.0;
    size_t i, n = (size_t)img->width * img->height;
    for (i = 0; i < n; i++) sum += img->rgb[3 * i + channel];
    return sum / (double)n;
}

/* A glass sphere on a diffuse floor under a small quad light: every kind
   of path (direct, caustic through the sphere, indirect). */
static const char glass_sphere_scene[] =
    "camera { position 0 2 4 look_at 0 0.4 0 fov 40 resolution 24 18 spp 8 }\n"
    "material floor diffuse { albedo 0.8 }\n"
    "material glass dielectric { ior 1.5 }\n"
    "material lamp emissive { radiance 30 }\n"
    "quad { material floor size 6 6 }\n"
    "sphere { material glass radius 0.5 segments 48 rings 24 translate 0 0.6 0 }\n"
    "quad { material lamp size 0.5 0.5 rotate 180 1 0 0 translate 0.3 2.5 0 }\n";

static void test_pt_full_image_is_no_caustics_plus_caustics_only(pds_test_ctx *t)
{
    pds_options opt;
    pds_image all = {0, 0, NULL}, nc = {0, 0, NULL}, co = {0, 0, NULL};
    size_t i, n;
    double worst = 0.0, caustic_energy = 0.0;
    pds_options_default(&opt);
    opt.threads = 2;
    /* one eye pass: with eye rounds (by default one every 1.5 w h spp
       photons, here 7, one a pass) a full image's direct light is the mean of
       several eye passes', which a render without caustics does not
       trace */
    opt.eye_rounds = 1;
    REQUIRE(t, render_text(glass_sphere_scene, &opt, &all, NULL), "render all");
    opt.paths = PDS_PATHS_NO_CAUSTICS;
    REQUIRE(t, render_text(glass_sphere_scene, &opt, &nc, NULL), "render no-caustics");
    opt.paths = PDS_PATHS_CAUSTICS_ONLY;
    REQUIRE(t, render_text(glass_sphere_scene, &opt, &co, NULL), "render caustics-only");
    n = (size_t)all.width * all.height * 3;
    for (i = 0; i < n; i++) {
        double d = fabs((double)all.rgb[i] - ((double)nc.rgb[i] + (double)co.rgb[i]));
        double rel = d / (1e-6 + fabs(all.rgb[i]));
        if (rel > worst) worst = rel;
        caustic_energy += co.rgb[i];
    }
    /* the same random numbers drive all three: equal up to rounding */
    CHECK(t, worst < 1e-5, "worst relative difference %g", worst);
    CHECK(t, caustic_energy > 0.0, "the scene has a caustic under the sphere");
    CHECK(t, image_mean(&nc, 0) > image_mean(&co, 0), "direct light dominates");
    pds_image_free(&all);
    pds_image_free(&nc);
    pds_image_free(&co);
}

static void test_pt_image_is_identical_for_any_thread_count(pds_test_ctx *t)
{
    pds_options opt;
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    pds_options_default(&opt);
    opt.threads = 1;
    REQUIRE(t, render_text(glass_sphere_scene, &opt, &a, NULL), "1 thread");
    opt.threads = 3;
    REQUIRE(t, render_text(glass_sphere_scene, &opt, &b, NULL), "3 threads");
    CHECK(t, memcmp(a.rgb, b.rgb, sizeof(float) * 3 * (size_t)a.width * a.height) == 0, "bitwise equal");
    pds_image_free(&b);
    opt.seed = 7;
    REQUIRE(t, render_text(glass_sphere_scene, &opt, &b, NULL), "seed 7");
    CHECK(t, memcmp(a.rgb, b.rgb, sizeof(float) * 3 * (size_t)a.width * a.height) != 0, "another seed, another image");
    pds_image_free(&a);
    pds_image_free(&b);
}

/* Furnace: inside a closed diffuse sphere of albedo a with a point light
   of power P at its centre, the direct irradiance is E0 = P / (4 pi R^2)
   everywhere, and the radiance after all bounces is the geometric series
   L = a E0 / (pi (1 - a)) (the inside of a sphere of uniform radiance L
   receives E = pi L). */
static void test_pt_furnace_converges_to_the_analytic_radiance(pds_test_ctx *t)
{
    static const char text[] =
        "camera { position 0 0 0 look_at 0 0 -1 fov 60 resolution 8 8 spp 256 }\n"
        "material wall diffuse { albedo 0.5 }\n"
        "sphere { material wall radius 2 segments 512 rings 256 }\n"
        "light point { position 0 0 0 power 100 }\n";
    pds_options opt;
    pds_image img = {0, 0, NULL};
    double a = 0.5, R = 2.0, E0 = 100.0 / (4.0 * PDS__PI * R * R), expect = a * E0 / (PDS__PI * (1.0 - a));
    pds_options_default(&opt);
    opt.max_depth = 200;
    REQUIRE(t, render_text(text, &opt, &img, NULL), "render");
    CHECK(t, fabs(image_mean(&img, 1) / expect - 1.0) < 0.02, "mean radiance %g, expected %g", image_mean(&img, 1), expect);
    pds_image_free(&img);
}

/* A diffuse plane under a point light: radiance albedo/pi * P cos / (4 pi r^2)
   at the point each pixel sees (the centre ray; pixels are small enough
   that the variation inside one is far below the tolerance). */
static void test_pt_point_light_on_a_plane_matches_inverse_square_law(pds_test_ctx *t)
{
    static const char text[] =
        "camera { position 0 3 0.001 look_at 0 0 0 up 0 0 -1 fov 30 resolution 16 16 spp 256 }\n"
        "material white diffuse { albedo 0.6 }\n"
        "quad { material white size 20 20 }\n"
        "light point { position 0.4 1 0.2 power 50 }\n";
    pds_options opt;
    pds_image img = {0, 0, NULL};
    pds_error err;
    pds_scene *s = scene_from_text(text, &err);
    pds__camera_frame f;
    int x, y, bad = 0;
    double worst = 0.0;
    REQUIRE(t, s != NULL, "%s", err.text);
    pds_options_default(&opt);
    REQUIRE(t, pds_render(s, &opt, &img, NULL, &err) == PDS_OK, "%s", err.text);
    f = pds__camera_setup(&s->camera, 16, 16);
    for (y = 2; y < 14; y++) {
        for (x = 2; x < 14; x++) {
            pds__v3 d = pds__camera_dir(&f, x + 0.5, y + 0.5);
            pds__v3 p = pds__add(f.origin, pds__scale(d, -f.origin.y / d.y));
            pds__v3 l = pds__sub(pds__v(0.4, 1, 0.2), p);
            double r2 = pds__dot(l, l), cosine = l.y / sqrt(r2);
            double expect = 0.6 / PDS__PI * 50.0 * cosine / (4.0 * PDS__PI * r2);
            double rel = fabs(img.rgb[3 * (y * 16 + x)] / expect - 1.0);
            if (rel > worst) worst = rel;
            bad += rel > 0.01;
        }
    }
    CHECK(t, bad == 0, "%d pixels off by more than 1%%, worst %g", bad, worst);
    pds_image_free(&img);
    pds_scene_free(s);
}

/* A disk light of radiance L and radius R at height h above a diffuse
   plane gives irradiance E = pi L R^2 / (h^2 + R^2) right below its
   centre (and the same disk as a mesh light, found by BSDF sampling as well
   as light sampling, must agree: MIS weights sum to one). */
static void test_pt_area_lights_give_the_analytic_irradiance(pds_test_ctx *t)
{
    static const char *const texts[] = {
        "camera { position 2 0.6 0 look_at 0 0 0 fov 0.5 resolution 3 3 spp 4096 }\n"
        "material white diffuse { albedo 0.5 }\n"
        "quad { material white size 20 20 }\n"
        "light disk { center 0 1 0 normal 0 -1 0 radius 0.5 radiance 2 }\n",
        "camera { position 2 0.6 0 look_at 0 0 0 fov 0.5 resolution 3 3 spp 4096 }\n"
        "material white diffuse { albedo 0.5 }\n"
        "material lamp emissive { radiance 2 }\n"
        "quad { material white size 20 20 }\n"
        "disk { material lamp radius 0.5 segments 1024 rotate 180 1 0 0 translate 0 1 0 }\n",
    };
    int k;
    for (k = 0; k < 2; k++) {
        pds_options opt;
        pds_image img = {0, 0, NULL};
        double E = PDS__PI * 2.0 * 0.25 / (1.0 + 0.25), expect = 0.5 / PDS__PI * E;
        pds_options_default(&opt);
        REQUIRE(t, render_text(texts[k], &opt, &img, NULL), "render %d", k);
        /* the centre pixel sees the plane point right below the light */
        CHECK(t, fabs(img.rgb[3 * 4 + 1] / expect - 1.0) < 0.03, "case %d: radiance %g, expected %g", k,
              img.rgb[3 * 4 + 1], expect);
        pds_image_free(&img);
    }
}

/* --diffuse-bounces 0 keeps exactly the direct light: the disk light of
   the test above as a mesh (found by light sampling and, through the one
   ray that follows the last diffuse vertex, by BSDF sampling) beside a
   bright wall. The plane point below the light gets E = pi L R^2 / (h^2 +
   R^2) with the limit, for pt and for the photon methods' eye pass (pds,
   no caustics here), and 13% more without it (the wall's light); with
   --max-depth 0 instead, which ends the path at the vertex, the BSDF
   sample's share of the light is lost (5% here). */
static void test_pt_diffuse_bounces_0_leaves_exactly_the_direct_light(pds_test_ctx *t)
{
    static const char text[] =
        "camera { position 2 0.6 0 look_at 0 0 0 fov 0.5 resolution 3 3 spp 4096 }\n"
        "material white diffuse { albedo 0.5 }\n"
        "material wall diffuse { albedo 0.9 }\n"
        "material lamp emissive { radiance 2 }\n"
        "quad { material white size 20 20 }\n"
        "quad { material wall size 4 4 rotate -90 0 0 1 translate -0.6 2 0 }\n"
        "disk { material lamp radius 0.5 segments 1024 rotate 180 1 0 0 translate 0 1 0 }\n";
    static const pds_method methods[2] = {PDS_METHOD_PT, PDS_METHOD_PDS};
    double expect = 0.5 / PDS__PI * (PDS__PI * 2.0 * 0.25 / (1.0 + 0.25)), r;
    pds_options opt;
    pds_image img = {0, 0, NULL};
    int k;
    for (k = 0; k < 2; k++) {
        pds_options_default(&opt);
        opt.method = methods[k];
        opt.diffuse_bounces = 0;
        REQUIRE(t, render_text(text, &opt, &img, NULL), "render %d", k);
        r = img.rgb[3 * 4 + 1] / expect;
        CHECK(t, fabs(r - 1.0) < 0.02, "%s, 0 diffuse bounces: the direct light %g of the analytic",
              k ? "pds" : "pt", r);
        pds_image_free(&img);
    }
    pds_options_default(&opt);
    opt.method = PDS_METHOD_PT;
    REQUIRE(t, render_text(text, &opt, &img, NULL), "render without a limit");
    r = img.rgb[3 * 4 + 1] / expect;
    CHECK(t, r > 1.08, "no limit: %g of the direct light, want the wall's light on top", r);
    pds_image_free(&img);
    opt.max_depth = 0;
    REQUIRE(t, render_text(text, &opt, &img, NULL), "render at depth 0");
    r = img.rgb[3 * 4 + 1] / expect;
    CHECK(t, r < 0.97, "max depth 0: %g of the direct light, want the BSDF sample's share missing", r);
    pds_image_free(&img);
}

static void test_pt_delta_light_caustics_are_left_to_photons(pds_test_ctx *t)
{
    static const char text[] =
        "camera { position 0 2 3 look_at 0 0 0 fov 40 resolution 16 12 spp 4 }\n"
        "material floor diffuse { albedo 0.8 }\n"
        "material glass dielectric { ior 1.5 }\n"
        "quad { material floor size 6 6 }\n"
        "sphere { material glass radius 0.5 translate 0 0.6 0 }\n"
        "light point { position 0 3 0 power 100 }\n";
    pds_options opt;
    pds_image img = {0, 0, NULL};
    pds_options_default(&opt);
    opt.method = PDS_METHOD_PT;
    opt.paths = PDS_PATHS_CAUSTICS_ONLY;
    REQUIRE(t, render_text(text, &opt, &img, NULL), "render");
    CHECK(t, image_mean(&img, 0) == 0.0 && image_mean(&img, 2) == 0.0, "a path tracer finds no point-light caustic");
    pds_image_free(&img);
}

static void test_pt_time_budget_renders_whole_passes(pds_test_ctx *t)
{
    pds_options opt;
    pds_image img = {0, 0, NULL}, ref = {0, 0, NULL};
    pds_render_stats st;
    pds_options_default(&opt);
    opt.method = PDS_METHOD_PT;
    opt.spp = 1;
    opt.time_s = 0.3;
    REQUIRE(t, render_text(glass_sphere_scene, &opt, &img, &st), "timed render");
    CHECK(t, st.passes >= 1 && st.spp == st.passes, "passes %d spp %d", st.passes, st.spp);
    CHECK(t, st.time_total_s >= 0.3, "time used %g", st.time_total_s);
    pds_image_free(&img);
    /* a 0-second budget still renders one whole pass */
    opt.time_s = 1e-9;
    REQUIRE(t, render_text(glass_sphere_scene, &opt, &img, &st), "tiny budget");
    CHECK(t, st.passes == 1, "passes %d", st.passes);
    /* same passes, same image: pass 0 of a timed render is deterministic */
    REQUIRE(t, render_text(glass_sphere_scene, &opt, &ref, &st), "again");
    CHECK(t, memcmp(img.rgb, ref.rgb, sizeof(float) * 3 * (size_t)img.width * img.height) == 0, "deterministic");
    pds_image_free(&img);
    pds_image_free(&ref);
}

static void test_render_rejects_bad_options(pds_test_ctx *t)
{
    pds_options opt;
    pds_image img = {0, 0, NULL};
    pds_error err;
    pds_scene *s = scene_from_text("sphere { }\n", &err);
    REQUIRE(t, s != NULL, "%s", err.text);
    pds_options_default(&opt);
    opt.max_depth = -1;
    CHECK(t, pds_render(s, &opt, &img, NULL, &err) == PDS_ERR_INVALID_ARG && strstr(err.text, "max depth"), "%s", err.text);
    pds_options_default(&opt);
    opt.width = 20000;
    CHECK(t, pds_render(s, &opt, &img, NULL, &err) == PDS_ERR_LIMIT, "resolution limit");
    pds_options_default(&opt);
    opt.time_s = -1;
    CHECK(t, pds_render(s, &opt, &img, NULL, &err) == PDS_ERR_INVALID_ARG, "negative time");
    CHECK(t, img.rgb == NULL, "nothing allocated on failure");
    pds_scene_free(s);
}

/* The photons' Halton points (pds__halton): the radical inverse of
   index + 1 in the dim-th prime base, rotated by the seed's offset. The
   radical inverse is checked against its digits as an exact fraction
   N / b^L (integers; base 2 to the bit, as its fast path is exact, the
   others within a few ulps, as their loop rounds), and the rotations a
   thread keeps (pds__halton_rotation, what emission uses) against
   pds__halton to the bit, also when one value serves a second seed and
   then the first again. */
static void test_halton_points_are_rotated_radical_inverses(pds_test_ctx *t)
{
    static const unsigned base[PDS__HALTON_DIMS] = {2, 3, 5, 7, 11, 13, 17, 19};
    static const uint64_t seeds[3] = {0, 7, 0x76616c6964617465ULL};
    pds__halton_rot rot;
    int dim, k, bad = 0, wide = 0, rotbad = 0;
    for (dim = 0; dim < PDS__HALTON_DIMS; dim++)
        for (k = 0; k < 4000; k++) {
            /* small indices, then random ones up to 2^53 - 1 (base 2) or
               below b^L < 2^63 (the others), then the edges */
            uint64_t i = k < 1000 ? (uint64_t)k
                                  : pds__rng_bits(3, PDS__RNG_TEST, (uint64_t)k, (uint64_t)dim) >> (dim == 0 ? 11 : 12);
            uint64_t num = 0, den = 1, j;
            double exact, got;
            if (k == 3998) i = dim == 0 ? ((uint64_t)1 << 53) - 1 : ((uint64_t)1 << 40) - 1;
            if (k == 3999) i = (uint64_t)1 << 52;
            for (j = i; j > 0; j /= base[dim]) {
                num = num * base[dim] + j % base[dim];
                den *= base[dim];
            }
            exact = (double)num / (double)den; /* both below 2^63: num < den */
            got = pds__radical_inverse(i, dim);
            if (dim == 0 && got != exact) bad++;
            if (!(fabs(got - exact) <= 8.0 * DBL_EPSILON * exact)) wide++;
        }
    CHECK(t, bad == 0, "%d base-2 radical inverses differ from the exact fraction", bad);
    CHECK(t, wide == 0, "%d radical inverses are more than 8 ulps from the exact fraction", wide);
    CHECK(t, pds__radical_inverse(6, 0) == 0.375 && fabs(pds__radical_inverse(5, 1) - 7.0 / 9.0) < 1e-15,
          "radical inverses of 6 (base 2) and 5 (base 3): %.17g, %.17g", pds__radical_inverse(6, 0),
          pds__radical_inverse(5, 1));
    memset(&rot, 0, sizeof rot);
    for (k = 0; k < 4; k++) {
        uint64_t seed = seeds[k % 3 == 2 ? 0 : k % 3];
        const double *shift = pds__halton_rotation(&rot, seed);
        uint64_t i;
        for (dim = 0; dim < PDS__HALTON_DIMS; dim++)
            for (i = 0; i < 300; i += 7) {
                double a = pds__halton_rotated(shift[dim], i * 977, dim), b = pds__halton(seed, i * 977, dim);
                double u = pds__radical_inverse(i * 977 + 1, dim) + pds__rng_uniform(seed, 5, 0, (uint64_t)dim);
                if (memcmp(&a, &b, sizeof a) || !(a >= 0.0 && a < 1.0) || a != (u >= 1.0 ? u - 1.0 : u)) rotbad++;
            }
    }
    CHECK(t, rotbad == 0, "%d rotated points differ from pds__halton's", rotbad);
}

/* A stream's values (pds__rng_stream, pds__rng_uniform_in: the photons'
   bounce choices) are pds__rng_uniform's, to the bit, and its bits'. */
static void test_rng_streams_give_the_same_values(pds_test_ctx *t)
{
    int bad = 0;
    uint64_t k;
    for (k = 0; k < 2000; k++) {
        uint64_t seed = k % 7, purpose = 1 + k % 20, index = pds__rng_bits(1, PDS__RNG_TEST, k, 0) >> (k % 64);
        uint64_t dim = k % 40, stream = pds__rng_stream(seed, purpose, index);
        double a = pds__rng_uniform_in(stream, dim), b = pds__rng_uniform(seed, purpose, index, dim);
        if (memcmp(&a, &b, sizeof a) || pds__mix64(stream ^ dim) != pds__rng_bits(seed, purpose, index, dim)) bad++;
    }
    CHECK(t, bad == 0, "%d stream values differ from pds__rng_uniform's", bad);
    CHECK(t, pds__rng_stream(1, 2, 3) != pds__rng_stream(1, 2, 4) && pds__rng_stream(1, 2, 3) != pds__rng_stream(1, 3, 3),
          "streams of another index or purpose coincide");
}

/* Correlated multi-jittered samples (pds__cmj): for n = m x q points the
   n points fill one of n equal strips in x and one in y each, and one
   cell of the m x q grid each (Kensler's stratification), for any
   pattern; and the permutation behind it is a bijection for any length. */
static void test_pixel_samples_are_stratified(pds_test_ctx *t)
{
    static const int ns[] = {2, 4, 6, 8, 9, 12, 16, 64};
    uint32_t l;
    size_t a;
    int bad = 0;
    for (l = 1; l <= 70 && !bad; l++) {
        unsigned char seen[70];
        uint32_t i, key;
        for (key = 0; key < 5 && !bad; key++) {
            memset(seen, 0, sizeof seen);
            for (i = 0; i < l; i++) {
                uint32_t v = pds__permute(i, l, key * 0x9e3779b9u + 7u);
                if (v >= l || seen[v]++) bad = 1;
            }
        }
        CHECK(t, !bad, "pds__permute is not a bijection on 0..%u", l - 1);
    }
    for (a = 0; a < sizeof ns / sizeof ns[0]; a++) {
        int n = ns[a], m = (int)sqrt((double)n), q = n / m, k, pat, ok = 1;
        for (pat = 0; pat < 8 && ok; pat++) {
            int sx[64] = {0}, sy[64] = {0}, cell[64] = {0};
            uint64_t pattern = pds__rng_bits(5, PDS__RNG_STRATA, (uint64_t)pat, 0);
            for (k = 0; k < n; k++) {
                double x, y;
                pds__cmj(k, n, pattern, pds__rng_uniform(5, PDS__RNG_TEST, (uint64_t)k, 0),
                         pds__rng_uniform(5, PDS__RNG_TEST, (uint64_t)k, 1), &x, &y);
                if (!(x >= 0.0 && x < 1.0 && y >= 0.0 && y < 1.0)) ok = 0;
                else {
                    sx[(int)(x * n)]++;
                    sy[(int)(y * n)]++;
                    cell[(int)(y * q) * m + (int)(x * m)]++;
                }
            }
            for (k = 0; k < n; k++)
                if (sx[k] != 1 || sy[k] != 1 || cell[k] != 1) ok = 0;
        }
        CHECK(t, ok, "%d samples (grid %dx%d) are not stratified", n, m, q);
    }
}

/* The eye pass splits at glass into the reflected and the transmitted
   branch weighted by Fresnel (pds__trace_path, eye_splits): its estimate
   has the expectation of the one-branch estimator, which picks a branch
   with probability F, and less variance. A camera ray through a glass
   sphere onto a lit floor; both estimators over many samples. */
static void test_eye_split_at_glass_keeps_the_mean_and_cuts_the_variance(pds_test_ctx *t)
{
    const char *text = "camera { position 0 1 3 look_at 0 0.4 0 resolution 8 8 spp 1 }\n"
                       "material floor diffuse { albedo 0.7 }\n"
                       "material glass dielectric { ior 1.5 }\n"
                       "material wall diffuse { albedo 0.5 0.3 0.2 }\n"
                       "quad { material floor size 8 8 }\n"
                       "quad { material wall size 8 8 rotate 90 0 0 1 translate 0 0 -2 }\n"
                       "sphere { material glass radius 0.4 segments 48 rings 24 translate 0 0.4 0 }\n"
                       "light quad { center 0 2.5 1 edge1 0.8 0 0 edge2 0 0 0.8 radiance 20 }\n";
    pds_error err;
    pds_scene *s = scene_from_text(text, &err);
    pds__tracer tr;
    double mean[2], var[2];
    long leaves[2] = {0, 0};
    int pass, i, n = 20000;
    pds__v3 org = pds__v(0.0, 1.0, 3.0);
    /* toward the sphere's edge, where Fresnel reflection is strong */
    pds__v3 dir = pds__normalize(pds__sub(pds__v(0.33, 0.45, 0.1), org));
    REQUIRE(t, s, "scene: %s", err.text);
    memset(&tr, 0, sizeof tr);
    tr.scene = s;
    tr.paths = PDS_PATHS_NO_CAUSTICS;
    tr.max_depth = 8;
    tr.rr_depth = 5;
    tr.eps = 1e-6 * pds__scene_scale(s);
    tr.seed = 3;
    for (pass = 0; pass < 2; pass++) {
        double sum = 0.0, sum2 = 0.0;
        tr.eye_splits = pass ? 2 : 0;
        for (i = 0; i < n; i++) {
            double acc[3] = {0.0, 0.0, 0.0}, v;
            pds__eye_vertex rec[PDS__EYE_LEAVES];
            int k, c, got = pds__trace_path(&tr, org, dir, (uint64_t)i, 0.0, acc, rec);
            /* what the photon methods add at the vertices, for a uniform
               unit irradiance from straight above: their importance x
               albedo / pi, so that the importance is tested too */
            v = acc[0] + acc[1] + acc[2];
            for (k = 0; k < got; k++)
                for (c = 0; c < 3; c++) v += rec[k].weight[c];
            leaves[pass] += got;
            sum += v;
            sum2 += v * v;
        }
        mean[pass] = sum / n;
        var[pass] = sum2 / n - mean[pass] * mean[pass];
    }
    CHECK(t, leaves[1] > leaves[0] && leaves[1] <= (long)PDS__EYE_LEAVES * n, "vertices %ld unsplit, %ld split",
          leaves[0], leaves[1]);
    CHECK(t, mean[0] > 0.0 && fabs(mean[0] - mean[1]) < 4.0 * sqrt((var[0] + var[1]) / n),
          "one-branch mean %.5f, split mean %.5f (standard errors %.5f, %.5f)", mean[0], mean[1], sqrt(var[0] / n),
          sqrt(var[1] / n));
    CHECK(t, var[1] < 0.5 * var[0], "split variance %.4g is not well below one-branch's %.4g", var[1], var[0]);
    pds_scene_free(s);
}

/* The eye path's Russian roulette (pds__eye_roulette) weighs its
   throughput as it will be outside the glass (pds__eta2_undone, the
   inverse of a refraction's radiance factor) and, on the camera's
   specular chain, lets a survivor carry 0.1 rather than 1. Camera rays
   through the rim of a glass sphere, where paths reflect inside it, with
   the roulette from the first bounce on: the mean is that of the same
   paths without any roulette, and no vertex's importance exceeds 1 (the
   roulette on beta alone let a path that survived inside the glass come
   out at 2.25), none is below 0.1, and many are below 1/2 (a survivor
   at weight 1 made every vertex 1). */
static void test_eye_roulette_in_glass_keeps_the_mean_and_bounds_the_weights(pds_test_ctx *t)
{
    const char *text = "camera { position 0 1 3 look_at 0 0.4 0 resolution 8 8 spp 1 }\n"
                       "material floor diffuse { albedo 0.7 }\n"
                       "material glass dielectric { ior 1.5 }\n"
                       "quad { material floor size 8 8 }\n"
                       "sphere { material glass radius 0.4 segments 48 rings 24 translate 0 0.401 0 }\n"
                       "light point { position 2 2.5 1 power 50 }\n";
    pds_error err;
    pds_scene *s = scene_from_text(text, &err);
    pds__tracer tr;
    double mean[2], var[2], most = 0.0, least = HUGE_VAL;
    long vertices = 0, faint = 0;
    int pass, i, n = 40000;
    pds__v3 org = pds__v(0.0, 1.0, 3.0);
    REQUIRE(t, s, "scene: %s", err.text);
    memset(&tr, 0, sizeof tr);
    tr.scene = s;
    tr.paths = PDS_PATHS_NO_CAUSTICS;
    tr.max_depth = 12;
    tr.eps = 1e-6 * pds__scene_scale(s);
    tr.seed = 5;
    tr.eye_splits = 2;
    for (pass = 0; pass < 2; pass++) {
        double sum = 0.0, sum2 = 0.0;
        tr.rr_depth = pass ? 1 : 100; /* pass 0: no roulette */
        for (i = 0; i < n; i++) {
            double acc[3] = {0.0, 0.0, 0.0}, v, a = 2.0 * PDS__PI * (i % 97) / 97.0;
            pds__eye_vertex rec[PDS__EYE_LEAVES];
            /* around the sphere's rim as the camera sees it */
            pds__v3 dir = pds__normalize(pds__sub(pds__v(0.385 * cos(a), 0.401 + 0.385 * sin(a), 0.0), org));
            int k, c, got = pds__trace_path(&tr, org, dir, (uint64_t)i, 0.0, acc, rec);
            v = acc[0] + acc[1] + acc[2];
            for (k = 0; k < got; k++) {
                double imp = fmax(rec[k].importance[0], fmax(rec[k].importance[1], rec[k].importance[2]));
                for (c = 0; c < 3; c++) v += rec[k].weight[c];
                if (!pass) continue;
                most = fmax(most, imp);
                least = fmin(least, imp);
                vertices++;
                faint += imp < 0.5;
            }
            sum += v;
            sum2 += v * v;
        }
        mean[pass] = sum / n;
        var[pass] = sum2 / n - mean[pass] * mean[pass];
    }
    CHECK(t, mean[0] > 0.0 && fabs(mean[0] - mean[1]) < 4.0 * sqrt((var[0] + var[1]) / n),
          "mean without roulette %.5f, with it %.5f (standard errors %.5f, %.5f)", mean[0], mean[1],
          sqrt(var[0] / n), sqrt(var[1] / n));
    CHECK(t, most > 0.0 && most <= 1.0 + 1e-6, "a vertex's importance reached %.4f", most);
    CHECK(t, least >= 0.1 - 1e-6 && faint > vertices / 10, "importances from %.4f, %ld of %ld below 1/2", least, faint,
          vertices);
    pds_scene_free(s);
}

/* pds__eta2_undone is the inverse of the radiance factor the production
   BSDF sampler puts on a refraction, into the glass and out of it, and 1
   for a reflection. */
static void test_eta2_undone_inverts_the_refractions_radiance_factor(pds_test_ctx *t)
{
    pds_material m;
    pds__v3 n = pds__v(0.0, 0.0, 1.0);
    int side;
    memset(&m, 0, sizeof m);
    m.type = PDS_MAT_DIELECTRIC;
    m.ior = 1.5;
    m.outside_ior = 1.2;
    for (side = 0; side < 2; side++) {
        /* from above (outside) or from below (inside), 30 degrees off the normal */
        pds__v3 wo = pds__v(0.5, 0.0, side ? -0.8660254 : 0.8660254);
        static const double ut[3] = {1.0, 0.0, 0.0}, ur[3] = {0.0, 0.0, 0.0};
        pds__bsdf_result bt, br;
        REQUIRE(t, pds__bsdf_sample(&m, pds__v(0.0, 0.0, 0.0), wo, n, n, ut, PDS__RADIANCE, &bt) && bt.transmitted,
                "no refraction");
        CHECK(t, fabs(pds__eta2_undone(&m, &bt) * bt.weight[0] - 1.0) < 1e-12, "side %d: factor %.6f, weight %.6f",
              side, pds__eta2_undone(&m, &bt), bt.weight[0]);
        CHECK(t, fabs(pds__eta2_undone(&m, &bt) - (side ? 1.2 * 1.2 / (1.5 * 1.5) : 1.5 * 1.5 / (1.2 * 1.2))) < 1e-12,
              "side %d: factor %.6f", side, pds__eta2_undone(&m, &bt));
        REQUIRE(t, pds__bsdf_sample(&m, pds__v(0.0, 0.0, 0.0), wo, n, n, ur, PDS__RADIANCE, &br) && !br.transmitted,
                "no reflection");
        CHECK(t, pds__eta2_undone(&m, &br) == 1.0, "reflection: %.6f", pds__eta2_undone(&m, &br));
    }
}

static const pds_test_case tests_render[] = {
    {"halton_points_are_rotated_radical_inverses", test_halton_points_are_rotated_radical_inverses},
    {"rng_streams_give_the_same_values", test_rng_streams_give_the_same_values},
    {"pixel_samples_are_stratified", test_pixel_samples_are_stratified},
    {"eye_split_at_glass_keeps_the_mean_and_cuts_the_variance", test_eye_split_at_glass_keeps_the_mean_and_cuts_the_variance},
    {"eye_roulette_in_glass_keeps_the_mean_and_bounds_the_weights", test_eye_roulette_in_glass_keeps_the_mean_and_bounds_the_weights},
    {"eta2_undone_inverts_the_refractions_radiance_factor", test_eta2_undone_inverts_the_refractions_radiance_factor},
    {"pt_full_image_is_no_caustics_plus_caustics_only", test_pt_full_image_is_no_caustics_plus_caustics_only},
    {"pt_image_is_identical_for_any_thread_count", test_pt_image_is_identical_for_any_thread_count},
    {"pt_furnace_converges_to_the_analytic_radiance", test_pt_furnace_converges_to_the_analytic_radiance},
    {"pt_point_light_on_a_plane_matches_inverse_square_law", test_pt_point_light_on_a_plane_matches_inverse_square_law},
    {"pt_area_lights_give_the_analytic_irradiance", test_pt_area_lights_give_the_analytic_irradiance},
    {"pt_diffuse_bounces_0_leaves_exactly_the_direct_light", test_pt_diffuse_bounces_0_leaves_exactly_the_direct_light},
    {"pt_delta_light_caustics_are_left_to_photons", test_pt_delta_light_caustics_are_left_to_photons},
    {"pt_time_budget_renders_whole_passes", test_pt_time_budget_renders_whole_passes},
    {"render_rejects_bad_options", test_render_rejects_bad_options},
};

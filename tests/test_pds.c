/* tests/test_pds.c - photon differential splatting against known answers:
   the mirrored point light, the glass slab, flux conservation, agreement
   with the path tracer's caustics, and determinism. */

/* Render scene text with a photon method; tweak (if any) adjusts the
   options last. Shared by the PDS and baseline tests. */
static int photon_render_text(const char *text, pds_method method, long photons, double s, pds_paths paths,
                              int threads, pds_image *img, pds_render_stats *st, void (*tweak)(pds_options *))
{
    pds_options opt;
    pds_options_default(&opt);
    opt.method = method;
    opt.photons = photons;
    opt.smoothing = s;
    opt.progressive = 0; /* s is the paper's fixed smoothing; a tweak may turn passes on */
    opt.paths = paths;
    opt.threads = threads;
    if (tweak) tweak(&opt);
    return render_text(text, &opt, img, st);
}

static int pds_render_text(const char *text, long photons, double s, pds_paths paths, int threads, pds_image *img,
                           pds_render_stats *st)
{
    return photon_render_text(text, PDS_METHOD_PDS, photons, s, paths, threads, img, st, NULL);
}

/* A camera at height h looking straight down at the plane y = 0 sees, in
   every pixel, a patch of the same area (h * 2 tan(fov/2) / W)^2 (square
   pixels): the pinhole projection onto a plane parallel to the image plane
   is uniform. */
static double pixel_area_on_floor(double h, double fov_deg, int width)
{
    double side = h * 2.0 * tan(0.5 * fov_deg * PDS__PI / 180.0) / width;
    return side * side;
}

/* The floor point seen by pixel (x, y) of a camera at (0, h, 0) looking
   down with up = -z (image x = world x, image y = world z). */
static pds__v3 floor_point(double h, double fov_deg, int width, int x, int y)
{
    double half = h * tan(0.5 * fov_deg * PDS__PI / 180.0), step = 2.0 * half / width;
    return pds__v(-half + (x + 0.5) * step, 0.0, -half + (y + 0.5) * step);
}

/* A vertical mirror at x = 1 and a point light at (0, 1, 0): the caustic on
   the floor is the light of the mirrored source at (2, 1, 0) times the
   mirror's reflectance, E = R P / (4 pi) cos / d^2 with cos = 1 / d. */
/* A point light at (0, 1, 0) and a mirror in the plane x = 1: the floor
   sees the light mirrored at (2, 1, 0). */
static const char mirror_scene[] =
    "camera { position 0 2 0.000001 look_at 0 0 0 up 0 0 -1 fov 30 resolution 24 24 spp 16 }\n"
    "material floor diffuse { albedo 0.5 }\n"
    "material glass mirror { reflectance 0.9 }\n"
    "quad { material floor size 8 8 }\n"
    "quad { material glass size 3 3 rotate 90 0 0 1 translate 1 1.5 0 }\n"
    "light point { position 0 1 0 power 100 }\n";

static void test_pds_plane_mirror_reflects_the_mirrored_point_light(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    int x, y, bad = 0, n = 0;
    double worst = 0.0;
    REQUIRE(t, pds_render_text(mirror_scene, 400000, 20.0, PDS_PATHS_CAUSTICS_ONLY, 2, &img, NULL), "render");
    for (y = 3; y < 21; y++) {
        for (x = 3; x < 21; x++) {
            pds__v3 p = floor_point(2.0, 30.0, 24, x, y);
            pds__v3 d = pds__sub(pds__v(2.0, 1.0, 0.0), p);
            double d2 = pds__dot(d, d), E = 0.9 * 100.0 / (4.0 * PDS__PI) * (1.0 / sqrt(d2)) / d2;
            double expect = 0.5 / PDS__PI * E, rel = fabs(img.rgb[3 * (y * 24 + x) + 1] / expect - 1.0);
            if (rel > worst) worst = rel;
            bad += rel > 0.02;
            n++;
        }
    }
    CHECK(t, bad == 0, "%d of %d pixels off by more than 2%%, worst %.4f", bad, n, worst);
    pds_image_free(&img);
}

/* Glass slab of thickness d, absorption sigma, under collimated light E
   at normal incidence: below it E T^2 a / (1 - R^2 a^2), a = exp(-sigma d)
   (every pair of internal reflections adds a term of the series). */
static const char slab_scene[] =
    "camera { position 0 1.2 0.000001 look_at 0 0 0 up 0 0 -1 fov 90 resolution 24 24 spp 16 }\n"
    "material floor diffuse { albedo 0.5 }\n"
    "material glass dielectric { ior 1.5 absorption 0.2 0.5 1.0 }\n"
    "quad { material floor size 8 8 }\n"
    "box { material glass size 1 0.5 1 translate 0 1.75 0 }\n"
    "light directional { direction 0 -1 0 irradiance 3 rect 0 3 0 1.2 0 0 0 0 1.2 }\n";

static double slab_transmittance(double sigma)
{
    double R = 0.04, T = 0.96, a = exp(-sigma * 0.5);
    return T * T * a / (1.0 - R * R * a * a);
}

static void test_pds_glass_slab_transmits_both_fresnel_factors_and_absorption(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    static const double sigma[3] = {0.2, 0.5, 1.0};
    int x, y, c, bad = 0;
    double worst = 0.0;
    REQUIRE(t, pds_render_text(slab_scene, 200000, 40.0, PDS_PATHS_CAUSTICS_ONLY, 2, &img, NULL), "render");
    /* the slab's shadow is |x|, |z| < 0.5; look well inside it */
    for (y = 0; y < 24; y++) {
        for (x = 0; x < 24; x++) {
            pds__v3 p = floor_point(1.2, 90.0, 24, x, y);
            if (fabs(p.x) > 0.3 || fabs(p.z) > 0.3) continue;
            for (c = 0; c < 3; c++) {
                double expect = 0.5 / PDS__PI * 3.0 * slab_transmittance(sigma[c]);
                double rel = fabs(img.rgb[3 * (y * 24 + x) + c] / expect - 1.0);
                if (rel > worst) worst = rel;
                bad += rel > 0.02;
            }
        }
    }
    CHECK(t, bad == 0, "%d pixel channels off by more than 2%%, worst %.4f", bad, worst);
    pds_image_free(&img);
}

/* Flux conservation: the whole caustic lands on the visible floor, so the
   splatted irradiance integrated over the pixels' patches (E = pi L / albedo)
   equals the flux through the slab, E A T^2 a / (1 - R^2 a^2), whatever the
   smoothing: the kernel is normalised (eq. 11) and the filter matrix maps
   each footprint to the unit disc (eq. 12). */
static void test_pds_splatted_flux_equals_transmitted_flux_for_any_smoothing(pds_test_ctx *t)
{
    static const double smoothing[] = {5.0, 12.0, 30.0};
    static const double sigma[3] = {0.2, 0.5, 1.0};
    size_t k;
    for (k = 0; k < sizeof smoothing / sizeof smoothing[0]; k++) {
        pds_image img = {0, 0, NULL};
        double total[3] = {0, 0, 0}, area = pixel_area_on_floor(1.2, 90.0, 24);
        int i, c;
        REQUIRE(t, pds_render_text(slab_scene, 100000, smoothing[k], PDS_PATHS_CAUSTICS_ONLY, 2, &img, NULL), "render");
        for (i = 0; i < 24 * 24; i++)
            for (c = 0; c < 3; c++) total[c] += PDS__PI * img.rgb[3 * i + c] / 0.5 * area;
        for (c = 0; c < 3; c++) {
            double expect = 3.0 * 1.0 * slab_transmittance(sigma[c]);
            CHECK(t, fabs(total[c] / expect - 1.0) < 0.01, "s = %g, channel %d: flux %.5f W, expected %.5f W",
                  smoothing[k], c, total[c], expect);
        }
        pds_image_free(&img);
    }
}

/* The caustic of a glass sphere under a small area light, seen from above
   (the sphere hangs high enough that the camera sees the whole caustic on
   the floor below it, not through the ball). */
static const char sphere_caustic_scene[] =
    "camera { position 0 1 0.000001 look_at 0 0 0 up 0 0 -1 fov 100 resolution 40 40 spp 8 }\n"
    "material floor diffuse { albedo 0.8 }\n"
    "material glass dielectric { ior 1.5 }\n"
    "quad { material floor size 8 8 }\n"
    "sphere { material glass radius 0.4 segments 96 rings 48 translate 0 2 0 }\n"
    "light disk { center 0.2 4 0 normal 0 -1 0 radius 0.3 power 30 }\n";

/* The bound: PDS with 200,000 photons must be closer (RMSE) to a 2048-spp
   path-traced caustics-only image than a second path-traced image of the
   same effort with another seed is (measured: 0.023 against 0.033), and
   the caustic's total light must agree within 5%. */
static void test_pds_sphere_caustic_agrees_with_path_traced_caustics(pds_test_ctx *t)
{
    pds_options opt;
    pds_image ref = {0, 0, NULL}, ref2 = {0, 0, NULL}, img = {0, 0, NULL};
    pds_metrics m, m2;
    pds_error err;
    pds_options_default(&opt);
    opt.method = PDS_METHOD_PT;
    opt.paths = PDS_PATHS_CAUSTICS_ONLY;
    opt.spp = 2048;
    REQUIRE(t, render_text(sphere_caustic_scene, &opt, &ref, NULL), "reference");
    opt.seed = 5;
    REQUIRE(t, render_text(sphere_caustic_scene, &opt, &ref2, NULL), "second path-traced image");
    REQUIRE(t, pds_render_text(sphere_caustic_scene, 200000, 12.0, PDS_PATHS_CAUSTICS_ONLY, 2, &img, NULL), "pds");
    REQUIRE(t, pds_image_compare(&img, &ref, &m, &err) == PDS_OK, "%s", err.text);
    REQUIRE(t, pds_image_compare(&ref2, &ref, &m2, &err) == PDS_OK, "%s", err.text);
    CHECK(t, image_mean(&ref, 1) > 0.01, "the reference has a caustic");
    CHECK(t, m.rmse < m2.rmse, "pds rmse %g, path tracing's own rmse %g", m.rmse, m2.rmse);
    CHECK(t, fabs(image_mean(&img, 1) / image_mean(&ref, 1) - 1.0) < 0.05, "total caustic light %g vs %g",
          image_mean(&img, 1), image_mean(&ref, 1));
    pds_image_free(&ref);
    pds_image_free(&ref2);
    pds_image_free(&img);
}

static void test_pds_image_is_identical_for_any_thread_count(pds_test_ctx *t)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    pds_render_stats sa, sb;
    REQUIRE(t, pds_render_text(sphere_caustic_scene, 20000, 12.0, PDS_PATHS_ALL, 1, &a, &sa), "1 thread");
    REQUIRE(t, pds_render_text(sphere_caustic_scene, 20000, 12.0, PDS_PATHS_ALL, 3, &b, &sb), "3 threads");
    CHECK(t, memcmp(a.rgb, b.rgb, sizeof(float) * 3 * (size_t)a.width * a.height) == 0, "bitwise equal");
    /* over 4096 splats: one thread holds more landings than it may
       (PDS__LANDINGS_HELD) and splats them in two rounds, three threads
       in one each */
    CHECK(t, sa.photons == 20000 && sa.splatted == sb.splatted && sa.splatted > 4096, "photons %ld splatted %ld / %ld",
          sa.photons, sa.splatted, sb.splatted);
    CHECK(t, sa.eye_vertices > 0 && sa.eye_vertices == sb.eye_vertices, "eye vertices %ld", sa.eye_vertices);
    pds_image_free(&a);
    pds_image_free(&b);
}

/* The same at the defaults (progressive, the pixels choosing their
   scale) and at a size whose image is made on threads
   (PDS__PARALLEL_PIXELS): the threads' sums are added into the part, and
   the choice made, by shares of pixels. */
static void test_pds_large_default_image_is_identical_for_any_thread_count(pds_test_ctx *t)
{
    pds_image img[2] = {{0, 0, NULL}, {0, 0, NULL}};
    pds_render_stats st[2];
    pds_options opt;
    long took = 0;
    int k;
    for (k = 0; k < 2; k++) {
        pds_options_default(&opt);
        opt.photons = 20000;
        opt.paths = PDS_PATHS_CAUSTICS_ONLY;
        opt.width = 384;
        opt.height = 352;
        opt.spp = 4;
        opt.threads = k ? 3 : 1;
        REQUIRE(t, render_text(sphere_caustic_scene, &opt, &img[k], &st[k]), "%d threads", opt.threads);
    }
    REQUIRE(t, (size_t)img[0].width * img[0].height >= PDS__PARALLEL_PIXELS, "the image is shared out");
    for (k = 1; k < PDS_SCALE_ESTIMATES; k++) took += st[0].scale_pixels[k];
    CHECK(t, took > 0, "no pixel took another scale than the pass's");
    CHECK(t, memcmp(img[0].rgb, img[1].rgb, sizeof(float) * 3 * (size_t)img[0].width * img[0].height) == 0,
          "bitwise equal");
    CHECK(t, memcmp(st[0].scale_pixels, st[1].scale_pixels, sizeof st[0].scale_pixels) == 0, "the same choices");
    pds_image_free(&img[0]);
    pds_image_free(&img[1]);
}

/* ALL = NO_CAUSTICS + CAUSTICS_ONLY for PDS too: the eye pass and the
   photon pass never count the same light twice. */
static void test_pds_full_image_is_eye_pass_plus_splats(pds_test_ctx *t)
{
    pds_image all = {0, 0, NULL}, nc = {0, 0, NULL}, co = {0, 0, NULL};
    size_t i, n;
    double worst = 0.0;
    REQUIRE(t, pds_render_text(sphere_caustic_scene, 20000, 12.0, PDS_PATHS_ALL, 2, &all, NULL), "all");
    REQUIRE(t, pds_render_text(sphere_caustic_scene, 20000, 12.0, PDS_PATHS_NO_CAUSTICS, 2, &nc, NULL), "nc");
    REQUIRE(t, pds_render_text(sphere_caustic_scene, 20000, 12.0, PDS_PATHS_CAUSTICS_ONLY, 2, &co, NULL), "co");
    n = (size_t)all.width * all.height * 3;
    for (i = 0; i < n; i++) {
        double rel = fabs((double)all.rgb[i] - nc.rgb[i] - co.rgb[i]) / (1e-6 + all.rgb[i]);
        if (rel > worst) worst = rel;
    }
    CHECK(t, worst < 1e-5, "worst relative difference %g", worst);
    pds_image_free(&all);
    pds_image_free(&nc);
    pds_image_free(&co);
}

/* The footprint debug image: green (round) where the slab's photons land,
   black where none do (the camera sees 1.2 to each side, the slab's shadow
   is 0.5). */
static void test_pds_footprint_debug_image_shows_anisotropy(pds_test_ctx *t)
{
    pds_options opt;
    pds_image img = {0, 0, NULL};
    pds_debug dbg;
    const pds_image *fp = &dbg.value[PDS_DEBUG_FOOTPRINT];
    pds_options_default(&opt);
    pds_debug_init(&dbg);
    dbg.views = 1u << PDS_DEBUG_FOOTPRINT;
    opt.method = PDS_METHOD_PDS;
    opt.photons = 20000;
    opt.debug = &dbg;
    REQUIRE(t, render_text(slab_scene, &opt, &img, NULL), "render");
    REQUIRE(t, fp->width == 24 && fp->height == 24, "footprint image %dx%d", fp->width, fp->height);
    /* centre pixel: under the slab, collimated light, footprints stay round */
    CHECK(t, fp->rgb[3 * (12 * 24 + 12) + 1] > 0.9, "m_a at the centre %g", fp->rgb[3 * (12 * 24 + 12) + 1]);
    CHECK(t, fp->rgb[0] == 0.0f && fp->rgb[1] == 0.0f, "corner outside the caustic is black");
    /* the picture: the same colours over a legend strip */
    CHECK(t, dbg.picture[PDS_DEBUG_FOOTPRINT].height == 24 + PDS_DEBUG_LEGEND_ROWS, "picture height %d",
          dbg.picture[PDS_DEBUG_FOOTPRINT].height);
    pds_image_free(&img);
    pds_debug_free(&dbg);
}

/* --min-aspect widens needles without moving them: the widened ellipse has
   the same centre, major semi-axis and orientation, a minor semi-axis of
   min_aspect x the major one (so the area pi A B), and rounder footprints
   are left alone; a collapsed footprint widens across the surface. */
static void test_pds_footprint_widening_keeps_the_major_axis(pds_test_ctx *t)
{
    pds__v3 np = pds__v(0, 1, 0), du = pds__v(1.0, 0.0, 0.2), dv = pds__v(0.9, 0.0, 0.25), u2 = du, v2 = dv;
    double major = pds__footprint_major_axis(du, dv), x, y;
    REQUIRE(t, pds__footprint_widen(&u2, &v2, np, 0.3), "a needle is widened");
    CHECK_NEAR(t, pds__footprint_major_axis(u2, v2), major, 1e-12);
    CHECK_NEAR(t, pds__footprint_area(u2, v2), PDS__PI * major * 0.3 * major, 1e-12);
    CHECK_NEAR(t, pds__dot(u2, v2), 0.0, 1e-12);
    /* the major axis keeps its direction: the old ellipse's farthest point
       from the centre lies on it */
    x = pds__length(pds__cross(pds__normalize(u2), pds__normalize(pds__add(pds__scale(du, 0.5),
                                                                           pds__scale(dv, 0.5)))));
    CHECK(t, x < 0.02, "major axis turned by sin = %g", x);
    u2 = pds__v(1, 0, 0);
    v2 = pds__v(0, 0, 0.8);
    CHECK(t, !pds__footprint_widen(&u2, &v2, np, 0.3), "a round footprint is left alone");
    u2 = pds__v(1, 0, 0);
    v2 = pds__v(1, 0, 0);
    /* du = dv: the segment x = (cos t + sin t) du / 2, half-length sqrt(1/2) */
    REQUIRE(t, pds__footprint_widen(&u2, &v2, np, 0.25), "a collapsed footprint is widened");
    y = pds__footprint_area(u2, v2);
    CHECK_NEAR(t, y, PDS__PI * 0.5 * 0.25, 1e-12);
    CHECK_NEAR(t, fabs(v2.z), 2.0 * 0.25 * sqrt(0.5), 1e-12); /* across the surface */
}


/* The width floor (min_width, progressive PDS): both semi-axes at least the
   floor, a long axis kept, a footprint larger than the floor left alone. */
static void test_pds_footprint_width_floor_raises_both_semi_axes(pds_test_ctx *t)
{
    pds__v3 np = pds__v(0, 1, 0), u2, v2;
    /* a needle, semi-axes 1 and 0.01: the minor one becomes 0.5 */
    u2 = pds__v(2.0, 0.0, 0.0);
    v2 = pds__v(0.0, 0.0, 0.02);
    REQUIRE(t, pds__footprint_widen_to(&u2, &v2, np, 0.0, 0.5), "a needle is widened");
    CHECK_NEAR(t, pds__footprint_major_axis(u2, v2), 1.0, 1e-12);
    CHECK_NEAR(t, pds__footprint_area(u2, v2), PDS__PI * 1.0 * 0.5, 1e-12);
    /* a tiny round footprint becomes a disc of the floor's radius */
    u2 = pds__v(0.02, 0.0, 0.0);
    v2 = pds__v(0.0, 0.0, 0.02);
    REQUIRE(t, pds__footprint_widen_to(&u2, &v2, np, 0.0, 0.5), "a tiny footprint is widened");
    CHECK_NEAR(t, pds__footprint_area(u2, v2), PDS__PI * 0.25, 1e-12);
    /* the aspect floor applies to the widened major axis */
    u2 = pds__v(0.02, 0.0, 0.0);
    v2 = pds__v(0.0, 0.0, 0.001);
    REQUIRE(t, pds__footprint_widen_to(&u2, &v2, np, 0.3, 0.5), "widened");
    CHECK_NEAR(t, pds__footprint_area(u2, v2), PDS__PI * 0.5 * 0.5, 1e-12);
    u2 = pds__v(2.0, 0.0, 0.0);
    v2 = pds__v(0.0, 0.0, 1.6);
    CHECK(t, !pds__footprint_widen_to(&u2, &v2, np, 0.3, 0.5), "a large round footprint is left alone");
}

static void min_aspect_03(pds_options *o) { o->min_aspect = 0.3; }

/* Widening moves light only sideways within each footprint: the sphere's
   caustic keeps its total light while the image changes. (What it loses
   is light spread past the edge of the view by the wider splats of photons
   landing near it: 0.4% here; 0.2% at min_aspect 0.5 with a view eleven
   times as wide.) */
static void test_pds_footprint_widening_conserves_the_caustic_light(pds_test_ctx *t)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    pds_metrics m;
    pds_error err;
    REQUIRE(t, photon_render_text(sphere_caustic_scene, PDS_METHOD_PDS, 50000, 12.0, PDS_PATHS_CAUSTICS_ONLY, 2, &a,
                                  NULL, NULL), "pds");
    REQUIRE(t, photon_render_text(sphere_caustic_scene, PDS_METHOD_PDS, 50000, 12.0, PDS_PATHS_CAUSTICS_ONLY, 2, &b,
                                  NULL, min_aspect_03), "pds --min-aspect 0.3");
    REQUIRE(t, pds_image_compare(&b, &a, &m, &err) == PDS_OK, "%s", err.text);
    CHECK(t, m.rmse > 1e-3 * image_mean(&a, 1), "widening changed nothing (rmse %g)", m.rmse);
    CHECK(t, fabs(image_mean(&b, 1) / image_mean(&a, 1) - 1.0) < 0.01, "total light %g vs %g", image_mean(&b, 1),
          image_mean(&a, 1));
    pds_image_free(&a);
    pds_image_free(&b);
}


/* Progressive PDS's schedule: pass i splats with s_i = s_1 i^((alpha-1)/2),
   so that its footprint areas (~ s_i^2 / M, eqs. 5-6) shrink as
   i^(alpha - 1). */
static void test_progressive_pds_schedule_shrinks_footprint_areas_as_i_to_alpha_minus_1(pds_test_ctx *t)
{
    /* alpha 2/3, pass 8: 8^(-1/6) = 2^(-1/2) */
    CHECK_NEAR(t, pds__pass_smoothing(4.0, 2.0 / 3.0, 8), 4.0 / sqrt(2.0), 1e-12);
    CHECK_NEAR(t, pds__pass_smoothing(4.0, 2.0 / 3.0, 1), 4.0, 1e-12);
    /* area ratio of passes 1000 and 1 is 1000^(alpha - 1) */
    CHECK_NEAR(t, pow(pds__pass_smoothing(3.0, 0.5, 1000) / 3.0, 2.0), pow(1000.0, -0.5), 1e-12);
    CHECK_NEAR(t, pds__pass_smoothing(3.0, 1.0, 77), 3.0, 1e-12);
}

/* RMSE, relative to the answer, of the plane mirror scene over the inner
   pixels: its caustic (the point light of 100 W at (0, 1, 0) mirrored at
   (2, 1, 0) by reflectance 0.9: E = 0.9 P / (4 pi d^2) cos on the floor of
   albedo 0.5), plus `direct` times the light's own direct light. */
static double mirror_error(const pds_image *img, double direct)
{
    double sum = 0.0;
    int x, y, n = 0;
    for (y = 3; y < 21; y++) {
        for (x = 3; x < 21; x++) {
            pds__v3 p = floor_point(2.0, 30.0, 24, x, y);
            pds__v3 a = pds__sub(pds__v(0.0, 1.0, 0.0), p), b = pds__sub(pds__v(2.0, 1.0, 0.0), p);
            double a2 = pds__dot(a, a), b2 = pds__dot(b, b);
            double E = 100.0 / (4.0 * PDS__PI) * (direct * (1.0 / sqrt(a2)) / a2 + 0.9 * (1.0 / sqrt(b2)) / b2);
            double rel = img->rgb[3 * (y * 24 + x) + 1] / (0.5 / PDS__PI * E) - 1.0;
            sum += rel * rel;
            n++;
        }
    }
    return sqrt(sum / n);
}

static double mirror_caustic_error(const pds_image *img)
{
    return mirror_error(img, 0.0);
}

static void progressive_small_passes(pds_options *o)
{
    o->progressive = 1;
    o->pass_photons = 2048;
    o->pass_smoothing = 3.0;
    o->pass_min_aspect = o->pass_min_width = 0.0; /* the analytic caustic needs no widening */
}

static void progressive_small_passes_3000(pds_options *o)
{
    o->progressive = 1;
    o->pass_photons = 3000;
    o->pass_smoothing = 3.0;
    o->pass_min_aspect = o->pass_min_width = 0.0; /* the analytic caustic needs no widening */
}

/* Progressive PDS converges: with a fixed seed its error against the
   analytic caustic falls at every eightfold step of the photon count, to
   well below the paper's fixed-s PDS at the same count (whose noise stops
   falling: the same s^2 footprints cover each point whatever N is). */
static void test_progressive_pds_error_falls_as_photons_are_added(pds_test_ctx *t)
{
    static const long counts[] = {2048, 16384, 131072, 1048576};
    double err[4], fixed;
    pds_image img = {0, 0, NULL};
    pds_render_stats st;
    int i;
    for (i = 0; i < 4; i++) {
        REQUIRE(t, photon_render_text(mirror_scene, PDS_METHOD_PDS, counts[i], 3.0, PDS_PATHS_CAUSTICS_ONLY, 2, &img,
                                      &st, progressive_small_passes),
                "render");
        err[i] = mirror_caustic_error(&img);
        CHECK(t, st.passes == (int)(counts[i] / 2048) && st.photons == counts[i], "%ld photons: %d passes, %ld photons",
              counts[i], st.passes, st.photons);
        pds_image_free(&img);
        if (i > 0) CHECK(t, err[i] < err[i - 1], "error %g at %ld photons, %g at %ld", err[i], counts[i], err[i - 1], counts[i - 1]);
    }
    REQUIRE(t, pds_render_text(mirror_scene, counts[3], 3.0, PDS_PATHS_CAUSTICS_ONLY, 2, &img, NULL), "render");
    fixed = mirror_caustic_error(&img);
    pds_image_free(&img);
    CHECK(t, err[3] < 0.5 * fixed, "progressive %g, fixed s %g at %ld photons", err[3], fixed, counts[3]);
}


static void progressive_quarter_second(pds_options *o)
{
    progressive_small_passes_3000(o);
    o->time_s = 0.25;
    o->eye_rounds = 1; /* one eye pass, as a photon budget's */
}

/* Under a time budget progressive PDS runs whole passes: the photon count
   is a multiple of the pass size, and each pass is the same photons as
   without a budget (the image of a budget that ran K passes equals the
   image of K passes' photons, with one eye pass as theirs). */
static void test_progressive_pds_under_a_time_budget_runs_whole_passes(pds_test_ctx *t)
{
    pds_image timed = {0, 0, NULL}, counted = {0, 0, NULL};
    pds_render_stats st, st2;
    size_t i, n;
    double worst = 0.0;
    REQUIRE(t, photon_render_text(mirror_scene, PDS_METHOD_PDS, 100000, 3.0, PDS_PATHS_CAUSTICS_ONLY, 2, &timed, &st,
                                  progressive_quarter_second),
            "render");
    CHECK(t, st.passes >= 1 && st.photons == 3000L * st.passes, "%d passes, %ld photons", st.passes, st.photons);
    REQUIRE(t, photon_render_text(mirror_scene, PDS_METHOD_PDS, 3000L * st.passes, 3.0, PDS_PATHS_CAUSTICS_ONLY, 1,
                                  &counted, &st2, progressive_small_passes_3000),
            "render");
    n = (size_t)timed.width * timed.height * 3;
    for (i = 0; i < n; i++) worst = fmax(worst, fabs(timed.rgb[i] - counted.rgb[i]));
    CHECK(t, st2.passes == st.passes && worst == 0.0, "%d and %d passes, largest difference %g", st.passes, st2.passes,
          worst);
    pds_image_free(&timed);
    pds_image_free(&counted);
}

/* Eye rounds (pds__pds_passes): a photon budget's K passes in R runs of
   consecutive passes, round floor(k R / K); under a time budget a round is
   due once the passes since the last eye pass took as long as it did, and
   only if a pass can still follow it. */
static void test_eye_rounds_are_runs_of_consecutive_passes(pds_test_ctx *t)
{
    static const long seven_in_three[7] = {0, 0, 0, 1, 1, 2, 2};
    long k, bad = 0;
    for (k = 0; k < 7; k++) bad += pds__eye_round_of(k, 7, 3) != seven_in_three[k];
    CHECK(t, bad == 0, "7 passes in 3 rounds: %ld passes in the wrong round", bad);
    for (k = 0; k < 5; k++) bad += pds__eye_round_of(k, 5, 5) != k || pds__eye_round_of(k, 5, 1) != 0;
    CHECK(t, bad == 0, "one round a pass, or one round: %ld wrong", bad);
    /* a billion passes in 65536 rounds: no overflow, the last pass in the last round */
    CHECK(t, pds__eye_round_of(999999999L, 1000000000L, 65536) == 65535 &&
                 pds__eye_round_of(15258L, 1000000000L, 65536) == 0 && pds__eye_round_of(15259L, 1000000000L, 65536) == 1,
          "large counts: %ld", pds__eye_round_of(999999999L, 1000000000L, 65536));
    CHECK(t, !pds__eye_round_due(0.09, 0.1, 0.03, 0.0, 10.0, 1.0) && pds__eye_round_due(0.1, 0.1, 0.03, 0.0, 10.0, 1.0),
          "a round is due once the passes took as long as the eye pass (ratio 1)");
    CHECK(t, !pds__eye_round_due(0.39, 0.1, 0.03, 0.0, 10.0, 4.0) && pds__eye_round_due(0.4, 0.1, 0.03, 0.0, 10.0, 4.0),
          "at ratio 4 a round is due once the passes took four times the eye pass");
    CHECK(t, pds__eye_round_due(0.2, 0.1, 0.04, 9.88, 10.0, 1.0) && !pds__eye_round_due(0.2, 0.1, 0.04, 9.89, 10.0, 1.0),
          "a round only if half a pass still fits after it (9.88 + 0.1 + 0.02 = 10)");
}

/* The full image of the mirror scene: direct light and caustic. */
static double mirror_full_error(const pds_image *img)
{
    return mirror_error(img, 1.0);
}

/* progressive_small_passes with R eye rounds (0: the default rule), one
   callback a count, as photon_render_text takes them */
static void small_passes_rounds(pds_options *o, int rounds)
{
    progressive_small_passes(o);
    o->eye_rounds = rounds;
}
static void eye_rounds_default(pds_options *o) { small_passes_rounds(o, 0); }
static void eye_rounds_1(pds_options *o) { small_passes_rounds(o, 1); }
static void eye_rounds_3(pds_options *o) { small_passes_rounds(o, 3); }
static void eye_rounds_8(pds_options *o) { small_passes_rounds(o, 8); }

/* Eye rounds under a photon budget: 64 passes splatting into 8 eye passes
   of 16 samples a pixel (8 x 16 = 128 samples, reported as spp), the
   direct light the mean of the 8 eye passes'. The full image matches the
   analytic direct light and caustic as closely as one eye pass's does, the
   same bits for 1 and 2 threads, and the rounds did change the eye
   samples (the image is not the one eye pass's). */
static void test_pds_eye_rounds_keep_the_analytic_image(pds_test_ctx *t)
{
    pds_image one = {0, 0, NULL}, rounds = {0, 0, NULL}, rounds1 = {0, 0, NULL};
    pds_render_stats st, st1;
    double e_one, e_rounds;
    REQUIRE(t, photon_render_text(mirror_scene, PDS_METHOD_PDS, 131072, 3.0, PDS_PATHS_ALL, 2, &one, &st1, eye_rounds_1),
            "render");
    REQUIRE(t, photon_render_text(mirror_scene, PDS_METHOD_PDS, 131072, 3.0, PDS_PATHS_ALL, 2, &rounds, &st, eye_rounds_8),
            "render");
    REQUIRE(t, photon_render_text(mirror_scene, PDS_METHOD_PDS, 131072, 3.0, PDS_PATHS_ALL, 1, &rounds1, NULL, eye_rounds_8),
            "render");
    e_one = mirror_full_error(&one);
    e_rounds = mirror_full_error(&rounds);
    CHECK(t, st1.spp == 16 && st.spp == 128 && st.passes == 64 && st.photons == 131072,
          "spp %d and %d, %d passes, %ld photons", st1.spp, st.spp, st.passes, st.photons);
    CHECK(t, e_rounds < 0.005 && e_rounds < 1.5 * e_one, "relative error %g with 8 eye rounds, %g with one", e_rounds,
          e_one);
    CHECK(t, memcmp(rounds.rgb, rounds1.rgb, sizeof *rounds.rgb * 3 * 24 * 24) == 0, "1 and 2 threads differ");
    CHECK(t, memcmp(rounds.rgb, one.rgb, sizeof *one.rgb * 3 * 24 * 24) != 0, "the rounds changed nothing");
    pds_image_free(&one);
    pds_image_free(&rounds);
    pds_image_free(&rounds1);
}

/* The mirror scene's light and mirror over a gently curved floor (a
   sphere of radius 20), seen at a slant: every pixel sees the floor
   directly; and the same with the mirror in view. */
static const char slant_floor_scene[] =
    "camera { position -1.2 1.5 1.2 look_at -0.4 0 -0.1 fov 30 resolution 24 24 spp 16 }\n"
    "material floor diffuse { albedo 0.5 }\n"
    "material glass mirror { reflectance 0.9 }\n"
    "sphere { material floor radius 20 segments 256 rings 128 translate 0 -20 0 }\n"
    "quad { material glass size 3 3 rotate 90 0 0 1 translate 1 1.5 0 }\n"
    "light point { position 0 1 0 power 100 }\n";
static const char slant_mirror_scene[] =
    "camera { position -0.4 1.5 1.2 look_at 1.0 0.4 -0.1 fov 40 resolution 24 24 spp 16 }\n"
    "material floor diffuse { albedo 0.5 }\n"
    "material glass mirror { reflectance 0.9 }\n"
    "sphere { material floor radius 20 segments 256 rings 128 translate 0 -20 0 }\n"
    "quad { material glass size 3 3 rotate 90 0 0 1 translate 1 1.5 0 }\n"
    "light point { position 0 1 0 power 100 }\n";

/* A render of 131,072 photons in 8 eye rounds (eye_rounds_8). */
static int rounds8_render(const char *scene, pds_paths paths, int threads, pds_image *img, pds_render_stats *st)
{
    return photon_render_text(scene, PDS_METHOD_PDS, 131072, 3.0, paths, threads, img, st, eye_rounds_8);
}

/* A caustics-only render's eye rounds trace only the pixels that round 0
   did not see whole (pds__eye_retrace); a pixel seen whole keeps round 0's
   vertex, since its value is no caustic's. With every pixel seeing the
   floor directly, 8 rounds (spp 128) trace round 0's 576 x 16 camera
   samples and no more, a full image 576 x 16 x 15 (its direct light is
   every round's, traced first, and rounds 1-7 again for their vertices
   as their passes come); with the mirror in view, each later round traces the
   pixels that see the floor through it, 16 samples each, the same for 1
   and 2 threads. A shard's split of these rounds is checked in
   tests/test_shards.c (pds (caustic eye rounds)). */
static void test_pds_caustic_eye_rounds_keep_round_0s_whole_pixels(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL}, img1 = {0, 0, NULL};
    pds_render_stats st, st1;
    long later;
    REQUIRE(t, rounds8_render(slant_floor_scene, PDS_PATHS_CAUSTICS_ONLY, 2, &img, &st), "render");
    CHECK(t, st.spp == 128 && st.eye_samples == 576 * 16, "spp %d, %ld camera samples traced", st.spp, st.eye_samples);
    pds_image_free(&img);
    REQUIRE(t, rounds8_render(slant_floor_scene, PDS_PATHS_ALL, 2, &img, &st), "render");
    CHECK(t, st.spp == 128 && st.eye_samples == 576 * 16 * 15, "full image: spp %d, %ld camera samples traced", st.spp,
          st.eye_samples);
    pds_image_free(&img);
    REQUIRE(t, rounds8_render(slant_mirror_scene, PDS_PATHS_CAUSTICS_ONLY, 2, &img, &st), "render");
    REQUIRE(t, rounds8_render(slant_mirror_scene, PDS_PATHS_CAUSTICS_ONLY, 1, &img1, &st1), "render");
    later = (st.eye_samples - 576 * 16) / 16 / 7; /* the pixels each later round traced */
    CHECK(t, st.spp == 128 && st.eye_samples == 576 * 16 + 7 * 16 * later && later > 24 && later < 576 - 24,
          "mirror in view: %ld camera samples traced (%ld pixels a later round)", st.eye_samples, later);
    CHECK(t, st1.eye_samples == st.eye_samples && memcmp(img.rgb, img1.rgb, sizeof *img.rgb * 3 * 24 * 24) == 0,
          "1 and 2 threads differ");
    pds_image_free(&img);
    pds_image_free(&img1);
}

/* A photon budget left to the default (eye_rounds 0) takes one eye round
   every 1.5 w h spp photons (pds__budget_rounds; w h spp: a round's eye
   samples): on the 24 x 24 mirror at 16 samples a pixel (13,824 photons
   a round), 27,647 photons keep one eye pass, 27,648 take 2 and 41,472
   take 3 (reported as spp 48), the image the same as with --eye-rounds
   3 and as close to the analytic full image as one eye pass's. */
static void test_pds_photon_budget_takes_eye_rounds_in_proportion_to_its_photons(pds_test_ctx *t)
{
    pds_image one = {0, 0, NULL}, dflt = {0, 0, NULL}, three = {0, 0, NULL}, few = {0, 0, NULL};
    pds_render_stats st_one, st, st3, st_few;
    double e_one, e_dflt;
    CHECK(t, pds__budget_rounds(27647, 24, 24, 16) == 1 && pds__budget_rounds(27648, 24, 24, 16) == 2 &&
                 pds__budget_rounds(41472, 24, 24, 16) == 3 && pds__budget_rounds(0, 24, 24, 16) == 1 &&
                 pds__budget_rounds(LONG_MAX, 1, 1, 1) > 1000,
          "rounds %ld %ld %ld %ld", pds__budget_rounds(27647, 24, 24, 16), pds__budget_rounds(27648, 24, 24, 16),
          pds__budget_rounds(41472, 24, 24, 16), pds__budget_rounds(LONG_MAX, 1, 1, 1));
    REQUIRE(t, photon_render_text(mirror_scene, PDS_METHOD_PDS, 41472, 3.0, PDS_PATHS_ALL, 2, &one, &st_one, eye_rounds_1),
            "render");
    REQUIRE(t, photon_render_text(mirror_scene, PDS_METHOD_PDS, 41472, 3.0, PDS_PATHS_ALL, 2, &dflt, &st,
                                  eye_rounds_default),
            "render");
    REQUIRE(t, photon_render_text(mirror_scene, PDS_METHOD_PDS, 41472, 3.0, PDS_PATHS_ALL, 1, &three, &st3, eye_rounds_3),
            "render");
    REQUIRE(t, photon_render_text(mirror_scene, PDS_METHOD_PDS, 27647, 3.0, PDS_PATHS_ALL, 2, &few, &st_few,
                                  eye_rounds_default),
            "render");
    CHECK(t, st_one.spp == 16 && st.spp == 48 && st3.spp == 48 && st_few.spp == 16,
          "spp %d with one eye pass, %d by default, %d with 3 rounds, %d at 27,647 photons", st_one.spp, st.spp, st3.spp,
          st_few.spp);
    CHECK(t, memcmp(dflt.rgb, three.rgb, sizeof *dflt.rgb * 3 * 24 * 24) == 0, "the default's 3 rounds are not --eye-rounds 3");
    e_one = mirror_full_error(&one);
    e_dflt = mirror_full_error(&dflt);
    CHECK(t, e_dflt < 0.01 && e_dflt < 1.5 * e_one, "relative error %g by default, %g with one eye pass", e_dflt, e_one);
    pds_image_free(&one);
    pds_image_free(&dflt);
    pds_image_free(&three);
    pds_image_free(&few);
}

static void quarter_second_with_rounds(pds_options *o)
{
    progressive_small_passes_3000(o);
    o->time_s = 0.25;
}

/* Under a time budget progressive PDS traces eye rounds as the time goes
   (here the eye pass of 24 x 24 pixels costs far less than a pass of 3000
   photons, so there are several), and the direct light is the mean of
   theirs: the full image matches the analytic one (an image that kept the
   first eye pass's direct light but divided by the rounds' samples would be
   dark by their ratio). */
static void test_pds_time_budget_eye_rounds_keep_the_analytic_image(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    pds_render_stats st;
    double e;
    REQUIRE(t, photon_render_text(mirror_scene, PDS_METHOD_PDS, 100000, 3.0, PDS_PATHS_ALL, 2, &img, &st,
                                  quarter_second_with_rounds),
            "render");
    e = mirror_full_error(&img);
    CHECK(t, st.spp > 16 && st.spp % 16 == 0 && st.spp <= 16 * st.passes, "spp %d over %d passes", st.spp, st.passes);
    CHECK(t, e < 0.005, "relative error %g (%d passes, spp %d)", e, st.passes, st.spp);
    pds_image_free(&img);
}

/* Light tracing, the references' estimator (pds_render_light_traced):
   on the plane mirror's analytic caustic, with no kernel, the relative
   error is noise only and falls as photons are added, at least as 1/sqrt(N)
   from 125,000 to 2M photons (0.28 at 250,000, 0.033 at 4M, 0.011 at 16M:
   a bias would stop it); the same bits for 1 and 2 threads. */
static void test_light_traced_reference_meets_the_analytic_caustic(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = NULL;
    pds_options opt;
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL}, c = {0, 0, NULL};
    double e_small, e_large;
    REQUIRE(t, pds_scene_load_string(mirror_scene, "mirror.scene", &s, &err) == PDS_OK, "load: %s", err.text);
    pds_options_default(&opt);
    opt.photons = 125000;
    opt.threads = 2;
    REQUIRE(t, pds_render_light_traced(s, &opt, &a, &err) == PDS_OK, "render: %s", err.text);
    opt.threads = 1;
    REQUIRE(t, pds_render_light_traced(s, &opt, &b, &err) == PDS_OK, "render: %s", err.text);
    opt.threads = 2;
    opt.photons = 2000000;
    REQUIRE(t, pds_render_light_traced(s, &opt, &c, &err) == PDS_OK, "render: %s", err.text);
    e_small = mirror_caustic_error(&a);
    e_large = mirror_caustic_error(&c);
    CHECK(t, a.width == 24 && a.height == 24 && memcmp(a.rgb, b.rgb, sizeof *a.rgb * 3 * 24 * 24) == 0,
          "1 and 2 threads differ");
    CHECK(t, e_large < 0.08 && e_large < e_small / 4.0, "relative error %g at 125k photons, %g at 2M", e_small, e_large);
    pds_image_free(&a);
    pds_image_free(&b);
    pds_image_free(&c);
    pds_scene_free(s);
}

/* Sub-photons tile their parent's share of the emission domain: their
   starts and directions are the parent's moved by +-1/4 of its
   differentials (their mean is the parent), their differentials are half
   the parent's, the directional ones perpendicular to their own
   direction. */
static void test_pds_sub_photons_tile_the_parent(pds_test_ctx *t)
{
    pds__ray_diff r, q[4];
    pds__v3 mean = pds__v(0, 0, 0), dmean = pds__v(0, 0, 0);
    static const double at[4][2] = {{-0.25, -0.25}, {0.25, -0.25}, {-0.25, 0.25}, {0.25, 0.25}};
    int k;
    pds__photon_diff_init(&r, pds__v(1, 2, 3), pds__normalize(pds__v(0.2, -1, 0.1)), pds__v(0, -1, 0), 0.08, 0.05);
    for (k = 0; k < 4; k++) {
        q[k] = pds__sub_photon(&r, at[k][0], at[k][1]);
        mean = pds__add(mean, pds__scale(q[k].p, 0.25));
        dmean = pds__add(dmean, pds__scale(q[k].d, 0.25));
        CHECK(t, fabs(pds__length(q[k].dpdu) - 0.5 * pds__length(r.dpdu)) < 1e-12 &&
                     fabs(pds__length(q[k].dpdv) - 0.5 * pds__length(r.dpdv)) < 1e-12,
              "sub-photon %d: positional differentials %g %g of %g", k, pds__length(q[k].dpdu), pds__length(q[k].dpdv),
              pds__length(r.dpdu));
        CHECK(t, fabs(pds__dot(q[k].dddu, q[k].d)) < 1e-12 && fabs(pds__dot(q[k].dddv, q[k].d)) < 1e-12 &&
                     fabs(pds__length(q[k].dddu) - 0.025) < 1e-3,
              "sub-photon %d: directional differential %g, along d %g", k, pds__length(q[k].dddu),
              pds__dot(q[k].dddu, q[k].d));
    }
    CHECK(t, pds__length(pds__sub(mean, r.p)) < 1e-12, "mean start off by %g", pds__length(pds__sub(mean, r.p)));
    CHECK(t, pds__length(pds__sub(pds__normalize(dmean), r.d)) < 1e-6, "mean direction off by %g",
          pds__length(pds__sub(pds__normalize(dmean), r.d)));
    CHECK(t, pds__length(pds__sub(q[3].p, q[0].p)) > 0.0, "sub-photons start apart");
}

/* The mirror scene's photons all leave the point light with the same
   directional differential length d_i in pass i (eqs. 5-6: s_i over the
   light's 4 pi), s_i = 3 i^(-1/6) over the 20 passes of
   40960 photons, so d_i >= 0.6 d_1. Their direction's spread is d_i / 2
   (a plane mirror keeps it), a sub-photon's d_i / 4: split angle
   0.14 d_1 splits every photon once (d_i / 2 > 0.28 d_1) and no
   sub-photon (d_i / 4 < 0.28 d_1). */
static double split_angle_once;

static void split_every_photon(pds_options *o)
{
    progressive_small_passes(o);
    o->split_depth = 1;
    o->split_angle = split_angle_once;
}

static void split_never(pds_options *o)
{
    progressive_small_passes(o);
    o->split_depth = 0;
}

/* Splitting conserves flux and, where the optics is linear (a plane
   mirror), the four sub-photons' footprints cover their parent's: every
   photon split once gives the same caustic, within the noise, as no
   splitting, and both match the analytic one. */
static void test_pds_split_photons_carry_their_parents_flux(pds_test_ctx *t)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    pds_render_stats sa, sb;
    double ta = 0.0, tb = 0.0, cos_max;
    size_t i;
    pds_error err;
    pds_scene *s = scene_from_text(mirror_scene, &err);
    pds__target tg;
    pds__v3 axis;
    REQUIRE(t, s != NULL, "%s", err.text);
    tg = pds__specular_target(s);
    /* the light is inside the mirror's bounding sphere: it emits into all
       4 pi */
    REQUIRE(t, !pds__target_cone(&tg, pds__v(0, 1, 0), &axis, &cos_max), "the light is inside the target");
    split_angle_once = 0.14 * pds__photon_diff_length(3.0, 4.0 * PDS__PI, 2048.0);
    pds_scene_free(s);
    REQUIRE(t, photon_render_text(mirror_scene, PDS_METHOD_PDS, 40960, 3.0, PDS_PATHS_CAUSTICS_ONLY, 2, &a, &sa,
                                  split_every_photon),
            "render split");
    REQUIRE(t, photon_render_text(mirror_scene, PDS_METHOD_PDS, 40960, 3.0, PDS_PATHS_CAUSTICS_ONLY, 2, &b, &sb,
                                  split_never),
            "render unsplit");
    for (i = 0; i < (size_t)a.width * a.height * 3; i++) {
        ta += a.rgb[i];
        tb += b.rgb[i];
    }
    /* a few sub-photons of photons at the mirror's edges miss it */
    CHECK(t, sb.split == 0 && sa.split >= sb.splatted && sa.splatted > 4 * sb.splatted * 0.94 &&
                 sa.splatted <= 4 * sb.splatted && sa.splatted <= 4 * sa.split,
          "split %ld photons into %ld splats (unsplit: %ld splats)", sa.split, sa.splatted, sb.splatted);
    CHECK(t, fabs(ta / tb - 1.0) < 0.01, "image total split %g, unsplit %g", ta, tb);
    CHECK(t, mirror_caustic_error(&a) < 0.05 && mirror_caustic_error(&b) < 0.05, "error split %g, unsplit %g",
          mirror_caustic_error(&a), mirror_caustic_error(&b));
    pds_image_free(&a);
    pds_image_free(&b);
}

/* pds__kernel_over_pixel against a fine midpoint rule over the pixel's
   parallelogram: within 1% of the kernel's peak for pixels small against
   the footprint (the moment-matched evaluation) and within 4% for pixels
   up to half the footprint's radius (the 4 x 4 rule); and the average over
   any pixel carries the kernel's whole weight (its integral over the
   footprint's plane is 1, as the kernel's is). */
static void test_pds_kernel_averaged_over_a_pixel_matches_fine_quadrature(pds_test_ctx *t)
{
    static const double cases[][6] = {
        /* u, m1, m2 */
        {0.0, 0.0, 0.05, 0.0, 0.0, 0.05},   {0.5, 0.3, 0.1, 0.02, -0.03, 0.08}, {0.9, 0.1, 0.12, 0.0, 0.0, 0.12},
        {0.2, -0.7, 0.3, 0.1, 0.0, 0.25},   {0.95, 0.2, 0.5, 0.0, 0.1, 0.45},   {0.0, 0.0, 0.2, 0.2, -0.2, 0.2},
        {1.1, 0.0, 0.3, 0.0, 0.0, 0.3},     {0.4, 0.4, 2.0, 0.0, 0.0, 1.5},
    };
    const double peak = 3.0 / PDS__PI;
    size_t c;
    int i, j, n = 400;
    double u0[2] = {0.3, -0.4}, z[2] = {0.0, 0.0};
    CHECK(t, pds__kernel_over_pixel(u0, z, z) == pds__kernel_silverman(0.25), "a point pixel is the kernel");
    {
        /* the 4 x 4 rule's points reach 3/4 of the half-axes: a thin pixel
           whose outermost point lies just inside the disc (u + 3/4 (m1 +
           m2) = (0.99, 0.0075)) is lit, one whose points all lie outside
           is not */
        double mt1[2] = {0.4, 0.0}, mt2[2] = {0.4, 0.01}, in[2] = {1.59, 0.0}, out[2] = {1.61, 0.0};
        CHECK(t, pds__kernel_over_pixel(in, mt1, mt2) > 0.0, "the pixel's outermost point inside: %g",
              pds__kernel_over_pixel(in, mt1, mt2));
        CHECK(t, pds__kernel_over_pixel(out, mt1, mt2) == 0.0, "every point outside: %g",
              pds__kernel_over_pixel(out, mt1, mt2));
    }
    for (c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        const double *q = cases[c];
        double u[2] = {q[0], q[1]}, m1[2] = {q[2], q[3]}, m2[2] = {q[4], q[5]}, fine = 0.0, got, tol;
        double l = fmax(sqrt(m1[0] * m1[0] + m1[1] * m1[1]), sqrt(m2[0] * m2[0] + m2[1] * m2[1]));
        for (i = 0; i < n; i++)
            for (j = 0; j < n; j++) {
                double a = (2.0 * i + 1.0) / n - 1.0, b = (2.0 * j + 1.0) / n - 1.0;
                double x = u[0] + a * m1[0] + b * m2[0], y = u[1] + a * m1[1] + b * m2[1];
                fine += pds__kernel_silverman(x * x + y * y);
            }
        fine /= (double)n * n;
        got = pds__kernel_over_pixel(u, m1, m2);
        tol = l <= 0.125 ? 0.01 * peak : l <= 0.5 ? 0.04 * peak : 0.25 * fine + 0.02 * peak;
        CHECK(t, fabs(got - fine) <= tol, "case %zu: %g, fine quadrature %g", c, got, fine);
    }
    for (c = 0; c < 4; c++) {
        static const double px[4][4] = {{0.05, 0.0, 0.0, 0.05}, {0.3, 0.1, -0.1, 0.2}, {1.0, 0.0, 0.0, 0.2},
                                         {2.0, 0.5, 0.0, 2.0}};
        double m1[2] = {px[c][0], px[c][1]}, m2[2] = {px[c][2], px[c][3]}, sum = 0.0, h = 0.01;
        double reach = 1.0 + fabs(m1[0]) + fabs(m1[1]) + fabs(m2[0]) + fabs(m2[1]);
        int m = (int)ceil(reach / h);
        for (i = -m; i < m; i++)
            for (j = -m; j < m; j++) {
                double u[2] = {(i + 0.5) * h, (j + 0.5) * h};
                sum += pds__kernel_over_pixel(u, m1, m2) * h * h;
            }
        CHECK(t, fabs(sum - 1.0) < 0.005, "pixel %zu: the average's integral %g, not 1", c, sum);
    }
}

/* The merge tests' camera: 64 x 48 pixels, 40 degrees, looking down at
   the origin from (0, 2, 3). */
static pds__camera_frame merge_test_camera(void)
{
    pds_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position = (pds_vec3){0.0, 2.0, 3.0};
    cam.look_at = (pds_vec3){0.0, 0.0, 0.0};
    cam.up = (pds_vec3){0.0, 1.0, 0.0};
    cam.fov_deg = 40.0;
    cam.width = 64;
    cam.height = 48;
    return pds__camera_setup(&cam, 64, 48);
}

/* pds__eye_merge: four samples of one pixel on a floor seen straight from
   the camera become one vertex carrying their summed importance and
   weight at the pixel's centre on the floor (not at their weighted
   centroid, which the samples' jitter moves about: the box filter's
   window is the pixel), with the pixel's half-axes on the floor (the
   corner rays' hits lie at centre +- px +- py); two seen through
   something (their wo does not point at the camera), one of another
   material, stay apart. */
static void test_pds_eye_merge_sums_a_pixels_samples_at_the_pixels_centre(pds_test_ctx *t)
{
    pds__camera_frame f;
    pds__eye_vertex v[6];
    pds__v3 up = pds__v(0.0, 1.0, 0.0), centre, ex, ey;
    double wsum = 0.0, cx = 0.0, cz = 0.0;
    int k, c, px = 37, py = 21;
    size_t n;
    f = merge_test_camera();
    memset(v, 0, sizeof v);
    for (k = 0; k < 6; k++) {
        /* samples jittered in the 2x2 strata; the floor y = 0 */
        double sx = px + 0.1 + 0.5 * (k % 2) + 0.07 * k, sy = py + 0.4 + 0.5 * ((k / 2) % 2) - 0.05 * k;
        pds__v3 d = pds__camera_dir(&f, sx, sy), x = pds__add(f.origin, pds__scale(d, -f.origin.y / d.y));
        double beta[3] = {0.25, 0.25 * (1 + k), 0.25};
        pds_material m;
        memset(&m, 0, sizeof m);
        m.type = PDS_MAT_DIFFUSE;
        m.albedo[0] = m.albedo[1] = m.albedo[2] = 0.5;
        REQUIRE(t, pds__eye_vertex_set(&v[k], &m, x, up, up, pds__scale(d, -1.0), beta, k == 4 ? 1 : 0),
                "vertex %d", k);
        v[k].pixel = py * 64 + px;
        if (k < 4) {
            double w = v[k].weight[0] + v[k].weight[1] + v[k].weight[2];
            wsum += w;
            cx += w * x.x;
            cz += w * x.z;
        }
    }
    /* the fifth and sixth see the floor through something (the fifth of
       another material): their wo is turned; the four camera samples
       each saw the floor directly */
    pds__f3_set(v[4].wo, pds__normalize(pds__v(-0.2, 1.0, 0.3)));
    pds__f3_set(v[5].wo, pds__normalize(pds__v(0.3, 1.0, 0.2)));
    n = pds__eye_merge(v, 6, &f, 4);
    REQUIRE(t, n == 3, "%zu vertices left, want 3", n);
    CHECK(t, v[0].material == 0 && fabs(v[0].importance[1] - 0.25 * (1 + 2 + 3 + 4)) < 1e-6 &&
                 fabs(v[0].importance[0] - 1.0) < 1e-6 && fabs(v[0].weight[1] - 0.5 / PDS__PI * 2.5) < 1e-6,
          "merged importance %g %g, weight %g", v[0].importance[0], v[0].importance[1], v[0].weight[1]);
    {
        pds__v3 d = pds__camera_dir(&f, px + 0.5, py + 0.5), want = pds__add(f.origin, pds__scale(d, -f.origin.y / d.y));
        double off = hypot(cx / wsum - want.x, cz / wsum - want.z);
        CHECK(t, off > 0.05 * pds__length(pds__sub(want, f.origin)) * f.tan_half_fov / f.height,
              "the samples' centroid should lie off the pixel's centre (by %g)", off);
        CHECK(t, fabs(v[0].pos[0] - want.x) < 1e-6 && fabs(v[0].pos[2] - want.z) < 1e-6 && fabs(v[0].pos[1]) < 1e-6,
              "merged at %g %g %g, want the pixel's centre %g 0 %g (the centroid: %g 0 %g)", v[0].pos[0], v[0].pos[1],
              v[0].pos[2], want.x, want.z, cx / wsum, cz / wsum);
    }
    CHECK(t, v[1].px[0] == 0.0f && v[2].px[0] == 0.0f && v[1].py[2] == 0.0f && v[2].py[2] == 0.0f,
          "the unmerged vertices have no pixel axes");
    CHECK(t, (v[1].material == 1) != (v[2].material == 1), "the other material's sample is kept");
    /* the pixel's corners on the floor against centre +- px +- py, the axes
       taken at the pixel's centre */
    {
        pds__v3 d = pds__camera_dir(&f, px + 0.5, py + 0.5);
        centre = pds__add(f.origin, pds__scale(d, -f.origin.y / d.y));
        REQUIRE(t, pds__pixel_axes(&f, centre, up, &ex, &ey), "pixel axes");
        for (k = 0; k < 8; k++) {
            /* the corners, then the points halfway to them: the error of
               the linear map is of second order, a quarter there */
            double sc = k < 4 ? 1.0 : 0.5, a = (k % 2 ? 1.0 : -1.0) * sc, b = ((k / 2) % 2 ? 1.0 : -1.0) * sc;
            pds__v3 dc = pds__camera_dir(&f, px + 0.5 + 0.5 * a, py + 0.5 - 0.5 * b);
            pds__v3 hit = pds__add(f.origin, pds__scale(dc, -f.origin.y / dc.y));
            pds__v3 lin = pds__add(centre, pds__add(pds__scale(ex, a), pds__scale(ey, b)));
            CHECK(t, pds__length(pds__sub(hit, lin)) < (k < 4 ? 0.04 : 0.01) * pds__length(ex), "corner %d off by %g (axis %g)", k,
                  pds__length(pds__sub(hit, lin)), pds__length(ex));
        }
        for (c = 0; c < 3; c++) {
            CHECK(t, fabs(v[0].px[c] - pds__v3_get(ex, c)) < 0.01 * pds__length(ex),
                  "merged px[%d] %g, at the centre %g", c, v[0].px[c], pds__v3_get(ex, c));
        }
    }
}

/* pds__eye_merge at a silhouette: a pixel whose four camera samples saw
   the floor merges them into one vertex for the whole pixel; if one of
   the four saw something else (an object's edge in front of the floor),
   the three floor samples stay apart, since a merged vertex would average
   the kernel over the whole pixel's floor, most of it unseen. (On the
   demo's gold ring, merging such pixels lost 17% of the thin caustic along
   its rim.) */
static void test_pds_eye_merge_keeps_a_partly_covered_pixels_samples(pds_test_ctx *t)
{
    pds__camera_frame f = merge_test_camera();
    pds__eye_vertex v[4];
    pds__v3 up = pds__v(0.0, 1.0, 0.0);
    pds_material floor_m, edge_m;
    int k, pass, px = 20, py = 30;
    memset(&floor_m, 0, sizeof floor_m);
    floor_m.type = PDS_MAT_DIFFUSE;
    floor_m.albedo[0] = floor_m.albedo[1] = floor_m.albedo[2] = 0.5;
    edge_m = floor_m;
    for (pass = 0; pass < 2; pass++) {
        size_t n;
        memset(v, 0, sizeof v);
        for (k = 0; k < 4; k++) {
            double sx = px + 0.25 + 0.5 * (k % 2), sy = py + 0.25 + 0.5 * (k / 2), beta[3] = {0.25, 0.25, 0.25};
            pds__v3 d = pds__camera_dir(&f, sx, sy), x = pds__add(f.origin, pds__scale(d, -f.origin.y / d.y));
            /* pass 1: the last sample meets an object's face 0.5 before the floor */
            int edge = pass == 1 && k == 3;
            if (edge) x = pds__sub(x, pds__scale(d, 0.5));
            REQUIRE(t, pds__eye_vertex_set(&v[k], edge ? &edge_m : &floor_m, x, edge ? pds__scale(d, -1.0) : up,
                                           edge ? pds__scale(d, -1.0) : up, pds__scale(d, -1.0), beta, edge ? 1 : 0),
                    "vertex %d", k);
            v[k].pixel = py * 64 + px;
        }
        n = pds__eye_merge(v, 4, &f, 4);
        if (pass == 0) {
            CHECK(t, n == 1 && fabs(v[0].importance[0] - 1.0) < 1e-6 && v[0].px[0] != 0.0f,
                  "a covered pixel: %zu vertices left, want 1 with the pixel's axes", n);
        } else {
            CHECK(t, n == 4, "a partly covered pixel: %zu vertices left, want all 4", n);
            for (k = 0; k < (int)n; k++)
                CHECK(t, v[k].px[0] == 0.0f && v[k].px[2] == 0.0f && fabs(v[k].importance[0] - 0.25) < 1e-6,
                      "vertex %d was merged", k);
        }
    }
}

/* pds__defocus_widen: a photon from a point light (no positional
   differential, directional ones of length 0.01) that travelled 2 units
   has the unfocused cross-section 0.01^2 x 2^2 = 4e-4. Landing straight
   down on a floor as a needle of semi-axes a = 0.2, b = 0.005
   (cross-section 4e-3, m = 10, past the 1 / 0.15 that makes it round) it
   becomes round; as a needle a = 0.04, b = 0.005 (8e-4, m = 2) its aspect
   becomes 0.15 m = 0.3; either way its area becomes the geometric mean of
   the needle's (pi a b) and the needle's widened to that aspect at its
   own length (pi q a^2), its major axis staying along the needle's. As a
   focused needle a = 0.01, b = 0.001 (4e-5, m = 0.1) it keeps its shape. */
static void test_pds_defocused_needles_widen_and_focused_ones_do_not(pds_test_ctx *t)
{
    static const double cases[3][3] = {{0.4, 0.01, 1.0}, {0.08, 0.01, 0.3}, {0.02, 0.002, 0.1}};
    pds__photon_job job;
    pds__ray_diff start, r;
    pds__v3 ng = pds__v(0.0, 1.0, 0.0);
    int k;
    memset(&job, 0, sizeof job);
    job.min_aspect = 0.15;
    memset(&start, 0, sizeof start);
    start.d = pds__v(0.0, -1.0, 0.0);
    start.dddu = pds__v(0.01, 0.0, 0.0);
    start.dddv = pds__v(0.0, 0.0, 0.01);
    for (k = 0; k < 3; k++) {
        double a = 0.5 * cases[k][0], b = 0.5 * cases[k][1], q = cases[k][2], major, aniso, area, want;
        memset(&r, 0, sizeof r);
        r.d = pds__v(0.0, -1.0, 0.0);
        r.dpdu = pds__v(cases[k][0], 0.0, 0.0);
        r.dpdv = pds__v(0.0, 0.0, cases[k][1]);
        pds__defocus_widen(&job, &start, 2.0, ng, &r);
        major = pds__footprint_major_axis(r.dpdu, r.dpdv);
        aniso = pds__footprint_anisotropy(r.dpdu, r.dpdv);
        area = 0.25 * pds__length(pds__cross(r.dpdu, r.dpdv)); /* semi-axes' product */
        want = k < 2 ? sqrt(a * b * q * a * a) : a * b;
        CHECK(t, fabs(aniso - q) < 1e-9, "case %d: minor / major %g, want %g", k, aniso, q);
        CHECK(t, fabs(area - want) < 1e-12 * want + 1e-15, "case %d: area / pi %g, want %g", k, area, want);
        CHECK(t, fabs(major - sqrt(want / q)) < 1e-12, "case %d: major semi-axis %g, want %g", k, major, sqrt(want / q));
        CHECK(t, fabs(r.dpdu.y) + fabs(r.dpdu.z) < 1e-15 * fabs(r.dpdu.x), "case %d: the major axis turned", k);
    }
}

/* pds__eye_merge for samples seen through something (their wo does not
   point at the camera): four at the corners of a 2a x 2b rectangle on the
   floor, well inside a pixel's width, merge at its centre, and the
   pixel's half-axes are sqrt(3) times their standard deviations (a box of
   half-axis h has variance h^2 / 3) along the rectangle's sides. */
static void test_pds_eye_merge_takes_the_spread_of_samples_seen_through_glass(pds_test_ctx *t)
{
    pds__camera_frame f;
    pds__eye_vertex v[4];
    pds__v3 up = pds__v(0.0, 1.0, 0.0), c0 = pds__v(0.3, 0.0, -0.2), wo = pds__normalize(pds__v(0.5, 1.0, 0.1));
    pds_material mat;
    double wpix, a, b, beta[3] = {0.2, 0.2, 0.2}, ax, ay;
    int k;
    size_t n;
    f = merge_test_camera();
    wpix = 2.0 * pds__length(pds__sub(c0, f.origin)) * f.tan_half_fov / 48.0;
    a = 0.2 * wpix;
    b = 0.1 * wpix;
    memset(&mat, 0, sizeof mat);
    memset(v, 0, sizeof v); /* lambda 0: RGB vertices */
    mat.type = PDS_MAT_DIFFUSE;
    mat.albedo[0] = mat.albedo[1] = mat.albedo[2] = 0.5;
    for (k = 0; k < 4; k++) {
        pds__v3 x = pds__add(c0, pds__v(k % 2 ? a : -a, 0.0, k / 2 ? b : -b));
        REQUIRE(t, pds__eye_vertex_set(&v[k], &mat, x, up, up, wo, beta, 0), "vertex %d", k);
    }
    n = pds__eye_merge(v, 4, &f, 4);
    REQUIRE(t, n == 1, "%zu vertices left, want 1", n);
    CHECK(t, pds__length(pds__sub(pds__f3_get(v[0].pos), c0)) < 1e-9 * wpix + 1e-7, "merged at the centre");
    CHECK(t, fabs(v[0].importance[0] - 0.8) < 1e-6, "importance %g", v[0].importance[0]);
    ax = pds__length(pds__f3_get(v[0].px));
    ay = pds__length(pds__f3_get(v[0].py));
    CHECK(t, fabs(fmax(ax, ay) - sqrt(3.0) * a) < 1e-4 * wpix && fabs(fmin(ax, ay) - sqrt(3.0) * b) < 1e-4 * wpix,
          "half-axes %g %g, want %g %g", ax, ay, sqrt(3.0) * a, sqrt(3.0) * b);
    CHECK(t, fabs(ax > ay ? v[0].px[0] : v[0].py[0]) > 0.999 * fmax(ax, ay), "the longer axis runs along x");
}

/* The splat tests' job and thread buffer: the eye map `map` seen by the
   camera f, pixel sums `sum` at 2^40 units, nothing else switched on. */
static void splat_test_job(pds__photon_job *job, pds__splat_buf *buf, const pds__eye_map *map, pds__camera_frame f,
                           pds__sum128 *sum)
{
    memset(job, 0, sizeof *job);
    job->map = map;
    job->frame = f;
    job->eye = f.origin;
    job->plane_tolerance = 0.25;
    memset(buf, 0, sizeof *buf);
    buf->sum = sum;
    buf->unit = 1099511627776.0; /* 2^40 */
}

/* A diffuse white of albedo 0.6. */
static pds_material splat_test_floor(void)
{
    pds_material m;
    memset(&m, 0, sizeof m);
    m.type = PDS_MAT_DIFFUSE;
    m.albedo[0] = m.albedo[1] = m.albedo[2] = 0.6;
    return m;
}

/* pds__splat through the two trees of the eye-path map (pds__eye_map_build)
   against brute force over every vertex: 300 Lambertian vertices scattered
   on the floor y = 0 around a needle footprint and 60 on a shelf 0.035
   above it, a third of each merged (their pixels three times the camera's
   there, so the kernel is averaged over them). Each vertex must get pi K
   w Ep exactly as a loop over all of them gives it: single samples the
   kernel at their point, merged ones its average over their pixel, and
   none on the shelf, which is beyond the footprint's own guard slab
   (0.25 of its major semi-axis 0.1): a query grown by the merged pixels
   must not thicken it. */
static void test_pds_splat_finds_single_and_merged_vertices_as_brute_force_does(pds_test_ctx *t)
{
    enum { NV = 360 };
    pds__camera_frame f = merge_test_camera();
    pds__eye_vertex *v = (pds__eye_vertex *)calloc(NV, sizeof *v);
    pds__eye_vertex *orig = (pds__eye_vertex *)calloc(NV, sizeof *orig);
    pds__sum128 *sum = (pds__sum128 *)calloc(3 * NV, sizeof *sum);
    pds__photon_job job;
    pds__splat_buf buf;
    pds__eye_map map;
    pds__ray_diff r;
    pds__v3 up = pds__v(0.0, 1.0, 0.0);
    pds_material m;
    double flux[3] = {1.0, 2.0, 3.0}, beta[3] = {0.5, 0.5, 0.5}, M0[2][3], ap, tol, worst = 0.0;
    double got_single, got_merged;
    int i, c, fp, lit = 0, lit_merged = 0;
    REQUIRE(t, v && orig && sum, "memory");
    m = splat_test_floor();
    for (i = 0; i < NV; i++) {
        double a = pds__rng_uniform(7, 1, (uint64_t)i, 0), b = pds__rng_uniform(7, 1, (uint64_t)i, 1);
        pds__v3 x = pds__v(-0.16 + 0.32 * a, i < 300 ? 0.0 : 0.035, -0.06 + 0.12 * b), ex, ey;
        REQUIRE(t, pds__eye_vertex_set(&v[i], &m, x, up, up, pds__normalize(pds__sub(f.origin, x)), beta, 0),
                "vertex %d", i);
        v[i].pixel = i;
        if (i % 3 == 0) {
            REQUIRE(t, pds__pixel_axes(&f, x, up, &ex, &ey), "pixel axes");
            pds__f3_set(v[i].px, pds__scale(ex, 1.4));
            pds__f3_set(v[i].py, pds__scale(ey, 1.4));
        }
        orig[i] = v[i];
    }
    memset(&map, 0, sizeof map);
    map.v = v;
    map.n = NV;
    REQUIRE(t, pds__eye_map_build(&map, 0, 0, NULL, 1, NULL) == PDS_OK, "eye map");
    CHECK(t, map.n_single == 240 && map.merged.n == 120, "%zu single and %zu merged vertices, want 240 and 120",
          map.n_single, map.merged.n);
    splat_test_job(&job, &buf, &map, f, sum);
    for (fp = 0; fp < 2; fp++) {
        memset(&r, 0, sizeof r);
        r.p = pds__v(0.01, 0.0, 0.005);
        r.d = pds__v(0.0, -1.0, 0.0);
        /* a needle, then a round footprint 5 pixels across */
        r.dpdu = fp == 0 ? pds__v(0.19, 0.0, 0.06) : pds__v(0.1, 0.0, 0.0);
        r.dpdv = fp == 0 ? pds__v(-0.004, 0.0, 0.0127) : pds__v(0.0, 0.0, 0.1);
        memset(sum, 0, 3 * NV * sizeof *sum);
        lit = lit_merged = 0;
        worst = 0.0;
        buf.e_single = buf.e_merged = 0.0;
        got_single = got_merged = 0.0;
        pds__splat(&job, &buf, &r, up, flux, 0.0, 0);
        REQUIRE(t, pds__filter_matrix(r.dpdu, r.dpdv, up, M0), "filter matrix");
        ap = pds__footprint_area(r.dpdu, r.dpdv);
        tol = 0.25 * pds__footprint_major_axis(r.dpdu, r.dpdv);
        for (i = 0; i < NV; i++) {
            const pds__eye_vertex *o = &orig[i];
            pds__v3 d = pds__sub(pds__f3_get(o->pos), r.p);
            double u[2], m1[2], m2[2], k = 0.0;
            int j;
            for (j = 0; j < 2; j++) {
                pds__v3 row = pds__v(M0[j][0], M0[j][1], M0[j][2]);
                u[j] = pds__dot(row, d);
                m1[j] = pds__dot(row, pds__f3_get(o->px));
                m2[j] = pds__dot(row, pds__f3_get(o->py));
            }
            if (fabs(pds__dot(d, up)) <= tol) k = pds__kernel_over_pixel(u, m1, m2);
            if (k > 0.0) {
                lit++;
                lit_merged += i % 3 == 0;
            }
            for (c = 0; c < 3; c++) {
                double want = PDS__PI * k * o->weight[c] * flux[c] / ap;
                double got = pds__sum128_value(sum[3 * i + c]) / buf.unit;
                worst = fmax(worst, fabs(got - want) / (1e-9 + fabs(want)));
                if (i % 3 == 0)
                    got_merged += got;
                else
                    got_single += got;
            }
        }
        CHECK(t, worst < 1e-6, "footprint %d: a vertex's splat is %g off brute force (relative)", fp, worst);
        /* the light counted as splatted into single and merged vertices
           (pds__eye_round_ratio's shares) is what their pixels got */
        CHECK(t, fabs(buf.e_single - got_single) <= 1e-6 * got_single && fabs(buf.e_merged - got_merged) <= 1e-6 * got_merged,
              "footprint %d: counted %g single and %g merged, the pixels got %g and %g", fp, buf.e_single,
              buf.e_merged, got_single, got_merged);
        CHECK(t, lit > 30 && lit_merged > 10, "footprint %d reaches %d vertices, %d merged: too few for a test", fp,
              lit, lit_merged);
    }
    pds__eye_map_free_index(&map);
    free(v);
    free(orig);
    free(sum);
}

/* The whole pixels' kernel (pds__pixel_kernel_at, what a splat adds to a
   pixel seen whole) against pds__kernel_over_pixel with each pixel's own
   half-axes, those pds__eye_merge gives its vertex (pds__pixel_axes at
   its centre ray's point on the floor): 300 footprints on the floor of
   the merge tests' camera, round to needles 100:1, 0.5 to 12 pixels
   across, every pixel whose centre ray meets the floor. Where the pixel
   takes the rule (moment-matched, or n1 x n2 midpoints) the pixel where
   the photon landed takes, the two agree to 1e-9 of the kernel's peak;
   where a pixel of another size would take another rule, within the
   rules' difference (1% of the peak); and no pixel that its own
   average lights is left at 0 unless it is more than 1.5 times the
   photon's pixel (the query's own margin). */
static void test_pds_whole_pixel_kernel_is_each_pixels_own_average(pds_test_ctx *t)
{
    enum { W = 64, H = 48 };
    pds__camera_frame f = merge_test_camera();
    pds__v3 up = pds__v(0.0, 1.0, 0.0);
    size_t q, same = 0, other = 0, bad_same = 0, bad_other = 0, skipped = 0, lit = 0;
    double worst_same = 0.0, worst_other = 0.0, peak = 3.0 / PDS__PI;
    for (q = 0; q < 300; q++) {
        uint64_t sd = 977;
        double px = 4.0 + (W - 8) * pds__rng_uniform(sd, PDS__RNG_TEST, q, 1);
        double py = 4.0 + (H - 8) * pds__rng_uniform(sd, PDS__RNG_TEST, q, 2);
        double aspect = pow(10.0, -2.0 * pds__rng_uniform(sd, PDS__RNG_TEST, q, 3));
        double across = 0.5 * pow(24.0, pds__rng_uniform(sd, PDS__RNG_TEST, q, 4)); /* pixels */
        double ang = PDS__PI * pds__rng_uniform(sd, PDS__RNG_TEST, q, 5), M[2][3], major, l0;
        pds__v3 dir = pds__camera_dir(&f, px, py), c, ex, ey;
        pds__pixel_kernel pk;
        int x, y, j;
        c = pds__add(f.origin, pds__scale(dir, -f.origin.y / dir.y));
        REQUIRE(t, pds__pixel_axes(&f, c, up, &ex, &ey), "footprint %zu off the floor", q);
        REQUIRE(t, tkd_footprint(up, across * pds__length(ex), aspect, ang, M, &major), "filter matrix");
        pds__pixel_kernel_init(&pk, (const double(*)[3])M, &f, c, ex, ey, 1);
        REQUIRE(t, pk.kind != 0, "footprint %zu: no pixel average", q);
        {
            double m1[2], m2[2];
            for (j = 0; j < 2; j++) {
                m1[j] = M[j][0] * ex.x + M[j][1] * ex.y + M[j][2] * ex.z;
                m2[j] = M[j][0] * ey.x + M[j][1] * ey.y + M[j][2] * ey.z;
            }
            l0 = sqrt(m1[0] * m1[0] + m1[1] * m1[1]) + sqrt(m2[0] * m2[0] + m2[1] * m2[1]);
        }
        for (y = 0; y < H; y++)
            for (x = 0; x < W; x++) {
                pds__v3 d3 = pds__camera_dir(&f, x + 0.5, y + 0.5), p, pex, pey;
                double d[3], u[2], m1[2], m2[2], l1, l2, want, got, err;
                int n1, n2, rule, rule0;
                if (!(d3.y < 0.0)) continue;
                p = pds__add(f.origin, pds__scale(d3, -f.origin.y / d3.y));
                if (!pds__pixel_axes(&f, p, up, &pex, &pey)) continue;
                d[0] = p.x - c.x;
                d[1] = p.y - c.y;
                d[2] = p.z - c.z;
                for (j = 0; j < 2; j++) {
                    u[j] = M[j][0] * d[0] + M[j][1] * d[1] + M[j][2] * d[2];
                    m1[j] = M[j][0] * pex.x + M[j][1] * pex.y + M[j][2] * pex.z;
                    m2[j] = M[j][0] * pey.x + M[j][1] * pey.y + M[j][2] * pey.z;
                }
                want = pds__kernel_over_pixel(u, m1, m2);
                got = pds__pixel_kernel_at(&pk, d, u);
                l1 = sqrt(m1[0] * m1[0] + m1[1] * m1[1]);
                l2 = sqrt(m2[0] * m2[0] + m2[1] * m2[1]);
                n1 = pds__pixel_points(l1);
                n2 = pds__pixel_points(l2);
                rule = n1 <= 1 && n2 <= 1 ? 0 : (n1 < 1 ? 1 : n1) * 8 + (n2 < 1 ? 1 : n2);
                rule0 = pk.n1 <= 1 && pk.n2 <= 1 ? 0 : (pk.n1 < 1 ? 1 : pk.n1) * 8 + (pk.n2 < 1 ? 1 : pk.n2);
                if (want == 0.0 && got == 0.0) continue;
                if (want > 0.0) lit++;
                if (want > 0.0 && got == 0.0) {
                    if (l1 + l2 <= 1.5 * l0) skipped++;
                    continue;
                }
                err = fabs(got - want) / peak;
                if (rule == rule0) {
                    same++;
                    if (err > worst_same) worst_same = err;
                    bad_same += err > 1e-9;
                } else {
                    other++;
                    if (err > worst_other) worst_other = err;
                    bad_other += err > 0.01;
                }
            }
    }
    CHECK(t, lit > 1000 && same > 4 * other && other > 0, "coverage: %zu lit, %zu same rule, %zu another", lit,
          same, other);
    CHECK(t, bad_same == 0, "%zu pixels of the photon's rule differ from their own average (worst %.3g of the peak)",
          bad_same, worst_same);
    CHECK(t, bad_other == 0, "%zu pixels of another rule beyond 1%% of the peak (worst %.3g)", bad_other,
          worst_other);
    CHECK(t, skipped == 0, "%zu pixels lit by their own average were left dark", skipped);
}

/* pds__grid_range_ellipse: the whole pixels' vertices (pds__eye_map_build's
   third part) a splat's query finds through the image are exactly those
   their tree finds (pds__kdtree_range_ellipse, itself tested against brute
   force): each index once, with the same |M d|^2 bit for bit. The camera
   sees a floor y = 0 and, for x > 0.2, a step 0.03 above it (vertices the
   slab must leave out or take, depending on its thickness); every
   seventh pixel's vertex is merged but not whole and must go to the
   second part, not the grid; every fifth lies near a corner of its pixel
   rather than on its centre ray (then again with every vertex on its
   centre ray, where each row's band is thin: pds__eye_map_build's
   grid_slack). 400 footprints from round to needles 1000:1
   at random angles, lying on the floor or tilted up to 0.4 rad (an
   oblique slab), 0.005 to 0.4 across. A query whose box reaches behind
   the camera is left to the tree (0, nothing reported). */
static void whole_pixels_grid_against_tree(pds_test_ctx *t, int corners)
{
    enum { W = 64, H = 48 };
    pds__camera_frame f = merge_test_camera();
    pds__eye_vertex *v = (pds__eye_vertex *)calloc(W * H, sizeof *v);
    pds__v3 up = pds__v(0.0, 1.0, 0.0);
    pds_material m = splat_test_floor();
    double beta[3] = {0.5, 0.5, 0.5};
    pds__eye_map map;
    tkd_hits hg, hk;
    size_t n = 0, merged_other = 0, q, i, bad = 0, hits = 0, needles = 0;
    int x, y, refused = 0;
    REQUIRE(t, v && tkd_hits_alloc(&hg, W * H) && tkd_hits_alloc(&hk, W * H), "memory");
    for (y = 0; y < H; y++)
        for (x = 0; x < W; x++) {
            /* at the centre ray, as pds__eye_merge puts it; a fifth near
               a corner (its samples' mean, where the centre ray grazes) */
            int corner = corners && (x + y) % 5 == 0;
            pds__v3 d = pds__camera_dir(&f, x + (corner ? 0.02 : 0.5), y + (corner ? 0.97 : 0.5)), p, ex, ey;
            double tf = -f.origin.y / d.y, h;
            if (!(tf > 0.0)) continue;
            p = pds__add(f.origin, pds__scale(d, tf));
            h = p.x > 0.2 ? 0.03 : 0.0;
            p = pds__add(f.origin, pds__scale(d, (h - f.origin.y) / d.y));
            if (!pds__pixel_axes(&f, p, up, &ex, &ey)) continue;
            REQUIRE(t, pds__eye_vertex_set(&v[n], &m, p, up, up, pds__normalize(pds__sub(f.origin, p)), beta, 0),
                    "vertex %d %d", x, y);
            v[n].pixel = y * W + x;
            pds__f3_set(v[n].px, ex);
            pds__f3_set(v[n].py, ey);
            v[n].whole = (y * W + x) % 7 != 0;
            merged_other += !v[n].whole;
            n++;
        }
    memset(&map, 0, sizeof map);
    map.v = v;
    map.n = n;
    REQUIRE(t, pds__eye_map_build(&map, W, H, &f, 2, NULL) == PDS_OK, "eye map");
    CHECK(t, map.n_single == 0 && map.merged.n == merged_other && map.whole.n == n - merged_other,
          "parts %zu / %zu / %zu, want 0 / %zu / %zu", map.n_single, map.merged.n, map.whole.n, merged_other,
          n - merged_other);
    for (i = map.n_whole; i < n; i++)
        if (!map.v[i].whole || map.grid[map.v[i].pixel] != (int)(i - map.n_whole)) bad++;
    CHECK(t, bad == 0, "%zu whole vertices not in their pixel of the grid", bad);
    /* the rows' bands: a pixel wide with vertices near its corners, none
       where every vertex is on its centre ray */
    CHECK(t, corners ? map.grid_slack > 0.45 && map.grid_slack <= 0.5 : map.grid_slack < 1e-4,
          "grid slack %.3g pixels", map.grid_slack);
    bad = 0;
    for (q = 0; q < 400; q++) {
        uint64_t sd = 4242;
        double tilt = q % 2 ? 0.4 * pds__rng_uniform(sd, PDS__RNG_TEST, q, 1) : 0.0;
        double az = 2.0 * PDS__PI * pds__rng_uniform(sd, PDS__RNG_TEST, q, 2);
        double aspect = pow(10.0, -3.0 * pds__rng_uniform(sd, PDS__RNG_TEST, q, 3));
        double len = 0.005 + 0.395 * pds__rng_uniform(sd, PDS__RNG_TEST, q, 4);
        double ang = PDS__PI * pds__rng_uniform(sd, PDS__RNG_TEST, q, 5), M[2][3], major, tol;
        pds__v3 c = pds__v(-1.2 + 2.4 * pds__rng_uniform(sd, PDS__RNG_TEST, q, 6), q % 3 == 0 ? 0.03 : 0.0,
                           -1.2 + 2.4 * pds__rng_uniform(sd, PDS__RNG_TEST, q, 7));
        pds__v3 nrm = pds__v(sin(tilt) * cos(az), cos(tilt), sin(tilt) * sin(az));
        int ok;
        REQUIRE(t, tkd_footprint(nrm, len, aspect, ang, M, &major), "filter matrix");
        tol = 0.25 * major;
        needles += aspect < 0.01;
        memset(hg.count, 0, W * H * sizeof *hg.count);
        memset(hk.count, 0, W * H * sizeof *hk.count);
        hg.n = hk.n = n - map.n_whole;
        hg.total = hk.total = hg.out_of_range = hk.out_of_range = 0;
        ok = pds__grid_range_ellipse(&map, &f, c, major, (const double(*)[3])M, nrm, tol, tkd_collect_many, &hg, 1);
        pds__kdtree_range_ellipse(&map.whole, c, major, (const double(*)[3])M, nrm, tol, tkd_collect_many, &hk);
        if (!ok) {
            refused++;
            continue;
        }
        bad += hg.out_of_range + hk.out_of_range;
        for (i = 0; i < hg.n; i++)
            if (hg.count[i] != hk.count[i] || hg.count[i] > 1 || (hg.count[i] && hg.d2[i] != hk.d2[i])) bad++;
        hits += hk.total;
    }
    CHECK(t, bad == 0 && refused == 0, "%zu differences from the tree, %d queries refused", bad, refused);
    CHECK(t, hits > 1000 && needles > 50, "%zu vertices found, %zu needles: too few to tell", hits, needles);
    {
        /* a footprint around the camera itself: its box reaches behind it */
        double M[2][3] = {{1.0, 0.0, 0.0}, {0.0, 0.0, 1.0}};
        hg.total = 0;
        CHECK(t, !pds__grid_range_ellipse(&map, &f, pds__add(f.origin, pds__scale(f.forward, 0.5)), 1.5,
                                          (const double(*)[3])M, up, 0.4, tkd_collect_many, &hg, 1) &&
                  hg.total == 0,
              "a query reaching behind the camera was taken (%zu reported)", hg.total);
    }
    pds__eye_map_free_index(&map);
    tkd_hits_free(&hg);
    tkd_hits_free(&hk);
    free(v);
}

static void test_pds_whole_pixels_are_found_through_the_image_as_through_their_tree(pds_test_ctx *t)
{
    whole_pixels_grid_against_tree(t, 1);
    whole_pixels_grid_against_tree(t, 0);
}

/* The floor of whole_pixels_grid_against_tree (every pixel's vertex at
   its centre ray), with every third vertex a single sample (no half-axes)
   and every seventh merged but not whole; the vertices of pixels below
   `rows` only. Returns how many. */
static size_t rebuild_test_floor(pds__eye_vertex *v, int w, int rows, const pds__camera_frame *f)
{
    pds__v3 up = pds__v(0.0, 1.0, 0.0);
    pds_material m = splat_test_floor();
    double beta[3] = {0.5, 0.5, 0.5};
    size_t n = 0;
    int x, y;
    for (y = 0; y < rows; y++)
        for (x = 0; x < w; x++) {
            pds__v3 d = pds__camera_dir(f, x + 0.5, y + 0.5), p, ex, ey;
            double tf = -f->origin.y / d.y;
            int k = y * w + x;
            if (!(tf > 0.0)) continue;
            p = pds__add(f->origin, pds__scale(d, tf));
            if (!pds__pixel_axes(f, p, up, &ex, &ey) ||
                !pds__eye_vertex_set(&v[n], &m, p, up, up, pds__normalize(pds__sub(f->origin, p)), beta, 0))
                continue;
            v[n].pixel = k;
            if (k % 3 != 0) {
                pds__f3_set(v[n].px, ex);
                pds__f3_set(v[n].py, ey);
                v[n].whole = k % 7 != 0;
            }
            n++;
        }
    return n;
}

/* An eye round rebuilds its map in the buffers of the last build
   (pds__eye_map_free_trees, then pds__eye_map_build): on fewer vertices
   than the first build's, the rebuilt map is the fresh build's bit for
   bit (its parts, vertex order, grid, grid positions, slack, splat
   fields and trees; two threads' build the same as one thread's), and it
   kept the first build's scratch and hot arrays (their capacity for the
   first build's vertices) rather than making new ones. */
static void test_eye_map_rebuild_in_its_buffers_is_a_fresh_build(pds_test_ctx *t)
{
    enum { W = 64, H = 48 };
    pds__camera_frame f = merge_test_camera();
    pds__eye_vertex *big = (pds__eye_vertex *)calloc(W * H, sizeof *big);
    pds__eye_vertex *small = (pds__eye_vertex *)calloc(W * H, sizeof *small);
    pds__eye_vertex *copy = (pds__eye_vertex *)calloc(W * H, sizeof *copy);
    pds__eye_map re, fresh;
    size_t nb, ns;
    size_t scratch_cap, hot_cap;
    REQUIRE(t, big && small && copy, "memory");
    nb = rebuild_test_floor(big, W, H, &f);
    ns = rebuild_test_floor(small, W, 30, &f);
    memcpy(copy, small, ns * sizeof *small);
    /* a build grows its buffers by doubling from 16: 2048 for the small
       set alone, 4096 once the big one has been built */
    REQUIRE(t, ns > 1000 && ns <= 2048 && nb > 2048, "%zu and %zu vertices", ns, nb);
    memset(&re, 0, sizeof re);
    re.v = big;
    re.n = nb;
    REQUIRE(t, pds__eye_map_build(&re, W, H, &f, 2, NULL) == PDS_OK, "first build");
    scratch_cap = re.scratch_cap;
    hot_cap = re.hot_cap;
    pds__eye_map_free_trees(&re);
    re.v = small;
    re.n = ns;
    REQUIRE(t, pds__eye_map_build(&re, W, H, &f, 2, NULL) == PDS_OK, "rebuild");
    memset(&fresh, 0, sizeof fresh);
    fresh.v = copy;
    fresh.n = ns;
    REQUIRE(t, pds__eye_map_build(&fresh, W, H, &f, 1, NULL) == PDS_OK, "fresh build");
    CHECK(t, re.n_single == fresh.n_single && re.n_whole == fresh.n_whole && re.n_single > 0 &&
                 re.n_whole > re.n_single && re.n_whole < ns,
          "parts %zu / %zu against %zu / %zu", re.n_single, re.n_whole, fresh.n_single, fresh.n_whole);
    CHECK(t, memcmp(small, copy, ns * sizeof *small) == 0, "the vertices' order differs");
    CHECK(t, memcmp(re.grid, fresh.grid, W * H * sizeof *re.grid) == 0 &&
                 memcmp(re.grid_pos, fresh.grid_pos, 3 * (ns - re.n_whole) * sizeof *re.grid_pos) == 0 &&
                 re.grid_slack == fresh.grid_slack,
          "grids differ");
    CHECK(t, memcmp(re.hot, fresh.hot, ns * sizeof *re.hot) == 0, "splat fields differ");
    CHECK(t, re.tree.n == fresh.tree.n && re.whole.n == fresh.whole.n &&
                 memcmp(re.tree.pts, fresh.tree.pts, 3 * re.tree.n * sizeof(float)) == 0 &&
                 memcmp(re.tree.axis, fresh.tree.axis, re.tree.n) == 0 &&
                 memcmp(re.whole.pts, fresh.whole.pts, 3 * re.whole.n * sizeof(float)) == 0,
          "trees differ");
    CHECK(t, re.scratch_cap == scratch_cap && re.hot_cap == hot_cap && fresh.scratch_cap < scratch_cap,
          "the rebuild allocated anew: scratch %zu (first %zu, fresh %zu), hot %zu (first %zu)", re.scratch_cap,
          scratch_cap, fresh.scratch_cap, re.hot_cap, hot_cap);
    pds__eye_map_free_index(&re);
    pds__eye_map_free_index(&fresh);
    free(big);
    free(small);
    free(copy);
}

/* The splat's cost roulette (pds__splat, PDS__SPLAT_ROULETTE): a round
   footprint over a floor of eye vertices, splatted as photons 0..P-1 of a
   pass whose bound it exceeds about fourfold, keeps a share of them, and
   the image summed over all P and divided by P is the footprint's own
   splat without the roulette, within 4 standard errors of the binomial
   count. The bound follows the footprints' areas (pds__pass_begin): the
   same footprint scaled to pass 8 (areas i^(alpha - 1) = 1/2 of pass 1's
   at alpha 2/3) and to pass 27 of passes a quarter the size (1/3 times
   4) keeps the same photons; with a fixed bound pass 8 would keep twice
   as many. */
static void test_pds_splat_roulette_keeps_the_mean_and_follows_the_footprints_area(pds_test_ctx *t)
{
    enum { NV = 600, P = 2000 };
    static const long pass_k[3] = {0, 7, 26}, pass_m[3] = {16384, 16384, 4096};
    pds__camera_frame f = merge_test_camera();
    pds__eye_vertex *v = (pds__eye_vertex *)calloc(NV, sizeof *v);
    pds__sum128 *sum = (pds__sum128 *)calloc(3 * NV, sizeof *sum);
    pds__photon_job job;
    pds__splat_buf buf;
    pds__eye_map map;
    pds__ray_diff r;
    pds__v3 up = pds__v(0.0, 1.0, 0.0);
    pds_material m;
    pds_options opt;
    double flux[3] = {1.0, 2.0, 3.0}, beta[3] = {0.5, 0.5, 0.5}, once = 0.0, all = 0.0, keep, se;
    long kept[3];
    int i, c, p, pass;
    REQUIRE(t, v && sum, "memory");
    m = splat_test_floor();
    for (i = 0; i < NV; i++) {
        double a = pds__rng_uniform(9, 1, (uint64_t)i, 0), b = pds__rng_uniform(9, 1, (uint64_t)i, 1);
        pds__v3 x = pds__v(-0.3 + 0.6 * a, 0.0, -0.3 + 0.6 * b);
        REQUIRE(t, pds__eye_vertex_set(&v[i], &m, x, up, up, pds__normalize(pds__sub(f.origin, x)), beta, 0),
                "vertex %d", i);
        v[i].pixel = i;
    }
    memset(&map, 0, sizeof map);
    map.v = v;
    map.n = NV;
    REQUIRE(t, pds__eye_map_build(&map, 0, 0, NULL, 1, NULL) == PDS_OK, "eye map");
    splat_test_job(&job, &buf, &map, f, sum);
    job.sample_angle = 0.00045;
    pds_options_default(&opt);
    opt.pass_alpha = 2.0 / 3.0;
    opt.pass_min_width = 0.0;
    memset(&r, 0, sizeof r);
    r.p = pds__v(0.01, 0.0, 0.005);
    r.d = pds__v(0.0, -1.0, 0.0);
    /* without the roulette: the footprint's own splat */
    r.dpdu = pds__v(0.3, 0.0, 0.0);
    r.dpdv = pds__v(0.0, 0.0, 0.3);
    pds__splat(&job, &buf, &r, up, flux, 0.0, 0);
    for (i = 0; i < 3 * NV; i++) once += pds__sum128_value(sum[i]) / buf.unit;
    REQUIRE(t, once > 0.0 && buf.roulette == 0, "the footprint lights nothing (%g)", once);
    for (pass = 0; pass < 3; pass++) {
        /* the footprint of pass k of m photons: its size s_i / sqrt(m) */
        double scale = pds__pass_smoothing(1.0, opt.pass_alpha, pass_k[pass] + 1) * sqrt(16384.0 / pass_m[pass]);
        r.dpdu = pds__v(0.3 * scale, 0.0, 0.0);
        r.dpdv = pds__v(0.0, 0.0, 0.3 * scale);
        job.roulette_vertices = 1.0; /* played: pds__pass_begin sets the bound */
        pds__pass_begin(&job, &opt, pass_k[pass], pass_m[pass]);
        memset(sum, 0, 3 * NV * sizeof *sum);
        buf.splatted = buf.roulette = 0;
        for (p = 0; p < P; p++) pds__splat(&job, &buf, &r, up, flux, 0.0, p);
        kept[pass] = buf.splatted;
        CHECK(t, buf.splatted + buf.roulette == P, "pass %ld: %ld splatted and %ld skipped of %d", pass_k[pass] + 1,
              buf.splatted, buf.roulette, P);
        if (pass == 0) {
            for (i = 0, all = 0.0; i < NV; i++)
                for (c = 0; c < 3; c++) all += pds__sum128_value(sum[3 * i + c]) / buf.unit;
            keep = (double)kept[0] / P;
            CHECK(t, keep > 0.15 && keep < 0.4, "%ld of %d photons kept: the roulette should keep about a quarter",
                  kept[0], P);
            se = once * sqrt((1.0 - keep) / (keep * P));
            CHECK(t, fabs(all / P - once) < 4.0 * se, "mean splat %g, without the roulette %g (standard error %g)",
                  all / P, once, se);
        }
    }
    CHECK(t, kept[1] == kept[0] && kept[2] == kept[0],
          "kept %ld, %ld and %ld photons in passes 1, 8 and 27 (a quarter the size): the bound should follow the "
          "footprints' area", kept[0], kept[1], kept[2]);
    pds__eye_map_free_index(&map);
    free(v);
    free(sum);
}

/* Under a time budget the photon passes get `ratio` eye passes' time
   between eye rounds (pds__eye_round_ratio): c / f for a caustics-only
   image whose single samples took the share f of the splatted light, the
   ratio falling as f grows and held between 1 (f >= c) and 8 (f <= c / 8,
   and no light yet); a full image keeps 1, its direct light being the
   eye samples' alone. */
static void test_eye_round_ratio_gives_photons_the_time_single_samples_do_not_need(pds_test_ctx *t)
{
    static const double f[] = {0.0, 0.01, 0.05, 0.1, 0.13, 0.2, 0.4, 0.52, 0.9, 1.0};
    double last = HUGE_VAL;
    size_t i;
    for (i = 0; i < sizeof f / sizeof f[0]; i++) {
        double r = pds__eye_round_ratio(f[i], 1.0 - f[i], 1), want = f[i] <= 0.05 ? 8.0 : f[i] >= 0.4 ? 1.0 : 0.4 / f[i];
        CHECK(t, fabs(r - want) < 1e-12 * want, "share %g: ratio %g, want %g", f[i], r, want);
        CHECK(t, r <= last, "share %g: ratio %g above the smaller share's %g", f[i], r, last);
        CHECK(t, pds__eye_round_ratio(f[i], 1.0 - f[i], 0) == 1.0, "full image, share %g: ratio %g, want 1", f[i],
              pds__eye_round_ratio(f[i], 1.0 - f[i], 0));
        last = r;
    }
    /* the same shares of any amount of light, and none yet */
    CHECK(t, fabs(pds__eye_round_ratio(13.0, 87.0, 1) - 0.4 / 0.13) < 1e-12, "share 13 of 100: ratio %g",
          pds__eye_round_ratio(13.0, 87.0, 1));
    CHECK(t, pds__eye_round_ratio(0.0, 0.0, 1) == 8.0, "no light splatted yet: ratio %g, want 8",
          pds__eye_round_ratio(0.0, 0.0, 1));
}

/* The pixels' second scale (pds_options.pass_select) is the pass at half
   its smoothing: on the plane mirror's floor (every pixel a merged
   vertex), one pass of 16,384 photons with s_1 = 3 and no widening (so
   the footprints scale with s) holds, besides its own sums, those of the
   same photons at s_1 = 1.5, as a render at 1.5 without the second scale
   makes them (to rounding: the two add their terms in other orders of
   operations), and its own sums are that render's at 3, bit for bit. */
static void select_one_pass(pds_options *o, double s1, int select)
{
    o->method = PDS_METHOD_PDS;
    o->progressive = 1;
    o->photons = o->pass_photons = 16384;
    o->pass_smoothing = s1;
    o->pass_min_aspect = o->pass_min_width = 0.0;
    o->walls = 0; /* the probes' reach follows the footprint's size */
    o->pass_select = select;
    o->paths = PDS_PATHS_CAUSTICS_ONLY;
    o->threads = 2;
}

static void test_pds_second_scale_is_the_pass_at_half_the_smoothing(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text(mirror_scene, &err);
    pds_partial *sel = NULL, *half = NULL, *own = NULL;
    pds_options opt;
    size_t i, npix = 24 * 24;
    double worst = 0.0, lit = 0.0;
    int same = 1, c;
    REQUIRE(t, s != NULL, "load: %s", err.text);
    pds_options_default(&opt);
    select_one_pass(&opt, 3.0, 1);
    REQUIRE(t, pds_render_part(s, &opt, &sel, NULL, &err) == PDS_OK, "render with the second scale: %s", err.text);
    select_one_pass(&opt, 1.5, 0);
    REQUIRE(t, pds_render_part(s, &opt, &half, NULL, &err) == PDS_OK, "render at s 1.5: %s", err.text);
    select_one_pass(&opt, 3.0, 0);
    REQUIRE(t, pds_render_part(s, &opt, &own, NULL, &err) == PDS_OK, "render at s 3: %s", err.text);
    REQUIRE(t, sel->stride == PDS__STRIDE_SELECT && half->stride == 3 && own->stride == 3, "strides %d %d %d",
            sel->stride, half->stride, own->stride);
    /* an RGB render's S- is 0: its parts hold none */
    CHECK(t, sel->neg == NULL && half->neg == NULL && own->neg == NULL, "an RGB render's part holds S- sums");
    for (i = 0; i < npix; i++)
        for (c = 0; c < 3; c++) {
            const pds__sum128 *a = &sel->photon[PDS__STRIDE_SELECT * i + (size_t)c], *b = &own->photon[3 * i + (size_t)c];
            double small = pds__sum128_value(a[PDS__SEL_HALF]);
            double want = pds__sum128_value(half->photon[3 * i + (size_t)c]);
            same &= a->lo == b->lo && a->hi == b->hi;
            lit += want;
            if (want > 0.0) worst = fmax(worst, fabs(small / want - 1.0));
            else worst = fmax(worst, small == 0.0 ? 0.0 : 1.0);
        }
    CHECK(t, lit > 0.0, "the floor got no caustic");
    CHECK(t, worst < 1e-9, "the second scale's sums are %g from the render at half the smoothing", worst);
    CHECK(t, same, "the pass's own sums differ from a render without the second scale");
    pds_partial_free(sel);
    pds_partial_free(half);
    pds_partial_free(own);
    pds_scene_free(s);
}

/* The pixels' validation (pds_options.pass_select) is the light tracer's
   image of photons of their own: on the plane mirror's floor, 3 passes
   of 16,384 photons hold in each pixel's validation sum the R + G + B of
   pds_render_light_traced with the validation's seed and 3 x 4,096
   photons (the same photons, each weighted for 4,096 a pass rather than
   12,288 in all: equal to rounding), and every pixel took part in the 3
   passes; the floor's pixels see one surface, so no edges between them. */
static void test_pds_validation_is_the_light_tracers_image_of_its_own_photons(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text(mirror_scene, &err);
    pds_partial *part = NULL;
    pds_options opt;
    pds_image lt = {0, 0, NULL};
    size_t i, npix = 24 * 24;
    double worst = 0.0, lit = 0.0, scale;
    int took = 0, edges = 0;
    REQUIRE(t, s != NULL, "load: %s", err.text);
    pds_options_default(&opt);
    opt.photons = 3 * 16384;
    opt.paths = PDS_PATHS_CAUSTICS_ONLY;
    opt.threads = 2;
    REQUIRE(t, opt.pass_select == 1 && opt.pass_photons == 16384, "defaults: pass_select %d, pass photons %ld",
            opt.pass_select, opt.pass_photons);
    REQUIRE(t, pds_render_part(s, &opt, &part, NULL, &err) == PDS_OK, "render: %s", err.text);
    REQUIRE(t, part->stride == PDS__STRIDE_SELECT && part->neg == NULL, "stride %d, S- %s", part->stride,
            part->neg ? "held" : "none");
    opt.seed = pds__mix64(0 ^ PDS__VALIDATE_SEED);
    opt.photons = 3 * 4096;
    REQUIRE(t, pds_render_light_traced(s, &opt, &lt, &err) == PDS_OK, "light traced: %s", err.text);
    scale = part->n_planned / (double)part->emitted / part->unit;
    for (i = 0; i < npix; i++) {
        const pds__sum128 *ps = &part->photon[PDS__STRIDE_SELECT * i];
        double v = pds__sum128_value(ps[PDS__SEL_VALID]) * scale; /* (an RGB render's S- is 0) */
        double want = (double)lt.rgb[3 * i] + lt.rgb[3 * i + 1] + lt.rgb[3 * i + 2];
        took += ps[PDS__SEL_COUNT].lo == 3;
        edges += ps[PDS__SEL_COUNT].hi != 0 && i % 24 != 23 && i / 24 != 23 ? 1 : 0;
        lit += want;
        worst = fmax(worst, fabs(v - want) / fmax(want, 1e-30) * (want > 0.0 || v != 0.0));
    }
    CHECK(t, lit > 0.0, "the light tracer saw no caustic");
    CHECK(t, worst < 1e-5, "the validation is %g from the light tracer's image", worst);
    CHECK(t, took == (int)npix, "%d of %d pixels took part in every pass", took, (int)npix);
    CHECK(t, edges == 0, "%d pixels inside the floor have an edge", edges);
    {
        /* the render's count of the pixels' choices, and the merge's of
           the same part: every pixel, once; none with one scale */
        pds_render_stats st;
        pds_merge_report rep;
        pds_image img = {0, 0, NULL}, merged = {0, 0, NULL};
        const pds_partial *parts[1];
        long all = 0;
        int k, same = 1;
        opt.seed = 0;
        opt.photons = 3 * 16384;
        REQUIRE(t, pds_render(s, &opt, &img, &st, &err) == PDS_OK, "render: %s", err.text);
        for (k = 0; k < PDS_SCALE_ESTIMATES; k++) all += st.scale_pixels[k];
        CHECK(t, all == (long)npix, "the choices counted %ld pixels, want %d", all, (int)npix);
        parts[0] = part;
        REQUIRE(t, pds_partial_merge_report(parts, NULL, 1, 0, &merged, &rep, &err) == PDS_OK, "merge: %s", err.text);
        for (k = 0; k < PDS_SCALE_ESTIMATES; k++) same &= rep.scale_pixels[k] == st.scale_pixels[k];
        CHECK(t, same && rep.fraction == 1.0 && rep.nonfinite == 0, "the merge's report differs from the render's");
        pds_image_free(&img);
        pds_image_free(&merged);
        opt.pass_select = 0;
        REQUIRE(t, pds_render(s, &opt, &img, &st, &err) == PDS_OK, "render: %s", err.text);
        for (k = 0, all = 0; k < PDS_SCALE_ESTIMATES; k++) all += st.scale_pixels[k];
        CHECK(t, all == 0, "one scale counted %ld choices", all);
        CHECK(t, pds_partial_merge_report(parts, NULL, 1, 0, &merged, NULL, &err) == PDS_ERR_INVALID_ARG,
              "a NULL report taken");
        pds_image_free(&img);
    }
    pds_image_free(&lt);
    pds_partial_free(part);
    pds_scene_free(s);
}

/* The choice (pds__scale_choice, through the image it makes). A part of
   K passes (unit 1, one photon planned a pass, so a sum of K v holds v)
   whose pixels all took part, 64 x 16: the pass's scale is L = 2
   everywhere, the second scale 2.3 on the left half and 2.6 on the
   right, and the validation (R + G + B) says the truth is 2.3 a channel
   on the left and 2 on the right: the left takes the second scale, the
   right keeps the pass's (beyond the reach of the errors' three boxes of
   radius 7 from the middle). A pixel that took part in fewer than K
   passes keeps the pass's scale. Then the blurs and the edges: the pass's
   scale is the truth (1 on the left, 3 on the right) plus a checkerboard
   of +-0.5, the second scale the same, the validation the truth: every
   pixel takes a blur, which removes the checkerboard but for the columns
   next to the middle; with an edge between the halves (the high word of
   the count) no blur crosses it, and every pixel is within 0.2 of its
   side's truth. And the first case again with a validation whose terms'
   squares say it is far too noisy to tell the estimates apart: every
   pixel keeps the pass's scale. Then stripes, the truth 1 and 3 on
   alternate rows, the pass's scale that plus +-0.5 alternating along the
   row: only the blur along the rows alone removes the noise without
   mixing the rows, and every pixel takes it, within 0.2 of the truth;
   and the same turned a quarter (columns). Then the blend: the pass's
   scale 2, the second scale 3 and the truth 2.4 everywhere, which
   neither estimate is but 0.6 and 0.4 of them are: every pixel takes
   that blend, counted as the second scale's. Then the second scale
   blurred: the pass's scale 0.5 too high everywhere, the second scale
   right but for a checkerboard of +-0.5: every pixel takes the second
   blurred by the box of radius 1, within 0.2 of the truth. Each time the choices it counts are the
   pixels that took each estimate: all that took part, one each. Also the
   segmented box against a direct mean over a run. */
static void sel_set(pds__sum128 *photon, pds__sum128 *neg, int i, int slot, double v, long k)
{
    double f = v * (double)k * 1000.0; /* in thousandths */
    pds__sum128 *d = f < 0.0 ? &neg[PDS__STRIDE_SELECT * i + slot] : &photon[PDS__STRIDE_SELECT * i + slot];
    d->lo = (uint64_t)floor(fabs(f) + 0.5);
    d->hi = 0;
}

static void test_pds_scale_choice_takes_the_estimate_the_validation_says_is_closest(pds_test_ctx *t)
{
    enum { W = 64, H = 16, K = 8, N = W * H };
    static pds__sum128 photon[N * PDS__STRIDE_SELECT], neg[N * PDS__STRIDE_SELECT];
    static float out[N * 3];
    static double eye[N * 3];
    double x[40], m[40], want, rgb[120], scratch[40];
    unsigned char edge[40], none[40];
    long chose[PDS__SELECT_ESTIMATES];
    int px, py, c, pass, bad = 0, skipped = 0, away = 0, crossed = 0, unsure = 0, striped = 0, blended = 0, smoothed = 0;
    memset(eye, 0, sizeof eye);
    for (pass = 0; pass < 8; pass++) {
        memset(photon, 0, sizeof photon);
        memset(neg, 0, sizeof neg);
        for (py = 0; py < H; py++)
            for (px = 0; px < W; px++) {
                int i = py * W + px, left = px < W / 2;
                double chk = ((px + py) % 2 ? 0.5 : -0.5), base, half, truth;
                if (pass == 0 || pass == 3) {
                    base = 2.0;
                    half = left ? 2.3 : 2.6;
                    truth = left ? 2.3 : 2.0;
                } else if (pass == 6) {
                    base = 2.0;
                    half = 3.0;
                    truth = 2.4;
                } else if (pass == 7) {
                    truth = 2.0;
                    base = 2.5;
                    half = truth + chk;
                } else if (pass >= 4) {
                    /* stripes along the rows (4) or the columns (5), the
                       noise across them */
                    int along = pass == 4 ? py : px, across = pass == 4 ? px : py;
                    truth = along % 2 ? 3.0 : 1.0;
                    base = half = truth + (across % 2 ? 0.5 : -0.5);
                } else {
                    truth = left ? 1.0 : 3.0;
                    base = half = truth + chk;
                }
                for (c = 0; c < 3; c++) {
                    sel_set(photon, neg, i, c, base, K);
                    sel_set(photon, neg, i, PDS__SEL_HALF + c, half, K);
                }
                sel_set(photon, neg, i, PDS__SEL_VALID, 3.0 * truth, K);
                photon[PDS__STRIDE_SELECT * i + PDS__SEL_COUNT].lo = (pass == 0 && px == 3 && py == 3) ? K - 1 : K;
                if (pass == 3) photon[PDS__STRIDE_SELECT * i + PDS__SEL_VALID2].hi = 1; /* a very noisy validation */
                if (pass == 2 && px == W / 2 - 1) photon[PDS__STRIDE_SELECT * i + PDS__SEL_COUNT].hi = 1; /* edge right */
            }
        pds__choice_report report = {NULL, NULL, NULL, 0.0, NULL};
        report.chose = chose;
        memset(chose, 0, sizeof chose);
        REQUIRE(t, pds__partial_image(eye, photon, neg, PDS__STRIDE_SELECT, W, H, 1000.0, 1.0, K, out, 1, &report) == 0,
                "image");
        {
            /* the pixels counted: the half on the left beyond the errors'
               boxes took the second scale, the right the pass's; the
               checkerboards a blur where they are away from the middle;
               the noisy validation the pass's scale everywhere */
            long all = chose[0] + chose[1] + chose[2] + chose[3] + chose[4] + chose[5] + chose[6] + chose[7];
            long blurred = chose[2] + chose[3] + chose[4] + chose[5] + chose[6];
            CHECK(t, all == (pass == 0 ? N - 1 : N), "pass %d: %ld pixels counted, want %d", pass, all,
                  pass == 0 ? N - 1 : N);
            if (pass == 0)
                CHECK(t, chose[1] >= (W / 2 - 22) * H - 1 && chose[0] >= (W / 2 - 22) * H && blurred == 0,
                      "the two halves' choices: %ld %ld %ld", chose[0], chose[1], blurred);
            if (pass == 1 || pass == 2)
                CHECK(t, blurred >= (W - 8) * H, "pass %d: %ld pixels took a blur", pass, blurred);
            if (pass == 3)
                CHECK(t, chose[0] == N, "the noisy validation: %ld of %d kept the pass's scale", chose[0], N);
            if (pass == 6) CHECK(t, chose[1] == N, "the blend: %ld of %d took the second scale's", chose[1], N);
            if (pass == 7) CHECK(t, chose[7] == N, "the second blurred: %ld of %d took it", chose[7], N);
            if (pass == 4 || pass == 5)
                CHECK(t, chose[pass == 4 ? 5 : 6] == N, "stripes along the %s: %ld of %d took the blur along them",
                      pass == 4 ? "rows" : "columns", chose[pass == 4 ? 5 : 6], N);
        }
        for (py = 0; py < H; py++)
            for (px = 0; px < W; px++) {
                int i = py * W + px, left = px < W / 2;
                double v = out[3 * i];
                if (pass == 0) {
                    if (px == 3 && py == 3) skipped += fabs(v - 2.0) > 1e-6;
                    else if (px < W / 2 - 22) bad += fabs(v - 2.3) > 1e-6;
                    else if (px >= W / 2 + 22) bad += fabs(v - 2.0) > 1e-6;
                } else if (pass == 1) {
                    if (px < W / 2 - 4 || px >= W / 2 + 4) away += fabs(v - (left ? 1.0 : 3.0)) > 0.2;
                } else if (pass == 2) {
                    crossed += fabs(v - (left ? 1.0 : 3.0)) > 0.2;
                } else if (pass == 6) {
                    blended += fabs(v - 2.4) > 1e-6;
                } else if (pass == 7) {
                    smoothed += fabs(v - 2.0) > 0.2;
                } else if (pass >= 4) {
                    striped += fabs(v - ((pass == 4 ? py : px) % 2 ? 3.0 : 1.0)) > 0.2;
                } else {
                    unsure += fabs(v - 2.0) > 1e-6;
                }
            }
    }
    CHECK(t, bad == 0, "%d pixels took the other scale", bad);
    CHECK(t, skipped == 0, "a pixel that did not take part in every pass left the pass's scale");
    CHECK(t, away == 0, "%d pixels away from the middle kept the checkerboard", away);
    CHECK(t, crossed == 0, "%d pixels were blurred across the edge", crossed);
    CHECK(t, unsure == 0, "%d pixels left the pass's scale on a validation too noisy to tell", unsure);
    CHECK(t, striped == 0, "%d striped pixels are more than 0.2 from the truth", striped);
    CHECK(t, blended == 0, "%d pixels are not the blend 0.6 x 2 + 0.4 x 3", blended);
    CHECK(t, smoothed == 0, "%d pixels are more than 0.2 from the second scale's smoothed truth", smoothed);
    /* the segmented box: a run of 40 broken by a pixel that takes no part
       (17) and an edge after 29: runs 0-16, 18-29, 30-39 */
    for (px = 0; px < 40; px++) {
        x[px] = (double)((px * 37) % 11);
        m[px] = px == 17 ? 0.0 : 1.0;
        edge[px] = px == 29 ? 1 : 0;
    }
    memset(none, 0, sizeof none);
    for (pass = 0; pass < 2; pass++) {
        /* the run as a row of 40 pixels (its edges to the right), then as
           a column (its edges below; mt and edget are column-major), in
           each of R, G, B */
        int w = pass ? 1 : 40, h = pass ? 40 : 1;
        for (px = 0; px < 120; px++) rgb[px] = x[px / 3] + (double)(px % 3);
        REQUIRE(t, pds__segmented_box(rgb, m, m, pass ? none : edge, pass ? edge : none, scratch, w, h, 2, 1, 3, 1),
                "segmented box");
        for (px = 0, bad = 0; px < 40; px++) {
            int a0 = px <= 16 ? 0 : px <= 29 ? 18 : 30, b0 = px <= 16 ? 16 : px <= 29 ? 29 : 39, lo, hi, k, cnt = 0;
            if (px == 17) {
                for (c = 0; c < 3; c++) bad += rgb[3 * px + c] != x[px] + c;
                continue;
            }
            lo = px - 2 < a0 ? a0 : px - 2;
            hi = px + 2 > b0 ? b0 : px + 2;
            want = 0.0;
            for (k = lo; k <= hi; k++, cnt++) want += x[k];
            for (c = 0; c < 3; c++) bad += fabs(rgb[3 * px + c] - (want / cnt + c)) > 1e-12;
        }
        CHECK(t, bad == 0, "segmented box along a %s: %d values differ from the runs' direct means",
              pass ? "column" : "row", bad);
    }
}

/* The choice where there is no light (pds__scale_choice, through the
   image it makes): a bright 3 x 3 patch at the left of a 64 x 16 part
   whose other pixels all took part and hold nothing, every estimate 0
   there and V too. Pixels beyond the reach of the blurs (3 boxes of
   radius 2) and the errors' boxes (3 of radius 7) from the patch have
   no evidence for any estimate and must keep the pass's scale. With
   running sums that kept the patch's rounding (box means of +-1e-16 of
   its light where there was none) they took candidates on that residue:
   on this part 263 of the 512 pixels tested. */
static void test_pds_scale_choice_makes_no_choice_where_there_is_no_light(pds_test_ctx *t)
{
    enum { W = 64, H = 16, K = 8, N = W * H };
    static pds__sum128 photon[N * PDS__STRIDE_SELECT], neg[N * PDS__STRIDE_SELECT];
    static float out[N * 3], view[N * 3];
    static double eye[N * 3];
    long chose[PDS__SELECT_ESTIMATES];
    uint64_t r = 777;
    int px, py, c, moved = 0, tested = 0;
    pds__choice_report report = {NULL, NULL, NULL, 0.0, NULL};
    memset(eye, 0, sizeof eye);
    memset(photon, 0, sizeof photon);
    memset(neg, 0, sizeof neg);
    for (py = 0; py < H; py++)
        for (px = 0; px < W; px++) {
            int i = py * W + px;
            if (px < 8) {
                /* the light: noisy estimates of a bright patch */
                double u[4], base;
                for (c = 0; c < 4; c++) {
                    r = r * 6364136223846793005u + 1442695040888963407u;
                    u[c] = (double)(r >> 11) / 9007199254740992.0;
                }
                base = 100.0 + 9000.0 * u[0];
                for (c = 0; c < 3; c++) {
                    sel_set(photon, neg, i, c, base * (1.0 + 0.1 * c), K);
                    sel_set(photon, neg, i, PDS__SEL_HALF + c, base * (0.7 + 0.6 * u[1]) * (1.0 + 0.1 * c), K);
                }
                sel_set(photon, neg, i, PDS__SEL_VALID, 3.3 * base * (0.5 + u[2]), K);
            }
            photon[PDS__STRIDE_SELECT * i + PDS__SEL_COUNT].lo = K;
        }
    for (px = 0; px < N * 3; px++) view[px] = -1.0f;
    report.chose = chose;
    report.view = view;
    memset(chose, 0, sizeof chose);
    REQUIRE(t, pds__partial_image(eye, photon, neg, PDS__STRIDE_SELECT, W, H, 1000.0, 1.0, K, out, 1, &report) == 0,
            "image");
    for (py = 0; py < H; py++)
        for (px = 36; px < W; px++) {
            tested++;
            moved += view[3 * (py * W + px)] != 0.0f;
        }
    CHECK(t, moved == 0, "%d of %d pixels far from any light took another estimate than the pass's", moved, tested);
    CHECK(t, chose[0] + chose[1] + chose[2] + chose[3] + chose[4] + chose[5] + chose[6] + chose[7] == N,
          "every pixel counted");
}

/* The blur of the pixels seen through glass (pds__through_choice, through
   the image pds__partial_image makes). A part of K = 8 passes, 4 of them
   odd, 64 x 16 pixels, none seen whole (so the validated choice leaves
   them all): each half A (odd passes) and B (even) is the truth plus
   noise of its own, sd 0.3 a channel, the image their mean. The left
   half is flat (2 a channel): blurs take its noise off, and its interior
   pixels' error falls by more than half. The right half is columns
   alternating 1 and 3: only the blurs along the columns keep them (the
   square and row boxes would put a pixel 0.67 to 1 off, where the noise
   of their mean is 0.17 on average), and its interior's mean error falls
   by more than 40%. (Values within the sums' rounding, 1e-4.) The pixels seen
   whole keep the validated choice: a band of such pixels (taking part
   in every pass, the choice's other candidates all the pass's own)
   comes out as the pass's values, untouched. A part whose sums hold no
   odd passes apart (a render before them, or one that did not keep
   them) keeps every pixel's value and counts no blur; nor does a part
   of one pass. */
static void test_pds_through_choice_blurs_where_the_halves_say_noise(pds_test_ctx *t)
{
    enum { W = 64, H = 16, K = 8, KO = 4, N = W * H };
    static pds__sum128 photon[N * PDS__STRIDE_SELECT], neg[N * PDS__STRIDE_SELECT];
    static float out[N * 3];
    static double eye[N * 3], mean[N * 3];
    uint64_t r = 2024;
    long through = 0;
    double se_before = 0.0, se_after = 0.0, worst_right = 0.0, abs_right = 0.0, abs_right_before = 0.0, moved_whole = 0.0;
    int n_right = 0;
    int px, py, c, round;
    memset(eye, 0, sizeof eye);
    for (round = 0; round < 3; round++) {
        pds__choice_report report = {NULL, NULL, NULL, 0.0, NULL};
        memset(photon, 0, sizeof photon);
        memset(neg, 0, sizeof neg);
        for (py = 0; py < H; py++)
            for (px = 0; px < W; px++) {
                int i = py * W + px;
                for (c = 0; c < 3; c++) {
                    double truth = px < W / 2 ? 2.0 : px % 2 ? 3.0 : 1.0, u[2], a, b;
                    int k;
                    for (k = 0; k < 2; k++) {
                        /* a sum of 12 uniforms: about normal, sd 1 */
                        int j;
                        u[k] = -6.0;
                        for (j = 0; j < 12; j++) {
                            r = r * 6364136223846793005ULL + 1442695040888963407ULL;
                            u[k] += (double)(r >> 11) * (1.0 / 9007199254740992.0);
                        }
                    }
                    a = truth + 0.3 * u[0];
                    b = truth + 0.3 * u[1];
                    mean[3 * i + c] = (KO * a + (K - KO) * b) / K;
                    sel_set(photon, neg, i, c, mean[3 * i + c], K);
                    sel_set(photon, neg, i, PDS__SEL_ODD + c, KO * a / K, K);
                    sel_set(photon, neg, i, PDS__SEL_HALF + c, mean[3 * i + c], K);
                }
                sel_set(photon, neg, i, PDS__SEL_VALID, mean[3 * i] + mean[3 * i + 1] + mean[3 * i + 2], K);
                /* round 1: rows 6-9 seen whole in every pass */
                photon[PDS__STRIDE_SELECT * i + PDS__SEL_COUNT].lo = round == 1 && py >= 6 && py <= 9 ? K : 0;
                photon[PDS__STRIDE_SELECT * i + PDS__SEL_ODDS].lo = round == 2 ? 0 : KO;
            }
        report.through = &through;
        through = 0;
        REQUIRE(t, pds__partial_image(eye, photon, neg, PDS__STRIDE_SELECT, W, H, 1000.0, 1.0, K, out, 1, &report) == 0,
                "image, round %d", round);
        for (py = 0; py < H; py++)
            for (px = 0; px < W; px++) {
                int i = py * W + px;
                for (c = 0; c < 3; c++) {
                    double truth = px < W / 2 ? 2.0 : px % 2 ? 3.0 : 1.0, v = out[3 * i + c];
                    if (round == 0 && px >= 3 && px < W / 2 - 3 && py >= 3 && py < H - 3) {
                        se_before += (mean[3 * i + c] - truth) * (mean[3 * i + c] - truth);
                        se_after += (v - truth) * (v - truth);
                    }
                    if (round == 0 && px >= W / 2 + 3 && py >= 3 && py < H - 3) {
                        worst_right = fmax(worst_right, fabs(v - truth));
                        abs_right += fabs(v - truth);
                        abs_right_before += fabs(mean[3 * i + c] - truth);
                        n_right++;
                    }
                    if (round == 1 && py >= 6 && py <= 9)
                        moved_whole = fmax(moved_whole, fabs(v - mean[3 * i + c]) / fmax(fabs(mean[3 * i + c]), 1.0));
                    if (round == 2)
                        moved_whole = fmax(moved_whole, fabs(v - mean[3 * i + c]) / fmax(fabs(mean[3 * i + c]), 1.0));
                }
            }
        if (round == 0) {
            CHECK(t, se_after < 0.25 * se_before, "the flat half's squared error %g, before the blurs %g", se_after,
                  se_before);
            CHECK(t, abs_right < 0.6 * abs_right_before,
                  "the columns: a pixel ends %g from its truth, their mean error %g (before the blurs %g)", worst_right,
                  abs_right / n_right, abs_right_before / n_right);
            CHECK(t, through > N / 2, "%ld pixels took a blur", through);
        }
        if (round == 2) CHECK(t, through == 0, "with no odd passes apart %ld pixels took a blur", through);
        CHECK(t, moved_whole < 1e-4, "round %d: a pixel seen whole (or with no halves) moved by %g", round,
              moved_whole);
        moved_whole = 0.0;
    }
    /* one pass: no halves */
    through = 0;
    {
        pds__choice_report report = {NULL, NULL, NULL, 0.0, NULL};
        for (px = 0; px < N; px++) photon[PDS__STRIDE_SELECT * px + PDS__SEL_ODDS].lo = 0;
        report.through = &through;
        REQUIRE(t, pds__partial_image(eye, photon, neg, PDS__STRIDE_SELECT, W, H, 1000.0, 1.0, 1, out, 1, &report) == 0,
                "image of one pass");
        CHECK(t, through == 0, "one pass: %ld pixels took a blur", through);
    }
}

/* The image made from the sums (the choice of scale: its box means, its
   segments' blurs, its per-pixel steps) on threads is the same, bit for
   bit, as on one, for an image large enough to be shared out
   (PDS__PARALLEL_PIXELS): noisy sums whose pixels take part in broad
   patches with edges between them, a smooth truth for V; the pixels
   between the patches choose their blur by the odd passes' half
   (pds__through_choice), which holds the pass's scale's noise. */
static void test_pds_image_making_is_identical_for_any_thread_count(pds_test_ctx *t)
{
    enum { W = 480, H = 300, N = W * H, K = 6 };
    pds__sum128 *photon = (pds__sum128 *)calloc((size_t)N * PDS__STRIDE_SELECT, sizeof *photon);
    pds__sum128 *neg = (pds__sum128 *)calloc((size_t)N * PDS__STRIDE_SELECT, sizeof *neg);
    double *eye = (double *)calloc((size_t)N * 3, sizeof *eye);
    float *out[3];
    long chose[3][PDS__SELECT_ESTIMATES], through[3];
    static const int threads[3] = {1, 2, 5};
    uint64_t r = 12345;
    int i, k, c, used = 0;
    REQUIRE(t, N >= PDS__PARALLEL_PIXELS, "the image is shared out");
    for (k = 0; k < 3; k++) out[k] = (float *)malloc(sizeof(float) * 3 * N);
    REQUIRE(t, photon && neg && eye && out[0] && out[1] && out[2], "memory");
    for (i = 0; i < N; i++) {
        int px = i % W, py = i / W;
        double truth = 2.0 + sin(0.05 * px) * cos(0.07 * py), u[3];
        for (k = 0; k < 3; k++) {
            r = r * 6364136223846793005ULL + 1442695040888963407ULL;
            u[k] = (double)(r >> 11) * (1.0 / 9007199254740992.0) - 0.5;
        }
        /* four bands of columns: the pass's scale noisy (a blur wins),
           biased with the second scale right (the second), biased with
           the second noisy (the second blurred), alternating along the
           rows (a blur along them) */
        for (c = 0; c < 3; c++) {
            double chk = (px + py) % 2 ? 0.5 : -0.5, alt = px % 2 ? 0.5 : -0.5;
            double base = px < 120 ? truth + 0.6 * u[0] : px < 360 ? truth + 0.5 : truth + alt;
            double half = px < 120 ? truth + 1.2 * u[1] : px < 240 ? truth + 0.02 * u[1] : truth + chk;
            sel_set(photon, neg, i, c, base + 0.1 * c, K);
            sel_set(photon, neg, i, PDS__SEL_HALF + c, half + 0.1 * c, K);
            sel_set(photon, neg, i, PDS__SEL_ODD + c, 0.5 * (truth + 0.1 * c) + 0.4 * u[c], K);
        }
        photon[PDS__STRIDE_SELECT * i + PDS__SEL_ODDS].lo = K / 2;
        sel_set(photon, neg, i, PDS__SEL_VALID, 3.0 * truth + 0.3 + 2.0 * u[2], K);
        /* patches that take part, edges along every 37th column and 23rd row */
        photon[PDS__STRIDE_SELECT * i + PDS__SEL_COUNT].lo = ((px / 60 + py / 50) % 3) ? K : 0;
        photon[PDS__STRIDE_SELECT * i + PDS__SEL_COUNT].hi =
            (px % 37 == 36 ? 1u : 0u) | (py % 23 == 22 ? (uint64_t)1 << 32 : 0u);
    }
    for (k = 0; k < 3; k++) {
        pds__choice_report report = {NULL, NULL, NULL, 0.0, NULL};
        report.chose = chose[k];
        report.through = &through[k];
        through[k] = 0;
        memset(chose[k], 0, sizeof chose[k]);
        REQUIRE(t, pds__partial_image(eye, photon, neg, PDS__STRIDE_SELECT, W, H, 1000.0, 1.0, K, out[k], threads[k],
                                      &report) == 0,
                "image on %d threads", threads[k]);
    }
    for (k = 0; k < PDS__SELECT_ESTIMATES; k++) used += chose[0][k] > 0;
    CHECK(t, used >= 4, "the noisy sums took %d of the candidates: %ld %ld %ld %ld %ld %ld %ld %ld", used, chose[0][0],
          chose[0][1], chose[0][2], chose[0][3], chose[0][4], chose[0][5], chose[0][6], chose[0][7]);
    CHECK(t, through[0] > 1000, "only %ld pixels seen through glass took a blur", through[0]);
    for (k = 1; k < 3; k++) {
        CHECK(t, memcmp(out[0], out[k], sizeof(float) * 3 * N) == 0, "%d threads: the image differs", threads[k]);
        CHECK(t, memcmp(chose[0], chose[k], sizeof chose[0]) == 0 && through[0] == through[k],
              "%d threads: the choices differ", threads[k]);
    }
    free(photon);
    free(neg);
    free(eye);
    for (k = 0; k < 3; k++) free(out[k]);
}

/* A lamp met from its front ends a caustic photon, as it ends an eye path
   and a global photon: a point light under a ceiling lights it by way of a
   mirror floor, and a dim quad light halfway, facing down, shadows the
   middle of the ceiling (its square of half-width 0.5, seen from the
   light's mirror image 1.95 below the floor, spreads to 0.57 at the
   ceiling). Photons going down pass the quad from behind, where it is not
   there; coming back up they meet its front. The camera, between the quad
   and the ceiling, looks straight up (caustics only, progressive PDS, so
   that the small core runs it too): its middle 4 x 4 pixels get 2e-5 of
   what its corners get. Passing through, the photons lit the middle 1.02
   times as brightly as the corners. */
static void progressive_defaults(pds_options *o)
{
    o->progressive = 1;
}

static void test_pds_caustic_photons_end_at_a_light_they_meet(pds_test_ctx *t)
{
    static const char text[] =
        "camera { position 0 1.6 0.000001 look_at 0 2 0 up 0 0 -1 fov 130 resolution 24 24 spp 1 }\n"
        "material white diffuse { albedo 0.75 }\n"
        "material mirror mirror { reflectance 1 }\n"
        "quad { material mirror size 4 4 }\n"
        "quad { material white size 6 6 rotate 180 1 0 0 translate 0 2 0 }\n"
        "light point { position 0 1.95 0 power 100 }\n"
        "light quad { center 0 1.5 0 edge1 1 0 0 edge2 0 0 1 radiance 0.001 }\n";
    pds_image img = {0, 0, NULL};
    double middle = 0.0, corners = 0.0;
    int x, y, c;
    REQUIRE(t, photon_render_text(text, PDS_METHOD_PDS, 50000, 12.0, PDS_PATHS_CAUSTICS_ONLY, 2, &img, NULL,
                                  progressive_defaults),
            "render");
    for (y = 0; y < 24; y++)
        for (x = 0; x < 24; x++)
            for (c = 0; c < 3; c++) {
                double v = img.rgb[3 * (y * 24 + x) + c];
                if (x >= 10 && x < 14 && y >= 10 && y < 14) middle += v / 16.0;
                if ((x < 3 || x >= 21) && (y < 3 || y >= 21)) corners += v / 36.0;
            }
    CHECK(t, corners > 0.0 && middle < 0.01 * corners, "the middle %g against the corners %g", middle, corners);
    pds_image_free(&img);
}

/* Footprints folded at walls (pds__splat_wall). A flat mirror throws a
   directional light onto the floor at 45 degrees, a uniform caustic that
   runs up to a thin wall (0.01 thick, 0.6 high) and none beyond it (the
   wall shades the far side). Seen straight from above (caustics only,
   8,000 photons, progressive PDS at s_1 8, so that footprints are a few
   pixels wide): the three columns of pixels beside the wall on the lit
   side get the patch's own light within 2% (measured 1.000-1.003, seeds
   0-3), and the floor from 0.07 to 0.21 beyond the wall none at all.
   Without walls the same pixels get 12% less (the kernels reach under the
   wall; the nearest column 26% less) and the far side 3.1% of the patch
   (the kernels reach through the wall). */
static void walls_tweak(pds_options *o)
{
    o->progressive = 1;
    o->pass_smoothing = 8.0;
}

static void no_walls_tweak(pds_options *o)
{
    walls_tweak(o);
    o->walls = 0;
}

static void test_pds_footprints_fold_at_a_wall(pds_test_ctx *t)
{
    static const char text[] =
        "camera { position 0 4 0 look_at 0 0 0 up 0 0 -1 fov 40 resolution 64 64 spp 4 }\n"
        "material floor diffuse { albedo 0.8 }\n"
        "material mirror conductor { preset silver }\n"
        "light directional { direction -1 -1 0 irradiance 1 rect 1.3 4 0  1.5 -1.5 0  0 0 3 }\n"
        "quad { material floor size 8 8 }\n"
        "box { material floor size 0.01 0.6 3 translate 0.3 0.3 0 }\n"
        "quad { material mirror size 3 4 rotate -90 0 0 1 translate -1.7 1.5 0 }\n";
    int pass;
    for (pass = 0; pass < 2; pass++) {
        pds_image img = {0, 0, NULL};
        double patch = 0.0, beside = 0.0, beyond = 0.0;
        int np = 0, nn = 0, nf = 0, x, y, c;
        REQUIRE(t, photon_render_text(text, PDS_METHOD_PDS, 8000, 12.0, PDS_PATHS_CAUSTICS_ONLY, 2, &img, NULL,
                                      pass == 0 ? walls_tweak : no_walls_tweak),
                "render");
        for (y = 4; y < 60; y++)
            for (x = 0; x < 64; x++) {
                double px = floor_point(4.0, 40.0, 64, x, y).x - 0.3, v = 0.0; /* from the wall's middle */
                for (c = 0; c < 3; c++) v += img.rgb[3 * (y * 64 + x) + c] / 3.0;
                /* the wall hides the floor to 0.05 beyond it from this camera */
                if (px > -0.85 && px < -0.43) patch += v, np++;
                if (px > -0.15 && px < -0.02) beside += v, nn++;
                if (px > 0.07 && px < 0.21) beyond += v, nf++;
            }
        REQUIRE(t, np > 0 && nn > 0 && nf > 0 && patch > 0.0, "the pixels: %d %d %d", np, nn, nf);
        patch /= np;
        beside /= nn;
        beyond /= nf;
        if (pass == 0)
            CHECK(t, fabs(beside / patch - 1.0) < 0.02 && beyond == 0.0,
                  "walls: beside the wall %g of the patch, beyond it %g", beside / patch, beyond / patch);
        else
            CHECK(t, beside / patch < 0.95 && beyond > 0.01 * patch,
                  "no walls: beside the wall %g of the patch, beyond it %g (the test should see both)", beside / patch,
                  beyond / patch);
        pds_image_free(&img);
    }
}

/* The noise a mean over a box of radius r applied three times keeps
   (pds__scale_choice's significance rule): the sum of its weights'
   squares is the chance that two sums of three independent uniform
   steps in -r..r are equal, counted here over every pair of triples;
   and 141/729 by hand for r = 1 (weights 1 3 6 7 6 3 1 over 27). */
static void test_box3_square_sum_is_the_chance_two_triple_sums_agree(pds_test_ctx *t)
{
    int radii[3] = {1, 3, PDS__SELECT_RADIUS}, k;
    CHECK_NEAR(t, pds__box3_square_sum(1), 141.0 / 729.0, 1e-15);
    CHECK_NEAR(t, pds__box3_square_sum(0), 1.0, 0.0);
    for (k = 0; k < 3; k++) {
        int r = radii[k], n = 2 * r + 1, a, b;
        double equal = 0.0, triples = (double)n * n * n;
        for (a = 0; a < n * n * n; a++)
            for (b = 0; b < n * n * n; b++)
                equal += a % n + a / n % n + a / (n * n) == b % n + b / n % n + b / (n * n);
        CHECK_NEAR(t, pds__box3_square_sum(r), equal / (triples * triples), 1e-14);
    }
}

static const pds_test_case tests_pds[] = {
    {"pds_caustic_photons_end_at_a_light_they_meet", test_pds_caustic_photons_end_at_a_light_they_meet},
    {"pds_footprints_fold_at_a_wall", test_pds_footprints_fold_at_a_wall},
    {"pds_whole_pixel_kernel_is_each_pixels_own_average", test_pds_whole_pixel_kernel_is_each_pixels_own_average},
    {"pds_whole_pixels_are_found_through_the_image_as_through_their_tree",
     test_pds_whole_pixels_are_found_through_the_image_as_through_their_tree},
    {"eye_map_rebuild_in_its_buffers_is_a_fresh_build", test_eye_map_rebuild_in_its_buffers_is_a_fresh_build},
    {"pds_splat_finds_single_and_merged_vertices_as_brute_force_does",
     test_pds_splat_finds_single_and_merged_vertices_as_brute_force_does},
    {"pds_second_scale_is_the_pass_at_half_the_smoothing", test_pds_second_scale_is_the_pass_at_half_the_smoothing},
    {"pds_validation_is_the_light_tracers_image_of_its_own_photons",
     test_pds_validation_is_the_light_tracers_image_of_its_own_photons},
    {"pds_scale_choice_takes_the_estimate_the_validation_says_is_closest",
     test_pds_scale_choice_takes_the_estimate_the_validation_says_is_closest},
    {"pds_scale_choice_makes_no_choice_where_there_is_no_light",
     test_pds_scale_choice_makes_no_choice_where_there_is_no_light},
    {"pds_through_choice_blurs_where_the_halves_say_noise", test_pds_through_choice_blurs_where_the_halves_say_noise},
    {"pds_image_making_is_identical_for_any_thread_count", test_pds_image_making_is_identical_for_any_thread_count},
    {"pds_large_default_image_is_identical_for_any_thread_count",
     test_pds_large_default_image_is_identical_for_any_thread_count},
    {"box3_square_sum_is_the_chance_two_triple_sums_agree", test_box3_square_sum_is_the_chance_two_triple_sums_agree},
    {"eye_round_ratio_gives_photons_the_time_single_samples_do_not_need",
     test_eye_round_ratio_gives_photons_the_time_single_samples_do_not_need},
    {"pds_splat_roulette_keeps_the_mean_and_follows_the_footprints_area",
     test_pds_splat_roulette_keeps_the_mean_and_follows_the_footprints_area},
    {"pds_eye_merge_takes_the_spread_of_samples_seen_through_glass",
     test_pds_eye_merge_takes_the_spread_of_samples_seen_through_glass},
    {"pds_defocused_needles_widen_and_focused_ones_do_not", test_pds_defocused_needles_widen_and_focused_ones_do_not},
    {"pds_kernel_averaged_over_a_pixel_matches_fine_quadrature",
     test_pds_kernel_averaged_over_a_pixel_matches_fine_quadrature},
    {"pds_eye_merge_sums_a_pixels_samples_at_the_pixels_centre", test_pds_eye_merge_sums_a_pixels_samples_at_the_pixels_centre},
    {"pds_eye_merge_keeps_a_partly_covered_pixels_samples", test_pds_eye_merge_keeps_a_partly_covered_pixels_samples},
    {"pds_footprint_width_floor_raises_both_semi_axes", test_pds_footprint_width_floor_raises_both_semi_axes},
    {"progressive_pds_schedule_shrinks_footprint_areas_as_i_to_alpha_minus_1",
     test_progressive_pds_schedule_shrinks_footprint_areas_as_i_to_alpha_minus_1},
    {"progressive_pds_error_falls_as_photons_are_added", test_progressive_pds_error_falls_as_photons_are_added},
    {"progressive_pds_under_a_time_budget_runs_whole_passes", test_progressive_pds_under_a_time_budget_runs_whole_passes},
    {"eye_rounds_are_runs_of_consecutive_passes", test_eye_rounds_are_runs_of_consecutive_passes},
    {"light_traced_reference_meets_the_analytic_caustic", test_light_traced_reference_meets_the_analytic_caustic},
    {"pds_eye_rounds_keep_the_analytic_image", test_pds_eye_rounds_keep_the_analytic_image},
    {"pds_caustic_eye_rounds_keep_round_0s_whole_pixels", test_pds_caustic_eye_rounds_keep_round_0s_whole_pixels},
    {"pds_photon_budget_takes_eye_rounds_in_proportion_to_its_photons",
     test_pds_photon_budget_takes_eye_rounds_in_proportion_to_its_photons},
    {"pds_time_budget_eye_rounds_keep_the_analytic_image", test_pds_time_budget_eye_rounds_keep_the_analytic_image},
    {"pds_footprint_widening_keeps_the_major_axis", test_pds_footprint_widening_keeps_the_major_axis},
    {"pds_footprint_widening_conserves_the_caustic_light", test_pds_footprint_widening_conserves_the_caustic_light},
    {"pds_plane_mirror_reflects_the_mirrored_point_light", test_pds_plane_mirror_reflects_the_mirrored_point_light},
    {"pds_glass_slab_transmits_both_fresnel_factors_and_absorption",
     test_pds_glass_slab_transmits_both_fresnel_factors_and_absorption},
    {"pds_splatted_flux_equals_transmitted_flux_for_any_smoothing",
     test_pds_splatted_flux_equals_transmitted_flux_for_any_smoothing},
    {"pds_sphere_caustic_agrees_with_path_traced_caustics", test_pds_sphere_caustic_agrees_with_path_traced_caustics},
    {"pds_image_is_identical_for_any_thread_count", test_pds_image_is_identical_for_any_thread_count},
    {"pds_full_image_is_eye_pass_plus_splats", test_pds_full_image_is_eye_pass_plus_splats},
    {"pds_footprint_debug_image_shows_anisotropy", test_pds_footprint_debug_image_shows_anisotropy},
    {"pds_sub_photons_tile_the_parent", test_pds_sub_photons_tile_the_parent},
    {"pds_split_photons_carry_their_parents_flux", test_pds_split_photons_carry_their_parents_flux},
};

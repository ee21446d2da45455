/* tests/test_envlight.c - the environment light (constant radiance, CIE
   clear sky, sun disk) and the thin-lens camera against known answers:
   a Lambertian plane under a constant sky and under the sun, the sampling
   pdf's integral, the photons' total flux, the sun's caustic through a
   glass ball by the path tracer and by the photon methods, the circle of
   confusion, the pinhole as the lens of radius 0, and the scene hash. */

/* A plane of albedo 0.5 filling the view of a camera looking down. */
#define TENV_PLANE                                                                                  \
    "camera { position 0 2 0.000001 look_at 0 0 0 up 0 0 -1 fov 30 resolution 16 16 spp 16 }\n"  \
    "material white diffuse { albedo 0.5 }\n"                                                       \
    "quad { material white size 40 40 }\n"

static double tenv_mean3(const pds_image *img)
{
    return (image_mean(img, 0) + image_mean(img, 1) + image_mean(img, 2)) / 3.0;
}

static int tenv_render(const char *text, pds_method method, int spp, long photons, pds_paths paths, pds_image *img)
{
    pds_options opt;
    pds_options_default(&opt);
    opt.method = method;
    opt.spp = spp;
    opt.photons = photons;
    opt.paths = paths;
    opt.progressive = 0;
    opt.threads = 2;
    return render_text(text, &opt, img, NULL);
}

/* Under a constant environment of radiance L a Lambertian plane receives
   E = pi L from the upper hemisphere and reflects (albedo / pi) E =
   albedo L. The ground below (3 more) must not count: the plane sees
   only the upper hemisphere. Path tracing, and the eye pass of pds (its
   photons find no specular surface). */
static void test_env_constant_sky_gives_a_plane_radiance_times_albedo(pds_test_ctx *t)
{
    static const char scene[] = TENV_PLANE "light environment { radiance 1 ground 3 }\n";
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    REQUIRE(t, tenv_render(scene, PDS_METHOD_PT, 16, 0, PDS_PATHS_ALL, &a), "pt");
    CHECK(t, fabs(tenv_mean3(&a) - 0.5) < 0.015, "pt: %g, expected 0.5", tenv_mean3(&a));
    REQUIRE(t, tenv_render(scene, PDS_METHOD_PDS, 16, 2000, PDS_PATHS_ALL, &b), "pds");
    CHECK(t, fabs(tenv_mean3(&b) - 0.5) < 0.015, "pds: %g, expected 0.5", tenv_mean3(&b));
    pds_image_free(&a);
    pds_image_free(&b);
}

/* The sun alone, a disk of angular radius alpha and irradiance E at
   normal incidence, 30 degrees from the zenith: the plane receives the
   integral of Ls cos over the disk, n . (axis Ls pi sin^2 alpha) =
   E cos 30 exactly, and reflects 0.5 / pi of it. Next-event estimation
   picks the sun; MIS against the BSDF rays that hit it. */
static void test_env_sun_gives_a_plane_its_irradiance_times_cos(pds_test_ctx *t)
{
    static const char scene[] =
        TENV_PLANE "light environment { sun 2 sun_direction 0.5 0.8660254 0 sun_radius 3 }\n";
    pds_image a = {0, 0, NULL};
    double want = 0.5 / PDS__PI * 2.0 * cos(PDS__PI / 6.0);
    REQUIRE(t, tenv_render(scene, PDS_METHOD_PT, 16, 0, PDS_PATHS_ALL, &a), "pt");
    CHECK(t, fabs(tenv_mean3(&a) / want - 1.0) < 0.01, "pt: %g, expected %g", tenv_mean3(&a), want);
    pds_image_free(&a);
}

/* The CIE clear sky (S 011/E:2003 type 12: a = -1, b = -0.32, c = 10,
   d = -3, e = 0.45), written out here from zenith angle Z, angle to the
   sun chi and the sun's zenith angle Zs, relative to the zenith. */
static double tenv_cie(double z, double chi, double zs)
{
    double phi_z = 1.0 - exp(-0.32 / cos(z)), phi_0 = 1.0 - exp(-0.32);
    double f_chi = 1.0 + 10.0 * (exp(-3.0 * chi) - exp(-3.0 * PDS__PI / 2.0)) + 0.45 * cos(chi) * cos(chi);
    double f_zs = 1.0 + 10.0 * (exp(-3.0 * zs) - exp(-3.0 * PDS__PI / 2.0)) + 0.45 * cos(zs) * cos(zs);
    return f_chi * phi_z / (f_zs * phi_0);
}

/* The sky alone (sun 45 degrees high, no sun disk): a horizontal plane
   receives E = sky x the integral of Y cos Z over the upper hemisphere,
   here by a midpoint rule in (Z, azimuth) of the formula above, and
   reflects 0.5 / pi of it. Also L itself in a few directions. */
static void test_env_clear_sky_matches_the_cie_formula(pds_test_ctx *t)
{
    static const char scene[] = TENV_PLANE "light environment { sky 0.4 sun_direction 1 1 0 }\n";
    pds_image a = {0, 0, NULL};
    pds_error err;
    pds_scene *s = scene_from_text(scene, &err);
    double e = 0.0, want, zs = PDS__PI / 4.0;
    int i, j, bad = 0;
    REQUIRE(t, s != NULL, "%s", err.text);
    for (i = 0; i < 400; i++) {
        double z = (i + 0.5) * (PDS__PI / 2.0) / 400;
        for (j = 0; j < 400; j++) {
            double az = (j + 0.5) * 2.0 * PDS__PI / 400;
            /* the sun at azimuth 0: cos chi = cos z cos zs + sin z sin zs cos az */
            double cchi = cos(z) * cos(zs) + sin(z) * sin(zs) * cos(az);
            double y = tenv_cie(z, acos(fmax(-1.0, fmin(1.0, cchi))), zs);
            pds__v3 w = pds__v(sin(z) * cos(az), cos(z), sin(z) * sin(az));
            e += y * cos(z) * sin(z) * (PDS__PI / 2.0 / 400) * (2.0 * PDS__PI / 400);
            if (i % 50 == 7 && j % 50 == 3) {
                /* the same direction in the scene's frame (sun in the x-y plane) */
                double L[3];
                pds__env_radiance(pds_scene_light(s, 0), w, L);
                if (!(fabs(L[1] / (0.4 * y) - 1.0) < 1e-9)) bad++;
            }
        }
    }
    CHECK(t, bad == 0, "%d directions where L differs from 0.4 Y", bad);
    e *= 0.4;
    want = 0.5 / PDS__PI * e;
    REQUIRE(t, tenv_render(scene, PDS_METHOD_PT, 16, 0, PDS_PATHS_ALL, &a), "pt");
    CHECK(t, fabs(tenv_mean3(&a) / want - 1.0) < 0.015, "pt: %g, expected %g", tenv_mean3(&a), want);
    pds_image_free(&a);
    pds_scene_free(s);
}

/* A light record as the scene parser leaves it (position, radius, area
   and power are the scene's; here a unit sphere at the origin). */
static pds_light tenv_light(void)
{
    pds_light l;
    memset(&l, 0, sizeof l);
    l.type = PDS_LIGHT_ENVIRONMENT;
    l.material = -1;
    l.up = pds__v(0.0, 1.0, 0.0);
    l.sun_direction = pds__normalize(pds__v(0.3, 0.5, -0.2));
    l.sun_radius_deg = 2.0;
    l.radius = 1.0;
    l.area = PDS__PI;
    return l;
}

/* The mixture pdf (sun cone, two hemispheres) integrates to 1 over the
   sphere: a midpoint rule in coordinates about the sun's direction, fine
   inside 3 sun radii, coarser outside. The sampler returns the pdf of
   the direction it made, and puts the sun's share of directions in its
   disk. */
static void test_env_sampling_pdf_integrates_to_one(pds_test_ctx *t)
{
    pds_light l = tenv_light();
    pds__light_table lt;
    pds_error err;
    pds__v3 b1, b2, axis;
    double alpha = l.sun_radius_deg * PDS__PI / 180.0, sum = 0.0, cos_a = cos(alpha);
    const double edges[3] = {0.0, 3.0 * alpha, PDS__PI};
    const int cells[2] = {600, 1500};
    long i, in_sun = 0, n = 200000, bad = 0;
    int part, j, k;
    l.sky[0] = 0.3;
    l.sky[1] = 0.4;
    l.sky[2] = 0.6;
    l.ground[1] = 0.2;
    l.radiance[2] = 0.05;
    l.sun_irradiance[0] = l.sun_irradiance[1] = l.sun_irradiance[2] = 1.0;
    REQUIRE(t, pds__lights_prepare(&lt, &l, 1, NULL, &err) == PDS_OK, "%s", err.text);
    CHECK(t, lt.env_p[0] > 0.05 && lt.env_p[1] > 0.05 && lt.env_p[2] > 0.05, "parts %g %g %g", lt.env_p[0],
          lt.env_p[1], lt.env_p[2]);
    axis = pds__normalize(l.sun_direction);
    pds__onb(axis, &b1, &b2);
    for (part = 0; part < 2; part++) {
        double dth = (edges[part + 1] - edges[part]) / cells[part];
        for (j = 0; j < cells[part]; j++) {
            double th = edges[part] + (j + 0.5) * dth;
            for (k = 0; k < 720; k++) {
                double ph = 2.0 * PDS__PI * (k + 0.5) / 720.0;
                pds__v3 w = pds__add(pds__scale(axis, cos(th)),
                                     pds__add(pds__scale(b1, sin(th) * cos(ph)), pds__scale(b2, sin(th) * sin(ph))));
                sum += pds__env_pdf(&l, lt.env_p, w) * sin(th) * dth * (2.0 * PDS__PI / 720.0);
            }
        }
    }
    CHECK(t, fabs(sum - 1.0) < 2e-3, "integral of the pdf %.6f", sum);
    for (i = 0; i < n; i++) {
        pds__v3 w;
        double pdf = pds__env_sample(&l, lt.env_p, tlights_u(7, (uint64_t)i, 0), tlights_u(7, (uint64_t)i, 1), &w);
        if (!(fabs(pdf / pds__env_pdf(&l, lt.env_p, w) - 1.0) < 1e-12) || !(fabs(pds__length(w) - 1.0) < 1e-12)) bad++;
        in_sun += pds__dot(w, axis) >= cos_a;
    }
    CHECK(t, bad == 0, "%ld samples whose pdf disagrees with pds__env_pdf", bad);
    {
        /* the sun's share: p_sun plus the hemisphere's samples that fall
           into its cone, p_up Omega_s / (2 pi) */
        double omega = 2.0 * PDS__PI * (1.0 - cos_a), want = lt.env_p[0] + lt.env_p[1] * omega / (2.0 * PDS__PI);
        double got = (double)in_sun / n, sd = sqrt(want * (1.0 - want) / n);
        CHECK(t, fabs(got - want) < 5.0 * sd, "share in the sun %g, expected %g", got, want);
    }
    pds__lights_free(&lt);
}

/* Photons from the environment carry, on average, the flux that crosses
   the bounding sphere: pi R^2 times the integral of L over all
   directions. Constant radiance, ground and sun have that integral in
   closed form: 4 pi L + 2 pi G + Ls Omega_s with Ls = E / (pi sin^2 a).
   Every photon starts outside the sphere and travels along a line that
   meets it (its disk covers the sphere's shadow). */
static void test_env_photons_carry_the_flux_through_the_bounding_sphere(pds_test_ctx *t)
{
    pds_light l = tenv_light();
    pds__light_table lt;
    pds_error err;
    double sum[3] = {0.0, 0.0, 0.0}, want[3], a = l.sun_radius_deg * PDS__PI / 180.0;
    long i, n = 200000, outside = 0, miss = 0;
    int c;
    l.position = pds__v(1.0, 2.0, -0.5);
    l.radius = 3.0;
    l.area = PDS__PI * 9.0;
    for (c = 0; c < 3; c++) {
        l.radiance[c] = 0.1 * (c + 1);
        l.ground[c] = 0.3;
        l.sun_irradiance[c] = 2.0 - 0.5 * c;
        want[c] = l.area * (4.0 * PDS__PI * l.radiance[c] + 2.0 * PDS__PI * l.ground[c] +
                            l.sun_irradiance[c] / (PDS__PI * sin(a) * sin(a)) * 2.0 * PDS__PI * (1.0 - cos(a)));
    }
    REQUIRE(t, pds__lights_prepare(&lt, &l, 1, NULL, &err) == PDS_OK, "%s", err.text);
    for (i = 0; i < n; i++) {
        pds__light_emit e;
        double u[4];
        pds__v3 q;
        for (c = 0; c < 4; c++) u[c] = tlights_u(11, (uint64_t)i, (uint64_t)c);
        if (!pds__light_emit_sample(&lt, &l, 0, NULL, u, &e)) continue;
        for (c = 0; c < 3; c++) sum[c] += e.flux[c];
        outside += pds__length(pds__sub(e.pos, l.position)) >= l.radius * (1.0 - 1e-12);
        /* closest approach of the photon's line to the centre */
        q = pds__sub(l.position, e.pos);
        q = pds__sub(q, pds__scale(e.dir, pds__dot(q, e.dir)));
        miss += !(pds__length(q) <= l.radius * (1.0 + 1e-9));
    }
    for (c = 0; c < 3; c++)
        CHECK(t, fabs(sum[c] / n / want[c] - 1.0) < 0.01, "channel %d: mean flux %g, expected %g", c, sum[c] / n,
              want[c]);
    CHECK(t, outside == n && miss == 0, "%ld of %ld photons start outside, %ld miss the sphere", outside, n, miss);
    pds__lights_free(&lt);
}

/* The sun (8 degrees wide, so that path tracing finds it through the
   ball) above a glass ball on a floor: the caustic under the ball as the
   path tracer sees it (caustics only, brute force: floor, ball, sun by
   BSDF sampling) and as pds and pm make it from photons. The total caustic
   light must agree within 6%: the path tracer's own noise at 1024 samples
   is about 2% (measured over seeds: 0.0749 to 0.0775), and it also counts
   caustics seen from the floor through the ball (L S+ D S+ D E), which the
   photon methods leave out (they measured 2-3% below pt's mean). */
static const char tenv_ball_scene[] =
    "camera { position 0 3 0.000001 look_at 0 0 0 up 0 0 -1 fov 40 resolution 32 32 spp 4 }\n"
    "material floor diffuse { albedo 0.8 }\n"
    "material glass dielectric { ior 1.5 }\n"
    "quad { material floor size 6 6 }\n"
    "sphere { material glass radius 0.35 segments 64 rings 32 translate 0 0.8 0 }\n"
    "light environment { sun 3 sun_direction 0.2 1 0.1 sun_radius 8 }\n";

static void test_env_sun_caustic_agrees_between_pt_and_photon_methods(pds_test_ctx *t)
{
    pds_image ref = {0, 0, NULL}, a = {0, 0, NULL}, b = {0, 0, NULL};
    double r;
    REQUIRE(t, tenv_render(tenv_ball_scene, PDS_METHOD_PT, 1024, 0, PDS_PATHS_CAUSTICS_ONLY, &ref), "pt");
    REQUIRE(t, tenv_render(tenv_ball_scene, PDS_METHOD_PDS, 4, 100000, PDS_PATHS_CAUSTICS_ONLY, &a), "pds");
    REQUIRE(t, tenv_render(tenv_ball_scene, PDS_METHOD_PM, 4, 100000, PDS_PATHS_CAUSTICS_ONLY, &b), "pm");
    CHECK(t, image_mean(&ref, 1) > 0.02, "the path tracer sees a caustic (%g)", image_mean(&ref, 1));
    r = tenv_mean3(&a) / tenv_mean3(&ref);
    CHECK(t, fabs(r - 1.0) < 0.06, "pds / pt caustic light %g (%g vs %g)", r, tenv_mean3(&a), tenv_mean3(&ref));
    r = tenv_mean3(&b) / tenv_mean3(&ref);
    CHECK(t, fabs(r - 1.0) < 0.06, "pm / pt caustic light %g (%g vs %g)", r, tenv_mean3(&b), tenv_mean3(&ref));
    pds_image_free(&ref);
    pds_image_free(&a);
    pds_image_free(&b);
}

/* The photon differentials' extent of an environment photon (eqs. 5-6
   of the PDS paper): A_e = the area of the disk it leaves from, omega_e =
   0 (a thin parallel beam, normal = direction). Aimed at the specular
   objects (pds), the disk is their bounding sphere's cross-section,
   pulled back outside the scene: every aimed photon starts outside the
   scene's sphere and its line crosses the target's disk. */
static void test_env_photons_are_parallel_beams_with_their_share_of_the_disk(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text(tenv_ball_scene, &err);
    const pds_light *l;
    pds__target tg;
    long i, bad_extent = 0, bad_aim = 0, n = 2000;
    REQUIRE(t, s != NULL, "%s", err.text);
    l = pds_scene_light(s, 0);
    tg = pds__specular_target(s);
    REQUIRE(t, tg.any && tg.radius < l->radius, "target radius %g, scene radius %g", tg.radius, l->radius);
    for (i = 0; i < n; i++) {
        double u[5];
        pds_emission e;
        pds__photon_start ph;
        int c;
        for (c = 0; c < 5; c++) u[c] = tlights_u(13, (uint64_t)i, (uint64_t)c);
        if (pds_scene_emit(s, 0, u, &e)) {
            pds_vec3 d = pds__sub(e.normal, e.direction);
            if (!(fabs(e.area / (PDS__PI * l->radius * l->radius) - 1.0) < 1e-12) || e.solid_angle != 0.0 ||
                !(pds__length(d) < 1e-12))
                bad_extent++;
        }
        if (pds__emit_caustic_photon(s, &tg, 0, u, &ph)) {
            pds__v3 q = pds__sub(tg.centre, ph.pos);
            q = pds__sub(q, pds__scale(ph.dir, pds__dot(q, ph.dir)));
            if (!(fabs(ph.area / (PDS__PI * tg.radius * tg.radius) - 1.0) < 1e-12) || ph.solid_angle != 0.0 ||
                !(pds__length(q) <= tg.radius * (1.0 + 1e-9)) ||
                !(pds__length(pds__sub(ph.pos, l->position)) >= l->radius))
                bad_aim++;
        }
    }
    CHECK(t, bad_extent == 0, "%ld of %ld emitted photons with the wrong extent", bad_extent, n);
    CHECK(t, bad_aim == 0, "%ld of %ld aimed photons miss the target or start inside the scene", bad_aim, n);
    pds_scene_free(s);
}

/* --- the thin lens ------------------------------------------------------- */

/* The image of a small disk light (radius rho, facing the camera, on the
   axis at distance z) on black: centroid and second moment of the
   brightness about it, in pixels. A uniform disk of radius r has
   E[d^2] = r^2 / 2; convolutions add second moments: the source's disk,
   the circle of confusion and the pixel's box (1/12 per axis) for the
   sample position and again for the measurement on the pixel grid. */
static double tenv_blur_radius(const pds_image *img, double source_px)
{
    double sw = 0.0, sx = 0.0, sy = 0.0, sxx = 0.0, m2;
    int x, y;
    for (y = 0; y < img->height; y++)
        for (x = 0; x < img->width; x++) {
            double v = img->rgb[3 * ((size_t)y * img->width + x) + 1];
            sw += v;
            sx += v * (x + 0.5);
            sy += v * (y + 0.5);
        }
    if (!(sw > 0.0)) return -1.0;
    sx /= sw;
    sy /= sw;
    for (y = 0; y < img->height; y++)
        for (x = 0; x < img->width; x++) {
            double v = img->rgb[3 * ((size_t)y * img->width + x) + 1], dx = x + 0.5 - sx, dy = y + 0.5 - sy;
            sxx += v * (dx * dx + dy * dy);
        }
    m2 = sxx / sw - source_px * source_px / 2.0 - 4.0 / 12.0;
    return m2 > 0.0 ? sqrt(2.0 * m2) : 0.0;
}

static int tenv_lens_render(double aperture, double focus, double z, double rho, pds_image *img)
{
    char text[1024];
    pds_options opt;
    snprintf(text, sizeof text,
             "camera { position 0 0 0 look_at 0 0 -1 fov 30 resolution 64 64 spp 64 aperture %.17g "
             "focus_distance %.17g }\n"
             "light disk { center 0 0 %.17g normal 0 0 1 radius %.17g radiance 1 }\n",
             aperture, focus, -z, rho);
    pds_options_default(&opt);
    opt.method = PDS_METHOD_PT;
    opt.threads = 2;
    return render_text(text, &opt, img, NULL);
}

/* Lens radius A = 0.3 focused at F = 4 (fov 30, 64 pixels): a light on
   the plane in focus stays as sharp as the pinhole draws it; one at
   z = 2 spreads over the circle of confusion of radius A |z - F| / z on
   the plane in focus, A |z - F| / (z F tan 15deg) x 32 = 8.96 pixels. */
static void test_thin_lens_blurs_to_the_circle_of_confusion(pds_test_ctx *t)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    double A = 0.3, F = 4.0, px_per_m_at_F = 32.0 / (F * tan(PDS__PI / 12.0));
    double rho_sharp = 0.02, rho_near = 0.06, got, want;
    REQUIRE(t, tenv_lens_render(A, F, F, rho_sharp, &a), "in focus");
    got = tenv_blur_radius(&a, rho_sharp * px_per_m_at_F);
    CHECK(t, got >= 0.0 && got < 0.5, "a point in focus blurs by %g pixels", got);
    REQUIRE(t, tenv_lens_render(A, F, 2.0, rho_near, &b), "out of focus");
    want = A * fabs(2.0 - F) / 2.0 * px_per_m_at_F;
    got = tenv_blur_radius(&b, rho_near * 32.0 / (2.0 * tan(PDS__PI / 12.0)));
    CHECK(t, fabs(got / want - 1.0) < 0.02, "circle of confusion %g pixels, thin-lens formula %g", got, want);
    pds_image_free(&a);
    pds_image_free(&b);
}

/* aperture 0 is the pinhole, bit for bit, whatever the focus distance;
   with a lens the image changes (and pds's eye pass follows it). */
static void test_thin_lens_of_radius_0_is_the_pinhole_bit_for_bit(pds_test_ctx *t)
{
    static const char base[] =
        "camera { position 0 1.5 3 look_at 0 0.5 0 fov 40 resolution 24 16 spp 2%s }\n"
        "material floor diffuse { albedo 0.7 }\n"
        "material glass dielectric { ior 1.5 }\n"
        "quad { material floor size 6 6 }\n"
        "sphere { material glass radius 0.5 segments 32 rings 16 translate 0 0.5 0 }\n"
        "light environment { sky 0.3 sun 2 sun_direction 0.3 1 0.2 }\n";
    char text[1024];
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL}, c = {0, 0, NULL};
    size_t bytes;
    snprintf(text, sizeof text, base, "");
    REQUIRE(t, tenv_render(text, PDS_METHOD_PDS, 2, 5000, PDS_PATHS_ALL, &a), "pinhole");
    snprintf(text, sizeof text, base, " aperture 0 focus_distance 2");
    REQUIRE(t, tenv_render(text, PDS_METHOD_PDS, 2, 5000, PDS_PATHS_ALL, &b), "aperture 0");
    snprintf(text, sizeof text, base, " aperture 0.1 focus_distance 2");
    REQUIRE(t, tenv_render(text, PDS_METHOD_PDS, 2, 5000, PDS_PATHS_ALL, &c), "aperture 0.1");
    bytes = sizeof(float) * 3 * (size_t)a.width * a.height;
    CHECK(t, memcmp(a.rgb, b.rgb, bytes) == 0, "aperture 0 differs from the pinhole");
    CHECK(t, memcmp(a.rgb, c.rgb, bytes) != 0, "a lens changes nothing");
    pds_image_free(&a);
    pds_image_free(&b);
    pds_image_free(&c);
}

/* Lens samples and environment samples are functions of (seed, purpose,
   index): the same image, bit for bit, on 1 and 3 threads (pds and pt). */
static void test_env_and_lens_images_are_identical_for_any_thread_count(pds_test_ctx *t)
{
    static const char scene[] =
        "camera { position 0 1.5 3 look_at 0 0.5 0 fov 40 resolution 24 16 spp 2 aperture 0.1 }\n"
        "material floor diffuse { albedo 0.7 }\n"
        "material glass dielectric { ior 1.5 }\n"
        "quad { material floor size 6 6 }\n"
        "sphere { material glass radius 0.5 segments 32 rings 16 translate 0 0.5 0 }\n"
        "light environment { sky 0.3 ground 0.1 sun 2 sun_direction 0.3 1 0.2 sun_radius 2 }\n";
    static const pds_method methods[2] = {PDS_METHOD_PDS, PDS_METHOD_PT};
    int k;
    for (k = 0; k < 2; k++) {
        pds_options opt;
        pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
        pds_options_default(&opt);
        opt.method = methods[k];
        opt.photons = 5000;
        opt.threads = 1;
        REQUIRE(t, render_text(scene, &opt, &a, NULL), "1 thread");
        opt.threads = 3;
        REQUIRE(t, render_text(scene, &opt, &b, NULL), "3 threads");
        CHECK(t, memcmp(a.rgb, b.rgb, sizeof(float) * 3 * (size_t)a.width * a.height) == 0, "%s: 1 and 3 threads differ",
              pds_method_name(methods[k]));
        CHECK(t, tenv_mean3(&a) > 0.01, "%s: a black image", pds_method_name(methods[k]));
        pds_image_free(&a);
        pds_image_free(&b);
    }
}

/* Image-space caustics and the teaching views project points into a
   pinhole: with a lens they refuse, with a message. */
static void test_thin_lens_is_refused_by_isc_and_the_teaching_views(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text("camera { aperture 0.1 }\n"
                                   "material floor diffuse { albedo 0.7 }\n"
                                   "quad { material floor size 6 6 }\n"
                                   "light point { position 0 2 0 power 10 }\n",
                                   &err);
    pds_options opt;
    pds_image img = {0, 0, NULL};
    pds_debug dbg;
    REQUIRE(t, s != NULL, "%s", err.text);
    pds_options_default(&opt);
    opt.method = PDS_METHOD_ISC;
    CHECK(t, pds_render(s, &opt, &img, NULL, &err) == PDS_ERR_INVALID_ARG && strstr(err.text, "pinhole"),
          "isc: %s", err.text);
    pds_options_default(&opt);
    pds_debug_init(&dbg);
    dbg.views = 1u << PDS_DEBUG_LANDINGS;
    opt.debug = &dbg;
    CHECK(t, pds_render(s, &opt, &img, NULL, &err) == PDS_ERR_INVALID_ARG && strstr(err.text, "pinhole"),
          "views: %s", err.text);
    pds_debug_free(&dbg);
    pds_image_free(&img);
    pds_scene_free(s);
}

/* The README's example scene loads as described: one environment light
   with sky, ground and sun around the scene's bounding sphere, a camera
   with a lens; the light's power is pi R^2 times the integral of L (the
   sun's and the ground's parts in closed form, the sky's at least the
   zenith's value over the hemisphere, as the horizon is brighter). */
static void test_env_example_scene_loads_as_the_readme_says(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = NULL;
    const pds_light *l;
    double a, lower, upper;
    int c;
    REQUIRE(t, pds_scene_load("scenes/sky.scene", &s, &err) == PDS_OK, "%s", err.text);
    REQUIRE(t, pds_scene_light(s, 0) != NULL && pds_scene_light(s, 0)->type == PDS_LIGHT_ENVIRONMENT, "no environment");
    l = pds_scene_light(s, 0);
    CHECK(t, pds_scene_camera(s)->aperture > 0.0 && pds_scene_camera(s)->focus_distance > 0.0, "no lens");
    CHECK(t, fabs(l->area - PDS__PI * l->radius * l->radius) < 1e-9 * l->area, "area %g, radius %g", l->area, l->radius);
    a = l->sun_radius_deg * PDS__PI / 180.0;
    for (c = 0; c < 3; c++) {
        double sun = l->sun_irradiance[c] / (PDS__PI * sin(a) * sin(a)) * 2.0 * PDS__PI * (1.0 - cos(a));
        lower = l->area * (sun + 2.0 * PDS__PI * l->ground[c] + 2.0 * PDS__PI * l->sky[c]);
        upper = l->area * (sun + 2.0 * PDS__PI * l->ground[c] + 2.0 * PDS__PI * l->sky[c] * 10.0);
        CHECK(t, l->power[c] > lower && l->power[c] < upper, "channel %d: power %g outside (%g, %g)", c, l->power[c],
              lower, upper);
    }
    pds_scene_free(s);
}

/* --- the scene text and the hash ------------------------------------------- */

static unsigned long long tenv_hash(const char *text)
{
    pds_error err;
    pds_scene *s = scene_from_text(text, &err);
    unsigned long long h;
    if (!s) {
        printf("  scene: %s\n", err.text);
        return 0;
    }
    h = pds_scene_hash(s);
    pds_scene_free(s);
    return h;
}

/* Partial files are checked against the scene hash: every field of the
   environment and of the lens must change it; a pinhole's hash is the
   one it had before the lens existed (aperture 0, no focus distance). */
static void test_scene_hash_covers_the_environment_and_the_lens(pds_test_ctx *t)
{
    static const char *const variants[] = {
        "light environment { radiance 0.5 }",
        "light environment { radiance 0.5 sky 0.2 }",
        "light environment { radiance 0.5 ground 0.2 }",
        "light environment { radiance 0.5 up 0 0 1 }",
        "light environment { radiance 0.5 sun 1 }",
        "light environment { radiance 0.5 sun 1 sun_direction 1 1 0 }",
        "light environment { radiance 0.5 sun 1 sun_radius 2 }",
        "camera { aperture 0.1 } light environment { radiance 0.5 }",
        "camera { aperture 0.1 focus_distance 3 } light environment { radiance 0.5 }",
    };
    unsigned long long h[9];
    char text[512];
    int i, j;
    for (i = 0; i < 9; i++) {
        snprintf(text, sizeof text, "material w diffuse { albedo 0.5 }\nquad { material w size 2 2 }\n%s\n", variants[i]);
        h[i] = tenv_hash(text);
        CHECK(t, h[i] != 0, "variant %d did not load", i);
    }
    for (i = 0; i < 9; i++)
        for (j = i + 1; j < 9; j++) CHECK(t, h[i] != h[j], "variants %d and %d hash alike", i, j);
    CHECK(t, tenv_hash("material w diffuse { albedo 0.5 }\nquad { material w size 2 2 }\n"
                       "light environment { radiance 0.5 }\ncamera { aperture 0 }\n") == h[0],
          "aperture 0 changed the hash");
}

/* Errors in the new blocks, word for word with file:line:column. */
static void test_env_and_lens_errors_name_the_place(pds_test_ctx *t)
{
    static const struct { const char *text, *msg; } cases[] = {
        {"light environment { }\n",
         ":1:7: environment light needs 'radiance', 'sky', 'ground' or 'sun' (all are 0 by default)"},
        {"light environment { radiance 1 }\nlight environment { sky 1 }\n",
         ":2:7: a second environment light (a scene has one environment: add its parts in one block)"},
        {"light environment { sun 1 sun_radius 0 }\n", "'sun_radius' must be above 0 degrees (at most 45)"},
        {"light environment { sun 1 sun_radius 1e-300 }\n",
         ":1:7: the sun's disk (sun_radius 1e-300 degrees) is too small: its radiance E / (pi sin^2 radius) is out of range"},
        {"camera { aperture -1 }\n", ":1:19: 'aperture' (the lens radius) must be 0 or more, got -1"},
        {"camera { focus_distance 0 }\n", ":1:25: 'focus_distance' must be above 0, got 0"},
        {"light point { position 0 1 0 power 1 sky 1 }\n", "sky"},
    };
    size_t i;
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        pds_error err;
        pds_scene *s = scene_from_text(cases[i].text, &err);
        CHECK(t, s == NULL, "case %lu loaded", (unsigned long)i);
        if (s) {
            pds_scene_free(s);
            continue;
        }
        CHECK(t, strstr(err.text, cases[i].msg) != NULL, "case %lu: got '%s'", (unsigned long)i, err.text);
    }
}

static const pds_test_case tests_envlight[] = {
    {"env_constant_sky_gives_a_plane_radiance_times_albedo", test_env_constant_sky_gives_a_plane_radiance_times_albedo},
    {"env_sun_gives_a_plane_its_irradiance_times_cos", test_env_sun_gives_a_plane_its_irradiance_times_cos},
    {"env_clear_sky_matches_the_cie_formula", test_env_clear_sky_matches_the_cie_formula},
    {"env_sampling_pdf_integrates_to_one", test_env_sampling_pdf_integrates_to_one},
    {"env_photons_carry_the_flux_through_the_bounding_sphere", test_env_photons_carry_the_flux_through_the_bounding_sphere},
    {"env_sun_caustic_agrees_between_pt_and_photon_methods", test_env_sun_caustic_agrees_between_pt_and_photon_methods},
    {"env_photons_are_parallel_beams_with_their_share_of_the_disk",
     test_env_photons_are_parallel_beams_with_their_share_of_the_disk},
    {"thin_lens_blurs_to_the_circle_of_confusion", test_thin_lens_blurs_to_the_circle_of_confusion},
    {"thin_lens_of_radius_0_is_the_pinhole_bit_for_bit", test_thin_lens_of_radius_0_is_the_pinhole_bit_for_bit},
    {"env_and_lens_images_are_identical_for_any_thread_count", test_env_and_lens_images_are_identical_for_any_thread_count},
    {"thin_lens_is_refused_by_isc_and_the_teaching_views", test_thin_lens_is_refused_by_isc_and_the_teaching_views},
    {"env_example_scene_loads_as_the_readme_says", test_env_example_scene_loads_as_the_readme_says},
    {"scene_hash_covers_the_environment_and_the_lens", test_scene_hash_covers_the_environment_and_the_lens},
    {"env_and_lens_errors_name_the_place", test_env_and_lens_errors_name_the_place},
};

/* tests/test_spectral.c - spectral rendering (the >>spectral section)
   against known answers: the CIE 1931 fit against the CIE table and the
   equal-energy white point, the sRGB matrix against D65, Smits' uplift,
   the minimum deviation of a prism by Snell's law at each wavelength, the
   flux a dispersive slab transmits per wavelength, spectral renders of
   non-dispersive scenes against the RGB renderer, dispersion in every
   photon method, and determinism. */

/* CIE 1931 2-degree observer, from the CIE's 5 nm table: lambda, xbar,
   ybar, zbar. */
static const double spectral_cie_table[][4] = {
    {450.0, 0.3362, 0.0380, 1.7721},
    {500.0, 0.0049, 0.3230, 0.2720},
    {555.0, 0.5121, 1.0000, 0.0057},
    {600.0, 1.0622, 0.6310, 0.0008},
    {650.0, 0.2835, 0.1070, 0.0000},
};

/* Wyman, Sloan and Shirley give their multi-lobe fit as within about 0.01
   of the table; measured here: 0.0093 at most (zbar at 450 nm). */
static void test_spectral_cie_fit_is_within_its_accuracy_of_the_cie_table(pds_test_ctx *t)
{
    size_t i;
    int c;
    double worst = 0.0;
    for (i = 0; i < sizeof spectral_cie_table / sizeof spectral_cie_table[0]; i++) {
        double xyz[3];
        pds__cie_xyz(spectral_cie_table[i][0], xyz);
        for (c = 0; c < 3; c++) worst = fmax(worst, fabs(xyz[c] - spectral_cie_table[i][1 + c]));
    }
    CHECK(t, worst < 0.01, "largest difference from the CIE table %.4f", worst);
}

/* A flat spectrum (CIE illuminant E) has chromaticity (1/3, 1/3), and the
   table's ybar sums to 106.857 nm over 360-830 nm (pbrt's
   CIE_Y_integral); the fit over 380-780 nm gets 106.94 (0.08% more). */
static void test_spectral_cie_fit_integrates_to_the_equal_energy_white_point(pds_test_ctx *t)
{
    double sum[3] = {0, 0, 0}, x, y;
    int i, c;
    for (i = 0; i < 4000; i++) {
        double xyz[3];
        pds__cie_xyz(PDS__LAMBDA_MIN + (i + 0.5) * 0.1, xyz);
        for (c = 0; c < 3; c++) sum[c] += xyz[c] * 0.1;
    }
    x = sum[0] / (sum[0] + sum[1] + sum[2]);
    y = sum[1] / (sum[0] + sum[1] + sum[2]);
    CHECK(t, fabs(x - 1.0 / 3.0) < 0.001 && fabs(y - 1.0 / 3.0) < 0.001, "white point x %.5f y %.5f", x, y);
    CHECK(t, fabs(sum[1] / 106.856895 - 1.0) < 0.002, "integral of ybar %.4f", sum[1]);
}

/* The XYZ -> linear sRGB matrix takes the D65 white point (0.95047, 1,
   1.08883) to (1, 1, 1). */
static void test_spectral_srgb_matrix_maps_d65_to_white(pds_test_ctx *t)
{
    double xyz[3] = {0.95047, 1.0, 1.08883}, rgb[3];
    pds__xyz_to_srgb(xyz, rgb);
    CHECK(t, fabs(rgb[0] - 1) < 1e-4 && fabs(rgb[1] - 1) < 1e-4 && fabs(rgb[2] - 1) < 1e-4, "D65 -> %.6f %.6f %.6f",
          rgb[0], rgb[1], rgb[2]);
}

/* The film's normalisers are the integrals they claim to be, so the film
   weight W averages to (1, 1, 1) over the sampled range: a flat spectrum
   of 1 is white 1. */
static void test_spectral_film_weights_average_to_white(pds_test_ctx *t)
{
    double norm[3] = {0, 0, 0}, mean[3] = {0, 0, 0};
    int i, c, n = 400000;
    for (i = 0; i < n; i++) {
        double l = PDS__LAMBDA_MIN + (i + 0.5) * (PDS__LAMBDA_MAX - PDS__LAMBDA_MIN) / n, xyz[3], rgb[3], w[3];
        pds__cie_xyz(l, xyz);
        pds__xyz_to_srgb(xyz, rgb);
        pds__film_weight(l, w);
        for (c = 0; c < 3; c++) {
            norm[c] += rgb[c] * (PDS__LAMBDA_MAX - PDS__LAMBDA_MIN) / n;
            mean[c] += w[c] / n;
        }
    }
    for (c = 0; c < 3; c++) {
        CHECK(t, fabs(norm[c] / pds__film_norm[c] - 1.0) < 1e-7, "channel %d: integral %.9f, constant %.9f", c, norm[c],
              pds__film_norm[c]);
        CHECK(t, fabs(mean[c] - 1.0) < 1e-7, "channel %d: mean film weight %.9f", c, mean[c]);
    }
}

/* Smits' uplift: grey is flat, the map is homogeneous, and the round trip
   RGB -> spectrum -> film -> RGB returns the colour (measured: grey and
   white exactly, primaries and secondaries within 0.013 per channel, an
   orange 0.8 0.5 0.2 within 0.004). */
static void test_spectral_smits_uplift_round_trips_within_its_accuracy(pds_test_ctx *t)
{
    static const double colours[][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 0}, {0, 1, 1},
                                        {1, 0, 1}, {0.8, 0.5, 0.2}, {0.3, 0.3, 0.3}};
    double grey[3] = {0.37, 0.37, 0.37}, worst = 0.0, worst_grey = 0.0, worst_scale = 0.0;
    size_t k;
    int i, c, n = 40000;
    for (i = 0; i < 400; i++) {
        double l = PDS__LAMBDA_MIN + i + 0.5, rgb[3] = {0.2, 0.7, 0.4}, big[3] = {2.0, 7.0, 4.0};
        worst_grey = fmax(worst_grey, fabs(pds__spectral_value(grey, l) - 0.37));
        worst_scale = fmax(worst_scale, fabs(pds__spectral_value(big, l) - 10.0 * pds__spectral_value(rgb, l)));
    }
    CHECK(t, worst_grey == 0.0, "grey is not flat: %g", worst_grey);
    CHECK(t, worst_scale < 1e-12, "not homogeneous: %g", worst_scale);
    for (k = 0; k < sizeof colours / sizeof colours[0]; k++) {
        double back[3] = {0, 0, 0};
        for (i = 0; i < n; i++) {
            double l = PDS__LAMBDA_MIN + (i + 0.5) * (PDS__LAMBDA_MAX - PDS__LAMBDA_MIN) / n, w[3];
            double v = pds__spectral_value(colours[k], l);
            pds__film_weight(l, w);
            for (c = 0; c < 3; c++) back[c] += w[c] * v / n;
        }
        for (c = 0; c < 3; c++) worst = fmax(worst, fabs(back[c] - colours[k][c]));
    }
    CHECK(t, worst < 0.015, "round trip off by %.4f", worst);
}

/* The material the scene text gives `name`. */
static const pds_material *spectral_material_named(const pds_scene *s, const char *name)
{
    int i = pds__materials_find(&s->materials, name);
    return i >= 0 ? pds_scene_material(s, i) : NULL;
}

#define SPECTRAL_SF11 "sellmeier 1.73759695 0.313747346 1.89878101 0.013188707 0.0623068142 155.23629"

/* A 60-degree prism of N-SF11 at minimum deviation: the ray enters at
   theta_i = asin(n sin(A/2)), crosses parallel to the base and leaves
   turned by delta = 2 theta_i - A (Snell's law). The ray is refracted by
   the production BSDF sampler (pds__bsdf_sample, photon mode) on the
   material as a path at lambda sees it (pds__spectral_material), face by
   face; n(lambda) itself is checked against Schott's published indices. */
static void test_spectral_prism_deviates_each_wavelength_as_snells_law(pds_test_ctx *t)
{
    static const double lambda[5] = {400.0, 486.1, 587.6, 656.3, 700.0};
    static const double schott[5] = {1.84542, 1.80652, 1.78471, 1.77595, 1.77175};
    const double A = 60.0 * PDS__PI / 180.0;
    pds_error err;
    pds_scene *s = scene_from_text("material flint dielectric { " SPECTRAL_SF11 " }\nquad { material flint }\n", &err);
    const pds_material *flint;
    double prev = 0.0;
    int i;
    REQUIRE(t, s != NULL, "%s", err.text);
    flint = spectral_material_named(s, "flint");
    REQUIRE(t, flint != NULL, "material");
    for (i = 0; i < 5; i++) {
        pds_material m;
        pds__bsdf_result b1, b2;
        double u[3] = {0.9999999, 0.5, 0.5}, n, ti, want, got;
        pds__v3 n1 = pds__v(-cos(A / 2), sin(A / 2), 0.0), n2 = pds__v(cos(A / 2), sin(A / 2), 0.0), din;
        pds__spectral_material(flint, lambda[i], &m);
        n = m.ior;
        CHECK(t, fabs(n - schott[i]) < 2e-5, "n(%g nm) = %.6f, Schott %.5f", lambda[i], n, schott[i]);
        ti = asin(n * sin(A / 2));
        din = pds__v(cos(ti - A / 2), sin(ti - A / 2), 0.0);
        REQUIRE(t, pds__bsdf_sample(&m, pds__v(0, 0, 0), pds__scale(din, -1.0), n1, n1, u, PDS__IMPORTANCE, &b1) &&
                       b1.transmitted,
                "first face at %g nm", lambda[i]);
        CHECK(t, fabs(b1.wi.y) < 1e-12, "inside the prism the ray is not parallel to the base: %g", b1.wi.y);
        REQUIRE(t, pds__bsdf_sample(&m, pds__v(0, 0, 0), pds__scale(b1.wi, -1.0), n2, n2, u, PDS__IMPORTANCE, &b2) &&
                       b2.transmitted,
                "second face at %g nm", lambda[i]);
        got = acos(pds__dot(din, b2.wi));
        want = 2.0 * ti - A;
        CHECK(t, fabs(got - want) < 1e-12, "%g nm: deviation %.12f, Snell %.12f", lambda[i], got, want);
        CHECK(t, i == 0 || got < prev, "%g nm is turned no less than %g nm", lambda[i], lambda[i - 1]);
        prev = got;
    }
    pds_scene_free(s);
}

/* A slab of N-SF11 under collimated white light at normal incidence
   passes T^2 / (1 - R^2) = (1 - R) / (1 + R) of the flux of each
   wavelength, R = ((n - 1) / (n + 1))^2 (every pair of internal
   reflections adds a term). The photons are traced by the production
   photon tracer and stored where they land; per 100 nm band the spectral
   flux landed (stored flux / W(lambda)) must be what the photons of that
   band carried times the mean of (1 - R) / (1 + R) over them, within 0.6%
   (the Fresnel choices are random: 0.2% standard deviation); from 400 to
   780 nm the transmission rises by 1.7%, so a constant index would fail. */
static void test_spectral_slab_conserves_flux_per_wavelength(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text("material floor diffuse { albedo 0.5 }\n"
                                   "material flint dielectric { " SPECTRAL_SF11 " }\n"
                                   "quad { material floor size 8 8 }\n"
                                   "box { material flint size 1 0.5 1 translate 0 1.75 0 }\n"
                                   "light directional { direction 0 -1 0 irradiance 3 rect 0 3 0 0.98 0 0 0 0 0.98 }\n",
                                   &err);
    pds__photon_job job;
    pds__splat_buf buf;
    double emitted[4] = {0, 0, 0, 0}, expect[4] = {0, 0, 0, 0}, landed[4] = {0, 0, 0, 0}, ratio[4];
    double phi0;
    long i, n = 200000;
    size_t j;
    int b;
    REQUIRE(t, s != NULL, "%s", err.text);
    memset(&job, 0, sizeof job);
    memset(&buf, 0, sizeof buf);
    job.scene = s;
    job.target = pds__specular_target(s);
    job.seed = 3;
    job.smoothing = 12.0;
    job.eps = 1e-6 * pds__scene_scale(s);
    job.max_depth = 16;
    job.n_planned = (double)n;
    job.land = pds__store_photon;
    job.spectral = pds__render_is_spectral(s, &(pds_options){0});
    CHECK(t, job.spectral, "a dispersive material makes the render spectral");
    phi0 = 3.0 * 0.98 * 0.98 / (double)n; /* grey light: the same at every wavelength */
    for (i = 0; i < n; i++) {
        double l = pds__photon_wavelength(job.seed, i), ior, R;
        pds_material m;
        b = (int)((l - PDS__LAMBDA_MIN) / 100.0);
        pds__spectral_material(spectral_material_named(s, "flint"), l, &m);
        ior = m.ior;
        R = (ior - 1.0) * (ior - 1.0) / ((ior + 1.0) * (ior + 1.0));
        emitted[b] += phi0;
        expect[b] += phi0 * (1.0 - R) / (1.0 + R);
        pds__trace_photon(&job, &buf, i);
    }
    for (j = 0; j < buf.nstored; j++) {
        const pds__stored_photon *p = &buf.stored[j];
        double w[3];
        int c, best = 0;
        pds__film_weight(p->lambda, w);
        for (c = 1; c < 3; c++)
            if (fabs(w[c]) > fabs(w[best])) best = c;
        CHECK(t, p->lambda > 0.0f && fabs(p->lambda - pds__photon_wavelength(job.seed, p->index)) < 1e-3,
              "photon %ld landed with wavelength %g", p->index, p->lambda);
        landed[(int)((p->lambda - PDS__LAMBDA_MIN) / 100.0)] += p->flux[best] / w[best];
    }
    for (b = 0; b < 4; b++) {
        ratio[b] = landed[b] / emitted[b];
        CHECK(t, fabs(landed[b] / expect[b] - 1.0) < 0.006, "band %d: landed %.6f of %.6f W, expected %.6f", b,
              landed[b], emitted[b], expect[b]);
    }
    CHECK(t, ratio[3] > ratio[0] * 1.008, "red passes more than violet: %.5f vs %.5f", ratio[3], ratio[0]);
    free(buf.stored);
    pds_scene_free(s);
}

/* A white (0.8) floor under a white area light, path traced: spectral
   from the camera on (--spectral) against the RGB renderer, the same
   random numbers for everything but the wavelengths. White stays white
   within 1% (measured: R 0.7%, G 0.6%, B 0.3% at 32 x 32 pixels of 16
   samples, the wavelength noise of 16,384 samples; at 64 x 64 of 32
   samples, as here: 0.15%, 0.07%, 0.01%). */
static void test_spectral_white_reflector_matches_the_rgb_render(pds_test_ctx *t)
{
    static const char scene[] = "camera { position 0 2 0.000001 look_at 0 0 0 up 0 0 -1 fov 50 resolution 64 64 spp 32 }\n"
                                "material floor diffuse { albedo 0.8 }\n"
                                "quad { material floor size 8 8 }\n"
                                "light quad { center 0 3 0 edge1 2 0 0 edge2 0 0 2 radiance 5 }\n";
    pds_options opt;
    pds_image rgb = {0, 0, NULL}, spec = {0, 0, NULL};
    pds_render_stats st;
    int c;
    pds_options_default(&opt);
    opt.method = PDS_METHOD_PT;
    REQUIRE(t, render_text(scene, &opt, &rgb, &st) && st.spectral == 0, "rgb");
    opt.spectral = 1;
    REQUIRE(t, render_text(scene, &opt, &spec, &st) && st.spectral == 1, "spectral");
    for (c = 0; c < 3; c++)
        CHECK(t, fabs(image_mean(&spec, c) / image_mean(&rgb, c) - 1.0) < 0.01, "channel %d: %.5f vs %.5f", c,
              image_mean(&spec, c), image_mean(&rgb, c));
    CHECK(t, image_mean(&rgb, 1) > 0.1, "lit: %g", image_mean(&rgb, 1));
    pds_image_free(&rgb);
    pds_image_free(&spec);
}

/* The glass-sphere caustic of the PDS tests (non-dispersive, lit by a
   white light), with PDS: spectral from the light on against RGB. Every
   photon's colour now comes from one wavelength, so the caustic's colour
   is noisier; its light per channel agrees within 2% (measured: +0.4%,
   -0.6%, +0.9%), and it differs from the RGB image by at most 2.5 times
   what a second RGB render with another seed does (measured: 0.0152
   against 0.0081, 1.9 times: the wavelength noise is about 1.6 times the
   photons' own). */
static void spectral_on(pds_options *opt)
{
    opt->spectral = 1;
}

static void seed_1(pds_options *opt)
{
    opt->seed = 1;
}

static void test_spectral_caustic_matches_the_rgb_render_within_noise(pds_test_ctx *t)
{
    pds_image rgb = {0, 0, NULL}, rgb2 = {0, 0, NULL}, spec = {0, 0, NULL};
    pds_render_stats st;
    int c;
    REQUIRE(t, photon_render_text(sphere_caustic_scene, PDS_METHOD_PDS, 40000, 6.0, PDS_PATHS_CAUSTICS_ONLY, 2, &rgb,
                                  &st, NULL),
            "rgb");
    REQUIRE(t, photon_render_text(sphere_caustic_scene, PDS_METHOD_PDS, 40000, 6.0, PDS_PATHS_CAUSTICS_ONLY, 2, &rgb2,
                                  &st, seed_1),
            "rgb, seed 1");
    REQUIRE(t, photon_render_text(sphere_caustic_scene, PDS_METHOD_PDS, 40000, 6.0, PDS_PATHS_CAUSTICS_ONLY, 2,
                                  &spec, &st, spectral_on) &&
                   st.spectral,
            "spectral");
    for (c = 0; c < 3; c++)
        CHECK(t, fabs(image_mean(&spec, c) / image_mean(&rgb, c) - 1.0) < 0.02, "channel %d: %.5f vs %.5f", c,
              image_mean(&spec, c), image_mean(&rgb, c));
    CHECK(t, pds_image_rmse(&spec, &rgb) < 2.5 * pds_image_rmse(&rgb2, &rgb), "rmse %.4f, RGB's own %.4f",
          pds_image_rmse(&spec, &rgb), pds_image_rmse(&rgb2, &rgb));
    CHECK(t, image_mean(&rgb, 1) > 0.01, "a caustic: %g", image_mean(&rgb, 1));
    pds_image_free(&rgb);
    pds_image_free(&rgb2);
    pds_image_free(&spec);
}

/* A narrow white beam through an N-SF11 prism (scenes/prism.obj, side
   0.4, apex towards +z) at minimum deviation for n_d onto a screen in the
   plane x = 1.5: every photon method fans it out the same way. The
   prism turns light towards its base (-z), violet more than red, and the
   camera sees -z on the screen to the left: per method the B channel's
   centroid lies left of the R channel's, by an amount that agrees
   between methods within 10% (measured: 5%, 2.2 to 2.3 pixels), and the
   R, G, B light within 15% (measured: splat and ppm within 5% of PDS, pm
   and pdm up to 13% off: their gathers blur the narrow fan at 60,000
   photons, as they would in an RGB render). */
static const char spectral_fan_scene[] =
    "camera { position 0.6 0.8 0.3 look_at 1.5 0.3 -0.85 fov 50 resolution 48 32 spp 4 }\n"
    "material screen diffuse { albedo 0.8 }\n"
    "material flint dielectric { " SPECTRAL_SF11 " }\n"
    "quad { material screen size 3 3 rotate 90 0 0 1 translate 1.5 0.3 -0.8 }\n"
    "mesh \"prism.obj\" { material flint scale 0.4 0.6 0.4 }\n"
    "light directional { direction 0.8369 0 0.5473 irradiance 50 rect -0.937 0.3 -0.489 -0.0109 0 0.0167 0 0.2 0 }\n";

/* Render the fan scene as if it were a file in scenes/ (for its mesh). */
static int spectral_fan_render(pds_method method, long photons, int threads, pds_image *img, pds_render_stats *st)
{
    pds_error err;
    pds_scene *s = NULL;
    pds_options opt;
    int ok;
    if (pds_scene_load_string(spectral_fan_scene, "scenes/spectral-fan.scene", &s, &err) != PDS_OK) {
        printf("  scene: %s\n", err.text);
        return 0;
    }
    pds_options_default(&opt);
    opt.method = method;
    opt.photons = photons;
    opt.paths = PDS_PATHS_CAUSTICS_ONLY;
    opt.spp = 16; /* the fan is a thin line: 4 samples a pixel miss much of it */
    opt.threads = threads;
    ok = pds_render(s, &opt, img, st, &err) == PDS_OK;
    if (!ok) printf("  render: %s\n", err.text);
    pds_scene_free(s);
    return ok;
}

static void test_spectral_prism_fans_out_in_every_photon_method(pds_test_ctx *t)
{
    static const pds_method methods[] = {PDS_METHOD_PDS, PDS_METHOD_PM, PDS_METHOD_PDM, PDS_METHOD_SPLAT,
                                         PDS_METHOD_PPM};
    double sep[5], light[5][3];
    size_t k;
    for (k = 0; k < 5; k++) {
        pds_image img = {0, 0, NULL};
        pds_render_stats st;
        double wx[3] = {0, 0, 0}, w[3] = {0, 0, 0};
        int x, y, c;
        REQUIRE(t, spectral_fan_render(methods[k], 60000, 2, &img, &st), "%s", pds_method_name(methods[k]));
        CHECK(t, st.spectral == 1, "%s: not spectral", pds_method_name(methods[k]));
        for (y = 0; y < img.height; y++)
            for (x = 0; x < img.width; x++)
                for (c = 0; c < 3; c++) {
                    double v = fmax(0.0, img.rgb[3 * (y * img.width + x) + c]);
                    wx[c] += v * x;
                    w[c] += v;
                }
        for (c = 0; c < 3; c++) light[k][c] = w[c];
        REQUIRE(t, w[0] > 0.0 && w[2] > 0.0, "%s: no caustic", pds_method_name(methods[k]));
        sep[k] = wx[2] / w[2] - wx[0] / w[0];
        pds_image_free(&img);
    }
    for (k = 0; k < 5; k++) {
        int c;
        CHECK(t, sep[k] < -1.0, "%s: blue %.2f pixels right of red", pds_method_name(methods[k]), sep[k]);
        CHECK(t, fabs(sep[k] / sep[0] - 1.0) < 0.10, "%s: fan %.2f pixels, pds %.2f", pds_method_name(methods[k]),
              sep[k], sep[0]);
        for (c = 0; c < 3; c++)
            CHECK(t, fabs(light[k][c] / light[0][c] - 1.0) < 0.15, "%s channel %d: %.4f vs pds %.4f",
                  pds_method_name(methods[k]), c, light[k][c], light[0][c]);
    }
}

/* The eye pass through dispersive glass (L S S E, the same in every
   method): the camera looks back through the fan scene's prism, along the
   minimum-deviation ray for n_d, at a thin white emissive line 2 units
   before it. Looking through a prism one sees an object displaced towards
   the apex, violet more than red; the apex (+z) is on the image's left
   here, so the line becomes a spectrum with blue left of red: the B
   channel's centroid lies left of the R channel's by more than 2 pixels
   (measured: 3.1 with pt and with pds, whose eye passes are the same;
   2.8 at twice the samples).
   The same prism with a fixed index (1.7847) shows no such shift
   (measured: 0). */
static const char spectral_eye_scene[] =
    "camera { position 1.355 0.3 -0.763 look_at 0.1 0.3 0.0577 fov 24 resolution 96 32 spp 64 }\n"
    "material flint dielectric { %s }\n"
    "material lamp emissive { radiance 4 }\n"
    "mesh \"prism.obj\" { material flint scale 0.4 0.6 0.4 }\n"
    "quad { material lamp size 0.2 0.04 rotate 90 0 0 1 rotate 146.83 0 1 0 translate -1.774 0.3 -1.037 }\n";

/* Centroid of channel c minus that of channel 0 (red), in pixels along
   x, over the columns within 5 of the brightest one (the line seen
   through the prism; the faint reflections of the line off the prism's
   faces lie further right and stay out). */
static double spectral_centroid_shift(const pds_image *img, int c)
{
    double wx[3] = {0, 0, 0}, w[3] = {0, 0, 0}, col[512] = {0}, best = -1.0;
    int x, y, k, peak = 0;
    if (img->width > 512) return 0.0;
    for (y = 0; y < img->height; y++)
        for (x = 0; x < img->width; x++)
            for (k = 0; k < 3; k++) col[x] += fmax(0.0, img->rgb[3 * (y * img->width + x) + k]);
    for (x = 0; x < img->width; x++)
        if (col[x] > best) best = col[x], peak = x;
    for (y = 0; y < img->height; y++)
        for (x = peak - 5; x <= peak + 5; x++)
            for (k = 0; k < 3 && x >= 0 && x < img->width; k++) {
                double v = fmax(0.0, img->rgb[3 * (y * img->width + x) + k]);
                wx[k] += v * x;
                w[k] += v;
            }
    return w[c] > 0.0 && w[0] > 0.0 ? wx[c] / w[c] - wx[0] / w[0] : 0.0;
}

static void test_spectral_eye_paths_see_a_line_through_a_prism_as_a_spectrum(pds_test_ctx *t)
{
    static const pds_method methods[2] = {PDS_METHOD_PT, PDS_METHOD_PDS};
    char text[1024];
    int k, dispersive;
    for (dispersive = 1; dispersive >= 0; dispersive--) {
        snprintf(text, sizeof text, spectral_eye_scene, dispersive ? SPECTRAL_SF11 : "ior 1.7847");
        for (k = 0; k < 2; k++) {
            pds_error err;
            pds_scene *s = NULL;
            pds_options opt;
            pds_image img = {0, 0, NULL};
            double shift;
            REQUIRE(t, pds_scene_load_string(text, "scenes/spectral-eye.scene", &s, &err) == PDS_OK, "%s", err.text);
            pds_options_default(&opt);
            opt.method = methods[k];
            opt.photons = 1000;
            REQUIRE(t, pds_render(s, &opt, &img, NULL, &err) == PDS_OK, "%s", err.text);
            shift = spectral_centroid_shift(&img, 2);
            if (dispersive)
                CHECK(t, shift < -2.0, "%s: blue %.3f pixels right of red", pds_method_name(methods[k]), shift);
            else
                CHECK(t, fabs(shift) < 0.05, "%s, fixed index: blue %.3f pixels from red", pds_method_name(methods[k]),
                      shift);
            pds_image_free(&img);
            pds_scene_free(s);
        }
    }
}

/* Spectral images are the same bit for bit for any thread count (the
   wavelengths are functions of the pixel sample and the photon number). */
static void test_spectral_images_are_identical_for_any_thread_count(pds_test_ctx *t)
{
    static const pds_method methods[] = {PDS_METHOD_PDS, PDS_METHOD_PM, PDS_METHOD_PPM};
    size_t k;
    for (k = 0; k < sizeof methods / sizeof methods[0]; k++) {
        pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
        REQUIRE(t, spectral_fan_render(methods[k], 20000, 1, &a, NULL), "1 thread");
        REQUIRE(t, spectral_fan_render(methods[k], 20000, 3, &b, NULL), "3 threads");
        CHECK(t, memcmp(a.rgb, b.rgb, sizeof(float) * 3 * (size_t)a.width * a.height) == 0, "%s: not bitwise equal",
              pds_method_name(methods[k]));
        pds_image_free(&a);
        pds_image_free(&b);
    }
}

/* pm's estimate at an eye vertex seen through dispersive glass (it holds
   at lambda_e = 560 nm) from spectral photons: those of its wavelength
   bin count with the bin count's weight, 16 (one photon in 16 falls in a
   bin, so the expectation is right), once; those of another bin not at
   all. So against the same vertex holding at every wavelength the
   estimate is exactly 16 times as large from photons of its bin, and 0
   from the others. (pm once applied the weight twice: 256 times, a
   caustic seen through a dispersive ball too bright.) */
static void test_spectral_pm_weighs_a_wavelength_bin_once(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text("material floor diffuse { albedo 0.5 0.6 0.7 }\nquad { material floor }\n", &err);
    pds__stored_photon ph[12];
    pds__eye_vertex v;
    pds__gather g;
    pds__v3 up = pds__v(0.0, 1.0, 0.0);
    size_t idx[12];
    double d2[12], beta[3] = {0.3, 0.3, 0.3};
    double any[2][3] = {{0, 0, 0}, {0, 0, 0}}, one[2][3] = {{0, 0, 0}, {0, 0, 0}}; /* [bin: same, next] */
    int i, c, pass;
    REQUIRE(t, s != NULL, "scene: %s", err.text);
    memset(&v, 0, sizeof v);
    REQUIRE(t, pds__eye_vertex_set(&v, &s->materials.items[0], pds__v(0.0, 0.0, 0.0), up, up, up, beta, 0), "vertex");
    memset(&g, 0, sizeof g);
    g.scene = s;
    g.photons = ph;
    g.k = 12;
    g.kernel = PDS_KERNEL_CONE;
    for (pass = 0; pass < 2; pass++) {
        memset(ph, 0, sizeof ph);
        for (i = 0; i < 12; i++) {
            double a = 2.0 * PDS__PI * i / 12.0, r = 0.01 * (1 + i);
            pds__f3_set(ph[i].pos, pds__v(r * cos(a), 0.0, r * sin(a)));
            pds__f3_set(ph[i].dir, pds__v(0.1 * cos(a), -1.0, 0.0));
            pds__f3_set(ph[i].ng, up);
            ph[i].flux[0] = 0.2f;
            ph[i].flux[1] = 0.1f * (float)(1 + i % 3);
            ph[i].flux[2] = 0.05f;
            /* pass 0: within 560's bin [555, 580) nm; pass 1: the next bin */
            ph[i].lambda = (float)(pass == 0 ? 556.0 + 2.0 * i : 581.0 + 2.0 * i);
            idx[i] = (size_t)i;
            d2[i] = r * r;
        }
        v.lambda = 0.0f;
        pds__pm_estimate(&g, &v, idx, d2, 12, any[pass]);
        v.lambda = 560.0f;
        pds__pm_estimate(&g, &v, idx, d2, 12, one[pass]);
    }
    for (c = 0; c < 3; c++) {
        CHECK(t, any[0][c] > 0.0 && fabs(one[0][c] / any[0][c] - 16.0) < 1e-9,
              "channel %d: the estimate in its bin is %g times the achromatic one, want 16", c, one[0][c] / any[0][c]);
        CHECK(t, any[1][c] > 0.0 && one[1][c] == 0.0, "channel %d: photons of the next bin give %g (achromatic %g)", c,
              one[1][c], any[1][c]);
    }
    pds_scene_free(s);
}

static const pds_test_case tests_spectral[] = {
    {"spectral_pm_weighs_a_wavelength_bin_once", test_spectral_pm_weighs_a_wavelength_bin_once},
    {"spectral_cie_fit_is_within_its_accuracy_of_the_cie_table",
     test_spectral_cie_fit_is_within_its_accuracy_of_the_cie_table},
    {"spectral_cie_fit_integrates_to_the_equal_energy_white_point",
     test_spectral_cie_fit_integrates_to_the_equal_energy_white_point},
    {"spectral_srgb_matrix_maps_d65_to_white", test_spectral_srgb_matrix_maps_d65_to_white},
    {"spectral_film_weights_average_to_white", test_spectral_film_weights_average_to_white},
    {"spectral_smits_uplift_round_trips_within_its_accuracy", test_spectral_smits_uplift_round_trips_within_its_accuracy},
    {"spectral_prism_deviates_each_wavelength_as_snells_law", test_spectral_prism_deviates_each_wavelength_as_snells_law},
    {"spectral_slab_conserves_flux_per_wavelength", test_spectral_slab_conserves_flux_per_wavelength},
    {"spectral_white_reflector_matches_the_rgb_render", test_spectral_white_reflector_matches_the_rgb_render},
    {"spectral_caustic_matches_the_rgb_render_within_noise", test_spectral_caustic_matches_the_rgb_render_within_noise},
    {"spectral_prism_fans_out_in_every_photon_method", test_spectral_prism_fans_out_in_every_photon_method},
    {"spectral_eye_paths_see_a_line_through_a_prism_as_a_spectrum",
     test_spectral_eye_paths_see_a_line_through_a_prism_as_a_spectrum},
    {"spectral_images_are_identical_for_any_thread_count", test_spectral_images_are_identical_for_any_thread_count},
};

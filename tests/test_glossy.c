/* tests/test_glossy.c - the glossy material (GGX microfacets with Smith
   masking-shadowing, >>materials): the distribution's normalisation, the
   weak white furnace, directional albedo (<= 1, near 1 when smooth, and
   the same by sampling and by quadrature), reciprocity, the sampler's
   histogram against its pdf, and a glossy floor in a photon method's eye
   pass against the BRDF times the analytic irradiance. */

static pds_material gtest_glossy(double alpha, int conductor)
{
    pds_material m = pds__material_default("glossy");
    m.type = PDS_MAT_GLOSSY;
    m.roughness = alpha;
    m.reflectance[0] = m.reflectance[1] = m.reflectance[2] = 1.0;
    if (conductor) {
        /* gold, Johnson & Christy */
        m.fresnel = 1;
        m.eta[0] = 0.14; m.eta[1] = 0.43; m.eta[2] = 1.38;
        m.k[0] = 3.697; m.k[1] = 2.455; m.k[2] = 1.914;
    }
    return m;
}

/* Direction at polar angle theta (from +z) and azimuth phi. */
static pds__v3 gtest_dir(double theta, double phi)
{
    return pds__v(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
}

/* Integral of D(h) cos(h) over the hemisphere, by the midpoint rule in
   mu = cos^2 theta... in theta directly, with enough steps for alpha 0.05:
   2 pi int D cos sin dtheta. Must be 1 (Walter et al. 2007, eq. 4). */
static void test_ggx_distribution_projected_area_is_one(pds_test_ctx *t)
{
    static const double alphas[] = {0.05, 0.2, 0.5, 1.0};
    int a, i, n = 200000;
    for (a = 0; a < 4; a++) {
        double sum = 0.0, dt = 0.5 * PDS__PI / n;
        for (i = 0; i < n; i++) {
            double th = (i + 0.5) * dt;
            sum += pds__ggx_d(cos(th), alphas[a]) * cos(th) * sin(th) * dt;
        }
        CHECK_NEAR(t, 2.0 * PDS__PI * sum, 1.0, 1e-6);
    }
}

/* The visible normals' density G1(o) max(0, o.h) D(h) / cos_o integrates to
   1 over h for every o (Heitz 2014, eq. 38: the "weak white furnace"): a
   check that G1 is the masking function that belongs to D. Quadrature on a
   theta x phi grid. */
static void test_ggx_weak_white_furnace_holds(pds_test_ctx *t)
{
    static const double alphas[] = {0.2, 0.5, 1.0};
    static const double views[] = {0.0, 0.6, 1.2, 1.45};
    int a, v, i, j, nt = 1500, np = 256;
    for (a = 0; a < 3; a++) {
        for (v = 0; v < 4; v++) {
            pds__v3 o = gtest_dir(views[v], 0.3);
            double sum = 0.0, dt = 0.5 * PDS__PI / nt, dp = 2.0 * PDS__PI / np, g1 = pds__ggx_g1(o.z, alphas[a]);
            for (i = 0; i < nt; i++) {
                double th = (i + 0.5) * dt, d = pds__ggx_d(cos(th), alphas[a]);
                for (j = 0; j < np; j++) {
                    pds__v3 h = gtest_dir(th, (j + 0.5) * dp);
                    double oh = pds__dot(o, h);
                    if (oh > 0.0) sum += g1 * oh * d / o.z * sin(th) * dt * dp;
                }
            }
            CHECK(t, fabs(sum - 1.0) < 2e-4, "alpha %g view %g: visible normals integrate to %.6f", alphas[a],
                  views[v], sum);
        }
    }
}

/* Reciprocity: f(wo, wi) = f(wi, wo) for random pairs above the surface,
   with a tilted shading normal and conductor Fresnel. */
static void test_glossy_bsdf_is_reciprocal(pds_test_ctx *t)
{
    pds_material m = gtest_glossy(0.3, 1);
    pds__v3 ng = pds__v(0, 0, 1), ns = pds__normalize(pds__v(0.1, -0.05, 1.0));
    int i, n = 0, bad = 0;
    for (i = 0; i < 2000; i++) {
        pds__v3 wo = mtest_sphere(mtest_u(31, i, 0), mtest_u(31, i, 1));
        pds__v3 wi = mtest_sphere(mtest_u(31, i, 2), mtest_u(31, i, 3));
        double f1[3], f2[3], p1, p2;
        int c;
        if (wo.z < 0.0) wo.z = -wo.z;
        if (wi.z < 0.0) wi.z = -wi.z;
        if (pds__dot(wo, ns) <= 0.0 || pds__dot(wi, ns) <= 0.0) continue;
        pds__bsdf_eval(&m, pds__v(0, 0, 0), wo, wi, ns, ng, f1, &p1);
        pds__bsdf_eval(&m, pds__v(0, 0, 0), wi, wo, ns, ng, f2, &p2);
        n++;
        for (c = 0; c < 3; c++)
            if (!(fabs(f1[c] - f2[c]) <= 1e-12 * fmax(1.0, fabs(f1[c])))) bad++;
        if (!(f1[0] > 0.0)) bad++;
    }
    CHECK(t, n > 1500 && bad == 0, "%d of %d pairs not reciprocal", bad, n);
}

/* Directional albedo with F = 1, two ways: the mean sample weight of the
   production sampler, and the quadrature of f cos over the hemisphere by
   the production evaluator. They must agree (the sampler's weight is
   f cos / pdf), never exceed 1, be near 1 for a smooth surface and fall
   with roughness (single scattering loses the light that would bounce
   again between the microfacets). */
static void test_glossy_white_furnace_albedo(pds_test_ctx *t)
{
    static const double alphas[] = {0.05, 0.3, 0.6, 1.0};
    static const double views[] = {0.0, 0.8, 1.3};
    double normal_albedo[4];
    int a, v, i, j;
    pds__v3 up = pds__v(0, 0, 1);
    for (a = 0; a < 4; a++) {
        pds_material m = gtest_glossy(alphas[a], 0);
        for (v = 0; v < 3; v++) {
            pds__v3 wo = gtest_dir(views[v], 1.0);
            double mc = 0.0, mc2 = 0.0, quad = 0.0, se;
            int n = 20000, nt = 2000, np = 128;
            for (i = 0; i < n; i++) {
                double u[3] = {mtest_u(32, i, 0), mtest_u(32, i, 1), 0.5}, f[3], pdf;
                pds__bsdf_result s;
                if (!pds__bsdf_sample(&m, pds__v(0, 0, 0), wo, up, up, u, PDS__RADIANCE, &s)) continue;
                mc += s.weight[0];
                mc2 += s.weight[0] * s.weight[0];
                /* the sample's weight is f cos / pdf of the evaluator */
                pds__bsdf_eval(&m, pds__v(0, 0, 0), wo, s.wi, up, up, f, &pdf);
                if (!(fabs(f[0] * s.wi.z / pdf - s.weight[0]) < 1e-9) || !(fabs(pdf - s.pdf) < 1e-9 * pdf)) {
                    CHECK(t, 0, "sample weight %g or pdf %g disagrees with eval %g, %g", s.weight[0], s.pdf,
                          f[0] * s.wi.z / pdf, pdf);
                    return;
                }
            }
            mc /= n;
            se = sqrt(fmax(0.0, mc2 / n - mc * mc) / n);
            /* quadrature in (cos theta_i)^(1/4)-spaced angles is overkill;
               the half vector concentrates near the mirror direction, so
               integrate in theta with many steps */
            for (i = 0; i < nt; i++) {
                double th = (i + 0.5) * 0.5 * PDS__PI / nt;
                for (j = 0; j < np; j++) {
                    pds__v3 wi = gtest_dir(th, (j + 0.5) * 2.0 * PDS__PI / np);
                    double f[3], pdf;
                    pds__bsdf_eval(&m, pds__v(0, 0, 0), wo, wi, up, up, f, &pdf);
                    quad += f[0] * wi.z * sin(th) * (0.5 * PDS__PI / nt) * (2.0 * PDS__PI / np);
                }
            }
            if (alphas[a] >= 0.3)
                CHECK(t, fabs(mc - quad) < 4.0 * se + 2e-3, "alpha %g view %g: sampled albedo %.5f +- %.5f, quadrature %.5f",
                      alphas[a], views[v], mc, se, quad);
            CHECK(t, mc <= 1.0 + 1e-12, "alpha %g view %g: albedo %.5f above 1", alphas[a], views[v], mc);
            if (v == 0) normal_albedo[a] = mc;
        }
    }
    /* At normal incidence the microfacets steeper than 45 degrees reflect
       below the horizon; the GGX slope distribution, P(tan^2 theta_h < x)
       = x / (alpha^2 + x), puts alpha^2 / (1 + alpha^2) of them there, so
       the single-scattering albedo is at most 1 / (1 + alpha^2) (and
       G2 < 1 takes a little more). */
    /* Exactly: with o = n, Lambda(o) = 0 and the weight is 1 / (1 +
       Lambda(i)), theta_i = 2 theta_h, h drawn with density D cos_h: a
       1-d integral over theta_h < 45 degrees, written out here from the
       closed forms (D: Walter 2007 eq. 33; Lambda: Heitz 2014 eq. 72). */
    for (a = 0; a < 4; a++) {
        double bound = 1.0 / (1.0 + alphas[a] * alphas[a]), a2 = alphas[a] * alphas[a], e = 0.0;
        int k, nk = 100000;
        for (k = 0; k < nk; k++) {
            double th = (k + 0.5) * 0.25 * PDS__PI / nk, c = cos(th), q = c * c * (a2 - 1.0) + 1.0;
            double D = a2 / (PDS__PI * q * q), ti = tan(2.0 * th);
            double lambda = 0.5 * (sqrt(1.0 + a2 * ti * ti) - 1.0);
            e += 2.0 * PDS__PI * D * c * sin(th) * (0.25 * PDS__PI / nk) / (1.0 + lambda);
        }
        CHECK(t, normal_albedo[a] <= bound + 1e-3, "alpha %g: albedo %.5f above the bound %.5f", alphas[a],
              normal_albedo[a], bound);
        CHECK(t, fabs(normal_albedo[a] - e) < 0.005, "alpha %g: albedo %.5f at normal incidence, expected %.5f",
              alphas[a], normal_albedo[a], e);
    }
    CHECK(t, normal_albedo[0] > 0.997, "alpha 0.05 at normal incidence keeps %.5f", normal_albedo[0]);
    CHECK(t, normal_albedo[0] > normal_albedo[1] && normal_albedo[1] > normal_albedo[2] &&
             normal_albedo[2] > normal_albedo[3],
          "albedo at normal incidence %.4f %.4f %.4f %.4f should fall with roughness", normal_albedo[0],
          normal_albedo[1], normal_albedo[2], normal_albedo[3]);
}

/* The sampler's directions against its pdf: a histogram over 12 x 16
   cells in (cos theta, phi) of 200,000 samples, each cell's expected count
   the pdf integrated over the cell (8 x 8 midpoint rule); Pearson's
   chi-square over cells expecting at least 20 must stay below dof +
   5 sqrt(2 dof) (a 5-sigma bound). Samples the sampler drops (below the
   horizon) are the pdf's missing mass. */
static void test_glossy_samples_follow_the_pdf(pds_test_ctx *t)
{
    enum { NC = 12, NP = 16, SUB = 8 };
    static const double alphas[] = {0.15, 0.5};
    int a;
    pds__v3 up = pds__v(0, 0, 1);
    for (a = 0; a < 2; a++) {
        pds_material m = gtest_glossy(alphas[a], 0);
        pds__v3 wo = gtest_dir(0.9, 0.0);
        static double hist[NC][NP];
        double chi2 = 0.0, mass = 0.0;
        int i, j, si, sj, n = 200000, dof = 0, kept = 0;
        memset(hist, 0, sizeof hist);
        for (i = 0; i < n; i++) {
            double u[3] = {mtest_u(33 + a, i, 0), mtest_u(33 + a, i, 1), 0.5}, phi;
            pds__bsdf_result s;
            int ci, cp;
            if (!pds__bsdf_sample(&m, pds__v(0, 0, 0), wo, up, up, u, PDS__RADIANCE, &s)) continue;
            kept++;
            phi = atan2(s.wi.y, s.wi.x);
            if (phi < 0.0) phi += 2.0 * PDS__PI;
            ci = (int)(s.wi.z * NC);
            cp = (int)(phi / (2.0 * PDS__PI) * NP);
            if (ci >= NC) ci = NC - 1;
            if (cp >= NP) cp = NP - 1;
            hist[ci][cp] += 1.0;
        }
        for (i = 0; i < NC; i++) {
            for (j = 0; j < NP; j++) {
                double expect = 0.0;
                for (si = 0; si < SUB; si++) {
                    for (sj = 0; sj < SUB; sj++) {
                        double z = (i + (si + 0.5) / SUB) / NC, phi = (j + (sj + 0.5) / SUB) / NP * 2.0 * PDS__PI;
                        double r = sqrt(fmax(0.0, 1.0 - z * z)), f[3], pdf;
                        pds__v3 wi = pds__v(r * cos(phi), r * sin(phi), z);
                        pds__bsdf_eval(&m, pds__v(0, 0, 0), wo, wi, up, up, f, &pdf);
                        /* solid angle of a sub-cell: dz dphi */
                        expect += pdf * (1.0 / (NC * SUB)) * (2.0 * PDS__PI / (NP * SUB));
                    }
                }
                mass += expect;
                expect *= n;
                if (expect >= 20.0) {
                    chi2 += (hist[i][j] - expect) * (hist[i][j] - expect) / expect;
                    dof++;
                }
            }
        }
        CHECK(t, dof > 20, "alpha %g: only %d cells with enough samples", alphas[a], dof);
        CHECK(t, chi2 < dof + 5.0 * sqrt(2.0 * dof), "alpha %g: chi-square %.1f over %d cells", alphas[a], chi2, dof);
        CHECK(t, fabs(mass - (double)kept / n) < 0.01, "alpha %g: pdf mass %.4f, samples kept %.4f", alphas[a], mass,
              (double)kept / n);
    }
}

/* A photon method's eye pass on a glossy floor: the mirror scene of
   test_pds.c with the floor made glossy (alpha 0.5). The caustic is the
   mirrored point light (2, 1, 0), so each pixel must show
   f(wo, wi) E, E = R P / (4 pi) cos / d^2, with the GGX f. */
static const char glossy_mirror_scene[] =
    "camera { position 0 2 0.000001 look_at 0 0 0 up 0 0 -1 fov 30 resolution 24 24 spp 16 }\n"
    "material floor glossy { roughness 0.5 reflectance 0.5 0.5 0.5 }\n"
    "material glass mirror { reflectance 0.9 }\n"
    "quad { material floor size 8 8 }\n"
    "quad { material glass size 3 3 rotate 90 0 0 1 translate 1 1.5 0 }\n"
    "light point { position 0 1 0 power 100 }\n";

static void test_glossy_floor_caustic_matches_brdf_times_irradiance(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    pds_material m = gtest_glossy(0.5, 0);
    int x, y, bad = 0, n = 0;
    double worst = 0.0;
    m.reflectance[0] = m.reflectance[1] = m.reflectance[2] = 0.5;
    REQUIRE(t, pds_render_text(glossy_mirror_scene, 400000, 20.0, PDS_PATHS_CAUSTICS_ONLY, 2, &img, NULL), "render");
    for (y = 4; y < 20; y++) {
        for (x = 4; x < 20; x++) {
            pds__v3 p = floor_point(2.0, 30.0, 24, x, y);
            pds__v3 d = pds__sub(pds__v(2.0, 1.0, 0.0), p), wi = pds__normalize(d);
            pds__v3 wo = pds__normalize(pds__sub(pds__v(0.0, 2.0, 0.0), p)), up = pds__v(0, 1, 0);
            double d2 = pds__dot(d, d), E = 0.9 * 100.0 / (4.0 * PDS__PI) * wi.y / d2, f[3], pdf, expect, rel;
            pds__bsdf_eval(&m, p, wo, wi, up, up, f, &pdf);
            expect = f[1] * E;
            rel = fabs(img.rgb[3 * (y * 24 + x) + 1] / expect - 1.0);
            if (rel > worst) worst = rel;
            bad += rel > 0.03;
            n++;
        }
    }
    CHECK(t, bad == 0, "%d of %d pixels off by more than 3%%, worst %.4f", bad, n, worst);
    pds_image_free(&img);
}

/* The scene parser reads a glossy material: roughness, reflectance, and a
   conductor preset that turns on the Fresnel factor. */
static void test_glossy_material_parses(pds_test_ctx *t)
{
    pds_scene *s = NULL;
    pds_error err;
    const pds_material *a, *b;
    REQUIRE(t, pds_scene_load_string("material a glossy { roughness 0.3 reflectance 0.5 0.6 0.7 }\n"
                                     "material b glossy { preset gold }\n"
                                     "sphere { material a radius 1 }\n", "g.scene", &s, &err) == PDS_OK,
            "%s", err.text);
    a = pds_scene_material(s, 0);
    b = pds_scene_material(s, 1);
    REQUIRE(t, a && b, "materials");
    CHECK(t, a->type == PDS_MAT_GLOSSY && a->roughness == 0.3 && a->reflectance[1] == 0.6 && a->fresnel == 0,
          "glossy a");
    CHECK(t, b->type == PDS_MAT_GLOSSY && b->roughness == 0.2 && b->fresnel == 1 && b->k[0] > 3.0, "glossy b");
    pds_scene_free(s);
    CHECK(t, pds_scene_load_string("material a glossy { roughness 0 }\n", "g.scene", &s, &err) != PDS_OK,
          "roughness 0 refused");
    CHECK(t, strstr(err.text, "g.scene:1:") == err.text, "message has the location: %s", err.text);
}

static const pds_test_case tests_glossy[] = {
    {"ggx_distribution_projected_area_is_one", test_ggx_distribution_projected_area_is_one},
    {"ggx_weak_white_furnace_holds", test_ggx_weak_white_furnace_holds},
    {"glossy_bsdf_is_reciprocal", test_glossy_bsdf_is_reciprocal},
    {"glossy_white_furnace_albedo_is_at_most_one_and_sampling_matches_quadrature",
     test_glossy_white_furnace_albedo},
    {"glossy_samples_follow_the_pdf", test_glossy_samples_follow_the_pdf},
    {"glossy_floor_caustic_matches_brdf_times_irradiance", test_glossy_floor_caustic_matches_brdf_times_irradiance},
    {"glossy_material_parses", test_glossy_material_parses},
};

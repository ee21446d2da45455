/* tests/test_materials.c - Fresnel, BSDF sampling, Beer-Lambert and
   dispersion (the >>materials section) against hand-computed values,
   independent implementations and Monte Carlo estimates with known
   expectations. Random numbers: pds__rng_uniform(seed, PDS__RNG_TEST, ...). */

static double mtest_u(uint64_t seed, uint64_t index, uint64_t dim)
{
    return pds__rng_uniform(seed, PDS__RNG_TEST, index, dim);
}

/* Uniform direction on the unit sphere from two uniforms. */
static pds__v3 mtest_sphere(double u1, double u2)
{
    double z = 1.0 - 2.0 * u1, r = sqrt(fmax(0.0, 1.0 - z * z)), phi = 2.0 * PDS__PI * u2;
    return pds__v(r * cos(phi), r * sin(phi), z);
}

/* n tilted by angle (radians) toward a random perpendicular direction. */
static pds__v3 mtest_tilt(pds__v3 n, double angle, double u)
{
    pds__v3 b1, b2, t;
    double phi = 2.0 * PDS__PI * u;
    pds__onb(n, &b1, &b2);
    t = pds__add(pds__scale(b1, cos(phi)), pds__scale(b2, sin(phi)));
    return pds__normalize(pds__add(pds__scale(n, cos(angle)), pds__scale(t, sin(angle))));
}

static pds_material mtest_material(pds_material_type type)
{
    pds_material m = pds__material_default("test");
    m.type = type;
    m.albedo[0] = 0.9; m.albedo[1] = 0.5; m.albedo[2] = 0.1;
    m.reflectance[0] = 0.95; m.reflectance[1] = 0.7; m.reflectance[2] = 0.3;
    /* gold: Johnson & Christy, Phys. Rev. B 6, 4370 (1972), at 650, 550, 450 nm */
    m.eta[0] = 0.14; m.eta[1] = 0.43; m.eta[2] = 1.38;
    m.k[0] = 3.697; m.k[1] = 2.455; m.k[2] = 1.914;
    m.ior = 1.5;
    m.outside_ior = 1.0;
    m.radiance[0] = m.radiance[1] = m.radiance[2] = 1.0;
    return m;
}

/* ---------------------------------------------------- dielectric Fresnel */

static void test_fresnel_normal_incidence(pds_test_ctx *t)
{
    /* ((n1 - n2)/(n1 + n2))^2 = (0.5/2.5)^2 = 0.04 either way */
    CHECK_NEAR(t, pds__fresnel_dielectric(1.0, 1.0, 1.5), 0.04, 1e-15);
    CHECK_NEAR(t, pds__fresnel_dielectric(1.0, 1.5, 1.0), 0.04, 1e-15);
    /* water: (0.33/2.33)^2 */
    CHECK_NEAR(t, pds__fresnel_dielectric(1.0, 1.0, 1.33), (0.33 / 2.33) * (0.33 / 2.33), 1e-15);
    /* index-matched interface reflects nothing */
    CHECK_NEAR(t, pds__fresnel_dielectric(0.3, 1.5, 1.5), 0.0, 1e-15);
}

static void test_fresnel_brewster(pds_test_ctx *t)
{
    /* At Brewster's angle tan(theta_B) = 1.5: cos_i = 1/sqrt(3.25),
       sin_t = sin_i/1.5 = cos_i and cos_t = sin_i, so r_par = 0 and
       r_perp = (cos_i - 1.5 cos_t)/(cos_i + 1.5 cos_t) = (1 - 2.25)/(1 + 2.25)
       = -5/13: R_perp = 25/169 = 0.147929, R = R_perp/2 = 25/338 = 0.0739645. */
    double theta_b = atan(1.5);
    double r = pds__fresnel_dielectric(cos(theta_b), 1.0, 1.5);
    CHECK_NEAR(t, r, 25.0 / 338.0, 1e-14);
    CHECK_NEAR(t, r, 0.0739645, 1e-7);
    /* Brewster from inside: tan(theta) = 1/1.5, same reflectance (Stokes) */
    CHECK_NEAR(t, pds__fresnel_dielectric(cos(atan(1.0 / 1.5)), 1.5, 1.0), 25.0 / 338.0, 1e-14);
}

static void test_fresnel_45_degrees(pds_test_ctx *t)
{
    /* n = 1.5 at 45 degrees, by hand: cos_t = sqrt(1 - 0.5/2.25) = 0.881917,
       r_perp = (0.707107 - 1.322876)/(0.707107 + 1.322876) = -0.303337,
       r_par = (1.060660 - 0.881917)/(1.060660 + 0.881917) = 0.092012,
       R = (0.092013 + 0.008466)/2 = 0.050240 */
    CHECK_NEAR(t, pds__fresnel_dielectric(sqrt(0.5), 1.0, 1.5), 0.050240, 2e-6);
}

static void test_fresnel_grazing(pds_test_ctx *t)
{
    CHECK_NEAR(t, pds__fresnel_dielectric(0.0, 1.0, 1.5), 1.0, 0.0);
    CHECK(t, pds__fresnel_dielectric(1e-6, 1.0, 1.5) > 0.99999, "R at cos 1e-6 = %g",
          pds__fresnel_dielectric(1e-6, 1.0, 1.5));
    CHECK(t, pds__fresnel_dielectric(1e-3, 1.0, 1.5) > 0.99, "R at cos 1e-3");
    /* monotonic rise toward grazing from outside */
    {
        int i;
        double prev = pds__fresnel_dielectric(1.0, 1.0, 1.5);
        for (i = 1; i <= 100; i++) {
            double r = pds__fresnel_dielectric(1.0 - i / 100.0, 1.0, 1.5);
            CHECK(t, r >= prev - 1e-15, "R not increasing at step %d", i);
            prev = r;
        }
    }
}

static void test_fresnel_tir(pds_test_ctx *t)
{
    double crit = asin(1.0 / 1.5); /* 41.81 degrees */
    double below = pds__fresnel_dielectric(cos(crit - 0.01), 1.5, 1.0);
    CHECK_NEAR(t, pds__fresnel_dielectric(cos(crit + 1e-6), 1.5, 1.0), 1.0, 0.0);
    CHECK_NEAR(t, pds__fresnel_dielectric(cos(PDS__PI / 4), 1.5, 1.0), 1.0, 0.0);
    CHECK_NEAR(t, pds__fresnel_dielectric(cos(1.2), 1.5, 1.0), 1.0, 0.0);
    CHECK(t, below < 1.0 && below > 0.04, "just below the critical angle R = %g", below);
    CHECK(t, pds__fresnel_dielectric(cos(crit - 0.1), 1.5, 1.0) < below, "R should rise to the critical angle");
}

static void test_fresnel_stokes(pds_test_ctx *t)
{
    /* R(1 -> 1.5 at theta_i) = R(1.5 -> 1 at theta_t) */
    int i;
    for (i = 0; i <= 20; i++) {
        double ti = (i / 20.0) * (PDS__PI / 2 - 1e-3);
        double st = sin(ti) / 1.5, ct = sqrt(1.0 - st * st);
        double a = pds__fresnel_dielectric(cos(ti), 1.0, 1.5);
        double b = pds__fresnel_dielectric(ct, 1.5, 1.0);
        CHECK_NEAR(t, a, b, 1e-12);
    }
}

/* ---------------------------------------------------- conductor Fresnel */

typedef struct mtest_cx { double re, im; } mtest_cx;

static mtest_cx mtest_c(double re, double im) { mtest_cx z; z.re = re; z.im = im; return z; }
static mtest_cx mtest_cadd(mtest_cx a, mtest_cx b) { return mtest_c(a.re + b.re, a.im + b.im); }
static mtest_cx mtest_csub(mtest_cx a, mtest_cx b) { return mtest_c(a.re - b.re, a.im - b.im); }
static mtest_cx mtest_cmul(mtest_cx a, mtest_cx b)
{
    return mtest_c(a.re * b.re - a.im * b.im, a.re * b.im + a.im * b.re);
}
static double mtest_cabs2(mtest_cx a) { return a.re * a.re + a.im * a.im; }
/* principal square root (Re >= 0) */
static mtest_cx mtest_csqrt(mtest_cx a)
{
    double m = sqrt(sqrt(mtest_cabs2(a)));
    double arg = atan2(a.im, a.re) / 2.0;
    return mtest_c(m * cos(arg), m * sin(arg));
}

/* Independent reference: the Fresnel amplitudes for complex n = eta + ik,
   with w = n cos_t = sqrt(n^2 - sin^2 i):
   rs = (c - w)/(c + w), rp = (n^2 c - w)/(n^2 c + w), R = (|rs|^2+|rp|^2)/2. */
static double mtest_conductor_ref(double c, double eta, double k)
{
    mtest_cx n = mtest_c(eta, k), n2 = mtest_cmul(n, n), cc = mtest_c(c, 0.0);
    mtest_cx w = mtest_csqrt(mtest_csub(n2, mtest_c(1.0 - c * c, 0.0)));
    mtest_cx n2c = mtest_cmul(n2, cc);
    double rs = mtest_cabs2(mtest_csub(cc, w)) / mtest_cabs2(mtest_cadd(cc, w));
    double rp = mtest_cabs2(mtest_csub(n2c, w)) / mtest_cabs2(mtest_cadd(n2c, w));
    return 0.5 * (rs + rp);
}

static void test_conductor_normal_incidence(pds_test_ctx *t)
{
    static const double nk[][3] = {
        {0.14, 3.697, 0.963}, {0.43, 2.455, 0.787}, {1.38, 1.914, 0.408}, /* gold */
        {0.05, 4.483, 0.991}, {1.47, 7.64, 0.909}                        /* silver, aluminium */
    };
    size_t i;
    for (i = 0; i < sizeof nk / sizeof nk[0]; i++) {
        double n = nk[i][0], k = nk[i][1];
        double r0 = ((n - 1) * (n - 1) + k * k) / ((n + 1) * (n + 1) + k * k);
        double r = pds__fresnel_conductor(1.0, n, k);
        CHECK_NEAR(t, r, r0, 1e-14);
        CHECK_NEAR(t, r, nk[i][2], 5e-4); /* R = ((n-1)^2 + k^2) / ((n+1)^2 + k^2), worked by hand */
    }
    /* gold at 650 nm by hand: 14.407409 / 14.967409 */
    CHECK_NEAR(t, pds__fresnel_conductor(1.0, 0.14, 3.697), 14.407409 / 14.967409, 1e-12);
}

static void test_conductor_grazing(pds_test_ctx *t)
{
    CHECK_NEAR(t, pds__fresnel_conductor(0.0, 0.14, 3.697), 1.0, 1e-14);
    CHECK_NEAR(t, pds__fresnel_conductor(0.0, 1.47, 7.64), 1.0, 1e-14);
    CHECK(t, pds__fresnel_conductor(1e-4, 1.38, 1.914) > 0.999, "near-grazing gold should reflect");
}

static void test_conductor_matches_complex_reference(pds_test_ctx *t)
{
    static const double nk[][2] = {
        {0.14, 3.697}, {0.43, 2.455}, {1.38, 1.914}, {0.05, 4.483},
        {1.47, 7.64}, {0.602, 5.36}, {2.5, 0.3}, {1.0, 1.0}
    };
    size_t i;
    int j;
    for (i = 0; i < sizeof nk / sizeof nk[0]; i++) {
        for (j = 0; j <= 16; j++) {
            double theta = j * (PDS__PI / 2) / 16.0;
            double c = cos(theta);
            if (j == 16) c = 0.0;
            CHECK_NEAR(t, pds__fresnel_conductor(c, nk[i][0], nk[i][1]),
                       mtest_conductor_ref(c, nk[i][0], nk[i][1]), 1e-9);
        }
    }
}

static void test_conductor_zero_k_is_dielectric(pds_test_ctx *t)
{
    int j;
    for (j = 0; j <= 40; j++) {
        double c = j / 40.0;
        CHECK_NEAR(t, pds__fresnel_conductor(c, 1.5, 0.0), pds__fresnel_dielectric(c, 1.0, 1.5), 1e-12);
        /* eta < 1 is the inside of glass, total internal reflection included */
        CHECK_NEAR(t, pds__fresnel_conductor(c, 1.0 / 1.5, 0.0), pds__fresnel_dielectric(c, 1.5, 1.0),
                   1e-12);
    }
}

/* ---------------------------------------------------- directions */

static void test_refract_snell(pds_test_ctx *t)
{
    static const double etas[] = {1.0 / 1.5, 1.5, 1.33 / 1.5, 1.5 / 1.33, 2.4, 1.0 / 2.4, 1.0};
    int i, ntir = 0, nref = 0;
    for (i = 0; i < 2000; i++) {
        double eta = etas[i % 7];
        pds__v3 n = mtest_sphere(mtest_u(1, i, 0), mtest_u(1, i, 1));
        pds__v3 d = mtest_sphere(mtest_u(1, i, 2), mtest_u(1, i, 3));
        pds__v3 tr, r;
        double dn;
        if (pds__dot(d, n) > 0.0) d = pds__scale(d, -1.0);
        dn = pds__dot(d, n);
        r = pds__reflect(d, n);
        CHECK_NEAR(t, pds__length(r), 1.0, 1e-12);
        CHECK_NEAR(t, pds__dot(r, n), -dn, 1e-12);
        if (!pds__refract(d, n, eta, &tr)) {
            ntir++;
            CHECK(t, eta * eta * (1.0 - dn * dn) > 1.0 - 1e-12, "refract reported TIR wrongly (eta %g, cos %g)",
                  eta, -dn);
            continue;
        }
        nref++;
        CHECK_NEAR(t, pds__length(tr), 1.0, 1e-12);
        /* eta_i sin_i = eta_t sin_t, with eta = eta_i/eta_t */
        CHECK_NEAR(t, eta * pds__length(pds__cross(d, n)), pds__length(pds__cross(tr, n)), 1e-12);
        /* in the plane of d and n, and on the far side */
        CHECK_NEAR(t, pds__dot(tr, pds__normalize(pds__cross(d, n))), 0.0, 1e-12);
        CHECK(t, pds__dot(tr, n) <= 0.0, "transmitted direction on the incident side");
        /* the tangential component keeps its direction */
        CHECK(t, pds__dot(pds__sub(tr, pds__scale(n, pds__dot(tr, n))),
                          pds__sub(d, pds__scale(n, dn))) >= 0.0, "tangential component reversed");
    }
    CHECK(t, ntir > 50 && nref > 1000, "sample mix: %d TIR, %d refracted", ntir, nref);
}

static void test_refract_normal_incidence(pds_test_ctx *t)
{
    pds__v3 n = pds__normalize(pds__v(0.2, -0.3, 0.9)), tr;
    static const double etas[] = {0.5, 1.0 / 1.5, 1.0, 1.5, 3.0};
    int i;
    for (i = 0; i < 5; i++) {
        REQUIRE(t, pds__refract(pds__scale(n, -1.0), n, etas[i], &tr), "no TIR at normal incidence");
        CHECK_NEAR(t, tr.x, -n.x, 1e-14);
        CHECK_NEAR(t, tr.y, -n.y, 1e-14);
        CHECK_NEAR(t, tr.z, -n.z, 1e-14);
    }
}

static void test_refract_tir(pds_test_ctx *t)
{
    pds__v3 n = pds__v(0, 0, 1), tr;
    double crit = asin(1.0 / 1.5);
    pds__v3 d_above = pds__v(sin(crit + 0.01), 0, -cos(crit + 0.01));
    pds__v3 d_below = pds__v(sin(crit - 0.01), 0, -cos(crit - 0.01));
    CHECK(t, !pds__refract(d_above, n, 1.5, &tr), "expected TIR above the critical angle");
    CHECK(t, pds__refract(d_below, n, 1.5, &tr), "expected refraction below the critical angle");
    CHECK(t, pds__refract(d_above, n, 1.0 / 1.5, &tr), "never TIR into the denser medium");
}

/* ---------------------------------------------------- BSDF sampling */

static void test_dielectric_radiance_weight(pds_test_ctx *t)
{
    pds_material m = mtest_material(PDS_MAT_DIELECTRIC);
    pds__v3 ng = pds__v(0, 0, 1);
    double u[3] = {0.999999, 0.5, 0.5};
    pds__bsdf_result s;
    /* from the front (air) into glass: eye radiance scales by (1/1.5)^2 */
    pds__v3 wo = pds__v(0.6, 0.0, 0.8);
    REQUIRE(t, pds__bsdf_sample(&m, pds__v(0, 0, 0), wo, ng, ng, u, PDS__RADIANCE, &s), "no sample");
    REQUIRE(t, s.transmitted == 1 && s.delta == 1 && s.side == -1, "expected refraction into the back");
    CHECK_NEAR(t, s.weight[0], 1.0 / 2.25, 1e-15);
    CHECK_NEAR(t, s.weight[2], 1.0 / 2.25, 1e-15);
    CHECK_NEAR(t, s.pdf, 1.0 - pds__fresnel_dielectric(0.8, 1.0, 1.5), 1e-15);
    /* Snell: sin_t = 0.6/1.5 = 0.4, continuing in the same tangent direction */
    CHECK_NEAR(t, s.wi.x, -0.4, 1e-12);
    CHECK_NEAR(t, s.wi.y, 0.0, 1e-12);
    CHECK_NEAR(t, s.wi.z, -sqrt(0.84), 1e-12);
    REQUIRE(t, pds__bsdf_sample(&m, pds__v(0, 0, 0), wo, ng, ng, u, PDS__IMPORTANCE, &s), "no sample");
    CHECK_NEAR(t, s.weight[1], 1.0, 0.0);
    /* from the back (glass) out to air: x 1.5^2 */
    wo = pds__v(0.4, 0.0, -sqrt(0.84));
    REQUIRE(t, pds__bsdf_sample(&m, pds__v(0, 0, 0), wo, ng, ng, u, PDS__RADIANCE, &s), "no sample");
    REQUIRE(t, s.transmitted == 1 && s.side == 1, "expected refraction to the front");
    CHECK_NEAR(t, s.weight[0], 2.25, 1e-14);
    CHECK_NEAR(t, s.wi.x, -0.6, 1e-12);
    CHECK_NEAR(t, s.wi.z, 0.8, 1e-12);
    REQUIRE(t, pds__bsdf_sample(&m, pds__v(0, 0, 0), wo, ng, ng, u, PDS__IMPORTANCE, &s), "no sample");
    CHECK_NEAR(t, s.weight[0], 1.0, 0.0);
    /* reflection carries no eta factor in either mode */
    u[0] = 0.0;
    REQUIRE(t, pds__bsdf_sample(&m, pds__v(0, 0, 0), wo, ng, ng, u, PDS__RADIANCE, &s), "no sample");
    CHECK(t, s.transmitted == 0 && s.side == -1, "expected reflection inside");
    CHECK_NEAR(t, s.weight[0], 1.0, 0.0);
    CHECK_NEAR(t, s.pdf, pds__fresnel_dielectric(sqrt(0.84), 1.5, 1.0), 1e-15);
}

/* Average sample weight for one wo over nsamp draws (failures count 0). */
static void mtest_albedo(const pds_material *m, pds__v3 wo, pds__v3 ns, pds__v3 ng, pds__transport mode,
                         uint64_t seed, int nsamp, double avg[3], int *nrefl, int *nfail)
{
    int j, c;
    avg[0] = avg[1] = avg[2] = 0.0;
    *nrefl = 0;
    *nfail = 0;
    for (j = 0; j < nsamp; j++) {
        double u[3];
        pds__bsdf_result s;
        u[0] = mtest_u(seed, (uint64_t)j, 0);
        u[1] = mtest_u(seed, (uint64_t)j, 1);
        u[2] = mtest_u(seed, (uint64_t)j, 2);
        if (!pds__bsdf_sample(m, pds__v(0, 0, 0), wo, ns, ng, u, mode, &s)) {
            (*nfail)++;
            continue;
        }
        if (!s.transmitted) (*nrefl)++;
        for (c = 0; c < 3; c++) avg[c] += s.weight[c];
    }
    for (c = 0; c < 3; c++) avg[c] /= nsamp;
}

static void test_albedo_at_most_one(pds_test_ctx *t)
{
    static const pds_material_type types[] = {PDS_MAT_DIFFUSE, PDS_MAT_MIRROR, PDS_MAT_CONDUCTOR,
                                              PDS_MAT_DIELECTRIC};
    int i, ti, c, bad = 0, absorbed = 0;
    for (ti = 0; ti < 4; ti++) {
        pds_material m = mtest_material(types[ti]);
        for (i = 0; i < 1000; i++) {
            pds__v3 ng = mtest_sphere(mtest_u(2, i, 0), mtest_u(2, i, 1));
            pds__v3 wo = mtest_sphere(mtest_u(2, i, 2), mtest_u(2, i, 3)); /* either side */
            pds__v3 ns = mtest_tilt(ng, 0.7 * mtest_u(2, i, 4), mtest_u(2, i, 5));
            double avg[3];
            int nr, nf;
            if (i % 4 == 3) ns = pds__scale(ns, -1.0); /* stored against ng */
            mtest_albedo(&m, wo, ns, ng, PDS__IMPORTANCE, 100 + i, 64, avg, &nr, &nf);
            absorbed += nf;
            for (c = 0; c < 3; c++)
                if (!(avg[c] <= 1.0 + 1e-12) || !(avg[c] >= 0.0)) bad++;
        }
    }
    CHECK(t, bad == 0, "%d directional albedo estimates outside [0, 1]", bad);
    /* tilted shading normals must sometimes push samples under the surface */
    CHECK(t, absorbed > 0, "no wrong-side sample was absorbed");
}

static void test_albedo_exact_with_flat_normals(pds_test_ctx *t)
{
    pds_material dif = mtest_material(PDS_MAT_DIFFUSE), mir = mtest_material(PDS_MAT_MIRROR);
    pds_material con = mtest_material(PDS_MAT_CONDUCTOR), die = mtest_material(PDS_MAT_DIELECTRIC);
    int i, c, nr, nf, nsamp = 64;
    double avg[3];
    double refl = 0.0, refl_expect = 0.0, refl_var = 0.0;
    double rad = 0.0, rad_expect = 0.0, rad_var = 0.0;
    for (i = 0; i < 1000; i++) {
        pds__v3 ng = mtest_sphere(mtest_u(3, i, 0), mtest_u(3, i, 1));
        pds__v3 wo = mtest_sphere(mtest_u(3, i, 2), mtest_u(3, i, 3));
        double cosg = fabs(pds__dot(wo, ng));
        int front = pds__dot(wo, ng) > 0.0;
        double ei = front ? 1.0 : 1.5, et = front ? 1.5 : 1.0;
        double f = pds__fresnel_dielectric(cosg, ei, et);
        double g = (ei * ei) / (et * et);

        mtest_albedo(&dif, wo, ng, ng, PDS__RADIANCE, 1000 + i, nsamp, avg, &nr, &nf);
        CHECK(t, nf == 0, "diffuse absorbed %d samples with flat normals", nf);
        for (c = 0; c < 3; c++) CHECK_NEAR(t, avg[c], dif.albedo[c], 1e-12);

        mtest_albedo(&mir, wo, ng, ng, PDS__RADIANCE, 2000 + i, 4, avg, &nr, &nf);
        for (c = 0; c < 3; c++) CHECK_NEAR(t, avg[c], mir.reflectance[c], 1e-12);

        mtest_albedo(&con, wo, ng, ng, PDS__IMPORTANCE, 3000 + i, 4, avg, &nr, &nf);
        for (c = 0; c < 3; c++) CHECK_NEAR(t, avg[c], pds__fresnel_conductor(cosg, con.eta[c], con.k[c]), 1e-12);

        /* dielectric, photons: R + T = 1, nothing absorbed */
        mtest_albedo(&die, wo, ng, ng, PDS__IMPORTANCE, 4000 + i, nsamp, avg, &nr, &nf);
        CHECK(t, nf == 0, "dielectric lost %d samples", nf);
        CHECK_NEAR(t, avg[0], 1.0, 1e-12);
        refl += nr;
        refl_expect += nsamp * f;
        refl_var += nsamp * f * (1.0 - f);

        /* dielectric, eye paths: E[weight] = F + (1 - F)(eta_i/eta_t)^2 */
        mtest_albedo(&die, wo, ng, ng, PDS__RADIANCE, 5000 + i, nsamp, avg, &nr, &nf);
        rad += avg[1] * nsamp;
        rad_expect += nsamp * (f + (1.0 - f) * g);
        rad_var += nsamp * f * (1.0 - f) * (g - 1.0) * (g - 1.0);
    }
    /* reflection is chosen with probability F: within 5 standard deviations */
    CHECK(t, fabs(refl - refl_expect) < 5.0 * sqrt(refl_var), "reflections %g, expected %g +- %g", refl,
          refl_expect, sqrt(refl_var));
    CHECK(t, fabs(rad - rad_expect) < 5.0 * sqrt(rad_var), "radiance sum %g, expected %g +- %g", rad,
          rad_expect, sqrt(rad_var));
}

static void test_diffuse_reciprocity_and_pdf(pds_test_ctx *t)
{
    pds_material m = mtest_material(PDS_MAT_DIFFUSE);
    int i, both = 0;
    for (i = 0; i < 2000; i++) {
        pds__v3 ng = mtest_sphere(mtest_u(4, i, 0), mtest_u(4, i, 1));
        pds__v3 ns = (i & 1) ? mtest_tilt(ng, 0.4 * mtest_u(4, i, 6), mtest_u(4, i, 7)) : ng;
        pds__v3 a = mtest_sphere(mtest_u(4, i, 2), mtest_u(4, i, 3));
        pds__v3 b = mtest_sphere(mtest_u(4, i, 4), mtest_u(4, i, 5));
        double fab[3], fba[3], pab, pba;
        int same_side, above;
        pds__bsdf_eval(&m, pds__v(0, 0, 0), a, b, ns, ng, fab, &pab);
        pds__bsdf_eval(&m, pds__v(0, 0, 0), b, a, ns, ng, fba, &pba);
        same_side = (pds__dot(a, ng) > 0) == (pds__dot(b, ng) > 0);
        /* both above the shading normal turned to their side */
        above = pds__dot(a, ns) * pds__dot(a, ng) > 0 && pds__dot(b, ns) * pds__dot(b, ng) > 0;
        if (same_side && above) {
            both++;
            CHECK_NEAR(t, fab[0], m.albedo[0] / PDS__PI, 1e-15);
            CHECK_NEAR(t, fab[2], m.albedo[2] / PDS__PI, 1e-15);
            /* pdf is the cosine density about the shading normal */
            CHECK_NEAR(t, pab, fabs(pds__dot(b, ns)) / PDS__PI, 1e-12);
            CHECK_NEAR(t, pba, fabs(pds__dot(a, ns)) / PDS__PI, 1e-12);
        }
        if (!same_side) {
            CHECK(t, fab[0] == 0.0 && pab == 0.0, "diffuse transmits");
        }
        if (!same_side || above) {
            CHECK_NEAR(t, fab[0], fba[0], 0.0);
            CHECK_NEAR(t, fab[1], fba[1], 0.0);
        }
    }
    CHECK(t, both > 500, "only %d pairs on one side", both);
}

static void test_diffuse_cosine_distribution(pds_test_ctx *t)
{
    pds_material m = mtest_material(PDS_MAT_DIFFUSE);
    pds__v3 n = pds__normalize(pds__v(0.3, -0.5, 0.8));
    pds__v3 wo = pds__normalize(pds__v(0.1, 0.2, 0.9));
    pds__v3 t1 = pds__normalize(pds__cross(n, pds__v(1, 0, 0))), t2 = pds__cross(n, t1);
    enum { NS = 200000, NB = 10, NP = 8 };
    int bins[NB] = {0}, pbins[NP] = {0};
    int i, b;
    double sumcos = 0.0, chi = 0.0, chip = 0.0;
    for (i = 0; i < NS; i++) {
        double u[3], f[3], pdf, cs, phi;
        pds__bsdf_result s;
        u[0] = mtest_u(5, i, 0);
        u[1] = mtest_u(5, i, 1);
        u[2] = 0.0;
        REQUIRE(t, pds__bsdf_sample(&m, pds__v(0, 0, 0), wo, n, n, u, PDS__RADIANCE, &s), "no diffuse sample");
        REQUIRE(t, s.delta == 0 && s.transmitted == 0 && s.side == 1, "diffuse sample flags");
        cs = pds__dot(s.wi, n);
        sumcos += cs;
        if (i < 1000) {
            CHECK_NEAR(t, pds__length(s.wi), 1.0, 1e-12);
            CHECK_NEAR(t, s.pdf, cs / PDS__PI, 1e-12);
            pds__bsdf_eval(&m, pds__v(0, 0, 0), wo, s.wi, n, n, f, &pdf);
            CHECK_NEAR(t, pdf, s.pdf, 1e-12);
            /* weight = f cos / pdf */
            CHECK_NEAR(t, s.weight[1], f[1] * cs / pdf, 1e-12);
        }
        b = (int)(cs * cs * NB); /* cos^2 is uniform under the cosine density */
        if (b >= NB) b = NB - 1;
        bins[b]++;
        phi = atan2(pds__dot(s.wi, t2), pds__dot(s.wi, t1)) + PDS__PI;
        b = (int)(phi / (2.0 * PDS__PI) * NP);
        if (b >= NP) b = NP - 1;
        pbins[b]++;
    }
    /* E[cos] = int cos^2/pi = 2/3; sd of the mean = sqrt(1/18/NS) = 5.3e-4 */
    CHECK_NEAR(t, sumcos / NS, 2.0 / 3.0, 3e-3);
    for (b = 0; b < NB; b++) {
        double e = (double)NS / NB;
        chi += (bins[b] - e) * (bins[b] - e) / e;
    }
    for (b = 0; b < NP; b++) {
        double e = (double)NS / NP;
        chip += (pbins[b] - e) * (pbins[b] - e) / e;
    }
    /* 0.1% points of chi-square: 27.9 for 9 dof, 24.3 for 7 */
    CHECK(t, chi < 27.9, "cos^2 histogram chi-square %g", chi);
    CHECK(t, chip < 24.3, "azimuth histogram chi-square %g", chip);
}

static void test_geometric_normal_decides_side(pds_test_ctx *t)
{
    pds_material m = mtest_material(PDS_MAT_DIELECTRIC);
    pds__v3 ng = pds__v(0, 0, 1), ns, wo, n, g, wi_ref;
    double u[3] = {0.999999, 0.0, 0.0}, cosn, f;
    int side;
    pds__bsdf_result s;

    /* shading normal stored flipped: still entering from the front */
    wo = pds__v(0.6, 0.0, 0.8);
    REQUIRE(t, pds__bsdf_sample(&m, pds__v(0, 0, 0), wo, pds__scale(ng, -1.0), ng, u, PDS__RADIANCE, &s), "no sample");
    CHECK(t, s.transmitted == 1 && s.side == -1, "expected entering (side %d)", s.side);
    CHECK_NEAR(t, s.weight[0], 1.0 / 2.25, 1e-15);
    CHECK_NEAR(t, s.wi.x, -0.4, 1e-12);

    /* tilted shading normal, wo behind ng: leaving glass (1.5 -> 1) */
    ns = pds__v(sin(0.35), 0.0, cos(0.35));
    wo = pds__normalize(pds__v(0.3, 0.1, -0.9));
    REQUIRE(t, pds__bsdf_frame(wo, ns, ng, &n, &g, &side), "frame");
    CHECK(t, side == -1, "wo should be behind");
    CHECK_NEAR(t, n.x, -ns.x, 1e-15);
    CHECK_NEAR(t, n.z, -ns.z, 1e-15);
    cosn = pds__dot(wo, n);
    f = pds__fresnel_dielectric(cosn, 1.5, 1.0);
    REQUIRE(t, f < 0.5, "test setup: expected no TIR (F %g)", f);
    REQUIRE(t, pds__bsdf_sample(&m, pds__v(0, 0, 0), wo, ns, ng, u, PDS__RADIANCE, &s), "no sample");
    CHECK(t, s.transmitted == 1 && s.side == 1, "expected leaving to the front");
    CHECK_NEAR(t, s.weight[2], 2.25, 1e-14);
    CHECK_NEAR(t, s.pdf, 1.0 - f, 1e-15);
    /* Snell about the shading normal: 1.5 sin_i = 1.0 sin_t */
    CHECK_NEAR(t, 1.5 * pds__length(pds__cross(wo, n)), pds__length(pds__cross(s.wi, n)), 1e-12);

    /* wo in front but below the tilted shading hemisphere: geometric normal */
    ns = pds__v(sin(PDS__PI / 3), 0.0, cos(PDS__PI / 3));
    wo = pds__normalize(pds__v(-1.0, 0.0, 0.3));
    REQUIRE(t, pds__bsdf_frame(wo, ns, ng, &n, &g, &side), "frame");
    CHECK(t, side == 1 && n.z == 1.0, "expected fallback to ng");
    u[0] = 0.0;
    REQUIRE(t, pds__bsdf_sample(&m, pds__v(0, 0, 0), wo, ns, ng, u, PDS__RADIANCE, &s), "no sample");
    wi_ref = pds__v(-wo.x, -wo.y, wo.z);
    CHECK(t, s.transmitted == 0 && s.side == 1, "expected reflection");
    CHECK_NEAR(t, s.wi.x, wi_ref.x, 1e-12);
    CHECK_NEAR(t, s.wi.z, wi_ref.z, 1e-12);
    CHECK_NEAR(t, s.pdf, pds__fresnel_dielectric(wo.z, 1.0, 1.5), 1e-15);
}

static void test_nested_media(pds_test_ctx *t)
{
    /* water (1.33) behind, glass (1.5) in front */
    pds_material m = mtest_material(PDS_MAT_DIELECTRIC);
    pds__v3 ng = pds__v(0, 0, 1), wo;
    double u[3] = {0.0, 0.0, 0.0}, sin_i = 0.5;
    double r0 = (0.17 / 2.83) * (0.17 / 2.83);
    pds__bsdf_result s;
    m.ior = 1.33;
    m.outside_ior = 1.5;
    REQUIRE(t, pds__bsdf_sample(&m, pds__v(0, 0, 0), ng, ng, ng, u, PDS__RADIANCE, &s), "no sample");
    CHECK(t, s.transmitted == 0, "u0 = 0 must reflect");
    CHECK_NEAR(t, s.pdf, r0, 1e-15);
    u[0] = 0.999;
    wo = pds__v(sin_i, 0.0, sqrt(1.0 - sin_i * sin_i));
    REQUIRE(t, pds__bsdf_sample(&m, pds__v(0, 0, 0), wo, ng, ng, u, PDS__RADIANCE, &s), "no sample");
    CHECK(t, s.transmitted == 1 && s.side == -1, "expected entering the water");
    CHECK_NEAR(t, s.weight[0], (1.5 / 1.33) * (1.5 / 1.33), 1e-14);
    CHECK_NEAR(t, -s.wi.x, 1.5 / 1.33 * sin_i, 1e-12); /* 1.5 sin_i = 1.33 sin_t */
    /* and back out of the water into the glass */
    wo = pds__v(0.3, 0.0, -sqrt(1.0 - 0.09));
    REQUIRE(t, pds__bsdf_sample(&m, pds__v(0, 0, 0), wo, ng, ng, u, PDS__RADIANCE, &s), "no sample");
    CHECK(t, s.transmitted == 1 && s.side == 1, "expected leaving the water");
    CHECK_NEAR(t, s.weight[0], (1.33 / 1.5) * (1.33 / 1.5), 1e-14);
    CHECK_NEAR(t, -s.wi.x, 1.33 / 1.5 * 0.3, 1e-12);
    /* water -> glass never totally reflects */
    CHECK(t, pds__fresnel_dielectric(0.01, 1.33, 1.5) < 1.0, "no TIR into the denser glass");
}

static void test_tir_always_reflects(pds_test_ctx *t)
{
    pds_material m = mtest_material(PDS_MAT_DIELECTRIC);
    pds__v3 ng = pds__v(0, 0, 1), wo = pds__v(sin(1.0), 0.0, -cos(1.0)); /* 57 deg inside */
    static const double us[] = {0.0, 0.5, 0.999999};
    int i;
    for (i = 0; i < 3; i++) {
        double u[3];
        pds__bsdf_result s;
        u[0] = us[i]; u[1] = u[2] = 0.5;
        REQUIRE(t, pds__bsdf_sample(&m, pds__v(0, 0, 0), wo, ng, ng, u, PDS__RADIANCE, &s), "no sample");
        CHECK(t, s.transmitted == 0 && s.side == -1 && s.delta == 1, "TIR must reflect inside");
        CHECK_NEAR(t, s.pdf, 1.0, 0.0);
        CHECK_NEAR(t, s.weight[0], 1.0, 0.0);
        CHECK_NEAR(t, s.wi.x, -wo.x, 1e-15);
        CHECK_NEAR(t, s.wi.z, wo.z, 1e-15);
    }
}

static void test_mirror_and_conductor_reflect(pds_test_ctx *t)
{
    pds_material mir = mtest_material(PDS_MAT_MIRROR), con = mtest_material(PDS_MAT_CONDUCTOR);
    pds__v3 ng = pds__normalize(pds__v(0.2, 0.3, 0.9)), wo = pds__normalize(pds__v(-0.5, 0.1, 0.4));
    double u[3] = {0.3, 0.6, 0.9}, c = pds__dot(wo, ng);
    pds__v3 r = pds__sub(pds__scale(ng, 2.0 * c), wo);
    pds__bsdf_result s;
    REQUIRE(t, pds__bsdf_sample(&mir, pds__v(0, 0, 0), wo, ng, ng, u, PDS__RADIANCE, &s), "no sample");
    CHECK(t, s.delta == 1 && s.transmitted == 0 && s.side == 1, "mirror flags");
    CHECK_NEAR(t, s.pdf, 1.0, 0.0);
    CHECK_NEAR(t, s.weight[1], 0.7, 0.0);
    CHECK_NEAR(t, pds__dot(s.wi, r), 1.0, 1e-12);
    /* from behind: reflects behind, same reflectance */
    REQUIRE(t, pds__bsdf_sample(&con, pds__v(0, 0, 0), pds__scale(wo, -1.0), ng, ng, u, PDS__IMPORTANCE, &s), "no sample");
    CHECK(t, s.side == -1 && s.transmitted == 0, "conductor from behind");
    CHECK_NEAR(t, pds__dot(s.wi, pds__scale(r, -1.0)), 1.0, 1e-12);
    CHECK_NEAR(t, s.weight[0], pds__fresnel_conductor(c, 0.14, 3.697), 1e-15);
    CHECK_NEAR(t, s.weight[2], pds__fresnel_conductor(c, 1.38, 1.914), 1e-15);
}

static void test_sample_rejections(pds_test_ctx *t)
{
    pds__v3 ng = pds__v(0, 0, 1), ns = pds__v(sin(PDS__PI / 3), 0.0, cos(PDS__PI / 3));
    double u[3] = {0.25, 0.25, 0.25};
    pds__bsdf_result s;
    pds_material em = mtest_material(PDS_MAT_EMISSIVE), dif = mtest_material(PDS_MAT_DIFFUSE);
    pds_material mir = mtest_material(PDS_MAT_MIRROR);
    CHECK(t, !pds__bsdf_sample(&em, pds__v(0, 0, 0), ng, ng, ng, u, PDS__RADIANCE, &s), "emitters absorb");
    dif.albedo[0] = dif.albedo[1] = dif.albedo[2] = 0.0;
    CHECK(t, !pds__bsdf_sample(&dif, pds__v(0, 0, 0), ng, ng, ng, u, PDS__RADIANCE, &s), "zero albedo absorbs");
    CHECK(t, !pds__bsdf_sample(&mir, pds__v(0, 0, 0), pds__v(1, 0, 0), ng, ng, u, PDS__RADIANCE, &s), "tangent wo");
    /* wo along ng, mirror about a 60-degree shading normal: wi.z = -0.5 */
    CHECK(t, !pds__bsdf_sample(&mir, pds__v(0, 0, 0), ng, ns, ng, u, PDS__RADIANCE, &s), "reflection under the surface");
    CHECK(t, pds__bsdf_sample(&mir, pds__v(0, 0, 0), ng, ng, ng, u, PDS__RADIANCE, &s), "flat mirror reflects");
}

static void test_eval_nondiffuse_is_zero(pds_test_ctx *t)
{
    static const pds_material_type types[] = {PDS_MAT_MIRROR, PDS_MAT_CONDUCTOR, PDS_MAT_DIELECTRIC,
                                              PDS_MAT_EMISSIVE};
    pds__v3 ng = pds__v(0, 0, 1), wo = pds__normalize(pds__v(0.3, 0, 1)), wi = pds__normalize(pds__v(-0.3, 0, 1));
    int i;
    for (i = 0; i < 4; i++) {
        pds_material m = mtest_material(types[i]);
        double f[3] = {1, 1, 1}, pdf = 1;
        pds__bsdf_eval(&m, pds__v(0, 0, 0), wo, wi, ng, ng, f, &pdf);
        CHECK(t, f[0] == 0 && f[1] == 0 && f[2] == 0 && pdf == 0, "type %d: delta BSDFs have no density", (int)types[i]);
        CHECK(t, pds__material_is_specular(&m) == (types[i] != PDS_MAT_EMISSIVE), "is_specular type %d",
              (int)types[i]);
    }
    {
        pds_material m = mtest_material(PDS_MAT_DIFFUSE);
        CHECK(t, !pds__material_is_specular(&m), "diffuse is not specular");
    }
}

/* ---------------------------------------------------- media, dispersion */

static void test_beer(pds_test_ctx *t)
{
    double sigma[3] = {0.5, 1.0, 2.0}, w[3] = {1.0, 2.0, 3.0};
    pds__beer(sigma, 1.5, w);
    CHECK_NEAR(t, w[0], exp(-0.75), 1e-15);
    CHECK_NEAR(t, w[1], 2.0 * exp(-1.5), 1e-15);
    CHECK_NEAR(t, w[2], 3.0 * exp(-3.0), 1e-15);
    pds__beer(NULL, 100.0, w);
    CHECK_NEAR(t, w[0], exp(-0.75), 0.0);
    /* two segments multiply: exp(-s a) exp(-s b) = exp(-s (a + b)) */
    w[0] = w[1] = w[2] = 1.0;
    pds__beer(sigma, 0.3, w);
    pds__beer(sigma, 0.9, w);
    CHECK_NEAR(t, w[2], exp(-2.4), 1e-15);
}

static void test_medium_absorption_side(pds_test_ctx *t)
{
    pds_material m = mtest_material(PDS_MAT_DIELECTRIC);
    const double *s;
    m.absorption[0] = 0.1; m.absorption[1] = 0.2; m.absorption[2] = 0.3;
    CHECK(t, pds__medium_absorption(&m, -1) == m.absorption, "behind = absorption");
    CHECK(t, pds__medium_absorption(&m, 1) == NULL, "clear outside = NULL");
    m.outside_absorption[2] = 0.7;
    s = pds__medium_absorption(&m, 1);
    CHECK(t, s == m.outside_absorption && s[2] == 0.7, "front = outside_absorption");
    m.type = PDS_MAT_DIFFUSE;
    CHECK(t, pds__medium_absorption(&m, -1) == NULL, "only dielectrics bound media");
}

static void test_ior_sellmeier(pds_test_ctx *t)
{
    pds_material m = mtest_material(PDS_MAT_DIELECTRIC);
    m.dispersion = PDS_DISPERSION_SELLMEIER;
    m.dispersion_coef[0] = 1.03961212; m.dispersion_coef[1] = 0.231792344; m.dispersion_coef[2] = 1.01046945;
    m.dispersion_coef[3] = 0.00600069867; m.dispersion_coef[4] = 0.0200179144; m.dispersion_coef[5] = 103.560653;
    CHECK_NEAR(t, pds__ior_at(&m, 587.6), 1.51680, 6e-6);
    CHECK_NEAR(t, pds__ior_at(&m, 486.1), 1.52238, 6e-6);
    CHECK_NEAR(t, pds__ior_at(&m, 400.0), 1.53085, 6e-6);
    CHECK_NEAR(t, pds__ior_at(&m, 656.3), 1.51432, 6e-6);
    CHECK_NEAR(t, pds__ior_at(&m, 700.0), 1.51306, 6e-6);
    m.dispersion = PDS_DISPERSION_NONE;
    CHECK_NEAR(t, pds__ior_at(&m, 400.0), 1.5, 0.0);
}

static void test_ior_cauchy(pds_test_ctx *t)
{
    pds_material m = mtest_material(PDS_MAT_DIELECTRIC);
    m.dispersion = PDS_DISPERSION_CAUCHY;
    m.dispersion_coef[0] = 1.5046;
    m.dispersion_coef[1] = 0.00420;
    CHECK_NEAR(t, pds__ior_at(&m, 500.0), 1.5046 + 0.0042 / 0.25, 1e-14);  /* 1.5214 */
    CHECK_NEAR(t, pds__ior_at(&m, 400.0), 1.5046 + 0.0042 / 0.16, 1e-14);  /* 1.530850 */
    CHECK_NEAR(t, pds__ior_at(&m, 700.0), 1.5046 + 0.0042 / 0.49, 1e-14);
    CHECK(t, pds__ior_at(&m, 450.0) > pds__ior_at(&m, 650.0), "normal dispersion: blue bends more");
}

/* Tiled diffuse materials: the albedo at a tile's middle, the grout's on
   the lines, along the two axes that lie in the surface (a floor: x and
   z; a wall facing z: x and y); the BSDF sampler and evaluator use it. */
static void test_tiles_put_grout_lines_along_the_surface_axes(pds_test_ctx *t)
{
    pds_material m;
    double a[3], f[3], pdf, u[3] = {0.3, 0.6, 0.0};
    pds__bsdf_result s;
    pds__v3 up = pds__v(0, 1, 0), front = pds__v(0, 0, 1);
    memset(&m, 0, sizeof m);
    m.type = PDS_MAT_DIFFUSE;
    m.albedo[0] = m.albedo[1] = m.albedo[2] = 0.5;
    m.tile_size = 0.25;
    m.tile_grout = 0.02;
    m.grout_albedo[0] = m.grout_albedo[1] = m.grout_albedo[2] = 0.9;
    pds__albedo_at(&m, pds__v(0.125, 7.0, -0.375), up, a);
    CHECK_NEAR(t, a[0], 0.5, 0.0);
    pds__albedo_at(&m, pds__v(0.259, 0.0, 0.125), up, a); /* 0.009 from the line x = 0.25 */
    CHECK_NEAR(t, a[1], 0.9, 0.0);
    pds__albedo_at(&m, pds__v(0.262, 0.0, 0.125), up, a); /* 0.012: on the tile */
    CHECK_NEAR(t, a[1], 0.5, 0.0);
    pds__albedo_at(&m, pds__v(0.125, 0.0, -0.495), up, a); /* near z = -0.5 */
    CHECK_NEAR(t, a[2], 0.9, 0.0);
    pds__albedo_at(&m, pds__v(0.125, 0.0, 0.125), front, a); /* a wall: y = 0 is a line */
    CHECK_NEAR(t, a[2], 0.9, 0.0);
    pds__albedo_at(&m, pds__v(0.125, 0.125, 0.0), front, a);
    CHECK_NEAR(t, a[2], 0.5, 0.0);
    REQUIRE(t, pds__bsdf_sample(&m, pds__v(0.25, 0, 0.125), up, up, up, u, PDS__RADIANCE, &s), "no sample");
    CHECK_NEAR(t, s.weight[0], 0.9, 0.0);
    pds__bsdf_eval(&m, pds__v(0.125, 0, 0.125), up, up, up, up, f, &pdf);
    CHECK_NEAR(t, f[0], 0.5 / PDS__PI, 1e-15);
    m.tile_size = 0.0;
    pds__albedo_at(&m, pds__v(0.25, 0.0, 0.25), up, a);
    CHECK_NEAR(t, a[0], 0.5, 0.0);
}

static const pds_test_case tests_materials[] = {
    {"tiles_put_grout_lines_along_the_surface_axes", test_tiles_put_grout_lines_along_the_surface_axes},
    {"fresnel_dielectric_normal_incidence_is_0_04_for_glass", test_fresnel_normal_incidence},
    {"fresnel_dielectric_at_brewster_angle_is_half_r_perp", test_fresnel_brewster},
    {"fresnel_dielectric_matches_hand_value_at_45_degrees", test_fresnel_45_degrees},
    {"fresnel_dielectric_rises_to_one_at_grazing", test_fresnel_grazing},
    {"fresnel_dielectric_total_internal_reflection_above_critical_angle", test_fresnel_tir},
    {"fresnel_dielectric_obeys_stokes_symmetry", test_fresnel_stokes},
    {"fresnel_conductor_normal_incidence_matches_closed_form", test_conductor_normal_incidence},
    {"fresnel_conductor_is_one_at_grazing", test_conductor_grazing},
    {"fresnel_conductor_matches_complex_arithmetic", test_conductor_matches_complex_reference},
    {"fresnel_conductor_with_zero_k_equals_dielectric", test_conductor_zero_k_is_dielectric},
    {"refract_obeys_snell_and_stays_in_plane", test_refract_snell},
    {"refract_at_normal_incidence_goes_straight_through", test_refract_normal_incidence},
    {"refract_reports_total_internal_reflection", test_refract_tir},
    {"dielectric_radiance_weight_is_eta_ratio_squared_both_ways", test_dielectric_radiance_weight},
    {"bsdf_directional_albedo_never_exceeds_one", test_albedo_at_most_one},
    {"bsdf_albedo_is_exact_with_flat_normals", test_albedo_exact_with_flat_normals},
    {"diffuse_bsdf_is_reciprocal_with_cosine_pdf", test_diffuse_reciprocity_and_pdf},
    {"diffuse_samples_are_cosine_distributed", test_diffuse_cosine_distribution},
    {"dielectric_side_is_decided_by_geometric_normal", test_geometric_normal_decides_side},
    {"dielectric_nested_media_use_outside_over_inside_ior", test_nested_media},
    {"dielectric_total_internal_reflection_always_reflects", test_tir_always_reflects},
    {"mirror_and_conductor_reflect_with_their_weights", test_mirror_and_conductor_reflect},
    {"bsdf_sample_absorbs_emitters_black_and_wrong_side", test_sample_rejections},
    {"bsdf_eval_has_no_density_for_specular", test_eval_nondiffuse_is_zero},
    {"beer_transmittance_is_exp_minus_sigma_d", test_beer},
    {"medium_absorption_picks_the_side", test_medium_absorption_side},
    {"ior_sellmeier_bk7_matches_reference", test_ior_sellmeier},
    {"ior_cauchy_bk7_formula_exact", test_ior_cauchy},
};

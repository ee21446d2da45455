/* tests/test_lights.c - light sampling, pdfs, emission and selection,
   checked against closed forms (point and spot intensity, disk irradiance,
   Lambert's polygon formula, spot power) and Monte Carlo within noise. */

/* --- helpers ------------------------------------------------------------ */

static double tlights_u(uint64_t seed, uint64_t index, uint64_t dim)
{
    return pds__rng_uniform(seed, PDS__RNG_TEST, index, dim);
}

static void tlights_rgb(double out[3], double a, double b, double c)
{
    out[0] = a;
    out[1] = b;
    out[2] = c;
}

static pds_light tlights_point(pds__v3 pos, double p0, double p1, double p2)
{
    pds_light l;
    memset(&l, 0, sizeof l);
    l.type = PDS_LIGHT_POINT;
    l.position = pos;
    tlights_rgb(l.power, p0, p1, p2);
    l.material = -1;
    return l;
}

static pds_light tlights_spot(pds__v3 pos, pds__v3 axis, double inner, double outer, double p)
{
    pds_light l;
    memset(&l, 0, sizeof l);
    l.type = PDS_LIGHT_SPOT;
    l.position = pos;
    l.direction = pds__normalize(axis);
    l.cone_inner_deg = inner;
    l.cone_outer_deg = outer;
    tlights_rgb(l.power, p, 2.0 * p, 0.5 * p);
    l.material = -1;
    return l;
}

/* Disk/quad: radiance given, area and power filled as the parser does. */
static pds_light tlights_disk(pds__v3 c, pds__v3 n, double r, double L)
{
    pds_light l;
    int k;
    memset(&l, 0, sizeof l);
    l.type = PDS_LIGHT_DISK;
    l.position = c;
    l.direction = pds__normalize(n);
    l.radius = r;
    l.area = PDS__PI * r * r;
    tlights_rgb(l.radiance, L, 0.5 * L, 2.0 * L);
    for (k = 0; k < 3; k++) l.power[k] = PDS__PI * l.radiance[k] * l.area;
    l.material = -1;
    return l;
}

static pds_light tlights_quad(pds__v3 c, pds__v3 e1, pds__v3 e2, double L)
{
    pds_light l;
    int k;
    memset(&l, 0, sizeof l);
    l.type = PDS_LIGHT_QUAD;
    l.position = c;
    l.edge1 = e1;
    l.edge2 = e2;
    l.area = pds__length(pds__cross(e1, e2));
    l.direction = pds__normalize(pds__cross(e1, e2));
    tlights_rgb(l.radiance, L, 0.5 * L, 2.0 * L);
    for (k = 0; k < 3; k++) l.power[k] = PDS__PI * l.radiance[k] * l.area;
    l.material = -1;
    return l;
}

static pds_light tlights_directional(pds__v3 d, int shape, pds__v3 c, double r, pds__v3 e1, pds__v3 e2, double E)
{
    pds_light l;
    int k;
    memset(&l, 0, sizeof l);
    l.type = PDS_LIGHT_DIRECTIONAL;
    l.direction = pds__normalize(d);
    l.emitter_shape = shape;
    l.position = c;
    l.radius = r;
    l.edge1 = e1;
    l.edge2 = e2;
    l.area = shape == 0 ? PDS__PI * r * r : fabs(pds__dot(pds__cross(e1, e2), l.direction));
    tlights_rgb(l.irradiance, E, 2.0 * E, 3.0 * E);
    for (k = 0; k < 3; k++) l.power[k] = l.irradiance[k] * l.area;
    l.material = -1;
    return l;
}

static pds_light tlights_mesh(int first, int count, double area, double L)
{
    pds_light l;
    int k;
    memset(&l, 0, sizeof l);
    l.type = PDS_LIGHT_MESH;
    l.material = 1;
    l.first_triangle = first;
    l.triangle_count = count;
    l.area = area;
    tlights_rgb(l.radiance, L, 0.5 * L, 2.0 * L);
    for (k = 0; k < 3; k++) l.power[k] = PDS__PI * l.radiance[k] * l.area;
    return l;
}

static long tlights_vert(pds__mesh *m, double x, double y, double z)
{
    return pds__mesh_add_vertex(m, pds__v(x, y, z), pds__v(0.0, 1.0, 0.0));
}

/* Triangle 0: a non-emissive triangle on the floor; triangles 1 and 2: the
   square |x|, |z| <= a at height h, facing -y (material 1). */
static int tlights_square_mesh(pds__mesh *m, double h, double a)
{
    long f0 = tlights_vert(m, 5, 0, 5), f1 = tlights_vert(m, 6, 0, 5), f2 = tlights_vert(m, 5, 0, 6);
    long v0 = tlights_vert(m, -a, h, -a), v1 = tlights_vert(m, a, h, -a);
    long v2 = tlights_vert(m, a, h, a), v3 = tlights_vert(m, -a, h, a);
    int ok = 1;
    ok &= pds__mesh_add_tri(m, f0, f2, f1, 0) == 1;
    ok &= pds__mesh_add_tri(m, v0, v1, v2, 1) == 1;
    ok &= pds__mesh_add_tri(m, v0, v2, v3, 1) == 1;
    return ok;
}

/* Irradiance at p (normal np) from a planar convex polygon of constant
   radiance L entirely above p's horizon (Lambert's formula):
   E = L/2 |sum_i angle(v_i, v_i+1) np . unit(v_i x v_i+1)|. */
static double tlights_lambert(pds__v3 p, pds__v3 np, const pds__v3 *poly, int n, double L)
{
    double sum = 0.0;
    int i;
    for (i = 0; i < n; i++) {
        pds__v3 a = pds__normalize(pds__sub(poly[i], p));
        pds__v3 b = pds__normalize(pds__sub(poly[(i + 1) % n], p));
        double c = pds__dot(a, b);
        if (c > 1.0) c = 1.0;
        if (c < -1.0) c = -1.0;
        sum += acos(c) * pds__dot(np, pds__normalize(pds__cross(a, b)));
    }
    return 0.5 * L * fabs(sum);
}

/* Monte Carlo irradiance at p (normal np) from light li: mean of
   li * cos / pdf over n samples, with its standard error. Returns the
   number of samples that returned 1. */
static long tlights_mc_irradiance(const pds__light_table *lt, const pds_light *l, int index,
                                  const pds__mesh *mesh, pds__v3 p, pds__v3 np, long n, uint64_t seed,
                                  double *mean, double *se)
{
    double s = 0.0, s2 = 0.0;
    long i, ok = 0;
    for (i = 0; i < n; i++) {
        pds__light_li r;
        double f = 0.0;
        if (pds__light_sample_li(lt, l, index, mesh, p, tlights_u(seed, (uint64_t)i, 0),
                                 tlights_u(seed, (uint64_t)i, 1), &r)) {
            double c = pds__dot(r.wi, np);
            ok++;
            if (c > 0.0) f = r.li[0] * c / r.pdf;
        }
        s += f;
        s2 += f * f;
    }
    *mean = s / (double)n;
    *se = sqrt(fmax(0.0, s2 / (double)n - (*mean) * (*mean)) / (double)n);
    return ok;
}

/* Möller-Trumbore, for the brute-force hit test against mesh lights. */
static int tlights_ray_tri(pds__v3 o, pds__v3 d, pds__v3 p0, pds__v3 p1, pds__v3 p2, double *t)
{
    pds__v3 e1 = pds__sub(p1, p0), e2 = pds__sub(p2, p0), pv = pds__cross(d, e2), tv, qv;
    double det = pds__dot(e1, pv), u, v;
    if (fabs(det) < 1e-14) return 0;
    tv = pds__sub(o, p0);
    u = pds__dot(tv, pv) / det;
    if (u < 0.0 || u > 1.0) return 0;
    qv = pds__cross(tv, e1);
    v = pds__dot(d, qv) / det;
    if (v < 0.0 || u + v > 1.0) return 0;
    *t = pds__dot(e2, qv) / det;
    return *t > 0.0;
}

/* Uniform direction on the sphere. */
static pds__v3 tlights_sphere_dir(double u1, double u2)
{
    double z = 1.0 - 2.0 * u1, s = sqrt(fmax(0.0, 1.0 - z * z)), phi = 2.0 * PDS__PI * u2;
    return pds__v(s * cos(phi), s * sin(phi), z);
}

/* --- tests ---------------------------------------------------------------- */

static void test_lights_point_li_is_power_over_4pi_r2(pds_test_ctx *t)
{
    pds_light l = tlights_point(pds__v(1.0, 2.0, 3.0), 4.0, 8.0, 12.0);
    pds__light_table lt;
    pds__light_li r;
    pds__v3 p = pds__v(1.0 + 1.5, 2.0 - 2.0, 3.0);
    double r2 = 1.5 * 1.5 + 2.0 * 2.0;
    int c;
    REQUIRE(t, pds__lights_prepare(&lt, &l, 1, NULL, NULL) == PDS_OK, "prepare failed");
    REQUIRE(t, pds__light_sample_li(&lt, &l, 0, NULL, p, 0.3, 0.7, &r) == 1, "point light gave nothing");
    for (c = 0; c < 3; c++) CHECK_NEAR(t, r.li[c], l.power[c] / (4.0 * PDS__PI * r2), 1e-12);
    CHECK_NEAR(t, r.dist, sqrt(r2), 1e-12);
    CHECK_NEAR(t, r.wi.x, -1.5 / sqrt(r2), 1e-12);
    CHECK_NEAR(t, r.wi.y, 2.0 / sqrt(r2), 1e-12);
    CHECK_NEAR(t, r.wi.z, 0.0, 1e-12);
    CHECK(t, r.pdf == 1.0 && r.delta == 1, "pdf %g delta %d", r.pdf, r.delta);
    CHECK(t, pds__light_sample_li(&lt, &l, 0, NULL, l.position, 0.3, 0.7, &r) == 0,
          "a point at the light itself receives nothing");
    pds__lights_free(&lt);
}

static void test_lights_spot_li_follows_smoothstep_cone(pds_test_ctx *t)
{
    pds_light l = tlights_spot(pds__v(0.0, 3.0, 0.0), pds__v(0.0, -1.0, 0.0), 20.0, 40.0, 10.0);
    pds__light_table lt;
    pds__light_li r;
    double ci = cos(20.0 * PDS__PI / 180.0), co = cos(40.0 * PDS__PI / 180.0);
    double i0 = 10.0 / (2.0 * PDS__PI * ((1.0 - ci) + 0.5 * (ci - co)));
    double deg[3] = {10.0, 30.0, 50.0}, x, s;
    int k;
    REQUIRE(t, pds__lights_prepare(&lt, &l, 1, NULL, NULL) == PDS_OK, "prepare failed");
    for (k = 0; k < 3; k++) {
        double a = deg[k] * PDS__PI / 180.0, dist = 2.0;
        pds__v3 p = pds__v(dist * sin(a), 3.0 - dist * cos(a), 0.0);
        int got = pds__light_sample_li(&lt, &l, 0, NULL, p, 0.5, 0.5, &r);
        if (k == 0) s = 1.0;
        else if (k == 1) {
            x = (cos(a) - co) / (ci - co);
            s = 3.0 * x * x - 2.0 * x * x * x;
        } else s = 0.0;
        CHECK(t, got == (s > 0.0), "angle %g: returned %d", deg[k], got);
        CHECK_NEAR(t, r.li[0], i0 * s / (dist * dist), 1e-12);
        CHECK_NEAR(t, r.li[1], 2.0 * i0 * s / (dist * dist), 1e-12);
        if (got) CHECK(t, r.delta == 1 && r.pdf == 1.0, "delta light pdf");
    }
    /* hard cone: inner == outer */
    l.cone_inner_deg = l.cone_outer_deg = 30.0;
    co = cos(30.0 * PDS__PI / 180.0);
    i0 = 10.0 / (2.0 * PDS__PI * (1.0 - co));
    CHECK(t, pds__light_sample_li(&lt, &l, 0, NULL, pds__v(0.5, 0.0, 0.0), 0.5, 0.5, &r) == 1, "inside hard cone");
    CHECK_NEAR(t, r.li[0], i0 / (0.25 + 9.0), 1e-12);
    CHECK(t, pds__light_sample_li(&lt, &l, 0, NULL, pds__v(2.0, 0.0, 0.0), 0.5, 0.5, &r) == 0, "outside hard cone");
    pds__lights_free(&lt);
}

static void test_lights_disk_irradiance_matches_analytic(pds_test_ctx *t)
{
    double h = 2.0, R = 1.0, L = 3.0, E = PDS__PI * L * R * R / (h * h + R * R), mean, se;
    pds_light l = tlights_disk(pds__v(0.0, h, 0.0), pds__v(0.0, -1.0, 0.0), R, L);
    pds__light_table lt;
    long ok;
    REQUIRE(t, pds__lights_prepare(&lt, &l, 1, NULL, NULL) == PDS_OK, "prepare failed");
    ok = tlights_mc_irradiance(&lt, &l, 0, NULL, pds__v(0, 0, 0), pds__v(0, 1, 0), 200000, 11, &mean, &se);
    CHECK(t, ok == 200000, "%ld of 200000 samples returned 1", ok);
    CHECK(t, se < 0.01 * E, "noise %g too large to judge", se);
    CHECK(t, fabs(mean - E) < 5.0 * se, "MC irradiance %.6g, analytic %.6g (se %.3g)", mean, E, se);
    /* behind the one-sided disk: nothing, for any sample */
    ok = tlights_mc_irradiance(&lt, &l, 0, NULL, pds__v(0, 3, 0), pds__v(0, -1, 0), 1000, 12, &mean, &se);
    CHECK(t, ok == 0 && mean == 0.0, "behind the disk: %ld samples returned 1, mean %g", ok, mean);
    pds__lights_free(&lt);
}

static void test_lights_quad_irradiance_matches_lambert_formula(pds_test_ctx *t)
{
    pds__v3 c = pds__v(0.2, 1.5, 0.1), e1 = pds__v(1.0, 0.3, 0.0), e2 = pds__v(0.0, 0.2, 1.0);
    pds_light l = tlights_quad(c, e1, e2, 2.0);
    pds__light_table lt;
    pds__v3 poly[4], p = pds__v(0.3, 0.0, -0.2), np = pds__v(0, 1, 0);
    double E, mean, se;
    long ok;
    poly[0] = pds__sub(pds__sub(c, pds__scale(e1, 0.5)), pds__scale(e2, 0.5));
    poly[1] = pds__sub(pds__add(c, pds__scale(e1, 0.5)), pds__scale(e2, 0.5));
    poly[2] = pds__add(pds__add(c, pds__scale(e1, 0.5)), pds__scale(e2, 0.5));
    poly[3] = pds__add(pds__sub(c, pds__scale(e1, 0.5)), pds__scale(e2, 0.5));
    E = tlights_lambert(p, np, poly, 4, 2.0);
    REQUIRE(t, l.direction.y < 0.0, "test quad must face down");
    REQUIRE(t, pds__lights_prepare(&lt, &l, 1, NULL, NULL) == PDS_OK, "prepare failed");
    ok = tlights_mc_irradiance(&lt, &l, 0, NULL, p, np, 200000, 21, &mean, &se);
    CHECK(t, ok == 200000, "%ld of 200000 samples returned 1", ok);
    CHECK(t, se < 0.01 * E, "noise %g too large to judge", se);
    CHECK(t, fabs(mean - E) < 5.0 * se, "MC irradiance %.6g, Lambert %.6g (se %.3g)", mean, E, se);
    ok = tlights_mc_irradiance(&lt, &l, 0, NULL, pds__v(0, 4, 0), pds__v(0, -1, 0), 1000, 22, &mean, &se);
    CHECK(t, ok == 0 && mean == 0.0, "behind the quad: %ld samples returned 1", ok);
    pds__lights_free(&lt);
}

static void test_lights_mesh_irradiance_matches_lambert_formula(pds_test_ctx *t)
{
    pds__mesh m;
    double h = 1.2, a = 0.5, E, mean, se;
    pds_light l[2];
    pds__light_table lt;
    pds__v3 poly[4], p = pds__v(0.4, 0.0, 0.1), np = pds__v(0, 1, 0);
    long ok;
    memset(&m, 0, sizeof m);
    REQUIRE(t, tlights_square_mesh(&m, h, a), "mesh build failed");
    l[0] = tlights_point(pds__v(0, 9, 0), 1, 1, 1);
    l[1] = tlights_mesh(1, 2, 4.0 * a * a, 2.5);
    poly[0] = pds__v(-a, h, -a);
    poly[1] = pds__v(a, h, -a);
    poly[2] = pds__v(a, h, a);
    poly[3] = pds__v(-a, h, a);
    E = tlights_lambert(p, np, poly, 4, 2.5);
    REQUIRE(t, pds__lights_prepare(&lt, l, 2, &m, NULL) == PDS_OK, "prepare failed");
    CHECK_NEAR(t, lt.area[1], 4.0 * a * a, 1e-6);
    ok = tlights_mc_irradiance(&lt, &l[1], 1, &m, p, np, 200000, 31, &mean, &se);
    CHECK(t, ok == 200000, "%ld of 200000 samples returned 1", ok);
    CHECK(t, se < 0.01 * E, "noise %g too large to judge", se);
    CHECK(t, fabs(mean - E) < 5.0 * se, "MC irradiance %.6g, Lambert %.6g (se %.3g)", mean, E, se);
    ok = tlights_mc_irradiance(&lt, &l[1], 1, &m, pds__v(0, 2, 0), pds__v(0, -1, 0), 1000, 32, &mean, &se);
    CHECK(t, ok == 0 && mean == 0.0, "behind the mesh light: %ld samples returned 1", ok);
    /* a wrong index (not a mesh light in the table) is refused, not a crash */
    CHECK(t, tlights_mc_irradiance(&lt, &l[1], 0, &m, p, np, 10, 33, &mean, &se) == 0, "wrong index accepted");
    pds__lights_free(&lt);
    pds__mesh_free(&m);
}

static void test_lights_pdf_li_matches_sampled_pdf(pds_test_ctx *t)
{
    pds__mesh m;
    pds_light l[4];
    pds__light_table lt;
    pds__v3 p = pds__v(0.1, 0.0, 0.2), nx[3];
    int k;
    long i;
    memset(&m, 0, sizeof m);
    REQUIRE(t, tlights_square_mesh(&m, 1.0, 0.5), "mesh build failed");
    l[0] = tlights_disk(pds__v(0.3, 1.5, 0.0), pds__v(0.2, -1.0, 0.1), 0.7, 1.0);
    l[1] = tlights_quad(pds__v(-0.2, 2.0, 0.3), pds__v(1.0, 0.3, 0.0), pds__v(0.0, 0.2, 1.0), 1.0);
    l[2] = tlights_mesh(1, 2, 1.0, 1.0);
    l[3] = tlights_point(pds__v(0, 3, 0), 1, 1, 1);
    nx[0] = l[0].direction;
    nx[1] = l[1].direction;
    nx[2] = pds__v(0, -1, 0);
    REQUIRE(t, pds__lights_prepare(&lt, l, 4, &m, NULL) == PDS_OK, "prepare failed");
    for (k = 0; k < 3; k++) {
        int mismatches = 0, sampled = 0;
        for (i = 0; i < 2000; i++) {
            pds__light_li r;
            pds__v3 x;
            double pdf, pdf_back;
            if (!pds__light_sample_li(&lt, &l[k], k, &m, p, tlights_u(41 + k, i, 0), tlights_u(41 + k, i, 1), &r))
                continue;
            sampled++;
            x = pds__add(p, pds__scale(r.wi, r.dist));
            pdf = pds__light_pdf_li(&lt, &l[k], k, &m, p, x, nx[k]);
            pdf_back = pds__light_pdf_li(&lt, &l[k], k, &m, p, x, pds__scale(nx[k], -1.0));
            if (!(fabs(pdf - r.pdf) <= 1e-9 * r.pdf) || pdf_back != pdf || r.delta) mismatches++;
        }
        CHECK(t, sampled == 2000, "light %d: %d of 2000 samples", k, sampled);
        CHECK(t, mismatches == 0, "light %d: %d pdf mismatches", k, mismatches);
    }
    CHECK(t, pds__light_pdf_li(&lt, &l[3], 3, &m, p, l[3].position, pds__v(0, 1, 0)) == 0.0,
          "delta light pdf_li must be 0");
    pds__lights_free(&lt);
    pds__mesh_free(&m);
}

static void test_lights_pdf_li_integrates_to_one_over_directions(pds_test_ctx *t)
{
    pds__mesh m;
    pds_light l[3];
    pds__light_table lt;
    pds__v3 p = pds__v(0.1, 0.0, 0.2);
    long i, n = 400000;
    int k;
    memset(&m, 0, sizeof m);
    REQUIRE(t, tlights_square_mesh(&m, 0.8, 0.6), "mesh build failed");
    l[0] = tlights_disk(pds__v(0.3, 1.0, 0.0), pds__v(0.2, -1.0, 0.1), 0.9, 1.0);
    l[1] = tlights_quad(pds__v(-0.2, 1.0, 0.3), pds__v(1.5, 0.3, 0.0), pds__v(0.0, 0.2, 1.2), 1.0);
    l[2] = tlights_mesh(1, 2, 4.0 * 0.36, 1.0);
    REQUIRE(t, pds__lights_prepare(&lt, l, 3, &m, NULL) == PDS_OK, "prepare failed");
    for (k = 0; k < 3; k++) {
        double s = 0.0, s2 = 0.0, mean, se;
        long hits = 0;
        for (i = 0; i < n; i++) {
            pds__v3 d = tlights_sphere_dir(tlights_u(51 + k, i, 0), tlights_u(51 + k, i, 1)), nx;
            double th = 0.0, f = 0.0;
            int hit = 0;
            if (k < 2) {
                hit = pds__light_intersect(&l[k], p, d, 1e-9, 1e30, &th, &nx);
            } else {
                long tri;
                for (tri = 1; tri <= 2 && !hit; tri++) {
                    pds__v3 p0, p1, p2;
                    pds__lights_tri_geom(&m, tri, &p0, &p1, &p2, &nx);
                    hit = tlights_ray_tri(p, d, p0, p1, p2, &th);
                }
            }
            if (hit) {
                hits++;
                f = 4.0 * PDS__PI * pds__light_pdf_li(&lt, &l[k], k, &m, p, pds__add(p, pds__scale(d, th)), nx);
            }
            s += f;
            s2 += f * f;
        }
        mean = s / (double)n;
        se = sqrt(fmax(0.0, s2 / (double)n - mean * mean) / (double)n);
        CHECK(t, hits > n / 20, "light %d: only %ld hits", k, hits);
        CHECK(t, se < 0.02, "light %d: noise %g too large", k, se);
        CHECK(t, fabs(mean - 1.0) < 5.0 * se, "light %d: integral of pdf_li = %.5f (se %.4f), expected 1", k, mean, se);
    }
    pds__lights_free(&lt);
    pds__mesh_free(&m);
}

/* Flux means per channel over n samples; checks each sample with fn. */
static void test_lights_emission_flux_mean_equals_power(pds_test_ctx *t)
{
    pds__mesh m;
    pds_light l[7];
    pds__light_table lt;
    long i, n = 100000;
    int k, c;
    long v0, v1, v2, v3, v4, v5;
    memset(&m, 0, sizeof m);
    /* mesh light of two triangles with areas 0.5 and 1.5 facing +y */
    v0 = tlights_vert(&m, 0, 1, 0);
    v1 = tlights_vert(&m, 0, 1, 1);
    v2 = tlights_vert(&m, 1, 1, 0);
    v3 = tlights_vert(&m, 2, 1, 0);
    v4 = tlights_vert(&m, 2, 1, 3);
    v5 = tlights_vert(&m, 3, 1, 0);
    REQUIRE(t, pds__mesh_add_tri(&m, v0, v1, v2, 1) == 1 && pds__mesh_add_tri(&m, v3, v4, v5, 1) == 1,
            "mesh build failed");
    l[0] = tlights_point(pds__v(1, 2, 3), 5.0, 6.0, 7.0);
    l[1] = tlights_spot(pds__v(0, 3, 0), pds__v(0.3, -1.0, 0.2), 15.0, 35.0, 8.0);
    l[2] = tlights_disk(pds__v(0.3, 1.5, 0.0), pds__v(0.2, -1.0, 0.1), 0.7, 2.0);
    l[3] = tlights_quad(pds__v(-0.2, 2.0, 0.3), pds__v(1.0, 0.3, 0.0), pds__v(0.0, 0.2, 1.0), 3.0);
    l[4] = tlights_mesh(0, 2, 2.0, 1.5);
    l[5] = tlights_directional(pds__v(0, -1, 0), 0, pds__v(0, 5, 0), 1.3, pds__v(0, 0, 0), pds__v(0, 0, 0), 4.0);
    l[6] = tlights_directional(pds__v(1, -2, 0.5), 1, pds__v(0, 4, 0), 0.0, pds__v(2, 0, 0), pds__v(0, 0.5, 1.5), 4.0);
    REQUIRE(t, pds__lights_prepare(&lt, l, 7, &m, NULL) == PDS_OK, "prepare failed");
    for (k = 0; k < 7; k++) {
        double s[3] = {0, 0, 0}, s2[3] = {0, 0, 0}, expect[3], sumcos = 0.0, frac_small = 0.0;
        double spot_ci, spot_co;
        int bad_pos = 0, bad_dir = 0, bad_pdf = 0, fails = 0;
        pds__v3 axis = pds__normalize(l[k].direction), mean_dir = pds__v(0, 0, 0);
        pds__light_spot_cones(&l[k], &spot_ci, &spot_co);
        for (c = 0; c < 3; c++)
            expect[c] = l[k].type == PDS_LIGHT_DIRECTIONAL ? l[k].irradiance[c] * l[k].area : l[k].power[c];
        for (i = 0; i < n; i++) {
            double u[4];
            pds__light_emit e;
            int d;
            for (d = 0; d < 4; d++) u[d] = tlights_u(61 + k, i, d);
            if (!pds__light_emit_sample(&lt, &l[k], k, &m, u, &e)) {
                fails++;
                continue;
            }
            for (c = 0; c < 3; c++) {
                s[c] += e.flux[c];
                s2[c] += e.flux[c] * e.flux[c];
            }
            if (fabs(pds__length(e.dir) - 1.0) > 1e-9) bad_dir++;
            mean_dir = pds__add(mean_dir, e.dir);
            switch (l[k].type) {
            case PDS_LIGHT_POINT:
                if (pds__length(pds__sub(e.pos, l[k].position)) != 0.0 || pds__length(e.normal) != 0.0) bad_pos++;
                if (e.pdf_pos != 1.0 || fabs(e.pdf_dir - 1.0 / (4.0 * PDS__PI)) > 1e-12) bad_pdf++;
                break;
            case PDS_LIGHT_SPOT:
                if (pds__length(pds__sub(e.pos, l[k].position)) != 0.0 || pds__length(e.normal) != 0.0) bad_pos++;
                if (pds__dot(e.dir, axis) < spot_co - 1e-12) bad_dir++;
                if (fabs(e.pdf_dir * 2.0 * PDS__PI * (1.0 - spot_co) - 1.0) > 1e-9) bad_pdf++;
                break;
            case PDS_LIGHT_DISK: {
                pds__v3 r = pds__sub(e.pos, l[k].position);
                if (fabs(pds__dot(r, axis)) > 1e-9 || pds__length(r) > l[k].radius * (1.0 + 1e-9)) bad_pos++;
                break;
            }
            case PDS_LIGHT_QUAD: {
                pds__v3 r = pds__sub(e.pos, l[k].position), nq = pds__cross(l[k].edge1, l[k].edge2);
                double a = pds__dot(pds__cross(r, l[k].edge2), nq) / pds__dot(nq, nq);
                double b = pds__dot(pds__cross(l[k].edge1, r), nq) / pds__dot(nq, nq);
                if (fabs(pds__dot(r, l[k].direction)) > 1e-9 || fabs(a) > 0.5 + 1e-9 || fabs(b) > 0.5 + 1e-9)
                    bad_pos++;
                break;
            }
            case PDS_LIGHT_MESH:
                /* on T1 = {x, z >= 0, x + z <= 1} or T2 = {x >= 2, z >= 0, 3(x - 2) + z <= 3} at y = 1 */
                if (fabs(e.pos.y - 1.0) > 1e-6 || e.pos.z < -1e-9) bad_pos++;
                else if (e.pos.x < 1.5) {
                    if (e.pos.x < -1e-9 || e.pos.x + e.pos.z > 1.0 + 1e-9) bad_pos++;
                    frac_small += 1.0;
                } else if (e.pos.x < 2.0 - 1e-9 || 3.0 * (e.pos.x - 2.0) + e.pos.z > 3.0 + 1e-6) bad_pos++;
                break;
            case PDS_LIGHT_DIRECTIONAL:
                if (pds__length(pds__sub(e.dir, axis)) > 1e-12 || pds__length(pds__sub(e.normal, axis)) > 1e-12)
                    bad_dir++;
                if (e.pdf_dir != 1.0 || fabs(e.pdf_pos * l[k].area - 1.0) > 1e-9) bad_pdf++;
                if (l[k].emitter_shape == 0) {
                    pds__v3 r = pds__sub(e.pos, l[k].position);
                    if (fabs(pds__dot(r, axis)) > 1e-9 || pds__length(r) > l[k].radius * (1.0 + 1e-9)) bad_pos++;
                } else {
                    pds__v3 r = pds__sub(e.pos, l[k].position), nq = pds__cross(l[k].edge1, l[k].edge2);
                    double a = pds__dot(pds__cross(r, l[k].edge2), nq) / pds__dot(nq, nq);
                    double b = pds__dot(pds__cross(l[k].edge1, r), nq) / pds__dot(nq, nq);
                    if (fabs(pds__dot(r, nq)) > 1e-9 || fabs(a) > 0.5 + 1e-9 || fabs(b) > 0.5 + 1e-9) bad_pos++;
                }
                break;
            case PDS_LIGHT_ENVIRONMENT: /* not in this table: tests/test_envlight.c */
                break;
            }
            if (pds__light_is_area(l[k].type)) {
                double cs = pds__dot(e.dir, e.normal);
                if (!(cs > 0.0)) bad_dir++;
                if (fabs(pds__length(e.normal) - 1.0) > 1e-9) bad_dir++;
                if (l[k].type != PDS_LIGHT_MESH && pds__length(pds__sub(e.normal, l[k].direction)) > 1e-9) bad_dir++;
                if (fabs(e.pdf_dir - cs / PDS__PI) > 1e-9 || fabs(e.pdf_pos * l[k].area - 1.0) > 1e-6) bad_pdf++;
                sumcos += cs;
            }
        }
        CHECK(t, bad_pos == 0 && bad_dir == 0 && bad_pdf == 0,
              "light %d: %d bad positions, %d bad directions, %d bad pdfs", k, bad_pos, bad_dir, bad_pdf);
        CHECK(t, fails == 0 || l[k].type == PDS_LIGHT_SPOT, "light %d: %d failed samples", k, fails);
        for (c = 0; c < 3; c++) {
            double mean = s[c] / (double)n;
            double se = sqrt(fmax(0.0, s2[c] / (double)n - mean * mean) / (double)n);
            CHECK(t, fabs(mean - expect[c]) <= 5.0 * se + 1e-9 * expect[c],
                  "light %d channel %d: mean flux %.6g, power %.6g (se %.3g)", k, c, mean, expect[c], se);
        }
        if (l[k].type == PDS_LIGHT_POINT)
            CHECK(t, pds__length(mean_dir) / (double)n < 0.01, "point emission not isotropic: |mean dir| %g",
                  pds__length(mean_dir) / (double)n);
        if (pds__light_is_area(l[k].type))
            CHECK(t, fabs(sumcos / (double)n - 2.0 / 3.0) < 0.005, "light %d: mean cos %g, cosine-weighted gives 2/3",
                  k, sumcos / (double)n);
        if (l[k].type == PDS_LIGHT_MESH)
            CHECK(t, fabs(frac_small / (double)n - 0.25) < 0.006, "fraction on the small triangle %g, expected 0.25",
                  frac_small / (double)n);
    }
    pds__lights_free(&lt);
    pds__mesh_free(&m);
}

static void test_lights_spot_emission_follows_intensity_profile(pds_test_ctx *t)
{
    pds_light l = tlights_spot(pds__v(0, 3, 0), pds__v(0.3, -1.0, 0.2), 15.0, 35.0, 8.0);
    pds__light_table lt;
    double ci = cos(15.0 * PDS__PI / 180.0), co = cos(35.0 * PDS__PI / 180.0);
    double inner_expected = (1.0 - ci) / ((1.0 - ci) + 0.5 * (ci - co));
    double total = 0.0, inner = 0.0, frac;
    double band[2] = {0.0, 0.0};
    long i, n = 200000;
    REQUIRE(t, pds__lights_prepare(&lt, &l, 1, NULL, NULL) == PDS_OK, "prepare failed");
    for (i = 0; i < n; i++) {
        double u[4];
        pds__light_emit e;
        double ct;
        u[0] = tlights_u(71, i, 0);
        u[1] = tlights_u(71, i, 1);
        u[2] = u[3] = 0.5;
        if (!pds__light_emit_sample(&lt, &l, 0, NULL, u, &e)) continue;
        ct = pds__dot(e.dir, l.direction);
        total += e.flux[0];
        if (ct >= ci) inner += e.flux[0];
        /* flux in the lower and upper halves (in cos) of the falloff band:
           the integrals of the smoothstep over [0,1/2] and [1/2,1] are
           3/32 and 13/32 */
        if (ct < ci && ct >= co) band[ct < 0.5 * (ci + co) ? 0 : 1] += e.flux[0];
    }
    frac = inner / total;
    CHECK(t, fabs(frac - inner_expected) < 0.01, "flux fraction inside the inner cone %.4f, expected %.4f", frac,
          inner_expected);
    CHECK(t, fabs(band[0] / band[1] - 3.0 / 13.0) < 0.02, "falloff band flux ratio %.4f, expected %.4f",
          band[0] / band[1], 3.0 / 13.0);
    pds__lights_free(&lt);
}

static void test_lights_pick_frequencies_follow_power(pds_test_ctx *t)
{
    pds_light l[5];
    pds__light_table lt;
    long counts[5] = {0, 0, 0, 0, 0}, i, n = 200000;
    double w[5], total, pmf, sum = 0.0;
    int k, bad_pmf = 0;
    l[0] = tlights_point(pds__v(0, 0, 0), 0.0, 0.0, 0.0);                  /* no power, first */
    l[1] = tlights_point(pds__v(0, 0, 0), 1.0, 1.0, 1.0);                  /* 3 */
    l[2] = tlights_disk(pds__v(0, 1, 0), pds__v(0, -1, 0), 1.0, 6.0 / (3.5 * PDS__PI * PDS__PI)); /* 6 */
    l[3] = tlights_directional(pds__v(0, -1, 0), 0, pds__v(0, 5, 0), 1.0, pds__v(0, 0, 0), pds__v(0, 0, 0),
                               9.0 / (6.0 * PDS__PI));                     /* 9 */
    l[4] = tlights_spot(pds__v(0, 0, 0), pds__v(0, -1, 0), 10, 20, 0.0);   /* no power, last */
    for (k = 0; k < 5; k++) w[k] = pds__light_total_power(&l[k], l[k].area);
    CHECK_NEAR(t, w[2], 6.0, 1e-9);
    CHECK_NEAR(t, w[3], 9.0, 1e-9);
    total = w[0] + w[1] + w[2] + w[3] + w[4];
    REQUIRE(t, pds__lights_prepare(&lt, l, 5, NULL, NULL) == PDS_OK, "prepare failed");
    for (k = 0; k < 5; k++) {
        CHECK_NEAR(t, pds__lights_pmf(&lt, k), w[k] / total, 1e-12);
        sum += pds__lights_pmf(&lt, k);
    }
    CHECK_NEAR(t, sum, 1.0, 1e-15);
    CHECK(t, pds__lights_pmf(&lt, -1) == 0.0 && pds__lights_pmf(&lt, 5) == 0.0, "pmf out of range must be 0");
    for (i = 0; i < n; i++) {
        int j = pds__lights_pick(&lt, tlights_u(81, i, 0), &pmf);
        if (j < 0 || j >= 5) {
            bad_pmf++;
            continue;
        }
        counts[j]++;
        if (pmf != pds__lights_pmf(&lt, j)) bad_pmf++;
    }
    CHECK(t, bad_pmf == 0, "%d picks out of range or with a wrong pmf", bad_pmf);
    CHECK(t, counts[0] == 0 && counts[4] == 0, "zero-power lights picked %ld and %ld times", counts[0], counts[4]);
    for (k = 1; k < 4; k++) {
        double pk = w[k] / total, f = (double)counts[k] / (double)n;
        CHECK(t, fabs(f - pk) < 5.0 * sqrt(pk * (1.0 - pk) / (double)n), "light %d picked %.4f, expected %.4f", k, f, pk);
    }
    /* the ends of [0,1) and bad input never give a zero-power light */
    CHECK(t, pds__lights_pick(&lt, 0.0, NULL) == 1, "u = 0 must pick the first light with power");
    CHECK(t, pds__lights_pick(&lt, 0.9999999999999999, NULL) == 3, "u -> 1 must pick the last light with power");
    CHECK(t, pds__lights_pick(&lt, 1.0, NULL) == 3, "u = 1 must pick the last light with power");
    CHECK(t, pds__lights_pick(&lt, -0.5, NULL) == 1, "u < 0 clamps to 0");
    CHECK(t, pds__lights_pick(&lt, 3.0 / 18.0 - 1e-12, NULL) == 1 && pds__lights_pick(&lt, 3.0 / 18.0 + 1e-12, NULL) == 2,
          "the boundary between lights 1 and 2 is at 3/18");
    pds__lights_free(&lt);

    /* no light with power: -1 and pmf 0 */
    REQUIRE(t, pds__lights_prepare(&lt, l, 1, NULL, NULL) == PDS_OK, "prepare failed");
    pmf = 7.0;
    CHECK(t, pds__lights_pick(&lt, 0.5, &pmf) == -1 && pmf == 0.0, "powerless scene picked a light");
    pds__lights_free(&lt);
    REQUIRE(t, pds__lights_prepare(&lt, NULL, 0, NULL, NULL) == PDS_OK, "prepare of no lights failed");
    CHECK(t, pds__lights_pick(&lt, 0.5, NULL) == -1, "empty table picked a light");
    CHECK(t, pds__light_of_triangle(&lt, 0) == -1, "empty table maps a triangle");
    pds__lights_free(&lt);
}

static void test_lights_triangle_map_marks_mesh_light_triangles(pds_test_ctx *t)
{
    pds__mesh m;
    pds_light l[3];
    pds__light_table lt;
    long v[4], tri;
    int expect[5] = {-1, 1, 1, -1, 2};
    memset(&m, 0, sizeof m);
    v[0] = tlights_vert(&m, 0, 0, 0);
    v[1] = tlights_vert(&m, 1, 0, 0);
    v[2] = tlights_vert(&m, 0, 0, 1);
    v[3] = tlights_vert(&m, 1, 0, 1);
    for (tri = 0; tri < 5; tri++)
        REQUIRE(t, pds__mesh_add_tri(&m, v[0], v[tri % 2 ? 2 : 1], v[3], expect[tri] < 0 ? 0 : 1) == 1,
                "mesh build failed");
    l[0] = tlights_point(pds__v(0, 1, 0), 1, 1, 1);
    l[1] = tlights_mesh(1, 2, 1.0, 1.0);
    l[2] = tlights_mesh(4, 1, 0.5, 1.0);
    REQUIRE(t, pds__lights_prepare(&lt, l, 3, &m, NULL) == PDS_OK, "prepare failed");
    for (tri = 0; tri < 5; tri++)
        CHECK(t, pds__light_of_triangle(&lt, tri) == expect[tri], "triangle %ld -> %d, expected %d", tri,
              pds__light_of_triangle(&lt, tri), expect[tri]);
    CHECK(t, pds__light_of_triangle(&lt, 5) == -1 && pds__light_of_triangle(&lt, -1) == -1, "out of range -> -1");
    CHECK_NEAR(t, lt.area[1], 1.0, 1e-7);
    CHECK_NEAR(t, lt.area[2], 0.5, 1e-7);
    pds__lights_free(&lt);
    pds__mesh_free(&m);
}

static void test_lights_prepare_rejects_bad_mesh_ranges_and_powers(pds_test_ctx *t)
{
    pds__mesh m;
    pds_light l[2];
    pds__light_table lt;
    pds_error err;
    memset(&m, 0, sizeof m);
    memset(&err, 0, sizeof err);
    REQUIRE(t, tlights_square_mesh(&m, 1.0, 0.5), "mesh build failed");
    l[0] = tlights_mesh(2, 2, 1.0, 1.0); /* triangles 2..3 of a 3-triangle mesh */
    CHECK(t, pds__lights_prepare(&lt, l, 1, &m, &err) == PDS_ERR_INVALID_ARG && strstr(err.text, "3 triangles"),
          "out-of-range mesh light accepted (%s)", err.text);
    CHECK(t, pds__lights_pick(&lt, 0.5, NULL) == -1, "a failed prepare leaves an empty table");
    CHECK(t, pds__lights_prepare(&lt, l, 1, NULL, &err) == PDS_ERR_INVALID_ARG, "mesh light without a mesh accepted");
    l[0] = tlights_mesh(1, 2, 1.0, 1.0);
    l[1] = tlights_mesh(2, 1, 0.5, 1.0);
    CHECK(t, pds__lights_prepare(&lt, l, 2, &m, &err) == PDS_ERR_INVALID_ARG && strstr(err.text, "triangle 2"),
          "overlapping mesh lights accepted (%s)", err.text);
    l[1] = tlights_point(pds__v(0, 0, 0), 1.0, 1.0, 1.0);
    l[1].power[1] = nan("");
    CHECK(t, pds__lights_prepare(&lt, l, 2, &m, &err) == PDS_ERR_INVALID_ARG, "NaN power accepted");
    l[1].power[1] = HUGE_VAL;
    CHECK(t, pds__lights_prepare(&lt, l, 2, &m, &err) == PDS_ERR_INVALID_ARG, "infinite power accepted");
    pds__mesh_free(&m);
}

static void test_lights_intersect_hits_inside_and_misses_outside(pds_test_ctx *t)
{
    pds__v3 c = pds__v(1.0, 2.0, 3.0), n = pds__normalize(pds__v(0.3, -1.0, 0.2)), b1, b2, nx;
    pds_light disk = tlights_disk(c, n, 0.8, 1.0);
    pds__v3 e1 = pds__v(1.0, 0.3, 0.0), e2 = pds__v(0.0, 0.2, 1.0);
    pds_light quad = tlights_quad(c, e1, e2, 1.0);
    pds_light point = tlights_point(c, 1, 1, 1);
    pds__v3 org = pds__v(0.5, -1.0, 2.0), target, dir;
    double th;
    pds__onb(n, &b1, &b2);
    /* disk centre, from the front (below) */
    dir = pds__sub(c, org);
    CHECK(t, pds__light_intersect(&disk, org, dir, 1e-9, 1e30, &th, &nx) == 1, "disk centre missed");
    CHECK_NEAR(t, th, 1.0, 1e-12);
    CHECK(t, pds__length(pds__sub(nx, n)) < 1e-12, "disk normal not the emitter's");
    /* tmin / tmax */
    CHECK(t, pds__light_intersect(&disk, org, dir, 1e-9, 0.999, &th, &nx) == 0, "tmax not respected");
    CHECK(t, pds__light_intersect(&disk, org, dir, 1.001, 1e30, &th, &nx) == 0, "tmin not respected");
    /* from behind: still a hit, normal not flipped */
    CHECK(t, pds__light_intersect(&disk, pds__add(c, pds__scale(n, -2.0)), n, 0.0, 1e30, &th, &nx) == 1
             && fabs(th - 2.0) < 1e-12 && pds__dot(nx, n) > 0.999, "disk missed from behind");
    /* just inside / just outside the rim */
    target = pds__add(c, pds__scale(b1, 0.8 * 0.999));
    CHECK(t, pds__light_intersect(&disk, org, pds__sub(target, org), 1e-9, 1e30, &th, &nx) == 1, "inside rim missed");
    target = pds__add(c, pds__scale(pds__normalize(pds__add(b1, b2)), 0.8 * 1.001));
    CHECK(t, pds__light_intersect(&disk, org, pds__sub(target, org), 1e-9, 1e30, &th, &nx) == 0, "outside rim hit");
    /* parallel ray */
    CHECK(t, pds__light_intersect(&disk, pds__sub(c, b1), b1, 0.0, 1e30, &th, &nx) == 0, "parallel ray hit");

    /* quad */
    dir = pds__sub(c, org);
    CHECK(t, pds__light_intersect(&quad, org, pds__scale(dir, 2.0), 1e-9, 1e30, &th, &nx) == 1 && fabs(th - 0.5) < 1e-12,
          "quad centre missed (t in units of |dir|)");
    CHECK(t, pds__length(pds__sub(nx, quad.direction)) < 1e-12, "quad normal not the emitter's");
    target = pds__add(c, pds__add(pds__scale(e1, 0.499), pds__scale(e2, -0.499)));
    CHECK(t, pds__light_intersect(&quad, org, pds__sub(target, org), 1e-9, 1e30, &th, &nx) == 1, "quad corner missed");
    target = pds__add(c, pds__scale(e1, 0.501));
    CHECK(t, pds__light_intersect(&quad, org, pds__sub(target, org), 1e-9, 1e30, &th, &nx) == 0, "beyond edge1 hit");
    target = pds__add(c, pds__scale(e2, -0.501));
    CHECK(t, pds__light_intersect(&quad, org, pds__sub(target, org), 1e-9, 1e30, &th, &nx) == 0, "beyond edge2 hit");
    CHECK(t, pds__light_intersect(&quad, org, pds__sub(c, org), 1e-9, 0.5, &th, &nx) == 0, "quad tmax not respected");
    CHECK(t, pds__light_intersect(&point, org, pds__sub(c, org), 1e-9, 1e30, &th, &nx) == 0, "point light hit");
}

static void test_lights_le_is_one_sided(pds_test_ctx *t)
{
    pds_light disk = tlights_disk(pds__v(0, 1, 0), pds__v(0, -1, 0), 1.0, 2.0);
    pds_light point = tlights_point(pds__v(0, 1, 0), 1, 1, 1);
    double le[3];
    pds__light_le(&disk, disk.direction, pds__v(0.3, -0.9, 0.0), le);
    CHECK(t, le[0] == 2.0 && le[1] == 1.0 && le[2] == 4.0, "front side: %g %g %g", le[0], le[1], le[2]);
    pds__light_le(&disk, disk.direction, pds__v(0.3, 0.9, 0.0), le);
    CHECK(t, le[0] == 0.0 && le[1] == 0.0 && le[2] == 0.0, "back side emits");
    pds__light_le(&point, pds__v(0, -1, 0), pds__v(0, -1, 0), le);
    CHECK(t, le[0] == 0.0, "a delta light has no surface radiance");
}

static void test_lights_directional_li_inside_beam_only(pds_test_ctx *t)
{
    pds_light l[2];
    pds__light_table lt;
    pds__light_li r;
    pds__v3 d, e1 = pds__v(2, 0, 0), e2 = pds__v(0, 0.5, 1.5), p;
    l[0] = tlights_directional(pds__v(0, -1, 0), 0, pds__v(0, 5, 0), 1.0, pds__v(0, 0, 0), pds__v(0, 0, 0), 4.0);
    l[1] = tlights_directional(pds__v(1, -2, 0.5), 1, pds__v(0, 4, 0), 0.0, e1, e2, 4.0);
    REQUIRE(t, pds__lights_prepare(&lt, l, 2, NULL, NULL) == PDS_OK, "prepare failed");
    CHECK(t, pds__light_sample_li(&lt, &l[0], 0, NULL, pds__v(0.5, 0.0, 0.2), 0.1, 0.2, &r) == 1, "inside disk beam");
    CHECK(t, r.li[0] == 4.0 && r.li[1] == 8.0 && r.li[2] == 12.0 && r.delta == 1 && r.pdf == 1.0, "li %g", r.li[0]);
    CHECK_NEAR(t, r.dist, 5.0, 1e-12);
    CHECK(t, pds__length(pds__sub(r.wi, pds__v(0, 1, 0))) < 1e-12, "wi must be -d");
    CHECK(t, pds__light_sample_li(&lt, &l[0], 0, NULL, pds__v(1.01, 0.0, 0.0), 0.1, 0.2, &r) == 0
             && r.li[0] == 0.0, "outside the disk beam");
    CHECK(t, pds__light_sample_li(&lt, &l[0], 0, NULL, pds__v(0.0, 6.0, 0.0), 0.1, 0.2, &r) == 0,
          "a point upstream of the emitter receives nothing");
    /* slanted rectangle: p = emitter point + t0 d */
    d = l[1].direction;
    p = pds__add(pds__add(l[1].position, pds__add(pds__scale(e1, 0.45), pds__scale(e2, -0.3))), pds__scale(d, 3.7));
    CHECK(t, pds__light_sample_li(&lt, &l[1], 1, NULL, p, 0.1, 0.2, &r) == 1 && r.li[0] == 4.0, "inside rect beam");
    CHECK_NEAR(t, r.dist, 3.7, 1e-9);
    p = pds__add(pds__add(l[1].position, pds__add(pds__scale(e1, 0.55), pds__scale(e2, -0.3))), pds__scale(d, 3.7));
    CHECK(t, pds__light_sample_li(&lt, &l[1], 1, NULL, p, 0.1, 0.2, &r) == 0 && r.li[0] == 0.0, "outside rect beam");
    p = pds__add(pds__add(l[1].position, pds__add(pds__scale(e1, 0.2), pds__scale(e2, 0.52))), pds__scale(d, 3.7));
    CHECK(t, pds__light_sample_li(&lt, &l[1], 1, NULL, p, 0.1, 0.2, &r) == 0, "outside rect beam along edge2");
    CHECK(t, pds__light_pdf_li(&lt, &l[1], 1, NULL, p, p, d) == 0.0, "directional pdf_li must be 0");
    pds__lights_free(&lt);
}

static void test_lights_emission_extent_per_type(pds_test_ctx *t)
{
    pds_light l;
    double a, w;
    l = tlights_point(pds__v(0, 0, 0), 1, 1, 1);
    pds__light_emission_extent(&l, &a, &w);
    CHECK(t, a == 0.0 && fabs(w - 4.0 * PDS__PI) < 1e-12, "point: %g %g", a, w);
    l = tlights_spot(pds__v(0, 0, 0), pds__v(0, -1, 0), 20, 60, 1);
    pds__light_emission_extent(&l, &a, &w);
    CHECK(t, a == 0.0 && fabs(w - PDS__PI) < 1e-12, "spot (60 deg): %g %g, expected 0, pi", a, w);
    l = tlights_directional(pds__v(0, -1, 0), 1, pds__v(0, 0, 0), 0, pds__v(2, 0, 0), pds__v(0, 1, 3), 1);
    pds__light_emission_extent(&l, &a, &w);
    CHECK(t, fabs(a - 6.0) < 1e-12 && w == 0.0, "directional rect: %g %g, expected 6 (|(e1 x e2).d|), 0", a, w);
    l = tlights_directional(pds__v(0, -1, 0), 0, pds__v(0, 0, 0), 2.0, pds__v(0, 0, 0), pds__v(0, 0, 0), 1);
    pds__light_emission_extent(&l, &a, &w);
    CHECK(t, fabs(a - 4.0 * PDS__PI) < 1e-12 && w == 0.0, "directional disk: %g %g", a, w);
    l = tlights_disk(pds__v(0, 0, 0), pds__v(0, -1, 0), 0.5, 1);
    pds__light_emission_extent(&l, &a, &w);
    CHECK(t, fabs(a - 0.25 * PDS__PI) < 1e-12 && fabs(w - 2.0 * PDS__PI) < 1e-12, "disk: %g %g", a, w);
    l = tlights_quad(pds__v(0, 0, 0), pds__v(2, 0, 0), pds__v(0, 0, 1.5), 1);
    pds__light_emission_extent(&l, &a, &w);
    CHECK(t, fabs(a - 3.0) < 1e-12 && fabs(w - 2.0 * PDS__PI) < 1e-12, "quad: %g %g", a, w);
    l = tlights_mesh(0, 4, 2.5, 1);
    pds__light_emission_extent(&l, &a, &w);
    CHECK(t, a == 2.5 && fabs(w - 2.0 * PDS__PI) < 1e-12, "mesh: %g %g", a, w);
}

static const pds_test_case tests_lights[] = {
    {"lights_point_li_is_power_over_4pi_r2", test_lights_point_li_is_power_over_4pi_r2},
    {"lights_spot_li_follows_smoothstep_cone", test_lights_spot_li_follows_smoothstep_cone},
    {"lights_disk_irradiance_matches_analytic", test_lights_disk_irradiance_matches_analytic},
    {"lights_quad_irradiance_matches_lambert_formula", test_lights_quad_irradiance_matches_lambert_formula},
    {"lights_mesh_irradiance_matches_lambert_formula", test_lights_mesh_irradiance_matches_lambert_formula},
    {"lights_pdf_li_matches_sampled_pdf", test_lights_pdf_li_matches_sampled_pdf},
    {"lights_pdf_li_integrates_to_one_over_directions", test_lights_pdf_li_integrates_to_one_over_directions},
    {"lights_emission_flux_mean_equals_power", test_lights_emission_flux_mean_equals_power},
    {"lights_spot_emission_follows_intensity_profile", test_lights_spot_emission_follows_intensity_profile},
    {"lights_pick_frequencies_follow_power", test_lights_pick_frequencies_follow_power},
    {"lights_triangle_map_marks_mesh_light_triangles", test_lights_triangle_map_marks_mesh_light_triangles},
    {"lights_prepare_rejects_bad_mesh_ranges_and_powers", test_lights_prepare_rejects_bad_mesh_ranges_and_powers},
    {"lights_intersect_hits_inside_and_misses_outside", test_lights_intersect_hits_inside_and_misses_outside},
    {"lights_le_is_one_sided", test_lights_le_is_one_sided},
    {"lights_directional_li_inside_beam_only", test_lights_directional_li_inside_beam_only},
    {"lights_emission_extent_per_type", test_lights_emission_extent_per_type},
};

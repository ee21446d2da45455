/* tests/test_differentials.c - photon differentials (>>differentials).

   The central tests check the propagated differentials against finite
   differences of real neighbouring rays traced through scene geometry:
   a photon (p, d) with differential (DP, DD) and its neighbours
   (p +- eps DP, normalize(d +- eps DD)) follow the same specular sequence
   (same reflect/refract choice), and (P'(+eps) - P'(-eps)) / (2 eps) must
   match the transferred DP' at every hit, (D'(+eps) - D'(-eps)) / (2 eps)
   the directional differential after every event. A smooth-shaded mesh is
   only C0 across triangle edges, so a sample counts only when all three
   rays meet the same triangles; offsets are kept ~1e-4 of the scene size,
   far below the triangle sizes, so almost every sample qualifies.

   Needs scene_from_text from test_scene.c (included before this file). */

/* Define to print the worst errors each finite-difference test found. */
/* #define DT_VERBOSE 1 */

#define DT_MAXHITS 6

/* One traced specular path: per hit, the triangle, and the photon state
   after the transfer and the event at that hit. */
typedef struct dt_path {
    int nhits;
    long tri[DT_MAXHITS];
    pds__ray_diff at[DT_MAXHITS];
} dt_path;

static double dt_rand(unsigned long i, int dim)
{
    return pds__rng_uniform(20140601u, PDS__RNG_TEST, (uint64_t)i, (uint64_t)dim);
}

static double dt_rel(pds__v3 got, pds__v3 want)
{
    double w = pds__length(want);
    return pds__length(pds__sub(got, want)) / (w > 1e-300 ? w : 1e-300);
}

/* Trace r through the scene: events[k] says what happens at hit k:
   'R' mirror reflection, 'T' refraction by the hit dielectric, '.' none
   (the path ends there). The shading normal is turned against the
   incident direction by the geometric normal's side, as the materials
   code decides sides, and its differentials with it. Returns 1 if every
   hit and event happened. Rays with zero differentials trace the plain
   neighbours: the directions come out of pds__reflect / pds__refract
   either way. */
static int dt_trace(const pds_scene *s, pds__ray_diff r, const char *events, dt_path *out)
{
    int k;
    out->nhits = 0;
    for (k = 0; events[k] && k < DT_MAXHITS; k++) {
        pds__tri_hit th;
        pds_hit hit;
        pds__v3 n, dnu, dnv;
        pds_material_type mt;
        int front;
        if (!pds__bvh_intersect(&s->bvh, r.p, r.d, 1e-4, 1e30, &th)) return 0;
        pds__scene_fill_hit(s, &th, r.p, r.d, &hit);
        if (!pds__diff_transfer(&r, hit.t, hit.ng)) return 0;
        pds__mesh_normal_diff(&s->mesh, th.tri, th.u, th.v, r.dpdu, 0.0, &dnu, NULL);
        pds__mesh_normal_diff(&s->mesh, th.tri, th.u, th.v, r.dpdv, 0.0, &dnv, NULL);
        front = pds__dot(r.d, hit.ng) < 0.0;
        n = hit.ns;
        if (!front) {
            n = pds__scale(n, -1.0);
            dnu = pds__scale(dnu, -1.0);
            dnv = pds__scale(dnv, -1.0);
        }
        if (!(pds__dot(r.d, n) < 0.0)) return 0;
        mt = s->materials.items[hit.material].type;
        if (events[k] == 'R') {
            if (mt != PDS_MAT_MIRROR && mt != PDS_MAT_CONDUCTOR) return 0;
            pds__diff_reflect(&r, n, dnu, dnv);
        } else if (events[k] == 'T') {
            const pds_material *m = &s->materials.items[hit.material];
            double eta;
            if (mt != PDS_MAT_DIELECTRIC) return 0;
            eta = front ? m->outside_ior / m->ior : m->ior / m->outside_ior;
            if (!pds__diff_refract(&r, n, dnu, dnv, eta)) return 0;
        }
        out->tri[k] = hit.triangle;
        out->at[k] = r;
        out->nhits = k + 1;
    }
    return 1;
}

/* Worst relative errors of a finite-difference comparison. */
typedef struct dt_fd_stats {
    int tried, used; /* photons that followed the path; of them, compared */
    double pos_err, dir_err;
} dt_fd_stats;

/* Compare photon r's propagated differentials along events with central
   differences of neighbouring traced rays, for both axes. h is the size
   of the offset (scene units) the neighbours get. Updates *st. */
static void dt_fd_compare(const pds_scene *s, const pds__ray_diff *r, const char *events, double h,
                          dt_fd_stats *st)
{
    dt_path ref, plus, minus;
    int axis, k, n = (int)strlen(events);
    if (!dt_trace(s, *r, events, &ref) || ref.nhits != n) return; /* missed: not a sample */
    st->tried++;
    for (axis = 0; axis < 2; axis++) {
        pds__v3 dp = axis ? r->dpdv : r->dpdu, dd = axis ? r->dddv : r->dddu;
        double eps = h / (pds__length(dp) + 4.0 * pds__length(dd));
        pds__ray_diff a, b;
        memset(&a, 0, sizeof a);
        memset(&b, 0, sizeof b);
        a.p = pds__add(r->p, pds__scale(dp, eps));
        a.d = pds__normalize(pds__add(r->d, pds__scale(dd, eps)));
        b.p = pds__sub(r->p, pds__scale(dp, eps));
        b.d = pds__normalize(pds__sub(r->d, pds__scale(dd, eps)));
        if (!dt_trace(s, a, events, &plus) || !dt_trace(s, b, events, &minus)) return;
        for (k = 0; k < n; k++)
            if (plus.tri[k] != ref.tri[k] || minus.tri[k] != ref.tri[k]) return;
    }
    /* all six rays stayed in the same triangles: compare */
    for (axis = 0; axis < 2; axis++) {
        pds__v3 dp = axis ? r->dpdv : r->dpdu, dd = axis ? r->dddv : r->dddu;
        double eps = h / (pds__length(dp) + 4.0 * pds__length(dd));
        pds__ray_diff a, b;
        memset(&a, 0, sizeof a);
        memset(&b, 0, sizeof b);
        a.p = pds__add(r->p, pds__scale(dp, eps));
        a.d = pds__normalize(pds__add(r->d, pds__scale(dd, eps)));
        b.p = pds__sub(r->p, pds__scale(dp, eps));
        b.d = pds__normalize(pds__sub(r->d, pds__scale(dd, eps)));
        dt_trace(s, a, events, &plus);
        dt_trace(s, b, events, &minus);
        for (k = 0; k < n; k++) {
            pds__v3 fdp = pds__scale(pds__sub(plus.at[k].p, minus.at[k].p), 0.5 / eps);
            pds__v3 fdd = pds__scale(pds__sub(plus.at[k].d, minus.at[k].d), 0.5 / eps);
            pds__v3 ap = axis ? ref.at[k].dpdv : ref.at[k].dpdu;
            pds__v3 ad = axis ? ref.at[k].dddv : ref.at[k].dddu;
            double e = dt_rel(fdp, ap);
            if (e > st->pos_err) st->pos_err = e;
            if (pds__length(ad) > 0.0 || pds__length(fdd) > 0.0) {
                e = dt_rel(fdd, ad);
                if (e > st->dir_err) st->dir_err = e;
            }
        }
    }
    st->used++;
}

static void dt_fd_report(const char *what, const dt_fd_stats *st)
{
#ifdef DT_VERBOSE
    printf("  %-34s used %3d/%3d  pos %.2e  dir %.2e\n", what, st->used, st->tried, st->pos_err, st->dir_err);
#else
    (void)what;
    (void)st;
#endif
}

/* Tolerance of the finite-difference tests (relative). The brief asks 1%;
   central differences with ~2e-5 offsets reach ~2e-8 here. */
#define DT_FD_TOL 1e-5

/* A generic photon: unit direction d, arbitrary positional
   differentials (not perpendicular to d, to exercise the Dt term) and
   directional ones perpendicular to d, of size ~pos / ~dir. */
static pds__ray_diff dt_photon(pds__v3 p, pds__v3 d, unsigned long i, double pos, double dir)
{
    pds__ray_diff r;
    pds__v3 b1, b2;
    double a = 2.0 * PDS__PI * dt_rand(i, 10);
    r.p = p;
    r.d = pds__normalize(d);
    pds__onb(r.d, &b1, &b2);
    r.dpdu = pds__scale(pds__v(dt_rand(i, 11) - 0.5, dt_rand(i, 12) - 0.5, dt_rand(i, 13) - 0.5), 2.0 * pos);
    r.dpdv = pds__scale(pds__v(dt_rand(i, 14) - 0.5, dt_rand(i, 15) - 0.5, dt_rand(i, 16) - 0.5), 2.0 * pos);
    r.dddu = pds__scale(pds__add(pds__scale(b1, cos(a)), pds__scale(b2, sin(a))), dir);
    r.dddv = pds__scale(pds__add(pds__scale(b1, -0.3 * sin(a)), pds__scale(b2, 0.8 * cos(a))), dir);
    return r;
}

static void dt_fd_check(pds_test_ctx *t, const char *what, const dt_fd_stats *st, int need_dir)
{
    dt_fd_report(what, st);
    CHECK(t, st->used >= 15 && st->used >= (3 * st->tried) / 4,
          "%s: only %d of %d samples stayed in the same triangles", what, st->used, st->tried);
    CHECK(t, st->pos_err <= DT_FD_TOL, "%s: positional differential off by %.3g (relative)", what, st->pos_err);
    CHECK(t, st->dir_err <= DT_FD_TOL, "%s: directional differential off by %.3g (relative)", what, st->dir_err);
    if (need_dir) CHECK(t, st->dir_err > 0.0, "%s: no directional differential was compared", what);
}

/* ------------------------------------------------------------------ tests */

static void test_diff_transfer_onto_sphere_and_plane_matches_traced_neighbours(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text("sphere { radius 1 segments 512 rings 256 rotate 90 1 0 0 }\n"
                                   "quad { size 10 10 translate 0 -2 0 }\n",
                                   &err);
    dt_fd_stats sph, pl;
    unsigned long i;
    int on_sphere = 0, on_plane = 0;
    REQUIRE(t, s != NULL, "%s", err.text);
    memset(&sph, 0, sizeof sph);
    memset(&pl, 0, sizeof pl);
    for (i = 0; i < 60; i++) {
        /* half aimed at the sphere, half past it onto the plane */
        int at_plane = i & 1;
        double x = at_plane ? 1.5 + 2.0 * dt_rand(i, 0) : 1.4 * (dt_rand(i, 0) - 0.5);
        double z = 1.4 * (dt_rand(i, 1) - 0.5);
        pds__ray_diff r = dt_photon(pds__v(x, 3.0, z), pds__v(0.1, -1.0, 0.05), i, 1.0, 0.0);
        dt_path path;
        r.dddu = r.dddv = pds__v(0.0, 0.0, 0.0); /* positional only */
        if (dt_trace(s, r, ".", &path) && path.nhits == 1) {
            pds__v3 ng = pds__normalize(pds__cross(
                pds__sub(pds__mesh_pos(&s->mesh, s->mesh.idx[3 * path.tri[0] + 1]),
                         pds__mesh_pos(&s->mesh, s->mesh.idx[3 * path.tri[0]])),
                pds__sub(pds__mesh_pos(&s->mesh, s->mesh.idx[3 * path.tri[0] + 2]),
                         pds__mesh_pos(&s->mesh, s->mesh.idx[3 * path.tri[0]]))));
            /* the transferred differentials lie in the hit plane */
            CHECK(t, fabs(pds__dot(path.at[0].dpdu, ng)) <= 1e-12 * pds__length(path.at[0].dpdu),
                  "DP'.N = %g", pds__dot(path.at[0].dpdu, ng));
            if (path.at[0].p.y < -1.5) on_plane++;
            else on_sphere++;
        }
        dt_fd_compare(s, &r, ".", 1e-4, at_plane ? &pl : &sph);
    }
    CHECK(t, on_sphere >= 20 && on_plane >= 20, "hits: sphere %d, plane %d", on_sphere, on_plane);
    dt_fd_check(t, "transfer onto sphere", &sph, 0);
    dt_fd_check(t, "transfer onto plane", &pl, 0);
    pds_scene_free(s);
}

/* A finite-difference case: photons from points spread over a square
   (centre c, side `spread` in x and z) all along direction d, through the
   specular events `path`, compared with their traced neighbours. */
typedef struct dt_fd_case {
    const char *what, *scene, *path;
    double spread;
    double c[3], d[3];
} dt_fd_case;

static void dt_fd_run(pds_test_ctx *t, const dt_fd_case *c)
{
    pds_error err;
    pds_scene *s = scene_from_text(c->scene, &err);
    dt_fd_stats st;
    unsigned long i;
    REQUIRE(t, s != NULL, "%s", err.text);
    memset(&st, 0, sizeof st);
    for (i = 0; i < 40; i++) {
        double x = c->spread * (dt_rand(i, 0) - 0.5), z = c->spread * (dt_rand(i, 1) - 0.5);
        pds__ray_diff r = dt_photon(pds__v(c->c[0] + x, c->c[1], c->c[2] + z), pds__v(c->d[0], c->d[1], c->d[2]), i,
                                    1.0, 0.3);
        dt_fd_compare(s, &r, c->path, 2e-5, &st);
    }
    dt_fd_check(t, c->what, &st, 1);
    pds_scene_free(s);
}

static void test_diff_reflection_off_mirror_sphere_matches_traced_neighbours(pds_test_ctx *t)
{
    static const dt_fd_case c = {"reflection off mirror sphere",
                                 "material m mirror { reflectance 1 }\n"
                                 "sphere { material m radius 1 segments 512 rings 256 rotate 90 1 0 0 }\n"
                                 "sphere { radius 8 segments 256 rings 128 rotate 90 1 0 0 }\n",
                                 "R.", 1.6, {-0.5, 3.0, 0.25}, {0.2, -1.0, -0.1}};
    dt_fd_run(t, &c);
}

static void test_diff_reflection_off_sine_heightfield_matches_traced_neighbours(pds_test_ctx *t)
{
    static const dt_fd_case c = {"reflection off heightfield",
                                 "material m mirror { reflectance 1 }\n"
                                 "heightfield { material m size 4 4 resolution 512 512\n"
                                 "  wave 0.06 0.9 1 0  wave 0.03 0.55 0.6 0.8 40 }\n"
                                 "sphere { radius 8 segments 256 rings 128 rotate 90 1 0 0 }\n",
                                 "R.", 2.0, {0.0, 2.0, 0.0}, {0.3, -1.0, 0.2}};
    dt_fd_run(t, &c);
}

static void test_diff_refraction_through_glass_sphere_matches_traced_neighbours(pds_test_ctx *t)
{
    static const dt_fd_case c = {"refraction in and out of glass sphere",
                                 "material g dielectric { ior 1.5 }\n"
                                 "sphere { material g radius 1 segments 512 rings 256 rotate 90 1 0 0 }\n"
                                 "quad { size 40 40 translate 0 -3 0 }\n",
                                 "TT.", 1.4, {0.0, 3.0, 0.0}, {0.05, -1.0, 0.1}};
    dt_fd_run(t, &c);
}

static void test_diff_refraction_into_water_heightfield_matches_traced_neighbours(pds_test_ctx *t)
{
    static const dt_fd_case c = {"refraction into water heightfield",
                                 "material w dielectric { ior 1.33 }\n"
                                 "heightfield { material w size 4 4 resolution 512 512\n"
                                 "  wave 0.05 0.8 1 0.3  wave 0.02 0.35 -0.2 1 70 }\n"
                                 "quad { size 20 20 translate 0 -1.5 0 }\n",
                                 "T.", 2.0, {0.0, 2.0, 0.0}, {-0.2, -1.0, 0.3}};
    dt_fd_run(t, &c);
}

static void test_diff_reflection_inside_ring_matches_traced_neighbours(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text("material gold mirror { reflectance 1 }\n"
                                   "cylinder { material gold radius 1 inner_radius 0.9 height 0.5 segments 256 }\n"
                                   "quad { size 6 6 }\n",
                                   &err);
    dt_fd_stats st;
    unsigned long i;
    REQUIRE(t, s != NULL, "%s", err.text);
    memset(&st, 0, sizeof st);
    for (i = 0; i < 40; i++) {
        /* from inside the ring toward its inner wall, slightly down, so
           the reflection lands on the floor (the cardioid caustic's path) */
        double a = 2.0 * PDS__PI * dt_rand(i, 0);
        pds__v3 d = pds__v(cos(a), -0.15 - 0.1 * dt_rand(i, 1), sin(a));
        pds__ray_diff r = dt_photon(pds__v(0.1, 0.45, -0.05), d, i, 0.5, 0.3);
        dt_fd_compare(s, &r, "R.", 2e-5, &st);
    }
    dt_fd_check(t, "reflection inside ring", &st, 1);
    pds_scene_free(s);
}

/* Eqs 2-3 and 5-6 for an emitted photon: unit directions, orthogonal
   pairs, u = theta, v = u x n, phi = theta x omega, lengths as given. */
static void dt_check_emission(pds_test_ctx *t, const pds__ray_diff *r, pds__v3 n, double pos_len, double dir_len)
{
    pds__v3 u = pds__normalize(r->dpdu), v = pds__normalize(r->dpdv);
    pds__v3 th = pds__normalize(r->dddu), ph = pds__normalize(r->dddv);
    CHECK_NEAR(t, pds__length(r->dpdu), pos_len, 1e-12 * (1.0 + pos_len));
    CHECK_NEAR(t, pds__length(r->dpdv), pos_len, 1e-12 * (1.0 + pos_len));
    CHECK_NEAR(t, pds__length(r->dddu), dir_len, 1e-12 * (1.0 + dir_len));
    CHECK_NEAR(t, pds__length(r->dddv), dir_len, 1e-12 * (1.0 + dir_len));
    CHECK_NEAR(t, pds__length(r->d), 1.0, 1e-12);
    if (dir_len > 0.0) {
        CHECK_NEAR(t, pds__dot(th, ph), 0.0, 1e-12);
        CHECK_NEAR(t, pds__dot(th, r->d), 0.0, 1e-12);
        CHECK_NEAR(t, pds__dot(ph, r->d), 0.0, 1e-12);
        CHECK(t, dt_rel(ph, pds__cross(th, r->d)) < 1e-12, "phi != theta x omega");
    }
    if (pos_len > 0.0) {
        CHECK_NEAR(t, pds__dot(u, v), 0.0, 1e-12);
        if (pds__length(n) > 0.0) {
            pds__v3 nn = pds__normalize(n);
            if (pds__dot(nn, r->d) < 0.0) nn = pds__scale(nn, -1.0);
            CHECK_NEAR(t, pds__dot(u, nn), 0.0, 1e-12);
            CHECK_NEAR(t, pds__dot(v, nn), 0.0, 1e-12);
            CHECK(t, dt_rel(v, pds__cross(u, nn)) < 1e-12, "v != u x n");
            if (pds__length(pds__cross(nn, r->d)) > 1e-6)
                CHECK(t, dt_rel(u, pds__normalize(pds__cross(nn, r->d))) < 1e-12, "u != n x omega / |..|");
        }
    }
    if (pos_len > 0.0 && dir_len > 0.0) CHECK(t, dt_rel(th, u) < 1e-6, "theta direction != u direction");
}

/* Appendix A: transfer the positional and the directional parts of each
   pair separately to the plane (t, ng) and check D_theta x' || Du x',
   D_phi x' || Dv x' (same sense), D_theta x' = t |D_theta w|/|Du x| Du x',
   and that the parts add to the combined transfer (eq 7). */
static void dt_check_appendix_a(pds_test_ctx *t, const pds__ray_diff *r, double tt, pds__v3 ng)
{
    pds__ray_diff pos = *r, dir = *r, both = *r;
    pds__v3 zero = pds__v(0.0, 0.0, 0.0), want;
    pos.dddu = pos.dddv = zero;
    dir.dpdu = dir.dpdv = zero;
    REQUIRE(t, pds__diff_transfer(&pos, tt, ng) && pds__diff_transfer(&dir, tt, ng) &&
                   pds__diff_transfer(&both, tt, ng),
            "transfer failed");
    CHECK(t, pds__length(pds__cross(dir.dpdu, pos.dpdu)) <=
                 1e-9 * pds__length(dir.dpdu) * pds__length(pos.dpdu),
          "D_theta x' not parallel to Du x'");
    CHECK(t, pds__dot(dir.dpdu, pos.dpdu) > 0.0, "D_theta x' against Du x'");
    CHECK(t, pds__length(pds__cross(dir.dpdv, pos.dpdv)) <=
                 1e-9 * pds__length(dir.dpdv) * pds__length(pos.dpdv),
          "D_phi x' not parallel to Dv x'");
    CHECK(t, pds__dot(dir.dpdv, pos.dpdv) > 0.0, "D_phi x' against Dv x'");
    want = pds__scale(pos.dpdu, tt * pds__length(r->dddu) / pds__length(r->dpdu));
    CHECK(t, dt_rel(dir.dpdu, want) < 1e-9, "D_theta x' != t' |D_theta w|/|Du x| Du x' (%g)",
          dt_rel(dir.dpdu, want));
    CHECK(t, dt_rel(both.dpdu, pds__add(pos.dpdu, dir.dpdu)) < 1e-12, "pair u does not add");
    CHECK(t, dt_rel(both.dpdv, pds__add(pos.dpdv, dir.dpdv)) < 1e-12, "pair v does not add");
}

static void test_diff_emission_directions_and_lengths_follow_eqs_2_to_6(pds_test_ctx *t)
{
    pds__ray_diff r;
    unsigned long i;
    double pl = pds__photon_diff_length(10.0, 2.0, 1e4), dl = pds__photon_diff_length(10.0, 2.0 * PDS__PI, 1e4);
    /* eqs 5-6 by hand: 2 s sqrt(A/(pi N)) */
    CHECK_NEAR(t, pl, 20.0 * sqrt(2.0 / (PDS__PI * 1e4)), 1e-15);
    CHECK_NEAR(t, pds__photon_diff_length(1.0, 4.0 * PDS__PI, 100.0), 0.4, 1e-15);
    CHECK(t, pds__photon_diff_length(10.0, 0.0, 1e4) == 0.0, "zero extent -> 0");
    CHECK(t, pds__photon_diff_length(10.0, 1.0, 0.0) == 0.0, "no photons -> 0");
    /* the footprints of N photons sum to s^2 Ae: N pi/4 len^2 = s^2 A */
    CHECK_NEAR(t, 1e4 * 0.25 * PDS__PI * pl * pl, 100.0 * 2.0, 1e-9);
    for (i = 0; i < 200; i++) {
        pds__v3 n = pds__normalize(pds__v(dt_rand(i, 0) - 0.5, dt_rand(i, 1) - 0.5, dt_rand(i, 2) - 0.5));
        pds__v3 w = pds__normalize(pds__v(dt_rand(i, 3) - 0.5, dt_rand(i, 4) - 0.5, dt_rand(i, 5) - 0.5));
        pds__v3 x = pds__v(dt_rand(i, 6), dt_rand(i, 7), dt_rand(i, 8));
        switch (i % 5) {
        case 1: w = n; break;                                  /* omega = n: ONB fallback */
        case 2: w = pds__normalize(pds__add(n, pds__v(3e-7, -2e-7, 1e-7))); break; /* omega ~ n */
        case 3: n = pds__scale(n, -1.0); break;                /* emitting off the back */
        default: break;
        }
        pds__photon_diff_init(&r, x, w, n, pl, dl);
        CHECK(t, r.p.x == x.x && r.p.y == x.y && r.p.z == x.z, "position");
        dt_check_emission(t, &r, n, pl, dl);
        if (i % 5 == 4) { /* no normal (point/spot light) */
            pds__photon_diff_init(&r, x, w, pds__v(0.0, 0.0, 0.0), 0.0, dl);
            dt_check_emission(t, &r, pds__v(0.0, 0.0, 0.0), 0.0, dl);
            CHECK(t, pds__length(r.dpdu) == 0.0 && pds__length(r.dpdv) == 0.0, "point light has no area");
        }
        {
            /* Appendix A on a random receiving plane in front */
            pds__v3 ng = pds__normalize(pds__v(dt_rand(i, 20) - 0.5, dt_rand(i, 21) - 0.5, dt_rand(i, 22) - 0.5));
            if (fabs(pds__dot(ng, r.d)) < 0.2) ng = pds__normalize(pds__sub(ng, r.d));
            if (pds__length(r.dpdu) > 0.0) dt_check_appendix_a(t, &r, 0.5 + 3.0 * dt_rand(i, 23), ng);
        }
    }
}

static void test_diff_point_light_photon_matches_traced_neighbours(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text("material m mirror { reflectance 1 }\n"
                                   "light point { position 0.1 3 -0.1 power 100 }\n"
                                   "sphere { material m radius 1 segments 512 rings 256 rotate 90 1 0 0 }\n"
                                   "sphere { radius 8 segments 256 rings 128 rotate 90 1 0 0 }\n",
                                   &err);
    dt_fd_stats st, st2;
    unsigned long i;
    int emitted = 0;
    REQUIRE(t, s != NULL, "%s", err.text);
    memset(&st, 0, sizeof st);
    memset(&st2, 0, sizeof st2);
    for (i = 0; i < 5000 && st.tried < 40; i++) {
        double u[4];
        pds_emission e;
        pds__ray_diff r;
        double dl;
        u[0] = dt_rand(i, 0), u[1] = dt_rand(i, 1), u[2] = dt_rand(i, 2), u[3] = dt_rand(i, 3);
        REQUIRE(t, pds_scene_emit(s, 0, u, &e), "emission failed");
        CHECK(t, e.area == 0.0 && fabs(e.solid_angle - 4.0 * PDS__PI) < 1e-12, "extent %g %g", e.area,
              e.solid_angle);
        dl = pds__photon_diff_length(8.0, e.solid_angle, 1e4);
        pds__photon_diff_init(&r, e.position, e.direction, e.normal, pds__photon_diff_length(8.0, e.area, 1e4),
                              dl);
        emitted++;
        CHECK(t, r.dpdu.x == 0.0 && r.dpdu.y == 0.0 && r.dpdu.z == 0.0 && pds__length(r.dpdv) == 0.0,
              "point light: zero positional differentials");
        dt_check_emission(t, &r, e.normal, 0.0, dl);
        CHECK_NEAR(t, dl, 2.0 * 8.0 * sqrt(4.0 / 1e4), 1e-12);
        /* only photons that head for the mirror sphere */
        if (r.d.y > -0.93) continue;
        dt_fd_compare(s, &r, ".", 2e-5, &st);
        dt_fd_compare(s, &r, "R.", 2e-5, &st2);
    }
    CHECK(t, emitted > 0, "no photon");
    dt_fd_check(t, "point light: transfer onto sphere", &st, 0);
    dt_fd_check(t, "point light: reflect off sphere", &st2, 1);
    pds_scene_free(s);
}

static void test_diff_area_light_photon_matches_traced_neighbours(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text("material g dielectric { ior 1.5 }\n"
                                   "light disk { center 0 3 0 normal 0 -1 0 radius 0.5 radiance 1 }\n"
                                   "sphere { material g radius 1 segments 512 rings 256 rotate 90 1 0 0 }\n"
                                   "quad { size 40 40 translate 0 -3 0 }\n",
                                   &err);
    dt_fd_stats st, st2;
    unsigned long i;
    REQUIRE(t, s != NULL, "%s", err.text);
    memset(&st, 0, sizeof st);
    memset(&st2, 0, sizeof st2);
    for (i = 0; i < 2000 && st2.tried < 40; i++) {
        double u[4], pl, dl;
        pds_emission e;
        pds__ray_diff r;
        dt_path path;
        u[0] = dt_rand(i, 0), u[1] = dt_rand(i, 1), u[2] = dt_rand(i, 2), u[3] = dt_rand(i, 3);
        if (!pds_scene_emit(s, 0, u, &e)) continue;
        CHECK_NEAR(t, e.area, PDS__PI * 0.25, 1e-12);
        pl = pds__photon_diff_length(12.0, e.area, 1e4);
        dl = pds__photon_diff_length(12.0, e.solid_angle, 1e4);
        CHECK_NEAR(t, pl, 24.0 * sqrt(0.25 / 1e4), 1e-12);
        pds__photon_diff_init(&r, e.position, e.direction, e.normal, pl, dl);
        dt_check_emission(t, &r, e.normal, pl, dl);
        /* appendix A at the real first hit */
        if (!dt_trace(s, r, ".", &path) || path.nhits != 1) continue;
        {
            pds__tri_hit th;
            pds_hit hit;
            REQUIRE(t, pds__bvh_intersect(&s->bvh, r.p, r.d, 1e-4, 1e30, &th), "hit");
            pds__scene_fill_hit(s, &th, r.p, r.d, &hit);
            dt_check_appendix_a(t, &r, hit.t, hit.ng);
        }
        dt_fd_compare(s, &r, ".", 2e-5, &st);
        if (pds__length(pds__v(path.at[0].p.x, 0.0, path.at[0].p.z)) < 0.8 && path.at[0].p.y > 0.0)
            dt_fd_compare(s, &r, "TT.", 2e-5, &st2);
    }
    dt_fd_check(t, "area light: first transfer", &st, 0);
    dt_fd_check(t, "area light: through glass sphere", &st2, 1);
    CHECK(t, st2.tried >= 20, "only %d photons reached the glass sphere", st2.tried);
    pds_scene_free(s);
}

static void test_diff_directional_light_photon_matches_traced_neighbours(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text("material g dielectric { ior 1.5 }\n"
                                   "light directional { direction 0.05 -1 0.1 irradiance 1 disk -0.2 4 -0.4 0.6 }\n"
                                   "sphere { material g radius 1 segments 512 rings 256 rotate 90 1 0 0 }\n"
                                   "quad { size 40 40 translate 0 -3 0 }\n",
                                   &err);
    dt_fd_stats st;
    unsigned long i;
    REQUIRE(t, s != NULL, "%s", err.text);
    memset(&st, 0, sizeof st);
    for (i = 0; i < 40; i++) {
        double u[4], pl;
        pds_emission e;
        pds__ray_diff r;
        u[0] = dt_rand(i, 0), u[1] = dt_rand(i, 1), u[2] = dt_rand(i, 2), u[3] = dt_rand(i, 3);
        REQUIRE(t, pds_scene_emit(s, 0, u, &e), "emission failed");
        CHECK(t, e.solid_angle == 0.0, "directional light has no solid angle");
        CHECK_NEAR(t, e.area, PDS__PI * 0.36, 1e-12);
        pl = pds__photon_diff_length(5.0, e.area, 1e3);
        pds__photon_diff_init(&r, e.position, e.direction, e.normal, pl,
                              pds__photon_diff_length(5.0, e.solid_angle, 1e3));
        CHECK(t, pds__length(r.dddu) == 0.0 && pds__length(r.dddv) == 0.0, "zero directional differentials");
        dt_check_emission(t, &r, e.normal, pl, 0.0);
        /* across the beam: both positional vectors perpendicular to it */
        CHECK_NEAR(t, pds__dot(r.dpdu, r.d), 0.0, 1e-12);
        CHECK_NEAR(t, pds__dot(r.dpdv, r.d), 0.0, 1e-12);
        dt_fd_compare(s, &r, "TT.", 2e-5, &st);
    }
    dt_fd_check(t, "directional light: through glass sphere", &st, 1);
    pds_scene_free(s);
}

/* ------------------------------------------------ local algebraic checks */

/* random unit vector */
static pds__v3 dt_unit(unsigned long i, int dim)
{
    double z = 2.0 * dt_rand(i, dim) - 1.0, a = 2.0 * PDS__PI * dt_rand(i, dim + 1), s = sqrt(1.0 - z * z);
    return pds__v(s * cos(a), s * sin(a), z);
}

static pds__v3 dt_perp(pds__v3 v, pds__v3 n)
{
    return pds__sub(v, pds__scale(n, pds__dot(v, n)));
}

static void test_diff_reflect_refract_keep_direction_differentials_perpendicular(pds_test_ctx *t)
{
    unsigned long i;
    int refracted = 0, tir = 0;
    for (i = 0; i < 500; i++) {
        pds__v3 n = dt_unit(i, 0), d = dt_unit(i, 2), t0;
        pds__ray_diff r, r2;
        pds__v3 dnu = pds__scale(dt_perp(dt_unit(i, 4), n), 2.0), dnv = pds__scale(dt_perp(dt_unit(i, 6), n), 0.7);
        double eta = (i & 1) ? 1.0 / 1.5 : 1.5;
        if (pds__dot(d, n) > 0.0) d = pds__scale(d, -1.0);
        r.p = pds__v(0.0, 0.0, 0.0);
        r.d = d;
        r.dpdu = dt_unit(i, 8);
        r.dpdv = dt_unit(i, 10);
        r.dddu = pds__scale(dt_perp(dt_unit(i, 12), d), 3.0);
        r.dddv = pds__scale(dt_perp(dt_unit(i, 14), d), 0.5);
        r2 = r;
        pds__diff_reflect(&r, (i & 2) ? n : pds__scale(n, -1.0), (i & 2) ? dnu : pds__scale(dnu, -1.0),
                          (i & 2) ? dnv : pds__scale(dnv, -1.0));
        CHECK_NEAR(t, pds__length(r.d), 1.0, 1e-12);
        CHECK(t, fabs(pds__dot(r.d, r.dddu)) <= 1e-12 * pds__length(r.dddu), "R.DRu = %g", pds__dot(r.d, r.dddu));
        CHECK(t, fabs(pds__dot(r.d, r.dddv)) <= 1e-12 * pds__length(r.dddv), "R.DRv = %g", pds__dot(r.d, r.dddv));
        CHECK(t, r.dpdu.x == r2.dpdu.x && r.dpdv.z == r2.dpdv.z, "reflection keeps positional differentials");
        if (pds__diff_refract(&r2, n, dnu, dnv, eta)) {
            refracted++;
            REQUIRE(t, pds__refract(d, n, eta, &t0), "pds__refract disagrees about TIR");
            CHECK(t, r2.d.x == t0.x && r2.d.y == t0.y && r2.d.z == t0.z, "T differs from pds__refract");
            CHECK_NEAR(t, pds__length(r2.d), 1.0, 1e-12);
            CHECK(t, fabs(pds__dot(r2.d, r2.dddu)) <= 1e-11 * pds__length(r2.dddu), "T.DTu = %g",
                  pds__dot(r2.d, r2.dddu));
            CHECK(t, fabs(pds__dot(r2.d, r2.dddv)) <= 1e-11 * pds__length(r2.dddv), "T.DTv = %g",
                  pds__dot(r2.d, r2.dddv));
        } else {
            tir++;
            CHECK(t, !pds__refract(d, n, eta, &t0), "refused a refraction pds__refract does");
            CHECK(t, r2.d.x == d.x && r2.d.y == d.y && r2.d.z == d.z, "r changed on TIR");
        }
    }
    CHECK(t, refracted > 100 && tir > 20, "refracted %d, TIR %d", refracted, tir);
    {
        /* normal incidence: T = -N, and with DN = 0, DT = eta DD + ... */
        pds__ray_diff r;
        memset(&r, 0, sizeof r);
        r.d = pds__v(0.0, 0.0, -1.0);
        r.dddu = pds__v(1.0, 0.0, 0.0);
        REQUIRE(t, pds__diff_refract(&r, pds__v(0.0, 0.0, 1.0), r.dpdu, r.dpdu, 1.0 / 1.5), "refract");
        CHECK_NEAR(t, r.d.z, -1.0, 1e-15);
        /* paraxial Snell: a tilt a outside becomes a/1.5 inside */
        CHECK_NEAR(t, r.dddu.x, 1.0 / 1.5, 1e-15);
    }
}

/* Directional differentials of reflection and refraction against finite
   differences of pds__reflect / pds__refract with a normal that varies
   linearly (then renormalised) along the differential. */
static void test_diff_reflect_refract_match_finite_differences_of_the_laws(pds_test_ctx *t)
{
    unsigned long i;
    double worst_r = 0.0, worst_t = 0.0;
    for (i = 0; i < 200; i++) {
        pds__v3 n = dt_unit(i, 0), d = dt_unit(i, 2), dd, dn, tp, tm;
        double eta = (i & 1) ? 1.0 / 1.33 : 1.33, h = 1e-5;
        pds__ray_diff r;
        if (pds__dot(d, n) > 0.0) d = pds__scale(d, -1.0);
        if (pds__dot(d, n) > -0.3) continue; /* keep away from grazing/critical */
        dd = dt_perp(dt_unit(i, 4), d);
        dn = dt_perp(dt_unit(i, 6), n);
        memset(&r, 0, sizeof r);
        r.d = d;
        r.dddu = dd;
        pds__diff_reflect(&r, n, dn, dn);
        {
            pds__v3 dp = pds__normalize(pds__add(d, pds__scale(dd, h)));
            pds__v3 dm = pds__normalize(pds__sub(d, pds__scale(dd, h)));
            pds__v3 np = pds__normalize(pds__add(n, pds__scale(dn, h)));
            pds__v3 nm = pds__normalize(pds__sub(n, pds__scale(dn, h)));
            pds__v3 fd = pds__scale(pds__sub(pds__reflect(dp, np), pds__reflect(dm, nm)), 0.5 / h);
            double e = dt_rel(fd, r.dddu);
            if (e > worst_r) worst_r = e;
            memset(&r, 0, sizeof r);
            r.d = d;
            r.dddu = dd;
            if (pds__diff_refract(&r, n, dn, dn, eta) && pds__refract(dp, np, eta, &tp) &&
                pds__refract(dm, nm, eta, &tm)) {
                fd = pds__scale(pds__sub(tp, tm), 0.5 / h);
                e = dt_rel(fd, r.dddu);
                if (e > worst_t) worst_t = e;
            }
        }
    }
    CHECK(t, worst_r < 1e-7, "reflection DR off by %g", worst_r);
    CHECK(t, worst_t < 1e-7, "refraction DT off by %g", worst_t);
    CHECK(t, worst_t > 0.0 && worst_r > 0.0, "nothing compared");
}

static void test_diff_transfer_lands_in_plane_and_refuses_grazing(pds_test_ctx *t)
{
    pds__ray_diff r;
    unsigned long i;
    for (i = 0; i < 100; i++) {
        pds__v3 ng = pds__scale(dt_unit(i, 0), 0.5 + dt_rand(i, 9)); /* need not be unit */
        r.p = pds__v(1.0, 2.0, 3.0);
        r.d = dt_unit(i, 2);
        if (fabs(pds__dot(r.d, pds__normalize(ng))) < 0.1) continue;
        r.dpdu = dt_unit(i, 4);
        r.dpdv = dt_unit(i, 6);
        r.dddu = dt_perp(dt_unit(i, 8), r.d);
        r.dddv = dt_perp(dt_unit(i, 10), r.d);
        REQUIRE(t, pds__diff_transfer(&r, 2.5, ng), "transfer failed");
        CHECK(t, fabs(pds__dot(r.dpdu, ng)) < 1e-12 * pds__length(ng) * (1.0 + pds__length(r.dpdu)), "DPu'.N");
        CHECK(t, fabs(pds__dot(r.dpdv, ng)) < 1e-12 * pds__length(ng) * (1.0 + pds__length(r.dpdv)), "DPv'.N");
    }
    /* hand example: d = -z onto z = const, DP = (0,0,1), DD = (1,0,0), t = 2:
       DP + t DD = (2,0,1), Dt = 1, DP' = (2,0,0); DD unchanged */
    memset(&r, 0, sizeof r);
    r.d = pds__v(0.0, 0.0, -1.0);
    r.dpdu = pds__v(0.0, 0.0, 1.0);
    r.dddu = pds__v(1.0, 0.0, 0.0);
    REQUIRE(t, pds__diff_transfer(&r, 2.0, pds__v(0.0, 0.0, -3.0)), "transfer");
    CHECK_NEAR(t, r.p.z, -2.0, 0.0);
    CHECK_NEAR(t, r.dpdu.x, 2.0, 1e-15);
    CHECK_NEAR(t, r.dpdu.z, 0.0, 1e-15);
    CHECK_NEAR(t, r.dddu.x, 1.0, 0.0);
    /* grazing: d in the plane -> refused, r untouched */
    {
        pds__ray_diff g = r;
        g.d = pds__v(1.0, 0.0, 0.0);
        CHECK(t, !pds__diff_transfer(&g, 1.0, pds__v(0.0, 0.0, 1.0)), "grazing accepted");
        CHECK(t, g.p.z == r.p.z && g.dpdu.x == r.dpdu.x, "grazing transfer changed r");
        g.d = pds__v(0.0, 0.0, -1.0);
        CHECK(t, !pds__diff_transfer(&g, NAN, pds__v(0.0, 0.0, 1.0)), "NaN distance accepted");
    }
}

static void test_diff_mesh_normal_differential_is_zero_on_flat_and_matches_sphere(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text("box { size 1 1 1 }\n"
                                   "sphere { radius 2 segments 512 rings 256 translate 5 0 0 }\n",
                                   &err);
    pds__tri_hit th;
    pds_hit hit;
    pds__v3 dn, dp;
    REQUIRE(t, s != NULL, "%s", err.text);
    /* box faces are flat: DN = 0 */
    REQUIRE(t, pds__bvh_intersect(&s->bvh, pds__v(0.1, 3.0, 0.2), pds__v(0.0, -1.0, 0.0), 0.0, 1e30, &th), "box");
    pds__mesh_normal_diff(&s->mesh, th.tri, th.u, th.v, pds__v(0.3, 0.0, 0.7), 0.0, &dn, NULL);
    CHECK(t, dn.x == 0.0 && dn.y == 0.0 && dn.z == 0.0, "flat face DN = (%g %g %g)", dn.x, dn.y, dn.z);
    /* a smooth sphere of radius 2: DN ~ DP/R for DP in the tangent plane
       (the mesh interpolates normals linearly, so only to ~1%) */
    REQUIRE(t, pds__bvh_intersect(&s->bvh, pds__v(5.3, 5.0, 0.4), pds__v(0.0, -1.0, 0.0), 0.0, 1e30, &th), "sph");
    pds__scene_fill_hit(s, &th, pds__v(5.3, 5.0, 0.4), pds__v(0.0, -1.0, 0.0), &hit);
    dp = pds__normalize(pds__cross(hit.ng, pds__v(1.0, 0.0, 0.0)));
    pds__mesh_normal_diff(&s->mesh, th.tri, th.u, th.v, dp, 0.0, &dn, NULL);
    CHECK(t, dt_rel(dn, pds__scale(dp, 0.5)) < 0.02, "sphere DN = (%g %g %g), DP/R = (%g %g %g)", dn.x, dn.y, dn.z,
          0.5 * dp.x, 0.5 * dp.y, 0.5 * dp.z);
    CHECK_NEAR(t, pds__dot(dn, hit.ns), 0.0, 1e-12); /* a unit normal's differential is tangent */
    pds_scene_free(s);
}

/* The normal's differential at a footprint's scale (pds__mesh_normal_diff,
   pds__mesh_smooth_normals) on a glass sphere of radius 0.5 tessellated
   into 240 x 120 segments, at the middle of every triangle away from the
   poles, along a random tangent step: the analytic DN = DP / R. The exact
   vertex normals are found smooth (no averaged fields) and every scale
   keeps that (mean error under 1.5%, the per-triangle derivative); with
   every vertex normal tilted at random
   (each component by up to 0.1) the per-triangle derivative is mostly
   noise (mean error above 3) and a footprint 8 or 16 triangles across
   takes the averaged fields' derivative, within 0.5 (0.44). One 1.5
   triangles across (the footprints of a few million photons) is within
   1 (0.63; 4.1 when the field was chosen by the footprint's width alone,
   PDS__NORMAL_REACH 1, which stalled that sphere's caustic from 200,000
   to 2 million photons). */
static double dt_sphere_dn_error(const pds_scene *s, double scale_edges, long *n_out)
{
    const pds__mesh *m = &s->mesh;
    double sum = 0.0;
    long n = 0;
    size_t t;
    for (t = 0; t < m->ntris; t++) {
        const int *ix = &m->idx[3 * t];
        pds__v3 p = pds__scale(pds__add(pds__add(pds__mesh_pos(m, ix[0]), pds__mesh_pos(m, ix[1])), pds__mesh_pos(m, ix[2])),
                               1.0 / 3.0);
        pds__v3 c = pds__v(0.0, 1.0, 0.0), nrm = pds__normalize(pds__sub(p, c)), t1, t2, dp, dn;
        double a = 2.0 * PDS__PI * dt_rand(t, 30), e = sqrt(pds__mesh_tri_area2(m, ix[0], ix[1], ix[2]));
        if (fabs(nrm.y) > 0.8) continue;
        pds__onb(nrm, &t1, &t2);
        dp = pds__scale(pds__add(pds__scale(t1, cos(a)), pds__scale(t2, sin(a))), 1e-3);
        pds__mesh_normal_diff(m, (long)t, 1.0 / 3.0, 1.0 / 3.0, dp, 0.5 * scale_edges * e, &dn, NULL);
        sum += dt_rel(dn, pds__scale(dp, 1.0 / 0.5));
        n++;
    }
    *n_out = n;
    return n > 0 ? sum / n : HUGE_VAL;
}

/* Tilt every vertex normal of s's mesh at random, each component by up
   to amp, and average the result again as the loader does
   (pds__mesh_smooth_normals; its status). */
static int dt_jitter_normals(pds_scene *s, double amp)
{
    size_t i;
    for (i = 0; i < s->mesh.nverts; i++) {
        pds__v3 nv = pds__mesh_nrm(&s->mesh, (long)i), jitter;
        jitter = pds__v(amp * (2.0 * dt_rand(i, 31) - 1.0), amp * (2.0 * dt_rand(i, 32) - 1.0),
                        amp * (2.0 * dt_rand(i, 33) - 1.0));
        nv = pds__normalize(pds__add(nv, jitter));
        s->mesh.nrm[3 * i] = (float)nv.x;
        s->mesh.nrm[3 * i + 1] = (float)nv.y;
        s->mesh.nrm[3 * i + 2] = (float)nv.z;
    }
    return pds__mesh_smooth_normals(&s->mesh, &s->materials);
}

static void test_diff_mesh_normal_differential_at_a_footprint_scale_averages_out_noise(pds_test_ctx *t)
{
    static const double scales[] = {0.0, 1.5, 4.0, 8.0, 16.0};
    pds_error err;
    pds_scene *s = scene_from_text("material glass dielectric { ior 1.5 }\n"
                                   "sphere { material glass radius 0.5 segments 240 rings 120 translate 0 1 0 }\n",
                                   &err);
    double e_exact[5], e_noise[5];
    long n = 0;
    size_t k;
    REQUIRE(t, s != NULL, "%s", err.text);
    CHECK(t, s->mesh.smooth == NULL, "smooth normals need no averaged fields");
    for (k = 0; k < 5; k++) e_exact[k] = dt_sphere_dn_error(s, scales[k], &n);
    REQUIRE(t, dt_jitter_normals(s, 0.1) == 0, "out of memory");
    CHECK(t, s->mesh.smooth != NULL, "noisy normals get their averaged fields");
    for (k = 0; k < 5; k++) e_noise[k] = dt_sphere_dn_error(s, scales[k], &n);
    CHECK(t, n > 2000, "only %ld triangles", n);
    for (k = 0; k < 5; k++)
        CHECK(t, e_exact[k] < 0.015, "exact normals, footprint %g triangles across: mean error %g", scales[k], e_exact[k]);
    CHECK(t, e_noise[0] > 3.0, "noisy normals, within a triangle: mean error %g (the noise's)", e_noise[0]);
    CHECK(t, e_noise[3] < 0.5 && e_noise[4] < 0.5, "noisy normals, 8 and 16 triangles across: mean errors %g, %g",
          e_noise[3], e_noise[4]);
    CHECK(t, e_noise[1] < 1.0, "noisy normals, 1.5 triangles across: mean error %g", e_noise[1]);
    pds_scene_free(s);
}


/* Noisy vertex normals must not explode footprints into streaks (the
   glass bunny at 20,000 photons once had footprints covering its whole
   floor). A glass sphere (120 x 60 segments) whose vertex normals are
   tilted at random, each component by up to 0.2 (about 0.17 rad), lit
   from the side by a small disk light so that its caustic lands on the
   floor beside it, seen from above with the sphere out of view (48 x 48
   pixels): PDS at 20,000 photons (6,700 since the photons' target is
   the sphere itself: the same photons reach the glass) against light
   tracing (no kernel, 10^6 photons), both summed in 8 x 8 blocks of 6 x
   6 pixels. The figures below are of the 20,000. With the
   defaults the image keeps 0.97-0.99 of the reference's light and the
   blocks' shares of it differ by 0.066-0.075 in sum (seeds 0-4; before
   footprints took the unresolved noise's blur, pds__footprint_blur,
   0.98-1.00 and 0.048-0.067: the blur spreads the caustic a little
   wider, and takes its per-pixel RMSE from 0.0205-0.0229 to
   0.0185-0.0197). With
   neither guard, no averaged normal fields (pds__mesh_smooth_normals)
   and no bound on the normal's turn over a footprint (split_angle 10
   rad), 7-10% of the light is spread out of view and the shares differ
   by 0.081-0.099, 1.25-2 times the defaults' at each seed; either guard
   alone keeps the light within 3% (shares 0.047-0.067). (Before
   defocused footprints were rounded at the geometric mean of their areas
   (pds__defocus_round) the unguarded render lost a fifth of its light,
   shares 0.18-0.20: the rounder, shorter faint footprints are a third
   guard.) */
static void dt_blocks(const pds_image *img, double blk[64])
{
    int x, y, c;
    memset(blk, 0, 64 * sizeof *blk);
    for (y = 0; y < 48; y++)
        for (x = 0; x < 48; x++)
            for (c = 0; c < 3; c++) blk[(y / 6) * 8 + x / 6] += img->rgb[3 * (y * 48 + x) + c];
}

/* The image's light over the reference's, and the L1 distance between
   their blocks' shares of it. */
static void dt_block_shares(const double ref[64], const pds_image *img, double *light, double *l1)
{
    double b[64], tot = 0.0, rtot = 0.0;
    int i;
    dt_blocks(img, b);
    for (i = 0; i < 64; i++) {
        tot += b[i];
        rtot += ref[i];
    }
    *light = tot / rtot;
    *l1 = 0.0;
    for (i = 0; i < 64; i++) *l1 += fabs(b[i] / tot - ref[i] / rtot);
}

static void test_diff_noisy_normals_make_no_streaks(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text("camera { position -1.6 2.5 0.000001 look_at -1.6 0 0 up 0 0 -1 fov 36 resolution 48 48 spp 4 }\n"
                                   "material floor diffuse { albedo 0.8 }\n"
                                   "material glass dielectric { ior 1.5 }\n"
                                   "light disk { center 4 2 0 normal -0.94 -0.34 0 radius 0.1 power 100 }\n"
                                   "quad { material floor size 6 6 }\n"
                                   "sphere { material glass radius 0.5 segments 120 rings 60 translate 0 0.55 0 }\n",
                                   &err);
    pds_options opt;
    pds_image ref = {0, 0, NULL}, img = {0, 0, NULL};
    double rb[64], light[2], l1[2];
    int k;
    REQUIRE(t, s != NULL, "%s", err.text);
    REQUIRE(t, dt_jitter_normals(s, 0.2) == 0, "out of memory");
    REQUIRE(t, s->mesh.smooth != NULL, "noisy normals get their averaged fields");
    pds_options_default(&opt);
    opt.threads = 2;
    opt.photons = 1000000;
    REQUIRE(t, pds_render_light_traced(s, &opt, &ref, &err) == PDS_OK, "reference: %s", err.text);
    dt_blocks(&ref, rb);
    /* about 7,000 photons reach the glass in two passes, as 20,000 in
       passes of 16,384 did while the photons' target was the sphere
       about the glass's bounding box (3 times the solid angle) */
    opt.photons = 6700;
    opt.pass_photons = 5461;
    opt.paths = PDS_PATHS_CAUSTICS_ONLY;
    /* the footprints alone: the pixels' validated choice of scale
       (pass_select) takes the unguarded render's light from 0.90-0.93 of
       the reference's to 0.96 where the camera sees the floor, which
       would hide what the guards do */
    opt.pass_select = 0;
    for (k = 0; k < 2; k++) {
        if (k == 1) {
            /* neither guard */
            free(s->mesh.smooth);
            s->mesh.smooth = NULL;
            opt.split_angle = 10.0;
        }
        REQUIRE(t, pds_render(s, &opt, &img, NULL, &err) == PDS_OK, "render: %s", err.text);
        dt_block_shares(rb, &img, &light[k], &l1[k]);
        pds_image_free(&img);
    }
    CHECK(t, fabs(light[0] - 1.0) < 0.05 && l1[0] < 0.08, "defaults: light %g of the reference's, shares apart by %g",
          light[0], l1[0]);
    CHECK(t, light[1] < 0.95 && l1[1] > 1.2 * l1[0],
          "without the guards the test should see streaks: light %g, shares %g (defaults %g)", light[1], l1[1], l1[0]);
    pds_image_free(&ref);
    pds_scene_free(s);
}

/* pds__footprint_blur convolves Silverman's kernel over the footprint
   with an isotropic Gaussian of standard deviation sigma in the tangent
   plane, matching the first two moments: the kernel's covariance in the
   unit disc is I / 8 (checked here by quadrature), so an ellipse of
   semi-axis vectors A, B has covariance (A A^T + B B^T) / 8, and after
   the blur that plus sigma^2 (I - n n^T). sigma 0 leaves it as it was. */
static void test_diff_footprint_blur_adds_the_noise_to_the_kernels_covariance(pds_test_ctx *t)
{
    double second = 0.0, h = 1.0 / 400.0, worst = 0.0;
    unsigned long i;
    int a, b, changed = 0;
    for (a = 0; a < 800; a++)
        for (b = 0; b < 800; b++) {
            double x = -1.0 + (a + 0.5) * h, y = -1.0 + (b + 0.5) * h;
            second += x * x * pds__kernel_silverman(x * x + y * y) * h * h;
        }
    CHECK(t, fabs(second - 0.125) < 1e-4, "Silverman's kernel: E[x^2] = %g, want 1/8", second);
    for (i = 0; i < 200; i++) {
        pds__v3 np = dt_unit(i, 40), b1, b2, du, dv, du0, dv0;
        double sigma = 0.05 * dt_rand(i, 41), S0[3][3], S1[3][3];
        int r, c;
        pds__onb(np, &b1, &b2);
        du = pds__add(pds__scale(b1, dt_rand(i, 42) - 0.5), pds__scale(b2, 0.2 * (dt_rand(i, 43) - 0.5)));
        dv = pds__add(pds__scale(b1, 0.1 * (dt_rand(i, 44) - 0.5)), pds__scale(b2, dt_rand(i, 45) - 0.5));
        du0 = du;
        dv0 = dv;
        changed += pds__footprint_blur(&du, &dv, np, sigma);
        for (r = 0; r < 3; r++)
            for (c = 0; c < 3; c++) {
                double ar = 0.5 * pds__v3_get(du0, r), ac = 0.5 * pds__v3_get(du0, c);
                double br = 0.5 * pds__v3_get(dv0, r), bc = 0.5 * pds__v3_get(dv0, c);
                S0[r][c] = (ar * ac + br * bc) / 8.0 + sigma * sigma * ((r == c) - pds__v3_get(np, r) * pds__v3_get(np, c));
                ar = 0.5 * pds__v3_get(du, r);
                ac = 0.5 * pds__v3_get(du, c);
                br = 0.5 * pds__v3_get(dv, r);
                bc = 0.5 * pds__v3_get(dv, c);
                S1[r][c] = (ar * ac + br * bc) / 8.0;
                worst = fmax(worst, fabs(S1[r][c] - S0[r][c]));
            }
    }
    CHECK(t, changed == 200 && worst < 1e-12, "%d of 200 blurred; covariance off by %g", changed, worst);
    {
        pds__v3 du = pds__v(0.2, 0.0, 0.0), dv = pds__v(0.0, 0.0, 0.1), du0 = du, dv0 = dv;
        CHECK(t, !pds__footprint_blur(&du, &dv, pds__v(0.0, 1.0, 0.0), 0.0) && pds__length(pds__sub(du, du0)) == 0.0 &&
                     pds__length(pds__sub(dv, dv0)) == 0.0,
              "sigma 0 changed the footprint");
    }
}

/* pds__noise_gain against the production refraction and reflection: at
   normal incidence a normal tilted by delta turns the transmitted
   direction by |1 - eta| delta (entering glass, eta = 1/1.5, and leaving
   it, eta = 1.5) and the reflected one by 2 delta, to first order. */
static void test_diff_noise_gain_is_the_turn_of_the_refracted_and_reflected_ray(pds_test_ctx *t)
{
    static const double etas[] = {1.0 / 1.5, 1.5, 1.0 / 1.33};
    pds__v3 d = pds__v(0.0, -1.0, 0.0), n = pds__v(0.0, 1.0, 0.0), nt, t0, t1;
    double delta = 1e-5;
    size_t k;
    nt = pds__normalize(pds__v(sin(delta), cos(delta), 0.0));
    for (k = 0; k < 3; k++) {
        double turn;
        REQUIRE(t, pds__refract(d, n, etas[k], &t0) && pds__refract(d, nt, etas[k], &t1), "refraction");
        turn = pds__length(pds__sub(pds__normalize(t1), pds__normalize(t0))) / delta;
        CHECK(t, fabs(turn - pds__noise_gain(1, etas[k])) < 1e-3 * pds__noise_gain(1, etas[k]),
              "eta %g: the refracted ray turns by %g per radian, gain %g", etas[k], turn, pds__noise_gain(1, etas[k]));
    }
    t0 = pds__reflect(d, n);
    t1 = pds__reflect(d, nt);
    CHECK(t, fabs(pds__length(pds__sub(t1, t0)) / delta - pds__noise_gain(0, 1.0)) < 1e-3,
          "the reflected ray turns by %g per radian", pds__length(pds__sub(t1, t0)) / delta);
}

/* pds__mesh_normal_diff's noise estimate: nothing on exact normals or
   within a triangle; on the sphere of 240 x 120 segments whose vertex
   normals are tilted at random (each component uniform in +-0.1, so
   about 0.058 rad rms per tangent direction), a footprint 8 triangles
   across reports a noise of that order (mean 0.5 to 2 times it). */
static void test_diff_normal_noise_estimate_matches_the_jitter(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text("material glass dielectric { ior 1.5 }\n"
                                   "sphere { material glass radius 0.5 segments 240 rings 120 translate 0 1 0 }\n",
                                   &err);
    double sum[3] = {0.0, 0.0, 0.0}, jitter = 0.1 / sqrt(3.0);
    long n = 0;
    size_t tri;
    int pass;
    REQUIRE(t, s != NULL, "%s", err.text);
    for (pass = 0; pass < 2; pass++) {
        const pds__mesh *m = &s->mesh;
        if (pass == 1) REQUIRE(t, dt_jitter_normals(s, 0.1) == 0, "out of memory");
        for (tri = 0; tri < m->ntris; tri++) {
            const int *ix = &m->idx[3 * tri];
            pds__v3 p = pds__scale(pds__add(pds__add(pds__mesh_pos(m, ix[0]), pds__mesh_pos(m, ix[1])),
                                            pds__mesh_pos(m, ix[2])), 1.0 / 3.0);
            pds__v3 nrm = pds__normalize(pds__sub(p, pds__v(0.0, 1.0, 0.0))), t1, t2, dp, dn;
            double e = sqrt(pds__mesh_tri_area2(m, ix[0], ix[1], ix[2])), noise_small, noise_wide;
            if (fabs(nrm.y) > 0.8) continue;
            pds__onb(nrm, &t1, &t2);
            dp = pds__scale(t1, 8.0 * e);
            pds__mesh_normal_diff(m, (long)tri, 1.0 / 3.0, 1.0 / 3.0, pds__scale(t1, 0.2 * e), 0.1 * e, &dn, &noise_small);
            pds__mesh_normal_diff(m, (long)tri, 1.0 / 3.0, 1.0 / 3.0, dp, 4.0 * e, &dn, &noise_wide);
            sum[pass] += noise_wide;
            if (pass == 1) sum[2] += noise_small;
            n += pass;
        }
    }
    CHECK(t, n > 2000, "only %ld triangles", n);
    CHECK(t, sum[0] == 0.0, "exact normals: noise %g", sum[0]);
    CHECK(t, sum[2] == 0.0, "footprints within a triangle: noise %g", sum[2]);
    CHECK(t, sum[1] / n > 0.5 * jitter && sum[1] / n < 2.0 * jitter, "noisy normals: mean noise %g rad, the jitter's %g",
          sum[1] / n, jitter);
    pds_scene_free(s);
}

static void test_diff_filter_matrix_eq12_equals_general_inverse(pds_test_ctx *t)
{
    unsigned long i;
    int compared = 0;
    for (i = 0; i < 1000; i++) {
        pds__v3 np = dt_unit(i, 0), b1, b2, du, dv;
        double M[2][3], G[2][3], scale = pow(10.0, 4.0 * dt_rand(i, 20) - 2.0), mx = 0.0, diff = 0.0;
        int a, b;
        pds__onb(np, &b1, &b2);
        du = pds__scale(pds__add(pds__scale(b1, dt_rand(i, 2) - 0.5), pds__scale(b2, dt_rand(i, 3) - 0.5)), scale);
        dv = pds__scale(pds__add(pds__scale(b1, dt_rand(i, 4) - 0.5), pds__scale(b2, dt_rand(i, 5) - 0.5)), scale);
        if (pds__length(pds__cross(du, dv)) < 0.05 * scale * scale) continue; /* well conditioned */
        REQUIRE(t, pds__filter_matrix(du, dv, np, M), "eq 12 refused");
        REQUIRE(t, pds__filter_matrix_general(du, dv, np, G), "general inverse refused");
        for (a = 0; a < 2; a++)
            for (b = 0; b < 3; b++) {
                if (fabs(G[a][b]) > mx) mx = fabs(G[a][b]);
                if (fabs(G[a][b] - M[a][b]) > diff) diff = fabs(G[a][b] - M[a][b]);
            }
        CHECK(t, diff <= 1e-12 * mx, "eq 12 vs general inverse: %g of %g", diff, mx);
        /* M maps Du/2 -> (1,0), Dv/2 -> (0,1), np -> (0,0) */
        {
            pds__v3 ha = pds__scale(du, 0.5), hb = pds__scale(dv, 0.5);
            double m0[3], m1[3];
            m0[0] = M[0][0], m0[1] = M[0][1], m0[2] = M[0][2];
            m1[0] = M[1][0], m1[1] = M[1][1], m1[2] = M[1][2];
            CHECK_NEAR(t, m0[0] * ha.x + m0[1] * ha.y + m0[2] * ha.z, 1.0, 1e-12);
            CHECK_NEAR(t, m1[0] * ha.x + m1[1] * ha.y + m1[2] * ha.z, 0.0, 1e-12);
            CHECK_NEAR(t, m0[0] * hb.x + m0[1] * hb.y + m0[2] * hb.z, 0.0, 1e-12);
            CHECK_NEAR(t, m1[0] * hb.x + m1[1] * hb.y + m1[2] * hb.z, 1.0, 1e-12);
            CHECK_NEAR(t, (m0[0] * np.x + m0[1] * np.y + m0[2] * np.z) * scale, 0.0, 1e-12);
            CHECK_NEAR(t, (m1[0] * np.x + m1[1] * np.y + m1[2] * np.z) * scale, 0.0, 1e-12);
        }
        compared++;
    }
    CHECK(t, compared > 500, "only %d footprints", compared);
    {
        /* collapsed footprint: refused, M untouched */
        double M[2][3] = {{7, 7, 7}, {7, 7, 7}};
        pds__v3 a = pds__v(1.0, 0.0, 0.0);
        CHECK(t, !pds__filter_matrix(a, pds__scale(a, 2.0), pds__v(0.0, 0.0, 1.0), M), "parallel accepted");
        CHECK(t, !pds__filter_matrix_general(a, pds__scale(a, 2.0), pds__v(0.0, 0.0, 1.0), M), "general accepted");
        CHECK(t, M[0][0] == 7.0 && M[1][2] == 7.0, "M changed");
        CHECK(t, !pds__filter_matrix(a, pds__v(0.0, 1.0, 0.0), pds__v(NAN, 0.0, 1.0), M), "NaN accepted");
    }
}

/* The splat of one photon integrates to its flux: midpoint quadrature of
   pi K(|M y|) E_p over the photon's tangent plane, E_p = Phi_p / A_p. */
static void test_diff_kernel_splat_integrates_to_photon_flux(pds_test_ctx *t)
{
    int trial;
    double sum = 0.0, k0;
    int i, j, nq = 2000;
    /* the kernel alone over the unit disc (polar midpoint rule) */
    for (i = 0; i < 100000; i++) {
        double r = (i + 0.5) / 100000.0;
        sum += pds__kernel_silverman(r * r) * 2.0 * PDS__PI * r / 100000.0;
    }
    CHECK_NEAR(t, sum, 1.0, 1e-9);
    k0 = pds__kernel_silverman(0.0);
    CHECK_NEAR(t, k0, 3.0 / PDS__PI, 1e-15);
    CHECK_NEAR(t, pds__kernel_silverman(0.25), 3.0 / PDS__PI * 0.5625, 1e-15);
    CHECK(t, pds__kernel_silverman(1.0) == 0.0 && pds__kernel_silverman(4.0) == 0.0, "support is the unit disc");
    CHECK(t, pds__kernel_silverman(NAN) == 0.0, "NaN gives 0");
    for (trial = 0; trial < 3; trial++) {
        pds__v3 np = dt_unit(100 + trial, 0), e1, e2, du, dv;
        double M[2][3], ap, phi = 2.5, ep, ext, acc = 0.0, h;
        pds__onb(np, &e1, &e2);
        du = pds__add(pds__scale(e1, 0.3 + trial * 0.2), pds__scale(e2, 0.1));
        dv = pds__add(pds__scale(e1, 0.25 * trial), pds__scale(e2, 0.2 + 0.1 * trial));
        REQUIRE(t, pds__filter_matrix(du, dv, np, M), "M");
        ap = pds__footprint_area(du, dv);
        ep = phi / ap;
        ext = pds__footprint_major_axis(du, dv) * 1.01;
        h = 2.0 * ext / nq;
        for (i = 0; i < nq; i++) {
            for (j = 0; j < nq; j++) {
                double s = -ext + (i + 0.5) * h, q = -ext + (j + 0.5) * h;
                pds__v3 y = pds__add(pds__scale(e1, s), pds__scale(e2, q));
                double m0 = M[0][0] * y.x + M[0][1] * y.y + M[0][2] * y.z;
                double m1 = M[1][0] * y.x + M[1][1] * y.y + M[1][2] * y.z;
                acc += PDS__PI * pds__kernel_silverman(m0 * m0 + m1 * m1) * ep * h * h;
            }
        }
        /* y = B z maps the unit disc onto the footprint, dA = |det B| dz
           with |det B| = |Du x Dv|/4 = A_p/pi, so the integral is
           pi E_p (A_p/pi) * (integral of K over the disc = 1) = Phi_p */
        CHECK(t, fabs(acc - phi) < 1e-4 * phi, "splat integral %.9g, flux %g", acc, phi);
    }
}

/* The principal semi-axes without trigonometry: against their definition
   (a, b turned by t = atan2(2 a.b, a.a - b.b) / 2) in every quadrant of
   (a.a - b.b, 2 a.b), including near its negative axis where cos t is
   small; and what any pair of principal axes keeps: A.B = 0, |A| the
   major semi-axis, |A|^2 + |B|^2 = |a|^2 + |b|^2 and |A x B| = |a x b|. */
static void test_diff_footprint_axes_match_their_definition(pds_test_ctx *t)
{
    unsigned long i;
    pds__v3 A, B;
    for (i = 0; i < 2000; i++) {
        pds__v3 du = pds__scale(dt_unit(i, 0), 0.1 + dt_rand(i, 4)), dv = pds__scale(dt_unit(i, 2), 0.1 + dt_rand(i, 5));
        pds__v3 a, b, At, Bt;
        double aa, bb, ab, th, scale;
        if (i % 4 == 1) dv = pds__add(pds__scale(du, -1.0 + 1e-9 * dt_rand(i, 6)), pds__scale(dv, 1e-7)); /* b ~ -a */
        if (i % 4 == 2) dv = pds__scale(dv, 1e-3); /* a needle */
        if (i % 4 == 3) dv = pds__scale(pds__cross(du, dt_unit(i, 7)), 10.0); /* b long, across a: d < 0, e ~ 0 */
        a = pds__scale(du, 0.5);
        b = pds__scale(dv, 0.5);
        aa = pds__dot(a, a);
        bb = pds__dot(b, b);
        ab = pds__dot(a, b);
        th = 0.5 * atan2(2.0 * ab, aa - bb);
        At = pds__add(pds__scale(a, cos(th)), pds__scale(b, sin(th)));
        Bt = pds__add(pds__scale(a, -sin(th)), pds__scale(b, cos(th)));
        pds__footprint_axes(du, dv, &A, &B);
        scale = sqrt(aa + bb);
        CHECK(t, pds__length(pds__sub(A, At)) <= 1e-12 * scale && pds__length(pds__sub(B, Bt)) <= 1e-12 * scale,
              "case %lu: A (%g %g %g), atan2's (%g %g %g)", i, A.x, A.y, A.z, At.x, At.y, At.z);
        CHECK(t, fabs(pds__dot(A, B)) <= 1e-12 * (aa + bb), "case %lu: A.B = %g", i, pds__dot(A, B));
        CHECK(t, fabs(pds__length(A) - pds__footprint_major_axis(du, dv)) <= 1e-12 * scale &&
                     pds__length(A) >= pds__length(B),
              "case %lu: |A| %g, major semi-axis %g, |B| %g", i, pds__length(A), pds__footprint_major_axis(du, dv),
              pds__length(B));
        CHECK(t, fabs(pds__dot(A, A) + pds__dot(B, B) - (aa + bb)) <= 1e-12 * (aa + bb) &&
                     fabs(pds__length(pds__cross(A, B)) - pds__length(pds__cross(a, b))) <= 1e-12 * (aa + bb),
              "case %lu: the sum of squares or the area changed", i);
    }
    /* a circle keeps its own pair: A = a, B = b */
    pds__footprint_axes(pds__v(2.0, 0.0, 0.0), pds__v(0.0, 2.0, 0.0), &A, &B);
    CHECK(t, A.x == 1.0 && A.y == 0.0 && B.x == 0.0 && B.y == 1.0, "circle: A (%g %g), B (%g %g)", A.x, A.y, B.x, B.y);
    /* b = -a exactly (d = 0, e < 0): t = -pi/4 */
    pds__footprint_axes(pds__v(2.0, 0.0, 0.0), pds__v(-2.0, 0.0, 0.0), &A, &B);
    CHECK(t, fabs(A.x - sqrt(2.0)) < 1e-15 && fabs(B.x) < 1e-15, "b = -a: A.x %g, B.x %g", A.x, B.x);
}

static void test_diff_footprint_area_axis_and_anisotropy_known_values(pds_test_ctx *t)
{
    unsigned long i;
    pds__v3 x = pds__v(1.0, 0.0, 0.0), y = pds__v(0.0, 1.0, 0.0);
    /* eq 4 for orthogonal vectors: pi/4 |a||b| */
    CHECK_NEAR(t, pds__footprint_area(pds__scale(x, 2.0), pds__scale(y, 3.0)), 0.25 * PDS__PI * 6.0, 1e-14);
    CHECK_NEAR(t, pds__footprint_area(x, pds__scale(x, 5.0)), 0.0, 0.0);
    /* a = (1,0,0), b = (1,1,0): A^2 = 3/2 + sqrt(1/4 + 1) = golden ratio^2 */
    CHECK_NEAR(t, pds__footprint_major_axis(pds__scale(x, 2.0), pds__v(2.0, 2.0, 0.0)), (1.0 + sqrt(5.0)) / 2.0,
               1e-14);
    /* circle */
    CHECK_NEAR(t, pds__footprint_major_axis(pds__scale(x, 2.0), pds__scale(y, 2.0)), 1.0, 1e-15);
    /* anisotropy */
    CHECK_NEAR(t, pds__footprint_anisotropy(pds__scale(x, 0.3), pds__scale(y, 0.3)), 1.0, 1e-15);
    CHECK_NEAR(t, pds__footprint_anisotropy(x, pds__scale(x, -0.5)), 0.0, 1e-15);
    CHECK(t, pds__footprint_anisotropy(x, pds__v(0.5, 1e-9, 0.0)) < 1e-8, "nearly parallel -> ~0");
    CHECK_NEAR(t, pds__footprint_anisotropy(pds__scale(x, 2.0), pds__v(1.0, 1.0, 0.0)), 0.5, 1e-15);
    CHECK_NEAR(t, pds__footprint_anisotropy(pds__v(1.0, 1.0, 0.0), pds__scale(x, 2.0)), 0.5, 1e-15); /* order-free */
    CHECK(t, pds__footprint_anisotropy(pds__v(0.0, 0.0, 0.0), pds__v(0.0, 0.0, 0.0)) == 0.0, "degenerate");
    for (i = 0; i < 300; i++) {
        pds__v3 du = pds__scale(dt_unit(i, 0), 0.1 + dt_rand(i, 4)), dv = pds__scale(dt_unit(i, 2), 0.1 + dt_rand(i, 5));
        pds__v3 a = pds__scale(du, 0.5), b = pds__scale(dv, 0.5), mx = a, mn = b, perp;
        double A = pds__footprint_major_axis(du, dv), reach = 0.0, ma, want;
        int k;
        CHECK(t, A >= fmax(pds__length(a), pds__length(b)) * (1.0 - 1e-14), "A below max(|a|,|b|)");
        CHECK(t, A <= sqrt(pds__dot(a, a) + pds__dot(b, b)) * (1.0 + 1e-14), "A above sqrt(|a|^2+|b|^2)");
        for (k = 0; k < 4096; k++) {
            double s = 2.0 * PDS__PI * k / 4096.0;
            double dist = pds__length(pds__add(pds__scale(a, cos(s)), pds__scale(b, sin(s))));
            CHECK(t, dist <= A * (1.0 + 1e-12), "boundary point at %g beyond A = %g", dist, A);
            if (dist > reach) reach = dist;
        }
        CHECK(t, reach >= A * (1.0 - 1e-6), "no boundary point reaches A (%g < %g)", reach, A);
        if (pds__dot(b, b) > pds__dot(a, a)) {
            mx = b;
            mn = a;
        }
        perp = pds__sub(mn, pds__scale(mx, pds__dot(mx, mn) / pds__dot(mx, mx)));
        want = pds__length(perp) / pds__length(mx);
        ma = pds__footprint_anisotropy(du, dv);
        CHECK_NEAR(t, ma, want, 1e-12);
        CHECK(t, ma >= 0.0 && ma <= 1.0, "m_a = %g out of [0,1]", ma);
    }
}

static const pds_test_case tests_differentials[] = {
    {"diff_transfer_onto_sphere_and_plane_matches_traced_neighbours",
     test_diff_transfer_onto_sphere_and_plane_matches_traced_neighbours},
    {"diff_reflection_off_mirror_sphere_matches_traced_neighbours",
     test_diff_reflection_off_mirror_sphere_matches_traced_neighbours},
    {"diff_reflection_off_sine_heightfield_matches_traced_neighbours",
     test_diff_reflection_off_sine_heightfield_matches_traced_neighbours},
    {"diff_refraction_through_glass_sphere_matches_traced_neighbours",
     test_diff_refraction_through_glass_sphere_matches_traced_neighbours},
    {"diff_refraction_into_water_heightfield_matches_traced_neighbours",
     test_diff_refraction_into_water_heightfield_matches_traced_neighbours},
    {"diff_reflection_inside_ring_matches_traced_neighbours", test_diff_reflection_inside_ring_matches_traced_neighbours},
    {"diff_emission_directions_and_lengths_follow_eqs_2_to_6",
     test_diff_emission_directions_and_lengths_follow_eqs_2_to_6},
    {"diff_point_light_photon_matches_traced_neighbours", test_diff_point_light_photon_matches_traced_neighbours},
    {"diff_area_light_photon_matches_traced_neighbours", test_diff_area_light_photon_matches_traced_neighbours},
    {"diff_directional_light_photon_matches_traced_neighbours",
     test_diff_directional_light_photon_matches_traced_neighbours},
    {"diff_reflect_refract_keep_direction_differentials_perpendicular",
     test_diff_reflect_refract_keep_direction_differentials_perpendicular},
    {"diff_reflect_refract_match_finite_differences_of_the_laws",
     test_diff_reflect_refract_match_finite_differences_of_the_laws},
    {"diff_transfer_lands_in_plane_and_refuses_grazing", test_diff_transfer_lands_in_plane_and_refuses_grazing},
    {"diff_mesh_normal_differential_at_a_footprint_scale_averages_out_noise",
     test_diff_mesh_normal_differential_at_a_footprint_scale_averages_out_noise},
    {"diff_noisy_normals_make_no_streaks", test_diff_noisy_normals_make_no_streaks},
    {"diff_footprint_blur_adds_the_noise_to_the_kernels_covariance",
     test_diff_footprint_blur_adds_the_noise_to_the_kernels_covariance},
    {"diff_noise_gain_is_the_turn_of_the_refracted_and_reflected_ray",
     test_diff_noise_gain_is_the_turn_of_the_refracted_and_reflected_ray},
    {"diff_normal_noise_estimate_matches_the_jitter", test_diff_normal_noise_estimate_matches_the_jitter},
    {"diff_mesh_normal_differential_is_zero_on_flat_and_matches_sphere",
     test_diff_mesh_normal_differential_is_zero_on_flat_and_matches_sphere},
    {"diff_filter_matrix_eq12_equals_general_inverse", test_diff_filter_matrix_eq12_equals_general_inverse},
    {"diff_kernel_splat_integrates_to_photon_flux", test_diff_kernel_splat_integrates_to_photon_flux},
    {"diff_footprint_axes_match_their_definition", test_diff_footprint_axes_match_their_definition},
    {"diff_footprint_area_axis_and_anisotropy_known_values", test_diff_footprint_area_axis_and_anisotropy_known_values},
};

/* tests/test_streams.c - streamed photon mapping (spm) against known
   answers: the uniform caustic under the glass slab (eq. 2 with the
   search circle set by the k-th stream and by R), the flux of the
   streams, its equivalence with photon mapping when a stream is one
   photon, determinism and the map's size. Then the streams of gi's
   global map: where the associated photons land (chi-square against
   the uniform disc), the flux of a stream against its leader's single
   photon, the estimate on a uniform light, single-photon streams against
   the single-photon map, determinism and the map's bytes. Uses the
   scenes and helpers of test_pds.c, test_baselines.c and test_gi.c. */

static long spm_test_streams = 100000;
static int spm_test_k = 100;
static double spm_test_radius = 0.0;
static int spm_test_nfa = 10;

static void spm_tweak(pds_options *o)
{
    o->streams = spm_test_streams;
    o->k = spm_test_k;
    o->max_radius = spm_test_radius;
    o->stream_photons = spm_test_nfa;
}

static int spm_render(const char *text, long streams, int k, double radius, int nfa, int threads, pds_image *img,
                      pds_render_stats *st)
{
    spm_test_streams = streams;
    spm_test_k = k;
    spm_test_radius = radius;
    spm_test_nfa = nfa;
    return photon_render_text(text, PDS_METHOD_SPM, 0, 12.0, PDS_PATHS_CAUSTICS_ONLY, threads, img, st, spm_tweak);
}

/* Under the slab the caustic is uniform, E T^2 a / (1 - R^2 a^2). Eq. 2
   with dA = pi r_k^2 (k streams found) returns it up to the k-th
   neighbour estimate's k / (k - 1) (1 % at k = 100); with dA = pi R^2 (R
   binding, k never reached) it is unbiased. */
static void test_spm_finds_the_analytic_irradiance_of_a_uniform_caustic(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    pds_render_stats st;
    REQUIRE(t, spm_render(slab_scene, 100000, 100, 0.0, 10, 2, &img, &st), "k binding");
    baseline_check_slab(t, &img, 0.02, 0.05, "spm, the k-th stream's circle");
    CHECK(t, st.streams == 100000 && st.photons == 1100000, "%ld streams, %ld photons", st.streams, st.photons);
    pds_image_free(&img);
    /* R = 0.01: some 18 streams inside, where the farthest one's circle
       instead of R's would read 5 % high */
    REQUIRE(t, spm_render(slab_scene, 100000, 100000, 0.01, 10, 2, &img, NULL), "R binding");
    baseline_check_slab(t, &img, 0.01, 0.25, "spm, the circle of radius R");
    pds_image_free(&img);
}

/* eq. 2 at one eye vertex, by hand: 12 streams of energy 2 at distances
   0.01 .. 0.12 on a white (albedo 0.5) floor, and one at 0.005 that
   arrived from below (it counts for the search circle, not the light).
   L = (0.5 / pi) (energy found) / dA with dA = pi r_k^2 when k streams are
   found, pi R^2 when fewer lie within R, and the farthest's circle when
   there is no R. */
static void test_spm_estimate_divides_by_the_search_circle(pds_test_ctx *t)
{
    static const struct { size_t k; double radius, r, energy; } cases[] = {
        {5, DBL_MAX, 0.04, 4 * 2.0},      /* k found: the 5th (0.04) */
        {100, 0.075, 0.075, 7 * 2.0},     /* fewer than k within R: R */
        {100, DBL_MAX, 0.12, 12 * 2.0},   /* no R, fewer than k in the map */
    };
    pds_error err;
    pds_scene *s = scene_from_text("material white diffuse { albedo 0.5 }\nquad { material white }\n", &err);
    pds__eye_vertex v;
    pds__stored_photon ph[13];
    pds__kdtree tree;
    pds__gather g;
    size_t idx[100], n, i;
    double d2[100], one[3] = {1.0, 1.0, 1.0};
    REQUIRE(t, s != NULL, "%s", err.text);
    memset(&v, 0, sizeof v);
    REQUIRE(t, pds__eye_vertex_set(&v, pds_scene_material(s, 0), pds__v(0, 0, 0), pds__v(0, 1, 0), pds__v(0, 1, 0),
                                   pds__v(0, 1, 0), one, 0), "vertex");
    for (i = 0; i < 13; i++) {
        memset(&ph[i], 0, sizeof ph[i]);
        ph[i].pos[0] = i < 12 ? 0.01f * (float)(i + 1) : 0.005f;
        ph[i].dir[1] = i < 12 ? -1.0f : 1.0f;
        ph[i].ng[1] = i < 12 ? 1.0f : -1.0f;
        ph[i].flux[0] = ph[i].flux[1] = ph[i].flux[2] = 2.0f;
        ph[i].index = (long)i;
    }
    REQUIRE(t, pds__kdtree_build(&tree, &ph[0].pos[0], sizeof ph[0] / sizeof(float), 13, &err) == PDS_OK, "tree");
    memset(&g, 0, sizeof g);
    g.scene = s;
    g.photons = ph;
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        double sum[3] = {0, 0, 0}, expect = 0.5 / PDS__PI * cases[i].energy / (PDS__PI * cases[i].r * cases[i].r);
        g.k = cases[i].k;
        g.radius = cases[i].radius;
        n = pds__kdtree_knn(&tree, pds__v(0, 0, 0), g.k, g.radius, idx, d2);
        pds__spm_estimate(&g, &v, idx, d2, n, sum);
        CHECK(t, fabs(sum[1] / expect - 1.0) < 1e-5, "case %lu: L %.6g, expected %.6g", (unsigned long)i, sum[1],
              expect);
    }
    pds__kdtree_free(&tree);
    pds_scene_free(s);
}

/* Every stream that lands gives its energy Ei / (pi R^2) to the eye
   vertices within R (k never reached), so the caustic image holds the
   streams' flux: the light's flux through the slab times both Fresnel
   factors and the absorption (the series of internal reflections), 3 W x
   slab_transmittance, within the pixels' sampling of the discs. */
static void test_spm_streams_carry_the_emitted_flux_times_the_fresnel_factors(pds_test_ctx *t)
{
    static const double sigma[3] = {0.2, 0.5, 1.0};
    pds_image img = {0, 0, NULL};
    double total[3] = {0, 0, 0}, area = pixel_area_on_floor(1.2, 90.0, 24);
    int i, c;
    REQUIRE(t, spm_render(slab_scene, 20000, 100000, 0.1, 10, 2, &img, NULL), "spm");
    for (i = 0; i < 24 * 24; i++)
        for (c = 0; c < 3; c++) total[c] += PDS__PI * img.rgb[3 * i + c] / 0.5 * area;
    for (c = 0; c < 3; c++) {
        double expect = 3.0 * slab_transmittance(sigma[c]);
        CHECK(t, fabs(total[c] / expect - 1.0) < 0.01, "channel %d: flux %.5f W, expected %.5f W", c, total[c],
              expect);
    }
    pds_image_free(&img);
}

/* The paper's concentration: a stream that meets a specular surface first
   travels on as its leader with the whole stream's energy Es = Phi / nfs
   (eq. 1). A caustic stream is therefore one photon of photon mapping
   with nfs photons, and eq. 2 with k streams found is pm's uniform-kernel
   estimate: the images are bit for bit the same, whatever nfa. */
static void pm_uniform_k50(pds_options *o)
{
    o->kernel = PDS_KERNEL_NONE;
    o->k = 50;
}

static void test_spm_caustic_streams_are_pm_photons_of_the_streams_energy(pds_test_ctx *t)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL}, c = {0, 0, NULL};
    pds_render_stats sa, sb, sc;
    size_t n;
    REQUIRE(t, baseline_render(sphere_caustic_scene, PDS_METHOD_PM, 20000, 2, &a, &sa, pm_uniform_k50), "pm");
    REQUIRE(t, spm_render(sphere_caustic_scene, 20000, 50, 0.0, 0, 2, &b, &sb), "spm nfa 0");
    REQUIRE(t, spm_render(sphere_caustic_scene, 20000, 50, 0.0, 10, 2, &c, &sc), "spm nfa 10");
    n = sizeof(float) * 3 * (size_t)a.width * a.height;
    CHECK(t, sa.splatted > 1000 && memcmp(a.rgb, b.rgb, n) == 0, "spm with single-photon streams is pm (%ld stored)",
          sa.splatted);
    CHECK(t, memcmp(b.rgb, c.rgb, n) == 0, "associated photons change no caustic");
    CHECK(t, sb.photons == 20000 && sc.photons == 220000 && sc.streams == 20000 && sc.splatted == sa.splatted,
          "photons %ld and %ld, streams %ld, stored %ld", sb.photons, sc.photons, sc.streams, sc.splatted);
    pds_image_free(&a);
    pds_image_free(&b);
    pds_image_free(&c);
}

static void test_spm_is_identical_for_any_thread_count(pds_test_ctx *t)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    REQUIRE(t, spm_render(sphere_caustic_scene, 20000, 50, 0.3, 10, 1, &a, NULL), "1 thread");
    REQUIRE(t, spm_render(sphere_caustic_scene, 20000, 50, 0.3, 10, 3, &b, NULL), "3 threads");
    CHECK(t, memcmp(a.rgb, b.rgb, sizeof(float) * 3 * (size_t)a.width * a.height) == 0, "bitwise equal");
    pds_image_free(&a);
    pds_image_free(&b);
}

/* The stream map holds one 56-byte record per landed stream (its leader
   with the stream's energy) and its kd-tree: it grows with the streams,
   not with the photons a stream stands for. */
static void test_spm_map_bytes_count_the_stored_streams(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    pds_render_stats a, b, c;
    REQUIRE(t, spm_render(slab_scene, 10000, 50, 0.0, 10, 2, &img, &a), "10k streams");
    pds_image_free(&img);
    REQUIRE(t, spm_render(slab_scene, 10000, 50, 0.0, 100, 2, &img, &b), "10k streams of 101 photons");
    pds_image_free(&img);
    REQUIRE(t, spm_render(slab_scene, 40000, 50, 0.0, 10, 2, &img, &c), "40k streams");
    pds_image_free(&img);
    CHECK(t, a.splatted > 5000 && a.map_bytes >= (size_t)a.splatted * sizeof(pds__stored_photon) &&
                 a.map_bytes < (size_t)a.splatted * (sizeof(pds__stored_photon) + 64),
          "%lu bytes for %ld streams", (unsigned long)a.map_bytes, a.splatted);
    CHECK(t, b.map_bytes == a.map_bytes && b.photons == 101 * a.streams, "nfa 100: %lu bytes, %ld photons",
          (unsigned long)b.map_bytes, b.photons);
    CHECK(t, c.map_bytes > 3 * a.map_bytes, "map %lu -> %lu bytes", (unsigned long)a.map_bytes,
          (unsigned long)c.map_bytes);
}

/* Without a stream count spm emits photons / (nfa + 1) streams, as many
   photons as pm would; out-of-range counts are refused. */
static void test_spm_stream_count_and_its_limits(pds_test_ctx *t)
{
    pds_options opt;
    pds_error err;
    pds_scene *s = scene_from_text(gi_plane_scene, &err);
    REQUIRE(t, s != NULL, "scene: %s", err.message);
    pds_options_default(&opt);
    opt.method = PDS_METHOD_SPM;
    pds_options_resolve(s, &opt); /* the photon count a render uses */
    pds_scene_free(s);
    CHECK(t, opt.streams == 0 && opt.stream_photons == 10 && pds__spm_streams(&opt) == 100000 / 11, "default %ld",
          pds__spm_streams(&opt));
    opt.stream_photons = 0;
    CHECK(t, pds__spm_streams(&opt) == 100000, "nfa 0: %ld", pds__spm_streams(&opt));
    opt.streams = 7;
    CHECK(t, pds__spm_streams(&opt) == 7, "given: %ld", pds__spm_streams(&opt));
    opt.stream_photons = 10001;
    CHECK(t, pds__options_check(&opt, 8, 8, &err) == PDS_ERR_INVALID_ARG &&
                 !strcmp(err.message, "associated photons per stream 10001 is outside 0..10000"),
          "%s", err.message);
    opt.stream_photons = 10;
    opt.streams = LONG_MAX / 2;
    CHECK(t, pds__options_check(&opt, 8, 8, &err) == PDS_ERR_INVALID_ARG && strstr(err.message, "stream count"), "%s",
          err.message);
    CHECK(t, !strcmp(pds_method_name(PDS_METHOD_SPM), "spm"), "name");
}

/* ---------------------------------------------------- gi's streams */

/* gi options with a map of streams of nfa associated photons, radius rs,
   nfs streams. */
static void gi_streams_options(pds_options *o, int threads, long nfs, int nfa, double rs)
{
    gi_options(o, threads);
    o->global_map = PDS_GLOBAL_STREAMS;
    o->stream_photons = nfa;
    o->stream_radius = rs;
    o->global_photons = nfs * (nfa + 1L);
}

/* Pearson's chi-square of counts against equal expected counts. */
static double streams_chi2(const long *count, int bins, long total)
{
    double e = (double)total / bins, x = 0.0;
    int i;
    for (i = 0; i < bins; i++) x += (count[i] - e) * (count[i] - e) / e;
    return x;
}

/* Sect. 3.1, 3a: each associated photon gets "a random point within the
   region surrounding the new position of the leading photon of a radius
   denoting the stream's width". Under a point light over a plane the
   associated photons of every stream must lie within rs of its leader,
   have left from the light towards where they lie (their directions
   deviate from the leader's by the disc's angle), and be uniform by area
   in the disc: (d / rs)^2 and the polar angle each uniform on 20 bins,
   chi-square below 43.82 (19 degrees of freedom, 0.1 % false alarms;
   the seed is fixed). The same data read as uniform in d / rs instead
   must fail that bound by far, so the test can see a wrong law. */
static void test_gi_streams_associated_photons_are_uniform_in_the_stream_disc(pds_test_ctx *t)
{
    enum { BINS = 20 };
    pds_error err;
    pds_scene *s = scene_from_text(gi_plane_scene, &err);
    pds__gi_map g;
    pds_options o;
    long area_bins[BINS] = {0}, angle_bins[BINS] = {0}, radius_bins[BINS] = {0}, n = 0, outside = 0, astray = 0;
    size_t i;
    double rs = 0.3, chi_area, chi_angle, chi_radius;
    pds__v3 light = pds__v(0.0, 1.0, 0.0);
    REQUIRE(t, s, "scene: %s", err.text);
    gi_streams_options(&o, 2, 3000, 20, rs);
    REQUIRE(t, pds__gi_map_build(&g, s, &o, 2, &err) == PDS_OK, "map: %s", err.text);
    CHECK(t, g.nstreams > 1200 && g.nstreams < 1800, "%lu streams landed of 3000 (about half go down)",
          (unsigned long)g.nstreams);
    for (i = 0; i < g.nstreams; i++) {
        const pds__gi_stream *st = &g.streams[i];
        const pds__gi_photon *lead = &g.photons[st->first];
        long j;
        for (j = 1; j < st->count; j++) {
            const pds__gi_photon *p = &g.photons[st->first + j];
            double dx = (double)p->pos[0] - lead->pos[0], dz = (double)p->pos[2] - lead->pos[2];
            double q = (dx * dx + dz * dz) / (rs * rs), phi = atan2(dz, dx) + PDS__PI;
            pds__v3 from_light = pds__normalize(pds__sub(pds__f3_get(p->pos), light));
            int b;
            outside += q > 1.0 + 1e-5 || p->index != lead->index;
            astray += pds__length(pds__sub(from_light, pds__f3_get(p->dir))) > 1e-5;
            b = (int)(q * BINS);
            area_bins[b < BINS ? b : BINS - 1]++;
            b = (int)(sqrt(q) * BINS);
            radius_bins[b < BINS ? b : BINS - 1]++;
            b = (int)(phi / (2.0 * PDS__PI) * BINS);
            angle_bins[b < BINS ? b : BINS - 1]++;
            n++;
        }
    }
    chi_area = streams_chi2(area_bins, BINS, n);
    chi_angle = streams_chi2(angle_bins, BINS, n);
    chi_radius = streams_chi2(radius_bins, BINS, n);
    CHECK(t, n > 20000, "%ld associated photons", n);
    CHECK(t, outside == 0, "%ld associated photons outside their stream's disc", outside);
    CHECK(t, astray == 0, "%ld associated photons did not come from the light", astray);
    CHECK(t, chi_area < 43.82, "(d / rs)^2 not uniform: chi-square %.1f", chi_area);
    CHECK(t, chi_angle < 43.82, "polar angle not uniform: chi-square %.1f", chi_angle);
    CHECK(t, chi_radius > 10.0 * 43.82, "uniform in d / rs would pass too: chi-square %.1f", chi_radius);
    pds__gi_map_free(&g);
    pds_scene_free(s);
}

/* Energy: stream i's leader is photon i of a map of nfs streams of one
   photon (nfa = 0: single photons, the same emission and bounces, stored
   at every diffuse hit; a map of single photons would leave out the
   direct ones, >>gi), so at every diffuse hit the
   stream's photons together must carry exactly that photon's flux, the
   emitted Es = Ez / nfs (eq. 1) times the surface factors on the way
   (albedo over the roulette's survival, Fresnel, absorption): the
   associated photons share it (nfa + 1 ways) or give their share back
   to the leader. In the box with a glass ball and a glossy one. */
static void test_gi_streams_carry_their_leaders_flux(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text(gi_box_scene, &err);
    pds__gi_map g1, gs;
    pds_options o;
    size_t i;
    long shared = 0, bad = 0, moved = 0;
    double worst = 0.0;
    REQUIRE(t, s, "scene: %s", err.text);
    gi_streams_options(&o, 2, 4000, 0, 0.1);
    REQUIRE(t, pds__gi_map_build(&g1, s, &o, 2, &err) == PDS_OK, "single photons: %s", err.text);
    gi_streams_options(&o, 2, 4000, 5, 0.1);
    REQUIRE(t, pds__gi_map_build(&gs, s, &o, 3, &err) == PDS_OK, "streams: %s", err.text);
    REQUIRE(t, gs.nstreams == g1.n && g1.n > 5000, "%lu stream stores, %lu single stores", (unsigned long)gs.nstreams,
            (unsigned long)g1.n);
    for (i = 0; i < gs.nstreams; i++) {
        const pds__gi_stream *st = &gs.streams[i];
        const pds__gi_photon *p1 = &g1.photons[i];
        double sum[3] = {0.0, 0.0, 0.0};
        long j;
        int c;
        for (j = 0; j < st->count; j++)
            for (c = 0; c < 3; c++) sum[c] += gs.photons[st->first + j].flux[c];
        for (c = 0; c < 3; c++) {
            double rel = fabs(sum[c] / p1->flux[c] - 1.0);
            if (rel > worst) worst = rel;
            bad += !(rel < 2e-6);
        }
        moved += memcmp(gs.photons[st->first].pos, p1->pos, sizeof p1->pos) != 0;
        shared += st->count > 1;
    }
    CHECK(t, bad == 0, "%ld stream fluxes differ from their leader's photon, worst by %.3g", bad, worst);
    CHECK(t, moved == 0, "%ld leaders are not where their single photon landed", moved);
    CHECK(t, shared > (long)gs.nstreams / 2, "only %ld of %lu streams kept associated photons", shared,
          (unsigned long)gs.nstreams);
    pds__gi_map_free(&g1);
    pds__gi_map_free(&gs);
    pds_scene_free(s);
}

/* The streams' estimate (eq. 2 over the k nearest leaders, each
   stream's photons inside the circle, cone filter) where the light is
   uniform: a plane of albedo 0.5 under a directional light of
   irradiance 2 W/m^2 over 8 x 8 units. At 25 points away from the edge,
   L = 0.5 / pi x 2, within 8 % each and 2 % on average. */
static void test_gi_streams_estimate_returns_a_uniform_irradiance(pds_test_ctx *t)
{
    static const char text[] =
        "camera { position 0 3 0.000001 look_at 0 0 0 up 0 0 -1 fov 40 resolution 8 8 spp 1 }\n"
        "material floor diffuse { albedo 0.5 }\n"
        "quad { material floor size 20 20 }\n"
        "light directional { direction 0 -1 0 irradiance 2 rect 0 3 0 8 0 0 0 0 8 }\n";
    pds_error err;
    pds_scene *s = scene_from_text(text, &err);
    pds__gi_map g;
    pds_options o;
    int i, j, bad = 0, n = 0;
    double exact = 0.5 / PDS__PI * 2.0, sum = 0.0, worst = 0.0;
    pds__v3 up = pds__v(0.0, 1.0, 0.0);
    REQUIRE(t, s, "scene: %s", err.text);
    gi_streams_options(&o, 2, 20000, 10, 0.25);
    o.global_k = 100;
    REQUIRE(t, pds__gi_map_build(&g, s, &o, 2, &err) == PDS_OK, "map: %s", err.text);
    CHECK(t, g.nstreams == 20000 && g.n > 210000, "%lu streams, %lu photons", (unsigned long)g.nstreams,
          (unsigned long)g.n);
    for (i = -2; i <= 2; i++) {
        for (j = -2; j <= 2; j++) {
            double L[3], rel;
            pds__gi_radiance(&g, &s->materials.items[0], pds__v(0.5 * i, 0.0, 0.5 * j),
                             pds__normalize(pds__v(0.3, 1.0, -0.2)), up, up, 0.0, L);
            rel = fabs(L[1] / exact - 1.0);
            if (rel > worst) worst = rel;
            bad += rel > 0.08;
            sum += L[1];
            n++;
        }
    }
    CHECK(t, bad == 0, "%d of %d estimates off by more than 8%%, worst %.4f", bad, n, worst);
    CHECK(t, fabs(sum / n / exact - 1.0) < 0.02, "mean estimate / exact = %.4f", sum / n / exact);
    pds__gi_map_free(&g);
    pds_scene_free(s);
}

/* Streams of one photon (nfa = 0) are single photons: every photon its
   own stream, and the streams' estimate (eq. 2) the single photons'
   (Jensen's eq. 3 with the cone filter): the same k nearest, the same
   cone weights, so the same radiance but for the order of the sums. The
   map of streams read as one of single photons (the same photons, in the
   same order as the leaders its kd-tree holds) gives the single-photon
   estimate; the two are compared at every 25th stored photon of the box.
   (A map of single photons leaves out the direct photons, which a map of
   streams keeps, >>gi; so their renders differ.) */
static void test_gi_streams_of_one_photon_are_the_single_photon_map(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text(gi_box_scene, &err);
    pds__gi_map gs, single;
    pds_material white;
    pds_options o;
    size_t i;
    long ones = 0, compared = 0;
    double worst = 0.0, total = 0.0;
    REQUIRE(t, s, "scene: %s", err.text);
    gi_streams_options(&o, 2, 20000, 0, 0.05);
    REQUIRE(t, pds__gi_map_build(&gs, s, &o, 2, &err) == PDS_OK, "map: %s", err.text);
    for (i = 0; i < gs.nstreams; i++) ones += gs.streams[i].count == 1 && gs.streams[i].first == (long)i;
    CHECK(t, gs.nstreams == gs.n && ones == (long)gs.n && gs.n > 20000, "%lu streams of one photon of %lu photons",
          (unsigned long)ones, (unsigned long)gs.n);
    single = gs;
    single.streams = NULL;
    single.nstreams = 0;
    single.reach = 0.0;
    memset(&white, 0, sizeof white);
    white.type = PDS_MAT_DIFFUSE;
    white.albedo[0] = white.albedo[1] = white.albedo[2] = 1.0;
    for (i = 0; i < gs.n && ones == (long)gs.n; i += 25) {
        pds__v3 x = pds__f3_get(gs.photons[i].pos), n = pds__f3_get(gs.photons[i].ng);
        double a[3], b[3];
        int c;
        pds__gi_radiance(&single, &white, x, n, n, n, 0.0, a);
        pds__gi_radiance(&gs, &white, x, n, n, n, 0.0, b);
        for (c = 0; c < 3; c++) {
            worst = fmax(worst, fabs(a[c] - b[c]) / (1e-9 + a[c]));
            total += a[c];
        }
        compared++;
    }
    CHECK(t, compared > 800 && total > 0.0 && worst < 1e-5, "%ld points, worst relative difference %g", compared, worst);
    pds__gi_map_free(&gs);
    pds_scene_free(s);
}

/* The same image bit for bit on 1 and 3 threads, and the same counts;
   the map's bytes are its photons, its stream records and the kd-tree
   over the leaders (not over every photon), plus the shadow map. */
static void test_gi_streams_are_identical_for_any_thread_count_and_counted(pds_test_ctx *t)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    pds_render_stats sa, sb;
    pds_options o;
    size_t node = 3 * sizeof(float) + sizeof(size_t) + 1, expect;
    gi_streams_options(&o, 1, 4000, 10, 0.1);
    REQUIRE(t, render_text(gi_box_scene, &o, &a, &sa), "1 thread");
    o.threads = 3;
    REQUIRE(t, render_text(gi_box_scene, &o, &b, &sb), "3 threads");
    CHECK(t, memcmp(a.rgb, b.rgb, sizeof(float) * 3 * (size_t)a.width * a.height) == 0, "bitwise equal");
    CHECK(t, sa.global_stored == sb.global_stored && sa.global_streams == sb.global_streams &&
                 sa.global_streams > 4000 && sa.global_stored > 5 * sa.global_streams &&
                 sa.gather_rays == sb.gather_rays && sa.map_bytes == sb.map_bytes,
          "counts differ: stored %ld/%ld, streams %ld/%ld", sa.global_stored, sb.global_stored, sa.global_streams,
          sb.global_streams);
    expect = (size_t)sa.global_stored * sizeof(pds__gi_photon) +
             (size_t)sa.global_streams * (sizeof(pds__gi_stream) + node) +
             (size_t)sa.shadow_stored * (sizeof(pds__gi_shadow_photon) + node); /* no precomputed irradiance:
                                                                                   too few gathers for it */
    CHECK(t, sa.map_bytes == expect, "map_bytes %lu, expected %lu", (unsigned long)sa.map_bytes,
          (unsigned long)expect);
    pds_image_free(&a);
    pds_image_free(&b);
}

static void test_gi_streams_reject_bad_options(pds_test_ctx *t)
{
    pds_options o;
    pds_error err;
    gi_streams_options(&o, 1, 100, 10, 0.1);
    o.global_map = (pds_global_map)2;
    CHECK(t, pds__options_check(&o, 8, 8, &err) == PDS_ERR_INVALID_ARG && !strcmp(err.message, "unknown global map 2"),
          "%s", err.message);
    gi_streams_options(&o, 1, 100, 10, -1.0);
    CHECK(t, pds__options_check(&o, 8, 8, &err) == PDS_ERR_INVALID_ARG && strstr(err.message, "stream radius"), "%s",
          err.message);
    o.stream_radius = nan("");
    CHECK(t, pds__options_check(&o, 8, 8, &err) == PDS_ERR_INVALID_ARG, "NaN radius");
}

/* ---------------------------------------------------- spm's full image */

/* spm's full image in the small box of test_gi.c (glass and glossy balls,
   a quad light): 24 x 24 pixels, 2 samples, 4 gathers, 1,000 caustic
   streams and 1,000 global streams of 6 photons, rs 0.1 (the box is 2
   units). */
static void spm_full_options(pds_options *o, int threads)
{
    gi_options(o, threads);
    o->method = PDS_METHOD_SPM;
    o->spp = 2;
    o->gather = 4;
    o->stream_photons = 5;
    o->photons = 6000;        /* 1,000 caustic streams */
    o->global_photons = 6000; /* 1,000 global streams */
    o->stream_radius = 0.1;
    o->k = 30;
    o->global_k = 30;
}

static int spm_same_pixels(const pds_image *a, const pds_image *b)
{
    return a->width == b->width && a->height == b->height &&
           memcmp(a->rgb, b->rgb, sizeof(float) * 3 * (size_t)a->width * (size_t)a->height) == 0;
}

/* The contract of pds__spm_as_gi: spm without --caustics-only is the gi
   render with a global map of streams and spm's caustic streams, all
   other options as given, bit for bit; a stream count given is nfs of
   both maps (the global map then emits nfs (nfa + 1) photons whatever
   global_photons says). And it is streams: a global map of single photons
   gives another image. */
static void test_spm_full_image_is_gi_with_streams_and_spm_caustics(pds_test_ctx *t)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL}, c = {0, 0, NULL};
    pds_render_stats sa, sb;
    pds_options o, g;
    size_t i, n;
    double total = 0.0;
    spm_full_options(&o, 2);
    g = o;
    g.method = PDS_METHOD_GI;
    g.caustics = PDS_METHOD_SPM;
    g.global_map = PDS_GLOBAL_STREAMS;
    REQUIRE(t, render_text(gi_box_scene, &o, &a, &sa), "spm");
    REQUIRE(t, render_text(gi_box_scene, &g, &b, &sb), "gi, streams, spm caustics");
    n = (size_t)a.width * a.height * 3;
    for (i = 0; i < n; i++) total += a.rgb[i];
    CHECK(t, total > 0.0 && spm_same_pixels(&a, &b), "spm's full image is not gi's (mean %g)", total / (double)n);
    CHECK(t, sa.streams == 1000 && sa.photons == 6000 && sa.global_streams == sb.global_streams &&
                 sa.global_streams > 1000 && sa.global_stored == sb.global_stored && sa.gather_rays == sb.gather_rays &&
                 sa.gather_rays > 0 && sa.map_bytes == sb.map_bytes,
          "streams %ld, photons %ld, global streams %ld/%ld, stored %ld/%ld, gathers %ld/%ld", sa.streams, sa.photons,
          sa.global_streams, sb.global_streams, sa.global_stored, sb.global_stored, sa.gather_rays, sb.gather_rays);
    pds_image_free(&a);
    pds_image_free(&b);
    /* nfs given: 700 caustic and 700 global streams (4,200 photons each) */
    o.streams = 700;
    o.global_photons = 123456; /* not used: nfs decides */
    g.streams = 700;
    g.global_photons = 700 * 6;
    REQUIRE(t, render_text(gi_box_scene, &o, &a, &sa), "spm, 700 streams");
    REQUIRE(t, render_text(gi_box_scene, &g, &b, &sb), "gi, 700 streams");
    CHECK(t, spm_same_pixels(&a, &b) && sa.streams == 700 && sa.global_streams == sb.global_streams,
          "with nfs given: streams %ld, global streams %ld/%ld", sa.streams, sa.global_streams, sb.global_streams);
    g.global_map = PDS_GLOBAL_PHOTONS;
    REQUIRE(t, render_text(gi_box_scene, &g, &c, NULL), "gi, single photons");
    CHECK(t, !spm_same_pixels(&a, &c), "a global map of single photons gives spm's image");
    pds_image_free(&a);
    pds_image_free(&b);
    pds_image_free(&c);
}

/* rs places a stream's associated photons about its leader's diffuse
   hits: it changes the full image (the global map) and not one bit of the
   caustics-only image, nor do the global map's and the gather's options,
   since a caustic stream has lost its associated photons at its first
   specular hit. */
static void test_spm_stream_radius_shapes_the_full_image_not_the_caustics(pds_test_ctx *t)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    pds_render_stats sa, sb;
    pds_options o;
    size_t i, n, differ = 0;
    spm_full_options(&o, 2);
    o.stream_radius = 0.05;
    REQUIRE(t, render_text(gi_box_scene, &o, &a, &sa), "rs 0.05");
    o.stream_radius = 0.4;
    REQUIRE(t, render_text(gi_box_scene, &o, &b, &sb), "rs 0.4");
    n = (size_t)a.width * a.height * 3;
    for (i = 0; i < n; i++) differ += a.rgb[i] != b.rgb[i];
    CHECK(t, differ > n / 4, "rs 0.05 and 0.4: only %lu of %lu values differ", (unsigned long)differ,
          (unsigned long)n);
    CHECK(t, sa.global_streams == sb.global_streams && sa.global_stored != sb.global_stored,
          "the streams are the same, their photons not: stored %ld and %ld", sa.global_stored, sb.global_stored);
    pds_image_free(&a);
    pds_image_free(&b);
    o.paths = PDS_PATHS_CAUSTICS_ONLY;
    o.stream_radius = 0.05;
    REQUIRE(t, render_text(gi_box_scene, &o, &a, &sa), "caustics only, rs 0.05");
    o.stream_radius = 0.4;
    o.global_photons = 50000;
    o.global_k = 7;
    o.gather = 1;
    o.gather_mix = 1.0;
    o.shadow_photons = 0;
    REQUIRE(t, render_text(gi_box_scene, &o, &b, &sb), "caustics only, rs 0.4 and other gi options");
    CHECK(t, sa.splatted > 100 && spm_same_pixels(&a, &b), "rs or gi's options changed the caustics (%ld stored)",
          sa.splatted);
    CHECK(t, sa.global_stored == 0 && sa.gather_rays == 0, "caustics only built a global map (%ld stored)",
          sa.global_stored);
    pds_image_free(&a);
    pds_image_free(&b);
}

/* ALL = NO_CAUSTICS + CAUSTICS_ONLY for spm in expectation: its full
   image gathers the caustic streams at gi's eye vertices (one branch at
   glass), --caustics-only at the photon methods' (both branches), so
   their caustic light agrees in total but not pixel by pixel. The
   branch choices of 1,152 camera samples move the full image's caustic
   total by up to 9 % (seeds 0 to 5 here: 0.95 to 1.09 of the caustics
   only image's); caustics counted twice, or not at all, would be 100 %
   off, so the bound is 20 %. */
static void test_spm_full_image_holds_the_caustics_only_light(pds_test_ctx *t)
{
    pds_image all = {0, 0, NULL}, nc = {0, 0, NULL}, co = {0, 0, NULL};
    pds_options o;
    size_t i, n;
    double full = 0.0, rest = 0.0, caustic = 0.0;
    spm_full_options(&o, 2);
    o.photons = 60000; /* 10,000 caustic streams */
    REQUIRE(t, gi_box_three_ways(&o, &all, &nc, &co, NULL), "render");
    n = (size_t)all.width * all.height * 3;
    for (i = 0; i < n; i++) {
        full += all.rgb[i];
        rest += nc.rgb[i];
        caustic += co.rgb[i];
    }
    CHECK(t, caustic > 0.01 * full && fabs((full - rest) / caustic - 1.0) < 0.2,
          "the full image's caustic light %g, caustics only %g (the rest %g)", full - rest, caustic, rest);
    pds_image_free(&all);
    pds_image_free(&nc);
    pds_image_free(&co);
}

static void test_spm_full_image_is_identical_for_any_thread_count(pds_test_ctx *t)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    pds_options o;
    spm_full_options(&o, 1);
    REQUIRE(t, render_text(gi_box_scene, &o, &a, NULL), "1 thread");
    o.threads = 3;
    REQUIRE(t, render_text(gi_box_scene, &o, &b, NULL), "3 threads");
    CHECK(t, spm_same_pixels(&a, &b), "bitwise equal");
    pds_image_free(&a);
    pds_image_free(&b);
}

/* rs must be a distance (0: the scene's largest side / 16); a stream
   count must fit the global map's 1e9 photons in the full image only. */
static void test_spm_refuses_bad_stream_radii_and_counts(pds_test_ctx *t)
{
    static const double bad[] = {-1.0, 2e12, -1e-300};
    pds_options o;
    pds_error err;
    size_t i;
    spm_full_options(&o, 1);
    for (i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        o.stream_radius = bad[i];
        CHECK(t, pds__options_check(&o, 8, 8, &err) == PDS_ERR_INVALID_ARG &&
                     !strcmp(err.message, "the stream radius must be between 0 and 1e12"),
              "rs %g: %s", bad[i], err.message);
    }
    o.stream_radius = nan("");
    CHECK(t, pds__options_check(&o, 8, 8, &err) == PDS_ERR_INVALID_ARG, "NaN radius");
    o.stream_radius = 0.0;
    CHECK(t, pds__options_check(&o, 8, 8, &err) == PDS_OK, "rs 0 (automatic): %s", err.message);
    o.streams = 1000000000L / 6 + 1;
    CHECK(t, pds__options_check(&o, 8, 8, &err) == PDS_ERR_INVALID_ARG &&
                 !strcmp(err.message, "stream count 166666667 is outside 0..166666666: spm's full image also emits "
                                      "that many streams of 6 photons into its global map, at most 1e9 photons"),
          "%s", err.message);
    o.paths = PDS_PATHS_CAUSTICS_ONLY;
    CHECK(t, pds__options_check(&o, 8, 8, &err) == PDS_OK, "caustics only: %s", err.message);
}

#ifdef PDS_TEST_POSIX
/* The pds tool: rs is an spm option of the full image (a note, not a
   refusal, with --caustics-only, saying why), refused when it is not a
   positive distance, and sweepable (two values, two different errors);
   sweeping it with --caustics-only is refused. A race of spm against the
   gi render it is gives both the same error; rs set for spm in a race of
   caustics is refused. */
static void test_spm_cli_takes_the_stream_radius(pds_test_ctx *t)
{
    static const char *const bad[][2] = {
        {"-1", "pds render: --stream-radius needs a positive distance in scene units, got '-1'\n"},
        {"0", "pds render: --stream-radius needs a positive distance in scene units, got '0'\n"},
        {"wide", "pds render: --stream-radius needs a positive distance in scene units, got 'wide'\n"},
    };
    static const char small[] = "--method spm --streams 300 --stream-photons 4 --global-k 20 --gather 2 "
                                "--res 16x12 --spp 1 --quiet";
    char out[32768], args[1024], dir[256], ref[256], png[256], path[300], *csv, *line;
    size_t i;
    double rmse[2] = {-1.0, -1.0};
    harness_path(png, sizeof png, "spm.png");
    harness_path(ref, sizeof ref, "spm-ref.pfm");
    harness_path(dir, sizeof dir, "spm-sweep");
    for (i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        snprintf(args, sizeof args, "render tests/golden/glass.scene %s --stream-radius %s -o %s", small, bad[i][0],
                 png);
        CHECK(t, cli_run(args, out, sizeof out) == 2 && strstr(out, bad[i][1]) == out, "rs %s: %s", bad[i][0], out);
    }
    snprintf(args, sizeof args, "render tests/golden/glass.scene %s --stream-radius 0.2 -o %s", small, png);
    CHECK(t, cli_run(args, out, sizeof out) == 0 && !strstr(out, "note:") && strstr(out, " stream_radius=0.2 "),
          "%s", out);
    snprintf(args, sizeof args, "render tests/golden/glass.scene %s --stream-radius 0.2 --caustics-only -o %s", small,
             png);
    CHECK(t, cli_run(args, out, sizeof out) == 0 &&
                 strstr(out, "pds render: note: --stream-radius has no effect with --method spm and --caustics-only "
                             "(rs spreads a stream's associated photons about its leader's diffuse hits, and a "
                             "caustic stream loses them at its first specular hit)\n") &&
                 !strstr(out, "stream_radius="),
          "%s", out);
    /* the reference: the same full image with rs 0.05 */
    snprintf(args, sizeof args, "render tests/golden/glass.scene %s --stream-radius 0.05 -o %s", small, ref);
    REQUIRE(t, cli_run(args, out, sizeof out) == 0, "%s", out);
    snprintf(args, sizeof args,
             "sweep tests/golden/glass.scene %s --param stream-radius --values 0.05,0.4 --ref %s -o %s", small, ref,
             dir);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "%s", out);
    snprintf(path, sizeof path, "%s/sweep.csv", dir);
    csv = harness_slurp(path, NULL);
    /* method,param,value,photons,spp,passes,map_bytes,rmse,...: the 8th field */
    for (line = csv ? strchr(csv, '\n') : NULL, i = 0; line && line[1] && i < 2; line = strchr(line + 1, '\n'), i++) {
        const char *f = line + 1;
        int k;
        for (k = 0; k < 7 && f; k++) f = strchr(f, ',') ? strchr(f, ',') + 1 : NULL;
        rmse[i] = f ? atof(f) : -1.0;
    }
    CHECK(t, rmse[0] == 0.0 && rmse[1] > 0.0, "sweep of rs: RMSE %g and %g against rs 0.05's image\n%s", rmse[0],
          rmse[1], csv ? csv : out);
    free(csv);
    snprintf(args, sizeof args, "sweep tests/golden/glass.scene %s --caustics-only --param stream-radius --values 0.1 "
             "--ref %s -o %s", small, ref, dir);
    CHECK(t, cli_run(args, out, sizeof out) == 2 &&
                 strstr(out, "pds sweep: --param stream-radius has no effect with --method spm and --caustics-only"),
          "%s", out);
    harness_rmtree(dir);
    /* race: spm's full image and the gi render it is give the same error */
    snprintf(args, sizeof args, "race tests/golden/glass.scene %s --photons 1500 --ref %s -o %s --methods "
             "spm:stream-radius=0.4,gi:global-map=streams:caustics=spm:stream-radius=0.4:global-photons=1500",
             small + strlen("--method spm "), ref, dir);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "%s", out);
    {
        const char *a = strstr(out, "race method=spm "), *b = strstr(out, "race method=gi ");
        const char *ra = a ? strstr(a, " rmse=") : NULL, *rb = b ? strstr(b, " rmse=") : NULL;
        CHECK(t, ra && rb && atof(ra + 6) > 0.0 && !strncmp(ra, rb, 16), "race: spm and gi differ: %s", out);
    }
    harness_rmtree(dir);
    snprintf(args, sizeof args, "race tests/golden/glass.scene %s --caustics-only --photons 1500 --ref %s -o %s "
             "--methods spm:stream-radius=0.4", small + strlen("--method spm "), ref, dir);
    CHECK(t, cli_run(args, out, sizeof out) == 2 &&
                 strstr(out, "pds race: --methods: stream-radius has no effect with spm and --caustics-only"),
          "%s", out);
    harness_rmtree(dir);
    remove(ref);
    remove(png);
}
#endif

static const pds_test_case tests_streams[] = {
    {"spm_finds_the_analytic_irradiance_of_a_uniform_caustic",
     test_spm_finds_the_analytic_irradiance_of_a_uniform_caustic},
    {"spm_estimate_divides_by_the_search_circle", test_spm_estimate_divides_by_the_search_circle},
    {"spm_streams_carry_the_emitted_flux_times_the_fresnel_factors",
     test_spm_streams_carry_the_emitted_flux_times_the_fresnel_factors},
    {"spm_caustic_streams_are_pm_photons_of_the_streams_energy",
     test_spm_caustic_streams_are_pm_photons_of_the_streams_energy},
    {"spm_is_identical_for_any_thread_count", test_spm_is_identical_for_any_thread_count},
    {"spm_map_bytes_count_the_stored_streams", test_spm_map_bytes_count_the_stored_streams},
    {"spm_stream_count_and_its_limits", test_spm_stream_count_and_its_limits},
    {"gi_streams_associated_photons_are_uniform_in_the_stream_disc",
     test_gi_streams_associated_photons_are_uniform_in_the_stream_disc},
    {"gi_streams_carry_their_leaders_flux", test_gi_streams_carry_their_leaders_flux},
    {"gi_streams_estimate_returns_a_uniform_irradiance", test_gi_streams_estimate_returns_a_uniform_irradiance},
    {"gi_streams_of_one_photon_are_the_single_photon_map", test_gi_streams_of_one_photon_are_the_single_photon_map},
    {"gi_streams_are_identical_for_any_thread_count_and_counted",
     test_gi_streams_are_identical_for_any_thread_count_and_counted},
    {"gi_streams_reject_bad_options", test_gi_streams_reject_bad_options},
    {"spm_full_image_is_gi_with_streams_and_spm_caustics", test_spm_full_image_is_gi_with_streams_and_spm_caustics},
    {"spm_stream_radius_shapes_the_full_image_not_the_caustics",
     test_spm_stream_radius_shapes_the_full_image_not_the_caustics},
    {"spm_full_image_holds_the_caustics_only_light", test_spm_full_image_holds_the_caustics_only_light},
    {"spm_full_image_is_identical_for_any_thread_count", test_spm_full_image_is_identical_for_any_thread_count},
    {"spm_refuses_bad_stream_radii_and_counts", test_spm_refuses_bad_stream_radii_and_counts},
#ifdef PDS_TEST_POSIX
    {"spm_cli_takes_the_stream_radius", test_spm_cli_takes_the_stream_radius},
#endif
};

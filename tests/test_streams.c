/* tests/test_streams.c - streamed photon mapping (spm) against known
   answers: the uniform caustic under the glass slab (eq. 2 with the
   search circle set by the k-th stream and by R), the flux of the
   streams, its equivalence with photon mapping when a stream is one
   photon, determinism and the map's size. Uses the scenes and helpers of
   test_pds.c and test_baselines.c. */

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
    pds_options_default(&opt);
    CHECK(t, opt.streams == 0 && opt.stream_photons == 10 && pds__spm_streams(&opt) == 100000 / 11, "default %ld",
          pds__spm_streams(&opt));
    opt.stream_photons = 0;
    CHECK(t, pds__spm_streams(&opt) == 100000, "nfa 0: %ld", pds__spm_streams(&opt));
    opt.streams = 7;
    CHECK(t, pds__spm_streams(&opt) == 7, "given: %ld", pds__spm_streams(&opt));
    opt.method = PDS_METHOD_SPM;
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
};

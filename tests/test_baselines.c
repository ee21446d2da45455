/* tests/test_baselines.c - the methods PDS is measured against: photon
   mapping and fixed-radius splatting, on the same known answers. Uses the
   slab scene and helpers of test_pds.c. */

static int baseline_render(const char *text, pds_method method, long photons, int threads, pds_image *img,
                           pds_render_stats *st, void (*tweak)(pds_options *))
{
    return photon_render_text(text, method, photons, 12.0, PDS_PATHS_CAUSTICS_ONLY, threads, img, st, tweak);
}

/* Under the slab the caustic is uniform, E T^2 a / (1 - R^2 a^2): the
   k-nearest-neighbour estimate with the cone filter (normalised for a
   uniform 2-D density) must find it, on average and per pixel. */
static void baseline_check_slab(pds_test_ctx *t, const pds_image *img, double mean_tol, double pixel_tol,
                                const char *what)
{
    static const double sigma[3] = {0.2, 0.5, 1.0};
    int x, y, c, n = 0, bad = 0;
    double sum[3] = {0, 0, 0}, worst = 0.0;
    for (y = 0; y < 24; y++) {
        for (x = 0; x < 24; x++) {
            pds__v3 p = floor_point(1.2, 90.0, 24, x, y);
            if (fabs(p.x) > 0.3 || fabs(p.z) > 0.3) continue;
            n++;
            for (c = 0; c < 3; c++) {
                double expect = 0.5 / PDS__PI * 3.0 * slab_transmittance(sigma[c]);
                double rel = fabs(img->rgb[3 * (y * 24 + x) + c] / expect - 1.0);
                sum[c] += img->rgb[3 * (y * 24 + x) + c] / expect;
                if (rel > worst) worst = rel;
                bad += rel > pixel_tol;
            }
        }
    }
    for (c = 0; c < 3; c++)
        CHECK(t, fabs(sum[c] / n - 1.0) < mean_tol, "%s: channel %d mean ratio %.4f", what, c, sum[c] / n);
    CHECK(t, bad == 0, "%s: %d pixel channels off by more than %g, worst %.4f", what, bad, pixel_tol, worst);
}

static void pm_gaussian(pds_options *o) { o->kernel = PDS_KERNEL_GAUSSIAN; }
static void pm_uniform(pds_options *o) { o->kernel = PDS_KERNEL_NONE; }

static void test_pm_finds_the_analytic_irradiance_of_a_uniform_caustic(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    pds_render_stats st;
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PM, 100000, 2, &img, &st, NULL), "pm cone");
    baseline_check_slab(t, &img, 0.02, 0.05, "cone");
    CHECK(t, st.map_bytes >= (size_t)st.splatted * sizeof(pds__stored_photon) && st.splatted > 50000,
          "map %lu bytes for %ld photons", (unsigned long)st.map_bytes, st.splatted);
    pds_image_free(&img);
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PM, 100000, 2, &img, NULL, pm_gaussian), "pm gaussian");
    baseline_check_slab(t, &img, 0.02, 0.05, "gaussian");
    pds_image_free(&img);
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PM, 100000, 2, &img, NULL, pm_uniform), "pm none");
    baseline_check_slab(t, &img, 0.02, 0.05, "none");
    pds_image_free(&img);
}

/* The filters' normalisations are their integrals over the unit disc:
   cone 1/3 (k_cone = 1: 1 - 2/(3k)), Gaussian 0.531 (Jensen's filter, a = 0.918, b = 1.953), by
   midpoint quadrature in r. */
static void test_pm_filter_normalisations_are_the_filters_integrals(pds_test_ctx *t)
{
    pds_kernel k[3] = {PDS_KERNEL_CONE, PDS_KERNEL_GAUSSIAN, PDS_KERNEL_NONE};
    int i, j;
    for (i = 0; i < 3; i++) {
        double integral = 0.0, n = 100000;
        for (j = 0; j < (int)n; j++) {
            double r = (j + 0.5) / n;
            integral += pds__pm_weight(k[i], r * r, 1.0) * 2.0 * r / n; /* 2 pi r dr / pi */
        }
        CHECK_NEAR(t, pds__pm_norm(k[i]), integral, 1e-8);
    }
    CHECK_NEAR(t, pds__gauss_filter_norm(), 0.5312, 5e-4);
}

/* Memory of photon mapping grows with the photon count (the map), unlike
   PDS's. */
static void test_pm_map_grows_with_the_photon_count(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    pds_render_stats a, b;
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PM, 10000, 2, &img, &a, NULL), "10k");
    pds_image_free(&img);
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PM, 40000, 2, &img, &b, NULL), "40k");
    pds_image_free(&img);
    CHECK(t, b.map_bytes > 3 * a.map_bytes, "map %lu -> %lu bytes", (unsigned long)a.map_bytes, (unsigned long)b.map_bytes);
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PDS, 10000, 2, &img, &a, NULL), "pds 10k");
    pds_image_free(&img);
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PDS, 40000, 2, &img, &b, NULL), "pds 40k");
    pds_image_free(&img);
    CHECK(t, a.memory_bytes == b.memory_bytes && a.map_bytes == 0, "pds memory %lu vs %lu",
          (unsigned long)a.memory_bytes, (unsigned long)b.memory_bytes);
}

static void splat_radius_005(pds_options *o) { o->radius = 0.05; }

/* Fixed-radius splatting conserves the flux like PDS (its kernel is
   normalised over its disc) and finds the uniform caustic. */
static void test_splat_conserves_flux_and_finds_the_uniform_caustic(pds_test_ctx *t)
{
    static const double sigma[3] = {0.2, 0.5, 1.0};
    pds_image img = {0, 0, NULL};
    double total[3] = {0, 0, 0}, area = pixel_area_on_floor(1.2, 90.0, 24);
    int i, c;
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_SPLAT, 100000, 2, &img, NULL, splat_radius_005), "splat");
    for (i = 0; i < 24 * 24; i++)
        for (c = 0; c < 3; c++) total[c] += PDS__PI * img.rgb[3 * i + c] / 0.5 * area;
    for (c = 0; c < 3; c++) {
        double expect = 3.0 * slab_transmittance(sigma[c]);
        CHECK(t, fabs(total[c] / expect - 1.0) < 0.01, "channel %d: flux %.5f W, expected %.5f W", c, total[c], expect);
    }
    baseline_check_slab(t, &img, 0.02, 0.05, "splat");
    pds_image_free(&img);
}

static void test_baselines_are_identical_for_any_thread_count(pds_test_ctx *t)
{
    static const pds_method methods[4] = {PDS_METHOD_PM, PDS_METHOD_SPLAT, PDS_METHOD_PDM, PDS_METHOD_PPM};
    int m;
    for (m = 0; m < 4; m++) {
        pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
        REQUIRE(t, baseline_render(sphere_caustic_scene, methods[m], 20000, 1, &a, NULL, NULL), "1 thread");
        REQUIRE(t, baseline_render(sphere_caustic_scene, methods[m], 20000, 3, &b, NULL, NULL), "3 threads");
        CHECK(t, memcmp(a.rgb, b.rgb, sizeof(float) * 3 * (size_t)a.width * a.height) == 0, "%s: bitwise equal",
              pds_method_name(methods[m]));
        pds_image_free(&a);
        pds_image_free(&b);
    }
}

/* The largest per-channel difference of two images of one size, and the
   largest value of the first (the scale the difference is judged on). */
static double baseline_worst_difference(const pds_image *a, const pds_image *b, double *peak)
{
    size_t i, n = (size_t)a->width * a->height * 3;
    double worst = 0.0;
    *peak = 0.0;
    for (i = 0; i < n; i++) {
        double d = fabs((double)a->rgb[i] - b->rgb[i]);
        if (d > worst) worst = d;
        if (a->rgb[i] > *peak) *peak = a->rgb[i];
    }
    return worst;
}

static void pdm_big_cap(pds_options *o) { o->max_photons = 100000; }

/* Photon differential mapping evaluates eqs. 10-12 by gathering instead of
   splatting: with a cap that never binds, the image is PDS's (up to the
   fixed-point rounding of each splat). */
static void test_pdm_gathers_the_same_image_pds_splats(pds_test_ctx *t)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    pds_render_stats sa, sb;
    double worst, peak;
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PDS, 20000, 2, &a, &sa, NULL), "pds");
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PDM, 20000, 2, &b, &sb, pdm_big_cap), "pdm");
    worst = baseline_worst_difference(&a, &b, &peak);
    CHECK(t, peak > 0.0 && worst <= 1e-5 * peak, "largest difference %g (peak %g)", worst, peak);
    CHECK(t, sb.splatted == sa.splatted && sb.map_bytes > 0, "stored %ld photons, pds splatted %ld", sb.splatted,
          sa.splatted);
    pds_image_free(&a);
    pds_image_free(&b);
}

/* The progressive update of one vertex against the published recurrence
   (Hachisuka et al. 2008): 10 photons inside R in pass 1, then the photons
   inside the shrunken radius in pass 2. */
static void test_ppm_updates_follow_the_published_recurrence(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text("material white diffuse { albedo 0.5 }\nquad { material white }\n", &err);
    pds__eye_vertex v;
    pds__stored_photon ph[12];
    pds__ppm_state st;
    pds__ppm_job job;
    pds__kdtree tree;
    double alpha = 0.7, r2, n, tau, grow;
    int i, inside;
    REQUIRE(t, s != NULL, "%s", err.text);
    memset(&v, 0, sizeof v);
    {
        double one[3] = {1.0, 1.0, 1.0};
        REQUIRE(t, pds__eye_vertex_set(&v, pds_scene_material(s, 0), pds__v(0, 0, 0), pds__v(0, 1, 0), pds__v(0, 1, 0),
                                       pds__v(0, 1, 0), one, 0), "vertex");
    }
    for (i = 0; i < 12; i++) {
        /* photons at distances 0.01 .. 0.12 from the vertex, flux 2 each */
        memset(&ph[i], 0, sizeof ph[i]);
        ph[i].pos[0] = 0.01f * (float)(i + 1);
        ph[i].dir[1] = -1.0f;
        ph[i].ng[1] = 1.0f;
        ph[i].flux[0] = ph[i].flux[1] = ph[i].flux[2] = 2.0f;
        ph[i].index = i;
    }
    REQUIRE(t, pds__kdtree_build(&tree, &ph[0].pos[0], sizeof ph[0] / sizeof(float), 12, &err) == PDS_OK, "tree");
    memset(&job, 0, sizeof job);
    job.scene = s;
    job.v = &v;
    job.state = &st;
    job.nv = 1;
    job.photons = ph;
    job.tree = &tree;
    job.alpha = alpha;
    job.photon_scale = 1.0;
    st.r2 = 0.105 * 0.105;
    st.n = 0.0;
    st.tau[0] = st.tau[1] = st.tau[2] = 0.0;
    r2 = st.r2;
    n = 0.0;
    tau = 0.0;
    for (i = 0; i < 2; i++) {
        int k;
        pds__mutex_init(&job.lock);
        job.next = 0;
        pds__ppm_worker(&job);
        pds__mutex_destroy(&job.lock);
        /* by hand: M photons within the radius, Phi_M = M * fr * flux */
        for (inside = 0, k = 0; k < 12; k++) inside += (0.01 * (k + 1)) * (0.01 * (k + 1)) <= r2 * (1 + 1e-6);
        grow = (n + alpha * inside) / (n + inside);
        r2 *= grow;
        tau = (tau + inside * (0.5 / PDS__PI) * 2.0) * grow;
        n += alpha * inside;
        CHECK(t, fabs(st.r2 / r2 - 1.0) < 1e-9 && fabs(st.n - n) < 1e-9 && fabs(st.tau[1] / tau - 1.0) < 1e-6,
              "pass %d: R^2 %g (expected %g), N %g (%g), tau %g (%g)", i + 1, st.r2, r2, st.n, n, st.tau[1], tau);
    }
    CHECK(t, fabs(st.n - (0.7 * 10 + 0.7 * 8)) < 1e-9, "N after two passes %g", st.n);
    pds__kdtree_free(&tree);
    pds_scene_free(s);
}

static void ppm_small_radius(pds_options *o)
{
    o->radius = 0.05;
    o->passes = 6;
}

/* Progressive photon mapping converges on the uniform caustic. */
static void test_ppm_converges_on_the_uniform_caustic(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    pds_render_stats st;
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PPM, 20000, 2, &img, &st, ppm_small_radius), "ppm");
    CHECK(t, st.passes == 6 && st.photons == 6 * 20000, "passes %d photons %ld", st.passes, st.photons);
    baseline_check_slab(t, &img, 0.02, 0.08, "ppm");
    pds_image_free(&img);
}

static void budget_quarter_second(pds_options *o) { o->time_s = 0.25; }

/* Under --time, pm's map holds exactly the photons it counts (the
   calibration photons are thrown away): the image is the fixed-count
   image of the same number of photons, up to the fixed-point rounding,
   gathered with the k the budget left it (gather_cap; the k asked for
   unless the gather could not fit) and the search radius it bounded the
   gather by, if any (gather_radius). */
static pds_render_stats budget_used;
static void fixed_k(pds_options *o)
{
    o->k = (int)budget_used.gather_cap;
    o->max_radius = budget_used.gather_radius;
}
static void test_pm_under_a_time_budget_maps_only_the_photons_it_counts(pds_test_ctx *t)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    pds_render_stats sa, sb;
    double worst, peak;
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PM, 0, 2, &a, &sa, budget_quarter_second), "pm --time");
    REQUIRE(t, sa.photons > 0, "no photons in time");
    REQUIRE(t, sa.gather_cap >= 8 && sa.gather_cap <= 50, "k used %ld", sa.gather_cap);
    budget_used = sa;
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PM, sa.photons, 2, &b, &sb, fixed_k), "pm --photons");
    worst = baseline_worst_difference(&b, &a, &peak);
    CHECK(t, peak > 0.0 && worst <= 1e-5 * peak, "%ld photons: largest difference %g (peak %g)", sa.photons, worst,
          peak);
    CHECK(t, sa.splatted == sb.splatted, "stored %ld vs %ld", sa.splatted, sb.splatted);
    pds_image_free(&a);
    pds_image_free(&b);
}

/* The time planner of pm and pdm leaves room for the map, on fixed probe
   figures (no clock involved): a probe of 1024 vertices that took 1 ms to
   gather 2000 stored photons (of 4000 emitted, planned 100000) and 0.1 ms
   to build; 100,000 eye vertices; 1e6 photons traced per second. */
static void test_map_plan_leaves_time_for_the_build_and_gather(pds_test_ctx *t)
{
    pds__map_probe p;
    double pm_half, pm_two, pdm_two, n, m, cost;
    p.build_s = 1e-4;
    p.gather_s = 1e-3;
    p.found = 50.0;
    p.map_photons = 2000.0;
    p.emitted = 4000.0;
    p.planned = 100000.0;
    p.queried = 1024.0;
    p.gather2_s = p.found2 = 0.0; /* one probe: c0 = c1 */
    p.gather3_s = 0.0;
    p.parallel = 1.0;
    pm_half = pds__map_plan(&p, 0, 50.0, 0, 100000, 1e6, 0.0, 0.5);
    pm_two = pds__map_plan(&p, 0, 50.0, 0, 100000, 1e6, 0.0, 2.0);
    /* pm, 2 s: the tracing plus the modelled build and gather fill the budget */
    n = pm_two * 1e6;
    m = 0.5 * n;
    cost = pm_two + 1e-4 * m / 2000.0 * log(m) / log(2000.0) +
           1e-3 / 1024.0 / 51.0 * 100000.0 * 51.0 * sqrt(log(m) / log(2000.0));
    CHECK_NEAR(t, cost, 2.0, 1e-6);
    CHECK(t, pm_half > 0.0 && pm_half < 0.5 && pm_two > pm_half && pm_two < 2.0, "pm: %g of 0.5 s, %g of 2 s", pm_half,
          pm_two);
    /* pdm: each query will meet min(500, 50 * 100000 / 4000) = 500 footprints */
    p.found = 50.0;
    pdm_two = pds__map_plan(&p, 1, 500.0, 0, 100000, 1e6, 0.0, 2.0);
    CHECK(t, pdm_two < pm_two, "pdm traces %g s, pm %g s", pdm_two, pm_two);
    /* a budget the gather alone exceeds leaves no tracing */
    CHECK_NEAR(t, pds__map_plan(&p, 1, 500.0, 0, 100000, 1e6, 0.0, 0.1), 0.0, 1e-9);
}

static void pdm_cap_one(pds_options *o) { o->max_photons = 1; }

/* pdm's cap binds: each eye vertex keeps at most max_photons footprints,
   so with a cap of one, where footprints overlap, the slab's caustic loses
   most of its light. */
static void test_pdm_max_photons_caps_each_gather(pds_test_ctx *t)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PDM, 20000, 2, &a, NULL, NULL), "pdm");
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PDM, 20000, 2, &b, NULL, pdm_cap_one), "pdm cap 1");
    CHECK(t, image_mean(&b, 1) < 0.5 * image_mean(&a, 1), "cap 1: %g, cap 500: %g", image_mean(&b, 1),
          image_mean(&a, 1));
    pds_image_free(&a);
    pds_image_free(&b);
}

static void ppm_budget(pds_options *o)
{
    o->radius = 0.05;
    o->passes = 1000000;
    o->time_s = 0.3;
}

/* A receiver's winding must not matter: the plane mirror's floor with its
   triangles facing down (rotated 180 degrees about x, the same plane) gets
   the same caustic from every photon method as the floor facing up. (It
   used to get none: the eye vertices kept the mesh's normal as stored.) */
static void test_photon_methods_light_a_receiver_of_either_winding(pds_test_ctx *t)
{
    static const pds_method methods[] = {PDS_METHOD_PDS, PDS_METHOD_PM, PDS_METHOD_PDM, PDS_METHOD_SPLAT,
                                         PDS_METHOD_PPM};
    const char *up = "quad { material floor size 8 8 }\n";
    const char *at = strstr(mirror_scene, up);
    char flipped[2048];
    size_t i, head;
    REQUIRE(t, at != NULL, "the mirror scene has its floor");
    head = (size_t)(at - mirror_scene);
    snprintf(flipped, sizeof flipped, "%.*squad { material floor size 8 8 rotate 180 1 0 0 }\n%s", (int)head,
             mirror_scene, at + strlen(up));
    for (i = 0; i < sizeof methods / sizeof methods[0]; i++) {
        pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
        double mean = 0.0;
        size_t k;
        REQUIRE(t, photon_render_text(mirror_scene, methods[i], 20000, 8.0, PDS_PATHS_CAUSTICS_ONLY, 2, &a, NULL, NULL),
                "render");
        REQUIRE(t, photon_render_text(flipped, methods[i], 20000, 8.0, PDS_PATHS_CAUSTICS_ONLY, 2, &b, NULL, NULL),
                "render flipped");
        for (k = 0; k < (size_t)a.width * a.height * 3; k++) mean += a.rgb[k] / ((double)a.width * a.height * 3);
        CHECK(t, mean > 0.0 && pds_image_rmse(&b, &a) < 1e-4 * mean, "%s: mean %g, rmse between windings %g",
              pds_method_name(methods[i]), mean, pds_image_rmse(&b, &a));
        pds_image_free(&a);
        pds_image_free(&b);
    }
}

/* ppm under --time runs passes until the time is spent, whatever --passes
   says (whole ones while they fit, then perhaps shorter ones of whole
   batches: pds__ppm_pass_photons; the first is whole), and counts every
   photon of them. */
static void test_ppm_under_a_time_budget_counts_every_photon_of_its_passes(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    pds_render_stats st;
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PPM, 5000, 2, &img, &st, ppm_budget), "ppm --time");
    CHECK(t, st.passes >= 1 && st.passes < 1000000 && st.photons <= (long)st.passes * 5000 &&
                 st.photons >= 5000 + (long)(st.passes - 1) * PDS__PHOTON_BATCH,
          "passes %d photons %ld", st.passes, st.photons);
    pds_image_free(&img);
}

/* ppm's update skips a run of 64 vertices only when no photon lies
   within any of its vertices' radii (pds__ppm_run_empty), against brute
   force: photons in a 2 x 2 patch of a 10 x 10 plane, vertices on the
   plane in runs of neighbours (each run a small square, now and then a
   run that jumps across the plane), radii of 0.01-0.3. Runs near the
   patch are kept, runs far from it skipped, and no skipped run holds a
   vertex a photon reaches. */
static void test_ppm_skips_only_runs_no_photon_reaches(pds_test_ctx *t)
{
    size_t np = 2000, nv = 64 * 200, i, j, skipped = 0, kept = 0, wrong = 0;
    float *pos = (float *)malloc(sizeof *pos * 3 * np);
    pds__eye_vertex *v = (pds__eye_vertex *)calloc(nv, sizeof *v);
    pds__ppm_state *state = (pds__ppm_state *)calloc(nv, sizeof *state);
    pds__kdtree tree;
    pds__ppm_job job;
    REQUIRE(t, pos && v && state, "memory");
    for (i = 0; i < np; i++) {
        pos[3 * i] = (float)(4.0 + 2.0 * pds__rng_uniform(5, PDS__RNG_TEST, i, 0));
        pos[3 * i + 1] = 0.0f;
        pos[3 * i + 2] = (float)(4.0 + 2.0 * pds__rng_uniform(5, PDS__RNG_TEST, i, 1));
    }
    for (i = 0; i < nv; i++) {
        size_t run = i / 64;
        /* the run's corner; every 7th run's last vertex far across */
        double cx = 10.0 * pds__rng_uniform(6, PDS__RNG_TEST, run, 0), cz = 10.0 * pds__rng_uniform(6, PDS__RNG_TEST, run, 1);
        double x = cx + 0.2 * pds__rng_uniform(7, PDS__RNG_TEST, i, 0), z = cz + 0.2 * pds__rng_uniform(7, PDS__RNG_TEST, i, 1);
        if (run % 7 == 0 && i % 64 == 63) {
            x = 10.0 - cx;
            z = 10.0 - cz;
        }
        v[i].pos[0] = (float)x;
        v[i].pos[2] = (float)z;
        state[i].r2 = pow(0.01 + 0.29 * pds__rng_uniform(8, PDS__RNG_TEST, i, 0), 2.0);
    }
    REQUIRE(t, pds__kdtree_build(&tree, pos, 3, np, NULL) == PDS_OK, "build");
    memset(&job, 0, sizeof job);
    job.v = v;
    job.state = state;
    job.nv = nv;
    job.tree = &tree;
    for (i = 0; i < nv; i += 64) {
        int empty = pds__ppm_run_empty(&job, i, nv), reached = 0;
        for (j = i; j < i + 64; j++) {
            size_t p;
            for (p = 0; p < np; p++)
                if (pds__kd_dist2(pos + 3 * p, v[j].pos[0], v[j].pos[1], v[j].pos[2]) <= state[j].r2) reached = 1;
        }
        if (empty && reached) wrong++;
        if (empty) skipped++;
        else kept++;
    }
    CHECK(t, wrong == 0 && skipped > 50 && kept > 10, "%lu runs skipped, %lu kept, %lu skipped wrongly",
          (unsigned long)skipped, (unsigned long)kept, (unsigned long)wrong);
    pds__kdtree_free(&tree);
    free(pos);
    free(v);
    free(state);
}

static const pds_test_case tests_baselines[] = {
    {"ppm_skips_only_runs_no_photon_reaches", test_ppm_skips_only_runs_no_photon_reaches},
    {"pm_finds_the_analytic_irradiance_of_a_uniform_caustic", test_pm_finds_the_analytic_irradiance_of_a_uniform_caustic},
    {"pm_filter_normalisations_are_the_filters_integrals", test_pm_filter_normalisations_are_the_filters_integrals},
    {"pm_map_grows_with_the_photon_count", test_pm_map_grows_with_the_photon_count},
    {"splat_conserves_flux_and_finds_the_uniform_caustic", test_splat_conserves_flux_and_finds_the_uniform_caustic},
    {"baselines_are_identical_for_any_thread_count", test_baselines_are_identical_for_any_thread_count},
    {"pdm_gathers_the_same_image_pds_splats", test_pdm_gathers_the_same_image_pds_splats},
    {"ppm_updates_follow_the_published_recurrence", test_ppm_updates_follow_the_published_recurrence},
    {"ppm_converges_on_the_uniform_caustic", test_ppm_converges_on_the_uniform_caustic},
    {"pm_under_a_time_budget_maps_only_the_photons_it_counts", test_pm_under_a_time_budget_maps_only_the_photons_it_counts},
    {"map_plan_leaves_time_for_the_build_and_gather", test_map_plan_leaves_time_for_the_build_and_gather},
    {"pdm_max_photons_caps_each_gather", test_pdm_max_photons_caps_each_gather},
    {"ppm_under_a_time_budget_counts_every_photon_of_its_passes",
     test_ppm_under_a_time_budget_counts_every_photon_of_its_passes},
    {"photon_methods_light_a_receiver_of_either_winding", test_photon_methods_light_a_receiver_of_either_winding},
};

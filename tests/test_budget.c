/* tests/test_budget.c - time budgets (--time): the planners' decisions on
   fixed figures with known answers (no clock involved), the gather's
   measured cap through the production path with a deadline that has
   certainly passed, and whole renders on a simulated machine given as
   the render's clock (pds__clock), whose time is a function of the work
   done. Nothing here asserts a wall time. Uses the slab scene and helpers
   of test_pds.c and test_baselines.c. */

/* The paper's PDS: with a photon costing a + b/N (a = 1e-5 s, b = 2 s),
   the calibration batches at N1 = 1e5 and N2 = 5e4 took 3e-5 and 5e-5 s a
   photon. On 2 threads for 2 s (4 CPU-s) the plan is N a + b = 4, N =
   2e5; for 1 s (2 CPU-s) the splats alone fill it, and N is planned for a
   quarter of it: 0.25 x 2 / 1e-5 = 5e4. */
static void test_pds_plan_solves_the_cost_of_tracing_and_splats(pds_test_ctx *t)
{
    double a = 1e-5, b = 2.0, n;
    n = pds__pds_plan(a + b / 1e5, 1e5, a + b / 5e4, 5e4, 2.0, 2);
    CHECK_NEAR(t, n, 2e5, 1e-3);
    CHECK_NEAR(t, n * a + b, 4.0, 1e-9);
    CHECK_NEAR(t, pds__pds_plan(a + b / 1e5, 1e5, a + b / 5e4, 5e4, 1.0, 2), 5e4, 1e-3);
    /* no splat cost (the second batch no slower): all of it is tracing */
    CHECK_NEAR(t, pds__pds_plan(1e-5, 1e5, 1e-5, 5e4, 1.0, 1), 1e5, 1e-3);
}

/* A smoothing whose splats cannot fit (a = 1e-4 s, b = 13 CPU-s, on 2
   threads for 1 s): the quarter rule alone would plan 0.25 x 2 / 1e-4 =
   5,000 photons, whose batches of 1024 would each take 1024 (a + b / N)
   = 2.8 s on one thread; N is raised until a batch takes an eighth of
   the time left, N = 1024 b / (1 / 8 - 1024 a). */
static void test_pds_plan_keeps_a_batch_within_an_eighth_of_the_time(pds_test_ctx *t)
{
    double a = 1e-4, b = 13.0, n, expect = 1024.0 * 13.0 / (1.0 / 8.0 - 1024.0 * 1e-4);
    n = pds__pds_plan(a + b / 1e5, 1e5, a + b / 2.5e4, 2.5e4, 1.0, 2);
    CHECK(t, fabs(n / expect - 1.0) < 1e-9, "N %g, expected %g", n, expect);
    CHECK_NEAR(t, 1024.0 * (a + b / n), 1.0 / 8.0, 1e-12);
    /* 0.5 s: not even the tracing of a batch fits an eighth (0.1024 s
       against 0.0625): the quarter rule stands */
    n = pds__pds_plan(a + b / 1e5, 1e5, a + b / 2.5e4, 2.5e4, 0.5, 2);
    CHECK(t, fabs(n / 2500.0 - 1.0) < 1e-9, "N %g, expected 2500", n);
}

#ifndef PDS_NO_BASELINES
/* The gather's samples (pds__gather_sampled): runs of PDS__SAMPLE_RUN
   neighbours, one a block of S runs; the count and the places agree with
   the selection, and at 256 x 256 with 4 samples a pixel (a block of 64
   runs is then exactly 16 image rows) the runs fall at many places
   across a row, not in one column. */
static void test_gather_sample_is_counted_and_spread(pds_test_ctx *t)
{
    static const size_t nvs[4] = {262144, 252824, 4097, 100};
    static const size_t Ss[3] = {1, 4, 64};
    int a, b;
    for (a = 0; a < 4; a++)
        for (b = 0; b < 3; b++) {
            size_t nv = nvs[a], S = Ss[b], i, n = 0, count = pds__gather_sample_count(nv, S);
            unsigned char *seen = (unsigned char *)calloc(count + 1, 1);
            int dup = 0;
            REQUIRE(t, seen != NULL, "memory");
            for (i = 0; i < nv; i++)
                if (pds__gather_sampled(i, S)) {
                    size_t at = pds__gather_sample_at(i, S);
                    if (at >= count || seen[at]) dup++;
                    else seen[at] = 1;
                    n++;
                }
            CHECK(t, n == count && dup == 0, "nv %zu S %zu: %zu sampled, counted %zu, %d misplaced", nv, S, n, count,
                  dup);
            free(seen);
        }
    {
        /* rows of 1024 vertices: which of a row's 16 runs are sampled */
        size_t i;
        int places[16] = {0}, distinct = 0, p;
        for (i = 0; i < 262144; i += PDS__SAMPLE_RUN)
            if (pds__gather_sampled(i, 64)) places[(i % 1024) / PDS__SAMPLE_RUN] = 1;
        for (p = 0; p < 16; p++) distinct += places[p];
        CHECK(t, distinct >= 12, "the sample's runs sit at %d of a row's 16 places", distinct);
    }
}
#endif

/* A budget already spent, for 50,000 photons (a pass's or the paper's
   PDS's N). */
static void budget_spent(pds_options *o)
{
    o->time_s = 1e-9;
    o->photons = 50000;
}

#ifndef PDS_NO_BASELINES
/* ppm's next pass: whole while it fits; else the pass whose tracing and
   update fill the time left, in whole batches; else one batch if its
   pass ends nearer T than stopping now; else none. First with an update
   that is all fixed (1 s whatever the photons), then with one that grows
   with them. */
static void test_ppm_pass_photons_fit_the_time_left(pds_test_ctx *t)
{
    CHECK(t, pds__ppm_pass_photons(10.0, 2.0, 1.0, 0.0, 100000) == 100000, "a whole pass fits");
    CHECK(t, pds__ppm_pass_photons(3.0, 2.0, 1.0, 0.0, 100000) == 100000, "exactly fits");
    /* 2 s left, 1 s for the update: half the tracing, 50,000 photons, in
       whole batches of 1024: 48 x 1024 */
    CHECK(t, pds__ppm_pass_photons(2.0, 2.0, 1.0, 0.0, 100000) == 48 * PDS__PHOTON_BATCH, "%ld",
          pds__ppm_pass_photons(2.0, 2.0, 1.0, 0.0, 100000));
    /* one batch traces in 2 x 1024 / 1e5 = 0.02 s: with 0.9 s left the
       pass overruns by 0.12 s, nearer T than 0.9 s early */
    CHECK(t, pds__ppm_pass_photons(0.9, 2.0, 1.0, 0.0, 100000) == PDS__PHOTON_BATCH, "the update alone does not fit");
    CHECK(t, pds__ppm_pass_photons(1.01, 2.0, 1.0, 0.0, 100000) == PDS__PHOTON_BATCH, "not one batch fits");
    /* 0.4 s left: 0.62 s over is farther from T than 0.4 s early */
    CHECK(t, pds__ppm_pass_photons(0.4, 2.0, 1.0, 0.0, 100000) == 0, "stopping is nearer T");
    CHECK(t, pds__ppm_pass_photons(-1.0, 2.0, 1.0, 0.0, 100000) == 0, "the budget is spent");
    /* the ring and octahedron's figures: 100,000 photons trace in 0.022 s,
       an update costs 0.025 s + 4.75 us a photon: a whole pass takes
       0.522 s, so with 0.5 s left the pass is the whole batches of
       (0.5 - 0.025) / 4.97e-6 = 95,573 photons: 93 x 1024 (the update of
       the fixed part alone had planned a whole pass: 0.022 s beside
       0.025) */
    CHECK(t, pds__ppm_pass_photons(0.6, 0.022, 0.025, 4.75e-6, 100000) == 100000, "a whole pass fits");
    CHECK(t, pds__ppm_pass_photons(0.5, 0.022, 0.025, 4.75e-6, 100000) == 93 * PDS__PHOTON_BATCH, "%ld",
          pds__ppm_pass_photons(0.5, 0.022, 0.025, 4.75e-6, 100000));
}

/* The update's model from the passes measured: an update of 0.025 s +
   4.75 us a photon, seen at 1,024 photons (0.0299 s) and then 20,480
   (0.1223 s): the line through the two gives both parts; with one pass
   alone all of it is taken per photon; two passes of about one size
   leave the fixed part as it was and refresh the rest; a line with a
   negative part (the second pass cheaper a photon and dearer in all, as
   radii shrink) is not taken. */
static void test_ppm_update_model_fits_the_passes_measured(pds_test_ctx *t)
{
    double a = 0.025, b = 4.75e-6, fixed = 0.0, per = 0.0;
    pds__ppm_update_model(1024.0, a + b * 1024.0, 0.0, 0.0, &fixed, &per);
    CHECK(t, fixed == 0.0 && fabs(per - (a + b * 1024.0) / 1024.0) < 1e-15, "one pass: %g + %g n", fixed, per);
    pds__ppm_update_model(20480.0, a + b * 20480.0, 1024.0, a + b * 1024.0, &fixed, &per);
    CHECK(t, fabs(fixed - a) < 1e-12 && fabs(per - b) < 1e-15, "two passes: %g + %g n", fixed, per);
    /* a third pass of about the last one's size, whose photons now cost
       3 us each (smaller radii): the fixed part stays */
    pds__ppm_update_model(30720.0, a + 3e-6 * 30720.0, 20480.0, a + b * 20480.0, &fixed, &per);
    CHECK(t, fabs(fixed - a) < 1e-12 && fabs(per - 3e-6) < 1e-15, "three passes: %g + %g n", fixed, per);
    /* then a pass 4 times smaller whose whole update (0.02 s) is below
       the fixed part: the line's intercept is negative and not taken,
       and the fixed part falls to the update itself */
    pds__ppm_update_model(7680.0, 0.02, 30720.0, a + 3e-6 * 30720.0, &fixed, &per);
    CHECK(t, fixed <= 0.02 && fabs(fixed + per * 7680.0 - 0.02) < 1e-12, "fixed %g per %g", fixed, per);
}

/* The gather's cap from two samples: a query taking c microseconds at cap
   c (t_50 = 50 us, t_8 = 8 us) fits 20 us at a cap of 20. */
static void test_gather_cap_fit_interpolates_the_two_samples(pds_test_ctx *t)
{
    CHECK_NEAR(t, pds__gather_cap_fit(8.0, 8e-6, 50.0, 50e-6, 20e-6, NULL, 0), 20.0, 1e-9);
    /* whole caps, rounded down; never above the cap asked, nor below 8;
       8 when the deadline passed */
    CHECK_NEAR(t, pds__gather_cap_fit(8.0, 8e-6, 50.0, 50e-6, 20.5e-6, NULL, 0), 20.0, 1e-9);
    CHECK_NEAR(t, pds__gather_cap_fit(8.0, 8e-6, 50.0, 50e-6, 60e-6, NULL, 0), 50.0, 1e-9);
    CHECK_NEAR(t, pds__gather_cap_fit(8.0, 8e-6, 50.0, 50e-6, 1e-6, NULL, 0), 8.0, 1e-9);
    CHECK_NEAR(t, pds__gather_cap_fit(8.0, 8e-6, 50.0, 50e-6, -1.0, NULL, 0), 8.0, 1e-9);
    /* a noisy pair whose cap-8 sample was no quicker */
    CHECK_NEAR(t, pds__gather_cap_fit(8.0, 60e-6, 50.0, 50e-6, 45e-6, NULL, 0), 8.0, 1e-9);
}

/* The cap from the photons the sample's queries found: half of them
   find 50 photons within reach at a cap of 50, half only 12, and a
   query costs 1 us a photon found, so F(c) = (c + min(c, 12)) / 2, t_8 =
   8 us, t_50 = 31 us. 16.2 us a query allows F(c) = 16.2: c = 20.4, a
   cap of 20. The line through the two samples would allow 8 + 8.2 x 42 /
   23 = 22.97, a cap of 22, whose queries take 17 us. */
static void test_gather_cap_fit_follows_the_photons_found(pds_test_ctx *t)
{
    float found[10];
    int i;
    for (i = 0; i < 10; i++) found[i] = i % 2 ? 50.0f : 12.0f;
    CHECK_NEAR(t, pds__gather_found(found, 10, 8.0), 8.0, 1e-12);
    CHECK_NEAR(t, pds__gather_found(found, 10, 30.0), 21.0, 1e-12);
    CHECK_NEAR(t, pds__gather_cap_fit(8.0, 8e-6, 50.0, 31e-6, 16.2e-6, found, 10), 20.0, 1e-9);
    CHECK_NEAR(t, pds__gather_cap_fit(8.0, 8e-6, 50.0, 31e-6, 16.2e-6, NULL, 0), 22.0, 1e-9);
    CHECK_NEAR(t, pds__gather_cap_fit(8.0, 8e-6, 50.0, 31e-6, 31e-6, found, 10), 50.0, 1e-9);
    CHECK_NEAR(t, pds__gather_cap_fit(8.0, 8e-6, 50.0, 31e-6, 7e-6, found, 10), 8.0, 1e-9);
    /* the refit between the cap chosen (20, measured at 12 us, quicker
       than the fit said) and 50: t(c) = 12 + 19 (F(c) - 16) / 15 us fits
       16.2 us up to F(c) = 19.3, c = 26.6 */
    CHECK_NEAR(t, pds__gather_cap_fit(20.0, 12e-6, 50.0, 31e-6, 16.2e-6, found, 10), 26.0, 1e-9);
    /* every query found at most 8: any cap costs t_8 */
    for (i = 0; i < 10; i++) found[i] = 8.0f;
    CHECK_NEAR(t, pds__gather_cap_fit(8.0, 8e-6, 50.0, 9e-6, 8.5e-6, found, 10), 50.0, 1e-9);
}

/* ppm under a budget already spent: the first pass (a 200th of the
   budget at most) still traces one batch, and no pass follows. */

static void test_ppm_past_its_deadline_traces_one_batch(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    pds_render_stats st;
    double peak = 0.0;
    size_t i;
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PPM, 0, 2, &img, &st, budget_spent), "ppm --time 1e-9");
    CHECK(t, st.photons == PDS__PHOTON_BATCH && st.passes == 1, "photons %ld passes %d", st.photons, st.passes);
    for (i = 0; i < (size_t)img.width * img.height * 3; i++) peak = fmax(peak, img.rgb[i]);
    CHECK(t, peak > 0.0, "a caustic");
    pds_image_free(&img);
}

/* The map plan's figures: a probe of 1024 vertices, 2000 stored photons
   of 4000 emitted (planned 100000), built in 0.1 ms; gathered with the cap
   (50 found a query) in 1 ms and with a cap of 8 (8 found) in 0.3 ms: a
   query costs c0 + c1 f with c1 = (1e-3 - 0.3e-3) / 1024 / 42 and c0 =
   0.3e-3 / 1024 - 8 c1. */
static void budget_probe(pds__map_probe *p)
{
    p->build_s = 1e-4;
    p->gather_s = 1e-3;
    p->found = 50.0;
    p->gather2_s = 0.3e-3;
    p->found2 = 8.0;
    p->map_photons = 2000.0;
    p->emitted = 4000.0;
    p->planned = 100000.0;
    p->queried = 1024.0;
    p->parallel = 2.0;
    p->gather3_s = 0.0;
}

static void test_map_cost_is_the_line_through_the_two_probes(pds_test_ctx *t)
{
    pds__map_probe p;
    double c1 = 0.7e-3 / 1024.0 / 42.0, c0 = 0.3e-3 / 1024.0 - 8.0 * c1, m = 2000.0;
    budget_probe(&p);
    /* a map the probe's size: the build as probed, the gather of 1e5
       vertices at cap 20 on P = 2 */
    CHECK_NEAR(t, pds__map_cost(&p, 0, 20.0, 0, 100000, m), 1e-4 + 1e5 * (c0 + c1 * 20.0) / 2.0, 1e-12);
    /* pm finds no more photons than the map holds */
    CHECK_NEAR(t, pds__map_cost(&p, 0, 50.0, 0, 100000, 30.0) > 0.0, 1.0, 0.0);
    /* with one probe (found2 = 0): c0 = c1 = the time a query / (1 + found) */
    p.found2 = p.gather2_s = 0.0;
    CHECK_NEAR(t, pds__map_cost(&p, 0, 20.0, 0, 100000, m),
               1e-4 + 1e5 * (1e-3 / 1024.0 / 51.0) * 21.0 / 2.0, 1e-12);
}

/* Steps 1-2 of the plan: the cap asked for is kept when the tracing keeps
   a quarter of the time; else the largest that does; more photons traced
   already leave less tracing; a quarter of the budget is traced at least. */
static void test_map_tracing_lowers_the_cap_only_when_it_must(pds_test_ctx *t)
{
    pds__map_probe p;
    double cap, tr, tr_more;
    budget_probe(&p);
    /* 1e5 vertices, 1e6 photons a second, 5 s: k = 50 leaves room */
    tr = pds__map_tracing(&p, 0, 50.0, 100000, 1e6, 0.0, 0.0, 5.0, &cap);
    CHECK(t, cap == 50.0 && tr >= 1.25 && tr < 5.0, "cap %g tracing %g", cap, tr);
    /* 2e6 vertices in 1 s: the gather at k = 50 alone takes about 1 s, at
       k = 8 0.3 s, so the cap falls to the largest that keeps a quarter */
    tr = pds__map_tracing(&p, 0, 50.0, 2000000, 1e6, 0.0, 0.0, 1.0, &cap);
    CHECK(t, cap > 8.0 && cap < 50.0, "cap %g", cap);
    CHECK(t, pds__map_plan(&p, 0, cap, 0, 2000000, 1e6, 0.0, 1.0) >= 0.25 &&
                 pds__map_plan(&p, 0, cap + 1.0, 0, 2000000, 1e6, 0.0, 1.0) < 0.25,
          "cap %g: tracing %g, at cap + 1 %g", cap, pds__map_plan(&p, 0, cap, 0, 2000000, 1e6, 0.0, 1.0),
          pds__map_plan(&p, 0, cap + 1.0, 0, 2000000, 1e6, 0.0, 1.0));
    CHECK_NEAR(t, tr, pds__map_plan(&p, 0, cap, 0, 2000000, 1e6, 0.0, 1.0), 1e-12);
    /* 1e7 vertices: even k = 8 leaves less than a quarter: 8, and half
       the budget traced (the gather will bound its radius, at a cost the
       model does not know) */
    tr = pds__map_tracing(&p, 0, 50.0, 10000000, 1e6, 0.0, 0.0, 1.0, &cap);
    CHECK(t, cap == 8.0 && fabs(tr - 0.5) < 1e-12, "cap %g tracing %g", cap, tr);
    /* the same with the bounded gather probed: 0.1 ms for the probe's
       1024 queries (0.1 us a query: 0.49 s for 1e7 at P = 2 on a map of
       the probe's size, more on a larger one): the tracing fills what
       that gather and the build leave, more than a quarter and less than
       the half traced without the probe */
    p.gather3_s = 1e-4;
    CHECK_NEAR(t, pds__map_cost(&p, 0, 8.0, 1, 10000000, 2000.0), 1e-4 + 1e7 * 1e-4 / 1024.0 / 2.0, 1e-12);
    tr = pds__map_tracing(&p, 0, 50.0, 10000000, 1e6, 0.0, 0.0, 1.0, &cap);
    CHECK(t, cap == 8.0 && tr > 0.3 && tr < 0.45, "cap %g tracing %g", cap, tr);
    CHECK_NEAR(t, tr + pds__map_cost(&p, 0, 8.0, 1, 10000000, tr * 1e6 * 0.5), 1.0, 1e-6);
    /* 0.5 s, which that gather alone fills: a quarter traced */
    tr = pds__map_tracing(&p, 0, 50.0, 10000000, 1e6, 0.0, 0.0, 0.5, &cap);
    CHECK(t, cap == 8.0 && fabs(tr - 0.125) < 1e-12, "cap %g tracing %g", cap, tr);
    p.gather3_s = 0.0;
    /* round 2: 2e6 photons traced in 0.5 s of 4.5 s left: less to trace
       than from scratch, and the plan's cost fills what is left */
    tr = pds__map_tracing(&p, 0, 50.0, 100000, 1e6, 0.0, 0.0, 4.5, &cap);
    tr_more = pds__map_tracing(&p, 0, 50.0, 100000, 1e6, 2e6, 0.5, 4.5, &cap);
    CHECK(t, tr_more < tr, "tracing %g after 2e6 photons, %g before", tr_more, tr);
    CHECK_NEAR(t, tr_more + pds__map_cost(&p, 0, 50.0, 0, 100000, (2e6 + tr_more * 1e6) * 0.5), 4.5, 1e-6);
    /* a budget the map of what is traced already exceeds: the floor, a
       quarter of (left + traced_s) minus traced_s */
    tr = pds__map_tracing(&p, 0, 50.0, 10000000, 1e6, 2e6, 0.5, 0.01, &cap);
    CHECK(t, tr <= 0.0 && cap == 8.0, "tracing %g cap %g", tr, cap);
}

/* Step 3 through the production path: a deadline certainly passed (a
   budget of 1e-9 s) makes the gather measure its samples, fall to a cap
   of 8 and, as even that cannot end in time, bound its search radius by
   the tenth of the sample's 8th-photon distances (the last trial). The
   image is then pm's with k = 8 and that maximum radius, of the photons
   it counted (one batch: no time was left to trace), each vertex's
   estimate once (the sample kept, the rest gathered after it). */
static void budget_gone(pds_options *o) { o->time_s = 1e-9; }
static double budget_radius;
static void pm_k8(pds_options *o)
{
    o->k = 8;
    o->max_radius = budget_radius;
}

static void test_gather_past_its_deadline_uses_a_cap_of_8(pds_test_ctx *t)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    pds_render_stats sa, sb;
    double worst, peak;
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PM, 0, 2, &a, &sa, budget_gone), "pm --time 1e-9");
    CHECK(t, sa.photons == PDS__PHOTON_BATCH && sa.gather_cap == 8 && sa.eye_vertices >= 64 * 64 &&
                 sa.gather_radius > 0.0,
          "photons %ld k used %ld radius %g vertices %ld", sa.photons, sa.gather_cap, sa.gather_radius,
          sa.eye_vertices);
    budget_radius = sa.gather_radius;
    REQUIRE(t, baseline_render(slab_scene, PDS_METHOD_PM, sa.photons, 2, &b, &sb, pm_k8), "pm k 8");
    CHECK(t, sb.gather_cap == 8, "a photon budget keeps its k: %ld", sb.gather_cap);
    worst = baseline_worst_difference(&b, &a, &peak);
    CHECK(t, peak > 0.0 && worst <= 1e-5 * peak, "largest difference %g (peak %g)", worst, peak);
    pds_image_free(&a);
    pds_image_free(&b);
}
#endif

/* The paper's PDS with no time left traces one batch for 16 times the
   photon count asked for (small footprints: cheap splats), not for 1024
   photons (whose footprints could each cover much of the image). */

static void test_paper_pds_without_time_keeps_small_footprints(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    pds_render_stats st;
    REQUIRE(t, photon_render_text(slab_scene, PDS_METHOD_PDS, 0, 12.0, PDS_PATHS_CAUSTICS_ONLY, 2, &img, &st,
                                  budget_spent),
            "pds --time 1e-9");
    CHECK(t, st.photons == PDS__PHOTON_BATCH && st.photons_planned == 16.0 * 50000.0, "photons %ld planned %g", st.photons,
          st.photons_planned);
    pds_image_free(&img);
}

#ifndef PDS_NO_BASELINES
/* P, the gather's speed-up over the probe's: the threads over the
   probe's threads that had a chunk of vertices to gather (one thread's
   probe: P = the threads; a probe on all threads: 1, unless it had
   fewer chunks than threads, as pdm's 384 vertices are one chunk). */
static void test_probe_parallel_counts_the_threads_that_had_work(pds_test_ctx *t)
{
    CHECK_NEAR(t, pds__probe_parallel(2, 1, 8192), 2.0, 0.0);
    CHECK_NEAR(t, pds__probe_parallel(2, 2, 4096), 1.0, 0.0);
    CHECK_NEAR(t, pds__probe_parallel(2, 2, 384), 2.0, 0.0);
    CHECK_NEAR(t, pds__probe_parallel(8, 8, 3 * PDS__GATHER_CHUNK), 8.0 / 3.0, 1e-15);
    CHECK_NEAR(t, pds__probe_parallel(2, 2, 0), 2.0, 0.0);
}
#endif

#ifndef PDS_NO_BASELINES
/* A simulated machine for the time planner, given to the render as its
   clock (pds__clock): its time is a pure function of the work the
   render tells it of (photons traced, photons built into a map, eye
   vertices queried, photons found, pixels whose scale progressive PDS
   chooses), each at a fixed cost in seconds
   whichever thread does it, so that a render on it is the same whatever
   the threads' order, and cheap: its seconds are not spent. Guarded by
   a lock (tracing threads tell it their batches and read it). */
typedef struct budget_machine {
    pds__mutex lock;
    double traced, queried, found, build_s, chosen, eye;     /* the work told so far */
    double trace_s, query_s, found_s, map_s, chosen_s, eye_s; /* what each costs; a map of m photons: map_s m log2 m */
} budget_machine;

static double budget_machine_now(void *user)
{
    budget_machine *m = (budget_machine *)user;
    double t;
    pds__mutex_lock(&m->lock);
    t = m->traced * m->trace_s + m->queried * m->query_s + m->found * m->found_s + m->build_s + m->chosen * m->chosen_s +
        m->eye * m->eye_s;
    pds__mutex_unlock(&m->lock);
    return t;
}

static void budget_machine_spent(void *user, pds__work what, double units)
{
    budget_machine *m = (budget_machine *)user;
    pds__mutex_lock(&m->lock);
    if (what == PDS__WORK_TRACED) m->traced += units;
    if (what == PDS__WORK_MAPPED) m->build_s += m->map_s * units * log2(fmax(2.0, units));
    if (what == PDS__WORK_QUERIED) m->queried += units;
    if (what == PDS__WORK_FOUND) m->found += units;
    if (what == PDS__WORK_CHOSEN) m->chosen += units;
    if (what == PDS__WORK_EYE) m->eye += units;
    pds__mutex_unlock(&m->lock);
}

/* method (tweak: options beside it) on the slab, caustics only, 2
   threads, under a budget of T simulated seconds on a machine where a
   photon costs 10 us, a map of m photons 1 us m log2 m, a query 2 us,
   0.05 us a photon found, chosen_s a pixel whose scale is chosen and
   eye_s an eye sample, through the production path (pds__render_at),
   with or without the map plan's step 2 (one_round). *landed: the
   photon pass's simulated seconds over T. 0 if the render failed. */
static int budget_machine_render_eye(pds_method method, double T, int one_round, void (*tweak)(pds_options *),
                                     double chosen_s, double eye_s, double *landed, pds_render_stats *st)
{
    budget_machine m;
    pds__clock clock;
    pds_options opt;
    pds_image img = {0, 0, NULL};
    pds_error err;
    pds_scene *s = scene_from_text(slab_scene, &err);
    int ok;
    if (!s) return 0;
    memset(&m, 0, sizeof m);
    pds__mutex_init(&m.lock);
    m.trace_s = 10e-6;
    m.map_s = 1e-6;
    m.query_s = 2e-6;
    m.found_s = 0.05e-6;
    m.chosen_s = chosen_s;
    m.eye_s = eye_s;
    memset(&clock, 0, sizeof clock);
    clock.now = budget_machine_now;
    clock.spent = budget_machine_spent;
    clock.user = &m;
    clock.one_round = one_round;
    pds_options_default(&opt);
    opt.method = method;
    opt.paths = PDS_PATHS_CAUSTICS_ONLY;
    opt.threads = 2;
    opt.time_s = T;
    if (tweak) tweak(&opt);
    ok = pds__render_at(s, &opt, &clock, &img, st, &err) == PDS_OK;
    if (!ok) printf("  render: %s\n", err.text);
    *landed = st->time_photons_s / T;
    pds__mutex_destroy(&m.lock);
    pds_image_free(&img);
    pds_scene_free(s);
    return ok;
}

/* The same where an eye sample costs nothing. */
static int budget_machine_render_at(pds_method method, double T, int one_round, void (*tweak)(pds_options *),
                                    double chosen_s, double *landed, pds_render_stats *st)
{
    return budget_machine_render_eye(method, T, one_round, tweak, chosen_s, 0.0, landed, st);
}

/* The same where choosing a pixel's scale costs nothing too. */
static int budget_machine_render(pds_method method, double T, int one_round, void (*tweak)(pds_options *),
                                 double *landed, pds_render_stats *st)
{
    return budget_machine_render_at(method, T, one_round, tweak, 0.0, landed, st);
}

/* The map plan's step 2 through the production path, on the simulated
   machine above: two threads there are no quicker than one (a machine
   whose other core is busy), so the photons are traced at half the rate
   the one-thread calibration foretold for two threads, and step 1, which
   planned from it, expects a map twice the size it will be and its
   build (most of the pass after the tracing: 0.3-0.5 s of 1 s) twice as
   long. In one round the pass ends at 0.72 T; with step 2's re-plan from
   the rate the threads measured, at 1.00 T (1.00-1.02 for T from 0.5 to
   4 s and map costs from half to twice these). */
static void test_map_budget_replans_on_a_machine_slower_than_probed(pds_test_ctx *t)
{
    pds_render_stats a, b;
    double landed, landed1;
    REQUIRE(t, budget_machine_render(PDS_METHOD_PM, 1.0, 0, NULL, &landed, &a), "pm on the simulated machine");
    REQUIRE(t, budget_machine_render(PDS_METHOD_PM, 1.0, 1, NULL, &landed1, &b), "pm on it in one round");
    CHECK(t, fabs(landed - 1.0) <= 0.15, "landed at %.3f of T (%ld photons)", landed, a.photons);
    CHECK(t, fabs(landed1 - 1.0) > 0.15, "in one round, landed at %.3f of T: the re-plan was not needed",
          landed1);
    CHECK(t, a.photons > b.photons, "%ld photons with the re-plan, %ld without", a.photons, b.photons);
}

static void paper_pds(pds_options *o) { o->progressive = 0; }
static void short_passes(pds_options *o) { o->pass_photons = 4096; }

/* The other planners through the production path on the same simulated
   machine: ppm's passes sized from the updates it measured (an update
   there is the map's build and a query at every vertex), the paper's PDS
   (its N from two calibration batches) and progressive PDS (whole passes
   while the next one's end is nearer T: passes of 4096 photons, 41 ms
   there); each lands within 15% of T, which it could not if any of its
   deadline checks read another clock than the render's. */
static void test_budgets_hold_on_a_simulated_machine(pds_test_ctx *t)
{
    static const struct {
        pds_method method;
        void (*tweak)(pds_options *);
        double T;
    } cases[3] = {{PDS_METHOD_PPM, NULL, 1.0}, {PDS_METHOD_PDS, paper_pds, 0.25}, {PDS_METHOD_PDS, short_passes, 0.25}};
    int i;
    for (i = 0; i < 3; i++) {
        pds_render_stats st;
        double landed;
        REQUIRE(t, budget_machine_render(cases[i].method, cases[i].T, 0, cases[i].tweak, &landed, &st), "render");
        CHECK(t, fabs(landed - 1.0) <= 0.15, "case %d (%s): landed at %.3f of T (%ld photons, %d passes)", i,
              pds_method_name(cases[i].method), landed, st.photons, st.passes);
    }
}
#endif

#ifndef PDS_NO_BASELINES
/* Progressive PDS's image, where its pixels choose their scale, is part
   of the photon pass and within its budget (pds__choice_seconds): on the
   simulated machine a pixel's choice costs 0.434 ms, so the slab's 576
   pixels take a quarter of a 1 s budget, and so does the calibration
   (the image is below 128 x 128: timed whole). The passes stop early by
   that quarter and the pass, the image included, lands within 10% of T
   (passes of 4096 + 1024 validation photons: 51 ms); without the room
   it would land at 1.25 T, and with the image's time left out of the
   pass at 0.75 T. The same render with the choice free spends its budget
   on passes: more photons. */
static void test_pds_budget_holds_the_choice_of_scale(pds_test_ctx *t)
{
    pds_render_stats st, free_st;
    double landed, landed_free, image_s = 576 * 0.434e-3;
    REQUIRE(t, budget_machine_render_at(PDS_METHOD_PDS, 1.0, 0, short_passes, 0.434e-3, &landed, &st), "render");
    REQUIRE(t, budget_machine_render_at(PDS_METHOD_PDS, 1.0, 0, short_passes, 0.0, &landed_free, &free_st),
            "render, the choice free");
    REQUIRE(t, st.scale_pixels[0] + st.scale_pixels[1] > 0, "no pixel chose its scale");
    CHECK(t, fabs(landed - 1.0) <= 0.1, "landed at %.3f of T (%ld photons, %d passes)", landed, st.photons,
          st.passes);
    CHECK(t, fabs(landed_free - 1.0) <= 0.1, "the choice free: landed at %.3f of T", landed_free);
    CHECK(t, st.time_photons_s >= 2.0 * image_s, "the pass took %.3f s: the image's %.3f s and the calibration's "
          "are not in it", st.time_photons_s, image_s);
    CHECK(t, free_st.photons > st.photons, "%ld photons with the choice free, %ld with it", free_st.photons,
          st.photons);
}
#endif

#ifndef PDS_NO_BASELINES
/* --time is the render's, its eye pass included: on the simulated
   machine with eye samples that make the eye pass 0.4 T, ppm, pm and
   progressive PDS (passes of 4096 photons) end the whole render within
   15% of T, their photon passes at 0.6 T, and trace fewer photons than
   when the eye pass is free. (With the budget the photon pass's alone,
   the renders ended at 1.4 T.) */
static void test_budgets_count_the_eye_pass(pds_test_ctx *t)
{
    static const pds_method methods[3] = {PDS_METHOD_PPM, PDS_METHOD_PM, PDS_METHOD_PDS};
    pds_error err;
    pds_scene *s = scene_from_text(slab_scene, &err);
    int i, spp;
    REQUIRE(t, s != NULL, "slab: %s", err.text);
    spp = pds_scene_camera(s)->spp > 0 ? pds_scene_camera(s)->spp : 1;
    pds_scene_free(s);
    for (i = 0; i < 3; i++) {
        void (*tweak)(pds_options *) = methods[i] == PDS_METHOD_PDS ? short_passes : NULL;
        pds_render_stats free_st, st;
        double landed, eye_s, T = 1.0;
        REQUIRE(t, budget_machine_render_eye(methods[i], T, 0, tweak, 0.0, 0.0, &landed, &free_st), "render");
        /* (free_st.spp counts PDS's eye rounds too) */
        eye_s = 0.4 * T / ((double)free_st.width * free_st.height * spp);
        REQUIRE(t, budget_machine_render_eye(methods[i], T, 0, tweak, 0.0, eye_s, &landed, &st), "render");
        CHECK(t, fabs(st.time_eye_s - 0.4 * T) < 1e-9, "%s: the eye pass took %.4g s", pds_method_name(methods[i]),
              st.time_eye_s);
        CHECK(t, fabs(st.time_total_s / T - 1.0) <= 0.15 && fabs(st.time_photons_s / T - 0.6) <= 0.15,
              "%s: the render ended at %.3f T, its photon pass took %.3f T", pds_method_name(methods[i]),
              st.time_total_s / T, st.time_photons_s / T);
        CHECK(t, st.photons < free_st.photons, "%s: %ld photons, %ld with the eye pass free",
              pds_method_name(methods[i]), st.photons, free_st.photons);
    }
}
#endif

static const pds_test_case tests_budget[] = {
    {"pds_plan_solves_the_cost_of_tracing_and_splats", test_pds_plan_solves_the_cost_of_tracing_and_splats},
    {"pds_plan_keeps_a_batch_within_an_eighth_of_the_time", test_pds_plan_keeps_a_batch_within_an_eighth_of_the_time},
#ifndef PDS_NO_BASELINES
    {"gather_sample_is_counted_and_spread", test_gather_sample_is_counted_and_spread},
    {"probe_parallel_counts_the_threads_that_had_work", test_probe_parallel_counts_the_threads_that_had_work},
    {"ppm_pass_photons_fit_the_time_left", test_ppm_pass_photons_fit_the_time_left},
    {"ppm_update_model_fits_the_passes_measured", test_ppm_update_model_fits_the_passes_measured},
    {"ppm_past_its_deadline_traces_one_batch", test_ppm_past_its_deadline_traces_one_batch},
    {"gather_cap_fit_interpolates_the_two_samples", test_gather_cap_fit_interpolates_the_two_samples},
    {"gather_cap_fit_follows_the_photons_found", test_gather_cap_fit_follows_the_photons_found},
    {"map_cost_is_the_line_through_the_two_probes", test_map_cost_is_the_line_through_the_two_probes},
    {"map_tracing_lowers_the_cap_only_when_it_must", test_map_tracing_lowers_the_cap_only_when_it_must},
    {"gather_past_its_deadline_uses_a_cap_of_8", test_gather_past_its_deadline_uses_a_cap_of_8},
    {"map_budget_replans_on_a_machine_slower_than_probed", test_map_budget_replans_on_a_machine_slower_than_probed},
    {"budgets_hold_on_a_simulated_machine", test_budgets_hold_on_a_simulated_machine},
    {"pds_budget_holds_the_choice_of_scale", test_pds_budget_holds_the_choice_of_scale},
    {"budgets_count_the_eye_pass", test_budgets_count_the_eye_pass},
#endif
    {"paper_pds_without_time_keeps_small_footprints", test_paper_pds_without_time_keeps_small_footprints},
};

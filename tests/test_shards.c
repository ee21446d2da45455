/* tests/test_shards.c - shards, exact merges, interrupt and resume, and the
   partial file: a render split any way, stopped anywhere and continued,
   gives the image of the render in one go, bit for bit. */

/* A glass ball on a floor under a point light: caustics for the photon
   methods, direct light for the eye pass. 24 x 16 pixels, 2 samples. */
static const char shards_scene[] =
    "camera { position 0 2 4 look_at 0 0.3 0 fov 40 resolution 24 16 spp 2 }\n"
    "material floor diffuse { albedo 0.8 }\n"
    "material glass dielectric { ior 1.5 }\n"
    "quad { material floor size 6 6 }\n"
    "sphere { material glass radius 0.5 translate 0 0.6 0 }\n"
    "light point { position 0.3 3 0.2 power 200 }\n";

static pds_scene *shards_load(const char *text, pds_error *err)
{
    pds_scene *s = NULL;
    if (pds_scene_load_string(text, "shards.scene", &s, err) != PDS_OK) return NULL;
    return s;
}

/* One method and its options, small enough for a test. */
typedef struct shards_case {
    const char *name;
    pds_method method;
    int progressive;
    pds_method caustics; /* gi */
    pds_paths paths;     /* default PDS_PATHS_ALL */
    int eye_rounds;      /* progressive pds */
    int select;          /* progressive pds: the pixels' second scale */
    long photons;        /* 0: 6000 */
} shards_case;

static const shards_case shards_cases[] = {
    /* 0: since 7 December 2026 its 6000 photons take the default's 3 eye
       rounds (one every 1.5 w h spp photons: 5, held to its 3 passes);
       gi's cases keep progressive PDS's one eye pass */
    {"pds (progressive)", PDS_METHOD_PDS, 1, PDS_METHOD_PDS, PDS_PATHS_ALL, 0, 0, 0},
    {"pds (paper)", PDS_METHOD_PDS, 0, PDS_METHOD_PDS, PDS_PATHS_ALL, 0, 0, 0},
    {"splat", PDS_METHOD_SPLAT, 0, PDS_METHOD_PDS, PDS_PATHS_ALL, 0, 0, 0},
    {"pm", PDS_METHOD_PM, 0, PDS_METHOD_PDS, PDS_PATHS_ALL, 0, 0, 0},
    {"pdm", PDS_METHOD_PDM, 0, PDS_METHOD_PDS, PDS_PATHS_ALL, 0, 0, 0},
    {"ppm", PDS_METHOD_PPM, 0, PDS_METHOD_PDS, PDS_PATHS_ALL, 0, 0, 0},
    {"pt", PDS_METHOD_PT, 0, PDS_METHOD_PDS, PDS_PATHS_ALL, 0, 0, 0},
    /* 7: gi with caustics split by photon passes (the gather of every
       row's eye vertex but the shard's own is skipped); 8: by gathers */
    {"gi (pds caustics)", PDS_METHOD_GI, 1, PDS_METHOD_PDS, PDS_PATHS_ALL, 0, 0, 0},
    {"gi (pm caustics)", PDS_METHOD_GI, 0, PDS_METHOD_PM, PDS_PATHS_ALL, 0, 0, 0},
    /* 9: spm's full image, gi's with streams and spm caustics */
    {"spm", PDS_METHOD_SPM, 0, PDS_METHOD_PDS, PDS_PATHS_ALL, 0, 0, 0},
    {"isc", PDS_METHOD_ISC, 0, PDS_METHOD_PDS, PDS_PATHS_ALL, 0, 0, 0},
    {"spm (caustics only)", PDS_METHOD_SPM, 0, PDS_METHOD_PDS, PDS_PATHS_CAUSTICS_ONLY, 0, 0, 0},
    /* 12: a photon budget's eye rounds, one a pass: every shard traces
       every round's direct light and the rounds of its passes */
    {"pds (eye rounds)", PDS_METHOD_PDS, 1, PDS_METHOD_PDS, PDS_PATHS_ALL, 3, 0, 0},
    /* 13: the pixels' choice of two scales, from the odd and even passes
       of every shard; and the pixels seen through the glass ball choose
       their blur by the odd passes' half (pass 1, in the second shard) */
    {"pds (two scales)", PDS_METHOD_PDS, 1, PDS_METHOD_PDS, PDS_PATHS_ALL, 0, 1, 0},
    /* 14: a photon budget's default eye rounds, one every 1.5 w h spp
       photons, with more photons (24 x 16 x 2 samples: 12288 photons, 10
       rounds, held to one a pass: 6), which every shard works out alike */
    {"pds (default eye rounds)", PDS_METHOD_PDS, 1, PDS_METHOD_PDS, PDS_PATHS_ALL, 0, 0, 12288},
    /* 15: caustics only, a round a pass: the shards of rounds 1 and 2
       trace round 0 first, whose whole pixels every later round keeps */
    {"pds (caustic eye rounds)", PDS_METHOD_PDS, 1, PDS_METHOD_PDS, PDS_PATHS_CAUSTICS_ONLY, 3, 1, 0},
};

static void shards_options(const shards_case *c, pds_options *opt)
{
    pds_options_default(opt);
    opt->method = c->method;
    opt->progressive = c->progressive;
    opt->caustics = c->caustics;
    opt->paths = c->paths;
    opt->eye_rounds = c->eye_rounds;
    opt->pass_select = c->select;
    opt->global_photons = 3000; /* gi, spm */
    opt->gather = 4;
    opt->stream_photons = 4; /* spm: 1200 caustic streams, 600 global ones */
    opt->stream_radius = 0.2;
    opt->light_resolution = 64; /* isc */
    opt->photons = c->photons ? c->photons : 6000; /* pds: 6 batches; progressive: 3 passes of 2000 */
    opt->pass_photons = 2048;
    opt->passes = 2;          /* ppm */
    opt->k = 20;
    opt->max_photons = 100;
    opt->threads = 2;
}

static int shards_same(const pds_image *a, const pds_image *b)
{
    return a->width == b->width && a->height == b->height &&
           memcmp(a->rgb, b->rgb, sizeof *a->rgb * 3 * (size_t)a->width * (size_t)a->height) == 0;
}

/* The image of parts, merged in the order given. */
static pds_status shards_merge(pds_partial **parts, int n, int subset, pds_image *img, double *fraction,
                               pds_error *err)
{
    return pds_partial_merge((const pds_partial *const *)parts, NULL, n, subset, img, fraction, err);
}

/* Every method: three shards (on 1, 2 and 1 threads), merged in any
   order, equal the single run bit for bit; and the single run's image is
   not black (the test would hold trivially for an empty image). gi's
   shards make between them the single run's final-gather rays: each eye
   sample is gathered by one shard only, though every shard records the
   eye vertices of all rows for pds caustics. */
static void test_shards_merge_equals_the_single_run_bit_for_bit(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = shards_load(shards_scene, &err);
    size_t k;
    REQUIRE(t, s != NULL, "load: %s", err.text);
    for (k = 0; k < sizeof shards_cases / sizeof shards_cases[0]; k++) {
        const shards_case *c = &shards_cases[k];
        pds_options opt;
        pds_image full = {0, 0, NULL}, merged = {0, 0, NULL};
        pds_partial *parts[3] = {NULL, NULL, NULL}, *shuffled[3];
        pds_render_stats fst;
        double fraction = 0.0, caustic = 0.0;
        long gather_rays = 0;
        int i;
        size_t p;
        shards_options(c, &opt);
        REQUIRE(t, pds_render(s, &opt, &full, &fst, &err) == PDS_OK, "%s: render: %s", c->name, err.text);
        for (p = 0; p < 3 * (size_t)full.width * full.height; p++) caustic += full.rgb[p];
        CHECK(t, caustic > 0.0, "%s: a black image", c->name);
        if (c->select) CHECK(t, fst.through_pixels > 0, "%s: no pixel seen through glass took a blur", c->name);
        for (i = 0; i < 3; i++) {
            pds_render_stats st;
            opt.shard_index = i;
            opt.shard_count = 3;
            opt.threads = i == 1 ? 2 : 1;
            CHECK(t, pds_render_part(s, &opt, &parts[i], &st, &err) == PDS_OK, "%s: shard %d: %s", c->name, i,
                  err.text);
            CHECK(t, st.partial == 0 && st.done_fraction == 1.0, "%s: shard %d is not whole", c->name, i);
            gather_rays += st.gather_rays;
        }
        if (c->method == PDS_METHOD_GI || (c->method == PDS_METHOD_SPM && c->paths != PDS_PATHS_CAUSTICS_ONLY))
            CHECK(t, fst.gather_rays > 0 && gather_rays == fst.gather_rays,
                  "%s: %ld gather rays in the shards, %ld in one", c->name, gather_rays, fst.gather_rays);
        shuffled[0] = parts[2];
        shuffled[1] = parts[0];
        shuffled[2] = parts[1];
        if (parts[0] && parts[1] && parts[2]) {
            CHECK(t, shards_merge(shuffled, 3, 0, &merged, &fraction, &err) == PDS_OK, "%s: merge: %s", c->name,
                  err.text);
            CHECK(t, fraction == 1.0, "%s: fraction %g", c->name, fraction);
            CHECK(t, merged.rgb && shards_same(&merged, &full), "%s: the merged shards differ from the single run",
                  c->name);
        }
        for (i = 0; i < 3; i++) pds_partial_free(parts[i]);
        pds_image_free(&full);
        pds_image_free(&merged);
    }
    pds_scene_free(s);
}

/* A spectral render (scenes/prism.scene: dispersive glass, so one
   wavelength per photon): its photon part is a positive and a negative
   exact sum (>>spectral's XYZ-to-RGB matrix has negative entries). Three
   shards of pds and pm, each through its partial file, merge to the single
   run bit for bit, and a pds shard's file holds negative sums (else the
   test would not exercise them). */
static unsigned char *shards_slurp(const char *path, size_t *n);

static void test_shards_spectral_merge_equals_the_single_run(pds_test_ctx *t)
{
    static const pds_method methods[] = {PDS_METHOD_PDS, PDS_METHOD_PM};
    pds_error err;
    pds_scene *s = NULL;
    char path[128];
    size_t m;
    REQUIRE(t, pds_scene_load("scenes/prism.scene", &s, &err) == PDS_OK, "load: %s", err.text);
    snprintf(path, sizeof path, "/tmp/pds_test_spectral_%ld.pdsp", (long)getpid());
    for (m = 0; m < sizeof methods / sizeof methods[0]; m++) {
        pds_options opt;
        pds_image full = {0, 0, NULL}, merged = {0, 0, NULL};
        pds_partial *parts[3] = {NULL, NULL, NULL};
        const char *name = m == 0 ? "pds" : "pm";
        int i, negative = 0;
        pds_options_default(&opt);
        opt.method = methods[m];
        opt.progressive = 0;
        opt.width = 24;
        opt.height = 16;
        opt.spp = 1;
        opt.photons = 6000;
        opt.k = 20;
        opt.threads = 2;
        REQUIRE(t, pds_render(s, &opt, &full, NULL, &err) == PDS_OK, "%s: render: %s", name, err.text);
        for (i = 0; i < 3; i++) {
            pds_partial *p = NULL;
            opt.shard_index = i;
            opt.shard_count = 3;
            opt.threads = i == 1 ? 2 : 1;
            CHECK(t, pds_render_part(s, &opt, &p, NULL, &err) == PDS_OK, "%s: shard %d: %s", name, i, err.text);
            CHECK(t, p && pds_partial_write(path, p, &err) == PDS_OK, "%s: write: %s", name, err.text);
            CHECK(t, pds_partial_read(path, &parts[i], &err) == PDS_OK, "%s: read: %s", name, err.text);
            if (m == 0 && i == 0 && parts[0]) {
                /* the S- sums read back from the file */
                size_t k;
                for (k = 0; k < 24 * 16 * 3; k++) negative |= parts[0]->neg[k].lo != 0 || parts[0]->neg[k].hi != 0;
                CHECK(t, negative, "pds: the spectral shard holds no negative sums");
            }
            pds_partial_free(p);
        }
        remove(path);
        if (parts[0] && parts[1] && parts[2]) {
            CHECK(t, shards_merge(parts, 3, 0, &merged, NULL, &err) == PDS_OK, "%s: merge: %s", name, err.text);
            CHECK(t, merged.rgb && shards_same(&merged, &full), "%s: the merged spectral shards differ from the single run",
                  name);
        }
        for (i = 0; i < 3; i++) pds_partial_free(parts[i]);
        pds_image_free(&full);
        pds_image_free(&merged);
    }
    pds_scene_free(s);
}

/* A progress callback that asks to stop at its stop_at-th call, and
   records the phases it saw. */
typedef struct shards_stopper {
    int calls, stop_at;
    int phases[3];      /* calls per pds_phase */
    int order_broken;   /* a phase came after a later one */
    int last;
} shards_stopper;

static int shards_stop(void *user, pds_phase phase, double fraction, double elapsed_s)
{
    shards_stopper *s = (shards_stopper *)user;
    (void)elapsed_s;
    if ((unsigned)phase < 3) s->phases[phase]++;
    if ((int)phase < s->last || !(fraction >= 0.0 && fraction <= 1.0)) s->order_broken = 1;
    s->last = (int)phase;
    return ++s->calls == s->stop_at;
}

/* Stopped through the progress callback, written to a partial file, read
   back and continued on two threads: the image equals the uninterrupted
   render's, for a stop in the eye pass (pt; pds and ppm, whose eye pass
   starts over) and in the photon pass (pds after its first pass, the
   paper's pds after two batches, pm, whose photons start over). The
   stopped render's own image is a real partial image. */
static void test_shards_interrupt_and_resume_equal_the_uninterrupted_render(pds_test_ctx *t)
{
    static const struct {
        int case_index;
        int stop_at;
        int threads;
    } runs[] = {/* one thread: only the calling thread reports, so the call
                   counts are exact: 16 eye rows, then batches or passes */
                {6, 5, 1}, {0, 3, 1}, {0, 17, 1}, {1, 18, 1}, {3, 18, 1}, {5, 3, 1},
                /* gi in its eye pass and after its first photon pass (pds
                   caustics), and in its photon pass (pm caustics: its
                   photons start over); spm in its eye pass and photons */
                {7, 3, 1}, {7, 17, 1}, {8, 18, 1}, {9, 3, 1}, {9, 18, 1},
                /* eye rounds: in the second round's direct light (16 rows
                   of each of 3 rounds first), after the second pass */
                {12, 20, 1}, {12, 50, 1}};
    pds_error err;
    pds_scene *s = shards_load(shards_scene, &err);
    char path[128];
    size_t r;
    REQUIRE(t, s != NULL, "load: %s", err.text);
    snprintf(path, sizeof path, "/tmp/pds_test_resume_%ld.pdsp", (long)getpid());
    for (r = 0; r < sizeof runs / sizeof runs[0]; r++) {
        const shards_case *c = &shards_cases[runs[r].case_index];
        pds_options opt;
        pds_image full = {0, 0, NULL}, stopped = {0, 0, NULL}, resumed = {0, 0, NULL};
        pds_render_stats st;
        pds_partial *part = NULL, *back = NULL;
        shards_stopper stopper;
        memset(&stopper, 0, sizeof stopper);
        stopper.stop_at = runs[r].stop_at;
        shards_options(c, &opt);
        REQUIRE(t, pds_render(s, &opt, &full, NULL, &err) == PDS_OK, "%s: render: %s", c->name, err.text);
        opt.threads = runs[r].threads;
        opt.progress = shards_stop;
        opt.progress_user = &stopper;
        CHECK(t, pds_render(s, &opt, &stopped, &st, &err) == PDS_OK, "%s: stopped render: %s", c->name, err.text);
        CHECK(t, st.partial == 1 && st.done_fraction < 1.0, "%s, stop at call %d: partial %d, done %g", c->name,
              runs[r].stop_at, st.partial, st.done_fraction);
        CHECK(t, stopped.rgb && !shards_same(&stopped, &full), "%s: the stopped image is the whole one", c->name);
        /* the same stop through pds_render_part, kept in a file */
        stopper.calls = 0;
        CHECK(t, pds_render_part(s, &opt, &part, &st, &err) == PDS_OK && st.partial == 1, "%s: part: %s", c->name,
              err.text);
        CHECK(t, part && pds_partial_write(path, part, &err) == PDS_OK, "%s: write: %s", c->name, err.text);
        CHECK(t, pds_partial_read(path, &back, &err) == PDS_OK, "%s: read: %s", c->name, err.text);
        if (back) {
            opt.progress = NULL;
            opt.threads = 2;
            CHECK(t, pds_render_part(s, &opt, &back, &st, &err) == PDS_OK && st.partial == 0 && st.done_fraction == 1.0,
                  "%s: resume: %s", c->name, err.text);
            CHECK(t, shards_merge(&back, 1, 0, &resumed, NULL, &err) == PDS_OK, "%s: image: %s", c->name, err.text);
            CHECK(t, resumed.rgb && shards_same(&resumed, &full), "%s (stop at call %d): resumed differs from the "
                  "uninterrupted render", c->name, runs[r].stop_at);
        }
        pds_partial_free(part);
        pds_partial_free(back);
        pds_image_free(&full);
        pds_image_free(&stopped);
        pds_image_free(&resumed);
    }
    remove(path);
    pds_scene_free(s);
}

/* isc renders its frame in one go: a stop asked for by the callback lets
   the frame finish, and the part is whole (its image the render's). */
static void test_shards_isc_stop_finishes_the_frame(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = shards_load(shards_scene, &err);
    pds_options opt;
    pds_image full = {0, 0, NULL}, stopped = {0, 0, NULL};
    pds_render_stats st;
    shards_stopper stopper;
    REQUIRE(t, s != NULL, "load: %s", err.text);
    shards_options(&shards_cases[10], &opt);
    REQUIRE(t, pds_render(s, &opt, &full, NULL, &err) == PDS_OK, "render: %s", err.text);
    memset(&stopper, 0, sizeof stopper);
    stopper.stop_at = 1;
    opt.progress = shards_stop;
    opt.progress_user = &stopper;
    CHECK(t, pds_render(s, &opt, &stopped, &st, &err) == PDS_OK, "stopped: %s", err.text);
    CHECK(t, stopper.calls >= 1 && st.partial == 0 && st.done_fraction == 1.0 && shards_same(&stopped, &full),
          "calls %d, partial %d, done %g: not the whole frame", stopper.calls, st.partial, st.done_fraction);
    pds_image_free(&full);
    pds_image_free(&stopped);
    pds_scene_free(s);
}

/* The callback names the phases in the order the render goes through
   them: eye pass, photons, gather (pm); fractions stay in [0, 1]. */
static void test_shards_progress_names_the_phases_in_order(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = shards_load(shards_scene, &err);
    pds_options opt;
    pds_image img = {0, 0, NULL};
    shards_stopper seen;
    REQUIRE(t, s != NULL, "load: %s", err.text);
    memset(&seen, 0, sizeof seen);
    shards_options(&shards_cases[3], &opt);
    opt.threads = 1; /* only the calling thread reports: with two, the other may take every row */
    opt.progress = shards_stop;
    opt.progress_user = &seen;
    seen.stop_at = -1;
    CHECK(t, pds_render(s, &opt, &img, NULL, &err) == PDS_OK, "render: %s", err.text);
    CHECK(t, seen.phases[PDS_PHASE_EYE] > 0 && seen.phases[PDS_PHASE_PHOTONS] > 0 && seen.phases[PDS_PHASE_GATHER] > 0,
          "eye %d, photons %d, gather %d", seen.phases[0], seen.phases[1], seen.phases[2]);
    CHECK(t, !seen.order_broken, "phases out of order or a fraction outside [0, 1]");
    pds_image_free(&img);
    pds_scene_free(s);
}

/* Parts of another scene, of other options, the same shard twice, a
   missing or unfinished shard: refused with a message that says which.
   A subset merges when asked for, and says what fraction it holds. */
static void test_shards_merge_refuses_foreign_duplicate_and_missing_parts(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = shards_load(shards_scene, &err), *other = NULL;
    pds_options opt;
    pds_partial *p[3] = {NULL, NULL, NULL}, *foreign = NULL, *seeded = NULL, *set[3];
    pds_image img = {0, 0, NULL};
    static const char *const names[] = {"a.pdsp", "b.pdsp", "c.pdsp"};
    char text[sizeof shards_scene + 8];
    double fraction = 0.0;
    int i;
    REQUIRE(t, s != NULL, "load: %s", err.text);
    /* the same scene with a brighter light */
    snprintf(text, sizeof text, "%s", shards_scene);
    memcpy(strstr(text, "power 200"), "power 201", 9);
    REQUIRE(t, pds_scene_load_string(text, "other.scene", &other, &err) == PDS_OK, "load: %s", err.text);
    CHECK(t, pds_scene_hash(s) != pds_scene_hash(other), "a changed light does not change the hash");
    shards_options(&shards_cases[6], &opt); /* pt: cheap */
    opt.shard_count = 3;
    for (i = 0; i < 3; i++) {
        opt.shard_index = i;
        REQUIRE(t, pds_render_part(s, &opt, &p[i], NULL, &err) == PDS_OK, "shard %d: %s", i, err.text);
    }
    opt.shard_index = 1;
    REQUIRE(t, pds_render_part(other, &opt, &foreign, NULL, &err) == PDS_OK, "foreign: %s", err.text);
    opt.seed = 7;
    REQUIRE(t, pds_render_part(s, &opt, &seeded, NULL, &err) == PDS_OK, "seeded: %s", err.text);

    set[0] = p[0];
    set[1] = foreign;
    set[2] = p[2];
    CHECK(t, pds_partial_merge((const pds_partial *const *)set, names, 3, 0, &img, NULL, &err) == PDS_ERR_INVALID_ARG &&
                 strstr(err.text, "b.pdsp: a part of another scene (other.scene") &&
                 strstr(err.text, "than a.pdsp (shards.scene"),
          "foreign: %s", err.text);
    set[1] = seeded;
    CHECK(t, pds_partial_merge((const pds_partial *const *)set, names, 3, 0, &img, NULL, &err) == PDS_ERR_INVALID_ARG &&
                 !strcmp(err.text, "b.pdsp: a part of the same scene rendered with other options than a.pdsp"),
          "options: %s", err.text);
    set[1] = p[0];
    CHECK(t, pds_partial_merge((const pds_partial *const *)set, names, 3, 1, &img, NULL, &err) == PDS_ERR_INVALID_ARG &&
                 !strcmp(err.text, "b.pdsp: shard 1/3 again: a.pdsp is that shard too"),
          "duplicate: %s", err.text);
    set[1] = p[2];
    CHECK(t, pds_partial_merge((const pds_partial *const *)set, names, 2, 0, &img, NULL, &err) == PDS_ERR_INVALID_ARG &&
                 !strcmp(err.text, "shard 2/3 is missing (2 of 3 given; --partial merges a subset)"),
          "missing: %s", err.text);
    CHECK(t, pds_partial_merge((const pds_partial *const *)set, names, 2, 1, &img, &fraction, &err) == PDS_OK,
          "subset: %s", err.text);
    /* rows 0, 3, ... (6 of 16) and 2, 5, ... (5 of 16) */
    CHECK(t, fraction == 11.0 / 16.0, "subset fraction %g", fraction);
    if (img.rgb) {
        /* row 10 belongs to the missing shard: black; row 9 (shard 1) is not */
        double row9 = 0.0, row10 = 0.0;
        int x;
        for (x = 0; x < 3 * img.width; x++) {
            row9 += img.rgb[9 * 3 * img.width + x];
            row10 += img.rgb[10 * 3 * img.width + x];
        }
        CHECK(t, row9 > 0.0 && row10 == 0.0, "rows 9 and 10: %g %g", row9, row10);
    }
    pds_image_free(&img);
    /* an unfinished shard */
    {
        shards_stopper stopper;
        pds_partial *half = NULL;
        memset(&stopper, 0, sizeof stopper);
        stopper.stop_at = 2;
        opt.seed = 0;
        opt.shard_index = 1;
        opt.threads = 1;
        opt.progress = shards_stop;
        opt.progress_user = &stopper;
        REQUIRE(t, pds_render_part(s, &opt, &half, NULL, &err) == PDS_OK, "half: %s", err.text);
        set[0] = p[0];
        set[1] = half;
        set[2] = p[2];
        CHECK(t, pds_partial_merge((const pds_partial *const *)set, names, 3, 0, &img, NULL, &err) ==
                         PDS_ERR_INVALID_ARG &&
                     !strcmp(err.text, "b.pdsp: shard 2/3 is unfinished (40.0% done): continue it with --resume, or "
                                       "merge with --partial"),
              "unfinished: %s", err.text);
        pds_partial_free(half);
    }
    for (i = 0; i < 3; i++) pds_partial_free(p[i]);
    pds_partial_free(foreign);
    pds_partial_free(seeded);
    pds_scene_free(other);
    pds_scene_free(s);
}

/* Read a whole file into memory (test helper). */
static unsigned char *shards_slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    unsigned char *b;
    long len;
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    len = ftell(f);
    fseek(f, 0, SEEK_SET);
    b = (unsigned char *)malloc((size_t)len + 1);
    if (b && fread(b, 1, (size_t)len, f) != (size_t)len) {
        free(b);
        b = NULL;
    }
    fclose(f);
    *n = (size_t)len;
    return b;
}

static void shards_spit(const char *path, const unsigned char *b, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f) return;
    fwrite(b, 1, n, f);
    fclose(f);
}

/* Part p's file as format version 9 wrote it (its values whole, not in
   groups) from its version-10 file's header (1072 bytes at `file`): the
   header, every value word in order (pds__partial_word), the check sum.
   *n gets its length. */
static unsigned char *shards_whole_v9(const pds_partial *p, const unsigned char *file, size_t *n)
{
    size_t words = (size_t)pds__partial_words(p->width, p->height, p->split, p->rows_done, p->stride), k;
    unsigned char *b;
    *n = 1072 + 8 * words + 8;
    b = (unsigned char *)malloc(*n);
    if (!b) return NULL;
    memcpy(b, file, 1072);
    b[8] = 9;
    for (k = 0; k < words; k++) pds__put_u64(b + 1072 + 8 * k, pds__partial_word(p, k));
    pds__put_u64(b + *n - 8, pds__fnv1a64(b, *n - 8));
    return b;
}

/* The partial file: what is written reads back the same (same info, same
   image), the layout is the README's (magic, little-endian fields at their
   offsets), and a file of another format version, another library
   version, damaged or truncated is refused with a message saying which. */
static void test_shards_partial_file_round_trips_and_is_versioned(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = shards_load(shards_scene, &err);
    pds_options opt;
    pds_partial *p = NULL, *back = NULL;
    pds_partial_info a, b;
    pds_image ia = {0, 0, NULL}, ib = {0, 0, NULL};
    char path[128], bad[140];
    unsigned char *bytes, *copy;
    size_t n = 0;
    REQUIRE(t, s != NULL, "load: %s", err.text);
    snprintf(path, sizeof path, "/tmp/pds_test_part_%ld.pdsp", (long)getpid());
    snprintf(bad, sizeof bad, "%s.bad", path);
    shards_options(&shards_cases[0], &opt);
    {
        /* gi's, spm's and isc's options at their defaults, as every
           render stored in format version 2 had them */
        pds_options d;
        pds_options_default(&d);
        opt.global_photons = d.global_photons;
        opt.gather = d.gather;
        opt.stream_photons = d.stream_photons;
        opt.stream_radius = d.stream_radius; /* format version 4 */
        opt.light_resolution = d.light_resolution;
    }
    opt.walls = 0;       /* format version 7: every render of an earlier version splatted without walls */
    opt.pass_select = 0; /* format version 9 (8): ... and with one scale */
    opt.shard_index = 1;
    opt.shard_count = 2;
    REQUIRE(t, pds_render_part(s, &opt, &p, NULL, &err) == PDS_OK, "render: %s", err.text);
    REQUIRE(t, pds_partial_write(path, p, &err) == PDS_OK, "write: %s", err.text);
    REQUIRE(t, pds_partial_read(path, &back, &err) == PDS_OK, "read: %s", err.text);
    pds_partial_get_info(p, &a);
    pds_partial_get_info(back, &b);
    CHECK(t, a.shard_index == 1 && b.shard_index == 1 && b.shard_count == 2 && b.width == 24 && b.height == 16 &&
                 b.method == PDS_METHOD_PDS && b.scene_hash == pds_scene_hash(s) && b.complete &&
                 !strcmp(b.scene_path, "shards.scene") && b.units_done == a.units_done && b.units_total == 1,
          "info: shard %d/%d %dx%d units %ld/%ld", b.shard_index, b.shard_count, b.width, b.height, b.units_done,
          b.units_total);
    CHECK(t, shards_merge(&p, 1, 1, &ia, NULL, &err) == PDS_OK && shards_merge(&back, 1, 1, &ib, NULL, &err) == PDS_OK &&
                 shards_same(&ia, &ib),
          "the image read back differs");
    pds_partial_free(back);
    back = NULL;
    {
        /* format version 11 (as 10) holds the values in groups (most words are 0:
           the S- of an RGB render, pixels no photon reached), fewer bytes
           than their 8 rows of 24 x 3 doubles and 2 x 24 x 16 x 3 sums
           whole; a file of version 9, the same header and the values
           whole, reads back to the same part */
        size_t n10 = 0, whole = 1072 + 8 * 24 * 3 * 8 + 2 * 24 * 16 * 3 * 16 + 8;
        unsigned char *v10 = shards_slurp(path, &n10);
        REQUIRE(t, v10 != NULL && n10 > 1072 + 16, "slurp");
        CHECK(t, v10[8] == 11 && n10 < whole, "version %d, %lu bytes (%lu whole)", v10[8], (unsigned long)n10,
              (unsigned long)whole);
        bytes = shards_whole_v9(p, v10, &n);
        REQUIRE(t, bytes != NULL && n == whole, "version 9: %lu bytes", (unsigned long)n);
        shards_spit(bad, bytes, n);
        pds_image_free(&ib);
        CHECK(t, pds_partial_read(bad, &back, &err) == PDS_OK && shards_merge(&back, 1, 1, &ib, NULL, &err) == PDS_OK &&
                     shards_same(&ia, &ib),
              "version 9: %s", err.text);
        pds_partial_free(back);
        back = NULL;
        /* a group that claims a word more, or a file cut short, is refused
           before its check sum is looked at */
        free(bytes);
        bytes = (unsigned char *)malloc(n10);
        REQUIRE(t, bytes != NULL, "malloc");
        memcpy(bytes, v10, n10);
        pds__put_u64(bytes + 1072 + 8, pds__get_u64(v10 + 1072 + 8) + 1);
        shards_spit(bad, bytes, n10);
        CHECK(t, pds_partial_read(bad, &back, &err) == PDS_ERR_PARSE && strstr(err.text, "truncated or damaged"),
              "a group one word longer: %s", err.text);
        shards_spit(bad, v10, n10 - 24);
        CHECK(t, pds_partial_read(bad, &back, &err) == PDS_ERR_PARSE && strstr(err.text, "truncated or damaged"),
              "version 10 cut short: %s", err.text);
        free(bytes);
        bytes = shards_whole_v9(p, v10, &n);
        free(v10);
        REQUIRE(t, bytes != NULL, "version 9");
    }
    CHECK(t, !memcmp(bytes, "PDSPART\n", 8) && bytes[8] == 9 && bytes[9] == 0 && !strcmp((char *)bytes + 12, "0.2.0") &&
                 bytes[548] == 24 && bytes[552] == 16 && bytes[556] == 1 && bytes[560] == 2 && bytes[564] == 1 &&
                 bytes[568 + 8 * 41] == 4 && bytes[568 + 8 * 46] == 0xff && bytes[568 + 8 * 47] == 0 &&
                 bytes[568 + 8 * 48] == 0 && bytes[568 + 8 * 49] == 0 && bytes[968 + 8] == 3,
          "layout"); /* options 41 (history, default 4), 46 (diffuse bounces, default -1), 47 (eye rounds,
                        default 0), 48 (walls, 0 here) and 49 (pass_select, 0 here) and units total (3
                        passes) at their offsets */
    copy = (unsigned char *)malloc(n);
    REQUIRE(t, copy != NULL, "malloc");
    {
        /* format versions 2 to 8 are read: the same part without
           options 31-49, 44-49, 46-49, 47-49, 48-49 and 49 (at their
           defaults, as every render of those versions had them; walls
           off, one scale), and version 8's with all of them */
        static const struct { unsigned char version; size_t nopt; } old[7] = {{2, 31}, {3, 44}, {4, 46}, {5, 47},
                                                                              {6, 48}, {7, 49}, {8, 50}};
        int v;
        for (v = 0; v < 7; v++) {
            size_t at = 568 + 8 * old[v].nopt, cut = 968 - at;
            memcpy(copy, bytes, at);
            memcpy(copy + at, bytes + 968, n - 968);
            copy[8] = old[v].version;
            pds__put_u64(copy + n - cut - 8, pds__fnv1a64(copy, n - cut - 8));
            shards_spit(bad, copy, n - cut);
            CHECK(t, pds_partial_read(bad, &back, &err) == PDS_OK, "version %d: %s", old[v].version, err.text);
            if (back) {
                pds_image_free(&ib);
                pds_partial_get_info(back, &b);
                CHECK(t, b.units_done == a.units_done && b.complete &&
                             shards_merge(&back, 1, 1, &ib, NULL, &err) == PDS_OK && shards_same(&ia, &ib),
                      "version %d: another part or image read back", old[v].version);
                CHECK(t, pds__partial_same_options(&p->opt, &back->opt), "version %d: other options read back",
                      old[v].version);
                pds_partial_free(back);
                back = NULL;
            }
        }
    }
    memcpy(copy, bytes, n);
    copy[8] = 1;
    shards_spit(bad, copy, n);
    CHECK(t, pds_partial_read(bad, &back, &err) == PDS_ERR_PARSE &&
                 strstr(err.text, ": partial file format version 1; this pds reads versions 2 to 11"),
          "format version: %s", err.text);
    memcpy(copy, bytes, n);
    memcpy(copy + 12, "9.9.9", 5);
    shards_spit(bad, copy, n);
    CHECK(t, pds_partial_read(bad, &back, &err) == PDS_ERR_INVALID_ARG &&
                 strstr(err.text, ": written by pds 9.9.9, this is pds 0.2.0: versions may render differently"),
          "library version: %s", err.text);
    memcpy(copy, bytes, n);
    copy[1000] ^= 1;
    shards_spit(bad, copy, n);
    CHECK(t, pds_partial_read(bad, &back, &err) == PDS_ERR_PARSE && strstr(err.text, "check sum does not match"),
          "damaged: %s", err.text);
    shards_spit(bad, bytes, n - 100);
    CHECK(t, pds_partial_read(bad, &back, &err) == PDS_ERR_PARSE && strstr(err.text, "truncated or damaged"),
          "truncated: %s", err.text);
    shards_spit(bad, (const unsigned char *)"P6\n1 1\n255\n", 11);
    CHECK(t, pds_partial_read(bad, &back, &err) == PDS_ERR_PARSE && strstr(err.text, "not a PDS partial file"),
          "not a partial file: %s", err.text);
    CHECK(t, pds_partial_read("/tmp", &back, &err) == PDS_ERR_IO && strstr(err.text, "is a directory"), "folder: %s",
          err.text);
    /* continuing with other options, or another scene, is refused */
    opt.seed = 3;
    CHECK(t, pds_render_part(s, &opt, &p, NULL, &err) == PDS_ERR_INVALID_ARG &&
                 strstr(err.text, "not the ones the part was rendered with"),
          "other options: %s", err.text);
    {
        /* with the pixels' choice of scale the part holds 13 sums a pixel
           in each image, and reads back to the same image; format versions
           9 and 10 held 9 (no odd passes' apart) and version 8 other sums
           with it (the odd and even passes'), and such files are refused */
        pds_partial *q = NULL, *qb = NULL;
        unsigned char *qbytes;
        size_t qn = 0;
        opt.seed = 1;
        opt.pass_select = 1;
        REQUIRE(t, pds_render_part(s, &opt, &q, NULL, &err) == PDS_OK, "render, two scales: %s", err.text);
        REQUIRE(t, pds_partial_write(path, q, &err) == PDS_OK, "write, two scales: %s", err.text);
        qbytes = shards_slurp(path, &qn);
        if (qbytes) {
            /* the same part as version 9 wrote it, its values whole */
            unsigned char *v10 = qbytes;
            qbytes = shards_whole_v9(q, v10, &qn);
            free(v10);
        }
        CHECK(t, qbytes && qn == 1072 + 8 * 24 * 3 * 8 + 2 * 24 * 16 * 13 * 16 + 8 && qbytes[568 + 8 * 49] == 1,
              "two scales: %lu bytes", (unsigned long)qn);
        if (qbytes && qn > 16) {
            pds_partial *old8 = NULL;
            shards_spit(bad, qbytes, qn); /* as version 9 */
            CHECK(t, pds_partial_read(bad, &old8, &err) == PDS_ERR_PARSE &&
                         strstr(err.text, "a render with --pass-select in format version 9"),
                  "version 9 with its scales: %s", err.text);
            qbytes[8] = 8;
            pds__put_u64(qbytes + qn - 8, pds__fnv1a64(qbytes, qn - 8));
            shards_spit(bad, qbytes, qn);
            CHECK(t, pds_partial_read(bad, &old8, &err) == PDS_ERR_PARSE &&
                         strstr(err.text, "a render with --pass-select in format version 8"),
                  "version 8 with its scales: %s", err.text);
            pds_partial_free(old8);
        }
        free(qbytes);
        pds_image_free(&ia);
        pds_image_free(&ib);
        CHECK(t, pds_partial_read(path, &qb, &err) == PDS_OK && shards_merge(&q, 1, 1, &ia, NULL, &err) == PDS_OK &&
                     shards_merge(&qb, 1, 1, &ib, NULL, &err) == PDS_OK && shards_same(&ia, &ib),
              "two scales: the image read back differs");
        pds_partial_free(q);
        pds_partial_free(qb);
    }
    free(copy);
    free(bytes);
    remove(path);
    remove(bad);
    pds_partial_free(p);
    pds_partial_free(back);
    pds_image_free(&ia);
    pds_image_free(&ib);
    pds_scene_free(s);
}

/* Every field of pds_options, and whether the partial file keeps it:
   1 = it may change the image, so it is stored (and parts that differ in
   it are not one render); 0 = it cannot change the image (threads and
   the order of work, callbacks, a memory guard, the shard, which the
   header holds, isc's static lighting, which changes animation frames
   only). */
typedef struct shards_field {
    const char *name;
    size_t offset, size;
    int stored;
} shards_field;

#define SHARDS_FIELD(f, stored) {#f, offsetof(pds_options, f), sizeof(((pds_options *)0)->f), stored}
static const shards_field shards_fields[] = {
    SHARDS_FIELD(method, 1),         SHARDS_FIELD(paths, 1),           SHARDS_FIELD(width, 1),
    SHARDS_FIELD(height, 1),         SHARDS_FIELD(spp, 1),             SHARDS_FIELD(threads, 0),
    SHARDS_FIELD(seed, 1),           SHARDS_FIELD(max_depth, 1),       SHARDS_FIELD(rr_depth, 1),
    SHARDS_FIELD(time_s, 1),         SHARDS_FIELD(progress, 0),        SHARDS_FIELD(progress_user, 0),
    SHARDS_FIELD(photons, 1),        SHARDS_FIELD(smoothing, 1),       SHARDS_FIELD(plane_tolerance, 1),
    SHARDS_FIELD(min_aspect, 1),     SHARDS_FIELD(progressive, 1),     SHARDS_FIELD(pass_photons, 1),
    SHARDS_FIELD(pass_alpha, 1),     SHARDS_FIELD(pass_smoothing, 1),  SHARDS_FIELD(pass_min_aspect, 1),
    SHARDS_FIELD(pass_min_width, 1), SHARDS_FIELD(min_width, 1),       SHARDS_FIELD(photon_depth, 1),
    SHARDS_FIELD(split_depth, 1),    SHARDS_FIELD(split_angle, 1),     SHARDS_FIELD(k, 1),
    SHARDS_FIELD(kernel, 1),         SHARDS_FIELD(max_radius, 1),      SHARDS_FIELD(radius, 1),
    SHARDS_FIELD(alpha, 1),          SHARDS_FIELD(passes, 1),          SHARDS_FIELD(max_photons, 1),
    SHARDS_FIELD(streams, 1),        SHARDS_FIELD(stream_photons, 1),  SHARDS_FIELD(debug, 0),
    SHARDS_FIELD(spectral, 1),       SHARDS_FIELD(caustics, 1),        SHARDS_FIELD(global_photons, 1),
    SHARDS_FIELD(global_k, 1),       SHARDS_FIELD(gather, 1),          SHARDS_FIELD(gather_mix, 1),
    SHARDS_FIELD(shadow_photons, 1), SHARDS_FIELD(isc_gather, 1),      SHARDS_FIELD(light_resolution, 1),
    SHARDS_FIELD(history, 1),        SHARDS_FIELD(orbit, 1),           SHARDS_FIELD(orbit_deg, 1),
    SHARDS_FIELD(global_map, 1),     SHARDS_FIELD(stream_radius, 1),   SHARDS_FIELD(diffuse_bounces, 1),
    SHARDS_FIELD(memory_limit, 0),   SHARDS_FIELD(shard_index, 0),     SHARDS_FIELD(shard_count, 0),
    SHARDS_FIELD(static_lighting, 0), SHARDS_FIELD(eye_rounds, 1), SHARDS_FIELD(walls, 1),
    SHARDS_FIELD(pass_select, 1),
};

/* The names of pds_options's fields as pds.h declares them: comments
   taken out, then the last identifier of every declarator between the
   struct's braces ("int width, height;" gives width and height). n names
   at most; returns how many, or -1 if pds.h cannot be read. */
static int shards_header_fields(char names[][40], int n)
{
    size_t len = 0, i, o = 0;
    unsigned char *h = shards_slurp("pds.h", &len);
    char *text, *body, *end, *decl;
    int count = 0;
    if (!h) return -1;
    text = (char *)malloc(len + 1);
    for (i = 0; text && i < len; i++) {
        if (h[i] == '/' && i + 1 < len && h[i + 1] == '*') {
            for (i += 2; i + 1 < len && !(h[i] == '*' && h[i + 1] == '/'); i++) {}
            i++;
            text[o++] = ' ';
        } else {
            text[o++] = (char)h[i];
        }
    }
    free(h);
    if (!text) return -1;
    text[o] = '\0';
    body = strstr(text, "typedef struct pds_options {");
    end = body ? strstr(body, "} pds_options;") : NULL;
    if (!body || !end) {
        free(text);
        return -1;
    }
    *end = '\0';
    body = strchr(body, '{') + 1;
    for (decl = strtok(body, ";"); decl; decl = strtok(NULL, ";")) {
        char *part = decl, *comma;
        do {
            char *e;
            comma = strchr(part, ',');
            e = comma ? comma : part + strlen(part);
            while (e > part && !(isalnum((unsigned char)e[-1]) || e[-1] == '_')) e--;
            {
                char *b = e;
                while (b > part && (isalnum((unsigned char)b[-1]) || b[-1] == '_')) b--;
                if (e > b && count < n) {
                    snprintf(names[count], 40, "%.*s", (int)(e - b), b);
                    count++;
                }
            }
            part = comma ? comma + 1 : NULL;
        } while (part);
    }
    free(text);
    return count;
}

/* The partial file keeps every option that may change the image: each
   field pds.h declares in pds_options is in the table above (a new field
   fails here until it is placed), a stored field changes the stored
   options when it changes (and reads back), a field listed as not
   shaping the image does not. */
static void test_shards_partial_file_keeps_every_option_that_shapes_the_image(pds_test_ctx *t)
{
    char names[128][40];
    int n = shards_header_fields(names, 128), i;
    size_t f, nf = sizeof shards_fields / sizeof shards_fields[0];
    pds_options base;
    uint64_t v0[PDS__PARTIAL_NOPT];
    REQUIRE(t, n > 40, "pds.h: found %d fields of pds_options", n);
    CHECK(t, (size_t)n == nf, "pds.h declares %d fields of pds_options, the table lists %lu", n, (unsigned long)nf);
    for (i = 0; i < n; i++) {
        int listed = 0;
        for (f = 0; f < nf; f++) listed |= !strcmp(names[i], shards_fields[f].name);
        CHECK(t, listed, "pds_options.%s is neither stored in the partial file nor listed as not shaping the image",
              names[i]);
    }
    pds_options_default(&base);
    pds__partial_opt_encode(&base, v0);
    for (f = 0; f < nf; f++) {
        const shards_field *fd = &shards_fields[f];
        pds_options o = base, back;
        uint64_t v[PDS__PARTIAL_NOPT];
        unsigned char *bytes = (unsigned char *)&o + fd->offset;
        if (fd->size == sizeof(void *) && (!strcmp(fd->name, "progress") || !strcmp(fd->name, "progress_user") ||
                                           !strcmp(fd->name, "debug")))
            continue; /* pointers: not values to flip */
        bytes[0] ^= 1; /* another value of any integer, enum or binary64 */
        pds__partial_opt_encode(&o, v);
        CHECK(t, (memcmp(v, v0, sizeof v) != 0) == fd->stored, "pds_options.%s: %s", fd->name,
              fd->stored ? "a change is not stored" : "listed as not shaping the image, but stored");
        pds__partial_opt_decode(v, PDS__PARTIAL_NOPT, &back);
        if (fd->stored)
            CHECK(t, !memcmp((unsigned char *)&back + fd->offset, bytes, fd->size), "pds_options.%s does not read back",
                  fd->name);
    }
}

/* The teaching views are made by a render in one go: a shard or a
   continued render is refused (its views would show part of the photons),
   and a render in one go still gets them through the part it renders. */
static void test_shards_refuse_teaching_views(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = shards_load(shards_scene, &err);
    pds_options opt;
    pds_debug dbg;
    pds_partial *p = NULL;
    pds_image img = {0, 0, NULL};
    REQUIRE(t, s != NULL, "load: %s", err.text);
    pds_debug_init(&dbg);
    dbg.views = 1u << PDS_DEBUG_LANDINGS;
    shards_options(&shards_cases[0], &opt);
    opt.debug = &dbg;
    opt.shard_count = 2;
    CHECK(t, pds_render_part(s, &opt, &p, NULL, &err) == PDS_ERR_INVALID_ARG && strstr(err.text, "not made for shards"),
          "shard with views: %s", err.text);
    CHECK(t, p == NULL, "a refused shard made a part");
    /* a part half done, then continued with views: refused */
    opt.shard_count = 1;
    opt.debug = NULL;
    {
        shards_stopper stopper;
        pds_render_stats st;
        memset(&stopper, 0, sizeof stopper);
        stopper.stop_at = 3; /* in the eye pass */
        opt.threads = 1;
        opt.progress = shards_stop;
        opt.progress_user = &stopper;
        REQUIRE(t, pds_render_part(s, &opt, &p, &st, &err) == PDS_OK && st.partial, "first part: %s", err.text);
    }
    opt.progress = NULL;
    opt.debug = &dbg;
    CHECK(t, pds_render_part(s, &opt, &p, NULL, &err) == PDS_ERR_INVALID_ARG && strstr(err.text, "in one go"),
          "continued with views: %s", err.text);
    /* in one go: the landings view counts the photons that landed in frame */
    REQUIRE(t, pds_render(s, &opt, &img, NULL, &err) == PDS_OK, "render: %s", err.text);
    CHECK(t, dbg.value[PDS_DEBUG_LANDINGS].rgb != NULL && dbg.landings_in_frame > 0, "no landings view (%ld)",
          dbg.landings_in_frame);
    pds_debug_free(&dbg);
    pds_image_free(&img);
    pds_partial_free(p);
    pds_scene_free(s);
}

#ifdef PDS_TEST_POSIX /* the tests that drive the pds tool through a shell */

/* The image of the scene file at path as pds_render makes it here. */
static int shards_render_file(const char *path, pds_method method, int w, int h, int spp, long photons, pds_image *img)
{
    pds_scene *s = NULL;
    pds_options opt;
    pds_error err;
    int ok;
    if (pds_scene_load(path, &s, &err) != PDS_OK) return 0;
    pds_options_default(&opt);
    opt.method = method;
    opt.width = w;
    opt.height = h;
    opt.spp = spp;
    opt.photons = photons;
    ok = pds_render(s, &opt, img, NULL, &err) == PDS_OK;
    pds_scene_free(s);
    return ok;
}

/* A real `pds render` stopped by SIGINT: exit status 130, the image so far
   and OUT.pdsp written; `pds render --resume OUT.pdsp` finishes it to the
   image of the render in one go, bit for bit, and removes OUT.pdsp. The
   signal is sent once the render has begun: when its first progress line
   (--progress, into a pipe) arrives, which it prints after its first row. */
static void test_shards_cli_sigint_then_resume_equals_the_whole_render(pds_test_ctx *t)
{
    char dir[128], out[200], part[220], args[600], text[4096], c = 0;
    char *argv[] = {NULL, "render", "scenes/demo.scene", "--method", "pt", "--res", "96x72", "--spp", "64",
                    "--threads", "1", "--progress", "-o", out, NULL};
    const char *bin = getenv("PDS_BIN");
    pds_image whole = {0, 0, NULL}, got = {0, 0, NULL};
    pds_error err;
    int status = 0, fds[2];
    pid_t pid;
    snprintf(dir, sizeof dir, "/tmp/pds_test_sigint_%ld", (long)getpid());
    snprintf(out, sizeof out, "%s/out.pfm", dir);
    snprintf(part, sizeof part, "%s.pdsp", out);
    mkdir(dir, 0777);
    REQUIRE(t, pipe(fds) == 0, "pipe");
    argv[0] = (char *)(bin ? bin : "./pds");
    pid = fork();
    if (pid == 0) {
        int null = open("/dev/null", O_WRONLY);
        if (null >= 0) dup2(null, 1);
        dup2(fds[1], 2);
        close(fds[0]);
        signal(SIGINT, SIG_DFL);
        signal(SIGTERM, SIG_DFL);
        execv(argv[0], argv);
        _exit(127);
    }
    close(fds[1]);
    REQUIRE(t, pid > 0, "fork failed");
    /* the first progress line ("eye     [#....]  ..."): the render is under way */
    {
        int bracket = 0;
        while (read(fds[0], &c, 1) == 1) {
            bracket |= c == '[';
            if (c == '\n' && bracket) break;
        }
    }
    kill(pid, SIGINT);
    waitpid(pid, &status, 0); /* the pipe stays open: a late line must not meet a closed pipe */
    close(fds[0]);
    CHECK(t, WIFEXITED(status) && WEXITSTATUS(status) == 130,
          "status %d: not stopped by the signal (exit 0: the render ended before it)", status);
    CHECK(t, cli_file_exists(out) && cli_file_exists(part), "no %s or no %s", out, part);
    snprintf(args, sizeof args, "render --resume %s --quiet", part);
    CHECK(t, cli_run(args, text, sizeof text) == 0, "resume: %s", text);
    CHECK(t, !cli_file_exists(part), "the spent partial file is still there");
    REQUIRE(t, shards_render_file("scenes/demo.scene", PDS_METHOD_PT, 96, 72, 64, 0, &whole), "render");
    CHECK(t, pds_image_read_pfm(out, &got, &err) == PDS_OK && shards_same(&got, &whole),
          "the resumed image differs from the whole render");
    pds_image_free(&whole);
    pds_image_free(&got);
    remove(out);
    remove(part);
    rmdir(dir);
}

/* `pds render --shard I/N` and `pds merge`: the merged image is the whole
   render's; a shard given twice or missing is refused, --partial merges a
   subset and says what fraction it holds. With four samples a pixel (the
   floor's pixels seen whole, choosing their scale) the merge's final line
   counts the pixels' choices as the whole render's does. */
static void test_shards_cli_shards_and_merge(pds_test_ctx *t)
{
    char dir[128], args[900], text[4096], p1[200], p2[200], out[200];
    pds_image whole = {0, 0, NULL}, got = {0, 0, NULL};
    pds_error err;
    int i;
    snprintf(dir, sizeof dir, "/tmp/pds_test_merge_%ld", (long)getpid());
    mkdir(dir, 0777);
    snprintf(p1, sizeof p1, "%s/1.pdsp", dir);
    snprintf(p2, sizeof p2, "%s/2.pdsp", dir);
    snprintf(out, sizeof out, "%s/merged.pfm", dir);
    for (i = 1; i <= 2; i++) {
        snprintf(args, sizeof args, "render scenes/refraction.scene --res 32x24 --spp 1 --photons 20000 --quiet "
                 "--shard %d/2 -o %s", i, i == 1 ? p1 : p2);
        CHECK(t, cli_run(args, text, sizeof text) == 0, "shard %d: %s", i, text);
    }
    snprintf(args, sizeof args, "merge -o %s %s %s", out, p2, p1);
    CHECK(t, cli_run(args, text, sizeof text) == 0 && strstr(text, "merge parts=2 shards=2 fraction=1.000000"), "%s",
          text);
    REQUIRE(t, shards_render_file("scenes/refraction.scene", PDS_METHOD_PDS, 32, 24, 1, 20000, &whole), "render");
    CHECK(t, pds_image_read_pfm(out, &got, &err) == PDS_OK && shards_same(&got, &whole),
          "the merged image differs from the whole render");
    {
        char whole_line[4096];
        const char *a, *b;
        for (i = 1; i <= 2; i++) {
            snprintf(args, sizeof args, "render scenes/refraction.scene --res 32x24 --caustics-only --photons 20000 "
                     "--quiet --shard %d/2 -o %s", i, i == 1 ? p1 : p2);
            CHECK(t, cli_run(args, text, sizeof text) == 0, "shard %d (4 samples a pixel): %s", i, text);
        }
        snprintf(args, sizeof args, "render scenes/refraction.scene --res 32x24 --caustics-only --photons 20000 -o %s",
                 out);
        CHECK(t, cli_run(args, whole_line, sizeof whole_line) == 0, "whole: %s", whole_line);
        snprintf(args, sizeof args, "merge -o %s %s %s", out, p1, p2);
        CHECK(t, cli_run(args, text, sizeof text) == 0, "merge: %s", text);
        a = strstr(cli_last_line(whole_line), " scale_pixels=");
        b = strstr(cli_last_line(text), " scale_pixels=");
        CHECK(t, a && b && strncmp(a, b, strcspn(a + 1, " ") + 1) == 0, "the choices: %s against %s", a ? a : "none",
              b ? b : "none");
    }
    snprintf(args, sizeof args, "merge -o %s %s %s", out, p1, p1);
    CHECK(t, cli_run(args, text, sizeof text) == 1 && strstr(text, "1.pdsp: shard 1/2 again: "), "twice: %s", text);
    snprintf(args, sizeof args, "merge -o %s %s", out, p2);
    CHECK(t, cli_run(args, text, sizeof text) == 1 && strstr(text, "shard 1/2 is missing"), "missing: %s", text);
    snprintf(args, sizeof args, "merge --partial -o %s %s", out, p2);
    CHECK(t, cli_run(args, text, sizeof text) == 0 && strstr(text, "holding 50.0% of the render's work"), "subset: %s",
          text);
    CHECK(t, cli_run("render scenes/refraction.scene --shard 3/2 -o x.pdsp", text, sizeof text) == 2 &&
                 strstr(text, "--shard needs I/N with 1 <= I <= N"),
          "bad shard: %s", text);
    CHECK(t, cli_run("render scenes/refraction.scene --debug landings --shard 1/2 -o x.pdsp", text, sizeof text) == 2 &&
                 strstr(text, "--debug views are made by a render in one go"),
          "shard with a view: %s", text);
    CHECK(t, cli_run("render scenes/refraction.scene --shard 1/2 -o x.png", text, sizeof text) == 2 &&
                 strstr(text, "a shard is written as a partial file"),
          "shard to an image: %s", text);
    pds_image_free(&whole);
    pds_image_free(&got);
    remove(p1);
    remove(p2);
    remove(out);
    rmdir(dir);
}

/* --checkpoint: the render stops to write its partial file and image and
   goes on; the end result is the render in one go, bit for bit, and the
   spent checkpoint is removed. (A checkpoint every millisecond: one after
   nearly every row.) */
static void test_shards_cli_checkpoints_leave_the_image_unchanged(pds_test_ctx *t)
{
    char out[200], part[220], args[600], text[4096];
    pds_image whole = {0, 0, NULL}, got = {0, 0, NULL};
    pds_error err;
    snprintf(out, sizeof out, "/tmp/pds_test_checkpoint_%ld.pfm", (long)getpid());
    snprintf(part, sizeof part, "%s.pdsp", out);
    const char *note;
    snprintf(args, sizeof args, "render scenes/demo.scene --method pt --res 48x36 --spp 8 --threads 1 --checkpoint 0.001 "
             "-o %s", out);
    CHECK(t, cli_run(args, text, sizeof text) == 0, "render: %s", text);
    note = strstr(text, "pds render: ");
    CHECK(t, note && atoi(note + 12) >= 5 && strstr(note, " checkpoints written to "), "no checkpoints: %s", text);
    CHECK(t, !cli_file_exists(part), "the spent checkpoint %s is still there", part);
    REQUIRE(t, shards_render_file("scenes/demo.scene", PDS_METHOD_PT, 48, 36, 8, 0, &whole), "render");
    CHECK(t, pds_image_read_pfm(out, &got, &err) == PDS_OK && shards_same(&got, &whole),
          "the checkpointed render differs from the render in one go");
    pds_image_free(&whole);
    pds_image_free(&got);
    remove(out);
}

/* gi, spm (its full image, gi's with streams) and isc through the pds
   tool: two shards merged are the render in one go, byte for byte; gi with pds caustics checkpoints between its
   photon passes and ends with the same image; an animation (--frames) is
   not split or checkpointed. */
static void test_shards_cli_gi_spm_isc_shards_merge_and_checkpoint(pds_test_ctx *t)
{
    static const char *const methods[] = {
        "--method gi --global-photons 2000 --gather 2 --photons 6000 --pass-photons 2048",
        "--method spm --photons 6000 --stream-photons 4 --global-photons 2000 --gather 2 --stream-radius 0.3",
        "--method isc --light-res 48"};
    char dir[128], args[1200], text[4096], p1[200], p2[200], out[200], whole_path[200];
    pds_image whole = {0, 0, NULL}, got = {0, 0, NULL};
    pds_error err;
    size_t m;
    int i;
    const char *note;
    snprintf(dir, sizeof dir, "/tmp/pds_test_gsi_%ld", (long)getpid());
    mkdir(dir, 0777);
    snprintf(p1, sizeof p1, "%s/1.pdsp", dir);
    snprintf(p2, sizeof p2, "%s/2.pdsp", dir);
    snprintf(out, sizeof out, "%s/merged.pfm", dir);
    snprintf(whole_path, sizeof whole_path, "%s/whole.pfm", dir);
    for (m = 0; m < sizeof methods / sizeof methods[0]; m++) {
        snprintf(args, sizeof args, "render scenes/ring_octahedron.scene %s --res 24x16 --spp 1 --quiet -o %s",
                 methods[m], whole_path);
        CHECK(t, cli_run(args, text, sizeof text) == 0, "%s: %s", methods[m], text);
        for (i = 1; i <= 2; i++) {
            snprintf(args, sizeof args, "render scenes/ring_octahedron.scene %s --res 24x16 --spp 1 --quiet "
                     "--shard %d/2 -o %s", methods[m], i, i == 1 ? p1 : p2);
            CHECK(t, cli_run(args, text, sizeof text) == 0, "%s shard %d: %s", methods[m], i, text);
        }
        snprintf(args, sizeof args, "merge -o %s %s %s", out, p2, p1);
        CHECK(t, cli_run(args, text, sizeof text) == 0, "%s: merge: %s", methods[m], text);
        CHECK(t, pds_image_read_pfm(whole_path, &whole, &err) == PDS_OK &&
                     pds_image_read_pfm(out, &got, &err) == PDS_OK && shards_same(&got, &whole),
              "%s: the merged image differs from the render in one go", methods[m]);
        pds_image_free(&whole);
        pds_image_free(&got);
    }
    /* gi with pds caustics: 3 photon passes, a checkpoint after each but the last */
    snprintf(args, sizeof args, "render scenes/ring_octahedron.scene %s --res 24x16 --spp 1 --threads 1 "
             "--checkpoint 0.000001 -o %s", methods[0], out);
    CHECK(t, cli_run(args, text, sizeof text) == 0, "gi checkpoints: %s", text);
    note = strstr(text, "pds render: ");
    CHECK(t, note && atoi(note + 12) == 2 && strstr(note, " checkpoints written to "), "gi: no checkpoints: %s", text);
    snprintf(args, sizeof args, "render scenes/ring_octahedron.scene %s --res 24x16 --spp 1 --quiet -o %s", methods[0],
             whole_path);
    CHECK(t, cli_run(args, text, sizeof text) == 0, "gi: %s", text);
    CHECK(t, pds_image_read_pfm(whole_path, &whole, &err) == PDS_OK && pds_image_read_pfm(out, &got, &err) == PDS_OK &&
                 shards_same(&got, &whole),
          "gi: the checkpointed render differs from the render in one go");
    CHECK(t, cli_run("render scenes/ring_octahedron.scene --method isc --frames 2 --shard 1/2 -o x.pdsp", text,
                     sizeof text) == 2 &&
                 strstr(text, "--frames writes an animation frame by frame: it is not split into shards or "
                              "checkpointed"),
          "frames: %s", text);
    pds_image_free(&whole);
    pds_image_free(&got);
    remove(p1);
    remove(p2);
    remove(out);
    remove(whole_path);
    rmdir(dir);
}

/* The row of race.csv that begins with "method,label,". */
static const char *shards_csv_row(const char *csv, const char *start, char *row, size_t n)
{
    const char *p = strstr(csv, start), *end;
    if (!p) return "";
    end = strchr(p, '\n');
    snprintf(row, n, "%.*s", (int)(end ? end - p : (long)strlen(p)), p);
    return row;
}

/* race keeps each finished entry in DIR/entries; a race run again with
   --resume loads those (the same row in race.csv, times and all) and
   renders only the missing ones; an entry of other options is not taken. */
static void test_shards_race_resume_keeps_finished_entries(pds_test_ctx *t)
{
    char out[16384], args[1024], ref[256], dir[256], path[512], row1[512], row2[512], lines[4][512];
    char *csv1, *csv2;
    REQUIRE(t, harness_reference(t, ref, sizeof ref), "no reference");
    harness_path(dir, sizeof dir, "race-resume");
    harness_rmtree(dir);
    snprintf(args, sizeof args,
             "race tests/golden/glass.scene --ref %s --photons 1000 --methods pt,pds --res 32x24 --spp 1 --quiet -o %s",
             ref, dir);
    REQUIRE(t, cli_run(args, out, sizeof out) == 0, "race: %s", out);
    snprintf(path, sizeof path, "%s/entries/pt.txt", dir);
    CHECK(t, cli_file_exists(path), "no %s", path);
    snprintf(path, sizeof path, "%s/race.csv", dir);
    csv1 = harness_slurp(path, NULL);
    /* as if the race had stopped while rendering pds */
    snprintf(path, sizeof path, "%s/entries/pds.txt", dir);
    remove(path);
    snprintf(path, sizeof path, "%s/race.csv", dir);
    remove(path);
    snprintf(args + strlen(args), sizeof args - strlen(args), " --resume");
    REQUIRE(t, cli_run(args, out, sizeof out) == 0, "race --resume: %s", out);
    REQUIRE(t, harness_lines(out, "race method=", lines, 4) == 2, "%s", out);
    CHECK(t, strstr(lines[0], "label=pt ") && strstr(lines[0], " resumed=1"), "pt not resumed: %s", lines[0]);
    CHECK(t, strstr(lines[1], "label=pds ") && !strstr(lines[1], "resumed="), "pds not rendered: %s", lines[1]);
    CHECK(t, strstr(cli_last_line(out), " resumed=1"), "final line: %s", out);
    csv2 = harness_slurp(path, NULL);
    CHECK(t, csv1 && csv2 && !strcmp(shards_csv_row(csv1, "pt,pt,", row1, sizeof row1),
                                     shards_csv_row(csv2, "pt,pt,", row2, sizeof row2)) && row1[0],
          "the kept entry's row changed: %s / %s", row1, row2);
    /* another seed: the kept entries are not this race's */
    snprintf(args + strlen(args), sizeof args - strlen(args), " --seed 5");
    CHECK(t, cli_run(args, out, sizeof out) == 0 && strstr(cli_last_line(out), " resumed=0"), "seed 5: %s", out);
    free(csv1);
    free(csv2);
    harness_rmtree(dir);
}

/* sweep keeps each finished render too, and --resume loads them. */
static void test_shards_sweep_resume_keeps_finished_entries(pds_test_ctx *t)
{
    char out[16384], args[1024], ref[256], dir[256], path[512], lines[4][512];
    REQUIRE(t, harness_reference(t, ref, sizeof ref), "no reference");
    harness_path(dir, sizeof dir, "sweep-resume");
    harness_rmtree(dir);
    snprintf(args, sizeof args, "sweep tests/golden/glass.scene --ref %s --method pt --param spp --values 1,2 --res 32x24 "
             "--quiet -o %s", ref, dir);
    REQUIRE(t, cli_run(args, out, sizeof out) == 0, "sweep: %s", out);
    snprintf(path, sizeof path, "%s/entries/spp-2.txt", dir);
    remove(path); /* as if the sweep had stopped while rendering spp 2 */
    snprintf(args + strlen(args), sizeof args - strlen(args), " --resume");
    REQUIRE(t, cli_run(args, out, sizeof out) == 0, "sweep --resume: %s", out);
    REQUIRE(t, harness_lines(out, "sweep method=", lines, 4) == 2, "%s", out);
    CHECK(t, strstr(lines[0], "spp=1 ") && strstr(lines[0], " resumed=1"), "spp 1 not resumed: %s", lines[0]);
    CHECK(t, strstr(lines[1], "spp=2 ") && !strstr(lines[1], "resumed="), "spp 2 not rendered: %s", lines[1]);
    harness_rmtree(dir);
}

/* sweep --resume with gi, spm and isc: a kept entry is taken again only
   if every option that shapes its image is the same, gi's global map,
   spm's stream count and isc's light buffer included (they were not in
   the entries' key before the partial file's options were). */
static void test_shards_sweep_resume_knows_gi_spm_and_isc_entries_by_all_their_options(pds_test_ctx *t)
{
    static const struct {
        const char *scene, *method, *param, *other;
    } runs[] = {{"tests/golden/glass.scene", "--method gi --global-photons 1000 --gather 2 --caustics pm --photons 2000",
                 "k", "--global-photons 1500"},
                {"tests/golden/glass.scene", "--method spm --streams 300 --photons 2000", "k", "--streams 400"},
                {"scenes/ring_octahedron.scene", "--method isc", "photons", "--light-res 24"}};
    char out[16384], args[1024], ref[256], dir[256], path[512], lines[4][512];
    size_t r;
    harness_path(ref, sizeof ref, "gsref.pfm");
    harness_path(dir, sizeof dir, "sweep-gi-spm");
    snprintf(args, sizeof args, "render tests/golden/glass.scene --method pt --res 24x16 --spp 2 --quiet -o %s", ref);
    REQUIRE(t, cli_run(args, out, sizeof out) == 0, "reference: %s", out);
    for (r = 0; r < sizeof runs / sizeof runs[0]; r++) {
        harness_rmtree(dir);
        snprintf(args, sizeof args, "sweep %s %s --param %s --values 10,20 --ref %s --res 24x16 --spp 1 --quiet -o %s",
                 runs[r].scene, runs[r].method, runs[r].param, ref, dir);
        REQUIRE(t, cli_run(args, out, sizeof out) == 0, "%s: sweep: %s", runs[r].method, out);
        snprintf(path, sizeof path, "%s/entries/%s-20.txt", dir, runs[r].param);
        CHECK(t, cli_file_exists(path), "%s: no %s", runs[r].method, path);
        remove(path); /* as if the sweep had stopped while rendering the second value */
        snprintf(args + strlen(args), sizeof args - strlen(args), " --resume");
        REQUIRE(t, cli_run(args, out, sizeof out) == 0, "%s: sweep --resume: %s", runs[r].method, out);
        REQUIRE(t, harness_lines(out, "sweep method=", lines, 4) == 2, "%s", out);
        CHECK(t, strstr(lines[0], " resumed=1") && !strstr(lines[1], "resumed="), "%s: not resumed: %s / %s",
              runs[r].method, lines[0], lines[1]);
        /* one option of the method's own changed: nothing is taken */
        snprintf(args + strlen(args), sizeof args - strlen(args), " %s", runs[r].other);
        REQUIRE(t, cli_run(args, out, sizeof out) == 0, "%s %s: %s", runs[r].method, runs[r].other, out);
        REQUIRE(t, harness_lines(out, "sweep method=", lines, 4) == 2, "%s", out);
        CHECK(t, !strstr(lines[0], "resumed=") && !strstr(lines[1], "resumed="),
              "%s: an entry of %s was taken: %s / %s", runs[r].method, runs[r].other, lines[0], lines[1]);
    }
    harness_rmtree(dir);
    remove(ref);
}

#endif /* PDS_TEST_POSIX */

static const pds_test_case tests_shards[] = {
#ifdef PDS_TEST_POSIX
    {"shards_sweep_resume_keeps_finished_entries", test_shards_sweep_resume_keeps_finished_entries},
    {"shards_sweep_resume_knows_gi_spm_and_isc_entries_by_all_their_options",
     test_shards_sweep_resume_knows_gi_spm_and_isc_entries_by_all_their_options},
    {"shards_race_resume_keeps_finished_entries", test_shards_race_resume_keeps_finished_entries},
    {"shards_cli_checkpoints_leave_the_image_unchanged", test_shards_cli_checkpoints_leave_the_image_unchanged},
    {"shards_cli_sigint_then_resume_equals_the_whole_render", test_shards_cli_sigint_then_resume_equals_the_whole_render},
    {"shards_cli_shards_and_merge", test_shards_cli_shards_and_merge},
    {"shards_cli_gi_spm_isc_shards_merge_and_checkpoint", test_shards_cli_gi_spm_isc_shards_merge_and_checkpoint},
#endif
    {"shards_merge_equals_the_single_run_bit_for_bit", test_shards_merge_equals_the_single_run_bit_for_bit},
    {"shards_spectral_merge_equals_the_single_run", test_shards_spectral_merge_equals_the_single_run},
    {"shards_interrupt_and_resume_equal_the_uninterrupted_render",
     test_shards_interrupt_and_resume_equal_the_uninterrupted_render},
    {"shards_progress_names_the_phases_in_order", test_shards_progress_names_the_phases_in_order},
    {"shards_isc_stop_finishes_the_frame", test_shards_isc_stop_finishes_the_frame},
    {"shards_merge_refuses_foreign_duplicate_and_missing_parts",
     test_shards_merge_refuses_foreign_duplicate_and_missing_parts},
    {"shards_partial_file_round_trips_and_is_versioned", test_shards_partial_file_round_trips_and_is_versioned},
    {"shards_partial_file_keeps_every_option_that_shapes_the_image",
     test_shards_partial_file_keeps_every_option_that_shapes_the_image},
    {"shards_refuse_teaching_views", test_shards_refuse_teaching_views},
};

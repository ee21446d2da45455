/* tests/test_limits.c - bounded on any input: special files, sizes, lines,
   values past the documented limits, and the parts that used to take
   quadratic time. Uses scene_tmp_write and scene_from_text (test_scene.c). */

#include <sys/stat.h>
#include <sys/types.h>

/* Set the size of the file at path (sparse where the system allows);
   0 on success. Windows' off_t has 32 bits: its 64-bit _chsize_s. */
static int limits_set_size(const char *path, double bytes)
{
#ifdef _WIN32
    FILE *f = fopen(path, "r+b");
    int r;
    if (!f) return -1;
    r = _chsize_s(_fileno(f), (long long)bytes);
    fclose(f);
    return r;
#else
    return truncate(path, (off_t)bytes);
#endif
}

/* Load path as a scene; 0 and the error text in *err if it failed. */
static int limits_load(const char *path, pds_error *err)
{
    pds_scene *s = NULL;
    if (pds_scene_load(path, &s, err) != PDS_OK) return 0;
    pds_scene_free(s);
    return 1;
}

static int limits_contains(const char *text, const char *part)
{
    return strstr(text, part) != NULL;
}

#ifdef PDS_TEST_POSIX
static void test_readers_refuse_fifos_devices_and_directories(pds_test_ctx *t)
{
    char fifo[256], scene[256], obj[256], text[600];
    pds_error err;
    pds_image img = {0, 0, NULL};
    pds_scene *s = NULL;
    snprintf(fifo, sizeof fifo, "/tmp/pds_test_%ld_fifo", (long)getpid());
    remove(fifo);
    REQUIRE(t, mkfifo(fifo, 0600) == 0, "mkfifo");
    /* a FIFO with no writer would block an ordinary open forever */
    CHECK(t, !limits_load(fifo, &err) && !strcmp(err.message, "not a regular file") && !strcmp(err.file, fifo),
          "FIFO scene: %s", err.text);
    CHECK(t, pds_image_read_pfm(fifo, &img, &err) != PDS_OK && !strcmp(err.message, "not a regular file"),
          "FIFO PFM: %s", err.text);
    CHECK(t, pds_scene_load_obj(fifo, &s, &err) != PDS_OK && !strcmp(err.message, "not a regular file"),
          "FIFO OBJ: %s", err.text);
    /* a device as the mesh of a scene, and as the MTL of an OBJ */
    CHECK(t, !limits_load(scene_tmp_write(scene, sizeof scene, "dev.scene", "mesh \"/dev/zero\" {}\n"), &err) &&
              limits_contains(err.text, "dev.scene:1:6: cannot read mesh '/dev/zero': not a regular file"),
          "mesh /dev/zero: %s", err.text);
    snprintf(text, sizeof text, "mtllib /dev/zero\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    CHECK(t, pds_scene_load_obj(scene_tmp_write(obj, sizeof obj, "dev.obj", text), &s, &err) != PDS_OK &&
              limits_contains(err.text, "dev.obj:1:8: cannot read material library /dev/zero: not a regular file"),
          "mtllib /dev/zero: %s", err.text);
    snprintf(text, sizeof text, "mesh \"%s\" {}\n", fifo);
    CHECK(t, !limits_load(scene_tmp_write(scene, sizeof scene, "fifo.scene", text), &err) &&
              limits_contains(err.message, "not a regular file"),
          "mesh FIFO: %s", err.text);
    CHECK(t, !limits_load("/tmp", &err) && !strcmp(err.text, "/tmp: is a directory"), "directory: %s", err.text);
    remove(fifo);
    remove(scene);
    remove(obj);
}
#endif

static void test_readers_refuse_files_past_their_size_limit_before_reading(pds_test_ctx *t)
{
    char path[256];
    pds_error err;
    pds_image img = {0, 0, NULL};
    FILE *f;
    snprintf(path, sizeof path, "/tmp/pds_test_%ld_big.scene", (long)getpid());
    f = fopen(path, "wb");
    REQUIRE(t, f != NULL, "create");
    fclose(f);
    /* a sparse file one byte over the limit: refused from its size alone */
    REQUIRE(t, limits_set_size(path, (double)PDS_MAX_TEXT_BYTES + 1) == 0, "truncate");
    CHECK(t, !limits_load(path, &err) && err.status == PDS_ERR_LIMIT &&
              limits_contains(err.message, "larger than the limit of 67108864 bytes for a scene file"),
          "scene: %s", err.text);
    REQUIRE(t, limits_set_size(path, (double)PDS__MAX_PFM_BYTES + 1) == 0, "truncate");
    CHECK(t, pds_image_read_pfm(path, &img, &err) == PDS_ERR_LIMIT, "PFM: %s", err.text);
    remove(path);
}

static void test_readers_name_the_first_line_past_the_line_limit(pds_test_ctx *t)
{
    size_t n = (size_t)PDS_MAX_LINE_BYTES + 10;
    char *text = (char *)malloc(n + 64), path[256];
    pds_error err;
    pds_scene *s = NULL;
    REQUIRE(t, text != NULL, "memory");
    strcpy(text, "v 0 0 0\nv 1 0 0\n# ");
    memset(text + strlen(text), 'x', n);
    strcpy(text + 18 + n, "\nv 0 1 0\nf 1 2 3\n");
    REQUIRE(t, scene_tmp_write(path, sizeof path, "long.obj", text) != NULL, "write");
    CHECK(t, pds_scene_load_obj(path, &s, &err) == PDS_ERR_LIMIT && err.line == 3 &&
              limits_contains(err.message, "longer than the limit of 4194304"),
          "long OBJ line: %s", err.text);
    remove(path);
    free(text);
}

static void test_pfm_with_nan_or_infinity_names_the_first_bad_pixel(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL}, back = {0, 0, NULL};
    char path[256];
    pds_error err;
    REQUIRE(t, pds_image_alloc(&img, 4, 3) == PDS_OK, "alloc");
    img.rgb[3 * (1 * 4 + 2) + 1] = (float)NAN; /* x 2, y 1 (from the top), green */
    snprintf(path, sizeof path, "/tmp/pds_test_%ld_nan.pfm", (long)getpid());
    REQUIRE(t, pds_image_write_pfm(path, &img, NULL) == PDS_OK, "write");
    CHECK(t, pds_image_read_pfm(path, &back, &err) == PDS_ERR_PARSE &&
              !strcmp(err.message, "pixel (2, 1) green is NaN: an image must hold finite values"),
          "NaN: %s", err.text);
    CHECK(t, back.rgb == NULL, "no image is returned with the error");
    img.rgb[3 * (1 * 4 + 2) + 1] = 0.0f;
    img.rgb[3 * (2 * 4 + 0) + 2] = -HUGE_VALF;
    REQUIRE(t, pds_image_write_pfm(path, &img, NULL) == PDS_OK, "write");
    CHECK(t, pds_image_read_pfm(path, &back, &err) == PDS_ERR_PARSE &&
              !strcmp(err.message, "pixel (0, 2) blue is -infinity: an image must hold finite values"),
          "infinity: %s", err.text);
    remove(path);
    pds_image_free(&img);
}

static void test_scene_refuses_values_past_the_documented_limits(pds_test_ctx *t)
{
    static const struct {
        const char *text, *message;
    } cases[] = {
        /* a transform that pushes vertices past 1e12 */
        {"quad { size 1 1 }\nsphere { radius 1 translate 9e11 0 0 scale 100 }\n",
         "t.scene:2:1: 2145 vertices of this sphere lie beyond +-1e+12 once transformed"},
        /* a Sellmeier law with a pole in the visible range */
        {"material h dielectric { sellmeier 1.03 0.23 1.01 0.006 0.3 103 }\n",
         "t.scene:1:25: this Sellmeier law gives n = 0.990508 at 497 nm: it must stay within 1 to 10 from 360 to "
         "830 nm"},
        /* a disk light whose area underflows */
        {"light disk { center 0 2 0 radius 1e-200 power 10 }\n",
         "t.scene:1:7: this disk light is too small: its area (0) or radiance is out of range (a point light "
         "stands for a tiny one)"},
    };
    size_t i;
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        pds_error err;
        pds_scene *s = scene_from_text(cases[i].text, &err);
        CHECK(t, s == NULL && limits_contains(err.text, cases[i].message), "case %lu: got '%s'", (unsigned long)i,
              s ? "(loaded)" : err.text);
        pds_scene_free(s);
    }
}

static void test_scene_warns_of_a_light_that_emits_nothing(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text("camera { position 0 1 3 look_at 0 0 0 }\nquad { size 1 1 }\n"
                                   "light point { position 0 1 0 power 0 }\n", &err);
    pds_scene_info info;
    REQUIRE(t, s != NULL, "load: %s", err.text);
    pds_scene_get_info(s, &info);
    CHECK(t, info.warnings == 1 && limits_contains(pds_scene_warning(s, 0), "t.scene:3:7: this point light emits nothing"),
          "warning: %s", info.warnings ? pds_scene_warning(s, 0) : "(none)");
    pds_scene_free(s);
}

static void test_mtl_illum_out_of_range_is_refused_before_conversion(pds_test_ctx *t)
{
    char obj[256], mtl[256];
    pds_error err;
    pds_scene *s = NULL;
    scene_tmp_write(mtl, sizeof mtl, "illum.mtl", "newmtl a\nillum 4e44\n");
    scene_tmp_write(obj, sizeof obj, "illum.obj", "");
    {
        char text[512];
        snprintf(text, sizeof text, "mtllib %s\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n", strrchr(mtl, '/') + 1);
        scene_tmp_write(obj, sizeof obj, "illum.obj", text);
    }
    CHECK(t, pds_scene_load_obj(obj, &s, &err) == PDS_ERR_PARSE &&
              limits_contains(err.text, "illum.mtl:2:7: expected an illumination model number 0-10 for 'illum', got '4e44'"),
          "illum: %s", err.text);
    remove(obj);
    remove(mtl);
}

/* 65,536 materials (the limit): each is found by name, and one past the
   limit is refused. A linear search made this quadratic (43 s). */
static void test_scene_with_the_most_materials_loads_and_finds_each(pds_test_ctx *t)
{
    size_t n = (size_t)PDS_MAX_MATERIALS, i, len = 0, cap = 48 * (n + 2);
    char *text = (char *)malloc(cap);
    pds_error err;
    pds_scene *s;
    REQUIRE(t, text != NULL, "memory");
    for (i = 0; i + 1 < n; i++) len += (size_t)snprintf(text + len, cap - len, "material m%lu diffuse {}\n", (unsigned long)i);
    len += (size_t)snprintf(text + len, cap - len, "quad { material m%lu size 1 1 }\n", (unsigned long)(n / 2));
    s = scene_from_text(text, &err);
    REQUIRE(t, s != NULL, "load: %s", err.text);
    CHECK(t, s->mesh.mat[0] == (int)(n / 2), "the quad's material is m%lu (index %d)", (unsigned long)(n / 2),
          s->mesh.mat[0]);
    for (i = 0; i + 1 < n; i += 997) {
        char name[32];
        snprintf(name, sizeof name, "m%lu", (unsigned long)i);
        CHECK(t, pds__materials_find(&s->materials, name) == (int)i, "find %s", name);
    }
    pds_scene_free(s);
    /* n - 1 materials and two more is one over the limit */
    len += (size_t)snprintf(text + len, cap - len, "material x1 diffuse {}\nmaterial x2 diffuse {}\n");
    s = scene_from_text(text, &err);
    CHECK(t, s == NULL && limits_contains(err.text, "more than 65536 materials"), "over the limit: %s",
          s ? "(loaded)" : err.text);
    pds_scene_free(s);
    free(text);
}


/* A glass ball on a floor under a point light: the memory tests' scene */
#define LIMITS_GLASS_BALL                                                                                              \
    "camera { position 0 1 3 look_at 0 0 0 resolution 40 30 spp 4 }\n"                                                 \
    "material glass dielectric { ior 1.5 }\n"                                                                          \
    "quad { size 4 4 }\nsphere { material glass radius 0.5 translate 0 0.6 0 }\n"                                      \
    "light point { position 0 3 0 power 100 }\n"

/* The estimate is an upper bound on what a render holds, follows the
   documented bytes per eye vertex, stored photon and pixel, and a render
   over the memory limit is refused before any work. */
static void test_render_memory_estimate_bounds_the_render_and_refuses_too_much(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text(LIMITS_GLASS_BALL, &err);
    pds_options opt;
    pds_render_estimate est;
    pds_render_stats st;
    pds_image img = {0, 0, NULL};
    double pixels = 40.0 * 30.0;
    int depth;
    REQUIRE(t, s != NULL, "load: %s", err.text);
    pds_options_default(&opt);
    opt.method = PDS_METHOD_PM;
    opt.photons = 5000;
    opt.threads = 2;
    REQUIRE(t, pds_render_estimate_get(s, &opt, &est, &err) == PDS_OK, "estimate: %s", err.text);
    /* glass: the eye pass splits there, up to 4 first vertices a sample */
    CHECK(t, est.eye_vertices == pixels * 4 * 4 && est.stored_photons == 5000 && est.samples == pixels * 4,
          "counts %g %g %g", est.eye_vertices, est.stored_photons, est.samples);
    /* 149 bytes per stored photon where long has 64 bits (pds.h); 16 fewer
       where it has 32 (Windows): the photon's number is a long */
    CHECK(t, est.memory_bytes == pixels * 60 + pixels * 4 * 4 * (3 * sizeof(pds__eye_vertex)) + pixels * 96 +
                                     2 * pixels * 48 +
                                     5000.0 * (sizeof(long) == 8 ? 149 : 133),
          "bytes %.0f", est.memory_bytes);
    REQUIRE(t, pds_render(s, &opt, &img, &st, &err) == PDS_OK, "render: %s", err.text);
    CHECK(t, (double)st.memory_bytes <= est.memory_bytes, "the render held %lu bytes, over the estimate %.0f",
          (unsigned long)st.memory_bytes, est.memory_bytes);
    pds_image_free(&img);
    opt.memory_limit = est.memory_bytes - 1.0;
    CHECK(t, pds_render(s, &opt, &img, &st, &err) == PDS_ERR_LIMIT && img.rgb == NULL &&
              limits_contains(err.message, "but the memory limit is"),
          "over the limit: %s", err.text);
    /* PDS: no map, but each thread holds up to 4096 landings (216 bytes
       each) before it splats them, however its photons split: the
       estimate is pm's without the photons plus those, and with the
       pixels' choice of scale (pass_select) 10 more sums a pixel in the
       part's two images, 8 in each thread's and two sums and a long a
       pixel for the pixels' counts and whole vertices; a render on two threads holds one image (with its
       second scale's) and one thread's landings more than on one */
    opt.memory_limit = 0.0;
    opt.method = PDS_METHOD_PDS;
    for (depth = 0; depth <= 2; depth += 2) {
        pds_render_estimate pest;
        pds_render_stats one;
        int second = depth == 2; /* the second scale with the splits */
        opt.split_depth = depth;
        opt.pass_select = second;
        opt.threads = 2;
        REQUIRE(t, pds_render_estimate_get(s, &opt, &pest, &err) == PDS_OK, "pds estimate: %s", err.text);
        CHECK(t, pest.stored_photons == 0.0 &&
                     pest.memory_bytes == est.memory_bytes - 5000.0 * (sizeof(long) == 8 ? 149 : 133) + 2 * 4096 * 216.0 +
                                              (second ? pixels * 16 * (2 * 10 + 2 * 8) + pixels * (32.0 + sizeof(long))
                                                      : 0.0),
              "pds estimate %.0f bytes, pm's %.0f", pest.memory_bytes, est.memory_bytes);
        REQUIRE(t, pds_render(s, &opt, &img, &st, &err) == PDS_OK, "pds render: %s", err.text);
        pds_image_free(&img);
        CHECK(t, (double)st.memory_bytes <= pest.memory_bytes && st.map_bytes == 0,
              "pds (split depth %d) held %lu bytes, over the estimate %.0f", depth, (unsigned long)st.memory_bytes,
              pest.memory_bytes);
        opt.threads = 1;
        REQUIRE(t, pds_render(s, &opt, &img, &one, &err) == PDS_OK, "pds render, one thread: %s", err.text);
        pds_image_free(&img);
        CHECK(t, st.memory_bytes - one.memory_bytes == (size_t)(pixels * (3 + (second ? 8 : 0)) * 16 + 4096 * 216),
              "two threads %lu bytes, one %lu", (unsigned long)st.memory_bytes, (unsigned long)one.memory_bytes);
    }
    {
        /* over the limit on 4 threads and within it on 2: pm is refused
           with what a thread holds and that 2 would fit, and not told so
           where one alone is over; pds, where 2 of its 4 threads' images
           (3 + 8 sums a pixel) fit, renders with its threads taking turns
           at 2 shared ones: 2 images less memory than on its own 4, and
           the same image bit for bit as on one thread */
        pds_render_estimate e4, e1;
        pds_render_stats s4, own;
        double image = pixels * (3 + PDS__SEL_THREAD + PDS__SEL_THREAD_ODD) * sizeof(pds__sum128);
        pds_image one_img = {0, 0, NULL};
        int m;
        for (m = 0; m < 2; m++) {
            opt.method = m ? PDS_METHOD_PDS : PDS_METHOD_PM;
            opt.split_depth = 0;
            opt.pass_select = 1;
            opt.memory_limit = 0.0;
            opt.threads = 4;
            REQUIRE(t, pds_render_estimate_get(s, &opt, &e4, &err) == PDS_OK, "4 threads: %s", err.text);
            opt.threads = 1;
            REQUIRE(t, pds_render_estimate_get(s, &opt, &e1, &err) == PDS_OK, "1 thread: %s", err.text);
            if (m) REQUIRE(t, pds_render(s, &opt, &one_img, NULL, &err) == PDS_OK, "pds, 1 thread: %s", err.text);
            opt.threads = 4;
            if (m) {
                REQUIRE(t, pds_render(s, &opt, &img, &own, &err) == PDS_OK, "pds, 4 threads: %s", err.text);
                pds_image_free(&img);
            }
            opt.memory_limit = m ? e4.memory_bytes - 1.5 * image
                                 : e1.memory_bytes + 1.5 * (e4.memory_bytes - e1.memory_bytes) / 3.0;
            if (!m) {
                CHECK(t, pds_render(s, &opt, &img, &st, &err) == PDS_ERR_LIMIT &&
                             limits_contains(err.message, "2 would fit"),
                      "pm, 4 threads over the limit: %s", err.text);
                opt.memory_limit = e1.memory_bytes - 1.0;
                CHECK(t, pds_render(s, &opt, &img, &st, &err) == PDS_ERR_LIMIT &&
                             !limits_contains(err.message, "would fit"),
                      "pm, 1 thread over the limit: %s", err.text);
                continue;
            }
            REQUIRE(t, pds_render(s, &opt, &img, &s4, &err) == PDS_OK, "pds, 4 threads, 2 images: %s", err.text);
            CHECK(t, memcmp(img.rgb, one_img.rgb, sizeof(float) * 3 * (size_t)img.width * img.height) == 0,
                  "pds on 4 threads sharing 2 images differs from 1 thread");
            CHECK(t, (double)own.memory_bytes - (double)s4.memory_bytes == 2 * image,
                  "pds held %lu bytes sharing, %lu on its own: not 2 images less", (unsigned long)s4.memory_bytes,
                  (unsigned long)own.memory_bytes);
            pds_image_free(&img);
            pds_image_free(&one_img);
        }
        opt.memory_limit = 0.0;
    }
    pds_scene_free(s);
}


/* Found by fuzzing: an `mtllib` of several names walked its tokens in a
   scratch array the MTL reader refills for a multi-word `newmtl`, and read
   the next name from the freed MTL text. Both libraries must load. */
static void test_obj_mtllib_of_several_files_survives_multi_word_newmtl(pds_test_ctx *t)
{
    char obj[256], a[256], b[256], text[600];
    pds_error err;
    pds_scene *s = NULL;
    scene_tmp_write(a, sizeof a, "multi_a.mtl", "newmtl red glossy\nKd 1 0 0\n");
    scene_tmp_write(b, sizeof b, "multi_b.mtl", "newmtl blue\nKd 0 0 1\n");
    snprintf(text, sizeof text, "mtllib %s %s\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl blue\nf 1 2 3\n",
             strrchr(a, '/') + 1, strrchr(b, '/') + 1);
    REQUIRE(t, pds_scene_load_obj(scene_tmp_write(obj, sizeof obj, "multi.obj", text), &s, &err) == PDS_OK,
            "load: %s", err.text);
    CHECK(t, s->mesh.ntris == 1 && s->materials.items[s->mesh.mat[0]].albedo[2] > 0.5 &&
              s->materials.items[s->mesh.mat[0]].albedo[0] < 0.5,
          "the triangle has the second library's blue");
    pds_scene_free(s);
    remove(obj);
    remove(a);
    remove(b);
}


/* Scene text from memory: the same scene as from a file, errors naming the
   virtual file, meshes found beside it. */
static void test_scene_loads_from_a_string_with_a_virtual_file_name(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = NULL;
    pds_scene_info info;
    CHECK(t, pds_scene_load_string("quad { size 2 2 }\nlight point { position 0 1 0 power 1 }\n", "mem.scene", &s, &err) ==
                 PDS_OK,
          "load: %s", err.text);
    if (s) {
        pds_scene_get_info(s, &info);
        CHECK(t, info.triangles == 2 && info.lights == 1, "%ld triangles, %d lights", info.triangles, info.lights);
        pds_scene_free(s);
    }
    s = NULL;
    CHECK(t, pds_scene_load_string("quad { size 2 2 }\nsphere { radius -1 }\n", "virtual/mem.scene", &s, &err) ==
                 PDS_ERR_PARSE && !strncmp(err.text, "virtual/mem.scene:2:", 20),
          "error: %s", err.text);
    CHECK(t, pds_scene_load_string("mesh \"octahedron.obj\" {}\n", "scenes/virtual.scene", &s, &err) == PDS_OK,
          "mesh beside the virtual file: %s", err.text);
    pds_scene_free(s);
}

/* Where the bound of 4 eye vertices a sample would take over 256 MiB, a
   pilot of the camera's samples estimates their mean: the estimate is
   then below the bound, yet not below what the eye pass really recorded
   (ppm, caustics only: a vertex a sample on the floor, two or more where
   a sample meets the glass ball), within the pilot's margin of it. */
static void test_render_memory_estimate_measures_the_eye_vertices_of_a_large_render(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text(LIMITS_GLASS_BALL, &err);
    pds_options opt;
    pds_render_estimate est;
    pds_render_stats st;
    pds_image img = {0, 0, NULL};
    double samples = 160.0 * 120.0 * 16.0;
    REQUIRE(t, s != NULL, "load: %s", err.text);
    pds_options_default(&opt);
    opt.method = PDS_METHOD_PPM;
    opt.paths = PDS_PATHS_CAUSTICS_ONLY;
    opt.width = 160;
    opt.height = 120;
    opt.spp = 16;
    opt.photons = 2000;
    opt.passes = 1;
    opt.threads = 2;
    REQUIRE(t, pds_render_estimate_get(s, &opt, &est, &err) == PDS_OK, "estimate: %s", err.text);
    REQUIRE(t, pds_render(s, &opt, &img, &st, &err) == PDS_OK, "render: %s", err.text);
    pds_image_free(&img);
    /* the bound (4 a sample, 264 bytes each) is over 256 MiB here */
    CHECK(t, samples * 4 * 3 * sizeof(pds__eye_vertex) > 268435456.0, "the bound is under the pilot's threshold");
    CHECK(t, est.eye_vertices < 0.5 * samples * 4, "estimated %.0f vertices, the bound %.0f", est.eye_vertices,
          samples * 4);
    CHECK(t, est.eye_vertices >= (double)st.eye_vertices && est.eye_vertices <= st.eye_vertices + 0.3 * samples,
          "estimated %.0f vertices, the render recorded %ld (%.3f a sample)", est.eye_vertices, st.eye_vertices,
          st.eye_vertices / samples);
    CHECK(t, (double)st.memory_bytes <= est.memory_bytes, "the render held %lu bytes, over the estimate %.0f",
          (unsigned long)st.memory_bytes, est.memory_bytes);
    {
        /* the pilot itself, less its margin for what it may miss (a
           sixteenth of 4), is the recorded mean within its standard
           errors: its samples split at glass as the eye pass's do */
        double m = pds__eye_vertices_per_sample(s, &opt, 160, 120, 2) - 0.25, real = st.eye_vertices / samples;
        CHECK(t, m >= real && m <= real + 0.08, "pilot %.4f a sample (less the margin), the render %.4f", m, real);
    }
    pds_scene_free(s);
}

static const pds_test_case tests_limits[] = {
#ifdef PDS_TEST_POSIX
    {"readers_refuse_fifos_devices_and_directories", test_readers_refuse_fifos_devices_and_directories},
#endif
    {"readers_refuse_files_past_their_size_limit_before_reading",
     test_readers_refuse_files_past_their_size_limit_before_reading},
    {"readers_name_the_first_line_past_the_line_limit", test_readers_name_the_first_line_past_the_line_limit},
    {"pfm_with_nan_or_infinity_names_the_first_bad_pixel", test_pfm_with_nan_or_infinity_names_the_first_bad_pixel},
    {"scene_refuses_values_past_the_documented_limits", test_scene_refuses_values_past_the_documented_limits},
    {"scene_warns_of_a_light_that_emits_nothing", test_scene_warns_of_a_light_that_emits_nothing},
    {"mtl_illum_out_of_range_is_refused_before_conversion", test_mtl_illum_out_of_range_is_refused_before_conversion},
    {"scene_with_the_most_materials_loads_and_finds_each", test_scene_with_the_most_materials_loads_and_finds_each},
    {"obj_mtllib_of_several_files_survives_multi_word_newmtl", test_obj_mtllib_of_several_files_survives_multi_word_newmtl},
    {"scene_loads_from_a_string_with_a_virtual_file_name", test_scene_loads_from_a_string_with_a_virtual_file_name},
    {"render_memory_estimate_bounds_the_render_and_refuses_too_much",
     test_render_memory_estimate_bounds_the_render_and_refuses_too_much},
    {"render_memory_estimate_measures_the_eye_vertices_of_a_large_render",
     test_render_memory_estimate_measures_the_eye_vertices_of_a_large_render},
};

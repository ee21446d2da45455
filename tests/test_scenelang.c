/* tests/test_scenelang.c - the scene language's include and variables
   (define, $NAME, -D), a bare OBJ in its studio, and the OBJ loader's
   tolerance of real downloads (escaped spaces, missing MTL files). */

/* /tmp/pds_sl_PID_name */
static void sl_path(char *out, size_t n, const char *name)
{
    snprintf(out, n, "/tmp/pds_sl_%ld_%s", (long)getpid(), name);
}


/* Load scene text with -D overrides (n of them, "name", "value" pairs). */
static pds_status sl_load(const char *text, const char *const *kv, int n, pds_scene **s, pds_error *err)
{
    pds_load_options lo;
    pds_define d[8];
    int i;
    pds_load_options_default(&lo);
    for (i = 0; i < n && i < 8; i++) {
        d[i].name = kv[2 * i];
        d[i].value = kv[2 * i + 1];
    }
    lo.defines = d;
    lo.define_count = n;
    *s = NULL;
    return pds_scene_load_string_ex(text, "mem.scene", &lo, s, err);
}

static int sl_has_warning(const pds_scene *s, const char *text)
{
    int i;
    const char *w;
    for (i = 0; (w = pds_scene_warning(s, i)) != NULL; i++)
        if (strstr(w, text)) return 1;
    return 0;
}

/* ----------------------------------------------------------------- include */

static void test_scene_include_reads_files_relative_to_the_including_file(pds_test_ctx *t)
{
    char dir[256], sub[300], main_path[400], mat[400], floor_path[400];
    pds_scene *s = NULL, *flat = NULL;
    pds_error err;
    sl_path(dir, sizeof dir, "inc");
    snprintf(sub, sizeof sub, "%s/parts", dir);
    mkdir(dir, 0700);
    mkdir(sub, 0700);
    snprintf(main_path, sizeof main_path, "%s/main.scene", dir);
    snprintf(mat, sizeof mat, "%s/parts/mat.scene", dir);
    snprintf(floor_path, sizeof floor_path, "%s/floor.scene", dir);
    /* main includes parts/mat.scene, which includes ../floor.scene: each
       path is relative to the file that names it */
    REQUIRE(t, tobj_write(main_path, "include \"parts/mat.scene\"\nsphere { material glass radius 0.5 translate 0 1 0 }\n"
                                   "light point { position 0 3 0 power 10 }\n") &&
                   tobj_write(mat, "material glass dielectric { ior 1.33 }\ninclude \"../floor.scene\"\n") &&
                   tobj_write(floor_path, "material white diffuse { albedo 0.5 }\nquad { material white size 4 4 }\n"),
            "cannot write the files");
    REQUIRE(t, pds_scene_load(main_path, &s, &err) == PDS_OK, "%s", err.text);
    REQUIRE(t, pds_scene_load_string("material glass dielectric { ior 1.33 }\n"
                                     "material white diffuse { albedo 0.5 }\nquad { material white size 4 4 }\n"
                                     "sphere { material glass radius 0.5 translate 0 1 0 }\n"
                                     "light point { position 0 3 0 power 10 }\n",
                                     main_path, &flat, &err) == PDS_OK,
            "%s", err.text);
    CHECK(t, pds_scene_hash(s) == pds_scene_hash(flat), "the included scene differs from the same statements in one file");
    CHECK(t, s->mesh.ntris == flat->mesh.ntris && s->nlights == 1 && s->materials.count == 2,
          "triangles %lu / %lu, lights %lu, materials %lu", (unsigned long)s->mesh.ntris,
          (unsigned long)flat->mesh.ntris, (unsigned long)s->nlights, (unsigned long)s->materials.count);
    pds_scene_free(s);
    pds_scene_free(flat);
    remove(main_path);
    remove(mat);
    remove(floor_path);
    rmdir(sub);
    rmdir(dir);
}

static void test_scene_include_errors_name_the_file_and_where_it_was_included_from(pds_test_ctx *t)
{
    char a[256], b[256], c[256], expect[1200];
    pds_scene *s = NULL;
    pds_error err;
    sl_path(a, sizeof a, "ea.scene");
    sl_path(b, sizeof b, "eb.scene");
    sl_path(c, sizeof c, "ec.scene");
    {
        char text[512];
        snprintf(text, sizeof text, "# outer\n\n  include \"%s\"\n", strrchr(b, '/') + 1);
        REQUIRE(t, tobj_write(a, text), "write a");
        snprintf(text, sizeof text, "quad { size 1 1 }\ninclude %s\n", strrchr(c, '/') + 1);
        REQUIRE(t, tobj_write(b, text), "write b");
    }
    /* an error inside the innermost file: its own line and column, then the
       chain of include statements, innermost first */
    REQUIRE(t, tobj_write(c, "material m diffuse {\n  albedo red\n}\n"), "write c");
    CHECK(t, pds_scene_load(a, &s, &err) == PDS_ERR_PARSE, "bad albedo accepted");
    snprintf(expect, sizeof expect, "%s:2:10: expected a number after 'albedo', got 'red' (included from %s:2:1, from %s:3:3)",
             c, b, a);
    CHECK(t, !strcmp(err.text, expect), "got      '%s'\n  expected '%s'", err.text, expect);
    CHECK(t, err.line == 2 && err.column == 10 && !strcmp(err.file, c), "location %s:%d:%d", err.file, err.line, err.column);
    /* a missing file: at its name in the including file */
    remove(c);
    CHECK(t, pds_scene_load(a, &s, &err) == PDS_ERR_IO, "missing include accepted");
    snprintf(expect, sizeof expect, "%s:2:9: cannot read included file '%s': No such file or directory (included from %s:3:3)",
             b, c, a);
    CHECK(t, !strcmp(err.text, expect), "got      '%s'\n  expected '%s'", err.text, expect);
    /* a near miss of the keyword */
    REQUIRE(t, tobj_write(c, "inclde \"x.scene\"\n"), "write c");
    CHECK(t, pds_scene_load(a, &s, &err) == PDS_ERR_PARSE, "inclde accepted");
    CHECK(t, strstr(err.text, ":1:1: unknown keyword 'inclde' (did you mean 'include'?) (included from ") != NULL, "got '%s'",
          err.text);
    /* a missing '}' before an include points at the brace */
    CHECK(t, sl_load("material m diffuse { albedo 0.5\ninclude \"x.scene\"\n", NULL, 0, &s, &err) == PDS_ERR_PARSE &&
                 !strcmp(err.text, "mem.scene:2:1: 'include' starts a statement, but the diffuse material block opened "
                                   "at 1:20 is not closed (a '}' missing?)"),
          "got '%s'", err.text);
    remove(a);
    remove(b);
    remove(c);
}

static void test_scene_include_cycles_and_depth_are_refused(pds_test_ctx *t)
{
    char a[256], b[256], expect[2000], text[512], name[64];
    pds_scene *s = NULL;
    pds_error err;
    int i;
    sl_path(a, sizeof a, "ca.scene");
    sl_path(b, sizeof b, "cb.scene");
    snprintf(text, sizeof text, "include \"%s\"\n", strrchr(b, '/') + 1);
    REQUIRE(t, tobj_write(a, text), "write a");
    /* b names a through "./": still the same file */
    snprintf(text, sizeof text, "quad { size 1 1 }\ninclude \"./%s\"\n", strrchr(a, '/') + 1);
    REQUIRE(t, tobj_write(b, text), "write b");
    CHECK(t, pds_scene_load(a, &s, &err) == PDS_ERR_PARSE, "cycle accepted");
    snprintf(expect, sizeof expect, "%s:2:9: include cycle: %s -> %s -> %s (included from %s:1:1)", b, a, b, a, a);
    CHECK(t, !strcmp(err.text, expect), "got      '%s'\n  expected '%s'", err.text, expect);
    /* a file that includes itself */
    snprintf(text, sizeof text, "include \"%s\"\n", strrchr(a, '/') + 1);
    REQUIRE(t, tobj_write(a, text), "write a");
    CHECK(t, pds_scene_load(a, &s, &err) == PDS_ERR_PARSE, "self-include accepted");
    snprintf(expect, sizeof expect, "%s:1:9: include cycle: %s -> %s", a, a, a);
    CHECK(t, !strcmp(err.text, expect), "got      '%s'\n  expected '%s'", err.text, expect);
    remove(a);
    remove(b);
    /* a chain 0 -> 1 -> ... -> 17: deeper than 16 is refused (no cycle) */
    for (i = 0; i <= PDS_MAX_INCLUDE_DEPTH + 1; i++) {
        char path[256];
        snprintf(name, sizeof name, "deep%d.scene", i);
        sl_path(path, sizeof path, name);
        snprintf(name, sizeof name, "deep%d.scene", i + 1);
        sl_path(text, sizeof text, name);
        snprintf(expect, sizeof expect, "include \"%s\"\n", strrchr(text, '/') + 1);
        REQUIRE(t, tobj_write(path, i <= PDS_MAX_INCLUDE_DEPTH ? expect : "quad { size 1 1 }\n"), "write %s", path);
    }
    sl_path(a, sizeof a, "deep0.scene");
    CHECK(t, pds_scene_load(a, &s, &err) == PDS_ERR_LIMIT && strstr(err.message, "includes nested more than 16 deep") &&
                 strstr(err.text, "deep16.scene:1:1: "),
          "got '%s'", err.text);
    /* 16 deep is allowed: start one file further in */
    sl_path(a, sizeof a, "deep1.scene");
    CHECK(t, pds_scene_load(a, &s, &err) == PDS_OK, "%s", err.text);
    pds_scene_free(s);
    for (i = 0; i <= PDS_MAX_INCLUDE_DEPTH + 1; i++) {
        snprintf(name, sizeof name, "deep%d.scene", i);
        sl_path(a, sizeof a, name);
        remove(a);
    }
    /* the scene and its includes hold at most 64 MiB of text in all: a
       33 MiB file (comment lines of 1 MiB) included twice is refused at the
       second include */
    {
        FILE *f;
        char *line = (char *)malloc(1u << 20);
        REQUIRE(t, line != NULL, "out of memory");
        memset(line, 'x', (1u << 20) - 1);
        line[0] = '#';
        line[(1u << 20) - 1] = '\n';
        sl_path(b, sizeof b, "big.scene");
        f = fopen(b, "wb");
        REQUIRE(t, f != NULL, "cannot write %s", b);
        for (i = 0; i < 33; i++) fwrite(line, 1, 1u << 20, f);
        fclose(f);
        free(line);
        sl_path(a, sizeof a, "twice.scene");
        snprintf(text, sizeof text, "include \"%s\"\n  include \"%s\"\n", strrchr(b, '/') + 1, strrchr(b, '/') + 1);
        REQUIRE(t, tobj_write(a, text), "write");
        CHECK(t, pds_scene_load(a, &s, &err) == PDS_ERR_LIMIT &&
                     strstr(err.text, "twice.scene:2:3: the scene and its included files hold more than 67108864 bytes in all"),
              "got '%s'", err.text);
        remove(a);
        remove(b);
    }
}

/* --------------------------------------------------------------- variables */

static const char sl_var_scene[] =
    "define ior 1.5\n"
    "define height 2\n"
    "define glass_name glass\n"
    "define power 40  # watts\n"
    "material $glass_name dielectric { ior $ior }\n"
    "sphere { material $glass_name radius 0.5 translate 0 $height 0 }\n"
    "light point { position 0 4 0 power $power }\n";

static void test_scene_variables_take_defaults_and_command_line_values(pds_test_ctx *t)
{
    static const char *const over[] = {"ior", "1.33", "power", "10", "power", "20", "hieght", "3"};
    pds_scene *s = NULL;
    pds_error err;
    const pds_material *m;
    REQUIRE(t, sl_load(sl_var_scene, NULL, 0, &s, &err) == PDS_OK, "%s", err.text);
    m = pds_scene_material(s, 0);
    CHECK(t, !strcmp(m->name, "glass") && m->ior == 1.5 && s->lights[0].power[0] == 40.0, "defaults: %s ior %g power %g",
          m->name, m->ior, s->lights[0].power[0]);
    CHECK_NEAR(t, s->bounds_max.y, 2.5, 1e-6);
    CHECK(t, s->nwarnings == 1, "warnings %lu (only 'no camera')", (unsigned long)s->nwarnings);
    pds_scene_free(s);
    /* -D values replace the defaults (the last of a name wins); a name the
       scene never defines is a warning with the near name */
    REQUIRE(t, sl_load(sl_var_scene, over, 4, &s, &err) == PDS_OK, "%s", err.text);
    m = pds_scene_material(s, 0);
    CHECK(t, m->ior == 1.33 && s->lights[0].power[0] == 20.0, "overridden: ior %g power %g", m->ior, s->lights[0].power[0]);
    CHECK_NEAR(t, s->bounds_max.y, 2.5, 1e-6);
    CHECK(t, sl_has_warning(s, "mem.scene: -D hieght: the scene defines no variable 'hieght' (did you mean 'height'?)"),
          "no warning about -D hieght");
    pds_scene_free(s);
}

static void test_scene_variable_errors_point_at_the_use(pds_test_ctx *t)
{
    static const char *const bad_ior[] = {"ior", "water"};
    static const char *const undeclared[] = {"k", "2"};
    static const struct {
        const char *text, *expect;
    } cases[] = {
        {"define radius 1\nsphere { radius $raduis }\n",
         "mem.scene:2:17: undefined variable '$raduis' (did you mean '$radius'?)"},
        {"sphere { radius $r }\n", "mem.scene:1:17: undefined variable '$r' (declare it first: 'define r VALUE')"},
        {"sphere { radius $ }\n", "mem.scene:1:17: expected a variable name after '$'"},
        {"define r 1\ndefine r 2\n", "mem.scene:2:8: variable 'r' is already defined at mem.scene:1:8"},
        {"define 2r 1\n", "mem.scene:1:8: expected a variable name after 'define' (a letter or '_', then letters, digits "
                          "or '_'), got '2r'"},
        {"define r {\n", "mem.scene:1:10: expected a value after 'define r' (a number, a name or a \"string\"), got '{'"},
        {"define r red\nsphere { radius $r }\n",
         "mem.scene:2:17: expected a number after 'radius', got 'red' (the value of $r, defined at mem.scene:1:8)"},
        {"defnie r 1\n", "mem.scene:1:1: unknown keyword 'defnie' (did you mean 'define'?)"},
    };
    pds_scene *s = NULL;
    pds_error err;
    size_t i;
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        CHECK(t, sl_load(cases[i].text, NULL, 0, &s, &err) == PDS_ERR_PARSE && !strcmp(err.text, cases[i].expect),
              "case %lu: got '%s'\n  expected '%s'", (unsigned long)i, err.text, cases[i].expect);
        pds_scene_free(s);
    }
    /* a -D value of the wrong kind: the error is at the use and says where
       the value came from */
    CHECK(t, sl_load(sl_var_scene, bad_ior, 1, &s, &err) == PDS_ERR_PARSE &&
                 !strcmp(err.text, "mem.scene:5:39: expected a number after 'ior', got 'water' (the value of $ior, set "
                                   "by -D ior=...)"),
          "got '%s'", err.text);
    /* -D cannot declare a variable: the scene must */
    CHECK(t, sl_load("sphere { radius $k }\n", undeclared, 1, &s, &err) == PDS_ERR_PARSE &&
                 !strcmp(err.text, "mem.scene:1:17: undefined variable '$k': -D gives it a value, but the scene must "
                                   "declare it first with 'define k DEFAULT'"),
          "got '%s'", err.text);
}

/* The content hash partial files carry is of the loaded values: a -D that
   changes a value changes it, one equal to the default does not, and the
   scene with the value written in has the same hash. */
static void test_scene_hash_follows_command_line_values(pds_test_ctx *t)
{
    static const char *const same[] = {"ior", "1.5"};
    static const char *const other[] = {"ior", "1.33"};
    static const char *const extra[] = {"nothing", "1"};
    pds_scene *s0 = NULL, *s1 = NULL, *s2 = NULL, *s3 = NULL, *lit = NULL;
    pds_error err;
    REQUIRE(t, sl_load(sl_var_scene, NULL, 0, &s0, &err) == PDS_OK && sl_load(sl_var_scene, same, 1, &s1, &err) == PDS_OK &&
                   sl_load(sl_var_scene, other, 1, &s2, &err) == PDS_OK && sl_load(sl_var_scene, extra, 1, &s3, &err) == PDS_OK,
            "%s", err.text);
    REQUIRE(t, pds_scene_load_string("material glass dielectric { ior 1.33 }\n"
                                     "sphere { material glass radius 0.5 translate 0 2 0 }\n"
                                     "light point { position 0 4 0 power 40 }\n",
                                     "lit.scene", &lit, &err) == PDS_OK,
            "%s", err.text);
    CHECK(t, pds_scene_hash(s0) == pds_scene_hash(s1), "a -D equal to the default changed the hash");
    CHECK(t, pds_scene_hash(s0) != pds_scene_hash(s2), "-D ior=1.33 did not change the hash");
    CHECK(t, pds_scene_hash(s2) == pds_scene_hash(lit), "-D ior=1.33 differs from the scene with 1.33 written in");
    CHECK(t, pds_scene_hash(s0) == pds_scene_hash(s3), "an unused -D changed the hash");
    pds_scene_free(s0);
    pds_scene_free(s1);
    pds_scene_free(s2);
    pds_scene_free(s3);
    pds_scene_free(lit);
}

/* ------------------------------------------------------------ a bare OBJ */

/* A closed UV sphere of radius r centred at (0, r + lift, 0) as an OBJ,
   optionally with a first line (mtllib ...). */
static int sl_write_sphere_obj(const char *path, double r, double lift, const char *first)
{
    FILE *f = fopen(path, "wb");
    int i, j, nu = 24, nv = 12, ok;
    if (!f) return 0;
    if (first) fprintf(f, "%s\n", first);
    fprintf(f, "v 0 %.9g 0\n", 2.0 * r + lift);
    for (j = 1; j < nv; j++)
        for (i = 0; i < nu; i++) {
            double th = PDS__PI * j / nv, ph = 2.0 * PDS__PI * i / nu;
            fprintf(f, "v %.9g %.9g %.9g\n", r * sin(th) * cos(ph), r + lift + r * cos(th), r * sin(th) * sin(ph));
        }
    fprintf(f, "v 0 %.9g 0\n", lift);
    for (i = 0; i < nu; i++) fprintf(f, "f 1 %d %d\n", 2 + (i + 1) % nu, 2 + i);
    for (j = 0; j < nv - 2; j++)
        for (i = 0; i < nu; i++) {
            int a = 2 + j * nu + i, b = 2 + j * nu + (i + 1) % nu;
            fprintf(f, "f %d %d %d %d\n", a, b, b + nu, a + nu);
        }
    for (i = 0; i < nu; i++) fprintf(f, "f %d %d %d\n", 2 + (nv - 2) * nu + i, 2 + (nv - 2) * nu + (i + 1) % nu,
                                     2 + (nv - 1) * nu);
    ok = !ferror(f);
    return (fclose(f) == 0) && ok;
}

/* Share of the pixel centres whose camera ray first hits the mesh (the
   triangles before the studio's), and of those that hit anything. */
static void sl_frame_cover(const pds_scene *s, long mesh_tris, double *mesh, double *any)
{
    const pds_camera *c = pds_scene_camera(s);
    pds__v3 fwd = pds__normalize(pds__sub(c->look_at, c->position));
    pds__v3 right = pds__normalize(pds__cross(fwd, c->up)), up = pds__cross(right, fwd);
    double th = tan(0.5 * c->fov_deg * PDS__PI / 180.0), aspect = (double)c->width / c->height;
    int x, y, W = 64, H = 48;
    long nm = 0, na = 0;
    for (y = 0; y < H; y++)
        for (x = 0; x < W; x++) {
            double u = (2.0 * (x + 0.5) / W - 1.0) * th * aspect, v = (1.0 - 2.0 * (y + 0.5) / H) * th;
            pds_ray ray;
            pds_hit hit;
            ray.origin = c->position;
            ray.dir = pds__add(fwd, pds__add(pds__scale(right, u), pds__scale(up, v)));
            ray.tmin = 0.0;
            ray.tmax = 1e30;
            if (pds_scene_intersect(s, &ray, &hit)) {
                na++;
                nm += hit.triangle < mesh_tris;
            }
        }
    *mesh = (double)nm / (W * H);
    *any = (double)na / (W * H);
}

static void test_obj_bare_mesh_is_set_in_a_studio_that_frames_and_lights_it(pds_test_ctx *t)
{
    static const double scales[2] = {1.0, 250.0}; /* any unit: metres or millimetres */
    char obj[256];
    int k;
    sl_path(obj, sizeof obj, "ball.obj");
    for (k = 0; k < 2; k++) {
        pds_scene *s = NULL, *bare = NULL;
        pds_error err;
        pds_options opt;
        pds_image img = {0, 0, NULL};
        double mesh, any, mean = 0.0;
        size_t i;
        REQUIRE(t, sl_write_sphere_obj(obj, scales[k], 3.0 * scales[k], "mtllib absent.mtl"), "write");
        REQUIRE(t, pds_scene_load_obj(obj, &bare, &err) == PDS_OK, "%s", err.text);
        REQUIRE(t, pds_scene_load_ex(obj, NULL, &s, &err) == PDS_OK, "%s", err.text);
        /* the mesh alone has no light; the studio adds one light and a
           ground just under the mesh */
        CHECK(t, bare->nlights == 0 && s->nlights == 1 && s->lights[0].type == PDS_LIGHT_DISK, "lights %lu / %lu",
              (unsigned long)bare->nlights, (unsigned long)s->nlights);
        CHECK(t, s->mesh.ntris == bare->mesh.ntris + 2, "the studio has %lu triangles, the mesh %lu",
              (unsigned long)s->mesh.ntris, (unsigned long)bare->mesh.ntris);
        CHECK_NEAR(t, s->bounds_min.y, bare->bounds_min.y - 1e-3 * 0.5 * pds__length(pds__sub(bare->bounds_max,
                                                                                                    bare->bounds_min)),
                   1e-6 * scales[k]);
        CHECK(t, sl_has_warning(s, "material libraries not found"), "the missing MTL is not a warning");
        {
            /* the light makes the unshadowed ground under the mesh's centre
               of radiance 0.6: albedo/pi times E, E integrated over the disk
               (E = integral of Le cos(theta_l) cos(theta_g) / d^2 dA, a
               200 x 400 polar midpoint rule) */
            const pds_light *l = &s->lights[0];
            pds__v3 q = pds__v(0.5 * (bare->bounds_min.x + bare->bounds_max.x), s->bounds_min.y,
                               0.5 * (bare->bounds_min.z + bare->bounds_max.z));
            pds__v3 n = l->direction, e1, e2;
            double E = 0.0;
            int ir, ia;
            pds__onb(n, &e1, &e2);
            for (ir = 0; ir < 200; ir++)
                for (ia = 0; ia < 400; ia++) {
                    double r = l->radius * (ir + 0.5) / 200, a = 2.0 * PDS__PI * (ia + 0.5) / 400;
                    pds__v3 p = pds__add(l->position, pds__add(pds__scale(e1, r * cos(a)), pds__scale(e2, r * sin(a))));
                    pds__v3 d = pds__sub(q, p);
                    double d2 = pds__dot(d, d), len = sqrt(d2);
                    double dA = r * (l->radius / 200) * (2.0 * PDS__PI / 400);
                    E += l->radiance[0] * (pds__dot(n, d) / len) * (-d.y / len) / d2 * dA;
                }
            CHECK(t, fabs(0.75 * E / PDS__PI - 0.6) < 0.6 * 0.01, "the ground under the mesh would be %g, not 0.6",
                  0.75 * E / PDS__PI);
        }
        /* framed: the mesh covers a fair part of the frame, and the ground
           the rest of its lower half */
        sl_frame_cover(s, (long)bare->mesh.ntris, &mesh, &any);
        CHECK(t, mesh > 0.12 && mesh < 0.5, "the mesh covers %.3f of the frame", mesh);
        CHECK(t, any > 0.6, "the rays hit something in only %.3f of the frame", any);
        /* and lit: a small path-traced image is far from black */
        pds_options_default(&opt);
        opt.method = PDS_METHOD_PT;
        opt.width = 32;
        opt.height = 24;
        opt.spp = 2;
        opt.threads = 2;
        REQUIRE(t, pds_render(s, &opt, &img, NULL, &err) == PDS_OK, "%s", err.text);
        for (i = 0; i < (size_t)img.width * img.height * 3; i++) mean += img.rgb[i];
        mean /= (double)img.width * img.height * 3;
        CHECK(t, mean > 0.15 && mean < 1.0, "mean pixel %.4f", mean);
        pds_image_free(&img);
        pds_scene_free(s);
        pds_scene_free(bare);
    }
    remove(obj);
}

/* Caustic light on the studio's ground: glass and metal make some, a
   diffuse mesh none (a caustic path needs a specular bounce). */
static void test_obj_studio_glass_and_metal_cast_a_caustic_on_the_ground(pds_test_ctx *t)
{
    static const pds_obj_material kinds[3] = {PDS_OBJ_MATERIAL_GLASS, PDS_OBJ_MATERIAL_METAL, PDS_OBJ_MATERIAL_DIFFUSE};
    static const char *const names[3] = {"glass", "metal", "diffuse"};
    char obj[256];
    int k;
    double ground[3];
    sl_path(obj, sizeof obj, "cball.obj");
    REQUIRE(t, sl_write_sphere_obj(obj, 1.0, 0.0, NULL), "write");
    for (k = 0; k < 3; k++) {
        pds_scene *s = NULL;
        pds_error err;
        pds_options opt;
        pds_load_options lo;
        pds_image img = {0, 0, NULL};
        pds_render_stats st;
        const pds_material *m;
        int x, y;
        pds_load_options_default(&lo);
        lo.obj_material = kinds[k];
        REQUIRE(t, pds_scene_load_ex(obj, &lo, &s, &err) == PDS_OK, "%s", err.text);
        m = pds_scene_material(s, s->mesh.mat[0]);
        CHECK(t, m->type == (k == 0 ? PDS_MAT_DIELECTRIC : k == 1 ? PDS_MAT_CONDUCTOR : PDS_MAT_DIFFUSE),
              "%s: material type %d", names[k], (int)m->type);
        pds_options_default(&opt);
        opt.method = PDS_METHOD_PDS;
        opt.paths = PDS_PATHS_CAUSTICS_ONLY;
        opt.photons = 20000;
        opt.width = 64;
        opt.height = 48;
        opt.spp = 1;
        opt.threads = 2;
        REQUIRE(t, pds_render(s, &opt, &img, &st, &err) == PDS_OK, "%s", err.text);
        /* the caustic light that lands on pixels that see the ground */
        ground[k] = 0.0;
        for (y = 0; y < img.height; y++)
            for (x = 0; x < img.width; x++) {
                const pds_camera *c = pds_scene_camera(s);
                pds__v3 fwd = pds__normalize(pds__sub(c->look_at, c->position));
                pds__v3 right = pds__normalize(pds__cross(fwd, c->up)), up = pds__cross(right, fwd);
                double th = tan(0.5 * c->fov_deg * PDS__PI / 180.0);
                double u = (2.0 * (x + 0.5) / img.width - 1.0) * th * img.width / img.height;
                double v = (1.0 - 2.0 * (y + 0.5) / img.height) * th;
                const float *p = img.rgb + 3 * ((size_t)y * img.width + x);
                pds_ray ray;
                pds_hit hit;
                ray.origin = c->position;
                ray.dir = pds__add(fwd, pds__add(pds__scale(right, u), pds__scale(up, v)));
                ray.tmin = 0.0;
                ray.tmax = 1e30;
                if (pds_scene_intersect(s, &ray, &hit) &&
                    !strcmp(pds_scene_material(s, hit.material)->name, "studio_ground"))
                    ground[k] += (double)p[0] + p[1] + p[2];
            }
        CHECK(t, k == 2 ? ground[k] == 0.0 && st.splatted == 0 : ground[k] > 1.0 && st.splatted > 1000,
              "%s: caustic on the ground %g, splatted %ld", names[k], ground[k], st.splatted);
        pds_image_free(&img);
        pds_scene_free(s);
    }
    remove(obj);
}

/* -------------------------------------------------------- OBJ robustness */

/* Names with escaped spaces, and one mtllib line naming two libraries that
   exist and one that does not: the missing one is a warning, the others
   load, and their materials reach the faces. */
static void test_obj_escaped_spaces_and_a_partly_missing_mtllib_line(pds_test_ctx *t)
{
    char obj[256], a[256], b[256], text[1024];
    pds_scene *s = NULL;
    pds_error err;
    const char *na, *nb;
    sl_path(obj, sizeof obj, "esc.obj");
    sl_path(a, sizeof a, "my lib.mtl");
    sl_path(b, sizeof b, "b.mtl");
    na = strrchr(a, '/') + 1;
    nb = strrchr(b, '/') + 1;
    REQUIRE(t, tobj_write(a, "newmtl paint\\ red\nKd 1 0 0\n") && tobj_write(b, "newmtl blue\nKd 0 0 1\n"), "write mtl");
    /* "pds_sl_PID_my lib.mtl" written with its space escaped */
    snprintf(text, sizeof text,
             "mtllib %.*s\\ lib.mtl absent.mtl %s\n"
             "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\n"
             "usemtl paint\\ red\nf 1//1 2//1 3//1\n"
             "usemtl blue\nf 1//1 2//1 3//7\n",
             (int)(strchr(na, ' ') - na), na, nb);
    REQUIRE(t, tobj_write(obj, text), "write obj");
    REQUIRE(t, pds_scene_load_ex(obj, NULL, &s, &err) == PDS_OK, "%s", err.text);
    CHECK(t, !strcmp(s->materials.items[s->mesh.mat[0]].name, "paint red") &&
                 s->materials.items[s->mesh.mat[0]].albedo[0] == 1.0,
          "triangle 0 has '%s'", s->materials.items[s->mesh.mat[0]].name);
    CHECK(t, !strcmp(s->materials.items[s->mesh.mat[1]].name, "blue"), "triangle 1 has '%s'",
          s->materials.items[s->mesh.mat[1]].name);
    CHECK(t, sl_has_warning(s, "1 material libraries not found, first ") && sl_has_warning(s, ":1:"),
          "no warning about absent.mtl");
    /* vn 7 of 1: a warning, and the corner gets the face's own normal */
    CHECK(t, sl_has_warning(s, "normal index 7 of 1"), "no warning about the normal index");
    {
        const float *n = s->mesh.nrm + 3 * s->mesh.idx[3 * 1 + 2];
        CHECK(t, fabs(n[2] - 1.0f) < 1e-6f, "the corner's normal is (%g, %g, %g)", n[0], n[1], n[2]);
    }
    pds_scene_free(s);
    remove(obj);
    remove(a);
    remove(b);
}

#ifdef PDS_TEST_POSIX
/* The tool: -D (separate, joined, --define) and --obj-material reach the
   load of render and info; mistakes are usage errors with suggestions. */
static void test_cli_defines_and_obj_material_reach_the_scene(pds_test_ctx *t)
{
    char scene[256], obj[256], out[256], args[1200], buf[8192];
    sl_path(scene, sizeof scene, "cli.scene");
    sl_path(obj, sizeof obj, "cli.obj");
    sl_path(out, sizeof out, "cli.pfm");
    REQUIRE(t, tobj_write(scene, sl_var_scene) && sl_write_sphere_obj(obj, 1.0, 0.0, NULL), "write");
    snprintf(args, sizeof args, "info %s -D power=7 -Dior=1.25 --define height=3", scene);
    CHECK(t, cli_run(args, buf, sizeof buf) == 0 && strstr(buf, "power (7, 7, 7) W") && strstr(buf, "ior 1.25") &&
                 strstr(buf, "bounds=-0.5,2.5,-0.5:0.5,3.5,0.5"),
          "info with -D: %s", buf);
    snprintf(args, sizeof args, "render %s --method pt --res 8x6 --spp 1 -D pwoer=3 -o %s", scene, out);
    CHECK(t, cli_run(args, buf, sizeof buf) == 0 &&
                 strstr(buf, "-D pwoer: the scene defines no variable 'pwoer' (did you mean 'power'?)"),
          "render with an unknown -D: %s", buf);
    snprintf(args, sizeof args, "render %s -D 3d=1 -o %s", scene, out);
    CHECK(t, cli_run(args, buf, sizeof buf) == 2 && strstr(buf, "-D needs NAME=VALUE"), "a bad -D name: %s", buf);
    snprintf(args, sizeof args, "info %s --obj-material glas", obj);
    CHECK(t, cli_run(args, buf, sizeof buf) == 2 && strstr(buf, "(did you mean 'glass'?)"), "--obj-material glas: %s", buf);
    snprintf(args, sizeof args, "info %s --obj-material=metal", obj);
    CHECK(t, cli_run(args, buf, sizeof buf) == 0 && strstr(buf, "studio_mesh      conductor") &&
                 strstr(buf, "light       disk"),
          "--obj-material metal: %s", buf);
    /* race --resume reuses a kept entry only for the same scene content:
       other -D values are another scene */
    {
        char dir[256];
        static const char *const runs[3][2] = {{"-D power=30", ""}, {"-D power=30", "--resume"}, {"-D power=31", "--resume"}};
        static const char *const resumed[3] = {"resumed=0", "resumed=2", "resumed=0"};
        int k;
        sl_path(dir, sizeof dir, "race");
        snprintf(args, sizeof args, "render %s --method pt --caustics-only --res 16x12 --spp 2 -o %s --quiet", scene, out);
        REQUIRE(t, cli_run(args, buf, sizeof buf) == 0, "reference: %s", buf);
        for (k = 0; k < 3; k++) {
            snprintf(args, sizeof args, "race %s --ref %s --photons 2000 --methods pds,pm --caustics-only --res 16x12 "
                     "--spp 1 -o %s --quiet %s %s", scene, out, dir, runs[k][0], runs[k][1]);
            CHECK(t, cli_run(args, buf, sizeof buf) == 0 && strstr(buf, resumed[k]), "race %s %s: %s", runs[k][0],
                  runs[k][1], buf);
        }
        snprintf(args, sizeof args, "rm -rf '%s'", dir);
        CHECK(t, system(args) == 0, "rm");
    }
    remove(scene);
    remove(obj);
    remove(out);
}
#endif

static const pds_test_case tests_scenelang[] = {
    {"scene_include_reads_files_relative_to_the_including_file", test_scene_include_reads_files_relative_to_the_including_file},
    {"scene_include_errors_name_the_file_and_where_it_was_included_from",
     test_scene_include_errors_name_the_file_and_where_it_was_included_from},
    {"scene_include_cycles_and_depth_are_refused", test_scene_include_cycles_and_depth_are_refused},
    {"scene_variables_take_defaults_and_command_line_values", test_scene_variables_take_defaults_and_command_line_values},
    {"scene_variable_errors_point_at_the_use", test_scene_variable_errors_point_at_the_use},
    {"scene_hash_follows_command_line_values", test_scene_hash_follows_command_line_values},
    {"obj_bare_mesh_is_set_in_a_studio_that_frames_and_lights_it",
     test_obj_bare_mesh_is_set_in_a_studio_that_frames_and_lights_it},
    {"obj_studio_glass_and_metal_cast_a_caustic_on_the_ground", test_obj_studio_glass_and_metal_cast_a_caustic_on_the_ground},
    {"obj_escaped_spaces_and_a_partly_missing_mtllib_line", test_obj_escaped_spaces_and_a_partly_missing_mtllib_line},
#ifdef PDS_TEST_POSIX
    {"cli_defines_and_obj_material_reach_the_scene", test_cli_defines_and_obj_material_reach_the_scene},
#endif
};

/* tests/test_scene.c - scene format parser, shape generators, transforms,
   lights, and the public ray queries. */

/* Write text to a fresh temporary file; returns its path in buf. */
static const char *scene_tmp_write(char *buf, size_t n, const char *name, const char *text)
{
    FILE *f;
    snprintf(buf, n, "/tmp/pds_test_%ld_%s", (long)getpid(), name);
    f = fopen(buf, "wb");
    if (!f) return NULL;
    fputs(text, f);
    fclose(f);
    return buf;
}

/* Load scene text; returns the scene or NULL with *err filled. */
static pds_scene *scene_from_text(const char *text, pds_error *err)
{
    char path[256];
    pds_scene *s = NULL;
    if (!scene_tmp_write(path, sizeof path, "t.scene", text)) return NULL;
    if (pds_scene_load(path, &s, err) != PDS_OK) s = NULL;
    remove(path);
    return s;
}

static void test_scene_parses_every_statement_kind(pds_test_ctx *t)
{
    pds_error err;
    const pds_material *m;
    const pds_light *l;
    pds_scene_info info;
    pds_scene *s = scene_from_text(
        "# a comment line\n"
        "camera { position 1 2 3 look_at 0 0 0 up 0 1 0 fov 45 resolution 320 240 spp 8 filter tent }\n"
        "material white diffuse { albedo 0.5 0.6 0.7 }\n"
        "material grey diffuse { albedo 0.25 }  # one number means grey\n"
        "material m mirror { reflectance 0.9 }\n"
        "material au conductor { eta 0.1 0.2 0.3 k 3 2 1 }\n"
        "material ag conductor { preset silver }\n"
        "material glass dielectric { ior 1.33 absorption 0.1 0.2 0.3 }\n"
        "material bk7 dielectric { sellmeier 1.03961212 0.231792344 1.01046945 0.00600069867 0.0200179144 103.560653 }\n"
        "material lamp emissive { radiance 2 3 4 }\n"
        "light point { position 0 5 0 power 100 }\n"
        "light spot { position 0 5 0 look_at 0 0 0 power 10 20 30 cone 10 20 }\n"
        "light directional { direction 0 -1 0 irradiance 2 disk 0 5 0 0.5 }\n"
        "light directional { direction 0 -1 0 irradiance 1 rect 0 5 0 2 0 0 0 0 3 }\n"
        "light disk { center 0 3 0 normal 0 -1 0 radius 0.5 radiance 1 }\n"
        "light quad { center 0 3 0 edge1 1 0 0 edge2 0 0 2 power 8 }\n"
        "sphere { material glass radius 0.5 segments 16 rings 8 translate 0 1 0 }\n"
        "quad { material white size 4 4 }\n"
        "box { material grey size 1 2 3 }\n"
        "disk { material lamp radius 1 segments 12 translate 0 4 0 rotate 180 1 0 0 }\n"
        "cylinder { material au radius 1 inner_radius 0.9 height 0.3 segments 24 sweep 180 }\n"
        "torus { material ag major 1 minor 0.2 segments 24 rings 12 }\n"
        "revolve { material glass profile 0 0 1 0 1 1 0.5 2 segments 16 }\n"
        "heightfield { material m size 2 2 resolution 8 8 wave 0.1 1 1 0 wave 0.05 0.5 0 1 90 }\n",
        &err);
    REQUIRE(t, s != NULL, "load failed: %s", err.text);
    pds_scene_get_info(s, &info);
    CHECK(t, info.materials == 8, "materials %d", info.materials);
    CHECK(t, info.shapes == 8, "shapes %d", info.shapes);
    CHECK(t, info.lights == 7, "lights %d (6 explicit + 1 emissive mesh)", info.lights);
    CHECK(t, info.mesh_lights == 1, "mesh lights %d", info.mesh_lights);
    CHECK(t, info.warnings == 0, "warnings %d: %s", info.warnings, info.warnings ? pds_scene_warning(s, 0) : "");
    CHECK(t, pds_scene_camera(s)->width == 320 && pds_scene_camera(s)->height == 240, "resolution");
    CHECK(t, pds_scene_camera(s)->spp == 8 && pds_scene_camera(s)->filter == PDS_FILTER_TENT, "spp/filter");
    CHECK_NEAR(t, pds_scene_camera(s)->fov_deg, 45.0, 0);
    m = pds_scene_material(s, 1);
    CHECK(t, m->type == PDS_MAT_DIFFUSE && m->albedo[0] == 0.25 && m->albedo[2] == 0.25, "grey albedo");
    m = pds_scene_material(s, 4);
    CHECK(t, m->type == PDS_MAT_CONDUCTOR && m->eta[1] == 0.237 && m->k[0] == 4.483, "silver preset");
    m = pds_scene_material(s, 6);
    /* N-BK7 at 587.6 nm: n_d = 1.5168 (Schott's N-BK7 data sheet) */
    CHECK_NEAR(t, m->ior, 1.51680, 2e-5);
    CHECK(t, m->dispersion == PDS_DISPERSION_SELLMEIER, "sellmeier kept");
    l = pds_scene_light(s, 1);
    CHECK(t, l->type == PDS_LIGHT_SPOT && l->power[2] == 30.0, "spot power");
    CHECK_NEAR(t, l->direction.y, -1.0, 1e-12);
    l = pds_scene_light(s, 2);
    CHECK_NEAR(t, l->area, PDS__PI * 0.25, 1e-12);
    CHECK_NEAR(t, l->power[0], 2.0 * PDS__PI * 0.25, 1e-12);
    l = pds_scene_light(s, 3);
    CHECK_NEAR(t, l->area, 6.0, 1e-12);
    l = pds_scene_light(s, 4);
    /* one-sided Lambertian disk: P = pi L A */
    CHECK_NEAR(t, l->power[1], PDS__PI * 1.0 * PDS__PI * 0.25, 1e-12);
    l = pds_scene_light(s, 5);
    CHECK_NEAR(t, l->area, 2.0, 1e-12);
    CHECK_NEAR(t, l->radiance[0], 8.0 / (PDS__PI * 2.0), 1e-12);
    l = pds_scene_light(s, 6);
    CHECK(t, l->type == PDS_LIGHT_MESH, "mesh light last");
    /* disk of radius 1 with 12 segments: area of the regular 12-gon, 3 r^2 */
    CHECK_NEAR(t, l->area, 3.0, 1e-6);
    CHECK_NEAR(t, l->power[2], PDS__PI * 4.0 * 3.0, 1e-5);
    pds_scene_free(s);
}

static void test_scene_numbers_take_every_c_form(pds_test_ctx *t)
{
    static const struct { const char *text; double value; } cases[] = {
        {"16", 16}, {"0x10", 16}, {"010", 8}, {"1e2", 100}, {"0x1p-1", 0.5}, {"1.5f", 1.5}, {"+2", 2},
        {".5", 0.5}, {"10u", 10}, {"-3.25e-1", -0.325}, {"7L", 7}, {"0", 0}, {"0.0", 0}, {"0XFF", 255},
    };
    static const char *const bad[] = {"1.2.3", "0x", "1e", "12abc", "0x1g", "--1", "nan", "inf"};
    size_t i;
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        double v = -1;
        CHECK(t, pds__parse_c_number(cases[i].text, &v) == 0 && v == cases[i].value, "'%s' -> %g, expected %g",
              cases[i].text, v, cases[i].value);
    }
    for (i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        double v;
        CHECK(t, pds__parse_c_number(bad[i], &v) != 0, "'%s' should not parse", bad[i]);
    }
}

/* Each bad scene gives exactly this message (the file name is replaced by
   FILE in the expectation). */
static void test_scene_errors_name_file_line_column_word_for_word(pds_test_ctx *t)
{
    static const struct { const char *text, *expect; pds_status status; } cases[] = {
        {"sphere { radius 1 }\nfoo { }\n", "FILE:2:1: unknown keyword 'foo' (expected camera, material, light, include, "
                                          "define, mesh, sphere, disk, quad, box, cylinder, torus, revolve or heightfield)", PDS_ERR_PARSE},
        {"material g dielectric { ior glass }", "FILE:1:29: expected a number after 'ior', got 'glass'", PDS_ERR_PARSE},
        {"sphere {\n  material nothing\n}", "FILE:2:12: unknown material 'nothing'", PDS_ERR_PARSE},
        {"mesh \"missing.obj\" { }", "FILE:1:6: cannot read mesh '/tmp/missing.obj': No such file or directory", PDS_ERR_IO},
        {"camera { resolution -5 10 }", "FILE:1:21: 'resolution' must be at least 1, got -5", PDS_ERR_PARSE},
        {"camera { resolution 99999 10 }", "FILE:1:21: 'resolution' must be at most 16384, got 99999", PDS_ERR_LIMIT},
        {"sphere { radius nan }", "FILE:1:17: expected a number after 'radius', got 'nan'", PDS_ERR_PARSE},
        {"sphere { radius 1e999 }", "FILE:1:17: 'radius' must be finite, got '1e999'", PDS_ERR_PARSE},
        {"sphere { radius 1e13 }", "FILE:1:17: 'radius' value 1e13 is beyond the limit of 1e+12", PDS_ERR_LIMIT},
        {"light spot { position 0 1 0 direction 0 0 0 power 1 }",
         "FILE:1:43: 'direction' must not be a zero-length vector", PDS_ERR_PARSE},
        {"sphere { segments 100000 }", "FILE:1:19: 'segments' must be at most 4096, got 100000", PDS_ERR_LIMIT},
        {"sphere { radius -1 }", "FILE:1:17: 'radius' must be positive, got -1", PDS_ERR_PARSE},
        {"sphere { radius 1 ", "FILE:1:8: this '{' of the sphere block is never closed: the file ends first",
         PDS_ERR_PARSE},
        /* near misses get the nearest key valid in that block, and only those */
        {"material m diffuse { albdo 0.5 }",
         "FILE:1:22: unknown keyword 'albdo' in the diffuse material block (did you mean 'albedo'?)", PDS_ERR_PARSE},
        {"light point { positon 0 1 0 power 1 }",
         "FILE:1:15: unknown keyword 'positon' in the point light block (did you mean 'position'?)", PDS_ERR_PARSE},
        {"box { segmnts 4 }", "FILE:1:7: unknown keyword 'segmnts' in the box block", PDS_ERR_PARSE},
        {"material m diffuse {\n albedo 0.5\n\nquad { }\n",
         "FILE:4:1: 'quad' starts a statement, but the diffuse material block opened at 1:20 is not closed (a '}' "
         "missing?)", PDS_ERR_PARSE},
        {"sphere { colour 1 }", "FILE:1:10: unknown keyword 'colour' in the sphere block", PDS_ERR_PARSE},
        {"material a diffuse { }\nmaterial a mirror { }", "FILE:2:10: material 'a' is defined twice", PDS_ERR_PARSE},
        {"camera { }\ncamera { }", "FILE:2:1: the scene has two cameras", PDS_ERR_PARSE},
        {"mesh \"abc { }", "FILE:1:6: unterminated string", PDS_ERR_PARSE},
        {"camera { position 0 0 0 look_at 0 0 0 }", "FILE:1:1: camera position and look_at are the same point", PDS_ERR_PARSE},
        {"camera { fov 180 }", "FILE:1:14: 'fov' must be between 0 and 180 degrees, got 180", PDS_ERR_PARSE},
        {"light point { position 0 1 0 }", "FILE:1:7: point light needs 'power'", PDS_ERR_PARSE},
        {"light directional { irradiance 1 }",
         "FILE:1:7: directional light needs an emitter: 'disk CENTER RADIUS' or 'rect CENTER EDGE1 EDGE2'", PDS_ERR_PARSE},
        {"material d diffuse { albedo 1.5 }", "FILE:1:29: 'albedo' must be at most 1 (energy conservation)", PDS_ERR_PARSE},
        {"material d diffuse { tiles 0.2 0.3 1 }", "FILE:1:32: 'tiles' must be between 0 and 0.2, got 0.3", PDS_ERR_PARSE},
        {"material d diffuse { tiles 0.2 0.01 2 }", "FILE:1:37: the grout albedo of 'tiles' must be between 0 and 1", PDS_ERR_PARSE},
        {"torus { major 1 minor 2 }", "FILE:1:1: torus 'minor' must be smaller than 'major'", PDS_ERR_PARSE},
        {"sphere { scale 0 }", "FILE:1:16: 'scale' factors must be positive (use 'rotate' to turn a shape over)", PDS_ERR_PARSE},
        {"sphere { segments 2.5 }", "FILE:1:19: 'segments' must be a whole number, got 2.5", PDS_ERR_PARSE},
        {"sphere @", "FILE:1:8: unexpected character '@'", PDS_ERR_PARSE},
        {"sphere { radius 1 } }", "FILE:1:21: expected a statement (camera, material, light or a shape), got '}'", PDS_ERR_PARSE},
        {"revolve { profile 1 0 }", "FILE:1:11: 'profile' needs at least two points (r y pairs)", PDS_ERR_PARSE},
    };
    size_t i;
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char path[256], expect[1024];
        const char *at;
        pds_scene *s = NULL;
        pds_error err;
        pds_status st;
        scene_tmp_write(path, sizeof path, "err.scene", cases[i].text);
        st = pds_scene_load(path, &s, &err);
        remove(path);
        CHECK(t, st == cases[i].status && s == NULL, "case %d: status %d, expected %d", (int)i, (int)st, (int)cases[i].status);
        if (st == PDS_OK) {
            pds_scene_free(s);
            continue;
        }
        at = strstr(cases[i].expect, "FILE");
        snprintf(expect, sizeof expect, "%s%s", path, at + 4);
        CHECK(t, strcmp(err.text, expect) == 0, "case %d:\n  got      %s\n  expected %s", (int)i, err.text, expect);
    }
}

static void test_scene_missing_file_is_an_io_error(pds_test_ctx *t)
{
    pds_scene *s = (pds_scene *)1;
    pds_error err;
    pds_status st = pds_scene_load("/nonexistent/x.scene", &s, &err);
    CHECK(t, st == PDS_ERR_IO && s == NULL, "status %d", (int)st);
    CHECK(t, strcmp(err.text, "/nonexistent/x.scene: cannot open: No such file or directory") == 0, "%s", err.text);
}

/* Signed volume by the divergence theorem: sum over triangles of
   p0 . (p1 x p2) / 6. Positive and equal to the solid's volume only if the
   surface is closed and wound outwards. */
static double mesh_signed_volume(const pds__mesh *m, size_t first, size_t count)
{
    double v = 0.0;
    size_t i;
    for (i = first; i < first + count; i++) {
        const int *k = &m->idx[3 * i];
        v += pds__dot(pds__mesh_pos(m, k[0]), pds__cross(pds__mesh_pos(m, k[1]), pds__mesh_pos(m, k[2])));
    }
    return v / 6.0;
}

static double mesh_area(const pds__mesh *m)
{
    double a = 0.0;
    size_t i;
    for (i = 0; i < m->ntris; i++) a += 0.5 * pds__mesh_tri_area2(m, m->idx[3 * i], m->idx[3 * i + 1], m->idx[3 * i + 2]);
    return a;
}

/* Fraction of triangles whose geometric normal agrees with all three vertex
   normals (dot > 0). */
static double mesh_winding_agreement(const pds__mesh *m)
{
    size_t i, good = 0;
    for (i = 0; i < m->ntris; i++) {
        const int *k = &m->idx[3 * i];
        pds__v3 p0 = pds__mesh_pos(m, k[0]);
        pds__v3 ng = pds__cross(pds__sub(pds__mesh_pos(m, k[1]), p0), pds__sub(pds__mesh_pos(m, k[2]), p0));
        int j, ok = 1;
        for (j = 0; j < 3; j++) ok &= pds__dot(ng, pds__mesh_nrm(m, k[j])) > 0.0;
        good += (size_t)ok;
    }
    return m->ntris ? (double)good / (double)m->ntris : 0.0;
}

static void test_shapes_closed_solids_have_their_analytic_volume(pds_test_ctx *t)
{
    pds__xform id = pds__xform_identity();
    pds__mesh m;
    pds__emitter e;
    double R = 1.3, r = 0.4, h = 0.7;
    e.xf = &id;
    e.material = 0;
    e.mesh = &m;
    /* box: exact */
    memset(&m, 0, sizeof m);
    REQUIRE(t, pds__gen_box(&e, pds__v(1, 2, 3)) == 0, "box");
    CHECK_NEAR(t, mesh_signed_volume(&m, 0, m.ntris), 6.0, 1e-6);
    CHECK(t, mesh_winding_agreement(&m) == 1.0, "box winding");
    pds__mesh_free(&m);
    /* sphere: the inscribed polyhedron approaches 4/3 pi r^3 from below */
    memset(&m, 0, sizeof m);
    REQUIRE(t, pds__gen_sphere(&e, R, 256, 128) == 0, "sphere");
    CHECK_NEAR(t, mesh_signed_volume(&m, 0, m.ntris) / (4.0 / 3.0 * PDS__PI * R * R * R), 1.0, 1e-3);
    CHECK_NEAR(t, mesh_area(&m) / (4.0 * PDS__PI * R * R), 1.0, 1e-3);
    CHECK(t, mesh_winding_agreement(&m) == 1.0, "sphere winding %g", mesh_winding_agreement(&m));
    CHECK(t, m.degenerate_dropped == 0, "pole triangles are not counted as user-degenerate");
    pds__mesh_free(&m);
    /* closed tube (a ring): pi (R^2 - r^2) h, segments-gon corrected */
    memset(&m, 0, sizeof m);
    REQUIRE(t, pds__gen_cylinder(&e, R, r, h, 64, 1, 2.0 * PDS__PI) == 0, "tube");
    {
        double polygon = 0.5 * 64 * sin(2.0 * PDS__PI / 64); /* area of unit 64-gon / r^2 */
        CHECK_NEAR(t, mesh_signed_volume(&m, 0, m.ntris), polygon * (R * R - r * r) * h, 1e-5);
    }
    CHECK(t, mesh_winding_agreement(&m) == 1.0, "tube winding");
    pds__mesh_free(&m);
    /* closed half tube: the two cut faces close it */
    memset(&m, 0, sizeof m);
    REQUIRE(t, pds__gen_cylinder(&e, R, r, h, 64, 1, PDS__PI) == 0, "half tube");
    /* 64 segments over half a turn: half of a regular 128-gon */
    CHECK_NEAR(t, mesh_signed_volume(&m, 0, m.ntris), 0.5 * 0.5 * 128 * sin(2.0 * PDS__PI / 128) * (R * R - r * r) * h, 1e-5);
    pds__mesh_free(&m);
    /* torus: 2 pi^2 R r^2 */
    memset(&m, 0, sizeof m);
    REQUIRE(t, pds__gen_torus(&e, R, r, 256, 128, 2.0 * PDS__PI) == 0, "torus");
    CHECK_NEAR(t, mesh_signed_volume(&m, 0, m.ntris) / (2.0 * PDS__PI * PDS__PI * R * r * r), 1.0, 1e-3);
    CHECK(t, mesh_winding_agreement(&m) == 1.0, "torus winding");
    pds__mesh_free(&m);
    /* revolve: a closed cylinder drawn as a profile (axis, bottom rim, top
       rim, axis) with sharp creases: pi r^2 h */
    memset(&m, 0, sizeof m);
    {
        double prof[8] = {0, 0, 1, 0, 1, 2, 0, 2};
        /* walk: bottom outwards, up the side, top inwards; normals to the
           right of travel: down, out, up */
        REQUIRE(t, pds__gen_revolve(&e, prof, 4, 256, 2.0 * PDS__PI, 30.0) == 0, "revolve");
        CHECK_NEAR(t, mesh_signed_volume(&m, 0, m.ntris) / (PDS__PI * 2.0), 1.0, 1e-3);
        CHECK(t, mesh_winding_agreement(&m) == 1.0, "revolve winding");
    }
    pds__mesh_free(&m);
}

static void test_shapes_normals_match_the_analytic_surface(pds_test_ctx *t)
{
    pds__xform id = pds__xform_identity();
    pds__mesh m;
    pds__emitter e;
    pds__wave w[2] = {{0.1, 1.0, 1.0, 0.0, 0.0}, {0.05, 0.5, 0.6, 0.8, 1.0}};
    size_t i;
    double worst = 0.0;
    e.xf = &id;
    e.material = 0;
    e.mesh = &m;
    memset(&m, 0, sizeof m);
    REQUIRE(t, pds__gen_sphere(&e, 2.0, 32, 16) == 0, "sphere");
    for (i = 0; i < m.nverts; i++) {
        pds__v3 d = pds__sub(pds__scale(pds__mesh_pos(&m, (long)i), 0.5), pds__mesh_nrm(&m, (long)i));
        if (pds__length(d) > worst) worst = pds__length(d);
    }
    CHECK(t, worst < 1e-6, "sphere normal = position / radius, worst %g", worst);
    pds__mesh_free(&m);
    /* heightfield: analytic gradient vs central finite differences */
    memset(&m, 0, sizeof m);
    REQUIRE(t, pds__gen_heightfield(&e, 2.0, 2.0, 16, 16, w, 2) == 0, "heightfield");
    worst = 0.0;
    for (i = 0; i < m.nverts; i++) {
        pds__v3 p = pds__mesh_pos(&m, (long)i), n = pds__mesh_nrm(&m, (long)i);
        double hx, hz, eps = 1e-5, gx, gz;
        double y = pds__waves_eval(w, 2, p.x, p.z, &hx, &hz);
        gx = (pds__waves_eval(w, 2, p.x + eps, p.z, &hx, &hz) - pds__waves_eval(w, 2, p.x - eps, p.z, &hx, &hz)) / (2 * eps);
        gz = (pds__waves_eval(w, 2, p.x, p.z + eps, &hx, &hz) - pds__waves_eval(w, 2, p.x, p.z - eps, &hx, &hz)) / (2 * eps);
        {
            pds__v3 expect = pds__normalize(pds__v(-gx, 1.0, -gz));
            double d = pds__length(pds__sub(expect, n));
            if (d > worst) worst = d;
        }
        CHECK(t, fabs(y - p.y) < 1e-6, "height at vertex %d", (int)i);
    }
    CHECK(t, worst < 1e-5, "heightfield normals vs finite differences, worst %g", worst);
    CHECK(t, mesh_winding_agreement(&m) == 1.0, "heightfield winding");
    pds__mesh_free(&m);
    /* revolve with crease 180 is smooth: the rim vertex has one averaged normal */
    memset(&m, 0, sizeof m);
    {
        double prof[6] = {1, 0, 1, 1, 0, 1};
        REQUIRE(t, pds__gen_revolve(&e, prof, 3, 8, 2.0 * PDS__PI, 180.0) == 0, "revolve smooth");
        /* rows: 3 profile points x 9 columns; the rim (row 1, column 0) normal
           averages (1,0) and (0,1) */
        CHECK_NEAR(t, m.nrm[3 * 9 + 0], sqrt(0.5), 1e-6);
        CHECK_NEAR(t, m.nrm[3 * 9 + 1], sqrt(0.5), 1e-6);
    }
    pds__mesh_free(&m);
}

static void test_transforms_apply_in_written_order(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text("box { size 1 scale 2 1 1 rotate 90 0 1 0 translate 0 0 5 }\n", &err);
    pds_scene_info info;
    REQUIRE(t, s != NULL, "%s", err.text);
    pds_scene_get_info(s, &info);
    /* scale x by 2 -> [-1,1]x[-.5,.5]^2; rotate +90 about y maps x to -z;
       translate z by 5 */
    CHECK_NEAR(t, info.bounds_min.x, -0.5, 1e-6);
    CHECK_NEAR(t, info.bounds_max.x, 0.5, 1e-6);
    CHECK_NEAR(t, info.bounds_min.z, 4.0, 1e-6);
    CHECK_NEAR(t, info.bounds_max.z, 6.0, 1e-6);
    pds_scene_free(s);
    {
        /* rotation: +90 degrees about +y takes +x to -z (right hand) */
        pds__xform r = pds__xform_rotate(90.0, pds__v(0, 1, 0));
        pds__v3 p = pds__xform_point(&r, pds__v(1, 0, 0));
        CHECK(t, fabs(p.x) < 1e-12 && fabs(p.z + 1.0) < 1e-12, "R(+x) = (%g, %g, %g)", p.x, p.y, p.z);
    }
    {
        /* non-uniform scale: normals stay perpendicular to the surface */
        pds__xform x = pds__xform_identity();
        pds__v3 tangent = pds__v(1, -1, 0), n = pds__normalize(pds__v(1, 1, 0));
        x.m[0][0] = 3.0;
        CHECK_NEAR(t, pds__dot(pds__sub(pds__xform_point(&x, tangent), pds__xform_point(&x, pds__v(0, 0, 0))), pds__xform_normal(&x, n)), 0.0, 1e-12);
        x.m[0][0] = -3.0; /* mirroring keeps the normal on the same side */
        CHECK(t, pds__xform_det(&x) < 0, "mirror det");
        CHECK(t, pds__xform_normal(&x, n).x < 0, "mirrored normal flips with the surface");
    }
}

static void test_scene_ray_queries_report_hit_details(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text("material red diffuse { albedo 0.8 0.1 0.1 }\n"
                                   "sphere { material red radius 1 segments 256 rings 128 translate 0 0 -5 }\n",
                                   &err);
    pds_ray ray;
    pds_hit hit;
    REQUIRE(t, s != NULL, "%s", err.text);
    ray.origin = pds__v(0, 0, 0);
    ray.dir = pds__v(0, 0, -1);
    ray.tmin = 0.0;
    ray.tmax = 1e30;
    REQUIRE(t, pds_scene_intersect(s, &ray, &hit), "ray misses the sphere");
    CHECK_NEAR(t, hit.t, 4.0, 1e-3);
    CHECK_NEAR(t, hit.position.z, -4.0, 1e-3);
    CHECK(t, hit.ns.z > 0.999 && hit.ng.z > 0.999, "normals face the ray's origin");
    CHECK(t, strcmp(pds_scene_material(s, hit.material)->name, "red") == 0, "material");
    CHECK(t, pds_scene_occluded(s, &ray), "occluded");
    ray.tmax = 3.9;
    CHECK(t, !pds_scene_occluded(s, &ray) && !pds_scene_intersect(s, &ray, &hit), "tmax respected");
    ray.tmax = 1e30;
    ray.dir = pds__v(0, 0, 1);
    CHECK(t, !pds_scene_intersect(s, &ray, &hit), "ray away misses");
    pds_scene_free(s);
}

static void test_scene_warns_about_missing_lights_and_camera(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text("sphere { }\n", &err);
    pds_scene_info info;
    REQUIRE(t, s != NULL, "%s", err.text);
    pds_scene_get_info(s, &info);
    CHECK(t, info.warnings == 2, "warnings %d", info.warnings);
    CHECK(t, info.warnings == 2 && strstr(pds_scene_warning(s, 0), "no camera given") &&
                 strstr(pds_scene_warning(s, 1), "no light"), "warning texts");
    CHECK(t, info.materials == 1 && !strcmp(pds_scene_material(s, 0)->name, "default"), "default material");
    pds_scene_free(s);
}


static void test_scene_mesh_statement_loads_obj_relative_to_the_scene(pds_test_ctx *t)
{
    char obj[256], mtl[256], scene[256];
    pds_scene *s = NULL;
    pds_error err;
    pds_scene_info info;
    int i, glass_tris = 0, red_tris = 0;
    scene_tmp_write(mtl, sizeof mtl, "m.mtl", "newmtl glassy\nNi 1.5\nillum 7\nnewmtl plain\nKd 0.2 0.3 0.4\n");
    {
        char text[512];
        snprintf(text, sizeof text,
                 "mtllib pds_test_%ld_m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                 "usemtl glassy\nf 1 2 3\nusemtl plain\nf 1 3 4\n", (long)getpid());
        scene_tmp_write(obj, sizeof obj, "m.obj", text);
    }
    {
        char text[512];
        snprintf(text, sizeof text,
                 "material red diffuse { albedo 0.9 0 0 }\n"
                 "mesh \"pds_test_%ld_m.obj\" { replace plain red  scale 2  translate 0 0 -1 }\n", (long)getpid());
        scene_tmp_write(scene, sizeof scene, "m.scene", text);
    }
    REQUIRE(t, pds_scene_load(scene, &s, &err) == PDS_OK, "%s", err.text);
    pds_scene_get_info(s, &info);
    CHECK(t, info.triangles == 2, "triangles %ld", info.triangles);
    CHECK_NEAR(t, info.bounds_max.x, 2.0, 1e-6);
    CHECK_NEAR(t, info.bounds_min.z, -1.0, 1e-6);
    for (i = 0; i < 2; i++) {
        const pds_material *m = pds_scene_material(s, s->mesh.mat[i]);
        glass_tris += m->type == PDS_MAT_DIELECTRIC && m->ior == 1.5;
        red_tris += !strcmp(m->name, "red");
    }
    CHECK(t, glass_tris == 1 && red_tris == 1, "materials: glass %d red %d", glass_tris, red_tris);
    pds_scene_free(s);
    /* the same OBJ as a bare scene: default camera framing its bounds */
    REQUIRE(t, pds_scene_load_obj(obj, &s, &err) == PDS_OK, "%s", err.text);
    CHECK_NEAR(t, pds_scene_camera(s)->look_at.x, 0.5, 1e-9);
    CHECK_NEAR(t, pds_scene_camera(s)->look_at.y, 0.5, 1e-9);
    {
        pds_ray ray;
        pds_hit hit;
        ray.origin = pds_scene_camera(s)->position;
        ray.dir = pds__sub(pds_scene_camera(s)->look_at, ray.origin);
        ray.tmin = 0.0;
        ray.tmax = 1e30;
        CHECK(t, pds_scene_intersect(s, &ray, &hit) && fabs(hit.t - 1.0) < 1e-6, "camera looks at the mesh");
    }
    pds_scene_free(s);
    remove(obj);
    remove(mtl);
    remove(scene);
}

static const pds_test_case tests_scene[] = {
    {"scene_parses_every_statement_kind", test_scene_parses_every_statement_kind},
    {"scene_numbers_take_every_c_form", test_scene_numbers_take_every_c_form},
    {"scene_errors_name_file_line_column_word_for_word", test_scene_errors_name_file_line_column_word_for_word},
    {"scene_missing_file_is_an_io_error", test_scene_missing_file_is_an_io_error},
    {"shapes_closed_solids_have_their_analytic_volume", test_shapes_closed_solids_have_their_analytic_volume},
    {"shapes_normals_match_the_analytic_surface", test_shapes_normals_match_the_analytic_surface},
    {"transforms_apply_in_written_order", test_transforms_apply_in_written_order},
    {"scene_ray_queries_report_hit_details", test_scene_ray_queries_report_hit_details},
    {"scene_warns_about_missing_lights_and_camera", test_scene_warns_about_missing_lights_and_camera},
    {"scene_mesh_statement_loads_obj_relative_to_the_scene", test_scene_mesh_statement_loads_obj_relative_to_the_scene},
};

/* tests/test_teach.c - the teaching kit: the debug views (>>debug) are
   checked for their content against the render they come with, the paths
   OBJ is read back by the OBJ loader, and `pds trace-photon`'s
   differentials agree with finite differences of neighbouring photons. */

/* Render scene text with the paper's PDS (caustics only, 5000 photons)
   and the debug views in `views`. */
static int teach_render_text(const char *text, unsigned views, int threads, pds_image *img, pds_render_stats *st,
                             pds_debug *dbg)
{
    pds_options opt;
    pds_options_default(&opt);
    pds_debug_init(dbg);
    dbg->views = views;
    dbg->ellipse_every = 50;
    dbg->path_photons = 300;
    opt.method = PDS_METHOD_PDS;
    opt.progressive = 0;
    opt.smoothing = 8.0;
    opt.photons = 5000;
    opt.paths = PDS_PATHS_CAUSTICS_ONLY;
    opt.threads = threads;
    opt.debug = dbg;
    return render_text(text, &opt, img, st);
}

/* Render mirror_scene (tests/test_pds.c: a point light, a vertical plane
   mirror, a camera looking straight down at the floor) so. */
static int teach_render(unsigned views, int threads, pds_image *img, pds_render_stats *st, pds_debug *dbg)
{
    return teach_render_text(mirror_scene, views, threads, img, st, dbg);
}

static double teach_sum(const pds_image *v)
{
    size_t i, n = (size_t)v->width * v->height;
    double s = 0.0;
    for (i = 0; i < n; i++) s += v->rgb[3 * i];
    return s;
}

/* Every landed photon is counted once: the landings equal the photons
   splatted, and the landing image sums to the landings inside the frame.
   Where a photon landed its own kernel reaches the pixel (the footprints
   are many pixels wide), so that pixel has caustic light; and a pixel has
   caustic light exactly when some splat term reached it. */
static void test_debug_landings_and_splats_agree_with_the_render(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    pds_render_stats st;
    pds_debug dbg;
    const pds_image *land = &dbg.value[PDS_DEBUG_LANDINGS], *spl = &dbg.value[PDS_DEBUG_SPLATS];
    size_t i, n, mismatched = 0, landed_dark = 0;
    REQUIRE(t, teach_render((1u << PDS_DEBUG_LANDINGS) | (1u << PDS_DEBUG_SPLATS), 2, &img, &st, &dbg), "render");
    REQUIRE(t, land->width == 24 && spl->height == 24, "value images %dx%d", land->width, spl->height);
    CHECK(t, st.splatted > 200 && dbg.landings == st.splatted, "landings %ld, splatted %ld", dbg.landings,
          st.splatted);
    CHECK(t, dbg.landings_in_frame > 20 && dbg.landings_in_frame <= dbg.landings, "in frame %ld of %ld",
          dbg.landings_in_frame, dbg.landings);
    CHECK(t, teach_sum(land) == (double)dbg.landings_in_frame, "landing image sums to %g, not %ld", teach_sum(land),
          dbg.landings_in_frame);
    n = (size_t)img.width * img.height;
    for (i = 0; i < n; i++) {
        int lit = img.rgb[3 * i] > 0.0f;
        if (lit != (spl->rgb[3 * i] > 0.0f)) mismatched++;
        if (land->rgb[3 * i] > 0.0f && !lit) landed_dark++;
    }
    CHECK(t, mismatched == 0, "%lu pixels lit without splats or splatted and dark", (unsigned long)mismatched);
    CHECK(t, landed_dark == 0, "%lu pixels with landings but no caustic", (unsigned long)landed_dark);
    CHECK(t, dbg.scale_max[PDS_DEBUG_LANDINGS] > 0.0 &&
                 dbg.picture[PDS_DEBUG_LANDINGS].height == 24 + PDS_DEBUG_LEGEND_ROWS,
          "picture with its legend strip");
    pds_image_free(&img);
    pds_debug_free(&dbg);
}

/* The debug views are exact counts: the same for any thread count. */
static void test_debug_views_are_identical_for_any_thread_count(pds_test_ctx *t)
{
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    pds_debug da, db;
    unsigned views = (1u << PDS_DEBUG_LANDINGS) | (1u << PDS_DEBUG_SPLATS) | (1u << PDS_DEBUG_ELLIPSES) |
                     (1u << PDS_DEBUG_PATHS) | (1u << PDS_DEBUG_FOOTPRINT) | (1u << PDS_DEBUG_SCALES);
    int v;
    REQUIRE(t, teach_render(views, 1, &a, NULL, &da), "1 thread");
    REQUIRE(t, teach_render(views, 3, &b, NULL, &db), "3 threads");
    for (v = 0; v < PDS_DEBUG_VIEWS; v++) {
        const pds_image *x = &da.picture[v], *y = &db.picture[v];
        if (v == PDS_DEBUG_PATHS || v == PDS_DEBUG_EYE) continue;
        REQUIRE(t, x->rgb && y->rgb, "view %s made", pds_debug_view_name((pds_debug_view)v));
        CHECK(t, memcmp(x->rgb, y->rgb, sizeof(float) * 3 * (size_t)x->width * x->height) == 0, "view %s differs",
              pds_debug_view_name((pds_debug_view)v));
    }
    CHECK(t, da.paths_obj && db.paths_obj && strcmp(da.paths_obj, db.paths_obj) == 0, "paths differ");
    pds_image_free(&a);
    pds_image_free(&b);
    pds_debug_free(&da);
    pds_debug_free(&db);
}

/* A camera looking straight down at a plane sees every eye vertex in its
   own pixel: spp vertices per pixel, all of them in frame. */
static void test_debug_eye_view_puts_spp_vertices_in_each_pixel(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    pds_render_stats st;
    pds_debug dbg;
    const pds_image *eye = &dbg.value[PDS_DEBUG_EYE];
    size_t i, wrong = 0;
    REQUIRE(t, teach_render(1u << PDS_DEBUG_EYE, 2, &img, &st, &dbg), "render");
    REQUIRE(t, eye->width == 24 && eye->height == 24, "eye image %dx%d", eye->width, eye->height);
    CHECK(t, dbg.eye_vertices_in_frame == st.eye_vertices && st.eye_vertices == 24 * 24 * 16, "in frame %ld of %ld",
          dbg.eye_vertices_in_frame, st.eye_vertices);
    for (i = 0; i < 24 * 24; i++)
        if (eye->rgb[3 * i] != 16.0f) wrong++;
    CHECK(t, wrong == 0, "%lu pixels without 16 vertices", (unsigned long)wrong);
    CHECK(t, dbg.scale_max[PDS_DEBUG_EYE] == 16.0, "scale %g", dbg.scale_max[PDS_DEBUG_EYE]);
    pds_image_free(&img);
    pds_debug_free(&dbg);
}

/* The ellipses are drawn in yellow over the render: a pixel is yellow
   exactly where the count image says an ellipse passes (the render itself
   is grey, never pure yellow), and one ellipse at most per 50 photons. */
static void test_debug_ellipses_are_drawn_where_counted(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    pds_render_stats st;
    pds_debug dbg;
    const pds_image *cnt = &dbg.value[PDS_DEBUG_ELLIPSES], *pic = &dbg.picture[PDS_DEBUG_ELLIPSES];
    size_t i, wrong = 0, drawn = 0;
    REQUIRE(t, teach_render(1u << PDS_DEBUG_ELLIPSES, 2, &img, &st, &dbg), "render");
    REQUIRE(t, pic->width == 24 && pic->height == 24 + PDS_DEBUG_LEGEND_ROWS, "picture %dx%d", pic->width, pic->height);
    CHECK(t, dbg.ellipses > 3 && dbg.ellipses <= (st.photons + 49) / 50, "%ld ellipses", dbg.ellipses);
    for (i = 0; i < 24 * 24; i++) {
        int yellow = pic->rgb[3 * i] == 1.0f && pic->rgb[3 * i + 1] == 1.0f && pic->rgb[3 * i + 2] == 0.0f;
        if (yellow != (cnt->rgb[3 * i] > 0.0f)) wrong++;
        drawn += yellow;
    }
    CHECK(t, wrong == 0 && drawn > 10, "%lu pixels disagree, %lu drawn", (unsigned long)wrong, (unsigned long)drawn);
    pds_image_free(&img);
    pds_debug_free(&dbg);
}

/* What the camera sees, on a floor under an opaque box and a glass box:
   a point hidden by the opaque box is not seen, one behind the glass is
   (glass is looked through), and so are points in the open and on the
   opaque box's own top; its bottom is hidden by its top. */
static void test_debug_camera_sees_through_glass_but_not_through_walls(pds_test_ctx *t)
{
    static const char text[] =
        "camera { position 0 2 0.000001 look_at 0 0 0 up 0 0 -1 fov 90 resolution 8 8 }\n"
        "material white diffuse { albedo 0.5 }\n"
        "material glass dielectric { ior 1.5 }\n"
        "quad { material white size 8 8 }\n"
        "box { material white size 0.4 translate -0.5 1 0 }\n"
        "box { material glass size 0.4 translate 0.5 1 0 }\n"
        "light point { position 0 3 0 power 10 }\n";
    pds_error err;
    pds_scene *s = scene_from_text(text, &err);
    pds__camera_frame f;
    REQUIRE(t, s != NULL, "scene: %s", err.text);
    f = pds__camera_setup(&s->camera, 8, 8);
    /* the floor points on the lines from the camera through the boxes' centres */
    CHECK(t, !pds__camera_sees(s, &f, pds__v(-1.0, 0.0, 0.0)), "floor behind the opaque box is seen");
    CHECK(t, pds__camera_sees(s, &f, pds__v(1.0, 0.0, 0.0)), "floor behind the glass box is hidden");
    CHECK(t, pds__camera_sees(s, &f, pds__v(0.0, 0.0, 0.5)), "floor in the open is hidden");
    CHECK(t, pds__camera_sees(s, &f, pds__v(-0.5, 1.2, 0.0)), "the opaque box's top is hidden");
    CHECK(t, !pds__camera_sees(s, &f, pds__v(-0.5, 0.8, 0.0)), "the opaque box's bottom is seen");
    CHECK(t, pds__camera_pixel_seen(s, &f, pds__v(-1.0, 0.0, 0.0)) == -1 &&
                 pds__camera_pixel_seen(s, &f, pds__v(0.0, 0.0, 0.5)) == pds__camera_pixel(&f, pds__v(0.0, 0.0, 0.5)) &&
                 pds__camera_pixel(&f, pds__v(0.0, 0.0, 0.5)) >= 0,
          "pixels of what is seen");
    pds_scene_free(s);
}

/* mirror_scene with an opaque slab between the camera (y = 2) and the
   light (y = 1) over the left half of the view (x < 0; columns 0-11). It
   hides that half of the floor but is in no photon's way to the floor:
   the mirror (x = 1) sends light down from below y = 1. The photons that
   land there in the open are not drawn behind the slab; columns 13-23
   have the open scene's landings, photon for photon (column 12 is the
   slab's side x = 0, seen edge on, where photons the mirror sends up may
   land). Ellipses are drawn only for centres the camera sees: fewer. */
static void test_debug_landings_behind_an_occluder_are_not_drawn(pds_test_ctx *t)
{
    static const char hidden_scene[] =
        "camera { position 0 2 0.000001 look_at 0 0 0 up 0 0 -1 fov 30 resolution 24 24 spp 16 }\n"
        "material floor diffuse { albedo 0.5 }\n"
        "material glass mirror { reflectance 0.9 }\n"
        "quad { material floor size 8 8 }\n"
        "quad { material glass size 3 3 rotate 90 0 0 1 translate 1 1.5 0 }\n"
        "light point { position 0 1 0 power 100 }\n"
        "box { material floor size 0.6 0.1 1.4 translate -0.3 1.8 0 }\n";
    pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
    pds_debug open, hid;
    unsigned views = (1u << PDS_DEBUG_LANDINGS) | (1u << PDS_DEBUG_ELLIPSES);
    const pds_image *lo = &open.value[PDS_DEBUG_LANDINGS], *lh = &hid.value[PDS_DEBUG_LANDINGS];
    double left_open = 0.0, left_hidden = 0.0, right = 0.0;
    long right_differs = 0;
    int x, y;
    REQUIRE(t, teach_render(views, 2, &a, NULL, &open), "open render");
    REQUIRE(t, teach_render_text(hidden_scene, views, 2, &b, NULL, &hid), "render behind the slab");
    for (y = 0; y < 24; y++)
        for (x = 0; x < 24; x++) {
            size_t i = 3 * ((size_t)y * 24 + x);
            if (x < 12) {
                left_open += lo->rgb[i];
                left_hidden += lh->rgb[i];
            } else if (x > 12) {
                right += lh->rgb[i];
                right_differs += lh->rgb[i] != lo->rgb[i];
            }
        }
    CHECK(t, left_open > 5.0, "open: %g landings in the left half (nothing to hide)", left_open);
    CHECK(t, left_hidden == 0.0, "%g landings drawn behind the slab", left_hidden);
    CHECK(t, right > 10.0 && right_differs == 0, "right half: %g landings, %ld pixels differ from the open scene's",
          right, right_differs);
    CHECK(t, teach_sum(lh) == (double)hid.landings_in_frame && hid.landings_in_frame < open.landings_in_frame,
          "seen: %ld behind the slab, %ld in the open", hid.landings_in_frame, open.landings_in_frame);
    CHECK(t, hid.ellipses > 0 && hid.ellipses < open.ellipses, "ellipses: %ld behind the slab, %ld in the open",
          hid.ellipses, open.ellipses);
    pds_image_free(&a);
    pds_image_free(&b);
    pds_debug_free(&open);
    pds_debug_free(&hid);
}

/* The eye view draws only eye vertices the camera sees. A mirror tilted
   45 degrees under the camera (pixels 10-13) sends the camera's rays
   sideways to a wall at x = 0.9, which an opaque slab at y = 1.5 hides
   from the camera (it fills columns 20-23, where those wall vertices
   would project). Every other pixel sees its own surface: 16 vertices
   (spp) each, never more; the mirror's pixels have none. */
static void test_debug_eye_view_leaves_out_vertices_the_camera_cannot_see(pds_test_ctx *t)
{
    static const char text[] =
        "camera { position 0 2 0.000001 look_at 0 0 0 up 0 0 -1 fov 90 resolution 24 24 spp 16 }\n"
        "material white diffuse { albedo 0.5 }\n"
        "material silver mirror { reflectance 0.9 }\n"
        "quad { material white size 8 8 }\n"
        "quad { material silver size 0.4 0.4 rotate -45 0 0 1 translate 0 1 0 }\n"
        "quad { material white size 2 2 rotate 90 0 0 1 translate 0.9 1 0 }\n"
        "quad { material white size 0.58 1.6 translate 0.59 1.5 0 }\n"
        "light point { position -0.5 1.9 0 power 10 }\n";
    pds_image img = {0, 0, NULL};
    pds_render_stats st;
    pds_debug dbg;
    const pds_image *eye = &dbg.value[PDS_DEBUG_EYE];
    size_t i;
    long over = 0;
    REQUIRE(t, teach_render_text(text, 1u << PDS_DEBUG_EYE, 2, &img, &st, &dbg), "render");
    REQUIRE(t, eye->width == 24 && eye->height == 24, "eye image %dx%d", eye->width, eye->height);
    for (i = 0; i < 24 * 24; i++) over += eye->rgb[3 * i] > 16.0f;
    CHECK(t, over == 0, "%ld pixels with more vertices than samples (hidden ones drawn)", over);
    CHECK(t, eye->rgb[0] == 16.0f && eye->rgb[3 * (12 * 24 + 22)] == 16.0f, "floor %g, slab %g vertices",
          eye->rgb[0], eye->rgb[3 * (12 * 24 + 22)]);
    CHECK(t, eye->rgb[3 * (11 * 24 + 11)] == 0.0f && eye->rgb[3 * (12 * 24 + 12)] == 0.0f,
          "the mirror's pixels hold %g and %g vertices", eye->rgb[3 * (11 * 24 + 11)], eye->rgb[3 * (12 * 24 + 12)]);
    CHECK(t, teach_sum(eye) == (double)dbg.eye_vertices_in_frame && dbg.eye_vertices_in_frame < st.eye_vertices,
          "seen %ld of %ld", dbg.eye_vertices_in_frame, st.eye_vertices);
    pds_image_free(&img);
    pds_debug_free(&dbg);
}

/* The paths OBJ is read by PDS's own OBJ loader: as many polylines'
   segments and vertices as the view says it wrote, each path from the
   light at (0, 1, 0) with at most 2 segments here (light, mirror, floor). */
static void test_debug_paths_obj_reads_back_with_its_segment_count(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    pds_debug dbg;
    tobj_fix f;
    char path[256];
    REQUIRE(t, teach_render(1u << PDS_DEBUG_PATHS, 2, &img, NULL, &dbg), "render");
    REQUIRE(t, dbg.paths_obj != NULL, "paths written");
    CHECK(t, dbg.paths > 50 && dbg.path_segments >= dbg.paths && dbg.path_segments <= 2 * dbg.paths,
          "%ld paths, %ld segments", dbg.paths, dbg.path_segments);
    CHECK(t, strstr(dbg.paths_obj, "\nv 0 1 0\n") != NULL, "paths start at the light");
    tobj_init(&f);
    CHECK(t, tobj_load_text(&f, "paths.obj", dbg.paths_obj, path, sizeof path) == PDS_OK, "OBJ: %s", f.err.text);
    CHECK(t, f.stats.line_segments == dbg.path_segments, "loader counts %ld segments, the view wrote %ld",
          f.stats.line_segments, dbg.path_segments);
    CHECK(t, f.stats.vertices == dbg.path_segments + dbg.paths && f.stats.objects == dbg.paths,
          "%ld vertices, %ld objects", f.stats.vertices, f.stats.objects);
    remove(path);
    tobj_done(&f);
    pds_image_free(&img);
    pds_debug_free(&dbg);
}

/* Eqs. 2-9 by finite differences: through the smooth glass sphere of
   sphere_caustic_scene every differential trace-photon reports agrees with
   the central difference of neighbouring photons traced by the renderer,
   at every vertex where the neighbours met the same triangles. */
static void test_trace_photon_differentials_match_finite_differences(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text(sphere_caustic_scene, &err);
    pds_options opt;
    long i;
    int compared = 0, refracted = 0, landed = 0;
    double worst = 0.0;
    REQUIRE(t, s != NULL, "scene: %s", err.text);
    pds_options_default(&opt);
    opt.photons = 10000;
    for (i = 0; i < 40; i++) {
        pds_trace tr;
        int k;
        REQUIRE(t, pds_trace_photon(s, &opt, i, &tr, &err) == PDS_OK, "%s", err.text);
        for (k = 0; k < tr.count; k++) {
            const pds_trace_vertex *v = &tr.v[k];
            const pds_vec3 *a[4] = {&v->dxdu, &v->dxdv, &v->dwdu, &v->dwdv};
            const pds_vec3 *b[4] = {&v->fd_dxdu, &v->fd_dxdv, &v->fd_dwdu, &v->fd_dwdv};
            int j;
            refracted += v->event == PDS_TRACE_REFRACT;
            landed += v->event == PDS_TRACE_LAND;
            CHECK(t, fabs(v->area - pds__footprint_area(pds__v(v->dxdu.x, v->dxdu.y, v->dxdu.z),
                                                        pds__v(v->dxdv.x, v->dxdv.y, v->dxdv.z))) <= 1e-15,
                  "area is eq. 4's");
            if (!v->fd_valid) continue;
            compared++;
            for (j = 0; j < 4; j++) {
                double dx = a[j]->x - b[j]->x, dy = a[j]->y - b[j]->y, dz = a[j]->z - b[j]->z;
                double na = sqrt(a[j]->x * a[j]->x + a[j]->y * a[j]->y + a[j]->z * a[j]->z);
                double rel = sqrt(dx * dx + dy * dy + dz * dz) / fmax(na, 1e-12);
                if (rel > worst) worst = rel;
            }
        }
        pds_trace_free(&tr);
    }
    CHECK(t, refracted >= 20 && landed >= 8 && compared >= 60, "%d refractions, %d landings, %d compared", refracted,
          landed, compared);
    CHECK(t, worst < 1e-5, "worst relative difference %g", worst);
    pds_scene_free(s);
}

#ifdef PDS_TEST_POSIX
/* The tool: differentials beside finite differences, and a usage error
   without --photon. */
static void test_cli_trace_photon_prints_differentials_and_their_check(pds_test_ctx *t)
{
    char out[16384];
    const char *last;
    double rel = 1.0;
    CHECK(t, cli_run("trace-photon scenes/refraction.scene --photon 0", out, sizeof out) == 0, "failed: %s", out);
    CHECK(t, strstr(out, "vertex 1: refracted on 'water'") && strstr(out, "  Dtheta w ") && strstr(out, "   fd ("),
          "output: %s", out);
    last = cli_last_line(out);
    CHECK(t, strncmp(last, "trace-photon photon=0 vertices=3 landed=1 max_rel_diff=", 55) == 0, "final line: %s", last);
    if (strstr(last, "max_rel_diff=")) rel = atof(strstr(last, "max_rel_diff=") + 13);
    CHECK(t, rel < 1e-6, "max_rel_diff %g", rel);
    CHECK(t, cli_run("trace-photon scenes/refraction.scene", out, sizeof out) == 2, "no --photon: %s", out);
    CHECK(t, strstr(out, "trace-photon needs --photon I") != NULL, "message: %s", out);
}

/* pds pixel: the mean of a window, clipped at the image's edge. */
static void test_cli_pixel_prints_the_mean_of_a_window(pds_test_ctx *t)
{
    char out[4096], path[128], args[256];
    pds_image img = {0, 0, NULL};
    pds_error err;
    int i;
    snprintf(path, sizeof path, "/tmp/pds_teach_pixel_%ld.pfm", (long)getpid());
    REQUIRE(t, pds_image_alloc(&img, 4, 3) == PDS_OK, "alloc");
    for (i = 0; i < 12; i++) img.rgb[3 * i] = img.rgb[3 * i + 1] = img.rgb[3 * i + 2] = (float)i; /* value = x + 4 y */
    REQUIRE(t, pds_image_write_pfm(path, &img, &err) == PDS_OK, "%s", err.text);
    snprintf(args, sizeof args, "pixel %s 1 1 1", path);
    CHECK(t, cli_run(args, out, sizeof out) == 0 && strstr(out, "pixel x=1 y=1 radius=1 pixels=9 r=5 g=5 b=5"), "%s", out);
    snprintf(args, sizeof args, "pixel %s 0 0 1", path); /* (0,1,4,5) */
    CHECK(t, cli_run(args, out, sizeof out) == 0 && strstr(out, "pixels=4 r=2.5 "), "%s", out);
    snprintf(args, sizeof args, "pixel %s 4 0", path);
    CHECK(t, cli_run(args, out, sizeof out) == 2 && strstr(out, "pixel 4,0 is outside the 4x3 image"), "%s", out);
    remove(path);
    pds_image_free(&img);
}
#endif

#ifndef PDS_NO_SPECTRAL
/* The views ride along a spectral render (the splat buffers then hold
   negative sums too, >>spectral): the landings still equal the photons
   splatted, the splats view lights exactly the pixels the caustic lights,
   and the footprint view is drawn. */
static void test_debug_views_ride_along_a_spectral_render(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    pds_render_stats st;
    pds_debug dbg;
    pds_options opt;
    const pds_image *spl = &dbg.value[PDS_DEBUG_SPLATS];
    size_t i, n, mismatched = 0;
    pds_options_default(&opt);
    pds_debug_init(&dbg);
    dbg.views = (1u << PDS_DEBUG_LANDINGS) | (1u << PDS_DEBUG_SPLATS) | (1u << PDS_DEBUG_FOOTPRINT) |
                (1u << PDS_DEBUG_PATHS);
    dbg.path_photons = 50;
    opt.method = PDS_METHOD_PDS;
    opt.progressive = 0;
    opt.smoothing = 8.0;
    opt.photons = 5000;
    opt.paths = PDS_PATHS_CAUSTICS_ONLY;
    opt.threads = 2;
    opt.spectral = 1;
    opt.debug = &dbg;
    REQUIRE(t, render_text(mirror_scene, &opt, &img, &st), "spectral render with debug views");
    CHECK(t, st.splatted > 200 && dbg.landings == st.splatted, "landings %ld, splatted %ld", dbg.landings,
          st.splatted);
    n = (size_t)img.width * img.height;
    for (i = 0; i < n; i++)
        if ((img.rgb[3 * i] != 0.0f || img.rgb[3 * i + 1] != 0.0f || img.rgb[3 * i + 2] != 0.0f) !=
            (spl->rgb[3 * i] > 0.0f))
            mismatched++;
    CHECK(t, mismatched == 0, "%lu pixels lit without splats or splatted and dark", (unsigned long)mismatched);
    CHECK(t, dbg.picture[PDS_DEBUG_FOOTPRINT].width == img.width && dbg.paths_obj && dbg.path_segments > 0,
          "footprint picture %d wide, paths %s", dbg.picture[PDS_DEBUG_FOOTPRINT].width,
          dbg.paths_obj ? "made" : "missing");
    pds_image_free(&img);
    pds_debug_free(&dbg);
}
#else
/* The small core leaves spectral rendering out: a render that asks for
   it, or whose scene has a dispersive glass, is refused, naming the
   scene; the scene itself still loads. */
static void test_core_refuses_spectral_renders(pds_test_ctx *t)
{
    pds_options opt;
    pds_error err;
    pds_image img = {0, 0, NULL};
    pds_scene *s = scene_from_text(mirror_scene, &err), *prism;
    REQUIRE(t, s != NULL, "scene: %s", err.text);
    pds_options_default(&opt);
    opt.spectral = 1;
    CHECK(t, pds_render(s, &opt, &img, NULL, &err) == PDS_ERR_INVALID_ARG && img.rgb == NULL &&
                 strstr(err.text, ": this build leaves spectral rendering out (PDS_NO_SPECTRAL): the options ask"),
          "--spectral: %s", err.text);
    pds_scene_free(s);
    prism = scene_from_text("camera { position 0 2 0.000001 look_at 0 0 0 up 0 0 -1 resolution 8 8 }\n"
                            "material white diffuse { albedo 0.5 }\n"
                            "material bk7 dielectric { cauchy 1.5046 0.0042 }\n"
                            "quad { material white size 4 4 }\n"
                            "sphere { material bk7 radius 0.2 translate 0 0.5 0 }\n"
                            "light point { position 0 1.5 0 power 10 }\n",
                            &err);
    REQUIRE(t, prism != NULL, "dispersive scene: %s", err.text);
    opt.spectral = 0;
    CHECK(t, pds_render(prism, &opt, &img, NULL, &err) == PDS_ERR_INVALID_ARG && img.rgb == NULL &&
                 strstr(err.text, "(PDS_NO_SPECTRAL): the scene has a dispersive material"),
          "dispersive: %s", err.text);
    pds_scene_free(prism);
}
#endif

#ifdef PDS_NO_BASELINES
/* The small core leaves streamed photon mapping out with the other
   baselines, and says so. */
static void test_core_refuses_spm(pds_test_ctx *t)
{
    pds_options opt;
    pds_error err;
    pds_image img = {0, 0, NULL};
    pds_scene *s = scene_from_text(mirror_scene, &err);
    REQUIRE(t, s != NULL, "scene: %s", err.text);
    pds_options_default(&opt);
    opt.method = PDS_METHOD_SPM;
    CHECK(t, pds_render(s, &opt, &img, NULL, &err) == PDS_ERR_INVALID_ARG && strstr(err.text, "PDS_NO_BASELINES") &&
                 strstr(err.text, "spm"),
          "%s", err.text);
    pds_image_free(&img);
    pds_scene_free(s);
}
#endif

#if defined(PDS_NO_GI) && defined(PDS_NO_ISC)
/* The small core leaves gi and isc out and says so, before any work and
   without an image; isc's animation frames too. */
static pds_status teach_count_frame(void *user, int frame, const pds_image *img, pds_error *err)
{
    (void)frame, (void)img, (void)err;
    (*(int *)user)++;
    return PDS_OK;
}

static void test_core_refuses_gi_and_isc(pds_test_ctx *t)
{
    pds_options opt;
    pds_error err;
    pds_image img = {0, 0, NULL};
    pds_render_estimate est;
    pds_scene *s = scene_from_text(mirror_scene, &err);
    int frames = 0;
    REQUIRE(t, s != NULL, "scene: %s", err.text);
    pds_options_default(&opt);
    opt.method = PDS_METHOD_GI;
    CHECK(t, pds_render(s, &opt, &img, NULL, &err) == PDS_ERR_INVALID_ARG &&
                 strcmp(err.text, "this build leaves gi out (PDS_NO_GI)") == 0 && img.rgb == NULL,
          "gi: %s", err.text);
    CHECK(t, pds_render_estimate_get(s, &opt, &est, &err) == PDS_ERR_INVALID_ARG && strstr(err.text, "PDS_NO_GI"),
          "gi estimate: %s", err.text);
    opt.method = PDS_METHOD_ISC;
    CHECK(t, pds_render(s, &opt, &img, NULL, &err) == PDS_ERR_INVALID_ARG &&
                 strcmp(err.text, "this build leaves isc out (PDS_NO_ISC)") == 0 && img.rgb == NULL,
          "isc: %s", err.text);
    CHECK(t, pds_render_frames(s, &opt, 2, teach_count_frame, &frames, NULL, &err) == PDS_ERR_INVALID_ARG &&
                 strstr(err.text, "PDS_NO_ISC") && frames == 0,
          "isc frames: %s (%d frames)", err.text, frames);
    pds_image_free(&img);
    pds_scene_free(s);
}
#endif

#ifdef PDS_NO_PARTIAL_FILE
/* The small core renders in memory (pds_render_part, merging) but writes
   and reads no partial file, and says so; nothing is written. */
static void test_core_refuses_partial_files(pds_test_ctx *t)
{
    pds_options opt;
    pds_error err;
    pds_partial *part = NULL, *back = (pds_partial *)&err;
    pds_scene *s = scene_from_text(mirror_scene, &err);
    FILE *f;
    REQUIRE(t, s != NULL, "scene: %s", err.text);
    pds_options_default(&opt);
    opt.method = PDS_METHOD_PT;
    opt.spp = 1;
    REQUIRE(t, pds_render_part(s, &opt, &part, NULL, &err) == PDS_OK, "part: %s", err.text);
    CHECK(t, pds_partial_write("core-part.pdspart", part, &err) == PDS_ERR_INVALID_ARG &&
                 strcmp(err.text, "core-part.pdspart: this build leaves partial files out (PDS_NO_PARTIAL_FILE)") == 0,
          "write: %s", err.text);
    f = fopen("core-part.pdspart", "rb");
    CHECK(t, f == NULL, "a file was written");
    if (f) fclose(f);
    CHECK(t, pds_partial_read("core-part.pdspart", &back, &err) == PDS_ERR_INVALID_ARG && back == NULL &&
                 strstr(err.text, "PDS_NO_PARTIAL_FILE"),
          "read: %s", err.text);
    pds_partial_free(part);
    pds_scene_free(s);
}
#endif

#ifdef PDS_NO_ENV
/* The small core leaves the environment light out: the parser refuses
   it where it is written. */
static void test_core_refuses_the_environment_light(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text("material white diffuse { albedo 0.5 }\n"
                                   "light environment { radiance 1 1 1 }\n",
                                   &err);
    CHECK(t, s == NULL && err.status == PDS_ERR_PARSE &&
                 strstr(err.text, ":2:7: this build leaves the environment light out (PDS_NO_ENV)") != NULL,
          "%s", s ? "loaded" : err.text);
    pds_scene_free(s);
}
#endif

/* The scales view is the image's own choice of scale (progressive PDS,
   the default): its numbers count, estimate by estimate, what the render
   reports in scale_pixels; every pixel's colour is its estimate's, dimmed
   by its weight in a blend, black where it took no part (pale yellow,
   PDS__VIEW_THROUGH, where such a pixel took a blur by its passes'
   halves: as many as the render's through_pixels, on a glass ball's
   floor seen through it); no pixel is
   counted as taking an estimate it has no share of (until 7 December
   2026 a blend of weight 0, the pass's own value, that rounding made
   look better, was counted as the candidate's: a quarter of the
   reflection case's pixels); the view is the same on 1 and 3 threads.
   With one scale for every pixel (the paper's PDS) no pixel takes
   part. */
static void test_debug_scales_view_is_the_images_choice(pds_test_ctx *t)
{
    pds_options opt;
    pds_image img = {0, 0, NULL};
    pds_render_stats st[2];
    pds_debug dbg[2], paper;
    const pds_image *val = &dbg[0].value[PDS_DEBUG_SCALES], *pic = &dbg[0].picture[PDS_DEBUG_SCALES];
    long count[PDS_SCALE_ESTIMATES] = {0}, through = 0;
    int k, threads[2] = {1, 3}, used = 0, unshared = 0, wrong = 0, parted = 0;
    float dim[3], full[3];
    size_t i, n = 24 * 24;
    for (k = 0; k < 2; k++) {
        pds_options_default(&opt);
        pds_debug_init(&dbg[k]);
        dbg[k].views = 1u << PDS_DEBUG_SCALES;
        opt.photons = 200000;
        opt.paths = PDS_PATHS_CAUSTICS_ONLY;
        opt.threads = threads[k];
        opt.debug = &dbg[k];
        REQUIRE(t, render_text(mirror_scene, &opt, &img, &st[k]), "render on %d threads", threads[k]);
        pds_image_free(&img);
    }
    REQUIRE(t, val->rgb && pic->rgb && val->width == 24 && pic->height == 24 + PDS_DEBUG_LEGEND_ROWS, "view made");
    for (i = 0; i < n; i++) {
        int j = (int)val->rgb[3 * i];
        float c[3];
        pds__colour_scale(j, val->rgb[3 * i + 1], c);
        if (j == PDS__VIEW_THROUGH) {
            /* seen in the mirror, blurred by its passes' halves */
            through += val->rgb[3 * i + 1] == 1.0f;
        } else if (j >= 0) {
            REQUIRE(t, j < PDS_SCALE_ESTIMATES && (float)j == val->rgb[3 * i], "pixel %lu: estimate %g", (unsigned long)i,
                    val->rgb[3 * i]);
            count[j]++;
            parted++;
            unshared += j > 0 && !(val->rgb[3 * i + 1] > 0.0f && val->rgb[3 * i + 1] <= 1.0f);
        } else if (c[0] != 0.0f || c[1] != 0.0f || c[2] != 0.0f || val->rgb[3 * i] != -1.0f) {
            wrong++;
        }
        if (memcmp(c, &pic->rgb[3 * i], sizeof c) != 0) wrong++;
    }
    CHECK(t, wrong == 0, "%d pixels' colours or numbers are not their estimates'", wrong);
    for (k = 0; k < PDS_SCALE_ESTIMATES; k++) {
        CHECK(t, count[k] == st[0].scale_pixels[k], "estimate %d: %ld pixels in the view, %ld in the render", k,
              count[k], st[0].scale_pixels[k]);
        used += count[k] > 0;
    }
    CHECK(t, parted > (int)n / 2 && used >= 3, "%d pixels took part, %d estimates", parted, used);
    CHECK(t, through == st[0].through_pixels, "%ld pixels blurred through the mirror in the view, %ld in the render",
          through, st[0].through_pixels);
    CHECK(t, unshared == 0, "%d pixels counted for an estimate they have no share of", unshared);
    /* a blend is drawn dimmer by its weight */
    pds__colour_scale(3, 0.5, dim);
    pds__colour_scale(3, 1.0, full);
    CHECK(t, dim[0] < full[0] && dim[1] < full[1] && dim[2] < full[2] && dim[2] > 0.5f * full[2],
          "a blend of weight 0.5 drawn as %g %g %g against %g %g %g", dim[0], dim[1], dim[2], full[0], full[1],
          full[2]);
    CHECK(t, memcmp(val->rgb, dbg[1].value[PDS_DEBUG_SCALES].rgb, sizeof(float) * 3 * n) == 0 &&
                 memcmp(pic->rgb, dbg[1].picture[PDS_DEBUG_SCALES].rgb,
                        sizeof(float) * 3 * (size_t)pic->width * pic->height) == 0,
          "the view differs on 3 threads");
    {
        /* a glass ball on the floor: the pixels that see the floor
           through it take no part, and those that took a blur by their
           passes' halves are marked, as many as the render counts */
        static const char ball[] = "camera { position 0 2 4 look_at 0 0.3 0 fov 40 resolution 48 32 spp 4 }\n"
                                   "material floor diffuse { albedo 0.8 }\n"
                                   "material glass dielectric { ior 1.5 }\n"
                                   "quad { material floor size 6 6 }\n"
                                   "sphere { material glass radius 0.5 translate 0 0.6 0 }\n"
                                   "light point { position 0.3 3 0.2 power 200 }\n";
        pds_debug bd;
        pds_render_stats bst;
        long marked = 0;
        pds_options_default(&opt);
        pds_debug_init(&bd);
        bd.views = 1u << PDS_DEBUG_SCALES;
        opt.photons = 4 * 16384;
        opt.paths = PDS_PATHS_CAUSTICS_ONLY;
        opt.threads = 2;
        opt.debug = &bd;
        REQUIRE(t, render_text(ball, &opt, &img, &bst), "the glass ball");
        for (i = 0; i < 48 * 32; i++) marked += bd.value[PDS_DEBUG_SCALES].rgb[3 * i] == (float)PDS__VIEW_THROUGH;
        CHECK(t, marked > 0 && marked == bst.through_pixels, "the glass ball: %ld pixels marked, %ld counted", marked,
              bst.through_pixels);
        pds_image_free(&img);
        pds_debug_free(&bd);
    }
    REQUIRE(t, teach_render(1u << PDS_DEBUG_SCALES, 2, &img, NULL, &paper), "the paper's PDS");
    for (i = 0, wrong = 0; i < n; i++) wrong += paper.value[PDS_DEBUG_SCALES].rgb[3 * i] != -1.0f;
    CHECK(t, wrong == 0, "%d pixels of the paper's PDS took part in a choice", wrong);
    pds_image_free(&img);
    pds_debug_free(&dbg[0]);
    pds_debug_free(&dbg[1]);
    pds_debug_free(&paper);
}

static const pds_test_case tests_teach[] = {
#ifndef PDS_NO_SPECTRAL
    {"debug_views_ride_along_a_spectral_render", test_debug_views_ride_along_a_spectral_render},
#else
    {"core_refuses_spectral_renders", test_core_refuses_spectral_renders},
#endif
#ifdef PDS_NO_BASELINES
    {"core_refuses_spm", test_core_refuses_spm},
#endif
#if defined(PDS_NO_GI) && defined(PDS_NO_ISC)
    {"core_refuses_gi_and_isc", test_core_refuses_gi_and_isc},
#endif
#ifdef PDS_NO_PARTIAL_FILE
    {"core_refuses_partial_files", test_core_refuses_partial_files},
#endif
#ifdef PDS_NO_ENV
    {"core_refuses_the_environment_light", test_core_refuses_the_environment_light},
#endif
    {"debug_landings_and_splats_agree_with_the_render", test_debug_landings_and_splats_agree_with_the_render},
    {"debug_views_are_identical_for_any_thread_count", test_debug_views_are_identical_for_any_thread_count},
    {"debug_eye_view_puts_spp_vertices_in_each_pixel", test_debug_eye_view_puts_spp_vertices_in_each_pixel},
    {"debug_ellipses_are_drawn_where_counted", test_debug_ellipses_are_drawn_where_counted},
    {"debug_scales_view_is_the_images_choice", test_debug_scales_view_is_the_images_choice},
    {"debug_camera_sees_through_glass_but_not_through_walls", test_debug_camera_sees_through_glass_but_not_through_walls},
    {"debug_landings_behind_an_occluder_are_not_drawn", test_debug_landings_behind_an_occluder_are_not_drawn},
    {"debug_eye_view_leaves_out_vertices_the_camera_cannot_see",
     test_debug_eye_view_leaves_out_vertices_the_camera_cannot_see},
    {"debug_paths_obj_reads_back_with_its_segment_count", test_debug_paths_obj_reads_back_with_its_segment_count},
    {"trace_photon_differentials_match_finite_differences", test_trace_photon_differentials_match_finite_differences},
#ifdef PDS_TEST_POSIX
    {"cli_trace_photon_prints_differentials_and_their_check", test_cli_trace_photon_prints_differentials_and_their_check},
    {"cli_pixel_prints_the_mean_of_a_window", test_cli_pixel_prints_the_mean_of_a_window},
#endif
};

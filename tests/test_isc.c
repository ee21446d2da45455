/* tests/test_isc.c - image-space caustics (Wyman and Davis 2006): the
   light-space photon buffer against a per-photon tracer, flux conservation
   of every gather and the quads' exact cover on a plane mirror's analytic
   caustic, determinism, the temporal filter's flicker, and the tool's
   frames. Uses scene_from_text (test_scene.c), render_text
   (test_render.c), cli_run (test_cli.c) and harness_path
   (test_harness.c). */

/* A point light at (-2, 1, 0) and a small square mirror (reflectance 0.8)
   at (0, 1, 0) facing (-1, -1, 0)/sqrt 2: the floor sees the light
   mirrored at V = (0, 3, 0), E = R I 3 / d^3 with d = |x - V|, on a patch
   about 0.55 x 0.75 around the origin, in front of the light and in full
   view of a camera that looks past the mirror. */
static const char isc_mirror_scene[] =
    "camera { position 1.2 2.2 0 look_at 0 0 0 fov 40 resolution 64 64 }\n"
    "material floor diffuse { albedo 1 }\n"
    "material m mirror { reflectance 0.8 }\n"
    "quad { material floor size 6 6 }\n"
    "quad { material m size 0.5 0.5 rotate 135 0 0 1 translate 0 1 0 }\n"
    "light point { position -2 1 0 power 100 }\n";

#define ISC_R 0.8
#define ISC_I (100.0 / (4.0 * PDS__PI))

static double isc_mirror_irradiance(pds__v3 x)
{
    pds__v3 d = pds__sub(x, pds__v(0, 3, 0));
    double r = pds__length(d);
    return ISC_R * ISC_I * 3.0 / (r * r * r);
}

/* Solid angle of triangle (a, b, c) seen from the origin (Van Oosterom and
   Strackee 1983): tan(Omega/2) = |a.(b x c)| / (abc + (a.b)c + (a.c)b + (b.c)a). */
static double isc_triangle_solid_angle(pds__v3 a, pds__v3 b, pds__v3 c)
{
    double la = pds__length(a), lb = pds__length(b), lc = pds__length(c);
    double num = fabs(pds__dot(a, pds__cross(b, c)));
    double den = la * lb * lc + pds__dot(a, b) * lc + pds__dot(a, c) * lb + pds__dot(b, c) * la;
    double h = atan2(num, den);
    return 2.0 * (h < 0.0 ? h + PDS__PI : h);
}

/* The flux the mirror sends to the floor: R I Omega, Omega the mirror's
   solid angle from the light (its two triangles). */
static double isc_mirror_flux(void)
{
    pds__v3 l = pds__v(-2, 1, 0), c = pds__v(0, 1, 0), t = pds__scale(pds__v(1, -1, 0), 0.25 / sqrt(2.0));
    pds__v3 z = pds__v(0, 0, 0.25), p[4];
    p[0] = pds__sub(pds__sub(pds__sub(c, t), z), l);
    p[1] = pds__sub(pds__add(pds__sub(c, t), z), l);
    p[2] = pds__sub(pds__add(pds__add(c, t), z), l);
    p[3] = pds__sub(pds__sub(pds__add(c, t), z), l);
    return ISC_R * ISC_I * (isc_triangle_solid_angle(p[0], p[1], p[2]) + isc_triangle_solid_angle(p[0], p[2], p[3]));
}

/* The floor (y = 0) patch pixel (x, y) of the scene's camera sees: its
   four corners' rays meet the plane; the area of that quadrilateral is
   half the cross product of its diagonals. Also the centre's point. */
static double isc_floor_pixel_area(const pds_scene *s, int w, int h, int x, int y, pds__v3 *centre)
{
    pds__camera_frame f = pds__camera_setup(pds_scene_camera(s), w, h);
    pds__v3 q[4], d;
    int k;
    for (k = 0; k < 4; k++) {
        d = pds__camera_dir(&f, x + (k == 1 || k == 2), y + (k >= 2));
        q[k] = pds__add(f.origin, pds__scale(d, -f.origin.y / d.y));
    }
    d = pds__camera_dir(&f, x + 0.5, y + 0.5);
    *centre = pds__add(f.origin, pds__scale(d, -f.origin.y / d.y));
    return 0.5 * pds__length(pds__cross(pds__sub(q[2], q[0]), pds__sub(q[3], q[1])));
}

static int isc_render(const char *text, pds_isc_gather g, int res, int size, int threads, pds_image *img,
                      pds_render_stats *st)
{
    pds_options opt;
    pds_options_default(&opt);
    opt.width = opt.height = size;
    opt.method = PDS_METHOD_ISC;
    opt.paths = PDS_PATHS_CAUSTICS_ONLY;
    opt.isc_gather = g;
    opt.light_resolution = res;
    opt.threads = threads;
    return render_text(text, &opt, img, st);
}

static const char *const isc_gather_label[] = {"points", "quads", "eye", "light"};

/* Each gather turns the photons' flux into irradiance without losing or
   making any: the irradiance the image shows (L / f_r, f_r = 1/pi),
   integrated over the floor with each pixel's exact footprint, is the
   flux the mirror reflects, R I Omega. Quads lose the half-cell rim
   between the outermost photons and the mirror's edge, about 1/N + 1/M
   of it for N x M photons on the mirror (1.1% here), and their cover is
   sampled at pixel centres, up to half a pixel off along each edge of
   the lit patch (about 1% at 192 x 192). */
static void test_isc_gathers_conserve_flux_on_a_flat_receiver(pds_test_ctx *t)
{
    static const double tol[4] = {0.01, 0.03, 0.01, 0.01};
    pds_error err;
    pds_scene *s = scene_from_text(isc_mirror_scene, &err);
    double expect = isc_mirror_flux();
    int g;
    REQUIRE(t, s != NULL, "scene: %s", err.text);
    for (g = 0; g < 4; g++) {
        pds_image img = {0, 0, NULL};
        pds_render_stats st;
        double flux = 0.0;
        int x, y;
        if (!isc_render(isc_mirror_scene, (pds_isc_gather)g, 256, 192, 2, &img, &st)) {
            CHECK(t, 0, "%s: render", isc_gather_label[g]);
            continue;
        }
        for (y = 0; y < img.height; y++)
            for (x = 0; x < img.width; x++) {
                pds__v3 c;
                double a = isc_floor_pixel_area(s, img.width, img.height, x, y, &c);
                flux += PDS__PI * img.rgb[3 * (y * img.width + x) + 1] * a;
            }
        CHECK(t, st.splatted > 2000, "%s: %ld photons landed", isc_gather_label[g], st.splatted);
        CHECK(t, fabs(flux / expect - 1.0) < tol[g], "%s: flux %.5g W, the mirror reflects %.5g W (ratio %.4f)",
              isc_gather_label[g], flux, expect, flux / expect);
        if (getenv("ISC_DBG")) printf("%s ratio %.5f landed %ld\n", isc_gather_label[g], flux / expect, st.splatted);
        pds_image_free(&img);
    }
    pds_scene_free(s);
}

/* The quads gather rasterises the caustic polygons between neighbouring
   photons: on a plane mirror's caustic they tile the lit patch, so every
   pixel inside it is covered by exactly one polygon (no gap, no double
   count: the count the estimate keeps), and each polygon's irradiance,
   beam flux over polygon area, is the analytic E = R I cos / d^2. */
static void test_isc_quads_cover_a_plane_mirrors_caustic_exactly_once(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text(isc_mirror_scene, &err);
    pds_options opt;
    pds__isc ctx;
    pds_image img = {0, 0, NULL};
    int x, y, inside = 0, once = 0, bad = 0;
    double worst = 0.0;
    REQUIRE(t, s != NULL, "scene: %s", err.text);
    pds_options_default(&opt);
    opt.method = PDS_METHOD_ISC;
    opt.isc_gather = PDS_ISC_QUADS;
    opt.light_resolution = 256;
    opt.paths = PDS_PATHS_CAUSTICS_ONLY;
    opt.threads = 2;
    if (pds__isc_init(&ctx, s, &opt, 64, 64, 2, &err) != PDS_OK || pds_image_alloc(&img, 64, 64) != PDS_OK) {
        pds_scene_free(s);
        REQUIRE(t, 0, "init: %s", err.text);
    }
    pds__isc_frame(&ctx, 0, 0, &img);
    for (y = 0; y < 64; y++)
        for (x = 0; x < 64; x++) {
            pds__v3 c;
            const pds__isc_est *e = &ctx.est[y * 64 + x];
            double expect, rel;
            /* pixels well inside the patch: 0.4 x 0.6 around its middle */
            (void)isc_floor_pixel_area(s, 64, 64, x, y, &c);
            if (fabs(c.x + 0.02) > 0.2 || fabs(c.z) > 0.3) continue;
            inside++;
            once += e->count == 1.0f;
            expect = isc_mirror_irradiance(c);
            rel = fabs(e->e[1] / expect - 1.0);
            if (rel > worst) worst = rel;
            bad += rel > 0.01;
        }
    CHECK(t, inside > 200, "only %d pixels inside", inside);
    CHECK(t, once == inside, "%d of %d pixels covered exactly once", once, inside);
    CHECK(t, bad == 0, "%d pixels off the analytic irradiance by more than 1%% (worst %.4f)", bad, worst);
    if (getenv("ISC_DBG")) printf("inside %d once %d worst %g\n", inside, once, worst);
    pds__isc_free(&ctx);
    pds_image_free(&img);
    pds_scene_free(s);
}

/* A glass box (flat faces, IOR 1.5) tilted above a floor under a point
   light, and a mirror beside it: photons refract twice, reflect, or are
   totally internally reflected. */
#define ISC_GLASS_SCENE                                                                                  \
    "camera { position 0 4 3 look_at 0 0 0 fov 40 resolution 32 32 }\n"                                  \
    "material floor diffuse { albedo 0.7 }\n"                                                             \
    "material glass dielectric { ior 1.5 }\n"                                                             \
    "material m mirror { reflectance 0.9 }\n"                                                             \
    "quad { material floor size 8 8 }\n"                                                                 \
    "box { material glass size 0.8 0.5 0.6 rotate 35 1 0.3 0.2 translate 0.2 1.2 0 }\n"                  \
    "quad { material m size 0.6 0.6 rotate 100 0 0 1 translate 0.9 1 0.2 }\n"                            \
    "light point { position -0.5 3.5 0.4 power 50 }\n"
static const char isc_glass_scene[] = ISC_GLASS_SCENE;

/* The unpolarised Fresnel reflectance, written out (Born and Wolf). */
static double isc_fresnel(double ci, double n1, double n2)
{
    double s2 = (n1 / n2) * (n1 / n2) * (1.0 - ci * ci), ct, rs, rp;
    if (s2 >= 1.0) return 1.0;
    ct = sqrt(1.0 - s2);
    rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct);
    rp = (n2 * ci - n1 * ct) / (n2 * ci + n1 * ct);
    return 0.5 * (rs * rs + rp * rp);
}

/* A per-photon tracer on the public ray queries: from o along d through
   mirrors (reflect) and glass (Snell's law, or reflection under total
   internal reflection), to the first diffuse surface after a specular
   bounce; *w the product of reflectances and Fresnel transmittances,
   *glass the glass interfaces met. */
static int isc_reference_photon(const pds_scene *s, pds__v3 o, pds__v3 d, pds__v3 *land, double *w, int *glass)
{
    int depth;
    *w = 1.0;
    *glass = 0;
    for (depth = 0; depth < 16; depth++) {
        pds_ray ray;
        pds_hit hit;
        const pds_material *m;
        pds__v3 n;
        double c;
        ray.origin = o;
        ray.dir = d;
        ray.tmin = 0.0;
        ray.tmax = 1e30;
        if (!pds_scene_intersect(s, &ray, &hit)) return 0;
        m = pds_scene_material(s, hit.material);
        if (m->type == PDS_MAT_DIFFUSE) {
            *land = hit.position;
            return depth > 0;
        }
        c = -pds__dot(d, hit.ng);
        n = c > 0.0 ? hit.ng : pds__scale(hit.ng, -1.0);
        c = fabs(c);
        if (m->type == PDS_MAT_MIRROR) {
            *w *= m->reflectance[1];
            d = pds__add(d, pds__scale(n, 2.0 * c));
        } else {
            double n1 = pds__dot(d, hit.ng) < 0.0 ? 1.0 : m->ior, n2 = n1 == 1.0 ? m->ior : 1.0, eta = n1 / n2;
            double k = 1.0 - eta * eta * (1.0 - c * c);
            ++*glass;
            if (k < 0.0) {
                d = pds__add(d, pds__scale(n, 2.0 * c));
            } else {
                *w *= 1.0 - isc_fresnel(c, n1, n2);
                d = pds__add(pds__scale(d, eta), pds__scale(n, eta * c - sqrt(k)));
            }
        }
        d = pds__normalize(d);
        /* off the surface, to the side the new direction leaves on */
        o = pds__add(hit.position, pds__scale(hit.ng, pds__dot(d, hit.ng) > 0.0 ? 1e-6 : -1e-6));
    }
    return 0;
}

/* The light-space buffer holds, for each texel's direction, the photon a
   per-photon tracer finds: the same landing point, the same path weight,
   and no photon where the tracer finds none (also where the mask of
   texels that can see a specular triangle spared the ray). */
static void test_isc_buffer_photons_land_where_a_per_photon_tracer_does(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text(isc_glass_scene, &err);
    pds_options opt;
    pds__isc ctx;
    int i, j, both = 0, mismatched = 0, res = 96, refracted = 0, masked = 0;
    double worst = 0.0, worst_w = 0.0;
    REQUIRE(t, s != NULL, "scene: %s", err.text);
    pds_options_default(&opt);
    opt.method = PDS_METHOD_ISC;
    opt.light_resolution = res;
    if (pds__isc_init(&ctx, s, &opt, 32, 32, 2, &err) != PDS_OK) {
        pds_scene_free(s);
        REQUIRE(t, 0, "init: %s", err.text);
    }
    ctx.lights[0] = s->lights[0];
    ctx.light = &ctx.lights[0];
    if (!pds__isc_view_setup(s, &ctx.target, ctx.light->position, res, 0.3, 0.7, &ctx.view)) {
        pds__isc_free(&ctx);
        pds_scene_free(s);
        REQUIRE(t, 0, "view");
    }
    pds__isc_mask(&ctx);
    pds__isc_parallel(&ctx, res, 4, pds__isc_photon_rows);
    for (j = 0; j < res; j++)
        for (i = 0; i < res; i++) {
            const pds__isc_photon *ph = &ctx.ph[j * res + i];
            pds__v3 d = pds__isc_view_dir(&ctx.view, i + ctx.view.jx, j + ctx.view.jy), land;
            double w;
            int glass, ref = isc_reference_photon(s, s->lights[0].position, d, &land, &w, &glass);
            masked += !ctx.mask[j * res + i];
            if (!ref || !ph->path) {
                mismatched += !ref != !ph->path;
                continue;
            }
            both++;
            refracted += glass > 0;
            {
                double dist = pds__length(pds__sub(pds__f3_get(ph->pos), land));
                double rel = fabs(ph->e[1] / (50.0 / (4.0 * PDS__PI)) / w - 1.0); /* I = P / 4 pi */
                if (dist > worst) worst = dist;
                if (rel > worst_w) worst_w = rel;
            }
        }
    CHECK(t, both > 500 && refracted > 100, "%d photons landed (%d through glass)", both, refracted);
    CHECK(t, masked > res * res / 10, "only %d of %d texels spared", masked, res * res);
    if (getenv("ISC_DBG")) printf("both %d refracted %d mismatched %d masked %d worst %g %g\n", both, refracted, mismatched, masked, worst, worst_w);
    CHECK(t, mismatched <= res * res / 2000, "%d texels where one tracer lands a photon and the other not", mismatched);
    CHECK(t, worst < 1e-4, "landing points differ by up to %g", worst);
    CHECK(t, worst_w < 1e-5, "path weights differ by up to %g (relative)", worst_w);
    pds__isc_free(&ctx);
    pds_scene_free(s);
}

/* Same seed, same image, whatever the thread count: every gather. */
static void test_isc_is_identical_for_any_thread_count(pds_test_ctx *t)
{
    int g;
    for (g = 0; g < 4; g++) {
        pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
        pds_options opt;
        pds_options_default(&opt);
        opt.method = PDS_METHOD_ISC;
        opt.isc_gather = (pds_isc_gather)g;
        opt.light_resolution = 128;
        opt.threads = 1;
        REQUIRE(t, render_text(isc_glass_scene, &opt, &a, NULL), "1 thread");
        opt.threads = 3;
        REQUIRE(t, render_text(isc_glass_scene, &opt, &b, NULL), "3 threads");
        CHECK(t, memcmp(a.rgb, b.rgb, sizeof *a.rgb * 3 * 32 * 32) == 0, "%s: 1 and 3 threads differ",
              isc_gather_label[g]);
        pds_image_free(&a);
        pds_image_free(&b);
    }
}

/* Frames of an animation, kept for the tests. */
typedef struct isc_frames {
    float *rgb[8];
    int n;
} isc_frames;

static pds_status isc_keep_frame(void *user, int frame, const pds_image *img, pds_error *err)
{
    isc_frames *f = (isc_frames *)user;
    size_t bytes = sizeof *img->rgb * 3 * (size_t)img->width * img->height;
    (void)err;
    if (frame >= 8) return PDS_OK;
    f->rgb[frame] = (float *)malloc(bytes);
    if (f->rgb[frame]) memcpy(f->rgb[frame], img->rgb, bytes);
    f->n = frame + 1;
    return PDS_OK;
}

static void isc_frames_free(isc_frames *f)
{
    int k;
    for (k = 0; k < 8; k++) free(f->rgb[k]);
}

/* Flicker, the mean squared frame-to-frame change of frames 4..7 over the
   pixels where the caustic is, of a static scene (no orbit): each frame
   samples the light through a differently offset grid. */
static double isc_flicker(const isc_frames *f, int npix)
{
    double sum = 0.0;
    int k, i, n = 0;
    for (k = 4; k < 8; k++)
        for (i = 0; i < npix; i++) {
            double a = f->rgb[k][3 * i + 1], b = f->rgb[k - 1][3 * i + 1];
            if (f->rgb[7][3 * i + 1] <= 0.0f) continue;
            sum += (a - b) * (a - b);
            n++;
        }
    return n ? sum / n : 0.0;
}

static int isc_animate(const char *text, int history, isc_frames *f)
{
    pds_error err;
    pds_scene *s = scene_from_text(text, &err);
    pds_options opt;
    int ok;
    if (!s) return 0;
    pds_options_default(&opt);
    opt.method = PDS_METHOD_ISC;
    opt.paths = PDS_PATHS_CAUSTICS_ONLY;
    opt.isc_gather = PDS_ISC_EYE;
    opt.light_resolution = 48;
    opt.history = history;
    opt.orbit = PDS_ORBIT_NONE;
    opt.threads = 2;
    memset(f, 0, sizeof *f);
    ok = pds_render_frames(s, &opt, 8, isc_keep_frame, f, NULL, &err) == PDS_OK && f->n == 8;
    pds_scene_free(s);
    return ok;
}

/* The temporal filter (Wyman and Davis sect. 3.2.3): averaging the last 4
   frames' estimates makes a static scene's caustic flicker far less than
   frame by frame (the difference of two running means of 4 frames is a
   quarter of the difference of two frames 4 apart: 1/16 the variance, for
   independent offsets), and
   the first frame of an animation is the still pds_render gives. */
static void test_isc_temporal_filter_reduces_flicker(pds_test_ctx *t)
{
    isc_frames raw, filtered;
    pds_image still = {0, 0, NULL};
    pds_options opt;
    double fr, ff;
    REQUIRE(t, isc_animate(isc_mirror_scene, 1, &raw), "frames without the filter");
    if (!isc_animate(isc_mirror_scene, 4, &filtered)) {
        isc_frames_free(&raw);
        REQUIRE(t, 0, "frames with the filter");
    }
    fr = isc_flicker(&raw, 64 * 64);
    ff = isc_flicker(&filtered, 64 * 64);
    CHECK(t, fr > 0.0 && ff < 0.4 * fr, "flicker %.4g with the 4-frame filter, %.4g without", ff, fr);
    if (getenv("ISC_DBG")) printf("flicker %g vs %g ratio %g\n", ff, fr, ff / fr);
    pds_options_default(&opt);
    opt.method = PDS_METHOD_ISC;
    opt.paths = PDS_PATHS_CAUSTICS_ONLY;
    opt.isc_gather = PDS_ISC_EYE;
    opt.light_resolution = 48;
    opt.threads = 2;
    if (render_text(isc_mirror_scene, &opt, &still, NULL))
        CHECK(t, memcmp(still.rgb, filtered.rgb[0], sizeof *still.rgb * 3 * 64 * 64) == 0,
              "frame 0 differs from the still");
    pds_image_free(&still);
    isc_frames_free(&raw);
    isc_frames_free(&filtered);
}

/* The glass box and mirror under a point and a spot light: static
   lighting keeps a buffer and a light map per light. */
static const char isc_two_lights_scene[] = ISC_GLASS_SCENE
    "light spot { position 1.5 3.2 -1 look_at 0.5 1 0 power 40 cone 25 35 }\n";

static void isc_static_options(pds_options *opt, pds_isc_gather g, int history)
{
    pds_options_default(opt);
    opt->method = PDS_METHOD_ISC;
    opt->isc_gather = g;
    opt->light_resolution = 64;
    opt->width = opt->height = 48;
    opt->history = history;
    opt->orbit = PDS_ORBIT_CAMERA;
    opt->orbit_deg = 7.0;
    opt->static_lighting = 1;
    opt->threads = 2;
}

/* Static lighting (Wyman and Davis, Table 1's "static" columns): with
   the lights and the scene still, the frames keep each light's photon
   buffer (and the light gather's map) traced in the first frame and redo only what
   depends on the eye. With the camera orbiting and the temporal filter
   on, every frame is bit for bit what recomputing everything each frame
   from frame 0's grid gives; each frame with the filter off is what a
   new render of that frame alone gives; each buffer is traced once; and
   frame 0 is the still, with or without the option. */
static void test_isc_static_lighting_frames_equal_frames_rendered_anew(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text(isc_two_lights_scene, &err);
    size_t bytes = sizeof(float) * 3 * 48 * 48;
    int g, f;
    REQUIRE(t, s != NULL, "scene: %s", err.text);
    for (g = 0; g < 4; g++) {
        pds_options opt;
        pds_render_stats st;
        isc_frames anim, single;
        pds__isc ctx;
        pds_image img = {0, 0, NULL}, still = {0, 0, NULL};
        int same = 0, alone = 0;
        memset(&anim, 0, sizeof anim);
        memset(&single, 0, sizeof single);
        REQUIRE(t, pds_image_alloc(&img, 48, 48) == PDS_OK, "image");
        isc_static_options(&opt, (pds_isc_gather)g, 4);
        CHECK(t, pds_render_frames(s, &opt, 6, isc_keep_frame, &anim, &st, &err) == PDS_OK && anim.n == 6,
              "%s: frames: %s", isc_gather_label[g], err.text);
        CHECK(t, st.photons == 2 * 64 * 64 && st.splatted > 100, "%s: %ld photons traced for 6 frames, %ld landed",
              isc_gather_label[g], st.photons, st.splatted);
        /* the same frames with every buffer recomputed each frame */
        if (anim.n == 6 && pds__isc_init(&ctx, s, &opt, 48, 48, 2, &err) == PDS_OK) {
            ctx.reuse = 0;
            for (f = 0; f < 6; f++) {
                pds__isc_frame(&ctx, f, 0, &img);
                same += memcmp(img.rgb, anim.rgb[f], bytes) == 0;
            }
            CHECK(t, ctx.photons == 6 * 2 * 64 * 64, "%s: recomputed %ld photons", isc_gather_label[g], ctx.photons);
            pds__isc_free(&ctx);
        }
        CHECK(t, same == 6, "%s: %d of 6 frames equal the recomputed ones", isc_gather_label[g], same);
        CHECK(t, anim.n == 6 && memcmp(anim.rgb[0], anim.rgb[5], bytes) != 0, "%s: the camera did not move",
              isc_gather_label[g]);
        /* frame 0 is the still, which the option does not change */
        opt.static_lighting = 0;
        if (anim.n == 6 && pds_render(s, &opt, &still, NULL, &err) == PDS_OK)
            CHECK(t, memcmp(still.rgb, anim.rgb[0], bytes) == 0, "%s: frame 0 is not the still", isc_gather_label[g]);
        pds_image_free(&still);
        /* without the filter, frame 5 is frame 5 rendered alone */
        isc_static_options(&opt, (pds_isc_gather)g, 1);
        if (pds_render_frames(s, &opt, 6, isc_keep_frame, &single, NULL, &err) == PDS_OK && single.n == 6 &&
            pds__isc_init(&ctx, s, &opt, 48, 48, 2, &err) == PDS_OK) {
            pds__isc_frame(&ctx, 5, 0, &img);
            alone = memcmp(img.rgb, single.rgb[5], bytes) == 0;
            pds__isc_free(&ctx);
        }
        CHECK(t, alone, "%s: frame 5 of the animation is not frame 5 rendered alone", isc_gather_label[g]);
        pds_image_free(&img);
        isc_frames_free(&anim);
        isc_frames_free(&single);
    }
    pds_scene_free(s);
}

/* Spectral isc: the fan scene of tests/test_spectral.c (an N-SF11 prism,
   scenes/prism.obj, at minimum deviation for n_d before a screen), lit by
   a narrow spot light where that test has a slit of collimated light
   (isc takes point and spot lights only). Each light-space photon
   carries a wavelength and is refracted with n(lambda), so the caustic on
   the screen fans out: blue lands left of red, by the amount photon
   mapping's photons give on the same scene, with the same light in each
   channel. */
static const char isc_fan_scene[] =
    "camera { position 0.6 0.8 0.3 look_at 1.5 0.3 -0.85 fov 50 resolution 96 64 spp 4 }\n"
    "material screen diffuse { albedo 0.8 }\n"
    "material flint dielectric { %s }\n"
    "quad { material screen size 3 3 rotate 90 0 0 1 translate 1.5 0.3 -0.8 }\n"
    "mesh \"prism.obj\" { material flint scale 0.4 0.6 0.4 }\n"
    "light spot { position -3.448 0.3 -2.131 direction 0.8369 0 0.5473 power 2000 cone 1 1.5 }\n";

/* Render the fan scene (glass: the dielectric's law) as if it were a file
   in scenes/ (for its mesh); caustics only. */
static int isc_fan_render(const char *glass, pds_method method, pds_isc_gather g, int threads, pds_image *img,
                          pds_render_stats *st)
{
    char text[1024];
    pds_error err;
    pds_scene *s = NULL;
    pds_options opt;
    int ok;
    snprintf(text, sizeof text, isc_fan_scene, glass);
    if (pds_scene_load_string(text, "scenes/isc-fan.scene", &s, &err) != PDS_OK) {
        printf("  scene: %s\n", err.text);
        return 0;
    }
    pds_options_default(&opt);
    opt.method = method;
    opt.isc_gather = g;
    opt.light_resolution = 256;
    opt.photons = 200000; /* pm */
    opt.paths = PDS_PATHS_CAUSTICS_ONLY;
    opt.threads = threads;
    ok = pds_render(s, &opt, img, st, &err) == PDS_OK;
    if (!ok) printf("  render: %s\n", err.text);
    pds_scene_free(s);
    return ok;
}

/* The blue channel's centroid minus the red one's, in pixels along x,
   and the light in each channel. */
static double isc_fan_measure(const pds_image *img, double light[3])
{
    double wx[3] = {0, 0, 0};
    int x, y, c;
    for (c = 0; c < 3; c++) light[c] = 0.0;
    for (y = 0; y < img->height; y++)
        for (x = 0; x < img->width; x++)
            for (c = 0; c < 3; c++) {
                double v = fmax(0.0, img->rgb[3 * (y * img->width + x) + c]);
                wx[c] += v * x;
                light[c] += v;
            }
    return light[0] > 0.0 && light[2] > 0.0 ? wx[2] / light[2] - wx[0] / light[0] : 0.0;
}

static void test_isc_spectral_photons_fan_out_through_a_prism_as_pm_s(pds_test_ctx *t)
{
    pds_image img = {0, 0, NULL};
    pds_render_stats st;
    double pm_sep, pm_light[3], sep, light[3];
    int g, c;
    REQUIRE(t, isc_fan_render(SPECTRAL_SF11, PDS_METHOD_PM, PDS_ISC_EYE, 2, &img, &st), "pm");
    pm_sep = isc_fan_measure(&img, pm_light);
    pds_image_free(&img);
    CHECK(t, pm_sep < -2.0, "pm: blue %.2f pixels right of red", pm_sep);
    for (g = 0; g < 4; g++) {
        REQUIRE(t, isc_fan_render(SPECTRAL_SF11, PDS_METHOD_ISC, (pds_isc_gather)g, 2, &img, &st), "%s",
                isc_gather_label[g]);
        sep = isc_fan_measure(&img, light);
        CHECK(t, st.spectral == 1, "%s: not spectral", isc_gather_label[g]);
        CHECK(t, fabs(sep / pm_sep - 1.0) < 0.1, "%s: fan %.2f pixels, pm %.2f", isc_gather_label[g], sep, pm_sep);
        for (c = 0; c < 3; c++)
            CHECK(t, fabs(light[c] / pm_light[c] - 1.0) < 0.1, "%s channel %d: %.4f, pm %.4f", isc_gather_label[g], c,
                  light[c], pm_light[c]);
        if (getenv("ISC_DBG"))
            printf("%s sep %.3f (pm %.3f) light %.4f %.4f %.4f (pm %.4f %.4f %.4f)\n", isc_gather_label[g], sep, pm_sep,
                   light[0], light[1], light[2], pm_light[0], pm_light[1], pm_light[2]);
        pds_image_free(&img);
    }
    /* the same prism with a fixed index: no fan, and an RGB render */
    REQUIRE(t, isc_fan_render("ior 1.7847", PDS_METHOD_ISC, PDS_ISC_EYE, 2, &img, &st), "fixed index");
    sep = isc_fan_measure(&img, light);
    CHECK(t, st.spectral == 0 && fabs(sep) < 0.05, "fixed index: spectral %d, blue %.3f pixels from red", st.spectral,
          sep);
    pds_image_free(&img);
}

/* The eye buffer through dispersive glass: the camera of
   tests/test_spectral.c's eye-path test looks back through the prism at a
   thin white diffuse strip lit by a point light. Each pixel's ray
   refracts at its own wavelength, so the strip becomes a spectrum with
   blue left of red, shifted as the path tracer shows it: one wavelength a
   pixel is noisy (measured: 4.0 to 6.2 pixels over seeds 0-7), their mean
   5.16 pixels (seeds 8-15: 5.55), pt 5.53 (5.48 at 256 samples a pixel).
   With a fixed index there is no shift. */
static const char isc_eye_scene[] =
    "camera { position 1.355 0.3 -0.763 look_at 0.1 0.3 0.0577 fov 24 resolution 192 64 spp 64 }\n"
    "material flint dielectric { %s }\n"
    "material white diffuse { albedo 1 }\n"
    "mesh \"prism.obj\" { material flint scale 0.4 0.6 0.4 }\n"
    "quad { material white size 1.5 0.04 rotate 90 0 0 1 rotate 146.83 0 1 0 translate -1.774 0.3 -1.037 }\n"
    "light point { position -1.342 0.8 -0.786 power 20 }\n";

/* The blue channel's centroid minus the red one's, in pixels along x,
   over the left 55% of the image: the strip seen through the prism (pt
   also shows its reflection off the prism's face, further right, which
   isc's one-path rule leaves out). */
static double isc_strip_shift(const pds_image *img)
{
    double wx[3] = {0, 0, 0}, w[3] = {0, 0, 0};
    int x, y, c;
    for (y = 0; y < img->height; y++)
        for (x = 0; x < img->width * 55 / 100; x++)
            for (c = 0; c < 3; c += 2) {
                double v = fmax(0.0, img->rgb[3 * (y * img->width + x) + c]);
                wx[c] += v * x;
                w[c] += v;
            }
    return w[0] > 0.0 && w[2] > 0.0 ? wx[2] / w[2] - wx[0] / w[0] : 0.0;
}

/* The strip's shift in a render by method (glass: the prism's law), the
   mean over seeds 0..seeds-1. */
static int isc_strip_render(const char *glass, pds_method method, int seeds, double *shift)
{
    char text[1024];
    pds_error err;
    pds_scene *s = NULL;
    int k, ok = 1;
    snprintf(text, sizeof text, isc_eye_scene, glass);
    if (pds_scene_load_string(text, "scenes/isc-eye.scene", &s, &err) != PDS_OK) return 0;
    *shift = 0.0;
    for (k = 0; k < seeds && ok; k++) {
        pds_options opt;
        pds_image img = {0, 0, NULL};
        pds_options_default(&opt);
        opt.method = method;
        opt.paths = PDS_PATHS_NO_CAUSTICS;
        opt.seed = (unsigned long long)k;
        opt.threads = 2;
        ok = pds_render(s, &opt, &img, NULL, &err) == PDS_OK;
        if (ok) *shift += isc_strip_shift(&img) / seeds;
        pds_image_free(&img);
    }
    pds_scene_free(s);
    return ok;
}

static void test_isc_spectral_eye_rays_see_a_strip_through_a_prism_as_a_spectrum(pds_test_ctx *t)
{
    double isc, pt, fixed;
    REQUIRE(t, isc_strip_render(SPECTRAL_SF11, PDS_METHOD_ISC, 8, &isc), "isc");
    REQUIRE(t, isc_strip_render(SPECTRAL_SF11, PDS_METHOD_PT, 1, &pt), "pt");
    REQUIRE(t, isc_strip_render("ior 1.7847", PDS_METHOD_ISC, 1, &fixed), "isc, fixed index");
    if (getenv("ISC_DBG")) printf("shift isc %.3f pt %.3f; fixed index isc %.3f\n", isc, pt, fixed);
    CHECK(t, isc < -2.0, "isc: blue %.3f pixels right of red", isc);
    CHECK(t, fabs(isc / pt - 1.0) < 0.15, "isc: blue %.3f pixels from red, pt %.3f", isc, pt);
    CHECK(t, fabs(fixed) < 0.05, "isc, fixed index: blue %.3f pixels from red", fixed);
}

/* Spectral isc is the same bit for bit for any thread count: every gather. */
static void test_isc_spectral_is_identical_for_any_thread_count(pds_test_ctx *t)
{
    int g;
    for (g = 0; g < 4; g++) {
        pds_image a = {0, 0, NULL}, b = {0, 0, NULL};
        REQUIRE(t, isc_fan_render(SPECTRAL_SF11, PDS_METHOD_ISC, (pds_isc_gather)g, 1, &a, NULL), "1 thread");
        REQUIRE(t, isc_fan_render(SPECTRAL_SF11, PDS_METHOD_ISC, (pds_isc_gather)g, 3, &b, NULL), "3 threads");
        CHECK(t, memcmp(a.rgb, b.rgb, sizeof(float) * 3 * (size_t)a.width * a.height) == 0, "%s: 1 and 3 threads differ",
              isc_gather_label[g]);
        pds_image_free(&a);
        pds_image_free(&b);
    }
}

/* A light orbit moves the caustic: frame 45 degrees on is not frame 0,
   and a full turn brings it back. */
static void test_isc_light_orbit_moves_the_caustic_and_returns(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text(isc_glass_scene, &err);
    pds_options opt;
    isc_frames f;
    REQUIRE(t, s != NULL, "scene: %s", err.text);
    pds_options_default(&opt);
    opt.method = PDS_METHOD_ISC;
    opt.isc_gather = PDS_ISC_QUADS;
    opt.light_resolution = 64;
    opt.history = 1;
    opt.orbit_deg = 180.0;
    opt.threads = 2;
    memset(&f, 0, sizeof f);
    /* frames 0, 1, 2 at 0, 180 and 360 degrees; the grid offsets differ,
       so compare the direct light (no caustics) */
    opt.paths = PDS_PATHS_NO_CAUSTICS;
    CHECK(t, pds_render_frames(s, &opt, 3, isc_keep_frame, &f, NULL, &err) == PDS_OK && f.n == 3, "frames: %s",
          err.text);
    if (f.n == 3) {
        double d01 = 0.0, d02 = 0.0;
        int i;
        for (i = 0; i < 3 * 32 * 32; i++) {
            d01 += fabs(f.rgb[0][i] - f.rgb[1][i]);
            d02 += fabs(f.rgb[0][i] - f.rgb[2][i]);
        }
        CHECK(t, d01 > 1.0 && d02 < 1e-3 * d01, "half a turn changes the image by %g, a whole turn by %g", d01, d02);
    }
    isc_frames_free(&f);
    pds_scene_free(s);
}

/* Mean relative error of the points gather's irradiance against the
   mirror's analytic caustic, inside the lit patch (64 x 64 image). */
static double isc_points_error(const pds_scene *s, const pds_image *img)
{
    double sum = 0.0;
    int x, y, n = 0;
    for (y = 0; y < 64; y++)
        for (x = 0; x < 64; x++) {
            pds__v3 c;
            (void)isc_floor_pixel_area(s, 64, 64, x, y, &c);
            if (fabs(c.x + 0.02) > 0.2 || fabs(c.z) > 0.3) continue;
            sum += fabs(PDS__PI * img->rgb[3 * (y * 64 + x) + 1] / isc_mirror_irradiance(c) - 1.0);
            n++;
        }
    return n ? sum / n : 1.0;
}

/* Under a time budget a still averages frames whose light-space grids are
   offset differently (and nothing turns): the sparse points image
   converges toward the analytic caustic. */
static void test_isc_time_budget_averages_offset_frames(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text(isc_mirror_scene, &err);
    pds_options opt;
    pds_image one = {0, 0, NULL}, many = {0, 0, NULL};
    pds_render_stats st;
    REQUIRE(t, s != NULL, "scene: %s", err.text);
    pds_options_default(&opt);
    opt.method = PDS_METHOD_ISC;
    opt.paths = PDS_PATHS_CAUSTICS_ONLY;
    opt.isc_gather = PDS_ISC_POINTS;
    opt.light_resolution = 40;
    opt.threads = 2;
    if (pds_render(s, &opt, &one, NULL, &err) == PDS_OK) {
        opt.time_s = 0.5;
        if (pds_render(s, &opt, &many, &st, &err) == PDS_OK) {
            double e1 = isc_points_error(s, &one), en = isc_points_error(s, &many);
            CHECK(t, st.passes >= 2 && st.photons == (long)st.passes * 40 * 40, "%d frames, %ld photons", st.passes,
                  st.photons);
            /* the error falls at least as 1/sqrt(frames) would from 2 to 4
               frames, however many the machine managed */
            CHECK(t, en < e1 * (st.passes >= 4 ? 0.5 : 1.0 / sqrt((double)st.passes) + 0.01),
                  "error %.4f after %d frames, %.4f after one", en, st.passes, e1);
            if (getenv("ISC_DBG")) printf("frames %d error %g vs %g\n", st.passes, en, e1);
        }
    }
    CHECK(t, one.rgb && many.rgb, "render: %s", err.text);
    pds_image_free(&one);
    pds_image_free(&many);
    pds_scene_free(s);
}

/* A frame callback that fails stops the animation with its status. */
static pds_status isc_fail_second(void *user, int frame, const pds_image *img, pds_error *err)
{
    (void)img;
    ++*(int *)user;
    if (frame < 1) return PDS_OK;
    snprintf(err->text, sizeof err->text, "disk full");
    err->status = PDS_ERR_IO;
    return PDS_ERR_IO;
}

static void test_isc_frames_stop_when_the_callback_fails(pds_test_ctx *t)
{
    pds_error err;
    pds_scene *s = scene_from_text(isc_mirror_scene, &err);
    pds_options opt;
    pds_render_stats st;
    int calls = 0;
    REQUIRE(t, s != NULL, "scene: %s", err.text);
    pds_options_default(&opt);
    opt.method = PDS_METHOD_ISC;
    opt.light_resolution = 16;
    opt.threads = 2;
    CHECK(t, pds_render_frames(s, &opt, 5, isc_fail_second, &calls, &st, NULL) == PDS_ERR_IO && calls == 2 &&
                 st.passes == 1,
          "calls %d, frames %d", calls, st.passes);
    pds_scene_free(s);
}

/* What isc cannot take is refused with a message, not rendered wrong. */
static void test_isc_refuses_what_it_cannot_render(pds_test_ctx *t)
{
    pds_error err;
    pds_options opt;
    pds_image img = {0, 0, NULL};
    pds_scene *s = scene_from_text("camera { position 0 2 3 look_at 0 0 0 resolution 8 8 }\n"
                                   "material floor diffuse { albedo 0.5 }\n"
                                   "quad { material floor }\n"
                                   "light quad { center 0 2 0 edge1 1 0 0 edge2 0 0 -1 power 10 }\n",
                                   &err);
    REQUIRE(t, s != NULL, "scene: %s", err.text);
    pds_options_default(&opt);
    opt.method = PDS_METHOD_ISC;
    CHECK(t, pds_render(s, &opt, &img, NULL, &err) == PDS_ERR_INVALID_ARG &&
                 strstr(err.text, "point and spot lights only, as Wyman and Davis's method does; light 1 is a quad light") != NULL,
          "quad light: %s", err.text);
    opt.method = PDS_METHOD_PDS;
    CHECK(t, pds_render_frames(s, &opt, 3, isc_keep_frame, NULL, NULL, &err) == PDS_ERR_INVALID_ARG &&
                 strstr(err.text, "isc") != NULL,
          "frames with pds: %s", err.text);
    opt.method = PDS_METHOD_ISC;
    opt.history = 0;
    CHECK(t, pds_render(s, &opt, &img, NULL, &err) == PDS_ERR_INVALID_ARG && strstr(err.text, "history 0") != NULL,
          "history 0: %s", err.text);
    opt.history = 4;
    opt.static_lighting = 1;
    CHECK(t, pds_render_frames(s, &opt, 3, isc_keep_frame, NULL, NULL, &err) == PDS_ERR_INVALID_ARG &&
                 strstr(err.text, "the light cannot orbit") != NULL,
          "static lighting, light orbit: %s", err.text);
    opt.time_s = 1.0;
    CHECK(t, pds_render(s, &opt, &img, NULL, &err) == PDS_ERR_INVALID_ARG &&
                 strstr(err.text, "static lighting keeps one light-space grid") != NULL,
          "static lighting, time budget: %s", err.text);
    pds_scene_free(s);
}

#ifdef PDS_TEST_POSIX
/* The tool: --frames writes numbered frames and one final line; isc's
   options are checked and their mistakes named. */
static void test_isc_cli_frames_and_options(pds_test_ctx *t)
{
    char out[8192], args[1024], base[256], path[300];
    int k;
    harness_path(base, sizeof base, "isc.png");
    snprintf(args, sizeof args,
             "render scenes/ring_octahedron.scene --method isc --gather quads --light-res 32 --res 16x12 --frames 3 "
             "--orbit camera --orbit-step 10 --quiet -o %s",
             base);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "%s", out);
    CHECK(t, HARNESS_STARTS(cli_last_line(out), "render method=isc paths=all width=16 height=12 spp=1 photons=3072 ") &&
                 strstr(out, " frames=3 gather=quads history=4 ") != NULL,
          "final line: %s", out);
    for (k = 0; k < 3; k++) {
        snprintf(path, sizeof path, "/tmp/pds_harness_%ld_isc.%04d.png", (long)getpid(), k);
        CHECK(t, cli_file_exists(path), "%s written", path);
        remove(path);
    }
    CHECK(t, cli_run("render scenes/ring_octahedron.scene --method isc --gather eyes", out, sizeof out) == 2 &&
                 strstr(out, "pds render: --gather takes points, quads, eye or light, got 'eyes' (did you mean 'eye'?)"),
          "%s", out);
    CHECK(t, cli_run("render scenes/ring_octahedron.scene --method isc --static-lighting", out, sizeof out) == 2 &&
                 strstr(out, "pds render: --static-lighting keeps the photons from frame to frame: it is for --frames"),
          "%s", out);
    CHECK(t, cli_run("render scenes/ring_octahedron.scene --method isc --static-lighting --frames 2", out, sizeof out) ==
                     2 &&
                 strstr(out, "pds render: --static-lighting keeps the light where it is: give --orbit camera or --orbit none"),
          "%s", out);
    CHECK(t, cli_run("render tests/golden/glass.scene --frames 3", out, sizeof out) == 2 &&
                 strstr(out, "--frames renders an animation with --method isc only"),
          "%s", out);
    CHECK(t, cli_run("render tests/golden/glass.scene --method pm --gather eye --res 8x6 --spp 1 --photons 100 --quiet "
                     "-o /tmp/pds_isc_note.png",
                     out, sizeof out) == 0 &&
                 strstr(out, "pds render: note: --gather has no effect with --method pm (it is for gi, spm and isc)"),
          "%s", out);
    remove("/tmp/pds_isc_note.png");
}
#endif

static const pds_test_case tests_isc[] = {
    {"isc_buffer_photons_land_where_a_per_photon_tracer_does", test_isc_buffer_photons_land_where_a_per_photon_tracer_does},
    {"isc_gathers_conserve_flux_on_a_flat_receiver", test_isc_gathers_conserve_flux_on_a_flat_receiver},
    {"isc_quads_cover_a_plane_mirrors_caustic_exactly_once", test_isc_quads_cover_a_plane_mirrors_caustic_exactly_once},
    {"isc_is_identical_for_any_thread_count", test_isc_is_identical_for_any_thread_count},
    {"isc_temporal_filter_reduces_flicker", test_isc_temporal_filter_reduces_flicker},
    {"isc_static_lighting_frames_equal_frames_rendered_anew", test_isc_static_lighting_frames_equal_frames_rendered_anew},
    {"isc_spectral_photons_fan_out_through_a_prism_as_pm_s", test_isc_spectral_photons_fan_out_through_a_prism_as_pm_s},
    {"isc_spectral_eye_rays_see_a_strip_through_a_prism_as_a_spectrum",
     test_isc_spectral_eye_rays_see_a_strip_through_a_prism_as_a_spectrum},
    {"isc_spectral_is_identical_for_any_thread_count", test_isc_spectral_is_identical_for_any_thread_count},
    {"isc_light_orbit_moves_the_caustic_and_returns", test_isc_light_orbit_moves_the_caustic_and_returns},
    {"isc_time_budget_averages_offset_frames", test_isc_time_budget_averages_offset_frames},
    {"isc_frames_stop_when_the_callback_fails", test_isc_frames_stop_when_the_callback_fails},
    {"isc_refuses_what_it_cannot_render", test_isc_refuses_what_it_cannot_render},
#ifdef PDS_TEST_POSIX
    {"isc_cli_frames_and_options", test_isc_cli_frames_and_options},
#endif
};

/* tests/test_obj.c - the Wavefront OBJ/MTL loader (>>obj in pds.c).

   Every test writes its own small files under /tmp (names carry the
   process id) and checks the mesh against hand-computed answers. */

#include <sys/stat.h>
#include <unistd.h>

/* /tmp/pds_obj_PID_name */
static void tobj_path(char *out, size_t n, const char *name)
{
    snprintf(out, n, "/tmp/pds_obj_%ld_%s", (long)getpid(), name);
}

static int tobj_write(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    size_t len = strlen(text);
    int ok;
    if (!f) return 0;
    ok = fwrite(text, 1, len, f) == len;
    return (fclose(f) == 0) && ok;
}

/* A loader fixture: a mesh, a material table holding "scene_default"
   (index 0) and the options the tests change. */
typedef struct tobj_fix {
    pds__mesh mesh;
    pds__materials mats;
    pds__obj_options opt;
    pds__obj_stats stats;
    pds_error err;
} tobj_fix;

static void tobj_init(tobj_fix *f)
{
    pds_material d = pds__material_default("scene_default");
    memset(f, 0, sizeof *f);
    pds__materials_add(&f->mats, &d);
    f->opt.xform = NULL;
    f->opt.material_override = -1;
    f->opt.default_material = 0;
}

static void tobj_done(tobj_fix *f)
{
    pds__mesh_free(&f->mesh);
    pds__materials_free(&f->mats);
}

/* Write text to /tmp/pds_obj_PID_name and load it into f. */
static pds_status tobj_load_text(tobj_fix *f, const char *name, const char *text, char *path, size_t n)
{
    tobj_path(path, n, name);
    if (!tobj_write(path, text)) return PDS_ERR_IO;
    return pds__obj_load(path, &f->mesh, &f->mats, &f->opt, &f->stats, &f->err);
}

/* Winding normal (P1-P0)x(P2-P0) of triangle t: twice its area vector. */
static pds__v3 tobj_tri_cross(const pds__mesh *m, size_t t)
{
    const int *c = m->idx + 3 * t;
    pds__v3 a = pds__mesh_pos(m, c[0]), b = pds__mesh_pos(m, c[1]), d = pds__mesh_pos(m, c[2]);
    return pds__cross(pds__sub(b, a), pds__sub(d, a));
}

static double tobj_total_area(const pds__mesh *m)
{
    size_t t;
    double a = 0.0;
    for (t = 0; t < m->ntris; t++) a += 0.5 * pds__length(tobj_tri_cross(m, t));
    return a;
}

static int tobj_vec_near(pds__v3 a, pds__v3 b, double tol)
{
    return fabs(a.x - b.x) <= tol && fabs(a.y - b.y) <= tol && fabs(a.z - b.z) <= tol;
}

/* ------------------------------------------------------------- index forms */

static void test_obj_index_forms(pds_test_ctx *t)
{
    tobj_fix f;
    char path[256];
    size_t i;
    static const char text[] =
        "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
        "vt 0 0\nvt 1 0\n"
        "vn 0 0 2\n"
        "f 1 2 3\n"
        "f 1/1 2/2 3/1\n"
        "f 1//1 2//1 3//1\n"
        "f 1/1/1 2/2/1 3/1/1\n"
        "f 1 2/1 3//1\n";
    tobj_init(&f);
    REQUIRE(t, tobj_load_text(&f, "forms.obj", text, path, sizeof path) == PDS_OK, "%s", f.err.text);
    CHECK(t, f.stats.vertices == 3 && f.stats.texcoords == 2 && f.stats.normals == 1,
          "counts v=%ld vt=%ld vn=%ld", f.stats.vertices, f.stats.texcoords, f.stats.normals);
    CHECK(t, f.stats.faces == 5 && f.stats.triangles == 5, "faces %ld triangles %ld", f.stats.faces,
          f.stats.triangles);
    REQUIRE(t, f.mesh.ntris == 5, "ntris %lu", (unsigned long)f.mesh.ntris);
    /* (position, normal source) pairs: 3 smooth + 3 with vn 1 */
    CHECK(t, f.mesh.nverts == 6, "nverts %lu, expected 6", (unsigned long)f.mesh.nverts);
    for (i = 0; i < 5; i++) {
        pds__v3 p0 = pds__mesh_pos(&f.mesh, f.mesh.idx[3 * i]);
        pds__v3 p1 = pds__mesh_pos(&f.mesh, f.mesh.idx[3 * i + 1]);
        pds__v3 p2 = pds__mesh_pos(&f.mesh, f.mesh.idx[3 * i + 2]);
        CHECK(t, tobj_vec_near(p0, pds__v(0, 0, 0), 0) && tobj_vec_near(p1, pds__v(1, 0, 0), 0) &&
                     tobj_vec_near(p2, pds__v(0, 1, 0), 0),
              "triangle %lu has the wrong corners", (unsigned long)i);
        CHECK(t, f.mesh.mat[i] == 0, "triangle %lu material %d", (unsigned long)i, f.mesh.mat[i]);
    }
    /* every normal, given or computed, is +z here */
    for (i = 0; i < f.mesh.nverts; i++)
        CHECK(t, tobj_vec_near(pds__mesh_nrm(&f.mesh, (long)i), pds__v(0, 0, 1), 1e-6),
              "vertex %lu normal", (unsigned long)i);
    /* the mixed face: corners 1, 2 smooth (shared with face 1), 3 from vn */
    CHECK(t, f.mesh.idx[12] == f.mesh.idx[0] && f.mesh.idx[13] == f.mesh.idx[1] &&
                 f.mesh.idx[14] == f.mesh.idx[8],
          "mixed face corners %d %d %d", f.mesh.idx[12], f.mesh.idx[13], f.mesh.idx[14]);
    remove(path);
    tobj_done(&f);
}

static void test_obj_negative_indices(pds_test_ctx *t)
{
    tobj_fix f;
    char path[256];
    static const char text[] =
        "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
        "vn 1 0 0\n"
        "f -3 -2 -1\n"
        "v 5 0 0\nv 6 0 0\nv 5 1 0\n"
        "vn 0 0 1\n"
        "f -3//-1 -2//-1 -1//-1\n"
        "f -6//-2 -5//-2 -4//-2\n";
    tobj_init(&f);
    REQUIRE(t, tobj_load_text(&f, "neg.obj", text, path, sizeof path) == PDS_OK, "%s", f.err.text);
    REQUIRE(t, f.mesh.ntris == 3, "ntris %lu", (unsigned long)f.mesh.ntris);
    CHECK(t, tobj_vec_near(pds__mesh_pos(&f.mesh, f.mesh.idx[0]), pds__v(0, 0, 0), 0), "tri 0 corner 0");
    CHECK(t, tobj_vec_near(pds__mesh_pos(&f.mesh, f.mesh.idx[2]), pds__v(0, 1, 0), 0), "tri 0 corner 2");
    CHECK(t, tobj_vec_near(pds__mesh_pos(&f.mesh, f.mesh.idx[3]), pds__v(5, 0, 0), 0), "tri 1 corner 0");
    CHECK(t, tobj_vec_near(pds__mesh_pos(&f.mesh, f.mesh.idx[5]), pds__v(5, 1, 0), 0), "tri 1 corner 2");
    CHECK(t, tobj_vec_near(pds__mesh_nrm(&f.mesh, f.mesh.idx[3]), pds__v(0, 0, 1), 1e-6), "tri 1 uses vn 2");
    CHECK(t, tobj_vec_near(pds__mesh_pos(&f.mesh, f.mesh.idx[6]), pds__v(0, 0, 0), 0), "tri 2 corner 0");
    CHECK(t, tobj_vec_near(pds__mesh_nrm(&f.mesh, f.mesh.idx[6]), pds__v(1, 0, 0), 1e-6), "tri 2 uses vn 1");
    remove(path);
    tobj_done(&f);
}

/* ----------------------------------------------------------- triangulation */

/* Inside the L hexagon [0,2]x[0,1] u [0,1]x[0,2] (strictly). */
static int tobj_in_L(double x, double y)
{
    return (x > 0 && x < 2 && y > 0 && y < 1) || (x > 0 && x < 1 && y > 0 && y < 2);
}

static void test_obj_polygons_triangulate(pds_test_ctx *t)
{
    tobj_fix f;
    char path[256];
    size_t i;
    /* the L starts at the convex corner (2,0): a fan from there would
       fold over itself (area 4 instead of 3) */
    static const char l_xy[] =
        "v 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 0 0 0\n"
        "f 1 2 3 4 5 6\n";
    static const char quad[] = "v 0 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\nf 1 2 3 4\n";
    /* square with an extra corner in the middle of one edge */
    static const char square5[] = "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\nf 1 2 3 4 5\n";
    /* the same L in the plane x + y + z = 0 through a rotation-like map
       (u, v) -> u*a + v*b with a = (1,-1,0)/sqrt2, b = (1,1,-2)/sqrt6 */
    char tilted[1024];
    static const double L2[6][2] = {{2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}, {0, 0}};
    pds__v3 a = pds__scale(pds__v(1, -1, 0), 1.0 / sqrt(2.0));
    pds__v3 b = pds__scale(pds__v(1, 1, -2), 1.0 / sqrt(6.0));
    pds__v3 nrm = pds__normalize(pds__cross(a, b));
    size_t len = 0;

    tobj_init(&f);
    REQUIRE(t, tobj_load_text(&f, "quad.obj", quad, path, sizeof path) == PDS_OK, "%s", f.err.text);
    CHECK(t, f.mesh.ntris == 2, "quad gives %lu triangles", (unsigned long)f.mesh.ntris);
    CHECK_NEAR(t, tobj_total_area(&f.mesh), 4.0, 1e-9);
    remove(path);
    tobj_done(&f);

    tobj_init(&f);
    REQUIRE(t, tobj_load_text(&f, "sq5.obj", square5, path, sizeof path) == PDS_OK, "%s", f.err.text);
    CHECK_NEAR(t, tobj_total_area(&f.mesh), 4.0, 1e-9);
    for (i = 0; i < f.mesh.ntris; i++) CHECK(t, tobj_tri_cross(&f.mesh, i).z > 0.0, "sq5 tri %lu flipped", (unsigned long)i);
    remove(path);
    tobj_done(&f);

    tobj_init(&f);
    REQUIRE(t, tobj_load_text(&f, "lxy.obj", l_xy, path, sizeof path) == PDS_OK, "%s", f.err.text);
    CHECK(t, f.mesh.ntris == 4, "L gives %lu triangles", (unsigned long)f.mesh.ntris);
    CHECK_NEAR(t, tobj_total_area(&f.mesh), 3.0, 1e-9);
    for (i = 0; i < f.mesh.ntris; i++) {
        const int *c = f.mesh.idx + 3 * i;
        pds__v3 g = pds__scale(pds__add(pds__add(pds__mesh_pos(&f.mesh, c[0]), pds__mesh_pos(&f.mesh, c[1])),
                                        pds__mesh_pos(&f.mesh, c[2])), 1.0 / 3.0);
        CHECK(t, tobj_in_L(g.x, g.y), "L triangle %lu centroid (%g, %g) is outside", (unsigned long)i, g.x, g.y);
        CHECK(t, tobj_tri_cross(&f.mesh, i).z > 0.0, "L triangle %lu is flipped", (unsigned long)i);
    }
    remove(path);
    tobj_done(&f);

    for (i = 0; i < 6; i++) {
        pds__v3 p = pds__add(pds__scale(a, L2[i][0]), pds__scale(b, L2[i][1]));
        len += (size_t)snprintf(tilted + len, sizeof tilted - len, "v %.17g %.17g %.17g\n", p.x, p.y, p.z);
    }
    snprintf(tilted + len, sizeof tilted - len, "f 1 2 3 4 5 6\n");
    tobj_init(&f);
    REQUIRE(t, tobj_load_text(&f, "ltilt.obj", tilted, path, sizeof path) == PDS_OK, "%s", f.err.text);
    CHECK(t, f.mesh.ntris == 4, "tilted L gives %lu triangles", (unsigned long)f.mesh.ntris);
    CHECK_NEAR(t, tobj_total_area(&f.mesh), 3.0, 1e-5);
    for (i = 0; i < f.mesh.ntris; i++) {
        const int *c = f.mesh.idx + 3 * i;
        pds__v3 g = pds__scale(pds__add(pds__add(pds__mesh_pos(&f.mesh, c[0]), pds__mesh_pos(&f.mesh, c[1])),
                                        pds__mesh_pos(&f.mesh, c[2])), 1.0 / 3.0);
        CHECK(t, tobj_in_L(pds__dot(g, a), pds__dot(g, b)), "tilted L triangle %lu is outside", (unsigned long)i);
        CHECK(t, pds__dot(pds__normalize(tobj_tri_cross(&f.mesh, i)), nrm) > 0.999999,
              "tilted L triangle %lu is not facing the polygon normal", (unsigned long)i);
    }
    remove(path);
    tobj_done(&f);
}

/* ---------------------------------------------------------------- lexing */

static void test_obj_messy_file_parses_like_clean(pds_test_ctx *t)
{
    tobj_fix a, b;
    char pa[256], pb[256];
    static const char clean[] =
        "# a comment\n"
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
        "vn 0 0 1\n"
        "g one two\n"
        "f 1//1 2//1 3//1 4//1\n"
        "s off\n"
        "f 1 3 4\n";
    static const char messy[] =
        "\xEF\xBB\xBF# a comment\r\n"
        "v\t0 0 0\r\n"
        "v 1 \\\r\n   0 0\r\n"
        "\r\n"
        "\tv 1\t1 0   \r\n"
        "v 0 1 0 # trailing comment\r\n"
        "vn 0 0 1\r\n"
        "g one \\\n two\r\n"
        "f 1//1 2//1 \\\n"
        "  3//1 \\  \n"
        "  4//1\r\n"
        "s off\r\n"
        "f 1 3 4";
    tobj_init(&a);
    tobj_init(&b);
    REQUIRE(t, tobj_load_text(&a, "clean.obj", clean, pa, sizeof pa) == PDS_OK, "%s", a.err.text);
    REQUIRE(t, tobj_load_text(&b, "messy.obj", messy, pb, sizeof pb) == PDS_OK, "%s", b.err.text);
    CHECK(t, a.mesh.ntris == 3 && b.mesh.ntris == 3, "ntris %lu vs %lu", (unsigned long)a.mesh.ntris,
          (unsigned long)b.mesh.ntris);
    REQUIRE(t, a.mesh.nverts == b.mesh.nverts && a.mesh.ntris == b.mesh.ntris, "sizes differ");
    CHECK(t, memcmp(a.mesh.pos, b.mesh.pos, 3 * a.mesh.nverts * sizeof(float)) == 0, "positions differ");
    CHECK(t, memcmp(a.mesh.nrm, b.mesh.nrm, 3 * a.mesh.nverts * sizeof(float)) == 0, "normals differ");
    CHECK(t, memcmp(a.mesh.idx, b.mesh.idx, 3 * a.mesh.ntris * sizeof(int)) == 0, "indices differ");
    CHECK(t, a.stats.groups == 1 && b.stats.groups == 1, "groups %ld %ld", a.stats.groups, b.stats.groups);
    CHECK(t, b.stats.ignored_statements == 0, "ignored %ld (%s)", b.stats.ignored_statements,
          b.stats.ignored_example);
    remove(pa);
    remove(pb);
    tobj_done(&a);
    tobj_done(&b);
}

static void test_obj_unknown_statements_are_counted(pds_test_ctx *t)
{
    tobj_fix f;
    char path[256], expect[600];
    static const char text[] =
        "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
        "l 1 2\np 1\nvp 0.5\ncstype bspline\n"
        "  frobnicate 1 2\n"
        "zap\n"
        "f 1 2 3\n";
    tobj_init(&f);
    REQUIRE(t, tobj_load_text(&f, "unknown.obj", text, path, sizeof path) == PDS_OK, "%s", f.err.text);
    CHECK(t, f.stats.ignored_statements == 2, "ignored %ld", f.stats.ignored_statements);
    snprintf(expect, sizeof expect, "%s:8:3: 'frobnicate'", path);
    CHECK(t, strcmp(f.stats.ignored_example, expect) == 0, "example '%s'", f.stats.ignored_example);
    CHECK(t, f.mesh.ntris == 1, "ntris %lu", (unsigned long)f.mesh.ntris);
    remove(path);
    tobj_done(&f);
}

/* ---------------------------------------------------------------- normals */

static const char tobj_cube[] =
    "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\n"
    "v -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n"
    "f 1 4 3 2\n" /* -z */
    "f 5 6 7 8\n" /* +z */
    "f 1 2 6 5\n" /* -y */
    "f 4 8 7 3\n" /* +y */
    "f 1 5 8 4\n" /* -x */
    "f 2 3 7 6\n";/* +x */

static void test_obj_cube_smooth_and_flat_normals(pds_test_ctx *t)
{
    tobj_fix f;
    char path[256], text[1024];
    size_t i;
    int k, pass;
    for (pass = 0; pass < 3; pass++) {
        const char *header = pass == 0 ? "s 1\n" : pass == 1 ? "s off\n" : "";
        snprintf(text, sizeof text, "%s%s", header, tobj_cube);
        tobj_init(&f);
        REQUIRE(t, tobj_load_text(&f, "cube.obj", text, path, sizeof path) == PDS_OK, "%s", f.err.text);
        REQUIRE(t, f.mesh.ntris == 12, "cube pass %d: %lu triangles", pass, (unsigned long)f.mesh.ntris);
        CHECK_NEAR(t, tobj_total_area(&f.mesh), 24.0, 1e-9);
        if (pass != 1) {
            /* smooth: one vertex per corner, normal along the diagonal */
            CHECK(t, f.mesh.nverts == 8, "pass %d: %lu vertices, expected 8", pass, (unsigned long)f.mesh.nverts);
            for (i = 0; i < f.mesh.nverts; i++) {
                pds__v3 p = pds__mesh_pos(&f.mesh, (long)i);
                pds__v3 want = pds__scale(p, 1.0 / sqrt(3.0));
                CHECK(t, tobj_vec_near(pds__mesh_nrm(&f.mesh, (long)i), want, 1e-6),
                      "pass %d vertex %lu normal", pass, (unsigned long)i);
            }
        } else {
            /* flat: 4 vertices per face, normals = outward face normals */
            CHECK(t, f.mesh.nverts == 24, "flat: %lu vertices, expected 24", (unsigned long)f.mesh.nverts);
            for (i = 0; i < f.mesh.ntris; i++) {
                pds__v3 g = pds__normalize(tobj_tri_cross(&f.mesh, i));
                for (k = 0; k < 3; k++)
                    CHECK(t, tobj_vec_near(pds__mesh_nrm(&f.mesh, f.mesh.idx[3 * i + k]), g, 1e-6),
                          "flat triangle %lu corner %d", (unsigned long)i, k);
                /* outward: along the centroid direction */
                CHECK(t, pds__dot(g, pds__mesh_pos(&f.mesh, f.mesh.idx[3 * i])) > 0.0, "flat triangle %lu inward",
                      (unsigned long)i);
            }
        }
        remove(path);
        tobj_done(&f);
    }
}

static void test_obj_given_normals_are_normalised(pds_test_ctx *t)
{
    tobj_fix f;
    char path[256];
    /* face 2 has a zero vn: its corners become smooth vertices shared
       with face 3 (which has no vn), normal = angle-weighted mean */
    static const char text[] =
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 1\n"
        "vn 0 3 4\nvn 0 0 0\n"
        "f 1//1 2//1 3//1\n"
        "f 1//2 2//2 3//2\n"
        "f 2 4 3\n";
    pds__v3 n2, n3, want;
    tobj_init(&f);
    REQUIRE(t, tobj_load_text(&f, "vn.obj", text, path, sizeof path) == PDS_OK, "%s", f.err.text);
    REQUIRE(t, f.mesh.ntris == 3, "ntris %lu", (unsigned long)f.mesh.ntris);
    CHECK(t, tobj_vec_near(pds__mesh_nrm(&f.mesh, f.mesh.idx[0]), pds__v(0, 0.6, 0.8), 1e-6),
          "vn 0 3 4 not normalised");
    CHECK(t, f.mesh.idx[4] == f.mesh.idx[6] && f.mesh.idx[5] == f.mesh.idx[8],
          "zero-vn corners are not the smooth vertices of face 3");
    CHECK(t, tobj_vec_near(pds__mesh_nrm(&f.mesh, f.mesh.idx[3]), pds__v(0, 0, 1), 1e-6),
          "position 1 (face 2 only) should get face 2's normal");
    /* position 2 = (1,0,0): face 2 (normal +z, angle 45 deg) and face 3
       (normal n3, angle between (0,1,1) and (-1,1,0): 60 deg) */
    n2 = pds__v(0, 0, 1);
    n3 = pds__normalize(pds__cross(pds__v(0, 1, 1), pds__v(-1, 1, 0)));
    want = pds__normalize(pds__add(pds__scale(n2, PDS__PI / 4), pds__scale(n3, PDS__PI / 3)));
    CHECK(t, tobj_vec_near(pds__mesh_nrm(&f.mesh, f.mesh.idx[4]), want, 1e-6), "smooth normal at (1,0,0)");
    remove(path);
    tobj_done(&f);
}

static void test_obj_transform_positions_and_normals(pds_test_ctx *t)
{
    tobj_fix f;
    char path[256];
    pds__xform x = pds__xform_identity();
    pds__v3 want = pds__normalize(pds__v(1, 2, 0));
    size_t i;
    /* a triangle in the plane x + y = 1, once with vn, once computed */
    static const char text[] =
        "v 1 0 0\nv 0 1 0\nv 1 0 1\n"
        "vn 3 3 0\n"
        "f 1//1 2//1 3//1\n"
        "f 1 2 3\n";
    x.m[0][0] = 2.0; /* non-uniform scale: x by 2 ... */
    x.m[1][3] = 5.0; /* ... and a shift along y */
    tobj_init(&f);
    f.opt.xform = &x;
    REQUIRE(t, tobj_load_text(&f, "xf.obj", text, path, sizeof path) == PDS_OK, "%s", f.err.text);
    REQUIRE(t, f.mesh.ntris == 2, "ntris %lu", (unsigned long)f.mesh.ntris);
    CHECK(t, tobj_vec_near(pds__mesh_pos(&f.mesh, f.mesh.idx[0]), pds__v(2, 5, 0), 1e-6), "P0 transformed");
    CHECK(t, tobj_vec_near(pds__mesh_pos(&f.mesh, f.mesh.idx[1]), pds__v(0, 6, 0), 1e-6), "P1 transformed");
    CHECK(t, tobj_vec_near(pds__mesh_pos(&f.mesh, f.mesh.idx[2]), pds__v(2, 5, 1), 1e-6), "P2 transformed");
    /* inverse transpose of diag(2,1,1) maps (1,1,0) to (1/2,1,0) */
    for (i = 0; i < 6; i++)
        CHECK(t, tobj_vec_near(pds__mesh_nrm(&f.mesh, f.mesh.idx[i]), want, 1e-6), "corner %lu normal (%g %g %g)",
              (unsigned long)i, pds__mesh_nrm(&f.mesh, f.mesh.idx[i]).x, pds__mesh_nrm(&f.mesh, f.mesh.idx[i]).y,
              pds__mesh_nrm(&f.mesh, f.mesh.idx[i]).z);
    remove(path);
    tobj_done(&f);

    /* a mirror keeps winding and shading normals on the same side */
    x = pds__xform_identity();
    x.m[0][0] = -1.0;
    tobj_init(&f);
    f.opt.xform = &x;
    REQUIRE(t, tobj_load_text(&f, "mirror.obj", text, path, sizeof path) == PDS_OK, "%s", f.err.text);
    REQUIRE(t, f.mesh.ntris == 2, "ntris %lu", (unsigned long)f.mesh.ntris);
    for (i = 0; i < 2; i++) {
        pds__v3 g = pds__normalize(tobj_tri_cross(&f.mesh, i));
        CHECK(t, tobj_vec_near(g, pds__normalize(pds__v(-1, 1, 0)), 1e-6), "mirrored winding normal %lu",
              (unsigned long)i);
        CHECK(t, tobj_vec_near(pds__mesh_nrm(&f.mesh, f.mesh.idx[3 * i]), g, 1e-6), "mirrored shading normal %lu",
              (unsigned long)i);
    }
    remove(path);
    tobj_done(&f);
}

/* -------------------------------------------------------------- materials */

static void test_obj_mtllib_two_files_and_subdirectory(pds_test_ctx *t)
{
    tobj_fix f;
    char dir[256], sub[300], obj[400], a[400], b[400], c[400];
    static const char text[] =
        "mtllib a.mtl sub/b.mtl\n"
        "mtllib my lib.mtl\n"
        "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
        "usemtl red\nf 1 2 3\n"
        "usemtl blue\nf 1 2 3\n"
        "usemtl spaced name\nf 1 2 3\n";
    tobj_path(dir, sizeof dir, "libdir");
    snprintf(sub, sizeof sub, "%s/sub", dir);
    mkdir(dir, 0700);
    mkdir(sub, 0700);
    snprintf(obj, sizeof obj, "%s/m.obj", dir);
    snprintf(a, sizeof a, "%s/a.mtl", dir);
    snprintf(b, sizeof b, "%s/b.mtl", sub);
    snprintf(c, sizeof c, "%s/my lib.mtl", dir);
    REQUIRE(t, tobj_write(obj, text) && tobj_write(a, "newmtl red\nKd 1 0 0\n") &&
                   tobj_write(b, "newmtl blue\nKd 0 0 1\n") && tobj_write(c, "newmtl spaced name\nKd 0 1 0\n"),
            "cannot write the files");
    tobj_init(&f);
    REQUIRE(t, pds__obj_load(obj, &f.mesh, &f.mats, &f.opt, &f.stats, &f.err) == PDS_OK, "%s", f.err.text);
    REQUIRE(t, f.mesh.ntris == 3 && f.mats.count == 4, "ntris %lu materials %lu", (unsigned long)f.mesh.ntris,
            (unsigned long)f.mats.count);
    CHECK(t, f.stats.mtl_materials == 3, "mtl_materials %d", f.stats.mtl_materials);
    CHECK(t, strcmp(f.mats.items[f.mesh.mat[0]].name, "red") == 0 && f.mats.items[f.mesh.mat[0]].albedo[0] == 1.0,
          "triangle 0 is not red");
    CHECK(t, strcmp(f.mats.items[f.mesh.mat[1]].name, "blue") == 0 && f.mats.items[f.mesh.mat[1]].albedo[2] == 1.0,
          "triangle 1 is not blue");
    CHECK(t, strcmp(f.mats.items[f.mesh.mat[2]].name, "spaced name") == 0 &&
                 f.mats.items[f.mesh.mat[2]].albedo[1] == 1.0,
          "triangle 2 is not 'spaced name'");
    tobj_done(&f);
    remove(obj);
    remove(a);
    remove(b);
    remove(c);
    rmdir(sub);
    rmdir(dir);
}

static void test_mtl_maps_each_kind(pds_test_ctx *t)
{
    tobj_fix f;
    char obj[256], mtl[256], text[2048], name[64];
    pds_material scene_mat = pds__material_default("taken");
    static const char *const names[] = {"lamp", "glass7", "glass_d", "glass4", "chrome", "paint",
                                        "plain", "alpha", "bright", "grey", "taken", "glass_tr",
                                        "glass_tf", "opaque_tr"};
    static const char mtl_text[] =
        "# one of each\n"
        "newmtl lamp\nKd 0.5 0.5 0.5\nKe 5 4 3\n"
        "newmtl glass7\nillum 7\nNi 1.33\nKd 0 0 0\n"
        "newmtl glass_d\nd 0.5\nNi 1.6\n"
        "newmtl glass4\nillum 4\n"
        "newmtl chrome\nillum 3\nKs 0.9 0.8 0.7\n"
        "newmtl paint\nillum 2\nKd 0.2 0.3 0.4\nKs 0.5 0.5 0.5\nNs 10\nKa 1 1 1\nmap_Kd paint.png\n"
        "newmtl plain\n"
        "newmtl alpha\nd 0.5\nNi 1.0\nKd 0.1 0.1 0.1\n"
        "newmtl bright\nKd 2\n"
        "newmtl grey\nKd 0.25\nKe 0 0 0\nTr 0\n"
        "newmtl taken\nKd 0 0 0\n"
        "newmtl glass_tr\nTr 0.5\nNi 1.45\n"
        "newmtl glass_tf\nTf 0.5 0.6 0.7\nNi 1.4\n"
        "newmtl opaque_tr\nd 1\nTr 1\nNi 1.5\nKd 0.3 0.3 0.3\n"; /* exporter writing Tr = d */
    int i, k;
    size_t len;
    tobj_init(&f);
    scene_mat.type = PDS_MAT_MIRROR;
    REQUIRE(t, pds__materials_add(&f.mats, &scene_mat) == 1, "setup");
    tobj_path(mtl, sizeof mtl, "kinds.mtl");
    REQUIRE(t, tobj_write(mtl, mtl_text), "cannot write %s", mtl);
    len = (size_t)snprintf(text, sizeof text, "mtllib %s\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", strrchr(mtl, '/') + 1);
    for (i = 0; i < 14; i++) len += (size_t)snprintf(text + len, sizeof text - len, "usemtl %s\nf 1 2 3\n", names[i]);
    REQUIRE(t, tobj_load_text(&f, "kinds.obj", text, obj, sizeof obj) == PDS_OK, "%s", f.err.text);
    REQUIRE(t, f.mesh.ntris == 14, "ntris %lu", (unsigned long)f.mesh.ntris);
    CHECK(t, f.stats.mtl_materials == 14, "mtl_materials %d", f.stats.mtl_materials);
    CHECK(t, f.mats.count == 2 + 13, "materials %lu: 'taken' must not be added again", (unsigned long)f.mats.count);
    for (i = 0; i < 14; i++) {
        snprintf(name, sizeof name, "%s", f.mats.items[f.mesh.mat[i]].name);
        CHECK(t, strcmp(name, names[i]) == 0, "triangle %d has material '%s', expected '%s'", i, name, names[i]);
    }
#define TOBJ_M(i) (&f.mats.items[f.mesh.mat[i]])
    CHECK(t, TOBJ_M(0)->type == PDS_MAT_EMISSIVE && TOBJ_M(0)->radiance[0] == 5 && TOBJ_M(0)->radiance[1] == 4 &&
                 TOBJ_M(0)->radiance[2] == 3,
          "lamp");
    CHECK(t, TOBJ_M(1)->type == PDS_MAT_DIELECTRIC && TOBJ_M(1)->ior == 1.33, "glass7 type %d ior %g",
          TOBJ_M(1)->type, TOBJ_M(1)->ior);
    CHECK(t, TOBJ_M(2)->type == PDS_MAT_DIELECTRIC && TOBJ_M(2)->ior == 1.6, "glass_d");
    CHECK(t, TOBJ_M(3)->type == PDS_MAT_DIELECTRIC && TOBJ_M(3)->ior == 1.5, "glass4 default ior");
    CHECK(t, TOBJ_M(4)->type == PDS_MAT_MIRROR && TOBJ_M(4)->reflectance[0] == 0.9 &&
                 TOBJ_M(4)->reflectance[1] == 0.8 && TOBJ_M(4)->reflectance[2] == 0.7,
          "chrome");
    CHECK(t, TOBJ_M(5)->type == PDS_MAT_DIFFUSE && TOBJ_M(5)->albedo[0] == 0.2 && TOBJ_M(5)->albedo[2] == 0.4,
          "paint");
    CHECK(t, TOBJ_M(6)->type == PDS_MAT_DIFFUSE && TOBJ_M(6)->albedo[1] == 0.8, "plain default albedo");
    CHECK(t, TOBJ_M(7)->type == PDS_MAT_DIFFUSE && TOBJ_M(7)->albedo[0] == 0.1, "alpha (d < 1, Ni 1) is diffuse");
    for (k = 0; k < 3; k++) CHECK(t, TOBJ_M(8)->albedo[k] == 1.0, "bright albedo[%d] = %g (clamped)", k, TOBJ_M(8)->albedo[k]);
    CHECK(t, TOBJ_M(9)->type == PDS_MAT_DIFFUSE && TOBJ_M(9)->albedo[2] == 0.25, "grey (Kd r alone)");
    CHECK(t, f.mesh.mat[10] == 1 && TOBJ_M(10)->type == PDS_MAT_MIRROR, "the scene's 'taken' wins");
    CHECK(t, TOBJ_M(11)->type == PDS_MAT_DIELECTRIC && TOBJ_M(11)->ior == 1.45, "glass_tr (Tr = 1 - d)");
    CHECK(t, TOBJ_M(12)->type == PDS_MAT_DIELECTRIC && TOBJ_M(12)->ior == 1.4, "glass_tf");
    CHECK(t, TOBJ_M(13)->type == PDS_MAT_DIFFUSE && TOBJ_M(13)->albedo[0] == 0.3, "opaque_tr: d wins over Tr");
#undef TOBJ_M
    remove(obj);
    remove(mtl);
    tobj_done(&f);
}

static void test_obj_unknown_usemtl_uses_default(pds_test_ctx *t)
{
    tobj_fix f;
    char path[256];
    pds_material other = pds__material_default("other");
    static const char text[] =
        "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
        "f 1 2 3\n"
        "usemtl nosuch\nf 1 2 3\n"
        "usemtl other\nf 1 2 3\n"
        "usemtl nosuch\nf 1 2 3\n";
    tobj_init(&f);
    pds__materials_add(&f.mats, &other);
    pds__materials_add(&f.mats, &other);
    pds__strlcpy(f.mats.items[2].name, "fallback", sizeof f.mats.items[2].name);
    f.opt.default_material = 2;
    REQUIRE(t, tobj_load_text(&f, "unk.obj", text, path, sizeof path) == PDS_OK, "%s", f.err.text);
    REQUIRE(t, f.mesh.ntris == 4, "ntris %lu", (unsigned long)f.mesh.ntris);
    CHECK(t, f.mesh.mat[0] == 2 && f.mesh.mat[1] == 2 && f.mesh.mat[2] == 1 && f.mesh.mat[3] == 2,
          "materials %d %d %d %d", f.mesh.mat[0], f.mesh.mat[1], f.mesh.mat[2], f.mesh.mat[3]);
    CHECK(t, f.stats.unknown_materials == 1, "unknown_materials %ld", f.stats.unknown_materials);
    CHECK(t, f.mats.count == 3, "materials %lu", (unsigned long)f.mats.count);
    remove(path);
    tobj_done(&f);
}

static void test_obj_material_overrides(pds_test_ctx *t)
{
    tobj_fix f;
    char obj[256], mtl[256], text[512];
    pds_material extra = pds__material_default("extra");
    static const char *const onames[] = {"red"};
    static const int omats[] = {1};
    tobj_path(mtl, sizeof mtl, "ovr.mtl");
    REQUIRE(t, tobj_write(mtl, "newmtl red\nKd 1 0 0\nnewmtl green\nKd 0 1 0\n"), "write");
    snprintf(text, sizeof text,
             "mtllib %s\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\nusemtl green\nf 1 2 3\n",
             strrchr(mtl, '/') + 1);

    /* everything overridden: no MTL material is added, but they are read */
    tobj_init(&f);
    pds__materials_add(&f.mats, &extra);
    f.opt.material_override = 1;
    REQUIRE(t, tobj_load_text(&f, "ovr.obj", text, obj, sizeof obj) == PDS_OK, "%s", f.err.text);
    CHECK(t, f.mesh.ntris == 2 && f.mesh.mat[0] == 1 && f.mesh.mat[1] == 1, "override: %d %d", f.mesh.mat[0],
          f.mesh.mat[1]);
    CHECK(t, f.mats.count == 2 && f.stats.mtl_materials == 2, "materials %lu, read %d", (unsigned long)f.mats.count,
          f.stats.mtl_materials);
    tobj_done(&f);

    /* per name: red -> scene material 1, green from the MTL */
    tobj_init(&f);
    pds__materials_add(&f.mats, &extra);
    f.opt.override_names = onames;
    f.opt.override_materials = omats;
    f.opt.override_count = 1;
    REQUIRE(t, tobj_load_text(&f, "ovr.obj", text, obj, sizeof obj) == PDS_OK, "%s", f.err.text);
    REQUIRE(t, f.mesh.ntris == 2, "ntris");
    CHECK(t, f.mesh.mat[0] == 1, "red overridden: %d", f.mesh.mat[0]);
    CHECK(t, strcmp(f.mats.items[f.mesh.mat[1]].name, "green") == 0, "green from the MTL");
    tobj_done(&f);

    /* the override must exist */
    tobj_init(&f);
    f.opt.material_override = 7;
    CHECK(t, pds__obj_load(obj, &f.mesh, &f.mats, &f.opt, NULL, &f.err) == PDS_ERR_INVALID_ARG, "bad override");
    tobj_done(&f);
    remove(obj);
    remove(mtl);
}

/* ---------------------------------------------------------------- errors */

/* Load text; expect failure with status st and text "PATH:" + suffix. */
static void tobj_expect_error(pds_test_ctx *t, const char *name, const char *text, pds_status st,
                              const char *suffix)
{
    tobj_fix f;
    char path[256], expect[1200];
    pds_status got;
    tobj_init(&f);
    got = tobj_load_text(&f, name, text, path, sizeof path);
    snprintf(expect, sizeof expect, "%s:%s", path, suffix);
    CHECK(t, got == st, "%s: status %d, expected %d", name, (int)got, (int)st);
    CHECK(t, strcmp(f.err.text, expect) == 0, "%s:\n  got      '%s'\n  expected '%s'", name, f.err.text, expect);
    CHECK(t, f.mesh.nverts == 0 && f.mesh.ntris == 0 && f.mats.count == 1, "%s: mesh not rolled back", name);
    remove(path);
    tobj_done(&f);
}

static void test_obj_errors_word_for_word(pds_test_ctx *t)
{
    tobj_fix f;
    char path[256], dir[256], expect[1200];
    tobj_expect_error(t, "e_zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 0 3\n", PDS_ERR_PARSE,
                      "4:5: face index 0 is invalid: OBJ indices start at 1");
    tobj_expect_error(t, "e_range.obj",
                      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 0\nv 1 0 0\nf 1 2 9\n",
                      PDS_ERR_PARSE, "9:7: face index 9 is out of range: 8 vertices defined so far");
    tobj_expect_error(t, "e_neg.obj", "v 0 0 0\nf -1 -2 -3\n", PDS_ERR_PARSE,
                      "2:6: face index -2 is out of range: 1 vertex defined so far");
    tobj_expect_error(t, "e_num.obj", "v 1 2 x\n", PDS_ERR_PARSE, "1:7: expected a number for 'v', got 'x'");
    tobj_expect_error(t, "e_nan.obj", "v 0 0 0\r\nvn 0 nan 1\n", PDS_ERR_PARSE, "2:6: 'nan' is not a finite number");
    tobj_expect_error(t, "e_inf.obj", "v 0 1e999 0\n", PDS_ERR_PARSE, "1:5: '1e999' is not a finite number");
    tobj_expect_error(t, "e_few.obj", "v 0 0\n", PDS_ERR_PARSE, "1:1: 'v' needs more numbers");
    tobj_expect_error(t, "e_two.obj", "v 0 0 0\nv 1 0 0\n\n  f 1 2\n", PDS_ERR_PARSE,
                      "4:3: a face needs at least 3 corners, got 2");
    tobj_expect_error(t, "e_corner.obj", "v 0 0 0\nf 1 1/x 1\n", PDS_ERR_PARSE,
                      "2:5: expected a vertex index like 7, 7/2, 7//3 or 7/2/3, got '1/x'");
    tobj_expect_error(t, "e_s.obj", "s maybe\n", PDS_ERR_PARSE,
                      "1:3: expected a smoothing group number or 'off' for 's', got 'maybe'");

    /* vt and vn indices out of range are dropped with a warning (the
       corner's normal is computed), as other importers do */
    {
        static const char *const texts[2] = {"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3/ \\\n 1/2\n",
                                             "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//2\n"};
        static const char *const names[2] = {"w_vt.obj", "w_vn.obj"};
        static const char *const where[2] = {":6:4: texture coordinate index 2 of 0", ":5:16: normal index 2 of 1"};
        int k;
        for (k = 0; k < 2; k++) {
            tobj_init(&f);
            CHECK(t, tobj_load_text(&f, names[k], texts[k], path, sizeof path) == PDS_OK && f.mesh.ntris == 1,
                  "%s: %s", names[k], f.err.text);
            CHECK(t, f.stats.bad_references == 1 && strstr(f.stats.bad_example, where[k]) != NULL, "%s: %ld, '%s'",
                  names[k], f.stats.bad_references, f.stats.bad_example);
            remove(path);
            tobj_done(&f);
        }
    }

    /* a missing mtllib is a warning (downloads often lack their .mtl): the
       OBJ loads, its usemtl takes the default, and the warning names the
       OBJ line and the path looked for */
    tobj_init(&f);
    f.err.text[0] = '\0';
    CHECK(t, tobj_load_text(&f, "e_mtl.obj", "# materials\nmtllib   missing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n",
                            path, sizeof path) == PDS_OK,
          "missing mtllib: %s", f.err.text);
    pds__dirname(path, dir, sizeof dir);
    snprintf(expect, sizeof expect, "%s:2:10: 'missing.mtl' (looked for %smissing.mtl)", path, dir);
    CHECK(t, f.stats.missing_mtl == 1 && strcmp(f.stats.missing_example, expect) == 0 && f.mesh.ntris == 1 &&
             f.mesh.mat[0] == 0,
          "got %ld: '%s'\n  expected '%s'", f.stats.missing_mtl, f.stats.missing_example, expect);
    remove(path);
    tobj_done(&f);

    /* an error inside an MTL file names the MTL file */
    {
        char mtl[256];
        tobj_path(mtl, sizeof mtl, "bad.mtl");
        REQUIRE(t, tobj_write(mtl, "newmtl a\nKd 0.5 zz 0.5\n"), "write");
        tobj_init(&f);
        snprintf(expect, sizeof expect, "mtllib %s\n", strrchr(mtl, '/') + 1);
        CHECK(t, tobj_load_text(&f, "e_badmtl.obj", expect, path, sizeof path) == PDS_ERR_PARSE, "bad mtl status");
        snprintf(expect, sizeof expect, "%s:2:8: expected a number for 'Kd', got 'zz'", mtl);
        CHECK(t, strcmp(f.err.text, expect) == 0, "got '%s'\n  expected '%s'", f.err.text, expect);
        remove(path);
        remove(mtl);
        tobj_done(&f);
    }

    /* missing OBJ */
    tobj_init(&f);
    tobj_path(path, sizeof path, "does_not_exist.obj");
    CHECK(t, pds__obj_load(path, &f.mesh, &f.mats, &f.opt, NULL, &f.err) == PDS_ERR_IO, "missing OBJ status");
    snprintf(expect, sizeof expect, "%s: cannot open: No such file or directory", path);
    CHECK(t, strcmp(f.err.text, expect) == 0, "got '%s'", f.err.text);
    tobj_done(&f);
}

static void test_obj_degenerate_triangles_dropped(pds_test_ctx *t)
{
    tobj_fix f;
    char path[256];
    static const char text[] =
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\n"
        "f 1 2 3\n"  /* collinear */
        "f 1 1 2\n"  /* repeated corner */
        "f 1 2 4\n"  /* fine */
        "f 1 2 4 2 1 4\n"; /* folds onto itself: 4 triangles, some degenerate */
    tobj_init(&f);
    REQUIRE(t, tobj_load_text(&f, "degen.obj", text, path, sizeof path) == PDS_OK, "%s", f.err.text);
    CHECK(t, f.stats.degenerate_dropped >= 2, "dropped %ld", f.stats.degenerate_dropped);
    CHECK(t, f.stats.degenerate_dropped == f.mesh.degenerate_dropped, "stats and mesh disagree");
    CHECK(t, f.stats.triangles + f.stats.degenerate_dropped == 1 + 1 + 1 + 4, "triangles %ld + dropped %ld",
          f.stats.triangles, f.stats.degenerate_dropped);
    CHECK(t, (long)f.mesh.ntris == f.stats.triangles, "ntris %lu", (unsigned long)f.mesh.ntris);
    remove(path);
    tobj_done(&f);

    /* exactly two dropped */
    tobj_init(&f);
    REQUIRE(t, tobj_load_text(&f, "degen2.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 1 2\nf 1 2 4\n",
                              path, sizeof path) == PDS_OK, "%s", f.err.text);
    CHECK(t, f.stats.degenerate_dropped == 2 && f.mesh.ntris == 1, "dropped %ld, kept %lu",
          f.stats.degenerate_dropped, (unsigned long)f.mesh.ntris);
    remove(path);
    tobj_done(&f);
}

/* Not timed (speed belongs to benchmarks): a 100 x 1000 quad grid. */
static void test_obj_loads_200k_triangles(pds_test_ctx *t)
{
    tobj_fix f;
    char path[256];
    FILE *fp;
    int i, j;
    const int nx = 1000, ny = 100;
    tobj_path(path, sizeof path, "big.obj");
    fp = fopen(path, "wb");
    REQUIRE(t, fp != NULL, "cannot write %s", path);
    for (j = 0; j <= ny; j++)
        for (i = 0; i <= nx; i++) fprintf(fp, "v %g %g %g\n", i * 0.01, j * 0.01, 0.001 * ((i * 7 + j * 3) % 5));
    fprintf(fp, "s 1\n");
    for (j = 0; j < ny; j++)
        for (i = 0; i < nx; i++) {
            int a = j * (nx + 1) + i + 1;
            fprintf(fp, "f %d %d %d %d\n", a, a + 1, a + nx + 2, a + nx + 1);
        }
    fclose(fp);
    tobj_init(&f);
    REQUIRE(t, pds__obj_load(path, &f.mesh, &f.mats, &f.opt, &f.stats, &f.err) == PDS_OK, "%s", f.err.text);
    CHECK(t, f.stats.vertices == (long)(nx + 1) * (ny + 1), "v %ld", f.stats.vertices);
    CHECK(t, f.stats.faces == (long)nx * ny, "faces %ld", f.stats.faces);
    CHECK(t, f.mesh.ntris == (size_t)2 * nx * ny, "ntris %lu", (unsigned long)f.mesh.ntris);
    CHECK(t, f.mesh.nverts == (size_t)(nx + 1) * (ny + 1), "nverts %lu", (unsigned long)f.mesh.nverts);
    CHECK(t, f.stats.degenerate_dropped == 0, "dropped %ld", f.stats.degenerate_dropped);
    remove(path);
    tobj_done(&f);
}


/* Twice the signed area of polygon (u, v)[0..n-1] (shoelace). */
static double tobj_shoelace2(const double *u, const double *v, int n)
{
    double a = 0.0;
    int i;
    for (i = 0; i < n; i++) a += u[i] * v[(i + 1) % n] - u[(i + 1) % n] * v[i];
    return a;
}

/* The sweep's triangles of hard simple polygons: every one counter-
   clockwise, n - 2 of them, adding up to the polygon's area (so none
   overlaps and none is missing). */
static void test_obj_sweep_triangulates_hard_polygons_to_their_area(pds_test_ctx *t)
{
    enum { MAX = 40000 };
    double *u = (double *)malloc(sizeof(double) * MAX), *v = (double *)malloc(sizeof(double) * MAX);
    int *tris = (int *)malloc(sizeof(int) * 3 * MAX), kind, i, n;
    static const char *const names[] = {"star", "random star-shaped", "comb", "ring bridged to its hole", "sawtooth"};
    REQUIRE(t, u && v && tris, "memory");
    for (kind = 0; kind < 5; kind++) {
        double want, got = 0.0;
        int r, negative = 0;
        n = 0;
        if (kind == 0)
            for (i = 0; i < 20000; i++, n++) {
                double a = 2.0 * PDS__PI * i / 20000, rad = i % 2 ? 0.5 : 1.0;
                u[n] = rad * cos(a);
                v[n] = rad * sin(a);
            }
        if (kind == 1)
            for (i = 0; i < 9001; i++, n++) {
                double a = 2.0 * PDS__PI * i / 9001, rad = 0.2 + pds__rng_uniform(5, 1, (uint64_t)i, 0);
                u[n] = rad * cos(a);
                v[n] = rad * sin(a);
            }
        if (kind == 2) { /* 3000 teeth standing on a bar */
            u[n] = 0.0, v[n++] = 0.0;
            u[n] = 6000.0, v[n++] = 0.0;
            for (i = 2999; i >= 0; i--) {
                double x = 2.0 * i;
                u[n] = x + 2.0, v[n++] = 10.0;
                u[n] = x + 1.5, v[n++] = 10.0;
                u[n] = x + 1.5, v[n++] = 1.0;
                u[n] = x + 0.5, v[n++] = 1.0;
                u[n] = x + 0.5, v[n++] = 10.0;
            }
            u[n] = 0.0, v[n++] = 10.0;
        }
        if (kind == 3) { /* outer circle, bridge, inner circle backwards, bridge back: positions repeat */
            for (i = 0; i <= 5000; i++, n++) u[n] = cos(2.0 * PDS__PI * i / 5000), v[n] = sin(2.0 * PDS__PI * i / 5000);
            for (i = 0; i <= 5000; i++, n++)
                u[n] = 0.5 * cos(-2.0 * PDS__PI * i / 5000), v[n] = 0.5 * sin(-2.0 * PDS__PI * i / 5000);
        }
        if (kind == 4) {
            for (i = 0; i < 3000; i++, n++) u[n] = i, v[n] = i % 2 ? 0.3 : 0.0;
            for (i = 2999; i >= 0; i--, n++) u[n] = i, v[n] = i % 2 ? 1.7 : 2.0;
        }
        r = pds__obj_triangulate_sweep(u, v, n, tris);
        CHECK(t, r == 1, "%s: the sweep gave up (%d)", names[kind], r);
        if (r != 1) continue;
        for (i = 0; i < n - 2; i++) {
            double o = pds__obj_orient(u, v, tris[3 * i], tris[3 * i + 1], tris[3 * i + 2]);
            negative += o < 0.0;
            got += o;
        }
        want = tobj_shoelace2(u, v, n);
        CHECK(t, negative == 0 && fabs(got - want) <= 1e-9 * fabs(want), "%s (%d corners): area %.12g of %.12g, %d clockwise",
              names[kind], n, got / 2, want / 2, negative);
    }
    free(u);
    free(v);
    free(tris);
}

/* A 100,000-corner face (a circle written with six decimals: ear
   clipping took 38 s on it) loads through the OBJ path as n - 2
   triangles covering the disc. */
static void test_obj_face_of_100000_corners_triangulates_to_its_area(pds_test_ctx *t)
{
    enum { N = 100000 };
    size_t cap = (size_t)N * 40 + 64, len = 0;
    char *text = (char *)malloc(cap), path[256];
    tobj_fix f;
    int i;
    double want = 0.0, got;
    REQUIRE(t, text != NULL, "memory");
    for (i = 0; i < N; i++) {
        double a = 2.0 * PDS__PI * i / N;
        len += (size_t)snprintf(text + len, cap - len, "v %.6f %.6f 0\n", cos(a), sin(a));
    }
    len += (size_t)snprintf(text + len, cap - len, "f");
    for (i = 1; i <= N; i++) len += (size_t)snprintf(text + len, cap - len, " %d", i);
    snprintf(text + len, cap - len, "\n");
    tobj_init(&f);
    REQUIRE(t, tobj_load_text(&f, "circle.obj", text, path, sizeof path) == PDS_OK, "load: %s", f.err.text);
    for (i = 0; i < N; i++) {
        pds__v3 p = pds__mesh_pos(&f.mesh, i), q = pds__mesh_pos(&f.mesh, (i + 1) % N);
        want += p.x * q.y - q.x * p.y;
    }
    want *= 0.5;
    got = tobj_total_area(&f.mesh);
    CHECK(t, (long)f.mesh.ntris + f.mesh.degenerate_dropped == N - 2, "%lu triangles + %ld dropped",
          (unsigned long)f.mesh.ntris, f.mesh.degenerate_dropped);
    CHECK(t, fabs(got - want) <= 1e-6 * want, "area %.9g, the polygon's %.9g", got, want);
    for (i = 0; (size_t)i < f.mesh.ntris; i++)
        if (tobj_tri_cross(&f.mesh, (size_t)i).z < 0.0) break;
    CHECK(t, (size_t)i == f.mesh.ntris, "triangle %d faces away from the face's normal", i);
    tobj_done(&f);
    remove(path);
    free(text);
}

static const pds_test_case tests_obj[] = {
    {"obj_reads_every_face_index_form", test_obj_index_forms},
    {"obj_negative_indices_count_back_from_the_last_element", test_obj_negative_indices},
    {"obj_quad_and_concave_polygons_triangulate_to_their_area", test_obj_polygons_triangulate},
    {"obj_sweep_triangulates_hard_polygons_to_their_area", test_obj_sweep_triangulates_hard_polygons_to_their_area},
    {"obj_face_of_100000_corners_triangulates_to_its_area", test_obj_face_of_100000_corners_triangulates_to_its_area},
    {"obj_crlf_tabs_bom_and_continuations_parse_like_a_clean_file", test_obj_messy_file_parses_like_clean},
    {"obj_unknown_statements_are_skipped_and_counted", test_obj_unknown_statements_are_counted},
    {"obj_cube_normals_are_smooth_by_default_and_flat_under_s_off", test_obj_cube_smooth_and_flat_normals},
    {"obj_given_normals_are_normalised_and_zero_ones_computed", test_obj_given_normals_are_normalised},
    {"obj_transform_moves_positions_and_normals_by_inverse_transpose", test_obj_transform_positions_and_normals},
    {"obj_mtllib_reads_several_files_subdirectories_and_spaced_names", test_obj_mtllib_two_files_and_subdirectory},
    {"mtl_materials_map_to_emissive_dielectric_mirror_diffuse", test_mtl_maps_each_kind},
    {"obj_unknown_usemtl_name_uses_the_default_material", test_obj_unknown_usemtl_uses_default},
    {"obj_material_override_and_per_name_overrides", test_obj_material_overrides},
    {"obj_errors_carry_file_line_column_word_for_word", test_obj_errors_word_for_word},
    {"obj_degenerate_triangles_are_dropped_and_counted", test_obj_degenerate_triangles_dropped},
    {"obj_loads_a_generated_200k_triangle_grid", test_obj_loads_200k_triangles},
};

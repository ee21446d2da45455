/* fuzz_scene.c - libFuzzer harness for the scene parser.

   The input is a scene file: written to in.scene in the harness's temporary
   directory and loaded with pds_scene_load, which parses it, generates the
   shapes, loads named meshes and builds the BVH. Beside it the harness puts
   octahedron.obj (the shipped scenes/octahedron.obj, for the shipped
   ring_octahedron.scene) and tri.obj with its tri.mtl, so that `mesh`
   statements, `replace` and MTL materials are reached, and inc.scene
   (variables and an include of tri.obj's scene use) for `include`; the
   load passes -D r=0.25 and -D name=red, so overrides are reached too;
   see fuzz.h for the guards on other paths and on memory.

   Seeds (corpus/scene): the shipped and golden scenes, the pool's and the
   refraction case's heightfields at 1/8 of their resolution (at full size
   each load took seconds under the sanitizers and slowed every mutation of
   them), and hand-written ones for every statement, number form, meshes,
   a byte order mark with CRLF, errors, include (nested, a cycle) and
   variables. */
#include "fuzz.h"

static const char pds_fuzz_octahedron[] =
    "o octahedron\n"
    "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n"
    "s off\n"
    "f 1 3 5\nf 5 3 2\nf 2 3 6\nf 6 3 1\nf 5 4 1\nf 2 4 5\nf 6 4 2\nf 1 4 6\n";
static const char pds_fuzz_tri_obj[] =
    "mtllib tri.mtl\n"
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
    "vn 0 0 1\n"
    "usemtl red\nf 1 2 3\n"
    "usemtl lamp\nf 2//1 4//1 3//1\n";
static const char pds_fuzz_inc_scene[] =
    "define r 0.5\n"
    "define name white\n"
    "material $name diffuse { albedo 0.5 }\n"
    "sphere { material $name radius $r segments 8 rings 4 }\n";
static const char pds_fuzz_tri_mtl[] =
    "newmtl red\nKd 1 0 0\n"
    "newmtl lamp\nKe 4 4 4\n";

int PDS_FUZZ_ENTRY(const uint8_t *data, size_t size)
{
    static int ready;
    char path[4096];
    pds_scene *scene = NULL;
    pds_error err;
    static const pds_define defines[2] = {{"r", "0.25"}, {"name", "red"}};
    pds_load_options lo;
    if (!ready) {
        pds_fuzz_write("octahedron.obj", pds_fuzz_octahedron, sizeof pds_fuzz_octahedron - 1, path);
        pds_fuzz_write("tri.obj", pds_fuzz_tri_obj, sizeof pds_fuzz_tri_obj - 1, path);
        pds_fuzz_write("tri.mtl", pds_fuzz_tri_mtl, sizeof pds_fuzz_tri_mtl - 1, path);
        pds_fuzz_write("inc.scene", pds_fuzz_inc_scene, sizeof pds_fuzz_inc_scene - 1, path);
        ready = 1;
    }
    pds_fuzz_write("in.scene", data, size, path);
    pds_load_options_default(&lo);
    lo.defines = defines;
    lo.define_count = 2;
    if (pds_scene_load_ex(path, &lo, &scene, &err) == PDS_OK) {
        pds_scene_info info;
        pds_ray ray;
        pds_hit hit;
        const pds_camera *cam = pds_scene_camera(scene);
        int i;
        pds_scene_get_info(scene, &info);
        for (i = 0; i < info.warnings; i++)
            if (!pds_scene_warning(scene, i)) abort();
        /* one ray from the camera through its target */
        ray.origin = cam->position;
        ray.dir.x = cam->look_at.x - cam->position.x;
        ray.dir.y = cam->look_at.y - cam->position.y;
        ray.dir.z = cam->look_at.z - cam->position.z;
        ray.tmin = 0.0;
        ray.tmax = 1e30;
        pds_scene_intersect(scene, &ray, &hit);
        pds_scene_free(scene);
    } else if (strlen(pds_error_string(&err)) >= sizeof err.text) {
        abort();
    }
    return 0;
}

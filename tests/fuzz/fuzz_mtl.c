/* fuzz_mtl.c - libFuzzer harness for the MTL reader.

   The input is an MTL file, written to in.mtl; a fixed OBJ beside it
   (m.obj: `mtllib in.mtl` and two triangles that use materials `a` and `b`)
   is loaded with pds_scene_load_obj, so the MTL is read, mapped to PDS
   materials and looked up by name exactly as for any OBJ. */
#include "fuzz.h"

static const char pds_fuzz_obj[] =
    "mtllib in.mtl\n"
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
    "usemtl a\nf 1 2 3\n"
    "usemtl b\nf 2 4 3\n";

int PDS_FUZZ_ENTRY(const uint8_t *data, size_t size)
{
    static int ready;
    char obj_path[4096], path[4096];
    pds_scene *scene = NULL;
    pds_error err;
    if (!ready) {
        pds_fuzz_write("m.obj", pds_fuzz_obj, sizeof pds_fuzz_obj - 1, obj_path);
        ready = 1;
    }
    pds_fuzz_write("in.mtl", data, size, path);
    pds_fuzz_path("m.obj", obj_path);
    if (pds_scene_load_obj(obj_path, &scene, &err) == PDS_OK) {
        int i;
        for (i = 0; pds_scene_material(scene, i); i++) {
            const pds_material *m = pds_scene_material(scene, i);
            if (memchr(m->name, '\0', sizeof m->name) == NULL) abort();
        }
        pds_scene_free(scene);
    }
    return 0;
}

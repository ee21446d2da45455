/* fuzz_obj.c - libFuzzer harness for the OBJ loader.

   The input is an OBJ file, optionally followed by an MTL file: everything
   after the first line that is exactly "#MTL" goes to in.mtl (which the OBJ
   part can read with `mtllib in.mtl`); the line itself is an OBJ comment, so
   a plain OBJ file is an input as it is. The OBJ part is written to in.obj
   and loaded as `pds render in.obj` loads it (pds_scene_load_ex: in the
   studio, which also builds the scene's BVH).
   Without the separator in.mtl does not exist. See fuzz.h for the guard on
   paths outside the temporary directory. */
#include "fuzz.h"

/* Offset of the "#MTL" line's first byte, or size if there is none; *mtl
   gets the offset just past that line. */
static size_t pds_fuzz_split(const uint8_t *data, size_t size, size_t *mtl)
{
    static const char sep[] = "#MTL";
    size_t i = 0, n = sizeof sep - 1;
    while (i < size) {
        size_t end = i;
        while (end < size && data[end] != '\n') end++;
        if (end - i == n && memcmp(data + i, sep, n) == 0) {
            *mtl = end < size ? end + 1 : end;
            return i;
        }
        i = end + 1;
    }
    *mtl = size;
    return size;
}

int PDS_FUZZ_ENTRY(const uint8_t *data, size_t size)
{
    char path[4096], mtl_path[4096];
    size_t mtl, cut = pds_fuzz_split(data, size, &mtl);
    pds_scene *scene = NULL;
    pds_error err;
    pds_load_options lo;
    if (cut < size) pds_fuzz_write("in.mtl", data + mtl, size - mtl, mtl_path);
    else remove(pds_fuzz_path("in.mtl", mtl_path));
    pds_fuzz_write("in.obj", data, cut, path);
    /* as `pds render x.obj` loads it: in the studio, with a material the
       input's length chooses (the studio's text is parsed for every one) */
    pds_load_options_default(&lo);
    lo.obj_material = (pds_obj_material)(size % 4);
    if (pds_scene_load_ex(path, &lo, &scene, &err) == PDS_OK) {
        pds_scene_info info;
        pds_scene_get_info(scene, &info);
        if (info.materials < 1) abort();
        pds_scene_free(scene);
    }
    return 0;
}

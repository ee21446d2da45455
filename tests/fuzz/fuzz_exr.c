/* fuzz_exr.c - libFuzzer harness for the OpenEXR reader (and its inflate
   decoder).

   The input is an OpenEXR file, written to in.exr and read with
   pds_image_read_exr. A successful read must give a non-empty image of
   finite values, every float of which the harness touches (so ASan checks
   the whole allocation), and metadata entries that pds_image_meta_set
   would accept; a failed one must leave the image and the metadata
   empty. */
#include "fuzz.h"

static pds_image_meta pds_fuzz_meta;  /* 26 KB: not on the stack */

int PDS_FUZZ_ENTRY(const uint8_t *data, size_t size)
{
    char path[4096];
    pds_image img;
    pds_error err;
    pds_fuzz_write("in.exr", data, size, path);
    if (pds_image_read_exr(path, &img, &pds_fuzz_meta, &err) == PDS_OK) {
        size_t i, n;
        int k;
        if (img.width < 1 || img.height < 1 || !img.rgb) abort();
        n = (size_t)img.width * (size_t)img.height * 3;
        for (i = 0; i < n; i++) {
            if (!(img.rgb[i] - img.rgb[i] == 0.0f)) abort(); /* NaN or infinity */
            pds_fuzz_sink = img.rgb[i];
        }
        if (pds_fuzz_meta.count < 0 || pds_fuzz_meta.count > PDS_IMAGE_META_MAX) abort();
        for (k = 0; k < pds_fuzz_meta.count; k++)
            if (!pds__meta_key_ok(pds_fuzz_meta.key[k]) ||
                !pds__meta_value_ok(pds_fuzz_meta.value[k], strlen(pds_fuzz_meta.value[k])))
                abort();
        pds_image_free(&img);
    } else if (img.rgb || img.width || img.height || pds_fuzz_meta.count != 0) {
        abort();
    }
    return 0;
}

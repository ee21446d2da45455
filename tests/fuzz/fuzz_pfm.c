/* fuzz_pfm.c - libFuzzer harness for the PFM reader.

   The input is a PFM file, written to in.pfm and read with
   pds_image_read_pfm. A successful read must give a non-empty image whose
   every float the harness touches (so ASan checks the whole allocation);
   a failed one must leave the image empty. */
#include "fuzz.h"


int PDS_FUZZ_ENTRY(const uint8_t *data, size_t size)
{
    char path[4096];
    pds_image img;
    pds_error err;
    pds_fuzz_write("in.pfm", data, size, path);
    if (pds_image_read_pfm(path, &img, &err) == PDS_OK) {
        size_t i, n;
        if (img.width < 1 || img.height < 1 || !img.rgb) abort();
        n = (size_t)img.width * (size_t)img.height * 3;
        for (i = 0; i < n; i++) pds_fuzz_sink = img.rgb[i];
        pds_image_free(&img);
    } else if (img.rgb || img.width || img.height) {
        abort();
    }
    return 0;
}

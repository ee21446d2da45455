/* fuzz_partial.c - libFuzzer harness for the partial file reader.

   The input is a partial file (.pdsp), written to in.pdsp and read with
   pds_partial_read. Random bytes rarely survive the file's check sum, so
   the harness first writes the right check sum into the last 8 bytes (of
   an input long enough to have a header): the fuzzer then reaches the
   header checks and the decoding behind them. A successful read must give
   a part whose image can be made (pds_partial_merge of the one part, as
   pds render does) and whose every float the harness touches; a failed
   one must leave *out NULL. */
#include "fuzz.h"


int PDS_FUZZ_ENTRY(const uint8_t *data, size_t size)
{
    char path[4096];
    pds_partial *part = (pds_partial *)1;
    pds_error err;
    uint8_t *copy = (uint8_t *)malloc(size ? size : 1);
    if (!copy) return 0;
    memcpy(copy, data, size);
    if (size >= PDS__PARTIAL_HEADER_AT(PDS__PARTIAL_NOPT_V2) + 8u) /* the shortest header read: version 2's */
        pds__put_u64(copy + size - 8, pds__fnv1a64(copy, size - 8));
    pds_fuzz_write("in.pdsp", copy, size, path);
    free(copy);
    if (pds_partial_read(path, &part, &err) == PDS_OK) {
        const pds_partial *parts[1];
        pds_image img = {0, 0, NULL};
        if (!part) abort();
        parts[0] = part;
        if (pds_partial_merge(parts, NULL, 1, 1, &img, NULL, &err) == PDS_OK) {
            size_t i, n = (size_t)img.width * (size_t)img.height * 3;
            for (i = 0; i < n; i++) pds_fuzz_sink = img.rgb[i];
            pds_image_free(&img);
        }
        pds_partial_free(part);
    } else if (part) {
        abort();
    }
    return 0;
}

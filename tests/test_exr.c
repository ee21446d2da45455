/* tests/test_exr.c - OpenEXR files, the inflate decoder, image metadata
   (EXR attributes, PNG tEXt, the PFM trailer), reference kinds and the
   PNG tone curves.

   The EXR writer's files are taken apart byte by byte here against the
   OpenEXR file layout, and their ZIP blocks decoded with the independent
   inflater of test_image.c (timg_zlib_inflate) and an independent undoing
   of the split and predictor; the reader is fed files built by hand (half
   channels, extra channels, an offset data window) and broken files. The
   inflate decoder is checked on a stream made by another encoder (Python's
   zlib) and on every stream pds__deflate makes of the deflate tests'
   data. tests/check_exr_oiio.sh checks the files with OpenImageIO. */

/* ------------------------------------------------------------ helpers */

static uint32_t texr_u32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* A test image with awkward values: negative zero, a subnormal, the
   largest float, tiny and huge, and an odd size (ZIP's last block has 5
   lines). */
static void texr_image(pds_image *img)
{
    int i, n;
    pds_image_alloc(img, 37, 21);
    n = 37 * 21 * 3;
    for (i = 0; i < n; i++) img->rgb[i] = (float)((i * 7919) % 1000) / 250.0f;
    img->rgb[0] = -0.0f;
    img->rgb[1] = pds__bits_float(1u); /* the smallest subnormal */
    img->rgb[2] = FLT_MAX;
    img->rgb[3] = 1e-30f;
    img->rgb[4] = -3.5f;
    for (i = 0; i < 37 * 3; i++) img->rgb[5 * 37 * 3 + i] = 0.25f; /* a flat row: compresses */
}

static int texr_same_bits(const pds_image *a, const pds_image *b)
{
    return a->width == b->width && a->height == b->height &&
           memcmp(a->rgb, b->rgb, (size_t)a->width * (size_t)a->height * 12) == 0;
}

static void texr_meta(pds_image_meta *m)
{
    memset(m, 0, sizeof *m);
    pds_image_meta_set(m, PDS_META_KIND, PDS_META_KIND_CAUSTICS);
    pds_image_meta_set(m, PDS_META_METHOD, "pds");
    pds_image_meta_set(m, "pds:options", "paths=caustics-only spp=4 smoothing=12");
    /* longer than 31 bytes: needs the long-names flag */
    pds_image_meta_set(m, "pds:a-key-longer-than-thirty-one-bytes", "x");
}

/* ------------------------------------------------------------- EXR out */

static void test_exr_round_trip_is_bit_exact_for_every_compression(pds_test_ctx *t)
{
    static const pds_exr_compression comps[3] = {PDS_EXR_NONE, PDS_EXR_ZIPS, PDS_EXR_ZIP};
    pds_image img, back;
    pds_image_meta meta, got;
    pds_error err;
    char path[256];
    int c;
    texr_image(&img);
    texr_meta(&meta);
    timg_path(path, sizeof path, "round.exr");
    for (c = 0; c < 3; c++) {
        pds_status st = pds_image_write_exr(path, &img, comps[c], &meta, &err);
        CHECK(t, st == PDS_OK, "compression %d: write: %s", (int)comps[c], err.text);
        st = pds_image_read(path, &back, &got, &err);
        REQUIRE(t, st == PDS_OK, "compression %d: read: %s", (int)comps[c], err.text);
        CHECK(t, texr_same_bits(&img, &back), "compression %d: pixels differ", (int)comps[c]);
        CHECK(t, got.count == meta.count, "compression %d: %d metadata entries of %d", (int)comps[c], got.count,
              meta.count);
        CHECK(t, pds_image_meta_get(&got, PDS_META_KIND) && !strcmp(pds_image_meta_get(&got, PDS_META_KIND),
                                                                     PDS_META_KIND_CAUSTICS),
              "compression %d: kind", (int)comps[c]);
        CHECK(t, pds_image_meta_get(&got, "pds:a-key-longer-than-thirty-one-bytes") != NULL,
              "compression %d: long key", (int)comps[c]);
        pds_image_free(&back);
    }
    /* pds_image_write picks EXR by the extension, ZIP by default */
    CHECK(t, pds_image_write(path, &img, 0.0, &err) == PDS_OK, "write by extension: %s", err.text);
    CHECK(t, pds_image_read_exr(path, &back, NULL, &err) == PDS_OK && texr_same_bits(&img, &back),
          "read after write by extension");
    pds_image_free(&back);
    remove(path);
    pds_image_free(&img);
}

/* Undo EXR's ZIP steps, written from the description: the predictor
   first (each byte plus the previous decoded one, minus 128), then the
   two halves interleaved. */
static void texr_unzip_steps(const unsigned char *in, size_t n, unsigned char *out)
{
    unsigned char *d = (unsigned char *)malloc(n);
    size_t i, half = (n + 1) / 2;
    if (!d) return;
    for (i = 0; i < n; i++) d[i] = i == 0 ? in[0] : (unsigned char)(d[i - 1] + in[i] - 128);
    for (i = 0; i < half; i++) out[2 * i] = d[i];
    for (i = 0; i + half < n; i++) out[2 * i + 1] = d[half + i];
    free(d);
}

/* Walk the file as the layout says and check every field; the blocks'
   values are compared with the image (channels B, G, R per line). */
static void texr_check_layout(pds_test_ctx *t, const char *path, const pds_image *img, int compression)
{
    size_t n, pos = 8, lines = compression == 3 ? 16 : 1, nblocks, b;
    unsigned char *f = timg_read_bytes(path, &n);
    int seen = 0, raw_blocks = 0;
    REQUIRE(t, f != NULL, "read %s", path);
    CHECK(t, n > 8 && f[0] == 0x76 && f[1] == 0x2f && f[2] == 0x31 && f[3] == 0x01, "magic");
    CHECK(t, f[4] == 2 && f[6] == 0 && f[7] == 0, "version 2, single-part scanline");
    while (pos < n && f[pos] != 0) {
        const char *name = (const char *)f + pos, *type;
        uint32_t size;
        pos += strlen(name) + 1;
        type = (const char *)f + pos;
        pos += strlen(type) + 1;
        size = texr_u32(f + pos);
        pos += 4;
        if (!strcmp(name, "channels")) {
            static const unsigned char want[55] = {'B', 0, 2, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0,
                                                   'G', 0, 2, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0,
                                                   'R', 0, 2, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0};
            CHECK(t, !strcmp(type, "chlist") && size == 55 && !memcmp(f + pos, want, 55), "channels B, G, R float");
            seen |= 1;
        } else if (!strcmp(name, "compression")) {
            CHECK(t, !strcmp(type, "compression") && size == 1 && f[pos] == compression, "compression");
            seen |= 2;
        } else if (!strcmp(name, "dataWindow") || !strcmp(name, "displayWindow")) {
            CHECK(t, !strcmp(type, "box2i") && size == 16 && texr_u32(f + pos) == 0 && texr_u32(f + pos + 4) == 0 &&
                     texr_u32(f + pos + 8) == (uint32_t)img->width - 1 &&
                     texr_u32(f + pos + 12) == (uint32_t)img->height - 1, "%s", name);
            seen |= name[1] == 'a' ? 4 : 8;
        } else if (!strcmp(name, "lineOrder")) {
            CHECK(t, !strcmp(type, "lineOrder") && size == 1 && f[pos] == 0, "lineOrder increasing y");
            seen |= 16;
        } else if (!strcmp(name, "pixelAspectRatio")) {
            CHECK(t, !strcmp(type, "float") && size == 4 && texr_u32(f + pos) == timg_bits(1.0f), "aspect 1");
            seen |= 32;
        } else if (!strcmp(name, "screenWindowCenter")) {
            CHECK(t, !strcmp(type, "v2f") && size == 8 && texr_u32(f + pos) == 0 && texr_u32(f + pos + 4) == 0,
                  "screen window centre");
            seen |= 64;
        } else if (!strcmp(name, "screenWindowWidth")) {
            CHECK(t, !strcmp(type, "float") && size == 4 && texr_u32(f + pos) == timg_bits(1.0f), "screen width");
            seen |= 128;
        } else {
            CHECK(t, !strcmp(type, "string"), "metadata '%s' is a string attribute", name);
        }
        pos += size;
    }
    CHECK(t, seen == 255, "the eight required attributes (mask %d)", seen);
    pos++;
    nblocks = ((size_t)img->height + lines - 1) / lines;
    for (b = 0; b < nblocks && pos + 8 * nblocks <= n; b++) {
        size_t off = (size_t)texr_u32(f + pos + 8 * b), y0 = b * lines, nl, want, y, x;
        uint32_t ds;
        unsigned char *raw;
        CHECK(t, texr_u32(f + pos + 8 * b + 4) == 0 && off + 8 <= n, "block %lu offset", (unsigned long)b);
        if (off + 8 > n) break;
        nl = (size_t)img->height - y0 < lines ? (size_t)img->height - y0 : lines;
        want = nl * (size_t)img->width * 12;
        CHECK(t, texr_u32(f + off) == y0, "block %lu starts at line %lu", (unsigned long)b, (unsigned long)y0);
        ds = texr_u32(f + off + 4);
        CHECK(t, off + 8 + ds <= n, "block %lu size", (unsigned long)b);
        if (off + 8 + ds > n) break;
        raw = (unsigned char *)malloc(want);
        REQUIRE(t, raw != NULL, "malloc");
        if (ds == want) {
            memcpy(raw, f + off + 8, want);
            raw_blocks++;
        } else {
            tinf s;
            unsigned char *z = (unsigned char *)malloc(want);
            const char *why = z ? timg_zlib_inflate(f + off + 8, ds, z, want, &s) : "malloc";
            CHECK(t, compression != 0, "an uncompressed file holds a block of another size");
            CHECK(t, why == NULL && s.len == want, "block %lu: %s", (unsigned long)b, why ? why : "short");
            if (z) texr_unzip_steps(z, want, raw);
            free(z);
        }
        for (y = 0; y < nl; y++)
            for (x = 0; x < (size_t)img->width * 3; x++) {
                size_t c = x / (size_t)img->width, px = x % (size_t)img->width; /* c: 0 B, 1 G, 2 R */
                uint32_t v = texr_u32(raw + (y * (size_t)img->width * 3 + x) * 4);
                CHECK(t, v == timg_bits(img->rgb[((y0 + y) * (size_t)img->width + px) * 3 + 2 - c]),
                      "block %lu line %lu value %lu", (unsigned long)b, (unsigned long)y, (unsigned long)x);
            }
        free(raw);
    }
    if (compression == 0) CHECK(t, raw_blocks == (int)nblocks, "every block raw");
    else CHECK(t, raw_blocks < (int)nblocks, "some blocks compressed");
    free(f);
}

static void test_exr_files_follow_the_openexr_layout(pds_test_ctx *t)
{
    pds_image img;
    pds_image_meta meta;
    pds_error err;
    char path[256];
    texr_image(&img);
    texr_meta(&meta);
    timg_path(path, sizeof path, "layout.exr");
    CHECK(t, pds_image_write_exr(path, &img, PDS_EXR_NONE, &meta, &err) == PDS_OK, "write: %s", err.text);
    texr_check_layout(t, path, &img, 0);
    CHECK(t, pds_image_write_exr(path, &img, PDS_EXR_ZIP, &meta, &err) == PDS_OK, "write: %s", err.text);
    texr_check_layout(t, path, &img, 3);
    CHECK(t, pds_image_write_exr(path, &img, PDS_EXR_ZIPS, NULL, &err) == PDS_OK, "write: %s", err.text);
    texr_check_layout(t, path, &img, 2);
    remove(path);
    pds_image_free(&img);
}

/* The split and predictor on bytes worked out by hand: 10 20 30 40 50 is
   split into 10 30 50 | 20 40, then each byte from the second becomes
   byte - previous + 128 (mod 256). */
static void test_exr_zip_steps_match_hand_computed_bytes(pds_test_ctx *t)
{
    static const unsigned char raw[5] = {10, 20, 30, 40, 50};
    static const unsigned char want[5] = {10, 148, 148, 98, 148};
    unsigned char tmp[5], back[5], big[1001], bt[1001], bb[1001];
    size_t i;
    pds__exr_zip_prepare(raw, 5, tmp);
    CHECK(t, !memcmp(tmp, want, 5), "prepared %d %d %d %d %d", tmp[0], tmp[1], tmp[2], tmp[3], tmp[4]);
    pds__exr_zip_undo(tmp, 5, back);
    CHECK(t, !memcmp(back, raw, 5), "undone");
    for (i = 0; i < sizeof big; i++) big[i] = (unsigned char)(i * 131 + (i >> 3));
    pds__exr_zip_prepare(big, sizeof big, bt);
    texr_unzip_steps(bt, sizeof big, bb);
    CHECK(t, !memcmp(bb, big, sizeof big), "an independent undo of 1001 bytes");
}

/* ------------------------------------------------------------- EXR in */

/* A hand-made EXR: channels A, B, G, R as half (A first: one the reader
   skips), data window (10, 5)-(12, 6), uncompressed, string "comments". */
static size_t texr_build_half(unsigned char *f, int tiled, int compression, int with_b)
{
    size_t p = 0, table, k;
    const char *names = with_b ? "ABGR" : "AGRY";
    unsigned char *w;
    int y, c, x;
    /* half bits for the values of (x, y, channel) */
    static const unsigned short vals[4] = {0x3c00 /* 1 */, 0x3800 /* 0.5 */, 0xc000 /* -2 */, 0x0001 /* 2^-24 */};
    memcpy(f, "\x76\x2f\x31\x01\x02\x00\x00\x00", 8);
    if (tiled) f[5] = 0x02;
    p = 8;
#define TEXR_ATTR(name, type, size)                   \
    do {                                              \
        memcpy(f + p, name, strlen(name) + 1);        \
        p += strlen(name) + 1;                        \
        memcpy(f + p, type, strlen(type) + 1);        \
        p += strlen(type) + 1;                        \
        timg_put_le(f + p, (uint32_t)(size));         \
        p += 4;                                       \
    } while (0)
    TEXR_ATTR("channels", "chlist", 4 * 18 + 1);
    for (c = 0; c < 4; c++) {
        f[p] = (unsigned char)names[c];
        f[p + 1] = 0;
        timg_put_le(f + p + 2, 1); /* HALF */
        timg_put_le(f + p + 6, 0);
        timg_put_le(f + p + 10, 1);
        timg_put_le(f + p + 14, 1);
        p += 18;
    }
    f[p++] = 0;
    TEXR_ATTR("compression", "compression", 1);
    f[p++] = (unsigned char)compression;
    TEXR_ATTR("dataWindow", "box2i", 16);
    timg_put_le(f + p, 10);
    timg_put_le(f + p + 4, 5);
    timg_put_le(f + p + 8, 12);
    timg_put_le(f + p + 12, 6);
    p += 16;
    TEXR_ATTR("comments", "string", 5);
    memcpy(f + p, "hello", 5);
    p += 5;
#undef TEXR_ATTR
    f[p++] = 0;
    table = p;
    p += 16; /* two blocks of one line */
    for (y = 0; y < 2; y++) {
        for (k = 0; k < 8; k++) f[table + 8 * (size_t)y + k] = (unsigned char)(k == 0 ? p & 0xff : k == 1 ? p >> 8 : 0);
        timg_put_le(f + p, (uint32_t)(5 + y));
        timg_put_le(f + p + 4, 4 * 3 * 2);
        w = f + p + 8;
        for (c = 0; c < 4; c++)
            for (x = 0; x < 3; x++) {
                unsigned short h = vals[(x + y + c) % 4];
                w[0] = (unsigned char)(h & 0xff);
                w[1] = (unsigned char)(h >> 8);
                w += 2;
            }
        p += 8 + 24;
    }
    return p;
}

static void test_exr_reader_takes_half_channels_offset_windows_and_grey(pds_test_ctx *t)
{
    static const float vals[4] = {1.0f, 0.5f, -2.0f, 5.9604644775390625e-08f};
    unsigned char f[1024];
    char path[256];
    pds_image img;
    pds_image_meta meta;
    pds_error err;
    int x, y;
    size_t n = texr_build_half(f, 0, 0, 1);
    timg_path(path, sizeof path, "half.exr");
    REQUIRE(t, timg_write_bytes(path, f, n), "write %s", path);
    REQUIRE(t, pds_image_read(path, &img, &meta, &err) == PDS_OK, "read: %s", err.text);
    CHECK(t, img.width == 3 && img.height == 2, "size %dx%d", img.width, img.height);
    for (y = 0; y < 2; y++)
        for (x = 0; x < 3; x++) {
            /* channel order in the file: A 0, B 1, G 2, R 3 */
            const float *px = img.rgb + (y * 3 + x) * 3;
            CHECK(t, px[0] == vals[(x + y + 3) % 4] && px[1] == vals[(x + y + 2) % 4] && px[2] == vals[(x + y + 1) % 4],
                  "pixel (%d, %d) = %g %g %g", x, y, px[0], px[1], px[2]);
        }
    CHECK(t, pds_image_meta_get(&meta, "comments") && !strcmp(pds_image_meta_get(&meta, "comments"), "hello"),
          "string attribute");
    pds_image_free(&img);
    /* A, G, R, Y: no B, so the grey channel Y is read */
    n = texr_build_half(f, 0, 0, 0);
    REQUIRE(t, timg_write_bytes(path, f, n), "write %s", path);
    REQUIRE(t, pds_image_read_exr(path, &img, NULL, &err) == PDS_OK, "read grey: %s", err.text);
    for (y = 0; y < 2; y++)
        for (x = 0; x < 3; x++) {
            const float *px = img.rgb + (y * 3 + x) * 3;
            CHECK(t, px[0] == vals[(x + y + 3) % 4] && px[1] == px[0] && px[2] == px[0], "grey pixel (%d, %d)", x, y);
        }
    pds_image_free(&img);
    remove(path);
}

/* A layered file written by oiiotool (half, ZIP; committed as a fuzzing
   seed): channels AO.R, AO.G, AO.B, Depth.Z and ViewLayer.Combined.R, .G,
   .B, .A, constant 0.1, 0.2, 0.3, 9 and 0.5, 0.6, 0.7, 1. The reader takes
   the Combined layer, as Blender's multilayer files name the image. */
static void test_exr_reader_takes_the_combined_layer(pds_test_ctx *t)
{
    pds_image img;
    pds_error err;
    int i;
    REQUIRE(t, pds_image_read("tests/fuzz/corpus/exr/oiio-layers-half-zip.exr", &img, NULL, &err) == PDS_OK,
            "read: %s", err.text);
    CHECK(t, img.width == 4 && img.height == 3, "size %dx%d", img.width, img.height);
    for (i = 0; i < 12; i++)
        CHECK(t, img.rgb[3 * i] == 0.5f && img.rgb[3 * i + 1] == pds__half_to_float(0x38cd) &&
                 img.rgb[3 * i + 2] == pds__half_to_float(0x399a),
              "pixel %d: %g %g %g (half 0.6 = %g, 0.7 = %g)", i, img.rgb[3 * i], img.rgb[3 * i + 1],
              img.rgb[3 * i + 2], pds__half_to_float(0x38cd), pds__half_to_float(0x399a));
    pds_image_free(&img);
}

static void test_half_to_float_known_values(pds_test_ctx *t)
{
    CHECK(t, pds__half_to_float(0x3c00) == 1.0f, "1");
    CHECK(t, pds__half_to_float(0xc000) == -2.0f, "-2");
    CHECK(t, pds__half_to_float(0x7bff) == 65504.0f, "largest half");
    CHECK(t, pds__half_to_float(0x0400) == 6.103515625e-05f, "smallest normal 2^-14");
    CHECK(t, pds__half_to_float(0x0001) == 5.9604644775390625e-08f, "smallest subnormal 2^-24");
    CHECK(t, pds__half_to_float(0x3555) == 0.333251953125f, "0x3555");
    CHECK(t, timg_bits(pds__half_to_float(0x8000)) == 0x80000000u, "negative zero");
    CHECK(t, timg_bits(pds__half_to_float(0x7c00)) == 0x7f800000u, "infinity");
    CHECK(t, pds__half_to_float(0x7e00) != pds__half_to_float(0x7e00), "NaN");
}

/* Reading f[0..n) must fail with a message holding the path and want. */
static void texr_expect_bad(pds_test_ctx *t, const char *what, const unsigned char *f, size_t n, const char *want)
{
    char path[256];
    pds_image img;
    pds_image_meta meta;
    pds_error err;
    pds_status st;
    timg_path(path, sizeof path, "bad.exr");
    if (!timg_write_bytes(path, f, n)) {
        CHECK(t, 0, "%s: cannot write the test file", what);
        return;
    }
    memset(&err, 0, sizeof err);
    st = pds_image_read_exr(path, &img, &meta, &err);
    CHECK(t, st != PDS_OK, "%s: accepted", what);
    CHECK(t, img.rgb == NULL && img.width == 0 && meta.count == 0, "%s: image or metadata left behind", what);
    CHECK(t, strncmp(err.text, path, strlen(path)) == 0 && strstr(err.text, want) != NULL, "%s: message '%s'",
          what, err.text);
    remove(path);
}

static void test_exr_reader_rejects_bad_files_with_the_reason(pds_test_ctx *t)
{
    unsigned char f[1024], g[1024];
    pds_image img;
    char path[256];
    pds_error err;
    size_t n = texr_build_half(f, 0, 0, 1), zn, k;
    texr_expect_bad(t, "truncated header", f, 20, "cut short");
    texr_expect_bad(t, "truncated channel list", f, 40, "size of 73 bytes, past the end of the file");
    texr_expect_bad(t, "truncated block", f, n - 3, "past the end of the file");
    memcpy(g, f, n);
    g[5] = 0x02;
    texr_expect_bad(t, "tiled", g, n, "tiled");
    memcpy(g, f, n);
    g[5] = 0x10;
    texr_expect_bad(t, "multi-part", g, n, "multi-part");
    n = texr_build_half(f, 0, 4, 1);
    texr_expect_bad(t, "PIZ", f, n, "compression PIZ is not supported");
    n = texr_build_half(f, 0, 0, 1);
    memcpy(g, f, n);
    g[8 + 9 + 7 + 4] = 'X'; /* channel A -> X: still fine; B -> X below */
    g[8 + 9 + 7 + 4 + 18] = 'X';
    texr_expect_bad(t, "no B channel", g, n, "no R, G, B (or Y, or LAYER.R, .G, .B) channels");
    /* the first offset pointed past the end */
    memcpy(g, f, n);
    for (k = 0; k < n; k++)
        if (!memcmp(g + k, "hello", 5)) break;
    g[k + 5 + 1 + 7] = 0x7f;
    texr_expect_bad(t, "offset outside", g, n, "outside the file");
    /* a block that claims another line */
    memcpy(g, f, n);
    g[k + 5 + 1 + 16] = 9;
    texr_expect_bad(t, "wrong line", g, n, "starts at line 9");
    /* half infinity in a pixel */
    memcpy(g, f, n);
    g[k + 5 + 1 + 16 + 8 + 6] = 0x00;
    g[k + 5 + 1 + 16 + 8 + 7] = 0x7c;
    texr_expect_bad(t, "infinity", g, n, "an image must hold finite values");
    texr_expect_bad(t, "not EXR", (const unsigned char *)"\x76\x2f\x31\x02\x02\x00\x00\x00", 8, "not an OpenEXR");

    /* a ZIP file whose zlib data is damaged: the reason, not a crash */
    {
        pds_image src;
        unsigned char *z;
        int i;
        timg_path(path, sizeof path, "zipbad.exr");
        pds_image_alloc(&src, 40, 20);
        for (i = 0; i < 40 * 20 * 3; i++) src.rgb[i] = (float)(i % 97) * 0.25f; /* compresses */
        REQUIRE(t, pds_image_write_exr(path, &src, PDS_EXR_ZIP, NULL, &err) == PDS_OK, "write: %s", err.text);
        z = timg_read_bytes(path, &zn);
        REQUIRE(t, z != NULL, "read back");
        z[zn - 5] ^= 0x55; /* the last byte of the last block's deflate data */
        texr_expect_bad(t, "damaged ZIP", z, zn, "the ZIP data is corrupt");
        free(z);
        remove(path);
        pds_image_free(&src);
    }
    CHECK(t, pds_image_read_exr("/nonexistent/x.exr", &img, NULL, &err) != PDS_OK && img.rgb == NULL,
          "missing file");
}

/* ------------------------------------------------------------ inflate */

static void test_inflate_decodes_another_encoders_stream_and_every_pds_stream(pds_test_ctx *t)
{
    /* zlib.compress(b'abcabcabcabcabcabc', 9) from Python: a fixed-Huffman block */
    static const unsigned char py[13] = {0x78, 0xda, 0x4b, 0x4c, 0x4a, 0x4e, 0x44, 0x45, 0x00, 0x41, 0x7c, 0x06, 0xe5};
    unsigned char out[64], *data, *back;
    size_t n = 200000, i, k;
    uint32_t lcg = 12345u;
    const char *why = pds__zlib_decode(py, sizeof py, out, 18);
    CHECK(t, why == NULL && !memcmp(out, "abcabcabcabcabcabc", 18), "python stream: %s", why ? why : "bytes differ");
    CHECK(t, pds__zlib_decode(py, sizeof py, out, 17) != NULL, "one byte more than the room is an error");
    CHECK(t, pds__zlib_decode(py, sizeof py, out, 19) != NULL, "one byte fewer than expected is an error");
    /* the deflate tests' kinds of data: text-like, noise (stored), runs,
       long matches, a test card's PNG rows (dynamic) */
    data = (unsigned char *)malloc(n);
    back = (unsigned char *)malloc(n);
    REQUIRE(t, data && back, "malloc");
    for (k = 0; k < 4; k++) {
        pds__bitout o;
        unsigned char hdr[2] = {0x78, 0x9C}, tr[4];
        tinf s;
        for (i = 0; i < n; i++) {
            lcg = lcg * 1664525u + 1013904223u;
            data[i] = k == 0 ? (unsigned char)"the cat sat on the mat "[i % 23] ^ (unsigned char)((lcg >> 30) == 0)
                    : k == 1 ? (unsigned char)(lcg >> 24)
                    : k == 2 ? (unsigned char)(i / 1000)
                             : (unsigned char)((i % 300) * 7 + ((lcg >> 28) == 0));
        }
        memset(&o, 0, sizeof o);
        pds__out_bytes(&o, hdr, 2);
        pds__deflate(&o, data, n);
        timg_put_be(tr, pds__adler32_update(1, data, n));
        pds__out_bytes(&o, tr, 4);
        REQUIRE(t, !o.nomem, "deflate");
        why = pds__zlib_decode(o.buf, o.len, back, n);
        CHECK(t, why == NULL && !memcmp(back, data, n), "kind %lu: %s", (unsigned long)k, why ? why : "bytes differ");
        /* the test decoder names the block types: all three occur over the kinds */
        if (timg_zlib_inflate(o.buf, o.len, back, n, &s) == NULL && k == 1)
            CHECK(t, s.blocks[0] > 0, "noise is stored");
        if (k == 0) CHECK(t, timg_zlib_inflate(o.buf, o.len, back, n, &s) == NULL && s.blocks[2] > 0, "dynamic");
        /* damaged streams: an error, never more output than room */
        for (i = 2; i < o.len; i += o.len / 7 + 1) {
            o.buf[i] ^= 0x24;
            CHECK(t, pds__zlib_decode(o.buf, o.len, back, n) != NULL, "kind %lu: damage at %lu passed",
                  (unsigned long)k, (unsigned long)i);
            o.buf[i] ^= 0x24;
        }
        free(o.buf);
    }
    free(data);
    free(back);
}

/* ------------------------------------------------------------ metadata */

static void test_image_meta_keys_values_and_limits(pds_test_ctx *t)
{
    pds_image_meta m;
    char long_value[PDS_IMAGE_META_VALUE + 1];
    int i;
    memset(&m, 0, sizeof m);
    CHECK(t, pds_image_meta_set(&m, "pds:kind", "full") == PDS_OK, "set");
    CHECK(t, pds_image_meta_set(&m, "pds:kind", "caustics-only") == PDS_OK && m.count == 1, "replace");
    CHECK(t, !strcmp(pds_image_meta_get(&m, "pds:kind"), "caustics-only"), "get");
    CHECK(t, pds_image_meta_get(&m, "absent") == NULL, "absent key");
    CHECK(t, pds_image_meta_set(&m, "", "x") == PDS_ERR_INVALID_ARG, "empty key");
    CHECK(t, pds_image_meta_set(&m, " lead", "x") == PDS_ERR_INVALID_ARG, "leading space");
    CHECK(t, pds_image_meta_set(&m, "two  spaces", "x") == PDS_ERR_INVALID_ARG, "double space");
    CHECK(t, pds_image_meta_set(&m, "a=b", "x") == PDS_ERR_INVALID_ARG, "'=' in a key");
    CHECK(t, pds_image_meta_set(&m, "k", "line\nbreak") == PDS_ERR_INVALID_ARG, "newline in a value");
    memset(long_value, 'v', PDS_IMAGE_META_VALUE);
    long_value[PDS_IMAGE_META_VALUE] = '\0';
    CHECK(t, pds_image_meta_set(&m, "k", long_value) == PDS_ERR_INVALID_ARG, "value too long");
    for (i = 1; i < PDS_IMAGE_META_MAX; i++) {
        char key[16];
        snprintf(key, sizeof key, "k%d", i);
        CHECK(t, pds_image_meta_set(&m, key, "v") == PDS_OK, "entry %d", i);
    }
    CHECK(t, pds_image_meta_set(&m, "one-more", "v") == PDS_ERR_LIMIT, "full");
}

/* The PFM trailer: after the raster, so every reader of the raster sees
   the same file as without it; pds reads the entries back. */
static void test_pfm_metadata_trailer_follows_an_unchanged_raster(pds_test_ctx *t)
{
    pds_image img, back;
    pds_image_meta meta, got;
    pds_image_write_options o;
    pds_error err;
    char a[256], b[256];
    unsigned char *fa, *fb;
    size_t na, nb;
    const char *tail;
    texr_image(&img);
    texr_meta(&meta);
    timg_path(a, sizeof a, "plain.pfm");
    timg_path(b, sizeof b, "meta.pfm");
    CHECK(t, pds_image_write_pfm(a, &img, &err) == PDS_OK, "plain: %s", err.text);
    pds_image_write_options_default(&o);
    o.meta = &meta;
    CHECK(t, pds_image_write_with(b, &img, &o, &err) == PDS_OK, "with metadata: %s", err.text);
    fa = timg_read_bytes(a, &na);
    fb = timg_read_bytes(b, &nb);
    REQUIRE(t, fa && fb, "read back");
    CHECK(t, nb > na && !memcmp(fa, fb, na), "the file without metadata is a prefix of the file with it");
    tail = "# pds metadata\npds:kind=caustics-only\npds:method=pds\n";
    CHECK(t, nb > na && nb - na > strlen(tail) && !memcmp(fb + na, tail, strlen(tail)), "trailer text");
    CHECK(t, pds_image_read_pfm(b, &back, &err) == PDS_OK && texr_same_bits(&img, &back), "PFM reader: pixels");
    pds_image_free(&back);
    CHECK(t, pds_image_read(b, &back, &got, &err) == PDS_OK && got.count == meta.count &&
             !strcmp(pds_image_meta_get(&got, PDS_META_KIND), PDS_META_KIND_CAUSTICS), "metadata back");
    pds_image_free(&back);
    CHECK(t, pds_image_read(a, &back, &got, &err) == PDS_OK && got.count == 0, "no trailer, no metadata");
    pds_image_free(&back);
    free(fa);
    free(fb);
    remove(a);
    remove(b);
    pds_image_free(&img);
}

/* The PNG's chunks, parsed here: tEXt chunks with valid CRCs, before the
   IDAT, keyword NUL text; the image itself unchanged by them. */
static void test_png_carries_metadata_as_text_chunks(pds_test_ctx *t)
{
    pds_image img;
    pds_image_meta meta;
    pds_image_write_options o;
    pds_error err;
    char a[256], b[256];
    unsigned char *f, *plain;
    size_t n, np, pos = 8;
    int texts = 0, idat_seen = 0, found_kind = 0;
    int w, h, w2, h2;
    unsigned char *pa, *pb;
    texr_image(&img);
    texr_meta(&meta);
    timg_path(a, sizeof a, "meta.png");
    timg_path(b, sizeof b, "plain.png");
    pds_image_write_options_default(&o);
    o.meta = &meta;
    REQUIRE(t, pds_image_write_with(a, &img, &o, &err) == PDS_OK, "write: %s", err.text);
    REQUIRE(t, pds_image_write_png(b, &img, 0.0, &err) == PDS_OK, "write: %s", err.text);
    f = timg_read_bytes(a, &n);
    plain = timg_read_bytes(b, &np);
    REQUIRE(t, f && plain, "read back");
    while (pos + 12 <= n) {
        uint32_t len = timg_get_be(f + pos);
        const unsigned char *type = f + pos + 4;
        if (pos + 12 + len > n) break;
        CHECK(t, timg_get_be(f + pos + 8 + len) == timg_crc_bitwise(f + pos + 4, 4 + len), "CRC of a chunk");
        if (!memcmp(type, "tEXt", 4)) {
            const char *key = (const char *)f + pos + 8;
            const char *nul = (const char *)memchr(key, 0, len);
            size_t klen = nul ? (size_t)(nul - key) : len;
            texts++;
            CHECK(t, !idat_seen, "tEXt before IDAT");
            CHECK(t, klen > 0 && klen < 80 && klen < len, "keyword of 1-79 bytes and its NUL");
            if (!strcmp(key, PDS_META_KIND))
                found_kind = len - klen - 1 == strlen(PDS_META_KIND_CAUSTICS) &&
                             !memcmp(key + klen + 1, PDS_META_KIND_CAUSTICS, len - klen - 1);
        }
        if (!memcmp(type, "IDAT", 4)) idat_seen = 1;
        pos += 12 + len;
    }
    CHECK(t, pos == n, "chunks fill the file");
    CHECK(t, texts == meta.count, "%d tEXt chunks for %d entries", texts, meta.count);
    CHECK(t, found_kind, "pds:kind = caustics-only");
    pa = timg_png_read_rgb(a, &w, &h);
    pb = timg_png_read_rgb(b, &w2, &h2);
    CHECK(t, pa && pb && w == w2 && h == h2 && !memcmp(pa, pb, (size_t)w * (size_t)h * 3), "same pixels");
    free(pa);
    free(pb);
    free(f);
    free(plain);
    remove(a);
    remove(b);
    pds_image_free(&img);
}

/* The references under scenes/ say what they are and have the size races
   against them use: caustics-only but cardioid.ref.pfm, a full
   path-traced render (Makefile "references"). */
static void test_shipped_references_carry_their_kind(pds_test_ctx *t)
{
    static const struct {
        const char *path, *kind;
        int w, h;
    } refs[] = {{"scenes/refraction.ref.pfm", PDS_META_KIND_CAUSTICS, 256, 256},
                {"scenes/reflection.ref.pfm", PDS_META_KIND_CAUSTICS, 256, 256},
                {"scenes/ring_octahedron.ref.pfm", PDS_META_KIND_CAUSTICS, 512, 512},
                {"scenes/cardioid.caustics.ref.pfm", PDS_META_KIND_CAUSTICS, 256, 192},
                {"scenes/bunny.caustics.ref.pfm", PDS_META_KIND_CAUSTICS, 256, 256},
                {"scenes/cognac.caustics.ref.pfm", PDS_META_KIND_CAUSTICS, 256, 256},
                {"scenes/prism.caustics.ref.pfm", PDS_META_KIND_CAUSTICS, 240, 160},
                {"scenes/cornell.caustics.ref.pfm", PDS_META_KIND_CAUSTICS, 256, 256},
                {"scenes/demo.caustics.ref.pfm", PDS_META_KIND_CAUSTICS, 256, 192},
                {"scenes/torus.caustics.ref.pfm", PDS_META_KIND_CAUSTICS, 256, 256},
                {"scenes/cardioid.ref.pfm", PDS_META_KIND_FULL, 256, 192}};
    static pds_image_meta meta;
    size_t i;
    for (i = 0; i < sizeof refs / sizeof refs[0]; i++) {
        pds_image img;
        pds_error err;
        const char *kind;
        if (pds_image_read(refs[i].path, &img, &meta, &err) != PDS_OK) {
            CHECK(t, 0, "%s", err.text);
            continue;
        }
        kind = pds_image_meta_get(&meta, PDS_META_KIND);
        CHECK(t, kind && !strcmp(kind, refs[i].kind), "%s: kind %s, not %s", refs[i].path, kind ? kind : "(none)",
              refs[i].kind);
        CHECK(t, img.width == refs[i].w && img.height == refs[i].h, "%s: %dx%d, not %dx%d", refs[i].path, img.width,
              img.height, refs[i].w, refs[i].h);
        pds_image_free(&img);
    }
}

/* ---------------------------------------------------------- tone curves */

static void test_tonemap_curves_known_values(pds_test_ctx *t)
{
    /* Narkowicz 2015: f(x) = x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14) */
    CHECK(t, pds_tonemap_curve(PDS_TONEMAP_CLAMP, 0.25) == 0.25, "clamp inside");
    CHECK(t, pds_tonemap_curve(PDS_TONEMAP_CLAMP, 7.0) == 1.0 && pds_tonemap_curve(PDS_TONEMAP_CLAMP, -1.0) == 0.0,
          "clamp outside");
    /* Reinhard et al. 2002 eq. 3: L / (1 + L) */
    CHECK(t, pds_tonemap_curve(PDS_TONEMAP_REINHARD, 1.0) == 0.5, "reinhard(1) = 1/2");
    CHECK(t, pds_tonemap_curve(PDS_TONEMAP_REINHARD, 3.0) == 0.75, "reinhard(3) = 3/4");
    CHECK(t, pds_tonemap_curve(PDS_TONEMAP_REINHARD, 1e300 * 10) == 1.0, "reinhard(inf) = 1");
    CHECK(t, fabs(pds_tonemap_curve(PDS_TONEMAP_FILMIC, 1.0) - 2.54 / 3.16) < 1e-12, "filmic(1) = 2.54 / 3.16");
    CHECK(t, fabs(pds_tonemap_curve(PDS_TONEMAP_FILMIC, 0.5) - 0.6425 / 1.0425) < 1e-12, "filmic(0.5)");
    CHECK(t, pds_tonemap_curve(PDS_TONEMAP_FILMIC, 0.0) == 0.0, "filmic(0) = 0");
    /* f(x) = 1 where 0.08 x^2 - 0.56 x - 0.14 = 0: x = 7.24 */
    CHECK(t, pds_tonemap_curve(PDS_TONEMAP_FILMIC, 7.3) == 1.0, "filmic(7.3) clamps to 1");
    CHECK(t, fabs(pds_tonemap_curve(PDS_TONEMAP_FILMIC, 7.0) - 123.2 / 123.34) < 1e-12, "filmic(7) just below 1");
    {
        double nan = 0.0;
        nan = nan / nan;
        CHECK(t, pds_tonemap_curve(PDS_TONEMAP_FILMIC, nan) == 0.0 && pds_tonemap_curve(PDS_TONEMAP_REINHARD, nan) == 0.0,
              "NaN gives 0");
    }
}

/* A PNG through each curve: grey 1.0 and a saturated blue pixel; the
   bytes are the curve, then sRGB, then rounding (timg_srgb is the test
   file's own sRGB curve). Clamp is the writer's old output byte for byte. */
static void test_png_tonemap_bytes_follow_the_curves(pds_test_ctx *t)
{
    pds_image img;
    pds_image_write_options o;
    pds_error err;
    char a[256], b[256];
    unsigned char *px, *fa, *fb;
    size_t na, nb;
    int w, h;
    double s;
    pds_image_alloc(&img, 2, 1);
    img.rgb[0] = img.rgb[1] = img.rgb[2] = 1.0f;
    img.rgb[3] = 0.0f;
    img.rgb[4] = 0.0f;
    img.rgb[5] = 4.0f;
    timg_path(a, sizeof a, "tm.png");
    timg_path(b, sizeof b, "tm0.png");
    pds_image_write_options_default(&o);
    o.tonemap = PDS_TONEMAP_REINHARD;
    REQUIRE(t, pds_image_write_with(a, &img, &o, &err) == PDS_OK, "write: %s", err.text);
    px = timg_png_read_rgb(a, &w, &h);
    REQUIRE(t, px != NULL, "decode");
    /* grey 1: L = 1, scale 1/2; blue 4: L = 0.0722 * 4, B = 4 / (1 + L) > 1 clamps */
    CHECK(t, px[0] == (unsigned char)(timg_srgb(0.5) * 255 + 0.5) && px[1] == px[0] && px[2] == px[0],
          "reinhard grey %d", px[0]);
    CHECK(t, px[3] == 0 && px[4] == 0 && px[5] == 255, "reinhard blue %d %d %d", px[3], px[4], px[5]);
    free(px);
    o.tonemap = PDS_TONEMAP_FILMIC;
    o.exposure_stops = -1.0; /* 1 -> 0.5, 4 -> 2 */
    REQUIRE(t, pds_image_write_with(a, &img, &o, &err) == PDS_OK, "write: %s", err.text);
    px = timg_png_read_rgb(a, &w, &h);
    REQUIRE(t, px != NULL, "decode");
    s = 2.0 * (2.51 * 2.0 + 0.03) / (2.0 * (2.43 * 2.0 + 0.59) + 0.14);
    CHECK(t, px[0] == (unsigned char)(timg_srgb(0.6425 / 1.0425) * 255 + 0.5), "filmic grey %d", px[0]);
    CHECK(t, px[5] == (unsigned char)(timg_srgb(s) * 255 + 0.5) && px[3] == 0, "filmic blue %d", px[5]);
    free(px);
    /* clamp: the same file as pds_image_write_png */
    o.tonemap = PDS_TONEMAP_CLAMP;
    o.exposure_stops = 0.0;
    REQUIRE(t, pds_image_write_with(a, &img, &o, &err) == PDS_OK, "write: %s", err.text);
    REQUIRE(t, pds_image_write_png(b, &img, 0.0, &err) == PDS_OK, "write: %s", err.text);
    fa = timg_read_bytes(a, &na);
    fb = timg_read_bytes(b, &nb);
    CHECK(t, fa && fb && na == nb && !memcmp(fa, fb, na), "clamp is the PNG writer's old output");
    free(fa);
    free(fb);
    o.tonemap = (pds_tonemap)7;
    CHECK(t, pds_image_write_with(a, &img, &o, &err) == PDS_ERR_INVALID_ARG, "unknown curve refused");
    remove(a);
    remove(b);
    pds_image_free(&img);
}

/* ------------------------------------------------------------ the tool */

#ifdef PDS_TEST_POSIX
/* render -o .exr carries the render's metadata; merge of two shards to
   .exr gives the single render's image bit for bit through the same
   writer; compare warns once when the kinds differ, not otherwise; sweep
   warns about a reference of the other kind. */
static void test_cli_exr_output_metadata_and_kind_warnings(pds_test_ctx *t)
{
    char out[8192], err[4096], args[1024], dir[64], one[100], caus[100], full[100], merged[100], p1[100], p2[100];
    static pds_image_meta meta;
    pds_image a, b;
    pds_error e;
    const char *common = "scenes/teaching_mirror.scene --res 24x16 --spp 1 --photons 2000 --quiet --threads 2";
    snprintf(dir, sizeof dir, "/tmp/pds_test_exr_cli_%ld", (long)getpid());
    snprintf(one, sizeof one, "%s-one.exr", dir);
    snprintf(caus, sizeof caus, "%s-caus.pfm", dir);
    snprintf(full, sizeof full, "%s-full.exr", dir);
    snprintf(merged, sizeof merged, "%s-merged.exr", dir);
    snprintf(p1, sizeof p1, "%s-1.pdsp", dir);
    snprintf(p2, sizeof p2, "%s-2.pdsp", dir);

    snprintf(args, sizeof args, "render %s --caustics-only -o %s", common, caus);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "render caustics: %s", out);
    snprintf(args, sizeof args, "render %s --seed 3 -o %s --exr-compression none", common, full);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "render full: %s", out);
    REQUIRE(t, pds_image_read(full, &a, &meta, &e) == PDS_OK, "read: %s", e.text);
    CHECK(t, pds_image_meta_get(&meta, PDS_META_KIND) && !strcmp(pds_image_meta_get(&meta, PDS_META_KIND), "full"),
          "kind full");
    CHECK(t, pds_image_meta_get(&meta, "pds:seed") && !strcmp(pds_image_meta_get(&meta, "pds:seed"), "3"), "seed");
    CHECK(t, pds_image_meta_get(&meta, "pds:photons") && pds_image_meta_get(&meta, "pds:time") &&
             pds_image_meta_get(&meta, "pds:options") && pds_image_meta_get(&meta, "pds:version"),
          "photons, time, options, version");
    pds_image_free(&a);

    snprintf(args, sizeof args, "compare %s %s", full, caus);
    CHECK(t, cli_run_split(args, out, sizeof out, err, sizeof err) == 0, "compare: %s", err);
    CHECK(t, strstr(err, "warning: kinds differ") && strstr(err, "is full") && strstr(err, "caustics-only") &&
             strchr(err, '\n') == err + strlen(err) - 1,
          "one warning line: %s", err);
    snprintf(args, sizeof args, "compare %s %s", full, full);
    CHECK(t, cli_run_split(args, out, sizeof out, err, sizeof err) == 0 && err[0] == '\0', "same kinds: '%s'", err);

    /* shards merged into an EXR: the single render's pixels */
    snprintf(args, sizeof args, "render %s -o %s", common, one);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "render one: %s", out);
    snprintf(args, sizeof args, "render %s --shard 1/2 -o %s", common, p1);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "shard 1: %s", out);
    snprintf(args, sizeof args, "render %s --shard 2/2 -o %s", common, p2);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "shard 2: %s", out);
    snprintf(args, sizeof args, "merge -o %s --exr-compression zips %s %s", merged, p1, p2);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "merge: %s", out);
    if (pds_image_read(one, &a, NULL, &e) == PDS_OK && pds_image_read(merged, &b, &meta, &e) == PDS_OK) {
        CHECK(t, texr_same_bits(&a, &b), "merged EXR = single render");
        CHECK(t, pds_image_meta_get(&meta, "pds:merged") != NULL && pds_image_meta_get(&meta, PDS_META_KIND), "merge metadata");
        pds_image_free(&a);
        pds_image_free(&b);
    } else {
        CHECK(t, 0, "read: %s", e.text);
    }

    /* sweep with a caustics-only reference but full renders */
    snprintf(args, sizeof args, "sweep %s --param smoothing --values 12 --ref %s -o %s-sweep", common, caus, dir);
    CHECK(t, cli_run_split(args, out, sizeof out, err, sizeof err) == 0, "sweep: %s", err);
    CHECK(t, strstr(err, "pds sweep: warning: kinds differ: the renders are full, the reference") != NULL,
          "sweep warning: %s", err);
    CHECK(t, cli_run("render scenes/teaching_mirror.scene --tonemap filmc -o x.png", out, sizeof out) == 2 &&
             strstr(out, "filmic"), "a near miss: %s", out);
    snprintf(args, sizeof args, "rm -rf %s-sweep %s %s %s %s %s %s", dir, one, caus, full, merged, p1, p2);
    cli_shell(args, out, sizeof out);
}
#endif

static const pds_test_case tests_exr[] = {
    {"exr_round_trip_is_bit_exact_for_every_compression", test_exr_round_trip_is_bit_exact_for_every_compression},
    {"exr_files_follow_the_openexr_layout", test_exr_files_follow_the_openexr_layout},
    {"exr_zip_steps_match_hand_computed_bytes", test_exr_zip_steps_match_hand_computed_bytes},
    {"exr_reader_takes_half_channels_offset_windows_and_grey",
     test_exr_reader_takes_half_channels_offset_windows_and_grey},
    {"exr_reader_takes_the_combined_layer", test_exr_reader_takes_the_combined_layer},
    {"half_to_float_known_values", test_half_to_float_known_values},
    {"exr_reader_rejects_bad_files_with_the_reason", test_exr_reader_rejects_bad_files_with_the_reason},
    {"inflate_decodes_another_encoders_stream_and_every_pds_stream",
     test_inflate_decodes_another_encoders_stream_and_every_pds_stream},
    {"image_meta_keys_values_and_limits", test_image_meta_keys_values_and_limits},
    {"pfm_metadata_trailer_follows_an_unchanged_raster", test_pfm_metadata_trailer_follows_an_unchanged_raster},
    {"png_carries_metadata_as_text_chunks", test_png_carries_metadata_as_text_chunks},
    {"shipped_references_carry_their_kind", test_shipped_references_carry_their_kind},
    {"tonemap_curves_known_values", test_tonemap_curves_known_values},
    {"png_tonemap_bytes_follow_the_curves", test_png_tonemap_bytes_follow_the_curves},
#ifdef PDS_TEST_POSIX
    {"cli_exr_output_metadata_and_kind_warnings", test_cli_exr_output_metadata_and_kind_warnings},
#endif
};

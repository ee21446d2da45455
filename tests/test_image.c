/* tests/test_image.c - PFM and PNG files, tone mapping, RMSE and SSIM.

   The PNG tests decode the writer's output with a small independent reader
   (bitwise CRC-32, byte-at-a-time Adler-32, an inflater for stored, fixed
   and dynamic Huffman blocks written from RFC 1951, the five row filters),
   so a file that a real decoder would reject fails here too; the deflate
   and Huffman-length tests call the compressor's parts directly. The SSIM tests
   compare against a direct, non-separable evaluation of Wang et al.'s
   formula and against numbers computed once with scikit-image. */

#include <dirent.h>
#include <sys/stat.h>

/* ------------------------------------------------------------ helpers */

/* A per-process scratch path under /tmp. */
static void timg_path(char *out, size_t n, const char *name)
{
    snprintf(out, n, "/tmp/pds_test_image_%ld_%s", (long)getpid(), name);
}

static int timg_write_bytes(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    int ok;
    if (!f) return 0;
    ok = fwrite(data, 1, n, f) == n;
    return (fclose(f) == 0) && ok;
}

/* Whole file, or NULL. */
static unsigned char *timg_read_bytes(const char *path, size_t *n)
{
    char *data = NULL;
    if (pds__read_file(path, (size_t)1 << 30, "test file", &data, n, NULL) != PDS_OK) return NULL;
    return (unsigned char *)data;
}

static int timg_file_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* Entries in a directory other than "." and "..", or -1. */
static int timg_dir_count(const char *dir)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    int n = 0;
    if (!d) return -1;
    while ((e = readdir(d)) != NULL)
        if (strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0) n++;
    closedir(d);
    return n;
}

/* Little-endian float bytes of a bit pattern (independent of the host). */
static void timg_put_le(unsigned char *p, uint32_t u)
{
    p[0] = (unsigned char)(u & 0xff);
    p[1] = (unsigned char)((u >> 8) & 0xff);
    p[2] = (unsigned char)((u >> 16) & 0xff);
    p[3] = (unsigned char)(u >> 24);
}

static void timg_put_be(unsigned char *p, uint32_t u)
{
    p[0] = (unsigned char)(u >> 24);
    p[1] = (unsigned char)((u >> 16) & 0xff);
    p[2] = (unsigned char)((u >> 8) & 0xff);
    p[3] = (unsigned char)(u & 0xff);
}

static uint32_t timg_get_be(const unsigned char *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | (uint32_t)p[3];
}

static uint32_t timg_bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    return u;
}

/* Bit-by-bit CRC-32 (no table), to check the library's table version. */
static uint32_t timg_crc_bitwise(const unsigned char *p, size_t n)
{
    uint32_t c = 0xFFFFFFFFu;
    size_t i;
    int k;
    for (i = 0; i < n; i++) {
        c ^= p[i];
        for (k = 0; k < 8; k++) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
    }
    return c ^ 0xFFFFFFFFu;
}

/* Adler-32 with the modulo after every byte. */
static uint32_t timg_adler_naive(const unsigned char *p, size_t n)
{
    uint32_t a = 1, b = 0;
    size_t i;
    for (i = 0; i < n; i++) {
        a = (a + p[i]) % 65521u;
        b = (b + a) % 65521u;
    }
    return b << 16 | a;
}

/* Independent sRGB curve for expected values. */
static double timg_srgb(double c)
{
    if (c != c || c <= 0.0) return 0.0;
    if (c >= 1.0) return 1.0;
    return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

/* An inflater (RFC 1951) written for these tests from the RFC alone; it
   shares no code or tables with pds.c. It takes stored, fixed-Huffman and
   dynamic-Huffman blocks and is strict where the writer promises more than
   the RFC asks: every dynamic code must be complete (the writer pads a
   code with a lone symbol to two), and nothing may follow the final
   block but the zlib trailer. */
typedef struct tinf {
    const unsigned char *in;
    size_t n, pos;
    uint32_t bitbuf;
    int bitcnt;
    unsigned char *out;
    size_t len, max;  /* bytes out so far; more than max is an error */
    int blocks[3];    /* blocks seen, by BTYPE */
    size_t matches;   /* length/distance pairs decoded */
    const char *err;  /* first error, or NULL */
} tinf;

/* need (0-16) bits, first bit lowest; 0 once the input has run out. */
static unsigned tinf_bits(tinf *s, int need)
{
    unsigned v;
    while (s->bitcnt < need) {
        if (s->pos >= s->n) {
            if (!s->err) s->err = "deflate data runs past the end";
            return 0;
        }
        s->bitbuf |= (uint32_t)s->in[s->pos++] << s->bitcnt;
        s->bitcnt += 8;
    }
    v = (unsigned)(s->bitbuf & ((1u << need) - 1u));
    s->bitbuf >>= need;
    s->bitcnt -= need;
    return v;
}

/* A canonical code as the RFC defines it (sec. 3.2.2): how many codes
   have each length, and the symbols in code order (by length, then by
   symbol number). */
typedef struct tinf_code {
    int count[16];
    int symbol[320];
} tinf_code;

/* Build from n code lengths. Returns the unused part of the code space in
   units of 2^-15: 0 for a complete code, > 0 for an incomplete one, < 0
   for an over-subscribed one (not a prefix code at all). */
static long tinf_code_build(tinf_code *c, const unsigned char *len, int n)
{
    int start[16], l, i;
    long room = 1L << 15;
    for (l = 0; l < 16; l++) c->count[l] = 0;
    for (i = 0; i < n; i++) c->count[len[i]]++;
    c->count[0] = 0;
    start[1] = 0;
    for (l = 1; l < 15; l++) start[l + 1] = start[l] + c->count[l];
    for (i = 0; i < n; i++)
        if (len[i]) c->symbol[start[len[i]]++] = i;
    for (l = 1; l < 16; l++) room -= (long)c->count[l] << (15 - l);
    return room;
}

/* One symbol: the code's bits arrive first bit = most significant. At
   each length, the codes of that length are the next count[l] values
   after the last code of the length before, doubled (sec. 3.2.2). */
static int tinf_decode(tinf *s, const tinf_code *c)
{
    int code = 0, first = 0, seen = 0, l;
    for (l = 1; l < 16; l++) {
        code = code << 1 | (int)tinf_bits(s, 1);
        if (code - first < c->count[l]) return c->symbol[seen + code - first];
        seen += c->count[l];
        first = (first + c->count[l]) << 1;
    }
    if (!s->err) s->err = "no symbol has this code";
    return -1;
}

static void tinf_put(tinf *s, unsigned char b)
{
    if (s->len >= s->max) {
        if (!s->err) s->err = "more output than expected";
        return;
    }
    s->out[s->len++] = b;
}

/* Decode one Huffman-coded block's symbols up to end-of-block. Length and
   distance bases come from the RFC's table rule: lengths 3-10 take no
   extra bits, then every four codes one bit more; code 285 is 258.
   Distances 1-4 take none, then every two codes one more. */
static void tinf_block(tinf *s, const tinf_code *lit, const tinf_code *dist)
{
    int lbase[29], lextra[29], dbase[30], dextra[30], i;
    for (i = 0; i < 28; i++) {
        lextra[i] = i < 8 ? 0 : (i - 4) / 4;
        lbase[i] = i == 0 ? 3 : lbase[i - 1] + (1 << lextra[i - 1]);
    }
    lbase[28] = 258;
    lextra[28] = 0;
    for (i = 0; i < 30; i++) {
        dextra[i] = i < 4 ? 0 : i / 2 - 1;
        dbase[i] = i == 0 ? 1 : dbase[i - 1] + (1 << dextra[i - 1]);
    }
    while (!s->err) {
        int sym = tinf_decode(s, lit), d, k;
        size_t length, distance;
        if (sym < 0) return;
        if (sym < 256) {
            tinf_put(s, (unsigned char)sym);
            continue;
        }
        if (sym == 256) return;
        if (sym > 285) {
            s->err = "literal/length symbol 286 or 287";
            return;
        }
        length = (size_t)lbase[sym - 257] + tinf_bits(s, lextra[sym - 257]);
        d = tinf_decode(s, dist);
        if (d < 0) return;
        if (d > 29) {
            s->err = "distance symbol 30 or 31";
            return;
        }
        distance = (size_t)dbase[d] + tinf_bits(s, dextra[d]);
        if (distance > s->len || distance > 32768) {
            if (!s->err) s->err = "distance reaches before the start or past the window";
            return;
        }
        for (k = 0; k < (int)length; k++) tinf_put(s, s->out[s->len - distance]);
        s->matches++;
    }
}

/* The code lengths of a dynamic block (sec. 3.2.7), then its symbols. */
static void tinf_dynamic(tinf *s)
{
    static const int order[19] = {16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15};
    unsigned char lens[320], cl[19];
    tinf_code lit, dist, clc;
    int hlit = (int)tinf_bits(s, 5) + 257, hdist = (int)tinf_bits(s, 5) + 1, hclen = (int)tinf_bits(s, 4) + 4;
    int i = 0;
    if (hlit > 286 || hdist > 30) {
        s->err = "HLIT or HDIST out of range";
        return;
    }
    memset(cl, 0, sizeof cl);
    for (i = 0; i < hclen; i++) cl[order[i]] = (unsigned char)tinf_bits(s, 3);
    if (tinf_code_build(&clc, cl, 19) != 0) {
        s->err = "code-length code is not complete";
        return;
    }
    i = 0;
    while (i < hlit + hdist && !s->err) {
        int sym = tinf_decode(s, &clc), rep, val;
        if (sym < 0) return;
        if (sym < 16) {
            lens[i++] = (unsigned char)sym;
            continue;
        }
        if (sym == 16) {
            if (i == 0) {
                s->err = "repeat code 16 with no previous length";
                return;
            }
            val = lens[i - 1];
            rep = 3 + (int)tinf_bits(s, 2);
        } else {
            val = 0;
            rep = sym == 17 ? 3 + (int)tinf_bits(s, 3) : 11 + (int)tinf_bits(s, 7);
        }
        if (i + rep > hlit + hdist) {
            s->err = "code-length repeat runs past HLIT + HDIST";
            return;
        }
        while (rep--) lens[i++] = (unsigned char)val;
    }
    if (s->err) return;
    if (lens[256] == 0) {
        s->err = "end-of-block has no code";
        return;
    }
    if (tinf_code_build(&lit, lens, hlit) != 0 || tinf_code_build(&dist, lens + hlit, hdist) != 0) {
        s->err = "literal/length or distance code is not complete";
        return;
    }
    tinf_block(s, &lit, &dist);
}

/* Inflate a zlib stream (RFC 1950): checks CM, CINFO, FCHECK, FDICT,
   every block, and the Adler-32 trailer, which must end the input.
   Output goes to out (max bytes). Returns NULL or what was wrong. */
static const char *timg_zlib_inflate(const unsigned char *z, size_t n, unsigned char *out, size_t max,
                                     tinf *s)
{
    int final = 0;
    memset(s, 0, sizeof *s);
    s->out = out;
    s->max = max;
    if (n < 6) return "zlib stream too short";
    if ((z[0] & 0x0f) != 8 || (z[0] >> 4) > 7) return "zlib CMF is not deflate with a window <= 32 KiB";
    if ((z[0] * 256 + z[1]) % 31 != 0) return "zlib FCHECK wrong";
    if (z[1] & 0x20) return "zlib FDICT set";
    s->in = z + 2;
    s->n = n - 2 - 4;
    while (!final && !s->err) {
        int type;
        final = (int)tinf_bits(s, 1);
        type = (int)tinf_bits(s, 2);
        if (s->err) break;
        if (type == 3) return "block type 3";
        s->blocks[type]++;
        if (type == 0) {
            unsigned len, nlen;
            s->bitbuf = 0; /* the rest of the byte is padding */
            s->bitcnt = 0;
            if (s->n - s->pos < 4) return "stored block header runs past the end";
            len = s->in[s->pos] | (unsigned)s->in[s->pos + 1] << 8;
            nlen = s->in[s->pos + 2] | (unsigned)s->in[s->pos + 3] << 8;
            s->pos += 4;
            if ((len ^ 0xffffu) != nlen) return "stored block LEN and NLEN disagree";
            if (s->n - s->pos < len) return "stored block runs past the end";
            while (len-- && !s->err) tinf_put(s, s->in[s->pos++]);
        } else if (type == 1) {
            unsigned char lens[320];
            tinf_code lit, dist;
            int i;
            for (i = 0; i < 288; i++) lens[i] = (unsigned char)(i < 144 ? 8 : i < 256 ? 9 : i < 280 ? 7 : 8);
            tinf_code_build(&lit, lens, 288);
            for (i = 0; i < 32; i++) lens[i] = 5;
            tinf_code_build(&dist, lens, 32);
            tinf_block(s, &lit, &dist);
        } else {
            tinf_dynamic(s);
        }
    }
    if (s->err) return s->err;
    if (s->pos != s->n) return "bytes between the final block and the Adler-32";
    if (timg_get_be(z + n - 4) != timg_adler_naive(out, s->len)) return "bad Adler-32";
    return NULL;
}

/* PNG's Paeth predictor, from ISO/IEC 15948 sec. 9.4. */
static int timg_paeth(int a, int b, int c)
{
    int p = a + b - c, pa = abs(p - a), pb = abs(p - b), pc = abs(p - c);
    if (pa <= pb && pa <= pc) return a;
    if (pb <= pc) return b;
    return c;
}

/* A decoded PNG: 8-bit RGB pixels, top row first, and how it was coded. */
typedef struct timg_png {
    int width, height;
    unsigned char *rgb;
    int blocks[3];       /* deflate blocks by BTYPE */
    int filters[5];      /* rows by filter type */
    unsigned char cmf, flg;
    size_t idat_len;     /* bytes of zlib stream */
    size_t matches;
} timg_png;

/* Decode an 8-bit RGB, non-interlaced PNG: checks the signature, every
   chunk's CRC, IHDR, the zlib stream (timg_zlib_inflate) and the filter
   types, and undoes the filters. Returns NULL on success, else what was
   wrong; out->rgb is then NULL. */
static const char *timg_png_decode(const unsigned char *f, size_t n, timg_png *out)
{
    static const unsigned char sig[8] = {0x89, 0x50, 0x4E, 0x47, 0x0D, 0x0A, 0x1A, 0x0A};
    unsigned char *z = NULL, *raw = NULL;
    size_t zlen = 0, pos = 8, expect, stride, y, i;
    int seen_ihdr = 0, seen_iend = 0;
    const char *why;
    tinf s;
    memset(out, 0, sizeof *out);
    if (n < 8 || memcmp(f, sig, 8) != 0) return "bad signature";
    while (pos < n && !seen_iend) {
        uint32_t len, crc;
        const unsigned char *type, *data;
        if (n - pos < 12) why = "chunk header runs past the end";
        else if ((len = timg_get_be(f + pos)) > n - pos - 12) why = "chunk data runs past the end";
        else why = NULL;
        if (why) {
            free(z);
            return why;
        }
        type = f + pos + 4;
        data = f + pos + 8;
        crc = timg_get_be(data + len);
        if (crc != timg_crc_bitwise(type, 4 + (size_t)len)) why = "bad chunk CRC";
        else if (memcmp(type, "IHDR", 4) == 0) {
            if (pos != 8 || len != 13) why = "IHDR not first or wrong length";
            out->width = (int)timg_get_be(data);
            out->height = (int)timg_get_be(data + 4);
            if (data[8] != 8 || data[9] != 2 || data[10] || data[11] || data[12])
                why = "IHDR is not 8-bit RGB, deflate, filter 0, no interlace";
            if (out->width < 1 || out->height < 1 || out->width > 16384 || out->height > 16384)
                why = "IHDR size out of range";
            seen_ihdr = 1;
        } else if (memcmp(type, "IDAT", 4) == 0) {
            unsigned char *nz = (unsigned char *)realloc(z, zlen + len + 1);
            if (!seen_ihdr) why = "IDAT before IHDR";
            else if (!nz) why = "out of memory";
            else {
                z = nz;
                memcpy(z + zlen, data, len);
                zlen += len;
            }
        } else if (memcmp(type, "IEND", 4) == 0) {
            if (len != 0) why = "IEND has data";
            seen_iend = 1;
        } else if ((type[0] & 0x20) && seen_ihdr) {
            /* an ancillary chunk (lower-case first letter, ISO/IEC 15948
               sec. 5.4), e.g. the writer's tEXt metadata: not the image */
        } else {
            why = "unexpected chunk type";
        }
        if (why) {
            free(z);
            return why;
        }
        pos += 12 + (size_t)len;
    }
    if (!seen_iend || pos != n || !z) {
        free(z);
        return "missing IDAT or IEND, or bytes after IEND";
    }
    stride = 3 * (size_t)out->width;
    expect = (size_t)out->height * (1 + stride);
    raw = (unsigned char *)malloc(expect + 1);
    out->rgb = (unsigned char *)malloc(stride * out->height + 1);
    if (!raw || !out->rgb) {
        free(z);
        free(raw);
        free(out->rgb);
        out->rgb = NULL;
        return "out of memory";
    }
    out->cmf = z[0];
    out->flg = zlen > 1 ? z[1] : 0;
    out->idat_len = zlen;
    why = timg_zlib_inflate(z, zlen, raw, expect, &s);
    free(z);
    memcpy(out->blocks, s.blocks, sizeof out->blocks);
    out->matches = s.matches;
    if (!why && s.len != expect) why = "decoded stream has the wrong length";
    for (y = 0; !why && y < (size_t)out->height; y++) {
        const unsigned char *row = raw + y * (1 + stride);
        unsigned char *px = out->rgb + y * stride, *up = y ? px - stride : NULL;
        if (row[0] > 4) {
            why = "row filter type above 4";
            break;
        }
        out->filters[row[0]]++;
        for (i = 0; i < stride; i++) {
            int a = i >= 3 ? px[i - 3] : 0, b = up ? up[i] : 0, c = up && i >= 3 ? up[i - 3] : 0;
            int pred = row[0] == 0 ? 0 : row[0] == 1 ? a : row[0] == 2 ? b : row[0] == 3 ? (a + b) >> 1
                                                                                           : timg_paeth(a, b, c);
            px[i] = (unsigned char)((row[1 + i] + pred) & 0xff);
        }
    }
    free(raw);
    if (why) {
        free(out->rgb);
        out->rgb = NULL;
    }
    return why;
}

/* Write img as PNG with the given exposure to a scratch file and decode
   it; also returns the file's size. NULL on success. */
static const char *timg_png_round_trip(const pds_image *img, double exposure, timg_png *png, size_t *size)
{
    char path[256];
    pds_error err;
    unsigned char *file;
    const char *why;
    memset(png, 0, sizeof *png);
    timg_path(path, sizeof path, "round.png");
    if (pds_image_write_png(path, img, exposure, &err) != PDS_OK) return "the writer failed";
    file = timg_read_bytes(path, size);
    remove(path);
    if (!file) return "cannot read the file back";
    why = timg_png_decode(file, *size, png);
    free(file);
    return why;
}

/* Width, height and RGB bytes of a PNG file (caller frees), or NULL. */
static unsigned char *timg_png_read_rgb(const char *path, int *w, int *h)
{
    size_t n;
    unsigned char *file = timg_read_bytes(path, &n);
    timg_png png;
    if (!file) return NULL;
    if (timg_png_decode(file, n, &png) != NULL) png.rgb = NULL;
    free(file);
    *w = png.width;
    *h = png.height;
    return png.rgb;
}

/* Deterministic test pattern: dyadic values (exact in float), some out
   of [0,1] so clamping is exercised. which selects one of two images. */
static void timg_pattern(pds_image *img, int which)
{
    int x, y;
    for (y = 0; y < img->height; y++) {
        for (x = 0; x < img->width; x++) {
            float *p = img->rgb + 3 * ((size_t)y * img->width + x);
            if (which == 0) {
                p[0] = (float)((x * 7 + y * 13) % 17) / 16.0f;
                p[1] = (float)((x * x + 3 * y) % 11) / 8.0f;
                p[2] = (float)((x + y * y * 5) % 9) / 32.0f;
            } else {
                p[0] = (float)((x * 5 + y * 3 + 1) % 17) / 16.0f;
                p[1] = (float)((x * x + 3 * y + (x * y) % 3) % 11) / 8.0f;
                p[2] = (float)((x * 3 + y) % 13) / 64.0f - 1.0f / 32.0f;
            }
        }
    }
}

/* SSIM straight from the definition: at every valid position (with
   mask, every one whose centre pixel the mask holds), a 2-D Gaussian
   window built and normalised in 2-D, the five weighted sums taken
   directly, no separability, no ring buffer. */
static double timg_ssim_direct_masked(const pds_image *a, const pds_image *b, const pds_image *mask)
{
    int W = a->width, H = a->height, n = 11, r, ox, oy, i, j;
    double C1 = 0.0001, C2 = 0.0009, total = 0.0, wsum = 0.0, counted = 0.0;
    double win[11][11];
    double *ya = (double *)malloc(sizeof(double) * W * H);
    double *yb = (double *)malloc(sizeof(double) * W * H);
    if (!ya || !yb) {
        free(ya);
        free(yb);
        return -2.0;
    }
    if (W < n) n = W;
    if (H < n) n = H;
    if (n % 2 == 0) n--;
    r = n / 2;
    for (i = 0; i < W * H; i++) {
        const float *pa = a->rgb + 3 * i, *pb = b->rgb + 3 * i;
        ya[i] = 0.299 * timg_srgb(pa[0]) + 0.587 * timg_srgb(pa[1]) + 0.114 * timg_srgb(pa[2]);
        yb[i] = 0.299 * timg_srgb(pb[0]) + 0.587 * timg_srgb(pb[1]) + 0.114 * timg_srgb(pb[2]);
    }
    for (j = 0; j < n; j++)
        for (i = 0; i < n; i++) {
            win[j][i] = exp(-((i - r) * (i - r) + (j - r) * (j - r)) / (2.0 * 1.5 * 1.5));
            wsum += win[j][i];
        }
    for (oy = 0; oy + n <= H; oy++)
        for (ox = 0; ox + n <= W; ox++) {
            double mx = 0, my = 0, sxx = 0, syy = 0, sxy = 0, vx, vy, cxy;
            for (j = 0; j < n; j++)
                for (i = 0; i < n; i++) {
                    double w = win[j][i] / wsum;
                    double x = ya[(oy + j) * W + ox + i], y = yb[(oy + j) * W + ox + i];
                    mx += w * x;
                    my += w * y;
                    sxx += w * x * x;
                    syy += w * y * y;
                    sxy += w * x * y;
                }
            vx = sxx - mx * mx;
            vy = syy - my * my;
            cxy = sxy - mx * my;
            if (mask && !(mask->rgb[3 * ((oy + r) * W + ox + r)] > 0.0f)) continue;
            total += (2 * mx * my + C1) * (2 * cxy + C2) / ((mx * mx + my * my + C1) * (vx + vy + C2));
            counted += 1.0;
        }
    free(ya);
    free(yb);
    return counted > 0.0 ? total / counted : -1.0;
}

static double timg_ssim_direct(const pds_image *a, const pds_image *b)
{
    return timg_ssim_direct_masked(a, b, NULL);
}

/* ---------------------------------------------------------------- PFM */

static void test_pfm_round_trip(pds_test_ctx *t)
{
    char path[256];
    pds_image img, back;
    pds_error err;
    unsigned char *file;
    size_t size, i;
    static const char header[] = "PF\n5 3\n-1.0\n";
    const size_t hlen = sizeof header - 1;
    float special[6];
    special[0] = -0.0f;
    special[1] = 1e-40f; /* subnormal */
    special[2] = 1.17549435e-38f; /* smallest normal (infinities and NaN are refused on reading) */
    special[3] = -3.4028235e38f;
    special[4] = 3.4028235e38f;
    special[5] = -123.456f;

    timg_path(path, sizeof path, "roundtrip.pfm");
    REQUIRE(t, pds_image_alloc(&img, 5, 3) == PDS_OK, "alloc 5x3");
    for (i = 0; i < 45; i++) img.rgb[i] = (float)i * 0.25f - 3.0f;
    for (i = 0; i < 6; i++) img.rgb[20 + i] = special[i];
    REQUIRE(t, pds_image_write_pfm(path, &img, &err) == PDS_OK, "write: %s", err.text);
    REQUIRE(t, pds_image_read_pfm(path, &back, &err) == PDS_OK, "read: %s", err.text);
    CHECK(t, back.width == 5 && back.height == 3, "size %dx%d", back.width, back.height);
    CHECK(t, memcmp(back.rgb, img.rgb, 45 * sizeof(float)) == 0, "pixels not bit-exact");

    /* The file itself: exact header, then the BOTTOM row (image row 2)
       first, little-endian. */
    file = timg_read_bytes(path, &size);
    REQUIRE(t, file != NULL, "cannot read back %s", path);
    CHECK(t, size == hlen + 45 * 4, "file size %lu", (unsigned long)size);
    CHECK(t, memcmp(file, header, hlen) == 0, "header is not '%s'", "PF\\n5 3\\n-1.0\\n");
    if (size == hlen + 45 * 4) {
        for (i = 0; i < 45; i++) {
            size_t row = i / 15, col = i % 15; /* file row 0 = image row 2 */
            unsigned char want[4];
            timg_put_le(want, timg_bits(img.rgb[(2 - row) * 15 + col]));
            CHECK(t, memcmp(file + hlen + 4 * i, want, 4) == 0, "raster float %lu is wrong",
                  (unsigned long)i);
        }
    }
    free(file);
    pds_image_free(&back);
    pds_image_free(&img);
    remove(path);
}

static void test_pfm_big_endian(pds_test_ctx *t)
{
    /* 2x2 big-endian PFM (positive scale), rows bottom to top. Bit patterns:
       1.0 = 3F800000, -2.5 = C0200000, 0.5 = 3F000000, 3.0 = 40400000,
       0.25 = 3E800000, 100 = 42C80000. The header also uses odd but legal
       whitespace between tokens. */
    static const uint32_t bottom[6] = {0x3F800000u, 0xC0200000u, 0x3F000000u,
                                       0x40400000u, 0x3E800000u, 0x42C80000u};
    static const char header[] = "PF\r\n2 \t 2\n\n+2.5e0\n";
    static const float want_bottom[6] = {1.0f, -2.5f, 0.5f, 3.0f, 0.25f, 100.0f};
    unsigned char buf[64 + 48];
    size_t hlen = sizeof header - 1, i;
    char path[256];
    pds_image img;
    pds_error err;

    memcpy(buf, header, hlen);
    for (i = 0; i < 6; i++) timg_put_be(buf + hlen + 4 * i, bottom[i]);
    for (i = 0; i < 6; i++) timg_put_be(buf + hlen + 24 + 4 * i, bottom[5 - i]); /* top row reversed */
    timg_path(path, sizeof path, "be.pfm");
    REQUIRE(t, timg_write_bytes(path, buf, hlen + 48), "cannot write %s", path);
    REQUIRE(t, pds_image_read_pfm(path, &img, &err) == PDS_OK, "read: %s", err.text);
    REQUIRE(t, img.width == 2 && img.height == 2, "size %dx%d", img.width, img.height);
    for (i = 0; i < 6; i++) {
        CHECK(t, img.rgb[6 + i] == want_bottom[i], "bottom row value %lu = %g, want %g",
              (unsigned long)i, img.rgb[6 + i], want_bottom[i]);
        CHECK(t, img.rgb[i] == want_bottom[5 - i], "top row value %lu = %g, want %g",
              (unsigned long)i, img.rgb[i], want_bottom[5 - i]);
    }
    pds_image_free(&img);

    /* The same values little-endian with scale -0.5 read identically. */
    memcpy(buf, "PF\n2 2\n-0.5\n", 12);
    for (i = 0; i < 6; i++) timg_put_le(buf + 12 + 4 * i, bottom[i]);
    for (i = 0; i < 6; i++) timg_put_le(buf + 12 + 24 + 4 * i, bottom[5 - i]);
    REQUIRE(t, timg_write_bytes(path, buf, 12 + 48), "cannot write %s", path);
    REQUIRE(t, pds_image_read_pfm(path, &img, &err) == PDS_OK, "read LE: %s", err.text);
    for (i = 0; i < 6; i++) CHECK(t, img.rgb[6 + i] == want_bottom[i], "LE bottom value %lu", (unsigned long)i);
    pds_image_free(&img);
    remove(path);
}

static void test_pfm_greyscale(pds_test_ctx *t)
{
    /* "Pf" 3x2 little-endian: bottom row 1, 2, 3; top row 10, 20, 30. */
    static const float bottom[3] = {1.0f, 2.0f, 3.0f}, top[3] = {10.0f, 20.0f, 30.0f};
    unsigned char buf[16 + 24];
    char path[256];
    pds_image img;
    pds_error err;
    int i, c;
    memcpy(buf, "Pf\n3 2\n-1\n", 10);
    for (i = 0; i < 3; i++) timg_put_le(buf + 10 + 4 * i, timg_bits(bottom[i]));
    for (i = 0; i < 3; i++) timg_put_le(buf + 22 + 4 * i, timg_bits(top[i]));
    timg_path(path, sizeof path, "grey.pfm");
    REQUIRE(t, timg_write_bytes(path, buf, 34), "cannot write %s", path);
    REQUIRE(t, pds_image_read_pfm(path, &img, &err) == PDS_OK, "read: %s", err.text);
    REQUIRE(t, img.width == 3 && img.height == 2, "size %dx%d", img.width, img.height);
    for (i = 0; i < 3; i++)
        for (c = 0; c < 3; c++) {
            CHECK(t, img.rgb[3 * i + c] == top[i], "top pixel %d channel %d = %g", i, c, img.rgb[3 * i + c]);
            CHECK(t, img.rgb[9 + 3 * i + c] == bottom[i], "bottom pixel %d channel %d", i, c);
        }
    pds_image_free(&img);
    remove(path);
}

/* Writes bytes to a scratch file, reads it as PFM and checks the status,
   that err names the file, that the image stays empty, and (if given) a
   word of the message. */
static void timg_expect_bad_pfm(pds_test_ctx *t, const char *what, const void *bytes, size_t n,
                                pds_status want, const char *word)
{
    char path[256];
    pds_image img;
    pds_error err;
    pds_status st;
    timg_path(path, sizeof path, "bad.pfm");
    if (!timg_write_bytes(path, bytes, n)) {
        CHECK(t, 0, "%s: cannot write scratch file", what);
        return;
    }
    img.width = 7;
    img.rgb = (float *)&img; /* must be overwritten with an empty image */
    memset(&err, 0, sizeof err);
    st = pds_image_read_pfm(path, &img, &err);
    CHECK(t, st == want, "%s: status %s, want %s (%s)", what, pds_status_string(st),
          pds_status_string(want), err.text);
    CHECK(t, err.status == want, "%s: err.status not filled", what);
    CHECK(t, strcmp(err.file, path) == 0, "%s: err.file '%s'", what, err.file);
    CHECK(t, strncmp(err.text, path, strlen(path)) == 0, "%s: text does not start with the file: %s",
          what, err.text);
    CHECK(t, img.rgb == NULL && img.width == 0, "%s: image not left empty", what);
    if (word) CHECK(t, strstr(err.message, word) != NULL, "%s: message '%s' lacks '%s'", what, err.message, word);
    remove(path);
}

/* A bad file given as a string literal (its length without the NUL). */
#define TIMG_BAD(t, what, lit, want, word) timg_expect_bad_pfm((t), (what), (lit), sizeof(lit) - 1, (want), (word))

static void test_pfm_rejects_bad_files(pds_test_ctx *t)
{
    unsigned char buf[64];
    char path[256];
    pds_image img;
    pds_error err;
    pds_status st;
    memset(buf, 0, sizeof buf);
    memcpy(buf, "PF\n2 2\n-1.0\n", 12);
    /* 2x2 RGB needs 48 raster bytes: give 47. */
    timg_expect_bad_pfm(t, "truncated raster", buf, 12 + 47, PDS_ERR_PARSE, "truncated");
    TIMG_BAD(t, "header only", "PF\n2 2\n-1.0", PDS_ERR_PARSE, "truncated");
    TIMG_BAD(t, "header cut", "PF\n2 ", PDS_ERR_PARSE, "height");
    TIMG_BAD(t, "empty file", "", PDS_ERR_PARSE, "PF");
    TIMG_BAD(t, "bad magic P6", "P6\n2 2\n255\n", PDS_ERR_PARSE, "not a PFM file");
    TIMG_BAD(t, "magic glued", "PFX2 2\n-1\n", PDS_ERR_PARSE, "not a PFM file");
    TIMG_BAD(t, "zero scale", "PF\n1 1\n0.000\n123456789012", PDS_ERR_PARSE, "zero");
    TIMG_BAD(t, "minus zero scale", "PF\n1 1\n-0e5\n123456789012", PDS_ERR_PARSE, "zero");
    TIMG_BAD(t, "scale not a number", "PF\n1 1\n-1.0x\n123456789012", PDS_ERR_PARSE, "scale");
    TIMG_BAD(t, "zero width", "PF\n0 1\n-1\n", PDS_ERR_PARSE, "width");
    TIMG_BAD(t, "negative height", "PF\n1 -4\n-1\n", PDS_ERR_PARSE, "height");
    TIMG_BAD(t, "width not a number", "PF\nab 1\n-1\n", PDS_ERR_PARSE, "width");
    TIMG_BAD(t, "huge width", "PF\n16385 1\n-1\n", PDS_ERR_LIMIT, "16384");
    TIMG_BAD(t, "overflowing height", "PF\n1 99999999999999999999999\n-1\n", PDS_ERR_LIMIT, "height");

    /* The location of a header error: line 2, column 3 for the height. */
    timg_path(path, sizeof path, "loc.pfm");
    REQUIRE(t, timg_write_bytes(path, "PF\n4 x\n-1\n", 10), "write");
    st = pds_image_read_pfm(path, &img, &err);
    CHECK(t, st == PDS_ERR_PARSE && err.line == 2 && err.column == 3, "status %d at %d:%d (%s)", (int)st,
          err.line, err.column, err.text);
    remove(path);

    /* A missing file is an I/O error naming the file. */
    st = pds_image_read_pfm(path, &img, &err);
    CHECK(t, st == PDS_ERR_IO && strcmp(err.file, path) == 0, "missing file: %s", err.text);
}

/* ---------------------------------------------------------------- PNG */

static void test_crc_adler_known_values(pds_test_ctx *t)
{
    unsigned char *big;
    size_t i, n = 1u << 20;
    CHECK(t, pds__crc32_update(0, "IEND", 4) == 0xAE426082u, "CRC(IEND) = %08lx",
          (unsigned long)pds__crc32_update(0, "IEND", 4));
    CHECK(t, pds__crc32_update(0, "123456789", 9) == 0xCBF43926u, "CRC check value");
    /* Running CRC: two halves give the whole. */
    CHECK(t, pds__crc32_update(pds__crc32_update(0, "1234", 4), "56789", 5) == 0xCBF43926u,
          "CRC continued over two calls");
    CHECK(t, pds__adler32_update(1, "Wikipedia", 9) == 0x11E60398u, "Adler(Wikipedia) = %08lx",
          (unsigned long)pds__adler32_update(1, "Wikipedia", 9));
    /* 1 MiB of 0xFF stresses the deferred modulo; compare with the naive sum. */
    big = (unsigned char *)malloc(n);
    REQUIRE(t, big != NULL, "malloc");
    for (i = 0; i < n; i++) big[i] = (unsigned char)(i % 7 == 0 ? 0x00 : 0xFF);
    CHECK(t, pds__adler32_update(1, big, n) == timg_adler_naive(big, n), "Adler on 1 MiB");
    CHECK(t, pds__crc32_update(0, big, n) == timg_crc_bitwise(big, n), "CRC on 1 MiB");
    free(big);
}

static void test_srgb_encode_key_points(pds_test_ctx *t)
{
    CHECK(t, pds__srgb_encode(0.0) == 0.0, "encode(0)");
    CHECK_NEAR(t, pds__srgb_encode(0.0031308), 0.040449936, 1e-15);
    CHECK_NEAR(t, pds__srgb_encode(0.5), 0.7353569830524495, 1e-15);
    CHECK_NEAR(t, pds__srgb_encode(1.0), 1.0, 1e-15);
    /* Both branches meet at the threshold (to 1e-7: the standard's
       constants are rounded). */
    CHECK_NEAR(t, 1.055 * pow(0.0031308, 1.0 / 2.4) - 0.055, pds__srgb_encode(0.0031308), 1e-7);
    CHECK(t, pds__srgb_encode(-1.0) == 0.0, "negative clamps to 0");
    CHECK(t, pds__srgb_encode(7.0) == 1.0, "above 1 clamps to 1");
    CHECK(t, pds__srgb_encode(nan("")) == 0.0, "NaN gives 0");
}

static void test_png_small_image_decodes_to_tone_mapped_bytes(pds_test_ctx *t)
{
    /* 4x2 image written with exposure +1 stop (x2). Expected bytes computed
       by hand: 255 * srgb(2 v), rounded: 0.25 -> 0.5 -> 188; 0.09 -> 0.18
       -> 118; 0.0005 -> 0.001 -> 3 (linear segment); 0.125 -> 0.25 -> 137;
       0.375 -> 0.75 -> 225; 0.005 -> 0.01 -> 25; >= 0.5 -> 255; negative,
       -inf and NaN -> 0. */
    static const float in[24] = {0.25f, 0.09f, 0.0005f, 0.125f, 0.375f, 0.005f, 0.5f, 3.0f, 0.0f,
                                 -1.0f, 0.0f, 0.0f, /* NaN, +inf, -inf patched below */
                                 0.0f, 0.0f, 0.0f, 0.25f, 0.25f, 0.25f, 0.09f, 0.005f, 0.375f,
                                 0.0f, 0.5f, 0.125f};
    static const unsigned char want[24] = {188, 118, 3, 137, 225, 25, 255, 255, 0, 0, 0, 255,
                                           0, 0, 0, 188, 188, 188, 118, 25, 225, 0, 255, 137};
    static const unsigned char sig[8] = {0x89, 0x50, 0x4E, 0x47, 0x0D, 0x0A, 0x1A, 0x0A};
    char path[256];
    pds_image img;
    pds_error err;
    unsigned char *file;
    size_t size;
    timg_png png;
    const char *why;
    int i;

    REQUIRE(t, pds_image_alloc(&img, 4, 2) == PDS_OK, "alloc");
    memcpy(img.rgb, in, sizeof in);
    img.rgb[10] = (float)nan("");
    img.rgb[11] = (float)HUGE_VAL;
    img.rgb[12] = -(float)HUGE_VAL;
    timg_path(path, sizeof path, "small.png");
    REQUIRE(t, pds_image_write_png(path, &img, 1.0, &err) == PDS_OK, "write: %s", err.text);
    file = timg_read_bytes(path, &size);
    REQUIRE(t, file != NULL, "read back");
    CHECK(t, size >= 8 && memcmp(file, sig, 8) == 0, "PNG signature");
    why = timg_png_decode(file, size, &png);
    CHECK(t, why == NULL, "decode: %s", why ? why : "");
    if (!why) {
        CHECK(t, png.width == 4 && png.height == 2, "size %dx%d", png.width, png.height);
        for (i = 0; i < 24; i++) CHECK(t, png.rgb[i] == want[i], "byte %d = %d, want %d", i, png.rgb[i], want[i]);
        /* 26 raw bytes: fixed Huffman codes beat a dynamic block's header. */
        CHECK(t, png.blocks[1] == 1 && png.blocks[0] + png.blocks[2] == 0, "blocks: %d stored, %d fixed, %d dynamic",
              png.blocks[0], png.blocks[1], png.blocks[2]);
    }
    /* Never longer than the stored layout: 8 + 25 + 12 + (2 + 5 + 26 + 4) + 12. */
    CHECK(t, size <= 8 + 25 + 12 + 37 + 12, "file size %lu", (unsigned long)size);
    free(png.rgb);
    free(file);
    pds_image_free(&img);
    remove(path);
}

/* Writes a W x H pattern with exposure 0 through pds_image_write and
   checks the decoded bytes against an independent tone mapping. */
static void timg_png_size_case(pds_test_ctx *t, int W, int H)
{
    char path[256];
    pds_image img;
    pds_error err;
    unsigned char *rgb;
    size_t i;
    int w = 0, h = 0, bad = 0;

    REQUIRE(t, pds_image_alloc(&img, W, H) == PDS_OK, "alloc %dx%d", W, H);
    for (i = 0; i < (size_t)W * H * 3; i++) img.rgb[i] = (float)(i % 251) / 200.0f;
    timg_path(path, sizeof path, "wide.png");
    REQUIRE(t, pds_image_write(path, &img, 0.0, &err) == PDS_OK, "write: %s", err.text);
    rgb = timg_png_read_rgb(path, &w, &h);
    CHECK(t, rgb != NULL, "%dx%d does not decode", W, H);
    if (rgb) {
        CHECK(t, w == W && h == H, "size %dx%d", w, h);
        for (i = 0; i < (size_t)W * H * 3 && bad < 5; i++) {
            int want = (int)floor(timg_srgb(img.rgb[i]) * 255.0 + 0.5);
            if (rgb[i] != want) {
                CHECK(t, 0, "%dx%d byte %lu = %d, want %d", W, H, (unsigned long)i, rgb[i], want);
                bad++;
            }
        }
    }
    free(rgb);
    pds_image_free(&img);
    remove(path);
}

static void test_png_round_trips_odd_sizes(pds_test_ctx *t)
{
    timg_png_size_case(t, 16000, 3); /* rows longer than a stored block */
    timg_png_size_case(t, 1456, 15); /* 65535 raw bytes */
    timg_png_size_case(t, 1456, 30);
    timg_png_size_case(t, 1, 1);     /* the smallest image */
    timg_png_size_case(t, 2, 1);     /* one pixel to the left, none above */
    timg_png_size_case(t, 1, 70);    /* one pixel per row: Sub has nothing to the left */
    timg_png_size_case(t, PDS_MAX_RESOLUTION, 1);
}

/* A 512x300 test card, in bands of rows: black (None wins), a horizontal
   ramp that changes every row (Sub), rows repeating a noisy row (Up), a
   smooth 2-D blend (Average), diagonal stripes (Paeth), flat grey and, at
   the bottom, noise uniform over the byte values, which no code can
   shrink (stored blocks).
   Noise is a fixed LCG, so the image is the same on every run. */
static void timg_test_card(pds_image *img)
{
    uint32_t lcg = 12345u, row_seed = 0;
    int x, y, c;
    for (y = 0; y < img->height; y++) {
        if (y % 8 == 0) row_seed = lcg;
        for (x = 0; x < img->width; x++)
            for (c = 0; c < 3; c++) {
                float *p = img->rgb + 3 * ((size_t)y * img->width + x) + c;
                double v;
                lcg = lcg * 1664525u + 1013904223u;
                if (y < 20) {
                    v = 0.0;
                } else if (y < 60) {
                    v = (double)((x * (y - 19) + 40 * c) % 512) / 511.0;
                } else if (y < 100) {
                    uint32_t r = row_seed + (uint32_t)(x * 3 + c) * 2654435761u;
                    v = (double)(r >> 24) / 255.0;
                } else if (y < 150) {
                    v = 0.2 + 0.3 * sin(x * 0.021 + c) * cos(y * 0.033) + 0.001 * (double)(lcg >> 29);
                } else if (y < 200) {
                    v = ((x + 2 * y + 7 * c) / 9) % 3 == 0 ? 0.9 : 0.05 * (double)((x - y) & 7);
                } else if (y < 210) {
                    v = 0.18;
                } else { /* linear values whose sRGB bytes are uniform */
                    v = (double)(lcg >> 24) / 255.0;
                    v = v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4);
                }
                *p = (float)v;
            }
    }
}

static void test_png_round_trip_test_card_uses_every_filter_and_block_type(pds_test_ctx *t)
{
    pds_image img;
    timg_png png, again;
    size_t i, size, size2;
    const char *why;
    int bad = 0, k;
    REQUIRE(t, pds_image_alloc(&img, 512, 300) == PDS_OK, "alloc");
    timg_test_card(&img);
    why = timg_png_round_trip(&img, 0.0, &png, &size);
    REQUIRE(t, why == NULL, "decode: %s", why);
    CHECK(t, png.width == 512 && png.height == 300, "size %dx%d", png.width, png.height);
    for (i = 0; i < (size_t)512 * 300 * 3 && bad < 5; i++) {
        int want = (int)floor(timg_srgb(img.rgb[i]) * 255.0 + 0.5);
        if (png.rgb[i] != want) {
            CHECK(t, 0, "byte %lu = %d, want %d", (unsigned long)i, png.rgb[i], want);
            bad++;
        }
    }
    for (k = 0; k < 5; k++) CHECK(t, png.filters[k] > 0, "no row used filter type %d", k);
    CHECK(t, png.blocks[2] >= 1, "%d dynamic blocks", png.blocks[2]);
    CHECK(t, png.blocks[0] >= 1, "no stored block for the noise");
    CHECK(t, png.matches > 1000, "only %lu matches", (unsigned long)png.matches);

    /* Same image, same bytes. */
    why = timg_png_round_trip(&img, 0.0, &again, &size2);
    CHECK(t, why == NULL && size2 == size && again.idat_len == png.idat_len, "second write differs");
    if (!why) CHECK(t, memcmp(again.rgb, png.rgb, (size_t)512 * 300 * 3) == 0, "second decode differs");
    free(again.rgb);

    /* Exposure -3 stops: darker, different filters, still exact. */
    free(png.rgb);
    why = timg_png_round_trip(&img, -3.0, &png, &size);
    REQUIRE(t, why == NULL, "decode at -3 stops: %s", why);
    for (i = 0, bad = 0; i < (size_t)512 * 300 * 3 && bad < 5; i++) {
        int want = (int)floor(timg_srgb(img.rgb[i] * 0.125) * 255.0 + 0.5);
        if (png.rgb[i] != want) {
            CHECK(t, 0, "-3 stops: byte %lu = %d, want %d", (unsigned long)i, png.rgb[i], want);
            bad++;
        }
    }
    free(png.rgb);
    pds_image_free(&img);
}

static void test_png_zlib_header_and_adler32_trailer(pds_test_ctx *t)
{
    char path[256];
    pds_image img;
    pds_error err;
    unsigned char *file, *z = NULL, *raw;
    size_t size, pos = 8, zlen = 0, raw_len = 40 * (1 + 3 * 64);
    tinf s;
    const char *why;
    REQUIRE(t, pds_image_alloc(&img, 64, 40) == PDS_OK, "alloc");
    timg_pattern(&img, 1);
    timg_path(path, sizeof path, "zlib.png");
    REQUIRE(t, pds_image_write_png(path, &img, 0.0, &err) == PDS_OK, "write: %s", err.text);
    file = timg_read_bytes(path, &size);
    remove(path);
    REQUIRE(t, file != NULL, "read back");
    while (pos + 12 <= size) { /* the one IDAT's data */
        size_t len = timg_get_be(file + pos);
        if (memcmp(file + pos + 4, "IDAT", 4) == 0) {
            z = file + pos + 8;
            zlen = len;
        }
        pos += 12 + len;
    }
    REQUIRE(t, z != NULL && zlen >= 6, "no IDAT");
    CHECK(t, z[0] == 0x78 && z[1] == 0x9C, "zlib header %02x %02x", z[0], z[1]);
    CHECK(t, (z[0] * 256 + z[1]) % 31 == 0, "FCHECK: 0x%02x%02x is not a multiple of 31", z[0], z[1]);
    CHECK(t, (z[1] & 0x20) == 0, "FDICT set");
    raw = (unsigned char *)malloc(raw_len);
    REQUIRE(t, raw != NULL, "malloc");
    why = timg_zlib_inflate(z, zlen, raw, raw_len, &s);
    CHECK(t, why == NULL && s.len == raw_len, "inflate: %s, %lu bytes", why ? why : "ok", (unsigned long)s.len);
    if (!why)
        CHECK(t, timg_get_be(z + zlen - 4) == timg_adler_naive(raw, raw_len), "trailer %08lx, Adler-32 %08lx",
              (unsigned long)timg_get_be(z + zlen - 4), (unsigned long)timg_adler_naive(raw, raw_len));
    /* The decoder does check the trailer: flip one of its bits. */
    z[zlen - 1] ^= 1;
    why = timg_zlib_inflate(z, zlen, raw, raw_len, &s);
    CHECK(t, why && strcmp(why, "bad Adler-32") == 0, "corrupt trailer: %s", why ? why : "accepted");
    free(raw);
    free(file);
    pds_image_free(&img);
}

static void test_png_smooth_gradient_compresses_well(pds_test_ctx *t)
{
    /* 256x256 linear ramps: raw stream 256 * (1 + 768) = 196864 bytes.
       Sub/Up/Average turn a smooth ramp into a few small differences, and
       LZ77 + Huffman squeeze those: require 20:1 (it gets more). */
    pds_image img;
    timg_png png;
    size_t size, raw = 256 * (1 + 768);
    const char *why;
    int x, y;
    REQUIRE(t, pds_image_alloc(&img, 256, 256) == PDS_OK, "alloc");
    for (y = 0; y < 256; y++)
        for (x = 0; x < 256; x++) {
            float *p = img.rgb + 3 * (y * 256 + x);
            p[0] = (float)x / 255.0f;
            p[1] = (float)y / 255.0f;
            p[2] = (float)(x + y) / 510.0f;
        }
    why = timg_png_round_trip(&img, 0.0, &png, &size);
    CHECK(t, why == NULL, "decode: %s", why ? why : "");
    CHECK(t, size * 20 < raw, "%lu bytes for %lu raw: ratio %.1f", (unsigned long)size, (unsigned long)raw,
          (double)raw / (double)size);
    free(png.rgb);
    pds_image_free(&img);
}

/* Deflates data[0..n) with pds__deflate wrapped as zlib and inflates it
   with the test decoder; checks the bytes come back. Returns the stream. */
static unsigned char *timg_deflate_round_trip(pds_test_ctx *t, const char *what, const unsigned char *data,
                                              size_t n, tinf *s, size_t *zlen)
{
    pds__bitout o;
    unsigned char hdr[2] = {0x78, 0x9C}, trailer[4], *back;
    const char *why;
    memset(&o, 0, sizeof o);
    pds__out_bytes(&o, hdr, 2);
    pds__deflate(&o, data, n);
    timg_put_be(trailer, pds__adler32_update(1, data, n));
    pds__out_bytes(&o, trailer, 4);
    CHECK(t, !o.nomem, "%s: out of memory", what);
    back = (unsigned char *)malloc(n + 1);
    if (!back || o.nomem) {
        free(back);
        free(o.buf);
        return NULL;
    }
    why = timg_zlib_inflate(o.buf, o.len, back, n, s);
    CHECK(t, why == NULL, "%s: %s", what, why ? why : "");
    CHECK(t, s->len == n && (n == 0 || memcmp(back, data, n) == 0), "%s: %lu bytes back of %lu, or they differ",
          what, (unsigned long)s->len, (unsigned long)n);
    free(back);
    *zlen = o.len;
    return o.buf;
}

static void test_deflate_round_trips_edge_cases(pds_test_ctx *t)
{
    size_t n = 300000, i, zlen, zlen2;
    unsigned char *data = (unsigned char *)malloc(n), *z, *z2, small[80];
    uint32_t lcg = 7u;
    int len = 2;
    tinf s;
    REQUIRE(t, data != NULL, "malloc");

    /* Empty input: one final block with only end-of-block. */
    memset(data, 0, n);
    z = timg_deflate_round_trip(t, "empty", data, 0, &s, &zlen);
    CHECK(t, s.blocks[0] + s.blocks[1] + s.blocks[2] == 1, "empty: %d blocks", s.blocks[0] + s.blocks[1] + s.blocks[2]);
    free(z);
    data[0] = 'a';
    free(timg_deflate_round_trip(t, "one byte", data, 1, &s, &zlen));

    /* One distinct byte: one literal, then copies at distance 1, so the
       distance code has a single used symbol. */
    memset(data, 'a', n);
    z = timg_deflate_round_trip(t, "300000 x 'a'", data, n, &s, &zlen);
    CHECK(t, zlen < 2000 && s.matches > 1000, "run of one byte: %lu bytes, %lu matches", (unsigned long)zlen,
          (unsigned long)s.matches);
    free(z);

    /* No match at all: a sequence over 4 letters with no 3-byte string
       twice (built greedily), so the block is all literals and no
       distance code is used, yet 2 bits a letter beat the fixed code. */
    small[0] = small[1] = 0;
    for (;;) {
        int c, ok = 0;
        for (c = 3; c >= 0 && !ok; c--) {
            int j;
            ok = 1;
            for (j = 0; j + 2 < len && ok; j++)
                if (small[j] == small[len - 2] && small[j + 1] == small[len - 1] && small[j + 2] == c) ok = 0;
            if (ok) small[len] = (unsigned char)c;
        }
        if (!ok || len + 1 >= (int)sizeof small) break;
        len++;
    }
    CHECK(t, len >= 60, "greedy sequence only %d long", len);
    z = timg_deflate_round_trip(t, "no repeats", small, (size_t)len, &s, &zlen);
    CHECK(t, s.matches == 0 && s.blocks[2] == 1, "no repeats: %lu matches, %d dynamic blocks",
          (unsigned long)s.matches, s.blocks[2]);
    free(z);

    /* Noise: stored blocks, several of them (65535 bytes at most each). */
    for (i = 0; i < n; i++) {
        lcg = lcg * 1664525u + 1013904223u;
        data[i] = (unsigned char)(lcg >> 24);
    }
    z = timg_deflate_round_trip(t, "noise", data, n, &s, &zlen);
    CHECK(t, s.blocks[0] >= 5 && zlen < n + n / 1000 + 64, "noise: %d stored blocks, %lu bytes", s.blocks[0],
          (unsigned long)zlen);
    free(z);

    /* Long-range copies: noise repeating with period 32767, the longest
       distance the compressor uses: 258-byte matches all the way. */
    for (i = 32767; i < 132767; i++) data[i] = data[i - 32767];
    z = timg_deflate_round_trip(t, "window", data, 132767, &s, &zlen);
    CHECK(t, zlen < 40000 && s.matches > 300, "window: %lu bytes, %lu matches", (unsigned long)zlen,
          (unsigned long)s.matches);
    /* Deterministic. */
    z2 = timg_deflate_round_trip(t, "window again", data, 132767, &s, &zlen2);
    CHECK(t, z && z2 && zlen == zlen2 && memcmp(z, z2, zlen) == 0, "two runs differ");
    free(z);
    free(z2);
    free(data);
}

/* The optimal (unlimited) Huffman cost sum f_i * len_i, computed as the
   sum of the merged weights while repeatedly joining the two lightest. */
static uint64_t timg_huffman_cost(const uint32_t *freq, int n)
{
    uint64_t w[300], cost = 0;
    int m = 0, i;
    for (i = 0; i < n; i++)
        if (freq[i]) w[m++] = freq[i];
    while (m > 1) {
        int a = 0, b = 1, k;
        if (w[b] < w[a]) a = 1, b = 0;
        for (k = 2; k < m; k++) {
            if (w[k] < w[a]) b = a, a = k;
            else if (w[k] < w[b]) b = k;
        }
        w[a] += w[b];
        cost += w[a];
        w[b] = w[--m];
    }
    return cost;
}

/* Checks lengths from pds__huff_lengths: 0 exactly for unused symbols, at
   most limit, Kraft sum exactly 1 (1/2 for one symbol), and a more
   frequent symbol never gets a longer code. Returns sum f * len. */
static uint64_t timg_check_lengths(pds_test_ctx *t, const char *what, const uint32_t *freq, int n, int limit)
{
    unsigned char len[300];
    uint64_t kraft = 0, cost = 0, one = (uint64_t)1 << 40;
    int i, j, used = 0, maxlen = 0, bad = 0;
    pds__huff_lengths(freq, n, limit, len);
    for (i = 0; i < n; i++) {
        used += freq[i] > 0;
        if ((freq[i] > 0) != (len[i] > 0)) bad++;
        if (len[i] > maxlen) maxlen = len[i];
        if (len[i]) kraft += one >> len[i];
        cost += (uint64_t)freq[i] * len[i];
        for (j = 0; j < n; j++)
            if (freq[i] > 0 && freq[j] > freq[i] && len[j] > len[i]) bad++;
    }
    CHECK(t, bad == 0, "%s: %d symbols with a wrong or non-monotone length", what, bad);
    CHECK(t, maxlen <= limit, "%s: a length of %d over the limit %d", what, maxlen, limit);
    if (used >= 2) CHECK(t, kraft == one, "%s: Kraft sum %.17g", what, (double)kraft / (double)one);
    if (used == 1) CHECK(t, kraft == one / 2, "%s: one symbol, Kraft sum %.17g", what, (double)kraft / (double)one);
    if (used == 0) CHECK(t, maxlen == 0, "%s: lengths for no symbols", what);
    return cost;
}

static void test_huffman_lengths_are_limited_and_complete(pds_test_ctx *t)
{
    uint32_t freq[286];
    uint64_t cost;
    uint32_t lcg = 99u;
    int i, k;
    /* Fibonacci counts make the Huffman tree a chain as deep as there
       are symbols: 40 symbols want depth 39. */
    memset(freq, 0, sizeof freq);
    freq[0] = freq[1] = 1;
    for (i = 2; i < 40; i++) freq[i] = freq[i - 1] + freq[i - 2];
    timg_check_lengths(t, "fibonacci 40, limit 15", freq, 40, 15);
    cost = timg_check_lengths(t, "fibonacci 40, unlimited", freq, 40, 60);
    CHECK(t, cost == timg_huffman_cost(freq, 40), "unlimited cost %llu, Huffman %llu", (unsigned long long)cost,
          (unsigned long long)timg_huffman_cost(freq, 40));
    /* The code-length alphabet: 19 symbols, limit 7. */
    timg_check_lengths(t, "fibonacci 19, limit 7", freq, 19, 7);
    /* Spread over a literal/length-sized alphabet, with holes. */
    memset(freq, 0, sizeof freq);
    for (i = 0; i < 32; i++) freq[i * 9] = i < 2 ? 1 : 0;
    for (i = 2; i < 32; i++) freq[i * 9] = freq[(i - 1) * 9] + freq[(i - 2) * 9];
    timg_check_lengths(t, "fibonacci 32 of 286, limit 15", freq, 286, 15);
    /* Random counts: when the Huffman depth fits, the cost is optimal. */
    for (k = 0; k < 20; k++) {
        for (i = 0; i < 286; i++) {
            lcg = lcg * 1664525u + 1013904223u;
            freq[i] = (lcg >> 28) < 3 ? 0 : 1 + (lcg >> 20) % (k < 10 ? 50 : 5000);
        }
        cost = timg_check_lengths(t, "random", freq, 286, 15);
        CHECK(t, cost == timg_huffman_cost(freq, 286), "random %d: cost %llu, Huffman %llu", k,
              (unsigned long long)cost, (unsigned long long)timg_huffman_cost(freq, 286));
    }
    /* Degenerate tables. */
    memset(freq, 0, sizeof freq);
    timg_check_lengths(t, "no symbol", freq, 30, 15);
    freq[7] = 1000;
    timg_check_lengths(t, "one symbol", freq, 30, 15);
    freq[29] = 1;
    timg_check_lengths(t, "two symbols", freq, 30, 15);
    /* All 19 used with equal counts under limit 7; 2^limit = symbols. */
    for (i = 0; i < 19; i++) freq[i] = 5;
    timg_check_lengths(t, "19 equal", freq, 19, 7);
    for (i = 0; i < 16; i++) freq[i] = (uint32_t)1 << i;
    timg_check_lengths(t, "16 powers of two, limit 4", freq, 16, 4);
}

/* --------------------------------------------------------- writing files */

static void test_image_write_picks_format_by_extension(pds_test_ctx *t)
{
    char path[256];
    pds_image img;
    pds_error err;
    unsigned char *file;
    size_t size;
    pds_status st;
    REQUIRE(t, pds_image_alloc(&img, 2, 2) == PDS_OK, "alloc");

    timg_path(path, sizeof path, "upper.PNG");
    REQUIRE(t, pds_image_write(path, &img, 0.0, &err) == PDS_OK, ".PNG: %s", err.text);
    file = timg_read_bytes(path, &size);
    CHECK(t, file && size > 8 && file[1] == 'P' && file[2] == 'N' && file[3] == 'G', ".PNG gives a PNG");
    free(file);
    remove(path);

    timg_path(path, sizeof path, "mixed.Pfm");
    REQUIRE(t, pds_image_write(path, &img, 0.0, &err) == PDS_OK, ".Pfm: %s", err.text);
    file = timg_read_bytes(path, &size);
    CHECK(t, file && size == 12 + 48 && memcmp(file, "PF\n2 2\n-1.0\n", 12) == 0, ".Pfm gives a PFM");
    free(file);
    remove(path);

    timg_path(path, sizeof path, "picture.jpg");
    st = pds_image_write(path, &img, 0.0, &err);
    CHECK(t, st == PDS_ERR_INVALID_ARG, ".jpg: status %d", (int)st);
    CHECK(t, strstr(err.message, ".pfm") && strstr(err.message, ".png"), ".jpg message: %s", err.message);
    CHECK(t, strcmp(err.file, path) == 0, ".jpg: err names the file");
    CHECK(t, !timg_file_exists(path), ".jpg: a file was created");

    /* The extension is the last component's: "x.png/out" has none. */
    st = pds_image_write("/tmp/x.png/out", &img, 0.0, &err);
    CHECK(t, st == PDS_ERR_INVALID_ARG, "no extension: status %d", (int)st);
    st = pds_image_write("/tmp/out.pngx", &img, 0.0, &err);
    CHECK(t, st == PDS_ERR_INVALID_ARG, ".pngx: status %d", (int)st);
    pds_image_free(&img);
}

static void test_image_failed_write_leaves_no_file(pds_test_ctx *t)
{
    char dir[256], path[512], sub[512];
    pds_image img;
    pds_error err;
    pds_status st;
    REQUIRE(t, pds_image_alloc(&img, 3, 2) == PDS_OK, "alloc");

    /* Into a directory that does not exist: I/O error, nothing created. */
    timg_path(dir, sizeof dir, "no_such_dir");
    snprintf(path, sizeof path, "%s/out.pfm", dir);
    st = pds_image_write(path, &img, 0.0, &err);
    CHECK(t, st == PDS_ERR_IO && strcmp(err.file, path) == 0, "pfm: status %d (%s)", (int)st, err.text);
    snprintf(path, sizeof path, "%s/out.png", dir);
    st = pds_image_write(path, &img, 0.0, &err);
    CHECK(t, st == PDS_ERR_IO, "png: status %d (%s)", (int)st, err.text);
    CHECK(t, !timg_file_exists(dir), "the directory appeared");

    /* Onto an existing directory: the temporary file is written, the
       rename fails, and the temporary must be gone afterwards. */
    timg_path(dir, sizeof dir, "dir");
    REQUIRE(t, mkdir(dir, 0700) == 0, "mkdir %s", dir);
    snprintf(sub, sizeof sub, "%s/sub.png", dir);
    REQUIRE(t, mkdir(sub, 0700) == 0, "mkdir %s", sub);
    st = pds_image_write(sub, &img, 0.0, &err);
    CHECK(t, st == PDS_ERR_IO, "onto a directory: status %d", (int)st);
    CHECK(t, timg_dir_count(dir) == 1, "%d entries left in %s", timg_dir_count(dir), dir);

    /* A good write leaves exactly the one file. */
    snprintf(path, sizeof path, "%s/good.pfm", dir);
    CHECK(t, pds_image_write(path, &img, 0.0, &err) == PDS_OK, "good write: %s", err.text);
    CHECK(t, timg_dir_count(dir) == 2, "%d entries after a good write", timg_dir_count(dir));
    remove(path);
    rmdir(sub);
    rmdir(dir);
    pds_image_free(&img);
}

static void test_image_alloc_and_writers_check_arguments(pds_test_ctx *t)
{
    pds_image img, empty = {0, 0, NULL};
    pds_error err;
    char path[256];
    int i, zero = 1;
    CHECK(t, pds_image_alloc(&img, 0, 4) == PDS_ERR_INVALID_ARG && img.rgb == NULL, "0 width");
    CHECK(t, pds_image_alloc(&img, 4, -1) == PDS_ERR_INVALID_ARG && img.rgb == NULL, "negative height");
    CHECK(t, pds_image_alloc(&img, PDS_MAX_RESOLUTION + 1, 1) == PDS_ERR_LIMIT, "over the limit");
    REQUIRE(t, pds_image_alloc(&img, 3, 5) == PDS_OK, "alloc 3x5");
    CHECK(t, img.width == 3 && img.height == 5, "size");
    for (i = 0; i < 45; i++) zero &= img.rgb[i] == 0.0f;
    CHECK(t, zero, "pixels start at zero");
    pds_image_free(&img);
    CHECK(t, img.rgb == NULL && img.width == 0, "free empties the image");
    pds_image_free(&img); /* twice is harmless */
    pds_image_free(NULL);

    timg_path(path, sizeof path, "empty.pfm");
    CHECK(t, pds_image_write_pfm(path, &empty, &err) == PDS_ERR_INVALID_ARG, "empty pfm");
    CHECK(t, pds_image_write_png(path, &empty, 0.0, &err) == PDS_ERR_INVALID_ARG, "empty png");
    CHECK(t, !timg_file_exists(path), "nothing written for an empty image");
    REQUIRE(t, pds_image_alloc(&img, 1, 1) == PDS_OK, "alloc");
    CHECK(t, pds_image_write_png(path, &img, nan(""), &err) == PDS_ERR_INVALID_ARG, "NaN exposure");
    pds_image_free(&img);
}

/* ------------------------------------------------------------- metrics */

static void test_rmse_hand_computed(pds_test_ctx *t)
{
    /* 2x2: 12 channel values; two differ, by 0.5 and 1.5 (exact in
       float): sum of squares 0.25 + 2.25 = 2.5, mean 2.5/12, RMSE
       sqrt(5/24) = 0.45643546458763842. */
    pds_image a, b, c;
    int i;
    REQUIRE(t, pds_image_alloc(&a, 2, 2) == PDS_OK && pds_image_alloc(&b, 2, 2) == PDS_OK, "alloc");
    for (i = 0; i < 12; i++) a.rgb[i] = b.rgb[i] = (float)i * 0.125f;
    b.rgb[4] += 0.5f;
    b.rgb[11] -= 1.5f;
    CHECK_NEAR(t, pds_image_rmse(&a, &b), 0.45643546458763842, 1e-15);
    CHECK_NEAR(t, pds_image_rmse(&b, &a), 0.45643546458763842, 1e-15);
    CHECK(t, pds_image_rmse(&a, &a) == 0.0, "RMSE of an image with itself");
    REQUIRE(t, pds_image_alloc(&c, 4, 1) == PDS_OK, "alloc");
    CHECK(t, pds_image_rmse(&a, &c) == -1.0, "sizes differ -> -1");
    CHECK(t, pds_image_ssim(&a, &c) == -1.0, "SSIM sizes differ -> -1");
    pds_image_free(&c);
    CHECK(t, pds_image_rmse(&a, &c) == -1.0, "empty -> -1");
    CHECK(t, pds_image_ssim(&c, &c) == -1.0, "SSIM empty -> -1");
    pds_image_free(&a);
    pds_image_free(&b);
}

static void test_ssim_identical_is_one(pds_test_ctx *t)
{
    static const int sizes[4][2] = {{40, 30}, {11, 11}, {5, 8}, {1, 1}};
    int k;
    for (k = 0; k < 4; k++) {
        pds_image a;
        double s;
        REQUIRE(t, pds_image_alloc(&a, sizes[k][0], sizes[k][1]) == PDS_OK, "alloc");
        timg_pattern(&a, 0);
        s = pds_image_ssim(&a, &a);
        CHECK(t, fabs(s - 1.0) <= 1e-12, "%dx%d: SSIM(a, a) = %.17g", a.width, a.height, s);
        pds_image_free(&a);
    }
}

static void test_ssim_matches_direct_and_scikit_image(pds_test_ctx *t)
{
    /* Reference values, computed once (Debian bookworm python3-skimage 0.19.3,
       numpy 1.24.2) on the same two patterns (timg_pattern), luminance Y as in
       pds.h:
         24x19: skimage.metrics.structural_similarity(Ya, Yb,
                gaussian_weights=True, sigma=1.5, use_sample_covariance=False,
                data_range=1.0) = 0.57082689650189122
         7x9 and 8x12 (window clipped to 7): scipy.ndimage.gaussian_filter
                (sigma 1.5, truncate 2.0 -> 7 taps) of x, y, x^2, y^2, xy,
                the SSIM map cropped by 3 on each side, mean =
                0.42520299132850653 and 0.47927628504959757. */
    static const struct { int w, h; double ref; } cases[3] = {
        {24, 19, 0.57082689650189122}, {7, 9, 0.42520299132850653}, {8, 12, 0.47927628504959757}};
    int k;
    for (k = 0; k < 3; k++) {
        pds_image a, b;
        double s, direct;
        REQUIRE(t, pds_image_alloc(&a, cases[k].w, cases[k].h) == PDS_OK, "alloc");
        REQUIRE(t, pds_image_alloc(&b, cases[k].w, cases[k].h) == PDS_OK, "alloc");
        timg_pattern(&a, 0);
        timg_pattern(&b, 1);
        s = pds_image_ssim(&a, &b);
        direct = timg_ssim_direct(&a, &b);
        CHECK(t, fabs(s - direct) <= 1e-12, "%dx%d: SSIM %.17g, direct %.17g", a.width, a.height, s, direct);
        CHECK(t, fabs(s - cases[k].ref) <= 1e-9, "%dx%d: SSIM %.17g, scikit-image %.17g", a.width,
              a.height, s, cases[k].ref);
        pds_image_free(&a);
        pds_image_free(&b);
    }
}

static void test_ssim_constant_images_closed_form(pds_test_ctx *t)
{
    /* Constant images: all variances vanish, so SSIM = (2 ya yb + C1) /
       (ya^2 + yb^2 + C1) with C1 = 1e-4 and Y the encoded grey level. */
    static const float levels[3][2] = {{0.5f, 0.25f}, {0.0f, 1.0f}, {0.001f, 0.002f}};
    static const int sizes[2][2] = {{20, 16}, {3, 3}};
    int k, s, i;
    for (k = 0; k < 3; k++)
        for (s = 0; s < 2; s++) {
            pds_image a, b;
            double ya = timg_srgb(levels[k][0]), yb = timg_srgb(levels[k][1]), want, got;
            REQUIRE(t, pds_image_alloc(&a, sizes[s][0], sizes[s][1]) == PDS_OK, "alloc");
            REQUIRE(t, pds_image_alloc(&b, sizes[s][0], sizes[s][1]) == PDS_OK, "alloc");
            for (i = 0; i < a.width * a.height * 3; i++) {
                a.rgb[i] = levels[k][0];
                b.rgb[i] = levels[k][1];
            }
            want = (2 * ya * yb + 1e-4) / (ya * ya + yb * yb + 1e-4);
            got = pds_image_ssim(&a, &b);
            CHECK(t, fabs(got - want) <= 1e-12, "levels %g/%g on %dx%d: %.17g, want %.17g", levels[k][0],
                  levels[k][1], a.width, a.height, got, want);
            pds_image_free(&a);
            pds_image_free(&b);
        }
}

static void test_ssim_is_symmetric(pds_test_ctx *t)
{
    pds_image a, b;
    double ab, ba;
    REQUIRE(t, pds_image_alloc(&a, 33, 21) == PDS_OK && pds_image_alloc(&b, 33, 21) == PDS_OK, "alloc");
    timg_pattern(&a, 0);
    timg_pattern(&b, 1);
    ab = pds_image_ssim(&a, &b);
    ba = pds_image_ssim(&b, &a);
    CHECK(t, ab == ba, "SSIM(a,b) = %.17g, SSIM(b,a) = %.17g", ab, ba);
    CHECK(t, ab > 0.0 && ab < 0.99, "different images score below 1: %.17g", ab);
    pds_image_free(&a);
    pds_image_free(&b);
}

static void test_compare_fills_metrics_and_rejects_size_mismatch(pds_test_ctx *t)
{
    pds_image a, b, c;
    pds_metrics m;
    pds_error err;
    pds_status st;
    REQUIRE(t, pds_image_alloc(&a, 64, 64) == PDS_OK && pds_image_alloc(&b, 64, 64) == PDS_OK
                   && pds_image_alloc(&c, 32, 32) == PDS_OK,
            "alloc");
    timg_pattern(&a, 0);
    timg_pattern(&b, 1);
    REQUIRE(t, pds_image_compare(&a, &b, &m, &err) == PDS_OK, "compare: %s", err.text);
    CHECK(t, m.rmse == pds_image_rmse(&a, &b), "rmse %.17g", m.rmse);
    CHECK(t, m.ssim == pds_image_ssim(&a, &b), "ssim %.17g", m.ssim);
    CHECK(t, m.rmse > 0.0 && m.ssim < 1.0, "the images differ");
    st = pds_image_compare(&a, &c, &m, &err);
    CHECK(t, st == PDS_ERR_INVALID_ARG, "mismatch status %d", (int)st);
    CHECK(t, strcmp(err.message, "image sizes differ: 64x64 vs 32x32") == 0, "message '%s'", err.message);
    CHECK(t, strcmp(err.text, "image sizes differ: 64x64 vs 32x32") == 0, "text '%s'", err.text);
    CHECK(t, pds_image_compare(&a, &c, &m, NULL) == PDS_ERR_INVALID_ARG, "NULL err is allowed");
    pds_image_free(&c);
    CHECK(t, pds_image_compare(&c, &c, &m, &err) == PDS_ERR_INVALID_ARG, "empty images");
    pds_image_free(&a);
    pds_image_free(&b);
}

/* pds_image_compare_masked: the RMSE over the channels of the pixels the
   mask holds (first channel > 0; 0, a negative value and NaN hold none)
   by hand, the SSIM over the windows centred on them against the direct
   definition; a mask holding every pixel gives pds_image_compare's bits;
   one holding only border pixels (no window centred there) an SSIM of -1
   and its RMSE; an empty mask and one of another size are refused. */
static void test_compare_masked_takes_the_pixels_the_mask_holds(pds_test_ctx *t)
{
    pds_image a, b, mask, small;
    pds_metrics m, all;
    pds_error err;
    double sum = 0.0, direct;
    int x, y, c, used = 0;
    REQUIRE(t, pds_image_alloc(&a, 40, 30) == PDS_OK && pds_image_alloc(&b, 40, 30) == PDS_OK &&
                   pds_image_alloc(&mask, 40, 30) == PDS_OK && pds_image_alloc(&small, 32, 32) == PDS_OK,
            "alloc");
    timg_pattern(&a, 0);
    timg_pattern(&b, 1);
    for (y = 0; y < 30; y++)
        for (x = 0; x < 40; x++) {
            int i = y * 40 + x;
            float v = x < 17 || (x + 3 * y) % 7 == 0 ? 1.0f : (x + y) % 3 == 0 ? -1.0f : (x + y) % 3 == 1 ? NAN : 0.0f;
            for (c = 0; c < 3; c++) mask.rgb[3 * i + c] = c == 0 ? v : 1.0f; /* only the first channel counts */
            if (!(v > 0.0f)) continue;
            used++;
            for (c = 0; c < 3; c++) {
                double d = (double)a.rgb[3 * i + c] - (double)b.rgb[3 * i + c];
                sum += d * d;
            }
        }
    REQUIRE(t, pds_image_compare_masked(&a, &b, &mask, &m, &err) == PDS_OK, "compare: %s", err.text);
    CHECK(t, fabs(m.rmse - sqrt(sum / (3.0 * used))) <= 1e-15, "rmse %.17g, by hand %.17g over %d pixels", m.rmse,
          sqrt(sum / (3.0 * used)), used);
    direct = timg_ssim_direct_masked(&a, &b, &mask);
    CHECK(t, direct > -1.0 && fabs(m.ssim - direct) <= 1e-12, "ssim %.17g, direct %.17g", m.ssim, direct);
    CHECK(t, fabs(m.ssim - pds_image_ssim(&a, &b)) > 1e-6 && fabs(m.rmse - pds_image_rmse(&a, &b)) > 1e-6,
          "the mask changed nothing: the test cannot tell");
    for (x = 0; x < 40 * 30; x++) mask.rgb[3 * x] = 0.5f;
    REQUIRE(t, pds_image_compare_masked(&a, &b, &mask, &m, &err) == PDS_OK && pds_image_compare(&a, &b, &all, &err) ==
                   PDS_OK, "compare: %s", err.text);
    CHECK(t, m.rmse == all.rmse && m.ssim == all.ssim, "every pixel held: %.17g %.17g against %.17g %.17g", m.rmse,
          m.ssim, all.rmse, all.ssim);
    for (x = 0; x < 40 * 30; x++) mask.rgb[3 * x] = x % 40 == 0 ? 1.0f : 0.0f; /* the left column: no centre */
    REQUIRE(t, pds_image_compare_masked(&a, &b, &mask, &m, &err) == PDS_OK, "compare: %s", err.text);
    CHECK(t, m.ssim == -1.0 && m.rmse > 0.0, "border only: ssim %g, rmse %g", m.ssim, m.rmse);
    for (x = 0; x < 40 * 30; x++) mask.rgb[3 * x] = 0.0f;
    CHECK(t, pds_image_compare_masked(&a, &b, &mask, &m, &err) == PDS_ERR_INVALID_ARG &&
                 !strcmp(err.message, "the mask holds no pixel"),
          "an empty mask: '%s'", err.message);
    CHECK(t, pds_image_compare_masked(&a, &b, &small, &m, &err) == PDS_ERR_INVALID_ARG &&
                 !strcmp(err.message, "the mask is 32x32, the images 40x30"),
          "a mask of another size: '%s'", err.message);
    pds_image_free(&a);
    pds_image_free(&b);
    pds_image_free(&mask);
    pds_image_free(&small);
}

static void test_ssim_ring_buffer_matches_direct_on_larger_image(pds_test_ctx *t)
{
    /* 131x97: the ring of filtered rows wraps many times and neither side
       is a multiple of 11. */
    pds_image a, b;
    double s, direct;
    REQUIRE(t, pds_image_alloc(&a, 131, 97) == PDS_OK && pds_image_alloc(&b, 131, 97) == PDS_OK, "alloc");
    timg_pattern(&a, 0);
    timg_pattern(&b, 1);
    s = pds_image_ssim(&a, &b);
    direct = timg_ssim_direct(&a, &b);
    CHECK(t, fabs(s - direct) <= 1e-12, "SSIM %.17g, direct %.17g", s, direct);
    pds_image_free(&a);
    pds_image_free(&b);
}

static const pds_test_case tests_image[] = {
    {"pfm_round_trip_is_bit_exact_and_stores_bottom_row_first", test_pfm_round_trip},
    {"pfm_reads_big_endian_raster_when_scale_is_positive", test_pfm_big_endian},
    {"pfm_reads_greyscale_pf_into_all_three_channels", test_pfm_greyscale},
    {"pfm_rejects_truncated_bad_magic_zero_scale_and_bad_sizes_naming_the_file", test_pfm_rejects_bad_files},
    {"crc32_and_adler32_match_known_check_values", test_crc_adler_known_values},
    {"srgb_encode_matches_the_curve_at_key_points", test_srgb_encode_key_points},
    {"png_decodes_to_hand_computed_tone_mapped_bytes", test_png_small_image_decodes_to_tone_mapped_bytes},
    {"png_round_trips_odd_sizes_exactly", test_png_round_trips_odd_sizes},
    {"png_round_trip_of_test_card_is_exact_and_uses_every_filter_and_block_type",
     test_png_round_trip_test_card_uses_every_filter_and_block_type},
    {"png_zlib_header_check_value_and_adler32_trailer", test_png_zlib_header_and_adler32_trailer},
    {"png_smooth_gradient_compresses_at_least_20_to_1", test_png_smooth_gradient_compresses_well},
    {"deflate_round_trips_empty_one_byte_runs_no_repeats_noise_and_far_copies", test_deflate_round_trips_edge_cases},
    {"huffman_lengths_are_limited_complete_and_optimal_when_unlimited", test_huffman_lengths_are_limited_and_complete},
    {"image_write_picks_format_by_extension_case_insensitively", test_image_write_picks_format_by_extension},
    {"image_failed_write_leaves_no_file_behind", test_image_failed_write_leaves_no_file},
    {"image_alloc_and_writers_check_arguments", test_image_alloc_and_writers_check_arguments},
    {"rmse_matches_hand_computed_value_on_2x2", test_rmse_hand_computed},
    {"compare_masked_takes_the_pixels_the_mask_holds", test_compare_masked_takes_the_pixels_the_mask_holds},
    {"ssim_of_identical_images_is_one", test_ssim_identical_is_one},
    {"ssim_matches_direct_formula_and_scikit_image", test_ssim_matches_direct_and_scikit_image},
    {"ssim_of_constant_images_matches_closed_form", test_ssim_constant_images_closed_form},
    {"ssim_is_symmetric", test_ssim_is_symmetric},
    {"compare_fills_metrics_and_rejects_size_mismatch", test_compare_fills_metrics_and_rejects_size_mismatch},
    {"ssim_ring_buffer_matches_direct_formula_on_larger_image", test_ssim_ring_buffer_matches_direct_on_larger_image},
};

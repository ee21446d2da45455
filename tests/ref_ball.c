/* ref_ball.c - an independent reference image of scenes/ball.scene: a glass
   ball (exact sphere, IOR 1.5) resting on a Lambertian floor under a point
   light, seen by a pinhole camera. It shares no code with pds.c: it knows
   the scene analytically and is written from the formulas alone, so that
   pds, pm and POV-Ray can all be judged against it (README "PDS against
   POV-Ray").

     cc -std=c99 -O2 -o tests/ref_ball tests/ref_ball.c -lm -lpthread
     tests/ref_ball [options] -o OUT.pfm
       --photons-side N  the light tracer's N x N stratified photons (8192)
       --spp-side M      M x M stratified eye samples a pixel (16)
       --cell H          the fine caustic grid's cell in scene units (0.004)
       --seed S          random numbers (0)
       --threads T       (2)
       --caustics OUT    also the caustic part alone (L S+ D S* E paths)
       --direct OUT      also the rest (L D S* E paths)
       --ball-mask OUT   also 1 where the camera ray meets the ball, else 0
       --camera PX PY PZ AX AY AZ FOV  another pinhole: position, look-at
                         point, vertical field of view (the scene's: 0.8 4.6 4.4
                         -0.45 0.4 -0.6 36); up is +y
       --eye-depth K     eye paths meet at most K glass interfaces (24; a
                         check of pds's eye pass with its --max-depth K)

   The light transport is split as in Jensen's two-pass method and as in
   every photon method of pds: light that reaches the floor through the
   glass (one or more specular bounces) is the caustic, estimated by light
   tracing; light straight from the lamp is exact (a shadow ray); the eye
   follows the glass by both Fresnel branches. Neither part carries light
   that bounces diffusely twice (none of the renderers compared does).

   1. Caustic irradiance (light tracing). Photons leave the point light
      into the cone that holds the sphere: a direction uniform in the
      cone's solid angle W = 2 pi (1 - cos a), sin a = R / d (d the
      distance to the centre), each carrying the flux I W / N (I = P / 4 pi,
      N the number of photons). The cone's (u, v) square is stratified:
      N = n x n cells, one jittered photon each. A photon is split at every
      glass interface into a reflected and a transmitted photon of weights
      F and 1 - F (F the exact unpolarised Fresnel reflectance of a
      dielectric, e.g. Pharr, Jakob, Humphreys, "Physically Based
      Rendering", 3rd ed., eq. 8.5; total internal reflection when
      sin t > 1), so no branch is sampled. A photon that leaves the glass
      and meets the floor adds its flux to the cell of a grid it lands in:
      irradiance E = flux / cell area. Two grids: a fine one (cell H) over
      the ball's neighbourhood, a coarse one (cell 0.03) over the whole
      floor, looked up outside the fine one. Sums are 64-bit fixed point, so they do not depend on the
      order or the thread count.
   2. The image. Each pixel averages M x M jittered samples (a box
      filter over the pixel, as pds's `filter box`). The camera is pds's
      pinhole: pixel coordinates (x right, y down) map to
      forward + sx right + sy up with sx = (2 px / W - 1) tan(fov/2) W / H,
      sy = (1 - 2 py / H) tan(fov/2), right = normalize(forward x up),
      up' = right x forward. At the glass the ray splits into both Fresnel
      branches (pruned below a weight of 1e-6, at most 24 interfaces). On
      the floor (albedo a) the radiance is
        L = (a / pi) (I cos t / r^2 V + E_c),
      V the shadow ray's visibility (the ball blocks it: light through the
      glass is the caustic), E_c the caustic grid bilinearly interpolated
      between cell centres. Anything else (the sky) is black.

   Errors of this reference: the grid's cell (bias at sharp rims, about a
   cell), the photons' noise (stratified; tests/povray_compare.sh measures
   both by a second reference with another seed and a coarser grid). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

/* ------------------------------------------------------------ the scene */
/* scenes/ball.scene, in its own (right-handed, y up) frame */
static const double BALL_C[3] = {0.0, 1.001, 0.0};
static const double BALL_R = 1.0;
static const double BALL_IOR = 1.5;
static const double FLOOR_HALF = 15.0;   /* quad 30 x 30 at y = 0 */
static const double ALBEDO = 0.8;
static const double LIGHT_P[3] = {5.6, 5.4, 3.7};
static const double LIGHT_POWER_W = 2000.0;
static double CAM_POS[3] = {0.8, 4.6, 4.4};
static double CAM_AT[3] = {-0.45, 0.4, -0.6};
static double CAM_FOV_DEG = 36.0;
static const int IMG_W = 320, IMG_H = 240;

/* the fine caustic grid: x in [FINE_X0, FINE_X0 + FINE_SIZE], same for z */
static const double FINE_X0 = -4.0, FINE_Z0 = -3.5, FINE_SIZE = 6.0;
static const double COARSE_CELL = 0.03;
static int eye_depth = 24; /* --eye-depth: most glass interfaces on an eye path */
static const double FIXED_ONE = 4294967296.0; /* 2^32: a photon of weight 1 */

/* ----------------------------------------------------------- 3-vectors */
typedef struct { double x, y, z; } v3;
static v3 v3_make(double x, double y, double z) { v3 r; r.x = x; r.y = y; r.z = z; return r; }
static v3 v3_arr(const double *a) { return v3_make(a[0], a[1], a[2]); }
static v3 add(v3 a, v3 b) { return v3_make(a.x + b.x, a.y + b.y, a.z + b.z); }
static v3 sub(v3 a, v3 b) { return v3_make(a.x - b.x, a.y - b.y, a.z - b.z); }
static v3 mul(v3 a, double s) { return v3_make(a.x * s, a.y * s, a.z * s); }
static double dot(v3 a, v3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static v3 cross(v3 a, v3 b)
{
    return v3_make(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static v3 unit(v3 a) { return mul(a, 1.0 / sqrt(dot(a, a))); }

/* ------------------------------------------------------ random numbers */
/* A pure function of (seed, purpose, index, dimension): splitmix64's
   finaliser over a combination of the four (Steele, Lea, Flood 2014). */
static uint64_t mix64(uint64_t z)
{
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}
static double rnd(uint64_t seed, uint64_t purpose, uint64_t index, uint64_t dim)
{
    uint64_t h = mix64(seed ^ mix64(purpose * 0x100000001b3ull ^ mix64(index ^ mix64(dim + 0x51ed27ull))));
    return (double)(h >> 11) * (1.0 / 9007199254740992.0);
}
enum { RNG_PHOTON = 1, RNG_PIXEL = 2 };

/* ------------------------------------------------------- the sphere */
/* Nearest t > eps along o + t d (d unit) where the ray meets the sphere,
   or -1. */
static double sphere_hit(v3 o, v3 d)
{
    v3 oc = sub(o, v3_arr(BALL_C));
    double b = dot(oc, d), c = dot(oc, oc) - BALL_R * BALL_R;
    double disc = b * b - c, s, t;
    const double eps = 1e-9;
    if (disc < 0.0) return -1.0;
    s = sqrt(disc);
    t = -b - s;
    if (t > eps) return t;
    t = -b + s;
    return t > eps ? t : -1.0;
}

/* t > 0 where the ray meets the floor quad, or -1. */
static double floor_hit(v3 o, v3 d)
{
    double t;
    v3 p;
    if (d.y >= 0.0 || o.y <= 0.0) return -1.0;
    t = -o.y / d.y;
    p = add(o, mul(d, t));
    if (fabs(p.x) > FLOOR_HALF || fabs(p.z) > FLOOR_HALF) return -1.0;
    return t;
}

/* At a glass interface with unit normal n facing the incoming ray (dot(d,
   n) < 0) and relative index eta = n_incident / n_transmitted: the
   Fresnel reflectance (unpolarised), the reflected and the refracted
   directions. Returns F (1: total internal reflection, *refr unset). */
static double fresnel_split(v3 d, v3 n, double eta, v3 *refl, v3 *refr)
{
    double ci = -dot(d, n);
    double s2t = eta * eta * (1.0 - ci * ci), ct, rs, rp;
    *refl = add(d, mul(n, 2.0 * ci));
    if (s2t >= 1.0) return 1.0;
    ct = sqrt(1.0 - s2t);
    *refr = add(mul(d, eta), mul(n, eta * ci - ct));
    /* rs = (n1 cos i - n2 cos t) / (n1 cos i + n2 cos t), rp = (n2 cos i -
       n1 cos t) / (n2 cos i + n1 cos t), divided through by n2 */
    rs = (eta * ci - ct) / (eta * ci + ct);
    rp = (ci - eta * ct) / (ci + eta * ct);
    return 0.5 * (rs * rs + rp * rp);
}

/* ------------------------------------------------------- caustic grids */
typedef struct {
    int fine_n, coarse_n;       /* cells per side */
    double fine_h, coarse_h;
    uint64_t *fine, *coarse;    /* fixed-point sums of photon weight */
} grids;

static void grids_add(grids *g, v3 p, double w)
{
    uint64_t q = (uint64_t)(w * FIXED_ONE + 0.5);
    int i, j;
    if (p.x >= FINE_X0 && p.x < FINE_X0 + FINE_SIZE && p.z >= FINE_Z0 && p.z < FINE_Z0 + FINE_SIZE) {
        i = (int)((p.x - FINE_X0) / g->fine_h);
        j = (int)((p.z - FINE_Z0) / g->fine_h);
        if (i >= g->fine_n) i = g->fine_n - 1;
        if (j >= g->fine_n) j = g->fine_n - 1;
        g->fine[(size_t)j * g->fine_n + i] += q;
    }
    /* every photon also goes into the coarse grid, so that its cells at
       the fine grid's border hold all their photons */
    i = (int)((p.x + FLOOR_HALF) / g->coarse_h);
    j = (int)((p.z + FLOOR_HALF) / g->coarse_h);
    if (i < 0 || j < 0 || i >= g->coarse_n || j >= g->coarse_n) return;
    g->coarse[(size_t)j * g->coarse_n + i] += q;
}

/* Follow one photon of weight w from o along d (unit) through the glass,
   splitting at each interface; bounces counts the interfaces met. */
static void trace_photon(grids *g, v3 o, v3 d, double w, int bounces)
{
    double ts, tf;
    if (w < 1e-7 || bounces > 24) return;
    ts = sphere_hit(o, d);
    tf = floor_hit(o, d);
    if (ts > 0.0 && (tf < 0.0 || ts < tf)) {
        v3 p = add(o, mul(d, ts));
        v3 n = unit(sub(p, v3_arr(BALL_C)));
        v3 refl, refr;
        int inside = dot(d, n) > 0.0;
        double F = fresnel_split(d, inside ? mul(n, -1.0) : n, inside ? BALL_IOR : 1.0 / BALL_IOR, &refl, &refr);
        trace_photon(g, p, refl, w * F, bounces + 1);
        if (F < 1.0) trace_photon(g, p, refr, w * (1.0 - F), bounces + 1);
        return;
    }
    if (tf > 0.0 && bounces > 0) grids_add(g, add(o, mul(d, tf)), w);
}

typedef struct {
    grids g;
    long n, row0, row1; /* the rows of the n x n strata this thread does */
    uint64_t seed;
} photon_job;

/* The light's frame: photons fill the cone of half-angle a about the
   axis towards the ball's centre. */
static void light_cone(v3 *axis, v3 *b1, v3 *b2, double *cos_a)
{
    v3 toc = sub(v3_arr(BALL_C), v3_arr(LIGHT_P));
    double dist = sqrt(dot(toc, toc));
    *axis = mul(toc, 1.0 / dist);
    *b1 = unit(cross(*axis, fabs(axis->x) < 0.9 ? v3_make(1, 0, 0) : v3_make(0, 1, 0)));
    *b2 = cross(*axis, *b1);
    *cos_a = sqrt(1.0 - (BALL_R / dist) * (BALL_R / dist));
}

static void *photon_worker(void *arg)
{
    photon_job *job = (photon_job *)arg;
    v3 axis, b1, b2;
    double cos_a;
    long r, c;
    light_cone(&axis, &b1, &b2, &cos_a);
    for (r = job->row0; r < job->row1; r++)
        for (c = 0; c < job->n; c++) {
            uint64_t idx = (uint64_t)r * (uint64_t)job->n + (uint64_t)c;
            double u = (c + rnd(job->seed, RNG_PHOTON, idx, 0)) / job->n;
            double v = (r + rnd(job->seed, RNG_PHOTON, idx, 1)) / job->n;
            /* uniform in the cone's solid angle: cos t uniform in [cos a, 1] */
            double ct = 1.0 - u * (1.0 - cos_a), st = sqrt(fmax(0.0, 1.0 - ct * ct)), ph = 2.0 * PI * v;
            v3 d = add(mul(axis, ct), add(mul(b1, st * cos(ph)), mul(b2, st * sin(ph))));
            trace_photon(&job->g, v3_arr(LIGHT_P), d, 1.0, 0);
        }
    return NULL;
}

/* Irradiance grids in W/m^2 (each cell: its flux / its area). */
typedef struct {
    int fine_n, coarse_n;
    double fine_h, coarse_h;
    double *fine, *coarse;
} irradiance;

static int caustic_irradiance(long n, double cell, uint64_t seed, int threads, irradiance *E)
{
    photon_job *jobs = calloc((size_t)threads, sizeof *jobs);
    pthread_t *tid = calloc((size_t)threads, sizeof *tid);
    v3 axis, b1, b2;
    double cos_a, flux_w;
    int t;
    size_t k, nf, nc;
    if (!jobs || !tid) return -1;
    light_cone(&axis, &b1, &b2, &cos_a);
    E->fine_h = cell;
    E->fine_n = (int)ceil(FINE_SIZE / cell);
    E->coarse_h = COARSE_CELL;
    E->coarse_n = (int)ceil(2.0 * FLOOR_HALF / COARSE_CELL);
    nf = (size_t)E->fine_n * E->fine_n;
    nc = (size_t)E->coarse_n * E->coarse_n;
    for (t = 0; t < threads; t++) {
        jobs[t].g.fine_n = E->fine_n;
        jobs[t].g.coarse_n = E->coarse_n;
        jobs[t].g.fine_h = E->fine_h;
        jobs[t].g.coarse_h = E->coarse_h;
        jobs[t].g.fine = calloc(nf, sizeof(uint64_t));
        jobs[t].g.coarse = calloc(nc, sizeof(uint64_t));
        if (!jobs[t].g.fine || !jobs[t].g.coarse) return -1;
        jobs[t].n = n;
        jobs[t].row0 = n * t / threads;
        jobs[t].row1 = n * (t + 1) / threads;
        jobs[t].seed = seed;
        if (pthread_create(&tid[t], NULL, photon_worker, &jobs[t]) != 0) return -1;
    }
    for (t = 0; t < threads; t++) pthread_join(tid[t], NULL);
    /* each photon carries I W / N, W = 2 pi (1 - cos a) */
    flux_w = LIGHT_POWER_W / (4.0 * PI) * 2.0 * PI * (1.0 - cos_a) / ((double)n * (double)n);
    E->fine = calloc(nf, sizeof(double));
    E->coarse = calloc(nc, sizeof(double));
    if (!E->fine || !E->coarse) return -1;
    for (k = 0; k < nf; k++) {
        uint64_t s = 0;
        for (t = 0; t < threads; t++) s += jobs[t].g.fine[k];
        E->fine[k] = (double)s / FIXED_ONE * flux_w / (cell * cell);
    }
    for (k = 0; k < nc; k++) {
        uint64_t s = 0;
        for (t = 0; t < threads; t++) s += jobs[t].g.coarse[k];
        E->coarse[k] = (double)s / FIXED_ONE * flux_w / (COARSE_CELL * COARSE_CELL);
    }
    for (t = 0; t < threads; t++) {
        free(jobs[t].g.fine);
        free(jobs[t].g.coarse);
    }
    free(jobs);
    free(tid);
    return 0;
}

/* Bilinear interpolation between cell centres of an n x n grid of cell h
   whose corner is (x0, z0); clamped at the border. */
static double grid_lerp(const double *g, int n, double h, double x0, double z0, double x, double z)
{
    double fx = (x - x0) / h - 0.5, fz = (z - z0) / h - 0.5;
    int i = (int)floor(fx), j = (int)floor(fz), i1, j1;
    double ax = fx - i, az = fz - j;
    if (i < 0) { i = 0; ax = 0.0; }
    if (j < 0) { j = 0; az = 0.0; }
    if (i >= n - 1) { i = n - 1; ax = 0.0; }
    if (j >= n - 1) { j = n - 1; az = 0.0; }
    i1 = i + 1 < n ? i + 1 : i;
    j1 = j + 1 < n ? j + 1 : j;
    return (1 - az) * ((1 - ax) * g[(size_t)j * n + i] + ax * g[(size_t)j * n + i1]) +
           az * ((1 - ax) * g[(size_t)j1 * n + i] + ax * g[(size_t)j1 * n + i1]);
}

static double caustic_at(const irradiance *E, v3 p)
{
    /* the fine grid, but for a cell's width at its border (there the
       coarse grid's cells hold the photons) */
    double m = E->fine_h;
    if (p.x >= FINE_X0 + m && p.x < FINE_X0 + FINE_SIZE - m && p.z >= FINE_Z0 + m && p.z < FINE_Z0 + FINE_SIZE - m)
        return grid_lerp(E->fine, E->fine_n, E->fine_h, FINE_X0, FINE_Z0, p.x, p.z);
    return grid_lerp(E->coarse, E->coarse_n, E->coarse_h, -FLOOR_HALF, -FLOOR_HALF, p.x, p.z);
}

/* ------------------------------------------------------------ the eye */
/* Radiance along o + t d, split into the direct part and the caustic
   part (added to out[0] and out[1], times the path weight w). */
static void radiance(const irradiance *E, v3 o, v3 d, double w, int depth, double out[2])
{
    double ts, tf;
    if (w < 1e-6 || depth > eye_depth) return;
    ts = sphere_hit(o, d);
    tf = floor_hit(o, d);
    if (ts > 0.0 && (tf < 0.0 || ts < tf)) {
        v3 p = add(o, mul(d, ts));
        v3 n = unit(sub(p, v3_arr(BALL_C)));
        v3 refl, refr;
        int inside = dot(d, n) > 0.0;
        double F = fresnel_split(d, inside ? mul(n, -1.0) : n, inside ? BALL_IOR : 1.0 / BALL_IOR, &refl, &refr);
        radiance(E, p, refl, w * F, depth + 1, out);
        if (F < 1.0) radiance(E, p, refr, w * (1.0 - F), depth + 1, out);
        return;
    }
    if (tf > 0.0) {
        v3 p = add(o, mul(d, tf));
        v3 tl = sub(v3_arr(LIGHT_P), p);
        double r2 = dot(tl, tl), r = sqrt(r2);
        v3 l = mul(tl, 1.0 / r);
        double ts2 = sphere_hit(p, l);
        double I = LIGHT_POWER_W / (4.0 * PI);
        if (!(ts2 > 0.0 && ts2 < r)) out[0] += w * ALBEDO / PI * I * l.y / r2;
        out[1] += w * ALBEDO / PI * caustic_at(E, p);
    }
}

typedef struct {
    const irradiance *E;
    int m, row0, row1;
    uint64_t seed;
    float *direct, *caustic, *mask;
} eye_job;

static void *eye_worker(void *arg)
{
    eye_job *job = (eye_job *)arg;
    v3 pos = v3_arr(CAM_POS);
    v3 fwd = unit(sub(v3_arr(CAM_AT), pos));
    v3 right = unit(cross(fwd, v3_make(0, 1, 0)));
    v3 up = cross(right, fwd);
    double th = tan(0.5 * CAM_FOV_DEG * PI / 180.0), aspect = (double)IMG_W / IMG_H;
    int x, y, a, b;
    for (y = job->row0; y < job->row1; y++)
        for (x = 0; x < IMG_W; x++) {
            uint64_t pixel = (uint64_t)y * IMG_W + (uint64_t)x;
            double sum[2] = {0.0, 0.0};
            int hits = 0;
            for (b = 0; b < job->m; b++)
                for (a = 0; a < job->m; a++) {
                    uint64_t idx = pixel * (uint64_t)(job->m * job->m) + (uint64_t)(b * job->m + a);
                    double px = x + (a + rnd(job->seed, RNG_PIXEL, idx, 0)) / job->m;
                    double py = y + (b + rnd(job->seed, RNG_PIXEL, idx, 1)) / job->m;
                    double sx = (2.0 * px / IMG_W - 1.0) * th * aspect, sy = (1.0 - 2.0 * py / IMG_H) * th;
                    v3 d = unit(add(fwd, add(mul(right, sx), mul(up, sy))));
                    double ts = sphere_hit(pos, d), tf = floor_hit(pos, d);
                    if (ts > 0.0 && (tf < 0.0 || ts < tf)) hits++;
                    radiance(job->E, pos, d, 1.0, 0, sum);
                }
            job->direct[pixel] = (float)(sum[0] / (job->m * job->m));
            job->caustic[pixel] = (float)(sum[1] / (job->m * job->m));
            job->mask[pixel] = 2 * hits >= job->m * job->m ? 1.0f : 0.0f;
        }
    return NULL;
}

/* ------------------------------------------------------------- output */
/* PFM: "PF", width height, -1 (little-endian), rows bottom to top. */
static int write_pfm(const char *path, const float *grey, const float *grey2)
{
    FILE *f = fopen(path, "wb");
    int x, y, c;
    if (!f) return -1;
    fprintf(f, "PF\n%d %d\n-1.0\n", IMG_W, IMG_H);
    for (y = IMG_H - 1; y >= 0; y--)
        for (x = 0; x < IMG_W; x++) {
            size_t i = (size_t)y * IMG_W + x;
            float v = grey[i] + (grey2 ? grey2[i] : 0.0f);
            unsigned char bytes[4];
            uint32_t u;
            memcpy(&u, &v, 4);
            bytes[0] = (unsigned char)(u & 0xff);
            bytes[1] = (unsigned char)((u >> 8) & 0xff);
            bytes[2] = (unsigned char)((u >> 16) & 0xff);
            bytes[3] = (unsigned char)(u >> 24);
            for (c = 0; c < 3; c++) fwrite(bytes, 1, 4, f);
        }
    return fclose(f) == 0 ? 0 : -1;
}

static int usage(void)
{
    fprintf(stderr, "usage: ref_ball [--photons-side N] [--spp-side M] [--cell H] [--seed S] [--threads T]\n"
                    "                [--caustics OUT.pfm] [--direct OUT.pfm] [--ball-mask OUT.pfm] -o OUT.pfm\n");
    return 2;
}

int main(int argc, char **argv)
{
    long n = 8192;
    int m = 16, threads = 2, i, t;
    double cell = 0.004;
    uint64_t seed = 0;
    const char *out = NULL, *out_c = NULL, *out_d = NULL, *out_m = NULL;
    irradiance E;
    eye_job *jobs;
    pthread_t *tid;
    float *direct, *caustic, *mask;
    for (i = 1; i < argc; i += 2) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!v) return usage();
        if (!strcmp(a, "--photons-side")) n = atol(v);
        else if (!strcmp(a, "--spp-side")) m = atoi(v);
        else if (!strcmp(a, "--cell")) cell = atof(v);
        else if (!strcmp(a, "--seed")) seed = (uint64_t)strtoull(v, NULL, 10);
        else if (!strcmp(a, "--threads")) threads = atoi(v);
        else if (!strcmp(a, "-o")) out = v;
        else if (!strcmp(a, "--caustics")) out_c = v;
        else if (!strcmp(a, "--direct")) out_d = v;
        else if (!strcmp(a, "--ball-mask")) out_m = v;
        else if (!strcmp(a, "--eye-depth")) eye_depth = atoi(v);
        else if (!strcmp(a, "--camera") && i + 7 < argc) {
            int k;
            for (k = 0; k < 3; k++) CAM_POS[k] = atof(argv[i + 1 + k]);
            for (k = 0; k < 3; k++) CAM_AT[k] = atof(argv[i + 4 + k]);
            CAM_FOV_DEG = atof(argv[i + 7]);
            i += 6;
        }
        else return usage();
    }
    if (!out || n < 1 || m < 1 || threads < 1 || !(cell > 0.0) || cell > 1.0) return usage();
    if (caustic_irradiance(n, cell, seed, threads, &E) != 0) {
        fprintf(stderr, "ref_ball: out of memory\n");
        return 1;
    }
    direct = calloc((size_t)IMG_W * IMG_H, sizeof(float));
    caustic = calloc((size_t)IMG_W * IMG_H, sizeof(float));
    mask = calloc((size_t)IMG_W * IMG_H, sizeof(float));
    jobs = calloc((size_t)threads, sizeof *jobs);
    tid = calloc((size_t)threads, sizeof *tid);
    if (!direct || !caustic || !mask || !jobs || !tid) {
        fprintf(stderr, "ref_ball: out of memory\n");
        return 1;
    }
    for (t = 0; t < threads; t++) {
        jobs[t].E = &E;
        jobs[t].m = m;
        jobs[t].row0 = IMG_H * t / threads;
        jobs[t].row1 = IMG_H * (t + 1) / threads;
        jobs[t].seed = seed;
        jobs[t].direct = direct;
        jobs[t].caustic = caustic;
        jobs[t].mask = mask;
        if (pthread_create(&tid[t], NULL, eye_worker, &jobs[t]) != 0) return 1;
    }
    for (t = 0; t < threads; t++) pthread_join(tid[t], NULL);
    if (write_pfm(out, direct, caustic) != 0 || (out_c && write_pfm(out_c, caustic, NULL) != 0) ||
        (out_d && write_pfm(out_d, direct, NULL) != 0) || (out_m && write_pfm(out_m, mask, NULL) != 0)) {
        fprintf(stderr, "ref_ball: cannot write the images\n");
        return 1;
    }
    printf("ref_ball photons=%ld spp=%d cell=%g seed=%llu\n", n * n, m * m, cell, (unsigned long long)seed);
    free(E.fine);
    free(E.coarse);
    free(direct);
    free(caustic);
    free(mask);
    free(jobs);
    free(tid);
    return 0;
}

/* tests/test_bvh.c - the BVH (>>bvh) against brute force, watertightness,
   ray intervals, degenerate inputs and tree sanity. Included by
   test_main.c after pds.c and runner.h, so the static internals are in
   scope. */

/* splitmix64: a tiny deterministic generator local to each test */
typedef struct tbvh_rng { unsigned long long s; } tbvh_rng;

static double tbvh_rand(tbvh_rng *g)
{
    unsigned long long z = (g->s += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    z ^= z >> 31;
    return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

static double tbvh_range(tbvh_rng *g, double lo, double hi)
{
    return lo + (hi - lo) * tbvh_rand(g);
}

/* uniform direction on the unit sphere */
static pds__v3 tbvh_dir(tbvh_rng *g)
{
    double z = 1.0 - 2.0 * tbvh_rand(g), phi = 2.0 * PDS__PI * tbvh_rand(g);
    double r = sqrt(1.0 - z * z);
    return pds__v(r * cos(phi), r * sin(phi), z);
}

/* A triangle soup: 3 vertices per triangle, idx = 0, 1, 2, ... */
typedef struct tbvh_soup {
    float *pos;
    int *idx;
    size_t ntris;
} tbvh_soup;

static void tbvh_soup_free(tbvh_soup *s)
{
    free(s->pos);
    free(s->idx);
    s->pos = NULL;
    s->idx = NULL;
    s->ntris = 0;
}

static int tbvh_soup_alloc(tbvh_soup *s, size_t n)
{
    size_t i;
    s->ntris = n;
    s->pos = (float *)malloc((9 * n + 1) * sizeof(float));
    s->idx = (int *)malloc((3 * n + 1) * sizeof(int));
    if (!s->pos || !s->idx) return 0;
    for (i = 0; i < 3 * n; i++) s->idx[i] = (int)i;
    return 1;
}

/* kind 0: random triangles of size up to `size` in [-1, 1]^3;
   kind 1: every triangle the same (all centroids at one spot);
   kind 2: triangles sharing one centroid, randomly rotated;
   kind 3: coplanar (z = 0.25) random triangles. */
static int tbvh_soup_make(tbvh_soup *s, size_t n, int kind, double size, tbvh_rng *g)
{
    size_t i;
    int k;
    if (!tbvh_soup_alloc(s, n)) return 0;
    for (i = 0; i < n; i++) {
        float *v = s->pos + 9 * i;
        if (kind == 1) {
            const float t[9] = {-0.5f, -0.4f, 0.1f, 0.6f, -0.3f, 0.0f, 0.1f, 0.7f, -0.2f};
            memcpy(v, t, sizeof t);
        } else if (kind == 2) {
            pds__v3 a = tbvh_dir(g), b = tbvh_dir(g), c;
            c = pds__scale(pds__add(a, b), -1.0); /* a + b + c = 0: centroid 0 */
            v[0] = (float)a.x; v[1] = (float)a.y; v[2] = (float)a.z;
            v[3] = (float)b.x; v[4] = (float)b.y; v[5] = (float)b.z;
            v[6] = (float)c.x; v[7] = (float)c.y; v[8] = (float)c.z;
        } else {
            double cx = tbvh_range(g, -1, 1), cy = tbvh_range(g, -1, 1), cz = tbvh_range(g, -1, 1);
            for (k = 0; k < 3; k++) {
                v[3 * k + 0] = (float)(cx + size * tbvh_range(g, -1, 1));
                v[3 * k + 1] = (float)(cy + size * tbvh_range(g, -1, 1));
                v[3 * k + 2] = kind == 3 ? 0.25f : (float)(cz + size * tbvh_range(g, -1, 1));
            }
        }
    }
    return 1;
}

static const float *tbvh_vert(const float *pos, const int *idx, size_t tri, int c)
{
    return pos + 3 * (size_t)idx[3 * tri + c];
}

/* The BVH's own watertight test on one triangle v (9 floats), through a
   block holding it in all four lanes: 1 with *t on a hit in (tmin,
   tmax). */
static int tbvh_tri_test(const pds__bvh_ray *r, const float v[9], float tmin, float tmax, float *t)
{
    pds__bvh_tri4 q;
    int c, k, l;
    for (c = 0; c < 3; c++)
        for (k = 0; k < 3; k++)
            for (l = 0; l < 4; l++) q.v[c][k][l] = v[3 * c + k];
    return pds__bvh_tri4_test(r, &q, tmin, tmax, t) >= 0;
}

/* Brute force with the BVH's own watertight float test over every
   triangle in original order: the closest float t and its triangle (-1 if
   none). */
static long tbvh_brute_watertight(const float *pos, const int *idx, size_t ntris, pds__v3 o,
                                  pds__v3 d, double tmin, double tmax, float *t_out)
{
    pds__bvh_ray r;
    double tscale;
    float best = 0.0f, v[9];
    long bi = -1;
    size_t i;
    int c;
    if (!pds__bvh_ray_setup(&r, o, d, tmin, tmax, &tscale)) return -1;
    best = r.tmax;
    for (i = 0; i < ntris; i++) {
        float t;
        for (c = 0; c < 3; c++) memcpy(v + 3 * c, tbvh_vert(pos, idx, i, c), 3 * sizeof(float));
        if (tbvh_tri_test(&r, v, r.tmin, best, &t)) {
            best = t;
            bi = (long)i;
        }
    }
    *t_out = best;
    return bi;
}

/* Float t of the watertight test on one triangle, or -1 on a miss. */
static float tbvh_watertight_t(const float *pos, const int *idx, long tri, pds__v3 o, pds__v3 d,
                               double tmin, double tmax)
{
    pds__bvh_ray r;
    double tscale;
    float v[9], t;
    int c;
    if (!pds__bvh_ray_setup(&r, o, d, tmin, tmax, &tscale)) return -1.0f;
    for (c = 0; c < 3; c++) memcpy(v + 3 * c, tbvh_vert(pos, idx, (size_t)tri, c), 3 * sizeof(float));
    return tbvh_tri_test(&r, v, r.tmin, r.tmax, &t) ? t : -1.0f;
}

/* Independent reference: plain Moller-Trumbore in double, closest hit in
   (tmin, tmax). Returns the triangle or -1. */
static long tbvh_brute_mt(const float *pos, const int *idx, size_t ntris, pds__v3 o, pds__v3 d,
                          double tmin, double tmax, double *t_out)
{
    long bi = -1;
    double best = tmax;
    size_t i;
    for (i = 0; i < ntris; i++) {
        const float *a = tbvh_vert(pos, idx, i, 0), *b = tbvh_vert(pos, idx, i, 1),
                    *c = tbvh_vert(pos, idx, i, 2);
        pds__v3 p0 = pds__v(a[0], a[1], a[2]);
        pds__v3 e1 = pds__sub(pds__v(b[0], b[1], b[2]), p0);
        pds__v3 e2 = pds__sub(pds__v(c[0], c[1], c[2]), p0);
        pds__v3 p = pds__cross(d, e2), s, q;
        double det = pds__dot(e1, p), u, v, t;
        if (det == 0.0) continue;
        s = pds__sub(o, p0);
        u = pds__dot(s, p) / det;
        if (u < 0.0 || u > 1.0) continue;
        q = pds__cross(s, e1);
        v = pds__dot(d, q) / det;
        if (v < 0.0 || u + v > 1.0) continue;
        t = pds__dot(e2, q) / det;
        if (t > tmin && t < best) {
            best = t;
            bi = (long)i;
        }
    }
    *t_out = best;
    return bi;
}

/* Checks one ray against both brute forces. Returns 1 if the BVH agrees
   with the watertight brute force (same hit/miss, a triangle at the
   closest float t, t/u/v consistent); *mt_disagree counts rays where the
   double Moller-Trumbore reference differs (allowed rarely: it is not
   watertight and decides edges in double). */
static int tbvh_check_ray(pds_test_ctx *t, const pds__bvh *bvh, const float *pos, const int *idx,
                          size_t ntris, pds__v3 o, pds__v3 d, double tmin, double tmax,
                          long *mt_disagree)
{
    pds__tri_hit h;
    float bt = 0.0f;
    double mt_t = 0.0;
    long bi = tbvh_brute_watertight(pos, idx, ntris, o, d, tmin, tmax, &bt);
    long mi = tbvh_brute_mt(pos, idx, ntris, o, d, tmin, tmax, &mt_t);
    int hit = pds__bvh_intersect(bvh, o, d, tmin, tmax, &h);
    int occ = pds__bvh_occluded(bvh, o, d, tmin, tmax);
    int ok = 1;

    if (hit != (bi >= 0) || occ != (bi >= 0)) {
        CHECK(t, 0, "hit %d occluded %d but brute force %s (tri %ld t %.9g)", hit, occ,
              bi >= 0 ? "hits" : "misses", bi, (double)bt);
        return 0;
    }
    if ((mi >= 0) != (bi >= 0)) ++*mt_disagree;
    if (!hit) return 1;
    {
        /* the BVH's triangle must sit at the brute-force closest float t */
        float ft = tbvh_watertight_t(pos, idx, h.tri, o, d, tmin, tmax);
        const float *a = tbvh_vert(pos, idx, (size_t)h.tri, 0), *b = tbvh_vert(pos, idx, (size_t)h.tri, 1),
                    *c = tbvh_vert(pos, idx, (size_t)h.tri, 2);
        double w = 1.0 - h.u - h.v, scale = 1.0 + pds__length(o) + h.t * pds__length(d);
        pds__v3 p = pds__add(o, pds__scale(d, h.t));
        pds__v3 q = pds__v(w * a[0] + h.u * b[0] + h.v * c[0], w * a[1] + h.u * b[1] + h.v * c[1],
                           w * a[2] + h.u * b[2] + h.v * c[2]);
        if (h.tri < 0 || (size_t)h.tri >= ntris || ft != bt) {
            CHECK(t, 0, "BVH hit tri %ld at float t %.9g, brute force tri %ld at %.9g", h.tri,
                  (double)ft, bi, (double)bt);
            ok = 0;
        }
        if (!(h.t > tmin && h.t < tmax)) {
            CHECK(t, 0, "t %.17g outside (%.17g, %.17g)", h.t, tmin, tmax);
            ok = 0;
        }
        if (fabs(h.t - (double)bt) > 1e-5 * (1.0 + fabs(h.t))) {
            CHECK(t, 0, "double t %.12g far from float t %.12g", h.t, (double)bt);
            ok = 0;
        }
        if (mi >= 0 && fabs(mt_t - h.t) > 1e-5 * (1.0 + fabs(h.t))) ++*mt_disagree;
        if (!(h.u >= 0.0 && h.v >= 0.0 && h.u + h.v <= 1.0 + 1e-12) ||
            pds__length(pds__sub(p, q)) > 1e-5 * scale) {
            CHECK(t, 0, "barycentrics (%.9g, %.9g) give a point %.3g away from o + t d", h.u, h.v,
                  pds__length(pds__sub(p, q)));
            ok = 0;
        }
    }
    return ok;
}

/* Random rays: origins in [-1.5, 1.5]^3, uniform directions of random
   length, random (tmin, tmax) on a quarter of them. */
static void tbvh_random_rays(pds_test_ctx *t, const pds__bvh *bvh, const float *pos, const int *idx,
                             size_t ntris, int nrays, tbvh_rng *g, long *mt_disagree, int *bad)
{
    int i;
    for (i = 0; i < nrays; i++) {
        pds__v3 o = pds__v(tbvh_range(g, -1.5, 1.5), tbvh_range(g, -1.5, 1.5), tbvh_range(g, -1.5, 1.5));
        pds__v3 d = pds__scale(tbvh_dir(g), tbvh_range(g, 0.1, 10.0));
        double tmin = 0.0, tmax = 1e30;
        if (i % 4 == 3) {
            tmin = tbvh_range(g, 0.0, 0.3);
            tmax = tmin + tbvh_range(g, 0.0, 0.5);
        }
        if (!tbvh_check_ray(t, bvh, pos, idx, ntris, o, d, tmin, tmax, mt_disagree)) ++*bad;
        if (*bad > 5) return; /* enough messages */
    }
}

/* Walks the 4-wide tree: every leaf is one block of its own holding
   1..PDS__BVH_MAX_LEAF triangles (spare lanes repeat the last), leaves
   cover every triangle exactly once, boxes contain what is below them,
   every node and block is reachable. Returns 1 if all holds; *sah gets
   the SAH cost (expected child boxes entered, inner nodes and leaf blocks
   alike, by a random ray through the root box). */
static int tbvh_validate(pds_test_ctx *t, const pds__bvh *bvh, const float *pos, const int *idx,
                         double *sah)
{
    unsigned char *seen_tri = (unsigned char *)calloc(bvh->ntris + 1, 1);
    unsigned char *seen_node = (unsigned char *)calloc(bvh->nnodes + 1, 1);
    unsigned char *seen_block = (unsigned char *)calloc(bvh->nblocks + 1, 1);
    size_t *stack = (size_t *)malloc((bvh->nnodes + 1) * sizeof(size_t));
    size_t sp = 0, i, covered = 0;
    int ok = 1, k, c;
    float rlo[3], rhi[3];
    double root_area;
    if (!seen_tri || !seen_node || !seen_block || !stack) {
        free(seen_tri);
        free(seen_node);
        free(seen_block);
        free(stack);
        CHECK(t, 0, "out of memory in the test");
        return 0;
    }
    *sah = 0.0;
    pds__bvh_box_empty(rlo, rhi);
    for (k = 0; k < 4; k++) {
        for (c = 0; c < 3; c++) {
            if (bvh->nodes[0].b[4 * c + k] > bvh->nodes[0].b[4 * (3 + c) + k]) continue;
            rlo[c] = bvh->nodes[0].b[4 * c + k] < rlo[c] ? bvh->nodes[0].b[4 * c + k] : rlo[c];
            rhi[c] = bvh->nodes[0].b[4 * (3 + c) + k] > rhi[c] ? bvh->nodes[0].b[4 * (3 + c) + k] : rhi[c];
        }
    }
    root_area = pds__bvh_half_area(rlo, rhi);
    if (!(root_area > 0.0)) root_area = 1.0;
    stack[sp++] = 0;
    seen_node[0] = 1;
    while (sp > 0 && ok) {
        const pds__bvh_node *n = &bvh->nodes[stack[--sp]];
        for (k = 0; k < 4; k++) {
            float lo[3], hi[3];
            for (c = 0; c < 3; c++) {
                lo[c] = n->b[4 * c + k];
                hi[c] = n->b[4 * (3 + c) + k];
            }
            if (lo[0] > hi[0]) continue; /* unused slot */
            *sah += pds__bvh_half_area(lo, hi) / root_area;
            if (n->child[k] & PDS__BVH_LEAF) {
                size_t b = n->child[k] & ~PDS__BVH_LEAF, cnt = n->count[k];
                int l;
                if (cnt < 1 || cnt > PDS__BVH_MAX_LEAF || b >= bvh->nblocks || seen_block[b]++) {
                    CHECK(t, 0, "leaf block %lu of %lu triangles out of range, too big or shared",
                          (unsigned long)b, (unsigned long)cnt);
                    ok = 0;
                    break;
                }
                for (l = 0; l < 4; l++) {
                    /* lanes past the count repeat the last triangle */
                    int id = bvh->tri_id[4 * b + l], v;
                    if (id < 0 || (size_t)id >= bvh->ntris ||
                        ((size_t)l >= cnt && id != bvh->tri_id[4 * b + cnt - 1])) {
                        CHECK(t, 0, "block %lu lane %d holds triangle %d", (unsigned long)b, l, id);
                        ok = 0;
                        break;
                    }
                    if ((size_t)l < cnt) {
                        if (seen_tri[id]++) {
                            CHECK(t, 0, "triangle %d in two leaves", id);
                            ok = 0;
                        }
                        covered++;
                    }
                    for (v = 0; v < 3; v++) {
                        const float *p = tbvh_vert(pos, idx, (size_t)id, v);
                        for (c = 0; c < 3; c++) {
                            if (p[c] < lo[c] || p[c] > hi[c] || p[c] != bvh->tri4[b].v[v][c][l]) {
                                CHECK(t, 0, "triangle %d not inside its leaf box or not copied", id);
                                ok = 0;
                            }
                        }
                    }
                }
            } else {
                const pds__bvh_node *ch;
                int kk;
                if (n->child[k] >= bvh->nnodes || seen_node[n->child[k]]) {
                    CHECK(t, 0, "bad or shared child node %u", (unsigned)n->child[k]);
                    ok = 0;
                    break;
                }
                seen_node[n->child[k]] = 1;
                ch = &bvh->nodes[n->child[k]];
                for (kk = 0; kk < 4; kk++) {
                    if (ch->b[kk] > ch->b[12 + kk]) continue;
                    for (c = 0; c < 3; c++) {
                        if (ch->b[4 * c + kk] < lo[c] || ch->b[4 * (3 + c) + kk] > hi[c]) {
                            CHECK(t, 0, "child box sticks out of its parent's");
                            ok = 0;
                        }
                    }
                }
                stack[sp++] = n->child[k];
            }
        }
    }
    if (ok && covered != bvh->ntris) {
        CHECK(t, 0, "leaves cover %lu of %lu triangles", (unsigned long)covered, (unsigned long)bvh->ntris);
        ok = 0;
    }
    for (i = 0; ok && i < bvh->nnodes; i++) {
        if (!seen_node[i]) {
            CHECK(t, 0, "node %lu is unreachable", (unsigned long)i);
            ok = 0;
        }
    }
    for (i = 0; ok && i < bvh->nblocks; i++) {
        if (!seen_block[i]) {
            CHECK(t, 0, "block %lu is unreachable", (unsigned long)i);
            ok = 0;
        }
    }
    if (ok && bvh->nblocks != (size_t)bvh->leaves) {
        CHECK(t, 0, "%lu blocks for %ld leaves", (unsigned long)bvh->nblocks, bvh->leaves);
        ok = 0;
    }
    free(seen_tri);
    free(seen_node);
    free(seen_block);
    free(stack);
    CHECK(t, ok, "tree structure is invalid");
    return ok;
}

/* ------------------------------------------------------------------ tests */

static void test_bvh_empty_misses_every_ray(pds_test_ctx *t)
{
    pds__bvh bvh;
    pds__tri_hit h;
    pds_error err;
    REQUIRE(t, pds__bvh_build(&bvh, NULL, NULL, 0, &err) == PDS_OK, "empty build failed");
    CHECK(t, !pds__bvh_intersect(&bvh, pds__v(0, 0, 0), pds__v(0, 0, 1), 0.0, 1e30, &h), "empty BVH hit");
    CHECK(t, !pds__bvh_occluded(&bvh, pds__v(0, 0, 0), pds__v(0, 0, 1), 0.0, 1e30), "empty BVH occluded");
    CHECK(t, pds__bvh_memory(&bvh) == 0, "empty BVH owns %lu bytes", (unsigned long)pds__bvh_memory(&bvh));
    pds__bvh_free(&bvh);
    pds__bvh_free(&bvh); /* freeing twice is harmless */
}

static void test_bvh_matches_brute_force_on_random_soups(pds_test_ctx *t)
{
    static const size_t sizes[] = {1, 2, 3, 5, 17, 100, 1000, 5000};
    static const int rays[] = {2000, 2000, 2000, 2000, 2000, 2000, 2000, 1500};
    tbvh_rng g = {1};
    size_t s;
    for (s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        tbvh_soup soup;
        pds__bvh bvh;
        pds_error err;
        long mt_disagree = 0;
        int bad = 0;
        double sah;
        double size = sizes[s] > 100 ? 0.08 : 0.5;
        REQUIRE(t, tbvh_soup_make(&soup, sizes[s], 0, size, &g), "out of memory");
        REQUIRE(t, pds__bvh_build(&bvh, soup.pos, soup.idx, soup.ntris, &err) == PDS_OK, "%s", err.text);
        tbvh_validate(t, &bvh, soup.pos, soup.idx, &sah);
        tbvh_random_rays(t, &bvh, soup.pos, soup.idx, soup.ntris, rays[s], &g, &mt_disagree, &bad);
        CHECK(t, bad == 0, "%d rays disagree with brute force on %lu triangles", bad, (unsigned long)sizes[s]);
        /* double Moller-Trumbore decides edges differently only for rays
           within rounding of an edge: a handful at most */
        CHECK(t, mt_disagree <= rays[s] / 200, "%ld of %d rays disagree with double Moller-Trumbore",
              mt_disagree, rays[s]);
        CHECK(t, pds__bvh_memory(&bvh) >= soup.ntris * 9 * sizeof(float), "memory %lu too small",
              (unsigned long)pds__bvh_memory(&bvh));
        pds__bvh_free(&bvh);
        tbvh_soup_free(&soup);
    }
}

static void test_bvh_handles_degenerate_centroids(pds_test_ctx *t)
{
    /* all at one spot, one shared centroid, coplanar */
    static const int kinds[] = {1, 2, 3};
    static const size_t sizes[] = {1000, 777, 3000};
    tbvh_rng g = {2};
    int k;
    for (k = 0; k < 3; k++) {
        tbvh_soup soup;
        pds__bvh bvh;
        pds_error err;
        long mt_disagree = 0;
        int bad = 0;
        double sah;
        REQUIRE(t, tbvh_soup_make(&soup, sizes[k], kinds[k], 0.05, &g), "out of memory");
        REQUIRE(t, pds__bvh_build(&bvh, soup.pos, soup.idx, soup.ntris, &err) == PDS_OK, "%s", err.text);
        tbvh_validate(t, &bvh, soup.pos, soup.idx, &sah);
        /* split by count keeps the tree balanced */
        CHECK(t, bvh.depth <= 20, "kind %d: depth %d", kinds[k], bvh.depth);
        tbvh_random_rays(t, &bvh, soup.pos, soup.idx, soup.ntris, 300, &g, &mt_disagree, &bad);
        CHECK(t, bad == 0, "kind %d: %d rays disagree with brute force", kinds[k], bad);
        pds__bvh_free(&bvh);
        tbvh_soup_free(&soup);
    }
}

/* UV sphere of radius rad around the origin through the mesh API: a pole
   vertex at +-z, rings of seg vertices, all shared, so it is closed. */
static int tbvh_uv_sphere(pds__mesh *m, int rings, int seg, double rad)
{
    long top, bottom, base;
    int i, j;
    memset(m, 0, sizeof *m);
    top = pds__mesh_add_vertex(m, pds__v(0, 0, rad), pds__v(0, 0, 1));
    for (i = 1; i < rings; i++) {
        double th = PDS__PI * i / rings;
        for (j = 0; j < seg; j++) {
            double ph = 2.0 * PDS__PI * j / seg;
            pds__v3 n = pds__v(sin(th) * cos(ph), sin(th) * sin(ph), cos(th));
            if (pds__mesh_add_vertex(m, pds__scale(n, rad), n) < 0) return 0;
        }
    }
    bottom = pds__mesh_add_vertex(m, pds__v(0, 0, -rad), pds__v(0, 0, -1));
    if (top < 0 || bottom < 0) return 0;
    base = top + 1;
    for (j = 0; j < seg; j++) {
        int j1 = (j + 1) % seg;
        if (pds__mesh_add_tri(m, top, base + j, base + j1, 0) < 0) return 0;
        if (pds__mesh_add_tri(m, bottom, base + (long)(rings - 2) * seg + j1,
                              base + (long)(rings - 2) * seg + j, 0) < 0)
            return 0;
    }
    for (i = 0; i < rings - 2; i++) {
        for (j = 0; j < seg; j++) {
            long a = base + (long)i * seg + j, b = base + (long)i * seg + (j + 1) % seg;
            long c = a + seg, d = b + seg;
            if (pds__mesh_add_tri(m, a, c, d, 0) < 0 || pds__mesh_add_tri(m, a, d, b, 0) < 0) return 0;
        }
    }
    return 1;
}

static void test_bvh_closed_mesh_is_watertight_at_edges_and_vertices(pds_test_ctx *t)
{
    pds__mesh m;
    pds__bvh bvh;
    pds_error err;
    pds__tri_hit h;
    static const double origins[4][3] = {{0, 0, 0}, {0.1, -0.05, 0.02}, {-0.3, 0.2, 0.1}, {0.01, 0.7, -0.5}};
    long shots = 0, misses = 0, far_off = 0;
    size_t tri;
    int o, c, e;
    REQUIRE(t, tbvh_uv_sphere(&m, 24, 48, 1.0), "out of memory");
    REQUIRE(t, m.degenerate_dropped == 0, "sphere lost %ld triangles", m.degenerate_dropped);
    REQUIRE(t, pds__bvh_build(&bvh, m.pos, m.idx, m.ntris, &err) == PDS_OK, "%s", err.text);
    /* from points inside, aim exactly at every vertex and at the midpoint
       of every edge (in double: the midpoint lies on the edge): a closed
       surface must be hit every time */
    for (o = 0; o < 4; o++) {
        pds__v3 org = pds__v(origins[o][0], origins[o][1], origins[o][2]);
        for (tri = 0; tri < m.ntris; tri++) {
            for (c = 0; c < 3; c++) {
                pds__v3 a = pds__mesh_pos(&m, m.idx[3 * tri + c]);
                pds__v3 b = pds__mesh_pos(&m, m.idx[3 * tri + (c + 1) % 3]);
                for (e = 0; e < 2; e++) {
                    pds__v3 aim = e == 0 ? a : pds__scale(pds__add(a, b), 0.5);
                    pds__v3 dir = pds__sub(aim, org);
                    shots++;
                    if (!pds__bvh_intersect(&bvh, org, dir, 0.0, 1e30, &h)) {
                        misses++;
                        continue;
                    }
                    if (!pds__bvh_occluded(&bvh, org, dir, 0.0, 1e30)) misses++;
                    /* the ray leaves through the aimed point, at t = 1 */
                    if (fabs(h.t - 1.0) > 1e-5) far_off++;
                }
            }
        }
    }
    CHECK(t, misses == 0, "%ld of %ld rays at edges and vertices slipped through", misses, shots);
    CHECK(t, far_off == 0, "%ld of %ld rays hit away from the aimed point", far_off, shots);
    /* from outside, aim at the vertices facing the origin */
    misses = 0;
    shots = 0;
    for (tri = 0; tri < m.nverts; tri++) {
        pds__v3 org = pds__v(0.3, -2.5, 1.7), v = pds__mesh_pos(&m, (long)tri);
        /* well inside the visible cap (faces tilt < 8 degrees from v) */
        if (pds__dot(v, pds__normalize(pds__sub(org, v))) <= 0.3) continue;
        shots++;
        if (!pds__bvh_intersect(&bvh, org, pds__sub(v, org), 0.0, 1e30, &h) || fabs(h.t - 1.0) > 1e-5) misses++;
    }
    CHECK(t, shots > 100 && misses == 0, "%ld of %ld outside rays at vertices missed", misses, shots);
    pds__bvh_free(&bvh);
    pds__mesh_free(&m);
}

/* A flat grid of n x n unit squares at z = 0, each split into two
   triangles along a diagonal that alternates, stored in a scrambled order
   (so neighbours land in different leaves and lanes). */
static int tbvh_grid(tbvh_soup *s, int n)
{
    int i, j, q = 0;
    size_t k;
    if (!tbvh_soup_alloc(s, (size_t)(2 * n * n))) return 0;
    for (j = 0; j < n; j++) {
        for (i = 0; i < n; i++) {
            const float x0 = (float)i, y0 = (float)j, x1 = x0 + 1.0f, y1 = y0 + 1.0f;
            const float a[18] = {x0, y0, 0, x1, y0, 0, x1, y1, 0, x0, y0, 0, x1, y1, 0, x0, y1, 0};
            const float b[18] = {x0, y0, 0, x1, y0, 0, x0, y1, 0, x1, y0, 0, x1, y1, 0, x0, y1, 0};
            memcpy(s->pos + 18 * q, (i + j) % 2 ? a : b, sizeof a);
            q++;
        }
    }
    /* scramble: swap triangle k with triangle 7k mod ntris */
    for (k = 0; k < s->ntris; k++) {
        size_t m = (7 * k) % s->ntris;
        float tmp[9];
        memcpy(tmp, s->pos + 9 * k, sizeof tmp);
        memcpy(s->pos + 9 * k, s->pos + 9 * m, sizeof tmp);
        memcpy(s->pos + 9 * m, tmp, sizeof tmp);
    }
    return 1;
}

static void test_bvh_grid_vertices_and_edges_never_leak(pds_test_ctx *t)
{
    /* Rays aimed exactly at interior grid vertices and edge midpoints:
       there the float edge functions are within rounding of 0 (exactly 0
       for the axis-parallel rays), so the exact-sign fallback decides;
       some triangle must report the hit, at the aimed point. */
    static const double origins[5][3] = {
        {4.5, 4.5, 3.0}, {4.0, 4.0, 1.0}, {-3.25, 2.5, 0.7}, {11.0, -5.0, 2.5}, {7.0, 3.0, -2.0}};
    const int n = 8;
    tbvh_soup soup;
    pds__bvh bvh;
    pds_error err;
    pds__tri_hit h;
    long shots = 0, misses = 0, far_off = 0;
    int o, i, j, e;
    REQUIRE(t, tbvh_grid(&soup, n), "out of memory");
    REQUIRE(t, pds__bvh_build(&bvh, soup.pos, soup.idx, soup.ntris, &err) == PDS_OK, "%s", err.text);
    for (o = 0; o < 6; o++) {
        for (j = 1; j < 2 * n; j++) {
            for (i = 1; i < 2 * n; i++) {
                /* (i/2, j/2): a vertex, an edge midpoint or a diagonal's */
                pds__v3 aim = pds__v(0.5 * i, 0.5 * j, 0.0), org, dir;
                if (o < 5) {
                    org = pds__v(origins[o][0], origins[o][1], origins[o][2]);
                } else {
                    org = pds__v(aim.x, aim.y, 2.0); /* straight down */
                }
                dir = pds__sub(aim, org);
                for (e = 0; e < 2; e++) {
                    shots++;
                    if (e == 0 ? !pds__bvh_intersect(&bvh, org, dir, 0.0, 1e30, &h)
                               : !pds__bvh_occluded(&bvh, org, dir, 0.0, 1e30)) {
                        misses++;
                        continue;
                    }
                    if (e == 0 && fabs(h.t - 1.0) > 1e-6) far_off++;
                }
            }
        }
    }
    CHECK(t, misses == 0, "%ld of %ld rays at grid vertices and edges slipped through", misses, shots);
    CHECK(t, far_off == 0, "%ld of %ld rays hit away from the aimed point", far_off, shots);
    pds__bvh_free(&bvh);
    tbvh_soup_free(&soup);
}

static void test_bvh_axis_parallel_rays_match_brute_force(pds_test_ctx *t)
{
    tbvh_soup soup;
    pds__bvh bvh;
    pds_error err;
    pds__tri_hit h;
    tbvh_rng g = {3};
    long mt_disagree = 0;
    int bad = 0, i, k;
    pds__mesh m;
    REQUIRE(t, tbvh_soup_make(&soup, 2000, 0, 0.1, &g), "out of memory");
    REQUIRE(t, pds__bvh_build(&bvh, soup.pos, soup.idx, soup.ntris, &err) == PDS_OK, "%s", err.text);
    for (i = 0; i < 3000 && bad <= 5; i++) {
        double dd[3] = {0, 0, 0};
        pds__v3 o, d;
        int axis = i % 3, mode = (i / 3) % 3;
        /* mode 0: one axis; 1: two axes (one component zero); 2: origin on
           a vertex's coordinates (slab planes through the origin) */
        dd[axis] = tbvh_rand(&g) < 0.5 ? -1.0 : 1.0;
        if (mode == 1) dd[(axis + 1) % 3] = tbvh_range(&g, -1, 1);
        o = pds__v(tbvh_range(&g, -1.2, 1.2), tbvh_range(&g, -1.2, 1.2), tbvh_range(&g, -1.2, 1.2));
        if (mode == 2) {
            const float *p = soup.pos + 3 * (size_t)(tbvh_rand(&g) * 3.0 * (double)soup.ntris);
            double oc[3];
            oc[0] = p[0];
            oc[1] = p[1];
            oc[2] = p[2];
            oc[axis] = -1.5 * dd[axis];
            o = pds__v(oc[0], oc[1], oc[2]);
        }
        d = pds__v(dd[0], dd[1], dd[2]);
        if (!tbvh_check_ray(t, &bvh, soup.pos, soup.idx, soup.ntris, o, d, 0.0, 1e30, &mt_disagree)) bad++;
    }
    CHECK(t, bad == 0, "%d axis-parallel rays disagree with brute force", bad);
    pds__bvh_free(&bvh);
    tbvh_soup_free(&soup);

    /* from inside a closed sphere, the six axis directions hit the poles
       (vertices) and ring points exactly */
    REQUIRE(t, tbvh_uv_sphere(&m, 16, 32, 2.0), "out of memory");
    REQUIRE(t, pds__bvh_build(&bvh, m.pos, m.idx, m.ntris, &err) == PDS_OK, "%s", err.text);
    for (k = 0; k < 6; k++) {
        double dd[3] = {0, 0, 0};
        dd[k % 3] = k < 3 ? 1.0 : -1.0;
        CHECK(t, pds__bvh_intersect(&bvh, pds__v(0, 0, 0), pds__v(dd[0], dd[1], dd[2]), 0.0, 1e30, &h),
              "axis ray %d from the centre missed", k);
        CHECK(t, h.t > 1.9 && h.t <= 2.0 + 1e-6, "axis ray %d: t = %.9g", k, h.t);
    }
    pds__bvh_free(&bvh);
    pds__mesh_free(&m);
}

static void test_bvh_respects_tmin_and_tmax(pds_test_ctx *t)
{
    /* four parallel squares z = 0, 1, 2, 3 (two triangles each) */
    tbvh_soup soup;
    pds__bvh bvh;
    pds_error err;
    pds__tri_hit h;
    pds__v3 o = pds__v(0.1, 0.2, -1.0), up = pds__v(0, 0, 1);
    int q;
    REQUIRE(t, tbvh_soup_alloc(&soup, 8), "out of memory");
    for (q = 0; q < 4; q++) {
        const float z = (float)q;
        const float v[18] = {-1, -1, z, 1, -1, z, 1, 1, z, -1, -1, z, 1, 1, z, -1, 1, z};
        memcpy(soup.pos + 18 * q, v, sizeof v);
    }
    REQUIRE(t, pds__bvh_build(&bvh, soup.pos, soup.idx, soup.ntris, &err) == PDS_OK, "%s", err.text);
    /* planes at t = 1, 2, 3, 4 along the ray */
    CHECK(t, pds__bvh_intersect(&bvh, o, up, 0.0, 1e30, &h) && fabs(h.t - 1.0) < 1e-12, "first plane: t %.17g", h.t);
    CHECK(t, pds__bvh_intersect(&bvh, o, up, 1.0, 1e30, &h) && fabs(h.t - 2.0) < 1e-12,
          "tmin = 1 must skip the plane at t = 1: t %.17g", h.t);
    CHECK(t, pds__bvh_intersect(&bvh, o, up, 1.5, 3.5, &h) && fabs(h.t - 2.0) < 1e-12, "window: t %.17g", h.t);
    CHECK(t, !pds__bvh_intersect(&bvh, o, up, 2.0, 3.0, &h), "open interval (2, 3) must miss the planes at 2 and 3");
    CHECK(t, !pds__bvh_occluded(&bvh, o, up, 2.0, 3.0), "occluded on (2, 3)");
    CHECK(t, pds__bvh_occluded(&bvh, o, up, 2.0, 3.0 + 1e-6), "occluded on (2, 3 + 1e-6)");
    CHECK(t, !pds__bvh_intersect(&bvh, o, up, 0.0, 1.0, &h), "tmax = 1 must exclude the plane at t = 1");
    /* the loop works in float inside (tmin, tmax): a hit within about
       1e-7 relative of an end may be dropped, never one outside added */
    CHECK(t, pds__bvh_intersect(&bvh, o, up, 0.0, 1.0 + 1e-6, &h) && h.tri <= 1, "tmax just past 1");
    CHECK(t, pds__bvh_intersect(&bvh, o, up, 4.0 - 1e-6, 1e30, &h) && fabs(h.t - 4.0) < 1e-12 && h.tri >= 6,
          "tmin just below 4");
    CHECK(t, !pds__bvh_intersect(&bvh, o, up, 4.0, 1e30, &h), "nothing beyond t = 4");
    CHECK(t, !pds__bvh_intersect(&bvh, o, up, 3.0, 2.0, &h), "empty interval");
    /* t is in units of |dir|, for any length */
    CHECK(t, pds__bvh_intersect(&bvh, o, pds__v(0, 0, 0.5), 0.0, 1e30, &h) && fabs(h.t - 2.0) < 1e-12,
          "half-length dir: t %.17g", h.t);
    CHECK(t, pds__bvh_intersect(&bvh, o, pds__v(0, 0, 1e-70), 0.0, 1e300, &h) && fabs(h.t / 1e70 - 1.0) < 1e-12,
          "tiny dir: t %.17g", h.t);
    CHECK(t, pds__bvh_intersect(&bvh, o, pds__v(0, 0, 1e70), 0.0, 1.0, &h) && fabs(h.t * 1e70 - 1.0) < 1e-12,
          "huge dir: t %.17g", h.t);
    CHECK(t, pds__bvh_occluded(&bvh, o, pds__v(0, 0, 1e-70), 0.0, 1e300), "tiny dir occluded");
    /* rays that cannot hit anything */
    CHECK(t, !pds__bvh_intersect(&bvh, o, pds__v(0, 0, 0), 0.0, 1e30, &h), "zero direction");
    CHECK(t, !pds__bvh_intersect(&bvh, o, pds__v(0, 0, NAN), 0.0, 1e30, &h), "NaN direction");
    CHECK(t, !pds__bvh_intersect(&bvh, pds__v(NAN, 0, -1), up, 0.0, 1e30, &h), "NaN origin");
    CHECK(t, !pds__bvh_occluded(&bvh, o, up, NAN, 1e30), "NaN tmin");
    pds__bvh_free(&bvh);
    tbvh_soup_free(&soup);
}

static void test_bvh_barycentrics_reproduce_hit_point(pds_test_ctx *t)
{
    /* a mesh whose triangles share vertices: idx order differs from
       storage order, and tri must be the original index */
    pds__mesh m;
    pds__bvh bvh;
    pds_error err;
    pds__tri_hit h;
    tbvh_rng g = {4};
    int i, hits = 0;
    REQUIRE(t, tbvh_uv_sphere(&m, 12, 20, 1.5), "out of memory");
    REQUIRE(t, pds__bvh_build(&bvh, m.pos, m.idx, m.ntris, &err) == PDS_OK, "%s", err.text);
    for (i = 0; i < 2000; i++) {
        pds__v3 o = pds__scale(tbvh_dir(&g), 4.0), target = pds__scale(tbvh_dir(&g), 0.5);
        pds__v3 d = pds__sub(target, o), p, q, p0, p1, p2;
        if (!pds__bvh_intersect(&bvh, o, d, 0.0, 1e30, &h)) {
            CHECK(t, 0, "ray %d through the sphere missed", i);
            continue;
        }
        hits++;
        p0 = pds__mesh_pos(&m, m.idx[3 * h.tri]);
        p1 = pds__mesh_pos(&m, m.idx[3 * h.tri + 1]);
        p2 = pds__mesh_pos(&m, m.idx[3 * h.tri + 2]);
        p = pds__add(o, pds__scale(d, h.t));
        q = pds__add(pds__add(pds__scale(p0, 1.0 - h.u - h.v), pds__scale(p1, h.u)), pds__scale(p2, h.v));
        CHECK(t, pds__length(pds__sub(p, q)) < 1e-12, "ray %d: |P(t) - P(u,v)| = %.3g", i,
              pds__length(pds__sub(p, q)));
        CHECK(t, h.u >= 0.0 && h.v >= 0.0 && h.u + h.v <= 1.0, "ray %d: u %.9g v %.9g", i, h.u, h.v);
        /* the near side: the hit faces the ray */
        CHECK(t, pds__dot(pds__cross(pds__sub(p1, p0), pds__sub(p2, p0)), d) < 0.0,
              "ray %d hit a back face first", i);
    }
    CHECK(t, hits == 2000, "%d of 2000 hits", hits);
    pds__bvh_free(&bvh);
    pds__mesh_free(&m);
}

static void test_bvh_sah_cost_is_far_below_brute_force(pds_test_ctx *t)
{
    tbvh_soup soup;
    pds__bvh bvh;
    pds_error err;
    tbvh_rng g = {5};
    double sah = 0.0;
    REQUIRE(t, tbvh_soup_make(&soup, 20000, 0, 0.02, &g), "out of memory");
    REQUIRE(t, pds__bvh_build(&bvh, soup.pos, soup.idx, soup.ntris, &err) == PDS_OK, "%s", err.text);
    REQUIRE(t, tbvh_validate(t, &bvh, soup.pos, soup.idx, &sah), "invalid tree");
    /* brute force costs 20000 triangle tests per ray; a sane tree a few
       dozen box and triangle tests */
    CHECK(t, sah < 100.0, "SAH cost %.1f (brute force 20000)", sah);
    CHECK(t, bvh.nnodes <= 2 * soup.ntris / 3, "%lu nodes for %lu triangles", (unsigned long)bvh.nnodes,
          (unsigned long)soup.ntris);
    CHECK(t, bvh.depth <= 40, "depth %d", bvh.depth);
    pds__bvh_free(&bvh);
    tbvh_soup_free(&soup);
}

static void test_bvh_rejects_invalid_input(pds_test_ctx *t)
{
    float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    int idx[3] = {0, 1, 2};
    pds__bvh bvh;
    pds_error err;
    idx[1] = -1;
    CHECK(t, pds__bvh_build(&bvh, pos, idx, 1, &err) == PDS_ERR_INVALID_ARG, "negative index accepted");
    CHECK(t, strstr(err.message, "negative vertex index") != NULL, "message: %s", err.message);
    CHECK(t, bvh.nodes == NULL && pds__bvh_memory(&bvh) == 0, "failed build left memory");
    idx[1] = 1;
    pos[4] = NAN;
    CHECK(t, pds__bvh_build(&bvh, pos, idx, 1, &err) == PDS_ERR_INVALID_ARG, "NaN coordinate accepted");
    CHECK(t, strstr(err.message, "not a number") != NULL, "message: %s", err.message);
    pos[4] = 0;
    CHECK(t, pds__bvh_build(&bvh, pos, idx, (size_t)PDS_MAX_TRIANGLES + 1, &err) == PDS_ERR_LIMIT,
          "too many triangles accepted");
    CHECK(t, pds__bvh_build(&bvh, pos, idx, 1, NULL) == PDS_OK, "one triangle, no error struct");
    pds__bvh_free(&bvh);
}

static const pds_test_case tests_bvh[] = {
    {"bvh_empty_misses_every_ray", test_bvh_empty_misses_every_ray},
    {"bvh_matches_brute_force_on_random_soups", test_bvh_matches_brute_force_on_random_soups},
    {"bvh_handles_degenerate_centroids", test_bvh_handles_degenerate_centroids},
    {"bvh_closed_mesh_is_watertight_at_edges_and_vertices", test_bvh_closed_mesh_is_watertight_at_edges_and_vertices},
    {"bvh_grid_vertices_and_edges_never_leak", test_bvh_grid_vertices_and_edges_never_leak},
    {"bvh_axis_parallel_rays_match_brute_force", test_bvh_axis_parallel_rays_match_brute_force},
    {"bvh_respects_tmin_and_tmax", test_bvh_respects_tmin_and_tmax},
    {"bvh_barycentrics_reproduce_hit_point", test_bvh_barycentrics_reproduce_hit_point},
    {"bvh_sah_cost_is_far_below_brute_force", test_bvh_sah_cost_is_far_below_brute_force},
    {"bvh_rejects_invalid_input", test_bvh_rejects_invalid_input},
};

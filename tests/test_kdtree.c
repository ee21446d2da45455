/* tests/test_kdtree.c - the kd-tree (>>kdtree) against brute force: range
   queries (every point within r exactly once), k nearest neighbours
   (distances, indices and tie order of a full sort), degenerate point
   sets, stride, determinism and the structural invariants. Included by
   test_main.c after pds.c and runner.h. */

/* Uniform in [lo, hi) from the counter-based generator. */
static double tkd_rand(uint64_t seed, uint64_t index, uint64_t dim, double lo, double hi)
{
    return lo + (hi - lo) * pds__rng_uniform(seed, PDS__RNG_TEST, index, dim);
}

/* Point set kinds used below. */
enum {
    TKD_UNIFORM,     /* uniform in [-1, 1]^3 */
    TKD_DUPLICATES,  /* coordinates on a 4x4x4 grid: ~n/64 copies of each */
    TKD_IDENTICAL,   /* all the same point */
    TKD_LINE,        /* on a line along (1, 2, -1) */
    TKD_PLANE,       /* on the plane z = 0.25, x, y on a 16x16 grid + noise */
    TKD_KINDS
};

static const char *const tkd_kind_name[TKD_KINDS] = {
    "uniform", "duplicates", "identical", "line", "plane"
};

/* n points of the given kind, stride floats apart (the extra floats are
   filled with junk the tree must ignore). Returns NULL on no memory. */
static float *tkd_points(int kind, size_t n, size_t stride, uint64_t seed)
{
    float *p = (float *)malloc((n ? n : 1) * stride * sizeof(float));
    size_t i, j;
    if (!p) return NULL;
    for (i = 0; i < n; i++) {
        float *q = p + i * stride;
        double u = tkd_rand(seed, i, 0, -1.0, 1.0);
        double v = tkd_rand(seed, i, 1, -1.0, 1.0);
        double w = tkd_rand(seed, i, 2, -1.0, 1.0);
        switch (kind) {
        case TKD_DUPLICATES:
            u = floor((u + 1.0) * 2.0) * 0.5;
            v = floor((v + 1.0) * 2.0) * 0.5;
            w = floor((w + 1.0) * 2.0) * 0.5;
            break;
        case TKD_IDENTICAL:
            u = 0.125;
            v = -0.5;
            w = 0.75;
            break;
        case TKD_LINE:
            v = 2.0 * u;
            w = -u;
            break;
        case TKD_PLANE:
            /* grid values are repeated many times, plus some free points */
            if (i % 3 != 0) {
                u = floor((u + 1.0) * 8.0) / 8.0;
                v = floor((v + 1.0) * 8.0) / 8.0;
            }
            w = 0.25;
            break;
        default:
            break;
        }
        q[0] = (float)u;
        q[1] = (float)v;
        q[2] = (float)w;
        for (j = 3; j < stride; j++) q[j] = (float)(1000.0 + (double)(i * stride + j));
    }
    return p;
}

/* What a range query reported. */
typedef struct tkd_hits {
    unsigned *count;   /* times each index was reported */
    double *d2;        /* the distance reported with it */
    size_t n, total, out_of_range;
} tkd_hits;

static void tkd_collect(void *ctx, size_t index, double dist2)
{
    tkd_hits *h = (tkd_hits *)ctx;
    h->total++;
    if (index >= h->n) {
        h->out_of_range++;
        return;
    }
    h->count[index]++;
    h->d2[index] = dist2;
}

static void tkd_collect_many(void *ctx, const size_t *index, const double *dist2, int n)
{
    int j;
    for (j = 0; j < n; j++) tkd_collect(ctx, index[j], dist2[j]);
}

/* a and b equal up to rounding: the tree and the brute force evaluate
   the same expression, bit for bit equal under ISO C's default floating
   point contraction, but a build with -ffp-contract=fast may fuse the
   two copies differently and move the last bit. */
static int tkd_same(double a, double b)
{
    return fabs(a - b) <= 1e-13 * fmax(fabs(a), fabs(b));
}

/* Range query at c with radius r against brute force over the same
   points; returns the number of mismatches (0 = equal sets, each point
   once, same distances) and adds the number of hits to *hits. */
static size_t tkd_range_check(const pds__kdtree *kd, const float *pos, size_t stride, size_t n,
                              pds__v3 c, double r, tkd_hits *h, size_t *hits)
{
    size_t i, bad = 0;
    double r2 = r * r;
    memset(h->count, 0, (n ? n : 1) * sizeof *h->count);
    h->n = n;
    h->total = 0;
    h->out_of_range = 0;
    pds__kdtree_range(kd, c, r, tkd_collect, h);
    bad += h->out_of_range;
    for (i = 0; i < n; i++) {
        double d2 = pds__kd_dist2(pos + i * stride, c.x, c.y, c.z);
        unsigned want = (r >= 0.0 && d2 <= r2) ? 1u : 0u;
        if (h->count[i] > 1) bad++;
        else if (h->count[i] != want && !tkd_same(d2, r2)) bad++;
        else if (h->count[i] && !tkd_same(h->d2[i], d2)) bad++;
        *hits += want;
    }
    return bad;
}

static int tkd_hits_alloc(tkd_hits *h, size_t n)
{
    h->count = (unsigned *)malloc((n ? n : 1) * sizeof *h->count);
    h->d2 = (double *)malloc((n ? n : 1) * sizeof *h->d2);
    return h->count && h->d2;
}

static void tkd_hits_free(tkd_hits *h)
{
    free(h->count);
    free(h->d2);
}

/* Query centre number q for a set: alternately a random spot in a box a
   little larger than the points, and exactly one of the points. */
static pds__v3 tkd_query(const float *pos, size_t stride, size_t n, uint64_t seed, size_t q)
{
    if (n > 0 && q % 2 == 1) {
        size_t i = (size_t)(pds__rng_uniform(seed, PDS__RNG_TEST, 1000000 + q, 7) * (double)n);
        const float *p = pos + i * stride;
        return pds__v(p[0], p[1], p[2]);
    }
    return pds__v(tkd_rand(seed, 2000000 + q, 0, -1.2, 1.2),
                  tkd_rand(seed, 2000000 + q, 1, -1.2, 1.2),
                  tkd_rand(seed, 2000000 + q, 2, -1.2, 1.2));
}

static void test_kdtree_range_random(pds_test_ctx *t)
{
    static const size_t sizes[] = {0, 1, 2, 17, 1000, 100000};
    /* 4.0 exceeds the diameter of every set (sqrt(12) ~ 3.46); DBL_MAX
       squares to infinity, which must still mean "everything" */
    static const double radii[] = {0.0, 1e-3, 0.02, 0.1, 0.35, 1.0, 4.0, DBL_MAX};
    size_t si, ri, q;
    for (si = 0; si < sizeof sizes / sizeof sizes[0]; si++) {
        size_t n = sizes[si], hits = 0, bad = 0;
        size_t nq = n >= 100000 ? 24 : 64;
        pds__kdtree kd;
        tkd_hits h;
        float *pos = tkd_points(TKD_UNIFORM, n, 3, 11 + si);
        REQUIRE(t, pos && tkd_hits_alloc(&h, n), "out of memory");
        REQUIRE(t, pds__kdtree_build(&kd, pos, 3, n, NULL) == PDS_OK, "build failed, n=%lu",
                (unsigned long)n);
        for (ri = 0; ri < sizeof radii / sizeof radii[0]; ri++)
            for (q = 0; q < nq; q++)
                bad += tkd_range_check(&kd, pos, 3, n, tkd_query(pos, 3, n, 5 + si, q), radii[ri], &h,
                                       &hits);
        CHECK(t, bad == 0, "n=%lu: %lu mismatches against brute force", (unsigned long)n,
              (unsigned long)bad);
        /* the test is only meaningful if something was found: r = DBL_MAX
           alone finds n per query, and r = 0 at a point finds it */
        CHECK(t, n == 0 || hits >= nq * n, "n=%lu: only %lu hits", (unsigned long)n,
              (unsigned long)hits);
        pds__kdtree_free(&kd);
        tkd_hits_free(&h);
        free(pos);
    }
}

/* A footprint in the plane with normal nrm: semi-axes len and len *
   aspect, the first at angle ang from pds__onb's first axis; its eq. 12
   filter matrix in M and major semi-axis in *major (0 if it has none). */
static int tkd_footprint(pds__v3 nrm, double len, double aspect, double ang, double M[2][3], double *major)
{
    pds__v3 t1, t2, a1, a2;
    pds__onb(nrm, &t1, &t2);
    a1 = pds__scale(pds__add(pds__scale(t1, cos(ang)), pds__scale(t2, sin(ang))), len);
    a2 = pds__scale(pds__add(pds__scale(t1, -sin(ang)), pds__scale(t2, cos(ang))), len * aspect);
    /* conjugate diameters 2 a1, 2 a2: the footprint of eq. 4 */
    if (!pds__filter_matrix(pds__scale(a1, 2.0), pds__scale(a2, 2.0), nrm, M)) return 0;
    *major = pds__footprint_major_axis(pds__scale(a1, 2.0), pds__scale(a2, 2.0));
    return 1;
}

/* The splat's query (an elliptic disc thickened to a slab, within the
   ball of its major axis) against brute force: random footprints of every
   shape, from round to needles 1000:1, at random orientations, over
   uniform, duplicate and planar point sets. The reported set (each point
   once) and the value |M d|^2 must be those of testing every point. */
static void test_kdtree_ellipse_query_matches_brute_force(pds_test_ctx *t)
{
    static const int kinds[] = {TKD_UNIFORM, TKD_DUPLICATES, TKD_PLANE};
    size_t n = 20000, q, i, bad = 0, hits = 0, visited_total = 0;
    int ki;
    for (ki = 0; ki < 3; ki++) {
        pds__kdtree kd;
        tkd_hits h;
        float *pos = tkd_points(kinds[ki], n, 3, 40 + (uint64_t)ki);
        REQUIRE(t, pos && tkd_hits_alloc(&h, n), "out of memory");
        REQUIRE(t, pds__kdtree_build(&kd, pos, 3, n, NULL) == PDS_OK, "build failed");
        for (q = 0; q < 200; q++) {
            uint64_t sd = 900 + (uint64_t)ki;
            pds__v3 c = tkd_query(pos, 3, n, sd, q), nrm;
            double M[2][3], major, tol, aspect = pow(10.0, -3.0 * pds__rng_uniform(sd, PDS__RNG_TEST, q, 20));
            double len = tkd_rand(sd, q, 21, 0.01, 0.8), ang = tkd_rand(sd, q, 22, 0.0, PDS__PI);
            nrm = pds__normalize(pds__v(tkd_rand(sd, q, 23, -1, 1), tkd_rand(sd, q, 24, -1, 1), tkd_rand(sd, q, 25, -1, 1)));
            if (ki == 2 && q % 2 == 0) nrm = pds__v(0, 0, 1); /* in the plane of the points */
            REQUIRE(t, tkd_footprint(nrm, len, aspect, ang, M, &major), "filter matrix");
            tol = 0.25 * major;
            memset(h.count, 0, n * sizeof *h.count);
            h.n = n;
            h.total = 0;
            h.out_of_range = 0;
            pds__kdtree_range_ellipse(&kd, c, major, (const double(*)[3])M, nrm, tol, tkd_collect_many, &h);
            bad += h.out_of_range;
            visited_total += h.total;
            for (i = 0; i < n; i++) {
                const float *p = pos + 3 * i;
                double d[3], y0, y1, r2;
                int want;
                d[0] = (double)p[0] - c.x;
                d[1] = (double)p[1] - c.y;
                d[2] = (double)p[2] - c.z;
                y0 = M[0][0] * d[0] + M[0][1] * d[1] + M[0][2] * d[2];
                y1 = M[1][0] * d[0] + M[1][1] * d[1] + M[1][2] * d[2];
                r2 = y0 * y0 + y1 * y1;
                want = pds__kd_dist2(p, c.x, c.y, c.z) <= major * major &&
                       fabs(nrm.x * d[0] + nrm.y * d[1] + nrm.z * d[2]) <= tol && r2 < 1.0;
                if (h.count[i] > 1 || (unsigned)want != h.count[i]) bad++;
                else if (want && h.d2[i] != r2) bad++;
                hits += (size_t)want;
            }
        }
        pds__kdtree_free(&kd);
        tkd_hits_free(&h);
        free(pos);
    }
    CHECK(t, bad == 0, "%lu mismatches against brute force", (unsigned long)bad);
    CHECK(t, hits > 1000 && visited_total == hits, "%lu hits, %lu reported", (unsigned long)hits,
          (unsigned long)visited_total);
}

static void test_kdtree_range_degenerate(pds_test_ctx *t)
{
    static const size_t sizes[] = {1, 7, 100, 5000};
    static const double radii[] = {0.0, 1e-6, 0.01, 0.26, 0.5, 1.0, 5.0};
    int kind;
    size_t si, ri, q;
    for (kind = TKD_DUPLICATES; kind < TKD_KINDS; kind++) {
        for (si = 0; si < sizeof sizes / sizeof sizes[0]; si++) {
            size_t n = sizes[si], hits = 0, bad = 0, exact = 0;
            pds__kdtree kd;
            tkd_hits h;
            float *pos = tkd_points(kind, n, 3, 100 + (uint64_t)kind);
            REQUIRE(t, pos && tkd_hits_alloc(&h, n), "out of memory");
            REQUIRE(t, pds__kdtree_build(&kd, pos, 3, n, NULL) == PDS_OK, "build failed");
            for (ri = 0; ri < sizeof radii / sizeof radii[0]; ri++) {
                for (q = 0; q < 40; q++) {
                    size_t before = hits;
                    bad += tkd_range_check(&kd, pos, 3, n, tkd_query(pos, 3, n, 9, q), radii[ri], &h,
                                           &hits);
                    /* r = 0 at a point: all its exact copies, at least one */
                    if (radii[ri] == 0.0 && q % 2 == 1 && hits > before) exact++;
                }
            }
            CHECK(t, bad == 0, "%s n=%lu: %lu mismatches", tkd_kind_name[kind], (unsigned long)n,
                  (unsigned long)bad);
            CHECK(t, exact == 20, "%s n=%lu: r = 0 found the query point %lu of 20 times",
                  tkd_kind_name[kind], (unsigned long)n, (unsigned long)exact);
            if (kind == TKD_IDENTICAL) {
                /* every query at the point finds all n copies */
                tkd_range_check(&kd, pos, 3, n, pds__v(pos[0], pos[1], pos[2]), 0.0, &h, &hits);
                CHECK(t, h.total == n, "identical n=%lu: %lu found at r = 0", (unsigned long)n,
                      (unsigned long)h.total);
            }
            pds__kdtree_free(&kd);
            tkd_hits_free(&h);
            free(pos);
        }
    }
}

/* Brute-force k-NN: every point sorted by (d2, index); the answer for
   (k, rmax) is the first min(k, #{d2 <= rmax^2}) of that list. */
typedef struct tkd_pair { double d2; size_t i; } tkd_pair;

static int tkd_pair_cmp(const void *a, const void *b)
{
    const tkd_pair *x = (const tkd_pair *)a, *y = (const tkd_pair *)b;
    if (x->d2 < y->d2) return -1;
    if (x->d2 > y->d2) return 1;
    return x->i < y->i ? -1 : x->i > y->i ? 1 : 0;
}

static void tkd_knn_sort(const float *pos, size_t stride, size_t n, pds__v3 c, tkd_pair *all)
{
    size_t i;
    for (i = 0; i < n; i++) {
        all[i].d2 = pds__kd_dist2(pos + i * stride, c.x, c.y, c.z);
        all[i].i = i;
    }
    qsort(all, n, sizeof *all, tkd_pair_cmp);
}

/* How many of the sorted list the brute force keeps for (k, rmax). */
static size_t tkd_knn_count(const tkd_pair *all, size_t n, size_t k, double rmax)
{
    size_t m = 0;
    double r2 = rmax * rmax;
    while (m < n && m < k && all[m].d2 <= r2) m++;
    return m;
}

/* Compare a k-NN answer (idx, d2, got) with the sorted brute force (all,
   want): same count, each index at most once, the tree's own order is by
   (distance, index), and slot j holds the brute force's j-th point or one
   at the same distance (a tie that rounding may order either way, see
   tkd_same). seen[] is n zero bytes, returned zeroed. Returns the number
   of mismatches. */
static size_t tkd_knn_compare(const float *pos, size_t stride, size_t n, pds__v3 c,
                              const tkd_pair *all, size_t want, const size_t *idx,
                              const double *d2, size_t got, unsigned char *seen)
{
    size_t j, bad = 0;
    if (got != want) return 1;
    for (j = 0; j < got; j++) {
        if (idx[j] >= n || seen[idx[j]]) {
            bad++;
            continue;
        }
        seen[idx[j]] = 1;
        if (j > 0 && (d2[j] < d2[j - 1] || (d2[j] == d2[j - 1] && idx[j] < idx[j - 1]))) bad++;
        if (!tkd_same(d2[j], all[j].d2)) bad++;
        else if (idx[j] != all[j].i &&
                 !tkd_same(pds__kd_dist2(pos + idx[j] * stride, c.x, c.y, c.z), all[j].d2))
            bad++;
    }
    for (j = 0; j < got; j++)
        if (idx[j] < n) seen[idx[j]] = 0;
    return bad;
}

static void test_kdtree_knn(pds_test_ctx *t)
{
    static const size_t sizes[] = {0, 1, 2, 17, 1000, 20000};
    static const double rmaxes[] = {DBL_MAX, 0.0, 0.05, 0.3};
    int kind;
    size_t si, q, ki, mi;
    for (kind = 0; kind < TKD_KINDS; kind++) {
        for (si = 0; si < sizeof sizes / sizeof sizes[0]; si++) {
            size_t n = sizes[si], bad = 0, found = 0;
            size_t ks[4];
            pds__kdtree kd;
            float *pos = tkd_points(kind, n, 3, 300 + si + 10 * (uint64_t)kind);
            tkd_pair *all = (tkd_pair *)malloc((n ? n : 1) * sizeof *all);
            size_t *idx = (size_t *)malloc((n + 60) * sizeof *idx);
            unsigned char *seen = (unsigned char *)calloc(n ? n : 1, 1);
            double *d2 = (double *)malloc((n + 60) * sizeof *d2);
            REQUIRE(t, pos && all && idx && d2 && seen, "out of memory");
            REQUIRE(t, pds__kdtree_build(&kd, pos, 3, n, NULL) == PDS_OK, "build failed");
            ks[0] = 1;
            ks[1] = 8;
            ks[2] = 50;
            ks[3] = n + 3; /* more than there are */
            for (q = 0; q < 30; q++) {
                pds__v3 c = tkd_query(pos, 3, n, 77, q);
                tkd_knn_sort(pos, 3, n, c, all);
                for (ki = 0; ki < 4; ki++) {
                    for (mi = 0; mi < sizeof rmaxes / sizeof rmaxes[0]; mi++) {
                        size_t want = tkd_knn_count(all, n, ks[ki], rmaxes[mi]);
                        size_t got = pds__kdtree_knn(&kd, c, ks[ki], rmaxes[mi], idx, d2);
                        found += got;
                        bad += tkd_knn_compare(pos, 3, n, c, all, want, idx, d2, got, seen);
                    }
                }
            }
            CHECK(t, bad == 0, "%s n=%lu: %lu k-NN mismatches against a sort", tkd_kind_name[kind],
                  (unsigned long)n, (unsigned long)bad);
            CHECK(t, n == 0 || found > 0, "%s n=%lu: nothing found", tkd_kind_name[kind],
                  (unsigned long)n);
            pds__kdtree_free(&kd);
            free(pos);
            free(all);
            free(idx);
            free(d2);
            free(seen);
        }
    }
}

/* The gathers' k-nearest queries within the bound an earlier query gives
   (pds__kdtree_knn_hint: its k-th distance plus the step between the two)
   return exactly what the unbounded query returns, indices, distances
   and ties alike: on every kind of point set (duplicates and a single
   repeated point tie everywhere), for walks of small steps (a tight
   bound) and of jumps across the set, with and without rmax. */
static void test_kdtree_knn_hint_finds_the_same_neighbours(pds_test_ctx *t)
{
    static const double rmaxes[] = {DBL_MAX, 0.3};
    static const size_t ks[] = {1, 8, 50};
    int kind;
    for (kind = 0; kind < TKD_KINDS; kind++) {
        size_t n = 5000, q, ki, mi, bad = 0, hinted = 0;
        pds__kdtree kd;
        float *pos = tkd_points(kind, n, 3, 900 + (uint64_t)kind);
        size_t ia[50], ib[50];
        double da[50], db[50];
        REQUIRE(t, pos != NULL, "out of memory");
        REQUIRE(t, pds__kdtree_build(&kd, pos, 3, n, NULL) == PDS_OK, "build failed");
        for (ki = 0; ki < 3; ki++)
            for (mi = 0; mi < 2; mi++) {
                pds__v3 prev = pds__v(0, 0, 0);
                double prev_k2 = -1.0;
                for (q = 0; q < 400; q++) {
                    /* a walk: small steps, a jump every 50 */
                    pds__v3 c = q % 50 == 0 ? tkd_query(pos, 3, n, 91, q)
                                            : pds__add(prev, pds__v(tkd_rand(92, q, 0, -0.01, 0.01),
                                                                    tkd_rand(92, q, 1, -0.01, 0.01),
                                                                    tkd_rand(92, q, 2, -0.01, 0.01)));
                    double bound = pds__kdtree_knn_hint(c, prev, prev_k2, rmaxes[mi]);
                    size_t na = pds__kdtree_knn(&kd, c, ks[ki], rmaxes[mi], ia, da);
                    size_t nb = pds__kdtree_knn_within(&kd, c, ks[ki], bound, ib, db), j;
                    hinted += bound < rmaxes[mi] * rmaxes[mi];
                    if (na != nb) bad++;
                    for (j = 0; j < na && j < nb; j++)
                        if (ia[j] != ib[j] || da[j] != db[j]) bad++;
                    prev = c;
                    prev_k2 = nb == ks[ki] ? db[nb - 1] : -1.0;
                }
            }
        CHECK(t, bad == 0 && hinted > 1000, "%s: %lu differences, %lu queries bounded by the hint",
              tkd_kind_name[kind], (unsigned long)bad, (unsigned long)hinted);
        pds__kdtree_free(&kd);
        free(pos);
    }
}

/* Equal distances are ranked by smaller index: four points at the
   corners of a square around the query, plus one in the middle. */
static void test_kdtree_knn_tie_order(pds_test_ctx *t)
{
    static const float pos[] = {
        1, 0, 0,   0, 1, 0,   -1, 0, 0,   0, -1, 0,   0, 0, 0,   1, 0, 0,   0, 0, 3,
    };
    pds__kdtree kd;
    size_t idx[8];
    double d2[8];
    size_t got;
    REQUIRE(t, pds__kdtree_build(&kd, pos, 3, 7, NULL) == PDS_OK, "build failed");
    got = pds__kdtree_knn(&kd, pds__v(0, 0, 0), 4, DBL_MAX, idx, d2);
    REQUIRE(t, got == 4, "got %lu", (unsigned long)got);
    CHECK(t, idx[0] == 4 && d2[0] == 0.0, "nearest %lu at %g", (unsigned long)idx[0], d2[0]);
    CHECK(t, idx[1] == 0 && idx[2] == 1 && idx[3] == 2, "tie order %lu %lu %lu",
          (unsigned long)idx[1], (unsigned long)idx[2], (unsigned long)idx[3]);
    CHECK(t, d2[1] == 1.0 && d2[3] == 1.0, "distances %g %g", d2[1], d2[3]);
    /* rmax exactly 1 keeps the unit circle (<=), drops the far point */
    got = pds__kdtree_knn(&kd, pds__v(0, 0, 0), 8, 1.0, idx, d2);
    CHECK(t, got == 6 && idx[5] == 5, "rmax = 1: got %lu, last %lu", (unsigned long)got,
          (unsigned long)idx[got ? got - 1 : 0]);
    got = pds__kdtree_knn(&kd, pds__v(0, 0, 0), 8, 0.999, idx, d2);
    CHECK(t, got == 1 && idx[0] == 4, "rmax = 0.999: got %lu", (unsigned long)got);
    pds__kdtree_free(&kd);
}

/* Stride > 3: the extra floats are ignored, and the tree is the very
   same as from a packed copy. */
static void test_kdtree_stride(pds_test_ctx *t)
{
    size_t n = 3000, i, q, hits = 0, bad = 0;
    float *wide = tkd_points(TKD_UNIFORM, n, 7, 42);
    float *packed = tkd_points(TKD_UNIFORM, n, 3, 42);
    pds__kdtree a, b;
    tkd_hits h;
    REQUIRE(t, wide && packed && tkd_hits_alloc(&h, n), "out of memory");
    for (i = 0; i < 3 * n; i++)
        REQUIRE(t, packed[i] == wide[(i / 3) * 7 + i % 3], "test sets differ");
    REQUIRE(t, pds__kdtree_build(&a, wide, 7, n, NULL) == PDS_OK, "build failed");
    REQUIRE(t, pds__kdtree_build(&b, packed, 3, n, NULL) == PDS_OK, "build failed");
    CHECK(t, memcmp(a.pts, b.pts, 3 * n * sizeof(float)) == 0 &&
                 memcmp(a.perm, b.perm, n * sizeof(size_t)) == 0,
          "stride changed the tree");
    for (q = 0; q < 50; q++)
        bad += tkd_range_check(&a, wide, 7, n, tkd_query(wide, 7, n, 3, q), 0.2, &h, &hits);
    CHECK(t, bad == 0 && hits > 50, "%lu mismatches, %lu hits", (unsigned long)bad,
          (unsigned long)hits);
    pds__kdtree_free(&a);
    pds__kdtree_free(&b);
    tkd_hits_free(&h);
    free(wide);
    free(packed);
}

static void test_kdtree_deterministic(pds_test_ctx *t)
{
    int kind;
    for (kind = 0; kind < TKD_KINDS; kind++) {
        size_t n = 20000;
        float *pos = tkd_points(kind, n, 3, 8);
        pds__kdtree a, b;
        REQUIRE(t, pos, "out of memory");
        REQUIRE(t, pds__kdtree_build(&a, pos, 3, n, NULL) == PDS_OK, "build failed");
        REQUIRE(t, pds__kdtree_build(&b, pos, 3, n, NULL) == PDS_OK, "build failed");
        CHECK(t, a.n == b.n && memcmp(a.pts, b.pts, 3 * n * sizeof(float)) == 0 &&
                     memcmp(a.perm, b.perm, n * sizeof(size_t)) == 0 &&
                     memcmp(a.axis, b.axis, n) == 0,
              "%s: two builds differ", tkd_kind_name[kind]);
        pds__kdtree_free(&a);
        pds__kdtree_free(&b);
        free(pos);
    }
}

/* Check the subtree [lo, hi): every point on the correct side of each
   split plane and the depth bound; returns the number of violations. */
static size_t tkd_check_node(const pds__kdtree *kd, size_t lo, size_t hi, int depth, int *maxdepth)
{
    size_t m, i, bad = 0;
    int a;
    float s;
    if (depth > *maxdepth) *maxdepth = depth;
    if (hi - lo <= PDS__KD_LEAF) return 0;
    m = lo + (hi - lo) / 2;
    a = kd->axis[m];
    if (a > 2) return 1;
    s = kd->pts[3 * m + a];
    for (i = lo; i < m; i++)
        if (kd->pts[3 * i + a] > s) bad++;
    for (i = m + 1; i < hi; i++)
        if (kd->pts[3 * i + a] < s) bad++;
    return bad + tkd_check_node(kd, lo, m, depth + 1, maxdepth) +
           tkd_check_node(kd, m + 1, hi, depth + 1, maxdepth);
}

/* The tree holds each input point once (perm is a permutation and the
   stored coordinates are the caller's), split planes separate the
   halves, the depth is logarithmic, and the split axis is that of
   largest extent (checked at the root of an elongated set). */
static void test_kdtree_structure(pds_test_ctx *t)
{
    size_t n = 50000, i, bad = 0;
    int maxdepth = 0;
    float *pos = tkd_points(TKD_UNIFORM, n, 3, 21);
    unsigned char *seen = (unsigned char *)calloc(n, 1);
    pds__kdtree kd;
    REQUIRE(t, pos && seen, "out of memory");
    for (i = 0; i < n; i++) pos[3 * i + 1] *= 5.0f; /* y is the long axis */
    REQUIRE(t, pds__kdtree_build(&kd, pos, 3, n, NULL) == PDS_OK, "build failed");
    for (i = 0; i < n; i++) {
        size_t j = kd.perm[i];
        if (j >= n || seen[j]) {
            bad++;
            continue;
        }
        seen[j] = 1;
        if (memcmp(kd.pts + 3 * i, pos + 3 * j, 3 * sizeof(float)) != 0) bad++;
    }
    CHECK(t, bad == 0, "%lu slots are not a permutation of the input", (unsigned long)bad);
    bad = tkd_check_node(&kd, 0, n, 0, &maxdepth);
    CHECK(t, bad == 0, "%lu points on the wrong side of a split plane", (unsigned long)bad);
    /* a child holds at most half its parent's points, so depth d holds
       at most n >> d: every node at depth D with n >> D <= the leaf size
       is a leaf */
    {
        int bound = 0;
        while ((n >> bound) > PDS__KD_LEAF) bound++;
        CHECK(t, maxdepth <= bound && maxdepth >= bound - 1, "depth %d, expected %d", maxdepth,
              bound);
    }
    CHECK(t, kd.axis[n / 2] == 1, "root splits axis %d, not the long y axis", kd.axis[n / 2]);
    pds__kdtree_free(&kd);
    free(pos);
    free(seen);
}

/* Empty trees, bad arguments, memory accounting, NaN inputs. */
static void test_kdtree_edge_cases(pds_test_ctx *t)
{
    float pos[3 * 40];
    pds__kdtree kd;
    pds_error err;
    size_t idx[4], i, q, hits = 0, bad = 0;
    double d2[4];
    tkd_hits h;
    /* empty */
    REQUIRE(t, pds__kdtree_build(&kd, NULL, 3, 0, NULL) == PDS_OK, "empty build failed");
    CHECK(t, pds__kdtree_memory(&kd) == 0, "empty tree owns %lu bytes",
          (unsigned long)pds__kdtree_memory(&kd));
    CHECK(t, pds__kdtree_knn(&kd, pds__v(0, 0, 0), 4, DBL_MAX, idx, d2) == 0, "knn on empty");
    pds__kdtree_free(&kd);
    pds__kdtree_free(&kd); /* twice is harmless */
    /* stride below 3 is refused with a message */
    for (i = 0; i < 3 * 40; i++) pos[i] = (float)i;
    memset(&err, 0, sizeof err);
    CHECK(t, pds__kdtree_build(&kd, pos, 2, 10, &err) == PDS_ERR_INVALID_ARG, "stride 2 accepted");
    CHECK(t, err.status == PDS_ERR_INVALID_ARG && strstr(err.message, "stride") != NULL,
          "message: %s", err.message);
    CHECK(t, kd.n == 0 && kd.pts == NULL, "failed build left data behind");
    /* memory is reported; negative or NaN radii and NaN queries find nothing */
    REQUIRE(t, pds__kdtree_build(&kd, pos, 3, 40, NULL) == PDS_OK, "build failed");
    CHECK(t, pds__kdtree_memory(&kd) >= 40 * 3 * sizeof(float), "memory %lu",
          (unsigned long)pds__kdtree_memory(&kd));
    REQUIRE(t, tkd_hits_alloc(&h, 40), "out of memory");
    h.n = 40;
    h.total = 0;
    pds__kdtree_range(&kd, pds__v(3, 4, 5), -1.0, tkd_collect, &h);
    pds__kdtree_range(&kd, pds__v(3, 4, 5), NAN, tkd_collect, &h);
    pds__kdtree_range(&kd, pds__v(NAN, 4, 5), 1e9, tkd_collect, &h);
    CHECK(t, h.total == 0, "%lu points reported for a negative/NaN radius or query",
          (unsigned long)h.total);
    CHECK(t, pds__kdtree_knn(&kd, pds__v(3, 4, 5), 4, -1.0, idx, d2) == 0, "knn, negative rmax");
    CHECK(t, pds__kdtree_knn(&kd, pds__v(3, 4, 5), 0, DBL_MAX, idx, d2) == 0, "knn, k = 0");
    CHECK(t, pds__kdtree_knn(&kd, pds__v(3, 4, 5), 1, DBL_MAX, idx, d2) == 1 && idx[0] == 1 &&
                 d2[0] == 0.0,
          "knn at point 1");
    pds__kdtree_free(&kd);
    tkd_hits_free(&h);
    /* NaN points are never found, and do not hide the others: a fifth of
       the points have one NaN coordinate, so NaNs become pivots and
       medians (they must sort above every number, or a partition around
       a NaN pivot would leave the others unordered) */
    {
        size_t nn = 4000;
        float *np = tkd_points(TKD_UNIFORM, nn, 3, 55);
        REQUIRE(t, np && tkd_hits_alloc(&h, nn), "out of memory");
        for (i = 0; i < nn; i++)
            if (pds__rng_uniform(56, PDS__RNG_TEST, i, 0) < 0.2) np[3 * i + i % 3] = NAN;
        REQUIRE(t, pds__kdtree_build(&kd, np, 3, nn, NULL) == PDS_OK, "build with NaN failed");
        for (q = 0; q < 100; q++) {
            double r = 0.15 + 0.01 * (double)(q % 7);
            bad += tkd_range_check(&kd, np, 3, nn, tkd_query(np, 3, nn, 57, 2 * q), r, &h, &hits);
        }
        CHECK(t, bad == 0 && hits > 100, "NaN points: %lu mismatches, %lu hits", (unsigned long)bad,
              (unsigned long)hits);
        pds__kdtree_free(&kd);
        tkd_hits_free(&h);
        free(np);
    }
}

static const pds_test_case tests_kdtree[] = {
    {"kdtree_ellipse_query_matches_brute_force", test_kdtree_ellipse_query_matches_brute_force},
    {"kdtree_range_matches_brute_force_on_random_points", test_kdtree_range_random},
    {"kdtree_range_matches_brute_force_on_duplicates_lines_and_planes", test_kdtree_range_degenerate},
    {"kdtree_knn_matches_a_full_sort_including_ties_and_rmax", test_kdtree_knn},
    {"kdtree_knn_breaks_distance_ties_by_smaller_index", test_kdtree_knn_tie_order},
    {"kdtree_knn_within_the_hint_finds_the_same_neighbours", test_kdtree_knn_hint_finds_the_same_neighbours},
    {"kdtree_honours_point_stride", test_kdtree_stride},
    {"kdtree_build_is_deterministic", test_kdtree_deterministic},
    {"kdtree_is_a_balanced_permutation_with_valid_split_planes", test_kdtree_structure},
    {"kdtree_handles_empty_sets_bad_arguments_and_nan", test_kdtree_edge_cases},
};

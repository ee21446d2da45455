/* tests/test_exact.c - the photon images' exact sums: 128-bit integer
   arithmetic against known answers, and images that scale with the light
   at any level for every method. Uses render_text (test_render.c). */

static void test_sum128_adds_exactly_and_carries_into_the_high_word(pds_test_ctx *t)
{
    pds__sum128 a = {0, 0};
    int i;
    /* 2^63 + 2^63 carries into hi */
    CHECK(t, pds__sum128_add(&a, PDS__TWO63) == PDS__SUM_ADDED, "2^63 added");
    CHECK(t, pds__sum128_add(&a, PDS__TWO63) == PDS__SUM_ADDED, "2^63 added again");
    CHECK(t, a.hi == 1 && a.lo == 0, "2^64 = hi 1, lo 0 (got %llu, %llu)", (unsigned long long)a.hi,
          (unsigned long long)a.lo);
    /* a term above 2^64 splits exactly: 3 * 2^70 + 2^20 */
    a.lo = a.hi = 0;
    CHECK(t, pds__sum128_add(&a, 3.0 * ldexp(1.0, 70) + ldexp(1.0, 20)) == PDS__SUM_ADDED, "big term");
    CHECK(t, a.hi == 192 && a.lo == 1048576, "3 * 2^70 + 2^20 (got hi %llu lo %llu)", (unsigned long long)a.hi,
          (unsigned long long)a.lo);
    /* terms round to the nearest unit, each on its own */
    a.lo = a.hi = 0;
    for (i = 0; i < 1000; i++) pds__sum128_add(&a, 0.75);
    CHECK(t, a.hi == 0 && a.lo == 1000, "0.75 rounds to 1 each time (got %llu)", (unsigned long long)a.lo);
    CHECK(t, pds__sum128_value(a) == 1000.0, "value of 1000 units");
}

static void test_sum128_is_the_same_in_any_order(pds_test_ctx *t)
{
    /* terms spread over 40 orders of magnitude: in double precision the
       order changes the sum; the integer sums agree to the bit */
    enum { N = 4000 };
    static double v[N];
    pds__sum128 fwd = {0, 0}, bwd = {0, 0}, split[3] = {{0, 0}, {0, 0}, {0, 0}}, merged = {0, 0};
    double dfwd = 0.0, dbwd = 0.0;
    int i;
    for (i = 0; i < N; i++) v[i] = ldexp(1.0 + pds__rng_uniform(7, 1, (uint64_t)i, 0), (int)(pds__rng_uniform(7, 2, (uint64_t)i, 0) * 130.0) - 20);
    for (i = 0; i < N; i++) {
        pds__sum128_add(&fwd, v[i]);
        dfwd += v[i];
    }
    for (i = N - 1; i >= 0; i--) {
        pds__sum128_add(&bwd, v[i]);
        dbwd += v[i];
    }
    for (i = 0; i < N; i++) pds__sum128_add(&split[i % 3], v[i]);
    for (i = 0; i < 3; i++) pds__sum128_add_bits(&merged, split[i].lo, split[i].hi);
    CHECK(t, fwd.lo == bwd.lo && fwd.hi == bwd.hi, "forward and backward sums differ");
    CHECK(t, fwd.lo == merged.lo && fwd.hi == merged.hi, "three partial sums merged differ from one sum");
    CHECK(t, dfwd != dbwd, "the double sums agree, so this data does not show order dependence");
}

static void test_sum128_saturates_and_refuses_what_is_not_a_number(pds_test_ctx *t)
{
    pds__sum128 a = {0, 0};
    CHECK(t, pds__sum128_add(&a, -1.0) == PDS__SUM_INVALID, "negative");
    CHECK(t, pds__sum128_add(&a, NAN) == PDS__SUM_INVALID, "NaN");
    CHECK(t, pds__sum128_add(&a, HUGE_VAL) == PDS__SUM_INVALID, "infinity");
    CHECK(t, a.lo == 0 && a.hi == 0, "invalid terms add nothing");
    CHECK(t, pds__sum128_add(&a, ldexp(1.0, 127)) == PDS__SUM_SATURATED, "2^127 is past one term's range");
    CHECK(t, a.lo == UINT64_MAX && a.hi == UINT64_MAX, "saturated sum holds its largest value");
    a.lo = 0;
    a.hi = UINT64_MAX;
    CHECK(t, pds__sum128_add(&a, ldexp(1.0, 126)) == PDS__SUM_SATURATED, "2^128 - 2^64 + 2^126 overflows");
    a.lo = UINT64_MAX - 1;
    a.hi = UINT64_MAX;
    CHECK(t, pds__sum128_add_bits(&a, 1, 0) == 0 && a.lo == UINT64_MAX, "2^128 - 1 is still in range");
    CHECK(t, pds__sum128_add_bits(&a, 1, 0) == 1, "2^128 is not");
}

/* A silver ring and a glass ball on a floor, lit by a point light and a
   small quad light (so the path tracer has caustics too), their powers
   scaled by `scale` (the documented limit of 1e12 allows 1e-12 to 1e12). */
static int exact_render(pds_method method, double scale, pds_image *img, pds_render_stats *st)
{
    char text[1024];
    pds_options opt;
    snprintf(text, sizeof text,
             "camera { position 0.4 3 2.4 look_at 0 0 0 fov 40 resolution 24 20 spp 2 }\n"
             "material floor diffuse { albedo 0.7 }\n"
             "material silver conductor { preset silver }\n"
             "material glass dielectric { ior 1.5 }\n"
             "material lamp emissive { radiance %.17g }\n"
             "light point { position -3 2 -0.5 power %.17g }\n"
             "quad { material floor size 8 8 }\n"
             "quad { material lamp size 0.4 0.4 rotate 180 1 0 0 translate 1 3 0 }\n"
             "cylinder { material silver radius 0.8 inner_radius 0.75 height 0.3 segments 64 closed }\n"
             "sphere { material glass radius 0.3 translate 0.9 0.6 0.2 }\n",
             0.5 * scale, 0.9 * scale);
    pds_options_default(&opt);
    opt.method = method;
    opt.photons = 4000;
    opt.passes = 2;
    opt.threads = 2;
    opt.seed = 3;
    return render_text(text, &opt, img, st);
}

/* Every method's image scales with the lights to 1e-6 relative, from
   1e-12 to 1e12 times the light (the photon methods' old 2^-32 fixed point
   lost a whole caustic at 1e-9 and overflowed at 1e12). */
static void test_images_scale_with_the_light_for_every_method(pds_test_ctx *t)
{
    static const pds_method methods[] = {PDS_METHOD_PT, PDS_METHOD_PDS
#ifndef PDS_NO_BASELINES
                                         , PDS_METHOD_PM, PDS_METHOD_PDM, PDS_METHOD_SPLAT, PDS_METHOD_PPM
#endif
    };
    static const double scales[] = {1e-12, 1e-8, 1e-4, 1e4, 1e8, 1e12};
    size_t m, k, i;
    for (m = 0; m < sizeof methods / sizeof methods[0]; m++) {
        pds_image base = {0, 0, NULL};
        pds_render_stats st;
        double peak = 0.0, sum = 0.0;
        size_t n;
        REQUIRE(t, exact_render(methods[m], 1.0, &base, &st), "render %s", pds_method_name(methods[m]));
        n = (size_t)base.width * base.height * 3;
        for (i = 0; i < n; i++) {
            peak = fmax(peak, base.rgb[i]);
            sum += base.rgb[i];
        }
        CHECK(t, sum > 0.0 && st.saturated == 0 && st.dropped_invalid == 0 && st.nonfinite == 0,
              "%s: an unlit or overflowing base image (saturated %ld, invalid %ld, nonfinite %ld)",
              pds_method_name(methods[m]), st.saturated, st.dropped_invalid, st.nonfinite);
        for (k = 0; k < sizeof scales / sizeof scales[0]; k++) {
            pds_image img = {0, 0, NULL};
            double worst = 0.0;
            size_t bad = 0;
            REQUIRE(t, exact_render(methods[m], scales[k], &img, &st), "render");
            for (i = 0; i < n; i++) {
                double a = img.rgb[i] / scales[k], b = base.rgb[i], e = fabs(a - b);
                if (e > 1e-6 * b + 1e-15 * peak) bad++;
                if (b > 1e-9 * peak && e / b > worst) worst = e / b;
            }
            CHECK(t, bad == 0, "%s at %g x the light: %lu values off by more than 1e-6 (worst %g)",
                  pds_method_name(methods[m]), scales[k], (unsigned long)bad, worst);
            CHECK(t, st.saturated == 0 && st.nonfinite == 0, "%s at %g: saturated %ld, nonfinite %ld",
                  pds_method_name(methods[m]), scales[k], st.saturated, st.nonfinite);
            pds_image_free(&img);
        }
        pds_image_free(&base);
    }
}


/* No output image holds NaN or infinity: the render's conversion replaces
   and counts them (NaN -> 0, beyond the float range -> the largest float). */
static void test_output_images_hold_no_nan_or_infinity(pds_test_ctx *t)
{
    double in[6];
    float out[6];
    in[0] = 0.5;
    in[1] = NAN;
    in[2] = HUGE_VAL;
    in[3] = -HUGE_VAL;
    in[4] = 1e39;
    in[5] = FLT_MAX;
    CHECK(t, pds__finite_floats(in, out, 6) == 4, "four values replaced");
    CHECK(t, out[0] == 0.5f && out[1] == 0.0f && out[2] == FLT_MAX && out[3] == -FLT_MAX && out[4] == FLT_MAX &&
             out[5] == FLT_MAX,
          "replacements %g %g %g %g %g", out[1], out[2], out[3], out[4], out[5]);
}

/* pds__image_add3, the splats' three channels in one call with its own
   fast paths, is pds__image_add three times, bit for bit and in the
   counts of saturated and dropped terms: over terms from 0 and denormals
   to past 2^127 units, negative (into the negative sums, or dropped in
   an RGB image), NaN and infinite, mixed within one call, into sums at
   0, about to carry into their high word, with the high word past 2^63
   and one below its largest value, and saturated. */
static void test_image_add3_is_image_add_three_times(pds_test_ctx *t)
{
    static const double unit = 1048576.0;
    const double terms[] = {1.0,      0.3,  0.0,    5e-320, 1e-7,   ldexp(1.0, 40), ldexp(1.0, 43) - 1.0,
                            ldexp(1.0, 43), ldexp(1.0, 43) + 2048.0, ldexp(1.0, 80), ldexp(1.0, 106),
                            ldexp(1.0, 107), -2.5, NAN, HUGE_VAL, -HUGE_VAL};
    const pds__sum128 starts[] = {{0, 0},
                                  {UINT64_MAX - 3u, 0},
                                  {UINT64_MAX - 3u, UINT64_MAX / 2u},
                                  {5, (UINT64_MAX / 2u) + 1u},
                                  {UINT64_MAX, UINT64_MAX - 1u},
                                  {UINT64_MAX, UINT64_MAX}};
    size_t nt = sizeof terms / sizeof terms[0], ns = sizeof starts / sizeof starts[0], a, b, c, k, bad = 0, cases = 0;
    int spectral;
    for (spectral = 0; spectral < 2; spectral++)
        for (a = 0; a < nt; a++)
            for (b = 0; b < nt; b++)
                for (k = 0; k < ns * ns; k++) {
                    pds__sum128 s3[6], s1[6];
                    pds__splat_buf b3, b1;
                    double v[3];
                    v[0] = terms[a];
                    v[1] = terms[b];
                    v[2] = terms[(a + b) % nt];
                    /* each pair of starts on the first two channels */
                    for (c = 0; c < 6; c++)
                        s3[c] = s1[c] = starts[c % 3 == 0 ? k % ns : c % 3 == 1 ? k / ns : k % 2];
                    memset(&b3, 0, sizeof b3);
                    b3.sum = s3;
                    b3.neg = spectral ? s3 + 3 : NULL;
                    b3.unit = unit;
                    b1 = b3;
                    b1.sum = s1;
                    b1.neg = spectral ? s1 + 3 : NULL;
                    pds__image_add3(&b3, 0, v);
                    for (c = 0; c < 3; c++) pds__image_add(&b1, c, v[c]);
                    for (c = 0; c < 6; c++)
                        if (s3[c].lo != s1[c].lo || s3[c].hi != s1[c].hi) bad++;
                    if (b3.saturated != b1.saturated || b3.invalid != b1.invalid) bad++;
                    cases++;
                }
    CHECK(t, bad == 0 && cases == 2 * nt * nt * ns * ns, "%zu of %zu calls differ from three single adds", bad, cases);
}

static const pds_test_case tests_exact[] = {
    {"sum128_adds_exactly_and_carries_into_the_high_word", test_sum128_adds_exactly_and_carries_into_the_high_word},
    {"sum128_is_the_same_in_any_order", test_sum128_is_the_same_in_any_order},
    {"sum128_saturates_and_refuses_what_is_not_a_number", test_sum128_saturates_and_refuses_what_is_not_a_number},
    {"image_add3_is_image_add_three_times", test_image_add3_is_image_add_three_times},
    {"images_scale_with_the_light_for_every_method", test_images_scale_with_the_light_for_every_method},
    {"output_images_hold_no_nan_or_infinity", test_output_images_hold_no_nan_or_infinity},
};

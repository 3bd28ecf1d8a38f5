/*
 * The Principled BSDF (render/bsdf_principled.c), Blender 4.x and 3.x modes.
 *
 * Monte Carlo checks use a fixed seed; every tolerance is a multiple (5) of the
 * estimator's standard error computed from the same samples, plus a stated float
 * allowance, so a failure means a real disagreement, not bad luck:
 * - pdf consistency: the integral of pdf over the sphere (uniform sphere sampling) equals
 *   the probability that sample() returns a direction (counted);
 * - sample() returns the bits eval() gives for the same direction (outside a bump's
 *   sampler-only region);
 * - energy: the albedo E[f_cos / pdf] is <= 1 for white materials;
 * - white furnace: 4.x white metal has albedo 1 at every roughness and view (1%);
 * - principled_albedo() against the Monte Carlo albedo;
 * - the renderer's split of the bumped albedo: principled_albedo_uncut() plus the mean of
 *   principled_albedo_cut_estimate() against the Monte Carlo albedo, and exactly the
 *   tabulated albedo (cut estimate 0) without a bump;
 * - the prepared-closure functions give the same bits as the one-shot ones;
 * - reciprocity of 3.x (Disney diffuse + GGX are symmetric; 4.x is not, by design: its
 *   energy compensation and layering depend on the view direction only, as in Cycles);
 * - values computed by hand from Cycles' formulas.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "render/bsdf_principled.h"
#include "render/microfacet_tables.h"

#define PI 3.14159265358979323846

typedef struct rng {
    uint64_t s;
} rng;

/* SplitMix64, to [0, 1). */
static double rnd(rng *r)
{
    uint64_t z = (r->s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

static float3 uniform_sphere(rng *r)
{
    double z = 1.0 - 2.0 * rnd(r), phi = 2.0 * PI * rnd(r);
    double s = sqrt(fmax(0.0, 1.0 - z * z));
    return make_float3((float)(s * cos(phi)), (float)(s * sin(phi)), (float)z);
}

/* A direction in the upper hemisphere of +z with cos >= min_cos. */
static float3 upper_direction(rng *r, float min_cos)
{
    double z = min_cos + (1.0 - min_cos) * rnd(r), phi = 2.0 * PI * rnd(r);
    double s = sqrt(fmax(0.0, 1.0 - z * z));
    return make_float3((float)(s * cos(phi)), (float)(s * sin(phi)), (float)z);
}

static const float3 NG = {0.0f, 0.0f, 1.0f};

/* Random material; bump > 0 tilts the shading normal by up to that many radians. */
static void random_material(rng *r, principled_inputs *in, float bump)
{
    principled_inputs_default(in);
    for (int c = 0; c < 3; c++)
        in->base_color[c] = (float)rnd(r);
    in->metallic = rnd(r) < 0.3 ? (float)(rnd(r) < 0.5) : (float)rnd(r);
    in->roughness = (float)(0.05 + 0.95 * rnd(r));
    if (bump > 0.0f) {
        double t = bump * rnd(r), phi = 2.0 * PI * rnd(r);
        in->N = make_float3((float)(sin(t) * cos(phi)), (float)(sin(t) * sin(phi)),
                            (float)cos(t));
    }
}

typedef struct albedo_estimate {
    double mean[3], se[3];  /* albedo per channel and its standard error */
    double success;         /* fraction of sample() calls that returned a direction */
    double success_eval;    /* ... a direction above the shading normal's horizon, where
                               eval() is defined (sample() also returns directions above Ng
                               below it, as Cycles' sampler does) */
} albedo_estimate;

/* Whether principled_sample() with these numbers gives a direction of the sampler-only
 * region: above Ng, below the hemisphere of the microfacet lobe that sampled it. */
static bool sampler_only(const principled_inputs *in, int blender, float3 wo,
                         const float u[3])
{
    principled_closure c;
    principled_sampled smp;
    if (!principled_prepare(in, blender, wo, NG, &c))
        return false;
    principled_closure_sample_direction(&c, u, &smp);
    if (!smp.usable || smp.lobe == PRINCIPLED_DIFFUSE)
        return false;
    const float3 N = c.lobe[smp.lobe].N;
    return !(N.x * smp.raw.x + N.y * smp.raw.y + N.z * smp.raw.z > 0.0f);
}

static albedo_estimate mc_albedo(const principled_inputs *in, int blender, float3 wo,
                                 int n, rng *r)
{
    double s[3] = {0}, s2[3] = {0};
    int ok = 0, ok_eval = 0;
    for (int i = 0; i < n; i++) {
        float u[3] = {(float)rnd(r), (float)rnd(r), (float)rnd(r)};
        float3 wi;
        float f[3], pdf;
        if (!principled_sample(in, blender, wo, NG, u, &wi, f, &pdf))
            continue;
        ok++;
        ok_eval += !sampler_only(in, blender, wo, u);
        for (int c = 0; c < 3; c++) {
            double v = f[c] / pdf;
            s[c] += v;
            s2[c] += v * v;
        }
    }
    albedo_estimate e;
    for (int c = 0; c < 3; c++) {
        e.mean[c] = s[c] / n;
        e.se[c] = sqrt(fmax(s2[c] / n - e.mean[c] * e.mean[c], 0.0) / n);
    }
    e.success = (double)ok / n;
    e.success_eval = (double)ok_eval / n;
    return e;
}

/* The pdf integrates (over the sphere) to the probability that sample() returns a
 * direction where eval() is defined (above the shading normal's horizon); without a bump
 * that is every direction sample() returns. */
static void check_pdf_integral(int blender, float bump)
{
    rng r = {blender * 1000 + (bump > 0.0f)};
    const int n = 200000;
    for (int trial = 0; trial < 12; trial++) {
        principled_inputs in;
        random_material(&r, &in, bump);
        in.roughness = (float)(0.25 + 0.75 * rnd(&r)); /* uniform sampling needs wide lobes */
        float3 wo = upper_direction(&r, 0.1f);
        double s = 0.0, s2 = 0.0;
        for (int i = 0; i < n; i++) {
            float3 wi = uniform_sphere(&r);
            float f[3], pdf;
            principled_eval(&in, blender, wo, wi, NG, f, &pdf);
            double v = pdf * 4.0 * PI;
            s += v;
            s2 += v * v;
        }
        double integral = s / n;
        double se_int = sqrt(fmax(s2 / n - integral * integral, 0.0) / n);
        albedo_estimate e = mc_albedo(&in, blender, wo, n, &r);
        double se_succ = sqrt(e.success_eval * (1.0 - e.success_eval) / n);
        double tol = 5.0 * sqrt(se_int * se_int + se_succ * se_succ) + 1e-4;
        if (fabs(integral - e.success_eval) > tol)
            fail_msg("blender %d trial %d: integral of pdf %.5f, sample() success where eval "
                     "is defined %.5f, tolerance %.5f (roughness %.3f metallic %.3f)",
                     blender, trial, integral, e.success_eval, tol, in.roughness,
                     in.metallic);
        if (bump == 0.0f)
            assert_true(e.success == e.success_eval);
        if (bump == 0.0f && blender == 4 && in.metallic == 0.0f)
            assert_true(fabs(integral - 1.0) < 5.0 * se_int + 0.02);
    }
}

static void test_pdf_integral_4(void **state)
{
    (void)state;
    check_pdf_integral(4, 0.0f);
    check_pdf_integral(4, 0.6f);
}

static void test_pdf_integral_3(void **state)
{
    (void)state;
    check_pdf_integral(3, 0.0f);
    check_pdf_integral(3, 0.6f);
}

/* sample() reports the same f_cos and pdf as eval(), bit for bit, for the direction it
 * chose, where eval() is defined. With a bump it also returns directions above Ng but below the
 * shading normal's horizon, where eval() is 0 and sample() keeps the sampled lobe's
 * value, as Cycles' sampler does (bsdf_principled.c, microfacet_sampled_value). */
static void check_sample_matches_eval(int blender)
{
    rng r = {77 + blender};
    int n_sampler_only = 0;
    for (int trial = 0; trial < 200; trial++) {
        principled_inputs in;
        random_material(&r, &in, trial % 2 ? 0.8f : 0.0f);
        float3 wo = upper_direction(&r, 0.02f);
        for (int k = 0; k < 50; k++) {
            float u[3] = {(float)rnd(&r), (float)rnd(&r), (float)rnd(&r)};
            float3 wi;
            float f[3], pdf, fe[3], pe;
            if (!principled_sample(&in, blender, wo, NG, u, &wi, f, &pdf))
                continue;
            principled_eval(&in, blender, wo, wi, NG, fe, &pe);
            assert_true(pdf > 0.0f);
            assert_true(wi.z > 0.0f);
            if (sampler_only(&in, blender, wo, u)) {
                assert_true(pe == 0.0f && fe[0] == 0.0f && fe[1] == 0.0f && fe[2] == 0.0f);
                assert_true(f[0] >= 0.0f && f[1] >= 0.0f && f[2] >= 0.0f);
                n_sampler_only++;
                continue;
            }
            /* The same bits: random_material's roughness has no delta lobe. */
            assert_true(pe == pdf);
            assert_memory_equal(fe, f, sizeof f);
        }
    }
    /* The bumped trials reach that region. */
    assert_true(n_sampler_only > 0);
}

static void test_sample_matches_eval(void **state)
{
    (void)state;
    check_sample_matches_eval(4);
    check_sample_matches_eval(3);
}

/* White materials reflect at most all the light, for every view. */
static void test_energy_conservation(void **state)
{
    (void)state;
    rng r = {5};
    for (int blender = 3; blender <= 4; blender++) {
        for (int trial = 0; trial < 40; trial++) {
            principled_inputs in;
            random_material(&r, &in, trial % 3 == 0 ? 0.7f : 0.0f);
            in.base_color[0] = in.base_color[1] = in.base_color[2] = 1.0f;
            float3 wo = upper_direction(&r, 0.05f);
            albedo_estimate e = mc_albedo(&in, blender, wo, 40000, &r);
            for (int c = 0; c < 3; c++) {
                /* 3.x's Disney diffuse is not energy conserving: its retro-reflection adds
                 * up to ~ roughness * (FL + FV) at grazing angles; only 4.x must hold. */
                if (blender == 4 && e.mean[c] > 1.0 + 5.0 * e.se[c] + 1e-3)
                    fail_msg("blender 4 trial %d: albedo %.4f +- %.4f > 1 (roughness %.3f "
                             "metallic %.3f, view cos %.3f)",
                             trial, e.mean[c], e.se[c], in.roughness, in.metallic, wo.z);
            }
        }
    }
}

/* 4.x's multiple-scattering GGX: white metal keeps all energy at any roughness. */
static void test_white_furnace_4(void **state)
{
    (void)state;
    rng r = {11};
    const float roughness[] = {0.0f, 0.05f, 0.1f, 0.2f, 0.3f, 0.5f, 0.7f, 0.85f, 1.0f};
    const float view_cos[] = {1.0f, 0.7f, 0.4f, 0.2f, 0.08f};
    for (size_t i = 0; i < sizeof roughness / sizeof *roughness; i++) {
        for (size_t j = 0; j < sizeof view_cos / sizeof *view_cos; j++) {
            principled_inputs in;
            principled_inputs_default(&in);
            in.base_color[0] = in.base_color[1] = in.base_color[2] = 1.0f;
            in.metallic = 1.0f;
            in.roughness = roughness[i];
            float s = sqrtf(1.0f - view_cos[j] * view_cos[j]);
            float3 wo = make_float3(s, 0.0f, view_cos[j]);
            albedo_estimate e = mc_albedo(&in, 4, wo, 40000, &r);
            if (fabs(e.mean[0] - 1.0) > 0.01 + 5.0 * e.se[0])
                fail_msg("white metal roughness %.2f view cos %.2f: albedo %.4f +- %.4f",
                         roughness[i], view_cos[j], e.mean[0], e.se[0]);
            /* principled_albedo agrees. (Not exactly 1: Cycles' compensation reads E from
             * its 32 x 32 table, linearly interpolated, while the albedo integrates the
             * actual lobe; they coincide on the table's grid points, e.g. view cos 1.) */
            float alb[3];
            principled_albedo(&in, 4, wo, NG, alb);
            assert_true(fabs(alb[0] - 1.0) <= 0.01);
            assert_true(fabs(alb[0] - e.mean[0]) <= 5.0 * e.se[0] + 0.002);
            if (view_cos[j] == 1.0f)
                assert_float_equal(alb[0], 1.0f, 2e-5f);
        }
    }
}

/* principled_albedo against the Monte Carlo integral of f_cos. */
static void check_albedo(int blender, float bump)
{
    rng r = {300 + blender + (bump > 0.0f) * 10};
    double worst = 0.0;
    for (int trial = 0; trial < 40; trial++) {
        principled_inputs in;
        random_material(&r, &in, bump);
        float3 wo = upper_direction(&r, 0.05f);
        albedo_estimate e = mc_albedo(&in, blender, wo, 100000, &r);
        float alb[3];
        principled_albedo(&in, blender, wo, NG, alb);
        for (int c = 0; c < 3; c++) {
            double err = fabs(alb[c] - e.mean[c]) - 5.0 * e.se[c];
            worst = fmax(worst, err);
            /* Allowance beyond 5 sigma: linear interpolation of the 32 x 32 tables between
             * grid points (worst seen 0.0007, at low roughness and oblique views), or, for
             * bumped normals, the coarse quadrature (worst 0.0045, mean 0.0003, against an
             * 8x finer one over 800 random cases). */
            if (err > (bump > 0.0f ? 0.005 : 0.002))
                fail_msg("blender %d bump %.1f trial %d channel %d: principled_albedo %.5f, "
                         "Monte Carlo %.5f +- %.5f (roughness %.3f metallic %.3f cos %.3f)",
                         blender, bump, trial, c, alb[c], e.mean[c], e.se[c], in.roughness,
                         in.metallic, wo.z);
        }
    }
    print_message("blender %d bump %.1f: worst |albedo - MC| beyond 5 sigma: %.5f\n", blender,
                  bump, worst);
}

static void test_albedo(void **state)
{
    (void)state;
    check_albedo(4, 0.0f);
    check_albedo(3, 0.0f);
    check_albedo(4, 0.6f);
    check_albedo(3, 0.6f);
}

/* The renderer's world term with a bump: uncut tables + the mean cut estimate must be the
 * albedo. The cut estimate is averaged over n random u; both it and the Monte Carlo
 * albedo carry a standard error, and the tables their interpolation allowance. */
static void check_cut_estimate(int blender)
{
    rng r = {900 + blender};
    double worst = 0.0, largest_cut = 0.0;
    for (int trial = 0; trial < 40; trial++) {
        principled_inputs in;
        random_material(&r, &in, 0.8f);
        float3 wo = upper_direction(&r, 0.05f);
        principled_closure c;
        assert_true(principled_prepare(&in, blender, wo, NG, &c));
        albedo_estimate e = mc_albedo(&in, blender, wo, 100000, &r);
        float uncut[3];
        principled_albedo_uncut(&c, uncut);
        const int n = 100000;
        double s[3] = {0}, s2[3] = {0};
        for (int k = 0; k < n; k++) {
            float u[3] = {(float)rnd(&r), (float)rnd(&r), (float)rnd(&r)}, cut[3];
            principled_albedo_cut_estimate(&c, u, cut);
            for (int ch = 0; ch < 3; ch++) {
                s[ch] += cut[ch];
                s2[ch] += (double)cut[ch] * cut[ch];
            }
        }
        for (int ch = 0; ch < 3; ch++) {
            double mean = s[ch] / n;
            double se = sqrt(fmax(s2[ch] / n - mean * mean, 0.0) / n);
            double err = fabs(uncut[ch] + mean - e.mean[ch]) -
                         5.0 * sqrt(se * se + e.se[ch] * e.se[ch]);
            worst = fmax(worst, err);
            largest_cut = fmax(largest_cut, -mean);
            /* Same table allowance as check_albedo's unbumped case. */
            if (err > 0.002)
                fail_msg("blender %d trial %d channel %d: uncut %.5f + cut %.5f +- %.5f, "
                         "Monte Carlo %.5f +- %.5f (roughness %.3f metallic %.3f)",
                         blender, trial, ch, uncut[ch], mean, se, e.mean[ch], e.se[ch],
                         in.roughness, in.metallic);
        }
    }
    /* The check means something only if the bump really cuts lobes. */
    assert_true(largest_cut > 0.01);
    print_message("blender %d: largest cut %.4f, worst |uncut + cut - MC| beyond 5 sigma "
                  "%.5f\n", blender, largest_cut, worst);
}

static void test_albedo_cut_estimate(void **state)
{
    (void)state;
    check_cut_estimate(4);
    check_cut_estimate(3);
    /* Without a bump the uncut albedo is the albedo and nothing is cut. */
    rng r = {77};
    for (int trial = 0; trial < 200; trial++) {
        int blender = trial % 2 ? 3 : 4;
        principled_inputs in;
        random_material(&r, &in, 0.0f);
        float alb[3], uncut[3], cut[3], u[3] = {(float)rnd(&r), (float)rnd(&r), 0.5f};
        float3 wo = upper_direction(&r, 0.05f);
        principled_closure c;
        assert_true(principled_prepare(&in, blender, wo, NG, &c));
        assert_int_equal(c.bumped, 0);
        principled_albedo(&in, blender, wo, NG, alb);
        principled_albedo_uncut(&c, uncut);
        principled_albedo_cut_estimate(&c, u, cut);
        for (int ch = 0; ch < 3; ch++) {
            assert_true(alb[ch] == uncut[ch]);
            assert_true(cut[ch] == 0.0f);
        }
    }
}

/* principled_closure_* on a prepared closure == the one-shot functions, bit for bit. */
static void test_prepared_closure(void **state)
{
    (void)state;
    rng r = {55};
    for (int trial = 0; trial < 2000; trial++) {
        int blender = trial % 2 ? 3 : 4;
        principled_inputs in;
        random_material(&r, &in, trial % 4 < 2 ? 0.0f : 0.8f);
        float u[3] = {(float)rnd(&r), (float)rnd(&r), (float)rnd(&r)};
        float3 wo = upper_direction(&r, 0.05f), wi = uniform_sphere(&r);
        principled_closure c;
        assert_true(principled_prepare(&in, blender, wo, NG, &c));
        float f1[3], f2[3], p1, p2;
        float3 w1, w2;
        principled_eval(&in, blender, wo, wi, NG, f1, &p1);
        principled_closure_eval(&c, wi, f2, &p2);
        assert_memory_equal(f1, f2, sizeof f1);
        assert_true(p1 == p2);
        int ok1 = principled_sample(&in, blender, wo, NG, u, &w1, f1, &p1);
        int ok2 = principled_closure_sample(&c, u, &w2, f2, &p2);
        assert_int_equal(ok1, ok2);
        assert_memory_equal(&w1, &w2, sizeof w1);
        assert_memory_equal(f1, f2, sizeof f1);
        assert_true(p1 == p2);
        /* In two steps (the direction, then its value): the same. */
        principled_sampled smp;
        principled_closure_sample_direction(&c, u, &smp);
        principled_closure_sampled_eval(&c, &smp, f1, &p1);
        assert_int_equal(smp.usable && p1 > 0.0f, ok2);
        if (smp.usable) {
            assert_memory_equal(&smp.raw, &w2, sizeof w2);
            assert_memory_equal(f1, f2, sizeof f1);
            assert_true(p1 == p2);
        } else {
            assert_true(f1[0] == 0.0f && f1[1] == 0.0f && f1[2] == 0.0f && p1 == 0.0f);
        }
        /* The cut estimate reusing that direction: the same bits as sampling it anew. */
        float cut1[3], cut2[3];
        principled_albedo_cut_estimate(&c, u, cut1);
        principled_albedo_cut_estimate_shared(&c, u, &smp, cut2);
        assert_memory_equal(cut1, cut2, sizeof cut1);
    }
    /* Seen from below the surface: not prepared, and every function gives zeros. */
    principled_inputs in;
    principled_inputs_default(&in);
    principled_closure c;
    float3 below = make_float3(0.0f, 0.6f, -0.8f);
    float f[3], p, alb[3];
    assert_false(principled_prepare(&in, 4, below, NG, &c));
    principled_closure_eval(&c, NG, f, &p);
    principled_albedo_uncut(&c, alb);
    assert_true(f[0] == 0.0f && p == 0.0f && alb[0] == 0.0f);
}

/* 3.x: f(wo, wi) / cos(wi) = f(wi, wo) / cos(wo) (unbumped normal). */
static void test_reciprocity_3(void **state)
{
    (void)state;
    rng r = {9};
    for (int trial = 0; trial < 2000; trial++) {
        principled_inputs in;
        random_material(&r, &in, 0.0f);
        float3 a = upper_direction(&r, 0.05f);
        float3 b = upper_direction(&r, 0.05f);
        float fab[3], fba[3], p;
        principled_eval(&in, 3, a, b, NG, fab, &p);
        principled_eval(&in, 3, b, a, NG, fba, &p);
        for (int c = 0; c < 3; c++) {
            double x = fab[c] / b.z, y = fba[c] / a.z;
            assert_true(fabs(x - y) <= 1e-4 * fmax(fabs(x), fabs(y)) + 1e-7);
        }
    }
}

/* Values worked out by hand from Cycles' formulas. */
static void test_hand_values(void **state)
{
    (void)state;
    const float3 up = make_float3(0.0f, 0.0f, 1.0f);
    principled_inputs in;
    float f[3], pdf;

    /* 3.x, roughness 1, V = L = N: the Disney diffuse is base/pi (FV = FL = 0); GGX has
     * D = 1/pi, G = 1, F = cspec0 = 0.08 * 0.5, f_cos = F D / 4. */
    principled_inputs_default(&in);
    in.roughness = 1.0f;
    principled_eval(&in, 3, up, up, NG, f, &pdf);
    assert_float_equal(f[0], (0.8 + 0.04 / 4.0) / PI, 1e-6);
    /* pdf: p_d / pi + p_s * D G1 / 4 with p_s / p_d = F(view) / 0.8 = 0.04 / 0.8. */
    {
        double ps = 0.04 / 0.84, pd = 0.8 / 0.84;
        assert_float_equal(pdf, pd / PI + ps / (4.0 * PI), 1e-6);
    }

    /* 3.x Disney diffuse alone (Specular 0, no metal: no specular closure), roughness 1,
     * V = N, L at cos 0.5: FV = 0, FL = (1 - 0.5)^5 = 1/32, RR = 1 * (1 + L.V) = 1.5,
     * f = (1 - FL/2) + RR FL = 1 + 1/32, f_cos = base f cos / pi; pdf cos / pi. */
    principled_inputs_default(&in);
    in.roughness = 1.0f;
    in.specular_ior_level = 0.0f;
    {
        float3 L60 = make_float3(sqrtf(0.75f), 0.0f, 0.5f);
        principled_eval(&in, 3, up, L60, NG, f, &pdf);
        assert_float_equal(f[0], 0.8 * (1.0 + 1.0 / 32.0) * 0.5 / PI, 1e-6);
        assert_float_equal(pdf, 0.5 / PI, 1e-6);
        /* Half the roughness halves the retro-reflection: f = 1 - 1/64 + 0.75/32. */
        in.roughness = 0.5f;
        principled_eval(&in, 3, up, L60, NG, f, &pdf);
        assert_float_equal(f[0], 0.8 * (1.0 - 1.0 / 64.0 + 0.75 / 32.0) * 0.5 / PI, 1e-6);
    }

    /* 3.x, roughness 0 metal: a delta. Sample at view cos 0.5: f_cos / pdf is the Fresnel
     * mix(cspec0, 1, (F_real - F0) / (1 - F0)) for IOR 1.5 at cos 0.5. */
    principled_inputs_default(&in);
    in.metallic = 1.0f;
    in.roughness = 0.0f;
    in.base_color[0] = 0.9f;
    in.base_color[1] = 0.6f;
    in.base_color[2] = 0.3f;
    float3 wo = make_float3(sqrtf(0.75f), 0.0f, 0.5f), wi;
    float u[3] = {0.3f, 0.6f, 0.5f};
    assert_int_equal(principled_sample(&in, 3, wo, NG, u, &wi, f, &pdf), 1);
    {
        /* Fresnel of IOR 1.5 at cos 0.5 (Fresnel equations, by hand). */
        double c = 0.5, n = 1.5, st = sqrt(1 - c * c) / n, ct = sqrt(1 - st * st);
        double rs = (c - n * ct) / (c + n * ct), rp = (ct - n * c) / (ct + n * c);
        double F = 0.5 * (rs * rs + rp * rp), F0 = 0.04, s = (F - F0) / (1 - F0);
        assert_float_equal(wi.x, -wo.x, 1e-6);
        assert_float_equal(wi.z, wo.z, 1e-6);
        assert_float_equal(f[0] / pdf, 0.9 + (1 - 0.9) * s, 1e-5);
        assert_float_equal(f[2] / pdf, 0.3 + (1 - 0.3) * s, 1e-5);
    }

    /* 4.x, roughness 0 metal (delta, E = 1 so no compensation): Schlick F82 with white
     * tint, F = f0 + (1 - f0) (1 - cos)^5 at cos 0.5. */
    assert_int_equal(principled_sample(&in, 4, wo, NG, u, &wi, f, &pdf), 1);
    assert_float_equal(f[0] / pdf, 0.9 + 0.1 / 32.0, 1e-5);
    assert_float_equal(f[2] / pdf, 0.3 + 0.7 / 32.0, 1e-5);

    /* 4.x F82 tint: at cos = 1/7 the metal Fresnel is Schlick's times the tint. Roughness 0
     * with the view at cos 1/7 reflects at exactly that angle. */
    in.specular_tint[0] = 0.5f;
    in.specular_tint[1] = 0.25f;
    in.specular_tint[2] = 1.0f;
    float c7 = 1.0f / 7.0f;
    float3 wo7 = make_float3(sqrtf(1.0f - c7 * c7), 0.0f, c7);
    assert_int_equal(principled_sample(&in, 4, wo7, NG, u, &wi, f, &pdf), 1);
    {
        double m5 = pow(6.0 / 7.0, 5);
        assert_float_equal(f[0] / pdf, (0.9 + 0.1 * m5) * 0.5, 1e-5);
        assert_float_equal(f[1] / pdf, (0.6 + 0.4 * m5) * 0.25, 1e-5);
        assert_float_equal(f[2] / pdf, 0.3 + 0.7 * m5, 1e-5);
    }

    /* 4.x white metal, roughness 1, V = L = N: single scattering D G2 / 4 = 1 / (4 pi)
     * (D = 1/pi for alpha = 1), compensated by 1/E with E(mu = 1) = 1 - ln 2 (the albedo
     * of alpha = 1 GGX at normal incidence, integral of c / (1 + c) over c in [0, 1]). */
    principled_inputs_default(&in);
    in.metallic = 1.0f;
    in.roughness = 1.0f;
    in.base_color[0] = in.base_color[1] = in.base_color[2] = 1.0f;
    principled_eval(&in, 4, up, up, NG, f, &pdf);
    assert_float_equal(f[0], 1.0 / (4.0 * PI) / (1.0 - log(2.0)), 2e-4 / (4.0 * PI));
    assert_float_equal(pdf, 1.0 / (4.0 * PI), 1e-6);

    /* 4.x Specular IOR Level 0 removes the specular layer: pure Lambert. */
    principled_inputs_default(&in);
    in.specular_ior_level = 0.0f;
    principled_eval(&in, 4, wo, up, NG, f, &pdf);
    assert_float_equal(f[1], 0.8 / PI, 1e-6);
    assert_float_equal(pdf, 1.0 / PI, 1e-6);

    /* Views from below the geometric surface see nothing. */
    float3 below = make_float3(0.0f, 0.6f, -0.8f);
    principled_inputs_default(&in);
    principled_eval(&in, 4, below, up, NG, f, &pdf);
    assert_true(f[0] == 0.0f && pdf == 0.0f);
}

/* 4.x: the shading normal used by the specular lobes is raised so that the view's mirror
 * reflection is above the surface; the diffuse lobe keeps the normal. */
static void test_valid_reflection(void **state)
{
    (void)state;
    principled_inputs in;
    principled_inputs_default(&in);
    in.roughness = 0.0f;
    in.metallic = 1.0f;
    /* Normal tilted 60 degrees towards +x, view from -x near grazing: the mirror
     * reflection about N would go below the surface. */
    in.N = make_float3(sinf(1.047f), 0.0f, cosf(1.047f));
    float3 wo = make_float3(-0.8f, 0.0f, 0.6f), wi;
    float u[3] = {0.5f, 0.5f, 0.5f}, f[3], pdf;
    for (int blender = 3; blender <= 4; blender++) {
        assert_int_equal(principled_sample(&in, blender, wo, NG, u, &wi, f, &pdf), 1);
        /* The corrected reflection sits at the threshold min(0.9 cos, 0.01) above Ng. */
        assert_float_equal(wi.z, 0.01f, 2e-3f);
    }
}

/* Our regenerated tables against the numbers Cycles ships (intern/cycles/scene/shader.tables,
 * made by Monte Carlo with 2^23 samples a cell; ours by quadrature), read at a few points:
 * ggx_E(x = roughness grid, y = mu grid), ggx_Eavg, and the layering factor
 * ggx_gen_schlick_ior_s looked up for IOR 1.5 (z = sqrt(0.2)), given there to 4 decimals. */
static void test_tables_match_cycles(void **state)
{
    (void)state;
    static const struct { int x, y; double value; } E[] = {
        {1, 0, 0.980405}, {3, 1, 0.954714}, {5, 1, 0.891678}, {10, 16, 0.968235},
        {15, 16, 0.871576}, {26, 31, 0.500893}, {31, 31, 0.306853}, {31, 1, 0.888202}};
    for (size_t i = 0; i < sizeof E / sizeof *E; i++)
        assert_float_equal(microfacet_ggx_E[32 * E[i].y + E[i].x], E[i].value, 5e-5);
    static const struct { int x; double value; } Eavg[] = {
        {4, 0.998729}, {8, 0.985805}, {16, 0.870874}, {20, 0.761345}, {31, 0.409137}};
    for (size_t i = 0; i < sizeof Eavg / sizeof *Eavg; i++)
        assert_float_equal(microfacet_ggx_Eavg[Eavg[i].x], Eavg[i].value, 5e-5);
    static const float rough[4] = {0.0f, 0.25f, 0.5f, 1.0f}, mu[4] = {1.0f, 0.7f, 0.4f, 0.1f};
    static const double S[4][4] = {{0.0000, 0.0117, 0.0955, 0.5628},
                                   {0.0001, 0.0126, 0.0927, 0.4092},
                                   {0.0006, 0.0138, 0.0639, 0.1705},
                                   {0.0014, 0.0058, 0.0161, 0.0403}};
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            assert_float_equal(microfacet_table_3d(microfacet_ggx_gen_schlick_ior_s, rough[i],
                                                   mu[j], sqrtf(0.2f), 16, 16, 16),
                               S[i][j], 1.5e-4);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tables_match_cycles),
        cmocka_unit_test(test_hand_values),
        cmocka_unit_test(test_valid_reflection),
        cmocka_unit_test(test_sample_matches_eval),
        cmocka_unit_test(test_reciprocity_3),
        cmocka_unit_test(test_pdf_integral_4),
        cmocka_unit_test(test_pdf_integral_3),
        cmocka_unit_test(test_energy_conservation),
        cmocka_unit_test(test_white_furnace_4),
        cmocka_unit_test(test_albedo),
        cmocka_unit_test(test_albedo_cut_estimate),
        cmocka_unit_test(test_prepared_closure),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

/*
 * The refinement search (pipeline.h, "refinement") on a loss known in closed form: values
 * with a known optimum, a circular value whose optimum is across the wrap, a selector whose
 * right choice makes another value matter, a fixed parameter and an inactive one. Every
 * method: the budget is the number of loss calls, the curve never rises, fixed and inactive
 * parameters keep their values, the same seed gives the same bytes; coordinate search and
 * the ES get most of the way to the optimum, better than random draws do. Then each
 * variant's promise on a loss made for it (sweeps, jumps, joint zoom, split, mirror) and
 * the colour phase's weighing of the loss's two terms.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "pipeline/pipeline.h"

enum { N = 8, SEL = 4, HUE = 5, GATED = 6, FIXED = 7 };
static const refine_kind kinds[N] = {REFINE_VALUE,    REFINE_VALUE,    REFINE_VALUE,
                                     REFINE_VALUE,    REFINE_SELECTOR, REFINE_CIRCULAR,
                                     REFINE_VALUE,    REFINE_FIXED};
static const int choices[N] = {0, 0, 0, 0, 3, 0, 0, 0};
static const float optimum[N] = {0.2f, 0.8f, 0.5f, 0.05f, 0, 0.95f, 0.3f, 0};

typedef struct problem {
    int calls, active_calls;
    int fail_at; /* the loss call that fails, or 0 */
} problem;

/* Selector 4 at choice 2 (of 3) makes value 6 matter; at other choices the loss pays 1. */
static int quadratic(void *ctx, const float *x, double *loss, double *colour, char *err,
                     size_t errlen)
{
    problem *p = ctx;
    if (++p->calls == p->fail_at) {
        snprintf(err, errlen, "render failed");
        return -1;
    }
    double f = 0.0;
    for (int i = 0; i < 4; i++)
        f += (x[i] - optimum[i]) * (x[i] - optimum[i]);
    double dh = fabs(x[HUE] - optimum[HUE]);
    dh = dh > 0.5 ? 1.0 - dh : dh;
    f += dh * dh;
    int c = (int)(x[SEL] * 3);
    if (c == 2)
        f += (x[GATED] - optimum[GATED]) * (x[GATED] - optimum[GATED]);
    else
        f += 1.0;
    *loss = f;
    *colour = 0.0;
    return 0;
}

static int active_of(void *ctx, const float *x, uint8_t *active, char *err, size_t errlen)
{
    (void)err, (void)errlen;
    problem *p = ctx;
    p->active_calls++;
    for (int i = 0; i < N; i++)
        active[i] = 1;
    active[GATED] = (int)(x[SEL] * 3) == 2;
    return 0;
}

static const refine_space space = {.n = N, .kind = kinds, .choices = choices};
static const float start[N] = {0.5f, 0.5f, 0.9f, 0.6f, 1.0f / 6, 0.1f, 0.77f, 0.42f};

static double run(refine_method m, int budget, uint64_t seed, float *x, refine_result *r,
                  problem *p)
{
    refine_options o;
    refine_options_default(&o);
    o.method = m;
    o.budget = budget;
    o.seed = seed;
    memcpy(x, start, sizeof start);
    char err[256];
    assert_int_equal(refine_search(&space, &o, quadratic, active_of, p, x, r, err, sizeof err), 0);
    return r->best_loss;
}

static void test_contract(void **state)
{
    (void)state;
    for (int m = 0; m < REFINE_N_METHODS; m++) {
        problem p = {0};
        float x[N];
        refine_result r;
        double best = run((refine_method)m, 60, 7, x, &r, &p);
        assert_int_equal(p.calls, 60);
        assert_int_equal(r.evals, 60);
        assert_true(r.curve[0] == r.start_loss);
        for (int i = 1; i < r.evals; i++)
            assert_true(r.curve[i] <= r.curve[i - 1]);
        assert_true(r.curve[r.evals - 1] == best);
        assert_true(best <= r.start_loss);
        /* The returned point has the returned loss. */
        problem q = {0};
        double f, c0;
        char err[64];
        assert_int_equal(quadratic(&q, x, &f, &c0, err, sizeof err), 0);
        assert_true(f == best);
        assert_true(x[FIXED] == start[FIXED]);
        for (int i = 0; i < N; i++)
            assert_true(x[i] >= 0.0f && x[i] <= 1.0f);
        /* A selector holds a bin centre. */
        int c = (int)(x[SEL] * 3);
        assert_true(x[SEL] == (float)((c + 0.5) / 3));
        /* The gated value moves only while it matters: unless the selector's right choice
         * was found, it keeps its start. */
        if (c != 2)
            assert_true(x[GATED] == start[GATED]);
        /* Same seed, same bytes; another seed, another path. */
        problem p2 = {0};
        float x2[N];
        refine_result r2;
        run((refine_method)m, 60, 7, x2, &r2, &p2);
        assert_memory_equal(x, x2, sizeof x);
        assert_memory_equal(r.curve, r2.curve, 60 * sizeof(double));
        refine_result_free(&r);
        refine_result_free(&r2);
    }
}

static void test_quality(void **state)
{
    (void)state;
    /* Over 10 seeds, the median best loss of each method at 120 evaluations. The start's
     * loss is 1.6; the optimum 0. */
    double med[REFINE_N_METHODS];
    for (int m = 0; m < REFINE_N_METHODS; m++) {
        double v[10];
        for (int s = 0; s < 10; s++) {
            problem p = {0};
            float x[N];
            refine_result r;
            v[s] = run((refine_method)m, 120, 100 + (uint64_t)s, x, &r, &p);
            refine_result_free(&r);
        }
        for (int i = 0; i < 10; i++) /* sort */
            for (int j = i + 1; j < 10; j++)
                if (v[j] < v[i]) {
                    double t = v[i];
                    v[i] = v[j];
                    v[j] = t;
                }
        med[m] = 0.5 * (v[4] + v[5]);
        printf("# %-10s median best loss %.4f (start 1.6)\n", refine_method_names[m], med[m]);
    }
    assert_true(med[REFINE_COORDINATE] < 0.02);
    assert_true(med[REFINE_ES] < 0.02);
    assert_true(med[REFINE_COORDINATE] < med[REFINE_RANDOM]);
    assert_true(med[REFINE_ES] < med[REFINE_RANDOM]);
}

/* A loss that never improves on the start and records which parameter each call moved. */
typedef struct flat_problem {
    int calls;
    int moved[64];
} flat_problem;

static int flat_loss(void *ctx, const float *x, double *loss, double *colour, char *err,
                     size_t errlen)
{
    (void)err, (void)errlen;
    flat_problem *p = ctx;
    int k = -1;
    for (int i = 0; i < N; i++)
        if (x[i] != start[i])
            k = i;
    if (p->calls < 64)
        p->moved[p->calls] = k;
    p->calls++;
    *loss = 1.0;
    *colour = 0.0;
    return 0;
}

/* active_of's activity, for a flat_problem context. */
static int flat_active(void *ctx, const float *x, uint8_t *active, char *err, size_t errlen)
{
    problem q = {0};
    (void)ctx;
    return active_of(&q, x, active, err, errlen);
}

/* coordinate-sweep tries each movable parameter once per sweep: over two sweeps' worth of
 * calls, the parameters moved form two runs, each a permutation of the six movable ones
 * (GATED is inactive at the start's selector, FIXED never moves), a value taking two calls
 * (both directions fail), the selector one. */
static void test_coordinate_sweep(void **state)
{
    (void)state;
    refine_options o;
    refine_options_default(&o);
    o.method = REFINE_COORDINATE_SWEEP;
    o.budget = 1 + 2 * (5 * 2 + 1);
    for (uint64_t seed = 1; seed <= 5; seed++) {
        o.seed = seed;
        flat_problem p = {0};
        float x[N];
        memcpy(x, start, sizeof x);
        refine_result r;
        char err[64];
        assert_int_equal(refine_search(&space, &o, flat_loss, flat_active, &p, x, &r, err, sizeof err), 0);
        assert_int_equal(p.calls, o.budget);
        assert_int_equal(p.moved[0], -1); /* the start */
        int call = 1;
        for (int sweep = 0; sweep < 2; sweep++) {
            int seen[N] = {0};
            for (int t = 0; t < 6; t++) {
                int k = p.moved[call];
                assert_true(k >= 0 && k != GATED && k != FIXED);
                assert_int_equal(seen[k], 0);
                seen[k] = 1;
                call += k == SEL ? 1 : 2;
                if (k != SEL)
                    assert_int_equal(p.moved[call - 1], k);
            }
        }
        assert_int_equal(call, o.budget);
        assert_memory_equal(x, start, sizeof x);
        refine_result_free(&r);
    }
}

/* One hue whose loss has a wide local minimum at the start (0.2, loss 0.1) and a narrow
 * global one across a plateau (0.7, loss 0): the shape of a palette ramp, where the colour
 * the input has is several palette entries away. +-step moves never leave the wide basin;
 * coordinate-jump's uniform draws find the narrow one. */
static int two_basins(void *ctx, const float *x, double *loss, double *colour, char *err,
                      size_t errlen)
{
    (void)err, (void)errlen;
    (*(int *)ctx)++;
    double h = x[0];
    *loss = fabs(h - 0.2) < 0.15 ? 0.1 + (h - 0.2) * (h - 0.2)
            : fabs(h - 0.7) < 0.05 ? (h - 0.7) * (h - 0.7)
                                   : 1.0;
    *colour = 0.0;
    return 0;
}

static int hue_active(void *ctx, const float *x, uint8_t *active, char *err, size_t errlen)
{
    (void)ctx, (void)x, (void)err, (void)errlen;
    active[0] = 1;
    return 0;
}

static void test_coordinate_jump(void **state)
{
    (void)state;
    static const refine_kind hue_kind[1] = {REFINE_CIRCULAR};
    static const int no_choices[1] = {0};
    const refine_space hue_space = {.n = 1, .kind = hue_kind, .choices = no_choices};
    for (uint64_t seed = 1; seed <= 5; seed++) {
        double best[2];
        for (int k = 0; k < 2; k++) {
            refine_options o;
            refine_options_default(&o);
            o.method = k ? REFINE_COORDINATE_JUMP : REFINE_COORDINATE_SWEEP;
            o.budget = 200; /* ~65 jumps, each 1 in 10 to land in the narrow basin */
            o.seed = seed;
            float x[1] = {0.2f};
            int calls = 0;
            refine_result r;
            char err[64];
            assert_int_equal(refine_search(&hue_space, &o, two_basins, hue_active, &calls, x, &r,
                                           err, sizeof err), 0);
            assert_int_equal(calls, 200);
            best[k] = r.best_loss;
            refine_result_free(&r);
        }
        assert_true(best[0] >= 0.1);
        assert_true(best[1] < 0.01);
    }
}

static void test_errors(void **state)
{
    (void)state;
    refine_options o;
    refine_options_default(&o);
    char err[256];
    refine_result r;
    problem p = {0};
    float x[N];
    memcpy(x, start, sizeof x);
    x[2] = NAN;
    assert_int_equal(refine_search(&space, &o, quadratic, active_of, &p, x, &r, err, sizeof err), -1);
    assert_non_null(strstr(err, "parameter 2"));
    assert_int_equal(p.calls, 0);
    assert_null(r.curve);

    /* A failing loss stops the search with its message; the start is left as given. */
    memcpy(x, start, sizeof x);
    p.fail_at = 5;
    assert_int_equal(refine_search(&space, &o, quadratic, active_of, &p, x, &r, err, sizeof err), -1);
    assert_string_equal(err, "render failed");
    assert_memory_equal(x, start, sizeof x);
    assert_null(r.curve);

    o.budget = 0;
    assert_int_equal(refine_search(&space, &o, quadratic, active_of, &p, x, &r, err, sizeof err), -1);
    assert_int_equal(refine_method_parse("es"), REFINE_ES);
    assert_int_equal(refine_method_parse("cma"), -1);
}

/* Budget 1 evaluates the start only. */
static void test_budget_one(void **state)
{
    (void)state;
    problem p = {0};
    float x[N];
    refine_result r;
    double best = run(REFINE_COORDINATE, 1, 1, x, &r, &p);
    assert_int_equal(p.calls, 1);
    assert_true(best == r.start_loss);
    assert_memory_equal(x, start, sizeof x);
    refine_result_free(&r);
}

/* The kinds follow the super-shader's names: a selector's choices from "Mult N", the
 * offset fixed, hues circular, a noise's Scale a zoom (and nothing else called Scale). */
static void test_space_for_params(void **state)
{
    (void)state;
    const char *names[] = {"Mult 11 Noise A Pattern", "Noise A Scale", "Noise C Scale",
                           "Pattern Offset",         "Color 1 Hue",   "Bump Strength",
                           "Noise B Detail",         "Scale",         "Noise Scale"};
    enum { M = sizeof names / sizeof names[0] };
    const refine_kind want[M] = {REFINE_SELECTOR, REFINE_ZOOM,  REFINE_ZOOM,
                                 REFINE_FIXED,    REFINE_CIRCULAR, REFINE_VALUE,
                                 REFINE_VALUE,    REFINE_VALUE, REFINE_VALUE};
    refine_kind kind[M];
    int ch[M];
    refine_space_for_params(names, M, kind, ch);
    for (int i = 0; i < M; i++)
        assert_int_equal(kind[i], want[i]);
    assert_int_equal(ch[0], 11);
}

/* A loss that watches the proposals: each against the search's current point (the best so
 * far: the search keeps a proposal exactly when its loss is lower), counting those that move
 * the zoom, the other values, or both. */
enum { Z = 3 };
static const refine_kind zoom_kinds[N] = {REFINE_VALUE, REFINE_VALUE, REFINE_VALUE, REFINE_ZOOM,
                                          REFINE_VALUE, REFINE_VALUE, REFINE_VALUE, REFINE_VALUE};
/* The watching losses' own: a bowl with its bottom at 0.3 in every parameter. */
static double bowl(const float *x)
{
    double f = 0.0;
    for (int i = 0; i < N; i++)
        f += (x[i] - 0.3) * (x[i] - 0.3);
    return f;
}

typedef struct watch {
    float best[N];
    double best_loss;
    int calls, zoom_only, others_only, both;
} watch;

static int watched(void *ctx, const float *x, double *loss, double *colour, char *err,
                   size_t errlen)
{
    (void)err, (void)errlen;
    watch *w = ctx;
    double f = bowl(x);
    if (w->calls++ > 0) {
        int zoom = x[Z] != w->best[Z], others = 0;
        for (int i = 0; i < N; i++)
            others += i != Z && x[i] != w->best[i];
        w->zoom_only += zoom && !others;
        w->others_only += others && !zoom;
        w->both += zoom && others;
    }
    if (w->calls == 1 || f < w->best_loss) {
        memcpy(w->best, x, sizeof w->best);
        w->best_loss = f;
    }
    *loss = f;
    *colour = 0.0;
    return 0;
}

static int all_active(void *ctx, const float *x, uint8_t *active, char *err, size_t errlen)
{
    (void)ctx, (void)x, (void)err, (void)errlen;
    memset(active, 1, N);
    return 0;
}

/* 200 evaluations of method m from every parameter at x0, all active. */
static void search_from(const refine_space *sp, refine_method m, float x0, refine_loss_fn f,
                        void *ctx)
{
    refine_options o;
    refine_options_default(&o);
    o.method = m;
    o.budget = 200;
    float x[N];
    for (int i = 0; i < N; i++)
        x[i] = x0;
    refine_result r;
    char err[128];
    assert_int_equal(refine_search(sp, &o, f, all_active, ctx, x, &r, err, sizeof err), 0);
    refine_result_free(&r);
}

/* es-split's promise: a proposal moves the zoom alone (about one in ZOOM_EVERY = 4) or the
 * other values alone, never both; the plain ES moves them together. */
static void test_zoom_split(void **state)
{
    (void)state;
    const refine_space zs = {.n = N, .kind = zoom_kinds, .choices = choices};
    for (int k = 0; k < 2; k++) {
        watch w = {0};
        search_from(&zs, k ? REFINE_ES_SPLIT : REFINE_ES, 0.8f, watched, &w);
        assert_int_equal(w.zoom_only + w.others_only + w.both, 199);
        if (k) {
            assert_int_equal(w.both, 0);
            assert_in_range(w.zoom_only, 30, 70); /* 199 / 4 = 50 expected */
        } else
            assert_true(w.both > 190);
    }
}

/* es-mirror's promise: a value move that failed is followed by its mirror about the current
 * point, x - d for x + d; a mirror that failed is followed by a fresh draw. The loss watches
 * pairs of consecutive proposals from the same current point. */
typedef struct mirror_watch {
    float best[N], prev[N];
    double best_loss;
    int calls, prev_failed, prev_mirror, mirrors, fresh_after_fail;
} mirror_watch;

static int mirror_watched(void *ctx, const float *x, double *loss, double *colour, char *err,
                          size_t errlen)
{
    (void)err, (void)errlen;
    mirror_watch *w = ctx;
    double f = bowl(x);
    int is_mirror = 0;
    if (w->calls > 0 && (w->prev_failed || w->prev_mirror)) {
        is_mirror = 1;
        for (int i = 0; i < N; i++) {
            double d = (double)w->prev[i] - w->best[i], m = (double)x[i] - w->best[i];
            if (w->prev[i] > 0.0f && w->prev[i] < 1.0f && x[i] > 0.0f && x[i] < 1.0f &&
                fabs(m + d) > 1e-6)
                is_mirror = 0;
        }
        if (w->prev_mirror)
            w->fresh_after_fail += !is_mirror;
        else
            w->mirrors += is_mirror;
    }
    int failed = w->calls > 0 && !(f < w->best_loss);
    if (w->calls++ == 0 || f < w->best_loss) {
        memcpy(w->best, x, sizeof w->best);
        w->best_loss = f;
    }
    memcpy(w->prev, x, sizeof w->prev);
    w->prev_mirror = failed && is_mirror;
    w->prev_failed = failed && !w->prev_mirror;
    *loss = f;
    *colour = 0.0;
    return 0;
}

static void test_mirror(void **state)
{
    (void)state;
    const refine_kind values[N] = {REFINE_VALUE, REFINE_VALUE, REFINE_VALUE, REFINE_VALUE,
                                   REFINE_VALUE, REFINE_VALUE, REFINE_VALUE, REFINE_VALUE};
    const refine_space vs = {.n = N, .kind = values, .choices = choices};
    for (int k = 0; k < 2; k++) {
        mirror_watch w = {0};
        search_from(&vs, k ? REFINE_ES_MIRROR : REFINE_ES, 0.6f, mirror_watched, &w);
        if (k) {
            printf("# es-mirror %d mirrors, %d fresh draws after a failed mirror\n", w.mirrors,
                   w.fresh_after_fail);
            assert_true(w.mirrors > 40); /* most failures: at a 1/5 success rate, ~100 */
            assert_true(w.fresh_after_fail > 20);
        } else
            assert_int_equal(w.mirrors, 0);
    }
}

/* coordinate-zoom's promise: when the loss wants the zooms moved together (the pattern's
 * size) and punishes them apart (the patterns' proportions), one joint move does what
 * single moves reach only by steps small enough that the mismatch costs less than the gain.
 * Two zooms at 0.3 whose best is both at 0.7; one value beside them, already at its best. */
static int zoom_pair(void *ctx, const float *x, double *gram, double *colour, char *err,
                     size_t errlen)
{
    (void)err, (void)errlen;
    (*(int *)ctx)++;
    double apart = x[0] - x[1], size = x[0] + x[1] - 1.4;
    *gram = 100.0 * apart * apart + size * size + (x[2] - 0.5) * (x[2] - 0.5);
    *colour = 0.0;
    return 0;
}

static int three_active(void *ctx, const float *x, uint8_t *active, char *err, size_t errlen)
{
    (void)ctx, (void)x, (void)err, (void)errlen;
    memset(active, 1, 3);
    return 0;
}

static void test_coordinate_zoom(void **state)
{
    (void)state;
    static const refine_kind kinds3[3] = {REFINE_ZOOM, REFINE_ZOOM, REFINE_VALUE};
    static const int choices3[3] = {0, 0, 0};
    const refine_space zs = {.n = 3, .kind = kinds3, .choices = choices3};
    for (uint64_t seed = 1; seed <= 5; seed++) {
        double best[2];
        for (int k = 0; k < 2; k++) {
            refine_options o;
            refine_options_default(&o);
            o.method = k ? REFINE_COORDINATE_ZOOM : REFINE_COORDINATE_SWEEP;
            o.budget = 40;
            o.seed = seed;
            float x[3] = {0.3f, 0.3f, 0.5f};
            int calls = 0;
            refine_result r;
            char err[64];
            assert_int_equal(refine_search(&zs, &o, zoom_pair, three_active, &calls, x, &r, err,
                                           sizeof err), 0);
            assert_int_equal(calls, 40);
            best[k] = r.best_loss;
            refine_result_free(&r);
        }
        printf("# seed %llu: best loss sweep %.4f, zoom %.4f (start 0.64)\n",
               (unsigned long long)seed, best[0], best[1]);
        assert_true(best[1] < 0.01);
        assert_true(best[0] > 0.3);
    }
}

/* The colour phase: a value whose two terms pull apart, gram (x - 0.2)^2 and colour
 * (x - 0.8)^2, so that gram + w colour is least at (0.2 + 0.8 w) / (1 + w): 0.68 at the final
 * weight 4, 0.754 at the phase's 12. */
static int two_terms(void *ctx, const float *x, double *gram, double *colour, char *err,
                     size_t errlen)
{
    (void)err, (void)errlen;
    (*(int *)ctx)++;
    *gram = (x[0] - 0.2) * (x[0] - 0.2);
    *colour = (x[0] - 0.8) * (x[0] - 0.8);
    return 0;
}

static double two_terms_at(double x, double w)
{
    return (x - 0.2) * (x - 0.2) + w * (x - 0.8) * (x - 0.8);
}

/* 120 evaluations of two_terms from x[0] with a colour phase of `phase` evaluations at the
 * default weights. A change of weight re-weighs the best's terms: no evaluation more. */
static void phase_search(int phase, float *x, refine_result *r)
{
    static const refine_kind value_kind[1] = {REFINE_VALUE};
    static const int no_choices[1] = {0};
    const refine_space vs = {.n = 1, .kind = value_kind, .choices = no_choices};
    refine_options o;
    refine_options_default(&o);
    o.budget = 120;
    o.colour_phase = phase;
    assert_true(o.colour_weight == PIPELINE_COLOUR_WEIGHT);
    assert_true(o.colour_phase_weight == PIPELINE_COLOUR_PHASE_WEIGHT);
    int calls = 0;
    char err[64];
    assert_int_equal(refine_search(&vs, &o, two_terms, hue_active, &calls, x, r, err, sizeof err),
                     0);
    assert_int_equal(calls, 120);
}

static void test_colour_phase(void **state)
{
    (void)state;
    /* phase: none, half the budget, all of it. */
    const int phases[3] = {0, 60, 120};
    const double optima[3] = {0.68, 0.68, 0.2 + 0.6 * 12.0 / 13.0};
    for (int k = 0; k < 3; k++) {
        float x[1] = {0.3f};
        refine_result r;
        phase_search(phases[k], x, &r);
        printf("# colour phase %3d: x %.4f (optimum %.4f)\n", phases[k], (double)x[0], optima[k]);
        assert_true(fabs(x[0] - optima[k]) < 0.01);
        /* start and best under the final weight; the curve under each evaluation's. */
        assert_true(fabs(r.start_loss - two_terms_at(0.3f, 4.0)) < 1e-12);
        assert_true(fabs(r.best_loss - two_terms_at(x[0], 4.0)) < 1e-12);
        assert_true(fabs(r.curve[0] - two_terms_at(0.3f, k ? 12.0 : 4.0)) < 1e-12);
        for (int i = 1; i < r.evals; i++)
            assert_true(r.curve[i] <= r.curve[i - 1]); /* the weight only falls here */
        if (k == 1) {
            /* The phase ends at its own optimum (the least of gram + 12 colour is
             * 0.36 x 12 / 13), and the curve drops to at most that point's loss under
             * weight 4 (evaluation 60 may improve on it). */
            assert_true(fabs(r.curve[59] - 0.36 * 12.0 / 13.0) < 1e-4);
            assert_true(r.curve[60] <= two_terms_at(0.2 + 0.6 * 12.0 / 13.0, 4.0) + 1e-3);
            assert_true(r.curve[60] < r.curve[59]);
        }
        refine_result_free(&r);
    }
    /* From the final weight's optimum the phase can only lead away: under weight 4 its point
     * is worse than the start, so at its end (or at the budget's, when it takes all) the
     * search goes back to the start; the result is never worse than the start. */
    for (int k = 1; k < 3; k++) {
        float x[1] = {0.68f};
        refine_result r;
        phase_search(phases[k], x, &r);
        printf("# colour phase %3d from 0.68: x %.4f, loss %.6f (start %.6f)\n", phases[k],
               (double)x[0], r.best_loss, r.start_loss);
        assert_true(r.best_loss <= r.start_loss);
        assert_true(fabs(x[0] - 0.68) < 0.01);
        if (k == 2)
            assert_true(x[0] == 0.68f); /* the start itself */
        refine_result_free(&r);
    }
}

/* Every loss the race's callback returned, in call order (quadratic's, recorded). */
typedef struct recorded {
    problem p;
    int n;
    double loss[256];
} recorded;

static int recording(void *ctx, const float *x, double *loss, double *colour, char *err,
                     size_t errlen)
{
    recorded *rec = ctx;
    if (quadratic(&rec->p, x, loss, colour, err, errlen))
        return -1;
    assert_true(rec->n < 256);
    rec->loss[rec->n++] = *loss;
    return 0;
}

static int recording_active(void *ctx, const float *x, uint8_t *active, char *err,
                            size_t errlen)
{
    return active_of(&((recorded *)ctx)->p, x, active, err, errlen);
}

/* One value with two basins: a shallow one at 0.1 (loss 0.2 there) next to a start, and a
 * narrow, deeper one at 0.8 behind a wall that steps of <= 0.5 from 0.1 do not cross. */
static int shallow_and_deep(void *ctx, const float *x, double *loss, double *colour,
                            char *err, size_t errlen)
{
    (void)err, (void)errlen;
    ++*(int *)ctx;
    double a = (x[0] - 0.1) * (x[0] - 0.1) + 0.2, b = 30.0 * (x[0] - 0.8) * (x[0] - 0.8);
    *loss = a < b ? a : b;
    *colour = 0.0;
    return 0;
}

static int one_active(void *ctx, const float *x, uint8_t *active, char *err, size_t errlen)
{
    (void)ctx, (void)x, (void)err, (void)errlen;
    active[0] = 1;
    return 0;
}

/* The race: the budget is every search's evaluations together, spent by successive halving
 * (2 starts: 56 + 112 of 224 for the one that goes on; 4 starts: 18 + 38 + 76); the curve
 * is the best loss any search had reached at each evaluation; the result is never worse
 * than the best start; one start is refine_search; the start whose own loss is worse can
 * win when its basin is deeper. */
static void test_race(void **state)
{
    (void)state;
    float starts[4 * N], x[N];
    for (int k = 0; k < 4; k++) {
        memcpy(starts + k * N, start, sizeof start);
        starts[k * N + 0] = 0.1f + 0.25f * (float)k; /* four different points */
        starts[k * N + SEL] = (float)((k % 3 + 0.5) / 3);
    }
    char err[256];
    for (int m = 0; m < REFINE_N_METHODS; m++)
        for (int K = 1; K <= 4; K++) {
            refine_options o;
            refine_options_default(&o);
            o.method = (refine_method)m;
            o.budget = 224;
            o.seed = 3;
            recorded rec = {0};
            refine_result r;
            assert_int_equal(refine_race(&space, &o, recording, recording_active, &rec, starts,
                                         K, x, &r, err, sizeof err), 0);
            assert_int_equal(rec.n, 224);
            assert_int_equal(r.evals, 224);
            double best = INFINITY, best_start = INFINITY;
            for (int i = 0; i < 224; i++) {
                best = fmin(best, rec.loss[i]);
                assert_true(r.curve[i] == best);
            }
            for (int k = 0; k < K; k++) { /* each search begins with its start */
                problem q = {0};
                double f, c;
                assert_int_equal(quadratic(&q, starts + k * N, &f, &c, err, sizeof err), 0);
                best_start = fmin(best_start, f);
            }
            assert_true(r.start_loss == best_start);
            assert_true(r.best_loss == best && best <= best_start);
            assert_true(r.winner >= 0 && r.winner < K);
            assert_int_equal(r.n_starts, K);
            int total = 0;
            for (int k = 0; k < K; k++) {
                total += r.spent[k];
                assert_true(r.reached[k] >= r.best_loss);
            }
            assert_int_equal(total, 224);
            assert_true(r.reached[r.winner] == r.best_loss && r.spent[r.winner] == r.winner_evals);
            static const int winner_evals[5] = {0, 224, 168, 138, 132};
            assert_int_equal(r.winner_evals, winner_evals[K]);
            problem q = {0};
            double f, c;
            assert_int_equal(quadratic(&q, x, &f, &c, err, sizeof err), 0);
            assert_true(f == r.best_loss);
            if (K == 1) { /* refine_search, evaluation for evaluation */
                float y[N];
                memcpy(y, starts, sizeof y);
                refine_result r1;
                problem p1 = {0};
                assert_int_equal(refine_search(&space, &o, quadratic, active_of, &p1, y, &r1, err,
                                               sizeof err), 0);
                assert_memory_equal(x, y, sizeof y);
                assert_memory_equal(r.curve, r1.curve, 224 * sizeof(double));
                refine_result_free(&r1);
            }
            refine_result_free(&r);
        }

    /* A worse start in a deeper basin wins the race; alone, the better start stays shallow. */
    static const refine_kind one_kind[1] = {REFINE_VALUE};
    static const int no_choices[1] = {0};
    const refine_space one = {.n = 1, .kind = one_kind, .choices = no_choices};
    for (uint64_t seed = 1; seed <= 5; seed++) {
        refine_options o;
        refine_options_default(&o);
        o.budget = 40;
        o.seed = seed;
        const float two[2] = {0.12f, 0.7f}; /* losses 0.2004 and 0.3 */
        float y[1];
        int calls = 0;
        refine_result r;
        assert_int_equal(refine_race(&one, &o, shallow_and_deep, one_active, &calls, two, 1, y,
                                     &r, err, sizeof err), 0);
        assert_true(r.best_loss >= 0.2);
        refine_result_free(&r);
        assert_int_equal(refine_race(&one, &o, shallow_and_deep, one_active, &calls, two, 2, y,
                                     &r, err, sizeof err), 0);
        assert_int_equal(r.winner, 1);
        assert_true(r.best_loss < 0.01 && fabs(y[0] - 0.8) < 0.02);
        assert_int_equal(calls, 80);
        refine_result_free(&r);
    }

    /* More starts than the budget: the first `budget` only, one evaluation each. */
    refine_options o;
    refine_options_default(&o);
    o.budget = 3;
    recorded rec = {0};
    refine_result r;
    assert_int_equal(refine_race(&space, &o, recording, recording_active, &rec, starts, 4, x, &r,
                                 err, sizeof err), 0);
    assert_int_equal(rec.n, 3);
    assert_true(r.winner < 3);
    assert_memory_equal(x, starts + r.winner * N, sizeof x);
    refine_result_free(&r);

    /* A bad start is named before anything is evaluated. */
    starts[1 * N + 2] = 1.5f;
    rec.n = 0;
    assert_int_equal(refine_race(&space, &o, recording, recording_active, &rec, starts, 2, x, &r,
                                 err, sizeof err), -1);
    assert_non_null(strstr(err, "start 1's parameter 2"));
    assert_int_equal(rec.n, 0);
    assert_null(r.curve);
}

/* refine_method_list is refine_method_names joined. */
static void test_method_list(void **state)
{
    (void)state;
    char joined[256] = "";
    for (int m = 0; m < REFINE_N_METHODS; m++) {
        size_t len = strlen(joined);
        snprintf(joined + len, sizeof joined - len, "%s%s", m ? ", " : "", refine_method_names[m]);
    }
    assert_string_equal(refine_method_list(), joined);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_contract),
        cmocka_unit_test(test_quality),
        cmocka_unit_test(test_coordinate_sweep),
        cmocka_unit_test(test_coordinate_jump),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_budget_one),
        cmocka_unit_test(test_space_for_params),
        cmocka_unit_test(test_zoom_split),
        cmocka_unit_test(test_mirror),
        cmocka_unit_test(test_coordinate_zoom),
        cmocka_unit_test(test_colour_phase),
        cmocka_unit_test(test_method_list),
        cmocka_unit_test(test_race),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

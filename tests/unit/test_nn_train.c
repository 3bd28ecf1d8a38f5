/*
 * Training layers, losses and optimiser pieces against double-precision references:
 * each layer's backward (float) against central finite differences of an independent
 * double-precision forward written here, of L = sum(dout * f(x)); each forward against
 * the same double forward. Then the whole MLP (every option at once) against finite
 * differences of its own loss, arch/heads parsing, schedules, data checks.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "nn/nn.h"

/* Central differences in double with step 1e-6 are exact to ~1e-9 here; the float
 * backward carries float rounding (~1e-7 relative per operation), so 1e-4 of the
 * gradient's scale separates rounding from a wrong formula by orders of magnitude. */
#define FD_H 1e-6
#define GRAD_TOL 1e-4

static uint64_t rng_state = 0x1234567;
static double urand(void)
{
    rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(rng_state >> 11) * 0x1p-53;
}
static void fill(float *a, size_t n, double lo, double hi)
{
    for (size_t i = 0; i < n; i++)
        a[i] = (float)(lo + (hi - lo) * urand());
}

/* |got - want| / max(1e-3, max|want|) over n: errors relative to the gradient's scale. */
static double scaled_err(const float *got, const double *want, size_t n)
{
    double scale = 1e-3, e = 0.0;
    for (size_t i = 0; i < n; i++)
        scale = fmax(scale, fabs(want[i]));
    for (size_t i = 0; i < n; i++)
        e = fmax(e, fabs(got[i] - want[i]));
    return e / scale;
}

/* ---------------------------------------------------------------- double forwards */

typedef struct layer_case {
    int B, C, OC;
    double slope, p;
    const float *w, *b, *keep, *dout;
} layer_case;

typedef double (*scalar_fn)(const layer_case *c, const double *x);

static double d_linear(const layer_case *c, const double *x)
{
    double L = 0.0;
    for (int i = 0; i < c->B; i++)
        for (int k = 0; k < c->OC; k++) {
            double s = c->b[k];
            for (int j = 0; j < c->C; j++)
                s += x[i * c->C + j] * c->w[k * c->C + j];
            L += c->dout[i * c->OC + k] * s;
        }
    return L;
}

static double d_act(const layer_case *c, const double *x, int kind)
{
    double L = 0.0;
    for (int i = 0; i < c->B * c->C; i++) {
        double v = x[i], y;
        switch (kind) {
        case 0: y = v > 0 ? v : 0; break;
        case 1: y = v > 0 ? v : c->slope * v; break;
        case 2: y = 0.5 * v * (1 + erf(v / sqrt(2.0))); break;
        case 3: y = 1 / (1 + exp(-v)); break;
        default: y = v * c->keep[i]; break;
        }
        L += c->dout[i] * y;
    }
    return L;
}
static double d_relu(const layer_case *c, const double *x) { return d_act(c, x, 0); }
static double d_leaky(const layer_case *c, const double *x) { return d_act(c, x, 1); }
static double d_gelu(const layer_case *c, const double *x) { return d_act(c, x, 2); }
static double d_sigmoid(const layer_case *c, const double *x) { return d_act(c, x, 3); }
static double d_dropout(const layer_case *c, const double *x) { return d_act(c, x, 4); }

static double d_layernorm(const layer_case *c, const double *x)
{
    double L = 0.0;
    for (int i = 0; i < c->B; i++) {
        const double *r = x + i * c->C;
        double mu = 0, var = 0;
        for (int j = 0; j < c->C; j++)
            mu += r[j] / c->C;
        for (int j = 0; j < c->C; j++)
            var += (r[j] - mu) * (r[j] - mu) / c->C;
        for (int j = 0; j < c->C; j++)
            L += c->dout[i * c->C + j] *
                 ((r[j] - mu) / sqrt(var + 1e-5) * c->w[j] + c->b[j]);
    }
    return L;
}

/* Finite-difference gradient of f at x (n floats), in double. */
static void fd_grad(scalar_fn f, const layer_case *c, const float *x, size_t n, double *g)
{
    double *xd = malloc(n * sizeof(double));
    for (size_t i = 0; i < n; i++)
        xd[i] = x[i];
    for (size_t i = 0; i < n; i++) {
        double keep = xd[i];
        xd[i] = keep + FD_H;
        double up = f(c, xd);
        xd[i] = keep - FD_H;
        double down = f(c, xd);
        xd[i] = keep;
        g[i] = (up - down) / (2 * FD_H);
    }
    free(xd);
}

/* ---------------------------------------------------------------- layer tests */

static void test_linear_gradients(void **state)
{
    (void)state;
    enum { B = 5, C = 7, OC = 4 };
    float x[B * C], w[OC * C], b[OC], dout[B * OC], out[B * OC];
    fill(x, B * C, -1, 1);
    fill(w, OC * C, -1, 1);
    fill(b, OC, -1, 1);
    fill(dout, B * OC, -1, 1);
    layer_case c = {.B = B, .C = C, .OC = OC, .w = w, .b = b, .dout = dout};
    // forward against the double sum
    linear_forward(out, x, w, b, B, C, OC, 1);
    for (int i = 0; i < B; i++)
        for (int k = 0; k < OC; k++) {
            double s = b[k];
            for (int j = 0; j < C; j++)
                s += (double)x[i * C + j] * w[k * C + j];
            assert_true(fabs(out[i * OC + k] - s) < 1e-5);
        }
    // dx against finite differences; dw, db against the exact double formulas (the
    // loss is linear in them, so finite differences would only restate the product)
    float dx[B * C], dw[OC * C] = {0}, db[OC] = {0};
    double g[B * C];
    linear_backward(dx, dw, db, dout, x, w, B, C, OC, 1);
    fd_grad(d_linear, &c, x, B * C, g);
    assert_true(scaled_err(dx, g, B * C) < GRAD_TOL);
    double gw[OC * C], gb[OC];
    for (int k = 0; k < OC; k++) {
        gb[k] = 0;
        for (int i = 0; i < B; i++)
            gb[k] += dout[i * OC + k];
        for (int j = 0; j < C; j++) {
            gw[k * C + j] = 0;
            for (int i = 0; i < B; i++)
                gw[k * C + j] += (double)dout[i * OC + k] * x[i * C + j];
        }
    }
    assert_true(scaled_err(dw, gw, OC * C) < GRAD_TOL);
    assert_true(scaled_err(db, gb, OC) < GRAD_TOL);
    // and dw by finite differences too, through the same double forward
    double fw[OC * C];
    float wcopy[OC * C];
    memcpy(wcopy, w, sizeof w);
    for (int i = 0; i < OC * C; i++) {
        double keep = wcopy[i], xd[B * C];
        for (int k = 0; k < B * C; k++)
            xd[k] = x[k];
        c.w = wcopy;
        wcopy[i] = (float)(keep + 1e-2);
        double up = d_linear(&c, xd), hu = (double)wcopy[i] - keep;
        wcopy[i] = (float)(keep - 1e-2);
        double down = d_linear(&c, xd), hd = keep - (double)wcopy[i];
        wcopy[i] = (float)keep;
        fw[i] = (up - down) / (hu + hd); /* exact: L is linear in w */
    }
    assert_true(scaled_err(dw, fw, OC * C) < GRAD_TOL);
    // the parameter gradients accumulate: a second backward doubles them
    linear_backward(NULL, dw, db, dout, x, w, B, C, OC, 1);
    for (int k = 0; k < OC; k++)
        assert_true(fabs(db[k] - 2 * gb[k]) < 1e-5);
}

static void check_elementwise(scalar_fn f, int kind, double lo, double hi)
{
    enum { B = 3, C = 11 };
    float x[B * C], dout[B * C], din[B * C], keep[B * C], out[B * C];
    double g[B * C];
    fill(x, B * C, lo, hi);
    fill(dout, B * C, -1, 1);
    for (int i = 0; i < B * C; i++) /* keep away from ReLU's kink */
        if (fabsf(x[i]) < 1e-3f)
            x[i] = 0.5f;
    float slope = 0.1f;
    layer_case c = {.B = B, .C = C, .slope = slope, .dout = dout, .keep = keep};
    switch (kind) {
    case 0: relu_backward(din, dout, x, B * C); break;
    case 1: leaky_relu_backward(din, dout, x, B * C, slope); break;
    case 2: gelu_backward(din, dout, x, B * C); break;
    case 3:
        sigmoid_forward(out, x, B * C);
        sigmoid_backward(din, dout, out, B * C);
        break;
    default:
        dropout_forward(out, keep, x, B * C, 0.3f, 42);
        dropout_backward(din, dout, keep, B * C);
        break;
    }
    fd_grad(f, &c, x, B * C, g);
    double e = scaled_err(din, g, B * C);
    printf("elementwise %d: gradient error %.3g\n", kind, e);
    assert_true(e < GRAD_TOL);
}

static void test_activation_gradients(void **state)
{
    (void)state;
    check_elementwise(d_relu, 0, -2, 2);
    check_elementwise(d_leaky, 1, -2, 2);
    check_elementwise(d_gelu, 2, -4, 4);
    check_elementwise(d_sigmoid, 3, -6, 6);
    check_elementwise(d_dropout, 4, -2, 2);
    // forwards: GELU and sigmoid against double; sigmoid does not overflow far out
    float x[4] = {-100.0f, -1.5f, 0.7f, 100.0f}, y[4];
    gelu_forward(y, x, 4);
    for (int i = 0; i < 4; i++)
        assert_true(fabs(y[i] - 0.5 * x[i] * (1 + erf(x[i] / sqrt(2.0)))) < 1e-5);
    sigmoid_forward(y, x, 4);
    for (int i = 0; i < 4; i++)
        assert_true(fabs(y[i] - 1 / (1 + exp(-(double)x[i]))) < 1e-7);
}

static void test_dropout_statistics(void **state)
{
    (void)state;
    // keep is 0 or 1/(1-p), a fraction ~1-p kept, the same for the same seed, and a
    // different pattern for another seed
    enum { N = 20000 };
    float *x = malloc(N * sizeof(float)), *y = malloc(N * sizeof(float)),
          *k1 = malloc(N * sizeof(float)), *k2 = malloc(N * sizeof(float));
    for (int i = 0; i < N; i++)
        x[i] = 1.0f;
    dropout_forward(y, k1, x, N, 0.25f, 7);
    int kept = 0, same = 1, differs = 0;
    for (int i = 0; i < N; i++) {
        assert_true(k1[i] == 0.0f || fabsf(k1[i] - 1.0f / 0.75f) < 1e-7f);
        kept += k1[i] != 0.0f;
    }
    assert_true(fabs(kept / (double)N - 0.75) < 0.02);
    dropout_forward(y, k2, x, N, 0.25f, 7);
    for (int i = 0; i < N; i++)
        same &= k1[i] == k2[i];
    dropout_forward(y, k2, x, N, 0.25f, 8);
    for (int i = 0; i < N; i++)
        differs += k1[i] != k2[i];
    assert_true(same);
    assert_true(differs > N / 10);
    free(x);
    free(y);
    free(k1);
    free(k2);
}

static void test_layernorm_gradients(void **state)
{
    (void)state;
    enum { B = 4, C = 9 };
    float x[B * C], w[C], b[C], dout[B * C], out[B * C], mean[B], rstd[B];
    fill(x, B * C, -2, 3);
    fill(w, C, 0.5, 1.5);
    fill(b, C, -1, 1);
    fill(dout, B * C, -1, 1);
    layer_case c = {.B = B, .C = C, .w = w, .b = b, .dout = dout};
    layernorm_forward(out, mean, rstd, x, w, b, B, C);
    float din[B * C], dw[C] = {0}, db[C] = {0};
    layernorm_backward(din, dw, db, dout, x, w, mean, rstd, B, C);
    double g[B * C];
    fd_grad(d_layernorm, &c, x, B * C, g);
    double e = scaled_err(din, g, B * C);
    printf("layernorm dx error %.3g\n", e);
    assert_true(e < GRAD_TOL);
    // dw = sum_i dout xhat, db = sum_i dout, from the double normalisation
    double gw[C] = {0}, gb[C] = {0};
    for (int i = 0; i < B; i++) {
        double mu = 0, var = 0;
        for (int j = 0; j < C; j++)
            mu += x[i * C + j] / (double)C;
        for (int j = 0; j < C; j++)
            var += (x[i * C + j] - mu) * (x[i * C + j] - mu) / C;
        for (int j = 0; j < C; j++) {
            double xhat = (x[i * C + j] - mu) / sqrt(var + 1e-5);
            gw[j] += dout[i * C + j] * xhat;
            gb[j] += dout[i * C + j];
            assert_true(fabs(out[i * C + j] - (xhat * w[j] + b[j])) < 1e-5);
        }
    }
    assert_true(scaled_err(dw, gw, C) < GRAD_TOL);
    assert_true(scaled_err(db, gb, C) < GRAD_TOL);
}

/* ---------------------------------------------------------------- losses */

static double d_regression(nn_loss kind, const double *p, const float *y, const float *m,
                           const float *wc, int B, int C)
{
    double s = 0, active = 0;
    for (int i = 0; i < B * C; i++) {
        double mk = m ? m[i] : 1;
        active += mk;
        if (!mk)
            continue;
        double d = p[i] - y[i], e = kind == NN_LOSS_L1 ? fabs(d) : d * d;
        if (kind == NN_LOSS_THESIS) {
            double dl = log(p[i] + 1e-7) - log(y[i] + 1e-7);
            e += 20 * dl * dl;
        }
        s += mk * (wc ? wc[i % C] : 1) * e;
    }
    return s / fmax(1, active);
}

static void test_regression_loss_gradients(void **state)
{
    (void)state;
    enum { B = 6, C = 5 };
    float p[B * C], y[B * C], m[B * C], wc[C];
    fill(p, B * C, 0.05, 0.95);
    fill(y, B * C, 0.05, 0.95);
    fill(wc, C, 0.5, 2);
    for (int i = 0; i < B * C; i++)
        m[i] = urand() < 0.6 ? 1.0f : 0.0f;
    for (int kind = 0; kind < 3; kind++)
        for (int masked = 0; masked < 2; masked++) {
            const float *mk = masked ? m : NULL;
            float yy[B * C];
            memcpy(yy, y, sizeof yy);
            if (masked) /* a masked target may be anything, NaN included */
                for (int i = 0; i < B * C; i++)
                    if (!m[i])
                        yy[i] = NAN;
            float dp[B * C] = {0};
            double loss = regression_loss_forward_backward((nn_loss)kind, dp, p, yy, mk, wc, B,
                                                           C, 1.0);
            double pd[B * C], g[B * C];
            for (int i = 0; i < B * C; i++)
                pd[i] = p[i];
            double want = d_regression((nn_loss)kind, pd, yy, mk, wc, B, C);
            assert_true(isfinite(loss));
            assert_true(fabs(loss - want) <= 1e-6 * fmax(1, fabs(want)));
            for (int i = 0; i < B * C; i++) {
                double keep = pd[i];
                pd[i] = keep + FD_H;
                double up = d_regression((nn_loss)kind, pd, yy, mk, wc, B, C);
                pd[i] = keep - FD_H;
                double down = d_regression((nn_loss)kind, pd, yy, mk, wc, B, C);
                pd[i] = keep;
                g[i] = (up - down) / (2 * FD_H);
                if (masked && !m[i])
                    assert_true(dp[i] == 0.0f); /* no gradient through a masked element */
            }
            double e = scaled_err(dp, g, B * C);
            printf("loss %d masked %d: loss %.6g, gradient error %.3g\n", kind, masked, loss, e);
            assert_true(e < GRAD_TOL);
        }
    // everything masked: loss 0, no gradient, no division by zero
    float zero[B * C] = {0}, dp[B * C] = {0};
    assert_true(regression_loss_forward_backward(NN_LOSS_MSE, dp, p, y, zero, NULL, B, C, 1) ==
                0.0);
    for (int i = 0; i < B * C; i++)
        assert_true(dp[i] == 0.0f);
}

static double d_ce(const double *z, const float *cls, const float *m, int B, int K)
{
    double s = 0, active = 0;
    for (int i = 0; i < B; i++) {
        double mk = m ? m[i] : 1;
        active += mk;
        if (!mk)
            continue;
        double lse = 0;
        for (int k = 0; k < K; k++)
            lse += exp(z[i * K + k]);
        s += mk * (log(lse) - z[i * K + (int)cls[i]]);
    }
    return s / fmax(1, active);
}

static void test_cross_entropy_gradients(void **state)
{
    (void)state;
    enum { B = 7, K = 4 };
    float z[B * K], cls[B], m[B], probs[B * K];
    fill(z, B * K, -3, 3);
    for (int i = 0; i < B; i++) {
        cls[i] = (float)(i % K);
        m[i] = i % 3 ? 1.0f : 0.0f;
    }
    for (int masked = 0; masked < 2; masked++) {
        float dz[B * K] = {0};
        const float *mk = masked ? m : NULL;
        double loss = cross_entropy_forward_backward(dz, probs, z, cls, mk, B, K, 1.0);
        double zd[B * K], g[B * K];
        for (int i = 0; i < B * K; i++)
            zd[i] = z[i];
        assert_true(fabs(loss - d_ce(zd, cls, mk, B, K)) < 1e-6);
        for (int i = 0; i < B * K; i++) {
            double keep = zd[i];
            zd[i] = keep + FD_H;
            double up = d_ce(zd, cls, mk, B, K);
            zd[i] = keep - FD_H;
            double down = d_ce(zd, cls, mk, B, K);
            zd[i] = keep;
            g[i] = (up - down) / (2 * FD_H);
        }
        double e = scaled_err(dz, g, B * K);
        printf("cross-entropy masked %d: gradient error %.3g\n", masked, e);
        assert_true(e < GRAD_TOL);
    }
    // large logits stay finite (log-sum-exp from the maximum)
    float big[K] = {1000.0f, -1000.0f, 999.0f, 0.0f}, c0 = 2.0f, dz[K] = {0};
    double l = cross_entropy_forward_backward(dz, probs, big, &c0, NULL, 1, K, 1.0);
    assert_true(fabs(l - log(1 + exp(1.0))) < 1e-6);
}

/* ---------------------------------------------------------------- the whole model */

/* Every option at once (GELU, LayerNorm, residual, dropout; sigmoid + thesis, softmax,
 * unit selector, linear + L1, loss weights, a mask): the analytic gradient of the model's
 * own float loss against central differences of it, on the parameters with the largest
 * gradients (float differences need a gradient well above the loss's rounding). */
static void test_mlp_gradient_all_options(void **state)
{
    (void)state;
    enum { B = 8, IN = 6, YC = 6 };
    char err[256];
    nn_mlp_config cfg;
    assert_int_equal(nn_mlp_parse_arch("mlp:6-10-10-10-9,gelu,ln,res,dropout=0.2", &cfg, err,
                                       sizeof err),
                     0);
    nn_head heads[8];
    int nh = nn_heads_parse("sigmoid:0-1@2,softmax:2/3,softmax:3/3:unit@0.5,linear:4-4", YC, 9,
                            NN_LOSS_THESIS, heads, 8, err, sizeof err);
    assert_int_equal(nh, 4);
    heads[3].loss = NN_LOSS_MSE;
    nn_mlp m;
    assert_int_equal(nn_mlp_create(&m, &cfg, heads, nh, 3, err, sizeof err), 0);
    assert_int_equal(m.y_cols, 5);
    float x[B * IN], y[B * 5], mask[B * 5];
    fill(x, B * IN, -1, 1);
    for (int i = 0; i < B; i++) {
        y[i * 5 + 0] = (float)(0.1 + 0.8 * urand());
        y[i * 5 + 1] = (float)(0.1 + 0.8 * urand());
        y[i * 5 + 2] = (float)(i % 3);
        y[i * 5 + 3] = (float)(i % 3) / 2.0f;
        y[i * 5 + 4] = (float)urand();
        for (int j = 0; j < 5; j++)
            mask[i * 5 + j] = (i + j) % 4 ? 1.0f : 0.0f;
    }
    assert_int_equal(nn_mlp_check_data(&m, x, y, mask, B, err, sizeof err), 0);
    double loss;
    assert_int_equal(nn_mlp_forward_backward(&m, x, y, mask, B, 5, &loss), 0);
    // eval mode has no dropout: another loss, and the gradients stay untouched
    double eval;
    float g0 = m.grads[0];
    assert_int_equal(nn_mlp_evaluate(&m, x, y, mask, B, &eval), 0);
    assert_true(isfinite(eval) && eval != loss && m.grads[0] == g0);
    float *g = malloc(m.n_floats * sizeof(float));
    memcpy(g, m.grads, m.n_floats * sizeof(float));
    int checked = 0;
    double worst = 0;
    for (int pass = 0; pass < 24; pass++) {
        size_t best = 0;
        for (size_t i = 0; i < m.n_floats; i++)
            if (fabsf(g[i]) > fabsf(g[best]))
                best = i;
        float keep = m.weights[best], h = 2e-3f, want = g[best];
        double up, down;
        m.weights[best] = keep + h;
        nn_mlp_forward_backward(&m, x, y, mask, B, 5, &up);
        m.weights[best] = keep - h;
        nn_mlp_forward_backward(&m, x, y, mask, B, 5, &down);
        m.weights[best] = keep;
        double fd = (up - down) / (2.0 * ((double)(keep + h) - keep));
        double rel = fabs(fd - want) / fabs(want);
        worst = fmax(worst, rel);
        g[best] = 0; /* next largest */
        checked++;
    }
    printf("MLP, all options: %d largest gradients, worst relative error %.3g\n", checked,
           worst);
    assert_true(worst < 2e-3);
    free(g);
    nn_mlp_free(&m);
}

static void test_threads_bit_identical(void **state)
{
    (void)state;
    // big enough that every sgemm is cut into pieces (widths 600: three pieces of at
    // least 256 columns, linear.c) and the pieces run on several threads
    enum { B = 64, IN = 300, STEPS = 3 };
    char err[256];
    nn_mlp_config cfg;
    assert_int_equal(nn_mlp_parse_arch("mlp:300-600-600-8,gelu,ln", &cfg, err, sizeof err), 0);
    nn_head heads[2];
    assert_int_equal(nn_heads_parse("sigmoid:0-7", 8, 8, NN_LOSS_MSE, heads, 2, err, sizeof err),
                     1);
    float *x = malloc(B * IN * sizeof(float)), y[B * 8];
    fill(x, B * IN, -1, 1);
    fill(y, B * 8, 0, 1);
    float *result[3];
    int threads[3] = {1, 2, 5};
    for (int r = 0; r < 3; r++) {
        nn_mlp m;
        assert_int_equal(nn_mlp_create(&m, &cfg, heads, 1, 9, err, sizeof err), 0);
        m.threads = threads[r];
        nn_optimizer_config oc = nn_optimizer_defaults(NN_OPT_ADAMW);
        nn_optimizer opt;
        assert_int_equal(nn_optimizer_init(&opt, &oc, m.n_floats), 0);
        double loss = 0, eval;
        for (int t = 0; t < STEPS; t++)
            assert_int_equal(nn_mlp_train_step(&m, &opt, x, y, NULL, B, &loss), 0);
        // no dropout here: evaluation repeats the training forward's loss exactly
        assert_int_equal(nn_mlp_forward_backward(&m, x, y, NULL, B, 0, &loss), 0);
        assert_int_equal(nn_mlp_evaluate(&m, x, y, NULL, B, &eval), 0);
        assert_true(eval == loss);
        result[r] = malloc(m.n_floats * sizeof(float));
        memcpy(result[r], m.weights, m.n_floats * sizeof(float));
        if (r)
            assert_memory_equal(result[0], result[r], m.n_floats * sizeof(float));
        nn_optimizer_free(&opt);
        nn_mlp_free(&m);
    }
    for (int r = 0; r < 3; r++)
        free(result[r]);
    free(x);
}

/* ---------------------------------------------------------------- specs, schedules */

static void test_arch_and_heads_specs(void **state)
{
    (void)state;
    char err[256], buf[256];
    nn_mlp_config cfg;
    assert_int_equal(nn_mlp_parse_arch("mlp:2500-512-512-50,gelu,ln,dropout=0.1,res,init=xavier",
                                       &cfg, err, sizeof err),
                     0);
    assert_int_equal(cfg.n_linear, 3);
    assert_int_equal(cfg.width[3], 50);
    assert_true(cfg.act == NN_ACT_GELU && cfg.layernorm && cfg.residual);
    assert_true(cfg.init == NN_INIT_XAVIER && fabsf(cfg.dropout - 0.1f) < 1e-7f);
    nn_mlp_format_arch(&cfg, buf, sizeof buf);
    nn_mlp_config again;
    assert_int_equal(nn_mlp_parse_arch(buf, &again, err, sizeof err), 0);
    assert_memory_equal(&cfg, &again, sizeof cfg);
    const char *bad[] = {"mlp:10", "mlp:10-x-3", "mlp:10-0-3", "conv:3-3", "mlp:4-4,tanh",
                         "mlp:4-4,dropout=1", "mlp:4-4,init=he"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        assert_int_equal(nn_mlp_parse_arch(bad[i], &cfg, err, sizeof err), -1);
        assert_non_null(strstr(err, "--arch"));
    }
    nn_head h[8];
    assert_int_equal(nn_heads_parse("sigmoid:0-40,softmax:41/9,softmax:42/3:unit@0.5", 43,
                                    41 + 9 + 3, NN_LOSS_THESIS, h, 8, err, sizeof err),
                     3);
    assert_true(h[1].kind == NN_HEAD_SOFTMAX && h[1].classes == 9 && h[1].out_first == 41);
    assert_true(h[2].unit_selector && h[2].weight == 0.5f && h[2].out_first == 50);
    nn_heads_format(h, 3, buf, sizeof buf);
    assert_string_equal(buf, "sigmoid:0-40,softmax:41/9,softmax:42/3:unit@0.5");
    const char *bad_heads[] = {"sigmoid:0-41", "sigmoid:0-40,softmax:40/9", "tanh:0-3",
                               "softmax:41", "softmax:41/1", "sigmoid:3-1"};
    for (size_t i = 0; i < sizeof bad_heads / sizeof bad_heads[0]; i++)
        assert_int_equal(nn_heads_parse(bad_heads[i], 42, 50, NN_LOSS_MSE, h, 8, err, sizeof err),
                         -1);
    // the thesis loss needs positive predictions: not on a linear head
    nn_mlp m;
    assert_int_equal(nn_heads_parse("linear:0-3", 4, 4, NN_LOSS_THESIS, h, 8, err, sizeof err), 1);
    assert_int_equal(nn_mlp_parse_arch("mlp:3-4", &cfg, err, sizeof err), 0);
    assert_int_equal(nn_mlp_create(&m, &cfg, h, 1, 1, err, sizeof err), -1);
    assert_non_null(strstr(err, "use a sigmoid head"));
    // outputs must add up to the network's width
    assert_int_equal(nn_heads_parse("sigmoid:0-3", 4, 5, NN_LOSS_MSE, h, 8, err, sizeof err),
                     -1);
    assert_non_null(strstr(err, "need 4 network outputs"));
}

static void test_schedules(void **state)
{
    (void)state;
    nn_optimizer_config c = nn_optimizer_defaults(NN_OPT_ADAMW);
    c.lr = 1.0f;
    assert_true(nn_schedule_lr(&c, 12345) == 1.0f);
    c.schedule = NN_SCHEDULE_STEP;
    c.step_size = 10;
    c.gamma = 0.5f;
    assert_true(nn_schedule_lr(&c, 9) == 1.0f && nn_schedule_lr(&c, 10) == 0.5f &&
                nn_schedule_lr(&c, 25) == 0.25f);
    c.schedule = NN_SCHEDULE_COSINE;
    c.warmup_steps = 4;
    c.total_steps = 14;
    assert_true(nn_schedule_lr(&c, 0) == 0.25f && nn_schedule_lr(&c, 3) == 1.0f);
    assert_true(nn_schedule_lr(&c, 4) == 1.0f);
    assert_true(fabsf(nn_schedule_lr(&c, 9) - 0.5f) < 1e-6f);
    assert_true(nn_schedule_lr(&c, 14) < 1e-6f && nn_schedule_lr(&c, 100) < 1e-6f);
}

static void test_clipping(void **state)
{
    (void)state;
    // gradient (3, 4): norm 5, clipped to 1 -> (0.6, 0.8); plain SGD lr 1 then moves p by it
    nn_optimizer_config c = nn_optimizer_defaults(NN_OPT_SGD);
    c.lr = 1.0f;
    c.clip_norm = 1.0f;
    nn_optimizer opt;
    assert_int_equal(nn_optimizer_init(&opt, &c, 2), 0);
    float p[2] = {0, 0}, g[2] = {3, 4};
    nn_optimizer_step(&opt, p, g);
    assert_true(fabsf(p[0] + 0.6f) < 1e-6f && fabsf(p[1] + 0.8f) < 1e-6f);
    // a gradient already inside the bound is left alone
    float g2[2] = {0.3f, 0.4f};
    nn_optimizer_step(&opt, p, g2);
    assert_true(g2[0] == 0.3f && g2[1] == 0.4f);
    nn_optimizer_free(&opt);
}

static void test_data_checks(void **state)
{
    (void)state;
    char err[256];
    nn_mlp_config cfg;
    assert_int_equal(nn_mlp_parse_arch("mlp:2-4-4", &cfg, err, sizeof err), 0);
    nn_head h[4];
    int nh = nn_heads_parse("sigmoid:0-0,softmax:1/3", 2, 4, NN_LOSS_MSE, h, 4, err, sizeof err);
    nn_mlp m;
    assert_int_equal(nn_mlp_create(&m, &cfg, h, nh, 1, err, sizeof err), 0);
    float x[4] = {0, 1, 2, 3}, y[4] = {0.5f, 2, 0.25f, 0}, mask[4] = {1, 1, 1, 1};
    assert_int_equal(nn_mlp_check_data(&m, x, y, mask, 2, err, sizeof err), 0);
    x[3] = NAN;
    assert_int_equal(nn_mlp_check_data(&m, x, y, mask, 2, err, sizeof err), -1);
    assert_non_null(strstr(err, "X row 1 column 1"));
    x[3] = 3;
    y[3] = 3; /* class 3 of 3 */
    assert_int_equal(nn_mlp_check_data(&m, x, y, mask, 2, err, sizeof err), -1);
    assert_non_null(strstr(err, "Y row 1 column 1"));
    mask[3] = 0; /* masked: anything goes */
    y[3] = NAN;
    assert_int_equal(nn_mlp_check_data(&m, x, y, mask, 2, err, sizeof err), 0);
    mask[0] = 0.5f;
    assert_int_equal(nn_mlp_check_data(&m, x, y, mask, 2, err, sizeof err), -1);
    assert_non_null(strstr(err, "mask row 0"));
    // predictions: the sigmoid value, and the argmax class for the softmax head
    float pred[4], probs[8];
    assert_int_equal(nn_mlp_predict(&m, x, 2, pred), 0);
    assert_int_equal(nn_mlp_forward(&m, x, 2, probs), 0);
    for (int i = 0; i < 2; i++) {
        assert_true(pred[i * 2] == probs[i * 4]);
        int best = 0;
        for (int k = 1; k < 3; k++)
            best = probs[i * 4 + 1 + k] > probs[i * 4 + 1 + best] ? k : best;
        assert_true(pred[i * 2 + 1] == (float)best);
        assert_true(fabsf(probs[i * 4 + 1] + probs[i * 4 + 2] + probs[i * 4 + 3] - 1) < 1e-6f);
    }
    nn_mlp_free(&m);
}

static void test_batches(void **state)
{
    (void)state;
    // an epoch of 10 rows in batches of 4: 4, 4, 2 (torch's drop_last=False)
    long long epoch;
    size_t first;
    int count;
    nn_step_batch(2, 10, 4, &epoch, &first, &count);
    assert_true(epoch == 0 && first == 8 && count == 2);
    nn_step_batch(3, 10, 4, &epoch, &first, &count);
    assert_true(epoch == 1 && first == 0 && count == 4);
    // shuffled orders: permutations, a pure function of (seed, epoch), new every epoch
    enum { N = 50 };
    size_t a[N], b[N], c[N];
    nn_epoch_order(7, 3, 1, N, a);
    nn_epoch_order(7, 3, 1, N, b);
    nn_epoch_order(7, 4, 1, N, c);
    assert_memory_equal(a, b, sizeof a);
    int seen[N] = {0}, moved = 0, differs = 0;
    for (int i = 0; i < N; i++) {
        assert_true(a[i] < N && !seen[a[i]]);
        seen[a[i]] = 1;
        moved += a[i] != (size_t)i;
        differs += a[i] != c[i];
    }
    assert_true(moved > N / 2 && differs > N / 2);
    nn_epoch_order(7, 3, 0, N, a); /* --no-shuffle: file order */
    for (int i = 0; i < N; i++)
        assert_true(a[i] == (size_t)i);
    float src[6] = {0, 1, 2, 3, 4, 5}, dst[4];
    size_t rows[2] = {2, 0};
    nn_gather_rows(dst, src, 2, rows, 2);
    assert_true(dst[0] == 4 && dst[1] == 5 && dst[2] == 0 && dst[3] == 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_linear_gradients),
        cmocka_unit_test(test_activation_gradients),
        cmocka_unit_test(test_dropout_statistics),
        cmocka_unit_test(test_layernorm_gradients),
        cmocka_unit_test(test_regression_loss_gradients),
        cmocka_unit_test(test_cross_entropy_gradients),
        cmocka_unit_test(test_mlp_gradient_all_options),
        cmocka_unit_test(test_threads_bit_identical),
        cmocka_unit_test(test_arch_and_heads_specs),
        cmocka_unit_test(test_schedules),
        cmocka_unit_test(test_clipping),
        cmocka_unit_test(test_data_checks),
        cmocka_unit_test(test_batches),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

/*
 * Checkpoints: save and load give back the same model and optimiser bit for bit; training
 * resumed from a checkpoint equals training straight through; a torch-written file and
 * ours hold the same names, shapes and bytes; truncated, lying and mismatched files are
 * errors naming the file and the tensor or key; weights stored as float16 load back
 * rounded, and a weight past the half range is refused.
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

#define REF IMSYNTH_SOURCE_DIR "/tests/reference/nn_train/"
#define OUT IMSYNTH_BINARY_DIR "/nn_train_checkpoint_"

enum { B = 16, IN = 16, YC = 8 };

static void make_model(nn_mlp *m, const char *arch, const char *heads)
{
    char err[256];
    nn_mlp_config cfg;
    assert_int_equal(nn_mlp_parse_arch(arch, &cfg, err, sizeof err), 0);
    nn_head h[8];
    int nh = nn_heads_parse(heads, YC, cfg.width[cfg.n_linear], NN_LOSS_THESIS, h, 8, err,
                            sizeof err);
    assert_true(nh > 0);
    for (int k = 0; k < nh; k++) /* the thesis loss is for sigmoid heads */
        if (h[k].kind == NN_HEAD_LINEAR)
            h[k].loss = NN_LOSS_MSE;
    assert_int_equal(nn_mlp_create(m, &cfg, h, nh, 5, err, sizeof err), 0);
}

static float *load(const char *name, size_t *rows, size_t *cols)
{
    float *d;
    char err[256];
    assert_int_equal(nn_npy_read_f32(name, &d, rows, cols, err, sizeof err), 0);
    return d;
}

static void train(nn_mlp *m, nn_optimizer *opt, const float *x, const float *y,
                  const float *mask, int steps)
{
    for (int t = 0; t < steps; t++) {
        size_t lo = (size_t)(opt->step * B % 64);
        double loss;
        assert_int_equal(nn_mlp_train_step(m, opt, x + lo * IN, y + lo * YC, mask + lo * YC, B,
                                           &loss),
                         0);
    }
}

static void test_save_load_resume(void **state)
{
    (void)state;
    size_t r, c;
    float *x = load(REF "x.npy", &r, &c), *y = load(REF "y.npy", &r, &c),
          *mask = load(REF "mask.npy", &r, &c);
    const char *arch = "mlp:16-24-24-13,gelu,ln,dropout=0.1";
    const char *heads = "sigmoid:0-5,softmax:6/4,softmax:7/3:unit@0.5";
    char err[512];
    nn_optimizer_config oc = nn_optimizer_defaults(NN_OPT_ADAMW);
    oc.schedule = NN_SCHEDULE_COSINE;
    oc.warmup_steps = 3;
    oc.total_steps = 20;
    oc.clip_norm = 2.0f;

    nn_mlp straight, half, resumed;
    nn_optimizer o_straight, o_half, o_resumed;
    make_model(&straight, arch, heads);
    make_model(&half, arch, heads);
    assert_int_equal(nn_optimizer_init(&o_straight, &oc, straight.n_floats), 0);
    assert_int_equal(nn_optimizer_init(&o_half, &oc, half.n_floats), 0);
    train(&straight, &o_straight, x, y, mask, 20);
    train(&half, &o_half, x, y, mask, 10);
    assert_int_equal(nn_mlp_save(&half, &o_half, OUT "half.safetensors", err, sizeof err), 0);
    int rc = nn_mlp_load(&resumed, &o_resumed, OUT "half.safetensors", err, sizeof err);
    if (rc)
        printf("%s\n", err);
    assert_int_equal(rc, 0);
    // the same model and optimiser, bit for bit
    assert_memory_equal(&resumed.cfg, &half.cfg, sizeof half.cfg);
    assert_int_equal(resumed.n_heads, half.n_heads);
    assert_memory_equal(resumed.heads, half.heads, (size_t)half.n_heads * sizeof *half.heads);
    assert_int_equal(resumed.y_cols, half.y_cols);
    assert_memory_equal(resumed.weights, half.weights, half.n_floats * sizeof(float));
    assert_memory_equal(&o_resumed.cfg, &o_half.cfg, sizeof oc);
    assert_true(o_resumed.step == 10);
    assert_memory_equal(o_resumed.m, o_half.m, half.n_floats * sizeof(float));
    assert_memory_equal(o_resumed.v, o_half.v, half.n_floats * sizeof(float));
    // and resuming equals training straight through (dropout draws follow the step)
    train(&resumed, &o_resumed, x, y, mask, 10);
    assert_memory_equal(resumed.weights, straight.weights, straight.n_floats * sizeof(float));
    nn_mlp_free(&straight);
    nn_mlp_free(&half);
    nn_mlp_free(&resumed);
    nn_optimizer_free(&o_straight);
    nn_optimizer_free(&o_half);
    nn_optimizer_free(&o_resumed);
    free(x);
    free(y);
    free(mask);
}

/* torch's file (make_fixtures.py's hand-written safetensors of model.state_dict()) loaded
 * and written again by us: the same tensor names, shapes and bytes. */
static void test_torch_names_both_ways(void **state)
{
    (void)state;
    const char *cases[][3] = {
        {"adamw_mlp3", "mlp:16-64-64-4,relu", "linear:0-3"},
        {"adamw_mixed", "mlp:16-48-48-13,gelu,ln", "sigmoid:0-5,softmax:6/4,softmax:7/3:unit"},
        {"adam_res_cosine", "mlp:16-32-32-32-4,relu,ln,res", "linear:0-3"},
    };
    char err[512], path[1024];
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        nn_mlp m;
        make_model(&m, cases[k][1], cases[k][2]);
        snprintf(path, sizeof path, REF "%s/init.safetensors", cases[k][0]);
        assert_int_equal(nn_mlp_load_weights(&m, path, err, sizeof err), 0);
        assert_int_equal(nn_mlp_save(&m, NULL, OUT "names.safetensors", err, sizeof err), 0);
        nn_safetensors theirs, ours;
        assert_int_equal(nn_safetensors_open(path, &theirs, err, sizeof err), 0);
        assert_int_equal(nn_safetensors_open(OUT "names.safetensors", &ours, err, sizeof err), 0);
        assert_int_equal(theirs.count, ours.count);
        for (int i = 0; i < theirs.count; i++) {
            const nn_tensor_info *a = &theirs.tensors[i];
            int j = nn_safetensors_find(&ours, a->name);
            assert_true(j >= 0);
            const nn_tensor_info *b = &ours.tensors[j];
            assert_int_equal(a->ndim, b->ndim);
            assert_memory_equal(a->shape, b->shape, (size_t)a->ndim * sizeof a->shape[0]);
            assert_int_equal(a->end - a->begin, b->end - b->begin);
            assert_memory_equal(theirs.data + a->begin, ours.data + b->begin, a->end - a->begin);
        }
        // our data section starts 8-byte aligned, as the reference writer pads
        assert_int_equal((size_t)(ours.data - ours.file) % 8, 0);
        nn_safetensors_close(&theirs);
        nn_safetensors_close(&ours);
        nn_mlp_free(&m);
    }
}

static void write_bytes(const char *path, const unsigned char *d, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(d, 1, n, f), n);
    fclose(f);
}

static unsigned char *read_bytes(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    *n = (size_t)ftell(f);
    rewind(f);
    unsigned char *d = malloc(*n);
    assert_int_equal(fread(d, 1, *n, f), *n);
    fclose(f);
    return d;
}

/* First occurrence of needle (len bytes) in hay (n bytes), or NULL. */
static char *find_bytes(unsigned char *hay, size_t n, const char *needle, size_t len)
{
    for (size_t i = 0; i + len <= n; i++)
        if (!memcmp(hay + i, needle, len))
            return (char *)hay + i;
    return NULL;
}

static void expect_load_error(const char *path, const char *what)
{
    nn_mlp m;
    nn_optimizer o;
    char err[512] = "";
    assert_int_equal(nn_mlp_load(&m, &o, path, err, sizeof err), -1);
    printf("  %s\n", err);
    assert_non_null(strstr(err, path));
    assert_non_null(strstr(err, what));
}

static void test_bad_checkpoints(void **state)
{
    (void)state;
    char err[512];
    nn_mlp m;
    make_model(&m, "mlp:16-8-4", "linear:0-3");
    nn_optimizer_config oc = nn_optimizer_defaults(NN_OPT_ADAM);
    nn_optimizer opt;
    assert_int_equal(nn_optimizer_init(&opt, &oc, m.n_floats), 0);
    assert_int_equal(nn_mlp_save(&m, &opt, OUT "good.safetensors", err, sizeof err), 0);
    size_t n;
    unsigned char *good = read_bytes(OUT "good.safetensors", &n);

    // truncated: the data section shorter than the header claims
    write_bytes(OUT "truncated.safetensors", good, n - 10);
    expect_load_error(OUT "truncated.safetensors", "run past the end");
    // truncated inside the header
    write_bytes(OUT "truncated.safetensors", good, 40);
    expect_load_error(OUT "truncated.safetensors", "header length");

    // lying metadata: the arch claims another hidden width than the tensors have
    unsigned char *lie = malloc(n);
    memcpy(lie, good, n);
    char *at = find_bytes(lie, n, "mlp:16-8-4", 10);
    assert_non_null(at);
    at[7] = '9';
    write_bytes(OUT "lying.safetensors", lie, n);
    expect_load_error(OUT "lying.safetensors", "trunk.0.weight\" has shape (8,16), expected (9,16)");
    // lying step count
    memcpy(lie, good, n);
    at = find_bytes(lie, n, "\"optimizer.step\":\"0\"", 20);
    assert_non_null(at);
    at[18] = 'x';
    write_bytes(OUT "lying.safetensors", lie, n);
    expect_load_error(OUT "lying.safetensors", "optimizer.step");
    // a step count no integer holds (converting it would be undefined behaviour)
    unsigned char *huge = malloc(n + 8);
    at = find_bytes(good, n, "\"optimizer.step\":\"0\"", 20);
    size_t pos = (size_t)((unsigned char *)at - good) + 18;
    memcpy(huge, good, pos);
    memcpy(huge + pos, "1e300", 5);
    memcpy(huge + pos + 5, good + pos + 1, n - pos - 1);
    // the header grew by 4 bytes: fix its length (little-endian u64 at the start)
    uint64_t hl = 0;
    for (int b = 7; b >= 0; b--)
        hl = hl << 8 | good[b];
    hl += 4;
    for (int b = 0; b < 8; b++)
        huge[b] = (unsigned char)(hl >> (8 * b));
    write_bytes(OUT "lying.safetensors", huge, n + 4);
    expect_load_error(OUT "lying.safetensors", "optimizer.step = 1e+300");
    free(huge);
    free(lie);

    // not ours: torch's state_dict has no imsynth metadata
    expect_load_error(REF "adamw_mlp3/init.safetensors", "imsynth.format");

    // mismatched: weights of another architecture into a model (strict, as torch)
    nn_mlp other;
    make_model(&other, "mlp:16-64-64-4", "linear:0-3");
    assert_int_equal(nn_mlp_load_weights(&other, OUT "good.safetensors", err, sizeof err), -1);
    printf("  %s\n", err);
    assert_non_null(strstr(err, "trunk.0.weight"));
    nn_mlp shallow;
    make_model(&shallow, "mlp:16-4", "linear:0-3");
    assert_int_equal(
        nn_mlp_load_weights(&shallow, REF "adamw_mlp3/init.safetensors", err, sizeof err), -1);
    printf("  %s\n", err);
    assert_non_null(strstr(err, "is not a parameter"));

    // a missing optimiser tensor
    nn_safetensors st;
    assert_int_equal(nn_safetensors_open(OUT "good.safetensors", &st, err, sizeof err), 0);
    nn_tensor_out t[16];
    int k = 0;
    const char *meta[64];
    int nmeta = 0;
    const char *keys[] = {"imsynth.format", "imsynth.arch", "imsynth.heads", "imsynth.losses",
                          "imsynth.y_cols", "optimizer.kind", "optimizer.step",
                          "optimizer.schedule", "optimizer.lr", "optimizer.weight_decay",
                          "optimizer.beta1", "optimizer.beta2", "optimizer.eps",
                          "optimizer.momentum", "optimizer.clip_norm", "optimizer.warmup_steps",
                          "optimizer.total_steps", "optimizer.step_size", "optimizer.gamma"};
    enum { NKEYS = sizeof keys / sizeof keys[0] };
    static char vals[NKEYS][256];
    for (int i = 0; i < NKEYS; i++) {
        assert_int_equal(nn_safetensors_metadata(&st, keys[i], vals[i], sizeof vals[i]), 0);
        meta[2 * nmeta] = keys[i];
        meta[2 * nmeta + 1] = vals[i];
        nmeta++;
    }
    for (int i = 0; i < m.n_params; i++)
        t[k++] = (nn_tensor_out){m.params[i].name, m.params[i].ndim,
                                 {m.params[i].shape[0], m.params[i].shape[1]},
                                 m.weights + m.params[i].offset};
    assert_int_equal(nn_safetensors_write(OUT "partial.safetensors", t, k, meta, nmeta, err,
                                          sizeof err),
                     0);
    expect_load_error(OUT "partial.safetensors", "no tensor \"optimizer.exp_avg.trunk.0.weight\"");
    nn_safetensors_close(&st);

    free(good);
    nn_optimizer_free(&opt);
    nn_mlp_free(&m);
    nn_mlp_free(&other);
    nn_mlp_free(&shallow);
}

static long file_size(const char *path)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fclose(f);
    return n;
}

/* nn_mlp_save_weights: F32 is nn_mlp_save's file without optimiser state, byte for byte;
 * F16 loads back as each weight rounded to the nearest half, in about half the bytes, and
 * predicts within the rounding's reach; a weight past the half range is refused by name. */
static void test_weights_as_f16(void **state)
{
    (void)state;
    size_t r, c;
    float *x = load(REF "x.npy", &r, &c), *y = load(REF "y.npy", &r, &c),
          *mask = load(REF "mask.npy", &r, &c);
    char err[512];
    nn_mlp m, back;
    nn_optimizer opt;
    make_model(&m, "mlp:16-24-24-13,gelu,ln", "sigmoid:0-5,softmax:6/4,softmax:7/3:unit@0.5");
    nn_optimizer_config oc = nn_optimizer_defaults(NN_OPT_ADAMW);
    assert_int_equal(nn_optimizer_init(&opt, &oc, m.n_floats), 0);
    train(&m, &opt, x, y, mask, 10);

    assert_int_equal(nn_mlp_save(&m, NULL, OUT "w32a.safetensors", err, sizeof err), 0);
    assert_int_equal(nn_mlp_save_weights(&m, NN_F32, OUT "w32b.safetensors", err, sizeof err),
                     0);
    size_t na, nb;
    unsigned char *a = read_bytes(OUT "w32a.safetensors", &na),
                  *b = read_bytes(OUT "w32b.safetensors", &nb);
    assert_int_equal(na, nb);
    assert_memory_equal(a, b, na);
    free(a);
    free(b);

    assert_int_equal(nn_mlp_save_weights(&m, NN_F16, OUT "w16.safetensors", err, sizeof err),
                     0);
    long s32 = file_size(OUT "w32a.safetensors"), s16 = file_size(OUT "w16.safetensors");
    // the data halves; the header (a few hundred bytes) stays
    assert_true(s16 < s32 / 2 + 1024);
    assert_int_equal(nn_mlp_load(&back, NULL, OUT "w16.safetensors", err, sizeof err), 0);
    assert_memory_equal(&back.cfg, &m.cfg, sizeof m.cfg);
    size_t changed = 0;
    for (size_t k = 0; k < m.n_floats; k++) {
        float want = nn_half_to_float(nn_float_to_half(m.weights[k]));
        assert_memory_equal(&back.weights[k], &want, sizeof want);
        changed += back.weights[k] != m.weights[k];
    }
    assert_true(changed > m.n_floats / 2); /* it did round */
    float p32[B * YC], p16[B * YC];
    assert_int_equal(nn_mlp_predict(&m, x, B, p32), 0);
    assert_int_equal(nn_mlp_predict(&back, x, B, p16), 0);
    double worst = 0;
    for (int k = 0; k < B * YC; k++)
        worst = fmax(worst, fabs((double)p32[k] - p16[k]));
    assert_true(worst > 0 && worst < 1e-2);

    m.weights[m.params[1].offset] = 1e5f;
    assert_int_equal(nn_mlp_save_weights(&m, NN_F16, OUT "w16big.safetensors", err, sizeof err),
                     -1);
    assert_non_null(strstr(err, m.params[1].name));
    assert_non_null(strstr(err, "F16"));
    FILE *f = fopen(OUT "w16big.safetensors", "rb");
    assert_null(f); /* nothing written */
    assert_int_equal(nn_mlp_save_weights(&m, NN_BF16, OUT "wbf.safetensors", err, sizeof err),
                     -1);
    nn_mlp_free(&m);
    nn_mlp_free(&back);
    nn_optimizer_free(&opt);
    free(x);
    free(y);
    free(mask);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_save_load_resume),
        cmocka_unit_test(test_torch_names_both_ways),
        cmocka_unit_test(test_bad_checkpoints),
        cmocka_unit_test(test_weights_as_f16),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

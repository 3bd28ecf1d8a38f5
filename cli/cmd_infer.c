/* imsynth infer: predictions of a trained model (imsynth train) for rows of X, as .npy. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli/cli.h"
#include "nn/nn.h"

#include <cblas.h> /* after our headers: its <complex.h> defines I */

static const char *const help =
    "usage: imsynth infer MODEL.safetensors --x X.npy -o Y.npy [options]\n"
    "\n"
    "Writes the model's predictions for each row of X as a float32 .npy of the shape of\n"
    "the Y it was trained on: regression heads' values (after their sigmoid), and for a\n"
    "softmax head the most probable class in its column (k/(K-1) for a :unit head).\n"
    "\n"
    "options:\n"
    "  --x X.npy                  inputs, N x IN (any float/int/bool dtype)\n"
    "  -o, --output Y.npy         predictions (required)\n"
    "  --probs                    instead, the raw head outputs N x OUT: sigmoid values and\n"
    "                             every softmax head's class probabilities\n"
    "  --batch N                  rows per forward pass (default 256)\n"
    "  --threads N                worker threads (default: online CPUs; same bits)\n";

int cmd_infer(int argc, char **argv)
{
    const char *sub = "infer";
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    const char *model_path = NULL, *x_path = NULL, *out_path = NULL;
    long batch = 256, threads = sysconf(_SC_NPROCESSORS_ONLN);
    int probs = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (a[0] != '-') {
            if (model_path) {
                cli_error(sub, "unexpected argument \"%s\"", a);
                return EXIT_USAGE;
            }
            model_path = a;
            continue;
        }
        if (!strcmp(a, "--probs")) {
            probs = 1;
            continue;
        }
        if (i + 1 >= argc) {
            cli_error(sub, "%s needs a value (or is unknown; see --help)", a);
            return EXIT_USAGE;
        }
        const char *v = argv[++i];
        char *end;
        if (!strcmp(a, "--x"))
            x_path = v;
        else if (!strcmp(a, "-o") || !strcmp(a, "--output"))
            out_path = v;
        else if (!strcmp(a, "--batch") || !strcmp(a, "--threads")) {
            long n = strtol(v, &end, 10);
            if (!*v || *end || n < 1 || n > (1 << 20)) {
                cli_error(sub, "%s: expected a positive integer, got \"%s\"", a, v);
                return EXIT_USAGE;
            }
            *(!strcmp(a, "--batch") ? &batch : &threads) = n;
        } else {
            cli_error(sub, "unknown option \"%s\"", a);
            return EXIT_USAGE;
        }
    }
    if (!model_path || !x_path || !out_path) {
        cli_error(sub, "need MODEL.safetensors, --x X.npy and -o Y.npy (see --help)");
        return EXIT_USAGE;
    }
    char err[1024];
    nn_mlp m;
    if (nn_mlp_load(&m, NULL, model_path, err, sizeof err)) {
        cli_error(sub, "%s", err);
        return EXIT_FAILURE_WORK;
    }
    int rc = EXIT_FAILURE_WORK;
    float *x = NULL, *out = NULL;
    size_t n, in;
    nn_npy_writer *w = NULL;
    if (nn_npy_read_f32(x_path, &x, &n, &in, err, sizeof err)) {
        cli_error(sub, "--x %s", err);
        goto done;
    }
    if (in != (size_t)m.cfg.width[0]) {
        cli_error(sub, "%s has %zu columns but %s takes %d inputs", x_path, in, model_path,
                  m.cfg.width[0]);
        goto done;
    }
    for (size_t i = 0; i < n * in; i++)
        if (!isfinite(x[i])) {
            cli_error(sub, "%s: row %zu column %zu is not finite", x_path, i / in, i % in);
            goto done;
        }
    m.threads = (int)threads;
    openblas_set_num_threads(1);
    if (nn_blas_warning() && !getenv("OPENBLAS_CORETYPE"))
        cli_error(sub, "warning: %s", nn_blas_warning());
    size_t cols = probs ? (size_t)m.cfg.width[m.cfg.n_linear] : (size_t)m.y_cols;
    out = malloc((size_t)batch * cols * sizeof(float));
    if (!out) {
        cli_error(sub, "out of memory");
        goto done;
    }
    w = nn_npy_begin(out_path, n, cols, err, sizeof err);
    if (!w) {
        cli_error(sub, "%s", err);
        goto done;
    }
    for (size_t first = 0; first < n; first += (size_t)batch) {
        int k = n - first < (size_t)batch ? (int)(n - first) : (int)batch;
        int bad = probs ? nn_mlp_forward(&m, x + first * in, k, out)
                        : nn_mlp_predict(&m, x + first * in, k, out);
        if (bad) {
            cli_error(sub, "out of memory");
            goto done;
        }
        if (nn_npy_append(w, out, (size_t)k, err, sizeof err)) {
            cli_error(sub, "%s", err);
            goto done;
        }
    }
    if (nn_npy_commit(w, err, sizeof err)) {
        w = NULL;
        cli_error(sub, "%s", err);
        goto done;
    }
    w = NULL;
    printf("%s: %zu x %zu float32\n", out_path, n, cols);
    rc = EXIT_OK;
done:
    nn_npy_abort(w);
    nn_mlp_free(&m);
    free(x);
    free(out);
    return rc;
}

/* imsynth forest: fit a multi-output random forest, rank features, predict (.npy in/out). */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "cli/cli.h"
#include "pipeline/pipeline.h"
#include "forest/forest.h"
#include "nn/nn.h"

static const char *const help =
    "usage: imsynth forest fit --x X.npy --y Y.npy [--mask M.npy] -o FOREST.bin [options]\n"
    "       imsynth forest fit --dataset DS.sqlite -o FOREST.bin [options]\n"
    "         (X = the stored descriptors, Y = the parameters, mask = the active mask)\n"
    "       imsynth forest importance FOREST.bin --top-k K -o MASK.npy [options]\n"
    "       imsynth forest predict FOREST.bin --x X.npy -o YHAT.npy [--y Y.npy [--mask M.npy]]\n"
    "\n"
    "A multi-output random forest of CART regression trees, as scikit-learn's\n"
    "RandomForestRegressor with a 2-D y (forest/forest.h). X is rows x features, Y rows x\n"
    "outputs, M (optional) rows x outputs with 1 = target active, 0 = ignore it; any numeric\n"
    ".npy dtype is read as float32.\n"
    "\n"
    "fit options:\n"
    "  --trees N                  number of trees (default 100)\n"
    "  --max-features F           features tried per node: sqrt (default), log2, all, a\n"
    "                             fraction in (0, 1) such as 0.3, or a count such as 50\n"
    "                             (scikit-learn's default is all)\n"
    "  --max-depth N              0 = unlimited (default)\n"
    "  --min-samples-split N      default 2\n"
    "  --min-samples-leaf N       default 1\n"
    "  --no-bootstrap             every tree sees every row once\n"
    "  --seed N                   default 0; trees depend on (seed, tree index) only\n"
    "  --split binned|exact       binned (default): uint8 quantile bins; exact: every\n"
    "                             midpoint between distinct values, as scikit-learn\n"
    "  --bins N                   bins per feature in binned mode, 2..256 (default 256)\n"
    "  --mask-mode exclude|impute masked targets left out of each output's sums (default)\n"
    "                             or replaced by their output's mean over active rows\n"
    "  --threads N                worker threads (default: online CPUs); same forest for any N\n"
    "  --quiet                    no progress on stderr\n"
    "\n"
    "importance options:\n"
    "  --top-k K                  features to keep (required)\n"
    "  -o MASK.npy                1 x features float32, 1 for the K kept (required)\n"
    "  --scores S.npy             also write the scores (1 x features float32)\n"
    "  --indices I.npy            also write the K indices, best first (K x 1 float32)\n"
    "  --permutation              rank by permutation importance on held-out rows given by\n"
    "                             --x X.npy --y Y.npy [--mask M.npy] instead of impurity\n"
    "  --candidates C             with --permutation: only the C best by impurity are\n"
    "                             permuted (default: all if features <= 5000, else 4 * K);\n"
    "                             the others score 0\n"
    "  --repeats R                shuffles per feature (default 5); --seed, --threads as fit\n"
    "\n"
    "predict: writes rows x outputs float32; with --y also prints R^2 (mean over outputs,\n"
    "each over its active rows).\n";

static int parse_long(const char *sub, const char *opt, const char *s, long lo, long hi,
                      long *v)
{
    char *end;
    *v = strtol(s, &end, 10);
    if (!*s || *end || *v < lo || *v > hi) {
        cli_error(sub, "%s: expected an integer in [%ld, %ld], got \"%s\"", opt, lo, hi, s);
        return -1;
    }
    return 0;
}

static double now_seconds(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

typedef struct progress {
    double start;
    int last_shown; /* trees done when last printed */
    int tty;
} progress;

/* Progress with an ETA: every tree on a terminal, every ~10% otherwise. */
static void show_progress(void *ctx, int done, int total)
{
    progress *p = ctx;
    int step = p->tty ? 1 : (total + 9) / 10;
    if (done != total && done - p->last_shown < step)
        return;
    p->last_shown = done;
    double el = now_seconds() - p->start;
    double eta = done ? el * (total - done) / done : 0.0;
    fprintf(stderr, "%strees %d/%d  %.1f s elapsed, ETA %.1f s%s", p->tty ? "\r" : "", done,
            total, el, eta, p->tty && done != total ? "" : "\n");
    fflush(stderr);
}

/* Reads a .npy that must have `rows` rows (0: any) and `cols` columns (0: any). */
static float *read_npy(const char *sub, const char *what, const char *path, size_t *rows,
                       size_t *cols)
{
    char err[1024];
    float *a = NULL;
    size_t r, c;
    if (nn_npy_read_f32(path, &a, &r, &c, err, sizeof err)) {
        cli_error(sub, "%s", err);
        return NULL;
    }
    if ((*rows && r != *rows) || (*cols && c != *cols)) {
        cli_error(sub, "%s: %s is %zu x %zu, expected %zu x %zu", path, what, r, c,
                  *rows ? *rows : r, *cols ? *cols : c);
        free(a);
        return NULL;
    }
    *rows = r;
    *cols = c;
    return a;
}

/* A mask .npy as bytes (nonzero = active). */
static uint8_t *read_mask(const char *sub, const char *path, size_t rows, size_t cols)
{
    size_t r = rows, c = cols;
    float *m = read_npy(sub, "the mask", path, &r, &c);
    if (!m)
        return NULL;
    uint8_t *b = malloc(r * c);
    if (!b)
        cli_error(sub, "out of memory");
    for (size_t i = 0; b && i < r * c; i++)
        b[i] = m[i] != 0.0f;
    free(m);
    return b;
}

static int parse_max_features(const char *s, forest_params *p)
{
    if (!strcmp(s, "sqrt"))
        p->max_features = FOREST_MAXF_SQRT;
    else if (!strcmp(s, "log2"))
        p->max_features = FOREST_MAXF_LOG2;
    else if (!strcmp(s, "all"))
        p->max_features = FOREST_MAXF_ALL;
    else {
        char *end;
        double v = strtod(s, &end);
        if (!*s || *end || !(v > 0.0))
            return -1;
        if (strchr(s, '.')) {
            if (v > 1.0)
                return -1;
            p->max_features = FOREST_MAXF_FRACTION;
        } else
            p->max_features = FOREST_MAXF_COUNT;
        p->max_features_value = v;
    }
    return 0;
}

static int forest_fit_cmd(int argc, char **argv)
{
    const char *sub = "forest fit";
    const char *x_path = NULL, *y_path = NULL, *m_path = NULL, *out_path = NULL;
    const char *ds_path = NULL;
    forest_params p = forest_default_params();
    p.max_features = FOREST_MAXF_SQRT;
    long threads = sysconf(_SC_NPROCESSORS_ONLN), v;
    int quiet = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int takes = strcmp(a, "--no-bootstrap") && strcmp(a, "--quiet");
        if (takes && i + 1 >= argc) {
            cli_error(sub, "%s needs a value", a);
            return EXIT_USAGE;
        }
        if (!strcmp(a, "--x"))
            x_path = argv[++i];
        else if (!strcmp(a, "--y"))
            y_path = argv[++i];
        else if (!strcmp(a, "--mask"))
            m_path = argv[++i];
        else if (!strcmp(a, "--dataset"))
            ds_path = argv[++i];
        else if (!strcmp(a, "-o") || !strcmp(a, "--output"))
            out_path = argv[++i];
        else if (!strcmp(a, "--trees")) {
            if (parse_long(sub, a, argv[++i], 1, 100000, &v))
                return EXIT_USAGE;
            p.n_estimators = (int)v;
        } else if (!strcmp(a, "--max-features")) {
            if (parse_max_features(argv[++i], &p)) {
                cli_error(sub, "--max-features: expected sqrt, log2, all, a fraction in (0, 1] "
                               "or a count, got \"%s\"", argv[i]);
                return EXIT_USAGE;
            }
        } else if (!strcmp(a, "--max-depth")) {
            if (parse_long(sub, a, argv[++i], 0, 100000, &v))
                return EXIT_USAGE;
            p.max_depth = (int)v;
        } else if (!strcmp(a, "--min-samples-split")) {
            if (parse_long(sub, a, argv[++i], 2, INT32_MAX, &v))
                return EXIT_USAGE;
            p.min_samples_split = (int)v;
        } else if (!strcmp(a, "--min-samples-leaf")) {
            if (parse_long(sub, a, argv[++i], 1, INT32_MAX, &v))
                return EXIT_USAGE;
            p.min_samples_leaf = (int)v;
        } else if (!strcmp(a, "--no-bootstrap"))
            p.bootstrap = 0;
        else if (!strcmp(a, "--quiet"))
            quiet = 1;
        else if (!strcmp(a, "--seed")) {
            if (parse_long(sub, a, argv[++i], 0, INT32_MAX, &v))
                return EXIT_USAGE;
            p.seed = (uint64_t)v;
        } else if (!strcmp(a, "--split")) {
            const char *s = argv[++i];
            if (!strcmp(s, "binned"))
                p.split = FOREST_SPLIT_BINNED;
            else if (!strcmp(s, "exact"))
                p.split = FOREST_SPLIT_EXACT;
            else {
                cli_error(sub, "--split: expected binned or exact, got \"%s\"", s);
                return EXIT_USAGE;
            }
        } else if (!strcmp(a, "--bins")) {
            if (parse_long(sub, a, argv[++i], 2, 256, &v))
                return EXIT_USAGE;
            p.n_bins = (int)v;
        } else if (!strcmp(a, "--mask-mode")) {
            const char *s = argv[++i];
            if (!strcmp(s, "exclude"))
                p.mask_mode = FOREST_MASK_EXCLUDE;
            else if (!strcmp(s, "impute"))
                p.mask_mode = FOREST_MASK_IMPUTE;
            else {
                cli_error(sub, "--mask-mode: expected exclude or impute, got \"%s\"", s);
                return EXIT_USAGE;
            }
        } else if (!strcmp(a, "--threads")) {
            if (parse_long(sub, a, argv[++i], 1, 256, &threads))
                return EXIT_USAGE;
        } else {
            cli_error(sub, "unknown option \"%s\"", a);
            return EXIT_USAGE;
        }
    }
    if (ds_path ? (x_path || y_path || m_path || !out_path) : (!x_path || !y_path || !out_path)) {
        cli_error(sub, "need (--dataset DS.sqlite | --x X.npy --y Y.npy [--mask M.npy]) and -o "
                       "FOREST.bin (see --help)");
        return EXIT_USAGE;
    }
    p.n_threads = threads < 1 ? 1 : (int)threads;
    int rc = EXIT_FAILURE_WORK;
    size_t n = 0, d = 0, ny = 0, k = 0;
    float *X = NULL, *Y = NULL;
    uint8_t *M = NULL;
    forest *f = NULL;
    char err[1024];
    if (ds_path) {
        /* X = descriptors, Y = parameters, M = the active mask (inactive targets excluded). */
        dataset *ds = dataset_open(ds_path, err, sizeof err);
        int bad = !ds || dataset_read_arrays(ds, &X, &Y, &M, &n, &d, &k, err, sizeof err);
        dataset_close(ds);
        if (bad) {
            cli_error(sub, "%s", err);
            goto done;
        }
        x_path = y_path = ds_path;
    } else {
        if (!(X = read_npy(sub, "X", x_path, &n, &d)))
            goto done;
        ny = n;
        if (!(Y = read_npy(sub, "Y (one row per row of X)", y_path, &ny, &k)))
            goto done;
        if (m_path && !(M = read_mask(sub, m_path, n, k)))
            goto done;
    }
    progress prog = {now_seconds(), 0, isatty(2)};
    if (!quiet) {
        p.progress = show_progress;
        p.progress_ctx = &prog;
        fprintf(stderr, "fitting %d trees on %zu rows x %zu features -> %zu outputs, %d threads\n",
                p.n_estimators, n, d, k, p.n_threads);
    }
    if (forest_fit(X, n, d, Y, k, M, &p, &f, err, sizeof err)) {
        cli_error(sub, "%s (fitting %s, %s)", err, x_path, y_path);
        goto done;
    }
    if (forest_save(f, out_path, err, sizeof err)) {
        cli_error(sub, "%s", err);
        goto done;
    }
    printf("%s: %d trees, %zu nodes, %zu features -> %zu outputs, fitted in %.2f s\n", out_path,
           forest_n_trees(f), forest_n_nodes(f), d, k, now_seconds() - prog.start);
    rc = EXIT_OK;
done:
    forest_free(f);
    free(X);
    free(Y);
    free(M);
    return rc;
}

static forest *load_forest(const char *sub, const char *path)
{
    char err[1024];
    forest *f = NULL;
    if (forest_load(path, &f, err, sizeof err))
        cli_error(sub, "%s", err);
    return f;
}

static int write_npy(const char *sub, const char *path, const float *a, size_t rows,
                     size_t cols)
{
    char err[1024];
    if (nn_npy_write_f32(path, a, rows, cols, err, sizeof err)) {
        cli_error(sub, "%s", err);
        return -1;
    }
    return 0;
}

static int forest_importance_cmd(int argc, char **argv)
{
    const char *sub = "forest importance";
    const char *model = NULL, *out_path = NULL, *scores_path = NULL, *indices_path = NULL;
    const char *x_path = NULL, *y_path = NULL, *m_path = NULL;
    long top_k = -1, candidates = -1, repeats = 5, seed = 0, v;
    long threads = sysconf(_SC_NPROCESSORS_ONLN);
    int permutation = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (a[0] != '-') {
            if (model) {
                cli_error(sub, "one FOREST.bin only (got \"%s\" and \"%s\")", model, a);
                return EXIT_USAGE;
            }
            model = a;
            continue;
        }
        if (!strcmp(a, "--permutation")) {
            permutation = 1;
            continue;
        }
        if (i + 1 >= argc) {
            cli_error(sub, "%s needs a value", a);
            return EXIT_USAGE;
        }
        if (!strcmp(a, "-o") || !strcmp(a, "--output"))
            out_path = argv[++i];
        else if (!strcmp(a, "--scores"))
            scores_path = argv[++i];
        else if (!strcmp(a, "--indices"))
            indices_path = argv[++i];
        else if (!strcmp(a, "--x"))
            x_path = argv[++i];
        else if (!strcmp(a, "--y"))
            y_path = argv[++i];
        else if (!strcmp(a, "--mask"))
            m_path = argv[++i];
        else if (!strcmp(a, "--top-k")) {
            if (parse_long(sub, a, argv[++i], 1, INT32_MAX, &top_k))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--candidates")) {
            if (parse_long(sub, a, argv[++i], 1, INT32_MAX, &candidates))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--repeats")) {
            if (parse_long(sub, a, argv[++i], 1, 10000, &repeats))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--seed")) {
            if (parse_long(sub, a, argv[++i], 0, INT32_MAX, &seed))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--threads")) {
            if (parse_long(sub, a, argv[++i], 1, 256, &v))
                return EXIT_USAGE;
            threads = v;
        } else {
            cli_error(sub, "unknown option \"%s\"", a);
            return EXIT_USAGE;
        }
    }
    if (!model || top_k < 0 || !out_path) {
        cli_error(sub, "need FOREST.bin, --top-k K and -o MASK.npy (see --help)");
        return EXIT_USAGE;
    }
    if (permutation && (!x_path || !y_path)) {
        cli_error(sub, "--permutation needs held-out rows: --x X.npy --y Y.npy");
        return EXIT_USAGE;
    }
    int rc = EXIT_FAILURE_WORK;
    forest *f = load_forest(sub, model);
    float *X = NULL, *Y = NULL, *out = NULL;
    uint8_t *M = NULL;
    double *score = NULL, *pm = NULL, *ps = NULL;
    size_t *order = NULL, *cand = NULL;
    if (!f)
        goto done;
    size_t d = forest_n_features(f), k = forest_n_outputs(f);
    if ((size_t)top_k > d) {
        cli_error(sub, "--top-k %ld: %s has only %zu features", top_k, model, d);
        goto done;
    }
    score = malloc(d * sizeof *score);
    order = malloc(d * sizeof *order);
    out = malloc(d * sizeof *out);
    if (!score || !order || !out || forest_feature_importances(f, score) ||
        forest_top_k(score, d, d, order)) {
        cli_error(sub, "out of memory");
        goto done;
    }
    if (permutation) {
        size_t n = 0, dd = d, ny = 0, kk = k;
        if (!(X = read_npy(sub, "X (features as the forest's)", x_path, &n, &dd)))
            goto done;
        ny = n;
        if (!(Y = read_npy(sub, "Y (rows as X, outputs as the forest's)", y_path, &ny, &kk)))
            goto done;
        if (m_path && !(M = read_mask(sub, m_path, n, k)))
            goto done;
        size_t nc = candidates > 0 ? (size_t)candidates
                                   : (d <= 5000 ? d : (size_t)top_k * 4 < d ? (size_t)top_k * 4 : d);
        if (nc > d)
            nc = d;
        if (nc < (size_t)top_k) {
            cli_error(sub, "--candidates %zu is fewer than --top-k %ld", nc, top_k);
            rc = EXIT_USAGE;
            goto done;
        }
        pm = malloc(nc * sizeof *pm);
        ps = malloc(nc * sizeof *ps);
        cand = malloc(nc * sizeof *cand);
        if (!pm || !ps || !cand) {
            cli_error(sub, "out of memory");
            goto done;
        }
        memcpy(cand, order, nc * sizeof *cand);
        char err[1024];
        if (forest_permutation_importance(f, X, Y, M, n, cand, nc, (int)repeats, (uint64_t)seed,
                                          (int)threads, pm, ps, err, sizeof err)) {
            cli_error(sub, "%s: %s", model, err);
            goto done;
        }
        for (size_t j = 0; j < d; j++)
            score[j] = 0.0;
        for (size_t c = 0; c < nc; c++)
            score[cand[c]] = pm[c];
        if (forest_top_k(score, d, d, order)) {
            cli_error(sub, "out of memory");
            goto done;
        }
    }
    for (size_t j = 0; j < d; j++)
        out[j] = 0.0f;
    for (long r = 0; r < top_k; r++)
        out[order[r]] = 1.0f;
    if (write_npy(sub, out_path, out, 1, d))
        goto done;
    if (scores_path) {
        for (size_t j = 0; j < d; j++)
            out[j] = (float)score[j];
        if (write_npy(sub, scores_path, out, 1, d))
            goto done;
    }
    if (indices_path) {
        for (long r = 0; r < top_k; r++)
            out[r] = (float)order[r];
        if (write_npy(sub, indices_path, out, (size_t)top_k, 1))
            goto done;
    }
    printf("%s: top %ld of %zu features by %s importance (best: feature %zu, %.4g)\n", out_path,
           top_k, d, permutation ? "permutation" : "impurity", order[0], score[order[0]]);
    rc = EXIT_OK;
done:
    forest_free(f);
    free(X);
    free(Y);
    free(M);
    free(out);
    free(score);
    free(order);
    free(pm);
    free(ps);
    free(cand);
    return rc;
}

static int forest_predict_cmd(int argc, char **argv)
{
    const char *sub = "forest predict";
    const char *model = NULL, *x_path = NULL, *y_path = NULL, *m_path = NULL, *out_path = NULL;
    long threads = sysconf(_SC_NPROCESSORS_ONLN);
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (a[0] != '-') {
            if (model) {
                cli_error(sub, "one FOREST.bin only (got \"%s\" and \"%s\")", model, a);
                return EXIT_USAGE;
            }
            model = a;
            continue;
        }
        if (i + 1 >= argc) {
            cli_error(sub, "%s needs a value", a);
            return EXIT_USAGE;
        }
        if (!strcmp(a, "--x"))
            x_path = argv[++i];
        else if (!strcmp(a, "--y"))
            y_path = argv[++i];
        else if (!strcmp(a, "--mask"))
            m_path = argv[++i];
        else if (!strcmp(a, "-o") || !strcmp(a, "--output"))
            out_path = argv[++i];
        else if (!strcmp(a, "--threads")) {
            if (parse_long(sub, a, argv[++i], 1, 256, &threads))
                return EXIT_USAGE;
        } else {
            cli_error(sub, "unknown option \"%s\"", a);
            return EXIT_USAGE;
        }
    }
    if (!model || !x_path || !out_path) {
        cli_error(sub, "need FOREST.bin, --x X.npy and -o YHAT.npy (see --help)");
        return EXIT_USAGE;
    }
    int rc = EXIT_FAILURE_WORK;
    float *X = NULL, *Y = NULL, *P = NULL;
    uint8_t *M = NULL;
    forest *f = load_forest(sub, model);
    if (!f)
        goto done;
    size_t n = 0, d = forest_n_features(f), k = forest_n_outputs(f), ny = 0;
    if (!(X = read_npy(sub, "X (features as the forest's)", x_path, &n, &d)))
        goto done;
    if (!(P = malloc(n * k * sizeof *P)) || forest_predict(f, X, n, P, (int)threads)) {
        cli_error(sub, "out of memory");
        goto done;
    }
    if (write_npy(sub, out_path, P, n, k))
        goto done;
    printf("%s: %zu x %zu predictions\n", out_path, n, k);
    if (y_path) {
        ny = n;
        if (!(Y = read_npy(sub, "Y (rows as X, outputs as the forest's)", y_path, &ny, &k)))
            goto done;
        if (m_path && !(M = read_mask(sub, m_path, n, k)))
            goto done;
        printf("R^2 (mean over outputs): %.6f\n", forest_score(f, X, Y, M, n, (int)threads));
    }
    rc = EXIT_OK;
done:
    forest_free(f);
    free(X);
    free(Y);
    free(P);
    free(M);
    return rc;
}

int cmd_forest(int argc, char **argv)
{
    if (argc < 2 || (cli_wants_help(argc, argv) && argc == 2)) {
        fputs(help, argc < 2 ? stderr : stdout);
        return argc < 2 ? EXIT_USAGE : EXIT_OK;
    }
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    if (!strcmp(argv[1], "fit"))
        return forest_fit_cmd(argc - 1, argv + 1);
    if (!strcmp(argv[1], "importance"))
        return forest_importance_cmd(argc - 1, argv + 1);
    if (!strcmp(argv[1], "predict"))
        return forest_predict_cmd(argc - 1, argv + 1);
    cli_error("forest", "unknown action \"%s\" (fit, importance or predict)", argv[1]);
    return EXIT_USAGE;
}

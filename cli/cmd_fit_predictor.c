/* imsynth fit-predictor: train the parameter predictor on a dataset into a model directory. */
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "cli/cli.h"
#include "pipeline/pipeline.h"

static const char *const help =
    "usage: imsynth fit-predictor --dataset DS.sqlite -o MODEL_DIR [options]\n"
    "\n"
    "Trains the parameter predictor on a dataset from `imsynth datagen` and writes a model\n"
    "directory (model.json, transform/network/catalogue .safetensors, losses.csv, loss.svg)\n"
    "for `imsynth predict-params`, `imsynth evaluate` and `imsynth predict`.\n"
    "\n"
    "Inputs: every descriptor value through sign(x) log1p(|x| / s) (s: its mean |x|),\n"
    "standardised, reduced to the leading principal components (whitened). Targets: each\n"
    "\"Mult N\" selector is a softmax classification, every other parameter but Pattern Offset\n"
    "a sigmoid regression (a hue as a point on the circle); both are trained only on the\n"
    "samples where the parameter is\n"
    "active (the extracted sub-shader depends on it). Pattern Offset moves the pattern like a\n"
    "seed and is not a target. The network: an MLP with LayerNorm and dropout, AdamW with a\n"
    "cosine schedule; the epoch of least validation loss is kept.\n"
    "\n"
    "Resumable: the run lives in MODEL_DIR.partial/ with a checkpoint after every epoch;\n"
    "killed or stopped (Ctrl-C: after the current epoch), rerun the same command and it\n"
    "continues to the same result. MODEL_DIR appears complete or not at all.\n"
    "\n"
    "options:\n"
    "  --dataset DS.sqlite     training samples (required)\n"
    "  --val-dataset V.sqlite  validation samples (same super-shader and descriptor); default:\n"
    "                          hold out --val-fraction of the ids (by a hash of the id)\n"
    "  --val-fraction F        default 0.05\n"
    "  --max-ids N             train on the first N training ids only; the validation ids\n"
    "                          stay all of them (learning curves compare like with like)\n"
    "  -o, --output MODEL_DIR  the model directory (must not exist)\n"
    "  --components K          principal components fed to the network (default 256)\n"
    "  --per-tap               split the components equally among the descriptor's taps,\n"
    "                          each a PCA of that tap's values alone (default: one PCA of\n"
    "                          all of them, which spends most components on the big deep\n"
    "                          taps)\n"
    "  --feature-mask M.npy    fit the PCA on the features M keeps (1 x features, 0/1:\n"
    "                          `imsynth forest importance --top-k K -o M.npy` of a forest\n"
    "                          fitted on the training rows only)\n"
    "  --texstats              the network also reads 38 texture statistics of each render\n"
    "                          (colour percentiles, the dark and bright ends' colours,\n"
    "                          pyramid band energies, row / column detail), computed from\n"
    "                          the stored renders (docs/predictor.md)\n"
    "  --conditional           the value parameters given the selectors: the network also\n"
    "                          reads a combination's one-hot classes and learns each sample\n"
    "                          twice (without them: the selectors and values; with its\n"
    "                          own: the values), so that each top-k hypothesis gets values\n"
    "                          of its own (docs/predictor.md)\n"
    "  --hidden W1-W2-...      hidden layer widths (default 1024-1024)\n"
    "  --epochs E              default 60\n"
    "  --batch B               default 128\n"
    "  --lr F                  peak learning rate (default 1e-3)\n"
    "  --wd F                  AdamW weight decay (default 1e-4)\n"
    "  --dropout P             default 0.5\n"
    "  --value-weight W        loss weight of the value regression against the selectors'\n"
    "                          mean cross-entropy (default 10)\n"
    "  --seed S                initial weights, PCA test matrix, shuffling, dropout (default 1)\n"
    "  --members M             train M networks on the same inputs (member m from seed + m)\n"
    "                          and predict with their averaged outputs: an ensemble, M\n"
    "                          times the training time and network bytes (default 1)\n"
    "  --threads T             worker threads (default: online CPUs); never changes a bit\n"
    "  --half                  store the PCA basis, the catalogue and the networks in\n"
    "                          float16 (the basis rounded before training, so predictions\n"
    "                          see what training saw; the networks once trained, and the\n"
    "                          model's figures are theirs as stored): a model half the\n"
    "                          size, for shipping (assets/model)\n"
    "  --catalogue N           keep the first N training samples (by id) in the retrieval\n"
    "                          catalogue (default: all of them)\n"
    "  --restart               discard an unfinished run made with other settings\n"
    "  --quiet                 no progress\n";

static volatile int stop_requested;

static void on_sigint(int sig)
{
    (void)sig;
    stop_requested = 1;
}

typedef struct progress_state {
    int quiet;
    int epochs_seen;  /* by this process (a resumed run's earlier epochs are not timed) */
    double elapsed;
} progress_state;

static void progress(void *ctx, int member, int members, int epoch, int epochs,
                     double train_loss, double val_loss, double acc, double r2, double seconds)
{
    progress_state *p = ctx;
    p->elapsed += seconds;
    p->epochs_seen++;
    if (p->quiet)
        return;
    long long left = (long long)(members - member - 1) * epochs + (epochs - epoch);
    double eta = p->elapsed / p->epochs_seen * (double)left;
    char who[48] = "";
    if (members > 1)
        snprintf(who, sizeof who, "network %d/%d ", member + 1, members);
    fprintf(stderr,
            "fit-predictor: %sepoch %d/%d  loss %.4f  val %.4f  selector accuracy %.3f  median "
            "R^2 %.3f  %.1f s/epoch  ETA %.0f s\n",
            who, epoch, epochs, train_loss, val_loss, acc, r2, seconds, eta);
}

static void progress_text(void *ctx, const char *what)
{
    const progress_state *p = ctx;
    if (!p->quiet)
        fprintf(stderr, "fit-predictor: %s\n", what);
}

int cmd_fit_predictor(int argc, char **argv)
{
    const char *sub = "fit-predictor";
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    predictor_fit_options o;
    predictor_fit_defaults(&o);
    o.threads = (int)sysconf(_SC_NPROCESSORS_ONLN);
    int quiet = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--quiet")) {
            quiet = 1;
            continue;
        }
        if (!strcmp(a, "--restart")) {
            o.restart = 1;
            continue;
        }
        if (!strcmp(a, "--half")) {
            o.half = 1;
            continue;
        }
        if (!strcmp(a, "--per-tap")) {
            o.per_tap = 1;
            continue;
        }
        if (!strcmp(a, "--texstats")) {
            o.texstats = 1;
            continue;
        }
        if (!strcmp(a, "--conditional")) {
            o.conditional = 1;
            continue;
        }
        if (i + 1 >= argc) {
            cli_error(sub, "%s needs a value (see --help)", a);
            return EXIT_USAGE;
        }
        const char *v = argv[++i];
        long long x;
        double f;
        int bad = 0;
        if (!strcmp(a, "--dataset"))
            o.dataset_path = v;
        else if (!strcmp(a, "--val-dataset"))
            o.val_dataset_path = v;
        else if (!strcmp(a, "-o") || !strcmp(a, "--output"))
            o.out_dir = v;
        else if (!strcmp(a, "--feature-mask"))
            o.feature_mask_path = v;
        else if (!strcmp(a, "--hidden"))
            o.hidden = v;
        else if (!strcmp(a, "--val-fraction"))
            bad = cli_parse_double(sub, a, v, 0.001, 0.5, &o.val_fraction);
        else if (!strcmp(a, "--catalogue"))
            bad = cli_parse_ll(sub, a, v, 1, 1LL << 40, &o.catalogue);
        else if (!strcmp(a, "--max-ids"))
            bad = cli_parse_ll(sub, a, v, 2, 1LL << 40, &o.max_ids);
        else if (!strcmp(a, "--components"))
            bad = cli_parse_ll(sub, a, v, 1, 8192, &x) ? -1 : (o.components = (int)x, 0);
        else if (!strcmp(a, "--epochs"))
            bad = cli_parse_ll(sub, a, v, 1, 100000, &x) ? -1 : (o.epochs = (int)x, 0);
        else if (!strcmp(a, "--batch"))
            bad = cli_parse_ll(sub, a, v, 1, 65536, &x) ? -1 : (o.batch = (int)x, 0);
        else if (!strcmp(a, "--seed"))
            bad = cli_parse_ll(sub, a, v, 0, 1LL << 62, &x) ? -1 : (o.seed = (uint64_t)x, 0);
        else if (!strcmp(a, "--members"))
            bad = cli_parse_ll(sub, a, v, 1, PREDICTOR_MAX_MEMBERS, &x) ? -1
                                                                    : (o.members = (int)x, 0);
        else if (!strcmp(a, "--threads"))
            bad = cli_parse_ll(sub, a, v, 1, 256, &x) ? -1 : (o.threads = (int)x, 0);
        else if (!strcmp(a, "--lr"))
            bad = cli_parse_double(sub, a, v, 1e-8, 10, &f) ? -1 : (o.lr = (float)f, 0);
        else if (!strcmp(a, "--wd"))
            bad = cli_parse_double(sub, a, v, 0, 10, &f) ? -1 : (o.weight_decay = (float)f, 0);
        else if (!strcmp(a, "--dropout"))
            bad = cli_parse_double(sub, a, v, 0, 0.95, &f) ? -1 : (o.dropout = (float)f, 0);
        else if (!strcmp(a, "--value-weight"))
            bad = cli_parse_double(sub, a, v, 0, 1e6, &f) ? -1 : (o.value_weight = (float)f, 0);
        else {
            cli_error(sub, "unknown option \"%s\" (see --help)", a);
            return EXIT_USAGE;
        }
        if (bad)
            return EXIT_USAGE;
    }
    if (!o.dataset_path || !o.out_dir) {
        cli_error(sub, "need --dataset DS.sqlite and -o MODEL_DIR (see --help)");
        return EXIT_USAGE;
    }
    if (o.per_tap && o.feature_mask_path) {
        cli_error(sub, "--per-tap and --feature-mask are two reductions: choose one");
        return EXIT_USAGE;
    }
    progress_state ps = {.quiet = quiet};
    predictor_fit_result res;
    o.progress = progress;
    o.progress_text = progress_text;
    o.progress_ctx = &ps;
    o.stop = &stop_requested;
    o.result = &res;
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_sigint;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    char err[1024];
    int rc = predictor_fit(&o, err, sizeof err);
    if (rc < 0) {
        cli_error(sub, "%s", err);
        return EXIT_FAILURE_WORK;
    }
    if (rc == 1) {
        if (!quiet)
            fprintf(stderr, "fit-predictor: stopped; rerun the same command to continue\n");
        return 130;
    }
    if (!quiet)
        fprintf(stderr,
                "fit-predictor: %s: %zu training and %zu validation rows, best epoch %d (val "
                "loss %.4f, selector accuracy %.3f, median R^2 %.3f), %.1f s\n",
                o.out_dir, res.train_rows, res.val_rows, res.best_epoch, res.best_val_loss,
                res.mean_selector_accuracy, res.median_value_r2, res.seconds);
    return EXIT_OK;
}

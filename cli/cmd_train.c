/* imsynth train: fit an MLP with heads to X -> Y (.npy), write a safetensors checkpoint. */
/* before cblas.h, whose complex.h defines I (a field name in shadergraph.h) */
#include "pipeline/pipeline.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "cli/cli.h"
#include "nn/nn.h"

#include <cblas.h> /* after our headers: its <complex.h> defines I */

static const char *const help =
    "usage: imsynth train --x X.npy --y Y.npy --arch SPEC -o MODEL.safetensors [options]\n"
    "\n"
    "Trains an MLP on rows of X (N x IN) to the columns of Y (N x YC) and writes its weights\n"
    "(torch state_dict names) with the optimiser state to a safetensors file that\n"
    "`imsynth infer` and `--resume` read. Every step of a run is bit-identical whatever\n"
    "--threads.\n"
    "\n"
    "--arch \"mlp:IN-H1-...-OUT[,OPTION...]\": linear layers of these widths; each hidden one\n"
    "  is followed by [LayerNorm], the activation and [dropout]. OPTIONs:\n"
    "    relu (default) | gelu | leaky[=SLOPE]   activation (leaky slope 0.01 by default)\n"
    "    ln                                     LayerNorm after each hidden linear layer\n"
    "    dropout=P                              dropout probability P in [0, 1)\n"
    "    res                                    residual blocks: a hidden layer whose input\n"
    "                                           and output widths agree adds its input\n"
    "    init=torch|kaiming|xavier              torch's nn.Linear default (uniform\n"
    "                                           +-1/sqrt(fan_in)), Kaiming normal, Xavier\n"
    "  Names: as a torch nn.Sequential (trunk.0.weight, trunk.0.bias, trunk.1.weight for a\n"
    "  LayerNorm, ...); with res each hidden layer is trunk.<l>.linear / trunk.<l>.norm.\n"
    "--heads SPEC: comma-separated heads, network outputs handed out in this order:\n"
    "    sigmoid:A-B     Y columns A..B (inclusive) regressed through a sigmoid (--loss)\n"
    "    linear:A-B      the same without an activation\n"
    "    softmax:C/K     Y column C holds a class index 0..K-1; K outputs; cross-entropy\n"
    "    softmax:C/K:unit  Y column C holds a selector value v in [0,1] meaning class\n"
    "                    round(v (K-1)) (infer writes k/(K-1) back)\n"
    "    ...@W           loss weight W of that head (default 1)\n"
    "  e.g. \"sigmoid:0-40,softmax:41/9,softmax:42/3\" needs OUT = 41 + 9 + 3 = 53. Default:\n"
    "  linear over all Y columns. The loss is the weighted sum of the heads' losses, each\n"
    "  the mean over the elements (rows for softmax) the mask keeps.\n"
    "\n"
    "options:\n"
    "  --x X.npy, --y Y.npy       inputs and targets (any float/int/bool dtype, 2-D)\n"
    "  --mask M.npy               N x YC of 0/1: an element with 0 contributes neither loss\n"
    "                             nor gradient (its Y may be anything, NaN included); a\n"
    "                             softmax head's mask is its column's\n"
    "  --column-weights W.npy     YC per-column loss weights (1 x YC or YC x 1): a\n"
    "                             regression element's term, or a softmax head's loss, is\n"
    "                             multiplied by its column's weight\n"
    "  --loss mse|l1|thesis       regression heads' loss (default mse); thesis =\n"
    "                             MSE(p, y) + 20 MSE(log(p + 1e-7), log(y + 1e-7))\n"
    "  --optimizer sgd|adam|adamw (default adamw), torch 1.13's update rules\n"
    "  --lr F --wd F              learning rate, weight decay (defaults: torch's)\n"
    "  --momentum F               SGD momentum (default 0)\n"
    "  --beta1 F --beta2 F --eps F  Adam(W) (defaults 0.9, 0.999, 1e-8)\n"
    "  --clip F                   clip the gradients' global L2 norm to F (default off)\n"
    "  --schedule constant|step|cosine  learning-rate schedule (default constant)\n"
    "  --step-size N --gamma F    step: lr gamma^floor(step / N) (defaults 1 epoch, 0.1)\n"
    "  --warmup N                 cosine: linear warm-up over N steps, then cosine to 0\n"
    "  --schedule-steps N         cosine: the step where lr reaches 0 (default: this run's\n"
    "                             steps; set it to the whole plan when a run is resumed)\n"
    "  --batch N                  rows per step (default 64); an epoch's last may be short\n"
    "  --steps N | --epochs E     length of the run (default 1 epoch)\n"
    "  --init W.safetensors       start from these weights (a torch state_dict of the same\n"
    "                             structure, or an imsynth checkpoint)\n"
    "  --resume CKPT.safetensors  continue a run: model, heads, losses and optimiser\n"
    "                             (settings and state) from CKPT, then\n"
    "                             --steps/--epochs more (give the same --seed and --batch\n"
    "                             to continue the same batch order)\n"
    "  --no-shuffle               rows in file order every epoch (default: a permutation\n"
    "                             per epoch from --seed)\n"
    "  --seed S                   initial weights, shuffling and dropout (default 1)\n"
    "  --threads N                worker threads (default: online CPUs)\n"
    "  --val-x VX.npy --val-y VY.npy [--val-mask VM.npy]\n"
    "                             a validation set: its loss (eval mode: no dropout) after\n"
    "                             every epoch and at the end\n"
    "  --log LOSSES.csv           step,epoch,loss,lr,val_loss per step (val_loss empty but\n"
    "                             where computed); the loss curve beside it as LOSSES.svg\n"
    "  -o, --output MODEL.safetensors  the checkpoint (required)\n"
    "  -q, --quiet                no progress on stderr\n";

static int parse_long(const char *sub, const char *opt, const char *s, long long lo,
                      long long hi, long long *v)
{
    char *end;
    errno = 0;
    *v = strtoll(s, &end, 10);
    if (!*s || *end || errno || *v < lo || *v > hi) {
        cli_error(sub, "%s: expected an integer in [%lld, %lld], got \"%s\"", opt, lo, hi, s);
        return -1;
    }
    return 0;
}

static int parse_float(const char *sub, const char *opt, const char *s, double lo, double hi,
                       float *v)
{
    char *end;
    double d = strtod(s, &end);
    if (!*s || *end || !(d >= lo && d <= hi)) {
        cli_error(sub, "%s: expected a number in [%g, %g], got \"%s\"", opt, lo, hi, s);
        return -1;
    }
    *v = (float)d;
    return 0;
}

static double now_seconds(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int write_loss_csv(const char *path, const double *loss, const float *lr,
                          const double *val, long long first_step, long long n, size_t rows,
                          int batch, char *err, size_t errlen)
{
    char tmp[1100];
    if (snprintf(tmp, sizeof tmp, "%s.tmp", path) >= (int)sizeof tmp) {
        snprintf(err, errlen, "%.100s...: path too long", path);
        return -1;
    }
    FILE *f = fopen(tmp, "w");
    if (!f) {
        snprintf(err, errlen, "%s: %s", tmp, strerror(errno));
        return -1;
    }
    fprintf(f, "step,epoch,loss,lr,val_loss\n");
    for (long long i = 0; i < n; i++) {
        long long epoch;
        size_t first;
        int count;
        nn_step_batch(first_step + i, rows, batch, &epoch, &first, &count);
        fprintf(f, "%lld,%lld,%.9g,%.9g,", first_step + i, epoch, loss[i], lr[i]);
        if (!isnan(val[i]))
            fprintf(f, "%.9g", val[i]);
        fputc('\n', f);
    }
    if (fclose(f)) {
        snprintf(err, errlen, "%s: write error: %s", tmp, strerror(errno));
        remove(tmp);
        return -1;
    }
    if (rename(tmp, path)) {
        snprintf(err, errlen, "%s: %s", path, strerror(errno));
        remove(tmp);
        return -1;
    }
    return 0;
}

/* Reads a 2-D array, naming the option in errors. */
static float *read_array(const char *sub, const char *opt, const char *path, size_t *rows,
                         size_t *cols)
{
    float *d;
    char err[1024];
    if (nn_npy_read_f32(path, &d, rows, cols, err, sizeof err)) {
        cli_error(sub, "%s %s", opt, err);
        return NULL;
    }
    return d;
}

int cmd_train(int argc, char **argv)
{
    const char *sub = "train";
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    const char *x_path = NULL, *y_path = NULL, *m_path = NULL, *arch = NULL, *heads_spec = NULL,
               *init = NULL, *resume = NULL, *colw_path = NULL, *val_x_path = NULL,
               *val_y_path = NULL, *val_m_path = NULL, *log_path = NULL, *out_path = NULL;
    int loss_kind = NN_LOSS_MSE, opt_kind = NN_OPT_ADAMW, schedule = NN_SCHEDULE_CONSTANT;
    int shuffle = 1, quiet = 0;
    long long batch = 64, steps = -1, epochs = -1, seed = 1, warmup = 0, step_size = -1,
              schedule_steps = -1;
    long long threads = sysconf(_SC_NPROCESSORS_ONLN);
    float lr = NAN, wd = NAN, momentum = 0, beta1 = 0.9f, beta2 = 0.999f, eps = 1e-8f,
          clip = 0, gamma = 0.1f;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        static const char *const flags[] = {"--no-shuffle", "-q", "--quiet"};
        int is_flag = 0;
        for (size_t k = 0; k < sizeof flags / sizeof flags[0]; k++)
            is_flag |= !strcmp(a, flags[k]);
        if (is_flag) {
            if (!strcmp(a, "--no-shuffle"))
                shuffle = 0;
            else
                quiet = 1;
            continue;
        }
        if (i + 1 >= argc) {
            cli_error(sub, a[0] == '-' ? "%s needs a value (or is unknown; see --help)"
                                       : "unexpected argument \"%s\"",
                      a);
            return EXIT_USAGE;
        }
        const char *v = argv[++i];
        int bad = 0;
        if (!strcmp(a, "--x"))
            x_path = v;
        else if (!strcmp(a, "--y"))
            y_path = v;
        else if (!strcmp(a, "--mask"))
            m_path = v;
        else if (!strcmp(a, "--arch"))
            arch = v;
        else if (!strcmp(a, "--heads"))
            heads_spec = v;
        else if (!strcmp(a, "--val-x"))
            val_x_path = v;
        else if (!strcmp(a, "--val-y"))
            val_y_path = v;
        else if (!strcmp(a, "--val-mask"))
            val_m_path = v;
        else if (!strcmp(a, "--column-weights"))
            colw_path = v;
        else if (!strcmp(a, "--init"))
            init = v;
        else if (!strcmp(a, "--resume"))
            resume = v;
        else if (!strcmp(a, "--log"))
            log_path = v;
        else if (!strcmp(a, "-o") || !strcmp(a, "--output"))
            out_path = v;
        else if (!strcmp(a, "--loss")) {
            loss_kind = nn_loss_parse(v);
            if (loss_kind < 0) {
                cli_error(sub, "--loss: expected mse, l1 or thesis, got \"%s\"", v);
                return EXIT_USAGE;
            }
        } else if (!strcmp(a, "--optimizer")) {
            opt_kind = nn_optimizer_parse(v);
            if (opt_kind < 0) {
                cli_error(sub, "--optimizer: expected sgd, adam or adamw, got \"%s\"", v);
                return EXIT_USAGE;
            }
        } else if (!strcmp(a, "--schedule")) {
            schedule = !strcmp(v, "constant") ? NN_SCHEDULE_CONSTANT
                       : !strcmp(v, "step")   ? NN_SCHEDULE_STEP
                       : !strcmp(v, "cosine") ? NN_SCHEDULE_COSINE
                                              : -1;
            if (schedule < 0) {
                cli_error(sub, "--schedule: expected constant, step or cosine, got \"%s\"", v);
                return EXIT_USAGE;
            }
        } else if (!strcmp(a, "--lr"))
            bad = parse_float(sub, a, v, 0, 1e3, &lr);
        else if (!strcmp(a, "--wd"))
            bad = parse_float(sub, a, v, 0, 1e3, &wd);
        else if (!strcmp(a, "--momentum"))
            bad = parse_float(sub, a, v, 0, 1, &momentum);
        else if (!strcmp(a, "--beta1"))
            bad = parse_float(sub, a, v, 0, 0.999999, &beta1);
        else if (!strcmp(a, "--beta2"))
            bad = parse_float(sub, a, v, 0, 0.999999999, &beta2);
        else if (!strcmp(a, "--eps"))
            bad = parse_float(sub, a, v, 1e-30, 1, &eps);
        else if (!strcmp(a, "--clip"))
            bad = parse_float(sub, a, v, 0, 1e30, &clip);
        else if (!strcmp(a, "--gamma"))
            bad = parse_float(sub, a, v, 0, 1e3, &gamma);
        else if (!strcmp(a, "--batch"))
            bad = parse_long(sub, a, v, 1, 1 << 20, &batch);
        else if (!strcmp(a, "--steps"))
            bad = parse_long(sub, a, v, 0, 1ll << 40, &steps);
        else if (!strcmp(a, "--epochs"))
            bad = parse_long(sub, a, v, 0, 1ll << 30, &epochs);
        else if (!strcmp(a, "--seed"))
            bad = parse_long(sub, a, v, 0, INT64_MAX, &seed);
        else if (!strcmp(a, "--warmup"))
            bad = parse_long(sub, a, v, 0, 1ll << 40, &warmup);
        else if (!strcmp(a, "--schedule-steps"))
            bad = parse_long(sub, a, v, 1, 1ll << 40, &schedule_steps);
        else if (!strcmp(a, "--step-size"))
            bad = parse_long(sub, a, v, 1, 1ll << 40, &step_size);
        else if (!strcmp(a, "--threads"))
            bad = parse_long(sub, a, v, 1, 256, &threads);
        else {
            cli_error(sub, "unknown option \"%s\"", a);
            return EXIT_USAGE;
        }
        if (bad)
            return EXIT_USAGE;
    }
    if (!x_path || !y_path || !out_path || (!arch && !resume)) {
        cli_error(sub, "need --x, --y, --arch (or --resume) and -o (see --help)");
        return EXIT_USAGE;
    }
    if (!val_x_path != !val_y_path || (val_m_path && !val_x_path)) {
        cli_error(sub, "--val-x and --val-y go together (--val-mask with them)");
        return EXIT_USAGE;
    }
    if (steps >= 0 && epochs >= 0) {
        cli_error(sub, "give --steps or --epochs, not both");
        return EXIT_USAGE;
    }
    if (resume && (init || arch || heads_spec)) {
        cli_error(sub, "--resume takes the model from the checkpoint: no --init, --arch or "
                       "--heads with it");
        return EXIT_USAGE;
    }
    // Parse the specs before reading any data: a typo is a usage error.
    char err[4096];
    nn_mlp_config cfg;
    if (arch && !resume && nn_mlp_parse_arch(arch, &cfg, err, sizeof err)) {
        cli_error(sub, "%s", err);
        return EXIT_USAGE;
    }

    int rc = EXIT_FAILURE_WORK;
    size_t n = 0, in = 0, ny = 0, yc = 0, nm = 0, mc = 0;
    float *x = NULL, *y = NULL, *mask = NULL, *colw = NULL, *bx = NULL, *by = NULL, *bm = NULL, *lrs = NULL;
    double *losses = NULL, *val_losses = NULL;
    float *vx = NULL, *vy = NULL, *vm = NULL;
    size_t vn = 0;
    size_t *order = NULL;
    nn_mlp model = {0};
    nn_optimizer opt = {0};
    if (!(x = read_array(sub, "--x", x_path, &n, &in)) ||
        !(y = read_array(sub, "--y", y_path, &ny, &yc)) ||
        (m_path && !(mask = read_array(sub, "--mask", m_path, &nm, &mc))))
        goto done;
    size_t wr = 0, wc = 0;
    if (colw_path && !(colw = read_array(sub, "--column-weights", colw_path, &wr, &wc)))
        goto done;
    if (colw) {
        int ok = wr * wc == yc;
        for (size_t k = 0; ok && k < yc; k++)
            ok = isfinite(colw[k]) && colw[k] >= 0.0f;
        if (!ok) {
            cli_error(sub, "%s: need %zu finite non-negative weights (one per Y column), got %zu "
                      "x %zu",
                      colw_path, yc, wr, wc);
            goto done;
        }
    }
    if (ny != n || (mask && (nm != n || mc != yc))) {
        cli_error(sub, "%s has %zu rows, %s %zu x %zu, %s %zu x %zu: X, Y and the mask need the "
                  "same rows, Y and the mask the same columns",
                  x_path, n, y_path, ny, yc, m_path ? m_path : "(no mask)", nm, mc);
        goto done;
    }
    if (!n) {
        cli_error(sub, "%s: no rows", x_path);
        goto done;
    }
    if (resume) {
        if (nn_mlp_load(&model, &opt, resume, err, sizeof err)) {
            cli_error(sub, "%s", err);
            goto done;
        }
        if (!opt.n) {
            cli_error(sub, "%s: no optimiser state to resume from (a weights-only file: use --init)",
                      resume);
            goto done;
        }
        cfg = model.cfg;
    } else {
        nn_head heads[NN_MAX_HEADS];
        int nh = nn_heads_parse(heads_spec, (int)yc, cfg.width[cfg.n_linear], (nn_loss)loss_kind,
                                heads, NN_MAX_HEADS, err, sizeof err);
        if (nh < 0) {
            cli_error(sub, "%s", err);
            rc = EXIT_USAGE;
            goto done;
        }
        if (nn_mlp_create(&model, &cfg, heads, nh, (uint64_t)seed, err, sizeof err)) {
            cli_error(sub, "%s", err);
            goto done;
        }
        model.y_cols = (int)yc;
        if (init && nn_mlp_load_weights(&model, init, err, sizeof err)) {
            cli_error(sub, "--init %s", err);
            goto done;
        }
    }
    if ((size_t)cfg.width[0] != in || (size_t)model.y_cols != yc) {
        cli_error(sub, "%s is %zu x %zu and %s %zu x %zu but the model takes %d inputs and %d Y "
                  "columns",
                  x_path, n, in, y_path, ny, yc, cfg.width[0], model.y_cols);
        goto done;
    }
    if (nn_mlp_check_data(&model, x, y, mask, n, err, sizeof err)) {
        cli_error(sub, "%s / %s: %s", x_path, y_path, err);
        goto done;
    }
    if (val_x_path) {
        size_t vin, vny, vyc, vnm = 0, vmc = 0;
        if (!(vx = read_array(sub, "--val-x", val_x_path, &vn, &vin)) ||
            !(vy = read_array(sub, "--val-y", val_y_path, &vny, &vyc)) ||
            (val_m_path && !(vm = read_array(sub, "--val-mask", val_m_path, &vnm, &vmc))))
            goto done;
        if (vin != in || vny != vn || vyc != yc || (vm && (vnm != vn || vmc != yc)) || !vn) {
            cli_error(sub, "validation set %s (%zu x %zu), %s (%zu x %zu): need X's %zu and Y's "
                      "%zu columns, the same rows (and the mask Y's shape)",
                      val_x_path, vn, vin, val_y_path, vny, vyc, in, yc);
            goto done;
        }
        if (nn_mlp_check_data(&model, vx, vy, vm, vn, err, sizeof err)) {
            cli_error(sub, "%s / %s: %s", val_x_path, val_y_path, err);
            goto done;
        }
    }
    if ((size_t)batch > n) /* one batch is the whole set: allocate no more than that */
        batch = (long long)n;
    long long per_epoch = (long long)((n + (size_t)batch - 1) / (size_t)batch);
    long long run = steps >= 0 ? steps : epochs >= 0 ? epochs * per_epoch : per_epoch;
    if (!resume) {
        nn_optimizer_config oc = nn_optimizer_defaults((nn_optimizer_kind)opt_kind);
        if (!isnan(lr))
            oc.lr = lr;
        if (!isnan(wd))
            oc.weight_decay = wd;
        oc.momentum = momentum;
        oc.beta1 = beta1;
        oc.beta2 = beta2;
        oc.eps = eps;
        oc.clip_norm = clip;
        oc.schedule = (nn_schedule_kind)schedule;
        oc.warmup_steps = warmup;
        oc.total_steps = schedule_steps > 0 ? schedule_steps : run;
        oc.step_size = step_size > 0 ? step_size : per_epoch;
        oc.gamma = gamma;
        if (nn_optimizer_init(&opt, &oc, model.n_floats)) {
            cli_error(sub, "out of memory for the optimiser");
            goto done;
        }
    }
    model.threads = (int)threads;
    model.column_weights = colw;
    // Our workers each run single-threaded sgemms in fixed pieces (bit-identical results);
    // OpenBLAS's own threads would change the sums' order and fight ours for the cores.
    openblas_set_num_threads(1);
    if (nn_blas_warning() && !getenv("OPENBLAS_CORETYPE"))
        cli_error(sub, "warning: %s", nn_blas_warning());

    bx = malloc((size_t)batch * in * sizeof(float));
    by = malloc((size_t)batch * yc * sizeof(float));
    bm = mask ? malloc((size_t)batch * yc * sizeof(float)) : NULL;
    order = malloc(n * sizeof *order);
    losses = malloc((size_t)(run ? run : 1) * sizeof *losses);
    val_losses = malloc((size_t)(run ? run : 1) * sizeof *val_losses);
    lrs = malloc((size_t)(run ? run : 1) * sizeof *lrs);
    if (!bx || !by || (mask && !bm) || !order || !losses || !val_losses || !lrs) {
        cli_error(sub, "out of memory");
        goto done;
    }
    if (!quiet)
        fprintf(stderr, "train: %zu rows, %zu parameters, %lld steps of %lld (%lld per epoch)\n",
                n, model.n_floats, run, batch, per_epoch);
    long long first_step = opt.step, order_epoch = -1;
    double t0 = now_seconds(), last_report = t0, recent = 0;
    long long recent_n = 0;
    for (long long s = 0; s < run; s++) {
        long long step = first_step + s, epoch;
        size_t first;
        int count;
        nn_step_batch(step, n, (int)batch, &epoch, &first, &count);
        if (epoch != order_epoch) {
            nn_epoch_order((uint64_t)seed, epoch, shuffle, n, order);
            order_epoch = epoch;
        }
        nn_gather_rows(bx, x, in, order + first, (size_t)count);
        nn_gather_rows(by, y, yc, order + first, (size_t)count);
        if (mask)
            nn_gather_rows(bm, mask, yc, order + first, (size_t)count);
        lrs[s] = nn_schedule_lr(&opt.cfg, opt.step);
        if (nn_mlp_train_step(&model, &opt, bx, by, bm, count, &losses[s])) {
            cli_error(sub, "out of memory at step %lld", step);
            goto done;
        }
        if (!isfinite(losses[s])) {
            cli_error(sub, "step %lld: the loss is %g (diverged: lower --lr or add --clip)", step,
                      losses[s]);
            goto done;
        }
        // validation (eval mode, whole set at once) after each epoch's last step
        val_losses[s] = NAN;
        long long next_epoch;
        size_t next_first;
        int next_count;
        nn_step_batch(step + 1, n, (int)batch, &next_epoch, &next_first, &next_count);
        if (vx && (next_epoch != epoch || s == run - 1)) {
            if (nn_mlp_evaluate(&model, vx, vy, vm, (int)vn, &val_losses[s])) {
                cli_error(sub, "out of memory evaluating %s", val_x_path);
                goto done;
            }
            if (!quiet)
                fprintf(stderr, "epoch %lld: validation loss %.6g\n", epoch, val_losses[s]);
        }
        recent += losses[s];
        recent_n++;
        double t = now_seconds();
        if (!quiet && (t - last_report >= 1.0 || s == run - 1)) {
            double per_step = (t - t0) / (double)(s + 1);
            fprintf(stderr,
                    "step %lld/%lld  epoch %lld  loss %.6g (mean of last %lld)  lr %.3g  "
                    "%.0f samples/s  ETA %.0f s\n",
                    s + 1, run, epoch, recent / (double)recent_n, recent_n, lrs[s],
                    (double)batch / per_step, per_step * (double)(run - s - 1));
            last_report = t;
            recent = 0;
            recent_n = 0;
        }
    }
    if (nn_mlp_save(&model, &opt, out_path, err, sizeof err)) {
        cli_error(sub, "%s", err);
        goto done;
    }
    if (log_path) {
        char svg[1100];
        size_t len = strlen(log_path);
        if (len > 4 && !strcmp(log_path + len - 4, ".csv"))
            snprintf(svg, sizeof svg, "%.*s.svg", (int)(len - 4), log_path);
        else
            snprintf(svg, sizeof svg, "%s.svg", log_path);
        if (write_loss_csv(log_path, losses, lrs, val_losses, first_step, run, n, (int)batch,
                           err, sizeof err) ||
            pipeline_write_loss_svg(svg, losses, val_losses, run, "step", err, sizeof err)) {
            cli_error(sub, "%s", err);
            goto done;
        }
    }
    printf("%s: %s, %lld steps (now at step %lld), final loss %.6g\n", out_path, arch ? arch : resume,
           run, opt.step, run ? losses[run - 1] : NAN);
    rc = EXIT_OK;
done:
    nn_mlp_free(&model);
    nn_optimizer_free(&opt);
    free(x);
    free(y);
    free(mask);
    free(colw);
    free(bx);
    free(by);
    free(bm);
    free(order);
    free(losses);
    free(val_losses);
    free(vx);
    free(vy);
    free(vm);
    free(lrs);
    return rc;
}

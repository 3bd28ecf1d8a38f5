/*
 * Training the predictor (predictor.c says what it is): read a dataset, fit the input
 * transform and PCA, train the MLP with masked losses, keep the epoch of least validation
 * loss, write the model directory.
 *
 * Storage of a run (SQLite's rule: a reader sees the old state or the new one, never half):
 *   OUT.partial/transform.safetensors   fitted once; a resumed run reads it back
 *   OUT.partial/checkpoint-E.safetensors  weights + optimiser after epoch E (the last)
 *   OUT.partial/best-B.safetensors      weights of the best epoch B so far
 *   OUT.partial/state.json              the run's settings, epochs done, losses so far
 * every file written to a temporary name and renamed, the state last: a kill at any moment
 * leaves a state that names files that exist. The finished model directory is renamed to
 * OUT in one step.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dirent.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "pipeline/pipeline_internal.h"

#include <cblas.h> /* after shadergraph.h: its complex.h defines I */

void predictor_fit_defaults(predictor_fit_options *o)
{
    memset(o, 0, sizeof *o);
    o->val_fraction = 0.05;
    o->components = 256;
    o->hidden = "1024-1024";
    o->epochs = 60;
    o->batch = 128;
    o->lr = 1e-3f;
    o->weight_decay = 1e-4f;
    o->dropout = 0.5f;
    o->value_weight = 10.0f;
    o->seed = 1;
}

/* One side of the split: rows of descriptors, targets and masks. */
typedef struct rowset {
    size_t n, cap;
    size_t hint;      /* the first allocation's rows: the dataset's row count, so that the
                       * descriptors (rows x 38,808 floats: 7.8 GB at 50k) are allocated
                       * once, not doubled through realloc (which needs old + new at once) */
    float *X;         /* (n, d) descriptors, then their transform */
    float *params;    /* (n, n_params) */
    uint8_t *active;  /* (n, n_params) */
    long long *ids;
    float *S;         /* (n, TEXSTATS_N) texture statistics (only with o->texstats),
                       * then standardised */
    float *Z;         /* (n, k) reduced descriptors (the catalogue's) */
    float *input;         /* (n, k + s) the network's inputs: Z, then S when used */
    float *Y, *M;     /* (n, yc) targets and masks */
} rowset;

static void rowset_free(rowset *r)
{
    free(r->X);
    free(r->params);
    free(r->active);
    free(r->ids);
    free(r->S);
    free(r->Z);
    free(r->input);
    free(r->Y);
    free(r->M);
    memset(r, 0, sizeof *r);
}

static int rowset_push(rowset *r, const dataset_row *row, const float *stats, size_t d, int np)
{
    if (r->n == r->cap) {
        size_t cap = r->cap ? r->cap * 2 : r->hint ? r->hint : 1024;
        float *X = realloc(r->X, cap * d * sizeof(float));
        if (X)
            r->X = X;
        float *P = realloc(r->params, cap * (size_t)np * sizeof(float));
        if (P)
            r->params = P;
        uint8_t *A = realloc(r->active, cap * (size_t)np);
        if (A)
            r->active = A;
        long long *ids = realloc(r->ids, cap * sizeof(long long));
        if (ids)
            r->ids = ids;
        float *S = stats ? realloc(r->S, cap * TEXSTATS_N * sizeof(float)) : r->S;
        if (S)
            r->S = S;
        if (!X || !P || !A || !ids || (stats && !S))
            return -1;
        r->cap = cap;
    }
    memcpy(r->X + r->n * d, row->descriptor, d * sizeof(float));
    memcpy(r->params + r->n * (size_t)np, row->params, (size_t)np * sizeof(float));
    memcpy(r->active + r->n * (size_t)np, row->active, (size_t)np);
    if (stats)
        memcpy(r->S + r->n * TEXSTATS_N, stats, TEXSTATS_N * sizeof(float));
    r->ids[r->n++] = row->id;
    return 0;
}

/* Whether id is held out for validation: a hash of the id, so every view of a sample lands
 * on the same side and the split does not depend on the dataset's order or size. */
static int is_validation_id(long long id, double fraction)
{
    return (double)(nn_mix64((uint64_t)id ^ 0x76616c6964617465ull) >> 11) * 0x1p-53 < fraction;
}

/* Reads a dataset's rows; with fraction >= 0 splits them into train and val by id (else
 * all into train). Checks the descriptor is stored and every value finite. With texstats,
 * also the texture statistics of every row's stored render. */
static int read_rows(const char *path, double fraction, long long max_ids, int texstats,
                     rowset *train,
                     rowset *val, size_t *d_out, char ***names_out, int *np_out,
                     char **config_out, char *err, size_t errlen)
{
    dataset *ds = dataset_open(path, err, errlen);
    if (!ds)
        return -1;
    dataset_info info;
    int rc = -1;
    dataset_iter *it = NULL;
    if (dataset_get_info(ds, &info, err, errlen)) {
        dataset_close(ds);
        return -1;
    }
    if (!info.descriptor_size) {
        pipeline_error(err, errlen, "%s: the dataset stores no descriptor (made with "
                                    "--descriptor none: run imsynth dataset describe first)",
                       path);
        goto done;
    }
    if (*d_out && *d_out != info.descriptor_size) {
        pipeline_error(err, errlen, "%s: descriptors of %zu values, the training set's have %zu",
                       path, info.descriptor_size, *d_out);
        goto done;
    }
    *d_out = info.descriptor_size;
    int np = info.n_params;
    if (names_out) {
        const char *const *names = dataset_param_names(ds);
        char **copy = calloc((size_t)np, sizeof *copy);
        for (int i = 0; copy && i < np; i++)
            copy[i] = strdup(names[i]);
        *names_out = copy;
        *np_out = np;
    } else if (np != *np_out) {
        pipeline_error(err, errlen, "%s: %d parameters, the training set has %d", path, np,
                       *np_out);
        goto done;
    }
    if (config_out && !(*config_out = strdup(info.config_json))) {
        pipeline_error(err, errlen, "out of memory");
        goto done;
    }
    if (!(it = dataset_iter_new(ds, 1, texstats, err, errlen)))
        goto done;
    if (!train->cap)
        train->hint = (size_t)info.rows;
    if (val && !val->cap)
        val->hint = (size_t)(info.rows * (fraction > 0 ? fraction : 0) * 1.5) + 64;
    dataset_row row;
    int got;
    long long ids_seen = 0, last_id = -1;
    while ((got = dataset_iter_next(it, &row, err, errlen)) == 1) {
        int to_val = fraction >= 0 && is_validation_id(row.id, fraction);
        if (row.id != last_id) {
            last_id = row.id;
            ids_seen += !to_val;
        }
        // max_ids limits the training ids only: the validation rows stay the same whatever
        // the training size, so a learning curve compares like with like
        if (max_ids > 0 && !to_val && ids_seen > max_ids)
            continue;
        for (size_t j = 0; j < info.descriptor_size; j++)
            if (!isfinite(row.descriptor[j])) {
                pipeline_error(err, errlen, "%s: id %lld view %d: descriptor value %zu is not "
                                            "finite",
                               path, row.id, row.view, j);
                goto done;
            }
        float stats[TEXSTATS_N];
        if (texstats) {
            char msg[512];
            if (!row.img.pixels) {
                pipeline_error(err, errlen, "%s: id %lld view %d: no render stored (made with "
                                            "--images none), so no texture statistics",
                               path, row.id, row.view);
                goto done;
            }
            if (pipeline_texstats(&row.img, stats, msg, sizeof msg)) {
                pipeline_error(err, errlen, "%s: id %lld view %d: %s", path, row.id, row.view,
                               msg);
                goto done;
            }
        }
        rowset *dst = to_val ? val : train;
        if (rowset_push(dst, &row, texstats ? stats : NULL, info.descriptor_size, np)) {
            pipeline_error(err, errlen, "%s: out of memory at row %zu", path,
                           train->n + (val ? val->n : 0));
            goto done;
        }
    }
    rc = got < 0 ? -1 : 0;
done:
    dataset_iter_free(it);
    dataset_info_free(&info);
    dataset_close(ds);
    return rc;
}

/*
 * Reductions other than one PCA of every value. Each fits PCAs on subsets of the columns
 * and scatters them into the same k x d basis a global PCA gives, zero outside each
 * component's columns, so the model's format and the prediction path do not change. X
 * (n x d) is standardised, so every subset is centred.
 */

/* kt components of X's columns cols[0..w) (ascending) into rows comp[0..kt) of a k x d
 * basis (zero elsewhere) and var[0..kt). */
static int pca_fit_columns(const float *X, size_t n, size_t d, const uint32_t *cols, size_t w,
                           int kt, uint64_t seed, int threads, float *comp, float *var,
                           char *msg, size_t len)
{
    if ((size_t)kt > w || (size_t)kt >= n)
        return pipeline_error(msg, len, "%d components from %zu values and %zu rows: at most "
                                        "min(rows - 1, values)",
                              kt, w, n);
    float *block = malloc(n * w * sizeof *block), *bc = malloc((size_t)kt * w * sizeof *bc);
    int rc = !block || !bc ? pipeline_error(msg, len, "out of memory for %zu x %zu values", n, w)
                           : 0;
    for (size_t i = 0; !rc && i < n; i++)
        for (size_t j = 0; j < w; j++)
            block[i * w + j] = X[i * d + cols[j]];
    if (!rc)
        rc = nn_pca_fit(block, (int)n, (int)w, kt, 2, seed, threads, bc, var, msg, len);
    for (int c = 0; !rc && c < kt; c++)
        for (size_t j = 0; j < w; j++)
            comp[(size_t)c * d + cols[j]] = bc[(size_t)c * w + j];
    free(block);
    free(bc);
    return rc;
}

/*
 * Per tap. The descriptor concatenates the Grams of a few taps of very different sizes
 * (MobileNetV2's: conv1's 528 values, the colours, beside block_6_expand's 18,528), and one
 * PCA of all the standardised values spends its components where most values are, on the
 * deep taps. Here each tap gets an equal share of the k components (the first k % taps get
 * one more), fitted on its own columns. (Measured: EVALUATION.md, "the reduction".)
 */
static int pca_fit_per_tap(const float *X, size_t n, size_t d, const char *config, int k,
                           uint64_t seed, int threads, float *comp, float *var, char *msg,
                           size_t len)
{
    cJSON *cfg = cJSON_Parse(config);
    const cJSON *feat = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(cfg, "descriptor"), "features");
    datagen_descriptor kind =
        pipeline_descriptor_kind_named(cJSON_IsString(feat) ? feat->valuestring : NULL);
    cJSON_Delete(cfg);
    if (kind == DATAGEN_DESC_NONE)
        return pipeline_error(msg, len, "per-tap reduction: the dataset's descriptor is unknown");
    pipeline_descriptor *pd = pipeline_descriptor_create(kind, msg, len);
    if (!pd)
        return -1;
    size_t off[65];
    int taps = pipeline_descriptor_layers(pd, off);
    pipeline_descriptor_free(pd);
    if (off[taps] != d)
        return pipeline_error(msg, len, "per-tap reduction: the dataset's descriptors have %zu "
                                        "values, its taps %zu",
                              d, off[taps]);
    if (k < taps)
        return pipeline_error(msg, len, "per-tap reduction: %d components for %d taps", k, taps);
    uint32_t *cols = malloc(d * sizeof *cols);
    if (!cols)
        return pipeline_error(msg, len, "out of memory");
    memset(comp, 0, (size_t)k * d * sizeof *comp);
    int first = 0, rc = 0;
    for (int t = 0; t < taps && !rc; t++) {
        size_t w = off[t + 1] - off[t];
        int kt = k / taps + (t < k % taps);
        for (size_t j = 0; j < w; j++)
            cols[j] = (uint32_t)(off[t] + j);
        char why[512];
        if (pca_fit_columns(X, n, d, cols, w, kt, seed + (uint64_t)t, threads,
                            comp + (size_t)first * d, var + first, why, sizeof why))
            rc = pipeline_error(msg, len, "per-tap reduction, tap %d: %s", t, why);
        first += kt;
    }
    free(cols);
    return rc;
}

/*
 * Feature mask. A 1 x d 0/1 mask (`imsynth forest importance --top-k K -o MASK.npy`: the
 * features a random forest found most useful for the parameters, as the thesis reduced its
 * inputs) keeps its columns; the PCA is fitted on those alone. The forest must have been
 * fitted on training rows only, or the mask has seen the validation set.
 */
/* MASK.npy: d values, each 0 or 1, at least k ones. *sha gets the file's SHA-256 (the run's
 * settings name it, so that a resumed run uses the same mask). */
static int read_feature_mask(const char *path, size_t d, int k, float **mask, char sha[65],
                             char *err, size_t errlen)
{
    size_t r, c;
    char msg[768];
    if (pipeline_file_sha256(path, sha, err, errlen))
        return -1;
    if (nn_npy_read_f32(path, mask, &r, &c, msg, sizeof msg))
        return pipeline_error(err, errlen, "--feature-mask: %s", msg);
    size_t ones = 0;
    int rc = 0;
    if (r * c != d)
        rc = pipeline_error(err, errlen, "%s: %zu values, the descriptors have %zu", path, r * c,
                            d);
    for (size_t j = 0; !rc && j < d; j++) {
        if ((*mask)[j] != 0.0f && (*mask)[j] != 1.0f)
            rc = pipeline_error(err, errlen, "%s: value %zu is %g, not 0 or 1", path, j,
                                (double)(*mask)[j]);
        ones += (*mask)[j] == 1.0f;
    }
    if (!rc && ones < (size_t)k)
        rc = pipeline_error(err, errlen, "%s: keeps %zu features, fewer than the %d components",
                            path, ones, k);
    if (rc) {
        free(*mask);
        *mask = NULL;
    }
    return rc;
}

static int pca_fit_masked(const float *X, size_t n, size_t d, const float *mask, int k,
                          uint64_t seed, int threads, float *comp, float *var, char *msg,
                          size_t len)
{
    uint32_t *cols = malloc(d * sizeof *cols);
    if (!cols)
        return pipeline_error(msg, len, "out of memory");
    size_t w = 0;
    for (size_t j = 0; j < d; j++)
        if (mask[j] != 0.0f)
            cols[w++] = (uint32_t)j;
    memset(comp, 0, (size_t)k * d * sizeof *comp);
    int rc = pca_fit_columns(X, n, d, cols, w, k, seed, threads, comp, var, msg, len);
    free(cols);
    return rc;
}

/* The parts of two dataset configs that must agree for a validation set: the super-shader
 * and the descriptor (the preset, augmentation and ids may differ). */
static int configs_compatible(const char *a, const char *b, char *why, size_t len)
{
    cJSON *ja = cJSON_Parse(a), *jb = cJSON_Parse(b);
    int ok = ja && jb;
    const char *keys[] = {"supershader_sha256", "descriptor", "blender"};
    for (int i = 0; ok && i < 3; i++) {
        if (!cJSON_Compare(cJSON_GetObjectItemCaseSensitive(ja, keys[i]),
                           cJSON_GetObjectItemCaseSensitive(jb, keys[i]), 1)) {
            snprintf(why, len, "\"%s\" differs", keys[i]);
            ok = 0;
        }
    }
    cJSON_Delete(ja);
    cJSON_Delete(jb);
    return ok;
}

/* ---------------------------------------------------------------- the run's files -- */

static int mkdir_p1(const char *dir, char *err, size_t errlen)
{
    if (mkdir(dir, 0777) && errno != EEXIST)
        return pipeline_error(err, errlen, "%s: cannot create: %s", dir, strerror(errno));
    return 0;
}

/* Removes the files of a run directory (a run makes no folders), keeping the directory:
 * all of them, or only_run_files: the checkpoints and best weights of run_file, which a
 * kill between writing a new one and unlinking the old can leave. */
static void clear_dir(const char *dir, int only_run_files)
{
    DIR *d = opendir(dir);
    if (d) {
        struct dirent *e;
        char path[1400];
        while ((e = readdir(d))) {
            const char *n = e->d_name;
            if (!strcmp(n, ".") || !strcmp(n, ".."))
                continue;
            if (only_run_files && strncmp(n, "checkpoint-", 11) && strncmp(n, "best-", 5) &&
                strncmp(n, "member", 6))
                continue;
            snprintf(path, sizeof path, "%s/%s", dir, n);
            unlink(path);
        }
        closedir(d);
    }
}

/* The checkpoint after `epochs` epochs and the best weights as of then carry the epoch in
 * their names: state.json names the ones it goes with, so a kill between writing them and
 * writing the state leaves the state's own files untouched. Member 0's names are those of
 * a single network's run. */
static void run_file(char *out, size_t len, const char *dir, const char *what, int member,
                     int epoch)
{
    if (member)
        snprintf(out, len, "%s/member%d-%s-%d.safetensors", dir, member + 1, what, epoch);
    else
        snprintf(out, len, "%s/%s-%d.safetensors", dir, what, epoch);
}

/* A finished member's weights, as the model directory keeps them: network.safetensors,
 * then network-2.safetensors, ... (model.json's "network"."members" lists them). */
static void member_name(char *out, size_t len, int member)
{
    if (member)
        snprintf(out, len, "network-%d.safetensors", member + 1);
    else
        snprintf(out, len, "network.safetensors");
}

static void member_file(char *out, size_t len, const char *dir, int member)
{
    char name[64];
    member_name(name, sizeof name, member);
    snprintf(out, len, "%s/%s", dir, name);
}

static int write_transform(const char *path, const float *scale, const float *mean,
                           const float *std, const float *comp, const float *var,
                           const float *mean_params, const float *stats_mean,
                           const float *stats_std, size_t d, int k, int np, int half,
                           char *err, size_t errlen)
{
    nn_tensor_out t[8] = {
        {"signed_log.scale", 1, {(int64_t)d}, scale},
        {"standardise.mean", 1, {(int64_t)d}, mean},
        {"standardise.std", 1, {(int64_t)d}, std},
        {"pca.components", 2, {k, (int64_t)d}, comp, half ? NN_F16 : NN_F32},
        {"pca.variance", 1, {k}, var},
        {"params.mean", 1, {np}, mean_params},
        {"texstats.mean", 1, {TEXSTATS_N}, stats_mean},
        {"texstats.std", 1, {TEXSTATS_N}, stats_std},
    };
    const char *meta[] = {"format", "imsynth-model-transform/1"};
    return nn_safetensors_write(path, t, stats_mean ? 8 : 6, meta, 1, err, errlen);
}

/* mean and std (TEXSTATS_N each) of the statistics S (n rows), a std of 0 taken as 1. */
static void texstats_standardisation(const float *S, size_t n, float *mean, float *std)
{
    for (int c = 0; c < TEXSTATS_N; c++) {
        double s = 0, ss = 0;
        for (size_t i = 0; i < n; i++)
            s += S[i * TEXSTATS_N + (size_t)c];
        double m = s / (double)n;
        for (size_t i = 0; i < n; i++) {
            double v = S[i * TEXSTATS_N + (size_t)c] - m;
            ss += v * v;
        }
        double sd = sqrt(ss / (double)n);
        mean[c] = (float)m;
        std[c] = sd > 0 ? (float)sd : 1.0f;
    }
}

/* r->input (n, nin) = each row's reduced descriptor, then (ns > 0) its standardised
 * texture statistics, then (nin > k + ns: a conditional model) zeros where a combination's
 * one-hot classes go: what the network reads, as predictor_predict forms it. */
static void network_inputs(rowset *r, int k, int ns, int nin, const float *stats_mean,
                           const float *stats_std)
{
    for (size_t i = 0; i < r->n; i++) {
        float *x = r->input + i * (size_t)nin;
        memset(x, 0, (size_t)nin * sizeof(float));
        memcpy(x, r->Z + i * (size_t)k, (size_t)k * sizeof(float));
        if (ns)
            predictor_texstats_standardise(x + k, r->S + i * TEXSTATS_N, stats_mean, stats_std);
    }
}

/* A conditional model sees every row twice. Rows [0, n) of x (n, nin), y and m (n, yc) are
 * the rows as read, their one-hot part zero: there the network predicts the selectors and
 * the values with no combination given. This writes rows [n, 2n): the same rows given their
 * own combination (the true classes, also where a selector is inactive: they are the
 * sample's), the selectors' masks zero, so that there only the values are learnt (the
 * classes are in the input). kin = the inputs before the one-hot part. */
static void pair_with_combination(const param_layout *L, int kin, int nin, float *x, float *y,
                                  float *m, size_t n)
{
    size_t yc = (size_t)(L->n_values + L->n_selectors);
    for (size_t r = 0; r < n; r++) {
        float *x2 = x + (n + r) * (size_t)nin, *y2 = y + (n + r) * yc, *m2 = m + (n + r) * yc;
        memcpy(x2, x + r * (size_t)nin, (size_t)kin * sizeof(float));
        predictor_layout_onehot(L, y + r * yc + L->n_values, x2 + kin);
        memcpy(y2, y + r * yc, yc * sizeof(float));
        memcpy(m2, m + r * yc, (size_t)L->n_values * sizeof(float));
        memset(m2 + L->n_values, 0, (size_t)L->n_selectors * sizeof(float));
    }
}

static int write_catalogue(const char *path, const rowset *full, int k, int np, int half,
                           long long max_rows, char *err, size_t errlen)
{
    rowset first = *full; /* the first max_rows rows (rows are in id order) */
    if (max_rows > 0 && (size_t)max_rows < first.n)
        first.n = (size_t)max_rows;
    const rowset *r = &first;
    float *lo = malloc((r->n ? r->n : 1) * sizeof(float)),
          *hi = malloc((r->n ? r->n : 1) * sizeof(float));
    if (!lo || !hi) {
        free(lo);
        free(hi);
        return pipeline_error(err, errlen, "out of memory");
    }
    // ids in two exactly representable floats (safetensors via nn holds F32 only)
    for (size_t i = 0; i < r->n; i++) {
        lo[i] = (float)(r->ids[i] & ((1ll << 24) - 1));
        hi[i] = (float)(r->ids[i] >> 24);
    }
    nn_tensor_out t[4] = {
        {"catalogue.z", 2, {(int64_t)r->n, k}, r->Z, half ? NN_F16 : NN_F32},
        {"catalogue.params", 2, {(int64_t)r->n, np}, r->params},
        {"catalogue.id_low24", 1, {(int64_t)r->n}, lo},
        {"catalogue.id_high", 1, {(int64_t)r->n}, hi},
    };
    const char *meta[] = {"format", "imsynth-model-catalogue/1"};
    int rc = nn_safetensors_write(path, t, 4, meta, 1, err, errlen);
    free(lo);
    free(hi);
    return rc;
}

/* ---------------------------------------------------------------- metrics ---------- */

/* Validation figures of the network on a rowset: per selector the accuracy where active,
 * per value R^2 where active (SST about the training mean). */
typedef struct fit_metrics {
    double selector_acc[NN_MAX_HEADS], selector_majority[NN_MAX_HEADS];
    double value_r2[2 * NN_MAX_HEADS];
    double mean_selector_acc, median_value_r2;
} fit_metrics;

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The metrics of n_nets networks' averaged outputs (one network: its own). input: the
 * networks' inputs of val's rows (val->input, or the rows given their combination for a
 * conditional model's R^2 given the selectors). */
static int compute_metrics(nn_mlp *nets, int n_nets, const param_layout *L, const rowset *val,
                           const float *input, const rowset *train, const float *mean_y,
                           fit_metrics *fm)
{
    memset(fm, 0, sizeof *fm);
    int yc = L->n_values + L->n_selectors, out = nets[0].cfg.width[nets[0].cfg.n_linear];
    float *pred = malloc((val->n ? val->n : 1) * (size_t)yc * sizeof(float));
    float *mean = malloc((size_t)256 * (size_t)out * sizeof(float));
    int bad = !pred || !mean;
    for (size_t i = 0; !bad && i < val->n; i += 256) {
        int B = val->n - i < 256 ? (int)(val->n - i) : 256;
        bad = nn_mlp_forward_mean(nets, n_nets, input + i * (size_t)nets[0].cfg.width[0], B,
                                  mean);
        if (!bad)
            nn_mlp_decode(&nets[0], mean, B, pred + i * (size_t)yc);
    }
    free(mean);
    if (bad) {
        free(pred);
        return -1;
    }
    double r2s[2 * NN_MAX_HEADS];
    int nr2 = 0;
    for (int c = 0; c < yc; c++) {
        int is_sel = c >= L->n_values;
        double hit = 0, cnt = 0, sse = 0, sst = 0;
        for (size_t i = 0; i < val->n; i++) {
            if (val->M[i * (size_t)yc + c] == 0)
                continue;
            double y = val->Y[i * (size_t)yc + c], p = pred[i * (size_t)yc + c];
            cnt++;
            hit += is_sel && p == y;
            sse += (p - y) * (p - y);
            sst += (y - mean_y[c]) * (y - mean_y[c]);
        }
        if (is_sel) {
            int s = c - L->n_values;
            fm->selector_acc[s] = cnt ? hit / cnt : NAN;
            // majority class among the training rows where the selector is active
            double counts[64] = {0}, total = 0;
            for (size_t i = 0; i < train->n; i++)
                if (train->M[i * (size_t)yc + c] != 0) {
                    int k = (int)train->Y[i * (size_t)yc + c];
                    if (k >= 0 && k < 64) {
                        counts[k]++;
                        total++;
                    }
                }
            double best = 0;
            for (int k = 0; k < 64; k++)
                best = fmax(best, counts[k]);
            fm->selector_majority[s] = total ? best / total : NAN;
            fm->mean_selector_acc += fm->selector_acc[s] / L->n_selectors;
        } else {
            fm->value_r2[c] = sst > 0 ? 1 - sse / sst : NAN;
            if (isfinite(fm->value_r2[c]))
                r2s[nr2++] = fm->value_r2[c];
        }
    }
    qsort(r2s, (size_t)nr2, sizeof *r2s, cmp_double);
    fm->median_value_r2 = nr2 ? (nr2 % 2 ? r2s[nr2 / 2] : (r2s[nr2 / 2 - 1] + r2s[nr2 / 2]) / 2)
                              : NAN;
    free(pred);
    return 0;
}

/* ---------------------------------------------------------------- the run ---------- */

/* The settings that define a run (a resumed run must have the same). */
static char *run_settings_json(const predictor_fit_options *o, const char *arch,
                               const char *train_config, size_t n_train, size_t n_val,
                               const char *mask_sha)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "dataset", o->dataset_path);
    cJSON_AddStringToObject(j, "val_dataset", o->val_dataset_path ? o->val_dataset_path : "");
    cJSON_AddNumberToObject(j, "val_fraction", o->val_dataset_path ? 0 : o->val_fraction);
    cJSON_AddNumberToObject(j, "max_ids", (double)o->max_ids);
    cJSON_AddNumberToObject(j, "train_rows", (double)n_train);
    cJSON_AddNumberToObject(j, "val_rows", (double)n_val);
    cJSON_AddNumberToObject(j, "components", o->components);
    if (o->texstats)
        cJSON_AddNumberToObject(j, "texstats", TEXSTATS_N);
    if (o->per_tap)
        cJSON_AddStringToObject(j, "reduction", "per-tap");
    if (*mask_sha) {
        cJSON_AddStringToObject(j, "reduction", "feature mask");
        cJSON_AddStringToObject(j, "feature_mask", o->feature_mask_path);
        cJSON_AddStringToObject(j, "feature_mask_sha256", mask_sha);
    }
    if (o->half)
        cJSON_AddBoolToObject(j, "half", 1);
    if (o->conditional)
        cJSON_AddBoolToObject(j, "conditional", 1);
    if (o->catalogue)
        cJSON_AddNumberToObject(j, "catalogue", (double)o->catalogue);
    cJSON_AddStringToObject(j, "arch", arch);
    cJSON_AddNumberToObject(j, "epochs", o->epochs);
    cJSON_AddNumberToObject(j, "batch", o->batch);
    cJSON_AddNumberToObject(j, "lr", o->lr);
    cJSON_AddNumberToObject(j, "weight_decay", o->weight_decay);
    cJSON_AddNumberToObject(j, "value_weight", o->value_weight);
    cJSON_AddNumberToObject(j, "seed", (double)o->seed);
    if (o->members > 1)
        cJSON_AddNumberToObject(j, "members", o->members);
    cJSON_AddStringToObject(j, "optimizer", "adamw, cosine schedule, 1 epoch warm-up");
    cJSON *cfg = cJSON_Parse(train_config);
    cJSON_AddItemToObject(j, "dataset_config", cfg ? cfg : cJSON_CreateNull());
    char *s = cJSON_PrintUnformatted(j);
    cJSON_Delete(j);
    return s;
}

static int write_losses(const char *dir, const double *train_loss, const double *val_loss,
                        const double *acc, const double *r2, int n, char *err, size_t errlen)
{
    size_t cap = 128 + (size_t)n * 128;
    char *csv = malloc(cap), path[1200];
    if (!csv)
        return pipeline_error(err, errlen, "out of memory");
    size_t len = (size_t)snprintf(csv, cap, "epoch,train_loss,val_loss,val_selector_accuracy,"
                                            "val_median_r2\n");
    for (int e = 0; e < n; e++)
        len += (size_t)snprintf(csv + len, cap - len, "%d,%.9g,%.9g,%.6g,%.6g\n", e + 1,
                                train_loss[e], val_loss[e], acc[e], r2[e]);
    int rc = predictor_path_join(path, sizeof path, dir, "losses.csv", err, errlen) ||
             pipeline_write_text_atomic(path, csv, err, errlen);
    free(csv);
    if (rc)
        return -1;
    if (predictor_path_join(path, sizeof path, dir, "loss.svg", err, errlen))
        return -1;
    return pipeline_write_loss_svg(path, train_loss, val_loss, n, "epoch", err, errlen);
}

typedef struct run_state {
    int member;                /* the network being trained; those before it are finished */
    int epochs_done, best_epoch; /* the member's */
    double best_val;
    double *train_loss, *val_loss, *acc, *r2; /* epochs each, the member's */
    int done_best_epoch[PREDICTOR_MAX_MEMBERS]; /* the finished members' (member entries) */
    double done_best_val[PREDICTOR_MAX_MEMBERS];
} run_state;

static char *state_json(const char *settings, const run_state *s)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddItemToObject(j, "settings", cJSON_Parse(settings));
    cJSON_AddNumberToObject(j, "member", s->member);
    cJSON *fin = cJSON_AddArrayToObject(j, "members_done"); /* [best epoch, best val loss] */
    for (int m = 0; m < s->member; m++) {
        cJSON *r = cJSON_CreateArray();
        cJSON_AddItemToArray(r, cJSON_CreateNumber(s->done_best_epoch[m]));
        cJSON_AddItemToArray(r, cJSON_CreateNumber(s->done_best_val[m]));
        cJSON_AddItemToArray(fin, r);
    }
    cJSON_AddNumberToObject(j, "epochs_done", s->epochs_done);
    cJSON_AddNumberToObject(j, "best_epoch", s->best_epoch);
    // null until an epoch has a finite validation loss (cJSON would print infinity as null
    // anyway; state_read takes it back as infinity)
    cJSON_AddItemToObject(j, "best_val_loss", isfinite(s->best_val)
                                                  ? cJSON_CreateNumber(s->best_val)
                                                  : cJSON_CreateNull());
    cJSON *h = cJSON_AddArrayToObject(j, "history");
    for (int e = 0; e < s->epochs_done; e++) {
        cJSON *r = cJSON_CreateArray();
        // %.17g round trip: a resumed run's curve is the uninterrupted one's
        double v[4] = {s->train_loss[e], s->val_loss[e], s->acc[e], s->r2[e]};
        for (int k = 0; k < 4; k++)
            cJSON_AddItemToArray(r, cJSON_CreateNumber(isfinite(v[k]) ? v[k] : -1));
        cJSON_AddItemToArray(h, r);
    }
    char *out = cJSON_Print(j);
    cJSON_Delete(j);
    return out;
}

/* Reads OUT.partial/state.json: 1 when it is a run with these settings (s filled in), 0
 * when there is none, 2 when it is another run's (or unreadable). A state without
 * "member" (written before ensembles) is member 0's; member == members: every network is
 * finished and the model was being written when the run stopped. */
static int state_read(const char *path, const char *settings, run_state *s, int epochs,
                      int members)
{
    char *text = pipeline_read_file(path, NULL, NULL, 0);
    if (!text)
        return 0;
    cJSON *j = cJSON_Parse(text), *want = cJSON_Parse(settings);
    free(text);
    int rc = 2;
    if (j && want && cJSON_Compare(cJSON_GetObjectItemCaseSensitive(j, "settings"), want, 1)) {
        const cJSON *done = cJSON_GetObjectItemCaseSensitive(j, "epochs_done");
        const cJSON *be = cJSON_GetObjectItemCaseSensitive(j, "best_epoch");
        const cJSON *bv = cJSON_GetObjectItemCaseSensitive(j, "best_val_loss");
        const cJSON *h = cJSON_GetObjectItemCaseSensitive(j, "history");
        const cJSON *mem = cJSON_GetObjectItemCaseSensitive(j, "member");
        const cJSON *fin = cJSON_GetObjectItemCaseSensitive(j, "members_done");
        int member = cJSON_IsNumber(mem) ? mem->valueint : 0;
        if (cJSON_IsNumber(done) && cJSON_IsNumber(be) &&
            (cJSON_IsNumber(bv) || cJSON_IsNull(bv)) && done->valueint >= 0 &&
            done->valueint <= epochs && cJSON_GetArraySize(h) == done->valueint &&
            member >= 0 && member <= members && cJSON_GetArraySize(fin) == member) {
            s->member = member;
            for (int m = 0; m < member; m++) {
                const cJSON *r = cJSON_GetArrayItem(fin, m);
                s->done_best_epoch[m] = (int)cJSON_GetNumberValue(cJSON_GetArrayItem(r, 0));
                s->done_best_val[m] = cJSON_GetNumberValue(cJSON_GetArrayItem(r, 1));
            }
            s->epochs_done = done->valueint;
            s->best_epoch = be->valueint;
            s->best_val = cJSON_IsNull(bv) ? INFINITY : bv->valuedouble;
            for (int e = 0; e < s->epochs_done; e++) {
                const cJSON *r = cJSON_GetArrayItem(h, e);
                s->train_loss[e] = cJSON_GetNumberValue(cJSON_GetArrayItem(r, 0));
                s->val_loss[e] = cJSON_GetNumberValue(cJSON_GetArrayItem(r, 1));
                s->acc[e] = cJSON_GetNumberValue(cJSON_GetArrayItem(r, 2));
                s->r2[e] = cJSON_GetNumberValue(cJSON_GetArrayItem(r, 3));
            }
            rc = 1;
        }
    }
    cJSON_Delete(j);
    cJSON_Delete(want);
    return rc;
}

static char *model_json(const predictor_fit_options *o, const param_layout *L,
                        char *const *names, const char *settings, const char *config,
                        size_t d, const rowset *train, const rowset *val, const run_state *st,
                        const fit_metrics *fm, const fit_metrics *first,
                        const fit_metrics *given, const char *arch, const char *heads,
                        double seconds)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "format", MODEL_FORMAT);
    cJSON *ds = cJSON_AddObjectToObject(j, "dataset");
    cJSON_AddStringToObject(ds, "path", o->dataset_path);
    cJSON_AddItemToObject(ds, "config", cJSON_Parse(config));
    cJSON_AddNumberToObject(ds, "train_rows", (double)train->n);
    cJSON_AddNumberToObject(ds, "val_rows", (double)val->n);
    long long lo = train->n ? train->ids[0] : 0, hi = train->n ? train->ids[train->n - 1] : 0;
    cJSON *ids = cJSON_AddArrayToObject(ds, "train_ids");
    cJSON_AddItemToArray(ids, cJSON_CreateNumber((double)lo));
    cJSON_AddItemToArray(ids, cJSON_CreateNumber((double)hi));
    cJSON *pa = cJSON_AddArrayToObject(j, "parameters");
    cJSON *roles = cJSON_AddArrayToObject(j, "roles");
    for (int i = 0; i < L->n_params; i++) {
        cJSON_AddItemToArray(pa, cJSON_CreateString(names[i]));
        cJSON_AddItemToArray(roles, cJSON_CreateString(L->role[i] == ROLE_SELECTOR ? "selector"
                                                       : L->role[i] == ROLE_SEED   ? "seed"
                                                       : L->role[i] == ROLE_HUE    ? "hue"
                                                                                   : "value"));
    }
    cJSON *tr = cJSON_AddObjectToObject(j, "transform");
    cJSON_AddNumberToObject(tr, "features", (double)d);
    cJSON_AddStringToObject(tr, "signed_log", "t = sign(x) log1p(|x| / s), s = mean |x|");
    cJSON_AddStringToObject(tr, "standardise", "(t - mean) / std over the training rows");
    cJSON_AddNumberToObject(tr, "components", o->components);
    if (o->texstats) {
        cJSON_AddNumberToObject(tr, "texstats", TEXSTATS_N);
        cJSON_AddStringToObject(tr, "texstats_input", "the render's texture statistics "
                                "(nn texstats_forward), standardised, after the components");
    }
    cJSON_AddStringToObject(tr, "pca",
                            o->feature_mask_path
                                ? "of the feature mask's values only; randomized SVD, 2 power "
                                  "iterations, whitened"
                            : o->per_tap ? "per tap: each tap's share of the components from its "
                                           "own values; randomized SVD, 2 power iterations, "
                                           "whitened"
                                         : "randomized SVD, 2 power iterations, whitened");
    cJSON *net = cJSON_AddObjectToObject(j, "network");
    cJSON_AddStringToObject(net, "arch", arch);
    cJSON_AddStringToObject(net, "heads", heads);
    if (st->member > 1) {
        cJSON *mem = cJSON_AddArrayToObject(net, "members");
        for (int m = 0; m < st->member; m++) {
            char name[64];
            member_name(name, sizeof name, m);
            cJSON_AddItemToArray(mem, cJSON_CreateString(name));
        }
        cJSON_AddStringToObject(net, "ensemble", "the members' outputs (softmax probabilities, "
                                "values) averaged; member m trained from seed + m");
    }
    if (o->conditional) {
        cJSON_AddNumberToObject(net, "selector_inputs", predictor_layout_classes(L));
        cJSON_AddStringToObject(net, "conditional",
                                "after the other inputs, a combination's one-hot selector "
                                "classes: zero to predict the selectors (and values with no "
                                "combination), a hypothesis's classes for its values");
    }
    cJSON_AddItemToObject(j, "training", cJSON_Parse(settings));
    cJSON *res = cJSON_AddObjectToObject(j, "result");
    cJSON_AddNumberToObject(res, "best_epoch", st->done_best_epoch[0]); /* the first member's */
    cJSON_AddNumberToObject(res, "best_val_loss", st->done_best_val[0]);
    if (st->member > 1) {
        cJSON *be = cJSON_AddArrayToObject(res, "members_best_epoch");
        for (int m = 0; m < st->member; m++)
            cJSON_AddItemToArray(be, cJSON_CreateNumber(st->done_best_epoch[m]));
        cJSON_AddNumberToObject(res, "first_member_val_mean_selector_accuracy",
                                first->mean_selector_acc);
        cJSON_AddNumberToObject(res, "first_member_val_median_value_r2",
                                first->median_value_r2);
    }
    cJSON_AddNumberToObject(res, "seconds", round(seconds * 10) / 10);
    cJSON_AddNumberToObject(res, "val_mean_selector_accuracy", fm->mean_selector_acc);
    cJSON_AddNumberToObject(res, "val_median_value_r2", fm->median_value_r2);
    if (given)
        cJSON_AddNumberToObject(res, "val_median_value_r2_given_true_selectors",
                                given->median_value_r2);
    cJSON *sel = cJSON_AddObjectToObject(res, "val_selector_accuracy");
    cJSON *maj = cJSON_AddObjectToObject(res, "train_selector_majority");
    cJSON *r2 = cJSON_AddObjectToObject(res, "val_value_r2");
    for (int i = 0; i < L->n_params; i++) {
        if (L->role[i] == ROLE_SELECTOR) {
            int s = L->column[i] - L->n_values;
            cJSON_AddNumberToObject(sel, names[i], round(fm->selector_acc[s] * 1e4) / 1e4);
            cJSON_AddNumberToObject(maj, names[i], round(fm->selector_majority[s] * 1e4) / 1e4);
        } else if (L->role[i] == ROLE_VALUE || L->role[i] == ROLE_HUE) {
            // a hue's figure: the mean of its cosine and sine columns'
            double v = L->role[i] == ROLE_HUE ? (fm->value_r2[L->column[i]] +
                                                 fm->value_r2[L->column[i] + 1]) / 2
                                              : fm->value_r2[L->column[i]];
            if (isfinite(v))
                cJSON_AddNumberToObject(r2, names[i], round(v * 1e4) / 1e4);
        }
    }
    char *s = cJSON_Print(j);
    cJSON_Delete(j);
    return s;
}

int predictor_fit(const predictor_fit_options *o, char *err, size_t errlen)
{
    double t_start = pipeline_now();
    rowset train = {0}, val = {0};
    char **names = NULL, *config = NULL, *vconfig = NULL, *settings = NULL, *text = NULL;
    int np = 0, rc = -1, lock_fd = -1;
    size_t d = 0;
    float *scale = NULL, *mean = NULL, *std = NULL, *comp = NULL, *var = NULL, *mean_p = NULL;
    float *best_w = NULL, *bx = NULL, *by = NULL, *bm = NULL, *mean_y = NULL;
    float *vx = NULL, *vy = NULL, *vm = NULL; /* a conditional model's validation pairs */
    float *feature_mask = NULL;
    float stats_mean[TEXSTATS_N], stats_std[TEXSTATS_N];
    char mask_sha[65] = "";
    size_t *order = NULL;
    nn_mlp net = {0}, nets[PREDICTOR_MAX_MEMBERS] = {0};
    nn_optimizer opt = {0};
    run_state st = {0};
    char partial[1100], path[1200], arch[256], heads_spec[1024], msg[768];
    param_layout L;

    if (snprintf(partial, sizeof partial, "%s.partial", o->out_dir) >= (int)sizeof partial)
        return pipeline_error(err, errlen, "%.200s...: path too long", o->out_dir);
    struct stat sb;
    if (!stat(o->out_dir, &sb))
        return pipeline_error(err, errlen, "%s: exists; remove it or choose another output",
                              o->out_dir);
    if (o->epochs < 1 || o->batch < 1 || o->components < 1 || !(o->lr > 0))
        return pipeline_error(err, errlen, "epochs, batch, components and lr must be positive");
    int members = o->members > 0 ? o->members : 1;
    if (members > PREDICTOR_MAX_MEMBERS)
        return pipeline_error(err, errlen, "members: at most %d networks",
                              PREDICTOR_MAX_MEMBERS);

    // OpenBLAS's own threads would split sums differently from run to run (nn/nn.h); our
    // workers parallelise instead
    openblas_set_num_threads(1);

    // 1. rows
    if (read_rows(o->dataset_path, o->val_dataset_path ? -1.0 : o->val_fraction, o->max_ids,
                  o->texstats, &train, &val, &d, &names, &np, &config, err, errlen))
        goto done;
    if (o->val_dataset_path) {
        if (read_rows(o->val_dataset_path, -1.0, 0, o->texstats, &val, NULL, &d, NULL, &np,
                      &vconfig, err, errlen))
            goto done;
        char why[128];
        if (!configs_compatible(config, vconfig, why, sizeof why)) {
            pipeline_error(err, errlen, "%s: not made like %s (%s)", o->val_dataset_path,
                           o->dataset_path, why);
            goto done;
        }
    }
    if (train.n < 2 || val.n < 1) {
        pipeline_error(err, errlen, "%s: %zu training and %zu validation rows: too few to fit",
                       o->dataset_path, train.n, val.n);
        goto done;
    }
    if ((size_t)o->components > d || (size_t)o->components >= train.n) {
        pipeline_error(err, errlen, "%d components from %zu rows of %zu features: at most "
                                    "min(rows - 1, features)",
                       o->components, train.n, d);
        goto done;
    }
    if (o->feature_mask_path &&
        read_feature_mask(o->feature_mask_path, d, o->components, &feature_mask, mask_sha, err,
                          errlen))
        goto done;
    if (predictor_layout_make(&L, (const char *const *)names, np, err, errlen))
        goto done;
    int outputs = predictor_layout_outputs(&L), yc = L.n_values + L.n_selectors, k = o->components;
    int ns = o->texstats ? TEXSTATS_N : 0, kin = k + ns;
    int nin = kin + (o->conditional ? predictor_layout_classes(&L) : 0); /* the input width */
    int pairs = o->conditional ? 2 : 1; /* network rows per sample (pair_with_combination) */
    snprintf(arch, sizeof arch, "mlp:%d-%s-%d,ln,dropout=%g", nin, o->hidden, outputs,
             (double)o->dropout);
    nn_mlp_config cfg;
    if (nn_mlp_parse_arch(arch, &cfg, msg, sizeof msg)) {
        pipeline_error(err, errlen, "hidden layers \"%s\": %s", o->hidden, msg);
        goto done;
    }
    settings = run_settings_json(o, arch, config, train.n, val.n, mask_sha);

    // 2. the run's directory: resume it when it is this run's
    st.train_loss = calloc((size_t)o->epochs, sizeof(double));
    st.val_loss = calloc((size_t)o->epochs, sizeof(double));
    st.acc = calloc((size_t)o->epochs, sizeof(double));
    st.r2 = calloc((size_t)o->epochs, sizeof(double));
    st.best_val = INFINITY;
    st.best_epoch = 0;
    if (!settings || !st.train_loss || !st.val_loss || !st.acc || !st.r2) {
        pipeline_error(err, errlen, "out of memory");
        goto done;
    }
    // one writer at a time: an flock on the run's directory (released when the process
    // ends, however it ends)
    if (mkdir_p1(partial, err, errlen))
        goto done;
    lock_fd = open(partial, O_RDONLY | O_DIRECTORY);
    if (lock_fd < 0 || flock(lock_fd, LOCK_EX | LOCK_NB)) {
        pipeline_error(err, errlen, "%s: %s", partial,
                       lock_fd < 0 ? strerror(errno)
                                   : "another imsynth fit-predictor is writing this run");
        goto done;
    }
    char state_path[1200];
    snprintf(state_path, sizeof state_path, "%s/state.json", partial);
    int resumed = state_read(state_path, settings, &st, o->epochs, members);
    if (resumed == 2 && !o->restart) {
        pipeline_error(err, errlen, "%s: an unfinished run with other settings; rerun it with "
                                    "its settings, or pass --restart to discard it",
                       partial);
        goto done;
    }
    if (resumed != 1) { /* nothing to resume (or discarded): start from an empty directory */
        clear_dir(partial, 0);
        resumed = 0;
    }

    // 3. the input transform (fitted once per run), applied to both sides
    scale = malloc(d * sizeof(float));
    mean = malloc(d * sizeof(float));
    std = malloc(d * sizeof(float));
    comp = malloc((size_t)k * d * sizeof(float));
    var = malloc((size_t)k * sizeof(float));
    mean_p = calloc((size_t)np, sizeof(float));
    train.Z = malloc(train.n * (size_t)k * sizeof(float));
    val.Z = malloc(val.n * (size_t)k * sizeof(float));
    train.input = malloc(train.n * (size_t)nin * sizeof(float));
    val.input = malloc(val.n * (size_t)nin * sizeof(float));
    if (!scale || !mean || !std || !comp || !var || !mean_p || !train.Z || !val.Z || !train.input ||
        !val.input) {
        pipeline_error(err, errlen, "out of memory for the transform");
        goto done;
    }
    snprintf(path, sizeof path, "%s/transform.safetensors", partial);
    nn_safetensors tst = {0};
    if (resumed == 1 && !nn_safetensors_open(path, &tst, msg, sizeof msg)) {
        int bad = predictor_read_tensor(&tst, "signed_log.scale", scale, d, err, errlen) ||
                  predictor_read_tensor(&tst, "standardise.mean", mean, d, err, errlen) ||
                  predictor_read_tensor(&tst, "standardise.std", std, d, err, errlen) ||
                  predictor_read_tensor(&tst, "pca.components", comp, (size_t)k * d, err,
                                        errlen) ||
                  predictor_read_tensor(&tst, "pca.variance", var, (size_t)k, err, errlen) ||
                  predictor_read_tensor(&tst, "params.mean", mean_p, (size_t)np, err, errlen) ||
                  (ns && (predictor_read_tensor(&tst, "texstats.mean", stats_mean, TEXSTATS_N,
                                                err, errlen) ||
                          predictor_read_tensor(&tst, "texstats.std", stats_std, TEXSTATS_N, err,
                                                errlen)));
        nn_safetensors_close(&tst);
        if (bad)
            goto done;
        for (size_t i = 0; i < train.n; i++)
            predictor_transform_row(train.X + i * d, d, scale, mean, std);
    } else {
        if (o->progress_text)
            o->progress_text(o->progress_ctx, "fitting the input transform and PCA");
        if (predictor_transform_fit(train.X, train.n, d, scale, mean, std)) {
            pipeline_error(err, errlen, "out of memory");
            goto done;
        }
        if (feature_mask ? pca_fit_masked(train.X, train.n, d, feature_mask, k, o->seed,
                                          o->threads, comp, var, msg, sizeof msg)
            : o->per_tap ? pca_fit_per_tap(train.X, train.n, d, config, k, o->seed, o->threads,
                                           comp, var, msg, sizeof msg)
                         : nn_pca_fit(train.X, (int)train.n, (int)d, k, 2, o->seed, o->threads,
                                      comp, var, msg, sizeof msg)) {
            pipeline_error(err, errlen, "%s", msg);
            goto done;
        }
        if (o->half) /* as stored, so that the network learns from what predictions see */
            for (size_t i = 0; i < (size_t)k * d; i++)
                comp[i] = nn_half_to_float(nn_float_to_half(comp[i]));
        for (size_t i = 0; i < train.n; i++)
            for (int c = 0; c < np; c++)
                mean_p[c] += train.params[i * (size_t)np + (size_t)c] / (float)train.n;
        if (ns)
            texstats_standardisation(train.S, train.n, stats_mean, stats_std);
        text = state_json(settings, &st); /* epochs_done 0: a kill from here on resumes */
        if (write_transform(path, scale, mean, std, comp, var, mean_p, ns ? stats_mean : NULL,
                            ns ? stats_std : NULL, d, k, np, o->half, msg, sizeof msg) ||
            !text || pipeline_write_text_atomic(state_path, text, msg, sizeof msg)) {
            pipeline_error(err, errlen, "%s", text ? msg : "out of memory");
            goto done;
        }
    }
    for (size_t i = 0; i < val.n; i++)
        predictor_transform_row(val.X + i * d, d, scale, mean, std);
    nn_pca_transform(train.Z, train.X, comp, var, (int)train.n, (int)d, k, 1, o->threads);
    nn_pca_transform(val.Z, val.X, comp, var, (int)val.n, (int)d, k, 1, o->threads);
    network_inputs(&train, k, ns, nin, stats_mean, stats_std);
    network_inputs(&val, k, ns, nin, stats_mean, stats_std);
    free(train.X);
    free(val.X);
    train.X = val.X = NULL;

    // 4. targets
    train.Y = calloc(train.n * (size_t)yc, sizeof(float));
    train.M = calloc(train.n * (size_t)yc, sizeof(float));
    val.Y = calloc(val.n * (size_t)yc, sizeof(float));
    val.M = calloc(val.n * (size_t)yc, sizeof(float));
    mean_y = calloc((size_t)yc, sizeof(float));
    if (!train.Y || !train.M || !val.Y || !val.M || !mean_y) {
        pipeline_error(err, errlen, "out of memory");
        goto done;
    }
    for (size_t i = 0; i < train.n; i++)
        predictor_layout_targets(&L, train.params + i * (size_t)np, train.active + i * (size_t)np,
                                 train.Y + i * (size_t)yc, train.M + i * (size_t)yc);
    for (size_t i = 0; i < val.n; i++)
        predictor_layout_targets(&L, val.params + i * (size_t)np, val.active + i * (size_t)np,
                                 val.Y + i * (size_t)yc, val.M + i * (size_t)yc);
    for (int c = 0; c < yc; c++) { /* training mean where active: the R^2 baseline */
        double s = 0, n = 0;
        for (size_t i = 0; i < train.n; i++)
            if (train.M[i * (size_t)yc + c] != 0) {
                s += train.Y[i * (size_t)yc + c];
                n++;
            }
        mean_y[c] = n ? (float)(s / n) : 0.0f;
    }

    // 5. what every member shares: heads, batches, the validation rows
    nn_head heads[NN_MAX_HEADS];
    int nh = predictor_layout_heads(&L, heads, o->value_weight);
    nn_heads_format(heads, nh, heads_spec, sizeof heads_spec);
    long long per_epoch = (long long)((train.n + (size_t)o->batch - 1) / (size_t)o->batch);
    bx = malloc((size_t)(pairs * o->batch) * (size_t)nin * sizeof(float));
    by = malloc((size_t)(pairs * o->batch) * (size_t)yc * sizeof(float));
    bm = malloc((size_t)(pairs * o->batch) * (size_t)yc * sizeof(float));
    order = malloc(train.n * sizeof(size_t));
    if (!bx || !by || !bm || !order) {
        pipeline_error(err, errlen, "out of memory");
        goto done;
    }
    // the validation loss of a conditional model is over both kinds of row, as training's
    const float *vxs = val.input, *vys = val.Y, *vms = val.M;
    if (o->conditional) {
        vx = malloc(2 * val.n * (size_t)nin * sizeof(float));
        vy = malloc(2 * val.n * (size_t)yc * sizeof(float));
        vm = malloc(2 * val.n * (size_t)yc * sizeof(float));
        if (!vx || !vy || !vm) {
            pipeline_error(err, errlen, "out of memory");
            goto done;
        }
        memcpy(vx, val.input, val.n * (size_t)nin * sizeof(float));
        memcpy(vy, val.Y, val.n * (size_t)yc * sizeof(float));
        memcpy(vm, val.M, val.n * (size_t)yc * sizeof(float));
        pair_with_combination(&L, kin, nin, vx, vy, vm, val.n);
        vxs = vx;
        vys = vy;
        vms = vm;
    }

    // 6. the members, one after another: member m from seed + m (initial weights,
    // shuffling, dropout), on the same inputs; a single network is member 0 alone, seeded
    // as before ensembles existed. Each ends as its best epoch's weights in member_file.
    while (st.member < members) {
        int m = st.member;
        uint64_t seed = o->seed + (uint64_t)m;
        run_file(path, sizeof path, partial, "checkpoint", m, st.epochs_done);
        if (st.epochs_done > 0) {
            if (nn_mlp_load(&net, &opt, path, msg, sizeof msg)) {
                pipeline_error(err, errlen, "%s", msg);
                goto done;
            }
        } else {
            if (nn_mlp_create(&net, &cfg, heads, nh, seed, msg, sizeof msg)) {
                pipeline_error(err, errlen, "%s", msg);
                goto done;
            }
            nn_optimizer_config oc = nn_optimizer_defaults(NN_OPT_ADAMW);
            oc.lr = o->lr;
            oc.weight_decay = o->weight_decay;
            oc.schedule = NN_SCHEDULE_COSINE;
            oc.warmup_steps = per_epoch;
            oc.total_steps = per_epoch * o->epochs;
            if (nn_optimizer_init(&opt, &oc, net.n_floats)) {
                pipeline_error(err, errlen, "out of memory");
                goto done;
            }
        }
        net.threads = o->threads > 0 ? o->threads : 1;
        net.dropout_seed = seed;
        if (nn_mlp_check_data(&net, train.input, train.Y, train.M, train.n, msg, sizeof msg) ||
            nn_mlp_check_data(&net, val.input, val.Y, val.M, val.n, msg, sizeof msg)) {
            pipeline_error(err, errlen, "%s", msg);
            goto done;
        }
        if (!best_w && !(best_w = malloc(net.n_floats * sizeof(float)))) {
            pipeline_error(err, errlen, "out of memory");
            goto done;
        }
        memcpy(best_w, net.weights, net.n_floats * sizeof(float));
        run_file(path, sizeof path, partial, "best", m, st.best_epoch);
        if (st.epochs_done > 0) {
            nn_mlp tmp = {0};
            if (nn_mlp_load(&tmp, NULL, path, msg, sizeof msg) || tmp.n_floats != net.n_floats) {
                nn_mlp_free(&tmp);
                pipeline_error(err, errlen, "%s: %s", path, msg);
                goto done;
            }
            memcpy(best_w, tmp.weights, net.n_floats * sizeof(float));
            nn_mlp_free(&tmp);
        }

        for (int e = st.epochs_done; e < o->epochs; e++) {
            double t0 = pipeline_now(), sum = 0;
            nn_epoch_order(seed, e, 1, train.n, order);
            for (long long b = 0; b < per_epoch; b++) {
                long long epoch;
                size_t first;
                int count;
                nn_step_batch((long long)e * per_epoch + b, train.n, o->batch, &epoch, &first,
                              &count);
                nn_gather_rows(bx, train.input, (size_t)nin, order + first, (size_t)count);
                nn_gather_rows(by, train.Y, (size_t)yc, order + first, (size_t)count);
                nn_gather_rows(bm, train.M, (size_t)yc, order + first, (size_t)count);
                if (o->conditional)
                    pair_with_combination(&L, kin, nin, bx, by, bm, (size_t)count);
                double loss;
                if (nn_mlp_train_step(&net, &opt, bx, by, bm, pairs * count, &loss)) {
                    pipeline_error(err, errlen, "out of memory");
                    goto done;
                }
                sum += loss * count;
            }
            double vl;
            fit_metrics fm;
            if (nn_mlp_evaluate(&net, vxs, vys, vms, pairs * (int)val.n, &vl) ||
                compute_metrics(&net, 1, &L, &val, val.input, &train, mean_y, &fm)) {
                pipeline_error(err, errlen, "out of memory");
                goto done;
            }
            st.train_loss[e] = sum / (double)train.n;
            st.val_loss[e] = vl;
            st.acc[e] = fm.mean_selector_acc;
            st.r2[e] = fm.median_value_r2;
            int old_best = st.best_epoch;
            st.epochs_done = e + 1;
            if (vl < st.best_val) {
                st.best_val = vl;
                st.best_epoch = e + 1;
                memcpy(best_w, net.weights, net.n_floats * sizeof(float));
                run_file(path, sizeof path, partial, "best", m, e + 1);
                if (nn_mlp_save(&net, NULL, path, msg, sizeof msg)) {
                    pipeline_error(err, errlen, "%s", msg);
                    goto done;
                }
            }
            run_file(path, sizeof path, partial, "checkpoint", m, e + 1);
            free(text);
            text = state_json(settings, &st);
            if (nn_mlp_save(&net, &opt, path, msg, sizeof msg) ||
                pipeline_write_text_atomic(state_path, text, msg, sizeof msg)) {
                pipeline_error(err, errlen, "%s", msg);
                goto done;
            }
            // the state now names epoch e + 1's files: the previous ones can go
            run_file(path, sizeof path, partial, "checkpoint", m, e);
            unlink(path);
            if (old_best != st.best_epoch) {
                run_file(path, sizeof path, partial, "best", m, old_best);
                unlink(path);
            }
            if (o->progress)
                o->progress(o->progress_ctx, m, members, e + 1, o->epochs, st.train_loss[e], vl,
                            st.acc[e], st.r2[e], pipeline_now() - t0);
            if (o->stop && *o->stop && (e + 1 < o->epochs || m + 1 < members)) {
                rc = 1;
                goto done;
            }
        }

        // the member is finished: its best weights, its curves (the first member's are the
        // model's losses.csv), then a state that starts the next; a kill before that state
        // redoes only this (the same bytes)
        memcpy(net.weights, best_w, net.n_floats * sizeof(float));
        member_file(path, sizeof path, partial, m);
        if (nn_mlp_save_weights(&net, o->half ? NN_F16 : NN_F32, path, msg, sizeof msg) ||
            (m == 0 && write_losses(partial, st.train_loss, st.val_loss, st.acc, st.r2,
                                    st.epochs_done, msg, sizeof msg))) {
            pipeline_error(err, errlen, "%s", msg);
            goto done;
        }
        run_state next = st;
        next.done_best_epoch[m] = st.best_epoch;
        next.done_best_val[m] = st.best_val;
        next.member = m + 1;
        next.epochs_done = next.best_epoch = 0;
        next.best_val = INFINITY;
        free(text);
        text = state_json(settings, &next);
        if (!text || pipeline_write_text_atomic(state_path, text, msg, sizeof msg)) {
            pipeline_error(err, errlen, "%s", text ? msg : "out of memory");
            goto done;
        }
        run_file(path, sizeof path, partial, "checkpoint", m, st.epochs_done);
        unlink(path);
        run_file(path, sizeof path, partial, "best", m, st.best_epoch);
        unlink(path);
        st = next;
        nn_mlp_free(&net);
        nn_optimizer_free(&opt);
        memset(&net, 0, sizeof net);
        memset(&opt, 0, sizeof opt);
    }

    // 7. the model: the members read back (their averaged outputs are its predictions),
    // catalogue, description; then OUT in one rename
    for (int m = 0; m < members; m++) {
        member_file(path, sizeof path, partial, m);
        if (nn_mlp_load(&nets[m], NULL, path, msg, sizeof msg)) {
            pipeline_error(err, errlen, "%s", msg);
            goto done;
        }
        nets[m].threads = o->threads > 0 ? o->threads : 1;
    }
    fit_metrics fm, first, given;
    if (compute_metrics(nets, members, &L, &val, val.input, &train, mean_y, &fm) ||
        compute_metrics(nets, 1, &L, &val, val.input, &train, mean_y, &first) ||
        (o->conditional &&
         compute_metrics(nets, members, &L, &val, vx + val.n * (size_t)nin, &train, mean_y,
                         &given))) {
        pipeline_error(err, errlen, "out of memory");
        goto done;
    }
    snprintf(path, sizeof path, "%s/catalogue.safetensors", partial);
    if (write_catalogue(path, &train, k, np, o->half, o->catalogue, msg, sizeof msg)) {
        pipeline_error(err, errlen, "%s", msg);
        goto done;
    }
    free(text);
    text = model_json(o, &L, names, settings, config, d, &train, &val, &st, &fm, &first,
                      o->conditional ? &given : NULL, arch, heads_spec, pipeline_now() - t_start);
    snprintf(path, sizeof path, "%s/model.json", partial);
    if (!text || pipeline_write_text_atomic(path, text, msg, sizeof msg)) {
        pipeline_error(err, errlen, "%s", text ? msg : "out of memory");
        goto done;
    }
    // a kill between writing a checkpoint (or a member's finishing state) and unlinking
    // the files it replaces leaves those behind
    clear_dir(partial, 1);
    unlink(state_path);
    if (rename(partial, o->out_dir)) {
        pipeline_error(err, errlen, "%s: cannot rename into place: %s", o->out_dir,
                       strerror(errno));
        goto done;
    }
    if (o->result) {
        o->result->best_epoch = st.done_best_epoch[0];
        o->result->best_val_loss = st.done_best_val[0];
        o->result->mean_selector_accuracy = fm.mean_selector_acc;
        o->result->median_value_r2 = fm.median_value_r2;
        o->result->train_rows = train.n;
        o->result->val_rows = val.n;
        o->result->seconds = pipeline_now() - t_start;
    }
    rc = 0;
done:
    for (int i = 0; names && i < np; i++)
        free(names[i]);
    free(names);
    free(config);
    free(vconfig);
    free(settings);
    free(text);
    rowset_free(&train);
    rowset_free(&val);
    free(scale);
    free(mean);
    free(std);
    free(comp);
    free(var);
    free(mean_p);
    free(feature_mask);
    free(best_w);
    free(bx);
    free(by);
    free(bm);
    free(vx);
    free(vy);
    free(vm);
    free(mean_y);
    free(order);
    free(st.train_loss);
    free(st.val_loss);
    free(st.acc);
    free(st.r2);
    nn_mlp_free(&net);
    nn_optimizer_free(&opt);
    for (int m = 0; m < PREDICTOR_MAX_MEMBERS; m++)
        nn_mlp_free(&nets[m]);
    if (lock_fd >= 0)
        close(lock_fd);
    return rc;
}

/*
 * The parameter predictor: descriptor -> input transform -> MLP -> selector classes and
 * value parameters, trained on a dataset from datagen (predictor_fit), read back by
 * predictor_load for prediction and retrieval.
 *
 * What defeated the thesis's predictor, and what is done about it here:
 *   - Gram values are heavy-tailed (a few bright materials dominate a feature's scale):
 *     every feature goes through t = sign(x) log1p(|x| / s), s its mean |x| over the
 *     training rows, then is standardised; PCA (nn_pca_fit) keeps the leading components,
 *     whitened, so the network sees a few hundred inputs of unit variance.
 *   - A value parameter that the sub-shader does not use cannot be learnt from the image:
 *     its loss is masked by the dataset's active mask. A selector is a classification
 *     (softmax, cross-entropy), masked likewise. Pattern Offset moves the pattern like a
 *     seed: not a target.
 *   - One image is ambiguous between selector combinations: predictor_predict returns the
 *     k likeliest combinations for a renderer to choose from.
 *
 * Training is deterministic (nn's counter-based shuffling and dropout, PCA and layers
 * bit-identical for any thread count) and resumable: the run lives in OUT.partial/ with
 * a checkpoint after every epoch, and a rerun of the same command continues it to the
 * same bytes. OUT appears only when complete (a rename).
 */
#include <assert.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "pipeline/pipeline_internal.h"

struct predictor {
    char dir[4096];                 /* where it was loaded from (the bundled model resolved) */
    param_layout lay;
    char **names;
    datagen_descriptor kind;
    size_t d;
    int k;
    float *scale, *mean, *std;      /* (d) the signed-log transform and standardisation */
    float *components, *variance;   /* (k, d), (k) */
    float *mean_params;             /* (n_params) */
    int ns;                         /* texture statistics after the components: 0 or TEXSTATS_N */
    int nc;                         /* a conditional model's one-hot classes after them, or 0 */
    double temperature;             /* 0: the k likeliest combinations; > 0: sampled ones
                                     * (predictor_sample_hypotheses) */
    predictor_metric metric;        /* predictor_nearest's distance */
    float stats_mean[TEXSTATS_N], stats_std[TEXSTATS_N];
    int n_nets;                     /* an ensemble's members (model.json "network"."members"),
                                     * or 1; their outputs are averaged */
    char net_files[PREDICTOR_MAX_MEMBERS][64];
    nn_mlp nets[PREDICTOR_MAX_MEMBERS];
    size_t n_cat;
    float *cat_z, *cat_params;      /* (n_cat, k), (n_cat, n_params) */
    long long *cat_id;
    char *dataset_config;
    float *x, *z, *out;             /* scratch: (d), (k + ns + nc), (outputs) */
};

/* ---------------------------------------------------------------- layout ----------- */

int predictor_layout_make(param_layout *L, const char *const *names, int n, char *err,
                       size_t errlen)
{
    memset(L, 0, sizeof *L);
    if (n > (int)(sizeof L->role / sizeof L->role[0]))
        return pipeline_error(err, errlen, "%d parameters: at most %zu supported", n,
                              sizeof L->role / sizeof L->role[0]);
    L->n_params = n;
    for (int i = 0; i < n; i++) {
        int c = sg_param_mult_choices(names[i]);
        L->role[i] = c                                   ? ROLE_SELECTOR
                     : !strcmp(names[i], "Pattern Offset") ? ROLE_SEED
                     : strstr(names[i], "Hue")             ? ROLE_HUE
                                                           : ROLE_VALUE;
        L->classes[i] = c;
        if (L->role[i] == ROLE_VALUE || L->role[i] == ROLE_HUE) {
            L->column[i] = L->n_values;
            L->n_values += L->role[i] == ROLE_HUE ? 2 : 1;
        }
    }
    for (int i = 0; i < n; i++)
        if (L->role[i] == ROLE_SELECTOR)
            L->column[i] = L->n_values + L->n_selectors++;
    if (L->n_selectors + 1 > NN_MAX_HEADS)
        return pipeline_error(err, errlen, "%d selectors: at most %d supported", L->n_selectors,
                              NN_MAX_HEADS - 1);
    return 0;
}

int predictor_layout_classes(const param_layout *L)
{
    return predictor_layout_outputs(L) - L->n_values;
}

void predictor_layout_onehot(const param_layout *L, const float *cls, float *out)
{
    memset(out, 0, (size_t)predictor_layout_classes(L) * sizeof(float));
    for (int i = 0, s = 0, at = 0; i < L->n_params; i++)
        if (L->role[i] == ROLE_SELECTOR) {
            int c = (int)cls[s++];
            assert(c >= 0 && c < L->classes[i]);
            out[at + c] = 1.0f;
            at += L->classes[i];
        }
}

/* The class a selector's stored value (a bin centre (c + 0.5) / N) means. */
static int selector_class(float v, int classes)
{
    int c = (int)floorf(v * (float)classes);
    return c < 0 ? 0 : c >= classes ? classes - 1 : c;
}

int predictor_layout_heads(const param_layout *L, nn_head *heads, float value_weight)
{
    int nh = 0, out = 0;
    if (L->n_values) {
        heads[nh++] = (nn_head){.kind = NN_HEAD_SIGMOID, .y_first = 0, .count = L->n_values,
                                .out_first = 0, .weight = value_weight, .loss = NN_LOSS_MSE};
        out = L->n_values;
    }
    for (int i = 0; i < L->n_params; i++)
        if (L->role[i] == ROLE_SELECTOR) {
            heads[nh++] = (nn_head){.kind = NN_HEAD_SOFTMAX, .y_first = L->column[i], .count = 1,
                                    .classes = L->classes[i], .out_first = out,
                                    .weight = 1.0f / (float)L->n_selectors};
            out += L->classes[i];
        }
    return nh;
}

int predictor_layout_outputs(const param_layout *L)
{
    int out = L->n_values;
    for (int i = 0; i < L->n_params; i++)
        out += L->role[i] == ROLE_SELECTOR ? L->classes[i] : 0;
    return out;
}

/* Y and mask rows (n_values + n_selectors columns) of one sample. */
void predictor_layout_targets(const param_layout *L, const float *params, const uint8_t *active,
                           float *y, float *m)
{
    for (int i = 0; i < L->n_params; i++) {
        if (L->role[i] == ROLE_SEED)
            continue;
        int c = L->column[i];
        m[c] = active[i] ? 1.0f : 0.0f;
        if (L->role[i] == ROLE_HUE) {
            double a = 6.283185307179586 * params[i];
            y[c] = (float)((cos(a) + 1) / 2);
            y[c + 1] = (float)((sin(a) + 1) / 2);
            m[c + 1] = m[c];
        } else
            y[c] = L->role[i] == ROLE_SELECTOR ? (float)selector_class(params[i], L->classes[i])
                                               : params[i];
    }
}

/* ---------------------------------------------------------------- input transform -- */

/* x (d) in place: signed log over the feature's scale, then standardised. */
void predictor_transform_row(float *x, size_t d, const float *scale, const float *mean,
                          const float *std)
{
    for (size_t j = 0; j < d; j++) {
        float v = x[j] / scale[j];
        float t = v < 0 ? -log1pf(-v) : log1pf(v);
        x[j] = (t - mean[j]) / std[j];
    }
}

/* Fits scale, mean, std over the rows of X (n, d) and transforms X in place. Sums in
 * double, in row order. */
int predictor_transform_fit(float *X, size_t n, size_t d, float *scale, float *mean, float *std)
{
    double *acc = calloc(d, sizeof *acc), *acc2 = calloc(d, sizeof *acc2);
    if (!acc || !acc2) {
        free(acc);
        free(acc2);
        return -1;
    }
    for (size_t i = 0; i < n; i++)
        for (size_t j = 0; j < d; j++)
            acc[j] += fabs((double)X[i * d + j]);
    for (size_t j = 0; j < d; j++) {
        double s = acc[j] / (double)n;
        scale[j] = s > 1e-30 ? (float)s : 1.0f;
        mean[j] = 0.0f;
        std[j] = 1.0f;
        acc[j] = 0;
    }
    for (size_t i = 0; i < n; i++) {
        float *x = X + i * d;
        predictor_transform_row(x, d, scale, mean, std); /* the signed log alone (mean 0, std 1) */
        for (size_t j = 0; j < d; j++) {
            acc[j] += x[j];
            acc2[j] += (double)x[j] * x[j];
        }
    }
    for (size_t j = 0; j < d; j++) {
        double m = acc[j] / (double)n, v = acc2[j] / (double)n - m * m;
        mean[j] = (float)m;
        std[j] = v > 1e-12 ? (float)sqrt(v) : 1.0f;
    }
    for (size_t i = 0; i < n; i++)
        for (size_t j = 0; j < d; j++)
            X[i * d + j] = (X[i * d + j] - mean[j]) / std[j];
    free(acc);
    free(acc2);
    return 0;
}

/* ---------------------------------------------------------------- files ------------ */

int predictor_path_join(char *out, size_t len, const char *dir, const char *name, char *err,
                     size_t errlen)
{
    if (snprintf(out, len, "%s/%s", dir, name) >= (int)len)
        return pipeline_error(err, errlen, "%.200s...: path too long", dir);
    return 0;
}

/* Reads tensor `name` of exactly `count` floats (any shape) from st. */
int predictor_read_tensor(const nn_safetensors *st, const char *name, float *out, size_t count,
                       char *err, size_t errlen)
{
    int i = nn_safetensors_find(st, name);
    if (i < 0)
        return pipeline_error(err, errlen, "%s: no tensor \"%s\"", st->path, name);
    const nn_tensor_info *t = &st->tensors[i];
    size_t n = 1;
    for (int a = 0; a < t->ndim; a++)
        n *= (size_t)t->shape[a];
    if (n != count)
        return pipeline_error(err, errlen, "%s: tensor \"%s\" has %zu values, expected %zu",
                              st->path, name, n, count);
    char msg[512];
    if (nn_safetensors_read_f32(st, name, t->ndim, t->shape, out, msg, sizeof msg))
        return pipeline_error(err, errlen, "%s", msg);
    for (size_t j = 0; j < count; j++)
        if (!isfinite(out[j]))
            return pipeline_error(err, errlen, "%s: tensor \"%s\" value %zu is not finite",
                                  st->path, name, j);
    return 0;
}

/* ---------------------------------------------------------------- loading ---------- */

void predictor_free(predictor *p)
{
    if (!p)
        return;
    for (int i = 0; p->names && i < p->lay.n_params; i++)
        free(p->names[i]);
    free(p->names);
    free(p->scale);
    free(p->mean);
    free(p->std);
    free(p->components);
    free(p->variance);
    free(p->mean_params);
    for (int m = 0; m < PREDICTOR_MAX_MEMBERS; m++)
        nn_mlp_free(&p->nets[m]);
    free(p->cat_z);
    free(p->cat_params);
    free(p->cat_id);
    free(p->dataset_config);
    free(p->x);
    free(p->z);
    free(p->out);
    free(p);
}

/* model.json's parts this file reads back. */
static int read_model_json(predictor *p, const char *path, char *err, size_t errlen)
{
    char *text = pipeline_read_file(path, NULL, err, errlen);
    if (!text)
        return -1;
    cJSON *root = cJSON_Parse(text);
    free(text);
    int rc = -1;
    if (!root) {
        pipeline_error(err, errlen, "%s: not valid JSON", path);
        goto done;
    }
    const cJSON *fmt = cJSON_GetObjectItemCaseSensitive(root, "format");
    if (!cJSON_IsString(fmt) || strcmp(fmt->valuestring, MODEL_FORMAT)) {
        pipeline_error(err, errlen, "%s: not an %s model (\"format\")", path, MODEL_FORMAT);
        goto done;
    }
    const cJSON *params = cJSON_GetObjectItemCaseSensitive(root, "parameters");
    int n = cJSON_GetArraySize(params);
    if (!cJSON_IsArray(params) || n < 1 || n > (int)(sizeof p->lay.role / sizeof(int))) {
        pipeline_error(err, errlen, "%s: \"parameters\" must be a list of 1 to %zu names", path,
                       sizeof p->lay.role / sizeof(int));
        goto done;
    }
    p->names = calloc((size_t)n, sizeof *p->names);
    if (!p->names) {
        pipeline_error(err, errlen, "out of memory");
        goto done;
    }
    for (int i = 0; i < n; i++) {
        const cJSON *it = cJSON_GetArrayItem(params, i);
        if (!cJSON_IsString(it) || !(p->names[i] = strdup(it->valuestring))) {
            pipeline_error(err, errlen, "%s: parameters[%d] is not a name", path, i);
            for (int j = 0; j < i; j++)
                free(p->names[j]);
            free(p->names);
            p->names = NULL;
            goto done;
        }
    }
    if (predictor_layout_make(&p->lay, (const char *const *)p->names, n, err, errlen))
        goto done;
    const cJSON *tr = cJSON_GetObjectItemCaseSensitive(root, "transform");
    const cJSON *feat = cJSON_GetObjectItemCaseSensitive(tr, "features");
    const cJSON *comp = cJSON_GetObjectItemCaseSensitive(tr, "components");
    const cJSON *desc = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(root, "dataset"),
                                         "config"),
        "descriptor");
    const cJSON *kind = cJSON_GetObjectItemCaseSensitive(desc, "features");
    const cJSON *size = cJSON_GetObjectItemCaseSensitive(desc, "size");
    if (!cJSON_IsNumber(feat) || !cJSON_IsNumber(comp) || !cJSON_IsString(kind) ||
        !cJSON_IsNumber(size) || feat->valuedouble != size->valuedouble ||
        feat->valuedouble < 1 || feat->valuedouble > 1e7 || comp->valuedouble < 1 ||
        comp->valuedouble > feat->valuedouble) {
        pipeline_error(err, errlen, "%s: \"transform\" or the dataset's descriptor is missing or "
                                    "inconsistent",
                       path);
        goto done;
    }
    if (cJSON_GetObjectItemCaseSensitive(desc, "mask_sha256")) {
        pipeline_error(err, errlen, "%s: models of masked descriptors are not supported", path);
        goto done;
    }
    const cJSON *ts = cJSON_GetObjectItemCaseSensitive(tr, "texstats");
    if (ts && (!cJSON_IsNumber(ts) || (ts->valuedouble != 0 && ts->valuedouble != TEXSTATS_N))) {
        pipeline_error(err, errlen, "%s: \"transform\".\"texstats\" must be 0 or %d (the texture "
                                    "statistics this imsynth computes)",
                       path, TEXSTATS_N);
        goto done;
    }
    p->ns = ts ? (int)ts->valuedouble : 0;
    const cJSON *sel_in = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(root, "network"), "selector_inputs");
    if (sel_in && (!cJSON_IsNumber(sel_in) ||
                   sel_in->valuedouble != predictor_layout_classes(&p->lay))) {
        pipeline_error(err, errlen, "%s: \"network\".\"selector_inputs\" must be %d (the "
                                    "selectors' classes)",
                       path, predictor_layout_classes(&p->lay));
        goto done;
    }
    p->nc = sel_in ? predictor_layout_classes(&p->lay) : 0;
    // an ensemble names its members' files; a single network is network.safetensors
    const cJSON *members = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(root, "network"), "members");
    p->n_nets = 1;
    snprintf(p->net_files[0], sizeof p->net_files[0], "network.safetensors");
    if (members) {
        int count = cJSON_GetArraySize(members);
        if (!cJSON_IsArray(members) || count < 1 || count > PREDICTOR_MAX_MEMBERS) {
            pipeline_error(err, errlen, "%s: \"network\".\"members\" must list 1 to %d files",
                           path, PREDICTOR_MAX_MEMBERS);
            goto done;
        }
        for (int m = 0; m < count; m++) {
            const char *f = cJSON_GetStringValue(cJSON_GetArrayItem(members, m));
            // a plain name in the model's directory: a model cannot point outside itself
            if (!f || !*f || strchr(f, '/') || !strcmp(f, "..") ||
                strlen(f) >= sizeof p->net_files[m]) {
                pipeline_error(err, errlen, "%s: \"network\".\"members\"[%d] must be a file "
                                            "name in the model's directory",
                               path, m);
                goto done;
            }
            snprintf(p->net_files[m], sizeof p->net_files[m], "%s", f);
        }
        p->n_nets = count;
    }
    p->d = (size_t)feat->valuedouble;
    p->k = (int)comp->valuedouble;
    p->kind = pipeline_descriptor_kind_named(kind->valuestring);
    if (p->kind == DATAGEN_DESC_NONE) {
        pipeline_error(err, errlen, "%s: unknown descriptor \"%s\"", path, kind->valuestring);
        goto done;
    }
    p->dataset_config = cJSON_PrintUnformatted(
        cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(root, "dataset"),
                                         "config"));
    rc = p->dataset_config ? 0 : pipeline_error(err, errlen, "out of memory");
done:
    cJSON_Delete(root);
    return rc;
}

predictor *predictor_load(const char *model_dir, char *err, size_t errlen)
{
    predictor *p = calloc(1, sizeof *p);
    char path[1100], msg[768];
    nn_safetensors st = {0};
    if (!p) {
        pipeline_error(err, errlen, "out of memory");
        return NULL;
    }
    if (!model_dir) {
        if (pipeline_find_data("assets/model", p->dir, sizeof p->dir, err, errlen))
            goto fail;
    } else if ((size_t)snprintf(p->dir, sizeof p->dir, "%s", model_dir) >= sizeof p->dir) {
        pipeline_error(err, errlen, "%.200s...: path too long", model_dir);
        goto fail;
    }
    const char *dir = p->dir;
    struct stat sb;
    if (stat(dir, &sb) || !S_ISDIR(sb.st_mode)) {
        pipeline_error(err, errlen, "%s: not a model directory (imsynth fit-predictor writes one)",
                       dir);
        goto fail;
    }
    if (predictor_path_join(path, sizeof path, dir, "model.json", err, errlen) ||
        read_model_json(p, path, err, errlen))
        goto fail;
    size_t d = p->d, k = (size_t)p->k, np = (size_t)p->lay.n_params;
    /* The sizes come from model.json: the transform file must hold a basis of exactly
     * k x d values before k x d floats are allocated (a hostile model.json claiming 10^7
     * components is refused here, not by an allocation). */
    if (predictor_path_join(path, sizeof path, dir, "transform.safetensors", err, errlen))
        goto fail;
    if (nn_safetensors_open(path, &st, msg, sizeof msg)) {
        pipeline_error(err, errlen, "%s", msg);
        goto fail;
    }
    {
        int ci = nn_safetensors_find(&st, "pca.components");
        size_t count = ci < 0 ? 0 : 1;
        for (int a = 0; ci >= 0 && a < st.tensors[ci].ndim; a++)
            count *= (size_t)st.tensors[ci].shape[a];
        if (ci < 0 || count != k * d) {
            pipeline_error(err, errlen, "%s: no tensor \"pca.components\" of %zu x %zu values "
                                        "(model.json's components x features)",
                           path, k, d);
            goto fail;
        }
    }
    p->scale = malloc(d * sizeof(float));
    p->mean = malloc(d * sizeof(float));
    p->std = malloc(d * sizeof(float));
    p->components = malloc(k * d * sizeof(float));
    p->variance = malloc(k * sizeof(float));
    p->mean_params = malloc(np * sizeof(float));
    p->x = malloc(d * sizeof(float));
    p->z = calloc(k + (size_t)p->ns + (size_t)p->nc, sizeof(float)); /* one-hot part zero */
    if (!p->scale || !p->mean || !p->std || !p->components || !p->variance || !p->mean_params ||
        !p->x || !p->z) {
        pipeline_error(err, errlen, "%s: out of memory for %zu features", dir, d);
        goto fail;
    }
    if (predictor_read_tensor(&st, "signed_log.scale", p->scale, d, err, errlen) ||
        predictor_read_tensor(&st, "standardise.mean", p->mean, d, err, errlen) ||
        predictor_read_tensor(&st, "standardise.std", p->std, d, err, errlen) ||
        predictor_read_tensor(&st, "pca.components", p->components, k * d, err, errlen) ||
        predictor_read_tensor(&st, "pca.variance", p->variance, k, err, errlen) ||
        predictor_read_tensor(&st, "params.mean", p->mean_params, np, err, errlen) ||
        (p->ns && (predictor_read_tensor(&st, "texstats.mean", p->stats_mean, TEXSTATS_N, err,
                                         errlen) ||
                   predictor_read_tensor(&st, "texstats.std", p->stats_std, TEXSTATS_N, err,
                                         errlen))))
        goto fail;
    for (int j = 0; j < p->ns; j++)
        if (!(p->stats_std[j] > 0)) {
            pipeline_error(err, errlen, "%s: texture statistic %d has a std that is not positive",
                           path, j);
            goto fail;
        }
    for (size_t j = 0; j < k; j++)
        if (!(p->variance[j] >= 0)) { /* whitening divides by its root, retrieval weighs by it */
            pipeline_error(err, errlen, "%s: principal component %zu has a negative variance",
                           path, j);
            goto fail;
        }
    for (size_t j = 0; j < d; j++)
        if (!(p->scale[j] > 0) || !(p->std[j] > 0)) {
            pipeline_error(err, errlen, "%s: feature %zu has a scale or std that is not positive",
                           path, j);
            goto fail;
        }
    nn_safetensors_close(&st);

    int outputs = predictor_layout_outputs(&p->lay);
    for (int m = 0; m < p->n_nets; m++) {
        nn_mlp *net = &p->nets[m];
        if (predictor_path_join(path, sizeof path, dir, p->net_files[m], err, errlen))
            goto fail;
        if (nn_mlp_load(net, NULL, path, msg, sizeof msg)) {
            pipeline_error(err, errlen, "%s", msg);
            goto fail;
        }
        if (net->cfg.width[0] != p->k + p->ns + p->nc ||
            net->cfg.width[net->cfg.n_linear] != outputs ||
            (m && (memcmp(&net->cfg, &p->nets[0].cfg, sizeof net->cfg) ||
                   net->n_heads != p->nets[0].n_heads ||
                   memcmp(net->heads, p->nets[0].heads,
                          (size_t)net->n_heads * sizeof *net->heads)))) {
            pipeline_error(err, errlen, "%s: the network maps %d inputs to %d outputs; the model "
                                        "needs %d to %d%s",
                           path, net->cfg.width[0], net->cfg.width[net->cfg.n_linear],
                           p->k + p->ns + p->nc, outputs,
                           m ? ", with the first member's layers and heads" : "");
            goto fail;
        }
        net->threads = 1;
    }
    if (!(p->out = malloc((size_t)outputs * sizeof(float)))) {
        pipeline_error(err, errlen, "out of memory");
        goto fail;
    }

    if (predictor_path_join(path, sizeof path, dir, "catalogue.safetensors", err, errlen))
        goto fail;
    if (nn_safetensors_open(path, &st, msg, sizeof msg)) {
        pipeline_error(err, errlen, "%s", msg);
        goto fail;
    }
    int zi = nn_safetensors_find(&st, "catalogue.z");
    if (zi < 0 || st.tensors[zi].ndim != 2 || st.tensors[zi].shape[1] != (int64_t)k ||
        st.tensors[zi].shape[0] < 1) {
        pipeline_error(err, errlen, "%s: no tensor \"catalogue.z\" of shape (n, %zu)", path, k);
        goto fail;
    }
    p->n_cat = (size_t)st.tensors[zi].shape[0];
    size_t nc = p->n_cat;
    p->cat_z = malloc(nc * k * sizeof(float));
    p->cat_params = malloc(nc * np * sizeof(float));
    p->cat_id = malloc(nc * sizeof(long long));
    float *lo = malloc(nc * sizeof(float)), *hi = malloc(nc * sizeof(float));
    int bad = !p->cat_z || !p->cat_params || !p->cat_id || !lo || !hi
                  ? pipeline_error(err, errlen, "%s: out of memory", path)
                  : predictor_read_tensor(&st, "catalogue.z", p->cat_z, nc * k, err, errlen) ||
                        predictor_read_tensor(&st, "catalogue.params", p->cat_params, nc * np, err,
                                    errlen) ||
                        predictor_read_tensor(&st, "catalogue.id_low24", lo, nc, err, errlen) ||
                        predictor_read_tensor(&st, "catalogue.id_high", hi, nc, err, errlen);
    for (size_t i = 0; !bad && i < nc; i++) {
        /* An id is stored as two floats, its low 24 bits and the rest: both must be whole
         * numbers in range, or converting them to long long is undefined. */
        if (!(lo[i] >= 0 && lo[i] < 16777216.0f && lo[i] == floorf(lo[i]) && hi[i] >= 0 &&
              hi[i] < 549755813888.0f && hi[i] == floorf(hi[i])))
            bad = pipeline_error(err, errlen, "%s: catalogue id %zu is not a whole number in "
                                 "[0, 2^63)", path, i);
        else
            p->cat_id[i] = (long long)hi[i] * (1ll << 24) + (long long)lo[i];
    }
    free(lo);
    free(hi);
    nn_safetensors_close(&st);
    if (bad)
        goto fail;
    return p;
fail:
    nn_safetensors_close(&st);
    predictor_free(p);
    return NULL;
}

int predictor_n_params(const predictor *p) { return p->lay.n_params; }
const char *const *predictor_param_names(const predictor *p)
{
    return (const char *const *)p->names;
}
datagen_descriptor predictor_descriptor_kind(const predictor *p) { return p->kind; }
const char *predictor_dir(const predictor *p) { return p->dir; }
size_t predictor_descriptor_size(const predictor *p) { return p->d; }
int predictor_uses_texstats(const predictor *p) { return p->ns > 0; }
const char *predictor_dataset_config(const predictor *p) { return p->dataset_config; }
const float *predictor_mean_params(const predictor *p) { return p->mean_params; }
size_t predictor_catalogue_size(const predictor *p) { return p->n_cat; }
const float *predictor_catalogue_params(const predictor *p, size_t i, long long *id)
{
    if (id)
        *id = p->cat_id[i];
    return p->cat_params + i * (size_t)p->lay.n_params;
}

/* ---------------------------------------------------------------- prediction ------- */

/* p->z = the reduced input of a descriptor. */
static int reduce(predictor *p, const float *descriptor, char *err, size_t errlen)
{
    for (size_t j = 0; j < p->d; j++)
        if (!isfinite(descriptor[j]))
            return pipeline_error(err, errlen, "descriptor value %zu is not finite", j);
    memcpy(p->x, descriptor, p->d * sizeof(float));
    predictor_transform_row(p->x, p->d, p->scale, p->mean, p->std);
    nn_pca_transform(p->z, p->x, p->components, p->variance, 1, (int)p->d, p->k, 1, 1);
    return 0;
}

typedef struct combo {
    double logp;
    int cls[NN_MAX_HEADS];
} combo;

void predictor_texstats_standardise(float *out, const float *raw, const float *mean,
                                    const float *std)
{
    for (int j = 0; j < TEXSTATS_N; j++)
        out[j] = (raw[j] - mean[j]) / std[j];
}

void predictor_sample_hypotheses(predictor *p, double temperature)
{
    p->temperature = temperature > 0 ? temperature : 0;
}

const char *const predictor_metric_names[2] = {"pca", "whitened"};

void predictor_nearest_metric(predictor *p, predictor_metric metric) { p->metric = metric; }

/* The likeliest combination and others drawn from the heads' distributions sharpened by
 * the temperature (class c of a head with probability proportional to p_c^(1/T)): up to k
 * distinct in out, most probable first like likeliest_combos', their logp under the heads.
 * The draws are a pure function of (draw, selector), so one image always gets the same
 * hypotheses. */
static int sampled_combos(const predictor *p, int k, combo *out)
{
    const param_layout *L = &p->lay;
    int n = 0;
    for (int draw = 0; draw < 64 * k && n < k; draw++) {
        combo c = {0};
        int out_first = L->n_values, s = 0;
        for (int i = 0; i < L->n_params; i++) {
            if (L->role[i] != ROLE_SELECTOR)
                continue;
            int C = L->classes[i], pick = 0;
            const float *pr = p->out + out_first;
            if (draw == 0) { /* the likeliest: each head's argmax (ties: the lower class) */
                for (int j = 1; j < C; j++)
                    pick = pr[j] > pr[pick] ? j : pick;
            } else {
                double w[64], total = 0;
                assert(C <= 64);
                for (int j = 0; j < C; j++)
                    total += w[j] = pow(fmax((double)pr[j], 1e-30), 1 / p->temperature);
                uint64_t bits = nn_mix64(((uint64_t)draw << 8 | (uint64_t)s) ^ 0x68797073ull);
                double u = (double)(bits >> 11) * 0x1.0p-53 * total;
                for (pick = 0; pick < C - 1 && (u -= w[pick]) >= 0; pick++)
                    ;
            }
            c.cls[s] = pick;
            c.logp += log(fmax((double)pr[pick], 1e-30));
            out_first += C;
            s++;
        }
        int seen = 0;
        for (int j = 0; j < n && !seen; j++)
            seen = !memcmp(out[j].cls, c.cls, sizeof c.cls);
        if (!seen)
            out[n++] = c;
    }
    for (int a = 1; a < n; a++) /* stable: the likeliest, drawn first, stays first */
        for (int b = a; b > 0 && out[b].logp > out[b - 1].logp; b--) {
            combo t = out[b];
            out[b] = out[b - 1];
            out[b - 1] = t;
        }
    return n;
}

/* The k most probable combinations of independent heads (p->out), exactly, most probable
 * first: a beam of width k over the selectors in turn (every prefix of a top-k combination
 * is a top-k prefix, since extending a prefix only multiplies by probabilities <= 1 that
 * do not depend on the prefix). Returns how many (min(k, combinations)), or -1 (out of
 * memory). */
static int likeliest_combos(const predictor *p, int k, combo *beam)
{
    const param_layout *L = &p->lay;
    combo *next = NULL;
    int nb = 1, cap_next = 0;
    beam[0] = (combo){0};
    int out_first = L->n_values, s = 0;
    for (int i = 0; i < L->n_params; i++) {
        if (L->role[i] != ROLE_SELECTOR)
            continue;
        int C = L->classes[i];
        if (nb * C > cap_next) {
            cap_next = nb * C;
            combo *nn = realloc(next, sizeof(combo) * (size_t)cap_next);
            if (!nn) {
                free(next);
                return -1;
            }
            next = nn;
        }
        int nn_count = 0;
        for (int b = 0; b < nb; b++)
            for (int c = 0; c < C; c++) {
                combo *x = &next[nn_count++];
                *x = beam[b];
                x->cls[s] = c;
                x->logp += log(fmax((double)p->out[out_first + c], 1e-30));
            }
        // keep the k best (stable: ties keep the earlier, lower class)
        int keep = nn_count < k ? nn_count : k;
        for (int a = 0; a < keep; a++) {
            int best = a;
            for (int b = a + 1; b < nn_count; b++)
                if (next[b].logp > next[best].logp)
                    best = b;
            combo t = next[best];
            memmove(next + a + 1, next + a, sizeof(combo) * (size_t)(best - a));
            next[a] = t;
        }
        memcpy(beam, next, sizeof(combo) * (size_t)keep);
        nb = keep;
        out_first += C;
        s++;
    }
    free(next);
    return nb;
}

int predictor_predict(predictor *p, const float *descriptor, const float *texstats, int k,
                      float *params, double *prob, char *err, size_t errlen)
{
    if (k < 1)
        return pipeline_error(err, errlen, "top-k: k must be at least 1");
    if (p->ns && !texstats)
        return pipeline_error(err, errlen, "%s: the model reads the image's texture statistics; "
                                           "none were given",
                              p->dir);
    for (int j = 0; j < p->ns; j++)
        if (!isfinite(texstats[j]))
            return pipeline_error(err, errlen, "texture statistic %d is not finite", j);
    if (reduce(p, descriptor, err, errlen))
        return -1;
    if (p->ns)
        predictor_texstats_standardise(p->z + p->k, texstats, p->stats_mean, p->stats_std);
    if (nn_mlp_forward_mean(p->nets, p->n_nets, p->z, 1, p->out))
        return pipeline_error(err, errlen, "out of memory");
    const param_layout *L = &p->lay;
    combo *beam = malloc(sizeof(combo) * (size_t)k);
    int nb = !beam                ? -1
             : p->temperature > 0 ? sampled_combos(p, k, beam)
                                  : likeliest_combos(p, k, beam);
    if (nb < 0) {
        free(beam);
        return pipeline_error(err, errlen, "out of memory");
    }
    // a conditional model: each hypothesis's values from a pass given its combination
    // (one batch of nb rows); otherwise every hypothesis has the values of the first pass
    int outputs = predictor_layout_outputs(L), width = p->k + p->ns + p->nc;
    float *given = NULL;
    if (p->nc) {
        float *x = malloc(sizeof(float) * (size_t)(nb * width)), cls[NN_MAX_HEADS];
        given = malloc(sizeof(float) * (size_t)(nb * outputs));
        for (int h = 0; x && given && h < nb; h++) {
            memcpy(x + (size_t)(h * width), p->z, sizeof(float) * (size_t)(p->k + p->ns));
            for (int si = 0; si < L->n_selectors; si++)
                cls[si] = (float)beam[h].cls[si];
            predictor_layout_onehot(L, cls, x + (size_t)(h * width + p->k + p->ns));
        }
        int bad = !x || !given || nn_mlp_forward_mean(p->nets, p->n_nets, x, nb, given);
        free(x);
        if (bad) {
            free(given);
            free(beam);
            return pipeline_error(err, errlen, "out of memory");
        }
    }
    for (int h = 0; h < nb; h++) {
        float *row = params + (size_t)h * L->n_params;
        const float *out = given ? given + (size_t)(h * outputs) : p->out;
        for (int i = 0, si = 0; i < L->n_params; i++) {
            if (L->role[i] == ROLE_VALUE)
                row[i] = out[L->column[i]];
            else if (L->role[i] == ROLE_HUE) {
                const float *o = out + L->column[i];
                double hue = atan2(2.0 * o[1] - 1, 2.0 * o[0] - 1) / 6.283185307179586;
                hue = hue < 0 ? hue + 1 : hue;
                row[i] = (float)(hue >= 1 ? 0 : hue);
            }
            else if (L->role[i] == ROLE_SELECTOR)
                row[i] = ((float)beam[h].cls[si++] + 0.5f) / (float)L->classes[i];
            else
                row[i] = p->mean_params[i];
        }
        if (prob)
            prob[h] = exp(beam[h].logp);
    }
    free(given);
    free(beam);
    return nb;
}

int predictor_nearest(predictor *p, const float *descriptor, int k, size_t *index, double *dist,
                      char *err, size_t errlen)
{
    if (k < 1)
        return pipeline_error(err, errlen, "nearest: k must be at least 1");
    if (reduce(p, descriptor, err, errlen))
        return -1;
    if ((size_t)k > p->n_cat)
        k = (int)p->n_cat;
    double *best = malloc(sizeof(double) * (size_t)k);
    if (!best)
        return pipeline_error(err, errlen, "out of memory");
    int have = 0, pca = p->metric == PREDICTOR_METRIC_PCA;
    for (size_t i = 0; i < p->n_cat; i++) {
        const float *c = p->cat_z + i * (size_t)p->k;
        double s = 0;
        for (int j = 0; j < p->k; j++) {
            double e = (double)c[j] - p->z[j];
            s += e * e * (pca ? (double)p->variance[j] : 1.0); /* whitened * sd = the score */
        }
        if (have == k && s >= best[k - 1])
            continue;
        int at = have < k ? have++ : k - 1;
        while (at > 0 && best[at - 1] > s) { /* insertion: ties keep catalogue order */
            best[at] = best[at - 1];
            index[at] = index[at - 1];
            at--;
        }
        best[at] = s;
        index[at] = i;
    }
    for (int i = 0; dist && i < have; i++)
        dist[i] = sqrt(best[i]);
    free(best);
    return have;
}

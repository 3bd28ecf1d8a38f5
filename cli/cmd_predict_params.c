/* imsynth predict-params: the super-shader parameters a trained predictor gives an image. */
#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli.h"
#include "pipeline/pipeline.h"

#include <cblas.h> /* after our headers: its <complex.h> defines I */

static const char *const help =
    "usage: imsynth predict-params IMAGE [--model MODEL_DIR] [-o PARAMS.json] [options]\n"
    "\n"
    "Describes IMAGE (PNG, JPEG, TIFF, EXR; its largest centred square resampled to the\n"
    "scene's 256 x 256, as the training renders were) with the model's descriptor and\n"
    "writes the predicted super-shader parameters as a parameter file (the format of\n"
    "`imsynth sample`, read by `render --params`, `extract`, `export`): the selectors'\n"
    "likeliest combination with the predicted values; Pattern Offset is the training mean.\n"
    "\n"
    "options:\n"
    "  --model MODEL_DIR      from `imsynth fit-predictor` (default: the bundled assets/model)\n"
    "  -o, --output P.json    the top hypothesis (default: stdout)\n"
    "  --top-k K              also consider K selector combinations: the likeliest and\n"
    "                         K - 1 drawn as --sample-hypotheses says\n"
    "  --sample-hypotheses T  draw from the selectors' distributions sharpened to p^(1/T)\n"
    "                         (default 0.5, predict's; 0: the K likeliest instead)\n"
    "  --hypotheses H.json    write all K as {\"hypotheses\": [{\"probability\": p,\n"
    "                         \"params\": {...}}, ...]}, likeliest first\n"
    "  --nearest N            also list the N nearest training samples (id, distance) in\n"
    "                         H.json's \"nearest\" (retrieval in the model's catalogue)\n"
    "  --nearest-metric M     that retrieval's distance: pca (default, search's) or whitened\n";

static int write_params_atomic(const char *path, const char *const *names, const float *v,
                               int n, char *err, size_t errlen)
{
    sg_params p = {.n = n, .names = (char **)names, .values = (float *)v};
    char e[SG_ERROR_MAX] = "";
    if (sg_params_write_file(path, &p, e, sizeof e) < 0) {
        snprintf(err, errlen, "%s", e);
        return -1;
    }
    return 0;
}

int cmd_predict_params(int argc, char **argv)
{
    const char *sub = "predict-params";
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    const char *image_path = NULL, *model_dir = NULL, *out = NULL, *hyp_path = NULL;
    long long top_k = 1, nearest = 0;
    double temperature = PIPELINE_SAMPLE_HYPOTHESES;
    int metric = PREDICTOR_METRIC_PCA;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (a[0] != '-') {
            if (image_path) {
                cli_error(sub, "one IMAGE only (got \"%s\" and \"%s\")", image_path, a);
                return EXIT_USAGE;
            }
            image_path = a;
            continue;
        }
        if (i + 1 >= argc) {
            cli_error(sub, "%s needs a value (see --help)", a);
            return EXIT_USAGE;
        }
        const char *v = argv[++i];
        if (!strcmp(a, "--model"))
            model_dir = v;
        else if (!strcmp(a, "-o") || !strcmp(a, "--output"))
            out = v;
        else if (!strcmp(a, "--hypotheses"))
            hyp_path = v;
        else if (!strcmp(a, "--top-k")) {
            if (cli_parse_ll(sub, a, v, 1, 4096, &top_k))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--sample-hypotheses")) {
            if (cli_parse_sample_hypotheses(sub, a, v, &temperature))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--nearest-metric")) {
            if (cli_parse_nearest_metric(sub, a, v, &metric))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--nearest")) {
            if (cli_parse_ll(sub, a, v, 1, 4096, &nearest))
                return EXIT_USAGE;
        } else {
            cli_error(sub, "unknown option \"%s\" (see --help)", a);
            return EXIT_USAGE;
        }
    }
    if (!image_path) {
        cli_error(sub, "need IMAGE (see --help)");
        return EXIT_USAGE;
    }
    char err[1024];
    int rc = EXIT_FAILURE_WORK;
    image img = {0}, prepared = {0};
    float *desc = NULL, *params = NULL;
    double *prob = NULL, *dist = NULL;
    size_t *index = NULL;
    pipeline_descriptor *pd = NULL;
    cJSON *hyp = NULL;
    // a threaded OpenBLAS splits the descriptor's sums differently from run to run (nn/nn.h):
    // the same image must give the same parameters
    openblas_set_num_threads(1);
    predictor *p = predictor_load(model_dir, err, sizeof err);
    if (!p)
        goto fail;
    predictor_sample_hypotheses(p, temperature);
    predictor_nearest_metric(p, (predictor_metric)metric);
    if (image_read(image_path, &img, err, sizeof err) ||
        pipeline_prepare_input(&img, 256, &prepared, err, sizeof err))
        goto fail;
    if (!(pd = pipeline_descriptor_create(predictor_descriptor_kind(p), err, sizeof err)))
        goto fail;
    int np = predictor_n_params(p);
    desc = malloc(predictor_descriptor_size(p) * sizeof *desc);
    params = malloc((size_t)top_k * (size_t)np * sizeof *params);
    prob = malloc((size_t)top_k * sizeof *prob);
    if (!desc || !params || !prob) {
        snprintf(err, sizeof err, "out of memory");
        goto fail;
    }
    if (pipeline_descriptor_compute(pd, &prepared, desc, err, sizeof err))
        goto fail;
    float stats[PIPELINE_TEXSTATS_N];
    int use_stats = predictor_uses_texstats(p);
    if (use_stats && pipeline_texstats(&prepared, stats, err, sizeof err))
        goto fail;
    int got = predictor_predict(p, desc, use_stats ? stats : NULL, (int)top_k, params, prob, err,
                                sizeof err);
    if (got < 0)
        goto fail;
    const char *const *names = predictor_param_names(p);
    if (out && write_params_atomic(out, names, params, np, err, sizeof err))
        goto fail;
    if (!out) {
        sg_params top = {.n = np, .names = (char **)names, .values = params};
        char *text = sg_params_to_json(&top);
        if (text)
            fputs(text, stdout);
        free(text);
    }
    if (hyp_path) {
        hyp = cJSON_CreateObject();
        cJSON_AddStringToObject(hyp, "image", image_path);
        cJSON_AddStringToObject(hyp, "model", predictor_dir(p));
        cJSON *list = cJSON_AddArrayToObject(hyp, "hypotheses");
        for (int h = 0; h < got; h++) {
            cJSON *e = cJSON_CreateObject();
            cJSON_AddNumberToObject(e, "probability", prob[h]);
            cJSON_AddItemToObject(e, "params", pipeline_params_json(names, params + (size_t)h * np, np));
            cJSON_AddItemToArray(list, e);
        }
        if (nearest) {
            index = malloc((size_t)nearest * sizeof *index);
            dist = malloc((size_t)nearest * sizeof *dist);
            int n = index && dist ? predictor_nearest(p, desc, (int)nearest, index, dist, err,
                                                      sizeof err)
                                  : -1;
            if (n < 0)
                goto fail;
            cJSON *nl = cJSON_AddArrayToObject(hyp, "nearest");
            for (int i = 0; i < n; i++) {
                long long id;
                const float *cp = predictor_catalogue_params(p, index[i], &id);
                cJSON *e = cJSON_CreateObject();
                cJSON_AddNumberToObject(e, "id", (double)id);
                cJSON_AddNumberToObject(e, "distance", dist[i]);
                cJSON_AddItemToObject(e, "params", pipeline_params_json(names, cp, np));
                cJSON_AddItemToArray(nl, e);
            }
        }
        if (pipeline_write_json_atomic(hyp_path, hyp, err, sizeof err))
            goto fail;
    }
    rc = EXIT_OK;
fail:
    if (rc != EXIT_OK)
        cli_error(sub, "%s", err);
    cJSON_Delete(hyp);
    image_free(&img);
    image_free(&prepared);
    free(desc);
    free(params);
    free(prob);
    free(index);
    free(dist);
    pipeline_descriptor_free(pd);
    predictor_free(p);
    return rc;
}

/*
 * pipeline: the in-process glue every user-facing command shares.
 *
 *   finding data   pipeline_find_data("assets/supershader.json", ...) wherever imsynth runs
 *   material       load -> bind parameters -> (extract) -> compile for the renderer
 *   active mask    which parameters the extracted sub-shader depends on
 *   datagen        sample -> extract -> render -> describe -> store, resumable and sharded
 *   dataset        the SQLite store: open, info, merge, export, contact sheet
 *
 * Dependencies: pipeline uses render, nn, imageio and shadergraph; nothing below it knows
 * pipeline exists. Every call that can fail takes (err, errlen) and writes a message
 * naming the file and the place.
 */
#ifndef IMSYNTH_PIPELINE_H
#define IMSYNTH_PIPELINE_H

#include <stddef.h>
#include <stdint.h>

#include "imageio/imageio.h"
#include "render/render.h"
#include "shadergraph/shadergraph.h"

/* ---------------------------------------------------------------- finding data ----- */

/* Resolves a data file named relative to the source tree ("assets/supershader.json",
 * "assets/scene.json", "blender/import_material.py") to a path that exists, trying in
 * order:
 *   1. the directory in $IMSYNTH_DATA (a source tree or an installed share/imsynth);
 *   2. <directory of the executable>/../share/imsynth (what `cmake --install` lays out);
 *   3. the source tree the executable was built from (build trees);
 *   4. the current directory.
 * A path that is absolute, or starts with "./" or "../", is taken as it is. Returns 0 with
 * the path in out, or -1 with a message listing the places tried. */
int pipeline_find_data(const char *rel, char *out, size_t outlen, char *err, size_t errlen);

/* ---------------------------------------------------------------- material --------- */

/* Loads a graph and, if asked, binds a parameter file (params_path) or frame `seed`'s
 * parameters (seed >= 0); both NULL/-1 leaves the graph's own values. NULL on error. */
sg_graph *pipeline_load_graph(const char *graph_path, const char *params_path, long long seed,
                              char *err, size_t errlen);

/* The renderer's view of a (bound) graph; NULL with a message naming graph_path. */
render_material *pipeline_render_material(const sg_graph *g, const char *graph_path,
                                          sg_blender_mode blender, char *err, size_t errlen);

/* ---------------------------------------------------------------- active mask ------ */

/* Which parameters of the bound graph g the sub-shader depends on. Parameter k is active
 * when setting it alone to another value changes the extracted sub-shader (its JSON,
 * constants included): for a "Mult N" selector, any other of its N choices (bin centres);
 * for a value parameter, any of 7 values spread over (0, 1) (v + 1/8, 2/8, ... mod 1),
 * since a value may act only past a threshold. Testing stops at the first
 * change, so an active parameter costs one extraction or a few. An inactive parameter is
 * folded away (a factor of zero, an unselected branch), so it does not affect the image
 * (tests/unit/test_pipeline.c checks the material's values at other values too). g's
 * parameters are restored before returning.
 * active[k] is 0 or 1 for the k-th parameter of g (sg_params_from_graph order).
 * *subshader_nodes receives the extracted sub-shader's node count (may be NULL).
 * Returns 0, or -1 with a message. */
int pipeline_active_params(sg_graph *g, sg_blender_mode blender, uint8_t *active, int *subshader_nodes,
                           char *err, size_t errlen);
/* The same, the parameters shared among n_graphs threads (at most 8): g[0] is the graph,
 * g[1..] copies of the same graph (any parameters bound; theirs are restored too), one per
 * helper thread. The same active[] as pipeline_active_params(g[0]), in about 1 / n_graphs
 * of its time: its ~50 parameters cost one extraction of the whole super-shader each (7
 * for an inactive value), predict's search asks after every accepted move. */
int pipeline_active_params_on(sg_graph *const *g, int n_graphs, sg_blender_mode blender,
                              uint8_t *active, int *subshader_nodes, char *err, size_t errlen);

/* Of n parameter sets for g (rows in g's parameter order), the indices of the first `keep`
 * at most whose extracted sub-shaders (JSON, constants included) differ from every one kept
 * before: sets that differ only in what the sub-shader ignores render alike, so a search
 * over hypotheses should not spend renders on them. g's parameters are restored. Returns
 * the count, or -1 with a message. */
int pipeline_distinct_subshaders(sg_graph *g, sg_blender_mode blender, const float *params, int n, int keep,
                                 int *index, char *err, size_t errlen);

/* ---------------------------------------------------------------- hashing ---------- */

/* SHA-256 (FIPS 180-4) of data, as 64 lowercase hex digits and a NUL. */
void pipeline_sha256_hex(const void *data, size_t len, char out[65]);

/* ---------------------------------------------------------------- datagen ---------- */

/* A render preset: how datagen renders (fast mode, fixed shading points unless adaptive).
 * Presets are named so that a dataset's config says exactly how it was made. */
typedef struct datagen_preset {
    const char *name;
    int spp, max_spp, light_samples;
    float noise_target;
} datagen_preset;

/* The preset named `name` ("draft", "datagen" (default), "converged"), or NULL. */
const datagen_preset *datagen_preset_find(const char *name);
/* Comma-separated list of preset names, for messages and --help. */
const char *datagen_preset_names(void);
/* Render options of a preset (fast mode), with render_options_default's threads and seed. */
void datagen_preset_render_options(const datagen_preset *p, sg_blender_mode blender, render_options *ro);

typedef enum datagen_images { DATAGEN_IMAGES_NONE, DATAGEN_IMAGES_PNG16, DATAGEN_IMAGES_EXR } datagen_images;
/* What datagen stores as a sample's descriptor (float16): nothing, the VGG19 Gram
 * descriptor (random weights, seed 1, avg3, fp32: 305,888 values), or the MobileNetV2 one
 * (nsfwjs' ImageNet layers, default taps: 38,808 values; nn/nn.h). */
typedef enum datagen_descriptor {
    DATAGEN_DESC_NONE,
    DATAGEN_DESC_VGG19_F16,
    DATAGEN_DESC_MOBILENETV2_F16
} datagen_descriptor;

/* Augmentation: extra views of every sample (same parameters, another image). Parsed from
 * a spec "views=K,light=J,flash=F,exposure=E,wb=W,rotate=D,shift=S" (datagen_augment_parse):
 *   views     extra views per sample (0: none; view 0 is always the plain scene)
 *   light     light position jitter, metres (uniform in a cube of that half-size)
 *   flash     probability that an extra view uses the flash scene (light at the camera)
 *   exposure  exposure jitter in stops (uniform in [-E, E])
 *   wb        white-balance jitter: each of R and B scaled by 2^u, u uniform in [-W, W]
 *   rotate    texture-space rotation about the plane's normal, degrees (uniform in [-D, D])
 *   shift     texture-space offset in x and y, metres (uniform in [-S, S]); rotate and shift
 *             set the plane's object transform (render/scene.c), as Blender's would */
typedef struct datagen_augment {
    int views;
    float light, flash, exposure, wb, rotate, shift;
} datagen_augment;

/* Parses spec into a (all zero when spec is NULL or ""). -1 with a message on error. */
int datagen_augment_parse(const char *spec, datagen_augment *a, char *err, size_t errlen);

typedef struct datagen_options {
    const char *out_path;      /* the dataset file (created if missing) */
    const char *graph_path;    /* super-shader; NULL: found with pipeline_find_data */
    const char *scene_path;    /* NULL: assets/scene.json found likewise */
    const char *flash_scene_path; /* NULL: assets/scene-flash.json found likewise */
    long long first_id, count; /* ids [first_id, first_id + count) ... */
    int shard_index, shard_count; /* ... with id % shard_count == shard_index */
    int threads;               /* worker threads (0 = online CPUs); never changes a byte */
    sg_blender_mode blender;
    const datagen_preset *preset;
    datagen_augment augment;
    datagen_images images;
    datagen_descriptor descriptor;
    /* NULL: the whole descriptor. Else a .npy that selects the stored features: a 0/1
     * mask over the descriptor's 305,888 values, or a list of their indices (e.g. the
     * forest's top-k from `imsynth forest importance`). Its hash is part of the config. */
    const char *descriptor_mask_path;
    int batch;                 /* samples per transaction (0 = 4 x threads) */
    /* Progress: called after every committed batch with counts and seconds spent so far
     * (summed over workers) in each stage. May be NULL. */
    void (*progress)(void *ctx, long long done, long long todo, const double stage_seconds[5]);
    void *progress_ctx;
    /* Polled between batches: non-zero stops cleanly after the current batch (SIGINT). */
    volatile int *stop;
} datagen_options;

/* Names of the stages timed in stage_seconds: sample+bind, extract (active mask), render,
 * describe, store. */
extern const char *const datagen_stage_names[5];

/* Runs datagen: every id of the range and shard that the dataset lacks is made and
 * stored, in batches of one transaction each. A sample's bytes are a pure function of
 * (id, config): the thread count, the shard split and interruptions never change them.
 * Opening an existing dataset made with another config is an error. *made (may be NULL)
 * receives the number of samples stored by this run. Returns 0, 1 when stopped through
 * `stop`, or -1 with a message. */
int datagen_run(const datagen_options *o, long long *made, char *err, size_t errlen);

/* ---------------------------------------------------------------- descriptors ------ */

/* A dataset descriptor outside datagen: the same network, options and float16 rounding
 * as datagen stores (describe.c), so an image described here gives exactly the values a
 * dataset row of the same image holds. Not shareable between threads: one per thread.
 * layer_offsets lets a Gram distance weigh each tapped layer alike. */
typedef struct pipeline_descriptor pipeline_descriptor;

/* The kind a dataset config's descriptor.features names ("mobilenetv2", "vgg19"), or
 * DATAGEN_DESC_NONE for NULL or any other name. */
datagen_descriptor pipeline_descriptor_kind_named(const char *features);
/* kind: DATAGEN_DESC_VGG19_F16 or DATAGEN_DESC_MOBILENETV2_F16 (whole descriptor). */
pipeline_descriptor *pipeline_descriptor_create(datagen_descriptor kind, char *err,
                                                size_t errlen);
void pipeline_descriptor_free(pipeline_descriptor *d);
size_t pipeline_descriptor_size(const pipeline_descriptor *d);
/* Where each Gram layer starts, offsets[n] = size; returns n (the layer count). */
int pipeline_descriptor_layers(const pipeline_descriptor *d, size_t offsets[64]);
/* out (size floats) = the descriptor of a linear RGB(A)/grey image of at least 224 x 224,
 * each value rounded through float16 as stored. Returns 0, or -1 with a message. */
int pipeline_descriptor_compute(pipeline_descriptor *d, const image *img, float *out,
                                char *err, size_t errlen);

#define PIPELINE_TEXSTATS_N 38 /* nn's TEXSTATS_N (asserted equal in describe.c) */
/* The texture statistics (nn's texstats_forward: PIPELINE_TEXSTATS_N floats into out) of the
 * centre 224 x 224 crop the descriptors see, clamped to [0, 1] and sRGB-encoded; a grey
 * image counts as R = G = B. Returns 0, or -1 with a message. */
int pipeline_texstats(const image *img, float *out, char *err, size_t errlen);

/* ---------------------------------------------------------------- dataset ---------- */

typedef struct dataset dataset;

/* Opens an existing dataset read-only (checks the schema version). NULL on error. */
dataset *dataset_open(const char *path, char *err, size_t errlen);
void dataset_close(dataset *d);

typedef struct dataset_info {
    long long samples, rows;   /* distinct ids, rows (ids x views) */
    long long min_id, max_id;
    int n_params;
    size_t descriptor_size;    /* floats per row's descriptor (0: none stored) */
    long long file_bytes;
    char config_hash[65];
    char *config_json;         /* malloc'd; the config table's JSON */
} dataset_info;

int dataset_get_info(dataset *d, dataset_info *info, char *err, size_t errlen);
void dataset_info_free(dataset_info *info);

/* Parameter names in storage order (n_params of them; owned by d). */
const char *const *dataset_param_names(const dataset *d);

/* Streams rows in (id, view) order. Each call fills one row; returns 1 while rows come, 0 at
 * the end, -1 on error. The row's arrays are owned by the iterator (valid until the next
 * call). Descriptors are decoded to float (NULL when none stored); images are decoded only
 * when want_image. */
typedef struct dataset_row {
    long long id;
    int view;
    const float *params;       /* n_params */
    const uint8_t *active;     /* n_params */
    const float *descriptor;   /* descriptor_size, or NULL */
    const char *view_json;     /* the view's scene settings */
    int subshader_nodes;
    image img;                 /* only with want_image; zero otherwise */
} dataset_row;

typedef struct dataset_iter dataset_iter;
dataset_iter *dataset_iter_new(dataset *d, int want_descriptor, int want_image, char *err,
                               size_t errlen);
int dataset_iter_next(dataset_iter *it, dataset_row *row, char *err, size_t errlen);
void dataset_iter_free(dataset_iter *it);

/* SHA-256 over every row's contents in (id, view) order: equal digests mean the same
 * samples, byte for byte, however the files were made (shards, merges, resumed runs). */
int dataset_digest(dataset *d, char out[65], char *err, size_t errlen);

/* Every row's descriptor, parameters and active mask as row-major arrays (malloc'd):
 * X rows x descriptor_size floats, Y rows x n_params, M rows x n_params bytes (1 =
 * active), in (id, view) order; the input of `imsynth forest fit --dataset` and of the
 * predictor's training. An error when no descriptor is stored. */
int dataset_read_arrays(dataset *d, float **X, float **Y, uint8_t **M, size_t *rows,
                        size_t *x_cols, size_t *y_cols, char *err, size_t errlen);

/* Merges datasets made with the same config into out_path (written to a temporary file
 * and renamed). A config mismatch or an id present in two inputs is an error naming both
 * files. */
int dataset_merge(const char *const *inputs, int n_inputs, const char *out_path, char *err,
                  size_t errlen);

/* Recomputes the descriptors of src's stored renders into a new dataset out_path (written
 * to a temporary file and renamed): every row as in src, the descriptor `kind` computed as
 * datagen does (restricted to mask_path's features when not NULL), the config's
 * descriptor section changed accordingly. For a dataset made with --descriptor none, the
 * other network's descriptor, or fewer features. */
int dataset_describe(const char *src_path, const char *out_path, datagen_descriptor kind,
                     const char *mask_path, int threads, char *err, size_t errlen);

/* Writes ids.npy (int64), params.npy (float32, rows x n_params), active.npy (uint8),
 * views.npy (int32), descriptors.npy (float16, when stored) and params.txt (names) into
 * dir (created if missing), each atomically. */
int dataset_export_npy(dataset *d, const char *dir, char *err, size_t errlen);

/* A contact sheet PNG of the first `count` rows' renders (`cols` per row of the sheet),
 * each labelled with its id (and view when > 0). */
int dataset_contact_sheet(dataset *d, const char *png_path, int count, int cols, int tile,
                          char *err, size_t errlen);

/* ---------------------------------------------------------------- user images ------ */

/* An image as the training renders were: its largest centred square (a photo's sides are
 * cropped, not squeezed), resampled to size x size (the scene's 256: area-correct when
 * shrinking, bilinear when enlarging). out is allocated. Returns 0, or -1 with a message. */
int pipeline_prepare_input(const image *in, int size, image *out, char *err, size_t errlen);

/* Writes text to path through path.tmp renamed into place: the file is whole or absent.
 * Returns 0, or -1 with a message naming the file. */
int pipeline_write_text_atomic(const char *path, const char *text, char *err, size_t errlen);

/* The same for a JSON document, pretty-printed, ending with a newline (cJSON's). */
struct cJSON;
int pipeline_write_json_atomic(const char *path, const struct cJSON *j, char *err,
                               size_t errlen);
/* A parameter set as a JSON object keyed by name, each value in the shortest form that reads
 * back as the same float (sg_params_to_json's); an empty object when out of memory. */
struct cJSON *pipeline_params_json(const char *const *names, const float *values, int n);

/* Output directories written whole (predict's OUTDIR, evaluate's report): the files go to
 * OUT.tmp.PID, renamed to OUT when complete. A run killed before the rename leaves its
 * OUT.tmp.PID behind; the next run for the same OUT removes those whose process is gone
 * (pipeline_remove_stale_temps), as SQLite rolls back a hot journal. The directories hold
 * files only: pipeline_remove_flat_dir unlinks the entries and removes the directory (a
 * subdirectory, which no writer makes, keeps it). */
void pipeline_remove_flat_dir(const char *dir);
void pipeline_remove_stale_temps(const char *out_dir);

/* A user's image for predict and search (PNG, JPEG, TIFF, EXR through image_read), refused
 * when smaller than 32 x 32 or when any value is NaN or infinite, with a message naming the
 * file. out is allocated. Returns 0 or -1. */
int pipeline_read_user_image(const char *path, image *out, char *err, size_t errlen);

/* ---------------------------------------------------------------- loss curves ------ */

/* A training run's loss curve as a small SVG line chart: log-scale training loss over n
 * points (steps or epochs, named by xlabel; blue), validation losses (NaN or <= 0 where
 * absent) as red dots, min/max labels; written through a temporary file. */
int pipeline_write_loss_svg(const char *path, const double *loss, const double *val, long long n,
                            const char *xlabel, char *err, size_t errlen);

/* ---------------------------------------------------------------- predictor -------- */
/*
 * A model directory, written by predictor_fit (`imsynth fit-predictor`):
 *   model.json               what the model is: format "imsynth-model/1", the training
 *                            dataset's config (super-shader, scene, preset, descriptor),
 *                            parameter names and roles, the input transform, the network,
 *                            the training settings and its figures
 *   transform.safetensors    the input transform (signed-log scales, standardisation,
 *                            PCA basis and variances) and the training mean parameters
 *   network.safetensors      the MLP (an nn checkpoint: arch and heads in its metadata)
 *   catalogue.safetensors    the training samples' reduced descriptors, parameters and
 *                            ids: nearest-neighbour retrieval and baselines
 *   losses.csv, loss.svg     the training curve (per epoch: losses, validation accuracy
 *                            of the selectors, median R^2 of the values)
 * Parameter roles: a "Mult N" selector is a classification (a softmax head of N classes);
 * "Pattern Offset" moves the pattern like a seed and is not a target (a prediction carries
 * the training mean); every other parameter is a value regressed where it is active.
 *
 * A predictor is not shareable between threads (the network keeps activations): one per
 * thread, or calls from one thread at a time.
 */
typedef struct predictor predictor;

/* model_dir NULL: the bundled model, assets/model (found as pipeline_find_data finds data). */
predictor *predictor_load(const char *model_dir, char *err, size_t errlen);
void predictor_free(predictor *p);
/* The directory it was loaded from (the bundled model's resolved path). */
const char *predictor_dir(const predictor *p);

int predictor_n_params(const predictor *p);
/* Names in the super-shader's parameter order (sg_params_from_graph's). */
const char *const *predictor_param_names(const predictor *p);
/* The descriptor the model reads (a dataset's rows, or pipeline_descriptor_create(kind)). */
datagen_descriptor predictor_descriptor_kind(const predictor *p);
size_t predictor_descriptor_size(const predictor *p);
/* The training dataset's config JSON (as `imsynth dataset info` prints it). */
const char *predictor_dataset_config(const predictor *p);

/* The training set's mean of every parameter (the thesis's result, as a baseline). */
const float *predictor_mean_params(const predictor *p);

/* The catalogue: training samples kept with the model. Sample i's parameters (n_params)
 * and, if id is not NULL, its dataset id. */
size_t predictor_catalogue_size(const predictor *p);
const float *predictor_catalogue_params(const predictor *p, size_t i, long long *id);

/* Whether the network also reads the image's texture statistics (pipeline_texstats),
 * which predictor_predict then needs. */
int predictor_uses_texstats(const predictor *p);

/* Up to k hypotheses for a descriptor (predictor_descriptor_size floats) and, when the
 * model uses them, the same image's texture statistics (PIPELINE_TEXSTATS_N floats; may be NULL
 * otherwise), most probable first: the k likeliest combinations of the selectors under
 * the network's (independent) softmax heads, each with the value parameters the network
 * predicts. params (k x n_params), prob (k, may be NULL): the combination's probability.
 * Returns the number written (>= 1), or -1 with a message. */
int predictor_predict(predictor *p, const float *descriptor, const float *texstats, int k,
                      float *params, double *prob, char *err, size_t errlen);
/* How predictor_predict chooses its k combinations from then on: temperature 0 (the
 * default) the k likeliest; T > 0 the likeliest and k - 1 distinct others drawn from the
 * heads' distributions sharpened to p^(1/T) (the same draws for every call: a pure
 * function of the draw's index), which spreads the k over more of the uncertain selectors
 * than the likeliest few do (EVALUATION.md, session 24). Still most probable first. */
void predictor_sample_hypotheses(predictor *p, double temperature);

/* The k catalogue samples nearest to a descriptor in the model's reduced input space,
 * nearest first: index (k), dist (k, may be NULL), measured as predictor_nearest_metric
 * says. Returns the number written, or -1 with a message. */
int predictor_nearest(predictor *p, const float *descriptor, int k, size_t *index,
                      double *dist, char *err, size_t errlen);
/* How predictor_nearest measures. PCA (the default): Euclidean over the PCA scores, each
 * whitened component scaled back by its standard deviation, which is the distance of the
 * standardised signed-log Gram values within the leading components. WHITENED: over the
 * network's unit-variance inputs; it gives the many small components, most of them
 * particular to one render, as much say as the few large ones that carry what renders
 * share (EVALUATION.md, session 11), and retrieves samples farther under the Gram
 * distance (session 27). Predict's candidates still use it: from the PCA scores' closer
 * starts its refined result was no closer (predict_options_default). */
typedef enum predictor_metric { PREDICTOR_METRIC_PCA, PREDICTOR_METRIC_WHITENED } predictor_metric;
extern const char *const predictor_metric_names[2]; /* "pca", "whitened" */
void predictor_nearest_metric(predictor *p, predictor_metric metric);

/* Training (predictor_fit.c). The run is resumable: it lives in OUT.partial/ (checkpoint
 * after every epoch) and the same call continues it, to the same bytes as an uninterrupted
 * run; OUT appears complete, by one rename, or not at all. */
typedef struct predictor_fit_result {
    int best_epoch;
    double best_val_loss, mean_selector_accuracy, median_value_r2, seconds;
    size_t train_rows, val_rows;
} predictor_fit_result;

#define PREDICTOR_MAX_MEMBERS 16

typedef struct predictor_fit_options {
    const char *dataset_path;
    const char *val_dataset_path; /* NULL: hold out val_fraction of the ids (by a hash) */
    double val_fraction;
    long long max_ids;            /* 0: every sample; else the first max_ids ids */
    const char *out_dir;          /* must not exist */
    int components;               /* PCA components (the network's inputs) */
    int per_tap;                  /* split the components among the descriptor's taps, a
                                   * PCA of each tap's values alone (predictor_fit.c) */
    const char *feature_mask_path; /* NULL, or a 1 x d 0/1 .npy: the PCA sees only its
                                    * features (a forest's: `forest importance`) */
    int texstats;                 /* the network also reads each render's texture
                                   * statistics (pipeline_texstats), after the components */
    int half;                     /* store the PCA basis, the catalogue's reduced
                                   * descriptors and the networks as float16 (the basis
                                   * rounded before it is used, so training and prediction
                                   * see the same values; the networks rounded once
                                   * trained, and the model's figures are the rounded
                                   * networks'): half the bytes of a model to ship */
    long long catalogue;          /* 0: every training sample in the catalogue; else the
                                   * first N (by id) */
    int conditional;              /* the value parameters given the selectors: the network
                                   * also reads a combination's one-hot classes (zeros: it
                                   * predicts the selectors and values as without; a
                                   * combination: that combination's values), so that each
                                   * top-k hypothesis gets its own (predictor_fit.c) */
    const char *hidden;           /* hidden widths, "1024-1024" */
    int epochs, batch;
    float lr, weight_decay, dropout;
    float value_weight;           /* the value head's loss weight (selectors' sum to 1) */
    uint64_t seed;
    int members;                  /* 0 or 1: one network; M: an ensemble of M networks on
                                   * the same inputs, member m trained from seed + m, whose
                                   * outputs predictions average (at most
                                   * PREDICTOR_MAX_MEMBERS) */
    int threads;                  /* 0 = 1; never changes a bit */
    int restart;                  /* discard an unfinished run with other settings */
    void (*progress)(void *ctx, int member, int members, int epoch, int epochs,
                     double train_loss, double val_loss, double val_selector_accuracy,
                     double val_median_r2, double seconds);
    void (*progress_text)(void *ctx, const char *what);
    void *progress_ctx;
    volatile int *stop;           /* non-zero: stop after the current epoch (resumable) */
    predictor_fit_result *result; /* may be NULL */
} predictor_fit_options;

void predictor_fit_defaults(predictor_fit_options *o);
/* Returns 0 (OUT written), 1 (stopped through `stop`; rerun to continue) or -1 with a
 * message. */
int predictor_fit(const predictor_fit_options *o, char *err, size_t errlen);

/* ---------------------------------------------------------------- refinement ------- */
/*
 * A derivative-free search over parameters in [0, 1] (refine.c): the step after the
 * predictor's and the catalogue's candidates, in `predict` and `evaluate`. The caller owns
 * the loss (render, describe, compare) and says, for the current point, which parameters
 * matter (pipeline_active_params); the search moves only those.
 */
typedef enum refine_kind {
    REFINE_VALUE,    /* in [0, 1], clamped */
    REFINE_CIRCULAR, /* in [0, 1), 0 and 1 the same (a hue): wrapped */
    REFINE_SELECTOR, /* choices[i] bins; the value is its bin's centre */
    REFINE_FIXED,    /* never moved (Pattern Offset: a seed, not a look) */
    REFINE_ZOOM      /* a value that multiplies coordinates far from their origin (a noise's
                        Scale times Pattern Offset's shift of up to 100): any change of it
                        also draws a new instance of the pattern, so the loss is rugged along
                        it at every step size. Clamped like a value. */
} refine_kind;

typedef struct refine_space {
    int n;
    const refine_kind *kind; /* n */
    const int *choices;      /* n: a selector's number of choices (others ignored) */
} refine_space;

typedef enum refine_method {
    REFINE_COORDINATE,
    REFINE_ES,
    REFINE_RANDOM,
    REFINE_ES_SPLIT,
    REFINE_ES_MIRROR,
    REFINE_COORDINATE_SWEEP,
    REFINE_COORDINATE_JUMP,
    REFINE_COORDINATE_ZOOM,
    REFINE_N_METHODS
} refine_method;
extern const char *const refine_method_names[REFINE_N_METHODS];
/* The method named `name` ("coordinate", "es", "random", "es-split", "es-mirror",
 * "coordinate-sweep", "coordinate-jump", "coordinate-zoom"), or -1. */
int refine_method_parse(const char *name);
/* The names, comma-separated, for messages (as datagen_preset_names). */
const char *refine_method_list(void);

/* Which colour term the loss uses (evaluate_colour_term): the box averages compared where
 * they are (PIPELINE_COLOUR_BLOCKS, evaluate_colour_distance) or as distributions, blind to
 * where they are (PIPELINE_COLOUR_SORTED, evaluate_colour_sorted_distance). */
typedef enum pipeline_colour_term {
    PIPELINE_COLOUR_BLOCKS,
    PIPELINE_COLOUR_SORTED,
    PIPELINE_N_COLOUR_TERMS
} pipeline_colour_term;
extern const char *const pipeline_colour_term_names[PIPELINE_N_COLOUR_TERMS];

/* The loss has two terms, the Gram distance and the colour term (refine_loss_fn), and the
 * search minimises gram + w x colour: w = colour_weight, except during the first
 * colour_phase evaluations, when it is colour_phase_weight (a colour-heavy start: the
 * search first finds the input's colour, then the texture; pipeline/refine.c says why). */
typedef struct refine_options {
    refine_method method;
    int budget;      /* loss evaluations in all, the start's included (>= 1) */
    double step;     /* a value's first step (coordinate) or the first sigma (es) */
    double min_step; /* steps never shrink below this */
    uint64_t seed;
    double colour_weight;       /* w after the colour phase (PIPELINE_COLOUR_WEIGHT) */
    pipeline_colour_term colour_term; /* what C is (PIPELINE_COLOUR_TERM); the callers
                                       * compute it, the search only weighs it */
    int colour_phase;           /* evaluations weighted colour_phase_weight (0: none) */
    double colour_phase_weight; /* w during them */
    int starts; /* starts raced (refine_race; >= 1): the caller's best few candidates */
    double start_colour_weight; /* w when the caller ranks its candidates as starts
                                 * (PIPELINE_START_COLOUR_WEIGHT): predict's and
                                 * evaluate's -refine rows', not the search's */
} refine_options;
/* coordinate-sweep (the measured best at predict's budget: docs/predict.md), budget 48,
 * step 0.25, min_step 1/128, seed 1, colour_weight PIPELINE_COLOUR_WEIGHT, no colour phase
 * (its weight PIPELINE_COLOUR_PHASE_WEIGHT when one is asked for), one start. */
void refine_options_default(refine_options *o);

/* The search space of a super-shader's parameters, from their names: "Mult N" selectors,
 * "Pattern Offset" fixed (a seed, not a look), hues circular, the noises' "Scale"s zooms,
 * the rest values. kind and
 * choices have n entries. */
void refine_space_for_params(const char *const *names, int n, refine_kind *kind, int *choices);

/* The loss predict and evaluate's refinement minimise: gram + colour_weight x colour (the
 * training descriptor's Gram distance and evaluate_colour_distance's term). One definition,
 * so that the evaluation measures the search predict runs. */
double pipeline_refine_loss(double gram, double colour, double colour_weight);
#define PIPELINE_COLOUR_WEIGHT 4.0        /* predict's default */
/* predict's default: it ended closer under the VGG19 judge on 37 of 46 inputs, level under
 * the training descriptor (EVALUATION.md, session 29) */
#define PIPELINE_COLOUR_TERM PIPELINE_COLOUR_SORTED
#define PIPELINE_COLOUR_PHASE_WEIGHT 12.0 /* the colour phase's, when there is one */
#define PIPELINE_START_COLOUR_WEIGHT 4.0  /* ranking the candidates as starts */
/* The predictor's top k: its likeliest combination and k - 1 drawn at this temperature
 * (predictor_sample_hypotheses), predict's, predict-params' and evaluate's default: the
 * rendered pick is closer than the k likeliest's (EVALUATION.md, sessions 24 and 26). */
#define PIPELINE_SAMPLE_HYPOTHESES 0.5

/* The two terms of a parameter set's loss (each lower is better; the search weighs them,
 * refine_options): 0, or -1 with a message. A loss of one term sets colour to 0. */
typedef int (*refine_loss_fn)(void *ctx, const float *params, double *gram, double *colour,
                              char *err, size_t errlen);
/* Which parameters matter at params (active[i] 0 or 1): 0, or -1 with a message. */
typedef int (*refine_active_fn)(void *ctx, const float *params, uint8_t *active, char *err,
                                size_t errlen);

typedef struct refine_result {
    double *curve; /* budget entries, the first `evals`: best loss after each evaluation,
                    * under that evaluation's weight */
    int evals, accepted;
    int start_movable; /* parameters the search could move at the start (the winner's) */
    double start_loss, best_loss; /* both under colour_weight, the final weight; start_loss
                                   * is the best of the starts' */
    int winner;       /* refine_race: the start whose search gave the result (0: one start) */
    int winner_evals; /* the evaluations spent on the winner's search */
    int n_starts;     /* the starts searched (<= the budget) and, for each, malloc'd: */
    double *reached;  /* the loss its search reached, under colour_weight */
    int *spent;       /* the evaluations its search made */
} refine_result;

/* Searches from params (in: the start, every value in [0, 1]; out: the best found) with
 * o->method, deterministically for o->seed. The result's curve is malloc'd: free with
 * refine_result_free. Returns 0, or -1 with a message (a callback's, or a bad start). */
int refine_search(const refine_space *s, const refine_options *o, refine_loss_fn loss,
                  refine_active_fn active, void *ctx, float *params, refine_result *r,
                  char *err, size_t errlen);
/* Several starts (starts: n_starts x s->n, the likeliest first) raced by successive halving
 * within o->budget evaluations in all: every start is searched for an equal share, the
 * better half (by loss under colour_weight) goes on with the next share, and so on until
 * one is left, which gets the last share (pipeline/refine.c says why). n_starts 1 is
 * refine_search, evaluation for evaluation. Starts beyond the budget are not used. params
 * (out, s->n): the best found; r->winner says whose search found it, r->curve is the best
 * loss over all the searches after each evaluation. 0, or -1 with a message. */
int refine_race(const refine_space *s, const refine_options *o, refine_loss_fn loss,
                refine_active_fn active, void *ctx, const float *starts, int n_starts,
                float *params, refine_result *r, char *err, size_t errlen);
void refine_result_free(refine_result *r);

/* ---------------------------------------------------------------- evaluation ------- */
/*
 * `imsynth evaluate` (evaluate.c; docs/evaluation.md): every test input (a synthetic test
 * dataset's rows, hand-made Cycles materials) against every method (the training mean, a
 * random training sample, nearest-neighbour retrieval, the predictor, and their top-k picked
 * by rendering), in parameter space and in image space. The arithmetic below
 * (evaluate_metrics.c) is public so that tests and benchmarks measure the same way.
 */

/* Gram distance of two descriptors whose layer l spans [offsets[l], offsets[l + 1])
 * (pipeline_descriptor_layers): the mean over layers of
 *     ||a_l - b_l||_2 / (||a_l||_2 + ||b_l||_2 + 1e-12),
 * so each layer counts alike whatever its size or scale; symmetric, in [0, 1], 0 for equal
 * descriptors, unchanged when both are scaled alike. Sums in double. */
double evaluate_gram_distance(const float *a, const float *b, const size_t *offsets,
                              int n_layers);

/* The colour term: mean |a - b| over the 32 x 32 box averages (7 x 7 pixels each) of the
 * two images' centre 224 x 224 crops, R, G and B, values clamped to [0, 1] first (what the
 * descriptors see; a stored dataset render is clamped so). Grey images count as R = G = B.
 * Both images at least 224 x 224. Returns 0, or -1 with a message. */
int evaluate_colour_distance(const image *a, const image *b, double *out, char *err,
                             size_t errlen);

/* The colour term blind to where colours are: the two images' 32 x 32 box averages (as
 * evaluate_colour_distance takes them) projected on six directions (R, G, B and half of
 * R - G, G - B, B - R), and along each the mean |a_i - b_i| of the projections sorted
 * ascending (the 1-D Wasserstein-1 distance between the two distributions), averaged over
 * the directions: a sliced Wasserstein distance with fixed slices. Never above
 * evaluate_colour_distance of the same pair; 0 for a shifted or shuffled copy.
 * Why: compared box by box, a high-contrast pattern (bricks, planks) at another offset is
 * farther from itself than a flat field of its mean colour is, so a search under that
 * term is pushed towards featureless materials (EVALUATION.md, session 29). */
int evaluate_colour_sorted_distance(const image *a, const image *b, double *out, char *err,
                                    size_t errlen);
/* term's distance of a and b (either function above). */
int evaluate_colour_term(pipeline_colour_term term, const image *a, const image *b,
                         double *out, char *err, size_t errlen);

/* A distance divided by the target's floor (two renders of the target's own parameters at
 * Pattern Offsets 0.5 apart; for a hand-made material, its render against its render with
 * shifted texture coordinates): 1 is as close as an exact answer can be expected to come.
 * A floor below EVALUATE_FLOOR_EPSILON (a material that nothing moves) is taken as the
 * epsilon, and the report counts such floors. */
#define EVALUATE_FLOOR_EPSILON 1e-3
double evaluate_normalise(double distance, double floor);

/* The q-quantile (q in [0, 1]) of n values, linear between order statistics (numpy's
 * default): position q (n - 1) of the sorted values. NaNs are left out; NAN when nothing is
 * left. v is not changed. */
double evaluate_quantile(const double *v, size_t n, double q);

/* The coefficient of determination of predictions against truths (n of them, stride 1):
 * 1 - SSE / SST, SST taken about `reference_mean` (the training mean: a predictor that
 * predicts it scores exactly 0, any other constant less). NAN when SST is 0 or n is 0. */
double evaluate_r2(const double *pred, const double *truth, size_t n, double reference_mean);
/* std(pred) / std(truth) (population standard deviations): 0 for a constant predictor, 1
 * when the predictions vary as much as the targets. NAN when the truths do not vary. */
double evaluate_spread(const double *pred, const double *truth, size_t n);
/* Pearson's correlation of predictions and truths. With the predictions' mean at the truths'
 * and spread s, R^2 = 2 s r - s^2: at most r^2 (at s = r, what a least-squares predictor
 * converges to), so R^2 >= 0.3 and s >= 0.7 together need r >= 0.564. NAN when either
 * does not vary. */
double evaluate_correlation(const double *pred, const double *truth, size_t n);
/* The 95% Wilson score interval of a share of k successes in n trials ("beats the mean on
 * k of n inputs"): the shares p for which k / n lies within 1.96 standard errors
 * sqrt(p (1 - p) / n) of p. Unlike the normal approximation around k / n, it stays inside
 * [0, 1] and is not empty at k = 0 or k = n. It says how far a share measured on n inputs
 * may be from the share on all inputs like them: the sampling of the inputs only, not the
 * variation between training runs or render seeds. lo = hi = NAN when n is 0. */
void evaluate_share_interval(size_t k, size_t n, double *lo, double *hi);

typedef struct evaluate_options {
    const char *model_dir;    /* written by predictor_fit */
    const char *test_path;    /* a test dataset (renders stored); may be NULL with handmade */
    const char *handmade_dir; /* NULL, or a folder of <name>/{render,shifted,flash}.exr */
    const char *out_dir;      /* the report folder (must not exist; written whole or not) */
    const char *graph_path;   /* super-shader; NULL: found with pipeline_find_data */
    const char *scene_path, *flash_scene_path; /* NULL: assets/scene.json, scene-flash.json */
    const datagen_preset *preset; /* how candidates and results are rendered and measured */
    const datagen_preset *refine_preset; /* the refinement's renders; NULL: preset */
    int top_k;                /* candidates of the -topk methods (>= 1) */
    double sample_hypotheses; /* 0: the predictor's k likeliest combinations; T > 0:
                               * predictor_sample_hypotheses(T) */
    predictor_metric nearest_metric; /* the nearest methods' retrieval (PCA) */
    long long limit;          /* at most this many test rows (<= 0: all) */
    int threads;              /* workers (0 = online CPUs); never changes a byte */
    sg_blender_mode blender;
    uint64_t seed;            /* render seeds and the random method's draws */
    int sheet_inputs;         /* synthetic inputs on the contact sheet (16) */
    refine_options refine;    /* the -refine methods' search (budget 1: their start) */
    /* After every input, with counts and seconds since the start. May be NULL. */
    void (*progress)(void *ctx, long long done, long long todo, double seconds);
    void *progress_ctx;
} evaluate_options;

/* Runs the evaluation into o->out_dir: report.json, summary.csv, summary.md, inputs.csv
 * (every input, method and distance), sheet-synthetic.png and sheet-handmade.png (when
 * there are such inputs), index.html, timings.json (wall clock: apart, so that the rest
 * does not depend on the run, --threads included).
 * The folder is written as o->out_dir.tmp.PID and renamed when complete; on error nothing
 * is left. Returns 0, or -1 with a message naming the file and the place. */
int evaluate_run(const evaluate_options *o, char *err, size_t errlen);

/* ---------------------------------------------------------------- predict ---------- */
/*
 * `imsynth predict` (predict.c; docs/predict.md): an image in, a Blender material out.
 * Describe -> the predictor's first top-k distinct hypotheses and the catalogue's nearest
 * samples -> each rendered and scored -> the best refined (refine_race: the
 * refine.starts best raced, one by default) -> rendered at the final
 * preset -> sub-shader extracted. OUTDIR receives material.json (the sub-shader, in the
 * graph format blender/import_material.py builds), params.json (super-shader parameters),
 * preview.png, compare.png (input | preview | loss curve) and report.json (format
 * "imsynth-predict/1": candidates and their losses, the winner, the curve, timings).
 */
typedef enum predict_light { PREDICT_LIGHT_SCENE, PREDICT_LIGHT_FLASH, PREDICT_LIGHT_AUTO } predict_light;
extern const char *const predict_light_names[3]; /* "scene", "flash", "auto" */
/* Which way the input's pattern runs. The super-shader's bricks, planks and bands run
 * along X; a turn puts them along Y (sg_graph_rotate_texture). 0: as the super-shader
 * makes them; 90: turned a quarter (the predictor and the catalogue see the input turned
 * back, and the material carries a Mapping node); auto: the candidates of both, the loss
 * keeps the better. */
typedef enum predict_rotation { PREDICT_ROTATION_0, PREDICT_ROTATION_90, PREDICT_ROTATION_AUTO } predict_rotation;
extern const char *const predict_rotation_names[3]; /* "0", "90", "auto" */

typedef struct predict_options {
    const char *image_path;
    const char *out_dir;      /* written whole or not at all; an earlier output is replaced */
    const char *model_dir;    /* NULL: assets/model found with pipeline_find_data */
    const char *graph_path;   /* NULL: assets/supershader.json likewise */
    const char *scene_path, *flash_scene_path; /* NULL: assets/scene.json, scene-flash.json */
    int top_k;                /* predictor hypotheses (8) */
    double sample_hypotheses; /* 0: the top_k likeliest; T > 0: predictor_sample_hypotheses
                               * (PIPELINE_SAMPLE_HYPOTHESES) */
    int nearest;              /* catalogue candidates (8; 0: none) */
    predictor_metric nearest_metric; /* their retrieval (predictor_nearest_metric; whitened) */
    refine_options refine;    /* budget 1: the best candidate as it is (default 350); its
                               * colour_weight also scores the candidates and the final */
    const datagen_preset *search_preset; /* the candidates ("draft") */
    const datagen_preset *refine_preset; /* the refinement's renders ("draft") */
    const datagen_preset *final_preset;  /* the preview ("converged") */
    predict_light light;      /* where the input's light was: our scene, a flash, or try both (auto) */
    predict_rotation rotation; /* the texture rotations tried (0, 90, or both: auto) */
    double rotation_margin;   /* auto: the turned candidates win only when their least loss
                               * is below margin x the unturned ones' (1: the least wins) */
    int threads;              /* render threads (0 = online CPUs); never changes a byte */
    sg_blender_mode blender;
    uint64_t seed;            /* render noise (one seed for the whole run) */
    const char *blend;        /* NULL, or a Blender executable: OUTDIR also gets
                               * material.blend, built by blender/import_material.py (the
                               * material on our scene's plane) */
    /* After every render with the stage ("describe", "candidates", "refine", "final
     * render"), counts and the best loss so far. May be NULL. */
    void (*progress)(void *ctx, const char *stage, int done, int todo, double best);
    void *progress_ctx;
    /* A doubt about the result that is not an error (a model trained on another
     * super-shader than graph_path); also listed in report.json's "warnings". May be NULL. */
    void (*warn)(void *ctx, const char *message);
    void *warn_ctx;
} predict_options;

/* top_k 8 sampled at PIPELINE_SAMPLE_HYPOTHESES, nearest 8 (whitened), refinement
 * coordinate-sweep with budget 350, presets draft (candidates) / draft (refinement) / converged (final),
 * light auto, rotation auto (margin 1), colour_weight 4, blender 4, seed 1. */
void predict_options_default(predict_options *o);
/* Returns 0, or -1 with a message naming the file and the place. */
int predict_run(const predict_options *o, char *err, size_t errlen);

/* ---------------------------------------------------------------- search ----------- */
/*
 * `imsynth search` (search.c): the k materials nearest an image, nearest first, as a
 * labelled contact sheet (input first) and, if asked, a JSON list (id, view, distance, the
 * `imsynth export --seed ID` command, parameters). From a model's catalogue (default: the
 * bundled model; its retrieval distance; hits rendered at `preset`) or from a dataset (the
 * Gram distance of its stored descriptor over every row; its stored renders shown).
 */
typedef struct search_options {
    const char *image_path, *sheet_path;
    const char *json_path;    /* NULL: none */
    const char *model_dir;    /* NULL: assets/model (when no dataset_path) */
    const char *dataset_path; /* search this dataset instead of a catalogue */
    predictor_metric nearest_metric; /* a catalogue's retrieval (PCA) */
    const char *graph_path, *scene_path; /* NULL: found with pipeline_find_data */
    int k;
    int cols, tile;           /* the sheet (0: 5 columns of 160 pixels) */
    const datagen_preset *preset; /* renders of catalogue hits */
    int threads, blender;
    int print;                /* also "id\tview\tdistance" lines on stdout */
} search_options;
int search_run(const search_options *o, char *err, size_t errlen);

#endif

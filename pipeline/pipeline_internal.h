/* Private to pipeline/: helpers its files share. */
#ifndef IMSYNTH_PIPELINE_INTERNAL_H
#define IMSYNTH_PIPELINE_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "nn/nn.h"
#include "pipeline/pipeline.h"

/* Formats a message into err (if not NULL); returns -1 for chaining. */
int pipeline_error(char *err, size_t errlen, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Seconds on the monotonic clock. */
double pipeline_now(void);

/* Worker threads for an option where 0 means every online core: asked if > 0, else the
 * online cores (at least 1). */
int pipeline_thread_count(int asked);

/* Inserts index j into order[0..j), kept ascending by key[] (NaN last; ties: the earlier
 * index first): one step of an insertion sort, for ranking an input's few candidates. */
void pipeline_insert_by_key(int *order, int j, const double *key);

/* SplitMix64 (Steele, Lea and Flood 2014): the next of a seeded stream of 64-bit values,
 * for datagen's augmentation and the evaluation's draws. */
static inline uint64_t pipeline_splitmix64(uint64_t *state)
{
    uint64_t z = (*state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* Reads a whole file (NUL-terminated; *len excludes the NUL). NULL with a message. */
char *pipeline_read_file(const char *path, size_t *len, char *err, size_t errlen);

/* The SHA-256 of a file's bytes, as 64 hex digits: how a dataset, a model and predict name
 * the super-shader and the masks they were made with. -1 with a message naming the file. */
int pipeline_file_sha256(const char *path, char out[65], char *err, size_t errlen);

/* SHA-256, incrementally (sha256.c). */
typedef struct sha256_ctx {
    uint32_t h[8];
    uint64_t length; /* bytes so far */
    unsigned char block[64];
    size_t fill;
} sha256_ctx;
void sha256_init(sha256_ctx *c);
void sha256_update(sha256_ctx *c, const void *data, size_t len);
void sha256_final_hex(sha256_ctx *c, char out[65]);

/* The centre crop every measure of an image reads (the descriptors, the texture
 * statistics, the colour terms): PIPELINE_CROP x PIPELINE_CROP pixels from column
 * (width - PIPELINE_CROP) / 2 and row (height - PIPELINE_CROP) / 2. An image that is only
 * measured need not be rendered beyond it (predict's search, render_options' window). */
enum { PIPELINE_CROP = 224 };
_Static_assert((int)PIPELINE_CROP == (int)VGG_INPUT_SIZE && (int)PIPELINE_CROP == (int)MNV2_INPUT_SIZE,
               "the descriptors' crop");
/* Sets ro's window to the scene's PIPELINE_CROP centre when the render allows one (no
 * adaptive sampling; the image at least the crop): a render only measured, never shown,
 * then costs 77% of its shading points at 256 x 256, its measures the same bit for bit
 * (test_render's window test). */
void pipeline_render_crop_only(render_options *ro, const render_scene *s);

/* ---------------------------------------------------------------- predictor -------- */
/* Shared by predictor.c (loading, prediction) and predictor_fit.c (training). */

#define MODEL_FORMAT "imsynth-model/1"

/* A hue is a value on a circle (0 and 1 are the same colour): it is learnt as the point
 * ((cos 2 pi h + 1) / 2, (sin 2 pi h + 1) / 2), two value columns, so that a red near 0.99
 * and one near 0.01 are neighbours to the loss too. */
enum { ROLE_VALUE, ROLE_SELECTOR, ROLE_SEED, ROLE_HUE };

/* How the parameters map to network outputs: values first (one sigmoid head), then one
 * softmax head per selector, in parameter order. */
typedef struct param_layout {
    int n_params, n_values, n_selectors;
    int role[NN_MAX_HEADS * 2];
    int classes[NN_MAX_HEADS * 2]; /* selectors */
    int column[NN_MAX_HEADS * 2];  /* Y column: value index (a hue's first of two), or
                                    * n_values + selector index */
} param_layout;

/* Roles from the names ("Mult N ..." selectors, "Pattern Offset" the seed, values). */
int predictor_layout_make(param_layout *L, const char *const *names, int n, char *err,
                          size_t errlen);
/* The network's heads (one sigmoid head of the values, weighted value_weight; a softmax
 * head per selector, weighted 1/n_selectors); returns their count. */
int predictor_layout_heads(const param_layout *L, nn_head *heads, float value_weight);
int predictor_layout_outputs(const param_layout *L);
/* The selectors' classes summed: the width of a combination's one-hot encoding. */
int predictor_layout_classes(const param_layout *L);
/* out (predictor_layout_classes) = the one-hot encoding of a combination: cls[s] is
 * selector s's class (in parameter order), as a Y row's selector columns hold it. A
 * conditional model (predictor_fit_options.conditional) reads it after its other inputs. */
void predictor_layout_onehot(const param_layout *L, const float *cls, float *out);
/* A sample's Y and mask row (n_values + n_selectors columns): values, selector classes;
 * mask = active. */
void predictor_layout_targets(const param_layout *L, const float *params, const uint8_t *active,
                              float *y, float *m);
/* x (d) in place: sign(x) log1p(|x| / scale), then (t - mean) / std. */
void predictor_transform_row(float *x, size_t d, const float *scale, const float *mean,
                             const float *std);
/* Fits scale (mean |x|), mean and std over X (n, d) and transforms X in place. */
int predictor_transform_fit(float *X, size_t n, size_t d, float *scale, float *mean, float *std);
/* out (TEXSTATS_N) = (raw - mean) / std: the texture statistics as the network reads them
 * (one definition for training and prediction). */
void predictor_texstats_standardise(float *out, const float *raw, const float *mean,
                                    const float *std);
/* Tensor `name` of exactly count floats, every one finite. */
int predictor_read_tensor(const nn_safetensors *st, const char *name, float *out, size_t count,
                          char *err, size_t errlen);
int predictor_path_join(char *out, size_t len, const char *dir, const char *name, char *err,
                        size_t errlen);

/* A dataset view's settings (datagen.c; stored as a row's view_json): which scene, where
 * its light is, exposure, white balance and the texture space's transform. */
typedef struct pipeline_view {
    int flash;       /* the flash scene (assets/scene-flash.json) instead of the plain one */
    double light[3]; /* the light's location */
    double exposure; /* stops */
    double wb[3];    /* channel gains */
    double rotate;   /* texture space: radians about +Z */
    double shift[2]; /* texture space: metres in x, y */
} pipeline_view;

/* Parses a row's view_json into vs; -1 with a message quoting it. */
int pipeline_view_parse(const char *view_json, pipeline_view *vs, char *err, size_t errlen);
/* The scene JSON text of a view (malloc'd; NULL when scene_text has no light or plane, or
 * out of memory): its first light moved to the view's location, and the first object's
 * texture space rotated and shifted (an object transform) when asked. */
char *pipeline_scene_for_view(const char *scene_text, const pipeline_view *vs);
/* Exposure and white balance on a linear render, as datagen applies them to a view. */
void pipeline_view_apply_gain(const pipeline_view *vs, image *img);

/* Contact sheets (dataset.c), on an RGB image: a label in a 3x5 pixel font (digits, letters
 * as capitals, a small 'v', - . _ / + %; others as spaces) of `scale`-pixel dots, white on a
 * dark box, clipped to the sheet; and an image resized (imageio's tent filter) to a tile x
 * tile square at (ox, oy), grey spread to RGB. The paste returns -1 when out of memory. */
void pipeline_sheet_label(image *sheet, int x, int y, const char *text, int scale);
int pipeline_sheet_paste(image *sheet, const image *img, int ox, int oy, int tile);

#endif

/* Private to pipeline/: helpers its files share. */
#ifndef IMSYNTH_PIPELINE_INTERNAL_H
#define IMSYNTH_PIPELINE_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "pipeline/pipeline.h"

/* Formats a message into err (if not NULL); returns -1 for chaining. */
int pipeline_error(char *err, size_t errlen, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Seconds on the monotonic clock. */
double pipeline_now(void);

/* Reads a whole file (NUL-terminated; *len excludes the NUL). NULL with a message. */
char *pipeline_read_file(const char *path, size_t *len, char *err, size_t errlen);

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

/* A user's image as the predictor's training renders were: square, at the scene's size. */
#include <string.h>

#include "pipeline/pipeline_internal.h"

int pipeline_prepare_input(const image *in, int size, image *out, char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    if (in->width < 1 || in->height < 1 || size < 1)
        return pipeline_error(err, errlen, "empty image");
    // the largest centred square, then resampled (area-correct when shrinking)
    int side = in->width < in->height ? in->width : in->height;
    int x0 = (in->width - side) / 2, y0 = (in->height - side) / 2, c = in->channels;
    image square;
    if (image_alloc(&square, side, side, c))
        return pipeline_error(err, errlen, "out of memory for a %d x %d image", side, side);
    for (int y = 0; y < side; y++)
        memcpy(square.pixels + (size_t)y * side * c,
               in->pixels + ((size_t)(y0 + y) * in->width + (size_t)x0) * c,
               (size_t)side * c * sizeof(float));
    int rc = image_resize(&square, size, size, out);
    image_free(&square);
    return rc ? pipeline_error(err, errlen, "out of memory resampling to %d x %d", size, size)
              : 0;
}

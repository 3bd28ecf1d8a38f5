/*
 * imageio: reading and writing images as linear float pixels.
 *
 * Reading goes through OpenImageIO (PNG, JPEG, TIFF, EXR, ...) behind a small extern "C"
 * shim; EXR is written with OpenEXR's C API (OpenEXRCore), PNG through OpenImageIO.
 * Pixels in memory are always linear, row-major with the top row first, channels
 * interleaved. 8- and 16-bit files are sRGB-decoded on read unless their metadata says
 * they are linear; PNG is sRGB-encoded on write.
 *
 * Every call that can fail takes (err, errlen) and writes a message naming the file and
 * what is wrong with it. Writers write to a temporary file beside the target and rename,
 * so a failed or killed write never leaves a half-written output.
 */
#ifndef IMSYNTH_IMAGEIO_H
#define IMSYNTH_IMAGEIO_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct image {
    int width, height, channels; /* channels: 1 (Y), 3 (RGB) or 4 (RGBA) */
    float *pixels;               /* width * height * channels floats, malloc'd */
} image;

/* Allocate a zeroed image. Returns 0, or -1 when out of memory. */
int image_alloc(image *img, int width, int height, int channels);
void image_free(image *img);

/* Read any supported file. Returns 0, or -1 with a message in err. */
int image_read(const char *path, image *img, char *err, size_t errlen);

typedef enum image_exr_pixel { IMAGE_EXR_HALF, IMAGE_EXR_FLOAT } image_exr_pixel;

/* Linear EXR, ZIP-compressed; channels named Y, or R G B (A). Returns 0 or -1. */
int image_write_exr(const char *path, const image *img, image_exr_pixel pixel_type, char *err,
                    size_t errlen);

/* 8-bit sRGB PNG (values clamped to [0,1], then sRGB-encoded). Returns 0 or -1. */
int image_write_png(const char *path, const image *img, char *err, size_t errlen);

/* Resample to width x height with a separable triangle (tent) filter whose support
 * widens with the scale factor when shrinking (area-correct), bilinear when enlarging.
 * Returns 0 or -1 (out of memory). */
int image_resize(const image *src, int width, int height, image *dst);

/* sRGB transfer functions (IEC 61966-2-1), exact piecewise form. */
float srgb_to_linear(float v);
float linear_to_srgb(float v);

#ifdef __cplusplus
}
#endif
#endif

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

/* Read any supported file (first subimage, full resolution). Returns 0, or -1 with a
 * message in err; img is then zeroed (image_free is still safe).
 *
 * Colour: files stored as half, float or double (EXR, HDR, float TIFF) are taken as linear,
 * as stored. Integer files (8/16-bit PNG, JPEG, TIFF, ...) are sRGB-decoded unless their
 * metadata says they are linear: OIIO's "oiio:ColorSpace" is linear ("Linear", "linear",
 * "scene_linear", "lin_srgb", "lin_rec709") or "oiio:Gamma" is 1.0 (e.g. a PNG gAMA of
 * 1.0). Any other gamma is treated as sRGB. Alpha is never decoded, and never multiplied
 * or divided: it comes out as stored (straight in PNG/TIFF, premultiplied in EXR).
 *
 * Channels: grey stays 1 channel, RGB 3, RGBA 4; grey + alpha becomes RGBA (Y, Y, Y, A).
 * Other channels are dropped: a file with more channels (extra EXR layers, Z) gives R, G,
 * B and A if the 4th channel is alpha, else R, G, B; a 2-channel file whose 2nd channel is
 * not alpha gives its 1st. EXIF Orientation (photos) is applied: pixels come out as a
 * viewer shows them, so width and height are swapped for quarter turns.
 *
 * Rejected with an error: images over 32768 pixels on a side or 2^28 pixels in all
 * (16384 x 16384), deep and volume images, and missing, empty, truncated or corrupt files
 * and folders. */
int image_read(const char *path, image *img, char *err, size_t errlen);

typedef enum image_exr_pixel { IMAGE_EXR_HALF, IMAGE_EXR_FLOAT } image_exr_pixel;

/* Linear EXR, ZIP-compressed; channels named Y, or R G B (A). Returns 0 or -1. */
int image_write_exr(const char *path, const image *img, image_exr_pixel pixel_type, char *err,
                    size_t errlen);

/* image_write_exr plus string attributes in the header: meta is NULL or a NULL-terminated
 * list of name, value pairs, e.g. {"imsynth:params", json, NULL}. Names must not be
 * standard EXR attribute names. Returns 0 or -1. */
int image_write_exr_meta(const char *path, const image *img, image_exr_pixel pixel_type,
                         const char *const *meta, char *err, size_t errlen);

/* Read string attribute name from the header of EXR file path into value (NUL-terminated;
 * value may be NULL to test presence). Returns 0 when found, 1 when the file has no such
 * attribute, -1 with a message in err (unreadable file, not a string, value too small). */
int image_exr_get_string(const char *path, const char *name, char *value, size_t valuelen,
                         char *err, size_t errlen);

/* 8-bit sRGB PNG (values clamped to [0,1], then sRGB-encoded; alpha clamped but not
 * encoded; NaN written as 0). Returns 0 or -1. */
int image_write_png(const char *path, const image *img, char *err, size_t errlen);

/* 16-bit linear PNG (values clamped to [0,1], not encoded, rounded to 1/65535; NaN as 0),
 * tagged linear (gAMA 1.0) so image_read returns the same linear values to 8e-6.
 * Lossless storage for renders whose values lie in [0, 1]. Returns 0 or -1. */
int image_write_png16_linear(const char *path, const image *img, char *err, size_t errlen);

/* Resample to width x height with a separable triangle (tent) filter whose support
 * widens with the scale factor when shrinking (area-correct), bilinear when enlarging.
 * Pixel centres map to pixel centres with the image edges aligned; taps outside the image
 * are dropped and the weights renormalised. Channels are filtered independently (alpha is
 * not used as a weight). Returns 0, or -1 (out of memory, or an empty
 * source or target size); dst is then zeroed. */
int image_resize(const image *src, int width, int height, image *dst);

/* The image turned a quarter counterclockwise, as a viewer sees it: dst is height x width
 * and dst's top-left pixel is src's top-right (dst[r][c] = src[c][width - 1 - r]).
 * Exact: pixels are moved, not resampled. Returns 0, or -1 when out of memory (dst is
 * then zeroed). */
int image_rotate_ccw(const image *src, image *dst);

/* How far an image is from a reference (imsynth compare; compare.c). Metrics are over
 * the first 3 channels (RGB), every pixel weighted equally, accumulated in double.
 * The reference is ref_a, or the mean (a + b) / 2 of two independent renders a and b of
 * the same scene (e.g. two halves of a Cycles reference with different seeds). */
typedef struct image_comparison {
    double ref_mean; /* mean of the reference over pixels and RGB */
    double rmse;     /* sqrt(mean (img - ref)^2) */
    double mae;      /* mean |img - ref| */
    /* Per channel (mean img_c - mean ref_c) / mean ref_c: the relative error of the
     * channel's mean, 0 where the reference channel's mean is 0. */
    double bias[3];
    /* Over the whole 16 x 16 blocks of a grid anchored at the top left (a partial last
     * row or column of blocks is ignored), the largest |mean_block(img) -
     * mean_block(ref)| / mean_block(ref), the means taken over the block's pixels and RGB
     * together: the same block measure as tests/unit/test_render_reference.c, which
     * catches a local error that the image means dilute. A block whose reference mean is
     * 0 is measured against ref_mean instead (or counts 0 when that is 0 too). The
     * position is in blocks (pixel x / 16, y / 16); -1, -1 and worst_block 0 when the
     * image is smaller than one block. */
    double worst_block;
    int worst_block_x, worst_block_y;
    /* Only with ref_b (has_b = 1; else both are -1). ref_noise_rmse = sqrt(mean
     * ((a - b) / 2)^2) estimates the RMS noise of the reference (a + b) / 2 itself, and
     * rmse_converged = sqrt(max(rmse^2 - ref_noise_rmse^2, 0)) the RMSE of img against
     * the converged image, given img's error is independent of the reference's noise. */
    int has_b;
    double ref_noise_rmse, rmse_converged;
} image_comparison;

/* Compare img with ref_a, or with (ref_a + ref_b) / 2 when ref_b is not NULL. All images
 * must have the same width and height and at least 3 channels (they may differ in
 * channel count: extra channels are ignored). Returns 0 with *out filled, or -1 with a
 * message in err (mismatched sizes, too few channels, or a NaN or infinite RGB value,
 * naming the image and its first such pixel and channel); *out is then zeroed. */
int image_compare(const image *img, const image *ref_a, const image *ref_b,
                  image_comparison *out, char *err, size_t errlen);

/* sRGB transfer functions (IEC 61966-2-1), exact piecewise form. */
float srgb_to_linear(float v);
float linear_to_srgb(float v);

#ifdef __cplusplus
}
#endif
#endif

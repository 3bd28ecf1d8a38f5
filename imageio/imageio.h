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

/* Resample to width x height with a separable triangle (tent) filter whose support
 * widens with the scale factor when shrinking (area-correct), bilinear when enlarging.
 * Pixel centres map to pixel centres with the image edges aligned; taps outside the image
 * are dropped and the weights renormalised. Channels are filtered independently (alpha is
 * not used as a weight). Returns 0, or -1 (out of memory, or an empty
 * source or target size); dst is then zeroed. */
int image_resize(const image *src, int width, int height, image *dst);

/* sRGB transfer functions (IEC 61966-2-1), exact piecewise form. */
float srgb_to_linear(float v);
float linear_to_srgb(float v);

#ifdef __cplusplus
}
#endif
#endif

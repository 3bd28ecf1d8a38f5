/*
 * Private to imageio: the C view of the few OpenImageIO calls imageio needs. The
 * implementation (oiio_shim.cpp) is the only C++ in the library; it catches every
 * exception, so these functions only ever fail by returning an error code and a message.
 *
 * Messages written to err do not name the file; the caller prefixes the path.
 *
 * The functions below are oiio_module.c's: each loads the module (oiio_shim.cpp as
 * libimsynth_oiio.so) on first use and calls its entry in the module's oiio_api table. A
 * module that cannot be loaded makes them fail with a message saying where it was looked
 * for. OpenImageIO with its dependencies is ~250 shared libraries and 0.37 s of start-up
 * (BENCHMARKS.md, the suite's own time): most commands read no image and never pay it.
 */
#ifndef IMSYNTH_IMAGEIO_OIIO_SHIM_H
#define IMSYNTH_IMAGEIO_OIIO_SHIM_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct oiio_reader oiio_reader;

/* What a file says about itself, from its header (first subimage, top MIP level). */
typedef struct oiio_image_info {
    int width, height, depth; /* depth > 1: a volume, which imageio rejects */
    int channels;
    int alpha_channel;        /* index of the alpha channel, or -1 */
    int is_float;             /* stored as half, float or double */
    int bits;                 /* bits per channel value as stored (8, 16, 32, ...) */
    int is_deep;
    int metadata_linear;      /* oiio:ColorSpace says linear, or oiio:Gamma is 1 */
    int orientation;          /* EXIF Orientation, 1..8 (1 when absent or invalid) */
    char format_name[32];     /* "png", "openexr", "jpeg", ... */
} oiio_image_info;

/* Open path and fill info. Returns a reader, or NULL with a message in err. The file's
 * alpha is left as stored (PNG's unassociated alpha is not premultiplied on read). */
oiio_reader *oiio_reader_open(const char *path, oiio_image_info *info, char *err,
                              size_t errlen);

/* The same for a file already read into memory, data[0, size), decoded as `format`
 * ("png", ...); path only names it in messages. data must outlive the reader. */
oiio_reader *oiio_reader_open_memory(const char *path, const char *format, const void *data,
                                     size_t size, oiio_image_info *info, char *err,
                                     size_t errlen);

/* Read channels [0, nchannels) of the whole image into pixels, interleaved, top row first:
 * as uint8_t when as_uint8 (only sensible for 8-bit files), else as float (integer formats
 * scaled to [0,1]). Returns 0, or -1 with a message in err. */
int oiio_reader_read(oiio_reader *reader, int nchannels, int as_uint8, void *pixels, char *err,
                     size_t errlen);

void oiio_reader_close(oiio_reader *reader);

/* Write a PNG of width x height x channels (1, 3 or 4) values of `bits` (8: uint8_t,
 * 16: uint16_t), tagged sRGB, or linear (gAMA 1.0) when `linear`, to path exactly (no
 * temporary file: the caller provides one). Returns 0, or -1 with a message. */
int oiio_write_png(const char *path, int width, int height, int channels, int bits, int linear,
                   const void *pixels, char *err, size_t errlen);

/* The module's table (its one exported symbol: imsynth_oiio_api). The version is checked
 * at load: a module from another build of imsynth is refused rather than called. */
#define OIIO_API_VERSION 1
typedef struct oiio_api {
    int version;
    oiio_reader *(*reader_open)(const char *path, oiio_image_info *info, char *err,
                                size_t errlen);
    oiio_reader *(*reader_open_memory)(const char *path, const char *format, const void *data,
                                       size_t size, oiio_image_info *info, char *err,
                                       size_t errlen);
    int (*reader_read)(oiio_reader *reader, int nchannels, int as_uint8, void *pixels,
                       char *err, size_t errlen);
    void (*reader_close)(oiio_reader *reader);
    int (*write_png)(const char *path, int width, int height, int channels, int bits,
                     int linear, const void *pixels, char *err, size_t errlen);
} oiio_api;
const oiio_api *imsynth_oiio_api(void);

#ifdef __cplusplus
}
#endif
#endif

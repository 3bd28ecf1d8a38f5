/* fuzz_image: image files through our reader, image_read (OpenImageIO behind
 * imageio/oiio_shim.cpp, plus our own checks: the PNG completeness check, size limits,
 * channel selection, sRGB decoding, EXIF orientation). OpenImageIO picks the decoder from
 * the file name, so the first byte of an input chooses the extension (0 PNG, 1 JPEG,
 * 2 TIFF, 3 EXR; taken modulo 4) and the rest is the file: one harness covers the four
 * formats the tool reads, and mutations can move a file between decoders. */
#include <stdint.h>
#include <stdlib.h>

#include "fuzz_util.h"
#include "imageio/imageio.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char *const names[4] = {"input.png", "input.jpg", "input.tif", "input.exr"};
    if (size < 1)
        return 0;
    char path[512], err[512];
    fuzz_temp_path(path, sizeof path, names[data[0] & 3]);
    if (fuzz_write_file(path, data + 1, size - 1) != 0)
        return 0;
    image img;
    if (image_read(path, &img, err, sizeof err) == 0) {
        if (img.width < 1 || img.height < 1 || !img.pixels)
            abort(); /* success means a non-empty image */
        volatile float sum = 0.0f;
        size_t n = (size_t)img.width * (size_t)img.height * (size_t)img.channels;
        for (size_t i = 0; i < n; i += 7)
            sum += img.pixels[i];
        (void)sum;
    }
    image_free(&img);
    return 0;
}

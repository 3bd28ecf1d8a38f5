// Writes the image seeds of tests/fuzz/corpus/image (run by make_corpus.sh): a small
// gradient as PNG (8-bit RGBA, 16-bit grey), JPEG, TIFF (8-bit RGB, float RGB) and EXR
// (half RGBA), each prefixed by the byte fuzz_image.c reads as the format selector.
// OpenImageIO is a build dependency already, so the seeds need no other image tool.
#include <OpenImageIO/imageio.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

using namespace OIIO;

static int write(const std::string &dir, const char *name, int selector, int w, int h,
                 int channels, TypeDesc type)
{
    const std::string ext = std::string(name).substr(std::string(name).rfind('.'));
    const std::string tmp = dir + "/tmp" + ext;
    std::vector<float> px((size_t)w * h * channels);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < channels; c++)
                px[((size_t)y * w + x) * channels + c] = (float)(x + y + c) / (float)(w + h);
    auto out = ImageOutput::create(tmp);
    if (!out)
        return std::fprintf(stderr, "make_images: no writer for %s\n", ext.c_str()), 1;
    ImageSpec spec(w, h, channels, type);
    if (ext == ".jpg")
        spec.attribute("CompressionQuality", 50);
    if (!out->open(tmp, spec) || !out->write_image(TypeDesc::FLOAT, px.data()) || !out->close())
        return std::fprintf(stderr, "make_images: %s: %s\n", name, out->geterror().c_str()), 1;
    // The seed: the selector byte, then the file.
    std::ifstream in(tmp, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream seed(dir + "/" + name, std::ios::binary);
    seed.put((char)selector);
    seed << bytes;
    std::remove(tmp.c_str());
    return 0;
}

int main(int argc, char **argv)
{
    if (argc != 2)
        return std::fprintf(stderr, "usage: make_images DIR\n"), 2;
    const std::string dir = argv[1];
    int bad = 0;
    bad |= write(dir, "rgba8.png", 0, 8, 6, 4, TypeDesc::UINT8);
    bad |= write(dir, "grey16.png", 0, 5, 3, 1, TypeDesc::UINT16);
    bad |= write(dir, "rgb.jpg", 1, 8, 8, 3, TypeDesc::UINT8);
    bad |= write(dir, "rgb8.tif", 2, 6, 4, 3, TypeDesc::UINT8);
    bad |= write(dir, "float.tif", 2, 4, 4, 3, TypeDesc::FLOAT);
    bad |= write(dir, "rgba_half.exr", 3, 4, 4, 4, TypeDesc::HALF);
    return bad;
}

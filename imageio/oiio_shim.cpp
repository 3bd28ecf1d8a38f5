/*
 * The only C++ in imageio: a thin C layer over OpenImageIO 2.4, built as its own module
 * (libimsynth_oiio.so) that oiio_module.c loads at the first call, so that a command that
 * reads no image never loads OpenImageIO's ~250 libraries. Its one exported symbol is
 * imsynth_oiio_api (oiio_shim.h); everything else has hidden visibility.
 *
 * OIIO reports most failures through return values and geterror(), but the format
 * libraries under it (OpenEXR, libtiff, ...) can throw, and so can std::string and
 * allocation. Every entry point therefore catches everything and turns it into an error
 * message: no exception ever crosses into C.
 *
 * OIIO keeps error messages per thread (global) and per ImageInput/ImageOutput; both are
 * always retrieved, which also clears them, so a later call never sees a stale message.
 */
#include "imageio/oiio_shim.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <cctype>
#include <cstdio>
#include <cstring>
#include <exception>
#include <memory>
#include <string>

using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

/* The proxy, when there is one, is declared first so that it outlives the input that
 * reads through it (members are destroyed in reverse order). */
struct oiio_reader {
    std::unique_ptr<OIIO::Filesystem::IOMemReader> memory;
    std::unique_ptr<ImageInput> input;
};

/* Copy msg into err as one line without trailing whitespace (OIIO messages often end in
 * a newline and sometimes contain several lines). */
static void set_error(char *err, size_t errlen, const std::string &msg)
{
    if (!err || errlen == 0)
        return;
    std::string line = msg;
    for (char &c : line)
        if (c == '\n' || c == '\r')
            c = ' ';
    while (!line.empty() && line.back() == ' ')
        line.pop_back();
    if (line.empty())
        line = "unknown OpenImageIO error";
    std::snprintf(err, errlen, "%s", line.c_str());
}

/* The most specific message available: the object's own, else OIIO's global one. */
static std::string pending_errors(const std::string &own)
{
    std::string global = OIIO::geterror();
    if (!own.empty())
        return own;
    return global;
}

static bool says_linear(const ImageSpec &spec)
{
    std::string cs = spec.get_string_attribute("oiio:ColorSpace");
    for (char &c : cs)
        c = (char)std::tolower((unsigned char)c);
    if (cs == "linear" || cs == "scene_linear" || cs == "lin_rec709" || cs == "lin_srgb")
        return true;
    float gamma = spec.get_float_attribute("oiio:Gamma", 0.0f);
    return gamma == 1.0f;
}

/* Open path, or, when format is given, the in-memory copy of it in data[0, size). */
static oiio_reader *open_reader(const char *path, const char *format, const void *data,
                                size_t size, oiio_image_info *info, char *err, size_t errlen)
{
    try {
        /* Keep PNG/TIFF alpha as stored: OIIO would otherwise premultiply colour by alpha
         * in the file's (sRGB-encoded) space, which cannot be undone exactly. */
        ImageSpec config;
        config.attribute("oiio:UnassociatedAlpha", 1);
        std::unique_ptr<OIIO::Filesystem::IOMemReader> memory;
        std::unique_ptr<ImageInput> input;
        if (format) {
            /* Created by format name: a path need not end in the format's extension. */
            memory.reset(new OIIO::Filesystem::IOMemReader(data, size));
            /* open() takes its proxy from the configuration (one passed to create() alone
             * is dropped there, and the file read from its path after all). */
            void *proxy = memory.get();
            config.attribute("oiio:ioproxy", TypeDesc::PTR, &proxy);
            input = ImageInput::create(format, false, &config, memory.get());
            ImageSpec spec;
            if (input && !input->open(path, spec, config)) {
                set_error(err, errlen, pending_errors(input->geterror()));
                return nullptr;
            }
        } else {
            input = ImageInput::open(path, &config);
        }
        if (!input) {
            set_error(err, errlen, pending_errors(""));
            return nullptr;
        }
        const ImageSpec &spec = input->spec();
        std::memset(info, 0, sizeof *info);
        info->width = spec.width;
        info->height = spec.height;
        info->depth = spec.depth;
        info->channels = spec.nchannels;
        info->alpha_channel = spec.alpha_channel;
        TypeDesc::BASETYPE base = (TypeDesc::BASETYPE)spec.format.basetype;
        info->is_float = base == TypeDesc::HALF || base == TypeDesc::FLOAT
                         || base == TypeDesc::DOUBLE;
        info->bits = (int)spec.format.size() * 8;
        /* A file's own bit depth can be below its in-memory type (e.g. 12-bit TIFF). */
        int stored_bits = spec.get_int_attribute("oiio:BitsPerSample", 0);
        if (!info->is_float && stored_bits > 0 && stored_bits < info->bits)
            info->bits = stored_bits;
        info->is_deep = spec.deep ? 1 : 0;
        info->metadata_linear = says_linear(spec) ? 1 : 0;
        int orientation = spec.get_int_attribute("Orientation", 1);
        info->orientation = orientation >= 1 && orientation <= 8 ? orientation : 1;
        std::snprintf(info->format_name, sizeof info->format_name, "%s", input->format_name());
        oiio_reader *reader = new oiio_reader;
        reader->input = std::move(input);
        reader->memory = std::move(memory);
        return reader;
    } catch (const std::exception &e) {
        OIIO::geterror();
        set_error(err, errlen, std::string("OpenImageIO exception: ") + e.what());
    } catch (...) {
        OIIO::geterror();
        set_error(err, errlen, "unknown exception in OpenImageIO");
    }
    return nullptr;
}

static oiio_reader *shim_reader_open(const char *path, oiio_image_info *info, char *err,
                                         size_t errlen)
{
    return open_reader(path, nullptr, nullptr, 0, info, err, errlen);
}

static oiio_reader *shim_reader_open_memory(const char *path, const char *format,
                                                const void *data, size_t size,
                                                oiio_image_info *info, char *err,
                                                size_t errlen)
{
    return open_reader(path, format, data, size, info, err, errlen);
}

static int shim_reader_read(oiio_reader *reader, int nchannels, int as_uint8, void *pixels,
                                char *err, size_t errlen)
{
    try {
        TypeDesc type = as_uint8 ? TypeDesc::UINT8 : TypeDesc::FLOAT;
        bool ok = reader->input->read_image(0, 0, 0, nchannels, type, pixels);
        /* A reader may succeed yet record an error (e.g. data past a truncation filled
         * with zeros); treat any recorded error as failure. */
        std::string own = reader->input->geterror();
        std::string msg = pending_errors(own);
        if (!ok || !own.empty()) {
            set_error(err, errlen, msg.empty() ? std::string("read failed") : msg);
            return -1;
        }
        return 0;
    } catch (const std::exception &e) {
        OIIO::geterror();
        set_error(err, errlen, std::string("OpenImageIO exception: ") + e.what());
    } catch (...) {
        OIIO::geterror();
        set_error(err, errlen, "unknown exception in OpenImageIO");
    }
    return -1;
}

static void shim_reader_close(oiio_reader *reader)
{
    if (!reader)
        return;
    try {
        reader->input->close();
        reader->input->geterror();
        OIIO::geterror();
    } catch (...) {
        /* Nothing to report to: the pixels were read, or the read already failed. */
    }
    delete reader;
}

static int shim_write_png(const char *path, int width, int height, int channels,
                              int bits, int linear, const void *pixels, char *err,
                              size_t errlen)
{
    try {
        /* Created by format name, not by path: the caller's temporary file name does not
         * end in .png. */
        std::unique_ptr<ImageOutput> out = ImageOutput::create("png");
        if (!out) {
            set_error(err, errlen, pending_errors("no PNG writer in OpenImageIO"));
            return -1;
        }
        TypeDesc type = bits == 16 ? TypeDesc::UINT16 : TypeDesc::UINT8;
        ImageSpec spec(width, height, channels, type);
        if (linear) {
            /* OIIO writes gAMA 1.0 for this, which our reader (and others) take as linear. */
            spec.attribute("oiio:ColorSpace", "Linear");
            spec.attribute("oiio:Gamma", 1.0f);
        } else {
            spec.attribute("oiio:ColorSpace", "sRGB");
        }
        if (channels == 4)
            spec.alpha_channel = 3;
        /* The pixels are already unassociated (straight) alpha: do not divide them. */
        spec.attribute("oiio:UnassociatedAlpha", 1);
        if (!out->open(path, spec)) {
            set_error(err, errlen, pending_errors(out->geterror()));
            return -1;
        }
        bool ok = out->write_image(type, pixels);
        std::string msg = out->geterror();
        bool closed = out->close();
        if (msg.empty())
            msg = out->geterror();
        msg = pending_errors(msg);
        if (!ok || !closed || !msg.empty()) {
            set_error(err, errlen, msg.empty() ? std::string("write failed") : msg);
            return -1;
        }
        return 0;
    } catch (const std::exception &e) {
        OIIO::geterror();
        set_error(err, errlen, std::string("OpenImageIO exception: ") + e.what());
    } catch (...) {
        OIIO::geterror();
        set_error(err, errlen, "unknown exception in OpenImageIO");
    }
    return -1;
}

extern "C" __attribute__((visibility("default"))) const oiio_api *imsynth_oiio_api(void)
{
    static const oiio_api api = {OIIO_API_VERSION,     shim_reader_open, shim_reader_open_memory,
                                 shim_reader_read,     shim_reader_close, shim_write_png};
    return &api;
}

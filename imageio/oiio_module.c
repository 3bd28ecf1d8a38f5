/*
 * The oiio_* functions of oiio_shim.h, loading libimsynth_oiio.so at the first call.
 *
 * Where the module is looked for, in order:
 *   1. <directory of the running executable>/../lib/imsynth/ (an installed imsynth:
 *      `cmake --install` puts it there beside bin/imsynth);
 *   2. the build tree's own (IMSYNTH_OIIO_MODULE_BUILD, set by imageio/CMakeLists.txt),
 *      for binaries run from where they were built (the CLI, the tests, the benches).
 *
 * The load happens once per process (pthread_once) and its result, a table of function
 * pointers or the reason there is none, never changes afterwards: the only state of its
 * kind in imageio, written before any reader can see it.
 */
#include "imageio/oiio_shim.h"

#include <dlfcn.h>
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#ifndef IMSYNTH_OIIO_MODULE_BUILD
#error "IMSYNTH_OIIO_MODULE_BUILD: the build tree's libimsynth_oiio.so (imageio/CMakeLists.txt)"
#endif

#define MODULE_NAME "libimsynth_oiio.so"

typedef struct module_state {
    const oiio_api *api; /* NULL when the module could not be loaded */
    char error[1024];    /* then: every place tried, and why it failed */
} module_state;

static module_state loaded;
static pthread_once_t load_once = PTHREAD_ONCE_INIT;

/* Open `path` and take its table; NULL with the reason appended to loaded.error. */
static const oiio_api *try_load(const char *path)
{
    size_t used = strlen(loaded.error);
    char *why = loaded.error + used;
    size_t room = sizeof loaded.error - used;
    void *handle = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
        const char *e = dlerror();
        snprintf(why, room, "%s%s", used ? "; " : "", e ? e : path);
        return NULL;
    }
    const oiio_api *(*get)(void);
    void *sym = dlsym(handle, "imsynth_oiio_api");
    memcpy(&get, &sym, sizeof get); /* object to function pointer, as POSIX allows */
    const oiio_api *api = sym ? get() : NULL;
    if (!api || api->version != OIIO_API_VERSION) {
        snprintf(why, room, "%s%s: not this imsynth's module (no imsynth_oiio_api version %d)",
                 used ? "; " : "", path, OIIO_API_VERSION);
        dlclose(handle);
        return NULL;
    }
    return api; /* the handle stays open for the process's life */
}

static void load_module(void)
{
    char exe[PATH_MAX];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n > 0) {
        exe[n] = '\0';
        char *slash = strrchr(exe, '/');
        if (slash) {
            *slash = '\0';
            char path[PATH_MAX + 64];
            snprintf(path, sizeof path, "%s/../lib/imsynth/" MODULE_NAME, exe);
            if (access(path, F_OK) == 0 && (loaded.api = try_load(path)))
                return;
        }
    }
    loaded.api = try_load(IMSYNTH_OIIO_MODULE_BUILD);
}

/* The table, or NULL with a message in err. */
static const oiio_api *module(char *err, size_t errlen)
{
    pthread_once(&load_once, load_module);
    if (!loaded.api && err && errlen)
        snprintf(err, errlen, "cannot load imsynth's OpenImageIO module (" MODULE_NAME "): %s",
                 loaded.error);
    return loaded.api;
}

oiio_reader *oiio_reader_open(const char *path, oiio_image_info *info, char *err, size_t errlen)
{
    const oiio_api *api = module(err, errlen);
    return api ? api->reader_open(path, info, err, errlen) : NULL;
}

oiio_reader *oiio_reader_open_memory(const char *path, const char *format, const void *data,
                                     size_t size, oiio_image_info *info, char *err,
                                     size_t errlen)
{
    const oiio_api *api = module(err, errlen);
    return api ? api->reader_open_memory(path, format, data, size, info, err, errlen) : NULL;
}

/* A reader exists only if the module loaded: these two cannot be the first call. */
int oiio_reader_read(oiio_reader *reader, int nchannels, int as_uint8, void *pixels, char *err,
                     size_t errlen)
{
    return module(err, errlen)->reader_read(reader, nchannels, as_uint8, pixels, err, errlen);
}

void oiio_reader_close(oiio_reader *reader)
{
    if (reader)
        module(NULL, 0)->reader_close(reader);
}

int oiio_write_png(const char *path, int width, int height, int channels, int bits, int linear,
                   const void *pixels, char *err, size_t errlen)
{
    const oiio_api *api = module(err, errlen);
    return api ? api->write_png(path, width, height, channels, bits, linear, pixels, err, errlen)
               : -1;
}

/* fuzz_scene: render scene files (imsynth-scene/1, assets/scene.json; `--scene`) through
 * render_scene_load_json, which validates camera, lights, plane, film and sampling
 * settings before a render reads them. A scene that loads must report a usable
 * resolution. Rendering itself is not fuzzed: it costs seconds, not microseconds. */
#include <stdint.h>
#include <stdlib.h>

#include "render/render.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char err[512];
    render_scene *s = render_scene_load_json((const char *)data, size, "fuzz-scene.json", err,
                                             sizeof err);
    if (!s)
        return 0;
    int w = 0, h = 0;
    render_scene_resolution(s, &w, &h);
    if (w < 1 || h < 1)
        abort(); /* a validated scene renders something */
    render_scene_free(s);
    return 0;
}

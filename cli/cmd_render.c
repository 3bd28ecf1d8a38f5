/* imsynth render: path-trace a material on the scene's plane (Cycles-compatible). */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli.h"
#include "imageio/imageio.h"
#include "pipeline/pipeline.h"
#include "render/render.h"
#include "shadergraph/shadergraph.h"

static const char *const help =
    "usage: imsynth render GRAPH.json -o OUT.exr [options]\n"
    "\n"
    "Renders the material's Principled BSDF on the plane of the scene (DESIGN.md) as\n"
    "Blender's Cycles would, converging to the same image: point light with next-event\n"
    "estimation and MIS, uniform world, Blackman-Harris 1.5 px pixel filter. The output\n"
    "is a linear RGB EXR (half float); --png adds an sRGB 8-bit PNG.\n"
    "\n"
    "options:\n"
    "  -o, --output OUT.exr    the render (required; written atomically)\n"
    "  --png OUT.png           also write an sRGB PNG\n"
    "  --params P.json         bind these super-shader parameters first\n"
    "  --spp N                 samples per pixel (fast mode: 4, then adaptive sampling;\n"
    "                          reference mode: 256)\n"
    "  --light-samples N       fast mode: light/BSDF sample pairs per shading point (4)\n"
    "  --max-spp N             fast mode: adaptive sampling; pixels whose neighbours are\n"
    "                          noisy get up to N shading points (default 256; 0: off)\n"
    "  --noise-target E        adaptive sampling's aim: standard error E x sqrt(local\n"
    "                          mean x image mean) (default 0.03)\n"
    "  --mode fast|reference   fast (default): low noise, same expected value;\n"
    "                          reference: plain Monte Carlo\n"
    "  --blender 4|3           BSDF and node semantics (default 4)\n"
    "  --threads N             worker threads (default: all cores); the image does not\n"
    "                          depend on it\n"
    "  --seed N                sampling seed (default 0)\n"
    "  --scene SCENE.json      default assets/scene.json (installed, source tree, or\n"
    "                          $IMSYNTH_DATA)\n"
    "  --float                 write a float EXR instead of half\n"
    "  --stats                 print timing and ray counts to stderr\n";

static int parse_int(const char *sub, const char *opt, const char *s, long lo, long hi,
                     long *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || *end || !*s || v < lo || v > hi) {
        cli_error(sub, "%s: expected an integer in [%ld, %ld], got \"%s\"", opt, lo, hi, s);
        return -1;
    }
    *out = v;
    return 0;
}

int cmd_render(int argc, char **argv)
{
    const char *sub = "render";
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    const char *graph_path = NULL, *out_path = NULL, *png_path = NULL, *params_path = NULL;
    const char *scene_path = NULL;
    int want_float = 0, want_stats = 0, spp_given = 0;
    render_options o;
    render_options_default(&o);
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int takes = !strcmp(a, "-o") || !strcmp(a, "--output") || !strcmp(a, "--png") ||
                    !strcmp(a, "--params") || !strcmp(a, "--spp") || !strcmp(a, "--mode") ||
                    !strcmp(a, "--blender") || !strcmp(a, "--threads") || !strcmp(a, "--seed") ||
                    !strcmp(a, "--scene") || !strcmp(a, "--light-samples") ||
                    !strcmp(a, "--max-spp") || !strcmp(a, "--noise-target");
        if (takes && i + 1 >= argc) {
            cli_error(sub, "%s needs a value", a);
            return EXIT_USAGE;
        }
        long v;
        if (!strcmp(a, "-o") || !strcmp(a, "--output"))
            out_path = argv[++i];
        else if (!strcmp(a, "--png"))
            png_path = argv[++i];
        else if (!strcmp(a, "--params"))
            params_path = argv[++i];
        else if (!strcmp(a, "--scene"))
            scene_path = argv[++i];
        else if (!strcmp(a, "--spp")) {
            if (parse_int(sub, a, argv[++i], 1, 1 << 20, &v) < 0)
                return EXIT_USAGE;
            o.spp = (int)v;
            spp_given = 1;
        } else if (!strcmp(a, "--max-spp")) {
            if (parse_int(sub, a, argv[++i], 0, 1 << 20, &v) < 0)
                return EXIT_USAGE;
            o.max_spp = (int)v;
        } else if (!strcmp(a, "--noise-target")) {
            const char *t = argv[++i];
            char *end;
            errno = 0;
            double d = strtod(t, &end);
            if (errno || *end || !*t || !(d > 0.0) || !(d <= 1.0)) {
                cli_error(sub, "--noise-target: expected a number in (0, 1], got \"%s\"", t);
                return EXIT_USAGE;
            }
            o.noise_target = (float)d;
        } else if (!strcmp(a, "--light-samples")) {
            if (parse_int(sub, a, argv[++i], 1, 64, &v) < 0)
                return EXIT_USAGE;
            o.light_samples = (int)v;
        } else if (!strcmp(a, "--blender")) {
            if (parse_int(sub, a, argv[++i], 3, 4, &v) < 0)
                return EXIT_USAGE;
            o.blender = (int)v;
        } else if (!strcmp(a, "--threads")) {
            if (parse_int(sub, a, argv[++i], 0, 256, &v) < 0)
                return EXIT_USAGE;
            o.threads = (int)v;
        } else if (!strcmp(a, "--seed")) {
            const char *s = argv[++i];
            char *end;
            errno = 0;
            unsigned long long seed = strtoull(s, &end, 10);
            if (errno || *end || !*s || s[0] == '-' || s[0] == '+' || s[0] == ' ') {
                cli_error(sub, "--seed: expected an integer in [0, 2^64), got \"%s\"", s);
                return EXIT_USAGE;
            }
            o.seed = seed;
        } else if (!strcmp(a, "--mode")) {
            const char *m = argv[++i];
            if (!strcmp(m, "fast"))
                o.mode = RENDER_FAST;
            else if (!strcmp(m, "reference"))
                o.mode = RENDER_REFERENCE;
            else {
                cli_error(sub, "--mode: expected fast or reference, got \"%s\"", m);
                return EXIT_USAGE;
            }
        } else if (!strcmp(a, "--float"))
            want_float = 1;
        else if (!strcmp(a, "--stats"))
            want_stats = 1;
        else if (a[0] == '-' && a[1]) {
            cli_error(sub, "unknown option \"%s\"", a);
            return EXIT_USAGE;
        } else if (!graph_path)
            graph_path = a;
        else {
            cli_error(sub, "unexpected argument \"%s\"", a);
            return EXIT_USAGE;
        }
    }
    if (!graph_path || !out_path) {
        cli_error(sub, "need GRAPH.json and -o OUT.exr (see --help)");
        return EXIT_USAGE;
    }
    if (!spp_given && o.mode == RENDER_REFERENCE)
        o.spp = 256;

    char err[1024], scene_buf[1024];
    if (!(scene_path = cli_data_path(sub, scene_path, "assets/scene.json", scene_buf,
                                     sizeof scene_buf)))
        return EXIT_FAILURE_WORK;
    sg_graph *g = pipeline_load_graph(graph_path, params_path, -1, err, sizeof err);
    if (!g) {
        cli_error(sub, "%s", err);
        return EXIT_FAILURE_WORK;
    }
    render_material *m = pipeline_render_material(g, graph_path, o.blender, err, sizeof err);
    sg_graph_free(g);
    if (!m) {
        cli_error(sub, "%s", err);
        return EXIT_FAILURE_WORK;
    }
    render_scene *s = render_scene_load(scene_path, err, sizeof err);
    if (!s) {
        cli_error(sub, "%s", err);
        render_material_free(m);
        return EXIT_FAILURE_WORK;
    }
    image img;
    render_stats st;
    int rc = render_image(s, m, &o, &img, &st, err, sizeof err);
    render_scene_free(s);
    render_material_free(m);
    if (rc < 0) {
        cli_error(sub, "%s", err);
        return EXIT_FAILURE_WORK;
    }
    if (want_stats)
        fprintf(stderr,
                "imsynth render: %.3f s, %llu camera rays, %llu shading points, %llu shadow "
                "rays, %llu indirect hits, %llu shading points added by adaptive sampling, "
                "%.3f s in the material evaluator (summed over threads)\n",
                st.seconds, (unsigned long long)st.camera_rays,
                (unsigned long long)st.shading_points, (unsigned long long)st.shadow_rays,
                (unsigned long long)st.indirect_hits,
                (unsigned long long)st.extra_shading_points, st.material_seconds);
    if (image_write_exr(out_path, &img, want_float ? IMAGE_EXR_FLOAT : IMAGE_EXR_HALF, err,
                        sizeof err) < 0 ||
        (png_path && image_write_png(png_path, &img, err, sizeof err) < 0)) {
        cli_error(sub, "%s", err);
        image_free(&img);
        return EXIT_FAILURE_WORK;
    }
    image_free(&img);
    return EXIT_OK;
}

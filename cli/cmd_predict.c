/* imsynth predict: an image in, an editable Blender material out (pipeline.h, "predict";
 * docs/predict.md). */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli/cli.h"
#include "pipeline/pipeline.h"

static const char *const help =
    "usage: imsynth predict IMAGE -o OUTDIR [options]\n"
    "\n"
    "Turns a photo or render of a surface into a procedural Blender material:\n"
    "  1. IMAGE (PNG, JPEG with EXIF orientation, TIFF, EXR; 8/16-bit, float, grey, RGBA;\n"
    "     any size of at least 32 x 32) is cut to its largest centred square and resampled\n"
    "     to the scene's 256 x 256, then described as the model's training renders were;\n"
    "  2. candidates: the predictor's --top-k hypotheses and the --nearest catalogue samples\n"
    "     (each list's first whose sub-shaders differ), each rendered in our scene and scored;\n"
    "  3. the best is refined: a search over the parameters its sub-shader depends on,\n"
    "     --refine N renders at the refine preset (N = 1: no refinement);\n"
    "  4. the result is rendered at the final preset and its sub-shader extracted.\n"
    "The loss is G + w C: G the Gram distance of the model's descriptor, C the mean\n"
    "difference of the sorted 32x32 box averages of the colours (their distributions,\n"
    "not where they are), w = --colour-weight.\n"
    "\n"
    "OUTDIR (written whole or not at all; an earlier predict output there is replaced):\n"
    "  material.json  the material, for Blender:\n"
    "                 blender -b -P blender/import_material.py -- OUTDIR/material.json \\\n"
    "                     --save material.blend\n"
    "  params.json    its super-shader parameters, before any texture rotation (imsynth\n"
    "                 extract --params params.json --texture-rotation R, R from report.json)\n"
    "  preview.png    our render of it in the scene\n"
    "  compare.png    input | preview | the refinement's loss curve\n"
    "  report.json    candidates, losses, the winner, the curve, timings\n"
    "  material.blend with --blend: the material on our scene's plane, built by Blender\n"
    "                 (blender on PATH, or $IMSYNTH_BLENDER) with import_material.py\n"
    "\n"
    "options:\n"
    "  -o, --output OUTDIR    the output folder (required)\n"
    "  --model DIR            a model from imsynth fit-predictor (default assets/model)\n"
    "  --light scene|flash|auto  where the input's light was: our point-light scene, a\n"
    "                         flash at the camera, or auto (default): both, the better kept\n"
    "  --rotation 0|90|auto   which way the input's pattern may run: as the super-shader\n"
    "                         makes bricks, planks and bands (0: along X), turned a quarter\n"
    "                         (90: along Y; the material gets a Mapping node), or auto\n"
    "                         (default): both ways' candidates, the least loss wins\n"
    "  --rotation-margin M    auto: the turned candidates win only when their least loss is\n"
    "                         below M x the unturned ones' (default 1)\n"
    "  --top-k K              predictor hypotheses (default 8)\n"
    "  --sample-hypotheses T  the likeliest and K - 1 drawn from the selectors' distributions\n"
    "                         sharpened to p^(1/T) (default 0.5; 0: the K likeliest)\n"
    "  --nearest N            catalogue candidates (default 8; 0: none)\n"
    "  --nearest-metric M     their retrieval: whitened (default: Euclidean over the model's\n"
    "                         whitened components) or pca (over its PCA scores: closer\n"
    "                         starts, results no closer; EVALUATION.md, session 27)\n"
    "  --refine N             refinement renders, the start's included (default 350)\n"
    "  --method M             coordinate-sweep (default), coordinate, coordinate-jump,\n"
    "                         coordinate-zoom, es, es-split, es-mirror, random\n"
    "                         (docs/predict.md)\n"
    "  --search-preset NAME   the candidates': draft (default; datagen before session\n"
    "                         30), datagen, converged\n"
    "  --refine-preset NAME   the refinement's (default draft: 224 renders take about the\n"
    "                         time of 64 at datagen; docs/predict.md)\n"
    "  --final-preset NAME    the preview's (default converged)\n"
    "  --colour-weight W      weight of the colour term (default 4)\n"
    "  --colour-term T        sorted: the box averages compared as distributions, blind\n"
    "                         to where they are (default); blocks: box by box, where they\n"
    "                         are (the default before session 29; docs/predict.md)\n"
    "  --colour-phase N       the refinement's first N renders weigh it\n"
    "                         --colour-phase-weight (default 12) instead (default N 0)\n"
    "  --start-colour-weight W  the candidates' ranking as starts: G + W C in the chosen\n"
    "                         scene (default 4)\n"
    "  --starts K             race the K best candidates for the --refine renders by\n"
    "                         successive halving (default 1: the best alone)\n"
    "  --threads T            render threads (default: online CPUs); never changes a byte\n"
    "  --seed S               render noise seed (default 1)\n"
    "  --blender 4|3          node and BSDF semantics (default 4)\n"
    "  --graph G.json         the super-shader (default assets/supershader.json; a\n"
    "                         warning if the model was trained on another)\n"
    "  --blend                also write material.blend (needs Blender 3.4 or 4.x)\n"
    "  --quiet                no progress on stderr\n";

typedef struct progress_state {
    int tty, open;
    double last;
} progress_state;

static void progress(void *ctx, const char *stage, int done, int todo, double best)
{
    progress_state *ps = ctx;
    if (ps->tty) {
        fprintf(stderr, "\rpredict: %-12s %3d/%-3d  best loss %.4f   ", stage, done, todo, best);
        ps->open = 1;
    } else if (done == todo) {
        fprintf(stderr, "predict: %s %d/%d, best loss %.4f\n", stage, done, todo, best);
    }
    fflush(stderr);
}

/* Printed with --quiet too: a doubt about the result is not progress. */
static void warn(void *ctx, const char *message)
{
    (void)ctx;
    fprintf(stderr, "imsynth predict: warning: %s\n", message);
}

int cmd_predict(int argc, char **argv)
{
    const char *sub = "predict";
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    predict_options o;
    predict_options_default(&o);
    int quiet = 0;
    long long v;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (a[0] != '-') {
            if (o.image_path) {
                cli_error(sub, "one IMAGE only (got \"%s\" and \"%s\")", o.image_path, a);
                return EXIT_USAGE;
            }
            o.image_path = a;
            continue;
        }
        if (!strcmp(a, "--quiet")) {
            quiet = 1;
            continue;
        }
        if (!strcmp(a, "--blend")) {
            o.blend = getenv("IMSYNTH_BLENDER") ? getenv("IMSYNTH_BLENDER") : "blender";
            continue;
        }
        if (i + 1 >= argc) {
            cli_error(sub, "%s needs a value (see --help)", a);
            return EXIT_USAGE;
        }
        const char *val = argv[++i];
        int r = cli_parse_refine_option(sub, a, val, &o.refine);
        if (r < 0)
            return EXIT_USAGE;
        if (r > 0)
            continue;
        if (!strcmp(a, "-o") || !strcmp(a, "--output"))
            o.out_dir = val;
        else if (!strcmp(a, "--model"))
            o.model_dir = val;
        else if (!strcmp(a, "--graph"))
            o.graph_path = val;
        else if (!strcmp(a, "--light")) {
            int k = cli_name_index(val, predict_light_names, 3);
            if (k < 0) {
                cli_error(sub, "--light: \"%s\" is not scene, flash or auto", val);
                return EXIT_USAGE;
            }
            o.light = (predict_light)k;
        } else if (!strcmp(a, "--rotation")) {
            int k = cli_name_index(val, predict_rotation_names, 3);
            if (k < 0) {
                cli_error(sub, "--rotation: \"%s\" is not 0, 90 or auto", val);
                return EXIT_USAGE;
            }
            o.rotation = (predict_rotation)k;
        } else if (!strcmp(a, "--rotation-margin")) {
            if (cli_parse_double(sub, a, val, 0.0, 10.0, &o.rotation_margin))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--sample-hypotheses")) {
            if (cli_parse_sample_hypotheses(sub, a, val, &o.sample_hypotheses))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--top-k")) {
            if (cli_parse_ll(sub, a, val, 1, 256, &v))
                return EXIT_USAGE;
            o.top_k = (int)v;
        } else if (!strcmp(a, "--nearest-metric")) {
            int m;
            if (cli_parse_nearest_metric(sub, a, val, &m))
                return EXIT_USAGE;
            o.nearest_metric = (predictor_metric)m;
        } else if (!strcmp(a, "--nearest")) {
            if (cli_parse_ll(sub, a, val, 0, 256, &v))
                return EXIT_USAGE;
            o.nearest = (int)v;
        } else if (!strcmp(a, "--search-preset")) {
            if (!(o.search_preset = cli_parse_preset(sub, a, val)))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--refine-preset")) {
            if (!(o.refine_preset = cli_parse_preset(sub, a, val)))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--final-preset")) {
            if (!(o.final_preset = cli_parse_preset(sub, a, val)))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--threads")) {
            if (cli_parse_ll(sub, a, val, 0, 1024, &v))
                return EXIT_USAGE;
            o.threads = (int)v;
        } else if (!strcmp(a, "--seed")) {
            if (cli_parse_ll(sub, a, val, 0, INT64_MAX, &v))
                return EXIT_USAGE;
            o.seed = (uint64_t)v;
        } else if (!strcmp(a, "--blender")) {
            if (strcmp(val, "3") && strcmp(val, "4")) {
                cli_error(sub, "--blender: \"%s\" is not 3 or 4", val);
                return EXIT_USAGE;
            }
            o.blender = atoi(val);
        } else {
            cli_error(sub, "unknown option \"%s\" (see --help)", a);
            return EXIT_USAGE;
        }
    }
    if (!o.image_path || !o.out_dir) {
        cli_error(sub, "need IMAGE and -o OUTDIR (see --help)");
        return EXIT_USAGE;
    }
    progress_state ps = {.tty = isatty(2)};
    if (!quiet) {
        o.progress = progress;
        o.progress_ctx = &ps;
    }
    o.warn = warn;
    char err[1024];
    int rc = predict_run(&o, err, sizeof err);
    if (ps.open)
        fputc('\n', stderr);
    if (rc) {
        cli_error(sub, "%s", err);
        return EXIT_FAILURE_WORK;
    }
    if (!quiet)
        fprintf(stderr, "predict: wrote %s/material.json (import: blender -b -P "
                        "blender/import_material.py -- %s/material.json --save material.blend) "
                        "and %s/compare.png\n",
                o.out_dir, o.out_dir, o.out_dir);
    return EXIT_OK;
}

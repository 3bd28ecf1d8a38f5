/* imsynth search: the materials nearest an image, as a contact sheet (pipeline.h,
 * "search"). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli.h"
#include "pipeline/pipeline.h"

static const char *const help =
    "usage: imsynth search IMAGE -o SHEET.png [--model DIR | --dataset DS.sqlite] [-k K]\n"
    "                      [options]\n"
    "\n"
    "Finds the K materials nearest IMAGE (its centred square at 256 x 256, as predict reads\n"
    "it) and writes a labelled contact sheet: the input, then each hit with its dataset id\n"
    "and distance, nearest first. Every hit is a super-shader sample: export it with\n"
    "  imsynth export assets/supershader.json --seed ID -o material.json\n"
    "Sources:\n"
    "  --model DIR       a model's catalogue (default: the bundled assets/model): the\n"
    "                    retrieval of --nearest-metric; hits are rendered at --preset.\n"
    "                    --catalogue DIR is the same option\n"
    "  --dataset DS      every row of a dataset with a whole MobileNetV2 or VGG19\n"
    "                    descriptor: the Gram distance; its stored renders are shown\n"
    "\n"
    "options:\n"
    "  -o, --output F    the sheet (PNG, required)\n"
    "  -k K              hits (default 8)\n"
    "  --json F          also the hits as JSON (id, view, distance, export command, params)\n"
    "  --cols C          sheet columns (default 5)\n"
    "  --tile PX         tile size (default 160)\n"
    "  --nearest-metric M  a catalogue's distance: pca (default: Euclidean over the\n"
    "                    model's PCA scores) or whitened (over its whitened components)\n"
    "  --preset NAME     renders of catalogue hits: draft, datagen (default), converged\n"
    "  --threads T       render threads (default: online CPUs)\n"
    "  --quiet           no \"id view distance\" lines on stdout\n";

int cmd_search(int argc, char **argv)
{
    const char *sub = "search";
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    search_options o;
    memset(&o, 0, sizeof o);
    o.k = 8;
    o.blender = SG_BLENDER_4;
    o.print = 1;
    o.preset = datagen_preset_find("datagen");
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
            o.print = 0;
            continue;
        }
        if (i + 1 >= argc) {
            cli_error(sub, "%s needs a value (see --help)", a);
            return EXIT_USAGE;
        }
        const char *val = argv[++i];
        if (!strcmp(a, "-o") || !strcmp(a, "--output"))
            o.sheet_path = val;
        else if (!strcmp(a, "--json"))
            o.json_path = val;
        else if (!strcmp(a, "--model") || !strcmp(a, "--catalogue"))
            o.model_dir = val;
        else if (!strcmp(a, "--dataset"))
            o.dataset_path = val;
        else if (!strcmp(a, "--nearest-metric")) {
            int m;
            if (cli_parse_nearest_metric(sub, a, val, &m))
                return EXIT_USAGE;
            o.nearest_metric = (predictor_metric)m;
        }
        else if (!strcmp(a, "-k") || !strcmp(a, "--cols") || !strcmp(a, "--tile") ||
                 !strcmp(a, "--threads")) {
            long long hi = 1024;
            if (cli_parse_ll(sub, a, val, !strcmp(a, "--threads") ? 0 : 1, hi, &v))
                return EXIT_USAGE;
            *(!strcmp(a, "-k") ? &o.k : !strcmp(a, "--cols") ? &o.cols
                                    : !strcmp(a, "--tile") ? &o.tile : &o.threads) = (int)v;
        } else if (!strcmp(a, "--preset")) {
            if (!(o.preset = datagen_preset_find(val))) {
                cli_error(sub, "--preset: unknown \"%s\" (%s)", val, datagen_preset_names());
                return EXIT_USAGE;
            }
        } else {
            cli_error(sub, "unknown option \"%s\" (see --help)", a);
            return EXIT_USAGE;
        }
    }
    if (!o.image_path || !o.sheet_path) {
        cli_error(sub, "need IMAGE and -o SHEET.png (see --help)");
        return EXIT_USAGE;
    }
    if (o.model_dir && o.dataset_path) {
        cli_error(sub, "--model (--catalogue) and --dataset are two sources; give one");
        return EXIT_USAGE;
    }
    char err[1024];
    if (search_run(&o, err, sizeof err)) {
        cli_error(sub, "%s", err);
        return EXIT_FAILURE_WORK;
    }
    return EXIT_OK;
}

/* imsynth evaluate: a model against test inputs, every method, parameter and image space
 * (pipeline.h, "evaluation"; docs/evaluation.md). */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli.h"
#include "pipeline/pipeline.h"

static const char *const help =
    "usage: imsynth evaluate --model DIR (--test TEST.sqlite | --handmade DIR) -o REPORT_DIR\n"
    "                        [options]\n"
    "\n"
    "Evaluates a predictor (imsynth fit-predictor) on inputs it never saw: the rows of a\n"
    "synthetic test dataset (imsynth datagen with ids disjoint from the training set's;\n"
    "renders stored; augmented views are a set of their own) and hand-made Cycles materials\n"
    "(DIR/<name>/render.exr in assets/scene.json, shifted.exr the same with its texture\n"
    "coordinates shifted, flash.exr in assets/scene-flash.json: a second input set).\n"
    "\n"
    "Methods, for every input:\n"
    "  mean            the training set's mean parameters (the thesis's result)\n"
    "  random          a catalogue sample drawn per input (seeded)\n"
    "  nearest         the catalogue sample nearest the input's descriptor (retrieval)\n"
    "  nearest-topk    the --top-k nearest, rendered; the best by the training descriptor\n"
    "  predictor       the predictor's most probable hypothesis\n"
    "  predictor-topk  its --top-k hypotheses, rendered; the best by the training descriptor\n"
    "  nearest-refine, predictor-refine  the two -topk methods' candidates refined as\n"
    "                  imsynth predict does: from the one best by the loss G + w C,\n"
    "                  --refine renders of the search (docs/predict.md)\n"
    "A candidate is rendered with the --preset in the input's own scene (a synthetic row's\n"
    "view: light, flash, exposure, white balance, texture transform); every render of one\n"
    "input shares one seed, a function of --seed and the input only.\n"
    "\n"
    "Image space: distances between the input and each method's render:\n"
    "  mobilenetv2, vgg19  Gram distance: the mean over the descriptor's layers of\n"
    "                      ||a_l - b_l|| / (||a_l|| + ||b_l||), in [0, 1]; the model's own\n"
    "                      descriptor is the training one, the other an independent judge\n"
    "  colour              mean |a - b| of the 32x32 box averages of the centre 224 crops\n"
    "                      (linear RGB clamped to [0, 1]), box by box\n"
    "  colour-sorted       the same boxes compared as distributions (R, G, B and half of\n"
    "                      R-G, G-B, B-R, each sorted): never above colour\n"
    "each divided by the target's floor: the distance between the input and a render of the\n"
    "target's own parameters with Pattern Offset + 0.5 (hand-made: render.exr against\n"
    "shifted.exr; flash.exr against flash-shifted.exr if present, else render.exr's floor);\n"
    "a floor below 1e-3 counts as 1e-3 (the report says how many). 1 = as close as an exact\n"
    "answer can be expected to come.\n"
    "Parameter space (synthetic sets): selector accuracy against the majority class; R^2 of\n"
    "each value parameter where active (about the training mean: the mean method scores 0);\n"
    "spread = std of predictions / std of targets; correlation (Pearson's) of the two.\n"
    "\n"
    "REPORT_DIR (must not exist; written whole or not at all): report.json (every input,\n"
    "method and distance, raw and normalised; floors; summaries; targets; configs),\n"
    "summary.csv, summary.md, inputs.csv (every input x method x distance), sheet-synthetic.png,\n"
    "sheet-handmade.png, index.html, and timings.json (wall clock: the other files do not\n"
    "depend on --threads).\n"
    "\n"
    "options:\n"
    "  --model DIR           the model folder (required)\n"
    "  --test TEST.sqlite    the synthetic test dataset\n"
    "  --handmade DIR        the hand-made materials (e.g. tests/handmade)\n"
    "  -o, --output DIR      the report folder (required)\n"
    "  --top-k K             candidates of the -topk methods (default 8)\n"
    "  --sample-hypotheses T the predictor's top-k: its likeliest combination and K - 1\n"
    "                        drawn from its heads sharpened to p^(1/T) (default 0.5,\n"
    "                        predict's; 0: the K likeliest)\n"
    "  --nearest-metric M    the nearest methods' retrieval: pca (default, the stronger\n"
    "                        baseline) or whitened (predict's candidates')\n"
    "  --refine N            renders of each refinement, its start's included (default 350,\n"
    "                        predict's; 1: the -refine rows are their starts)\n"
    "  --method M            the refinement: coordinate-sweep (default), coordinate,\n"
    "                        coordinate-jump, coordinate-zoom, es, es-split, es-mirror,\n"
    "                        random\n"
    "  --preset NAME         how candidates are rendered: draft, datagen (default), converged\n"
    "  --colour-weight W     the -refine rows' loss G + W C (default 4, predict's)\n"
    "  --colour-term T       C: blocks or sorted (default sorted, predict's)\n"
    "  --colour-phase N      their first N renders weigh C --colour-phase-weight\n"
    "                        (default 12) instead (default N 0, predict's)\n"
    "  --start-colour-weight W  a -refine row starts from its -topk method's candidate\n"
    "                        best by G + W C (default 4, predict's)\n"
    "  --starts K            race the -topk method's K best picks (default 1, predict's)\n"
    "  --refine-preset NAME  the -refine rows' search renders (default draft, predict's);\n"
    "                        their results are rendered and measured at --preset\n"
    "  --limit N             the first N rows of the test dataset only\n"
    "  --threads T           workers (default: online CPUs); never changes report.json\n"
    "  --seed S              render seeds and random draws (default 0)\n"
    "  --sheet N             synthetic inputs on the contact sheet (default 16)\n"
    "  --blender 4|3         node and BSDF semantics (default 4)\n"
    "  --graph G.json        the super-shader (default assets/supershader.json)\n"
    "  --scene S.json        default assets/scene.json\n"
    "  --flash-scene S.json  default assets/scene-flash.json\n";

static void progress(void *ctx, long long done, long long todo, double seconds)
{
    *(int *)ctx = done < todo; /* a line to end before an error message */
    double eta = done ? seconds / (double)done * (double)(todo - done) : 0.0;
    fprintf(stderr, "\revaluate: %lld/%lld inputs, %.0f s, ETA %.0f s   ", done, todo, seconds,
            eta);
    if (done == todo)
        fputc('\n', stderr);
    fflush(stderr);
}

int cmd_evaluate(int argc, char **argv)
{
    const char *sub = "evaluate";
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    evaluate_options o;
    memset(&o, 0, sizeof o);
    o.top_k = 8;
    o.blender = SG_BLENDER_4;
    o.sheet_inputs = 16;
    o.preset = datagen_preset_find("datagen");
    /* The -refine rows run predict's search: its method, budget and preset; the -topk
     * rows its hypotheses. */
    predict_options po;
    predict_options_default(&po);
    o.refine = po.refine;
    o.sample_hypotheses = po.sample_hypotheses;
    /* The nearest rows are the retrieval baseline: the stronger retrieval (PCA scores;
     * EVALUATION.md, session 27), not predict's candidates' (pipeline.h) */
    o.nearest_metric = PREDICTOR_METRIC_PCA;
    o.refine_preset = po.refine_preset;
    int open_line = 0;
    o.progress = progress;
    o.progress_ctx = &open_line;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (i + 1 >= argc) {
            cli_error(sub, "%s: unknown option or missing value (see --help)", a);
            return EXIT_USAGE;
        }
        const char *v = argv[++i];
        long long n;
        int r = cli_parse_refine_option(sub, a, v, &o.refine);
        if (r < 0)
            return EXIT_USAGE;
        if (r > 0)
            continue;
        if (!strcmp(a, "--model"))
            o.model_dir = v;
        else if (!strcmp(a, "--test"))
            o.test_path = v;
        else if (!strcmp(a, "--handmade"))
            o.handmade_dir = v;
        else if (!strcmp(a, "-o") || !strcmp(a, "--output"))
            o.out_dir = v;
        else if (!strcmp(a, "--graph"))
            o.graph_path = v;
        else if (!strcmp(a, "--scene"))
            o.scene_path = v;
        else if (!strcmp(a, "--flash-scene"))
            o.flash_scene_path = v;
        else if (!strcmp(a, "--preset")) {
            if (!(o.preset = cli_parse_preset(sub, a, v)))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--refine-preset")) {
            if (!(o.refine_preset = cli_parse_preset(sub, a, v)))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--top-k")) {
            if (cli_parse_ll(sub, a, v, 1, 256, &n))
                return EXIT_USAGE;
            o.top_k = (int)n;
        } else if (!strcmp(a, "--sample-hypotheses")) {
            if (cli_parse_sample_hypotheses(sub, a, v, &o.sample_hypotheses))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--nearest-metric")) {
            int m;
            if (cli_parse_nearest_metric(sub, a, v, &m))
                return EXIT_USAGE;
            o.nearest_metric = (predictor_metric)m;
        } else if (!strcmp(a, "--limit")) {
            if (cli_parse_ll(sub, a, v, 1, INT64_MAX, &n))
                return EXIT_USAGE;
            o.limit = n;
        } else if (!strcmp(a, "--threads")) {
            if (cli_parse_ll(sub, a, v, 1, 256, &n))
                return EXIT_USAGE;
            o.threads = (int)n;
        } else if (!strcmp(a, "--seed")) {
            if (cli_parse_ll(sub, a, v, 0, INT64_MAX, &n))
                return EXIT_USAGE;
            o.seed = (uint64_t)n;
        } else if (!strcmp(a, "--sheet")) {
            if (cli_parse_ll(sub, a, v, 1, 256, &n))
                return EXIT_USAGE;
            o.sheet_inputs = (int)n;
        } else if (!strcmp(a, "--blender")) {
            if (strcmp(v, "3") && strcmp(v, "4")) {
                cli_error(sub, "--blender: expected 3 or 4, got \"%s\"", v);
                return EXIT_USAGE;
            }
            o.blender = v[0] - '0';
        } else {
            cli_error(sub, "unknown option \"%s\" (see --help)", a);
            return EXIT_USAGE;
        }
    }
    if (!o.model_dir || !o.out_dir || (!o.test_path && !o.handmade_dir)) {
        cli_error(sub, "need --model DIR, -o REPORT_DIR and --test TEST.sqlite and/or "
                       "--handmade DIR (see --help)");
        return EXIT_USAGE;
    }
    char err[2048];
    if (evaluate_run(&o, err, sizeof err)) {
        if (open_line)
            fputc('\n', stderr);
        cli_error(sub, "%s", err);
        return EXIT_FAILURE_WORK;
    }
    printf("%s: report.json, summary.md, index.html\n", o.out_dir);
    return EXIT_OK;
}

/* imsynth datagen: make (or resume) a training dataset. */
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#include "cli/cli.h"
#include "pipeline/pipeline.h"

static const char *const help =
    "usage: imsynth datagen --out DS.sqlite --count N [options]\n"
    "\n"
    "Makes the samples with ids [first-id, first-id + N) that DS.sqlite lacks: for each id,\n"
    "the super-shader parameters of `imsynth sample --seed ID`, the active-parameter mask\n"
    "(parameters the extracted sub-shader depends on), a render of every view, its Gram\n"
    "descriptor (stored as float16) and the render itself (docs/datasets.md).\n"
    "A sample's bytes depend only on its id and the config: threads, shards and interruptions\n"
    "never change them. Killed or interrupted, rerun the same command: only missing ids are\n"
    "made. A file made with another config is refused. Ctrl-C stops after the current batch.\n"
    "\n"
    "options:\n"
    "  --out DS.sqlite        the dataset (created if missing)\n"
    "  --count N              ids in the range\n"
    "  --first-id K           first id (default 0)\n"
    "  --shard i/n            only ids with id % n == i (for clusters; merge the shards with\n"
    "                         `imsynth dataset merge`). i may be SLURM or JOB_COMPLETION to\n"
    "                         read $SLURM_ARRAY_TASK_ID or $JOB_COMPLETION_INDEX\n"
    "  --threads T            worker threads (default: online CPUs)\n"
    "  --preset NAME          render preset: draft (1 shading point a pixel), datagen (4,\n"
    "                         default), converged (4 + adaptive up to 256)\n"
    "  --augment SPEC         extra views: views=K,light=M,flash=P,exposure=STOPS,wb=W,\n"
    "                         rotate=DEGREES,shift=M (texture space) (e.g. views=2,\n"
    "                         light=0.15,flash=0.5,exposure=0.5,wb=0.1,rotate=180,shift=1)\n"
    "  --images none|png16|exr  store the render as a 16-bit linear PNG (default), a half\n"
    "                         EXR, or not at all\n"
    "  --descriptor mobilenetv2|vgg19|none  the stored descriptor: MobileNetV2 Gram values\n"
    "                         (ImageNet layers, 38,808 floats; default: measured the better\n"
    "                         texture descriptor, BENCHMARKS.md), VGG19 (random weights, seed\n"
    "                         1, avg3: 305,888), or none (`dataset describe` adds one later)\n"
    "  --descriptor-mask M.npy  store only these features: a 0/1 mask over the descriptor's\n"
    "                         values or their indices (e.g. `imsynth forest importance`)\n"
    "  --batch B              samples per transaction (default 4 x threads)\n"
    "  --blender 4|3          node and BSDF semantics (default 4)\n"
    "  --graph G.json         super-shader (default: assets/supershader.json, found beside\n"
    "                         the installed or built imsynth, or in $IMSYNTH_DATA)\n"
    "  --scene S.json         scene (default assets/scene.json)\n"
    "  --flash-scene S.json   flash scene for --augment flash (default assets/scene-flash.json)\n"
    "  --quiet                no progress\n";

/* The one piece of process-wide state: set by SIGINT, read between batches. */
static volatile int stop_requested;

static void on_sigint(int sig)
{
    (void)sig;
    stop_requested = 1;
}

typedef struct progress_state {
    int tty, quiet;
    double start, last;
} progress_state;

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void progress(void *ctx, long long done, long long todo, const double stage[5])
{
    progress_state *p = ctx;
    if (p->quiet)
        return;
    double t = now_s(), el = t - p->start;
    if (!p->tty && t - p->last < 5.0 && done < todo)
        return;
    p->last = t;
    double rate = el > 0 ? (double)done / el : 0, eta = rate > 0 ? (double)(todo - done) / rate : 0;
    double total = 0;
    for (int k = 0; k < 5; k++)
        total += stage[k];
    char split[160];
    int n = 0;
    for (int k = 0; k < 5; k++)
        n += snprintf(split + n, sizeof split - (size_t)n, "%s%s %.0f%%", k ? " " : "",
                      datagen_stage_names[k], total > 0 ? 100.0 * stage[k] / total : 0.0);
    if (p->tty) {
        int width = 24, fill = todo ? (int)(width * done / todo) : width;
        char bar[32];
        for (int i = 0; i < width; i++)
            bar[i] = i < fill ? '#' : '.';
        bar[width] = 0;
        fprintf(stderr, "\r[%s] %lld/%lld  %.2f/s  ETA %02d:%02d:%02d  (%s)  ", bar, done, todo,
                rate, (int)(eta / 3600), (int)(eta / 60) % 60, (int)eta % 60, split);
        if (done == todo)
            fputc('\n', stderr);
    } else
        fprintf(stderr, "datagen: %lld/%lld samples, %.2f/s, ETA %.0f s (%s)\n", done, todo, rate,
                eta, split);
    fflush(stderr);
}

/* "i/n", with i read from the scheduler's variable when it is SLURM or JOB_COMPLETION. */
static int parse_shard(const char *sub, const char *s, int *index, int *count)
{
    char buf[64];
    snprintf(buf, sizeof buf, "%s", s);
    char *slash = strchr(buf, '/');
    if (!slash) {
        cli_error(sub, "--shard: expected i/n, got \"%s\"", s);
        return -1;
    }
    *slash = 0;
    const char *is = buf;
    if (!strcmp(buf, "SLURM") || !strcmp(buf, "JOB_COMPLETION")) {
        const char *var = buf[0] == 'S' ? "SLURM_ARRAY_TASK_ID" : "JOB_COMPLETION_INDEX";
        is = getenv(var);
        if (!is) {
            cli_error(sub, "--shard %s: $%s is not set", s, var);
            return -1;
        }
    }
    long long i, n;
    if (cli_parse_ll(sub, "--shard n", slash + 1, 1, 1 << 20, &n) ||
        cli_parse_ll(sub, "--shard i", is, 0, n - 1, &i))
        return -1;
    *index = (int)i;
    *count = (int)n;
    return 0;
}

int cmd_datagen(int argc, char **argv)
{
    const char *sub = "datagen";
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    datagen_options o;
    memset(&o, 0, sizeof o);
    o.shard_count = 1;
    o.blender = SG_BLENDER_4;
    o.preset = datagen_preset_find("datagen");
    o.images = DATAGEN_IMAGES_PNG16;
    o.descriptor = DATAGEN_DESC_MOBILENETV2_F16;
    int have_count = 0, quiet = 0;
    const char *augment = NULL;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int flag = !strcmp(a, "--quiet");
        if (!flag && i + 1 >= argc) {
            cli_error(sub, "%s needs a value (see --help)", a);
            return EXIT_USAGE;
        }
        const char *v = flag ? NULL : argv[++i];
        long long x;
        if (flag)
            quiet = 1;
        else if (!strcmp(a, "--out") || !strcmp(a, "-o"))
            o.out_path = v;
        else if (!strcmp(a, "--count")) {
            if (cli_parse_ll(sub, a, v, 0, 1LL << 40, &o.count))
                return EXIT_USAGE;
            have_count = 1;
        } else if (!strcmp(a, "--first-id")) {
            if (cli_parse_ll(sub, a, v, 0, 1LL << 50, &o.first_id))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--shard")) {
            if (parse_shard(sub, v, &o.shard_index, &o.shard_count))
                return EXIT_USAGE;
        } else if (!strcmp(a, "--threads")) {
            if (cli_parse_ll(sub, a, v, 0, 256, &x))
                return EXIT_USAGE;
            o.threads = (int)x;
        } else if (!strcmp(a, "--batch")) {
            if (cli_parse_ll(sub, a, v, 1, 4096, &x))
                return EXIT_USAGE;
            o.batch = (int)x;
        } else if (!strcmp(a, "--blender")) {
            if (cli_parse_ll(sub, a, v, 3, 4, &x))
                return EXIT_USAGE;
            o.blender = (int)x;
        } else if (!strcmp(a, "--preset")) {
            if (!(o.preset = datagen_preset_find(v))) {
                cli_error(sub, "--preset: unknown \"%s\" (one of %s)", v, datagen_preset_names());
                return EXIT_USAGE;
            }
        } else if (!strcmp(a, "--augment"))
            augment = v;
        else if (!strcmp(a, "--images")) {
            if (!strcmp(v, "none"))
                o.images = DATAGEN_IMAGES_NONE;
            else if (!strcmp(v, "png16"))
                o.images = DATAGEN_IMAGES_PNG16;
            else if (!strcmp(v, "exr"))
                o.images = DATAGEN_IMAGES_EXR;
            else {
                cli_error(sub, "--images: expected none, png16 or exr, got \"%s\"", v);
                return EXIT_USAGE;
            }
        } else if (!strcmp(a, "--descriptor")) {
            if (!strcmp(v, "none"))
                o.descriptor = DATAGEN_DESC_NONE;
            else if (!strcmp(v, "vgg19"))
                o.descriptor = DATAGEN_DESC_VGG19_F16;
            else if (!strcmp(v, "mobilenetv2"))
                o.descriptor = DATAGEN_DESC_MOBILENETV2_F16;
            else {
                cli_error(sub, "--descriptor: expected mobilenetv2, vgg19 or none, got \"%s\"", v);
                return EXIT_USAGE;
            }
        } else if (!strcmp(a, "--graph"))
            o.graph_path = v;
        else if (!strcmp(a, "--scene"))
            o.scene_path = v;
        else if (!strcmp(a, "--flash-scene"))
            o.flash_scene_path = v;
        else if (!strcmp(a, "--descriptor-mask"))
            o.descriptor_mask_path = v;
        else {
            cli_error(sub, "unknown option \"%s\" (see --help)", a);
            return EXIT_USAGE;
        }
    }
    if (!o.out_path || !have_count) {
        cli_error(sub, "need --out DS.sqlite and --count N (see --help)");
        return EXIT_USAGE;
    }
    char err[1024];
    if (datagen_augment_parse(augment, &o.augment, err, sizeof err)) {
        cli_error(sub, "%s", err);
        return EXIT_USAGE;
    }
    progress_state ps = {.tty = isatty(2), .quiet = quiet, .start = now_s()};
    o.progress = progress;
    o.progress_ctx = &ps;
    o.stop = &stop_requested;
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_sigint;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    long long made = 0;
    int rc = datagen_run(&o, &made, err, sizeof err);
    if (rc < 0) {
        cli_error(sub, "%s", err);
        return EXIT_FAILURE_WORK;
    }
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    if (!quiet)
        fprintf(stderr, "datagen: %s: %lld samples made in %.1f s, peak RSS %.0f MB%s\n",
                o.out_path, made, now_s() - ps.start, (double)ru.ru_maxrss / 1024.0,
                rc == 1 ? " (stopped; rerun to resume)" : "");
    return rc == 1 ? 130 : EXIT_OK;
}

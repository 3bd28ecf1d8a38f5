/* imsynth dataset: look at, merge, export or view datasets made by datagen. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli.h"
#include "pipeline/pipeline.h"

static const char *const help =
    "usage: imsynth dataset info DS.sqlite [--json] [--digest]\n"
    "       imsynth dataset merge A.sqlite B.sqlite ... -o ALL.sqlite\n"
    "       imsynth dataset export DS.sqlite --npy DIR\n"
    "       imsynth dataset sheet DS.sqlite -o SHEET.png [--count N] [--cols C] [--tile PX]\n"
    "       imsynth dataset describe DS.sqlite -o OUT.sqlite [--descriptor mobilenetv2|vgg19]\n"
    "                                [--descriptor-mask M.npy] [--threads T]\n"
    "\n"
    "info    samples, rows (samples x views), id range, parameters, descriptor size, size\n"
    "        on disk, the config and its hash; --digest adds a SHA-256 of every row's\n"
    "        contents (equal digests: the same samples, byte for byte)\n"
    "merge   the union of datasets made with the same config (shards); refuses mismatched\n"
    "        configs and ids present twice; written atomically\n"
    "export  ids.npy (int64), views.npy (int32), params.npy (float32), active.npy (uint8),\n"
    "        descriptors.npy (float16, when stored) and params.txt, one row per (id, view), in id order.\n"
    "        In NumPy:\n"
    "          import numpy as np\n"
    "          X = np.load('DIR/descriptors.npy').astype(np.float32)\n"
    "          Y = np.load('DIR/params.npy'); M = np.load('DIR/active.npy').astype(bool)\n"
    "          names = open('DIR/params.txt').read().split('\\n')[:-1]\n"
    "          ids = np.load('DIR/ids.npy')\n"
    "sheet   a contact sheet of the first N renders (default 64), labelled with their ids\n"
    "describe  recompute the descriptors from the stored renders into a new dataset, as\n"
    "        datagen makes them (default mobilenetv2), all values or only the features of a\n"
    "        mask (a 0/1 mask or an index list)\n";

static int info(const char *sub, int argc, char **argv)
{
    const char *path = NULL;
    int json = 0, digest = 0;
    for (int i = 0; i < argc; i++) {
        if (!strcmp(argv[i], "--json"))
            json = 1;
        else if (!strcmp(argv[i], "--digest"))
            digest = 1;
        else if (argv[i][0] != '-' && !path)
            path = argv[i];
        else {
            cli_error(sub, "info: unexpected argument \"%s\"", argv[i]);
            return EXIT_USAGE;
        }
    }
    if (!path) {
        cli_error(sub, "info: need DS.sqlite");
        return EXIT_USAGE;
    }
    char err[1024];
    dataset *d = dataset_open(path, err, sizeof err);
    dataset_info in;
    if (!d || dataset_get_info(d, &in, err, sizeof err)) {
        cli_error(sub, "%s", err);
        dataset_close(d);
        return EXIT_FAILURE_WORK;
    }
    char sum[65] = "";
    if (digest && dataset_digest(d, sum, err, sizeof err)) {
        cli_error(sub, "%s", err);
        dataset_info_free(&in);
        dataset_close(d);
        return EXIT_FAILURE_WORK;
    }
    if (json)
        printf("{\"path\": \"%s\", \"digest\": \"%s\", \"samples\": %lld, \"rows\": %lld, \"min_id\": %lld, "
               "\"max_id\": %lld, \"params\": %d, \"descriptor_size\": %zu, \"bytes\": %lld, "
               "\"config_hash\": \"%s\", \"config\": %s}\n",
               path, sum, in.samples, in.rows, in.min_id, in.max_id, in.n_params, in.descriptor_size,
               in.file_bytes, in.config_hash, in.config_json);
    else {
        printf("%s\n  samples          %lld (%lld rows with views)\n", path, in.samples, in.rows);
        if (in.samples)
            printf("  ids              %lld .. %lld\n", in.min_id, in.max_id);
        printf("  parameters       %d\n  descriptor       %zu floats (float16)\n"
               "  size             %.1f MB (%.1f KB a row)\n  config hash      %s\n"
               "  config           %s\n",
               in.n_params, in.descriptor_size, (double)in.file_bytes / 1e6,
               in.rows ? (double)in.file_bytes / 1e3 / (double)in.rows : 0.0, in.config_hash,
               in.config_json);
        if (digest)
            printf("  content digest   %s\n", sum);
    }
    dataset_info_free(&in);
    dataset_close(d);
    return EXIT_OK;
}

static int merge(const char *sub, int argc, char **argv)
{
    const char *out = NULL;
    const char **inputs = calloc((size_t)argc + 1, sizeof *inputs);
    int n = 0;
    if (!inputs)
        return EXIT_FAILURE_WORK;
    for (int i = 0; i < argc; i++) {
        if ((!strcmp(argv[i], "-o") || !strcmp(argv[i], "--out")) && i + 1 < argc)
            out = argv[++i];
        else if (argv[i][0] != '-')
            inputs[n++] = argv[i];
        else {
            cli_error(sub, "merge: unexpected argument \"%s\"", argv[i]);
            free(inputs);
            return EXIT_USAGE;
        }
    }
    if (!out || n < 1) {
        cli_error(sub, "merge: need at least one input and -o OUT.sqlite");
        free(inputs);
        return EXIT_USAGE;
    }
    char err[1024];
    int rc = dataset_merge(inputs, n, out, err, sizeof err);
    free(inputs);
    if (rc) {
        cli_error(sub, "%s", err);
        return EXIT_FAILURE_WORK;
    }
    return EXIT_OK;
}

static int export_or_sheet(const char *sub, int argc, char **argv, int sheet)
{
    const char *path = NULL, *out = NULL;
    long count = 64, cols = 8, tile = 128;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        int takes = !strcmp(a, "--npy") || !strcmp(a, "-o") || !strcmp(a, "--count") ||
                    !strcmp(a, "--cols") || !strcmp(a, "--tile");
        if (takes && i + 1 < argc) {
            const char *v = argv[++i];
            if (!strcmp(a, "--npy") || !strcmp(a, "-o"))
                out = v;
            else {
                char *end;
                long x = strtol(v, &end, 10);
                if (*end || x < 1 || x > 100000) {
                    cli_error(sub, "%s: expected a positive integer, got \"%s\"", a, v);
                    return EXIT_USAGE;
                }
                *(!strcmp(a, "--count") ? &count : !strcmp(a, "--cols") ? &cols : &tile) = x;
            }
        } else if (a[0] != '-' && !path)
            path = a;
        else {
            cli_error(sub, "unexpected argument \"%s\" (see --help)", a);
            return EXIT_USAGE;
        }
    }
    if (!path || !out) {
        cli_error(sub, sheet ? "sheet: need DS.sqlite and -o SHEET.png"
                             : "export: need DS.sqlite and --npy DIR");
        return EXIT_USAGE;
    }
    if (tile > 1024)
        tile = 1024;
    char err[1024];
    dataset *d = dataset_open(path, err, sizeof err);
    int rc = d ? 0 : -1;
    if (d)
        rc = sheet ? dataset_contact_sheet(d, out, (int)count, (int)cols, (int)tile, err, sizeof err)
                   : dataset_export_npy(d, out, err, sizeof err);
    dataset_close(d);
    if (rc) {
        cli_error(sub, "%s", err);
        return EXIT_FAILURE_WORK;
    }
    return EXIT_OK;
}

static int describe(const char *sub, int argc, char **argv)
{
    const char *path = NULL, *out = NULL, *mask = NULL;
    datagen_descriptor kind = DATAGEN_DESC_MOBILENETV2_F16;
    long threads = 2;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if ((!strcmp(a, "-o") || !strcmp(a, "--out")) && i + 1 < argc)
            out = argv[++i];
        else if (!strcmp(a, "--descriptor-mask") && i + 1 < argc)
            mask = argv[++i];
        else if (!strcmp(a, "--descriptor") && i + 1 < argc) {
            const char *v = argv[++i];
            if (!strcmp(v, "vgg19"))
                kind = DATAGEN_DESC_VGG19_F16;
            else if (!strcmp(v, "mobilenetv2"))
                kind = DATAGEN_DESC_MOBILENETV2_F16;
            else {
                cli_error(sub, "--descriptor: expected mobilenetv2 or vgg19, got \"%s\"", v);
                return EXIT_USAGE;
            }
        }
        else if (!strcmp(a, "--threads") && i + 1 < argc) {
            char *end;
            threads = strtol(argv[++i], &end, 10);
            if (*end || threads < 1 || threads > 256) {
                cli_error(sub, "--threads: expected 1-256, got \"%s\"", argv[i]);
                return EXIT_USAGE;
            }
        } else if (a[0] != '-' && !path)
            path = a;
        else {
            cli_error(sub, "describe: unexpected argument \"%s\"", a);
            return EXIT_USAGE;
        }
    }
    if (!path || !out) {
        cli_error(sub, "describe: need DS.sqlite and -o OUT.sqlite");
        return EXIT_USAGE;
    }
    char err[1024];
    if (dataset_describe(path, out, kind, mask, (int)threads, err, sizeof err)) {
        cli_error(sub, "%s", err);
        return EXIT_FAILURE_WORK;
    }
    return EXIT_OK;
}

int cmd_dataset(int argc, char **argv)
{
    const char *sub = "dataset";
    if (cli_wants_help(argc, argv) || argc < 2) {
        fputs(help, argc < 2 ? stderr : stdout);
        return argc < 2 ? EXIT_USAGE : EXIT_OK;
    }
    const char *verb = argv[1];
    if (!strcmp(verb, "info"))
        return info(sub, argc - 2, argv + 2);
    if (!strcmp(verb, "merge"))
        return merge(sub, argc - 2, argv + 2);
    if (!strcmp(verb, "export"))
        return export_or_sheet(sub, argc - 2, argv + 2, 0);
    if (!strcmp(verb, "sheet"))
        return export_or_sheet(sub, argc - 2, argv + 2, 1);
    if (!strcmp(verb, "describe"))
        return describe(sub, argc - 2, argv + 2);
    cli_error(sub, "unknown verb \"%s\" (info, merge, export, sheet, describe)", verb);
    return EXIT_USAGE;
}

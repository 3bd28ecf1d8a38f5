/* imsynth compare: error metrics of a render against a (Cycles) reference, for people and
 * for scripts (--json). */
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "cli/cli.h"
#include "imageio/imageio.h"

static const char *const help =
    "usage: imsynth compare IMAGE REFERENCE [REFERENCE_B] [--json]\n"
    "\n"
    "Compares IMAGE with REFERENCE over RGB (any format image_read takes: EXR, PNG, ...;\n"
    "same size, 3 or more channels). With REFERENCE_B, the reference is the mean of the\n"
    "two, taken as independent renders of the same scene (the -a and -b halves of a\n"
    "Cycles reference), and their difference measures the reference's own noise.\n"
    "\n"
    "Metrics (ref is the reference or the mean of the two):\n"
    "  ref_mean         mean of ref over pixels and RGB\n"
    "  rmse, mae        sqrt(mean (IMAGE - ref)^2), mean |IMAGE - ref|\n"
    "  bias             per channel (mean IMAGE_c - mean ref_c) / mean ref_c\n"
    "  worst_block      over whole 16 x 16 blocks, the largest |block mean of IMAGE -\n"
    "                   block mean of ref| / block mean of ref (RGB together), and the\n"
    "                   block's position in blocks (x, y from the top left)\n"
    "  ref_noise_rmse   (with REFERENCE_B) sqrt(mean ((A - B) / 2)^2): the RMS noise of ref\n"
    "  rmse_converged   (with REFERENCE_B) sqrt(max(rmse^2 - ref_noise_rmse^2, 0)): the\n"
    "                   estimated RMSE against the converged image\n"
    "\n"
    "options:\n"
    "  --json           print one JSON object with these keys (bias is [r, g, b]; the\n"
    "                   worst_block keys are null when the image is under 16 x 16) at\n"
    "                   9 significant digits, instead of the human-readable lines\n"
    "\n"
    "A NaN or infinite RGB value in any image is an error naming the file and the pixel.\n";

static void print_json(const image_comparison *m)
{
    printf("{\"ref_mean\": %.9g, \"rmse\": %.9g, \"mae\": %.9g, "
           "\"bias\": [%.9g, %.9g, %.9g], ",
           m->ref_mean, m->rmse, m->mae, m->bias[0], m->bias[1], m->bias[2]);
    if (m->worst_block_x >= 0)
        printf("\"worst_block\": %.9g, \"worst_block_x\": %d, \"worst_block_y\": %d", m->worst_block,
               m->worst_block_x, m->worst_block_y);
    else
        printf("\"worst_block\": null, \"worst_block_x\": null, \"worst_block_y\": null");
    if (m->has_b)
        printf(", \"ref_noise_rmse\": %.9g, \"rmse_converged\": %.9g", m->ref_noise_rmse,
               m->rmse_converged);
    printf("}\n");
}

/* " (x as a percentage of the reference mean)", nothing when that mean is 0. */
static void print_percent_of_mean(double x, double ref_mean)
{
    if (ref_mean != 0)
        printf(" (%.3f%% of ref mean)", 100.0 * x / ref_mean);
}

static void print_text(const image_comparison *m)
{
    printf("ref mean        %.6g\n", m->ref_mean);
    printf("rmse            %.6g", m->rmse);
    print_percent_of_mean(m->rmse, m->ref_mean);
    printf("\n");
    if (m->has_b) {
        printf("rmse converged  %.6g", m->rmse_converged);
        print_percent_of_mean(m->rmse_converged, m->ref_mean);
        printf("   (the reference's own noise taken out)\n");
        printf("ref noise rmse  %.6g", m->ref_noise_rmse);
        print_percent_of_mean(m->ref_noise_rmse, m->ref_mean);
        printf("\n");
    }
    printf("mae             %.6g", m->mae);
    print_percent_of_mean(m->mae, m->ref_mean);
    printf("\n");
    printf("bias            R %+.3f%%  G %+.3f%%  B %+.3f%%\n", 100.0 * m->bias[0],
           100.0 * m->bias[1], 100.0 * m->bias[2]);
    if (m->worst_block_x >= 0)
        printf("worst block     %.3f%% at block (%d, %d), pixels x %d-%d, y %d-%d\n",
               100.0 * m->worst_block, m->worst_block_x, m->worst_block_y,
               16 * m->worst_block_x, 16 * m->worst_block_x + 15, 16 * m->worst_block_y,
               16 * m->worst_block_y + 15);
    else
        printf("worst block     none (the image is smaller than 16 x 16)\n");
}

int cmd_compare(int argc, char **argv)
{
    const char *sub = "compare";
    if (cli_wants_help(argc, argv)) {
        fputs(help, stdout);
        return EXIT_OK;
    }
    const char *paths[3];
    int n_paths = 0;
    bool json = false;
    bool options_done = false;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!options_done && !strcmp(a, "--")) {
            options_done = true;
        } else if (!options_done && !strcmp(a, "--json")) {
            json = true;
        } else if (!options_done && a[0] == '-' && a[1]) {
            cli_error(sub, "unknown option \"%s\"", a);
            return EXIT_USAGE;
        } else if (n_paths == 3) {
            cli_error(sub, "unexpected argument \"%s\" (at most IMAGE REFERENCE REFERENCE_B)", a);
            return EXIT_USAGE;
        } else {
            paths[n_paths++] = a;
        }
    }
    if (n_paths < 2) {
        cli_error(sub, "need IMAGE and REFERENCE (see --help)");
        return EXIT_USAGE;
    }

    char err[1024];
    image images[3];
    memset(images, 0, sizeof images);
    int rc = EXIT_OK;
    for (int k = 0; k < n_paths && rc == EXIT_OK; k++)
        if (image_read(paths[k], &images[k], err, sizeof err) < 0) {
            cli_error(sub, "%s", err);
            rc = EXIT_FAILURE_WORK;
        }
    image_comparison m;
    if (rc == EXIT_OK &&
        image_compare(&images[0], &images[1], n_paths == 3 ? &images[2] : NULL, &m, err,
                      sizeof err) < 0) {
        /* The library names the images by role; say which files play them. */
        if (n_paths == 3)
            cli_error(sub, "%s (image %s, reference A %s, reference B %s)", err, paths[0],
                      paths[1], paths[2]);
        else
            cli_error(sub, "%s (image %s, reference %s)", err, paths[0], paths[1]);
        rc = EXIT_FAILURE_WORK;
    }
    if (rc == EXIT_OK) {
        if (json)
            print_json(&m);
        else
            print_text(&m);
        if (fflush(stdout) != 0 || ferror(stdout)) {
            cli_error(sub, "cannot write to stdout");
            rc = EXIT_FAILURE_WORK;
        }
    }
    for (int k = 0; k < 3; k++)
        image_free(&images[k]);
    return rc;
}

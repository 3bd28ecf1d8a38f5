/* See fuzz_util.h. */
#include "fuzz_util.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* The paths handed out, removed at exit. Set once per name, at the first input: libFuzzer
 * runs inputs one after another in a process, so this needs no lock. */
#define FUZZ_MAX_TEMPS 8
static char temps[FUZZ_MAX_TEMPS][512];
static int n_temps;

static void remove_temps(void)
{
    for (int i = 0; i < n_temps; i++) {
        /* A directory (fuzz_model's model directory) holds plain files only. */
        DIR *d = opendir(temps[i]);
        if (d) {
            struct dirent *e;
            char p[1024];
            while ((e = readdir(d)))
                if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) {
                    snprintf(p, sizeof p, "%s/%s", temps[i], e->d_name);
                    remove(p);
                }
            closedir(d);
        }
        remove(temps[i]); /* best effort: a leftover is overwritten by the next run */
    }
}

char *fuzz_temp_path(char *buf, size_t len, const char *name)
{
    const char *dir = getenv("TMPDIR");
    snprintf(buf, len, "%s/imsynth-fuzz-%ld-%s", dir && *dir ? dir : "/tmp", (long)getpid(),
             name);
    for (int i = 0; i < n_temps; i++)
        if (strcmp(temps[i], buf) == 0)
            return buf;
    if (n_temps < FUZZ_MAX_TEMPS) {
        if (n_temps == 0)
            atexit(remove_temps);
        snprintf(temps[n_temps++], sizeof temps[0], "%s", buf);
    }
    return buf;
}

int fuzz_write_file(const char *path, const uint8_t *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    int rc = fwrite(data, 1, n, f) == n ? 0 : -1;
    if (fclose(f) != 0)
        rc = -1;
    return rc;
}

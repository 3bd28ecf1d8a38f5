/* Finding imsynth's data files wherever the command runs from (pipeline.h). */
#include <errno.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "pipeline/pipeline_internal.h"

static int exists(const char *path) { return access(path, R_OK) == 0; }

/* The directory holding the running executable, from /proc/self/exe; "" if unknown. */
static void exe_dir(char *out, size_t outlen)
{
    char buf[PATH_MAX];
    ssize_t n = readlink("/proc/self/exe", buf, sizeof buf - 1);
    out[0] = 0;
    if (n <= 0)
        return;
    buf[n] = 0;
    char *slash = strrchr(buf, '/');
    if (!slash)
        return;
    *slash = 0;
    snprintf(out, outlen, "%s", buf);
}

int pipeline_find_data(const char *rel, char *out, size_t outlen, char *err, size_t errlen)
{
    if (rel[0] == '/' || !strncmp(rel, "./", 2) || !strncmp(rel, "../", 3)) {
        if ((size_t)snprintf(out, outlen, "%s", rel) >= outlen)
            return pipeline_error(err, errlen, "%s: path too long", rel);
        return 0;
    }
    char roots[4][PATH_MAX];
    int n = 0;
    const char *env = getenv("IMSYNTH_DATA");
    if (env && *env)
        snprintf(roots[n++], PATH_MAX, "%s", env);
    char dir[PATH_MAX];
    exe_dir(dir, sizeof dir);
    if (dir[0])
        snprintf(roots[n++], PATH_MAX, "%.*s/../share/imsynth", PATH_MAX - 32, dir);
#ifdef IMSYNTH_SOURCE_TREE
    snprintf(roots[n++], PATH_MAX, "%s", IMSYNTH_SOURCE_TREE);
#endif
    snprintf(roots[n++], PATH_MAX, ".");
    char tried[1024] = "";
    size_t used = 0;
    for (int i = 0; i < n; i++) {
        char path[PATH_MAX + 256];
        if ((size_t)snprintf(path, sizeof path, "%.*s/%s", PATH_MAX, roots[i], rel) >= sizeof path)
            continue;
        if (exists(path)) {
            if ((size_t)snprintf(out, outlen, "%s", i == n - 1 ? rel : path) >= outlen)
                return pipeline_error(err, errlen, "%s: path too long", path);
            return 0;
        }
        if (used < sizeof tried)
            used += (size_t)snprintf(tried + used, sizeof tried - used, "%s%s", i ? ", " : "",
                                     path);
    }
    return pipeline_error(err, errlen,
                          "%s: not found (tried %s; set IMSYNTH_DATA to the directory that "
                          "holds assets/)",
                          rel, tried);
}

/* Small helpers shared inside pipeline/. */
#include <dirent.h>
#include <errno.h>
#include <signal.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "pipeline/pipeline_internal.h"

int pipeline_error(char *err, size_t errlen, const char *fmt, ...)
{
    if (err && errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return -1;
}

int pipeline_thread_count(int asked)
{
    if (asked > 0)
        return asked;
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    return cores > 0 ? (int)cores : 1;
}

double pipeline_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

void pipeline_insert_by_key(int *order, int j, const double *key)
{
    double k = isnan(key[j]) ? INFINITY : key[j];
    int b = j;
    for (; b > 0 && k < (isnan(key[order[b - 1]]) ? INFINITY : key[order[b - 1]]); b--)
        order[b] = order[b - 1];
    order[b] = j;
}

char *pipeline_read_file(const char *path, size_t *len, char *err, size_t errlen)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        pipeline_error(err, errlen, "%s: cannot open: %s", path, strerror(errno));
        return NULL;
    }
    char *buf = NULL;
    size_t cap = 0, n = 0;
    for (;;) {
        if (n + 65536 + 1 > cap) {
            size_t ncap = cap ? cap * 2 : 65536 * 2;
            char *nb = realloc(buf, ncap);
            if (!nb) {
                free(buf);
                fclose(f);
                pipeline_error(err, errlen, "%s: out of memory", path);
                return NULL;
            }
            buf = nb;
            cap = ncap;
        }
        size_t got = fread(buf + n, 1, cap - n - 1, f);
        n += got;
        if (got == 0)
            break;
    }
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        free(buf);
        pipeline_error(err, errlen, "%s: read error", path);
        return NULL;
    }
    buf[n] = 0;
    if (len)
        *len = n;
    return buf;
}

int pipeline_file_sha256(const char *path, char out[65], char *err, size_t errlen)
{
    size_t len;
    char *bytes = pipeline_read_file(path, &len, err, errlen);
    if (!bytes)
        return -1;
    pipeline_sha256_hex(bytes, len, out);
    free(bytes);
    return 0;
}

int pipeline_write_loss_svg(const char *path, const double *loss, const double *val, long long n,
                            const char *xlabel, char *err, size_t errlen)
{
    char tmp[1100];
    if (snprintf(tmp, sizeof tmp, "%s.tmp", path) >= (int)sizeof tmp) {
        snprintf(err, errlen, "%.100s...: path too long", path);
        return -1;
    }
    FILE *f = fopen(tmp, "w");
    if (!f) {
        snprintf(err, errlen, "%s: %s", tmp, strerror(errno));
        return -1;
    }
    const double W = 640, H = 360, L = 70, R = 20, T = 20, Bm = 40;
    double lo = INFINITY, hi = -INFINITY;
    for (long long i = 0; i < n; i++)
        for (int k = 0; k < 2; k++) {
            double v = k ? val[i] : loss[i];
            if (v > 0 && isfinite(v)) {
                lo = fmin(lo, v);
                hi = fmax(hi, v);
            }
        }
    if (!(lo <= hi)) {
        lo = 1e-3;
        hi = 1;
    }
    double llo = log10(lo), lhi = log10(hi);
    if (lhi - llo < 1e-6)
        lhi = llo + 1;
    fprintf(f,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%g\" height=\"%g\" "
            "font-family=\"sans-serif\" font-size=\"12\">\n"
            "<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n"
            "<rect x=\"%g\" y=\"%g\" width=\"%g\" height=\"%g\" fill=\"none\" stroke=\"#888\"/>\n",
            W, H, L, T, W - L - R, H - T - Bm);
    fprintf(f, "<text x=\"%g\" y=\"%g\" text-anchor=\"end\">%.4g</text>\n", L - 4, T + 10, hi);
    fprintf(f, "<text x=\"%g\" y=\"%g\" text-anchor=\"end\">%.4g</text>\n", L - 4, H - Bm, lo);
    fprintf(f, "<text x=\"%g\" y=\"%g\">0</text>\n", L, H - Bm + 16);
    fprintf(f, "<text x=\"%g\" y=\"%g\" text-anchor=\"end\">%lld</text>\n", W - R, H - Bm + 16,
            n);
    fprintf(f,
            "<text x=\"%g\" y=\"%g\" text-anchor=\"middle\">%s (training loss, log scale; "
            "red: validation)</text>\n",
            (W + L - R) / 2, H - 8, xlabel);
    fprintf(f, "<polyline fill=\"none\" stroke=\"#1f77b4\" stroke-width=\"1.2\" points=\"");
    // at most ~2000 points: the mean loss of each chunk of steps
    long long stride = n > 2000 ? (n + 1999) / 2000 : 1;
    for (long long i = 0; i < n; i += stride) {
        double s = 0;
        long long k = 0;
        for (long long j = i; j < i + stride && j < n; j++, k++)
            s += loss[j];
        double v = s / (double)k;
        double x = L + (W - L - R) * ((double)i + 0.5 * (double)(k - 1)) /
                           (double)(n > 1 ? n - 1 : 1);
        double y = v > 0 && isfinite(v) ? T + (H - T - Bm) * (lhi - log10(v)) / (lhi - llo)
                                        : H - Bm;
        fprintf(f, "%.1f,%.1f ", x, y);
    }
    fprintf(f, "\"/>\n");
    for (long long i = 0; i < n; i++)
        if (val[i] > 0 && isfinite(val[i]))
            fprintf(f, "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"2.5\" fill=\"#d62728\"/>\n",
                    L + (W - L - R) * (double)i / (double)(n > 1 ? n - 1 : 1),
                    T + (H - T - Bm) * (lhi - log10(val[i])) / (lhi - llo));
    fprintf(f, "</svg>\n");
    if (fclose(f)) {
        snprintf(err, errlen, "%s: write error: %s", tmp, strerror(errno));
        remove(tmp);
        return -1;
    }
    if (rename(tmp, path)) {
        snprintf(err, errlen, "%s: %s", path, strerror(errno));
        remove(tmp);
        return -1;
    }
    return 0;
}

int pipeline_write_text_atomic(const char *path, const char *text, char *err, size_t errlen)
{
    char tmp[1200];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    FILE *f = fopen(tmp, "w");
    if (!f)
        return pipeline_error(err, errlen, "%s: %s", tmp, strerror(errno));
    errno = 0;
    int bad = fputs(text, f) < 0;
    bad |= fclose(f) != 0;
    if (bad) {
        int e = errno ? errno : EIO;
        remove(tmp);
        return pipeline_error(err, errlen, "%s: write error: %s", tmp, strerror(e));
    }
    if (rename(tmp, path)) {
        int e = errno;
        remove(tmp);
        return pipeline_error(err, errlen, "%s: cannot rename into place: %s", path, strerror(e));
    }
    return 0;
}

int pipeline_write_json_atomic(const char *path, const cJSON *j, char *err, size_t errlen)
{
    char *text = cJSON_Print(j);
    size_t n = text ? strlen(text) : 0;
    char *t = text ? realloc(text, n + 2) : NULL; /* end the file with a newline */
    if (!t) {
        free(text);
        return pipeline_error(err, errlen, "%s: out of memory", path);
    }
    memcpy(t + n, "\n", 2);
    int rc = pipeline_write_text_atomic(path, t, err, errlen);
    free(t);
    return rc;
}

cJSON *pipeline_params_json(const char *const *names, const float *values, int n)
{
    sg_params p = {.n = n, .names = (char **)names, .values = (float *)values};
    char *text = sg_params_to_json(&p);
    cJSON *o = text ? cJSON_Parse(text) : NULL;
    free(text);
    return o ? o : cJSON_CreateObject();
}

int pipeline_read_user_image(const char *path, image *out, char *err, size_t errlen)
{
    if (image_read(path, out, err, errlen))
        return -1;
    size_t n = (size_t)out->width * (size_t)out->height * (size_t)out->channels, bad = 0;
    for (size_t i = 0; i < n; i++)
        bad += !isfinite(out->pixels[i]);
    if (out->width < 32 || out->height < 32)
        pipeline_error(err, errlen, "%s: %d x %d pixels; an input needs at least 32 x 32", path,
                       out->width, out->height);
    else if (bad)
        pipeline_error(err, errlen, "%s: %zu of %zu pixel values are NaN or infinite", path, bad,
                       n);
    else
        return 0;
    image_free(out);
    return -1;
}

void pipeline_remove_flat_dir(const char *dir)
{
    DIR *d = opendir(dir);
    if (d) {
        struct dirent *e;
        char p[4096];
        while ((e = readdir(d)))
            if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..") &&
                (size_t)snprintf(p, sizeof p, "%s/%s", dir, e->d_name) < sizeof p)
                unlink(p);
        closedir(d);
    }
    rmdir(dir);
}

void pipeline_remove_stale_temps(const char *out_dir)
{
    char parent[4096], prefix[1024];
    const char *slash = strrchr(out_dir, '/');
    const char *base = slash ? slash + 1 : out_dir;
    if (slash)
        snprintf(parent, sizeof parent, "%.*s", (int)(slash - out_dir), out_dir);
    else
        snprintf(parent, sizeof parent, ".");
    if (!*parent)
        snprintf(parent, sizeof parent, "/");
    if (!*base || (size_t)snprintf(prefix, sizeof prefix, "%s.tmp.", base) >= sizeof prefix)
        return;
    DIR *d = opendir(parent);
    if (!d)
        return;
    size_t plen = strlen(prefix);
    struct dirent *e;
    while ((e = readdir(d))) {
        if (strncmp(e->d_name, prefix, plen))
            continue;
        const char *digits = e->d_name + plen;
        char *end;
        long pid = strtol(digits, &end, 10);
        // only OUT.tmp.<pid> of a process that no longer exists (kill(pid, 0) says ESRCH;
        // EPERM means it runs under another user: keep it)
        if (!*digits || *end || pid <= 0 || pid == (long)getpid() ||
            kill((pid_t)pid, 0) == 0 || errno != ESRCH)
            continue;
        char path[4096];
        if ((size_t)snprintf(path, sizeof path, "%s/%s", parent, e->d_name) < sizeof path)
            pipeline_remove_flat_dir(path);
    }
    closedir(d);
}

/*
 * Super-shader parameters: listing them from the graph's parameter group, sampling a
 * frame's set, reading and writing parameter files, and binding a set into a graph.
 *
 * Where a parameter lives: the group SG_PARAMS_GROUP has no inputs; its output k is fed
 * by a ShaderNodeValue inside the group, and that node's output value is parameter k.
 * The group's interface default for output k is kept equal to it, so Blender (which
 * shows the default on the group's sockets) and a saved file agree with the evaluator.
 */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "shadergraph/graph_internal.h"

/* ---- locating parameters -------------------------------------------------------- */

static int find_params_group(const sg_graph *g)
{
    for (int i = 0; i < g->n_groups; i++)
        if (!strcmp(g->groups[i].name, SG_PARAMS_GROUP))
            return i;
    return -1;
}

/* Index, in group tree `t`, of the Value node feeding interface output `k`, or -1. */
static int value_node_of_output(const sg_tree *t, int k)
{
    for (int i = 0; i < t->n_nodes; i++) {
        if (t->nodes[i].type->role != SG_ROLE_GROUP_OUTPUT)
            continue;
        /* The first Group Output is the active one (as in flatten.c). */
        int l = sg_tree_input_link(t, i, k);
        if (l < 0)
            return -1;
        int from = t->links[l].from_node;
        const sg_node *v = &t->nodes[from];
        return v->type->role == SG_ROLE_CONSTANT && v->out[0].type == SG_SOCKET_FLOAT ? from : -1;
    }
    return -1;
}

/* Checks the group's shape; returns its index or -1 with err set. */
static int params_group(const sg_graph *g, char *err, size_t errlen)
{
    int gi = find_params_group(g);
    if (gi < 0)
        return sg_error_set(err, errlen, "graph \"%s\": no parameter group \"%s\"", g->name,
                            SG_PARAMS_GROUP);
    const sg_tree *t = &g->groups[gi];
    if (t->n_iface_in)
        return sg_error_set(err, errlen, "group \"%s\": a parameter group has no inputs (found %d)",
                            t->name, t->n_iface_in);
    for (int k = 0; k < t->n_iface_out; k++) {
        if (t->iface_out[k].type != SG_SOCKET_FLOAT)
            return sg_error_set(err, errlen, "group \"%s\": output \"%s\" is not FLOAT", t->name,
                                t->iface_out[k].name);
        if (value_node_of_output(t, k) < 0)
            return sg_error_set(err, errlen, "group \"%s\": output \"%s\" is not fed by a Value node",
                                t->name, t->iface_out[k].name);
    }
    return gi;
}

void sg_params_free(sg_params *p)
{
    if (!p)
        return;
    for (int i = 0; i < p->n && p->names; i++)
        free(p->names[i]);
    free(p->names);
    free(p->values);
    p->n = 0;
    p->names = NULL;
    p->values = NULL;
}

static int params_alloc(sg_params *p, int n)
{
    p->n = n;
    p->names = calloc((size_t)(n ? n : 1), sizeof *p->names);
    p->values = calloc((size_t)(n ? n : 1), sizeof *p->values);
    if (!p->names || !p->values) {
        sg_params_free(p);
        return -1;
    }
    return 0;
}

int sg_params_from_graph(const sg_graph *g, sg_params *out, char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    int gi = params_group(g, err, errlen);
    if (gi < 0)
        return -1;
    const sg_tree *t = &g->groups[gi];
    if (params_alloc(out, t->n_iface_out) < 0)
        return sg_error_set(err, errlen, "out of memory");
    for (int k = 0; k < t->n_iface_out; k++) {
        out->names[k] = strdup(t->iface_out[k].name);
        if (!out->names[k]) {
            sg_params_free(out);
            return sg_error_set(err, errlen, "out of memory");
        }
        out->values[k] = t->nodes[value_node_of_output(t, k)].out[0].value[0];
    }
    return 0;
}

int sg_params_copy(const sg_params *src, sg_params *dst)
{
    if (params_alloc(dst, src->n) < 0)
        return -1;
    for (int i = 0; i < src->n; i++) {
        if (!(dst->names[i] = strdup(src->names[i]))) {
            sg_params_free(dst);
            return -1;
        }
        dst->values[i] = src->values[i];
    }
    return 0;
}

int sg_params_index(const sg_params *p, const char *name)
{
    for (int i = 0; i < p->n; i++)
        if (!strcmp(p->names[i], name))
            return i;
    return -1;
}

int sg_param_mult_choices(const char *name)
{
    /* "Mult" SP digits (SP | end). */
    if (strncmp(name, "Mult ", 5) || name[5] < '0' || name[5] > '9')
        return 0;
    char *end;
    errno = 0;
    long n = strtol(name + 5, &end, 10);
    if (errno || (*end && *end != ' ') || n < 2 || n > 1000000)
        return 0;
    return (int)n;
}

/* ---- sampling ------------------------------------------------------------------- */

/* SplitMix64 (Steele, Lea and Flood 2014; the seeding generator of xoshiro, public
 * domain reference at prng.di.unimi.it): state advances by the golden-ratio constant,
 * output is the state through two xor-shift-multiply rounds. Seeding it with the frame
 * number directly is sound because the output mixing decorrelates nearby seeds. A
 * uniform double in [0, 1) is the top 53 bits over 2^53. */
static uint64_t splitmix64_next(uint64_t *state)
{
    uint64_t z = (*state += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return z ^ (z >> 31);
}

static double uniform01(uint64_t *state)
{
    return (double)(splitmix64_next(state) >> 11) * 0x1.0p-53;
}

void sg_params_sample(sg_params *p, unsigned long long frame)
{
    uint64_t state = (uint64_t)frame;
    for (int i = 0; i < p->n; i++) {
        /* Python's round(u, 3): nearest, ties to even (rint in the default mode). */
        double u = rint(uniform01(&state) * 1000.0) / 1000.0;
        int n = sg_param_mult_choices(p->names[i]);
        if (n)
            u = fmin((floor(u * n) + 0.5) / n, 1.0);
        p->values[i] = (float)u;
    }
}

/* ---- files ---------------------------------------------------------------------- */

int sg_params_read_json(const char *text, size_t len, const char *source_name, sg_params *p,
                        char *err, size_t errlen)
{
    const char *src = source_name ? source_name : "<params>";
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(text, len, &end, 0);
    if (!root) {
        /* Line and column of the parse error. */
        int line = 1, col = 1;
        for (const char *c = text; end && c < end && c < text + len; c++) {
            if (*c == '\n') {
                line++;
                col = 1;
            } else
                col++;
        }
        return sg_error_set(err, errlen, "%s:%d:%d: invalid JSON", src, line, col);
    }
    int rc = -1;
    float *vals = malloc(sizeof(float) * (size_t)(p->n ? p->n : 1));
    char *seen = calloc((size_t)(p->n ? p->n : 1), 1);
    if (!vals || !seen) {
        sg_error_set(err, errlen, "%s: out of memory", src);
        goto done;
    }
    if (!cJSON_IsObject(root)) {
        sg_error_set(err, errlen, "%s: expected a JSON object keyed by parameter name", src);
        goto done;
    }
    for (const cJSON *it = root->child; it; it = it->next) {
        int k = sg_params_index(p, it->string);
        if (k < 0) {
            sg_error_set(err, errlen, "%s: \"%s\": not a parameter of the graph", src, it->string);
            goto done;
        }
        if (seen[k]) {
            sg_error_set(err, errlen, "%s: \"%s\": given twice", src, it->string);
            goto done;
        }
        seen[k] = 1;
        if (!cJSON_IsNumber(it)) {
            sg_error_set(err, errlen, "%s: \"%s\": expected a number", src, it->string);
            goto done;
        }
        double v = it->valuedouble;
        if (!isfinite(v)) {
            sg_error_set(err, errlen, "%s: \"%s\": value is not finite", src, it->string);
            goto done;
        }
        if (v < 0.0 || v > 1.0) {
            sg_error_set(err, errlen, "%s: \"%s\": %g is outside [0, 1]", src, it->string, v);
            goto done;
        }
        vals[k] = (float)v;
    }
    for (int k = 0; k < p->n; k++) {
        if (!seen[k]) {
            sg_error_set(err, errlen, "%s: \"%s\": missing", src, p->names[k]);
            goto done;
        }
    }
    memcpy(p->values, vals, sizeof(float) * (size_t)p->n);
    rc = 0;
done:
    free(seen);
    free(vals);
    cJSON_Delete(root);
    return rc;
}

int sg_params_read_file(const char *path, sg_params *p, char *err, size_t errlen)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return sg_error_set(err, errlen, "%s: %s", path, strerror(errno));
    char *buf = NULL;
    size_t len = 0, cap = 0;
    for (;;) {
        if (len + 4096 + 1 > cap) {
            cap = cap ? cap * 2 : 8192;
            char *nb = realloc(buf, cap);
            if (!nb) {
                free(buf);
                fclose(f);
                return sg_error_set(err, errlen, "%s: out of memory", path);
            }
            buf = nb;
        }
        size_t got = fread(buf + len, 1, cap - len - 1, f);
        len += got;
        if (got == 0)
            break;
    }
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        free(buf);
        return sg_error_set(err, errlen, "%s: read error", path);
    }
    buf[len] = '\0';
    int rc = sg_params_read_json(buf, len, path, p, err, errlen);
    free(buf);
    return rc;
}

/* The shortest %g form that reads back as the same float (9 significant digits always
 * suffice), so sampled values print as 0.017, not 0.0170000009. buf holds 32 bytes. */
static void format_float(char buf[32], float v)
{
    for (int prec = 1; prec <= 9; prec++) {
        snprintf(buf, 32, "%.*g", prec, (double)v);
        if (strtof(buf, NULL) == v)
            return;
    }
}

char *sg_params_to_json(const sg_params *p)
{
    /* By hand rather than through cJSON so that the order is p's and every number
     * reads back as the same float. Size: per entry at most 6 bytes per name byte
     * (\u00XX escapes), 15 for the number, 8 for punctuation. */
    size_t cap = 8;
    for (int i = 0; i < p->n; i++)
        cap += 6 * strlen(p->names[i]) + 40;
    char *s = malloc(cap);
    if (!s)
        return NULL;
    size_t at = 0;
    s[at++] = '{';
    for (int i = 0; i < p->n; i++) {
        if (i)
            s[at++] = ',';
        memcpy(s + at, "\n  \"", 4);
        at += 4;
        for (const char *c = p->names[i]; *c; c++) {
            unsigned char ch = (unsigned char)*c;
            if (ch < 0x20) {
                static const char hex[] = "0123456789abcdef";
                memcpy(s + at, "\\u00", 4);
                s[at + 4] = hex[ch >> 4];
                s[at + 5] = hex[ch & 15];
                at += 6;
                continue;
            }
            if (ch == '"' || ch == '\\')
                s[at++] = '\\';
            s[at++] = (char)ch;
        }
        char num[32];
        format_float(num, p->values[i]);
        size_t nl = strlen(num);
        memcpy(s + at, "\": ", 3);
        at += 3;
        memcpy(s + at, num, nl);
        at += nl;
    }
    memcpy(s + at, "\n}\n", 4);
    return s;
}

int sg_params_write_file(const char *path, const sg_params *p, char *err, size_t errlen)
{
    char *text = sg_params_to_json(p);
    if (!text)
        return sg_error_set(err, errlen, "%s: out of memory", path);
    size_t plen = strlen(path);
    char *tmp = malloc(plen + 16);
    if (!tmp) {
        free(text);
        return sg_error_set(err, errlen, "%s: out of memory", path);
    }
    snprintf(tmp, plen + 16, "%s.tmpXXXXXX", path);
    int fd = mkstemp(tmp);
    int rc = 0;
    if (fd < 0) {
        rc = sg_error_set(err, errlen, "%s: cannot create a temporary file: %s", path, strerror(errno));
    } else {
        FILE *f = fdopen(fd, "wb");
        size_t n = strlen(text);
        if (!f) {
            close(fd);
            rc = -1;
        } else if (fwrite(text, 1, n, f) != n) {
            fclose(f);
            rc = -1;
        } else if (fclose(f) != 0)
            rc = -1;
        if (rc < 0)
            sg_error_set(err, errlen, "%s: write error: %s", path, strerror(errno));
        else if (rename(tmp, path) != 0)
            rc = sg_error_set(err, errlen, "%s: cannot rename the temporary file: %s", path,
                              strerror(errno));
        if (rc < 0)
            unlink(tmp);
    }
    free(tmp);
    free(text);
    return rc;
}

/* ---- binding -------------------------------------------------------------------- */

int sg_graph_bind_params(sg_graph *g, const sg_params *p, char *err, size_t errlen)
{
    int gi = params_group(g, err, errlen);
    if (gi < 0)
        return -1;
    sg_tree *t = &g->groups[gi];
    /* Check everything first so that a failed bind leaves the graph as it was. */
    for (int i = 0; i < p->n; i++) {
        int k;
        for (k = 0; k < t->n_iface_out; k++)
            if (!strcmp(t->iface_out[k].name, p->names[i]))
                break;
        if (k == t->n_iface_out)
            return sg_error_set(err, errlen, "parameter \"%s\": not a parameter of the graph",
                                p->names[i]);
        if (!(p->values[i] >= 0.0f && p->values[i] <= 1.0f))
            return sg_error_set(err, errlen, "parameter \"%s\": %g is outside [0, 1]", p->names[i],
                                (double)p->values[i]);
    }
    for (int k = 0; k < t->n_iface_out; k++)
        if (sg_params_index(p, t->iface_out[k].name) < 0)
            return sg_error_set(err, errlen, "parameter \"%s\": missing", t->iface_out[k].name);
    for (int k = 0; k < t->n_iface_out; k++) {
        float v = p->values[sg_params_index(p, t->iface_out[k].name)];
        t->nodes[value_node_of_output(t, k)].out[0].value[0] = v;
        t->iface_out[k].value[0] = v;
        /* The Group Output node's unlinked-input value mirrors the default. */
        for (int i = 0; i < t->n_nodes; i++)
            if (t->nodes[i].type->role == SG_ROLE_GROUP_OUTPUT && k < t->nodes[i].n_in)
                t->nodes[i].in[k].value[0] = v;
    }
    return 0;
}

/* SPDX-License-Identifier: MIT */
/*
 * Scene files, the JSON layer: parsing with cJSON, the source position of every value (for
 * "file:line:col" in messages), typed access with range checks, --set overrides, and vertex
 * selections.
 *
 * cJSON keeps no source positions, so a second pass over the (already validated) text records
 * where each value starts, in document order. cJSON keeps members and elements in document
 * order too, so a pre-order walk of its tree pairs each node with its offset. The pass must
 * agree with cJSON on what is whitespace (every byte up to 0x20).
 *
 * Contents: source positions; sj_parse; typed access; overrides; vertex selections (indices and
 * boxes, for pins, forces and drives).
 */
#include "scene_json.h"

#include <ctype.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* Source positions */

/* cJSON's whitespace: every byte up to 0x20, NUL and other control bytes included. */
static int json_ws(char ch) { return (unsigned char)ch <= 0x20; }

static size_t skip_json_ws(const char *t, size_t i, size_t n)
{
    while (i < n && json_ws(t[i])) ++i;
    return i;
}

/* Position scanner: where each value starts, in pre-order. */
typedef struct scan {
    const char *t;
    size_t n;
    size_t *out, cap, k;   /* out[0..cap) holds the first cap starts; k counts them all */
} scan;

/* Scans one value of text that cJSON accepted; returns the index past it. Whatever the text,
 * it writes no more than `cap` entries and ends (each step moves forward or stops). */
static size_t scan_value(scan *sc, size_t i)
{
    const char *t = sc->t;
    const size_t n = sc->n;
    i = skip_json_ws(t, i, n);
    if (sc->k < sc->cap) sc->out[sc->k] = i;
    ++sc->k;
    if (i >= n) return i;
    if (t[i] == '{' || t[i] == '[') {
        const char close = t[i] == '{' ? '}' : ']';
        const int object = t[i] == '{';
        i = skip_json_ws(t, i + 1, n);
        while (i < n && t[i] != close) {
            const size_t before = i;
            if (object) {
                /* the key: a string, then ':' */
                ++i;
                while (i < n && t[i] != '"') i += t[i] == '\\' ? 2 : 1;
                i = skip_json_ws(t, i + 1, n) + 1;   /* past ':' */
            }
            i = skip_json_ws(t, scan_value(sc, i), n);
            if (i < n && t[i] == ',') i = skip_json_ws(t, i + 1, n);
            else if (i <= before) return n;   /* not JSON: give up, the count will disagree */
        }
        return i + 1;
    }
    if (t[i] == '"') {
        ++i;
        while (i < n && t[i] != '"') i += t[i] == '\\' ? 2 : 1;
        return i + 1;
    }
    while (i < n && !json_ws(t[i]) && !strchr(",]}", t[i])) ++i;
    return i;
}

static size_t count_nodes(const cJSON *j)
{
    size_t n = 1;
    for (const cJSON *c = j->child; c; c = c->next) n += count_nodes(c);
    return n;
}

static void pair_nodes(const cJSON *j, const size_t *offsets, size_t *k, sj_pos *out)
{
    out[*k].node = j;
    out[*k].offset = offsets[*k];
    ++*k;
    for (const cJSON *c = j->child; c; c = c->next) pair_nodes(c, offsets, k, out);
}

static int cmp_pos(const void *a, const void *b)
{
    const sj_pos *x = a, *y = b;
    return (x->node > y->node) - (x->node < y->node);
}

/* "file:line:col" of a node, or "file (--set)" for nodes that overrides made. */
static void where(const sj_ctx *c, const cJSON *node, char *out, size_t size)
{
    size_t lo = 0, hi = c->npos;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (c->pos[mid].node < node) lo = mid + 1;
        else hi = mid;
    }
    if (!node || lo >= c->npos || c->pos[lo].node != node) {
        snprintf(out, size, "%s", c->s->path);
        return;
    }
    int line = 1, col = 1;
    for (size_t i = 0; i < c->pos[lo].offset && i < c->text_len; ++i) {
        if (c->text[i] == '\n') { ++line; col = 1; }
        else ++col;
    }
    snprintf(out, size, "%s:%d:%d", c->s->path, line, col);
}

int sj_node_line(const sj_ctx *c, const cJSON *node)
{
    char buf[1100];
    where(c, node, buf, sizeof buf);
    const char *p = strrchr(buf, ':');
    if (!p || p == buf) return 0;
    const char *q = p - 1;
    while (q > buf && isdigit((unsigned char)*q)) --q;
    return *q == ':' ? atoi(q + 1) : 0;
}

int sj_fail(sj_ctx *c, const cJSON *node, const char *fmt, ...)
{
    char loc[1100], msg[2048];
    where(c, node, loc, sizeof loc);
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    snprintf(c->s->error, sizeof c->s->error, "%s: %s", loc, msg);
    return -1;
}

cJSON *sj_parse(sj_ctx *c)
{
    scene *s = c->s;
    const char *path = s->path, *text = c->text;
    const size_t len = c->text_len;
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(text, len, &end, 0);
    if (!root) {
        /* cJSON points at the character where parsing stopped. */
        const char *e = cJSON_GetErrorPtr();
        size_t off = e && e >= text && e <= text + len ? (size_t)(e - text) : 0;
        int line = 1, col = 1;
        for (size_t i = 0; i < off; ++i) {
            if (text[i] == '\n') { ++line; col = 1; }
            else ++col;
        }
        char near[24];
        size_t k = 0;
        for (; k + 1 < sizeof near && off + k < len && text[off + k] != '\n'; ++k)
            near[k] = text[off + k] == '\r' || text[off + k] == '\t' ? ' ' : text[off + k];
        near[k] = '\0';
        snprintf(s->error, sizeof s->error, "%s:%d:%d: JSON syntax error near \"%s\"", path,
                 line, col, near);
        return NULL;
    }
    if (end) {
        size_t i = skip_json_ws(text, (size_t)(end - text), len);
        if (i < len) {
            int line = 1;
            for (size_t k = 0; k < i; ++k) line += text[k] == '\n';
            snprintf(s->error, sizeof s->error, "%s:%d: text after the end of the JSON value",
                     path, line);
            cJSON_Delete(root);
            return NULL;
        }
    }
    /* Positions of the file's own nodes (before overrides add any). */
    size_t start = 0;
    if (len >= 3 && (unsigned char)text[0] == 0xEF) start = 3;   /* UTF-8 byte order mark */
    const size_t nn = count_nodes(root);
    size_t *offsets = malloc(nn * sizeof *offsets);
    c->pos = malloc(nn * sizeof *c->pos);
    if (!offsets || !c->pos) {
        snprintf(s->error, sizeof s->error, "out of memory");
    } else {
        scan sc = {text, len, offsets, nn, 0};
        scan_value(&sc, start);
        if (sc.k == nn) {
            size_t k = 0;
            pair_nodes(root, offsets, &k, c->pos);
            c->npos = nn;
            qsort(c->pos, nn, sizeof *c->pos, cmp_pos);
            free(offsets);
            return root;
        }
        snprintf(s->error, sizeof s->error, "%s: internal error mapping JSON positions", path);
    }
    free(offsets);
    free(c->pos);
    c->pos = NULL;
    cJSON_Delete(root);
    return NULL;
}

/* ------------------------------------------------------------------------------------------ */
/* Typed access with checks */

int sj_keys(sj_ctx *c, const cJSON *obj, const char *what, const char *const *known)
{
    if (!cJSON_IsObject(obj)) return sj_fail(c, obj, "%s must be an object", what);
    for (const cJSON *m = obj->child; m; m = m->next) {
        int ok = 0;
        for (const char *const *k = known; *k && !ok; ++k) ok = strcmp(m->string, *k) == 0;
        if (!ok) {
            char list[400] = "";
            size_t n = 0;
            for (const char *const *k = known; *k; ++k)
                n += (size_t)snprintf(list + n, n < sizeof list ? sizeof list - n : 0, "%s%s",
                                      k == known ? "" : ", ", *k);
            return sj_fail(c, m, "unknown key \"%s\" in %s (known: %s)", m->string, what, list);
        }
        for (const cJSON *o = obj->child; o != m; o = o->next)
            if (strcmp(o->string, m->string) == 0)
                return sj_fail(c, m, "key \"%s\" appears twice in %s", m->string, what);
    }
    return 0;
}

int sj_number(sj_ctx *c, const cJSON *obj, const char *key, const char *what, double lo,
                      double hi, int lo_open, double *out)
{
    const cJSON *j = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!j) return 0;
    if (!cJSON_IsNumber(j) || !isfinite(j->valuedouble))
        return sj_fail(c, j, "%s.%s must be a number", what, key);
    const double v = j->valuedouble;
    if (v < lo || v > hi || (lo_open && v == lo))
        return sj_fail(c, j, "%s.%s = %g must be %s %g%s", what, key, v, lo_open ? ">" : ">=", lo,
                       hi < 1e300 ? " and within range" : "");
    *out = v;
    return 0;
}

int sj_int(sj_ctx *c, const cJSON *obj, const char *key, const char *what, int lo, int hi,
                   int32_t *out)
{
    const cJSON *j = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!j) return 0;
    if (!cJSON_IsNumber(j) || j->valuedouble != floor(j->valuedouble))
        return sj_fail(c, j, "%s.%s must be an integer", what, key);
    if (j->valuedouble < lo || j->valuedouble > hi)
        return sj_fail(c, j, "%s.%s = %g must be in [%d, %d]", what, key, j->valuedouble, lo, hi);
    *out = (int32_t)j->valuedouble;
    return 0;
}

int sj_bool(sj_ctx *c, const cJSON *obj, const char *key, const char *what, int *out)
{
    const cJSON *j = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!j) return 0;
    if (!cJSON_IsBool(j)) return sj_fail(c, j, "%s.%s must be true or false", what, key);
    *out = cJSON_IsTrue(j);
    return 0;
}

int sj_vec(sj_ctx *c, const cJSON *j, const char *what, int n, double *out)
{
    if (!cJSON_IsArray(j) || cJSON_GetArraySize(j) != n)
        return sj_fail(c, j, "%s must be an array of %d numbers", what, n);
    int i = 0;
    for (const cJSON *e = j->child; e; e = e->next, ++i) {
        if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble))
            return sj_fail(c, e, "%s[%d] must be a finite number", what, i);
        out[i] = e->valuedouble;
    }
    return 0;
}

int sj_vec3(sj_ctx *c, const cJSON *obj, const char *key, const char *what, double out[3])
{
    const cJSON *j = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!j) return 0;
    char w[512];
    snprintf(w, sizeof w, "%s.%s", what, key);
    return sj_vec(c, j, w, 3, out);
}

/* The numbers of j (flat or rows of width) into out (count of them first with out NULL). */
static int sj_flat(sj_ctx *c, const cJSON *j, const char *what, int width, double *out,
                   int64_t *count)
{
    if (!cJSON_IsArray(j))
        return sj_fail(c, j, "%s must be an array of numbers, or of arrays of %d numbers", what,
                       width);
    int64_t k = 0;
    int rows = -1;   /* unknown, 0 flat, 1 rows */
    for (const cJSON *e = j->child; e; e = e->next) {
        const int row = cJSON_IsArray(e);
        if (rows >= 0 && row != rows)
            return sj_fail(c, e, "%s mixes numbers and rows", what);
        rows = row;
        if (row) {
            if (cJSON_GetArraySize(e) != width)
                return sj_fail(c, e, "%s: every row must have %d numbers", what, width);
            for (const cJSON *x = e->child; x; x = x->next, ++k) {
                if (!cJSON_IsNumber(x) || !isfinite(x->valuedouble))
                    return sj_fail(c, x, "%s must hold finite numbers", what);
                if (out) out[k] = x->valuedouble;
            }
        } else {
            if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble))
                return sj_fail(c, e, "%s must hold finite numbers", what);
            if (out) out[k] = e->valuedouble;
            ++k;
        }
    }
    if (k % width != 0)
        return sj_fail(c, j, "%s holds %lld numbers, not a multiple of %d", what, (long long)k,
                       width);
    if (k / width > INT32_MAX / 4) return sj_fail(c, j, "%s is too long", what);
    *count = k;
    return 0;
}

int sj_doubles(sj_ctx *c, const cJSON *j, const char *what, int width, double **out, int32_t *n)
{
    *out = NULL;
    *n = 0;
    int64_t k = 0;
    if (sj_flat(c, j, what, width, NULL, &k)) return -1;
    if (k == 0) return 0;
    *out = malloc((size_t)k * sizeof **out);
    if (!*out) return sj_fail(c, j, "out of memory");
    sj_flat(c, j, what, width, *out, &k);
    *n = (int32_t)(k / width);
    return 0;
}

int sj_ints(sj_ctx *c, const cJSON *j, const char *what, int width, int32_t lo, int32_t hi,
            int32_t **out, int32_t *n)
{
    double *d = NULL;
    int32_t rows = 0;
    *out = NULL;
    *n = 0;
    if (sj_doubles(c, j, what, width, &d, &rows)) return -1;
    const int64_t k = (int64_t)rows * width;
    if (k == 0) return 0;
    *out = malloc((size_t)k * sizeof **out);
    if (!*out) {
        free(d);
        return sj_fail(c, j, "out of memory");
    }
    for (int64_t i = 0; i < k; ++i) {
        if (d[i] != floor(d[i]) || d[i] < lo || d[i] > hi) {
            const double bad = d[i];
            free(d);
            free(*out);
            *out = NULL;
            return sj_fail(c, j, "%s: entry %lld (%g) must be an integer in [%d, %d]", what,
                           (long long)i, bad, (int)lo, (int)hi);
        }
        (*out)[i] = (int32_t)d[i];
    }
    free(d);
    *n = rows;
    return 0;
}

const cJSON *sj_require(sj_ctx *c, const cJSON *obj, const char *key, const char *what)
{
    const cJSON *j = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!j) sj_fail(c, obj, "%s needs \"%s\"", what, key);
    return j;
}

/* ------------------------------------------------------------------------------------------ */
/* Overrides: "a.b.0.c=JSON" */

int sj_override(scene *s, cJSON *root, const char *spec)
{
    const char *eq = strchr(spec, '=');
    if (!eq || eq == spec) {
        snprintf(s->error, sizeof s->error, "--set %s: expected key.path=value", spec);
        return -1;
    }
    cJSON *value = cJSON_Parse(eq + 1);
    if (!value) value = cJSON_CreateString(eq + 1);
    if (!value) {
        snprintf(s->error, sizeof s->error, "out of memory");
        return -1;
    }
    char path[512];
    snprintf(path, sizeof path, "%.*s", (int)(eq - spec), spec);
    cJSON *node = root;
    char *save = NULL;
    char *tok = strtok_r(path, ".", &save);
    while (tok) {
        char *next = strtok_r(NULL, ".", &save);
        char *end;
        long idx = strtol(tok, &end, 10);
        const int is_index = *end == '\0' && cJSON_IsArray(node);
        if (is_index) {
            if (idx < 0 || idx >= cJSON_GetArraySize(node)) {
                snprintf(s->error, sizeof s->error, "--set %s: index %ld out of range", spec, idx);
                cJSON_Delete(value);
                return -1;
            }
            if (!next) {
                cJSON_ReplaceItemInArray(node, (int)idx, value);
                return 0;
            }
            node = cJSON_GetArrayItem(node, (int)idx);
        } else {
            if (!cJSON_IsObject(node)) {
                snprintf(s->error, sizeof s->error, "--set %s: \"%s\" is not inside an object",
                         spec, tok);
                cJSON_Delete(value);
                return -1;
            }
            if (!next) {
                if (cJSON_GetObjectItemCaseSensitive(node, tok))
                    cJSON_ReplaceItemInObjectCaseSensitive(node, tok, value);
                else
                    cJSON_AddItemToObject(node, tok, value);
                return 0;
            }
            cJSON *child = cJSON_GetObjectItemCaseSensitive(node, tok);
            if (!child) {
                child = cJSON_CreateObject();
                cJSON_AddItemToObject(node, tok, child);
            }
            node = child;
        }
        tok = next;
    }
    cJSON_Delete(value);
    snprintf(s->error, sizeof s->error, "--set %s: empty key path", spec);
    return -1;
}

int sj_select(sj_ctx *c, const cJSON *indices, const cJSON *boxes, const char *what,
              const double *pos, int32_t nv, double tol, uint8_t *mark)
{
    if (indices && !cJSON_IsArray(indices))
        return sj_fail(c, indices, "%s.indices must be an array of vertex indices", what);
    if (indices)
        for (const cJSON *e = indices->child; e; e = e->next) {
            if (!cJSON_IsNumber(e) || e->valuedouble != floor(e->valuedouble) ||
                e->valuedouble < 0 || e->valuedouble >= nv)
                return sj_fail(c, e, "%s: vertex index must be an integer in [0, %d)", what, (int)nv);
            mark[(int32_t)e->valuedouble] = 1;
        }
    if (!boxes) return 0;
    /* One box {lo, hi}, or an array of them. */
    const cJSON *one = cJSON_IsArray(boxes) ? boxes->child : boxes;
    if (cJSON_IsArray(boxes) && !one) return sj_fail(c, boxes, "%s.box: empty list", what);
    for (; one; one = cJSON_IsArray(boxes) ? one->next : NULL) {
        static const char *const keys[] = {"lo", "hi", NULL};
        double lo[3], hi[3];
        char wb[220];
        snprintf(wb, sizeof wb, "%s.box", what);
        if (sj_keys(c, one, wb, keys) || !sj_require(c, one, "lo", wb) ||
            !sj_require(c, one, "hi", wb) || sj_vec3(c, one, "lo", wb, lo) ||
            sj_vec3(c, one, "hi", wb, hi))
            return -1;
        int hits = 0;
        for (int32_t i = 0; i < nv; ++i) {
            const double *p = pos + 3 * i;
            int in = 1;
            for (int k = 0; k < 3; ++k) in &= p[k] >= lo[k] - tol && p[k] <= hi[k] + tol;
            if (in) { mark[i] = 1; ++hits; }
        }
        if (hits == 0)
            return sj_fail(c, one, "%s.box contains no vertex of the body (at rest, after "
                           "\"transform\")", what);
    }
    return 0;
}

int sj_marked(sj_ctx *c, const cJSON *where, const uint8_t *mark, int32_t nv, int32_t **out,
              int32_t *n)
{
    int32_t k = 0;
    for (int32_t i = 0; i < nv; ++i) k += mark[i];
    *out = malloc((size_t)(k > 0 ? k : 1) * sizeof **out);
    if (!*out) return sj_fail(c, where, "out of memory");
    *n = 0;
    for (int32_t i = 0; i < nv; ++i)
        if (mark[i]) (*out)[(*n)++] = i;
    return 0;
}

/* SPDX-License-Identifier: MIT */
#include "mesh_reader.h"

#include "file_read.h"
#include "mesh.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int defsim__vec_push(defsim__vec *v, const void *item, size_t count)
{
    if (v->n + count > v->cap) {
        size_t cap = v->cap ? v->cap : 256;
        while (cap < v->n + count) cap *= 2;
        void *p = realloc(v->p, cap * v->elem);
        if (!p) return 0;
        v->p = p;
        v->cap = cap;
    }
    memcpy((char *)v->p + v->n * v->elem, item, count * v->elem);
    v->n += count;
    return 1;
}

defsim_status defsim__rd_fail(defsim__reader *r, defsim_status st, int line, const char *fmt,
                                  ...)
{
    char msg[400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (line > 0) defsim__set_last_error("%s:%d: %s", r->path, line, msg);
    else defsim__set_last_error("%s: %s", r->path, msg);
    r->st = st;
    return st;
}

defsim_status defsim__rd_open(defsim__reader *r, const char *path, int hash_comments)
{
    memset(r, 0, sizeof *r);
    r->path = path;
    r->line = 1;
    r->hash_comments = hash_comments;
    const int64_t max = defsim_get_limit(DEFSIM_LIMIT_FILE_BYTES);
    int err = defsim__read_file(path, (size_t)max, &r->buf, &r->len);
    if (err == ENOMEM) {
        defsim__set_last_error("%s: out of memory", path);
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    if (err == EFBIG)
        return defsim__rd_fail(r, DEFSIM_ERR_IO, 0, "larger than %lld bytes, the limit for mesh "
                               "files (defsim_set_limit(DEFSIM_LIMIT_FILE_BYTES) raises it)",
                               (long long)max);
    if (err)
        return defsim__rd_fail(r, DEFSIM_ERR_IO, 0, "cannot read: %s", defsim__read_strerror(err));
    return DEFSIM_OK;
}

void defsim__rd_close(defsim__reader *r) { free(r->buf); r->buf = NULL; }

void defsim__rd_skip_ws(defsim__reader *r)
{
    while (r->pos < r->len) {
        char c = r->buf[r->pos];
        if (c == '\n' || c == DEFSIM__RD_CONT) { r->line++; r->pos++; }
        else if (defsim__rd_is_space(c) || c == '\0') r->pos++;
        else if (c == '#' && r->hash_comments) {
            while (r->pos < r->len && r->buf[r->pos] != '\n') r->pos++;
        } else break;
    }
}

void defsim__rd_to_eol(defsim__reader *r)
{
    while (r->pos < r->len && r->buf[r->pos] != '\n') r->pos++;
}

void defsim__rd_skip_line(defsim__reader *r)
{
    while (r->pos < r->len && r->buf[r->pos] != '\n') r->pos++;
    if (r->pos < r->len) { r->pos++; r->line++; }
}

size_t defsim__rd_token(defsim__reader *r, const char **tok)
{
    defsim__rd_skip_ws(r);
    size_t s = r->pos;
    while (r->pos < r->len && !defsim__rd_is_space(r->buf[r->pos]) && r->buf[r->pos] != '\n' &&
           r->buf[r->pos] != '\0' && !(r->hash_comments && r->buf[r->pos] == '#'))
        r->pos++;
    *tok = r->buf + s;
    return r->pos - s;
}

void defsim__rd_show(char *out, size_t size, const char *tok, size_t n)
{
    if (n == 0) { snprintf(out, size, "end of file"); return; }
    snprintf(out, size, "'%.*s'", (int)(n > 40 ? 40 : n), tok);
}

/* tok[0..n) as a NUL-terminated string in tmp; 0 if it is empty or does not fit. */
static int token_text(const char *tok, size_t n, char tmp[80])
{
    if (n == 0 || n >= 80) return 0;
    memcpy(tmp, tok, n);
    tmp[n] = '\0';
    return 1;
}

int defsim__parse_i64(const char *tok, size_t n, long long *out)
{
    char tmp[80], *end;
    if (!token_text(tok, n, tmp)) return 0;
    errno = 0;
    long long v = strtoll(tmp, &end, 10);
    if (*end != '\0' || errno != 0) return 0;
    *out = v;
    return 1;
}

int defsim__parse_f64(const char *tok, size_t n, double *out)
{
    char tmp[80], *end;
    if (!token_text(tok, n, tmp)) return 0;
    double v = strtod(tmp, &end);
    if (*end != '\0' || !isfinite(v)) return 0;
    *out = v;
    return 1;
}

/* The next token, parsed by `parse`; else an error "expected WHAT (KIND), found ...". */
static int read_number(defsim__reader *r, const char *what, const char *kind,
                       int (*parse)(const char *, size_t, void *), void *out)
{
    if (r->st != DEFSIM_OK) return 0;
    const char *tok;
    size_t n = defsim__rd_token(r, &tok);
    if (parse(tok, n, out)) return 1;
    char shown[64];
    defsim__rd_show(shown, sizeof shown, tok, n);
    defsim__rd_fail(r, DEFSIM_ERR_IO, r->line, "expected %s (%s), found %s", what, kind, shown);
    return 0;
}

static int parse_i64_any(const char *tok, size_t n, void *out)
{
    return defsim__parse_i64(tok, n, out);
}

static int parse_f64_any(const char *tok, size_t n, void *out)
{
    return defsim__parse_f64(tok, n, out);
}

int defsim__rd_i64(defsim__reader *r, const char *what, long long *out)
{
    return read_number(r, what, "an integer", parse_i64_any, out);
}

int defsim__rd_f64(defsim__reader *r, const char *what, double *out)
{
    return read_number(r, what, "a finite number", parse_f64_any, out);
}

int defsim__rd_count(defsim__reader *r, const char *what, long long lo, long long hi,
                     long long *out)
{
    int line = r->line;
    if (!defsim__rd_i64(r, what, out)) return 0;
    if (*out < lo || *out > hi) {
        defsim__rd_skip_ws(r);
        defsim__rd_fail(r, DEFSIM_ERR_IO, line, "%s %lld out of range [%lld, %lld]", what, *out, lo,
                        hi);
        return 0;
    }
    return 1;
}


int defsim__coord_check(defsim__reader *r, int line, const char *what, double x)
{
    if (fabs(x) <= DEFSIM__COORD_MAX) return 1;
    defsim__rd_fail(r, DEFSIM_ERR_INVALID_MESH, line, "%s = %g is beyond +-%g m, the largest "
                    "coordinate accepted (lengths and volumes would overflow)", what, x,
                    DEFSIM__COORD_MAX);
    return 0;
}

int defsim__rd_coord(defsim__reader *r, const char *what, double *out)
{
    return defsim__rd_f64(r, what, out) && defsim__coord_check(r, r->line, what, *out);
}

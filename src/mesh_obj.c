/* SPDX-License-Identifier: MIT */
/* Wavefront .obj: faces (fan-triangulated) and polylines; their edges become springs. */
#include "mesh_obj.h"

#include "mesh_raw.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* OBJ statements end at a newline; a backslash before the newline continues them. The loader
 * turns such newlines into DEFSIM__RD_CONT, which counts as a line but not as the end of a
 * statement. */

/* Next token of the current statement (0 at its end). */
static size_t obj_token(defsim__reader *r, const char **tok)
{
    while (r->pos < r->len &&
           (defsim__rd_is_space(r->buf[r->pos]) || r->buf[r->pos] == DEFSIM__RD_CONT)) {
        if (r->buf[r->pos] == DEFSIM__RD_CONT) r->line++;
        r->pos++;
    }
    size_t s = r->pos;
    while (r->pos < r->len && !defsim__rd_is_space(r->buf[r->pos]) &&
           r->buf[r->pos] != DEFSIM__RD_CONT &&
           r->buf[r->pos] != '\n' && r->buf[r->pos] != '#')
        r->pos++;
    *tok = r->buf + s;
    return r->pos - s;
}

/* Skips to the start of the next statement. */
static void obj_next_statement(defsim__reader *r)
{
    while (r->pos < r->len && r->buf[r->pos] != '\n') {
        if (r->buf[r->pos] == DEFSIM__RD_CONT) r->line++;
        r->pos++;
    }
    if (r->pos < r->len) { r->pos++; r->line++; }
}

/* Parses one "v", "v/vt", "v//vn" or "v/vt/vn" reference; returns the 0-based vertex index
 * (relative ones resolved against the vertices read so far). */
static int obj_index(defsim__reader *r, const char *tok, size_t n, size_t nv, int line,
                     long long *out)
{
    size_t k = 0;
    while (k < n && tok[k] != '/') ++k;
    long long v;
    if (defsim__parse_i64(tok, k, &v) && v != 0) {
        if (v < 0) {
            /* 0 - v in unsigned arithmetic: -v overflows for LLONG_MIN. */
            if (0ull - (unsigned long long)v > nv) {
                defsim__rd_fail(r, DEFSIM_ERR_INVALID_MESH, line, "relative vertex index %lld "
                                "reaches before the first vertex (%zu read so far)", v, nv);
                return 0;
            }
            *out = (long long)nv + v;
        } else {
            *out = v - 1;
        }
        return 1;
    }
    defsim__rd_fail(r, DEFSIM_ERR_IO, line, "bad vertex reference '%.*s' (expected a non-zero "
                    "index, optionally with /texture/normal)", (int)(n > 40 ? 40 : n), tok);
    return 0;
}

defsim_status defsim__load_obj(const char *path, defsim_mesh *out)
{
    defsim__reader r;
    defsim__raw_mesh m;
    defsim_status st = defsim__raw_open(&m, &r, path, 1);
    if (st != DEFSIM_OK) return st;
    m.tags_are_indices = 1;
    defsim__vec poly = {NULL, 0, 0, sizeof(long long)};
    for (size_t i = 0; i + 1 < r.len; ++i) {
        size_t j = i + 1;
        if (r.buf[i] != '\\') continue;
        while (j < r.len && r.buf[j] == '\r') ++j;
        if (j < r.len && r.buf[j] == '\n') { r.buf[i] = ' '; r.buf[j] = DEFSIM__RD_CONT; }
    }
    while (r.st == DEFSIM_OK && st == DEFSIM_OK) {
        defsim__rd_skip_ws(&r);
        if (r.pos >= r.len) break;
        const int line = r.line;
        const char *kw, *tok;
        size_t kn = obj_token(&r, &kw), tn;
        if (defsim__tok_is(kw, kn, "v")) {
            double p[3];
            static const char *axis[3] = {"x", "y", "z"};
            for (int c = 0; c < 3 && r.st == DEFSIM_OK; ++c) {
                tn = obj_token(&r, &tok);
                if (defsim__parse_f64(tok, tn, &p[c])) {
                    defsim__coord_check(&r, line, axis[c], p[c]);
                    continue;
                }
                char shown[64];
                defsim__rd_show(shown, sizeof shown, tok, tn);
                if (tn == 0) snprintf(shown, sizeof shown, "end of line");
                defsim__rd_fail(&r, DEFSIM_ERR_IO, line, "vertex: expected %s (a finite number), "
                                "found %s", axis[c], shown);
            }
            if (!defsim__raw_room(&r, &m, 1)) break;
            long long tag = (long long)m.pos.n;
            if (!defsim__vec_push(&m.pos, p, 1) || !defsim__vec_push(&m.tag, &tag, 1))
                st = defsim__mesh_oom(path);
        } else if (defsim__tok_is(kw, kn, "f") || defsim__tok_is(kw, kn, "l")) {
            const int face = kw[0] == 'f';
            poly.n = 0;
            while ((tn = obj_token(&r, &tok)) > 0) {
                long long idx;
                if (!obj_index(&r, tok, tn, m.pos.n, line, &idx)) break;
                if (!defsim__vec_push(&poly, &idx, 1)) { st = defsim__mesh_oom(path); break; }
            }
            if (r.st != DEFSIM_OK || st != DEFSIM_OK) break;
            const long long *v = poly.p;
            if (poly.n < (face ? 3u : 2u)) {
                defsim__rd_fail(&r, DEFSIM_ERR_INVALID_MESH, line, "%s with %zu vertices (needs at "
                                "least %d)", face ? "face" : "line", poly.n, face ? 3 : 2);
                break;
            }
            /* Polygons are fan-triangulated; polylines give one segment per pair. */
            for (size_t k = face ? 1 : 0; k + 1 < poly.n && st == DEFSIM_OK; ++k) {
                long long t[3] = {v[0], v[k], v[k + 1]}, s[2] = {v[k], v[k + 1]};
                if (!defsim__raw_room(&r, &m, 0)) break;
                if (face ? !defsim__vec_push(&m.tris, t, 1) ||
                               !defsim__vec_push(&m.tri_line, &line, 1)
                         : !defsim__vec_push(&m.segs, s, 1) ||
                               !defsim__vec_push(&m.seg_line, &line, 1))
                    st = defsim__mesh_oom(path);
            }
        }
        /* vt, vn, vp, o, g, s, usemtl, mtllib, ...: not needed for simulation. */
        obj_next_statement(&r);
    }
    if (st == DEFSIM_OK) st = r.st;
    if (st == DEFSIM_OK && m.tris.n == 0 && m.segs.n == 0) {
        defsim__set_last_error("%s: no faces (f) or lines (l) in the file", path);
        st = DEFSIM_ERR_INVALID_MESH;
    }
    defsim__rd_close(&r);
    free(poly.p);
    if (st == DEFSIM_OK) st = defsim__mesh_finish(path, &m, 1, out);
    defsim__raw_free(&m);
    return st;
}


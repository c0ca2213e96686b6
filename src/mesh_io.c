/* SPDX-License-Identifier: MIT */
/*
 * Mesh files: TetGen .node/.ele, Gmsh .msh (2.x and 4.x ASCII), Wavefront .obj.
 *
 * Every loader reads the whole file into memory and walks it with one small tokenizer that
 * counts lines, so that every error can name "file:line". Loaders collect vertices by the tag
 * (number) the file gives them and elements by tags; `finish` then maps tags to indices, drops
 * vertices that no element uses (they would have no mass), orients tets positively, rejects
 * degenerate elements, and adds the tets' boundary triangles.
 */
#include "mesh.h"

#include "mat3.h"
#include "status.h"

#include <errno.h>
#include <stdarg.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A tet whose |det Dm| is below this fraction of its longest edge cubed is degenerate
 * (the same rule defsim_world_add_body applies). */
#define DEGENERATE_REL 1e-12

/* ------------------------------------------------------------------------------------------ */
/* Growable arrays */

typedef struct vec { void *p; size_t n, cap, elem; } vec;

static int vec_push(vec *v, const void *item, size_t count)
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

/* ------------------------------------------------------------------------------------------ */
/* Tokenizer */

typedef struct reader {
    const char *path;
    char *buf;
    size_t len, pos;
    int line;           /* line of the current position, from 1 */
    int hash_comments;  /* '#' starts a comment to the end of the line */
    defsim_status st;   /* first error */
} reader;

static defsim_status reader_fail(reader *r, defsim_status st, int line, const char *fmt, ...)
    DEFSIM_PRINTF(4, 5);

static defsim_status reader_fail(reader *r, defsim_status st, int line, const char *fmt, ...)
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

static defsim_status reader_open(reader *r, const char *path, int hash_comments)
{
    memset(r, 0, sizeof *r);
    r->path = path;
    r->line = 1;
    r->hash_comments = hash_comments;
    FILE *f = fopen(path, "rb");
    if (!f) return reader_fail(r, DEFSIM_ERR_IO, 0, "cannot open: %s", strerror(errno));
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap + 1);
    while (buf) {
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap) break;
        cap *= 2;
        char *nb = realloc(buf, cap + 1);
        if (!nb) { free(buf); buf = NULL; }
        else buf = nb;
    }
    int err = ferror(f);
    fclose(f);
    if (!buf) {
        defsim__set_last_error("%s: out of memory", path);
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    if (err) {
        free(buf);
        return reader_fail(r, DEFSIM_ERR_IO, 0, "read error");
    }
    buf[n] = '\0';
    r->buf = buf;
    r->len = n;
    return DEFSIM_OK;
}

static void reader_close(reader *r) { free(r->buf); r->buf = NULL; }

/* A continued newline (OBJ); see load_obj. */
#define CONT '\x01'

static int is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

/* Skips blanks, newlines and comments. */
static void skip_ws(reader *r)
{
    while (r->pos < r->len) {
        char c = r->buf[r->pos];
        if (c == '\n' || c == CONT) { r->line++; r->pos++; }
        else if (is_space(c) || c == '\0') r->pos++;
        else if (c == '#' && r->hash_comments) {
            while (r->pos < r->len && r->buf[r->pos] != '\n') r->pos++;
        } else break;
    }
}

/* Moves to the end of the current line (its newline stays unread). */
static void to_eol(reader *r)
{
    while (r->pos < r->len && r->buf[r->pos] != '\n') r->pos++;
}

/* Skips the rest of the current line, including its newline. */
static void skip_line(reader *r)
{
    while (r->pos < r->len && r->buf[r->pos] != '\n') r->pos++;
    if (r->pos < r->len) { r->pos++; r->line++; }
}

/* Next whitespace-delimited token; returns its length (0 at the end of the file). */
static size_t next_token(reader *r, const char **tok)
{
    skip_ws(r);
    size_t s = r->pos;
    while (r->pos < r->len && !is_space(r->buf[r->pos]) && r->buf[r->pos] != '\n' &&
           r->buf[r->pos] != '\0' && !(r->hash_comments && r->buf[r->pos] == '#'))
        r->pos++;
    *tok = r->buf + s;
    return r->pos - s;
}

static void show_token(char *out, size_t size, const char *tok, size_t n)
{
    if (n == 0) { snprintf(out, size, "end of file"); return; }
    snprintf(out, size, "'%.*s'", (int)(n > 40 ? 40 : n), tok);
}

static int read_i64(reader *r, const char *what, long long *out)
{
    if (r->st != DEFSIM_OK) return 0;
    const char *tok;
    size_t n = next_token(r, &tok);
    char tmp[48];
    if (n > 0 && n < sizeof tmp) {
        memcpy(tmp, tok, n);
        tmp[n] = '\0';
        char *end;
        errno = 0;
        long long v = strtoll(tmp, &end, 10);
        if (*end == '\0' && errno == 0) { *out = v; return 1; }
    }
    char shown[64];
    show_token(shown, sizeof shown, tok, n);
    reader_fail(r, DEFSIM_ERR_IO, r->line, "expected %s (an integer), found %s", what, shown);
    return 0;
}

static int read_f64(reader *r, const char *what, double *out)
{
    if (r->st != DEFSIM_OK) return 0;
    const char *tok;
    size_t n = next_token(r, &tok);
    char tmp[80];
    if (n > 0 && n < sizeof tmp) {
        memcpy(tmp, tok, n);
        tmp[n] = '\0';
        char *end;
        double v = strtod(tmp, &end);
        if (*end == '\0' && isfinite(v)) { *out = v; return 1; }
    }
    char shown[64];
    show_token(shown, sizeof shown, tok, n);
    reader_fail(r, DEFSIM_ERR_IO, r->line, "expected %s (a finite number), found %s", what, shown);
    return 0;
}

/* Reads an integer that must lie in [lo, hi]. */
static int read_count(reader *r, const char *what, long long lo, long long hi, long long *out)
{
    int line = r->line;
    if (!read_i64(r, what, out)) return 0;
    if (*out < lo || *out > hi) {
        skip_ws(r);
        reader_fail(r, DEFSIM_ERR_IO, line, "%s %lld out of range [%lld, %lld]", what, *out, lo, hi);
        return 0;
    }
    return 1;
}

static int token_is(const char *tok, size_t n, const char *s)
{
    return n == strlen(s) && memcmp(tok, s, n) == 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Collected mesh: vertices by tag, elements by vertex tag, with the line each came from. */

typedef struct raw {
    vec pos;      /* double x3 */
    vec tag;      /* long long, one per vertex */
    vec tets;     /* long long x4 (vertex tags) */
    vec tet_line; /* int */
    vec tris;     /* long long x3 */
    vec tri_line; /* int */
    vec segs;     /* long long x2: explicit springs (OBJ 'l') */
    vec seg_line; /* int */
    int tags_are_indices; /* tags are 0-based indices already (OBJ) */
} raw;

static void raw_init(raw *m)
{
    memset(m, 0, sizeof *m);
    m->pos.elem = 3 * sizeof(double);
    m->tag.elem = sizeof(long long);
    m->tets.elem = 4 * sizeof(long long);
    m->tris.elem = 3 * sizeof(long long);
    m->segs.elem = 2 * sizeof(long long);
    m->tet_line.elem = m->tri_line.elem = m->seg_line.elem = sizeof(int);
}

static void raw_free(raw *m)
{
    free(m->pos.p); free(m->tag.p); free(m->tets.p); free(m->tet_line.p);
    free(m->tris.p); free(m->tri_line.p); free(m->segs.p); free(m->seg_line.p);
}

static defsim_status oom(const char *path)
{
    defsim__set_last_error("%s: out of memory", path);
    return DEFSIM_ERR_OUT_OF_MEMORY;
}

typedef struct tagidx { long long tag; int32_t idx; } tagidx;

static int cmp_tagidx(const void *a, const void *b)
{
    const tagidx *x = a, *y = b;
    return (x->tag > y->tag) - (x->tag < y->tag);
}

static int32_t find_tag(const tagidx *map, size_t n, long long tag)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (map[mid].tag < tag) lo = mid + 1;
        else hi = mid;
    }
    return lo < n && map[lo].tag == tag ? map[lo].idx : -1;
}

typedef struct edge { int32_t a, b; } edge;

static int cmp_edge(const void *p, const void *q)
{
    const edge *x = p, *y = q;
    if (x->a != y->a) return x->a < y->a ? -1 : 1;
    return (x->b > y->b) - (x->b < y->b);
}

static double dist(const double *p, const double *q)
{
    return sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                (p[2] - q[2]) * (p[2] - q[2]));
}

/* Maps tags to indices, compacts, checks and orients; on success fills *out (owning). With
 * `edge_springs`, the unique edges of the triangles become springs (OBJ cloth). */
static defsim_status finish(const char *path, raw *m, int edge_springs, defsim_mesh *out)
{
    const size_t nv = m->pos.n, nt = m->tets.n, ntri = m->tris.n, nseg = m->segs.n;
    const long long *tags = m->tag.p;
    if (nv > (size_t)INT32_MAX / 3 || nt > (size_t)INT32_MAX / 4 || ntri > (size_t)INT32_MAX / 6 ||
        nseg > (size_t)INT32_MAX / 4) {
        defsim__set_last_error("%s: mesh too large for 32-bit indices", path);
        return DEFSIM_ERR_INVALID_MESH;
    }
    tagidx *map = malloc((nv ? nv : 1) * sizeof *map);
    int32_t *remap = malloc((nv ? nv : 1) * sizeof *remap);
    int32_t *tets = malloc((nt ? nt : 1) * 4 * sizeof *tets);
    int32_t *tris = malloc((ntri ? ntri : 1) * 3 * sizeof *tris);
    int32_t *segs = malloc((nseg ? nseg : 1) * 2 * sizeof *segs);
    defsim_mesh res;
    memset(&res, 0, sizeof res);
    defsim_status st = DEFSIM_ERR_INVALID_MESH;
    if (!map || !remap || !tets || !tris || !segs) { st = oom(path); goto done; }

    /* Tags to indices (a sorted table; duplicate tags are an error). */
    for (size_t i = 0; i < nv; ++i) {
        map[i].tag = m->tags_are_indices ? (long long)i : tags[i];
        map[i].idx = (int32_t)i;
    }
    if (!m->tags_are_indices) {
        qsort(map, nv, sizeof *map, cmp_tagidx);
        for (size_t i = 1; i < nv; ++i)
            if (map[i].tag == map[i - 1].tag) {
                defsim__set_last_error("%s: vertex number %lld is defined twice", path, map[i].tag);
                goto done;
            }
    }
    struct { const vec *src, *line; int32_t *dst; size_t n; int k; const char *what; } groups[3] = {
        {&m->tets, &m->tet_line, tets, nt, 4, "tet"},
        {&m->tris, &m->tri_line, tris, ntri, 3, "face"},
        {&m->segs, &m->seg_line, segs, nseg, 2, "line"}};
    for (int g = 0; g < 3; ++g) {
        const long long *src = groups[g].src->p;
        const int *line = groups[g].line->p;
        const int k = groups[g].k;
        for (size_t e = 0; e < groups[g].n; ++e)
            for (int a = 0; a < k; ++a) {
                long long t = src[(size_t)k * e + (size_t)a];
                int32_t idx = m->tags_are_indices ? (t >= 0 && (size_t)t < nv ? (int32_t)t : -1)
                                                  : find_tag(map, nv, t);
                if (idx < 0) {
                    if (m->tags_are_indices)
                        defsim__set_last_error("%s:%d: %s refers to vertex %lld, but the file "
                                               "has %zu vertices", path, line[e], groups[g].what,
                                               t + 1, nv);
                    else
                        defsim__set_last_error("%s:%d: %s refers to vertex %lld, which is not "
                                               "defined", path, line[e], groups[g].what, t);
                    goto done;
                }
                for (int b = 0; b < a; ++b)
                    if (groups[g].dst[(size_t)k * e + (size_t)b] == idx) {
                        defsim__set_last_error("%s:%d: %s repeats vertex %lld", path, line[e],
                                               groups[g].what, m->tags_are_indices ? t + 1 : t);
                        goto done;
                    }
                groups[g].dst[(size_t)k * e + (size_t)a] = idx;
            }
    }

    /* Keep only the vertices that some element uses, in file order. */
    for (size_t i = 0; i < nv; ++i) remap[i] = -1;
    for (size_t i = 0; i < 4 * nt; ++i) remap[tets[i]] = 0;
    for (size_t i = 0; i < 3 * ntri; ++i) remap[tris[i]] = 0;
    for (size_t i = 0; i < 2 * nseg; ++i) remap[segs[i]] = 0;
    int32_t nkeep = 0;
    for (size_t i = 0; i < nv; ++i)
        if (remap[i] == 0) remap[i] = nkeep++;
    if (nkeep == 0) {
        defsim__set_last_error("%s: the file has no elements this loader reads", path);
        goto done;
    }
    res.positions = malloc((size_t)nkeep * 3 * sizeof *res.positions);
    if (!res.positions) { st = oom(path); goto done; }
    const double *pos = m->pos.p;
    for (size_t i = 0; i < nv; ++i)
        if (remap[i] >= 0) memcpy(res.positions + 3 * (size_t)remap[i], pos + 3 * i, 3 * sizeof *pos);
    for (size_t i = 0; i < 4 * nt; ++i) tets[i] = remap[tets[i]];
    for (size_t i = 0; i < 3 * ntri; ++i) tris[i] = remap[tris[i]];
    for (size_t i = 0; i < 2 * nseg; ++i) segs[i] = remap[segs[i]];
    res.vertex_count = nkeep;
    const double *P = res.positions;

    /* Tets: positive orientation, not degenerate. */
    for (size_t t = 0; t < nt; ++t) {
        int32_t *tt = tets + 4 * t;
        double dm[9], lmax = 0.0;
        for (int a = 0; a < 3; ++a)
            for (int i = 0; i < 3; ++i)
                dm[3 * i + a] = P[3 * (size_t)tt[a] + (size_t)i] - P[3 * (size_t)tt[3] + (size_t)i];
        for (int a = 0; a < 4; ++a)
            for (int b = a + 1; b < 4; ++b) {
                double l = dist(P + 3 * (size_t)tt[a], P + 3 * (size_t)tt[b]);
                if (l > lmax) lmax = l;
            }
        double det = defsim__m3_det(dm);
        if (!(fabs(det) > DEGENERATE_REL * lmax * lmax * lmax)) {
            defsim__set_last_error("%s:%d: tet %zu is degenerate (volume %g)", path,
                                   ((const int *)m->tet_line.p)[t], t, det / 6.0);
            goto done;
        }
        if (det < 0.0) { int32_t s = tt[0]; tt[0] = tt[1]; tt[1] = s; }
    }
    /* Edges and polylines must have length: they become springs. */
    for (size_t e = 0; e < ntri; ++e)
        for (int a = 0; a < 3; ++a)
            if (!(dist(P + 3 * (size_t)tris[3 * e + (size_t)a],
                       P + 3 * (size_t)tris[3 * e + (size_t)(a + 1) % 3]) > 0.0)) {
                defsim__set_last_error("%s:%d: face has two vertices at the same point", path,
                                       ((const int *)m->tri_line.p)[e]);
                goto done;
            }
    for (size_t e = 0; e < nseg; ++e)
        if (!(dist(P + 3 * (size_t)segs[2 * e], P + 3 * (size_t)segs[2 * e + 1]) > 0.0)) {
            defsim__set_last_error("%s:%d: line segment of zero length", path,
                                   ((const int *)m->seg_line.p)[e]);
            goto done;
        }

    if (nt > 0) {
        res.tets = tets; tets = NULL;
        res.tet_count = (int32_t)nt;
        st = defsim__tet_boundary(res.positions, res.tets, res.tet_count, &res.triangles,
                                  &res.triangle_count);
        if (st != DEFSIM_OK) { st = oom(path); goto done; }
    } else if (ntri > 0) {
        res.triangles = tris; tris = NULL;
        res.triangle_count = (int32_t)ntri;
    }
    if (edge_springs && (res.triangle_count > 0 || nseg > 0) && nt == 0) {
        /* Unique edges of the faces and the polylines, sorted, become springs. */
        size_t ne = 3 * (size_t)res.triangle_count + nseg;
        edge *E = malloc(ne * sizeof *E);
        if (!E) { st = oom(path); goto done; }
        size_t k = 0;
        for (int32_t t = 0; t < res.triangle_count; ++t)
            for (int a = 0; a < 3; ++a) {
                int32_t u = res.triangles[3 * t + a], v = res.triangles[3 * t + (a + 1) % 3];
                E[k].a = u < v ? u : v;
                E[k++].b = u < v ? v : u;
            }
        for (size_t s = 0; s < nseg; ++s) {
            int32_t u = segs[2 * s], v = segs[2 * s + 1];
            E[k].a = u < v ? u : v;
            E[k++].b = u < v ? v : u;
        }
        qsort(E, ne, sizeof *E, cmp_edge);
        size_t nu = 0;
        for (size_t i = 0; i < ne; ++i)
            if (nu == 0 || cmp_edge(&E[i], &E[nu - 1]) != 0) E[nu++] = E[i];
        res.springs = malloc(2 * nu * sizeof *res.springs);
        if (!res.springs) { free(E); st = oom(path); goto done; }
        for (size_t i = 0; i < nu; ++i) {
            res.springs[2 * i] = E[i].a;
            res.springs[2 * i + 1] = E[i].b;
        }
        res.spring_count = (int32_t)nu;
        free(E);
    }
    res.size = out->size;
    *out = res;
    memset(&res, 0, sizeof res);
    st = DEFSIM_OK;
done:
    defsim_mesh_free(&res);
    free(map); free(remap); free(tets); free(tris); free(segs);
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* TetGen */

static defsim_status load_tetgen(const char *base, defsim_mesh *out)
{
    size_t bl = strlen(base);
    char *node_path = malloc(bl + 6), *ele_path = malloc(bl + 6);
    if (!node_path || !ele_path) { free(node_path); free(ele_path); return oom(base); }
    snprintf(node_path, bl + 6, "%s.node", base);
    snprintf(ele_path, bl + 6, "%s.ele", base);
    raw m;
    raw_init(&m);
    reader r;
    long long n = 0, dim = 0, nattr = 0, nmark = 0;
    defsim_status st = reader_open(&r, node_path, 1);
    if (st != DEFSIM_OK) goto done;
    read_count(&r, "number of points", 1, INT32_MAX / 3, &n);
    read_i64(&r, "dimension", &dim);
    if (r.st == DEFSIM_OK && dim != 3) reader_fail(&r, DEFSIM_ERR_INVALID_MESH, r.line,
                                                   "dimension %lld: only 3-D meshes are read", dim);
    read_count(&r, "number of attributes", 0, 1000, &nattr);
    read_count(&r, "number of boundary markers", 0, 1, &nmark);
    for (long long i = 0; i < n && r.st == DEFSIM_OK; ++i) {
        long long tag;
        double p[3];
        int line;
        skip_ws(&r);
        line = r.line;
        if (!read_i64(&r, "point number", &tag) || !read_f64(&r, "x", &p[0]) ||
            !read_f64(&r, "y", &p[1]) || !read_f64(&r, "z", &p[2]))
            break;
        for (long long a = 0; a < nattr + nmark; ++a) {
            double skip;
            if (!read_f64(&r, "attribute or boundary marker", &skip)) break;
        }
        if (r.st == DEFSIM_OK && r.line != line)
            reader_fail(&r, DEFSIM_ERR_IO, line, "point %lld: expected %lld values on the line",
                        tag, 4 + nattr + nmark);
        if (r.st == DEFSIM_OK && (!vec_push(&m.pos, p, 1) || !vec_push(&m.tag, &tag, 1)))
            st = oom(node_path);
    }
    if (st == DEFSIM_OK) st = r.st;
    reader_close(&r);
    if (st != DEFSIM_OK) goto done;

    st = reader_open(&r, ele_path, 1);
    if (st != DEFSIM_OK) goto done;
    long long nt = 0, per = 0;
    read_count(&r, "number of tetrahedra", 1, INT32_MAX / 4, &nt);
    skip_ws(&r);
    int per_line = r.line;
    read_i64(&r, "nodes per tetrahedron", &per);
    if (r.st == DEFSIM_OK && per != 4)
        reader_fail(&r, DEFSIM_ERR_INVALID_MESH, per_line,
                    "%lld nodes per tetrahedron: only linear (4-node) tets are supported "
                    "(run tetgen without -o2)", per);
    read_count(&r, "number of attributes", 0, 1000, &nattr);
    for (long long t = 0; t < nt && r.st == DEFSIM_OK; ++t) {
        long long tag, v[4];
        skip_ws(&r);
        int line = r.line;
        if (!read_i64(&r, "tet number", &tag)) break;
        for (int a = 0; a < 4; ++a)
            if (!read_i64(&r, "vertex number", &v[a])) break;
        for (long long a = 0; a < nattr && r.st == DEFSIM_OK; ++a) {
            double skip;
            read_f64(&r, "region attribute", &skip);
        }
        if (r.st == DEFSIM_OK && r.line != line)
            reader_fail(&r, DEFSIM_ERR_IO, line, "tet %lld: expected %lld values on the line",
                        tag, 5 + nattr);
        if (r.st == DEFSIM_OK && (!vec_push(&m.tets, v, 1) || !vec_push(&m.tet_line, &line, 1)))
            st = oom(ele_path);
    }
    if (st == DEFSIM_OK) st = r.st;
    reader_close(&r);
    if (st == DEFSIM_OK) st = finish(ele_path, &m, 0, out);
done:
    raw_free(&m);
    free(node_path);
    free(ele_path);
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* Gmsh */

/* Gmsh element types: node count and dimension (0 for unknown types). */
static void gmsh_type(long long type, int *nodes, int *dim, const char **name)
{
    static const struct { int type, nodes, dim; const char *name; } T[] = {
        {1, 2, 1, "2-node line"}, {2, 3, 2, "3-node triangle"}, {3, 4, 2, "4-node quadrangle"},
        {4, 4, 3, "4-node tetrahedron"}, {5, 8, 3, "8-node hexahedron"},
        {6, 6, 3, "6-node prism"}, {7, 5, 3, "5-node pyramid"}, {8, 3, 1, "3-node line"},
        {9, 6, 2, "6-node triangle"}, {10, 9, 2, "9-node quadrangle"},
        {11, 10, 3, "10-node (quadratic) tetrahedron"}, {12, 27, 3, "27-node hexahedron"},
        {13, 18, 3, "18-node prism"}, {14, 14, 3, "14-node pyramid"}, {15, 1, 0, "point"},
        {16, 8, 2, "8-node quadrangle"}, {17, 20, 3, "20-node hexahedron"},
        {18, 15, 3, "15-node prism"}, {19, 13, 3, "13-node pyramid"},
        {20, 9, 2, "9-node triangle"}, {21, 10, 2, "10-node triangle"},
        {22, 12, 2, "12-node triangle"}, {23, 15, 2, "15-node triangle"},
        {24, 15, 2, "15-node triangle"}, {25, 21, 2, "21-node triangle"},
        {26, 4, 1, "4-node line"}, {27, 5, 1, "5-node line"}, {28, 6, 1, "6-node line"},
        {29, 20, 3, "20-node tetrahedron"}, {30, 35, 3, "35-node tetrahedron"},
        {31, 56, 3, "56-node tetrahedron"}, {92, 64, 3, "64-node hexahedron"},
        {93, 125, 3, "125-node hexahedron"}};
    *nodes = 0;
    *dim = -1;
    *name = "unknown element type";
    for (size_t i = 0; i < sizeof T / sizeof T[0]; ++i)
        if (T[i].type == type) { *nodes = T[i].nodes; *dim = T[i].dim; *name = T[i].name; }
}

/* Reads "$Name" and checks it; skips unknown sections. Returns 1 if a section was opened. */
static int gmsh_section(reader *r, const char **name, size_t *n)
{
    *n = next_token(r, name);
    return *n > 0;
}

static void gmsh_skip_section(reader *r, const char *name, size_t n)
{
    char end[128];
    snprintf(end, sizeof end, "$End%.*s", (int)(n > 100 ? 100 : n) - 1, name + 1);
    int line = r->line;
    for (;;) {
        const char *tok;
        size_t k = next_token(r, &tok);
        if (k == 0) {
            reader_fail(r, DEFSIM_ERR_IO, line, "section %.*s has no %s", (int)n, name, end);
            return;
        }
        if (token_is(tok, k, end)) return;
    }
}

static void gmsh_expect_end(reader *r, const char *end)
{
    if (r->st != DEFSIM_OK) return;
    const char *tok;
    size_t k = next_token(r, &tok);
    if (!token_is(tok, k, end)) {
        char shown[64];
        show_token(shown, sizeof shown, tok, k);
        reader_fail(r, DEFSIM_ERR_IO, r->line, "expected %s, found %s", end, shown);
    }
}

static int gmsh_push_node(reader *r, raw *m, long long tag, const double p[3])
{
    if (!vec_push(&m->pos, p, 1) || !vec_push(&m->tag, &tag, 1)) {
        r->st = oom(r->path);
        return 0;
    }
    return 1;
}

/* One element; keeps tets, skips lower-dimensional ones, rejects other volume elements. */
static void gmsh_element(reader *r, raw *m, long long type, int dim_hint, int line,
                         long long nodes[], int nn)
{
    int tn, dim;
    const char *name;
    gmsh_type(type, &tn, &dim, &name);
    if (dim < 0) dim = dim_hint;
    if (type == 4) {
        if (!vec_push(&m->tets, nodes, 1) || !vec_push(&m->tet_line, &line, 1)) r->st = oom(r->path);
    } else if (dim == 3) {
        reader_fail(r, DEFSIM_ERR_INVALID_MESH, line,
                    "element type %lld (%s): only linear tetrahedra (type 4) are supported as "
                    "volume elements%s", type, name,
                    type == 11 ? "; mesh with Mesh.ElementOrder = 1" : "");
    } else if (dim < 0) {
        reader_fail(r, DEFSIM_ERR_INVALID_MESH, line, "unknown element type %lld", type);
    }
    (void)nn;
}

static void gmsh_v2(reader *r, raw *m)
{
    const char *name;
    size_t n;
    while (r->st == DEFSIM_OK && gmsh_section(r, &name, &n)) {
        int line = r->line;
        if (token_is(name, n, "$Nodes")) {
            long long nn;
            if (!read_count(r, "number of nodes", 0, INT32_MAX / 3, &nn)) return;
            for (long long i = 0; i < nn; ++i) {
                long long tag;
                double p[3];
                if (!read_i64(r, "node number", &tag) || !read_f64(r, "x", &p[0]) ||
                    !read_f64(r, "y", &p[1]) || !read_f64(r, "z", &p[2]))
                    return;
                if (!gmsh_push_node(r, m, tag, p)) return;
            }
            gmsh_expect_end(r, "$EndNodes");
        } else if (token_is(name, n, "$Elements")) {
            long long ne;
            if (!read_count(r, "number of elements", 0, INT32_MAX, &ne)) return;
            for (long long e = 0; e < ne; ++e) {
                long long tag, type, ntags, skip, v[4];
                skip_ws(r);
                int eline = r->line;
                if (!read_i64(r, "element number", &tag) || !read_i64(r, "element type", &type) ||
                    !read_count(r, "number of tags", 0, 1000, &ntags))
                    return;
                for (long long k = 0; k < ntags; ++k)
                    if (!read_i64(r, "tag", &skip)) return;
                if (type == 4) {
                    for (int a = 0; a < 4; ++a)
                        if (!read_i64(r, "node number", &v[a])) return;
                    if (r->line != eline) {
                        reader_fail(r, DEFSIM_ERR_IO, eline, "element %lld: line ends early", tag);
                        return;
                    }
                } else {
                    to_eol(r);
                }
                gmsh_element(r, m, type, -1, eline, v, 4);
                if (r->st != DEFSIM_OK) return;
            }
            gmsh_expect_end(r, "$EndElements");
        } else if (name[0] == '$') {
            gmsh_skip_section(r, name, n);
        } else {
            reader_fail(r, DEFSIM_ERR_IO, line, "expected a section ($Name), found '%.*s'",
                        (int)(n > 40 ? 40 : n), name);
        }
    }
}

static void gmsh_v4(reader *r, raw *m, int minor)
{
    const char *name;
    size_t n;
    while (r->st == DEFSIM_OK && gmsh_section(r, &name, &n)) {
        int line = r->line;
        if (token_is(name, n, "$Nodes")) {
            long long nblocks, nn, skip;
            if (!read_count(r, "number of entity blocks", 0, INT32_MAX, &nblocks) ||
                !read_count(r, "number of nodes", 0, INT32_MAX / 3, &nn))
                return;
            if (minor >= 1 && (!read_i64(r, "minimum node tag", &skip) ||
                               !read_i64(r, "maximum node tag", &skip)))
                return;
            for (long long b = 0; b < nblocks; ++b) {
                long long dim, etag, param, cnt;
                if (minor >= 1) {
                    if (!read_count(r, "entity dimension", 0, 3, &dim) ||
                        !read_i64(r, "entity tag", &etag))
                        return;
                } else if (!read_i64(r, "entity tag", &etag) ||
                           !read_count(r, "entity dimension", 0, 3, &dim)) {
                    return;
                }
                if (!read_count(r, "parametric flag", 0, 1, &param) ||
                    !read_count(r, "nodes in block", 0, INT32_MAX / 3, &cnt))
                    return;
                /* Parametric coordinates follow x y z: one per entity dimension. */
                const long long npar = param ? (minor >= 1 ? dim : (dim < 2 ? dim : 2)) : 0;
                if (minor >= 1) {
                    size_t first = m->tag.n;
                    for (long long i = 0; i < cnt; ++i) {
                        long long tag;
                        const double zero[3] = {0, 0, 0};
                        if (!read_i64(r, "node tag", &tag) || !gmsh_push_node(r, m, tag, zero))
                            return;
                    }
                    double *P = m->pos.p;
                    for (long long i = 0; i < cnt; ++i) {
                        double *p = P + 3 * (first + (size_t)i), u;
                        if (!read_f64(r, "x", &p[0]) || !read_f64(r, "y", &p[1]) ||
                            !read_f64(r, "z", &p[2]))
                            return;
                        for (long long k = 0; k < npar; ++k)
                            if (!read_f64(r, "parametric coordinate", &u)) return;
                    }
                } else {
                    for (long long i = 0; i < cnt; ++i) {
                        long long tag;
                        double p[3], u;
                        if (!read_i64(r, "node tag", &tag) || !read_f64(r, "x", &p[0]) ||
                            !read_f64(r, "y", &p[1]) || !read_f64(r, "z", &p[2]))
                            return;
                        for (long long k = 0; k < npar; ++k)
                            if (!read_f64(r, "parametric coordinate", &u)) return;
                        if (!gmsh_push_node(r, m, tag, p)) return;
                    }
                }
            }
            gmsh_expect_end(r, "$EndNodes");
        } else if (token_is(name, n, "$Elements")) {
            long long nblocks, ne, skip;
            if (!read_count(r, "number of entity blocks", 0, INT32_MAX, &nblocks) ||
                !read_count(r, "number of elements", 0, INT32_MAX, &ne))
                return;
            if (minor >= 1 && (!read_i64(r, "minimum element tag", &skip) ||
                               !read_i64(r, "maximum element tag", &skip)))
                return;
            for (long long b = 0; b < nblocks; ++b) {
                long long dim, etag, type, cnt;
                skip_ws(r);
                int bline = r->line;
                if (minor >= 1) {
                    if (!read_count(r, "entity dimension", 0, 3, &dim) ||
                        !read_i64(r, "entity tag", &etag))
                        return;
                } else if (!read_i64(r, "entity tag", &etag) ||
                           !read_count(r, "entity dimension", 0, 3, &dim)) {
                    return;
                }
                if (!read_i64(r, "element type", &type) ||
                    !read_count(r, "elements in block", 0, INT32_MAX, &cnt))
                    return;
                if (type != 4) {
                    /* Boundary elements are skipped line by line; other volumes are errors. */
                    gmsh_element(r, m, type, (int)dim, bline, NULL, 0);
                    if (r->st != DEFSIM_OK) return;
                    skip_line(r);
                    for (long long e = 0; e < cnt; ++e) skip_line(r);
                    continue;
                }
                for (long long e = 0; e < cnt; ++e) {
                    long long tag, v[4];
                    skip_ws(r);
                    int eline = r->line;
                    if (!read_i64(r, "element tag", &tag)) return;
                    for (int a = 0; a < 4; ++a)
                        if (!read_i64(r, "node tag", &v[a])) return;
                    if (r->line != eline) {
                        reader_fail(r, DEFSIM_ERR_IO, eline, "element %lld: line ends early", tag);
                        return;
                    }
                    gmsh_element(r, m, 4, 3, eline, v, 4);
                    if (r->st != DEFSIM_OK) return;
                }
            }
            gmsh_expect_end(r, "$EndElements");
        } else if (name[0] == '$') {
            gmsh_skip_section(r, name, n);
        } else {
            reader_fail(r, DEFSIM_ERR_IO, line, "expected a section ($Name), found '%.*s'",
                        (int)(n > 40 ? 40 : n), name);
        }
    }
}

static defsim_status load_gmsh(const char *path, defsim_mesh *out)
{
    reader r;
    defsim_status st = reader_open(&r, path, 0);
    if (st != DEFSIM_OK) return st;
    raw m;
    raw_init(&m);
    const char *tok;
    size_t n = next_token(&r, &tok);
    if (!token_is(tok, n, "$MeshFormat")) {
        reader_fail(&r, DEFSIM_ERR_IO, r.line, "not a Gmsh file: expected $MeshFormat");
        goto done;
    }
    skip_ws(&r);
    int vline = r.line;
    double version;
    long long ftype, dsize;
    if (!read_f64(&r, "format version", &version) || !read_i64(&r, "file type", &ftype) ||
        !read_i64(&r, "data size", &dsize))
        goto done;
    if (ftype != 0) {
        reader_fail(&r, DEFSIM_ERR_IO, vline, "binary .msh files are not read; save as ASCII "
                                              "(Mesh.Binary = 0, the default)");
        goto done;
    }
    int major = (int)floor(version), minor = (int)lround((version - major) * 10.0);
    if (!(major == 2 || (major == 4 && minor <= 1))) {
        reader_fail(&r, DEFSIM_ERR_IO, vline, "Gmsh format %g is not supported (2.x and 4.0, "
                                              "4.1 ASCII are)", version);
        goto done;
    }
    gmsh_expect_end(&r, "$EndMeshFormat");
    if (r.st != DEFSIM_OK) goto done;
    if (major == 2) gmsh_v2(&r, &m);
    else gmsh_v4(&r, &m, minor);
    if (r.st == DEFSIM_OK && m.tets.n == 0)
        reader_fail(&r, DEFSIM_ERR_INVALID_MESH, 0, "no tetrahedra (element type 4) in the file");
done:
    st = r.st;
    reader_close(&r);
    if (st == DEFSIM_OK) st = finish(path, &m, 0, out);
    raw_free(&m);
    return st;
}

/* ------------------------------------------------------------------------------------------ */
/* Wavefront OBJ */

/* OBJ statements end at a newline; a backslash before the newline continues them. The loader
 * turns such newlines into CONT, which counts as a line but not as the end of a statement. */

/* Next token of the current statement (0 at its end). */
static size_t obj_token(reader *r, const char **tok)
{
    while (r->pos < r->len && (is_space(r->buf[r->pos]) || r->buf[r->pos] == CONT)) {
        if (r->buf[r->pos] == CONT) r->line++;
        r->pos++;
    }
    size_t s = r->pos;
    while (r->pos < r->len && !is_space(r->buf[r->pos]) && r->buf[r->pos] != CONT &&
           r->buf[r->pos] != '\n' && r->buf[r->pos] != '#')
        r->pos++;
    *tok = r->buf + s;
    return r->pos - s;
}

/* Skips to the start of the next statement. */
static void obj_next_statement(reader *r)
{
    while (r->pos < r->len && r->buf[r->pos] != '\n') {
        if (r->buf[r->pos] == CONT) r->line++;
        r->pos++;
    }
    if (r->pos < r->len) { r->pos++; r->line++; }
}

/* Parses one "v", "v/vt", "v//vn" or "v/vt/vn" reference; returns the 0-based vertex index
 * (relative ones resolved against the vertices read so far). */
static int obj_index(reader *r, const char *tok, size_t n, size_t nv, int line, long long *out)
{
    char tmp[64];
    size_t k = 0;
    while (k < n && tok[k] != '/') ++k;
    if (k > 0 && k < sizeof tmp) {
        memcpy(tmp, tok, k);
        tmp[k] = '\0';
        char *end;
        errno = 0;
        long long v = strtoll(tmp, &end, 10);
        if (*end == '\0' && errno == 0 && v != 0) {
            if (v < 0) {
                if ((unsigned long long)-v > nv) {
                    reader_fail(r, DEFSIM_ERR_INVALID_MESH, line, "relative vertex index %lld "
                                "reaches before the first vertex (%zu read so far)", v, nv);
                    return 0;
                }
                *out = (long long)nv + v;
            } else {
                *out = v - 1;
            }
            return 1;
        }
    }
    reader_fail(r, DEFSIM_ERR_IO, line, "bad vertex reference '%.*s' (expected a non-zero "
                "index, optionally with /texture/normal)", (int)(n > 40 ? 40 : n), tok);
    return 0;
}

static defsim_status load_obj(const char *path, defsim_mesh *out)
{
    reader r;
    defsim_status st = reader_open(&r, path, 1);
    if (st != DEFSIM_OK) return st;
    raw m;
    raw_init(&m);
    m.tags_are_indices = 1;
    vec poly = {NULL, 0, 0, sizeof(long long)};
    for (size_t i = 0; i + 1 < r.len; ++i) {
        size_t j = i + 1;
        if (r.buf[i] != '\\') continue;
        while (j < r.len && r.buf[j] == '\r') ++j;
        if (j < r.len && r.buf[j] == '\n') { r.buf[i] = ' '; r.buf[j] = CONT; }
    }
    while (r.st == DEFSIM_OK && st == DEFSIM_OK) {
        skip_ws(&r);
        if (r.pos >= r.len) break;
        const int line = r.line;
        const char *kw, *tok;
        size_t kn = obj_token(&r, &kw), tn;
        if (token_is(kw, kn, "v")) {
            double p[3];
            static const char *axis[3] = {"x", "y", "z"};
            for (int c = 0; c < 3 && r.st == DEFSIM_OK; ++c) {
                tn = obj_token(&r, &tok);
                char tmp[80], *end;
                if (tn > 0 && tn < sizeof tmp) {
                    memcpy(tmp, tok, tn);
                    tmp[tn] = '\0';
                    p[c] = strtod(tmp, &end);
                    if (*end == '\0' && isfinite(p[c])) continue;
                }
                char shown[64];
                show_token(shown, sizeof shown, tok, tn);
                if (tn == 0) snprintf(shown, sizeof shown, "end of line");
                reader_fail(&r, DEFSIM_ERR_IO, line, "vertex: expected %s (a finite number), "
                            "found %s", axis[c], shown);
            }
            if (r.st != DEFSIM_OK) break;
            long long tag = (long long)m.pos.n;
            if (!vec_push(&m.pos, p, 1) || !vec_push(&m.tag, &tag, 1)) st = oom(path);
        } else if (token_is(kw, kn, "f") || token_is(kw, kn, "l")) {
            const int face = kw[0] == 'f';
            poly.n = 0;
            while ((tn = obj_token(&r, &tok)) > 0) {
                long long idx;
                if (!obj_index(&r, tok, tn, m.pos.n, line, &idx)) break;
                if (!vec_push(&poly, &idx, 1)) { st = oom(path); break; }
            }
            if (r.st != DEFSIM_OK || st != DEFSIM_OK) break;
            const long long *v = poly.p;
            if (poly.n < (face ? 3u : 2u)) {
                reader_fail(&r, DEFSIM_ERR_INVALID_MESH, line, "%s with %zu vertices (needs at "
                            "least %d)", face ? "face" : "line", poly.n, face ? 3 : 2);
                break;
            }
            /* Polygons are fan-triangulated; polylines give one segment per pair. */
            for (size_t k = face ? 1 : 0; k + 1 < poly.n && st == DEFSIM_OK; ++k) {
                long long t[3] = {v[0], v[k], v[k + 1]}, s[2] = {v[k], v[k + 1]};
                if (face ? !vec_push(&m.tris, t, 1) || !vec_push(&m.tri_line, &line, 1)
                         : !vec_push(&m.segs, s, 1) || !vec_push(&m.seg_line, &line, 1))
                    st = oom(path);
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
    reader_close(&r);
    free(poly.p);
    if (st == DEFSIM_OK) st = finish(path, &m, 1, out);
    raw_free(&m);
    return st;
}

/* ------------------------------------------------------------------------------------------ */

static int ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), k = strlen(suffix);
    if (n < k) return 0;
    for (size_t i = 0; i < k; ++i) {
        char c = s[n - k + i];
        if (c >= 'A' && c <= 'Z') c = (char)(c - 'A' + 'a');
        if (c != suffix[i]) return 0;
    }
    return 1;
}

defsim_status defsim_mesh_load(const char *path, defsim_mesh *mesh)
{
    if (!path || !mesh || mesh->size < sizeof(defsim_mesh)) {
        defsim__set_last_error("defsim_mesh_load: NULL argument or mesh->size not "
                               "sizeof(defsim_mesh)");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    defsim__clear_last_error();
    if (ends_with(path, ".msh")) return load_gmsh(path, mesh);
    if (ends_with(path, ".obj")) return load_obj(path, mesh);
    size_t n = strlen(path);
    char *base = malloc(n + 1);
    if (!base) return oom(path);
    memcpy(base, path, n + 1);
    defsim_status st;
    if (ends_with(base, ".node")) base[n - 5] = '\0';
    else if (ends_with(base, ".ele")) base[n - 4] = '\0';
    else {
        /* A base name: TetGen if base.node exists. */
        char *node = malloc(n + 6);
        FILE *f = NULL;
        if (node) {
            snprintf(node, n + 6, "%s.node", base);
            f = fopen(node, "rb");
        }
        free(node);
        if (!f) {
            free(base);
            defsim__set_last_error("%s: unknown mesh format (expected .node/.ele, .msh or .obj, "
                                   "or a TetGen base name)", path);
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
        fclose(f);
    }
    st = load_tetgen(base, mesh);
    free(base);
    return st;
}

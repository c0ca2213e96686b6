/* SPDX-License-Identifier: MIT */
#include "vtk.h"

#include "fileio.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int set_err(char *err, size_t errsz, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

static int set_err(char *err, size_t errsz, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, errsz, fmt, ap);
    va_end(ap);
    return -1;
}

static int grow(void **p, int64_t n, size_t elem)
{
    void *q = realloc(*p, (size_t)(n > 0 ? n : 1) * elem);
    if (!q) return 0;
    *p = q;
    return 1;
}

int vtk_cells_add(vtk_cells *c, const int32_t *idx, int64_t n, int k, int32_t offset, uint8_t type,
                  int32_t body)
{
    const int64_t nc = c->ncells + n, nk = c->nconn + n * k;
    if (!grow((void **)&c->conn, nk, sizeof *c->conn) ||
        !grow((void **)&c->offsets, nc, sizeof *c->offsets) ||
        !grow((void **)&c->types, nc, sizeof *c->types) ||
        !grow((void **)&c->body, nc, sizeof *c->body))
        return -1;
    for (int64_t e = 0; e < n; ++e) {
        for (int a = 0; a < k; ++a) c->conn[c->nconn + e * k + a] = (int64_t)idx[e * k + a] + offset;
        c->offsets[c->ncells + e] = c->nconn + (e + 1) * k;
        c->types[c->ncells + e] = type;
        c->body[c->ncells + e] = body;
    }
    c->ncells = nc;
    c->nconn = nk;
    return 0;
}

void vtk_cells_free(vtk_cells *c)
{
    free(c->conn); free(c->offsets); free(c->types); free(c->body);
    memset(c, 0, sizeof *c);
}

static int little_endian(void)
{
    const uint16_t one = 1;
    return *(const uint8_t *)&one == 1;
}

/* Raw appended blocks: a UInt64 byte count, then the bytes. */
static int put_block(FILE *f, const void *data, uint64_t bytes)
{
    return fwrite(&bytes, sizeof bytes, 1, f) == 1 &&
           (bytes == 0 || fwrite(data, 1, (size_t)bytes, f) == (size_t)bytes);
}

static void array_tag(FILE *f, const char *name, int components, uint64_t offset)
{
    fprintf(f, "        <DataArray type=\"Float64\" Name=\"%s\" NumberOfComponents=\"%d\" "
               "format=\"appended\" offset=\"%llu\"/>\n", name, components,
            (unsigned long long)offset);
}

int vtk_write_vtu(const char *path, int32_t nv, const double *x, const double *v,
                  const vtk_cells *c, double time, const vtk_array *extra, int n_extra,
                  char *err, size_t errsz)
{
    enum { MAX_EXTRA = 16 };
    if (n_extra < 0 || n_extra > MAX_EXTRA)
        return set_err(err, errsz, "%s: %d extra arrays (at most %d)", path, n_extra, MAX_EXTRA);
    char tmp[2200];
    FILE *f = tools_tmp_open(path, tmp, sizeof tmp, err, errsz);
    if (!f) return -1;
    const uint64_t bx = 3 * (uint64_t)nv * sizeof(double);
    const uint64_t bconn = (uint64_t)c->nconn * sizeof(int64_t);
    const uint64_t boff = (uint64_t)c->ncells * sizeof(int64_t);
    const uint64_t btyp = (uint64_t)c->ncells;
    const uint64_t bbody = (uint64_t)c->ncells * sizeof(int32_t);
    uint64_t o = 0, o_v = 0, o_body, o_x, o_conn, o_off, o_typ, o_extra[MAX_EXTRA], b_extra[MAX_EXTRA];
    if (v) { o_v = o; o += 8 + bx; }
    int point_extra = 0;
    for (int k = 0; k < n_extra; ++k) {
        b_extra[k] = (uint64_t)extra[k].components * sizeof(double) *
                     (extra[k].cell ? (uint64_t)c->ncells : (uint64_t)nv);
        o_extra[k] = o;
        o += 8 + b_extra[k];
        point_extra += !extra[k].cell;
    }
    o_body = o; o += 8 + bbody;
    o_x = o; o += 8 + bx;
    o_conn = o; o += 8 + bconn;
    o_off = o; o += 8 + boff;
    o_typ = o;
    fprintf(f, "<?xml version=\"1.0\"?>\n"
               "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"%s\" "
               "header_type=\"UInt64\">\n"
               "  <UnstructuredGrid>\n"
               "    <FieldData>\n"
               "      <DataArray type=\"Float64\" Name=\"TimeValue\" NumberOfTuples=\"1\" "
               "format=\"ascii\">%.17g</DataArray>\n"
               "    </FieldData>\n"
               "    <Piece NumberOfPoints=\"%d\" NumberOfCells=\"%lld\">\n",
            little_endian() ? "LittleEndian" : "BigEndian", time, (int)nv, (long long)c->ncells);
    if (v || point_extra) {
        fprintf(f, v ? "      <PointData Vectors=\"velocity\">\n" : "      <PointData>\n");
        if (v) array_tag(f, "velocity", 3, o_v);
        for (int k = 0; k < n_extra; ++k)
            if (!extra[k].cell) array_tag(f, extra[k].name, extra[k].components, o_extra[k]);
        fprintf(f, "      </PointData>\n");
    }
    fprintf(f, "      <CellData Scalars=\"body\">\n"
               "        <DataArray type=\"Int32\" Name=\"body\" format=\"appended\" "
               "offset=\"%llu\"/>\n", (unsigned long long)o_body);
    for (int k = 0; k < n_extra; ++k)
        if (extra[k].cell) array_tag(f, extra[k].name, extra[k].components, o_extra[k]);
    fprintf(f, "      </CellData>\n"
               "      <Points>\n"
               "        <DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" "
               "format=\"appended\" offset=\"%llu\"/>\n"
               "      </Points>\n"
               "      <Cells>\n"
               "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\" "
               "offset=\"%llu\"/>\n"
               "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"appended\" "
               "offset=\"%llu\"/>\n"
               "        <DataArray type=\"UInt8\" Name=\"types\" format=\"appended\" "
               "offset=\"%llu\"/>\n"
               "      </Cells>\n"
               "    </Piece>\n"
               "  </UnstructuredGrid>\n"
               "  <AppendedData encoding=\"raw\">\n   _",
            (unsigned long long)o_x, (unsigned long long)o_conn,
            (unsigned long long)o_off, (unsigned long long)o_typ);
    int ok = !v || put_block(f, v, bx);
    for (int k = 0; k < n_extra && ok; ++k) ok = put_block(f, extra[k].data, b_extra[k]);
    ok = ok && put_block(f, c->body, bbody) && put_block(f, x, bx) &&
         put_block(f, c->conn, bconn) && put_block(f, c->offsets, boff) &&
         put_block(f, c->types, btyp);
    fputs("\n  </AppendedData>\n</VTKFile>\n", f);
    return tools_tmp_commit(f, tmp, path, ok, err, errsz);
}

int vtk_write_pvd(const char *path, int n, const double *times, const char *const *files,
                  char *err, size_t errsz)
{
    char tmp[2200];
    FILE *f = tools_tmp_open(path, tmp, sizeof tmp, err, errsz);
    if (!f) return -1;
    fprintf(f, "<?xml version=\"1.0\"?>\n"
               "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"%s\">\n"
               "  <Collection>\n", little_endian() ? "LittleEndian" : "BigEndian");
    for (int i = 0; i < n; ++i)
        fprintf(f, "    <DataSet timestep=\"%.17g\" group=\"\" part=\"0\" file=\"%s\"/>\n",
                times[i], files[i]);
    fputs("  </Collection>\n</VTKFile>\n", f);
    return tools_tmp_commit(f, tmp, path, 1, err, errsz);
}

/* ------------------------------------------------------------------------------------------ */
/* Reading back */

/* Value of attribute `name` inside the tag that starts at `tag` (up to its '>'). */
static int attr(const char *tag, const char *name, char *out, size_t size)
{
    const char *end = strchr(tag, '>');
    size_t nl = strlen(name);
    for (const char *p = tag; p && p < end; ++p) {
        if (strncmp(p, name, nl) == 0 && p[nl] == '=' && p[nl + 1] == '"' && p > tag &&
            (p[-1] == ' ' || p[-1] == '\n' || p[-1] == '\t')) {
            const char *q = p + nl + 2, *e = strchr(q, '"');
            if (!e || e > end) return 0;
            snprintf(out, size, "%.*s", (int)(e - q), q);
            return 1;
        }
    }
    return 0;
}

/* The appended block of the DataArray named `name`: pointer and byte count. */
static const uint8_t *block(const char *xml, const uint8_t *data, const uint8_t *data_end,
                            const char *name, uint64_t *bytes)
{
    char want[80], val[64];
    snprintf(want, sizeof want, "Name=\"%s\"", name);
    const char *p = strstr(xml, want);
    if (!p) return NULL;
    while (p > xml && *p != '<') --p;
    if (!attr(p, "offset", val, sizeof val) || !attr(p, "format", want, sizeof want) ||
        strcmp(want, "appended") != 0)
        return NULL;
    const uint64_t off = strtoull(val, NULL, 10);
    if (off + 8 > (uint64_t)(data_end - data)) return NULL;
    memcpy(bytes, data + off, 8);
    if (*bytes > (uint64_t)(data_end - data) - off - 8) return NULL;
    return data + off + 8;
}

int vtk_read_vtu(const char *path, vtk_frame *out, char *err, size_t errsz)
{
    memset(out, 0, sizeof *out);
    size_t len;
    char *buf = tools_read_file(path, &len);
    if (!buf) return set_err(err, errsz, "%s: cannot read: %s", path, strerror(errno));
    int rc = -1;
    char *app = strstr(buf, "<AppendedData encoding=\"raw\">");
    char *us = app ? strchr(app, '_') : NULL;
    if (!us || !strstr(buf, "header_type=\"UInt64\"") ||
        !strstr(buf, little_endian() ? "LittleEndian" : "BigEndian")) {
        set_err(err, errsz, "%s: not a .vtu written by defsim (raw appended, UInt64 headers, "
                            "this machine's byte order)", path);
        goto done;
    }
    *app = '\0';   /* the XML part ends here */
    const uint8_t *data = (const uint8_t *)us + 1, *end = (const uint8_t *)buf + len;
    char val[64];
    const char *piece = strstr(buf, "<Piece");
    if (!piece || !attr(piece, "NumberOfPoints", val, sizeof val)) {
        set_err(err, errsz, "%s: no <Piece NumberOfPoints=...>", path);
        goto done;
    }
    const long long nv = strtoll(val, NULL, 10);
    if (!attr(piece, "NumberOfCells", val, sizeof val)) {
        set_err(err, errsz, "%s: no NumberOfCells", path);
        goto done;
    }
    const long long nc = strtoll(val, NULL, 10);
    const char *tv = strstr(buf, "Name=\"TimeValue\"");
    if (tv && (tv = strchr(tv, '>'))) out->time = strtod(tv + 1, NULL);
    uint64_t bx, bconn, boff, btyp, bbody;
    const uint8_t *px = block(buf, data, end, "Points", &bx);
    const uint8_t *pconn = block(buf, data, end, "connectivity", &bconn);
    const uint8_t *poff = block(buf, data, end, "offsets", &boff);
    const uint8_t *ptyp = block(buf, data, end, "types", &btyp);
    const uint8_t *pbody = block(buf, data, end, "body", &bbody);
    if (nv < 0 || nv > INT32_MAX / 3 || nc < 0 || !px || !pconn || !poff || !ptyp || !pbody ||
        bx != 3 * (uint64_t)nv * 8 || boff != (uint64_t)nc * 8 || btyp != (uint64_t)nc ||
        bbody != (uint64_t)nc * 4 || bconn % 8) {
        set_err(err, errsz, "%s: missing or inconsistent data arrays", path);
        goto done;
    }
    out->nv = (int32_t)nv;
    vtk_cells *c = &out->cells;
    c->ncells = nc;
    c->nconn = (int64_t)(bconn / 8);
    out->x = malloc(bx ? bx : 1);
    c->conn = malloc(bconn ? bconn : 1);
    c->offsets = malloc(boff ? boff : 1);
    c->types = malloc(btyp ? btyp : 1);
    c->body = malloc(bbody ? bbody : 1);
    if (!out->x || !c->conn || !c->offsets || !c->types || !c->body) goto oom;
    memcpy(out->x, px, bx);
    memcpy(c->conn, pconn, bconn);
    memcpy(c->offsets, poff, boff);
    memcpy(c->types, ptyp, btyp);
    memcpy(c->body, pbody, bbody);
    /* Optional arrays the renderer colours by; a wrong size is an error, absence is not. */
    uint64_t bvm = 0, bdisp = 0;
    const uint8_t *pvm = block(buf, data, end, "von_mises", &bvm);
    const uint8_t *pdisp = block(buf, data, end, "displacement", &bdisp);
    if ((pvm && bvm != (uint64_t)nc * 8) || (pdisp && bdisp != bx)) {
        set_err(err, errsz, "%s: von_mises or displacement has the wrong size", path);
        goto done;
    }
    if (pvm && !(out->von_mises = malloc(bvm ? bvm : 1))) goto oom;
    if (pdisp && !(out->displacement = malloc(bdisp ? bdisp : 1))) goto oom;
    if (pvm) memcpy(out->von_mises, pvm, bvm);
    if (pdisp) memcpy(out->displacement, pdisp, bdisp);
    int64_t prev = 0;
    for (int64_t i = 0; i < nc; ++i) {
        const int64_t k = c->offsets[i] - prev;
        const int want = c->types[i] == VTK_TETRA ? 4 : c->types[i] == VTK_TRIANGLE ? 3
                         : c->types[i] == VTK_LINE ? 2 : -1;
        if (k != want || c->offsets[i] > c->nconn) {
            set_err(err, errsz, "%s: cell %lld: unsupported type %d or bad offsets", path,
                    (long long)i, (int)c->types[i]);
            goto done;
        }
        for (int64_t a = prev; a < c->offsets[i]; ++a)
            if (c->conn[a] < 0 || c->conn[a] >= nv) {
                set_err(err, errsz, "%s: cell %lld refers to point %lld of %lld", path,
                        (long long)i, (long long)c->conn[a], nv);
                goto done;
            }
        prev = c->offsets[i];
    }
    rc = 0;
    goto done;
oom:
    set_err(err, errsz, "%s: out of memory", path);
done:
    free(buf);
    if (rc) vtk_frame_free(out);
    return rc;
}

void vtk_frame_free(vtk_frame *f)
{
    free(f->x);
    free(f->von_mises);
    free(f->displacement);
    vtk_cells_free(&f->cells);
    memset(f, 0, sizeof *f);
}

int vtk_read_pvd(const char *path, char ***files, double **times, char *err, size_t errsz)
{
    *files = NULL;
    *times = NULL;
    size_t len;
    char *buf = tools_read_file(path, &len);
    if (!buf) return set_err(err, errsz, "%s: cannot read: %s", path, strerror(errno));
    int n = 0, cap = 0;
    char **f = NULL;
    double *t = NULL;
    for (const char *p = strstr(buf, "<DataSet"); p; p = strstr(p + 1, "<DataSet")) {
        char file[1024], ts[64];
        if (!attr(p, "file", file, sizeof file) || !attr(p, "timestep", ts, sizeof ts)) {
            for (int i = 0; i < n; ++i) free(f[i]);
            free(f); free(t); free(buf);
            return set_err(err, errsz, "%s: <DataSet> without file or timestep", path);
        }
        if (n == cap) {
            cap = cap ? 2 * cap : 64;
            char **nf = realloc(f, (size_t)cap * sizeof *nf);
            double *nt = nf ? realloc(t, (size_t)cap * sizeof *nt) : NULL;
            if (nf) f = nf;
            if (nt) t = nt;
            if (!nf || !nt) {
                for (int i = 0; i < n; ++i) free(f[i]);
                free(f); free(t); free(buf);
                return set_err(err, errsz, "out of memory");
            }
        }
        f[n] = strdup(file);
        t[n] = strtod(ts, NULL);
        ++n;
    }
    free(buf);
    *files = f;
    *times = t;
    return n;
}

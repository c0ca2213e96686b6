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

int vtk_check_cells(int32_t nv, int64_t ncells, const uint8_t *types, const int64_t *offsets,
                    const int64_t *conn, int64_t *nconn, char *err, size_t errsz)
{
    int64_t prev = 0;
    for (int64_t c = 0; c < ncells; ++c) {
        const int k = vtk_cell_size(types[c]);
        if (!k)
            return set_err(err, errsz, "cell %lld: type %d is not a line (3), triangle (5), "
                           "tet (10) or quadratic tet (24)", (long long)c, (int)types[c]);
        if (offsets[c] - prev != k)
            return set_err(err, errsz, "cell %lld: offsets give %lld vertices, its type %d",
                           (long long)c, (long long)(offsets[c] - prev), k);
        for (int64_t j = prev; j < offsets[c]; ++j)
            if (conn[j] < 0 || conn[j] >= nv)
                return set_err(err, errsz, "cell %lld: vertex %lld out of range [0, %d)",
                               (long long)c, (long long)conn[j], (int)nv);
        prev = offsets[c];
    }
    *nconn = prev;
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

/* Appended data is base64 (VTK's encoding="base64"): each block is a UInt64 byte count
 * encoded on its own (12 characters) followed by the bytes encoded on their own, and offsets
 * count characters. Raw binary would be smaller, but text readers (meshio) strip or split it at
 * bytes that look like whitespace, which small meshes hit. */
static const char b64_chars[] =
    "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

static uint64_t b64_len(uint64_t bytes) { return 4 * ((bytes + 2) / 3); }

/* Encoded size of a block: header and data. */
static uint64_t block_len(uint64_t bytes) { return b64_len(8) + b64_len(bytes); }

static int put_b64(FILE *f, const uint8_t *p, uint64_t n)
{
    char out[4 * 1024];
    size_t k = 0;
    for (uint64_t i = 0; i < n; i += 3) {
        const uint32_t a = p[i], b = i + 1 < n ? p[i + 1] : 0, c = i + 2 < n ? p[i + 2] : 0;
        const uint32_t v = a << 16 | b << 8 | c;
        out[k++] = b64_chars[v >> 18 & 63];
        out[k++] = b64_chars[v >> 12 & 63];
        out[k++] = i + 1 < n ? b64_chars[v >> 6 & 63] : '=';
        out[k++] = i + 2 < n ? b64_chars[v & 63] : '=';
        if (k == sizeof out) {
            if (fwrite(out, 1, k, f) != k) return 0;
            k = 0;
        }
    }
    return k == 0 || fwrite(out, 1, k, f) == k;
}

static int put_block(FILE *f, const void *data, uint64_t bytes)
{
    return put_b64(f, (const uint8_t *)&bytes, sizeof bytes) && put_b64(f, data, bytes);
}

static void array_tag(FILE *f, const char *type, const char *name, int components,
                      uint64_t offset)
{
    fprintf(f, "        <DataArray type=\"%s\" Name=\"%s\" NumberOfComponents=\"%d\" "
               "format=\"appended\" offset=\"%llu\"/>\n", type, name, components,
            (unsigned long long)offset);
}

static const char *array_type(const vtk_array *a) { return a->u8 ? "UInt8" : "Float64"; }

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
    if (v) { o_v = o; o += block_len(bx); }
    int point_extra = 0;
    for (int k = 0; k < n_extra; ++k) {
        b_extra[k] = (uint64_t)extra[k].components * (extra[k].u8 ? 1 : sizeof(double)) *
                     (extra[k].cell ? (uint64_t)c->ncells : (uint64_t)nv);
        o_extra[k] = o;
        o += block_len(b_extra[k]);
        point_extra += !extra[k].cell;
    }
    o_body = o; o += block_len(bbody);
    o_x = o; o += block_len(bx);
    o_conn = o; o += block_len(bconn);
    o_off = o; o += block_len(boff);
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
        if (v) array_tag(f, "Float64", "velocity", 3, o_v);
        for (int k = 0; k < n_extra; ++k)
            if (!extra[k].cell)
                array_tag(f, array_type(&extra[k]), extra[k].name, extra[k].components, o_extra[k]);
        fprintf(f, "      </PointData>\n");
    }
    const char *tag = c->tag ? c->tag : "body";
    fprintf(f, "      <CellData Scalars=\"%s\">\n"
               "        <DataArray type=\"Int32\" Name=\"%s\" format=\"appended\" "
               "offset=\"%llu\"/>\n", tag, tag, (unsigned long long)o_body);
    for (int k = 0; k < n_extra; ++k)
        if (extra[k].cell)
            array_tag(f, array_type(&extra[k]), extra[k].name, extra[k].components, o_extra[k]);
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
               "  <AppendedData encoding=\"base64\">\n   _",
            (unsigned long long)o_x, (unsigned long long)o_conn,
            (unsigned long long)o_off, (unsigned long long)o_typ);
    int ok = !v || put_block(f, v, bx);
    for (int k = 0; k < n_extra && ok; ++k)
        ok = put_block(f, extra[k].u8 ? (const void *)extra[k].u8 : (const void *)extra[k].data,
                       b_extra[k]);
    ok = ok && put_block(f, c->body, bbody) && put_block(f, x, bx) &&
         put_block(f, c->conn, bconn) && put_block(f, c->offsets, boff) &&
         put_block(f, c->types, btyp);
    fputs("\n  </AppendedData>\n</VTKFile>\n", f);
    return tools_tmp_commit(f, tmp, path, ok, err, errsz);
}

/* An index of datasets (atomically): a .pvd collection (times: each entry's timestep) or a
 * .vtm multiblock (names: each entry's block name). */
static int write_index(const char *path, const char *type, const char *version, const char *tag,
                       int n, const char *const *names, const double *times,
                       const char *const *files, char *err, size_t errsz)
{
    char tmp[2200];
    FILE *f = tools_tmp_open(path, tmp, sizeof tmp, err, errsz);
    if (!f) return -1;
    fprintf(f, "<?xml version=\"1.0\"?>\n"
               "<VTKFile type=\"%s\" version=\"%s\" byte_order=\"%s\">\n"
               "  <%s>\n", type, version, little_endian() ? "LittleEndian" : "BigEndian", tag);
    for (int i = 0; i < n; ++i) {
        if (times)
            fprintf(f, "    <DataSet timestep=\"%.17g\" group=\"\" part=\"0\" file=\"%s\"/>\n",
                    times[i], files[i]);
        else
            fprintf(f, "    <DataSet index=\"%d\" name=\"%s\" file=\"%s\"/>\n", i, names[i],
                    files[i]);
    }
    fprintf(f, "  </%s>\n</VTKFile>\n", tag);
    return tools_tmp_commit(f, tmp, path, 1, err, errsz);
}

int vtk_write_vtm(const char *path, int n, const char *const *names, const char *const *files,
                  char *err, size_t errsz)
{
    return write_index(path, "vtkMultiBlockDataSet", "1.0", "vtkMultiBlockDataSet", n, names,
                       NULL, files, err, errsz);
}

int vtk_write_pvd(const char *path, int n, const double *times, const char *const *files,
                  char *err, size_t errsz)
{
    return write_index(path, "Collection", "0.1", "Collection", n, NULL, times, files, err,
                       errsz);
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

static int b64_value(uint8_t ch)
{
    if (ch >= 'A' && ch <= 'Z') return ch - 'A';
    if (ch >= 'a' && ch <= 'z') return ch - 'a' + 26;
    if (ch >= '0' && ch <= '9') return ch - '0' + 52;
    return ch == '+' ? 62 : ch == '/' ? 63 : -1;
}

/* Decodes `chars` characters (a multiple of 4, '=' padding at the end only) at p into out,
 * which has room for 3 chars / 4 bytes. Returns the byte count, or -1 for bad input. */
static int64_t b64_decode(const uint8_t *p, uint64_t chars, uint8_t *out)
{
    uint64_t n = 0;
    for (uint64_t i = 0; i + 4 <= chars; i += 4) {
        int v[4], pad = 0;
        for (int k = 0; k < 4; ++k) {
            v[k] = p[i + k] == '=' && k >= 2 ? (++pad, 0) : b64_value(p[i + k]);
            if (v[k] < 0 || (pad && p[i + k] != '=')) return -1;
        }
        if (pad && i + 4 != chars) return -1;
        const uint32_t w = (uint32_t)v[0] << 18 | (uint32_t)v[1] << 12 | (uint32_t)v[2] << 6 |
                           (uint32_t)v[3];
        out[n++] = (uint8_t)(w >> 16);
        if (pad < 2) out[n++] = (uint8_t)(w >> 8);
        if (pad < 1) out[n++] = (uint8_t)w;
    }
    return (int64_t)n;
}

/* The appended block of the DataArray named `name` in `section` ("" for any): a malloc'd copy
 * of its bytes and their count; NULL when absent or malformed (*bad set when malformed). */
static uint8_t *block(const char *xml, const uint8_t *data, const uint8_t *data_end, int base64,
                      const char *name, uint64_t *bytes, int *bad)
{
    char want[80], val[64];
    snprintf(want, sizeof want, "Name=\"%s\"", name);
    const char *p = strstr(xml, want);
    if (!p) return NULL;
    while (p > xml && *p != '<') --p;
    if (!attr(p, "offset", val, sizeof val) || !attr(p, "format", want, sizeof want) ||
        strcmp(want, "appended") != 0) {
        *bad = 1;
        return NULL;
    }
    const uint64_t off = strtoull(val, NULL, 10), avail = (uint64_t)(data_end - data);
    uint8_t head[9];
    if (base64) {
        if (off > avail || avail - off < b64_len(8) || b64_decode(data + off, b64_len(8), head) != 8)
            goto malformed;
    } else {
        if (off > avail || avail - off < 8) goto malformed;
        memcpy(head, data + off, 8);
    }
    memcpy(bytes, head, 8);
    const uint64_t start = off + (base64 ? b64_len(8) : 8);
    const uint64_t len = base64 ? b64_len(*bytes) : *bytes;
    if (*bytes > avail || len > avail - start) goto malformed;
    uint8_t *out = malloc(*bytes + 3);
    if (!out) goto malformed;
    if (base64 ? b64_decode(data + start, len, out) != (int64_t)*bytes
               : (memcpy(out, data + start, *bytes), 0)) {
        free(out);
        goto malformed;
    }
    return out;
malformed:
    *bad = 1;
    return NULL;
}

int vtk_read_vtu(const char *path, vtk_frame *out, char *err, size_t errsz)
{
    memset(out, 0, sizeof *out);
    size_t len;
    char *buf = tools_read_file(path, &len);
    if (!buf) return set_err(err, errsz, "%s: cannot read: %s", path, strerror(errno));
    int rc = -1, bad = 0;
    uint8_t *px = NULL, *pconn = NULL, *poff = NULL, *ptyp = NULL, *pbody = NULL;
    /* base64 (written since issue 16) or raw (earlier files). */
    char *app = strstr(buf, "<AppendedData encoding=\"base64\">");
    const int base64 = app != NULL;
    if (!app) app = strstr(buf, "<AppendedData encoding=\"raw\">");
    char *us = app ? strchr(app, '_') : NULL;
    if (!us || !strstr(buf, "header_type=\"UInt64\"") ||
        !strstr(buf, little_endian() ? "LittleEndian" : "BigEndian")) {
        set_err(err, errsz, "%s: not a .vtu written by defsim (appended base64 or raw data, "
                            "UInt64 headers, this machine's byte order)", path);
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
    uint64_t bx = 0, bconn = 0, boff = 0, btyp = 0, bbody = 0;
    px = block(buf, data, end, base64, "Points", &bx, &bad);
    pconn = block(buf, data, end, base64, "connectivity", &bconn, &bad);
    poff = block(buf, data, end, base64, "offsets", &boff, &bad);
    ptyp = block(buf, data, end, base64, "types", &btyp, &bad);
    pbody = block(buf, data, end, base64, "body", &bbody, &bad);
    if (bad || nv < 0 || nv > INT32_MAX / 3 || nc < 0 || !px || !pconn || !poff || !ptyp ||
        !pbody || bx != 3 * (uint64_t)nv * 8 || boff != (uint64_t)nc * 8 ||
        btyp != (uint64_t)nc || bbody != (uint64_t)nc * 4 || bconn % 8) {
        set_err(err, errsz, "%s: missing or inconsistent data arrays", path);
        goto done;
    }
    out->nv = (int32_t)nv;
    vtk_cells *c = &out->cells;
    c->ncells = nc;
    c->nconn = (int64_t)(bconn / 8);
    out->x = (double *)px;
    c->conn = (int64_t *)pconn;
    c->offsets = (int64_t *)poff;
    c->types = ptyp;
    c->body = (int32_t *)pbody;
    px = pconn = poff = ptyp = pbody = NULL;
    /* Optional arrays the renderer colours by or draws; a wrong size is an error, absence is
     * not. */
    uint64_t bvm = 0, bdisp = 0, bvel = 0, bpin = 0, bcf = 0;
    out->von_mises = (double *)block(buf, data, end, base64, "von_mises", &bvm, &bad);
    out->displacement = (double *)block(buf, data, end, base64, "displacement", &bdisp, &bad);
    out->velocity = (double *)block(buf, data, end, base64, "velocity", &bvel, &bad);
    out->pinned = block(buf, data, end, base64, "pinned", &bpin, &bad);
    out->contact_force = (double *)block(buf, data, end, base64, "contact_force", &bcf, &bad);
    if (bad || (out->von_mises && bvm != (uint64_t)nc * 8) ||
        (out->displacement && bdisp != bx) || (out->velocity && bvel != bx) ||
        (out->pinned && bpin != (uint64_t)nv) || (out->contact_force && bcf != bx)) {
        set_err(err, errsz, "%s: von_mises, displacement, velocity, pinned or contact_force is "
                            "malformed or has the wrong size", path);
        goto done;
    }
    int64_t prev = 0;
    for (int64_t i = 0; i < nc; ++i) {
        const int64_t k = c->offsets[i] - prev;
        const int want = vtk_cell_size(c->types[i]) ? vtk_cell_size(c->types[i]) : -1;
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
done:
    free(px); free(pconn); free(poff); free(ptyp); free(pbody);
    free(buf);
    if (rc) vtk_frame_free(out);
    return rc;
}

void vtk_frame_free(vtk_frame *f)
{
    free(f->x);
    free(f->von_mises);
    free(f->displacement);
    free(f->velocity);
    free(f->pinned);
    free(f->contact_force);
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

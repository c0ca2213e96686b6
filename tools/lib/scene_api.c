/* SPDX-License-Identifier: MIT */
/* libdefsim_scene (include/defsim/scene.h): the tools' scene loader and VTK writer behind a small
 * checked C API, so that bindings reuse them instead of re-implementing them. */
#include <defsim/scene.h>

#include "api_error.h"
#include "fields.h"
#include "frame.h"
#include "scene.h"
#include "vtk.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct defsim_scene {
    scene s;
    defsim_world *world;    /* the world scene_build made (owned by the caller), or NULL */
    char error[4096];
};

/* defsim_scene_load and defsim_scene_load_string: the arguments' checks, then the file (path)
 * or the text (json, len). */
static defsim_status load(const char *fn, const char *path, const char *json, size_t len,
                          const char *label, const char *dir, const char *const *overrides,
                          int32_t count, defsim_scene **out, char *err, size_t errsz)
{
    if (err && errsz > 0) err[0] = '\0';
    if (out) *out = NULL;
    if ((!path && !json) || !out || count < 0 || (count > 0 && !overrides))
        return api_fail(err, errsz, DEFSIM_ERR_INVALID_ARGUMENT,
                        "%s: NULL %s or out, or count < 0 with no overrides", fn,
                        json || !label ? "path" : "json");
    for (int32_t i = 0; i < count; ++i)
        if (!overrides[i])
            return api_fail(err, errsz, DEFSIM_ERR_INVALID_ARGUMENT, "%s: override %d is NULL",
                            fn, (int)i);
    defsim_scene *sc = calloc(1, sizeof *sc);
    if (!sc) return api_fail(err, errsz, DEFSIM_ERR_OUT_OF_MEMORY, "out of memory");
    const int rc = path ? scene_load(&sc->s, path, overrides, count)
                        : scene_load_string(&sc->s, json, len, label, dir, overrides, count);
    if (rc != 0) {
        const defsim_status st = sc->s.io_failure ? DEFSIM_ERR_IO : DEFSIM_ERR_INVALID_ARGUMENT;
        api_fail(err, errsz, st, "%s", sc->s.error);
        free(sc);
        return st;
    }
    *out = sc;
    return DEFSIM_OK;
}

defsim_status defsim_scene_load(const char *path, const char *const *overrides, int32_t count,
                                defsim_scene **out, char *err, size_t errsz)
{
    return load("defsim_scene_load", path, NULL, 0, NULL, NULL, overrides, count, out, err,
                errsz);
}

defsim_status defsim_scene_load_string(const char *json, size_t len, const char *label,
                                       const char *dir, const char *const *overrides,
                                       int32_t count, defsim_scene **out, char *err, size_t errsz)
{
    return load("defsim_scene_load_string", NULL, json, len, label ? label : "<string>", dir,
                overrides, count, out, err, errsz);
}

defsim_status defsim_scene_export(const defsim_world *world, const defsim_scene *sc, double h,
                                  double duration, char **json, size_t *length, char *err,
                                  size_t errsz)
{
    if (json) *json = NULL;
    if (length) *length = 0;
    if (!world || !json)
        return api_fail(err, errsz, DEFSIM_ERR_INVALID_ARGUMENT,
                        "defsim_scene_export: NULL world or json");
    if (sc && sc->world != world)
        return api_fail(err, errsz, DEFSIM_ERR_INVALID_ARGUMENT,
                        "defsim_scene_export: the scene did not build this world");
    return scene_export(sc ? &sc->s : NULL, world, h, duration, json, length, err, errsz);
}

void defsim_scene_string_free(char *json)
{
    free(json);
}

void defsim_scene_free(defsim_scene *sc)
{
    if (!sc) return;
    scene_free(&sc->s);
    free(sc);
}

const char *defsim_scene_last_error(const defsim_scene *sc)
{
    return sc ? sc->error : "";
}

defsim_status defsim_scene_build(defsim_scene *sc, defsim_world **out)
{
    if (out) *out = NULL;
    if (!sc || !out) return DEFSIM_ERR_INVALID_ARGUMENT;
    sc->error[0] = '\0';
    if (sc->world) {
        snprintf(sc->error, sizeof sc->error, "defsim_scene_build: the scene was built before "
                                              "(load it again for a second world)");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    sc->s.error[0] = '\0';
    const defsim_status st = scene_build(&sc->s, &sc->world);
    if (st != DEFSIM_OK) {
        snprintf(sc->error, sizeof sc->error, "%s", sc->s.error);
        sc->world = NULL;
        return st;
    }
    *out = sc->world;
    return DEFSIM_OK;
}

defsim_status defsim_scene_step(defsim_scene *sc, defsim_world *w, double h)
{
    if (!sc) return DEFSIM_ERR_INVALID_ARGUMENT;
    sc->error[0] = '\0';
    if (!w || w != sc->world) {
        snprintf(sc->error, sizeof sc->error, "defsim_scene_step: %s",
                 !w ? "world is NULL" : sc->world ? "not the world this scene built"
                                                  : "the scene is not built");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    const defsim_status st = scene_step(&sc->s, w, h);
    if (st != DEFSIM_OK) snprintf(sc->error, sizeof sc->error, "%s", defsim_world_last_error(w));
    return st;
}

defsim_status defsim_scene_get_info(const defsim_scene *sc, defsim_scene_info *out)
{
    if (!sc || !out || out->size < offsetof(defsim_scene_info, gravity) + sizeof out->gravity)
        return DEFSIM_ERR_INVALID_ARGUMENT;
    defsim_scene_info r;
    memset(&r, 0, sizeof r);
    r.name = sc->s.name;
    r.backend = sc->s.def.backend ? sc->s.def.backend : sc->s.backend;
    r.step = sc->s.h;
    r.duration = sc->s.duration;
    r.frame_steps = sc->s.frame_steps;
    r.frames = sc->s.frames;
    r.body_count = sc->s.nbodies;
    r.vertex_count = sc->s.vertex_count;
    memcpy(r.gravity, sc->s.def.gravity, sizeof r.gravity);
    r.size = out->size;
    memcpy(out, &r, out->size < sizeof r ? out->size : sizeof r);
    return DEFSIM_OK;
}

defsim_status defsim_scene_get_body(const defsim_scene *sc, int32_t i, defsim_scene_body *out)
{
    if (!sc || !out || i < 0 || i >= sc->s.nbodies ||
        out->size < offsetof(defsim_scene_body, vertex_offset) + sizeof out->vertex_offset)
        return DEFSIM_ERR_INVALID_ARGUMENT;
    const scene_body *b = &sc->s.bodies[i];
    defsim_scene_body r;
    memset(&r, 0, sizeof r);
    r.name = b->name;
    r.mesh = &b->mesh;
    r.line_count = b->line_count;
    memcpy(r.color, b->color, sizeof r.color);
    if (sc->world) {
        r.id = b->id;
        r.vertex_offset = b->offset;
    }
    r.size = out->size;
    memcpy(out, &r, out->size < sizeof r ? out->size : sizeof r);
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* VTK */

static int good_name(const char *s)
{
    if (!s || !*s) return 0;
    for (; *s; ++s)
        if (!((*s >= 'a' && *s <= 'z') || (*s >= 'A' && *s <= 'Z') || (*s >= '0' && *s <= '9') ||
              *s == '_'))
            return 0;
    return 1;
}

/* Cells as defsim_vtk_write_vtu takes them (vtk_check_cells); *nconn receives the length of
 * conn. */
static defsim_status check_cells(int32_t nv, int64_t ncells, const uint8_t *types,
                                 const int64_t *offsets, const int64_t *conn, int64_t *nconn,
                                 char *err, size_t errsz)
{
    char msg[256];
    if (vtk_check_cells(nv, ncells, types, offsets, conn, nconn, msg, sizeof msg))
        return api_fail(err, errsz, DEFSIM_ERR_INVALID_ARGUMENT, "%s", msg);
    return DEFSIM_OK;
}

defsim_status defsim_vtk_write_vtu(const char *path, int32_t nv, const double *x, const double *v,
                                   int64_t ncells, const uint8_t *types, const int64_t *offsets,
                                   const int64_t *conn, const int32_t *body, double time,
                                   const defsim_vtk_array *arrays, int32_t count, char *err,
                                   size_t errsz)
{
    enum { MAX_ARRAYS = 16 };
    const defsim_status bad = DEFSIM_ERR_INVALID_ARGUMENT;
    if (err && errsz > 0) err[0] = '\0';
    if (!path || nv < 0 || (nv > 0 && !x) || ncells < 0 ||
        (ncells > 0 && (!types || !offsets || !conn)) || count < 0 || count > MAX_ARRAYS ||
        (count > 0 && !arrays))
        return api_fail(err, errsz, bad, "defsim_vtk_write_vtu: NULL argument or negative count "
                                     "(at most %d arrays)", MAX_ARRAYS);
    int64_t prev = 0;
    const defsim_status cst = check_cells(nv, ncells, types, offsets, conn, &prev, err, errsz);
    if (cst != DEFSIM_OK) return cst;
    vtk_array extra[MAX_ARRAYS];
    memset(extra, 0, sizeof extra);   /* fields the tools' struct may grow stay zero */
    for (int32_t k = 0; k < count; ++k) {
        const defsim_vtk_array *a = &arrays[k];
        if (!good_name(a->name) || !a->data || (a->cell != 0 && a->cell != 1) ||
            (a->components != 1 && a->components != 3 && a->components != 6 && a->components != 9))
            return api_fail(err, errsz, bad, "array %d: needs a name of letters, digits and '_', "
                                         "data, cell 0 or 1 and 1, 3, 6 or 9 components", (int)k);
        extra[k].name = a->name;
        extra[k].components = a->components;
        extra[k].cell = a->cell;
        extra[k].data = a->data;
    }
    int32_t *zeros = NULL;
    if (!body) {
        zeros = calloc((size_t)(ncells > 0 ? ncells : 1), sizeof *zeros);
        if (!zeros) return api_fail(err, errsz, DEFSIM_ERR_OUT_OF_MEMORY, "out of memory");
    }
    /* The writer only reads the cells; the casts drop const for its struct. */
    vtk_cells cells;
    memset(&cells, 0, sizeof cells);
    cells.conn = (int64_t *)conn;
    cells.offsets = (int64_t *)offsets;
    cells.types = (uint8_t *)types;
    cells.body = body ? (int32_t *)body : zeros;
    cells.ncells = ncells;
    cells.nconn = prev;
    char msg[1024] = "";
    const int rc = vtk_write_vtu(path, nv, x, v, &cells, time, extra, count, msg, sizeof msg);
    free(zeros);
    if (rc != 0) return api_fail(err, errsz, DEFSIM_ERR_IO, "%s", msg);
    return DEFSIM_OK;
}

defsim_status defsim_vtk_write_pvd(const char *path, int32_t count, const double *times,
                                   const char *const *files, char *err, size_t errsz)
{
    if (err && errsz > 0) err[0] = '\0';
    if (!path || count < 0 || (count > 0 && (!times || !files)))
        return api_fail(err, errsz, DEFSIM_ERR_INVALID_ARGUMENT,
                    "defsim_vtk_write_pvd: NULL argument or count < 0");
    for (int32_t i = 0; i < count; ++i)
        if (!files[i] || strpbrk(files[i], "\"<>&"))
            return api_fail(err, errsz, DEFSIM_ERR_INVALID_ARGUMENT,
                        "defsim_vtk_write_pvd: file %d is NULL or has '\"', '<', '>' or '&'",
                        (int)i);
    char msg[1024] = "";
    if (vtk_write_pvd(path, count, times, files, msg, sizeof msg) != 0)
        return api_fail(err, errsz, DEFSIM_ERR_IO, "%s", msg);
    return DEFSIM_OK;
}

void defsim_vtk_frame_def_init(defsim_vtk_frame_def *def, size_t size)
{
    if (!def) return;
    defsim_vtk_frame_def d;
    memset(&d, 0, sizeof d);
    d.size = (uint32_t)sizeof d;
    d.fields = DEFSIM_VTK_ALL;
    if (size > sizeof d) size = sizeof d;
    memcpy(def, &d, size);
    def->size = (uint32_t)size;
}

defsim_status defsim_vtk_write_world(const char *path, defsim_world *w,
                                     const defsim_vtk_frame_def *def, double time,
                                     double *plane_out, int32_t *vtm, char *err, size_t errsz)
{
    const defsim_status bad = DEFSIM_ERR_INVALID_ARGUMENT;
    if (err && errsz > 0) err[0] = '\0';
    if (vtm) *vtm = 0;
    const size_t len = path ? strlen(path) : 0;
    if (!path || !w || !def || def->size != sizeof *def || def->cell_count < 0 ||
        (def->cell_count > 0 && (!def->types || !def->offsets || !def->conn || !def->body)))
        return api_fail(err, errsz, bad, "defsim_vtk_write_world: NULL argument, a def of the "
                                     "wrong size or a negative cell count");
    if (len < 4 || strcmp(path + len - 4, ".vtu") != 0)
        return api_fail(err, errsz, bad, "defsim_vtk_write_world: %s does not end in .vtu", path);
    const int32_t nv = defsim_world_vertex_count(w);
    int64_t nconn = 0;
    defsim_status st = check_cells(nv, def->cell_count, def->types, def->offsets, def->conn,
                                   &nconn, err, errsz);
    if (st != DEFSIM_OK) return st;
    vtk_cells cells;
    memset(&cells, 0, sizeof cells);
    cells.conn = (int64_t *)def->conn;
    cells.offsets = (int64_t *)def->offsets;
    cells.types = (uint8_t *)def->types;
    cells.body = (int32_t *)def->body;
    cells.ncells = def->cell_count;
    cells.nconn = nconn;
    /* The fields as defsim run evaluates them (fields.c), displacement from the reference. */
    const unsigned which =
        (def->fields & DEFSIM_VTK_STRESS ? (unsigned)SCENE_FIELD_STRESS : 0u) |
        (def->fields & DEFSIM_VTK_DISPLACEMENT && def->reference ? (unsigned)SCENE_FIELD_DISPLACEMENT : 0u) |
        (def->fields & DEFSIM_VTK_PIN_FORCES ? (unsigned)SCENE_FIELD_PIN_FORCES : 0u) |
        (def->fields & DEFSIM_VTK_ATTACHMENT_FORCES ? (unsigned)SCENE_FIELD_ATTACHMENT_FORCES : 0u) |
        (def->fields & DEFSIM_VTK_CONTACT_FORCES ? (unsigned)SCENE_FIELD_CONTACT_FORCES : 0u);
    fields fl;
    char msg[1024] = "";
    double *x = malloc(3 * (size_t)nv * sizeof *x + 1), *v = malloc(3 * (size_t)nv * sizeof *v + 1);
    if (!x || !v) {
        free(x);
        free(v);
        return api_fail(err, errsz, DEFSIM_ERR_OUT_OF_MEMORY, "out of memory");
    }
    if (fields_init(&fl, w, &cells, which, msg, sizeof msg)) {
        free(x);
        free(v);
        return api_fail(err, errsz, strstr(msg, "memory") ? DEFSIM_ERR_OUT_OF_MEMORY : bad, "%s",
                        msg);
    }
    if (def->reference) memcpy(fl.x0, def->reference, 3 * (size_t)nv * sizeof *fl.x0);
    frame_plane plane;
    if (def->plane_half > 0.0 && isfinite(def->plane_half)) {
        memcpy(plane.centre, def->plane_center, sizeof plane.centre);
        plane.half = def->plane_half;
    } else {
        frame_plane_extent(w, NULL, &plane);
    }
    int wrote_vtm = 0;
    st = DEFSIM_OK;
    if (defsim_world_get_positions(w, x, nv) != DEFSIM_OK ||
        defsim_world_get_velocities(w, v, nv) != DEFSIM_OK)
        st = api_fail(err, errsz, bad, "%s", defsim_world_last_error(w));
    else if (fields_eval(&fl, w, msg, sizeof msg))
        st = api_fail(err, errsz, bad, "%s", msg);
    else if (frame_write(path, w, x, v, &cells, &fl, time,
                         (def->fields & DEFSIM_VTK_COLLIDERS) != 0, &plane, &wrote_vtm, msg,
                         sizeof msg))
        st = api_fail(err, errsz, DEFSIM_ERR_IO, "%s", msg);
    fields_free(&fl);
    free(x);
    free(v);
    if (st == DEFSIM_OK && plane_out) {
        memcpy(plane_out, plane.centre, sizeof plane.centre);
        plane_out[3] = plane.half;
    }
    if (st == DEFSIM_OK && vtm) *vtm = wrote_vtm;
    return st;
}

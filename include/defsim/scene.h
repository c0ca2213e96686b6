/* SPDX-License-Identifier: MIT */
/** @file
 * libdefsim_scene: the scene files of `defsim run` and its VTK frames, for bindings and hosts.
 *
 * A second, optional library built from the tools' own code (tools/scene.c, tools/vtk.c), so
 * that Python and other hosts load the same JSON with the same parser and write the same .vtu
 * / .pvd files as `defsim run`. It links libdefsim and cJSON. The scene format is documented in
 * tools/README.md. Plain C11 that cffi can parse: explicit types, no macros or inline functions
 * needed to call it. Thread safety: a scene is used from one thread at a time; different scenes
 * are independent.
 */
#ifndef DEFSIM_SCENE_H
#define DEFSIM_SCENE_H

#include "defsim/defsim.h"

#ifdef __cplusplus
extern "C" {
#endif

/// A scene file loaded into memory: world settings, bodies (meshes, materials, pins, forces,
/// driven pins, attachments) and output settings. Opaque; made by defsim_scene_load.
typedef struct defsim_scene defsim_scene;

/// Reads and checks a scene file. `overrides` are `count` strings "key.path=JSON" applied before
/// the checks, as `defsim run --set` does (a value that is not JSON is taken as a string); it
/// may be NULL when count is 0. Relative mesh paths are taken from the scene file's folder.
/// On success *out receives the scene (free it with defsim_scene_free). On failure *out is NULL
/// and `err` (may be NULL; errsz bytes, always terminated) receives "file:line:col: what".
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL path or out, count < 0, a NULL override, or a
/// scene the parser rejects), DEFSIM_ERR_IO (the scene file, or a mesh file it names, cannot be
/// read: missing, not a regular file, too large; a mesh file that is malformed),
/// DEFSIM_ERR_OUT_OF_MEMORY.
DEFSIM_API defsim_status defsim_scene_load(const char *path, const char *const *overrides,
                                           int32_t count, defsim_scene **out, char *err,
                                           size_t errsz);

/// defsim_scene_load from JSON text instead of a file: `len` bytes at `json` (copied; need not
/// be terminated), named `label` in messages ("label:line:col: what"; NULL: "<string>"), with
/// relative mesh paths taken from the folder `dir` (NULL or "": the working directory). The
/// scene's name is the label's file name without ".json". Same overrides, ownership and errors
/// as defsim_scene_load (DEFSIM_ERR_IO only for a mesh file the scene names).
DEFSIM_API defsim_status defsim_scene_load_string(const char *json, size_t len, const char *label,
                                                  const char *dir,
                                                  const char *const *overrides, int32_t count,
                                                  defsim_scene **out, char *err, size_t errsz);

/// Writes the scene JSON of a world, which defsim_scene_load (or _load_string) reads back into a
/// world that steps to the same bits as `world` from its current state: the world's backend,
/// gravity, thread count and every option that differs from its default; each live body as the
/// library holds it (an "inline" mesh of its rest positions, tets, contact triangles and
/// springs, its masses and spring stiffnesses, material, pins, the current positions and
/// velocities as its initial state, held external forces, collision filter and friction);
/// attachments with their target vertices and weights; colliders at their poses (a mesh
/// collider's vertices and triangles inline). `scene` may be NULL; otherwise it must be the
/// scene that built `world` (defsim_scene_build): its body names and colours, its drives and the
/// keyed paths of its attachments and colliders are written too (not its output settings).
/// `h` and `duration` (s) are the run's, which a scene file needs and a world does not hold;
/// <= 0 takes the scene's. The world is not changed. Not expressible, and refused with
/// DEFSIM_ERR_UNSUPPORTED (err says which): an SDF collider (a host function), driven-pin
/// targets or a collider pose set for the next step (export before setting them or after the
/// step), a scene's keyed paths when the world's time is not 0 (a scene starts at t = 0). The
/// force callback and the log sink are host functions the world does not report: a host that
/// set a force callback must not expect it in the file (the Python binding refuses). What a
/// scene starts from is the state; a backend's history (multistep, adaptive) and contact's
/// carried state start afresh, so a world exported after steps continues to roundoff, not bit
/// for bit (a checkpoint continues bit for bit). On success *json receives NUL-terminated text
/// that the caller owns and releases with defsim_scene_string_free, and *length (may be NULL)
/// its length. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL world or json, h or duration not
/// finite and > 0 without a scene), DEFSIM_ERR_UNSUPPORTED, DEFSIM_ERR_LOCKED (from inside a
/// host callback), DEFSIM_ERR_OUT_OF_MEMORY; the reason in `err` (may be NULL).
DEFSIM_API defsim_status defsim_scene_export(const defsim_world *world, const defsim_scene *scene,
                                             double h, double duration, char **json,
                                             size_t *length, char *err, size_t errsz);

/// Releases text from defsim_scene_export. NULL is ignored.
DEFSIM_API void defsim_scene_string_free(char *json);

/// Frees a scene (NULL is ignored). A world it built stays valid and remains the caller's.
DEFSIM_API void defsim_scene_free(defsim_scene *scene);

/// Detail of the last failure of defsim_scene_build or defsim_scene_step on this scene, or "".
/// Borrowed: valid until the next call on the scene.
DEFSIM_API const char *defsim_scene_last_error(const defsim_scene *scene);

/// Creates the scene's world (backend, gravity, options), adds its bodies with their pins,
/// external forces, driven pins and attachments, exactly as `defsim run` does. Once per scene.
/// On success *out receives the world, owned by the caller (defsim_world_destroy); it must
/// outlive every defsim_scene_step on it. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, built
/// before), or the library's status for the option, body or attachment that failed (named by
/// defsim_scene_last_error).
DEFSIM_API defsim_status defsim_scene_build(defsim_scene *scene, defsim_world **out);

/// One step of h seconds: moves driven pins and keyframed attachment points to where their
/// paths are at t + h, then defsim_world_step. `world` must be the one this scene built.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, not built, another world), or the step's status
/// (the world is then as before the step, as defsim_world_step guarantees).
DEFSIM_API defsim_status defsim_scene_step(defsim_scene *scene, defsim_world *world, double h);

/// What a scene sets up. Strings are borrowed from the scene (valid until defsim_scene_free).
typedef struct defsim_scene_info {
    uint32_t size;          ///< Set by the caller to sizeof(defsim_scene_info).
    const char *name;       ///< File name without folder and ".json".
    const char *backend;    ///< Backend name.
    double step;            ///< Step size h, s.
    double duration;        ///< Simulated time of a run, s.
    int32_t frame_steps;    ///< Steps per output frame.
    int32_t frames;         ///< Frames after the initial state.
    int32_t body_count;     ///< Bodies (defsim_scene_get_body's range).
    int32_t vertex_count;   ///< Sum over bodies.
    double gravity[3];      ///< m/s^2.
} defsim_scene_info;

/// Fills *out (whose size must be set; fields beyond it are not written).
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, size too small).
DEFSIM_API defsim_status defsim_scene_get_info(const defsim_scene *scene, defsim_scene_info *out);

/// One body of a scene. Pointers are borrowed from the scene (valid until defsim_scene_free).
typedef struct defsim_scene_body {
    uint32_t size;              ///< Set by the caller to sizeof(defsim_scene_body).
    const char *name;           ///< "body<i>" unless the scene names it.
    const defsim_mesh *mesh;    ///< Rest mesh after "transform": positions, tets, triangles, springs.
    int32_t line_count;         ///< Springs drawn as lines: the first line_count of mesh->springs.
    float color[3];             ///< RGB in [0, 1].
    defsim_body_id id;          ///< After defsim_scene_build; {0, 0} before.
    int32_t vertex_offset;      ///< First vertex in the world, after defsim_scene_build; else 0.
} defsim_scene_body;

/// Fills *out with body i (0 <= i < body_count; out->size must be set).
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, size too small, i out of range).
DEFSIM_API defsim_status defsim_scene_get_body(const defsim_scene *scene, int32_t i,
                                               defsim_scene_body *out);

/* VTK frames: the writer of `defsim run`, for frames a host assembles itself. */

/// VTK cell types accepted by defsim_vtk_write_vtu.
typedef enum defsim_vtk_cell {
    DEFSIM_VTK_LINE = 3,
    DEFSIM_VTK_TRIANGLE = 5,
    DEFSIM_VTK_TETRA = 10,
    DEFSIM_VTK_QUADRATIC_TETRA = 24   ///< 10 vertices: the order of defsim_body_def.tet_nodes.
} defsim_vtk_cell;

/// An extra Float64 array of a frame: point data (cell 0: one tuple per vertex) or cell data
/// (cell 1: one tuple per cell). Borrowed for the call.
typedef struct defsim_vtk_array {
    const char *name;       ///< Letters, digits and '_' only.
    int32_t components;     ///< 1, 3, 6 or 9.
    int32_t cell;           ///< 0: per point, 1: per cell.
    const double *data;     ///< components * tuples doubles.
} defsim_vtk_array;

/// Writes one .vtu frame (an unstructured grid that ParaView and meshio read) atomically (a
/// temporary file renamed into place): `nv` points x (3 nv doubles, m), optional velocities v
/// (3 nv or NULL) as point data "velocity", `ncells` cells given by `types` (defsim_vtk_cell
/// per cell), `offsets` (the end of each cell in `conn`, VTK's convention) and `conn` (vertex
/// indices in [0, nv)), `body` (an int32 per cell, cell data "body"; NULL: all 0), the time t
/// (field data "TimeValue", s) and `count` extra arrays. Every argument is checked before the
/// file is opened. Returns DEFSIM_OK; DEFSIM_ERR_INVALID_ARGUMENT (NULL, counts, a cell whose
/// size does not match its type, an index out of range, a bad array) or DEFSIM_ERR_IO (cannot
/// write) with the reason in `err` (may be NULL).
DEFSIM_API defsim_status defsim_vtk_write_vtu(const char *path, int32_t nv, const double *x,
                                              const double *v, int64_t ncells,
                                              const uint8_t *types, const int64_t *offsets,
                                              const int64_t *conn, const int32_t *body,
                                              double time, const defsim_vtk_array *arrays,
                                              int32_t count, char *err, size_t errsz);

/// Writes a .pvd collection (ParaView's time series) of `count` datasets: file names as they are
/// to appear in it (relative to the .pvd's folder) and their times (s). Atomic like the .vtu.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, count < 0, a name with '"', '<', '&'),
/// DEFSIM_ERR_IO, with the reason in `err`.
DEFSIM_API defsim_status defsim_vtk_write_pvd(const char *path, int32_t count,
                                              const double *times, const char *const *files,
                                              char *err, size_t errsz);

/* A world's frame, the whole scene (issue 28): what `defsim run` writes per frame. */

/// What defsim_vtk_write_world writes beyond positions, velocities and body tags (bits).
typedef enum defsim_vtk_field {
    DEFSIM_VTK_STRESS = 1,            ///< Cell data cauchy_stress (9), von_mises, energy_density.
    DEFSIM_VTK_DISPLACEMENT = 2,      ///< Point data displacement (m, from `reference`).
    DEFSIM_VTK_PIN_FORCES = 4,        ///< Point data pin_force (N); with any pin also "pinned".
    DEFSIM_VTK_ATTACHMENT_FORCES = 8, ///< Point data attachment_force (N).
    DEFSIM_VTK_CONTACT_FORCES = 16,   ///< Point data contact_force (N, colliders + body contact).
    DEFSIM_VTK_COLLIDERS = 32,        ///< The colliders' geometry and the .vtm (see below).
    DEFSIM_VTK_ALL = 63
} defsim_vtk_field;

/// How defsim_vtk_write_world writes a frame. Fill with defsim_vtk_frame_def_init. Arrays are
/// borrowed for the call.
typedef struct defsim_vtk_frame_def {
    uint32_t size;              ///< sizeof(defsim_vtk_frame_def), set by the init function.
    int64_t cell_count;         ///< Cells of the bodies, as for defsim_vtk_write_vtu:
    const uint8_t *types;       ///< defsim_vtk_cell per cell,
    const int64_t *offsets;     ///< the end of each cell in conn,
    const int64_t *conn;        ///< world vertex indices,
    const int32_t *body;        ///< the body (index in vertex order) of each cell: each body's
                                ///< cells in one run, in body order; its tets in its tets' order.
    const double *reference;    ///< 3 nv positions that displacement is measured from; NULL:
                                ///< no displacement array.
    uint32_t fields;            ///< defsim_vtk_field bits. Default DEFSIM_VTK_ALL. A field the
                                ///< world cannot have (stress without tets, pin forces without
                                ///< pins, ...) is left out.
    double plane_center[3];     ///< Planes are drawn as squares about the point of the plane
    double plane_half;          ///< nearest plane_center, of half side plane_half (m); 0
                                ///< (default): sized to the scene now (the bounds of the bodies
                                ///< and of the other colliders, half side twice their largest side).
} defsim_vtk_frame_def;

/// Fills *def with defaults (no cells, no reference, all fields, planes sized to the scene).
/// Does nothing if def is NULL.
DEFSIM_API void defsim_vtk_frame_def_init(defsim_vtk_frame_def *def, size_t size);

/// Writes the world's current state as `defsim run` writes a frame, with the same code: `path`
/// (ending in ".vtu") the bodies (points, cells, velocity, the fields asked for at the current
/// state), and with DEFSIM_VTK_COLLIDERS and a world that has colliders also
/// `<path without .vtu>_colliders.vtu` (each collider's geometry at its current pose: spheres,
/// capsules, boxes and meshes tessellated, planes as squares, an SDF as its bounds box's edges;
/// cell data "collider" (its index, defsim_world_get_collider) and "shape") and the multiblock
/// `<path without .vtu>.vtm` holding both (blocks "bodies" and "colliders"), all atomically.
/// `time` is the frame's field data TimeValue (s). `plane_out` (4 doubles: centre, half side;
/// may be NULL) receives the square used for planes, for the next frames of a series. `*vtm`
/// (may be NULL) receives 1 when the .vtm was written. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL,
/// a def of the wrong size, a path not ending in ".vtu", cells as defsim_vtk_write_vtu refuses
/// them, body tags not the world's bodies in order, a body's tet count other than its cells');
/// DEFSIM_ERR_IO; DEFSIM_ERR_OUT_OF_MEMORY; with the reason in `err` (may be NULL).
DEFSIM_API defsim_status defsim_vtk_write_world(const char *path, defsim_world *world,
                                                const defsim_vtk_frame_def *def, double time,
                                                double *plane_out, int32_t *vtm, char *err,
                                                size_t errsz);

#ifdef __cplusplus
}
#endif

#endif

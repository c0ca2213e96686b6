/* SPDX-License-Identifier: MIT */
/*
 * Misuse of the public API (issue 17): a table of calls with NULL pointers, wrong sizes,
 * negative counts, NaN and Inf, stale ids, ids of another world, pointers that are no live
 * world, and calls in the wrong place (from inside the log callback or the force callback of
 * the world, before any body). Each row runs against a fixture of three worlds; the row's
 * status must be the documented one, nothing may crash, and every world must be unchanged: its
 * state compared exactly and its model by a digest (bodies, ids, pins, masses, attachments,
 * external forces, callback, driven pins, colliders, options).
 *
 * The header agrees with the table: a second test parses include/defsim/defsim.h and checks
 * that every public function has at least one row, and that every status a row observes for a
 * function is named in that function's "Errors:" line.
 *
 * Adding a row: one line in MISUSE_ROWS below (context, flags, function, expected, call).
 * BADW, BADW1 and BADWV (functions that return nothing) add the three rows of a world pointer
 * that is NULL, destroyed or foreign; LOCKED adds the two rows of a call from inside the log
 * callback and from inside the force callback.
 */
#include "test_util.h"

#include "world.h"

#include <ctype.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef DEFSIM_HEADER
#error "DEFSIM_HEADER (the path of include/defsim/defsim.h) must be defined"
#endif

enum { CTX_DIRECT, CTX_LOG, CTX_FORCE };   /* where the call is made */
enum {
    F_VALUE = 1,     /* returns a value, not a status: the header check skips it */
    F_CHANGES = 2    /* succeeds and may change its world: the unchanged check skips it */
};

#define BUF 4096
#define H 1e-3

typedef struct fx {
    defsim_world *w, *w2, *e;      /* the world under test, another world, an empty world */
    defsim_world *dead, *alien;    /* a world marked destroyed; bytes that are no world */
    defsim_body_id box, rope, stale, foreign, null_id;
    defsim_attachment_id att, att_stale, att_foreign, att_null;
    defsim_collider_id col, col_stale, col_foreign, col_null, col_out;
    defsim_collider_def cdef, cdef_size0, cdef_nan, cdef_shape, cdef_radius, cdef_quat, cdef_out0;
    double quat_id[4], quat_bad[4];
    int32_t nv, nt, nv2;
    double buf[BUF], x_nan[BUF], f_inf[BUF];
    int32_t verts[2], bad_verts[2];
    double p3[3], nan3[3], inf3[3], zero3[3], unit3[3];
    defsim_body_def bdef, bdef_size0, bdef_negcount, bdef_nan, bdef_badidx, bdef_badk;
    double rest2[6], rest2_nan[6];
    int32_t spring01[2], spring05[2];
    double kneg[1];
    defsim_attachment_def adef, adef_foreign, adef_stale_target, adef_nan_k, adef_weights,
        adef_size0, adef_badvertex, adef_out;
    defsim_world_def wdef, wdef_size0, wdef_nan_g, wdef_backend, wdef_threads, wdef_nobackend;
    defsim_world *out_world;
    void *data;
    size_t size;
    char junk[64];
    defsim_body_id body_out;
    defsim_attachment_id att_out;
    defsim_material mat, mat0, mat_spring, mat_bad, mat_nh;
    double F_id[9], F_nan[9], F_inv[9], P[9];
    defsim_mesh mesh, mesh0;
    defsim_stats stats, stats0;
    defsim_option_info oinfo, oinfo0;
    defsim_energy energy;
    double value;
    const char *name;
    int32_t pending;               /* row to run from inside a callback, or -1 */
    int64_t observed;
    int ran;
    defsim_tape *tape_out;
    defsim_tape_stats tape_stats;
} fx;

static fx *F;                      /* the fixture, for the callbacks */

static double sdf_dummy(void *user, const double p[3], double grad[3])
{
    (void)user;
    grad[0] = 0.0;
    grad[1] = 1.0;
    grad[2] = 0.0;
    return p[1];
}
static defsim_world dead_world;    /* only its magic is ever read */
static uint64_t alien_bytes[64];

/* ------------------------------------------------------------------------------------------ */
/* The table */

#define BADW(X, fn, expect, ...)                                                           \
    X(CTX_DIRECT, 0, fn, expect, fn(NULL, __VA_ARGS__))                                    \
    X(CTX_DIRECT, 0, fn, expect, fn(f->dead, __VA_ARGS__))                                 \
    X(CTX_DIRECT, 0, fn, expect, fn(f->alien, __VA_ARGS__))
#define BADW1(X, flags, fn, expect)                                                        \
    X(CTX_DIRECT, flags, fn, expect, fn(NULL))                                             \
    X(CTX_DIRECT, flags, fn, expect, fn(f->dead))                                          \
    X(CTX_DIRECT, flags, fn, expect, fn(f->alien))
#define BADWV(X, fn)                                                                       \
    X(CTX_DIRECT, F_VALUE, fn, 0, (fn(NULL), 0))                                           \
    X(CTX_DIRECT, F_VALUE, fn, 0, (fn(f->dead), 0))                                        \
    X(CTX_DIRECT, F_VALUE, fn, 0, (fn(f->alien), 0))
#define LOCKED(X, fn, ...)                                                                 \
    X(CTX_LOG, 0, fn, DEFSIM_ERR_LOCKED, fn(f->w, __VA_ARGS__))                            \
    X(CTX_FORCE, 0, fn, DEFSIM_ERR_LOCKED, fn(f->w, __VA_ARGS__))

#define INVALID DEFSIM_ERR_INVALID_ARGUMENT
#define STALE DEFSIM_ERR_STALE_ID
#define OK DEFSIM_OK

#define MISUSE_ROWS(X)                                                                          \
    /* status text, version, last error */                                                      \
    X(CTX_DIRECT, F_VALUE, defsim_status_string, 1, defsim_status_string(DEFSIM_ERR_LOCKED) != NULL) \
    X(CTX_DIRECT, F_VALUE, defsim_status_string, 1, defsim_status_string((defsim_status)-999) != NULL) \
    X(CTX_DIRECT, F_VALUE, defsim_status_string, 1, defsim_status_string((defsim_status)7) != NULL) \
    X(CTX_DIRECT, F_VALUE, defsim_last_error, 1, defsim_last_error() != NULL)                  \
    X(CTX_DIRECT, F_VALUE, defsim_version_number, 1, defsim_version_number() == DEFSIM_VERSION_NUMBER) \
    X(CTX_DIRECT, F_VALUE, defsim_world_last_error, 1, defsim_world_last_error(NULL)[0] == '\0') \
    X(CTX_DIRECT, F_VALUE, defsim_world_last_error, 1, defsim_world_last_error(f->dead) != NULL) \
    X(CTX_DIRECT, F_VALUE, defsim_world_last_error, 1, defsim_world_last_error(f->alien) != NULL) \
    X(CTX_LOG, F_VALUE, defsim_world_last_error, 1, defsim_world_last_error(f->w) != NULL)     \
    /* materials */                                                                             \
    X(CTX_DIRECT, F_VALUE, defsim_material_init, 0, (defsim_material_init(NULL, sizeof f->mat, DEFSIM_MODEL_STVK), 0)) \
    X(CTX_DIRECT, F_VALUE, defsim_material_init, 0, (defsim_material_init(&f->mat0, 0, DEFSIM_MODEL_STVK), f->mat0.size)) \
    X(CTX_DIRECT, 0, defsim_material_eval, INVALID, defsim_material_eval(NULL, f->F_id, NULL, NULL, NULL)) \
    X(CTX_DIRECT, 0, defsim_material_eval, INVALID, defsim_material_eval(&f->mat, NULL, NULL, NULL, NULL)) \
    X(CTX_DIRECT, 0, defsim_material_eval, INVALID, defsim_material_eval(&f->mat, f->F_nan, NULL, f->P, NULL)) \
    X(CTX_DIRECT, 0, defsim_material_eval, INVALID, defsim_material_eval(&f->mat_spring, f->F_id, NULL, f->P, NULL)) \
    X(CTX_DIRECT, 0, defsim_material_eval, DEFSIM_ERR_INVALID_MATERIAL, defsim_material_eval(&f->mat_bad, f->F_id, NULL, f->P, NULL)) \
    X(CTX_DIRECT, 0, defsim_material_eval, DEFSIM_ERR_UNSTABLE, defsim_material_eval(&f->mat_nh, f->F_inv, NULL, f->P, NULL)) \
    X(CTX_DIRECT, 0, defsim_material_check, INVALID, defsim_material_check(NULL))             \
    X(CTX_DIRECT, 0, defsim_material_check, INVALID, defsim_material_check(&f->mat0))         \
    X(CTX_DIRECT, 0, defsim_material_check, DEFSIM_ERR_INVALID_MATERIAL, defsim_material_check(&f->mat_bad)) \
    X(CTX_DIRECT, 0, defsim_material_check, OK, defsim_material_check(&f->mat))               \
    X(CTX_DIRECT, 0, defsim_material_check, OK, defsim_material_check(&f->mat_spring))        \
    /* creation */                                                                              \
    X(CTX_DIRECT, F_VALUE, defsim_world_def_init, 0, (defsim_world_def_init(NULL, sizeof f->wdef), 0)) \
    X(CTX_DIRECT, 0, defsim_world_create, INVALID, defsim_world_create(NULL, &f->out_world))   \
    X(CTX_DIRECT, 0, defsim_world_create, INVALID, defsim_world_create(&f->wdef, NULL))        \
    X(CTX_DIRECT, 0, defsim_world_create, INVALID, defsim_world_create(&f->wdef_size0, &f->out_world)) \
    X(CTX_DIRECT, 0, defsim_world_create, INVALID, defsim_world_create(&f->wdef_nan_g, &f->out_world)) \
    X(CTX_DIRECT, 0, defsim_world_create, INVALID, defsim_world_create(&f->wdef_threads, &f->out_world)) \
    X(CTX_DIRECT, 0, defsim_world_create, INVALID, defsim_world_create(&f->wdef_nobackend, &f->out_world)) \
    X(CTX_DIRECT, 0, defsim_world_create, DEFSIM_ERR_BACKEND_UNAVAILABLE, defsim_world_create(&f->wdef_backend, &f->out_world)) \
    BADWV(X, defsim_world_destroy)                                                              \
    X(CTX_LOG, F_VALUE, defsim_world_destroy, 0, (defsim_world_destroy(f->w), 0))              \
    X(CTX_FORCE, F_VALUE, defsim_world_destroy, 0, (defsim_world_destroy(f->w), 0))            \
    /* bodies */                                                                                \
    X(CTX_DIRECT, F_VALUE, defsim_body_def_init, 0, (defsim_body_def_init(NULL, sizeof f->bdef), 0)) \
    BADW(X, defsim_world_add_body, INVALID, &f->bdef, NULL)                                     \
    X(CTX_DIRECT, 0, defsim_world_add_body, INVALID, defsim_world_add_body(f->w, NULL, NULL))  \
    X(CTX_DIRECT, 0, defsim_world_add_body, INVALID, defsim_world_add_body(f->w, &f->bdef_size0, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_add_body, INVALID, defsim_world_add_body(f->w, &f->bdef_negcount, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_add_body, DEFSIM_ERR_INVALID_MESH, defsim_world_add_body(f->w, &f->bdef_nan, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_add_body, DEFSIM_ERR_INVALID_MESH, defsim_world_add_body(f->w, &f->bdef_badidx, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_add_body, DEFSIM_ERR_INVALID_MATERIAL, defsim_world_add_body(f->w, &f->bdef_badk, NULL)) \
    LOCKED(X, defsim_world_add_body, &f->bdef, NULL)                                            \
    BADW(X, defsim_world_remove_body, INVALID, f->box)                                          \
    X(CTX_DIRECT, 0, defsim_world_remove_body, STALE, defsim_world_remove_body(f->w, f->null_id)) \
    X(CTX_DIRECT, 0, defsim_world_remove_body, STALE, defsim_world_remove_body(f->w, f->stale)) \
    X(CTX_DIRECT, 0, defsim_world_remove_body, STALE, defsim_world_remove_body(f->w, f->foreign)) \
    X(CTX_DIRECT, 0, defsim_world_remove_body, STALE, defsim_world_remove_body(f->w2, f->box))  \
    LOCKED(X, defsim_world_remove_body, f->box)                                                 \
    LOCKED(X, defsim_world_remove_body, f->rope)                                                \
    BADW(X, defsim_body_vertex_count, INVALID, f->box)                                          \
    X(CTX_DIRECT, 0, defsim_body_vertex_count, STALE, defsim_body_vertex_count(f->w, f->stale)) \
    X(CTX_DIRECT, 0, defsim_body_vertex_count, STALE, defsim_body_vertex_count(f->w, f->foreign)) \
    X(CTX_DIRECT, 0, defsim_body_vertex_count, STALE, defsim_body_vertex_count(f->e, f->box))  \
    X(CTX_LOG, F_VALUE, defsim_body_vertex_count, 3, defsim_body_vertex_count(f->w, f->rope))  \
    BADW(X, defsim_body_vertex_offset, INVALID, f->box)                                         \
    X(CTX_DIRECT, 0, defsim_body_vertex_offset, STALE, defsim_body_vertex_offset(f->w, f->null_id)) \
    X(CTX_DIRECT, 0, defsim_body_vertex_offset, STALE, defsim_body_vertex_offset(f->w2, f->rope)) \
    /* pins */                                                                                  \
    BADW(X, defsim_body_pin, INVALID, f->box, f->verts, 1)                                      \
    X(CTX_DIRECT, 0, defsim_body_pin, INVALID, defsim_body_pin(f->w, f->box, f->verts, -1))    \
    X(CTX_DIRECT, 0, defsim_body_pin, INVALID, defsim_body_pin(f->w, f->box, NULL, 1))         \
    X(CTX_DIRECT, 0, defsim_body_pin, INVALID, defsim_body_pin(f->w, f->box, f->bad_verts, 2)) \
    X(CTX_DIRECT, 0, defsim_body_pin, STALE, defsim_body_pin(f->w, f->stale, f->verts, 1))     \
    X(CTX_DIRECT, 0, defsim_body_pin, STALE, defsim_body_pin(f->w, f->foreign, f->verts, 1))   \
    LOCKED(X, defsim_body_pin, f->box, f->verts, 2)                                             \
    BADW(X, defsim_body_unpin, INVALID, f->rope, f->verts, 1)                                   \
    X(CTX_DIRECT, 0, defsim_body_unpin, INVALID, defsim_body_unpin(f->w, f->rope, f->verts, -5)) \
    X(CTX_DIRECT, 0, defsim_body_unpin, INVALID, defsim_body_unpin(f->w, f->rope, f->bad_verts, 1)) \
    X(CTX_DIRECT, 0, defsim_body_unpin, STALE, defsim_body_unpin(f->w, f->foreign, f->verts, 1)) \
    LOCKED(X, defsim_body_unpin, f->rope, f->verts, 1)                                          \
    BADW(X, defsim_body_set_collision, INVALID, f->rope, 1, 1u, 1u)                             \
    X(CTX_DIRECT, 0, defsim_body_set_collision, INVALID, defsim_body_set_collision(f->w, f->rope, 2, 1u, 1u)) \
    X(CTX_DIRECT, 0, defsim_body_set_collision, INVALID, defsim_body_set_collision(f->w, f->rope, -1, 1u, 1u)) \
    X(CTX_DIRECT, 0, defsim_body_set_collision, STALE, defsim_body_set_collision(f->w, f->stale, 1, 1u, 1u)) \
    X(CTX_DIRECT, 0, defsim_body_set_collision, STALE, defsim_body_set_collision(f->w, f->foreign, 1, 1u, 1u)) \
    LOCKED(X, defsim_body_set_collision, f->rope, 0, 2u, 2u)                                    \
    /* simulation */                                                                            \
    BADW1(X, F_VALUE, defsim_world_vertex_count, 0)                                             \
    BADW(X, defsim_world_step, INVALID, H)                                                      \
    X(CTX_DIRECT, 0, defsim_world_step, INVALID, defsim_world_step(f->w, NAN))                 \
    X(CTX_DIRECT, 0, defsim_world_step, INVALID, defsim_world_step(f->w, INFINITY))            \
    X(CTX_DIRECT, 0, defsim_world_step, INVALID, defsim_world_step(f->w, 0.0))                 \
    X(CTX_DIRECT, 0, defsim_world_step, INVALID, defsim_world_step(f->w, -H))                  \
    X(CTX_DIRECT, F_CHANGES, defsim_world_step, OK, defsim_world_step(f->e, H))                \
    LOCKED(X, defsim_world_step, H)                                                             \
    BADW(X, defsim_world_stable_step, INVALID, &f->value, NULL)                                 \
    X(CTX_DIRECT, 0, defsim_world_stable_step, OK, defsim_world_stable_step(f->e, &f->value, NULL)) \
    LOCKED(X, defsim_world_stable_step, &f->value, NULL)                                        \
    BADW1(X, F_VALUE, defsim_world_time, 0)                                                     \
    BADW(X, defsim_world_get_positions, INVALID, f->buf, f->nv)                                 \
    X(CTX_DIRECT, 0, defsim_world_get_positions, INVALID, defsim_world_get_positions(f->w, NULL, f->nv)) \
    X(CTX_DIRECT, 0, defsim_world_get_positions, INVALID, defsim_world_get_positions(f->w, f->buf, f->nv - 1)) \
    X(CTX_DIRECT, 0, defsim_world_get_positions, INVALID, defsim_world_get_positions(f->w, f->buf, -1)) \
    X(CTX_DIRECT, 0, defsim_world_get_positions, OK, defsim_world_get_positions(f->e, f->buf, 0)) \
    X(CTX_LOG, 0, defsim_world_get_positions, OK, defsim_world_get_positions(f->w, f->buf, f->nv)) \
    X(CTX_FORCE, 0, defsim_world_get_positions, OK, defsim_world_get_positions(f->w, f->buf, f->nv)) \
    BADW(X, defsim_world_get_velocities, INVALID, f->buf, f->nv)                                \
    X(CTX_DIRECT, 0, defsim_world_get_velocities, INVALID, defsim_world_get_velocities(f->w, f->buf, f->nv + 1)) \
    X(CTX_DIRECT, 0, defsim_world_get_velocities, INVALID, defsim_world_get_velocities(f->w, NULL, f->nv)) \
    BADW(X, defsim_world_state_view, INVALID, NULL, NULL, NULL)                                 \
    X(CTX_DIRECT, 0, defsim_world_state_view, OK, defsim_world_state_view(f->w, NULL, NULL, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_state_view, OK, defsim_world_state_view(f->e, NULL, NULL, NULL)) \
    X(CTX_LOG, 0, defsim_world_state_view, OK, defsim_world_state_view(f->w, NULL, NULL, NULL)) \
    X(CTX_FORCE, 0, defsim_world_state_view, OK, defsim_world_state_view(f->w, NULL, NULL, NULL)) \
    BADW(X, defsim_world_get_masses, INVALID, f->buf, f->nv)                                    \
    X(CTX_DIRECT, 0, defsim_world_get_masses, INVALID, defsim_world_get_masses(f->w, f->buf, INT32_MIN)) \
    X(CTX_LOG, 0, defsim_world_get_masses, OK, defsim_world_get_masses(f->w, f->buf, f->nv))   \
    BADW(X, defsim_world_set_state, INVALID, NULL, NULL)                                        \
    X(CTX_DIRECT, 0, defsim_world_set_state, INVALID, defsim_world_set_state(f->w, f->x_nan, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_set_state, INVALID, defsim_world_set_state(f->w, NULL, f->f_inf)) \
    LOCKED(X, defsim_world_set_state, f->buf, NULL)                                             \
    X(CTX_LOG, 0, defsim_world_set_state, OK, defsim_world_set_state(f->w2, NULL, NULL))       \
    BADW(X, defsim_world_energy, INVALID, &f->energy)                                           \
    X(CTX_DIRECT, 0, defsim_world_energy, INVALID, defsim_world_energy(f->w, NULL))            \
    X(CTX_DIRECT, 0, defsim_world_energy, OK, defsim_world_energy(f->e, &f->energy))           \
    X(CTX_LOG, 0, defsim_world_energy, OK, defsim_world_energy(f->w, &f->energy))              \
    BADW(X, defsim_world_forces, INVALID, NULL, f->buf)                                         \
    X(CTX_DIRECT, 0, defsim_world_forces, INVALID, defsim_world_forces(f->w, NULL, NULL))      \
    LOCKED(X, defsim_world_forces, NULL, f->buf)                                                \
    BADW(X, defsim_world_stats, INVALID, &f->stats)                                             \
    X(CTX_DIRECT, 0, defsim_world_stats, INVALID, defsim_world_stats(f->w, NULL))              \
    X(CTX_DIRECT, 0, defsim_world_stats, INVALID, defsim_world_stats(f->w, &f->stats0))        \
    X(CTX_FORCE, 0, defsim_world_stats, OK, defsim_world_stats(f->w, &f->stats))               \
    BADWV(X, defsim_world_reset_stats)                                                          \
    X(CTX_LOG, F_VALUE, defsim_world_reset_stats, 1, (defsim_world_reset_stats(f->w), f->w->stats.steps > 0)) \
    /* options and statistics by name */                                                        \
    BADW(X, defsim_world_set_option, INVALID, "core.auto_substep", "on")                        \
    X(CTX_DIRECT, 0, defsim_world_set_option, INVALID, defsim_world_set_option(f->w, NULL, "1")) \
    X(CTX_DIRECT, 0, defsim_world_set_option, INVALID, defsim_world_set_option(f->w, "core.auto_substep", NULL)) \
    X(CTX_DIRECT, 0, defsim_world_set_option, INVALID, defsim_world_set_option(f->w, "core.no_such_option", "1")) \
    X(CTX_DIRECT, 0, defsim_world_set_option, INVALID, defsim_world_set_option(f->w, "newton_cholmod.rtol", "1e-3")) \
    X(CTX_DIRECT, 0, defsim_world_set_option, INVALID, defsim_world_set_option(f->w, "core.substep_safety", "nan")) \
    X(CTX_DIRECT, 0, defsim_world_set_option, INVALID, defsim_world_set_option(f->w, "core.substep_safety", "2")) \
    X(CTX_DIRECT, 0, defsim_world_set_option, INVALID, defsim_world_set_option(f->w, "core.simd", "sse9")) \
    LOCKED(X, defsim_world_set_option, "core.auto_substep", "on")                               \
    BADW(X, defsim_world_set_option_number, INVALID, "core.substep_safety", 0.5)                \
    X(CTX_DIRECT, 0, defsim_world_set_option_number, INVALID, defsim_world_set_option_number(f->w, "core.substep_safety", NAN)) \
    X(CTX_DIRECT, 0, defsim_world_set_option_number, INVALID, defsim_world_set_option_number(f->w, "core.substep_safety", INFINITY)) \
    X(CTX_DIRECT, 0, defsim_world_set_option_number, INVALID, defsim_world_set_option_number(f->w, "core.auto_substep", 0.5)) \
    X(CTX_DIRECT, 0, defsim_world_set_option_number, INVALID, defsim_world_set_option_number(f->w, NULL, 1.0)) \
    LOCKED(X, defsim_world_set_option_number, "core.substep_safety", 0.5)                       \
    BADW(X, defsim_world_get_option, INVALID, "core.auto_substep", &f->value)                   \
    X(CTX_DIRECT, 0, defsim_world_get_option, INVALID, defsim_world_get_option(f->w, "core.auto_substep", NULL)) \
    X(CTX_DIRECT, 0, defsim_world_get_option, INVALID, defsim_world_get_option(f->w, "nope", &f->value)) \
    X(CTX_DIRECT, 0, defsim_world_get_option, INVALID, defsim_world_get_option(f->w, NULL, &f->value)) \
    X(CTX_LOG, 0, defsim_world_get_option, OK, defsim_world_get_option(f->w, "core.auto_substep", &f->value)) \
    BADW1(X, F_VALUE, defsim_world_option_count, 0)                                             \
    BADW(X, defsim_world_option_info, INVALID, 0, &f->oinfo)                                    \
    X(CTX_DIRECT, 0, defsim_world_option_info, INVALID, defsim_world_option_info(f->w, -1, &f->oinfo)) \
    X(CTX_DIRECT, 0, defsim_world_option_info, INVALID, defsim_world_option_info(f->w, 1 << 20, &f->oinfo)) \
    X(CTX_DIRECT, 0, defsim_world_option_info, INVALID, defsim_world_option_info(f->w, 0, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_option_info, INVALID, defsim_world_option_info(f->w, 0, &f->oinfo0)) \
    BADW(X, defsim_world_stat, INVALID, "steps", &f->value)                                     \
    X(CTX_DIRECT, 0, defsim_world_stat, INVALID, defsim_world_stat(f->w, "no_such_stat", &f->value)) \
    X(CTX_DIRECT, 0, defsim_world_stat, INVALID, defsim_world_stat(f->w, NULL, &f->value))     \
    X(CTX_DIRECT, 0, defsim_world_stat, INVALID, defsim_world_stat(f->w, "steps", NULL))       \
    BADW1(X, F_VALUE, defsim_world_stat_count, 0)                                               \
    BADW(X, defsim_world_stat_info, INVALID, 0, &f->name, &f->value)                            \
    X(CTX_DIRECT, 0, defsim_world_stat_info, INVALID, defsim_world_stat_info(f->w, -1, &f->name, &f->value)) \
    X(CTX_DIRECT, 0, defsim_world_stat_info, INVALID, defsim_world_stat_info(f->w, INT32_MAX, NULL, NULL)) \
    /* meshes */                                                                                \
    X(CTX_DIRECT, 0, defsim_mesh_box, INVALID, defsim_mesh_box(NULL, f->unit3, 1, 1, 1, &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_box, INVALID, defsim_mesh_box(f->zero3, f->unit3, 1, 1, 1, NULL)) \
    X(CTX_DIRECT, 0, defsim_mesh_box, INVALID, defsim_mesh_box(f->zero3, f->unit3, 0, 1, 1, &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_box, INVALID, defsim_mesh_box(f->zero3, f->unit3, 1, -1, 1, &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_box, INVALID, defsim_mesh_box(f->zero3, f->zero3, 1, 1, 1, &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_box, INVALID, defsim_mesh_box(f->nan3, f->unit3, 1, 1, 1, &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_box, INVALID, defsim_mesh_box(f->zero3, f->inf3, 1, 1, 1, &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_box, INVALID, defsim_mesh_box(f->zero3, f->unit3, 1, 1, 1, &f->mesh0)) \
    X(CTX_DIRECT, 0, defsim_mesh_make_quadratic, INVALID, defsim_mesh_make_quadratic(NULL))      \
    X(CTX_DIRECT, 0, defsim_mesh_make_quadratic, INVALID, defsim_mesh_make_quadratic(&f->mesh0)) \
    X(CTX_DIRECT, 0, defsim_mesh_make_quadratic, INVALID, defsim_mesh_make_quadratic(&f->mesh))  \
    X(CTX_DIRECT, F_VALUE, defsim_mesh_free, 0, (defsim_mesh_free(NULL), 0))                   \
    X(CTX_DIRECT, F_VALUE, defsim_mesh_free, 0, (defsim_mesh_free(&f->mesh0), f->mesh0.vertex_count)) \
    X(CTX_DIRECT, 0, defsim_mesh_load, INVALID, defsim_mesh_load(NULL, &f->mesh))              \
    X(CTX_DIRECT, 0, defsim_mesh_load, INVALID, defsim_mesh_load("/nonexistent/misuse.obj", NULL)) \
    X(CTX_DIRECT, 0, defsim_mesh_load, INVALID, defsim_mesh_load("/nonexistent/misuse.obj", &f->mesh0)) \
    X(CTX_DIRECT, 0, defsim_mesh_load, INVALID, defsim_mesh_load("misuse.unknown_extension", &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_load, DEFSIM_ERR_IO, defsim_mesh_load("/nonexistent/misuse.obj", &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_cloth, INVALID, defsim_mesh_cloth(NULL, f->unit3, f->p3, 2, 2, &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_cloth, INVALID, defsim_mesh_cloth(f->zero3, f->unit3, f->p3, 0, 2, &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_cloth, INVALID, defsim_mesh_cloth(f->zero3, f->unit3, f->p3, 2, -3, &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_cloth, INVALID, defsim_mesh_cloth(f->zero3, f->unit3, f->unit3, 2, 2, &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_cloth, INVALID, defsim_mesh_cloth(f->nan3, f->unit3, f->p3, 2, 2, &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_cloth, INVALID, defsim_mesh_cloth(f->zero3, f->unit3, f->p3, 2, 2, &f->mesh0)) \
    X(CTX_DIRECT, 0, defsim_mesh_rope, INVALID, defsim_mesh_rope(NULL, f->unit3, 4, &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_rope, INVALID, defsim_mesh_rope(f->zero3, f->unit3, 0, &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_rope, INVALID, defsim_mesh_rope(f->unit3, f->unit3, 4, &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_rope, INVALID, defsim_mesh_rope(f->zero3, f->nan3, 4, &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_rope, INVALID, defsim_mesh_rope(f->zero3, f->inf3, 4, &f->mesh)) \
    X(CTX_DIRECT, 0, defsim_mesh_rope, INVALID, defsim_mesh_rope(f->zero3, f->unit3, 4, NULL)) \
    /* coupling: external forces, callback, driven pins */                                      \
    BADW(X, defsim_world_set_external_forces, INVALID, f->buf, f->nv)                           \
    X(CTX_DIRECT, 0, defsim_world_set_external_forces, INVALID, defsim_world_set_external_forces(f->w, f->buf, f->nv - 1)) \
    X(CTX_DIRECT, 0, defsim_world_set_external_forces, INVALID, defsim_world_set_external_forces(f->w, f->buf, -1)) \
    X(CTX_DIRECT, 0, defsim_world_set_external_forces, INVALID, defsim_world_set_external_forces(f->w, f->f_inf, f->nv)) \
    X(CTX_DIRECT, 0, defsim_world_set_external_forces, INVALID, defsim_world_set_external_forces(f->w, f->x_nan, f->nv)) \
    LOCKED(X, defsim_world_set_external_forces, f->buf, f->nv)                                  \
    LOCKED(X, defsim_world_set_external_forces, NULL, 0)                                        \
    BADW(X, defsim_world_set_force_callback, INVALID, NULL, NULL, NULL)                         \
    X(CTX_DIRECT, 0, defsim_world_set_force_callback, INVALID, defsim_world_set_force_callback(f->w, NULL, jac_cb, NULL)) \
    LOCKED(X, defsim_world_set_force_callback, NULL, NULL, NULL)                                \
    BADW(X, defsim_body_set_pin_targets, INVALID, f->rope, f->verts, 1, f->p3)                  \
    X(CTX_DIRECT, 0, defsim_body_set_pin_targets, INVALID, defsim_body_set_pin_targets(f->w, f->rope, f->verts, -1, f->p3)) \
    X(CTX_DIRECT, 0, defsim_body_set_pin_targets, INVALID, defsim_body_set_pin_targets(f->w, f->rope, f->verts, 1, NULL)) \
    X(CTX_DIRECT, 0, defsim_body_set_pin_targets, INVALID, defsim_body_set_pin_targets(f->w, f->rope, NULL, 1, f->p3)) \
    X(CTX_DIRECT, 0, defsim_body_set_pin_targets, INVALID, defsim_body_set_pin_targets(f->w, f->rope, f->bad_verts, 1, f->p3)) \
    X(CTX_DIRECT, 0, defsim_body_set_pin_targets, INVALID, defsim_body_set_pin_targets(f->w, f->rope, f->verts, 1, f->nan3)) \
    X(CTX_DIRECT, 0, defsim_body_set_pin_targets, STALE, defsim_body_set_pin_targets(f->w, f->stale, f->verts, 1, f->p3)) \
    X(CTX_DIRECT, 0, defsim_body_set_pin_targets, STALE, defsim_body_set_pin_targets(f->w, f->foreign, f->verts, 1, f->p3)) \
    LOCKED(X, defsim_body_set_pin_targets, f->rope, f->verts, 1, f->p3)                         \
    /* coupling: attachments */                                                                 \
    X(CTX_DIRECT, F_VALUE, defsim_attachment_def_init, 0, (defsim_attachment_def_init(NULL, sizeof f->adef), 0)) \
    BADW(X, defsim_world_add_attachment, INVALID, &f->adef, NULL)                               \
    X(CTX_DIRECT, 0, defsim_world_add_attachment, INVALID, defsim_world_add_attachment(f->w, NULL, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_add_attachment, INVALID, defsim_world_add_attachment(f->w, &f->adef_size0, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_add_attachment, INVALID, defsim_world_add_attachment(f->w, &f->adef_nan_k, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_add_attachment, INVALID, defsim_world_add_attachment(f->w, &f->adef_weights, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_add_attachment, INVALID, defsim_world_add_attachment(f->w, &f->adef_badvertex, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_add_attachment, STALE, defsim_world_add_attachment(f->w, &f->adef_foreign, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_add_attachment, STALE, defsim_world_add_attachment(f->w, &f->adef_stale_target, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_add_attachment, STALE, defsim_world_add_attachment(f->w2, &f->adef, NULL)) \
    LOCKED(X, defsim_world_add_attachment, &f->adef, NULL)                                      \
    BADW(X, defsim_world_remove_attachment, INVALID, f->att)                                    \
    X(CTX_DIRECT, 0, defsim_world_remove_attachment, STALE, defsim_world_remove_attachment(f->w, f->att_null)) \
    X(CTX_DIRECT, 0, defsim_world_remove_attachment, STALE, defsim_world_remove_attachment(f->w, f->att_stale)) \
    X(CTX_DIRECT, 0, defsim_world_remove_attachment, STALE, defsim_world_remove_attachment(f->w, f->att_foreign)) \
    X(CTX_DIRECT, 0, defsim_world_remove_attachment, STALE, defsim_world_remove_attachment(f->w2, f->att)) \
    LOCKED(X, defsim_world_remove_attachment, f->att)                                           \
    BADW(X, defsim_attachment_set_target, INVALID, f->att, f->p3)                               \
    X(CTX_DIRECT, 0, defsim_attachment_set_target, INVALID, defsim_attachment_set_target(f->w, f->att, NULL)) \
    X(CTX_DIRECT, 0, defsim_attachment_set_target, INVALID, defsim_attachment_set_target(f->w, f->att, f->nan3)) \
    X(CTX_DIRECT, 0, defsim_attachment_set_target, INVALID, defsim_attachment_set_target(f->w, f->att, f->inf3)) \
    X(CTX_DIRECT, 0, defsim_attachment_set_target, STALE, defsim_attachment_set_target(f->w, f->att_stale, f->p3)) \
    X(CTX_DIRECT, 0, defsim_attachment_set_target, STALE, defsim_attachment_set_target(f->w, f->att_foreign, f->p3)) \
    LOCKED(X, defsim_attachment_set_target, f->att, f->p3)                                      \
    BADW(X, defsim_world_get_attachment_force, INVALID, f->att, f->p3)                          \
    X(CTX_DIRECT, 0, defsim_world_get_attachment_force, INVALID, defsim_world_get_attachment_force(f->w, f->att, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_get_attachment_force, STALE, defsim_world_get_attachment_force(f->w, f->att_null, f->buf)) \
    X(CTX_DIRECT, 0, defsim_world_get_attachment_force, STALE, defsim_world_get_attachment_force(f->w, f->att_foreign, f->buf)) \
    X(CTX_FORCE, 0, defsim_world_get_attachment_force, OK, defsim_world_get_attachment_force(f->w, f->att, f->buf)) \
    /* coupling: read-back */                                                                   \
    BADW(X, defsim_world_get_pin_forces, INVALID, f->buf, f->nv)                                \
    X(CTX_DIRECT, 0, defsim_world_get_pin_forces, INVALID, defsim_world_get_pin_forces(f->w, NULL, f->nv)) \
    X(CTX_DIRECT, 0, defsim_world_get_pin_forces, INVALID, defsim_world_get_pin_forces(f->w, f->buf, f->nv + 1)) \
    X(CTX_DIRECT, 0, defsim_world_get_pin_forces, INVALID, defsim_world_get_pin_forces(f->w, f->buf, -1)) \
    LOCKED(X, defsim_world_get_pin_forces, f->buf, f->nv)                                       \
    BADW(X, defsim_body_element_stress, INVALID, f->box, f->buf, NULL, NULL, f->nt)             \
    X(CTX_DIRECT, 0, defsim_body_element_stress, INVALID, defsim_body_element_stress(f->w, f->box, f->buf, NULL, NULL, f->nt + 1)) \
    X(CTX_DIRECT, 0, defsim_body_element_stress, INVALID, defsim_body_element_stress(f->w, f->box, f->buf, NULL, NULL, -1)) \
    X(CTX_DIRECT, 0, defsim_body_element_stress, STALE, defsim_body_element_stress(f->w, f->stale, NULL, NULL, NULL, 0)) \
    X(CTX_DIRECT, 0, defsim_body_element_stress, STALE, defsim_body_element_stress(f->w, f->foreign, NULL, NULL, NULL, 0)) \
    X(CTX_LOG, 0, defsim_body_element_stress, OK, defsim_body_element_stress(f->w, f->box, f->buf, NULL, NULL, f->nt)) \
    /* colliders */                                                                             \
    X(CTX_DIRECT, F_VALUE, defsim_collider_def_init, 0, (defsim_collider_def_init(NULL, sizeof f->cdef), 0)) \
    BADW(X, defsim_world_add_collider, INVALID, &f->cdef, NULL)                                 \
    X(CTX_DIRECT, 0, defsim_world_add_collider, INVALID, defsim_world_add_collider(f->w, NULL, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_add_collider, INVALID, defsim_world_add_collider(f->w, &f->cdef_size0, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_add_collider, INVALID, defsim_world_add_collider(f->w, &f->cdef_nan, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_add_collider, INVALID, defsim_world_add_collider(f->w, &f->cdef_shape, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_add_collider, INVALID, defsim_world_add_collider(f->w, &f->cdef_radius, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_add_collider, INVALID, defsim_world_add_collider(f->w, &f->cdef_quat, NULL)) \
    LOCKED(X, defsim_world_add_collider, &f->cdef, NULL)                                        \
    BADW(X, defsim_world_remove_collider, INVALID, f->col)                                      \
    X(CTX_DIRECT, 0, defsim_world_remove_collider, STALE, defsim_world_remove_collider(f->w, f->col_null)) \
    X(CTX_DIRECT, 0, defsim_world_remove_collider, STALE, defsim_world_remove_collider(f->w, f->col_stale)) \
    X(CTX_DIRECT, 0, defsim_world_remove_collider, STALE, defsim_world_remove_collider(f->w, f->col_foreign)) \
    X(CTX_DIRECT, 0, defsim_world_remove_collider, STALE, defsim_world_remove_collider(f->w2, f->col)) \
    LOCKED(X, defsim_world_remove_collider, f->col)                                             \
    BADW(X, defsim_collider_set_pose, INVALID, f->col, f->p3, f->quat_id)                       \
    X(CTX_DIRECT, 0, defsim_collider_set_pose, INVALID, defsim_collider_set_pose(f->w, f->col, NULL, f->quat_id)) \
    X(CTX_DIRECT, 0, defsim_collider_set_pose, INVALID, defsim_collider_set_pose(f->w, f->col, f->p3, NULL)) \
    X(CTX_DIRECT, 0, defsim_collider_set_pose, INVALID, defsim_collider_set_pose(f->w, f->col, f->nan3, f->quat_id)) \
    X(CTX_DIRECT, 0, defsim_collider_set_pose, INVALID, defsim_collider_set_pose(f->w, f->col, f->p3, f->quat_bad)) \
    X(CTX_DIRECT, 0, defsim_collider_set_pose, STALE, defsim_collider_set_pose(f->w, f->col_stale, f->p3, f->quat_id)) \
    X(CTX_DIRECT, 0, defsim_collider_set_pose, STALE, defsim_collider_set_pose(f->w, f->col_foreign, f->p3, f->quat_id)) \
    LOCKED(X, defsim_collider_set_pose, f->col, f->p3, f->quat_id)                              \
    BADW1(X, F_VALUE, defsim_world_collider_count, 0)                                           \
    X(CTX_LOG, F_VALUE, defsim_world_collider_count, 1, defsim_world_collider_count(f->w))     \
    BADW(X, defsim_world_get_collider, INVALID, 0, &f->col_out, NULL)                           \
    X(CTX_DIRECT, 0, defsim_world_get_collider, INVALID, defsim_world_get_collider(f->w, -1, &f->col_out, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_get_collider, INVALID, defsim_world_get_collider(f->w, 1, &f->col_out, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_get_collider, INVALID, defsim_world_get_collider(f->w, 0, NULL, &f->cdef_out0)) \
    X(CTX_FORCE, 0, defsim_world_get_collider, OK, defsim_world_get_collider(f->w, 0, &f->col_out, NULL)) \
    BADW(X, defsim_world_get_contact_forces, INVALID, f->buf, f->nv)                            \
    X(CTX_DIRECT, 0, defsim_world_get_contact_forces, INVALID, defsim_world_get_contact_forces(f->w, NULL, f->nv)) \
    X(CTX_DIRECT, 0, defsim_world_get_contact_forces, INVALID, defsim_world_get_contact_forces(f->w, f->buf, f->nv - 1)) \
    X(CTX_FORCE, 0, defsim_world_get_contact_forces, OK, defsim_world_get_contact_forces(f->w, f->buf, f->nv)) \
    /* input limits, log sink */                                                                \
    X(CTX_DIRECT, 0, defsim_set_limit, INVALID, defsim_set_limit((defsim_limit)7, 1))           \
    X(CTX_DIRECT, 0, defsim_set_limit, INVALID, defsim_set_limit(DEFSIM_LIMIT_VERTICES, 0))     \
    X(CTX_DIRECT, 0, defsim_set_limit, INVALID, defsim_set_limit(DEFSIM_LIMIT_VERTICES, INT64_MAX)) \
    X(CTX_DIRECT, F_VALUE, defsim_get_limit, 1, defsim_get_limit((defsim_limit)-1) == -1)       \
    BADW(X, defsim_world_set_log, INVALID, NULL, NULL)                                          \
    LOCKED(X, defsim_world_set_log, NULL, NULL)                                                 \
    /* checkpoints */                                                                           \
    BADW(X, defsim_world_save, INVALID, "misuse.dfck")                                          \
    X(CTX_DIRECT, 0, defsim_world_save, INVALID, defsim_world_save(f->w, NULL))                 \
    X(CTX_DIRECT, 0, defsim_world_save, INVALID, defsim_world_save(f->w, ""))                   \
    X(CTX_DIRECT, 0, defsim_world_save, DEFSIM_ERR_IO, defsim_world_save(f->w, "/nonexistent-dir/x.dfck")) \
    LOCKED(X, defsim_world_save, "misuse.dfck")                                                 \
    BADW(X, defsim_world_save_buffer, INVALID, &f->data, &f->size)                              \
    X(CTX_DIRECT, 0, defsim_world_save_buffer, INVALID, defsim_world_save_buffer(f->w, NULL, &f->size)) \
    X(CTX_DIRECT, 0, defsim_world_save_buffer, INVALID, defsim_world_save_buffer(f->w, &f->data, NULL)) \
    LOCKED(X, defsim_world_save_buffer, &f->data, &f->size)                                     \
    X(CTX_DIRECT, F_VALUE, defsim_buffer_free, 1, (defsim_buffer_free(NULL), 1))                \
    X(CTX_DIRECT, 0, defsim_world_load, INVALID, defsim_world_load(NULL, NULL, NULL, &f->out_world)) \
    X(CTX_DIRECT, 0, defsim_world_load, INVALID, defsim_world_load("x.dfck", NULL, NULL, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_load, DEFSIM_ERR_IO, defsim_world_load("/nonexistent-dir/x.dfck", NULL, NULL, &f->out_world)) \
    X(CTX_DIRECT, 0, defsim_world_load_buffer, INVALID, defsim_world_load_buffer(NULL, 16, NULL, NULL, &f->out_world)) \
    X(CTX_DIRECT, 0, defsim_world_load_buffer, INVALID, defsim_world_load_buffer(f->junk, sizeof f->junk, NULL, NULL, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_load_buffer, DEFSIM_ERR_IO, defsim_world_load_buffer(f->junk, sizeof f->junk, NULL, NULL, &f->out_world)) \
    BADW(X, defsim_collider_set_sdf, INVALID, f->col, sdf_dummy, NULL)                          \
    X(CTX_DIRECT, 0, defsim_collider_set_sdf, INVALID, defsim_collider_set_sdf(f->w, f->col, sdf_dummy, NULL)) \
    X(CTX_DIRECT, 0, defsim_collider_set_sdf, STALE, defsim_collider_set_sdf(f->w, f->col_stale, sdf_dummy, NULL)) \
    X(CTX_DIRECT, 0, defsim_collider_set_sdf, STALE, defsim_collider_set_sdf(f->w, f->col_foreign, sdf_dummy, NULL)) \
    LOCKED(X, defsim_collider_set_sdf, f->col, sdf_dummy, NULL)                                 \
    BADW1(X, F_VALUE, defsim_world_body_count, 0)                                               \
    X(CTX_LOG, F_VALUE, defsim_world_body_count, 1, defsim_world_body_count(f->w) >= 1)         \
    BADW(X, defsim_world_body_at, INVALID, 0, &f->body_out)                                     \
    X(CTX_DIRECT, 0, defsim_world_body_at, INVALID, defsim_world_body_at(f->w, -1, &f->body_out)) \
    X(CTX_DIRECT, 0, defsim_world_body_at, INVALID, defsim_world_body_at(f->w, 1000, &f->body_out)) \
    X(CTX_DIRECT, 0, defsim_world_body_at, INVALID, defsim_world_body_at(f->w, 0, NULL))        \
    X(CTX_FORCE, 0, defsim_world_body_at, OK, defsim_world_body_at(f->w, 0, &f->body_out))      \
    BADW1(X, F_VALUE, defsim_world_attachment_count, 0)                                         \
    X(CTX_LOG, F_VALUE, defsim_world_attachment_count, 1, defsim_world_attachment_count(f->w) >= 1) \
    BADW(X, defsim_world_attachment_at, INVALID, 0, &f->att_out)                                \
    X(CTX_DIRECT, 0, defsim_world_attachment_at, INVALID, defsim_world_attachment_at(f->w, -1, &f->att_out)) \
    X(CTX_DIRECT, 0, defsim_world_attachment_at, INVALID, defsim_world_attachment_at(f->w, 1000, &f->att_out)) \
    X(CTX_DIRECT, 0, defsim_world_attachment_at, INVALID, defsim_world_attachment_at(f->w, 0, NULL)) \
    /* what writers of frames read back (issue 28) */                                           \
    BADW(X, defsim_world_get_pinned, INVALID, (uint8_t *)f->buf, f->nv)                         \
    X(CTX_DIRECT, 0, defsim_world_get_pinned, INVALID, defsim_world_get_pinned(f->w, NULL, f->nv)) \
    X(CTX_DIRECT, 0, defsim_world_get_pinned, INVALID, defsim_world_get_pinned(f->w, (uint8_t *)f->buf, f->nv + 1)) \
    X(CTX_FORCE, 0, defsim_world_get_pinned, OK, defsim_world_get_pinned(f->w, (uint8_t *)f->buf, f->nv)) \
    BADW(X, defsim_world_get_attachment, INVALID, f->att, &f->adef_out)                         \
    X(CTX_DIRECT, 0, defsim_world_get_attachment, INVALID, defsim_world_get_attachment(f->w, f->att, NULL)) \
    X(CTX_DIRECT, 0, defsim_world_get_attachment, INVALID, defsim_world_get_attachment(f->w, f->att, &f->adef_size0)) \
    X(CTX_DIRECT, 0, defsim_world_get_attachment, STALE, defsim_world_get_attachment(f->w, f->att_null, &f->adef_out)) \
    X(CTX_DIRECT, 0, defsim_world_get_attachment, STALE, defsim_world_get_attachment(f->w, f->att_foreign, &f->adef_out)) \
    X(CTX_LOG, 0, defsim_world_get_attachment, OK, defsim_world_get_attachment(f->w, f->att, &f->adef_out)) \
    /* gradients through a run (issue 25): the fixture's world has a callback and attachments */ \
    X(CTX_DIRECT, F_VALUE, defsim_tape_def_init, 0, (defsim_tape_def_init(NULL, sizeof(defsim_tape_def)), 0)) \
    BADW(X, defsim_world_record, INVALID, NULL, &f->tape_out)                                   \
    X(CTX_DIRECT, 0, defsim_world_record, INVALID, defsim_world_record(f->w, NULL, NULL))       \
    X(CTX_DIRECT, 0, defsim_world_record, INVALID, defsim_world_record(f->e, NULL, &f->tape_out)) \
    X(CTX_DIRECT, 0, defsim_world_record, DEFSIM_ERR_UNSUPPORTED, defsim_world_record(f->w, NULL, &f->tape_out)) \
    LOCKED(X, defsim_world_record, NULL, &f->tape_out)                                           \
    X(CTX_DIRECT, 0, defsim_tape_backward, INVALID, defsim_tape_backward(NULL, f->buf, NULL, 3, NULL, 0)) \
    X(CTX_DIRECT, 0, defsim_tape_get_stats, INVALID, defsim_tape_get_stats(NULL, &f->tape_stats)) \
    X(CTX_DIRECT, F_VALUE, defsim_tape_last_error, 1, defsim_tape_last_error(NULL)[0] == '\0') \
    X(CTX_DIRECT, F_VALUE, defsim_tape_destroy, 0, (defsim_tape_destroy(NULL), 0))            \
    /* measured fabrics */                                                                      \
    X(CTX_DIRECT, F_VALUE, defsim_fabric_count, 1, defsim_fabric_count() > 0)                   \
    X(CTX_DIRECT, 0, defsim_fabric_get, INVALID, defsim_fabric_get(0, NULL))                    \
    X(CTX_DIRECT, 0, defsim_fabric_find, INVALID, defsim_fabric_find("denim", NULL))            \
    X(CTX_DIRECT, 0, defsim_body_def_set_fabric, INVALID, defsim_body_def_set_fabric(NULL, "denim"))

typedef struct row {
    int ctx, flags;
    const char *fn;
    int64_t expect;
    const char *call;
} row;

static int jac_cb(void *user, const double *x, const double *v, double t, int32_t n,
                  double *blocks)
{
    (void)user; (void)x; (void)v; (void)t; (void)n; (void)blocks;
    return 0;
}

#define META(ctx, flags, fn, expect, call) {ctx, flags, #fn, (int64_t)(expect), #call},
static const row ROWS[] = {MISUSE_ROWS(META)};
#define NROWS ((int)(sizeof ROWS / sizeof ROWS[0]))

/* Runs row i: the call of the table, as an integer. */
static int64_t run_row(int i, fx *f)
{
    int k = 0;
#define CASE(ctx, flags, fn, expect, call) \
    if (i == k++) { (void)(fn); return (int64_t)(call); }
    MISUSE_ROWS(CASE)
#undef CASE
    fail_msg("no row %d", i);
    return INT64_MIN;
}

/* ------------------------------------------------------------------------------------------ */
/* The fixture */

static void log_cb(void *user, int level, const char *message)
{
    (void)level; (void)message;
    fx *f = user;
    if (f->pending < 0 || ROWS[f->pending].ctx != CTX_LOG) return;
    const int i = f->pending;
    f->pending = -1;
    f->observed = run_row(i, f);
    f->ran = 1;
}

/* The force callback of a row run from inside it: runs the row, then fails the step (which
 * rolls the state back, so that the world must be as before). A row from inside the log
 * callback only needs the step to fail: the failure is logged. */
static int force_cb(void *user, const double *x, const double *v, double t, int32_t n,
                    double *f_inout)
{
    (void)x; (void)v; (void)t; (void)n; (void)f_inout;
    fx *f = user;
    if (f->pending >= 0 && ROWS[f->pending].ctx == CTX_FORCE) {
        const int i = f->pending;
        f->pending = -1;
        f->observed = run_row(i, f);
        f->ran = 1;
    }
    return 1;
}

static defsim_world *make_world(fx *f)
{
    defsim_world_def d = tu_world_def("symplectic_euler", -9.81, 1);
    d.log = log_cb;
    d.log_user = f;
    return tu_create(&d);
}

static const double LO[3] = {0, 0, 0}, HI[3] = {0.2, 0.1, 0.1};
static const double ROPE_X[9] = {0, 1, 0, 0.1, 1, 0, 0.2, 1, 0};
static const int32_t ROPE_S[4] = {0, 1, 1, 2};

static defsim_body_def rope_def(void)
{
    defsim_body_def d;
    defsim_body_def_init(&d, sizeof d);
    defsim_material_init(&d.material, sizeof d.material, DEFSIM_MODEL_SPRING);
    d.rest_positions = ROPE_X;
    d.vertex_count = 3;
    d.springs = ROPE_S;
    d.spring_count = 2;
    return d;
}

static int setup(void **state)
{
    fx *f = calloc(1, sizeof *f);
    F = f;
    f->pending = -1;
    f->w = make_world(f);
    f->w2 = make_world(f);
    f->e = make_world(f);
    dead_world.magic = DEFSIM__WORLD_DEAD;
    f->dead = &dead_world;
    memset(alien_bytes, 0x5a, sizeof alien_bytes);
    f->alien = (defsim_world *)(void *)alien_bytes;

    /* w: a box of tets, a pinned rope, an attachment, external forces; a stale body id */
    f->box = tu_add_box(f->w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 2, 1, 1, LO, HI, 1e5, 0.3, 1000);
    defsim_body_def rd = rope_def();
    defsim_body_id gone;
    TU_OK(defsim_world_add_body(f->w, &rd, &gone));
    TU_OK(defsim_world_add_body(f->w, &rd, &f->rope));
    TU_OK(defsim_world_remove_body(f->w, gone));
    f->stale = gone;
    const int32_t pin0 = 0;
    TU_OK(defsim_body_pin(f->w, f->rope, &pin0, 1));
    f->nv = defsim_world_vertex_count(f->w);
    f->nt = 2 * 6;
    assert_true(3 * f->nv <= BUF);
    defsim_attachment_def_init(&f->adef, sizeof f->adef);
    f->adef.body = f->box;
    f->adef.vertex = 1;
    f->adef.target[1] = 0.5;
    defsim_attachment_id tmp;
    TU_OK(defsim_world_add_attachment(f->w, &f->adef, &tmp));
    TU_OK(defsim_world_add_attachment(f->w, &f->adef, &f->att));
    TU_OK(defsim_world_remove_attachment(f->w, tmp));
    f->att_stale = tmp;
    double *fe = calloc(3 * (size_t)f->nv, sizeof *fe);
    for (int i = 0; i < 3 * f->nv; ++i) fe[i] = 0.01 * (i % 7);
    TU_OK(defsim_world_set_external_forces(f->w, fe, f->nv));
    free(fe);
    /* a ground plane far below, a stale collider id */
    defsim_collider_def_init(&f->cdef, sizeof f->cdef);
    f->cdef.position[1] = -100.0;
    TU_OK(defsim_world_add_collider(f->w, &f->cdef, &f->col_stale));
    TU_OK(defsim_world_add_collider(f->w, &f->cdef, &f->col));
    TU_OK(defsim_world_remove_collider(f->w, f->col_stale));
    TU_OK(defsim_world_step(f->w, H));   /* planned, backend ready, moving */

    /* w2: a body and an attachment of its own, whose ids must be stale in w */
    f->foreign = tu_add_box(f->w2, DEFSIM_MODEL_COROTATED, 1, 1, 1, LO, HI, 1e5, 0.3, 1000);
    defsim_attachment_def ad = f->adef;
    ad.body = f->foreign;
    TU_OK(defsim_world_add_attachment(f->w2, &ad, &f->att_foreign));
    TU_OK(defsim_world_add_collider(f->w2, &f->cdef, &f->col_foreign));
    f->nv2 = defsim_world_vertex_count(f->w2);

    /* scratch inputs */
    TU_OK(defsim_world_get_positions(f->w, f->buf, f->nv));
    memcpy(f->x_nan, f->buf, 3 * (size_t)f->nv * sizeof *f->x_nan);
    f->x_nan[3 * f->nv - 2] = NAN;
    memset(f->f_inf, 0, sizeof f->f_inf);
    f->f_inf[4] = INFINITY;
    f->verts[0] = 0; f->verts[1] = 1;
    f->bad_verts[0] = 99; f->bad_verts[1] = 1;
    for (int c = 0; c < 3; ++c) {
        f->p3[c] = c == 1 ? 1.0 : 0.0;
        f->nan3[c] = c == 2 ? NAN : 0.5;
        f->inf3[c] = c == 0 ? INFINITY : 1.0;
        f->unit3[c] = 1.0;
    }
    f->unit3[1] = 0.0;   /* u = (1, 0, 1), v = p3 = (0, 1, 0): they span a plane */

    f->bdef = rope_def();
    f->bdef_size0 = f->bdef;
    f->bdef_size0.size = 0;
    f->bdef_negcount = f->bdef;
    f->bdef_negcount.vertex_count = -3;
    for (int i = 0; i < 6; ++i) f->rest2[i] = f->rest2_nan[i] = (double)(i == 3);
    f->rest2_nan[4] = NAN;
    f->spring01[0] = 0; f->spring01[1] = 1;
    f->spring05[0] = 0; f->spring05[1] = 5;
    f->kneg[0] = -1.0;
    f->bdef_nan = f->bdef;
    f->bdef_nan.rest_positions = f->rest2_nan;
    f->bdef_nan.vertex_count = 2;
    f->bdef_nan.springs = f->spring01;
    f->bdef_nan.spring_count = 1;
    f->bdef_badidx = f->bdef_nan;
    f->bdef_badidx.rest_positions = f->rest2;
    f->bdef_badidx.springs = f->spring05;
    f->bdef_badk = f->bdef_badidx;
    f->bdef_badk.springs = f->spring01;
    f->bdef_badk.spring_stiffness = f->kneg;

    f->adef_foreign = f->adef;
    f->adef_foreign.body = f->foreign;
    f->adef_stale_target = f->adef;
    f->adef_stale_target.target_body = f->stale;
    f->adef_stale_target.target_vertex_count = 1;
    f->adef_stale_target.target_weights[0] = 1.0;
    f->adef_nan_k = f->adef;
    f->adef_nan_k.stiffness = NAN;
    f->adef_weights = f->adef;
    f->adef_weights.target_body = f->rope;
    f->adef_weights.target_vertex_count = 2;
    f->adef_weights.target_vertices[1] = 1;
    f->adef_weights.target_weights[0] = f->adef_weights.target_weights[1] = 0.3;
    f->adef_badvertex = f->adef;
    f->adef_badvertex.vertex = 1000;
    f->adef_size0 = f->adef;
    f->adef_size0.size = 0;
    defsim_attachment_def_init(&f->adef_out, sizeof f->adef_out);

    f->cdef_size0 = f->cdef;
    f->cdef_size0.size = 0;
    f->cdef_nan = f->cdef;
    f->cdef_nan.position[0] = NAN;
    f->cdef_shape = f->cdef;
    f->cdef_shape.shape = (defsim_shape)99;
    f->cdef_radius = f->cdef;
    f->cdef_radius.shape = DEFSIM_SHAPE_SPHERE;
    f->cdef_radius.radius = -1.0;
    f->cdef_quat = f->cdef;
    f->cdef_quat.rotation[0] = 2.0;
    f->cdef_out0.size = 0;
    f->quat_id[0] = 1.0;
    f->quat_bad[0] = f->quat_bad[1] = 1.0;

    f->wdef = tu_world_def("symplectic_euler", -9.81, 1);
    f->wdef_size0 = f->wdef;
    f->wdef_size0.size = 0;
    f->wdef_nan_g = f->wdef;
    f->wdef_nan_g.gravity[2] = NAN;
    f->wdef_backend = f->wdef;
    f->wdef_backend.backend = "no_such_backend";
    f->wdef_threads = f->wdef;
    f->wdef_threads.num_threads = -2;
    f->wdef_nobackend = f->wdef;
    f->wdef_nobackend.backend = NULL;

    defsim_material_init(&f->mat, sizeof f->mat, DEFSIM_MODEL_STVK);
    defsim_material_init(&f->mat_spring, sizeof f->mat_spring, DEFSIM_MODEL_SPRING);
    defsim_material_init(&f->mat_nh, sizeof f->mat_nh, DEFSIM_MODEL_NEOHOOKEAN);
    f->mat_bad = f->mat;
    f->mat_bad.poisson_ratio = 0.5;
    for (int i = 0; i < 9; ++i) f->F_id[i] = f->F_nan[i] = f->F_inv[i] = (double)(i % 4 == 0);
    f->F_nan[5] = NAN;
    f->F_inv[0] = -1.0;
    f->mesh.size = sizeof f->mesh;
    f->stats.size = sizeof f->stats;
    f->oinfo.size = sizeof f->oinfo;
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    fx *f = *state;
    defsim_world_destroy(f->w);
    defsim_world_destroy(f->w2);
    defsim_world_destroy(f->e);
    free(f);
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* What "unchanged" means: the state exactly, the model by a digest */

typedef struct snapshot {
    double *x, *v;
    double t;
    int32_t nv;
    uint64_t model;
} snapshot;

static void mix(uint64_t *h, const void *p, size_t n)
{
    const unsigned char *b = p;
    for (size_t i = 0; i < n; ++i) *h = (*h ^ b[i]) * 0x100000001b3ull;
}

static uint64_t model_digest(const defsim_world *w)
{
    uint64_t h = 0xcbf29ce484222325ull;
    mix(&h, &w->magic, sizeof w->magic);
    mix(&h, &w->bodies.ids.tag, sizeof w->bodies.ids.tag);
    mix(&h, &w->nv, sizeof w->nv);
    mix(&h, &w->bodies.n, sizeof w->bodies.n);
    mix(&h, &w->bodies.ids.nslots, sizeof w->bodies.ids.nslots);
    mix(&h, w->bodies.ids.gen, (size_t)w->bodies.ids.nslots * sizeof *w->bodies.ids.gen);
    mix(&h, w->bodies.ids.dense, (size_t)w->bodies.ids.nslots * sizeof *w->bodies.ids.dense);
    for (int32_t b = 0; b < w->bodies.n; ++b) {
        const defsim__body *bd = &w->bodies.b[b];
        mix(&h, &bd->generation, sizeof bd->generation);
        mix(&h, &bd->nv, sizeof bd->nv);
        mix(&h, &bd->nt, sizeof bd->nt);
        mix(&h, &bd->ns, sizeof bd->ns);
        mix(&h, &bd->offset, sizeof bd->offset);
        mix(&h, bd->rest, 3 * (size_t)bd->nv * sizeof *bd->rest);
        mix(&h, bd->mass, (size_t)bd->nv * sizeof *bd->mass);
        mix(&h, bd->pinned, (size_t)bd->nv);
        mix(&h, bd->tets, 4 * (size_t)bd->nt * sizeof *bd->tets);
        mix(&h, bd->springs, 2 * (size_t)bd->ns * sizeof *bd->springs);
        mix(&h, bd->k, (size_t)bd->ns * sizeof *bd->k);
        mix(&h, &bd->mat.youngs_modulus, sizeof(double) * 7);
        mix(&h, &bd->mat.model, sizeof bd->mat.model);
    }
    mix(&h, w->bodies.mass, (size_t)w->nv * sizeof *w->bodies.mass);
    mix(&h, w->bodies.pinned, (size_t)w->nv);
    mix(&h, &w->coupling.fext_nonzero, sizeof w->coupling.fext_nonzero);
    if (w->coupling.fext) mix(&h, w->coupling.fext, 3 * (size_t)w->nv * sizeof *w->coupling.fext);
    mix(&h, &w->coupling.natt, sizeof w->coupling.natt);
    for (int32_t i = 0; i < w->coupling.natt; ++i) {
        const defsim__attachment *a = &w->coupling.att[i];
        mix(&h, &a->generation, sizeof a->generation);
        if (!(a->generation & 1u)) continue;
        mix(&h, &a->def.body, sizeof a->def.body);
        mix(&h, &a->def.vertex, sizeof a->def.vertex);
        mix(&h, &a->def.stiffness, sizeof a->def.stiffness);
        mix(&h, &a->def.damping, sizeof a->def.damping);
        mix(&h, a->def.target, sizeof a->def.target);
        mix(&h, &a->def.target_body, sizeof a->def.target_body);
        mix(&h, &a->def.target_vertex_count, sizeof a->def.target_vertex_count);
        mix(&h, a->def.target_vertices, sizeof a->def.target_vertices);
        mix(&h, a->def.target_weights, sizeof a->def.target_weights);
    }
    mix(&h, &w->colliders.ncol, sizeof w->colliders.ncol);
    for (int32_t i = 0; i < w->colliders.ncol; ++i) {
        const defsim__collider *c = &w->colliders.col[i];
        mix(&h, &c->generation, sizeof c->generation);
        if (!(c->generation & 1u)) continue;
        mix(&h, &c->def.shape, sizeof c->def.shape);
        mix(&h, c->def.normal, sizeof c->def.normal);
        mix(&h, &c->def.radius, sizeof c->def.radius);
        mix(&h, &c->def.friction, sizeof c->def.friction);
        mix(&h, c->pos, sizeof c->pos);
        mix(&h, c->rot, sizeof c->rot);
        mix(&h, c->pos1, sizeof c->pos1);
        mix(&h, c->rot1, sizeof c->rot1);
    }
    mix(&h, &w->coupling.ntargeted, sizeof w->coupling.ntargeted);
    if (w->coupling.targeted) mix(&h, w->coupling.targeted, (size_t)w->nv);
    mix(&h, &w->coupling.cpl.fn, sizeof w->coupling.cpl.fn);
    mix(&h, &w->coupling.cpl.jac, sizeof w->coupling.cpl.jac);
    mix(&h, &w->coupling.cpl.user, sizeof w->coupling.cpl.user);
    mix(&h, &w->msg->locked, sizeof w->msg->locked);
    const int32_t no = defsim_world_option_count(w);
    for (int32_t i = 0; i < no; ++i) {
        defsim_option_info info;
        info.size = sizeof info;
        TU_OK(defsim_world_option_info(w, i, &info));
        mix(&h, &info.value, sizeof info.value);
    }
    return h;
}

static snapshot snap(const defsim_world *w)
{
    snapshot s;
    s.nv = defsim_world_vertex_count(w);
    const size_t n = 3 * (size_t)(s.nv > 0 ? s.nv : 1);
    s.x = malloc(n * sizeof *s.x);
    s.v = malloc(n * sizeof *s.v);
    TU_OK(defsim_world_get_positions(w, s.x, s.nv));
    TU_OK(defsim_world_get_velocities(w, s.v, s.nv));
    s.t = defsim_world_time(w);
    s.model = model_digest(w);
    return s;
}

/* 1 if w is as in s: the same vertex count, time, positions and velocities bit for bit, and
 * the same model digest. */
static int same(const defsim_world *w, const snapshot *s)
{
    snapshot now = snap(w);
    int ok = now.nv == s->nv && now.t == s->t && now.model == s->model &&
             memcmp(now.x, s->x, 3 * (size_t)s->nv * sizeof *s->x) == 0 &&
             memcmp(now.v, s->v, 3 * (size_t)s->nv * sizeof *s->v) == 0;
    free(now.x);
    free(now.v);
    return ok;
}

static void drop(snapshot *s)
{
    free(s->x);
    free(s->v);
}

/* ------------------------------------------------------------------------------------------ */
/* The table test */

/* Runs row i where its context says; returns what it gave. */
static int64_t call_row(fx *f, int i)
{
    const row *r = &ROWS[i];
    if (r->ctx == CTX_DIRECT) return run_row(i, f);
    f->pending = i;
    f->ran = 0;
    TU_OK(defsim_world_set_force_callback(f->w, force_cb, NULL, f));
    const defsim_status st = defsim_world_step(f->w, H);
    TU_OK(defsim_world_set_force_callback(f->w, NULL, NULL, NULL));
    if (st != DEFSIM_ERR_CALLBACK || !f->ran)
        fail_msg("row %d (%s): the step gave %d and the row ran %d times", i, r->call, (int)st,
                 f->ran);
    f->pending = -1;
    return f->observed;
}

static void test_table(void **state)
{
    fx *f = *state;
    int failures = 0;
    for (int i = 0; i < NROWS; ++i) {
        const row *r = &ROWS[i];
        snapshot s[3] = {snap(f->w), snap(f->w2), snap(f->e)};
        defsim_world *worlds[3] = {f->w, f->w2, f->e};
        const int64_t got = call_row(f, i);
        if (got != r->expect) {
            printf("row %d: %s [%s] gave %lld, expected %lld\n", i, r->call,
                   r->ctx == CTX_LOG ? "in log callback" : r->ctx == CTX_FORCE ? "in force callback"
                                                                               : "direct",
                   (long long)got, (long long)r->expect);
            ++failures;
        }
        for (int k = 0; k < 3; ++k) {
            if (!(r->flags & F_CHANGES) && !same(worlds[k], &s[k])) {
                printf("row %d: %s changed world %d\n", i, r->call, k);
                ++failures;
            }
            assert_int_equal(worlds[k]->msg->locked, 0);
            drop(&s[k]);
        }
    }
    /* the summary that docs/errors.md quotes */
    int by_status[16] = {0}, by_ctx[3] = {0}, values = 0;
    for (int i = 0; i < NROWS; ++i) {
        by_ctx[ROWS[i].ctx]++;
        if (ROWS[i].flags & F_VALUE) ++values;
        else if (ROWS[i].expect <= 0 && ROWS[i].expect > -16) by_status[-ROWS[i].expect]++;
    }
    for (int k = 0; k < 16; ++k)
        if (by_status[k])
            printf("  %-28s %3d rows\n", defsim_status_string((defsim_status)-k), by_status[k]);
    printf("  %-28s %3d rows\n", "(a value, not a status)", values);
    printf("  direct %d, from the log callback %d, from the force callback %d\n",
           by_ctx[CTX_DIRECT], by_ctx[CTX_LOG], by_ctx[CTX_FORCE]);
    printf("%d rows, %d failures\n", NROWS, failures);
    assert_int_equal(failures, 0);
    /* The fixture is still usable: the lock is released, the world steps. */
    TU_OK(defsim_world_step(f->w, H));
}

/* ------------------------------------------------------------------------------------------ */
/* The header agrees with the table */

typedef struct api_fn {
    char name[96];
    char errors[64][48];   /* DEFSIM_ERR_* named in its Errors line */
    int nerrors;
    char same_as[96];      /* "Same errors as defsim_x" */
    int rows;
} api_fn;

static char *read_text(const char *path)
{
    FILE *fp = fopen(path, "rb");
    if (!fp) return NULL;
    fseek(fp, 0, SEEK_END);
    const long n = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    char *s = malloc((size_t)n + 1);
    const size_t got = fread(s, 1, (size_t)n, fp);
    s[got] = '\0';
    fclose(fp);
    return s;
}

static int ident_char(char c) { return isalnum((unsigned char)c) || c == '_'; }

/* Parses every "DEFSIM_API ... name(" declaration and the "///" block above it. */
static int parse_header(const char *text, api_fn *fns, int cap)
{
    int n = 0;
    const char *comment = NULL;   /* start of the current run of "///" lines */
    for (const char *line = text; *line;) {
        const char *end = strchr(line, '\n');
        if (!end) end = line + strlen(line);
        const char *p = line;
        while (*p == ' ') ++p;
        if (strncmp(p, "///", 3) == 0) {
            if (!comment) comment = line;
        } else if (strncmp(p, "DEFSIM_API ", 11) == 0) {
            const char *paren = strchr(p, '(');
            assert_non_null(paren);
            const char *q = paren;
            while (q > p && !ident_char(q[-1])) --q;
            const char *b = q;
            while (b > p && ident_char(b[-1])) --b;
            assert_true(n < cap);
            api_fn *fn = &fns[n++];
            memset(fn, 0, sizeof *fn);
            snprintf(fn->name, sizeof fn->name, "%.*s", (int)(q - b), b);
            /* the comment block: from "Errors:" (or from its start, for "Same ... as") */
            const size_t clen = comment ? (size_t)(line - comment) : 0;
            char *c = malloc(clen + 1);
            memcpy(c, comment ? comment : "", clen);
            c[clen] = '\0';
            const char *errors = strstr(c, "Errors:");
            for (const char *e = errors; e && (e = strstr(e, "DEFSIM_ERR_"));) {
                size_t k = 0;
                while (ident_char(e[k])) ++k;
                assert_true(fn->nerrors < 64);
                snprintf(fn->errors[fn->nerrors++], sizeof fn->errors[0], "%.*s", (int)k, e);
                e += k;
            }
            const char *same = strstr(c, "Same errors as");
            if (!same) same = strstr(c, "Same rules and errors as");
            if (!same) same = strstr(c, "Same rules as");
            if (same) {
                const char *d = strstr(same, "defsim_");
                assert_non_null(d);
                size_t k = 0;
                while (ident_char(d[k])) ++k;
                snprintf(fn->same_as, sizeof fn->same_as, "%.*s", (int)k, d);
            }
            free(c);
            comment = NULL;
        } else {
            comment = NULL;
        }
        line = *end ? end + 1 : end;
    }
    return n;
}

static api_fn *find_fn(api_fn *fns, int n, const char *name)
{
    for (int i = 0; i < n; ++i)
        if (strcmp(fns[i].name, name) == 0) return &fns[i];
    return NULL;
}

/* Status names by value, from the header's enum. */
static const char *status_name(const char *text, int64_t value, char *out, size_t cap)
{
    for (const char *e = text; (e = strstr(e, "DEFSIM_ERR_"));) {
        size_t k = 0;
        while (ident_char(e[k])) ++k;
        const char *q = e + k;
        while (*q == ' ') ++q;
        if (*q == '=' && strtoll(q + 1, NULL, 10) == value) {
            snprintf(out, cap, "%.*s", (int)k, e);
            return out;
        }
        e += k;
    }
    return NULL;
}

static int names_status(api_fn *fns, int n, const api_fn *fn, const char *status, int depth)
{
    for (int i = 0; i < fn->nerrors; ++i)
        if (strcmp(fn->errors[i], status) == 0) return 1;
    if (fn->same_as[0] && depth < 4) {
        const api_fn *o = find_fn(fns, n, fn->same_as);
        if (o) return names_status(fns, n, o, status, depth + 1);
    }
    return 0;
}

static void test_header_agrees(void **state)
{
    (void)state;
    char *text = read_text(DEFSIM_HEADER);
    assert_non_null(text);
    static api_fn fns[256];
    const int n = parse_header(text, fns, 256);
    assert_true(n >= 50);
    int failures = 0;
    for (int i = 0; i < NROWS; ++i) {
        api_fn *fn = find_fn(fns, n, ROWS[i].fn);
        if (!fn) {
            printf("row %d names %s, which is not declared in %s\n", i, ROWS[i].fn, DEFSIM_HEADER);
            ++failures;
            continue;
        }
        fn->rows++;
        if ((ROWS[i].flags & F_VALUE) || ROWS[i].expect == DEFSIM_OK) continue;
        char name[64];
        if (!status_name(text, ROWS[i].expect, name, sizeof name)) {
            printf("row %d (%s): %lld is no status of the header\n", i, ROWS[i].call,
                   (long long)ROWS[i].expect);
            ++failures;
        } else if (!names_status(fns, n, fn, name, 0)) {
            printf("row %d (%s): %s gives %s, which its Errors line in defsim.h does not name\n",
                   i, ROWS[i].call, fn->name, name);
            ++failures;
        }
    }
    for (int i = 0; i < n; ++i)
        if (fns[i].rows == 0) {
            printf("PUBLIC FUNCTION WITHOUT A MISUSE ROW: %s (add its rows to MISUSE_ROWS in "
                   "tests/unit/test_misuse.c)\n", fns[i].name);
            ++failures;
        }
    for (int i = 0; i < n; ++i)
        if (fns[i].same_as[0] && !find_fn(fns, n, fns[i].same_as)) {
            printf("%s refers to %s, which defsim.h does not declare\n", fns[i].name,
                   fns[i].same_as);
            ++failures;
        }
    printf("%d public functions, %d rows, %d disagreements\n", n, NROWS, failures);
    free(text);
    assert_int_equal(failures, 0);
}

/* ------------------------------------------------------------------------------------------ */
/* Regression tests of issue 17 (public API only: each crashed or misbehaved before the fix) */

typedef struct reentry {
    defsim_world *w;
    defsim_body_id body;
    defsim_body_def def;
    int in_log;          /* 1: call from the log callback, 0: from the force callback */
    int ran;             /* the calls were made (once) */
    defsim_status got[6];
} reentry;

static void reentry_calls(reentry *r)
{
    if (r->ran) return;
    r->ran = 1;
    const int32_t v0 = 0;
    double f[3] = {0, 0, 0};
    r->got[0] = defsim_world_remove_body(r->w, r->body);
    r->got[1] = defsim_world_add_body(r->w, &r->def, NULL);
    r->got[2] = defsim_body_unpin(r->w, r->body, &v0, 1);
    r->got[3] = defsim_world_step(r->w, H);
    r->got[4] = defsim_world_set_state(r->w, NULL, NULL);
    r->got[5] = defsim_world_get_pin_forces(r->w, f, 1);
}

static void reentry_log(void *user, int level, const char *message)
{
    (void)level; (void)message;
    reentry *r = user;
    if (r->in_log) reentry_calls(r);
}

static int reentry_force(void *user, const double *x, const double *v, double t, int32_t n,
                         double *f)
{
    (void)x; (void)v; (void)t; (void)n; (void)f;
    reentry *r = user;
    if (!r->in_log) reentry_calls(r);
    return 1;   /* the step fails, is logged, and rolls back */
}

/* A failing step calls the log callback in the middle of defsim_world_step. Before the fix a
 * callback that removed a body overflowed the heap in the roll-back memcpy, one that added a
 * body or unpinned crashed on NULL. Now each change is refused and the step fails as it
 * would have without them, state rolled back, the lock released after it. The same from the
 * force callback (get_pin_forces there recursed into the callback). */
static void test_reentry(void **state)
{
    (void)state;
    for (int in_log = 1; in_log >= 0; --in_log) {
        reentry r;
        memset(&r, 0, sizeof r);
        r.in_log = in_log;
        r.def = rope_def();
        defsim_world_def d = tu_world_def("symplectic_euler", -9.81, 1);
        d.log = reentry_log;
        d.log_user = &r;
        r.w = tu_create(&d);
        r.body = tu_add_box(r.w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 2, 1, 1, LO, HI, 1e5, 0.3, 1e3);
        const int32_t v0 = 0;
        TU_OK(defsim_body_pin(r.w, r.body, &v0, 1));
        TU_OK(defsim_world_step(r.w, H));
        const int nv = defsim_world_vertex_count(r.w);
        double *x0 = tu_positions(r.w), *v0s = tu_velocities(r.w);
        TU_OK(defsim_world_set_force_callback(r.w, reentry_force, NULL, &r));
        assert_int_equal(defsim_world_step(r.w, H), DEFSIM_ERR_CALLBACK);
        assert_int_equal(r.ran, 1);
        for (int k = 0; k < 6; ++k) assert_int_equal(r.got[k], DEFSIM_ERR_LOCKED);
        assert_int_equal(defsim_world_vertex_count(r.w), nv);
        assert_int_equal(defsim_body_vertex_count(r.w, r.body), nv);
        double *x1 = tu_positions(r.w), *v1 = tu_velocities(r.w);
        assert_memory_equal(x0, x1, 3 * (size_t)nv * sizeof *x0);
        assert_memory_equal(v0s, v1, 3 * (size_t)nv * sizeof *v0s);
        /* the lock is released: the same calls work now */
        TU_OK(defsim_world_set_force_callback(r.w, NULL, NULL, NULL));
        r.ran = 1;   /* no more re-entry */
        TU_OK(defsim_world_step(r.w, H));
        TU_OK(defsim_body_unpin(r.w, r.body, &v0, 1));
        TU_OK(defsim_world_add_body(r.w, &r.def, NULL));
        TU_OK(defsim_world_remove_body(r.w, r.body));
        assert_int_equal(defsim_world_vertex_count(r.w), 3);
        free(x0); free(v0s); free(x1); free(v1);
        defsim_world_destroy(r.w);
    }
}

/* A refused call from inside the log callback does not replace the failure being logged: the
 * world's last error after the step is that of the same step without re-entry. */
static void test_reentry_keeps_message(void **state)
{
    (void)state;
    char plain[512];
    for (int pass = 0; pass < 2; ++pass) {
        reentry r;
        memset(&r, 0, sizeof r);
        r.in_log = 1;
        r.ran = pass == 0;   /* pass 0: no re-entry */
        r.def = rope_def();
        defsim_world_def d = tu_world_def("symplectic_euler", -9.81, 1);
        d.log = reentry_log;
        d.log_user = &r;
        r.w = tu_create(&d);
        r.body = tu_add_box(r.w, DEFSIM_MODEL_STABLE_NEOHOOKEAN, 1, 1, 1, LO, HI, 1e5, 0.3, 1e3);
        TU_OK(defsim_world_set_force_callback(r.w, reentry_force, NULL, &r));
        assert_int_equal(defsim_world_step(r.w, H), DEFSIM_ERR_CALLBACK);
        if (pass == 0) snprintf(plain, sizeof plain, "%s", defsim_world_last_error(r.w));
        else assert_string_equal(defsim_world_last_error(r.w), plain);
        assert_true(plain[0] != '\0');
        defsim_world_destroy(r.w);
    }
}

/* defsim_world_remove_body(w2, id of w1) returned OK and removed a body of w2. */
static void test_ids_of_another_world(void **state)
{
    (void)state;
    defsim_world *w1 = tu_world("symplectic_euler", -9.81, 1);
    defsim_world *w2 = tu_world("symplectic_euler", -9.81, 1);
    const defsim_model m = DEFSIM_MODEL_COROTATED;
    const defsim_body_id b1 = tu_add_box(w1, m, 1, 1, 1, LO, HI, 1e5, 0.3, 1e3);
    const defsim_body_id b2 = tu_add_box(w2, m, 1, 1, 1, LO, HI, 1e5, 0.3, 1e3);
    const int nv = defsim_world_vertex_count(w2);
    assert_int_equal(defsim_world_remove_body(w2, b1), DEFSIM_ERR_STALE_ID);
    assert_int_equal(defsim_world_vertex_count(w2), nv);
    assert_int_equal(defsim_body_vertex_count(w2, b2), nv);
    assert_int_equal(defsim_body_vertex_count(w2, b1), DEFSIM_ERR_STALE_ID);
    defsim_attachment_def ad;
    defsim_attachment_def_init(&ad, sizeof ad);
    ad.body = b1;
    defsim_attachment_id a1;
    TU_OK(defsim_world_add_attachment(w1, &ad, &a1));
    ad.body = b2;
    defsim_attachment_id a2;
    TU_OK(defsim_world_add_attachment(w2, &ad, &a2));
    assert_int_equal(defsim_world_remove_attachment(w2, a1), DEFSIM_ERR_STALE_ID);
    double force[3];
    TU_OK(defsim_world_get_attachment_force(w2, a2, force));
    TU_OK(defsim_world_remove_attachment(w1, a1));
    TU_OK(defsim_world_remove_body(w2, b2));
    defsim_world_destroy(w1);
    defsim_world_destroy(w2);
}

/* Body slots were never reused (index 1001 after 1,000 remove/add cycles). Now the slot of a
 * removed body takes the next one, with a new generation (the old ids stay stale), and the
 * vertices of a body still follow those of the bodies added before it. */
static void test_slot_reuse(void **state)
{
    (void)state;
    defsim_world *w = tu_world("symplectic_euler", -9.81, 1);
    defsim_body_def rd = rope_def();
    defsim_body_id first, id, prev;
    TU_OK(defsim_world_add_body(w, &rd, &first));
    id = first;
    for (int k = 0; k < 1000; ++k) {
        prev = id;
        TU_OK(defsim_world_remove_body(w, prev));
        TU_OK(defsim_world_add_body(w, &rd, &id));
        assert_int_equal(id.index, first.index);
        assert_int_equal(id.generation, prev.generation + 2);
        assert_int_equal(defsim_body_vertex_count(w, prev), DEFSIM_ERR_STALE_ID);
    }
    assert_int_equal(defsim_body_vertex_count(w, first), DEFSIM_ERR_STALE_ID);
    assert_int_equal(defsim_body_vertex_count(w, id), 3);

    /* A (the rope), B (a box) ; remove A ; C takes A's slot but comes after B */
    const defsim_body_id b = tu_add_box(w, DEFSIM_MODEL_COROTATED, 1, 1, 1, LO, HI, 1e5, 0.3, 1e3);
    const int nb = defsim_body_vertex_count(w, b);
    defsim_attachment_def ad;
    defsim_attachment_def_init(&ad, sizeof ad);
    ad.body = id;
    defsim_attachment_id att;
    TU_OK(defsim_world_add_attachment(w, &ad, &att));
    TU_OK(defsim_world_remove_body(w, id));
    assert_int_equal(defsim_world_remove_attachment(w, att), DEFSIM_ERR_STALE_ID);
    static const double CX[9] = {5, 5, 5, 6, 5, 5, 7, 5, 5};
    rd.rest_positions = CX;
    defsim_body_id c;
    TU_OK(defsim_world_add_body(w, &rd, &c));
    assert_int_equal(c.index, first.index);
    assert_int_equal(defsim_body_vertex_offset(w, b), 0);
    assert_int_equal(defsim_body_vertex_offset(w, c), nb);
    double *x = tu_positions(w);
    assert_memory_equal(x + 3 * nb, CX, sizeof CX);
    free(x);
    /* the attachment of the removed body does not come back with the slot */
    defsim_energy e;
    TU_OK(defsim_world_energy(w, &e));
    assert_true(e.elastic == 0.0);
    TU_OK(defsim_world_step(w, H));
    defsim_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_header_agrees),
        cmocka_unit_test(test_reentry),
        cmocka_unit_test(test_reentry_keeps_message),
        cmocka_unit_test(test_ids_of_another_world),
        cmocka_unit_test(test_slot_reuse),
        cmocka_unit_test_setup_teardown(test_table, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

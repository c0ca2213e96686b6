/* SPDX-License-Identifier: MIT */
/*
 * Colliders (collider.c, collider_shape.c): shapes the host places and moves, stored by the world
 * as the host gave them (validated, normalised), with the pose they have now and the pose they
 * reach at the end of the next step. The geometric queries here are what contact (contact.c)
 * needs: signed distance with its gradient and Hessian, world bounds, and a conservative time of
 * impact for a moving point.
 */
#ifndef DEFSIM_COLLIDER_H
#define DEFSIM_COLLIDER_H

#include "chunk.h"
#include "defsim/defsim.h"
#include "id_pool.h"
#include "mesh.h"
#include "status.h"

#include <math.h>
#include <stdint.h>

struct defsim__bvh;

typedef struct defsim__collider {
    uint32_t generation;      /* odd while alive; bumped on removal */
    defsim_collider_def def;  /* validated: unit rotation and normal; mesh arrays point below */
    double *mesh_x;           /* MESH: 3 vertex_count, owned */
    int32_t *mesh_t;          /* MESH: 3 triangle_count, owned */
    struct defsim__bvh *bvh;  /* MESH: bounding volume hierarchy over the triangles, owned */
    double pos[3], rot[4];    /* pose now (the start of the next step) */
    double pos1[3], rot1[4];  /* pose at the end of the next step (== pos, rot if not moved) */
} defsim__collider;

/* The world's colliders, a sub-object of the world: slots in creation order (ids name them;
 * live ones have odd generations), what changed since the last step, and the contact forces
 * of the last step that the host reads back (colliders' and bodies'). */
typedef struct defsim__collider_set {
    defsim__collider *col;    /* by id slot (a collider's generation is its slot's) */
    int32_t ncol, cap_col;
    defsim__id_pool ids;
    int changed;              /* a collider was added or removed since the last step */
    int came;                 /* a collider came or went since the last successful step */
    double *force;            /* 3 force_nv: contact forces of the last step, or NULL */
    int32_t force_nv;
    int force_zero;           /* force is known to be all zero */
} defsim__collider_set;

/* The number of live colliders. */
int32_t defsim__collider_set_live(const defsim__collider_set *s);
/* Frees the colliders and the read-back (at destruction). */
void defsim__collider_set_free(defsim__collider_set *s);

/* The contact-force read-back made a zeroed array of nv vertices (collider and body contact
 * write it at a step's end). DEFSIM_ERR_OUT_OF_MEMORY (with msg's error set) on failure. */
defsim_status defsim__collider_set_readback(defsim__collider_set *s, int32_t nv,
                                            defsim__messages *msg);

/* Checkpoints (docs/checkpoints.md): writes a COLL chunk per live collider in slot order, with
 * its pose now and at the end of the next step as stored (normalised), and the CFRC chunk:
 * whether the colliders changed since the last step, and that step's contact forces when they
 * are still of the world's nv vertices. */
void defsim__collider_set_save(defsim__bw *b, const defsim__collider_set *s, int32_t nv);

/* A COLL chunk read back: the def (arrays in the buffers here, the SDF's function left to the
 * caller) and the pose at the end of the next step. */
typedef struct defsim__collider_saved {
    defsim_collider_def def;
    double pos1[3], rot1[4];
    double *vertices;
    int32_t *triangles;
} defsim__collider_saved;

/* Reads a COLL chunk into *out, whose buffers are the caller's to free with
 * defsim__collider_saved_free, also on failure: DEFSIM_ERR_IO with *why saying what is
 * malformed, DEFSIM_ERR_OUT_OF_MEMORY. The def's values are validated by
 * defsim_world_add_collider. */
defsim_status defsim__collider_read(defsim__br *r, defsim__collider_saved *out, const char **why);
void defsim__collider_saved_free(defsim__collider_saved *s);
/* Gives collider c the saved bits of both poses and the normal (a second normalisation may
 * move the last bit). */
void defsim__collider_restore(defsim__collider *c, const defsim__collider_saved *saved);
/* Reads the CFRC chunk into the set for a world of nv vertices: DEFSIM_ERR_IO if malformed,
 * DEFSIM_ERR_OUT_OF_MEMORY. */
defsim_status defsim__collider_set_load_forces(defsim__collider_set *s, defsim__br *r,
                                               int32_t nv);

/* A pose: position (m) and unit quaternion (w, x, y, z), with its rotation matrix (row-major,
 * local to world). */
typedef struct defsim__pose {
    double p[3], q[4], R[9];
} defsim__pose;

/* Validates a def into *out (defaults for fields an older def lacks; rotation and normal
 * normalised) and copies mesh arrays into c. Returns DEFSIM_OK, or INVALID_ARGUMENT /
 * OUT_OF_MEMORY with the message in msg. */
defsim_status defsim__collider_make(defsim__messages *msg, const defsim_collider_def *def,
                                    defsim__collider *c);
void defsim__collider_free(defsim__collider *c);

/* 1 if the n values of a are finite and within +-DEFSIM__COORD_MAX (mesh.h), the bound of mesh
 * coordinates: a collider's position (and, for its shape, coordinates and sizes) within it keeps
 * every distance, its square and every bound finite. 0 otherwise (NaN included). Inline:
 * collider.c and collider_mesh.c both check with it, and collider.c calls collider_mesh.c. */
static inline int defsim__collider_coords_ok(const double *a, int64_t n)
{
    for (int64_t i = 0; i < n; ++i)
        if (!(fabs(a[i]) <= DEFSIM__COORD_MAX)) return 0;
    return 1;
}

/* Normalises a quaternion (w, x, y, z) within 1e-6 of unit length into out; returns 0 (out
 * unchanged) for any other, or a non-finite one. */
int defsim__unit_quaternion(const double *in, double out[4]);

/* The pose at fraction s in [0, 1] of the next step: position linear, rotation along the
 * shortest arc (slerp) from (pos, rot) to (pos1, rot1). */
void defsim__collider_pose_at(const defsim__collider *c, double s, defsim__pose *out);
/* Makes a pose from a position and a unit quaternion. */
void defsim__pose_set(defsim__pose *pose, const double p[3], const double q[4]);

/* Triangle meshes (collider_mesh.c). check: the def's arrays (NULL, counts, finite coordinates,
 * indices in range, no zero-area triangle), INVALID_ARGUMENT with the message. build: normals,
 * pseudo-normals and the AABB tree over c->mesh_x / c->mesh_t (already copied), into c->bvh.
 * distance: signed distance, gradient and (if h) Hessian of a local point, in the local frame.
 * local_bounds: the mesh's local axis-aligned box (the tree's root). */
defsim_status defsim__mesh_check(defsim__messages *msg, const defsim_collider_def *d);
defsim_status defsim__mesh_build(defsim__collider *c);
void defsim__mesh_free(defsim__collider *c);
void defsim__mesh_distance(const defsim__collider *c, const double p[3], double *d, double g[3],
                           double h[9]);
void defsim__mesh_local_bounds(const defsim__collider *c, double lo[3], double hi[3]);
/* The unsigned distance of a local point by a loop over every triangle: the reference that the
 * tree must match (test_collider, tools/bench_collider.c). */
double defsim__mesh_distance_brute(const defsim__collider *c, const double p[3]);

/* Signed distance (m, > 0 outside) of world point p to the collider at `pose`, its gradient
 * (the unit outward normal at the closest point, world frame) into grad, and if hess is not NULL
 * the Hessian of the distance (3x3 row-major, world frame; zero where the distance is not twice
 * differentiable in a useful sense, e.g. the planar faces of a box). Returns DEFSIM_OK, or
 * DEFSIM_ERR_CALLBACK when an SDF callback returned a non-finite value. */
defsim_status defsim__collider_distance(const defsim__collider *c, const defsim__pose *pose,
                                        const double p[3], double *d, double grad[3],
                                        double hess[9]);

/* World axis-aligned bounds of the collider at `pose`, grown by margin (m): every point with
 * d <= margin lies inside (for an open mesh: every point with |d| <= margin; the region behind
 * it, d < 0, is unbounded). Tight: the rotated box, capsule or mesh vertices. Unbounded
 * directions (planes, except along a world axis normal; SDFs without bounds) get -inf / +inf. */
void defsim__collider_bounds(const defsim__collider *c, const defsim__pose *pose, double margin,
                             double lo[3], double hi[3]);

/* Conservative time of impact of a point moving from p0 to p1 (world, straight line) against the
 * collider held at `pose`: the largest t in [0, 1] such that the distance stays above
 * min_distance for every point of the segment up to t (1 if it never comes closer); 0 when the
 * distance at p0 does not exceed min_distance. Plane, sphere: exact (t is reduced by 1e-9 of
 * the gap so that rounding cannot land closer); box, capsule: Newton from the left on the
 * convex distance (slabs first for the box), exact to rounding; mesh, SDF: conservative
 * advancement (the distance is 1-Lipschitz: for an SDF that is the host's promise), to 1e-6
 * of the initial gap or after 256 samples (grazing paths). An open mesh's sign flip behind its border (docs/colliders.md) is caught
 * where an advancement sample lands behind it, not between samples. Returns DEFSIM_OK or
 * DEFSIM_ERR_CALLBACK. */
defsim_status defsim__collider_toi(const defsim__collider *c, const defsim__pose *pose,
                                   const double p0[3], const double p1[3], double min_distance,
                                   double *t);

#endif /* DEFSIM_COLLIDER_H */

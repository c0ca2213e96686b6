/* SPDX-License-Identifier: MIT */
/** @file
 * defsim: deformable-body simulation (mass-spring networks and tetrahedral FEM).
 *
 * This is the only header a host application includes. It is plain C11, compiles as C++,
 * and parses with cffi: no inline functions, no macros are needed to call the API.
 *
 * Conventions that hold for every function below unless its comment says otherwise:
 *  - Units are SI (m, kg, s, Pa, N/m).
 *  - Arrays of positions, velocities and forces are flat: x0 y0 z0 x1 y1 z1 ..., 3 doubles per
 *    vertex, in the order in which vertices were added to the world (body by body).
 *  - Input arrays are copied; the caller keeps ownership. Outputs are written into buffers that
 *    the caller owns, unless a comment says that a pointer is borrowed.
 *  - Fallible calls return a defsim_status: DEFSIM_OK (0) or a negative error code. A call that
 *    fails leaves the world exactly as it was, and defsim_world_last_error() describes why. The
 *    statuses a function can return are named in its "Errors:" line (docs/errors.md; a test
 *    holds the two together).
 *  - A world pointer that is NULL, destroyed or not made by defsim_world_create is refused with
 *    DEFSIM_ERR_INVALID_ARGUMENT (or ignored, by functions that return nothing) where the
 *    library can tell: a magic number in the world checks it, best effort, not a guarantee
 *    (using a destroyed world is undefined behaviour; the check catches most cases).
 *  - From inside a host callback of a world (its log callback, force callback or force
 *    Jacobian), every call that changes that world returns DEFSIM_ERR_LOCKED and changes
 *    nothing (defsim_world_destroy and defsim_world_reset_stats do nothing); read-only calls are
 *    allowed and see the state as it is at that moment of the step.
 *  - A world is not thread-safe: call it from one thread at a time, read-only calls included
 *    (they write the world's message and workspaces). Different worlds may be used from
 *    different threads concurrently. Registration of backends is thread-safe. See
 *    docs/threads.md.
 */
#ifndef DEFSIM_DEFSIM_H
#define DEFSIM_DEFSIM_H

#include <stddef.h>
#include <stdint.h>

#include "defsim/version.h"

#if defined(_WIN32) && !defined(DEFSIM_STATIC)
#  ifdef DEFSIM_BUILDING
#    define DEFSIM_API __declspec(dllexport)
#  else
#    define DEFSIM_API __declspec(dllimport)
#  endif
#elif defined(__GNUC__)
#  define DEFSIM_API __attribute__((visibility("default")))
#else
#  define DEFSIM_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* ------------------------------------------------------------------------------------------ */
/* Status codes                                                                               */

/// Result of every fallible call: 0 on success, a negative code on failure.
typedef enum defsim_status {
    DEFSIM_OK = 0,                        ///< Success.
    DEFSIM_ERR_INVALID_ARGUMENT = -1,     ///< A NULL pointer, size, count or option out of range.
    DEFSIM_ERR_INVALID_MESH = -2,         ///< Bad indices, non-finite or degenerate geometry.
    DEFSIM_ERR_INVALID_MATERIAL = -3,     ///< Non-physical material parameters.
    DEFSIM_ERR_BACKEND_UNAVAILABLE = -4,  ///< No backend of that name, or its module failed to load.
    DEFSIM_ERR_NOT_CONVERGED = -5,        ///< A nonlinear or adaptive solve failed; state unchanged.
    DEFSIM_ERR_UNSTABLE = -6,             ///< The step produced a non-finite state or one outside
                                          ///< the watchdog's envelope; state unchanged.
    DEFSIM_ERR_OUT_OF_MEMORY = -7,        ///< An allocation failed; state unchanged.
    DEFSIM_ERR_IO = -8,                   ///< A file could not be read or written, or is malformed.
    DEFSIM_ERR_STALE_ID = -9,             ///< A body or attachment id that is null, removed, or
                                          ///< from another world.
    DEFSIM_ERR_LOCKED = -10,              ///< The world is inside a callback and cannot be changed.
    DEFSIM_ERR_CONFLICT = -11,            ///< A backend of that name is already registered.
    DEFSIM_ERR_CALLBACK = -12,            ///< A host callback reported failure or returned a
                                          ///< non-finite value; state unchanged.
    DEFSIM_ERR_UNSUPPORTED = -13          ///< The world's backend cannot do what the world asks
                                          ///< (body contact on an explicit backend); state
                                          ///< unchanged.
} defsim_status;

/// Static English text for a status code ("invalid argument", ...). Never NULL; the string is
/// owned by the library and valid for the life of the process. Unknown codes give "unknown status".
DEFSIM_API const char *defsim_status_string(defsim_status status);

/// Detail of the last failure on this thread of a call that has no world to report to
/// (defsim_world_create, defsim_register_backend, defsim_mesh_*). Empty string if none.
/// Borrowed: valid until the next defsim call on this thread.
DEFSIM_API const char *defsim_last_error(void);

/// Version of the library that is linked, as DEFSIM_VERSION_NUMBER encodes it
/// (major * 10000 + minor * 100 + patch). Bindings compare it with the header they were made for.
DEFSIM_API int32_t defsim_version_number(void);

/* ------------------------------------------------------------------------------------------ */
/* Materials                                                                                  */

/// Constitutive model of a body.
typedef enum defsim_model {
    DEFSIM_MODEL_SPRING = 1,            ///< Hooke springs only: E = k/2 (l - l0)^2 per spring.
    DEFSIM_MODEL_STVK = 2,              ///< Saint Venant-Kirchhoff.
    DEFSIM_MODEL_COROTATED = 3,         ///< Co-rotated linear, R from the signed (inversion-safe) SVD.
    DEFSIM_MODEL_NEOHOOKEAN = 4,        ///< Compressible neo-Hookean with log J (undefined for J <= 0).
    DEFSIM_MODEL_STABLE_NEOHOOKEAN = 5  ///< Smith, de Goes, Kim 2018; inversion-safe.
} defsim_model;

/// Material parameters of a body. Fill with defsim_material_init, then change what you need.
typedef struct defsim_material {
    uint32_t size;              ///< sizeof(defsim_material), set by defsim_material_init.
    defsim_model model;         ///< The constitutive model, set by defsim_material_init.
    double youngs_modulus;      ///< E in Pa (tet models). Default 1e6.
    double poisson_ratio;       ///< nu in [0, 0.5) (tet models). Default 0.3.
    double density;             ///< rho in kg/m^3, gives lumped tet masses. Default 1000.
    double stiffness;           ///< Spring stiffness k in N/m for every spring of the body. Default 1e3.
    double vertex_mass;         ///< kg added to every vertex of the body (springs). Default 0.01
                                ///< for DEFSIM_MODEL_SPRING, 0 for tet models.
    double mass_damping;        ///< Rayleigh alpha in 1/s: damping force -alpha M v. Default 0.
    double stiffness_damping;   ///< Rayleigh beta in s: damping force -beta K(x) v. Default 0.
} defsim_material;

/// Fills *material with the defaults of the given model. `size` must be sizeof *material.
/// Does nothing if material is NULL or size is smaller than the first two fields.
DEFSIM_API void defsim_material_init(defsim_material *material, size_t size, defsim_model model);

/// Evaluates a tet material at one deformation gradient F (row-major, F[3*i+j] = F_ij):
/// the energy density psi (J/m^3), the first Piola-Kirchhoff stress P (row-major), and its
/// derivative dPdF with dPdF[9*(3*i+j) + (3*k+l)] = dP_ij / dF_kl. Any output may be NULL.
/// The stable neo-Hookean energy is not zero at F = I: psi(I) = lambda'/2 (1 - alpha)^2 -
/// mu'/2 log 4, a constant (see README "Materials"); world energies subtract it so that a body at
/// rest has zero elastic energy, defsim_material_eval does not.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL material or F, a spring model, or non-finite F),
/// DEFSIM_ERR_INVALID_MATERIAL (bad parameters), DEFSIM_ERR_UNSTABLE (the neo-Hookean model at
/// det F <= 0, where it is undefined, and any model when a requested output overflows: large F,
/// e.g. StVK's energy grows like |F|^4 and is not finite beyond |F| ~ 1e77; the outputs are then
/// written as computed, inf or NaN). Thread-safe.
DEFSIM_API defsim_status defsim_material_eval(const defsim_material *material, const double F[9],
                                              double *psi, double P[9], double dPdF[81]);

/// Checks a material's parameters by the rules that defsim_world_add_body applies to them, for
/// a body of any shape: a known model; for tet models E finite and > 0, nu in [0, 0.5), density
/// finite and >= 0; for every model stiffness, vertex_mass, mass_damping and stiffness_damping
/// finite and >= 0 (add_body checks stiffness only for bodies with springs). What depends on the
/// body (tets with DEFSIM_MODEL_SPRING) stays add_body's. Bindings call it when a material is
/// made, so that a bad value is refused where it is given. defsim_last_error() names the first
/// bad field. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, size smaller than sizeof
/// (defsim_material)), DEFSIM_ERR_INVALID_MATERIAL. Thread-safe.
DEFSIM_API defsim_status defsim_material_check(const defsim_material *material);

/* ------------------------------------------------------------------------------------------ */
/* Worlds                                                                                     */

/// A simulation world: bodies, colliders, attachments, their state and the backend that steps
/// them. Opaque; made by defsim_world_create, freed by defsim_world_destroy.
typedef struct defsim_world defsim_world;

/// How implicit backends make element Hessians positive semi-definite before assembly: the
/// values of a backend's CHOICE option "projection" ("none|clamp|abs", and "auto" where the
/// backend offers it, e.g. "newton_cholmod.projection"). A backend without that option gets
/// DEFSIM_PROJECTION_CLAMP.
typedef enum defsim_projection {
    DEFSIM_PROJECTION_NONE = 0,     ///< Exact Hessians (may be indefinite).
    DEFSIM_PROJECTION_CLAMP = 1,    ///< Negative eigenvalues of each element Hessian set to 0.
    DEFSIM_PROJECTION_ABS = 2,      ///< Negative eigenvalues replaced by their absolute value.
    DEFSIM_PROJECTION_AUTO = 3      ///< Exact Hessians while the Newton matrix (with the
                                    ///< inertia) is positive definite; clamped for an iteration
                                    ///< where it is not (the implicit core's backends).
} defsim_projection;

/// Log callback: level 0 error, 1 warning, 2 info, 3 debug. `message` is borrowed for the call.
typedef void (*defsim_log_fn)(void *user, int level, const char *message);

/// Creation parameters of a world. Fill with defsim_world_def_init, then change what you need.
/// It holds only what every backend shares; the settings of one backend (tolerances, iteration
/// limits, projection, ...) and of the core (auto_substep, the watchdog, contact) are options
/// by name (defsim_world_set_option, docs/api.md).
typedef struct defsim_world_def {
    uint32_t size;             ///< sizeof(defsim_world_def), set by defsim_world_def_init.
    const char *backend;       ///< Integrator: "explicit_euler", "symplectic_euler" (built in),
                               ///< "newton_cholmod", "sundials_ida", "sundials_erk",
                               ///< "sundials_kinsol" (modules), or a registered one. Copied.
                               ///< Default "symplectic_euler".
    double gravity[3];         ///< m/s^2. Default (0, -9.81, 0).
    int32_t num_threads;       ///< Threads for force and Hessian assembly; 0: OpenMP's default.
    defsim_log_fn log;         ///< Optional log sink; NULL: silent.
    void *log_user;            ///< Passed to log.
} defsim_world_def;

/// Fills *def with defaults. `size` must be sizeof *def. Does nothing if def is NULL.
DEFSIM_API void defsim_world_def_init(defsim_world_def *def, size_t size);

/// Creates an empty world. On success *out receives a world the caller owns and must release
/// with defsim_world_destroy. Loads the backend's module now if it is not built in.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, def->size 0 or too small, an empty backend name
/// or one of 64 characters or more, a non-finite gravity, num_threads < 0),
/// DEFSIM_ERR_BACKEND_UNAVAILABLE (unknown name or module failed), DEFSIM_ERR_OUT_OF_MEMORY.
/// On failure *out is set to NULL and defsim_last_error() says why.
DEFSIM_API defsim_status defsim_world_create(const defsim_world_def *def, defsim_world **out);

/// Destroys a world and everything it owns. NULL is ignored, and so is a world that is already
/// destroyed or not a world, where this can be told (best effort), and a call from inside one of
/// the world's host callbacks (the world lives on; destroy it after the callback returns).
DEFSIM_API void defsim_world_destroy(defsim_world *world);

/// Detail of the last failed call on this world ("tet 17 is degenerate (volume 1e-30)"), or ""
/// if none failed. Borrowed: valid until the next call on this world. NULL world gives "", a
/// pointer that is not a live world the thread's defsim_last_error().
DEFSIM_API const char *defsim_world_last_error(const defsim_world *world);

/* ------------------------------------------------------------------------------------------ */
/* Bodies                                                                                     */

/// A body handle: a small value, not a pointer. {0, 0} is the null id. Ids of removed bodies
/// become stale and are rejected with DEFSIM_ERR_STALE_ID, and so are ids of another world: an
/// id carries a tag of the world that made it (one of 4095; worlds made less than 4095
/// creations apart have different tags). The slot of a removed body is reused by the next body
/// added (a new generation). A world holds at most 1,048,575 bodies, as many attachments and as
/// many colliders.
/// Treat ids as opaque: do not make them up.
typedef struct defsim_body_id {
    uint32_t index;        ///< The slot, with the world's tag.
    uint32_t generation;   ///< The slot's generation; 0 only in the null id.
} defsim_body_id;

/// Creation parameters of a body. All arrays are copied by defsim_world_add_body.
typedef struct defsim_body_def {
    uint32_t size;                      ///< sizeof(defsim_body_def), set by defsim_body_def_init.
    const double *rest_positions;       ///< 3 * vertex_count doubles, m. Required.
    int32_t vertex_count;               ///< >= 1.
    const int32_t *tets;                ///< tet_nodes vertex indices per tet (0-based, body-local), or NULL.
    int32_t tet_count;                  ///< >= 0; tets may be NULL only when it is 0.
    const int32_t *springs;             ///< 2 vertex indices per spring, or NULL.
    int32_t spring_count;               ///< >= 0; springs may be NULL only when it is 0.
    const double *spring_stiffness;     ///< Optional: one k (N/m) per spring; NULL: material.stiffness.
    const double *vertex_mass;          ///< Optional: kg per vertex; NULL: lumped from density plus
                                        ///< material.vertex_mass. Every vertex needs a positive mass.
    const double *initial_positions;    ///< Optional, 3 * vertex_count; NULL: rest positions.
    const double *initial_velocities;   ///< Optional, 3 * vertex_count; NULL: zero.
    defsim_material material;           ///< Default: stable neo-Hookean defaults.
    /* Stiffness by spring kind (appended). */
    /// Optional: one defsim_spring_kind per spring (e.g. defsim_mesh.spring_kinds), copied.
    /// Stretch springs get material.stiffness, shear and bend springs shear_stiffness and
    /// bend_stiffness. Cannot be combined with spring_stiffness (DEFSIM_ERR_INVALID_ARGUMENT);
    /// a value outside the enum is DEFSIM_ERR_INVALID_MESH.
    const int32_t *spring_kinds;
    double shear_stiffness;             ///< N/m of DEFSIM_SPRING_SHEAR springs; < 0 (default): material.stiffness.
    double bend_stiffness;              ///< N/m of DEFSIM_SPRING_BEND springs; < 0 (default): material.stiffness.
    /* Body-body and self-contact (appended; see the section "Body contact" and
     * docs/body-contact.md). Used only while the core option body_contact is on. */
    /// Optional: 3 body-local vertex indices per triangle, the contact surface of a cloth (e.g.
    /// defsim_mesh.triangles), copied. NULL: a tet body uses its boundary triangles, a body of
    /// springs only (a rope) its stretch springs as edges (all springs when spring_kinds is NULL).
    /// An index out of range or a triangle that repeats a vertex is DEFSIM_ERR_INVALID_MESH.
    const int32_t *triangles;
    int32_t triangle_count;             ///< >= 0; triangles may be NULL only when it is 0.
    int32_t self_contact;               ///< 1 (default): the body collides with itself; 0: not.
    uint32_t collision_group;           ///< Groups the body belongs to (bits), default 1.
    /// Groups the body collides with, default 0xFFFFFFFF. Bodies A != B collide iff
    /// (A.group & B.mask) != 0 and (B.group & A.mask) != 0.
    uint32_t collision_mask;
    /// Coulomb coefficient of body-body friction (>= 0, finite; default 0.5); a pair of bodies
    /// uses sqrt(mu_A mu_B). Larger than 10 is DEFSIM_ERR_INVALID_MATERIAL.
    double friction;
    /* Volume averaging against volumetric locking (appended; see docs/materials.md). */
    /// 1: the body's tets use the averaged-nodal-volume element (Bonet and Burton 1998, in energy
    /// form): each tet keeps the part of its material's energy without lambda, and the part with
    /// lambda, U(J), is evaluated per vertex on the vertex's volume ratio, the sum of its tets'
    /// current volumes over the sum of their rest volumes (a quarter of each). Nearly incompressible
    /// bodies (poisson_ratio near 0.5) then bend as the continuum does instead of locking; the
    /// matrices couple every vertex of a vertex's tets (a wider pattern). With quadratic tets
    /// (tet_nodes 10) it selects the mean-dilatation element instead (P2/P0; docs/elements.md):
    /// the part without lambda at each quadrature point, U on the element's mean volume ratio
    /// (its current over its rest volume), the pattern the quadratic tets' own. 0 (default):
    /// the standard element. Only the neo-Hookean and stable neo-Hookean models have the split
    /// (their lambda terms depend on J alone); with StVK or co-rotated, or a value other than 0
    /// and 1: DEFSIM_ERR_INVALID_MATERIAL.
    int32_t volume_averaging;
    /* Quadratic tets (appended; see docs/elements.md). */
    /// Indices per tet in `tets`: 4 (default: linear tets) or 10 (quadratic tets: the 4 corners,
    /// then the mid-edge nodes of edges 01, 12, 02, 03, 13, 23, VTK_QUADRATIC_TETRA's order; the
    /// mid-edge nodes are vertices like the corners, so pins, attachments and collider contact
    /// use them as any vertex). Elements are isoparametric: a mid-edge node off its edge's middle
    /// curves the element. Energies, forces and Hessians integrate with the 4-point degree-2
    /// rule, each point's dP/dF projected as for linear tets; masses are HRZ-lumped (positive;
    /// vertex_mass overrides them as for linear tets); body contact uses each boundary face as 4
    /// triangles through its mid-edge nodes. Another value is DEFSIM_ERR_INVALID_ARGUMENT; an
    /// element whose Jacobian determinant falls to 1e-3 of its corners' straight tet or below
    /// anywhere it is checked (corners, mid-edge nodes, centroid, quadrature points) is
    /// DEFSIM_ERR_INVALID_MESH. Elements with negative corner orientation are reordered as
    /// linear tets are (corners 0 and 1 swapped with their mid-edge nodes).
    int32_t tet_nodes;
    /* Cloth and shells (appended; issue 26, docs/shells.md). A body is a shell when
     * shell_membrane is not DEFSIM_SHELL_MEMBRANE_NONE or its bending rigidity is > 0: then
     * `triangles` above (at least one, no tets) are its elements as well as its contact surface,
     * each triangle a membrane element on the rest shape's own plane and each interior edge (shared
     * by exactly two triangles; more is DEFSIM_ERR_INVALID_MESH) a bending hinge whose rest angle
     * is the rest shape's. Masses: shell_areal_density A / 3 per vertex of each triangle, plus
     * material.vertex_mass. Springs may be added; material.stiffness_damping must be 0 (stiffness
     * damping does not act on shells: DEFSIM_ERR_INVALID_MATERIAL). Bad values below are
     * DEFSIM_ERR_INVALID_MATERIAL, a zero-area triangle DEFSIM_ERR_INVALID_MESH. */
    /// The membrane energy, a defsim_shell_membrane. Default DEFSIM_SHELL_MEMBRANE_NONE.
    int32_t shell_membrane;
    /// Isotropic membranes (STVK, NEOHOOKEAN): Young's modulus E in Pa (finite, > 0). Default 1e6.
    double shell_youngs_modulus;
    /// Isotropic membranes: Poisson ratio nu in [0, 0.5). Default 0.3.
    double shell_poisson_ratio;
    /// Isotropic membranes: thickness t in m (finite, > 0); the membrane's 2D Lame parameters
    /// are mu = E t / (2 (1 + nu)) and lambda = E t nu / (1 - nu^2) (plane stress), in N/m.
    /// Default 1e-3.
    double shell_thickness;
    /// ORTHOTROPIC_STVK: tensile moduli along the warp and the weft and the in-plane shear
    /// modulus, in N/m (2D moduli, as textile data give them; E t of a plate); finite, > 0.
    /// Defaults 1e3.
    double shell_warp_modulus;
    double shell_weft_modulus;   ///< ORTHOTROPIC_STVK: weft tensile modulus (N/m). Default 1e3.
    double shell_shear_modulus;  ///< ORTHOTROPIC_STVK: in-plane shear modulus (N/m). Default 1e3.
    /// ORTHOTROPIC_STVK: Poisson ratio nu_12 (weft contraction under warp tension), >= 0 with
    /// nu_12^2 weft / warp < 1. Default 0.
    double shell_warp_poisson;
    /// The warp direction, a vector in the rest shape's coordinates (need not be unit): each
    /// triangle's warp is its projection onto the triangle's rest plane (orthotropic membranes
    /// and warp/weft bending need it not normal to any triangle: DEFSIM_ERR_INVALID_MESH).
    /// Default (1, 0, 0).
    double shell_warp_direction[3];
    /// Mass per rest area in kg/m^2 (finite, >= 0). Default 0.1.
    double shell_areal_density;
    /// Bending rigidity D in N m of the discrete-shell hinges (for bending along the warp when
    /// shell_bending_rigidity_weft differs); finite, >= 0; 0: no bending. < 0 (default): an
    /// isotropic membrane's plate rigidity E t^3 / (12 (1 - nu^2)), none for the others.
    double shell_bending_rigidity;
    /// Bending rigidity along the weft (N m), finite, >= 0; < 0 (default): as the warp's.
    double shell_bending_rigidity_weft;
    /* Strain limiting (appended; issue 26, docs/shells.md). */
    /// A cap on each membrane triangle's largest principal stretch (the largest singular value
    /// of its F, over its rest shape): 0.1 keeps every triangle below 1.1 times its rest length
    /// in every direction. 0 (default): none. Enforced as a barrier in the potential (active in
    /// a band of a tenth of the cap below it, zero elsewhere, +inf at the cap) whose line search
    /// never crosses the cap, so only backends with DEFSIM_BACKEND_CONTACT_CCD take it
    /// (newton_cholmod, bdf2, newmark); on another backend defsim_world_add_body returns
    /// DEFSIM_ERR_BACKEND_UNAVAILABLE. Finite, in (0, 1] for a shell body with a membrane;
    /// otherwise (negative, a body without a membrane, tets) DEFSIM_ERR_INVALID_MATERIAL; initial
    /// positions at or over the cap DEFSIM_ERR_INVALID_ARGUMENT.
    double shell_strain_limit;
    /* Contact thickness (appended; issue 26, docs/body-contact.md "Thickness"). */
    /// The body's contact thickness t in m (finite, >= 0, at most 1e3; default 0): contact keeps
    /// the body's surface t / 2 away from everything it touches, so two bodies keep the sum of
    /// their half-thicknesses, (t_A + t_B) / 2, between their surfaces (two layers of cloth of
    /// thickness t rest t apart), one body against itself t, and a body t / 2 from a collider.
    /// The barrier acts on the distance less that offset, inside the band [offset, offset +
    /// dhat]; CCD keeps every pair beyond the offset. 0: contact at the surfaces, as without
    /// it. Self-contact with t > 0 needs t below the distance between non-adjacent primitives
    /// of the rest mesh (about the edge length): else the first step fails as a start closer
    /// than the thickness. Another value is DEFSIM_ERR_INVALID_ARGUMENT.
    double contact_thickness;
} defsim_body_def;

/// The membrane energy of a shell body (defsim_body_def.shell_membrane; docs/shells.md), on
/// the 3x2 deformation gradient F of each triangle over its rest plane, E = (F^T F - I) / 2.
typedef enum defsim_shell_membrane {
    DEFSIM_SHELL_MEMBRANE_NONE = 0,             ///< No membrane (bending, springs or both only).
    DEFSIM_SHELL_MEMBRANE_STVK = 1,             ///< psi = mu |E|^2 + lambda/2 tr(E)^2 (J/m^2).
    DEFSIM_SHELL_MEMBRANE_NEOHOOKEAN = 2,       ///< psi = mu/2 (tr C - 2) - mu log J +
                                                ///< lambda/2 (log J)^2, C = F^T F, J = sqrt(det C).
    DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK = 3  ///< StVK with plane-stress orthotropic moduli in
                                                ///< the warp/weft frame (docs/shells.md).
} defsim_shell_membrane;

/// Fills *def with defaults (no geometry, stable neo-Hookean material). `size` = sizeof *def.
DEFSIM_API void defsim_body_def_init(defsim_body_def *def, size_t size);

/// Adds a body; its vertices follow those of the bodies added before it. Rest tets with negative
/// orientation are reordered (counted in defsim_stats.reordered_tets). On success *out (may be
/// NULL) receives the id. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, not a live world, size,
/// counts, tet_nodes other than 4 or 10),
/// DEFSIM_ERR_INVALID_MESH (index out of range, non-finite coordinate, degenerate tet or spring
/// of zero rest length, repeated vertex, vertex without mass; the message names the element),
/// DEFSIM_ERR_INVALID_MATERIAL (E <= 0, nu outside [0, 0.5), negative density, stiffness, mass or
/// damping, tets with a spring model, friction outside [0, 10]), DEFSIM_ERR_LOCKED (from inside a
/// host callback),
/// DEFSIM_ERR_OUT_OF_MEMORY (also: the world holds the most bodies it can).
DEFSIM_API defsim_status defsim_world_add_body(defsim_world *world, const defsim_body_def *def,
                                               defsim_body_id *out);

/// Removes a body; the vertices of later bodies move down. The id becomes stale.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL world), DEFSIM_ERR_STALE_ID (null, removed, or of
/// another world), DEFSIM_ERR_LOCKED (from inside a host callback), DEFSIM_ERR_OUT_OF_MEMORY.
DEFSIM_API defsim_status defsim_world_remove_body(defsim_world *world, defsim_body_id body);

/// Number of vertices of a live body (>= 1), or a negative status.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL world), DEFSIM_ERR_STALE_ID.
DEFSIM_API int32_t defsim_body_vertex_count(const defsim_world *world, defsim_body_id body);

/// Index of the body's first vertex in the world's arrays, or a negative status.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL world), DEFSIM_ERR_STALE_ID.
DEFSIM_API int32_t defsim_body_vertex_offset(const defsim_world *world, defsim_body_id body);

/// Pins vertices (body-local indices) where they are now: their velocity becomes zero and they do
/// not move until unpinned. Pinning a pinned vertex is allowed. verts may be NULL when n == 0.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, n < 0, index out of range), DEFSIM_ERR_STALE_ID,
/// DEFSIM_ERR_LOCKED (from inside a host callback).
DEFSIM_API defsim_status defsim_body_pin(defsim_world *world, defsim_body_id body,
                                         const int32_t *verts, int32_t n);

/// Unpins vertices (body-local indices); unpinning a free vertex is allowed. Same errors as
/// defsim_body_pin.
DEFSIM_API defsim_status defsim_body_unpin(defsim_world *world, defsim_body_id body,
                                           const int32_t *verts, int32_t n);

/* ------------------------------------------------------------------------------------------ */
/* Simulation                                                                                 */

/// Total vertex count of the world (all live bodies).
DEFSIM_API int32_t defsim_world_vertex_count(const defsim_world *world);

/// Advances the world by h seconds with its backend. On any error the positions, velocities and
/// time are exactly as before the call and the world stays usable.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (h not finite or <= 0, NULL world, or h so small against
/// the time that t + h rounds to t), DEFSIM_ERR_UNSTABLE (the result was not finite, or left the
/// stability watchdog's envelope: energy beyond what the scene's forces explain, a body stretched
/// far beyond its rest size, an inverted neo-Hookean element; see docs/watchdog.md and the
/// core.watchdog options), DEFSIM_ERR_NOT_CONVERGED (implicit backends),
/// DEFSIM_ERR_OUT_OF_MEMORY (first step after a change of bodies or pins, when buffers are made),
/// DEFSIM_ERR_CALLBACK (the force callback or an SDF collider's callback failed),
/// DEFSIM_ERR_LOCKED (from inside a host callback). A vertex so far out (beyond about 1e150 m)
/// that its distance to a collider overflows fails the step with DEFSIM_ERR_UNSTABLE. A world
/// without bodies only advances its time.
/// Work: explicit backends take one step of h (or, with core.auto_substep, up to 1e7 substeps);
/// adaptive ones at most their max_internal_steps internal steps, and sundials_erk refuses at
/// once (DEFSIM_ERR_NOT_CONVERGED) an h that needs more at its stability limit. A host interrupts
/// a long call from its force callback: a non-zero return fails the call with
/// DEFSIM_ERR_CALLBACK at the next force evaluation (every evaluation for explicit backends and
/// sundials_erk; implicit backends call it once per step, or per Newton iterate with a Jacobian).
DEFSIM_API defsim_status defsim_world_step(defsim_world *world, double h);

/// Estimates the largest step that the world's backend can take stably from the current state.
/// omega_max^2 is the largest eigenvalue of M^-1 K(x) over the free DOFs (exact element Hessians,
/// found by power iteration to 1e-4 relative), and c = alpha + beta omega_max^2 the Rayleigh
/// damping of that mode (largest alpha and beta in the scene). The stability region is the
/// backend's: symplectic Euler 2/omega_max without damping (the root of h^2 w^2 + 2 c h = 4 with
/// it), explicit Euler c / omega_max^2 (0 without damping: forward Euler is unstable for any h on
/// an undamped oscillator), +INFINITY for implicit backends. It is a linearisation at the current
/// state: large deformations that stiffen the material lower it. With a collider, backends with
/// penalty contact count it whether or not a vertex touches the collider yet: omega_max^2 =
/// omega_el^2 + (2.5 max(omega_c, omega_el))^2, the factor 2.5 for the energy the penalty's switch
/// feeds an explicit step, and c adds friction's damping rate at a contact at least as deep as
/// d = 0 (docs/stability.md "Contact"). Either output may be NULL.
/// Cost: about 20 to 100 force evaluations. Errors: DEFSIM_ERR_INVALID_ARGUMENT,
/// DEFSIM_ERR_LOCKED (from inside a host callback), DEFSIM_ERR_OUT_OF_MEMORY,
/// DEFSIM_ERR_UNSTABLE (a non-finite stiffness, or a distance to a collider that overflows),
/// DEFSIM_ERR_CALLBACK (an SDF collider's callback failed).
DEFSIM_API defsim_status defsim_world_stable_step(defsim_world *world, double *h_out,
                                                  double *omega_max_out);

/// Simulated time in seconds: the sum of the h of all successful steps.
DEFSIM_API double defsim_world_time(const defsim_world *world);

/// Copies positions (m) into out, which holds 3 * n doubles; n must equal the world's vertex count.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, n mismatch).
DEFSIM_API defsim_status defsim_world_get_positions(const defsim_world *world, double *out,
                                                    int32_t n);

/// Copies velocities (m/s) into out, 3 * n doubles. Same rules as defsim_world_get_positions.
DEFSIM_API defsim_status defsim_world_get_velocities(const defsim_world *world, double *out,
                                                     int32_t n);

/// Borrowed, read-only views of the world's state, for hosts that read it every frame without a
/// copy: *x and *v (either may be NULL) receive the world's own arrays of positions (m) and
/// velocities (m/s), 3 * n doubles each in world vertex order, and *n (may be NULL) the vertex
/// count n. The world owns them: never write through them or free them. Their contents are
/// the state: defsim_world_step, defsim_world_set_state and defsim_body_pin (a pinned vertex's
/// velocity becomes 0) change them in place, and a step that fails leaves them as before it;
/// inside a host callback they hold the state as it is at that moment of the step. The pointers
/// stay valid until the next defsim_world_add_body or defsim_world_remove_body (which move the
/// state into new arrays) or defsim_world_destroy; take them again after those. A world without
/// vertices gives NULL and n = 0.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL or not a live world; the outputs are then NULL
/// and 0).
DEFSIM_API defsim_status defsim_world_state_view(const defsim_world *world, const double **x,
                                                 const double **v, int32_t *n);

/// Copies the lumped vertex masses (kg) into out, n doubles (one per vertex). Same rules as
/// defsim_world_get_positions.
DEFSIM_API defsim_status defsim_world_get_masses(const defsim_world *world, double *out, int32_t n);

/// Sets positions and velocities, each 3 * vertex_count doubles (either may be NULL: unchanged).
/// Pinned vertices take the given positions as their new targets and zero velocity. Backends
/// with internal history (adaptive BDF) restart from this state, unless every value given is
/// bitwise equal to the current one (a get/set round trip, or x and v both NULL): then nothing
/// changes and the run continues bit for bit.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL world, non-finite value), DEFSIM_ERR_LOCKED (from
/// inside a host callback).
DEFSIM_API defsim_status defsim_world_set_state(defsim_world *world, const double *x,
                                                const double *v);

/// Energies of the current state, in joules.
typedef struct defsim_energy {
    double kinetic;        ///< 1/2 v^T M v.
    double elastic;        ///< Springs, tets and attachment springs, relative to the rest state
                           ///< (see README).
    double gravitational;  ///< Potential of the constant force fields: -sum (m g + f_ext) . x,
                           ///< with f_ext the held external forces (zero at the origin). The
                           ///< force callback has no potential and is not included.
    double total;          ///< kinetic + elastic + gravitational.
} defsim_energy;

/// Computes the energies of the current state.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL); DEFSIM_ERR_UNSTABLE when the total is not finite
/// (an inverted neo-Hookean element, whose energy is undefined, or an overflow): *out is still
/// filled, with elastic and total +INFINITY for an inverted element.
DEFSIM_API defsim_status defsim_world_energy(const defsim_world *world, defsim_energy *out);

/// Elastic forces -dE/dx (N) at positions x (3 * vertex_count doubles; NULL: current positions),
/// written to f_out (3 * vertex_count): springs, tets and attachment springs. No gravity,
/// damping, external forces, callback or pinning is applied.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL world or f_out, a non-finite entry of x: f_out
/// untouched), DEFSIM_ERR_UNSTABLE (the forces are not finite: an inverted neo-Hookean element,
/// an overflow; f_out holds them as computed), DEFSIM_ERR_LOCKED (from inside a host callback:
/// it compiles the world and counts in its statistics), DEFSIM_ERR_OUT_OF_MEMORY.
DEFSIM_API defsim_status defsim_world_forces(defsim_world *world, const double *x, double *f_out);

/// Passes the world ran in its last step (bits of defsim_stats.passes).
enum {
    DEFSIM_PASS_SPRINGS = 1u << 0,          ///< Spring forces.
    DEFSIM_PASS_STVK = 1u << 1,             ///< One bit per tet material kernel...
    DEFSIM_PASS_COROTATED = 1u << 2,
    DEFSIM_PASS_NEOHOOKEAN = 1u << 3,
    DEFSIM_PASS_STABLE_NEOHOOKEAN = 1u << 4,
    DEFSIM_PASS_GRAVITY = 1u << 5,          ///< Gravity forces (skipped when g = 0).
    DEFSIM_PASS_MASS_DAMPING = 1u << 6,     ///< -alpha M v (skipped when every alpha = 0).
    DEFSIM_PASS_STIFFNESS_DAMPING = 1u << 7,///< -beta K v (skipped when every beta = 0).
    DEFSIM_PASS_PINS = 1u << 8,             ///< Pinned-vertex handling (skipped without pins).
    DEFSIM_PASS_HESSIAN = 1u << 9,          ///< Stiffness matrix assembly (implicit backends only).
    DEFSIM_PASS_ENERGY = 1u << 10,          ///< Energy evaluation inside the step (line searches).
    DEFSIM_PASS_EXTERNAL_FORCES = 1u << 11, ///< Held external forces (skipped when none are set).
    DEFSIM_PASS_FORCE_CALLBACK = 1u << 12,  ///< The host's force callback (skipped when none).
    DEFSIM_PASS_ATTACHMENTS = 1u << 13,     ///< Attachment springs (skipped without attachments).
    DEFSIM_PASS_DRIVEN_PINS = 1u << 14,     ///< Pinned vertices moved to targets in this step.
    DEFSIM_PASS_MEMBRANE = 1u << 15,        ///< Shell membrane forces (docs/shells.md).
    DEFSIM_PASS_BENDING = 1u << 16          ///< Shell hinge (bending) forces.
};

/// The core's counters and timings, cumulative since creation (or since
/// defsim_world_reset_stats). Times are wall-clock seconds. Fields are only ever appended (the
/// backend counters this struct held before, newton_iterations ... nonlinear_residual, left it:
/// each backend declares its own, read by name as "<backend>.<counter>" with defsim_world_stat
/// and listed by defsim_world_stat_info; docs/api.md lists those of the shipped backends).
typedef struct defsim_stats {
    uint32_t size;                 ///< Set by the caller to sizeof(defsim_stats) before the call.
    uint32_t passes;               ///< DEFSIM_PASS_* bits of the last step.
    int64_t steps;                 ///< Successful calls of defsim_world_step.
    int64_t failed_steps;          ///< Calls that returned an error (state rolled back).
    int32_t threads;               ///< Threads used for assembly.
    int32_t reordered_tets;        ///< Rest tets with negative orientation that were reordered.
    double time_step;              ///< Total time inside defsim_world_step.
    double time_forces;            ///< Force evaluation (elastic, gravity, damping).
    double time_hessian;           ///< Stiffness matrix assembly.
    int64_t force_evals;           ///< Force evaluations.
    int64_t hessian_evals;         ///< Stiffness matrix assemblies.
    int64_t energy_evals;          ///< Potential energy evaluations (the watchdog's included).
    int64_t substeps;              ///< Backend steps taken by auto_substep (>= steps when on).
    double stable_step;            ///< Last estimate of the stable step (s), 0 if never made.
    /* Stability watchdog (docs/watchdog.md). The first three are computed from the current state
     * when the statistics are read (one pass over the tets and one energy evaluation), not by
     * the step, and only once the world is planned (by a step, defsim_world_forces or
     * defsim_world_stable_step): before, min_volume_ratio and energy_drift are NaN and
     * inverted_elements 0. The others are kept by the step. */
    double min_volume_ratio;       ///< Smallest J = det F over all tets now (1 without tets).
    int64_t inverted_elements;     ///< Tets with J <= 0 now (any model; neo-Hookean ones fail
                                   ///< the step that inverts them while the watchdog is on).
    double energy_drift;           ///< J: total energy now (kinetic of free vertices plus
                                   ///< elastic) minus the energy at the watchdog's reference
                                   ///< (with the contact energy then) and the work done since:
                                   ///< gravity and applied forces exactly; the force callback,
                                   ///< driven pins and moving colliders as upper bounds, and
                                   ///< the contact energy of colliders added (docs/watchdog.md);
                                   ///< negative when damping dissipates. NaN without a
                                   ///< reference (the watchdog is off, or the last step's work
                                   ///< overflowed).
    int64_t watchdog_trips;        ///< Steps the watchdog failed with DEFSIM_ERR_UNSTABLE.
} defsim_stats;

/// Copies the world's statistics into *out; set out->size = sizeof *out first (a smaller size
/// from an older header receives the fields it knows). Errors: DEFSIM_ERR_INVALID_ARGUMENT.
DEFSIM_API defsim_status defsim_world_stats(const defsim_world *world, defsim_stats *out);

/// Zeroes the counters and timings (not reordered_tets, threads, passes), including the
/// backend's counters by name. Does nothing for a NULL world or from inside a host callback.
DEFSIM_API void defsim_world_reset_stats(defsim_world *world);

/* ------------------------------------------------------------------------------------------ */
/* Options and statistics by name                                                             */

/// Type of an option. Every option value is held in a double.
typedef enum defsim_option_type {
    DEFSIM_OPTION_REAL = 1,     ///< A real number within [min_value, max_value].
    DEFSIM_OPTION_INT = 2,      ///< A whole number within [min_value, max_value].
    DEFSIM_OPTION_BOOL = 3,     ///< 0 or 1; as text "true|false|on|off|1|0".
    DEFSIM_OPTION_CHOICE = 4    ///< One of the names in `choices` ("none|clamp|abs"); the value is
                                ///< its index (0-based).
} defsim_option_type;

/// Description and current value of one option of a world (defsim_world_option_info).
typedef struct defsim_option_info {
    uint32_t size;              ///< Set by the caller to sizeof(defsim_option_info) before the call.
    const char *name;           ///< Full name: "core.simd", "sundials_ida.rtol". Borrowed.
    defsim_option_type type;    ///< REAL, INT, BOOL or CHOICE.
    double value;               ///< Current value (CHOICE: index into choices).
    double default_value;       ///< The value a new world has.
    double min_value;           ///< Inclusive range (REAL, INT); 0 and 1 for BOOL; 0 and the
    double max_value;           ///< number of choices - 1 for CHOICE.
    const char *choices;        ///< CHOICE: names separated by '|'; NULL otherwise. Borrowed.
    const char *doc;            ///< One line with units. Borrowed.
} defsim_option_info;

/// Sets an option of the world by name. `name` is "<backend>.<option>" for an option of the
/// world's backend ("sundials_ida.max_order") or "core.<option>" for an option of the world
/// itself: "core.simd" (auto|scalar|generic|avx2|avx512: the tet force kernels; the environment
/// variable DEFSIM_SIMD, when set, overrides it), "core.auto_substep" (BOOL),
/// "core.substep_safety" (REAL in [0.01, 1]), and the stability watchdog's "core.watchdog" (BOOL,
/// default on), "core.watchdog_energy_growth" (REAL >= 1, default 10) and
/// "core.watchdog_max_stretch" (REAL >= 1, default 100) (docs/watchdog.md). `value` is text: a number ("3", "1e-6"), a BOOL word
/// ("true", "false", "on", "off", "1", "0") or a CHOICE name ("clamp"). Changing an option of the
/// backend re-initialises the backend (fini, then init) before the next step: adaptive history
/// is dropped as by defsim_world_set_state; counters are kept. Setting an option to its current
/// value changes nothing. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, unknown name, an option of
/// a backend other than the world's, unparsable or out of range; defsim_world_last_error names
/// the valid range or choices, and the world is unchanged), DEFSIM_ERR_LOCKED (from inside a
/// host callback).
DEFSIM_API defsim_status defsim_world_set_option(defsim_world *world, const char *name,
                                                 const char *value);

/// Sets an option by name to a number: REAL and INT values (INT must be whole), BOOL 0 or 1,
/// CHOICE the index of a choice. Same rules and errors as defsim_world_set_option.
DEFSIM_API defsim_status defsim_world_set_option_number(defsim_world *world, const char *name,
                                                        double value);

/// Reads the current value of an option by name into *value (CHOICE: the index of the choice).
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, unknown name).
DEFSIM_API defsim_status defsim_world_get_option(const defsim_world *world, const char *name,
                                                 double *value);

/// Number of options of the world: the core's, then its backend's. 0 for a NULL world.
DEFSIM_API int32_t defsim_world_option_count(const defsim_world *world);

/// Describes option i (0 .. defsim_world_option_count - 1) into *out; set out->size first (a
/// smaller size from an older header receives the fields it knows). The strings are borrowed
/// and valid until the world is destroyed. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, size,
/// i out of range).
DEFSIM_API defsim_status defsim_world_option_info(const defsim_world *world, int32_t i,
                                                  defsim_option_info *out);

/// Reads a statistic by name into *value: a field of defsim_stats by its field name ("steps",
/// "force_evals", "time_step", ...; integer fields are converted to double), a counter of the
/// world's backend ("sundials_ida.internal_steps", "newton_cholmod.newton_iterations"), contact's ("contact.active",
/// docs/contact.md), or a counter of a term kind ("collider.linearisations",
/// "body_contact.cached_pairs": Hessian evaluations since the world was planned or its
/// statistics reset, and the pair Hessians cached now). min_volume_ratio, inverted_elements and energy_drift are computed from the
/// current state at this call (see defsim_stats).
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, unknown name).
DEFSIM_API defsim_status defsim_world_stat(const defsim_world *world, const char *name,
                                           double *value);

/// Number of statistics by name: the fields of defsim_stats (except size), then the backend's
/// counters, then contact's (contact.*), then the term kinds' ("<kind>.<counter>"). 0 for a
/// NULL world.
DEFSIM_API int32_t defsim_world_stat_count(const defsim_world *world);

/// Name and value of statistic i (0 .. defsim_world_stat_count - 1). Either output may be NULL.
/// The name is borrowed and valid until the world is destroyed.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL world, i out of range).
DEFSIM_API defsim_status defsim_world_stat_info(const defsim_world *world, int32_t i,
                                                const char **name, double *value);

/* ------------------------------------------------------------------------------------------ */
/* Meshes                                                                                     */

/// A mesh made or loaded by the library. Arrays are owned by the library: release them with
/// defsim_mesh_free. Counts are 0 and pointers NULL for what the mesh does not have.
typedef struct defsim_mesh {
    uint32_t size;           ///< Set by the caller to sizeof(defsim_mesh) before the call.
    double *positions;       ///< 3 * vertex_count, m.
    int32_t vertex_count;    ///< Vertices.
    int32_t *tets;           ///< 4 per tet, positively oriented.
    int32_t tet_count;       ///< Tets.
    int32_t *triangles;      ///< 3 per triangle: cloth faces, or the boundary of the tets.
    int32_t triangle_count;  ///< Triangles.
    int32_t *springs;        ///< 2 per spring (edges of cloth, rope links).
    int32_t spring_count;    ///< Springs.
    /// One defsim_spring_kind per spring (cloth and rope meshes), or NULL: every spring is a
    /// stretch spring. Only written when `size` covers this field (older callers keep working).
    int32_t *spring_kinds;
    /// Indices per tet in `tets`: 4 (linear) or 10 (quadratic, the order of
    /// defsim_body_def.tet_nodes). Only written when `size` covers this field; a mesh with
    /// quadratic tets is only made for a caller whose `size` covers it.
    int32_t tet_nodes;
} defsim_mesh;

/// Makes a box of nx * ny * nz hexahedra on [lo, hi], each split into 6 positively oriented tets
/// (Kuhn split along the cell diagonal; conforming), vertex index i + (nx+1)(j + (ny+1) k).
/// mesh->size must be set; on success the arrays are allocated (free with defsim_mesh_free).
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, n < 1, empty box, a corner beyond +-1e100 m),
/// DEFSIM_ERR_OUT_OF_MEMORY.
DEFSIM_API defsim_status defsim_mesh_box(const double lo[3], const double hi[3], int32_t nx,
                                         int32_t ny, int32_t nz, defsim_mesh *mesh);

/// Turns a mesh of linear tets (tet_nodes 4, as defsim_mesh_box and defsim_mesh_load make them)
/// into quadratic tets: one new vertex at the middle of each edge (appended after the mesh's
/// vertices, in the order edges are first met), 10 indices per tet (defsim_body_def.tet_nodes),
/// and the boundary triangles split into 4 each through the mid-edge vertices (outward, as
/// before). The mesh's arrays are replaced (free with defsim_mesh_free); on failure it is
/// unchanged. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, `size` that does not cover tet_nodes,
/// a mesh without tets or whose tets are already quadratic), DEFSIM_ERR_OUT_OF_MEMORY.
DEFSIM_API defsim_status defsim_mesh_make_quadratic(defsim_mesh *mesh);

/// Frees the arrays of a mesh made by the library and sets its pointers to NULL and counts to 0.
/// NULL is ignored.
DEFSIM_API void defsim_mesh_free(defsim_mesh *mesh);

/// Loads a mesh file, choosing the format by the file's extension:
///  - ".node" / ".ele" (TetGen; either file of the pair, or the base name "beam.1" when
///    "beam.1.node" exists): linear tets, or quadratic ones (10 nodes per tet: `tetgen -o2`),
///    any first index; attributes and markers are ignored.
///  - ".msh" (Gmsh 2.x and 4.0 / 4.1, ASCII): linear tetrahedra (type 4) or quadratic ones (type
///    11), not both. Points, lines and surface elements are skipped; any other volume element
///    (hexahedra, prisms, ...) is an error.
///  - ".obj" (Wavefront): faces (polygons are fan-triangulated; "v/vt/vn" forms and negative,
///    relative indices are accepted) and polylines ("l"). The unique edges of the faces and the
///    polyline segments become springs, sorted by vertex pair (a cloth or a rope); no bending
///    springs are added. Texture coordinates, normals, groups and materials are ignored.
/// Vertices that no element uses are dropped; the others keep their order in the file. Tets are
/// reordered to positive orientation and `triangles` receives their outward boundary (for OBJ,
/// the faces as given). Quadratic tets come with tet_nodes = 10: their mid-edge nodes are put in
/// defsim_body_def.tet_nodes' order by position (each edge takes the node nearest its middle, so
/// the file's order of them does not matter), and each boundary face gives 4 triangles; a
/// mesh->size that does not cover tet_nodes is then DEFSIM_ERR_INVALID_ARGUMENT. mesh->size must be set; on success the arrays are allocated (free with
/// defsim_mesh_free), on failure *mesh is unchanged. Only regular files are read (a FIFO,
/// device or socket is refused without blocking), within the limits of defsim_set_limit (file
/// size, vertex and element counts); coordinates must lie within +-1e100 m (so that lengths
/// and volumes stay finite).
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, mesh->size, unknown extension), DEFSIM_ERR_IO
/// (cannot read, not a regular file, larger than DEFSIM_LIMIT_FILE_BYTES, malformed or binary
/// file), DEFSIM_ERR_INVALID_MESH (unsupported element, undefined or repeated vertex, degenerate
/// tet, a quadratic tet whose mid-edge nodes are not one near each edge's middle or that they
/// invert, linear and quadratic tets mixed, zero-length edge, no elements, a coordinate beyond +-1e100 m, more vertices or elements
/// than their limit), DEFSIM_ERR_OUT_OF_MEMORY; defsim_last_error() says "file:line: ...".
/// Thread-safe.
DEFSIM_API defsim_status defsim_mesh_load(const char *path, defsim_mesh *mesh);

/// Makes a cloth grid of (nu + 1) x (nv + 1) vertices at origin + i/nu * u + j/nv * v (m),
/// vertex index i + (nu + 1) j, with two triangles per cell (split along the diagonal from
/// (i, j) to (i + 1, j + 1), normals along u x v) and springs in this order:
/// structural along u (nu (nv + 1)), structural along v ((nu + 1) nv), shear (both diagonals of
/// every cell, 2 nu nv), then bending between every second vertex along u ((nu - 1)(nv + 1)) and
/// along v ((nu + 1)(nv - 1)). mesh->spring_kinds tells each spring's kind (stretch, shear,
/// bend): pass it as defsim_body_def.spring_kinds with shear_stiffness and bend_stiffness to
/// give each kind its stiffness (or defsim_body_def.spring_stiffness, one k per spring).
/// mesh->size must be set; on success the arrays are allocated (free with defsim_mesh_free).
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, nu or nv < 1, too large, u and v not spanning a
/// plane, non-finite input or a corner beyond +-1e100 m), DEFSIM_ERR_OUT_OF_MEMORY.
DEFSIM_API defsim_status defsim_mesh_cloth(const double origin[3], const double u[3],
                                           const double v[3], int32_t nu, int32_t nv,
                                           defsim_mesh *mesh);

/// Makes a rope from a to b (m): segments + 1 equally spaced vertices, `segments` springs
/// between neighbours (vertex i to i + 1, in order), then segments - 1 bending springs between
/// every second vertex (i to i + 2), with spring_kinds DEFSIM_SPRING_STRETCH and
/// DEFSIM_SPRING_BEND. No tets or triangles.
/// mesh->size must be set; on success the arrays are allocated (free with defsim_mesh_free).
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, segments < 1 or too large, a == b, non-finite
/// input or an end beyond +-1e100 m), DEFSIM_ERR_OUT_OF_MEMORY.
DEFSIM_API defsim_status defsim_mesh_rope(const double a[3], const double b[3], int32_t segments,
                                          defsim_mesh *mesh);

/* ------------------------------------------------------------------------------------------ */
/* Coupling with the host: external forces, driven pins, attachments, read-back               */
/*                                                                                            */
/* These are terms of the world's forces, energy and stiffness: every backend sees them       */
/* through the same host services as elasticity and gravity, and a world that does not use    */
/* them runs exactly the passes it ran before (see defsim_stats.passes).                      */

/// Sets one constant external force per vertex (N), 3 * n doubles in world vertex order; n must
/// equal defsim_world_vertex_count. The forces are copied and held, in every step that follows,
/// until changed or cleared: f == NULL (n is then ignored) clears them. Forces on pinned vertices
/// are kept but have no effect while the vertex is pinned. When a body is added its vertices get
/// zero force; when one is removed its forces go with it, the others keep theirs. Held forces
/// are a potential force field (energy -f . x, reported in defsim_energy.gravitational), so
/// implicit backends treat them exactly. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL world, n
/// different from the vertex count, a non-finite value: the message names the vertex; the
/// forces held before the call are kept), DEFSIM_ERR_LOCKED (from inside a host callback),
/// DEFSIM_ERR_OUT_OF_MEMORY.
DEFSIM_API defsim_status defsim_world_set_external_forces(defsim_world *world, const double *f,
                                                          int32_t n);

/// A host force callback. Adds forces (N) into f_inout (3 * n doubles, world vertex order; it
/// holds the world's other forces, or zeros: add to it, do not overwrite it) at positions
/// x (m) and velocities v (m/s), 3 * n doubles each, at time t (s). x, v and f_inout are
/// borrowed for the call. Returns 0 on success; any other value is a failure: the step (or the
/// call) that evaluated it fails with DEFSIM_ERR_CALLBACK and the world's state is unchanged.
/// A non-finite force is treated as a failure too. The callback must not call the world.
/// Forces it adds to pinned vertices have no effect (but count in defsim_world_get_pin_forces).
/// Adaptive backends may call it at times up to one internal step past the end of the current
/// defsim_world_step (sundials_ida steps past t + h and interpolates the state at t + h), so
/// within a call it should depend on (x, v, t) only.
typedef int (*defsim_force_fn)(void *user, const double *x, const double *v, double t, int32_t n,
                               double *f_inout);

/// Optional Jacobian of a force callback: writes the per-vertex 3x3 blocks dF_i/dx_i (N/m),
/// row-major (blocks[9 i + 3 r + c] = d F_i[r] / d x_i[c]), 9 * n doubles, at (x, v, t).
/// Couplings between different vertices are not expressible and taken as zero; implicit
/// backends use the symmetric part of each block, made negative semi-definite as the world's
/// projection does for element Hessians (so a force that pushes away from equilibrium is
/// treated by the stabilised part only). Same return convention as defsim_force_fn.
typedef int (*defsim_force_jacobian_fn)(void *user, const double *x, const double *v, double t,
                                        int32_t n, double *blocks);

/// Sets the world's force callback (fn == NULL clears it, with its jacobian and user). `user`
/// is passed to both functions and stays owned by the host; it must outlive the world or the
/// next call of this function.
/// When it runs: explicit backends (explicit_euler, symplectic_euler, velocity_verlet,
/// sundials_erk) call fn at every force evaluation with that evaluation's x, v and t (so an
/// adaptive or multi-stage method sees the time within the step). Implicit backends (those
/// flagged DEFSIM_BACKEND_IMPLICIT) with a jacobian call fn and jacobian at every Newton
/// iterate (the force enters the residual, its Jacobian the Newton matrix, and the line-search
/// energy the quadratic model -f0 . d - d^T J0 d / 2 with d = x - x_n, f0, J0 at the step's
/// start); without a jacobian they call fn once at the start of the step, at (x_n, v_n, t_n),
/// and hold that force constant over the step (first-order lag: fine for slowly varying forces,
/// unstable for stiff ones; give a jacobian then). Implicit backends also call fn (and the
/// jacobian) once at the start of every step, for the held value and the line-search model. When
/// a backend evaluates forces without velocities, fn receives the world's current velocity array.
/// defsim_world_get_pin_forces calls fn at the current state.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL world, a jacobian without fn), DEFSIM_ERR_LOCKED
/// (from inside a host callback), DEFSIM_ERR_OUT_OF_MEMORY.
DEFSIM_API defsim_status defsim_world_set_force_callback(defsim_world *world, defsim_force_fn fn,
                                                         defsim_force_jacobian_fn jacobian,
                                                         void *user);

/// Drives pinned vertices: each listed vertex (body-local index) is pinned by this call if it
/// was not, and reaches positions[3 i .. 3 i + 2] (m) exactly at the end of the next step,
/// moving on the straight line from where it is with constant velocity (displacement / h) over
/// that step, which is also its velocity when the step ends. In the steps after that it stays
/// where it arrived (an ordinary pin, velocity zero) unless given a new target. Backends see the
/// motion within the step (implicit ones as Dirichlet conditions with prescribed values, IDA with
/// the consistent derivative). Calling it again before stepping replaces the targets of the
/// vertices it lists. Unpinning a vertex drops its target. verts may be NULL when n == 0.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, n < 0, index out of range, a non-finite
/// position), DEFSIM_ERR_STALE_ID, DEFSIM_ERR_LOCKED (from inside a host callback),
/// DEFSIM_ERR_OUT_OF_MEMORY; on error nothing changes.
DEFSIM_API defsim_status defsim_body_set_pin_targets(defsim_world *world, defsim_body_id body,
                                                     const int32_t *verts, int32_t n,
                                                     const double *positions);

/// An attachment handle: a small value like defsim_body_id (tagged with its world, slots
/// reused). {0, 0} is the null id. Ids of removed attachments, and of another world's, are
/// stale and rejected with DEFSIM_ERR_STALE_ID.
typedef struct defsim_attachment_id {
    uint32_t index;        ///< The slot, with the world's tag.
    uint32_t generation;   ///< The slot's generation; 0 only in the null id.
} defsim_attachment_id;

/// Creation parameters of an attachment: a zero-rest-length spring (energy k/2 |x_v - p|^2) with
/// an optional damper (force -c (v_v - v_p)) from one vertex of `body` to a target point p:
///  - target_body null ({0, 0}): p is the world point `target` (m), held fixed during steps,
///    velocity zero, until defsim_attachment_set_target moves it;
///  - otherwise p = sum_j target_weights[j] x[target_vertices[j]] over target_vertex_count
///    (1 to 4) body-local vertices of target_body: a vertex (1), an edge (2), a triangle (3:
///    a row of defsim_mesh.triangles, for a cloth or the boundary of a solid) or a tet (4: a row
///    of defsim_mesh.tets). The weights are barycentric: finite and summing to 1 (within 1e-9),
///    so that moving both ends together stretches nothing; the spring's reaction is spread over
///    the target vertices with the same weights, and its exact Hessian couples both bodies.
/// Fill with defsim_attachment_def_init, then change what you need.
typedef struct defsim_attachment_def {
    uint32_t size;                  ///< sizeof(defsim_attachment_def), set by the init function.
    defsim_body_id body;            ///< Body of the attached vertex. Required.
    int32_t vertex;                 ///< Body-local index of the attached vertex.
    double stiffness;               ///< k in N/m, > 0. Default 1e3.
    double damping;                 ///< c in N s/m, >= 0. Default 0.
    double target[3];               ///< World point (m) when target_body is null. Default 0.
    defsim_body_id target_body;     ///< Body of the target element, or null for a world point.
    int32_t target_vertex_count;    ///< 1..4 (target_body only). Default 0.
    int32_t target_vertices[4];     ///< Body-local vertex indices of target_body.
    double target_weights[4];       ///< Barycentric weights of those vertices.
} defsim_attachment_def;

/// Fills *def with defaults (no body, k = 1e3 N/m, no damping, the world origin as target).
/// `size` must be sizeof *def. Does nothing if def is NULL.
DEFSIM_API void defsim_attachment_def_init(defsim_attachment_def *def, size_t size);

/// Adds an attachment; on success *out (may be NULL) receives its id. An attachment whose body
/// or target body is removed is removed with it (its id becomes stale). A pinned attached
/// vertex is allowed: the spring then acts on the target only (and on the pin's reaction).
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, size, stiffness <= 0 or damping < 0 or not
/// finite, vertex or target vertex out of range, target_vertex_count outside 1..4, weights not
/// finite or not summing to 1, a non-finite target), DEFSIM_ERR_STALE_ID (body or target_body),
/// DEFSIM_ERR_LOCKED (from inside a host callback), DEFSIM_ERR_OUT_OF_MEMORY (also: the world
/// holds the most attachments it can).
DEFSIM_API defsim_status defsim_world_add_attachment(defsim_world *world,
                                                     const defsim_attachment_def *def,
                                                     defsim_attachment_id *out);

/// Removes an attachment; its id becomes stale. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL
/// world), DEFSIM_ERR_STALE_ID, DEFSIM_ERR_LOCKED (from inside a host callback).
DEFSIM_API defsim_status defsim_world_remove_attachment(defsim_world *world,
                                                        defsim_attachment_id attachment);

/// Moves the world point of an attachment to a world point (target_body becomes null if it was
/// not: the attachment now pulls towards `target`, m). The point is held during the steps that
/// follow (it jumps; it does not move within a step). Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL,
/// non-finite target), DEFSIM_ERR_STALE_ID, DEFSIM_ERR_LOCKED (from inside a host callback).
DEFSIM_API defsim_status defsim_attachment_set_target(defsim_world *world,
                                                      defsim_attachment_id attachment,
                                                      const double target[3]);

/// The force (N) that the attachment applies to its vertex at the current state:
/// -k (x_v - p) - c (v_v - v_p). Its target receives the opposite force (spread by the weights).
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL), DEFSIM_ERR_STALE_ID.
DEFSIM_API defsim_status defsim_world_get_attachment_force(const defsim_world *world,
                                                           defsim_attachment_id attachment,
                                                           double out[3]);

/// Reaction forces of the pins (N), 3 * n doubles, n = the world's vertex count: for each pinned
/// (or driven) vertex, the force its support applies to the body to hold it on its path,
/// R_i = m_i a_i - f_i(x, v, t) with f_i the total force of the world on that vertex (elastic,
/// gravity, damping, external forces, callback, attachments) at the current state, and a_i = 0
/// (pins move with constant velocity within a step). Free vertices get 0. At static equilibrium
/// the pin forces sum to minus the sum of the world's applied forces (for a hanging body: its
/// weight, pointing up). A rigid-body engine coupled two-way applies -R_i to what holds the pin.
/// Evaluated on demand (one force evaluation, plus the force callback if one is set).
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, n mismatch), DEFSIM_ERR_CALLBACK (the force
/// callback failed, also when nothing is pinned; out is unchanged), DEFSIM_ERR_LOCKED (from
/// inside a host callback: it calls the force callback), DEFSIM_ERR_OUT_OF_MEMORY.
DEFSIM_API defsim_status defsim_world_get_pin_forces(defsim_world *world, double *out,
                                                     int32_t n);

/// Per-tet stress of a body at the current state, in the order of its tets as given to
/// defsim_world_add_body (tet_count must equal that count; a spring body has 0): the Cauchy
/// stress sigma = P F^T / det F (Pa, row-major 3x3, 9 doubles per tet), its von Mises value
/// sqrt(3/2 s : s) with s = sigma - tr(sigma)/3 I (Pa, 1 per tet), and the strain energy density
/// psi(F) relative to rest (J/m^3 of rest volume, 1 per tet). Any output may be NULL. All are
/// zero at rest. A tet with det F = 0, or det F <= 0 under the neo-Hookean model (undefined
/// there), gets NaN stresses; its energy density is that of the model (+inf for neo-Hookean).
/// A body with volume_averaging reports its tets' isochoric stress plus their averaged nodal
/// pressure p_e cof(F) (the stress its forces come from), and the isochoric energy density plus
/// the mean of its vertices' volumetric U(J_n); with quadratic tets, the mean over the
/// quadrature points of the isochoric stress plus the element's pressure U'(Jbar) cof(F), and
/// the element's energy (isochoric at the points, U(Jbar) of its mean volume ratio) over its
/// volume.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL world, tet_count mismatch), DEFSIM_ERR_STALE_ID,
/// DEFSIM_ERR_OUT_OF_MEMORY (volume_averaging only).
DEFSIM_API defsim_status defsim_body_element_stress(const defsim_world *world,
                                                    defsim_body_id body, double *cauchy,
                                                    double *von_mises, double *energy_density,
                                                    int32_t tet_count);


/* ------------------------------------------------------------------------------------------ */
/* Colliders: shapes the host places and moves. They push on the bodies (contact with Coulomb */
/* friction) and are not pushed back: the host reads the contact forces                        */
/* (defsim_world_get_contact_forces) to move its own rigid bodies.                             */

/// Shape of a collider. Every shape is given in its own frame and placed by the collider's pose
/// (position, rotation). The y axis is "up" by default (the default gravity is -y).
typedef enum defsim_shape {
    DEFSIM_SHAPE_PLANE = 0,    ///< The half-space below the plane through the origin with
                               ///< outward normal `normal` (local frame).
    DEFSIM_SHAPE_SPHERE = 1,   ///< A ball of `radius` about the origin.
    DEFSIM_SHAPE_BOX = 2,      ///< A box with `half_extents` about the origin.
    DEFSIM_SHAPE_CAPSULE = 3,  ///< The points within `radius` of the segment from
                               ///< (0, -half_height, 0) to (0, half_height, 0).
    DEFSIM_SHAPE_MESH = 4,     ///< A static triangle mesh (closed or open; copied at creation).
    DEFSIM_SHAPE_SDF = 5       ///< A signed distance given by the host's callback `sdf`.
} defsim_shape;

/// A host signed-distance function: returns the signed distance (m, < 0 inside) of the point
/// p (m, in the collider's local frame) and writes its gradient (unit outward normal, local
/// frame) into grad. Called during steps, from the stepping thread only; a non-finite return
/// or gradient, or a gradient of zero length, fails the step with DEFSIM_ERR_CALLBACK and the
/// state unchanged. The gradient need not be unit (defsim normalises it). The value must be a
/// true distance bound: |sdf(p) - sdf(q)| <= |p - q| (|grad| <= 1), which continuous collision
/// detection relies on to never step a vertex through the surface. The Hessian is taken by
/// central differences (1e-5 m) of the normalised gradient: 6 more calls where contact needs it.
typedef double (*defsim_sdf_fn)(void *user, const double p[3], double grad[3]);

/// A collider handle: a small value like defsim_body_id (tagged with its world, slots reused).
/// {0, 0} is the null id. Ids of removed colliders, and of another world's, are stale and
/// rejected with DEFSIM_ERR_STALE_ID.
typedef struct defsim_collider_id {
    uint32_t index;        ///< The slot, with the world's tag.
    uint32_t generation;   ///< The slot's generation; 0 only in the null id.
} defsim_collider_id;

/// Creation parameters of a collider. Fill with defsim_collider_def_init, then change what the
/// shape needs; fields of other shapes are ignored.
typedef struct defsim_collider_def {
    uint32_t size;              ///< sizeof(defsim_collider_def), set by the init function.
    defsim_shape shape;         ///< Default DEFSIM_SHAPE_PLANE.
    double position[3];         ///< Origin of the collider's frame in the world (m). Default 0.
    double rotation[4];         ///< Unit quaternion (w, x, y, z) from the local frame to the
                                ///< world. Default (1, 0, 0, 0). A quaternion within 1e-6 of unit
                                ///< length is normalised; others are rejected.
    double normal[3];           ///< PLANE: outward normal (local frame; normalised, not zero).
                                ///< Default (0, 1, 0).
    double radius;              ///< SPHERE, CAPSULE: radius (m, a normal number in
                                ///< [DBL_MIN, 1e100]). Default 0.5.
    double half_extents[3];     ///< BOX: half side lengths (m, each in [DBL_MIN, 1e100]).
                                ///< Default (0.5, 0.5, 0.5).
    double half_height;         ///< CAPSULE: half length of its axis segment (m, 0 or in
                                ///< [DBL_MIN, 1e100]). Default 0.5.
    double friction;            ///< Coulomb friction coefficient mu (>= 0). Default 0.
    const double *vertices;     ///< MESH: 3 * vertex_count coordinates (m, local frame). Copied.
    int32_t vertex_count;       ///< MESH: >= 3.
    const int32_t *triangles;   ///< MESH: 3 * triangle_count vertex indices. Copied.
    int32_t triangle_count;     ///< MESH: >= 1.
    defsim_sdf_fn sdf;          ///< SDF: the distance function. Required for SDF.
    void *sdf_user;             ///< SDF: passed to sdf. Borrowed: must outlive the collider.
    double sdf_bounds[6];       ///< SDF: local box (lo xyz, hi xyz, m) outside which the
                                ///< distance is at least the distance to that box, so that
                                ///< vertices far away are never queried. Default: all zero,
                                ///< meaning unbounded (every vertex is queried every step).
    /* appended */
    /// 1: `rotation` and `normal` are unit already (as defsim_world_get_collider returns them)
    /// and are kept bit for bit instead of being divided by their computed length again,
    /// which can change their last bits (scene files that defsim_scene_export writes rebuild
    /// a collider exactly so); each must still be within 1e-6 of unit length. Default 0.
    int32_t normalized;
} defsim_collider_def;

/// Fills *def with defaults (a ground plane through the origin, normal +y, no friction).
/// `size` must be sizeof *def. Does nothing if def is NULL.
DEFSIM_API void defsim_collider_def_init(defsim_collider_def *def, size_t size);

/// Adds a collider; on success *out (may be NULL) receives its id. Mesh arrays are copied.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, size, unknown shape, non-finite numbers, a
/// position beyond +-1e100 m (the coordinate bound of meshes: distances would overflow), a zero
/// normal, a radius or half extent not in [DBL_MIN, 1e100] m (zero, negative, denormal or too
/// large), a half_height neither 0 nor in that range, friction < 0, a quaternion not within
/// 1e-6 of unit length, a mesh with too few vertices or triangles, NULL arrays, mesh
/// coordinates non-finite or beyond +-1e100 m, an index out of range or a zero-area triangle, an
/// SDF without a callback or with sdf_bounds lo > hi or beyond +-1e100 m), DEFSIM_ERR_LOCKED (from inside a host callback),
/// DEFSIM_ERR_OUT_OF_MEMORY (also: the world holds the most colliders it can). On error
/// nothing changes.
DEFSIM_API defsim_status defsim_world_add_collider(defsim_world *world,
                                                   const defsim_collider_def *def,
                                                   defsim_collider_id *out);

/// Removes a collider; its id becomes stale. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL world),
/// DEFSIM_ERR_STALE_ID, DEFSIM_ERR_LOCKED (from inside a host callback).
DEFSIM_API defsim_status defsim_world_remove_collider(defsim_world *world,
                                                      defsim_collider_id collider);

/// Sets the pose the collider reaches at the end of the next step (position in m, rotation a
/// quaternion w x y z, normalised as for defsim_collider_def). During that step it moves from
/// its current pose at constant velocity (position linearly, rotation along the shortest arc),
/// so friction carries bodies along. Calling it again before the step replaces the target.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, non-finite, a position beyond +-1e100 m, a
/// quaternion not within 1e-6 of unit length), DEFSIM_ERR_STALE_ID, DEFSIM_ERR_LOCKED. On error
/// nothing changes.
DEFSIM_API defsim_status defsim_collider_set_pose(defsim_world *world,
                                                  defsim_collider_id collider,
                                                  const double position[3],
                                                  const double rotation[4]);

/// Number of live colliders of the world (0 for NULL).
DEFSIM_API int32_t defsim_world_collider_count(const defsim_world *world);

/// The i-th live collider (0 <= i < count, in order of creation): its id (may be NULL) and its
/// def with the current pose (may be NULL). A mesh def's vertices and triangles point into the
/// world's copies, valid until the collider is removed. Errors: DEFSIM_ERR_INVALID_ARGUMENT
/// (NULL world, i out of range, def->size too small).
DEFSIM_API defsim_status defsim_world_get_collider(const defsim_world *world, int32_t i,
                                                   defsim_collider_id *id,
                                                   defsim_collider_def *def);

/// The total contact force (normal + friction, N) that the colliders applied to each vertex
/// during the last step, 3 * n doubles, n = the world's vertex count (zero before any step and
/// for vertices not in contact). Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, n mismatch).
DEFSIM_API defsim_status defsim_world_get_contact_forces(const defsim_world *world, double *out,
                                                         int32_t n);

/* ------------------------------------------------------------------------------------------ */
/* Body contact (issue 13; docs/body-contact.md)                                              */
/*                                                                                            */
/* With the core option body_contact on, bodies collide with each other and with themselves:  */
/* their surfaces (cloth triangles, tet bodies' boundary triangles, rope edges) repel through */
/* a log barrier inside contact_dhat, with continuous collision detection in the line search  */
/* and lagged Coulomb friction, on the backends with DEFSIM_BACKEND_CONTACT_CCD               */
/* (newton_cholmod, newmark, bdf2). Every other backend refuses such a step                   */
/* (DEFSIM_ERR_UNSUPPORTED, state unchanged). The forces join                                 */
/* defsim_world_get_contact_forces; statistics "contact.body_*" and                           */
/* "contact.pattern_growths" (defsim_world_stat).                                             */

/// Changes the collision filter of a live body (the fields of defsim_body_def of the same
/// names): self_contact 0 or 1, collision_group, collision_mask. Takes effect at the next step
/// without a re-plan. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL or not a live world,
/// self_contact not 0 or 1), DEFSIM_ERR_STALE_ID, DEFSIM_ERR_LOCKED (from inside a host
/// callback). On an error nothing changes.
DEFSIM_API defsim_status defsim_body_set_collision(defsim_world *world, defsim_body_id body,
                                                   int32_t self_contact, uint32_t group,
                                                   uint32_t mask);

/* ------------------------------------------------------------------------------------------ */
/* Spring kinds (issue 16): cloth and rope meshes tell each spring's kind                     */
/* (defsim_mesh.spring_kinds); a body def takes a stiffness per kind                          */
/* (defsim_body_def.spring_kinds, shear_stiffness, bend_stiffness).                           */

/// What a spring of a cloth or rope mesh resists (defsim_mesh.spring_kinds), so that each kind
/// can be given its own stiffness (defsim_body_def.spring_kinds).
typedef enum defsim_spring_kind {
    DEFSIM_SPRING_STRETCH = 0,  ///< Structural: neighbours along the grid or the rope.
    DEFSIM_SPRING_SHEAR = 1,    ///< Cell diagonals of a cloth.
    DEFSIM_SPRING_BEND = 2      ///< Between every second vertex: resists folding.
} defsim_spring_kind;

/* ------------------------------------------------------------------------------------------ */
/* Input limits; replacing the log sink (issue 17)                                            */
/*                                                                                            */
/* What a mesh file may make defsim_mesh_load read and allocate, so that a hostile or runaway */
/* file ends with a clear error instead of exhausting memory. docs/limits.md lists them.      */

/// The limits of defsim_mesh_load. Process-wide: one value each for every thread and world.
typedef enum defsim_limit {
    DEFSIM_LIMIT_FILE_BYTES = 0,   ///< Bytes in one mesh file. Default 2^30 (1 GiB).
    DEFSIM_LIMIT_VERTICES = 1,     ///< Vertices one mesh file may define. Default 10,000,000.
    DEFSIM_LIMIT_ELEMENTS = 2      ///< Tets + triangles + line segments of one mesh file.
                                   ///< Default 50,000,000.
} defsim_limit;

/// Sets a limit: value >= 1 and at most 2^62 bytes, 715,827,882 (INT32_MAX / 3) vertices or
/// 357,913,941 (INT32_MAX / 6) elements, the most that 32-bit indices can address. A load over
/// a limit fails with DEFSIM_ERR_IO (file size) or DEFSIM_ERR_INVALID_MESH (counts) and a
/// message that names the limit. Thread-safe; loads that have started keep the value they read.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (unknown limit, value out of range; nothing changes).
DEFSIM_API defsim_status defsim_set_limit(defsim_limit limit, int64_t value);

/// The current value of a limit, or -1 for an unknown one. Thread-safe.
DEFSIM_API int64_t defsim_get_limit(defsim_limit limit);

/// Replaces the world's log sink (given first in defsim_world_def.log and log_user); fn NULL:
/// silent. A host that owns the memory behind `user` detaches it this way before freeing it
/// (the C++ wrapper does so in World::release).
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL or destroyed world), DEFSIM_ERR_LOCKED (from inside
/// a host callback).
DEFSIM_API defsim_status defsim_world_set_log(defsim_world *world, defsim_log_fn fn, void *user);
/* Checkpoints (docs/checkpoints.md)                                                          */
/*                                                                                            */
/* A checkpoint holds everything a run needs to continue: the world def and options, bodies,  */
/* pins and driven-pin targets, attachments, held external forces, the state x, v, t, the     */
/* statistics and the backend's history. A world loaded from it and stepped gives the same    */
/* bits as the world that was saved, stepped the same way (with the same thread count). Not   */
/* saved: the log callback (given to the load call), the force callback and SDF colliders'    */
/* functions, which the host installs again (defsim_world_set_force_callback,                 */
/* defsim_collider_set_sdf).                                                                  */

/// Writes a checkpoint of the world to `path`, atomically: into a temporary file in the same
/// directory, flushed to disk (fsync), then renamed over `path`; on failure `path` is as it was.
/// The world is not changed. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, empty path),
/// DEFSIM_ERR_LOCKED (called from inside a host callback), DEFSIM_ERR_IO (the file could not be written: the
/// message names the call and errno text), DEFSIM_ERR_OUT_OF_MEMORY.
DEFSIM_API defsim_status defsim_world_save(const defsim_world *world, const char *path);

/// Writes a checkpoint into a buffer that the library allocates: on success *data receives it
/// (the caller owns it and releases it with defsim_buffer_free) and *size its length in bytes;
/// on failure *data is NULL and *size 0. The same contents as defsim_world_save writes.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL), DEFSIM_ERR_LOCKED (called from inside a host
/// callback), DEFSIM_ERR_OUT_OF_MEMORY.
DEFSIM_API defsim_status defsim_world_save_buffer(const defsim_world *world, void **data,
                                                  size_t *size);

/// Releases a buffer from defsim_world_save_buffer. NULL is ignored.
DEFSIM_API void defsim_buffer_free(void *data);

/// Creates a new world from a checkpoint file (any format version up to the library's). On
/// success *out receives a world the caller owns (release with defsim_world_destroy); its log
/// sink is `log` with `log_user` (both may be NULL). Body and attachment ids are those of the
/// new world: the i-th live body of the saved world, in vertex order, is
/// defsim_world_body_at(*out, i), and likewise for attachments. The file is checked whole (a
/// CRC-32 per chunk, an end marker) before anything is built.
/// On failure *out is NULL and defsim_last_error() says why. Errors: DEFSIM_ERR_INVALID_ARGUMENT
/// (NULL), DEFSIM_ERR_IO (unreadable, not a checkpoint, truncated, corrupted, or of a newer
/// format version), DEFSIM_ERR_BACKEND_UNAVAILABLE (its backend is not registered), and those of
/// defsim_world_create and defsim_world_add_body for contents that do not validate
/// (DEFSIM_ERR_INVALID_MESH, DEFSIM_ERR_INVALID_MATERIAL, DEFSIM_ERR_OUT_OF_MEMORY).
DEFSIM_API defsim_status defsim_world_load(const char *path, defsim_log_fn log, void *log_user,
                                           defsim_world **out);

/// defsim_world_load from `size` bytes at `data` (copied; the caller keeps them).
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL), DEFSIM_ERR_IO (not a checkpoint, truncated,
/// corrupted, or of a newer format version), and the others of defsim_world_load.
DEFSIM_API defsim_status defsim_world_load_buffer(const void *data, size_t size, defsim_log_fn log,
                                                  void *log_user, defsim_world **out);

/// Installs the distance function of an SDF collider again (checkpoints cannot hold host
/// functions: in a loaded world every SDF collider has a stand-in that fails the first step
/// that queries it with DEFSIM_ERR_CALLBACK until this is called). `user` as in
/// defsim_collider_def.sdf_user. Colliders of a loaded world: defsim_world_get_collider.
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL world or sdf, a collider of another shape),
/// DEFSIM_ERR_STALE_ID, DEFSIM_ERR_LOCKED.
DEFSIM_API defsim_status defsim_collider_set_sdf(defsim_world *world, defsim_collider_id collider,
                                                 defsim_sdf_fn sdf, void *user);

/// Number of live bodies of the world (0 for NULL).
DEFSIM_API int32_t defsim_world_body_count(const defsim_world *world);

/// Id of the i-th live body in vertex order (0 <= i < defsim_world_body_count).
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, i out of range).
DEFSIM_API defsim_status defsim_world_body_at(const defsim_world *world, int32_t i,
                                              defsim_body_id *out);

/// Number of live attachments of the world (0 for NULL).
DEFSIM_API int32_t defsim_world_attachment_count(const defsim_world *world);

/// Id of the i-th live attachment in the order they were added (0 <= i < the count).
/// Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, i out of range).
DEFSIM_API defsim_status defsim_world_attachment_at(const defsim_world *world, int32_t i,
                                                    defsim_attachment_id *out);

/* ------------------------------------------------------------------------------------------ */
/* What a writer of frames reads back (issue 28): the pins and the attachments as the world   */
/* holds them.                                                                                */

/// The pinned flags, n bytes, n = the world's vertex count: 1 for a pinned (or driven) vertex,
/// 0 for a free one. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, n mismatch).
DEFSIM_API defsim_status defsim_world_get_pinned(const defsim_world *world, uint8_t *out,
                                                 int32_t n);

/// The def of a live attachment as the world holds it now (with defaults filled in, and the
/// target that defsim_attachment_set_target last gave). out->size must be
/// sizeof(defsim_attachment_def). Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, size),
/// DEFSIM_ERR_STALE_ID.
DEFSIM_API defsim_status defsim_world_get_attachment(const defsim_world *world,
                                                     defsim_attachment_id attachment,
                                                     defsim_attachment_def *out);

/* ------------------------------------------------------------------------------------------ */
/* Gradients through a run (issue 25, docs/gradients.md): a recording (tape) of the steps a    */
/* host takes, and one backward pass that turns the gradient of a loss with respect to the     */
/* recorded states into gradients with respect to the initial state and the materials.         */

/// A recording of a world's steps. Opaque; made by defsim_world_record, freed by
/// defsim_tape_destroy.
typedef struct defsim_tape defsim_tape;

/// How a recording keeps its states (defsim_tape_def_init fills the defaults).
typedef struct defsim_tape_def {
    uint32_t size;                 ///< sizeof(defsim_tape_def).
    /// Store the state of every interval-th step and recompute the ones between in the
    /// backward pass (k >= 1; 1: store every state, nothing is recomputed). 0 (the default):
    /// automatic, every state while the stored states fit in max_bytes, then every 2nd, 4th,
    /// ... (the stored states thinned, so that memory stays within max_bytes).
    int32_t interval;
    /// The automatic interval's memory budget for stored states (bytes, > 0; default 256 MiB).
    int64_t max_bytes;
} defsim_tape_def;

/// What a recording holds and what its last backward pass cost.
typedef struct defsim_tape_stats {
    uint32_t size;                 ///< sizeof(defsim_tape_stats).
    int64_t steps;                 ///< Recorded steps N (states 0 .. N).
    int64_t stored_states;         ///< States the tape stores (checkpoints, with the last).
    int32_t interval;              ///< The interval k in effect.
    int64_t bytes;                 ///< Memory the tape holds now (bytes).
    int64_t backward_bytes;        ///< Peak memory of the last backward pass beyond that.
    int64_t recomputed_steps;      ///< Steps the last backward pass ran again.
    double time_forward;           ///< Wall time of the recorded steps (s).
    double time_backward;          ///< Wall time of the last backward pass (s), recomputation
                                   ///< included.
    double time_recompute;         ///< Of which recomputation (s).
} defsim_tape_stats;

/// One gradient that defsim_tape_backward fills: `name` (static or the host's, read during the
/// call) is one of "initial_positions", "initial_velocities" (count = 3 * vertex count, in the
/// world's vertex order), "youngs_modulus", "poisson_ratio", "density", "mass_damping",
/// "stiffness_damping" (count = body count, bodies in vertex order: dL/d of that body's
/// material field), "external_forces" (count = N * 3 * vertex count: for each recorded step
/// j = 0 .. N - 1, dL/df_j of the held external forces of that step, defsim_world_set_external_forces,
/// also where they were zero: the controls), "attachment_stiffness", "attachment_damping"
/// (count = attachment count, in defsim_world_attachment_at's order), "attachment_targets"
/// (count = N * 3 * attachment count: per step j, dL/dp_j of each world-point target that
/// defsim_attachment_set_target held during step j; 0 for body targets), "pin_targets"
/// (count = N * 3 * vertex count: per step j, dL/dp_j of the targets that
/// defsim_body_set_pin_targets gave the driven pins for step j, at those vertices; 0 at every
/// other vertex and step), "collider_friction" (count = collider count, in
/// defsim_world_get_collider's order: dL/dmu of each collider's friction coefficient, also
/// where it is 0), "body_friction" (count = body count: dL/dmu of each body's body-contact
/// friction), "collider_poses" (count = (N + 1) * collider count * 6: for each recorded state
/// s = 0 .. N and each collider in defsim_world_get_collider's order, dL/d of its pose at state
/// s, which defsim_collider_set_pose gave for step s - 1 (s = 0: its pose when the recording
/// began), as 3 translation components dp (m) then 3 of a small rotation dtheta (rad, world
/// frame, about the collider's origin): the pose moved to (p + dp, (I + [dtheta]) R));
/// out (count doubles, the host's) receives it.
typedef struct defsim_gradient {
    const char *name;              ///< The parameter (above).
    double *out;                   ///< Receives count doubles.
    int64_t count;                 ///< 3 * vertex count, or the body count.
} defsim_gradient;

/// Fills def with the defaults; size must be sizeof(defsim_tape_def).
DEFSIM_API void defsim_tape_def_init(defsim_tape_def *def, size_t size);

/// Begins recording the world's steps from its current state (state 0): every later
/// successful defsim_world_step is recorded, until defsim_tape_destroy. One recording per
/// world at a time. def may be NULL (the defaults). Plans the world if it is not planned
/// (nothing else changes); the backend's history (velocity_verlet's carried force, bdf2's
/// previous state) is dropped, so that the recorded run starts from state 0 alone.
/// Differentiable backends: explicit_euler, symplectic_euler, velocity_verlet,
/// newton_cholmod, newmark, bdf2. *out receives the tape, which the host owns and frees with
/// defsim_tape_destroy (before or after the world: a world destroyed first leaves the tape
/// usable only for defsim_tape_get_stats and destroy). On an error nothing is recorded, *out
/// is untouched and the world unchanged. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL, bad def, a
/// recording already
/// under way, a world without vertices), DEFSIM_ERR_UNSUPPORTED (the backend has no adjoint:
/// the message names it; or the scene uses a term that cannot be differentiated yet, named in
/// the message: collider contact on a backend whose contact is the penalty (explicit_euler,
/// symplectic_euler, velocity_verlet; newton_cholmod, newmark and bdf2 differentiate the
/// barrier and body contact), the force callback; or core.auto_substep on a backend that
/// substeps),
/// DEFSIM_ERR_OUT_OF_MEMORY, DEFSIM_ERR_LOCKED (inside a host callback).
DEFSIM_API defsim_status defsim_world_record(defsim_world *world, const defsim_tape_def *def,
                                             defsim_tape **out);

/// The backward pass: given the loss gradients dl_dx[s] = dL/dx_s and dl_dv[s] = dL/dv_s at
/// every recorded state s = 0 .. N (N = recorded steps; `count` doubles each, count =
/// (N + 1) * 3 * vertex count, state after state; either may be NULL: zero), fills the n
/// gradients `grads` (defsim_gradient). Steps stored states forward again where the tape
/// thinned them (recomputed bit for bit: a difference fails the call), then runs the
/// backend's adjoint step by step from the last. The world's state, time and statistics are
/// the same after the call as before it (restored), also on failure. The recording goes on
/// and may be run backward again. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL tape, a tape whose
/// world is gone, count not (N + 1) * 3 * vertex count, a non-finite loss gradient, an
/// unknown name or a wrong count in grads, or the world changed in a way the recording cannot
/// follow: bodies, pins, options, colliders added, removed or replaced (their poses may change:
/// set_pose is recorded), or the state or time set between recorded steps: the message says
/// which), DEFSIM_ERR_UNSUPPORTED (a recomputed step differs from the recording,
/// or since the last recorded step the scene came to use what cannot be differentiated: a
/// collider, the force callback, ...),
/// DEFSIM_ERR_OUT_OF_MEMORY, DEFSIM_ERR_LOCKED, or the backend's error. On an error the grads'
/// arrays hold nothing meaningful.
DEFSIM_API defsim_status defsim_tape_backward(defsim_tape *tape, const double *dl_dx,
                                              const double *dl_dv, int64_t count,
                                              const defsim_gradient *grads, int32_t n);

/// The tape's statistics into *out (out->size must be set). Errors:
/// DEFSIM_ERR_INVALID_ARGUMENT (NULL, size 0).
DEFSIM_API defsim_status defsim_tape_get_stats(const defsim_tape *tape, defsim_tape_stats *out);

/// The detail of the tape's last failed call (also in defsim_world_last_error while the world
/// lives): static until the next call on the tape. "" for NULL.
DEFSIM_API const char *defsim_tape_last_error(const defsim_tape *tape);

/// Ends the recording and frees the tape (NULL is ignored). The world keeps stepping as before.
DEFSIM_API void defsim_tape_destroy(defsim_tape *tape);

/* ------------------------------------------------------------------------------------------ */
/* Measured fabrics (issue 26, docs/shells.md "Fabrics by name"): a small table of fabrics     */
/* whose measured areal density, tensile and bending data fill a shell body's fields by name.  */

/// One fabric of the library's table (docs/shells.md lists it with the sources of its numbers):
/// the values that defsim_body_def_set_fabric puts into a body def's shell fields, in SI units.
typedef struct defsim_fabric {
    uint32_t size;                 ///< sizeof(defsim_fabric), set by the caller before the call.
    const char *name;              ///< Its name ("denim", ...): static, owned by the library.
    const char *description;       ///< What it is and the measurement it comes from (static).
    double areal_density;          ///< kg/m^2 (shell_areal_density).
    double warp_modulus;           ///< Small-strain tensile modulus along the warp, N/m.
    double weft_modulus;           ///< Small-strain tensile modulus along the weft, N/m.
    double shear_modulus;          ///< In-plane shear modulus, N/m.
    double warp_poisson;           ///< nu_12 (shell_warp_poisson).
    double bending_rigidity;       ///< Bending rigidity along the warp, N m.
    double bending_rigidity_weft;  ///< Bending rigidity along the weft, N m.
} defsim_fabric;

/// The number of fabrics in the table (> 0). Thread-safe.
DEFSIM_API int32_t defsim_fabric_count(void);

/// The fabric at index (0 .. defsim_fabric_count() - 1) into *out (out->size must be set).
/// Thread-safe. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL out, out->size too small, index out of
/// range); defsim_last_error() says which.
DEFSIM_API defsim_status defsim_fabric_get(int32_t index, defsim_fabric *out);

/// The fabric of that name into *out (out->size must be set). Thread-safe. Errors:
/// DEFSIM_ERR_INVALID_ARGUMENT (NULL out, out->size too small), DEFSIM_ERR_INVALID_MATERIAL (no
/// fabric of that name, or NULL name: defsim_last_error() names the table's fabrics).
DEFSIM_API defsim_status defsim_fabric_find(const char *name, defsim_fabric *out);

/// Makes def a shell of the named fabric: shell_membrane DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK
/// and shell_areal_density, shell_warp_modulus, shell_weft_modulus, shell_shear_modulus,
/// shell_warp_poisson, shell_bending_rigidity and shell_bending_rigidity_weft from the table;
/// the other fields (shell_warp_direction, the triangles, ...) are left as they are. On an error
/// def is unchanged. Thread-safe. Errors: DEFSIM_ERR_INVALID_ARGUMENT (NULL def, def->size not
/// that of defsim_body_def_init), DEFSIM_ERR_INVALID_MATERIAL (no fabric of that name, or NULL
/// name: defsim_last_error() names the table's fabrics).
DEFSIM_API defsim_status defsim_body_def_set_fabric(defsim_body_def *def, const char *name);

#ifdef __cplusplus
}
#endif

#endif /* DEFSIM_DEFSIM_H */

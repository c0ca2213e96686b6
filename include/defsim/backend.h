/* SPDX-License-Identifier: MIT */
/** @file
 * defsim backend ABI: the only header a backend (integrator / solver) includes.
 *
 * A backend owns time: it advances positions and velocities by h using only the services in
 * defsim_host, which evaluate the world's physics (the "system"). A backend never sees meshes or
 * materials. Built-in backends, host-registered backends and loadable modules use the same table.
 *
 * A module is a shared object named defsim_<name>.so that exports one symbol,
 * DEFSIM_MODULE_ENTRY ("defsim_module_init"), of type defsim_module_init_fn. It must not link
 * libdefsim: everything it needs from the core comes through the defsim_host table.
 *
 * Both tables are versioned: fields are only ever appended, never reordered. A backend checks
 * host->abi_version and host->size before using a field appended after version 1.
 */
#ifndef DEFSIM_BACKEND_H
#define DEFSIM_BACKEND_H

#include "defsim/defsim.h"

#ifdef __cplusplus
extern "C" {
#endif

/// ABI version of the tables below. Bumped when fields are appended.
/// Version 2 appended options and counters (defsim_backend.options ... counter_count,
/// defsim_host.option_values and counters, and defsim_host.omega_max); version 3 the host's
/// coupling services (defsim_host.forces_at, pin_positions, pin_velocities,
/// applied_forces_vary); version 4 defsim_backend.stable_step_options; version 5
/// defsim_backend.save_state and load_state (checkpoints, with defsim_state_writer and
/// defsim_state_reader), the contact services (defsim_host.contact_max_step, contact_start) and
/// DEFSIM_BACKEND_CONTACT_CCD; version 6 defsim_host.matrix_pattern_version (body contact grows
/// the pattern); version 7 defsim_host.option_is_set. Version 8 is a break, not an append (no
/// release shipped 1 to 7): defsim_host.gravity took the place of `options` (which handed out
/// the public world def, whose nine backend settings became options by name), defsim_stats
/// lost the backend counters (newton_iterations ... nonlinear_residual: a backend counts in its
/// own `counters`, read by name), and defsim_host.contact_active_dhat came (a Newton stop on
/// contact's scale). The core accepts tables built against 8 (a later table's struct_size says
/// which fields it has); a backend checks host->abi_version and host->size before using a field
/// appended after 8.
#define DEFSIM_BACKEND_ABI_VERSION 8u

/// Name of the one symbol a module exports.
#define DEFSIM_MODULE_ENTRY "defsim_module_init"

/// The world's physics as a backend sees it. Opaque; valid from init to fini.
typedef struct defsim_system defsim_system;

/// Which parts of the force to evaluate (bits for defsim_host.forces).
enum {
    DEFSIM_FORCE_ELASTIC = 1u << 0,  ///< -dE/dx of springs, tets and attachment springs.
    DEFSIM_FORCE_GRAVITY = 1u << 1,  ///< The applied forces: M g, the host's held external forces
                                     ///< and its force callback.
    DEFSIM_FORCE_DAMPING = 1u << 2,  ///< -(alpha M + B(x)) v (Rayleigh; B = sum beta_e K_e with
                                     ///< each K_e clamped to positive semi-definite, plus the
                                     ///< attachment dampers).
    DEFSIM_FORCE_ALL = 7u
};

/// Which triangle of the symmetric stiffness pattern to store.
typedef enum defsim_triangle {
    DEFSIM_TRIANGLE_FULL = 0,   ///< Both triangles (KLU, general solvers).
    DEFSIM_TRIANGLE_UPPER = 1   ///< Upper triangle and diagonal only (CHOLMOD stype = 1).
} defsim_triangle;

/// Compressed sparse column pattern over the free DOFs (pinned DOFs removed), 64-bit indices.
/// Row indices are sorted within each column. Borrowed from the system: valid until fini.
typedef struct defsim_csc {
    int64_t n;                 ///< Rows = columns = number of free DOFs.
    int64_t nnz;               ///< Stored entries.
    const int64_t *col_ptr;    ///< n + 1 entries.
    const int64_t *row_idx;    ///< nnz entries.
} defsim_csc;

/// Coefficients of a linear combination of the world's matrices:
///   A = k K(x) + kd B(x) + m M + md C
/// where K is the elastic stiffness d2E/dx2 (element Hessians projected as the world's
/// defsim_projection says; plus the attachment springs' exact, constant Hessians, and in an
/// implicit backend's step the force callback's stiffness -dF/dx when the host gave a Jacobian,
/// evaluated at x with the velocities and time of the latest force evaluation),
/// B = sum_e beta_e K_e the stiffness-damping matrix plus the attachment dampers, M the lumped
/// (diagonal) mass matrix and C = diag(alpha_i m_i) the mass-damping matrix.
typedef struct defsim_matrix_coeffs {
    double k;    ///< Factor of the stiffness K(x).
    double kd;   ///< Factor of the stiffness-damping matrix B(x).
    double m;    ///< Factor of the lumped mass matrix M.
    double md;   ///< Factor of the mass-damping matrix C.
} defsim_matrix_coeffs;

/// An option of a backend, set by hosts by name ("<backend>.<name>") with
/// defsim_world_set_option. The type (defsim_option_type) is declared in defsim.h, which hosts
/// read too. Every value is held as a double: INT values are whole numbers, BOOL values 0 or 1,
/// CHOICE values the index of the chosen name in `choices`.
/// One name is shared with the core: a CHOICE option "projection" with choices "none|clamp|abs"
/// (the defsim_projection values) is the projection that matrix_values and matrix_product apply
/// in that backend's worlds; a backend without it gets DEFSIM_PROJECTION_CLAMP.
typedef struct defsim_option_spec {
    const char *name;           ///< [a-z0-9_]{1,63}, unique within the backend: "rtol". Static.
    defsim_option_type type;    ///< REAL, INT, BOOL or CHOICE (defsim.h).
    double default_value;       ///< Within the range (REAL, INT); an index of `choices` (CHOICE).
    double min_value;           ///< Inclusive lower bound (REAL and INT; ignored otherwise).
    double max_value;           ///< Inclusive upper bound (REAL and INT; ignored otherwise).
    const char *choices;        ///< CHOICE only: names separated by '|' ("none|clamp|abs").
    const char *doc;            ///< One line, with units. Static.
} defsim_option_spec;

/// A counter of a backend, read by hosts by name ("<backend>.<name>") with defsim_world_stat.
typedef struct defsim_counter_spec {
    const char *name;           ///< [a-z0-9_]{1,63}, unique within the backend: "internal_steps".
    const char *doc;            ///< One line, with units. Static.
} defsim_counter_spec;

/// Host services handed to every backend op. Owned by the core; valid for the process.
typedef struct defsim_host {
    uint32_t abi_version;      ///< DEFSIM_BACKEND_ABI_VERSION of the core.
    uint32_t size;             ///< sizeof(defsim_host) of the core.

    /// Number of DOFs (3 * vertex count) and of free DOFs (not pinned).
    int64_t (*dof_count)(const defsim_system *sys);
    int64_t (*free_dof_count)(const defsim_system *sys);   ///< Free DOFs (not pinned).
    /// free index -> DOF (free_dof_count entries), and DOF -> free index or -1 (dof_count).
    const int64_t *(*free_dofs)(const defsim_system *sys);
    const int64_t *(*dof_to_free)(const defsim_system *sys);   ///< DOF -> free index or -1.

    /// The world's state, writable: the backend leaves the new positions and velocities here.
    /// The core keeps a copy and restores it if the step fails. Pinned DOFs are the core's: it
    /// sets them after the step (see pin_positions).
    double *(*positions)(defsim_system *sys);
    double *(*velocities)(defsim_system *sys);   ///< The velocities, writable (as positions).
    /// Simulated time at the start of this step (s); of the substep when the world splits its
    /// steps (auto_substep).
    double (*time)(const defsim_system *sys);
    /// Lumped mass per DOF (3 * vertex count, kg) and mass-damping alpha per DOF (1/s).
    const double *(*mass)(const defsim_system *sys);
    const double *(*mass_damping)(const defsim_system *sys);   ///< Alpha per DOF, 1/s.
    /// True if any element has stiffness damping (beta > 0).
    int (*has_stiffness_damping)(const defsim_system *sys);

    /// Forces (N) at positions x and velocities v (v may be NULL without DEFSIM_FORCE_DAMPING),
    /// the parts selected by `which` (DEFSIM_FORCE_* bits), into f (dof_count doubles). Pinned
    /// DOFs receive 0. Deterministic for a fixed thread count. Returns DEFSIM_OK, or
    /// DEFSIM_ERR_UNSTABLE if a non-finite value was produced, or DEFSIM_ERR_CALLBACK if the
    /// host's force callback failed (the core fails the step whatever the backend returns).
    /// The callback sees the time of the step's start in backends without
    /// DEFSIM_BACKEND_IMPLICIT and of its end in implicit ones; forces_at passes a time. In an
    /// implicit backend's step, a callback without a Jacobian is not called here: its value at
    /// the start of the step is added.
    defsim_status (*forces)(defsim_system *sys, const double *x, const double *v,
                            uint32_t which, double *f);
    /// Potential energy (J) at x: elastic (relative to rest, with attachment springs) plus
    /// gravitational, minus f_ext . (x - x_n) for the held external forces (x_n: the positions
    /// at the start of the step, so only differences within a step mean anything), and in an
    /// implicit backend's step the force callback's model from the step's start (-f0 . d, plus
    /// d^T K0 d / 2 with a Jacobian; d = x - x_n). Returns +inf where the energy is undefined
    /// (an inverted neo-Hookean element), so line searches back off.
    double (*potential_energy)(defsim_system *sys, const double *x);

    /// Builds (once; later calls return the cached pattern) the sparsity pattern of the matrices
    /// over the free DOFs. Returns DEFSIM_ERR_OUT_OF_MEMORY on failure.
    defsim_status (*matrix_pattern)(defsim_system *sys, defsim_triangle triangle,
                                    defsim_csc *out);
    /// Assembles A (see defsim_matrix_coeffs) at positions x into values (pattern's nnz doubles,
    /// in the order of the pattern built with the same triangle).
    defsim_status (*matrix_values)(defsim_system *sys, const double *x,
                                   const defsim_matrix_coeffs *c, defsim_triangle triangle,
                                   double *values);
    /// out = A(x) dx over all DOFs (dof_count doubles; pinned rows and columns are zero).
    /// Unprojected element Hessians are used only if the world's projection is NONE.
    defsim_status (*matrix_product)(defsim_system *sys, const double *x,
                                    const defsim_matrix_coeffs *c, const double *dx, double *out);

    /// The world's gravity (m/s^2) into g. (Before ABI 8 this slot handed out the world's
    /// defsim_world_def; a backend's settings are its options: see option_values.)
    void (*gravity)(const defsim_system *sys, double g[3]);
    /// Threads for assembly (>= 1).
    int32_t (*num_threads)(const defsim_system *sys);
    /// Diagonal of the bounding box of the rest positions (m): a length scale for tolerances.
    double (*length_scale)(const defsim_system *sys);

    /// The core's statistics: a backend with its own stable-step estimate writes stable_step;
    /// everything it counts (iterations, solves, timings) goes in its `counters`. Never NULL.
    defsim_stats *(*stats)(defsim_system *sys);
    /// Monotonic wall clock in seconds.
    double (*wall_time)(void);
    /// Sends a message to the world's log (level as defsim_log_fn).
    void (*log)(defsim_system *sys, int level, const char *message);
    /// Sets the detail that defsim_world_last_error returns after a failed step.
    void (*set_error)(defsim_system *sys, const char *message);
    /// Allocation that the core's allocator owns (NULL on failure); free with `release`.
    void *(*alloc)(size_t bytes);
    void (*release)(void *ptr);   ///< Frees what `alloc` returned (NULL is ignored).

    /* ABI version 2 */

    /// Current values of the backend's options, in the order of its `options` table (the
    /// defaults unless the host set them). Valid from init to fini: changing an option
    /// re-initialises the backend (fini, then init) before the next step, so a backend reads its
    /// options in init. NULL if the backend declares no options.
    const double *(*option_values)(const defsim_system *sys);
    /// The backend's counters, in the order of its `counters` table: zeroed at world creation
    /// and by defsim_world_reset_stats, kept across re-initialisation; the backend adds to them
    /// and hosts read them with defsim_world_stat. NULL if the backend declares no counters.
    double *(*counters)(defsim_system *sys);
    /// Stability of explicit methods at positions x: *omega receives omega_max (rad/s), the
    /// square root of the largest eigenvalue of M^-1 K(x) over the free DOFs (exact element
    /// Hessians, power iteration to 1e-4 relative), and *damping the Rayleigh damping rate at that
    /// frequency, c = alpha + beta omega_max^2 (1/s, the largest alpha and beta of the world): the
    /// numbers defsim_world_stable_step hands to the backend's stable_step. Costs up to a few
    /// hundred Hessian products. Returns DEFSIM_OK, DEFSIM_ERR_OUT_OF_MEMORY, or
    /// DEFSIM_ERR_UNSTABLE if the estimate is not finite.
    defsim_status (*omega_max)(defsim_system *sys, const double *x, double *omega,
                               double *damping);

    /* ABI version 3: the host's coupling terms. */

    /// forces with the time t (s) at which the host's force callback is evaluated (stages of
    /// multi-stage and adaptive methods). v NULL gives the callback the state's velocities.
    defsim_status (*forces_at)(defsim_system *sys, const double *x, const double *v, double t,
                               uint32_t which, double *f);
    /// Driven pins. A step of size h from time t0 moves some pinned DOFs on straight lines with
    /// constant velocity to prescribed end positions (implicit backends: Dirichlet conditions
    /// with prescribed values). pin_positions writes into x, for every pinned DOF that moves in
    /// this step, its position at time t in [t0, t0 + h] (exactly the end position for
    /// t >= t0 + h), and leaves the other DOFs alone. pin_velocities gives their velocity over
    /// the step (dof_count doubles, 0 for every other DOF), or NULL when no pinned DOF moves in
    /// this step. At the start of the step the state already holds each pinned DOF's start
    /// position and this velocity; after the step the core writes the end positions and the
    /// velocities into the pinned DOFs, so a backend whose forces never see positions within
    /// the step (explicit and symplectic Euler) needs neither service.
    void (*pin_positions)(const defsim_system *sys, double t, double *x);
    const double *(*pin_velocities)(const defsim_system *sys);   ///< See pin_positions.
    /// True when, in this step, the applied forces (DEFSIM_FORCE_GRAVITY) depend on x: a force
    /// callback with a Jacobian in an implicit backend. A backend that evaluates the applied
    /// forces once per step (at x_n) must then evaluate them at every iterate instead, to match
    /// the callback's stiffness that matrix_values adds to K.
    int (*applied_forces_vary)(const defsim_system *sys);

    /* ABI version 5: contact with the world's colliders (docs/contact.md). */

    /// Continuous collision detection for line searches: the largest alpha in (0, 1] such that
    /// along x + t dx, 0 <= t <= alpha (x and dx over all DOFs), no vertex comes closer to any
    /// collider (at its end-of-step pose) than 0.2 times its distance at x, and no body surface
    /// triangle or edge sweeps across a collider's witness (docs/contact.md, "No tunnelling"),
    /// nor body surfaces across each other with body contact on. 1 when the world has
    /// no colliders or in a step of a backend without DEFSIM_BACKEND_CONTACT_CCD; 0 when x is not
    /// feasible or a collider's SDF callback failed (the core then fails the step).
    double (*contact_max_step)(defsim_system *sys, const double *x, const double *dx);
    /// Makes a Newton start x (all DOFs; pinned DOFs at their end-of-step values) feasible for
    /// the barrier and reachable from the step's start without crossing a collider or a body
    /// surface: a vertex that a moving collider would pass is carried rigidly with it, and the
    /// free DOFs go back to that start (all of them, so that bodies keep their shape) unless
    /// continuous collision detection finds the whole way to x clear. A start that cannot be
    /// made so makes the energy +inf for the rest of the step. No-op without colliders and body
    /// contact, or without DEFSIM_BACKEND_CONTACT_CCD.
    void (*contact_start)(defsim_system *sys, double *x);

    /* ABI version 6: body contact (docs/body-contact.md). */

    /// The matrix pattern's version: a number that changes whenever the pattern does. Body
    /// contact couples vertices of different bodies (or far apart in one) when they come near,
    /// and its off-diagonal blocks need entries the pattern lacks: they are collected during the
    /// step (contact_max_step, matrix_values) and merged into the pattern by this call. A
    /// backend that keeps the pattern's pointers or values in its layout calls it at the start
    /// of each step and before each assembly; when the number differs from the one it saw,
    /// every pointer from matrix_pattern (and values in its layout) is stale: fetch the pattern
    /// again and redo any symbolic analysis. Merged pairs stay while contacts use them: at the
    /// end of a successful step, when over a quarter of them belong to no contact of the end
    /// state, those go (between steps, never within one; the number changes then too). Without
    /// body contact the number never changes. Returns 0 if merging ran out of memory (then
    /// matrix_pattern and matrix_values fail with DEFSIM_ERR_OUT_OF_MEMORY until it succeeds).
    uint64_t (*matrix_pattern_version)(defsim_system *sys);

    /* ABI version 7 */

    /// 1 if the host set the backend's option `index` (its place in the backend's `options`)
    /// in this world by name, at creation or by a checkpoint's load (which sets the options that
    /// differ from their value then), else 0 (the default holds); 0 for an index out of range. A backend
    /// whose environment variable gives an option's default (DEFSIM_CHOLMOD_ORDERING) reads
    /// the variable only when this is 0: an option the host set wins.
    int32_t (*option_is_set)(const defsim_system *sys, int32_t index);

    /* ABI version 8 */

    /// Barrier contact at the positions of the latest matrix_values call (a Newton iteration's
    /// Hessian): the activation distance dhat (m) of the world's contact when some
    /// contact constraint contributed a block there (a pair within dhat, or lagged friction of a
    /// pair that was within dhat at the step's start), else 0 (no contact active, no contact in
    /// the world, or a backend without DEFSIM_BACKEND_CONTACT_CCD). Reads what that call cached:
    /// changes nothing, evaluates nothing. For a Newton stop on contact's scale (docs/contact.md).
    double (*contact_active_dhat)(defsim_system *sys);

    /* Appended after ABI 8 (check host->size) */

    /// matrix_values with the element Hessians under `projection` (a defsim_projection) instead
    /// of the world's: a backend whose exact Hessian is indefinite at an iterate can assemble
    /// the projected one there (the "auto" projection of the implicit backends). Contact
    /// Hessians are projected either way. DEFSIM_ERR_INVALID_ARGUMENT for another value.
    defsim_status (*matrix_values_projected)(defsim_system *sys, const double *x,
                                             const defsim_matrix_coeffs *c,
                                             defsim_triangle triangle, int32_t projection,
                                             double *values);

    /* Appended after ABI 8 (check host->size): reverse mode (gradients, docs/gradients.md) */

    /// Vector-Jacobian products of the forces at (x, v), the parts `which` (DEFSIM_FORCE_*):
    /// gx += (df/dx)^T w and gv += (df/dv)^T w (dof_count doubles each; either may be NULL when
    /// not wanted; v may be NULL without DEFSIM_FORCE_DAMPING). w's entries at pinned DOFs are
    /// ignored (their forces are zero); gx and gv receive entries at every DOF, pinned ones
    /// included (a pinned vertex's position enters its neighbours' forces). With `accumulate`
    /// set, w^T df/dp is also added into the gradients of the recording under way (materials,
    /// masses, damping). Called only from a backend's adjoint_step: DEFSIM_ERR_INVALID_ARGUMENT
    /// outside one. Returns DEFSIM_OK, DEFSIM_ERR_UNSTABLE (a non-finite value).
    defsim_status (*forces_vjp)(defsim_system *sys, const double *x, const double *v,
                                uint32_t which, const double *w, double *gx, double *gv,
                                int32_t accumulate);
    /// Adds sum_i mw_i dm_i/dp (m_i: the lumped mass of DOF i, dof_count doubles) into the
    /// gradients of the recording under way: how a step's outcome depends on the masses
    /// beyond the forces (inertia). No-op outside a backend's adjoint_step.
    void (*mass_vjp)(defsim_system *sys, const double *mw);
} defsim_host;

/// One step's reverse mode (defsim_backend.adjoint_step): the step went from (x0, v0) to
/// (x1, v1) with step h; given the adjoints ax1 = dL/dx1 and av1 = dL/dv1 of some loss L, the
/// op writes ax0 = dL/dx0 and av0 = dL/dv0 through this step (all dof_count doubles, owned by
/// the core, valid during the call) and adds what the step's parameters contribute through
/// the host's forces_vjp and mass_vjp with `accumulate` set.
///
/// Pinned DOFs are inputs of the step three times over: their start positions x0, their end
/// positions x1 (x0 for a static pin, a driven pin's target) and their velocity over the step,
/// which v0 holds there (0 for a static pin; as the step saw it, whatever the state held
/// before). At a pinned DOF the op writes ax0 = dL/dx0 with x1 and the velocity held, av0 =
/// dL/d(the velocity) through the step's forces, and ap1 = dL/dx1 with x0 held (ax1 included);
/// the core composes them (static: dL/dx0 = ax0 + ap1).
typedef struct defsim_adjoint_step {
    const double *x0;                  ///< Positions at the step's start.
    const double *v0;                  ///< Velocities at the step's start.
    const double *x1;                  ///< Positions at the step's end.
    const double *v1;                  ///< Velocities at the step's end.
    const double *ax1;                 ///< dL/dx1.
    const double *av1;                 ///< dL/dv1.
    double *ax0;                       ///< Out: dL/dx0.
    double *av0;                       ///< Out: dL/dv0.
    /// For a backend with DEFSIM_BACKEND_ADJOINT_HISTORY (else NULL): the state at the start
    /// of the previous recorded step (the history of a scheme that carries one: bdf2's previous
    /// state, velocity_verlet's force), or NULL when this step started without history: the
    /// first recorded step (a recording starts the backend's history anew), or the first after
    /// a failed step.
    const double *x_prev;
    const double *v_prev;              ///< Velocities with x_prev (NULL with it).
    double h_prev;                     ///< The previous step's size (0 without x_prev).
    /// 1 on the first call of a backward pass (the last recorded step), else 0: a backend
    /// that carries adjoints from one call to the next (those of its history) starts them at
    /// zero. The calls of a pass go from the last recorded step to the first.
    int32_t first;
    /// 1 when the previous recorded step moved driven pins (velocity_verlet then evaluates
    /// the forces at the start of this step anew, not carried), else 0.
    int32_t prev_drove;
    /// 1 when this step moved driven pins (their velocities are the nonzero ones of v0 at
    /// pinned DOFs; pin_velocities as the forward step had it), else 0.
    int32_t drives;
    double *ap1;                       ///< Out: at pinned DOFs, dL/dx1 (see above); else 0.
} defsim_adjoint_step;

/// Capability flags of a backend.
enum {
    DEFSIM_BACKEND_NEEDS_MATRIX = 1u << 0,  ///< Uses matrix_pattern / matrix_values.
    DEFSIM_BACKEND_ADAPTIVE = 1u << 1,      ///< Takes internal steps under an error tolerance.
    DEFSIM_BACKEND_IMPLICIT = 1u << 2,      ///< Stable at any step size for dissipative scenes.
    DEFSIM_BACKEND_DISSIPATIVE = 1u << 3,   ///< Total energy never grows without external work.
    DEFSIM_BACKEND_CONSERVATIVE = 1u << 4,  ///< Without damping, the total energy stays in a
                                            ///< bounded band around its start: no drift, no
                                            ///< numerical dissipation (symplectic or
                                            ///< energy-conserving schemes; explicit ones inside
                                            ///< their stability limit).
    DEFSIM_BACKEND_CONTACT_CCD = 1u << 5,   ///< (ABI 5) Minimises the potential_energy with a line
                                            ///< search that starts each step's Newton iterate with
                                            ///< contact_start and never goes beyond
                                            ///< contact_max_step: contact is then a log barrier
                                            ///< (+inf on contact) with lagged friction in the
                                            ///< potential. Without the flag it is a penalty with
                                            ///< friction among the damping forces.
    /// Its adjoint_step reads defsim_adjoint_step.x_prev, v_prev and h_prev (a scheme that
    /// carries history from one step to the next: velocity_verlet, bdf2); recordings then keep
    /// the state before each checkpoint and the backend's saved history at each. Without the
    /// flag those fields are NULL and 0.
    DEFSIM_BACKEND_ADJOINT_HISTORY = 1u << 6,
};

/// Where a backend's save_state op writes its history (checkpoints, ABI version 5). The core
/// stores every value little-endian (doubles as IEEE 754 binary64), so a backend writes numbers,
/// never raw structs. Each call returns DEFSIM_OK or DEFSIM_ERR_OUT_OF_MEMORY (then the save
/// fails); `n` may be 0. Valid only during the op.
typedef struct defsim_state_writer {
    void *ctx;                ///< The core's; passed back to every function.
    /// Writes n doubles.
    defsim_status (*f64)(void *ctx, const double *values, int64_t n);
    /// Writes n 64-bit integers.
    defsim_status (*i64)(void *ctx, const int64_t *values, int64_t n);
} defsim_state_writer;

/// Where a backend's load_state op reads back what its save_state wrote, in the same order and
/// counts. Each call returns DEFSIM_OK, or DEFSIM_ERR_IO when fewer values remain than asked
/// for (a malformed checkpoint: the op then fails with DEFSIM_ERR_IO too). `remaining` gives the
/// number of 8-byte values left. Valid only during the op.
typedef struct defsim_state_reader {
    void *ctx;                ///< The core's; passed back to every function.
    /// Reads n doubles.
    defsim_status (*f64)(void *ctx, double *values, int64_t n);
    /// Reads n 64-bit integers.
    defsim_status (*i64)(void *ctx, int64_t *values, int64_t n);
    /// The number of 8-byte values left.
    int64_t (*remaining)(void *ctx);
} defsim_state_reader;

/// A backend: a const table. The host allocates `state_size` zeroed bytes per world and passes
/// them to every op, so snapshots and resets stay generic.
typedef struct defsim_backend {
    uint32_t abi_version;     ///< DEFSIM_BACKEND_ABI_VERSION the backend was built against.
    uint32_t struct_size;     ///< sizeof(defsim_backend) the backend was built against.
    const char *name;         ///< Unique name, [a-z0-9_]+; static storage.
    uint32_t flags;           ///< DEFSIM_BACKEND_* bits.
    size_t state_size;        ///< Bytes of per-world state (may be 0).
    /// Called at the first step after the world's bodies or pins changed (after fini of the
    /// previous set-up). Allocates what the backend needs; the state's bytes start zeroed.
    defsim_status (*init)(const defsim_host *host, defsim_system *sys, void *state);
    /// Advances the state by h > 0. On an error the core restores the state; the backend must
    /// still leave `state` usable for the next step.
    defsim_status (*step)(const defsim_host *host, defsim_system *sys, void *state, double h);
    /// Releases what init allocated. Must accept a state whose init failed part-way.
    void (*fini)(const defsim_host *host, defsim_system *sys, void *state);
    /// Optional (NULL: nothing to do): the host set the state between steps (history to drop).
    defsim_status (*reset)(const defsim_host *host, defsim_system *sys, void *state);
    /// Optional (NULL: no step-size limit, as for implicit backends): the largest stable step
    /// for a linear oscillator of angular frequency omega (rad/s) with damping rate c (1/s),
    /// i.e. x'' = -omega^2 x - c x'. Returns 0 if no step is stable.
    double (*stable_step)(double omega, double c);

    /* ABI version 2: a table built against version 1 (smaller struct_size) has none of these. */

    /// Options (may be NULL when option_count is 0). Static storage.
    const defsim_option_spec *options;
    int32_t option_count;                      ///< Entries of `options`.
    /// Counters (may be NULL when counter_count is 0). Static storage.
    const defsim_counter_spec *counters;
    int32_t counter_count;                     ///< Entries of `counters`.

    /* ABI version 4: tables built against 1 to 3 (smaller struct_size) have none of these. */

    /// Optional (NULL: the core uses stable_step): stable_step for a backend whose stability
    /// region depends on its options. option_values holds the world's current values of the
    /// backend's options, in the order of its `options` table (what defsim_host.option_values
    /// gives; NULL when option_count is 0); the op reads them only during the call. omega, c and
    /// the return value are as for stable_step. When present, the core calls it instead of
    /// stable_step for defsim_world_stable_step and auto_substep; keep stable_step (for the
    /// defaults) as well, so that a backend without this op still has a limit.
    double (*stable_step_options)(const double *option_values, double omega, double c);

    /* ABI version 5: tables built against 1 to 4 (smaller struct_size) have none of these. */

    /// Optional (NULL: the backend keeps no history between steps, or cannot save it; a
    /// checkpoint then restores such a backend as after defsim_world_set_state): writes what the
    /// next step needs beyond the world's state (x, v, t), so that a world loaded from the
    /// checkpoint continues bit for bit. Called between steps, only after a successful init and
    /// with the bodies, pins and options unchanged since. Must not change the state.
    defsim_status (*save_state)(const defsim_host *host, defsim_system *sys, const void *state,
                                const defsim_state_writer *writer);
    /// Reads what save_state wrote (same backend name, same bodies, pins and options), right
    /// after init on a world whose x, v and t are those of the checkpoint. On an error the core
    /// calls fini and fails the load. Required when save_state is present.
    defsim_status (*load_state)(const defsim_host *host, defsim_system *sys, void *state,
                                const defsim_state_reader *reader);

    /* Appended after ABI 8 (a table with a smaller struct_size has none of these). */

    /// Optional (NULL: the backend is not differentiable, and defsim_world_record refuses its
    /// worlds with DEFSIM_ERR_UNSUPPORTED): the reverse mode of one step (defsim_adjoint_step),
    /// called between steps, after a successful init, with the bodies, pins and options of
    /// the recorded steps. Exact for a converged step (docs/gradients.md). Must not change the
    /// world's state; may use the backend's workspaces. Returns DEFSIM_OK or an error status
    /// with the world's error set.
    defsim_status (*adjoint_step)(const defsim_host *host, defsim_system *sys, void *state,
                                  double h, const defsim_adjoint_step *a);
} defsim_backend;

/// Registers a backend for all worlds created after the call. The table (and its options and
/// counters) must stay valid for the life of the process. Thread-safe. Errors:
/// DEFSIM_ERR_INVALID_ARGUMENT (NULL, bad name, ABI version, struct size, missing
/// init/step/fini, or an invalid option or counter: bad or repeated name, negative count, a
/// default outside its range, a CHOICE without choices), DEFSIM_ERR_CONFLICT (name taken).
DEFSIM_API defsim_status defsim_register_backend(const defsim_backend *backend);

/// Entry point of a module: sets *out to the module's backend (static storage).
/// `host` is the core's service table, valid for the life of the process.
typedef defsim_status (*defsim_module_init_fn)(const defsim_host *host,
                                               const defsim_backend **out);

#ifdef __cplusplus
}
#endif

#endif /* DEFSIM_BACKEND_H */

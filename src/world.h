/* SPDX-License-Identifier: MIT */
/*
 * Private layout of a world. The world keeps MuJoCo's split: bodies hold what is constant during
 * simulation (topology, rest data, materials) as the host gave it; `plan` compiles them into
 * per-material element groups (structure of arrays, coloured for conflict-free scatter), and
 * the state (x, v) and workspaces live beside them.
 */
#ifndef DEFSIM_WORLD_H
#define DEFSIM_WORLD_H

#include "defsim/backend.h"
#include "options.h"

#include <stdint.h>

enum { DEFSIM__TET_MODELS = 4 };   /* STVK, COROTATED, NEOHOOKEAN, STABLE_NEOHOOKEAN */

/* A body as the host gave it (validated, tets reordered to positive orientation). */
typedef struct defsim__body {
    uint32_t generation;      /* odd while alive; bumped on removal */
    int32_t nv, nt, ns;
    double *rest;             /* 3 nv */
    double *mass;             /* nv */
    int32_t *tets;            /* 4 nt, body-local */
    int32_t *springs;         /* 2 ns, body-local */
    double *k;                /* ns */
    uint8_t *pinned;          /* nv */
    defsim_material mat;
    double mu, lambda;
    int32_t offset;           /* first vertex in the world arrays */
} defsim__body;

/* One element group: all tets of one model, or all springs. Elements are sorted by colour so
 * that elements of one colour share no vertex and can scatter in parallel without atomics. */
typedef struct defsim__group {
    int32_t n;                /* elements */
    int32_t nodes;            /* 4 (tets) or 2 (springs) */
    int32_t *idx;             /* nodes * n global vertex ids */
    double *dminv;            /* 9 n (tets) */
    double *vol;              /* n (tets) */
    double *mu, *lambda;      /* n (tets) */
    double *k, *l0;           /* n (springs) */
    double *beta;             /* n: stiffness damping (s) */
    int32_t ncolors;
    int32_t *color_ptr;       /* ncolors + 1 */
    int32_t *blk;             /* nodes^2 n: rank of row vertex in column vertex's list */
    uint32_t pass;            /* DEFSIM_PASS_* bit */
    int model;                /* defsim_model */
    /* SIMD batches of a tet group (tet_forces.h): colour c is batches bcolor_ptr[c] ..
     * bcolor_ptr[c + 1] - 1; blanes[b] of a batch's lanes are real elements. */
    int32_t nbatch;
    int32_t *bcolor_ptr;      /* ncolors + 1 */
    int32_t *bidx;            /* 4 DEFSIM__BATCH per batch: bidx[(4 b + a) BATCH + lane] */
    double *bdata;            /* DEFSIM__BATCH_ROWS DEFSIM__BATCH per batch, 64-byte aligned */
    uint8_t *blanes;          /* nbatch */
} defsim__group;

struct defsim_world {
    defsim_world_def def;
    char backend_name[64];
    const defsim_backend *backend;
    void *bstate;
    defsim__options options;  /* options and counters by name (options.c) */
    int backend_ready;        /* init succeeded for the current plan */
    int planned;              /* groups, maps and workspaces match the bodies */
    char error[512];

    defsim__body *bodies;
    int32_t nbodies, cap_bodies;
    int32_t body_count_alive;

    /* state and per-vertex data (rebuilt on add/remove; state carried over) */
    int32_t nv;
    double *x, *v;            /* 3 nv */
    double *mass;             /* nv */
    double *mass3, *alpha3;   /* 3 nv: mass and mass-damping alpha per DOF */
    uint8_t *pinned;          /* nv */
    double t;

    /* compiled element groups: tets per model, then springs */
    defsim__group groups[DEFSIM__TET_MODELS + 1];
    int has_gravity, has_mass_damping, has_stiffness_damping, has_pins;
    double length_scale;

    /* free DOFs: vertices are pinned whole, so free DOFs come in triples */
    int64_t nfree;
    int64_t *free_dofs, *dof_to_free;
    int32_t *vfree;           /* vertex -> free vertex index or -1 */
    int32_t nfree_v;

    /* vertex adjacency over free vertices (sorted), for matrix patterns */
    int64_t *adj_ptr;         /* nfree_v + 1 */
    int32_t *adj;             /* free-vertex neighbours (incl. self), sorted */
    int64_t *full_col_ptr, *full_row_idx;
    int64_t *upper_col_ptr, *upper_row_idx;
    int64_t full_nnz, upper_nnz;
    int32_t *upper_rank0;     /* per free vertex: neighbours ranked below it (for UPPER) */

    /* workspaces */
    double *x_save, *v_save;  /* 3 nv */
    double *ftmp;             /* 3 nv */
    double *partial;          /* per-block partial sums for deterministic reductions */
    int32_t npartial;

    int32_t nthreads;
    double h_stable;          /* auto_substep: cached estimate, 0 when stale */
    int32_t steps_since_estimate;
    defsim_stats stats;
    uint32_t step_passes;
    const struct defsim__tet_kernels *tet_kernels;   /* batched force kernels; NULL: scalar */
};

/* Internal force flag: leave pinned DOFs their force (defsim_world_forces). */
#define DEFSIM__FORCE_KEEP_PINNED (1u << 8)

/* Builds groups, maps and workspaces from the bodies (idempotent while planned). */
defsim_status defsim__plan(defsim_world *w);
void defsim__unplan(defsim_world *w);

/* Physics over the planned world (system.c). `which` is DEFSIM_FORCE_* bits. */
defsim_status defsim__forces(defsim_world *w, const double *x, const double *v, uint32_t which,
                             double *f);
double defsim__elastic_energy(defsim_world *w, const double *x);
double defsim__potential_energy(defsim_world *w, const double *x);
defsim_status defsim__matrix_pattern(defsim_world *w, defsim_triangle tri, defsim_csc *out);
defsim_status defsim__matrix_values(defsim_world *w, const double *x,
                                    const defsim_matrix_coeffs *c, defsim_triangle tri,
                                    double *values);
defsim_status defsim__matrix_product(defsim_world *w, const double *x,
                                     const defsim_matrix_coeffs *c, const double *dx,
                                     double *out);

/* omega_max = sqrt(largest eigenvalue of M^-1 K(x)) over the free DOFs (system.c). */
defsim_status defsim__omega_max(defsim_world *w, const double *x, double *omega);
/* Rayleigh damping rate c = alpha + beta omega^2 of the stability estimate (largest alpha over
 * the free DOFs, largest beta over the elements; world.c). */
double defsim__damping_rate(const defsim_world *w, double omega);

/* The host service table handed to backends. */
extern const defsim_host defsim__host;

/* Registry (registry.c). Finds a backend by name, loading its module if needed. */
defsim_status defsim__find_backend(const char *name, const defsim_backend **out);

/* Errors and logging. */
void defsim__world_error(defsim_world *w, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
void defsim__world_log(defsim_world *w, int level, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

double defsim__now(void);

#endif

/* SPDX-License-Identifier: MIT */
/*
 * The compiled system: what the bodies of a world compile to when it is planned (plan.c), in
 * the spirit of MuJoCo's mjModel. Element groups per material (structure of arrays, coloured for
 * conflict-free scatter, cut into SIMD batches), springs, masses, free-DOF maps, pins, the
 * sparse pattern, the pass plan, and the list of terms (term.h) that physics functions
 * (forces.c, energy.c, assembly.c, stability.c) loop over. They read a `const defsim__system *`
 * and write only into their outputs, into a `defsim__work` (scratch the planner sized) and into
 * the terms' mutable data and caches; they never see the world.
 */
#ifndef DEFSIM_SYSTEM_H
#define DEFSIM_SYSTEM_H

#include "defsim/backend.h"
#include "material_list.h"
#include "shell.h"
#include "term.h"

#include <stdint.h>

/* Tet models (material_list.h), one element group each. */
#define DEFSIM__COUNT_MODEL(name) +1
enum { DEFSIM__TET_MODELS = 0 DEFSIM__TET_MODEL_LIST(DEFSIM__COUNT_MODEL) };
#undef DEFSIM__COUNT_MODEL

/* The element groups of a system: linear tets per model (0 .. DEFSIM__TET_MODELS - 1), the
 * springs (DEFSIM__TET_MODELS), quadratic tets per model (DEFSIM__QUAD_GROUP + model), the
 * mean-dilatation quadratic tets per model (DEFSIM__QMIX_GROUP + model: quadratic bodies with
 * volume_averaging, term_quadratic_mixed.c; only the models with a split, material.h). */
enum {
    DEFSIM__QUAD_GROUP = DEFSIM__TET_MODELS + 1,
    DEFSIM__QMIX_GROUP = 2 * DEFSIM__TET_MODELS + 1,
    DEFSIM__GROUPS = 3 * DEFSIM__TET_MODELS + 1
};

/* One element group: all tets of one model, or all springs. Elements are sorted by colour so
 * that elements of one colour share no vertex and can scatter in parallel without atomics. */
typedef struct defsim__group {
    int32_t n;                /* elements */
    int32_t nodes;            /* 4 (tets), 10 (quadratic tets, tet10.h) or 2 (springs) */
    int32_t mixed;            /* quadratic tets: 1 for the mean-dilatation element (the
                                 DEFSIM__QMIX_GROUP groups, tet10.h), else 0 */
    int32_t *idx;             /* nodes * n global vertex ids */
    double *dminv;            /* 9 n (tets) */
    double *qrest;            /* DEFSIM__TET10_REST n (quadratic tets: gradients and weights
                                 per quadrature point, tet10.h) */
    double *vol;              /* n (tets, quadratic tets) */
    double *mu, *lambda;      /* n (tets) */
    double *k, *l0;           /* n (springs) */
    double *beta;             /* n: stiffness damping (s) */
    double *shell;            /* shell_width n: a membrane's rows (shell.h), or NULL */
    int32_t shell_width;
    int32_t shell_law;        /* a membrane group's DEFSIM__MEMBRANE_* */
    int32_t ncolors;
    int32_t *color_ptr;       /* ncolors + 1 */
    int32_t *blk;             /* nodes^2 n: rank of row vertex in column vertex's list */
    uint32_t pass;            /* DEFSIM_PASS_* bit */
    const struct defsim__model *law;   /* tets: the model (material.h); springs: NULL */
    /* SIMD batches of a tet group (tet_forces.h): colour c is batches bcolor_ptr[c] ..
     * bcolor_ptr[c + 1] - 1; blanes[b] of a batch's lanes are real elements. */
    int32_t nbatch;
    int32_t *bcolor_ptr;      /* ncolors + 1 */
    int32_t *bidx;            /* nodes DEFSIM__BATCH per batch: bidx[(nodes b + a) BATCH + lane] */
    double *bdata;            /* DEFSIM__BATCH_ROWS DEFSIM__BATCH per batch (quadratic tets:
                                 DEFSIM__QBATCH_ROWS; mean-dilatation ones: none), 64-byte
                                 aligned */
    uint8_t *blanes;          /* nbatch */
} defsim__group;

/* The volume-averaged tets of one model (term_nodal_volume.c; bodies with
 * defsim_body_def.volume_averaging): the energy sum_e V_e psi_iso(F_e) + sum_n V_n U(J_n), with
 * the nodal volume ratio J_n = sum_{e at n} (V_e / 4) J_e / V_n of each node n (a vertex of its
 * tets) and V_n = sum_{e at n} V_e / 4. Its tets are an element group of their own (coloured,
 * ranked into the pattern like the others; law the model, its split in material.h); the node
 * data below; the scratch its evaluations write. */
typedef struct defsim__vgroup {
    defsim__group g;          /* first: the element ops reach the rest from &g */
    int32_t nn;               /* nodes */
    int32_t *node;            /* nn: world vertex of each node */
    int32_t *enode;           /* 4 g.n: node of each element vertex */
    double *vn;               /* nn: V_n (m^3) */
    double *beta_n;           /* nn: stiffness damping of the node's body (s) */
    int64_t *ne_ptr;          /* nn + 1: node n's element vertices ne[ne_ptr[n] .. ne_ptr[n+1]) */
    int32_t *ne;              /* 4 e + a: element e's vertex a is the node */
    double *wne;              /* per ne entry: V_e / (4 V_n) */
    int64_t *patch_ptr;       /* nn + 1: node n's patch (the vertices of its tets, sorted) */
    int32_t *patch;           /* world vertices */
    int32_t *ploc;            /* 4 per ne entry: the patch places of the element's vertices */
    int64_t *prank_ptr;       /* nn + 1: offsets of the ranks (m^2 for a patch of m) */
    int32_t *prank;           /* rank of patch vertex a in patch vertex b's pattern list at
                                 prank_ptr[n] + a m + b (-1: pinned) */
    /* scratch of one evaluation (forces, energy, products) and the linearisation at the
     * kind's cache's x: */
    double *se, *sn;          /* 3 g.n, 2 nn */
    double *lin_pe;           /* g.n: the element pressures p_e = sum_{n of e} U'(J_n) / 4 */
    double *lin_un;           /* nn: U''(J_n) */
    double *gn;               /* 3 patch_ptr[nn]: dJ_n/dx over the patches (values) */
} defsim__vgroup;

/* The sparse pattern of matrices over free DOFs (assembly.c), built once per plan. Free DOFs
 * come in vertex triples, so the pattern is made of 3x3 blocks. */
typedef struct defsim__pattern {
    int built;
    int64_t *adj_ptr;         /* nfree_v + 1 */
    int32_t *adj;             /* free-vertex neighbours (incl. self), sorted */
    int64_t *full_col_ptr, *full_row_idx;
    int64_t *upper_col_ptr, *upper_row_idx;
    int64_t full_nnz, upper_nnz;
    int32_t *upper_rank0;     /* per free vertex: neighbours ranked below it (for UPPER) */
    /* Vertex pairs that body contact added (body_contact.h): (fa << 32 | fb), fa < fb free
     * vertices, sorted, unique; kept while the contacts at a step's end use them
     * (defsim__pattern_retain). version counts the pattern's builds (the host's
     * matrix_pattern_version). */
    int64_t *extra;
    int64_t nextra;
    uint64_t version;
} defsim__pattern;

/* Attachments (built by plan.c from coupling.c's list; evaluated by forces.c, energy.c and
 * assembly.c through element.h's attach_combine): zero-rest-length springs on d = sum_j a_j x[node_j] - p, energy
 * k/2 |d|^2, damping force -c a_j sum_l a_l v[node_l] on node j. Node 0 is the attached vertex
 * (a = 1); nodes 1..4 the target's vertices (a = -weight), or unused (node -1, a = 0) for a
 * world point p. */
enum { DEFSIM__ATTACH_NODES = 5 };

typedef struct defsim__attachments {
    int32_t n;
    int32_t *node;            /* 5 n */
    double *a;                /* 5 n */
    double *k, *c;            /* n: N/m, N s/m */
    double *p;                /* 3 n: world point (0 for a body target) */
    int32_t *blk;             /* 25 n: rank of node r in node s's pattern list (-1: pinned) */
} defsim__attachments;

typedef struct defsim__system {
    int32_t nv;               /* vertices */
    int32_t nthreads;
    double gravity[3];        /* m/s^2 */
    int projection;           /* defsim_projection of element Hessians */
    int exact_contact;        /* a backward pass assembles its matrix: contact terms' Hessians
                                 unprojected too (host.c's matrix_values_projected) */
    double *mass;             /* nv */
    double *mass3, *alpha3;   /* 3 nv: mass and mass-damping alpha per DOF */
    uint8_t *pinned;          /* nv */

    /* element groups: tets per model, springs, quadratic tets per model */
    defsim__group groups[DEFSIM__GROUPS];
    /* the volume-averaged tets per model (empty unless a body asks for them) */
    defsim__vgroup vgroups[DEFSIM__TET_MODELS];
    int has_volume_averaging;
    /* shells (shell.h): a group per membrane law (3 nodes; shell rows, vol the rest area),
     * then the hinges (4 nodes, the edge first; k the weight, l0 the rest angle) */
    defsim__group shells[DEFSIM__SHELL_GROUPS];

    /* the pass plan: what the scene uses */
    int has_gravity, has_mass_damping, has_stiffness_damping, has_pins;
    double length_scale;      /* diagonal of the rest bounding box (m) */

    /* free DOFs: vertices are pinned whole, so free DOFs come in triples */
    int64_t nfree;
    int64_t *free_dofs, *dof_to_free;
    int32_t *vfree;           /* vertex -> free vertex index or -1 */
    int32_t nfree_v;

    defsim__pattern pattern;
    const struct defsim__tet_kernels *tet_kernels;   /* batched force kernels; NULL: scalar */

    /* The host's terms (coupling.c; attachments compiled by plan.c). fext is owned by the world
     * and updated between steps; host is the world's handle of the host services (the force
     * callback's and held forces' terms read it), NULL for a system without a world. */
    defsim__attachments att;
    int has_attachment_damping;
    const double *fext;       /* 3 nv held external forces, or NULL (none or all zero) */
    struct defsim_system *host;

    /* Contact with the world's colliders (contact.h): set by the world for its steps while it
     * has live colliders, else NULL. Evaluations may grow its candidate pairs. */
    struct defsim__contact *contact;
    /* Body-body and self-contact (body_contact.h): set by the world for its steps while the
     * option body_contact is on, else NULL. */
    struct defsim__body_contact *body_contact;

    /* The terms (term.h), compiled by term.c from what the fields above say the scene uses:
     * terms[] in force order, energy_order and matrix_order index it in the order of those
     * sums. One linearisation cache per kind. */
    defsim__term terms[DEFSIM__TERM_MAX];
    int32_t nterms, nenergy, nmatrix;
    uint8_t energy_order[DEFSIM__TERM_MAX], matrix_order[DEFSIM__TERM_MAX];
    defsim__term_cache cache[DEFSIM__TERM_KINDS];
} defsim__system;

/* The first position in the sorted list[0 .. n) whose entry is not below key. */
static inline int32_t defsim__lower_rank(const int32_t *list, int64_t n, int32_t key)
{
    int64_t lo = 0, hi = n;
    while (lo < hi) {
        const int64_t mid = (lo + hi) / 2;
        if (list[mid] < key) lo = mid + 1;
        else hi = mid;
    }
    return (int32_t)lo;
}

/* The rank of free vertex fa in fb's neighbour list of a built pattern, or -1 if the pair is
 * not in it (the position of block (fa, fb) in column fb's blocks). */
static inline int32_t defsim__pattern_rank(const defsim__system *s, int32_t fa, int32_t fb)
{
    const defsim__pattern *p = &s->pattern;
    const int32_t *list = p->adj + p->adj_ptr[fb];
    const int64_t n = p->adj_ptr[fb + 1] - p->adj_ptr[fb];
    const int32_t r = defsim__lower_rank(list, n, fa);
    return r < n && list[r] == fa ? r : -1;
}

/* Scratch that physics functions write (sized by the planner, so that no step allocates). */
typedef struct defsim__work {
    double *partial;          /* per-block partial sums of deterministic reductions */
    int32_t npartial;
    double *pz, *py, *pu;     /* 3 nv each: power iteration (stability.c) */
} defsim__work;

#endif /* DEFSIM_SYSTEM_H */

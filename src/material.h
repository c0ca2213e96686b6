/* SPDX-License-Identifier: MIT */
/*
 * Material models (private). Each tet model is one file (material_<name>.c, listed in
 * material_list.h) exporting one defsim__model table; springs are material_spring.c with a
 * defsim__spring_model table. material.c holds what is common: Lame parameters, validation,
 * lookup by id, and the PSD projection of dP/dF from a model's eigen-structure.
 */
#ifndef DEFSIM_MATERIAL_H
#define DEFSIM_MATERIAL_H

#include <stddef.h>
#include <stdint.h>

#include "defsim/defsim.h"
#include "material_list.h"
#include "system.h"

/*
 * A tet model. Every function takes the Lame parameters mu = E/(2(1+nu)),
 * lambda = E nu/((1+nu)(1-2nu)) of the user's (E, nu) and a deformation gradient F, row-major
 * (F[3*i+j] = F_ij). P(I) = 0 and dPdF(I) is the linear elasticity tensor for every model.
 */
/*
 * The split psi(F) = psi_iso(F) + U(det F) of a model whose lambda term depends on J = det F
 * alone, which the volume-averaged tet (term_nodal_volume.c) evaluates per element (psi_iso, on
 * F) and per vertex (U, on the nodal volume ratio). psi_iso carries no lambda: near
 * incompressibility all the stiff part is in U. psi_iso(I) + U(1) = psi_rest.
 */
typedef struct defsim__model_split {
    /* P_iso = dpsi_iso/dF; returns psi_iso (+INFINITY, P NAN where the model is undefined). */
    double (*P)(double mu, double lambda, const double F[9], double P[9]);
    /* dP_iso/dF, the 9 x 9 layout of dPdF below (NAN where undefined). */
    void (*dPdF)(double mu, double lambda, const double F[9], double dPdF[81]);
    /* u[0] = U(J), u[1] = U'(J), u[2] = U''(J) (NAN where undefined). */
    void (*U)(double mu, double lambda, double J, double u[3]);
} defsim__model_split;

typedef struct defsim__model {
    const char *name;                 /* "stvk", as in material_list.h */
    defsim_model id;                  /* DEFSIM_MODEL_* */
    uint32_t pass;                    /* DEFSIM_PASS_* bit of its element group */
    int needs_positive_det;           /* undefined (NaN stress) where det F <= 0 */
    /* The per-element parameters of the batched law (batch rows P0, P1, P2): the model's own
     * reparameterisation of (mu, lambda) lives here. */
    void (*params)(double mu, double lambda, double p[3]);
    /* Energy density psi(F) (J/m^3); psi_rest(mu, lambda) = psi(I), which world energies
     * subtract (NULL: zero). */
    double (*psi)(double mu, double lambda, const double F[9]);
    double (*psi_rest)(double mu, double lambda);
    /* First Piola-Kirchhoff stress P = dpsi/dF; returns psi. */
    double (*P)(double mu, double lambda, const double F[9], double P[9]);
    /* dPdF[9*(3*i+j) + (3*k+l)] = dP_ij / dF_kl (symmetric 9 x 9). */
    void (*dPdF)(double mu, double lambda, const double F[9], double dPdF[81]);
    /* Eigen-structure in signed singular values s of F (psi = f(s)): the Hessian h = d2f/ds2
     * (3 x 3) and the twist / flip eigenvalues ev_sym = (g_a - g_b)/(s_a - s_b) and
     * ev_skew = (g_a + g_b)/(s_a + s_b) of the pairs (0,1), (0,2), (1,2), g = df/ds, in closed
     * forms: with them dPdF is projected without a 9 x 9 eigensolver. */
    void (*sigma)(double mu, double lambda, const double s[3], double h[9], double ev_sym[3],
                  double ev_skew[3]);
    /* Adds the elastic forces of group g at x into f: the scalar reference kernel
     * (DEFSIM_SIMD=scalar). */
    void (*forces)(const defsim__group *g, const double *x, double *f, int nthreads);
    /* Its isochoric / volumetric split, or NULL: StVK's lambda tr(E)^2 / 2 and co-rotated's
     * lambda tr(S - I)^2 / 2 are not functions of J, so they have none. */
    const defsim__model_split *split;
    /* dP/dmu and dP/dlambda at F (gradients, docs/gradients.md); NULL: P is linear in
     * (mu, lambda), so that they are P(1, 0, F) and P(0, 1, F) (defsim__model_dP_dlame). */
    void (*dP_dlame)(double mu, double lambda, const double F[9], double Pmu[9],
                     double Plambda[9]);
} defsim__model;

#define DEFSIM__DECLARE_MODEL(name) extern const defsim__model defsim__model_##name;
DEFSIM__TET_MODEL_LIST(DEFSIM__DECLARE_MODEL)
#undef DEFSIM__DECLARE_MODEL

/* The tet models in list order (the order of their element groups). */
extern const defsim__model *const defsim__tet_models[DEFSIM__TET_MODELS];

/* The tet model of a public id, or NULL (springs, unknown). */
const defsim__model *defsim__model_find(int id);

/* Springs: E = k/2 (l - l0)^2 between two vertices. */
typedef struct defsim__spring_model {
    const char *name;
    defsim_model id;
    uint32_t pass;
    /* Energy of one spring between xa and xb (J). */
    double (*energy)(const double *xa, const double *xb, double k, double l0);
    /* The 3x3 block Kb = k (n n^T + s (I - n n^T)), s = 1 - l0/l projected with `projection`
     * (its eigenvalues are k and k s); the element Hessian is [Kb -Kb; -Kb Kb]. */
    void (*block)(const double *xa, const double *xb, double k, double l0, int projection,
                  double Kb[9]);
    /* Adds the forces of spring group g at x into f. */
    void (*forces)(const defsim__group *g, const double *x, double *f, int nthreads);
} defsim__spring_model;

extern const defsim__spring_model defsim__model_spring;

/* Lame parameters of Young's modulus E and Poisson ratio nu (DESIGN.md section 4):
 * mu = E/(2(1+nu)), lambda = E nu/((1+nu)(1-2nu)). */
void defsim__lame(double E, double nu, double *mu, double *lambda);

/* params of a model whose batched law takes (mu, lambda) as they are: p = {mu, lambda, 0}.
 * Inline: the models' tables point at it, and material.c points at the tables (a call from a
 * model file back into material.c would be a cycle). */
static inline void defsim__lame_params(double mu, double lambda, double p[3])
{
    p[0] = mu;
    p[1] = lambda;
    p[2] = 0.0;
}

/* dPdF of model m made positive semi-definite (mode DEFSIM_PROJECTION_CLAMP or _ABS) from its
 * eigen-structure (sigma): the 3 x 3 block h is projected and the six twist / flip eigenvalues
 * clamped. D2, if not NULL, receives the projection with mode2 from the same decomposition. */
void defsim__model_dpdf_projected(const defsim__model *m, double mu, double lambda,
                                  const double F[9], int mode, double D[81], int mode2,
                                  double *D2);

/* The tangent of an element matrix k K + kd beta B at F: sk dPdF projected with proj (none,
 * clamp or abs) plus sd dPdF clamped (stiffness damping's share, always clamped). */
void defsim__model_dpdf_scaled(const defsim__model *law, double mu, double la, const double F[9],
                               int proj, double sk, double sd, double D[81]);
/* dP/dmu and dP/dlambda of model m at F (its dP_dlame, or P(1, 0, F) and P(0, 1, F)). */
void defsim__model_dP_dlame(const defsim__model *m, double mu, double lambda, const double F[9],
                            double Pmu[9], double Plambda[9]);

/* The Lame parameters' derivatives: dmu/dE, dmu/dnu, dlambda/dE, dlambda/dnu into d[4]. */
void defsim__lame_derivatives(double E, double nu, double d[4]);

/* Validates a material for a body that has tets and/or springs. Returns DEFSIM_OK,
 * DEFSIM_ERR_INVALID_ARGUMENT (NULL, size smaller than sizeof(defsim_material)) or
 * DEFSIM_ERR_INVALID_MATERIAL (unknown model, tets with the spring model, or a field out of
 * range; tet-model fields are checked whenever the model is a tet model, the stiffness when the
 * body has springs or the model is the spring model). On error, writes a message naming the field
 * and its value into msg (msg may be NULL or msg_size 0); on success writes "". Sets no error
 * state of its own. Thread-safe. */
defsim_status defsim__material_check(const defsim_material *m, int has_tets, int has_springs,
                                     char *msg, size_t msg_size);

#endif /* DEFSIM_MATERIAL_H */

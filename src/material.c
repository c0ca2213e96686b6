/* SPDX-License-Identifier: MIT */
/*
 * What the material models share: the list of tet models (material_list.h) and lookup by id,
 * Lame parameters, the PSD projection of dP/dF from a model's eigen-structure, validation, and
 * the public defaults and evaluation.
 */
#include "material.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "isotropic.h"
#include "mat3.h"
#include "status.h"

#define DEFSIM__MODEL_ENTRY(name) &defsim__model_##name,
const defsim__model *const defsim__tet_models[DEFSIM__TET_MODELS] = {
    DEFSIM__TET_MODEL_LIST(DEFSIM__MODEL_ENTRY)};
#undef DEFSIM__MODEL_ENTRY

const defsim__model *defsim__model_find(int id)
{
    for (int m = 0; m < DEFSIM__TET_MODELS; ++m)
        if ((int)defsim__tet_models[m]->id == id) return defsim__tet_models[m];
    return NULL;
}

void defsim__lame(double E, double nu, double *mu, double *lambda)
{
    *mu = E / (2.0 * (1.0 + nu));
    *lambda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
}


static void put_msg(char *msg, size_t msg_size, const char *fmt, ...)
{
    if (msg == NULL || msg_size == 0) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, msg_size, fmt, ap);
    va_end(ap);
}

/* dPdF of a tet model made positive semi-definite (mode DEFSIM_PROJECTION_CLAMP or _ABS) from
 * its eigen-structure in signed singular values (the model's sigma): the 3 x 3 block h
 * is projected and the six twist / flip eigenvalues clamped, which is the projection of the
 * 9 x 9 tensor without a 9 x 9 eigensolver. D2, if not NULL, receives the projection with mode2
 * from the same decomposition. */
void defsim__model_dpdf_projected(const defsim__model *m, double mu, double la,
                                  const double F[9], int mode, double D[81], int mode2,
                                  double *D2)
{
    double U[9], V[9], s[3], h[9], es[3], ek[3];
    defsim__svd3(F, U, s, V);
    m->sigma(mu, la, s, h, es, ek);
    const int modes[2] = {mode, mode2};
    double *out[2] = {D, D2};
    for (int k = 0; k < 2; ++k) {
        if (!out[k]) continue;
        double hp[9], esp[3], ekp[3];
        memcpy(hp, h, sizeof hp);
        /* Positive definite (leading minors > 0, Sylvester), the common case: nothing to do. */
        const double m2 = h[0] * h[4] - h[1] * h[3];
        const double m3 = h[0] * (h[4] * h[8] - h[5] * h[7]) - h[1] * (h[3] * h[8] - h[5] * h[6]) +
                          h[2] * (h[3] * h[7] - h[4] * h[6]);
        if (!(h[0] > 0.0 && m2 > 0.0 && m3 > 0.0)) defsim__project_psd(3, hp, modes[k]);
        for (int p = 0; p < 3; ++p) {
            esp[p] = es[p] < 0.0 ? (modes[k] == DEFSIM_PROJECTION_ABS ? -es[p] : 0.0) : es[p];
            ekp[p] = ek[p] < 0.0 ? (modes[k] == DEFSIM_PROJECTION_ABS ? -ek[p] : 0.0) : ek[p];
        }
        defsim__isotropic_dPdF(U, V, hp, esp, ekp, out[k]);
    }
}

void defsim__model_dpdf_scaled(const defsim__model *law, double mu, double la, const double F[9],
                               int proj, double sk, double sd, double D[81])
{
    if (proj == DEFSIM_PROJECTION_NONE) {
        law->dPdF(mu, la, F, D);
        if (sd != 0.0) {
            double Dd[81];
            defsim__model_dpdf_projected(law, mu, la, F, DEFSIM_PROJECTION_CLAMP, Dd, 0, NULL);
            for (int i = 0; i < 81; ++i) D[i] = sk * D[i] + sd * Dd[i];
        } else {
            for (int i = 0; i < 81; ++i) D[i] *= sk;
        }
    } else if (sd != 0.0 && proj != DEFSIM_PROJECTION_CLAMP) {
        double Dd[81];
        defsim__model_dpdf_projected(law, mu, la, F, proj, D, DEFSIM_PROJECTION_CLAMP, Dd);
        for (int i = 0; i < 81; ++i) D[i] = sk * D[i] + sd * Dd[i];
    } else {
        defsim__model_dpdf_projected(law, mu, la, F, proj, D, 0, NULL);
        for (int i = 0; i < 81; ++i) D[i] *= sk + sd;
    }
}

/* Written as !(x >= 0) so that NaN fails too. */
#define CHECK_NONNEG(field)                                                                     \
    do {                                                                                        \
        if (!(isfinite(m->field) && m->field >= 0.0)) {                                         \
            put_msg(msg, msg_size, "material." #field " must be finite and >= 0 (got %.17g)",   \
                    m->field);                                                                  \
            return DEFSIM_ERR_INVALID_MATERIAL;                                                 \
        }                                                                                       \
    } while (0)

defsim_status defsim__material_check(const defsim_material *m, int has_tets, int has_springs,
                                     char *msg, size_t msg_size)
{
    if (m == NULL) {
        put_msg(msg, msg_size, "material is NULL");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (m->size < sizeof(defsim_material)) {
        put_msg(msg, msg_size, "material.size is %u, expected at least %u (call defsim_material_init)",
                (unsigned)m->size, (unsigned)sizeof(defsim_material));
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    int model = (int)m->model;
    if (model != DEFSIM_MODEL_SPRING && !defsim__model_find(model)) {
        put_msg(msg, msg_size, "material.model %d is not a known model", model);
        return DEFSIM_ERR_INVALID_MATERIAL;
    }
    if (has_tets && model == DEFSIM_MODEL_SPRING) {
        put_msg(msg, msg_size, "material.model is DEFSIM_MODEL_SPRING but the body has tets");
        return DEFSIM_ERR_INVALID_MATERIAL;
    }
    if (defsim__model_find(model)) {
        if (!(isfinite(m->youngs_modulus) && m->youngs_modulus > 0.0)) {
            put_msg(msg, msg_size, "material.youngs_modulus must be finite and > 0 (got %.17g)",
                    m->youngs_modulus);
            return DEFSIM_ERR_INVALID_MATERIAL;
        }
        if (!(m->poisson_ratio >= 0.0 && m->poisson_ratio < 0.5)) {
            put_msg(msg, msg_size, "material.poisson_ratio must be in [0, 0.5) (got %.17g)",
                    m->poisson_ratio);
            return DEFSIM_ERR_INVALID_MATERIAL;
        }
        CHECK_NONNEG(density);
    }
    if (has_springs || model == DEFSIM_MODEL_SPRING) CHECK_NONNEG(stiffness);
    CHECK_NONNEG(vertex_mass);
    CHECK_NONNEG(mass_damping);
    CHECK_NONNEG(stiffness_damping);
    put_msg(msg, msg_size, "%s", "");
    return DEFSIM_OK;
}

#undef CHECK_NONNEG

#define FITS(field) \
    (size >= offsetof(defsim_material, field) + sizeof(((defsim_material *)0)->field))

void defsim_material_init(defsim_material *material, size_t size, defsim_model model)
{
    if (material == NULL || size < offsetof(defsim_material, youngs_modulus)) return;
    material->size = (uint32_t)(size < sizeof(defsim_material) ? size : sizeof(defsim_material));
    material->model = model;
    if (FITS(youngs_modulus)) material->youngs_modulus = 1e6;
    if (FITS(poisson_ratio)) material->poisson_ratio = 0.3;
    if (FITS(density)) material->density = 1000.0;
    if (FITS(stiffness)) material->stiffness = 1e3;
    if (FITS(vertex_mass)) material->vertex_mass = (model == DEFSIM_MODEL_SPRING) ? 0.01 : 0.0;
    if (FITS(mass_damping)) material->mass_damping = 0.0;
    if (FITS(stiffness_damping)) material->stiffness_damping = 0.0;
}

#undef FITS

defsim_status defsim_material_check(const defsim_material *material)
{
    char msg[256];
    /* As for a body with springs: stiffness is checked whatever the model. */
    const defsim_status st = defsim__material_check(material, 0, 1, msg, sizeof msg);
    if (st != DEFSIM_OK) defsim__set_last_error("defsim_material_check: %s", msg);
    else defsim__set_last_error("%s", "");
    return st;
}

defsim_status defsim_material_eval(const defsim_material *material, const double F[9],
                                   double *psi, double P[9], double dPdF[81])
{
    char msg[256];
    if (material == NULL || F == NULL) {
        defsim__set_last_error("defsim_material_eval: %s is NULL",
                               material == NULL ? "material" : "F");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (material->size >= sizeof(defsim_material) && material->model == DEFSIM_MODEL_SPRING) {
        defsim__set_last_error("defsim_material_eval: the spring model has no tet energy");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    defsim_status st = defsim__material_check(material, 1, 0, msg, sizeof msg);
    if (st != DEFSIM_OK) {
        defsim__set_last_error("defsim_material_eval: %s", msg);
        return st;
    }
    for (int i = 0; i < 9; ++i) {
        if (!isfinite(F[i])) {
            defsim__set_last_error("defsim_material_eval: F[%d] is not finite (%g)", i, F[i]);
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
    }

    double mu, lambda;
    defsim__lame(material->youngs_modulus, material->poisson_ratio, &mu, &lambda);
    /* The check admits only tet models here. */
    const defsim__model *m = defsim__model_find((int)material->model);
    double fmax = 0.0;
    for (int i = 0; i < 9; ++i) fmax = fabs(F[i]) > fmax ? fabs(F[i]) : fmax;
    if (m->needs_positive_det) {
        double J = defsim__m3_det(F);
        if (!(J > 0.0) || !isfinite(J)) {
            defsim__set_last_error(isfinite(J) ? "defsim_material_eval: %s is undefined at det F "
                                                 "= %.17g <= 0"
                                               : "defsim_material_eval: %s: det F = %g overflows "
                                                 "(max |F_ij| = %g)",
                                   m->name, J, fmax);
            return DEFSIM_ERR_UNSTABLE;
        }
    }
    /* Large F overflows the invariants (psi grows like |F|^2 to |F|^4): the outputs would be
     * inf or NaN, which a status reports instead. */
    double e = 0.0, Pbuf[9];
    int finite = 1;
    if (psi != NULL || P != NULL) {
        double *p = P != NULL ? P : Pbuf;
        e = m->P(mu, lambda, F, p);
        finite &= psi == NULL || isfinite(e);
        for (int i = 0; P != NULL && i < 9; ++i) finite &= isfinite(p[i]) != 0;
    }
    if (dPdF != NULL) {
        m->dPdF(mu, lambda, F, dPdF);
        for (int i = 0; i < 81; ++i) finite &= isfinite(dPdF[i]) != 0;
    }
    if (psi != NULL) *psi = e;
    if (!finite) {
        defsim__set_last_error("defsim_material_eval: %s overflows at max |F_ij| = %g (the "
                               "outputs are not finite)", m->name, fmax);
        return DEFSIM_ERR_UNSTABLE;
    }
    return DEFSIM_OK;
}

void defsim__model_dP_dlame(const defsim__model *m, double mu, double lambda, const double F[9],
                            double Pmu[9], double Plambda[9])
{
    (void)mu;
    (void)lambda;
    if (m->dP_dlame) {
        m->dP_dlame(mu, lambda, F, Pmu, Plambda);
        return;
    }
    m->P(1.0, 0.0, F, Pmu);
    m->P(0.0, 1.0, F, Plambda);
}

void defsim__lame_derivatives(double E, double nu, double d[4])
{
    const double q = (1.0 + nu) * (1.0 - 2.0 * nu);
    d[0] = 1.0 / (2.0 * (1.0 + nu));
    d[1] = -E / (2.0 * (1.0 + nu) * (1.0 + nu));
    d[2] = nu / q;
    d[3] = E * (1.0 + 2.0 * nu * nu) / (q * q);
}

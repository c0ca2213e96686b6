/* SPDX-License-Identifier: MIT */
#include "material.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>

#include "material_models.h"
#include "status.h"

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

static int is_tet_model(int model)
{
    return model == DEFSIM_MODEL_STVK || model == DEFSIM_MODEL_COROTATED ||
           model == DEFSIM_MODEL_NEOHOOKEAN || model == DEFSIM_MODEL_STABLE_NEOHOOKEAN;
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
    if (model != DEFSIM_MODEL_SPRING && !is_tet_model(model)) {
        put_msg(msg, msg_size, "material.model %d is not a known model", model);
        return DEFSIM_ERR_INVALID_MATERIAL;
    }
    if (has_tets && model == DEFSIM_MODEL_SPRING) {
        put_msg(msg, msg_size, "material.model is DEFSIM_MODEL_SPRING but the body has tets");
        return DEFSIM_ERR_INVALID_MATERIAL;
    }
    if (is_tet_model(model)) {
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
    double e = 0.0, Pbuf[9];
    double *Pout = P != NULL ? P : Pbuf;
    switch (material->model) {
    case DEFSIM_MODEL_STVK:
        if (psi != NULL || P != NULL) e = defsim__stvk_P(mu, lambda, F, Pout);
        if (dPdF != NULL) defsim__stvk_dPdF(mu, lambda, F, dPdF);
        break;
    case DEFSIM_MODEL_COROTATED:
        if (P != NULL) e = defsim__corotated_P(mu, lambda, F, P);
        else if (psi != NULL) e = defsim__corotated_psi(mu, lambda, F);
        if (dPdF != NULL) defsim__corotated_dPdF(mu, lambda, F, dPdF);
        break;
    case DEFSIM_MODEL_NEOHOOKEAN: {
        double J = defsim__m3_det(F);
        if (!(J > 0.0)) {
            defsim__set_last_error(
                "defsim_material_eval: neo-Hookean is undefined at det F = %.17g <= 0", J);
            return DEFSIM_ERR_UNSTABLE;
        }
        if (psi != NULL || P != NULL) e = defsim__neohookean_P(mu, lambda, F, Pout);
        if (dPdF != NULL) defsim__neohookean_dPdF(mu, lambda, F, dPdF);
        break;
    }
    default: /* DEFSIM_MODEL_STABLE_NEOHOOKEAN; the check admits no other model here. */
        if (psi != NULL || P != NULL) e = defsim__snh_P(mu, lambda, F, Pout);
        if (dPdF != NULL) defsim__snh_dPdF(mu, lambda, F, dPdF);
        break;
    }
    if (psi != NULL) *psi = e;
    return DEFSIM_OK;
}

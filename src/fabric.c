/* SPDX-License-Identifier: MIT */
/*
 * The table of measured fabrics (docs/shells.md, "Fabrics by name"): the shell fields of a
 * body def by name. The numbers come from the database of Wang, O'Brien and Ramamoorthi 2011
 * ("Data-driven elastic models for cloth: modeling and measurement", SIGGRAPH 2011), as the
 * ARCSim simulator reads its material files: areal density as given; from the small-strain
 * row (d0, d1, d2, d3) of a fabric's stretching data, whose energy density ARCSim evaluates as
 * d0 E11^2 + 2 d1 E11 E22 + d2 E22^2 + 2 d3 E12^2, the plane-stress moduli c11 = 2 d0,
 * c12 = 2 d1, c22 = 2 d2, G = d3, hence warp (first axis) and weft moduli
 * Y1 = c11 - c12^2 / c22, Y2 = c22 - c12^2 / c11 and nu_12 = c12 / c22; from the first
 * (smallest-curvature) bending sample k of each direction, whose hinge energy ARCSim evaluates
 * as k |e|^2 / (8 (A1 + A2)) theta^2, D = k / 4 (ours: D / 2 theta^2 |e|^2 / (A1 + A2)), the
 * warp's from the samples of hinges along the second axis (bending along the first). The
 * derived values are rounded to 4 or 5 digits; docs/shells.md lists the raw ones beside them.
 */
#include "status.h"

#include <stdio.h>
#include <string.h>

typedef struct fabric_row {
    const char *name, *description;
    double rho, warp, weft, shear, nu12, d_warp, d_weft;
} fabric_row;

static const fabric_row FABRICS[] = {
    {"denim", "11oz black denim, jeans, 99% cotton 1% spandex (Wang et al. 2011: "
     "11oz-black-denim)", 0.324, 410.5, 2026.8, 53.387, 0.01009, 2.424e-5, 1.605e-5},
    {"cotton_polyester", "twill, pants, 65% cotton 35% polyester (Wang et al. 2011: "
     "royal-target)", 0.220, 4033.0, 4069.9, 104.76, 0.004506, 3.135e-5, 3.135e-5},
    {"polyester_tablecloth", "tablecloth, 100% polyester (Wang et al. 2011: white-dots-on-blk)",
     0.128, 4004.2, 4055.0, 19.189, 0.0001705, 7.821e-6, 1.293e-5},
    {"polyester_blanket", "blanket, 100% polyester (Wang et al. 2011: pink-ribbon-brown)",
     0.228, 211.17, 341.26, 30.250, 0.4331, 1.494e-5, 2.927e-5},
    {"polyester_jacket", "jacket, 100% polyester (Wang et al. 2011: tango-red-jet-set)",
     0.113, 51.643, 205.56, 14.315, 0.3172, 5.086e-6, 3.573e-6},
    {"swimwear_knit", "swimsuit knit, 87% nylon 13% spandex (Wang et al. 2011: "
     "white-swim-solid)", 0.204, 95.049, 207.28, 60.774, 0.06533, 1.275e-5, 1.506e-5},
};

enum { FABRIC_COUNT = (int)(sizeof FABRICS / sizeof FABRICS[0]) };

int32_t defsim_fabric_count(void)
{
    return FABRIC_COUNT;
}

static void fill(const fabric_row *r, defsim_fabric *out)
{
    out->name = r->name;
    out->description = r->description;
    out->areal_density = r->rho;
    out->warp_modulus = r->warp;
    out->weft_modulus = r->weft;
    out->shear_modulus = r->shear;
    out->warp_poisson = r->nu12;
    out->bending_rigidity = r->d_warp;
    out->bending_rigidity_weft = r->d_weft;
}

defsim_status defsim_fabric_get(int32_t index, defsim_fabric *out)
{
    if (!out || out->size < sizeof *out) {
        defsim__set_last_error("defsim_fabric_get: NULL out or out->size not "
                               "sizeof(defsim_fabric)");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (index < 0 || index >= FABRIC_COUNT) {
        defsim__set_last_error("defsim_fabric_get: index %d outside [0, %d)", (int)index,
                               FABRIC_COUNT);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    fill(&FABRICS[index], out);
    return DEFSIM_OK;
}

/* The row of a name, or NULL with the error "unknown fabric" and the table's names. */
static const fabric_row *lookup(const char *fn, const char *name)
{
    if (name)
        for (int i = 0; i < FABRIC_COUNT; ++i)
            if (strcmp(FABRICS[i].name, name) == 0) return &FABRICS[i];
    char known[256] = "";
    size_t len = 0;
    for (int i = 0; i < FABRIC_COUNT && len < sizeof known; ++i)
        len += (size_t)snprintf(known + len, sizeof known - len, "%s%s", i ? ", " : "",
                                FABRICS[i].name);
    defsim__set_last_error("%s: unknown fabric \"%.64s\" (the table has %s)", fn,
                           name ? name : "(null)", known);
    return NULL;
}

defsim_status defsim_fabric_find(const char *name, defsim_fabric *out)
{
    if (!out || out->size < sizeof *out) {
        defsim__set_last_error("defsim_fabric_find: NULL out or out->size not "
                               "sizeof(defsim_fabric)");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    const fabric_row *r = lookup("defsim_fabric_find", name);
    if (!r) return DEFSIM_ERR_INVALID_MATERIAL;
    fill(r, out);
    return DEFSIM_OK;
}

defsim_status defsim_body_def_set_fabric(defsim_body_def *def, const char *name)
{
    if (!def || def->size < sizeof *def) {
        defsim__set_last_error("defsim_body_def_set_fabric: NULL def or def->size not "
                               "sizeof(defsim_body_def)");
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    const fabric_row *r = lookup("defsim_body_def_set_fabric", name);
    if (!r) return DEFSIM_ERR_INVALID_MATERIAL;
    def->shell_membrane = DEFSIM_SHELL_MEMBRANE_ORTHOTROPIC_STVK;
    def->shell_areal_density = r->rho;
    def->shell_warp_modulus = r->warp;
    def->shell_weft_modulus = r->weft;
    def->shell_shear_modulus = r->shear;
    def->shell_warp_poisson = r->nu12;
    def->shell_bending_rigidity = r->d_warp;
    def->shell_bending_rigidity_weft = r->d_weft;
    return DEFSIM_OK;
}

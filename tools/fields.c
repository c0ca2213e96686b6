/* SPDX-License-Identifier: MIT */
#include "fields.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int fail(fields *f, char *err, size_t errsz, const char *msg)
{
    fields_free(f);
    snprintf(err, errsz, "fields: %s", msg);
    return -1;
}

int fields_init(fields *f, defsim_world *w, const vtk_cells *c, unsigned which, char *err,
                size_t errsz)
{
    memset(f, 0, sizeof *f);
    f->nv = defsim_world_vertex_count(w);
    f->nbodies = defsim_world_body_count(w);
    f->ncells = c->ncells;
    f->cell_offset = malloc((size_t)(f->nbodies + 1) * sizeof *f->cell_offset);
    f->tet_count = calloc((size_t)f->nbodies + 1, sizeof *f->tet_count);
    if (!f->cell_offset || !f->tet_count) return fail(f, err, errsz, "out of memory");
    /* Each body's cells in one run, in body order. */
    int32_t next = 0;
    for (int64_t k = 0; k < c->ncells; ++k) {
        const int32_t b = c->body[k];
        if (b < 0 || b >= f->nbodies || b < next - 1)
            return fail(f, err, errsz, "the cells' body tags are not the world's bodies, each "
                                       "body's cells in one run in body order");
        while (next <= b) f->cell_offset[next++] = k;
        if (vtk_is_tet(c->types[k])) ++f->tet_count[b];
    }
    while (next <= f->nbodies) f->cell_offset[next++] = c->ncells;
    int tets = 0;
    for (int32_t i = 0; i < f->nbodies; ++i) tets |= f->tet_count[i] > 0;
    const size_t n3 = 3 * (size_t)f->nv, nc = (size_t)(f->ncells > 0 ? f->ncells : 1);
    f->pinned = calloc((size_t)f->nv + 1, 1);
    if (!f->pinned || defsim_world_get_pinned(w, f->pinned, f->nv) != DEFSIM_OK)
        return fail(f, err, errsz, "out of memory");
    int pins = 0;
    for (int32_t k = 0; k < f->nv; ++k) pins |= f->pinned[k];
    double body_contact = 0.0;
    defsim_world_get_option(w, "core.body_contact", &body_contact);
    if (!tets) which &= ~(unsigned)SCENE_FIELD_STRESS;
    if (!pins) which &= ~(unsigned)SCENE_FIELD_PIN_FORCES;
    if (defsim_world_attachment_count(w) == 0) which &= ~(unsigned)SCENE_FIELD_ATTACHMENT_FORCES;
    if (defsim_world_collider_count(w) == 0 && body_contact == 0.0)
        which &= ~(unsigned)SCENE_FIELD_CONTACT_FORCES;
    f->which = which;
    if (which & SCENE_FIELD_STRESS) {
        f->cauchy = calloc(9 * nc, sizeof *f->cauchy);
        f->von_mises = calloc(nc, sizeof *f->von_mises);
        f->energy_density = calloc(nc, sizeof *f->energy_density);
        if (!f->cauchy || !f->von_mises || !f->energy_density)
            return fail(f, err, errsz, "out of memory");
        f->arrays[f->narrays++] = (vtk_array){"cauchy_stress", 9, 1, f->cauchy, NULL};
        f->arrays[f->narrays++] = (vtk_array){"von_mises", 1, 1, f->von_mises, NULL};
        f->arrays[f->narrays++] = (vtk_array){"energy_density", 1, 1, f->energy_density, NULL};
    }
    f->x0 = malloc(n3 * sizeof *f->x0 + 1);
    if (!f->x0 || defsim_world_get_positions(w, f->x0, f->nv) != DEFSIM_OK)
        return fail(f, err, errsz, "out of memory");
    static const struct { unsigned bit; const char *name; } point3[] = {
        {SCENE_FIELD_DISPLACEMENT, "displacement"}, {SCENE_FIELD_PIN_FORCES, "pin_force"},
        {SCENE_FIELD_ATTACHMENT_FORCES, "attachment_force"},
        {SCENE_FIELD_CONTACT_FORCES, "contact_force"}};
    double **slot[4] = {&f->displacement, &f->pin_force, &f->attachment_force, &f->contact_force};
    for (int k = 0; k < 4; ++k) {
        if (!(which & point3[k].bit)) continue;
        if (!(*slot[k] = calloc(n3 + 1, sizeof **slot[k])))
            return fail(f, err, errsz, "out of memory");
        f->arrays[f->narrays++] = (vtk_array){point3[k].name, 3, 0, *slot[k], NULL};
    }
    /* The pinned flag is part of the model, not of the state: read once, written with every
     * frame of a world that pins or drives anything. */
    if (pins) {
        f->arrays[f->narrays++] = (vtk_array){"pinned", 1, 0, NULL, f->pinned};
    } else {
        free(f->pinned);
        f->pinned = NULL;
    }
    return 0;
}

int fields_eval(fields *f, defsim_world *w, char *err, size_t errsz)
{
    defsim_status st = DEFSIM_OK;
    const char *what = "";
    if (f->which & SCENE_FIELD_STRESS)
        for (int32_t i = 0; i < f->nbodies && st == DEFSIM_OK; ++i) {
            if (f->tet_count[i] == 0) continue;
            defsim_body_id id;
            const int64_t o = f->cell_offset[i];
            what = "element stress";
            st = defsim_world_body_at(w, i, &id);
            if (st == DEFSIM_OK)
                st = defsim_body_element_stress(w, id, f->cauchy + 9 * o, f->von_mises + o,
                                                f->energy_density + o, (int32_t)f->tet_count[i]);
        }
    if (st == DEFSIM_OK && f->displacement) {
        what = "positions";
        st = defsim_world_get_positions(w, f->displacement, f->nv);
        for (int64_t k = 0; k < 3 * (int64_t)f->nv; ++k) f->displacement[k] -= f->x0[k];
    }
    if (st == DEFSIM_OK && f->pin_force) {
        what = "pin forces";
        st = defsim_world_get_pin_forces(w, f->pin_force, f->nv);
    }
    if (st == DEFSIM_OK && f->contact_force) {
        what = "contact forces";
        st = defsim_world_get_contact_forces(w, f->contact_force, f->nv);
    }
    if (st == DEFSIM_OK && f->attachment_force) {
        what = "attachment forces";
        memset(f->attachment_force, 0, 3 * (size_t)f->nv * sizeof *f->attachment_force);
        const int32_t na = defsim_world_attachment_count(w);
        for (int32_t i = 0; i < na && st == DEFSIM_OK; ++i) {
            defsim_attachment_id id;
            defsim_attachment_def d = {.size = sizeof d};
            double g[3];
            st = defsim_world_attachment_at(w, i, &id);
            if (st == DEFSIM_OK) st = defsim_world_get_attachment(w, id, &d);
            if (st == DEFSIM_OK) st = defsim_world_get_attachment_force(w, id, g);
            const int32_t off = st == DEFSIM_OK ? defsim_body_vertex_offset(w, d.body) : 0;
            if (off < 0) st = (defsim_status)off;
            const int64_t v = (int64_t)off + d.vertex;
            for (int c = 0; c < 3 && st == DEFSIM_OK; ++c) f->attachment_force[3 * v + c] += g[c];
        }
    }
    if (st != DEFSIM_OK) {
        snprintf(err, errsz, "%s: %s: %s", what, defsim_status_string(st), defsim_world_last_error(w));
        return -1;
    }
    return 0;
}

void fields_free(fields *f)
{
    free(f->cell_offset); free(f->tet_count); free(f->x0); free(f->cauchy); free(f->von_mises);
    free(f->energy_density); free(f->displacement); free(f->pin_force);
    free(f->attachment_force); free(f->contact_force); free(f->pinned);
    memset(f, 0, sizeof *f);
}

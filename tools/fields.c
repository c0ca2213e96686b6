/* SPDX-License-Identifier: MIT */
#include "fields.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int64_t body_cells(const scene_body *b)
{
    if (b->mesh.tet_count > 0) return b->mesh.tet_count;
    if (b->mesh.triangle_count > 0) return b->mesh.triangle_count;
    return b->line_count;
}

int fields_init(fields *f, const scene *s, defsim_world *w, unsigned which, char *err, size_t errsz)
{
    memset(f, 0, sizeof *f);
    f->nv = defsim_world_vertex_count(w);
    f->cell_offset = malloc((size_t)(s->nbodies + 1) * sizeof *f->cell_offset);
    if (!f->cell_offset) goto oom;
    int tets = 0, pins = 0;
    for (int32_t i = 0; i < s->nbodies; ++i) {
        f->cell_offset[i] = f->ncells;
        f->ncells += body_cells(&s->bodies[i]);
        tets |= s->bodies[i].mesh.tet_count > 0;
        pins |= s->bodies[i].npins > 0 || s->bodies[i].ndrives > 0;
    }
    f->cell_offset[s->nbodies] = f->ncells;
    if (!tets) which &= ~(unsigned)SCENE_FIELD_STRESS;
    if (!pins) which &= ~(unsigned)SCENE_FIELD_PIN_FORCES;
    if (s->nattachments == 0) which &= ~(unsigned)SCENE_FIELD_ATTACHMENT_FORCES;
    f->which = which;
    const size_t n3 = 3 * (size_t)f->nv, nc = (size_t)(f->ncells > 0 ? f->ncells : 1);
    if (which & SCENE_FIELD_STRESS) {
        f->cauchy = calloc(9 * nc, sizeof *f->cauchy);
        f->von_mises = calloc(nc, sizeof *f->von_mises);
        f->energy_density = calloc(nc, sizeof *f->energy_density);
        if (!f->cauchy || !f->von_mises || !f->energy_density) goto oom;
        f->arrays[f->narrays++] = (vtk_array){"cauchy_stress", 9, 1, f->cauchy, NULL};
        f->arrays[f->narrays++] = (vtk_array){"von_mises", 1, 1, f->von_mises, NULL};
        f->arrays[f->narrays++] = (vtk_array){"energy_density", 1, 1, f->energy_density, NULL};
    }
    f->x0 = malloc(n3 * sizeof *f->x0 + 1);
    if (!f->x0 || defsim_world_get_positions(w, f->x0, f->nv) != DEFSIM_OK) goto oom;
    if (which & SCENE_FIELD_DISPLACEMENT) {
        if (!(f->displacement = calloc(n3 + 1, sizeof *f->displacement))) goto oom;
        f->arrays[f->narrays++] = (vtk_array){"displacement", 3, 0, f->displacement, NULL};
    }
    if (which & SCENE_FIELD_PIN_FORCES) {
        if (!(f->pin_force = calloc(n3 + 1, sizeof *f->pin_force))) goto oom;
        f->arrays[f->narrays++] = (vtk_array){"pin_force", 3, 0, f->pin_force, NULL};
    }
    if (which & SCENE_FIELD_ATTACHMENT_FORCES) {
        if (!(f->attachment_force = calloc(n3 + 1, sizeof *f->attachment_force))) goto oom;
        f->arrays[f->narrays++] = (vtk_array){"attachment_force", 3, 0, f->attachment_force, NULL};
    }
    /* The pinned flag is part of the model, not of the state: set once, written with every
     * frame of a scene that pins or drives anything. */
    if (pins) {
        if (!(f->pinned = calloc((size_t)f->nv + 1, 1))) goto oom;
        for (int32_t i = 0; i < s->nbodies; ++i) {
            const scene_body *b = &s->bodies[i];
            for (int32_t k = 0; k < b->npins; ++k) f->pinned[b->offset + b->pins[k]] = 1;
            for (int32_t d = 0; d < b->ndrives; ++d)
                for (int32_t k = 0; k < b->drives[d].n; ++k)
                    f->pinned[b->offset + b->drives[d].verts[k]] = 1;
        }
        f->arrays[f->narrays++] = (vtk_array){"pinned", 1, 0, NULL, f->pinned};
    }
    return 0;
oom:
    fields_free(f);
    snprintf(err, errsz, "fields: out of memory");
    return -1;
}

int fields_eval(fields *f, const scene *s, defsim_world *w, char *err, size_t errsz)
{
    defsim_status st = DEFSIM_OK;
    const char *what = "";
    if (f->which & SCENE_FIELD_STRESS)
        for (int32_t i = 0; i < s->nbodies && st == DEFSIM_OK; ++i) {
            const scene_body *b = &s->bodies[i];
            if (b->mesh.tet_count == 0) continue;
            const int64_t o = f->cell_offset[i];
            what = "element stress";
            st = defsim_body_element_stress(w, b->id, f->cauchy + 9 * o, f->von_mises + o,
                                            f->energy_density + o, b->mesh.tet_count);
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
    if (st == DEFSIM_OK && f->attachment_force) {
        what = "attachment forces";
        memset(f->attachment_force, 0, 3 * (size_t)f->nv * sizeof *f->attachment_force);
        for (int32_t i = 0; i < s->nattachments && st == DEFSIM_OK; ++i) {
            const scene_attachment *a = &s->attachments[i];
            double g[3];
            st = defsim_world_get_attachment_force(w, a->id, g);
            const int64_t v = (int64_t)s->bodies[a->body].offset + a->vertex;
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
    free(f->cell_offset); free(f->x0); free(f->cauchy); free(f->von_mises);
    free(f->energy_density); free(f->displacement); free(f->pin_force); free(f->attachment_force);
    free(f->pinned);
    memset(f, 0, sizeof *f);
}

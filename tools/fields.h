/* SPDX-License-Identifier: MIT */
/*
 * The fields of a frame beyond positions and velocities, evaluated from a world through its
 * public API alone (so that defsim run and libdefsim_scene's writer, which Python calls, write
 * the same arrays): per-tet Cauchy stress, von Mises stress and strain energy density (cell data,
 * in the cell order of the frame: each body's tets, triangles or lines in body order), and per
 * vertex the displacement from a reference, the pins' reaction forces, the attachment forces,
 * the contact forces (colliders and body contact) and the pinned flag (point data). Shared by
 * defsim run (VTK frames), the renderer (colours) and frame.c.
 */
#ifndef DEFSIM_TOOLS_FIELDS_H
#define DEFSIM_TOOLS_FIELDS_H

#include "scene.h"
#include "vtk.h"

#include <stddef.h>
#include <stdint.h>

typedef struct fields {
    int32_t nv;
    int64_t ncells;
    int32_t nbodies;
    unsigned which;          /* SCENE_FIELD_* evaluated (those requested that the world has) */
    int64_t *cell_offset;    /* first cell of each body (nbodies + 1) */
    int64_t *tet_count;      /* tet cells of each body */
    double *x0;              /* 3 nv: the reference of the displacement */
    double *cauchy;          /* 9 per cell (zero for triangles and lines), Pa */
    double *von_mises;       /* 1 per cell, Pa */
    double *energy_density;  /* 1 per cell, J/m^3 */
    double *displacement;    /* 3 nv, m */
    double *pin_force;       /* 3 nv, N: zero for free vertices */
    double *attachment_force;/* 3 nv, N: sum of the attachment forces on each vertex */
    double *contact_force;   /* 3 nv, N: colliders' and body contact's, of the last step */
    uint8_t *pinned;         /* nv: 1 for pinned and driven vertices (NULL: the world pins none) */
    vtk_array arrays[8];     /* what fields_eval fills, for vtk_write_vtu */
    int narrays;
} fields;

/* Sets up the fields `which` (SCENE_FIELD_*) for the world, whose bodies (in vertex order) are
 * the cells' body tags: each body's cells contiguous, in body order, its tets (if any) in the
 * order of the body's tets. The reference of the displacement is the world's positions now.
 * A field that the world cannot have (pin forces without pins, stress without tets, attachment
 * forces without attachments, contact forces without colliders or body contact) is left out;
 * the pinned flag comes with any pin. Returns 0, or -1 with err set. */
int fields_init(fields *f, defsim_world *w, const vtk_cells *c, unsigned which, char *err,
                size_t errsz);

/* Evaluates the fields at the world's current state. Returns 0, or -1 with err set. */
int fields_eval(fields *f, defsim_world *w, char *err, size_t errsz);

void fields_free(fields *f);

#endif

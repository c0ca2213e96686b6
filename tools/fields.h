/* SPDX-License-Identifier: MIT */
/*
 * The fields of a frame beyond positions and velocities, evaluated from a world built by
 * scene_build: per-tet Cauchy stress, von Mises stress and strain energy density (cell data, in
 * the cell order of the frame: each body's tets, triangles or lines in body order), and per
 * vertex the displacement from the initial state, the pins' reaction forces, the attachment
 * forces and the pinned flag (point data). Shared by defsim run (VTK frames) and the renderer (colours).
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
    unsigned which;          /* SCENE_FIELD_* evaluated (those requested that the scene has) */
    int64_t *cell_offset;    /* first cell of each body */
    double *x0;              /* 3 nv: initial positions */
    double *cauchy;          /* 9 per cell (zero for triangles and lines), Pa */
    double *von_mises;       /* 1 per cell, Pa */
    double *energy_density;  /* 1 per cell, J/m^3 */
    double *displacement;    /* 3 nv, m */
    double *pin_force;       /* 3 nv, N: zero for free vertices */
    double *attachment_force;/* 3 nv, N: sum of the attachment forces on each vertex */
    uint8_t *pinned;         /* nv: 1 for pinned and driven vertices (NULL: the scene pins none) */
    vtk_array arrays[7];     /* what fields_eval filled, for vtk_write_vtu */
    int narrays;
} fields;

/* Sets up the fields `which` (SCENE_FIELD_*) for the scene's world at its initial state (which
 * gives x0); a field that the scene cannot have (pin forces without pins, stress without tets,
 * attachment forces without attachments) is left out. Returns 0, or -1 with err set. */
int fields_init(fields *f, const scene *s, defsim_world *w, unsigned which, char *err, size_t errsz);

/* Evaluates the fields at the world's current state. Returns 0, or -1 with err set. */
int fields_eval(fields *f, const scene *s, defsim_world *w, char *err, size_t errsz);

void fields_free(fields *f);

#endif

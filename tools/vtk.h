/* SPDX-License-Identifier: MIT */
/*
 * VTK XML output that ParaView, VTK and meshio open: one .vtu (unstructured grid, appended data
 * in base64) per frame and a .pvd collection listing them with their times. The reader reads back the .vtu files
 * that vtk_write_vtu wrote (for defsim-render), not arbitrary VTK files.
 */
#ifndef DEFSIM_TOOLS_VTK_H
#define DEFSIM_TOOLS_VTK_H

#include <stddef.h>
#include <stdint.h>

enum { VTK_LINE = 3, VTK_TRIANGLE = 5, VTK_TETRA = 10, VTK_QUADRATIC_TETRA = 24 };

/* Vertices of a cell of VTK type t (its 4 corners first for a quadratic tet), 0 for others. */
static inline int vtk_cell_size(int t)
{
    return t == VTK_LINE ? 2 : t == VTK_TRIANGLE ? 3 : t == VTK_TETRA ? 4
           : t == VTK_QUADRATIC_TETRA ? 10 : 0;
}

/* A linear or quadratic tet. */
static inline int vtk_is_tet(int t) { return t == VTK_TETRA || t == VTK_QUADRATIC_TETRA; }

/* Cells of a frame: tets (linear or quadratic), triangles and lines, each tagged with its body. */
typedef struct vtk_cells {
    int64_t *conn;      /* vertex indices of all cells */
    int64_t *offsets;   /* end of each cell in conn (VTK's convention) */
    uint8_t *types;     /* VTK_* per cell */
    int32_t *body;      /* body index per cell */
    int64_t ncells, nconn;
    const char *tag;    /* name of the cell data `body` holds: NULL for "body" */
} vtk_cells;

/* A frame read back: positions, cells and the arrays the renderer can colour by. */
typedef struct vtk_frame {
    int32_t nv;
    double *x;          /* 3 nv */
    double time;
    vtk_cells cells;
    double *von_mises;      /* NULL, or one per cell (cell data "von_mises", Pa) */
    double *displacement;   /* NULL, or 3 nv (point data "displacement", m) */
    double *velocity;       /* NULL, or 3 nv (point data "velocity", m/s) */
    uint8_t *pinned;        /* NULL, or nv (point data "pinned": 1 pinned or driven, 0 free) */
    double *contact_force;  /* NULL, or 3 nv (point data "contact_force", N) */
} vtk_frame;

/* An extra data array of a frame: per point (`cell` 0, nv tuples) or per cell; Float64 from
 * `data`, or UInt8 from `u8` when that is set. */
typedef struct vtk_array {
    const char *name;
    int components;         /* 1, 3, 6 or 9 */
    int cell;
    const double *data;     /* components * tuples */
    const uint8_t *u8;      /* NULL, or components * tuples bytes (flags) */
} vtk_array;

/* Checks cells given as VTK's arrays: each type a line, triangle or tet (linear or quadratic), offsets that give it
 * its vertex count, vertex indices in [0, nv). *nconn receives the length of conn. Returns 0,
 * or -1 with the first fault in err. */
int vtk_check_cells(int32_t nv, int64_t ncells, const uint8_t *types, const int64_t *offsets,
                    const int64_t *conn, int64_t *nconn, char *err, size_t errsz);

/* Appends cells of one type (k vertices each, body-local indices + offset) for a body. */
int vtk_cells_add(vtk_cells *c, const int32_t *idx, int64_t n, int k, int32_t offset, uint8_t type,
                  int32_t body);
void vtk_cells_free(vtk_cells *c);

/* Writes a .vtu (atomically: a temporary file renamed into place). v may be NULL; `extra` adds
 * n_extra point or cell data arrays. Returns 0, or -1 with a message in err. */
int vtk_write_vtu(const char *path, int32_t nv, const double *x, const double *v,
                  const vtk_cells *c, double time, const vtk_array *extra, int n_extra,
                  char *err, size_t errsz);

/* Writes a .vtm multiblock (atomically) of n blocks: each a name and a file (relative to the
 * .vtm's folder). */
int vtk_write_vtm(const char *path, int n, const char *const *names, const char *const *files,
                  char *err, size_t errsz);

/* Writes a .pvd collection of n datasets (atomically). */
int vtk_write_pvd(const char *path, int n, const double *times, const char *const *files,
                  char *err, size_t errsz);

/* Reads a .vtu written by vtk_write_vtu (or by earlier versions, whose appended data was raw).
 * Returns 0, or -1 with a message in err. */
int vtk_read_vtu(const char *path, vtk_frame *out, char *err, size_t errsz);
void vtk_frame_free(vtk_frame *f);

/* Reads the file names (relative to the .pvd's folder, as written) and times of a .pvd.
 * *files and each name are malloc'd. Returns the count, or -1 with a message in err. */
int vtk_read_pvd(const char *path, char ***files, double **times, char *err, size_t errsz);

#endif

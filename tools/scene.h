/* SPDX-License-Identifier: MIT */
/*
 * Scene files (JSON, parsed with cJSON): world settings, bodies and output settings, turned into
 * a defsim world. Shared by the tools (defsim run / bench / stress, defsim-render); not part of
 * the library. The format is documented in tools/README.md.
 */
#ifndef DEFSIM_TOOLS_SCENE_H
#define DEFSIM_TOOLS_SCENE_H

#include <defsim/defsim.h>

#include <stddef.h>
#include <stdint.h>

/* Camera of the rendered frames: explicit (eye/target/up) or fitted to the scene. */
typedef struct scene_camera {
    int automatic;          /* 1: fit `fit_lo..fit_hi` (or the initial bounds) */
    double eye[3], target[3], up[3];
    double fov;             /* vertical field of view, degrees */
    double azimuth, elevation;   /* automatic: direction to the eye, degrees */
    double zoom;            /* automatic: > 1 moves closer */
    int has_fit;            /* fit_lo / fit_hi given */
    double fit_lo[3], fit_hi[3];
    int ground;             /* draw the ground grid */
    int has_ground_height;
    double ground_height;   /* along the up axis */
} scene_camera;

typedef struct scene_body {
    char name[64];
    int line;               /* of the body object in the scene file */
    defsim_mesh mesh;       /* rest positions after "transform" */
    double *initial;        /* NULL or 3 nv initial positions ("initial_transform") */
    double *velocity;       /* NULL or 3 nv initial velocities */
    double *spring_k;       /* NULL or one stiffness per spring */
    defsim_material material;
    int32_t *pins;
    int32_t npins;
    int32_t line_count;     /* springs drawn as lines (spring bodies without triangles) */
    float color[3];
    int32_t probe;          /* body-local vertex whose position is reported, or -1 */
    defsim_body_id id;      /* after scene_build */
    int32_t offset;         /* first vertex in the world, after scene_build */
} scene_body;

typedef struct scene {
    char path[1024];
    char name[256];         /* file name without directory and .json */
    defsim_world_def def;
    char backend[64];
    double h, duration;
    int32_t frame_steps;    /* steps per frame */
    int32_t frames;         /* frames after the initial state */
    int32_t every;          /* write every n-th frame */
    int write_vtk, write_png;
    int32_t width, height, supersample;
    int contact_sheet;
    scene_camera camera;
    struct cJSON *options;  /* world.options (a copy), applied by scene_build; or NULL */
    scene_body *bodies;
    int32_t nbodies;
    int32_t vertex_count;   /* sum over bodies */
    char error[4096];       /* "file:line:col: what" of the last failure */
} scene;

/* Reads and checks a scene file. `overrides` are "key.path=JSON" strings applied before the
 * checks (a value that is not JSON is taken as a string). Returns 0, or -1 with s->error set
 * (the scene is then freed). Relative mesh paths are taken from the scene file's folder. */
int scene_load(scene *s, const char *path, const char *const *overrides, int noverrides);

/* Creates the world, sets world.options (those of another backend than the world's are skipped
 * with a warning on stderr) and adds the bodies with their pins. Returns DEFSIM_OK or an error
 * with s->error naming the option or body (and the library's detail). */
defsim_status scene_build(scene *s, defsim_world **out);

void scene_free(scene *s);

/* The default colour of body i. */
void scene_palette(int i, float rgb[3]);

/* Bounds of the initial positions of all bodies. */
void scene_bounds(const scene *s, double lo[3], double hi[3]);

#endif

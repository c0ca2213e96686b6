/* SPDX-License-Identifier: MIT */
/*
 * The types of a scene file once read: world settings, bodies, coupling, colliders and output
 * settings. Their own header, so that the files that parse and build one section
 * (scene_coupling.c, scene_collider.c, scene_output.c) need only these and the JSON layer, and
 * scene.c, which loads and builds the whole scene, calls them (no call goes back to scene.c).
 */
#ifndef DEFSIM_TOOLS_SCENE_TYPES_H
#define DEFSIM_TOOLS_SCENE_TYPES_H

#include <defsim/defsim.h>

#include <stddef.h>
#include <stdint.h>

struct cJSON;

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

/* What the renderer colours bodies by. */
typedef enum scene_color {
    SCENE_COLOR_BODY = 0,          /* each body its colour */
    SCENE_COLOR_STRESS = 1,        /* von Mises stress per tet, Pa */
    SCENE_COLOR_DISPLACEMENT = 2,  /* |x - x(0)| per vertex, m */
    SCENE_COLOR_SPEED = 3          /* |v| per vertex, m/s */
} scene_color;

/* Fields of the VTK frames beyond positions, velocities and body (output.fields). */
enum {
    SCENE_FIELD_STRESS = 1,             /* cell data: cauchy_stress (9), von_mises, energy_density */
    SCENE_FIELD_DISPLACEMENT = 2,       /* point data: displacement */
    SCENE_FIELD_PIN_FORCES = 4,         /* point data: pin_force (reaction of each pin, N) */
    SCENE_FIELD_ATTACHMENT_FORCES = 8,  /* point data: attachment_force (N, on the vertex) */
    SCENE_FIELD_CONTACT_FORCES = 16     /* point data: contact_force (N, colliders and bodies) */
};

/* A keyframed rigid motion: keys (t, translation, rotation about an axis through a centre),
 * linear between keys in the translation, the rotation vector (axis x angle) and the centre;
 * held before the first key and after the last. */
typedef struct scene_path {
    int32_t n;
    double *key;            /* 10 per key: t, translation (3), rotation vector (3, rad), centre (3) */
} scene_path;

/* One entry of a body's "forces": a force on each selected vertex, or a total spread over them
 * in proportion to their masses. */
typedef struct scene_force {
    int32_t n;
    int32_t *verts;         /* body-local */
    double f[3];            /* N */
    int total;              /* 1: f is the total over the selection */
} scene_force;

/* Driven pins of a body: vertices that follow a path from where they start. */
typedef struct scene_drive {
    int32_t n;
    int32_t *verts;         /* body-local */
    double *anchor;         /* 3 n: their initial positions */
    double *target;         /* 3 n: scratch for the targets of the next step */
    scene_path path;
} scene_drive;

/* One attachment spring of the scene (a selection of k vertices makes k of them). */
typedef struct scene_attachment {
    int line;               /* of its object in the scene file */
    int32_t body, vertex;   /* scene body index, body-local vertex */
    double stiffness, damping;
    int32_t target_body;    /* -1: a world point */
    int32_t target_count;   /* target_body: 1..4 vertices and barycentric weights */
    int32_t target_vertices[4];
    double target_weights[4];
    double anchor[3];       /* world point at t = 0 */
    int32_t path;           /* -1: fixed; else index into scene.paths, moving anchor */
    defsim_attachment_id id;   /* after scene_build */
} scene_attachment;

/* A collider of the scene ("colliders"): its def (a mesh's arrays point into `mesh`) and, when
 * it moves, keyed poses (t, position, rotation w x y z) that scene_step follows. */
typedef struct scene_collider {
    int line;               /* of its object in the scene file */
    defsim_collider_def def;
    defsim_mesh mesh;       /* MESH: the loaded .obj */
    int normalized;         /* "normalized": rotations and normal used as given (bit for bit) */
    int32_t nkeys;          /* 0: it stays where it is */
    double *key;            /* 8 per key */
    defsim_collider_id id;  /* after scene_build */
} scene_collider;

typedef struct scene_body {
    char name[64];
    int line;               /* of the body object in the scene file */
    defsim_mesh mesh;       /* rest positions after "transform" */
    double *initial;        /* NULL or 3 nv initial positions ("initial_transform") */
    double *velocity;       /* NULL or 3 nv initial velocities */
    double *spring_k;       /* NULL or one stiffness per spring */
    double *masses;         /* NULL or one mass per vertex ("masses", kg) */
    int inline_mesh;        /* "mesh": {"type": "inline"}: springs and triangles given as they
                               are, with tets too (defsim_scene_export writes these) */
    defsim_material material;
    int32_t *pins;
    int32_t npins;
    int32_t line_count;     /* springs drawn as lines (spring bodies without triangles) */
    float color[3];
    int32_t probe;          /* body-local vertex whose position is reported, or -1 */
    defsim_body_id id;      /* after scene_build */
    int32_t offset;         /* first vertex in the world, after scene_build */
    struct scene_force *forces;   /* "forces": resolved into N per vertex by scene_build */
    int32_t nforces;
    scene_drive *drives;    /* "drive": keyframed pins */
    int32_t ndrives;
    double shear_k, bend_k; /* material.shear_stiffness, bending_stiffness; -1: not given */
    /* body contact (docs/body-contact.md): as in defsim_body_def */
    int self_contact;
    uint32_t collision_group, collision_mask;
    double friction;
    double contact_thickness;   /* "contact_thickness": defsim_body_def.contact_thickness (m) */
    int volume_averaging;   /* "volume_averaging": defsim_body_def.volume_averaging */
    /* "shell" (docs/shells.md): the body's shell_* fields (a def holding only them), or none */
    int has_shell;
    defsim_body_def shell;
} scene_body;

/* What a scene file may ask for at most, checked by scene_load before anything large is made
 * (docs/limits.md): a scene past a limit is refused with a message that names the option that
 * raises it (defsim run --max-vertices, --max-steps). */
typedef struct scene_limits {
    int64_t max_vertices;   /* over all bodies; default SCENE_MAX_VERTICES */
    int64_t max_steps;      /* time steps of the whole run (frames x steps per frame);
                               default SCENE_MAX_STEPS */
} scene_limits;
#define SCENE_MAX_VERTICES 2000000
#define SCENE_MAX_STEPS 10000000

/* Backend settings that a scene's "world" object gives by key ("tolerance": 1e-8), the names of
 * options of the world's backend; scene_setting names them in this order. */
enum {
    SCENE_TOLERANCE, SCENE_MAX_ITERATIONS, SCENE_RTOL, SCENE_ATOL, SCENE_PROJECTION,
    SCENE_MAX_ORDER, SCENE_MAX_INTERNAL_STEPS, SCENE_SETTINGS
};

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
    double settings[SCENE_SETTINGS];   /* world.tolerance ... (PROJECTION: a defsim_projection) */
    uint8_t settings_given[SCENE_SETTINGS];   /* the scene (or a tool) gave the setting */
    scene_body *bodies;
    int32_t nbodies;
    scene_attachment *attachments;
    int32_t nattachments;
    scene_path *paths;      /* the attachments' paths (each selection shares one) */
    int32_t npaths;
    int color;              /* scene_color of rendered frames */
    int has_color_range;
    double color_range[2];  /* fixed colour scale (Pa or m); else each frame 0 .. its maximum */
    unsigned fields;        /* SCENE_FIELD_* written into VTK frames */
    int contact_arrows;     /* rendered frames draw the contact forces as arrows */
    double arrow_scale;     /* m per N of those arrows; 0: the largest is 25 % of the scene */
    scene_collider *colliders;
    int32_t ncolliders;
    int32_t vertex_count;   /* sum over bodies */
    scene_limits limits;    /* those scene_load checked */
    char error[4096];       /* "file:line:col: what" of the last failure */
    int io_failure;         /* the failure was a file that cannot be read (the scene file, a
                               mesh file): DEFSIM_ERR_IO for libdefsim_scene */
} scene;

#endif

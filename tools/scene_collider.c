/* SPDX-License-Identifier: MIT */
/*
 * Scene files: the "colliders" array (shapes the scene places and may move along keyed poses),
 * building them into a world and setting their poses before each step. The format is in
 * tools/README.md, section "Colliders".
 */
#include "scene_collider.h"

#include "scene_json.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { KEY = 8 };   /* t, position (3), rotation (4: w x y z) */

static const char *const shape_names[] = {"plane", "sphere", "box", "capsule", "mesh", NULL};

/* Rotations about the world x, then y, then z axes (degrees) as a unit quaternion. */
static void euler_quat(const double deg[3], double q[4])
{
    double h[3], c[3], s[3];
    for (int k = 0; k < 3; ++k) {
        h[k] = 0.5 * deg[k] * 3.14159265358979323846 / 180.0;
        c[k] = cos(h[k]);
        s[k] = sin(h[k]);
    }
    /* q = qz qy qx */
    q[0] = c[2] * c[1] * c[0] + s[2] * s[1] * s[0];
    q[1] = c[2] * c[1] * s[0] - s[2] * s[1] * c[0];
    q[2] = c[2] * s[1] * c[0] + s[2] * c[1] * s[0];
    q[3] = s[2] * c[1] * c[0] - c[2] * s[1] * s[0];
}

/* "rotation" (w x y z, normalised here so that rounded numbers in a file are accepted, unless
 * `exact`: the collider's "normalized") or "euler_deg" of obj into q; q is left as is when
 * neither is given. */
static int parse_rotation(sj_ctx *c, const cJSON *obj, const char *what, int exact, double q[4])
{
    const cJSON *r = cJSON_GetObjectItemCaseSensitive(obj, "rotation");
    const cJSON *e = cJSON_GetObjectItemCaseSensitive(obj, "euler_deg");
    char w[300];
    if (r && e) return sj_fail(c, e, "%s: give rotation or euler_deg, not both", what);
    if (r) {
        snprintf(w, sizeof w, "%s.rotation", what);
        double v[4];
        if (sj_vec(c, r, w, 4, v)) return -1;
        const double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
        if (!(n > 0.0)) return sj_fail(c, r, "%s must not be zero", w);
        for (int k = 0; k < 4; ++k) q[k] = exact ? v[k] : v[k] / n;
    } else if (e) {
        snprintf(w, sizeof w, "%s.euler_deg", what);
        double v[3];
        if (sj_vec(c, e, w, 3, v)) return -1;
        euler_quat(v, q);
    }
    return 0;
}

static int parse_path(sj_ctx *c, const cJSON *j, const char *what, scene_collider *col)
{
    if (!cJSON_IsArray(j) || cJSON_GetArraySize(j) < 1)
        return sj_fail(c, j, "%s must be a non-empty array of {\"t\", \"position\", \"rotation\"}",
                       what);
    const int n = cJSON_GetArraySize(j);
    col->key = calloc((size_t)n * KEY, sizeof *col->key);
    if (!col->key) return sj_fail(c, j, "out of memory");
    char w[240];
    for (const cJSON *k = j->child; k; k = k->next) {
        snprintf(w, sizeof w, "%s[%d]", what, (int)col->nkeys);
        static const char *const keys[] = {"t", "position", "rotation", "euler_deg", NULL};
        double *q = col->key + KEY * col->nkeys;
        /* a key gives what changes: the rest is the collider's own pose */
        memcpy(q + 1, col->def.position, 3 * sizeof *q);
        memcpy(q + 4, col->def.rotation, 4 * sizeof *q);
        if (sj_keys(c, k, w, keys) || !sj_require(c, k, "t", w) ||
            sj_number(c, k, "t", w, -1e300, 1e300, 0, &q[0]) ||
            sj_vec3(c, k, "position", w, q + 1) || parse_rotation(c, k, w, col->normalized, q + 4))
            return -1;
        if (col->nkeys > 0 && !(q[0] > q[-KEY]))
            return sj_fail(c, cJSON_GetObjectItemCaseSensitive(k, "t"),
                           "%s.t = %g: key times must increase", w, q[0]);
        ++col->nkeys;
    }
    return 0;
}

static int parse_collider(sj_ctx *c, const cJSON *j, int index, scene_collider *col)
{
    char w[64];
    snprintf(w, sizeof w, "colliders[%d]", index);
    col->line = sj_node_line(c, j);
    defsim_collider_def_init(&col->def, sizeof col->def);
    if (!cJSON_IsObject(j)) return sj_fail(c, j, "%s must be an object", w);
    const cJSON *sh = sj_require(c, j, "shape", w);
    if (!sh) return -1;
    if (!cJSON_IsString(sh)) return sj_fail(c, sh, "%s.shape must be a string", w);
    int shape = -1;
    for (int k = 0; shape_names[k]; ++k)
        if (!strcmp(sh->valuestring, shape_names[k])) shape = k;
    if (shape < 0)
        return sj_fail(c, sh, "%s.shape \"%s\" is unknown (known: plane, sphere, box, capsule, "
                       "mesh)", w, sh->valuestring);
    col->def.shape = (defsim_shape)shape;
    /* the keys of this shape only: a "radius" on a box is a mistake worth reporting */
    static const char *const common[] = {"shape", "position", "rotation", "euler_deg", "friction",
                                         "path", "normalized"};
    static const char *const own[][3] = {{"normal"}, {"radius"}, {"half_extents"},
                                         {"radius", "half_height"},
                                         {"mesh", "vertices", "triangles"}};
    const char *keys[12];
    int nk = 0;
    for (int k = 0; k < 7; ++k) keys[nk++] = common[k];
    for (int k = 0; k < 3 && own[shape][k]; ++k) keys[nk++] = own[shape][k];
    keys[nk] = NULL;
    if (sj_keys(c, j, w, keys)) return -1;
    /* values are checked by the library when scene_build adds the collider */
    if (sj_bool(c, j, "normalized", w, &col->normalized) ||
        sj_vec3(c, j, "position", w, col->def.position) ||
        parse_rotation(c, j, w, col->normalized, col->def.rotation) ||
        sj_number(c, j, "friction", w, -1e300, 1e300, 0, &col->def.friction) ||
        sj_vec3(c, j, "normal", w, col->def.normal) ||
        sj_number(c, j, "radius", w, -1e300, 1e300, 0, &col->def.radius) ||
        sj_vec3(c, j, "half_extents", w, col->def.half_extents) ||
        sj_number(c, j, "half_height", w, -1e300, 1e300, 0, &col->def.half_height))
        return -1;
    const cJSON *inl = cJSON_GetObjectItemCaseSensitive(j, "vertices");
    if (shape == DEFSIM_SHAPE_MESH && (inl || cJSON_GetObjectItemCaseSensitive(j, "triangles"))) {
        /* The mesh itself (what defsim_scene_export writes); the library checks it. */
        const cJSON *tj = sj_require(c, j, "triangles", w);
        char wa[100];
        snprintf(wa, sizeof wa, "%s.vertices", w);
        if (!tj || !sj_require(c, j, "vertices", w)) return -1;
        if (cJSON_GetObjectItemCaseSensitive(j, "mesh"))
            return sj_fail(c, j, "%s: give \"mesh\" (a file) or \"vertices\" and "
                           "\"triangles\", not both", w);
        col->mesh.size = sizeof col->mesh;
        if (sj_doubles(c, inl, wa, 3, &col->mesh.positions, &col->mesh.vertex_count))
            return -1;
        snprintf(wa, sizeof wa, "%s.triangles", w);
        if (sj_ints(c, tj, wa, 3, 0, col->mesh.vertex_count - 1, &col->mesh.triangles,
                    &col->mesh.triangle_count))
            return -1;
        col->def.vertices = col->mesh.positions;
        col->def.vertex_count = col->mesh.vertex_count;
        col->def.triangles = col->mesh.triangles;
        col->def.triangle_count = col->mesh.triangle_count;
    } else if (shape == DEFSIM_SHAPE_MESH) {
        const cJSON *m = sj_require(c, j, "mesh", w);
        if (!m) return -1;
        if (!cJSON_IsString(m)) return sj_fail(c, m, "%s.mesh must be a file name (.obj)", w);
        char full[2200];
        if (m->valuestring[0] == '/') snprintf(full, sizeof full, "%s", m->valuestring);
        else snprintf(full, sizeof full, "%s%s", c->dir, m->valuestring);
        col->mesh.size = sizeof col->mesh;
        const defsim_status st = defsim_mesh_load(full, &col->mesh);
        c->s->io_failure = st == DEFSIM_ERR_IO;
        if (st != DEFSIM_OK)
            return sj_fail(c, m, "%s.mesh: %s: %s", w, defsim_status_string(st), defsim_last_error());
        if (col->mesh.triangle_count < 1)
            return sj_fail(c, m, "%s.mesh: \"%s\" has no triangles", w, m->valuestring);
        col->def.vertices = col->mesh.positions;
        col->def.vertex_count = col->mesh.vertex_count;
        col->def.triangles = col->mesh.triangles;
        col->def.triangle_count = col->mesh.triangle_count;
    }
    const cJSON *path = cJSON_GetObjectItemCaseSensitive(j, "path");
    char wp[80];
    snprintf(wp, sizeof wp, "%s.path", w);
    return path ? parse_path(c, path, wp, col) : 0;
}

int scene_parse_colliders(sj_ctx *c, const cJSON *j)
{
    scene *s = c->s;
    if (!cJSON_IsArray(j)) return sj_fail(c, j, "colliders must be an array");
    const int n = cJSON_GetArraySize(j);
    s->colliders = calloc((size_t)(n > 0 ? n : 1), sizeof *s->colliders);
    if (!s->colliders) return sj_fail(c, j, "out of memory");
    int i = 0;
    for (const cJSON *e = j->child; e; e = e->next, ++i) {
        s->ncolliders = i + 1;   /* so that scene_free releases what this one has so far */
        if (parse_collider(c, e, i, &s->colliders[i])) return -1;
    }
    return 0;
}

/* The pose of a collider's path at time t: position linear between keys, rotation along the
 * shortest arc at constant angular velocity; held before the first key and after the last. */
void scene_collider_pose(const scene_collider *col, double t, double p[3], double q[4])
{
    const double *k = col->key;
    const int32_t n = col->nkeys;
    if (t <= k[0] || n == 1) {
        memcpy(p, k + 1, 3 * sizeof *p);
        memcpy(q, k + 4, 4 * sizeof *q);
        return;
    }
    if (t >= k[KEY * (n - 1)]) {
        memcpy(p, k + KEY * (n - 1) + 1, 3 * sizeof *p);
        memcpy(q, k + KEY * (n - 1) + 4, 4 * sizeof *q);
        return;
    }
    int32_t i = 0;
    while (t > k[KEY * (i + 1)]) ++i;
    const double *a = k + KEY * i, *b = a + KEY, s = (t - a[0]) / (b[0] - a[0]);
    for (int m = 0; m < 3; ++m) p[m] = a[1 + m] + s * (b[1 + m] - a[1 + m]);
    double cosang = 0.0;
    for (int m = 0; m < 4; ++m) cosang += a[4 + m] * b[4 + m];
    const double flip = cosang < 0.0 ? -1.0 : 1.0;
    cosang = fmin(1.0, cosang * flip);
    const double ang = acos(cosang);
    double wa = 1.0 - s, wb = s;
    if (ang > 1e-9) {
        wa = sin((1.0 - s) * ang) / sin(ang);
        wb = sin(s * ang) / sin(ang);
    }
    double n2 = 0.0;
    for (int m = 0; m < 4; ++m) {
        q[m] = wa * a[4 + m] + flip * wb * b[4 + m];
        n2 += q[m] * q[m];
    }
    for (int m = 0; m < 4; ++m) q[m] /= sqrt(n2);
}

defsim_status scene_build_colliders(scene *s, defsim_world *w)
{
    for (int32_t i = 0; i < s->ncolliders; ++i) {
        scene_collider *col = &s->colliders[i];
        defsim_collider_def d = col->def;
        /* "normalized": the values as given; a path's poses are normalised by the library, as
         * defsim_collider_set_pose does at every step */
        d.normalized = col->nkeys == 0 && col->normalized;
        if (col->nkeys > 0) scene_collider_pose(col, defsim_world_time(w), d.position, d.rotation);
        const defsim_status st = defsim_world_add_collider(w, &d, &col->id);
        if (st != DEFSIM_OK) {
            snprintf(s->error, sizeof s->error, "%s:%d: colliders[%d]: %s: %s", s->path,
                     col->line, (int)i, defsim_status_string(st), defsim_world_last_error(w));
            return st;
        }
    }
    return DEFSIM_OK;
}

defsim_status scene_move_colliders(scene *s, defsim_world *w, double t)
{
    for (int32_t i = 0; i < s->ncolliders; ++i) {
        const scene_collider *col = &s->colliders[i];
        if (col->nkeys == 0) continue;
        double p[3], q[4];
        scene_collider_pose(col, t, p, q);
        const defsim_status st = defsim_collider_set_pose(w, col->id, p, q);
        if (st != DEFSIM_OK) return st;
    }
    return DEFSIM_OK;
}

void scene_free_colliders(scene *s)
{
    for (int32_t i = 0; i < s->ncolliders; ++i) {
        defsim_mesh_free(&s->colliders[i].mesh);
        free(s->colliders[i].key);
    }
    free(s->colliders);
    s->colliders = NULL;
    s->ncolliders = 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Drawing */

enum { SEG = 24, RINGS = 13 };   /* odd: no ring on a capsule's equator, which the cylinder spans */

int scene_collider_surface(const scene_collider *col, double **x, int32_t *nv, int32_t **tri,
                           int32_t *nt, int *smooth)
{
    const defsim_collider_def *d = &col->def;
    *x = NULL;
    *tri = NULL;
    *nv = *nt = 0;
    *smooth = 0;
    switch (d->shape) {
    case DEFSIM_SHAPE_SPHERE:
    case DEFSIM_SHAPE_CAPSULE: {
        const double hh = d->shape == DEFSIM_SHAPE_CAPSULE ? d->half_height : 0.0;
        *nv = 2 + SEG * (RINGS - 1);
        *nt = 2 * SEG * (RINGS - 1);
        *x = malloc(3 * (size_t)*nv * sizeof **x);
        *tri = malloc(3 * (size_t)*nt * sizeof **tri);
        if (!*x || !*tri) break;
        double *p = *x;
        p[0] = 0; p[1] = d->radius + hh; p[2] = 0;
        p[3] = 0; p[4] = -d->radius - hh; p[5] = 0;
        for (int i = 1; i < RINGS; ++i)
            for (int j = 0; j < SEG; ++j) {
                const double th = 3.14159265358979323846 * i / RINGS;
                const double ph = 2.0 * 3.14159265358979323846 * j / SEG;
                double *q = p + 3 * (2 + (i - 1) * SEG + j);
                q[0] = d->radius * sin(th) * cos(ph);
                q[1] = d->radius * cos(th) + (2 * i < RINGS ? hh : -hh);
                q[2] = -d->radius * sin(th) * sin(ph);
            }
        int32_t *t = *tri;
        for (int j = 0; j < SEG; ++j) {
            const int32_t a = 2 + j, b = 2 + (j + 1) % SEG;
            const int32_t c = 2 + (RINGS - 2) * SEG + j, e = 2 + (RINGS - 2) * SEG + (j + 1) % SEG;
            *t++ = 0; *t++ = a; *t++ = b;
            *t++ = 1; *t++ = e; *t++ = c;
        }
        for (int i = 1; i < RINGS - 1; ++i)
            for (int j = 0; j < SEG; ++j) {
                const int32_t a = 2 + (i - 1) * SEG + j, b = 2 + (i - 1) * SEG + (j + 1) % SEG;
                *t++ = a; *t++ = a + SEG; *t++ = b + SEG;
                *t++ = a; *t++ = b + SEG; *t++ = b;
            }
        *smooth = 1;
        return 0;
    }
    case DEFSIM_SHAPE_BOX: {
        static const int32_t T[36] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                      2, 3, 7, 2, 7, 6, 1, 2, 6, 1, 6, 5, 0, 4, 7, 0, 7, 3};
        *nv = 8;
        *nt = 12;
        *x = malloc(24 * sizeof **x);
        *tri = malloc(sizeof T);
        if (!*x || !*tri) break;
        for (int i = 0; i < 8; ++i) {
            /* corners 0-3 at -z, 4-7 at +z; T's triangles are counter-clockwise from outside */
            const int sx = (i & 3) == 1 || (i & 3) == 2, sy = (i & 3) >= 2, sz = i >= 4;
            (*x)[3 * i] = sx ? d->half_extents[0] : -d->half_extents[0];
            (*x)[3 * i + 1] = sy ? d->half_extents[1] : -d->half_extents[1];
            (*x)[3 * i + 2] = sz ? d->half_extents[2] : -d->half_extents[2];
        }
        memcpy(*tri, T, sizeof T);
        return 0;
    }
    case DEFSIM_SHAPE_MESH:
        *nv = d->vertex_count;
        *nt = d->triangle_count;
        *x = malloc(3 * (size_t)*nv * sizeof **x);
        *tri = malloc(3 * (size_t)*nt * sizeof **tri);
        if (!*x || !*tri) break;
        memcpy(*x, d->vertices, 3 * (size_t)*nv * sizeof **x);
        memcpy(*tri, d->triangles, 3 * (size_t)*nt * sizeof **tri);
        return 0;
    case DEFSIM_SHAPE_PLANE:
    case DEFSIM_SHAPE_SDF:
        return 0;
    }
    free(*x);
    free(*tri);
    *x = NULL;
    *tri = NULL;
    *nv = *nt = 0;
    return -1;
}

void scene_collider_place(const scene_collider *col, double t, const double *local, int32_t nv,
                          double *out)
{
    double p[3], q[4];
    if (col->nkeys > 0) {
        scene_collider_pose(col, t, p, q);
    } else {
        memcpy(p, col->def.position, sizeof p);
        memcpy(q, col->def.rotation, sizeof q);
    }
    const double w = q[0], x = q[1], y = q[2], z = q[3];
    const double R[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                         2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                         2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)};
    for (int32_t v = 0; v < nv; ++v) {
        const double *l = local + 3 * (int64_t)v;
        for (int r = 0; r < 3; ++r)
            out[3 * (int64_t)v + r] = p[r] + R[3 * r] * l[0] + R[3 * r + 1] * l[1] + R[3 * r + 2] * l[2];
    }
}

void scene_across(const double n[3], double t1[3], double t2[3])
{
    const double ref[3] = {fabs(n[0]) < 0.9 ? 1.0 : 0.0, fabs(n[0]) < 0.9 ? 0.0 : 1.0, 0.0};
    t1[0] = n[1] * ref[2] - n[2] * ref[1];
    t1[1] = n[2] * ref[0] - n[0] * ref[2];
    t1[2] = n[0] * ref[1] - n[1] * ref[0];
    const double l1 = sqrt(t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2]);
    for (int i = 0; i < 3; ++i) t1[i] /= l1;
    t2[0] = n[1] * t1[2] - n[2] * t1[1];
    t2[1] = n[2] * t1[0] - n[0] * t1[2];
    t2[2] = n[0] * t1[1] - n[1] * t1[0];
}

void scene_quat_rotate(const double q[4], const double v[3], double out[3])
{
    /* v + 2 w (u x v) + 2 u x (u x v), u the vector part of the unit quaternion. */
    const double *u = q + 1, w = q[0];
    const double t[3] = {2.0 * (u[1] * v[2] - u[2] * v[1]), 2.0 * (u[2] * v[0] - u[0] * v[2]),
                         2.0 * (u[0] * v[1] - u[1] * v[0])};
    out[0] = v[0] + w * t[0] + (u[1] * t[2] - u[2] * t[1]);
    out[1] = v[1] + w * t[1] + (u[2] * t[0] - u[0] * t[2]);
    out[2] = v[2] + w * t[2] + (u[0] * t[1] - u[1] * t[0]);
}

/* Local point p of the collider in world coordinates. */
static void to_world(const defsim_collider_def *d, const double p[3], double out[3])
{
    scene_quat_rotate(d->rotation, p, out);
    for (int i = 0; i < 3; ++i) out[i] += d->position[i];
}

/* The plane's square: corners q +- half t1 +- half t2 about q, the point of the plane nearest
 * centre, with t1, t2 unit tangents. 0 points for a zero normal. */
static int plane_square(const defsim_collider_def *d, const double centre[3], double half,
                        scene_geometry *g)
{
    double n[3], t1[3], t2[3], q[3];
    scene_quat_rotate(d->rotation, d->normal, n);
    const double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(len > 0.0)) return 0;
    for (int i = 0; i < 3; ++i) n[i] /= len;
    scene_across(n, t1, t2);
    double dist = 0.0;
    for (int i = 0; i < 3; ++i) dist += (centre[i] - d->position[i]) * n[i];
    for (int i = 0; i < 3; ++i) q[i] = centre[i] - dist * n[i];
    g->x = malloc(12 * sizeof *g->x);
    g->tri = malloc(6 * sizeof *g->tri);
    if (!g->x || !g->tri) return -1;
    for (int a = 0; a < 4; ++a) {
        const double s1 = a == 1 || a == 2 ? half : -half, s2 = a >= 2 ? half : -half;
        for (int i = 0; i < 3; ++i) g->x[3 * a + i] = q[i] + s1 * t1[i] + s2 * t2[i];
    }
    /* (t1, t2, n) is right-handed: 0 1 2 and 0 2 3 face along n, out of the half-space. */
    static const int32_t T[6] = {0, 1, 2, 0, 2, 3};
    memcpy(g->tri, T, sizeof T);
    g->nv = 4;
    g->nt = 2;
    g->smooth = 1;
    return 0;
}

/* The 12 edges of the SDF's bounds box (the distance field itself has no surface to sample
 * without a mesher). */
static int sdf_box(const defsim_collider_def *d, scene_geometry *g)
{
    const double *b = d->sdf_bounds;
    if (!(b[3] > b[0] && b[4] > b[1] && b[5] > b[2])) return 0;
    g->x = malloc(24 * sizeof *g->x);
    g->lines = malloc(24 * sizeof *g->lines);
    if (!g->x || !g->lines) return -1;
    for (int k = 0; k < 8; ++k) {
        const double local[3] = {b[k & 1 ? 3 : 0], b[k & 2 ? 4 : 1], b[k & 4 ? 5 : 2]};
        to_world(d, local, g->x + 3 * k);
    }
    for (int k = 0; k < 8; ++k)
        for (int axis = 0; axis < 3; ++axis)
            if (!(k & (1 << axis))) {
                g->lines[2 * g->nl] = k;
                g->lines[2 * g->nl + 1] = k | (1 << axis);
                ++g->nl;
            }
    g->nv = 8;
    return 0;
}

int scene_geometry_make(const defsim_collider_def *d, const double centre[3], double half,
                        scene_geometry *g)
{
    memset(g, 0, sizeof *g);
    int rc = 0;
    if (d->shape == DEFSIM_SHAPE_PLANE) {
        rc = plane_square(d, centre, half, g);
    } else if (d->shape == DEFSIM_SHAPE_SDF) {
        rc = sdf_box(d, g);
    } else {
        scene_collider sc;
        memset(&sc, 0, sizeof sc);
        sc.def = *d;
        double *local = NULL;
        rc = scene_collider_surface(&sc, &local, &g->nv, &g->tri, &g->nt, &g->smooth);
        g->x = rc ? NULL : malloc(3 * (size_t)(g->nv + 1) * sizeof *g->x);
        if (!rc && !g->x) rc = -1;
        for (int32_t k = 0; !rc && k < g->nv; ++k)
            to_world(d, local + 3 * (int64_t)k, g->x + 3 * (int64_t)k);
        free(local);
    }
    if (rc) scene_geometry_free(g);
    return rc;
}

void scene_geometry_free(scene_geometry *g)
{
    free(g->x);
    free(g->tri);
    free(g->lines);
    memset(g, 0, sizeof *g);
}

/* SPDX-License-Identifier: MIT */
/*
 * Scene files: what couples a scene to the outside: external forces on bodies, driven pins that
 * follow keyframed paths, and attachment springs to world points or to other bodies; building
 * them into a world and moving them along their paths step by step.
 *
 * Contents: paths; forces; drives; attachments; build, step, free.
 */
#include "scene_coupling.h"

#include "scene_collider.h"
#include "scene_json.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* Paths */

enum { KEY = 10 };   /* t, translation (3), rotation vector (3), centre (3) */

static int parse_path(sj_ctx *c, const cJSON *j, const char *what, scene_path *out)
{
    out->n = 0;
    out->key = NULL;
    if (!cJSON_IsArray(j) || cJSON_GetArraySize(j) < 1)
        return sj_fail(c, j, "%s must be a non-empty array of {\"t\", \"translate\", \"rotate\"}",
                       what);
    const int n = cJSON_GetArraySize(j);
    out->key = calloc((size_t)n * KEY, sizeof *out->key);
    if (!out->key) return sj_fail(c, j, "out of memory");
    char w[240];
    for (const cJSON *k = j->child; k; k = k->next) {
        snprintf(w, sizeof w, "%s[%d]", what, (int)out->n);
        static const char *const keys[] = {"t", "translate", "rotate", NULL};
        double *q = out->key + KEY * out->n;
        if (sj_keys(c, k, w, keys) || !sj_require(c, k, "t", w) ||
            sj_number(c, k, "t", w, -1e300, 1e300, 0, &q[0]) || sj_vec3(c, k, "translate", w, q + 1))
            return -1;
        if (out->n > 0 && !(q[0] > q[-KEY]))
            return sj_fail(c, cJSON_GetObjectItemCaseSensitive(k, "t"),
                           "%s.t = %g: key times must increase", w, q[0]);
        const cJSON *rot = cJSON_GetObjectItemCaseSensitive(k, "rotate");
        if (rot) {
            static const char *const rkeys[] = {"axis", "degrees", "center", "vector", NULL};
            char wr[260];
            snprintf(wr, sizeof wr, "%s.rotate", w);
            double axis[3] = {0, 0, 1}, deg = 0.0;
            const cJSON *vec = cJSON_GetObjectItemCaseSensitive(rot, "vector");
            if (vec) {
                /* The rotation vector itself (axis times angle, rad), as defsim_scene_export
                 * writes it: the keys' exact values. */
                if (sj_keys(c, rot, wr, rkeys) || sj_vec3(c, rot, "vector", wr, q + 4) ||
                    sj_vec3(c, rot, "center", wr, q + 7))
                    return -1;
                if (cJSON_GetObjectItemCaseSensitive(rot, "axis") ||
                    cJSON_GetObjectItemCaseSensitive(rot, "degrees"))
                    return sj_fail(c, vec, "%s: give vector, or axis and degrees", wr);
                ++out->n;
                continue;
            }
            if (sj_keys(c, rot, wr, rkeys) || !sj_require(c, rot, "axis", wr) ||
                !sj_require(c, rot, "degrees", wr) || sj_vec3(c, rot, "axis", wr, axis) ||
                sj_number(c, rot, "degrees", wr, -1e6, 1e6, 0, &deg) ||
                sj_vec3(c, rot, "center", wr, q + 7))
                return -1;
            const double l = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
            if (!(l > 0.0)) return sj_fail(c, rot, "%s.axis must not be zero", wr);
            for (int i = 0; i < 3; ++i) q[4 + i] = axis[i] / l * deg * 3.14159265358979323846 / 180.0;
        }
        ++out->n;
    }
    return 0;
}

/* p' = centre + R (p - centre) + translation, for the path at time t. */
static void path_apply(const scene_path *path, double t, const double *in, double *out, int32_t n)
{
    double q[KEY];
    const double *k = path->key;
    if (t <= k[0]) memcpy(q, k, sizeof q);
    else if (t >= k[KEY * (path->n - 1)]) memcpy(q, k + KEY * (path->n - 1), sizeof q);
    else {
        int32_t i = 0;
        while (t > k[KEY * (i + 1)]) ++i;
        const double *a = k + KEY * i, *b = a + KEY, s = (t - a[0]) / (b[0] - a[0]);
        for (int m = 0; m < KEY; ++m) q[m] = a[m] + s * (b[m] - a[m]);
    }
    /* Rodrigues: R = I + sin(a) K + (1 - cos(a)) K^2 for the unit axis' cross-product matrix K. */
    const double ang = sqrt(q[4] * q[4] + q[5] * q[5] + q[6] * q[6]);
    double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    if (ang > 0.0) {
        const double x = q[4] / ang, y = q[5] / ang, z = q[6] / ang;
        const double co = cos(ang), si = sin(ang), u = 1.0 - co;
        const double Rr[9] = {co + x * x * u, x * y * u - z * si, x * z * u + y * si,
                              y * x * u + z * si, co + y * y * u, y * z * u - x * si,
                              z * x * u - y * si, z * y * u + x * si, co + z * z * u};
        memcpy(R, Rr, sizeof R);
    }
    for (int32_t v = 0; v < n; ++v) {
        const double d[3] = {in[3 * v] - q[7], in[3 * v + 1] - q[8], in[3 * v + 2] - q[9]};
        for (int r = 0; r < 3; ++r)
            out[3 * v + r] = q[7 + r] + q[1 + r] + R[3 * r] * d[0] + R[3 * r + 1] * d[1] +
                             R[3 * r + 2] * d[2];
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Forces */

/* Selected vertices of `j` (keys "indices" and "box"; neither: every vertex). */
static int selection(sj_ctx *c, const cJSON *j, const char *what, const scene_body *b, double tol,
                     int32_t **out, int32_t *n)
{
    const int32_t nv = b->mesh.vertex_count;
    uint8_t *mark = calloc((size_t)nv, 1);
    if (!mark) return sj_fail(c, j, "out of memory");
    const cJSON *ind = cJSON_GetObjectItemCaseSensitive(j, "indices");
    const cJSON *box = cJSON_GetObjectItemCaseSensitive(j, "box");
    if (!ind && !box) memset(mark, 1, (size_t)nv);
    const int rc = sj_select(c, ind, box, what, b->mesh.positions, nv, tol, mark) ||
                   sj_marked(c, j, mark, nv, out, n);
    free(mark);
    if (rc) return -1;
    if (*n == 0) return sj_fail(c, j, "%s selects no vertex", what);
    return 0;
}

/* An object, or an array of objects: the i-th one. */
static int count_entries(const cJSON *j) { return cJSON_IsArray(j) ? cJSON_GetArraySize(j) : 1; }

int scene_parse_forces(sj_ctx *c, const cJSON *j, const char *what, scene_body *b, double tol)
{
    const int n = count_entries(j);
    b->forces = calloc((size_t)(n > 0 ? n : 1), sizeof *b->forces);
    if (!b->forces) return sj_fail(c, j, "out of memory");
    const cJSON *e = cJSON_IsArray(j) ? j->child : j;
    for (int i = 0; e; e = cJSON_IsArray(j) ? e->next : NULL, ++i) {
        char w[240];
        snprintf(w, sizeof w, cJSON_IsArray(j) ? "%s.forces[%d]" : "%s.forces", what, i);
        static const char *const keys[] = {"per_vertex", "total", "indices", "box", NULL};
        if (!cJSON_IsObject(e))
            return sj_fail(c, e, "%s must be an object with \"per_vertex\" or \"total\"", w);
        if (sj_keys(c, e, w, keys)) return -1;
        scene_force *f = &b->forces[i];
        const cJSON *pv = cJSON_GetObjectItemCaseSensitive(e, "per_vertex");
        const cJSON *tot = cJSON_GetObjectItemCaseSensitive(e, "total");
        if (!pv == !tot) return sj_fail(c, e, "%s: give \"per_vertex\" or \"total\" (N), one of them", w);
        f->total = tot != NULL;
        if (sj_vec3(c, e, tot ? "total" : "per_vertex", w, f->f) ||
            selection(c, e, w, b, tol, &f->verts, &f->n))
            return -1;
        b->nforces = i + 1;
    }
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Drives */

int scene_parse_drive(sj_ctx *c, const cJSON *j, const char *what, scene_body *b, double tol)
{
    const int n = count_entries(j);
    b->drives = calloc((size_t)(n > 0 ? n : 1), sizeof *b->drives);
    if (!b->drives) return sj_fail(c, j, "out of memory");
    const double *x0 = b->initial ? b->initial : b->mesh.positions;
    const cJSON *e = cJSON_IsArray(j) ? j->child : j;
    for (int i = 0; e; e = cJSON_IsArray(j) ? e->next : NULL, ++i) {
        char w[240], wk[260];
        snprintf(w, sizeof w, cJSON_IsArray(j) ? "%s.drive[%d]" : "%s.drive", what, i);
        static const char *const keys[] = {"indices", "box", "keys", NULL};
        if (!cJSON_IsObject(e)) return sj_fail(c, e, "%s must be an object with \"keys\"", w);
        if (sj_keys(c, e, w, keys)) return -1;
        scene_drive *d = &b->drives[i];
        b->ndrives = i + 1;
        if (!cJSON_GetObjectItemCaseSensitive(e, "indices") &&
            !cJSON_GetObjectItemCaseSensitive(e, "box"))
            return sj_fail(c, e, "%s needs \"indices\" and/or \"box\" (the driven vertices)", w);
        const cJSON *k = sj_require(c, e, "keys", w);
        snprintf(wk, sizeof wk, "%s.keys", w);
        if (!k || selection(c, e, w, b, tol, &d->verts, &d->n) || parse_path(c, k, wk, &d->path))
            return -1;
        d->anchor = malloc(3 * (size_t)d->n * sizeof *d->anchor);
        d->target = malloc(3 * (size_t)d->n * sizeof *d->target);
        if (!d->anchor || !d->target) return sj_fail(c, e, "out of memory");
        for (int32_t v = 0; v < d->n; ++v) memcpy(d->anchor + 3 * v, x0 + 3 * d->verts[v], 3 * sizeof(double));
    }
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Attachments */

/* A body by index or name. */
static int body_ref(sj_ctx *c, const cJSON *j, const char *what, int32_t *out)
{
    const scene *s = c->s;
    if (cJSON_IsNumber(j) && j->valuedouble == floor(j->valuedouble) && j->valuedouble >= 0 &&
        j->valuedouble < s->nbodies) {
        *out = (int32_t)j->valuedouble;
        return 0;
    }
    if (cJSON_IsString(j))
        for (int32_t i = 0; i < s->nbodies; ++i)
            if (!strcmp(s->bodies[i].name, j->valuestring)) {
                *out = i;
                return 0;
            }
    return sj_fail(c, j, "%s must be a body index in [0, %d) or a body's name", what,
                   (int)s->nbodies);
}

static double det3(const double a[3], const double b[3], const double d[3])
{
    return a[0] * (b[1] * d[2] - b[2] * d[1]) - a[1] * (b[0] * d[2] - b[2] * d[0]) +
           a[2] * (b[0] * d[1] - b[1] * d[0]);
}

/* Barycentric coordinates of p in the element of `tb` (at rest) that contains it, or, when none
 * does, in the one where p is least outside (the largest smallest weight); negative weights are
 * then clamped to zero and the rest rescaled, so the target is a point of that element. Tets
 * first; a body without tets uses its triangles, one without those its nearest vertex. */
static void nearest_element(const scene_body *tb, const double p[3], scene_attachment *a)
{
    const double *X = tb->mesh.positions;
    double best = -INFINITY;
    if (tb->mesh.tet_count > 0) {
        for (int32_t t = 0; t < tb->mesh.tet_count; ++t) {
            /* a quadratic tet by its corners (the first 4 of its 10) */
            const int32_t *q = tb->mesh.tets + (tb->mesh.tet_nodes == 10 ? 10 : 4) * (int64_t)t;
            double e[3][3], d[3];
            for (int i = 0; i < 3; ++i) {
                for (int k = 0; k < 3; ++k) e[i][k] = X[3 * q[i] + k] - X[3 * q[3] + k];
                d[i] = p[i] - X[3 * q[3] + i];
            }
            const double D = det3(e[0], e[1], e[2]);
            if (D == 0.0) continue;
            double l[4];
            l[0] = det3(d, e[1], e[2]) / D;
            l[1] = det3(e[0], d, e[2]) / D;
            l[2] = det3(e[0], e[1], d) / D;
            l[3] = 1.0 - l[0] - l[1] - l[2];
            const double m = fmin(fmin(l[0], l[1]), fmin(l[2], l[3]));
            if (m > best) {
                best = m;
                a->target_count = 4;
                memcpy(a->target_vertices, q, 4 * sizeof *q);
                memcpy(a->target_weights, l, sizeof l);
            }
        }
    } else if (tb->mesh.triangle_count > 0) {
        for (int32_t t = 0; t < tb->mesh.triangle_count; ++t) {
            const int32_t *q = tb->mesh.triangles + 3 * t;
            double e1[3], e2[3], d[3];
            for (int k = 0; k < 3; ++k) {
                e1[k] = X[3 * q[1] + k] - X[3 * q[0] + k];
                e2[k] = X[3 * q[2] + k] - X[3 * q[0] + k];
                d[k] = p[k] - X[3 * q[0] + k];
            }
            /* Weights of the projection of p onto the triangle's plane. */
            const double a11 = e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2];
            const double a12 = e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2];
            const double a22 = e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2];
            const double b1 = d[0] * e1[0] + d[1] * e1[1] + d[2] * e1[2];
            const double b2 = d[0] * e2[0] + d[1] * e2[1] + d[2] * e2[2];
            const double D = a11 * a22 - a12 * a12;
            if (!(D > 0.0)) continue;
            const double l1 = (b1 * a22 - b2 * a12) / D, l2 = (a11 * b2 - a12 * b1) / D;
            const double l[3] = {1.0 - l1 - l2, l1, l2};
            /* Points off the plane: the in-plane measure first, then the distance to the plane. */
            double off[3];
            for (int k = 0; k < 3; ++k) off[k] = d[k] - l1 * e1[k] - l2 * e2[k];
            const double m = fmin(fmin(l[0], l[1]), l[2]) -
                             sqrt(off[0] * off[0] + off[1] * off[1] + off[2] * off[2]) /
                                 sqrt(fmax(a11, a22));
            if (m > best) {
                best = m;
                a->target_count = 3;
                memcpy(a->target_vertices, q, 3 * sizeof *q);
                memcpy(a->target_weights, l, sizeof l);
            }
        }
    }
    if (a->target_count == 0) {
        for (int32_t v = 0; v < tb->mesh.vertex_count; ++v) {
            const double *q = X + 3 * v;
            const double m = -((q[0] - p[0]) * (q[0] - p[0]) + (q[1] - p[1]) * (q[1] - p[1]) +
                               (q[2] - p[2]) * (q[2] - p[2]));
            if (m > best) {
                best = m;
                a->target_count = 1;
                a->target_vertices[0] = v;
                a->target_weights[0] = 1.0;
            }
        }
        return;
    }
    double sum = 0.0;
    for (int i = 0; i < a->target_count; ++i) sum += a->target_weights[i] = fmax(a->target_weights[i], 0.0);
    for (int i = 0; i < a->target_count; ++i) a->target_weights[i] /= sum;
}

static int parse_attachment(sj_ctx *c, const cJSON *e, int index, scene_attachment **list,
                            int32_t *count, int32_t *cap)
{
    scene *s = c->s;
    char w[120], wt[140];
    snprintf(w, sizeof w, "attachments[%d]", index);
    snprintf(wt, sizeof wt, "%s.target", w);
    static const char *const keys[] = {"body", "vertex", "point", "indices", "box", "stiffness",
                                       "damping", "target", NULL};
    if (!cJSON_IsObject(e)) return sj_fail(c, e, "%s must be an object", w);
    if (sj_keys(c, e, w, keys)) return -1;
    const cJSON *bj = sj_require(c, e, "body", w);
    int32_t body = -1;
    char wb[160];
    snprintf(wb, sizeof wb, "%s.body", w);
    if (!bj || body_ref(c, bj, wb, &body)) return -1;
    const scene_body *b = &s->bodies[body];
    const int32_t nv = b->mesh.vertex_count;
    const double *x0 = b->initial ? b->initial : b->mesh.positions;
    /* The attached vertices: "vertex", "point" (the nearest at rest), "indices", "box". */
    uint8_t *mark = calloc((size_t)nv, 1);
    int32_t *verts = NULL, n = 0;
    if (!mark) return sj_fail(c, e, "out of memory");
    int rc = -1;
    const cJSON *vj = cJSON_GetObjectItemCaseSensitive(e, "vertex");
    const cJSON *pj = cJSON_GetObjectItemCaseSensitive(e, "point");
    const cJSON *ind = cJSON_GetObjectItemCaseSensitive(e, "indices");
    const cJSON *box = cJSON_GetObjectItemCaseSensitive(e, "box");
    if (!vj && !pj && !ind && !box) {
        sj_fail(c, e, "%s needs the attached vertices: \"vertex\", \"point\", \"indices\" or "
                "\"box\"", w);
        goto done;
    }
    if (vj) {
        int32_t v = 0;
        if (sj_int(c, e, "vertex", w, 0, nv - 1, &v)) goto done;
        mark[v] = 1;
    }
    if (pj) {
        double p[3], best = INFINITY;
        int32_t near = 0;
        if (sj_vec3(c, e, "point", w, p)) goto done;
        for (int32_t v = 0; v < nv; ++v) {
            const double *q = b->mesh.positions + 3 * v;
            const double d = (q[0] - p[0]) * (q[0] - p[0]) + (q[1] - p[1]) * (q[1] - p[1]) +
                             (q[2] - p[2]) * (q[2] - p[2]);
            if (d < best) { best = d; near = v; }
        }
        mark[near] = 1;
    }
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int32_t v = 0; v < nv; ++v)
        for (int k = 0; k < 3; ++k) {
            lo[k] = fmin(lo[k], b->mesh.positions[3 * v + k]);
            hi[k] = fmax(hi[k], b->mesh.positions[3 * v + k]);
        }
    const double tol = 1e-9 * sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) +
                                   (hi[1] - lo[1]) * (hi[1] - lo[1]) + (hi[2] - lo[2]) * (hi[2] - lo[2]));
    if (sj_select(c, ind, box, w, b->mesh.positions, nv, tol, mark) ||
        sj_marked(c, e, mark, nv, &verts, &n))
        goto done;
    double k = 0.0, damping = 0.0;
    if (!sj_require(c, e, "stiffness", w) ||
        sj_number(c, e, "stiffness", w, 0.0, 1e300, 1, &k) ||
        sj_number(c, e, "damping", w, 0.0, 1e300, 0, &damping))
        goto done;
    /* The target: a world point (each vertex's own start, or "point"), moved along "keys", or
     * the nearest element of another body. */
    const cJSON *tj = cJSON_GetObjectItemCaseSensitive(e, "target");
    int32_t tbody = -1, path = -1;
    int32_t explicit_count = 0, explicit_vertices[4] = {0, 0, 0, 0};
    double explicit_weights[4] = {0, 0, 0, 0};
    int has_point = 0;
    double point[3] = {0, 0, 0};
    if (tj) {
        static const char *const tkeys[] = {"point", "keys", "body", "vertices", "weights", NULL};
        if (!cJSON_IsObject(tj)) {
            sj_fail(c, tj, "%s must be an object with \"point\", \"keys\" or \"body\"", wt);
            goto done;
        }
        if (sj_keys(c, tj, wt, tkeys)) goto done;
        const cJSON *tb = cJSON_GetObjectItemCaseSensitive(tj, "body");
        const cJSON *tk = cJSON_GetObjectItemCaseSensitive(tj, "keys");
        const cJSON *tp = cJSON_GetObjectItemCaseSensitive(tj, "point");
        if (tb && (tk || tp)) {
            sj_fail(c, tb, "%s: \"body\" cannot be combined with \"point\" or \"keys\"", wt);
            goto done;
        }
        if (tb) {
            char wtb[180];
            snprintf(wtb, sizeof wtb, "%s.body", wt);
            if (body_ref(c, tb, wtb, &tbody)) goto done;
            if (tbody == body) {
                sj_fail(c, tb, "%s.body: a body cannot be attached to itself", wt);
                goto done;
            }
        }
        /* Explicit target vertices and barycentric weights instead of the nearest element (what
         * defsim_scene_export writes); the library checks the weights. */
        const cJSON *tv = cJSON_GetObjectItemCaseSensitive(tj, "vertices");
        const cJSON *tw = cJSON_GetObjectItemCaseSensitive(tj, "weights");
        if ((tv || tw) && (!tb || !tv || !tw)) {
            sj_fail(c, tv ? tv : tw, "%s: \"vertices\" and \"weights\" go together, with "
                    "\"body\"", wt);
            goto done;
        }
        if (tv) {
            int32_t *vv = NULL, nvv = 0, nww = 0;
            double *ww = NULL;
            char wv[180];
            snprintf(wv, sizeof wv, "%s.vertices", wt);
            int bad = sj_ints(c, tv, wv, 1, 0, s->bodies[tbody].mesh.vertex_count - 1, &vv, &nvv);
            snprintf(wv, sizeof wv, "%s.weights", wt);
            bad = bad || sj_doubles(c, tw, wv, 1, &ww, &nww);
            if (!bad && (nvv < 1 || nvv > 4 || nww != nvv))
                bad = sj_fail(c, tv, "%s: 1 to 4 vertices and as many weights", wt);
            if (!bad) {
                explicit_count = nvv;
                memcpy(explicit_vertices, vv, (size_t)nvv * sizeof *vv);
                memcpy(explicit_weights, ww, (size_t)nvv * sizeof *ww);
            }
            free(vv);
            free(ww);
            if (bad) goto done;
        }
        if (tp) {
            if (sj_vec3(c, tj, "point", wt, point)) goto done;
            has_point = 1;
        }
        if (tk) {
            char wk[160];
            snprintf(wk, sizeof wk, "%s.keys", wt);
            scene_path *np = realloc(s->paths, (size_t)(s->npaths + 1) * sizeof *np);
            if (!np) { sj_fail(c, tk, "out of memory"); goto done; }
            s->paths = np;
            path = s->npaths++;
            if (parse_path(c, tk, wk, &s->paths[path])) goto done;
        }
    }
    if (*count > INT32_MAX - n) { sj_fail(c, e, "too many attachments"); goto done; }
    if (*count + n > *cap) {
        const int32_t ncap = *count + n > 2 * *cap ? *count + n : 2 * *cap;
        scene_attachment *nl = realloc(*list, (size_t)ncap * sizeof *nl);
        if (!nl) { sj_fail(c, e, "out of memory"); goto done; }
        *list = nl;
        *cap = ncap;
    }
    for (int32_t i = 0; i < n; ++i) {
        scene_attachment *a = &(*list)[(*count)++];
        memset(a, 0, sizeof *a);
        a->line = sj_node_line(c, e);
        a->body = body;
        a->vertex = verts[i];
        a->stiffness = k;
        a->damping = damping;
        a->target_body = tbody;
        a->path = path;
        memcpy(a->anchor, has_point ? point : x0 + 3 * verts[i], sizeof a->anchor);
        if (tbody >= 0 && explicit_count > 0) {
            a->target_count = explicit_count;
            memcpy(a->target_vertices, explicit_vertices, sizeof explicit_vertices);
            memcpy(a->target_weights, explicit_weights, sizeof explicit_weights);
        } else if (tbody >= 0) {
            nearest_element(&s->bodies[tbody], b->mesh.positions + 3 * verts[i], a);
        }
    }
    rc = 0;
done:
    free(mark);
    free(verts);
    return rc;
}

int scene_parse_attachments(sj_ctx *c, const cJSON *j)
{
    scene *s = c->s;
    if (!cJSON_IsArray(j)) return sj_fail(c, j, "attachments must be an array of objects");
    int32_t cap = 0;
    int i = 0;
    for (const cJSON *e = j->child; e; e = e->next, ++i)
        if (parse_attachment(c, e, i, &s->attachments, &s->nattachments, &cap)) return -1;
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Building, stepping, freeing */

static defsim_status fail(scene *s, defsim_world *w, defsim_status st, const char *what, int line)
{
    snprintf(s->error, sizeof s->error, "%s:%d: %s: %s: %s", s->path, line, what,
             defsim_status_string(st), defsim_world_last_error(w));
    return st;
}

defsim_status scene_build_coupling(scene *s, defsim_world *w)
{
    defsim_status st = DEFSIM_OK;
    int any_force = 0;
    for (int32_t i = 0; i < s->nbodies; ++i) any_force |= s->bodies[i].nforces > 0;
    if (any_force) {
        const int32_t nv = defsim_world_vertex_count(w);
        double *f = calloc(3 * (size_t)nv, sizeof *f), *m = malloc((size_t)nv * sizeof *m);
        if (!f || !m) {
            free(f); free(m);
            snprintf(s->error, sizeof s->error, "%s: out of memory", s->path);
            return DEFSIM_ERR_OUT_OF_MEMORY;
        }
        st = defsim_world_get_masses(w, m, nv);
        for (int32_t i = 0; i < s->nbodies && st == DEFSIM_OK; ++i) {
            const scene_body *b = &s->bodies[i];
            for (int32_t k = 0; k < b->nforces; ++k) {
                const scene_force *sf = &b->forces[k];
                double mass = 0.0;
                for (int32_t v = 0; v < sf->n; ++v) mass += m[b->offset + sf->verts[v]];
                for (int32_t v = 0; v < sf->n; ++v) {
                    const int32_t g = b->offset + sf->verts[v];
                    const double share = sf->total ? m[g] / mass : 1.0;
                    for (int c = 0; c < 3; ++c) f[3 * (int64_t)g + c] += share * sf->f[c];
                }
            }
        }
        if (st == DEFSIM_OK) st = defsim_world_set_external_forces(w, f, nv);
        free(f);
        free(m);
        for (int32_t i = 0; i < s->nbodies && st != DEFSIM_OK; ++i)
            if (s->bodies[i].nforces > 0) return fail(s, w, st, "forces", s->bodies[i].line);
    }
    for (int32_t i = 0; i < s->nbodies; ++i) {
        const scene_body *b = &s->bodies[i];
        for (int32_t k = 0; k < b->ndrives; ++k) {
            st = defsim_body_pin(w, b->id, b->drives[k].verts, b->drives[k].n);
            if (st != DEFSIM_OK) return fail(s, w, st, "drive", b->line);
        }
    }
    for (int32_t i = 0; i < s->nattachments; ++i) {
        scene_attachment *a = &s->attachments[i];
        defsim_attachment_def d;
        defsim_attachment_def_init(&d, sizeof d);
        d.body = s->bodies[a->body].id;
        d.vertex = a->vertex;
        d.stiffness = a->stiffness;
        d.damping = a->damping;
        if (a->target_body >= 0) {
            d.target_body = s->bodies[a->target_body].id;
            d.target_vertex_count = a->target_count;
            memcpy(d.target_vertices, a->target_vertices, sizeof d.target_vertices);
            memcpy(d.target_weights, a->target_weights, sizeof d.target_weights);
        } else if (a->path >= 0) {
            path_apply(&s->paths[a->path], defsim_world_time(w), a->anchor, d.target, 1);
        } else {
            memcpy(d.target, a->anchor, sizeof d.target);
        }
        st = defsim_world_add_attachment(w, &d, &a->id);
        if (st != DEFSIM_OK) return fail(s, w, st, "attachments", a->line);
    }
    return DEFSIM_OK;
}

int scene_has_paths(const scene *s)
{
    for (int32_t i = 0; i < s->nbodies; ++i)
        if (s->bodies[i].ndrives > 0) return 1;
    for (int32_t i = 0; i < s->ncolliders; ++i)
        if (s->colliders[i].nkeys > 0) return 1;
    return s->npaths > 0;
}

defsim_status scene_step(scene *s, defsim_world *w, double h)
{
    const double t = defsim_world_time(w) + h;
    for (int32_t i = 0; i < s->nbodies; ++i) {
        const scene_body *b = &s->bodies[i];
        for (int32_t k = 0; k < b->ndrives; ++k) {
            scene_drive *d = &b->drives[k];
            path_apply(&d->path, t, d->anchor, d->target, d->n);
            const defsim_status st = defsim_body_set_pin_targets(w, b->id, d->verts, d->n, d->target);
            if (st != DEFSIM_OK) return st;
        }
    }
    for (int32_t i = 0; i < s->nattachments; ++i) {
        const scene_attachment *a = &s->attachments[i];
        if (a->path < 0) continue;
        double p[3];
        path_apply(&s->paths[a->path], t, a->anchor, p, 1);
        const defsim_status st = defsim_attachment_set_target(w, a->id, p);
        if (st != DEFSIM_OK) return st;
    }
    const defsim_status st = scene_move_colliders(s, w, t);
    if (st != DEFSIM_OK) return st;
    return defsim_world_step(w, h);
}

void scene_free_coupling(scene *s)
{
    for (int32_t i = 0; i < s->nbodies; ++i) {
        scene_body *b = &s->bodies[i];
        for (int32_t k = 0; k < b->nforces; ++k) free(b->forces[k].verts);
        for (int32_t k = 0; k < b->ndrives; ++k) {
            free(b->drives[k].verts);
            free(b->drives[k].anchor);
            free(b->drives[k].target);
            free(b->drives[k].path.key);
        }
        free(b->forces);
        free(b->drives);
        b->forces = NULL;
        b->drives = NULL;
        b->nforces = b->ndrives = 0;
    }
    for (int32_t i = 0; i < s->npaths; ++i) free(s->paths[i].key);
    free(s->paths);
    free(s->attachments);
    s->paths = NULL;
    s->attachments = NULL;
    s->npaths = s->nattachments = 0;
}

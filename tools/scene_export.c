/* SPDX-License-Identifier: MIT */
/*
 * Scene files, written: the scene JSON of a world (defsim_scene_export in libdefsim_scene), which
 * scene_load reads back into a world that steps to the same bits.
 *
 * What a world holds is read from its checkpoint (defsim_world_save_buffer, docs/checkpoints.md):
 * the bodies as the library keeps them (rest positions, masses, tets, springs and their
 * stiffnesses, pins, contact surfaces, materials, shell fields), attachments, held forces,
 * colliders and the world's def, so that the export sees exactly what the world steps with and
 * needs no accessor of its own in the core. Options, state and colliders' defs come through the public
 * calls. Every number is written with 17 significant digits, which strtod (cJSON) reads back to
 * the same double. What a scene cannot express (an SDF collider, pending pin targets or
 * collider poses, keyed paths of a scene at t != 0) is refused with DEFSIM_ERR_UNSUPPORTED,
 * never written approximately.
 */
#include "scene.h"

#include "../src/body.h"
#include "../src/checkpoint.h"
#include "lib/api_error.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* Text */

typedef struct out {
    char *p;
    size_t n, cap;
    int oom;
} out;

static void put(out *o, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
static void put(out *o, const char *fmt, ...)
{
    if (o->oom) return;
    for (;;) {
        va_list ap;
        va_start(ap, fmt);
        const int k = vsnprintf(o->p ? o->p + o->n : NULL, o->p ? o->cap - o->n : 0, fmt, ap);
        va_end(ap);
        if (k < 0) { o->oom = 1; return; }
        if (o->p && o->n + (size_t)k < o->cap) { o->n += (size_t)k; return; }
        size_t cap = o->cap ? 2 * o->cap : 4096;
        while (cap < o->n + (size_t)k + 1) cap *= 2;
        char *np = realloc(o->p, cap);
        if (!np) { o->oom = 1; return; }
        o->p = np;
        o->cap = cap;
    }
}

/* A double that reads back to the same bits (the sign of zero included). */
static void num(out *o, double v) { put(o, "%.17g", v); }

static void str(out *o, const char *s)
{
    put(o, "\"");
    for (; *s; ++s) {
        const unsigned char ch = (unsigned char)*s;
        if (ch == '"' || ch == '\\') put(o, "\\%c", ch);
        else if (ch < 0x20) put(o, "\\u%04x", ch);
        else put(o, "%c", ch);
    }
    put(o, "\"");
}

static void vec(out *o, const double *v, int n)
{
    put(o, "[");
    for (int i = 0; i < n; ++i) {
        if (i) put(o, ", ");
        num(o, v[i]);
    }
    put(o, "]");
}

/* n rows of `width` doubles, one row per line. */
static void rows(out *o, const double *v, int64_t n, int width)
{
    put(o, "[");
    for (int64_t i = 0; i < n; ++i) {
        put(o, i ? ",\n        " : "\n        ");
        vec(o, v + width * i, width);
    }
    put(o, "]");
}

static void irows(out *o, const int32_t *v, int64_t n, int width)
{
    put(o, "[");
    for (int64_t i = 0; i < n; ++i) {
        put(o, i ? ", [" : "[");
        for (int k = 0; k < width; ++k) put(o, k ? ", %d" : "%d", (int)v[width * i + k]);
        put(o, "]");
    }
    put(o, "]");
}

/* ------------------------------------------------------------------------------------------ */
/* The checkpoint's chunks */

typedef struct xbody {
    uint32_t saved, generation;
    int32_t nv, nt, ns, tn, ntri, nedge, self_contact, offset, volume_averaging;
    defsim_material mat;
    double *rest, *mass, *k;
    int32_t *tets, *springs, *tris, *edges;
    const unsigned char *pinned;
    uint32_t group, mask;
    double friction, thickness;   /* thickness: format 11's contact thickness (m) */
    defsim_body_def shell;   /* its shell_* fields (format 9), as the def gave them */
} xbody;

typedef struct xatt {
    uint32_t body[2], tbody[2];
    int32_t vertex, tcount, tverts[4];
    double k, c, target[3], weights[4];
} xatt;

typedef struct xcoll {
    int32_t shape, nvm, ntm;
    double pos[3], rot[4], next_pos[3], next_rot[4], normal[3], radius, half[3], half_height,
        friction;
    const unsigned char *verts, *tris;   /* little-endian payload bytes */
} xcoll;

typedef struct ckpt {
    char backend[256];
    double gravity[3];
    int32_t threads;
    xbody *bodies;
    int32_t nbodies;
    xatt *atts;
    int32_t natts;
    xcoll *colls;
    int32_t ncolls;
    const unsigned char *fext;   /* 3 nv f64 or NULL */
    int32_t npending;            /* driven-pin targets not yet consumed */
} ckpt;

static void ckpt_free(ckpt *k)
{
    for (int32_t i = 0; i < k->nbodies; ++i) {
        xbody *b = &k->bodies[i];
        free(b->rest); free(b->mass); free(b->k); free(b->tets); free(b->springs);
        free(b->tris); free(b->edges);
    }
    free(k->bodies);
    free(k->atts);
    free(k->colls);
}

static int grow(void **p, int32_t n, size_t size)
{
    void *np = realloc(*p, (size_t)(n + 1) * size);
    if (!np) return -1;
    *p = np;
    memset((char *)np + (size_t)n * size, 0, size);
    return 0;
}

static double *f64s(defsim__br *r, int64_t n)
{
    double *v = malloc((size_t)(n > 0 ? n : 1) * sizeof *v);
    if (v) defsim__get_f64s(r, v, n);
    return v;
}

static int32_t *i32s(defsim__br *r, int64_t n)
{
    int32_t *v = malloc((size_t)(n > 0 ? n : 1) * sizeof *v);
    if (v) defsim__get_i32s(r, v, n);
    return v;
}

/* The chunks of the checkpoint format (the library's own version, DEFSIM__CKPT_VERSION) that a
 * scene needs. Returns 0, -1 (malformed: a format this code does not know) or -2 (out of
 * memory). */
static int ckpt_read(const unsigned char *d, size_t size, ckpt *k)
{
    memset(k, 0, sizeof *k);
    if (size < 16 || memcmp(d, "DEFSIMCK", 8)) return -1;
    defsim__br h = {d + 8, 8, 0, 0};
    if (defsim__get_u32(&h) != DEFSIM__CKPT_VERSION) return -1;
    size_t at = 16;
    while (at + 12 <= size) {
        const unsigned char *tag = d + at;
        defsim__br lr = {d + at + 4, 8, 0, 0};
        const uint64_t len = defsim__get_u64(&lr);
        if (len > size - at - 16) return -1;
        defsim__br r = {d + at + 12, (size_t)len, 0, 0};
        if (!memcmp(tag, "WRLD", 4)) {
            defsim__get_str(&r, k->backend, sizeof k->backend);
            defsim__get_f64s(&r, k->gravity, 3);
            k->threads = defsim__get_i32(&r);
        } else if (!memcmp(tag, "BODY", 4)) {
            if (grow((void **)&k->bodies, k->nbodies, sizeof *k->bodies)) return -2;
            xbody *b = &k->bodies[k->nbodies++];
            b->saved = defsim__get_u32(&r);
            b->generation = defsim__get_u32(&r);
            b->nv = defsim__get_i32(&r);
            b->nt = defsim__get_i32(&r);
            b->ns = defsim__get_i32(&r);
            b->tn = defsim__get_i32(&r);   /* the chunk's version is the library's own */
            if (b->nv < 1 || b->nt < 0 || b->ns < 0 || (b->tn != 4 && b->tn != 10) ||
                !defsim__fits(&r, b->nv, 33) || !defsim__fits(&r, b->nt, 4 * (size_t)b->tn) ||
                !defsim__fits(&r, b->ns, 16))
                return -1;
            defsim_material *m = &b->mat;
            defsim_material_init(m, sizeof *m, (defsim_model)defsim__get_i32(&r));
            double *const mp[7] = {&m->youngs_modulus, &m->poisson_ratio, &m->density,
                                   &m->stiffness, &m->vertex_mass, &m->mass_damping,
                                   &m->stiffness_damping};   /* the chunk's order */
            for (int q = 0; q < 7; ++q) *mp[q] = defsim__get_f64(&r);
            b->rest = f64s(&r, 3 * (int64_t)b->nv);
            b->mass = f64s(&r, b->nv);
            b->tets = i32s(&r, (int64_t)b->tn * b->nt);
            b->springs = i32s(&r, 2 * (int64_t)b->ns);
            b->k = f64s(&r, b->ns);
            b->pinned = defsim__take(&r, (size_t)b->nv);
            b->ntri = defsim__get_i32(&r);
            b->nedge = defsim__get_i32(&r);
            if (b->ntri < 0 || b->nedge < 0 || !defsim__fits(&r, b->ntri, 12) ||
                !defsim__fits(&r, b->nedge, 8))
                return -1;
            b->tris = i32s(&r, 3 * (int64_t)b->ntri);
            b->edges = i32s(&r, 2 * (int64_t)b->nedge);
            b->self_contact = defsim__get_i32(&r);
            b->group = defsim__get_u32(&r);
            b->mask = defsim__get_u32(&r);
            b->friction = defsim__get_f64(&r);
            b->volume_averaging = defsim__get_i32(&r);
            defsim_body_def_init(&b->shell, sizeof b->shell);
            b->shell.shell_membrane = defsim__get_i32(&r);
            double sf[DEFSIM__SHELL_FIELDS];
            defsim__get_f64s(&r, sf, DEFSIM__SHELL_FIELDS);
            defsim__body_shell_fields(&b->shell, sf, 1);
            b->shell.shell_strain_limit = defsim__get_f64(&r);   /* version 10 */
            b->thickness = defsim__get_f64(&r);   /* version 11 */
            if (!b->rest || !b->mass || !b->tets || !b->springs || !b->k || !b->tris || !b->edges)
                return -2;
        } else if (!memcmp(tag, "ATCH", 4)) {
            if (grow((void **)&k->atts, k->natts, sizeof *k->atts)) return -2;
            xatt *a = &k->atts[k->natts++];
            a->body[0] = defsim__get_u32(&r);
            a->body[1] = defsim__get_u32(&r);
            a->vertex = defsim__get_i32(&r);
            a->k = defsim__get_f64(&r);
            a->c = defsim__get_f64(&r);
            defsim__get_f64s(&r, a->target, 3);
            a->tbody[0] = defsim__get_u32(&r);
            a->tbody[1] = defsim__get_u32(&r);
            a->tcount = defsim__get_i32(&r);
            defsim__get_i32s(&r, a->tverts, 4);
            defsim__get_f64s(&r, a->weights, 4);
        } else if (!memcmp(tag, "FEXT", 4)) {
            k->fext = r.p;
        } else if (!memcmp(tag, "PTGT", 4)) {
            k->npending = (int32_t)defsim__get_u32(&r);
        } else if (!memcmp(tag, "COLL", 4)) {
            if (grow((void **)&k->colls, k->ncolls, sizeof *k->colls)) return -2;
            xcoll *c = &k->colls[k->ncolls++];
            c->shape = defsim__get_i32(&r);
            defsim__get_f64s(&r, c->pos, 3);
            defsim__get_f64s(&r, c->rot, 4);
            defsim__get_f64s(&r, c->next_pos, 3);
            defsim__get_f64s(&r, c->next_rot, 4);
            defsim__get_f64s(&r, c->normal, 3);
            c->radius = defsim__get_f64(&r);
            defsim__get_f64s(&r, c->half, 3);
            c->half_height = defsim__get_f64(&r);
            c->friction = defsim__get_f64(&r);
        }
        if (r.bad) return -1;
        at += 16 + (size_t)len;
    }
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* The export */

static const char *model_name(defsim_model m)
{
    switch (m) {
    case DEFSIM_MODEL_SPRING: return "spring";
    case DEFSIM_MODEL_STVK: return "stvk";
    case DEFSIM_MODEL_COROTATED: return "corotated";
    case DEFSIM_MODEL_NEOHOOKEAN: return "neohookean";
    case DEFSIM_MODEL_STABLE_NEOHOOKEAN: return "stable_neohookean";
    }
    return NULL;
}

/* The world's options that differ from their defaults, by full name, in the world's order. */
static defsim_status write_options(out *o, const defsim_world *w)
{
    int first = 1;
    const int32_t n = defsim_world_option_count(w);
    for (int32_t i = 0; i < n; ++i) {
        defsim_option_info info;
        memset(&info, 0, sizeof info);
        info.size = sizeof info;
        const defsim_status st = defsim_world_option_info(w, i, &info);
        if (st != DEFSIM_OK) return st;
        if (info.value == info.default_value) continue;
        put(o, first ? ",\n    \"options\": {" : ", ");
        first = 0;
        str(o, info.name);
        put(o, ": ");
        if (info.type == DEFSIM_OPTION_BOOL) {
            put(o, info.value != 0.0 ? "true" : "false");
        } else if (info.type == DEFSIM_OPTION_CHOICE && info.choices) {
            /* the choice's name: its index in "a|b|c" */
            const char *p = info.choices;
            for (int c = 0; c < (int)info.value && p; ++c) {
                p = strchr(p, '|');
                if (p) ++p;
            }
            const char *e = p ? strchr(p, '|') : NULL;
            char name[128];
            snprintf(name, sizeof name, "%.*s", p ? (int)(e ? (size_t)(e - p) : strlen(p)) : 0,
                     p ? p : "");
            str(o, name);
        } else {
            num(o, info.value);
        }
    }
    if (!first) put(o, "}");
    return DEFSIM_OK;
}

/* Path keys of a scene (drives and keyed attachment targets): t, translation, rotation vector,
 * centre, exactly. */
static void write_path(out *o, const scene_path *p)
{
    put(o, "[");
    for (int32_t i = 0; i < p->n; ++i) {
        const double *q = p->key + 10 * (int64_t)i;
        put(o, i ? ", {\"t\": " : "{\"t\": ");
        num(o, q[0]);
        put(o, ", \"translate\": ");
        vec(o, q + 1, 3);
        put(o, ", \"rotate\": {\"vector\": ");
        vec(o, q + 4, 3);
        put(o, ", \"center\": ");
        vec(o, q + 7, 3);
        put(o, "}}");
    }
    put(o, "]");
}

/* Spring kinds that reproduce a body's contact edges with per-kind stiffnesses: needed for a
 * body of springs alone whose contact edges are not all its springs (a rope with bending
 * springs): the others are bend springs of one stiffness, and shear springs of a second one.
 * Returns 0 and fills kinds, shear and bend (-1: not used), or -1 when the stiffnesses cannot
 * be expressed per kind. */
static int spring_kinds(const xbody *b, int32_t *kinds, double *shear, double *bend)
{
    int32_t e = 0;
    *shear = *bend = -1.0;
    for (int32_t s = 0; s < b->ns; ++s) {
        const int stretch = e < b->nedge && b->springs[2 * s] == b->edges[2 * e] &&
                            b->springs[2 * s + 1] == b->edges[2 * e + 1];
        if (stretch) {
            if (b->k[s] != b->mat.stiffness) return -1;
            kinds[s] = DEFSIM_SPRING_STRETCH;
            ++e;
        } else if (*bend < 0.0 || b->k[s] == *bend) {
            *bend = b->k[s];
            kinds[s] = DEFSIM_SPRING_BEND;
        } else if (*shear < 0.0 || b->k[s] == *shear) {
            *shear = b->k[s];
            kinds[s] = DEFSIM_SPRING_SHEAR;
        } else {
            return -1;
        }
    }
    return e == b->nedge ? 0 : -1;
}

static int all_zero(const double *v, int64_t n)
{
    for (int64_t i = 0; i < n; ++i)
        if (v[i] != 0.0 || signbit(v[i])) return 0;
    return 1;
}

static int index_of_body(const ckpt *k, const uint32_t id[2])
{
    for (int32_t i = 0; i < k->nbodies; ++i)
        if (k->bodies[i].saved == id[0] && k->bodies[i].generation == id[1]) return i;
    return -1;
}

static int same_id(defsim_body_id a, defsim_body_id b)
{
    return a.index == b.index && a.generation == b.generation;
}

static defsim_status write_body(out *o, const ckpt *k, int32_t i, const scene_body *sb,
                                const double *x, const double *v, const scene *s,
                                char *err, size_t errsz)
{
    const xbody *b = &k->bodies[i];
    const int32_t nv = b->nv, off = b->offset;
    const char *model = model_name(b->mat.model);
    if (!model) return api_fail(err, errsz, DEFSIM_ERR_UNSUPPORTED, "body %d: unknown model %d",
                            (int)i, (int)b->mat.model);
    put(o, i ? ",\n  {" : "\n  {");
    char name[64];
    snprintf(name, sizeof name, "body %d", (int)i);
    put(o, "\"name\": ");
    str(o, sb ? sb->name : name);
    if (sb) {
        put(o, ", \"color\": [%.9g, %.9g, %.9g]", sb->color[0], sb->color[1], sb->color[2]);
    }
    /* Stiffness per spring, or by kind where the contact edges need the kinds. */
    int32_t *kinds = NULL;
    double shear = -1.0, bend = -1.0;
    if (b->ns > 0 && b->nt == 0 && b->ntri == 0 && b->nedge != b->ns) {
        kinds = malloc((size_t)b->ns * sizeof *kinds);
        if (!kinds) return DEFSIM_ERR_OUT_OF_MEMORY;
        if (spring_kinds(b, kinds, &shear, &bend)) {
            free(kinds);
            return api_fail(err, errsz, DEFSIM_ERR_UNSUPPORTED, "body %d: its springs' stiffnesses "
                        "and contact edges have no spring kinds that give both", (int)i);
        }
    }
    put(o, ",\n    \"mesh\": {\"type\": \"inline\",\n      \"positions\": ");
    rows(o, b->rest, nv, 3);
    if (b->nt) { put(o, ",\n      \"tets\": "); irows(o, b->tets, b->nt, b->tn); }
    if (b->nt && b->tn != 4) put(o, ",\n      \"tet_nodes\": %d", (int)b->tn);
    if (b->ntri) { put(o, ",\n      \"triangles\": "); irows(o, b->tris, b->ntri, 3); }
    if (b->ns) { put(o, ",\n      \"springs\": "); irows(o, b->springs, b->ns, 2); }
    if (kinds) { put(o, ",\n      \"spring_kinds\": "); irows(o, kinds, b->ns, 1); }
    free(kinds);
    put(o, "},\n    \"material\": {\"model\": \"%s\"", model);
    if (b->nt > 0) {
        put(o, ", \"youngs_modulus\": "); num(o, b->mat.youngs_modulus);
        put(o, ", \"poisson_ratio\": "); num(o, b->mat.poisson_ratio);
        put(o, ", \"density\": "); num(o, b->mat.density);
    } else {
        put(o, ", \"stiffness\": "); num(o, b->mat.stiffness);
        if (shear >= 0.0) { put(o, ", \"shear_stiffness\": "); num(o, shear); }
        if (bend >= 0.0) { put(o, ", \"bending_stiffness\": "); num(o, bend); }
    }
    put(o, ", \"vertex_mass\": "); num(o, b->mat.vertex_mass);
    put(o, ", \"mass_damping\": "); num(o, b->mat.mass_damping);
    put(o, ", \"stiffness_damping\": "); num(o, b->mat.stiffness_damping);
    put(o, "},\n    \"masses\": "); vec(o, b->mass, nv);
    if (b->ns && !(b->nt == 0 && b->ntri == 0 && b->nedge != b->ns)) {
        put(o, ",\n    \"spring_stiffness\": "); vec(o, b->k, b->ns);
    }
    if (memcmp(x + 3 * (int64_t)off, b->rest, 3 * (size_t)nv * sizeof *x)) {
        put(o, ",\n    \"initial_positions\": ");
        rows(o, x + 3 * (int64_t)off, nv, 3);
    }
    if (!all_zero(v + 3 * (int64_t)off, 3 * (int64_t)nv)) {
        put(o, ",\n    \"initial_velocities\": ");
        rows(o, v + 3 * (int64_t)off, nv, 3);
    }
    int32_t npin = 0;
    for (int32_t j = 0; j < nv; ++j) npin += b->pinned[j] != 0;
    if (npin) {
        put(o, ",\n    \"pin\": [");
        for (int32_t j = 0, c = 0; j < nv; ++j)
            if (b->pinned[j]) put(o, c++ ? ", %d" : "%d", (int)j);
        put(o, "]");
    }
    /* Held forces, grouped by value: one entry per distinct force. */
    if (k->fext) {
        defsim__br r = {k->fext + 24 * (size_t)off, 24 * (size_t)nv, 0, 0};
        double *f = f64s(&r, 3 * (int64_t)nv);
        uint8_t *done = calloc((size_t)nv, 1);
        if (!f || !done) { free(f); free(done); return DEFSIM_ERR_OUT_OF_MEMORY; }
        int first = 1;
        for (int32_t j = 0; j < nv; ++j) {
            if (done[j] || all_zero(f + 3 * (int64_t)j, 3)) continue;
            put(o, first ? ",\n    \"forces\": [{\"per_vertex\": " : ", {\"per_vertex\": ");
            first = 0;
            vec(o, f + 3 * (int64_t)j, 3);
            put(o, ", \"indices\": [");
            for (int32_t q = j, c = 0; q < nv; ++q)
                if (!done[q] && !memcmp(f + 3 * (int64_t)q, f + 3 * (int64_t)j, 3 * sizeof *f)) {
                    done[q] = 1;
                    put(o, c++ ? ", %d" : "%d", (int)q);
                }
            put(o, "]}");
        }
        if (!first) put(o, "]");
        free(f);
        free(done);
    }
    if (sb && sb->ndrives > 0) {
        put(o, ",\n    \"drive\": [");
        for (int32_t d = 0; d < sb->ndrives; ++d) {
            put(o, d ? ", {\"indices\": [" : "{\"indices\": [");
            for (int32_t q = 0; q < sb->drives[d].n; ++q)
                put(o, q ? ", %d" : "%d", (int)sb->drives[d].verts[q]);
            put(o, "], \"keys\": ");
            write_path(o, &sb->drives[d].path);
            put(o, "}");
        }
        put(o, "]");
    }
    (void)s;
    put(o, ",\n    \"self_contact\": %s, \"collision_group\": %u, \"collision_mask\": %u, "
        "\"friction\": ", b->self_contact ? "true" : "false", (unsigned)b->group,
        (unsigned)b->mask);
    num(o, b->friction);
    if (b->thickness != 0.0) {
        put(o, ", \"contact_thickness\": ");
        num(o, b->thickness);
    }
    if (b->volume_averaging) put(o, ", \"volume_averaging\": true");
    /* A shell (docs/shells.md: a membrane, or a bending rigidity > 0 whatever the membrane, as
     * < 0 resolves to 0 without one): its fields as the def gave them. */
    const defsim_body_def *sh = &b->shell;
    if (sh->shell_membrane != DEFSIM_SHELL_MEMBRANE_NONE || sh->shell_bending_rigidity > 0.0 ||
        sh->shell_bending_rigidity_weft > 0.0) {
        static const char *const membranes[] = {"none", "stvk", "neohookean", "orthotropic_stvk"};
        if (sh->shell_membrane < 0 || sh->shell_membrane > 3)
            return api_fail(err, errsz, DEFSIM_ERR_UNSUPPORTED, "body %d: unknown membrane %d",
                            (int)i, (int)sh->shell_membrane);
        put(o, ",\n    \"shell\": {\"membrane\": \"%s\"", membranes[sh->shell_membrane]);
        const char *const keys[] = {"youngs_modulus", "poisson_ratio", "thickness",
                                    "warp_modulus", "weft_modulus", "shear_modulus",
                                    "warp_poisson", "areal_density", "bending_rigidity",
                                    "bending_rigidity_weft"};
        const double vals[] = {sh->shell_youngs_modulus, sh->shell_poisson_ratio,
                               sh->shell_thickness, sh->shell_warp_modulus,
                               sh->shell_weft_modulus, sh->shell_shear_modulus,
                               sh->shell_warp_poisson, sh->shell_areal_density,
                               sh->shell_bending_rigidity, sh->shell_bending_rigidity_weft};
        for (int q = 0; q < 10; ++q) {
            put(o, ", \"%s\": ", keys[q]);
            num(o, vals[q]);
        }
        put(o, ", \"warp_direction\": ");
        vec(o, sh->shell_warp_direction, 3);
        if (sh->shell_strain_limit != 0.0) {
            put(o, ", \"strain_limit\": ");
            num(o, sh->shell_strain_limit);
        }
        put(o, "}");
    }
    put(o, "}");
    return DEFSIM_OK;
}

static const char *const SHAPES[] = {"plane", "sphere", "box", "capsule", "mesh"};

defsim_status scene_export(const scene *s, const defsim_world *w, double h, double duration,
                           char **json, size_t *length, char *err, size_t errsz)
{
    *json = NULL;
    if (length) *length = 0;
    if (err && errsz) err[0] = '\0';
    if (s) {
        if (!(h > 0.0)) h = s->h;
        if (!(duration > 0.0)) duration = s->duration;
    }
    if (!(h > 0.0) || !isfinite(h) || !(duration > 0.0) || !isfinite(duration))
        return api_fail(err, errsz, DEFSIM_ERR_INVALID_ARGUMENT, "defsim_scene_export: h = %g and "
                    "duration = %g must be finite and > 0 (a scene file needs both)", h,
                    duration);
    void *data = NULL;
    size_t size = 0;
    defsim_status st = defsim_world_save_buffer(w, &data, &size);
    if (st != DEFSIM_OK)
        return api_fail(err, errsz, st, "defsim_scene_export: %s", defsim_world_last_error(w));
    ckpt k;
    const int rc = ckpt_read(data, size, &k);
    out o = {NULL, 0, 0, 0};
    double *x = NULL, *v = NULL;
    const int32_t nv = defsim_world_vertex_count(w);
    const double t = defsim_world_time(w);
    if (rc) {
        st = rc == -2 ? DEFSIM_ERR_OUT_OF_MEMORY
                      : api_fail(err, errsz, DEFSIM_ERR_UNSUPPORTED, "defsim_scene_export: the "
                             "world's checkpoint is of a format this library does not read");
        goto done;
    }
    if (k.npending > 0) {
        st = api_fail(err, errsz, DEFSIM_ERR_UNSUPPORTED, "defsim_scene_export: %d driven-pin targets "
                  "are set for the next step (defsim_body_set_pin_targets); a scene cannot hold "
                  "them: export before setting them or after the step", (int)k.npending);
        goto done;
    }
    if (s && t != 0.0 && scene_has_paths(s)) {
        st = api_fail(err, errsz, DEFSIM_ERR_UNSUPPORTED, "defsim_scene_export: the world is at "
                  "t = %.17g s and its scene has keyed paths (drives, moving targets or "
                  "colliders): a scene starts at t = 0 and would replay them from their start",
                  t);
        goto done;
    }
    x = malloc(3 * (size_t)(nv > 0 ? nv : 1) * sizeof *x);
    v = malloc(3 * (size_t)(nv > 0 ? nv : 1) * sizeof *v);
    if (!x || !v) { st = DEFSIM_ERR_OUT_OF_MEMORY; goto done; }
    if (nv > 0 && ((st = defsim_world_get_positions(w, x, nv)) != DEFSIM_OK ||
                   (st = defsim_world_get_velocities(w, v, nv)) != DEFSIM_OK))
        goto done;
    for (int32_t i = 0, off = 0; i < k.nbodies; ++i) {
        k.bodies[i].offset = off;
        off += k.bodies[i].nv;
    }
    for (int32_t i = 0; i < k.ncolls; ++i) {
        const xcoll *c = &k.colls[i];
        if (c->shape < 0 || c->shape > DEFSIM_SHAPE_MESH) {
            st = api_fail(err, errsz, DEFSIM_ERR_UNSUPPORTED, "defsim_scene_export: collider %d is %s: "
                      "a scene holds planes, spheres, boxes, capsules and meshes", (int)i,
                      c->shape == DEFSIM_SHAPE_SDF ? "an SDF (a host function)" : "unknown");
            goto done;
        }
        if (memcmp(c->pos, c->next_pos, sizeof c->pos) || memcmp(c->rot, c->next_rot, sizeof c->rot)) {
            st = api_fail(err, errsz, DEFSIM_ERR_UNSUPPORTED, "defsim_scene_export: collider %d has "
                      "a pose set for the next step (defsim_collider_set_pose); a scene cannot "
                      "hold it: export before setting it or after the step", (int)i);
            goto done;
        }
    }

    put(&o, "{\n\"description\": ");
    char desc[256];
    snprintf(desc, sizeof desc, "exported by defsim_scene_export from a world at t = %.17g s", t);
    str(&o, desc);
    put(&o, ",\n\"world\": {\"backend\": ");
    str(&o, k.backend);
    put(&o, ", \"h\": "); num(&o, h);
    put(&o, ", \"duration\": "); num(&o, duration);
    if (s) put(&o, ", \"frame_steps\": %d", (int)s->frame_steps);
    put(&o, ", \"gravity\": "); vec(&o, k.gravity, 3);
    put(&o, ", \"threads\": %d", (int)k.threads);
    if ((st = write_options(&o, w)) != DEFSIM_OK) goto done;
    put(&o, "},\n\"bodies\": [");
    for (int32_t i = 0; i < k.nbodies; ++i) {
        const scene_body *sb = NULL;
        defsim_body_id id;
        if (s && defsim_world_body_at(w, i, &id) == DEFSIM_OK)
            for (int32_t j = 0; j < s->nbodies; ++j)
                if (same_id(s->bodies[j].id, id)) sb = &s->bodies[j];
        if ((st = write_body(&o, &k, i, sb, x, v, s, err, errsz)) != DEFSIM_OK) goto done;
    }
    put(&o, "]");
    for (int32_t i = 0; i < k.natts; ++i) {
        const xatt *a = &k.atts[i];
        const int b = index_of_body(&k, a->body);
        const int tb = a->tbody[0] || a->tbody[1] ? index_of_body(&k, a->tbody) : -2;
        if (b < 0 || tb == -1) {
            st = api_fail(err, errsz, DEFSIM_ERR_UNSUPPORTED, "defsim_scene_export: attachment %d "
                      "names a body the checkpoint does not hold", (int)i);
            goto done;
        }
        const scene_attachment *sa = NULL;
        defsim_attachment_id id;
        if (s && defsim_world_attachment_at(w, i, &id) == DEFSIM_OK)
            for (int32_t j = 0; j < s->nattachments; ++j)
                if (s->attachments[j].id.index == id.index &&
                    s->attachments[j].id.generation == id.generation)
                    sa = &s->attachments[j];
        put(&o, i ? ",\n  {\"body\": %d, \"vertex\": %d, \"stiffness\": "
                  : ",\n\"attachments\": [\n  {\"body\": %d, \"vertex\": %d, \"stiffness\": ",
            b, (int)a->vertex);
        num(&o, a->k);
        put(&o, ", \"damping\": ");
        num(&o, a->c);
        if (tb >= 0) {
            put(&o, ", \"target\": {\"body\": %d, \"vertices\": [", tb);
            for (int q = 0; q < a->tcount && q < 4; ++q) put(&o, q ? ", %d" : "%d", (int)a->tverts[q]);
            put(&o, "], \"weights\": ");
            vec(&o, a->weights, a->tcount < 4 ? a->tcount : 4);
            put(&o, "}}");
        } else if (sa && sa->path >= 0) {
            put(&o, ", \"target\": {\"point\": ");
            vec(&o, sa->anchor, 3);
            put(&o, ", \"keys\": ");
            write_path(&o, &s->paths[sa->path]);
            put(&o, "}}");
        } else {
            put(&o, ", \"target\": {\"point\": ");
            vec(&o, a->target, 3);
            put(&o, "}}");
        }
        if (i == k.natts - 1) put(&o, "]");
    }
    for (int32_t i = 0; i < k.ncolls; ++i) {
        const xcoll *c = &k.colls[i];
        defsim_collider_id id;
        defsim_collider_def d;
        defsim_collider_def_init(&d, sizeof d);
        if ((st = defsim_world_get_collider(w, i, &id, &d)) != DEFSIM_OK) goto done;
        const scene_collider *sc = NULL;
        for (int32_t j = 0; s && j < s->ncolliders; ++j)
            if (s->colliders[j].id.index == id.index &&
                s->colliders[j].id.generation == id.generation)
                sc = &s->colliders[j];
        put(&o, i ? ",\n  {\"shape\": \"%s\"" : ",\n\"colliders\": [\n  {\"shape\": \"%s\"",
            SHAPES[c->shape]);
        /* The stored pose and normal, kept bit for bit ("normalized"); a collider on a path
         * has its poses normalised by the library at each step, and its plane normal too: the
         * scene's own normal then, which the library normalises as it did. */
        const int keyed = sc && sc->nkeys > 0;
        put(&o, ", \"normalized\": true, \"position\": "); vec(&o, c->pos, 3);
        put(&o, ", \"rotation\": "); vec(&o, c->rot, 4);
        put(&o, ", \"friction\": "); num(&o, c->friction);
        switch (c->shape) {
        case DEFSIM_SHAPE_PLANE:
            put(&o, ", \"normal\": ");
            vec(&o, keyed ? sc->def.normal : c->normal, 3);
            break;
        case DEFSIM_SHAPE_SPHERE: put(&o, ", \"radius\": "); num(&o, c->radius); break;
        case DEFSIM_SHAPE_BOX: put(&o, ", \"half_extents\": "); vec(&o, c->half, 3); break;
        case DEFSIM_SHAPE_CAPSULE:
            put(&o, ", \"radius\": "); num(&o, c->radius);
            put(&o, ", \"half_height\": "); num(&o, c->half_height);
            break;
        case DEFSIM_SHAPE_MESH:
            put(&o, ",\n    \"vertices\": ");
            rows(&o, d.vertices, d.vertex_count, 3);
            put(&o, ",\n    \"triangles\": ");
            irows(&o, d.triangles, d.triangle_count, 3);
            break;
        }
        if (sc && sc->nkeys > 0) {
            put(&o, ",\n    \"path\": [");
            for (int32_t q = 0; q < sc->nkeys; ++q) {
                const double *key = sc->key + 8 * (int64_t)q;
                put(&o, q ? ", {\"t\": " : "{\"t\": ");
                num(&o, key[0]);
                put(&o, ", \"position\": "); vec(&o, key + 1, 3);
                put(&o, ", \"rotation\": "); vec(&o, key + 4, 4);
                put(&o, "}");
            }
            put(&o, "]");
        }
        put(&o, "}");
        if (i == k.ncolls - 1) put(&o, "]");
    }
    put(&o, "\n}\n");
    if (o.oom) { st = DEFSIM_ERR_OUT_OF_MEMORY; goto done; }
    *json = o.p;
    if (length) *length = o.n;
    o.p = NULL;
    st = DEFSIM_OK;
done:
    if (st == DEFSIM_ERR_OUT_OF_MEMORY && err && errsz && !err[0])
        api_fail(err, errsz, st, "defsim_scene_export: out of memory");
    free(o.p);
    free(x);
    free(v);
    ckpt_free(&k);
    defsim_buffer_free(data);
    return st;
}

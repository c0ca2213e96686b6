/* SPDX-License-Identifier: MIT */
/*
 * Body-body and self-contact (body_contact.h; docs/body-contact.md).
 *
 * Contents: surfaces; the broad phase and candidate pairs; one pair's barrier and one friction
 * pair's potential; energy, forces, matrix values and products; CCD and the feasible start; the
 * pattern; the start and end of a step.
 *
 * Per evaluation point x: candidates from the sorted hash (built only when x leaves the boxes
 * they were built for), the constraint set at x (built once, reused by every phase at that x),
 * then per-contact values computed in parallel into per-contact slots and summed or scattered
 * serially in the set's canonical order: results do not depend on the thread count.
 */
#include "body_contact.h"

#include "array.h"
#include "assembly.h"

#include "clock.h"
#include "contact.h"
#include "contact_barrier.h"
#include "contact_pair.h"
#include "contact_prim.h"
#include "mat3.h"
#include "mesh.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* CCD: no pair comes closer than this fraction of its distance in one line-search step, nor
 * than BC_CCD_NEAR of its distance or of dhat, whichever is less (ccd_fraction). */
#define BC_CCD_FRACTION 0.1
#define BC_CCD_NEAR 0.2
#define BC_CCD_ITERATIONS 5000
/* Room around each vertex's box when candidates are built (times dhat): Newton updates smaller
 * than this reuse them. */
#define BC_BOX_SLACK 0.25
static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* min and max without libm's calls (NaN: either operand) */
static double dmin(double a, double b) { return b < a ? b : a; }
static double dmax(double a, double b) { return b > a ? b : a; }

static int grow(void **p, int64_t *cap, int64_t need, size_t elem)
{
    return defsim__grow(p, cap, need, elem, 64);
}

/* ------------------------------------------------------------------------------------------ */
/* Surfaces */

void defsim__body_contact_unplan(defsim__body_contact *bc)
{
    free(bc->face); free(bc->edge); free(bc->vert); free(bc->rope);
    free(bc->face_body); free(bc->edge_body); free(bc->vert_body); free(bc->edge_len2);
    free(bc->self_contact); free(bc->group); free(bc->mask); free(bc->mu); free(bc->half);
    free(bc->vlo); free(bc->vhi); free(bc->lo); free(bc->hi); free(bc->scratch); free(bc->conx);
    bc->vlo = bc->vhi = bc->conx = NULL;
    bc->have_pairs = 0;
    bc->con_valid = 0;
    bc->ncon = 0;
    free(bc->clo); free(bc->chi); free(bc->cmap); free(bc->blo); free(bc->bhi); free(bc->bactive);
    bc->clo = bc->chi = bc->blo = bc->bhi = NULL;
    bc->cmap = NULL;
    bc->bactive = NULL;
    bc->face = bc->edge = bc->vert = bc->rope = NULL;
    bc->face_body = bc->edge_body = bc->vert_body = bc->self_contact = NULL;
    bc->edge_len2 = bc->mu = bc->half = bc->lo = bc->hi = bc->scratch = NULL;
    bc->group = bc->mask = NULL;
    bc->nface = bc->nedge = bc->nvert = bc->nrope = bc->nbody = 0;
    bc->npair = bc->nfric = 0;
    bc->npend = 0;
    bc->planned = 0;
}

void defsim__body_contact_free(defsim__body_contact *bc)
{
    defsim__body_contact_unplan(bc);
    free(bc->kind); free(bc->pa); free(bc->pb);
    free(bc->con); free(bc->ctmp); free(bc->act); free(bc->sv); free(bc->sg); free(bc->sh);
    free(bc->fric);
    free(bc->pend);
    free(bc->keep);
    defsim__hash_free(&bc->hash);
    memset(bc, 0, sizeof *bc);
}

/* One body's faces and edges (global indices) appended to the lists. */
static defsim_status add_surface(defsim__body_contact *bc, const defsim__body *b, int64_t *capf,
                                 int64_t *cape)
{
    int32_t *tris = NULL, nt = 0;
    defsim_status st = DEFSIM_OK;
    if (b->ntri > 0) {
        tris = malloc(3 * (size_t)b->ntri * sizeof *tris);
        if (!tris) return DEFSIM_ERR_OUT_OF_MEMORY;
        memcpy(tris, b->tris, 3 * (size_t)b->ntri * sizeof *tris);
        nt = b->ntri;
    } else if (b->nt > 0) {
        if ((st = defsim__tet_surface(b->rest, b->tets, b->tet_nodes, b->nt, &tris, &nt)) != DEFSIM_OK)
            return st;
    }
    int32_t *edges = NULL, ne = 0;
    const int rope = nt == 0 && b->nedge > 0;
    if (nt > 0 && (st = defsim__triangle_edges(tris, nt, &edges, &ne)) != DEFSIM_OK) goto done;
    if (rope) ne = b->nedge;
    if (!grow((void **)&bc->face, capf, 3 * ((int64_t)bc->nface + nt), sizeof(int32_t)) ||
        !grow((void **)&bc->edge, cape, 2 * ((int64_t)bc->nedge + ne), sizeof(int32_t))) {
        st = DEFSIM_ERR_OUT_OF_MEMORY;
        goto done;
    }
    for (int64_t k = 0; k < 3 * (int64_t)nt; ++k)
        bc->face[3 * (int64_t)bc->nface + k] = tris[k] + b->offset;
    const int32_t *src = rope ? b->edges : edges;
    for (int64_t k = 0; k < 2 * (int64_t)ne; ++k)
        bc->edge[2 * (int64_t)bc->nedge + k] = src[k] + b->offset;
    bc->nface += nt;
    bc->nedge += ne;
done:
    free(tris);
    free(edges);
    return st;
}

static defsim_status plan(defsim__body_contact *bc, const defsim__body *bodies, int32_t nbodies,
                          int32_t nv)
{
    defsim__body_contact_unplan(bc);
    int64_t capf = 0, cape = 0;
    int32_t *fb_end = calloc((size_t)nbodies + 1, sizeof *fb_end);
    int32_t *eb_end = calloc((size_t)nbodies + 1, sizeof *eb_end);
    uint8_t *rope_body = calloc((size_t)nbodies + 1, 1);
    defsim_status st = fb_end && eb_end && rope_body ? DEFSIM_OK : DEFSIM_ERR_OUT_OF_MEMORY;
    for (int32_t b = 0; b < nbodies && st == DEFSIM_OK; ++b) {
        if (bodies[b].generation & 1u) st = add_surface(bc, &bodies[b], &capf, &cape);
        fb_end[b] = bc->nface;
        eb_end[b] = bc->nedge;
        rope_body[b] = bodies[b].ntri == 0 && bodies[b].nt == 0 && bodies[b].nedge > 0;
    }
    const size_t nf = (size_t)(bc->nface > 0 ? bc->nface : 1);
    const size_t ne = (size_t)(bc->nedge > 0 ? bc->nedge : 1);
    const size_t nb = (size_t)(nbodies > 0 ? nbodies : 1);
    int32_t *mark = calloc((size_t)(nv > 0 ? nv : 1), sizeof *mark);
    if (st == DEFSIM_OK) {
        bc->face_body = malloc(nf * sizeof *bc->face_body);
        bc->edge_body = malloc(ne * sizeof *bc->edge_body);
        bc->edge_len2 = malloc(ne * sizeof *bc->edge_len2);
        bc->rope = malloc(ne * sizeof *bc->rope);
        bc->self_contact = malloc(nb * sizeof *bc->self_contact);
        bc->group = malloc(nb * sizeof *bc->group);
        bc->mask = malloc(nb * sizeof *bc->mask);
        bc->mu = malloc(nb * sizeof *bc->mu);
        bc->half = malloc(nb * sizeof *bc->half);
        bc->vlo = malloc(3 * (size_t)(nv > 0 ? nv : 1) * sizeof *bc->vlo);
        bc->vhi = malloc(3 * (size_t)(nv > 0 ? nv : 1) * sizeof *bc->vhi);
        bc->conx = malloc(3 * (size_t)(nv > 0 ? nv : 1) * sizeof *bc->conx);
        bc->scratch = malloc(3 * (size_t)(nv > 0 ? nv : 1) * sizeof *bc->scratch);
        if (!mark || !bc->face_body || !bc->edge_body || !bc->edge_len2 || !bc->rope ||
            !bc->self_contact || !bc->group || !bc->mask || !bc->mu || !bc->half || !bc->vlo ||
            !bc->vhi || !bc->conx || !bc->scratch)
            st = DEFSIM_ERR_OUT_OF_MEMORY;
    }
    if (st == DEFSIM_OK) {
        int32_t b = 0;
        for (int32_t f = 0; f < bc->nface; ++f) {
            while (f >= fb_end[b]) ++b;
            bc->face_body[f] = b;
        }
        b = 0;
        for (int32_t e = 0; e < bc->nedge; ++e) {
            while (e >= eb_end[b]) ++b;
            bc->edge_body[e] = b;
            const defsim__body *bd = &bodies[b];
            const double *p = bd->rest + 3 * (int64_t)(bc->edge[2 * (int64_t)e] - bd->offset);
            const double *q = bd->rest + 3 * (int64_t)(bc->edge[2 * (int64_t)e + 1] - bd->offset);
            const double d[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
            bc->edge_len2[e] = dot3(d, d);
            if (rope_body[b]) bc->rope[bc->nrope++] = e;
        }
        /* Surface vertices: those of a face or an edge, in vertex order (bodies are in vertex
         * order, so they come grouped by body). */
        for (int64_t k = 0; k < 3 * (int64_t)bc->nface; ++k) mark[bc->face[k]] = 1;
        for (int64_t k = 0; k < 2 * (int64_t)bc->nedge; ++k) mark[bc->edge[k]] = 1;
        for (int32_t i = 0; i < nv; ++i) bc->nvert += mark[i];
        bc->vert = malloc((size_t)(bc->nvert > 0 ? bc->nvert : 1) * sizeof *bc->vert);
        bc->vert_body = malloc((size_t)(bc->nvert > 0 ? bc->nvert : 1) * sizeof *bc->vert_body);
        const size_t nbox = (size_t)bc->nvert + (size_t)bc->nface + (size_t)bc->nedge +
                            (size_t)bc->nrope + 1;
        bc->lo = malloc(3 * nbox * sizeof *bc->lo);
        bc->hi = malloc(3 * nbox * sizeof *bc->hi);
        bc->clo = malloc(3 * nbox * sizeof *bc->clo);
        bc->chi = malloc(3 * nbox * sizeof *bc->chi);
        bc->cmap = malloc(nbox * sizeof *bc->cmap);
        bc->blo = malloc(3 * nb * sizeof *bc->blo);
        bc->bhi = malloc(3 * nb * sizeof *bc->bhi);
        bc->bactive = malloc(nb);
        if (!bc->vert || !bc->vert_body || !bc->lo || !bc->hi || !bc->clo || !bc->chi ||
            !bc->cmap || !bc->blo || !bc->bhi || !bc->bactive)
            st = DEFSIM_ERR_OUT_OF_MEMORY;
    }
    if (st == DEFSIM_OK) {
        int32_t k = 0, b = 0;
        for (int32_t i = 0; i < nv; ++i) {
            if (!mark[i]) continue;
            while (!(bodies[b].generation & 1u) || i >= bodies[b].offset + bodies[b].nv) ++b;
            bc->vert[k] = i;
            bc->vert_body[k++] = b;
        }
    }
    free(mark);
    free(fb_end);
    free(eb_end);
    free(rope_body);
    if (st != DEFSIM_OK) {
        defsim__body_contact_unplan(bc);
        return st;
    }
    bc->nv = nv;
    bc->nbody = nbodies;
    bc->planned = 1;
    bc->fresh = 1;
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* The broad phase and candidate pairs */

/* The global vertices of candidate (kind, a, b) (4, or 3 for point-edge); returns their count. */
static int nodes(const defsim__body_contact *bc, uint8_t kind, int32_t a, int32_t b,
                 int32_t idx[4])
{
    if (kind == DEFSIM__BC_PT) {
        idx[0] = bc->vert[a];
        for (int k = 0; k < 3; ++k) idx[1 + k] = bc->face[3 * (int64_t)b + k];
        return 4;
    }
    if (kind == DEFSIM__BC_EE) {
        idx[0] = bc->edge[2 * (int64_t)a];
        idx[1] = bc->edge[2 * (int64_t)a + 1];
        idx[2] = bc->edge[2 * (int64_t)b];
        idx[3] = bc->edge[2 * (int64_t)b + 1];
        return 4;
    }
    idx[0] = bc->vert[a];
    idx[1] = bc->edge[2 * (int64_t)b];
    idx[2] = bc->edge[2 * (int64_t)b + 1];
    idx[3] = -1;
    return 3;
}

static int filtered(const defsim__body_contact *bc, int32_t ba, int32_t bb)
{
    if (ba == bb) return !bc->self_contact[ba];
    return !((bc->group[ba] & bc->mask[bb]) && (bc->group[bb] & bc->mask[ba]));
}

static double dist2(uint8_t kind, const double *X, double *g, double *H);

/* The dense indices of the two bodies of candidate (kind, a, b). */
static void pair_bodies(const defsim__body_contact *bc, uint8_t kind, int32_t a, int32_t b,
                        int32_t *ba, int32_t *bb)
{
    if (kind == DEFSIM__BC_PT) *ba = bc->vert_body[a], *bb = bc->face_body[b];
    else if (kind == DEFSIM__BC_EE) *ba = bc->edge_body[a], *bb = bc->edge_body[b];
    else *ba = bc->vert_body[a], *bb = bc->edge_body[b];
}

/* The thickness offset of candidate q: its bodies' half-thicknesses summed (m). */
static double pair_xi(const defsim__body_contact *bc, int32_t q)
{
    int32_t ba, bb;
    pair_bodies(bc, bc->kind[q], bc->pa[q], bc->pb[q], &ba, &bb);
    return bc->half[ba] + bc->half[bb];
}

/* Appends candidate (kind, a, b) unless the filter excludes it, its primitives share a vertex
 * (adjacent), all its vertices are pinned or it cannot come within dhat inside the boxes. */
static void add_pair(defsim__body_contact *bc, uint8_t kind, int32_t a, int32_t b)
{
    int32_t idx[4];
    const int n = nodes(bc, kind, a, b, idx);
    /* neighbours in a surface first: the most common rejection, and the cheapest */
    for (int i = 1; i < n; ++i)
        for (int j = 0; j < i; ++j)
            if (idx[i] == idx[j]) return;   /* adjacent primitives share a vertex */
    int32_t ba, bb;
    pair_bodies(bc, kind, a, b, &ba, &bb);
    if (filtered(bc, ba, bb)) return;
    int free_node = 0;
    for (int i = 0; i < n; ++i) free_node |= !bc->pinned[idx[i]];
    if (!free_node) return;
    /* Boxes that overlap may still be too far apart to meet: while every vertex stays in its box
     * (within |dx_i| + sqrt(3) r of x_i), the pair's distance stays above its distance at x less
     * the largest such reach on each side. */
    const double r = sqrt(3.0) * BC_BOX_SLACK * bc->dhat;
    double X[12], ra = r, rb = r;
    const int first = kind == DEFSIM__BC_EE ? 2 : 1;
    double la2 = 0.0, lb2 = 0.0;
    for (int i = 0; i < n; ++i) {
        const int64_t v = 3 * (int64_t)idx[i];
        memcpy(X + 3 * i, bc->bx + v, 3 * sizeof(double));
        if (!bc->bdx) continue;
        const double l2 = dot3(bc->bdx + v, bc->bdx + v);
        if (i < first) la2 = l2 > la2 ? l2 : la2;
        else lb2 = l2 > lb2 ? l2 : lb2;
    }
    if (bc->bdx) {
        ra += sqrt(la2);
        rb += sqrt(lb2);
    }
    /* within dhat beyond the thickness offset */
    const double reach = (ra + rb + bc->dhat + (bc->half[ba] + bc->half[bb])) * (1.0 + 1e-9);
    /* Lower bounds of the distance before the closest features: first the distance of the lines
     * (edge-edge) or of the point to the triangle's plane (no square root) */
    if (kind != DEFSIM__BC_PE) {
        const int ee = kind == DEFSIM__BC_EE;
        const double *p0 = ee ? X : X + 3, *p1 = ee ? X + 3 : X + 6, *q0 = ee ? X + 6 : X + 3;
        const double u[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
        const double w[3] = {X[9] - q0[0], X[10] - q0[1], X[11] - q0[2]};
        const double rr[3] = {X[0] - q0[0], X[1] - q0[1], X[2] - q0[2]};
        const double nv[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                              u[0] * w[1] - u[1] * w[0]};
        const double nn = dot3(nv, nv), rn = dot3(rr, nv);
        if (nn > 0.0 && rn * rn >= reach * reach * nn * (1.0 + 1e-9)) return;
    }
    /* then the distance of the primitives' bounding spheres (about their centroids), another
     * lower bound */
    double c[2][3] = {{0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}}, rad2[2] = {0.0, 0.0};
    for (int i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) c[i >= first][k] += X[3 * i + k];
    for (int k = 0; k < 3; ++k) {
        c[0][k] /= first;
        c[1][k] /= n - first;
    }
    for (int i = 0; i < n; ++i) {
        const double *ci = c[i >= first];
        const double u[3] = {X[3 * i] - ci[0], X[3 * i + 1] - ci[1], X[3 * i + 2] - ci[2]};
        const double u2 = dot3(u, u);
        rad2[i >= first] = u2 > rad2[i >= first] ? u2 : rad2[i >= first];
    }
    /* |cc| - rad0 - rad1 >= reach, with one square root per side */
    const double cc[3] = {c[0][0] - c[1][0], c[0][1] - c[1][1], c[0][2] - c[1][2]};
    const double sep = (reach * (1.0 + 1e-9) + sqrt(rad2[0]) + sqrt(rad2[1])) * (1.0 + 1e-12);
    if (dot3(cc, cc) >= sep * sep) return;
    if (dist2(kind, X, NULL, NULL) >= reach * reach) return;
    int64_t cap = bc->cap_pair;
    if (bc->npair == cap) {
        int64_t c1 = cap, c2 = cap, c3 = cap;
        if (!grow((void **)&bc->kind, &c1, cap + 1, sizeof *bc->kind) ||
            !grow((void **)&bc->pa, &c2, cap + 1, sizeof *bc->pa) ||
            !grow((void **)&bc->pb, &c3, cap + 1, sizeof *bc->pb)) {
            bc->failed = DEFSIM_ERR_OUT_OF_MEMORY;
            return;
        }
        bc->cap_pair = (int32_t)c1;
    }
    bc->kind[bc->npair] = kind;
    bc->pa[bc->npair] = a;
    bc->pb[bc->npair++] = b;
}

/* Box of a set of vertices' boxes (vlo, vhi), grown by dhat / 2 and the half-thickness `half` of
 * the primitive's body: two primitives within dhat of each other beyond their offset (the sum of
 * their half-thicknesses) anywhere in their vertices' boxes have overlapping boxes. */
static void prim_box(const defsim__body_contact *bc, const int32_t *v, int n, double half,
                     double *lo, double *hi)
{
    const double r = 0.5 * bc->dhat + half;
    for (int k = 0; k < 3; ++k) {
        lo[k] = bc->vlo[3 * (int64_t)v[0] + k];
        hi[k] = bc->vhi[3 * (int64_t)v[0] + k];
    }
    for (int i = 1; i < n; ++i)
        for (int k = 0; k < 3; ++k) {
            lo[k] = dmin(lo[k], bc->vlo[3 * (int64_t)v[i] + k]);
            hi[k] = dmax(hi[k], bc->vhi[3 * (int64_t)v[i] + k]);
        }
    for (int k = 0; k < 3; ++k) {
        lo[k] -= r;
        hi[k] += r;
    }
}

/* Pairs from the hash's last query, mapped back from the compact lists (ma, mb). */
static void collect(defsim__body_contact *bc, uint8_t kind, const int32_t *ma, const int32_t *mb)
{
    const defsim__hash *h = &bc->hash;
    for (int64_t k = 0; k < h->npairs && !bc->failed; ++k) {
        const int32_t a = ma[h->pairs[k] >> 32], b = mb[h->pairs[k] & 0xFFFFFFFF];
        add_pair(bc, kind, a, kind == DEFSIM__BC_PE ? bc->rope[b] : b);
    }
}

/* Copies the boxes of the primitives whose body takes part into the compact lists; returns
 * their count. */
static int32_t compact(const defsim__body_contact *bc, const int32_t *body, const int32_t *sel,
                       int32_t n, const double *lo, const double *hi, double *clo, double *chi,
                       int32_t *map)
{
    int32_t m = 0;
    for (int32_t i = 0; i < n; ++i) {
        const int32_t k = sel ? sel[i] : i;
        if (!bc->bactive[body[k]]) continue;
        memcpy(clo + 3 * (int64_t)m, lo + 3 * (int64_t)k, 3 * sizeof(double));
        memcpy(chi + 3 * (int64_t)m, hi + 3 * (int64_t)k, 3 * sizeof(double));
        map[m++] = i;
    }
    return m;
}

/* The candidate pairs for the vertices' boxes vlo, vhi (a point each, or a segment for CCD):
 * point-triangle, edge-edge and point-edge (ropes) pairs whose primitive boxes, grown by
 * dhat / 2, overlap. Bodies that can meet nothing (no self-contact, and no body they collide with
 * whose box meets theirs) stay out of the hash. Cost: linear in the surface for boxes about the
 * size of a primitive (the hash's cells are the mean box size). */
static void broad(defsim__body_contact *bc)
{
    const double t0 = defsim__now();
    const int64_t nvb = bc->nvert, nfb = bc->nface, neb = bc->nedge;
    double *vlo = bc->lo, *vhi = bc->hi;
    double *flo = vlo + 3 * nvb, *fhi = vhi + 3 * nvb;
    double *elo = flo + 3 * nfb, *ehi = fhi + 3 * nfb;
    for (int64_t i = 0; i < nvb; ++i)
        prim_box(bc, bc->vert + i, 1, bc->half[bc->vert_body[i]], vlo + 3 * i, vhi + 3 * i);
    for (int64_t f = 0; f < nfb; ++f)
        prim_box(bc, bc->face + 3 * f, 3, bc->half[bc->face_body[f]], flo + 3 * f, fhi + 3 * f);
    for (int64_t e = 0; e < neb; ++e)
        prim_box(bc, bc->edge + 2 * e, 2, bc->half[bc->edge_body[e]], elo + 3 * e, ehi + 3 * e);
    /* bodies' boxes (of their surface vertices' boxes) and which of them take part */
    const int32_t nb = bc->nbody;
    for (int32_t b = 0; b < nb; ++b)
        for (int k = 0; k < 3; ++k) {
            bc->blo[3 * (int64_t)b + k] = INFINITY;
            bc->bhi[3 * (int64_t)b + k] = -INFINITY;
        }
    for (int64_t i = 0; i < nvb; ++i) {
        const int32_t b = bc->vert_body[i];
        for (int k = 0; k < 3; ++k) {
            bc->blo[3 * (int64_t)b + k] = dmin(bc->blo[3 * (int64_t)b + k], vlo[3 * i + k]);
            bc->bhi[3 * (int64_t)b + k] = dmax(bc->bhi[3 * (int64_t)b + k], vhi[3 * i + k]);
        }
    }
    for (int32_t b = 0; b < nb; ++b) {
        int on = bc->self_contact[b] != 0;
        for (int32_t c = 0; c < nb && !on; ++c) {
            if (c == b || filtered(bc, b, c)) continue;
            int meet = 1;
            for (int k = 0; k < 3 && meet; ++k)
                meet = bc->blo[3 * (int64_t)b + k] <= bc->bhi[3 * (int64_t)c + k] &&
                       bc->blo[3 * (int64_t)c + k] <= bc->bhi[3 * (int64_t)b + k];
            on = meet;
        }
        bc->bactive[b] = (uint8_t)on;
    }
    double *cvlo = bc->clo, *cvhi = bc->chi;
    int32_t *vmap = bc->cmap;
    const int32_t nv = compact(bc, bc->vert_body, NULL, bc->nvert, vlo, vhi, cvlo, cvhi, vmap);
    double *cflo = cvlo + 3 * (int64_t)nv, *cfhi = cvhi + 3 * (int64_t)nv;
    int32_t *fmap = vmap + nv;
    const int32_t nf = compact(bc, bc->face_body, NULL, bc->nface, flo, fhi, cflo, cfhi, fmap);
    double *celo = cflo + 3 * (int64_t)nf, *cehi = cfhi + 3 * (int64_t)nf;
    int32_t *emap = fmap + nf;
    const int32_t ne = compact(bc, bc->edge_body, NULL, bc->nedge, elo, ehi, celo, cehi, emap);
    double *crlo = celo + 3 * (int64_t)ne, *crhi = cehi + 3 * (int64_t)ne;
    int32_t *rmap = emap + ne;
    const int32_t nr = compact(bc, bc->edge_body, bc->rope, bc->nrope, elo, ehi, crlo, crhi, rmap);
    bc->npair = 0;
    if (nf > 0 && nv > 0) {
        if (defsim__hash_pairs(&bc->hash, cvlo, cvhi, nv, cflo, cfhi, nf, 0, 0.0) != DEFSIM_OK)
            bc->failed = DEFSIM_ERR_OUT_OF_MEMORY;
        else
            collect(bc, DEFSIM__BC_PT, vmap, fmap);
    }
    if (ne > 1 && !bc->failed) {
        if (defsim__hash_pairs(&bc->hash, celo, cehi, ne, celo, cehi, ne, 1, 0.0) != DEFSIM_OK)
            bc->failed = DEFSIM_ERR_OUT_OF_MEMORY;
        else
            collect(bc, DEFSIM__BC_EE, emap, emap);
    }
    if (nr > 0 && nv > 0 && !bc->failed) {
        if (defsim__hash_pairs(&bc->hash, cvlo, cvhi, nv, crlo, crhi, nr, 0, 0.0) != DEFSIM_OK)
            bc->failed = DEFSIM_ERR_OUT_OF_MEMORY;
        else
            collect(bc, DEFSIM__BC_PE, vmap, rmap);
    }
    bc->have_pairs = !bc->failed;
    bc->cand_dhat = bc->dhat;
    bc->broads++;
    bc->stat[DEFSIM__CSTAT_BODY_CANDIDATES] = bc->npair;
    bc->stat[DEFSIM__CSTAT_TIME_BODY_BROAD] += defsim__now() - t0;
}

/* Whether the candidates cover x (and x + dx when dx is not NULL): every surface vertex lies in
 * the box they were built for, so every primitive pair within dhat there is a candidate. */
static int covers(const defsim__body_contact *bc, const double *x, const double *dx)
{
    if (!bc->have_pairs) return 0;
    for (int32_t k = 0; k < bc->nvert; ++k) {
        const int64_t i = 3 * (int64_t)bc->vert[k];
        for (int c = 0; c < 3; ++c) {
            const double a = x[i + c], lo = bc->vlo[i + c], hi = bc->vhi[i + c];
            if (!(a >= lo && a <= hi)) return 0;
            if (dx) {
                const double b = a + dx[i + c];
                if (!(b >= lo && b <= hi)) return 0;
            }
        }
    }
    return 1;
}

/* Candidates for x (and the segment to x + dx when dx is not NULL), rebuilt unless the current
 * ones cover it. The vertices' boxes take BC_BOX_SLACK dhat of room: the small updates of a
 * converging Newton solve stay inside, and reuse them. */
static void ensure(defsim__body_contact *bc, const double *x, const double *dx)
{
    if (covers(bc, x, dx)) return;
    const double r = BC_BOX_SLACK * bc->dhat;
    for (int32_t k = 0; k < bc->nvert; ++k) {
        const int64_t i = 3 * (int64_t)bc->vert[k];
        for (int c = 0; c < 3; ++c) {
            const double a = x[i + c], b = dx ? a + dx[i + c] : a;
            bc->vlo[i + c] = dmin(a, b) - r;
            bc->vhi[i + c] = dmax(a, b) + r;
        }
    }
    bc->bx = x;
    bc->bdx = dx;
    broad(bc);
    bc->bx = bc->bdx = NULL;
}

defsim_status defsim__body_contact_candidates(defsim__body_contact *bc, const double *x)
{
    bc->have_pairs = 0;
    ensure(bc, x, NULL);
    return bc->failed;
}

/* ------------------------------------------------------------------------------------------ */
/* The constraint set */

static void gather(const double *x, const int32_t *idx, int n, double *X)
{
    for (int i = 0; i < n; ++i) memcpy(X + 3 * i, x + 3 * (int64_t)idx[i], 3 * sizeof(double));
}

/* Squared distance of candidate (kind, X). */
static double dist2(uint8_t kind, const double *X, double *g, double *H)
{
    if (kind == DEFSIM__BC_PT) return defsim__pt_dist2(X, X + 3, X + 6, X + 9, g, H, NULL);
    if (kind == DEFSIM__BC_EE) return defsim__ee_dist2(X, X + 3, X + 6, X + 9, g, H, NULL);
    return defsim__pe_dist2(X, X + 3, X + 6, g, H, NULL);
}

/* The barrier's stiffness for a contact: khat times the mean mass of its vertices. */
static double pair_kappa(const defsim__body_contact *bc, const int32_t *idx, int n)
{
    double m = 0.0;
    for (int i = 0; i < n; ++i) m += bc->mass[idx[i]];
    return bc->khat * m / n;
}

/* Where the closest point of segment (a, b) to p lies: 0 at a, 1 at b, 2 inside. */
static int segment_region(const double *p, const double *a, const double *b)
{
    const double e[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double r[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
    const double t = dot3(r, e), l2 = dot3(e, e);
    return t <= 0.0 ? 0 : t >= l2 ? 1 : 2;
}

/* The parameters s, t in [0, 1] of the closest points of segments (a0, a1) and (b0, b1) (X: the
 * four ends), clamped line parameters. */
static void segment_params(const double *X, double *ps, double *pt)
{
    const double *p1 = X, *q1 = X + 3, *p2 = X + 6, *q2 = X + 9;
    const double d1[3] = {q1[0] - p1[0], q1[1] - p1[1], q1[2] - p1[2]};
    const double d2[3] = {q2[0] - p2[0], q2[1] - p2[1], q2[2] - p2[2]};
    const double r[3] = {p1[0] - p2[0], p1[1] - p2[1], p1[2] - p2[2]};
    const double a = dot3(d1, d1), e = dot3(d2, d2), f = dot3(d2, r), c = dot3(d1, r);
    const double b = dot3(d1, d2), den = a * e - b * b;
    double s = den > 1e-12 * a * e ? (b * f - c * e) / den : 0.0;
    s = s < 0.0 ? 0.0 : s > 1.0 ? 1.0 : s;
    double t = e > 0.0 ? (b * s + f) / e : 0.0;
    if (t < 0.0 || t > 1.0) {
        t = t < 0.0 ? 0.0 : 1.0;
        s = a > 0.0 ? (b * t - c) / a : 0.0;
        s = s < 0.0 ? 0.0 : s > 1.0 ? 1.0 : s;
    }
    *ps = s;
    *pt = t;
}

/* The closest points of segments (a0, a1) and (b0, b1) as regions (0 at the first end, 1 at the
 * second, 2 inside) on each. */
static void edges_region(const double *X, int *ra, int *rb)
{
    double s, t;
    segment_params(X, &s, &t);
    *ra = s <= 0.0 ? 0 : s >= 1.0 ? 1 : 2;
    *rb = t <= 0.0 ? 0 : t >= 1.0 ? 1 : 2;
}

static void swap32(int32_t *a, int32_t *b)
{
    const int32_t t = *a;
    *a = *b;
    *b = t;
}

/* Candidate q at x as a contact (IPC's Collisions::build): its closest features decide the type
 * (a point-triangle candidate whose closest feature is a vertex or an edge becomes vertex-vertex
 * or edge-vertex; so does an edge-edge candidate whose closest points are an end or two, unless
 * the edges are nearly parallel, |ea x eb|^2 < eps, where it stays edge-edge for the mollifier).
 * Vertices in canonical order (a contact found from several candidates has one key); kappa is
 * the candidate's own (khat times the mean mass of its vertices): duplicates add their kappa, so
 * the merged set's energy is the sum over the candidates within dhat, continuous where a closest
 * feature changes. Sets out->type -1 when it is not within dhat. */
static void candidate_contact(const defsim__body_contact *bc, int32_t q, const double *x,
                              defsim__bc_contact *out)
{
    const uint8_t kind = bc->kind[q];
    int32_t idx[4], *v = out->v;
    const int n = nodes(bc, kind, bc->pa[q], bc->pb[q], idx);
    double X[12];
    gather(x, idx, n, X);
    out->type = -1;
    out->eps = 0.0;
    v[0] = v[1] = v[2] = v[3] = -1;
    if (kind == DEFSIM__BC_PT) {
        double w[3];
        const int r = defsim__triangle_closest(X, X + 3, X + 6, X + 9, w);
        v[0] = idx[0];
        if (r < 3) {
            out->type = DEFSIM__C_VV;
            v[1] = idx[1 + r];
        } else if (r < 6) {
            /* the edge's ends in the triangle's order */
            static const int ends[3][2] = {{0, 1}, {1, 2}, {0, 2}};
            out->type = DEFSIM__C_EV;
            v[1] = idx[1 + ends[r - 3][0]];
            v[2] = idx[1 + ends[r - 3][1]];
        } else {
            out->type = DEFSIM__C_FV;
            v[1] = idx[1], v[2] = idx[2], v[3] = idx[3];
        }
    } else if (kind == DEFSIM__BC_PE) {
        const int r = segment_region(X, X + 3, X + 6);
        v[0] = idx[0];
        if (r < 2) {
            out->type = DEFSIM__C_VV;
            v[1] = idx[1 + r];
        } else {
            out->type = DEFSIM__C_EV;
            v[1] = idx[1], v[2] = idx[2];
        }
    } else {
        const double eps = 1e-3 * bc->edge_len2[bc->pa[q]] * bc->edge_len2[bc->pb[q]];
        const double ea[3] = {X[3] - X[0], X[4] - X[1], X[5] - X[2]};
        const double eb[3] = {X[9] - X[6], X[10] - X[7], X[11] - X[8]};
        const double cr[3] = {ea[1] * eb[2] - ea[2] * eb[1], ea[2] * eb[0] - ea[0] * eb[2],
                              ea[0] * eb[1] - ea[1] * eb[0]};
        int ra = 2, rb = 2;
        if (!(dot3(cr, cr) < eps)) edges_region(X, &ra, &rb);
        if (ra < 2 && rb < 2) {
            out->type = DEFSIM__C_VV;
            v[0] = idx[ra], v[1] = idx[2 + rb];
        } else if (ra < 2) {
            out->type = DEFSIM__C_EV;
            v[0] = idx[ra], v[1] = idx[2], v[2] = idx[3];
        } else if (rb < 2) {
            out->type = DEFSIM__C_EV;
            v[0] = idx[2 + rb], v[1] = idx[0], v[2] = idx[1];
        } else {
            out->type = DEFSIM__C_EE;
            out->eps = eps;
            for (int i = 0; i < 4; ++i) v[i] = idx[i];
            if (v[0] > v[1]) swap32(&v[0], &v[1]);
            if (v[2] > v[3]) swap32(&v[2], &v[3]);
            if (v[0] > v[2] || (v[0] == v[2] && v[1] > v[3])) {
                swap32(&v[0], &v[2]);
                swap32(&v[1], &v[3]);
            }
        }
    }
    if (out->type == DEFSIM__C_VV && v[0] > v[1]) swap32(&v[0], &v[1]);
    if (out->type == DEFSIM__C_EV && v[1] > v[2]) swap32(&v[1], &v[2]);
    const int m = defsim__contact_nodes(out->type);
    int free_node = 0;
    for (int i = 0; i < m; ++i) free_node |= !bc->pinned[v[i]];
    gather(x, v, m, X);
    pair_bodies(bc, kind, bc->pa[q], bc->pb[q], &out->body[0], &out->body[1]);
    out->xi = bc->half[out->body[0]] + bc->half[out->body[1]];
    const double reach = bc->dhat + out->xi;   /* dhat itself without thickness */
    if (!free_node || !(defsim__contact_dist2(out->type, X, NULL, NULL) < reach * reach)) {
        out->type = -1;
        return;
    }
    out->kappa = pair_kappa(bc, idx, n);
}

/* The contacts' order: type, then vertices (the key), then stiffness (so that duplicates are
 * summed in one order whatever order the candidates came in). */
static int contact_key_cmp(const defsim__bc_contact *a, const defsim__bc_contact *b)
{
    if (a->type != b->type) return a->type < b->type ? -1 : 1;
    for (int i = 0; i < 4; ++i)
        if (a->v[i] != b->v[i]) return a->v[i] < b->v[i] ? -1 : 1;
    return 0;
}

static int contact_cmp(const void *pa, const void *pb)
{
    const defsim__bc_contact *a = pa, *b = pb;
    const int c = contact_key_cmp(a, b);
    if (c) return c;
    return (a->kappa > b->kappa) - (a->kappa < b->kappa);
}

/* Room for n contacts and their slots (energy, gradient, Hessian). */
static int reserve_contacts(defsim__body_contact *bc, int32_t n)
{
    if (n <= bc->cap_con) return 1;
    const int64_t c = defsim__grown_cap(bc->cap_con, n, 64);
    void **const arrays[] = {(void **)&bc->con, (void **)&bc->sv, (void **)&bc->sg,
                             (void **)&bc->sh};
    const size_t elem[] = {sizeof *bc->con, sizeof *bc->sv, 12 * sizeof *bc->sg,
                           144 * sizeof *bc->sh};
    if (!defsim__grow_parallel(arrays, elem, 4, c)) return 0;
    bc->cap_con = (int32_t)c;
    return 1;
}

static int nthreads_of(const defsim__body_contact *bc)
{
    return bc->nthreads > 0 ? bc->nthreads : 1;
}

defsim_status defsim__body_contact_build(defsim__body_contact *bc, const double *x)
{
    ensure(bc, x, NULL);
    if (bc->failed) return bc->failed;
    bc->con_valid = 0;
    if (bc->npair > bc->cap_tmp) {
        defsim__bc_contact *t = realloc(bc->ctmp, (size_t)bc->npair * sizeof *t);
        if (!t) return bc->failed = DEFSIM_ERR_OUT_OF_MEMORY;
        bc->ctmp = t;
        int32_t *a = realloc(bc->act, (size_t)bc->npair * sizeof *a);
        if (!a) return bc->failed = DEFSIM_ERR_OUT_OF_MEMORY;
        bc->act = a;
        bc->cap_tmp = bc->npair;
    }
    const int32_t np = bc->npair;
    defsim__bc_contact *tmp = bc->ctmp;
    const int nth = nthreads_of(bc);
    (void)nth;   /* used by OpenMP pragmas only */
    /* Each candidate's contact into its own slot (any thread), then compacted, sorted and
     * deduplicated in one order: the set does not depend on the thread count, nor on the
     * candidates' order or on which pairs beyond dhat were candidates. */
#pragma omp parallel for schedule(static) num_threads(nth) if (nth > 1 && np > 512)
    for (int32_t q = 0; q < np; ++q) candidate_contact(bc, q, x, &tmp[q]);
    int32_t m = 0;
    bc->nact = 0;
    for (int32_t q = 0; q < np; ++q)
        if (tmp[q].type >= 0) {
            tmp[m++] = tmp[q];
            bc->act[bc->nact++] = q;
        }
    if (m > 1) qsort(tmp, (size_t)m, sizeof *tmp, contact_cmp);   /* tmp: NULL if none */
    if (!reserve_contacts(bc, m)) return bc->failed = DEFSIM_ERR_OUT_OF_MEMORY;
    int32_t n = 0;
    for (int k = 0; k < 4; ++k) bc->ncon_type[k] = 0;
    for (int32_t q = 0; q < m; ++q) {
        if (n > 0 && contact_key_cmp(&tmp[q], &bc->con[n - 1]) == 0) {
            bc->con[n - 1].kappa += tmp[q].kappa;   /* the multiplicity, as a weight */
            continue;
        }
        bc->con[n++] = tmp[q];
        bc->ncon_type[tmp[q].type]++;
    }
    bc->ncon = n;
    memcpy(bc->conx, x, 3 * (size_t)bc->nv * sizeof *x);
    bc->con_valid = 1;
    bc->builds++;
    return DEFSIM_OK;
}

/* The constraint set at x: the one built last if it was built at x, else a new one. */
static defsim_status constraints_at(defsim__body_contact *bc, const double *x)
{
    if (bc->failed) return bc->failed;
    if (bc->con_valid && !memcmp(bc->conx, x, 3 * (size_t)bc->nv * sizeof *x)) return DEFSIM_OK;
    return defsim__body_contact_build(bc, x);
}

/* Contact c's barrier at x: energy, and the gradient (3n) and PSD-projected Hessian (3n x 3n,
 * row-major) when g / H are not NULL (left unwritten when the energy is 0 or +inf). */
static double contact_barrier(const defsim__body_contact *bc, const defsim__bc_contact *c,
                              const double *x, double *g, double *H)
{
    double X[12];
    gather(x, c->v, defsim__contact_nodes(c->type), X);
    /* exact: a backward pass's matrix (docs/gradients.md) */
    return defsim__contact_barrier_offset(c->type, X, bc->dhat, c->xi, c->kappa, c->eps,
                                          bc->exact && H, g, H);
}

/* Friction pair r at x: energy, gradient (12) and Hessian (144, PSD) over its four nodes (an
 * unused node has weight 0). */
static double pair_friction(const defsim__body_contact *bc, int32_t r, const double *x,
                            double *g, double *H)
{
    const defsim__bc_friction *fr = &bc->fric[r];
    const int32_t *idx = fr->node;
    const double *w = fr->w, *nrm = fr->nrm;
    const double mul = fr->mul, eps = bc->eps_v * bc->h;
    double u[3] = {0.0, 0.0, 0.0}, ut[3];
    for (int i = 0; i < 4; ++i) {
        if (idx[i] < 0) continue;
        for (int k = 0; k < 3; ++k)
            u[k] += w[i] * (x[3 * (int64_t)idx[i] + k] - bc->xn[3 * (int64_t)idx[i] + k]);
    }
    const double un = dot3(u, nrm);
    for (int k = 0; k < 3; ++k) ut[k] = u[k] - un * nrm[k];
    const double y = sqrt(dot3(ut, ut));
    if (g) {
        const double s = mul * friction_f1_over_y(y, eps);
        for (int i = 0; i < 4; ++i)
            for (int k = 0; k < 3; ++k) g[3 * i + k] = w[i] * s * ut[k];
    }
    if (H) {
        double B[9] = {0};
        friction_block(mul, nrm, ut, y, eps, B);
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j)
                for (int a = 0; a < 3; ++a)
                    for (int b = 0; b < 3; ++b)
                        H[(3 * i + a) * 12 + 3 * j + b] = w[i] * w[j] * B[3 * a + b];
    }
    return mul * friction_f0(y, eps);
}

/* ------------------------------------------------------------------------------------------ */
/* Energy, forces, matrices: each contact's value into its slot (in parallel), then summed or
 * scattered serially in the set's order, so the results are the same bits for every thread
 * count. */

double defsim__body_contact_energy(defsim__body_contact *bc, const double *x)
{
    const double t0 = defsim__now();
    if (constraints_at(bc, x) != DEFSIM_OK) return INFINITY;
    const int32_t n = bc->ncon;
    const defsim__bc_contact *con = bc->con;
    double *sv = bc->sv;
    const int nth = nthreads_of(bc);
    (void)nth;
#pragma omp parallel for schedule(static) num_threads(nth) if (nth > 1 && n > 256)
    for (int32_t q = 0; q < n; ++q) sv[q] = contact_barrier(bc, &con[q], x, NULL, NULL);
    double e = 0.0;
    for (int32_t q = 0; q < n; ++q) e += sv[q];
    for (int32_t r = 0; r < bc->nfric && isfinite(e); ++r) e += pair_friction(bc, r, x, NULL, NULL);
    bc->stat[DEFSIM__CSTAT_TIME_BODY_EVAL] += defsim__now() - t0;
    return isfinite(e) ? e : INFINITY;
}

defsim_status defsim__body_contact_forces(defsim__body_contact *bc, const double *x, double *f)
{
    const double t0 = defsim__now();
    defsim_status st = constraints_at(bc, x);
    if (st != DEFSIM_OK) return st;
    const int32_t n = bc->ncon;
    const defsim__bc_contact *con = bc->con;
    double *sv = bc->sv, *sg = bc->sg;
    const int nth = nthreads_of(bc);
    (void)nth;
#pragma omp parallel for schedule(static) num_threads(nth) if (nth > 1 && n > 256)
    for (int32_t q = 0; q < n; ++q)
        sv[q] = contact_barrier(bc, &con[q], x, sg + 12 * (int64_t)q, NULL);
    for (int32_t q = 0; q < n && st == DEFSIM_OK; ++q) {
        if (!isfinite(sv[q])) {
            st = DEFSIM_ERR_UNSTABLE;
            break;
        }
        if (sv[q] == 0.0) continue;
        const double *g = sg + 12 * (int64_t)q;
        for (int i = 0; i < defsim__contact_nodes(con[q].type); ++i) {
            const int32_t v = con[q].v[i];
            if (!bc->pinned[v])
                for (int k = 0; k < 3; ++k) f[3 * (int64_t)v + k] -= g[3 * i + k];
        }
    }
    double g[12];
    for (int32_t r = 0; r < bc->nfric && st == DEFSIM_OK; ++r) {
        pair_friction(bc, r, x, g, NULL);
        const int32_t *fi = bc->fric[r].node;
        for (int i = 0; i < 4; ++i)
            if (fi[i] >= 0 && !bc->pinned[fi[i]])
                for (int k = 0; k < 3; ++k) f[3 * (int64_t)fi[i] + k] -= g[3 * i + k];
    }
    bc->stat[DEFSIM__CSTAT_TIME_BODY_EVAL] += defsim__now() - t0;
    return st;
}

/* Queues the free-vertex pairs among idx that the pattern lacks. */
static void pend(defsim__body_contact *bc, const defsim__system *s, const int32_t *idx, int n)
{
    if (!s->pattern.built) return;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            if (idx[i] < 0 || idx[j] < 0) continue;
            const int32_t fa = s->vfree[idx[i]], fb = s->vfree[idx[j]];
            if (fa < 0 || fb < 0 || fa >= fb || defsim__pattern_rank(s, fa, fb) >= 0) continue;
            /* duplicates go when the pattern merges the list */
            const int64_t key = ((int64_t)fa << 32) | fb;
            if (!grow((void **)&bc->pend, &bc->cap_pend, bc->npend + 1, sizeof *bc->pend)) {
                bc->failed = DEFSIM_ERR_OUT_OF_MEMORY;
                return;
            }
            bc->pend[bc->npend++] = key;
        }
}

/* Queues the pattern pairs of every contact of the current set. */
static void pend_set(defsim__body_contact *bc)
{
    for (int32_t k = 0; k < bc->nact && !bc->failed; ++k) {
        const int32_t q = bc->act[k];
        int32_t idx[4];
        const int n = nodes(bc, bc->kind[q], bc->pa[q], bc->pb[q], idx);
        pend(bc, bc->sys, idx, n);
    }
}

void defsim__body_contact_scatter(defsim__body_contact *bc, const defsim__system *s,
                                  const int32_t *idx, int n, const double *H, double k, int upper,
                                  const int64_t *cp, double *values)
{
    const int nd = 3 * n;
    int missing = 0;
    for (int b = 0; b < n; ++b) {
        if (idx[b] < 0) continue;
        const int32_t fb = s->vfree[idx[b]];
        if (fb < 0) continue;
        for (int a = 0; a < n; ++a) {
            if (idx[a] < 0) continue;
            const int32_t fa = s->vfree[idx[a]];
            if (fa < 0 || (upper && fa > fb)) continue;
            const int32_t r = defsim__pattern_rank(s, fa, fb);
            if (r < 0) {
                missing = 1;
                continue;
            }
            for (int cb = 0; cb < 3; ++cb) {
                const int64_t base = cp[3 * (int64_t)fb + cb] + 3 * (int64_t)r;
                const int camax = (upper && fa == fb) ? cb : 2;
                for (int ca = 0; ca <= camax; ++ca)
                    values[base + ca] += k * H[(3 * a + ca) * nd + 3 * b + cb];
            }
        }
    }
    if (missing) pend(bc, s, idx, n);
}

void defsim__body_contact_hessians(defsim__body_contact *bc, const double *x,
                                   defsim__bc_hessian_fn fn, void *ctx)
{
    const double t0 = defsim__now();
    if (constraints_at(bc, x) != DEFSIM_OK) return;
    pend_set(bc);
    const int32_t n = bc->ncon;
    const defsim__bc_contact *con = bc->con;
    double *sv = bc->sv, *sh = bc->sh;
    const int nth = nthreads_of(bc);
    (void)nth;
#pragma omp parallel for schedule(dynamic, 16) num_threads(nth) if (nth > 1 && n > 64)
    for (int32_t q = 0; q < n; ++q)
        sv[q] = contact_barrier(bc, &con[q], x, NULL, sh + 144 * (int64_t)q);
    for (int32_t q = 0; q < n; ++q) {
        if (sv[q] == 0.0 || !isfinite(sv[q])) continue;
        fn(ctx, con[q].v, defsim__contact_nodes(con[q].type), sh + 144 * (int64_t)q);
    }
    double H[144];
    for (int32_t r = 0; r < bc->nfric; ++r) {
        pair_friction(bc, r, x, NULL, H);
        fn(ctx, bc->fric[r].node, 4, H);
    }
    bc->stat[DEFSIM__CSTAT_TIME_BODY_EVAL] += defsim__now() - t0;
}

/* ------------------------------------------------------------------------------------------ */
/* CCD and the feasible start */

/* The gap that CCD keeps for a pair at distance d at x: a tenth of d, as IPC Toolkit's additive
 * CCD (conservative_rescaling 0.9), and at least a fifth of d or of dhat where the barrier acts
 * (d below 2 dhat), so that a line search's first trial does not push pairs that already repel
 * deep into the barrier (which costs Newton iterations). As a fraction of d, in [0.1, 0.2];
 * continuous in d. */
static double ccd_fraction(const defsim__body_contact *bc, double d)
{
    const double near = BC_CCD_NEAR * (d < bc->dhat ? d : bc->dhat);
    const double far = BC_CCD_FRACTION * d;
    return (near > far ? near : far) / d;
}

/* Largest t in [0, tmax] along x + t dx that keeps candidate q at least ccd_fraction of its
 * distance at x beyond its thickness offset xi (d - xi >= s (d0 - xi) at t, d > xi on the way);
 * 0 if it starts at distance xi or less. */
static double pair_toi(const defsim__body_contact *bc, int32_t q, const double *x,
                       const double *dx, double tmax)
{
    int32_t idx[4];
    const uint8_t kind = bc->kind[q];
    const int n = nodes(bc, kind, bc->pa[q], bc->pb[q], idx);
    if (n == 3) idx[3] = idx[2];   /* point-edge: the edge's end again */
    double X[12], D[12];
    gather(x, idx, 4, X);
    gather(dx, idx, 4, D);
    const defsim__ccd_pair pair = kind == DEFSIM__BC_PT   ? DEFSIM__CCD_PT
                                  : kind == DEFSIM__BC_EE ? DEFSIM__CCD_EE
                                                          : DEFSIM__CCD_PE;
    /* A bound on the relative motion (the distance is Lipschitz in t with it) */
    const double lp = defsim__ccd_speed(pair, D);
    if (!(lp > 0.0)) return tmax;
    /* the distance beyond the offset (the distance itself without thickness) */
    const double xi = pair_xi(bc, q);
    const double d = sqrt(dist2(kind, X, NULL, NULL)) - xi;
    if (!(d > 0.0)) return 0.0;
    const double s = ccd_fraction(bc, d);
    if (lp * tmax <= (1.0 - s) * d) return tmax;
    /* A pair that cannot come within dhat on the segment cannot cross, and limiting the step
     * for it would make the result depend on which far pairs the broad phase kept. */
    if (d - lp * tmax >= bc->dhat) return tmax;
    return defsim__accd_offset(pair, X, D, d, xi, lp, s, tmax, BC_CCD_ITERATIONS);
}

/* The largest step along dx from x over the candidates of the swept boxes (built unless the
 * current ones cover the segment). Each candidate's time is the same whatever the thread that
 * computes it and the minimum does not depend on the order, so alpha is the same bits for every
 * thread count. */
static double ccd(defsim__body_contact *bc, const double *x, const double *dx)
{
    ensure(bc, x, dx);
    if (bc->failed) return 0.0;
    double alpha = 1.0;
    const int32_t np = bc->npair;
    const int nth = nthreads_of(bc);
    (void)nth;
#pragma omp parallel for schedule(dynamic, 64) num_threads(nth) reduction(min : alpha) \
    if (nth > 1 && np > 512)
    for (int32_t q = 0; q < np; ++q) {
        const double t = pair_toi(bc, q, x, dx, 1.0);
        if (t < alpha) alpha = t;
    }
    return alpha;
}

double defsim__body_contact_max_step(defsim__body_contact *bc, const double *x, const double *dx)
{
    const double t0 = defsim__now();
    const double alpha = ccd(bc, x, dx);
    /* The pattern's slack: the contacts at the update's end (the line search's first trial,
     * which reuses this set) join it before the next assembly. */
    if (alpha > 0.0 && !bc->failed) {
        double *xe = bc->scratch;
        const int64_t n3 = 3 * (int64_t)bc->nv;
        for (int64_t i = 0; i < n3; ++i) xe[i] = x[i] + alpha * dx[i];
        if (defsim__body_contact_build(bc, xe) == DEFSIM_OK) pend_set(bc);
    }
    bc->stat[DEFSIM__CSTAT_TIME_BODY_CCD] += defsim__now() - t0;
    return alpha;
}

int defsim__body_contact_start(defsim__body_contact *bc, double *x)
{
    const double t0 = defsim__now();
    double *d = bc->scratch;
    const int64_t n3 = 3 * (int64_t)bc->nv;
    for (int64_t i = 0; i < n3; ++i) d[i] = x[i] - bc->xn[i];
    double alpha = ccd(bc, bc->xn, d);
    const int cut = alpha < 1.0;
    if (cut) {
        /* Free vertices back along their way (pinned ones are the core's): once to where CCD
         * allows, and to the start if that mix with the pins' motion is not safe either. */
        for (int pass = 0; pass < 2 && alpha < 1.0; ++pass) {
            for (int32_t v = 0; v < bc->nv; ++v) {
                if (bc->pinned[v]) continue;
                for (int c = 0; c < 3; ++c) {
                    const int64_t i = 3 * (int64_t)v + c;
                    d[i] = pass == 0 ? alpha * d[i] : 0.0;
                    x[i] = bc->xn[i] + d[i];
                }
            }
            alpha = ccd(bc, bc->xn, d);
        }
    }
    bc->stat[DEFSIM__CSTAT_TIME_BODY_CCD] += defsim__now() - t0;
    return cut;
}

/* ------------------------------------------------------------------------------------------ */
/* The start and end of a step */

/* Closest points of contact (type, X) at the step's start: weights w (sum w_i X_i is the vector
 * from the second feature's closest point to the first's). */
static void closest_weights(int type, const double *X, double w[4])
{
    w[2] = w[3] = 0.0;
    if (type == DEFSIM__C_VV) {
        w[0] = 1.0;
        w[1] = -1.0;
        return;
    }
    if (type == DEFSIM__C_EV) {
        const double *p = X, *a = X + 3, *b = X + 6;
        const double e[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        const double r[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
        const double l2 = dot3(e, e);
        double t = l2 > 0.0 ? dot3(r, e) / l2 : 0.0;
        t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
        w[0] = 1.0;
        w[1] = -(1.0 - t);
        w[2] = -t;
        return;
    }
    if (type == DEFSIM__C_EE) {
        /* closest points of two segments (clamped line parameters) */
        double s, t;
        segment_params(X, &s, &t);
        w[0] = 1.0 - s;
        w[1] = s;
        w[2] = -(1.0 - t);
        w[3] = -t;
        return;
    }
    /* point-triangle: barycentric coordinates of the closest point (by Voronoi region) */
    double bary[3];
    defsim__triangle_closest(X, X + 3, X + 6, X + 9, bary);
    w[0] = 1.0;
    w[1] = -bary[0];
    w[2] = -bary[1];
    w[3] = -bary[2];
}

/* Lagged friction of contact c at its nodes' positions X (the step's start): the normal force
 * lam for mu = 1 (N), the closest points' weights w and the normal; 0 when it has none. */
static int lagged(const defsim__body_contact *bc, const defsim__bc_contact *c, const double *X,
                  double *lam, double w[4], double nrm[3])
{
    const int n = defsim__contact_nodes(c->type);
    /* the offset barrier's normal force (the distance beyond the thickness offset) */
    const double d = sqrt(defsim__contact_dist2(c->type, X, NULL, NULL)) - c->xi;
    double l = -c->kappa * barrier_d1(d, bc->dhat);
    if (c->type == DEFSIM__C_EE) l *= defsim__ee_mollifier(X, X + 3, X + 6, X + 9, c->eps, NULL, NULL);
    double dv[3] = {0.0, 0.0, 0.0};
    closest_weights(c->type, X, w);
    for (int i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) dv[k] += w[i] * X[3 * i + k];
    const double len = sqrt(dot3(dv, dv));
    *lam = l;
    if (!(len > 0.0)) return 0;
    for (int k = 0; k < 3; ++k) nrm[k] = dv[k] / len;
    return l > 0.0;
}

static int reserve_fric(defsim__body_contact *bc, int32_t n)
{
    int64_t cap = bc->cap_fric;
    if (!grow((void **)&bc->fric, &cap, n, sizeof *bc->fric)) return 0;
    bc->cap_fric = (int32_t)cap;
    return 1;
}

/* Segment (p, q) against triangle (a, b, c): 1 if they cross (floating point signs). */
static int segment_crosses(const double *p, const double *q, const double *a, const double *b,
                           const double *c)
{
    double o[5];
    const double *pts[5][4] = {{a, b, c, p}, {a, b, c, q}, {p, q, a, b}, {p, q, b, c},
                               {p, q, c, a}};
    for (int k = 0; k < 5; ++k) {
        const double *u = pts[k][0], *v = pts[k][1], *w = pts[k][2], *z = pts[k][3];
        const double e1[3] = {v[0] - u[0], v[1] - u[1], v[2] - u[2]};
        const double e2[3] = {w[0] - u[0], w[1] - u[1], w[2] - u[2]};
        const double e3[3] = {z[0] - u[0], z[1] - u[1], z[2] - u[2]};
        o[k] = e1[0] * (e2[1] * e3[2] - e2[2] * e3[1]) - e1[1] * (e2[0] * e3[2] - e2[2] * e3[0]) +
               e1[2] * (e2[0] * e3[1] - e2[1] * e3[0]);
        /* below the rounding of the products: no sign (nearly coplanar points) */
        if (fabs(o[k]) <= 1e-12 * sqrt(dot3(e1, e1) * dot3(e2, e2) * dot3(e3, e3))) o[k] = 0.0;
    }
    /* a coplanar pair is left to the distance check (only touching can happen there) */
    if ((o[0] >= 0.0 && o[1] >= 0.0) || (o[0] <= 0.0 && o[1] <= 0.0)) return 0;
    return (o[2] >= 0.0 && o[3] >= 0.0 && o[4] >= 0.0) || (o[2] <= 0.0 && o[3] <= 0.0 &&
                                                          o[4] <= 0.0);
}

/* The first edge and face that cross at x, among boxes that overlap (the start of a run or of a
 * plan: the barrier keeps later steps apart). Returns 1 and their indices, else 0. */
static int find_crossing(defsim__body_contact *bc, const double *x, int32_t *edge, int32_t *face)
{
    if (bc->nface == 0 || bc->nedge == 0) return 0;
    double *flo = bc->lo, *fhi = bc->hi, *elo = flo + 3 * (int64_t)bc->nface,
           *ehi = fhi + 3 * (int64_t)bc->nface;
    for (int32_t f = 0; f < bc->nface; ++f)
        for (int k = 0; k < 3; ++k) {
            const int32_t *t = bc->face + 3 * (int64_t)f;
            const double a = x[3 * (int64_t)t[0] + k], b = x[3 * (int64_t)t[1] + k],
                         c = x[3 * (int64_t)t[2] + k];
            flo[3 * (int64_t)f + k] = fmin(a, fmin(b, c));
            fhi[3 * (int64_t)f + k] = fmax(a, fmax(b, c));
        }
    for (int32_t e = 0; e < bc->nedge; ++e)
        for (int k = 0; k < 3; ++k) {
            const int32_t *t = bc->edge + 2 * (int64_t)e;
            const double a = x[3 * (int64_t)t[0] + k], b = x[3 * (int64_t)t[1] + k];
            elo[3 * (int64_t)e + k] = fmin(a, b);
            ehi[3 * (int64_t)e + k] = fmax(a, b);
        }
    if (defsim__hash_pairs(&bc->hash, elo, ehi, bc->nedge, flo, fhi, bc->nface, 0, 0.0) !=
        DEFSIM_OK) {
        bc->failed = DEFSIM_ERR_OUT_OF_MEMORY;
        return 0;
    }
    for (int64_t k = 0; k < bc->hash.npairs; ++k) {
        const int32_t e = (int32_t)(bc->hash.pairs[k] >> 32);
        const int32_t f = (int32_t)(bc->hash.pairs[k] & 0xFFFFFFFF);
        if (filtered(bc, bc->edge_body[e], bc->face_body[f])) continue;
        const int32_t *ev = bc->edge + 2 * (int64_t)e, *fv = bc->face + 3 * (int64_t)f;
        int shared = 0;
        for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 3; ++j) shared |= ev[i] == fv[j];
        if (shared) continue;
        if (segment_crosses(x + 3 * (int64_t)ev[0], x + 3 * (int64_t)ev[1],
                            x + 3 * (int64_t)fv[0], x + 3 * (int64_t)fv[1],
                            x + 3 * (int64_t)fv[2])) {
            *edge = e;
            *face = f;
            return 1;
        }
    }
    return 0;
}

defsim_status defsim__body_contact_begin(defsim__body_contact *bc, const defsim__system *s,
                                         const defsim__body *bodies, int32_t nbodies,
                                         double dhat_rel, double kappa, double eps_v,
                                         const double *x, const double *v, double h,
                                         double *stat, defsim__messages *msg)
{
    (void)v;
    bc->stat = stat;
    bc->sys = s;
    bc->failed = DEFSIM_OK;
    bc->active = 0;
    bc->exact = 0;
    defsim_status st = DEFSIM_OK;
    if ((!bc->planned || bc->nv != s->nv || bc->nbody != nbodies) &&
        (st = plan(bc, bodies, nbodies, s->nv)) != DEFSIM_OK) {
        defsim__error(msg, "out of memory for body contact surfaces");
        return st;
    }
    for (int32_t b = 0; b < nbodies; ++b) {
        bc->self_contact[b] = bodies[b].self_contact;
        bc->group[b] = bodies[b].group;
        bc->mask[b] = bodies[b].mask;
        bc->mu[b] = bodies[b].friction;
        bc->half[b] = 0.5 * bodies[b].thickness;
    }
    bc->mass = s->mass;
    bc->pinned = s->pinned;
    bc->vfree = s->vfree;
    bc->nthreads = s->nthreads;
    bc->xn = x;
    bc->h = h;
    bc->dhat = dhat_rel * s->length_scale;
    bc->eps_v = eps_v;
    const double gn = sqrt(dot3(s->gravity, s->gravity));
    bc->khat = kappa > 0.0 ? kappa : gn / bc->dhat + 1.0 / (h * h);
    bc->npend = 0;
    bc->nfric = 0;
    /* Masses and stiffness may have changed since the last step: the constraint set is built
     * again. The candidates too when the filter (fresh), pins (a plan) or dhat changed, or when
     * the start left their boxes; a scene at rest keeps them (no broad phase). */
    bc->con_valid = 0;
    if (bc->fresh || bc->cand_dhat != bc->dhat) bc->have_pairs = 0;
    ensure(bc, x, NULL);
    if (bc->failed) {
        defsim__error(msg, "out of memory for body contact pairs");
        return bc->failed;
    }
    /* Surfaces that touch or cross at the start: the barrier cannot separate them. */
    int32_t e = -1, f = -1;
    if (bc->fresh && find_crossing(bc, x, &e, &f)) {
        defsim__error(msg, "body contact: at the start of the step, edge (%d, %d) of body %d "
                      "crosses triangle (%d, %d, %d) of body %d (world vertex indices; bodies in "
                      "vertex order): surfaces must start apart (move the bodies, or filter the "
                      "pair with collision groups or self_contact)",
                      (int)bc->edge[2 * (int64_t)e], (int)bc->edge[2 * (int64_t)e + 1],
                      (int)bc->edge_body[e], (int)bc->face[3 * (int64_t)f],
                      (int)bc->face[3 * (int64_t)f + 1], (int)bc->face[3 * (int64_t)f + 2],
                      (int)bc->face_body[f]);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    if (bc->failed) {
        defsim__error(msg, "out of memory for body contact pairs");
        return bc->failed;
    }
    bc->fresh = 0;
    for (int32_t q = 0; q < bc->npair; ++q) {
        int32_t idx[4];
        const uint8_t kind = bc->kind[q];
        const int n = nodes(bc, kind, bc->pa[q], bc->pb[q], idx);
        double X[12];
        gather(x, idx, n, X);
        const double d2 = dist2(kind, X, NULL, NULL), xi = pair_xi(bc, q);
        if (!(d2 > 0.0) || (xi > 0.0 && !(sqrt(d2) > xi))) {
            static const char *const what[3] = {"vertex-triangle", "edge-edge", "vertex-edge"};
            int32_t ba, bb;
            pair_bodies(bc, kind, bc->pa[q], bc->pb[q], &ba, &bb);
            if (xi > 0.0)
                defsim__error(msg, "body contact: at the start of the step the %s pair of world "
                              "vertices (%d, %d, %d, %d) between bodies %d and %d (bodies in "
                              "vertex order) is %g m apart, not more than its contact thickness "
                              "offset %g m (the bodies' half contact_thickness summed): surfaces "
                              "must start farther apart, or self-contact needs a thickness below "
                              "the mesh's spacing", what[kind], (int)idx[0], (int)idx[1],
                              (int)idx[2], (int)idx[3], (int)ba, (int)bb, sqrt(d2), xi);
            else
                defsim__error(msg, "body contact: at the start of the step the %s pair of world "
                              "vertices (%d, %d, %d, %d) touches (distance 0) between bodies %d "
                              "and %d (bodies in vertex order): surfaces must start apart",
                              what[kind], (int)idx[0], (int)idx[1], (int)idx[2], (int)idx[3],
                              (int)ba, (int)bb);
            return DEFSIM_ERR_INVALID_ARGUMENT;
        }
    }
    /* The constraint set at the start: its pattern pairs, and lagged friction (IPC): each
     * contact's normal force and closest points. */
    if (defsim__body_contact_build(bc, x) != DEFSIM_OK) {
        defsim__error(msg, "out of memory for body contact pairs");
        return bc->failed;
    }
    pend_set(bc);
    for (int32_t q = 0; q < bc->ncon; ++q) {
        const defsim__bc_contact *c = &bc->con[q];
        const int n = defsim__contact_nodes(c->type);
        const double mu = sqrt(bc->mu[c->body[0]] * bc->mu[c->body[1]]);
        if (!(mu > 0.0)) continue;
        double X[12], lam, w[4], nrm[3];
        gather(x, c->v, n, X);
        if (!lagged(bc, c, X, &lam, w, nrm)) continue;
        if (!reserve_fric(bc, bc->nfric + 1)) {
            defsim__error(msg, "out of memory for body contact friction");
            return DEFSIM_ERR_OUT_OF_MEMORY;
        }
        defsim__bc_friction *fr = &bc->fric[bc->nfric++];
        for (int i = 0; i < 4; ++i) {
            fr->node[i] = i < n ? c->v[i] : -1;
            fr->w[i] = i < n ? w[i] : 0.0;
        }
        memcpy(fr->nrm, nrm, sizeof nrm);
        fr->mul = mu * lam;
    }
    if (bc->failed) {
        defsim__error(msg, "out of memory for body contact pairs");
        return bc->failed;
    }
    bc->active = 1;
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* The reverse mode (body_contact.h, docs/gradients.md) */

/* The index of the contact with c's key in the constraint set (sorted, one per key), or -1. */
static int32_t find_contact(const defsim__body_contact *bc, const defsim__bc_contact *c)
{
    int32_t lo = 0, hi = bc->ncon - 1;
    while (lo <= hi) {
        const int32_t mid = lo + (hi - lo) / 2;
        const int r = contact_key_cmp(&bc->con[mid], c);
        if (r == 0) return mid;
        if (r < 0) lo = mid + 1;
        else hi = mid - 1;
    }
    return -1;
}

/* The masses' gradient through the contacts' kappa: each candidate within dhat at x adds
 * khat times the mean mass of its primitives' vertices to its contact's kappa, so dL/dm_v
 * gains dk[contact] khat / n for each of its n vertices. */
static void kappa_masses(defsim__body_contact *bc, const double *x, const double *dk,
                         double *gmass)
{
    for (int32_t k = 0; k < bc->nact; ++k) {
        const int32_t q = bc->act[k];
        defsim__bc_contact c;
        candidate_contact(bc, q, x, &c);
        const int32_t r = c.type >= 0 ? find_contact(bc, &c) : -1;
        if (r < 0 || dk[r] == 0.0) continue;
        int32_t idx[4];
        const int n = nodes(bc, bc->kind[q], bc->pa[q], bc->pb[q], idx);
        for (int i = 0; i < n; ++i) gmass[idx[i]] += dk[r] * bc->khat / n;
    }
}

/* Lagged friction's share (the constraint set at x_n, whose contacts made the pairs in order):
 * for pair r with normal force mul = mu lam, weights w, normal n0 and u = sum w_i (x_i - x_n,i),
 * the forces are -mul s(y) w_i ut, so with A = sum w_i a_i (a: the adjoint at the nodes) and
 * F = s (A . ut), w^T f = -mul F: in x, -mul w_i B A (B: friction's exact block); in x_n,
 * mul w_i B A and, through lam, w and n0 (functions of x_n, held within the step), their
 * derivatives by central differences of `lagged` with a step of 1e-4 of the distance; mu's
 * (sqrt(mu_a mu_b)) and kappa's (into dk) too. */
static defsim_status friction_vjp(defsim__body_contact *bc, const double *x, const double *w,
                                  double *gx, double *gxn, double *gmu, double *dk)
{
    const double *xn = bc->xn, eps = bc->eps_v * bc->h;
    int32_t r = 0;
    for (int32_t q = 0; q < bc->ncon; ++q) {
        const defsim__bc_contact *c = &bc->con[q];
        const int n = defsim__contact_nodes(c->type);
        const double mua = bc->mu[c->body[0]], mub = bc->mu[c->body[1]], mu = sqrt(mua * mub);
        if (!(mu > 0.0)) continue;
        double X[12], lam, wt[4], nrm[3];
        gather(xn, c->v, n, X);
        if (!lagged(bc, c, X, &lam, wt, nrm)) continue;
        if (r >= bc->nfric || memcmp(bc->fric[r].node, c->v, (size_t)n * sizeof *c->v) != 0)
            return DEFSIM_ERR_UNSTABLE;   /* not the step's pairs: cannot happen */
        ++r;
        double A[3] = {0, 0, 0}, u[3] = {0, 0, 0}, ut[3], B[9] = {0}, BA[3];
        for (int i = 0; i < n; ++i)
            for (int k = 0; k < 3; ++k) {
                const int64_t j = 3 * (int64_t)c->v[i] + k;
                A[k] += wt[i] * w[j];
                u[k] += wt[i] * (x[j] - xn[j]);
            }
        const double un = dot3(u, nrm);
        for (int k = 0; k < 3; ++k) ut[k] = u[k] - un * nrm[k];
        const double y = sqrt(dot3(ut, ut)), sy = friction_f1_over_y(y, eps);
        friction_block(1.0, nrm, ut, y, eps, B);
        for (int k = 0; k < 3; ++k) BA[k] = B[3 * k] * A[0] + B[3 * k + 1] * A[1] + B[3 * k + 2] * A[2];
        const double F = sy * dot3(A, ut), mul = mu * lam;
        for (int i = 0; i < n && gx; ++i)
            for (int k = 0; k < 3; ++k) gx[3 * (int64_t)c->v[i] + k] -= mul * wt[i] * BA[k];
        if (gmu) {
            gmu[c->body[0]] -= F * lam * mub / (2.0 * mu);
            gmu[c->body[1]] -= F * lam * mua / (2.0 * mu);
        }
        dk[q] = -F * mul / c->kappa;
        if (!gxn) continue;
        const double nA = dot3(nrm, A);
        double dFdn[3], dFdw[4];
        for (int k = 0; k < 3; ++k) dFdn[k] = -un * (BA[k] + sy * nA * nrm[k]) - sy * nA * u[k];
        for (int i = 0; i < n; ++i) {
            double du[3], a[3];
            for (int k = 0; k < 3; ++k) {
                const int64_t j = 3 * (int64_t)c->v[i] + k;
                du[k] = x[j] - xn[j];
                a[k] = w[j];
            }
            dFdw[i] = dot3(BA, du) + sy * dot3(a, ut);
        }
        /* a step of 1e-4 of the distance beyond the thickness offset */
        const double hs = 1e-4 * (sqrt(defsim__contact_dist2(c->type, X, NULL, NULL)) - c->xi);
        for (int p = 0; p < 3 * n; ++p) {
            double Xp[12], lp[2], wp[2][4], np[2][3];
            for (int side = 0; side < 2; ++side) {
                memcpy(Xp, X, sizeof Xp);
                Xp[p] += side ? -hs : hs;
                (void)lagged(bc, c, Xp, &lp[side], wp[side], np[side]);
            }
            const double i2h = 1.0 / (2.0 * hs);
            double dphi = -mu * F * (lp[0] - lp[1]) * i2h;
            for (int i = 0; i < n; ++i) dphi -= mul * dFdw[i] * (wp[0][i] - wp[1][i]) * i2h;
            for (int k = 0; k < 3; ++k) dphi -= mul * dFdn[k] * (np[0][k] - np[1][k]) * i2h;
            gxn[3 * (int64_t)c->v[p / 3] + p % 3] += dphi + mul * wt[p / 3] * BA[p % 3];
        }
    }
    return r == bc->nfric ? DEFSIM_OK : DEFSIM_ERR_UNSTABLE;
}

defsim_status defsim__body_contact_vjp(defsim__body_contact *bc, const double *x, const double *w,
                                       double *gx, double *gxn, double *gmass, double *gmu)
{
    defsim_status st = DEFSIM_OK;
    if (bc->nfric > 0) {
        if ((st = constraints_at(bc, bc->xn)) != DEFSIM_OK) return st;
        double *dk = calloc((size_t)(bc->ncon > 0 ? bc->ncon : 1), sizeof *dk);
        if (!dk) return DEFSIM_ERR_OUT_OF_MEMORY;
        st = friction_vjp(bc, x, w, gx, gxn, gmu, dk);
        if (st == DEFSIM_OK && gmass) kappa_masses(bc, bc->xn, dk, gmass);
        free(dk);
        if (st != DEFSIM_OK) return st;
    }
    /* The barriers at x, candidate by candidate (each adds its own kappa times the unit barrier
     * of its contact): gx -= kappa H w with the exact Hessian H, and kappa's mass share. */
    if ((st = constraints_at(bc, x)) != DEFSIM_OK) return st;
    for (int32_t k = 0; k < bc->nact; ++k) {
        const int32_t q = bc->act[k];
        defsim__bc_contact c;
        candidate_contact(bc, q, x, &c);
        if (c.type < 0) continue;
        const int m = defsim__contact_nodes(c.type), nd = 3 * m;
        double X[12], g[12], H[144], wl[12];
        gather(x, c.v, m, X);
        gather(w, c.v, m, wl);
        const double e =
            defsim__contact_barrier_offset(c.type, X, bc->dhat, c.xi, 1.0, c.eps, 1, g, H);
        if (!isfinite(e)) return DEFSIM_ERR_UNSTABLE;
        if (e == 0.0) continue;
        for (int i = 0; i < nd && gx; ++i) {
            double sum = 0.0;
            for (int j = 0; j < nd; ++j) sum += H[i * nd + j] * wl[j];
            gx[3 * (int64_t)c.v[i / 3] + i % 3] -= c.kappa * sum;
        }
        if (!gmass) continue;
        double wg = 0.0;
        for (int i = 0; i < nd; ++i) wg += wl[i] * g[i];
        int32_t idx[4];
        const int n = nodes(bc, bc->kind[q], bc->pa[q], bc->pb[q], idx);
        for (int i = 0; i < n; ++i) gmass[idx[i]] -= wg * bc->khat / n;
    }
    return bc->failed;
}

/* defsim__body_contact_end's pattern retention (body_contact.h). */
static defsim_status retain(defsim__body_contact *bc, defsim__system *s)
{
    if (!s->pattern.built || s->pattern.nextra == 0 || !bc->con_valid) return DEFSIM_OK;
    /* the pairs pend_set queues: those of the candidates within dhat */
    int64_t n = 0;
    for (int32_t k = 0; k < bc->nact; ++k) {
        const int32_t q = bc->act[k];
        int32_t idx[4];
        const int m = nodes(bc, bc->kind[q], bc->pa[q], bc->pb[q], idx);
        if (!grow((void **)&bc->keep, &bc->cap_keep, n + 6, sizeof *bc->keep)) {
            bc->failed = DEFSIM_ERR_OUT_OF_MEMORY;
            return bc->failed;
        }
        for (int i = 0; i < m; ++i)
            for (int j = 0; j < m; ++j) {
                if (idx[i] < 0 || idx[j] < 0) continue;
                const int32_t fa = s->vfree[idx[i]], fb = s->vfree[idx[j]];
                if (fa >= 0 && fb >= 0 && fa < fb) bc->keep[n++] = ((int64_t)fa << 32) | fb;
            }
    }
    if (n > 1) qsort(bc->keep, (size_t)n, sizeof *bc->keep, defsim__cmp_i64);
    int64_t u = 0;
    for (int64_t k = 0; k < n; ++k)
        if (k == 0 || bc->keep[k] != bc->keep[k - 1]) bc->keep[u++] = bc->keep[k];
    int pruned = 0;
    return defsim__pattern_retain(s, bc->keep, u, 0.25, &pruned);
}

double defsim__body_contact_end(defsim__body_contact *bc, defsim__system *s, const double *x,
                                double *f)
{
    memset(f, 0, 3 * (size_t)bc->nv * sizeof *f);
    (void)defsim__body_contact_forces(bc, x, f);
    double dmin = INFINITY;
    int32_t idx[4];
    double X[12];
    for (int32_t q = 0; q < bc->npair; ++q) {
        const int n = nodes(bc, bc->kind[q], bc->pa[q], bc->pb[q], idx);
        gather(x, idx, n, X);
        /* the distance beyond the pair's thickness offset */
        const double d = sqrt(dist2(bc->kind[q], X, NULL, NULL)) - pair_xi(bc, q);
        if (d < dmin) dmin = d;
    }

    bc->stat[DEFSIM__CSTAT_BODY_ACTIVE] = bc->con_valid ? bc->ncon : 0;
    bc->stat[DEFSIM__CSTAT_BODY_MIN_DISTANCE] = dmin;
    if (retain(bc, s) != DEFSIM_OK) bc->failed = DEFSIM_ERR_OUT_OF_MEMORY;
    return dmin;
}

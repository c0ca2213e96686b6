/* SPDX-License-Identifier: MIT */
/*
 * The planner: compiles the bodies of a world into a defsim__system (system.h) when the world
 * is first stepped or evaluated after a change: element groups per material with their rest
 * data, colours and SIMD batches, attachments, per-DOF masses and damping, free-DOF maps, the
 * pass plan, the list of terms (term.c), the sparse pattern when the backend assembles
 * matrices, and the workspaces physics functions use, so that no step allocates.
 *
 * Contents: freeing; SIMD batches; element groups; defsim__plan.
 */
#include "plan.h"

#include "assembly.h"
#include "colour.h"
#include "energy.h"
#include "mat3.h"
#include "material.h"
#include "terms.h"
#include "tet10.h"
#include "tet_forces.h"
#include "tet_rest.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static void group_free(defsim__group *g)
{
    free(g->idx); free(g->dminv); free(g->qrest); free(g->vol); free(g->mu); free(g->lambda);
    free(g->k); free(g->l0); free(g->beta); free(g->shell); free(g->color_ptr); free(g->blk);
    free(g->bcolor_ptr); free(g->bidx); free(g->bdata); free(g->blanes);
    memset(g, 0, sizeof *g);
}

static void vgroup_free(defsim__vgroup *v)
{
    group_free(&v->g);
    free(v->node); free(v->enode); free(v->vn); free(v->beta_n); free(v->ne_ptr); free(v->ne);
    free(v->wne); free(v->patch_ptr); free(v->patch); free(v->ploc); free(v->prank_ptr);
    free(v->prank); free(v->se); free(v->sn); free(v->lin_pe); free(v->lin_un);
    free(v->gn);
    memset(v, 0, sizeof *v);
}

void defsim__unplan(defsim__system *s, defsim__work *wk)
{
    for (int m = 0; m < DEFSIM__GROUPS; ++m) group_free(&s->groups[m]);
    for (int m = 0; m < DEFSIM__TET_MODELS; ++m) vgroup_free(&s->vgroups[m]);
    for (int m = 0; m < DEFSIM__SHELL_GROUPS; ++m) group_free(&s->shells[m]);
    defsim__attachments *at = &s->att;
    free(at->node); free(at->a); free(at->k); free(at->c); free(at->p); free(at->blk);
    defsim__pattern *p = &s->pattern;
    free(p->adj_ptr); free(p->adj); free(p->upper_rank0);
    free(p->full_col_ptr); free(p->full_row_idx); free(p->upper_col_ptr); free(p->upper_row_idx);
    free(p->extra);
    free(s->mass); free(s->mass3); free(s->alpha3); free(s->pinned);
    free(s->free_dofs); free(s->dof_to_free); free(s->vfree);
    defsim__terms_free(s);
    memset(s, 0, sizeof *s);
    free(wk->partial); free(wk->pz); free(wk->py); free(wk->pu);
    memset(wk, 0, sizeof *wk);
}

/* A batch lane's data rows (stride DEFSIM__BATCH from d) from element e of g. */
typedef void (*batch_rows_fn)(const defsim__group *g, int64_t e, double *d);

static void tet_rows(const defsim__group *g, int64_t e, double *d)
{
    const int B = DEFSIM__BATCH;
    for (int r = 0; r < 9; ++r) d[(DEFSIM__ROW_DMINV + r) * B] = g->dminv[9 * e + r];
    d[DEFSIM__ROW_NVOL * B] = -g->vol[e];
    double prm[3];
    g->law->params(g->mu[e], g->lambda[e], prm);
    d[DEFSIM__ROW_P0 * B] = prm[0];
    d[DEFSIM__ROW_P1 * B] = prm[1];
    d[DEFSIM__ROW_P2 * B] = prm[2];
}

/* A quadratic tet's rows (DEFSIM__QBATCH_ROWS, tet_forces.h): -w_q, psi_rest, lambda, the
 * law's parameters, the gradients of its rest data (tet10.h) point by point. */
static void quad_rows(const defsim__group *g, int64_t e, double *d)
{
    const int B = DEFSIM__BATCH;
    const double *rest = g->qrest + DEFSIM__TET10_REST * e;
    for (int q = 0; q < DEFSIM__TET10_QP; ++q) {
        const double *G = rest + DEFSIM__TET10_QSTRIDE * q;
        d[(DEFSIM__QROW_NW + q) * B] = -G[30];
        for (int r = 0; r < 30; ++r) d[(DEFSIM__QROW_G + 30 * q + r) * B] = G[r];
    }
    for (int r = DEFSIM__QROW_LAMBDA + 1; r < DEFSIM__ROW_P0; ++r) d[r * B] = 0.0;
    d[DEFSIM__QROW_REST * B] = g->law->psi_rest ? g->law->psi_rest(g->mu[e], g->lambda[e]) : 0.0;
    d[DEFSIM__QROW_LAMBDA * B] = g->lambda[e];
    double prm[3];
    g->law->params(g->mu[e], g->lambda[e], prm);
    d[DEFSIM__ROW_P0 * B] = prm[0];
    d[DEFSIM__ROW_P1 * B] = prm[1];
    d[DEFSIM__ROW_P2 * B] = prm[2];
}

/* A membrane triangle's rows (tet_forces.h): Dm^-1, -area, the law's parameters. */
static void membrane_rows(const defsim__group *g, int64_t e, double *d)
{
    const int B = DEFSIM__BATCH;
    const double *row = g->shell + DEFSIM__MEMBRANE_WIDTH * e;
    for (int r = 0; r < 4; ++r) d[(DEFSIM__SROW_DMINV + r) * B] = row[r];
    d[DEFSIM__SROW_NAREA * B] = -g->vol[e];
    for (int r = 0; r < 4; ++r) d[(DEFSIM__SROW_P + r) * B] = row[4 + r];
}

/* A hinge's rows: its weight and rest angle. */
static void hinge_rows(const defsim__group *g, int64_t e, double *d)
{
    d[DEFSIM__SROW_W * DEFSIM__BATCH] = g->k[e];
    d[DEFSIM__SROW_THETA0 * DEFSIM__BATCH] = g->l0[e];
}

/* Cuts each colour of a group (tets, quadratic tets, membrane triangles, hinges) into batches
 * of DEFSIM__BATCH elements in the SIMD layout (tet_forces.h): g->nodes vertex ids per lane,
 * the `rows` data rows that `rows_of` fills. A colour's last batch is padded with copies of its
 * first element: they are computed with valid data but never scattered. */
static defsim_status pack_batches(defsim__group *g, batch_rows_fn rows_of, int rows)
{
    const int B = DEFSIM__BATCH, nn = g->nodes;
    g->bcolor_ptr = malloc(((size_t)g->ncolors + 1) * sizeof *g->bcolor_ptr);
    if (!g->bcolor_ptr) return DEFSIM_ERR_OUT_OF_MEMORY;
    int32_t nb = 0;
    for (int32_t c = 0; c < g->ncolors; ++c) {
        g->bcolor_ptr[c] = nb;
        nb += (g->color_ptr[c + 1] - g->color_ptr[c] + B - 1) / B;
    }
    g->bcolor_ptr[g->ncolors] = nb;
    g->nbatch = nb;
    const size_t nbs = (size_t)(nb > 0 ? nb : 1);
    g->bidx = malloc(nbs * nn * B * sizeof *g->bidx);
    g->bdata = aligned_alloc(64, nbs * rows * B * sizeof *g->bdata);   /* rows * 64 bytes */
    g->blanes = malloc(nbs);
    if (!g->bidx || !g->bdata || !g->blanes) return DEFSIM_ERR_OUT_OF_MEMORY;
    for (int32_t c = 0; c < g->ncolors; ++c)
        for (int32_t b = g->bcolor_ptr[c]; b < g->bcolor_ptr[c + 1]; ++b) {
            const int32_t first = g->color_ptr[c] + (b - g->bcolor_ptr[c]) * B;
            const int32_t left = g->color_ptr[c + 1] - first;
            g->blanes[b] = (uint8_t)(left < B ? left : B);
            for (int l = 0; l < B; ++l) {
                const int64_t e = l < g->blanes[b] ? first + l : first;
                for (int a = 0; a < nn; ++a)
                    g->bidx[((int64_t)nn * b + a) * B + l] = g->idx[nn * e + a];
                rows_of(g, e, g->bdata + (int64_t)rows * B * b + l);
            }
        }
    return DEFSIM_OK;
}

/* The element group of a body's tets: its model's (material_list.h order; bodies are
 * validated, so found), among the quadratic groups for quadratic tets (the mean-dilatation ones
 * with volume_averaging; linear volume-averaged tets: the model's index into s->vgroups). */
static int group_of(const defsim__body *bd)
{
    int m = 0;
    while (m < DEFSIM__TET_MODELS - 1 && (int)defsim__tet_models[m]->id != (int)bd->mat.model) ++m;
    if (bd->tet_nodes != 10) return m;
    return (bd->volume_averaging ? DEFSIM__QMIX_GROUP : DEFSIM__QUAD_GROUP) + m;
}

/* Room for count elements in g, group m of DEFSIM__GROUPS (linear tets of model m, springs,
 * quadratic tets of model m - DEFSIM__QUAD_GROUP, mean-dilatation ones of m -
 * DEFSIM__QMIX_GROUP; a volume-averaged group is its model's linear one), none filled yet. */
static defsim_status group_alloc(defsim__group *g, int m, int32_t count)
{
    const size_t n = (size_t)(count > 0 ? count : 1);
    const int quad = m >= DEFSIM__QUAD_GROUP, tets = m != DEFSIM__TET_MODELS;
    const int model = quad ? (m - DEFSIM__QUAD_GROUP) % DEFSIM__TET_MODELS : m;
    g->n = 0;
    g->nodes = quad ? 10 : tets ? 4 : 2;
    g->mixed = m >= DEFSIM__QMIX_GROUP;
    g->law = tets ? defsim__tet_models[model] : NULL;
    g->pass = tets ? defsim__tet_models[model]->pass : defsim__model_spring.pass;
    g->idx = malloc(n * g->nodes * sizeof *g->idx);
    g->beta = malloc(n * sizeof *g->beta);
    if (!g->idx || !g->beta) return DEFSIM_ERR_OUT_OF_MEMORY;
    if (tets) {
        if (quad) g->qrest = malloc(DEFSIM__TET10_REST * n * sizeof *g->qrest);
        else g->dminv = malloc(9 * n * sizeof *g->dminv);
        g->vol = malloc(n * sizeof *g->vol);
        g->mu = malloc(n * sizeof *g->mu);
        g->lambda = malloc(n * sizeof *g->lambda);
        if (!(g->dminv || g->qrest) || !g->vol || !g->mu || !g->lambda)
            return DEFSIM_ERR_OUT_OF_MEMORY;
    } else {
        g->k = malloc(n * sizeof *g->k);
        g->l0 = malloc(n * sizeof *g->l0);
        if (!g->k || !g->l0) return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    return DEFSIM_OK;
}

static int cmp_i32(const void *a, const void *b)
{
    const int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
    return (x > y) - (x < y);
}

/* The node data of a volume-averaged group whose elements are in place (coloured): nodes in
 * the order their vertices first appear, their rest volumes, the elements at each node in
 * element order, the patches (sorted vertices of a node's elements) and the scratch. */
static defsim_status plan_nodes(defsim__vgroup *v, int32_t nv)
{
    const defsim__group *g = &v->g;
    const size_t ne = (size_t)g->n * 4 + 1;
    int32_t *map = malloc((size_t)(nv > 0 ? nv : 1) * sizeof *map);
    v->enode = malloc(ne * sizeof *v->enode);
    v->node = malloc(ne * sizeof *v->node);
    if (!map || !v->enode || !v->node) { free(map); return DEFSIM_ERR_OUT_OF_MEMORY; }
    for (int32_t i = 0; i < nv; ++i) map[i] = -1;
    v->nn = 0;
    for (int64_t k = 0; k < 4 * (int64_t)g->n; ++k) {
        const int32_t vx = g->idx[k];
        if (map[vx] < 0) { map[vx] = v->nn; v->node[v->nn++] = vx; }
        v->enode[k] = map[vx];
    }
    free(map);
    const size_t nn = (size_t)v->nn + 1;
    v->vn = calloc(nn, sizeof *v->vn);
    v->beta_n = calloc(nn, sizeof *v->beta_n);
    v->ne_ptr = calloc(nn, sizeof *v->ne_ptr);
    v->ne = malloc(ne * sizeof *v->ne);
    v->wne = malloc(ne * sizeof *v->wne);
    v->patch_ptr = calloc(nn, sizeof *v->patch_ptr);
    v->prank_ptr = calloc(nn, sizeof *v->prank_ptr);
    v->ploc = malloc(4 * ne * sizeof *v->ploc);
    int32_t *list = malloc(4 * ne * sizeof *list);   /* a node's patch before it is unique */
    int64_t *fill = malloc(nn * sizeof *fill);
    if (!v->vn || !v->beta_n || !v->ne_ptr || !v->ne || !v->wne || !v->patch_ptr ||
        !v->prank_ptr || !v->ploc || !list || !fill) {
        free(list); free(fill);
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    for (int64_t k = 0; k < 4 * (int64_t)g->n; ++k) {
        const int32_t n = v->enode[k];
        v->vn[n] += 0.25 * g->vol[k / 4];
        v->beta_n[n] = g->beta[k / 4];
        v->ne_ptr[n + 1]++;
    }
    for (int32_t n = 0; n < v->nn; ++n) v->ne_ptr[n + 1] += v->ne_ptr[n];
    memcpy(fill, v->ne_ptr, nn * sizeof *fill);
    for (int64_t k = 0; k < 4 * (int64_t)g->n; ++k) {
        const int32_t n = v->enode[k];
        v->wne[fill[n]] = 0.25 * g->vol[k / 4] / v->vn[n];
        v->ne[fill[n]++] = (int32_t)k;
    }
    /* patches: sorted and unique into list, compacted */
    int64_t np = 0;
    for (int32_t n = 0; n < v->nn; ++n) {
        int32_t *l = list + np;
        int64_t m = 0;
        for (int64_t k = v->ne_ptr[n]; k < v->ne_ptr[n + 1]; ++k)
            for (int a = 0; a < 4; ++a) l[m++] = g->idx[4 * (int64_t)(v->ne[k] / 4) + a];
        qsort(l, (size_t)m, sizeof *l, cmp_i32);
        int64_t u = 0;
        for (int64_t k = 0; k < m; ++k)
            if (k == 0 || l[k] != l[k - 1]) l[u++] = l[k];
        for (int64_t k = v->ne_ptr[n]; k < v->ne_ptr[n + 1]; ++k)
            for (int a = 0; a < 4; ++a)
                v->ploc[4 * k + a] =
                    defsim__lower_rank(l, u, g->idx[4 * (int64_t)(v->ne[k] / 4) + a]);
        np += u;
        v->patch_ptr[n + 1] = np;
        v->prank_ptr[n + 1] = v->prank_ptr[n] + u * u;
    }
    free(fill);
    v->patch = realloc(list, (size_t)(np > 0 ? np : 1) * sizeof *v->patch);
    if (!v->patch) { free(list); return DEFSIM_ERR_OUT_OF_MEMORY; }
    const size_t nr = (size_t)v->prank_ptr[v->nn] + 1, n1 = (size_t)g->n + 1;
    v->prank = malloc(nr * sizeof *v->prank);
    v->se = malloc(3 * n1 * sizeof *v->se);
    v->lin_pe = malloc(n1 * sizeof *v->lin_pe);
    v->sn = malloc(2 * nn * sizeof *v->sn);
    v->lin_un = malloc(nn * sizeof *v->lin_un);
    v->gn = malloc((3 * (size_t)np + 1) * sizeof *v->gn);
    if (!v->prank || !v->se || !v->lin_pe || !v->sn || !v->lin_un || !v->gn)
        return DEFSIM_ERR_OUT_OF_MEMORY;
    return DEFSIM_OK;
}

static defsim_status plan_groups(defsim__system *s, const defsim__plan_input *in)
{
    int32_t count[DEFSIM__GROUPS] = {0}, vcount[DEFSIM__TET_MODELS] = {0};
    for (int32_t b = 0; b < in->nbodies; ++b) {
        const defsim__body *bd = &in->bodies[b];
        if (!(bd->generation & 1u)) continue;
        if (bd->nt > 0)
            (bd->volume_averaging && bd->tet_nodes == 4 ? vcount : count)[group_of(bd)] += bd->nt;
        count[DEFSIM__TET_MODELS] += bd->ns;
    }
    defsim_status st = DEFSIM_OK;
    for (int m = 0; m < DEFSIM__GROUPS && st == DEFSIM_OK; ++m)
        st = group_alloc(&s->groups[m], m, count[m]);
    for (int m = 0; m < DEFSIM__TET_MODELS && st == DEFSIM_OK; ++m)
        if (vcount[m] > 0) st = group_alloc(&s->vgroups[m].g, m, vcount[m]);
    if (st != DEFSIM_OK) return st;
    for (int32_t b = 0; b < in->nbodies; ++b) {
        const defsim__body *bd = &in->bodies[b];
        if (!(bd->generation & 1u)) continue;
        const double beta = bd->mat.stiffness_damping;
        if (bd->nt > 0 && bd->tet_nodes == 10) {
            defsim__group *g = &s->groups[group_of(bd)];
            for (int32_t t = 0; t < bd->nt; ++t) {
                const int32_t *lt = bd->tets + 10 * (int64_t)t;
                const int32_t e = g->n++;
                g->vol[e] = defsim__tet10_rest(bd->rest, lt, g->qrest + DEFSIM__TET10_REST * (int64_t)e);
                g->mu[e] = bd->mu;
                g->lambda[e] = bd->lambda;
                g->beta[e] = beta;
                for (int a = 0; a < 10; ++a) g->idx[10 * (int64_t)e + a] = bd->offset + lt[a];
            }
        } else if (bd->nt > 0) {
            const int m = group_of(bd);
            defsim__group *g = bd->volume_averaging ? &s->vgroups[m].g : &s->groups[m];
            for (int32_t t = 0; t < bd->nt; ++t) {
                const int32_t *lt = bd->tets + 4 * (int64_t)t;
                const int32_t e = g->n++;
                defsim__tet_rest rest;
                defsim__tet_rest_eval(bd->rest, lt, &rest, g->dminv + 9 * (int64_t)e);
                g->vol[e] = fabs(rest.det) / 6.0;
                g->mu[e] = bd->mu;
                g->lambda[e] = bd->lambda;
                g->beta[e] = beta;
                for (int a = 0; a < 4; ++a) g->idx[4 * (int64_t)e + a] = bd->offset + lt[a];
            }
        }
        defsim__group *sg = &s->groups[DEFSIM__TET_MODELS];
        for (int32_t s = 0; s < bd->ns; ++s) {
            const int32_t a = bd->springs[2 * (int64_t)s], c = bd->springs[2 * (int64_t)s + 1];
            const int32_t e = sg->n++;
            const double *pa = bd->rest + 3 * (int64_t)a, *pc = bd->rest + 3 * (int64_t)c;
            double d0 = pc[0] - pa[0], d1 = pc[1] - pa[1], d2 = pc[2] - pa[2];
            sg->idx[2 * (int64_t)e] = bd->offset + a;
            sg->idx[2 * (int64_t)e + 1] = bd->offset + c;
            sg->k[e] = bd->k[s];
            sg->l0[e] = sqrt(d0 * d0 + d1 * d1 + d2 * d2);
            sg->beta[e] = beta;
        }
    }
    for (int m = 0; m < DEFSIM__GROUPS; ++m) {
        st = defsim__colour_group(&s->groups[m], s->nv);
        if (st == DEFSIM_OK && m < DEFSIM__TET_MODELS)
            st = pack_batches(&s->groups[m], tet_rows, DEFSIM__BATCH_ROWS);
        else if (st == DEFSIM_OK && m >= DEFSIM__QUAD_GROUP && s->groups[m].n > 0)   /* QMIX too */
            st = pack_batches(&s->groups[m], quad_rows, DEFSIM__QBATCH_ROWS);
        if (st != DEFSIM_OK) return st;
    }
    for (int m = 0; m < DEFSIM__TET_MODELS; ++m) {
        defsim__vgroup *v = &s->vgroups[m];
        if (v->g.n == 0) continue;
        s->has_volume_averaging = 1;
        if ((st = defsim__colour_group(&v->g, s->nv)) != DEFSIM_OK ||
            (st = plan_nodes(v, s->nv)) != DEFSIM_OK)
            return st;
    }
    s->tet_kernels = in->tet_kernels;
    return DEFSIM_OK;
}

/* The shells' groups (shell.h): each shell body's triangles into its membrane law's group
 * (their rows and rest areas as body.c made them), its hinges into the hinge group, and the
 * triangles of the bodies with a strain limit into the limit's group. */
static defsim_status plan_shells(defsim__system *s, const defsim__plan_input *in)
{
    int32_t count[DEFSIM__SHELL_GROUPS] = {0};
    for (int32_t b = 0; b < in->nbodies; ++b) {
        const defsim__body *bd = &in->bodies[b];
        if (!(bd->generation & 1u) || !bd->shell) continue;
        if (bd->membrane >= 0) count[bd->membrane] += bd->ntri;
        if (bd->strain_limit > 0.0) count[DEFSIM__SHELL_LIMITS] += bd->ntri;
        count[DEFSIM__SHELL_HINGES] += bd->nhinge;
    }
    for (int m = 0; m < DEFSIM__SHELL_GROUPS; ++m) {
        defsim__group *g = &s->shells[m];
        const size_t n = (size_t)(count[m] > 0 ? count[m] : 1);
        const int hinge = m == DEFSIM__SHELL_HINGES;
        g->nodes = hinge ? 4 : 3;
        g->pass = hinge ? DEFSIM_PASS_BENDING : DEFSIM_PASS_MEMBRANE;
        g->idx = malloc(n * g->nodes * sizeof *g->idx);
        g->beta = calloc(n, sizeof *g->beta);
        if (!g->idx || !g->beta) return DEFSIM_ERR_OUT_OF_MEMORY;
        if (hinge) {
            g->k = malloc(n * sizeof *g->k);
            g->l0 = malloc(n * sizeof *g->l0);
            if (!g->k || !g->l0) return DEFSIM_ERR_OUT_OF_MEMORY;
        } else {
            g->shell_width = DEFSIM__MEMBRANE_WIDTH;
            g->shell_law = m;
            g->shell = malloc(n * DEFSIM__MEMBRANE_WIDTH * sizeof *g->shell);
            g->vol = malloc(n * sizeof *g->vol);
            if (!g->shell || !g->vol) return DEFSIM_ERR_OUT_OF_MEMORY;
        }
    }
    for (int32_t b = 0; b < in->nbodies; ++b) {
        const defsim__body *bd = &in->bodies[b];
        if (!(bd->generation & 1u) || !bd->shell) continue;
        if (bd->membrane >= 0) {
            defsim__group *g = &s->shells[bd->membrane];
            for (int32_t t = 0; t < bd->ntri; ++t) {
                const int32_t e = g->n++;
                for (int a = 0; a < 3; ++a)
                    g->idx[3 * (int64_t)e + a] = bd->offset + bd->tris[3 * (int64_t)t + a];
                memcpy(g->shell + DEFSIM__MEMBRANE_WIDTH * (int64_t)e,
                       bd->mrow + DEFSIM__MEMBRANE_WIDTH * (int64_t)t,
                       DEFSIM__MEMBRANE_WIDTH * sizeof *g->shell);
                g->vol[e] = bd->marea[t];
            }
        }
        if (bd->strain_limit > 0.0) {
            defsim__group *g = &s->shells[DEFSIM__SHELL_LIMITS];
            for (int32_t t = 0; t < bd->ntri; ++t) {
                const int32_t e = g->n++;
                for (int a = 0; a < 3; ++a)
                    g->idx[3 * (int64_t)e + a] = bd->offset + bd->tris[3 * (int64_t)t + a];
                defsim__strain_limit_row(bd->membrane,
                                         bd->mrow + DEFSIM__MEMBRANE_WIDTH * (int64_t)t,
                                         bd->strain_limit,
                                         g->shell + DEFSIM__MEMBRANE_WIDTH * (int64_t)e);
                g->vol[e] = bd->marea[t];
            }
        }
        defsim__group *g = &s->shells[DEFSIM__SHELL_HINGES];
        for (int32_t h = 0; h < bd->nhinge; ++h) {
            const int32_t e = g->n++;
            for (int a = 0; a < 4; ++a)
                g->idx[4 * (int64_t)e + a] = bd->offset + bd->hinges[4 * (int64_t)h + a];
            g->k[e] = bd->hw[h];
            g->l0[e] = bd->htheta0[h];
        }
    }
    for (int m = 0; m < DEFSIM__SHELL_GROUPS; ++m) {
        defsim_status st = defsim__colour_group(&s->shells[m], s->nv);
        /* the batched force kernels' layout (tet_forces.h) for the membranes and hinges */
        if (st == DEFSIM_OK && m < DEFSIM__SHELL_LIMITS)
            st = pack_batches(&s->shells[m],
                              m == DEFSIM__SHELL_HINGES ? hinge_rows : membrane_rows,
                              DEFSIM__BATCH_ROWS);
        if (st != DEFSIM_OK) return st;
    }
    return DEFSIM_OK;
}

/* Attachments in world vertex ids: node 0 the attached vertex, then the target's vertices. */
static defsim_status plan_attachments(defsim__system *s, const defsim__plan_input *in)
{
    int32_t n = 0;
    for (int32_t i = 0; i < in->nattachments; ++i) n += (in->attachments[i].generation & 1u) != 0;
    if (n == 0) return DEFSIM_OK;
    defsim__attachments *at = &s->att;
    const int an = DEFSIM__ATTACH_NODES;
    at->node = malloc((size_t)n * an * sizeof *at->node);
    at->a = malloc((size_t)n * an * sizeof *at->a);
    at->k = malloc((size_t)n * sizeof *at->k);
    at->c = malloc((size_t)n * sizeof *at->c);
    at->p = malloc((size_t)n * 3 * sizeof *at->p);
    if (!at->node || !at->a || !at->k || !at->c || !at->p) return DEFSIM_ERR_OUT_OF_MEMORY;
    for (int32_t i = 0; i < in->nattachments; ++i) {
        if (!(in->attachments[i].generation & 1u)) continue;
        const defsim_attachment_def *d = &in->attachments[i].def;
        const int32_t e = at->n++;
        int32_t *nd = at->node + an * (int64_t)e;
        double *a = at->a + an * (int64_t)e;
        for (int j = 0; j < an; ++j) { nd[j] = -1; a[j] = 0.0; }
        nd[0] = in->bodies[in->body_dense[DEFSIM__ID_SLOT(d->body.index)]].offset + d->vertex;
        a[0] = 1.0;
        const int point = d->target_body.index == 0;
        for (int c = 0; c < 3; ++c) at->p[3 * (int64_t)e + c] = point ? d->target[c] : 0.0;
        const int32_t target_offset =
            point ? 0 : in->bodies[in->body_dense[DEFSIM__ID_SLOT(d->target_body.index)]].offset;
        if (!point)
            for (int j = 0; j < d->target_vertex_count; ++j) {
                nd[1 + j] = target_offset + d->target_vertices[j];
                a[1 + j] = -d->target_weights[j];
            }
        at->k[e] = d->stiffness;
        at->c[e] = d->damping;
        if (d->damping > 0.0) s->has_attachment_damping = 1;
    }
    return DEFSIM_OK;
}

defsim_status defsim__plan(defsim__system *s, defsim__work *wk, const defsim__plan_input *in)
{
    defsim__unplan(s, wk);
    s->nv = in->nv;
    s->nthreads = in->nthreads;
    s->projection = in->projection;
    for (int c = 0; c < 3; ++c) s->gravity[c] = in->gravity[c];
    const int64_t ndof = 3 * (int64_t)s->nv;
    const size_t nd = (size_t)(ndof > 0 ? ndof : 1), nv = (size_t)(s->nv > 0 ? s->nv : 1);
    defsim_status st = plan_groups(s, in);
    if (st == DEFSIM_OK) st = plan_shells(s, in);
    if (st == DEFSIM_OK) st = plan_attachments(s, in);
    if (st != DEFSIM_OK) goto fail;
    st = DEFSIM_ERR_OUT_OF_MEMORY;
    s->mass = malloc(nv * sizeof *s->mass);
    s->pinned = malloc(nv);
    s->mass3 = malloc(nd * sizeof *s->mass3);
    s->alpha3 = malloc(nd * sizeof *s->alpha3);
    s->free_dofs = malloc(nd * sizeof *s->free_dofs);
    s->dof_to_free = malloc(nd * sizeof *s->dof_to_free);
    s->vfree = malloc(nv * sizeof *s->vfree);
    /* A batched energy sums blocks of DEFSIM__REDUCE_BLOCK / DEFSIM__BATCH batches, padding
     * lanes counted (term_elastic_quadratic.c). */
    int64_t maxn = 1;
    for (int m = 0; m < DEFSIM__GROUPS; ++m) {
        const int64_t lanes = (int64_t)s->groups[m].nbatch * DEFSIM__BATCH;
        if (s->groups[m].n > maxn) maxn = s->groups[m].n;
        if (lanes > maxn) maxn = lanes;
    }
    for (int m = 0; m < DEFSIM__TET_MODELS; ++m) {
        if (s->vgroups[m].g.n > maxn) maxn = s->vgroups[m].g.n;
        if (s->vgroups[m].nn > maxn) maxn = s->vgroups[m].nn;
    }
    for (int m = 0; m < DEFSIM__SHELL_GROUPS; ++m)
        if (s->shells[m].n > maxn) maxn = s->shells[m].n;
    wk->npartial = (int32_t)((maxn + DEFSIM__REDUCE_BLOCK - 1) / DEFSIM__REDUCE_BLOCK);
    wk->partial = malloc((size_t)wk->npartial * sizeof *wk->partial);
    wk->pz = malloc(nd * sizeof *wk->pz);
    wk->py = malloc(nd * sizeof *wk->py);
    wk->pu = malloc(nd * sizeof *wk->pu);
    if (!s->mass || !s->pinned || !s->mass3 || !s->alpha3 || !s->free_dofs || !s->dof_to_free ||
        !s->vfree || !wk->partial || !wk->pz || !wk->py || !wk->pu)
        goto fail;
    if (s->nv > 0) {
        memcpy(s->mass, in->mass, (size_t)s->nv * sizeof *s->mass);
        memcpy(s->pinned, in->pinned, (size_t)s->nv);
    }

    /* Per-DOF data, free maps and which passes the scene needs. */
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int32_t b = 0; b < in->nbodies; ++b) {
        const defsim__body *bd = &in->bodies[b];
        if (!(bd->generation & 1u)) continue;
        if (bd->mat.stiffness_damping > 0.0 && (bd->nt > 0 || bd->ns > 0))
            s->has_stiffness_damping = 1;
        for (int32_t i = 0; i < bd->nv; ++i) {
            const int64_t v = bd->offset + i;
            for (int c = 0; c < 3; ++c) {
                s->mass3[3 * v + c] = bd->mass[i];
                s->alpha3[3 * v + c] = bd->mat.mass_damping;
                double p = bd->rest[3 * (int64_t)i + c];
                if (p < lo[c]) lo[c] = p;
                if (p > hi[c]) hi[c] = p;
            }
            if (bd->mat.mass_damping > 0.0 && !s->pinned[v]) s->has_mass_damping = 1;
        }
    }
    for (int32_t v = 0; v < s->nv; ++v) {
        if (s->pinned[v]) {
            s->has_pins = 1;
            s->vfree[v] = -1;
            for (int c = 0; c < 3; ++c) s->dof_to_free[3 * (int64_t)v + c] = -1;
            continue;
        }
        s->vfree[v] = s->nfree_v++;
        for (int c = 0; c < 3; ++c) {
            s->dof_to_free[3 * (int64_t)v + c] = s->nfree;
            s->free_dofs[s->nfree++] = 3 * (int64_t)v + c;
        }
    }
    const double *g = s->gravity;
    s->has_gravity = (g[0] != 0.0 || g[1] != 0.0 || g[2] != 0.0) && s->nv > 0;
    double diag = 0.0;
    if (s->nv > 0)
        diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                    (hi[2] - lo[2]) * (hi[2] - lo[2]));
    s->length_scale = diag > 0.0 ? diag : 1.0;
    if ((st = defsim__terms_compile(s)) != DEFSIM_OK) goto fail;
    if (in->need_matrix && (st = defsim__pattern_build(s)) != DEFSIM_OK) goto fail;
    return DEFSIM_OK;
fail:
    defsim__unplan(s, wk);
    return st;
}

/* SPDX-License-Identifier: MIT */
/*
 * The system: the world's physics over planned element groups. Forces, energies, sparse
 * matrices. Elements of one group are sorted by colour (no two elements of a colour share a
 * vertex), so each colour scatters into per-vertex arrays in parallel without atomics, and every
 * sum is formed in the same order whatever the thread count: results are bit-identical for any
 * number of threads.
 */
#include "world.h"

#include "mat3.h"
#include "material_models.h"
#include "tet_forces.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#ifdef _OPENMP
#include <omp.h>
#endif

/* Deterministic reductions sum fixed blocks of elements, then the blocks in order. */
enum { REDUCE_BLOCK = 2048, PAR_MIN = 1024 };

/* ------------------------------------------------------------------------------------------ */
/* Per-node gradient vectors: dF = sum_a dx_a g_a^T, with g_a = row a of Dm^-1 (a < 3) and
 * g_3 = -(g_0 + g_1 + g_2). */

static inline void tet_gradients(const double *dminv, double g[4][3])
{
    for (int j = 0; j < 3; ++j) {
        g[0][j] = dminv[0 * 3 + j];
        g[1][j] = dminv[1 * 3 + j];
        g[2][j] = dminv[2 * 3 + j];
        g[3][j] = -(g[0][j] + g[1][j] + g[2][j]);
    }
}

/* F = Ds Dm^-1 with Ds = [x0 - x3, x1 - x3, x2 - x3] (columns). */
static inline void tet_deformation(const double *x, const int32_t *id, const double *dminv,
                                   double F[9])
{
    const double *p3 = x + 3 * (int64_t)id[3];
    double ds[9];
    for (int a = 0; a < 3; ++a) {
        const double *pa = x + 3 * (int64_t)id[a];
        for (int i = 0; i < 3; ++i) ds[3 * i + a] = pa[i] - p3[i];
    }
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            F[3 * i + j] = ds[3 * i + 0] * dminv[0 + j] + ds[3 * i + 1] * dminv[3 + j] +
                           ds[3 * i + 2] * dminv[6 + j];
}

/* Adds s * P g_a to the force of node a (s = -volume for elastic forces). */
static inline void tet_scatter(double *f, const int32_t *id, const double *dminv,
                               const double P[9], double s)
{
    double h[3][3];   /* h[a][i] = s sum_j P_ij Dminv[a][j] */
    for (int a = 0; a < 3; ++a)
        for (int i = 0; i < 3; ++i)
            h[a][i] = s * (P[3 * i + 0] * dminv[3 * a + 0] + P[3 * i + 1] * dminv[3 * a + 1] +
                           P[3 * i + 2] * dminv[3 * a + 2]);
    for (int a = 0; a < 3; ++a) {
        double *fa = f + 3 * (int64_t)id[a];
        fa[0] += h[a][0];
        fa[1] += h[a][1];
        fa[2] += h[a][2];
    }
    double *f3 = f + 3 * (int64_t)id[3];
    f3[0] -= h[0][0] + h[1][0] + h[2][0];
    f3[1] -= h[0][1] + h[1][1] + h[2][1];
    f3[2] -= h[0][2] + h[1][2] + h[2][2];
}

static inline void apply_dpdf(const double D[81], const double dF[9], double dP[9])
{
    for (int r = 0; r < 9; ++r) {
        double s = 0.0;
        for (int c = 0; c < 9; ++c) s += D[9 * r + c] * dF[c];
        dP[r] = s;
    }
}

/* dPdF of any tet model (not the hot path). */
static void group_dpdf(int model, double mu, double la, const double F[9], double D[81])
{
    switch (model) {
    case DEFSIM_MODEL_STVK: defsim__stvk_dPdF(mu, la, F, D); break;
    case DEFSIM_MODEL_COROTATED: defsim__corotated_dPdF(mu, la, F, D); break;
    case DEFSIM_MODEL_NEOHOOKEAN: defsim__neohookean_dPdF(mu, la, F, D); break;
    default: defsim__snh_dPdF(mu, la, F, D); break;
    }
}

/* dPdF of a tet model made positive semi-definite (mode DEFSIM_PROJECTION_CLAMP or _ABS) from
 * its eigen-structure in signed singular values (material_models.h, *_sigma): the 3 x 3 block h
 * is projected and the six twist / flip eigenvalues clamped, which is the projection of the
 * 9 x 9 tensor without a 9 x 9 eigensolver. D2, if not NULL, receives the projection with mode2
 * from the same decomposition. */
static void group_dpdf_projected(int model, double mu, double la, const double F[9], int mode,
                                 double D[81], int mode2, double *D2)
{
    double U[9], V[9], s[3], h[9], es[3], ek[3];
    defsim__svd3(F, U, s, V);
    switch (model) {
    case DEFSIM_MODEL_STVK: defsim__stvk_sigma(mu, la, s, h, es, ek); break;
    case DEFSIM_MODEL_COROTATED: defsim__corotated_sigma(mu, la, s, h, es, ek); break;
    case DEFSIM_MODEL_NEOHOOKEAN: defsim__neohookean_sigma(mu, la, s, h, es, ek); break;
    default: defsim__snh_sigma(mu, la, s, h, es, ek); break;
    }
    const int modes[2] = {mode, mode2};
    double *out[2] = {D, D2};
    for (int k = 0; k < 2; ++k) {
        if (!out[k]) continue;
        double hp[9], esp[3], ekp[3];
        memcpy(hp, h, sizeof hp);
        /* Positive definite (leading minors > 0, Sylvester), the common case: nothing to do. */
        const double m2 = h[0] * h[4] - h[1] * h[3];
        const double m3 = h[0] * (h[4] * h[8] - h[5] * h[7]) - h[1] * (h[3] * h[8] - h[5] * h[6]) +
                          h[2] * (h[3] * h[7] - h[4] * h[6]);
        if (!(h[0] > 0.0 && m2 > 0.0 && m3 > 0.0)) defsim__project_psd(3, hp, modes[k]);
        for (int p = 0; p < 3; ++p) {
            esp[p] = es[p] < 0.0 ? (modes[k] == DEFSIM_PROJECTION_ABS ? -es[p] : 0.0) : es[p];
            ekp[p] = ek[p] < 0.0 ? (modes[k] == DEFSIM_PROJECTION_ABS ? -ek[p] : 0.0) : ek[p];
        }
        defsim__isotropic_dPdF(U, V, hp, esp, ekp, out[k]);
    }
}

/* ------------------------------------------------------------------------------------------ */
/* Elastic force kernels: one per material model, the constitutive law inlined. */

#define DEFSIM__TET_FORCE_KERNEL(NAME, PFUN)                                                  \
    static void NAME(const defsim__group *g, const double *x, double *f, int nthreads)       \
    {                                                                                         \
        (void)nthreads;                                                                       \
        for (int32_t c = 0; c < g->ncolors; ++c) {                                            \
            const int32_t e0 = g->color_ptr[c], e1 = g->color_ptr[c + 1];                     \
            _Pragma("omp parallel for schedule(static) num_threads(nthreads) if(e1 - e0 > PAR_MIN)") \
            for (int32_t e = e0; e < e1; ++e) {                                               \
                const int32_t *id = g->idx + 4 * (int64_t)e;                                  \
                const double *dm = g->dminv + 9 * (int64_t)e;                                 \
                double F[9], P[9];                                                            \
                tet_deformation(x, id, dm, F);                                                \
                (void)PFUN(g->mu[e], g->lambda[e], F, P);                                     \
                tet_scatter(f, id, dm, P, -g->vol[e]);                                        \
            }                                                                                 \
        }                                                                                     \
    }

DEFSIM__TET_FORCE_KERNEL(forces_stvk, defsim__stvk_P)
DEFSIM__TET_FORCE_KERNEL(forces_corotated, defsim__corotated_P)
DEFSIM__TET_FORCE_KERNEL(forces_neohookean, defsim__neohookean_P)
DEFSIM__TET_FORCE_KERNEL(forces_snh, defsim__snh_P)

typedef void (*tet_force_fn)(const defsim__group *, const double *, double *, int);
static const tet_force_fn tet_force_kernels[DEFSIM__TET_MODELS] = {
    forces_stvk, forces_corotated, forces_neohookean, forces_snh};

/* The batched kernels (tet_forces.c) come in one variant per instruction set; the scalar
 * kernels above remain the reference (core.simd = scalar). */
const defsim__tet_kernels *defsim__tet_kernels_find(const char *name)
{
    if (!name) return NULL;
    if (!strcmp(name, "generic")) return &defsim__tet_kernels_generic;
#if defined(DEFSIM_HAVE_X86_KERNELS)
    __builtin_cpu_init();
    if (!strcmp(name, "avx2") && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))
        return &defsim__tet_kernels_avx2;
    if (!strcmp(name, "avx512") && __builtin_cpu_supports("avx512f") &&
        __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl"))
        return &defsim__tet_kernels_avx512;
#endif
    return NULL;
}

const defsim__tet_kernels *defsim__tet_kernels_best(void)
{
    static const char *const order[] = {"avx512", "avx2", "generic"};
    for (int i = 0; i < 3; ++i) {
        const defsim__tet_kernels *k = defsim__tet_kernels_find(order[i]);
        if (k) return k;
    }
    return &defsim__tet_kernels_generic;
}

/* Spring direction, length and the 3x3 block Kb = k (n n^T + s (I - n n^T)), s = 1 - l0/l,
 * with s projected as the element's Hessian would be (its eigenvalues are k and k s). */
static inline void spring_block(const double *xa, const double *xb, double k, double l0,
                                int projection, double Kb[9])
{
    double d[3] = {xb[0] - xa[0], xb[1] - xa[1], xb[2] - xa[2]};
    double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    double n[3] = {0, 0, 0};
    double s = 0.0;
    if (l > 0.0) {
        n[0] = d[0] / l; n[1] = d[1] / l; n[2] = d[2] / l;
        s = 1.0 - l0 / l;
    }
    if (projection == DEFSIM_PROJECTION_CLAMP && s < 0.0) s = 0.0;
    if (projection == DEFSIM_PROJECTION_ABS) s = fabs(s);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            Kb[3 * i + j] = k * ((1.0 - s) * n[i] * n[j] + (i == j ? s : 0.0));
}

static void forces_springs(const defsim__group *g, const double *x, double *f, int nthreads)
{
    (void)nthreads;   /* used by OpenMP pragmas only */
    for (int32_t c = 0; c < g->ncolors; ++c) {
        const int32_t e0 = g->color_ptr[c], e1 = g->color_ptr[c + 1];
#pragma omp parallel for schedule(static) num_threads(nthreads) if (e1 - e0 > PAR_MIN)
        for (int32_t e = e0; e < e1; ++e) {
            const int32_t a = g->idx[2 * (int64_t)e], b = g->idx[2 * (int64_t)e + 1];
            const double *xa = x + 3 * (int64_t)a, *xb = x + 3 * (int64_t)b;
            double d[3] = {xb[0] - xa[0], xb[1] - xa[1], xb[2] - xa[2]};
            double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            /* f_a = k (l - l0) d / l; a spring of zero current length exerts no force. */
            double s = l > 0.0 ? g->k[e] * (l - g->l0[e]) / l : 0.0;
            for (int i = 0; i < 3; ++i) {
                f[3 * (int64_t)a + i] += s * d[i];
                f[3 * (int64_t)b + i] -= s * d[i];
            }
        }
    }
}

/* Stiffness damping -beta K_e(x) v_e per element with the element stiffness made positive
 * semi-definite (analytic eigenvalue clamping of dP/dF): linear in v, never injects energy, and
 * the same matrix B that implicit backends assemble. */
static void damping_tets(const defsim__group *g, const double *x, const double *v, double *f,
                         int nthreads)
{
    (void)nthreads;   /* used by OpenMP pragmas only */
    for (int32_t c = 0; c < g->ncolors; ++c) {
        const int32_t e0 = g->color_ptr[c], e1 = g->color_ptr[c + 1];
#pragma omp parallel for schedule(static) num_threads(nthreads) if (e1 - e0 > PAR_MIN / 8)
        for (int32_t e = e0; e < e1; ++e) {
            if (g->beta[e] == 0.0) continue;
            const int32_t *id = g->idx + 4 * (int64_t)e;
            const double *dm = g->dminv + 9 * (int64_t)e;
            double F[9], dF[9], D[81], dP[9];
            tet_deformation(x, id, dm, F);
            tet_deformation(v, id, dm, dF);
            group_dpdf_projected(g->model, g->mu[e], g->lambda[e], F, DEFSIM_PROJECTION_CLAMP, D,
                                 0, NULL);
            apply_dpdf(D, dF, dP);
            tet_scatter(f, id, dm, dP, -g->beta[e] * g->vol[e]);
        }
    }
}

static void damping_springs(const defsim__group *g, const double *x, const double *v, double *f,
                            int nthreads)
{
    (void)nthreads;   /* used by OpenMP pragmas only */
    for (int32_t c = 0; c < g->ncolors; ++c) {
        const int32_t e0 = g->color_ptr[c], e1 = g->color_ptr[c + 1];
#pragma omp parallel for schedule(static) num_threads(nthreads) if (e1 - e0 > PAR_MIN)
        for (int32_t e = e0; e < e1; ++e) {
            if (g->beta[e] == 0.0) continue;
            const int32_t a = g->idx[2 * (int64_t)e], b = g->idx[2 * (int64_t)e + 1];
            double Kb[9];
            spring_block(x + 3 * (int64_t)a, x + 3 * (int64_t)b, g->k[e], g->l0[e],
                         DEFSIM_PROJECTION_CLAMP, Kb);
            const double *va = v + 3 * (int64_t)a, *vb = v + 3 * (int64_t)b;
            double dv[3] = {vb[0] - va[0], vb[1] - va[1], vb[2] - va[2]};
            for (int i = 0; i < 3; ++i) {
                double s = g->beta[e] * (Kb[3 * i] * dv[0] + Kb[3 * i + 1] * dv[1] +
                                         Kb[3 * i + 2] * dv[2]);
                f[3 * (int64_t)a + i] += s;
                f[3 * (int64_t)b + i] -= s;
            }
        }
    }
}

static int all_finite(const double *a, int64_t n)
{
    int ok = 1;
    for (int64_t i = 0; i < n; ++i) ok &= isfinite(a[i]);
    return ok;
}

defsim_status defsim__forces(defsim_world *w, const double *x, const double *v, uint32_t which,
                             double *f)
{
    double t0 = defsim__now();
    const int64_t ndof = 3 * (int64_t)w->nv;
    const int nt = w->nthreads;
    memset(f, 0, (size_t)ndof * sizeof *f);
    if (which & DEFSIM_FORCE_ELASTIC) {
        for (int m = 0; m < DEFSIM__TET_MODELS; ++m) {
            if (w->groups[m].n == 0) continue;
            if (w->tet_kernels) w->tet_kernels->forces[m](&w->groups[m], x, f, nt);
            else tet_force_kernels[m](&w->groups[m], x, f, nt);
            w->step_passes |= w->groups[m].pass;
        }
        defsim__group *sg = &w->groups[DEFSIM__TET_MODELS];
        if (sg->n > 0) {
            forces_springs(sg, x, f, nt);
            w->step_passes |= DEFSIM_PASS_SPRINGS;
        }
    }
    if ((which & DEFSIM_FORCE_DAMPING) && v) {
        if (w->has_stiffness_damping) {
            for (int m = 0; m < DEFSIM__TET_MODELS; ++m)
                if (w->groups[m].n > 0) damping_tets(&w->groups[m], x, v, f, nt);
            defsim__group *sg = &w->groups[DEFSIM__TET_MODELS];
            if (sg->n > 0) damping_springs(sg, x, v, f, nt);
            w->step_passes |= DEFSIM_PASS_STIFFNESS_DAMPING;
        }
        if (w->has_mass_damping) {
            for (int64_t i = 0; i < ndof; ++i) f[i] -= w->alpha3[i] * w->mass3[i] * v[i];
            w->step_passes |= DEFSIM_PASS_MASS_DAMPING;
        }
    }
    if ((which & DEFSIM_FORCE_GRAVITY) && w->has_gravity) {
        const double *gr = w->def.gravity;
        for (int32_t i = 0; i < w->nv; ++i) {
            f[3 * (int64_t)i + 0] += w->mass[i] * gr[0];
            f[3 * (int64_t)i + 1] += w->mass[i] * gr[1];
            f[3 * (int64_t)i + 2] += w->mass[i] * gr[2];
        }
        w->step_passes |= DEFSIM_PASS_GRAVITY;
    }
    if (w->has_pins && !(which & DEFSIM__FORCE_KEEP_PINNED)) {
        for (int32_t i = 0; i < w->nv; ++i)
            if (w->pinned[i]) f[3 * (int64_t)i] = f[3 * (int64_t)i + 1] = f[3 * (int64_t)i + 2] = 0.0;
        w->step_passes |= DEFSIM_PASS_PINS;
    }
    w->stats.force_evals++;
    w->stats.time_forces += defsim__now() - t0;
    return all_finite(f, ndof) ? DEFSIM_OK : DEFSIM_ERR_UNSTABLE;
}

/* ------------------------------------------------------------------------------------------ */
/* Energies (deterministic blocked sums). */

static double element_energy(const defsim__group *g, const double *x, int32_t e)
{
    if (g->nodes == 2) {
        const double *xa = x + 3 * (int64_t)g->idx[2 * (int64_t)e];
        const double *xb = x + 3 * (int64_t)g->idx[2 * (int64_t)e + 1];
        double d0 = xb[0] - xa[0], d1 = xb[1] - xa[1], d2 = xb[2] - xa[2];
        double dl = sqrt(d0 * d0 + d1 * d1 + d2 * d2) - g->l0[e];
        return 0.5 * g->k[e] * dl * dl;
    }
    double F[9], psi;
    tet_deformation(x, g->idx + 4 * (int64_t)e, g->dminv + 9 * (int64_t)e, F);
    const double mu = g->mu[e], la = g->lambda[e];
    switch (g->model) {
    case DEFSIM_MODEL_STVK: psi = defsim__stvk_psi(mu, la, F); break;
    case DEFSIM_MODEL_COROTATED: psi = defsim__corotated_psi(mu, la, F); break;
    case DEFSIM_MODEL_NEOHOOKEAN: psi = defsim__neohookean_psi(mu, la, F); break;
    default: psi = defsim__snh_psi(mu, la, F) - defsim__snh_psi_rest(mu, la); break;
    }
    return g->vol[e] * psi;
}

double defsim__elastic_energy(defsim_world *w, const double *x)
{
    double total = 0.0;
    for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) {
        const defsim__group *g = &w->groups[m];
        if (g->n == 0) continue;
        const int32_t nb = (g->n + REDUCE_BLOCK - 1) / REDUCE_BLOCK;
        double *part = w->partial;
#pragma omp parallel for schedule(static) num_threads(w->nthreads) if (nb > 1)
        for (int32_t b = 0; b < nb; ++b) {
            int32_t e1 = (b + 1) * REDUCE_BLOCK < g->n ? (b + 1) * REDUCE_BLOCK : g->n;
            double s = 0.0;
            for (int32_t e = b * REDUCE_BLOCK; e < e1; ++e) s += element_energy(g, x, e);
            part[b] = s;
        }
        for (int32_t b = 0; b < nb; ++b) total += part[b];
    }
    return isnan(total) ? INFINITY : total;
}

double defsim__potential_energy(defsim_world *w, const double *x)
{
    double e = defsim__elastic_energy(w, x);
    if (w->has_gravity) {
        const double *gr = w->def.gravity;
        double s = 0.0;
        for (int32_t i = 0; i < w->nv; ++i)
            s -= w->mass[i] * (gr[0] * x[3 * (int64_t)i] + gr[1] * x[3 * (int64_t)i + 1] +
                               gr[2] * x[3 * (int64_t)i + 2]);
        e += s;
    }
    w->stats.energy_evals++;
    w->step_passes |= DEFSIM_PASS_ENERGY;
    return e;
}

/* ------------------------------------------------------------------------------------------ */
/* Sparse matrices over free DOFs. Free DOFs come in vertex triples, so the pattern is made of
 * 3x3 blocks: column 3 fb + cb holds, for each neighbour fa of fb (sorted, itself included), the
 * rows 3 fa .. 3 fa + 2 (UPPER: neighbours fa < fb, then rows 3 fb .. 3 fb + cb). The rank of fa
 * in fb's neighbour list, stored per element node pair (blk), locates an entry in both. */

static int cmp_i32(const void *a, const void *b)
{
    int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
    return (x > y) - (x < y);
}

static int32_t find_rank(const int32_t *list, int64_t n, int32_t key)
{
    int64_t lo = 0, hi = n;
    while (lo < hi) {
        int64_t mid = (lo + hi) / 2;
        if (list[mid] < key) lo = mid + 1; else hi = mid;
    }
    return (int32_t)lo;
}

static defsim_status build_pattern(defsim_world *w)
{
    const int32_t nfv = w->nfree_v;
    int64_t *cnt = calloc((size_t)nfv + 1, sizeof *cnt);
    if (!cnt) return DEFSIM_ERR_OUT_OF_MEMORY;
    for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) {
        const defsim__group *g = &w->groups[m];
        for (int64_t e = 0; e < g->n; ++e)
            for (int a = 0; a < g->nodes; ++a) {
                int32_t fa = w->vfree[g->idx[g->nodes * e + a]];
                if (fa < 0) continue;
                for (int b = 0; b < g->nodes; ++b)
                    if (w->vfree[g->idx[g->nodes * e + b]] >= 0) cnt[fa + 1]++;
            }
    }
    for (int32_t i = 0; i < nfv; ++i) cnt[i + 1] += cnt[i] + 1;   /* + self */
    int32_t *tmp = malloc((size_t)(cnt[nfv] > 0 ? cnt[nfv] : 1) * sizeof *tmp);
    int64_t *fill = malloc(((size_t)nfv + 1) * sizeof *fill);
    if (!tmp || !fill) { free(cnt); free(tmp); free(fill); return DEFSIM_ERR_OUT_OF_MEMORY; }
    for (int32_t i = 0; i < nfv; ++i) { fill[i] = cnt[i]; tmp[fill[i]++] = i; }
    for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) {
        const defsim__group *g = &w->groups[m];
        for (int64_t e = 0; e < g->n; ++e)
            for (int a = 0; a < g->nodes; ++a) {
                int32_t fa = w->vfree[g->idx[g->nodes * e + a]];
                if (fa < 0) continue;
                for (int b = 0; b < g->nodes; ++b) {
                    int32_t fb = w->vfree[g->idx[g->nodes * e + b]];
                    if (fb >= 0) tmp[fill[fa]++] = fb;
                }
            }
    }
    /* Sort and deduplicate each list in place, compacting into adj. */
    w->adj_ptr = malloc(((size_t)nfv + 1) * sizeof *w->adj_ptr);
    w->upper_rank0 = malloc(((size_t)nfv + 1) * sizeof *w->upper_rank0);
    if (!w->adj_ptr || !w->upper_rank0) { free(cnt); free(tmp); free(fill); return DEFSIM_ERR_OUT_OF_MEMORY; }
    int64_t out = 0;
    w->adj_ptr[0] = 0;
    for (int32_t i = 0; i < nfv; ++i) {
        int32_t *l = tmp + cnt[i];
        int64_t n = cnt[i + 1] - cnt[i];
        qsort(l, (size_t)n, sizeof *l, cmp_i32);
        int64_t start = out;
        for (int64_t k = 0; k < n; ++k)
            if (k == 0 || l[k] != l[k - 1]) tmp[out++] = l[k];
        w->adj_ptr[i + 1] = out;
        w->upper_rank0[i] = find_rank(tmp + start, out - start, i);
    }
    free(cnt);
    free(fill);
    w->adj = realloc(tmp, (size_t)(out > 0 ? out : 1) * sizeof *tmp);
    if (!w->adj) { free(tmp); return DEFSIM_ERR_OUT_OF_MEMORY; }

    /* Element node-pair ranks. */
    for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) {
        defsim__group *g = &w->groups[m];
        if (g->n == 0) continue;
        const int nn = g->nodes;
        g->blk = malloc((size_t)g->n * nn * nn * sizeof *g->blk);
        if (!g->blk) return DEFSIM_ERR_OUT_OF_MEMORY;
        for (int64_t e = 0; e < g->n; ++e)
            for (int a = 0; a < nn; ++a)
                for (int b = 0; b < nn; ++b) {
                    int32_t fa = w->vfree[g->idx[nn * e + a]], fb = w->vfree[g->idx[nn * e + b]];
                    int32_t r = -1;
                    if (fa >= 0 && fb >= 0)
                        r = find_rank(w->adj + w->adj_ptr[fb], w->adj_ptr[fb + 1] - w->adj_ptr[fb], fa);
                    g->blk[(nn * e + a) * nn + b] = r;
                }
    }

    /* Column pointers and row indices of both layouts. */
    const int64_t n = 3 * (int64_t)nfv;
    w->full_col_ptr = malloc(((size_t)n + 1) * sizeof(int64_t));
    w->upper_col_ptr = malloc(((size_t)n + 1) * sizeof(int64_t));
    if (!w->full_col_ptr || !w->upper_col_ptr) return DEFSIM_ERR_OUT_OF_MEMORY;
    w->full_col_ptr[0] = w->upper_col_ptr[0] = 0;
    for (int32_t fb = 0; fb < nfv; ++fb) {
        int64_t deg = w->adj_ptr[fb + 1] - w->adj_ptr[fb];
        for (int cb = 0; cb < 3; ++cb) {
            int64_t j = 3 * (int64_t)fb + cb;
            w->full_col_ptr[j + 1] = w->full_col_ptr[j] + 3 * deg;
            w->upper_col_ptr[j + 1] = w->upper_col_ptr[j] + 3 * (int64_t)w->upper_rank0[fb] + cb + 1;
        }
    }
    w->full_nnz = w->full_col_ptr[n];
    w->upper_nnz = w->upper_col_ptr[n];
    w->full_row_idx = malloc((size_t)(w->full_nnz > 0 ? w->full_nnz : 1) * sizeof(int64_t));
    w->upper_row_idx = malloc((size_t)(w->upper_nnz > 0 ? w->upper_nnz : 1) * sizeof(int64_t));
    if (!w->full_row_idx || !w->upper_row_idx) return DEFSIM_ERR_OUT_OF_MEMORY;
    for (int32_t fb = 0; fb < nfv; ++fb)
        for (int cb = 0; cb < 3; ++cb) {
            int64_t j = 3 * (int64_t)fb + cb;
            int64_t pf = w->full_col_ptr[j], pu = w->upper_col_ptr[j];
            for (int64_t k = w->adj_ptr[fb]; k < w->adj_ptr[fb + 1]; ++k) {
                int32_t fa = w->adj[k];
                for (int ca = 0; ca < 3; ++ca) {
                    int64_t row = 3 * (int64_t)fa + ca;
                    w->full_row_idx[pf++] = row;
                    if (row <= j) w->upper_row_idx[pu++] = row;
                }
            }
        }
    return DEFSIM_OK;
}

defsim_status defsim__matrix_pattern(defsim_world *w, defsim_triangle tri, defsim_csc *out)
{
    if (!out || (tri != DEFSIM_TRIANGLE_FULL && tri != DEFSIM_TRIANGLE_UPPER))
        return DEFSIM_ERR_INVALID_ARGUMENT;
    if (!w->adj_ptr) {
        defsim_status st = build_pattern(w);
        if (st != DEFSIM_OK) {
            defsim__world_error(w, "out of memory building the matrix pattern");
            return st;
        }
    }
    out->n = 3 * (int64_t)w->nfree_v;
    if (tri == DEFSIM_TRIANGLE_FULL) {
        out->nnz = w->full_nnz;
        out->col_ptr = w->full_col_ptr;
        out->row_idx = w->full_row_idx;
    } else {
        out->nnz = w->upper_nnz;
        out->col_ptr = w->upper_col_ptr;
        out->row_idx = w->upper_row_idx;
    }
    return DEFSIM_OK;
}

/* Element matrix over its nodes: K[(a c),(b d)], 12x12 for tets, 6x6 for springs, scaled by
 * k + kd beta (kd part always with clamped projection). Returns 0 if the element adds nothing. */
static int element_matrix(const defsim_world *w, const defsim__group *g, const double *x,
                          int32_t e, const defsim_matrix_coeffs *c, double *K)
{
    const double sk = c->k, sd = c->kd * g->beta[e];
    if (sk == 0.0 && sd == 0.0) return 0;
    const int proj = defsim__options_projection(&w->options, w->def.projection);
    const int nn = g->nodes, nd = 3 * nn;
    if (nn == 2) {
        const double *xa = x + 3 * (int64_t)g->idx[2 * (int64_t)e];
        const double *xb = x + 3 * (int64_t)g->idx[2 * (int64_t)e + 1];
        double Kb[9], Kd[9];
        spring_block(xa, xb, g->k[e], g->l0[e], proj, Kb);
        if (sd != 0.0) spring_block(xa, xb, g->k[e], g->l0[e], DEFSIM_PROJECTION_CLAMP, Kd);
        for (int i = 0; i < 9; ++i) Kb[i] = sk * Kb[i] + (sd != 0.0 ? sd * Kd[i] : 0.0);
        for (int a = 0; a < 2; ++a)
            for (int b = 0; b < 2; ++b)
                for (int i = 0; i < 3; ++i)
                    for (int j = 0; j < 3; ++j)
                        K[(3 * a + i) * nd + 3 * b + j] = (a == b ? 1.0 : -1.0) * Kb[3 * i + j];
        return 1;
    }
    double F[9], D[81], gr[4][3];
    tet_deformation(x, g->idx + 4 * (int64_t)e, g->dminv + 9 * (int64_t)e, F);
    if (proj == DEFSIM_PROJECTION_NONE) {
        group_dpdf(g->model, g->mu[e], g->lambda[e], F, D);
        if (sd != 0.0) {
            double Dd[81];
            group_dpdf_projected(g->model, g->mu[e], g->lambda[e], F, DEFSIM_PROJECTION_CLAMP,
                                 Dd, 0, NULL);
            for (int i = 0; i < 81; ++i) D[i] = sk * D[i] + sd * Dd[i];
        } else {
            for (int i = 0; i < 81; ++i) D[i] *= sk;
        }
    } else if (sd != 0.0 && proj != DEFSIM_PROJECTION_CLAMP) {
        double Dd[81];
        group_dpdf_projected(g->model, g->mu[e], g->lambda[e], F, proj, D,
                             DEFSIM_PROJECTION_CLAMP, Dd);
        for (int i = 0; i < 81; ++i) D[i] = sk * D[i] + sd * Dd[i];
    } else {
        group_dpdf_projected(g->model, g->mu[e], g->lambda[e], F, proj, D, 0, NULL);
        for (int i = 0; i < 81; ++i) D[i] *= sk + sd;
    }
    tet_gradients(g->dminv + 9 * (int64_t)e, gr);
    const double vol = g->vol[e];
    /* K[(a,i),(b,k)] = vol sum_{j,l} g_a[j] D[(i,j),(k,l)] g_b[l]. D is symmetric, so K is; and
     * g_3 = -(g_0 + g_1 + g_2) makes node 3's blocks minus sums of the others: only the six
     * blocks a <= b < 3 need the products. */
    for (int b = 0; b < 3; ++b) {
        double Dg[9][3];   /* Dg[(i,j)][k] = sum_l D[(i,j),(k,l)] g_b[l] */
        for (int r = 0; r < 9; ++r)
            for (int k = 0; k < 3; ++k)
                Dg[r][k] = D[9 * r + 3 * k] * gr[b][0] + D[9 * r + 3 * k + 1] * gr[b][1] +
                           D[9 * r + 3 * k + 2] * gr[b][2];
        for (int a = 0; a <= b; ++a)
            for (int i = 0; i < 3; ++i)
                for (int k = 0; k < 3; ++k) {
                    const double v = vol * (gr[a][0] * Dg[3 * i][k] + gr[a][1] * Dg[3 * i + 1][k] +
                                            gr[a][2] * Dg[3 * i + 2][k]);
                    K[(3 * a + i) * nd + 3 * b + k] = v;
                    K[(3 * b + k) * nd + 3 * a + i] = v;
                }
    }
    for (int a = 0; a < 3; ++a)
        for (int i = 0; i < 3; ++i)
            for (int k = 0; k < 3; ++k) {
                const double *row = K + (3 * a + i) * nd;
                const double v = -(row[k] + row[3 + k] + row[6 + k]);
                K[(3 * a + i) * nd + 9 + k] = v;
                K[(9 + k) * nd + 3 * a + i] = v;
            }
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) {
            const double *row = K + (9 + i) * nd;
            K[(9 + i) * nd + 9 + k] = -(row[k] + row[3 + k] + row[6 + k]);
        }
    return 1;
}

defsim_status defsim__matrix_values(defsim_world *w, const double *x,
                                    const defsim_matrix_coeffs *c, defsim_triangle tri,
                                    double *values)
{
    defsim_csc pat;
    defsim_status st = defsim__matrix_pattern(w, tri, &pat);
    if (st != DEFSIM_OK) return st;
    if (!x || !c || !values) return DEFSIM_ERR_INVALID_ARGUMENT;
    double t0 = defsim__now();
    const int upper = tri == DEFSIM_TRIANGLE_UPPER;
    const int64_t *cp = pat.col_ptr;
    memset(values, 0, (size_t)pat.nnz * sizeof *values);
    if (c->k != 0.0 || c->kd != 0.0) {
        for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) {
            const defsim__group *g = &w->groups[m];
            const int nn = g->nodes, nd = 3 * nn;
            for (int32_t col = 0; col < g->ncolors; ++col) {
                const int32_t e0 = g->color_ptr[col], e1 = g->color_ptr[col + 1];
#pragma omp parallel for schedule(static) num_threads(w->nthreads) if (e1 - e0 > 64)
                for (int32_t e = e0; e < e1; ++e) {
                    double K[144];
                    if (!element_matrix(w, g, x, e, c, K)) continue;
                    const int32_t *id = g->idx + (int64_t)nn * e;
                    const int32_t *blk = g->blk + (int64_t)nn * nn * e;
                    for (int b = 0; b < nn; ++b) {
                        int32_t fb = w->vfree[id[b]];
                        if (fb < 0) continue;
                        for (int a = 0; a < nn; ++a) {
                            int32_t r = blk[a * nn + b];
                            if (r < 0) continue;
                            int32_t fa = w->vfree[id[a]];
                            if (upper && fa > fb) continue;
                            for (int cb = 0; cb < 3; ++cb) {
                                int64_t base = cp[3 * (int64_t)fb + cb] + 3 * (int64_t)r;
                                int camax = (upper && fa == fb) ? cb : 2;
                                for (int ca = 0; ca <= camax; ++ca)
                                    values[base + ca] += K[(3 * a + ca) * nd + 3 * b + cb];
                            }
                        }
                    }
                }
            }
            if (g->n > 0) w->step_passes |= DEFSIM_PASS_HESSIAN;
        }
    }
    if (c->m != 0.0 || c->md != 0.0) {
        for (int32_t fv = 0; fv < w->nfree_v; ++fv)
            for (int cc = 0; cc < 3; ++cc) {
                int64_t dof = w->free_dofs[3 * (int64_t)fv + cc];
                int64_t pos = cp[3 * (int64_t)fv + cc] + 3 * (int64_t)w->upper_rank0[fv] + cc;
                values[pos] += (c->m + c->md * w->alpha3[dof]) * w->mass3[dof];
            }
    }
    w->stats.hessian_evals++;
    w->stats.time_hessian += defsim__now() - t0;
    return DEFSIM_OK;
}

/* out += A dx for one element without forming its matrix: for tets dF = sum_a dx_a g_a^T,
 * dP = (k D + kd beta Dclamped) : dF, out_a += vol dP g_a. */
static void element_apply(const defsim__group *g, const double *x, int32_t e,
                          const defsim_matrix_coeffs *c, int proj, const uint8_t *pinned,
                          const double *dx, double *out)
{
    const double sk = c->k, sd = c->kd * g->beta[e];
    if (sk == 0.0 && sd == 0.0) return;
    if (g->nodes == 2) {
        const int32_t a = g->idx[2 * (int64_t)e], b = g->idx[2 * (int64_t)e + 1];
        const double *xa = x + 3 * (int64_t)a, *xb = x + 3 * (int64_t)b;
        double Kb[9], Kd[9], d[3];
        spring_block(xa, xb, g->k[e], g->l0[e], proj, Kb);
        if (sd != 0.0) spring_block(xa, xb, g->k[e], g->l0[e], DEFSIM_PROJECTION_CLAMP, Kd);
        for (int i = 0; i < 3; ++i) {
            double ua = pinned[a] ? 0.0 : dx[3 * (int64_t)a + i];
            double ub = pinned[b] ? 0.0 : dx[3 * (int64_t)b + i];
            d[i] = ua - ub;
        }
        for (int i = 0; i < 3; ++i) {
            double s = 0.0;
            for (int j = 0; j < 3; ++j)
                s += (sk * Kb[3 * i + j] + (sd != 0.0 ? sd * Kd[3 * i + j] : 0.0)) * d[j];
            if (!pinned[a]) out[3 * (int64_t)a + i] += s;
            if (!pinned[b]) out[3 * (int64_t)b + i] -= s;
        }
        return;
    }
    const int32_t *id = g->idx + 4 * (int64_t)e;
    const double *dm = g->dminv + 9 * (int64_t)e;
    double F[9], D[81], dF[9], dP[9], gr[4][3];
    tet_deformation(x, id, dm, F);
    group_dpdf(g->model, g->mu[e], g->lambda[e], F, D);
    if (sd != 0.0 && proj != DEFSIM_PROJECTION_CLAMP) {
        double Dd[81];
        memcpy(Dd, D, sizeof Dd);
        defsim__project_psd(9, Dd, DEFSIM_PROJECTION_CLAMP);
        defsim__project_psd(9, D, proj);
        for (int i = 0; i < 81; ++i) D[i] = sk * D[i] + sd * Dd[i];
    } else {
        defsim__project_psd(9, D, proj);
        for (int i = 0; i < 81; ++i) D[i] *= sk + sd;
    }
    tet_gradients(dm, gr);
    memset(dF, 0, sizeof dF);
    for (int a = 0; a < 4; ++a) {
        if (pinned[id[a]]) continue;
        const double *u = dx + 3 * (int64_t)id[a];
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) dF[3 * i + j] += u[i] * gr[a][j];
    }
    apply_dpdf(D, dF, dP);
    const double vol = g->vol[e];
    for (int a = 0; a < 4; ++a) {
        if (pinned[id[a]]) continue;
        double *o = out + 3 * (int64_t)id[a];
        for (int i = 0; i < 3; ++i)
            o[i] += vol * (dP[3 * i] * gr[a][0] + dP[3 * i + 1] * gr[a][1] + dP[3 * i + 2] * gr[a][2]);
    }
}

static void matrix_apply(defsim_world *w, const double *x, const defsim_matrix_coeffs *c, int proj,
                         const double *dx, double *out)
{
    const int64_t ndof = 3 * (int64_t)w->nv;
    memset(out, 0, (size_t)ndof * sizeof *out);
    if (c->k != 0.0 || c->kd != 0.0) {
        for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) {
            const defsim__group *g = &w->groups[m];
            for (int32_t col = 0; col < g->ncolors; ++col) {
                const int32_t e0 = g->color_ptr[col], e1 = g->color_ptr[col + 1];
#pragma omp parallel for schedule(static) num_threads(w->nthreads) if (e1 - e0 > 256)
                for (int32_t e = e0; e < e1; ++e) element_apply(g, x, e, c, proj, w->pinned, dx, out);
            }
        }
    }
    if (c->m != 0.0 || c->md != 0.0)
        for (int64_t i = 0; i < ndof; ++i)
            if (!w->pinned[i / 3]) out[i] += (c->m + c->md * w->alpha3[i]) * w->mass3[i] * dx[i];
}

defsim_status defsim__matrix_product(defsim_world *w, const double *x,
                                     const defsim_matrix_coeffs *c, const double *dx,
                                     double *out)
{
    if (!x || !c || !dx || !out) return DEFSIM_ERR_INVALID_ARGUMENT;
    matrix_apply(w, x, c, defsim__options_projection(&w->options, w->def.projection), dx, out);
    return DEFSIM_OK;
}

/* Largest eigenvalue of M^-1/2 K(x) M^-1/2 over the free DOFs (exact Hessians) by power
 * iteration from a fixed start, to 1e-4 relative in the Rayleigh quotient. If the dominant
 * eigenvalue is negative (a strongly compressed, unstable configuration), the iteration is
 * repeated with that shift to find the largest positive one. */
defsim_status defsim__omega_max(defsim_world *w, const double *x, double *omega)
{
    const int64_t ndof = 3 * (int64_t)w->nv;
    double *z = malloc((size_t)(ndof > 0 ? ndof : 1) * sizeof *z);
    double *y = malloc((size_t)(ndof > 0 ? ndof : 1) * sizeof *y);
    double *u = malloc((size_t)(ndof > 0 ? ndof : 1) * sizeof *u);
    if (!z || !y || !u) { free(z); free(y); free(u); return DEFSIM_ERR_OUT_OF_MEMORY; }
    const defsim_matrix_coeffs ck = {1.0, 0.0, 0.0, 0.0};
    double shift = 0.0, lambda = 0.0;
    for (int pass = 0; pass < 2; ++pass) {
        unsigned long long seed = 0x9E3779B97F4A7C15ULL;
        double nrm = 0.0;
        for (int64_t i = 0; i < ndof; ++i) {
            seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
            z[i] = w->pinned[i / 3] ? 0.0 : (double)(seed >> 11) / 9007199254740992.0 + 0.5;
            nrm += z[i] * z[i];
        }
        if (!(nrm > 0.0)) break;
        for (int64_t i = 0; i < ndof; ++i) z[i] /= sqrt(nrm);
        double prev = 0.0;
        for (int it = 0; it < 300; ++it) {
            for (int64_t i = 0; i < ndof; ++i) u[i] = z[i] / sqrt(w->mass3[i]);
            matrix_apply(w, x, &ck, DEFSIM_PROJECTION_NONE, u, y);
            double q = 0.0, yn = 0.0;
            for (int64_t i = 0; i < ndof; ++i) {
                y[i] = y[i] / sqrt(w->mass3[i]) + shift * z[i];
                q += z[i] * y[i];
                yn += y[i] * y[i];
            }
            lambda = q;
            if (!(yn > 0.0)) break;
            for (int64_t i = 0; i < ndof; ++i) z[i] = y[i] / sqrt(yn);
            if (it > 5 && fabs(lambda - prev) <= 1e-4 * fabs(lambda)) break;
            prev = lambda;
        }
        lambda -= shift;
        if (lambda >= 0.0 || pass == 1) break;
        shift = -lambda;   /* dominant eigenvalue negative: shift the spectrum up */
    }
    free(z); free(y); free(u);
    *omega = lambda > 0.0 ? sqrt(lambda) : 0.0;
    return isfinite(*omega) ? DEFSIM_OK : DEFSIM_ERR_UNSTABLE;
}

/* ------------------------------------------------------------------------------------------ */
/* Planning: compile the bodies into coloured element groups. */

static void group_free(defsim__group *g)
{
    free(g->idx); free(g->dminv); free(g->vol); free(g->mu); free(g->lambda);
    free(g->k); free(g->l0); free(g->beta); free(g->color_ptr); free(g->blk);
    free(g->bcolor_ptr); free(g->bidx); free(g->bdata); free(g->blanes);
    memset(g, 0, sizeof *g);
}

void defsim__unplan(defsim_world *w)
{
    for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) group_free(&w->groups[m]);
    free(w->free_dofs); free(w->dof_to_free); free(w->vfree);
    free(w->adj_ptr); free(w->adj); free(w->upper_rank0);
    free(w->full_col_ptr); free(w->full_row_idx); free(w->upper_col_ptr); free(w->upper_row_idx);
    free(w->x_save); free(w->v_save); free(w->ftmp); free(w->partial);
    free(w->mass3); free(w->alpha3);
    w->free_dofs = w->dof_to_free = NULL;
    w->vfree = NULL;
    w->adj_ptr = NULL; w->adj = NULL; w->upper_rank0 = NULL;
    w->full_col_ptr = w->full_row_idx = w->upper_col_ptr = w->upper_row_idx = NULL;
    w->x_save = w->v_save = w->ftmp = w->partial = NULL;
    w->mass3 = w->alpha3 = NULL;
    w->planned = 0;
}

/* Greedy colouring in windows of 64 colours: an element takes the lowest colour of the window
 * that none of its vertices has; elements that find none wait for the next window. Then the
 * element arrays are permuted so that each colour is contiguous (stable within a colour). */
static defsim_status color_group(defsim__group *g, int32_t nv)
{
    const int nn = g->nodes;
    int32_t *color = malloc((size_t)(g->n > 0 ? g->n : 1) * sizeof *color);
    uint64_t *mask = malloc((size_t)(nv > 0 ? nv : 1) * sizeof *mask);
    if (!color || !mask) { free(color); free(mask); return DEFSIM_ERR_OUT_OF_MEMORY; }
    for (int32_t e = 0; e < g->n; ++e) color[e] = -1;
    int32_t left = g->n, base = 0;
    while (left > 0) {
        memset(mask, 0, (size_t)nv * sizeof *mask);
        for (int32_t e = 0; e < g->n; ++e) {
            if (color[e] >= 0) continue;
            uint64_t used = 0;
            for (int a = 0; a < nn; ++a) used |= mask[g->idx[(int64_t)nn * e + a]];
            if (used == ~(uint64_t)0) continue;
            int c = __builtin_ctzll(~used);
            for (int a = 0; a < nn; ++a) mask[g->idx[(int64_t)nn * e + a]] |= (uint64_t)1 << c;
            color[e] = base + c;
            --left;
        }
        base += 64;
    }
    free(mask);
    int32_t ncol = 0;
    for (int32_t e = 0; e < g->n; ++e) if (color[e] + 1 > ncol) ncol = color[e] + 1;
    g->ncolors = ncol;
    g->color_ptr = calloc((size_t)ncol + 1, sizeof *g->color_ptr);
    int32_t *perm = malloc((size_t)(g->n > 0 ? g->n : 1) * sizeof *perm);
    if (!g->color_ptr || !perm) { free(color); free(perm); return DEFSIM_ERR_OUT_OF_MEMORY; }
    for (int32_t e = 0; e < g->n; ++e) g->color_ptr[color[e] + 1]++;
    for (int32_t c = 0; c < ncol; ++c) g->color_ptr[c + 1] += g->color_ptr[c];
    {
        int32_t *fill = malloc(((size_t)ncol + 1) * sizeof *fill);
        if (!fill) { free(color); free(perm); return DEFSIM_ERR_OUT_OF_MEMORY; }
        memcpy(fill, g->color_ptr, ((size_t)ncol + 1) * sizeof *fill);
        for (int32_t e = 0; e < g->n; ++e) perm[fill[color[e]]++] = e;
        free(fill);
    }
    free(color);
    /* Apply the permutation to every per-element array. */
#define PERMUTE(arr, width, type)                                                              \
    if (g->arr) {                                                                              \
        type *na = malloc((size_t)g->n * (width) * sizeof *na);                                \
        if (!na) { free(perm); return DEFSIM_ERR_OUT_OF_MEMORY; }                              \
        for (int32_t e = 0; e < g->n; ++e)                                                     \
            memcpy(na + (int64_t)(width) * e, g->arr + (int64_t)(width) * perm[e], (width) * sizeof *na); \
        free(g->arr);                                                                          \
        g->arr = na;                                                                           \
    }
    PERMUTE(idx, nn, int32_t)
    PERMUTE(dminv, 9, double)
    PERMUTE(vol, 1, double)
    PERMUTE(mu, 1, double)
    PERMUTE(lambda, 1, double)
    PERMUTE(k, 1, double)
    PERMUTE(l0, 1, double)
    PERMUTE(beta, 1, double)
#undef PERMUTE
    free(perm);
    return DEFSIM_OK;
}

/* Cuts each colour of a tet group into batches of DEFSIM__BATCH elements in the SIMD layout
 * (tet_forces.h). A colour's last batch is padded with copies of its first element: they are
 * computed with valid data but never scattered. */
static defsim_status pack_batches(defsim__group *g)
{
    const int B = DEFSIM__BATCH, rows = DEFSIM__BATCH_ROWS;
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
    g->bidx = malloc(nbs * 4 * B * sizeof *g->bidx);
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
                double *d = g->bdata + (int64_t)rows * B * b + l;
                for (int a = 0; a < 4; ++a) g->bidx[(4 * (int64_t)b + a) * B + l] = g->idx[4 * e + a];
                for (int r = 0; r < 9; ++r) d[(DEFSIM__ROW_DMINV + r) * B] = g->dminv[9 * e + r];
                d[DEFSIM__ROW_NVOL * B] = -g->vol[e];
                if (g->model == DEFSIM_MODEL_STABLE_NEOHOOKEAN) {
                    defsim__snh_params(g->mu[e], g->lambda[e], &d[DEFSIM__ROW_P0 * B],
                                       &d[DEFSIM__ROW_P1 * B], &d[DEFSIM__ROW_P2 * B]);
                } else {
                    d[DEFSIM__ROW_P0 * B] = g->mu[e];
                    d[DEFSIM__ROW_P1 * B] = g->lambda[e];
                    d[DEFSIM__ROW_P2 * B] = 0.0;
                }
            }
        }
    return DEFSIM_OK;
}

static const int tet_models[DEFSIM__TET_MODELS] = {
    DEFSIM_MODEL_STVK, DEFSIM_MODEL_COROTATED, DEFSIM_MODEL_NEOHOOKEAN,
    DEFSIM_MODEL_STABLE_NEOHOOKEAN};
static const uint32_t tet_passes[DEFSIM__TET_MODELS] = {
    DEFSIM_PASS_STVK, DEFSIM_PASS_COROTATED, DEFSIM_PASS_NEOHOOKEAN,
    DEFSIM_PASS_STABLE_NEOHOOKEAN};

static defsim_status plan_groups(defsim_world *w)
{
    int32_t count[DEFSIM__TET_MODELS + 1] = {0};
    for (int32_t b = 0; b < w->nbodies; ++b) {
        const defsim__body *bd = &w->bodies[b];
        if (!(bd->generation & 1u)) continue;
        if (bd->nt > 0) count[bd->mat.model - DEFSIM_MODEL_STVK] += bd->nt;
        count[DEFSIM__TET_MODELS] += bd->ns;
    }
    for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) {
        defsim__group *g = &w->groups[m];
        const size_t n = (size_t)(count[m] > 0 ? count[m] : 1);
        g->n = count[m];
        g->nodes = m < DEFSIM__TET_MODELS ? 4 : 2;
        g->model = m < DEFSIM__TET_MODELS ? tet_models[m] : DEFSIM_MODEL_SPRING;
        g->pass = m < DEFSIM__TET_MODELS ? tet_passes[m] : DEFSIM_PASS_SPRINGS;
        g->idx = malloc(n * g->nodes * sizeof *g->idx);
        g->beta = malloc(n * sizeof *g->beta);
        if (!g->idx || !g->beta) return DEFSIM_ERR_OUT_OF_MEMORY;
        if (m < DEFSIM__TET_MODELS) {
            g->dminv = malloc(9 * n * sizeof *g->dminv);
            g->vol = malloc(n * sizeof *g->vol);
            g->mu = malloc(n * sizeof *g->mu);
            g->lambda = malloc(n * sizeof *g->lambda);
            if (!g->dminv || !g->vol || !g->mu || !g->lambda) return DEFSIM_ERR_OUT_OF_MEMORY;
        } else {
            g->k = malloc(n * sizeof *g->k);
            g->l0 = malloc(n * sizeof *g->l0);
            if (!g->k || !g->l0) return DEFSIM_ERR_OUT_OF_MEMORY;
        }
        g->n = 0;
    }
    for (int32_t b = 0; b < w->nbodies; ++b) {
        const defsim__body *bd = &w->bodies[b];
        if (!(bd->generation & 1u)) continue;
        const double beta = bd->mat.stiffness_damping;
        if (bd->nt > 0) {
            defsim__group *g = &w->groups[bd->mat.model - DEFSIM_MODEL_STVK];
            for (int32_t t = 0; t < bd->nt; ++t) {
                const int32_t *lt = bd->tets + 4 * (int64_t)t;
                const int32_t e = g->n++;
                double dm[9];
                const double *p3 = bd->rest + 3 * (int64_t)lt[3];
                for (int a = 0; a < 3; ++a)
                    for (int i = 0; i < 3; ++i)
                        dm[3 * i + a] = bd->rest[3 * (int64_t)lt[a] + i] - p3[i];
                double det = defsim__m3_inverse(dm, g->dminv + 9 * (int64_t)e);
                g->vol[e] = fabs(det) / 6.0;
                g->mu[e] = bd->mu;
                g->lambda[e] = bd->lambda;
                g->beta[e] = beta;
                for (int a = 0; a < 4; ++a) g->idx[4 * (int64_t)e + a] = bd->offset + lt[a];
            }
        }
        defsim__group *sg = &w->groups[DEFSIM__TET_MODELS];
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
    for (int m = 0; m <= DEFSIM__TET_MODELS; ++m) {
        defsim_status st = color_group(&w->groups[m], w->nv);
        if (st == DEFSIM_OK && m < DEFSIM__TET_MODELS) st = pack_batches(&w->groups[m]);
        if (st != DEFSIM_OK) return st;
    }
    w->tet_kernels = defsim__options_tet_kernels(&w->options);
    return DEFSIM_OK;
}

defsim_status defsim__plan(defsim_world *w)
{
    if (w->planned) return DEFSIM_OK;
    defsim__unplan(w);
    const int64_t ndof = 3 * (int64_t)w->nv;
    const size_t nd = (size_t)(ndof > 0 ? ndof : 1);
    defsim_status st = plan_groups(w);
    if (st != DEFSIM_OK) goto fail;
    st = DEFSIM_ERR_OUT_OF_MEMORY;
    w->mass3 = malloc(nd * sizeof *w->mass3);
    w->alpha3 = malloc(nd * sizeof *w->alpha3);
    w->free_dofs = malloc(nd * sizeof *w->free_dofs);
    w->dof_to_free = malloc(nd * sizeof *w->dof_to_free);
    w->vfree = malloc((size_t)(w->nv > 0 ? w->nv : 1) * sizeof *w->vfree);
    w->x_save = malloc(nd * sizeof *w->x_save);
    w->v_save = malloc(nd * sizeof *w->v_save);
    w->ftmp = malloc(nd * sizeof *w->ftmp);
    int32_t maxn = 1;
    for (int m = 0; m <= DEFSIM__TET_MODELS; ++m)
        if (w->groups[m].n > maxn) maxn = w->groups[m].n;
    w->npartial = (maxn + REDUCE_BLOCK - 1) / REDUCE_BLOCK;
    w->partial = malloc((size_t)w->npartial * sizeof *w->partial);
    if (!w->mass3 || !w->alpha3 || !w->free_dofs || !w->dof_to_free || !w->vfree ||
        !w->x_save || !w->v_save || !w->ftmp || !w->partial)
        goto fail;

    /* Per-DOF data, free maps and which passes the scene needs. */
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    w->has_mass_damping = w->has_stiffness_damping = w->has_pins = 0;
    for (int32_t b = 0; b < w->nbodies; ++b) {
        const defsim__body *bd = &w->bodies[b];
        if (!(bd->generation & 1u)) continue;
        if (bd->mat.stiffness_damping > 0.0 && (bd->nt > 0 || bd->ns > 0))
            w->has_stiffness_damping = 1;
        for (int32_t i = 0; i < bd->nv; ++i) {
            const int64_t v = bd->offset + i;
            for (int c = 0; c < 3; ++c) {
                w->mass3[3 * v + c] = bd->mass[i];
                w->alpha3[3 * v + c] = bd->mat.mass_damping;
                double p = bd->rest[3 * (int64_t)i + c];
                if (p < lo[c]) lo[c] = p;
                if (p > hi[c]) hi[c] = p;
            }
            if (bd->mat.mass_damping > 0.0 && !w->pinned[v]) w->has_mass_damping = 1;
        }
    }
    w->nfree_v = 0;
    w->nfree = 0;
    for (int32_t v = 0; v < w->nv; ++v) {
        if (w->pinned[v]) {
            w->has_pins = 1;
            w->vfree[v] = -1;
            for (int c = 0; c < 3; ++c) w->dof_to_free[3 * (int64_t)v + c] = -1;
            continue;
        }
        w->vfree[v] = w->nfree_v++;
        for (int c = 0; c < 3; ++c) {
            w->dof_to_free[3 * (int64_t)v + c] = w->nfree;
            w->free_dofs[w->nfree++] = 3 * (int64_t)v + c;
        }
    }
    const double *g = w->def.gravity;
    w->has_gravity = (g[0] != 0.0 || g[1] != 0.0 || g[2] != 0.0) && w->nv > 0;
    double diag = 0.0;
    if (w->nv > 0)
        diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                    (hi[2] - lo[2]) * (hi[2] - lo[2]));
    w->length_scale = diag > 0.0 ? diag : 1.0;
    w->planned = 1;
    return DEFSIM_OK;
fail:
    defsim__unplan(w);
    return st;
}

/* SPDX-License-Identifier: MIT */
#include "be_reference.h"

#include "test_util.h"
#include "assembly.h"
#include "forces.h"
#include "world.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct ref_ctx {
    defsim_world *w;
    const double *xn, *vn;
    double h;
    int64_t n, ndof;
    int64_t *free;            /* free DOF indices */
    double *x, *dx, *fe, *fd; /* full DOF arrays */
} ref_ctx;

/* G over the free DOFs at free positions u. */
static void residual(ref_ctx *c, const double *u, double *g)
{
    defsim_world *w = c->w;
    for (int64_t i = 0; i < c->n; ++i) {
        const int64_t d = c->free[i];
        c->x[d] = u[i];
        c->dx[d] = u[i] - c->xn[d];
    }
    /* Damping (alpha M + beta K(x_n)) (x - x_n) / h with the core's matrices at x_n. */
    const defsim_matrix_coeffs damp = {0.0, 1.0 / c->h, 0.0, 1.0 / c->h};
    (void)defsim__forces(&w->sys, c->x, NULL, DEFSIM_FORCE_ELASTIC, c->fe, NULL);
    TU_OK(defsim__matrix_product(&w->sys, c->xn, &damp, c->dx, c->fd));
    for (int64_t i = 0; i < c->n; ++i) {
        const int64_t d = c->free[i];
        const double m = w->sys.mass3[d];
        g[i] = m * (u[i] - c->xn[d] - c->h * c->vn[d]) / (c->h * c->h) - c->fe[d] -
               m * w->def.gravity[d % 3] + c->fd[d];
    }
}

/* Solves A z = b in place (A n x n row-major, destroyed), partial pivoting. */
static void dense_solve(double *A, double *b, int64_t n)
{
    for (int64_t k = 0; k < n; ++k) {
        int64_t p = k;
        for (int64_t i = k + 1; i < n; ++i)
            if (fabs(A[i * n + k]) > fabs(A[p * n + k])) p = i;
        assert_true(A[p * n + k] != 0.0);
        if (p != k) {
            for (int64_t j = 0; j < n; ++j) {
                double t = A[k * n + j]; A[k * n + j] = A[p * n + j]; A[p * n + j] = t;
            }
            double t = b[k]; b[k] = b[p]; b[p] = t;
        }
        for (int64_t i = k + 1; i < n; ++i) {
            const double l = A[i * n + k] / A[k * n + k];
            if (l == 0.0) continue;
            for (int64_t j = k; j < n; ++j) A[i * n + j] -= l * A[k * n + j];
            b[i] -= l * b[k];
        }
    }
    for (int64_t k = n - 1; k >= 0; --k) {
        double s = b[k];
        for (int64_t j = k + 1; j < n; ++j) s -= A[k * n + j] * b[j];
        b[k] = s / A[k * n + k];
    }
}

int be_reference_step(defsim_world *w, const double *xn, const double *vn, double h, double *x1,
                      double *v1)
{
    TU_OK(defsim__world_plan(w));
    ref_ctx c = {.w = w, .xn = xn, .vn = vn, .h = h, .ndof = 3 * (int64_t)w->nv};
    const size_t nd = (size_t)c.ndof;
    c.free = malloc(nd * sizeof *c.free);
    c.x = malloc(nd * sizeof *c.x);
    c.dx = calloc(nd, sizeof *c.dx);
    c.fe = malloc(nd * sizeof *c.fe);
    c.fd = malloc(nd * sizeof *c.fd);
    for (int64_t d = 0; d < c.ndof; ++d)
        if (!w->bodies.pinned[d / 3]) c.free[c.n++] = d;
    memcpy(c.x, xn, nd * sizeof *c.x);
    const int64_t n = c.n;
    double *u = malloc((size_t)n * sizeof *u), *g = malloc((size_t)n * sizeof *g);
    double *gp = malloc((size_t)n * sizeof *gp), *gm = malloc((size_t)n * sizeof *gm);
    double *J = malloc((size_t)(n * n) * sizeof *J);
    const double L = w->sys.length_scale, eps = 1e-6 * L;
    for (int64_t i = 0; i < n; ++i) {
        const int64_t d = c.free[i];
        u[i] = xn[d] + h * vn[d] + h * h * w->def.gravity[d % 3];
    }
    int it = 0, done = 0;
    while (!done) {
        assert_true(++it <= 60);
        residual(&c, u, g);
        for (int64_t j = 0; j < n; ++j) {
            const double uj = u[j];
            u[j] = uj + eps;
            residual(&c, u, gp);
            u[j] = uj - eps;
            residual(&c, u, gm);
            u[j] = uj;
            for (int64_t i = 0; i < n; ++i) J[i * n + j] = (gp[i] - gm[i]) / (2 * eps);
        }
        for (int64_t i = 0; i < n; ++i) g[i] = -g[i];
        dense_solve(J, g, n);
        double step = 0.0;
        for (int64_t i = 0; i < n; ++i) {
            u[i] += g[i];
            step = fmax(step, fabs(g[i]));
        }
        /* Converged once a Newton step changes nothing beyond roundoff of the coordinates. */
        done = it >= 2 && step <= 1e-14 * L;
    }
    memcpy(x1, xn, nd * sizeof *x1);
    for (int64_t d = 0; d < c.ndof; ++d) v1[d] = 0.0;
    for (int64_t i = 0; i < n; ++i) {
        const int64_t d = c.free[i];
        x1[d] = u[i];
        v1[d] = (u[i] - xn[d]) / h;
    }
    free(u); free(g); free(gp); free(gm); free(J);
    free(c.free); free(c.x); free(c.dx); free(c.fe); free(c.fd);
    return it;
}

defsim_world *be_cantilever(const char *backend, double tol, int max_iter, defsim_model model,
                           double alpha, double beta, defsim_projection proj, double unit)
{
    defsim_world *w = tu_implicit_world(backend, -9.81 * unit, 1, tol, max_iter, proj);
    defsim_mesh m = {.size = sizeof m};
    const double lo[3] = {0, 0, 0}, hi[3] = {1.5 * unit, 0.5 * unit, 0.5 * unit};
    TU_OK(defsim_mesh_box(lo, hi, 3, 1, 1, &m));
    defsim_body_def bd = test_mesh_body(&m, model);
    /* Pa = kg / (m s^2): in kg, mm, s the modulus is 1e-3 times smaller, the density 1e-9. */
    bd.material.youngs_modulus = 5e4 / unit;
    bd.material.poisson_ratio = 0.35;
    bd.material.density = 1000.0 / (unit * unit * unit);
    bd.material.mass_damping = alpha;
    bd.material.stiffness_damping = beta;
    double *v = calloc(3 * (size_t)m.vertex_count, sizeof *v);
    for (int i = 0; i < m.vertex_count; ++i) v[3 * i + 1] = m.positions[3 * i];   /* 1/s */
    bd.initial_velocities = v;
    defsim_body_id b;
    TU_OK(defsim_world_add_body(w, &bd, &b));
    tu_pin_below(w, b, 0, 0.0);
    free(v);
    defsim_mesh_free(&m);
    return w;
}

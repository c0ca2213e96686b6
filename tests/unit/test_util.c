/* SPDX-License-Identifier: MIT */
#include "test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

double tu_rand(unsigned long long *s)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*s >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

defsim_world *tu_world(const char *backend, double gy, int threads)
{
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    d.backend = backend;
    d.gravity[1] = gy;
    d.num_threads = threads;
    defsim_world *w = NULL;
    defsim_status st = defsim_world_create(&d, &w);
    if (st != DEFSIM_OK) fail_msg("world_create(%s): %s", backend, defsim_last_error());
    return w;
}

defsim_body_id tu_add_spring_pair(defsim_world *w, const double rest[6], const double x0[6],
                                  const double *v0, double m0, double m, double k, double alpha,
                                  double beta, int pin)
{
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_SPRING);
    bd.vertex_count = 2;
    bd.rest_positions = rest;
    bd.initial_positions = x0;
    bd.initial_velocities = v0;
    const double mass[2] = {m0, m};
    bd.vertex_mass = mass;
    const int32_t s[2] = {0, 1};
    bd.springs = s;
    bd.spring_count = 1;
    bd.material.stiffness = k;
    bd.material.mass_damping = alpha;
    bd.material.stiffness_damping = beta;
    defsim_body_id id;
    TU_OK(defsim_world_add_body(w, &bd, &id));
    if (pin) {
        const int32_t anchor = 0;
        TU_OK(defsim_body_pin(w, id, &anchor, 1));
    }
    return id;
}

defsim_world *tu_oscillator(const char *backend, double m0, double m, double k, double alpha,
                            double beta, double a, int pin, int auto_substep)
{
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    d.backend = backend;
    d.gravity[1] = 0.0;
    d.num_threads = 1;
    d.auto_substep = auto_substep;
    defsim_world *w = NULL;
    if (defsim_world_create(&d, &w) != DEFSIM_OK)
        fail_msg("world_create(%s): %s", backend, defsim_last_error());
    const double rest[6] = {0, 0, 0, 1, 0, 0}, x0[6] = {0, 0, 0, 1 + a, 0, 0};
    tu_add_spring_pair(w, rest, x0, NULL, m0, m, k, alpha, beta, pin);
    return w;
}

double tu_energy_run(defsim_world *w, double h, int steps, double *max_dev)
{
    defsim_energy e0, e;
    TU_OK(defsim_world_energy(w, &e0));
    e = e0;
    double dev = 0.0;
    for (int i = 0; i < steps; ++i) {
        TU_OK(defsim_world_step(w, h));
        TU_OK(defsim_world_energy(w, &e));
        dev = fmax(dev, fabs(e.total - e0.total) / fabs(e0.total));
    }
    if (max_dev) *max_dev = dev;
    return e.total / e0.total;
}

defsim_body_id tu_add_box_material(defsim_world *w, int nx, int ny, int nz, const double lo[3],
                                   const double hi[3], const defsim_material *mat)
{
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_box(lo, hi, nx, ny, nz, &m));
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    bd.rest_positions = m.positions;
    bd.vertex_count = m.vertex_count;
    bd.tets = m.tets;
    bd.tet_count = m.tet_count;
    bd.material = *mat;
    defsim_body_id id = {0, 0};
    defsim_status st = defsim_world_add_body(w, &bd, &id);
    if (st != DEFSIM_OK) fail_msg("add_body: %s", defsim_world_last_error(w));
    defsim_mesh_free(&m);
    return id;
}

defsim_body_id tu_add_box(defsim_world *w, defsim_model model, int nx, int ny, int nz,
                          const double lo[3], const double hi[3], double E, double nu, double rho)
{
    defsim_material mat;
    defsim_material_init(&mat, sizeof mat, model);
    mat.youngs_modulus = E;
    mat.poisson_ratio = nu;
    mat.density = rho;
    return tu_add_box_material(w, nx, ny, nz, lo, hi, &mat);
}

int tu_pin_below(defsim_world *w, defsim_body_id b, int axis, double value)
{
    int nv = defsim_body_vertex_count(w, b), off = defsim_body_vertex_offset(w, b);
    int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w);
    int32_t *ids = malloc((size_t)nv * sizeof *ids);
    int k = 0;
    for (int i = 0; i < nv; ++i)
        if (x[3 * (off + i) + axis] <= value + 1e-12) ids[k++] = i;
    (void)n;
    TU_OK(defsim_body_pin(w, b, ids, k));
    free(ids);
    free(x);
    return k;
}

double *tu_positions(const defsim_world *w)
{
    int n = defsim_world_vertex_count(w);
    double *x = malloc(3 * (size_t)(n > 0 ? n : 1) * sizeof *x);
    TU_OK(defsim_world_get_positions(w, x, n));
    return x;
}

double *tu_velocities(const defsim_world *w)
{
    int n = defsim_world_vertex_count(w);
    double *v = malloc(3 * (size_t)(n > 0 ? n : 1) * sizeof *v);
    TU_OK(defsim_world_get_velocities(w, v, n));
    return v;
}

double tu_rel_diff(const double *a, const double *b, int n, double floor)
{
    double d = 0.0, s = floor;
    for (int i = 0; i < n; ++i) {
        if (fabs(a[i] - b[i]) > d) d = fabs(a[i] - b[i]);
        if (fabs(b[i]) > s) s = fabs(b[i]);
    }
    return d / s;
}

char tu_tmpdir[256];

int tu_tmpdir_setup(void **state)
{
    (void)state;
    snprintf(tu_tmpdir, sizeof tu_tmpdir, "/tmp/defsim_test_XXXXXX");
    return mkdtemp(tu_tmpdir) ? 0 : -1;
}

int tu_tmpdir_teardown(void **state)
{
    (void)state;
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tu_tmpdir);
    return system(cmd) == 0 ? 0 : -1;
}

const char *tu_write_file(const char *name, const char *text)
{
    static char paths[8][300];
    static int slot;
    char *p = paths[slot++ % 8];
    snprintf(p, sizeof paths[0], "%s/%s", tu_tmpdir, name);
    FILE *f = fopen(p, "wb");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
    return p;
}

defsim_body_id tu_add_oscillator(defsim_world *w, tu_osc *o, double z)
{
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_SPRING);
    double rest[6] = {0, 0, z, 1, 0, z}, x0[6] = {0, 0, z, 1 + o->u0, 0, z};
    double v0[6] = {0, 0, 0, o->v0, 0, 0}, mass[2] = {1.0, o->m};
    int32_t s[2] = {0, 1};
    bd.rest_positions = rest;
    bd.initial_positions = x0;
    bd.initial_velocities = v0;
    bd.vertex_count = 2;
    bd.springs = s;
    bd.spring_count = 1;
    bd.vertex_mass = mass;
    bd.material.stiffness = o->k;
    bd.material.mass_damping = o->alpha;
    bd.material.stiffness_damping = o->beta;
    defsim_body_id id;
    TU_OK(defsim_world_add_body(w, &bd, &id));
    int32_t pin = 0;
    TU_OK(defsim_body_pin(w, id, &pin, 1));
    o->vertex = defsim_body_vertex_offset(w, id) + 1;
    return id;
}

void tu_osc_exact(const tu_osc *o, double t, double *u, double *v)
{
    const double c = o->alpha + o->beta * o->k / o->m, w0 = sqrt(o->k / o->m);
    const double g = 0.5 * c, wd = sqrt(w0 * w0 - g * g);
    const double A = o->u0, B = (o->v0 + g * o->u0) / wd;
    const double e = exp(-g * t), cs = cos(wd * t), sn = sin(wd * t);
    *u = e * (A * cs + B * sn);
    *v = e * (-g * (A * cs + B * sn) + wd * (B * cs - A * sn));
}

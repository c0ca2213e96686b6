/* SPDX-License-Identifier: MIT */
#include "test_util.h"

#include "built_backends.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

double tu_rand(unsigned long long *s)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*s >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

defsim_world_def tu_world_def(const char *backend, double gy, int threads)
{
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    d.backend = backend;
    d.gravity[1] = gy;
    d.num_threads = threads;
    return d;
}

defsim_world *tu_create(const defsim_world_def *d)
{
    defsim_world *w = NULL;
    if (defsim_world_create(d, &w) != DEFSIM_OK)
        fail_msg("world_create(%s): %s", d->backend, defsim_last_error());
    return w;
}

defsim_world *tu_world(const char *backend, double gy, int threads)
{
    const defsim_world_def d = tu_world_def(backend, gy, threads);
    return tu_create(&d);
}

double tu_stat(const defsim_world *w, const char *name)
{
    double v = 0.0;
    if (defsim_world_stat(w, name, &v) != DEFSIM_OK)
        fail_msg("stat %s: %s", name, defsim_world_last_error(w));
    return v;
}

double tu_bstat(const defsim_world *w, const char *leaf)
{
    const size_t n = strlen(leaf);
    for (int32_t i = 0; i < defsim_world_stat_count(w); ++i) {
        const char *name;
        double v;
        TU_OK(defsim_world_stat_info(w, i, &name, &v));
        const char *dot = strchr(name, '.');
        if (dot && !strcmp(dot + 1, leaf) && strlen(dot + 1) == n) return v;
    }
    return 0.0;
}

int tu_backend_option(defsim_world *w, const char *backend, const char *leaf, double value)
{
    char name[160];
    snprintf(name, sizeof name, "%s.%s", backend, leaf);
    double now;
    if (defsim_world_get_option(w, name, &now) != DEFSIM_OK) return 0;
    if (defsim_world_set_option_number(w, name, value) != DEFSIM_OK)
        fail_msg("%s = %g: %s", name, value, defsim_world_last_error(w));
    return 1;
}

defsim_world *tu_implicit_world(const char *backend, double gy, int threads, double tol,
                                int max_iter, defsim_projection proj)
{
    defsim_world *w = tu_world(backend, gy, threads);
    tu_backend_option(w, backend, "tolerance", tol);
    tu_backend_option(w, backend, "max_iterations", max_iter);
    tu_backend_option(w, backend, "projection", proj);
    return w;
}

void tu_ladder(double x0, double cell, double z1, double x[24], int32_t springs[20])
{
    for (int i = 0; i < 4; ++i) {
        x[6 * i] = x0 + cell * i; x[6 * i + 1] = 0.0; x[6 * i + 2] = 0.0;
        x[6 * i + 3] = x0 + cell * i; x[6 * i + 4] = cell; x[6 * i + 5] = z1;
    }
    int k = 0;
    for (int i = 0; i < 4; ++i) { springs[k++] = 2 * i; springs[k++] = 2 * i + 1; }
    for (int i = 0; i < 3; ++i) { springs[k++] = 2 * i; springs[k++] = 2 * i + 2; }
    for (int i = 0; i < 3; ++i) { springs[k++] = 2 * i; springs[k++] = 2 * i + 3; }
}

defsim_world *tu_oscillator(const char *backend, double m0, double m, double k, double alpha,
                            double beta, double a, int pin, int auto_substep)
{
    defsim_world *w = tu_world(backend, 0.0, 1);
    if (auto_substep) TU_OK(defsim_world_set_option(w, "core.auto_substep", "true"));
    const tu_spring2 o = {.l0 = 1, .x1 = {1 + a, 0, 0}, .m0 = m0, .m1 = m, .k = k,
                          .alpha = alpha, .beta = beta, .pin_anchor = pin};
    tu_add_spring2(w, &o);
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
    defsim_body_def bd = test_mesh_body(&m, mat->model);
    bd.material = *mat;
    defsim_body_id id = {0, 0};
    defsim_status st = defsim_world_add_body(w, &bd, &id);
    if (st != DEFSIM_OK) fail_msg("add_body: %s", defsim_world_last_error(w));
    defsim_mesh_free(&m);
    return id;
}

defsim_body_id tu_add_spring2(defsim_world *w, const tu_spring2 *o)
{
    const double *a = o->anchor;
    double rest[6] = {a[0], a[1], a[2], a[0] + o->l0, a[1], a[2]};
    double x0[6] = {a[0], a[1], a[2], o->x1[0], o->x1[1], o->x1[2]};
    double v0[6] = {0, 0, 0, o->v1[0], o->v1[1], o->v1[2]}, mass[2] = {o->m0, o->m1};
    const int32_t link[2] = {0, 1};
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_SPRING);
    bd.rest_positions = rest;
    bd.initial_positions = x0;
    bd.initial_velocities = v0;
    bd.vertex_count = 2;
    bd.springs = link;
    bd.spring_count = 1;
    bd.vertex_mass = mass;
    bd.material.stiffness = o->k;
    bd.material.mass_damping = o->alpha;
    bd.material.stiffness_damping = o->beta;
    defsim_body_id id;
    TU_OK(defsim_world_add_body(w, &bd, &id));
    const int32_t pin = 0;
    if (o->pin_anchor) TU_OK(defsim_body_pin(w, id, &pin, 1));
    return id;
}

void tu_check_free_fall(defsim_world *w, const char *what, double gy, unsigned long long seed,
                        int steps, double h, double tol)
{
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    tu_add_box(w, DEFSIM_MODEL_COROTATED, 2, 2, 2, lo, hi, 1e5, 0.3, 1000);
    const int n = defsim_world_vertex_count(w);
    double *x = tu_positions(w), *v = tu_velocities(w), *m = malloc((size_t)n * sizeof *m);
    for (int i = 0; i < 3 * n; ++i) { x[i] += 0.05 * tu_rand(&seed); v[i] = 0.5 * tu_rand(&seed); }
    TU_OK(defsim_world_set_state(w, x, v));
    TU_OK(defsim_world_get_masses(w, m, n));
    double p0[3] = {0, 0, 0}, M = 0;
    for (int i = 0; i < n; ++i) {
        M += m[i];
        for (int c = 0; c < 3; ++c) p0[c] += m[i] * v[3 * i + c];
    }
    for (int s = 0; s < steps; ++s) TU_OK(defsim_world_step(w, h));
    free(v);
    v = tu_velocities(w);
    double p[3] = {0, 0, 0};
    for (int i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) p[c] += m[i] * v[3 * i + c];
    const double t = defsim_world_time(w);
    printf("%s free body: momentum drift %.2e %.2e %.2e (kg m/s, M = %g kg)\n", what,
           p[0] - p0[0], p[1] - (p0[1] + gy * M * t), p[2] - p0[2], M);
    assert_true(fabs(p[0] - p0[0]) < tol * M);
    assert_true(fabs(p[2] - p0[2]) < tol * M);
    assert_true(fabs(p[1] - (p0[1] + gy * M * t)) < tol * M);
    free(x); free(v); free(m);
}

double tu_check_clamped_end(defsim_world *w, int steps, double h, int npinned)
{
    const int n = defsim_world_vertex_count(w);
    double *x0 = tu_positions(w);
    for (int s = 0; s < steps; ++s) TU_OK(defsim_world_step(w, h));
    double *x = tu_positions(w), *v = tu_velocities(w);
    int pinned = 0;
    for (int i = 0; i < n; ++i) {
        for (int c = 0; c < 3; ++c) {
            assert_true(isfinite(x[3 * i + c]) && isfinite(v[3 * i + c]));
            if (x0[3 * i] <= 1e-12) {
                assert_true(x[3 * i + c] == x0[3 * i + c]);
                assert_true(v[3 * i + c] == 0.0);
            }
        }
        pinned += x0[3 * i] <= 1e-12;
    }
    assert_int_equal(pinned, npinned);
    const double tip = x[3 * (n - 1) + 1] - x0[3 * (n - 1) + 1];
    free(x0); free(x); free(v);
    return tip;
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

defsim_body_id tu_add_spring_cloth(defsim_world *w, const double o[3], const double u[3],
                                   const double v[3], int nu, int nv, double k,
                                   double vertex_mass)
{
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    TU_OK(defsim_mesh_cloth(o, u, v, nu, nv, &m));
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    bd.rest_positions = m.positions;
    bd.vertex_count = m.vertex_count;
    bd.springs = m.springs;
    bd.spring_count = m.spring_count;
    defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_SPRING);
    bd.material.stiffness = k;
    bd.material.vertex_mass = vertex_mass;
    defsim_body_id id = {0, 0};
    const defsim_status st = defsim_world_add_body(w, &bd, &id);
    if (st != DEFSIM_OK) fail_msg("add_body: %s", defsim_world_last_error(w));
    defsim_mesh_free(&m);
    return id;
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

int tu_mapped(const char *needle)
{
    FILE *f = fopen("/proc/self/maps", "r");
    if (!f) return -1;
    char line[1024];
    int found = 0;
    while (fgets(line, sizeof line, f))
        if (strstr(line, needle)) found = 1;
    fclose(f);
    return found;
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

const char *tu_write_bytes(const char *name, const void *data, size_t n)
{
    static char paths[8][300];
    static int slot;
    char *p = paths[slot++ % 8];
    snprintf(p, sizeof paths[0], "%s/%s", tu_tmpdir, name);
    FILE *f = fopen(p, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, n, f), n);
    assert_int_equal(fclose(f), 0);
    return p;
}

const char *tu_write_file(const char *name, const char *text)
{
    return tu_write_bytes(name, text, strlen(text));
}

defsim_body_id tu_add_oscillator(defsim_world *w, tu_osc *o, double z)
{
    const tu_spring2 s = {.anchor = {0, 0, z}, .l0 = 1, .x1 = {1 + o->u0, 0, z},
                          .v1 = {o->v0, 0, 0}, .m0 = 1.0, .m1 = o->m, .k = o->k,
                          .alpha = o->alpha, .beta = o->beta, .pin_anchor = 1};
    const defsim_body_id id = tu_add_spring2(w, &s);
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

int tu_built(const char *backend) { return built_backend(backend); }

static int tu_skips;

void tu_skip(const char *what)
{
    ++tu_skips;
    printf("SKIP: %s\n", what);
}

int tu_exit(int failures)
{
    return failures ? failures : tu_skips ? TU_SKIP_CODE : 0;
}

defsim_world *tu_create_or_skip(const defsim_world_def *d)
{
    defsim_world *w = NULL;
    if (defsim_world_create(d, &w) == DEFSIM_OK) return w;
    if (tu_built(d->backend))
        fail_msg("backend %s is built but no world can be created with it: %s", d->backend,
                 defsim_last_error());
    char what[160];
    snprintf(what, sizeof what, "backend %s is not in this build", d->backend);
    tu_skip(what);
    return NULL;
}

int tu_available(const char *backend)
{
    defsim_world_def d;
    defsim_world_def_init(&d, sizeof d);
    d.backend = backend;
    defsim_world *w = tu_create_or_skip(&d);
    defsim_world_destroy(w);
    return w != NULL;
}

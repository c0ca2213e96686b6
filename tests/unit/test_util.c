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

defsim_body_id tu_add_box(defsim_world *w, defsim_model model, int nx, int ny, int nz,
                          const double lo[3], const double hi[3], double E, double nu, double rho)
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
    defsim_material_init(&bd.material, sizeof bd.material, model);
    bd.material.youngs_modulus = E;
    bd.material.poisson_ratio = nu;
    bd.material.density = rho;
    defsim_body_id id = {0, 0};
    defsim_status st = defsim_world_add_body(w, &bd, &id);
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

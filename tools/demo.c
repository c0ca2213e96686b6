/* SPDX-License-Identifier: MIT */
/*
 * defsim-demo: a cantilever beam of tets (3 m x 1 m x 1 m, stable neo-Hookean, E = 1 MPa),
 * clamped at x = 0, sagging under gravity. Prints energy and tip position per frame and
 * writes the final positions (one vertex per line) to a text file.
 *
 *   defsim-demo [--backend NAME] [--frames N] [--fps F] [--substeps S] [--cells N]
 *               [--out FILE]
 */
#include <defsim/defsim.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int usage(void)
{
    fprintf(stderr, "usage: defsim-demo [--backend NAME] [--frames N] [--fps F] [--substeps S]"
                    " [--cells N] [--out FILE]\n");
    return 2;
}

int main(int argc, char **argv)
{
    const char *backend = "symplectic_euler", *out = "cantilever_final.txt";
    int frames = 60, substeps = 40, cells = 4;
    double fps = 30.0;
    for (int i = 1; i < argc; ++i) {
        if (i + 1 >= argc) return usage();
        if (!strcmp(argv[i], "--backend")) backend = argv[++i];
        else if (!strcmp(argv[i], "--frames")) frames = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--fps")) fps = atof(argv[++i]);
        else if (!strcmp(argv[i], "--substeps")) substeps = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--cells")) cells = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--out")) out = argv[++i];
        else return usage();
    }
    if (frames < 1 || substeps < 1 || cells < 1 || !(fps > 0)) return usage();

    defsim_world_def wd;
    defsim_world_def_init(&wd, sizeof wd);
    wd.backend = backend;
    defsim_world *w = NULL;
    defsim_status st = defsim_world_create(&wd, &w);
    if (st != DEFSIM_OK) {
        fprintf(stderr, "defsim-demo: %s: %s\n", defsim_status_string(st), defsim_last_error());
        return 1;
    }
    defsim_mesh m = {.size = sizeof m};
    const double lo[3] = {0, 0, 0}, hi[3] = {3, 1, 1};
    st = defsim_mesh_box(lo, hi, 3 * cells, cells, cells, &m);
    if (st != DEFSIM_OK) {
        fprintf(stderr, "defsim-demo: %s\n", defsim_last_error());
        return 1;
    }
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    bd.rest_positions = m.positions;
    bd.vertex_count = m.vertex_count;
    bd.tets = m.tets;
    bd.tet_count = m.tet_count;
    defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    bd.material.youngs_modulus = 1e6;
    bd.material.poisson_ratio = 0.3;
    bd.material.density = 1000;
    bd.material.mass_damping = 1.0;
    defsim_body_id body;
    if ((st = defsim_world_add_body(w, &bd, &body)) != DEFSIM_OK) {
        fprintf(stderr, "defsim-demo: %s\n", defsim_world_last_error(w));
        return 1;
    }
    int32_t *clamp = malloc((size_t)m.vertex_count * sizeof *clamp);
    int nclamp = 0, tip = 0;
    for (int i = 0; i < m.vertex_count; ++i) {
        const double *p = m.positions + 3 * i;
        if (p[0] == 0.0) clamp[nclamp++] = i;
        if (p[0] == 3.0 && p[1] == 1.0 && p[2] == 1.0) tip = i;
    }
    defsim_body_pin(w, body, clamp, nclamp);
    free(clamp);
    printf("cantilever: %d vertices, %d tets, backend %s, h = %.3g s\n", m.vertex_count,
           m.tet_count, backend, 1.0 / (fps * substeps));
    printf("%6s %8s %14s %14s %14s %14s  %s\n", "frame", "t [s]", "kinetic [J]", "elastic [J]",
           "gravity [J]", "total [J]", "tip (x, y, z) [m]");
    double *x = malloc(3 * (size_t)m.vertex_count * sizeof *x);
    const double h = 1.0 / (fps * substeps);
    for (int f = 1; f <= frames; ++f) {
        for (int s = 0; s < substeps; ++s)
            if ((st = defsim_world_step(w, h)) != DEFSIM_OK) {
                fprintf(stderr, "defsim-demo: step failed at frame %d: %s: %s\n", f,
                        defsim_status_string(st), defsim_world_last_error(w));
                return 1;
            }
        defsim_energy e;
        defsim_world_energy(w, &e);
        defsim_world_get_positions(w, x, m.vertex_count);
        printf("%6d %8.4f %14.6g %14.6g %14.6g %14.6g  (%.4f, %.4f, %.4f)\n", f,
               defsim_world_time(w), e.kinetic, e.elastic, e.gravitational, e.total,
               x[3 * tip], x[3 * tip + 1], x[3 * tip + 2]);
    }
    defsim_stats s = {.size = sizeof s};
    defsim_world_stats(w, &s);
    printf("%lld steps in %.3f s (forces %.3f s)\n", (long long)s.steps, s.time_step,
           s.time_forces);
    FILE *fo = fopen(out, "w");
    if (!fo) {
        fprintf(stderr, "defsim-demo: cannot write %s\n", out);
        return 1;
    }
    for (int i = 0; i < m.vertex_count; ++i)
        fprintf(fo, "%.17g %.17g %.17g\n", x[3 * i], x[3 * i + 1], x[3 * i + 2]);
    fclose(fo);
    printf("final positions written to %s\n", out);
    free(x);
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
    return 0;
}

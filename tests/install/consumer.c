/* SPDX-License-Identifier: MIT */
/* Builds against an installed defsim and steps a falling box: proves headers, library and
 * package files work together. `consumer NAME...` steps it with each named backend instead (the
 * modules must be found with no environment variable set), and `consumer --unknown NAME` checks
 * that NAME is refused as unavailable. */
#include <defsim/defsim.h>
#include <stdio.h>
#include <string.h>

/* Steps a 1 m box falling from rest (unpinned, so it stays undeformed) for n = 10 steps of h =
 * 1 ms: returns 0 when its corner fell between g h^2 n(n-1)/2 (explicit Euler) and
 * g h^2 n(n+1)/2 (backward and symplectic Euler); exact integrators give g (n h)^2 / 2 between. */
static int fall(const char *backend)
{
    defsim_world_def wd;
    defsim_world_def_init(&wd, sizeof wd);
    if (backend) wd.backend = backend;
    defsim_world *w = NULL;
    if (defsim_world_create(&wd, &w) != DEFSIM_OK) {
        fprintf(stderr, "%s: %s\n", backend ? backend : "default", defsim_last_error());
        return 2;
    }
    defsim_mesh m = {sizeof m};
    double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    if (defsim_mesh_box(lo, hi, 1, 1, 1, &m) != DEFSIM_OK) return 3;
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    bd.rest_positions = m.positions;
    bd.vertex_count = m.vertex_count;
    bd.tets = m.tets;
    bd.tet_count = m.tet_count;
    if (defsim_world_add_body(w, &bd, NULL) != DEFSIM_OK) return 4;
    for (int i = 0; i < 10; ++i)
        if (defsim_world_step(w, 1e-3) != DEFSIM_OK) {
            fprintf(stderr, "%s: step %d: %s\n", backend ? backend : "default", i,
                    defsim_world_last_error(w));
            return 5;
        }
    double x[3 * 8];
    defsim_world_get_positions(w, x, 8);
    const double drop = -x[1], gh2 = 9.81 * 1e-6;
    printf("%s: version %s, y0 after 10 steps %.6g (exact free fall %.6g)\n",
           backend ? backend : "default", DEFSIM_VERSION_STRING, x[1], -50 * gh2);
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
    return drop >= 0.99 * 45 * gh2 && drop <= 1.01 * 55 * gh2 ? 0 : 6;
}

int main(int argc, char **argv)
{
    if (defsim_version_number() != DEFSIM_VERSION_NUMBER) return 1;
    if (argc == 3 && strcmp(argv[1], "--unknown") == 0) {
        defsim_world_def wd;
        defsim_world_def_init(&wd, sizeof wd);
        wd.backend = argv[2];
        defsim_world *w = NULL;
        const defsim_status st = defsim_world_create(&wd, &w);
        printf("%s\n", defsim_last_error());
        return st == DEFSIM_ERR_BACKEND_UNAVAILABLE && w == NULL ? 0 : 7;
    }
    if (argc < 2) return fall(NULL);
    for (int i = 1; i < argc; ++i) {
        const int rc = fall(argv[i]);
        if (rc) return rc;
    }
    return 0;
}

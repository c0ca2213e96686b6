/* SPDX-License-Identifier: MIT */
/*
 * defsim-bench-collider: the cost of a distance query against a triangle-mesh collider, through
 * its AABB tree and by a loop over every triangle (the reference), on a UV sphere of about 10k
 * triangles (radius 1, rotated) for points near its surface (|d| < 0.1) and far from it (up to
 * 3 radii), with and without the Hessian, and the cost of building the collider (copy,
 * normals, tree). Medians over rounds; a tool, not a test.
 *
 *   defsim-bench-collider [--segments N] [--points P] [--rounds R]
 */
#include "cli.h"
#include "clock.h"

#include "collider.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const double PI = 3.14159265358979323846;

static double median(double *v, int n)
{
    for (int i = 1; i < n; ++i)
        for (int j = i; j > 0 && v[j] < v[j - 1]; --j) {
            const double t = v[j];
            v[j] = v[j - 1];
            v[j - 1] = t;
        }
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static unsigned long long rng = 88172645463325252ULL;
static double urand(void)   /* [-1, 1) */
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return (double)(rng >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

static void usage(FILE *f)
{
    fprintf(f, "usage: defsim-bench-collider [--segments N] [--points P] [--rounds R]\n"
               "Distance queries against a UV-sphere mesh collider: AABB tree against a loop\n"
               "over every triangle, and the collider's build; medians over rounds.\n"
               "  --segments N  segments around the sphere, >= 4 (default 100: 9800 triangles)\n"
               "  --points P    query points (default 20000)\n"
               "  --rounds R    rounds (default 5)\n"
               "  -h, --help    this text\n"
               "  --version     the library's version\n");
}

int main(int argc, char **argv)
{
    int nu = 100, npts = 20000, rounds = 5;
    static const cli_tool tool = {"defsim-bench-collider", usage, NULL, ""};
    const cli_opt opts[] = {{"segments", CLI_INT, &nu, 4, 100000},
                            {"points", CLI_INT, &npts, 1, 1e8},
                            {"rounds", CLI_INT, &rounds, 1, 1000}, {0}};
    int first;
    const int parsed = cli_parse(&tool, opts, argc, argv, &first);
    if (parsed >= 0) return parsed;
    if (first < argc) return cli_fail(&tool, "no operands expected (got %s)", argv[first]);
    /* UV sphere: nu segments around y, nu / 2 rings: 2 nu (nu / 2 - 1) triangles */
    const int nr = nu / 2, nv = 2 + nu * (nr - 1), nt = 2 * nu * (nr - 1);
    double *x = malloc(3 * (size_t)nv * sizeof *x);
    int32_t *t = malloc(3 * (size_t)nt * sizeof *t);
    double *pts = malloc(6 * (size_t)npts * sizeof *pts);
    if (!x || !t || !pts) return 1;
    x[0] = 0; x[1] = 1; x[2] = 0; x[3] = 0; x[4] = -1; x[5] = 0;
    for (int i = 1; i < nr; ++i)
        for (int j = 0; j < nu; ++j) {
            const double th = PI * i / nr, ph = 2 * PI * j / nu;
            double *p = x + 3 * (2 + (i - 1) * nu + j);
            p[0] = sin(th) * cos(ph); p[1] = cos(th); p[2] = -sin(th) * sin(ph);
        }
    int32_t *q = t;
    for (int j = 0; j < nu; ++j) {
        const int a = 2 + j, b = 2 + (j + 1) % nu, c = 2 + (nr - 2) * nu + j,
                  d = 2 + (nr - 2) * nu + (j + 1) % nu;
        *q++ = 0; *q++ = a; *q++ = b;
        *q++ = 1; *q++ = d; *q++ = c;
    }
    for (int i = 1; i < nr - 1; ++i)
        for (int j = 0; j < nu; ++j) {
            const int a = 2 + (i - 1) * nu + j, b = 2 + (i - 1) * nu + (j + 1) % nu;
            const int c = a + nu, d = b + nu;
            *q++ = a; *q++ = c; *q++ = d;
            *q++ = a; *q++ = d; *q++ = b;
        }
    defsim_collider_def def;
    defsim_collider_def_init(&def, sizeof def);
    def.shape = DEFSIM_SHAPE_MESH;
    def.vertices = x;
    def.vertex_count = nv;
    def.triangles = t;
    def.triangle_count = nt;
    def.rotation[0] = cos(0.3); def.rotation[1] = sin(0.3) / sqrt(2); def.rotation[3] = sin(0.3) / sqrt(2);
    defsim__messages msg;
    memset(&msg, 0, sizeof msg);
    defsim__collider col;
    double *tb = malloc((size_t)rounds * sizeof *tb), *tn = malloc((size_t)rounds * sizeof *tn),
           *tf = malloc((size_t)rounds * sizeof *tf), *tr = malloc((size_t)rounds * sizeof *tr);
    for (int r = 0; r < rounds; ++r) {
        const double t0 = tools_now();
        if (defsim__collider_make(&msg, &def, &col) != DEFSIM_OK) { fprintf(stderr, "%s\n", msg.error); return 1; }
        tb[r] = tools_now() - t0;
        if (r + 1 < rounds) defsim__collider_free(&col);
    }
    defsim__pose pose;
    defsim__pose_set(&pose, col.pos, col.rot);
    /* near: radius in [0.9, 1.1]; far: radius in [1.1, 3] (world = local for the radius) */
    for (int i = 0; i < 2 * npts; ++i) {
        double u[3], n;
        do { for (int k = 0; k < 3; ++k) u[k] = urand(); n = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]); } while (n < 0.1 || n > 1.0);
        const double rad = i < npts ? 1.0 + 0.1 * urand() : 2.05 + 0.95 * urand();
        for (int k = 0; k < 3; ++k) pts[3 * i + k] = rad * u[k] / n;
    }
    volatile double sink = 0.0;
    double maxdiff = 0.0;
    for (int set = 0; set < 2; ++set) {
        const double *P = pts + 3 * (size_t)set * npts;
        const int nbrute = npts / 100 > 0 ? npts / 100 : 1;   /* the loop is slow: fewer points */
        for (int r = 0; r < rounds; ++r) {
            double t0 = tools_now(), d, g[3], h[9];
            for (int i = 0; i < npts; ++i) {
                defsim__collider_distance(&col, &pose, P + 3 * i, &d, g, NULL);
                sink += d;
            }
            tn[r] = (tools_now() - t0) / npts;
            t0 = tools_now();
            for (int i = 0; i < npts; ++i) {
                defsim__collider_distance(&col, &pose, P + 3 * i, &d, g, h);
                sink += h[0];
            }
            tf[r] = (tools_now() - t0) / npts;
            t0 = tools_now();
            for (int i = 0; i < nbrute; ++i) {
                /* the brute force works in the local frame: the frame change is negligible */
                d = defsim__mesh_distance_brute(&col, P + 3 * i);
                sink += d;
            }
            tr[r] = (tools_now() - t0) / nbrute;
        }
        for (int i = 0; i < nbrute; ++i) {
            double l[3], d, g[3];
            const double *R = pose.R, *p = P + 3 * i;
            for (int k = 0; k < 3; ++k) l[k] = R[k] * p[0] + R[3 + k] * p[1] + R[6 + k] * p[2];
            defsim__collider_distance(&col, &pose, p, &d, g, NULL);
            maxdiff = fmax(maxdiff, fabs(fabs(d) - defsim__mesh_distance_brute(&col, l)));
        }
        const double mn = median(tn, rounds), mf = median(tf, rounds), mr = median(tr, rounds);
        printf("%-5s points: tree %.3g us (with Hessian %.3g us), all %d triangles %.3g us: %.0fx\n",
               set ? "far" : "near", 1e6 * mn, 1e6 * mf, nt, 1e6 * mr, mr / mn);
    }
    printf("build (copy, normals, tree) of %d triangles, %d vertices: %.3g ms\n", nt, nv,
           1e3 * median(tb, rounds));
    printf("largest |tree - loop| distance difference: %.3g m\n", maxdiff);
    (void)sink;
    defsim__collider_free(&col);
    free(x); free(t); free(pts); free(tb); free(tn); free(tf); free(tr);
    return 0;
}

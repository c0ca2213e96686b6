/* SPDX-License-Identifier: MIT */
/*
 * `defsim bench --spatial` (issue 29) on reduced sweeps of the cantilever (3 x 1 x 1 m, clamped,
 * stable neo-Hookean), coarse box 6 x 2 x 2 cells, reference quadratic tets on 12 x 4 x 4:
 *
 *  1. In its linear range (E = 1e8, nu = 0.3; backward Euler at h = 0.1 s for 1 s: at rest by
 *     then, so each mesh's static equilibrium), the top far corner's error at T is what
 *     test_tet10_accuracy measures by static solves: linear tets on 12 x 4 x 4 cells 20 % off
 *     (there the vertical sag: 10.311 against 12.889 mm, 20.0 %; here the displacement vector,
 *     20.8 %), quadratic tets on 6 x 2 x 2 within 2 %.
 *  2. The shipped dynamic scene (E = 1e6, velocity Verlet at each mesh's stable step, T = 0.5 s):
 *     the error of linear 6 x 2 x 2 lies in its band (1.8e-2 of the body size), refinement to
 *     12 x 4 x 4 cuts it at least 2.5 times, quadratic tets on 6 x 2 x 2 (the same 325 vertices as
 *     linear 12 x 4 x 4) are at least 4 times more accurate still, are on the front and own a
 *     level of it; the reference's spatial check (the same quadratic 6 x 2 x 2 box at the
 *     reference's step) agrees with the swept quadratic point to 5 %, and its temporal check
 *     (twice the step) is below 1e-5. A second run reuses the cached reference.
 *  3. Usage errors: a quadratic mesh as fine as the reference, cells that are not NXxNYxNZ;
 *     the rope (not a box) is refused with exit status 1.
 *
 * With --converged (ctest -L long: about a minute of CPU) it computes the full benchmark's
 * reference instead (quadratic tets on 30 x 10 x 10 cells) and checks that it is converged:
 * the quadratic 24 x 8 x 8 box differs from it by less than 1e-4 of the body size (measured
 * 3.9e-5; tip 1.6e-4 of its displacement, bound 1e-3), and twice its step changes less than 1e-5
 * (measured 6.9e-7); linear 6 x 2 x 2 against it lies in the band of (2).
 *
 *   test_bench_spatial DEFSIM_EXE CANTILEVER.json OUT_DIR [--converged]
 */
#include "tool_check.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>

typedef struct row {
    char order[16], cells[32], backend[32], kind[8], status[32];
    int vertices, pareto;
    double value, cpu, wall, rms, max, tip;
    long long steps, newton;
} row;

static int read_csv(const char *path, row *rows, int max)
{
    FILE *f = fopen(path, "r");
    if (!f) return -1;
    char line[1024];
    int n = 0;
    if (!fgets(line, sizeof line, f)) { fclose(f); return -1; }
    while (n < max && fgets(line, sizeof line, f)) {
        row *r = &rows[n];
        for (char *p = line; *p; ++p)
            if (*p == ',') *p = ' ';
        if (sscanf(line, "%15s %31s %d %31s %7s %lf %lf %lf %lf %lf %lf %31s %lld %lld %d",
                   r->order, r->cells, &r->vertices, r->backend, r->kind, &r->value, &r->cpu,
                   &r->wall, &r->rms, &r->max, &r->tip, r->status, &r->steps, &r->newton,
                   &r->pareto) != 15) {
            fclose(f);
            return -1;
        }
        ++n;
    }
    fclose(f);
    return n;
}

static const row *find(const row *rows, int n, const char *order, const char *cells)
{
    for (int i = 0; i < n; ++i)
        if (!strcmp(rows[i].order, order) && !strcmp(rows[i].cells, cells)) return &rows[i];
    return NULL;
}

static int run(const char *cmd)
{
    fprintf(stderr, "+ %s\n", cmd);
    const int st = system(cmd);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

/* The number after "key " in the first line of a file that starts with it. */
static double file_value(const char *path, const char *key)
{
    FILE *f = fopen(path, "r");
    char line[1024];
    double v = NAN;
    const size_t k = strlen(key);
    while (f && fgets(line, sizeof line, f))
        if (!strncmp(line, key, k) && line[k] == ' ') { v = atof(line + k + 1); break; }
    if (f) fclose(f);
    return v;
}

/* The reference file in dir (the first *_spatial_reference_*.txt found by ls). */
static int reference_path(const char *dir, char *out, size_t n)
{
    char cmd[1400];
    snprintf(cmd, sizeof cmd, "ls '%s'/*_spatial_reference_*.txt 2>/dev/null", dir);
    FILE *p = popen(cmd, "r");
    int ok = p && fgets(out, (int)n, p) != NULL;
    if (p) pclose(p);
    if (ok) out[strcspn(out, "\n")] = '\0';
    return ok ? 0 : -1;
}

int main(int argc, char **argv)
{
    if (argc != 4 && !(argc == 5 && !strcmp(argv[4], "--converged"))) {
        fprintf(stderr, "usage: test_bench_spatial DEFSIM_EXE CANTILEVER.json OUT_DIR "
                        "[--converged]\n");
        return 2;
    }
    const char *exe = argv[1], *scene = argv[2], *out = argv[3];
    char cmd[4096], csv[1400], dir[1200], ref[1400];
    row rows[32];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", out);
    run(cmd);
    if (argc == 5) {
        snprintf(cmd, sizeof cmd, "'%s' bench --spatial '%s' --cells 6x2x2 --linear 1 "
                 "--quadratic none --reference-refine 5 --backends velocity_verlet --repeats 1 "
                 "--no-plot --out '%s'", exe, scene, out);
        CHECK(run(cmd) == 0, "run failed");
        snprintf(csv, sizeof csv, "%s/cantilever_spatial.csv", out);
        CHECK(read_csv(csv, rows, 32) == 1 && rows[0].rms > 0.014 && rows[0].rms < 0.023,
              "linear 6x2x2 against the converged reference: not in 1.4e-2 .. 2.3e-2");
        CHECK(reference_path(out, ref, sizeof ref) == 0, "no reference file in %s", out);
        const double check = file_value(ref, "check_rms_err");
        const double tip = file_value(ref, "check_tip_err");
        const double tcheck = file_value(ref, "time_check_rms_err");
        CHECK(file_value(ref, "check_refine") == 4, "the check is not the 24x8x8 box");
        CHECK(check > 0 && check < 1e-4, "quadratic 24x8x8 against 30x10x10: %g", check);
        CHECK(tip > 0 && tip < 1e-3, "quadratic 24x8x8 against 30x10x10, tip: %g", tip);
        CHECK(tcheck > 0 && tcheck < 1e-5, "twice the reference's step: %g", tcheck);
        if (failures) fprintf(stderr, "%d check(s) failed\n", failures);
        else fprintf(stderr, "all checks passed\n");
        return failures ? 1 : 0;
    }

    /* 1. The linear range, at rest by T. */
    snprintf(dir, sizeof dir, "%s/static", out);
    snprintf(cmd, sizeof cmd,
             "'%s' bench --spatial '%s' --set bodies.0.material.youngs_modulus=1e8 "
             "--set world.fps=10 --time 1 --cells 6x2x2 --linear 2 --quadratic 1 "
             "--reference-refine 2 --reference-backend newton_cholmod --reference-h 0.1 "
             "--backends newton_cholmod --h 0.1 --repeats 1 --no-plot --out '%s'",
             exe, scene, dir);
    CHECK(run(cmd) == 0, "linear-range run failed");
    snprintf(csv, sizeof csv, "%s/cantilever_spatial.csv", dir);
    int n = read_csv(csv, rows, 32);
    CHECK(n == 2, "%s: %d rows, expected 2", csv, n);
    const row *lin = find(rows, n, "linear", "12x4x4"), *quad = find(rows, n, "quadratic", "6x2x2");
    CHECK(lin && !strcmp(lin->status, "ok") && lin->tip > 0.19 && lin->tip < 0.225,
          "linear 12x4x4, linear range: tip error %g, expected the static 20 %% (0.19..0.225)",
          lin ? lin->tip : NAN);
    CHECK(lin && lin->vertices == 325 && lin->steps == 10, "linear 12x4x4: %d vertices, %lld "
          "steps", lin ? lin->vertices : -1, lin ? lin->steps : -1);
    CHECK(quad && !strcmp(quad->status, "ok") && quad->tip < 0.02,
          "quadratic 6x2x2, linear range: tip error %g, expected below 2 %%",
          quad ? quad->tip : NAN);

    /* 2. The dynamic scene. */
    snprintf(dir, sizeof dir, "%s/dynamic", out);
    const char *common = "--cells 6x2x2 --linear 1,2 --quadratic 1 --reference-refine 2 "
                         "--backends velocity_verlet --repeats 3 --no-plot";
    snprintf(cmd, sizeof cmd, "'%s' bench --spatial '%s' %s --out '%s'", exe, scene, common, dir);
    CHECK(run(cmd) == 0, "dynamic run failed");
    snprintf(csv, sizeof csv, "%s/cantilever_spatial.csv", dir);
    n = read_csv(csv, rows, 32);
    CHECK(n == 3, "%s: %d rows, expected 3", csv, n);
    const row *l1 = find(rows, n, "linear", "6x2x2"), *l2 = find(rows, n, "linear", "12x4x4");
    const row *q1 = find(rows, n, "quadratic", "6x2x2");
    CHECK(l1 && l2 && q1, "missing rows");
    if (l1 && l2 && q1) {
        for (int i = 0; i < n; ++i)
            CHECK(!strcmp(rows[i].status, "ok") && rows[i].cpu > 0 && rows[i].max >= rows[i].rms,
                  "row %d: %s", i, rows[i].status);
        CHECK(l1->rms > 0.014 && l1->rms < 0.023, "linear 6x2x2: error %g, expected 1.4e-2 .. "
              "2.3e-2", l1->rms);
        CHECK(l2->rms < l1->rms / 2.5, "linear 12x4x4 (%g) not 2.5 times below 6x2x2 (%g)",
              l2->rms, l1->rms);
        CHECK(q1->vertices == l2->vertices && q1->rms < l2->rms / 4.0,
              "quadratic 6x2x2 (%d vertices, %g) not 4 times below linear 12x4x4 (%d, %g)",
              q1->vertices, q1->rms, l2->vertices, l2->rms);
        CHECK(q1->pareto == 1, "quadratic 6x2x2 is not on the front");
        CHECK(reference_path(dir, ref, sizeof ref) == 0, "no reference file in %s", dir);
        const double check = file_value(ref, "check_rms_err");
        const double tcheck = file_value(ref, "time_check_rms_err");
        CHECK(fabs(check - q1->rms) < 0.05 * q1->rms, "reference check %g: the quadratic 6x2x2 "
              "box at the reference's step does not agree with its sweep point %g", check,
              q1->rms);
        CHECK(tcheck >= 0 && tcheck < 1e-5, "reference at twice its step: %g", tcheck);
        /* The front file: quadratic tets own some level. */
        char md[1400], line[512];
        snprintf(md, sizeof md, "%s/cantilever_spatial_front.md", dir);
        FILE *f = fopen(md, "r");
        int lin_owned = -1, quad_owned = -1;
        while (f && fgets(line, sizeof line, f))
            if (sscanf(line, "Owned levels (resolved by the reference): linear %d, "
                       "quadratic %d", &lin_owned, &quad_owned) == 2)
                break;
        if (f) fclose(f);
        CHECK(quad_owned >= 1 && lin_owned >= 1, "%s: owned levels linear %d, quadratic %d", md,
              lin_owned, quad_owned);
        /* A second run reads the cached reference, unchanged. */
        struct stat s1, s2;
        CHECK(stat(ref, &s1) == 0, "stat %s", ref);
        snprintf(cmd, sizeof cmd, "'%s' bench --spatial '%s' --cells 6x2x2 --linear 1 "
                 "--quadratic none --reference-refine 2 --backends velocity_verlet --repeats 1 "
                 "--no-plot --out '%s'", exe, scene, dir);
        CHECK(run(cmd) == 0, "second run failed");
        CHECK(stat(ref, &s2) == 0 && s1.st_mtim.tv_sec == s2.st_mtim.tv_sec &&
                  s1.st_mtim.tv_nsec == s2.st_mtim.tv_nsec, "the reference was rewritten");
        row again[4];
        CHECK(read_csv(csv, again, 4) == 1 && again[0].rms == l1->rms,
              "linear 6x2x2 with the cached reference: a different error");
    }

    /* 3. Usage errors. */
    snprintf(cmd, sizeof cmd, "'%s' bench --spatial '%s' --quadratic 2 --reference-refine 2 "
             "--out '%s/u'", exe, scene, out);
    CHECK(run(cmd) == 2, "a quadratic mesh as fine as the reference was accepted");
    snprintf(cmd, sizeof cmd, "'%s' bench --spatial '%s' --cells 6x2 --out '%s/u'", exe, scene,
             out);
    CHECK(run(cmd) == 2, "--cells 6x2 accepted");
    /* A scene that is not one body on a generated box: an error (exit 1), not a crash. */
    char rope[1200];
    snprintf(rope, sizeof rope, "%s", scene);
    char *slash = strrchr(rope, '/');
    snprintf(slash ? slash + 1 : rope, sizeof rope - (size_t)(slash ? slash + 1 - rope : 0),
             "rope.json");
    snprintf(cmd, sizeof cmd, "'%s' bench --spatial '%s' --no-plot --out '%s/u'", exe, rope, out);
    CHECK(run(cmd) == 1, "the rope (no box) was not refused with exit status 1");
    if (failures) fprintf(stderr, "%d check(s) failed\n", failures);
    else fprintf(stderr, "all checks passed\n");
    return failures ? 1 : 0;
}

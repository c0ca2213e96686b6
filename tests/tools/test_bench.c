/* SPDX-License-Identifier: MIT */
/*
 * `defsim bench` on a tiny case: the rope scene to T = 0.1 s with symplectic_euler and
 * newton_cholmod at h = 2e-4, 4e-4, 8e-4 s and sundials_ida at tol = 1e-4, 1e-5, 1e-6. Checks the
 * CSV (both Euler methods are first order: doubling h doubles the error, within 1.6..2.5; IDA's
 * error falls with the tolerance, by at least 100x over the two decades), the Pareto table, the
 * reference (its rtol 1e-9 check agrees to 1e-9 of the body size), that a second run reuses the
 * cached reference (same file, not rewritten: same inode and modification time, same errors), that
 * another end time computes another reference, and that a reference of another key is refused.
 *
 *   test_bench DEFSIM_EXE SCENE.json OUT_DIR
 */
#include "tool_check.h"

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>

typedef struct row {
    char backend[32], kind[8], status[32];
    double value, wall, rms, max, energy;
    long long steps, newton, internal;
    int pareto;
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
        /* Commas to spaces: no field contains one. */
        for (char *p = line; *p; ++p)
            if (*p == ',') *p = ' ';
        if (sscanf(line, "%31s %7s %lf %lf %lf %lf %lf %31s %lld %lld %lld %d", r->backend,
                   r->kind, &r->value, &r->wall, &r->rms, &r->max, &r->energy, r->status,
                   &r->steps, &r->newton, &r->internal, &r->pareto) != 12) {
            fclose(f);
            return -1;
        }
        ++n;
    }
    fclose(f);
    return n;
}

static int run(const char *cmd)
{
    fprintf(stderr, "+ %s\n", cmd);
    const int st = system(cmd);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

/* The reference files in dir; the first name goes to first. */
static int count_refs(const char *dir, char *first, size_t n)
{
    DIR *d = opendir(dir);
    int c = 0;
    if (!d) return 0;
    for (struct dirent *e; (e = readdir(d));)
        if (strstr(e->d_name, "_reference_") && strstr(e->d_name, ".txt")) {
            if (c++ == 0) snprintf(first, n, "%s/%s", dir, e->d_name);
        }
    closedir(d);
    return c;
}

static double ref_value(const char *path, const char *key)
{
    FILE *f = fopen(path, "r");
    char line[1024];
    double v = NAN;
    size_t k = strlen(key);
    while (f && fgets(line, sizeof line, f))
        if (!strncmp(line, key, k) && line[k] == ' ') { v = atof(line + k + 1); break; }
    if (f) fclose(f);
    return v;
}

int main(int argc, char **argv)
{
    if (argc != 4) {
        fprintf(stderr, "usage: test_bench DEFSIM_EXE SCENE.json OUT_DIR\n");
        return 2;
    }
    const char *exe = argv[1], *scene = argv[2], *out = argv[3];
    char cmd[4096], csv[1200], ref[1400] = "", ref2[1400] = "";
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", out);
    run(cmd);
    const char *common = "--time 0.1 --backends symplectic_euler,newton_cholmod,sundials_ida "
                         "--h 2e-4,4e-4,8e-4 --tol 1e-4,1e-5,1e-6 --repeats 1 --no-plot";
    snprintf(cmd, sizeof cmd, "'%s' bench '%s' %s --out '%s'", exe, scene, common, out);
    CHECK(run(cmd) == 0, "first bench run failed");
    snprintf(csv, sizeof csv, "%s/rope.csv", out);
    row rows[32];
    const int n = read_csv(csv, rows, 32);
    CHECK(n == 9, "%s: %d rows, expected 9", csv, n);
    for (int i = 0; i < n; ++i)
        CHECK(!strcmp(rows[i].status, "ok") && rows[i].rms > 0 && rows[i].max >= rows[i].rms &&
                  rows[i].steps > 0 && rows[i].wall > 0,
              "row %d (%s %g): status %s rms %g max %g", i, rows[i].backend, rows[i].value,
              rows[i].status, rows[i].rms, rows[i].max);
    /* Fixed-step backends: rows in h order 2e-4, 4e-4, 8e-4; first-order convergence. */
    for (int b = 0; b < 2 && n == 9; ++b) {
        const row *r = rows + 3 * b;
        CHECK(!strcmp(r[0].kind, "h") && fabs(r[0].value - 2e-4) < 1e-12 && r[0].steps == 500,
              "%s: first row h %g, %lld steps", r[0].backend, r[0].value, r[0].steps);
        for (int k = 0; k < 2; ++k) {
            const double ratio = r[k + 1].rms / r[k].rms;
            CHECK(ratio > 1.6 && ratio < 2.5, "%s: error ratio h=%g/h=%g is %g, not ~2",
                  r[k].backend, r[k + 1].value, r[k].value, ratio);
        }
        if (b == 1)
            CHECK(r[0].newton >= r[0].steps, "newton_cholmod: %lld Newton iterations for %lld "
                  "steps", r[0].newton, r[0].steps);
    }
    if (n == 9) {
        const row *r = rows + 6;
        CHECK(!strcmp(r[0].kind, "tol") && r[0].internal > 0, "sundials_ida row");
        CHECK(r[1].rms < r[0].rms && r[2].rms < r[1].rms && r[2].rms < 1e-2 * r[0].rms,
              "sundials_ida: errors %g %g %g do not fall with the tolerance", r[0].rms, r[1].rms,
              r[2].rms);
        CHECK(r[2].internal > r[0].internal, "sundials_ida: the tighter tolerance took no more internal steps");
    }
    CHECK(count_refs(out, ref, sizeof ref) == 1, "one reference file expected in %s", out);
    const double check = ref_value(ref, "check_rms_err");
    CHECK(check >= 0 && check < 1e-9, "reference rtol 1e-9 vs 1e-10 differ by %g", check);
    CHECK(ref_value(ref, "wall_seconds") >= 0, "reference wall time not recorded");
    snprintf(cmd, sizeof cmd, "%s/rope_pareto.md", out);
    struct stat st1, st2;
    CHECK(stat(cmd, &st1) == 0 && st1.st_size > 100, "no Pareto table");
    /* The front's ratio t(1e-5) / t(1e-3), t(e) the fastest wall time of a row reaching e, as
     * computed here from the CSV. */
    {
        double t3 = 0.0, t5 = 0.0;
        for (int i = 0; i < n; ++i) {
            if (rows[i].rms <= 1e-3 && (t3 == 0.0 || rows[i].wall < t3)) t3 = rows[i].wall;
            if (rows[i].rms <= 1e-5 && (t5 == 0.0 || rows[i].wall < t5)) t5 = rows[i].wall;
        }
        FILE *pf = fopen(cmd, "r");
        char line[512];
        double printed = -1.0;
        while (pf && fgets(line, sizeof line, pf))
            if (sscanf(line, "Front: t(1e-5) / t(1e-3) = %lf", &printed) == 1) break;
        if (pf) fclose(pf);
        CHECK(t3 > 0.0 && t5 > 0.0, "rope: levels 1e-3 and 1e-5 not both reached");
        CHECK(fabs(printed - t5 / t3) <= 0.006 * t5 / t3 + 0.005,
              "Pareto file: t(1e-5) / t(1e-3) printed %g, the rows give %g", printed, t5 / t3);
    }

    /* Second run: the cached reference is used, not rewritten, and gives the same errors. */
    CHECK(stat(ref, &st1) == 0, "stat %s", ref);
    snprintf(cmd, sizeof cmd, "'%s' bench '%s' %s --out '%s'", exe, scene, common, out);
    CHECK(run(cmd) == 0, "second bench run failed");
    CHECK(stat(ref, &st2) == 0 && st1.st_ino == st2.st_ino &&
              st1.st_mtim.tv_sec == st2.st_mtim.tv_sec &&
              st1.st_mtim.tv_nsec == st2.st_mtim.tv_nsec,
          "the reference file was rewritten");
    row rows2[32];
    const int n2 = read_csv(csv, rows2, 32);
    CHECK(n2 == n, "second CSV has %d rows", n2);
    for (int i = 0; i < n && i < n2; ++i)
        CHECK(rows2[i].rms == rows[i].rms, "row %d: error changed with the cached reference", i);

    /* Another end time is another key: a second reference file. */
    snprintf(cmd, sizeof cmd,
             "'%s' bench '%s' --time 0.05 --backends symplectic_euler --h 5e-4 --repeats 1 "
             "--no-plot --out '%s'", exe, scene, out);
    CHECK(run(cmd) == 0, "bench at T = 0.05 failed");
    CHECK(count_refs(out, ref2, sizeof ref2) == 2, "T = 0.05 s did not compute a new reference");
    /* A reference computed for T = 0.1 s is refused for T = 0.05 s. */
    snprintf(cmd, sizeof cmd,
             "'%s' bench '%s' --time 0.05 --backends symplectic_euler --h 5e-4 --repeats 1 "
             "--no-plot --out '%s/x' --reference '%s'", exe, scene, out, ref);
    CHECK(run(cmd) == 1, "a reference of another key was accepted");
    /* Usage errors. */
    snprintf(cmd, sizeof cmd, "'%s' bench '%s' --h 0,1 --no-plot --out '%s/y'", exe, scene, out);
    CHECK(run(cmd) == 2, "--h 0 accepted");
    snprintf(cmd, sizeof cmd, "'%s' bench '%s' --backends nope --no-plot --out '%s/z'", exe, scene,
             out);
    CHECK(run(cmd) == 1, "a run with no available backend succeeded");
    if (failures) fprintf(stderr, "%d check(s) failed\n", failures);
    else fprintf(stderr, "all checks passed\n");
    return failures ? 1 : 0;
}

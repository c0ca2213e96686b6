/* SPDX-License-Identifier: MIT */
/*
 * Golden trajectories: every shipped scene, every backend and (for tet scenes) every tet model
 * runs a short trajectory; a 64-bit FNV-1a hash of the raw bytes of x and v after each step, of
 * the elastic forces at the final state and of the final energies must match the recorded ones
 * bit for bit. Refactors of the core must not change a single bit of any result.
 *
 *   test_golden <scenes dir> <golden file>            compare (exit 1 on the first difference)
 *   test_golden <scenes dir> <golden file> --record   write the golden file
 *
 * The batched kernels are forced to their generic variant (DEFSIM_SIMD=generic; symplectic Euler
 * runs again with the scalar reference kernels, DEFSIM_SIMD=scalar), newton_cholmod factorises
 * without the BLAS (simplicial) and worlds run on one thread, so the hashes do not depend on the
 * machine's instruction set or core count.
 */
#include "fileio.h"
#include "scene.h"

#include "built_backends.h"

#include <defsim/defsim.h>

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const uint64_t fnv_offset = 14695981039346656037ull;

typedef struct run_case {
    const char *scene;
    const char *variant;    /* "" or a label of the extra overrides */
    const char *extra;      /* NULL or one more override */
    int tets;
    const char *skip_model; /* NULL or a model the scene cannot run */
} run_case;

static const run_case scenes[] = {
    {"cantilever", "", NULL, 1, NULL},
    {"cantilever_corotated", "", NULL, 1, NULL},
    /* The squash starts inverted, where the neo-Hookean log J is undefined. */
    {"squash", "", NULL, 1, "neohookean"},
    {"stiff_block", "", NULL, 1, NULL},
    /* Stiffness (Rayleigh beta) damping: no shipped scene uses it. */
    {"squash", "+beta", "bodies.0.material.stiffness_damping=0.002", 1, "neohookean"},
    {"cloth", "", NULL, 0, NULL},
    {"rope", "", NULL, 0, NULL},
};

static const char *const models[] = {"stvk", "corotated", "neohookean", "stable_neohookean"};

typedef struct backend_case {
    const char *name;
    double h;               /* 0: the scene's own step */
    int steps;
} backend_case;

static const backend_case backends[] = {
    {"explicit_euler", 0.0, 20},
    {"symplectic_euler", 0.0, 20},
    {"newton_cholmod", 5e-3, 4},
    {"sundials_kinsol", 5e-3, 4},
    {"sundials_ida", 2e-3, 2},
};

/* One line of the golden file: "<case> <step> <hash>" where step is a number, "forces" or
 * "energy". */
typedef struct line {
    char key[160];
    char what[16];
    uint64_t hash;
} line;

typedef struct lines {
    line *v;
    int n, cap;
} lines;

static void push(lines *L, const char *key, const char *what, uint64_t hash)
{
    if (L->n == L->cap) {
        L->cap = L->cap ? 2 * L->cap : 256;
        L->v = realloc(L->v, (size_t)L->cap * sizeof *L->v);
        if (!L->v) {
            fprintf(stderr, "out of memory\n");
            exit(2);
        }
    }
    line *l = &L->v[L->n++];
    snprintf(l->key, sizeof l->key, "%s", key);
    snprintf(l->what, sizeof l->what, "%s", what);
    l->hash = hash;
}

/* Runs one case with the tet kernels `simd` (DEFSIM_SIMD: "generic" or "scalar") and appends
 * its lines. Returns 0, or -1 when the backend is unavailable. */
static int run(const char *dir, const run_case *rc, const char *model, const backend_case *bc,
               const char *simd, lines *out)
{
    char path[1024], key[160];
    snprintf(path, sizeof path, "%s/%s.json", dir, rc->scene);
    snprintf(key, sizeof key, "%s%s/%s/%s%s", rc->scene, rc->variant, bc->name,
             model ? model : "spring", strcmp(simd, "generic") ? "/scalar" : "");
    setenv("DEFSIM_SIMD", simd, 1);   /* read when the world is planned */
    char o_backend[128], o_model[128];
    snprintf(o_backend, sizeof o_backend, "world.backend=%s", bc->name);
    snprintf(o_model, sizeof o_model, "bodies.0.material.model=%s", model ? model : "spring");
    const char *ov[3] = {o_backend, o_model, rc->extra};
    const int nov = rc->extra ? 3 : 2;
    scene s;
    if (scene_load(&s, path, ov, nov)) {
        fprintf(stderr, "%s: %s\n", key, s.error);
        exit(2);
    }
    s.def.num_threads = 1;
    defsim_world *w = NULL;
    defsim_status st = scene_build(&s, &w);
    if (st == DEFSIM_ERR_BACKEND_UNAVAILABLE && !built_backend(bc->name)) {
        scene_free(&s);
        return -1;
    }
    if (st != DEFSIM_OK) {
        fprintf(stderr, "%s: %s\n", key, s.error);
        exit(2);
    }
    /* CHOLMOD's supernodal factorisation calls the BLAS, whose kernels OpenBLAS picks by CPU
     * (AVX2 and AVX-512 kernels round differently): the simplicial one calls none, so the
     * hashes stay those of the code, not of the machine. */
    if (!strcmp(bc->name, "newton_cholmod") &&
        defsim_world_set_option(w, "newton_cholmod.cholmod_factor", "simplicial") != DEFSIM_OK) {
        fprintf(stderr, "%s: %s\n", key, defsim_world_last_error(w));
        exit(2);
    }
    const int32_t n = s.vertex_count;
    double *x = malloc(3 * (size_t)n * sizeof *x), *v = malloc(3 * (size_t)n * sizeof *v);
    double *f = malloc(3 * (size_t)n * sizeof *f);
    if (!x || !v || !f) exit(2);
    const double h = bc->h > 0.0 ? bc->h : s.h;
    for (int k = 1; k <= bc->steps; ++k) {
        st = defsim_world_step(w, h);
        char what[16];
        snprintf(what, sizeof what, "%d", k);
        uint64_t hash = fnv_offset;
        hash = tools_fnv1a(hash, &st, sizeof st);
        if (defsim_world_get_positions(w, x, n) || defsim_world_get_velocities(w, v, n)) exit(2);
        for (int32_t i = 0; i < 3 * n; ++i)
            if (!isfinite(x[i]) || !isfinite(v[i])) {
                fprintf(stderr, "%s: step %d: non-finite state (step too large)\n", key, k);
                exit(2);
            }
        if (st != DEFSIM_OK) {
            fprintf(stderr, "%s: step %d: %s\n", key, k, defsim_world_last_error(w));
            exit(2);
        }
        hash = tools_fnv1a(hash, x, 3 * (size_t)n * sizeof *x);
        hash = tools_fnv1a(hash, v, 3 * (size_t)n * sizeof *v);
        push(out, key, what, hash);
    }
    uint64_t hf = fnv_offset;
    st = defsim_world_forces(w, x, f);
    hf = tools_fnv1a(hf, &st, sizeof st);
    hf = tools_fnv1a(hf, f, 3 * (size_t)n * sizeof *f);
    push(out, key, "forces", hf);
    defsim_energy e;
    st = defsim_world_energy(w, &e);
    uint64_t he = tools_fnv1a(fnv_offset, &st, sizeof st);
    he = tools_fnv1a(he, &e.kinetic, sizeof e.kinetic);
    he = tools_fnv1a(he, &e.elastic, sizeof e.elastic);
    he = tools_fnv1a(he, &e.gravitational, sizeof e.gravitational);
    he = tools_fnv1a(he, &e.total, sizeof e.total);
    push(out, key, "energy", he);
    free(x);
    free(v);
    free(f);
    defsim_world_destroy(w);
    scene_free(&s);
    return 0;
}

static int read_golden(const char *path, lines *L)
{
    FILE *fp = fopen(path, "r");
    if (!fp) return -1;
    char buf[512];
    while (fgets(buf, sizeof buf, fp)) {
        if (buf[0] == '#' || buf[0] == '\n') continue;
        char key[160], what[16];
        uint64_t hash;
        if (sscanf(buf, "%159s %15s %" SCNx64, key, what, &hash) != 3) {
            fprintf(stderr, "%s: malformed line: %s", path, buf);
            fclose(fp);
            return -1;
        }
        push(L, key, what, hash);
    }
    fclose(fp);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: %s <scenes dir> <golden file> [--record]\n", argv[0]);
        return 2;
    }
    const int record = argc > 3 && !strcmp(argv[3], "--record");

    lines got = {0}, want = {0};
    int skipped = 0;
    for (size_t i = 0; i < sizeof scenes / sizeof *scenes; ++i) {
        const int nm = scenes[i].tets ? (int)(sizeof models / sizeof *models) : 1;
        for (int m = 0; m < nm; ++m) {
            if (scenes[i].skip_model && !strcmp(scenes[i].skip_model, models[m])) continue;
            for (size_t b = 0; b < sizeof backends / sizeof *backends; ++b)
                /* The scalar reference kernels too, on tet scenes with symplectic Euler. */
                for (int k = 0; k < (scenes[i].tets && b == 1 ? 2 : 1); ++k)
                    if (run(argv[1], &scenes[i], scenes[i].tets ? models[m] : NULL,
                            &backends[b], k ? "scalar" : "generic", &got)) {
                        if (record) {
                            fprintf(stderr, "backend %s unavailable: cannot record\n",
                                    backends[b].name);
                            return 2;
                        }
                        ++skipped;
                    }
        }
    }

    if (record) {
        FILE *fp = fopen(argv[2], "w");
        if (!fp) {
            perror(argv[2]);
            return 2;
        }
        fprintf(fp, "# Golden trajectories (tests/golden/test_golden.c): <scene/backend/model> "
                    "<step|forces|energy> <FNV-1a 64 of the raw bytes>\n");
        for (int i = 0; i < got.n; ++i)
            fprintf(fp, "%s %s %016" PRIx64 "\n", got.v[i].key, got.v[i].what, got.v[i].hash);
        fclose(fp);
        printf("recorded %d lines to %s\n", got.n, argv[2]);
        return 0;
    }

    if (read_golden(argv[2], &want)) {
        fprintf(stderr, "cannot read %s\n", argv[2]);
        return 2;
    }
    /* Every computed line must be in the golden file with the same hash; cases of unavailable
     * backends are skipped (and counted). */
    int checked = 0, j = 0;
    for (int i = 0; i < got.n; ++i) {
        while (j < want.n && (strcmp(want.v[j].key, got.v[i].key) ||
                              strcmp(want.v[j].what, got.v[i].what)))
            ++j;
        if (j == want.n) {
            fprintf(stderr, "FAIL: %s %s not in the golden file\n", got.v[i].key,
                    got.v[i].what);
            return 1;
        }
        if (want.v[j].hash != got.v[i].hash) {
            fprintf(stderr, "FAIL: first difference at scene/backend/model %s, step %s "
                            "(hash %016" PRIx64 ", golden %016" PRIx64 ")\n",
                    got.v[i].key, got.v[i].what, got.v[i].hash, want.v[j].hash);
            return 1;
        }
        ++checked;
    }
    if (skipped == 0 && checked != want.n) {
        fprintf(stderr, "FAIL: computed %d lines, the golden file has %d\n", checked, want.n);
        return 1;
    }
    printf("%d golden hashes match (%d cases skipped: backend not built)\n", checked, skipped);
    free(got.v);
    free(want.v);
    return skipped ? 77 : 0;   /* ctest: skipped (SKIP_RETURN_CODE) */
}

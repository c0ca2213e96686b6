/* SPDX-License-Identifier: MIT */
/*
 * defsim-bench-features: what an unused feature costs. The same box beam (default 36x12x12 cells,
 * 31104 tets, stable neo-Hookean, x = 0 clamped) is stepped with symplectic Euler (or --backend)
 * in variants that differ in one feature, interleaved round-robin so that machine noise hits all
 * alike; the median time per step of each is compared with the baseline. "zero" variants have the
 * feature present in the scene but with no effect (a damping coefficient of 0, an empty pin list,
 * an extra body of another material without elements, external forces of zero, a force callback or
 * an attachment set and then removed; colliders far away, which the contact broad phase leaves
 * without pairs): the planner must skip them, so their ratio to the baseline is 1 within noise.
 * "on" variants show what the feature costs when used. The stability watchdog (core.watchdog) is
 * on in every variant but the "watchdog off" ones: baseline over "watchdog off" is what the
 * watchdog costs when nothing trips, and the neo-Hookean pair the same with its inversion check.
 * --cpu measures process CPU time instead of the monotonic clock: on a shared, oversubscribed
 * machine, time spent waiting for a core then does not count.
 *
 *   defsim-bench-features [--n N] [--steps S] [--rounds R] [--threads T] [--only WORD] [--cpu]
 *                         [--backend NAME]
 *
 * --only keeps the baseline and the variants whose name contains WORD ("colliders"); --cpu
 * times with process CPU time instead of the monotonic clock (for a loaded machine); --backend
 * steps every variant with another backend than symplectic_euler (e.g. newton_cholmod, whose
 * colliders get the barrier instead of the penalty).
 *
 * The body_contact variants (issue 13; --only body_contact) run newton_cholmod at h = 1e-3 on
 * two clamped beams of --n-implicit N (default 4) placed 2 m apart, body contact off (their
 * baseline), on, and on with self-contact off: nothing is ever near, so the ratio is what the
 * broad phase costs when it finds nothing (target: within 10 %). They also print the candidate
 * pairs and the share of the step in the body-contact broad phase, CCD and evaluation.
 *
 *   defsim-bench-features --cloth N [--threads T]
 *
 * instead drops an N x N cloth (1 m, springs) on a sphere for 1.5 s at h = 0.01 with
 * newton_cholmod (barrier contact) and symplectic_euler (penalty contact, auto_substep,
 * friction_eps_v 0.02 m/s) and
 * prints the time per step and the share of it spent in contact (broad phase, CCD, contact
 * energy, forces and blocks).
 */
#include "bench_beam.h"
#include "cli.h"
#include "clock.h"
#include "stat.h"

#include <defsim/defsim.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct variant {
    const char *name;
    double gravity;          /* m/s^2 along -y */
    double alpha, beta;      /* Rayleigh damping of the beam */
    int pins;                /* 0: none, 1: clamp x = 0, 2: pin then unpin (empty set) */
    int extra_body;          /* a one-vertex body of another material, no elements */
    int springs;             /* a spring body beside the beam: -1 none, 0 with zero springs... */
    int external;            /* held external forces: 0 none, 1 all zero, 2 on (0.1 N down) */
    int callback;            /* force callback: 0 none, 1 set then cleared, 2 on */
    int attachments;         /* 0 none, 1 one added then removed, 2 on (free end to a point) */
    int watchdog_off;        /* core.watchdog = false */
    int neohookean;          /* the beam is neo-Hookean instead of stable neo-Hookean */
    int colliders;           /* 0 none, 1 four far away (100 m), 2 a sphere under the free end */
    /* Body contact (issue 13): newton_cholmod (h = 1e-3) with a second beam 2 m beside the
     * first, compared with the variant marked own_base before it. */
    int implicit;            /* newton_cholmod instead of symplectic_euler */
    int own_base;            /* the baseline of the variants after it */
    int body_contact;        /* 0 off, 1 on, 2 on with self_contact 0 on both beams */
} variant;

static const variant variants[] = {
    {.name = "baseline: gravity, clamp", .gravity = 9.81, .pins = 1},
    {.name = "mass damping zero", .gravity = 9.81, .alpha = 0.0, .pins = 1},
    {.name = "mass damping on (alpha 1)", .gravity = 9.81, .alpha = 1.0, .pins = 1},
    {.name = "stiffness damping zero", .gravity = 9.81, .beta = 0.0, .pins = 1},
    {.name = "stiffness damping on (beta 1e-3)", .gravity = 9.81, .beta = 1e-3, .pins = 1},
    {.name = "gravity zero", .gravity = 0.0, .pins = 1},
    {.name = "pins: none", .gravity = 9.81, .pins = 0},
    {.name = "pins: pinned then unpinned", .gravity = 9.81, .pins = 2},
    {.name = "other material present, no tets", .gravity = 9.81, .pins = 1, .extra_body = 1},
    {.name = "spring body beside (1 spring)", .gravity = 9.81, .pins = 1, .springs = 1},
    {.name = "external forces zero", .gravity = 9.81, .pins = 1, .external = 1},
    {.name = "external forces on", .gravity = 9.81, .pins = 1, .external = 2},
    {.name = "no callback (set, then cleared)", .gravity = 9.81, .pins = 1, .callback = 1},
    {.name = "callback on (constant force)", .gravity = 9.81, .pins = 1, .callback = 2},
    {.name = "no attachments (added, then removed)", .gravity = 9.81, .pins = 1,
     .attachments = 1},
    {.name = "attachments on (10, free end to points)", .gravity = 9.81, .pins = 1,
     .attachments = 2},
    {.name = "watchdog off (core.watchdog = false)", .gravity = 9.81, .pins = 1,
     .watchdog_off = 1},
    {.name = "neo-Hookean beam, watchdog on", .gravity = 9.81, .pins = 1, .neohookean = 1},
    {.name = "neo-Hookean beam, watchdog off", .gravity = 9.81, .pins = 1, .neohookean = 1,
     .watchdog_off = 1},
    {.name = "colliders far away (3 spheres, 1 plane)", .gravity = 9.81, .pins = 1,
     .colliders = 1},
    {.name = "collider on (sphere under the free end)", .gravity = 9.81, .pins = 1,
     .colliders = 2},
    {.name = "body_contact off, newton_cholmod, 2 beams 2 m apart (baseline of the next two)",
     .gravity = 9.81, .pins = 1, .implicit = 1, .own_base = 1},
    {.name = "body_contact on, 2 beams 2 m apart", .gravity = 9.81, .pins = 1, .implicit = 1,
     .body_contact = 1},
    {.name = "body_contact on, self_contact 0, 2 beams 2 m apart", .gravity = 9.81, .pins = 1,
     .implicit = 1, .body_contact = 2},
};
enum { NV = sizeof variants / sizeof variants[0] };

static int use_cpu;   /* --cpu */
static const char *backend_name = "symplectic_euler";   /* --backend */

static double now(void)
{
    return use_cpu ? tools_cpu_now() : tools_now();
}

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* A force callback: 0.1 N down on every vertex. */
static int push_down(void *user, const double *x, const double *v, double t, int32_t n, double *f)
{
    (void)user; (void)x; (void)v; (void)t;
    for (int32_t i = 0; i < n; ++i) f[3 * (int64_t)i + 1] -= 0.1;
    return 0;
}

/* The host's coupling terms of a variant: held forces, callback, attachments. */
static int couple(defsim_world *w, const variant *v, const defsim_mesh *m, defsim_body_id b)
{
    const int n = defsim_world_vertex_count(w);
    if (v->external) {
        double *f = calloc(3 * (size_t)n, sizeof *f);
        if (!f) return -1;
        for (int i = 0; i < n && v->external == 2; ++i) f[3 * i + 1] = -0.1;
        int st = defsim_world_set_external_forces(w, f, n);
        free(f);
        if (st != DEFSIM_OK) return -1;
    }
    if (v->callback && defsim_world_set_force_callback(w, push_down, NULL, NULL) != DEFSIM_OK)
        return -1;
    if (v->callback == 1 && defsim_world_set_force_callback(w, NULL, NULL, NULL) != DEFSIM_OK)
        return -1;
    double xmax = 0.0;
    for (int i = 0; i < m->vertex_count; ++i)
        if (m->positions[3 * i] > xmax) xmax = m->positions[3 * i];
    for (int i = 0, k = 0; i < m->vertex_count && v->attachments && k < 10; ++i) {
        if (m->positions[3 * i] < xmax) continue;   /* the free end */
        defsim_attachment_def d;
        defsim_attachment_def_init(&d, sizeof d);
        d.body = b;
        d.vertex = i;
        memcpy(d.target, m->positions + 3 * i, sizeof d.target);
        defsim_attachment_id id;
        if (defsim_world_add_attachment(w, &d, &id) != DEFSIM_OK) return -1;
        if (v->attachments == 1) {
            if (defsim_world_remove_attachment(w, id) != DEFSIM_OK) return -1;
            break;
        }
        ++k;
    }
    return 0;
}

/* A world of `backend` with gravity -gy along y, or NULL. */
static defsim_world *new_world(const char *backend, double gy, int threads)
{
    defsim_world_def wd;
    defsim_world_def_init(&wd, sizeof wd);
    wd.backend = backend;
    wd.gravity[1] = -gy;
    wd.num_threads = threads;
    defsim_world *w = NULL;
    return defsim_world_create(&wd, &w) == DEFSIM_OK ? w : NULL;
}

/* The beam again, 2 m beside the first (z + 3 m), for body contact with nothing near. */
static int second_beam(defsim_world *w, const defsim_mesh *m, const defsim_material *mat,
                       int self_contact)
{
    defsim_mesh far = *m;
    far.positions = malloc(3 * (size_t)m->vertex_count * sizeof *far.positions);
    if (!far.positions) return -1;
    for (int i = 0; i < 3 * m->vertex_count; ++i)
        far.positions[i] = m->positions[i] + (i % 3 == 2 ? 3.0 : 0.0);
    defsim_body_id b;
    int st = bench_add_beam(w, &far, mat, 1, &b);
    free(far.positions);
    if (st == DEFSIM_OK && !self_contact)
        st = defsim_body_set_collision(w, b, 0, 1u, 0xFFFFFFFFu);
    return st == DEFSIM_OK ? 0 : -1;
}

static defsim_world *make(const variant *v, const defsim_mesh *m, int threads)
{
    defsim_world *w = new_world(v->implicit ? "newton_cholmod" : backend_name, v->gravity,
                                threads);
    if (!w) return NULL;
    defsim_material mat;
    defsim_material_init(&mat, sizeof mat,
                         v->neohookean ? DEFSIM_MODEL_NEOHOOKEAN : DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    mat.mass_damping = v->alpha;
    mat.stiffness_damping = v->beta;
    defsim_body_id b;
    if (bench_add_beam(w, m, &mat, v->pins >= 1, &b) != DEFSIM_OK) return NULL;
    if (v->implicit) {
        if (second_beam(w, m, &mat, v->body_contact != 2) != 0) return NULL;
        if (v->body_contact == 2 && defsim_body_set_collision(w, b, 0, 1u, 0xFFFFFFFFu) != DEFSIM_OK)
            return NULL;
        if (v->body_contact && defsim_world_set_option(w, "core.body_contact", "true") != DEFSIM_OK)
            return NULL;
    }
    if (v->pins == 2) {
        int32_t *pins = malloc((size_t)m->vertex_count * sizeof *pins);
        if (!pins) return NULL;
        defsim_body_unpin(w, b, pins, bench_clamp_list(m, pins));
        free(pins);
    }
    if (v->extra_body) {
        defsim_body_def eb;
        defsim_body_def_init(&eb, sizeof eb);
        double p[3] = {10, 0, 0}, mass = 1.0;
        eb.rest_positions = p;
        eb.vertex_count = 1;
        eb.vertex_mass = &mass;
        defsim_material_init(&eb.material, sizeof eb.material, DEFSIM_MODEL_COROTATED);
        if (defsim_world_add_body(w, &eb, NULL) != DEFSIM_OK) return NULL;
    }
    if (v->springs) {
        defsim_body_def sb;
        defsim_body_def_init(&sb, sizeof sb);
        double p[6] = {10, 0, 0, 11, 0, 0};
        int32_t s[2] = {0, 1};
        sb.rest_positions = p;
        sb.vertex_count = 2;
        sb.springs = s;
        sb.spring_count = 1;
        defsim_material_init(&sb.material, sizeof sb.material, DEFSIM_MODEL_SPRING);
        if (defsim_world_add_body(w, &sb, NULL) != DEFSIM_OK) return NULL;
    }
    if (couple(w, v, m, b) != 0) return NULL;
    if (v->watchdog_off && defsim_world_set_option(w, "core.watchdog", "false") != DEFSIM_OK)
        return NULL;
    /* Colliders far away: the broad phase must make them free. One near: contact's cost. */
    for (int k = 0; k < (v->colliders == 1 ? 4 : v->colliders == 2 ? 1 : 0); ++k) {
        defsim_collider_def cd;
        defsim_collider_def_init(&cd, sizeof cd);
        cd.shape = k < 3 ? DEFSIM_SHAPE_SPHERE : DEFSIM_SHAPE_PLANE;
        cd.radius = 0.5;
        if (v->colliders == 1) cd.position[k < 3 ? k : 1] = k < 3 ? 100.0 : -100.0;
        else cd.position[0] = 2.5, cd.position[1] = -0.5 - 1e-3;   /* 1 mm under the beam */
        if (defsim_world_add_collider(w, &cd, NULL) != DEFSIM_OK) return NULL;
    }
    return w;
}

static void passes(uint32_t p, char *out, size_t n)
{
    static const char *names[] = {"springs", "stvk", "corotated", "neohookean", "snh", "gravity",
                                  "mass_damping", "stiffness_damping", "pins", "hessian", "energy",
                                  "external", "callback", "attachments", "driven_pins"};
    out[0] = '\0';
    for (int i = 0; i < 15; ++i)
        if (p & (1u << i)) {
            strncat(out, names[i], n - strlen(out) - 1);
            strncat(out, " ", n - strlen(out) - 1);
        }
}

/* The cloth-on-sphere scene of test_contact, timed. */
static int cloth(int nu, const char *backend, int threads)
{
    defsim_world *w = new_world(backend, 9.81, threads);
    if (!w) {
        printf("| %s | not available | | |\n", backend);
        return 0;
    }
    char opt[96];
    snprintf(opt, sizeof opt, "%s.max_iterations", backend);
    defsim_world_set_option(w, opt, "200");   /* symplectic_euler has none: ignored */
    /* Newton's last digits converge slowly against the barrier (docs/contact.md) */
    snprintf(opt, sizeof opt, "%s.tolerance", backend);
    defsim_world_set_option(w, opt, "1e-5");
    /* Explicit friction's damping rate 2 mu lam / (m eps_v) bounds the explicit step: with the
     * default eps_v (1e-3 m/s) symplectic_euler needs thousands of substeps per step here. */
    if (!strcmp(backend, "symplectic_euler")) {
        defsim_world_set_option(w, "core.auto_substep", "1");
        defsim_world_set_option(w, "core.friction_eps_v", "0.02");
    }
    const double origin[3] = {-0.5, 0.4, -0.5}, u[3] = {1, 0, 0}, v[3] = {0, 0, 1};
    defsim_mesh m;
    memset(&m, 0, sizeof m);
    m.size = sizeof m;
    if (defsim_mesh_cloth(origin, u, v, nu, nu, &m) != DEFSIM_OK) return -1;
    defsim_body_def bd;
    defsim_body_def_init(&bd, sizeof bd);
    defsim_material_init(&bd.material, sizeof bd.material, DEFSIM_MODEL_SPRING);
    bd.material.stiffness = 2e3;   /* the cloth of test_contact: 1 kg, springs of 2 kN/m */
    bd.material.vertex_mass = 1.0 / ((nu + 1) * (nu + 1));
    bd.material.mass_damping = 1.0;
    bd.rest_positions = m.positions, bd.vertex_count = m.vertex_count;
    bd.springs = m.springs, bd.spring_count = m.spring_count;
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    cd.shape = DEFSIM_SHAPE_SPHERE;
    cd.radius = 0.3;
    cd.friction = 0.5;
    if (defsim_world_add_body(w, &bd, NULL) != DEFSIM_OK ||
        defsim_world_add_collider(w, &cd, NULL) != DEFSIM_OK)
        return -1;
    defsim_mesh_free(&m);
    const int steps = 150;
    for (int k = 0; k < steps; ++k)
        if (defsim_world_step(w, 0.01) != DEFSIM_OK) {
            printf("| %s | step %d failed: %s | | |\n", backend, k, defsim_world_last_error(w));
            defsim_world_destroy(w);
            return 0;
        }
    double t, broad, ccd, eval, it = 0.0, sub = 0.0;
    defsim_world_stat(w, "time_step", &t);
    defsim_world_stat(w, "contact.time_broad_phase", &broad);
    defsim_world_stat(w, "contact.time_ccd", &ccd);
    defsim_world_stat(w, "contact.time_eval", &eval);
    it = tools_backend_stat(w, "newton_iterations");
    defsim_world_stat(w, "substeps", &sub);
    printf("| %s | %.2f | %.1f %% | %.1f | %.0f |\n", backend, 1e3 * t / steps,
           100.0 * (broad + ccd + eval) / t, it / steps, sub / steps);
    defsim_world_destroy(w);
    return 0;
}

static void usage(FILE *f)
{
    fprintf(f, "usage: defsim-bench-features [--n N] [--steps S] [--rounds R] [--threads T]\n"
               "                             [--only WORD] [--cpu] [--backend NAME]\n"
               "                             [--n-implicit N]\n"
               "       defsim-bench-features --cloth N [--threads T]\n"
               "What an unused feature costs: the box beam stepped in variants that differ in\n"
               "one feature, round-robin; median time per step against the baseline.\n"
               "  --n N           beam cells across (default 12: 31104 tets)\n"
               "  --steps S       steps per variant and round (default 20)\n"
               "  --rounds R      rounds, 1..99 (default 7)\n"
               "  --threads T     OpenMP threads (default 1; 0: OpenMP's default)\n"
               "  --only WORD     the baseline and the variants whose name contains WORD\n"
               "  --cpu           time with process CPU time (for a loaded machine)\n"
               "  --backend NAME  step every variant with NAME (default symplectic_euler)\n"
               "  --n-implicit N  cells of the body_contact variants' beams (default 4)\n"
               "  --cloth N       instead: an N x N cloth dropped on a sphere, time per step\n"
               "                  and contact's share, newton_cholmod and symplectic_euler\n"
               "  -h, --help      this text\n"
               "  --version       the library's version\n");
}

int main(int argc, char **argv)
{
    int n = 12, steps = 20, rounds = 7, threads = 1, cloth_n = 0, n_implicit = 4;
    const char *only = NULL;
    static const cli_tool tool = {"defsim-bench-features", usage, NULL, ""};
    const cli_opt opts[] = {
        {"n", CLI_INT, &n, 1, 1000}, {"steps", CLI_INT, &steps, 1, 1e9},
        {"rounds", CLI_INT, &rounds, 1, 99}, {"threads", CLI_INT, &threads, 0, 4096},
        {"only", CLI_STRING, &only, 0, 0}, {"cloth", CLI_INT, &cloth_n, 1, 100000},
        {"backend", CLI_STRING, &backend_name, 0, 0}, {"n-implicit", CLI_INT, &n_implicit, 1, 1000},
        {"cpu", CLI_FLAG, &use_cpu, 0, 0}, {0}};
    int first;
    const int parsed = cli_parse(&tool, opts, argc, argv, &first);
    if (parsed >= 0) return parsed;
    if (first < argc) return cli_fail(&tool, "no operands expected (got %s)", argv[first]);
    if (cloth_n > 0) {
        printf("%dx%d cloth on a sphere, 150 steps of 0.01 s, %d threads\n\n", cloth_n, cloth_n,
               threads);
        printf("| backend | ms/step | contact share | Newton its/step | substeps/step |\n"
               "|---|---:|---:|---:|---:|\n");
        return cloth(cloth_n, "newton_cholmod", threads) || cloth(cloth_n, "symplectic_euler", threads);
    }
    defsim_mesh m, mi;
    if (bench_beam_mesh(n, &m) != DEFSIM_OK || bench_beam_mesh(n_implicit, &mi) != DEFSIM_OK)
        return 1;
    defsim_world *w[NV] = {0};
    for (int v = 0; v < NV; ++v)
        if ((v == 0 || !only || strstr(variants[v].name, only)) &&
            !(w[v] = make(&variants[v], variants[v].implicit ? &mi : &m, threads))) {
            fprintf(stderr, "variant %s: %s\n", variants[v].name, defsim_last_error());
            return 1;
        }
    double t[NV][100];
    for (int v = 0; v < NV; ++v)
        if (w[v]) defsim_world_step(w[v], variants[v].implicit ? 1e-3 : 1e-5);   /* plan, warm up */
    for (int r = 0; r < rounds; ++r)
        for (int v = 0; v < NV; ++v) {
            if (!w[v]) continue;
            const double h = variants[v].implicit ? 1e-3 : 1e-5;
            double t0 = now();
            for (int s = 0; s < steps; ++s)
                if (defsim_world_step(w[v], h) != DEFSIM_OK) {
                    fprintf(stderr, "variant %s: %s\n", variants[v].name,
                            defsim_world_last_error(w[v]));
                    return 1;
                }
            t[v][r] = (now() - t0) / steps;
        }
    printf("%s, %d tets (newton_cholmod variants: 2 x %d tets, h = 1e-3 s), %d threads, median "
           "of %d rounds x %d steps, variants interleaved, %s\n\n", backend_name, m.tet_count,
           mi.tet_count, threads, rounds, steps,
           use_cpu ? "process CPU time" : "monotonic clock");
    printf("| variant | ms/step | vs baseline | passes run |\n|---|---:|---:|---|\n");
    double base = 0;
    char notes[NV][192] = {{0}};
    for (int v = 0; v < NV; ++v) {
        if (!w[v]) continue;
        qsort(t[v], (size_t)rounds, sizeof(double), cmp);
        double med = t[v][rounds / 2];
        if (v == 0 || variants[v].own_base) base = med;
        defsim_stats s = {.size = sizeof s};
        defsim_world_stats(w[v], &s);
        char p[256];
        passes(s.passes, p, sizeof p);
        printf("| %s | %.3f | %.3f | %s|\n", variants[v].name, 1e3 * med, med / base, p);
        if (variants[v].body_contact) {
            /* nothing is near: what the broad phase and CCD cost, of the whole step */
            double cand = 0, broad = 0, ccd = 0, eval = 0, total = 1;
            defsim_world_stat(w[v], "contact.body_candidates", &cand);
            defsim_world_stat(w[v], "contact.time_body_broad", &broad);
            defsim_world_stat(w[v], "contact.time_body_ccd", &ccd);
            defsim_world_stat(w[v], "contact.time_body_eval", &eval);
            defsim_world_stat(w[v], "time_step", &total);
            snprintf(notes[v], sizeof notes[v], "%s: candidate pairs %.0f; body broad phase "
                     "%.2f %%, CCD %.2f %%, evaluation %.2f %% of the step", variants[v].name,
                     cand, 100 * broad / total, 100 * ccd / total, 100 * eval / total);
        }
        defsim_world_destroy(w[v]);
    }
    for (int v = 0; v < NV; ++v)
        if (notes[v][0]) printf("\n%s", notes[v]);
    printf("\n");
    defsim_mesh_free(&m);
    defsim_mesh_free(&mi);
    return 0;
}

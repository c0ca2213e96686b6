/* SPDX-License-Identifier: MIT */
/*
 * Contact with thickness (defsim_body_def.contact_thickness; docs/body-contact.md "Thickness"):
 * two cloth layers of thickness t (shells, and mass-spring cloth) dropped flat on a ground plane
 * with newton_cholmod at h = 1/60 s, body contact on. Checked at every step from the positions
 * alone, independently of the library's distance code (tests/common/exact_geom.c's triangle
 * distances, the plane's distance as the height):
 *   - the layers never come closer than t (the sum of their half-thicknesses), no layer comes
 *     closer than t to itself (vertex-disjoint triangles), and no vertex closer than t / 2 to
 *     the plane;
 *   - at rest, every vertex of the upper layer lies within [t, t + dhat] of the lower layer and
 *     every vertex of the lower layer within [t / 2, t / 2 + dhat] of the plane, and the contact
 *     forces carry the weight: the upper layer's sum to its weight, all of them to both layers'
 *     weight, within 1e-3;
 *   - a fast drop (both layers at 5 m/s onto the plane, h = 1/60 s) keeps the same separations
 *     at every step;
 *   - friction at a distance: an undamped shell sliding at 2 m/s on the plane (mu 0.3) slows at
 *     Coulomb's mu g within 1 %, with t = 4 mm as with t = 0;
 *   - a def without the field (an older header's size) and thickness 0 give the same bits; a
 *     checkpoint of a thick world continues bit for bit; bad values and a start closer than the
 *     thickness are refused.
 */
#include "exact_geom.h"
#include "mesh_body.h"
#include "test_util.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { CELLS = 8, NV = (CELLS + 1) * (CELLS + 1) };
static const double H = 1.0 / 60.0;
static const double G = 9.81;

typedef struct layers {
    defsim_world *w;
    defsim_mesh m;          /* the cloth mesh of both layers (its triangles are theirs) */
    defsim_body_id id[2];   /* lower, upper */
    double mass[2];         /* kg */
    double dhat;            /* m */
} layers;

/* A 0.5 m square cloth of CELLS x CELLS cells in the plane y = `y`, thickness t: a StVK shell
 * (E t 1000 N/m, D 1e-3 N m, 0.4 kg/m^2) or a mass-spring cloth (its springs at 200 N/m, 1.2 g
 * per vertex), with mass damping `damping` (1/s). */
static defsim_body_id add_layer(layers *L, double y, double t, int shell, double vy,
                                double damping, size_t def_size)
{
    double rest[3 * NV], v[3 * NV];
    memcpy(rest, L->m.positions, sizeof rest);
    for (int i = 0; i < NV; ++i) {
        rest[3 * i + 1] += y;
        v[3 * i] = v[3 * i + 2] = 0.0;
        v[3 * i + 1] = vy;
    }
    defsim_body_def d = shell ? test_shell_body(&L->m) : test_mesh_body(&L->m, DEFSIM_MODEL_SPRING);
    d.rest_positions = rest;
    d.initial_velocities = v;
    if (shell) {
        d.shell_membrane = DEFSIM_SHELL_MEMBRANE_STVK;
        d.shell_youngs_modulus = 1e6;
        d.shell_poisson_ratio = 0.3;
        d.shell_thickness = 1e-3;
        d.shell_areal_density = 0.4;
        d.shell_bending_rigidity = 1e-3;
    } else {
        d.triangles = L->m.triangles;
        d.triangle_count = L->m.triangle_count;
        d.spring_kinds = L->m.spring_kinds;
        d.material.stiffness = 200.0;
        d.material.vertex_mass = 1.2e-3;
    }
    d.material.mass_damping = damping;
    d.friction = 0.3;
    d.contact_thickness = t;
    if (def_size < sizeof d) d.size = (uint32_t)def_size;
    defsim_body_id id;
    const defsim_status st = defsim_world_add_body(L->w, &d, &id);
    if (st != DEFSIM_OK) fail_msg("add_body: %s", defsim_world_last_error(L->w));
    return id;
}

/* L empty but for the world w and the cloth mesh of its layers (0.5 m square, CELLS x CELLS). */
static void init_layers(layers *L, defsim_world *w)
{
    memset(L, 0, sizeof *L);
    L->w = w;
    L->m.size = sizeof L->m;
    const double o[3] = {-0.25, 0.0, -0.25}, u[3] = {0.5, 0.0, 0.0}, v[3] = {0.0, 0.0, 0.5};
    TU_OK(defsim_mesh_cloth(o, u, v, CELLS, CELLS, &L->m));
    assert_int_equal(L->m.vertex_count, NV);
}

/* Two layers at heights y0 < y1 above a ground plane (friction 0.3) at y = 0, both moving at vy;
 * def_size: the body defs' size (sizeof defsim_body_def, or an older one). */
static void make_layers2(layers *L, double t0, double t1, int shell, double y0, double y1,
                         double vy, size_t def_size);

static void make_layers(layers *L, double t, int shell, double y0, double y1, double vy,
                        size_t def_size)
{
    make_layers2(L, t, t, shell, y0, y1, vy, def_size);
}

/* The same with thickness t0 for the lower layer and t1 for the upper. */
static void make_layers2(layers *L, double t0, double t1, int shell, double y0, double y1,
                         double vy, size_t def_size)
{
    init_layers(L, tu_implicit_world("newton_cholmod", -G, 1, 1e-9, 200, DEFSIM_PROJECTION_CLAMP));
    TU_OK(defsim_world_set_option(L->w, "core.body_contact", "true"));
    L->id[0] = add_layer(L, y0, t0, shell, vy, 0.5, def_size);
    L->id[1] = add_layer(L, y1, t1, shell, vy, 0.5, def_size);
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    cd.friction = 0.3;
    TU_OK(defsim_world_add_collider(L->w, &cd, NULL));
    double mass[2 * NV];
    TU_OK(defsim_world_get_masses(L->w, mass, 2 * NV));
    for (int b = 0; b < 2; ++b) {
        L->mass[b] = 0.0;
        for (int i = 0; i < NV; ++i) L->mass[b] += mass[NV * b + i];
    }
    /* dhat: core.contact_dhat (1e-3) of the rest positions' bounding box diagonal */
    const double dy = y1 - y0;
    L->dhat = 1e-3 * sqrt(0.5 * 0.5 + 0.5 * 0.5 + dy * dy);
}

static void free_layers(layers *L)
{
    defsim_world_destroy(L->w);
    defsim_mesh_free(&L->m);
}

/* What the positions say, independently of the library's distances. */
typedef struct sep {
    double between;   /* least distance between the layers' triangles */
    double self;      /* least distance between vertex-disjoint triangles of one layer */
    double ground;    /* least height of a vertex (the plane is y = 0) */
    double up_lo, up_hi;   /* least and largest distance of an upper vertex to the lower layer */
    double lo_lo, lo_hi;   /* least and largest height of a lower vertex */
} sep;

static const double *vx(const double *x, int b, int i) { return x + 3 * (NV * b + i); }

static sep measure(const layers *L, const double *x)
{
    sep s = {INFINITY, INFINITY, INFINITY, INFINITY, -INFINITY, INFINITY, -INFINITY};
    const int32_t nt = L->m.triangle_count, *tr = L->m.triangles;
    for (int b = 0; b < 2; ++b)
        for (int i = 0; i < NV; ++i) s.ground = fmin(s.ground, vx(x, b, i)[1]);
    for (int i = 0; i < NV; ++i) {
        s.lo_lo = fmin(s.lo_lo, vx(x, 0, i)[1]);
        s.lo_hi = fmax(s.lo_hi, vx(x, 0, i)[1]);
        double d = INFINITY;
        for (int32_t f = 0; f < nt; ++f)
            d = fmin(d, eg_point_tri_distance(vx(x, 1, i), vx(x, 0, tr[3 * f]),
                                              vx(x, 0, tr[3 * f + 1]), vx(x, 0, tr[3 * f + 2])));
        s.up_lo = fmin(s.up_lo, d);
        s.up_hi = fmax(s.up_hi, d);
    }
    /* every triangle pair whose boxes are not already farther apart than the least distance
     * found so far (a lower bound of their distance: the minimum stays exact) */
    double *lo = malloc(3 * 2 * (size_t)nt * sizeof *lo), *hi = malloc(3 * 2 * (size_t)nt * sizeof *hi);
    for (int b = 0; b < 2; ++b)
        for (int32_t f = 0; f < nt; ++f)
            for (int k = 0; k < 3; ++k) {
                double l = INFINITY, h = -INFINITY;
                for (int p = 0; p < 3; ++p) {
                    l = fmin(l, vx(x, b, tr[3 * f + p])[k]);
                    h = fmax(h, vx(x, b, tr[3 * f + p])[k]);
                }
                lo[3 * (nt * b + f) + k] = l;
                hi[3 * (nt * b + f) + k] = h;
            }
    for (int32_t f = 0; f < nt; ++f) {
        const int32_t *a = tr + 3 * f;
        for (int32_t g = 0; g < nt; ++g) {
            const int32_t *c = tr + 3 * g;
            for (int b = -1; b < 2; ++b) {   /* -1: lower f against upper g; 0, 1: one layer */
                if (b >= 0 && g <= f) continue;
                const int ba = b < 0 ? 0 : b, bb = b < 0 ? 1 : b;
                double *best = b < 0 ? &s.between : &s.self, gap = 0.0;
                for (int k = 0; k < 3; ++k)
                    gap = fmax(gap, fmax(lo[3 * (nt * bb + g) + k] - hi[3 * (nt * ba + f) + k],
                                         lo[3 * (nt * ba + f) + k] - hi[3 * (nt * bb + g) + k]));
                if (gap >= *best) continue;
                if (b >= 0) {
                    int shared = 0;
                    for (int p = 0; p < 3; ++p)
                        for (int q = 0; q < 3; ++q) shared |= a[p] == c[q];
                    if (shared) continue;
                }
                *best = fmin(*best, eg_tri_tri_distance(vx(x, ba, a[0]), vx(x, ba, a[1]),
                                                        vx(x, ba, a[2]), vx(x, bb, c[0]),
                                                        vx(x, bb, c[1]), vx(x, bb, c[2])));
            }
        }
    }
    free(lo);
    free(hi);
    return s;
}

/* Steps n times, checking the separations after each step (between the layers xi, within a
 * layer ts, to the plane tg); returns the last measure. */
static sep run_checked3(layers *L, double xi, double ts, double tg, int n, sep *worst)
{
    double *x = malloc(3 * 2 * NV * sizeof *x);
    sep s = {0};
    for (int k = 0; k < n; ++k) {
        const defsim_status st = defsim_world_step(L->w, H);
        if (st != DEFSIM_OK) fail_msg("step %d: %s", k, defsim_world_last_error(L->w));
        TU_OK(defsim_world_get_positions(L->w, x, 2 * NV));
        s = measure(L, x);
        if (!(s.between > xi && s.self > ts && s.ground > tg))
            fail_msg("step %d: between %.9g self %.9g ground %.9g, offsets %g %g %g", k,
                     s.between, s.self, s.ground, xi, ts, tg);
        worst->between = fmin(worst->between, s.between);
        worst->self = fmin(worst->self, s.self);
        worst->ground = fmin(worst->ground, s.ground);
    }
    free(x);
    return s;
}

static sep run_checked(layers *L, double t, int n, sep *worst)
{
    return run_checked3(L, t, t, 0.5 * t, n, worst);
}

/* The contact forces' vertical sums on the lower and upper layer (N). */
static void contact_lift(const layers *L, double lift[2])
{
    double *f = malloc(3 * 2 * NV * sizeof *f);
    TU_OK(defsim_world_get_contact_forces(L->w, f, 2 * NV));
    lift[0] = lift[1] = 0.0;
    for (int b = 0; b < 2; ++b)
        for (int i = 0; i < NV; ++i) lift[b] += f[3 * (NV * b + i) + 1];
    free(f);
}

/* Two layers of thickness t0 (lower) and t1 1 cm apart (the lower 1 cm above the plane) fall and
 * settle over 2 s: the layers keep t = (t0 + t1) / 2, the lower one t0 / 2 from the plane, each
 * layer its own thickness from itself. */
static void stack_at_rest(int shell, double t0, double t1)
{
    layers L;
    const double t = 0.5 * (t0 + t1);
    make_layers2(&L, t0, t1, shell, 0.01 + t, 0.02 + 2.0 * t, 0.0, sizeof(defsim_body_def));
    sep worst = {INFINITY, INFINITY, INFINITY, 0, 0, 0, 0};
    const sep s = run_checked3(&L, t, fmin(t0, t1), 0.5 * t0, 120, &worst);
    double lift[2];
    contact_lift(&L, lift);
    const double w0 = L.mass[0] * G, w1 = L.mass[1] * G;
    const double e_up = fabs(lift[1] - w1) / w1, e_all = fabs(lift[0] + lift[1] - w0 - w1) / (w0 + w1);
    print_message("%s, t = %g m (lower %g, upper %g), dhat %.3g m: over 120 steps least distance between the layers "
                  "%.6g m, within a layer %.4g m, to the plane %.6g m; at rest the upper layer's "
                  "vertices lie %.6g to %.6g m from the lower layer (band [%g, %.6g]), the "
                  "lower's %.6g to %.6g m above the plane (band [%g, %.6g]); contact forces: "
                  "upper layer %.6g N for its weight %.6g N (%.2e), all %.6g N for %.6g N "
                  "(%.2e)\n",
                  shell ? "shells" : "springs", t, t0, t1, L.dhat, worst.between, worst.self,
                  worst.ground, s.up_lo, s.up_hi, t, t + L.dhat, s.lo_lo, s.lo_hi, 0.5 * t0,
                  0.5 * t0 + L.dhat, lift[1], w1, e_up, lift[0] + lift[1], w0 + w1, e_all);
    assert_true(s.up_lo >= t && s.up_hi <= t + L.dhat);
    assert_true(s.lo_lo >= 0.5 * t0 && s.lo_hi <= 0.5 * t0 + L.dhat);
    assert_true(e_up < 1e-3 && e_all < 1e-3);
    free_layers(&L);
}

static void test_stack_shells(void **state)
{
    (void)state;
    stack_at_rest(1, 5e-3, 5e-3);
}

/* Layers of different thickness: 6 mm below, 2 mm above, so 4 mm between them and 3 mm to the
 * plane (each body brings half its own). */
static void test_stack_mixed(void **state)
{
    (void)state;
    stack_at_rest(1, 6e-3, 2e-3);
}

static void test_stack_springs(void **state)
{
    (void)state;
    stack_at_rest(0, 5e-3, 5e-3);
}

/* Both layers thrown at the plane at 5 m/s from 0.1 and 0.13 m (8.3 cm per step of 1/60 s):
 * no step brings them closer than t, nor the lower one closer than t / 2 to the plane. */
static void test_fast_drop(void **state)
{
    (void)state;
    const double t = 5e-3;
    for (int shell = 1; shell >= 0; --shell) {
        layers L;
        make_layers(&L, t, shell, 0.1, 0.13, -5.0, sizeof(defsim_body_def));
        sep worst = {INFINITY, INFINITY, INFINITY, 0, 0, 0, 0};
        (void)run_checked(&L, t, 45, &worst);
        print_message("fast drop (%s, 5 m/s, h = 1/60 s, t = %g m): over 45 steps least distance "
                      "between the layers %.6g m, within a layer %.4g m, to the plane %.6g m\n",
                      shell ? "shells" : "springs", t, worst.between, worst.self, worst.ground);
        free_layers(&L);
    }
}

/* Collider contact's penalty (explicit backends) takes the same offset: one mass-spring cloth of
 * t = 5 mm on symplectic_euler at 0.9 of its stable step, placed 0.75 dhat beyond its offset
 * t / 2 above the plane (3.03 mm, where no penalty would act without the offset), is pushed up by
 * the penalty (above the band: the penalty is elastic, so it bounces) and over 2000 steps never
 * comes within t / 2 of the plane. (Body contact is refused on explicit backends.) */
static void test_penalty_offset(void **state)
{
    (void)state;
    const double t = 5e-3, dhat = 1e-3 * sqrt(0.5);
    layers L;
    init_layers(&L, tu_world("symplectic_euler", -G, 1));
    L.id[0] = add_layer(&L, 0.5 * t + 0.75 * dhat, t, 0, 0.0, 0.5, sizeof(defsim_body_def));
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    TU_OK(defsim_world_add_collider(L.w, &cd, NULL));
    double h = 0.0;
    TU_OK(defsim_world_stable_step(L.w, &h, NULL));
    h *= 0.9;
    double x[3 * NV], lo = INFINITY, hi = -INFINITY;
    for (int k = 0; k < 2000; ++k) {
        TU_OK(defsim_world_step(L.w, h));
        TU_OK(defsim_world_get_positions(L.w, x, NV));
        for (int i = 0; i < NV; ++i) {
            lo = fmin(lo, x[3 * i + 1]);
            hi = fmax(hi, x[3 * i + 1]);
        }
    }
    print_message("penalty (symplectic_euler, 2000 steps of %.3g us, t = %g m, started at %.6g m): "
                  "heights %.6g to %.6g m (the offset band [%g, %.6g])\n", 1e6 * h, t,
                  0.5 * t + 0.75 * dhat, lo, hi, 0.5 * t, 0.5 * t + dhat);
    assert_true(lo > 0.5 * t);
    assert_true(hi > 0.5 * t + dhat);
    defsim_world_destroy(L.w);
    defsim_mesh_free(&L.m);
}

/* Friction at a distance: one undamped shell of thickness t resting on the plane (friction 0.3)
 * at its offset t / 2, set sliding at 2 m/s along x, slows at Coulomb's mu g = 2.943 m/s^2 (its
 * contact forces carry its weight, friction is mu times them, and at 2 m/s the slip y = v h is
 * far above IPC's smoothing eps_v h) with t = 0 and with t = 4 mm alike, the mass-weighted mean
 * x velocity's drop over 20 steps of 1/60 s within 1 % of mu g T; no vertex comes within t / 2 of
 * the plane while it slides. */
static double slide_deceleration(double t)
{
    const double mu = 0.3, dhat = 1e-3 * sqrt(0.5), v0 = 2.0;
    layers L;
    init_layers(&L, tu_implicit_world("newton_cholmod", -G, 1, 1e-9, 200, DEFSIM_PROJECTION_CLAMP));
    L.id[0] = add_layer(&L, 0.5 * t + 0.5 * dhat, t, 1, 0.0, 0.0, sizeof(defsim_body_def));
    defsim_collider_def cd;
    defsim_collider_def_init(&cd, sizeof cd);
    cd.friction = mu;
    TU_OK(defsim_world_add_collider(L.w, &cd, NULL));
    /* Come to rest on the plane (1 s), then slide. */
    for (int k = 0; k < 60; ++k) TU_OK(defsim_world_step(L.w, H));
    double x[3 * NV], vel[3 * NV], mass[NV];
    TU_OK(defsim_world_get_masses(L.w, mass, NV));
    TU_OK(defsim_world_get_velocities(L.w, vel, NV));
    double vy_rest = 0.0;
    for (int i = 0; i < NV; ++i) {
        vy_rest = fmax(vy_rest, fabs(vel[3 * i + 1]));
        vel[3 * i] = v0;
    }
    TU_OK(defsim_world_set_state(L.w, NULL, vel));
    const int steps = 20;
    double lo = INFINITY;
    for (int k = 0; k < steps; ++k) {
        TU_OK(defsim_world_step(L.w, H));
        TU_OK(defsim_world_get_positions(L.w, x, NV));
        for (int i = 0; i < NV; ++i) lo = fmin(lo, x[3 * i + 1]);
    }
    TU_OK(defsim_world_get_velocities(L.w, vel, NV));
    double p = 0.0, m = 0.0;
    for (int i = 0; i < NV; ++i) {
        p += mass[i] * vel[3 * i];
        m += mass[i];
    }
    const double a = (v0 - p / m) / (steps * H);
    print_message("slide (shell, t = %g m, mu %.1f, from %.1f m/s, at rest to %.2g m/s before): "
                  "deceleration %.6f m/s^2 (mu g %.6f, %+.3f %%), lowest vertex %.6g m "
                  "(offset %.6g)\n", t, mu, v0, vy_rest, a, mu * G,
                  100 * (a - mu * G) / (mu * G), lo, 0.5 * t);
    assert_true(lo > 0.5 * t);
    assert_true(p / m > 0.5 * v0);   /* still sliding at the end */
    free_layers(&L);
    return a;
}

static void test_friction_thick(void **state)
{
    (void)state;
    const double a0 = slide_deceleration(0.0), a1 = slide_deceleration(4e-3);
    assert_true(fabs(a0 - 0.3 * G) < 0.01 * 0.3 * G);
    assert_true(fabs(a1 - 0.3 * G) < 0.01 * 0.3 * G);
}

/* Thickness 0 is the contact without thickness: a def of the size before the field (its
 * thickness then the default 0) and one that sets 0 give the same bits over the fast drop's
 * first 20 steps. */
static void test_zero_is_default(void **state)
{
    (void)state;
    layers a, b;
    make_layers(&a, 0.0, 1, 0.1, 0.13, -5.0, offsetof(defsim_body_def, contact_thickness));
    make_layers(&b, 0.0, 1, 0.1, 0.13, -5.0, sizeof(defsim_body_def));
    double *xa = malloc(3 * 2 * NV * sizeof *xa), *xb = malloc(3 * 2 * NV * sizeof *xb);
    for (int k = 0; k < 20; ++k) {
        TU_OK(defsim_world_step(a.w, H));
        TU_OK(defsim_world_step(b.w, H));
    }
    TU_OK(defsim_world_get_positions(a.w, xa, 2 * NV));
    TU_OK(defsim_world_get_positions(b.w, xb, 2 * NV));
    assert_memory_equal(xa, xb, 3 * 2 * NV * sizeof *xa);
    /* and they have landed: the lower layer within dhat of the plane */
    double lo = INFINITY;
    for (int i = 0; i < NV; ++i) lo = fmin(lo, xa[3 * i + 1]);
    assert_true(lo > 0.0 && lo < a.dhat);
    free(xa);
    free(xb);
    free_layers(&a);
    free_layers(&b);
}

/* A checkpoint holds the thickness (format 11): the stack saved after 30 steps, loaded, steps 20
 * more with the bits of the uninterrupted run, its lower layer resting t / 2 above the plane. */
static void test_checkpoint(void **state)
{
    (void)state;
    layers L;
    make_layers(&L, 5e-3, 1, 0.015, 0.03, 0.0, sizeof(defsim_body_def));
    for (int k = 0; k < 30; ++k) TU_OK(defsim_world_step(L.w, H));
    void *buf = NULL;
    size_t n = 0;
    TU_OK(defsim_world_save_buffer(L.w, &buf, &n));
    assert_int_equal(((const unsigned char *)buf)[8], 11);   /* the format's version */
    defsim_world *w2 = NULL;
    TU_OK(defsim_world_load_buffer(buf, n, NULL, NULL, &w2));
    defsim_buffer_free(buf);
    for (int k = 0; k < 20; ++k) {
        TU_OK(defsim_world_step(L.w, H));
        TU_OK(defsim_world_step(w2, H));
    }
    double *xa = malloc(3 * 2 * NV * sizeof *xa), *xb = malloc(3 * 2 * NV * sizeof *xb);
    TU_OK(defsim_world_get_positions(L.w, xa, 2 * NV));
    TU_OK(defsim_world_get_positions(w2, xb, 2 * NV));
    assert_memory_equal(xa, xb, 3 * 2 * NV * sizeof *xa);
    /* the thickness came back: the layers rest 5 mm apart, not within dhat */
    double lo = INFINITY;
    for (int i = 0; i < NV; ++i) lo = fmin(lo, xb[3 * i + 1]);
    assert_true(lo >= 2.5e-3 && lo < 2.5e-3 + L.dhat);
    free(xa);
    free(xb);
    defsim_world_destroy(w2);
    free_layers(&L);
}

/* Bad thicknesses are DEFSIM_ERR_INVALID_ARGUMENT; layers that start closer than the sum of
 * their half-thicknesses fail the first step with it, state unchanged. */
static void test_validation(void **state)
{
    (void)state;
    layers L;
    make_layers(&L, 0.0, 1, 0.1, 0.13, 0.0, sizeof(defsim_body_def));
    defsim_body_def d = test_shell_body(&L.m);
    d.shell_membrane = DEFSIM_SHELL_MEMBRANE_STVK;
    const double bad[4] = {-1e-3, NAN, INFINITY, 2e3};
    for (int k = 0; k < 4; ++k) {
        d.contact_thickness = bad[k];
        assert_int_equal(defsim_world_add_body(L.w, &d, NULL), DEFSIM_ERR_INVALID_ARGUMENT);
    }
    free_layers(&L);
    /* 4 mm apart with t = 5 mm each: 5 mm needed */
    make_layers(&L, 5e-3, 1, 0.1, 0.104, 0.0, sizeof(defsim_body_def));
    assert_int_equal(defsim_world_step(L.w, H), DEFSIM_ERR_INVALID_ARGUMENT);
    assert_true(defsim_world_time(L.w) == 0.0);
    free_layers(&L);
    /* 6 mm apart: fine */
    make_layers(&L, 5e-3, 1, 0.1, 0.106, 0.0, sizeof(defsim_body_def));
    TU_OK(defsim_world_step(L.w, H));
    free_layers(&L);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_stack_shells), cmocka_unit_test(test_stack_springs),
        cmocka_unit_test(test_stack_mixed),  cmocka_unit_test(test_penalty_offset),
        cmocka_unit_test(test_fast_drop),    cmocka_unit_test(test_zero_is_default),
        cmocka_unit_test(test_checkpoint),   cmocka_unit_test(test_validation),
        cmocka_unit_test(test_friction_thick),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

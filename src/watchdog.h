/* SPDX-License-Identifier: MIT */
/*
 * The stability watchdog (watchdog.c): after a backend's step succeeded, checks that the state
 * stayed inside an envelope that the scene explains (finite; kinetic energy within a multiple
 * of the energy at a reference plus the work of the applied forces since; every body within a
 * multiple of its rest size; no inverted element in a model that cannot invert), and computes
 * the per-step diagnostics that hosts read by name. It reads the compiled system and the bodies,
 * never the world (world.c hands them in), so it depends on neither the world nor a backend.
 * docs/watchdog.md describes the envelope and the thresholds.
 */
#ifndef DEFSIM_WATCHDOG_H
#define DEFSIM_WATCHDOG_H

#include "body.h"
#include "system.h"

#include <stddef.h>

typedef struct defsim__watchdog {
    int have_rest;        /* rest_diag and e_floor hold for the current bodies */
    int have_ref;         /* e_ref and work hold since the last forget */
    double e_ref;         /* J: kinetic (free vertices) plus elastic energy at the reference */
    double work;          /* J: work of gravity, held forces and attachment targets since then */
    double e_floor;       /* J: total mass x its rest size x max(|g|, 9.81 m/s^2) */
    double k_prev;        /* J: kinetic energy after the previous step */
    int32_t since_full;   /* steps since the last check of the total energy */
    double move2;         /* m^2: a step that deforms an element further checks the total energy */
    double jmin;          /* smallest J of the neo-Hookean elements at the last inversion check */
    double *rest_diag;    /* per body slot: diagonal of its rest bounding box (m) */
    double *dof;          /* nv: a vertex's mass, 0 if pinned */
    double *dx;           /* 3 nv: the displacements of the step being checked */
    int64_t energy_evals; /* elastic-energy evaluations so far (they join defsim_stats) */
    double *pin_f0, *pin_f1; /* 3 nv: elastic and damping forces at the start and end of a step
                                that moves driven pins (NULL until one does) */
    double pin_f_t;       /* s: the time whose state pin_f0 holds the forces of (NaN: none) */
    int32_t pin_nv;       /* the vertex count pin_f0 and pin_f1 were made for */
    int pin_end;          /* pin_f1 holds the end of the step under way */
    int32_t *pin_el;      /* (group, element) pairs of the elements with a pinned vertex */
    int32_t npin_el;
    int pin_el_ok;        /* pin_el and npin_el hold for the current plan */
} defsim__watchdog;

/* What one check needs: the system, the bodies, the state after (x, v) and before (x0, v0) the
 * step, and the thresholds (core.watchdog_* options). */
typedef struct defsim__watchdog_step {
    const defsim__system *sys;
    defsim__work *work;
    const defsim__body *bodies;
    int32_t nbodies;
    const double *x, *v, *x0, *v0;
    int on;               /* core.watchdog; off: only the finiteness check runs */
    /* The work done on the system in the step besides gravity and held forces (docs/watchdog.md
     * "The energy bound"): the force callback's evaluations recorded in the step (3 nv each; a
     * vertex's work is the largest of f . dx over them), the elastic and damping forces at the
     * pinned DOFs at the start and end of a step that moves driven pins (NULL: none moved), the
     * colliders' motion against the contact forces and the contact energy at the start of the
     * step (J; the check reads both from the terms' work, terms.h), which joins the reference,
     * or the work when colliders came or went (colliders_changed); contact_start_wanted: the
     * energy at the start is needed (no reference, or colliders changed). */
    const double *cb_f[4];
    int ncb;
    const double *pin_f0, *pin_f1;
    int contact_start_wanted;
    int colliders_changed;
    double energy_growth; /* core.watchdog_energy_growth */
    double max_stretch;   /* core.watchdog_max_stretch */
} defsim__watchdog_step;

/* Checks the state after a successful step. Returns DEFSIM_OK, DEFSIM_ERR_UNSTABLE with what
 * tripped written into `what` (one sentence without advice), or DEFSIM_ERR_OUT_OF_MEMORY. On OK
 * the work of the step joins the budget. The finiteness check runs even when `on` is 0. */
defsim_status defsim__watchdog_check(defsim__watchdog *wd, const defsim__watchdog_step *in,
                                     char *what, size_t size);

/* The message of a trip: what tripped (from defsim__watchdog_check), the step, and what to do:
 * for a backend with a step-size limit (`limited`) the stable step h_stable at the restored
 * start (NaN: not estimable) and the way out, else a smaller step or tolerance. */
void defsim__watchdog_message(char *out, size_t size, const char *what, double h, double t,
                              const char *backend, int limited, double h_stable, int auto_substep);

/* Drops the energy reference (the host changed the state or the model between steps); with
 * `bodies` set, the rest sizes too. The next check takes a new reference. */
void defsim__watchdog_forget(defsim__watchdog *wd, int bodies);

/* The buffers for the forces at driven pins (3 nv each), allocated at the first step that moves
 * one; NULL when out of memory. */
double *defsim__watchdog_pin_buffer(defsim__watchdog *wd, int32_t nv, int end);

/* The forces on the pinned vertices at (x, v) that the pins hold against and that exchange
 * work with the free vertices and the elements: elastic (tets, springs, attachment springs),
 * from the elements with a pinned vertex only (listed once per plan); with stiffness or
 * attachment damping or body contact, one full evaluation of the elastic and damping forces.
 * Writes the pinned vertices' entries of f (3 nv). Returns DEFSIM_ERR_UNSTABLE if one is not
 * finite, DEFSIM_ERR_OUT_OF_MEMORY. */
defsim_status defsim__watchdog_pin_forces(defsim__watchdog *wd, const defsim__system *s,
                                          const double *x, const double *v, double *f);

/* The step under way succeeded and the state is now that of time t: the forces at its end
 * serve as the next step's start. */
void defsim__watchdog_step_done(defsim__watchdog *wd, double t);

/* Frees the per-body sizes (at the world's destruction). */
void defsim__watchdog_free(defsim__watchdog *wd);

/* The host moves the world point of compiled attachment e to p (between steps): its spring's
 * energy change at x joins the work. */
void defsim__watchdog_attachment_moved(defsim__watchdog *wd, const defsim__system *s, int32_t e,
                                       const double *x, const double p[3]);

/* Fills the diagnostics of defsim_stats at the state (x, v) of a planned system: the smallest
 * volume ratio J and the count of elements with J <= 0 over all tets, and the energy drift since
 * the reference (NaN without one). One pass over the tets and one energy evaluation. */
void defsim__watchdog_diagnostics(const defsim__watchdog *wd, const defsim__system *s,
                                  defsim__work *wk, const double *x, const double *v,
                                  defsim_stats *out);

/* True if `name` is a statistic that defsim__watchdog_diagnostics computes. */
int defsim__watchdog_is_diagnostic(const char *name);

#endif /* DEFSIM_WATCHDOG_H */

/* SPDX-License-Identifier: MIT */
/*
 * The term kinds (term.h), one line each, in the order their forces are summed (which is the
 * order the sums had before terms, so trajectories keep their bits). Kind `name` lives in
 * src/term_<name>.c and exports the ops table `defsim__term_<name>`; CMake reads this list to
 * compile those files, so adding a force family is its file plus one line here. A kind adds a
 * term to a system only when the scene uses it (term.c compiles the list).
 */
#ifndef DEFSIM_TERM_LIST_H
#define DEFSIM_TERM_LIST_H

#define DEFSIM__TERM_LIST(X)    \
    X(elastic)                  \
    X(nodal_volume)             \
    X(elastic_quadratic)        \
    X(quadratic_mixed)          \
    X(spring)                   \
    X(membrane)                 \
    X(hinge)                    \
    X(strain_limit)             \
    X(attach)                   \
    X(collider)                 \
    X(body_contact)             \
    X(stiffness_damping)        \
    X(mass_damping)             \
    X(gravity)                  \
    X(held)                     \
    X(callback)                 \
    X(inertia)

#endif /* DEFSIM_TERM_LIST_H */

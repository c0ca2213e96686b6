/* SPDX-License-Identifier: MIT */
/*
 * What the two CHOLMOD solvers share (implicit_core's Newton solver for newton_cholmod, newmark
 * and bdf2; sundials_ida's reduced solver, linear_solver = cholmod): the CHOLMOD objects of one
 * factorisation, the sparse matrix that wraps the host's upper-triangle pattern and its values,
 * and their release. Header only, included by both solvers' sources after <cholmod.h>.
 */
#ifndef DEFSIM_CHOLMOD_SOLVER_H
#define DEFSIM_CHOLMOD_SOLVER_H

#include "defsim/backend.h"

#include <cholmod.h>

/* One factorisation's CHOLMOD objects. Zero-initialised: nothing started. cholmod_common is
 * large and must not move once started: the solvers keep this behind a pointer. */
typedef struct defsim__chol {
    cholmod_common cc;
    int started;               /* cc was started (defsim__chol_start) */
    cholmod_sparse A;          /* wraps a pattern and its values (defsim__chol_wrap) */
    cholmod_factor *L;
    cholmod_dense *rhs, *sol, *ywork, *ework;   /* cholmod_l_solve2's right-hand side, solution
                                                   and workspaces */
} defsim__chol;

static inline void defsim__chol_start(defsim__chol *c)
{
    cholmod_l_start(&c->cc);
    c->started = 1;
}

/* Makes c->A the symmetric matrix whose upper triangle is `pat` (the host's, DEFSIM_TRIANGLE_UPPER,
 * borrowed) with the values `values` (pat->nnz). The pattern is only read by CHOLMOD; the casts
 * drop const for its struct's sake. */
static inline void defsim__chol_wrap(defsim__chol *c, const defsim_csc *pat, double *values)
{
    c->A.nrow = c->A.ncol = (size_t)pat->n;
    c->A.nzmax = (size_t)pat->nnz;
    c->A.p = (void *)pat->col_ptr;
    c->A.i = (void *)pat->row_idx;
    c->A.x = values;
    c->A.stype = 1;
    c->A.itype = CHOLMOD_LONG;
    c->A.xtype = CHOLMOD_REAL;
    c->A.dtype = CHOLMOD_DOUBLE;
    c->A.sorted = 1;
    c->A.packed = 1;
}

/* Frees the factor and the dense vectors and finishes cc, if it was started. */
static inline void defsim__chol_finish(defsim__chol *c)
{
    if (!c->started) return;
    cholmod_l_free_dense(&c->rhs, &c->cc);
    cholmod_l_free_dense(&c->sol, &c->cc);
    cholmod_l_free_dense(&c->ywork, &c->cc);
    cholmod_l_free_dense(&c->ework, &c->cc);
    cholmod_l_free_factor(&c->L, &c->cc);
    cholmod_l_finish(&c->cc);
    c->started = 0;
}

#endif /* DEFSIM_CHOLMOD_SOLVER_H */

/* SPDX-License-Identifier: MIT */
/*
 * What sundials_ida reads and writes inside IDA's private memory (IDAMem, ida/ida_impl.h), in
 * one file: ida_private.c, the only one that includes ida_impl.h. IDA's public API cannot clear
 * a stop time (SUNDIALS 6.4 has no IDAClearStopTime), give the last internal point's y, or set
 * the BDF history a checkpoint restores. The layout is SUNDIALS 6.4's: ida_private.c refuses to
 * compile against another version (README "IDA's private memory").
 */
#ifndef DEFSIM_IDA_PRIVATE_H
#define DEFSIM_IDA_PRIVATE_H

#include <nvector/nvector_serial.h>

#include <stdint.h>

/* IDA's MXORDP1 (vectors of divided differences phi; ida_private.c checks the value), the
 * history's scalars (ints: 14 fields of IDAMem and the number of phi vectors; reals: 17 fields
 * of IDAMem and psi, alpha, beta, sigma, gamma), and its vectors (phi and the local error ee). */
enum {
    DEFSIM__IDA_MXORDP1 = 6,
    DEFSIM__IDA_HIST_INTS = 15,
    DEFSIM__IDA_HIST_REALS = 17 + 5 * DEFSIM__IDA_MXORDP1,
    DEFSIM__IDA_HIST_VECTORS = DEFSIM__IDA_MXORDP1 + 1
};

/* The time of IDA's last internal point (tn) and its y (phi[0]). */
double defsim__ida_tn(void *mem);
N_Vector defsim__ida_yn(void *mem);

/* Drops the stop time of the last IDASetStopTime. */
void defsim__ida_clear_stop_time(void *mem);

/* The history's scalars, in one order for both directions (a checkpoint's format). */
void defsim__ida_history_get(void *mem, int64_t ints[DEFSIM__IDA_HIST_INTS],
                             double reals[DEFSIM__IDA_HIST_REALS]);
/* Writes them back into an IDA restarted for the same system; 0 (nothing written) when they do
 * not fit it (another maximum order or number of vectors, an order out of range, no steps). */
int defsim__ida_history_set(void *mem, const int64_t ints[DEFSIM__IDA_HIST_INTS],
                            const double reals[DEFSIM__IDA_HIST_REALS]);
/* The history's vectors into vs; returns how many. */
int defsim__ida_history_vectors(void *mem, N_Vector vs[DEFSIM__IDA_HIST_VECTORS]);

/* IDASolve runs its initial set-up only before the first step (nst == 0): does its part that a
 * restored history needs (the error weights' user data, the linear and nonlinear solvers'
 * initialisation). Returns 0, or -1 when a solver did not initialise. */
int defsim__ida_resume_setup(void *mem);

#endif

/* SPDX-License-Identifier: MIT */
/* sundials_ida's reads and writes of IDA's private memory (ida_private.h). */
#include "ida_private.h"

#include <ida/ida.h>
#include <ida/ida_impl.h>
#include <sundials/sundials_config.h>

/* Written for IDAMem as SUNDIALS 6.4 lays it out. Another version may rename, retype or move
 * these fields, or change what IDASolve's first call sets up: compare its ida_impl.h and
 * idaInitialSetup (ida.c) with the fields below, then widen this test. */
#if SUNDIALS_VERSION_MAJOR != 6 || SUNDIALS_VERSION_MINOR != 4
#error "ida_private.c reads IDA's private memory as SUNDIALS 6.4 lays it out"
#endif
_Static_assert(MXORDP1 == DEFSIM__IDA_MXORDP1, "IDA's MXORDP1 is not ida_private.h's");

double defsim__ida_tn(void *mem) { return ((IDAMem)mem)->ida_tn; }

N_Vector defsim__ida_yn(void *mem) { return ((IDAMem)mem)->ida_phi[0]; }

void defsim__ida_clear_stop_time(void *mem) { ((IDAMem)mem)->ida_tstopset = SUNFALSE; }

static int vector_count(const IDAMem im)
{
    int k = 0;
    while (k < MXORDP1 && im->ida_phi[k]) ++k;
    return k;
}

/* The scalars, in one order for both directions: ints (as int64) then reals. */
#define IDA_INT_FIELDS(X)                                                                       \
    X(ida_kk) X(ida_kused) X(ida_knew) X(ida_phase) X(ida_ns) X(ida_nst) X(ida_nre)           \
    X(ida_ncfn) X(ida_netf) X(ida_nni) X(ida_nnf) X(ida_nsetups) X(ida_tstopset)              \
    X(ida_maxord_alloc)
#define IDA_REAL_FIELDS(X)                                                                      \
    X(ida_hin) X(ida_h0u) X(ida_hh) X(ida_hused) X(ida_eta) X(ida_tn) X(ida_tretlast)          \
    X(ida_cj) X(ida_cjlast) X(ida_cjold) X(ida_cjratio) X(ida_ss) X(ida_oldnrm)               \
    X(ida_epsNewt) X(ida_toldel) X(ida_tstop) X(ida_tolsf)

void defsim__ida_history_get(void *mem, int64_t ints[DEFSIM__IDA_HIST_INTS],
                             double reals[DEFSIM__IDA_HIST_REALS])
{
    const IDAMem im = mem;
    int ni = 0, nr = 0;
#define PUT_INT(f) ints[ni++] = (int64_t)im->f;
#define PUT_REAL(f) reals[nr++] = im->f;
    IDA_INT_FIELDS(PUT_INT)
    IDA_REAL_FIELDS(PUT_REAL)
#undef PUT_INT
#undef PUT_REAL
    ints[ni++] = vector_count(im);
    for (int k = 0; k < MXORDP1; ++k) {
        reals[nr++] = im->ida_psi[k];
        reals[nr++] = im->ida_alpha[k];
        reals[nr++] = im->ida_beta[k];
        reals[nr++] = im->ida_sigma[k];
        reals[nr++] = im->ida_gamma[k];
    }
}

int defsim__ida_history_set(void *mem, const int64_t ints[DEFSIM__IDA_HIST_INTS],
                            const double reals[DEFSIM__IDA_HIST_REALS])
{
    IDAMem im = mem;
    if (ints[13] != im->ida_maxord_alloc || ints[14] != vector_count(im) || ints[0] < 0 ||
        ints[0] > im->ida_maxord || ints[5] < 1)
        return 0;
    int ni = 0, nr = 0;
#define GET_INT(f) im->f = ints[ni++];
#define GET_REAL(f) im->f = reals[nr++];
    IDA_INT_FIELDS(GET_INT)
    IDA_REAL_FIELDS(GET_REAL)
#undef GET_INT
#undef GET_REAL
    for (int k = 0; k < MXORDP1; ++k) {
        im->ida_psi[k] = reals[nr++];
        im->ida_alpha[k] = reals[nr++];
        im->ida_beta[k] = reals[nr++];
        im->ida_sigma[k] = reals[nr++];
        im->ida_gamma[k] = reals[nr++];
    }
    return 1;
}

/* phi[0 ..] and the estimated local error ee (ida_yy and ida_yp alias the caller's vectors
 * inside IDASolve: not history). */
int defsim__ida_history_vectors(void *mem, N_Vector vs[DEFSIM__IDA_HIST_VECTORS])
{
    const IDAMem im = mem;
    int n = 0;
    for (int k = 0; k < vector_count(im); ++k) vs[n++] = im->ida_phi[k];
    vs[n++] = im->ida_ee;
    return n;
}

int defsim__ida_resume_setup(void *mem)
{
    IDAMem im = mem;
    im->ida_edata = im->ida_user_data;
    if ((im->ida_linit && im->ida_linit(im) != 0) || idaNlsInit(im) != IDA_SUCCESS) return -1;
    im->ida_SetupDone = SUNTRUE;
    return 0;
}

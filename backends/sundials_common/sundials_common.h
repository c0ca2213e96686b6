/* SPDX-License-Identifier: MIT */
/*
 * What the SUNDIALS backends (sundials_erk, sundials_ida, sundials_kinsol) share: the prologue of
 * their init and the macro of its setter calls, the end of their fini, a SUNDIALS context, a
 * sparse CSC matrix with the KLU direct solver (wrapped so that factorisation and solve times
 * land in defsim_stats), and capture of SUNDIALS error messages. Linked statically into each
 * module; every symbol is hidden.
 */
#ifndef DEFSIM_SUNDIALS_COMMON_H
#define DEFSIM_SUNDIALS_COMMON_H

#include "defsim/backend.h"

#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sundials/sundials_linearsolver.h>
#include <sundials/sundials_matrix.h>

/* SUNDIALS 6 (SUNContext, error handler functions); 7 changed both. */
#if SUNDIALS_VERSION_MAJOR != 6
#error "the SUNDIALS backends need SUNDIALS 6.x"
#endif

typedef struct defsim__sun_timer defsim__sun_timer;

/* SUNDIALS objects of one world. Zero-initialised state is "nothing allocated". */
typedef struct defsim__sun {
    const defsim_host *host;
    defsim_system *sys;
    SUNContext ctx;
    SUNMatrix J;               /* CSC, sunindextype = int64_t */
    SUNLinearSolver LS;        /* KLU, ops wrapped by `timer` */
    defsim__sun_timer *timer;
    char msg[384];             /* last error message SUNDIALS reported */
    int need_reinit;           /* adaptive modules: restart from the world's state next step */
    int coupled;               /* the host has the coupling services (ABI 3: forces_at, ...) */
    const double *pv;          /* this step's driven-pin velocities, or NULL */
    int drove;                 /* the last step drove pins */
} defsim__sun;

/* The prologue of every module's init, over its state `s` (a struct with the fields `sun`,
 * `host`, `sys`, `n`, `ndof` and `free_dofs`): notes the host and the system, reads the free-DOF
 * map, asks for a restart from the world's state at the first step (need_reinit; KINSOL keeps no
 * history and never reads it), and returns DEFSIM_OK from the init when every DOF is pinned
 * (nothing moves); else reads the backend's `count` option values into `o` (defsim__sun_options).
 * A macro because the three states are different structs with these fields in common. */
#define DEFSIM__SUN_INIT_PROLOGUE(s, host_, sys_, specs, count, o)                             \
    do {                                                                                       \
        (s)->host = (host_);                                                                   \
        (s)->sys = (sys_);                                                                     \
        (s)->n = (host_)->free_dof_count(sys_);                                                \
        (s)->ndof = (host_)->dof_count(sys_);                                                  \
        (s)->free_dofs = (host_)->free_dofs(sys_);                                             \
        (s)->sun.need_reinit = 1;                                                              \
        if ((s)->n == 0) return DEFSIM_OK;   /* everything pinned: nothing moves */            \
        defsim__sun_options(host_, sys_, specs, count, o);                                     \
    } while (0)

/* One SUNDIALS setter of a module's init: runs `call`; a negative flag is reported through the
 * module's `fail(s, text, flag)` and returns from the init, DEFSIM_ERR_OUT_OF_MEMORY when the flag
 * is the package's `mem_fail` (ARK_MEM_FAIL, IDA_MEM_FAIL, KIN_MEM_FAIL), else
 * DEFSIM_ERR_INVALID_ARGUMENT. `text` is the call as written (#call of the module's SET, taken
 * before its macros expand). */
#define DEFSIM__SUN_SET(s, fail, mem_fail, text, call)                                        \
    do {                                                                                      \
        int flag_ = (call);                                                                   \
        if (flag_ < 0) {                                                                      \
            fail(s, text, flag_);                                                             \
            return flag_ == (mem_fail) ? DEFSIM_ERR_OUT_OF_MEMORY : DEFSIM_ERR_INVALID_ARGUMENT; \
        }                                                                                     \
    } while (0)

/* Creates the context (and notes whether the host has the coupling services). Returns
 * DEFSIM_OK or DEFSIM_ERR_OUT_OF_MEMORY (message set). */
defsim_status defsim__sun_open(defsim__sun *s, const defsim_host *host, defsim_system *sys);

/* Creates an n x n CSC matrix with room for nnz entries and a KLU solver for it, whose solves
 * are counted in the backend's counter `counters` (linear_solves), and whose setup
 * (factorisation) and solve are timed into the two counters after it (time_factor,
 * time_solve). `tmpl` is a vector of length n. */
defsim_status defsim__sun_klu(defsim__sun *s, N_Vector tmpl, int64_t n, int64_t nnz,
                              int32_t counters);

/* Frees everything defsim__sun_open / defsim__sun_klu made (any subset of it). */
void defsim__sun_close(defsim__sun *s);

/* The end of every module's fini: frees the package's memory *mem with `mem_free` (IDAFree,
 * KINFree, ERKStepFree), destroys the module's `n` vectors *v[i] that exist and clears them,
 * then closes s (defsim__sun_close). What the module made with the context besides them (its
 * own linear solver) it frees before. */
void defsim__sun_fini(defsim__sun *s, void **mem, void (*mem_free)(void **), N_Vector *const *v,
                      int n);

/* Error handler for IDASetErrHandlerFn / KINSetErrHandlerFn (user data: the defsim__sun).
 * Keeps errors for the failure message and sends warnings to the world's log. */
void defsim__sun_error_handler(int code, const char *module, const char *function, char *msg,
                               void *user);

/* Sets the world's error to "<backend>: <call> failed with <FLAG_NAME> (flag <flag>) at t = ...:
 * <last SUNDIALS message>". `flag_name` may be NULL. */
void defsim__sun_fail(defsim__sun *s, const char *backend, const char *call, const char *flag_name,
                      long flag, double t);

/* The backend's option values in the order of `specs` (the host's; the defaults if the host
 * holds none). */
void defsim__sun_options(const defsim_host *host, const defsim_system *sys,
                         const defsim_option_spec *specs, int count, double *out);

/* The backend's counters (NULL if it declares none), and adding to one of them. */
double *defsim__sun_counters(const defsim_host *host, defsim_system *sys);
void defsim__sun_count(const defsim_host *host, defsim_system *sys, int which, double value);

/* The tolerances' rows of the adaptive modules' option tables (sundials_erk, sundials_ida):
 * rtol, then atol, a length (and a speed) within the coordinate bound, 1e100, and at least
 * 1e-30, below the rounding of any coordinate of a scene larger than 1e-14 m. */
#define DEFSIM__SUN_OPTION_TOLERANCES                                                         \
    {"rtol", DEFSIM_OPTION_REAL, 1e-4, 1e-14, 1.0, NULL,                                      \
     "relative tolerance per second of simulated time"},                                      \
    {"atol", DEFSIM_OPTION_REAL, 1e-6, 1e-30, 1e100, NULL,                                    \
     "absolute tolerance per second of simulated time (m for positions, m/s for velocities), " \
     "in [1e-30, 1e100]"}

/* The rows each module's backend table shares, for modules that name their state, ops and
 * spec tables after their prefix (every one does): the ABI's, its name and flags, its state
 * <prefix>_state, the ops <prefix>_init, _step and _fini, and its options and counters by name
 * (<prefix>_options[O_COUNT], <prefix>_counters[C_COUNT]). */
#define DEFSIM__SUN_TABLE(prefix, NAME, FLAGS)                                                \
    .abi_version = DEFSIM_BACKEND_ABI_VERSION, .struct_size = sizeof(defsim_backend),         \
    .name = NAME, .flags = FLAGS, .state_size = sizeof(prefix##_state),                       \
    .init = prefix##_init, .step = prefix##_step, .fini = prefix##_fini,                      \
    .options = prefix##_options, .option_count = O_COUNT, .counters = prefix##_counters,      \
    .counter_count = C_COUNT

/* Each module's entry point, over its backend table (defsim__sun_module). */
#define DEFSIM__SUN_MODULE_INIT(backend)                                                      \
    __attribute__((visibility("default"))) defsim_status defsim_module_init(                  \
        const defsim_host *host, const defsim_backend **out)                                  \
    {                                                                                         \
        return defsim__sun_module(host, out, &(backend));                                     \
    }

/* The body of each module's entry point: hands out `backend` if the host is of ABI version 8
 * (version 8 broke the table) with every service the SUNDIALS modules use (options, counters,
 * omega_max). */
defsim_status defsim__sun_module(const defsim_host *host, const defsim_backend **out,
                                 const defsim_backend *backend);

/* Driven pins at the start of a step: reads their velocities into s->pv. For the adaptive
 * modules (adaptive != 0), a step that drives pins, or follows one that did, restarts the
 * integrator from the world's state (need_reinit): the pins' velocities change from step to
 * step, a kink in the equations' dependence on time. */
void defsim__sun_drive_begin(defsim__sun *s, int adaptive);

/* Forces `which` at (x, v) and time t (the force callback sees t) into f, through forces_at when
 * the host has it. */
defsim_status defsim__sun_forces(const defsim__sun *s, const double *x, const double *v,
                                 double t, uint32_t which, double *f);

/* y = [x_free, v_free] (2n entries) into the free entries of the full x and v, and back. */
void defsim__sun_scatter(const int64_t *free_dofs, int64_t n, const double *y, double *x,
                         double *v);
void defsim__sun_gather(const int64_t *free_dofs, int64_t n, const double *x, const double *v,
                        double *y);

/* The reset op of the adaptive modules, whose state begins with its defsim__sun: the host set
 * the state, so the integrator's history goes (need_reinit). */
defsim_status defsim__sun_reset(const defsim_host *host, defsim_system *sys, void *state);

/* Checkpoints of the adaptive modules begin with two flags: the integrator has a history to
 * continue (has_history: a module's integrator exists and need not restart), and the last step
 * drove pins. save writes them; load reads them, restores s->drove and sets *history, or
 * returns DEFSIM_ERR_IO for a value other than 0 or 1. */
int defsim__sun_has_history(const defsim__sun *s, const void *mem, int64_t n);
defsim_status defsim__sun_save_flags(const defsim__sun *s, int history,
                                     const defsim_state_writer *wr);
defsim_status defsim__sun_load_flags(defsim__sun *s, const defsim_state_reader *rd, int *history);

/* Replaces the hot operations of serial vector v (linear sum, constant, scale, weighted RMS norm
 * and its sum of squares) with ones compiled with this build's flags that give the same bits;
 * vectors cloned from v afterwards (the integrator's) inherit them. */
void defsim__sun_fast_ops(N_Vector v);

/* Allocation through the host (zeroed; NULL on failure). */
void *defsim__sun_calloc(const defsim_host *host, size_t count, size_t size);

#endif

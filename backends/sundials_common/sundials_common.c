/* SPDX-License-Identifier: MIT */
/* Shared SUNDIALS plumbing of the sundials_erk, sundials_ida and sundials_kinsol modules. */
#include "sundials_common.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include <sunlinsol/sunlinsol_klu.h>
#include <sunmatrix/sunmatrix_sparse.h>

/* The KLU solver's ops table is replaced by a copy whose setup and solve time the original ones.
 * SUNDIALS passes only the solver to its ops, so the copy is the first member of a struct that
 * also holds what the timers need; the original table is put back before the solver is freed. */
struct defsim__sun_timer {
    struct _generic_SUNLinearSolver_Ops ops;   /* must stay first */
    SUNLinearSolver_Ops orig;
    const defsim_host *host;
    defsim_system *sys;
    int32_t first;   /* the backend's counters linear_solves, time_factor, time_solve */
};

static defsim__sun_timer *timer_of(SUNLinearSolver S) { return (defsim__sun_timer *)S->ops; }

static int timed_setup(SUNLinearSolver S, SUNMatrix A)
{
    defsim__sun_timer *t = timer_of(S);
    const double t0 = t->host->wall_time();
    int r = t->orig->setup(S, A);
    defsim__sun_count(t->host, t->sys, t->first + 1, t->host->wall_time() - t0);
    return r;
}

static int timed_solve(SUNLinearSolver S, SUNMatrix A, N_Vector x, N_Vector b, realtype tol)
{
    defsim__sun_timer *t = timer_of(S);
    const double t0 = t->host->wall_time();
    int r = t->orig->solve(S, A, x, b, tol);
    defsim__sun_count(t->host, t->sys, t->first + 2, t->host->wall_time() - t0);
    defsim__sun_count(t->host, t->sys, t->first, 1.0);
    return r;
}

void defsim__sun_scatter(const int64_t *free_dofs, int64_t n, const double *y, double *x,
                         double *v)
{
    for (int64_t i = 0; i < n; ++i) {
        x[free_dofs[i]] = y[i];
        v[free_dofs[i]] = y[n + i];
    }
}

void defsim__sun_gather(const int64_t *free_dofs, int64_t n, const double *x, const double *v,
                        double *y)
{
    for (int64_t i = 0; i < n; ++i) {
        y[i] = x[free_dofs[i]];
        y[n + i] = v[free_dofs[i]];
    }
}

defsim_status defsim__sun_reset(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)host;
    (void)sys;
    ((defsim__sun *)state)->need_reinit = 1;
    return DEFSIM_OK;
}

void *defsim__sun_calloc(const defsim_host *host, size_t count, size_t size)
{
    if (count == 0) count = 1;
    if (size != 0 && count > (size_t)-1 / size) return NULL;
    void *p = host->alloc(count * size);
    if (p) memset(p, 0, count * size);
    return p;
}

void defsim__sun_options(const defsim_host *host, const defsim_system *sys,
                         const defsim_option_spec *specs, int count, double *out)
{
    const double *v = host->option_values(sys);
    for (int i = 0; i < count; ++i) out[i] = v ? v[i] : specs[i].default_value;
}

double *defsim__sun_counters(const defsim_host *host, defsim_system *sys)
{
    return host->counters(sys);
}

void defsim__sun_count(const defsim_host *host, defsim_system *sys, int which, double value)
{
    double *c = host->counters(sys);
    if (c) c[which] += value;
}

defsim_status defsim__sun_module(const defsim_host *host, const defsim_backend **out,
                                 const defsim_backend *backend)
{
    if (!out || !host || host->abi_version < 8 ||
        host->size < offsetof(defsim_host, omega_max) + sizeof host->omega_max)
        return DEFSIM_ERR_BACKEND_UNAVAILABLE;
    *out = backend;
    return DEFSIM_OK;
}

defsim_status defsim__sun_open(defsim__sun *s, const defsim_host *host, defsim_system *sys)
{
    s->host = host;
    s->sys = sys;
    s->msg[0] = '\0';
    s->coupled = host->size >= offsetof(defsim_host, applied_forces_vary) +
                                   sizeof host->applied_forces_vary;
    if (SUNContext_Create(NULL, &s->ctx) != 0) {
        s->ctx = NULL;
        host->set_error(sys, "SUNDIALS: SUNContext_Create failed (out of memory)");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    return DEFSIM_OK;
}

defsim_status defsim__sun_klu(defsim__sun *s, N_Vector tmpl, int64_t n, int64_t nnz,
                             int32_t counters)
{
    s->J = SUNSparseMatrix((sunindextype)n, (sunindextype)n, (sunindextype)(nnz > 0 ? nnz : 1),
                           CSC_MAT, s->ctx);
    if (!s->J) goto oom;
    s->LS = SUNLinSol_KLU(tmpl, s->J, s->ctx);
    if (!s->LS) goto oom;
    s->timer = defsim__sun_calloc(s->host, 1, sizeof *s->timer);
    if (!s->timer) goto oom;
    s->timer->ops = *s->LS->ops;
    s->timer->orig = s->LS->ops;
    s->timer->host = s->host;
    s->timer->sys = s->sys;
    s->timer->first = counters;
    s->timer->ops.setup = timed_setup;
    s->timer->ops.solve = timed_solve;
    s->LS->ops = &s->timer->ops;
    return DEFSIM_OK;
oom:
    s->host->set_error(s->sys, "SUNDIALS: out of memory creating the sparse matrix or KLU solver");
    return DEFSIM_ERR_OUT_OF_MEMORY;
}

void defsim__sun_close(defsim__sun *s)
{
    if (s->LS) {
        if (s->timer) s->LS->ops = s->timer->orig;
        SUNLinSolFree(s->LS);
        s->LS = NULL;
    }
    if (s->timer) {
        s->host->release(s->timer);
        s->timer = NULL;
    }
    if (s->J) {
        SUNMatDestroy(s->J);
        s->J = NULL;
    }
    if (s->ctx) SUNContext_Free(&s->ctx);
    s->ctx = NULL;
}

void defsim__sun_fini(defsim__sun *s, void **mem, void (*mem_free)(void **), N_Vector *const *v,
                      int n)
{
    if (*mem) mem_free(mem);
    *mem = NULL;
    for (int i = 0; i < n; ++i) {
        if (*v[i]) N_VDestroy(*v[i]);
        *v[i] = NULL;
    }
    defsim__sun_close(s);
}

void defsim__sun_error_handler(int code, const char *module, const char *function, char *msg,
                               void *user)
{
    defsim__sun *s = user;
    char line[sizeof s->msg];
    snprintf(line, sizeof line, "%s (%s): %s", function ? function : "?", module ? module : "?",
             msg ? msg : "");
    /* 99 is IDA_WARNING and KIN_WARNING: worth a log line, not a failure. */
    if (code == 99) {
        s->host->log(s->sys, 1, line);
    } else {
        memcpy(s->msg, line, sizeof s->msg);
        s->host->log(s->sys, 3, line);
    }
}

void defsim__sun_fail(defsim__sun *s, const char *backend, const char *call, const char *flag_name,
                      long flag, double t)
{
    char buf[640];
    snprintf(buf, sizeof buf, "%s: %s failed with %s (flag %ld) at t = %.17g s%s%s", backend, call,
             flag_name ? flag_name : "an unknown flag", flag, t, s->msg[0] ? ": " : "", s->msg);
    s->host->set_error(s->sys, buf);
    s->msg[0] = '\0';
}

void defsim__sun_drive_begin(defsim__sun *s, int adaptive)
{
    s->pv = s->coupled ? s->host->pin_velocities(s->sys) : NULL;
    if (adaptive && (s->pv || s->drove)) s->need_reinit = 1;
    s->drove = s->pv != NULL;
}

defsim_status defsim__sun_forces(const defsim__sun *s, const double *x, const double *v,
                                 double t, uint32_t which, double *f)
{
    if (!s->coupled) return s->host->forces(s->sys, x, v, which, f);
    return s->host->forces_at(s->sys, x, v, t, which, f);
}

int defsim__sun_has_history(const defsim__sun *s, const void *mem, int64_t n)
{
    return n > 0 && mem && !s->need_reinit;
}

defsim_status defsim__sun_save_flags(const defsim__sun *s, int history,
                                     const defsim_state_writer *wr)
{
    const int64_t flags[2] = {history != 0, s->drove != 0};
    return wr->i64(wr->ctx, flags, 2);
}

defsim_status defsim__sun_load_flags(defsim__sun *s, const defsim_state_reader *rd, int *history)
{
    int64_t flags[2];
    defsim_status st = rd->i64(rd->ctx, flags, 2);
    if (st != DEFSIM_OK) return st;
    if ((flags[0] != 0 && flags[0] != 1) || (flags[1] != 0 && flags[1] != 1)) return DEFSIM_ERR_IO;
    s->drove = (int)flags[1];
    *history = (int)flags[0];
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Serial vector operations compiled with this build's flags. Debian's SUNDIALS 6.4.1 packages
 * ship libsundials_nvecserial unoptimised (every loop loads its index from the stack, about 20
 * instructions per element), and these four were 38 % of sundials_ida's instructions on the
 * benchmark cantilever. Each does the same floating-point operations in the same order as
 * SUNDIALS' serial one, special cases included (a x + b y with a = 1 is y + ... not 1 * x + ...),
 * so the results are the same bits. */

static void fast_linear_sum(realtype a, N_Vector xv, realtype b, N_Vector yv, N_Vector zv)
{
    const sunindextype n = NV_LENGTH_S(xv);
    const double *x = NV_DATA_S(xv), *y = NV_DATA_S(yv);   /* z may be either */
    double *z = NV_DATA_S(zv);
    /* In place: z = y + a x or z = x + b y, as axpy. */
    if ((b == 1.0 && zv == yv) || (a == 1.0 && zv == xv)) {
        const int on_y = b == 1.0 && zv == yv;
        const double c = on_y ? a : b;
        const double *u = on_y ? x : y;
        if (c == 1.0)
            for (sunindextype i = 0; i < n; ++i) z[i] += u[i];
        else if (c == -1.0)
            for (sunindextype i = 0; i < n; ++i) z[i] -= u[i];
        else
            for (sunindextype i = 0; i < n; ++i) z[i] += c * u[i];
        return;
    }
    if (a == 1.0 && b == 1.0) {
        for (sunindextype i = 0; i < n; ++i) z[i] = x[i] + y[i];
    } else if (a == 1.0 && b == -1.0) {
        for (sunindextype i = 0; i < n; ++i) z[i] = x[i] - y[i];
    } else if (a == -1.0 && b == 1.0) {
        for (sunindextype i = 0; i < n; ++i) z[i] = y[i] - x[i];
    } else if (a == 1.0 || b == 1.0) {   /* c u + w, (c, u, w) = (b, y, x) or (a, x, y) */
        const double c = a == 1.0 ? b : a;
        const double *u = a == 1.0 ? y : x, *w = a == 1.0 ? x : y;
        for (sunindextype i = 0; i < n; ++i) z[i] = (c * u[i]) + w[i];
    } else if (a == -1.0 || b == -1.0) {   /* c u - w */
        const double c = a == -1.0 ? b : a;
        const double *u = a == -1.0 ? y : x, *w = a == -1.0 ? x : y;
        for (sunindextype i = 0; i < n; ++i) z[i] = (c * u[i]) - w[i];
    } else if (a == b) {
        for (sunindextype i = 0; i < n; ++i) z[i] = a * (x[i] + y[i]);
    } else if (a == -b) {
        for (sunindextype i = 0; i < n; ++i) z[i] = a * (x[i] - y[i]);
    } else {
        for (sunindextype i = 0; i < n; ++i) z[i] = (a * x[i]) + (b * y[i]);
    }
}

static void fast_const(realtype c, N_Vector zv)
{
    const sunindextype n = NV_LENGTH_S(zv);
    double *z = NV_DATA_S(zv);
    for (sunindextype i = 0; i < n; ++i) z[i] = c;
}

static void fast_scale(realtype c, N_Vector xv, N_Vector zv)
{
    const sunindextype n = NV_LENGTH_S(xv);
    double *z = NV_DATA_S(zv);
    if (zv == xv) {
        for (sunindextype i = 0; i < n; ++i) z[i] *= c;
        return;
    }
    const double *restrict x = NV_DATA_S(xv);
    if (c == 1.0)
        memcpy(z, x, (size_t)n * sizeof *z);
    else if (c == -1.0)
        for (sunindextype i = 0; i < n; ++i) z[i] = -x[i];
    else
        for (sunindextype i = 0; i < n; ++i) z[i] = c * x[i];
}

static realtype fast_wsqrsum(N_Vector xv, N_Vector wv)
{
    const sunindextype n = NV_LENGTH_S(xv);
    const double *x = NV_DATA_S(xv), *w = NV_DATA_S(wv);
    double sum = 0.0;
    for (sunindextype i = 0; i < n; ++i) {
        const double p = x[i] * w[i];
        sum += p * p;
    }
    return sum;
}

static realtype fast_wrmsnorm(N_Vector xv, N_Vector wv)
{
    return sqrt(fast_wsqrsum(xv, wv) / (double)NV_LENGTH_S(xv));
}

void defsim__sun_fast_ops(N_Vector v)
{
    v->ops->nvlinearsum = fast_linear_sum;
    v->ops->nvconst = fast_const;
    v->ops->nvscale = fast_scale;
    v->ops->nvwrmsnorm = fast_wrmsnorm;
    v->ops->nvwsqrsumlocal = fast_wsqrsum;
}

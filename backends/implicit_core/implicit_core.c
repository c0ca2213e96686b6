/* SPDX-License-Identifier: MIT */
/*
 * The implicit-solver core (implicit_core.h): one Newton loop for every scheme that minimises an
 * incremental potential
 *
 *   g(x) = c_m/(2h^2) |x - y|^2_M + E(x) + c_d/(2h) |x - z|^2_D,   D = alpha M + B(x_b),
 *
 * with E the potential energy (elastic + gravitational): sparse Hessian assembled by the core
 * into a pattern built once, CHOLMOD symbolic analysis once per set-up, numeric factorisation per
 * iteration, a backtracking (Armijo) line search on g, and the scale-free test
 * |dx|_inf <= tolerance * length_scale. v' = c_d/h (x' - z).
 *
 * Linked into each implicit module: it includes only defsim/backend.h, links CHOLMOD, and never
 * libdefsim. README.md beside this file documents the method and the schemes.
 *
 * Contents: constants; BLAS and CHOLMOD threads; the per-world solver; options; orderings and
 * symbolic analysis; the incremental potential, its gradient and Hessian; factorise and solve
 * (with diagonal shifts); one step: driven pins, the Newton loop with its line search, roll-back.
 */
#include "implicit_core.h"

#include "cholmod_solver.h"

#ifdef _OPENMP
#include <omp.h>
#endif

#include <float.h>
#include <stddef.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Armijo constant and the most halvings of the step before the line search gives up. */
#define IC_ARMIJO 1e-4
#define IC_MAX_BACKTRACKS 40
/* Diagonal shifts tried (multiples of M / h^2) when an exact Hessian is not positive definite. */
#define IC_MAX_SHIFTS 12
/* Factorisations of fewer flops run the BLAS on one thread (bit-identical for any thread
 * count); larger ones on the world's threads (bit-identical for a fixed count). */
#define IC_BLAS_SERIAL_FLOPS 1e8
/* factor_solve without shifts: the matrix is not positive definite (or dx not descent). */
#define DEFSIM__IC_INDEFINITE ((defsim_status)1)
/* Projection auto, at an iteration that used the clamped Hessian: a full step whose decrease
 * g(x) - g(x + dx) is over IC_EXTRAPOLATE_RATIO times the linear prediction -grad . dx (the
 * clamped model predicts half of it) has met less curvature than the model, and the line search
 * tries longer steps, at most IC_EXTRAPOLATIONS of them, up to IC_EXTRAPOLATE_MAX dx. */
#define IC_EXTRAPOLATE_RATIO 0.75
#define IC_EXTRAPOLATIONS 4
#define IC_EXTRAPOLATE_MAX 16.0
/* Relative resolution of g: decreases smaller than this times |g|'s scale cannot be seen. */
#define IC_G_RESOLUTION (1e3 * DBL_EPSILON)

/* ------------------------------------------------------------------------------------------ */
/* BLAS threads. CHOLMOD's supernodal factorisation calls the BLAS; Debian's OpenBLAS keeps one
 * process-wide thread count, read from OPENBLAS_NUM_THREADS / OMP_NUM_THREADS at load (default:
 * every core). We run the BLAS with the world's thread count, so that a world set to T threads
 * uses T cores in every phase and its results are reproducible for that T. A world that needs a
 * different count than the one in effect waits until no other implicit-backend factorisation is
 * running; worlds with equal counts factorise concurrently. The weak references resolve to NULL
 * when the BLAS is not OpenBLAS, and then the BLAS is left alone. */

extern int openblas_get_num_threads(void) __attribute__((weak));
extern void openblas_set_num_threads(int num_threads) __attribute__((weak));

static pthread_mutex_t blas_lock = PTHREAD_MUTEX_INITIALIZER;
static pthread_cond_t blas_idle = PTHREAD_COND_INITIALIZER;
static int blas_active;    /* factorisations running */
static int blas_current;   /* thread count they run with */
static int blas_original;  /* count found before the first change; restored when idle */

static void blas_enter(int threads)
{
    if (!openblas_get_num_threads || !openblas_set_num_threads) return;
    pthread_mutex_lock(&blas_lock);
    while (blas_active > 0 && blas_current != threads) pthread_cond_wait(&blas_idle, &blas_lock);
    if (blas_active == 0) {
        blas_original = openblas_get_num_threads();
        blas_current = blas_original;
    }
    if (blas_current != threads) {
        openblas_set_num_threads(threads);
        blas_current = threads;
    }
    blas_active++;
    pthread_mutex_unlock(&blas_lock);
}

static void blas_leave(void)
{
    if (!openblas_get_num_threads || !openblas_set_num_threads) return;
    pthread_mutex_lock(&blas_lock);
    if (--blas_active == 0) {
        if (blas_current != blas_original) openblas_set_num_threads(blas_original);
        blas_current = blas_original;
        pthread_cond_broadcast(&blas_idle);
    }
    pthread_mutex_unlock(&blas_lock);
}

/* CHOLMOD's supernodal factorisation also opens OpenMP regions of its own (clearing, copying and
 * assembling supernodes) with a fixed team of 4 threads, a constant of its build: on a machine
 * with fewer free cores, or in a world set to 1 thread, those teams oversubscribe the cores and
 * their idle threads spin beside the BLAS (measured: the 9216-tet factorisation 2.5x slower on
 * 2 cores). With dynamic adjustment on and nthreads-var = T in the calling thread, libgomp gives
 * such a region at most T threads. Both settings belong to the calling thread's data
 * environment, so other threads are not affected; they are restored after the CHOLMOD calls. */
typedef struct omp_saved {
    int dynamic, threads;
} omp_saved;

static omp_saved omp_limit(int threads)
{
    omp_saved saved = {0, 0};
#ifdef _OPENMP
    saved.dynamic = omp_get_dynamic();
    saved.threads = omp_get_max_threads();
    omp_set_dynamic(1);
    omp_set_num_threads(threads);
#else
    (void)threads;
#endif
    return saved;
}

static void omp_restore(omp_saved saved)
{
#ifdef _OPENMP
    omp_set_num_threads(saved.threads);
    omp_set_dynamic(saved.dynamic);
#else
    (void)saved;
#endif
}

/* ------------------------------------------------------------------------------------------ */
/* ------------------------------------------------------------------------------------------ */
/* Per-world solver. Kept behind a pointer: cholmod_common is large and must not move. */

typedef struct ic_solver {
    defsim__ic_solver pub;     /* what schemes see; first, so the pointers convert */
    double tolerance;          /* relative (options) */
    double contact_tolerance;  /* relative to dhat; 0: contact steps stop as the others */
    int max_iterations;
    int stiffness_damping;
    int auto_projection;       /* projection auto (and the host can assemble the clamped) */
    double gravity[3];
    defsim_csc pat;            /* upper triangle over free DOFs (borrowed from the system) */
    double *hval;              /* Hessian values, pat.nnz */
    double *x, *xt;            /* dof_count */
    double *grad, *dx;         /* free DOFs */
    int coupled;               /* the host has the coupling services (pin_positions, ...) */
    int contact;               /* the host has the contact services (ABI 5) */
    int versioned;             /* the host has matrix_pattern_version (ABI 6) */
    int contact_scaled;        /* the host has contact_active_dhat (ABI 8) */
    uint64_t pattern_version;  /* of the pattern in pat (and the analysis in L) */
    int ordering;              /* CHOLMOD_AMD or _METIS once the first analysis chose, else -1 */
    int64_t analyses;          /* symbolic analyses since init */
    double *dxf;               /* the Newton update over all DOFs (contact_max_step) */
    const int64_t *dof_free;   /* DOF -> free index or -1 */
    double *dpin, *fpd;        /* driven pins: x_p - z_p, and -B(x_b) (x_p - z_p) on free DOFs */
    int fpd_on;                /* this step's g has the pins' damping cross term */
    defsim__chol ch;           /* A wraps pat and hval */
    double *adj;               /* the adjoint step's workspace (ic_adjoint), made on first use */
    int64_t adj_nnz;           /* the pattern's nnz it was made for */
} ic_solver;

static void ic_fini(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)sys;
    ic_solver **slot = state, *s = *slot;
    if (!s) return;
    defsim__chol_finish(&s->ch);
    defsim__ic_solver *p = &s->pub;
    double *owned[] = {s->hval, p->bval, p->x0, p->v0, p->y, p->z, s->x, s->xt, p->f,
                       s->grad, s->dx, p->e, p->be, s->dpin, s->fpd, s->dxf, s->adj};
    for (size_t k = 0; k < sizeof owned / sizeof *owned; ++k) host->release(owned[k]);
    for (int k = 0; k < DEFSIM__IC_MAX_WORK; ++k) host->release(p->work[k]);
    host->release(s);
    *slot = NULL;
}

static double *alloc_doubles(const defsim_host *host, int64_t n)
{
    return host->alloc((size_t)(n > 0 ? n : 1) * sizeof(double));
}

/* ------------------------------------------------------------------------------------------ */
/* Options ("<backend>.<name>"), the same for every scheme. "projection" is read by the core's
 * matrix assembly itself; the others here, at init. */

enum {
    OPT_TOLERANCE, OPT_MAX_ITERATIONS, OPT_PROJECTION, OPT_ORDERING, OPT_FACTOR,
    OPT_CONTACT_TOLERANCE, OPT_COUNT
};
static const char ORDERINGS[] = "best|amd|metis", FACTORS[] = "auto|supernodal|simplicial";

static const defsim_option_spec ic_options[OPT_COUNT] = {
    [OPT_TOLERANCE] = {.name = "tolerance", .type = DEFSIM_OPTION_REAL, .default_value = 1e-6,
        /* Below 1e-14 the test asks for less than the rounding of the positions themselves
         * (2.2e-16 of coordinates that may be larger than L): Newton could only run out. */
        .min_value = 1e-14, .max_value = 1.0,
        .doc = "Newton stops when no DOF's update exceeds tolerance x L (L: diagonal of the rest "
               "positions' bounding box); relative, in [1e-14, 1]"},
    [OPT_MAX_ITERATIONS] = {.name = "max_iterations", .type = DEFSIM_OPTION_INT,
        .default_value = 50, .min_value = 1, .max_value = 1e6,
        .doc = "Newton iterations per step before the step fails with NOT_CONVERGED"},
    [OPT_PROJECTION] = {.name = "projection", .type = DEFSIM_OPTION_CHOICE,
        .default_value = DEFSIM_PROJECTION_CLAMP, .choices = "none|clamp|abs|auto",
        .doc = "element Hessians: exact (none), negative eigenvalues set to 0 (clamp) or to "
               "their magnitude (abs), or exact while the Newton matrix is positive definite "
               "and clamped for an iteration where it is not (auto)"},
    [OPT_ORDERING] = {.name = "cholmod_ordering", .type = DEFSIM_OPTION_CHOICE,
        .choices = ORDERINGS,
        .doc = "fill-reducing ordering: best (AMD and METIS, the one with less fill), amd or "
               "metis; the environment variable DEFSIM_CHOLMOD_ORDERING gives the default"},
    [OPT_FACTOR] = {.name = "cholmod_factor", .type = DEFSIM_OPTION_CHOICE, .choices = FACTORS,
        .doc = "factorisation: auto (CHOLMOD's choice), supernodal or simplicial; the "
               "environment variable DEFSIM_CHOLMOD_FACTOR gives the default"},
    [OPT_CONTACT_TOLERANCE] = {.name = "contact_tolerance", .type = DEFSIM_OPTION_REAL,
        .default_value = 1e-2, .min_value = 0.0, .max_value = 1.0,
        .doc = "with barrier contact active, Newton also stops once the update and the updates "
               "its contraction predicts are within tc = max(tolerance x L, contact_tolerance x "
               "dhat), the full update is collision-free and each DOF's residual is below "
               "c_m m tc / h^2 or contact_tolerance x the forces it balances: a step then "
               "keeps at most about tc of position error; relative to dhat, in [0, 1]; 0: the "
               "old stop"},
};

static const defsim_counter_spec ic_core_counters[DEFSIM__IC_COUNTERS] = {
    {"shifted_factorisations", "Newton iterations whose Hessian needed a diagonal shift to be "
                               "positive definite (only with projection none)"},
    {"contact_stops", "steps that the contact stop ended (contact_tolerance) before the update "
                      "came within tolerance x L"},
    {"newton_iterations", "Newton iterations"},
    {"line_search_backtracks", "step halvings in the line search"},
    {"linear_solves", "Newton systems solved (CHOLMOD)"},
    {"convergence_failures", "steps that failed with DEFSIM_ERR_NOT_CONVERGED"},
    {"time_factor", "wall time of the numeric factorisations (s)"},
    {"time_solve", "wall time of the triangular solves (s)"},
    {"nonlinear_residual", "max norm of the gradient of the step's energy (N) at the last "
                           "Newton iteration of the last step (a level, not a sum)"},
    {"clamped_iterations", "Newton iterations whose exact Hessian was not positive definite, so "
                           "that they used the clamped one (only with projection auto)"},
    {"extrapolations", "clamped iterations (projection auto) whose full step found less "
                       "curvature than the clamped model, so that the line search tried longer "
                       "steps"},
};

/* The index of `name` in the '|'-separated `choices`, or -1. */
static int choice_index(const char *choices, const char *name)
{
    const size_t len = strlen(name);
    const char *p = choices;
    for (int k = 0;; ++k) {
        const size_t n = strcspn(p, "|");
        if (n == len && strncmp(p, name, len) == 0) return k;
        if (!p[n]) return -1;
        p += n + 1;
    }
}

/* A CHOICE option; the environment variable, when it names one of its choices, gives the
 * default: an option the host set wins (a host of ABI 7 or later says which it set). */
static int choice_option(const defsim_host *host, const defsim_system *sys, const double *values,
                         int opt, const char *env)
{
    const int set = host->size >= offsetof(defsim_host, option_is_set) +
                                      sizeof host->option_is_set &&
                    host->option_is_set(sys, opt);
    const char *e = set ? NULL : getenv(env);
    const int k = e ? choice_index(ic_options[opt].choices, e) : -1;
    return k >= 0 ? k : (int)values[opt];
}

/* Orderings to try: AMD and METIS ("best"), or one of them. */
static void ordering_methods(cholmod_common *cc, int ordering)
{
    if (ordering == 1 || ordering == 2) {
        cc->nmethods = 1;
        cc->method[0].ordering = ordering == 1 ? CHOLMOD_AMD : CHOLMOD_METIS;
    } else {
        cc->nmethods = 2;
        cc->method[0].ordering = CHOLMOD_AMD;
        cc->method[1].ordering = CHOLMOD_METIS;
    }
}

static pthread_mutex_t analysis_lock = PTHREAD_MUTEX_INITIALIZER;

static defsim_status analyse(ic_solver *s, const defsim_host *host, defsim_system *sys);
static void say(const ic_solver *s, const defsim_host *host, defsim_system *sys,
                const char *message);

static defsim_status ic_init(const defsim_host *host, defsim_system *sys, void *state)
{
    const defsim__ic_scheme *scheme = &defsim__ic_module_scheme;
    ic_solver **slot = state;
    ic_solver *s = host->alloc(sizeof *s);
    if (!s) return DEFSIM_ERR_OUT_OF_MEMORY;
    memset(s, 0, sizeof *s);
    *slot = s;
    s->ordering = -1;
    defsim__ic_solver *p = &s->pub;
    p->scheme = scheme;
    p->ndof = host->dof_count(sys);
    p->n = host->free_dof_count(sys);
    p->fdof = host->free_dofs(sys);
    p->mass = host->mass(sys);
    p->alpha = host->mass_damping(sys);
    s->stiffness_damping = host->has_stiffness_damping(sys);
    const double *opt = host->option_values(sys);
    s->tolerance = opt[OPT_TOLERANCE];
    s->contact_tolerance = opt[OPT_CONTACT_TOLERANCE];
    s->max_iterations = (int)opt[OPT_MAX_ITERATIONS];
    s->auto_projection = (int)opt[OPT_PROJECTION] == DEFSIM_PROJECTION_AUTO &&
                         host->size >= offsetof(defsim_host, matrix_values_projected) +
                                           sizeof host->matrix_values_projected;
    p->counters = host->counters(sys);
    host->gravity(sys, s->gravity);
    p->x0 = alloc_doubles(host, p->ndof);
    p->v0 = alloc_doubles(host, p->ndof);
    p->y = alloc_doubles(host, p->ndof);
    p->z = alloc_doubles(host, p->ndof);
    s->x = alloc_doubles(host, p->ndof);
    s->xt = alloc_doubles(host, p->ndof);
    p->f = alloc_doubles(host, p->ndof);
    s->grad = alloc_doubles(host, p->n);
    s->dx = alloc_doubles(host, p->n);
    p->e = alloc_doubles(host, p->n);
    p->be = alloc_doubles(host, p->n);
    if (!p->x0 || !p->v0 || !p->y || !p->z || !s->x || !s->xt || !p->f || !s->grad || !s->dx ||
        !p->e || !p->be)
        return DEFSIM_ERR_OUT_OF_MEMORY;
    for (int k = 0; k < scheme->work_vectors && k < DEFSIM__IC_MAX_WORK; ++k)
        if (!(p->work[k] = alloc_doubles(host, p->ndof))) return DEFSIM_ERR_OUT_OF_MEMORY;
    if (p->n == 0) return DEFSIM_OK;   /* everything pinned: nothing to solve */

    defsim_status status = host->matrix_pattern(sys, DEFSIM_TRIANGLE_UPPER, &s->pat);
    if (status != DEFSIM_OK) return status;
    s->hval = alloc_doubles(host, s->pat.nnz);
    if (!s->hval) return DEFSIM_ERR_OUT_OF_MEMORY;
    memset(s->hval, 0, (size_t)s->pat.nnz * sizeof *s->hval);
    if (s->stiffness_damping) {
        p->bval = alloc_doubles(host, s->pat.nnz);
        if (!p->bval) return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    s->coupled = host->size >= offsetof(defsim_host, applied_forces_vary) +
                                   sizeof host->applied_forces_vary;
    s->dof_free = host->dof_to_free(sys);
    s->contact = host->size >= offsetof(defsim_host, contact_start) + sizeof host->contact_start;
    s->versioned = host->size >= offsetof(defsim_host, matrix_pattern_version) +
                                     sizeof host->matrix_pattern_version;
    s->contact_scaled = host->size >= offsetof(defsim_host, contact_active_dhat) +
                                          sizeof host->contact_active_dhat;
    if (s->contact) {
        s->dxf = alloc_doubles(host, p->ndof);
        if (!s->dxf) return DEFSIM_ERR_OUT_OF_MEMORY;
        memset(s->dxf, 0, (size_t)p->ndof * sizeof *s->dxf);
    }
    if (s->coupled && s->stiffness_damping) {
        s->dpin = alloc_doubles(host, p->ndof);
        s->fpd = alloc_doubles(host, p->ndof);
        if (!s->dpin || !s->fpd) return DEFSIM_ERR_OUT_OF_MEMORY;
    }

    defsim__chol_start(&s->ch);
    /* Fill-reducing ordering: AMD and METIS, keeping the one with less fill (METIS halves the
     * flops on the 100k-tet beam). METIS keeps global random state, so analyses run one at a
     * time in the process (analysis_lock): then its ordering is the same on every run. */
    ordering_methods(&s->ch.cc,
                     choice_option(host, sys, opt, OPT_ORDERING, "DEFSIM_CHOLMOD_ORDERING"));
    s->ch.cc.postorder = 1;
    const int factor = choice_option(host, sys, opt, OPT_FACTOR, "DEFSIM_CHOLMOD_FACTOR");
    s->ch.cc.supernodal = factor == 1 ? CHOLMOD_SUPERNODAL
                       : factor == 2 ? CHOLMOD_SIMPLICIAL : CHOLMOD_AUTO;
    s->ch.cc.quick_return_if_not_posdef = 1;
    s->ch.cc.print = 0;

    s->ch.rhs = cholmod_l_zeros((size_t)p->n, 1, CHOLMOD_REAL, &s->ch.cc);
    if (!s->ch.rhs) {
        say(s, host, sys, "out of memory for CHOLMOD's right-hand side");
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    if (s->versioned) s->pattern_version = host->matrix_pattern_version(sys);
    return analyse(s, host, sys);
}

/* Body contact grows the pattern during a run (matrix_pattern_version, ABI 6): when it changed,
 * fetch it again, move the values to its layout and redo the symbolic analysis. */
static defsim_status sync_pattern(ic_solver *s, const defsim_host *host, defsim_system *sys)
{
    if (!s->versioned) return DEFSIM_OK;
    const uint64_t version = host->matrix_pattern_version(sys);
    if (version == s->pattern_version) return DEFSIM_OK;
    if (version == 0) return DEFSIM_ERR_OUT_OF_MEMORY;   /* the host set the message */
    defsim__ic_solver *p = &s->pub;
    defsim_status st = host->matrix_pattern(sys, DEFSIM_TRIANGLE_UPPER, &s->pat);
    if (st != DEFSIM_OK) return st;
    host->release(s->hval);
    s->hval = alloc_doubles(host, s->pat.nnz);
    if (!s->hval) return DEFSIM_ERR_OUT_OF_MEMORY;
    memset(s->hval, 0, (size_t)s->pat.nnz * sizeof *s->hval);
    if (p->bval) {
        host->release(p->bval);
        p->bval = alloc_doubles(host, s->pat.nnz);
        if (!p->bval) return DEFSIM_ERR_OUT_OF_MEMORY;
        if (p->xb && (st = defsim__ic_damping_matrix(p, host, sys, p->xb)) != DEFSIM_OK)
            return st;
    }
    cholmod_l_free_factor(&s->ch.L, &s->ch.cc);
    s->pattern_version = version;
    return analyse(s, host, sys);
}

/* CHOLMOD's symbolic analysis of the pattern in pat (the values in hval). */
static defsim_status analyse(ic_solver *s, const defsim_host *host, defsim_system *sys)
{
    const defsim__ic_solver *p = &s->pub;
    defsim__chol_wrap(&s->ch, &s->pat, s->hval);

    /* The first analysis chooses the ordering ("best": AMD and METIS, the one with less fill);
     * the later ones (the pattern grew by contact pairs) keep that method: trying both again on
     * every growth cost a seventh of the 32 x 32 cloth fold's step. The choice is part of the
     * solver's state (ic_save), so a loaded world orders as the one that saved it. */
    const int nmethods = s->ch.cc.nmethods, first = s->ch.cc.method[0].ordering;
    if (s->ordering >= 0) {
        s->ch.cc.nmethods = 1;
        s->ch.cc.method[0].ordering = s->ordering;
    }
    double t0 = host->wall_time();
    pthread_mutex_lock(&analysis_lock);
    s->ch.L = cholmod_l_analyze(&s->ch.A, &s->ch.cc);
    pthread_mutex_unlock(&analysis_lock);
    s->ch.cc.nmethods = nmethods;
    s->ch.cc.method[0].ordering = first;
    if (s->ch.L && s->ordering < 0 &&
        (s->ch.L->ordering == CHOLMOD_AMD || s->ch.L->ordering == CHOLMOD_METIS))
        s->ordering = s->ch.L->ordering;
    if (!s->ch.L) {
        char why[128];
        snprintf(why, sizeof why, "CHOLMOD analysis failed (CHOLMOD status %d)", s->ch.cc.status);
        say(s, host, sys, why);
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    s->analyses++;
    const int ord = s->ch.L->ordering;
    char msg[256];
    snprintf(msg, sizeof msg,
             "%s: %lld free DOFs, nnz(A upper) %lld, nnz(L) %.0f, %.3g Gflop per "
             "factorisation, %s, %s ordering, analysis %.3f s (analysis %lld of this set-up)",
             p->scheme->name, (long long)p->n, (long long)s->pat.nnz, s->ch.cc.lnz,
             s->ch.cc.fl * 1e-9, s->ch.L->is_super ? "supernodal" : "simplicial",
             ord == CHOLMOD_METIS ? "METIS" : ord == CHOLMOD_AMD ? "AMD" : "other",
             host->wall_time() - t0, (long long)s->analyses);
    host->log(sys, 2, msg);
    return DEFSIM_OK;
}

static defsim_status ic_reset(const defsim_host *host, defsim_system *sys, void *state)
{
    (void)host;
    (void)sys;
    ic_solver *s = *(ic_solver **)state;
    if (s) s->pub.history_valid = 0;
    return DEFSIM_OK;
}

/* Checkpoints: the scheme's history (x_{n-1}, v_{n-1} and h_{n-1} for bdf2; nothing that
 * outlives a step for backward Euler and Newmark, which save only the empty flag). */
static defsim_status ic_save(const defsim_host *host, defsim_system *sys, const void *state,
                             const defsim_state_writer *wr)
{
    (void)host;
    (void)sys;
    const ic_solver *s = *(ic_solver *const *)state;
    const defsim__ic_solver *p = &s->pub;
    const int64_t valid = p->history_valid && p->scheme->history_vectors > 0;
    defsim_status st = wr->i64(wr->ctx, &valid, 1);
    if (st == DEFSIM_OK && valid) st = wr->f64(wr->ctx, &p->history_h, 1);
    for (int k = 0; st == DEFSIM_OK && valid && k < p->scheme->history_vectors; ++k)
        st = wr->f64(wr->ctx, p->work[k], p->ndof);
    /* since issue 30: the ordering method the analyses keep (absent in older files) */
    const int64_t ordering = s->ordering;
    if (st == DEFSIM_OK) st = wr->i64(wr->ctx, &ordering, 1);
    return st;
}

static defsim_status ic_load(const defsim_host *host, defsim_system *sys, void *state,
                             const defsim_state_reader *rd)
{
    ic_solver *s = *(ic_solver **)state;
    defsim__ic_solver *p = &s->pub;
    int64_t valid = 0;
    defsim_status st = rd->i64(rd->ctx, &valid, 1);
    if (st != DEFSIM_OK) return st;
    if (valid != 0 && (valid != 1 || p->scheme->history_vectors == 0)) return DEFSIM_ERR_IO;
    if (valid && (st = rd->f64(rd->ctx, &p->history_h, 1)) != DEFSIM_OK) return st;
    for (int k = 0; valid && k < p->scheme->history_vectors; ++k)
        if ((st = rd->f64(rd->ctx, p->work[k], p->ndof)) != DEFSIM_OK) return st;
    if (valid && !(p->history_h > 0.0)) return DEFSIM_ERR_IO;
    p->history_valid = (int)valid;
    if (rd->remaining(rd->ctx) == 0) return DEFSIM_OK;
    int64_t ordering = -1;
    if ((st = rd->i64(rd->ctx, &ordering, 1)) != DEFSIM_OK) return st;
    if (ordering != -1 && ordering != CHOLMOD_AMD && ordering != CHOLMOD_METIS)
        return DEFSIM_ERR_IO;
    /* init analysed the loaded pattern afresh; the saved world's analyses kept its first
     * choice: analyse again with that one, so that the factorisations are the same */
    if (ordering < 0 || ordering == s->ordering || !s->ch.L) return DEFSIM_OK;
    s->ordering = (int)ordering;
    cholmod_l_free_factor(&s->ch.L, &s->ch.cc);
    return analyse(s, host, sys);
}

/* ------------------------------------------------------------------------------------------ */
/* The incremental potential, its gradient and Hessian, over the free DOFs. */

/* out = B in with B stored as its upper triangle (symmetric). */
static void sym_upper_product(const ic_solver *s, const double *v, const double *in, double *out)
{
    const int64_t *cp = s->pat.col_ptr, *ri = s->pat.row_idx;
    memset(out, 0, (size_t)s->pub.n * sizeof *out);
    for (int64_t j = 0; j < s->pub.n; ++j) {
        double sum = 0.0;
        for (int64_t p = cp[j]; p < cp[j + 1]; ++p) {
            const int64_t i = ri[p];
            if (i == j) {
                sum += v[p] * in[j];
            } else {
                sum += v[p] * in[i];
                out[i] += v[p] * in[j];
            }
        }
        out[j] += sum;
    }
}

void defsim__ic_damping_product(const defsim__ic_solver *p, const double *in, double *out)
{
    if (p->bval) sym_upper_product((const ic_solver *)p, p->bval, in, out);
    else memset(out, 0, (size_t)p->n * sizeof *out);
}

defsim_status defsim__ic_damping_matrix(defsim__ic_solver *p, const defsim_host *host,
                                        defsim_system *sys, const double *xb)
{
    p->xb = xb;
    if (!p->bval) return DEFSIM_OK;
    const defsim_matrix_coeffs cb = {0.0, 1.0, 0.0, 0.0};
    return host->matrix_values(sys, xb, &cb, DEFSIM_TRIANGLE_UPPER, p->bval);
}

/* e = x - z over the free DOFs, and be = B e if there is stiffness damping. */
static void displacement(ic_solver *s, const defsim__ic_targets *st, const double *x)
{
    defsim__ic_solver *p = &s->pub;
    for (int64_t k = 0; k < p->n; ++k) p->e[k] = x[p->fdof[k]] - st->z[p->fdof[k]];
    if (p->bval) sym_upper_product(s, p->bval, p->e, p->be);
}

/* g(x); +inf where the energy is undefined. *scale receives a magnitude of g's terms, so that
 * the line search knows which decreases it can resolve. */
static double merit(ic_solver *s, const defsim__ic_targets *st, const defsim_host *host,
                    defsim_system *sys, const double *x, double h, double *scale)
{
    defsim__ic_solver *p = &s->pub;
    const double pe = host->potential_energy(sys, x);
    if (!isfinite(pe)) return INFINITY;
    displacement(s, st, x);
    double inertia = 0.0, damping = 0.0, grav = 0.0;
    for (int64_t k = 0; k < p->n; ++k) {
        const int64_t i = p->fdof[k];
        const double d = x[i] - st->y[i], e = p->e[k];
        inertia += p->mass[i] * d * d;
        damping += p->alpha[i] * p->mass[i] * e * e;
        if (p->bval) damping += e * p->be[k];
        if (s->fpd_on) damping -= 2.0 * e * s->fpd[i];
        grav += p->mass[i] * fabs(s->gravity[i % 3] * x[i]);
    }
    inertia = st->cm * inertia / (2.0 * h * h);
    damping = st->cd * damping / (2.0 * h);
    if (scale) *scale = inertia + damping + fabs(pe) + grav;
    return inertia + pe + damping;
}

/* grad g(x) over the free DOFs. */
static defsim_status gradient(ic_solver *s, const defsim__ic_targets *st, const defsim_host *host,
                              defsim_system *sys, const double *x, double h)
{
    defsim__ic_solver *p = &s->pub;
    defsim_status status = host->forces(sys, x, NULL,
                                        DEFSIM_FORCE_ELASTIC | DEFSIM_FORCE_GRAVITY, p->f);
    if (status != DEFSIM_OK) return status;
    displacement(s, st, x);
    const double ih2 = st->cm / (h * h), ih = st->cd / h;
    for (int64_t k = 0; k < p->n; ++k) {
        const int64_t i = p->fdof[k];
        double damping = p->alpha[i] * p->mass[i] * p->e[k] + (p->bval ? p->be[k] : 0.0);
        if (s->fpd_on) damping -= s->fpd[i];
        s->grad[k] = p->mass[i] * (x[i] - st->y[i]) * ih2 - p->f[i] + damping * ih;
    }
    return DEFSIM_OK;
}

/* Hessian of g at x: K(x) + c_m M / h^2 + c_d (alpha M + B) / h, into hval; with `clamped`,
 * the element Hessians clamped to PSD (projection auto, where the exact matrix is not PD). */
static defsim_status hessian(ic_solver *s, const defsim__ic_targets *st, const defsim_host *host,
                             defsim_system *sys, const double *x, double h, int clamped)
{
    const defsim_matrix_coeffs c = {1.0, 0.0, st->cm / (h * h), st->cd / h};
    defsim_status status =
        clamped ? host->matrix_values_projected(sys, x, &c, DEFSIM_TRIANGLE_UPPER,
                                                DEFSIM_PROJECTION_CLAMP, s->hval)
                : host->matrix_values(sys, x, &c, DEFSIM_TRIANGLE_UPPER, s->hval);
    if (status != DEFSIM_OK) return status;
    if (s->pub.bval)
        for (int64_t p = 0; p < s->pat.nnz; ++p) s->hval[p] += st->cd * s->pub.bval[p] / h;
    return DEFSIM_OK;
}

/* Adds shift * m_i / h^2 to the diagonal (the last entry of each column of the upper pattern). */
static void add_shift(ic_solver *s, double shift, double h)
{
    for (int64_t j = 0; j < s->pub.n; ++j)
        s->hval[s->pat.col_ptr[j + 1] - 1] += shift * s->pub.mass[s->pub.fdof[j]] / (h * h);
}

/* A simplicial LDL' factorisation succeeds on indefinite matrices; the matrix is positive
 * definite exactly when every pivot D(j,j) (first entry of column j) is positive. Supernodal and
 * LL' factorisations report NOT_POSDEF themselves. */
static int ldl_positive(const cholmod_factor *L)
{
    if (L->is_super || L->is_ll) return 1;
    const SuiteSparse_long *lp = L->p;
    const double *lx = L->x;
    for (size_t j = 0; j < L->n; ++j)
        if (!(lx[lp[j]] > 0.0)) return 0;
    return 1;
}

/* Sets the world's error to "<backend>: <message>". */
static void say(const ic_solver *s, const defsim_host *host, defsim_system *sys,
                const char *message)
{
    char msg[320];
    snprintf(msg, sizeof msg, "%s: %s", s->pub.scheme->name, message);
    host->set_error(sys, msg);
}

/* Factorises the Hessian and solves H dx = -grad. An exact (unprojected) Hessian can be
 * indefinite: then the factorisation fails or dx is not a descent direction, and the diagonal is
 * shifted by growing multiples of M / h^2 until it is. *slope receives grad . dx. */
static defsim_status factor_solve(ic_solver *s, const defsim_host *host, defsim_system *sys,
                                  double h, int shifts, double *slope)
{
    double *count = s->pub.counters;
    const int64_t n = s->pub.n;
    /* Called from inside the host's own parallel region (worlds stepped in parallel), the
     * assembly runs on one thread (nested regions are inactive), and so should the BLAS:
     * T threads per world times the host's threads would oversubscribe the cores. */
    int threads = host->num_threads(sys);
#ifdef _OPENMP
    if (omp_in_parallel()) threads = 1;
#endif
    double shift = 0.0;
    defsim_status result = DEFSIM_OK;
    /* OpenBLAS splits its work by thread count, which changes the rounding: a small
     * factorisation, where a second thread gains nothing, runs its BLAS on one thread, so that
     * its results are the same for every thread count. */
    blas_enter(s->ch.cc.fl < IC_BLAS_SERIAL_FLOPS ? 1 : threads);
    const omp_saved omp = omp_limit(threads);
    for (int attempt = 0;; ++attempt) {
        double t0 = host->wall_time();
        cholmod_l_factorize(&s->ch.A, s->ch.L, &s->ch.cc);
        count[DEFSIM__IC_TIME_FACTOR] += host->wall_time() - t0;
        if (s->ch.cc.status < CHOLMOD_OK) {
            say(s, host, sys, "CHOLMOD factorisation failed (out of memory)");
            result = DEFSIM_ERR_OUT_OF_MEMORY;
            break;
        }
        if (s->ch.cc.status == CHOLMOD_OK && ldl_positive(s->ch.L)) {
            double *b = s->ch.rhs->x;
            for (int64_t k = 0; k < n; ++k) b[k] = -s->grad[k];
            t0 = host->wall_time();
            int ok = cholmod_l_solve2(CHOLMOD_A, s->ch.L, s->ch.rhs, NULL, &s->ch.sol, NULL,
                                      &s->ch.ywork, &s->ch.ework, &s->ch.cc);
            count[DEFSIM__IC_TIME_SOLVE] += host->wall_time() - t0;
            count[DEFSIM__IC_LINEAR_SOLVES] += 1.0;
            if (!ok) {
                say(s, host, sys, "CHOLMOD solve failed (out of memory)");
                result = DEFSIM_ERR_OUT_OF_MEMORY;
                break;
            }
            const double *xs = s->ch.sol->x;
            double d = 0.0, dmax = 0.0;
            for (int64_t k = 0; k < n; ++k) {
                s->dx[k] = xs[k];
                d += s->grad[k] * xs[k];
                dmax = fmax(dmax, fabs(xs[k]));
            }
            *slope = d;
            if (d < 0.0 || dmax == 0.0) break;
            if (!isfinite(d)) {
                say(s, host, sys, "the Newton step is not finite");
                result = DEFSIM_ERR_UNSTABLE;
                break;
            }
        }
        if (shifts == 0) {
            result = DEFSIM__IC_INDEFINITE;
            break;
        }
        if (attempt == IC_MAX_SHIFTS) {
            say(s, host, sys, "the Hessian stays indefinite after shifting its diagonal by "
                              "1e11 M/h^2");
            result = DEFSIM_ERR_NOT_CONVERGED;
            break;
        }
        if (shift == 0.0) s->pub.counters[DEFSIM__IC_SHIFTED] += 1.0;
        const double next = shift == 0.0 ? 1.0 : 10.0 * shift;
        add_shift(s, next - shift, h);
        shift = next;
    }
    omp_restore(omp);
    blas_leave();
    return result;
}

/* ------------------------------------------------------------------------------------------ */
/* One step. */

static defsim_status fail(const ic_solver *s, const defsim_host *host, defsim_system *sys,
                          defsim_status st, const char *message)
{
    if (st == DEFSIM_ERR_NOT_CONVERGED) s->pub.counters[DEFSIM__IC_CONVERGENCE_FAILURES] += 1.0;
    say(s, host, sys, message);
    return st;
}

/* Driven pins move their DOFs from z_p to x_p over the step; through the damping term of g,
 * c_d/(2h) |x - z|^2_D, that motion pulls on the free DOFs: the cross term c_d/h e . D_fp
 * (x_p - z_p) = -c_d/h e . fpd with fpd = -B(x_b) (x_p - z_p) on the free rows (the forces'
 * damping part at x_b with that velocity-like vector; alpha M is diagonal and adds nothing). */
static defsim_status pin_damping(ic_solver *s, const defsim__ic_targets *stp,
                                 const defsim_host *host, defsim_system *sys)
{
    defsim__ic_solver *p = &s->pub;
    s->fpd_on = p->pin_vel != NULL && p->bval != NULL && s->dpin != NULL;
    if (!s->fpd_on) return DEFSIM_OK;
    for (int64_t i = 0; i < p->ndof; ++i)
        s->dpin[i] = s->dof_free[i] < 0 ? s->x[i] - stp->z[i] : 0.0;
    return host->forces(sys, p->xb, s->dpin, DEFSIM_FORCE_DAMPING, s->fpd);
}

/* The contact stop (README.md, "Newton's method", 5): with barrier contact active at x (dhat > 0
 * from the host), the iteration has converged when, with tc = max(tol, contact_tolerance dhat),
 *  - the update moves no free DOF by more than tc, and the full update is collision-free;
 *  - the updates still to come, estimated from the contraction rho = |dx|_inf / |dx_prev|_inf of
 *    the last full step as |dx|_inf rho / (1 - rho) (a geometric tail), stay within tc;
 *  - every DOF's residual grad_i is small: below the force that would move it by tc against
 *    its inertia alone (c_m m_i tc / h^2), or below contact_tolerance times the forces it
 *    balances (|inertia_i| + |f_i| + |damping_i|: the equation of motion holds to that fraction
 *    of its terms, which a stiff barrier's force makes large where its stiffness makes dx tiny).
 * dx_prev is the previous iteration's |dx|_inf when that update was taken whole, else 0 (no
 * contraction known: no contact stop). Reads grad, f and the displacement e at x (what gradient
 * left there) and dx; changes nothing. */
static int contact_converged(const ic_solver *s, const defsim__ic_targets *st, const double *x,
                             double h, double dhat, double tol, double dxmax, double dx_prev,
                             double alpha_max)
{
    const defsim__ic_solver *p = &s->pub;
    if (!(s->contact_tolerance > 0.0 && dhat > 0.0 && alpha_max >= 1.0 && dx_prev > 0.0))
        return 0;
    const double tc = fmax(tol, s->contact_tolerance * dhat);
    const double rho = dxmax / dx_prev;
    if (!(dxmax <= tc && rho < 1.0 && dxmax * rho <= tc * (1.0 - rho))) return 0;
    const double ih2 = st->cm / (h * h), ih = st->cd / h;
    for (int64_t k = 0; k < p->n; ++k) {
        const int64_t i = p->fdof[k];
        const double r = fabs(s->grad[k]);
        if (r <= ih2 * p->mass[i] * tc) continue;
        double damping = p->alpha[i] * p->mass[i] * p->e[k] + (p->bval ? p->be[k] : 0.0);
        if (s->fpd_on) damping -= s->fpd[i];
        const double terms = fabs(ih2 * p->mass[i] * (x[i] - st->y[i])) + fabs(p->f[i]) +
                             fabs(ih * damping);
        if (!(r <= s->contact_tolerance * terms)) return 0;
    }
    return 1;
}

/* Projection auto, after a full step x -> xt = x + dx that the clamped Hessian gave and whose
 * decrease gt - gx <= IC_EXTRAPOLATE_RATIO slope shows less curvature along dx than the
 * clamped model has (the exact Hessian was indefinite: compressed springs, buckling): longer
 * steps a dx along the same direction, a from the minimiser of the quadratic through g(0),
 * g'(0) = slope and the last g(a), kept in [2 a, 4 a] and within what CCD allows along the
 * way (up to IC_EXTRAPOLATE_MAX dx), each taken while it satisfies Armijo's condition
 * against the last. Leaves the furthest accepted point in xt (and its g in *gt, its scale in
 * *tscale) and returns its a (1: none). Measured on the cloth fold (docs/contact-scale.md):
 * 6 % fewer Newton iterations at 48 x 48. */
static double extrapolate(ic_solver *s, const defsim__ic_targets *stp, const defsim_host *host,
                          defsim_system *sys, double h, double gx, double slope, double *gt,
                          double *tscale)
{
    defsim__ic_solver *p = &s->pub;
    double cap = IC_EXTRAPOLATE_MAX;
    if (s->contact) {
        /* CCD from x + dx along (IC_EXTRAPOLATE_MAX - 1) dx; xt is x + dx (dxf held dx) */
        for (int64_t k = 0; k < p->n; ++k)
            s->dxf[p->fdof[k]] = (IC_EXTRAPOLATE_MAX - 1.0) * s->dx[k];
        cap = 1.0 + (IC_EXTRAPOLATE_MAX - 1.0) * host->contact_max_step(sys, s->xt, s->dxf);
    }
    double a = 1.0;
    for (int e = 0; e < IC_EXTRAPOLATIONS && a < cap; ++e) {
        const double c = 2.0 * (*gt - gx - slope * a) / (a * a);
        double an = c > 0.0 ? -slope / c : 4.0 * a;
        an = fmin(fmax(an, 2.0 * a), fmin(4.0 * a, cap));
        if (!(an > a)) break;
        for (int64_t k = 0; k < p->n; ++k) {
            const int64_t i = p->fdof[k];
            s->x[i] = s->xt[i] + (an - a) * s->dx[k];   /* x is scratch here: the trial */
        }
        double ts = 0.0;
        const double gn = merit(s, stp, host, sys, s->x, h, &ts);
        if (!(gn <= *gt + IC_ARMIJO * (an - a) * slope)) break;
        for (int64_t k = 0; k < p->n; ++k) s->xt[p->fdof[k]] = s->x[p->fdof[k]];
        a = an;
        *gt = gn;
        *tscale = ts;
    }
    return a;
}

/* The Newton loop on g from the scheme's guess; on success x holds the minimiser. */
static defsim_status minimise(ic_solver *s, const defsim__ic_targets *stp, const defsim_host *host,
                              defsim_system *sys, double h)
{
    defsim__ic_solver *p = &s->pub;
    double *count = p->counters;
    const size_t bytes = (size_t)p->ndof * sizeof(double);

    /* Start from the scheme's guess; where its energy is undefined (an inverted neo-Hookean
     * element), from x_n. Pinned DOFs stay at x_n throughout, driven ones at their end-of-step
     * positions (Dirichlet values). */
    const double t_end = s->coupled ? host->time(sys) + h : 0.0;
    memcpy(s->x, stp->guess, bytes);
    if (p->pin_vel) host->pin_positions(sys, t_end, s->x);
    if (s->contact) host->contact_start(sys, s->x);
    defsim_status pst = pin_damping(s, stp, host, sys);
    if (pst != DEFSIM_OK) return fail(s, host, sys, pst, "non-finite damping of the driven pins");
    double scale = 0.0;
    double gx = merit(s, stp, host, sys, s->x, h, &scale);
    if (!isfinite(gx)) {
        memcpy(s->x, p->x0, bytes);
        if (p->pin_vel) host->pin_positions(sys, t_end, s->x);
        if (s->contact) host->contact_start(sys, s->x);
        gx = merit(s, stp, host, sys, s->x, h, &scale);
        if (!isfinite(gx))
            return fail(s, host, sys, DEFSIM_ERR_NOT_CONVERGED,
                        "the energy is undefined at the start of the step "
                        "(an inverted neo-Hookean element, or a shell triangle at its strain "
                        "limit?)");
    }
    memcpy(s->xt, s->x, bytes);

    const double tol = s->tolerance * host->length_scale(sys);
    double dx_prev = 0.0;   /* |dx|_inf of the previous update if it was taken whole, else 0 */
    char msg[200];
    for (int it = 1; it <= s->max_iterations; ++it) {
        count[DEFSIM__IC_NEWTON] += 1.0;
        defsim_status st = sync_pattern(s, host, sys);
        if (st != DEFSIM_OK) return fail(s, host, sys, st, "growing the matrix pattern failed");
        st = gradient(s, stp, host, sys, s->x, h);
        if (st != DEFSIM_OK) return fail(s, host, sys, st, "non-finite forces");
        double gmax = 0.0;
        for (int64_t k = 0; k < p->n; ++k) gmax = fmax(gmax, fabs(s->grad[k]));
        count[DEFSIM__IC_RESIDUAL] = gmax;   /* a level, not a sum */
        st = hessian(s, stp, host, sys, s->x, h, 0);
        if (st != DEFSIM_OK) return fail(s, host, sys, st, "Hessian assembly failed");
        double slope = 0.0;
        int clamped_now = 0;
        st = factor_solve(s, host, sys, h, !s->auto_projection, &slope);
        if (st == DEFSIM__IC_INDEFINITE) {
            /* projection auto: the exact matrix is not PD here; the clamped one is */
            count[DEFSIM__IC_CLAMPED] += 1.0;
            clamped_now = 1;
            st = hessian(s, stp, host, sys, s->x, h, 1);
            if (st != DEFSIM_OK) return fail(s, host, sys, st, "Hessian assembly failed");
            st = factor_solve(s, host, sys, h, 1, &slope);
        }
        if (st != DEFSIM_OK) {
            if (st == DEFSIM_ERR_NOT_CONVERGED) count[DEFSIM__IC_CONVERGENCE_FAILURES] += 1.0;
            return st;   /* factor_solve set the message */
        }
        double dxmax = 0.0;
        for (int64_t k = 0; k < p->n; ++k) dxmax = fmax(dxmax, fabs(s->dx[k]));

        /* Contact: no step goes further than continuous collision detection allows, so every
         * iterate stays strictly outside the colliders (the barrier is +inf on them). */
        double alpha_max = 1.0;
        if (s->contact) {
            for (int64_t k = 0; k < p->n; ++k) s->dxf[p->fdof[k]] = s->dx[k];
            alpha_max = host->contact_max_step(sys, s->x, s->dxf);
            if (!(alpha_max > 0.0)) {
                snprintf(msg, sizeof msg, "contact: no feasible step at Newton iteration %d", it);
                return fail(s, host, sys, DEFSIM_ERR_NOT_CONVERGED, msg);
            }
        }

        /* Converged: the update moves no DOF by more than tol. The update is still applied;
         * for exact Newton it squares the remaining error. */
        if (dxmax <= tol) {
            for (int64_t k = 0; k < p->n; ++k) s->x[p->fdof[k]] += alpha_max * s->dx[k];
            return DEFSIM_OK;
        }
        /* With contact active, the stop on contact's scale (contact_converged). */
        const double dhat = s->contact_scaled && s->contact_tolerance > 0.0
                                ? host->contact_active_dhat(sys) : 0.0;
        if (contact_converged(s, stp, s->x, h, dhat, tol, dxmax, dx_prev, alpha_max)) {
            for (int64_t k = 0; k < p->n; ++k) s->x[p->fdof[k]] += s->dx[k];
            p->counters[DEFSIM__IC_CONTACT_STOPS] += 1.0;
            return DEFSIM_OK;
        }

        /* Backtracking line search: Armijo decrease of g from the largest feasible step. A full
         * step whose predicted decrease is below g's resolution is taken if g does not rise
         * beyond that resolution either. */
        const double resolution = IC_G_RESOLUTION * scale;
        double alpha = alpha_max, gt = INFINITY, tscale = 0.0;
        int accepted = 0;
        for (int b = 0; b <= IC_MAX_BACKTRACKS; ++b) {
            for (int64_t k = 0; k < p->n; ++k) {
                const int64_t i = p->fdof[k];
                s->xt[i] = s->x[i] + alpha * s->dx[k];
            }
            gt = merit(s, stp, host, sys, s->xt, h, &tscale);
            if (gt <= gx + IC_ARMIJO * alpha * slope ||
                (b == 0 && -slope <= resolution && gt <= gx + resolution)) {
                accepted = 1;
                break;
            }
            alpha *= 0.5;
            count[DEFSIM__IC_BACKTRACKS] += 1.0;
        }
        if (!accepted) {
            snprintf(msg, sizeof msg,
                     "line search found no decrease at Newton iteration %d (|dx|_inf = %.3g m)",
                     it, dxmax);
            return fail(s, host, sys, DEFSIM_ERR_NOT_CONVERGED, msg);
        }
        /* the contraction the contact stop reads: of the whole update taken (a dx) */
        double taken = alpha == 1.0 ? 1.0 : 0.0;
        if (clamped_now && alpha == 1.0 && gt - gx <= IC_EXTRAPOLATE_RATIO * slope) {
            count[DEFSIM__IC_EXTRAPOLATED] += 1.0;
            taken = extrapolate(s, stp, host, sys, h, gx, slope, &gt, &tscale);
        }
        memcpy(s->x, s->xt, bytes);
        gx = gt;
        scale = tscale;
        dx_prev = taken * dxmax;
    }
    snprintf(msg, sizeof msg, "no convergence in %d Newton iterations (tolerance %.3g m)",
             s->max_iterations, tol);
    return fail(s, host, sys, DEFSIM_ERR_NOT_CONVERGED, msg);
}

static defsim_status ic_step(const defsim_host *host, defsim_system *sys, void *state, double h)
{
    ic_solver *s = *(ic_solver **)state;
    defsim__ic_solver *p = &s->pub;
    double *xw = host->positions(sys), *vw = host->velocities(sys);
    if (p->n == 0) return DEFSIM_OK;   /* every vertex pinned: nothing moves */
    if (!isfinite(1.0 / (h * h))) {
        /* The merit's inertia term is M |x - y|^2 / (2 h^2): no other check names the cause. */
        char msg[160];
        snprintf(msg, sizeof msg, "h = %g s is too small for this backend: its Newton energy "
                 "scales with 1/h^2, which overflows for h below about 1e-154 s", h);
        return fail(s, host, sys, DEFSIM_ERR_INVALID_ARGUMENT, msg);
    }
    const size_t bytes = (size_t)p->ndof * sizeof(double);
    memcpy(p->x0, xw, bytes);
    memcpy(p->v0, vw, bytes);
    p->pin_vel = s->coupled ? host->pin_velocities(sys) : NULL;

    /* Body contact may have rebuilt the pattern between steps (it keeps only the pairs of the
     * contacts at a step's end): the damping product of the scheme's start reads it already. */
    defsim_status st = sync_pattern(s, host, sys);
    if (st != DEFSIM_OK) return fail(s, host, sys, st, "growing the matrix pattern failed");
    defsim__ic_targets stp = {0};
    st = p->scheme->prepare(p, host, sys, h, &stp);
    if (st == DEFSIM_OK) st = minimise(s, &stp, host, sys, h);
    else fail(s, host, sys, st, "damping matrix or forces at the start of the step failed");
    if (st != DEFSIM_OK) {
        p->history_valid = 0;
        return st;
    }
    for (int64_t k = 0; k < p->n; ++k) {
        const int64_t i = p->fdof[k];
        vw[i] = stp.cd * (s->x[i] - stp.z[i]) / h;
        xw[i] = s->x[i];
    }
    if (p->scheme->accept) p->scheme->accept(p, h);
    return DEFSIM_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* The adjoint step (docs/gradients.md). A converged step x1 solves
 *
 *   r(x1) = c_m M (x1 - y)/h^2 - f_EG(x1) - f_D(z, v1) = 0,   v1 = c_d (x1 - z)/h,
 *
 * on the free DOFs (f_EG: elastic and gravity; f_D = -(alpha M + B(z)) v: damping with B frozen
 * at z, as g's damping term has it), with z = x0 + a_z h v0 and y = x0 + h v0 + a_a h^2 a0,
 * M a0 = f_EG(x0) + f_D(z, v0) (the scheme's adjoint_z, adjoint_a: backward Euler 0, 0 with
 * c_m = c_d = 1; Newmark 1/2, 1/4 with c_m = 4, c_d = 2). By the implicit function theorem, with
 * J = dr/dx1 = c_m M/h^2 + K(x1) + c_d (alpha M + B(z))/h (symmetric; K the exact Hessian, never
 * the projected one) and lambda = J^-1 (ax1 + c_d av1/h), dL/dp = -lambda^T dr/dp: the adjoints
 * of y and z are ay = c_m M lambda/h^2 and az = (df_D/dx)^T lambda - c_d/h ((df_D/dv)^T lambda
 * + av1), a0's (a_a h^2 ay) goes through the forces at x0 and (z, v0), and x0 and v0 collect
 * them through y and z; the masses' through the inertia terms, -lambda_i c_m (x1 - y)_i/h^2
 * and -a_a h^2 ay_i a0_i/m_i; the forces' parameter terms come through forces_vjp. J is factored
 * once per step with the Newton loop's symbolic analysis: exactly when it is positive definite
 * (the solve is then exact, refined once); where the exact K makes it indefinite, the clamped
 * matrix is factored instead and serves as the preconditioner of GMRES on the exact J. */

#define IC_ADJ_RESTART 20
#define IC_ADJ_MAX_ITERATIONS 400
#define IC_ADJ_TOL 1e-13

/* out = P^-1 in with the factor in ch.L (free-DOF vectors). */
static int adj_precond(ic_solver *s, const double *in, double *out)
{
    const int64_t n = s->pub.n;
    memcpy(s->ch.rhs->x, in, (size_t)n * sizeof *in);
    if (!cholmod_l_solve2(CHOLMOD_A, s->ch.L, s->ch.rhs, NULL, &s->ch.sol, NULL, &s->ch.ywork,
                          &s->ch.ework, &s->ch.cc))
        return 0;
    memcpy(out, s->ch.sol->x, (size_t)n * sizeof *out);
    return 1;
}

static double adj_dot(const double *a, const double *b, int64_t n)
{
    double d = 0.0;
    for (int64_t i = 0; i < n; ++i) d += a[i] * b[i];
    return d;
}

/* Right-preconditioned restarted GMRES on J x = b (J: the upper-stored aval; P: the factor),
 * from x = 0. Returns the relative residual reached. */
static double adj_gmres(ic_solver *s, const double *aval, const double *b, double *x, double *r,
                        double *V, double *Z, int *ok)
{
    const int64_t n = s->pub.n;
    const int m = IC_ADJ_RESTART;
    double H[IC_ADJ_RESTART + 1][IC_ADJ_RESTART], cs[IC_ADJ_RESTART], sn[IC_ADJ_RESTART],
        gg[IC_ADJ_RESTART + 1], y[IC_ADJ_RESTART];
    memset(x, 0, (size_t)n * sizeof *x);
    const double bn = sqrt(adj_dot(b, b, n));
    *ok = 1;
    if (bn == 0.0) return 0.0;
    memcpy(r, b, (size_t)n * sizeof *r);
    double rel = 1.0;
    for (int it = 0; it < IC_ADJ_MAX_ITERATIONS && rel > IC_ADJ_TOL;) {
        const double beta = sqrt(adj_dot(r, r, n));
        for (int64_t i = 0; i < n; ++i) V[i] = r[i] / beta;
        memset(gg, 0, sizeof gg);
        gg[0] = beta;
        int j = 0;
        for (; j < m && it < IC_ADJ_MAX_ITERATIONS; ++j, ++it) {
            double *z = Z + n * j, *wv = V + n * (j + 1);
            if (!adj_precond(s, V + n * j, z)) {
                *ok = 0;
                return INFINITY;
            }
            sym_upper_product(s, aval, z, wv);
            for (int i = 0; i <= j; ++i) {
                H[i][j] = adj_dot(wv, V + n * i, n);
                for (int64_t q = 0; q < n; ++q) wv[q] -= H[i][j] * V[n * i + q];
            }
            H[j + 1][j] = sqrt(adj_dot(wv, wv, n));
            if (H[j + 1][j] > 0.0)
                for (int64_t q = 0; q < n; ++q) wv[q] /= H[j + 1][j];
            for (int i = 0; i < j; ++i) {
                const double t = cs[i] * H[i][j] + sn[i] * H[i + 1][j];
                H[i + 1][j] = -sn[i] * H[i][j] + cs[i] * H[i + 1][j];
                H[i][j] = t;
            }
            const double d = hypot(H[j][j], H[j + 1][j]);
            cs[j] = d > 0.0 ? H[j][j] / d : 1.0;
            sn[j] = d > 0.0 ? H[j + 1][j] / d : 0.0;
            H[j][j] = d;
            H[j + 1][j] = 0.0;
            gg[j + 1] = -sn[j] * gg[j];
            gg[j] = cs[j] * gg[j];
            if (fabs(gg[j + 1]) <= IC_ADJ_TOL * bn) {
                ++j;
                ++it;
                break;
            }
        }
        for (int i = j - 1; i >= 0; --i) {
            double t = gg[i];
            for (int q = i + 1; q < j; ++q) t -= H[i][q] * y[q];
            y[i] = H[i][i] != 0.0 ? t / H[i][i] : 0.0;
        }
        for (int i = 0; i < j; ++i)
            for (int64_t q = 0; q < n; ++q) x[q] += y[i] * Z[n * i + q];
        sym_upper_product(s, aval, x, r);
        for (int64_t q = 0; q < n; ++q) r[q] = b[q] - r[q];
        rel = sqrt(adj_dot(r, r, n)) / bn;
    }
    return rel;
}

/* Numeric factorisation of hval into ch.L: 1 if it is positive definite. */
static int adj_factor(ic_solver *s, const defsim_host *host, defsim_system *sys)
{
    (void)host;
    (void)sys;
    cholmod_l_factorize(&s->ch.A, s->ch.L, &s->ch.cc);
    return s->ch.cc.status == CHOLMOD_OK && ldl_positive(s->ch.L);
}

static defsim_status ic_adjoint(const defsim_host *host, defsim_system *sys, void *state,
                                double h, const defsim_adjoint_step *a)
{
    ic_solver *s = *(ic_solver **)state;
    defsim__ic_solver *p = &s->pub;
    const int64_t nd = p->ndof, n = p->n;
    if (n == 0) {
        for (int64_t i = 0; i < nd; ++i) {
            a->ax0[i] = a->ax1[i];
            a->av0[i] = 0.0;
        }
        return DEFSIM_OK;
    }
    const int m = IC_ADJ_RESTART;
    const size_t bytes = (size_t)nd * sizeof(double);
    defsim__ic_targets stp = {0};
    defsim_status st = DEFSIM_OK;
    /* Contact at x1 may couple vertices that the pattern lacks (body contact queues them as it
     * assembles): the pattern then grows and the matrix is assembled once more. */
    for (int pass = 0; pass < 2; ++pass) {
        st = sync_pattern(s, host, sys);
        if (st != DEFSIM_OK) return fail(s, host, sys, st, "growing the matrix pattern failed");
        if (!s->adj || s->adj_nnz != s->pat.nnz) {
            host->release(s->adj);
            s->adj = alloc_doubles(host, s->pat.nnz + (int64_t)(4 + 2 * m + 1) * n + 9 * nd);
            if (!s->adj)
                return fail(s, host, sys, DEFSIM_ERR_OUT_OF_MEMORY, "adjoint: out of memory");
            s->adj_nnz = s->pat.nnz;
        }
        memcpy(p->x0, a->x0, bytes);
        memcpy(p->v0, a->v0, bytes);
        p->pin_vel = NULL;
        st = p->scheme->prepare(p, host, sys, h, &stp);   /* y, z = x0, B(x0) */
        if (st != DEFSIM_OK) return fail(s, host, sys, st, "adjoint: the damping matrix failed");
        const defsim_matrix_coeffs c = {1.0, 0.0, stp.cm / (h * h), stp.cd / h};
        st = host->matrix_values_projected(sys, a->x1, &c, DEFSIM_TRIANGLE_UPPER,
                                           DEFSIM_PROJECTION_NONE, s->adj);
        if (st != DEFSIM_OK) return fail(s, host, sys, st, "adjoint: Hessian assembly failed");
        if (!s->versioned || host->matrix_pattern_version(sys) == s->pattern_version) break;
    }
    double *aval = s->adj, *rhs = aval + s->pat.nnz, *lam = rhs + n, *r = lam + n, *tmp = r + n,
           *V = tmp + n, *Z = V + (int64_t)(m + 1) * n, *lf = Z + (int64_t)m * n, *gx1 = lf + nd,
           *gxn = gx1 + nd, *gv = gxn + nd, *mw = gv + nd, *gx0 = mw + nd, *gxz = gx0 + nd,
           *gvz = gxz + nd, *u = gvz + nd;
    if (p->bval)
        for (int64_t q = 0; q < s->pat.nnz; ++q) aval[q] += stp.cd * p->bval[q] / h;
    memcpy(s->hval, aval, (size_t)s->pat.nnz * sizeof *aval);

    int threads = host->num_threads(sys);
#ifdef _OPENMP
    if (omp_in_parallel()) threads = 1;
#endif
    blas_enter(s->ch.cc.fl < IC_BLAS_SERIAL_FLOPS ? 1 : threads);
    const omp_saved omp = omp_limit(threads);
    int exact = adj_factor(s, host, sys);
    if (!exact && s->ch.cc.status >= CHOLMOD_OK) {
        /* indefinite: the clamped matrix preconditions GMRES on the exact one */
        st = hessian(s, &stp, host, sys, a->x1, h, 1);
        if (st == DEFSIM_OK && !adj_factor(s, host, sys)) st = DEFSIM_ERR_NOT_CONVERGED;
    } else if (!exact) {
        st = DEFSIM_ERR_OUT_OF_MEMORY;
    }
    double rel = 0.0;
    int ok = 1;
    if (st == DEFSIM_OK) {
        for (int64_t k = 0; k < n; ++k) {
            const int64_t i = p->fdof[k];
            rhs[k] = a->ax1[i] + stp.cd * a->av1[i] / h;
        }
        if (exact) {
            /* the solve and one step of iterative refinement */
            ok = adj_precond(s, rhs, lam);
            if (ok) {
                sym_upper_product(s, aval, lam, r);
                for (int64_t k = 0; k < n; ++k) r[k] = rhs[k] - r[k];
                ok = adj_precond(s, r, tmp);
                for (int64_t k = 0; ok && k < n; ++k) lam[k] += tmp[k];
            }
        } else {
            rel = adj_gmres(s, aval, rhs, lam, r, V, Z, &ok);
        }
    }
    omp_restore(omp);
    blas_leave();
    if (st != DEFSIM_OK || !ok)
        return fail(s, host, sys, st != DEFSIM_OK ? st : DEFSIM_ERR_OUT_OF_MEMORY,
                    st == DEFSIM_ERR_NOT_CONVERGED ? "adjoint: the clamped matrix is not positive "
                                                     "definite"
                                                   : "adjoint: CHOLMOD failed (out of memory)");
    if (!(rel <= 1e-8)) {
        char msg[160];
        snprintf(msg, sizeof msg, "adjoint: GMRES on the exact Hessian reached only %.3g relative "
                                  "residual", rel);
        return fail(s, host, sys, DEFSIM_ERR_NOT_CONVERGED, msg);
    }

    memset(lf, 0, bytes);
    for (int64_t k = 0; k < n; ++k) lf[p->fdof[k]] = lam[k];
    memset(gx1, 0, bytes);
    memset(gxn, 0, bytes);
    memset(gv, 0, bytes);
    /* the residual's forces: f_EG at x1, the damping at (z, v1) */
    const uint32_t EG = DEFSIM_FORCE_ELASTIC | DEFSIM_FORCE_GRAVITY;
    st = host->forces_vjp(sys, a->x1, NULL, EG, lf, gx1, NULL, 1);
    if (st == DEFSIM_OK)
        st = host->forces_vjp(sys, stp.z, a->v1, DEFSIM_FORCE_DAMPING, lf, gxn, gv, 1);
    if (st != DEFSIM_OK) return st;
    const double ih2 = stp.cm / (h * h), ih = stp.cd / h, ca = p->scheme->adjoint_a * h * h,
                 cz = p->scheme->adjoint_z * h;
    /* a0's adjoint: u = a_a h^2 ay / m through the forces at x0 and (z, v0) */
    memset(gx0, 0, bytes);
    memset(gxz, 0, bytes);
    memset(gvz, 0, bytes);
    if (ca != 0.0) {
        for (int64_t i = 0; i < nd; ++i) {
            const int64_t k = s->dof_free[i];
            u[i] = k >= 0 ? ca * ih2 * lam[k] : 0.0;   /* ca ay_i / m_i */
        }
        st = host->forces_vjp(sys, a->x0, NULL, EG, u, gx0, NULL, 1);
        if (st == DEFSIM_OK)
            st = host->forces_vjp(sys, stp.z, a->v0, DEFSIM_FORCE_DAMPING, u, gxz, gvz, 1);
        if (st != DEFSIM_OK) return st;
    }
    for (int64_t i = 0; i < nd; ++i) {
        const int64_t k = s->dof_free[i];
        if (k < 0) {
            a->ax0[i] = a->ax1[i] + gx1[i] + gxn[i] + gx0[i] + gxz[i];
            a->av0[i] = 0.0;
            mw[i] = 0.0;
            continue;
        }
        const double l = lam[k], ay = p->mass[i] * l * ih2;
        const double az = gxn[i] - ih * (gv[i] + a->av1[i]) + gxz[i];
        a->ax0[i] = ay + az + gx0[i];
        a->av0[i] = h * ay + cz * az + gvz[i];
        mw[i] = -l * (a->x1[i] - stp.y[i]) * ih2;
        if (ca != 0.0) {
            const double a0 = (stp.y[i] - p->x0[i] - h * p->v0[i]) / ca;
            mw[i] -= ca * ay * a0 / p->mass[i];
        }
    }
    host->mass_vjp(sys, mw);
    return DEFSIM_OK;
}

/* The module's table and counters, filled from its scheme by the entry point (once, under the
 * registry's lock; the registry copies the table). */
static defsim_backend ic_backend;
static defsim_counter_spec ic_counters[DEFSIM__IC_COUNTERS + DEFSIM__IC_MAX_SCHEME_COUNTERS];

/// Module entry point (DEFSIM_MODULE_ENTRY): hands the core this module's backend table (its
/// scheme's name, flags and counters; the core's options). Returns
/// DEFSIM_ERR_BACKEND_UNAVAILABLE for a host table older than ABI version 8 (gravity).
__attribute__((visibility("default"))) defsim_status defsim_module_init(
    const defsim_host *host, const defsim_backend **out)
{
    const defsim__ic_scheme *scheme = &defsim__ic_module_scheme;
    if (!host || !out || host->abi_version < 8 ||
        host->size < offsetof(defsim_host, option_is_set) + sizeof host->option_is_set ||
        scheme->counter_count > DEFSIM__IC_MAX_SCHEME_COUNTERS)
        return DEFSIM_ERR_BACKEND_UNAVAILABLE;
    memcpy(ic_counters, ic_core_counters, sizeof ic_core_counters);
    for (int32_t k = 0; k < scheme->counter_count; ++k)
        ic_counters[DEFSIM__IC_COUNTERS + k] = scheme->counters[k];
    ic_backend = (defsim_backend){
        .abi_version = DEFSIM_BACKEND_ABI_VERSION,
        .struct_size = sizeof(defsim_backend),
        .name = scheme->name,
        .flags = DEFSIM_BACKEND_NEEDS_MATRIX | DEFSIM_BACKEND_IMPLICIT | scheme->flags,
        .state_size = sizeof(ic_solver *),
        .init = ic_init,
        .step = ic_step,
        .fini = ic_fini,
        .reset = ic_reset,
        .save_state = ic_save,
        .load_state = ic_load,
        .options = ic_options,
        .option_count = OPT_COUNT,
        .counters = ic_counters,
        .counter_count = DEFSIM__IC_COUNTERS + scheme->counter_count,
        .adjoint_step = scheme->differentiable && host->size >= offsetof(defsim_host, mass_vjp) +
                                                                    sizeof host->mass_vjp
                            ? ic_adjoint
                            : NULL,
    };
    *out = &ic_backend;
    return DEFSIM_OK;
}

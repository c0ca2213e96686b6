/* SPDX-License-Identifier: MIT */
/*
 * defsim-bench-contact-kernel: the per-contact kernel of body contact against IPC Toolkit on the
 * same inputs, written by tools/bench_contact_kernel.py (formats there).
 *
 *   defsim-bench-contact-kernel hessian FILE [ROUNDS]
 *       times defsim__contact_barrier with gradient and projected Hessian over every contact of
 *       FILE, one thread, CPU time, median of ROUNDS (default 21) passes; also per contact type.
 *   defsim-bench-contact-kernel ccd FILE [S]
 *       our additive CCD (defsim__pt_accd / defsim__ee_accd with minimum separation S, default
 *       0.1 = 1 - IPC Toolkit's conservative_rescaling 0.9) against IPC Toolkit's time of impact:
 *       the distribution of ours / theirs over the pairs where theirs is below 1.
 */
#include "cli.h"
#include "clock.h"
#include "contact_pair.h"
#include "contact_prim.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct contact {
    int32_t type;
    double eps, x[12];
} contact;

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* The q-quantile of v[0..n) (sorted in place). */
static double quantile(double *v, int n, double q)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    const int i = (int)floor(q * (n - 1) + 0.5);
    return v[i < 0 ? 0 : i >= n ? n - 1 : i];
}

/* One pass over the contacts of type `only` (-1: all); returns the CPU seconds and adds the
 * energies into *sink so the work is not optimised away. */
static double pass(const contact *c, int n, double dhat, int only, double *sink)
{
    double g[12], H[144];
    const double t0 = tools_cpu_now();
    for (int i = 0; i < n; ++i) {
        if (only >= 0 && c[i].type != only) continue;
        *sink += defsim__contact_barrier(c[i].type, c[i].x, dhat, 1.0, c[i].eps, g, H) + H[13];
    }
    return tools_cpu_now() - t0;
}

static int run_hessian(const char *path, int rounds)
{
    FILE *f = fopen(path, "rb");
    int32_t n;
    double dhat;
    if (!f || fread(&n, sizeof n, 1, f) != 1 || fread(&dhat, sizeof dhat, 1, f) != 1 || n <= 0) {
        fprintf(stderr, "cannot read %s\n", path);
        if (f) fclose(f);
        return 1;
    }
    contact *c = calloc((size_t)n, sizeof *c);
    int count[4] = {0, 0, 0, 0};
    for (int i = 0; i < n; ++i) {
        if (fread(&c[i].type, sizeof c[i].type, 1, f) != 1 ||
            fread(&c[i].eps, sizeof c[i].eps, 1, f) != 1 ||
            fread(c[i].x, sizeof c[i].x, 1, f) != 1 || c[i].type < 0 || c[i].type > 3) {
            fprintf(stderr, "%s: bad contact %d\n", path, i);
            free(c);
            fclose(f);
            return 1;
        }
        count[c[i].type]++;
    }
    fclose(f);
    static const char *names[4] = {"VV", "EV", "FV", "EE"};
    double *t = malloc((size_t)rounds * sizeof *t), sink = 0.0;
    for (int only = -1; only < 4; ++only) {
        const int m = only < 0 ? n : count[only];
        if (m == 0) continue;
        pass(c, n, dhat, only, &sink);   /* warm */
        for (int r = 0; r < rounds; ++r) t[r] = pass(c, n, dhat, only, &sink);
        const double med = quantile(t, rounds, 0.5);
        printf("%-3s %6d contacts: %8.3f ms, %6.0f ns per contact (median of %d, CPU time)\n",
               only < 0 ? "all" : names[only], m, 1e3 * med, 1e9 * med / m, rounds);
    }
    if (sink == 42.0) printf(" \n");
    free(t);
    free(c);
    return 0;
}

static int run_ccd(const char *path, double s)
{
    FILE *f = fopen(path, "rb");
    int32_t n;
    if (!f || fread(&n, sizeof n, 1, f) != 1 || n <= 0) {
        fprintf(stderr, "cannot read %s\n", path);
        if (f) fclose(f);
        return 1;
    }
    double *ratio = malloc((size_t)n * sizeof *ratio);
    int m = 0, below = 0, ours_hit = 0;
    double t_ours = 0.0;
    for (int i = 0; i < n; ++i) {
        int32_t kind;
        double x[12], dx[12], toi;
        if (fread(&kind, sizeof kind, 1, f) != 1 || fread(x, sizeof x, 1, f) != 1 ||
            fread(dx, sizeof dx, 1, f) != 1 || fread(&toi, sizeof toi, 1, f) != 1) {
            fprintf(stderr, "%s: bad pair %d\n", path, i);
            free(ratio);
            fclose(f);
            return 1;
        }
        const double t0 = tools_cpu_now();
        const double t = kind == 0 ? defsim__pt_accd(x, dx, s, 1.0, 1000000)
                                   : defsim__ee_accd(x, dx, s, 1.0, 1000000);
        t_ours += tools_cpu_now() - t0;
        ours_hit += t < 1.0;
        if (toi < 1.0) {
            ratio[m++] = t / toi;
            below += t < toi;
        }
    }
    fclose(f);
    printf("%d pairs, s = %.3g: ours < 1 on %d; ipctk < 1 on %d; ours / ipctk there: "
           "min %.3f, 10th percentile %.3f, median %.3f, 90th percentile %.3f; ours smaller on "
           "%d; our CCD %.2f us per pair (CPU)\n",
           n, s, ours_hit, m, m ? quantile(ratio, m, 0.0) : 0.0, m ? quantile(ratio, m, 0.1) : 0.0,
           m ? quantile(ratio, m, 0.5) : 0.0, m ? quantile(ratio, m, 0.9) : 0.0, below,
           1e6 * t_ours / n);
    free(ratio);
    return 0;
}

static void usage(FILE *f)
{
    fprintf(f, "usage: defsim-bench-contact-kernel hessian FILE [ROUNDS]\n"
               "       defsim-bench-contact-kernel ccd FILE [S]\n"
               "Body contact's per-contact kernel on the inputs bench_contact_kernel.py writes:\n"
               "  hessian  barrier gradient and projected Hessian per contact, one thread, CPU\n"
               "           time, median of ROUNDS passes (default 21)\n"
               "  ccd      additive CCD with minimum separation S (default 0.1) against IPC\n"
               "           Toolkit's time of impact\n"
               "  -h, --help   this text\n"
               "  --version    the library's version\n");
}

int main(int argc, char **argv)
{
    static const cli_tool tool = {"defsim-bench-contact-kernel", usage, NULL, ""};
    int first;
    const int parsed = cli_parse(&tool, NULL, argc, argv, &first);
    if (parsed >= 0) return parsed;
    char **arg = argv + first;
    const int nargs = argc - first;
    if (nargs < 2 || nargs > 3 || (strcmp(arg[0], "hessian") && strcmp(arg[0], "ccd")))
        return cli_fail(&tool, "need hessian FILE [ROUNDS] or ccd FILE [S]");
    char *end = NULL;
    if (!strcmp(arg[0], "hessian")) {
        const long rounds = nargs > 2 ? strtol(arg[2], &end, 10) : 21;
        if (nargs > 2 && (end == arg[2] || *end || rounds < 1 || rounds > 100000))
            return cli_fail(&tool, "ROUNDS: a whole number in 1..100000, got '%s'", arg[2]);
        return run_hessian(arg[1], (int)rounds);
    }
    const double sep = nargs > 2 ? strtod(arg[2], &end) : 0.1;
    if (nargs > 2 && (end == arg[2] || *end || !(sep >= 0.0 && sep <= 1.0)))
        return cli_fail(&tool, "S: a number in [0, 1], got '%s'", arg[2]);
    return run_ccd(arg[1], sep);
}

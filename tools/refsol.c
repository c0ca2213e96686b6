/* SPDX-License-Identifier: MIT */
#include "refsol.h"

#include "clock.h"
#include "stat.h"

#include <stdlib.h>
#include <string.h>
#include <time.h>

void refsol_free(refsol *r)
{
    if (!r) return;
    free(r->x);
    free(r->v);
    memset(r, 0, sizeof *r);
}

defsim_status refsol_integrate(defsim_world *w, double T, int calls, double rtol, double atol,
                               const char *tag, refsol *out)
{
    memset(out, 0, sizeof *out);
    const int32_t nv = defsim_world_vertex_count(w);
    if (nv <= 0 || calls < 1 || !(T > defsim_world_time(w))) return DEFSIM_ERR_INVALID_ARGUMENT;
    out->x = malloc(3 * (size_t)nv * sizeof *out->x);
    out->v = malloc(3 * (size_t)nv * sizeof *out->v);
    if (!out->x || !out->v) {
        refsol_free(out);
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    const double t_start = defsim_world_time(w), t0 = tools_now();
    for (int c = 0; c < calls; ++c) {
        /* The last call ends exactly on T. */
        const double h = (c == calls - 1) ? T - defsim_world_time(w) : (T - t_start) / calls;
        const defsim_status st = defsim_world_step(w, h);
        if (st != DEFSIM_OK) {
            fprintf(stderr, "%s: step %d (t = %g s) failed: %s: %s\n", tag ? tag : "reference",
                    c, defsim_world_time(w), defsim_status_string(st),
                    defsim_world_last_error(w));
            refsol_free(out);
            return st;
        }
        if (tag && (c + 1) % (calls >= 10 ? calls / 10 : 1) == 0) {
            fprintf(stderr, "%s: t = %.4g s: %.0f internal steps, %.1f s\n", tag,
                    defsim_world_time(w), tools_backend_stat(w, "internal_steps"),
                    tools_now() - t0);
        }
    }
    out->wall_seconds = tools_now() - t0;
    out->internal_steps = (int64_t)tools_backend_stat(w, "internal_steps");
    out->end_time = defsim_world_time(w);
    out->rtol = rtol;
    out->atol = atol;
    out->vertex_count = nv;
    defsim_world_energy(w, &out->energy);
    if (defsim_world_get_positions(w, out->x, nv) != DEFSIM_OK ||
        defsim_world_get_velocities(w, out->v, nv) != DEFSIM_OK) {
        refsol_free(out);
        return DEFSIM_ERR_INVALID_ARGUMENT;
    }
    return DEFSIM_OK;
}

int refsol_write_tail(FILE *f, const refsol *r)
{
    fprintf(f, "end_time %.17g\nbackend %s\nrtol %.17g\natol %.17g\n", r->end_time,
            r->backend, r->rtol, r->atol);
    fprintf(f, "internal_steps %lld\nwall_seconds %.3f\n", (long long)r->internal_steps,
            r->wall_seconds);
    fprintf(f, "energy %.17g %.17g %.17g %.17g\nvertices %d\n", r->energy.kinetic,
            r->energy.elastic, r->energy.gravitational, r->energy.total, (int)r->vertex_count);
    for (int32_t i = 0; i < r->vertex_count; ++i) {
        const double *x = r->x + 3 * (size_t)i, *v = r->v + 3 * (size_t)i;
        fprintf(f, "%.17g %.17g %.17g %.17g %.17g %.17g\n", x[0], x[1], x[2], v[0], v[1], v[2]);
    }
    return ferror(f) ? -1 : 0;
}

int refsol_read(const char *path, refsol *out, char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    if (errlen) err[0] = '\0';
    FILE *f = fopen(path, "r");
    if (!f) {
        snprintf(err, errlen, "%s: cannot open", path);
        return -1;
    }
    char line[1024];
    int have = 0, lineno = 0;
    enum { H_T = 1, H_RTOL = 2, H_ATOL = 4, H_E = 8 };
    if (!fgets(line, sizeof line, f) || strncmp(line, "defsim-reference 1", 18) != 0) {
        snprintf(err, errlen, "%s: not a defsim-reference version 1 file", path);
        fclose(f);
        return -1;
    }
    lineno = 1;
    while (fgets(line, sizeof line, f)) {
        ++lineno;
        long long ll;
        int n;
        if (sscanf(line, "end_time %lf", &out->end_time) == 1) have |= H_T;
        else if (sscanf(line, "rtol %lf", &out->rtol) == 1) have |= H_RTOL;
        else if (sscanf(line, "atol %lf", &out->atol) == 1) have |= H_ATOL;
        else if (sscanf(line, "internal_steps %lld", &ll) == 1) out->internal_steps = ll;
        else if (sscanf(line, "wall_seconds %lf", &out->wall_seconds) == 1) {}
        else if (sscanf(line, "energy %lf %lf %lf %lf", &out->energy.kinetic,
                        &out->energy.elastic, &out->energy.gravitational,
                        &out->energy.total) == 4) have |= H_E;
        else if (sscanf(line, "vertices %d", &n) == 1) {
            if (n < 1 || have != (H_T | H_RTOL | H_ATOL | H_E)) {
                snprintf(err, errlen, "%s:%d: vertex count %d, or end_time/rtol/atol/energy "
                         "missing before it", path, lineno, n);
                break;
            }
            out->vertex_count = n;
            out->x = malloc(3 * (size_t)n * sizeof *out->x);
            out->v = malloc(3 * (size_t)n * sizeof *out->v);
            if (!out->x || !out->v) {
                snprintf(err, errlen, "%s: out of memory", path);
                break;
            }
            int i = 0;
            for (; i < n; ++i) {
                double *x = out->x + 3 * (size_t)i, *v = out->v + 3 * (size_t)i;
                if (fscanf(f, "%lf %lf %lf %lf %lf %lf", &x[0], &x[1], &x[2], &v[0], &v[1],
                           &v[2]) != 6)
                    break;
            }
            if (i < n) {
                snprintf(err, errlen, "%s: vertex %d of %d unreadable", path, i, n);
                break;
            }
            fclose(f);
            return 0;
        }
    }
    if (!err[0]) snprintf(err, errlen, "%s: no vertices line", path);
    fclose(f);
    refsol_free(out);
    return -1;
}

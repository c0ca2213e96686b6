/* SPDX-License-Identifier: MIT */
#include "run_summary.h"

#include "stat.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

/* JSON has no NaN or infinity: a blown-up run reports null. */
static void put_number(FILE *f, double v)
{
    if (isfinite(v)) fprintf(f, "%.17g", v);
    else fputs("null", f);
}

static void put_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (const unsigned char *p = (const unsigned char *)s; *p; ++p) {
        if (*p == '"' || *p == '\\') fprintf(f, "\\%c", *p);
        else if (*p < 0x20) fprintf(f, "\\u%04x", *p);
        else fputc(*p, f);
    }
    fputc('"', f);
}

static void put_energy(FILE *f, const char *name, const defsim_energy *e)
{
    fprintf(f, "  \"%s\": {\"kinetic\": ", name);
    put_number(f, e->kinetic);
    fputs(", \"elastic\": ", f);
    put_number(f, e->elastic);
    fputs(", \"gravitational\": ", f);
    put_number(f, e->gravitational);
    fputs(", \"total\": ", f);
    put_number(f, e->total);
    fputs("},\n", f);
}

int run_summary_write(const char *path, const scene *s, const defsim_world *w,
                      const run_summary *r, char *err, size_t errsz)
{
    FILE *f = fopen(path, "w");
    if (!f) {
        snprintf(err, errsz, "%s: %s", path, strerror(errno));
        return -1;
    }
    defsim_stats st = {.size = sizeof st};
    defsim_world_stats(w, &st);
    fputs("{\n  \"status\": ", f);
    put_string(f, r->status);
    fprintf(f, ",\n  \"status_code\": %d,\n  \"message\": ", (int)r->step_status);
    put_string(f, r->message);
    fputs(",\n  \"scene\": ", f);
    put_string(f, s->name);
    fputs(",\n  \"backend\": ", f);
    put_string(f, s->backend);
    fprintf(f, ",\n  \"vertices\": %d,\n  \"h\": %.17g,\n  \"frames\": %d,\n"
               "  \"frames_planned\": %d,\n  \"steps\": %lld,\n  \"failed_steps\": %lld,\n"
               "  \"time\": %.17g,\n  \"wall\": %.9g,\n  \"time_step\": %.9g,\n"
               "  \"newton_iterations\": %lld,\n  \"internal_steps\": %lld,\n"
               "  \"stable_step\": ",
            (int)s->vertex_count, s->h, r->frames, (int)s->frames, (long long)st.steps,
            (long long)st.failed_steps, defsim_world_time(w), r->wall, st.time_step,
            (long long)tools_backend_stat(w, "newton_iterations"),
            (long long)tools_backend_stat(w, "internal_steps"));
    put_number(f, r->stable_step > 0.0 ? r->stable_step : NAN);
    fputs(",\n", f);
    put_energy(f, "energy_start", &r->start);
    put_energy(f, "energy_end", &r->end);
    fputs("  \"probes\": [", f);
    int first = 1;
    for (int32_t i = 0; i < s->nbodies; ++i) {
        const scene_body *b = &s->bodies[i];
        if (b->probe < 0) continue;
        const double *p = r->x + 3 * ((int64_t)b->offset + b->probe);
        fprintf(f, "%s\n    {\"body\": %d, \"name\": ", first ? "" : ",", (int)i);
        put_string(f, b->name);
        fprintf(f, ", \"vertex\": %d, \"position\": [", (int)b->probe);
        for (int k = 0; k < 3; ++k) {
            if (k) fputs(", ", f);
            put_number(f, p[k]);
        }
        fputs("]}", f);
        first = 0;
    }
    fputs(first ? "]\n}\n" : "\n  ]\n}\n", f);
    const int bad = ferror(f);
    if (fclose(f) != 0 || bad) {
        snprintf(err, errsz, "%s: write failed: %s", path, strerror(errno));
        return -1;
    }
    return 0;
}

/* SPDX-License-Identifier: MIT */
/* The tools' command lines over getopt_long: see cli.h. */
#include "cli.h"

#include <defsim/defsim.h>

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

enum { CLI_HELP = 'h', CLI_VERSION = CLI_OPT - 1 };

void cli_begin(cli *c, const cli_tool *tool, int argc, char **argv)
{
    memset(c, 0, sizeof *c);
    c->tool = tool;
    c->argc = argc;
    c->argv = argv;
    int n = 0;
    for (const struct option *o = tool->options; o && o->name && n < CLI_MAX_OPTIONS; ++o)
        c->all[n++] = *o;
    c->all[n++] = (struct option){"help", no_argument, NULL, CLI_HELP};
    c->all[n++] = (struct option){"version", no_argument, NULL, CLI_VERSION};
    /* Leading ':' (after a '+', if the tool stops at its first operand): getopt_long reports
     * a missing value apart from an unknown option, and prints nothing itself. */
    const char *s = tool->short_options ? tool->short_options : "";
    const int stop = s[0] == '+';
    snprintf(c->shorts, sizeof c->shorts, "%s:h%s", stop ? "+" : "", s + stop);
    optind = 0;   /* glibc and musl: start afresh (a command parsed after its dispatcher) */
    opterr = 0;
}

static int usage_error(const char *name, const char *fmt, va_list ap)
{
    fprintf(stderr, "%s: ", name);
    vfprintf(stderr, fmt, ap);
    fprintf(stderr, "\n(%s --help lists the options)\n", name);
    return 2;
}

int cli_error(cli *c, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    c->status = usage_error(c->tool->name, fmt, ap);
    va_end(ap);
    return 2;
}

int cli_fail(const cli_tool *tool, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    usage_error(tool->name, fmt, ap);
    va_end(ap);
    return 2;
}

int cli_next(cli *c)
{
    const int o = getopt_long(c->argc, c->argv, c->shorts, c->all, NULL);
    /* The element getopt_long just read: the option ("--out", "-n"), or its value when that was
     * a separate element. */
    const char *prev = optind > 0 && optind <= c->argc ? c->argv[optind - 1] : "";
    c->arg = optarg;
    c->flag = prev;
    if (optarg && prev == optarg && optind >= 2) c->flag = c->argv[optind - 2];
    if (o == -1) {
        c->optind = optind;
        return CLI_END;
    }
    if (o == CLI_HELP) {
        c->tool->usage(stdout);
        c->status = 0;
        return CLI_EXIT;
    }
    if (o == CLI_VERSION) {
        cli_print_version(c->tool->name);
        c->status = 0;
        return CLI_EXIT;
    }
    if (o == ':') return cli_error(c, "option %s needs a value", prev), CLI_EXIT;
    if (o == '?') {
        if (!strncmp(prev, "--", 2) && optopt != 0)
            return cli_error(c, "option %.*s takes no value", (int)strcspn(prev, "="), prev),
                   CLI_EXIT;
        if (!strncmp(prev, "--", 2)) {
            /* getopt_long takes an unambiguous prefix; name the candidates of one that is not. */
            const size_t n = strcspn(prev + 2, "=");
            char names[512] = "";
            int k = 0;
            for (const struct option *a = c->all; a->name; ++a)
                if (!strncmp(a->name, prev + 2, n) &&
                    strlen(names) + strlen(a->name) + 8 < sizeof names) {
                    strcat(names, k++ ? ", --" : "--");
                    strcat(names, a->name);
                }
            if (k > 1) return cli_error(c, "ambiguous option %s (%s)", prev, names), CLI_EXIT;
            return cli_error(c, "unknown option %s", prev), CLI_EXIT;
        }
        return cli_error(c, "unknown option -%c", optopt), CLI_EXIT;
    }
    return o;
}

int cli_long(cli *c, long lo, long hi, long *out)
{
    char *end = NULL;
    errno = 0;
    const long v = c->arg ? strtol(c->arg, &end, 10) : 0;
    if (!c->arg || end == c->arg || *end || errno || v < lo || v > hi) {
        cli_error(c, "%s: expected a whole number in %ld..%ld, got '%s'", c->flag, lo, hi,
                  c->arg ? c->arg : "");
        return 0;
    }
    *out = v;
    return 1;
}

int cli_int(cli *c, long lo, long hi, int *out)
{
    long v;
    if (lo < INT_MIN) lo = INT_MIN;
    if (hi > INT_MAX) hi = INT_MAX;
    if (!cli_long(c, lo, hi, &v)) return 0;
    *out = (int)v;
    return 1;
}

int cli_double(cli *c, double lo, double hi, double *out)
{
    char *end = NULL;
    const double v = c->arg ? strtod(c->arg, &end) : NAN;
    if (!c->arg || end == c->arg || *end || !isfinite(v) || v < lo || v > hi) {
        cli_error(c, "%s: expected a number in [%g, %g], got '%s'", c->flag, lo, hi,
                  c->arg ? c->arg : "");
        return 0;
    }
    *out = v;
    return 1;
}

int cli_positive(cli *c, double *out)
{
    char *end = NULL;
    const double v = c->arg ? strtod(c->arg, &end) : NAN;
    if (!c->arg || end == c->arg || *end || !isfinite(v) || !(v > 0)) {
        cli_error(c, "%s: expected a positive number, got '%s'", c->flag, c->arg ? c->arg : "");
        return 0;
    }
    *out = v;
    return 1;
}

void cli_print_version(const char *name)
{
    const int v = defsim_version_number();
    printf("%s (defsim %d.%d.%d)\n", name, v / 10000, v / 100 % 100, v % 100);
}

int cli_parse(const cli_tool *tool, const cli_opt *opts, int argc, char **argv, int *first)
{
    struct option longs[CLI_MAX_OPTIONS + 1];
    int n = 0;
    for (const cli_opt *o = opts; o && o->name && n < CLI_MAX_OPTIONS; ++o, ++n)
        longs[n] = (struct option){o->name, o->kind == CLI_FLAG ? no_argument : required_argument,
                                   NULL, CLI_OPT + n};
    longs[n] = (struct option){0};
    cli_tool t = *tool;
    t.options = longs;
    cli c;
    cli_begin(&c, &t, argc, argv);
    for (int k; (k = cli_next(&c)) != CLI_END;) {
        if (k == CLI_EXIT) return c.status;
        const cli_opt *o = &opts[k - CLI_OPT];
        int ok = 1;
        switch (o->kind) {
        case CLI_FLAG: *(int *)o->target = 1; break;
        case CLI_STRING: *(const char **)o->target = c.arg; break;
        case CLI_INT: ok = cli_int(&c, (long)o->lo, (long)o->hi, o->target); break;
        case CLI_LONG: ok = cli_long(&c, (long)o->lo, (long)o->hi, o->target); break;
        case CLI_DOUBLE: ok = cli_double(&c, o->lo, o->hi, o->target); break;
        case CLI_POSITIVE: ok = cli_positive(&c, o->target); break;
        case CLI_LIST: {
            cli_list *l = o->target;
            if (l->count == l->capacity) return cli_error(&c, "at most %d %s", l->capacity, c.flag);
            l->items[l->count++] = c.arg;
            break;
        }
        }
        if (!ok) return c.status;
    }
    *first = c.optind;
    return -1;
}

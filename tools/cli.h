/* SPDX-License-Identifier: MIT */
/*
 * The tools' command lines: getopt_long (libc) over a tool's own options plus the ones every
 * tool shares, -h/--help (usage on stdout, exit 0) and --version (the library's version, exit 0),
 * and one way to report a usage error (an unknown option, a missing or bad value: a message on
 * stderr and exit status 2). A tool loops:
 *
 *     cli c;
 *     cli_begin(&c, &tool, argc, argv);      // argv[0]: the program or command name
 *     for (int o; (o = cli_next(&c)) != CLI_END;) {
 *         if (o == CLI_EXIT) return c.status;   // help, version or a usage error: done
 *         switch (o) { case OPT_N: if (!cli_int(&c, 1, 1000, &n)) return c.status; ... }
 *     }
 *     // operands: c.argv[c.optind .. c.argc - 1]
 *
 * Operands and options may come in any order (GNU permutation), unless the tool's short options
 * begin with '+' (stop at the first operand: a command's name).
 *
 * A tool whose options only set variables describes them in a table instead, and cli_parse runs
 * that loop:
 *
 *     const cli_opt opts[] = {{"n", CLI_INT, &n, 1, 1000}, {"cpu", CLI_FLAG, &use_cpu, 0, 0}, {0}};
 *     int first;
 *     const int parsed = cli_parse(&tool, opts, argc, argv, &first);
 *     if (parsed >= 0) return parsed;          // help, version or a usage error
 *     // operands: argv[first .. argc - 1]
 */
#ifndef DEFSIM_TOOLS_CLI_H
#define DEFSIM_TOOLS_CLI_H

#include <getopt.h>
#include <stdio.h>

/* A tool's command line. */
typedef struct cli_tool {
    const char *name;                /* in messages: "defsim run", "defsim-bench-step" */
    void (*usage)(FILE *f);          /* the usage text (printed by -h/--help) */
    const struct option *options;    /* the tool's own long options, ended by {0}; their val is
                                        the id cli_next returns (a short option's character, or
                                        CLI_OPT + k); NULL for none */
    const char *short_options;       /* getopt's short options without 'h' ("" or NULL: none) */
} cli_tool;

enum {
    CLI_END = -1,       /* no more options: operands from c.optind */
    CLI_EXIT = -2,      /* help or version printed (status 0) or a usage error reported (2) */
    CLI_OPT = 0x100,    /* first id of options that have no short form */
    CLI_MAX_OPTIONS = 64
};

typedef struct cli {
    const cli_tool *tool;
    int argc;
    char **argv;
    const char *arg;      /* the value of the option cli_next returned (NULL: none) */
    const char *flag;     /* that option as written ("--out", "-n") for messages */
    int optind;           /* after CLI_END: the first operand */
    int status;           /* after CLI_EXIT: the exit status */
    struct option all[CLI_MAX_OPTIONS + 3];
    char shorts[2 * CLI_MAX_OPTIONS + 8];
} cli;

void cli_begin(cli *c, const cli_tool *tool, int argc, char **argv);

/* The next option's id, CLI_END or CLI_EXIT (see above). */
int cli_next(cli *c);

/* Reports a usage error ("NAME: MESSAGE" and a hint at --help on stderr); returns 2 and sets
 * c->status to it. */
int cli_error(cli *c, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* The current option's value as a whole number in [lo, hi] or a finite number in [lo, hi]:
 * 1 and *out set, or 0 after reporting a usage error (c->status 2). */
int cli_int(cli *c, long lo, long hi, int *out);
int cli_long(cli *c, long lo, long hi, long *out);
int cli_double(cli *c, double lo, double hi, double *out);
int cli_positive(cli *c, double *out);   /* finite and > 0 */

/* Prints "NAME (defsim X.Y.Z)": the version of the library the tool runs with. */
void cli_print_version(const char *name);

/* What an option of a table sets: CLI_FLAG 1 into an int; CLI_STRING the value into a const
 * char *; CLI_INT, CLI_LONG and CLI_DOUBLE the value checked against [lo, hi] into an int, long
 * or double; CLI_POSITIVE a finite number > 0 into a double; CLI_LIST appends the value to a
 * cli_list (a usage error once it is full). */
typedef enum cli_kind { CLI_FLAG, CLI_STRING, CLI_INT, CLI_LONG, CLI_DOUBLE, CLI_POSITIVE,
                        CLI_LIST } cli_kind;
typedef struct cli_opt {
    const char *name;   /* the long option without "--"; NULL ends the table */
    cli_kind kind;
    void *target;
    double lo, hi;      /* CLI_INT, CLI_LONG, CLI_DOUBLE */
} cli_opt;
typedef struct cli_list {
    const char **items;
    int count, capacity;
} cli_list;

/* Parses argv with the tool's table (at most CLI_MAX_OPTIONS; tool->options is not used).
 * Returns -1 with *first the first operand, or the exit status after help, version or a usage
 * error. */
int cli_parse(const cli_tool *tool, const cli_opt *opts, int argc, char **argv, int *first);

/* Reports a usage error of a tool as cli_error does, without a cli (after cli_parse). */
int cli_fail(const cli_tool *tool, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

#endif

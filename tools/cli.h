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

#endif

/* SPDX-License-Identifier: MIT */
/*
 * defsim: the command-line tool. `defsim <command> [args]`; each command lives in its own file
 * and receives the arguments from its name on (argv[0] = the name).
 */
#include "bench.h"
#include "cli.h"
#include "run.h"
#include "stress.h"

#include <stdio.h>
#include <string.h>

#ifdef DEFSIM_HAVE_VIEWER
int defsim_tool_view(int argc, char **argv);   /* tools/view/main.c */
#else
static int defsim_tool_view(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    fprintf(stderr, "defsim view: this build has no viewer (GLFW was not found when it was "
                    "configured: install libglfw3-dev and configure again)\n");
    return 1;
}
#endif

typedef struct command {
    const char *name;
    const char *help;
    int (*main)(int argc, char **argv);
} command;

static const command commands[] = {
    {"run", "run a scene file: progress, VTK frames, PNG frames with --render", run_main},
    {"stress", "stability stress matrix: scenes x backends x h x E x nu x starts", defsim_tool_stress},
    {"bench", "work-precision benchmark: error against wall time per backend, h and tolerance",
     defsim_tool_bench},
    {"view", "a scene in a window: play, step, reset, orbit, colours, drag a vertex",
     defsim_tool_view},
};

static void usage(FILE *f)
{
    fprintf(f, "usage: defsim <command> [arguments]   (defsim <command> --help for more)\n"
               "       defsim -h | --help | --version\n\n"
               "commands:\n");
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; ++i)
        fprintf(f, "  %-8s %s\n", commands[i].name, commands[i].help);
    fprintf(f, "  %-8s %s\n", "version", "print the library version");
}

int main(int argc, char **argv)
{
    /* '+': options up to the command's name are defsim's, the rest the command's. */
    static const cli_tool tool = {"defsim", usage, NULL, "+"};
    cli c;
    cli_begin(&c, &tool, argc, argv);
    for (int o; (o = cli_next(&c)) != CLI_END;)
        if (o == CLI_EXIT) return c.status;
    if (c.optind >= argc) {
        usage(stderr);
        return 2;
    }
    const char *name = argv[c.optind];
    if (!strcmp(name, "help")) {
        usage(stdout);
        return 0;
    }
    if (!strcmp(name, "version")) {
        cli_print_version("defsim");
        return 0;
    }
    /* The command parses its own arguments, its name in argv[0]. */
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; ++i)
        if (!strcmp(name, commands[i].name))
            return commands[i].main(argc - c.optind, argv + c.optind);
    return cli_error(&c, "unknown command \"%s\"", name);
}

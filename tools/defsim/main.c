/* SPDX-License-Identifier: MIT */
/*
 * defsim: the command-line tool. `defsim <command> [args]`; each command lives in its own file
 * and receives the arguments after its name.
 */
#include "bench.h"
#include "run.h"
#include "stress.h"

#include <defsim/defsim.h>

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

static int usage(FILE *f)
{
    fprintf(f, "usage: defsim <command> [arguments]   (defsim <command> --help for more)\n\n"
               "commands:\n");
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; ++i)
        fprintf(f, "  %-8s %s\n", commands[i].name, commands[i].help);
    fprintf(f, "  %-8s %s\n", "version", "print the library version");
    return f == stderr ? 2 : 0;
}

int main(int argc, char **argv)
{
    if (argc < 2) return usage(stderr);
    if (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help") || !strcmp(argv[1], "help"))
        return usage(stdout);
    if (!strcmp(argv[1], "version") || !strcmp(argv[1], "--version")) {
        const int v = defsim_version_number();
        printf("defsim %d.%d.%d\n", v / 10000, v / 100 % 100, v % 100);
        return 0;
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; ++i)
        if (!strcmp(argv[1], commands[i].name)) return commands[i].main(argc - 2, argv + 2);
    fprintf(stderr, "defsim: unknown command \"%s\"\n", argv[1]);
    return usage(stderr);
}

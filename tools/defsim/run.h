/* SPDX-License-Identifier: MIT */
#ifndef DEFSIM_TOOLS_RUN_H
#define DEFSIM_TOOLS_RUN_H

/* `defsim run`: argv[0] is the command's name ("run", in messages "defsim run"; or the tool's
 * that runs it, "defsim-render"), the arguments follow. Returns the process exit status:
 * 0 done, 1 error, 2 usage error, 130 interrupted by SIGINT (output complete so far). */
int run_main(int argc, char **argv);

#include <defsim/defsim.h>

/* --option NAME=VALUE (n of them), set after the scene's own options; an error is printed
 * as "TOOL: --option ...: " with what is valid. Returns 0, or -1. (Also `defsim view`'s.) */
int run_set_options(const char *tool, defsim_world *w, const char *const *opts, int n);

#endif

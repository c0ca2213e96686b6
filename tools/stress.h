/* SPDX-License-Identifier: MIT */
/* Subcommands of the defsim tool that live in their own files. */
#ifndef DEFSIM_TOOLS_STRESS_H
#define DEFSIM_TOOLS_STRESS_H

/* `defsim stress [options]`: the stability stress matrix (tools/stress.c). argv[0] is the
 * subcommand name. Returns the process exit code. */
int defsim_tool_stress(int argc, char **argv);

#endif

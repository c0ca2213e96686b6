/* SPDX-License-Identifier: MIT */
#ifndef DEFSIM_TOOLS_BENCH_H
#define DEFSIM_TOOLS_BENCH_H

/* `defsim bench SCENE.json [options]`: the work-precision benchmark (tools/defsim/bench.c). argv[0]
 * is the subcommand name. Returns the process exit status: 0 done, 1 error, 2 usage. */
int defsim_tool_bench(int argc, char **argv);

#endif

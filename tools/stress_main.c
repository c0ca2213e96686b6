/* SPDX-License-Identifier: MIT */
/* defsim-stress: the stability stress matrix as its own program (see tools/stress.c). */
#include "stress.h"

int main(int argc, char **argv) { return defsim_tool_stress(argc - 1, argv + 1); }

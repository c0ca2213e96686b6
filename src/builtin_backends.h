/* SPDX-License-Identifier: MIT */
/* The backends compiled into the library: a NULL-terminated list that CMake generates
 * (builtin_backends.c in the build tree) from DEFSIM_BUILTIN_BACKENDS. */
#ifndef DEFSIM_BUILTIN_BACKENDS_H
#define DEFSIM_BUILTIN_BACKENDS_H

#include "defsim/backend.h"

#include <stddef.h>

extern const defsim_backend *const defsim__builtin_backends[];

#endif

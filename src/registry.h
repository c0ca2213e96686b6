/* SPDX-License-Identifier: MIT */
/* The backend registry (registry.c). */
#ifndef DEFSIM_REGISTRY_H
#define DEFSIM_REGISTRY_H

#include "defsim/backend.h"

/* Finds a backend by name, loading its module if needed. */
defsim_status defsim__find_backend(const char *name, const defsim_backend **out);

#endif /* DEFSIM_REGISTRY_H */

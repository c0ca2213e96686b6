/* SPDX-License-Identifier: MIT */
/* The error reporting that libdefsim_scene, libdefsim_render and the scene export share
 * (compiled into the tools' defsim_scene library). */
#ifndef DEFSIM_TOOLS_LIB_API_ERROR_H
#define DEFSIM_TOOLS_LIB_API_ERROR_H

#include <defsim/defsim.h>

#include <stddef.h>

/* Formats the message into err (errsz bytes; err may be NULL) and returns st. */
defsim_status api_fail(char *err, size_t errsz, defsim_status st, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

#endif

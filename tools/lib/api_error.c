/* SPDX-License-Identifier: MIT */
#include "api_error.h"

#include <stdarg.h>
#include <stdio.h>

defsim_status api_fail(char *err, size_t errsz, defsim_status st, const char *fmt, ...)
{
    if (err && errsz > 0) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errsz, fmt, ap);
        va_end(ap);
    }
    return st;
}

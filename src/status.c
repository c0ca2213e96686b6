/* SPDX-License-Identifier: MIT */
#include "status.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

/* One X-macro list gives every code its text. */
#define DEFSIM_STATUS_LIST(X)                                   \
    X(DEFSIM_OK, "ok")                                          \
    X(DEFSIM_ERR_INVALID_ARGUMENT, "invalid argument")          \
    X(DEFSIM_ERR_INVALID_MESH, "invalid mesh")                  \
    X(DEFSIM_ERR_INVALID_MATERIAL, "invalid material")          \
    X(DEFSIM_ERR_BACKEND_UNAVAILABLE, "backend unavailable")    \
    X(DEFSIM_ERR_NOT_CONVERGED, "not converged")                \
    X(DEFSIM_ERR_UNSTABLE, "unstable")                          \
    X(DEFSIM_ERR_OUT_OF_MEMORY, "out of memory")                \
    X(DEFSIM_ERR_IO, "input/output error")                      \
    X(DEFSIM_ERR_STALE_ID, "stale id")                          \
    X(DEFSIM_ERR_LOCKED, "locked")                              \
    X(DEFSIM_ERR_CONFLICT, "conflict")                          \
    X(DEFSIM_ERR_CALLBACK, "host callback failed")                \
    X(DEFSIM_ERR_UNSUPPORTED, "unsupported")

const char *defsim_status_string(defsim_status status)
{
    switch (status) {
#define X(code, text) case code: return text;
        DEFSIM_STATUS_LIST(X)
#undef X
    }
    return "unknown status";
}

static _Thread_local char last_error[512];

void defsim__set_last_error(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(last_error, sizeof last_error, fmt, ap);
    va_end(ap);
}

void defsim__clear_last_error(void) { last_error[0] = '\0'; }

const char *defsim_last_error(void) { return last_error; }

/* Calls the host's log callback with the world locked; not from inside itself. */
static void call_log(defsim__messages *m, int level, const char *text)
{
    m->locked++;
    m->in_log = 1;
    m->log(m->log_user, level, text);
    m->in_log = 0;
    m->locked--;
}

void defsim__error(defsim__messages *m, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(m->error, sizeof m->error, fmt, ap);
    va_end(ap);
    if (!m->log || m->in_log) return;
    /* The callback gets a copy: a refused call from inside it overwrites m->error. */
    char text[sizeof m->error];
    memcpy(text, m->error, sizeof text);
    call_log(m, 0, text);
    memcpy(m->error, text, sizeof text);
}

void defsim__log(defsim__messages *m, int level, const char *fmt, ...)
{
    if (!m->log || m->in_log) return;
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    call_log(m, level, msg);
}

int32_t defsim_version_number(void) { return DEFSIM_VERSION_NUMBER; }

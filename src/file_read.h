/* SPDX-License-Identifier: MIT */
/*
 * Reading a whole file into memory: the one reader of the mesh loaders and of the tools (which
 * compile this file into their helper library, since the shared library does not export it).
 * Plain C library only: no defsim status or error state.
 */
#ifndef DEFSIM_FILE_READ_H
#define DEFSIM_FILE_READ_H

#include <stddef.h>

/* Largest file the tools read: 1 GiB (the mesh loaders read at most DEFSIM_LIMIT_FILE_BYTES,
 * by default the same). It bounds what a runaway file can make them allocate. */
#define DEFSIM__FILE_MAX ((size_t)1 << 30)

/* The error for a path that is not a regular file (a FIFO, device or socket): a FIFO would
 * block, a device such as /dev/zero never ends. Not an errno value (those are positive). */
#define DEFSIM__ENOTREG (-1)

/*
 * Reads the file at `path` into a malloc'd buffer with a NUL after its last byte; on success
 * *buf (owned by the caller) and *len (bytes, without the NUL) are set and 0 is returned.
 * Otherwise nothing is allocated and the result is an errno value: the one from opening or
 * reading the file (EIO for a read error), EISDIR for a folder, DEFSIM__ENOTREG for anything
 * else that is not a regular file (checked on the opened file; opening never blocks), ENOMEM,
 * or EFBIG when the file holds more than `max_bytes` bytes.
 */
int defsim__read_file(const char *path, size_t max_bytes, char **buf, size_t *len);

/* strerror, and a message for DEFSIM__ENOTREG. */
const char *defsim__read_strerror(int err);

#endif

/* SPDX-License-Identifier: MIT */
/*
 * Reading a whole file into memory: the one reader of the mesh loaders and of the tools (which
 * compile this file into their helper library, since the shared library does not export it).
 * Plain C library only: no defsim status or error state.
 */
#ifndef DEFSIM_FILE_READ_H
#define DEFSIM_FILE_READ_H

#include <stddef.h>

/* Largest file the loaders and the tools read: 1 GiB. It bounds what a file that never ends
 * (/dev/zero, a runaway generator) can make them allocate. */
#define DEFSIM__FILE_MAX ((size_t)1 << 30)

/*
 * Reads the file at `path` into a malloc'd buffer with a NUL after its last byte; on success
 * *buf (owned by the caller) and *len (bytes, without the NUL) are set and 0 is returned.
 * Otherwise nothing is allocated and the result is an errno value: the one from opening or
 * reading the file (EIO for a read error), ENOMEM, or EFBIG when the file holds more than
 * `max_bytes` bytes.
 */
int defsim__read_file(const char *path, size_t max_bytes, char **buf, size_t *len);

#endif

/* SPDX-License-Identifier: MIT */
/*
 * What the fuzz targets share: the libFuzzer entry point they define, and a per-process
 * scratch folder where each input is written as a file (the loaders under test read paths).
 * Each target is linked either with libFuzzer (clang, -DDEFSIM_FUZZ=ON) or with
 * regress_main.c, which feeds it the files of a corpus (any compiler; ctest).
 */
#ifndef DEFSIM_FUZZ_UTIL_H
#define DEFSIM_FUZZ_UTIL_H

#include <stddef.h>
#include <stdint.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerInitialize(int *argc, char ***argv);

/* Writes data to NAME in the scratch folder (created on first use, removed at exit) and
 * returns its path (static storage, valid until the next call); aborts if it cannot. */
const char *fz_write(const char *name, const uint8_t *data, size_t size);

/* Small input limits for the targets, so that no input can make them allocate much:
 * defsim_set_limit on file size, vertices and elements. */
void fz_small_limits(void);

#endif

/* SPDX-License-Identifier: MIT */
/*
 * Checkpoints (docs/checkpoints.md): the byte format's building blocks, shared by the writer and
 * the reader in checkpoint.c and by the unit tests, which build damaged and old-version files.
 */
#ifndef DEFSIM_CHECKPOINT_H
#define DEFSIM_CHECKPOINT_H

#include <stddef.h>
#include <stdint.h>

/* "DEFSIMCK", then the format version (u32) and flags (u32, 0), all little-endian. */
#define DEFSIM__CKPT_MAGIC "DEFSIMCK"
#define DEFSIM__CKPT_HEADER 16
/* The version this library writes; it reads 1 .. this. Version 2 added the auto_substep cache
 * (the stable-step estimate and its age) to the STAT chunk, version 3 the colliders (COLL
 * chunks, and CFRC for the contact forces of the last step), version 4 body contact (BODY's
 * surfaces and filters, PEXT), version 5 the contact state a continuation depends on (CNTC). */
#define DEFSIM__CKPT_VERSION 5u

/* CRC-32 (IEEE 802.3, reflected, polynomial 0xEDB88320) of n bytes, continuing from crc (0 to
 * start). */
uint32_t defsim__crc32(uint32_t crc, const void *data, size_t n);

#endif /* DEFSIM_CHECKPOINT_H */

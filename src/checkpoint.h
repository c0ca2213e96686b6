/* SPDX-License-Identifier: MIT */
/*
 * Checkpoints (docs/checkpoints.md): the byte format's building blocks, shared by the writer and
 * the reader in checkpoint.c and by the unit tests, which build damaged and old-version files.
 */
#ifndef DEFSIM_CHECKPOINT_H
#define DEFSIM_CHECKPOINT_H

#include "chunk.h"

/* "DEFSIMCK", then the format version (u32) and flags (u32, 0), all little-endian. */
#define DEFSIM__CKPT_MAGIC "DEFSIMCK"
#define DEFSIM__CKPT_HEADER 16
/* The version this library writes; it reads 1 .. this. Version 2 added the auto_substep cache
 * (the stable-step estimate and its age) to the STAT chunk, version 3 the colliders (COLL
 * chunks, and CFRC for the contact forces of the last step), version 4 body contact (BODY's
 * surfaces and filters, PEXT), version 5 the contact state a continuation depends on (CNTC),
 * version 6 the terms' state as each kind writes it (TERM chunks: the kind's name, then its
 * bytes; the collider term's holds what CNTC held and the safe box), version 7 BODY's
 * volume_averaging, version 8 quadratic tets (BODY's indices per tet after its counts), version 9
 * shells (BODY's shell_* fields at its end), version 10 BODY's shell_strain_limit after them,
 * version 11 BODY's contact thickness after that. The chunks' bytes and CRC-32 are chunk.h's. */
#define DEFSIM__CKPT_VERSION 11u

#endif /* DEFSIM_CHECKPOINT_H */

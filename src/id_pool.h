/* SPDX-License-Identifier: MIT */
/*
 * The one generational id pool of a world, for bodies, colliders and attachments alike: per
 * slot a generation (odd while the slot's object lives, bumped when it goes) and where the
 * object lies in its owner's array. An id's index is the world's tag above the slot + 1
 * (body.h), so ids of another world, stale ids and the null id are told apart.
 */
#ifndef DEFSIM_ID_POOL_H
#define DEFSIM_ID_POOL_H

#include "body.h"
#include "status.h"

#include <stdint.h>

typedef struct defsim__id_pool {
    uint32_t tag;             /* 1 .. DEFSIM__ID_TAGS, the world's, in every index it makes */
    uint32_t *gen;            /* per slot: generation, odd while the slot's object lives */
    int32_t *dense;           /* per slot: index of the object in its owner's array, -1: free */
    int32_t nslots, cap;
} defsim__id_pool;

/* The first free slot into *slot, with room for it. DEFSIM_ERR_OUT_OF_MEMORY with the message
 * in msg when the pool is full (DEFSIM__ID_MAX_SLOTS) or memory is; `what` names the objects
 * ("bodies"). Changes nothing but the capacity: defsim__id_pool_take commits. */
defsim_status defsim__id_pool_reserve(defsim__id_pool *p, defsim__messages *msg,
                                      const char *what, int32_t *slot);
/* Makes a reserved slot live with its object at `dense`; returns the new (odd) generation. */
uint32_t defsim__id_pool_take(defsim__id_pool *p, int32_t slot, int32_t dense);
/* Ends the life of a live slot: its ids turn stale, and the next reserve may reuse it. */
void defsim__id_pool_release(defsim__id_pool *p, int32_t slot);
/* Adds an object kept by id slot (colliders, attachments; bodies are kept in vertex order): a
 * slot reserved as by defsim__id_pool_reserve into *slot and, when the slot is new, room for it
 * in the owner's array `items` (*n elements of `size` bytes, room for *cap), whose *n then
 * counts it. Returns the array (moved when it grew), or NULL with the message in msg when the
 * pool is full or memory is (the old array stays). defsim__id_pool_take commits. */
void *defsim__id_pool_add(defsim__id_pool *p, defsim__messages *msg, const char *what,
                          void *items, size_t size, int32_t *n, int32_t *cap, int32_t *slot);
/* Ends the life of the live object in `slot`: its generation (which the owner's array keeps in
 * *generation) and the slot's turn even, and the slot is free for the next add. */
void defsim__id_pool_remove(defsim__id_pool *p, int32_t slot, uint32_t *generation);
/* The slot of a live object named by (index, generation), or -1. */
int64_t defsim__id_pool_find(const defsim__id_pool *p, uint32_t index, uint32_t generation);
/* The same, and for -1 the message "<what> id {i, g} is <problem>" in msg ("body"). */
int64_t defsim__id_pool_lookup(const defsim__id_pool *p, defsim__messages *msg, const char *what,
                               uint32_t index, uint32_t generation);
/* An index's slot (0-based) if it carries the pool's tag, else -1 (live or not). */
int64_t defsim__id_pool_slot(const defsim__id_pool *p, uint32_t index);
/* The index of slot `slot` in an id of this pool. */
uint32_t defsim__id_pool_index(const defsim__id_pool *p, int32_t slot);
/* What is wrong with an id that names nothing live: "null", "not of this world" or "stale". */
const char *defsim__id_pool_problem(const defsim__id_pool *p, uint32_t index,
                                    uint32_t generation);
void defsim__id_pool_free(defsim__id_pool *p);

#endif

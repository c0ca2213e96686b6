/* SPDX-License-Identifier: MIT */
/* The generational id pool (id_pool.h): slots, generations, where each object lies. */
#include "id_pool.h"

#include <stdlib.h>
#include <string.h>

defsim_status defsim__id_pool_reserve(defsim__id_pool *p, defsim__messages *msg,
                                      const char *what, int32_t *slot)
{
    int32_t s = 0;
    while (s < p->nslots && (p->gen[s] & 1u)) ++s;
    if (s == DEFSIM__ID_MAX_SLOTS) {
        defsim__error(msg, "the world holds %d %s, the most it can", (int)DEFSIM__ID_MAX_SLOTS,
                      what);
        return DEFSIM_ERR_OUT_OF_MEMORY;
    }
    if (s == p->cap) {
        int32_t cap = p->cap ? 2 * p->cap : 8;
        if (cap > DEFSIM__ID_MAX_SLOTS) cap = DEFSIM__ID_MAX_SLOTS;
        uint32_t *gen = realloc(p->gen, (size_t)cap * sizeof *gen);
        if (gen) p->gen = gen;
        int32_t *dense = gen ? realloc(p->dense, (size_t)cap * sizeof *dense) : NULL;
        if (!dense) {
            defsim__error(msg, "out of memory");
            return DEFSIM_ERR_OUT_OF_MEMORY;
        }
        p->dense = dense;
        p->cap = cap;
    }
    *slot = s;
    return DEFSIM_OK;
}

uint32_t defsim__id_pool_take(defsim__id_pool *p, int32_t slot, int32_t dense)
{
    if (slot == p->nslots) {   /* a new slot, at generation 0 until now */
        p->gen[slot] = 0u;
        p->nslots++;
    }
    p->dense[slot] = dense;
    return ++p->gen[slot];
}

void defsim__id_pool_release(defsim__id_pool *p, int32_t slot)
{
    p->gen[slot]++;
    p->dense[slot] = -1;
}

void *defsim__id_pool_add(defsim__id_pool *p, defsim__messages *msg, const char *what,
                          void *items, size_t size, int32_t *n, int32_t *cap, int32_t *slot)
{
    if (defsim__id_pool_reserve(p, msg, what, slot) != DEFSIM_OK) return NULL;
    if (*slot == *n && *n == *cap) {
        const int32_t c = *cap ? 2 * *cap : 8;
        void *grown = realloc(items, (size_t)c * size);
        if (!grown) {
            defsim__error(msg, "out of memory");
            return NULL;
        }
        items = grown;
        *cap = c;
    }
    if (*slot == *n) (*n)++;
    return items;
}

void defsim__id_pool_remove(defsim__id_pool *p, int32_t slot, uint32_t *generation)
{
    (*generation)++;
    defsim__id_pool_release(p, slot);
}

int64_t defsim__id_pool_slot(const defsim__id_pool *p, uint32_t index)
{
    if ((index >> DEFSIM__ID_SLOT_BITS) != p->tag) return -1;
    return DEFSIM__ID_SLOT(index);
}

int64_t defsim__id_pool_find(const defsim__id_pool *p, uint32_t index, uint32_t generation)
{
    const int64_t slot = defsim__id_pool_slot(p, index);
    if (slot < 0 || slot >= p->nslots || p->gen[slot] != generation || !(generation & 1u))
        return -1;
    return slot;
}

int64_t defsim__id_pool_lookup(const defsim__id_pool *p, defsim__messages *msg, const char *what,
                               uint32_t index, uint32_t generation)
{
    const int64_t slot = defsim__id_pool_find(p, index, generation);
    if (slot < 0)
        defsim__error(msg, "%s id {%u, %u} is %s", what, (unsigned)index, (unsigned)generation,
                      defsim__id_pool_problem(p, index, generation));
    return slot;
}

uint32_t defsim__id_pool_index(const defsim__id_pool *p, int32_t slot)
{
    return p->tag << DEFSIM__ID_SLOT_BITS | (uint32_t)(slot + 1);
}

const char *defsim__id_pool_problem(const defsim__id_pool *p, uint32_t index,
                                    uint32_t generation)
{
    if (index == 0 && generation == 0) return "null";
    return defsim__id_pool_slot(p, index) < 0 ? "not of this world" : "stale (removed)";
}

void defsim__id_pool_free(defsim__id_pool *p)
{
    free(p->gen);
    free(p->dense);
    p->gen = NULL;
    p->dense = NULL;
    p->nslots = p->cap = 0;
}

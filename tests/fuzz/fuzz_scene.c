/* SPDX-License-Identifier: MIT */
/*
 * Fuzz target for scene files (tools/scene*.c): the input is a scene file, loaded with small
 * limits (scene_load_limited) next to a few small mesh files it may name (cloth.obj, box.msh,
 * tet.node/.ele); a scene that loads is built into a world and stepped once.
 */
#include "fuzz_util.h"

#include "scene.h"

#include <defsim/defsim.h>

#include <string.h>

static const char OBJ[] = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nl 1 3\n";
static const char MSH[] =
    "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n5\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n"
    "5 1 1 1\n$EndNodes\n$Elements\n3\n1 2 2 0 1 1 2 3\n2 4 2 1 1 1 2 3 4\n"
    "3 4 2 1 1 2 3 4 5\n$EndElements\n";
static const char NODE[] = "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n";
static const char ELE[] = "1 4 0\n1 1 2 3 4\n";

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    fz_small_limits();
    fz_write("cloth.obj", (const uint8_t *)OBJ, sizeof OBJ - 1);
    fz_write("box.msh", (const uint8_t *)MSH, sizeof MSH - 1);
    fz_write("tet.node", (const uint8_t *)NODE, sizeof NODE - 1);
    fz_write("tet.ele", (const uint8_t *)ELE, sizeof ELE - 1);
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fz_write("scene.json", data, size);
    const scene_limits limits = {20000, 1000000};
    scene s;
    if (scene_load_limited(&s, path, NULL, 0, &limits) != 0) return 0;
    defsim_world *w = NULL;
    if (scene_build(&s, &w) == DEFSIM_OK) {
        (void)scene_step(&s, w, s.h);
        defsim_world_destroy(w);
    }
    scene_free(&s);
    return 0;
}

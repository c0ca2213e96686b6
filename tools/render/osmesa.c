/* SPDX-License-Identifier: MIT */
/*
 * The off-screen context of defsim run's PNG frames: OSMesa with a GL 3.3 core context
 * (llvmpipe or softpipe) drawing into the renderer's own buffer; render.c draws.
 */
#include "render.h"

#include <GL/osmesa.h>

#include <stdio.h>
#include <stdlib.h>

static int osmesa_make_current(void *ctx, uint8_t *buffer, int width, int height)
{
    return OSMesaMakeCurrent((OSMesaContext)ctx, buffer, GL_UNSIGNED_BYTE, width, height) ? 0 : -1;
}

static void osmesa_destroy(void *ctx)
{
    /* Unbind first, so that Mesa frees the framebuffer it made for this buffer. */
    OSMesaMakeCurrent(NULL, NULL, GL_UNSIGNED_BYTE, 0, 0);
    OSMesaDestroyContext((OSMesaContext)ctx);
}

static rd_glproc osmesa_getproc(const char *name)
{
    return (rd_glproc)OSMesaGetProcAddress(name);
}

rd_renderer *rd_create(int width, int height, int supersample, char *err, size_t errsz)
{
    const int attribs[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 24,
                           OSMESA_STENCIL_BITS, 0, OSMESA_ACCUM_BITS, 0,
                           OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                           OSMESA_CONTEXT_MAJOR_VERSION, 3, OSMESA_CONTEXT_MINOR_VERSION, 3, 0};
    OSMesaContext ctx = OSMesaCreateContextAttribs(attribs, NULL);
    if (!ctx) {
        snprintf(err, errsz, "OSMesa could not create a GL 3.3 core context (needs Mesa with "
                             "llvmpipe or softpipe)");
        return NULL;
    }
    const rd_context c = {"OSMesa", ctx, osmesa_make_current, osmesa_destroy, osmesa_getproc, 1};
    return rd_create_with(&c, width, height, supersample, err, errsz);
}

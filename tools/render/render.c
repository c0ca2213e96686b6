/* SPDX-License-Identifier: MIT */
/*
 * The renderer's drawing, for any GL 3.3 core context: OSMesa's (osmesa.c: defsim run's PNG
 * frames) or a window's (the viewer, tools/view). Every GL entry point, GL 1.1's included, is
 * looked up through the context's loader (types from glcorearb.h), so that no GL symbol is
 * linked and the two contexts can live in one program. Geometry is rebuilt on the CPU every
 * frame (flat normals for solids, area-weighted vertex normals for cloth, tubes for lines) and
 * drawn as plain triangles; nothing depends on timing, so a frame renders the same on every run.
 *
 * Contents: shaders; the renderer over a context (its buffer, or a framebuffer object and the
 * blit to a window); vectors and the view (camera fitting, grid spacing, matrices); geometry
 * (triangles with normals, line tubes); rd_render; surfaces of tet cells (rd_tet_surface).
 */
#include "render.h"

#include <GL/glcorearb.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define GL_FUNCS(X)                                                                               \
    X(PFNGLVIEWPORTPROC, glViewport)                                                            \
    X(PFNGLCLEARCOLORPROC, glClearColor)                                                        \
    X(PFNGLCLEARPROC, glClear)                                                                  \
    X(PFNGLENABLEPROC, glEnable)                                                                \
    X(PFNGLDISABLEPROC, glDisable)                                                              \
    X(PFNGLDEPTHMASKPROC, glDepthMask)                                                          \
    X(PFNGLBLENDFUNCPROC, glBlendFunc)                                                          \
    X(PFNGLPOLYGONOFFSETPROC, glPolygonOffset)                                                  \
    X(PFNGLDRAWARRAYSPROC, glDrawArrays)                                                        \
    X(PFNGLFINISHPROC, glFinish)                                                                \
    X(PFNGLGETERRORPROC, glGetError)                                                            \
    X(PFNGLREADPIXELSPROC, glReadPixels)                                                        \
    X(PFNGLPIXELSTOREIPROC, glPixelStorei)                                                      \
    X(PFNGLGENTEXTURESPROC, glGenTextures)                                                      \
    X(PFNGLDELETETEXTURESPROC, glDeleteTextures)                                                \
    X(PFNGLBINDTEXTUREPROC, glBindTexture)                                                      \
    X(PFNGLTEXIMAGE2DPROC, glTexImage2D)                                                        \
    X(PFNGLTEXPARAMETERIPROC, glTexParameteri)                                                  \
    X(PFNGLUNIFORM1IPROC, glUniform1i)                                                          \
    X(PFNGLGENFRAMEBUFFERSPROC, glGenFramebuffers)                                              \
    X(PFNGLDELETEFRAMEBUFFERSPROC, glDeleteFramebuffers)                                        \
    X(PFNGLBINDFRAMEBUFFERPROC, glBindFramebuffer)                                              \
    X(PFNGLGENRENDERBUFFERSPROC, glGenRenderbuffers)                                            \
    X(PFNGLDELETERENDERBUFFERSPROC, glDeleteRenderbuffers)                                      \
    X(PFNGLBINDRENDERBUFFERPROC, glBindRenderbuffer)                                            \
    X(PFNGLRENDERBUFFERSTORAGEPROC, glRenderbufferStorage)                                      \
    X(PFNGLFRAMEBUFFERRENDERBUFFERPROC, glFramebufferRenderbuffer)                              \
    X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, glCheckFramebufferStatus)                                \
    X(PFNGLCREATESHADERPROC, glCreateShader)                                                    \
    X(PFNGLSHADERSOURCEPROC, glShaderSource)                                                    \
    X(PFNGLCOMPILESHADERPROC, glCompileShader)                                                  \
    X(PFNGLGETSHADERIVPROC, glGetShaderiv)                                                      \
    X(PFNGLGETSHADERINFOLOGPROC, glGetShaderInfoLog)                                            \
    X(PFNGLCREATEPROGRAMPROC, glCreateProgram)                                                  \
    X(PFNGLATTACHSHADERPROC, glAttachShader)                                                    \
    X(PFNGLLINKPROGRAMPROC, glLinkProgram)                                                      \
    X(PFNGLGETPROGRAMIVPROC, glGetProgramiv)                                                    \
    X(PFNGLGETPROGRAMINFOLOGPROC, glGetProgramInfoLog)                                          \
    X(PFNGLDELETESHADERPROC, glDeleteShader)                                                    \
    X(PFNGLDELETEPROGRAMPROC, glDeleteProgram)                                                  \
    X(PFNGLUSEPROGRAMPROC, glUseProgram)                                                        \
    X(PFNGLGETUNIFORMLOCATIONPROC, glGetUniformLocation)                                        \
    X(PFNGLUNIFORMMATRIX4FVPROC, glUniformMatrix4fv)                                            \
    X(PFNGLUNIFORM3FPROC, glUniform3f)                                                          \
    X(PFNGLUNIFORM1FPROC, glUniform1f)                                                          \
    X(PFNGLGENVERTEXARRAYSPROC, glGenVertexArrays)                                              \
    X(PFNGLBINDVERTEXARRAYPROC, glBindVertexArray)                                              \
    X(PFNGLDELETEVERTEXARRAYSPROC, glDeleteVertexArrays)                                        \
    X(PFNGLGENBUFFERSPROC, glGenBuffers)                                                        \
    X(PFNGLBINDBUFFERPROC, glBindBuffer)                                                        \
    X(PFNGLBUFFERDATAPROC, glBufferData)                                                        \
    X(PFNGLDELETEBUFFERSPROC, glDeleteBuffers)                                                  \
    X(PFNGLENABLEVERTEXATTRIBARRAYPROC, glEnableVertexAttribArray)                              \
    X(PFNGLVERTEXATTRIBPOINTERPROC, glVertexAttribPointer)

typedef struct gl_api {
#define X(type, name) type name;
    GL_FUNCS(X)
#undef X
} gl_api;

struct rd_renderer {
    rd_context context;
    int width, height, ss;
    uint8_t *buffer;            /* RGBA at ss x size, bottom row first */
    gl_api gl;
    GLuint prog_mesh, prog_ground, prog_sky, prog_blit;
    GLuint vao, vbo;
    GLuint fbo, color_rb, depth_rb;   /* without into_buffer: the target drawn into */
    int fbo_w, fbo_h;
    GLuint texture;             /* rd_present's image */
    float *verts;               /* 9 floats per vertex: position, normal, colour */
    size_t nverts, cap;
};

/* ------------------------------------------------------------------------------------------ */
/* Shaders */

static const char *VS_MESH =
    "#version 330 core\n"
    "layout(location = 0) in vec3 pos;\n"
    "layout(location = 1) in vec3 nrm;\n"
    "layout(location = 2) in vec3 col;\n"
    "uniform mat4 mvp;\n"
    "out vec3 v_n; out vec3 v_c; out vec3 v_p;\n"
    "void main() { v_n = nrm; v_c = col; v_p = pos; gl_Position = mvp * vec4(pos, 1.0); }\n";

static const char *FS_MESH =
    "#version 330 core\n"
    "in vec3 v_n; in vec3 v_c; in vec3 v_p;\n"
    "uniform vec3 eye; uniform vec3 up; uniform vec3 key;\n"
    "out vec4 color;\n"
    "void main() {\n"
    "  vec3 n = normalize(v_n);\n"
    "  vec3 v = normalize(eye - v_p);\n"
    "  if (dot(n, v) < 0.0) n = -n;\n"   /* two-sided: back faces lit from the viewer's side */
    "  float d = max(dot(n, key), 0.0);\n"
    "  float hemi = 0.5 + 0.5 * dot(n, up);\n"
    "  vec3 h = normalize(key + v);\n"
    "  float s = pow(max(dot(n, h), 0.0), 48.0) * 0.25;\n"
    "  float fill = 0.3 * max(dot(n, v), 0.0);\n"   /* a headlight, so no face is black */
    "  vec3 c = v_c * (0.2 + 0.2 * hemi + 0.55 * d + fill) + vec3(s);\n"
    "  color = vec4(clamp(c, 0.0, 1.0), 1.0);\n"
    "}\n";

static const char *VS_GROUND =
    "#version 330 core\n"
    "layout(location = 0) in vec3 pos;\n"
    "layout(location = 1) in vec3 nrm;\n"
    "layout(location = 2) in vec3 col;\n"
    "uniform mat4 mvp;\n"
    "out vec2 v_uv; out vec3 v_p;\n"
    "void main() { v_uv = col.xy; v_p = pos; gl_Position = mvp * vec4(pos, 1.0); }\n";

static const char *FS_GROUND =
    "#version 330 core\n"
    "in vec2 v_uv; in vec3 v_p;\n"
    "uniform float spacing; uniform float extent; uniform vec3 center;\n"
    "out vec4 color;\n"
    "void main() {\n"
    "  vec2 g = v_uv / spacing;\n"
    "  vec2 w = fwidth(g);\n"
    "  vec2 a = abs(fract(g - 0.5) - 0.5) / max(w, vec2(1e-6));\n"
    "  float line = 1.0 - min(min(a.x, a.y), 1.0);\n"
    "  float r = length(v_p - center) / extent;\n"
    "  float fade = clamp(1.0 - r, 0.0, 1.0);\n"
    "  vec3 base = vec3(0.80, 0.81, 0.83);\n"
    "  vec3 c = mix(base, vec3(0.52, 0.54, 0.58), line * 0.85 * fade);\n"
    "  color = vec4(c, fade);\n"
    "}\n";

static const char *VS_SKY =
    "#version 330 core\n"
    "out float v_t;\n"
    "void main() {\n"
    "  vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));\n"
    "  v_t = p.y * 0.5;\n"
    "  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);\n"
    "}\n";

static const char *FS_SKY =
    "#version 330 core\n"
    "in float v_t;\n"
    "out vec4 color;\n"
    "void main() { color = vec4(mix(vec3(0.86, 0.87, 0.89), vec3(0.97, 0.98, 1.0), v_t), 1.0); }\n";

/* rd_present: an RGB8 image (top row first) over the whole viewport, pixel for pixel. */
static const char *VS_BLIT =
    "#version 330 core\n"
    "out vec2 v_uv;\n"
    "void main() {\n"
    "  vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));\n"
    "  v_uv = vec2(p.x, 1.0 - p.y);\n"
    "  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);\n"
    "}\n";

static const char *FS_BLIT =
    "#version 330 core\n"
    "in vec2 v_uv; uniform sampler2D image;\n"
    "out vec4 color;\n"
    "void main() { color = vec4(texture(image, v_uv).rgb, 1.0); }\n";

static GLuint compile(gl_api *gl, const char *vs, const char *fs, char *err, size_t errsz)
{
    const char *src[2] = {vs, fs};
    const GLenum kinds[2] = {GL_VERTEX_SHADER, GL_FRAGMENT_SHADER};
    GLuint sh[2] = {0, 0};
    for (int i = 0; i < 2; ++i) {
        sh[i] = gl->glCreateShader(kinds[i]);
        gl->glShaderSource(sh[i], 1, &src[i], NULL);
        gl->glCompileShader(sh[i]);
        GLint ok = 0;
        gl->glGetShaderiv(sh[i], GL_COMPILE_STATUS, &ok);
        if (!ok) {
            char log[512];
            gl->glGetShaderInfoLog(sh[i], sizeof log, NULL, log);
            snprintf(err, errsz, "shader compilation failed: %s", log);
            return 0;
        }
    }
    GLuint p = gl->glCreateProgram();
    gl->glAttachShader(p, sh[0]);
    gl->glAttachShader(p, sh[1]);
    gl->glLinkProgram(p);
    gl->glDeleteShader(sh[0]);
    gl->glDeleteShader(sh[1]);
    GLint ok = 0;
    gl->glGetProgramiv(p, GL_LINK_STATUS, &ok);
    if (!ok) {
        char log[512];
        gl->glGetProgramInfoLog(p, sizeof log, NULL, log);
        snprintf(err, errsz, "shader link failed: %s", log);
        return 0;
    }
    return p;
}

rd_renderer *rd_create_with(const rd_context *context, int width, int height, int supersample,
                           char *err, size_t errsz)
{
    if (width < 1 || height < 1 || supersample < 1 || supersample > 4 || width > 16384 ||
        height > 16384) {
        snprintf(err, errsz, "bad image size %d x %d (supersample %d)", width, height, supersample);
        if (context->destroy) context->destroy(context->ctx);
        return NULL;
    }
    rd_renderer *r = calloc(1, sizeof *r);
    if (!r) {
        snprintf(err, errsz, "out of memory");
        if (context->destroy) context->destroy(context->ctx);
        return NULL;
    }
    r->context = *context;
    r->width = width;
    r->height = height;
    r->ss = supersample;
    const size_t W = (size_t)width * supersample, H = (size_t)height * supersample;
    r->buffer = malloc(W * H * 4);
    if (!r->buffer || context->make_current(context->ctx, r->buffer, (int)W, (int)H)) {
        snprintf(err, errsz, "%s: cannot make the context current at %zu x %zu", context->name,
                 W, H);
        rd_destroy(r);
        return NULL;
    }
#define X(type, fn)                                                                               \
    {                                                                                            \
        rd_glproc p_ = context->getproc(#fn);                                                    \
        memcpy(&r->gl.fn, &p_, sizeof p_);                                                       \
    }                                                                                            \
    if (!r->gl.fn) {                                                                             \
        snprintf(err, errsz, "%s: no GL function %s", context->name, #fn);                      \
        rd_destroy(r);                                                                           \
        return NULL;                                                                             \
    }
    GL_FUNCS(X)
#undef X
    gl_api *gl = &r->gl;
    if (!(r->prog_mesh = compile(gl, VS_MESH, FS_MESH, err, errsz)) ||
        !(r->prog_ground = compile(gl, VS_GROUND, FS_GROUND, err, errsz)) ||
        !(r->prog_sky = compile(gl, VS_SKY, FS_SKY, err, errsz)) ||
        (!context->into_buffer && !(r->prog_blit = compile(gl, VS_BLIT, FS_BLIT, err, errsz)))) {
        rd_destroy(r);
        return NULL;
    }
    gl->glGenVertexArrays(1, &r->vao);
    gl->glGenBuffers(1, &r->vbo);
    gl->glBindVertexArray(r->vao);
    gl->glBindBuffer(GL_ARRAY_BUFFER, r->vbo);
    for (GLuint a = 0; a < 3; ++a) {
        gl->glEnableVertexAttribArray(a);
        gl->glVertexAttribPointer(a, 3, GL_FLOAT, GL_FALSE, 9 * sizeof(float),
                                  (const void *)(uintptr_t)(3 * a * sizeof(float)));
    }
    return r;
}

static void drop_target(rd_renderer *r)
{
    gl_api *gl = &r->gl;
    if (r->fbo) gl->glDeleteFramebuffers(1, &r->fbo);
    if (r->color_rb) gl->glDeleteRenderbuffers(1, &r->color_rb);
    if (r->depth_rb) gl->glDeleteRenderbuffers(1, &r->depth_rb);
    r->fbo = r->color_rb = r->depth_rb = 0;
    r->fbo_w = r->fbo_h = 0;
}

void rd_destroy(rd_renderer *r)
{
    if (!r) return;
    /* The context is current while its objects are deleted (a null function: never loaded). */
    if (r->buffer && r->context.make_current(r->context.ctx, r->buffer, r->width * r->ss,
                                             r->height * r->ss) == 0) {
        if (r->gl.glDeleteFramebuffers) drop_target(r);
        if (r->gl.glDeleteTextures && r->texture) r->gl.glDeleteTextures(1, &r->texture);
        if (r->gl.glDeleteBuffers && r->vbo) r->gl.glDeleteBuffers(1, &r->vbo);
        if (r->gl.glDeleteVertexArrays && r->vao) r->gl.glDeleteVertexArrays(1, &r->vao);
        if (r->gl.glDeleteProgram) {
            if (r->prog_mesh) r->gl.glDeleteProgram(r->prog_mesh);
            if (r->prog_ground) r->gl.glDeleteProgram(r->prog_ground);
            if (r->prog_sky) r->gl.glDeleteProgram(r->prog_sky);
            if (r->prog_blit) r->gl.glDeleteProgram(r->prog_blit);
        }
    }
    if (r->context.destroy) r->context.destroy(r->context.ctx);
    free(r->buffer);
    free(r->verts);
    free(r);
}

int rd_width(const rd_renderer *r) { return r->width; }
int rd_height(const rd_renderer *r) { return r->height; }

int rd_resize(rd_renderer *r, int width, int height, char *err, size_t errsz)
{
    if (width < 1 || height < 1 || width > 16384 || height > 16384) {
        snprintf(err, errsz, "bad image size %d x %d", width, height);
        return -1;
    }
    uint8_t *b = malloc((size_t)width * r->ss * (size_t)height * r->ss * 4);
    if (!b) {
        snprintf(err, errsz, "out of memory");
        return -1;
    }
    free(r->buffer);
    r->buffer = b;
    r->width = width;
    r->height = height;
    return 0;
}

/* Without into_buffer: a framebuffer object of the supersampled size (made again when the size
 * changes), bound for drawing. */
static int bind_target(rd_renderer *r, int W, int H, char *err, size_t errsz)
{
    gl_api *gl = &r->gl;
    if (r->fbo && (r->fbo_w != W || r->fbo_h != H)) drop_target(r);
    if (!r->fbo) {
        gl->glGenFramebuffers(1, &r->fbo);
        gl->glGenRenderbuffers(1, &r->color_rb);
        gl->glGenRenderbuffers(1, &r->depth_rb);
        gl->glBindFramebuffer(GL_FRAMEBUFFER, r->fbo);
        gl->glBindRenderbuffer(GL_RENDERBUFFER, r->color_rb);
        gl->glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, W, H);
        gl->glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER,
                                      r->color_rb);
        gl->glBindRenderbuffer(GL_RENDERBUFFER, r->depth_rb);
        gl->glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, W, H);
        gl->glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER,
                                      r->depth_rb);
        r->fbo_w = W;
        r->fbo_h = H;
        if (gl->glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
            snprintf(err, errsz, "%s: the framebuffer object of %d x %d is incomplete",
                     r->context.name, W, H);
            drop_target(r);
            return -1;
        }
    }
    gl->glBindFramebuffer(GL_FRAMEBUFFER, r->fbo);
    return 0;
}

int rd_present(rd_renderer *r, const uint8_t *rgb, int width, int height, int fb_width,
               int fb_height, char *err, size_t errsz)
{
    gl_api *gl = &r->gl;
    if (!r->prog_blit) {
        snprintf(err, errsz, "%s: the renderer draws into its buffer; nothing to present on",
                 r->context.name);
        return -1;
    }
    if (r->context.make_current(r->context.ctx, r->buffer, r->width * r->ss, r->height * r->ss)) {
        snprintf(err, errsz, "%s: cannot make the context current", r->context.name);
        return -1;
    }
    gl->glBindFramebuffer(GL_FRAMEBUFFER, 0);
    gl->glViewport(0, 0, fb_width, fb_height);
    gl->glDisable(GL_DEPTH_TEST);
    gl->glDisable(GL_BLEND);
    if (!r->texture) gl->glGenTextures(1, &r->texture);
    gl->glBindTexture(GL_TEXTURE_2D, r->texture);
    gl->glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    gl->glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB8, width, height, 0, GL_RGB, GL_UNSIGNED_BYTE, rgb);
    gl->glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    gl->glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER,
                        fb_width == width && fb_height == height ? GL_NEAREST : GL_LINEAR);
    gl->glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    gl->glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    gl->glUseProgram(r->prog_blit);
    gl->glUniform1i(gl->glGetUniformLocation(r->prog_blit, "image"), 0);
    gl->glBindVertexArray(r->vao);
    gl->glDrawArrays(GL_TRIANGLES, 0, 3);
    const GLenum e = gl->glGetError();
    if (e != GL_NO_ERROR) {
        snprintf(err, errsz, "GL error 0x%x", (unsigned)e);
        return -1;
    }
    return 0;
}

/* ------------------------------------------------------------------------------------------ */
/* Vectors and the view */

static void sub(const double *a, const double *b, double *o) { for (int i = 0; i < 3; ++i) o[i] = a[i] - b[i]; }
static double dot(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static void cross(const double *a, const double *b, double *o)
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}
static double norm(const double *a) { return sqrt(dot(a, a)); }
static void normalize(double *a)
{
    double l = norm(a);
    if (l > 0.0) for (int i = 0; i < 3; ++i) a[i] /= l;
}

/* (x1 - x0) x (x2 - x0) of triangle q: its normal, twice its area long. */
static void tri_normal(const double *x, const int32_t *q, double n[3])
{
    double e1[3], e2[3];
    sub(x + 3 * (int64_t)q[1], x + 3 * (int64_t)q[0], e1);
    sub(x + 3 * (int64_t)q[2], x + 3 * (int64_t)q[0], e2);
    cross(e1, e2, n);
}

/* A "nice" grid spacing (1, 2 or 5 times a power of ten) close to x. */
static double nice(double x)
{
    const double p = pow(10.0, floor(log10(x))), m = x / p;
    return p * (m < 1.5 ? 1.0 : m < 3.5 ? 2.0 : m < 7.5 ? 5.0 : 10.0);
}

void rd_view_make(const scene_camera *cam, const double lo_in[3], const double hi_in[3],
                  const double gravity[3], double aspect, rd_view *v)
{
    memset(v, 0, sizeof *v);
    double lo[3], hi[3];
    memcpy(lo, cam->has_fit ? cam->fit_lo : lo_in, sizeof lo);
    memcpy(hi, cam->has_fit ? cam->fit_hi : hi_in, sizeof hi);
    double up[3] = {-gravity[0], -gravity[1], -gravity[2]};
    if (norm(up) == 0.0) { up[0] = 0.0; up[1] = 1.0; up[2] = 0.0; }
    normalize(up);
    const double center[3] = {0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])};
    double half[3];
    sub(hi, center, half);
    double radius = norm(half);
    if (!(radius > 0.0)) radius = 1.0;
    v->fov = cam->fov;
    if (cam->automatic) {
        /* Eye direction from azimuth (about "up") and elevation, from a frame in which a
         * horizontal axis is the projection of +z (or +x) onto the ground plane. */
        double ref[3] = {0.0, 0.0, 1.0};
        if (fabs(dot(ref, up)) > 0.9) { ref[0] = 1.0; ref[2] = 0.0; }
        double f[3], s[3];
        const double d0 = dot(ref, up);
        for (int i = 0; i < 3; ++i) f[i] = ref[i] - d0 * up[i];
        normalize(f);
        cross(up, f, s);
        const double az = cam->azimuth * M_PI / 180.0, el = cam->elevation * M_PI / 180.0;
        double dir[3];
        for (int i = 0; i < 3; ++i)
            dir[i] = cos(el) * (cos(az) * f[i] + sin(az) * s[i]) + sin(el) * up[i];
        /* Distance so that the bounding sphere fits both field-of-view angles. */
        const double vf = cam->fov * M_PI / 360.0;
        const double hf = atan(tan(vf) * aspect);
        const double dist = radius / sin(fmin(vf, hf)) / cam->zoom;
        for (int i = 0; i < 3; ++i) {
            v->target[i] = center[i];
            v->eye[i] = center[i] + dist * dir[i];
            v->up[i] = up[i];
        }
    } else {
        memcpy(v->eye, cam->eye, sizeof v->eye);
        memcpy(v->target, cam->target, sizeof v->target);
        memcpy(v->up, cam->up, sizeof v->up);
        if (norm(v->up) == 0.0) memcpy(v->up, up, sizeof up);
    }
    double d[3];
    sub(v->eye, v->target, d);
    const double dist = norm(d) > 0.0 ? norm(d) : 1.0;
    v->ground = cam->ground;
    memcpy(v->ground_normal, up, sizeof up);
    /* Ground: at the given height along "up", else just below the fitted box. */
    double hlo = INFINITY;
    for (int c = 0; c < 8; ++c) {
        const double p[3] = {(c & 1) ? hi[0] : lo[0], (c & 2) ? hi[1] : lo[1], (c & 4) ? hi[2] : lo[2]};
        hlo = fmin(hlo, dot(p, up));
    }
    const double gh = cam->has_ground_height ? cam->ground_height : hlo - 0.05 * radius;
    const double ch = dot(center, up);
    for (int i = 0; i < 3; ++i) v->ground_origin[i] = center[i] + (gh - ch) * up[i];
    v->ground_extent = 4.0 * radius + 0.5 * dist;
    v->grid_spacing = nice(radius / 4.0);
    v->line_radius = 0.012 * radius;
    v->near_plane = fmax(dist - 3.0 * radius, 0.02 * dist);
    v->far_plane = dist + v->ground_extent * 1.5 + radius;
}

void rd_view_basis(const rd_view *v, double f[3], double s[3], double u[3])
{
    sub(v->target, v->eye, f);
    normalize(f);
    cross(f, v->up, s);
    if (norm(s) < 1e-12) {
        const double alt[3] = {1.0, 0.0, 0.0};
        cross(f, alt, s);
    }
    normalize(s);
    cross(s, f, u);
}

/* Column-major 4x4 for GL: proj * view. */
void rd_view_matrix(const rd_view *v, double aspect, double out[16])
{
    double f[3], s[3], u[3];
    rd_view_basis(v, f, s, u);
    double V[16] = {s[0], u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0,
                    -dot(s, v->eye), -dot(u, v->eye), dot(f, v->eye), 1};
    const double t = 1.0 / tan(v->fov * M_PI / 360.0), n = v->near_plane, fa = v->far_plane;
    double P[16] = {t / aspect, 0, 0, 0, 0, t, 0, 0, 0, 0, (fa + n) / (n - fa), -1,
                    0, 0, 2 * fa * n / (n - fa), 0};
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) {
            double acc = 0.0;
            for (int k = 0; k < 4; ++k) acc += P[4 * k + r] * V[4 * c + k];
            out[4 * c + r] = acc;
        }
}

/* ------------------------------------------------------------------------------------------ */
/* Geometry */

static int reserve(rd_renderer *r, size_t more)
{
    if (r->nverts + more <= r->cap) return 1;
    size_t cap = r->cap ? r->cap : 4096;
    while (cap < r->nverts + more) cap *= 2;
    float *p = realloc(r->verts, cap * 9 * sizeof *p);
    if (!p) return 0;
    r->verts = p;
    r->cap = cap;
    return 1;
}

static void emit(rd_renderer *r, const double *p, const double *n, const float *c)
{
    float *o = r->verts + 9 * r->nverts++;
    for (int i = 0; i < 3; ++i) { o[i] = (float)p[i]; o[3 + i] = (float)n[i]; o[6 + i] = c[i]; }
}

static int add_triangles(rd_renderer *r, const double *x, const rd_part *p)
{
    if (!reserve(r, 3 * (size_t)p->ntris)) return 0;
    double *vn = NULL;
    if (p->smooth) {
        /* Area-weighted vertex normals over this part's triangles. */
        int32_t maxv = 0;
        for (int64_t i = 0; i < 3 * (int64_t)p->ntris; ++i) if (p->tris[i] > maxv) maxv = p->tris[i];
        vn = calloc(3 * ((size_t)maxv + 1), sizeof *vn);
        if (!vn) return 0;
        for (int32_t t = 0; t < p->ntris; ++t) {
            const int32_t *q = p->tris + 3 * t;
            double n[3];
            tri_normal(x, q, n);
            for (int a = 0; a < 3; ++a)
                for (int i = 0; i < 3; ++i) vn[3 * (int64_t)q[a] + i] += n[i];
        }
    }
    for (int32_t t = 0; t < p->ntris; ++t) {
        const int32_t *q = p->tris + 3 * t;
        double n[3];
        tri_normal(x, q, n);
        normalize(n);
        for (int a = 0; a < 3; ++a) {
            double nn[3] = {n[0], n[1], n[2]};
            if (vn) {
                memcpy(nn, vn + 3 * (int64_t)q[a], sizeof nn);
                normalize(nn);
            }
            const float *col = p->tri_colors ? p->tri_colors + 3 * (int64_t)t
                               : p->vertex_colors ? p->vertex_colors + 3 * (int64_t)q[a] : p->color;
            emit(r, x + 3 * (int64_t)q[a], nn, col);
        }
    }
    free(vn);
    return 1;
}

/* Lines as 8-sided tubes with a small ball at each end. */
static int add_lines(rd_renderer *r, const double *x, const rd_part *p, double radius)
{
    enum { SIDES = 8, LAT = 4 };
    if (!reserve(r, (size_t)p->nlines * (6 * SIDES + 2 * 6 * SIDES * LAT))) return 0;
    for (int32_t l = 0; l < p->nlines; ++l) {
        const double *a = x + 3 * (int64_t)p->lines[2 * l], *b = x + 3 * (int64_t)p->lines[2 * l + 1];
        double d[3], e1[3], e2[3];
        sub(b, a, d);
        if (norm(d) == 0.0) continue;
        normalize(d);
        const double ref[3] = {fabs(d[0]) < 0.9 ? 1.0 : 0.0, fabs(d[0]) < 0.9 ? 0.0 : 1.0, 0.0};
        cross(d, ref, e1);
        normalize(e1);
        cross(d, e1, e2);
        for (int k = 0; k < SIDES; ++k) {
            const double t0 = 2 * M_PI * k / SIDES, t1 = 2 * M_PI * (k + 1) / SIDES;
            double n0[3], n1[3], pa0[3], pa1[3], pb0[3], pb1[3];
            for (int i = 0; i < 3; ++i) {
                n0[i] = cos(t0) * e1[i] + sin(t0) * e2[i];
                n1[i] = cos(t1) * e1[i] + sin(t1) * e2[i];
                pa0[i] = a[i] + radius * n0[i]; pa1[i] = a[i] + radius * n1[i];
                pb0[i] = b[i] + radius * n0[i]; pb1[i] = b[i] + radius * n1[i];
            }
            emit(r, pa0, n0, p->color); emit(r, pb0, n0, p->color); emit(r, pb1, n1, p->color);
            emit(r, pa0, n0, p->color); emit(r, pb1, n1, p->color); emit(r, pa1, n1, p->color);
        }
        /* Balls: latitude bands around d. */
        for (int end = 0; end < 2; ++end) {
            const double *c = end ? b : a;
            for (int la = 0; la < 2 * LAT; ++la)
                for (int k = 0; k < SIDES; ++k) {
                    if (r->nverts + 6 > r->cap && !reserve(r, 6)) return 0;
                    double q[4][3], n[4][3];
                    for (int corner = 0; corner < 4; ++corner) {
                        const double ph = M_PI * (la + (corner >> 1)) / (2 * LAT) - M_PI / 2;
                        const double th = 2 * M_PI * (k + (corner & 1)) / SIDES;
                        for (int i = 0; i < 3; ++i) {
                            n[corner][i] = cos(ph) * (cos(th) * e1[i] + sin(th) * e2[i]) + sin(ph) * d[i];
                            q[corner][i] = c[i] + radius * n[corner][i];
                        }
                    }
                    emit(r, q[0], n[0], p->color); emit(r, q[1], n[1], p->color); emit(r, q[3], n[3], p->color);
                    emit(r, q[0], n[0], p->color); emit(r, q[3], n[3], p->color); emit(r, q[2], n[2], p->color);
                }
        }
    }
    return 1;
}

/* Draws the r->nverts vertices gathered with the shaded mesh program. */
static void draw_mesh(rd_renderer *r, const float mvp[16], const rd_view *v, const double key[3])
{
    gl_api *gl = &r->gl;
    gl->glUseProgram(r->prog_mesh);
    gl->glUniformMatrix4fv(gl->glGetUniformLocation(r->prog_mesh, "mvp"), 1, GL_FALSE, mvp);
    gl->glUniform3f(gl->glGetUniformLocation(r->prog_mesh, "eye"), (float)v->eye[0],
                    (float)v->eye[1], (float)v->eye[2]);
    gl->glUniform3f(gl->glGetUniformLocation(r->prog_mesh, "up"), (float)v->up[0],
                    (float)v->up[1], (float)v->up[2]);
    gl->glUniform3f(gl->glGetUniformLocation(r->prog_mesh, "key"), (float)key[0],
                    (float)key[1], (float)key[2]);
    gl->glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(r->nverts * 9 * sizeof(float)), r->verts,
                     GL_STREAM_DRAW);
    gl->glDrawArrays(GL_TRIANGLES, 0, (GLsizei)r->nverts);
}

int rd_render(rd_renderer *r, const rd_view *v, const double *x, const rd_part *parts, int nparts,
              uint8_t *rgb, char *err, size_t errsz)
{
    gl_api *gl = &r->gl;
    const int W = r->width * r->ss, H = r->height * r->ss;
    if (r->context.make_current(r->context.ctx, r->buffer, W, H)) {
        snprintf(err, errsz, "%s: cannot make the context current", r->context.name);
        return -1;
    }
    if (!r->context.into_buffer && bind_target(r, W, H, err, errsz)) return -1;
    float mvp[16];
    {
        double m[16];
        rd_view_matrix(v, (double)r->width / r->height, m);
        for (int k = 0; k < 16; ++k) mvp[k] = (float)m[k];
    }
    gl->glViewport(0, 0, W, H);
    gl->glClearColor(1, 1, 1, 1);
    gl->glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    gl->glBindVertexArray(r->vao);
    gl->glBindBuffer(GL_ARRAY_BUFFER, r->vbo);

    /* Sky gradient, behind everything. */
    gl->glDisable(GL_DEPTH_TEST);
    gl->glDepthMask(GL_FALSE);
    gl->glUseProgram(r->prog_sky);
    gl->glDrawArrays(GL_TRIANGLES, 0, 3);
    gl->glDepthMask(GL_TRUE);
    gl->glEnable(GL_DEPTH_TEST);

    /* Bodies (the parts on top come last, below). */
    r->nverts = 0;
    for (int i = 0; i < nparts; ++i)
        if (!parts[i].on_top &&
            (!add_triangles(r, x, &parts[i]) || !add_lines(r, x, &parts[i], v->line_radius))) {
            snprintf(err, errsz, "out of memory");
            return -1;
        }
    double key[3];
    {
        /* Key light from above and from the viewer's side, a little to the right. */
        double f[3], s[3];
        sub(v->target, v->eye, f);
        normalize(f);
        cross(f, v->up, s);
        normalize(s);
        for (int i = 0; i < 3; ++i) key[i] = 0.6 * v->up[i] - 0.6 * f[i] + 0.3 * s[i];
        normalize(key);
    }
    if (r->nverts > 0) draw_mesh(r, mvp, v, key);

    /* Ground grid: a square around the target's foot point, blended so that it fades out. */
    if (v->ground) {
        double n[3], t1[3], t2[3], c[3];
        memcpy(n, v->ground_normal, sizeof n);
        const double ref[3] = {fabs(n[0]) < 0.9 ? 1.0 : 0.0, fabs(n[0]) < 0.9 ? 0.0 : 1.0, 0.0};
        cross(n, ref, t2);
        normalize(t2);
        cross(t2, n, t1);
        double d[3];
        sub(v->target, v->ground_origin, d);
        const double h = dot(d, n);
        for (int i = 0; i < 3; ++i) c[i] = v->target[i] - h * n[i];
        const double e = v->ground_extent;
        r->nverts = 0;
        reserve(r, 6);
        const int corners[6][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, -1}, {1, 1}, {-1, 1}};
        for (int k = 0; k < 6; ++k) {
            double p[3];
            for (int i = 0; i < 3; ++i) p[i] = c[i] + e * (corners[k][0] * t1[i] + corners[k][1] * t2[i]);
            /* Grid coordinates in the colour slot, measured from the ground origin. */
            double rel[3];
            sub(p, v->ground_origin, rel);
            const float uv[3] = {(float)dot(rel, t1), (float)dot(rel, t2), 0.0f};
            emit(r, p, n, uv);
        }
        gl->glUseProgram(r->prog_ground);
        gl->glUniformMatrix4fv(gl->glGetUniformLocation(r->prog_ground, "mvp"), 1, GL_FALSE, mvp);
        gl->glUniform1f(gl->glGetUniformLocation(r->prog_ground, "spacing"), (float)v->grid_spacing);
        gl->glUniform1f(gl->glGetUniformLocation(r->prog_ground, "extent"), (float)e);
        gl->glUniform3f(gl->glGetUniformLocation(r->prog_ground, "center"), (float)c[0],
                        (float)c[1], (float)c[2]);
        gl->glEnable(GL_BLEND);
        gl->glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
        gl->glEnable(GL_POLYGON_OFFSET_FILL);
        gl->glPolygonOffset(1.0f, 1.0f);
        gl->glBufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(6 * 9 * sizeof(float)), r->verts,
                         GL_STREAM_DRAW);
        gl->glDrawArrays(GL_TRIANGLES, 0, 6);
        gl->glDisable(GL_POLYGON_OFFSET_FILL);
        gl->glDisable(GL_BLEND);
    }
    /* Parts on top: over everything drawn so far, shaded, hiding each other as solids do. */
    r->nverts = 0;
    for (int i = 0; i < nparts; ++i)
        if (parts[i].on_top &&
            (!add_triangles(r, x, &parts[i]) || !add_lines(r, x, &parts[i], v->line_radius))) {
            snprintf(err, errsz, "out of memory");
            return -1;
        }
    if (r->nverts > 0) {
        gl->glClear(GL_DEPTH_BUFFER_BIT);
        gl->glBindBuffer(GL_ARRAY_BUFFER, r->vbo);
        draw_mesh(r, mvp, v, key);
    }
    gl->glFinish();
    GLenum e = gl->glGetError();
    if (e != GL_NO_ERROR) {
        snprintf(err, errsz, "GL error 0x%x", (unsigned)e);
        return -1;
    }
    if (!r->context.into_buffer) {
        gl->glPixelStorei(GL_PACK_ALIGNMENT, 1);
        gl->glReadPixels(0, 0, W, H, GL_RGBA, GL_UNSIGNED_BYTE, r->buffer);
    }
    /* Box-filter the supersampled buffer down; GL's rows run bottom-up. */
    const int ss = r->ss, n = ss * ss;
    for (int y = 0; y < r->height; ++y)
        for (int xo = 0; xo < r->width; ++xo) {
            unsigned acc[3] = {0, 0, 0};
            for (int sy = 0; sy < ss; ++sy)
                for (int sx = 0; sx < ss; ++sx) {
                    const uint8_t *p = r->buffer + 4 * ((size_t)(y * ss + sy) * W + (size_t)(xo * ss + sx));
                    acc[0] += p[0]; acc[1] += p[1]; acc[2] += p[2];
                }
            uint8_t *o = rgb + 3 * ((size_t)(r->height - 1 - y) * r->width + (size_t)xo);
            for (int c = 0; c < 3; ++c) o[c] = (uint8_t)((acc[c] + (unsigned)n / 2) / (unsigned)n);
        }
    return 0;
}

/* ------------------------------------------------------------------------------------------ */

typedef struct rface { int64_t key[3]; int32_t v[3]; } rface;

/* For a positively oriented tet (0, 1, 2, 3) these faces point outward. */
static const int F[4][3] = {{1, 3, 2}, {0, 2, 3}, {0, 3, 1}, {0, 1, 2}};

static void sort3(int64_t k[3])
{
    for (int i = 0; i < 3; ++i)
        for (int j = i + 1; j < 3; ++j)
            if (k[j] < k[i]) { const int64_t s = k[i]; k[i] = k[j]; k[j] = s; }
}

static int cmp_rface(const void *a, const void *b)
{
    const rface *x = a, *y = b;
    for (int i = 0; i < 3; ++i)
        if (x->key[i] != y->key[i]) return x->key[i] < y->key[i] ? -1 : 1;
    return 0;
}

int32_t *rd_tet_surface(const int64_t *tets, int64_t nt, int32_t *ntris)
{
    rface *f = malloc((size_t)(nt > 0 ? nt : 1) * 4 * sizeof *f);
    int32_t *out = malloc((size_t)(nt > 0 ? nt : 1) * 4 * 3 * sizeof *out);
    if (!f || !out) { free(f); free(out); return NULL; }
    for (int64_t t = 0; t < nt; ++t)
        for (int k = 0; k < 4; ++k) {
            rface *q = &f[4 * t + k];
            for (int i = 0; i < 3; ++i) q->v[i] = (int32_t)(q->key[i] = tets[4 * t + F[k][i]]);
            sort3(q->key);
        }
    qsort(f, (size_t)(4 * nt), sizeof *f, cmp_rface);
    int32_t n = 0;
    for (int64_t i = 0; i < 4 * nt;) {
        int64_t j = i + 1;
        while (j < 4 * nt && cmp_rface(&f[i], &f[j]) == 0) ++j;
        if (j - i == 1) { memcpy(out + 3 * (int64_t)n, f[i].v, 3 * sizeof *out); ++n; }
        i = j;
    }
    free(f);
    *ntris = n;
    return out;
}

int rd_triangle_tets(const int32_t *tets, int64_t nt, const int32_t *tris, int32_t ntris,
                     int32_t *tet_of)
{
    /* Every face of every tet, sorted by its vertex set; each triangle is looked up. */
    rface *f = malloc((size_t)(nt > 0 ? nt : 1) * 4 * sizeof *f);
    if (!f) return -1;
    for (int64_t t = 0; t < nt; ++t)
        for (int k = 0; k < 4; ++k) {
            rface *q = &f[4 * t + k];
            int64_t *key = q->key;
            for (int i = 0; i < 3; ++i) key[i] = tets[4 * t + F[k][i]];
            sort3(key);
            q->v[0] = (int32_t)t;
        }
    qsort(f, (size_t)(4 * nt), sizeof *f, cmp_rface);
    for (int32_t i = 0; i < ntris; ++i) {
        rface want;
        for (int a = 0; a < 3; ++a) want.key[a] = tris[3 * (int64_t)i + a];
        sort3(want.key);
        const rface *hit = nt > 0 ? bsearch(&want, f, (size_t)(4 * nt), sizeof *f, cmp_rface) : NULL;
        tet_of[i] = hit ? hit->v[0] : -1;
    }
    free(f);
    return 0;
}

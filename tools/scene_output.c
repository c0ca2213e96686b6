/* SPDX-License-Identifier: MIT */
/* Scene files: the settings of the rendered output (frames, image size, camera, colours). */
#include "scene_output.h"

#include "scene_json.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static const float palette[6][3] = {{0.85f, 0.45f, 0.20f}, {0.25f, 0.55f, 0.85f},
                                    {0.35f, 0.70f, 0.35f}, {0.80f, 0.30f, 0.45f},
                                    {0.60f, 0.45f, 0.80f}, {0.85f, 0.75f, 0.25f}};

void scene_palette(int i, float rgb[3]) { memcpy(rgb, palette[(i % 6 + 6) % 6], 3 * sizeof(float)); }

int scene_color_parse(const char *name)
{
    static const char *const names[] = {"body", "stress", "displacement", "speed"};
    for (int i = 0; name && i < 4; ++i)
        if (!strcmp(name, names[i])) return i;
    return -1;
}

void scene_output_defaults(scene *s)
{
    s->fields = SCENE_FIELD_STRESS | SCENE_FIELD_DISPLACEMENT | SCENE_FIELD_PIN_FORCES |
                SCENE_FIELD_ATTACHMENT_FORCES | SCENE_FIELD_CONTACT_FORCES;
    s->every = 1;
    s->write_vtk = 1;
    s->width = 640;
    s->height = 400;
    s->supersample = 2;
    s->contact_sheet = 1;
    s->camera.automatic = 1;
    s->camera.fov = 35.0;
    s->camera.azimuth = 35.0;
    s->camera.elevation = 20.0;
    s->camera.zoom = 1.0;
    s->camera.ground = 1;
}

static int parse_camera(sj_ctx *c, const cJSON *j)
{
    scene_camera *cam = &c->s->camera;
    static const char *const keys[] = {"eye", "target", "up", "fov", "azimuth", "elevation",
                                       "zoom", "fit", "ground", NULL};
    if (sj_keys(c, j, "output.camera", keys)) return -1;
    const cJSON *eye = cJSON_GetObjectItemCaseSensitive(j, "eye");
    if (eye) {
        cam->automatic = 0;
        if (!cJSON_GetObjectItemCaseSensitive(j, "target"))
            return sj_fail(c, j, "output.camera: \"eye\" needs \"target\"");
        for (const char *k = "azimuth"; k; k = strcmp(k, "azimuth") == 0 ? "elevation" :
                                              strcmp(k, "elevation") == 0 ? "zoom" :
                                              strcmp(k, "zoom") == 0 ? "fit" : NULL) {
            const cJSON *x = cJSON_GetObjectItemCaseSensitive(j, k);
            if (x) return sj_fail(c, x, "output.camera.%s is for the automatic camera; it cannot "
                                  "be combined with \"eye\"", k);
        }
    }
    if (sj_vec3(c, j, "eye", "output.camera", cam->eye) ||
        sj_vec3(c, j, "target", "output.camera", cam->target) ||
        sj_vec3(c, j, "up", "output.camera", cam->up) ||
        sj_number(c, j, "fov", "output.camera", 1.0, 170.0, 0, &cam->fov) ||
        sj_number(c, j, "azimuth", "output.camera", -360.0, 360.0, 0, &cam->azimuth) ||
        sj_number(c, j, "elevation", "output.camera", -89.0, 89.0, 0, &cam->elevation) ||
        sj_number(c, j, "zoom", "output.camera", 0.0, 1e6, 1, &cam->zoom))
        return -1;
    const cJSON *fit = cJSON_GetObjectItemCaseSensitive(j, "fit");
    if (fit) {
        if (!cJSON_IsArray(fit) || cJSON_GetArraySize(fit) != 2 ||
            sj_vec(c, fit->child, "output.camera.fit[0]", 3, cam->fit_lo) ||
            sj_vec(c, fit->child->next, "output.camera.fit[1]", 3, cam->fit_hi))
            return sj_fail(c, fit, "output.camera.fit must be [[xlo, ylo, zlo], [xhi, yhi, zhi]]");
        for (int i = 0; i < 3; ++i)
            if (!(cam->fit_hi[i] >= cam->fit_lo[i]))
                return sj_fail(c, fit, "output.camera.fit: the second corner must not be below the "
                               "first");
        cam->has_fit = 1;
    }
    const cJSON *g = cJSON_GetObjectItemCaseSensitive(j, "ground");
    if (g) {
        if (cJSON_IsBool(g)) cam->ground = cJSON_IsTrue(g);
        else if (cJSON_IsNumber(g) && isfinite(g->valuedouble)) {
            cam->ground = 1;
            cam->has_ground_height = 1;
            cam->ground_height = g->valuedouble;
        } else {
            return sj_fail(c, g, "output.camera.ground must be true, false or a height (m)");
        }
    }
    const double *u = cam->up;
    const cJSON *uj = cJSON_GetObjectItemCaseSensitive(j, "up");
    if (uj && u[0] * u[0] + u[1] * u[1] + u[2] * u[2] == 0.0)
        return sj_fail(c, uj, "output.camera.up must not be zero");
    return 0;
}

int scene_parse_output(sj_ctx *c, const cJSON *o)
{
    scene *s = c->s;
    static const char *const keys[] = {"every", "formats", "width", "height", "supersample",
                                       "contact_sheet", "camera", "color", "color_range",
                                       "fields", "contact_arrows", "arrow_scale", NULL};
    if (sj_keys(c, o, "output", keys)) return -1;
    if (sj_int(c, o, "every", "output", 1, 1000000000, &s->every) ||
        sj_int(c, o, "width", "output", 16, 8192, &s->width) ||
        sj_int(c, o, "height", "output", 16, 8192, &s->height) ||
        sj_int(c, o, "supersample", "output", 1, 4, &s->supersample) ||
        sj_bool(c, o, "contact_sheet", "output", &s->contact_sheet) ||
        sj_bool(c, o, "contact_arrows", "output", &s->contact_arrows) ||
        sj_number(c, o, "arrow_scale", "output", 0.0, 1e12, 1, &s->arrow_scale))
        return -1;
    const cJSON *f = cJSON_GetObjectItemCaseSensitive(o, "formats");
    if (f) {
        if (!cJSON_IsArray(f)) return sj_fail(c, f, "output.formats must be an array of \"vtk\", \"png\"");
        s->write_vtk = s->write_png = 0;
        for (const cJSON *e = f->child; e; e = e->next) {
            if (cJSON_IsString(e) && !strcmp(e->valuestring, "vtk")) s->write_vtk = 1;
            else if (cJSON_IsString(e) && !strcmp(e->valuestring, "png")) s->write_png = 1;
            else return sj_fail(c, e, "output.formats: unknown format (known: \"vtk\", \"png\")");
        }
    }
    const cJSON *cam = cJSON_GetObjectItemCaseSensitive(o, "camera");
    if (cam && parse_camera(c, cam)) return -1;
    const cJSON *col = cJSON_GetObjectItemCaseSensitive(o, "color");
    if (col) {
        s->color = cJSON_IsString(col) ? scene_color_parse(col->valuestring) : -1;
        if (s->color < 0)
            return sj_fail(c, col, "output.color must be \"body\", \"stress\", \"displacement\" "
                           "or \"speed\"");
    }
    const cJSON *cr = cJSON_GetObjectItemCaseSensitive(o, "color_range");
    if (cr) {
        if (sj_vec(c, cr, "output.color_range", 2, s->color_range)) return -1;
        if (!(s->color_range[1] > s->color_range[0]))
            return sj_fail(c, cr, "output.color_range must be [lo, hi] with hi > lo");
        s->has_color_range = 1;
    }
    const cJSON *fl = cJSON_GetObjectItemCaseSensitive(o, "fields");
    if (fl) {
        static const char *const names[] = {"stress", "displacement", "pin_forces",
                                            "attachment_forces", "contact_forces"};
        if (!cJSON_IsArray(fl))
            return sj_fail(c, fl, "output.fields must be an array of \"stress\", \"displacement\", "
                           "\"pin_forces\", \"attachment_forces\", \"contact_forces\"");
        s->fields = 0;
        for (const cJSON *e = fl->child; e; e = e->next) {
            int found = -1;
            for (int i = 0; i < 5; ++i)
                if (cJSON_IsString(e) && !strcmp(e->valuestring, names[i])) found = i;
            if (found < 0)
                return sj_fail(c, e, "output.fields: unknown field (known: \"stress\", "
                               "\"displacement\", \"pin_forces\", \"attachment_forces\", "
                               "\"contact_forces\")");
            s->fields |= 1u << found;
        }
    }
    return 0;
}

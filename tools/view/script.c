/* SPDX-License-Identifier: MIT */
/* The viewer's input scripts: one command a line (tools/view/README.md lists them). */
#include "viewer.h"

#include "../src/file_read.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void vw_script_free(vw_script *sc)
{
    free(sc->cmds);
    sc->cmds = NULL;
    sc->n = 0;
}

/* The next whitespace-separated word of *p into w (at most size - 1 characters); 0 at the end. */
static int word(const char **p, char *w, size_t size)
{
    const char *s = *p;
    while (*s && isspace((unsigned char)*s)) ++s;
    size_t n = 0;
    while (s[n] && !isspace((unsigned char)s[n])) ++n;
    if (n == 0 || n >= size) {
        *p = s + n;
        return 0;
    }
    memcpy(w, s, n);
    w[n] = '\0';
    *p = s + n;
    return 1;
}

static int number(const char **p, double *out)
{
    char w[64], *end;
    if (!word(p, w, sizeof w)) return 0;
    *out = strtod(w, &end);
    return *end == '\0';
}

static int count(const char **p, int lo, int *out)
{
    double v;
    if (!number(p, &v) || v != (double)(int)v || v < lo || v > 100000000) return 0;
    *out = (int)v;
    return 1;
}

static int expect_word(const char **p, const char *want)
{
    char w[32];
    return word(p, w, sizeof w) && !strcmp(w, want);
}

static int at_end(const char *p)
{
    while (*p && isspace((unsigned char)*p)) ++p;
    return *p == '\0';
}

/* One line into c; returns 1 for a command, 0 for a blank or comment line, -1 with why. */
static int parse_line(const char *line, vw_cmd *c, const char **why)
{
    const char *p = line;
    char op[32];
    memset(c, 0, sizeof *c);
    if (!word(&p, op, sizeof op)) {
        *why = "a command name is too long";
        return at_end(line) ? 0 : -1;
    }
    *why = NULL;
    if (!strcmp(op, "play")) c->op = VW_PLAY;
    else if (!strcmp(op, "pause")) c->op = VW_PAUSE;
    else if (!strcmp(op, "reset")) c->op = VW_RESET;
    else if (!strcmp(op, "release")) c->op = VW_RELEASE;
    else if (!strcmp(op, "quit")) c->op = VW_QUIT;
    else if (!strcmp(op, "step")) {
        c->op = VW_STEP;
        c->n = 1;
        if (!at_end(p) && !count(&p, 1, &c->n)) *why = "step [N]: N >= 1 steps";
    } else if (!strcmp(op, "wait")) {
        c->op = VW_WAIT;
        if (!count(&p, 1, &c->n)) *why = "wait N: N >= 1 frames";
    } else if (!strcmp(op, "color")) {
        char m[32];
        c->op = VW_COLOR;
        if (!word(&p, m, sizeof m) || (c->n = scene_color_parse(m)) < 0)
            *why = "color body|stress|displacement|speed";
    } else if (!strcmp(op, "timing")) {
        char m[8];
        c->op = VW_TIMING;
        if (!word(&p, m, sizeof m) || (strcmp(m, "on") && strcmp(m, "off")))
            *why = "timing on|off";
        else c->n = !strcmp(m, "on");
    } else if (!strcmp(op, "orbit") || !strcmp(op, "press") || !strcmp(op, "move")) {
        c->op = op[0] == 'o' ? VW_ORBIT : op[0] == 'p' ? VW_PRESS : VW_MOVE;
        if (!number(&p, &c->a[0]) || !number(&p, &c->a[1]))
            *why = c->op == VW_ORBIT ? "orbit DX DY (pixels)" : "press|move X Y (pixels)";
    } else if (!strcmp(op, "zoom")) {
        c->op = VW_ZOOM;
        if (!number(&p, &c->a[0])) *why = "zoom CLICKS (positive: closer)";
    } else if (!strcmp(op, "drag")) {
        c->op = VW_DRAG;
        if (!number(&p, &c->a[0]) || !number(&p, &c->a[1]) || !expect_word(&p, "->") ||
            !number(&p, &c->a[2]) || !number(&p, &c->a[3]) || !expect_word(&p, "over") ||
            !count(&p, 1, &c->n) || !expect_word(&p, "frames"))
            *why = "drag X Y -> X2 Y2 over N frames";
    } else if (!strcmp(op, "screenshot")) {
        c->op = VW_SCREENSHOT;
        if (!word(&p, c->text, sizeof c->text)) *why = "screenshot FILE.png";
    } else if (!strcmp(op, "expect")) {
        char cmp[8];
        c->op = VW_EXPECT;
        if (!word(&p, c->text, sizeof c->text) || !word(&p, cmp, sizeof cmp) ||
            !number(&p, &c->value))
            *why = "expect QUANTITY <|>|<=|>=|== VALUE";
        else if (!strcmp(cmp, "<")) c->cmp = '<';
        else if (!strcmp(cmp, ">")) c->cmp = '>';
        else if (!strcmp(cmp, "<=")) c->cmp = 'l';
        else if (!strcmp(cmp, ">=")) c->cmp = 'g';
        else if (!strcmp(cmp, "==")) c->cmp = '=';
        else *why = "expect: the comparison is one of < > <= >= ==";
    } else {
        *why = "unknown command (play, pause, step, reset, color, timing, wait, orbit, zoom, "
               "press, move, release, drag, screenshot, expect, quit)";
    }
    if (!*why && !at_end(p)) *why = "unexpected words after the command";
    return *why ? -1 : 1;
}

int vw_script_load(vw_script *sc, const char *path, char *err, size_t errsz)
{
    memset(sc, 0, sizeof *sc);
    snprintf(sc->path, sizeof sc->path, "%s", path);
    char *text = NULL;
    size_t len = 0;
    if (defsim__read_file(path, DEFSIM__FILE_MAX, &text, &len) != 0) {
        snprintf(err, errsz, "%s: cannot read the script", path);
        return -2;
    }
    int cap = 0, lineno = 0, rc = 0;
    for (char *line = text; line && *line && rc == 0;) {
        char *nl = strchr(line, '\n');
        if (nl) *nl = '\0';
        ++lineno;
        char *hash = strchr(line, '#');
        if (hash) *hash = '\0';
        vw_cmd c;
        const char *why = NULL;
        const int k = strlen(line) > 2000 ? (why = "the line is too long", -1)
                                          : parse_line(line, &c, &why);
        if (k < 0) {
            snprintf(err, errsz, "%s:%d: %s", path, lineno, why);
            rc = -1;
        } else if (k > 0) {
            if (sc->n == cap) {
                cap = cap ? 2 * cap : 32;
                vw_cmd *m = realloc(sc->cmds, (size_t)cap * sizeof *m);
                if (!m) {
                    snprintf(err, errsz, "out of memory");
                    rc = -1;
                    break;
                }
                sc->cmds = m;
            }
            c.line = lineno;
            sc->cmds[sc->n++] = c;
        }
        line = nl ? nl + 1 : NULL;
    }
    free(text);
    if (rc) vw_script_free(sc);
    return rc;
}

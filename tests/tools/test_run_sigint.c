/* SPDX-License-Identifier: MIT */
/*
 * Ctrl-C during `defsim run`: starts a long run of a scene, waits until it has written a few
 * frames, sends SIGINT, and checks that the run stops with status 130, that the .pvd is
 * well-formed XML listing exactly the frames on disk (consecutive from 0), that every listed
 * .vtu is complete, that final.vtu exists and that no temporary file is left behind.
 *
 *   test_run_sigint DEFSIM_EXE SCENE.json OUT_DIR
 */
#include "tool_check.h"

#include "file_read.h"

#include <dirent.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

/* *text: the whole file (NUL-terminated; the caller frees it) through the library's reader
 * (src/file_read.c), or NULL. */
static void slurp(const char *path, char **text, size_t *len)
{
    size_t n = 0;
    if (defsim__read_file(path, DEFSIM__FILE_MAX, text, &n)) *text = NULL;
    if (len) *len = n;
}

static int count_datasets(const char *pvd)
{
    char *t;
    slurp(pvd, &t, NULL);
    int n = 0;
    for (const char *p = t; p && (p = strstr(p, "<DataSet")); ++p) ++n;
    free(t);
    return n;
}

/* XML well-formedness for the subset we write: declaration, elements with quoted attributes,
 * self-closing tags, balanced nesting, nothing after the root. Returns the root's children. */
static int xml_well_formed(const char *s)
{
    const char *stack[16];
    size_t lens[16];
    int depth = 0, roots = 0;
    if (strncmp(s, "<?xml", 5) != 0) return 0;
    s = strstr(s, "?>");
    if (!s) return 0;
    s += 2;
    while (*s) {
        if (*s != '<') {
            if (depth == 0 && !strchr(" \t\r\n", *s)) return 0;
            ++s;
            continue;
        }
        if (s[1] == '/') {
            const char *name = s + 2, *end = strchr(name, '>');
            if (!end || depth == 0) return 0;
            --depth;
            if ((size_t)(end - name) != lens[depth] || strncmp(name, stack[depth], lens[depth]))
                return 0;
            s = end + 1;
            continue;
        }
        const char *name = s + 1;
        size_t n = strcspn(name, " \t\r\n/>");
        if (n == 0) return 0;
        const char *p = name + n;
        /* attributes: name="value" */
        for (;;) {
            p += strspn(p, " \t\r\n");
            if (*p == '>' || (p[0] == '/' && p[1] == '>')) break;
            size_t an = strcspn(p, "= \t\r\n>");
            if (an == 0 || p[an] != '=' || p[an + 1] != '"') return 0;
            const char *q = strchr(p + an + 2, '"');
            if (!q) return 0;
            p = q + 1;
        }
        if (depth == 0 && roots++ > 0) return 0;
        if (*p == '/') { s = p + 2; continue; }
        if (depth == 16) return 0;
        stack[depth] = name;
        lens[depth++] = n;
        s = p + 1;
    }
    return depth == 0 && roots == 1;
}

int main(int argc, char **argv)
{
    if (argc != 4) {
        fprintf(stderr, "usage: test_run_sigint DEFSIM SCENE OUT\n");
        return 2;
    }
    const char *exe = argv[1], *scene = argv[2], *out = argv[3];
    char cmd[4096], pvd[4096];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", out);
    if (system(cmd) != 0) return 2;
    snprintf(pvd, sizeof pvd, "%s/cantilever.pvd", out);

    pid_t pid = fork();
    if (pid < 0) return 2;
    if (pid == 0) {
        freopen("/dev/null", "w", stdout);
        execl(exe, exe, "run", scene, "--out", out, "--set", "world.duration=1000", "--threads",
              "1", "--progress", "lines", (char *)NULL);
        _exit(127);
    }
    /* Wait for at least 4 frames (at most 60 s). */
    const struct timespec nap = {0, 20 * 1000 * 1000};
    int frames = 0;
    for (int i = 0; i < 3000 && frames < 4; ++i) {
        nanosleep(&nap, NULL);
        frames = count_datasets(pvd);
        int st;
        if (waitpid(pid, &st, WNOHANG) == pid) {
            fprintf(stderr, "FAIL: defsim run ended early (status %d)\n", st);
            return 1;
        }
    }
    CHECK(frames >= 4, "only %d frames written after 60 s", frames);
    kill(pid, SIGINT);
    int status = 0, done = 0;
    for (int i = 0; i < 3000 && !done; ++i) {
        if (waitpid(pid, &status, WNOHANG) == pid) done = 1;
        else nanosleep(&nap, NULL);
    }
    if (!done) {
        kill(pid, SIGKILL);
        waitpid(pid, &status, 0);
        fprintf(stderr, "FAIL: defsim run did not stop within 60 s of SIGINT\n");
        return 1;
    }
    CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 130,
          "exit status %d (expected 130)", WIFEXITED(status) ? WEXITSTATUS(status) : -1);

    char *text;
    slurp(pvd, &text, NULL);
    CHECK(text && xml_well_formed(text), "%s is not well-formed XML", pvd);
    int listed = 0;
    for (const char *p = text; p && (p = strstr(p, "<DataSet")); ++p) {
        char want[64], path[4200];
        snprintf(want, sizeof want, "file=\"frame_%05d.vtu\"", listed);
        const char *end = strchr(p, '>');
        const char *at = strstr(p, want);
        CHECK(at && at < end, "DataSet %d does not name %s", listed, want);
        snprintf(path, sizeof path, "%s/frame_%05d.vtu", out, listed);
        size_t len = 0;
        char *vtu;
        slurp(path, &vtu, &len);
        CHECK(vtu && len > 20 && strncmp(vtu, "<?xml", 5) == 0 &&
              strcmp(vtu + len - 11, "</VTKFile>\n") == 0, "%s is missing or incomplete", path);
        free(vtu);
        ++listed;
    }
    free(text);
    CHECK(listed >= frames, "the .pvd lists %d frames, %d were seen before SIGINT", listed, frames);
    /* Every frame on disk is listed, and nothing temporary is left. */
    int on_disk = 0;
    DIR *d = opendir(out);
    CHECK(d != NULL, "cannot list %s", out);
    for (struct dirent *e; d && (e = readdir(d));) {
        if (!strncmp(e->d_name, "frame_", 6) && strstr(e->d_name, ".vtu")) ++on_disk;
        CHECK(!strstr(e->d_name, ".tmp"), "temporary file %s left behind", e->d_name);
    }
    if (d) closedir(d);
    CHECK(on_disk == listed, "%d frames on disk, %d listed", on_disk, listed);
    char final[4200];
    snprintf(final, sizeof final, "%s/final.vtu", out);
    struct stat sb;
    CHECK(stat(final, &sb) == 0 && sb.st_size > 0, "no final.vtu");
    printf("test_run_sigint: %d frames before SIGINT, %d listed, %d failures\n", frames, listed,
           failures);
    return failures ? 1 : 0;
}

/* SPDX-License-Identifier: MIT */
/*
 * pngdiff: compares two PNG images for the visual tests.
 *
 *   pngdiff A.png B.png [--threshold T] [--max-fraction F] [--diff OUT.png]
 *
 * A pixel differs when any channel differs by more than T (0..255, default 16). The images
 * match when at most the fraction F of pixels differ (default 0.002). Exit status: 0 match,
 * 1 differ (or different sizes), 2 usage error or unreadable file.
 */
#include "image.h"
#include "../cli.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void usage(FILE *f)
{
    fprintf(f, "usage: pngdiff A.png B.png [--threshold T] [--max-fraction F] "
               "[--diff OUT.png]\n"
               "Compares two PNGs: a pixel differs when a channel differs by more than T\n"
               "(0..255, default 16); they match when at most the fraction F (default 0.002)\n"
               "differs. Exit status: 0 match, 1 differ, 2 usage error or unreadable file.\n"
               "  -h, --help   this text\n"
               "  --version    the library's version\n");
}

int main(int argc, char **argv)
{
    const char *a_path = NULL, *b_path = NULL, *diff_path = NULL;
    int threshold = 16;
    double max_fraction = 0.002;
    enum { O_THRESHOLD = CLI_OPT, O_MAX_FRACTION, O_DIFF };
    static const struct option options[] = {
        {"threshold", required_argument, NULL, O_THRESHOLD},
        {"max-fraction", required_argument, NULL, O_MAX_FRACTION},
        {"diff", required_argument, NULL, O_DIFF}, {0}};
    static const cli_tool tool = {"pngdiff", usage, options, ""};
    cli c;
    cli_begin(&c, &tool, argc, argv);
    for (int o; (o = cli_next(&c)) != CLI_END;) {
        int ok = 1;
        switch (o) {
        case CLI_EXIT: return c.status;
        case O_THRESHOLD: ok = cli_int(&c, 0, 255, &threshold); break;
        case O_MAX_FRACTION: ok = cli_double(&c, 0.0, 1.0, &max_fraction); break;
        case O_DIFF: diff_path = c.arg; break;
        }
        if (!ok) return c.status;
    }
    if (argc - c.optind != 2) return cli_error(&c, "need two PNG files");
    a_path = argv[c.optind];
    b_path = argv[c.optind + 1];
    image a, b, d = {0, 0, NULL};
    char err[512];
    if (image_read_png(a_path, &a, err, sizeof err)) {
        fprintf(stderr, "pngdiff: %s\n", err);
        return 2;
    }
    if (image_read_png(b_path, &b, err, sizeof err)) {
        fprintf(stderr, "pngdiff: %s\n", err);
        image_free(&a);
        return 2;
    }
    image_diff r;
    if (image_compare(&a, &b, threshold, &r, diff_path ? &d : NULL)) {
        printf("pngdiff: sizes differ: %s is %d x %d, %s is %d x %d\n", a_path, a.width, a.height,
               b_path, b.width, b.height);
        image_free(&a);
        image_free(&b);
        return 1;
    }
    const int match = r.fraction <= max_fraction;
    printf("pngdiff: %lld of %lld pixels differ by more than %d (%.4f%%, limit %.4f%%), "
           "largest channel difference %d: %s\n", (long long)r.differing, (long long)r.pixels,
           threshold, 100.0 * r.fraction, 100.0 * max_fraction, r.max_channel_diff,
           match ? "match" : "DIFFER");
    if (diff_path && d.rgb && image_write_png(diff_path, &d, err, sizeof err))
        fprintf(stderr, "pngdiff: %s\n", err);
    image_free(&a);
    image_free(&b);
    image_free(&d);
    return match ? 0 : 1;
}

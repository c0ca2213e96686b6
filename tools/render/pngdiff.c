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
    static const cli_tool tool = {"pngdiff", usage, NULL, ""};
    const cli_opt opts[] = {{"threshold", CLI_INT, &threshold, 0, 255},
                            {"max-fraction", CLI_DOUBLE, &max_fraction, 0.0, 1.0},
                            {"diff", CLI_STRING, &diff_path, 0, 0}, {0}};
    int first;
    const int parsed = cli_parse(&tool, opts, argc, argv, &first);
    if (parsed >= 0) return parsed;
    if (argc - first != 2) return cli_fail(&tool, "need two PNG files");
    a_path = argv[first];
    b_path = argv[first + 1];
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

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

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int usage(void)
{
    fprintf(stderr, "usage: pngdiff A.png B.png [--threshold T] [--max-fraction F] "
                    "[--diff OUT.png]\n");
    return 2;
}

int main(int argc, char **argv)
{
    const char *a_path = NULL, *b_path = NULL, *diff_path = NULL;
    int threshold = 16;
    double max_fraction = 0.002;
    for (int i = 1; i < argc; ++i) {
        if (!strcmp(argv[i], "--threshold") && i + 1 < argc) {
            char *end;
            long t = strtol(argv[++i], &end, 10);
            if (*end || t < 0 || t > 255) return usage();
            threshold = (int)t;
        } else if (!strcmp(argv[i], "--max-fraction") && i + 1 < argc) {
            char *end;
            max_fraction = strtod(argv[++i], &end);
            if (*end || !(max_fraction >= 0.0 && max_fraction <= 1.0)) return usage();
        } else if (!strcmp(argv[i], "--diff") && i + 1 < argc) {
            diff_path = argv[++i];
        } else if (argv[i][0] == '-') {
            return usage();
        } else if (!a_path) {
            a_path = argv[i];
        } else if (!b_path) {
            b_path = argv[i];
        } else {
            return usage();
        }
    }
    if (!a_path || !b_path) return usage();
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

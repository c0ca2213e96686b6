/* SPDX-License-Identifier: MIT */
/* RGB8 images: PNG files (libpng), the comparison metric of the visual tests, contact sheets. */
#ifndef DEFSIM_TOOLS_IMAGE_H
#define DEFSIM_TOOLS_IMAGE_H

#include <stddef.h>
#include <stdint.h>

typedef struct image {
    int width, height;
    uint8_t *rgb;   /* width * height * 3, top row first */
} image;

/* Writes an 8-bit RGB PNG (atomically: temporary file, then rename). 0 or -1 with err. */
int image_write_png(const char *path, const image *im, char *err, size_t errsz);

/* Reads any PNG as 8-bit RGB (palette and grey expanded, alpha and 16-bit stripped). */
int image_read_png(const char *path, image *out, char *err, size_t errsz);

void image_free(image *im);

/* Comparison: a pixel differs when any channel differs by more than `threshold` (0..255). */
typedef struct image_diff {
    int64_t pixels, differing;
    int max_channel_diff;
    double fraction;          /* differing / pixels */
} image_diff;

/* Compares two images of the same size; `diff_out` (may be NULL) receives a visualisation
 * (differing pixels red over a faded copy of a). Returns -1 if the sizes differ. */
int image_compare(const image *a, const image *b, int threshold, image_diff *out, image *diff_out);

/* Scales an image down by an integer factor (box filter). */
int image_downscale(const image *in, int factor, image *out);

/* Draws text in a 3x5 pixel font scaled by `scale`, top-left corner (x0, y0), in grey level
 * `grey`; clipped to the image. Each character advances 4 * scale pixels. */
void image_draw_text(image *im, int x0, int y0, int scale, uint8_t grey, const char *text);

/* Lays tiles out in a grid with `cols` columns and a label under each ("%.2f s"). */
int image_contact_sheet(const image *tiles, const double *times, int n, int cols, image *out);

/* image_contact_sheet written to the PNG `path`. 0 or -1 with err. */
int image_write_contact_sheet(const char *path, const image *tiles, const double *times, int n,
                              int cols, char *err, size_t errsz);

#endif

/* SPDX-License-Identifier: MIT */
#include "image.h"

#include "fileio.h"

#include <png.h>

#include <errno.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void image_free(image *im)
{
    if (!im) return;
    free(im->rgb);
    im->rgb = NULL;
    im->width = im->height = 0;
}

int image_write_png(const char *path, const image *im, char *err, size_t errsz)
{
    char tmp[2200];
    FILE *f = tools_tmp_open(path, tmp, sizeof tmp, err, errsz);
    if (!f) return -1;
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    png_bytep *rows = malloc((size_t)im->height * sizeof *rows);
    if (!png || !info || !rows || setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        free(rows);
        fclose(f);
        remove(tmp);
        snprintf(err, errsz, "%s: PNG encoding failed", path);
        return -1;
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, (png_uint_32)im->width, (png_uint_32)im->height, 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    for (int y = 0; y < im->height; ++y) rows[y] = im->rgb + (size_t)y * im->width * 3;
    png_set_rows(png, info, rows);
    png_write_png(png, info, PNG_TRANSFORM_IDENTITY, NULL);
    png_destroy_write_struct(&png, &info);
    free(rows);
    return tools_tmp_commit(f, tmp, path, 1, err, errsz);
}

int image_read_png(const char *path, image *out, char *err, size_t errsz)
{
    memset(out, 0, sizeof *out);
    FILE *f = fopen(path, "rb");
    if (!f) {
        snprintf(err, errsz, "%s: cannot read: %s", path, strerror(errno));
        return -1;
    }
    uint8_t sig[8];
    if (fread(sig, 1, 8, f) != 8 || png_sig_cmp(sig, 0, 8)) {
        fclose(f);
        snprintf(err, errsz, "%s: not a PNG file", path);
        return -1;
    }
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    uint8_t *volatile rgb = NULL;
    png_bytep *volatile rows = NULL;
    if (!png || !info || setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, NULL);
        free(rgb);
        free(rows);
        fclose(f);
        snprintf(err, errsz, "%s: corrupt PNG", path);
        return -1;
    }
    png_init_io(png, f);
    png_set_sig_bytes(png, 8);
    png_read_info(png, info);
    const png_uint_32 w = png_get_image_width(png, info), h = png_get_image_height(png, info);
    const int ct = png_get_color_type(png, info), bd = png_get_bit_depth(png, info);
    if (bd == 16) png_set_strip_16(png);
    if (ct == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if (ct == PNG_COLOR_TYPE_GRAY && bd < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (ct == PNG_COLOR_TYPE_GRAY || ct == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_gray_to_rgb(png);
    if (ct & PNG_COLOR_MASK_ALPHA) png_set_strip_alpha(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_strip_alpha(png);
    png_read_update_info(png, info);
    if (w == 0 || h == 0 || w > 32768 || h > 32768 || png_get_rowbytes(png, info) != (size_t)w * 3) {
        png_destroy_read_struct(&png, &info, NULL);
        fclose(f);
        snprintf(err, errsz, "%s: unsupported PNG layout", path);
        return -1;
    }
    rgb = malloc((size_t)w * h * 3);
    rows = malloc((size_t)h * sizeof *rows);
    if (!rgb || !rows) png_error(png, "out of memory");
    for (png_uint_32 y = 0; y < h; ++y) rows[y] = rgb + (size_t)y * w * 3;
    png_read_image(png, rows);
    png_read_end(png, NULL);
    png_destroy_read_struct(&png, &info, NULL);
    free(rows);
    fclose(f);
    out->width = (int)w;
    out->height = (int)h;
    out->rgb = rgb;
    return 0;
}

int image_compare(const image *a, const image *b, int threshold, image_diff *out, image *diff_out)
{
    memset(out, 0, sizeof *out);
    if (a->width != b->width || a->height != b->height) return -1;
    const int64_t n = (int64_t)a->width * a->height;
    if (diff_out) {
        diff_out->width = a->width;
        diff_out->height = a->height;
        diff_out->rgb = malloc((size_t)n * 3);
    }
    for (int64_t i = 0; i < n; ++i) {
        int m = 0;
        for (int c = 0; c < 3; ++c) {
            int d = abs((int)a->rgb[3 * i + c] - (int)b->rgb[3 * i + c]);
            if (d > m) m = d;
        }
        if (m > out->max_channel_diff) out->max_channel_diff = m;
        if (m > threshold) out->differing++;
        if (diff_out && diff_out->rgb) {
            uint8_t *o = diff_out->rgb + 3 * i;
            if (m > threshold) { o[0] = 255; o[1] = 0; o[2] = 0; }
            else for (int c = 0; c < 3; ++c) o[c] = (uint8_t)(192 + a->rgb[3 * i + c] / 4);
        }
    }
    out->pixels = n;
    out->fraction = n ? (double)out->differing / (double)n : 0.0;
    return 0;
}

int image_downscale(const image *in, int k, image *out)
{
    out->width = in->width / k;
    out->height = in->height / k;
    out->rgb = malloc((size_t)out->width * out->height * 3 + 1);
    if (!out->rgb) return -1;
    for (int y = 0; y < out->height; ++y)
        for (int x = 0; x < out->width; ++x)
            for (int c = 0; c < 3; ++c) {
                unsigned acc = 0;
                for (int sy = 0; sy < k; ++sy)
                    for (int sx = 0; sx < k; ++sx)
                        acc += in->rgb[3 * ((size_t)(y * k + sy) * in->width + (size_t)(x * k + sx)) + c];
                out->rgb[3 * ((size_t)y * out->width + x) + c] = (uint8_t)((acc + (unsigned)(k * k) / 2) / (unsigned)(k * k));
            }
    return 0;
}

/* A 3x5 pixel font for labels: digits, capitals, and '.', ' ', '-', '+', '(', ')', ',', 'e'
 * (exponents), 's', 'a', 'm' and '/' (units), 't' and '=' (the time stamp), ':', '%', '<', '>',
 * '!', '[', ']', '_', '|' (the viewer's text). Unknown characters are blank. */
static const char *glyph(char ch)
{
    switch (ch) {
    case '0': return "111101101101111";
    case '1': return "010110010010111";
    case '2': return "111001111100111";
    case '3': return "111001111001111";
    case '4': return "101101111001001";
    case '5': return "111100111001111";
    case '6': return "111100111101111";
    case '7': return "111001010010010";
    case '8': return "111101111101111";
    case '9': return "111101111001111";
    case '.': return "000000000000010";
    case ',': return "000000000010100";
    case 's': return "000011110001110";
    case '-': return "000000111000000";
    case '+': return "000010111010000";
    case '(': return "001010010010001";
    case ')': return "100010010010100";
    case 'e': return "000111111100111";
    case 'a': return "000110011101111";
    case 'm': return "000110111101101";
    case 't': return "010111010010011";
    case '=': return "000111000111000";
    case '/': return "001001010100100";
    case 'A': return "010101111101101";
    case 'C': return "111100100100111";
    case 'D': return "110101101101110";
    case 'E': return "111100111100111";
    case 'I': return "111010010010111";
    case 'L': return "100100100100111";
    case 'M': return "101111111101101";
    case 'N': return "110101101101101";
    case 'O': return "111101101101111";
    case 'P': return "111101111100100";
    case 'S': return "111100111001111";
    case 'T': return "111010010010010";
    case 'V': return "101101101101010";
    case 'B': return "110101110101110";
    case 'F': return "111100110100100";
    case 'G': return "111100101101111";
    case 'H': return "101101111101101";
    case 'J': return "001001001101111";
    case 'K': return "101101110101101";
    case 'Q': return "111101101111001";
    case 'R': return "110101110101101";
    case 'U': return "101101101101111";
    case 'W': return "101101111111101";
    case 'X': return "101101010101101";
    case 'Y': return "101101010010010";
    case 'Z': return "111001010100111";
    case ':': return "000010000010000";
    case '%': return "101001010100101";
    case '<': return "001010100010001";
    case '>': return "100010001010100";
    case '!': return "010010010000010";
    case '[': return "110100100100110";
    case ']': return "011001001001011";
    case '_': return "000000000000111";
    case '|': return "010010010010010";
    default: return "000000000000000";
    }
}

void image_draw_text(image *im, int x0, int y0, int scale, uint8_t grey, const char *text)
{
    for (int i = 0; text[i]; ++i) {
        const char *g = glyph(text[i]);
        for (int gy = 0; gy < 5; ++gy)
            for (int gx = 0; gx < 3; ++gx)
                if (g[3 * gy + gx] == '1')
                    for (int sy = 0; sy < scale; ++sy)
                        for (int sx = 0; sx < scale; ++sx) {
                            const int x = x0 + (4 * i + gx) * scale + sx, y = y0 + gy * scale + sy;
                            if (x >= 0 && y >= 0 && x < im->width && y < im->height)
                                memset(im->rgb + 3 * ((size_t)y * im->width + x), grey, 3);
                        }
    }
}

int image_contact_sheet(const image *tiles, const double *times, int n, int cols, image *out)
{
    memset(out, 0, sizeof *out);
    if (n < 1 || cols < 1) return -1;
    const int tw = tiles[0].width, th = tiles[0].height, pad = 6, label = 16;
    const int rows = (n + cols - 1) / cols, c = n < cols ? n : cols;
    out->width = c * tw + (c + 1) * pad;
    out->height = rows * (th + label) + (rows + 1) * pad;
    out->rgb = malloc((size_t)out->width * out->height * 3);
    if (!out->rgb) return -1;
    memset(out->rgb, 255, (size_t)out->width * out->height * 3);
    for (int i = 0; i < n; ++i) {
        const int x0 = pad + (i % cols) * (tw + pad), y0 = pad + (i / cols) * (th + label + pad);
        for (int y = 0; y < th && y < tiles[i].height; ++y)
            memcpy(out->rgb + 3 * ((size_t)(y0 + y) * out->width + x0),
                   tiles[i].rgb + 3 * (size_t)y * tiles[i].width, 3 * (size_t)tw);
        char text[32];
        snprintf(text, sizeof text, "%.2f s", times[i]);
        image_draw_text(out, x0 + 2, y0 + th + 3, 2, 40, text);
    }
    return 0;
}

int image_write_contact_sheet(const char *path, const image *tiles, const double *times, int n,
                              int cols, char *err, size_t errsz)
{
    image sheet = {0, 0, NULL};
    int rc = image_contact_sheet(tiles, times, n, cols, &sheet);
    if (rc) snprintf(err, errsz, "out of memory");
    else rc = image_write_png(path, &sheet, err, errsz);
    image_free(&sheet);
    return rc;
}

/* SPDX-License-Identifier: MIT */
/*
 * set_module_dir FILE DIR: writes DIR over the module-directory record that src/registry.c
 * compiles into libdefsim ("defsim-module-dir[N]:" then the directory, in an N-byte array), in
 * every place FILE holds it (an archive or a shared library: the bytes of the object's data, so
 * the file stays valid). Run by the install step on the installed libraries, so that a program
 * linked with the installed static library finds the modules of the prefix it was installed
 * to. Exit status: 0 done (at least one record), 1 an error.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char mark[] = "defsim-module-dir[";

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: set_module_dir FILE DIR\n");
        return 1;
    }
    FILE *f = fopen(argv[1], "rb");
    if (!f) {
        perror(argv[1]);
        return 1;
    }
    fseek(f, 0, SEEK_END);
    const long n = ftell(f);
    rewind(f);
    char *b = n > 0 ? malloc((size_t)n) : NULL;
    if (!b || fread(b, 1, (size_t)n, f) != (size_t)n) {
        fprintf(stderr, "set_module_dir: cannot read %s\n", argv[1]);
        return 1;
    }
    fclose(f);
    const size_t dlen = strlen(argv[2]), mlen = sizeof mark - 1;
    int records = 0;
    for (long i = 0; i + (long)mlen < n; ++i) {
        if (memcmp(b + i, mark, mlen)) continue;
        /* "defsim-module-dir[4096]:": the array's size, then the directory. */
        char *end = NULL;
        const long size = strtol(b + i + mlen, &end, 10);
        if (end == b + i + mlen || end + 2 > b + n || end[0] != ']' || end[1] != ':') continue;
        const long head = (long)(end + 2 - (b + i));
        if (size <= head || i + size > n || (long)dlen >= size - head) {
            fprintf(stderr, "set_module_dir: %s: a record of %ld bytes cannot hold %s\n",
                    argv[1], size, argv[2]);
            return 1;
        }
        memset(b + i + head, 0, (size_t)(size - head));
        memcpy(b + i + head, argv[2], dlen);
        ++records;
        i += size - 1;
    }
    if (!records) {
        fprintf(stderr, "set_module_dir: %s holds no module-directory record\n", argv[1]);
        return 1;
    }
    f = fopen(argv[1], "r+b");
    if (!f || fwrite(b, 1, (size_t)n, f) != (size_t)n || fclose(f) != 0) {
        fprintf(stderr, "set_module_dir: cannot write %s\n", argv[1]);
        return 1;
    }
    free(b);
    printf("-- Module directory %s in %s (%d record%s)\n", argv[2], argv[1], records,
           records == 1 ? "" : "s");
    return 0;
}

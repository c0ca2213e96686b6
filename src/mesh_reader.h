/* SPDX-License-Identifier: MIT */
/*
 * The tokenizer of the mesh loaders: a whole file in memory, walked token by token with a line
 * count, so that every error can name "file:line". The first error is kept in the reader (and
 * in defsim_last_error); every read after it fails at once, so a loader may chain reads and
 * check the status once.
 */
#ifndef DEFSIM_MESH_READER_H
#define DEFSIM_MESH_READER_H

#include "defsim/defsim.h"
#include "status.h"

#include <stddef.h>
#include <string.h>

/* A growable array of `elem`-byte items. */
typedef struct defsim__vec { void *p; size_t n, cap, elem; } defsim__vec;

/* Appends `count` items; returns 0 when out of memory (the array is unchanged). */
int defsim__vec_push(defsim__vec *v, const void *item, size_t count);

typedef struct defsim__reader {
    const char *path;
    char *buf;
    size_t len, pos;
    int line;           /* line of the current position, from 1 */
    int hash_comments;  /* '#' starts a comment to the end of the line */
    defsim_status st;   /* first error */
} defsim__reader;

/* A continued newline (OBJ, see mesh_obj.c): counts as a line, not as the end of a statement. */
#define DEFSIM__RD_CONT '\x01'

/* Reads the file at `path` (a regular file of at most DEFSIM_LIMIT_FILE_BYTES bytes) into r. */
defsim_status defsim__rd_open(defsim__reader *r, const char *path, int hash_comments);
void defsim__rd_close(defsim__reader *r);

/* Records the first error as "path:line: message" (line <= 0: "path: message"); returns st. */
defsim_status defsim__rd_fail(defsim__reader *r, defsim_status st, int line, const char *fmt,
                                  ...) DEFSIM_PRINTF(4, 5);

static inline int defsim__rd_is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v';
}

static inline int defsim__tok_is(const char *tok, size_t n, const char *s)
{
    return n == strlen(s) && memcmp(tok, s, n) == 0;
}

/* Skips blanks, newlines and comments. */
void defsim__rd_skip_ws(defsim__reader *r);
/* Moves to the end of the current line (its newline stays unread). */
void defsim__rd_to_eol(defsim__reader *r);
/* Skips the rest of the current line, including its newline. */
void defsim__rd_skip_line(defsim__reader *r);
/* Next whitespace-delimited token; returns its length (0 at the end of the file). */
size_t defsim__rd_token(defsim__reader *r, const char **tok);
/* "'token'" (at most 40 characters) or "end of file", for messages. */
void defsim__rd_show(char *out, size_t size, const char *tok, size_t n);

/* tok[0..n) as a whole decimal integer / a finite number (at most 79 characters): 1 on
 * success, else 0 with *out unchanged. */
int defsim__parse_i64(const char *tok, size_t n, long long *out);
int defsim__parse_f64(const char *tok, size_t n, double *out);

/* The next token as an integer / a finite number / an integer in [lo, hi]: 1 on success, else
 * 0 with an error naming `what` recorded (and 0 at once after an earlier error). */
int defsim__rd_i64(defsim__reader *r, const char *what, long long *out);
int defsim__rd_f64(defsim__reader *r, const char *what, double *out);
int defsim__rd_count(defsim__reader *r, const char *what, long long lo, long long hi,
                       long long *out);
/* The next token as a coordinate: a finite number within +-DEFSIM__COORD_MAX (mesh.h); else 0
 * with an error naming `what` (a malformed number is DEFSIM_ERR_IO, one out of range
 * DEFSIM_ERR_INVALID_MESH). */
int defsim__rd_coord(defsim__reader *r, const char *what, double *out);
/* 1 if |x| <= DEFSIM__COORD_MAX; else 0 with the error "WHAT = x is beyond ..." at `line`. */
int defsim__coord_check(defsim__reader *r, int line, const char *what, double x);

#endif

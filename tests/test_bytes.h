/* A growing byte buffer for the tests that build files by hand (readers,
   inflate): append raw bytes, a byte, or printf-formatted text. */
#ifndef SQFFD_TEST_BYTES_H
#define SQFFD_TEST_BYTES_H

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct bytes {
    unsigned char *data;
    size_t size, capacity;
} bytes;

static inline void bytes_put(bytes *b, const void *p, size_t n)
{
    if (b->size + n > b->capacity) {
        b->capacity = 2 * (b->size + n) + 256;
        b->data = (unsigned char *)realloc(b->data, b->capacity);
        if (!b->data) {
            fprintf(stderr, "out of memory\n");
            exit(2);
        }
    }
    if (n) memcpy(b->data + b->size, p, n);
    b->size += n;
}

static inline void bytes_byte(bytes *b, unsigned value)
{
    unsigned char c = (unsigned char)value;
    bytes_put(b, &c, 1);
}

#if defined(__GNUC__)
static inline void bytes_text(bytes *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
#endif
static inline void bytes_text(bytes *b, const char *fmt, ...)
{
    char line[1024];
    va_list ap;
    int n;
    va_start(ap, fmt);
    n = vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    bytes_put(b, line, (size_t)(n < (int)sizeof line ? n : (int)sizeof line - 1));
}

static inline void bytes_free(bytes *b)
{
    free(b->data);
    b->data = NULL;
    b->size = b->capacity = 0;
}

#endif

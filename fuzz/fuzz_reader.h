/* The fuzz targets' byte reader: values taken in order from libFuzzer's
   input; past its end every read gives 0 (the position still advances, so
   a harness can tell it ran out). */
#ifndef SQFFD_FUZZ_READER_H
#define SQFFD_FUZZ_READER_H

#include <stdint.h>
#include <string.h>

typedef struct reader {
    const uint8_t *data;
    size_t size, at;
} reader;

static inline unsigned rd_u8(reader *r) { return r->at < r->size ? r->data[r->at++] : (r->at++, 0u); }
static inline int rd_i8(reader *r) { return (int)(int8_t)rd_u8(r); }
static inline int rd_exhausted(const reader *r) { return r->at >= r->size; }

static inline int rd_i16(reader *r)
{
    int v = (int)(rd_u8(r) | rd_u8(r) << 8);
    return v >= 32768 ? v - 65536 : v;
}

/* Any double, NaN and infinities included: 8 bytes, least significant first. */
static inline double rd_f64(reader *r)
{
    uint64_t bits = 0;
    double x;
    int b;
    for (b = 0; b < 8; b++) bits |= (uint64_t)rd_u8(r) << (8 * b);
    memcpy(&x, &bits, 8);
    return x;
}

#endif

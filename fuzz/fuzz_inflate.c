/* libFuzzer target: the bytes go to the gzip, zlib and raw DEFLATE decoders
   of examples/sqffd_inflate.h with a bounded output. Checks the contract
   beyond "no crash":
   - success: an output buffer of at most max_output bytes; for gzip, the
     file re-walked member by member with the raw decoder gives the same
     bytes, each member's CRC-32 and ISIZE match its trailer and only zero
     bytes follow the last member; for zlib, the same bytes from the raw
     decoder and the Adler-32 in the last four bytes;
   - failure: no output and a message "NAME: gzip: ..." / "NAME: zlib: ..." */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "../examples/sqffd_inflate.h"

enum { MAX_OUTPUT = 1 << 20 };

static void check_failure(int r, const unsigned char *out, size_t out_size, const char *err, const char *prefix)
{
    if (r != -1 || out || out_size) abort();
    if (strncmp(err, prefix, strlen(prefix)) != 0) abort();
}

/* Past the zero byte that ends a header string at `at`. */
static size_t skip_string(const uint8_t *data, size_t size, size_t at)
{
    const uint8_t *zero = at < size ? (const uint8_t *)memchr(data + at, 0, size - at) : NULL;
    if (!zero) abort(); /* the decoder accepted the header, so the zero is there */
    return (size_t)(zero - data) + 1;
}

/* The end of the gzip header at `at` (the file decoded, so it is valid). */
static size_t header_end(const uint8_t *data, size_t size, size_t at)
{
    unsigned flags;
    if (size - at < 10) abort();
    flags = data[at + 3];
    at += 10;
    if (flags & 4) {
        if (size - at < 2) abort();
        at += 2 + (size_t)(data[at] | data[at + 1] << 8);
    }
    if (flags & 8) at = skip_string(data, size, at);
    if (flags & 16) at = skip_string(data, size, at);
    if (flags & 2) at += 2;
    if (at > size) abort();
    return at;
}

static void check_gzip(const uint8_t *data, size_t size)
{
    unsigned char *out = NULL;
    size_t out_size = 0, at = 0, done = 0;
    char err[256];
    int r = sqffd_gz_decompress(data, size, "fuzz.gz", MAX_OUTPUT, &out, &out_size, err, sizeof err);
    if (r != 0) {
        check_failure(r, out, out_size, err, "fuzz.gz: gzip: ");
        return;
    }
    if (!out || out_size > MAX_OUTPUT) abort();
    for (;;) {
        unsigned char *member = NULL;
        size_t member_size = 0, used = 0;
        const char *why;
        at = header_end(data, size, at);
        if (sqffd_inflate_raw(data + at, size - at, &used, &member, &member_size, MAX_OUTPUT, &why) != 0) abort();
        if (member_size > out_size - done || memcmp(member, out + done, member_size) != 0) abort();
        at += used;
        if (size - at < 8) abort();
        if (sqffd_gz__load32_le(data + at) != sqffd_gz_crc32(0, member, member_size)) abort();
        if (sqffd_gz__load32_le(data + at + 4) != (uint32_t)member_size) abort();
        free(member);
        done += member_size;
        at += 8;
        if (!sqffd_gz_is_gzip(data + at, size - at)) break;
    }
    for (; at < size; at++)
        if (data[at] != 0) abort();
    if (done != out_size) abort();
    free(out);
}

static void check_zlib(const uint8_t *data, size_t size)
{
    unsigned char *out = NULL, *raw = NULL;
    size_t out_size = 0, raw_size = 0, used = 0;
    const char *why;
    char err[256];
    int r = sqffd_gz_zlib_decompress(data, size, "fuzz.zlib", MAX_OUTPUT, &out, &out_size, err, sizeof err);
    if (r != 0) {
        check_failure(r, out, out_size, err, "fuzz.zlib: zlib: ");
        return;
    }
    if (!out || out_size > MAX_OUTPUT || size < 6) abort();
    if (sqffd_inflate_raw(data + 2, size - 2, &used, &raw, &raw_size, MAX_OUTPUT, &why) != 0) abort();
    if (raw_size != out_size || memcmp(raw, out, out_size) != 0 || used != size - 6) abort();
    if (sqffd_gz_adler32(1, out, out_size) !=
        ((uint32_t)data[size - 4] << 24 | (uint32_t)data[size - 3] << 16 | (uint32_t)data[size - 2] << 8 | data[size - 1]))
        abort();
    free(out);
    free(raw);
}

static void check_raw(const uint8_t *data, size_t size)
{
    unsigned char *out = NULL;
    size_t out_size = 0, used = 0;
    const char *why = NULL;
    if (sqffd_inflate_raw(data, size, &used, &out, &out_size, MAX_OUTPUT, &why) == 0) {
        if (!out || out_size > MAX_OUTPUT || used > size || used == 0 || why) abort();
        free(out);
    } else {
        if (out || out_size || !why || used > size) abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    check_gzip(data, size);
    check_zlib(data, size);
    check_raw(data, size);
    return 0;
}

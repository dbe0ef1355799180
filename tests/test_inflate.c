/* suite_inflate: examples/sqffd_inflate.h (raw DEFLATE, zlib, gzip) and
   gzip-compressed point files read through examples/sqffd_io.h.

   Compressed inputs are either files made by zlib and GNU gzip (tests/data,
   see its README) or streams built here bit by bit by a small encoder of
   their own (fixed Huffman blocks, dynamic block headers, stored blocks).
   Expected outputs are generated here independently of the decoder, and
   checksums are compared with the values zlib computed when the files were
   made. */
#include "test.h"
#include "test_bytes.h"
#include <stdarg.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "../examples/sqffd_io.h" /* includes sqffd_inflate.h */

/* ---- byte buffers, files and the payloads the data files hold -------------- */

static void bytes_le32(bytes *b, uint32_t v)
{
    bytes_byte(b, v & 0xff);
    bytes_byte(b, (v >> 8) & 0xff);
    bytes_byte(b, (v >> 16) & 0xff);
    bytes_byte(b, v >> 24);
}


/* A file of tests/data (NULL, with a failed check, when it cannot be read). */
static unsigned char *load(const char *name, size_t *size)
{
    char path[256], err[512];
    unsigned char *data;
    snprintf(path, sizeof path, "tests/data/%s", name);
    if (sqffd_io_load_file(path, &data, size, err, sizeof err)) {
        test_fail(__FILE__, __LINE__, "%s", err);
        return NULL;
    }
    return data;
}

/* The 18,537-byte text in inflate_text_l*.gz (CRC-32 0xd41408c9). */
static bytes make_text(void)
{
    bytes b = {NULL, 0, 0};
    int i;
    for (i = 0; i < 900; i++) bytes_text(&b, "%d %d %d vertex\n", i, i * i % 1009, (i * 7919) % 65536);
    return b;
}

/* The 40,000 bytes in inflate_binary_*: 20,000 little-endian int16 samples of
   a parabolic wave plus 2 bits of LCG noise (CRC-32 0x6c7521fb). */
static bytes make_binary(void)
{
    bytes b = {NULL, 0, 0};
    uint32_t x = 12345;
    int i;
    for (i = 0; i < 20000; i++) {
        int v;
        x = x * 1103515245u + 12345u;
        v = (i % 400) * (400 - i % 400) / 40 + (int)((x >> 16) & 3) - 500;
        bytes_byte(&b, (unsigned)v & 0xff);
        bytes_byte(&b, ((unsigned)v >> 8) & 0xff);
    }
    return b;
}

/* The XYZ text in inflate_points.xyz.gz (500 points, CRC-32 0x770596e7). */
static bytes make_points_xyz(void)
{
    bytes b = {NULL, 0, 0};
    int i;
    for (i = 0; i < 500; i++) bytes_text(&b, "%d %d %d\n", i, i * i % 97, -3 * i);
    return b;
}

/* ---- an encoder of our own: bits, fixed Huffman, dynamic headers ---------- */

typedef struct bitwriter {
    bytes *out;
    unsigned acc, count;
} bitwriter;

/* count bits of value, least significant first (how DEFLATE packs numbers). */
static void put_bits(bitwriter *w, uint32_t value, unsigned count)
{
    unsigned i;
    for (i = 0; i < count; i++) {
        w->acc |= ((value >> i) & 1u) << w->count;
        if (++w->count == 8) {
            bytes_byte(w->out, w->acc);
            w->acc = 0;
            w->count = 0;
        }
    }
}

/* A Huffman code of len bits, most significant bit first (RFC 1951 3.1.1). */
static void put_code(bitwriter *w, uint32_t code, unsigned len)
{
    while (len--) put_bits(w, (code >> len) & 1u, 1);
}

static void flush_bits(bitwriter *w)
{
    if (w->count) put_bits(w, 0, 8 - w->count);
}

static const unsigned length_base[29] = {3,  4,  5,  6,  7,  8,  9,  10, 11,  13,  15,  17,  19,  23, 27,
                                         31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163, 195, 227, 258};
static const unsigned length_extra[29] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2,
                                          2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
static const unsigned dist_base[30] = {1,    2,    3,    4,    5,    7,    9,    13,    17,    25,
                                       33,   49,   65,   97,   129,  193,  257,  385,   513,   769,
                                       1025, 1537, 2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577};
static const unsigned dist_extra[30] = {0, 0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6,
                                        6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13, 13};

/* A literal/length symbol of the fixed code (RFC 1951 3.2.6). */
static void fixed_symbol(bitwriter *w, unsigned symbol)
{
    if (symbol < 144) put_code(w, 0x30 + symbol, 8);
    else if (symbol < 256) put_code(w, 0x190 + symbol - 144, 9);
    else if (symbol < 280) put_code(w, symbol - 256, 7);
    else put_code(w, 0xc0 + symbol - 280, 8);
}

/* The length symbol and extra bits of a match length (3..258). */
static void length_symbol(unsigned length, unsigned *symbol, unsigned *extra)
{
    unsigned s = 28;
    while (length_base[s] > length) s--;
    *symbol = 257 + s;
    *extra = length - length_base[s];
}

static void dist_symbol(unsigned dist, unsigned *symbol, unsigned *extra)
{
    unsigned s = 29;
    while (dist_base[s] > dist) s--;
    *symbol = s;
    *extra = dist - dist_base[s];
}

/* A match in a fixed block (distance codes are 5-bit codes there). */
static void fixed_match(bitwriter *w, unsigned length, unsigned dist)
{
    unsigned symbol, extra;
    length_symbol(length, &symbol, &extra);
    fixed_symbol(w, symbol);
    put_bits(w, extra, length_extra[symbol - 257]);
    dist_symbol(dist, &symbol, &extra);
    put_code(w, symbol, 5);
    put_bits(w, extra, dist_extra[symbol]);
}

static void fixed_header(bitwriter *w, int final)
{
    put_bits(w, final ? 1u : 0u, 1);
    put_bits(w, 1, 2);
}

/* The canonical codes of code lengths (RFC 1951 3.2.2), written out here
   independently of the decoder. */
static void canonical_codes(const unsigned char *lengths, unsigned count, uint32_t *codes)
{
    unsigned bl_count[16] = {0}, next[16], bits, n;
    uint32_t code = 0;
    for (n = 0; n < count; n++) bl_count[lengths[n]]++;
    bl_count[0] = 0;
    for (bits = 1; bits <= 15; bits++) {
        code = (code + bl_count[bits - 1]) << 1;
        next[bits] = code;
    }
    for (n = 0; n < count; n++)
        if (lengths[n]) codes[n] = next[lengths[n]]++;
}

/* The code-length code every hand-built dynamic block here uses: symbols
   0..12 get 4 bits, 13..18 get 5 (a complete code). */
static const unsigned char codelen_order[19] = {16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15};

static void codelen_symbol(bitwriter *w, unsigned symbol, unsigned extra)
{
    unsigned char lengths[19];
    uint32_t codes[19];
    unsigned i;
    for (i = 0; i < 19; i++) lengths[i] = (unsigned char)(i < 13 ? 4 : 5);
    canonical_codes(lengths, 19, codes);
    put_code(w, codes[symbol], lengths[symbol]);
    if (symbol == 16) put_bits(w, extra, 2);
    if (symbol == 17) put_bits(w, extra, 3);
    if (symbol == 18) put_bits(w, extra, 7);
}

/* A dynamic block header up to the code-length code's lengths: HLIT, HDIST
   as counts, all 19 code-length code lengths (in the RFC's order). */
static void dynamic_start(bitwriter *w, int final, unsigned hlit, unsigned hdist, const unsigned char cl_lengths[19])
{
    unsigned i;
    put_bits(w, final ? 1u : 0u, 1);
    put_bits(w, 2, 2);
    put_bits(w, hlit - 257, 5);
    put_bits(w, hdist - 1, 5);
    put_bits(w, 19 - 4, 4);
    for (i = 0; i < 19; i++) put_bits(w, cl_lengths[codelen_order[i]], 3);
}

/* A whole dynamic block header: literal/length and distance code lengths,
   zero runs as symbols 17/18. */
static void dynamic_header(bitwriter *w, int final, const unsigned char *litlen, unsigned hlit,
                           const unsigned char *dist, unsigned hdist)
{
    unsigned char cl_lengths[19], all[286 + 32];
    unsigned i, n = hlit + hdist;
    for (i = 0; i < 19; i++) cl_lengths[i] = (unsigned char)(i < 13 ? 4 : 5);
    dynamic_start(w, final, hlit, hdist, cl_lengths);
    memcpy(all, litlen, hlit);
    memcpy(all + hlit, dist, hdist);
    for (i = 0; i < n;) {
        unsigned run = 0;
        while (i + run < n && all[i + run] == 0 && run < 138) run++;
        if (run >= 11) { codelen_symbol(w, 18, run - 11); i += run; }
        else if (run >= 3) { codelen_symbol(w, 17, run - 3); i += run; }
        else codelen_symbol(w, all[i++], 0);
    }
}

/* Stored blocks (at most 65,535 bytes each) holding data. */
static void stored_blocks(bytes *out, const unsigned char *data, size_t size)
{
    size_t at = 0;
    do {
        size_t n = size - at > 65535 ? 65535 : size - at;
        unsigned len = (unsigned)n;
        bytes_byte(out, at + n == size ? 1 : 0); /* BFINAL, BTYPE 00, padding */
        bytes_byte(out, len & 0xff);
        bytes_byte(out, len >> 8);
        bytes_byte(out, ~len & 0xff);
        bytes_byte(out, (~len >> 8) & 0xff);
        bytes_put(out, data + at, n);
        at += n;
    } while (at < size);
}

/* A gzip member around a raw DEFLATE stream; the trailer describes `payload`. */
static void gzip_member(bytes *out, const unsigned char *deflate, size_t deflate_size, const unsigned char *payload,
                        size_t payload_size)
{
    static const unsigned char header[10] = {0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 3};
    bytes_put(out, header, 10);
    bytes_put(out, deflate, deflate_size);
    bytes_le32(out, sqffd_gz_crc32(0, payload, payload_size));
    bytes_le32(out, (uint32_t)payload_size);
}

/* A gzip member of stored blocks. */
static void gzip_stored(bytes *out, const unsigned char *payload, size_t size)
{
    bytes deflate = {NULL, 0, 0};
    stored_blocks(&deflate, payload, size);
    gzip_member(out, deflate.data, deflate.size, payload, size);
    free(deflate.data);
}

/* ---- checks ---------------------------------------------------------------- */

/* Decompresses gzip (zlib: a zlib stream) and compares with want, or with
   message: expects failure, no output and a message starting "t.gz: gzip: "
   ("t.gz: zlib: ") that contains `message`. */
static void expect_wrapped(int zlib, const void *data, size_t size, size_t max_output, const unsigned char *want,
                           size_t want_size, const char *message, const char *file, int line)
{
    unsigned char *out = (unsigned char *)&out; /* must be reset */
    size_t out_size = 12345;
    char err[256] = "";
    const char *prefix = zlib ? "t.gz: zlib: " : "t.gz: gzip: ";
    int r = zlib ? sqffd_gz_zlib_decompress(data, size, "t.gz", max_output, &out, &out_size, err, sizeof err)
                 : sqffd_gz_decompress(data, size, "t.gz", max_output, &out, &out_size, err, sizeof err);
    if (!message) {
        if (r != 0) { test_fail(file, line, "failed: %s", err); return; }
        if (!out) test_fail(file, line, "no output buffer");
        else if (out_size != want_size || (want_size && memcmp(out, want, want_size) != 0))
            test_fail(file, line, "output differs: %llu bytes, expected %llu", (unsigned long long)out_size,
                      (unsigned long long)want_size);
        free(out);
        return;
    }
    if (r != -1 || out || out_size) {
        test_fail(file, line, "expected failure \"%s\", got r %d, %llu bytes", message, r, (unsigned long long)out_size);
        if (r == 0) free(out);
        return;
    }
    if (strncmp(err, prefix, strlen(prefix)) != 0 || !strstr(err, message))
        test_fail(file, line, "message \"%s\", expected one with \"%s\"", err, message);
}
#define EXPECT_GZIP(data, size, want, want_size) expect_wrapped(0, data, size, 0, want, want_size, NULL, __FILE__, __LINE__)
#define EXPECT_GZIP_ERROR(data, size, message) expect_wrapped(0, data, size, 0, NULL, 0, message, __FILE__, __LINE__)
#define EXPECT_ZLIB(data, size, want, want_size) expect_wrapped(1, data, size, 0, want, want_size, NULL, __FILE__, __LINE__)
#define EXPECT_ZLIB_ERROR(data, size, message) expect_wrapped(1, data, size, 0, NULL, 0, message, __FILE__, __LINE__)

/* Raw DEFLATE: expects output want, or failure with `why` containing message. */
static void expect_raw(const bytes *in, size_t max_output, const unsigned char *want, size_t want_size,
                       const char *message, const char *file, int line)
{
    unsigned char *out = NULL;
    size_t out_size = 0, used = 0;
    const char *why = "unset";
    int r = sqffd_inflate_raw(in->data, in->size, &used, &out, &out_size, max_output, &why);
    if (!message) {
        if (r != 0) { test_fail(file, line, "failed: %s", why); return; }
        if (why != NULL) test_fail(file, line, "why not NULL on success");
        if (used != in->size) test_fail(file, line, "used %llu of %llu bytes", (unsigned long long)used,
                                        (unsigned long long)in->size);
        if (out_size != want_size || (want_size && memcmp(out, want, want_size) != 0))
            test_fail(file, line, "output differs: %llu bytes, expected %llu", (unsigned long long)out_size,
                      (unsigned long long)want_size);
        free(out);
        return;
    }
    if (r != -1 || out || out_size) {
        test_fail(file, line, "expected failure \"%s\", got r %d", message, r);
        if (r == 0) free(out);
        return;
    }
    if (!why || !strstr(why, message)) test_fail(file, line, "why \"%s\", expected \"%s\"", why ? why : "(null)", message);
}
#define EXPECT_RAW(in, want, want_size) expect_raw(in, 0, want, want_size, NULL, __FILE__, __LINE__)
#define EXPECT_RAW_ERROR(in, message) expect_raw(in, 0, NULL, 0, message, __FILE__, __LINE__)

/* Where the DEFLATE data of a gzip file made by zlib or gzip starts (FNAME at
   most among the flags), and its first block's type. */
static size_t deflate_start(const unsigned char *gz, size_t size)
{
    size_t at = 10;
    if (gz[3] & 8) {
        while (at < size && gz[at]) at++;
        at++;
    }
    return at;
}

/* ---- the cases --------------------------------------------------------------- */

static void test_inflate_checksums(void)
{
    static const unsigned char check[] = "123456789";
    bytes bin = make_binary(), text = make_text();
    unsigned char ones[20000];
    uint32_t crc = 0, adler = 1, a = 1, b = 0;
    size_t i;
    /* the standard check values of the two checksums */
    CHECK(sqffd_gz_crc32(0, check, 9) == 0xcbf43926u);
    CHECK(sqffd_gz_crc32(0, NULL, 0) == 0);
    CHECK(sqffd_gz_adler32(1, "Wikipedia", 9) == 0x11e60398u);
    CHECK(sqffd_gz_adler32(1, NULL, 0) == 1);
    /* zlib's values for the payloads (8-byte steps), and byte by byte when chained */
    CHECK(sqffd_gz_crc32(0, bin.data, bin.size) == 0x6c7521fbu);
    CHECK(sqffd_gz_crc32(0, text.data, text.size) == 0xd41408c9u);
    CHECK(sqffd_gz_adler32(1, bin.data, bin.size) == 0x96463f2cu);
    for (i = 0; i < bin.size; i++) crc = sqffd_gz_crc32(crc, bin.data + i, 1);
    CHECK(crc == 0x6c7521fbu);
    for (i = 0; i < bin.size; i += 777) adler = sqffd_gz_adler32(adler, bin.data + i, bin.size - i < 777 ? bin.size - i : 777);
    CHECK(adler == 0x96463f2cu);
    CHECK(sqffd_gz_crc32(sqffd_gz_crc32(0, bin.data, 1500), bin.data + 1500, bin.size - 1500) == 0x6c7521fbu);
    /* Adler-32's sums deferred over 5552 bytes of 0xff: the definition, reduced every byte */
    memset(ones, 0xff, sizeof ones);
    for (i = 0; i < sizeof ones; i++) {
        a = (a + 0xff) % 65521u;
        b = (b + a) % 65521u;
    }
    CHECK(sqffd_gz_adler32(1, ones, sizeof ones) == (b << 16 | a));
    free(bin.data);
    free(text.data);
}

/* zlib level 0 (stored), gzip -1/-6/-9 and zlib -1/-9 (dynamic) files of
   the two payloads, byte for byte. */
static void test_inflate_levels(void)
{
    static const struct { const char *file; int payload, first_type; } cases[] = {
        {"inflate_text_l0.gz", 0, 0},   {"inflate_text_l1.gz", 0, 2},   {"inflate_text_l6.gz", 0, 2},
        {"inflate_text_l9.gz", 0, 2},   {"inflate_binary_l0.gz", 1, 0}, {"inflate_binary_l1.gz", 1, 2},
        {"inflate_binary_l9.gz", 1, 2},
    };
    bytes payload[2];
    size_t k;
    payload[0] = make_text();
    payload[1] = make_binary();
    for (k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        size_t size;
        unsigned char *gz = load(cases[k].file, &size);
        if (!gz) continue;
        CHECK(sqffd_gz_is_gzip(gz, size));
        /* the block type the case stands for (bits 1-2 of the first byte) */
        CHECK_MSG(((gz[deflate_start(gz, size)] >> 1) & 3) == cases[k].first_type, "%s", cases[k].file);
        EXPECT_GZIP(gz, size, payload[cases[k].payload].data, payload[cases[k].payload].size);
        free(gz);
    }
    free(payload[0].data);
    free(payload[1].data);
}

/* The real files: sizes and CRC-32 as gzip -l and zlib reported them, and
   the NIfTI header fields the sizes come from. */
static void test_inflate_nifti_files(void)
{
    static const struct { const char *file; size_t size; uint32_t crc; int dims[5]; } cases[] = {
        {"KmeansTest_T1UCharRaw.nii.gz", 352 + 128 * 128 * 62 * 2, 0x284e145eu, {3, 128, 128, 62, 0}},
        {"example4d.nii.gz", 416 + 128 * 96 * 24 * 2 * 2, 0x7aa14c7eu, {4, 128, 96, 24, 2}},
    };
    size_t k;
    for (k = 0; k < 2; k++) {
        size_t size, out_size;
        unsigned char *gz = load(cases[k].file, &size), *out;
        char err[256];
        int d;
        if (!gz) continue;
        if (sqffd_gz_decompress(gz, size, cases[k].file, 0, &out, &out_size, err, sizeof err)) {
            test_fail(__FILE__, __LINE__, "%s", err);
            free(gz);
            continue;
        }
        CHECK(out_size == cases[k].size);
        CHECK(sqffd_gz_crc32(0, out, out_size) == cases[k].crc);
        CHECK(sqffd_gz__load32_le(out) == 348); /* sizeof_hdr */
        for (d = 0; d < 5 && d <= cases[k].dims[0]; d++)
            CHECK_MSG((out[40 + 2 * d] | out[41 + 2 * d] << 8) == cases[k].dims[d], "%s dim[%d]", cases[k].file, d);
        free(out);
        free(gz);
    }
}

/* Empty and 1-byte payloads as zlib 1.2.13 compresses them (fixed blocks),
   and the smallest streams built by hand. */
static void test_inflate_small_payloads(void)
{
    static const unsigned char gz_empty[] = {0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 3, 3, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    static const unsigned char gz_a[] = {0x1f, 0x8b, 8, 0, 0, 0,    0,    0,    0, 3, 0x73,
                                         4,    0,    0x8b, 0x9e, 0xd9, 0xd3, 1, 0, 0, 0};
    static const unsigned char zlib_empty[] = {0x78, 0x9c, 3, 0, 0, 0, 0, 1};
    static const unsigned char zlib_a[] = {0x78, 0x9c, 0x73, 4, 0, 0, 0x42, 0, 0x42};
    static const unsigned char fixed_end[] = {3, 0}, stored_empty[] = {1, 0, 0, 0xff, 0xff};
    bytes in = {NULL, 0, 0}, gz = {NULL, 0, 0};
    EXPECT_GZIP(gz_empty, sizeof gz_empty, NULL, 0);
    EXPECT_GZIP(gz_a, sizeof gz_a, (const unsigned char *)"A", 1);
    EXPECT_ZLIB(zlib_empty, sizeof zlib_empty, NULL, 0);
    EXPECT_ZLIB(zlib_a, sizeof zlib_a, (const unsigned char *)"A", 1);
    bytes_put(&in, fixed_end, sizeof fixed_end);
    EXPECT_RAW(&in, NULL, 0);
    in.size = 0;
    bytes_put(&in, stored_empty, sizeof stored_empty);
    EXPECT_RAW(&in, NULL, 0);
    gzip_stored(&gz, (const unsigned char *)"", 0);
    EXPECT_GZIP(gz.data, gz.size, NULL, 0);
    gz.size = 0;
    gzip_stored(&gz, (const unsigned char *)"z", 1);
    EXPECT_GZIP(gz.data, gz.size, (const unsigned char *)"z", 1);
    free(in.data);
    free(gz.data);
}

/* Members concatenated are decoded in sequence, each checked on its own. */
static void test_inflate_multi_member(void)
{
    size_t text_size, bin_size;
    unsigned char *text_gz = load("inflate_text_l6.gz", &text_size), *bin_gz = load("inflate_binary_l9.gz", &bin_size);
    bytes text = make_text(), bin = make_binary(), both = {NULL, 0, 0}, want = {NULL, 0, 0}, three = {NULL, 0, 0};
    bytes raw = {NULL, 0, 0};
    bitwriter w;
    if (!text_gz || !bin_gz) { free(text_gz); free(bin_gz); return; }
    bytes_put(&both, text_gz, text_size);
    bytes_put(&both, bin_gz, bin_size);
    bytes_put(&want, text.data, text.size);
    bytes_put(&want, bin.data, bin.size);
    EXPECT_GZIP(both.data, both.size, want.data, want.size);
    bytes_put(&both, "\0\0\0\0\0\0\0", 7); /* zero padding after the last member is fine */
    EXPECT_GZIP(both.data, both.size, want.data, want.size);
    bytes_put(&both, "x", 1);
    EXPECT_GZIP_ERROR(both.data, both.size, "8 bytes of trailing garbage after member 2");

    /* three stored members, the middle one empty */
    gzip_stored(&three, (const unsigned char *)"abc", 3);
    gzip_stored(&three, (const unsigned char *)"", 0);
    gzip_stored(&three, (const unsigned char *)"defg", 4);
    EXPECT_GZIP(three.data, three.size, (const unsigned char *)"abcdefg", 7);
    three.data[three.size - 8] ^= 1; /* the third member's CRC */
    EXPECT_GZIP_ERROR(three.data, three.size, "member 3: CRC-32 mismatch");
    three.size = 0;
    gzip_stored(&three, (const unsigned char *)"abc", 3);
    bytes_put(&three, "\x1f\x8b\x08", 3);
    EXPECT_GZIP_ERROR(three.data, three.size, "member 2: input ends inside the header");

    /* a member's matches may not reach into the one before it */
    three.size = 0;
    gzip_stored(&three, (const unsigned char *)"abc", 3);
    w.out = &raw;
    w.acc = w.count = 0;
    fixed_header(&w, 1);
    fixed_match(&w, 3, 3);
    fixed_symbol(&w, 256);
    flush_bits(&w);
    gzip_member(&three, raw.data, raw.size, (const unsigned char *)"abc", 3);
    EXPECT_GZIP_ERROR(three.data, three.size, "member 2: distance too far back");

    free(text_gz);
    free(bin_gz);
    free(text.data);
    free(bin.data);
    free(both.data);
    free(want.data);
    free(three.data);
    free(raw.data);
}

/* Every combination of FTEXT, FHCRC, FEXTRA, FNAME and FCOMMENT around the
   DEFLATE data of a gzip -6 file, and each field broken. */
static void test_inflate_header_fields(void)
{
    static const unsigned char extra[] = {10, 0, 'A', 'p', 6, 0, 'a', 'b', 'c', 'd', 'e', 'f'}; /* XLEN, one subfield */
    size_t size, start, deflate_size;
    unsigned char *gz = load("inflate_text_l6.gz", &size);
    bytes text = make_text(), file = {NULL, 0, 0};
    unsigned flags, reserved;
    if (!gz) return;
    start = deflate_start(gz, size);
    deflate_size = size - start - 8;
    for (flags = 0; flags < 32; flags++) {
        static const unsigned char fixed[] = {0x1f, 0x8b, 8};
        static const unsigned char rest[] = {1, 2, 3, 4, 2, 3}; /* MTIME, XFL, OS */
        file.size = 0;
        bytes_put(&file, fixed, 3);
        bytes_byte(&file, flags);
        bytes_put(&file, rest, 6);
        if (flags & 4) bytes_put(&file, extra, sizeof extra);
        if (flags & 8) bytes_put(&file, "name.txt", 9);
        if (flags & 16) bytes_put(&file, "a comment", 10);
        if (flags & 2) {
            uint32_t crc = sqffd_gz_crc32(0, file.data, file.size);
            bytes_byte(&file, crc & 0xff);
            bytes_byte(&file, (crc >> 8) & 0xff);
        }
        bytes_put(&file, gz + start, deflate_size + 8);
        expect_wrapped(0, file.data, file.size, 0, text.data, text.size, NULL, __FILE__, __LINE__);
        if (flags == 31) { /* every field: break each in turn */
            size_t hcrc = 10 + sizeof extra + 9 + 10;
            file.data[hcrc] ^= 0x40;
            EXPECT_GZIP_ERROR(file.data, file.size, "header CRC (FHCRC) is");
            file.data[hcrc] ^= 0x40;
            file.data[10] = 0xff; /* XLEN 255: past the end of this shortened file */
            EXPECT_GZIP_ERROR(file.data, 60, "input ends inside the extra field (FEXTRA says 255 bytes, 48 present)");
            file.data[10] = 10;
            EXPECT_GZIP_ERROR(file.data, 10 + sizeof extra + 5, "input ends inside the file name (FNAME)");
            EXPECT_GZIP_ERROR(file.data, 10 + sizeof extra + 9 + 4, "input ends inside the comment (FCOMMENT)");
            EXPECT_GZIP_ERROR(file.data, hcrc + 1, "input ends inside the header");
        }
    }
    for (reserved = 0x20; reserved <= 0x80; reserved <<= 1) {
        file.size = 0;
        bytes_put(&file, gz, size);
        file.data[3] = (unsigned char)(file.data[3] | reserved);
        EXPECT_GZIP_ERROR(file.data, file.size, "reserved header flags set");
    }
    file.size = 0;
    bytes_put(&file, gz, size);
    file.data[2] = 7;
    EXPECT_GZIP_ERROR(file.data, file.size, "compression method 7; only 8 (deflate) exists");
    free(gz);
    free(text.data);
    free(file.data);
}

/* 100,000 bytes: 32,768 pseudo-random literals, then matches of 258 at the
   farthest distance DEFLATE has (32,768), in a fixed block of our encoder. */
static void test_inflate_long_distance(void)
{
    enum { TOTAL = 100000, WINDOW = 32768 };
    unsigned char *want = (unsigned char *)malloc(TOTAL);
    bytes raw = {NULL, 0, 0}, gz = {NULL, 0, 0}, stored = {NULL, 0, 0};
    bitwriter w;
    uint32_t x = 1;
    size_t i, used = 0, out_size = 0;
    unsigned char *out = NULL;
    const char *why = NULL;
    for (i = 0; i < WINDOW; i++) {
        x = x * 1664525u + 1013904223u;
        want[i] = (unsigned char)(x >> 24);
    }
    for (; i < TOTAL; i++) want[i] = want[i - WINDOW];
    w.out = &raw;
    w.acc = w.count = 0;
    fixed_header(&w, 1);
    for (i = 0; i < WINDOW; i++) fixed_symbol(&w, want[i]);
    while (i < TOTAL) {
        size_t n = TOTAL - i >= 258 + 3 ? 258 : TOTAL - i; /* never leave fewer than 3 */
        fixed_match(&w, (unsigned)n, WINDOW);
        i += n;
    }
    fixed_symbol(&w, 256);
    flush_bits(&w);
    EXPECT_RAW(&raw, want, TOTAL);
    expect_raw(&raw, TOTAL, want, TOTAL, NULL, __FILE__, __LINE__);
    expect_raw(&raw, TOTAL - 1, NULL, 0, "output larger than the limit", __FILE__, __LINE__);
    /* what follows the stream is not consumed */
    bytes_put(&raw, "XYZ", 3);
    CHECK(sqffd_inflate_raw(raw.data, raw.size, &used, &out, &out_size, 0, &why) == 0);
    CHECK(used == raw.size - 3 && out_size == TOTAL && why == NULL);
    free(out);
    raw.size -= 3;
    gzip_member(&gz, raw.data, raw.size, want, TOTAL);
    EXPECT_GZIP(gz.data, gz.size, want, TOTAL);
    /* the same payload as two stored blocks (65,535 + 34,465 bytes) */
    stored_blocks(&stored, want, TOTAL);
    CHECK(stored.size == TOTAL + 10);
    EXPECT_RAW(&stored, want, TOTAL);

    /* one byte short of the window: distance 32,768 reaches before the start */
    raw.size = 0;
    w.acc = w.count = 0;
    fixed_header(&w, 1);
    for (i = 0; i < WINDOW - 1; i++) fixed_symbol(&w, want[i]);
    fixed_match(&w, 3, WINDOW);
    fixed_symbol(&w, 256);
    flush_bits(&w);
    EXPECT_RAW_ERROR(&raw, "distance too far back");
    free(want);
    free(raw.data);
    free(gz.data);
    free(stored.data);
}

/* Stored, fixed and dynamic blocks in one stream, the dynamic one with a
   single 1-bit distance code (RFC 1951 3.2.7's one-distance-code case). */
static void test_inflate_block_mix(void)
{
    unsigned char litlen[258] = {0}, dist[1] = {1};
    uint32_t codes[258], dist_codes[1];
    bytes raw = {NULL, 0, 0};
    bitwriter w;
    w.out = &raw;
    w.acc = w.count = 0;
    put_bits(&w, 0, 3); /* stored, not final */
    flush_bits(&w);
    bytes_put(&raw, "\x06\x00\xf9\xff" "hello ", 10);
    fixed_header(&w, 0);
    fixed_symbol(&w, 'w');
    fixed_symbol(&w, 'o');
    fixed_symbol(&w, 'r');
    fixed_match(&w, 3, 7); /* 7 back from the end of "hello wor": "llo" */
    fixed_symbol(&w, 256);
    litlen['a'] = 2;
    litlen[256] = 2;
    litlen[257] = 1; /* length 3 */
    dynamic_header(&w, 1, litlen, 258, dist, 1);
    canonical_codes(litlen, 258, codes);
    canonical_codes(dist, 1, dist_codes);
    put_code(&w, codes['a'], 2);
    put_code(&w, codes[257], 1);
    put_code(&w, dist_codes[0], 1); /* distance 1 */
    put_code(&w, codes[256], 2);
    flush_bits(&w);
    EXPECT_RAW(&raw, (const unsigned char *)"hello worlloaaaa", 16);
    /* the output limit in each kind of block: stored, literal, match */
    expect_raw(&raw, 16, (const unsigned char *)"hello worlloaaaa", 16, NULL, __FILE__, __LINE__);
    expect_raw(&raw, 5, NULL, 0, "output larger than the limit", __FILE__, __LINE__);
    expect_raw(&raw, 7, NULL, 0, "output larger than the limit", __FILE__, __LINE__);
    expect_raw(&raw, 10, NULL, 0, "output larger than the limit", __FILE__, __LINE__);
    expect_raw(&raw, 15, NULL, 0, "output larger than the limit", __FILE__, __LINE__);
    free(raw.data);
}

/* Each way a dynamic block's code can be wrong, with the decoder's message. */
static void test_inflate_bad_codes(void)
{
    unsigned char litlen[286], dist[32], cl[19];
    uint32_t codes[286], dist_codes[32];
    bytes raw = {NULL, 0, 0};
    bitwriter w;
    unsigned i;
    w.out = &raw;

#define BEGIN() (raw.size = 0, w.acc = w.count = 0, memset(litlen, 0, sizeof litlen), memset(dist, 0, sizeof dist))
    /* code-length code over-subscribed (19 codes of 1 bit) and incomplete (two of 2 bits) */
    BEGIN();
    memset(cl, 1, sizeof cl);
    dynamic_start(&w, 1, 257, 1, cl);
    flush_bits(&w);
    EXPECT_RAW_ERROR(&raw, "code-length code lengths are over-subscribed");
    BEGIN();
    memset(cl, 0, sizeof cl);
    cl[0] = cl[1] = 2;
    dynamic_start(&w, 1, 257, 1, cl);
    flush_bits(&w);
    EXPECT_RAW_ERROR(&raw, "code-length code lengths are incomplete");

    /* literal/length: 258 codes of 1 bit; two codes of 1 and 2 bits */
    BEGIN();
    memset(litlen, 1, 258);
    dynamic_header(&w, 1, litlen, 258, dist, 1);
    flush_bits(&w);
    EXPECT_RAW_ERROR(&raw, "literal/length code lengths are over-subscribed");
    BEGIN();
    litlen[256] = 1;
    litlen[257] = 2;
    dynamic_header(&w, 1, litlen, 258, dist, 1);
    flush_bits(&w);
    EXPECT_RAW_ERROR(&raw, "literal/length code lengths are incomplete");
    /* a single 1-bit literal/length code (end-of-block) is fine */
    BEGIN();
    litlen[256] = 1;
    dynamic_header(&w, 1, litlen, 257, dist, 1);
    put_code(&w, 0, 1);
    flush_bits(&w);
    EXPECT_RAW(&raw, NULL, 0);
    /* ... and its unused other half is an error */
    BEGIN();
    litlen[256] = 1;
    dynamic_header(&w, 1, litlen, 257, dist, 1);
    put_code(&w, 1, 1);
    flush_bits(&w);
    EXPECT_RAW_ERROR(&raw, "a literal/length code the block does not define");
    /* no end-of-block code */
    BEGIN();
    litlen[0] = litlen[1] = 1;
    dynamic_header(&w, 1, litlen, 257, dist, 1);
    flush_bits(&w);
    EXPECT_RAW_ERROR(&raw, "no code for end-of-block");

    /* distances: three 1-bit codes; two 2-bit codes */
    BEGIN();
    litlen[256] = litlen[257] = 1;
    dist[0] = dist[1] = dist[2] = 1;
    dynamic_header(&w, 1, litlen, 258, dist, 3);
    flush_bits(&w);
    EXPECT_RAW_ERROR(&raw, "distance code lengths are over-subscribed");
    BEGIN();
    litlen[256] = litlen[257] = 1;
    dist[0] = dist[1] = 2;
    dynamic_header(&w, 1, litlen, 258, dist, 2);
    flush_bits(&w);
    EXPECT_RAW_ERROR(&raw, "distance code lengths are incomplete");
    /* no distance codes: literals are fine, a match is not */
    BEGIN();
    litlen['a'] = litlen[256] = litlen[257] = 2;
    litlen['b'] = 2;
    dynamic_header(&w, 1, litlen, 258, dist, 1);
    canonical_codes(litlen, 258, codes);
    put_code(&w, codes['a'], 2);
    put_code(&w, codes['b'], 2);
    put_code(&w, codes[256], 2);
    flush_bits(&w);
    EXPECT_RAW(&raw, (const unsigned char *)"ab", 2);
    BEGIN();
    litlen['a'] = litlen[256] = litlen[257] = litlen['b'] = 2;
    dynamic_header(&w, 1, litlen, 258, dist, 1);
    put_code(&w, codes['a'], 2);
    put_code(&w, codes[257], 2);
    put_code(&w, 0, 1);
    flush_bits(&w);
    EXPECT_RAW_ERROR(&raw, "a distance code the block does not define");
    /* 32 distance codes of 5 bits (HDIST may say 32); symbol 30 in use is an error */
    BEGIN();
    litlen['a'] = litlen[256] = litlen[257] = litlen['b'] = 2;
    memset(dist, 5, 32);
    dynamic_header(&w, 1, litlen, 258, dist, 32);
    canonical_codes(dist, 32, dist_codes);
    put_code(&w, codes['a'], 2);
    put_code(&w, codes[257], 2);
    put_code(&w, dist_codes[0], 5);
    put_code(&w, codes[257], 2);
    put_code(&w, dist_codes[30], 5);
    flush_bits(&w);
    EXPECT_RAW_ERROR(&raw, "distance symbol 30 or 31 (reserved)");

    /* the header's counts and repeats */
    BEGIN();
    memset(cl, 4, 13);
    memset(cl + 13, 5, 6);
    dynamic_start(&w, 1, 287, 1, cl);
    flush_bits(&w);
    EXPECT_RAW_ERROR(&raw, "HLIT declares more than 286");
    BEGIN();
    dynamic_start(&w, 1, 257, 1, cl);
    codelen_symbol(&w, 16, 0);
    flush_bits(&w);
    EXPECT_RAW_ERROR(&raw, "repeat code 16 before any code length");
    BEGIN();
    dynamic_start(&w, 1, 257, 1, cl);
    codelen_symbol(&w, 18, 127);
    codelen_symbol(&w, 18, 127); /* 276 > 258 lengths */
    flush_bits(&w);
    EXPECT_RAW_ERROR(&raw, "code lengths repeat past HLIT + HDIST");

    /* fixed blocks: the reserved symbols */
    for (i = 286; i <= 287; i++) {
        BEGIN();
        fixed_header(&w, 1);
        fixed_symbol(&w, i);
        flush_bits(&w);
        EXPECT_RAW_ERROR(&raw, "literal/length symbol 286 or 287 (reserved)");
    }
    BEGIN();
    fixed_header(&w, 1);
    fixed_symbol(&w, 'a');
    fixed_symbol(&w, 257);
    put_code(&w, 31, 5);
    flush_bits(&w);
    EXPECT_RAW_ERROR(&raw, "distance symbol 30 or 31 (reserved)");
#undef BEGIN
    free(raw.data);
}

/* Broken streams and wrappers, each with its message. */
static void test_inflate_broken(void)
{
    static const unsigned char type3[] = {0x07}, nlen[] = {1, 5, 0, 0, 0, 'h', 'e', 'l', 'l', 'o'};
    static const unsigned char stored_short[] = {1, 5, 0, 0xfa, 0xff, 'h', 'e'};
    size_t size;
    unsigned char *gz = load("inflate_text_l6.gz", &size);
    bytes raw = {NULL, 0, 0}, file = {NULL, 0, 0}, text = make_text();
    bitwriter w;
    bytes_put(&raw, type3, sizeof type3);
    EXPECT_RAW_ERROR(&raw, "block type 3 (reserved)");
    raw.size = 0;
    bytes_put(&raw, nlen, sizeof nlen);
    EXPECT_RAW_ERROR(&raw, "stored block: NLEN is not the one's complement of LEN");
    raw.size = 0;
    bytes_put(&raw, stored_short, sizeof stored_short);
    EXPECT_RAW_ERROR(&raw, "input ends inside a stored block");
    raw.size = 0;
    stored_blocks(&raw, (const unsigned char *)"hello", 5);
    expect_raw(&raw, 5, (const unsigned char *)"hello", 5, NULL, __FILE__, __LINE__);
    expect_raw(&raw, 4, NULL, 0, "output larger than the limit", __FILE__, __LINE__);
    raw.size = 0;
    EXPECT_RAW_ERROR(&raw, "input ends inside the compressed data");
    w.out = &raw;
    w.acc = w.count = 0;
    fixed_header(&w, 1);
    fixed_symbol(&w, 'a');
    fixed_match(&w, 3, 2);
    fixed_symbol(&w, 256);
    flush_bits(&w);
    EXPECT_RAW_ERROR(&raw, "distance too far back");
    /* a final block missing: the stream ends after a non-final one */
    raw.size = 0;
    w.acc = w.count = 0;
    fixed_header(&w, 0);
    fixed_symbol(&w, 'a');
    fixed_symbol(&w, 256);
    flush_bits(&w);
    EXPECT_RAW_ERROR(&raw, "input ends inside the compressed data");

    EXPECT_GZIP_ERROR(NULL, 0, "no data");
    EXPECT_GZIP_ERROR("\x1f", 1, "input ends inside the header");
    EXPECT_GZIP_ERROR("hello", 5, "not gzip data (no 1f 8b at the start)");
    if (gz) {
        bytes_put(&file, gz, size);
        EXPECT_GZIP(file.data, file.size, text.data, text.size);
        file.data[size - 8] ^= 0x10;
        EXPECT_GZIP_ERROR(file.data, file.size, "CRC-32 mismatch: the trailer says 0x");
        file.data[size - 8] ^= 0x10;
        file.data[size - 3] ^= 1;
        EXPECT_GZIP_ERROR(file.data, file.size, "ISIZE mismatch: the trailer says 18793 bytes (mod 2^32), the data is 18537 bytes");
        file.data[size - 3] ^= 1;
        EXPECT_GZIP_ERROR(file.data, file.size - 1, "input ends inside the trailer (CRC-32 and ISIZE)");
        bytes_put(&file, "xyz", 3);
        EXPECT_GZIP_ERROR(file.data, file.size, "3 bytes of trailing garbage after member 1 (at byte 6834)");
        file.data[size] = 0x1f; /* one byte of a magic is garbage too */
        EXPECT_GZIP_ERROR(file.data, size + 1, "1 bytes of trailing garbage");
        file.data[size] = 0;
        EXPECT_GZIP(file.data, size + 1, text.data, text.size);
        file.data[200] ^= 0xff; /* damage inside the compressed data: any message but no output */
        expect_wrapped(0, file.data, size, 0, NULL, 0, "", __FILE__, __LINE__);
    }
    free(gz);
    free(raw.data);
    free(file.data);
    free(text.data);
}

/* A gzip file cut at every byte: always a message about the input ending. */
static void test_inflate_truncated(void)
{
    size_t size, k;
    unsigned char *gz = load("inflate_points.xyz.gz", &size);
    int failures = 0;
    if (!gz) return;
    for (k = 0; k < size; k++) {
        unsigned char *out = (unsigned char *)&out;
        size_t out_size = 1;
        char err[256] = "";
        int r = sqffd_gz_decompress(gz, k, "cut.gz", 0, &out, &out_size, err, sizeof err);
        if (r != -1 || out || out_size ||
            (k > 0 && !strstr(err, "cut.gz: gzip: input ends inside")) || (k == 0 && !strstr(err, "no data"))) {
            if (failures++ < 5) test_fail(__FILE__, __LINE__, "cut at %llu: r %d, \"%s\"", (unsigned long long)k, r, err);
            if (r == 0) free(out);
        }
    }
    CHECK(failures == 0);
    /* and the whole file is fine */
    {
        bytes want = make_points_xyz();
        EXPECT_GZIP(gz, size, want.data, want.size);
        CHECK(sqffd_gz_crc32(0, want.data, want.size) == 0x770596e7u);
        free(want.data);
    }
    free(gz);
}

/* 10 MB of zeros in a 10 KB file: the limit stops it, exactly at its size. */
static void test_inflate_bomb(void)
{
    enum { ZEROS = 10 * 1024 * 1024 };
    size_t size, out_size = 0, i, nonzero = 0;
    unsigned char *gz = load("inflate_zeros_10mb.gz", &size), *out = NULL;
    char err[256];
    if (!gz) return;
    expect_wrapped(0, gz, size, 1 << 20, NULL, 0, "decompressed data larger than the limit of 1048576 bytes", __FILE__,
                   __LINE__);
    expect_wrapped(0, gz, size, ZEROS - 1, NULL, 0, "larger than the limit of 10485759 bytes", __FILE__, __LINE__);
    CHECK(sqffd_gz_decompress(gz, size, "z.gz", ZEROS, &out, &out_size, err, sizeof err) == 0);
    CHECK(out_size == ZEROS);
    for (i = 0; out && i < out_size; i++) nonzero += out[i] != 0;
    CHECK(nonzero == 0);
    free(out);
    free(gz);
}

/* zlib streams (RFC 1950): the file, its checks, its header. */
static void test_inflate_zlib(void)
{
    size_t size;
    unsigned char *z = load("inflate_binary_l6.zlib", &size);
    bytes bin = make_binary(), file = {NULL, 0, 0};
    EXPECT_ZLIB_ERROR(NULL, 0, "no data");
    EXPECT_ZLIB_ERROR("\x78", 1, "input ends inside the header");
    EXPECT_ZLIB_ERROR("\x78\x9d\x03\x00", 4, "header check failed");
    EXPECT_ZLIB_ERROR("\x78\xbb\x03\x00", 4, "needs a preset dictionary (FDICT)");
    EXPECT_ZLIB_ERROR("\x77\x01\x03\x00", 4, "compression method 7");
    EXPECT_ZLIB_ERROR("\x88\x01\x03\x00", 4, "window size 2^16 is larger than 32 KiB");
    if (z) {
        bytes_put(&file, z, size);
        CHECK(file.data[0] == 0x78 && file.data[1] == 0x9c);
        EXPECT_ZLIB(file.data, file.size, bin.data, bin.size);
        expect_wrapped(1, file.data, file.size, bin.size, bin.data, bin.size, NULL, __FILE__, __LINE__);
        expect_wrapped(1, file.data, file.size, bin.size - 1, NULL, 0, "larger than the limit of 39999 bytes", __FILE__,
                       __LINE__);
        file.data[size - 1] ^= 1;
        EXPECT_ZLIB_ERROR(file.data, file.size, "Adler-32 mismatch: the trailer says 0x96463f2d, the data gives 0x96463f2c");
        file.data[size - 1] ^= 1;
        EXPECT_ZLIB_ERROR(file.data, file.size - 2, "input ends inside the Adler-32 trailer");
        bytes_put(&file, "\0", 1);
        EXPECT_ZLIB_ERROR(file.data, file.size, "1 bytes after the end of the stream");
        EXPECT_ZLIB_ERROR(file.data, 1000, "input ends inside the compressed data");
    }
    free(z);
    free(bin.data);
    free(file.data);
}

/* gzip-compressed point files through sqffd_io: the same points as plain. */
static void test_inflate_io_points(void)
{
    bytes xyz = make_points_xyz(), gz = {NULL, 0, 0};
    double *plain = NULL, *packed = NULL, *bunny = NULL, *bunny_gz = NULL;
    size_t plain_n = 0, packed_n = 0, bunny_n = 0, bunny_gz_n = 0;
    char err[256] = "";
    CHECK(sqffd_io_read_points(xyz.data, xyz.size, "p.xyz", &plain, &plain_n, err, sizeof err) == 0);
    CHECK_MSG(sqffd_io_read_file("tests/data/inflate_points.xyz.gz", &packed, &packed_n, err, sizeof err) == 0, "%s",
              err);
    CHECK(plain_n == 500 && packed_n == 500);
    CHECK(plain && packed && memcmp(plain, packed, 500 * 3 * sizeof(double)) == 0);
    CHECK(packed && packed[3 * 499] == 499 && packed[3 * 499 + 1] == 499 * 499 % 97 && packed[3 * 499 + 2] == -1497);
    CHECK_MSG(sqffd_io_read_file("tests/data/bunny.ply", &bunny, &bunny_n, err, sizeof err) == 0, "%s", err);
    CHECK_MSG(sqffd_io_read_file("tests/data/bunny.ply.gz", &bunny_gz, &bunny_gz_n, err, sizeof err) == 0, "%s", err);
    CHECK(bunny_n == 1839 && bunny_gz_n == 1839);
    CHECK(bunny && bunny_gz && memcmp(bunny, bunny_gz, 1839 * 3 * sizeof(double)) == 0);
    free(plain);
    free(packed);
    free(bunny);
    free(bunny_gz);

    /* no hint in the content: the name without .gz decides */
    gzip_stored(&gz, (const unsigned char *)"1 2 3\n", 6);
    CHECK(sqffd_io_read_points(gz.data, gz.size, "a.xyz.gz", &plain, &plain_n, err, sizeof err) == 0);
    CHECK(plain_n == 1 && plain && plain[0] == 1 && plain[1] == 2 && plain[2] == 3);
    free(plain);
    CHECK(sqffd_io_read_points(gz.data, gz.size, "a.PLY.gz", &plain, &plain_n, err, sizeof err) == 1);
    CHECK_MSG(strncmp(err, "a.PLY.gz: ", 10) == 0 && !plain && plain_n == 0, "%s", err);
    CHECK(sqffd_io_read_points(gz.data, gz.size, "a.off.gz", &plain, &plain_n, err, sizeof err) == 1);
    CHECK_MSG(strncmp(err, "a.off.gz: ", 10) == 0, "%s", err);
    CHECK(sqffd_io_read_points(gz.data, gz.size, "a.obj.gz", &plain, &plain_n, err, sizeof err) == 1);
    CHECK_MSG(strncmp(err, "a.obj.gz: ", 10) == 0, "%s", err);
    CHECK(sqffd_io_detect("1 2 3\n", 6, "a.PLY.GZ") == SQFFD_IO_PLY);
    CHECK(sqffd_io_detect("1 2 3\n", 6, "a.off.gz") == SQFFD_IO_OFF);
    CHECK(sqffd_io_detect("1 2 3\n", 6, "a.obj.gz") == SQFFD_IO_OBJ);
    CHECK(sqffd_io_detect("1 2 3\n", 6, "a.gz") == SQFFD_IO_XYZ);
    CHECK(sqffd_io_detect("1 2 3\n", 6, ".gz") == SQFFD_IO_XYZ);

    /* failures: the decompression's message, nothing, gzip inside gzip */
    gz.data[gz.size - 8] ^= 1;
    CHECK(sqffd_io_read_points(gz.data, gz.size, "a.xyz.gz", &plain, &plain_n, err, sizeof err) == 1);
    CHECK_MSG(strncmp(err, "a.xyz.gz: gzip-compressed data: CRC-32 mismatch", 47) == 0, "%s", err);
    gz.size = 0;
    gzip_stored(&gz, (const unsigned char *)"", 0);
    CHECK(sqffd_io_read_points(gz.data, gz.size, "e.xyz.gz", &plain, &plain_n, err, sizeof err) == 1);
    CHECK_MSG(strcmp(err, "e.xyz.gz: decompresses to nothing") == 0, "%s", err);
    {
        bytes twice = {NULL, 0, 0};
        gzip_stored(&twice, gz.data, gz.size);
        CHECK(sqffd_io_read_points(twice.data, twice.size, "t.xyz.gz", &plain, &plain_n, err, sizeof err) == 1);
        CHECK_MSG(strcmp(err, "t.xyz.gz: gzip-compressed twice") == 0, "%s", err);
        free(twice.data);
    }
    free(xyz.data);
    free(gz.data);
}

void suite_inflate(void)
{
    RUN_TEST(test_inflate_checksums);
    RUN_TEST(test_inflate_levels);
    RUN_TEST(test_inflate_nifti_files);
    RUN_TEST(test_inflate_small_payloads);
    RUN_TEST(test_inflate_multi_member);
    RUN_TEST(test_inflate_header_fields);
    RUN_TEST(test_inflate_long_distance);
    RUN_TEST(test_inflate_block_mix);
    RUN_TEST(test_inflate_bad_codes);
    RUN_TEST(test_inflate_broken);
    RUN_TEST(test_inflate_truncated);
    RUN_TEST(test_inflate_bomb);
    RUN_TEST(test_inflate_zlib);
    RUN_TEST(test_inflate_io_points);
}

/* sqffd_inflate.h - DEFLATE, zlib and gzip decompression for the sqffd tools (not part of the library).

   Header-only, every function `static inline`; plain C99 (and C++) plus the
   C library (malloc/realloc/free, snprintf). Independent of sqffd.h and zlib.

   Formats: raw DEFLATE (RFC 1951: stored, fixed and dynamic Huffman blocks),
   the zlib wrapper (RFC 1950: header check, Adler-32; a preset dictionary is
   refused) and gzip files (RFC 1952: every header field, CRC-32 and ISIZE
   checked, concatenated members decoded in sequence, zero padding after the
   last member accepted).

   Every decoder takes a memory buffer and its size, never reads outside it,
   and returns
     0  with *out = a malloc'd buffer of *out_size bytes (free() it; never
        NULL, even for empty output), or
     -1 with *out = NULL, *out_size = 0 and a message in err:
        "NAME: gzip: what is wrong" (gzip), "NAME: zlib: what is wrong" (zlib);
        NAME is the name the caller passed, for messages only.
   max_output bounds the decompressed size (0: SIZE_MAX / 2); a stream that
   would write more stops there with a message, so a decompression bomb costs
   at most max_output bytes of memory. The output grows by doubling.

   Where RFC 1951 leaves room, the decoder decides as zlib does: the
   code-length code must be complete; a literal/length or distance code may
   be incomplete only as a single 1-bit code (the RFC's one-distance-code
   case); a block with no distance codes is fine until it uses one. One
   difference: HDIST may declare 32 distance codes (the RFC's range; zlib
   refuses more than 30), but the reserved symbols 30 and 31, like
   literal/length symbols 286 and 287, are errors when they occur. The zlib
   window size (CINFO) is checked to be at most 32 KiB but not enforced on
   distances.

   Speed: a 64-bit bit buffer refilled 8 bytes at a time, a 10-bit first-level
   table for literal/length codes (8 bits for distances) with second-level
   tables for longer codes, up to three literals per refill, and match copies
   in 16-byte steps (the output keeps 274 spare bytes so a copy may overshoot;
   distances under 8 copy from a multiple of the distance). */
#ifndef SQFFD_INFLATE_H
#define SQFFD_INFLATE_H

#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- checksums ------------------------------------------------------------ */

/* CRC-32 of each byte value (the reflected polynomial 0xedb88320 of RFC 1952). */
static inline const uint32_t *sqffd_gz__crc_table(void)
{
    static const uint32_t table[256] = {
        0x00000000u, 0x77073096u, 0xee0e612cu, 0x990951bau, 0x076dc419u, 0x706af48fu,
        0xe963a535u, 0x9e6495a3u, 0x0edb8832u, 0x79dcb8a4u, 0xe0d5e91eu, 0x97d2d988u,
        0x09b64c2bu, 0x7eb17cbdu, 0xe7b82d07u, 0x90bf1d91u, 0x1db71064u, 0x6ab020f2u,
        0xf3b97148u, 0x84be41deu, 0x1adad47du, 0x6ddde4ebu, 0xf4d4b551u, 0x83d385c7u,
        0x136c9856u, 0x646ba8c0u, 0xfd62f97au, 0x8a65c9ecu, 0x14015c4fu, 0x63066cd9u,
        0xfa0f3d63u, 0x8d080df5u, 0x3b6e20c8u, 0x4c69105eu, 0xd56041e4u, 0xa2677172u,
        0x3c03e4d1u, 0x4b04d447u, 0xd20d85fdu, 0xa50ab56bu, 0x35b5a8fau, 0x42b2986cu,
        0xdbbbc9d6u, 0xacbcf940u, 0x32d86ce3u, 0x45df5c75u, 0xdcd60dcfu, 0xabd13d59u,
        0x26d930acu, 0x51de003au, 0xc8d75180u, 0xbfd06116u, 0x21b4f4b5u, 0x56b3c423u,
        0xcfba9599u, 0xb8bda50fu, 0x2802b89eu, 0x5f058808u, 0xc60cd9b2u, 0xb10be924u,
        0x2f6f7c87u, 0x58684c11u, 0xc1611dabu, 0xb6662d3du, 0x76dc4190u, 0x01db7106u,
        0x98d220bcu, 0xefd5102au, 0x71b18589u, 0x06b6b51fu, 0x9fbfe4a5u, 0xe8b8d433u,
        0x7807c9a2u, 0x0f00f934u, 0x9609a88eu, 0xe10e9818u, 0x7f6a0dbbu, 0x086d3d2du,
        0x91646c97u, 0xe6635c01u, 0x6b6b51f4u, 0x1c6c6162u, 0x856530d8u, 0xf262004eu,
        0x6c0695edu, 0x1b01a57bu, 0x8208f4c1u, 0xf50fc457u, 0x65b0d9c6u, 0x12b7e950u,
        0x8bbeb8eau, 0xfcb9887cu, 0x62dd1ddfu, 0x15da2d49u, 0x8cd37cf3u, 0xfbd44c65u,
        0x4db26158u, 0x3ab551ceu, 0xa3bc0074u, 0xd4bb30e2u, 0x4adfa541u, 0x3dd895d7u,
        0xa4d1c46du, 0xd3d6f4fbu, 0x4369e96au, 0x346ed9fcu, 0xad678846u, 0xda60b8d0u,
        0x44042d73u, 0x33031de5u, 0xaa0a4c5fu, 0xdd0d7cc9u, 0x5005713cu, 0x270241aau,
        0xbe0b1010u, 0xc90c2086u, 0x5768b525u, 0x206f85b3u, 0xb966d409u, 0xce61e49fu,
        0x5edef90eu, 0x29d9c998u, 0xb0d09822u, 0xc7d7a8b4u, 0x59b33d17u, 0x2eb40d81u,
        0xb7bd5c3bu, 0xc0ba6cadu, 0xedb88320u, 0x9abfb3b6u, 0x03b6e20cu, 0x74b1d29au,
        0xead54739u, 0x9dd277afu, 0x04db2615u, 0x73dc1683u, 0xe3630b12u, 0x94643b84u,
        0x0d6d6a3eu, 0x7a6a5aa8u, 0xe40ecf0bu, 0x9309ff9du, 0x0a00ae27u, 0x7d079eb1u,
        0xf00f9344u, 0x8708a3d2u, 0x1e01f268u, 0x6906c2feu, 0xf762575du, 0x806567cbu,
        0x196c3671u, 0x6e6b06e7u, 0xfed41b76u, 0x89d32be0u, 0x10da7a5au, 0x67dd4accu,
        0xf9b9df6fu, 0x8ebeeff9u, 0x17b7be43u, 0x60b08ed5u, 0xd6d6a3e8u, 0xa1d1937eu,
        0x38d8c2c4u, 0x4fdff252u, 0xd1bb67f1u, 0xa6bc5767u, 0x3fb506ddu, 0x48b2364bu,
        0xd80d2bdau, 0xaf0a1b4cu, 0x36034af6u, 0x41047a60u, 0xdf60efc3u, 0xa867df55u,
        0x316e8eefu, 0x4669be79u, 0xcb61b38cu, 0xbc66831au, 0x256fd2a0u, 0x5268e236u,
        0xcc0c7795u, 0xbb0b4703u, 0x220216b9u, 0x5505262fu, 0xc5ba3bbeu, 0xb2bd0b28u,
        0x2bb45a92u, 0x5cb36a04u, 0xc2d7ffa7u, 0xb5d0cf31u, 0x2cd99e8bu, 0x5bdeae1du,
        0x9b64c2b0u, 0xec63f226u, 0x756aa39cu, 0x026d930au, 0x9c0906a9u, 0xeb0e363fu,
        0x72076785u, 0x05005713u, 0x95bf4a82u, 0xe2b87a14u, 0x7bb12baeu, 0x0cb61b38u,
        0x92d28e9bu, 0xe5d5be0du, 0x7cdcefb7u, 0x0bdbdf21u, 0x86d3d2d4u, 0xf1d4e242u,
        0x68ddb3f8u, 0x1fda836eu, 0x81be16cdu, 0xf6b9265bu, 0x6fb077e1u, 0x18b74777u,
        0x88085ae6u, 0xff0f6a70u, 0x66063bcau, 0x11010b5cu, 0x8f659effu, 0xf862ae69u,
        0x616bffd3u, 0x166ccf45u, 0xa00ae278u, 0xd70dd2eeu, 0x4e048354u, 0x3903b3c2u,
        0xa7672661u, 0xd06016f7u, 0x4969474du, 0x3e6e77dbu, 0xaed16a4au, 0xd9d65adcu,
        0x40df0b66u, 0x37d83bf0u, 0xa9bcae53u, 0xdebb9ec5u, 0x47b2cf7fu, 0x30b5ffe9u,
        0xbdbdf21cu, 0xcabac28au, 0x53b39330u, 0x24b4a3a6u, 0xbad03605u, 0xcdd70693u,
        0x54de5729u, 0x23d967bfu, 0xb3667a2eu, 0xc4614ab8u, 0x5d681b02u, 0x2a6f2b94u,
        0xb40bbe37u, 0xc30c8ea1u, 0x5a05df1bu, 0x2d02ef8du};
    return table;
}

static inline uint32_t sqffd_gz__load32_le(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* CRC-32 (RFC 1952, as zlib's crc32): start with crc = 0; chaining works,
   sqffd_gz_crc32(sqffd_gz_crc32(0, a, n), b, m) is the CRC of a then b.
   Inputs of 1 KiB and more run eight bytes a step ("slice-by-8": seven more
   tables, derived on the stack, give the CRC of a byte followed by 1..7 zero
   bytes, so eight lookups replace eight dependent steps). */
static inline uint32_t sqffd_gz_crc32(uint32_t crc, const void *data, size_t size)
{
    const uint32_t *byte_table = sqffd_gz__crc_table();
    const unsigned char *p = (const unsigned char *)data;
    crc = ~crc;
    if (size >= 1024) {
        uint32_t t[8][256];
        unsigned i, k;
        for (i = 0; i < 256; i++) t[0][i] = byte_table[i];
        for (k = 1; k < 8; k++)
            for (i = 0; i < 256; i++) t[k][i] = (t[k - 1][i] >> 8) ^ byte_table[t[k - 1][i] & 0xff];
        while (size >= 8) {
            uint32_t lo = crc ^ sqffd_gz__load32_le(p), hi = sqffd_gz__load32_le(p + 4);
            crc = t[7][lo & 0xff] ^ t[6][(lo >> 8) & 0xff] ^ t[5][(lo >> 16) & 0xff] ^ t[4][lo >> 24] ^
                  t[3][hi & 0xff] ^ t[2][(hi >> 8) & 0xff] ^ t[1][(hi >> 16) & 0xff] ^ t[0][hi >> 24];
            p += 8;
            size -= 8;
        }
    }
    while (size--) crc = byte_table[(crc ^ *p++) & 0xff] ^ (crc >> 8);
    return ~crc;
}

/* Adler-32 (RFC 1950, as zlib's adler32): start with adler = 1; chaining
   works as for the CRC. */
static inline uint32_t sqffd_gz_adler32(uint32_t adler, const void *data, size_t size)
{
    const unsigned char *p = (const unsigned char *)data;
    uint32_t a = adler & 0xffff, b = adler >> 16;
    while (size > 0) {
        /* 5552 bytes is the longest run whose sums cannot overflow 32 bits before the reduction */
        size_t n = size < 5552 ? size : 5552;
        size -= n;
        while (n >= 8) {
            a += p[0]; b += a; a += p[1]; b += a; a += p[2]; b += a; a += p[3]; b += a;
            a += p[4]; b += a; a += p[5]; b += a; a += p[6]; b += a; a += p[7]; b += a;
            p += 8;
            n -= 8;
        }
        while (n--) { a += *p++; b += a; }
        a %= 65521u;
        b %= 65521u;
    }
    return b << 16 | a;
}

/* ---- raw DEFLATE (RFC 1951) ---------------------------------------------- */

/* Why a stream was refused; sqffd_inflate__message gives the text. */
enum {
    SQFFD_INFLATE__OK = 0,
    SQFFD_INFLATE__TRUNCATED,
    SQFFD_INFLATE__BLOCK_TYPE,
    SQFFD_INFLATE__STORED_LENGTH,
    SQFFD_INFLATE__STORED_TRUNCATED,
    SQFFD_INFLATE__TOO_MANY_LITLEN,
    SQFFD_INFLATE__CODELEN_OVER,
    SQFFD_INFLATE__CODELEN_INCOMPLETE,
    SQFFD_INFLATE__REPEAT_NOTHING,
    SQFFD_INFLATE__REPEAT_PAST_END,
    SQFFD_INFLATE__NO_END_CODE,
    SQFFD_INFLATE__LITLEN_OVER,
    SQFFD_INFLATE__LITLEN_INCOMPLETE,
    SQFFD_INFLATE__DIST_OVER,
    SQFFD_INFLATE__DIST_INCOMPLETE,
    SQFFD_INFLATE__LITLEN_RESERVED,
    SQFFD_INFLATE__LITLEN_UNDEFINED,
    SQFFD_INFLATE__DIST_RESERVED,
    SQFFD_INFLATE__DIST_UNDEFINED,
    SQFFD_INFLATE__TOO_FAR_BACK,
    SQFFD_INFLATE__TOO_LARGE,
    SQFFD_INFLATE__NO_MEMORY
};

static inline const char *sqffd_inflate__message(int code)
{
    switch (code) {
    case SQFFD_INFLATE__OK: return "no error";
    case SQFFD_INFLATE__TRUNCATED: return "input ends inside the compressed data";
    case SQFFD_INFLATE__BLOCK_TYPE: return "block type 3 (reserved)";
    case SQFFD_INFLATE__STORED_LENGTH: return "stored block: NLEN is not the one's complement of LEN";
    case SQFFD_INFLATE__STORED_TRUNCATED: return "input ends inside a stored block";
    case SQFFD_INFLATE__TOO_MANY_LITLEN: return "dynamic block: HLIT declares more than 286 literal/length codes";
    case SQFFD_INFLATE__CODELEN_OVER: return "dynamic block: code-length code lengths are over-subscribed";
    case SQFFD_INFLATE__CODELEN_INCOMPLETE: return "dynamic block: code-length code lengths are incomplete";
    case SQFFD_INFLATE__REPEAT_NOTHING: return "dynamic block: repeat code 16 before any code length";
    case SQFFD_INFLATE__REPEAT_PAST_END: return "dynamic block: code lengths repeat past HLIT + HDIST";
    case SQFFD_INFLATE__NO_END_CODE: return "dynamic block: no code for end-of-block (symbol 256)";
    case SQFFD_INFLATE__LITLEN_OVER: return "dynamic block: literal/length code lengths are over-subscribed";
    case SQFFD_INFLATE__LITLEN_INCOMPLETE: return "dynamic block: literal/length code lengths are incomplete";
    case SQFFD_INFLATE__DIST_OVER: return "dynamic block: distance code lengths are over-subscribed";
    case SQFFD_INFLATE__DIST_INCOMPLETE: return "dynamic block: distance code lengths are incomplete";
    case SQFFD_INFLATE__LITLEN_RESERVED: return "literal/length symbol 286 or 287 (reserved)";
    case SQFFD_INFLATE__LITLEN_UNDEFINED: return "a literal/length code the block does not define";
    case SQFFD_INFLATE__DIST_RESERVED: return "distance symbol 30 or 31 (reserved)";
    case SQFFD_INFLATE__DIST_UNDEFINED: return "a distance code the block does not define";
    case SQFFD_INFLATE__TOO_FAR_BACK: return "distance too far back (before the start of the output)";
    case SQFFD_INFLATE__TOO_LARGE: return "output larger than the limit";
    case SQFFD_INFLATE__NO_MEMORY: return "out of memory";
    default: return "unknown error";
    }
}

/* Decoding tables. An entry (uint32_t) is
     bits 0-3    bits its code takes (a link: the first-level table's bits)
     bits 4-7    extra bits after the code (lengths, distances);
                 a link: how many bits index its second-level table
     bits 8-12   the kind flags below; no flag: no valid stream reaches it
     bits 16-31  literal byte, length or distance base, code-length symbol,
                 or a link's offset of its second-level table.
   Second-level entries count the whole code's bits. */
enum {
    SQFFD_INFLATE__LITERAL = 0x100, /* also the symbols of the code-length code */
    SQFFD_INFLATE__MATCH = 0x200,   /* a length (literal/length table) or a distance */
    SQFFD_INFLATE__END = 0x400,     /* end of block */
    SQFFD_INFLATE__LINK = 0x800,    /* to a second-level table */
    SQFFD_INFLATE__RESERVED = 0x1000
};

#define SQFFD_INFLATE__LITLEN_BITS 10
#define SQFFD_INFLATE__DIST_BITS 8
#define SQFFD_INFLATE__CODELEN_BITS 7
/* Room for every second-level table. One hangs off a first-level entry
   whose subtree holds codes longer than the first level; a table of 2^k
   entries means a code k bits longer than that, and in a complete code that
   subtree then holds at least k + 1 codes (a sibling per level, plus the
   deepest). With k <= 15 - 10 and at most 288 literal/length codes that is
   at most 288 / 6 tables of 32 entries; distances: 32 codes, k <= 7, at most
   4 tables of 128. Incomplete codes are accepted only as a single 1-bit code,
   which has no second level. */
#define SQFFD_INFLATE__LITLEN_SIZE ((1 << SQFFD_INFLATE__LITLEN_BITS) + 288 / 6 * 32)
#define SQFFD_INFLATE__DIST_SIZE ((1 << SQFFD_INFLATE__DIST_BITS) + 32 / 8 * 128)
/* Spare output bytes kept past the write position: a longest match (258)
   copied in 16-byte steps overshoots by up to 15. */
#define SQFFD_INFLATE__SLACK (258 + 16)

typedef struct sqffd_inflate__tables {
    uint32_t litlen[SQFFD_INFLATE__LITLEN_SIZE];
    uint32_t distance[SQFFD_INFLATE__DIST_SIZE];
    uint32_t codelen[1 << SQFFD_INFLATE__CODELEN_BITS];
    int fixed; /* litlen and distance hold the fixed code of RFC 1951 3.2.6 */
} sqffd_inflate__tables;

/* The entry (without its bit count) of a symbol: kind 0 literal/length,
   1 distance, 2 code-length code. */
static inline uint32_t sqffd_inflate__symbol_entry(int kind, unsigned symbol)
{
    static const uint16_t length_base[29] = {3,  4,  5,  6,  7,  8,  9,  10, 11,  13,  15,  17,  19,  23, 27,
                                             31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163, 195, 227, 258};
    static const uint8_t length_extra[29] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2,
                                             2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
    static const uint16_t distance_base[30] = {1,   2,   3,   4,   5,   7,    9,    13,   17,   25,
                                               33,  49,  65,  97,  129, 193,  257,  385,  513,  769,
                                               1025, 1537, 2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577};
    static const uint8_t distance_extra[30] = {0, 0, 0, 0, 1, 1, 2, 2,  3,  3,  4,  4,  5,  5,  6,
                                               6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13, 13};
    if (kind == 0) {
        if (symbol < 256) return SQFFD_INFLATE__LITERAL | (uint32_t)symbol << 16;
        if (symbol == 256) return SQFFD_INFLATE__END;
        if (symbol < 286)
            return SQFFD_INFLATE__MATCH | (uint32_t)length_base[symbol - 257] << 16 |
                   (uint32_t)length_extra[symbol - 257] << 4;
        return SQFFD_INFLATE__RESERVED;
    }
    if (kind == 1) {
        if (symbol < 30)
            return SQFFD_INFLATE__MATCH | (uint32_t)distance_base[symbol] << 16 | (uint32_t)distance_extra[symbol] << 4;
        return SQFFD_INFLATE__RESERVED;
    }
    return SQFFD_INFLATE__LITERAL | (uint32_t)symbol << 16 |
           (uint32_t)(symbol == 16 ? 2 : symbol == 17 ? 3 : symbol == 18 ? 7 : 0) << 4;
}

/* Builds the table of the canonical Huffman code (RFC 1951 3.2.2) given by
   the code lengths (0..15) of `count` symbols. allow_partial accepts no
   codes at all or one 1-bit code. Returns 0, 1 (over-subscribed) or 2
   (incomplete). */
static inline int sqffd_inflate__build(uint32_t *table, size_t table_size, unsigned first_bits, int kind,
                                       const unsigned char *lengths, unsigned count, int allow_partial)
{
    unsigned length_count[16] = {0}, next_code[16], reversed[288];
    unsigned char second_bits[1 << SQFFD_INFLATE__LITLEN_BITS]; /* per first-level entry: its table's bits */
    unsigned first_size = 1u << first_bits, symbol, len, code, used = 0;
    size_t next_free = first_size;
    long left = 1;
    for (symbol = 0; symbol < count; symbol++) length_count[lengths[symbol]]++;
    for (len = 1; len <= 15; len++) {
        left = 2 * left - (long)length_count[len];
        if (left < 0) return 1;
        used += length_count[len];
    }
    if (left > 0 && !(allow_partial && (used == 0 || (used == 1 && length_count[1] == 1)))) return 2;

    code = 0;
    length_count[0] = 0;
    for (len = 1; len <= 15; len++) {
        code = (code + length_count[len - 1]) << 1;
        next_code[len] = code;
    }
    memset(table, 0, first_size * sizeof *table);
    memset(second_bits, 0, first_size);
    /* Codes are read least significant bit first: tables are indexed by the
       bit-reversed code. First pass: how deep each second-level table goes. */
    for (symbol = 0; symbol < count; symbol++) {
        unsigned c, r = 0, i;
        len = lengths[symbol];
        if (len == 0) continue;
        c = next_code[len]++;
        for (i = 0; i < len; i++) r |= ((c >> i) & 1u) << (len - 1 - i);
        reversed[symbol] = r;
        if (len > first_bits) {
            unsigned prefix = r & (first_size - 1);
            if (len - first_bits > second_bits[prefix]) second_bits[prefix] = (unsigned char)(len - first_bits);
        }
    }
    for (code = 0; code < first_size; code++) {
        size_t size;
        if (!second_bits[code]) continue;
        size = (size_t)1 << second_bits[code];
        if (next_free + size > table_size) return 1; /* impossible for a complete code (see the sizes) */
        memset(table + next_free, 0, size * sizeof *table);
        table[code] = SQFFD_INFLATE__LINK | (uint32_t)next_free << 16 | (uint32_t)second_bits[code] << 4 | first_bits;
        next_free += size;
    }
    for (symbol = 0; symbol < count; symbol++) {
        uint32_t entry;
        unsigned r, step;
        len = lengths[symbol];
        if (len == 0) continue;
        entry = sqffd_inflate__symbol_entry(kind, symbol) | len;
        r = reversed[symbol];
        if (len <= first_bits) {
            for (step = 1u << len; r < first_size; r += step) table[r] = entry;
        } else {
            unsigned prefix = r & (first_size - 1), size = 1u << second_bits[prefix];
            uint32_t *second = table + (table[prefix] >> 16); /* the link's offset */
            step = 1u << (len - first_bits);
            for (r >>= first_bits; r < size; r += step) second[r] = entry;
        }
    }
    return 0;
}

/* The input as a bit stream, least significant bit first. */
typedef struct sqffd_inflate__bits {
    const unsigned char *next, *end;
    uint64_t buffer;   /* unread bits, the next one lowest; bits above `count` are 0 or the true next bits */
    unsigned count;    /* valid bits in buffer (<= 63) */
    unsigned overrun;  /* zero bytes added past the end of the input; their bits sit at the top */
} sqffd_inflate__bits;

static inline uint64_t sqffd_inflate__load64_le(const unsigned char *p)
{
    return (uint64_t)sqffd_gz__load32_le(p) | (uint64_t)sqffd_gz__load32_le(p + 4) << 32;
}

/* Tops the buffer up to at least 56 bits. Near the end of the input it goes
   byte by byte, then adds zero bytes; returns 1 once a bit past the end has
   been consumed (the input ended early), 0 otherwise. */
static inline int sqffd_inflate__refill(sqffd_inflate__bits *b)
{
    if (b->end - b->next >= 8) {
        /* load 8 bytes, keep the whole ones that fit, leave the rest for the next load */
        b->buffer |= sqffd_inflate__load64_le(b->next) << b->count;
        b->next += (63 - b->count) >> 3;
        b->count |= 56;
        return 0;
    }
    if (b->count < 8 * b->overrun) return 1;
    while (b->count < 56) {
        if (b->next < b->end) b->buffer |= (uint64_t)*b->next++ << b->count;
        else b->overrun++;
        b->count += 8;
    }
    return 0;
}

/* Takes n <= 32 bits; 1 if the input ended early. */
static inline int sqffd_inflate__take(sqffd_inflate__bits *b, unsigned n, unsigned *value)
{
    if (b->count < n && sqffd_inflate__refill(b)) return 1;
    *value = (unsigned)(b->buffer & (((uint64_t)1 << n) - 1));
    b->buffer >>= n;
    b->count -= n;
    return 0;
}

/* The output: a malloc'd buffer that keeps SQFFD_INFLATE__SLACK spare bytes
   past `size` while decoding. */
typedef struct sqffd_inflate__output {
    unsigned char *data;
    size_t size, capacity, limit; /* limit <= SIZE_MAX / 2 */
} sqffd_inflate__output;

/* Makes room for `need` more bytes plus the slack (need <= limit - size):
   doubles the capacity, at most to limit + slack. */
static inline int sqffd_inflate__grow(sqffd_inflate__output *o, size_t need)
{
    size_t want = o->size + need + SQFFD_INFLATE__SLACK, most = o->limit + SQFFD_INFLATE__SLACK, capacity;
    unsigned char *grown;
    if (o->capacity >= want) return 0;
    capacity = o->capacity > most / 2 ? most : 2 * o->capacity;
    if (capacity < want) capacity = want;
    if (capacity < 4096 && most >= 4096) capacity = 4096;
    if (capacity > most) capacity = most;
    grown = (unsigned char *)realloc(o->data, capacity);
    if (!grown) return 1;
    o->data = grown;
    o->capacity = capacity;
    return 0;
}

/* The entry for the code at the bottom of the bit buffer: the first-level
   one, or the second-level one its link leads to. */
static inline uint32_t sqffd_inflate__lookup(const uint32_t *table, uint64_t buffer, unsigned first_bits)
{
    uint32_t entry = table[buffer & ((1u << first_bits) - 1)];
    if (entry & SQFFD_INFLATE__LINK)
        entry = table[(entry >> 16) + ((buffer >> first_bits) & ((1u << ((entry >> 4) & 15)) - 1))];
    return entry;
}

/* Decodes the symbols of one Huffman block up to its end-of-block code. */
static inline int sqffd_inflate__huffman_block(sqffd_inflate__bits *bits, const sqffd_inflate__tables *t,
                                               sqffd_inflate__output *o, size_t stream_start)
{
    const uint32_t *litlen = t->litlen, *distance = t->distance;
    sqffd_inflate__bits b = *bits; /* a local copy the compiler keeps in registers */
    unsigned char *out = o->data;
    size_t pos = o->size, capacity = o->capacity, limit = o->limit;
    int status = SQFFD_INFLATE__OK;
    for (;;) {
        uint32_t entry;
        unsigned n, length, dist, literals;
        if (capacity - pos < SQFFD_INFLATE__SLACK) {
            o->size = pos;
            if (sqffd_inflate__grow(o, 0)) { status = SQFFD_INFLATE__NO_MEMORY; break; }
            out = o->data;
            capacity = o->capacity;
        }
        if (sqffd_inflate__refill(&b)) { status = SQFFD_INFLATE__TRUNCATED; break; }
        /* At least 56 bits now: up to three literals (15 bits each at most), or
           a length and a distance with their extra bits (15 + 5 + 15 + 13). */
        entry = sqffd_inflate__lookup(litlen, b.buffer, SQFFD_INFLATE__LITLEN_BITS);
        if (entry & SQFFD_INFLATE__LITERAL) {
            for (literals = 0;;) {
                if (pos >= limit) { status = SQFFD_INFLATE__TOO_LARGE; break; }
                n = entry & 15;
                b.buffer >>= n;
                b.count -= n;
                out[pos++] = (unsigned char)(entry >> 16);
                if (++literals == 3) break;
                entry = sqffd_inflate__lookup(litlen, b.buffer, SQFFD_INFLATE__LITLEN_BITS);
                if (!(entry & SQFFD_INFLATE__LITERAL)) break;
            }
            if (status) break;
            continue;
        }
        if (!(entry & SQFFD_INFLATE__MATCH)) {
            if (entry & SQFFD_INFLATE__END) {
                n = entry & 15;
                b.buffer >>= n;
                b.count -= n;
                break;
            }
            status = entry & SQFFD_INFLATE__RESERVED ? SQFFD_INFLATE__LITLEN_RESERVED : SQFFD_INFLATE__LITLEN_UNDEFINED;
            break;
        }
        n = entry & 15;
        length = (entry >> 16) + (unsigned)((b.buffer >> n) & ((1u << ((entry >> 4) & 15)) - 1));
        n += (entry >> 4) & 15;
        b.buffer >>= n;
        b.count -= n;

        entry = sqffd_inflate__lookup(distance, b.buffer, SQFFD_INFLATE__DIST_BITS);
        if (!(entry & SQFFD_INFLATE__MATCH)) {
            status = entry & SQFFD_INFLATE__RESERVED ? SQFFD_INFLATE__DIST_RESERVED : SQFFD_INFLATE__DIST_UNDEFINED;
            break;
        }
        n = entry & 15;
        dist = (entry >> 16) + (unsigned)((b.buffer >> n) & ((1u << ((entry >> 4) & 15)) - 1));
        n += (entry >> 4) & 15;
        b.buffer >>= n;
        b.count -= n;
        if (dist > pos - stream_start) { status = SQFFD_INFLATE__TOO_FAR_BACK; break; }
        if (length > limit - pos) { status = SQFFD_INFLATE__TOO_LARGE; break; }
        {
            unsigned char *to = out + pos, *stop = to + length;
            const unsigned char *from = to - dist;
            pos += length;
            if (dist < 8) {
                /* The match repeats its first `dist` bytes, so any multiple of dist is
                   as good a distance once that many bytes exist: write the first few
                   byte by byte, then copy from the multiple that is at least 8 back. */
                unsigned stride = dist * ((8 + dist - 1) / dist), head = stride - dist;
                if (dist == 1 && length >= 16) {
                    memset(to, *from, length);
                    to = stop;
                }
                for (; head > 0 && to < stop; head--) *to++ = *from++;
                if (to < stop) from = to - stride;
            }
            /* 8-byte pieces, each read at least 8 bytes behind where it is written,
               so every byte read is final; the last step may run up to 15 bytes
               past the match, into the slack, to be overwritten later. */
            while (to < stop) {
                memcpy(to, from, 8);
                memcpy(to + 8, from + 8, 8);
                to += 16;
                from += 16;
            }
        }
    }
    o->size = pos;
    *bits = b;
    return status;
}

/* Decodes one raw DEFLATE stream from `in`, appending to o; a match may not
   reach before o->size as it was on entry. *in_used: bytes consumed, up to
   the end of the final block (its last partial byte included); on failure,
   about where decoding stopped. */
static inline int sqffd_inflate__stream(sqffd_inflate__tables *t, const unsigned char *in, size_t in_size,
                                        size_t *in_used, sqffd_inflate__output *o)
{
    static const unsigned char codelen_order[19] = {16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15};
    static const unsigned char empty[1] = {0};
    sqffd_inflate__bits b;
    size_t stream_start = o->size, whole_bytes;
    unsigned final = 0, type;
    int status = SQFFD_INFLATE__OK;
    if (!in) in = empty; /* no arithmetic on a null pointer */
    b.next = in;
    b.end = in + in_size;
    b.buffer = 0;
    b.count = 0;
    b.overrun = 0;
    t->fixed = 0;
    while (!final && !status) {
        if (sqffd_inflate__take(&b, 1, &final) || sqffd_inflate__take(&b, 2, &type)) {
            status = SQFFD_INFLATE__TRUNCATED;
            break;
        }
        if (type == 0) { /* stored: LEN, NLEN from the next byte boundary, then LEN bytes */
            unsigned len, nlen;
            b.buffer >>= b.count & 7;
            b.count -= b.count & 7;
            if (sqffd_inflate__take(&b, 16, &len) || sqffd_inflate__take(&b, 16, &nlen)) {
                status = SQFFD_INFLATE__TRUNCATED;
                break;
            }
            if (len != (~nlen & 0xffffu)) { status = SQFFD_INFLATE__STORED_LENGTH; break; }
            if (b.count < 8 * b.overrun) { status = SQFFD_INFLATE__TRUNCATED; break; }
            /* hand the whole bytes still in the bit buffer back to the input */
            b.next -= b.count / 8 - b.overrun;
            b.buffer = 0;
            b.count = 0;
            b.overrun = 0;
            if (len > (size_t)(b.end - b.next)) { status = SQFFD_INFLATE__STORED_TRUNCATED; break; }
            if (len > o->limit - o->size) { status = SQFFD_INFLATE__TOO_LARGE; break; }
            if (sqffd_inflate__grow(o, len)) { status = SQFFD_INFLATE__NO_MEMORY; break; }
            if (len) memcpy(o->data + o->size, b.next, len);
            o->size += len;
            b.next += len;
            continue;
        }
        if (type == 3) { status = SQFFD_INFLATE__BLOCK_TYPE; break; }
        if (type == 1 && !t->fixed) { /* RFC 1951 3.2.6 */
            unsigned char lengths[288];
            memset(lengths, 8, 144);
            memset(lengths + 144, 9, 112);
            memset(lengths + 256, 7, 24);
            memset(lengths + 280, 8, 8);
            sqffd_inflate__build(t->litlen, SQFFD_INFLATE__LITLEN_SIZE, SQFFD_INFLATE__LITLEN_BITS, 0, lengths, 288, 0);
            memset(lengths, 5, 32);
            sqffd_inflate__build(t->distance, SQFFD_INFLATE__DIST_SIZE, SQFFD_INFLATE__DIST_BITS, 1, lengths, 32, 0);
            t->fixed = 1;
        } else if (type == 2) { /* dynamic: the code lengths, themselves Huffman-coded (RFC 1951 3.2.7) */
            unsigned char codelen_lengths[19], lengths[286 + 32];
            unsigned hlit, hdist, hclen, i, total, value;
            t->fixed = 0;
            if (sqffd_inflate__take(&b, 5, &hlit) || sqffd_inflate__take(&b, 5, &hdist) ||
                sqffd_inflate__take(&b, 4, &hclen)) {
                status = SQFFD_INFLATE__TRUNCATED;
                break;
            }
            hlit += 257;
            hdist += 1;
            hclen += 4;
            if (hlit > 286) { status = SQFFD_INFLATE__TOO_MANY_LITLEN; break; }
            memset(codelen_lengths, 0, sizeof codelen_lengths);
            for (i = 0; i < hclen && !status; i++) {
                if (sqffd_inflate__take(&b, 3, &value)) status = SQFFD_INFLATE__TRUNCATED;
                codelen_lengths[codelen_order[i]] = (unsigned char)value;
            }
            if (status) break;
            switch (sqffd_inflate__build(t->codelen, 1u << SQFFD_INFLATE__CODELEN_BITS, SQFFD_INFLATE__CODELEN_BITS, 2,
                                         codelen_lengths, 19, 0)) {
            case 1: status = SQFFD_INFLATE__CODELEN_OVER; break;
            case 2: status = SQFFD_INFLATE__CODELEN_INCOMPLETE; break;
            default: break;
            }
            if (status) break;
            total = hlit + hdist;
            for (i = 0; i < total;) {
                uint32_t entry;
                unsigned symbol, repeat, extra;
                unsigned char fill;
                if (b.count < 14 && sqffd_inflate__refill(&b)) { status = SQFFD_INFLATE__TRUNCATED; break; }
                /* the code is complete: every entry is a symbol */
                entry = sqffd_inflate__lookup(t->codelen, b.buffer, SQFFD_INFLATE__CODELEN_BITS);
                b.buffer >>= entry & 15;
                b.count -= entry & 15;
                symbol = entry >> 16;
                if (symbol < 16) {
                    lengths[i++] = (unsigned char)symbol;
                    continue;
                }
                extra = (entry >> 4) & 15;
                repeat = (unsigned)(b.buffer & ((1u << extra) - 1));
                b.buffer >>= extra;
                b.count -= extra;
                if (symbol == 16) {
                    if (i == 0) { status = SQFFD_INFLATE__REPEAT_NOTHING; break; }
                    fill = lengths[i - 1];
                    repeat += 3;
                } else {
                    fill = 0;
                    repeat += symbol == 17 ? 3 : 11;
                }
                if (repeat > total - i) { status = SQFFD_INFLATE__REPEAT_PAST_END; break; }
                memset(lengths + i, fill, repeat);
                i += repeat;
            }
            if (status) break;
            if (lengths[256] == 0) { status = SQFFD_INFLATE__NO_END_CODE; break; }
            switch (sqffd_inflate__build(t->litlen, SQFFD_INFLATE__LITLEN_SIZE, SQFFD_INFLATE__LITLEN_BITS, 0, lengths,
                                         hlit, 1)) {
            case 1: status = SQFFD_INFLATE__LITLEN_OVER; break;
            case 2: status = SQFFD_INFLATE__LITLEN_INCOMPLETE; break;
            default: break;
            }
            if (status) break;
            switch (sqffd_inflate__build(t->distance, SQFFD_INFLATE__DIST_SIZE, SQFFD_INFLATE__DIST_BITS, 1,
                                         lengths + hlit, hdist, 1)) {
            case 1: status = SQFFD_INFLATE__DIST_OVER; break;
            case 2: status = SQFFD_INFLATE__DIST_INCOMPLETE; break;
            default: break;
            }
            if (status) break;
        }
        status = sqffd_inflate__huffman_block(&b, t, o, stream_start);
    }
    /* Any error after a bit past the end was read is the input ending early. */
    if (b.count < 8 * b.overrun) status = SQFFD_INFLATE__TRUNCATED;
    whole_bytes = b.count / 8 > b.overrun ? b.count / 8 - b.overrun : 0;
    *in_used = (size_t)(b.next - in) - whole_bytes;
    return status;
}

/* Makes the decoder's state and an output of `limit` bytes at most, with
   room for size_hint bytes to start with. */
static inline sqffd_inflate__tables *sqffd_inflate__begin(sqffd_inflate__output *o, size_t max_output,
                                                           size_t size_hint)
{
    sqffd_inflate__tables *t = (sqffd_inflate__tables *)malloc(sizeof *t);
    o->data = NULL;
    o->size = 0;
    o->capacity = 0;
    o->limit = max_output == 0 || max_output > SIZE_MAX / 2 ? SIZE_MAX / 2 : max_output;
    if (!t) return NULL;
    if (size_hint > o->limit) size_hint = o->limit;
    if (sqffd_inflate__grow(o, size_hint)) {
        free(t);
        return NULL;
    }
    return t;
}

/* Hands the output over at its exact size (at least one byte allocated). */
static inline void sqffd_inflate__finish(sqffd_inflate__output *o, unsigned char **out, size_t *out_size)
{
    unsigned char *shrunk = (unsigned char *)realloc(o->data, o->size ? o->size : 1);
    *out = shrunk ? shrunk : o->data;
    *out_size = o->size;
}

/* Raw DEFLATE (RFC 1951): decodes the stream at in[0, in_size) up to the end
   of its final block. Returns 0 with *out (malloc'd, never NULL; free() it),
   *out_size and *in_used (bytes consumed, the final block's last partial
   byte included; what follows is the caller's, e.g. a trailer), or -1 with
   *out = NULL, *out_size = 0, *in_used = about where decoding stopped and
   *why = a static description ("distance too far back ..."). max_output as
   for sqffd_gz_decompress. why may be NULL. */
static inline int sqffd_inflate_raw(const unsigned char *in, size_t in_size, size_t *in_used, unsigned char **out,
                                    size_t *out_size, size_t max_output, const char **why)
{
    sqffd_inflate__output o;
    sqffd_inflate__tables *t = sqffd_inflate__begin(&o, max_output, in_size < SIZE_MAX / 8 ? 4 * in_size : 0);
    int status = t ? sqffd_inflate__stream(t, in, in_size, in_used, &o) : SQFFD_INFLATE__NO_MEMORY;
    free(t);
    *out = NULL;
    *out_size = 0;
    if (!t) *in_used = 0;
    if (status) {
        free(o.data);
        if (why) *why = sqffd_inflate__message(status);
        return -1;
    }
    sqffd_inflate__finish(&o, out, out_size);
    if (why) *why = NULL;
    return 0;
}

/* ---- gzip (RFC 1952) and zlib (RFC 1950) ---------------------------------- */

#if defined(__GNUC__)
static inline int sqffd_gz__fail(char *err, size_t err_size, const char *name, const char *label, const char *fmt, ...)
    __attribute__((format(printf, 5, 6)));
#endif
/* Writes "NAME: LABEL: message" into err; returns -1. */
static inline int sqffd_gz__fail(char *err, size_t err_size, const char *name, const char *label, const char *fmt, ...)
{
    va_list ap;
    size_t used;
    if (!err || err_size == 0) return -1;
    snprintf(err, err_size, "%s: %s: ", name ? name : "input", label);
    used = strlen(err);
    va_start(ap, fmt);
    vsnprintf(err + used, err_size - used, fmt, ap);
    va_end(ap);
    return -1;
}

/* 1 if the data starts with the gzip magic bytes 1f 8b. */
static inline int sqffd_gz_is_gzip(const void *data, size_t size)
{
    const unsigned char *b = (const unsigned char *)data;
    return size >= 2 && b[0] == 0x1f && b[1] == 0x8b;
}

/* Parses the gzip member header at in[pos]; *end: where its DEFLATE data
   starts. Messages "NAME: LABEL: WHERE...". */
static inline int sqffd_gz__header(const unsigned char *in, size_t size, size_t pos, size_t *end, const char *name,
                                   const char *label, const char *where, char *err, size_t err_size)
{
    /* FLG bits (FTEXT, 1, is a hint with nothing to check) */
    enum {
        SQFFD_GZ__FHCRC = 2,
        SQFFD_GZ__FEXTRA = 4,
        SQFFD_GZ__FNAME = 8,
        SQFFD_GZ__FCOMMENT = 16,
        SQFFD_GZ__RESERVED = 0xe0
    };
    const unsigned char *zero;
    size_t at = pos + 10;
    unsigned flags;
    if (size - pos < 10) return sqffd_gz__fail(err, err_size, name, label, "%sinput ends inside the header", where);
    if (in[pos + 2] != 8)
        return sqffd_gz__fail(err, err_size, name, label, "%scompression method %u; only 8 (deflate) exists", where,
                              in[pos + 2]);
    flags = in[pos + 3];
    if (flags & SQFFD_GZ__RESERVED)
        return sqffd_gz__fail(err, err_size, name, label, "%sreserved header flags set (FLG 0x%02x)", where, flags);
    if (flags & SQFFD_GZ__FEXTRA) {
        size_t extra;
        if (size - at < 2) return sqffd_gz__fail(err, err_size, name, label, "%sinput ends inside the header", where);
        extra = (size_t)in[at] | (size_t)in[at + 1] << 8;
        at += 2;
        if (size - at < extra)
            return sqffd_gz__fail(err, err_size, name, label,
                                  "%sinput ends inside the extra field (FEXTRA says %u bytes, %llu present)", where,
                                  (unsigned)extra, (unsigned long long)(size - at));
        at += extra;
    }
    if (flags & SQFFD_GZ__FNAME) {
        zero = at < size ? (const unsigned char *)memchr(in + at, 0, size - at) : NULL;
        if (!zero)
            return sqffd_gz__fail(err, err_size, name, label, "%sinput ends inside the file name (FNAME)", where);
        at = (size_t)(zero - in) + 1;
    }
    if (flags & SQFFD_GZ__FCOMMENT) {
        zero = at < size ? (const unsigned char *)memchr(in + at, 0, size - at) : NULL;
        if (!zero)
            return sqffd_gz__fail(err, err_size, name, label, "%sinput ends inside the comment (FCOMMENT)", where);
        at = (size_t)(zero - in) + 1;
    }
    if (flags & SQFFD_GZ__FHCRC) { /* the low 16 bits of the CRC-32 of the header before it */
        unsigned stored, computed;
        if (size - at < 2) return sqffd_gz__fail(err, err_size, name, label, "%sinput ends inside the header", where);
        stored = (unsigned)in[at] | (unsigned)in[at + 1] << 8;
        computed = (unsigned)(sqffd_gz_crc32(0, in + pos, at - pos) & 0xffff);
        if (stored != computed)
            return sqffd_gz__fail(err, err_size, name, label, "%sheader CRC (FHCRC) is 0x%04x, the header gives 0x%04x",
                                  where, stored, computed);
        at += 2;
    }
    *end = at;
    return 0;
}

/* sqffd_gz_decompress with messages "NAME: LABEL: ..." (sqffd_io.h passes its own label). */
static inline int sqffd_gz__decompress(const void *data, size_t size, const char *name, const char *label,
                                       size_t max_output, unsigned char **out, size_t *out_size, char *err,
                                       size_t err_size)
{
    const unsigned char *in = (const unsigned char *)data;
    sqffd_inflate__output o;
    sqffd_inflate__tables *t;
    size_t pos = 0, hint = 0;
    unsigned member = 0;
    char where[32] = "";
    int r = -1;
    *out = NULL;
    *out_size = 0;
    if (size == 0) return sqffd_gz__fail(err, err_size, name, label, "no data");
    if (!sqffd_gz_is_gzip(data, size)) {
        if (size == 1 && in[0] == 0x1f)
            return sqffd_gz__fail(err, err_size, name, label, "input ends inside the header");
        return sqffd_gz__fail(err, err_size, name, label, "not gzip data (no 1f 8b at the start)");
    }
    /* The last member's ISIZE sizes the output, if the compressed size makes it
       possible (DEFLATE expands at most 1032 times): a hint, never trusted. */
    if (size >= 18) {
        hint = sqffd_gz__load32_le(in + size - 4);
        if (hint / 1032 > size) hint = 0;
    }
    t = sqffd_inflate__begin(&o, max_output, hint);
    if (!t) {
        free(o.data);
        return sqffd_gz__fail(err, err_size, name, label, "out of memory");
    }
    for (;;) {
        size_t start = o.size, used, at = pos;
        uint32_t crc, stored_crc, stored_size;
        int status;
        member++;
        if (member > 1) snprintf(where, sizeof where, "member %u: ", member);
        if (sqffd_gz__header(in, size, pos, &at, name, label, where, err, err_size)) break;
        status = sqffd_inflate__stream(t, in + at, size - at, &used, &o);
        if (status == SQFFD_INFLATE__TOO_LARGE) {
            sqffd_gz__fail(err, err_size, name, label, "decompressed data larger than the limit of %llu bytes",
                           (unsigned long long)o.limit);
            break;
        }
        if (status) {
            sqffd_gz__fail(err, err_size, name, label, "%s%s (at byte %llu)", where, sqffd_inflate__message(status),
                           (unsigned long long)(at + used));
            break;
        }
        pos = at + used;
        if (size - pos < 8) {
            sqffd_gz__fail(err, err_size, name, label, "%sinput ends inside the trailer (CRC-32 and ISIZE)", where);
            break;
        }
        crc = sqffd_gz_crc32(0, o.data + start, o.size - start);
        stored_crc = sqffd_gz__load32_le(in + pos);
        stored_size = sqffd_gz__load32_le(in + pos + 4);
        if (crc != stored_crc) {
            sqffd_gz__fail(err, err_size, name, label,
                           "%sCRC-32 mismatch: the trailer says 0x%08lx, the data gives 0x%08lx", where,
                           (unsigned long)stored_crc, (unsigned long)crc);
            break;
        }
        if ((uint32_t)(o.size - start) != stored_size) {
            sqffd_gz__fail(err, err_size, name, label,
                           "%sISIZE mismatch: the trailer says %lu bytes (mod 2^32), the data is %llu bytes", where,
                           (unsigned long)stored_size, (unsigned long long)(o.size - start));
            break;
        }
        pos += 8;
        if (sqffd_gz_is_gzip(in + pos, size - pos)) continue;
        for (at = pos; at < size && in[at] == 0;) at++; /* zero padding (tape blocks) is fine */
        if (at < size) {
            sqffd_gz__fail(err, err_size, name, label, "%llu bytes of trailing garbage after member %u (at byte %llu)",
                           (unsigned long long)(size - pos), member, (unsigned long long)pos);
            break;
        }
        r = 0;
        break;
    }
    free(t);
    if (r) {
        free(o.data);
        return -1;
    }
    sqffd_inflate__finish(&o, out, out_size);
    return 0;
}

/* A whole gzip file (every member, in sequence) into a malloc'd buffer.
   max_output bounds the output (0: no bound beyond SIZE_MAX / 2). Returns 0,
   or -1 with "NAME: gzip: what is wrong" in err (see the top of the file). */
static inline int sqffd_gz_decompress(const void *data, size_t size, const char *name, size_t max_output,
                                      unsigned char **out, size_t *out_size, char *err, size_t err_size)
{
    return sqffd_gz__decompress(data, size, name, "gzip", max_output, out, out_size, err, err_size);
}

/* One zlib stream (RFC 1950: 2-byte header, DEFLATE data, Adler-32), e.g.
   MetaImage CompressedData; nothing may follow it. Same conventions as
   sqffd_gz_decompress, messages "NAME: zlib: what is wrong". */
static inline int sqffd_gz_zlib_decompress(const void *data, size_t size, const char *name, size_t max_output,
                                           unsigned char **out, size_t *out_size, char *err, size_t err_size)
{
    const unsigned char *in = (const unsigned char *)data;
    sqffd_inflate__output o;
    sqffd_inflate__tables *t;
    size_t used, pos;
    uint32_t adler, stored;
    int status;
    *out = NULL;
    *out_size = 0;
    if (size < 2) return sqffd_gz__fail(err, err_size, name, "zlib", size ? "input ends inside the header" : "no data");
    if ((in[0] & 15) != 8)
        return sqffd_gz__fail(err, err_size, name, "zlib", "compression method %u; only 8 (deflate) is defined",
                              (unsigned)(in[0] & 15));
    if ((in[0] >> 4) > 7)
        return sqffd_gz__fail(err, err_size, name, "zlib", "window size 2^%u is larger than 32 KiB (CINFO %u)",
                              (unsigned)(in[0] >> 4) + 8, (unsigned)(in[0] >> 4));
    if (((unsigned)in[0] << 8 | in[1]) % 31 != 0)
        return sqffd_gz__fail(err, err_size, name, "zlib",
                              "header check failed (CMF*256 + FLG is not a multiple of 31)");
    if (in[1] & 0x20)
        return sqffd_gz__fail(err, err_size, name, "zlib", "needs a preset dictionary (FDICT), which is not supported");
    t = sqffd_inflate__begin(&o, max_output, size < SIZE_MAX / 8 ? 4 * size : 0);
    if (!t) {
        free(o.data);
        return sqffd_gz__fail(err, err_size, name, "zlib", "out of memory");
    }
    status = sqffd_inflate__stream(t, in + 2, size - 2, &used, &o);
    free(t);
    if (status) {
        free(o.data);
        if (status == SQFFD_INFLATE__TOO_LARGE)
            return sqffd_gz__fail(err, err_size, name, "zlib", "decompressed data larger than the limit of %llu bytes",
                                  (unsigned long long)o.limit);
        return sqffd_gz__fail(err, err_size, name, "zlib", "%s (at byte %llu)", sqffd_inflate__message(status),
                              (unsigned long long)(2 + used));
    }
    pos = 2 + used;
    if (size - pos < 4) {
        free(o.data);
        return sqffd_gz__fail(err, err_size, name, "zlib", "input ends inside the Adler-32 trailer");
    }
    adler = sqffd_gz_adler32(1, o.data, o.size);
    stored = (uint32_t)in[pos] << 24 | (uint32_t)in[pos + 1] << 16 | (uint32_t)in[pos + 2] << 8 | in[pos + 3];
    if (adler != stored) {
        free(o.data);
        return sqffd_gz__fail(err, err_size, name, "zlib",
                              "Adler-32 mismatch: the trailer says 0x%08lx, the data gives 0x%08lx",
                              (unsigned long)stored, (unsigned long)adler);
    }
    if (size - pos > 4) {
        free(o.data);
        return sqffd_gz__fail(err, err_size, name, "zlib", "%llu bytes after the end of the stream",
                              (unsigned long long)(size - pos - 4));
    }
    sqffd_inflate__finish(&o, out, out_size);
    return 0;
}

#endif

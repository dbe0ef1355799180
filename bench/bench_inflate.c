/* Inflate bench: gzip decompression throughput (MB of output per second,
   median of repeated runs; each run allocates and frees its output, CRC-32
   checked) of examples/sqffd_inflate.h on the real NIfTI files in
   tests/data, side by side with zlib when built with -DSQFFD_BENCH_ZLIB
   (link -lz). With zlib, also an 8 MB synthetic volume (a smooth ellipsoid
   on a zero background, with noise) that zlib compresses here at levels 1,
   6 and 9, and the checksums. Target: at least 0.5x zlib's throughput. */
#include "bench.h"
#include "../examples/sqffd_inflate.h"
#include <math.h>
#include <stdio.h>
#include <string.h>
#ifdef SQFFD_BENCH_ZLIB
#include <zlib.h>
#endif

#define RUNS 15

static void *xmalloc(size_t bytes)
{
    void *p = malloc(bytes ? bytes : 1);
    if (!p) { fprintf(stderr, "out of memory\n"); exit(1); }
    return p;
}

static unsigned char *load(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    unsigned char *data;
    long len;
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    len = ftell(f);
    fseek(f, 0, SEEK_SET);
    data = (unsigned char *)xmalloc(len > 0 ? (size_t)len : 1);
    *size = fread(data, 1, len > 0 ? (size_t)len : 0, f);
    fclose(f);
    return data;
}

/* Seconds of one sqffd_gz_decompress; the output is checked against want. */
static double time_ours(const unsigned char *gz, size_t size, const unsigned char *want, size_t want_size)
{
    unsigned char *out;
    size_t out_size;
    char err[256];
    double t0 = bench_now(), t;
    if (sqffd_gz_decompress(gz, size, "bench", 0, &out, &out_size, err, sizeof err)) {
        printf("%s\n", err);
        exit(1);
    }
    t = bench_now() - t0;
    if (want && (out_size != want_size || memcmp(out, want, want_size) != 0)) {
        printf("bench: output differs from the reference\n");
        exit(1);
    }
    free(out);
    return t;
}

#ifdef SQFFD_BENCH_ZLIB
/* Seconds of zlib's inflate of the same gzip file (CRC-32 checked by zlib),
   into a buffer of the known size allocated in the timing, as ours is. */
static double time_zlib(const unsigned char *gz, size_t size, size_t out_size)
{
    z_stream s;
    unsigned char *out;
    double t0 = bench_now(), t;
    int r;
    out = (unsigned char *)xmalloc(out_size + 1);
    memset(&s, 0, sizeof s);
    if (inflateInit2(&s, 15 + 16) != Z_OK) { printf("inflateInit2 failed\n"); exit(1); }
    s.next_in = (Bytef *)(uintptr_t)gz;
    s.avail_in = (uInt)size;
    s.next_out = out;
    s.avail_out = (uInt)(out_size + 1);
    r = inflate(&s, Z_FINISH);
    inflateEnd(&s);
    t = bench_now() - t0;
    if (r != Z_STREAM_END || s.total_out != out_size) { printf("zlib inflate failed (%d)\n", r); exit(1); }
    free(out);
    return t;
}

/* gzip-compresses data with zlib at `level`; malloc'd. */
static unsigned char *zlib_gzip(const unsigned char *data, size_t size, int level, size_t *gz_size)
{
    z_stream s;
    size_t bound;
    unsigned char *gz;
    memset(&s, 0, sizeof s);
    if (deflateInit2(&s, level, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) exit(1);
    bound = deflateBound(&s, (uLong)size);
    gz = (unsigned char *)xmalloc(bound);
    s.next_in = (Bytef *)(uintptr_t)data;
    s.avail_in = (uInt)size;
    s.next_out = gz;
    s.avail_out = (uInt)bound;
    if (deflate(&s, Z_FINISH) != Z_STREAM_END) { printf("zlib deflate failed\n"); exit(1); }
    *gz_size = s.total_out;
    deflateEnd(&s);
    return gz;
}
#endif

/* One row: ours and (with zlib) zlib's medians, alternating runs so the VM's
   drifts hit both alike. Returns ours / zlib (0 without zlib). */
static double bench_row(const char *name, const unsigned char *gz, size_t size, const unsigned char *want,
                        size_t want_size)
{
    double ours[RUNS], peer[RUNS], mb = (double)want_size / 1e6, o;
    int r;
    time_ours(gz, size, want, want_size); /* warm-up, and the output checked once */
    for (r = 0; r < RUNS; r++) {
        ours[r] = time_ours(gz, size, NULL, 0);
#ifdef SQFFD_BENCH_ZLIB
        peer[r] = time_zlib(gz, size, want_size);
#else
        peer[r] = 0.0;
#endif
    }
    o = bench_median(ours, RUNS);
    printf("%-44s %8.2f %7.2f %9.0f", name, (double)size / 1e6, mb, mb / o);
#ifdef SQFFD_BENCH_ZLIB
    {
        double p = bench_median(peer, RUNS);
        printf(" %9.0f %8.2f\n", mb / p, p / o);
        return p / o;
    }
#else
    (void)peer;
    printf("\n");
    return 0.0;
#endif
}

/* The decompressed bytes of a gzip file (the reference the rows check). */
static unsigned char *reference(const unsigned char *gz, size_t size, size_t *out_size)
{
    unsigned char *out;
    char err[256];
    if (sqffd_gz_decompress(gz, size, "bench", 0, &out, out_size, err, sizeof err)) {
        printf("%s\n", err);
        exit(1);
    }
    return out;
}

int main(void)
{
    static const char *const files[] = {"tests/data/KmeansTest_T1UCharRaw.nii.gz", "tests/data/example4d.nii.gz"};
    double worst = 1e9;
    size_t k;
    printf("== inflate (gzip, CRC-32 checked; MB/s of output, median of %d runs)\n", RUNS);
    printf("%-44s %8s %7s %9s %9s %8s\n", "input", "in MB", "out MB", "sqffd", "zlib", "ratio");
    for (k = 0; k < sizeof files / sizeof files[0]; k++) {
        size_t size, want_size;
        unsigned char *gz = load(files[k], &size), *want;
        if (!gz) { printf("%-44s (missing: run from the repository root)\n", files[k]); continue; }
        want = reference(gz, size, &want_size);
        {
            double ratio = bench_row(files[k] + strlen("tests/data/"), gz, size, want, want_size);
            if (ratio > 0.0 && ratio < worst) worst = ratio;
        }
        free(gz);
        free(want);
    }
#ifdef SQFFD_BENCH_ZLIB
    {
        /* 256 x 256 x 128 voxels: an ellipsoid of smooth values plus 2 bits of noise, zero outside */
        enum { NX = 256, NY = 256, NZ = 128 };
        size_t n = (size_t)NX * NY * NZ, i, gz_size;
        unsigned char *volume = (unsigned char *)xmalloc(n);
        uint32_t x = 2463534242u;
        int level;
        double ours[RUNS], peer[RUNS];
        for (i = 0; i < n; i++) {
            int vx = (int)(i % NX), vy = (int)(i / NX % NY), vz = (int)(i / ((size_t)NX * NY));
            double dx = (vx - 128) / 110.0, dy = (vy - 128) / 90.0, dz = (vz - 64) / 60.0;
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            if (dx * dx + dy * dy + dz * dz > 1.0) volume[i] = 0;
            else volume[i] = (unsigned char)(120 + 50 * sin(vx * 0.05) * cos(vy * 0.07) + 30 * sin(vz * 0.09) + (x & 3));
        }
        for (level = 1; level <= 9; level += level == 1 ? 5 : 3) {
            unsigned char *gz = zlib_gzip(volume, n, level, &gz_size);
            char name[64];
            double ratio;
            snprintf(name, sizeof name, "synthetic volume 8 MB, zlib level %d", level);
            ratio = bench_row(name, gz, gz_size, volume, n);
            if (ratio < worst) worst = ratio;
            free(gz);
        }
        /* the checksums alone, over the volume */
        for (i = 0; i < RUNS; i++) {
            double t0 = bench_now();
            volatile uint32_t c = sqffd_gz_crc32(0, volume, n);
            ours[i] = bench_now() - t0;
            t0 = bench_now();
            c = (uint32_t)crc32(0L, volume, (uInt)n);
            peer[i] = bench_now() - t0;
            (void)c;
        }
        printf("%-44s %8s %7.2f %9.0f %9.0f %8.2f\n", "CRC-32 alone", "-", (double)n / 1e6,
               (double)n / 1e6 / bench_median(ours, RUNS), (double)n / 1e6 / bench_median(peer, RUNS),
               bench_median(peer, RUNS) / bench_median(ours, RUNS));
        for (i = 0; i < RUNS; i++) {
            double t0 = bench_now();
            volatile uint32_t c = sqffd_gz_adler32(1, volume, n);
            ours[i] = bench_now() - t0;
            t0 = bench_now();
            c = (uint32_t)adler32(1L, volume, (uInt)n);
            peer[i] = bench_now() - t0;
            (void)c;
        }
        printf("%-44s %8s %7.2f %9.0f %9.0f %8.2f\n", "Adler-32 alone", "-", (double)n / 1e6,
               (double)n / 1e6 / bench_median(ours, RUNS), (double)n / 1e6 / bench_median(peer, RUNS),
               bench_median(peer, RUNS) / bench_median(ours, RUNS));
        free(volume);
    }
    printf("target (sqffd at least 0.5x zlib on every row): worst %.2fx: %s\n", worst, worst >= 0.5 ? "met" : "MISSED");
#else
    (void)worst;
    printf("zlib: not installed (build with -DSQFFD_BENCH_ZLIB and -lz): peer column and synthetic volume skipped\n");
#endif
    return 0;
}

/* stream_fit.c - fit and track a stream of point frames in fixed memory: the
   pattern for scanner-side code (firmware, acquisition software).

   The frames come from the point files named on the command line, in order,
   standing in for a sensor. Frame 0 gets the whole fit (sqffd_fit); every
   later frame keeps that superquadric, box and lattice and runs the FFD stage
   from the previous frame's control points against a system prepared once
   (sqffd_ffd_system_init, then sqffd_track_frame per frame): what
   sqffd_track makes of a sequence, to the bit, with its default options
   (100 iterations for the first fit, up to 100 for each later frame, to the
   tolerance), but one frame at a time, as they arrive, instead of over a
   sequence held in memory.

   MEMORY: everything the library needs comes out of ONE static block,
   carved once at start-up:
       points     capacity x 3 doubles: the frame being fitted (where a
                  sensor driver would DMA its points)
       system     the prepared FFD system (sqffd_ffd_system_size): lives
                  from the first model to the end of the stream
       scratch    sqffd_fit's workspace on the first frame, sqffd_track_frame's
                  on the later ones: never both at once, so they share one
                  region, the larger of the two sizes
       timings    the last STREAM_TIMINGS tracked frames' times (the median)
   The block is a static array, as firmware would have it: its size is fixed
   at link time and shows in the map file, there is no heap to run out of or
   fragment on a long-running device, and nothing can fail to allocate in the
   middle of an acquisition. Its size is a compile-time constant
   (STREAM_ARENA_BYTES), while the sizes the library asks for are computed at
   run time (they depend on the capacity, lattice, grid and options): so
   start-up computes them for the worst case, the capacity, and refuses to
   start when the block is too small (exit 2, with the size to rebuild with),
   rather than fail on some frame later. The sizes grow with the point count,
   so the capacity's sizes cover every smaller frame; were one short, the
   library would answer WORKSPACE_TOO_SMALL (that frame skipped), never write
   past the block. The fixed-size structs (two models, the report, the
   system's handle: 27 KB) are plain statics too. After start-up the frame
   path allocates nothing, with one exception: the file reader
   (examples/sqffd_io.h, the stand-in for the sensor) mallocs each file's
   points, which are copied (or subsampled) into the points buffer and freed
   at once; a real driver would DMA straight into the points buffer.

   A FRAME WITH MORE POINTS than the capacity is subsampled evenly into the
   buffer (sqffd_points_subsample), and its line says so: a stream must not
   stop because the scene filled the view. A FRAME THAT FAILS (unreadable
   file, NaN or absurd coordinates, too few points, any error of the fit)
   is reported on its line and skipped: the previous model stays
   the current one and the next frame is tracked from it (before any model
   exists, the next good frame gets the whole fit). One bad frame must not
   kill a streaming loop; the exit status still tells that some frame failed.

   Output: a line per frame (index, points, ms, FFD iterations, the relative
   RMS error of the report, in percent of the frame's bounding-box diagonal),
   then a summary. ms is the fitting alone (reading the file is not counted);
   the first frame's includes preparing the system.

   Build: cc -O2 -std=c99 stream_fit.c -lm        (make: build/stream_fit)
   Usage: stream_fit [--max-points N] FRAME...
   Exit status: 0 every frame fitted, 1 some frame failed, 2 usage or a
   capacity the static block cannot hold. */
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include "sqffd_io.h"

#ifndef STREAM_ARENA_BYTES
#define STREAM_ARENA_BYTES (8u << 20) /* 8 MiB: the default 20,000 points need 6.7 MB */
#endif
#define STREAM_DEFAULT_MAX_POINTS 20000
#define STREAM_TIMINGS 4096 /* tracked frames whose times the median is taken over (the last ones) */
#define STREAM_ALIGN 64     /* each region starts on a cache line (the library takes any alignment) */

/* The one block (the union aligns its start for the doubles carved from it). */
static union {
    unsigned char bytes[STREAM_ARENA_BYTES];
    double align_double;
    void *align_pointer;
} arena;

/* The fixed-size state: plain structs, no sizes to compute. */
static sqffd_model model;        /* the current model: the last frame that fitted */
static sqffd_model trial;        /* the frame being fitted: becomes `model` only on success */
static sqffd_fit_report report;
static sqffd_ffd_system system_; /* a handle; its memory is the block's system region */

typedef struct stream_memory {
    double *points;                  /* capacity x 3 */
    void *system;                    /* system_size bytes */
    void *scratch;                   /* scratch_size = max(fit_size, frame_size) */
    double *timings;                 /* STREAM_TIMINGS */
    size_t capacity, system_size, fit_size, frame_size, scratch_size, used;
} stream_memory;

/* Takes `size` bytes at the next aligned offset of the block; NULL when they
   do not fit (*offset then past the block: the total still comes out,
   saturated at SIZE_MAX). */
static void *carve(size_t *offset, size_t size)
{
    size_t at;
    if (*offset > (size_t)-1 - (STREAM_ALIGN - 1)) return NULL;
    at = (*offset + STREAM_ALIGN - 1) / STREAM_ALIGN * STREAM_ALIGN;
    *offset = size > (size_t)-1 - at ? (size_t)-1 : at + size;
    return size <= sizeof arena.bytes && at <= sizeof arena.bytes - size ? arena.bytes + at : NULL;
}

/* Start-up: the worst-case sizes for `capacity` points, and the block carved.
   Returns 0, or 1 with a message in err. */
static int stream_setup(stream_memory *m, size_t capacity, const sqffd_track_options *track, char *err,
                        size_t err_size)
{
    sqffd_superquadric sphere;
    size_t offset = 0;
    sqffd_result r;
    memset(m, 0, sizeof *m);
    m->capacity = capacity;
    /* The prepared system's size depends only on the lattice and the grid: a
       model around any superquadric gives it (a unit sphere here). */
    memset(&sphere, 0, sizeof sphere);
    sphere.size[0] = sphere.size[1] = sphere.size[2] = 1.0;
    sphere.shape[0] = sphere.shape[1] = 1.0;
    sphere.rotation[0] = sphere.rotation[4] = sphere.rotation[8] = 1.0;
    r = sqffd_model_init(&trial, &sphere, &track->fit);
    if (r == SQFFD_OK) r = sqffd_ffd_system_size(&trial, &m->system_size);
    if (r == SQFFD_OK) r = sqffd_fit_workspace_size(capacity, &track->fit, &m->fit_size);
    if (r == SQFFD_OK) r = sqffd_track_frame_workspace_size(capacity, track, &m->frame_size);
    if (r != SQFFD_OK) {
        snprintf(err, err_size, "sizes for %zu points: %s", capacity, sqffd_result_string(r));
        return 1;
    }
    if (capacity > (size_t)-1 / (3 * sizeof(double))) {
        snprintf(err, err_size, "%zu points: beyond a size_t", capacity);
        return 1;
    }
    m->points = (double *)carve(&offset, capacity * 3 * sizeof(double));
    m->system = carve(&offset, m->system_size);
    m->scratch_size = m->fit_size > m->frame_size ? m->fit_size : m->frame_size;
    m->scratch = carve(&offset, m->scratch_size);
    m->timings = (double *)carve(&offset, STREAM_TIMINGS * sizeof(double));
    m->used = offset;
    if (!m->points || !m->system || !m->scratch || !m->timings) {
        snprintf(err, err_size,
                 "%zu points a frame need %zu bytes, the static buffer has %zu: "
                 "lower --max-points or rebuild with -DSTREAM_ARENA_BYTES=%zu",
                 capacity, offset, sizeof arena.bytes, offset);
        return 1;
    }
    return 0;
}

/* The stand-in for the sensor driver: the points of `path` into the points
   buffer, evenly subsampled to the capacity when there are more. *raw: the
   count in the file. Returns 0, or 1 with a message in err. sqffd_io's reader
   mallocs the file's points (freed here); a real driver would DMA into
   m->points and need no copy. */
static int stream_receive(const stream_memory *m, const char *path, size_t *n, size_t *raw, char *err, size_t err_size)
{
    double *points;
    sqffd_result r;
    *n = *raw = 0;
    if (sqffd_io_read_file(path, &points, raw, err, err_size)) return 1;
    *n = *raw < m->capacity ? *raw : m->capacity;
    r = sqffd_points_subsample(points, *raw, *n, m->points); /* n == raw: a plain copy */
    free(points);
    if (r != SQFFD_OK) {
        snprintf(err, err_size, "%s: subsample: %s", path, sqffd_result_string(r));
        return 1;
    }
    return 0;
}

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

/* The median of v[0 .. n) (sorted in place: insertion sort, no allocation). */
static double median(double *v, size_t n)
{
    size_t i, j;
    for (i = 1; i < n; i++) {
        double x = v[i];
        for (j = i; j > 0 && v[j - 1] > x; j--) v[j] = v[j - 1];
        v[j] = x;
    }
    return n == 0 ? 0.0 : n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static int usage(FILE *f)
{
    fprintf(f, "usage: stream_fit [--max-points N] FRAME...\n"
               "fit the first frame, track each later one from the previous, in one static buffer\n"
               "  --max-points N   points a frame at most (default %d; more are subsampled evenly)\n",
            STREAM_DEFAULT_MAX_POINTS);
    return 2;
}

int main(int argc, char **argv)
{
    sqffd_track_options track = sqffd_track_options_default(); /* sqffd_track's defaults: 100 iterations
                                                                  for the first fit, up to 100 a later frame */
    stream_memory mem;
    char err[512];
    size_t capacity = STREAM_DEFAULT_MAX_POINTS, frames = 0, fitted = 0, failed = 0, timed = 0;
    size_t model_frame = 0, first_frame = 0;
    double first_ms = 0.0;
    int i, first_file = argc, have_model = 0;

    for (i = 1; i < argc; i++) {
        if (strcmp(argv[i], "-h") == 0 || strcmp(argv[i], "--help") == 0) {
            usage(stdout);
            return 0;
        } else if (strcmp(argv[i], "--max-points") == 0) {
            char *end;
            unsigned long long v;
            if (i + 1 >= argc) return usage(stderr);
            v = strtoull(argv[++i], &end, 10);
            if (argv[i][0] < '0' || argv[i][0] > '9' || *end || v < SQFFD_SQ_FIT_MIN_POINTS || v > 100000000ull) {
                fprintf(stderr, "stream_fit: --max-points: '%s' is not a count from %d to 100000000\n", argv[i],
                        SQFFD_SQ_FIT_MIN_POINTS);
                return 2;
            }
            capacity = (size_t)v;
        } else if (strcmp(argv[i], "--") == 0) {
            first_file = i + 1;
            break;
        } else if (argv[i][0] == '-' && argv[i][1]) {
            fprintf(stderr, "stream_fit: unknown option '%s'\n", argv[i]);
            return usage(stderr);
        } else {
            first_file = i;
            break;
        }
    }
    if (first_file >= argc) return usage(stderr);

    /* ---- start-up: the sizes, the block carved; no allocation after this ---- */
    if (stream_setup(&mem, capacity, &track, err, sizeof err)) {
        fprintf(stderr, "stream_fit: %s\n", err);
        return 2;
    }
    printf("stream_fit: up to %zu points a frame; one static buffer of %zu bytes, %zu used: points %zu, "
           "system %zu, scratch %zu (first fit %zu, tracking %zu), timings %zu\n",
           capacity, sizeof arena.bytes, mem.used, capacity * 3 * sizeof(double), mem.system_size,
           mem.scratch_size, mem.fit_size, mem.frame_size, STREAM_TIMINGS * sizeof(double));
    printf("frame  points        ms  iter   error %%\n");
    fflush(stdout);

    /* ---- the frame loop ---- */
    for (i = first_file; i < argc; i++, frames++) {
        size_t n, raw;
        double t0, ms;
        sqffd_result r = SQFFD_OK;
        int ok = 0;
        if (stream_receive(&mem, argv[i], &n, &raw, err, sizeof err)) {
            printf("%5zu  failed: %s", frames, err);
        } else {
            t0 = now_ms();
            if (!have_model) {
                /* the whole fit, then the system every later frame runs against */
                r = sqffd_fit(mem.points, n, &track.fit, &trial, &report, mem.scratch, mem.scratch_size);
                if (r == SQFFD_OK)
                    r = sqffd_ffd_system_init(&system_, &trial, &track.fit, mem.system, mem.system_size);
            } else {
                /* the FFD stage from the previous frame's control points; after a
                   failure `trial` may hold a half-way model, `model` is untouched */
                trial = model;
                r = sqffd_track_frame(&system_, mem.points, n, &track, &trial, &report, mem.scratch,
                                      mem.scratch_size);
            }
            ms = now_ms() - t0;
            if (r == SQFFD_OK) {
                ok = 1;
                printf("%5zu  %6zu  %8.2f  %4d  %8.4f", frames, n, ms, report.iterations,
                       100.0 * report.error.rms_relative);
                if (n < raw) printf("  subsampled from %zu", raw);
                if (!have_model) {
                    first_ms = ms;
                    first_frame = frames;
                } else {
                    mem.timings[timed++ % STREAM_TIMINGS] = ms;
                }
                model = trial;
                model_frame = frames;
                have_model = 1;
                fitted++;
            } else {
                printf("%5zu  failed: %s: %s (%zu points)", frames, argv[i], sqffd_result_string(r), n);
            }
        }
        if (!ok) {
            failed++;
            if (have_model) printf("; frame skipped, the model of frame %zu kept", model_frame);
            else printf("; frame skipped, no model yet");
        }
        printf("\n");
        fflush(stdout); /* a live log, line by line */
    }

    printf("summary: %zu frames, %zu fitted, %zu failed", frames, fitted, failed);
    if (fitted > 0) printf("; first fit (frame %zu) %.2f ms", first_frame, first_ms);
    if (timed > 0) { /* over the last STREAM_TIMINGS of them */
        size_t kept = timed < STREAM_TIMINGS ? timed : STREAM_TIMINGS;
        printf("; tracked frames median %.2f ms (%zu", median(mem.timings, kept), timed);
        if (kept < timed) printf(", the last %zu", kept);
        printf(")");
    }
    printf("; buffer %zu bytes (%zu used)\n", sizeof arena.bytes, mem.used);
    return failed ? 1 : 0;
}

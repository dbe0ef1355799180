/* sqffd.h - superquadric + free-form deformation shape fitting - v0.1.0
   Single-header C library, public domain or MIT (see end of file).

   DOCUMENTATION BLOCK: filled in at integration (see dev/README.md).
*/
#ifndef SQFFD_H
#define SQFFD_H

#include <stddef.h>
#include <stdint.h>

#define SQFFD_VERSION_MAJOR 0
#define SQFFD_VERSION_MINOR 1
#define SQFFD_VERSION_PATCH 0
#define SQFFD_VERSION_STRING "0.1.0"

#ifndef SQFFD_DEF
#ifdef SQFFD_STATIC
#define SQFFD_DEF static
#else
#define SQFFD_DEF extern
#endif
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* ======================================================================
   Common: result codes, progress callback
   ====================================================================== */

/* One list generates the enum and the strings. */
#define SQFFD_RESULT_LIST(X)                                                          \
    X(SQFFD_OK, "success")                                                            \
    X(SQFFD_ERROR_INVALID_ARGUMENT, "invalid argument: null pointer, size out of range or bad option") \
    X(SQFFD_ERROR_NON_FINITE, "input contains NaN or infinity")                      \
    X(SQFFD_ERROR_TOO_FEW_POINTS, "too few points for this operation")               \
    X(SQFFD_ERROR_DEGENERATE, "degenerate input: points coincident, collinear or coplanar") \
    X(SQFFD_ERROR_TOO_LARGE, "size beyond what the library can index or a size_t can hold") \
    X(SQFFD_ERROR_WORKSPACE_TOO_SMALL, "workspace smaller than the matching _workspace_size()") \
    X(SQFFD_ERROR_NOT_POSITIVE_DEFINITE, "matrix is not symmetric positive definite") \
    X(SQFFD_ERROR_NO_CONVERGENCE, "iteration did not converge within its limit")     \
    X(SQFFD_ERROR_CANCELLED, "cancelled by the progress callback")

typedef enum sqffd_result {
#define SQFFD__RESULT_ENUM(name, text) name,
    SQFFD_RESULT_LIST(SQFFD__RESULT_ENUM)
#undef SQFFD__RESULT_ENUM
    SQFFD_RESULT_COUNT
} sqffd_result;

/* Human-readable description of a result code; never NULL. */
SQFFD_DEF const char *sqffd_result_string(sqffd_result result);

/* Stages reported to a progress callback. */
typedef enum sqffd_stage {
    SQFFD_STAGE_SUPERQUADRIC = 1, /* superquadric fit: error = current cost */
    SQFFD_STAGE_FFD = 2           /* FFD two-step iteration: error = relative RMS error */
} sqffd_stage;

/* Called by long operations once per iteration; return non-zero to cancel
   (the operation then returns SQFFD_ERROR_CANCELLED). */
typedef int (*sqffd_progress_fn)(void *user, int stage, int iteration, double error);

#include "dev/1_linalg_api.h"
#include "dev/2_kdtree_api.h"
#include "dev/3_superquadric_api.h"
#include "dev/4_ffd_api.h"
#include "dev/5_model_api.h"

#ifdef __cplusplus
}
#endif
#endif /* SQFFD_H */

/* ====================================================================== */
/*                            IMPLEMENTATION                              */
/* ====================================================================== */
#ifdef SQFFD_IMPLEMENTATION
#ifndef SQFFD__IMPLEMENTED
#define SQFFD__IMPLEMENTED

#include <string.h>
#include <math.h>

#ifndef SQFFD_ASSERT
#include <assert.h>
#define SQFFD_ASSERT(x) assert(x)
#endif

#ifdef __cplusplus
extern "C" {
#endif

SQFFD_DEF const char *sqffd_result_string(sqffd_result result)
{
    switch (result) {
#define SQFFD__RESULT_CASE(name, text) case name: return text;
        SQFFD_RESULT_LIST(SQFFD__RESULT_CASE)
#undef SQFFD__RESULT_CASE
    default: break;
    }
    return "unknown result code";
}

/* ---- Workspace arena ------------------------------------------------------
   Every operation that needs scratch memory lays it out with one function
   that takes blocks from an arena. Run over a NULL base it only measures
   (that is what sqffd_X_workspace_size() does); run over the caller's block it
   hands out 16-byte aligned pieces. One layout function per operation keeps
   the size and the carving from ever disagreeing. */
#define SQFFD__ALIGN 16u

typedef struct sqffd__arena {
    unsigned char *base; /* NULL while measuring, else 16-byte aligned */
    size_t size;         /* usable bytes from base (ignored while measuring) */
    size_t used;
    int overflow;        /* a request did not fit, or its size overflowed */
} sqffd__arena;

/* The caller's block loses up to 15 bytes to alignment; exactly SQFFD__ALIGN
   are always set aside for it, so a block of the measured size works at any
   address and one byte less fails at any address. */
static void sqffd__arena_init(sqffd__arena *a, void *memory, size_t size)
{
    a->base = NULL;
    a->size = 0;
    a->used = 0;
    a->overflow = 0;
    if (memory) {
        size_t mis = (size_t)((uintptr_t)memory % SQFFD__ALIGN);
        if (size < SQFFD__ALIGN) { a->overflow = 1; return; }
        a->base = (unsigned char *)memory + (mis ? SQFFD__ALIGN - mis : 0);
        a->size = size - SQFFD__ALIGN;
    }
}

/* count * elem bytes, aligned; NULL while measuring or when out of room. */
static void *sqffd__arena_take(sqffd__arena *a, size_t count, size_t elem)
{
    size_t bytes, start;
    if (a->overflow) return NULL;
    if (elem && count > ((size_t)-1 - SQFFD__ALIGN) / elem) { a->overflow = 1; return NULL; }
    bytes = (count * elem + SQFFD__ALIGN - 1) & ~(size_t)(SQFFD__ALIGN - 1);
    start = a->used;
    if (bytes > (size_t)-1 - start - SQFFD__ALIGN) { a->overflow = 1; return NULL; }
    if (a->base && bytes > a->size - start) { a->overflow = 1; return NULL; }
    a->used = start + bytes;
    return a->base ? (void *)(a->base + start) : NULL;
}

/* What a measured layout needs from the caller: room for an unaligned base
   too. 0 means the request cannot be represented (absurd sizes). */
static size_t sqffd__arena_required(const sqffd__arena *a)
{
    return a->overflow ? 0 : a->used + SQFFD__ALIGN;
}

static int sqffd__finite3(const double *p)
{
    return isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]);
}

#include "dev/1_linalg_impl.h"
#include "dev/2_kdtree_impl.h"
#include "dev/3_superquadric_impl.h"
#include "dev/4_ffd_impl.h"
#include "dev/5_model_impl.h"

#ifdef __cplusplus
}
#endif
#endif /* SQFFD__IMPLEMENTED */
#endif /* SQFFD_IMPLEMENTATION */

/*
------------------------------------------------------------------------------
This software is available under 2 licenses -- choose whichever you prefer.
------------------------------------------------------------------------------
ALTERNATIVE A - MIT License
Copyright (c) 2026 the sqffd authors
Permission is hereby granted, free of charge, to any person obtaining a copy of
this software and associated documentation files (the "Software"), to deal in
the Software without restriction, including without limitation the rights to
use, copy, modify, merge, publish, distribute, sublicense, and/or sell copies
of the Software, and to permit persons to whom the Software is furnished to do
so, subject to the following conditions:
The above copyright notice and this permission notice shall be included in all
copies or substantial portions of the Software.
THE SOFTWARE IS PROVIDED "AS IS", WITHOUT WARRANTY OF ANY KIND, EXPRESS OR
IMPLIED, INCLUDING BUT NOT LIMITED TO THE WARRANTIES OF MERCHANTABILITY,
FITNESS FOR A PARTICULAR PURPOSE AND NONINFRINGEMENT. IN NO EVENT SHALL THE
AUTHORS OR COPYRIGHT HOLDERS BE LIABLE FOR ANY CLAIM, DAMAGES OR OTHER
LIABILITY, WHETHER IN AN ACTION OF CONTRACT, TORT OR OTHERWISE, ARISING FROM,
OUT OF OR IN CONNECTION WITH THE SOFTWARE OR THE USE OR OTHER DEALINGS IN THE
SOFTWARE.
------------------------------------------------------------------------------
ALTERNATIVE B - Public Domain (www.unlicense.org)
This is free and unencumbered software released into the public domain.
Anyone is free to copy, modify, publish, use, compile, sell, or distribute this
software, either in source code form or as a compiled binary, for any purpose,
commercial or non-commercial, and by any means.
In jurisdictions that recognize copyright laws, the author or authors of this
software dedicate any and all copyright interest in the software to the public
domain. We make this dedication for the benefit of the public at large and to
the detriment of our heirs and successors. We intend this dedication to be an
overt act of relinquishment in perpetuity of all present and future rights to
this software under copyright law.
THE SOFTWARE IS PROVIDED "AS IS", WITHOUT WARRANTY OF ANY KIND, EXPRESS OR
IMPLIED, INCLUDING BUT NOT LIMITED TO THE WARRANTIES OF MERCHANTABILITY,
FITNESS FOR A PARTICULAR PURPOSE AND NONINFRINGEMENT. IN NO EVENT SHALL THE
AUTHORS BE LIABLE FOR ANY CLAIM, DAMAGES OR OTHER LIABILITY, WHETHER IN AN
ACTION OF CONTRACT, TORT OR OTHERWISE, ARISING FROM, OUT OF OR IN CONNECTION
WITH THE SOFTWARE OR THE USE OR OTHER DEALINGS IN THE SOFTWARE.
------------------------------------------------------------------------------
*/

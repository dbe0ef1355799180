/* A firmware-style use of sqffd on a Cortex-M7: static arrays only, no heap.
   384 points of a synthetic tapered ellipsoid with a dent (made here, so the
   program needs no file), a static workspace checked at run time against
   sqffd_fit_workspace_size, one sqffd_fit. Linked by `make embedded` with
   newlib (nosys.specs: link only) against the separately built core object
   (core.c). With -DFIT_M7_QEMU and -nostartfiles it also runs under qemu-arm
   (Linux user mode) and prints the fit and the stack sqffd_fit used (the
   stack below the caller is painted before the fit and scanned after it).
   Exit status: 0 when the fit worked, beat the superquadric alone and
   kept its certified Jacobian bound at or above the floor. */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include "../../sqffd.h"

#define FIT_M7_POINTS 384
/* Grid and lattice smaller than the defaults (32 x 64, 5 x 5 x 5): the
   workspace is sqffd_fit_workspace_size's answer, 1.41 MB on 32-bit (the
   fold-free step's dense 192 x 192 system and its certificate; 0.58 MB
   without the floor): a part with 1.5 MB of RAM or more, or min_jacobian
   -HUGE_VAL. */
#define FIT_M7_WORKSPACE (1440u * 1024u)

static double points[3 * FIT_M7_POINTS];
static unsigned char workspace[FIT_M7_WORKSPACE];
static sqffd_model model;
static sqffd_fit_report report;

/* Even points on an ellipsoid (radii 3, 2, 1.5; golden-angle spiral), wider
   at the bottom, with a dent. */
static void make_points(double *p, int n)
{
    const double pi = 3.14159265358979323846, golden = pi * (3.0 - sqrt(5.0));
    int i;
    for (i = 0; i < n; i++) {
        double z = 1.0 - (2.0 * i + 1.0) / n, r = sqrt(1.0 - z * z), omega = golden * i;
        double x = r * cos(omega), y = r * sin(omega);
        double widen = 1.0 - 0.2 * z, dent = 1.0 - 0.2 * exp(-((x - 0.8) * (x - 0.8) + (z - 0.3) * (z - 0.3)) / 0.08);
        p[3 * i] = 3.0 * x * widen * dent;
        p[3 * i + 1] = 2.0 * y * widen * dent;
        p[3 * i + 2] = 1.5 * z * dent;
    }
}

#ifdef FIT_M7_QEMU
/* Run under qemu-arm (Linux user mode; the Cortex-M7 code runs unchanged on
   its ARMv8-A CPU): Linux system calls for the output and the exit, our own
   _start (link with -nostartfiles), no stdio (newlib's printf would want a
   heap). */
static long linux_call3(long number, long a, long b, long c)
{
    register long r0 __asm__("r0") = a;
    register long r1 __asm__("r1") = b;
    register long r2 __asm__("r2") = c;
    register long r7 __asm__("r7") = number;
    __asm__ volatile("svc 0" : "+r"(r0) : "r"(r1), "r"(r2), "r"(r7) : "memory");
    return r0;
}

static void put(const char *s)
{
    size_t n = 0;
    while (s[n]) n++;
    linux_call3(4 /* write */, 1, (long)s, (long)n);
}

static void put_unsigned(unsigned long v)
{
    char buf[24], *p = buf + sizeof buf;
    *--p = '\0';
    do *--p = (char)('0' + v % 10); while (v /= 10);
    put(p);
}

/* x with 4 decimals (x >= 0) */
static void put_fixed4(double x)
{
    unsigned long scaled = (unsigned long)(x * 10000.0 + 0.5), frac = scaled % 10000;
    put_unsigned(scaled / 10000);
    put(".");
    put(frac < 1000 ? (frac < 100 ? (frac < 10 ? "000" : "00") : "0") : "");
    if (frac) put_unsigned(frac);
}

/* Stack measurement: fill the stack below the current stack pointer with a
   pattern, run the fit, find the deepest word that changed. */
#define PAINT_BYTES (64u * 1024u)
#define PAINT_GAP 256u /* just below sp: left alone (paint's own frame) */
#define PAINT_WORD 0x5AC3A55Cu

static uintptr_t stack_pointer(void)
{
    uintptr_t sp;
    __asm__ volatile("mov %0, sp" : "=r"(sp));
    return sp;
}

static void paint(uintptr_t sp)
{
    volatile uint32_t *w = (volatile uint32_t *)((sp - PAINT_BYTES) & ~(uintptr_t)3);
    volatile uint32_t *end = (volatile uint32_t *)((sp - PAINT_GAP) & ~(uintptr_t)3);
    while (w < end) *w++ = PAINT_WORD;
}

static size_t used_below(uintptr_t sp)
{
    volatile uint32_t *w = (volatile uint32_t *)((sp - PAINT_BYTES) & ~(uintptr_t)3);
    while ((uintptr_t)w < sp && *w == PAINT_WORD) w++;
    return (size_t)(sp - (uintptr_t)w);
}

int main(void);
void _start(void);
void _start(void)
{
    linux_call3(1 /* exit */, main(), 0, 0);
    for (;;) {
    }
}
#endif

int main(void)
{
    sqffd_fit_options opt = sqffd_fit_options_default();
    size_t need;
    sqffd_result r;
#ifdef FIT_M7_QEMU
    uintptr_t sp;
    size_t used;
#endif

    opt.grid[0] = 16;
    opt.grid[1] = 32;
    opt.lattice[0] = opt.lattice[1] = opt.lattice[2] = 4;
    make_points(points, FIT_M7_POINTS);
    r = sqffd_fit_workspace_size(FIT_M7_POINTS, &opt, &need);
    if (r != SQFFD_OK) {
#ifdef FIT_M7_QEMU
        put("fit_m7: sqffd_fit_workspace_size: ");
        put(sqffd_result_string(r));
        put("\n");
#endif
        return 2;
    }
    if (need > sizeof workspace) {
#ifdef FIT_M7_QEMU
        put("fit_m7: the workspace needs ");
        put_unsigned(need);
        put(" bytes, more than FIT_M7_WORKSPACE\n");
#endif
        return 2;
    }
#ifdef FIT_M7_QEMU
    sp = stack_pointer();
    paint(sp);
#endif
    r = sqffd_fit(points, FIT_M7_POINTS, &opt, &model, &report, workspace, sizeof workspace);
#ifdef FIT_M7_QEMU
    used = used_below(sp);
    put("fit_m7: ");
    put_unsigned(FIT_M7_POINTS);
    put(" points, workspace ");
    put_unsigned(need);
    put(" bytes, ");
    put(sqffd_result_string(r));
    put(", ");
    put_unsigned((unsigned long)report.iterations);
    put(" FFD iterations\nfit_m7: error (RMS / diagonal, %) superquadric ");
    put_fixed4(100 * report.sq_error.rms_relative);
    put(", model ");
    put_fixed4(100 * report.error.rms_relative);
    put("; certified Jacobian bound on its region ");
    put(report.min_jacobian >= opt.min_jacobian ? "at or above the floor: no fold" : "BELOW THE FLOOR");
    put("\nfit_m7: sqffd_fit used ");
    put_unsigned(used);
    put(" bytes of stack (measured: the 64 KB below the caller painted)\n");
#endif
    if (r != SQFFD_OK) return 1;
    return report.error.rms_relative < report.sq_error.rms_relative && report.min_jacobian >= opt.min_jacobian ? 0 : 1;
}

"""The Python wrapper's calling overhead (make bench): sqffd.fit() against the same fit made in C
(bench/python_timer.c: workspace size, malloc, sqffd_fit, free, timed in C) on the phantom's
points, both through build/libsqffd.so in this one process, alternating run by run (C first in
every other pair) so that the machine's drift hits both alike. Overhead = the median of the
paired differences (Python - C) over the median C time, in wall-clock and in CPU time.

    python3 bench/bench_python.py [BUILD_DIR]     (BUILD_DIR: default build)"""

import ctypes
import os
import statistics
import sys
import time

import numpy as np

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir))
BUILD = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(REPO, "build"))
os.environ.setdefault("SQFFD_LIBRARY", os.path.join(BUILD, "libsqffd.so"))
sys.path.insert(0, os.path.join(REPO, "examples", "python"))
import sqffd  # noqa: E402

RUNS = 31
TARGET = 0.05  # overhead <= 5% of a 6,000-point fit

timer = ctypes.CDLL(os.path.join(BUILD, "python_timer.so"))
timer.python_timer_phantom.argtypes = (ctypes.c_size_t, ctypes.c_void_p)
timer.python_timer_phantom.restype = None
timer.python_timer_fit_ms.argtypes = (ctypes.c_void_p, ctypes.c_size_t, ctypes.POINTER(ctypes.c_double))
timer.python_timer_fit_ms.restype = ctypes.c_double


def python_fit_ms(points):
    """sqffd.fit(points): its wall-clock and CPU milliseconds."""
    wall, cpu = time.perf_counter(), time.thread_time()
    sqffd.fit(points)
    return 1e3 * (time.perf_counter() - wall), 1e3 * (time.thread_time() - cpu)


def c_fit_ms(points):
    """The same fit in C: its wall-clock and CPU milliseconds."""
    cpu = ctypes.c_double()
    wall = timer.python_timer_fit_ms(points.ctypes.data, len(points), ctypes.byref(cpu))
    if wall < 0:
        sys.exit("bench_python: the C fit failed")
    return wall, cpu.value


def measure(n):
    """{clock: (C median ms, Python median ms, median paired difference ms)} for wall and CPU time."""
    points = np.empty((n, 3))
    timer.python_timer_phantom(n, points.ctypes.data)
    pairs = []
    for run in range(RUNS + 2):  # the first two: warm-up; C first in even runs, Python first in odd ones
        python = python_fit_ms(points) if run % 2 else None
        c = c_fit_ms(points)
        pairs.append((c, python or python_fit_ms(points)))
    pairs = pairs[2:]
    return {clock: (statistics.median(c[k] for c, _ in pairs), statistics.median(p[k] for _, p in pairs),
                    statistics.median(p[k] - c[k] for c, p in pairs))
            for k, clock in enumerate(("wall", "cpu"))}


def wrapper_own_ms(points):
    """Median milliseconds of fit()'s own work, outside the sqffd_fit call (points, options,
    workspace, model and report): measured within each run, so the fit's own noise drops out."""
    c_function, inside, outside = sqffd._lib.sqffd_fit_view, [], []

    def timed_c_function(*arguments):
        start = time.perf_counter()
        result = c_function(*arguments)
        inside.append(time.perf_counter() - start)
        return result

    sqffd._lib.sqffd_fit_view = timed_c_function
    try:
        for _ in range(RUNS):
            start = time.perf_counter()
            sqffd.fit(points)
            outside.append(time.perf_counter() - start - inside[-1])
    finally:
        sqffd._lib.sqffd_fit_view = c_function
    return 1e3 * statistics.median(outside)


print(f"Python wrapper: sqffd.fit() against the same fit in C, the phantom's points, default options "
      f"(medians of {RUNS} alternating runs in one process; overhead = median of the paired differences; "
      f"cpu = the thread's CPU time; python {sys.version.split()[0]}, numpy {np.__version__})")
print(f"{'points':>8} {'clock':>5} {'C ms':>9} {'Python ms':>10} {'overhead ms':>12} {'overhead':>9}")
overhead, measured = {}, {}
for n in (6000, 500):
    measured[n] = measure(n)
    for clock, (c_ms, python_ms, difference) in measured[n].items():
        overhead[n, clock] = difference / c_ms
        print(f"{n:>8} {clock:>5} {c_ms:>9.2f} {python_ms:>10.2f} {difference:>12.3f} {100 * difference / c_ms:>8.2f}%")
points = np.empty((6000, 3))
timer.python_timer_phantom(len(points), points.ctypes.data)
own = wrapper_own_ms(points)
print(f"fit()'s own work around sqffd_fit, 6,000 points: {1e3 * own:.0f} us a call "
      f"({100 * own / measured[6000]['cpu'][0]:.2f}% of the C fit's CPU time)")
print(f"target: overhead <= {100 * TARGET:.0f}% of a 6,000-point fit (CPU time, which a busy machine does not "
      f"distort): {'met' if overhead[6000, 'cpu'] <= TARGET else 'NOT met'}")

"""sqffd for Python and numpy: superquadric + free-form deformation shape models.

A thin ctypes wrapper over the sqffd shared library (`make shared` builds
build/libsqffd.so from sqffd.h); numpy is its only dependency, nothing is
compiled or installed. The library is found through the SQFFD_LIBRARY
environment variable (the path of libsqffd.so), else in the build/ folder of
the repository this file sits in.

    import numpy as np, sqffd
    model = sqffd.fit(points)                      # points: (N, 3) array-like (or wider: x y z first)
    print(model.report.error.rms_relative)         # "the error": RMS distance / bounding-box diagonal
    vertices, triangles = model.mesh(64, 128)      # (V, 3) float64, (T, 3) uint32
    data = model.save()                            # the library's byte format; sqffd.load(data)

Options are the C field names of sqffd_fit_options (nested ones as dicts:
sq=dict(robust=True)); sqffd.fit_options_default() lists them with their
defaults. Every library error raises SqffdError (its .code, and the library's
message). The library never allocates: this module sizes each workspace with
the matching _workspace_size call and owns it for the call. ctypes releases
the GIL during a call, so fits in several threads run in parallel.

The ctypes structs below mirror sqffd.h's (SQFFD_MAX_LATTICE 8);
tests/python checks their sizes and offsets against the C compiler's.
"""

import ctypes
import dataclasses
import enum
import operator
import os
from typing import List

import numpy as np

__all__ = [
    "fit", "track", "motion", "wall", "load", "stack_detect", "stack_lids", "stack_shifts", "Model", "Stack", "SliceShifts",
    "SqffdError", "Result", "Stage",
    "SqCost", "SqOptimizer", "Regularization", "Solver",
    "Superquadric", "SuperquadricReport", "DistanceStats", "FitReport", "SegmentMotion", "Motion",
    "SegmentWall", "Wall", "wall",
    "fit_options_default", "track_options_default", "motion_options_default", "wall_options_default",
]

# ---- the library -------------------------------------------------------------------------------

LIBRARY_ENV = "SQFFD_LIBRARY"
_REPO_LIBRARY = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir, "build", "libsqffd.so")


def _load_library():
    path = os.environ.get(LIBRARY_ENV) or os.path.normpath(_REPO_LIBRARY)
    if not os.path.isfile(path):
        raise ImportError(
            f"sqffd: shared library not found at {path}: run `make shared` in the sqffd repository, "
            f"or set {LIBRARY_ENV} to the path of libsqffd.so")
    return ctypes.CDLL(path)


_lib = _load_library()

# ---- enums and result codes (values checked against sqffd.h by tests/python) --------------------


class Result(enum.IntEnum):
    """sqffd_result: SQFFD_OK and SQFFD_ERROR_<name>."""
    OK = 0
    INVALID_ARGUMENT = 1
    NON_FINITE = 2
    TOO_FEW_POINTS = 3
    DEGENERATE = 4
    TOO_LARGE = 5
    WORKSPACE_TOO_SMALL = 6
    NOT_POSITIVE_DEFINITE = 7
    NO_CONVERGENCE = 8
    CANCELLED = 9
    INVALID_MODEL = 10
    BAD_FORMAT = 11
    OUTPUT_TOO_SMALL = 12


class Stage(enum.IntEnum):
    """sqffd_stage: what a progress callback reports."""
    SUPERQUADRIC = 1  # error = the current cost
    FFD = 2           # error = the relative RMS error after the iteration
    FRAME = 3         # track: iteration = the frame's index, error = the previous frame's error
    COARSE = 4        # fit's coarse iterations: error = the relative RMS error on the coarse grid


class FitStop(enum.IntEnum):
    """sqffd_fit_stop: why a fit's iteration ended."""
    CONVERGED = 0  # the last plain step moved the model points by at most the tolerance
    CAPPED = 1     # max_iterations were done first: not converged
    STALLED = 2    # no further progress: a plain step that did not lower the energy


class SqCost(enum.IntEnum):
    SOLINA = 0
    RADIAL = 1


class SqOptimizer(enum.IntEnum):
    LM = 0
    CG = 1


class Regularization(enum.IntEnum):
    DISPLACEMENT = 0
    POSITION = 1


class Solver(enum.IntEnum):
    CHOLESKY = 0
    SVD = 1


class SqffdError(Exception):
    """A call into sqffd failed: .code (Result), .message (sqffd_result_string), .operation, and
    .frame (track: the index of the frame that failed; None elsewhere)."""

    def __init__(self, code, operation, frame=None):
        try:
            self.code = Result(code)
        except ValueError:  # a code this module does not know: a newer library
            self.code = code
        self.message = _lib.sqffd_result_string(code).decode()
        self.operation = operation
        self.frame = frame
        name = self.code.name if isinstance(self.code, Result) else str(code)
        where = f" (frame {frame})" if frame is not None else ""
        super().__init__(f"{operation}{where}: {self.message} [{name}]")

    def __reduce__(self):  # picklable (e.g. raised in a multiprocessing worker)
        return SqffdError, (int(self.code), self.operation, self.frame)


# ---- ctypes mirrors of sqffd.h's structs ---------------------------------------------------------

_MAX_LATTICE = 8
_FIT_HISTORY = 64
_SEGMENTS = 17
_STACK_PLANES = 64
_PROGRESS = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_double)
_int, _double, _size, _pointer = ctypes.c_int, ctypes.c_double, ctypes.c_size_t, ctypes.c_void_p


class _Points(ctypes.Structure):
    _fields_ = [("xyz", _pointer), ("count", _size), ("stride", _size), ("type", _int)]


_SCALAR_DOUBLE, _SCALAR_FLOAT = 0, 1  # sqffd_scalar


class _SqFitOptions(ctypes.Structure):
    _fields_ = [("cost", _int), ("optimizer", _int), ("taper", _int), ("shape_min", _double),
                ("shape_max", _double), ("taper_max", _double), ("max_iterations", _int), ("tolerance", _double),
                ("final_points", _size), ("robust", _int), ("robust_rounds", _int), ("progress", _PROGRESS), ("progress_user", _pointer)]


class _Superquadric(ctypes.Structure):
    _fields_ = [("size", _double * 3), ("shape", _double * 2), ("taper", _double * 2), ("rotation", _double * 9),
                ("center", _double * 3)]


class _SqFitReport(ctypes.Structure):
    _fields_ = [("iterations", _int), ("cost", _double), ("rms_radial", _double), ("start", _int),
                ("converged", _int), ("inlier_fraction", _double), ("best_start", _Superquadric), ("fallback", _int)]


class _Ffd(ctypes.Structure):
    _fields_ = [("dims", _int * 3), ("origin", _double * 3), ("edges", _double * 9), ("inverse", _double * 9),
                ("control", (_double * 3) * _MAX_LATTICE ** 3)]


class _Model(ctypes.Structure):
    _fields_ = [("sq", _Superquadric), ("ffd", _Ffd), ("grid", _int * 2)]


class _FitOptions(ctypes.Structure):
    _fields_ = [("sq", _SqFitOptions), ("lattice", _int * 3), ("box_margin", _double), ("grid", _int * 2),
                ("alpha", _double), ("tether", _double), ("regularization", _int), ("solver", _int),
                ("max_iterations", _int), ("coarse_iterations", _int), ("tolerance", _double), ("min_jacobian", _double),
                ("model_to_data", _double),
                ("sq_max_points", _size), ("ffd_max_points", _size), ("progress", _PROGRESS),
                ("progress_user", _pointer)]


class _DistanceStats(ctypes.Structure):
    _fields_ = [(name, _double) for name in
                ("rms", "mean", "max", "diagonal", "rms_relative", "mean_relative", "max_relative")]


class _FitReport(ctypes.Structure):
    _fields_ = [("sq", _SqFitReport), ("sq_error", _DistanceStats), ("error", _DistanceStats),
                ("coarse_iterations", _int), ("iterations", _int), ("converged", _int), ("step", _double),
                ("history_count", _int),
                ("history", _double * _FIT_HISTORY), ("energy", _double),
                ("energy_history", _double * _FIT_HISTORY), ("min_jacobian", _double), ("stop", _int)]


class _TrackOptions(ctypes.Structure):
    _fields_ = [("fit", _FitOptions), ("frame_iterations", _int), ("progress", _PROGRESS),
                ("progress_user", _pointer)]


class _MotionOptions(ctypes.Structure):
    _fields_ = [("ed_frame", _size), ("low_motion_fraction", _double), ("hypokinetic_share", _double),
                ("apex_fraction", _double), ("apex_direction", _double * 3), ("septum_direction", _double * 3),
                ("stacks", _pointer)]


class _MotionOutputs(ctypes.Structure):
    _fields_ = [("volumes", _pointer), ("trajectories", _pointer), ("displacement", _pointer),
                ("excursion", _pointer), ("low_motion", _pointer), ("segment", _pointer)]


class _SegmentMotion(ctypes.Structure):
    _fields_ = [("area", _double), ("mean_displacement", _double), ("mean_excursion", _double),
                ("low_motion_share", _double), ("hypokinetic", _int)]


class _MotionReport(ctypes.Structure):
    _fields_ = [("ed_frame", _size), ("es_frame", _size), ("edv", _double), ("esv", _double),
                ("ejection_fraction", _double), ("axis", _double * 3), ("apex", _double * 3), ("length", _double),
                ("anterior", _double * 3), ("septum", _double * 3), ("apex_fraction", _double),
                ("median_excursion", _double),
                ("segments", _SegmentMotion * _SEGMENTS)]


class _WallOptions(ctypes.Structure):
    _fields_ = [("dysfunctional_thickening", _double), ("stacks", _pointer), ("endo_stacks", _pointer)]


class _WallOutputs(ctypes.Structure):
    _fields_ = [("myocardium", _pointer), ("thickness_ed", _pointer), ("thickness_es", _pointer),
                ("thickening", _pointer)]


class _SegmentWall(ctypes.Structure):
    _fields_ = [("thickness_ed", _double), ("thickness_es", _double), ("thickening", _double),
                ("dysfunctional", _int)]


class _WallReport(ctypes.Structure):
    _fields_ = [("myocardium_ed", _double), ("myocardium_es", _double), ("thickness_ed", _double),
                ("thickness_es", _double), ("thickening", _double), ("measured", _size), ("unmeasured", _size),
                ("segments", _SegmentWall * _SEGMENTS)]


class _Stack(ctypes.Structure):
    _fields_ = [("axis", _double * 3), ("planes", _size), ("level", _double * _STACK_PLANES), ("spacing", _double)]


class _SliceShifts(ctypes.Structure):
    _fields_ = [("axis", _double * 3), ("slices", _size), ("level", _double * _STACK_PLANES),
                ("shift", (_double * 3) * _STACK_PLANES), ("tolerance", _double)]


# The mirrors by their C names (tests/python checks each against the compiler's layout).
_MIRRORS = {
    "sqffd_points": _Points, "sqffd_sq_fit_options": _SqFitOptions, "sqffd_superquadric": _Superquadric,
    "sqffd_sq_fit_report": _SqFitReport, "sqffd_ffd": _Ffd, "sqffd_model": _Model,
    "sqffd_fit_options": _FitOptions, "sqffd_distance_stats": _DistanceStats, "sqffd_fit_report": _FitReport,
    "sqffd_track_options": _TrackOptions, "sqffd_motion_options": _MotionOptions,
    "sqffd_motion_outputs": _MotionOutputs, "sqffd_segment_motion": _SegmentMotion,
    "sqffd_motion_report": _MotionReport, "sqffd_stack": _Stack, "sqffd_slice_shifts": _SliceShifts,
    "sqffd_wall_options": _WallOptions, "sqffd_wall_outputs": _WallOutputs, "sqffd_segment_wall": _SegmentWall,
    "sqffd_wall_report": _WallReport,
}


def _declare(name, restype, *argtypes):
    function = getattr(_lib, name)
    function.restype = restype
    function.argtypes = argtypes


_P = ctypes.POINTER
_declare("sqffd_result_string", ctypes.c_char_p, _int)
_declare("sqffd_fit_options_default", _FitOptions)
_declare("sqffd_fit_workspace_size", _int, _size, _P(_FitOptions), _P(_size))
_declare("sqffd_fit_view", _int, _Points, _P(_FitOptions), _P(_Model), _P(_FitReport), _pointer, _size)
_declare("sqffd_model_point", _int, _P(_Model), _double, _double, _pointer)
_declare("sqffd_model_mesh_size", _int, _int, _int, _P(_size), _P(_size))
_declare("sqffd_model_mesh", _int, _P(_Model), _int, _int, _pointer, _pointer)
_declare("sqffd_model_distances_workspace_size", _int, _size, _P(_Model), _P(_size))
_declare("sqffd_model_distances_view", _int, _P(_Model), _Points, _pointer, _P(_DistanceStats), _pointer, _size)
_declare("sqffd_model_reverse_distances_workspace_size", _int, _size, _P(_Model), _P(_size))
_declare("sqffd_model_reverse_distances_view", _int, _P(_Model), _Points, _pointer, _P(_DistanceStats),
         _pointer, _size)
_declare("sqffd_model_save_size", _int, _P(_Model), _P(_size))
_declare("sqffd_model_save", _int, _P(_Model), _pointer, _size)
_declare("sqffd_model_load", _int, _P(_Model), ctypes.c_char_p, _size)
_declare("sqffd_track_options_default", _TrackOptions)
_declare("sqffd_track_view_workspace_size", _int, _P(_Points), _size, _P(_TrackOptions), _P(_size))
_declare("sqffd_track_view", _int, _P(_Points), _size, _P(_TrackOptions), _P(_Model), _P(_FitReport),
         _P(_size), _pointer, _size)
_declare("sqffd_stack_detect_view", _int, _Points, _P(_Stack), _P(_int))
_declare("sqffd_stack_lids_view", _int, _Points, _P(_Stack), _pointer, _size, _P(_size))
_declare("sqffd_stack_shifts_view", _int, _P(_Points), _P(_Stack), _size, _P(_SliceShifts))
_declare("sqffd_stack_shifts_apply", _int, _P(_SliceShifts), _pointer, _size, _P(_size))
_declare("sqffd_motion_options_default", _MotionOptions)
_declare("sqffd_motion_workspace_size", _int, _P(_Model), _size, _P(_size))
_declare("sqffd_motion", _int, _P(_Model), _size, _P(_MotionOptions), _P(_MotionOutputs), _P(_MotionReport),
         _pointer, _size)
_declare("sqffd_wall_options_default", _WallOptions)
_declare("sqffd_wall_workspace_size", _int, _P(_Model), _P(_Model), _size, _P(_size))
_declare("sqffd_wall", _int, _P(_Model), _P(_Model), _size, _P(_MotionReport), _pointer, _P(_WallOptions),
         _P(_WallOutputs), _P(_WallReport), _pointer, _size)


def _check(result, operation, frame=None):
    if result != Result.OK:
        raise SqffdError(result, operation, frame)


def _workspace(size_function, operation, *arguments):
    """The workspace (a numpy byte buffer) that size_function sizes for these arguments, and its size."""
    size = _size()
    _check(size_function(*arguments, ctypes.byref(size)), operation)
    return np.empty(size.value, dtype=np.uint8), size.value


def _points(points, what="points"):
    """The points as a sqffd_points view, and the array it reads (keep it alive during the call).
    An (N, 3) array, or a wider one whose first three columns are x y z (e.g. x y z nx ny nz as
    np.loadtxt reads an XYZ file with normals: the other columns are not read). float32 and
    float64 arrays (native byte order) whose rows hold x y z side by side are read in place, at
    any row stride; anything else is converted to contiguous float64 first."""
    array = np.asarray(points)
    if array.ndim != 2 or array.shape[1] < 3:
        raise ValueError(f"{what}: expected an (N, 3) array of x y z (or (N, >3), x y z first), got shape "
                         f"{array.shape}")
    array = array[:, :3]
    in_place = (array.dtype in (np.dtype(np.float32), np.dtype(np.float64)) and array.strides[1] == array.itemsize
                and array.strides[0] >= 3 * array.itemsize)
    if not in_place:
        array = np.ascontiguousarray(array, dtype=np.float64)
    view = _Points(array.ctypes.data, len(array), array.strides[0] if len(array) > 1 else 3 * array.itemsize,
                   _SCALAR_FLOAT if array.dtype == np.float32 else _SCALAR_DOUBLE)
    return array, view


# ---- options: keyword arguments by the C field names ---------------------------------------------

_ENUM_FIELDS = {"cost": SqCost, "optimizer": SqOptimizer, "regularization": Regularization, "solver": Solver}
# a Python callable carries its own state; motion/wall(stacks=, endo_stacks=) set the stacks
_HIDDEN_FIELDS = ("progress_user", "stacks", "endo_stacks")


class _Progress:
    """A Python progress callable (stage, iteration, error) -> true to cancel, as the C callback.
    An exception it raises cancels the call and is raised again from it."""

    def __init__(self, function, name):
        if not callable(function):
            raise TypeError(f"{name} must be callable (stage, iteration, error) -> bool, got {function!r}")
        self.function = function
        self.error = None
        self.c_function = _PROGRESS(self._call)

    def _call(self, user, stage, iteration, error):
        try:
            return 1 if self.function(Stage(stage), iteration, error) else 0
        except BaseException as exception:  # KeyboardInterrupt too: the call stops at this iteration
            self.error = exception
            return 1


def _integer(ctype, value, name):
    """value as a C integer of type ctype, or an error naming the option: ctypes would wrap it silently."""
    try:
        number = operator.index(value)
    except TypeError:
        raise TypeError(f"{name}: expected an integer, got {value!r}") from None
    bits = 8 * ctypes.sizeof(ctype)
    low, high = (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if ctype(-1).value < 0 else (0, (1 << bits) - 1)
    if not low <= number <= high:
        raise ValueError(f"{name} = {number} is out of the range of its C type ({low}..{high})")
    return number


class _Range:
    """The valid values of a numeric option: low <= value <= high, or < where an end is open
    (printed as an interval: [0, inf) is finite and >= 0); NaN is never in it."""

    def __init__(self, low, high, low_open=False, high_open=False):
        self.low, self.high, self.low_open, self.high_open = low, high, low_open, high_open

    def __contains__(self, value):
        return (self.low < value if self.low_open else self.low <= value) and \
            (value < self.high if self.high_open else value <= self.high)

    def __str__(self):
        return f"{'(' if self.low_open else '['}{self.low:g}, {self.high:g}{')' if self.high_open else ']'}"


_INF = float("inf")
_AT_LEAST_0 = _Range(0, _INF, high_open=True)
# Each numeric option's valid range, as sqffd.h's checks have it (sqffd__fit_check_options,
# SQFFD_FIT_ALPHA_MAX, SQFFD_FIT_MODEL_TO_DATA_MAX, sqffd__fit_check_whole_options, sqffd__fit_grid_check, sqffd__sq_options_valid, sqffd_track's
# frame_iterations, sqffd_motion's options), so that a bad value is refused here naming the option
# (the library only says INVALID_ARGUMENT); tests/python probes every bound against the library.
# An array option has one range per element. Checked across fields: _check_options.
_OPTION_RANGES = {
    _FitOptions: {
        "lattice": (_Range(2, _MAX_LATTICE),) * 3, "box_margin": _AT_LEAST_0,
        "grid": (_Range(2, 65536), _Range(3, 65536)),  # (beyond 65536 a grid is TOO_LARGE)
        "alpha": _Range(0, 1e12), "tether": _AT_LEAST_0, "model_to_data": _Range(0, 100),
        "tolerance": _AT_LEAST_0, "min_jacobian": _Range(-_INF, 1.0),
        "max_iterations": _AT_LEAST_0, "coarse_iterations": _AT_LEAST_0},
    _SqFitOptions: {
        "shape_min": _Range(0.01, 4.0), "shape_max": _Range(0.01, 4.0), "taper_max": _Range(0.0, 1.0, high_open=True),
        "max_iterations": _Range(1, _INF, high_open=True), "tolerance": _AT_LEAST_0},
    _TrackOptions: {"frame_iterations": _AT_LEAST_0},
    _MotionOptions: {
        "low_motion_fraction": _AT_LEAST_0, "hypokinetic_share": _Range(0.0, 1.0),
        "apex_fraction": _Range(0.0, 1.0, high_open=True)},
    _WallOptions: {"dysfunctional_thickening": _Range(-1.0, _INF, low_open=True, high_open=True)},
}


def _check_options(struct, prefix=""):
    """Raises ValueError naming the first option of struct (nested structs too) out of its range."""
    ranges = _OPTION_RANGES.get(type(struct), {})
    for name, ctype in struct._fields_:
        value = getattr(struct, name)
        if isinstance(ctype, type) and issubclass(ctype, ctypes.Structure):
            _check_options(value, prefix + name + ".")
        elif name in ranges:
            for i, valid in enumerate(ranges[name] if isinstance(ranges[name], tuple) else (ranges[name],)):
                number = value[i] if isinstance(ranges[name], tuple) else value
                if number not in valid:
                    where = f"{prefix}{name}" + (f"[{i}]" if isinstance(ranges[name], tuple) else "")
                    raise ValueError(f"{where} = {number!r} is out of its range {valid}")
    if isinstance(struct, _SqFitOptions):
        if struct.shape_min > struct.shape_max:
            raise ValueError(f"{prefix}shape_min = {struct.shape_min!r} is above {prefix}shape_max = "
                             f"{struct.shape_max!r}")
        if struct.robust and struct.robust_rounds < 1:
            raise ValueError(f"{prefix}robust_rounds = {struct.robust_rounds} is out of its range [1, inf) "
                             f"with {prefix}robust")


def _field_value(ctype, value, field, name):
    """value for a scalar C field (field: its C name; name: as the caller wrote it, for messages)."""
    if field in _ENUM_FIELDS and not isinstance(value, enum.Enum):
        enum_type = _ENUM_FIELDS[field]
        try:
            return enum_type[value.upper()] if isinstance(value, str) else enum_type(_integer(ctype, value, name))
        except (KeyError, ValueError):
            choices = ", ".join(f"{member.name.lower()} ({member.value})" for member in enum_type)
            raise ValueError(f"{name}: {value!r} is not one of {choices}") from None
    if ctype is not _double:
        return _integer(ctype, value, name)
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{name}: expected a number, got {value!r}")
    return float(value)


def _set_options(struct, options, prefix, callbacks):
    """Sets struct's fields from options (C field names; nested structs as dicts), then checks them
    (_check_options). Progress callables are wrapped and appended to callbacks, which the caller
    keeps alive during the call."""
    fields = {name: ctype for name, ctype in struct._fields_ if name not in _HIDDEN_FIELDS}
    for name, value in options.items():
        full_name = prefix + name
        if name not in fields:
            raise TypeError(f"unknown option {full_name!r}; the options: {', '.join(prefix + f for f in fields)}")
        ctype = fields[name]
        if ctype is _PROGRESS:
            if value is None:
                setattr(struct, name, _PROGRESS())
            else:
                callbacks.append(_Progress(value, full_name))
                setattr(struct, name, callbacks[-1].c_function)
        elif issubclass(ctype, ctypes.Structure):
            if not isinstance(value, dict):
                raise TypeError(f"{full_name}: expected a dict of its fields, got {value!r}")
            _set_options(getattr(struct, name), value, full_name + ".", callbacks)
        elif issubclass(ctype, ctypes.Array):
            values = list(value) if np.ndim(value) == 1 else None
            if values is None or len(values) != ctype._length_:
                raise ValueError(f"{full_name}: expected {ctype._length_} values, got {value!r}")
            setattr(struct, name, ctype(*(_field_value(ctype._type_, v, name, full_name) for v in values)))
        else:
            setattr(struct, name, _field_value(ctype, value, name, full_name))
    if not prefix:  # the whole struct set: every range, and those across fields
        _check_options(struct)


def _raise_callback_errors(callbacks):
    for callback in callbacks:
        if callback.error is not None:
            raise callback.error


def _options_dict(struct):
    """A C options struct as a dict by field name (nested structs as dicts, enums as enum members)."""
    result = {}
    for name, ctype in struct._fields_:
        if name in _HIDDEN_FIELDS:
            continue
        value = getattr(struct, name)
        if ctype is _PROGRESS:
            result[name] = None  # the defaults have none
        elif issubclass(ctype, ctypes.Structure):
            result[name] = _options_dict(value)
        elif issubclass(ctype, ctypes.Array):
            result[name] = tuple(value)
        else:
            result[name] = _ENUM_FIELDS[name](value) if name in _ENUM_FIELDS else value
    return result


def fit_options_default():
    """sqffd_fit_options_default() as a dict: the names and defaults fit() accepts."""
    return _options_dict(_lib.sqffd_fit_options_default())


def track_options_default():
    """sqffd_track_options_default() as a dict: the names and defaults track() accepts."""
    return _options_dict(_lib.sqffd_track_options_default())


def motion_options_default():
    """sqffd_motion_options_default() as a dict: the names and defaults motion() accepts."""
    return _options_dict(_lib.sqffd_motion_options_default())


def wall_options_default():
    """sqffd_wall_options_default() as a dict: the names and defaults wall() accepts."""
    return _options_dict(_lib.sqffd_wall_options_default())


# ---- reports -------------------------------------------------------------------------------------

def _array(c_array, shape=None):
    array = np.array(c_array, dtype=np.float64)
    return array.reshape(shape) if shape else array


@dataclasses.dataclass(eq=False)
class Superquadric:
    """sqffd_superquadric: world = rotation @ tapered local point + center; rotation's columns are the
    local x, y, z axes."""
    size: np.ndarray      # a1, a2, a3: half-extents along the local axes
    shape: np.ndarray     # e1 (north-south), e2 (east-west)
    taper: np.ndarray     # Kx, Ky
    rotation: np.ndarray  # 3 x 3
    center: np.ndarray

    @classmethod
    def _from_c(cls, s):
        return cls(_array(s.size), _array(s.shape), _array(s.taper), _array(s.rotation, (3, 3)), _array(s.center))


@dataclasses.dataclass(eq=False)
class SuperquadricReport:
    """sqffd_sq_fit_report: stage 1 of the fit."""
    iterations: int
    cost: float
    rms_radial: float
    start: int
    converged: bool
    inlier_fraction: float
    best_start: Superquadric
    fallback: bool  # the fitted superquadric ended farther from the data than best_start, which was kept

    @classmethod
    def _from_c(cls, r):
        return cls(r.iterations, r.cost, r.rms_radial, r.start, bool(r.converged), r.inlier_fraction,
                   Superquadric._from_c(r.best_start), bool(r.fallback))


@dataclasses.dataclass(eq=False)
class DistanceStats:
    """sqffd_distance_stats: absolute (data units) and relative to the data's bounding-box diagonal."""
    rms: float
    mean: float
    max: float
    diagonal: float
    rms_relative: float
    mean_relative: float
    max_relative: float

    @classmethod
    def _from_c(cls, s):
        return cls(*(getattr(s, field.name) for field in dataclasses.fields(cls)))


@dataclasses.dataclass(eq=False)
class FitReport:
    """sqffd_fit_report. error is "the error" (RMS data-to-model distance, relative: over the
    bounding-box diagonal); history and energy_history hold one entry per FFD iteration."""
    sq: SuperquadricReport
    sq_error: DistanceStats   # the starting model's (fit: the superquadric alone)
    error: DistanceStats      # the final model's
    coarse_iterations: int    # fit's iterations on the coarse grid, before those on the grid
    iterations: int
    converged: bool
    step: float
    history: np.ndarray       # relative RMS error after iteration 1, 2, ...
    energy: float
    energy_history: np.ndarray
    min_jacobian: float       # the model's certified Jacobian bound on its region (> 0: it folds nowhere there)
    stop: FitStop             # why the iteration ended (CAPPED: not converged)

    @classmethod
    def _from_c(cls, r):
        count = min(r.history_count, _FIT_HISTORY)
        return cls(SuperquadricReport._from_c(r.sq), DistanceStats._from_c(r.sq_error), DistanceStats._from_c(r.error),
                   r.coarse_iterations, r.iterations, bool(r.converged), r.step, _array(r.history[:count]), r.energy,
                   _array(r.energy_history[:count]), r.min_jacobian, FitStop(r.stop))


# ---- the model -----------------------------------------------------------------------------------

class Model:
    """A fitted shape model (sqffd_model): from fit(), track() or load(). report is the fit's
    FitReport (None for a loaded model). Two models are equal when their saved bytes are."""

    def __init__(self, struct, report=None):
        if not isinstance(struct, _Model):
            raise TypeError("a Model comes from sqffd.fit(), sqffd.track() or sqffd.load()")
        self._struct = struct
        self.report = report

    # -- use
    def mesh(self, n_eta=64, n_omega=128):
        """The closed triangle mesh on an n_eta x n_omega grid (poles included): vertices
        (n_eta n_omega + 2, 3) float64 and triangles (2 n_eta n_omega, 3) uint32."""
        n_eta, n_omega = _integer(_int, n_eta, "n_eta"), _integer(_int, n_omega, "n_omega")
        vertex_count, triangle_count = _size(), _size()
        _check(_lib.sqffd_model_mesh_size(n_eta, n_omega, ctypes.byref(vertex_count), ctypes.byref(triangle_count)),
               "mesh")
        vertices = np.empty((vertex_count.value, 3), dtype=np.float64)
        triangles = np.empty((triangle_count.value, 3), dtype=np.uint32)
        _check(_lib.sqffd_model_mesh(self._struct, n_eta, n_omega, vertices.ctypes.data, triangles.ctypes.data),
               "mesh")
        return vertices, triangles

    def point(self, eta, omega):
        """The model surface point at (eta, omega), eta in [-pi/2, pi/2], omega in [-pi, pi]."""
        point = np.empty(3, dtype=np.float64)
        _check(_lib.sqffd_model_point(self._struct, float(eta), float(omega), point.ctypes.data), "point")
        return point

    def distances(self, points):
        """Each point's distance to the model ("the error" per point) and their DistanceStats."""
        array, view = _points(points)
        return self._distances(array, view, len(array), _lib.sqffd_model_distances_workspace_size,
                               _lib.sqffd_model_distances_view, "distances")

    def reverse_distances(self, points):
        """Model to data: for each vertex of the model's grid mesh (mesh(*model.grid)'s order), the
        distance to the nearest point, and their DistanceStats."""
        vertex_count = _size()
        _check(_lib.sqffd_model_mesh_size(self._struct.grid[0], self._struct.grid[1], ctypes.byref(vertex_count),
                                          None), "reverse_distances")
        array, view = _points(points)
        return self._distances(array, view, vertex_count.value, _lib.sqffd_model_reverse_distances_workspace_size,
                               _lib.sqffd_model_reverse_distances_view, "reverse_distances")

    def _distances(self, array, view, output_count, size_function, function, operation):
        work, work_size = _workspace(size_function, operation, len(array), self._struct)
        per_item = np.empty(output_count, dtype=np.float64)
        stats = _DistanceStats()
        _check(function(self._struct, view, per_item.ctypes.data, ctypes.byref(stats), work.ctypes.data, work_size),
               operation)
        return per_item, DistanceStats._from_c(stats)

    # -- the byte form
    def save(self):
        """The library's byte form of the model (sqffd_model_save: versioned, little-endian, CRC-32)."""
        size = _size()
        _check(_lib.sqffd_model_save_size(self._struct, ctypes.byref(size)), "save")
        buffer = ctypes.create_string_buffer(size.value)
        _check(_lib.sqffd_model_save(self._struct, buffer, size.value), "save")
        return buffer.raw

    @staticmethod
    def load(data):
        """A model from bytes made by save() (or any build's sqffd_model_save)."""
        return load(data)

    def __eq__(self, other):
        return isinstance(other, Model) and self.save() == other.save()

    __hash__ = None

    def __reduce__(self):
        return _unpickle, (self.save(), self.report)

    # -- what it holds
    @property
    def superquadric(self):
        return Superquadric._from_c(self._struct.sq)

    @property
    def grid(self):
        """(n_eta, n_omega) of the model's grid: its fitting points, the mesh of its error and motion."""
        return tuple(self._struct.grid)

    @property
    def lattice(self):
        """Control points per axis (l, m, n)."""
        return tuple(self._struct.ffd.dims)

    @property
    def box_origin(self):
        return _array(self._struct.ffd.origin)

    @property
    def box_edges(self):
        """3 x 3: rows are the box's edge vectors S, T, U."""
        return _array(self._struct.ffd.edges, (3, 3))

    @property
    def control_points(self):
        """(l, m, n, 3): control point P_ijk at [i, j, k]."""
        l, m, n = self.lattice
        return np.ctypeslib.as_array(self._struct.ffd.control)[:l * m * n].reshape(l, m, n, 3).copy()

    def __repr__(self):
        s = self._struct.sq
        error = f", error {100 * self.report.error.rms_relative:.4g}%" if self.report else ""
        return (f"<sqffd.Model size {s.size[0]:.6g} {s.size[1]:.6g} {s.size[2]:.6g}, shape {s.shape[0]:.3g} "
                f"{s.shape[1]:.3g}, lattice {'x'.join(map(str, self.lattice))}{error}>")


def load(data):
    """A Model from the bytes of Model.save() (sqffd_model_load). Raises SqffdError BAD_FORMAT for
    anything but exactly one saved model, INVALID_MODEL for a well-formed record of an invalid one."""
    data = memoryview(data).tobytes()
    model = _Model()
    _check(_lib.sqffd_model_load(ctypes.byref(model), data, len(data)), "load")
    return Model(model)


def _unpickle(data, report):
    model = load(data)
    model.report = report
    return model


# ---- fit and track -------------------------------------------------------------------------------

def fit(points, **options):
    """Fits the model (superquadric, then FFD) to points, an (N, 3) array-like, or (N, >3) with x y z
    in the first three columns (the rest, e.g. an XYZ file's normals, is ignored); float32 and
    float64 arrays are read in place, at any row stride; other input is converted to float64.
    options: sqffd_fit_options fields by name, e.g. lattice=(6, 6, 6),
    alpha=1e-4, max_iterations=50, sq=dict(robust=True, taper=False), progress=callable(stage,
    iteration, error) returning true to cancel. Returns the Model; model.report is its FitReport."""
    array, view = _points(points)
    struct_options = _lib.sqffd_fit_options_default()
    callbacks = []
    _set_options(struct_options, options, "", callbacks)
    work, work_size = _workspace(_lib.sqffd_fit_workspace_size, "fit", len(array), struct_options)
    model, report = _Model(), _FitReport()
    result = _lib.sqffd_fit_view(view, struct_options, model, report, work.ctypes.data, work_size)
    _raise_callback_errors(callbacks)
    _check(result, "fit")
    return Model(model, FitReport._from_c(report))


def track(frames, **options):
    """Tracks the model through a sequence: frames, a list of (N_t, 3) array-likes in time order
    (or wider, x y z first, as fit() takes them).
    Frame 0 gets the whole fit; each later frame keeps its superquadric and box and starts from
    the previous frame's control points, so vertex v of every model's grid mesh is the same
    material point. options: sqffd_track_options fields (fit=dict(...) of fit's options,
    frame_iterations, progress). Returns one Model per frame, each with its FitReport (for frames
    after the first, report.sq is zero and sq_error is the previous model's error on this frame).
    A failure raises SqffdError with .frame the index of the frame that failed."""
    prepared = [_points(frame, f"frames[{t}]") for t, frame in enumerate(frames)]  # (array, view) each
    count = len(prepared)
    frame_views = (_Points * max(count, 1))(*(view for _, view in prepared))
    struct_options = _lib.sqffd_track_options_default()
    callbacks = []
    _set_options(struct_options, options, "", callbacks)
    work, work_size = _workspace(_lib.sqffd_track_view_workspace_size, "track", frame_views, count, struct_options)
    models, reports, done = (_Model * max(count, 1))(), (_FitReport * max(count, 1))(), _size()
    result = _lib.sqffd_track_view(frame_views, count, struct_options, models, reports, ctypes.byref(done),
                                   work.ctypes.data, work_size)
    _raise_callback_errors(callbacks)
    _check(result, "track", done.value)
    return [Model(_Model.from_buffer_copy(models[t]), FitReport._from_c(reports[t])) for t in range(count)]


# ---- short-axis stacks ---------------------------------------------------------------------------

class _Planes:
    """What a Stack and SliceShifts share: the planes' normal and levels (its C count field: _COUNT)."""
    _COUNT = ""

    def __init__(self, struct):
        self._struct = struct

    @property
    def axis(self):
        """The planes' unit normal (its largest component positive)."""
        return _array(self._struct.axis)

    @property
    def levels(self):
        """The planes' positions along the axis (axis . x), ascending."""
        return _array(self._struct.level)[:getattr(self._struct, self._COUNT)]


class Stack(_Planes):
    """sqffd_stack: points on parallel planes, as the contours of cine MRI slices lie. Made by stack_detect()."""
    _COUNT = "planes"

    @property
    def spacing(self):
        """The median gap between neighbouring planes."""
        return self._struct.spacing

    def __repr__(self):
        return f"<sqffd.Stack {self._struct.planes} planes, spacing {self.spacing:.6g}, axis {self.axis.round(6)}>"


class SliceShifts(_Planes):
    """sqffd_slice_shifts: one in-plane shift a slice (breath-hold misregistration). Made by stack_shifts()."""
    _COUNT = "slices"

    @property
    def shifts(self):
        """(slices, 3), world, across the axis: what moves slice k onto the centreline."""
        return np.array(self._struct.shift, dtype=np.float64)[:self._struct.slices]

    @property
    def tolerance(self):
        """A point within it of a level belongs to that slice (a quarter spacing)."""
        return self._struct.tolerance

    def apply(self, points):
        """A float64 copy of points, (N, 3), with each slice's shift added to its points
        (sqffd_stack_shifts_apply), and how many moved; other points stay."""
        moved = np.array(_points(points)[0], dtype=np.float64, order="C")
        count = _size()
        _check(_lib.sqffd_stack_shifts_apply(self._struct, moved.ctypes.data, len(moved), ctypes.byref(count)),
               "slice shifts")
        return moved, count.value

    def __repr__(self):
        return f"<sqffd.SliceShifts {self._struct.slices} slices, largest {np.abs(self.shifts).max(initial=0):.6g}>"


def _stack_array(stacks, count, what):
    """stacks, one Stack per `what` (count of them), as a C array of sqffd_stack."""
    stacks = list(stacks)
    if len(stacks) != count or not all(isinstance(s, Stack) for s in stacks):
        raise TypeError(f"stacks: expected one sqffd.Stack a {what}")
    return (_Stack * max(count, 1))(*(s._struct for s in stacks))


def stack_detect(points):
    """The short-axis stack the points form (listed slice by slice, each contour in drawing order,
    as contour exports list them; sqffd_stack_detect), or None when they do not lie on 3 to 64
    parallel planes."""
    array, view = _points(points)
    struct, found = _Stack(), _int()
    _check(_lib.sqffd_stack_detect_view(view, ctypes.byref(struct), ctypes.byref(found)), "stack")
    return Stack(struct) if found.value else None


def stack_lids(points, stack):
    """The lids that close the stack where Simpson's method closes it (sqffd_stack_lids): (K, 3)
    points on the planes half a spacing beyond the outer slices, filling their contours. Fit or
    track np.vstack((points, lids)) for a model that closes there."""
    array, view = _points(points)
    count = _size()
    _check(_lib.sqffd_stack_lids_view(view, stack._struct, None, 0, ctypes.byref(count)), "stack lids")
    lids = np.empty((count.value, 3))
    _check(_lib.sqffd_stack_lids_view(view, stack._struct, lids.ctypes.data, count.value, ctypes.byref(count)),
           "stack lids")
    return lids


def stack_shifts(frames, stacks):
    """One in-plane shift a slice from the frames' stacks (sqffd_stack_shifts): frames, a list of
    (N_t, 3) contour stacks; stacks, their Stack each. Returns SliceShifts; apply it to every frame
    and fit or track again."""
    prepared = [_points(frame, f"frames[{t}]") for t, frame in enumerate(frames)]
    count = len(prepared)
    structs = _stack_array(stacks, count, "frame")
    views = (_Points * max(count, 1))(*(view for _, view in prepared))
    shifts = _SliceShifts()
    _check(_lib.sqffd_stack_shifts_view(views, structs, count, ctypes.byref(shifts)), "stack shifts")
    return SliceShifts(shifts)


# ---- motion --------------------------------------------------------------------------------------

@dataclasses.dataclass(eq=False)
class SegmentMotion:
    """sqffd_segment_motion: one AHA segment."""
    area: float               # at ED
    mean_displacement: float  # area-weighted
    mean_excursion: float     # area-weighted, inward along the ED normal
    low_motion_share: float   # of its area
    hypokinetic: bool


@dataclasses.dataclass(eq=False)
class Motion:
    """sqffd_motion's outputs and report. Per-vertex arrays follow the models' grid mesh
    (mesh(*model.grid)'s vertex order, M vertices); segments[k] is AHA segment k + 1."""
    volumes: np.ndarray       # (frames,)
    trajectories: np.ndarray  # (frames, M, 3): vertex v in every frame
    displacement: np.ndarray  # (M,) |x(ES) - x(ED)|
    excursion: np.ndarray     # (M,) inward part of that motion along the ED normal
    low_motion: np.ndarray    # (M,) bool
    segment: np.ndarray       # (M,) uint8: AHA segment 1-17, 0 for the valve plane
    ed_frame: int
    es_frame: int
    edv: float
    esv: float
    ejection_fraction: float
    axis: np.ndarray          # unit, base -> apex
    apex: np.ndarray
    length: float
    anterior: np.ndarray
    septum: np.ndarray
    apex_fraction: float      # the options' (wall() places the ES segments with it)
    median_excursion: float
    segments: List[SegmentMotion]


def motion(models, stacks=None, **options):
    """Volumes, ejection fraction, per-vertex motion, low-motion zones and the AHA 17 segments of a
    tracked left ventricle (sqffd_motion), from track()'s models. stacks: the frames' Stack each
    (volumes between each stack's outer planes +- half a spacing, Simpson's extent), or None
    (closed volumes). options: sqffd_motion_options fields: ed_frame, low_motion_fraction,
    hypokinetic_share, apex_fraction, apex_direction=(x, y, z), septum_direction=(x, y, z) (give it
    for a real heart: the points do not carry it)."""
    models = list(models)
    for t, model in enumerate(models):
        if not isinstance(model, Model):
            raise TypeError(f"models[{t}]: expected an sqffd.Model, got {type(model).__name__}")
    count = len(models)
    structs = (_Model * max(count, 1))(*(model._struct for model in models))
    struct_options = _lib.sqffd_motion_options_default()
    _set_options(struct_options, options, "", [])
    if stacks is not None:
        stack_structs = _stack_array(stacks, count, "model")  # (alive until the call returns)
        struct_options.stacks = ctypes.cast(stack_structs, _pointer)
    work, work_size = _workspace(_lib.sqffd_motion_workspace_size, "motion", structs, count)
    vertex_count = _size()
    _check(_lib.sqffd_model_mesh_size(structs[0].grid[0], structs[0].grid[1], ctypes.byref(vertex_count), None),
           "motion")
    m = vertex_count.value
    volumes, trajectories = np.empty(count), np.empty((count, m, 3))
    displacement, excursion = np.empty(m), np.empty(m)
    low_motion, segment = np.empty(m, dtype=np.uint8), np.empty(m, dtype=np.uint8)
    outputs = _MotionOutputs(volumes.ctypes.data, trajectories.ctypes.data, displacement.ctypes.data,
                             excursion.ctypes.data, low_motion.ctypes.data, segment.ctypes.data)
    report = _MotionReport()
    _check(_lib.sqffd_motion(structs, count, struct_options, outputs, report, work.ctypes.data, work_size), "motion")
    segments = [SegmentMotion(s.area, s.mean_displacement, s.mean_excursion, s.low_motion_share, bool(s.hypokinetic))
                for s in report.segments]
    return Motion(volumes, trajectories, displacement, excursion, low_motion.astype(bool), segment,
                  report.ed_frame, report.es_frame, report.edv, report.esv, report.ejection_fraction,
                  _array(report.axis), _array(report.apex), report.length, _array(report.anterior),
                  _array(report.septum), report.apex_fraction, report.median_excursion, segments)


# ---- the heart wall ------------------------------------------------------------------------------

@dataclasses.dataclass(eq=False)
class SegmentWall:
    """sqffd_segment_wall: one AHA segment's wall (thicknesses 0, thickening NaN and not
    dysfunctional where a frame measured none of its vertices)."""
    thickness_ed: float       # over its ED vertices measured at ED, by their ED areas
    thickness_es: float       # over its ES vertices (placed on the ES mesh) measured at ES, by their ES areas
    thickening: float         # thickness_es / thickness_ed - 1
    dysfunctional: bool       # thickening < the options' dysfunctional_thickening


@dataclasses.dataclass(eq=False)
class Wall:
    """sqffd_wall's outputs and report. Per-vertex arrays follow the endocardium's grid mesh (as
    Motion's), NaN where not measured (the valve plane, no epicardium along the normal, a ray
    across the cavity, outside the slices, off the ES wall);
    segments[k] is AHA segment k + 1. Volumes and lengths in the models' units."""
    myocardium: np.ndarray    # (frames,) V_epi - V_endo
    thickness_ed: np.ndarray  # (M,) along the ED endocardium's normal to the ED epicardium
    thickness_es: np.ndarray  # (M,) the same at ES
    thickening: np.ndarray    # (M,) thickness_es / thickness_ed - 1
    myocardium_ed: float
    myocardium_es: float
    global_thickness_ed: float  # over the whole wall (the report's thickness_ed)
    global_thickness_es: float
    global_thickening: float
    measured: int             # wall vertices
    unmeasured: int
    segments: List[SegmentWall]


def _motion_report(motion_result):
    """A Motion's report as the C struct sqffd_wall reads."""
    report = _MotionReport()
    for name in ("ed_frame", "es_frame", "edv", "esv", "ejection_fraction", "length", "apex_fraction",
                 "median_excursion"):
        setattr(report, name, getattr(motion_result, name))
    for name in ("axis", "apex", "anterior", "septum"):
        getattr(report, name)[:] = [float(x) for x in getattr(motion_result, name)]
    for k, s in enumerate(motion_result.segments):
        report.segments[k] = _SegmentMotion(s.area, s.mean_displacement, s.mean_excursion, s.low_motion_share,
                                            int(s.hypokinetic))
    return report


def wall(endo_models, epi_models, motion_result, stacks=None, endo_stacks=None, **options):
    """The heart wall (sqffd_wall) in the endocardium's segment frame: endo_models, track()'s models
    of the cavity's border; epi_models, track()'s models of the wall's outer border, the same frames
    in the same order; motion_result, motion() of endo_models (its ED and ES frames, long axis and
    segments define the AHA segments of both surfaces). stacks: the epicardium's Stack a frame (the
    myocardium between its outer slices +- half a spacing, as motion() measures the cavity), or None
    (closed volumes). endo_stacks: the endocardium's Stack a frame (the thickness in their planes,
    radially from the cavity's centre, between their outer slices, as the slices show the wall), or
    None (along the normals over the whole wall). options: sqffd_wall_options fields (dysfunctional_thickening,
    default 0.2).
    Returns a Wall: the myocardial volume per frame (x 1.05 g/ml for a mass), the wall thickness
    along each endocardial vertex's normal at ED and ES, thickening per vertex, per segment and
    over the wall."""
    endo_models, epi_models, structs = list(endo_models), list(epi_models), []
    for name, models in (("endo_models", endo_models), ("epi_models", epi_models)):
        for t, model in enumerate(models):
            if not isinstance(model, Model):
                raise TypeError(f"{name}[{t}]: expected an sqffd.Model, got {type(model).__name__}")
        structs.append((_Model * max(len(models), 1))(*(model._struct for model in models)))
    count = len(endo_models)
    if len(epi_models) != count:
        raise ValueError(f"epi_models: {len(epi_models)} models, endo_models {count}: one a frame each")
    if not isinstance(motion_result, Motion):
        raise TypeError("motion_result: expected sqffd.motion()'s result")
    struct_options = _lib.sqffd_wall_options_default()
    _set_options(struct_options, options, "", [])
    if stacks is not None:
        stack_structs = _stack_array(stacks, count, "frame")  # (alive until the call returns)
        struct_options.stacks = ctypes.cast(stack_structs, _pointer)
    if endo_stacks is not None:
        endo_stack_structs = _stack_array(endo_stacks, count, "frame")  # (alive until the call returns)
        struct_options.endo_stacks = ctypes.cast(endo_stack_structs, _pointer)
    work, work_size = _workspace(_lib.sqffd_wall_workspace_size, "wall", structs[0], structs[1], count)
    segment = np.ascontiguousarray(motion_result.segment, dtype=np.uint8)
    m = segment.size
    myocardium, thickness_ed, thickness_es, thickening = np.empty(count), np.empty(m), np.empty(m), np.empty(m)
    outputs = _WallOutputs(myocardium.ctypes.data, thickness_ed.ctypes.data, thickness_es.ctypes.data,
                           thickening.ctypes.data)
    report = _WallReport()
    vertex_count = _size()
    _check(_lib.sqffd_model_mesh_size(structs[0][0].grid[0], structs[0][0].grid[1], ctypes.byref(vertex_count), None),
           "wall")
    if vertex_count.value != m:  # (sqffd_wall reads a segment a vertex)
        raise ValueError(f"motion_result: {m} vertices, endo_models' grid mesh {vertex_count.value}: not their motion")
    _check(_lib.sqffd_wall(structs[0], structs[1], count, _motion_report(motion_result), segment.ctypes.data,
                           struct_options, outputs, report, work.ctypes.data, work_size), "wall")
    segments = [SegmentWall(s.thickness_ed, s.thickness_es, s.thickening, bool(s.dysfunctional))
                for s in report.segments]
    return Wall(myocardium, thickness_ed, thickness_es, thickening, report.myocardium_ed, report.myocardium_es,
                report.thickness_ed, report.thickness_es, report.thickening, report.measured, report.unmeasured,
                segments)

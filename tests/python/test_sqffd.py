"""Tests of examples/python/sqffd.py (make test-python): the struct mirrors against the C
compiler's layout, results bit for bit equal to C's (tests/python/reference.c) on the bunny and
the phantom, errors raised for bad input, no memory growth over 1,000 fits.

    python3 tests/python/test_sqffd.py [BUILD_DIR]

BUILD_DIR (default build) holds libsqffd.so, python_layout and python_reference."""

import concurrent.futures
import ctypes
import dataclasses
import io
import os
import pickle
import subprocess
import sys
import tempfile
import unittest

import numpy as np

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
BUILD = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(REPO, "build"))
os.environ.setdefault("SQFFD_LIBRARY", os.path.join(BUILD, "libsqffd.so"))
sys.path.insert(0, os.path.join(REPO, "examples", "python"))
import sqffd  # noqa: E402

REFERENCE = os.path.join(BUILD, "python_reference")
FINDINGS = {}  # figures for the summary line


def reference(*arguments):
    subprocess.run([REFERENCE, *map(str, arguments)], check=True)


def read_report(path):
    """A reference .report / .motion file: {name: value}."""
    with open(path) as f:
        return {name: float(value) for name, value in (line.split() for line in f)}


def flatten(value, prefix=""):
    """A report dataclass as {dotted name: number}, named as reference.c names the C fields."""
    if dataclasses.is_dataclass(value):
        items = {}
        for field in dataclasses.fields(value):
            items.update(flatten(getattr(value, field.name), prefix + field.name + "."))
        return items
    if isinstance(value, (list, np.ndarray)):
        items = {}
        for i, element in enumerate(np.ravel(value) if isinstance(value, np.ndarray) else value):
            items.update(flatten(element, f"{prefix}{i}."))
        return items
    return {prefix[:-1]: float(value)}


def read_ascii_ply_vertices(path):
    """x y z of an ascii PLY's float vertices, rounded to float as the sqffd reader does."""
    with open(path) as f:
        header = []
        for line in f:
            header.append(line.split())
            if header[-1] == ["end_header"]:
                break
        count = next(int(words[2]) for words in header if words[:2] == ["element", "vertex"])
        return np.loadtxt(f, max_rows=count, usecols=(0, 1, 2), dtype=np.float32).astype(np.float64)


class Data:
    """Point sets shared by the tests, made once: the bunny and phantom frames (from reference.c)."""
    directory = None

    @classmethod
    def setup(cls):
        if cls.directory is None:
            cls.directory = tempfile.TemporaryDirectory(prefix="sqffd_python_")
            cls.bunny = read_ascii_ply_vertices(os.path.join(REPO, "tests", "data", "bunny.ply"))
            reference("phantom", cls.directory.name, 4, 3000)
            cls.frames = [np.fromfile(cls.path(f"frame_{t:02d}.f64")).reshape(-1, 3) for t in range(4)]

    @classmethod
    def path(cls, name):
        return os.path.join(cls.directory.name, name)


def setUpModule():
    Data.setup()


def tearDownModule():
    Data.directory.cleanup()


class Layout(unittest.TestCase):
    def test_mirrors_match_the_compiler(self):
        output = subprocess.run([os.path.join(BUILD, "python_layout")], check=True, capture_output=True,
                                text=True).stdout
        sizes, fields, constants = {}, {}, {}
        for words in (line.split() for line in output.splitlines()):
            if words[0] == "struct":
                sizes[words[1]] = int(words[2])
            elif words[0] == "field":
                fields[words[1]] = (int(words[2]), int(words[3]))
            else:
                self.assertEqual(words[0], "const")
                constants[words[1]] = int(words[2])
        for c_name, mirror in sqffd._MIRRORS.items():
            self.assertEqual(ctypes.sizeof(mirror), sizes[c_name], c_name)
            c_fields = {name.split(".", 1)[1]: where for name, where in fields.items()
                        if name.split(".", 1)[0] == c_name}
            mirrored = {name: (getattr(mirror, name).offset, getattr(mirror, name).size) for name, _ in mirror._fields_}
            self.assertEqual(mirrored, c_fields, c_name)
        self.assertEqual(len(sqffd._MIRRORS), len({name.split(".")[0] for name in fields}))
        self.assertEqual((constants["SQFFD_SCALAR_DOUBLE"], constants["SQFFD_SCALAR_FLOAT"]),
                         (sqffd._SCALAR_DOUBLE, sqffd._SCALAR_FLOAT))
        for c_enum in ("sqffd_result", "sqffd_sq_cost", "sqffd_sq_optimizer", "sqffd_regularization", "sqffd_solver",
                       "sqffd_scalar"):
            self.assertEqual(sizes[c_enum], ctypes.sizeof(ctypes.c_int), c_enum)
        self.assertEqual(constants["SQFFD_MAX_LATTICE"], sqffd._MAX_LATTICE)
        self.assertEqual(constants["SQFFD_FIT_HISTORY"], sqffd._FIT_HISTORY)
        self.assertEqual(constants["SQFFD_SEGMENTS"], sqffd._SEGMENTS)
        self.assertEqual(constants["SQFFD_RESULT_COUNT"], len(sqffd.Result))
        for prefix, enum_type in (("SQFFD_ERROR_", sqffd.Result), ("SQFFD_STAGE_", sqffd.Stage),
                                  ("SQFFD_SQ_COST_", sqffd.SqCost), ("SQFFD_SQ_OPTIMIZER_", sqffd.SqOptimizer),
                                  ("SQFFD_REG_", sqffd.Regularization), ("SQFFD_SOLVER_", sqffd.Solver)):
            c_values = {name[len(prefix):]: value for name, value in constants.items() if name.startswith(prefix)}
            if enum_type is sqffd.Result:
                c_values["OK"] = constants["SQFFD_OK"]
            self.assertEqual({member.name: member.value for member in enum_type}, c_values, prefix)


class SameAsC(unittest.TestCase):
    def check_fit(self, name, points, c_options, python_options):
        np.ascontiguousarray(points, dtype=np.float64).tofile(Data.path(name + ".f64"))
        reference("fit", Data.path(name + ".f64"), Data.path(name + "_c"), *c_options)
        model = sqffd.fit(points, **python_options)
        with open(Data.path(name + "_c.model"), "rb") as f:
            self.assertEqual(model.save(), f.read(), name)
        self.assertEqual(flatten(model.report), read_report(Data.path(name + "_c.report")), name)
        return model

    def test_bunny_default_options(self):
        model = self.check_fit("bunny", Data.bunny, [], {})
        FINDINGS["bunny"] = model.report.error.rms_relative

    def test_phantom_other_options(self):
        c_options = ["lattice=4,5,6", "grid=24,48", "alpha=1e-4", "max_iterations=12", "coarse_iterations=7",
                     "model_to_data=0", "regularization=1", "sq.robust=1", "sq.taper=0"]
        python_options = dict(lattice=(4, 5, 6), grid=np.array([24, 48]), alpha=1e-4, max_iterations=12,
                              coarse_iterations=7, model_to_data=0, regularization="position",
                              sq=dict(robust=True, taper=False))
        model = self.check_fit("phantom", Data.frames[0], c_options, python_options)
        self.assertEqual((model.lattice, model.grid), ((4, 5, 6), (24, 48)))
        self.assertTrue(np.all(model.superquadric.taper == 0))

    def test_track_and_motion(self):
        paths = [Data.path(f"frame_{t:02d}.f64") for t in range(len(Data.frames))]
        reference("track", Data.path("track_c"), *paths)
        models = sqffd.track(Data.frames)
        for t, model in enumerate(models):
            with open(Data.path(f"track_c_{t:02d}.model"), "rb") as f:
                self.assertEqual(model.save(), f.read(), f"frame {t}")
            self.assertEqual(flatten(model.report), read_report(Data.path(f"track_c_{t:02d}.report")), f"frame {t}")
        result = sqffd.motion(models, septum_direction=(-1, 0, 0))
        arrays = {"volumes": np.float64, "trajectories": np.float64, "displacement": np.float64,
                  "excursion": np.float64, "low_motion": np.uint8, "segment": np.uint8}
        for name, dtype in arrays.items():
            c_array = np.fromfile(Data.path("track_c." + name), dtype=dtype)
            self.assertTrue(np.array_equal(np.ravel(getattr(result, name)), c_array), name)
        scalars = dataclasses.replace(result, **{name: np.empty(0) for name in arrays})
        self.assertEqual(flatten(scalars), read_report(Data.path("track_c.motion")))
        vertices, _ = models[1].mesh(*models[1].grid)
        self.assertTrue(np.array_equal(result.trajectories[1], vertices))
        FINDINGS["ef"] = result.ejection_fraction


class ModelUse(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.model = sqffd.fit(Data.bunny, max_iterations=5)

    def test_mesh_and_points(self):
        vertices, triangles = self.model.mesh(8, 16)
        self.assertEqual((vertices.shape, triangles.shape, triangles.dtype), ((130, 3), (256, 3), np.uint32))
        self.assertEqual(triangles.max(), 129)
        north_pole = self.model.point(np.pi / 2, 0.0)
        self.assertTrue(np.allclose(vertices[-1], north_pole, rtol=0, atol=1e-9 * np.abs(vertices).max()))
        default_vertices, _ = self.model.mesh()
        self.assertEqual(default_vertices.shape, (64 * 128 + 2, 3))

    def test_distances(self):
        per_point, stats = self.model.distances(Data.bunny)
        self.assertEqual(per_point.shape, (len(Data.bunny),))
        self.assertAlmostEqual(stats.rms_relative, self.model.report.error.rms_relative, delta=1e-12)
        self.assertAlmostEqual(np.sqrt(np.mean(per_point ** 2)), stats.rms, delta=1e-12)
        per_vertex, reverse = self.model.reverse_distances(Data.bunny.tolist())
        self.assertEqual(per_vertex.shape, (32 * 64 + 2,))
        self.assertAlmostEqual(per_vertex.max(), reverse.max, delta=0)

    def test_save_load_pickle(self):
        data = self.model.save()
        self.assertEqual(len(data), 3288)
        for loaded in (sqffd.load(data), sqffd.Model.load(bytearray(data)), pickle.loads(pickle.dumps(self.model))):
            self.assertEqual(loaded, self.model)
            self.assertEqual(loaded.save(), data)
        self.assertIsNone(sqffd.load(data).report)
        report = pickle.loads(pickle.dumps(self.model)).report
        self.assertEqual((report.coarse_iterations, report.iterations), (4, 1))  # (never all coarse)
        self.assertTrue(np.allclose(self.model.superquadric.rotation @ self.model.superquadric.rotation.T, np.eye(3)))
        self.assertEqual(self.model.control_points.shape, (5, 5, 5, 3))

    def test_threads(self):
        serial = sqffd.fit(Data.frames[1], max_iterations=5)
        with concurrent.futures.ThreadPoolExecutor(2) as pool:
            parallel = list(pool.map(lambda _: sqffd.fit(Data.frames[1], max_iterations=5), range(2)))
        self.assertEqual(parallel, [serial, serial])

    def test_options_and_progress(self):
        defaults = sqffd.fit_options_default()
        self.assertEqual((defaults["lattice"], defaults["sq"]["robust"]), ((5, 5, 5), 0))
        self.assertEqual(sqffd.track_options_default()["fit"]["max_iterations"], 100)
        self.assertEqual(sqffd.motion_options_default()["ed_frame"], 0)
        calls = []
        sqffd.fit(Data.bunny, max_iterations=4, coarse_iterations=2, tolerance=0,
                  progress=lambda *call: calls.append(call))
        self.assertEqual([call[:2] for call in calls if call[0] in (sqffd.Stage.COARSE, sqffd.Stage.FFD)],
                         [(sqffd.Stage.COARSE, 1), (sqffd.Stage.COARSE, 2), (sqffd.Stage.FFD, 1), (sqffd.Stage.FFD, 2)])
        self.assertTrue(any(call[0] == sqffd.Stage.SUPERQUADRIC for call in calls))
        with self.assertRaises(sqffd.SqffdError) as caught:
            sqffd.fit(Data.bunny, progress=lambda stage, iteration, error: stage == sqffd.Stage.FFD)
        self.assertEqual(caught.exception.code, sqffd.Result.CANCELLED)

        def failing(stage, iteration, error):
            raise KeyError("from the callback")
        with self.assertRaisesRegex(KeyError, "from the callback"):
            sqffd.track(Data.frames[:2], progress=failing)


class BadInput(unittest.TestCase):
    def assert_code(self, code, function, *arguments, **options):
        with self.assertRaises(sqffd.SqffdError) as caught:
            function(*arguments, **options)
        self.assertEqual(caught.exception.code, code)
        self.assertIn(caught.exception.message, str(caught.exception))
        self.assertEqual(str(pickle.loads(pickle.dumps(caught.exception))), str(caught.exception))
        return caught.exception

    def test_points(self):
        points = Data.bunny.copy()
        points[17, 1] = np.nan
        error = self.assert_code(sqffd.Result.NON_FINITE, sqffd.fit, points)
        self.assertIn("NaN", error.message)
        self.assert_code(sqffd.Result.TOO_FEW_POINTS, sqffd.fit, Data.bunny[:5])
        self.assert_code(sqffd.Result.INVALID_ARGUMENT, sqffd.fit, np.empty((0, 3)))
        self.assert_code(sqffd.Result.DEGENERATE, sqffd.fit, np.tile(Data.bunny[:1], (100, 1)))
        for shape in ((100, 2), (300,), (10, 3, 3), ()):
            with self.assertRaisesRegex(ValueError, r"\(N, 3\)"):
                sqffd.fit(np.zeros(shape))
        with self.assertRaises(ValueError):
            sqffd.fit([["a", "b", "c"]] * 20)

    def test_points_read_in_place(self):
        """float32 arrays and x y z inside wider rows are read where they are (the library's point
        views): the same model, to the byte, as their values as contiguous float64."""
        as_float32 = Data.bunny.astype(np.float32)
        records = np.zeros((len(Data.bunny), 5), dtype=np.float32)  # x y z and two more columns
        records[:, :3] = as_float32
        records[:, 3:] = np.nan  # never read
        expected = sqffd.fit(as_float32.astype(np.float64), max_iterations=5)
        for points in (as_float32, records[:, :3]):
            array, view = sqffd._points(points)
            self.assertEqual(view.xyz, points.ctypes.data)  # no copy
            self.assertEqual(sqffd.fit(points, max_iterations=5).save(), expected.save())
        per_point, _ = expected.distances(records[:, :3])
        self.assertTrue(np.array_equal(per_point, expected.distances(as_float32.astype(np.float64))[0]))
        reversed_rows = Data.bunny[::-1]  # a negative stride: converted, same points
        self.assertNotEqual(sqffd._points(reversed_rows)[1].xyz, reversed_rows.ctypes.data)
        self.assertEqual(len(sqffd._points(reversed_rows)[0]), len(Data.bunny))

    def test_options(self):
        with self.assertRaisesRegex(TypeError, "unknown option 'lattice_size'"):
            sqffd.fit(Data.bunny, lattice_size=4)
        with self.assertRaisesRegex(TypeError, "unknown option 'sq.robustness'"):
            sqffd.fit(Data.bunny, sq=dict(robustness=1))
        with self.assertRaises(TypeError):
            sqffd.fit(Data.bunny, progress_user=None)
        with self.assertRaisesRegex(ValueError, "lattice: expected 3 values"):
            sqffd.fit(Data.bunny, lattice=(5, 5))
        with self.assertRaisesRegex(ValueError, "out of the range"):
            sqffd.fit(Data.bunny, max_iterations=2 ** 32 + 5)
        with self.assertRaisesRegex(ValueError, "out of the range"):
            sqffd.fit(Data.bunny, sq_max_points=-1)
        with self.assertRaisesRegex(TypeError, "max_iterations: expected an integer"):
            sqffd.fit(Data.bunny, max_iterations=2.5)
        with self.assertRaisesRegex(TypeError, "alpha: expected a number"):
            sqffd.fit(Data.bunny, alpha="1e-4")
        with self.assertRaisesRegex(ValueError, "solver: 'qr' is not one of cholesky, svd"):
            sqffd.fit(Data.bunny, solver="qr")
        with self.assertRaises(TypeError):
            sqffd.fit(Data.bunny, sq=True)
        with self.assertRaisesRegex(TypeError, "must be callable"):
            sqffd.fit(Data.bunny, progress=3)
        for options in (dict(alpha=-1.0), dict(alpha=float("nan")), dict(lattice=(1, 5, 5)), dict(lattice=(9, 5, 5)),
                        dict(grid=(1, 64)), dict(max_iterations=-1), dict(regularization=7)):
            self.assert_code(sqffd.Result.INVALID_ARGUMENT, sqffd.fit, Data.bunny, **options)
        self.assert_code(sqffd.Result.INVALID_ARGUMENT, sqffd.motion, [])

    def test_saved_bytes(self):
        data = bytearray(sqffd.fit(Data.bunny, max_iterations=0).save())
        for damaged in (data[:-1], data + b"\0", data[:100], b"", b"SQFFDMDL" + bytes(100)):
            self.assert_code(sqffd.Result.BAD_FORMAT, sqffd.load, bytes(damaged))
        data[200] ^= 0x10
        self.assert_code(sqffd.Result.BAD_FORMAT, sqffd.load, data)
        with self.assertRaises(TypeError):
            sqffd.load(42)
        model = sqffd.fit(Data.bunny, max_iterations=0)
        model._struct.grid[0] = 1  # a stored model that fails validation: no bytes, a code
        self.assert_code(sqffd.Result.INVALID_MODEL, model.save)

    def test_track_frames(self):
        frames = [Data.frames[0], Data.frames[1], Data.frames[2][:3]]
        error = self.assert_code(sqffd.Result.TOO_FEW_POINTS, sqffd.track, frames)
        self.assertEqual(error.frame, 2)
        self.assertIn("(frame 2)", str(error))
        self.assert_code(sqffd.Result.INVALID_ARGUMENT, sqffd.track, [])
        with self.assertRaisesRegex(ValueError, r"frames\[1\]"):
            sqffd.track([Data.frames[0], Data.frames[1][:, :2]])
        with self.assertRaisesRegex(TypeError, r"models\[0\]"):
            sqffd.motion([Data.frames[0]])

    def test_missing_library(self):
        environment = dict(os.environ, SQFFD_LIBRARY=os.path.join(BUILD, "no_such_libsqffd.so"))
        run = subprocess.run([sys.executable, "-c", "import sqffd"], env=environment, capture_output=True, text=True,
                             cwd=os.path.join(REPO, "examples", "python"))
        self.assertNotEqual(run.returncode, 0)
        self.assertIn("ImportError: sqffd: shared library not found at", run.stderr)
        self.assertIn("make shared", run.stderr)


class Memory(unittest.TestCase):
    FITS = 1000

    def test_no_growth_over_many_fits(self):
        points = Data.frames[0][:500]
        page = os.sysconf("SC_PAGE_SIZE")

        def resident():
            with open("/proc/self/statm") as f:
                return int(f.read().split()[1]) * page

        def work():  # a coarse grid and 3 iterations: about 10 ms a fit
            model = sqffd.fit(points, grid=(8, 16), max_iterations=3)
            sqffd.load(model.save()).distances(points)

        for _ in range(50):
            work()
        before = resident()
        for _ in range(self.FITS):
            work()
        growth = resident() - before
        FINDINGS['growth'] = growth
        self.assertLess(growth, 1 << 20, f"resident memory grew by {growth} bytes over {self.FITS} fits")


if __name__ == "__main__":
    stream = io.StringIO()
    result = unittest.TextTestRunner(stream=stream, verbosity=1).run(
        unittest.defaultTestLoader.loadTestsFromModule(sys.modules[__name__]))
    if not result.wasSuccessful():
        print(stream.getvalue(), end="")
        sys.exit(1)
    print(f"python wrapper: {result.testsRun} tests passed (python {sys.version.split()[0]}, numpy {np.__version__}): "
          f"layouts match sqffd.h; fit (bunny {100 * FINDINGS['bunny']:.4f} %, phantom), track and motion "
          f"(EF {100 * FINDINGS['ef']:.1f} %) byte-identical to C; "
          f"resident memory {FINDINGS['growth'] / 1024:+.0f} KB over {Memory.FITS:,} fits")

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
        self.assertEqual(constants["SQFFD_STACK_PLANES"], sqffd._STACK_PLANES)
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


class HeartWall(unittest.TestCase):
    """wall() on the phantom's thick wall (reference.c's frames: the cavity's and the epicardium's,
    4 phases of 3,000 points with 1 % noise), each surface tracked, in the cavity's segment frame."""

    @classmethod
    def setUpClass(cls):
        epi_frames = [np.fromfile(Data.path(f"epi_frame_{t:02d}.f64")).reshape(-1, 3) for t in range(4)]
        cls.endo, cls.epi = sqffd.track(Data.frames), sqffd.track(epi_frames)
        cls.motion = sqffd.motion(cls.endo, septum_direction=(-1, 0, 0))
        cls.wall = sqffd.wall(cls.endo, cls.epi, cls.motion)
        cls.truth = np.fromfile(Data.path("myocardium.f64"))

    def test_mass_and_thickening(self):
        w, m = self.wall, self.motion
        self.assertEqual((m.ed_frame, m.es_frame), (0, 2))  # (phase 0.5: ES)
        self.assertEqual((w.myocardium_ed, w.myocardium_es), (w.myocardium[0], w.myocardium[2]))
        for t in (0, 2):  # the phantom's truth: the closed epicardium less the closed cavity
            self.assertAlmostEqual(w.myocardium[t] / self.truth[t], 1.0, delta=0.02, msg=f"frame {t}")
        valve = m.segment == 0
        self.assertTrue(np.all(np.isnan(w.thickness_ed[valve])) and np.all(np.isnan(w.thickening[valve])))
        measured = ~np.isnan(w.thickening)
        self.assertEqual(int(measured.sum()), w.measured)
        self.assertEqual(int((~valve).sum()), w.measured + w.unmeasured)
        self.assertTrue(np.allclose(w.thickening[measured], w.thickness_es[measured] / w.thickness_ed[measured] - 1))
        # the phantom: 8 mm at ED, 35 % thickening off the hypokinetic zone (in segment 12), 7 % on its plateau
        self.assertAlmostEqual(w.global_thickness_ed, 8.0, delta=0.3)
        self.assertAlmostEqual(w.global_thickening, w.global_thickness_es / w.global_thickness_ed - 1, delta=1e-12)
        for k, s in enumerate(w.segments):
            self.assertEqual(s.dysfunctional, s.thickening < 0.2, f"segment {k + 1}")
        self.assertTrue(w.segments[11].dysfunctional, w.segments[11])
        for k in (7, 8, 9, 13, 14):  # septal and inferior: normal wall, thickening 35 %
            self.assertAlmostEqual(w.segments[k].thickening, 0.35, delta=0.06, msg=f"segment {k + 1}")
        FINDINGS["wall"] = (w.myocardium[0] / self.truth[0], w.myocardium[2] / self.truth[2], w.global_thickening)

    def test_rule_and_refusals(self):
        strict = sqffd.wall(self.endo, self.epi, self.motion, dysfunctional_thickening=0.5)
        self.assertTrue(all(s.dysfunctional for s in strict.segments if s.thickness_ed > 0))
        self.assertTrue(np.array_equal(strict.thickening, self.wall.thickening, equal_nan=True))
        with self.assertRaises(ValueError):
            sqffd.wall(self.endo, self.epi, self.motion, dysfunctional_thickening=-1.0)
        with self.assertRaises(ValueError):
            sqffd.wall(self.endo, self.epi[:3], self.motion)
        with self.assertRaises(TypeError):
            sqffd.wall(self.endo, self.epi, None)
        with self.assertRaises(sqffd.SqffdError) as caught:  # inside out: no epicardium ahead of the normals
            sqffd.wall(self.epi, self.endo, sqffd.motion(self.epi, septum_direction=(-1, 0, 0)))
        self.assertEqual(caught.exception.code, sqffd.Result.DEGENERATE)


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
        for shape in ((100, 2), (300,), (10, 3, 3), (), (100, 0)):
            with self.assertRaisesRegex(ValueError, r"\(N, 3\)"):
                sqffd.fit(np.zeros(shape))
        with self.assertRaises(ValueError):
            sqffd.fit([["a", "b", "c"]] * 20)

    def test_xyz_with_normals(self):
        """An XYZ file with normals, as np.loadtxt reads it ((N, 6): x y z nx ny nz): the first
        three columns are the points (the README's snippet), the same model as the (N, 3) file."""
        normals = Data.bunny / np.linalg.norm(Data.bunny, axis=1)[:, None]
        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, "bunny.xyz")
            np.savetxt(path, np.hstack((Data.bunny, normals)), fmt="%.17g")
            six = np.loadtxt(path)
        self.assertEqual(six.shape, (len(Data.bunny), 6))
        self.assertEqual(sqffd.fit(six, max_iterations=3).save(), sqffd.fit(Data.bunny, max_iterations=3).save())
        models = sqffd.track([np.hstack((frame, np.zeros((len(frame), 2)))) for frame in Data.frames[:2]],
                             frame_iterations=2, fit=dict(max_iterations=2))
        self.assertEqual([m.save() for m in models],
                         [m.save() for m in sqffd.track(Data.frames[:2], frame_iterations=2, fit=dict(max_iterations=2))])

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
        with self.assertRaisesRegex(ValueError, r"solver: 'qr' is not one of cholesky \(0\), svd \(1\)"):
            sqffd.fit(Data.bunny, solver="qr")
        with self.assertRaises(TypeError):
            sqffd.fit(Data.bunny, sq=True)
        with self.assertRaisesRegex(TypeError, "must be callable"):
            sqffd.fit(Data.bunny, progress=3)
        self.assert_code(sqffd.Result.INVALID_ARGUMENT, sqffd.motion, [])

    def test_options_out_of_range_named(self):
        """A value the library refuses is refused here first, the message naming the option and
        its range (the library's own code says only INVALID_ARGUMENT)."""
        cases = [(sqffd.fit, dict(alpha=-1), r"^alpha = -1\.0 is out of its range \[0, 1e\+12\]$"),
                 (sqffd.fit, dict(alpha=float("nan")), r"^alpha = nan is out of its range \[0, 1e\+12\]$"),
                 (sqffd.fit, dict(min_jacobian=2), r"^min_jacobian = 2\.0 is out of its range \[-inf, 1\]$"),
                 (sqffd.fit, dict(lattice=(5, 9, 5)), r"^lattice\[1\] = 9 is out of its range \[2, 8\]$"),
                 (sqffd.fit, dict(grid=(1, 64)), r"^grid\[0\] = 1 is out of its range \[2, 65536\]$"),
                 (sqffd.fit, dict(max_iterations=-1), r"^max_iterations = -1 is out of its range"),
                 (sqffd.fit, dict(sq=dict(taper_max=1.0)), r"^sq\.taper_max = 1\.0 is out of its range \[0, 1\)$"),
                 (sqffd.fit, dict(sq=dict(shape_min=1.5, shape_max=1.2)), r"^sq\.shape_min = 1\.5 is above sq\.shape_max"),
                 (sqffd.fit, dict(sq=dict(robust=True, robust_rounds=0)), r"^sq\.robust_rounds = 0 .* with sq\.robust$"),
                 (sqffd.fit, dict(regularization=7), r"^regularization: 7 is not one of displacement \(0\), position"),
                 (sqffd.track, dict(fit=dict(tether=float("inf"))), r"^fit\.tether = inf is out of its range"),
                 (sqffd.track, dict(frame_iterations=-1), r"^frame_iterations = -1 is out of its range"),
                 (sqffd.motion, dict(hypokinetic_share=1.5), r"^hypokinetic_share = 1\.5 is out of its range \[0, 1\]$")]
        for function, options, message in cases:
            with self.subTest(options=options), self.assertRaisesRegex(ValueError, message):
                function([Data.bunny] if function is sqffd.track else [] if function is sqffd.motion else Data.bunny,
                         **options)

    def test_option_ranges_are_the_librarys(self):
        """Every bound of the module's table (sqffd._OPTION_RANGES) against the library, the module's
        check bypassed: a value at a closed bound or just inside an open one is accepted, one just
        outside (and NaN) refused. A range changed in sqffd.h and not in the table fails here."""
        model = sqffd.fit(Data.frames[0], max_iterations=0)
        view = sqffd._points(Data.frames[0])[1]

        def library_accepts(struct_type, field, index, value):
            options = {field: value if index is None else
                       tuple(value if i == index else d for i, d in enumerate(defaults[struct_type][field]))}
            if field == "shape_max":  # (shape_min <= shape_max, across the fields)
                options["shape_min"] = min(value, 0.1) if value == value else 0.1
            elif field == "shape_min":
                options["shape_max"] = max(value, 1.9) if value == value else 1.9
            if struct_type is sqffd._MotionOptions:
                try:
                    sqffd.motion([model], **options)
                    return True
                except sqffd.SqffdError:
                    return False
            if struct_type is sqffd._WallOptions:  # (a wall of one surface measures nothing: DEGENERATE, not refused)
                try:
                    sqffd.wall([model], [model], sqffd.motion([model]), **options)
                    return True
                except sqffd.SqffdError as error:
                    return error.code != sqffd.Result.INVALID_ARGUMENT
            track = sqffd._lib.sqffd_track_options_default()
            nested = {sqffd._TrackOptions: {}, sqffd._FitOptions: {"fit": options},
                      sqffd._SqFitOptions: {"fit": {"sq": options}}}[struct_type] or options
            sqffd._set_options(track, nested, "", [])
            size = ctypes.c_size_t()
            return sqffd._lib.sqffd_track_view_workspace_size(ctypes.byref(view), 1, track, ctypes.byref(size)) == 0

        defaults = {sqffd._FitOptions: sqffd.fit_options_default(), sqffd._SqFitOptions: sqffd.fit_options_default()["sq"],
                    sqffd._TrackOptions: sqffd.track_options_default(), sqffd._MotionOptions: sqffd.motion_options_default(),
                    sqffd._WallOptions: sqffd.wall_options_default()}
        checked = 0
        original = sqffd._check_options
        sqffd._check_options = lambda struct, prefix="": None
        try:
            for struct_type, ranges in sqffd._OPTION_RANGES.items():
                ctypes_of = dict(struct_type._fields_)
                for field, valid in ranges.items():
                    for index, each in (enumerate(valid) if isinstance(valid, tuple) else [(None, valid)]):
                        ctype = ctypes_of[field]._type_ if index is not None else ctypes_of[field]
                        integer = ctype is not ctypes.c_double
                        for bound, is_open, outward in ((each.low, each.low_open, -1), (each.high, each.high_open, 1)):
                            if bound in (-np.inf, np.inf) and integer:
                                continue  # (the C type's limit: _integer's)
                            step = (lambda b, d: b + d) if integer else (lambda b, d: float(np.nextafter(b, d * np.inf)))
                            inside = step(bound, -outward) if is_open else bound
                            outside = bound if is_open else (None if bound in (-np.inf, np.inf) else step(bound, outward))
                            what = f"{struct_type.__name__}.{field}{'' if index is None else [index]}"
                            self.assertTrue(library_accepts(struct_type, field, index, inside), f"{what} = {inside!r}")
                            if outside is not None:
                                self.assertFalse(library_accepts(struct_type, field, index, outside), f"{what} = {outside!r}")
                            checked += 1
                        if not integer:
                            self.assertFalse(library_accepts(struct_type, field, index, float("nan")), f"{field} = nan")
        finally:
            sqffd._check_options = original
        FINDINGS["option_bounds"] = checked

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


class Stacks(unittest.TestCase):
    @staticmethod
    def circles(radii, levels, centres, rotation, per_slice=64):
        """A stack of circles slice by slice (in drawing order), rotated: x = rotation @ local."""
        theta = 2 * np.pi * np.arange(per_slice) / per_slice
        local = np.vstack([np.column_stack((cx + r * np.cos(theta), cy + r * np.sin(theta), np.full(per_slice, z)))
                           for r, z, (cx, cy) in zip(radii, levels, centres)])
        return local @ rotation.T

    def test_stack_of_circles(self):
        rotation, _ = np.linalg.qr(np.random.default_rng(31).normal(size=(3, 3)))
        radii, levels = 10.0 + np.arange(6), 8.0 * np.arange(6)
        points = self.circles(radii, levels, [(3.0, -4.0)] * 6, rotation)
        found = sqffd.stack_detect(points)
        normal = rotation[:, 2] * np.sign(rotation[np.argmax(np.abs(rotation[:, 2])), 2])  # largest component > 0
        self.assertTrue(np.allclose(found.axis, normal, rtol=0, atol=1e-12))
        offset = normal @ rotation @ np.array([3.0, -4.0, 0.0])
        along = np.sort((levels if normal @ rotation[:, 2] > 0 else -levels) + offset)
        self.assertTrue(np.allclose(found.levels, along, rtol=0, atol=1e-9))
        self.assertAlmostEqual(found.spacing, 8.0, delta=1e-9)
        lids = sqffd.stack_lids(points, found)
        local = lids @ rotation  # back to the stack's frame
        ends = np.where(np.abs(local[:, 2] - 44.0) < 1e-9, 1, np.where(np.abs(local[:, 2] + 4.0) < 1e-9, 0, -1))
        self.assertTrue(np.all(ends >= 0), "a lid point off the planes half a spacing beyond the outer slices")
        share = np.hypot(local[:, 0] - 3.0, local[:, 1] + 4.0) / np.where(ends == 1, 15.0, 10.0)
        rings = np.rint(4 * (1 - share)).astype(int)
        self.assertTrue(np.allclose(share, 1 - rings / 4, rtol=0, atol=1e-9))
        for end in (0, 1):  # the ring itself, then every 2nd, 3rd and 4th point at 3/4, 1/2, 1/4 of its radius
            self.assertEqual(np.bincount(rings[ends == end], minlength=4).tolist(), [64, 32, 22, 16])
        self.assertIsNone(sqffd.stack_detect(np.random.default_rng(5).normal(size=(300, 3))))

    def test_slice_shifts_exact(self):
        rotation, _ = np.linalg.qr(np.random.default_rng(29).normal(size=(3, 3)))
        k = np.arange(8.0)
        q, _ = np.linalg.qr(np.vander(k, 5, increasing=True))  # columns 3 and 4: orthogonal to 1, k, k^2
        jumps = np.column_stack((0.5 * q[:, 3], -0.4 * q[:, 4], np.zeros(8)))
        frames = []
        for t, (bend, radius) in enumerate(((0.02, 15.0), (-0.01, 12.0))):
            z = 5.0 * k
            centres = np.column_stack((1.0 + bend * z * z, -2.0 + 0.1 * z)) + jumps[:, :2]
            frames.append(self.circles(radius + 0.2 * z, z + 100.0, centres, rotation))
        stacks = [sqffd.stack_detect(frame) for frame in frames]
        shifts = sqffd.stack_shifts(frames, stacks)
        order = slice(None) if shifts.axis @ rotation[:, 2] > 0 else slice(None, None, -1)
        self.assertTrue(np.allclose(shifts.shifts, -(jumps @ rotation.T)[order], rtol=0, atol=1e-9))
        moved, count = shifts.apply(frames[0])
        self.assertEqual(count, len(frames[0]))
        again = sqffd.stack_shifts([moved, shifts.apply(frames[1])[0]], stacks)
        self.assertTrue(np.allclose(again.shifts, 0.0, rtol=0, atol=1e-9))
        with self.assertRaises(TypeError):
            sqffd.stack_shifts(frames, stacks[:1])
        broken = frames[0].copy()
        broken[5, 2] = np.nan
        self.assert_code(sqffd.Result.NON_FINITE, sqffd.stack_shifts, [broken], stacks[:1])

    def assert_code(self, code, function, *arguments):
        with self.assertRaises(sqffd.SqffdError) as raised:
            function(*arguments)
        self.assertEqual(raised.exception.code, code)
        return raised.exception

    def test_stack_pipeline_same_as_c(self):
        """Stacks, slice shifts, lids, track and motion between the stacks: the C pipeline's bytes."""
        reference("contours", Data.directory.name)
        paths = [Data.path(f"contours_{phase}.f64") for phase in ("ed", "es")]
        reference("stack", Data.path("stack_c"), *paths)
        frames = [np.fromfile(path).reshape(-1, 3) for path in paths]
        stacks = [sqffd.stack_detect(frame) for frame in frames]
        shifts = sqffd.stack_shifts(frames, stacks)
        self.assertTrue(np.array_equal(shifts.shifts.ravel(), np.fromfile(Data.path("stack_c.shifts"))))
        closed = []
        for t, frame in enumerate(frames):
            moved, _ = shifts.apply(frame)
            lids = sqffd.stack_lids(moved, stacks[t])
            self.assertTrue(np.array_equal(lids.ravel(), np.fromfile(Data.path(f"stack_c_{t:02d}.lids"))), f"frame {t}")
            closed.append(np.vstack((moved, lids)))
        models = sqffd.track(closed)
        for t, model in enumerate(models):
            with open(Data.path(f"stack_c_{t:02d}.model"), "rb") as f:
                self.assertEqual(model.save(), f.read(), f"frame {t}")
        result = sqffd.motion(models, stacks=stacks, septum_direction=(-1, 0, 0))
        self.assertTrue(np.array_equal(result.volumes, np.fromfile(Data.path("stack_c.volumes"))))
        self.assertEqual(result.ejection_fraction, read_report(Data.path("stack_c.motion"))["ejection_fraction"])
        closed_volumes = sqffd.motion(models, septum_direction=(-1, 0, 0)).volumes
        self.assertFalse(np.array_equal(result.volumes, closed_volumes))  # the stacks reached the library
        with self.assertRaises(TypeError):
            sqffd.motion(models, stacks=stacks[:1])
        FINDINGS["stack_ef"] = result.ejection_fraction


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
          f"(EF {100 * FINDINGS['ef']:.1f} %) and the stack pipeline (EF {100 * FINDINGS['stack_ef']:.1f} %) "
          f"byte-identical to C; the phantom's wall (myocardium {FINDINGS['wall'][0]:.3f} / {FINDINGS['wall'][1]:.3f} "
          f"of the truth at ED / ES, thickening {100 * FINDINGS['wall'][2]:.1f} %); "
          f"resident memory {FINDINGS['growth'] / 1024:+.0f} KB over {Memory.FITS:,} fits; "
          f"the {FINDINGS['option_bounds']} option bounds the module checks are the library's")

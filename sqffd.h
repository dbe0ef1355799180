/* sqffd.h - v0.20.0 - superquadric + free-form deformation shape fitting
   Public domain or MIT, your choice (see the end of this file).

   Turns 3-D points into a compact global shape model: a superquadric with
   global tapering (13 numbers), refined by a Bernstein free-form deformation
   (FFD) of a control lattice, with the two-step inverse algorithm and its
   regularisation from Bardinet, Cohen & Ayache, "Superquadrics and free-form
   deformations: a global model to fit and track 3D medical data".
   Uses libc (<string.h>, <stddef.h>, <stdint.h>) and libm only: no malloc,
   no FILE, no printf, no globals, no clock. Double precision; deterministic
   (the same input gives bit-identical output).

   USING IT
       Copy sqffd.h into your project. In ONE C or C++ file:
           #define SQFFD_IMPLEMENTATION
           #include "sqffd.h"
       Elsewhere include it without the define.
       SQFFD_STATIC          make every function static (private to one file)
       SQFFD_DEF             linkage of the public functions (extern/static)
       SQFFD_ASSERT(x)       programmer-error checks (default: assert); bad
                             data never asserts, it returns a result code
       SQFFD_MAX_LATTICE     control points per FFD axis at most (default 8, a
                             plain integer); sizes sqffd_ffd and sqffd_model at
                             compile time; translation units built with
                             different values fail to link

   MEMORY
       The library never allocates. Every operation that needs scratch memory
       comes as a pair:
           sqffd_result sqffd_X_workspace_size(..., size_t *size);
           sqffd_result sqffd_X(..., void *workspace, size_t workspace_size);
       The size call takes the operation's arguments that decide the size
       and checks them as the operation would: INVALID_ARGUMENT (or
       INVALID_MODEL) for arguments the operation refuses, TOO_LARGE when
       the size cannot be represented in a size_t; *size is 0 then. Hand in
       at least *size bytes, at any alignment: exactly *size always works,
       one byte less is SQFFD_ERROR_WORKSPACE_TOO_SMALL (and an operation
       whose sizes cannot be represented is TOO_LARGE, whatever the block).
       Nothing is ever written past
       the block or past an output array's documented size. Results (the
       superquadric, the lattice, the model) are plain structs you can keep on
       the stack, copy or store.
       The stack: no function frame over 2 KB and no recursion; sqffd_fit
       and sqffd_track need under 8 KB in all (make stack checks it; the
       measured figures: README.md, "Safety and portability"), plus what
       your progress callback uses.

   RESULTS
       Every fallible call returns sqffd_result: SQFFD_OK (0) or an error,
       named by sqffd_result_string(): INVALID_ARGUMENT, NON_FINITE,
       TOO_FEW_POINTS, DEGENERATE, TOO_LARGE, WORKSPACE_TOO_SMALL,
       NOT_POSITIVE_DEFINITE, NO_CONVERGENCE, CANCELLED, INVALID_MODEL,
       BAD_FORMAT, OUTPUT_TOO_SMALL. Values come back through pointers, never
       as sentinels. Options structs come from sqffd_X_options_default();
       change the fields you care about; a NULL options pointer means the
       defaults, everywhere. Integer types follow one rule: counts of the
       caller's elements (points, frames, vertices, triangles, voxels per
       axis, capacities, indices into them) and byte sizes are size_t; the
       small parameters the library bounds itself (lattice dims, grid, mesh
       and IoU resolutions, iteration counts, and the progress callback's
       iteration, whose frame index is capped at INT32_MAX) and flags are
       int. Every
       operation on points comes in two forms: sqffd_X on packed doubles
       and a count, sqffd_X_view on sqffd_points views (see POINTS); one
       size call serves both where it takes a count, and
       sqffd_track_view_workspace_size takes the views where
       sqffd_track_workspace_size takes counts (sqffd_stack_shifts_apply,
       which moves the caller's points in place, takes packed doubles
       only: a view is read-only). Names are sqffd_<object>_<operation>,
       the object first (sqffd_kdtree_build, sqffd_stack_lids). Long operations
       take a progress callback that may cancel. Stored data is data: a
       superquadric, lattice or model handed in is checked at run time
       (INVALID_MODEL), never by assert.
       Capacities, one convention (as snprintf's): a function that writes
       a number of elements it finds into the caller's array
       (sqffd_kdtree_radius, sqffd_sq_sample_uniform, sqffd_stack_lids,
       sqffd_iso_points) takes the array's capacity in elements and a
       count pointer. *count receives how many there are; capacity 0 only
       counts (the arrays may be NULL); a capacity below the count is
       OUTPUT_TOO_SMALL, found before anything is written: *count is the
       count needed and the arrays are untouched; else all are written.
       Nothing is ever truncated. So: call with capacity 0, allocate *count,
       call again. sqffd_model_save's capacity is in bytes and its count
       comes from sqffd_model_save_size.

   WHAT OUTPUTS HOLD AFTER AN ERROR
       1. Errors found before the work starts (INVALID_ARGUMENT,
          INVALID_MODEL, BAD_FORMAT, TOO_LARGE, WORKSPACE_TOO_SMALL,
          OUTPUT_TOO_SMALL, and NON_FINITE, TOO_FEW_POINTS or DEGENERATE
          found in the input itself): every output is as it was, except
          that a workspace-size call sets *size to 0, OUTPUT_TOO_SMALL sets
          *count to the count needed (see RESULTS: capacities),
          sqffd_kdtree_build zeroes the tree, sqffd_ffd_system_init zeroes
          the system and sqffd_track sets *frames_done.
       2. Errors during the work (NON_FINITE, DEGENERATE, NOT_POSITIVE_DEFINITE
          or NO_CONVERGENCE met midway, CANCELLED): arrays and counts hold
          unspecified values within their documented sizes; a model being
          fitted (sqffd_fit, sqffd_fit_ffd, sqffd_fit_prepared, the frame
          sqffd_track was on) is as it was or a later valid model (the last
          accepted iterate: sqffd_model_validate passes); a report holds what
          was measured up to the error (iterations, history). sqffd_sq_fit,
          sqffd_motion, sqffd_wall and sqffd_model_load write their results
          only on success.
       Nothing is ever written past a documented size, whatever the error.

   QUICK START
       sqffd_fit_options opt = sqffd_fit_options_default();
       size_t size;
       sqffd_model model;
       sqffd_fit_report report;
       if (sqffd_fit_workspace_size(n, &opt, &size) == SQFFD_OK) {
           void *ws = malloc(size);              // or any memory you own
           if (sqffd_fit(points, n, &opt, &model, &report, ws, size) == SQFFD_OK)
               printf("relative RMS error %g\n", report.error.rms_relative);
           free(ws);
       }

   POINTS
       Points go in as packed doubles (x0 y0 z0 x1 y1 z1 ...) or, through
       every function's _view form, as a sqffd_points view read in place:
       float or double x y z at any byte stride and alignment, e.g. inside a
       scanner's records, without a copy. A float view gives the same
       results, to the bit, as its values copied into doubles.

   API BY LAYER (each layer uses only the ones above it)
       X(_a, _b) stands for X, X_a and X_b; X/_a for X and X with its last
       word replaced (sqffd_points_packed/_strided: sqffd_points_packed and
       sqffd_points_strided). A "types:" line lists types, every other name
       is a function. make test checks the list against the declarations
       (tests/check_doc_names.sh): every name declared, every function listed.
   Common
       types: sqffd_result sqffd_progress_fn sqffd_points sqffd_scalar
       sqffd_result_string             description of a result code
       sqffd_points_packed/_strided    a view of points (float or double, any stride)
   1. Linear algebra
       sqffd_sym3_eigen                symmetric 3x3 eigen-decomposition (Jacobi)
       sqffd_cholesky_factor/_solve    Cholesky of an SPD matrix, and solve
       sqffd_svd(_workspace_size)      one-sided Jacobi SVD (QR-preconditioned)
       sqffd_svd_solve(_workspace_size) least squares / pseudo-inverse solve
       sqffd_cg_solve, sqffd_cg_workspace_size, sqffd_cg_options_default
                                       conjugate gradient for SPD systems
       sqffd_ncg_minimize, sqffd_ncg_workspace_size, sqffd_ncg_options_default
                                       nonlinear conjugate gradient with bounds
   2. kd-tree
       types: sqffd_kdtree
       sqffd_kdtree_build(_view), sqffd_kdtree_workspace_size
                                       static 3-D tree over your points
       sqffd_kdtree_refit(_view)       the same tree over moved points, O(n)
       sqffd_kdtree_nearest / _knn / _radius queries
   3. Superquadric
       types: sqffd_superquadric
       sqffd_sq_validate               a stored superquadric's check
       sqffd_sq_inside_outside         inside-outside function F
       sqffd_sq_radial_distance        radial (Euclidean-approximating) distance
       sqffd_sq_point                  surface point and normal at (eta, omega)
       sqffd_sq_sample_grid            regular (eta, omega) sampling
       sqffd_sq_sample_uniform         near-equal-distance sampling
       sqffd_sq_volume, sqffd_sq_iou   volume (closed form), volumetric IoU
       sqffd_sq_fit(_view, _workspace_size), sqffd_sq_fit_options_default
                                       the fit (LM or the paper's CG, robust mode)
   4. Free-form deformation
       types: sqffd_ffd
       sqffd_ffd_init                  regular lattice in a box
       sqffd_ffd_validate              a stored lattice's check
       sqffd_ffd_local / _eval / _deform / _weights
                                       local coordinates, Bernstein evaluation
       sqffd_ffd_jacobian_bound, sqffd_ffd_jacobian_workspace_size
                                       the Jacobian's Bernstein bound: > 0, no fold
   5. Model fit
       types: sqffd_model sqffd_fit_options sqffd_fit_report
       sqffd_fit(_view, _workspace_size), sqffd_fit_options_default
                                       superquadric + FFD two-step fit
       sqffd_model_init, sqffd_fit_ffd(_view, _workspace_size)
                                       FFD stage alone from a given model
       sqffd_model_point, sqffd_model_mesh(_size)
                                       model surface point, triangle mesh
       sqffd_model_validate, sqffd_model_save(_size), sqffd_model_load
                                       a stored model's check; the byte form
       sqffd_model_jacobian_bound, sqffd_model_jacobian_workspace_size
                                       no fold where the model lives: the
                                       certified Jacobian bound on its region
       sqffd_model_distances(_view, _workspace_size)
                                       data-to-model distances ("the error")
       sqffd_model_reverse_distances(_view, _workspace_size)
                                       model-to-data distances
   6. Tracking and motion
       types: sqffd_ffd_system sqffd_stack sqffd_slice_shifts
       sqffd_ffd_system_size/_init, sqffd_fit_prepared(_view, _workspace_size)
                                       the FFD stage against a system prepared once
       sqffd_fit_check_data(_view)     the data checks of a fit, which tracking makes of every frame
       sqffd_track(_view, _workspace_size, _view_workspace_size), sqffd_track_options_default
                                       a sequence: frame 0 whole, then frame to frame
       sqffd_track_frame(_view, _workspace_size)
                                       a stream: one later frame at a time, as sqffd_track
       sqffd_stack_detect(_view)       a short-axis stack's planes (contours on slices)
       sqffd_stack_shifts(_view), sqffd_stack_shifts_apply
                                       breath-hold misregistration: one in-plane shift a slice
       sqffd_stack_lids(_view)         a stack's ends closed as Simpson's method closes them
       sqffd_motion(_workspace_size), sqffd_motion_options_default
                                       volumes (closed or between slices), EF, motion,
                                       low-motion zones, 17 segments
       sqffd_wall(_workspace_size), sqffd_wall_options_default
                                       the heart wall (endo + epi): myocardial volume,
                                       thickness and thickening per segment
   7. Volumes to points
       types: sqffd_volume (a view of a 3-D image: any voxel type, strides, affine)
       sqffd_volume_range, sqffd_volume_otsu
                                       value range, automatic threshold
       sqffd_iso_points, sqffd_iso_workspace_size, sqffd_iso_options_default
                                       iso-surface crossing points of a level or a label
                                       (largest component)
       sqffd_points_subsample(_view)   an even subsample of points

   CHANGES: see CHANGELOG.md
*/
#ifndef SQFFD_H
#define SQFFD_H

#include <stddef.h>
#include <stdint.h>

#define SQFFD_VERSION_MAJOR 0
#define SQFFD_VERSION_MINOR 20
#define SQFFD_VERSION_PATCH 0
#define SQFFD_VERSION_STRING "0.20.0"

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
    X(SQFFD_ERROR_NON_FINITE, "input contains NaN, infinity or a value too large to compute with") \
    X(SQFFD_ERROR_TOO_FEW_POINTS, "too few points for this operation")               \
    X(SQFFD_ERROR_DEGENERATE, "degenerate input: points coincident, collinear or coplanar") \
    X(SQFFD_ERROR_TOO_LARGE, "size beyond what the library can index or a size_t can hold") \
    X(SQFFD_ERROR_WORKSPACE_TOO_SMALL, "workspace smaller than the matching _workspace_size()") \
    X(SQFFD_ERROR_NOT_POSITIVE_DEFINITE, "matrix is not symmetric positive definite") \
    X(SQFFD_ERROR_NO_CONVERGENCE, "iteration did not converge within its limit")     \
    X(SQFFD_ERROR_CANCELLED, "cancelled by the progress callback")                   \
    X(SQFFD_ERROR_INVALID_MODEL, "superquadric, lattice or model out of range, not finite or inconsistent") \
    X(SQFFD_ERROR_BAD_FORMAT, "not a saved model: wrong magic, unknown version, bad checksum or wrong length") \
    X(SQFFD_ERROR_OUTPUT_TOO_SMALL, "output buffer smaller than the size the call reports")

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
    SQFFD_STAGE_FFD = 2,          /* FFD two-step iteration: error = relative RMS error */
    SQFFD_STAGE_FRAME = 3,        /* sqffd_track, before each frame: iteration = the frame's index,
                                     error = the previous frame's relative RMS error (0 before frame 0) */
    SQFFD_STAGE_COARSE = 4        /* sqffd_fit's coarse FFD iterations: error = relative RMS error of the subsample
                                     on the coarse grid */
} sqffd_stage;

/* Called by long operations once per iteration; return non-zero to cancel
   (the operation then returns SQFFD_ERROR_CANCELLED). */
typedef int (*sqffd_progress_fn)(void *user, int stage, int iteration, double error);

/* Points as they lie in the caller's memory, read in place (never copied):
   x, y and z consecutive scalars of one type, one point every `stride`
   bytes from `xyz` (so xyz inside larger records, e.g. a scanner's
   x y z intensity or PCL's x y z _ rgb, is read where it is), at any
   alignment. Every function that takes points has a simple form over packed
   doubles (x0 y0 z0 x1 y1 z1 ...) and a _view form over one of these; a
   float coordinate is widened to double exactly, so a float view gives the
   same results as its values copied into doubles. A view is refused with
   INVALID_ARGUMENT (xyz NULL, an unknown type, a stride below 3 scalars)
   or TOO_LARGE (its last byte beyond what a size_t can address). */
typedef enum sqffd_scalar {
    SQFFD_SCALAR_DOUBLE = 0,
    SQFFD_SCALAR_FLOAT = 1
} sqffd_scalar;

typedef struct sqffd_points {
    const void *xyz;   /* point 0's x; its y and z follow it */
    size_t count;      /* number of points */
    size_t stride;     /* bytes from one point's x to the next one's */
    sqffd_scalar type; /* of x, y and z */
} sqffd_points;

/* The view of n packed double triples (stride 24). */
SQFFD_DEF sqffd_points sqffd_points_packed(const double *xyz, size_t n);
/* The view of n points of any layout (not checked here: the functions
   taking the view check it). */
SQFFD_DEF sqffd_points sqffd_points_strided(const void *xyz, size_t n, size_t stride, sqffd_scalar type);

/* ======================================================================
   Layer 1: linear algebra
   Dense matrices are row-major arrays of doubles. None of these functions
   allocates; those that need scratch memory take a workspace sized by the
   matching _workspace_size() function.
   ====================================================================== */

/* Symmetric 3x3 eigen-decomposition by cyclic Jacobi rotations; exact for
   repeated eigenvalues (any orthonormal basis of the eigenspace is returned).
   Only the upper triangle of `a` is read. `values` ascending; the
   eigenvectors are the COLUMNS of `vectors` (row-major 3x3), orthonormal,
   with det = +1 (a rotation). Deterministic signs: in columns 0 and 1 the
   component of largest magnitude is positive, column 2 = col0 x col1.
   NaN/Inf input gives NaN output (callers validate their data). */
SQFFD_DEF void sqffd_sym3_eigen(const double a[9], double values[3], double vectors[9]);

/* Cholesky factorisation A = L L^T of an n x n symmetric positive definite
   matrix, row-major, in place. Only the lower triangle is read; on success
   the lower triangle holds L and the strict upper triangle is zeroed, so `a`
   is exactly L. Returns SQFFD_ERROR_INVALID_ARGUMENT (a NULL or n < 1),
   SQFFD_ERROR_NON_FINITE (NaN/Inf in the lower triangle, nothing written) or
   SQFFD_ERROR_NOT_POSITIVE_DEFINITE (a pivot <= 0; `a` is then partly
   overwritten). */
SQFFD_DEF sqffd_result sqffd_cholesky_factor(double *a, size_t n);

/* Solves L L^T x = b in place (b becomes x), L from a successful
   sqffd_cholesky_factor. SQFFD_ERROR_INVALID_ARGUMENT (l or b NULL, n < 1;
   b untouched). */
SQFFD_DEF sqffd_result sqffd_cholesky_solve(const double *l, size_t n, double *b);

/* Singular value decomposition A = U diag(s) V^T of a row-major m x n matrix,
   m >= n >= 1, by Householder QR with column pivoting followed by one-sided
   Jacobi on R^T (de Rijk pivoting, relative convergence test).
   u: m x n row-major with orthonormal columns (NULL if not wanted: the
   rotations are then not accumulated, about half the time); s: n singular
   values, descending;
   v: n x n row-major orthogonal (NULL if not wanted). Columns of U and V that
   belong to zero singular values are completed to orthonormal sets.
   Accuracy: ||A - U S V^T|| / ||A|| and max |U^T U - I|, |V^T V - I| are
   ~5e-15 at n = 125; singular values are relatively accurate even for
   graded columns. Singular values below ~1e-154 * max|a_ij| are returned as exactly
   0. Deterministic; leaving out u or v does not change the other outputs.
   Results: SQFFD_ERROR_INVALID_ARGUMENT (a or s NULL, n < 1, m < n),
   SQFFD_ERROR_TOO_LARGE (sizes not representable), SQFFD_ERROR_NON_FINITE,
   SQFFD_ERROR_WORKSPACE_TOO_SMALL (workspace NULL or smaller than
   sqffd_svd_workspace_size(m, n)), SQFFD_ERROR_NO_CONVERGENCE (80 Jacobi
   sweeps were not enough, never seen in practice; the outputs are still
   filled). */
SQFFD_DEF sqffd_result sqffd_svd_workspace_size(size_t m, size_t n, size_t *size);
SQFFD_DEF sqffd_result sqffd_svd(const double *a, size_t m, size_t n, double *u, double *s, double *v,
                                 void *workspace, size_t workspace_size);

/* Least-squares / pseudo-inverse solve x = V diag(1/s_i) U^T b over the
   singular values s_i > rcond * s_0 (all others are treated as zero), from
   the output of sqffd_svd (u and v required). b has m entries, x has n;
   *rank (may be NULL) receives the numerical rank used (0: x = 0).
   INVALID_ARGUMENT (NULL arrays, n < 1, m < n, rcond < 0 or NaN),
   WORKSPACE_TOO_SMALL. */
SQFFD_DEF sqffd_result sqffd_svd_solve_workspace_size(size_t n, size_t *size);
SQFFD_DEF sqffd_result sqffd_svd_solve(const double *u, const double *s, const double *v, size_t m, size_t n,
                                       double rcond, const double *b, double *x, size_t *rank,
                                       void *workspace, size_t workspace_size);

/* Linear conjugate gradient for a symmetric positive definite system A x = b,
   A given as a mat-vec callback (y = A x, y never aliases x). */
typedef void (*sqffd_matvec_fn)(void *user, const double *x, double *y);
typedef struct sqffd_cg_options {
    int max_iterations;            /* 0 (default) = 2 n */
    double tolerance;              /* stop when ||r|| <= tolerance * ||b||, default 1e-10 */
    const double *jacobi_diagonal; /* diagonal of A for the Jacobi preconditioner, NULL = none (default) */
} sqffd_cg_options;
SQFFD_DEF sqffd_cg_options sqffd_cg_options_default(void);
SQFFD_DEF sqffd_result sqffd_cg_workspace_size(size_t n, size_t *size);
/* x: in the starting guess, out the solution. options NULL = defaults.
   iterations and relative_residual (true ||b - A x|| / ||b||, one extra
   mat-vec) may be NULL. Results: SQFFD_ERROR_INVALID_ARGUMENT (NULL pointers,
   n < 1, negative options), SQFFD_ERROR_NON_FINITE (b, x or a mat-vec result),
   SQFFD_ERROR_NOT_POSITIVE_DEFINITE (p^T A p <= 0, or a preconditioner
   diagonal entry <= 0), SQFFD_ERROR_NO_CONVERGENCE (limit reached; x holds
   the last iterate), SQFFD_ERROR_WORKSPACE_TOO_SMALL. */
SQFFD_DEF sqffd_result sqffd_cg_solve(size_t n, sqffd_matvec_fn matvec, void *user, const double *b, double *x,
                                      const sqffd_cg_options *options, int *iterations, double *relative_residual,
                                      void *workspace, size_t workspace_size);

/* Nonlinear conjugate gradient (Polak-Ribiere+, restarted every n steps or
   when the direction stops descending) with a bracketing weak-Wolfe line
   search along the projected path x(t) = project(x + t d).
   f returns f(x) and writes the gradient. options->project (may be NULL)
   clamps x into a feasible set (e.g. a box) in place; it is applied to the
   start point too. options NULL: the defaults.
   Stops with SQFFD_OK when the projected gradient step is small,
   ||project(x - g) - x||_inf <= tolerance * (1 + |f|), or when no step can
   decrease f any more at machine precision; SQFFD_ERROR_NO_CONVERGENCE after
   max_iterations (x, fx: the last accepted point, usable). options->progress
   (may be NULL) is called once per iteration with stage
   SQFFD_STAGE_SUPERQUADRIC and error = f; non-zero cancels
   (SQFFD_ERROR_CANCELLED, x = the last accepted point). iterations and fx may be NULL.
   Other results: SQFFD_ERROR_INVALID_ARGUMENT (NULL f/x, n < 1,
   max_iterations < 1, tolerance < 0), SQFFD_ERROR_NON_FINITE (x or f/gradient
   at the start point), SQFFD_ERROR_WORKSPACE_TOO_SMALL. */
typedef double (*sqffd_objective_fn)(void *user, const double *x, double *gradient);
typedef void (*sqffd_project_fn)(void *user, double *x);
typedef struct sqffd_ncg_options {
    int max_iterations;          /* >= 1 (default 100) */
    double tolerance;            /* >= 0 (default 1e-8) */
    sqffd_project_fn project;    /* called with f's user; NULL (default): unconstrained */
    sqffd_progress_fn progress;  /* NULL (default): none */
    void *progress_user;
} sqffd_ncg_options;
SQFFD_DEF sqffd_ncg_options sqffd_ncg_options_default(void);
SQFFD_DEF sqffd_result sqffd_ncg_workspace_size(size_t n, size_t *size);
SQFFD_DEF sqffd_result sqffd_ncg_minimize(size_t n, sqffd_objective_fn f, void *user, double *x,
                                          const sqffd_ncg_options *options, int *iterations, double *fx,
                                          void *workspace, size_t workspace_size);
/* ======================================================================
   Layer 2: kd-tree
   ====================================================================== */

/* A static 3-D kd-tree over caller points (x y z doubles, 3 per point,
   contiguous). It is built into caller memory (sqffd_kdtree_workspace_size())
   over a permutation of point indices: the points are NOT copied, so they must
   stay alive and unchanged while the tree is used (points that move a
   little, as a deforming surface's do, can take the tree along:
   sqffd_kdtree_refit). Memory: 4 bytes per point for the permutation plus at
   most one 24-byte node per 2.5 points (under 14 bytes per point in all),
   and 3 KB for the build's and the refit's stack. The
   fields are readable but belong to the library. A built tree is read-only:
   any number of threads may query it.

   Splits: the widest side of a node's tight bounding box is cut at its middle
   (so the cut always lies inside the data), each child keeps at least 5 points
   (leaves hold 5 to 10, except the root leaf of a tiny set and leaves of
   identical points, which may be any size), and where those cuts would make
   the tree deeper than SQFFD_KDTREE_MAX_DEPTH allows the node is split at its
   median instead, so degenerate spacing (e.g. exponential) keeps O(log n)
   depth. Every node stores the gap around its cut (the low child's largest
   and the high child's smallest coordinate on the cut axis). Queries walk the
   tree without recursion (a stack of SQFFD_KDTREE_MAX_DEPTH entries), nearest
   side first, and skip a subtree when the sum of the squared per-axis offsets
   from the query to the gaps crossed on the way there (incremental distance)
   exceeds the current answer; that sum is added in the same order as a
   point's distance, so it never exceeds the computed distance of any point
   in the subtree and no point is missed by rounding.

   Example:
       size_t size;
       sqffd_kdtree tree;
       void *memory = sqffd_kdtree_workspace_size(n, &size) == SQFFD_OK ? malloc(size) : NULL;
       if (memory && sqffd_kdtree_build(&tree, points, n, memory, size) == SQFFD_OK)
           sqffd_kdtree_nearest(&tree, query, &nearest, &dist2);

   Query contract shared by nearest / knn / radius:
   - distances are squared Euclidean, computed in double (points farther apart
     than ~1e154 overflow to +inf; results stay defined);
   - a query with a NaN or infinite coordinate is NON_FINITE;
   - equal distances are ordered arbitrarily but deterministically (the same
     tree and query always give the same answer). */

#define SQFFD_KDTREE_MAX_DEPTH 40 /* bound on the leaf depth (and the stacks): 2^32 points need 30 at the median */

/* One node, 24 bytes. Nodes are stored depth-first: an inner node's low child
   is the next node. */
typedef struct sqffd_kdtree_node {
    union {
        struct { double low, high; } split;   /* inner: gap around the cut on `axis` */
        struct { uint32_t begin, end; } leaf; /* leaf: its points are index[begin..end) */
    } u;
    uint32_t high_child; /* inner: node number of the high child; leaf: 0 */
    uint32_t axis;       /* inner: cut axis 0, 1 or 2; leaf: SQFFD_KDTREE_LEAF */
} sqffd_kdtree_node;

#define SQFFD_KDTREE_LEAF 3u

typedef struct sqffd_kdtree {
    sqffd_points points;     /* the caller's points (read in place, not copied) */
    size_t count;            /* number of points */
    uint32_t *index;         /* permutation of 0..count-1; every leaf's points are one range */
    sqffd_kdtree_node *nodes;/* node 0 is the root */
    size_t node_count;       /* nodes used: 1 if count <= 10, else at most 2 (count / 5) - 1 */
    double bbox[2][3];       /* bounding box of all points: [0] = min corner, [1] = max corner */
    void *scratch;           /* the build's and sqffd_kdtree_refit's stack (in the workspace) */
} sqffd_kdtree;

/* Workspace bytes sqffd_kdtree_build() needs for n points (the tree lives in
   it): INVALID_ARGUMENT for n == 0, TOO_LARGE beyond what the tree can
   index (n > UINT32_MAX). */
SQFFD_DEF sqffd_result sqffd_kdtree_workspace_size(size_t n, size_t *size);

/* Builds the tree over points[0 .. 3n) into the workspace (any alignment).
   Returns SQFFD_ERROR_INVALID_ARGUMENT (tree or points NULL, or n == 0),
   SQFFD_ERROR_NON_FINITE (a NaN or infinite coordinate),
   SQFFD_ERROR_TOO_LARGE (n > UINT32_MAX) or SQFFD_ERROR_WORKSPACE_TOO_SMALL
   (a NULL workspace or one smaller than sqffd_kdtree_workspace_size);
   on error *tree is zeroed. Deterministic: the same points give the same tree. */
SQFFD_DEF sqffd_result sqffd_kdtree_build(sqffd_kdtree *tree, const double *points, size_t n,
                                          void *workspace, size_t workspace_size);
/* The same over a view (read in place for the tree's life; n = its count). */
SQFFD_DEF sqffd_result sqffd_kdtree_build_view(sqffd_kdtree *tree, sqffd_points points, void *workspace,
                                               size_t workspace_size);

/* Moves a built tree to new positions of its points: points[3i .. 3i+3) is
   point i as at the build (the array may be another one, of the same count).
   O(n), no workspace: the tree keeps its partition and only its gaps and
   bounding box are measured again, so every query stays exact, but it slows
   down as points cross into each other's former regions (a gap may then be
   an overlap); rebuild when they have moved far. Returns
   SQFFD_ERROR_INVALID_ARGUMENT (tree not built, or points NULL),
   SQFFD_ERROR_NON_FINITE (a NaN or infinite coordinate) or
   SQFFD_ERROR_DEGENERATE (a leaf of once-identical points that are no longer
   identical: rebuild instead); on error the tree is unchanged. */
SQFFD_DEF sqffd_result sqffd_kdtree_refit(sqffd_kdtree *tree, const double *points);
/* The same over a view, which must hold the tree's count of points
   (INVALID_ARGUMENT otherwise). */
SQFFD_DEF sqffd_result sqffd_kdtree_refit_view(sqffd_kdtree *tree, sqffd_points points);

/* The queries. Each answers by increasing distance (indices into the
   caller's points, squared distances), and returns INVALID_ARGUMENT for a
   NULL or unbuilt tree, a NULL query or count pointer, or NULL arrays where
   something would be written; NON_FINITE for a query with a NaN or infinite
   coordinate. On an error the outputs are untouched.
   nearest: *index of the nearest point, its squared distance to *dist2
   (may be NULL). */
SQFFD_DEF sqffd_result sqffd_kdtree_nearest(const sqffd_kdtree *tree, const double query[3], size_t *index,
                                            double *dist2);
/* The k nearest points: *found = min(k, n) of them written (both arrays
   have room for k; k == 0: none). */
SQFFD_DEF sqffd_result sqffd_kdtree_knn(const sqffd_kdtree *tree, const double query[3], size_t k, size_t *indices,
                                        double *dist2, size_t *found);
/* The points within `radius` of query (distance <= radius; INVALID_ARGUMENT
   for a negative or NaN radius): *count = how many there are, all written
   (capacity 0 only counts, the arrays may then be NULL); a capacity below
   the count is OUTPUT_TOO_SMALL (see RESULTS: capacities). */
SQFFD_DEF sqffd_result sqffd_kdtree_radius(const sqffd_kdtree *tree, const double query[3], double radius,
                                           size_t *indices, double *dist2, size_t capacity, size_t *count);
/* ======================================================================
   Layer 3: superquadric with global tapering
   ====================================================================== */

/* A superellipsoid in its own frame, tapered along its local z, then
   rotated and moved:
     local surface at (eta, omega), eta in [-pi/2, pi/2], omega in [-pi, pi]:
       x = a1 c(eta)^e1 c(omega)^e2,  y = a2 c(eta)^e1 s(omega)^e2,  z = a3 s(eta)^e1
       (signed powers: c^e = sign(cos) |cos|^e)
     tapering (Solina): X = (Kx z / a3 + 1) x,  Y = (Ky z / a3 + 1) y,  Z = z
     world = rotation * (X, Y, Z) + center
   rotation is row-major and its COLUMNS are the local x, y, z axes in world
   coordinates (a proper rotation, det +1). */
typedef struct sqffd_superquadric {
    double size[3];     /* a1, a2, a3 > 0: half-extents along the local axes */
    double shape[2];    /* e1 (north-south, along local z), e2 (east-west) */
    double taper[2];    /* Kx, Ky, |K| < 1 */
    double rotation[9];
    double center[3];
} sqffd_superquadric;

/* A valid superquadric (sqffd_sq_validate): sizes positive and at most
   1e150, 0 < e1, e2 <= 4, |Kx|, |Ky| < 1, a centre within +-1e150 on each
   axis, and a proper rotation
   (orthonormal within 1e-6, det +1). Every function below checks it and
   returns INVALID_MODEL otherwise (INVALID_ARGUMENT for NULL pointers). */
SQFFD_DEF sqffd_result sqffd_sq_validate(const sqffd_superquadric *sq);
/* Inside-outside function F (tapering undone first): < 1 inside, 1 on the
   surface, > 1 outside. Computed in logarithms; may be +inf far away (not an
   error). NON_FINITE for a non-finite point, or where F cannot be computed
   (NaN: an exponent near 0 against sizes far apart; *value is then NaN). */
SQFFD_DEF sqffd_result sqffd_sq_inside_outside(const sqffd_superquadric *sq, const double point[3], double *value);
/* Radial distance: |u| |1 - F^(-e1/2)|, u the point in the untapered local
   frame: the distance along the ray from the centre (an approximation of the
   Euclidean distance that is exact for spheres). NON_FINITE for a
   non-finite point, or where F cannot be computed (as above). */
SQFFD_DEF sqffd_result sqffd_sq_radial_distance(const sqffd_superquadric *sq, const double point[3], double *distance);
/* World surface point and outward unit normal at (eta, omega); normal may be
   NULL. The normal is analytic (finite at the poles and for small e).
   NON_FINITE for non-finite angles, or a point or normal that cannot be
   computed (sizes so far apart or so small that the normal's length
   underflows). */
SQFFD_DEF sqffd_result sqffd_sq_point(const sqffd_superquadric *sq, double eta, double omega, double point[3],
                                      double normal[3]);
/* Regular grid: n_eta rows from eta = -pi/2 to pi/2 (poles included), n_omega
   columns from omega = -pi (included) to pi (excluded); row-major, point
   (i, j) at index i * n_omega + j. normals may be NULL. INVALID_ARGUMENT for
   NULL sq/points, n_eta < 2 or n_omega < 1; TOO_LARGE if 3 n_eta n_omega
   doubles do not fit a size_t; NON_FINITE as sqffd_sq_point (the points
   before the first such one written). */
SQFFD_DEF sqffd_result sqffd_sq_sample_grid(const sqffd_superquadric *sq, int n_eta, int n_omega, double *points, double *normals);
/* Near-equal-distance sampling (after Pilu & Fisher): rows of constant eta
   about `spacing` apart (measured on the longest of eight meridians), each
   row walked in omega with steps of about `spacing` (each step searched so
   its chord is the spacing within 10%), so flat and pointy shapes are
   covered evenly. Like Pilu & Fisher's product sampling, a shape much
   longer in x or y than its meridians are elsewhere gets its rows closer
   than `spacing` where the meridians are short. *count = how many points
   the sampling has, all written (capacity 0 only counts, points may then be
   NULL; a capacity below the count is OUTPUT_TOO_SMALL, see RESULTS:
   capacities). INVALID_ARGUMENT for a spacing that is
   not positive and finite, TOO_LARGE for one so small that the count could
   pass ~1e8. */
SQFFD_DEF sqffd_result sqffd_sq_sample_uniform(const sqffd_superquadric *sq, double spacing, double *points,
                                               size_t capacity, size_t *count);
/* Enclosed volume: a1 a2 a3 e1 e2 B(e2/2, e2/2) [B(e1/2, e1+1) + Kx Ky B(3 e1/2, e1+1)]
   (the untapered 2 a1 a2 a3 e1 e2 B(e1/2+1, e1) B(e2/2, e2/2), plus the
   tapering's term from the second moment of the cross-sections in z). */
SQFFD_DEF sqffd_result sqffd_sq_volume(const sqffd_superquadric *sq, double *volume);
/* Deterministic volumetric intersection-over-union of two superquadrics,
   counted at the cell centres of a resolution^3 grid over the union of
   their bounding boxes (48-64 resolve ~0.5%). INVALID_ARGUMENT for
   resolution < 1 or > 4096. */
SQFFD_DEF sqffd_result sqffd_sq_iou(const sqffd_superquadric *a, const sqffd_superquadric *b, int resolution,
                                    double *iou);

typedef enum sqffd_sq_cost {
    SQFFD_SQ_COST_SOLINA = 0, /* sqrt(a1 a2 a3) (F^e1 - 1): the paper's equation (1) family (default) */
    SQFFD_SQ_COST_RADIAL = 1  /* radial distance */
} sqffd_sq_cost;

typedef enum sqffd_sq_optimizer {
    SQFFD_SQ_OPTIMIZER_LM = 0, /* Levenberg-Marquardt, analytic Jacobian (default) */
    SQFFD_SQ_OPTIMIZER_CG = 1  /* the paper's conjugate-gradient descent */
} sqffd_sq_optimizer;

typedef struct sqffd_sq_fit_options {
    sqffd_sq_cost cost;           /* residual of the plain fit (default SOLINA) */
    sqffd_sq_optimizer optimizer; /* default LM */
    int taper;                 /* non-zero (default): fit Kx, Ky (13 parameters); 0: 11 parameters, K = 0 */
    double shape_min, shape_max; /* bounds on e1, e2 (default 0.1, 1.9; 0.01 <= min <= max <= 4) */
    double taper_max;          /* |K| bound (default 0.95, < 1) */
    int max_iterations;        /* per optimiser run (default 100; the CG gets 4 times as many) */
    double tolerance;          /* relative cost decrease that counts as converged (default 1e-5) */
    size_t final_points;       /* plain mode: the winner's last run, after it has converged on a 384-point
                                  subsample, on an even subsample of at most this many points (default 1,536;
                                  0 = all; 384 or fewer: no last run, as sqffd_fit_options_default() sets it) */
    int robust;                /* non-zero: outlier-robust mode (Gaussian + uniform mixture weights) */
    int robust_rounds;         /* EM rounds in robust mode (default 4) */
    sqffd_progress_fn progress;   /* called once per optimiser iteration (may be NULL) */
    void *progress_user;
} sqffd_sq_fit_options;

typedef struct sqffd_sq_fit_report {
    int iterations;       /* total optimiser iterations over all starts and rounds */
    double cost;          /* final sum of (inlier-weighted) squared residuals of `cost`, in data units */
    double rms_radial;    /* RMS radial distance of the (inlier-weighted) points, data units */
    int start;            /* which start won (0 = principal axes as found, e = 1, 1) */
    int converged;        /* the last optimiser run met its tolerance */
    double inlier_fraction; /* robust mode: sum of weights / n; 1 otherwise */
    sqffd_superquadric best_start; /* the start nearest the data (first-order distances on the screening subsample) */
    int fallback;         /* set by sqffd_fit: the fit's error was above best_start's, which was kept (0 here) */
} sqffd_sq_fit_report;

/* Fewest points sqffd_sq_fit accepts (one per parameter). */
#define SQFFD_SQ_FIT_MIN_POINTS 13

SQFFD_DEF sqffd_sq_fit_options sqffd_sq_fit_options_default(void);
/* Bytes of workspace a fit of n points needs with these options (NULL =
   defaults). */
SQFFD_DEF sqffd_result sqffd_sq_fit_workspace_size(size_t n, const sqffd_sq_fit_options *options, size_t *size);
/* Fit a superquadric to n points (x y z each); options NULL = defaults,
   report may be NULL. The data are normalised (centroid, RMS radius); the
   starts come from the moments of inertia (each principal axis as the local
   z, several (e1, e2) seeds, axes turned 45 degrees where two eigenvalues
   are close), are screened on a small subsample, the best ranked by a few
   iterations on a larger one, where the winner runs to convergence, then
   on all points (at most options->final_points of them, evenly spread:
   more move the fit little). Robust mode starts from the points that are
   not isolated (a nearest-neighbour density test), ranks the best starts
   on them, and alternates EM re-weighting with weighted fits of the radial
   distance (on the larger subsample, then on all points). A fit whose RMS radial
   distance exceeds 5% of its mean size (data that are no superquadric) is
   kept within the data's box enlarged by 25%; a close fit may reach past it
   (a partial view). Each size is at least half the data's standard
   deviation along its axis (no collapse into a tiny, fully tapered shape on
   thin, branched data). report->best_start is the start nearest the data
   by first-order distances (sqffd_fit keeps it where the fit ends farther).
   Deterministic.
   Results: INVALID_ARGUMENT (NULL points/sq, bad options), TOO_FEW_POINTS
   (n < SQFFD_SQ_FIT_MIN_POINTS), WORKSPACE_TOO_SMALL (also a NULL workspace),
   NON_FINITE, DEGENERATE (coincident, collinear or coplanar: smallest
   covariance eigenvalue <= 1e-10 of the largest), CANCELLED. On failure
   *sq and *report are not written. */
SQFFD_DEF sqffd_result sqffd_sq_fit(const double *points, size_t n, const sqffd_sq_fit_options *options,
                                    sqffd_superquadric *sq, sqffd_sq_fit_report *report,
                                    void *workspace, size_t workspace_size);
/* The same over a view (n = its count). */
SQFFD_DEF sqffd_result sqffd_sq_fit_view(sqffd_points points, const sqffd_sq_fit_options *options,
                                         sqffd_superquadric *sq, sqffd_sq_fit_report *report, void *workspace,
                                         size_t workspace_size);
/* ======================================================================
   Layer 4: free-form deformation (Bernstein lattice)
   ====================================================================== */

#ifndef SQFFD_MAX_LATTICE
#define SQFFD_MAX_LATTICE 8 /* control points per axis at most; bounds sqffd_ffd's size */
#endif

/* THE LATTICE GUARD. sqffd_ffd's and sqffd_model's layouts, and the range
   of every lattice size (sqffd_fit_options.lattice, a system's dims), depend
   on SQFFD_MAX_LATTICE. A build with another value (a plain integer) renames
   every public function whose arguments or results depend on it (all that
   take or return a lattice, a model, a system, fit or track options, or
   lattice dims), so translation units that disagree fail to link ("undefined
   reference to sqffd_fit_view_lattice6") instead of reading each other's
   structs wrongly. This is the one list: tests/check_lattice_guard.sh checks
   it against every SQFFD_DEF declaration below and links each name across
   a mismatch. */
#if SQFFD_MAX_LATTICE != 8
#define SQFFD__LATTICE_NAME2(name, n) name##_lattice##n
#define SQFFD__LATTICE_NAME(name, n) SQFFD__LATTICE_NAME2(name, n)
#define SQFFD__LATTICE(name) SQFFD__LATTICE_NAME(name, SQFFD_MAX_LATTICE)
#define sqffd_ffd_init SQFFD__LATTICE(sqffd_ffd_init)
#define sqffd_ffd_validate SQFFD__LATTICE(sqffd_ffd_validate)
#define sqffd_ffd_local SQFFD__LATTICE(sqffd_ffd_local)
#define sqffd_ffd_eval SQFFD__LATTICE(sqffd_ffd_eval)
#define sqffd_ffd_deform SQFFD__LATTICE(sqffd_ffd_deform)
#define sqffd_ffd_weights SQFFD__LATTICE(sqffd_ffd_weights)
#define sqffd_ffd_jacobian_workspace_size SQFFD__LATTICE(sqffd_ffd_jacobian_workspace_size)
#define sqffd_ffd_jacobian_bound SQFFD__LATTICE(sqffd_ffd_jacobian_bound)
#define sqffd_fit_options_default SQFFD__LATTICE(sqffd_fit_options_default)
#define sqffd_fit_workspace_size SQFFD__LATTICE(sqffd_fit_workspace_size)
#define sqffd_fit SQFFD__LATTICE(sqffd_fit)
#define sqffd_fit_view SQFFD__LATTICE(sqffd_fit_view)
#define sqffd_model_init SQFFD__LATTICE(sqffd_model_init)
#define sqffd_fit_ffd_workspace_size SQFFD__LATTICE(sqffd_fit_ffd_workspace_size)
#define sqffd_fit_ffd SQFFD__LATTICE(sqffd_fit_ffd)
#define sqffd_fit_ffd_view SQFFD__LATTICE(sqffd_fit_ffd_view)
#define sqffd_model_point SQFFD__LATTICE(sqffd_model_point)
#define sqffd_model_validate SQFFD__LATTICE(sqffd_model_validate)
#define sqffd_model_jacobian_workspace_size SQFFD__LATTICE(sqffd_model_jacobian_workspace_size)
#define sqffd_model_jacobian_bound SQFFD__LATTICE(sqffd_model_jacobian_bound)
#define sqffd_model_save_size SQFFD__LATTICE(sqffd_model_save_size)
#define sqffd_model_save SQFFD__LATTICE(sqffd_model_save)
#define sqffd_model_load SQFFD__LATTICE(sqffd_model_load)
#define sqffd_model_mesh SQFFD__LATTICE(sqffd_model_mesh)
#define sqffd_model_distances_workspace_size SQFFD__LATTICE(sqffd_model_distances_workspace_size)
#define sqffd_model_distances SQFFD__LATTICE(sqffd_model_distances)
#define sqffd_model_distances_view SQFFD__LATTICE(sqffd_model_distances_view)
#define sqffd_model_reverse_distances_workspace_size SQFFD__LATTICE(sqffd_model_reverse_distances_workspace_size)
#define sqffd_model_reverse_distances SQFFD__LATTICE(sqffd_model_reverse_distances)
#define sqffd_model_reverse_distances_view SQFFD__LATTICE(sqffd_model_reverse_distances_view)
#define sqffd_ffd_system_size SQFFD__LATTICE(sqffd_ffd_system_size)
#define sqffd_ffd_system_init SQFFD__LATTICE(sqffd_ffd_system_init)
#define sqffd_fit_prepared_workspace_size SQFFD__LATTICE(sqffd_fit_prepared_workspace_size)
#define sqffd_fit_prepared SQFFD__LATTICE(sqffd_fit_prepared)
#define sqffd_fit_prepared_view SQFFD__LATTICE(sqffd_fit_prepared_view)
#define sqffd_track_options_default SQFFD__LATTICE(sqffd_track_options_default)
#define sqffd_track_workspace_size SQFFD__LATTICE(sqffd_track_workspace_size)
#define sqffd_track SQFFD__LATTICE(sqffd_track)
#define sqffd_track_view_workspace_size SQFFD__LATTICE(sqffd_track_view_workspace_size)
#define sqffd_track_view SQFFD__LATTICE(sqffd_track_view)
#define sqffd_track_frame_workspace_size SQFFD__LATTICE(sqffd_track_frame_workspace_size)
#define sqffd_track_frame SQFFD__LATTICE(sqffd_track_frame)
#define sqffd_track_frame_view SQFFD__LATTICE(sqffd_track_frame_view)
#define sqffd_motion_workspace_size SQFFD__LATTICE(sqffd_motion_workspace_size)
#define sqffd_motion SQFFD__LATTICE(sqffd_motion)
#define sqffd_wall_workspace_size SQFFD__LATTICE(sqffd_wall_workspace_size)
#define sqffd_wall SQFFD__LATTICE(sqffd_wall)
#endif

/* A box (origin + three edge vectors, not necessarily orthogonal) holding an
   l x m x n lattice of control points (Sederberg & Parry); a point with local
   coordinates (s, t, u) maps to
     sum_ijk B_i^{l-1}(s) B_j^{m-1}(t) B_k^{n-1}(u) P_ijk,
   B_i^d(s) = C(d, i) s^i (1 - s)^(d - i). Points outside the box (s, t, u
   outside [0, 1]) follow the same polynomial (no clamping), so the map is
   smooth everywhere; far outside, rounding grows like (|s| + |1 - s|)^degree
   (the weights alternate in sign). The weights come from de Casteljau's
   recurrence: on a face (s = 0 or 1) only that face's control points act,
   and a corner lands exactly on its corner control point. */
typedef struct sqffd_ffd {
    int dims[3];       /* l, m, n: control points per axis, 2..SQFFD_MAX_LATTICE */
    double origin[3];  /* the box corner at (s, t, u) = (0, 0, 0) */
    double edges[9];   /* row-major: rows are the edge vectors S, T, U */
    double inverse[9]; /* set by sqffd_ffd_init: rows T x U, U x S, S x T over det, so stu = inverse (p - origin) */
    double control[SQFFD_MAX_LATTICE * SQFFD_MAX_LATTICE * SQFFD_MAX_LATTICE][3]; /* P_ijk at (i * m + j) * n + k */
} sqffd_ffd;

/* The regular lattice P0: P_ijk = origin + i/(l-1) S + j/(m-1) T + k/(n-1) U,
   which maps every point to itself (linear precision of Bernstein polynomials).
   INVALID_ARGUMENT for NULL or dims out of range, NON_FINITE, DEGENERATE for a
   flat box (|det| <= 1e-12 |S| |T| |U|). */
SQFFD_DEF sqffd_result sqffd_ffd_init(sqffd_ffd *ffd, const int dims[3], const double origin[3], const double edges[9]);
/* A valid lattice: dims in 2..SQFFD_MAX_LATTICE, a box that is not flat,
   `inverse` its inverse (within 1e-9), and the box and the l*m*n control
   points used within +-1e150 on each axis. INVALID_MODEL otherwise. The per-point functions below check the
   dims only (so a stored lattice can never make them index out of bounds)
   and report a non-finite result as NON_FINITE; call sqffd_ffd_validate
   once on a lattice you did not make yourself. */
SQFFD_DEF sqffd_result sqffd_ffd_validate(const sqffd_ffd *ffd);
/* Local (s, t, u) of a world point. */
SQFFD_DEF sqffd_result sqffd_ffd_local(const sqffd_ffd *ffd, const double point[3], double stu[3]);
/* The deformed position of local coordinates (s, t, u). */
SQFFD_DEF sqffd_result sqffd_ffd_eval(const sqffd_ffd *ffd, const double stu[3], double out[3]);
/* Forward deformation of a world point: eval(local(point)). */
SQFFD_DEF sqffd_result sqffd_ffd_deform(const sqffd_ffd *ffd, const double point[3], double out[3]);
/* One row of the matrix B: the l*m*n Bernstein products at (s, t, u), in
   control-point order (weights has room for l*m*n). INVALID_ARGUMENT for
   dims out of 2..SQFFD_MAX_LATTICE. */
SQFFD_DEF sqffd_result sqffd_ffd_weights(const int dims[3], const double stu[3], double *weights);
/* The deformation's Jacobian determinant over the whole box, relative to
   the regular lattice's (the volume ratio: 1 everywhere for P0, det A for an
   affine map A): *min receives the smallest coefficient of its Bernstein
   form, a lower bound of it at every point of the box. *min > 0 proves the
   deformation locally injective on the box: it cannot fold a surface inside
   it. The workspace depends on the dims only (about 20 KB for 5 x 5 x 5;
   INVALID_ARGUMENT for dims outside 2..SQFFD_MAX_LATTICE). INVALID_MODEL
   for a lattice sqffd_ffd_validate rejects, NON_FINITE where the bound
   overflows, WORKSPACE_TOO_SMALL. */
SQFFD_DEF sqffd_result sqffd_ffd_jacobian_workspace_size(const int dims[3], size_t *size);
SQFFD_DEF sqffd_result sqffd_ffd_jacobian_bound(const sqffd_ffd *ffd, double *min, void *workspace,
                                               size_t workspace_size);
/* ======================================================================
   Layer 5: model fit (superquadric + FFD, the paper's two-step algorithm)
   ====================================================================== */

/* The global shape model: 13 superquadric numbers plus the control lattice.
   Model point (eta, omega) = FFD(superquadric point (eta, omega)).
   The model's grid (n_eta x n_omega) places its model points and its mesh,
   evenly over the superquadric's surface whatever its shape: vertex
   i * n_omega + j is (eta_i, omega_j), where row eta_i lies (i + 1) /
   (n_eta + 1) of the way from the south pole to the north along the
   superquadric's meridian (the superellipse of half-width (a1 + a2) / 2,
   half-height a3 and exponent e1, untapered; measured by arc length) and
   column omega_j j / n_omega of the way around its cross-section (a1, a2,
   e2) from omega_0 = -pi; then the south pole (eta = -pi/2) and the
   north pole (eta = pi/2): n_eta n_omega + 2 vertices, 2 n_eta n_omega
   triangles (quads split along their (i, j)-(i+1, j+1) diagonal, fans at the
   poles, outward-facing for a proper superquadric).

   THE ERROR (used everywhere: report, history, progress, distances): for each
   data point, its exact Euclidean distance to the model's triangle mesh on
   the model's grid; the RMS of these over the points, and relative = that RMS
   divided by the diagonal of the data's axis-aligned bounding box. */
typedef struct sqffd_model {
    sqffd_superquadric sq;
    sqffd_ffd ffd;
    int grid[2]; /* n_eta >= 2, n_omega >= 3: the model-point grid of the fit and of the error's mesh */
} sqffd_model;

typedef enum sqffd_regularization {
    SQFFD_REG_DISPLACEMENT = 0, /* alpha ||D (P - P0)||^2: springs on the control-point displacements; keeps the box regular without shrinking it (default) */
    SQFFD_REG_POSITION = 1      /* alpha ||D P||^2: the paper's zero-length springs between lattice neighbours (also shrinks the box) */
} sqffd_regularization;

typedef enum sqffd_solver {
    SQFFD_SOLVER_CHOLESKY = 0,  /* factor a run's first normal matrix, then two CG steps preconditioned by it (refactored
                                   when they fall short); singular (alpha = 0, lattice parts no data reach): SVD (default) */
    SQFFD_SOLVER_SVD = 1        /* every step by the SVD of its normal matrix: pseudo-inverse solution, singular values below 1e-10 of the largest dropped (as the paper's resolution; slower) */
} sqffd_solver;

typedef struct sqffd_fit_options {
    sqffd_sq_fit_options sq;     /* stage 1 (its progress defaults to the one below) */
    int lattice[3];              /* control points per axis, 2..SQFFD_MAX_LATTICE (default 5 x 5 x 5) */
    double box_margin;           /* box = the tapered superquadric's local bounding box, axes along its axes, grown by this fraction per side (default 0.1) */
    int grid[2];                 /* model-point grid n_eta x n_omega (default 32 x 64: 2,050 model points) */
    double alpha;                /* spring weight in [0, SQFFD_FIT_ALPHA_MAX] (default 1e-6): weighs the mean spring energy per control point against the mean squared error per data point (see THE ENERGY below) */
    double tether;               /* weight >= 0 of the pull of every model point toward the superquadric (default 0) */
    sqffd_regularization regularization;
    sqffd_solver solver;
    int max_iterations;          /* two-step iterations at most, all stages (default 33; 0: the superquadric alone,
                                    identity lattice) */
    int coarse_iterations;       /* sqffd_fit only: how many of them (never all) run first on a half-resolution grid
                                    and at most SQFFD_FIT_COARSE_POINTS points: most of the moving at about half the
                                    cost (default 25; 0: none; skipped below 4 model points a control point) */
    double tolerance;            /* stop when the step moves the model points by at most this (RMS / diagonal; default 1e-4;
                                    0 = always max_iterations); under min_jacobian also when the next step's model predicts
                                    the energy to fall by under 10 x this of itself (that step is not taken) */
    double min_jacobian;         /* the floor: every model the fit returns keeps its Jacobian on its region
                                    (sqffd_model_jacobian_bound) at or above this; it cannot fold where it lives (default
                                    0.02; -HUGE_VAL: no floor, the plain two-step iteration) */
    double model_to_data;        /* weight in [0, SQFFD_FIT_MODEL_TO_DATA_MAX] of the model -> data term (THE ENERGY below): holds the parts of the model no
                                    data reach near the data (default 0.02; 0: none; 1: as much as the data -> model term) */
    size_t sq_max_points;        /* stage 1 runs on an even subsample of at most this many points (default 20,000; 0 = all) */
    size_t ffd_max_points;       /* the FFD iterations run on an even subsample of at most this many points (default 200,000; 0 = all); report.error is always over all points */
    sqffd_progress_fn progress;  /* per FFD iteration k = 1, 2, ...: stage SQFFD_STAGE_FFD, error = relative RMS error after it */
    void *progress_user;
} sqffd_fit_options;

/* Distances from points to a model, and their statistics. */
typedef struct sqffd_distance_stats {
    double rms, mean, max;       /* absolute, in the data's units */
    double diagonal;             /* the data's bounding-box diagonal */
    double rms_relative, mean_relative, max_relative; /* divided by diagonal */
} sqffd_distance_stats;

#define SQFFD_FIT_HISTORY 64 /* iterations whose error the report keeps */

typedef enum sqffd_fit_stop {
    SQFFD_FIT_CONVERGED = 0,    /* the last plain step moved the model points by at most the tolerance */
    SQFFD_FIT_CAPPED = 1,       /* max_iterations were done first: not converged */
    SQFFD_FIT_STALLED = 2       /* no further progress: a plain step that did not lower the energy */
} sqffd_fit_stop;
#define SQFFD_FIT_COARSE_POINTS 2000 /* the coarse iterations' subsample (sqffd_fit_options.coarse_iterations) */

typedef struct sqffd_fit_report {
    sqffd_sq_fit_report sq;        /* stage 1 (sqffd_fit only) */
    sqffd_distance_stats sq_error; /* data -> starting model: the superquadric alone for sqffd_fit */
    sqffd_distance_stats error;    /* data -> final model ("the error") */
    int coarse_iterations;         /* two-step iterations done on the coarse grid (sqffd_fit's; before those below) */
    int iterations;                /* two-step iterations done on the model's grid */
    int converged;                 /* the tolerance was reached */
    double step;                   /* RMS move of the model points by the last plain step (before over-relaxing) / diagonal */
    int history_count;
    double history[SQFFD_FIT_HISTORY]; /* relative RMS error after grid iteration 1, 2, ... (over the FFD subsample;
                                          before the last, the passes' own local closest points:
                                          never below the exact error, up to ~15% above it) */
    double energy;                 /* the energy of the final model (THE ENERGY, over the FFD subsample) */
    double energy_history[SQFFD_FIT_HISTORY]; /* after iteration 1, 2, ...: never rising */
    double min_jacobian;           /* the final model's certified Jacobian bound on its region (sqffd_model_jacobian_bound at
                                      options->min_jacobian, or at 0 without a floor; > 0: it folds nowhere on it) */
    sqffd_fit_stop stop;           /* why the iteration ended (a run that stopped at its cap has not converged) */
} sqffd_fit_report;

/* The largest alpha and model_to_data a fit takes (INVALID_ARGUMENT beyond):
   past them the springs, or the model -> data term, drown the data term's
   part of the step's normal matrix in rounding (its Cholesky factor fails
   from alpha ~1e16 on a 2 x 2 x 2 lattice, model_to_data ~1e12), and the
   result is the rigid limit anyway. Every value in the ranges fits. */
#define SQFFD_FIT_ALPHA_MAX 1e12
#define SQFFD_FIT_MODEL_TO_DATA_MAX 100.0

SQFFD_DEF sqffd_fit_options sqffd_fit_options_default(void);
SQFFD_DEF sqffd_result sqffd_fit_workspace_size(size_t n, const sqffd_fit_options *options, size_t *size);
/* Fit the model to n points (x y z each): the superquadric fit, a box around
   it with the regular lattice P0, model points X0 = B P0 on the grid, then the
   two-step iteration that minimises THE ENERGY (see "the least-squares
   problem of step 2" in the implementation, and the README):
     E(P) = 1/n sum_i rho(d_i) + alpha / L ||D (P - P0)||^2 (or ||D P||^2)
            + tether / M sum_v |x_v(P) - x_v(P0)|^2 + model_to_data / H sum_h |x_h - nearest data point|^2
   (h over every other model point in each grid direction and the poles),
   d_i the error of point i, rho(d) = d^2 or in robust mode (options->sq.robust)
   Welsch's nu^2 (1 - exp(-d^2 / nu^2)), over the models whose Jacobian on
   their region (sqffd_model_jacobian_bound: the superquadric's solid, which
   the model's surface and interior map from) stays at or above
   options->min_jacobian: the model cannot fold where it lives. Each
   iteration measures each data point's closest point on the model mesh
   (exact in the first and last pass, a local answer in between). Under the
   floor (the default) it then takes a damped Gauss-Newton step on E (the
   data term by its point-to-plane residuals) with the floor held at
   samples of the region by a penalty, and keeps it when the Jacobian on
   the region is certified at or above the floor and the step lowers E (a
   start that folds on the region, a model handed in, is first drawn
   toward the regular lattice P0 until it is certified: the result is
   certified whenever an iteration runs). Without a floor: (1) each data
   point's displacement, shared among its closest triangle's corners by
   barycentric weight, gives a weighted least-squares bound of E; (2) the
   control points minimising that bound (it cannot raise E), over-relaxed
   (adaptively), a step that raised E replaced by the plain step.
   report->energy_history never rises.
   From the superquadric, the first options->coarse_iterations of the
   iterations run on a coarse grid (half the rows and columns) and an even
   subsample of at most SQFFD_FIT_COARSE_POINTS points, the same energy on
   a coarser mesh at about half the cost; the rest on the grid start
   with an exact pass (report->history and energy_history are theirs; the
   progress callback sees SQFFD_STAGE_COARSE, then SQFFD_STAGE_FFD).
   options NULL: the defaults; report may be NULL. Results: INVALID_ARGUMENT
   (NULL points or model, lattice out of range, grid too coarse to mesh,
   alpha, tether or model_to_data < 0 or NaN, a negative iteration count,
   bad options), TOO_LARGE (grid), NON_FINITE (a NaN or infinite coordinate, or
   one beyond +-1e100), TOO_FEW_POINTS, DEGENERATE,
   WORKSPACE_TOO_SMALL, CANCELLED, and whatever sqffd_sq_fit rejects.
   Stage 1 is sqffd_sq_fit with options->sq (whose defaults here have no
   last run: final_points 384). It is guarded: where the superquadric's
   error is above its best start's (report->sq.best_start) on up to 512 of
   the stage's points (the RMS; robust mode: the third quartile), the start
   is kept and report->sq.fallback set. */
SQFFD_DEF sqffd_result sqffd_fit(const double *points, size_t n, const sqffd_fit_options *options,
                                 sqffd_model *model, sqffd_fit_report *report,
                                 void *workspace, size_t workspace_size);
/* The same over a view (n = its count). */
SQFFD_DEF sqffd_result sqffd_fit_view(sqffd_points points, const sqffd_fit_options *options, sqffd_model *model,
                                      sqffd_fit_report *report, void *workspace, size_t workspace_size);

/* A model around a given superquadric: the box, the regular lattice P0
   (options->lattice, box_margin) and the grid (options->grid); the model
   surface is then the superquadric itself. */
SQFFD_DEF sqffd_result sqffd_model_init(sqffd_model *model, const sqffd_superquadric *sq, const sqffd_fit_options *options);
/* Stage 2 alone: the two-step iteration starting from the model as given (its
   superquadric, box, grid and current control points; the springs' rest
   state P0 is its box's regular lattice). options' lattice, grid, box_margin
   and sq are not used. report->sq_error is the starting model's error.
   Under the floor, a start whose certified Jacobian bound is below
   options->min_jacobian (a model fitted without the floor) is first drawn
   toward P0, P0 + s (P - P0) with the largest s the certificate passes,
   so the result is certified; with max_iterations 0 it is left as given. */
SQFFD_DEF sqffd_result sqffd_fit_ffd_workspace_size(size_t n, const sqffd_model *model, const sqffd_fit_options *options,
                                                    size_t *size);
SQFFD_DEF sqffd_result sqffd_fit_ffd(const double *points, size_t n, const sqffd_fit_options *options, sqffd_model *model,
                                     sqffd_fit_report *report, void *workspace, size_t workspace_size);
SQFFD_DEF sqffd_result sqffd_fit_ffd_view(sqffd_points points, const sqffd_fit_options *options, sqffd_model *model,
                                          sqffd_fit_report *report, void *workspace, size_t workspace_size);

/* The model surface point at (eta, omega). Checks the model as the per-point
   FFD functions check a lattice (the superquadric and the dims); NON_FINITE
   for non-finite angles or result. */
SQFFD_DEF sqffd_result sqffd_model_point(const sqffd_model *model, double eta, double omega, double point[3]);
/* A valid model: sqffd_sq_validate(&sq), sqffd_ffd_validate(&ffd), and a grid
   of 2..65,536 rows and 3..65,536 columns. INVALID_MODEL otherwise. Every
   function taking a model checks this (the per-point ones, less: see
   sqffd_model_point) and returns INVALID_MODEL for a model that fails it. */
SQFFD_DEF sqffd_result sqffd_model_validate(const sqffd_model *model);
/* The model's Jacobian bound where the model lives, the bound the fit
   keeps at or above options->min_jacobian: J (as sqffd_ffd_jacobian_bound's)
   over THE REGION, the cells of the box's 8 x 8 x 8 partition that the
   superquadric's surface passes through (its 32 x 64 mesh) or whose centre
   lies inside it: the superquadric's solid, from which the model's surface
   and interior map, and a band of up to a cell around it. *min receives the
   smallest of J's Bernstein coefficients over those cells, each halved up
   to 4 times where they are below `floor`: *min >= floor proves J >= floor
   on the region, and *min > 0 that the model does not fold there. The
   lattice may fold outside it (at the box's corners, where nothing is
   fitted), which sqffd_ffd_jacobian_bound reports. The workspace depends
   on the dims only (about 0.6 MB for 5 x 5 x 5; INVALID_ARGUMENT for dims
   outside 2..SQFFD_MAX_LATTICE). INVALID_ARGUMENT (NULL model or min, floor
   not finite), INVALID_MODEL (sqffd_model_validate), NON_FINITE,
   WORKSPACE_TOO_SMALL. */
SQFFD_DEF sqffd_result sqffd_model_jacobian_workspace_size(const int dims[3], size_t *size);
SQFFD_DEF sqffd_result sqffd_model_jacobian_bound(const sqffd_model *model, double floor, double *min, void *workspace,
                                                 size_t workspace_size);
/* Save and load: a byte form of a model that any build reads back, whatever
   its endianness or SQFFD_MAX_LATTICE (when the lattice fits it).
   Little-endian throughout:
     0   8 bytes  magic "SQFFDMDL"
     8   u32      format version (1)
     12  u32      total length in bytes
     16  19 f64   superquadric: size[3], shape[2], taper[2], rotation[9], center[3]
     168 3 u32    lattice dims l, m, n
     180 12 f64   box: origin[3], edges[9]
     276 2 u32    grid n_eta, n_omega
     284 3lmn f64 the control points used, in sqffd_ffd's order
     end u32      CRC-32 (IEEE, as zlib's) of every byte before it
   3,288 bytes for a 5 x 5 x 5 lattice. The lattice's inverse is recomputed
   on load. sqffd_model_save_size: the byte count for a valid model;
   INVALID_ARGUMENT (NULL model or size) or INVALID_MODEL otherwise, *size 0
   then. sqffd_model_save: the same results, and OUTPUT_TOO_SMALL when
   capacity is below that count (nothing written).
   sqffd_model_load: BAD_FORMAT for anything but exactly one saved model
   (magic, version, length, checksum), TOO_LARGE for a lattice beyond this
   build's SQFFD_MAX_LATTICE, INVALID_MODEL for a well-formed record whose
   model fails sqffd_model_validate; *model is written only on success. */
SQFFD_DEF sqffd_result sqffd_model_save_size(const sqffd_model *model, size_t *size);
SQFFD_DEF sqffd_result sqffd_model_save(const sqffd_model *model, void *bytes, size_t capacity);
SQFFD_DEF sqffd_result sqffd_model_load(sqffd_model *model, const void *bytes, size_t size);
/* Triangle mesh of the model surface on an n_eta x n_omega grid laid out as
   above (closed, poles included): n_eta n_omega + 2 vertices (x y z each),
   2 n_eta n_omega triangles (3 uint32 indices each). INVALID_ARGUMENT when
   n_eta < 2 or n_omega < 3, TOO_LARGE beyond 65,536 per axis or 2^32 vertices,
   NON_FINITE when a vertex is not finite (a model too extreme to compute
   with; the vertices are then written, the triangles not). vertices or
   triangles may be NULL. */
SQFFD_DEF sqffd_result sqffd_model_mesh_size(int n_eta, int n_omega, size_t *vertex_count, size_t *triangle_count);
SQFFD_DEF sqffd_result sqffd_model_mesh(const sqffd_model *model, int n_eta, int n_omega, double *vertices, uint32_t *triangles);
/* Data-to-model distance of each point ("the error"; per_point may be NULL)
   and statistics, on the model's grid mesh. */
SQFFD_DEF sqffd_result sqffd_model_distances_workspace_size(size_t n, const sqffd_model *model, size_t *size);
SQFFD_DEF sqffd_result sqffd_model_distances(const sqffd_model *model, const double *points, size_t n,
                                             double *per_point, sqffd_distance_stats *stats,
                                             void *workspace, size_t workspace_size);
SQFFD_DEF sqffd_result sqffd_model_distances_view(const sqffd_model *model, sqffd_points points, double *per_point,
                                                  sqffd_distance_stats *stats, void *workspace, size_t workspace_size);
/* Model-to-data: for each vertex of the model's grid mesh (in
   sqffd_model_mesh's order), the distance to the nearest data point
   (per_vertex may be NULL), statistics relative to the data's diagonal.
   Shows whether parts of the model wander off where there is no data. The
   workspace holds a tree over the data. Both distance functions measure on
   model->grid: to measure on another mesh, set grid on a copy of the model. */
SQFFD_DEF sqffd_result sqffd_model_reverse_distances_workspace_size(size_t n, const sqffd_model *model, size_t *size);
SQFFD_DEF sqffd_result sqffd_model_reverse_distances(const sqffd_model *model, const double *points, size_t n,
                                                     double *per_vertex, sqffd_distance_stats *stats,
                                                     void *workspace, size_t workspace_size);
SQFFD_DEF sqffd_result sqffd_model_reverse_distances_view(const sqffd_model *model, sqffd_points points,
                                                          double *per_vertex, sqffd_distance_stats *stats,
                                                          void *workspace, size_t workspace_size);

/* ======================================================================
   Layer 6: tracking and motion
   ====================================================================== */

/* A prepared FFD system: what the FFD stage computes once for a model's
   superquadric, box, lattice and grid (the matrix B of Bernstein weights at
   the model points, the fixed part of the normal matrix: springs and tether),
   kept in caller memory, so that the stage can then run on any point set
   from any control points at no preparation cost (tracking runs it once per
   frame). The fields below record what it was prepared for and are
   read-only; `state` points into the caller's memory block, which must stay
   alive, in place and untouched while the system is used. A prepared system
   is read-only: any number of threads may run against it at once, each with
   its own workspace and model. */
typedef struct sqffd_ffd_system {
    sqffd_superquadric sq;   /* the model's superquadric ... */
    int dims[3];             /* ... its lattice (2..SQFFD_MAX_LATTICE per axis) ... */
    double origin[3], edges[9]; /* ... its box ... */
    int grid[2];             /* ... and its grid */
    double alpha, tether;    /* the options it fixed */
    sqffd_regularization regularization;
    void *state;             /* private */
} sqffd_ffd_system;

/* Memory bytes for a system prepared for this model (its lattice and grid). */
SQFFD_DEF sqffd_result sqffd_ffd_system_size(const sqffd_model *model, size_t *size);
/* Prepares the system for the model's superquadric, box (ffd.dims, origin,
   edges) and grid, and the options' alpha, tether and regularization
   (options NULL: the defaults); the control points are not read. Results:
   INVALID_ARGUMENT (NULL system or model, an invalid model or option),
   NON_FINITE (the superquadric's points), DEGENERATE (a flat box),
   WORKSPACE_TOO_SMALL (memory smaller than sqffd_ffd_system_size). */
SQFFD_DEF sqffd_result sqffd_ffd_system_init(sqffd_ffd_system *system, const sqffd_model *model,
                                             const sqffd_fit_options *options, void *memory, size_t memory_size);
/* Stage 2 against a prepared system: exactly sqffd_fit_ffd (the same
   results to the bit) without the preparation. The model's sq, ffd.dims,
   ffd.origin, ffd.edges and grid must equal the system's (else
   INVALID_ARGUMENT); ffd.control is the start, and receives the result. The
   options' alpha, tether and regularization are the system's (those fields
   are not read); options NULL: the defaults. Other results as sqffd_fit_ffd. */
SQFFD_DEF sqffd_result sqffd_fit_prepared_workspace_size(size_t n, const sqffd_ffd_system *system,
                                                         const sqffd_fit_options *options, size_t *size);
SQFFD_DEF sqffd_result sqffd_fit_prepared(const sqffd_ffd_system *system, const double *points, size_t n,
                                          const sqffd_fit_options *options, sqffd_model *model,
                                          sqffd_fit_report *report, void *workspace, size_t workspace_size);
SQFFD_DEF sqffd_result sqffd_fit_prepared_view(const sqffd_ffd_system *system, sqffd_points points,
                                               const sqffd_fit_options *options, sqffd_model *model,
                                               sqffd_fit_report *report, void *workspace, size_t workspace_size);

/* The checks sqffd_fit makes of its data, without the fit: at least
   SQFFD_SQ_FIT_MIN_POINTS points, every coordinate finite and within
   +-1e100, neither all coincident nor collinear or coplanar (as
   sqffd_sq_fit judges them). sqffd_track makes them of every frame before
   it fits any, and sqffd_track_frame of its frame: a sequence takes the
   frames a lone fit takes, whatever their order. Results: OK,
   INVALID_ARGUMENT (a bad view), TOO_FEW_POINTS, NON_FINITE, DEGENERATE. */
SQFFD_DEF sqffd_result sqffd_fit_check_data(const double *points, size_t n);
SQFFD_DEF sqffd_result sqffd_fit_check_data_view(sqffd_points points);

/* Tracking a sequence (the paper's section 4.2). Frame 0 gets the whole fit
   (sqffd_fit). Every later frame keeps frame 0's superquadric, box, lattice
   and grid (one prepared system for the sequence) and runs the FFD stage
   from the previous frame's control points, so grid point (eta, omega), i.e.
   mesh vertex v of every frame's model, is the same material point in every
   frame: its trajectory is vertex v through the frames, and
   sqffd_motion measures it. */
typedef struct sqffd_track_options {
    sqffd_fit_options fit;       /* frame 0's fit and every frame's FFD stage (fit.progress unused); frame 0 runs to
                                    convergence (max_iterations 100, no coarse stage) so later frames measure motion;
                                    alpha 1e-3, stiffer than a lone fit's, and model_to_data 0: the parts a frame's
                                    data do not reach follow the reached ones instead of being pulled onto the data */
    int frame_iterations;        /* FFD iterations of frames 1, 2, ... at most (default 100: a frame runs to the
                                    tolerance or this cap; ED to ES in one frame under the Jacobian floor takes 50
                                    to a few hundred) */
    sqffd_progress_fn progress;  /* frames (SQFFD_STAGE_FRAME) and, within each, the stages' iterations */
    void *progress_user;
} sqffd_track_options;

SQFFD_DEF sqffd_track_options sqffd_track_options_default(void);
/* Workspace for the whole sequence (one block, reused by every frame):
   counts[0 .. frame_count) are the frames' point counts. */
SQFFD_DEF sqffd_result sqffd_track_workspace_size(const size_t *counts, size_t frame_count,
                                                  const sqffd_track_options *options, size_t *size);
/* Tracks frames[t] (counts[t] points each, x y z) into models[t]; reports
   (may be NULL) gets frame_count reports (frames after the first: sq is
   zero, sq_error is the previous model's error on this frame's points).
   frames_done (may be NULL) receives the number of frames fitted: on an
   error it is the index of the failing frame; models and reports before it
   are complete, those from it on undefined. Every frame's points are
   checked first (sqffd_fit_check_data): a frame that fails them ends the
   call before any fit, *frames_done its index, nothing else written.
   options NULL: defaults.
   Results: INVALID_ARGUMENT (NULL frames, counts or models, frame_count 0,
   a NULL frame, bad options), TOO_FEW_POINTS, NON_FINITE, DEGENERATE (a
   frame's points), WORKSPACE_TOO_SMALL, CANCELLED, and whatever sqffd_fit
   rejects in frame 0. */
SQFFD_DEF sqffd_result sqffd_track(const double *const *frames, const size_t *counts, size_t frame_count,
                                   const sqffd_track_options *options, sqffd_model *models,
                                   sqffd_fit_report *reports, size_t *frames_done,
                                   void *workspace, size_t workspace_size);
/* The same over views, one per frame (INVALID_ARGUMENT for NULL frames, a
   frame's bad view as in sqffd_points); sqffd_track_view_workspace_size
   sizes it from the views' counts, as sqffd_track_workspace_size from
   counts (INVALID_ARGUMENT for NULL frames or an empty one). */
SQFFD_DEF sqffd_result sqffd_track_view_workspace_size(const sqffd_points *frames, size_t frame_count,
                                                       const sqffd_track_options *options, size_t *size);
SQFFD_DEF sqffd_result sqffd_track_view(const sqffd_points *frames, size_t frame_count,
                                        const sqffd_track_options *options, sqffd_model *models,
                                        sqffd_fit_report *reports, size_t *frames_done, void *workspace,
                                        size_t workspace_size);
/* A stream, one frame at a time as it arrives: frame 0 by sqffd_fit_view
   with options->fit, then sqffd_ffd_system_init on its model, then every
   later frame by sqffd_track_frame (n points x y z; sqffd_track_frame_view:
   a view) against that system, with *model the
   previous frame's model on entry (its control points are the start) and
   this frame's on success. Each later frame is what sqffd_track makes of
   it, to the bit: at most options->frame_iterations iterations, no exact
   first pass (a frame starts from its predecessor), options->progress for
   the iterations. The model must be the system's (as in
   sqffd_fit_prepared); the workspace size depends on the point count and
   options->fit's lattice, grid and limits, not on a system, so a stream
   can size its memory once at start-up. */
SQFFD_DEF sqffd_result sqffd_track_frame_workspace_size(size_t n, const sqffd_track_options *options, size_t *size);
SQFFD_DEF sqffd_result sqffd_track_frame(const sqffd_ffd_system *system, const double *points, size_t n,
                                         const sqffd_track_options *options, sqffd_model *model,
                                         sqffd_fit_report *report, void *workspace, size_t workspace_size);
SQFFD_DEF sqffd_result sqffd_track_frame_view(const sqffd_ffd_system *system, sqffd_points points,
                                              const sqffd_track_options *options, sqffd_model *model,
                                              sqffd_fit_report *report, void *workspace, size_t workspace_size);

/* A short-axis stack: points on parallel planes, as the contours of cine
   MRI slices lie (and Simpson's method measures). */
#define SQFFD_STACK_PLANES 64
typedef struct sqffd_stack {
    double axis[3];                    /* unit normal of the planes (its largest component positive) */
    size_t planes;                     /* how many hold points, 3..SQFFD_STACK_PLANES */
    double level[SQFFD_STACK_PLANES];  /* their positions along the axis (axis . x), ascending */
    double spacing;                    /* the median gap between neighbouring planes */
} sqffd_stack;

/* Whether the points form a short-axis stack, listed slice by slice (each
   contour in drawing order, as contour exports list them): the planes'
   normal is that of the steps between consecutive points (those across
   slices, longer than twice the RMS step, left out), and every point must
   lie within 1e-6 of the points' bounding-box diagonal of one of 3 to
   SQFFD_STACK_PLANES planes. *found: 1 and *stack filled, or 0 (stack
   untouched). INVALID_ARGUMENT (NULL stack or found, a bad view),
   NON_FINITE. */
SQFFD_DEF sqffd_result sqffd_stack_detect(const double *points, size_t n, sqffd_stack *stack, int *found);
SQFFD_DEF sqffd_result sqffd_stack_detect_view(sqffd_points points, sqffd_stack *stack, int *found);

/* Breath-hold misregistration. Each slice of a cine stack is acquired in a
   breath-hold of its own, the same for every frame of the cycle; a breath
   held differently moves the whole slice in-plane by a few millimetres.
   One shift a slice, from frame_count frames' stacks (their planes
   parallel; each frame listed slice by slice, each contour in drawing
   order, as sqffd_stack_detect wants them; frames[t]: counts[t] packed
   points, or sqffd_stack_shifts_view: a view each):
   - in each frame, the area centroid of each plane's contour (its points
     within a quarter spacing of the plane, consecutive points forming
     closed runs; a run that encloses nothing counts by its points' mean);
   - the frame's centreline: the least-squares quadratic in the level
     through those centroids (a line with 3 planes). A left ventricle's
     centreline bends smoothly, and a tilt or offset of the whole stack is
     the model's to follow: what the centreline explains is anatomy, the
     jumps between neighbouring slices that it cannot are misregistration;
   - a plane's shift: the centreline less its centroid, averaged over the
     frames that hold a plane at that level (within a quarter spacing).
   A stack of 3 planes gets zeros (nothing tells a jump from a bend); the
   shifts of a slice along a straight or quadratic path are not seen.
   Add shifts->shift[k] to the points of slice k (sqffd_stack_shifts_apply)
   and fit again. INVALID_ARGUMENT (NULL arguments, frame_count 0, a bad
   stack or view, planes not parallel, more than SQFFD_STACK_PLANES
   distinct levels), NON_FINITE; on an error *shifts is zeroed. */
typedef struct sqffd_slice_shifts {
    double axis[3];                        /* the planes' unit normal (the first frame's stack's) */
    size_t slices;                         /* distinct levels over the frames */
    double level[SQFFD_STACK_PLANES];      /* ascending */
    double shift[SQFFD_STACK_PLANES][3];   /* world, across the axis: what moves slice k onto the centreline */
    double tolerance;                      /* a point within it of a level is that slice's: a quarter spacing */
} sqffd_slice_shifts;

SQFFD_DEF sqffd_result sqffd_stack_shifts(const double *const *frames, const size_t *counts, const sqffd_stack *stacks,
                                          size_t frame_count, sqffd_slice_shifts *shifts);
SQFFD_DEF sqffd_result sqffd_stack_shifts_view(const sqffd_points *frames, const sqffd_stack *stacks, size_t frame_count,
                                               sqffd_slice_shifts *shifts);
/* Adds slice k's shift to each of the n packed points (3n doubles) within
   shifts->tolerance of its level, in place (so packed doubles only: a view
   is read-only); other points stay. *moved (may be NULL): how many moved.
   INVALID_ARGUMENT (NULL shifts or points with n > 0), NON_FINITE (a
   point, or a moved one, not finite: then none moves). */
SQFFD_DEF sqffd_result sqffd_stack_shifts_apply(const sqffd_slice_shifts *shifts, double *points, size_t n,
                                                size_t *moved);

/* A stack closed where Simpson's method closes it: the lids, points on
   the planes half a spacing beyond each outer slice, filling its contour
   (the slab faces a thick-slice label map has there). A contour stack is
   open at its ends, and a closed model fitted to it falls short of its
   outer slices (their sections a fraction of the contours' areas); with
   the lids added to the points, the model closes at the extent of
   Simpson's discs. Each lid: the outer slice's points (within a quarter
   spacing of its plane) moved along the axis, then SQFFD_STACK_LID_RINGS
   rings toward the contour's area centroid, ring r at (r + 1) /
   (rings + 1) of the way and every (r + 2)-th point: about 2.1 points a
   contour point. The fill is right for contours star-shaped about their
   centroid (a left ventricle's cavity). *count = how many lid points
   there are, all written to out (3 doubles each; capacity 0 only counts,
   out may then be NULL; a capacity below the count is OUTPUT_TOO_SMALL,
   see RESULTS: capacities). INVALID_ARGUMENT (NULL stack or count, a bad
   stack or view), NON_FINITE (also coordinates too large to compute with). */
#define SQFFD_STACK_LID_RINGS 3
SQFFD_DEF sqffd_result sqffd_stack_lids(const double *points, size_t n, const sqffd_stack *stack, double *out,
                                        size_t capacity, size_t *count);
SQFFD_DEF sqffd_result sqffd_stack_lids_view(sqffd_points points, const sqffd_stack *stack, double *out, size_t capacity,
                                             size_t *count);

/* Motion and function of a tracked left ventricle, from the frames' models
   (sqffd_track's; all with the same superquadric, lattice and grid). Per
   grid point v (sqffd_model_mesh's vertex order on the models' grid, M =
   n_eta n_omega + 2 of them), everything measured on the models' grid mesh:
   - volumes: each frame's closed model volume, exact for the triangle mesh
     (divergence theorem: the sum over its triangles of det(a, b, c) / 6);
     with options->stacks (the frames' short-axis stacks, one each), the
     model's volume between the frame's outer planes each moved out by half
     the spacing: the extent Simpson's method gives its discs (the model
     closes the base above the basal slice, Simpson's stops there), from the
     areas of its sections (Simpson's rule, SQFFD__MOTION_SECTIONS
     intervals);
   - ED: options->ed_frame (default 0); ES: the frame of least volume;
     EDV, ESV, ejection fraction (EDV - ESV) / EDV;
   - displacement[v]: |x_v(ES) - x_v(ED)|; trajectories: x_v in every frame;
     excursion[v]: the inward part of that motion, -(x_v(ES) - x_v(ED)) . n_v
     with n_v the ED mesh's outward normal: the wall motion a reader of
     gated images judges. The data only see motion across the surface: the
     model's points may slide along it differently from the tissue, which
     changes the displacement but not the excursion;
   - the long axis: the ED superquadric's longest axis, pointing from base to
     apex; the apex is the end where the ED model is narrower (the mean
     distance from the axis of its points in the outer fifth of the length),
     unless options->apex_direction is given. f_v in [0, 1]: the position
     along the axis from the apex (0) to the base (1);
   - valve plane: points at the base end (f > 1/2) whose outward normal is
     within 45 degrees of the axis (the lid closing the cavity) are not wall:
     segment 0, never low-motion;
   - segment[v], the AHA 17-segment model (Cerqueira et al., Circulation
     2002): f < apex_fraction is the apex (17); the rest of the axis is cut
     in thirds: apical (13-16, four 90-degree sectors), mid (7-12) and basal
     (1-6, six 60-degree sectors each). The angle turns about the axis from
     the anterior direction (segments 1, 7, 13 are centred on it) toward the
     septum: anterior = septum x axis (with axis base -> apex), so that seen
     from the apex the septum is on the left of anterior, as in the standard
     bull's-eye. options->septum_direction sets it (the default: the ED
     superquadric's first local axis other than the long one, which the
     points alone cannot tie to anatomy: give it for a real heart);
   - low_motion[v] = 1 when excursion[v] < low_motion_fraction x the median
     excursion of the wall points at its level (ten equal bands of f): a
     comparison with the wall at the same height, as the apex moves less than
     the base in every heart (outward motion, dyskinesia, is low-motion too);
   - per segment: area (at ED), area-weighted mean displacement and
     excursion, the share of its area flagged low-motion, and hypokinetic
     when that share is at least hypokinetic_share.
   outputs (may be NULL, and so may each of its arrays) receives the arrays.
   Results: INVALID_ARGUMENT (NULL models, frame_count 0, ed_frame out of
   range, models that differ in superquadric, lattice or grid, bad options
   or stacks,
   an apex or septum direction of zero length or along the axis),
   NON_FINITE, DEGENERATE (EDV <= 0, a flat model), WORKSPACE_TOO_SMALL. */
#define SQFFD_SEGMENTS 17

typedef struct sqffd_motion_options {
    size_t ed_frame;             /* end-diastole (default 0) */
    double low_motion_fraction;  /* default 0.5 */
    double hypokinetic_share;    /* default 0.5 */
    double apex_fraction;        /* the apex segment's share of the long axis (default 0.1) */
    double apex_direction[3];    /* base -> apex, world; all 0 (default): automatic */
    double septum_direction[3];  /* world (only its part across the axis counts); all 0 (default): see above */
    const sqffd_stack *stacks;   /* NULL (default): closed volumes; else frame_count stacks: volumes between their
                                    planes (see above) */
} sqffd_motion_options;

typedef struct sqffd_motion_outputs {
    double *volumes;             /* frame_count */
    double *trajectories;        /* frame_count x M x 3: vertex v of frame t at [3 (t M + v)] */
    double *displacement;        /* M */
    double *excursion;           /* M */
    unsigned char *low_motion;   /* M: 0 or 1 */
    unsigned char *segment;      /* M: 1-17, 0 for the valve plane */
} sqffd_motion_outputs;

typedef struct sqffd_segment_motion {
    double area;                 /* at ED, in the data's units squared */
    double mean_displacement;    /* area-weighted */
    double mean_excursion;       /* area-weighted */
    double low_motion_share;     /* of its area */
    int hypokinetic;
} sqffd_segment_motion;

typedef struct sqffd_motion_report {
    size_t ed_frame, es_frame;
    double edv, esv, ejection_fraction;
    double axis[3];              /* unit, base -> apex */
    double apex[3];              /* the ED model's point farthest along the axis */
    double length;               /* of the ED model along the axis */
    double anterior[3], septum[3]; /* unit, across the axis */
    double apex_fraction;        /* options->apex_fraction: the levels' apex cap (sqffd_wall's ES segments too) */
    double median_excursion;     /* over the wall points */
    sqffd_segment_motion segments[SQFFD_SEGMENTS]; /* [k]: AHA segment k + 1 */
} sqffd_motion_report;

SQFFD_DEF sqffd_motion_options sqffd_motion_options_default(void);
SQFFD_DEF sqffd_result sqffd_motion_workspace_size(const sqffd_model *models, size_t frame_count, size_t *size);
SQFFD_DEF sqffd_result sqffd_motion(const sqffd_model *models, size_t frame_count, const sqffd_motion_options *options,
                                    const sqffd_motion_outputs *outputs, sqffd_motion_report *report,
                                    void *workspace, size_t workspace_size);

/* The heart wall: myocardial volume, wall thickness and thickening, from
   two tracked sequences, the endocardium (the cavity's border: `endo`,
   sqffd_track's models, measured by sqffd_motion) and the epicardium (the
   wall's outer border: `epi`, sqffd_track's models of its own frames, the
   same frames in the same order). Both surfaces share ONE segment frame,
   the endocardium's: its ED long axis, apex, septum and levels (the
   motion report) and its vertices' segments (sqffd_motion's
   outputs->segment) define the AHA segments, and the epicardium is only
   measured against them, so neither surface's fit can move a segment of
   the other. Tracked on its own, the epicardium needs no correspondence
   with the endocardium: a thickness is a distance, not a material point.
   - myocardium[t] = V_epi(t) - V_endo(t): the closed volumes, or with
     options->stacks (the epicardium's stacks: its slices reach past the
     endocardium's at the apex) both between frame t's outer planes moved
     out by half the spacing, as sqffd_motion measures the cavity;
   - the wall thickness of endocardial grid point v at ED and at ES: along
     the endocardial mesh's outward normal at v (that frame's), the distance
     to the nearest crossing of the epicardial mesh ahead. The normal, not
     the nearest epicardial point: where the two closed surfaces meet at the
     base (both closed by their lids in one plane), the nearest point of a
     basal vertex is on the epicardium's lid, a wall-thickness away at most,
     while the normal crosses the wall as a reader's caliper does (and as
     the centreline method's chords do, across the wall). With
     options->endo_stacks (the endocardium's stacks: short-axis images), as
     the images show the wall: in frame t's planes, along the ray from the
     endocardium's centre at the vertex's level (the area-weighted mean of
     the vertices next to each plane, interpolated between planes) through
     the vertex, and only at vertices between frame t's outer planes. A
     reader measures in those planes, radially from the cavity's centre as
     the contours' thickness is measured (so were the normal values and the
     cut-off below): where a cross-section is not round, its normal points
     off that chord. Only on the slices: beyond the outer
     ones the surfaces are what closed them (sqffd_stack_lids' lids half a
     spacing out, where the cavity and the epicardium both end), not a
     drawn wall; measured up to the lids, a tube's thickening (endocardium
     20 -> 15, epicardium 28 -> 25) reads 19 % for its 25 %. (On the pig
     contours of ../shared/data/cardiac the global thickening read 2.76
     points from the contours' own on average this way, 3.68 along the
     normal's in-plane part; bench/bench_wall.c.) A ray that meets the
     endocardium again before the epicardium crosses the cavity, not the
     wall (a tracked surface's crease or sagging lid by the base): none
     there;
   - the ES segments: placed on the ES mesh as sqffd_motion places the ED
     mesh's, in the same frame (the motion report's axis, septum and
     apex_fraction) but with the ES mesh's own levels (its extent along the
     axis), centre (area centroid) and normals (the valve plane), so a
     segment's ES wall is the wall there at ES whichever tracked vertices
     slid onto it (the tracking's correspondence is the fit's, not the
     tissue's: see sqffd_motion). At ES only the ES wall (ES segment not 0)
     is measured;
   - thickening[v] = WT_ES / WT_ED - 1 at the tracked vertex (its ED and ES
     positions); ED valve-plane vertices (segment 0) and wall vertices
     whose normal crosses no epicardium (an epicardium inside the
     endocardium there) or the cavity first, or that are outside the
     planes or off the wall at ED or ES, have none: NaN in the outputs,
     counted in report->unmeasured;
   - per segment, the mean ED thickness: over the vertices of its ED
     segment measured at ED, weighted by their ED areas; the mean ES
     thickness over the vertices of its ES segment measured at ES, by their
     ES areas; thickening = ES mean / ED mean - 1; globally, the same over
     all wall vertices. Each frame's mean is the wall that frame shows,
     whatever the tracking's correspondence: a tracked vertex may slide
     along the wall, and the wall's area shrinks unevenly in systole, so
     the ES thickness weighed by the ED areas mixes the two frames (on the
     bench, along the normals: 5.4 points from the contours', 3.4 by each
     frame's own areas), and so do segments that keep their ED vertices at
     ES (per-sector r 0.80 against the contours' sectors, 0.88 placed at
     ES; bench/bench_wall.c). A segment that one frame measured no vertex
     of (none of positive area; at ES its ES segment may hold no vertex at
     all) has no means: both thicknesses 0, thickening NaN, not
     dysfunctional. A segment is dysfunctional when its thickening <
     options->dysfunctional_thickening
     (default 0.2, the cut-off the contours' sector share uses in issue 35;
     normal regional values on cine MRI: Ubachs, Heiberg, Steding & Arheden,
     "Normal values for wall thickening by magnetic resonance imaging", J
     Cardiovasc Magn Reson 2009, 11(Suppl 1):P61; the control pigs of
     ../shared/data/cardiac thicken by 46-67 % globally on their contours).
   Results: INVALID_ARGUMENT (NULL endo, epi, motion or segment, frame_count
   0, the motion report's ED or ES frame out of range, its axis, septum or
   anterior not a unit vector (within 1e-6) or its apex_fraction outside
   [0, 1), a segment above 17, either sequence's models differing in
   superquadric, lattice or grid, bad options or stacks), NON_FINITE,
   DEGENERATE (a flat ED or ES endocardium, no wall vertex measured),
   WORKSPACE_TOO_SMALL. Nothing is written on an error. */
typedef struct sqffd_wall_options {
    double dysfunctional_thickening; /* a segment thickening less is dysfunctional (default 0.2) */
    const sqffd_stack *stacks;       /* NULL (default): closed volumes; else frame_count stacks (the epicardium's):
                                        the myocardium between their planes (see above) */
    const sqffd_stack *endo_stacks;  /* NULL (default): the thickness along the normals over the whole wall;
                                        else frame_count stacks (the endocardium's): in their planes, radially
                                        from the cavity's centre, within them (see above) */
} sqffd_wall_options;

typedef struct sqffd_wall_outputs {
    double *myocardium;          /* frame_count: V_epi - V_endo */
    double *thickness_ed;        /* M (the endocardial grid's vertices): NaN where not measured */
    double *thickness_es;        /* M: NaN off the ES wall too */
    double *thickening;          /* M */
} sqffd_wall_outputs;

typedef struct sqffd_segment_wall {
    double thickness_ed, thickness_es; /* each frame's area-weighted mean over its segment's measured vertices
                                          (both 0 where either frame measured none) */
    double thickening;                 /* thickness_es / thickness_ed - 1 (NaN where none) */
    int dysfunctional;
} sqffd_segment_wall;

typedef struct sqffd_wall_report {
    double myocardium_ed, myocardium_es; /* volumes, in the data's units cubed */
    double thickness_ed, thickness_es, thickening; /* over the whole wall */
    size_t measured, unmeasured;         /* wall vertices */
    sqffd_segment_wall segments[SQFFD_SEGMENTS];
} sqffd_wall_report;

SQFFD_DEF sqffd_wall_options sqffd_wall_options_default(void);
/* Workspace for frame_count frames of these sequences' grids (endo[0]'s and epi[0]'s). */
SQFFD_DEF sqffd_result sqffd_wall_workspace_size(const sqffd_model *endo, const sqffd_model *epi, size_t frame_count,
                                                 size_t *size);
SQFFD_DEF sqffd_result sqffd_wall(const sqffd_model *endo, const sqffd_model *epi, size_t frame_count,
                                  const sqffd_motion_report *motion, const unsigned char *segment,
                                  const sqffd_wall_options *options, const sqffd_wall_outputs *outputs,
                                  sqffd_wall_report *report, void *workspace, size_t workspace_size);

/* ======================================================================
   Layer 7: volumes (3-D images) to points
   ====================================================================== */

/* Voxel types read in place (native byte order). */
typedef enum sqffd_voxel_type {
    SQFFD_VOXEL_U8 = 0,
    SQFFD_VOXEL_I8 = 1,
    SQFFD_VOXEL_U16 = 2,
    SQFFD_VOXEL_I16 = 3,
    SQFFD_VOXEL_I32 = 4,
    SQFFD_VOXEL_F32 = 5,
    SQFFD_VOXEL_F64 = 6
} sqffd_voxel_type;

/* A view of a 3-D image in caller memory: voxel (i, j, k) is at
   (const char *)data + i strides[0] + j strides[1] + k strides[2] (bytes; any
   sign, so a frame of a 4-D series or a flipped axis is a view, not a copy);
   its value is scale * stored + offset (scale 0 means 1: no scaling); its
   centre is at world affine * (i, j, k, 1) (row-major 4 x 4, last row 0 0 0 1). */
typedef struct sqffd_volume {
    const void *data;
    sqffd_voxel_type type;
    size_t dims[3];
    ptrdiff_t strides[3];
    double affine[16];
    double scale, offset;
} sqffd_volume;

/* Scaled value range of the finite voxels: INVALID_ARGUMENT (a bad view:
   NULL data, a zero dim or stride, an unknown type), NON_FINITE (affine or
   scaling, or an affine that takes a voxel's world coordinates past 1e300), TOO_LARGE (a voxel count beyond size_t), DEGENERATE (no finite
   voxel). Every function of this layer validates its view the same way. */
SQFFD_DEF sqffd_result sqffd_volume_range(const sqffd_volume *volume, double *min, double *max);
/* Otsu's threshold (the cut of a 256-bin histogram of the scaled values
   between their min and max that maximises the between-class variance;
   where a range of cuts does equally well, its middle): a level for
   sqffd_iso_points that separates the two main intensity classes. */
SQFFD_DEF sqffd_result sqffd_volume_otsu(const sqffd_volume *volume, double *threshold);

typedef struct sqffd_iso_options {
    double level;              /* a voxel is inside when its scaled value >= level */
    int largest_component;     /* keep only the crossings of the largest 6-connected inside component
                                  (by voxel count): drops specks (default 0) */
    int labelled;              /* a label map (segmentation): a voxel is inside when its scaled value equals
                                  label, and the crossings are the edges' midpoints; level is not read (default 0);
                                  2: when it equals label or label2, the border of the two regions together (a
                                  label map's epicardium: its cavity and myocardium labels) */
    double label, label2;
} sqffd_iso_options;

SQFFD_DEF sqffd_iso_options sqffd_iso_options_default(void);
/* Workspace for sqffd_iso_points: two slices of doubles, plus 4 bytes a
   voxel with largest_component (TOO_LARGE beyond 2^31 - 1 voxels then). */
SQFFD_DEF sqffd_result sqffd_iso_workspace_size(const sqffd_volume *volume, const sqffd_iso_options *options,
                                                size_t *size);
/* Iso-surface points: one per grid edge between neighbouring voxels (along
   i, j or k) where one is inside and the other not (each crossing once; an
   edge with a non-finite value has none), at the linear interpolation of
   the level between their values, in world coordinates (the affine).
   normals (may be NULL): per point the unit world direction of that edge,
   pointing from the inside voxel to the outside one. *count = how many
   there are, all written in voxel order (capacity 0 only counts, points may
   then be NULL; a capacity below the count is OUTPUT_TOO_SMALL, see
   RESULTS: capacities). options NULL: level 0, all components. Results as
   sqffd_volume_range, plus WORKSPACE_TOO_SMALL; an image with no crossing
   gives count 0 and OK. */
SQFFD_DEF sqffd_result sqffd_iso_points(const sqffd_volume *volume, const sqffd_iso_options *options, double *points,
                                        double *normals, size_t capacity, size_t *count,
                                        void *workspace, size_t workspace_size);
/* An even, deterministic subsample of k of n points (3 doubles each): point
   floor(i n / k) for i < k. INVALID_ARGUMENT for k > n or NULL arrays. */
SQFFD_DEF sqffd_result sqffd_points_subsample(const double *points, size_t n, size_t k, double *out);
/* The same from a view (n = its count), into packed doubles. */
SQFFD_DEF sqffd_result sqffd_points_subsample_view(sqffd_points points, size_t k, double *out);

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

/* Scratch taken from the workspace instead of the stack aliases nothing the
   hot loops write; saying so keeps them as fast as with local arrays. */
#if defined(__GNUC__) || defined(__clang__) || defined(_MSC_VER)
#define SQFFD__RESTRICT __restrict
#else
#define SQFFD__RESTRICT
#endif

/* Before a short loop written to be vectorised (its trip count a constant):
   GCC's -O3 unrolls such a loop completely before its loop vectoriser runs,
   and the straight-line code left has a branch per lane. On the exact
   passes' box gaps that made a whole fit 1.19x as long at -O3 as at -O2;
   kept as a loop, -O3 vectorises it as -O2 does. */
#if defined(__GNUC__) && __GNUC__ >= 8 && !defined(__clang__) && !defined(__INTEL_COMPILER) && !defined(__NVCOMPILER) && \
    !defined(__PGI) /* (gcc itself: others that say __GNUC__ may not know the pragma) */
#define SQFFD__KEEP_LOOP _Pragma("GCC unroll 1")
#else
#define SQFFD__KEEP_LOOP
#endif

/* A small function the hot loops call many times a point (the closest point
   on a triangle: ~1.3 M calls a fit on a scan), inlined into each of them:
   gcc -O2 left it a call, and inlined, fits take 0.96x the time. */
#if defined(__GNUC__) || defined(__clang__)
#define SQFFD__INLINE static inline __attribute__((always_inline))
#elif defined(_MSC_VER)
#define SQFFD__INLINE static __forceinline
#else
#define SQFFD__INLINE static
#endif

/* ---- Workspace arena ------------------------------------------------------
   Every operation that needs scratch memory lays it out with one function
   that takes blocks from an arena. Over a measuring arena it only adds up
   sizes (that is what sqffd_X_workspace_size() does); over the caller's block
   it hands out pieces aligned to a cache line (64 bytes: the dense
   matrices' rows then load whole lines; an 8x8x8 fold-free fit ran 20 %
   slower from a block at 16 past a line). One layout function per operation
   keeps the size and the carving from ever disagreeing. */
#define SQFFD__ALIGN 64u

typedef struct sqffd__arena {
    unsigned char *base; /* NULL while measuring, else SQFFD__ALIGN-aligned */
    size_t size;         /* usable bytes from base */
    size_t used;
    int overflow;        /* a request did not fit, or its size overflowed */
    int too_large;       /* the latter: the layout's size cannot be represented */
} sqffd__arena;

static void sqffd__arena_measure(sqffd__arena *a)
{
    a->base = NULL;
    a->size = 0;
    a->used = 0;
    a->overflow = 0;
    a->too_large = 0;
}

/* The caller's block loses up to SQFFD__ALIGN - 1 bytes to alignment; exactly SQFFD__ALIGN
   are always set aside for it, so a block of the measured size works at any
   address and one byte less fails at any address. A NULL block has no room. */
static void sqffd__arena_init(sqffd__arena *a, void *memory, size_t size)
{
    size_t mis = (size_t)((uintptr_t)memory % SQFFD__ALIGN);
    sqffd__arena_measure(a);
    if (!memory || size < SQFFD__ALIGN) { a->overflow = 1; return; }
    a->base = (unsigned char *)memory + (mis ? SQFFD__ALIGN - mis : 0);
    a->size = size - SQFFD__ALIGN;
}

static void sqffd__arena_too_large(sqffd__arena *a)
{
    a->overflow = a->too_large = 1;
}

/* count * elem bytes, aligned; NULL while measuring or when out of room.
   After a request that did not fit, the sizes are still added up, so that a
   later one whose size cannot be represented is still told apart. */
static void *sqffd__arena_take(sqffd__arena *a, size_t count, size_t elem)
{
    size_t bytes, start = a->used;
    if (a->too_large) return NULL;
    if (elem && count > ((size_t)-1 - SQFFD__ALIGN) / elem) { sqffd__arena_too_large(a); return NULL; }
    bytes = (count * elem + SQFFD__ALIGN - 1) & ~(size_t)(SQFFD__ALIGN - 1);
    if (bytes > (size_t)-1 - start - SQFFD__ALIGN) { sqffd__arena_too_large(a); return NULL; }
    a->used = start + bytes;
    if (!a->base || a->overflow) return NULL;
    if (bytes > a->size - start) { a->overflow = 1; return NULL; }
    return a->base + start;
}

/* Two layouts never live together share their bytes: with *mark where the
   first began, sqffd__arena_rewind after it goes back there (*mark: where it
   ended); sqffd__arena_past after the second goes past the longer. */
static void sqffd__arena_rewind(sqffd__arena *a, size_t *mark)
{
    size_t end = a->used;
    a->used = *mark;
    *mark = end;
}

static void sqffd__arena_past(sqffd__arena *a, size_t end)
{
    if (a->used < end) a->used = end;
}

/* The error of a layout that did not fit the caller's block. */
static sqffd_result sqffd__arena_error(const sqffd__arena *a)
{
    return a->too_large ? SQFFD_ERROR_TOO_LARGE : SQFFD_ERROR_WORKSPACE_TOO_SMALL;
}

/* What a measured layout needs from the caller: room for an unaligned base
   too. TOO_LARGE (and 0) when the request cannot be represented. */
static sqffd_result sqffd__arena_size(const sqffd__arena *a, size_t *size)
{
    *size = a->too_large ? 0 : a->used + SQFFD__ALIGN;
    return a->too_large ? SQFFD_ERROR_TOO_LARGE : SQFFD_OK;
}

static int sqffd__finite3(const double *p)
{
    return isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]);
}

/* ---- Point views ---------------------------------------------------------- */

SQFFD_DEF sqffd_points sqffd_points_strided(const void *xyz, size_t n, size_t stride, sqffd_scalar type)
{
    sqffd_points v;
    v.xyz = xyz;
    v.count = n;
    v.stride = stride;
    v.type = type;
    return v;
}

SQFFD_DEF sqffd_points sqffd_points_packed(const double *xyz, size_t n)
{
    return sqffd_points_strided(xyz, n, 3 * sizeof(double), SQFFD_SCALAR_DOUBLE);
}

/* A view's own checks (its count is each function's to judge). */
static sqffd_result sqffd__points_check(const sqffd_points *v)
{
    size_t scalar = v->type == SQFFD_SCALAR_FLOAT ? sizeof(float) : sizeof(double);
    if (!v->xyz || (v->type != SQFFD_SCALAR_DOUBLE && v->type != SQFFD_SCALAR_FLOAT) || v->stride < 3 * scalar)
        return SQFFD_ERROR_INVALID_ARGUMENT;
    if (v->count > 1 && v->count - 1 > ((size_t)-1 - 3 * scalar) / v->stride) return SQFFD_ERROR_TOO_LARGE;
    return SQFFD_OK;
}

/* Point i of a view, as doubles (memcpy: the records may be unaligned). */
static void sqffd__points_get(const sqffd_points *v, size_t i, double p[3])
{
    const unsigned char *at = (const unsigned char *)v->xyz + i * v->stride;
    if (v->type == SQFFD_SCALAR_FLOAT) {
        float f[3];
        memcpy(f, at, sizeof f);
        p[0] = f[0]; p[1] = f[1]; p[2] = f[2];
    } else {
        memcpy(p, at, 3 * sizeof(double));
    }
}

/* A stored superquadric's or lattice's numbers are at most this in
   magnitude, so that their squares and products stay far from overflow;
   data the fit takes, at most SQFFD__MAX_DATA, so that a fitted model
   (which may reach somewhat past its data) stays far within that bound. */
#define SQFFD__MAX_MAGNITUDE 1e150
#define SQFFD__MAX_DATA 1e100

static int sqffd__bounded3(const double *p)
{
    return fabs(p[0]) <= SQFFD__MAX_MAGNITUDE && fabs(p[1]) <= SQFFD__MAX_MAGNITUDE &&
           fabs(p[2]) <= SQFFD__MAX_MAGNITUDE; /* (false for NaN) */
}

/* An even, deterministic subsample of k of the n points (k <= n): point
   floor(i n / k), computed without forming i n, which could overflow. */
static void sqffd__subsample(const sqffd_points *points, size_t k, double *out)
{
    size_t i, n = points->count;
    for (i = 0; i < k; ++i) sqffd__points_get(points, i * (n / k) + i * (n % k) / k, out + 3 * i);
}

/* ======================================================================
   Layer 1: linear algebra
   ====================================================================== */

/* ---- 3-vectors and row-major 3x3 matrices (private helpers) ---- */
static double sqffd__dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void sqffd__sub3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[0] - b[0]; out[1] = a[1] - b[1]; out[2] = a[2] - b[2];
}

static void sqffd__cross3(const double a[3], const double b[3], double out[3])
{
    double x = a[1] * b[2] - a[2] * b[1];
    double y = a[2] * b[0] - a[0] * b[2];
    double z = a[0] * b[1] - a[1] * b[0];
    out[0] = x; out[1] = y; out[2] = z;
}

static double sqffd__dist2_3(const double a[3], const double b[3])
{
    double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}

/* out = M v (out may alias v) */
static void sqffd__mat3_vec(const double m[9], const double v[3], double out[3])
{
    double x = m[0] * v[0] + m[1] * v[1] + m[2] * v[2];
    double y = m[3] * v[0] + m[4] * v[1] + m[5] * v[2];
    double z = m[6] * v[0] + m[7] * v[1] + m[8] * v[2];
    out[0] = x; out[1] = y; out[2] = z;
}

/* out = M^T v (out may alias v) */
static void sqffd__mat3t_vec(const double m[9], const double v[3], double out[3])
{
    double x = m[0] * v[0] + m[3] * v[1] + m[6] * v[2];
    double y = m[1] * v[0] + m[4] * v[1] + m[7] * v[2];
    double z = m[2] * v[0] + m[5] * v[1] + m[8] * v[2];
    out[0] = x; out[1] = y; out[2] = z;
}

/* ---- Symmetric 3x3 eigen-decomposition (cyclic Jacobi) ---- */

/* Rotation in the (p, q) plane that zeroes m[p][q]; v accumulates columns. */
static void sqffd__la_jacobi3_rotate(double m[9], double v[9], int p, int q)
{
    double apq = m[3 * p + q], app = m[3 * p + p], aqq = m[3 * q + q];
    double theta, t, c, s;
    int k;
    theta = (aqq - app) / (2.0 * apq);
    /* t = tan of the rotation angle, the smaller root of t^2 + 2 theta t - 1 */
    if (fabs(theta) > 1e150) t = 0.5 / theta;
    else t = (theta >= 0.0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
    c = 1.0 / sqrt(t * t + 1.0);
    s = t * c;
    for (k = 0; k < 3; ++k) { /* columns p, q of m */
        double mkp = m[3 * k + p], mkq = m[3 * k + q];
        m[3 * k + p] = c * mkp - s * mkq;
        m[3 * k + q] = s * mkp + c * mkq;
    }
    for (k = 0; k < 3; ++k) { /* rows p, q of m */
        double mpk = m[3 * p + k], mqk = m[3 * q + k];
        m[3 * p + k] = c * mpk - s * mqk;
        m[3 * q + k] = s * mpk + c * mqk;
    }
    m[3 * p + q] = m[3 * q + p] = 0.0;
    m[3 * p + p] = app - t * apq;
    m[3 * q + q] = aqq + t * apq;
    for (k = 0; k < 3; ++k) {
        double vkp = v[3 * k + p], vkq = v[3 * k + q];
        v[3 * k + p] = c * vkp - s * vkq;
        v[3 * k + q] = s * vkp + c * vkq;
    }
}

/* Flip a column so that its component of largest magnitude is positive. */
static void sqffd__la_sign_column3(double v[9], int col)
{
    int k, big = 0;
    for (k = 1; k < 3; ++k)
        if (fabs(v[3 * k + col]) > fabs(v[3 * big + col])) big = k;
    if (v[3 * big + col] < 0.0)
        for (k = 0; k < 3; ++k) v[3 * k + col] = -v[3 * k + col];
}

SQFFD_DEF void sqffd_sym3_eigen(const double a[9], double values[3], double vectors[9])
{
    static const int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
    double m[9], v[9], c0[3], c1[3], c2[3];
    int sweep, i, j, k, order[3];
    for (i = 0; i < 3; ++i)
        for (j = 0; j < 3; ++j) {
            m[3 * i + j] = i <= j ? a[3 * i + j] : a[3 * j + i];
            v[3 * i + j] = i == j ? 1.0 : 0.0;
        }
    for (sweep = 0; sweep < 64; ++sweep) {
        int rotated = 0;
        for (k = 0; k < 3; ++k) {
            int p = pairs[k][0], q = pairs[k][1];
            double apq = m[3 * p + q], g = 100.0 * fabs(apq);
            if (apq == 0.0) continue;
            /* negligible next to both diagonal entries: drop it */
            if (fabs(m[3 * p + p]) + g == fabs(m[3 * p + p]) && fabs(m[3 * q + q]) + g == fabs(m[3 * q + q])) {
                m[3 * p + q] = m[3 * q + p] = 0.0;
                continue;
            }
            sqffd__la_jacobi3_rotate(m, v, p, q);
            rotated = 1;
        }
        if (!rotated) break;
    }
    /* ascending order */
    order[0] = 0; order[1] = 1; order[2] = 2;
    for (i = 0; i < 2; ++i)
        for (j = 0; j < 2 - i; ++j)
            if (m[3 * order[j + 1] + order[j + 1]] < m[3 * order[j] + order[j]]) {
                int t = order[j]; order[j] = order[j + 1]; order[j + 1] = t;
            }
    for (i = 0; i < 3; ++i) {
        values[i] = m[3 * order[i] + order[i]];
        for (k = 0; k < 3; ++k) vectors[3 * k + i] = v[3 * k + order[i]];
    }
    sqffd__la_sign_column3(vectors, 0);
    sqffd__la_sign_column3(vectors, 1);
    for (k = 0; k < 3; ++k) { c0[k] = vectors[3 * k]; c1[k] = vectors[3 * k + 1]; }
    sqffd__cross3(c0, c1, c2);
    for (k = 0; k < 3; ++k) vectors[3 * k + 2] = c2[k];
}

/* ---- Dense vector kernels ---- */

/* restrict lets compilers vectorise the kernels at -O2 (no alias checks) */
#ifdef __cplusplus
#define SQFFD__LA_RESTRICT __restrict
#else
#define SQFFD__LA_RESTRICT restrict
#endif

/* IEEE double constants (the core includes no <float.h>) */
#define SQFFD__LA_EPS 2.220446049250313080847e-16        /* DBL_EPSILON */
#define SQFFD__LA_MIN_NORMAL 2.225073858507201383090e-308 /* DBL_MIN */

/* The end of sqffd__la_dot_rest (below): the last terms k..n-1 (fewer
   than four) into lane 0, then the lanes' sum. Small enough to be inlined
   where a tile's entries are finished one by one. */
static double sqffd__la_dot_tail(const double *x, const double *y, size_t n, const double lanes[4], size_t k)
{
    double s0 = lanes[0];
    SQFFD_ASSERT(n - k < 4);
    for (; k < n; ++k) s0 += x[k] * y[k];
    return (s0 + lanes[1]) + (lanes[2] + lanes[3]);
}

/* x . y in four lanes (lane q sums the terms k = q mod 4, the last n mod 4
   terms go to lane 0), continued from `lanes`, their sums over the first
   `done` terms (a multiple of four): a fixed summation order
   (deterministic) with enough independent additions to keep the FPU busy
   without -ffast-math. */
static double sqffd__la_dot_rest(const double *x, const double *y, size_t n, const double lanes[4], size_t done)
{
    double s[4]; /* (an array: gcc packs its lanes into one vector, four scalars started from lanes[] it leaves) */
    size_t k, q;
    for (q = 0; q < 4; ++q) s[q] = lanes[q];
    for (k = done; k + 4 <= n; k += 4)
        for (q = 0; q < 4; ++q) s[q] += x[k + q] * y[k + q];
    return sqffd__la_dot_tail(x, y, n, s, k);
}

/* x . y, from no lanes: sqffd__la_dot_rest's order throughout. */
static double sqffd__la_dot(const double *x, const double *y, size_t n)
{
    static const double none[4] = {0.0, 0.0, 0.0, 0.0};
    return sqffd__la_dot_rest(x, y, n, none, 0);
}

/* y += alpha x. Unrolled by four like the rotation below: GCC's -O2
   vectoriser turns the four statements into one SIMD operation, while it
   leaves the plain loop (which would need a remainder loop) scalar. */
static void sqffd__la_axpy(double *SQFFD__LA_RESTRICT y, double alpha, const double *SQFFD__LA_RESTRICT x, size_t n)
{
    size_t k;
    for (k = 0; k + 4 <= n; k += 4) {
        y[k] += alpha * x[k];
        y[k + 1] += alpha * x[k + 1];
        y[k + 2] += alpha * x[k + 2];
        y[k + 3] += alpha * x[k + 3];
    }
    for (; k < n; ++k) y[k] += alpha * x[k];
}

/* ---- Cholesky ---- */

/* Where row i of a lower triangle packed row after row (i + 1 entries each) starts. */
static size_t sqffd__packed_row(size_t i)
{
    return i * (i + 1) / 2;
}

/* Row i of an n x n lower triangle stored row-major (n a row) or packed. */
static double *sqffd__la_row(const double *a, size_t n, int packed, size_t i)
{
    return (double *)a + (packed ? sqffd__packed_row(i) : i * n);
}

/* The lanes of sqffd__la_dot_rest (lane q: the terms k = q mod 4) of the
   eight dots of rows x[0], x[1] with rows y[0..3] over their first n
   terms (n a multiple of four) into lanes[r][t]. Eight accumulators, each
   its own array, which gcc keeps in vector registers (one [2][4][4] array
   it leaves scalar); they share each load. */
static void sqffd__la_lanes_2x4(const double *const x[2], const double *const y[4], size_t n, double lanes[2][4][4])
{
    double a[4] = {0.0, 0.0, 0.0, 0.0}, b[4] = {0.0, 0.0, 0.0, 0.0}, c[4] = {0.0, 0.0, 0.0, 0.0}, d[4] = {0.0, 0.0, 0.0, 0.0};
    double e[4] = {0.0, 0.0, 0.0, 0.0}, f[4] = {0.0, 0.0, 0.0, 0.0}, g[4] = {0.0, 0.0, 0.0, 0.0}, h[4] = {0.0, 0.0, 0.0, 0.0};
    const double *x0 = x[0], *x1 = x[1], *y0 = y[0], *y1 = y[1], *y2 = y[2], *y3 = y[3];
    size_t k, q;
    for (k = 0; k < n; k += 4)
        for (q = 0; q < 4; ++q) {
            a[q] += x0[k + q] * y0[k + q];
            b[q] += x0[k + q] * y1[k + q];
            c[q] += x0[k + q] * y2[k + q];
            d[q] += x0[k + q] * y3[k + q];
            e[q] += x1[k + q] * y0[k + q];
            f[q] += x1[k + q] * y1[k + q];
            g[q] += x1[k + q] * y2[k + q];
            h[q] += x1[k + q] * y3[k + q];
        }
    for (q = 0; q < 4; ++q) {
        lanes[0][0][q] = a[q];
        lanes[0][1][q] = b[q];
        lanes[0][2][q] = c[q];
        lanes[0][3][q] = d[q];
        lanes[1][0][q] = e[q];
        lanes[1][1][q] = f[q];
        lanes[1][2][q] = g[q];
        lanes[1][3][q] = h[q];
    }
}

/* The Cholesky factor L of the lower triangle of a (row-major or packed) in
   its place. Row by row (Cholesky-Crout): L[i][j] = (A[i][j] - L[i][:j].L[j][:j]) / L[j][j];
   both dot operands are contiguous rows. Two rows at a time against four
   columns' rows: their eight dots share each load and run as independent
   sums (one dot alone waits on its own additions) over the terms before
   the four, each then finished in sqffd__la_dot_rest's order (its tail).
   The rows go SQFFD__LA_BLOCK at a time, each group of four columns
   through all of them before the next: the earlier rows are read from
   memory once a block instead of once a pair (a matrix larger than the
   cache is otherwise bound by that reading). Every entry is computed as in
   plain row order, from the same finished entries. */
#define SQFFD__LA_BLOCK 32 /* rows (even: whole pairs); 32 of 1,536 doubles (an 8 x 8 x 8 lattice) fill 384 KB of a core's L2 cache */
static sqffd_result sqffd__la_cholesky(double *a, size_t n, int packed)
{
    size_t i, j, r, t, rows, block, end;
    for (i = 0; i < n; ++i) {
        const double *li = sqffd__la_row(a, n, packed, i);
        for (j = 0; j <= i; ++j)
            if (!isfinite(li[j])) return SQFFD_ERROR_NON_FINITE;
    }
    for (block = 0; block < n; block = end) {
        end = block + SQFFD__LA_BLOCK < n ? block + SQFFD__LA_BLOCK : n;
        for (j = 0; j < end; j += 4) /* columns j..j+3 (those past a pair's last row: none) */
            for (i = block + (j > block ? (j - block) / 2 * 2 : 0); i < end; i += rows) {
                double *row[2];
                const double *col[4];
                double lanes[2][4][4];
                rows = i + 1 < n ? 2 : 1;
                row[0] = sqffd__la_row(a, n, packed, i);
                row[1] = sqffd__la_row(a, n, packed, i + rows - 1);
                for (t = 0; t < 4; ++t) col[t] = j + t < i + rows ? sqffd__la_row(a, n, packed, j + t) : row[0];
                sqffd__la_lanes_2x4((const double *const *)row, col, j, lanes);
                for (t = 0; t < 4; ++t) /* (column by column: an entry needs its row's earlier ones and its column's row) */
                    for (r = 0; r < rows; ++r) {
                        size_t c = j + t;
                        double sum;
                        if (c > i + r) continue;
                        sum = row[r][c] - sqffd__la_dot_tail(row[r], col[t], c, lanes[r][t], j);
                        if (c < i + r) {
                            row[r][c] = sum / col[t][c];
                        } else {
                            if (!(sum > 0.0) || !isfinite(sum)) return SQFFD_ERROR_NOT_POSITIVE_DEFINITE;
                            row[r][c] = sqrt(sum);
                        }
                    }
            }
    }
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_cholesky_factor(double *a, size_t n)
{
    sqffd_result r;
    size_t i;
    if (!a || n < 1) return SQFFD_ERROR_INVALID_ARGUMENT;
    r = sqffd__la_cholesky(a, n, 0);
    if (r == SQFFD_OK)
        for (i = 0; i + 1 < n; ++i) memset(a + i * n + i + 1, 0, (n - i - 1) * sizeof(double));
    return r;
}

/* L y = b in place for k right-hand sides at once (b: k vectors of n one
   after another; each row of L is read once for all of them), L lower
   triangular (row-major n x n, or packed). Two rows at a time, as the
   factor is made, against four right-hand sides at a time, then the last
   k mod 4 one by one. */
static void sqffd__la_forward(const double *l, size_t n, int packed, double *b, size_t k)
{
    size_t i, c, r, t, rows;
    for (i = 0; i < n; i += rows) {
        const double *row[2];
        size_t done = i - i % 4;
        rows = i + 1 < n ? 2 : 1;
        row[0] = sqffd__la_row(l, n, packed, i);
        row[1] = sqffd__la_row(l, n, packed, i + rows - 1);
        for (c = 0; c + 4 <= k; c += 4) {
            const double *rhs[4];
            double lanes[2][4][4];
            for (t = 0; t < 4; ++t) rhs[t] = b + (c + t) * n;
            sqffd__la_lanes_2x4(row, rhs, done, lanes);
            for (r = 0; r < rows; ++r)
                for (t = 0; t < 4; ++t) {
                    double *bt = b + (c + t) * n;
                    bt[i + r] = (bt[i + r] - sqffd__la_dot_tail(row[r], bt, i + r, lanes[r][t], done)) / row[r][i + r];
                }
        }
        for (r = 0; r < rows; ++r)
            for (t = c; t < k; ++t) {
                double *bt = b + t * n;
                bt[i + r] = (bt[i + r] - sqffd__la_dot(row[r], bt, i + r)) / row[r][i + r];
            }
    }
}

/* L^T x = y in place, column-oriented so rows of L are read. */
static void sqffd__la_backward(const double *l, size_t n, int packed, double *b)
{
    size_t i;
    for (i = n; i-- > 0;) {
        const double *li = sqffd__la_row(l, n, packed, i);
        double xi = b[i] / li[i];
        b[i] = xi;
        sqffd__la_axpy(b, -xi, li, i);
    }
}

SQFFD_DEF sqffd_result sqffd_cholesky_solve(const double *l, size_t n, double *b)
{
    if (!l || !b || n < 1) return SQFFD_ERROR_INVALID_ARGUMENT;
    sqffd__la_forward(l, n, 0, b, 1);
    sqffd__la_backward(l, n, 0, b);
    return SQFFD_OK;
}

/* ---- SVD: Householder QR with column pivoting, then one-sided Jacobi on R^T ----
   A P = Q R. Jacobi rotations J orthogonalise the columns of X = R^T:
   X J = U1 diag(s), so R = J diag(s) U1^T and A = (Q J) diag(s) (P U1)^T.
   U is Q applied to J, V is the normalised columns of X J with rows permuted
   back. R^T converges in a few sweeps (Drmac & Veselic), and the n x n
   Jacobi costs far less than working on the m x n matrix. */

typedef struct sqffd__la_svd_work {
    double *qr;     /* m x n row-major: R on and above the diagonal, reflectors below */
    double *x;      /* n x n, column j contiguous: the columns of X = R^T being rotated */
    double *rot;    /* n x n, column j contiguous: accumulated right rotations J */
    double *tau;    /* n Householder scalars */
    double *norm2;  /* n squared column norms (of the QR columns, then of X) */
    double *norm2_ref; /* n: norm2 when last computed exactly (QR pivoting) */
    double *tmp;    /* n */
    int *perm;      /* n: column k of A P is column perm[k] of A */
} sqffd__la_svd_work;

static void sqffd__la_svd_layout(sqffd__arena *ar, size_t m, size_t n, sqffd__la_svd_work *w)
{
    w->qr = (double *)sqffd__arena_take(ar, m * n, sizeof(double));
    w->x = (double *)sqffd__arena_take(ar, n * n, sizeof(double));
    w->rot = (double *)sqffd__arena_take(ar, n * n, sizeof(double));
    w->tau = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->norm2 = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->norm2_ref = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->tmp = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->perm = (int *)sqffd__arena_take(ar, n, sizeof(int));
}

SQFFD_DEF sqffd_result sqffd_svd_workspace_size(size_t m, size_t n, size_t *size)
{
    sqffd__arena ar;
    sqffd__la_svd_work w;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    if (n < 1 || m < n) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (m > (size_t)-1 / n) return SQFFD_ERROR_TOO_LARGE;
    sqffd__arena_measure(&ar);
    sqffd__la_svd_layout(&ar, m, n, &w);
    return sqffd__arena_size(&ar, size);
}

/* (x, y) <- (c x - s y, s x + c y) in Rutishauser's form with
   tau = s / (1 + c), 1 - c = s tau: for the small angles of late sweeps c
   rounds to 1 and the plain form would grow every norm by ~s^2/2, a bias that
   thousands of rotations turn into ~1e-13 of lost orthogonality. */
static void sqffd__la_rotate(double *SQFFD__LA_RESTRICT x, double *SQFFD__LA_RESTRICT y, size_t n, double s, double tau)
{
    size_t k = 0, j;
    for (; k + 4 <= n; k += 4) {
        double xk[4], yk[4];
        for (j = 0; j < 4; ++j) { xk[j] = x[k + j]; yk[j] = y[k + j]; }
        for (j = 0; j < 4; ++j) {
            x[k + j] = xk[j] - s * (yk[j] + tau * xk[j]);
            y[k + j] = yk[j] + s * (xk[j] - tau * yk[j]);
        }
    }
    for (; k < n; ++k) {
        double xk = x[k], yk = y[k];
        x[k] = xk - s * (yk + tau * xk);
        y[k] = yk + s * (xk - tau * yk);
    }
}

static void sqffd__la_swap(double *x, double *y, size_t n)
{
    size_t k;
    for (k = 0; k < n; ++k) { double t = x[k]; x[k] = y[k]; y[k] = t; }
}

/* Squared norm of column j of the row-major qr over rows from..m-1. */
static double sqffd__la_column_norm2(const double *qr, size_t m, size_t n, size_t j, size_t from)
{
    double sum = 0.0;
    size_t i;
    for (i = from; i < m; ++i) sum += qr[i * n + j] * qr[i * n + j];
    return sum;
}

/* a <- H_k a on columns c0..n-1 of the row-major m x n `a`, with the
   reflector H_k = I - tau v v^T stored in column k of qr (v_k = 1, v_i =
   qr[i][k] below). Computed as w = tau a^T v, a -= v w^T, row by row, so
   every inner loop is a contiguous axpy. wrow: n scratch doubles. */
static void sqffd__la_reflect(const double *qr, double tau, size_t m, size_t n, size_t k, double *a, size_t c0,
                              double *wrow)
{
    size_t i, j, len = n - c0;
    double *w = wrow + c0;
    memcpy(w, a + k * n + c0, len * sizeof(double));
    for (i = k + 1; i < m; ++i) sqffd__la_axpy(w, qr[i * n + k], a + i * n + c0, len);
    for (j = 0; j < len; ++j) w[j] *= tau;
    sqffd__la_axpy(a + k * n + c0, -1.0, w, len);
    for (i = k + 1; i < m; ++i) sqffd__la_axpy(a + i * n + c0, -qr[i * n + k], w, len);
}

/* Householder QR with column pivoting of the row-major m x n w->qr, in place
   (LAPACK xGEQP3 conventions: H_k = I - tau v v^T, v_k = 1, v below the
   diagonal). */
static void sqffd__la_qr_pivoted(sqffd__la_svd_work *w, size_t m, size_t n)
{
    double *qr = w->qr, *vn = w->norm2, *vn_ref = w->norm2_ref;
    size_t i, j, k;
    for (j = 0; j < n; ++j) { vn[j] = 0.0; w->perm[j] = (int)j; }
    for (i = 0; i < m; ++i)
        for (j = 0; j < n; ++j) vn[j] += qr[i * n + j] * qr[i * n + j];
    for (j = 0; j < n; ++j) vn_ref[j] = vn[j];
    for (k = 0; k < n; ++k) {
        size_t p = k;
        double alpha, tau, amax;
        for (j = k + 1; j < n; ++j)
            if (vn[j] > vn[p]) p = j;
        if (p != k) {
            int t = w->perm[p]; w->perm[p] = w->perm[k]; w->perm[k] = t;
            for (i = 0; i < m; ++i) {
                double s = qr[i * n + p]; qr[i * n + p] = qr[i * n + k]; qr[i * n + k] = s;
            }
            vn[p] = vn[k]; vn_ref[p] = vn_ref[k];
        }
        /* The reflector is computed on the column scaled by a power of two
           (exact) into [0.5, 1): squares of tiny entries would lose digits to
           underflow, and an inexact norm makes H non-orthogonal. v and tau do
           not depend on the scale. Columns below 1e-300 (the matrix is
           scaled to max |a_ij| < 1) are left alone: H_k = I. */
        amax = 0.0;
        for (i = k; i < m; ++i) amax = fmax(amax, fabs(qr[i * n + k]));
        tau = 0.0;
        if (amax > 1e-300) {
            double f, xnorm2 = 0.0;
            int e;
            (void)frexp(amax, &e);
            f = ldexp(1.0, -e);
            alpha = qr[k * n + k] * f;
            for (i = k + 1; i < m; ++i) xnorm2 += (qr[i * n + k] * f) * (qr[i * n + k] * f);
            if (xnorm2 > 0.0) {
                double beta = -copysign(sqrt(alpha * alpha + xnorm2), alpha), scale = f / (alpha - beta);
                tau = (beta - alpha) / beta;
                for (i = k + 1; i < m; ++i) qr[i * n + k] *= scale;
                qr[k * n + k] = beta / f;
            }
        }
        w->tau[k] = tau;
        if (tau == 0.0 || k + 1 == n) continue;
        sqffd__la_reflect(qr, tau, m, n, k, qr, k + 1, w->tmp);
        /* downdate the remaining column norms; recompute when cancellation
           has eaten most of the digits (LAPACK working note 176) */
        for (j = k + 1; j < n; ++j) {
            double r, left;
            if (vn[j] == 0.0) continue;
            r = qr[k * n + j];
            left = vn[j] - r * r;
            if (left <= 1e-4 * vn_ref[j]) {
                vn[j] = vn_ref[j] = sqffd__la_column_norm2(qr, m, n, j, k + 1);
            } else {
                vn[j] = left;
            }
        }
    }
}

/* Swap columns p and q of the Jacobi state (X, J when accumulated, norms). */
static void sqffd__la_svd_swap(sqffd__la_svd_work *w, size_t n, size_t p, size_t q, int with_rot)
{
    double t = w->norm2[p];
    w->norm2[p] = w->norm2[q];
    w->norm2[q] = t;
    sqffd__la_swap(w->x + p * n, w->x + q * n, n);
    if (with_rot) sqffd__la_swap(w->rot + p * n, w->rot + q * n, n);
}

/* Cyclic one-sided Jacobi on the columns of w->x with de Rijk pivoting (the
   largest remaining column leads each row of the sweep). Columns whose
   squared norm is below `zero2` count as zero and are left alone. Returns 1
   when a sweep found every pair orthogonal:
   |x_p . x_q| <= eps sqrt(n) ||x_p|| ||x_q||. */
static int sqffd__la_jacobi_sweeps(sqffd__la_svd_work *w, size_t n, int with_rot, double zero2)
{
    const double tol = SQFFD__LA_EPS * sqrt((double)n);
    double *x = w->x, *norm2 = w->norm2;
    size_t p, q, j;
    int sweep;
    for (sweep = 0; sweep < 80; ++sweep) {
        int rotated = 0;
        for (j = 0; j < n; ++j) norm2[j] = sqffd__la_dot(x + j * n, x + j * n, n);
        for (p = 0; p + 1 < n; ++p) {
            size_t big = p;
            for (q = p + 1; q < n; ++q)
                if (norm2[q] > norm2[big]) big = q;
            if (big != p) sqffd__la_svd_swap(w, n, p, big, with_rot);
            for (q = p + 1; q < n; ++q) {
                double a = norm2[p], b = norm2[q], c, zeta, t, cs, sn, tau;
                if (a < zero2 || b < zero2) continue;
                c = sqffd__la_dot(x + p * n, x + q * n, n);
                if (fabs(c) <= tol * sqrt(a) * sqrt(b)) continue;
                rotated = 1;
                /* t = tan(angle): the smaller root of t^2 + 2 zeta t - 1 = 0 */
                zeta = (b - a) / (2.0 * c);
                if (fabs(zeta) > 1e150) t = 0.5 / zeta;
                else t = (zeta >= 0.0 ? 1.0 : -1.0) / (fabs(zeta) + sqrt(1.0 + zeta * zeta));
                cs = 1.0 / sqrt(1.0 + t * t);
                sn = cs * t;
                tau = sn / (1.0 + cs);
                sqffd__la_rotate(x + p * n, x + q * n, n, sn, tau);
                if (with_rot) sqffd__la_rotate(w->rot + p * n, w->rot + q * n, n, sn, tau);
                /* exact updates of the norms; recompute where they cancel */
                norm2[p] = a - t * c;
                norm2[q] = b + t * c;
                if (norm2[p] < 0.125 * a) norm2[p] = sqffd__la_dot(x + p * n, x + p * n, n);
                if (norm2[q] < 0.125 * b) norm2[q] = sqffd__la_dot(x + q * n, x + q * n, n);
            }
        }
        if (!rotated) return 1;
    }
    return 0;
}

/* Columns rank..n-1 of the n x n column-contiguous `basis` (the first `rank`
   orthonormal) are replaced by an orthonormal completion: each starts from
   the unit vector least represented in the span so far (smallest row norm)
   and is Gram-Schmidt orthogonalised twice. row2: n scratch doubles. */
static void sqffd__la_complete_basis(double *basis, size_t n, size_t rank, double *row2)
{
    size_t i, j, c, pass;
    for (i = 0; i < n; ++i) row2[i] = 0.0;
    for (c = 0; c < rank; ++c)
        for (i = 0; i < n; ++i) row2[i] += basis[c * n + i] * basis[c * n + i];
    for (j = rank; j < n; ++j) {
        double *col = basis + j * n, len;
        size_t best = 0;
        for (i = 1; i < n; ++i)
            if (row2[i] < row2[best]) best = i;
        for (i = 0; i < n; ++i) col[i] = i == best ? 1.0 : 0.0;
        for (pass = 0; pass < 2; ++pass)
            for (c = 0; c < j; ++c) {
                const double *other = basis + c * n;
                sqffd__la_axpy(col, -sqffd__la_dot(other, col, n), other, n);
            }
        len = sqrt(sqffd__la_dot(col, col, n));
        for (i = 0; i < n; ++i) { col[i] /= len; row2[i] += col[i] * col[i]; }
    }
}

SQFFD_DEF sqffd_result sqffd_svd(const double *a, size_t m, size_t n, double *u, double *s, double *v,
                                 void *workspace, size_t workspace_size)
{
    /* Jacobi columns of squared norm below DBL_MIN (norm < 1.5e-154 with the
       matrix scaled to max |a_ij| < 1) are zero: their dot products would
       underflow */
    const double zero2 = SQFFD__LA_MIN_NORMAL;
    sqffd__arena ar;
    sqffd__la_svd_work w;
    size_t mm, nn, i, j, k, rank;
    double amax = 0.0;
    int exponent = 0, converged;
    if (!a || !s || n < 1 || m < n) return SQFFD_ERROR_INVALID_ARGUMENT;
    mm = (size_t)m;
    nn = (size_t)n;
    sqffd__arena_init(&ar, workspace, workspace_size);
    sqffd__la_svd_layout(&ar, mm, nn, &w);
    if (mm > (size_t)-1 / nn) return SQFFD_ERROR_TOO_LARGE;
    if (ar.overflow) return sqffd__arena_error(&ar);
    for (i = 0; i < mm * nn; ++i) {
        if (!isfinite(a[i])) return SQFFD_ERROR_NON_FINITE;
        if (fabs(a[i]) > amax) amax = fabs(a[i]);
    }
    /* scale by a power of two (exact) so that norms can neither overflow nor underflow */
    if (amax > 0.0) (void)frexp(amax, &exponent);
    for (i = 0; i < mm * nn; ++i) w.qr[i] = ldexp(a[i], -exponent);

    sqffd__la_qr_pivoted(&w, mm, nn);
    for (j = 0; j < nn; ++j) /* column j of X = row j of R */
        for (i = 0; i < nn; ++i) w.x[j * nn + i] = i >= j ? w.qr[j * nn + i] : 0.0;
    if (u) {
        for (i = 0; i < nn * nn; ++i) w.rot[i] = 0.0;
        for (i = 0; i < nn; ++i) w.rot[i * nn + i] = 1.0;
    }
    converged = sqffd__la_jacobi_sweeps(&w, nn, u != NULL, zero2);

    /* exact norms, descending order, zero columns last */
    for (j = 0; j < nn; ++j) w.norm2[j] = sqffd__la_dot(w.x + j * nn, w.x + j * nn, nn);
    for (j = 0; j + 1 < nn; ++j) {
        size_t big = j;
        for (k = j + 1; k < nn; ++k)
            if (w.norm2[k] > w.norm2[big]) big = k;
        if (big != j) sqffd__la_svd_swap(&w, nn, j, big, u != NULL);
    }
    rank = 0;
    for (j = 0; j < nn; ++j) {
        double sj = w.norm2[j] < zero2 ? 0.0 : sqrt(w.norm2[j]);
        if (sj > 0.0) rank = j + 1;
        s[j] = ldexp(sj, exponent);
        w.tmp[j] = sj;
    }

    if (v) { /* V = P U1: normalise the nonzero columns of X, complete the rest */
        for (j = 0; j < rank; ++j)
            for (i = 0; i < nn; ++i) w.x[j * nn + i] /= w.tmp[j];
        sqffd__la_complete_basis(w.x, nn, rank, w.norm2);
        for (i = 0; i < nn; ++i)
            for (j = 0; j < nn; ++j) v[(size_t)w.perm[i] * nn + j] = w.x[j * nn + i];
    }
    if (u) { /* U = Q [J; 0], reflectors applied last to first, row by row */
        for (i = 0; i < mm; ++i)
            for (j = 0; j < nn; ++j) u[i * nn + j] = i < nn ? w.rot[j * nn + i] : 0.0;
        for (k = nn; k-- > 0;)
            if (w.tau[k] != 0.0) sqffd__la_reflect(w.qr, w.tau[k], mm, nn, k, u, 0, w.tmp);
    }
    return converged ? SQFFD_OK : SQFFD_ERROR_NO_CONVERGENCE;
}

SQFFD_DEF sqffd_result sqffd_svd_solve_workspace_size(size_t n, size_t *size)
{
    sqffd__arena ar;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    if (n < 1) return SQFFD_ERROR_INVALID_ARGUMENT;
    sqffd__arena_measure(&ar);
    sqffd__arena_take(&ar, n, sizeof(double));
    return sqffd__arena_size(&ar, size);
}

SQFFD_DEF sqffd_result sqffd_svd_solve(const double *u, const double *s, const double *v, size_t m, size_t n,
                                       double rcond, const double *b, double *x, size_t *rank,
                                       void *workspace, size_t workspace_size)
{
    sqffd__arena ar;
    double *scratch;
    size_t i, j, kept = 0;
    if (!u || !s || !v || !b || !x || n < 1 || m < n || !(rcond >= 0.0)) return SQFFD_ERROR_INVALID_ARGUMENT;
    sqffd__arena_init(&ar, workspace, workspace_size);
    scratch = (double *)sqffd__arena_take(&ar, n, sizeof(double));
    if (ar.overflow) return sqffd__arena_error(&ar);
    while (kept < n && s[kept] > 0.0 && s[kept] > rcond * s[0]) ++kept;
    /* scratch = diag(1/s) U^T b over the kept values, accumulated row by row */
    for (j = 0; j < n; ++j) scratch[j] = 0.0;
    for (i = 0; i < m; ++i) sqffd__la_axpy(scratch, b[i], u + i * n, kept);
    for (j = 0; j < kept; ++j) scratch[j] /= s[j];
    for (i = 0; i < n; ++i) x[i] = sqffd__la_dot(v + i * n, scratch, kept);
    if (rank) *rank = kept;
    return SQFFD_OK;
}

/* ---- Linear conjugate gradient ---- */

SQFFD_DEF sqffd_cg_options sqffd_cg_options_default(void)
{
    sqffd_cg_options o;
    o.max_iterations = 0;
    o.tolerance = 1e-10;
    o.jacobi_diagonal = NULL;
    return o;
}

typedef struct sqffd__la_cg_work {
    double *r, *z, *p, *q; /* residual, preconditioned residual, direction, A p */
} sqffd__la_cg_work;

static void sqffd__la_cg_layout(sqffd__arena *ar, size_t n, sqffd__la_cg_work *w)
{
    w->r = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->z = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->p = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->q = (double *)sqffd__arena_take(ar, n, sizeof(double));
}

SQFFD_DEF sqffd_result sqffd_cg_workspace_size(size_t n, size_t *size)
{
    sqffd__arena ar;
    sqffd__la_cg_work w;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    if (n < 1) return SQFFD_ERROR_INVALID_ARGUMENT;
    sqffd__arena_measure(&ar);
    sqffd__la_cg_layout(&ar, n, &w);
    return sqffd__arena_size(&ar, size);
}

/* 1 when all n entries are finite */
static int sqffd__la_all_finite(const double *x, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i)
        if (!isfinite(x[i])) return 0;
    return 1;
}

/* z = M^-1 r with the Jacobi preconditioner M = diag (NULL: z = r) */
static void sqffd__la_precondition(const double *diag, const double *r, double *z, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) z[i] = diag ? r[i] / diag[i] : r[i];
}

SQFFD_DEF sqffd_result sqffd_cg_solve(size_t n, sqffd_matvec_fn matvec, void *user, const double *b, double *x,
                                      const sqffd_cg_options *options, int *iterations, double *relative_residual,
                                      void *workspace, size_t workspace_size)
{
    sqffd_cg_options opt = options ? *options : sqffd_cg_options_default();
    sqffd__arena ar;
    sqffd__la_cg_work w;
    sqffd_result result = SQFFD_OK;
    size_t nn, i;
    double bnorm, rnorm, rz;
    int it = 0, max_it;
    if (iterations) *iterations = 0;
    if (relative_residual) *relative_residual = 0.0;
    if (n < 1 || !matvec || !b || !x || opt.max_iterations < 0 || !(opt.tolerance >= 0.0))
        return SQFFD_ERROR_INVALID_ARGUMENT;
    nn = (size_t)n;
    sqffd__arena_init(&ar, workspace, workspace_size);
    sqffd__la_cg_layout(&ar, nn, &w);
    if (ar.overflow) return sqffd__arena_error(&ar);
    if (!sqffd__la_all_finite(b, nn) || !sqffd__la_all_finite(x, nn)) return SQFFD_ERROR_NON_FINITE;
    if (opt.jacobi_diagonal) {
        if (!sqffd__la_all_finite(opt.jacobi_diagonal, nn)) return SQFFD_ERROR_NON_FINITE;
        for (i = 0; i < nn; ++i)
            if (!(opt.jacobi_diagonal[i] > 0.0)) return SQFFD_ERROR_NOT_POSITIVE_DEFINITE;
    }
    max_it = opt.max_iterations > 0 ? opt.max_iterations : (n > 0x3fffffff ? 0x7fffffff : 2 * (int)n);
    bnorm = sqrt(sqffd__la_dot(b, b, nn));
    if (bnorm == 0.0) { /* A x = 0 has the solution 0 */
        for (i = 0; i < nn; ++i) x[i] = 0.0;
        return SQFFD_OK;
    }
    matvec(user, x, w.q);
    for (i = 0; i < nn; ++i) w.r[i] = b[i] - w.q[i];
    rnorm = sqrt(sqffd__la_dot(w.r, w.r, nn));
    if (!isfinite(rnorm)) return SQFFD_ERROR_NON_FINITE;
    sqffd__la_precondition(opt.jacobi_diagonal, w.r, w.z, nn);
    memcpy(w.p, w.z, nn * sizeof(double));
    rz = sqffd__la_dot(w.r, w.z, nn);
    while (rnorm > opt.tolerance * bnorm) {
        double pq, alpha, rz_next, beta;
        if (it == max_it) { result = SQFFD_ERROR_NO_CONVERGENCE; break; }
        matvec(user, w.p, w.q);
        pq = sqffd__la_dot(w.p, w.q, nn);
        if (!isfinite(pq)) return SQFFD_ERROR_NON_FINITE;
        if (!(pq > 0.0)) return SQFFD_ERROR_NOT_POSITIVE_DEFINITE;
        alpha = rz / pq;
        sqffd__la_axpy(x, alpha, w.p, nn);
        sqffd__la_axpy(w.r, -alpha, w.q, nn);
        rnorm = sqrt(sqffd__la_dot(w.r, w.r, nn));
        ++it;
        sqffd__la_precondition(opt.jacobi_diagonal, w.r, w.z, nn);
        rz_next = sqffd__la_dot(w.r, w.z, nn);
        beta = rz_next / rz;
        rz = rz_next;
        for (i = 0; i < nn; ++i) w.p[i] = w.z[i] + beta * w.p[i];
    }
    if (iterations) *iterations = it;
    if (relative_residual) { /* the true residual, not the recurrence's */
        matvec(user, x, w.q);
        for (i = 0; i < nn; ++i) w.r[i] = b[i] - w.q[i];
        *relative_residual = sqrt(sqffd__la_dot(w.r, w.r, nn)) / bnorm;
    }
    return result;
}

/* ---- Nonlinear conjugate gradient ---- */

typedef struct sqffd__la_ncg_work {
    double *g;      /* gradient at x */
    double *gr;     /* reduced gradient: zero where the projection blocks descent */
    double *gr_old; /* previous reduced gradient (Polak-Ribiere) */
    double *d;      /* search direction */
    double *xu;     /* unprojected trial point x + t d */
    double *xt, *gt; /* trial point and its gradient */
    double *xb, *gb; /* best point of the line search that passed Armijo */
} sqffd__la_ncg_work;

static void sqffd__la_ncg_layout(sqffd__arena *ar, size_t n, sqffd__la_ncg_work *w)
{
    w->g = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->gr = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->gr_old = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->d = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->xu = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->xt = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->gt = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->xb = (double *)sqffd__arena_take(ar, n, sizeof(double));
    w->gb = (double *)sqffd__arena_take(ar, n, sizeof(double));
}

SQFFD_DEF sqffd_result sqffd_ncg_workspace_size(size_t n, size_t *size)
{
    sqffd__arena ar;
    sqffd__la_ncg_work w;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    if (n < 1) return SQFFD_ERROR_INVALID_ARGUMENT;
    sqffd__arena_measure(&ar);
    sqffd__la_ncg_layout(&ar, n, &w);
    return sqffd__arena_size(&ar, size);
}

typedef struct sqffd__la_ncg_problem {
    size_t n;
    sqffd_objective_fn f;
    sqffd_project_fn project;
    void *user;
} sqffd__la_ncg_problem;

/* Reduced gradient at x: g where a projected gradient step can move,
   0 where the projection holds the coordinate (a bound blocking descent).
   Returns ||project(x - g) - x||_inf, the optimality measure. Uses xt. */
static double sqffd__la_ncg_reduce(const sqffd__la_ncg_problem *pr, const double *x, sqffd__la_ncg_work *w)
{
    double worst = 0.0;
    size_t i;
    for (i = 0; i < pr->n; ++i) w->xt[i] = x[i] - w->g[i];
    if (pr->project) pr->project(pr->user, w->xt);
    for (i = 0; i < pr->n; ++i) {
        double step = w->xt[i] - x[i];
        w->gr[i] = step == 0.0 ? 0.0 : w->g[i];
        if (fabs(step) > worst) worst = fabs(step);
    }
    return worst;
}

/* Strong-Wolfe line search along the projected path x(t) = project(x + t d).
   phi(t) = f(x(t)); phi'(t) is measured on the coordinates the projection
   left free. A trial point is acceptable when it passes Armijo,
   phi(t) <= phi(0) + c1 g.(x(t) - x), or - where f is flat to rounding and
   Armijo cannot tell - the approximate Wolfe test of Hager & Zhang
   (phi(t) <= phi(0) + 1e-10 |phi(0)| and phi'(t) <= (1 - 2 c1) |phi'(0)|).
   The search ends at an acceptable point with |phi'(t)| <= c2 |phi'(0)|.
   [a, b] brackets the minimiser: phi'(a) < 0 at an acceptable a; b is an
   unacceptable step or one with phi'(b) >= 0. Next trials come from the
   secant on phi' (exact on quadratics) or a quadratic fit of phi, kept
   inside the bracket; without b the step grows 1.1x to 10x.
   On success x, g, *fx hold the new point and *t the step; returns 0 when no
   step was acceptable. */
static int sqffd__la_ncg_line_search(const sqffd__la_ncg_problem *pr, double *x, double *fx, double *t,
                                     sqffd__la_ncg_work *w)
{
    const double c1 = 1e-4, c2 = 0.1;
    size_t n = pr->n, i;
    double dg0 = sqffd__la_dot(w->g, w->d, n), step = *t;
    double a = 0.0, fa = *fx, da = dg0, a_prev = 0.0, da_prev = dg0; /* lower end */
    double b = -1.0, fb = 0.0, db = 0.0;                             /* upper end, b < 0: none yet */
    double best_t = 0.0, best_f = 0.0;
    int eval, found = 0, b_has_slope = 0;
    for (eval = 0; eval < 40; ++eval) {
        double ft, slope = 0.0, dphi = 0.0, next;
        int moved = 0, acceptable;
        for (i = 0; i < n; ++i) w->xu[i] = w->xt[i] = x[i] + step * w->d[i];
        if (pr->project) pr->project(pr->user, w->xt);
        for (i = 0; i < n; ++i) {
            slope += w->g[i] * (w->xt[i] - x[i]);
            if (w->xt[i] != x[i]) moved = 1;
        }
        if (!moved) break; /* the step vanished below the resolution of x */
        ft = pr->f(pr->user, w->xt, w->gt);
        for (i = 0; i < n; ++i)
            if (w->xt[i] == w->xu[i]) dphi += w->gt[i] * w->d[i];
        acceptable = isfinite(ft) && isfinite(dphi) && slope < 0.0 &&
                     (ft <= *fx + c1 * slope || (ft <= *fx + 1e-10 * fabs(*fx) && dphi <= -(1.0 - 2.0 * c1) * dg0));
        if (acceptable && (!found || ft <= best_f)) {
            memcpy(w->xb, w->xt, n * sizeof(double));
            memcpy(w->gb, w->gt, n * sizeof(double));
            best_t = step;
            best_f = ft;
            found = 1;
            if (fabs(dphi) <= -c2 * dg0) break;
        }
        if (acceptable && dphi < 0.0) {
            a_prev = a; da_prev = da;
            a = step; fa = ft; da = dphi;
        } else {
            b = step;
            fb = ft;
            db = dphi;
            b_has_slope = acceptable;
        }
        if (b < 0.0) { /* extrapolate: secant on phi' when it is rising, else x10 */
            next = da > da_prev ? a - da * (a - a_prev) / (da - da_prev) : 10.0 * a;
            if (!(next >= 1.1 * a)) next = 1.1 * a;
            if (next > 10.0 * a) next = 10.0 * a;
        } else {
            double width = b - a;
            if (b_has_slope) next = a - da * width / (db - da);
            else next = a - da * width * width / (2.0 * (fb - fa - da * width));
            if (!isfinite(next) || !(next >= a + 0.05 * width) || !(next <= b - 0.05 * width))
                next = a + 0.5 * width;
        }
        step = next;
    }
    if (!found) return 0;
    memcpy(x, w->xb, n * sizeof(double));
    memcpy(w->g, w->gb, n * sizeof(double));
    *fx = best_f;
    *t = best_t;
    return 1;
}

SQFFD_DEF sqffd_ncg_options sqffd_ncg_options_default(void)
{
    sqffd_ncg_options o;
    o.max_iterations = 100;
    o.tolerance = 1e-8;
    o.project = NULL;
    o.progress = NULL;
    o.progress_user = NULL;
    return o;
}

SQFFD_DEF sqffd_result sqffd_ncg_minimize(size_t n, sqffd_objective_fn f, void *user, double *x,
                                          const sqffd_ncg_options *options, int *iterations, double *fx,
                                          void *workspace, size_t workspace_size)
{
    sqffd_ncg_options defaults = sqffd_ncg_options_default();
    const sqffd_ncg_options *o = options ? options : &defaults;
    sqffd_project_fn project = o->project;
    int max_iterations = o->max_iterations;
    double tolerance = o->tolerance;
    sqffd__arena ar;
    sqffd__la_ncg_work w;
    sqffd__la_ncg_problem pr;
    sqffd_result result = SQFFD_ERROR_NO_CONVERGENCE;
    size_t nn, i;
    double value, step = 0.0, gd_old = 0.0;
    int it, since_restart = 0;
    if (iterations) *iterations = 0;
    if (n < 1 || !f || !x || max_iterations < 1 || !(tolerance >= 0.0)) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (n > 0x7fffffff) return SQFFD_ERROR_TOO_LARGE; /* (the restart count is an int) */
    nn = (size_t)n;
    sqffd__arena_init(&ar, workspace, workspace_size);
    sqffd__la_ncg_layout(&ar, nn, &w);
    if (ar.overflow) return sqffd__arena_error(&ar);
    if (!sqffd__la_all_finite(x, nn)) return SQFFD_ERROR_NON_FINITE;
    pr.n = nn; pr.f = f; pr.project = project; pr.user = user;
    if (project) project(user, x);
    value = f(user, x, w.g);
    if (fx) *fx = value;
    if (!isfinite(value) || !sqffd__la_all_finite(w.g, nn)) return SQFFD_ERROR_NON_FINITE;
    for (it = 0; it < max_iterations; ++it) {
        double gd, pgnorm = sqffd__la_ncg_reduce(&pr, x, &w);
        if (pgnorm <= tolerance * (1.0 + fabs(value))) { result = SQFFD_OK; break; }
        /* Polak-Ribiere+ on the reduced gradients, steepest descent on restart */
        if (since_restart > 0 && (size_t)since_restart < n) {
            double num = 0.0, den = sqffd__la_dot(w.gr_old, w.gr_old, nn), beta;
            for (i = 0; i < nn; ++i) num += w.gr[i] * (w.gr[i] - w.gr_old[i]);
            beta = den > 0.0 && num > 0.0 ? num / den : 0.0;
            for (i = 0; i < nn; ++i) w.d[i] = -w.gr[i] + beta * w.d[i];
        } else {
            for (i = 0; i < nn; ++i) w.d[i] = -w.gr[i];
            since_restart = 0;
        }
        gd = sqffd__la_dot(w.g, w.d, nn);
        if (!(gd < 0.0)) { /* lost descent: restart */
            for (i = 0; i < nn; ++i) w.d[i] = -w.gr[i];
            gd = -sqffd__la_dot(w.gr, w.gr, nn);
            since_restart = 0;
        }
        /* first trial step: a unit move in x at the start, then the step that
           repeats the last decrease predicted by the slope (Nocedal & Wright 3.5) */
        if (step > 0.0) step = step * gd_old / gd;
        if (!(step > 0.0) || !isfinite(step)) step = 1.0 / sqrt(sqffd__la_dot(w.d, w.d, nn));
        memcpy(w.gr_old, w.gr, nn * sizeof(double));
        gd_old = gd;
        if (!sqffd__la_ncg_line_search(&pr, x, &value, &step, &w)) {
            if (since_restart == 0) { result = SQFFD_OK; break; } /* no decrease possible */
            since_restart = 0; /* retry along steepest descent */
            step = 0.0;
            continue;
        }
        ++since_restart;
        if (fx) *fx = value;
        if (iterations) *iterations = it + 1;
        if (o->progress && o->progress(o->progress_user, SQFFD_STAGE_SUPERQUADRIC, it + 1, value)) {
            result = SQFFD_ERROR_CANCELLED;
            break;
        }
    }
    if (fx) *fx = value;
    return result;
}
/* ======================================================================
   Layer 2: kd-tree
   ====================================================================== */

#define SQFFD__KD_LEAF_SIZE 10u /* a node with more points than this is split */
#define SQFFD__KD_MIN_CHILD 5u  /* ... into children of at least this many points */

/* Nodes for n points: every leaf but a lone root holds >= MIN_CHILD points. */
static size_t sqffd__kd_max_nodes(size_t n)
{
    return n <= SQFFD__KD_LEAF_SIZE ? 1 : 2 * (n / SQFFD__KD_MIN_CHILD) - 1;
}

/* The one workspace layout: the permutation, then the nodes. */
/* A node waiting to be built: its point range, depth, tight box, and the
   node whose high child it is (0 for a low child or the root: those are
   simply the next node). */
typedef struct sqffd__kd_pending {
    size_t begin, end;
    unsigned depth;
    uint32_t parent_of_high;
    double box[2][3];
} sqffd__kd_pending;

/* The refit's stack of subtree boxes (one per level), in the same memory as
   the build's stack of pending nodes. */
typedef double sqffd__kd_box[2][3];

static void sqffd__kd_layout(sqffd__arena *a, size_t n, uint32_t **index, sqffd_kdtree_node **nodes, void **stack)
{
    *index = (uint32_t *)sqffd__arena_take(a, n, sizeof(uint32_t));
    *nodes = (sqffd_kdtree_node *)sqffd__arena_take(a, sqffd__kd_max_nodes(n), sizeof(sqffd_kdtree_node));
    *stack = sqffd__arena_take(a, SQFFD_KDTREE_MAX_DEPTH + 1, sizeof(sqffd__kd_pending) > sizeof(sqffd__kd_box)
                                                                  ? sizeof(sqffd__kd_pending) : sizeof(sqffd__kd_box));
}

SQFFD_DEF sqffd_result sqffd_kdtree_workspace_size(size_t n, size_t *size)
{
    sqffd__arena a;
    uint32_t *index;
    sqffd_kdtree_node *nodes;
    void *stack;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    if (n == 0) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (n > (size_t)UINT32_MAX) return SQFFD_ERROR_TOO_LARGE;
    sqffd__arena_measure(&a);
    sqffd__kd_layout(&a, n, &index, &nodes, &stack);
    return sqffd__arena_size(&a, size);
}

/* ceil(log2(c)) for c >= 1: the depth a median-split subtree of c points needs. */
static unsigned sqffd__kd_log2_ceil(size_t c)
{
    unsigned bits = 0;
    size_t v = c - 1;
    while (v) { bits++; v >>= 1; }
    return bits;
}

/* Grows box ([0] = min corner, [1] = max corner) to hold p. */
static void sqffd__kd_extend(double box[2][3], const double *p)
{
    int d;
    for (d = 0; d < 3; d++) { /* conditional moves, not branches */
        box[0][d] = p[d] < box[0][d] ? p[d] : box[0][d];
        box[1][d] = p[d] > box[1][d] ? p[d] : box[1][d];
    }
}

static void sqffd__kd_empty_box(double box[2][3])
{
    int d;
    for (d = 0; d < 3; d++) { box[0][d] = HUGE_VAL; box[1][d] = -HUGE_VAL; }
}

/* Tight bounding box of the points index[begin..end). */
static void sqffd__kd_bounds(const sqffd_points *points, const uint32_t *index, size_t begin, size_t end,
                             double box[2][3])
{
    size_t i;
    double p[3];
    sqffd__kd_empty_box(box);
    for (i = begin; i < end; i++) {
        sqffd__points_get(points, index[i], p);
        sqffd__kd_extend(box, p);
    }
}

/* The tree's points, field by field: its padding stays the zero its build
   wrote (a struct copy may carry the caller's stray padding bytes, and equal
   inputs must give equal trees to the byte). */
static void sqffd__kd_keep_points(sqffd_kdtree *tree, const sqffd_points *points)
{
    tree->points.xyz = points->xyz;
    tree->points.count = points->count;
    tree->points.stride = points->stride;
    tree->points.type = points->type;
}

/* Coordinate `axis` of point i. */
static double sqffd__kd_coord(const sqffd_points *points, uint32_t i, int axis)
{
    double p[3];
    sqffd__points_get(points, i, p);
    return p[axis];
}

/* Moves index[begin..end) so that position t holds the element of rank t
   along axis, smaller-or-equal ones before it, larger-or-equal after.
   Quickselect with Hoare partitions around a pivot at a pseudo-random
   position (a fixed xorshift sequence: deterministic, yet no ordering of the
   input makes it quadratic short of being built against that sequence). */
static void sqffd__kd_select(const sqffd_points *points, uint32_t *index, size_t begin, size_t end,
                             size_t t, int axis)
{
    ptrdiff_t lo = (ptrdiff_t)begin, hi = (ptrdiff_t)end - 1, target = (ptrdiff_t)t;
    uint32_t random = 2463534242u;
    while (lo < hi) {
        double pivot;
        random ^= random << 13; random ^= random >> 17; random ^= random << 5;
        pivot = sqffd__kd_coord(points, index[lo + (ptrdiff_t)(random % (uint32_t)(hi - lo + 1))], axis);
        ptrdiff_t i = lo, j = hi;
        while (i <= j) {
            uint32_t tmp;
            while (sqffd__kd_coord(points, index[i], axis) < pivot) i++;
            while (sqffd__kd_coord(points, index[j], axis) > pivot) j--;
            if (i > j) break;
            tmp = index[i]; index[i] = index[j]; index[j] = tmp;
            i++; j--;
        }
        if (target <= j) hi = j;
        else if (target >= i) lo = i;
        else break;
    }
}


/* Splits index[begin..end) of a node with a positive extent on `axis`: at the
   middle of the box (or the median), moved where needed so both children get
   MIN_CHILD points. Returns the size of the low part; fills both children's
   tight boxes. */
static size_t sqffd__kd_split(const sqffd_points *points, uint32_t *index, const sqffd__kd_pending *node,
                              int axis, int median, double low_box[2][3], double high_box[2][3])
{
    size_t count = node->end - node->begin, low_count = count / 2;
    int by_rank = median; /* the low part is the low_count smallest on axis */
    if (!median) {
        /* Branch-free partition (every step swaps; only the boundary k moves
           by the comparison), so the point loads never wait on a branch. */
        double cut = 0.5 * node->box[0][axis] + 0.5 * node->box[1][axis]; /* cannot overflow */
        size_t i, k = node->begin;
        for (i = node->begin; i < node->end; i++) {
            uint32_t p = index[i];
            index[i] = index[k];
            index[k] = p;
            k += (size_t)(sqffd__kd_coord(points, p, axis) < cut);
        }
        low_count = k - node->begin;
        by_rank = low_count < SQFFD__KD_MIN_CHILD || count - low_count < SQFFD__KD_MIN_CHILD;
        if (by_rank) low_count = low_count < SQFFD__KD_MIN_CHILD ? SQFFD__KD_MIN_CHILD : count - SQFFD__KD_MIN_CHILD;
    }
    if (by_rank) sqffd__kd_select(points, index, node->begin, node->end, node->begin + low_count, axis);
    sqffd__kd_bounds(points, index, node->begin, node->begin + low_count, low_box);
    sqffd__kd_bounds(points, index, node->begin + low_count, node->end, high_box);
    return low_count;
}

SQFFD_DEF sqffd_result sqffd_kdtree_build_view(sqffd_kdtree *tree, sqffd_points points, void *workspace,
                                               size_t workspace_size)
{
    sqffd__arena a;
    uint32_t *index;
    sqffd_kdtree_node *nodes;
    sqffd__kd_pending *stack;
    void *scratch;
    size_t top = 0, node_count = 0, i, n = points.count;
    sqffd_result r;

    if (tree) memset(tree, 0, sizeof *tree);
    if (!tree || n == 0) return SQFFD_ERROR_INVALID_ARGUMENT;
    r = sqffd__points_check(&points);
    if (r != SQFFD_OK) return r;
    if (n > (size_t)UINT32_MAX) return SQFFD_ERROR_TOO_LARGE;
    sqffd__arena_init(&a, workspace, workspace_size);
    sqffd__kd_layout(&a, n, &index, &nodes, &scratch);
    if (a.overflow) return sqffd__arena_error(&a);
    stack = (sqffd__kd_pending *)scratch;

    sqffd__kd_empty_box(stack[0].box);
    for (i = 0; i < n; i++) {
        double p[3];
        sqffd__points_get(&points, i, p);
        if (!sqffd__finite3(p)) return SQFFD_ERROR_NON_FINITE;
        sqffd__kd_extend(stack[0].box, p);
        index[i] = (uint32_t)i;
    }
    stack[0].begin = 0;
    stack[0].end = n;
    stack[0].depth = 0;
    stack[0].parent_of_high = 0;
    memcpy(tree->bbox, stack[0].box, sizeof tree->bbox);
    top = 1;
    while (top > 0) {
        sqffd__kd_pending cur = stack[--top];
        sqffd_kdtree_node *node = &nodes[node_count];
        size_t count = cur.end - cur.begin, low_count;
        double extent = -1.0;
        int axis = 0, d, median;

        SQFFD_ASSERT(node_count < sqffd__kd_max_nodes(n));
        memset(node, 0, sizeof *node); /* no stale bytes: equal inputs give equal trees */
        if (cur.parent_of_high) nodes[cur.parent_of_high - 1].high_child = (uint32_t)node_count;
        node_count++;
        for (d = 0; d < 3; d++) {
            double e = cur.box[1][d] - cur.box[0][d];
            if (e > extent) { extent = e; axis = d; }
        }
        if (count <= SQFFD__KD_LEAF_SIZE || !(extent > 0.0)) { /* small, or all points identical */
            node->u.leaf.begin = (uint32_t)cur.begin;
            node->u.leaf.end = (uint32_t)cur.end;
            node->axis = SQFFD_KDTREE_LEAF;
            continue;
        }
        /* Midpoint cuts while they cannot break the depth bound, else the
           median, whose subtree needs only ceil(log2(count)) more levels. */
        median = cur.depth + 1 + sqffd__kd_log2_ceil(count) > SQFFD_KDTREE_MAX_DEPTH;
        SQFFD_ASSERT(top + 2 <= SQFFD_KDTREE_MAX_DEPTH + 1);
        low_count = sqffd__kd_split(&points, index, &cur, axis, median, stack[top + 1].box, stack[top].box);
        node->axis = (uint32_t)axis;
        node->u.split.low = stack[top + 1].box[1][axis];
        node->u.split.high = stack[top].box[0][axis]; /* high_child is set when that child is built */
        /* High child below the low one on the stack: the low child is built next. */
        stack[top].begin = cur.begin + low_count;
        stack[top].end = cur.end;
        stack[top].depth = cur.depth + 1;
        stack[top].parent_of_high = (uint32_t)node_count; /* this node's number + 1 */
        stack[top + 1].begin = cur.begin;
        stack[top + 1].end = cur.begin + low_count;
        stack[top + 1].depth = cur.depth + 1;
        stack[top + 1].parent_of_high = 0;
        top += 2;
    }
    sqffd__kd_keep_points(tree, &points);
    tree->count = n;
    tree->index = index;
    tree->nodes = nodes;
    tree->node_count = node_count;
    tree->scratch = scratch;
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_kdtree_build(sqffd_kdtree *tree, const double *points, size_t n,
                                          void *workspace, size_t workspace_size)
{
    return sqffd_kdtree_build_view(tree, sqffd_points_packed(points, n), workspace, workspace_size);
}

/* Refit, in reverse node order: preorder numbers every node before its low
   subtree and that before its high subtree, so walking backwards finishes
   both subtrees of a node before it, and a stack of their boxes (the low
   child's on top) suffices. */
SQFFD_DEF sqffd_result sqffd_kdtree_refit_view(sqffd_kdtree *tree, sqffd_points points)
{
    sqffd__kd_box *stack;
    size_t top = 0, i, k;
    double p[3], first[3];
    sqffd_result r;
    if (!tree || !tree->nodes || !tree->scratch || points.count != tree->count) return SQFFD_ERROR_INVALID_ARGUMENT;
    r = sqffd__points_check(&points);
    if (r != SQFFD_OK) return r;
    stack = (sqffd__kd_box *)tree->scratch;
    for (i = 0; i < tree->count; i++) {
        sqffd__points_get(&points, i, p);
        if (!sqffd__finite3(p)) return SQFFD_ERROR_NON_FINITE;
    }
    for (i = 0; i < tree->node_count; i++) { /* the scan's shortcut for big leaves needs them identical */
        const sqffd_kdtree_node *n = &tree->nodes[i];
        if (n->axis != SQFFD_KDTREE_LEAF || n->u.leaf.end - n->u.leaf.begin <= SQFFD__KD_LEAF_SIZE) continue;
        sqffd__points_get(&points, tree->index[n->u.leaf.begin], first);
        for (k = n->u.leaf.begin + 1; k < n->u.leaf.end; k++) {
            sqffd__points_get(&points, tree->index[k], p);
            if (p[0] != first[0] || p[1] != first[1] || p[2] != first[2]) return SQFFD_ERROR_DEGENERATE;
        }
    }
    for (i = tree->node_count; i-- > 0;) {
        sqffd_kdtree_node *n = &tree->nodes[i];
        if (n->axis == SQFFD_KDTREE_LEAF) {
            SQFFD_ASSERT(top <= SQFFD_KDTREE_MAX_DEPTH);
            sqffd__kd_bounds(&points, tree->index, n->u.leaf.begin, n->u.leaf.end, stack[top++]);
            continue;
        }
        SQFFD_ASSERT(top >= 2);
        n->u.split.low = stack[top - 1][1][n->axis];
        n->u.split.high = stack[top - 2][0][n->axis];
        sqffd__kd_extend(stack[top - 2], stack[top - 1][0]);
        sqffd__kd_extend(stack[top - 2], stack[top - 1][1]);
        top--;
    }
    SQFFD_ASSERT(top == 1);
    memcpy(tree->bbox, stack[0], sizeof tree->bbox);
    sqffd__kd_keep_points(tree, &points);
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_kdtree_refit(sqffd_kdtree *tree, const double *points)
{
    return sqffd_kdtree_refit_view(tree, sqffd_points_packed(points, tree ? tree->count : 0));
}

/* ---- Queries --------------------------------------------------------------
   Results live in the caller's arrays: up to SQFFD__KD_SORTED_MAX of them
   kept sorted by insertion (cheaper than a heap for few), more as a max-heap
   on squared distance (the worst kept point on top), sorted once at the end. */
#define SQFFD__KD_SORTED_MAX 8

typedef struct sqffd__kd_results {
    size_t *index;
    double *dist2;
    size_t capacity, size;
    size_t worst;   /* where the worst kept point is: size - 1 when sorted, 0 in a heap */
    size_t within;  /* points seen at distance^2 <= reach (the radius count) */
    double reach;   /* points and subtrees farther than this (squared) cannot change the answer */
    int counting;   /* radius: every point within reach counts, so a full heap keeps reach */
} sqffd__kd_results;

static void sqffd__kd_sift_down(size_t *index, double *dist2, size_t size, size_t i)
{
    size_t moving = index[i];
    double d = dist2[i];
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= size) break;
        if (c + 1 < size && dist2[c + 1] > dist2[c]) c++;
        if (!(dist2[c] > d)) break;
        index[i] = index[c]; dist2[i] = dist2[c];
        i = c;
    }
    index[i] = moving; dist2[i] = d;
}

/* Keeps point (at squared distance d <= reach) if it is among the nearest
   `capacity` seen so far. */
static void sqffd__kd_offer(sqffd__kd_results *r, size_t point, double d)
{
    if (r->capacity <= SQFFD__KD_SORTED_MAX) { /* insertion, the worst dropped when full */
        size_t i;
        if (r->size == r->capacity && (r->size == 0 || !(d < r->dist2[r->size - 1]))) return;
        i = r->size < r->capacity ? r->size++ : r->size - 1;
        for (; i > 0 && r->dist2[i - 1] > d; i--) { r->index[i] = r->index[i - 1]; r->dist2[i] = r->dist2[i - 1]; }
        r->index[i] = point; r->dist2[i] = d;
        r->worst = r->size - 1;
    } else if (r->size < r->capacity) { /* not full: sift up from the end */
        size_t i = r->size++;
        while (i > 0 && r->dist2[(i - 1) / 2] < d) {
            r->index[i] = r->index[(i - 1) / 2]; r->dist2[i] = r->dist2[(i - 1) / 2];
            i = (i - 1) / 2;
        }
        r->index[i] = point; r->dist2[i] = d;
    } else if (r->size && d < r->dist2[0]) {
        r->index[0] = point; r->dist2[0] = d;
        sqffd__kd_sift_down(r->index, r->dist2, r->size, 0);
    } else {
        return;
    }
    if (!r->counting && r->size == r->capacity) r->reach = r->dist2[r->worst];
}

/* Scans a leaf. A leaf bigger than the leaf size holds identical points only:
   one distance serves them all, and offering stops once it cannot be kept. */
static double sqffd__kd_dist2(const sqffd_points *points, uint32_t i, const double q[3])
{
    double p[3];
    sqffd__points_get(points, i, p);
    return sqffd__dist2_3(p, q);
}

static void sqffd__kd_scan_leaf(const sqffd_kdtree *tree, const sqffd_kdtree_node *leaf, const double q[3],
                                sqffd__kd_results *r)
{
    const sqffd_points points = tree->points; /* (a copy the offers' stores cannot alias: kept in registers) */
    const uint32_t *index = tree->index;
    size_t i, begin = leaf->u.leaf.begin, end = leaf->u.leaf.end;
    if (end - begin > SQFFD__KD_LEAF_SIZE) {
        double d = sqffd__kd_dist2(&points, index[begin], q);
        if (!(d <= r->reach)) return;
        r->within += end - begin;
        for (i = begin; i < end && (r->size < r->capacity || (r->size && d < r->dist2[r->worst])); i++)
            sqffd__kd_offer(r, index[i], d);
        return;
    }
    for (i = begin; i < end; i++) {
        double d = sqffd__kd_dist2(&points, index[i], q);
        if (d <= r->reach) {
            r->within++;
            sqffd__kd_offer(r, index[i], d);
        }
    }
}

/* Depth-first walk, nearest child first. sq0..sq2 hold the squared per-axis
   distances from the query to the region known to hold a subtree's points;
   their sum (added in the same order as a point's distance, so it never
   exceeds any of those points' computed distances) prunes the far child. */
static void sqffd__kd_search(const sqffd_kdtree *tree, const double q[3], sqffd__kd_results *r)
{
    struct { double sq[3]; double bound; uint32_t node; } stack[SQFFD_KDTREE_MAX_DEPTH];
    const sqffd_kdtree_node *nodes = tree->nodes;
    size_t top = 0;
    double sq0, sq1, sq2, off[3];
    uint32_t node = 0;
    int d;

    for (d = 0; d < 3; d++)
        off[d] = q[d] < tree->bbox[0][d] ? tree->bbox[0][d] - q[d]
               : q[d] > tree->bbox[1][d] ? q[d] - tree->bbox[1][d] : 0.0;
    sq0 = off[0] * off[0]; sq1 = off[1] * off[1]; sq2 = off[2] * off[2];
    if (!(sq0 + sq1 + sq2 <= r->reach)) return;
    for (;;) {
        const sqffd_kdtree_node *n = &nodes[node];
        if (n->axis != SQFFD_KDTREE_LEAF) {
            /* Branch-free step: the far child's entry is written in place
               and kept (top advances) only when it is within reach. */
            uint32_t axis = n->axis;
            double above_low = q[axis] - n->u.split.low, below_high = n->u.split.high - q[axis];
            int go_high = !(above_low < below_high);
            double gap = go_high ? above_low : below_high;
            gap = gap > 0.0 ? gap : 0.0; /* (after a refit the children's regions may overlap) */
            SQFFD_ASSERT(top < SQFFD_KDTREE_MAX_DEPTH);
            stack[top].sq[0] = sq0; stack[top].sq[1] = sq1; stack[top].sq[2] = sq2;
            stack[top].sq[axis] = gap * gap;
            stack[top].bound = stack[top].sq[0] + stack[top].sq[1] + stack[top].sq[2];
            stack[top].node = go_high ? node + 1 : n->high_child;
            node = go_high ? n->high_child : node + 1;
            top += (size_t)(stack[top].bound <= r->reach);
            continue;
        }
        sqffd__kd_scan_leaf(tree, n, q, r);
        for (;;) { /* next pending subtree still within reach */
            if (top == 0) return;
            top--;
            if (stack[top].bound <= r->reach) break;
        }
        sq0 = stack[top].sq[0]; sq1 = stack[top].sq[1]; sq2 = stack[top].sq[2];
        node = stack[top].node;
    }
}

/* Sorts a heap by increasing distance. */
static void sqffd__kd_sort(sqffd__kd_results *r)
{
    size_t end = r->capacity <= SQFFD__KD_SORTED_MAX ? 0 : r->size;
    while (end > 1) {
        size_t i0 = r->index[0];
        double d0 = r->dist2[0];
        end--;
        r->index[0] = r->index[end]; r->dist2[0] = r->dist2[end];
        r->index[end] = i0; r->dist2[end] = d0;
        sqffd__kd_sift_down(r->index, r->dist2, end, 0);
    }
}

static size_t sqffd__kd_query(const sqffd_kdtree *tree, const double q[3], double limit, int counting,
                              size_t *indices, double *dist2, size_t capacity)
{
    sqffd__kd_results r;
    r.index = indices;
    r.dist2 = dist2;
    r.capacity = capacity;
    r.size = 0;
    r.worst = 0;
    r.within = 0;
    r.reach = limit;
    r.counting = counting;
    sqffd__kd_search(tree, q, &r);
    sqffd__kd_sort(&r);
    return counting ? r.within : r.size;
}

static sqffd_result sqffd__kd_queryable(const sqffd_kdtree *tree, const double q[3], const void *out)
{
    if (!tree || !tree->count || !tree->nodes || !q || !out) return SQFFD_ERROR_INVALID_ARGUMENT;
    return sqffd__finite3(q) ? SQFFD_OK : SQFFD_ERROR_NON_FINITE;
}

SQFFD_DEF sqffd_result sqffd_kdtree_nearest(const sqffd_kdtree *tree, const double query[3], size_t *index,
                                            double *dist2)
{
    double d = 0.0;
    sqffd_result r = sqffd__kd_queryable(tree, query, index);
    if (r != SQFFD_OK) return r;
    sqffd__kd_query(tree, query, HUGE_VAL, 0, index, &d, 1);
    if (dist2) *dist2 = d;
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_kdtree_knn(const sqffd_kdtree *tree, const double query[3], size_t k, size_t *indices,
                                        double *dist2, size_t *found)
{
    sqffd_result r = sqffd__kd_queryable(tree, query, found);
    if (r == SQFFD_OK && k > 0 && (!indices || !dist2)) r = SQFFD_ERROR_INVALID_ARGUMENT;
    if (r != SQFFD_OK) return r;
    *found = k ? sqffd__kd_query(tree, query, HUGE_VAL, 0, indices, dist2, k < tree->count ? k : tree->count) : 0;
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_kdtree_radius(const sqffd_kdtree *tree, const double query[3], double radius,
                                           size_t *indices, double *dist2, size_t capacity, size_t *count)
{
    size_t within;
    sqffd_result r = sqffd__kd_queryable(tree, query, count);
    if (r == SQFFD_OK && (!(radius >= 0.0) || (capacity > 0 && (!indices || !dist2)))) r = SQFFD_ERROR_INVALID_ARGUMENT;
    if (r != SQFFD_OK) return r;
    within = sqffd__kd_query(tree, query, radius * radius, 1, NULL, NULL, 0); /* counted before anything is written */
    *count = within;
    if (capacity == 0) return SQFFD_OK;
    if (within > capacity) return SQFFD_ERROR_OUTPUT_TOO_SMALL;
    sqffd__kd_query(tree, query, radius * radius, 1, indices, dist2, within);
    return SQFFD_OK;
}
/* ======================================================================
   Layer 3: superquadric with global tapering
   ====================================================================== */

#define SQFFD__SQ_PI 3.14159265358979323846
/* Magnitudes below this count as 0 before a logarithm (keeps logs finite). */
#define SQFFD__SQ_TINY 1e-300
/* Floor of the tapering factors 1 + K z / a3: they are >= 1 - |K| > 0 on the
   shape itself; only points far beyond the poles reach the floor. */
#define SQFFD__SQ_MIN_TAPER 1e-3

/* ---- geometry ----------------------------------------------------------- */

/* sign(v) |v|^e, 0 for v = 0 */
static double sqffd__sq_spow(double v, double e)
{
    if (v == 0.0) return 0.0;
    return v > 0.0 ? pow(v, e) : -pow(-v, e);
}

/* log(e^a + e^b) and the shares frac[0] = e^a / (e^a + e^b), frac[1] = e^b / (...),
   each computed directly so that a vanishing share is exactly 0. */
static double sqffd__sq_logsum(double a, double b, double frac[2])
{
    double hi = a > b ? a : b, t = exp(-fabs(a - b)); /* e^(lo - hi) */
    double s = 1.0 + t;
    frac[0] = a > b ? 1.0 / s : t / s;
    frac[1] = a > b ? t / s : 1.0 / s;
    return hi + log(s);
}

static double sqffd__sq_log_abs(double v)
{
    double m = fabs(v);
    return log(m > SQFFD__SQ_TINY ? m : SQFFD__SQ_TINY);
}

/* Tapered local coordinates q = R^T (p - c). */
static void sqffd__sq_to_local(const sqffd_superquadric *sq, const double p[3], double q[3])
{
    double d[3];
    sqffd__sub3(p, sq->center, d);
    sqffd__mat3t_vec(sq->rotation, d, q);
}

/* The tapering factors 1 + K z / a3 at local height z (floored). */
static void sqffd__sq_taper_factors(const sqffd_superquadric *sq, double z, double f[2])
{
    int k;
    for (k = 0; k < 2; k++) {
        f[k] = 1.0 + sq->taper[k] * z / sq->size[2];
        if (f[k] < SQFFD__SQ_MIN_TAPER) f[k] = SQFFD__SQ_MIN_TAPER;
    }
}

/* Untapered local coordinates of a world point. */
static void sqffd__sq_untapered(const sqffd_superquadric *sq, const double p[3], double u[3])
{
    double f[2];
    sqffd__sq_to_local(sq, p, u);
    sqffd__sq_taper_factors(sq, u[2], f);
    u[0] /= f[0];
    u[1] /= f[1];
}

/* log F at untapered local coordinates u (log_size = ln a1, ln a2, ln a3),
   computed in logarithms so that far points and small exponents neither
   overflow nor underflow:
   F = (|x/a1|^(2/e2) + |y/a2|^(2/e2))^(e2/e1) + |z/a3|^(2/e1) = G + H,
   G = A^(e2/e1), A = U + V. If parts is not NULL it receives what the
   derivatives need (SQFFD__SQ_PART_* indices). */
#define SQFFD__SQ_PART_LU 0    /* ln U */
#define SQFFD__SQ_PART_LV 1    /* ln V */
#define SQFFD__SQ_PART_LA 2    /* ln A */
#define SQFFD__SQ_PART_LG 3    /* ln G */
#define SQFFD__SQ_PART_LH 4    /* ln H */
#define SQFFD__SQ_PART_FU 5    /* U / A (then V / A) */
#define SQFFD__SQ_PART_FG 7    /* G / F (then H / F) */
#define SQFFD__SQ_PARTS 9
typedef struct sqffd__sq_exponents {
    double two_e1, two_e2, ratio; /* 2/e1, 2/e2, e2/e1 */
} sqffd__sq_exponents;

static sqffd__sq_exponents sqffd__sq_exponents_of(const sqffd_superquadric *sq)
{
    sqffd__sq_exponents x;
    x.two_e1 = 2.0 / sq->shape[0];
    x.two_e2 = 2.0 / sq->shape[1];
    x.ratio = sq->shape[1] / sq->shape[0];
    return x;
}

static double sqffd__sq_log_f(const double u[3], const double log_size[3], const sqffd__sq_exponents *x, double *parts)
{
    double lu = x->two_e2 * (sqffd__sq_log_abs(u[0]) - log_size[0]);
    double lv = x->two_e2 * (sqffd__sq_log_abs(u[1]) - log_size[1]);
    double lh = x->two_e1 * (sqffd__sq_log_abs(u[2]) - log_size[2]);
    double frac_u[2], frac_g[2], la, lg, lf;
    la = sqffd__sq_logsum(lu, lv, frac_u);
    lg = x->ratio * la;
    lf = sqffd__sq_logsum(lg, lh, frac_g);
    if (parts) {
        parts[SQFFD__SQ_PART_LU] = lu; parts[SQFFD__SQ_PART_LV] = lv; parts[SQFFD__SQ_PART_LA] = la;
        parts[SQFFD__SQ_PART_LG] = lg; parts[SQFFD__SQ_PART_LH] = lh;
        parts[SQFFD__SQ_PART_FU] = frac_u[0]; parts[SQFFD__SQ_PART_FU + 1] = frac_u[1];
        parts[SQFFD__SQ_PART_FG] = frac_g[0]; parts[SQFFD__SQ_PART_FG + 1] = frac_g[1];
    }
    return lf;
}

static double sqffd__sq_log_f_at(const sqffd_superquadric *sq, const double u[3])
{
    double log_size[3];
    sqffd__sq_exponents x = sqffd__sq_exponents_of(sq);
    log_size[0] = log(sq->size[0]); log_size[1] = log(sq->size[1]); log_size[2] = log(sq->size[2]);
    return sqffd__sq_log_f(u, log_size, &x, NULL);
}

/* The checks every public superquadric function starts with. */
static sqffd_result sqffd__sq_check(const sqffd_superquadric *sq, const double *point, const void *out)
{
    if (!sq || !out) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (sqffd_sq_validate(sq) != SQFFD_OK) return SQFFD_ERROR_INVALID_MODEL;
    if (point && !sqffd__finite3(point)) return SQFFD_ERROR_NON_FINITE;
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_sq_inside_outside(const sqffd_superquadric *sq, const double point[3], double *value)
{
    double u[3];
    sqffd_result r = point ? sqffd__sq_check(sq, point, value) : SQFFD_ERROR_INVALID_ARGUMENT;
    if (r != SQFFD_OK) return r;
    sqffd__sq_untapered(sq, point, u);
    *value = exp(sqffd__sq_log_f_at(sq, u));
    return isnan(*value) ? SQFFD_ERROR_NON_FINITE : SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_sq_radial_distance(const sqffd_superquadric *sq, const double point[3], double *distance)
{
    double u[3], lf;
    sqffd_result r = point ? sqffd__sq_check(sq, point, distance) : SQFFD_ERROR_INVALID_ARGUMENT;
    if (r != SQFFD_OK) return r;
    sqffd__sq_untapered(sq, point, u);
    lf = sqffd__sq_log_f_at(sq, u);
    *distance = sqrt(sqffd__dot3(u, u)) * fabs(1.0 - exp(-0.5 * sq->shape[0] * lf));
    return isnan(*distance) ? SQFFD_ERROR_NON_FINITE : SQFFD_OK;
}

/* Untapered local surface point at (eta, omega). */
static void sqffd__sq_local_point(const sqffd_superquadric *sq, double eta, double omega, double s[3])
{
    double ce = sqffd__sq_spow(cos(eta), sq->shape[0]);
    s[0] = sq->size[0] * ce * sqffd__sq_spow(cos(omega), sq->shape[1]);
    s[1] = sq->size[1] * ce * sqffd__sq_spow(sin(omega), sq->shape[1]);
    s[2] = sq->size[2] * sqffd__sq_spow(sin(eta), sq->shape[0]);
}

/* Apply the tapering to an untapered local point (in place). */
static void sqffd__sq_taper(const sqffd_superquadric *sq, double s[3])
{
    double f[2];
    sqffd__sq_taper_factors(sq, s[2], f);
    s[0] *= f[0];
    s[1] *= f[1];
}

/* The world point of the untapered local point s: tapered, turned, moved. */
static void sqffd__sq_place(const sqffd_superquadric *sq, const double s[3], double point[3])
{
    double q[3];
    q[0] = s[0]; q[1] = s[1]; q[2] = s[2];
    sqffd__sq_taper(sq, q);
    sqffd__mat3_vec(sq->rotation, q, point);
    point[0] += sq->center[0]; point[1] += sq->center[1]; point[2] += sq->center[2];
}

/* sqffd_sq_point on a valid superquadric. */
static void sqffd__sq_point(const sqffd_superquadric *sq, double eta, double omega, double point[3], double normal[3])
{
    double s[3], q[3];
    sqffd__sq_local_point(sq, eta, omega, s);
    sqffd__sq_place(sq, s, point);
    if (normal) {
        /* Untapered normal: the direction of grad F, which on the surface is
           (C^(2-e1) C^(2-e2) / a1, C^(2-e1) S^(2-e2) / a2, S^(2-e1) / a3);
           the exponents are positive, so it is finite at the poles too.
           The tapering X = fx x, Y = fy y has the Jacobian
           J = [fx 0 Kx x/a3; 0 fy Ky y/a3; 0 0 1]; normals map by J^-T,
           here scaled by fx fy > 0 to avoid divisions. */
        double e1 = sq->shape[0], e2 = sq->shape[1], f[2], n[3], len;
        double ce = sqffd__sq_spow(cos(eta), 2.0 - e1);
        n[0] = ce * sqffd__sq_spow(cos(omega), 2.0 - e2) / sq->size[0];
        n[1] = ce * sqffd__sq_spow(sin(omega), 2.0 - e2) / sq->size[1];
        n[2] = sqffd__sq_spow(sin(eta), 2.0 - e1) / sq->size[2];
        sqffd__sq_taper_factors(sq, s[2], f);
        q[0] = n[0] * f[1];
        q[1] = n[1] * f[0];
        q[2] = n[2] * f[0] * f[1] - (sq->taper[0] * s[0] * n[0] * f[1] + sq->taper[1] * s[1] * n[1] * f[0]) / sq->size[2];
        sqffd__mat3_vec(sq->rotation, q, normal);
        len = sqrt(sqffd__dot3(normal, normal));
        if (len > 0.0) { normal[0] /= len; normal[1] /= len; normal[2] /= len; }
    }
}

SQFFD_DEF sqffd_result sqffd_sq_point(const sqffd_superquadric *sq, double eta, double omega, double point[3],
                                      double normal[3])
{
    sqffd_result r = sqffd__sq_check(sq, NULL, point);
    if (r != SQFFD_OK) return r;
    if (!isfinite(eta) || !isfinite(omega)) return SQFFD_ERROR_NON_FINITE;
    sqffd__sq_point(sq, eta, omega, point, normal);
    return sqffd__finite3(point) && (!normal || sqffd__finite3(normal)) ? SQFFD_OK : SQFFD_ERROR_NON_FINITE;
}

SQFFD_DEF sqffd_result sqffd_sq_sample_grid(const sqffd_superquadric *sq, int n_eta, int n_omega, double *points, double *normals)
{
    int i, j;
    sqffd_result r = sqffd__sq_check(sq, NULL, points);
    if (r != SQFFD_OK) return r;
    if (n_eta < 2 || n_omega < 1) return SQFFD_ERROR_INVALID_ARGUMENT;
    if ((size_t)n_eta > ((size_t)-1 / 3 / sizeof(double)) / (size_t)n_omega) return SQFFD_ERROR_TOO_LARGE;
    for (i = 0; i < n_eta; i++) {
        double eta = -0.5 * SQFFD__SQ_PI + SQFFD__SQ_PI * (double)i / (double)(n_eta - 1);
        for (j = 0; j < n_omega; j++) {
            double omega = -SQFFD__SQ_PI + 2.0 * SQFFD__SQ_PI * (double)j / (double)n_omega;
            size_t k = 3 * ((size_t)i * (size_t)n_omega + (size_t)j);
            sqffd__sq_point(sq, eta, omega, points + k, normals ? normals + k : NULL);
            if (!sqffd__finite3(points + k) || (normals && !sqffd__finite3(normals + k))) return SQFFD_ERROR_NON_FINITE;
        }
    }
    return SQFFD_OK;
}

/* ---- near-equal-distance sampling ----
   Pilu & Fisher step the parameter by spacing / |dP/dt|; near the points
   where the signed powers are singular (|dP/dt| infinite for e < 1) that
   formula needs special cases, so each step here instead searches for the
   parameter increment whose chord is `spacing`. Rows of constant eta are
   spaced by the largest chord over eight meridians, then each row is walked
   in omega, one quadrant at a time (a quadrant is a convex arc, so its chord
   grows monotonically). Tapered local coordinates: the rigid motion does not
   change lengths. */
#define SQFFD__SQ_MERIDIANS 8

/* An arc being walked: along omega at eta = fixed (one curve), or along eta
   (eight meridians at once); start holds the curve points at the current
   parameter. */
typedef struct sqffd__sq_arc {
    const sqffd_superquadric *sq;
    int along_omega;
    double fixed;
    double start[SQFFD__SQ_MERIDIANS][3];
    double end[SQFFD__SQ_MERIDIANS][3]; /* the curve points at t_end */
} sqffd__sq_arc;

static int sqffd__sq_arc_curves(const sqffd__sq_arc *arc)
{
    return arc->along_omega ? 1 : SQFFD__SQ_MERIDIANS;
}

static void sqffd__sq_arc_point(const sqffd__sq_arc *arc, int curve, double t, double p[3])
{
    if (arc->along_omega) sqffd__sq_local_point(arc->sq, arc->fixed, t, p);
    else sqffd__sq_local_point(arc->sq, t, -SQFFD__SQ_PI + 2.0 * SQFFD__SQ_PI * curve / SQFFD__SQ_MERIDIANS, p);
    sqffd__sq_taper(arc->sq, p);
}

/* Longest chord from the start points to parameter t (to the end points
   when to_end). */
static double sqffd__sq_arc_chord(const sqffd__sq_arc *arc, double t, int to_end)
{
    double best = 0.0, p[3];
    int k;
    for (k = 0; k < sqffd__sq_arc_curves(arc); k++) {
        double d;
        if (to_end) memcpy(p, arc->end[k], sizeof p);
        else sqffd__sq_arc_point(arc, k, t, p);
        d = sqffd__dist2_3(arc->start[k], p);
        if (d > best) best = d;
    }
    return sqrt(best);
}

/* Begin walking the arc towards t_end. */
static void sqffd__sq_arc_begin(sqffd__sq_arc *arc, double t_end)
{
    int k;
    for (k = 0; k < sqffd__sq_arc_curves(arc); k++) sqffd__sq_arc_point(arc, k, t_end, arc->end[k]);
}

/* Next parameter after t on the arc towards t_end (t < t_end): a chord of
   `spacing` within 10%; the last two steps share the remainder evenly;
   t_end when the remainder is at most one spacing. *guess carries the
   previous increment: a safeguarded secant search from it (near the
   singular points the increments span many orders of magnitude when e is
   small, so the bracket shrinks geometrically when the secant step fails). */
static double sqffd__sq_next(sqffd__sq_arc *arc, double t, double t_end, double spacing, double *guess)
{
    double rest, target = spacing, lo = 0.0, hi = t_end - t, d = *guess;
    int it, k;
    for (k = 0; k < sqffd__sq_arc_curves(arc); k++) sqffd__sq_arc_point(arc, k, t, arc->start[k]);
    rest = sqffd__sq_arc_chord(arc, t_end, 1);
    if (rest <= spacing) return t_end;
    if (rest < 2.0 * spacing) target = 0.5 * rest;
    if (!(d > 0.0 && d < hi)) d = 0.5 * hi;
    for (it = 0; it < 100; it++) { /* chord(lo) < target < chord(hi) */
        double c = sqffd__sq_arc_chord(arc, t + d, 0), next;
        if (fabs(c - target) <= 0.1 * target && t + d > t) break;
        if (c < target) lo = d; else hi = d;
        next = c > 0.0 ? d * target / c : 4.0 * d; /* secant through the origin */
        if (!(next > lo && next < hi)) next = lo > 0.0 ? sqrt(lo * hi) : 0.125 * hi;
        d = next;
    }
    if (it == 100) d = hi;
    *guess = d;
    return t + d > t ? t + d : t_end; /* no representable progress: finish the arc */
}

/* Emit the samples of one row (constant eta). Returns the new count. */
static size_t sqffd__sq_sample_row(const sqffd_superquadric *sq, double eta, double spacing, double *points,
                                   size_t capacity, size_t count)
{
    sqffd__sq_arc arc;
    double ring = 0.0, p[3];
    int quadrant;
    arc.sq = sq;
    arc.along_omega = 1;
    arc.fixed = eta;
    sqffd__sq_arc_point(&arc, 0, -SQFFD__SQ_PI, arc.start[0]);
    for (quadrant = 1; quadrant <= 4; quadrant++) { /* the ring's perimeter, roughly */
        sqffd__sq_arc_point(&arc, 0, -SQFFD__SQ_PI + 0.5 * SQFFD__SQ_PI * quadrant, p);
        ring += sqrt(sqffd__dist2_3(arc.start[0], p));
        memcpy(arc.start[0], p, sizeof p);
    }
    for (quadrant = 0; quadrant < 4; quadrant++) {
        double t = -SQFFD__SQ_PI + 0.5 * SQFFD__SQ_PI * quadrant, t_end = t + 0.5 * SQFFD__SQ_PI, guess = 0.0;
        sqffd__sq_arc_begin(&arc, t_end);
        while (t < t_end) {
            if (count < capacity) sqffd__sq_point(sq, eta, t, points + 3 * count, NULL);
            count++;
            if (ring < spacing) return count; /* a ring smaller than the spacing (a pole): one point */
            t = sqffd__sq_next(&arc, t, t_end, spacing, &guess);
        }
    }
    return count;
}

/* Upper bound of the samples sqffd_sq_sample_uniform makes: rows of
   constant eta at most (meridian length) / spacing, each with at most
   (ring perimeter) / spacing points; a convex arc is no longer than the
   two legs of its bounding rectangle. */
static double sqffd__sq_sample_bound(const sqffd_superquadric *sq, double spacing)
{
    double x = sq->size[0] * (1.0 + fabs(sq->taper[0])), y = sq->size[1] * (1.0 + fabs(sq->taper[1]));
    double r = x > y ? x : y, z = sq->size[2];
    return (2.0 * (2.0 * (r + z)) / spacing + 2.0) * (4.0 * (x + y) / spacing + 4.0);
}

SQFFD_DEF sqffd_result sqffd_sq_validate(const sqffd_superquadric *sq)
{
    double cross[3];
    int i, j;
    if (!sq) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (!sqffd__bounded3(sq->size) || !sqffd__bounded3(sq->center)) return SQFFD_ERROR_INVALID_MODEL;
    for (i = 0; i < 3; i++)
        if (!(sq->size[i] > 0.0)) return SQFFD_ERROR_INVALID_MODEL;
    for (i = 0; i < 2; i++)
        if (!(sq->shape[i] > 0.0) || !(sq->shape[i] <= 4.0) || !(fabs(sq->taper[i]) < 1.0))
            return SQFFD_ERROR_INVALID_MODEL;
    for (i = 0; i < 3; i++) /* columns orthonormal (NaN fails the comparison) */
        for (j = i; j < 3; j++) {
            const double *r = sq->rotation;
            double d = r[i] * r[j] + r[3 + i] * r[3 + j] + r[6 + i] * r[6 + j];
            if (!(fabs(d - (i == j ? 1.0 : 0.0)) <= 1e-6)) return SQFFD_ERROR_INVALID_MODEL;
        }
    sqffd__cross3(sq->rotation + 3, sq->rotation + 6, cross);
    return sqffd__dot3(sq->rotation, cross) > 0.0 ? SQFFD_OK : SQFFD_ERROR_INVALID_MODEL;
}

/* The samples of sqffd_sq_sample_uniform, the first `capacity` written; returns their count. */
static size_t sqffd__sq_sample_all(const sqffd_superquadric *sq, double spacing, double *points, size_t capacity)
{
    sqffd__sq_arc arc;
    size_t found = 0;
    int half;
    arc.sq = sq;
    arc.along_omega = 0;
    arc.fixed = 0.0;
    for (half = 0; half < 2; half++) { /* eta in [-pi/2, 0), then [0, pi/2) */
        double t = -0.5 * SQFFD__SQ_PI + 0.5 * SQFFD__SQ_PI * half, t_end = t + 0.5 * SQFFD__SQ_PI, guess = 0.0;
        sqffd__sq_arc_begin(&arc, t_end);
        while (t < t_end) {
            found = sqffd__sq_sample_row(sq, t, spacing, points, capacity, found);
            t = sqffd__sq_next(&arc, t, t_end, spacing, &guess);
        }
    }
    return sqffd__sq_sample_row(sq, 0.5 * SQFFD__SQ_PI, spacing, points, capacity, found);
}

SQFFD_DEF sqffd_result sqffd_sq_sample_uniform(const sqffd_superquadric *sq, double spacing, double *points,
                                               size_t capacity, size_t *count)
{
    size_t found;
    sqffd_result r = sqffd__sq_check(sq, NULL, count);
    if (r != SQFFD_OK) return r;
    if (!(spacing > 0.0) || !isfinite(spacing) || (capacity && !points)) return SQFFD_ERROR_INVALID_ARGUMENT;
    /* refuse samplings beyond ~1e8 points rather than run for minutes */
    if (sqffd__sq_sample_bound(sq, spacing) > 1e8) return SQFFD_ERROR_TOO_LARGE;
    found = sqffd__sq_sample_all(sq, spacing, NULL, 0); /* counted before anything is written */
    *count = found;
    if (capacity == 0) return SQFFD_OK;
    if (found > capacity) return SQFFD_ERROR_OUTPUT_TOO_SMALL;
    sqffd__sq_sample_all(sq, spacing, points, capacity);
    return SQFFD_OK;
}

/* ---- volume and IoU ----
   Cross-section of the untapered shape at height z = a3 t:
   area a1 a2 e2 B(e2/2, e2/2) (1 - |t|^(2/e1))^e1, and
   int_0^1 t^k (1 - t^(2/e1))^e1 dt = (e1/2) B((k+1) e1/2, e1 + 1).
   Tapering scales the section by (1 + Kx t)(1 + Ky t); the odd term
   vanishes by symmetry, so
   V = a1 a2 a3 e1 e2 B(e2/2, e2/2) [B(e1/2, e1+1) + Kx Ky B(3 e1/2, e1+1)]
   (B(e1/2, e1+1) = 2 B(e1/2+1, e1): the textbook form). */
static double sqffd__sq_beta(double x, double y)
{
    return tgamma(x) * tgamma(y) / tgamma(x + y);
}

SQFFD_DEF sqffd_result sqffd_sq_volume(const sqffd_superquadric *sq, double *volume)
{
    double e1, e2;
    sqffd_result r = sqffd__sq_check(sq, NULL, volume);
    if (r != SQFFD_OK) return r;
    e1 = sq->shape[0]; e2 = sq->shape[1];
    *volume = sq->size[0] * sq->size[1] * sq->size[2] * e1 * e2 * sqffd__sq_beta(0.5 * e2, 0.5 * e2) *
              (sqffd__sq_beta(0.5 * e1, e1 + 1.0) + sq->taper[0] * sq->taper[1] * sqffd__sq_beta(1.5 * e1, e1 + 1.0));
    return isfinite(*volume) ? SQFFD_OK : SQFFD_ERROR_NON_FINITE;
}

/* World axis-aligned box around the tapered shape. */
static void sqffd__sq_bounds(const sqffd_superquadric *sq, double lo[3], double hi[3])
{
    double ext[3];
    int i;
    ext[0] = sq->size[0] * (1.0 + fabs(sq->taper[0]));
    ext[1] = sq->size[1] * (1.0 + fabs(sq->taper[1]));
    ext[2] = sq->size[2];
    for (i = 0; i < 3; i++) {
        double h = fabs(sq->rotation[3 * i]) * ext[0] + fabs(sq->rotation[3 * i + 1]) * ext[1] +
                   fabs(sq->rotation[3 * i + 2]) * ext[2];
        lo[i] = sq->center[i] - h;
        hi[i] = sq->center[i] + h;
    }
}

/* Inside test at a world point, cheap rejection by the local box first. */
static int sqffd__sq_contains(const sqffd_superquadric *sq, const double p[3])
{
    double q[3], f[2], x, y, z, e1 = sq->shape[0], e2 = sq->shape[1];
    sqffd__sq_to_local(sq, p, q);
    z = fabs(q[2]) / sq->size[2];
    if (z > 1.0) return 0;
    sqffd__sq_taper_factors(sq, q[2], f);
    x = fabs(q[0]) / (f[0] * sq->size[0]);
    y = fabs(q[1]) / (f[1] * sq->size[1]);
    if (x > 1.0 || y > 1.0) return 0;
    return pow(pow(x, 2.0 / e2) + pow(y, 2.0 / e2), e2 / e1) + pow(z, 2.0 / e1) <= 1.0;
}

SQFFD_DEF sqffd_result sqffd_sq_iou(const sqffd_superquadric *a, const sqffd_superquadric *b, int resolution,
                                    double *iou)
{
    double lo[3], hi[3], lo_b[3], hi_b[3], step[3];
    size_t in_a = 0, in_b = 0, in_both = 0;
    int i, j, k;
    sqffd_result r = sqffd__sq_check(a, NULL, iou);
    if (r == SQFFD_OK) r = sqffd__sq_check(b, NULL, iou);
    if (r != SQFFD_OK) return r;
    if (resolution < 1 || resolution > 4096) return SQFFD_ERROR_INVALID_ARGUMENT;
    sqffd__sq_bounds(a, lo, hi);
    sqffd__sq_bounds(b, lo_b, hi_b);
    for (i = 0; i < 3; i++) {
        if (lo_b[i] < lo[i]) lo[i] = lo_b[i];
        if (hi_b[i] > hi[i]) hi[i] = hi_b[i];
        step[i] = (hi[i] - lo[i]) / (double)resolution;
    }
    for (i = 0; i < resolution; i++)
        for (j = 0; j < resolution; j++)
            for (k = 0; k < resolution; k++) {
                double p[3];
                int ia, ib;
                p[0] = lo[0] + ((double)i + 0.5) * step[0];
                p[1] = lo[1] + ((double)j + 0.5) * step[1];
                p[2] = lo[2] + ((double)k + 0.5) * step[2];
                ia = sqffd__sq_contains(a, p);
                ib = sqffd__sq_contains(b, p);
                in_a += (size_t)ia;
                in_b += (size_t)ib;
                in_both += (size_t)(ia & ib);
            }
    *iou = in_a + in_b == 0 ? 0.0 : (double)in_both / (double)(in_a + in_b - in_both);
    return SQFFD_OK;
}

/* ---- fit ------------------------------------------------------------------
   The data are centred on their centroid and scaled to unit RMS radius; the
   fit runs in those coordinates and is mapped back at the end.
   Parameters (SQFFD__SQ_P_*): a rotation increment w around the current
   rotation (R_new = R exp([w]x), derivatives at w = 0), the centre, the log
   sizes (sizes stay positive), e1, e2, Kx, Ky (last, so the 11-parameter
   model is the leading block). */
#define SQFFD__SQ_P_ROT 0
#define SQFFD__SQ_P_CENTER 3
#define SQFFD__SQ_P_LOGSIZE 6
#define SQFFD__SQ_P_E1 9
#define SQFFD__SQ_P_E2 10
#define SQFFD__SQ_P_TAPER 11
#define SQFFD__SQ_NPAR 13
/* Row stride of J^T W J: padded to 16 so that the per-point row update has a
   fixed length and vectorises (the padding columns stay 0). */
#define SQFFD__SQ_ROW 16
/* The starts and how much work each gets (measured on random tapered
   superquadrics: fewer or smaller cost accuracy, more cost time). */
#define SQFFD__SQ_SCREEN 48            /* subsample every start is screened on */
#define SQFFD__SQ_START_ITERATIONS 4   /* LM iterations per start on it */
#define SQFFD__SQ_KEEP 2               /* best starts ranked ... */
#define SQFFD__SQ_POLISH 384           /* ... on this subsample, where the winner then converges */
#define SQFFD__SQ_RANK_ITERATIONS 4    /* LM iterations per start that rank them (robust mode: none) */
#define SQFFD__SQ_FINAL 1536           /* the winner's last run (final_points): on at most this many points
                                          (an even subsample; more move the fit little and cost linear time) */
#define SQFFD__SQ_CLEAR_WIN 1e-2       /* a start this much costlier than the best is not ranked */
#define SQFFD__SQ_CLOSE_RATIO 0.7      /* eigenvalues or sizes this close count as ambiguous axes */
#define SQFFD__SQ_HISTOGRAM 512        /* bins per axis for the robust initial sizes */
#define SQFFD__SQ_SIZE_QUANTILE 0.95
#define SQFFD__SQ_BOX_MARGIN 1.25      /* the fit stays within the data's box enlarged this much */
#define SQFFD__SQ_MIN_STEP 1e-10       /* parameter steps below this (normalised units) end the LM */
#define SQFFD__SQ_EXACT 1e-24          /* mean squared residual counted as an exact fit */
#define SQFFD__SQ_TURNED_SEEDS 3        /* shape seeds tried on a turned basis */
#define SQFFD__SQ_CLOSE_FIT 0.05   /* RMS radial distance / mean size of a fit allowed past the data's box */
#define SQFFD__SQ_FLAT_RATIO 1e-10 /* covariance eigenvalue ratio below which data are flat */
#define SQFFD__SQ_MIN_SIZE 0.5     /* sizes >= this times the data's standard deviation along the axis (a
                                      superquadric's own is 0.45-0.6 of its size) */

/* Per-evaluation constants of the residual. */
typedef struct sqffd__sq_eval {
    const sqffd_superquadric *sq;
    sqffd__sq_exponents x;
    double log_size[3];
    double volume_scale;  /* sqrt(a1 a2 a3) */
    double taper_over_a3[2]; /* Kx / a3, Ky / a3 */
    double e1, inv_e1;
    int cost;
} sqffd__sq_eval;

static void sqffd__sq_eval_init(sqffd__sq_eval *ev, const sqffd_superquadric *sq, int cost)
{
    int k;
    ev->sq = sq;
    ev->x = sqffd__sq_exponents_of(sq);
    for (k = 0; k < 3; k++) ev->log_size[k] = log(sq->size[k]);
    ev->volume_scale = sqrt(sq->size[0] * sq->size[1] * sq->size[2]);
    ev->taper_over_a3[0] = sq->taper[0] / sq->size[2];
    ev->taper_over_a3[1] = sq->taper[1] / sq->size[2];
    ev->e1 = sq->shape[0];
    ev->inv_e1 = 1.0 / sq->shape[0];
    ev->cost = cost;
}

/* The first links of the residual's chain: world p -> tapered local
   q = R^T (p - c) -> untapered u = (q0 / fx, q1 / fy, q2) -> ln F(u)
   (returned); inv_f and clamped are the tapering's, for the derivatives. */
static double sqffd__sq_local_log_f(const sqffd__sq_eval *ev, const double p[3], double q[3], double u[3],
                                    double inv_f[2], int clamped[2], double *parts)
{
    int k;
    sqffd__sq_to_local(ev->sq, p, q);
    for (k = 0; k < 2; k++) {
        double f = 1.0 + ev->taper_over_a3[k] * q[2];
        clamped[k] = f < SQFFD__SQ_MIN_TAPER;
        if (clamped[k]) f = SQFFD__SQ_MIN_TAPER;
        inv_f[k] = 1.0 / f;
        u[k] = q[k] * inv_f[k];
    }
    u[2] = q[2];
    return sqffd__sq_log_f(u, ev->log_size, &ev->x, parts);
}

/* The last link: the residual of `cost` from u and ln F. *power receives the
   power of F it took: F^e1 for Solina's sqrt(a1 a2 a3) (F^e1 - 1), F^(-e1/2)
   for the radial |u| (1 - F^(-e1/2)). */
static double sqffd__sq_value(const sqffd__sq_eval *ev, int cost, const double u[3], double lf, double *power)
{
    if (cost == SQFFD_SQ_COST_SOLINA) {
        *power = exp(ev->e1 * lf < 700.0 ? ev->e1 * lf : 700.0);
        return ev->volume_scale * (*power - 1.0);
    }
    *power = exp(-0.5 * ev->e1 * lf);
    return sqrt(sqffd__dot3(u, u)) * (1.0 - *power);
}

/* Residual of one point, and (grad not NULL) its derivatives with respect to
   the 13 parameters, along the chain above. */
static double sqffd__sq_residual(const sqffd__sq_eval *ev, const double p[3], double *grad)
{
    const sqffd_superquadric *sq = ev->sq;
    double e1 = ev->e1;
    double q[3], inv_f[2], u[3], parts[SQFFD__SQ_PARTS], lf, r, pw, kf, extra_e1, extra_size, t[3], gq[3], h[3];
    int k, clamped[2];
    lf = sqffd__sq_local_log_f(ev, p, q, u, inv_f, clamped, grad ? parts : NULL);
    r = sqffd__sq_value(ev, ev->cost, u, lf, &pw);
    if (!grad) return r;
    if (ev->cost == SQFFD_SQ_COST_SOLINA) {
        kf = ev->volume_scale * pw * e1; /* d r / d ln F */
        extra_e1 = ev->volume_scale * pw * lf;
        extra_size = 0.5 * r; /* from d sqrt(a1 a2 a3) / d ln a_i */
        t[0] = t[1] = t[2] = 0.0;
    } else {
        double rho = sqrt(sqffd__dot3(u, u)), along = rho > 0.0 ? (1.0 - pw) / rho : 0.0;
        kf = 0.5 * rho * pw * e1;
        extra_e1 = 0.5 * rho * pw * lf;
        extra_size = 0.0;
        for (k = 0; k < 3; k++) t[k] = along * u[k];
    }
    /* h_k = d ln F / d ln|u_k| */
    h[0] = ev->x.two_e1 * parts[SQFFD__SQ_PART_FG] * parts[SQFFD__SQ_PART_FU];
    h[1] = ev->x.two_e1 * parts[SQFFD__SQ_PART_FG] * parts[SQFFD__SQ_PART_FU + 1];
    h[2] = ev->x.two_e1 * parts[SQFFD__SQ_PART_FG + 1];
    for (k = 0; k < 3; k++) /* t = d r / d u; h_k / u_k -> 0 as u_k -> 0 (exponents 2/e > 1) */
        t[k] += fabs(u[k]) > SQFFD__SQ_TINY ? kf * h[k] / u[k] : 0.0;
    /* through the tapering: dx/dX = 1/fx, dx/dZ = -x Kx / (a3 fx),
       dx/dKx = -x Z / (a3 fx), dx/d ln a3 = x Kx Z / (a3 fx) */
    gq[0] = t[0] * inv_f[0];
    gq[1] = t[1] * inv_f[1];
    gq[2] = t[2];
    grad[SQFFD__SQ_P_LOGSIZE] = grad[SQFFD__SQ_P_LOGSIZE + 1] = grad[SQFFD__SQ_P_LOGSIZE + 2] = 0.0;
    for (k = 0; k < 2; k++) {
        double s = clamped[k] ? 0.0 : t[k] * u[k] * inv_f[k]; /* times 1/a3 below */
        gq[2] -= s * ev->taper_over_a3[k];
        grad[SQFFD__SQ_P_TAPER + k] = -s * q[2] / sq->size[2];
        grad[SQFFD__SQ_P_LOGSIZE + 2] += s * ev->taper_over_a3[k] * q[2];
    }
    sqffd__cross3(gq, q, grad + SQFFD__SQ_P_ROT); /* dq/dw = [q]x */
    sqffd__mat3_vec(sq->rotation, gq, grad + SQFFD__SQ_P_CENTER);
    for (k = 0; k < 3; k++) {
        grad[SQFFD__SQ_P_CENTER + k] = -grad[SQFFD__SQ_P_CENTER + k];
        grad[SQFFD__SQ_P_LOGSIZE + k] += extra_size - kf * h[k];
    }
    grad[SQFFD__SQ_P_E1] = extra_e1 - kf * ev->inv_e1 * (parts[SQFFD__SQ_PART_FG] * parts[SQFFD__SQ_PART_LG] +
                                                         parts[SQFFD__SQ_PART_FG + 1] * parts[SQFFD__SQ_PART_LH]);
    grad[SQFFD__SQ_P_E2] = kf * ev->inv_e1 * parts[SQFFD__SQ_PART_FG] *
                           (parts[SQFFD__SQ_PART_LA] - parts[SQFFD__SQ_PART_FU] * parts[SQFFD__SQ_PART_LU] -
                            parts[SQFFD__SQ_PART_FU + 1] * parts[SQFFD__SQ_PART_LV]);
    return r;
}

/* ---- robust mode's mixture ----
   "Gaussian in the radial distance around the surface (its density spread
   over the area) + uniform over the data box". An E-step gives each point
   its inlier probability from the current sigma^2 and prior; the M-step
   then re-estimates both from those weights. */
typedef struct sqffd__sq_mixture {
    double sigma2;   /* variance of the inlier distances */
    double prior;    /* inlier fraction */
    double *weights; /* the points' inlier probabilities (the E-step's output) */
    double peak, outlier, sum_w, sum_wd2; /* one E-step's densities and sums */
} sqffd__sq_mixture;

/* Approximate surface area (Thomsen's ellipsoid formula): only the density
   of the inlier model needs it. */
static double sqffd__sq_area(const sqffd_superquadric *sq)
{
    const double p = 1.6075;
    double x = pow(sq->size[0], p), y = pow(sq->size[1], p), z = pow(sq->size[2], p);
    return 4.0 * SQFFD__SQ_PI * pow((x * y + y * z + z * x) / 3.0, 1.0 / p);
}

static void sqffd__sq_estep_begin(sqffd__sq_mixture *mix, const sqffd_superquadric *sq, double box_volume)
{
    if (mix->sigma2 < 1e-12) mix->sigma2 = 1e-12;
    mix->peak = mix->prior / (sqrt(2.0 * SQFFD__SQ_PI * mix->sigma2) * sqffd__sq_area(sq));
    mix->outlier = (1.0 - mix->prior) / box_volume;
    mix->sum_w = mix->sum_wd2 = 0.0;
}

/* The E-step for point k at radial distance d: its weight, also summed for the M-step. */
static double sqffd__sq_estep_point(sqffd__sq_mixture *mix, size_t k, double d)
{
    double d2 = d * d, inlier = mix->peak * exp(-0.5 * d2 / mix->sigma2);
    double w = inlier / (inlier + mix->outlier);
    mix->weights[k] = w;
    mix->sum_w += w;
    mix->sum_wd2 += w * d2;
    return w;
}

/* The M-step after an E-step over m points. */
static void sqffd__sq_mstep(sqffd__sq_mixture *mix, size_t m)
{
    mix->prior = mix->sum_w / (double)m;
    if (mix->prior < 0.05) mix->prior = 0.05;
    if (mix->prior > 0.999) mix->prior = 0.999;
    if (mix->sum_w > 0.0) mix->sigma2 = mix->sum_wd2 / mix->sum_w;
}

/* State shared by the stages of one fit. */
typedef struct sqffd__sq_fit {
    const sqffd_sq_fit_options *opt;
    int npar;             /* 13, or 11 without tapering */
    int cost;             /* residual in use (sqffd_sq_cost) */
    double box_volume;
    double box_mid[3];    /* normalised data box: centre and half-extents */
    double box_half[3];
    double size_min;
    double cov[9];        /* covariance of the start set: each size is at least SQFFD__SQ_MIN_SIZE times the
                             data's standard deviation along its axis */
    sqffd_superquadric best_start; /* the start that describes the screening points best (sqffd__sq_distance2) */
    double best_start_spread;
    int iterations;       /* optimiser iterations so far */
    void *ncg_work;       /* CG optimiser scratch */
    size_t ncg_size;
    double *lm;           /* LM scratch (SQFFD__SQ_LM_SCRATCH doubles): J^T W J twice and the solve's matrix */
    sqffd_result status;  /* SQFFD_ERROR_CANCELLED once the callback asked */
    sqffd__sq_mixture *estep; /* robust mode: the next sqffd__sq_accumulate starts with this E-step
                                 (cost must be the radial distance, the mixture's own residual) */
} sqffd__sq_fit;

#define SQFFD__SQ_LM_SCRATCH (2 * SQFFD__SQ_NPAR * SQFFD__SQ_ROW + SQFFD__SQ_NPAR * SQFFD__SQ_NPAR)

/* Weighted cost sum w r^2 over m points (weights NULL = 1); with jtr also
   J^T W r, and with jtj too the first npar rows of J^T W J (the Gauss-Newton
   normal equations; row stride SQFFD__SQ_ROW). With fit->estep set (robust
   mode) the weights come from an E-step at sq on the way, then the M-step:
   the optimiser's first evaluation does the E-step without a pass of its own. */
static double sqffd__sq_accumulate(sqffd__sq_fit *fit, const sqffd_superquadric *sq, const double *pts,
                                   const double *weights, size_t m, double *jtj, double *jtr)
{
    sqffd__sq_mixture *mix = fit->estep;
    sqffd__sq_eval ev;
    double cost = 0.0, g[SQFFD__SQ_ROW];
    int np = fit->npar, i, j;
    size_t k;
    sqffd__sq_eval_init(&ev, sq, fit->cost);
    memset(g, 0, sizeof g);
    if (jtj) memset(jtj, 0, sizeof(double) * SQFFD__SQ_NPAR * SQFFD__SQ_ROW);
    if (jtr) memset(jtr, 0, sizeof(double) * SQFFD__SQ_NPAR);
    fit->estep = NULL;
    if (mix) sqffd__sq_estep_begin(mix, sq, fit->box_volume);
    for (k = 0; k < m; k++) {
        double w = weights && !mix ? weights[k] : 1.0, r;
        if (w <= 0.0) continue;
        r = sqffd__sq_residual(&ev, pts + 3 * k, jtr ? g : NULL);
        if (mix) w = sqffd__sq_estep_point(mix, k, r);
        cost += w * r * r;
        if (!jtr) continue;
        for (i = 0; i < np; i++) {
            double wg = w * g[i];
            jtr[i] += wg * r;
            if (jtj)
                for (j = 0; j < SQFFD__SQ_ROW; j++) jtj[i * SQFFD__SQ_ROW + j] += wg * g[j];
        }
    }
    if (mix) sqffd__sq_mstep(mix, m);
    return cost;
}

/* R <- R exp([w]x) (Rodrigues). */
static void sqffd__sq_rotate(double rot[9], const double w[3])
{
    double th2 = sqffd__dot3(w, w), th = sqrt(th2), s, c, e[9], out[9];
    int i, j;
    if (th < 1e-8) { s = 1.0 - th2 / 6.0; c = 0.5 - th2 / 24.0; }
    else { s = sin(th) / th; c = (1.0 - cos(th)) / th2; }
    /* exp = I + s [w]x + c [w]x^2, [w]x^2 = w w^T - |w|^2 I */
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) e[3 * i + j] = c * w[i] * w[j] + (i == j ? 1.0 - c * th2 : 0.0);
    e[1] -= s * w[2]; e[2] += s * w[1];
    e[3] += s * w[2]; e[5] -= s * w[0];
    e[6] -= s * w[1]; e[7] += s * w[0];
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++)
            out[3 * i + j] = rot[3 * i] * e[j] + rot[3 * i + 1] * e[3 + j] + rot[3 * i + 2] * e[6 + j];
    memcpy(rot, out, sizeof out);
}

/* The feasible set: e and K within their bounds, the centre in the data's
   box, each size at most SQFFD__SQ_BOX_MARGIN times the box's half-extent
   along that local axis (this stops the runaway of the F-based cost on data
   that are no superquadric; sqffd__sq_contain finishes the job) and at least
   SQFFD__SQ_MIN_SIZE times the data's standard deviation along it (a
   collapse: the F-based costs can prefer a tiny, fully tapered shape on
   thin, branched data). Returns
   the value parameter i moves (a log size moves a size; NULL for the free
   rotation increment) and writes its bounds at sq's rotation. */
static double *sqffd__sq_bounded(const sqffd__sq_fit *fit, sqffd_superquadric *sq, int i, double *lo, double *hi)
{
    const sqffd_sq_fit_options *o = fit->opt;
    int k;
    if (i >= SQFFD__SQ_P_TAPER) {
        *lo = -o->taper_max;
        *hi = o->taper_max;
        return &sq->taper[i - SQFFD__SQ_P_TAPER];
    }
    if (i >= SQFFD__SQ_P_E1) {
        *lo = o->shape_min;
        *hi = o->shape_max;
        return &sq->shape[i - SQFFD__SQ_P_E1];
    }
    if (i >= SQFFD__SQ_P_LOGSIZE) {
        double reach;
        k = i - SQFFD__SQ_P_LOGSIZE;
        reach = SQFFD__SQ_BOX_MARGIN * (fabs(sq->rotation[k]) * fit->box_half[0] +
                                        fabs(sq->rotation[3 + k]) * fit->box_half[1] +
                                        fabs(sq->rotation[6 + k]) * fit->box_half[2]);
        {
            const double r[3] = {sq->rotation[k], sq->rotation[3 + k], sq->rotation[6 + k]};
            double cr[3], spread;
            sqffd__mat3_vec(fit->cov, r, cr);
            spread = SQFFD__SQ_MIN_SIZE * sqrt(sqffd__dot3(r, cr));
            *lo = spread > fit->size_min ? spread : fit->size_min;
        }
        *hi = reach > *lo ? reach : *lo;
        return &sq->size[k];
    }
    if (i >= SQFFD__SQ_P_CENTER) {
        k = i - SQFFD__SQ_P_CENTER;
        *lo = fit->box_mid[k] - fit->box_half[k];
        *hi = fit->box_mid[k] + fit->box_half[k];
        return &sq->center[k];
    }
    return NULL;
}

/* Clamp into the feasible set. */
static void sqffd__sq_project(const sqffd__sq_fit *fit, sqffd_superquadric *sq)
{
    int i;
    if (fit->npar < SQFFD__SQ_NPAR) sq->taper[0] = sq->taper[1] = 0.0;
    for (i = SQFFD__SQ_P_CENTER; i < SQFFD__SQ_NPAR; i++) {
        double lo, hi, *v = sqffd__sq_bounded(fit, sq, i, &lo, &hi);
        if (*v < lo) *v = lo;
        if (*v > hi) *v = hi;
    }
}

/* ||(x, y)||_q for x, y >= 0, scaled so that a large q cannot overflow. */
static double sqffd__sq_qnorm(double x, double y, double q)
{
    double m = x > y ? x : y;
    if (m <= 0.0) return 0.0;
    return m * pow(pow(x / m, q) + pow(y / m, q), 1.0 / q);
}

/* How far the shape reaches from its centre along +dir (a world unit
   vector). Each cross-section at height z = a3 S^e1 (S = sin eta, signed
   power) is a superellipse with half-axes fx a1 C^e1, fy a2 C^e1, whose
   support is the dual norm with q = 2/(2 - e2) (e2 > 2 shapes lie inside
   the e2 = 2 ones); the reach is the largest over SQFFD__SQ_REACH_ROWS
   heights. */
#define SQFFD__SQ_REACH_ROWS 256
static double sqffd__sq_reach(const sqffd_superquadric *sq, const double dir[3])
{
    double v[3], best = -HUGE_VAL, q = 2.0 / (2.0 - (sq->shape[1] < 1.99 ? sq->shape[1] : 1.99));
    int i;
    sqffd__mat3t_vec(sq->rotation, dir, v);
    for (i = 0; i <= SQFFD__SQ_REACH_ROWS; i++) {
        double eta = -0.5 * SQFFD__SQ_PI + SQFFD__SQ_PI * i / SQFFD__SQ_REACH_ROWS, f[2], h;
        double c = sqffd__sq_spow(cos(eta), sq->shape[0]), z = sq->size[2] * sqffd__sq_spow(sin(eta), sq->shape[0]);
        sqffd__sq_taper_factors(sq, z, f);
        h = c * sqffd__sq_qnorm(f[0] * sq->size[0] * fabs(v[0]), f[1] * sq->size[1] * fabs(v[1]), q) + v[2] * z;
        if (h > best) best = h;
    }
    return best;
}

/* The last guard against a runaway: when the fitted shape reaches out of
   the data's box enlarged by SQFFD__SQ_BOX_MARGIN, shrink it about its
   centre (all sizes by one factor: the shape scales, K is scale-free) until
   it fits. The per-size bounds of the projection leave a rotated or
   off-centre shape room to stick out; this closes it. Returns non-zero
   when it shrank the shape. */
static int sqffd__sq_contain(const sqffd__sq_fit *fit, sqffd_superquadric *sq)
{
    double shrink = 1.0;
    int k, side;
    for (k = 0; k < 3; k++)
        for (side = -1; side <= 1; side += 2) {
            double dir[3] = {0.0, 0.0, 0.0}, reach, room;
            dir[k] = (double)side;
            reach = 1.001 * sqffd__sq_reach(sq, dir); /* the rows sample the reach from below */
            room = SQFFD__SQ_BOX_MARGIN * fit->box_half[k] - side * (sq->center[k] - fit->box_mid[k]);
            if (reach > 0.0 && reach * shrink > room) shrink = room / reach;
        }
    for (k = 0; k < 3; k++) sq->size[k] *= shrink;
    return shrink < 1.0;
}

/* sq <- project(sq + delta) */
static void sqffd__sq_step(const sqffd__sq_fit *fit, sqffd_superquadric *sq, const double *delta)
{
    int k;
    sqffd__sq_rotate(sq->rotation, delta + SQFFD__SQ_P_ROT);
    for (k = 0; k < 3; k++) {
        sq->center[k] += delta[SQFFD__SQ_P_CENTER + k];
        sq->size[k] *= exp(delta[SQFFD__SQ_P_LOGSIZE + k]);
    }
    sq->shape[0] += delta[SQFFD__SQ_P_E1];
    sq->shape[1] += delta[SQFFD__SQ_P_E2];
    if (fit->npar == SQFFD__SQ_NPAR) {
        sq->taper[0] += delta[SQFFD__SQ_P_TAPER];
        sq->taper[1] += delta[SQFFD__SQ_P_TAPER + 1];
    }
    sqffd__sq_project(fit, sq);
}

/* One optimiser iteration done: count it, report it, honour a cancel. */
static int sqffd__sq_tick(sqffd__sq_fit *fit, double cost)
{
    fit->iterations++;
    if (fit->opt->progress &&
        fit->opt->progress(fit->opt->progress_user, SQFFD_STAGE_SUPERQUADRIC, fit->iterations, cost)) {
        fit->status = SQFFD_ERROR_CANCELLED;
        return 0;
    }
    return 1;
}

/* Entry (i, j) of J^T J, stored as its upper triangle. */
static double sqffd__sq_jtj_at(const double *jtj, int i, int j)
{
    return i <= j ? jtj[i * SQFFD__SQ_ROW + j] : jtj[j * SQFFD__SQ_ROW + i];
}

/* The damped Gauss-Newton step (J^T J + lambda D) delta = -J^T r, D =
   diag(J^T J), with the bounds as an active set: a parameter the step would
   carry past a bound is fixed at it and the others are solved for again,
   until none crosses. (Cutting the step afterwards, in the projection,
   leaves the others' step counting on a move that does not happen: on data
   that are no superquadric, where a size sits at its bound, the LM then
   crawls.) Writes the reduction of the cost the linear model predicts;
   returns 0 when the matrix is not positive definite. */
static int sqffd__sq_solve(const sqffd__sq_fit *fit, sqffd_superquadric *sq, const double *jtj, const double *jtr,
                           double lambda, double ridge, double *delta, double *predicted)
{
    double *a = fit->lm + 2 * SQFFD__SQ_NPAR * SQFFD__SQ_ROW, lo, hi, *v, jd;
    int np = fit->npar, fixed[SQFFD__SQ_NPAR], i, j, again = 1;
    for (i = 0; i < SQFFD__SQ_NPAR; i++) {
        fixed[i] = 0;
        delta[i] = 0.0;
    }
    while (again) {
        for (i = 0; i < np; i++) { /* fixed rows and columns: identity, delta[i] their move */
            double rhs = -jtr[i];
            for (j = 0; j < np; j++) {
                double jij = sqffd__sq_jtj_at(jtj, i, j);
                if (fixed[j] && !fixed[i]) rhs -= jij * delta[j];
                a[i * np + j] = fixed[i] || fixed[j] ? (double)(i == j) : jij;
            }
            if (!fixed[i]) {
                a[i * np + i] += lambda * jtj[i * SQFFD__SQ_ROW + i] + ridge;
                delta[i] = rhs;
            }
        }
        if (sqffd_cholesky_factor(a, (size_t)np) != SQFFD_OK) return 0;
        sqffd_cholesky_solve(a, (size_t)np, delta);
        again = 0;
        for (i = 0; i < np; i++) {
            int log_size = i >= SQFFD__SQ_P_LOGSIZE && i < SQFFD__SQ_P_E1;
            double to, bound;
            v = sqffd__sq_bounded(fit, sq, i, &lo, &hi);
            if (fixed[i] || !v) continue;
            to = log_size ? *v * exp(delta[i]) : *v + delta[i];
            if (to >= lo && to <= hi) continue;
            bound = to < lo ? lo : hi;
            delta[i] = log_size ? log(bound / *v) : bound - *v;
            fixed[i] = again = 1;
        }
    }
    /* the model's reduction of sum r^2: -2 delta^T J^T r - delta^T J^T J delta */
    *predicted = 0.0;
    for (i = 0; i < np; i++) {
        jd = 0.0;
        for (j = 0; j < np; j++) jd += sqffd__sq_jtj_at(jtj, i, j) * delta[j];
        *predicted -= delta[i] * (2.0 * jtr[i] + jd);
    }
    return 1;
}

/* Levenberg-Marquardt (Marquardt's diagonal scaling) with bounds (the
   active set of sqffd__sq_solve, then the projection) and Nielsen's
   damping: lambda follows the gain ratio rho = actual / predicted reduction
   (lambda *= max(1/3, 1 - (2 rho - 1)^3) after a success; lambda *= nu,
   nu *= 2 after a failure) instead of fixed factors that zig-zag. Returns
   non-zero when converged; *cost gets the final cost. */
static int sqffd__sq_lm(sqffd__sq_fit *fit, sqffd_superquadric *sq, const double *pts, const double *weights,
                        size_t m, int max_iterations, double *cost)
{
    double *jtj = fit->lm, *tjtj = fit->lm + SQFFD__SQ_NPAR * SQFFD__SQ_ROW, jtr[SQFFD__SQ_NPAR], tjtr[SQFFD__SQ_NPAR];
    double delta[SQFFD__SQ_NPAR], lambda = 1e-3, nu = 2.0, step, predicted;
    int np = fit->npar, it, i;
    double c0 = sqffd__sq_accumulate(fit, sq, pts, weights, m, jtj, jtr);
    if (c0 < SQFFD__SQ_EXACT * (double)m) { *cost = c0; return 1; }
    for (it = 0; it < max_iterations; it++) {
        sqffd_superquadric trial = *sq;
        int last = it + 1 == max_iterations; /* no use for the trial's Jacobian */
        double c1;
        if (!sqffd__sq_solve(fit, sq, jtj, jtr, lambda, 1e-12 * (1.0 + c0), delta, &predicted)) {
            lambda *= nu;
            nu *= 2.0;
            if (!sqffd__sq_tick(fit, c0)) break;
            continue;
        }
        step = 0.0;
        for (i = 0; i < np; i++) step = fabs(delta[i]) > step ? fabs(delta[i]) : step;
        /* the model itself promises less than the tolerance: converged, no trial */
        if (predicted < fit->opt->tolerance * c0) { *cost = c0; return 1; }
        sqffd__sq_step(fit, &trial, delta);
        c1 = sqffd__sq_accumulate(fit, &trial, pts, weights, m, last ? NULL : tjtj, last ? NULL : tjtr);
        if (!sqffd__sq_tick(fit, c1 < c0 ? c1 : c0)) break;
        if (c1 < c0) {
            double gain = (c0 - c1) / c0, rho = predicted > 0.0 ? (c0 - c1) / predicted : 1.0, t = 2.0 * rho - 1.0;
            *sq = trial;
            if (!last) {
                memcpy(jtj, tjtj, SQFFD__SQ_NPAR * SQFFD__SQ_ROW * sizeof(double));
                memcpy(jtr, tjtr, sizeof jtr);
            }
            c0 = c1;
            t = 1.0 - t * t * t;
            lambda *= t > 1.0 / 3.0 ? t : 1.0 / 3.0;
            if (lambda < 1e-9) lambda = 1e-9;
            nu = 2.0;
            if (gain < fit->opt->tolerance || step < SQFFD__SQ_MIN_STEP || c0 < SQFFD__SQ_EXACT * (double)m) {
                *cost = c0;
                return 1;
            }
        } else {
            lambda *= nu;
            nu *= 2.0;
            /* no descent even along a tiny step: a (constrained) minimum */
            if (lambda > 1e6 || step < SQFFD__SQ_MIN_STEP) { *cost = c0; return 1; }
        }
    }
    *cost = c0;
    return 0;
}

/* ---- the paper's optimiser, nonlinear conjugate gradients ----
   Parameters x = (w, centre, log sizes, e1, e2, Kx, Ky) with R = R0 exp([w]x).
   The gradient is 2 J^T r from the same analytic Jacobian as the LM; its
   rotation part (taken at the current R) maps to w through the transposed
   right Jacobian of the exponential map,
   J_r(w)^T g = g + a w x g + b w x (w x g), a = (1 - cos t)/t^2, b = (t - sin t)/t^3. */
typedef struct sqffd__sq_cg {
    sqffd__sq_fit *fit;
    const sqffd_superquadric *base; /* R0 */
    const double *pts, *weights;
    size_t m;
} sqffd__sq_cg;

static void sqffd__sq_cg_model(const sqffd__sq_cg *cg, const double *x, sqffd_superquadric *sq)
{
    int k;
    *sq = *cg->base;
    sqffd__sq_rotate(sq->rotation, x + SQFFD__SQ_P_ROT);
    for (k = 0; k < 3; k++) {
        sq->center[k] = x[SQFFD__SQ_P_CENTER + k];
        sq->size[k] = exp(x[SQFFD__SQ_P_LOGSIZE + k]);
    }
    sq->shape[0] = x[SQFFD__SQ_P_E1];
    sq->shape[1] = x[SQFFD__SQ_P_E2];
    if (cg->fit->npar == SQFFD__SQ_NPAR) {
        sq->taper[0] = x[SQFFD__SQ_P_TAPER];
        sq->taper[1] = x[SQFFD__SQ_P_TAPER + 1];
    }
}

/* The non-rotation parameters of sq into x (x[0..2] untouched). */
static void sqffd__sq_cg_params(const sqffd__sq_fit *fit, const sqffd_superquadric *sq, double *x)
{
    int k;
    for (k = 0; k < 3; k++) {
        x[SQFFD__SQ_P_CENTER + k] = sq->center[k];
        x[SQFFD__SQ_P_LOGSIZE + k] = log(sq->size[k]);
    }
    x[SQFFD__SQ_P_E1] = sq->shape[0];
    x[SQFFD__SQ_P_E2] = sq->shape[1];
    if (fit->npar == SQFFD__SQ_NPAR) {
        x[SQFFD__SQ_P_TAPER] = sq->taper[0];
        x[SQFFD__SQ_P_TAPER + 1] = sq->taper[1];
    }
}

static double sqffd__sq_cg_objective(void *user, const double *x, double *gradient)
{
    const sqffd__sq_cg *cg = (const sqffd__sq_cg *)user;
    sqffd_superquadric sq;
    double jtr[SQFFD__SQ_NPAR], g[3], wg[3], wwg[3], cost, t2, a, b;
    int k;
    sqffd__sq_cg_model(cg, x, &sq);
    cost = sqffd__sq_accumulate(cg->fit, &sq, cg->pts, cg->weights, cg->m, NULL, jtr);
    for (k = 0; k < cg->fit->npar; k++) gradient[k] = 2.0 * jtr[k];
    t2 = sqffd__dot3(x, x);
    if (t2 < 1e-8) { a = 0.5 - t2 / 24.0; b = 1.0 / 6.0 - t2 / 120.0; }
    else {
        double t = sqrt(t2);
        a = (1.0 - cos(t)) / t2;
        b = (t - sin(t)) / (t2 * t);
    }
    memcpy(g, gradient + SQFFD__SQ_P_ROT, sizeof g);
    sqffd__cross3(x, g, wg);
    sqffd__cross3(x, wg, wwg);
    for (k = 0; k < 3; k++) gradient[SQFFD__SQ_P_ROT + k] = g[k] + a * wg[k] + b * wwg[k];
    return cost;
}

static void sqffd__sq_cg_project(void *user, double *x)
{
    const sqffd__sq_cg *cg = (const sqffd__sq_cg *)user;
    sqffd_superquadric sq;
    sqffd__sq_cg_model(cg, x, &sq);
    sqffd__sq_project(cg->fit, &sq);
    sqffd__sq_cg_params(cg->fit, &sq, x);
}

static int sqffd__sq_cg_progress(void *user, int stage, int iteration, double error)
{
    (void)stage;
    (void)iteration;
    return !sqffd__sq_tick((sqffd__sq_fit *)user, error);
}

static int sqffd__sq_cg_minimize(sqffd__sq_fit *fit, sqffd_superquadric *sq, const double *pts, const double *weights,
                                 size_t m, int max_iterations, double *cost)
{
    sqffd__sq_cg cg;
    sqffd_superquadric base = *sq;
    double x[SQFFD__SQ_NPAR], gradient[SQFFD__SQ_NPAR], f0;
    sqffd_ncg_options o = sqffd_ncg_options_default();
    sqffd_result r;
    cg.fit = fit;
    cg.base = &base;
    cg.pts = pts;
    cg.weights = weights;
    cg.m = m;
    x[0] = x[1] = x[2] = 0.0;
    sqffd__sq_cg_params(fit, sq, x);
    *cost = f0 = sqffd__sq_cg_objective(&cg, x, gradient); /* (the cost where the minimiser returns early) */
    o.max_iterations = max_iterations;
    o.tolerance = fit->opt->tolerance * (f0 > 1.0 ? f0 : 1.0);
    o.project = sqffd__sq_cg_project;
    o.progress = sqffd__sq_cg_progress;
    o.progress_user = fit;
    r = sqffd_ncg_minimize((size_t)fit->npar, sqffd__sq_cg_objective, &cg, x, &o, NULL, cost, fit->ncg_work,
                           fit->ncg_size);
    sqffd__sq_cg_model(&cg, x, sq);
    if (r == SQFFD_ERROR_CANCELLED) fit->status = SQFFD_ERROR_CANCELLED;
    return r == SQFFD_OK;
}

/* The configured optimiser; the CG needs more, cheaper iterations. */
#define SQFFD__SQ_CG_FACTOR 4
static int sqffd__sq_optimize(sqffd__sq_fit *fit, sqffd_superquadric *sq, const double *pts, const double *weights,
                              size_t m, int max_iterations, double *cost)
{
    if (fit->opt->optimizer == SQFFD_SQ_OPTIMIZER_CG)
        return sqffd__sq_cg_minimize(fit, sq, pts, weights, m, SQFFD__SQ_CG_FACTOR * max_iterations, cost);
    return sqffd__sq_lm(fit, sq, pts, weights, m, max_iterations, cost);
}

/* Workspace blocks of one fit. */
/* Keep the SQFFD__SQ_KEEP cheapest starts, sorted by cost. */
typedef struct sqffd__sq_shortlist {
    sqffd_superquadric sq[SQFFD__SQ_KEEP];
    double cost[SQFFD__SQ_KEEP];
    int id[SQFFD__SQ_KEEP];
    int count;
} sqffd__sq_shortlist;

typedef struct sqffd__sq_work {
    double *points;  /* 3n normalised points */
    double *weights; /* n robust weights (robust mode only) */
    double *screen;  /* 3 * min(n, SQFFD__SQ_SCREEN) subsample */
    double *polish;  /* 3 * min(n, SQFFD__SQ_POLISH) subsample */
    double *final;   /* 3 * final_points subsample when n is larger (else all points are the final set) */
    double *dense;   /* robust mode: the polish points that are not isolated */
    void *tree;      /* robust mode: kd-tree over the polish points */
    size_t tree_size;
    double *hist;    /* 3 * SQFFD__SQ_HISTOGRAM */
    void *ncg;       /* CG optimiser scratch */
    size_t ncg_size;
    double *lm;      /* SQFFD__SQ_LM_SCRATCH */
    sqffd__sq_shortlist *list; /* the starts kept (not on the stack) */
} sqffd__sq_work;

/* The points of the winner's last run (plain mode), 0 for none: at most
   final_points (0: all), and more than the polish subsample. */
static size_t sqffd__sq_final_count(size_t n, const sqffd_sq_fit_options *o)
{
    size_t m = o->final_points && o->final_points < n ? o->final_points : n;
    return !o->robust && m > SQFFD__SQ_POLISH ? m : 0;
}

static void sqffd__sq_fit_layout(sqffd__arena *a, size_t n, const sqffd_sq_fit_options *o, sqffd__sq_work *w)
{
    size_t m_final = sqffd__sq_final_count(n, o);
    w->points = (double *)sqffd__arena_take(a, n, 3 * sizeof(double));
    /* robust weights; also the 2 * min(n, SQFFD__SQ_POLISH) scratch of the density filter */
    w->weights = o->robust ? (double *)sqffd__arena_take(a, n > 2 * SQFFD__SQ_POLISH ? n : 2 * SQFFD__SQ_POLISH, sizeof(double)) : NULL;
    w->screen = (double *)sqffd__arena_take(a, n < SQFFD__SQ_SCREEN ? n : SQFFD__SQ_SCREEN, 3 * sizeof(double));
    w->polish = (double *)sqffd__arena_take(a, n < SQFFD__SQ_POLISH ? n : SQFFD__SQ_POLISH, 3 * sizeof(double));
    w->final = m_final && m_final < n ? (double *)sqffd__arena_take(a, m_final, 3 * sizeof(double)) : NULL;
    w->dense = o->robust ? (double *)sqffd__arena_take(a, n < SQFFD__SQ_POLISH ? n : SQFFD__SQ_POLISH, 3 * sizeof(double)) : NULL;
    w->tree_size = 0;
    if (o->robust && sqffd_kdtree_workspace_size(n < SQFFD__SQ_POLISH ? n : SQFFD__SQ_POLISH, &w->tree_size) != SQFFD_OK)
        sqffd__arena_too_large(a);
    w->tree = w->tree_size ? sqffd__arena_take(a, w->tree_size, 1) : NULL;
    w->hist = (double *)sqffd__arena_take(a, 3 * SQFFD__SQ_HISTOGRAM, sizeof(double));
    w->ncg_size = 0;
    if (o->optimizer == SQFFD_SQ_OPTIMIZER_CG && sqffd_ncg_workspace_size(SQFFD__SQ_NPAR, &w->ncg_size) != SQFFD_OK)
        sqffd__arena_too_large(a);
    w->ncg = w->ncg_size ? sqffd__arena_take(a, w->ncg_size, 1) : NULL;
    w->lm = (double *)sqffd__arena_take(a, SQFFD__SQ_LM_SCRATCH, sizeof(double));
    w->list = (sqffd__sq_shortlist *)sqffd__arena_take(a, 1, sizeof(sqffd__sq_shortlist));
}

SQFFD_DEF sqffd_sq_fit_options sqffd_sq_fit_options_default(void)
{
    sqffd_sq_fit_options o;
    memset(&o, 0, sizeof o);
    o.cost = SQFFD_SQ_COST_SOLINA;
    o.optimizer = SQFFD_SQ_OPTIMIZER_LM;
    o.taper = 1;
    o.shape_min = 0.1;
    o.shape_max = 1.9;
    o.taper_max = 0.95;
    o.max_iterations = 100;
    o.tolerance = 1e-5;
    o.final_points = SQFFD__SQ_FINAL;
    o.robust = 0;
    o.robust_rounds = 4;
    o.progress = NULL;
    o.progress_user = NULL;
    return o;
}

static int sqffd__sq_options_valid(const sqffd_sq_fit_options *o)
{
    return (o->cost == SQFFD_SQ_COST_SOLINA || o->cost == SQFFD_SQ_COST_RADIAL) &&
           (o->optimizer == SQFFD_SQ_OPTIMIZER_LM || o->optimizer == SQFFD_SQ_OPTIMIZER_CG) &&
           o->shape_min >= 0.01 && o->shape_min <= o->shape_max && o->shape_max <= 4.0 &&
           o->taper_max >= 0.0 && o->taper_max < 1.0 && o->max_iterations >= 1 &&
           o->tolerance >= 0.0 && isfinite(o->tolerance) && (!o->robust || o->robust_rounds >= 1);
}

SQFFD_DEF sqffd_result sqffd_sq_fit_workspace_size(size_t n, const sqffd_sq_fit_options *options, size_t *size)
{
    sqffd_sq_fit_options defaults = sqffd_sq_fit_options_default();
    const sqffd_sq_fit_options *o = options ? options : &defaults;
    sqffd__arena a;
    sqffd__sq_work w;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    if (n == 0 || !sqffd__sq_options_valid(o)) return SQFFD_ERROR_INVALID_ARGUMENT;
    sqffd__arena_measure(&a);
    sqffd__sq_fit_layout(&a, n, o, &w);
    return sqffd__arena_size(&a, size);
}

/* An EM step (E, then M) at sq over m points in a pass of its own. */
static void sqffd__sq_reweight(sqffd__sq_mixture *mix, const sqffd_superquadric *sq, const double *pts, size_t m,
                               double box_volume)
{
    sqffd__sq_eval ev;
    size_t k;
    sqffd__sq_eval_init(&ev, sq, SQFFD_SQ_COST_RADIAL);
    sqffd__sq_estep_begin(mix, sq, box_volume);
    for (k = 0; k < m; k++) sqffd__sq_estep_point(mix, k, sqffd__sq_residual(&ev, pts + 3 * k, NULL));
    sqffd__sq_mstep(mix, m);
}

/* The closing statistics over m points: the weighted (weights NULL = 1)
   mean of the squared radial distance (returned), and the weighted sum of
   squared residuals of the fit's cost into *cost; one ln F per point serves
   both. */
static double sqffd__sq_closing_stats(const sqffd__sq_fit *fit, const sqffd_superquadric *sq, const double *pts,
                                const double *weights, size_t m, double *cost)
{
    double sum = 0.0, sum_w = 0.0, q[3], u[3], inv_f[2], power;
    sqffd__sq_eval ev;
    size_t k;
    int clamped[2];
    sqffd__sq_eval_init(&ev, sq, fit->cost);
    *cost = 0.0;
    for (k = 0; k < m; k++) {
        double w = weights ? weights[k] : 1.0, lf = sqffd__sq_local_log_f(&ev, pts + 3 * k, q, u, inv_f, clamped, NULL);
        double d = sqffd__sq_value(&ev, SQFFD_SQ_COST_RADIAL, u, lf, &power);
        double r = fit->cost == SQFFD_SQ_COST_RADIAL ? d : sqffd__sq_value(&ev, fit->cost, u, lf, &power);
        sum += w * d * d;
        sum_w += w;
        *cost += w * r * r;
    }
    return sum_w > 0.0 ? sum / sum_w : 0.0;
}

/* Normalise in place: centroid, then scale to unit RMS radius (dividing by
   the largest offset first so that squares cannot overflow). Returns 0 when
   all points coincide. */
static int sqffd__sq_normalize(double *points, size_t n, double centroid[3], double *scale)
{
    double *out = points;
    double big = 0.0, sum2 = 0.0;
    size_t i;
    int k;
    for (k = 0; k < 3; k++) {
        double s = 0.0;
        for (i = 0; i < n; i++) s += points[3 * i + (size_t)k];
        centroid[k] = s / (double)n;
    }
    for (i = 0; i < 3 * n; i++) {
        double d = fabs(points[i] - centroid[i % 3]);
        if (d > big) big = d;
    }
    if (!(big > 0.0) || !isfinite(big)) return 0;
    for (i = 0; i < 3 * n; i++) {
        out[i] = (points[i] - centroid[i % 3]) / big;
        sum2 += out[i] * out[i];
    }
    *scale = big * sqrt(sum2 / (double)n);
    for (i = 0; i < 3 * n; i++) out[i] *= big / *scale;
    return 1;
}

/* Robust initial half-sizes along the columns of axes, about centre: the
   SQFFD__SQ_SIZE_QUANTILE quantile of |projection| (a fixed histogram, no
   sort), divided by the quantile (exact for a sphere sampled evenly). */
static void sqffd__sq_initial_sizes(const double *pts, size_t n, const double centre[3], const double axes[9],
                                    double *hist, double size[3])
{
    double top[3] = {0.0, 0.0, 0.0}, proj[3], d[3];
    size_t i;
    int k, b;
    memset(hist, 0, sizeof(double) * 3 * SQFFD__SQ_HISTOGRAM);
    for (i = 0; i < n; i++) {
        sqffd__sub3(pts + 3 * i, centre, d);
        sqffd__mat3t_vec(axes, d, proj);
        for (k = 0; k < 3; k++)
            if (fabs(proj[k]) > top[k]) top[k] = fabs(proj[k]);
    }
    for (i = 0; i < n; i++) {
        sqffd__sub3(pts + 3 * i, centre, d);
        sqffd__mat3t_vec(axes, d, proj);
        for (k = 0; k < 3; k++) {
            b = top[k] > 0.0 ? (int)(fabs(proj[k]) / top[k] * SQFFD__SQ_HISTOGRAM) : 0;
            hist[k * SQFFD__SQ_HISTOGRAM + (b < SQFFD__SQ_HISTOGRAM ? b : SQFFD__SQ_HISTOGRAM - 1)] += 1.0;
        }
    }
    for (k = 0; k < 3; k++) {
        double need = SQFFD__SQ_SIZE_QUANTILE * (double)n, seen = 0.0;
        for (b = 0; b < SQFFD__SQ_HISTOGRAM - 1; b++) {
            seen += hist[k * SQFFD__SQ_HISTOGRAM + b];
            if (seen >= need) break;
        }
        size[k] = top[k] * ((double)b + 1.0) / SQFFD__SQ_HISTOGRAM / SQFFD__SQ_SIZE_QUANTILE;
        if (size[k] > top[k]) size[k] = top[k];
    }
}

/* Centroid and covariance (row-major 3x3) of m points. */
static void sqffd__sq_moments(const double *pts, size_t m, double centre[3], double cov[9])
{
    size_t i;
    int k;
    memset(cov, 0, 9 * sizeof(double));
    centre[0] = centre[1] = centre[2] = 0.0;
    for (i = 0; i < m; i++)
        for (k = 0; k < 3; k++) centre[k] += pts[3 * i + (size_t)k] / (double)m;
    for (i = 0; i < m; i++) {
        double d[3];
        sqffd__sub3(pts + 3 * i, centre, d);
        for (k = 0; k < 9; k++) cov[k] += d[k / 3] * d[k % 3] / (double)m;
    }
}

/* The data checks of sqffd_sq_fit (and so of every fit): at least
   SQFFD_SQ_FIT_MIN_POINTS points, finite, neither all coincident nor
   collinear or coplanar (the covariance's smallest eigenvalue at most
   SQFFD__SQ_FLAT_RATIO of its largest; the offsets from the centroid
   divided by the largest first, so that no square overflows). */
static sqffd_result sqffd__sq_check_data(const sqffd_points *points)
{
    double p[3], centroid[3] = {0.0, 0.0, 0.0}, big = 0.0, cov[9], values[3], axes[9];
    size_t i, n = points->count;
    int k;
    if (n < SQFFD_SQ_FIT_MIN_POINTS) return SQFFD_ERROR_TOO_FEW_POINTS;
    for (i = 0; i < n; i++) {
        sqffd__points_get(points, i, p);
        if (!sqffd__finite3(p)) return SQFFD_ERROR_NON_FINITE;
        for (k = 0; k < 3; k++) centroid[k] += p[k] / (double)n;
    }
    for (i = 0; i < n; i++) {
        sqffd__points_get(points, i, p);
        for (k = 0; k < 3; k++) big = fabs(p[k] - centroid[k]) > big ? fabs(p[k] - centroid[k]) : big;
    }
    if (!(big > 0.0) || !isfinite(big)) return SQFFD_ERROR_DEGENERATE;
    memset(cov, 0, sizeof cov);
    for (i = 0; i < n; i++) {
        double d[3];
        sqffd__points_get(points, i, p);
        for (k = 0; k < 3; k++) d[k] = (p[k] - centroid[k]) / big;
        for (k = 0; k < 9; k++) cov[k] += d[k / 3] * d[k % 3] / (double)n;
    }
    sqffd_sym3_eigen(cov, values, axes);
    return values[0] > SQFFD__SQ_FLAT_RATIO * values[2] ? SQFFD_OK : SQFFD_ERROR_DEGENERATE;
}

static void sqffd__sq_swap(double *a, size_t i, size_t j)
{
    double t = a[i];
    a[i] = a[j];
    a[j] = t;
}

/* The k-th smallest of a[0..n-1] (quickselect, median-of-three pivot,
   Lomuto partition; reorders a). */
static double sqffd__sq_select(double *a, size_t n, size_t k)
{
    size_t lo = 0, hi = n - 1;
    while (hi > lo) {
        size_t mid = lo + (hi - lo) / 2, store = lo, i;
        if (a[mid] < a[lo]) sqffd__sq_swap(a, lo, mid);
        if (a[hi] < a[lo]) sqffd__sq_swap(a, lo, hi);
        if (a[mid] < a[hi]) sqffd__sq_swap(a, mid, hi); /* a[hi]: the median of the three */
        for (i = lo; i < hi; i++)
            if (a[i] < a[hi]) sqffd__sq_swap(a, i, store++);
        sqffd__sq_swap(a, store, hi);
        if (k == store) break;
        if (k < store) hi = store - 1;
        else lo = store + 1;
    }
    return a[k];
}

/* Robust mode's start set: of every other point, those whose
   SQFFD__SQ_NEIGHBOURS-th nearest neighbour among all m (a kd-tree over
   them) is at most 1.2 times the median such distance. Outliers away from
   the surface are isolated and drop out; so do some surface points, which
   the starts can spare. dist: m doubles of scratch. Returns the count
   written to out (0 if the tree cannot be built). */
#define SQFFD__SQ_NEIGHBOURS 6
static size_t sqffd__sq_dense_points(const double *pts, size_t m, double *out, double *dist, void *tree_work,
                                     size_t tree_size)
{
    sqffd_kdtree tree;
    size_t i, kept = 0, half = (m + 1) / 2, index[SQFFD__SQ_NEIGHBOURS + 1];
    double d2[SQFFD__SQ_NEIGHBOURS + 1], limit;
    if (sqffd_kdtree_build(&tree, pts, m, tree_work, tree_size) != SQFFD_OK) return 0;
    for (i = 0; i < half; i++) { /* the point itself is the first of the k + 1 nearest */
        size_t found = sqffd__kd_query(&tree, pts + 6 * i, HUGE_VAL, 0, index, d2,
                                       m < SQFFD__SQ_NEIGHBOURS + 1 ? m : SQFFD__SQ_NEIGHBOURS + 1);
        dist[i] = dist[half + i] = found ? d2[found - 1] : 0.0; /* (found >= 1: the tree holds the point) */
    }
    limit = 1.44 * sqffd__sq_select(dist + half, half, half / 2); /* squared: 1.2 times the median distance */
    for (i = 0; i < half; i++)
        if (dist[i] <= limit) memcpy(out + 3 * kept++, pts + 6 * i, 3 * sizeof(double));
    return kept;
}

/* Robust variance of the radial distances of m points: (1.4826 median |d|)^2.
   scratch: m doubles. */
static double sqffd__sq_robust_d2(const sqffd_superquadric *sq, const double *pts, size_t m, double *scratch)
{
    double mad;
    size_t k;
    sqffd__sq_eval ev;
    sqffd__sq_eval_init(&ev, sq, SQFFD_SQ_COST_RADIAL);
    for (k = 0; k < m; k++) scratch[k] = fabs(sqffd__sq_residual(&ev, pts + 3 * k, NULL));
    mad = 1.4826 * sqffd__sq_select(scratch, m, m / 2);
    return mad * mad;
}

#define SQFFD__SQ_ROBUST_COST SQFFD_SQ_COST_RADIAL /* the mixture's own residual */
/* Optimiser iterations per EM round but the last (the CG's get multiplied by
   SQFFD__SQ_CG_FACTOR too): one LM step lets the weights follow; the CG's
   steps do less (measured on random tapered superquadrics). */
#define SQFFD__SQ_ROUND_ITERATIONS(o) ((o)->optimizer == SQFFD_SQ_OPTIMIZER_CG ? 3 : 1)
#define SQFFD__SQ_FULL_ROUNDS 1      /* EM rounds on all points after the polish subsample */
/* Field by field: the core may not call memcmp. */
static int sqffd__sq_equal(const sqffd_superquadric *a, const sqffd_superquadric *b)
{
    int k;
    for (k = 0; k < 9; k++)
        if (a->rotation[k] != b->rotation[k]) return 0;
    for (k = 0; k < 3; k++)
        if (a->size[k] != b->size[k] || a->center[k] != b->center[k]) return 0;
    for (k = 0; k < 2; k++)
        if (a->shape[k] != b->shape[k] || a->taper[k] != b->taper[k]) return 0;
    return 1;
}

/* Robust mode: `rounds` EM rounds on m points, each an E-step and M-step
   (fused into the optimiser's first evaluation), then a few weighted LM
   iterations of the mixture's own residual, the radial distance; the last
   round runs the LM to convergence. Returns non-zero when that moved sq
   (else the last E-step's weights are those at the result). */
static int sqffd__sq_em(sqffd__sq_fit *fit, sqffd_superquadric *sq, const double *pts, size_t m,
                        sqffd__sq_mixture *mix, int rounds, int *converged)
{
    sqffd_superquadric at_estep = *sq;
    double cost;
    int r;
    fit->cost = SQFFD__SQ_ROBUST_COST;
    for (r = 0; r < rounds && fit->status == SQFFD_OK; r++) {
        at_estep = *sq;
        fit->estep = mix;
        *converged = sqffd__sq_optimize(fit, sq, pts, mix->weights, m,
                                        r + 1 < rounds ? SQFFD__SQ_ROUND_ITERATIONS(fit->opt) : fit->opt->max_iterations, &cost);
    }
    fit->cost = (int)fit->opt->cost;
    return !sqffd__sq_equal(&at_estep, sq);
}


static void sqffd__sq_shortlist_add(sqffd__sq_shortlist *list, const sqffd_superquadric *sq, double cost, int id)
{
    int slot;
    for (slot = list->count; slot > 0 && cost < list->cost[slot - 1]; slot--)
        if (slot < SQFFD__SQ_KEEP) {
            list->sq[slot] = list->sq[slot - 1];
            list->cost[slot] = list->cost[slot - 1];
            list->id[slot] = list->id[slot - 1];
        }
    if (slot >= SQFFD__SQ_KEEP) return;
    list->sq[slot] = *sq;
    list->cost[slot] = cost;
    list->id[slot] = id;
    if (list->count < SQFFD__SQ_KEEP) list->count++;
}

/* How well sq describes m points, close to their Euclidean distances: each
   radial distance d divided by the length of its gradient in the point (a
   first-order distance to the surface: the ray from the centre meets a thin
   shape's long side at a slant, where d overstates it), squared and
   averaged. It picks the best start (report->best_start), which sqffd_fit
   keeps where the fit ends farther from the data: a guard against a
   collapse or a runaway the bounds did not stop. */
static double sqffd__sq_distance2(const sqffd_superquadric *sq, const double *pts, size_t m)
{
    double g[SQFFD__SQ_ROW], sum = 0.0;
    sqffd__sq_eval ev;
    size_t k;
    sqffd__sq_eval_init(&ev, sq, SQFFD_SQ_COST_RADIAL);
    for (k = 0; k < m; k++) {
        double r = sqffd__sq_residual(&ev, pts + 3 * k, g), slope = sqffd__dot3(g + SQFFD__SQ_P_CENTER, g + SQFFD__SQ_P_CENTER);
        double d2 = slope > 1.0 ? r * r / slope : r * r; /* (a gradient below 1 only where the first order fails) */
        sum += d2;
    }
    return sum / (double)m;
}

/* Starts: each principal axis of the start set pts (its centre and
   covariance eigenvalues and axes given) as the local z, times the shape
   seeds; when two eigenvalues are close their axes are arbitrary within
   their plane, so that basis is also tried turned by 45 degrees in it.
   Each start gets a few LM iterations on the screening subsample. */
static void sqffd__sq_screen(sqffd__sq_fit *fit, const double *pts, size_t m, const double centre[3],
                             const double values[3], const double axes[9], const double *screen, size_t m_screen,
                             double *hist, sqffd__sq_shortlist *list)
{
    /* (e1, e2) seeds: round, then the pairs a start cannot get to from there */
    static const double shape_seeds[][2] = {{1.0, 1.0}, {1.7, 0.3}, {0.3, 1.7}, {1.7, 1.7}};
    const int n_seeds = (int)(sizeof shape_seeds / sizeof shape_seeds[0]);
    int basis, s, id = 0;
    list->count = 0;
    for (basis = 0; basis < 3 && fit->status == SQFFD_OK; basis++) {
        double b_axes[9], b_size[3];
        memcpy(b_axes, axes, sizeof b_axes);
        if (basis > 0) { /* basis 1: eigenvalues 0 and 1 close, turn about axis 2; basis 2: 1 and 2, about 0 */
            double ratio = basis == 1 ? values[0] / values[1] : values[1] / values[2], turn[3] = {0.0, 0.0, 0.0};
            if (!(ratio >= SQFFD__SQ_CLOSE_RATIO)) continue;
            turn[basis == 1 ? 2 : 0] = 0.25 * SQFFD__SQ_PI;
            sqffd__sq_rotate(b_axes, turn);
        }
        sqffd__sq_initial_sizes(pts, m, centre, b_axes, hist, b_size);
        for (s = 0; s < 3 * (basis ? SQFFD__SQ_TURNED_SEEDS : n_seeds) && fit->status == SQFFD_OK; s++, id++) {
            sqffd_superquadric cur;
            double cost, spread;
            int j;
            memset(&cur, 0, sizeof cur);
            for (j = 0; j < 3; j++) { /* cyclic column permutation: still a rotation */
                int col = (j + s) % 3;
                cur.rotation[j] = b_axes[col];
                cur.rotation[3 + j] = b_axes[3 + col];
                cur.rotation[6 + j] = b_axes[6 + col];
                cur.size[j] = b_size[col];
                cur.center[j] = centre[j];
            }
            cur.shape[0] = shape_seeds[s / 3][0];
            cur.shape[1] = shape_seeds[s / 3][1];
            sqffd__sq_project(fit, &cur);
            spread = sqffd__sq_distance2(&cur, screen, m_screen);
            if (spread < fit->best_start_spread) {
                fit->best_start_spread = spread;
                fit->best_start = cur;
            }
            sqffd__sq_optimize(fit, &cur, screen, NULL, m_screen, SQFFD__SQ_START_ITERATIONS, &cost);
            sqffd__sq_shortlist_add(list, &cur, cost, id);
            if (cost < SQFFD__SQ_EXACT * (double)m_screen) return; /* exact: no start can do better */
        }
    }
}

/* The twin of a fit whose a1 and a2 are close: turned 45 degrees about its
   z, with e2 -> 2 - e2 (a square cross-section and a diamond are the same
   shape turned, and the LM cannot get from one to the other). Sizes scale
   by 2^((1 - e2)/2): sqrt 2 from square to diamond, 1 for a circle.
   Returns 0 when a1 and a2 differ too much for a twin. */
static int sqffd__sq_twin(const sqffd__sq_fit *fit, const sqffd_superquadric *sq, sqffd_superquadric *twin)
{
    double lo = sq->size[0] < sq->size[1] ? sq->size[0] : sq->size[1];
    double hi = sq->size[0] < sq->size[1] ? sq->size[1] : sq->size[0];
    double turn[3] = {0.0, 0.0, 0.25 * SQFFD__SQ_PI};
    if (lo < SQFFD__SQ_CLOSE_RATIO * hi) return 0;
    *twin = *sq;
    sqffd__sq_rotate(twin->rotation, turn);
    twin->size[0] = twin->size[1] = 0.5 * (lo + hi) * pow(2.0, 0.5 * (1.0 - sq->shape[1]));
    twin->shape[1] = 2.0 - sq->shape[1];
    twin->taper[0] = twin->taper[1] = 0.5 * (sq->taper[0] + sq->taper[1]);
    sqffd__sq_project(fit, twin);
    return 1;
}

/* Point sets of one fit. */
typedef struct sqffd__sq_sets {
    const double *polish;  /* an even subsample of all points */
    size_t m_polish;
    const double *start;   /* the points the starts came from (robust mode: the dense polish points) */
    size_t m_start;
} sqffd__sq_sets;

/* Rank a candidate by its cost after a few LM iterations on the polish
   points (only the winner is run to convergence). Robust mode ranks it by
   its cost on the start set (the polish points without the isolated ones):
   the EM rounds that follow do the fitting. Returns that cost. */
static double sqffd__sq_rank(sqffd__sq_fit *fit, sqffd_superquadric *sq, const sqffd__sq_sets *sets)
{
    const sqffd_sq_fit_options *o = fit->opt;
    double cost = HUGE_VAL;
    if (o->robust) return sqffd__sq_accumulate(fit, sq, sets->start, NULL, sets->m_start, NULL, NULL);
    sqffd__sq_optimize(fit, sq, sets->polish, NULL, sets->m_polish,
                       o->max_iterations < SQFFD__SQ_RANK_ITERATIONS ? o->max_iterations : SQFFD__SQ_RANK_ITERATIONS, &cost);
    return cost;
}

SQFFD_DEF sqffd_result sqffd_sq_fit_view(sqffd_points points, const sqffd_sq_fit_options *options,
                                         sqffd_superquadric *sq, sqffd_sq_fit_report *report, void *workspace,
                                         size_t workspace_size)
{
    size_t n = points.count;
    sqffd_sq_fit_options defaults = sqffd_sq_fit_options_default();
    const sqffd_sq_fit_options *o = options ? options : &defaults;
    size_t m_polish = n < SQFFD__SQ_POLISH ? n : SQFFD__SQ_POLISH, m_final = sqffd__sq_final_count(n, o);
    size_t m_start, m_screen, i;
    sqffd__sq_shortlist *list;
    sqffd__sq_sets sets;
    sqffd__arena arena;
    sqffd__sq_work w;
    sqffd__sq_fit fit;
    sqffd_superquadric best, twin;
    sqffd__sq_mixture mix; /* robust mode's mixture */
    double centroid[3], scale, centre[3], cov[9], values[3], axes[9], best_cost = 0.0;
    const double *start_pts, *final_pts, *weights;
    sqffd_points all, starts;
    double rms, mean_d2 = 0.0, final_cost = 0.0;
    int k, best_start = 0, converged = 0;
    sqffd_result r = sqffd__points_check(&points);
    if (r == SQFFD_OK && (!sq || !sqffd__sq_options_valid(o))) r = SQFFD_ERROR_INVALID_ARGUMENT;
    if (r == SQFFD_OK) r = sqffd__sq_check_data(&points);
    if (r != SQFFD_OK) return r;
    sqffd__arena_init(&arena, workspace, workspace_size);
    sqffd__sq_fit_layout(&arena, n, o, &w);
    if (arena.overflow) return sqffd__arena_error(&arena);
    list = w.list;
    for (i = 0; i < n; i++) sqffd__points_get(&points, i, w.points + 3 * i); /* as doubles, normalised below */
    if (!sqffd__sq_normalize(w.points, n, centroid, &scale)) return SQFFD_ERROR_DEGENERATE;
    sqffd__sq_moments(w.points, n, centre, cov);
    sqffd_sym3_eigen(cov, values, axes);

    memset(&fit, 0, sizeof fit);
    fit.opt = o;
    fit.npar = o->taper ? SQFFD__SQ_NPAR : SQFFD__SQ_P_TAPER;
    fit.cost = (int)o->cost;
    fit.status = SQFFD_OK;
    fit.size_min = 1e-3;
    fit.ncg_work = w.ncg;
    fit.ncg_size = w.ncg_size;
    fit.lm = w.lm;
    for (k = 0; k < 3; k++) {
        double lo = w.points[k], hi = w.points[k];
        for (i = 1; i < n; i++) {
            double v = w.points[3 * i + (size_t)k];
            if (v < lo) lo = v;
            if (v > hi) hi = v;
        }
        fit.box_mid[k] = 0.5 * (lo + hi);
        fit.box_half[k] = 0.5 * (hi - lo);
    }
    fit.box_volume = 8.0 * fit.box_half[0] * fit.box_half[1] * fit.box_half[2];
    fit.best_start_spread = HUGE_VAL;

    /* The starts come from all points, or in robust mode from the polish
       subsample without its isolated points. Every start is screened on a
       small subsample, the best few are ranked on a larger one (polish),
       and the winner runs to convergence there, then on the final set (all
       points, or an even subsample of final_points; none where that is no
       more than the polish subsample). */
    all = sqffd_points_packed(w.points, n);
    sqffd__subsample(&all, m_polish, w.polish);
    final_pts = w.points;
    if (w.final) { /* (laid out where the last run takes a subsample) */
        sqffd__subsample(&all, m_final, w.final);
        final_pts = w.final;
    }
    start_pts = w.points;
    m_start = n;
    if (o->robust) {
        m_start = sqffd__sq_dense_points(w.polish, m_polish, w.dense, w.weights, w.tree, w.tree_size);
        start_pts = w.dense;
        if (m_start < SQFFD_SQ_FIT_MIN_POINTS) { start_pts = w.polish; m_start = m_polish; }
        sqffd__sq_moments(start_pts, m_start, centre, cov); /* else those of all points, above */
        sqffd_sym3_eigen(cov, values, axes);
    }
    memcpy(fit.cov, cov, sizeof cov);
    m_screen = m_start < SQFFD__SQ_SCREEN ? m_start : SQFFD__SQ_SCREEN;
    starts = sqffd_points_packed(start_pts, m_start);
    sqffd__subsample(&starts, m_screen, w.screen);
    sqffd__sq_screen(&fit, start_pts, m_start, centre, values, axes, w.screen, m_screen, w.hist, list);

    sets.polish = w.polish;
    sets.m_polish = m_polish;
    sets.start = start_pts;
    sets.m_start = m_start;
    if (list->count == 0) return SQFFD_ERROR_DEGENERATE; /* (no start screened: the screen adds the first always) */
    best = list->sq[0];
    for (k = 0; k < list->count && fit.status == SQFFD_OK; k++) {
        double cost;
        if (k > 0 && (list->cost[0] < SQFFD__SQ_CLEAR_WIN * list->cost[k] || best_cost < SQFFD__SQ_EXACT * (double)m_polish))
            break; /* the rest are far behind, or the best is exact */
        cost = sqffd__sq_rank(&fit, &list->sq[k], &sets);
        if (k == 0 || cost < best_cost) {
            best = list->sq[k];
            best_cost = cost;
            best_start = list->id[k];
        }
    }
    if (fit.status == SQFFD_OK && sqffd__sq_twin(&fit, &best, &twin)) {
        double cost = sqffd__sq_rank(&fit, &twin, &sets);
        if (cost < best_cost) {
            best = twin;
            best_cost = cost;
        }
    }
    if (o->robust && fit.status == SQFFD_OK) {
        /* EM from the fit's robust spread on the start set: on the polish
           subsample, then on all points */
        int moved;
        mix.sigma2 = sqffd__sq_robust_d2(&best, start_pts, m_start, w.weights);
        mix.prior = (double)m_start / (double)m_polish;
        mix.weights = w.weights;
        moved = sqffd__sq_em(&fit, &best, w.polish, m_polish, &mix, o->robust_rounds, &converged);
        if (m_polish < n) moved = sqffd__sq_em(&fit, &best, w.points, n, &mix, SQFFD__SQ_FULL_ROUNDS, &converged);
        if (moved) sqffd__sq_reweight(&mix, &best, w.points, n, fit.box_volume); /* the weights at the result */
    } else if (fit.status == SQFFD_OK) {
        /* the winner to convergence on the polish points, then on the final set */
        converged = sqffd__sq_optimize(&fit, &best, w.polish, NULL, m_polish, o->max_iterations, &best_cost);
        if (m_final && fit.status == SQFFD_OK)
            converged = sqffd__sq_optimize(&fit, &best, final_pts, NULL, m_final, o->max_iterations, &best_cost);
    }
    if (fit.status != SQFFD_OK) return fit.status;

    /* A fit that describes the data closely may reach past their box (a
       partial view: the data show part of the shape); any other is kept
       within the box enlarged by the margin. */
    weights = o->robust ? w.weights : NULL;
    /* robust mode: the last EM step's sigma^2 is this weighted mean already */
    if (!o->robust || report) mean_d2 = sqffd__sq_closing_stats(&fit, &best, w.points, weights, n, &final_cost);
    rms = sqrt(o->robust ? mix.sigma2 : mean_d2);
    if (rms > SQFFD__SQ_CLOSE_FIT * (best.size[0] + best.size[1] + best.size[2]) / 3.0 && sqffd__sq_contain(&fit, &best))
        rms = sqrt(sqffd__sq_closing_stats(&fit, &best, w.points, weights, n, &final_cost));
    if (report) {
        double sum_w = 0.0;
        for (i = 0; i < n; i++) sum_w += weights ? weights[i] : 1.0;
        report->iterations = fit.iterations;
        report->cost = final_cost * (o->cost == SQFFD_SQ_COST_SOLINA ? scale * scale * scale : scale * scale);
        report->rms_radial = scale * rms;
        report->start = best_start;
        report->converged = converged;
        report->inlier_fraction = sum_w / (double)n;
        report->fallback = 0;
        report->best_start = fit.best_start;
        for (k = 0; k < 3; k++) {
            report->best_start.size[k] *= scale;
            report->best_start.center[k] = centroid[k] + scale * fit.best_start.center[k];
        }
    }
    *sq = best;
    for (k = 0; k < 3; k++) {
        sq->size[k] *= scale;
        sq->center[k] = centroid[k] + scale * best.center[k];
    }
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_sq_fit(const double *points, size_t n, const sqffd_sq_fit_options *options,
                                    sqffd_superquadric *sq, sqffd_sq_fit_report *report,
                                    void *workspace, size_t workspace_size)
{
    return sqffd_sq_fit_view(sqffd_points_packed(points, n), options, sq, report, workspace, workspace_size);
}

/* ======================================================================
   Layer 4: free-form deformation (Bernstein lattice)
   ====================================================================== */

/* The degree+1 Bernstein polynomials B_i^degree(s), i = 0..degree, by the
   de Casteljau recurrence (each step splits every value into (1-s) and s
   parts): the weights sum to 1 up to rounding for any s, and at s = 0 or 1
   they are exactly one unit vector. */
static void sqffd__ffd_bernstein(int degree, double s, double *b)
{
    int d, i;
    double r = 1.0 - s;
    b[0] = 1.0;
    for (d = 1; d <= degree; ++d) {
        b[d] = s * b[d - 1];
        for (i = d - 1; i > 0; --i) b[i] = r * b[i] + s * b[i - 1];
        b[0] *= r;
    }
}

/* The three 1-D weight vectors of (s, t, u): w[0..l), w[l..l+m), w[l+m..l+m+n).
   B's row at (s, t, u) is their tensor product; the model fit stores these
   l+m+n numbers per point instead of the l*m*n products. */
static void sqffd__ffd_axis_weights(const int dims[3], const double stu[3], double *w)
{
    sqffd__ffd_bernstein(dims[0] - 1, stu[0], w);
    sqffd__ffd_bernstein(dims[1] - 1, stu[1], w + dims[0]);
    sqffd__ffd_bernstein(dims[2] - 1, stu[2], w + dims[0] + dims[1]);
}

/* q_ij = sum_k wu_k P_ijk for every (i, j) (l*m entries): the first of the
   sums in sum_ijk ws_i wt_j wu_k P_ijk. The model fit shares it between the
   points with the same u. Sums over points are kept in four lanes, the
   fourth zero: the compiler does x, y, z (and the idle lane) as one vector. */
static void sqffd__ffd_sum_u(const int dims[3], const double (*control)[3], const double *wu, double (*q)[4])
{
    int ij, k;
    for (ij = 0; ij < dims[0] * dims[1]; ++ij) {
        const double (*p)[3] = control + (size_t)ij * (size_t)dims[2];
        double x = 0.0, y = 0.0, z = 0.0;
        for (k = 0; k < dims[2]; ++k) {
            x += wu[k] * p[k][0];
            y += wu[k] * p[k][1];
            z += wu[k] * p[k][2];
        }
        q[ij][0] = x; q[ij][1] = y; q[ij][2] = z; q[ij][3] = 0.0;
    }
}

/* sum_ij ws_i wt_j q_ij: the rest of the sums. */
static void sqffd__ffd_sum_st(const int dims[3], const double (*q)[4], const double *ws, const double *wt, double out[3])
{
    double sum[4] = {0.0, 0.0, 0.0, 0.0};
    int i, j, c;
    for (i = 0; i < dims[0]; ++i) {
        const double (*qi)[4] = q + i * dims[1];
        double row[4] = {0.0, 0.0, 0.0, 0.0};
        for (j = 0; j < dims[1]; ++j)
            for (c = 0; c < 4; ++c) row[c] += wt[j] * qi[j][c];
        for (c = 0; c < 4; ++c) sum[c] += ws[i] * row[c];
    }
    out[0] = sum[0]; out[1] = sum[1]; out[2] = sum[2];
}

static int sqffd__ffd_dims_valid(const int dims[3])
{
    int a;
    for (a = 0; a < 3; ++a)
        if (dims[a] < 2 || dims[a] > SQFFD_MAX_LATTICE) return 0;
    return 1;
}

/* The box's inverse, 0 for a flat box (|S . (T x U)| <= 1e-12 |S| |T| |U|). */
static int sqffd__ffd_box_inverse(const double edges[9], double inverse[9])
{
    double det, scale;
    int a;
    /* Sederberg & Parry's local coordinates: s = (T x U).(X - X0) / (T x U).S
       and cyclically, so the rows of the inverse are T x U, U x S, S x T over
       the determinant S.(T x U). */
    sqffd__cross3(edges + 3, edges + 6, inverse);
    sqffd__cross3(edges + 6, edges, inverse + 3);
    sqffd__cross3(edges, edges + 3, inverse + 6);
    det = sqffd__dot3(edges, inverse);
    scale = sqrt(sqffd__dot3(edges, edges) * sqffd__dot3(edges + 3, edges + 3) * sqffd__dot3(edges + 6, edges + 6));
    if (!(fabs(det) > 1e-12 * scale) || !isfinite(det)) return 0;
    for (a = 0; a < 9; ++a) inverse[a] /= det;
    return 1;
}

/* A stored inverse is the box's: inverse times the edge matrix (columns S,
   T, U) is the identity within 1e-9. */
static int sqffd__ffd_inverse_holds(const double edges[9], const double inverse[9])
{
    int i, j;
    for (i = 0; i < 3; ++i)
        for (j = 0; j < 3; ++j) {
            double e = inverse[3 * i] * edges[3 * j] + inverse[3 * i + 1] * edges[3 * j + 1] +
                       inverse[3 * i + 2] * edges[3 * j + 2];
            if (!(fabs(e - (i == j ? 1.0 : 0.0)) <= 1e-9)) return 0;
        }
    return 1;
}

/* The regular lattice P0 (3 doubles a control point, sqffd_ffd's order). */
static void sqffd__ffd_regular(const int dims[3], const double origin[3], const double edges[9], double *control)
{
    int i, j, k, a;
    for (i = 0; i < dims[0]; ++i)
        for (j = 0; j < dims[1]; ++j)
            for (k = 0; k < dims[2]; ++k) {
                double s = (double)i / (double)(dims[0] - 1);
                double t = (double)j / (double)(dims[1] - 1);
                double u = (double)k / (double)(dims[2] - 1);
                double *p = control + 3 * ((i * dims[1] + j) * dims[2] + k);
                for (a = 0; a < 3; ++a) p[a] = origin[a] + s * edges[a] + t * edges[3 + a] + u * edges[6 + a];
            }
}

SQFFD_DEF sqffd_result sqffd_ffd_init(sqffd_ffd *ffd, const int dims[3], const double origin[3], const double edges[9])
{
    double inverse[9];
    int a;
    if (!ffd || !dims || !origin || !edges || !sqffd__ffd_dims_valid(dims)) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (!sqffd__finite3(origin) || !sqffd__finite3(edges) || !sqffd__finite3(edges + 3) || !sqffd__finite3(edges + 6))
        return SQFFD_ERROR_NON_FINITE;
    if (!sqffd__ffd_box_inverse(edges, inverse)) return SQFFD_ERROR_DEGENERATE;
    memset(ffd, 0, sizeof *ffd);
    memcpy(ffd->inverse, inverse, sizeof inverse);
    for (a = 0; a < 3; ++a) ffd->dims[a] = dims[a];
    memcpy(ffd->origin, origin, sizeof ffd->origin);
    memcpy(ffd->edges, edges, sizeof ffd->edges);
    sqffd__ffd_regular(dims, origin, edges, &ffd->control[0][0]);
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_ffd_validate(const sqffd_ffd *ffd)
{
    double inverse[9];
    size_t k, used;
    int i;
    if (!ffd) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (!sqffd__ffd_dims_valid(ffd->dims) || !sqffd__bounded3(ffd->origin)) return SQFFD_ERROR_INVALID_MODEL;
    for (i = 0; i < 3; ++i)
        if (!sqffd__bounded3(ffd->edges + 3 * i)) return SQFFD_ERROR_INVALID_MODEL;
    if (!sqffd__ffd_box_inverse(ffd->edges, inverse) || !sqffd__ffd_inverse_holds(ffd->edges, ffd->inverse))
        return SQFFD_ERROR_INVALID_MODEL; /* (NaN fails the comparisons) */
    used = (size_t)ffd->dims[0] * (size_t)ffd->dims[1] * (size_t)ffd->dims[2];
    for (k = 0; k < used; ++k)
        if (!sqffd__bounded3(ffd->control[k])) return SQFFD_ERROR_INVALID_MODEL;
    return SQFFD_OK;
}

/* The per-point functions on a lattice whose dims are valid. */
static void sqffd__ffd_local(const sqffd_ffd *ffd, const double point[3], double stu[3])
{
    double d[3];
    sqffd__sub3(point, ffd->origin, d);
    sqffd__mat3_vec(ffd->inverse, d, stu);
}

/* One point: sum_i ws_i sum_j wt_j (sum_k wu_k P_ijk), each inner sum made
   where it is used (sqffd__ffd_sum_u and _st keep them for a run of points). */
static void sqffd__ffd_eval(const sqffd_ffd *ffd, const double stu[3], double out[3])
{
    double w[3 * SQFFD_MAX_LATTICE], sum[3] = {0.0, 0.0, 0.0};
    const int *d = ffd->dims;
    const double *ws = w, *wt = w + d[0], *wu = w + d[0] + d[1];
    int i, j, k, c;
    sqffd__ffd_axis_weights(d, stu, w);
    for (i = 0; i < d[0]; ++i) {
        double row[3] = {0.0, 0.0, 0.0};
        for (j = 0; j < d[1]; ++j) {
            const double (*p)[3] = (const double (*)[3])ffd->control + (size_t)(i * d[1] + j) * (size_t)d[2];
            double q[3] = {0.0, 0.0, 0.0};
            for (k = 0; k < d[2]; ++k)
                for (c = 0; c < 3; ++c) q[c] += wu[k] * p[k][c];
            for (c = 0; c < 3; ++c) row[c] += wt[j] * q[c];
        }
        for (c = 0; c < 3; ++c) sum[c] += ws[i] * row[c];
    }
    out[0] = sum[0]; out[1] = sum[1]; out[2] = sum[2];
}

static void sqffd__ffd_deform(const sqffd_ffd *ffd, const double point[3], double out[3])
{
    double stu[3];
    sqffd__ffd_local(ffd, point, stu);
    sqffd__ffd_eval(ffd, stu, out);
}

/* The checks the per-point functions start with, and their ending. */
static sqffd_result sqffd__ffd_check(const sqffd_ffd *ffd, const double *in, const double *out)
{
    if (!ffd || !in || !out) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (!sqffd__ffd_dims_valid(ffd->dims)) return SQFFD_ERROR_INVALID_MODEL;
    return sqffd__finite3(in) ? SQFFD_OK : SQFFD_ERROR_NON_FINITE;
}

static sqffd_result sqffd__finite_result(const double out[3])
{
    return sqffd__finite3(out) ? SQFFD_OK : SQFFD_ERROR_NON_FINITE;
}

SQFFD_DEF sqffd_result sqffd_ffd_local(const sqffd_ffd *ffd, const double point[3], double stu[3])
{
    sqffd_result r = sqffd__ffd_check(ffd, point, stu);
    if (r != SQFFD_OK) return r;
    sqffd__ffd_local(ffd, point, stu);
    return sqffd__finite_result(stu);
}

SQFFD_DEF sqffd_result sqffd_ffd_eval(const sqffd_ffd *ffd, const double stu[3], double out[3])
{
    sqffd_result r = sqffd__ffd_check(ffd, stu, out);
    if (r != SQFFD_OK) return r;
    sqffd__ffd_eval(ffd, stu, out);
    return sqffd__finite_result(out);
}

SQFFD_DEF sqffd_result sqffd_ffd_deform(const sqffd_ffd *ffd, const double point[3], double out[3])
{
    sqffd_result r = sqffd__ffd_check(ffd, point, out);
    if (r != SQFFD_OK) return r;
    sqffd__ffd_deform(ffd, point, out);
    return sqffd__finite_result(out);
}

/* The l*m*n products of the three 1-D weight vectors, in control-point order. */
static void sqffd__ffd_expand(const int dims[3], const double *w, double *weights)
{
    const double *ws = w, *wt = w + dims[0], *wu = w + dims[0] + dims[1];
    int i, j, k;
    for (i = 0; i < dims[0]; ++i)
        for (j = 0; j < dims[1]; ++j) {
            double wij = ws[i] * wt[j];
            for (k = 0; k < dims[2]; ++k) *weights++ = wij * wu[k];
        }
}

SQFFD_DEF sqffd_result sqffd_ffd_weights(const int dims[3], const double stu[3], double *weights)
{
    double w[3 * SQFFD_MAX_LATTICE];
    if (!dims || !stu || !weights || !sqffd__ffd_dims_valid(dims)) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (!sqffd__finite3(stu)) return SQFFD_ERROR_NON_FINITE;
    sqffd__ffd_axis_weights(dims, stu, w);
    sqffd__ffd_expand(dims, w, weights);
    return SQFFD_OK;
}

/* ---- the Jacobian's Bernstein form ----------------------------------------
   In the box's own coordinates (stu = inverse (x - origin)) the regular
   lattice is the identity map, so J(s, t, u) = det(d stu' / d stu) is the
   deformation's volume ratio (1 for P0). The partial derivative along an
   axis is a Bernstein polynomial one degree lower along it, whose
   coefficients are degree x the control points' differences along it; and
   J = Ds . (Dt x Du) is one of degree 3d - 1 per axis (d = dims - 1) whose
   coefficients come exactly from theirs: with each factor's coefficients
   scaled by their binomials C(d, i), the product's are plain convolutions,
   unscaled by C(3d - 1, I). J lies between its smallest and largest
   coefficient over the whole box (the basis is nonnegative and sums to 1),
   so a smallest coefficient > 0 proves the map locally injective there.
   Each coefficient is a convex combination of triple products det(a, b, c)
   of the derivatives' coefficients (Vandermonde), so while every such vector
   is within eps of its rest value (1, 0, 0), (0, 1, 0) or (0, 0, 1) they are
   all at least 2 - (1 + eps)^3: a bound at O(l m n) that spares the
   convolutions while the lattice is near regular. */
typedef struct sqffd__jacobian_work {
    double *d[3];     /* the derivatives' coefficients, binomial-scaled, 3 doubles each */
    double *scale[3]; /* their binomial scales */
    double *cross;    /* Dt x Du, scaled */
    double *coef;     /* J's coefficients, unscaled */
} sqffd__jacobian_work;

/* Coefficient counts per axis: derivative a's (a < 3), J's (a = 3). */
static void sqffd__jacobian_extent(const int dims[3], int a, int ext[3])
{
    int b;
    for (b = 0; b < 3; ++b) ext[b] = a == 3 ? 3 * dims[b] - 3 : dims[b] - (a == b);
}

/* The product of the two derivatives other than a. */
static void sqffd__jacobian_cross_extent(const int dims[3], int a, int ext[3])
{
    int b;
    for (b = 0; b < 3; ++b) ext[b] = 2 * dims[b] - 1 - (a != b);
}

static size_t sqffd__jacobian_count(const int ext[3])
{
    return (size_t)ext[0] * (size_t)ext[1] * (size_t)ext[2];
}

static void sqffd__ffd_jacobian_layout(sqffd__arena *ar, const int dims[3], sqffd__jacobian_work *w)
{
    int a, ext[3];
    memset(w, 0, sizeof *w);
    for (a = 0; a < 3; ++a) {
        sqffd__jacobian_extent(dims, a, ext);
        w->d[a] = (double *)sqffd__arena_take(ar, 3 * sqffd__jacobian_count(ext), sizeof(double));
        w->scale[a] = (double *)sqffd__arena_take(ar, sqffd__jacobian_count(ext), sizeof(double));
    }
    sqffd__jacobian_cross_extent(dims, 0, ext);
    w->cross = (double *)sqffd__arena_take(ar, 3 * sqffd__jacobian_count(ext), sizeof(double));
    sqffd__jacobian_extent(dims, 3, ext);
    w->coef = (double *)sqffd__arena_take(ar, sqffd__jacobian_count(ext), sizeof(double));
}

/* Binomials C(d, 0..d) (d < 3 SQFFD_MAX_LATTICE: exact in doubles). */
static void sqffd__binomials(int d, double *c)
{
    int i, k;
    c[0] = 1.0;
    for (i = 1; i <= d; ++i) {
        c[i] = 1.0;
        for (k = i - 1; k > 0; --k) c[k] += c[k - 1];
    }
}

/* The derivatives' scaled coefficients in box coordinates; returns how far
   the farthest is from its rest value. */
static double sqffd__ffd_jacobian_derivatives(const int dims[3], const double *control, const double inverse[9],
                                              const sqffd__jacobian_work *w)
{
    double eps2 = 0.0, bin[3][SQFFD_MAX_LATTICE];
    int a, b, i, j, k, c, ext[3];
    for (a = 0; a < 3; ++a) {
        size_t step = a == 0 ? (size_t)(dims[1] * dims[2]) : a == 1 ? (size_t)dims[2] : 1, e = 0;
        sqffd__jacobian_extent(dims, a, ext);
        for (b = 0; b < 3; ++b) sqffd__binomials(ext[b] - 1, bin[b]);
        for (i = 0; i < ext[0]; ++i)
            for (j = 0; j < ext[1]; ++j)
                for (k = 0; k < ext[2]; ++k, ++e) {
                    const double *p = control + 3 * (size_t)((i * dims[1] + j) * dims[2] + k), *q = p + 3 * step;
                    double diff[3], v[3], off = 0.0;
                    w->scale[a][e] = bin[0][i] * bin[1][j] * bin[2][k];
                    for (c = 0; c < 3; ++c) diff[c] = (double)(dims[a] - 1) * (q[c] - p[c]);
                    sqffd__mat3_vec(inverse, diff, v);
                    for (c = 0; c < 3; ++c) {
                        double o = v[c] - (c == a ? 1.0 : 0.0);
                        off += o * o;
                        w->d[a][3 * e + (size_t)c] = v[c] * w->scale[a][e];
                    }
                    if (off > eps2) eps2 = off;
                }
    }
    return sqrt(eps2);
}

/* out = the convolution of x and y (extents ex and ey) under the cross product. */
static void sqffd__jacobian_convolve(const double *x, const int ex[3], const double *y, const int ey[3], double *out)
{
    int eo[3], i, j, k, i2, j2, k2, b;
    for (b = 0; b < 3; ++b) eo[b] = ex[b] + ey[b] - 1;
    memset(out, 0, 3 * sqffd__jacobian_count(eo) * sizeof(double));
    for (i = 0; i < ex[0]; ++i)
        for (j = 0; j < ex[1]; ++j)
            for (k = 0; k < ex[2]; ++k) {
                const double *t = x + 3 * ((i * ex[1] + j) * ex[2] + k);
                for (i2 = 0; i2 < ey[0]; ++i2)
                    for (j2 = 0; j2 < ey[1]; ++j2) {
                        const double *u = y + 3 * ((i2 * ey[1] + j2) * ey[2]);
                        double *o = out + 3 * (((i + i2) * eo[1] + j + j2) * eo[2] + k);
                        for (k2 = 0; k2 < ey[2]; ++k2, u += 3, o += 3) {
                            o[0] += t[1] * u[2] - t[2] * u[1];
                            o[1] += t[2] * u[0] - t[0] * u[2];
                            o[2] += t[0] * u[1] - t[1] * u[0];
                        }
                    }
            }
}

/* Dt x Du. */
static void sqffd__ffd_jacobian_products(const int dims[3], const sqffd__jacobian_work *w)
{
    int et[3], eu[3];
    sqffd__jacobian_extent(dims, 1, et);
    sqffd__jacobian_extent(dims, 2, eu);
    sqffd__jacobian_convolve(w->d[1], et, w->d[2], eu, w->cross);
}

/* J's coefficient (I, J, K) scaled by its binomials: the convolution of
   Ds (extents es) with Dt x Du (ec) there (inlined: the whole pass calls it
   for every coefficient). */
SQFFD__INLINE double sqffd__jacobian_scaled(const sqffd__jacobian_work *w, const int es[3], const int ec[3], int I,
                                            int J, int K)
{
    double sum = 0.0;
    int i, j, k, i0 = I - ec[0] + 1 > 0 ? I - ec[0] + 1 : 0, j0 = J - ec[1] + 1 > 0 ? J - ec[1] + 1 : 0;
    int k0 = K - ec[2] + 1 > 0 ? K - ec[2] + 1 : 0;
    for (i = i0; i < es[0] && i <= I; ++i)
        for (j = j0; j < es[1] && j <= J; ++j)
            for (k = k0; k < es[2] && k <= K; ++k) {
                const double *s = w->d[0] + 3 * ((i * es[1] + j) * es[2] + k);
                const double *x = w->cross + 3 * (((I - i) * ec[1] + J - j) * ec[2] + K - k);
                sum += s[0] * x[0] + s[1] * x[1] + s[2] * x[2];
            }
    return sum;
}

/* J's coefficients into w->coef, from Ds and Dt x Du; returns the smallest. */
static double sqffd__ffd_jacobian_coefficients(const int dims[3], const sqffd__jacobian_work *w)
{
    int es[3], ec[3], ej[3], i, I, J, K;
    double best = HUGE_VAL, *coef = w->coef, bin[3][3 * SQFFD_MAX_LATTICE];
    sqffd__jacobian_extent(dims, 0, es);
    sqffd__jacobian_cross_extent(dims, 0, ec);
    sqffd__jacobian_extent(dims, 3, ej);
    for (i = 0; i < 3; ++i) sqffd__binomials(ej[i] - 1, bin[i]);
    for (I = 0; I < ej[0]; ++I)
        for (J = 0; J < ej[1]; ++J)
            for (K = 0; K < ej[2]; ++K) {
                double c = sqffd__jacobian_scaled(w, es, ec, I, J, K) / (bin[0][I] * bin[1][J] * bin[2][K]);
                if (c < best) best = c;
                *coef++ = c;
            }
    return best;
}

/* The smallest of J's coefficients for control points in sqffd_ffd's
   layout, or the near-regular bound when that is at least `enough`
   (HUGE_VAL: always the coefficients, then in w->coef). */
static double sqffd__ffd_jacobian_min(const int dims[3], const double *control, const double inverse[9],
                                      const sqffd__jacobian_work *w, double enough)
{
    double eps = sqffd__ffd_jacobian_derivatives(dims, control, inverse, w);
    double near = 2.0 - (1.0 + eps) * (1.0 + eps) * (1.0 + eps);
    if (near >= enough) return near;
    sqffd__ffd_jacobian_products(dims, w);
    return sqffd__ffd_jacobian_coefficients(dims, w);
}

SQFFD_DEF sqffd_result sqffd_ffd_jacobian_workspace_size(const int dims[3], size_t *size)
{
    sqffd__arena a;
    sqffd__jacobian_work w;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    if (!dims || !sqffd__ffd_dims_valid(dims)) return SQFFD_ERROR_INVALID_ARGUMENT;
    sqffd__arena_measure(&a);
    sqffd__ffd_jacobian_layout(&a, dims, &w);
    return sqffd__arena_size(&a, size);
}

SQFFD_DEF sqffd_result sqffd_ffd_jacobian_bound(const sqffd_ffd *ffd, double *min, void *workspace,
                                               size_t workspace_size)
{
    sqffd__arena a;
    sqffd__jacobian_work w;
    sqffd_result r;
    double bound;
    if (!ffd || !min) return SQFFD_ERROR_INVALID_ARGUMENT;
    if ((r = sqffd_ffd_validate(ffd)) != SQFFD_OK) return r;
    sqffd__arena_init(&a, workspace, workspace_size);
    sqffd__ffd_jacobian_layout(&a, ffd->dims, &w);
    if (a.overflow) return sqffd__arena_error(&a);
    bound = sqffd__ffd_jacobian_min(ffd->dims, &ffd->control[0][0], ffd->inverse, &w, HUGE_VAL);
    if (!isfinite(bound)) return SQFFD_ERROR_NON_FINITE;
    *min = bound;
    return SQFFD_OK;
}
/* ======================================================================
   Layer 5: model fit (superquadric + FFD, the paper's two-step algorithm)
   ====================================================================== */

/* The map, in call order (sqffd_fit_view; sqffd_fit_ffd_view starts at
   sqffd__fit_prepare, sqffd_fit_prepared and sqffd_track at sqffd__fit_run
   with a system prepared once, in layer 6):
     sqffd__fit_check_whole_options, sqffd__fit_check_data   the arguments
     sqffd__fit_system_layout, sqffd__fit_frame_layout       the workspace
     sqffd__fit_whole                                        the stages:
       sqffd_sq_fit_view (layer 3), sqffd__fit_guard         stage 1, guarded by the error
       sqffd_model_init                                      the box and the regular lattice P0
       sqffd__fit_prepare         B's rows at the model points, the springs' and tether's fixed matrix
       sqffd__fit_coarse_first    (when there is a coarse grid) a run on it, then on the grid
     sqffd__fit_run               the subsample, the model -> data tree, the errors over all points
     sqffd__fit_iterate           stage 2's loop without a floor, in phases:
       sqffd__fit_begin, sqffd__fit_scale                    the start; robust mode's scale
       sqffd__fit_measure         the pass (sqffd__fit_pass -> sqffd__fit_closest per data point:
                                  sqffd__fit_nearest_vertex, the fan and the walk, sqffd__fit_certify
                                  in an exact pass), sqffd__fit_nearest_data, the energy
       sqffd__fit_accept_or_roll_back   the energy check; a rolled-back step is measured again
       sqffd__fit_record          the report, the progress callback
       sqffd__fit_advance         sqffd__fit_targets (step 1), sqffd__fit_step (step 2: sqffd__fit_solve
                                  or conjugate-gradient steps), the over-relaxed next control points
     sqffd__fit_iterate_fold_free under the floor:
       sqffd__fit_region          the region's cells and samples (from the superquadric and the box)
       sqffd__fit_fold_untangle   a start that folds on the region drawn toward P0 until certified
       sqffd__fit_fold_certify    J's Bernstein coefficients on the region's cells, halved where low
       sqffd__fit_fold_frames     J's frames on the region's node lattice (the samples' J, its change
                                  along a step)
       sqffd__fit_fold_linearise  the energy's Gauss-Newton matrix (point-to-plane) at the accepted model
       sqffd__fit_fold_step       the damped step with the samples' penalty (its dual over candidates)
   The sections below, in order: the grid and its mesh, the closest-point
   search, statistics, the passes' order and the pass, model geometry, save
   and load, distances (the same pass), options and the box, the
   least-squares problem of step 2, the fold-free step, the iteration, the
   fold-free iteration, the entry points. */

#define SQFFD__FIT_PI 3.14159265358979323846
#define SQFFD__FIT_MAX_GRID 65536     /* per grid axis */
#define SQFFD__FIT_MIN_POINTS 4       /* sqffd_fit_ffd; sqffd_fit defers to the superquadric fit */
#define SQFFD__FIT_MAX_WALK 8         /* fan-to-fan moves of the closest-point search */
#define SQFFD__FIT_SVD_RCOND 1e-10    /* singular values below this fraction of the largest are dropped */
#define SQFFD__FIT_SNAP 1e-14         /* u this close to its run's first is that u (rounding: the runs' B rows factor) */

/* ---- the (eta, omega) grid and its closed mesh ----------------------------
   Vertex i * n_omega + j is (eta_i, omega_j) at equal steps of arc length
   (see sqffd_model and below); then the south pole (eta = -pi/2), then
   the north pole. Each quad (i, j), (i, j+1), (i+1, j+1), (i+1, j) is split
   along its (i, j)-(i+1, j+1) diagonal; the pole caps are fans. */

static sqffd_result sqffd__fit_grid_check(const int grid[2])
{
    if (grid[0] < 2 || grid[1] < 3) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (grid[0] > SQFFD__FIT_MAX_GRID || grid[1] > SQFFD__FIT_MAX_GRID ||
        (double)grid[0] * (double)grid[1] + 2.0 > 4294967295.0)
        return SQFFD_ERROR_TOO_LARGE;
    return SQFFD_OK;
}

static size_t sqffd__fit_grid_count(const int grid[2])
{
    return (size_t)grid[0] * (size_t)grid[1] + 2;
}

/* The grid's angles: equal shares of arc length. Evenly spaced angles put
   a squarish superquadric's rows on its caps (e1 = 0.1: the first row off
   the equator at 0.74 of the half-height, nothing of the wall between), so
   rows go at equal steps of the length of its meridian (the superellipse of
   half-width (a1 + a2) / 2, half-height a3 and exponent e1, untapered) and
   columns at equal steps of the perimeter of its cross-section (a1, a2,
   e2). The length is summed over SQFFD__FIT_ARC_SAMPLES chords between
   points evenly spaced in their angle seen from the centre (which spreads
   them over the sides and the caps of a squarish curve alike); an angle
   within a chord is interpolated in that angle. */
#define SQFFD__FIT_ARC_SAMPLES 1024

typedef struct sqffd__fit_arc {
    double half[2], exponent, from, step; /* the superellipse and its central angles' range */
    double total;                         /* its length over the range */
    double walked, at[2];                 /* the walk: the length up to sample k, sample k's point */
    int k;
} sqffd__fit_arc;

/* The superellipse's point at central angle theta. */
static void sqffd__fit_arc_point(const sqffd__fit_arc *a, double theta, double xy[2])
{
    double c = cos(theta), s = sin(theta), big = a->half[0] > a->half[1] ? a->half[0] : a->half[1], power = 2.0 / a->exponent;
    double r = big * pow(pow(fabs(c) * big / a->half[0], power) + pow(fabs(s) * big / a->half[1], power), -0.5 * a->exponent);
    xy[0] = r * c;
    xy[1] = r * s;
}

static void sqffd__fit_arc_start(sqffd__fit_arc *a, double half0, double half1, double exponent, double from, double to)
{
    double next[2];
    int k;
    a->half[0] = half0;
    a->half[1] = half1;
    a->exponent = exponent;
    a->from = from;
    a->step = (to - from) / SQFFD__FIT_ARC_SAMPLES;
    a->total = 0.0;
    sqffd__fit_arc_point(a, from, a->at);
    for (k = 1; k <= SQFFD__FIT_ARC_SAMPLES; ++k) {
        sqffd__fit_arc_point(a, from + a->step * k, next);
        a->total += hypot(next[0] - a->at[0], next[1] - a->at[1]);
        a->at[0] = next[0];
        a->at[1] = next[1];
    }
    a->walked = 0.0;
    a->k = 0;
    sqffd__fit_arc_point(a, from, a->at);
}

/* The superellipse's own angle (its point is (h0 spow(cos t, e), h1 spow(sin t, e)))
   at share (0..1) of the length; shares must come in ascending order. */
static double sqffd__fit_arc_angle(sqffd__fit_arc *a, double share)
{
    double target = share * a->total, next[2], chord = 0.0, theta, xy[2], own;
    if (!(a->total > 0.0 && a->total < HUGE_VAL)) /* a superellipse too extreme to measure (sizes or exponent): */
        return a->from + a->step * SQFFD__FIT_ARC_SAMPLES * share; /* even angles */
    while (a->k < SQFFD__FIT_ARC_SAMPLES) {
        sqffd__fit_arc_point(a, a->from + a->step * (a->k + 1), next);
        chord = hypot(next[0] - a->at[0], next[1] - a->at[1]);
        if (a->walked + chord >= target) break;
        a->walked += chord;
        a->at[0] = next[0];
        a->at[1] = next[1];
        ++a->k;
    }
    theta = a->from + a->step * (a->k + (chord > 0.0 ? (target - a->walked) / chord : 0.0));
    sqffd__fit_arc_point(a, theta, xy);
    own = atan2(sqffd__sq_spow(xy[1] / a->half[1], 1.0 / a->exponent), sqffd__sq_spow(xy[0] / a->half[0], 1.0 / a->exponent));
    return isfinite(own) ? own : theta;
}

/* The mesh neighbours of a vertex in cyclic order: the triangles around v are
   (v, ring k, ring k+1 mod count). A pole's ring is its whole adjacent row.
   The searches read them from a table made once per mesh (sqffd__fit_rings). */
#define SQFFD__FIT_NOT_POLE UINT32_MAX

typedef struct sqffd__fit_ring {
    uint32_t count;
    uint32_t pole_row; /* a pole's: first vertex of its adjacent row; else SQFFD__FIT_NOT_POLE */
    uint32_t v[6];     /* other vertices */
} sqffd__fit_ring;

static void sqffd__fit_rings(const int grid[2], sqffd__fit_ring *rings)
{
    uint32_t ne = (uint32_t)grid[1], rows = (uint32_t)grid[0] * ne; /* the grid check keeps these below 2^32 */
    uint32_t south = rows, north = rows + 1, i, j, jp, jm, c, cand[6];
    for (i = 0; i < (uint32_t)grid[0]; ++i)
        for (j = 0; j < ne; ++j) {
            sqffd__fit_ring *r = rings + i * ne + j;
            jp = j + 1 < ne ? j + 1 : 0; jm = j > 0 ? j - 1 : ne - 1;
            cand[0] = i * ne + jp;
            cand[1] = i + 1 < (uint32_t)grid[0] ? (i + 1) * ne + jp : north;
            cand[2] = i + 1 < (uint32_t)grid[0] ? (i + 1) * ne + j : north;
            cand[3] = i * ne + jm;
            cand[4] = i > 0 ? (i - 1) * ne + jm : south;
            cand[5] = i > 0 ? (i - 1) * ne + j : south;
            r->count = 0;
            r->pole_row = SQFFD__FIT_NOT_POLE;
            for (c = 0; c < 6; ++c) /* a pole appears twice in a row next to it */
                if (r->count == 0 || cand[c] != r->v[r->count - 1]) r->v[r->count++] = cand[c];
        }
    for (c = 0; c < 2; ++c) {
        sqffd__fit_ring *r = rings + rows + c;
        memset(r, 0, sizeof *r);
        r->count = ne;
        r->pole_row = c == 0 ? 0 : rows - ne;
    }
}

static size_t sqffd__fit_ring_at(const sqffd__fit_ring *r, size_t k)
{
    return r->pole_row != SQFFD__FIT_NOT_POLE ? r->pole_row + k : r->v[k];
}

/* Closest point to q on the triangle (v, v + ea, v + eb), from ap = q - v:
   its barycentric weights w (of v, a, b; w[0] is exactly 0 on the edge ab
   and its ends), by the Voronoi regions of the vertices, edges and face
   (Ericson, Real-Time Collision Detection, 5.1.5), and its squared distance.
   A flat triangle falls back on its nearest vertex, a zero-length edge on
   its end. The region is found first and the weights take one division
   (measured: a few percent of a whole fit on the meshes over a division
   in each region's branch). */
SQFFD__INLINE double sqffd__fit_triangle(const double ap[3], const double ea[3], const double eb[3], double w[3])
{
    double pa = sqffd__dot3(ea, ap), pb = sqffd__dot3(eb, ap);
    double aa = sqffd__dot3(ea, ea), bb = sqffd__dot3(eb, eb), ab = sqffd__dot3(ea, eb);
    double d3 = pa - aa, d4 = pb - ab, d5 = pa - ab, d6 = pb - bb;
    double vc = pa * d4 - d3 * pb, vb = d5 * pb - pa * d6, va = d3 * d6 - d5 * d4, sum = va + vb + vc;
    double len2 = (d4 - d3) + (d5 - d6); /* |eb - ea|^2 */
    double da = aa - 2.0 * pa, db = bb - 2.0 * pb; /* |q - a|^2 - |q - v|^2, same for b */
    double num, den, t, r[3];
    /* the region: the first that holds, in Ericson's order */
    int region = pa <= 0.0 && pb <= 0.0                           ? 0  /* vertex v */
                 : d3 >= 0.0 && d4 <= d3                          ? 1  /* vertex a */
                 : d6 >= 0.0 && d5 <= d6                          ? 2  /* vertex b */
                 : vc <= 0.0 && pa >= 0.0 && d3 <= 0.0            ? 3  /* edge va */
                 : vb <= 0.0 && pb >= 0.0 && d6 <= 0.0            ? 4  /* edge vb */
                 : va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0  ? 5  /* edge ab */
                 : sum > 0.0                                      ? 6  /* face */
                 : da < 0.0 && da <= db                           ? 1  /* flat: its nearest vertex */
                 : db < 0.0                                       ? 2
                                                                  : 0;
    int edge_va = region == 3 && aa > 0.0, edge_vb = region == 4 && bb > 0.0, edge_ab = region == 5 && len2 > 0.0;
    num = edge_va ? pa : edge_vb ? pb : edge_ab ? d4 - d3 : 1.0;
    den = edge_va ? aa : edge_vb ? bb : edge_ab ? len2 : region == 6 ? sum : 1.0;
    t = num / den; /* (1 where the region needs no division: unused) */
    t = region >= 3 && region <= 5 && !(edge_va || edge_vb || edge_ab) ? 0.0 : t; /* a zero-length edge: its end */
    w[1] = region == 1 ? 1.0 : region == 3 ? t : region == 5 ? 1.0 - t : region == 6 ? vb * t : 0.0;
    w[2] = region == 2 ? 1.0 : region == 4 || region == 5 ? t : region == 6 ? vc * t : 0.0;
    w[0] = region == 0 ? 1.0 : region == 3 || region == 4 ? 1.0 - t : region == 6 ? va * t : 0.0;
    r[0] = ap[0] - w[1] * ea[0] - w[2] * eb[0];
    r[1] = ap[1] - w[1] * ea[1] - w[2] * eb[1];
    r[2] = ap[2] - w[1] * ea[2] - w[2] * eb[2];
    return sqffd__dot3(r, r);
}

/* The mesh triangle tri (corner tri[0] first, as in a fan around it) against
   q: the closest point's squared distance and barycentric weights. The fan
   search and the warm start's re-measurement of one triangle both come
   here, so they agree to the bit. */
SQFFD__INLINE double sqffd__fit_corner_triangle(const double *x, const size_t tri[3], const double q[3], double w[3])
{
    double ap[3], ea[3], eb[3];
    const double *v = x + 3 * tri[0];
    sqffd__sub3(q, v, ap);
    sqffd__sub3(x + 3 * tri[1], v, ea);
    sqffd__sub3(x + 3 * tri[2], v, eb);
    return sqffd__fit_triangle(ap, ea, eb, w);
}

/* The closest point to q on the fan of triangles (v, ring k, ring k+1 mod
   count) around vertex v: its squared distance, triangle (tri[0] = v) and
   barycentric weights (the first of equally close triangles). */
static double sqffd__fit_fan_closest(const double *x, const sqffd__fit_ring *rings, size_t v, const double q[3],
                                     size_t tri[3], double w[3])
{
    const sqffd__fit_ring *r = rings + v;
    double best = HUGE_VAL, tw[3];
    size_t k, t[3];
    t[0] = v;
    for (k = 0; k < r->count; ++k) {
        double d;
        t[1] = sqffd__fit_ring_at(r, k);
        t[2] = sqffd__fit_ring_at(r, k + 1 < r->count ? k + 1 : 0);
        d = sqffd__fit_corner_triangle(x, t, q, tw);
        if (d < best || k == 0) { /* (k == 0: an answer even when every distance overflows) */
            best = d;
            memcpy(tri, t, sizeof t);
            memcpy(w, tw, sizeof tw);
        }
    }
    return best;
}

/* "The error" of q from the closest point (best, tri, w) on the fan of its
   nearest mesh vertex: while that lies on the fan's outer rim (v's weight
   0), the fan around the rim vertex nearer to it is searched too (at most
   SQFFD__FIT_MAX_WALK moves, never getting farther). */
static double sqffd__fit_walk(const double *x, const sqffd__fit_ring *rings, const double q[3], double best, size_t tri[3],
                             double w[3])
{
    int step;
    for (step = 0; step < SQFFD__FIT_MAX_WALK && w[0] == 0.0; ++step) {
        size_t t2[3];
        double w2[3], d = sqffd__fit_fan_closest(x, rings, w[1] >= w[2] ? tri[1] : tri[2], q, t2, w2);
        if (!(d < best)) break;
        best = d;
        memcpy(tri, t2, sizeof t2);
        memcpy(w, w2, sizeof w2);
    }
    return best;
}

/* A bounding-volume tree over the mesh triangles (see sqffd__fit_certify),
   made of the grid's own patches: cells are the triangle strips between
   consecutive rows (the south cap, the quad rows, the north cap; a cell is
   one cap triangle or one quad's two), and a node is a rectangle of cells
   split into up to four (its rows halved where there are two or more, its
   columns likewise), down to nodes of at most 2 x 2 cells whose children are
   the cells themselves. The patches of a smooth surface are compact, so their
   boxes stay tight even where the triangles are long and thin (a boxy
   superquadric's faces). A node holds its children's boxes side by side, so
   a visit measures all four gaps in one loop that the compiler packs into
   vectors, and a cell's box is measured before its triangles. The nodes are
   laid out depth first (children after their parent) once a search, their
   boxes measured once a pass. */
#define SQFFD__FIT_BVH_WIDTH 4 /* children of a node at most */

typedef struct sqffd__fit_bvh_node {
    double low[3][SQFFD__FIT_BVH_WIDTH]; /* the children's boxes per axis (an unused slot: low +inf, high -inf) */
    double high[3][SQFFD__FIT_BVH_WIDTH];
    uint32_t child[SQFFD__FIT_BVH_WIDTH]; /* the child nodes; at the bottom, the cells (row x columns + column) */
    uint32_t count;                       /* children */
    uint32_t bottom;                      /* 1: the children are cells */
} sqffd__fit_bvh_node;

typedef struct sqffd__fit_bvh {
    sqffd__fit_bvh_node *nodes;
    size_t count;
} sqffd__fit_bvh;

/* A walk's or the build's pending nodes at most: three per level below the
   root (the fourth is being visited) and the last one's four; 16 levels of
   inner nodes for 65,537 x 65,536 cells (rows and columns halved at each),
   so 49 at most. */
#define SQFFD__FIT_BVH_STACK 64

/* The nodes over the grid's cells, depth first (nodes NULL: only counts them). */
static size_t sqffd__fit_bvh_build(const int grid[2], sqffd__fit_bvh_node *nodes)
{
    struct { uint32_t rows[2], cols[2], parent, slot; } stack[SQFFD__FIT_BVH_STACK], cur;
    size_t count = 0;
    uint32_t columns = (uint32_t)grid[1];
    int top = 0;
    stack[top].rows[0] = 0; stack[top].rows[1] = (uint32_t)grid[0] + 1;
    stack[top].cols[0] = 0; stack[top].cols[1] = columns;
    stack[top++].parent = UINT32_MAX;
    while (top > 0) {
        uint32_t nr, nc, r, c, split[2][3], parts[2], a, b, bottom;
        sqffd__fit_bvh_node *node = NULL;
        cur = stack[--top];
        nr = cur.rows[1] - cur.rows[0];
        nc = cur.cols[1] - cur.cols[0];
        bottom = nr <= 2 && nc <= 2;
        if (nodes) {
            node = nodes + count;
            if (cur.parent != UINT32_MAX) nodes[cur.parent].child[cur.slot] = (uint32_t)count;
            for (a = 0; a < 3; ++a)
                for (b = 0; b < SQFFD__FIT_BVH_WIDTH; ++b) {
                    node->low[a][b] = HUGE_VAL;
                    node->high[a][b] = -HUGE_VAL;
                }
            node->bottom = bottom;
            node->count = 0;
        }
        if (bottom) {
            if (node)
                for (r = cur.rows[0]; r < cur.rows[1]; ++r)
                    for (c = cur.cols[0]; c < cur.cols[1]; ++c) node->child[node->count++] = r * columns + c;
        } else { /* the quarters wait, the first on top */
            parts[0] = nr > 1 ? 2 : 1;
            parts[1] = nc > 1 ? 2 : 1;
            split[0][0] = cur.rows[0]; split[0][1] = cur.rows[0] + nr / 2; split[0][2] = cur.rows[1];
            split[1][0] = cur.cols[0]; split[1][1] = cur.cols[0] + nc / 2; split[1][2] = cur.cols[1];
            if (parts[0] == 1) split[0][1] = cur.rows[1];
            if (parts[1] == 1) split[1][1] = cur.cols[1];
            if (node) node->count = parts[0] * parts[1];
            SQFFD_ASSERT(top + SQFFD__FIT_BVH_WIDTH <= SQFFD__FIT_BVH_STACK); /* (the walk's bound too: see above) */
            for (a = parts[0]; a-- > 0;)
                for (b = parts[1]; b-- > 0;) {
                    stack[top].rows[0] = split[0][a]; stack[top].rows[1] = split[0][a + 1];
                    stack[top].cols[0] = split[1][b]; stack[top].cols[1] = split[1][b + 1];
                    stack[top].parent = (uint32_t)count;
                    stack[top++].slot = a * parts[1] + b;
                }
        }
        ++count;
    }
    return count;
}

/* The triangles of cell (r, c) of the grid mesh; returns 1 or 2. */
static int sqffd__fit_cell(const int grid[2], uint32_t r, uint32_t c, uint32_t tri[2][3])
{
    uint32_t ne = (uint32_t)grid[1], rows = (uint32_t)grid[0] * ne, c1 = c + 1 < ne ? c + 1 : 0;
    if (r == 0) { /* south cap */
        tri[0][0] = rows; tri[0][1] = c1; tri[0][2] = c;
        return 1;
    }
    if (r == (uint32_t)grid[0]) { /* north cap */
        tri[0][0] = rows - ne + c; tri[0][1] = rows - ne + c1; tri[0][2] = rows + 1;
        return 1;
    }
    tri[0][0] = (r - 1) * ne + c; tri[0][1] = (r - 1) * ne + c1; tri[0][2] = r * ne + c1;
    tri[1][0] = tri[0][0]; tri[1][1] = tri[0][2]; tri[1][2] = r * ne + c;
    return 2;
}

/* The grid mesh's triangles, cell by cell (the order sqffd_model_mesh lists). */
static void sqffd__fit_triangles(const int grid[2], uint32_t (*triangles)[3])
{
    uint32_t r, c, cell[2][3];
    size_t t = 0;
    int k, count;
    for (r = 0; r <= (uint32_t)grid[0]; ++r)
        for (c = 0; c < (uint32_t)grid[1]; ++c)
            for (count = sqffd__fit_cell(grid, r, c, cell), k = 0; k < count; ++k, ++t) {
                triangles[t][0] = cell[k][0]; triangles[t][1] = cell[k][1]; triangles[t][2] = cell[k][2];
            }
}

static void sqffd__fit_bvh_layout(sqffd__arena *a, const int grid[2], sqffd__fit_bvh *h)
{
    h->count = sqffd__fit_bvh_build(grid, NULL);
    h->nodes = (sqffd__fit_bvh_node *)sqffd__arena_take(a, h->count, sizeof(sqffd__fit_bvh_node));
}

/* ---- the closest-point search, with a warm start -------------------------
   A data point's answer (its nearest mesh vertex, and the closest triangle of
   that vertex's fan) rarely changes between two iterations, whose model
   points move little. So each point keeps its last answer: its nearest
   vertex is found again by descending the mesh from the last one (only a
   point without a last answer asks the tree over the vertices,
   sqffd__fit_tree), and in a fit's passes between its first and last
   (exact = 0, local answers) the point keeps its last triangle while that
   vertex stays the nearest and the closest point stays inside the triangle
   (the fan search it saves is most of a pass's cost on smooth surfaces).
   The point's matched triangle from the last pass stands where it is closer,
   so each step's bound still holds (sqffd__fit_closest). An exact pass (a
   fit's first and last, and sqffd_model_distances) then proves the answer
   the closest of the whole mesh or finds the one that is
   (sqffd__fit_certify). (Bounds on the vertices' moves that would prove the
   nearest vertex unchanged without a descent run out within a pass on real
   shapes: bench/NOTES.md.) */
#define SQFFD__FIT_DESCENT 16 /* vertex-to-vertex moves of a descent at most */

typedef struct sqffd__fit_search {
    const double *x;         /* mesh vertices (the model points) */
    size_t count;            /* and their number */
    const sqffd__fit_ring *rings;
    sqffd_kdtree tree;       /* over x, once built */
    void *tree_ws;
    size_t tree_size;
    int tree_current;        /* the tree is over x as it is */
    uint32_t (*triangle)[3]; /* the warm start (NULL: none): per data point, the closest triangle of its last fan
                                search (its corner 0: the fan's vertex, the nearest vertex then; UINT32_MAX: none yet) */
    uint32_t (*matched)[3];  /* a fit's: the triangle each point was matched to in the last pass (NULL: none) */
    struct sqffd__fit_bvh *bvh; /* the exact passes' tree over the triangles, when bvh_current */
    int bvh_current;
    int grid[2];
    int exact;               /* 0: a pass between a fit's first and last (see above) */
    int final;               /* an exact pass no other follows: a point starts the tree walk from its matched
                                triangle (of the pass before), and its last answer is neither read nor kept */
    const uint32_t *order;   /* the order a pass visits the data points in (NULL: theirs; see sqffd__fit_order) */
} sqffd__fit_search;

/* The tree over the mesh vertices as they are: built when first asked after
   the vertices moved. (Refitting the last one instead is 8x cheaper, but
   as the model leaves the superquadric's shape its boxes overlap and the
   queries slow down: rebuilding made the whole fit 20-25% faster on the
   phantom and a 6,000-point scan. Only points without a last answer ask.) */
static sqffd_result sqffd__fit_tree(sqffd__fit_search *s)
{
    sqffd_result res;
    if (s->tree_current) return SQFFD_OK;
    res = sqffd_kdtree_build(&s->tree, s->x, s->count, s->tree_ws, s->tree_size);
    if (res == SQFFD_OK) s->tree_current = 1;
    return res;
}

/* The nearest mesh vertex to data point i at q: a descent from its last
   one, or the tree's answer. */
static sqffd_result sqffd__fit_nearest_vertex(sqffd__fit_search *s, size_t i, const double q[3], size_t *nearest)
{
    size_t near, k, step;
    double d2;
    sqffd_result res;
    if (s->triangle && s->triangle[i][0] != UINT32_MAX) { /* (a descent needs no proof: see above) */
        size_t v = s->triangle[i][0], next;
        double best = sqffd__dist2_3(q, s->x + 3 * v);
        for (step = 0; step < SQFFD__FIT_DESCENT; ++step) {
            const sqffd__fit_ring *r = s->rings + v;
            for (next = v, k = 0; k < r->count; ++k) {
                size_t u = sqffd__fit_ring_at(r, k);
                double du = sqffd__dist2_3(q, s->x + 3 * u);
                if (du < best) { best = du; next = u; }
            }
            if (next == v) break;
            v = next;
        }
        *nearest = v;
        return SQFFD_OK;
    }
    res = sqffd__fit_tree(s);
    if (res != SQFFD_OK) return res;
    if (!sqffd__finite3(q)) return SQFFD_ERROR_NON_FINITE;
    if (sqffd__kd_query(&s->tree, q, HUGE_VAL, 0, &near, &d2, 1) == 0)
        return SQFFD_ERROR_NON_FINITE; /* (a tree over the mesh always answers) */
    *nearest = near;
    return SQFFD_OK;
}

/* The boxes of every node's children over the mesh vertices x, bottom up. */
static void sqffd__fit_bvh_boxes(sqffd__fit_bvh *h, const int grid[2], const double *x)
{
    uint32_t columns = (uint32_t)grid[1], k, j;
    size_t i;
    int c;
    for (i = h->count; i-- > 0;) { /* children come after their parent */
        sqffd__fit_bvh_node *node = h->nodes + i;
        for (k = 0; k < node->count; ++k) {
            double low[3], high[3];
            for (c = 0; c < 3; ++c) { low[c] = HUGE_VAL; high[c] = -HUGE_VAL; }
            if (node->bottom) {
                uint32_t tri[2][3];
                int t, n, count = sqffd__fit_cell(grid, node->child[k] / columns, node->child[k] % columns, tri);
                for (t = 0; t < count; ++t)
                    for (n = 0; n < 3; ++n)
                        for (c = 0; c < 3; ++c) {
                            double v = x[3 * (size_t)tri[t][n] + (size_t)c];
                            low[c] = v < low[c] ? v : low[c];
                            high[c] = v > high[c] ? v : high[c];
                        }
            } else {
                const sqffd__fit_bvh_node *child = h->nodes + node->child[k];
                for (c = 0; c < 3; ++c)
                    for (j = 0; j < SQFFD__FIT_BVH_WIDTH; ++j) { /* (unused slots are empty boxes) */
                        low[c] = child->low[c][j] < low[c] ? child->low[c][j] : low[c];
                        high[c] = child->high[c][j] > high[c] ? child->high[c][j] : high[c];
                    }
            }
            for (c = 0; c < 3; ++c) {
                node->low[c][k] = low[c];
                node->high[c][k] = high[c];
            }
        }
    }
}

/* The squared gaps between q and a node's four child boxes (0 inside; an
   unused slot's is infinite), written out so that the compiler packs the
   four into vectors. */
static void sqffd__fit_bvh_gaps(const sqffd__fit_bvh_node *node, const double q[3], double gap2[SQFFD__FIT_BVH_WIDTH])
{
    int c, k;
    for (k = 0; k < SQFFD__FIT_BVH_WIDTH; ++k) gap2[k] = 0.0;
    for (c = 0; c < 3; ++c)
        SQFFD__KEEP_LOOP
        for (k = 0; k < SQFFD__FIT_BVH_WIDTH; ++k) {
            double below = node->low[c][k] - q[c], above = q[c] - node->high[c][k];
            double d = below > above ? below : above;
            d = d > 0.0 ? d : 0.0;
            gap2[k] += d * d;
        }
}

/* A child pushed on a walk's stack among those pushed since first, kept
   farthest key first (so the nearest is popped next; insertion: at most 4). */
static void sqffd__fit_bvh_push(uint32_t *stack, double *keys, int *top, int first, double key, uint32_t child)
{
    int j;
    for (j = *top; j > first && keys[j - 1] < key; --j) {
        keys[j] = keys[j - 1];
        stack[j] = stack[j - 1];
    }
    keys[j] = key;
    stack[j] = child;
    ++*top;
}

/* The exact closest point from a first answer (best2, tri, w) for q: the
   tree over the triangles (sqffd__fit_bvh) is walked nearest box first,
   skipping every box (of a node, or of a cell before its triangles) farther
   than the best so far; the first answer is usually the closest already, so
   few boxes stay open. The boxes are measured once a pass, when first needed. */
static void sqffd__fit_certify(sqffd__fit_search *s, const double q[3], double *best2, size_t tri[3], double w[3])
{
    const sqffd__fit_bvh *h = s->bvh;
    uint32_t stack[SQFFD__FIT_BVH_STACK], columns = (uint32_t)s->grid[1];
    double gaps[SQFFD__FIT_BVH_STACK]; /* of the boxes on the stack */
    int top = 0;
    if (!s->bvh_current) {
        sqffd__fit_bvh_boxes(s->bvh, s->grid, s->x);
        s->bvh_current = 1;
    }
    stack[top] = 0;
    gaps[top++] = 0.0;
    while (top > 0) {
        const sqffd__fit_bvh_node *node;
        double gap2[SQFFD__FIT_BVH_WIDTH];
        uint32_t k;
        --top;
        if (gaps[top] >= *best2) continue; /* (the best may have improved since it was pushed) */
        node = h->nodes + stack[top];
        sqffd__fit_bvh_gaps(node, q, gap2);
        if (node->bottom) {
            for (k = 0; k < node->count; ++k) {
                uint32_t cell[2][3];
                int t, count;
                if (!(gap2[k] < *best2)) continue;
                count = sqffd__fit_cell(s->grid, node->child[k] / columns, node->child[k] % columns, cell);
                for (t = 0; t < count; ++t) {
                    size_t corners[3];
                    double tw[3], d;
                    corners[0] = cell[t][0]; corners[1] = cell[t][1]; corners[2] = cell[t][2];
                    d = sqffd__fit_corner_triangle(s->x, corners, q, tw);
                    if (d < *best2) {
                        *best2 = d;
                        memcpy(tri, corners, sizeof corners);
                        memcpy(w, tw, sizeof tw);
                    }
                }
            }
        } else { /* the children within reach, farthest first (so the nearest is visited next) */
            int first = top;
            for (k = 0; k < node->count; ++k)
                if (gap2[k] < *best2) sqffd__fit_bvh_push(stack, gaps, &top, first, gap2[k], node->child[k]);
        }
    }
}

/* The answer for data point i at q once its nearest vertex v is known: in a
   pass between, its last triangle while that is still v's and the closest
   point stays inside it; else the fan search and the walk. */
static void sqffd__fit_answer(sqffd__fit_search *s, size_t i, size_t v, const double q[3], double *dist2, size_t tri[3],
                              double w[3])
{
    size_t k;
    double d;
    if (s->triangle && s->triangle[i][0] == v && !s->exact) {
        for (k = 0; k < 3; ++k) tri[k] = s->triangle[i][k];
        d = sqffd__fit_corner_triangle(s->x, tri, q, w);
        if (w[0] != 0.0 && w[1] > 0.0 && w[2] > 0.0) { /* (else the full search would walk on) */
            *dist2 = d;
            return;
        }
    }
    d = sqffd__fit_fan_closest(s->x, s->rings, v, q, tri, w);
    if (s->triangle)
        for (k = 0; k < 3; ++k) s->triangle[i][k] = (uint32_t)tri[k];
    *dist2 = sqffd__fit_walk(s->x, s->rings, q, d, tri, w);
}

/* The closest point on the mesh to data point i at q ("the error"): squared
   distance, triangle and barycentric weights; exact in an exact pass (see
   sqffd__fit_certify), else the local answer described above. In a fit
   (matched set) the triangle the point was matched to in the last pass
   stands where it is closer: each step's bound then holds point by point,
   so the energy cannot rise (the local answer may miss it), and it gives
   the exact search a close first bound. */
static sqffd_result sqffd__fit_closest(sqffd__fit_search *s, size_t i, const double q[3], double *dist2, size_t tri[3],
                                       double w[3])
{
    size_t v;
    sqffd_result res;
    if (s->final && s->matched[i][0] != UINT32_MAX) {
        tri[0] = s->matched[i][0]; tri[1] = s->matched[i][1]; tri[2] = s->matched[i][2];
        *dist2 = sqffd__fit_corner_triangle(s->x, tri, q, w);
        sqffd__fit_certify(s, q, dist2, tri, w);
        return SQFFD_OK;
    }
    res = sqffd__fit_nearest_vertex(s, i, q, &v);
    if (res != SQFFD_OK) return res;
    sqffd__fit_answer(s, i, v, q, dist2, tri, w);
    if (s->matched && s->matched[i][0] != UINT32_MAX &&
        !(s->matched[i][0] == tri[0] && s->matched[i][1] == tri[1] && s->matched[i][2] == tri[2])) {
        size_t t[3];
        double wm[3], dm;
        t[0] = s->matched[i][0]; t[1] = s->matched[i][1]; t[2] = s->matched[i][2];
        dm = sqffd__fit_corner_triangle(s->x, t, q, wm);
        if (dm < *dist2) {
            *dist2 = dm;
            memcpy(tri, t, sizeof t);
            memcpy(w, wm, sizeof wm);
        }
    }
    if (s->exact) sqffd__fit_certify(s, q, dist2, tri, w);
    if (s->matched) {
        s->matched[i][0] = (uint32_t)tri[0]; s->matched[i][1] = (uint32_t)tri[1]; s->matched[i][2] = (uint32_t)tri[2];
    }
    return res;
}

/* The mesh vertices moved: the trees over them are measured again when asked. */
static void sqffd__fit_moved(sqffd__fit_search *s)
{
    s->bvh_current = 0;
    s->tree_current = 0;
}

/* ---- statistics ---------------------------------------------------------- */

/* Diagonal of the points' bounding box; NON_FINITE for NaN/Inf. */
static sqffd_result sqffd__fit_diagonal(const sqffd_points *points, double *diagonal)
{
    double lo[3], hi[3], d2 = 0.0, p[3];
    size_t i;
    int a;
    for (a = 0; a < 3; ++a) { lo[a] = HUGE_VAL; hi[a] = -HUGE_VAL; }
    for (i = 0; i < points->count; ++i) {
        sqffd__points_get(points, i, p);
        if (!sqffd__finite3(p)) return SQFFD_ERROR_NON_FINITE;
        for (a = 0; a < 3; ++a) {
            if (p[a] < lo[a]) lo[a] = p[a];
            if (p[a] > hi[a]) hi[a] = p[a];
        }
    }
    for (a = 0; a < 3; ++a) d2 += (hi[a] - lo[a]) * (hi[a] - lo[a]);
    *diagonal = sqrt(d2);
    return isfinite(*diagonal) ? SQFFD_OK : SQFFD_ERROR_NON_FINITE;
}

static void sqffd__fit_stats(double sum, double sum2, double max, size_t n, double diagonal, sqffd_distance_stats *s)
{
    s->rms = n ? sqrt(sum2 / (double)n) : 0.0;
    s->mean = n ? sum / (double)n : 0.0;
    s->max = max;
    s->diagonal = diagonal;
    s->rms_relative = diagonal > 0.0 ? s->rms / diagonal : 0.0;
    s->mean_relative = diagonal > 0.0 ? s->mean / diagonal : 0.0;
    s->max_relative = diagonal > 0.0 ? s->max / diagonal : 0.0;
}

/* A search over the mesh with vertices x on the grid (its ring table and
   tree workspace given, the tree built on first need), without a warm start. */
static void sqffd__fit_search_init(sqffd__fit_search *s, const double *x, const int grid[2], const sqffd__fit_ring *rings,
                                   void *tree_ws, size_t tree_size, sqffd__fit_bvh *bvh)
{
    memset(s, 0, sizeof *s);
    s->x = x;
    s->count = sqffd__fit_grid_count(grid);
    s->rings = rings;
    s->exact = 1;
    s->tree_ws = tree_ws;
    s->tree_size = tree_size;
    s->bvh = bvh;
    s->grid[0] = grid[0];
    s->grid[1] = grid[1];
    sqffd__fit_bvh_build(grid, bvh->nodes); /* (its boxes are measured when an exact pass needs them) */
}

/* ---- the order of the passes ----------------------------------------------
   A pass visits the data points in Morton (Z-curve) order of their
   coordinates: consecutive points then lie close together, and so do their
   closest-point searches through the mesh and its trees (an exact pass over
   6,000 points sampled in random order on a scan: 15-30% faster). The keys
   are 10 bits an axis over the points' bounding box, sorted by a radix sort
   of 6 digits of 5 bits (stable: equal keys keep their points' order).
   Only up to SQFFD__FIT_ORDER_MAX points: past the caches, visiting the
   points' arrays out of their order costs more than it saves (10^6 points:
   an iteration 4x slower). */
#define SQFFD__FIT_ORDER_MAX 16384
static uint32_t sqffd__fit_spread(uint32_t v) /* the low 10 bits of v to every third bit */
{
    v &= 0x3ffu;
    v = (v | (v << 16)) & 0x030000ffu;
    v = (v | (v << 8)) & 0x0300f00fu;
    v = (v | (v << 4)) & 0x030c30c3u;
    return (v | (v << 2)) & 0x09249249u;
}

/* order (n) <- the points' indices in Morton order; key, spare_key and
   spare_order (n each) are scratch. Points must be finite (checked before). */
static void sqffd__fit_order(const sqffd_points *points, uint32_t *order, uint32_t *key, uint32_t *spare_key,
                             uint32_t *spare_order)
{
    size_t n = points->count, i;
    double box[2][3], scale[3], p[3];
    uint32_t count[32], *from_key = key, *from_order = order, *to_key = spare_key, *to_order = spare_order, *swap;
    int c, digit;
    for (i = 0; i < n; ++i) order[i] = (uint32_t)i;
    sqffd__kd_bounds(points, order, 0, n, box);
    for (c = 0; c < 3; ++c) scale[c] = box[1][c] > box[0][c] ? 1023.0 / (box[1][c] - box[0][c]) : 0.0;
    for (i = 0; i < n; ++i) {
        uint32_t cell[3];
        sqffd__points_get(points, i, p);
        for (c = 0; c < 3; ++c) {
            double f = (p[c] - box[0][c]) * scale[c];
            cell[c] = f < 1023.0 ? (uint32_t)f : 1023u; /* (the box's top face rounds past 1023) */
        }
        key[i] = sqffd__fit_spread(cell[0]) | sqffd__fit_spread(cell[1]) << 1 | sqffd__fit_spread(cell[2]) << 2;
    }
    for (digit = 0; digit < 6; ++digit) { /* (an even number of passes: the result ends in order) */
        uint32_t sum = 0, shift = 5u * (uint32_t)digit;
        memset(count, 0, sizeof count);
        for (i = 0; i < n; ++i) ++count[(from_key[i] >> shift) & 31u];
        for (c = 0; c < 32; ++c) {
            uint32_t k = count[c];
            count[c] = sum;
            sum += k;
        }
        for (i = 0; i < n; ++i) {
            uint32_t at = count[(from_key[i] >> shift) & 31u]++;
            to_key[at] = from_key[i];
            to_order[at] = from_order[i];
        }
        swap = from_key; from_key = to_key; to_key = swap;
        swap = from_order; from_order = to_order; to_order = swap;
    }
}

/* Step 1's accumulators of a pass. */
typedef struct sqffd__fit_step1 {
    double *sums;    /* M x 3: summed weighted displacements per model point (NULL: measure only) */
    double *weights; /* M: the summed weights */
    double *planes;  /* M x 6 (may be NULL): the summed weights times n n^T, n the direction to the closest point */
    double nu2;      /* robust mode's Welsch scale squared (0: plain squares) */
    double energy;   /* out: the sum of rho(d) over the points */
} sqffd__fit_step1;

/* planes (M x 6) += robust w_k n n^T at the corners of a point's closest
   triangle (a, b, e; barycentric weights w), n the unit direction of its
   displacement (dx, dy, dz), or the triangle's normal where that is 0. */
static void sqffd__fit_planes(double *planes, const size_t tri[3], const double w[3], double robust, double dx,
                              double dy, double dz, const double *a, const double *b, const double *e)
{
    double n[3] = {dx, dy, dz}, len2 = dx * dx + dy * dy + dz * dz, outer[6];
    int k;
    if (!(len2 > 0.0)) {
        double u[3], v[3];
        sqffd__sub3(b, a, u);
        sqffd__sub3(e, a, v);
        sqffd__cross3(u, v, n);
        len2 = sqffd__dot3(n, n);
        if (!(len2 > 0.0)) return;
    }
    outer[0] = n[0] * n[0] / len2; outer[1] = n[0] * n[1] / len2; outer[2] = n[0] * n[2] / len2;
    outer[3] = n[1] * n[1] / len2; outer[4] = n[1] * n[2] / len2; outer[5] = n[2] * n[2] / len2;
    for (k = 0; k < 3; ++k) {
        double *p = planes + 6 * tri[k], wk = robust * w[k];
        int c;
        for (c = 0; c < 6; ++c) p[c] += wk * outer[c];
    }
}

/* One pass over the data against the search's mesh: each point's distance
   to the mesh (the error) into the statistics and per_point (may be NULL).
   With step1 (may be NULL) the pass also sums the data term of the energy
   and, with its sums, spreads each point's displacement from its closest
   mesh point over that triangle's vertices with the barycentric weights
   (times the point's Welsch weight in robust mode). Points go in batches:
   the searches of a batch first, then their sums (each loop short enough
   for the processor to overlap one point's search with the next). */
#define SQFFD__FIT_BATCH 8

static sqffd_result sqffd__fit_pass(const sqffd_points *points, sqffd__fit_search *search, double diagonal,
                                    double *per_point, sqffd__fit_step1 *step1, sqffd_distance_stats *stats)
{
    const double *x = search->x;
    double sum = 0.0, sum2 = 0.0, max = 0.0, energy = 0.0, nu2 = step1 ? step1->nu2 : 0.0;
    double *sums = step1 ? step1->sums : NULL;
    size_t first, j, n = points->count;
    int k;
    for (first = 0; first < n; first += SQFFD__FIT_BATCH) {
        size_t count = n - first < SQFFD__FIT_BATCH ? n - first : SQFFD__FIT_BATCH, tri[SQFFD__FIT_BATCH][3];
        size_t index[SQFFD__FIT_BATCH];
        double w[SQFFD__FIT_BATCH][3], dist2[SQFFD__FIT_BATCH], data[SQFFD__FIT_BATCH][3];
        for (j = 0; j < count; ++j) {
            sqffd_result res;
            index[j] = search->order ? search->order[first + j] : first + j;
            sqffd__points_get(points, index[j], data[j]);
            res = sqffd__fit_closest(search, index[j], data[j], dist2 + j, tri[j], w[j]);
            if (res != SQFFD_OK) return res;
        }
        for (j = 0; j < count; ++j) {
            const double *q = data[j], *wj = w[j];
            double d = sqrt(dist2[j]), robust = nu2 > 0.0 ? exp(-dist2[j] / nu2) : 1.0;
            energy += nu2 > 0.0 ? nu2 * (1.0 - robust) : dist2[j];
            sum += d; sum2 += dist2[j];
            if (d > max) max = d;
            if (per_point) per_point[index[j]] = d;
            if (sums) { /* (scalars, not a small array: a store-to-load stall per point otherwise) */
                const double *a = x + 3 * tri[j][0], *b = x + 3 * tri[j][1], *e = x + 3 * tri[j][2];
                double dx = q[0] - (wj[0] * a[0] + wj[1] * b[0] + wj[2] * e[0]);
                double dy = q[1] - (wj[0] * a[1] + wj[1] * b[1] + wj[2] * e[1]);
                double dz = q[2] - (wj[0] * a[2] + wj[1] * b[2] + wj[2] * e[2]);
                for (k = 0; k < 3; ++k) {
                    double *s = sums + 3 * tri[j][k], wk = robust * wj[k];
                    s[0] += wk * dx; s[1] += wk * dy; s[2] += wk * dz;
                    step1->weights[tri[j][k]] += wk;
                }
                if (step1->planes) sqffd__fit_planes(step1->planes, tri[j], wj, robust, dx, dy, dz, a, b, e);
            }
        }
    }
    if (step1) step1->energy = energy;
    sqffd__fit_stats(sum, sum2, max, n, diagonal, stats);
    return isfinite(sum2) ? SQFFD_OK : SQFFD_ERROR_NON_FINITE; /* (model and data too far apart to square) */
}

/* ---- model geometry ------------------------------------------------------ */

SQFFD_DEF sqffd_result sqffd_model_point(const sqffd_model *model, double eta, double omega, double point[3])
{
    double p[3];
    sqffd_result r = model ? sqffd_sq_point(&model->sq, eta, omega, p, NULL) : SQFFD_ERROR_INVALID_ARGUMENT;
    return r == SQFFD_OK ? sqffd_ffd_deform(&model->ffd, p, point) : r;
}

/* The superquadric's points on the grid into x, each as sqffd_sq_point gives
   it (to the bit) at the grid's angles, but with each row's and each
   column's powers taken once: the columns' are parked in the last row's
   slots (its x and y), which rows 0 ... rows - 2 read and the last row
   reads last, each slot before it is overwritten. */
static void sqffd__fit_sq_grid(const sqffd_superquadric *sq, const int grid[2], double *x)
{
    size_t rows = (size_t)grid[0], cols = (size_t)grid[1], i, j, last = 3 * (rows - 1) * cols;
    double s[3], eta;
    sqffd__fit_arc arc;
    sqffd__fit_arc_start(&arc, sq->size[0], sq->size[1], sq->shape[1], -SQFFD__FIT_PI, SQFFD__FIT_PI);
    for (j = 0; j < cols; ++j) {
        double omega = j == 0 ? -SQFFD__FIT_PI : sqffd__fit_arc_angle(&arc, (double)j / (double)cols);
        x[last + 3 * j] = sqffd__sq_spow(cos(omega), sq->shape[1]);
        x[last + 3 * j + 1] = sqffd__sq_spow(sin(omega), sq->shape[1]);
    }
    sqffd__fit_arc_start(&arc, 0.5 * (sq->size[0] + sq->size[1]), sq->size[2], sq->shape[0], -0.5 * SQFFD__FIT_PI,
                         0.5 * SQFFD__FIT_PI);
    for (i = 0; i < rows; ++i) {
        double ce;
        eta = sqffd__fit_arc_angle(&arc, (double)(i + 1) / (double)(rows + 1));
        ce = sqffd__sq_spow(cos(eta), sq->shape[0]);
        s[2] = sq->size[2] * sqffd__sq_spow(sin(eta), sq->shape[0]);
        for (j = 0; j < cols; ++j) {
            s[0] = sq->size[0] * ce * x[last + 3 * j];
            s[1] = sq->size[1] * ce * x[last + 3 * j + 1];
            sqffd__sq_place(sq, s, x + 3 * (i * cols + j));
        }
    }
    sqffd__sq_point(sq, -0.5 * SQFFD__FIT_PI, 0.0, x + 3 * rows * cols, NULL);
    sqffd__sq_point(sq, 0.5 * SQFFD__FIT_PI, 0.0, x + 3 * (rows * cols + 1), NULL);
}

/* The model's surface points on the grid into x; 0 when one is not finite
   (a model too extreme to compute with). */
static int sqffd__fit_surface(const sqffd_model *model, const int grid[2], double *x)
{
    size_t v, count = sqffd__fit_grid_count(grid);
    int finite = 1;
    sqffd__fit_sq_grid(&model->sq, grid, x);
    for (v = 0; v < count; ++v) {
        sqffd__ffd_deform(&model->ffd, x + 3 * v, x + 3 * v);
        finite &= sqffd__finite3(x + 3 * v);
    }
    return finite;
}

SQFFD_DEF sqffd_result sqffd_model_validate(const sqffd_model *model)
{
    sqffd_result r;
    if (!model) return SQFFD_ERROR_INVALID_ARGUMENT;
    r = sqffd_sq_validate(&model->sq);
    if (r == SQFFD_OK) r = sqffd_ffd_validate(&model->ffd);
    if (r == SQFFD_OK && sqffd__fit_grid_check(model->grid) != SQFFD_OK) r = SQFFD_ERROR_INVALID_MODEL;
    return r;
}

/* ---- save and load: the byte form documented at sqffd_model_save ---------- */

#define SQFFD__SAVE_VERSION 1u
#define SQFFD__SAVE_HEADER 284u /* bytes before the control points */

static const unsigned char sqffd__save_magic[8] = {'S', 'Q', 'F', 'F', 'D', 'M', 'D', 'L'};

/* CRC-32 with the reflected IEEE polynomial 0xEDB88320, four bits a step:
   entry k is the register after shifting k through four plain steps. */
static uint32_t sqffd__crc32(const unsigned char *p, size_t n)
{
    static const uint32_t nibble[16] = {
        0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu, 0x76DC4190u, 0x6B6B51F4u, 0x4DB26158u, 0x5005713Cu,
        0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu, 0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu};
    uint32_t crc = 0xFFFFFFFFu;
    size_t i;
    for (i = 0; i < n; ++i) {
        crc ^= p[i];
        crc = (crc >> 4) ^ nibble[crc & 15u];
        crc = (crc >> 4) ^ nibble[crc & 15u];
    }
    return ~crc;
}

static void sqffd__put_u32(unsigned char *p, uint32_t v)
{
    int i;
    for (i = 0; i < 4; ++i) p[i] = (unsigned char)(v >> (8 * i));
}

static uint32_t sqffd__get_u32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* Doubles by their IEEE bits, least significant byte first, whatever the host. */
static unsigned char *sqffd__put_f64s(unsigned char *p, const double *v, size_t n)
{
    size_t k;
    int i;
    for (k = 0; k < n; ++k) {
        uint64_t bits;
        memcpy(&bits, v + k, 8);
        for (i = 0; i < 8; ++i) *p++ = (unsigned char)(bits >> (8 * i));
    }
    return p;
}

static const unsigned char *sqffd__get_f64s(const unsigned char *p, double *v, size_t n)
{
    size_t k;
    int i;
    for (k = 0; k < n; ++k) {
        uint64_t bits = 0;
        for (i = 0; i < 8; ++i) bits |= (uint64_t)*p++ << (8 * i);
        memcpy(v + k, &bits, 8);
    }
    return p;
}

static size_t sqffd__save_size(const int dims[3])
{
    return SQFFD__SAVE_HEADER + 24u * (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2] + 4u;
}

SQFFD_DEF sqffd_result sqffd_model_save_size(const sqffd_model *model, size_t *size)
{
    sqffd_result r;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    r = sqffd_model_validate(model);
    if (r == SQFFD_OK) *size = sqffd__save_size(model->ffd.dims);
    return r;
}

SQFFD_DEF sqffd_result sqffd_model_save(const sqffd_model *model, void *bytes, size_t capacity)
{
    unsigned char *out = (unsigned char *)bytes, *p;
    const sqffd_superquadric *sq;
    size_t size;
    int i;
    sqffd_result r;
    if (!model || !bytes) return SQFFD_ERROR_INVALID_ARGUMENT;
    r = sqffd_model_validate(model);
    if (r != SQFFD_OK) return r;
    size = sqffd__save_size(model->ffd.dims);
    if (capacity < size) return SQFFD_ERROR_OUTPUT_TOO_SMALL;
    sq = &model->sq;
    memcpy(out, sqffd__save_magic, 8);
    sqffd__put_u32(out + 8, SQFFD__SAVE_VERSION);
    sqffd__put_u32(out + 12, (uint32_t)size);
    p = sqffd__put_f64s(out + 16, sq->size, 3);
    p = sqffd__put_f64s(p, sq->shape, 2);
    p = sqffd__put_f64s(p, sq->taper, 2);
    p = sqffd__put_f64s(p, sq->rotation, 9);
    p = sqffd__put_f64s(p, sq->center, 3);
    for (i = 0; i < 3; ++i, p += 4) sqffd__put_u32(p, (uint32_t)model->ffd.dims[i]);
    p = sqffd__put_f64s(p, model->ffd.origin, 3);
    p = sqffd__put_f64s(p, model->ffd.edges, 9);
    for (i = 0; i < 2; ++i, p += 4) sqffd__put_u32(p, (uint32_t)model->grid[i]);
    p = sqffd__put_f64s(p, &model->ffd.control[0][0], (size - SQFFD__SAVE_HEADER - 4u) / 8u);
    sqffd__put_u32(p, sqffd__crc32(out, size - 4u));
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_model_load(sqffd_model *model, const void *bytes, size_t size)
{
    const unsigned char *in = (const unsigned char *)bytes, *p;
    sqffd_superquadric sq;
    uint32_t dims[3];
    int grid[2], i, magic = 1;
    double box[12], inverse[9], v;
    size_t values, k;
    if (!model || !bytes) return SQFFD_ERROR_INVALID_ARGUMENT;
    for (i = 0; i < 8 && (size_t)i < size; ++i) magic &= in[i] == sqffd__save_magic[i];
    if (size < SQFFD__SAVE_HEADER + 4u || !magic || sqffd__get_u32(in + 8) != SQFFD__SAVE_VERSION ||
        sqffd__get_u32(in + 12) != size || sqffd__get_u32(in + size - 4u) != sqffd__crc32(in, size - 4u))
        return SQFFD_ERROR_BAD_FORMAT;
    for (i = 0; i < 3; ++i) /* the length must match the lattice it claims */
        if ((dims[i] = sqffd__get_u32(in + 168 + 4 * i)) < 2 || dims[i] > 0xFFFFu) return SQFFD_ERROR_BAD_FORMAT;
    values = 3u * (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2];
    if (size != SQFFD__SAVE_HEADER + 8u * values + 4u) return SQFFD_ERROR_BAD_FORMAT;
    for (i = 0; i < 3; ++i)
        if (dims[i] > SQFFD_MAX_LATTICE) return SQFFD_ERROR_TOO_LARGE;
    /* everything is checked before *model is written (no model-sized copy on the stack) */
    p = sqffd__get_f64s(in + 16, sq.size, 3);
    p = sqffd__get_f64s(p, sq.shape, 2);
    p = sqffd__get_f64s(p, sq.taper, 2);
    p = sqffd__get_f64s(p, sq.rotation, 9);
    sqffd__get_f64s(p, sq.center, 3);
    sqffd__get_f64s(in + 180, box, 12);
    for (i = 0; i < 2; ++i) {
        uint32_t g = sqffd__get_u32(in + 276 + 4 * i);
        grid[i] = g > SQFFD__FIT_MAX_GRID ? 0 : (int)g;
    }
    if (sqffd_sq_validate(&sq) != SQFFD_OK || sqffd__fit_grid_check(grid) != SQFFD_OK || !sqffd__bounded3(box) ||
        !sqffd__bounded3(box + 3) || !sqffd__bounded3(box + 6) || !sqffd__bounded3(box + 9) ||
        !sqffd__ffd_box_inverse(box + 3, inverse) || !sqffd__ffd_inverse_holds(box + 3, inverse))
        return SQFFD_ERROR_INVALID_MODEL;
    for (k = 0, p = in + SQFFD__SAVE_HEADER; k < values; ++k) {
        p = sqffd__get_f64s(p, &v, 1);
        if (!(fabs(v) <= SQFFD__MAX_MAGNITUDE)) return SQFFD_ERROR_INVALID_MODEL;
    }
    memset(model, 0, sizeof *model);
    model->sq = sq;
    for (i = 0; i < 3; ++i) model->ffd.dims[i] = (int)dims[i];
    memcpy(model->ffd.origin, box, sizeof model->ffd.origin);
    memcpy(model->ffd.edges, box + 3, sizeof model->ffd.edges);
    memcpy(model->ffd.inverse, inverse, sizeof inverse);
    sqffd__get_f64s(in + SQFFD__SAVE_HEADER, &model->ffd.control[0][0], values);
    model->grid[0] = grid[0];
    model->grid[1] = grid[1];
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_model_mesh_size(int n_eta, int n_omega, size_t *vertex_count, size_t *triangle_count)
{
    int grid[2];
    sqffd_result r;
    grid[0] = n_eta; grid[1] = n_omega;
    r = sqffd__fit_grid_check(grid);
    if (r != SQFFD_OK) return r;
    if (vertex_count) *vertex_count = sqffd__fit_grid_count(grid);
    if (triangle_count) *triangle_count = 2 * (size_t)n_eta * (size_t)n_omega;
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_model_mesh(const sqffd_model *model, int n_eta, int n_omega, double *vertices, uint32_t *triangles)
{
    int grid[2];
    sqffd_result r;
    if (!model) return SQFFD_ERROR_INVALID_ARGUMENT;
    r = sqffd_model_validate(model);
    if (r != SQFFD_OK) return r;
    grid[0] = n_eta; grid[1] = n_omega;
    r = sqffd__fit_grid_check(grid);
    if (r != SQFFD_OK) return r;
    if (vertices && !sqffd__fit_surface(model, grid, vertices)) return SQFFD_ERROR_NON_FINITE;
    if (!triangles) return SQFFD_OK;
    sqffd__fit_triangles(grid, (uint32_t (*)[3])triangles);
    return SQFFD_OK;
}

/* ---- distances ----------------------------------------------------------- */

/* The mesh vertices, the ring table (forward only) and a tree over n_tree points. */
typedef struct sqffd__fit_mesh_work {
    double *x;
    sqffd__fit_ring *rings;
    sqffd__fit_bvh bvh;
    void *tree_ws;
    size_t tree_size;
} sqffd__fit_mesh_work;

static void sqffd__fit_distances_layout(sqffd__arena *a, size_t n_tree, const int grid[2], int reverse, sqffd__fit_mesh_work *w)
{
    size_t vertices = sqffd__fit_grid_count(grid);
    w->x = (double *)sqffd__arena_take(a, vertices, 3 * sizeof(double));
    w->rings = reverse ? NULL : (sqffd__fit_ring *)sqffd__arena_take(a, vertices, sizeof(sqffd__fit_ring));
    if (!reverse) sqffd__fit_bvh_layout(a, grid, &w->bvh);
    if (sqffd_kdtree_workspace_size(n_tree, &w->tree_size) != SQFFD_OK) sqffd__arena_too_large(a);
    w->tree_ws = sqffd__arena_take(a, w->tree_size, 1);
}

static sqffd_result sqffd__fit_distances_size(size_t n, const sqffd_model *model, int reverse, size_t *size)
{
    sqffd__arena a;
    sqffd__fit_mesh_work w;
    sqffd_result r;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    if (!model || n == 0) return SQFFD_ERROR_INVALID_ARGUMENT;
    r = sqffd_model_validate(model);
    if (r != SQFFD_OK) return r;
    sqffd__arena_measure(&a);
    sqffd__fit_distances_layout(&a, reverse ? n : sqffd__fit_grid_count(model->grid), model->grid, reverse, &w);
    return sqffd__arena_size(&a, size);
}

SQFFD_DEF sqffd_result sqffd_model_distances_workspace_size(size_t n, const sqffd_model *model, size_t *size)
{
    return sqffd__fit_distances_size(n, model, 0, size);
}

SQFFD_DEF sqffd_result sqffd_model_reverse_distances_workspace_size(size_t n, const sqffd_model *model, size_t *size)
{
    return sqffd__fit_distances_size(n, model, 1, size);
}

/* Shared by both directions: validates, lays out and samples the model mesh;
   the tree's workspace is for the mesh vertices (forward) or the data
   (reverse). */
static sqffd_result sqffd__fit_distances_setup(const sqffd_model *model, const sqffd_points *points, int reverse,
                                              void *workspace, size_t workspace_size, sqffd__fit_mesh_work *w,
                                              double *diagonal)
{
    sqffd__arena a;
    size_t m, n = points->count;
    sqffd_result r = sqffd__points_check(points);
    if (r == SQFFD_OK && !model) r = SQFFD_ERROR_INVALID_ARGUMENT;
    if (r == SQFFD_OK) r = sqffd_model_validate(model);
    if (r != SQFFD_OK) return r;
    if (n == 0) return SQFFD_ERROR_TOO_FEW_POINTS;
    r = sqffd__fit_diagonal(points, diagonal);
    if (r != SQFFD_OK) return r;
    m = sqffd__fit_grid_count(model->grid);
    sqffd__arena_init(&a, workspace, workspace_size);
    sqffd__fit_distances_layout(&a, reverse ? n : m, model->grid, reverse, w);
    if (a.overflow) return sqffd__arena_error(&a);
    sqffd__fit_surface(model, model->grid, w->x);
    if (!reverse) sqffd__fit_rings(model->grid, w->rings);
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_model_distances_view(const sqffd_model *model, sqffd_points points, double *per_point,
                                                  sqffd_distance_stats *stats, void *workspace, size_t workspace_size)
{
    sqffd__fit_search search;
    sqffd__fit_mesh_work w;
    sqffd_distance_stats s;
    double diagonal = 0.0;
    sqffd_result r = sqffd__fit_distances_setup(model, &points, 0, workspace, workspace_size, &w, &diagonal);
    if (r != SQFFD_OK) return r;
    sqffd__fit_search_init(&search, w.x, model->grid, w.rings, w.tree_ws, w.tree_size, &w.bvh);
    r = sqffd__fit_pass(&points, &search, diagonal, per_point, NULL, &s);
    if (r == SQFFD_OK && stats) *stats = s;
    return r;
}

SQFFD_DEF sqffd_result sqffd_model_distances(const sqffd_model *model, const double *points, size_t n,
                                             double *per_point, sqffd_distance_stats *stats,
                                             void *workspace, size_t workspace_size)
{
    return sqffd_model_distances_view(model, sqffd_points_packed(points, n), per_point, stats, workspace,
                                      workspace_size);
}

SQFFD_DEF sqffd_result sqffd_model_reverse_distances_view(const sqffd_model *model, sqffd_points points,
                                                          double *per_vertex, sqffd_distance_stats *stats,
                                                          void *workspace, size_t workspace_size)
{
    sqffd_kdtree tree;
    sqffd__fit_mesh_work w;
    double diagonal = 0.0, sum = 0.0, sum2 = 0.0, max = 0.0;
    size_t v, m;
    sqffd_result r = sqffd__fit_distances_setup(model, &points, 1, workspace, workspace_size, &w, &diagonal);
    if (r == SQFFD_OK) r = sqffd_kdtree_build_view(&tree, points, w.tree_ws, w.tree_size);
    if (r != SQFFD_OK) return r;
    m = sqffd__fit_grid_count(model->grid);
    for (v = 0; v < m; ++v) {
        double d2, d;
        size_t nearest;
        if (!sqffd__finite3(w.x + 3 * v)) return SQFFD_ERROR_NON_FINITE;
        sqffd__kd_query(&tree, w.x + 3 * v, HUGE_VAL, 0, &nearest, &d2, 1);
        d = sqrt(d2);
        sum += d; sum2 += d2;
        if (d > max) max = d;
        if (per_vertex) per_vertex[v] = d;
    }
    if (stats) sqffd__fit_stats(sum, sum2, max, m, diagonal, stats);
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_model_reverse_distances(const sqffd_model *model, const double *points, size_t n,
                                                     double *per_vertex, sqffd_distance_stats *stats,
                                                     void *workspace, size_t workspace_size)
{
    return sqffd_model_reverse_distances_view(model, sqffd_points_packed(points, n), per_vertex, stats, workspace,
                                              workspace_size);
}

/* ---- options and the box ------------------------------------------------- */

SQFFD_DEF sqffd_fit_options sqffd_fit_options_default(void)
{
    sqffd_fit_options o;
    memset(&o, 0, sizeof o);
    o.sq = sqffd_sq_fit_options_default();
    /* Stage 1 stops where the winner has converged on its 384-point
       subsample: a last run refines a cost that is no distance, which the
       FFD stage outweighs, at a cost (bench/NOTES.md). */
    o.sq.final_points = SQFFD__SQ_POLISH;
    o.lattice[0] = o.lattice[1] = o.lattice[2] = 5;
    o.box_margin = 0.1;
    o.grid[0] = 32;
    o.grid[1] = 64;
    o.alpha = 1e-6;
    o.tether = 0.0;
    o.regularization = SQFFD_REG_DISPLACEMENT;
    o.solver = SQFFD_SOLVER_CHOLESKY;
    o.max_iterations = 33;
    o.coarse_iterations = 25;
    o.tolerance = 1e-4;
    o.model_to_data = 0.02;
    o.min_jacobian = 0.02;
    o.sq_max_points = 20000;
    o.ffd_max_points = 200000;
    o.progress = NULL;
    o.progress_user = NULL;
    return o;
}

/* The options the FFD stage reads (the lattice and grid are checked where
   they are used: sqffd_fit takes them from the options, sqffd_fit_ffd from
   the model). */
static sqffd_result sqffd__fit_check_options(const sqffd_fit_options *o)
{
    if (!(o->alpha >= 0.0 && o->alpha <= SQFFD_FIT_ALPHA_MAX)) return SQFFD_ERROR_INVALID_ARGUMENT; /* (NaN too) */
    if (!(o->tether >= 0.0) || !isfinite(o->tether)) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (!(o->model_to_data >= 0.0 && o->model_to_data <= SQFFD_FIT_MODEL_TO_DATA_MAX)) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (!(o->tolerance >= 0.0) || !isfinite(o->tolerance)) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (!(o->min_jacobian <= 1.0)) return SQFFD_ERROR_INVALID_ARGUMENT; /* (NaN too) */
    if (o->max_iterations < 0 || o->coarse_iterations < 0) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (o->regularization != SQFFD_REG_DISPLACEMENT && o->regularization != SQFFD_REG_POSITION)
        return SQFFD_ERROR_INVALID_ARGUMENT;
    if (o->solver != SQFFD_SOLVER_CHOLESKY && o->solver != SQFFD_SOLVER_SVD) return SQFFD_ERROR_INVALID_ARGUMENT;
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_model_init(sqffd_model *model, const sqffd_superquadric *sq, const sqffd_fit_options *options)
{
    sqffd_fit_options defaults = sqffd_fit_options_default();
    sqffd_superquadric shape;
    double half[3], origin[3], edges[9], m;
    int a, r;
    sqffd_result res;
    if (!options) options = &defaults;
    if (!model || !sq || !sqffd__ffd_dims_valid(options->lattice)) return SQFFD_ERROR_INVALID_ARGUMENT;
    res = sqffd_sq_validate(sq);
    if (res == SQFFD_OK) res = sqffd__fit_grid_check(options->grid);
    if (res != SQFFD_OK) return res;
    m = options->box_margin;
    if (!(m >= 0.0) || !isfinite(m)) return SQFFD_ERROR_INVALID_ARGUMENT;
    /* the tapered shape lies within |X| <= a1 (1 + |Kx|), |Y| <= a2 (1 + |Ky|), |Z| <= a3 */
    half[0] = sq->size[0] * (1.0 + fabs(sq->taper[0])) * (1.0 + m);
    half[1] = sq->size[1] * (1.0 + fabs(sq->taper[1])) * (1.0 + m);
    half[2] = sq->size[2] * (1.0 + m);
    memcpy(origin, sq->center, sizeof origin);
    for (a = 0; a < 3; ++a)     /* edge a = 2 half_a (column a of the rotation) */
        for (r = 0; r < 3; ++r) {
            edges[3 * a + r] = 2.0 * half[a] * sq->rotation[3 * r + a];
            origin[r] -= half[a] * sq->rotation[3 * r + a];
        }
    shape = *sq; /* sq may be model->sq */
    memset(model, 0, sizeof *model);
    model->sq = shape;
    model->grid[0] = options->grid[0];
    model->grid[1] = options->grid[1];
    return sqffd_ffd_init(&model->ffd, options->lattice, origin, edges);
}

/* ---- the least-squares problem of step 2 -----------------------------------
   THE ENERGY the FFD stage decreases (x_v(P) = (B P)_v, the M model points;
   d_i(P) the error of data point i, n data points, L control points):
     E(P) = 1/n sum_i rho(d_i)                      data -> model
          + alpha / L ||D (P - P0)||^2              lattice springs (or ||D P||^2)
          + tether / M sum_v |x_v(P) - x_v(P0)|^2   model points held to the superquadric
          + model_to_data / H sum_h |x_h - nearest data point|^2   model -> data
   (over the H holding model points, sqffd__fit_holds, and at most
   SQFFD__FIT_DATA_MAX of the data points, an even subsample.)
   rho(d) = d^2, or with `robust` the Welsch nu^2 (1 - exp(-d^2 / nu^2)).
   The model -> data term (default weight 0.02) keeps the parts of the model
   that no data reach from drifting off (the data -> model term does not see
   them); the tether (default 0) would hold them to the superquadric.
   Each iteration is a majorisation-minimisation step: with each data point's
   closest triangle and barycentric weights w held, Jensen's inequality
   bounds its squared distance by sum_k w_k |x_k - (x_k + displacement)|^2,
   and with each model point's nearest data point held, the model -> data
   term by its squared distance to that point, so E is majorised by a
   weighted least-squares problem in the model points,
     sum_v W_v |x_v(P) - y_v|^2 + springs + tether,
   (W_v: the data points' summed weights at v, plus the model -> data weight; y_v: their
   weighted mean target; robust mode multiplies each point's weights by
   exp(-d^2 / nu^2)), whose minimiser cannot raise E. The steps are
   over-relaxed (SQFFD__FIT_RELAX); one that raised E is replaced by the
   plain step.

   B (model points x control points) never changes during a fit, nor between
   the frames of a sequence that keep the superquadric and the box. B's row
   at a model point is the tensor product a (x) b (x) c of three 1-D Bernstein
   vectors (in s, t, u); only those l + m + n numbers are stored per point.
   Runs: the model points of one grid row share eta, and when the box is
   aligned with the superquadric's axes (as sqffd_model_init makes it) their
   u, which then depends on eta alone, agrees to rounding; prepare makes it
   agree exactly (SQFFD__FIT_SNAP), so over a run of consecutive points with
   the same c, B's products factor:
     (B P)_v   = sum_ij a_i b_j (sum_k c_k P_ijk), the inner sums once per run;
     B^T y     = sum over runs of (sum_v (a (x) b) y_v) (x) c;
     B^T W B   = sum over runs of (sum_v W_v (a (x) b)(a (x) b)^T) (x) c c^T.
   That cuts the first two's cost about n-fold and B^T W B's about n^2-fold.
   For another box the runs are single points and the same code does the
   plain products. */
typedef struct sqffd__fit_system {
    int dims[3];
    int grid[2];
    size_t lattice;      /* L = l m n control points */
    size_t count;        /* M model points */
    size_t hold_step;    /* the model -> data term holds every hold_step-th row and column (sqffd__fit_holds) */
    size_t stride;       /* l + m + n */
    double *weights;     /* M x stride */
    sqffd__fit_ring *rings; /* M: the mesh's ring table */
    uint32_t *run;       /* runs + 1: the first point of each run, then M */
    size_t runs;
    double *rest;        /* M x 3: the model points of P0 (the superquadric's) */
    double *rest_control;/* L x 3: P0 */
    double spring;       /* alpha M / L: the springs' weight in the step's units */
    double tether;
    sqffd_regularization regularization;
    double *fixed;       /* L x L, lower triangle: spring D^T D + tether B^T B */
    double *rhs0;        /* 3 x L: the fixed part's pull toward P0 */
    double *pairs;       /* (l m)^2: the tether's B^T B while preparing */
    double (*block)[SQFFD_MAX_LATTICE * SQFFD_MAX_LATTICE]; /* 4 x (l m) scratch while preparing */
} sqffd__fit_system;

/* Over-relaxation of the steps (Salakhutdinov & Roweis, "Adaptive
   overrelaxed bound optimization methods", 2003): the next control points
   are P + omega (G(P) - P), G the plain step; omega starts at
   SQFFD__FIT_RELAX, grows by SQFFD__FIT_RELAX_GROW after each step that
   lowered the energy, up to SQFFD__FIT_RELAX_MAX, and goes back to the
   start after one that did not (replaced by the plain step). Measured on
   the dev shapes at 30 iterations: Anderson acceleration (3-16 steps kept)
   gained nothing over plain steps (the map changes with the
   correspondences), a fixed omega of 1.5-3 gained 5-15%, this 10-25%. */
#define SQFFD__FIT_RELAX 2.0
#define SQFFD__FIT_RELAX_GROW 1.3
#define SQFFD__FIT_RELAX_MAX 6.0

#define SQFFD__FIT_DATA_KNN 8 /* data points a model point's model -> data query keeps (sqffd__fit_nearest_data) */
#define SQFFD__FIT_DATA_MAX 16384 /* the model -> data term measures to at most this many data points (an even
                                     subsample: the queries of far model points get dear in a big tree) */

/* The fold-free step's state (its section follows the least squares). */
typedef struct sqffd__fit_fold sqffd__fit_fold;
static void sqffd__fit_fold_layout(sqffd__arena *a, const int dims[3], size_t m, int with_floor, sqffd__fit_fold *f);

/* The iteration's scratch: model-sized, plus the optional subsample and data tree. */
typedef struct sqffd__fit_work {
    double *x, *next;    /* M x 3: current and next model points */
    double *target;      /* M x 3: summed weighted displacements, then W_v y_v */
    double *weights;     /* M: W_v */
    double *rhs;         /* 3 x L, coordinate by coordinate */
    double *scratch;     /* L */
    double *accepted;    /* L x 3 (as sqffd_ffd's): the last accepted control points */
    double *plain;       /* L x 3: the plain step from them */
    double *pairs;       /* (l m)^2: a run's sum of (a (x) b)(a (x) b)^T */
    double (*block)[SQFFD_MAX_LATTICE * SQFFD_MAX_LATTICE]; /* 4 x (l m) scratch of the B products (not on the stack: 2 KB) */
    double *distance;    /* robust: per data point, for the scale (NULL otherwise) */
    double nu2;          /* robust: the Welsch scale squared once known (0: from the starting model's distances) */
    void *tree_ws;       /* tree over the model points */
    size_t tree_size;
    uint32_t (*triangle)[3]; /* per FFD data point: the closest-point search's warm start */
    uint32_t (*matched)[3]; /* per FFD data point: its triangle in the last pass */
    uint32_t (*matched_accepted)[3]; /* and in the last accepted one */
    uint32_t *order;     /* per FFD data point: the passes' order (NULL: the points' own, past SQFFD__FIT_ORDER_MAX) */
    sqffd__fit_bvh bvh;  /* the exact passes' tree over the triangles */
    void *data_ws;       /* tree over the data of the model -> data term */
    size_t data_size;
    double *data;        /* those data: an even subsample of the FFD's points (NULL: all of them) */
    size_t data_count;
    uint32_t *data_near; /* M x SQFFD__FIT_DATA_KNN: each model point's nearest data points at its last query
                            (UINT32_MAX: none) */
    double *data_at;     /* M x 3: where the model point was then */
    double *data_far;    /* M: the distance to the farthest of them then */
    double *sample;      /* the FFD subsample (NULL: all points) */
    size_t sample_count;
    sqffd_solver solver;
    double *matrix;      /* L x L: the step's normal matrix, then its factor */
    int factored;        /* matrix holds the Cholesky factor of an earlier step of this run (sqffd__fit_step) */
    double *cg;          /* 5 x 3 x L: the conjugate-gradient steps' vectors */
    double *singular;    /* L: SVD solves: singular values, then their kept inverses */
    double *v;           /* L x L: SVD solves: V (NULL: Cholesky only) */
    void *svd_ws;
    size_t svd_size;
    sqffd__fit_fold *fold; /* the fold-free step's state and the report's Jacobian bound */
} sqffd__fit_work;

/* At most cap of n points (cap 0: all of them). */
static size_t sqffd__fit_cap(size_t n, size_t cap)
{
    return cap && n > cap ? cap : n;
}

/* The lattice neighbour of control point p one step along axis; 0 if none. */
static int sqffd__fit_spring(const int d[3], size_t p, int axis, size_t *other)
{
    size_t n = (size_t)d[2], mn = (size_t)d[1] * n;
    size_t i = p / mn, j = (p / n) % (size_t)d[1], k = p % n;
    if (axis == 0 && i + 1 < (size_t)d[0]) { *other = p + mn; return 1; }
    if (axis == 1 && j + 1 < (size_t)d[1]) { *other = p + n; return 1; }
    if (axis == 2 && k + 1 < n) { *other = p + 1; return 1; }
    return 0;
}

/* weight x the lattice's graph Laplacian (the springs' part of a normal
   matrix) added to the L x L block at (at, at) of an n x n lower triangle
   (row-major or packed). */
static void sqffd__fit_add_springs(const int dims[3], double weight, double *matrix, size_t n, int packed, size_t at)
{
    size_t l = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2], p, q;
    int axis;
    for (p = 0; p < l; ++p)
        for (axis = 0; axis < 3; ++axis)
            if (sqffd__fit_spring(dims, p, axis, &q)) {
                sqffd__la_row(matrix, n, packed, at + p)[at + p] += weight;
                sqffd__la_row(matrix, n, packed, at + q)[at + q] += weight;
                sqffd__la_row(matrix, n, packed, at + q)[at + p] -= weight; /* q > p: lower triangle */
            }
}

/* The Laplacian's trace: twice the springs (neighbours along an axis). */
static double sqffd__fit_laplacian_trace(const int d[3])
{
    return 2.0 * (double)((d[0] - 1) * d[1] * d[2] + d[0] * (d[1] - 1) * d[2] + d[0] * d[1] * (d[2] - 1));
}

/* Whether a step may meet a singular normal matrix (then it is solved by
   SVD): alpha 0, or so small that rounding loses the springs where no data
   reach (measured from 1e-20 on an 8 x 8 x 8 lattice over 25 points; below
   SQFFD__FIT_ALPHA_TINY a failed Cholesky factor falls back to the SVD). */
#define SQFFD__FIT_ALPHA_TINY 1e-9
static int sqffd__fit_needs_svd(const sqffd_fit_options *o)
{
    return o->solver == SQFFD_SOLVER_SVD || o->alpha < SQFFD__FIT_ALPHA_TINY;
}

/* The system's arrays (what stays the same through a sequence). */
static void sqffd__fit_system_layout(sqffd__arena *a, const int dims[3], const int grid[2], sqffd__fit_system *s)
{
    size_t m = sqffd__fit_grid_count(grid), l = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2];
    memset(s, 0, sizeof *s);
    s->dims[0] = dims[0]; s->dims[1] = dims[1]; s->dims[2] = dims[2];
    s->grid[0] = grid[0]; s->grid[1] = grid[1];
    s->lattice = l;
    s->count = m;
    s->hold_step = 2;
    s->stride = (size_t)(dims[0] + dims[1] + dims[2]);
    s->weights = (double *)sqffd__arena_take(a, m, s->stride * sizeof(double));
    s->run = (uint32_t *)sqffd__arena_take(a, m + 1, sizeof(uint32_t));
    s->rings = (sqffd__fit_ring *)sqffd__arena_take(a, m, sizeof(sqffd__fit_ring));
    s->rest = (double *)sqffd__arena_take(a, m, 3 * sizeof(double));
    s->rest_control = (double *)sqffd__arena_take(a, 3 * l, sizeof(double));
    s->fixed = (double *)sqffd__arena_take(a, l * l, sizeof(double));
    s->rhs0 = (double *)sqffd__arena_take(a, 3 * l, sizeof(double));
    s->pairs = (double *)sqffd__arena_take(a, (size_t)(dims[0] * dims[1] * dims[0] * dims[1]), sizeof(double));
    s->block = (double (*)[SQFFD_MAX_LATTICE * SQFFD_MAX_LATTICE])sqffd__arena_take(a, 4, sizeof *s->block);
}

/* The iteration's scratch for n data points against a system of that lattice and grid. */
static void sqffd__fit_work_layout(sqffd__arena *a, size_t n, const int dims[3], const int grid[2],
                                   const sqffd_fit_options *o, sqffd__fit_fold *fold, sqffd__fit_work *w)
{
    size_t m = sqffd__fit_grid_count(grid), l = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2];
    memset(w, 0, sizeof *w);
    w->solver = o->solver;
    w->matrix = (double *)sqffd__arena_take(a, l * l, sizeof(double));
    if (sqffd__fit_needs_svd(o)) {
        w->singular = (double *)sqffd__arena_take(a, l, sizeof(double));
        w->v = (double *)sqffd__arena_take(a, l * l, sizeof(double));
        if (sqffd_svd_workspace_size(l, l, &w->svd_size) != SQFFD_OK) sqffd__arena_too_large(a);
        w->svd_ws = sqffd__arena_take(a, w->svd_size, 1);
    }
    w->x = (double *)sqffd__arena_take(a, m, 3 * sizeof(double));
    w->next = (double *)sqffd__arena_take(a, m, 3 * sizeof(double));
    w->target = (double *)sqffd__arena_take(a, m, 3 * sizeof(double));
    w->weights = (double *)sqffd__arena_take(a, m, sizeof(double));
    w->rhs = (double *)sqffd__arena_take(a, 3 * l, sizeof(double));
    w->cg = (double *)sqffd__arena_take(a, 5 * 3 * l, sizeof(double));
    w->scratch = (double *)sqffd__arena_take(a, l, sizeof(double));
    w->accepted = (double *)sqffd__arena_take(a, 3 * l, sizeof(double));
    w->plain = (double *)sqffd__arena_take(a, 3 * l, sizeof(double));
    w->pairs = (double *)sqffd__arena_take(a, (size_t)(dims[0] * dims[1] * dims[0] * dims[1]), sizeof(double));
    w->block = (double (*)[SQFFD_MAX_LATTICE * SQFFD_MAX_LATTICE])sqffd__arena_take(a, 4, sizeof *w->block);
    if (sqffd_kdtree_workspace_size(m, &w->tree_size) != SQFFD_OK) sqffd__arena_too_large(a);
    w->tree_ws = sqffd__arena_take(a, w->tree_size, 1);
    w->sample_count = sqffd__fit_cap(n, o->ffd_max_points);
    if (w->sample_count < n) w->sample = (double *)sqffd__arena_take(a, w->sample_count, 3 * sizeof(double));
    if (o->sq.robust) w->distance = (double *)sqffd__arena_take(a, w->sample_count, sizeof(double));
    w->triangle = (uint32_t (*)[3])sqffd__arena_take(a, w->sample_count, 3 * sizeof(uint32_t));
    w->matched = (uint32_t (*)[3])sqffd__arena_take(a, w->sample_count, 3 * sizeof(uint32_t));
    w->matched_accepted = (uint32_t (*)[3])sqffd__arena_take(a, w->sample_count, 3 * sizeof(uint32_t));
    if (w->sample_count <= SQFFD__FIT_ORDER_MAX) w->order = (uint32_t *)sqffd__arena_take(a, w->sample_count, sizeof(uint32_t));
    sqffd__fit_bvh_layout(a, grid, &w->bvh);
    w->fold = fold;
    sqffd__fit_fold_layout(a, dims, m, o->min_jacobian > -HUGE_VAL, fold); /* (NULL while the arena measures) */
    if (o->model_to_data > 0.0) {
        w->data_count = sqffd__fit_cap(w->sample_count, SQFFD__FIT_DATA_MAX);
        if (w->data_count < w->sample_count) w->data = (double *)sqffd__arena_take(a, w->data_count, 3 * sizeof(double));
        if (sqffd_kdtree_workspace_size(w->data_count, &w->data_size) != SQFFD_OK) sqffd__arena_too_large(a);
        w->data_ws = sqffd__arena_take(a, w->data_size, 1);
        w->data_near = (uint32_t *)sqffd__arena_take(a, m, SQFFD__FIT_DATA_KNN * sizeof(uint32_t));
        w->data_at = (double *)sqffd__arena_take(a, m, 3 * sizeof(double));
        w->data_far = (double *)sqffd__arena_take(a, m, sizeof(double));
    }
}

/* The search's order over points (sqffd__fit_order), where the work has
   room for them: the warm start's arrays are its scratch, so it is made
   before an iteration sets them or after it is done with them. It is made
   again by each run over the same points: sqffd_fit's coarse stage works in
   memory over the grid stage's, order included. */
static void sqffd__fit_ordered(const sqffd_points *points, sqffd__fit_work *w, sqffd__fit_search *search)
{
    size_t n = points->count;
    if (!w->order || n > w->sample_count) return;
    sqffd__fit_order(points, w->order, &w->triangle[0][0], &w->triangle[0][0] + n, &w->matched[0][0]);
    search->order = w->order;
}

/* matrix (L x L, lower triangle) += B^T diag(scale w) B, run by run (w NULL: all 1; w may be negative; model
   points of weight 0 and runs of them are skipped). */
static void sqffd__fit_gram(const sqffd__fit_system *s, const double *w, double scale, double *SQFFD__RESTRICT pairs,
                            double (*SQFFD__RESTRICT ab)[SQFFD_MAX_LATTICE * SQFFD_MAX_LATTICE],
                            double *SQFFD__RESTRICT matrix)
{
    const int *d = s->dims;
    size_t l = s->lattice, lm = (size_t)(d[0] * d[1]), n = (size_t)d[2], r, v, e, f, k, h;
    for (r = 0; r < s->runs; ++r) {
        const double *c = s->weights + (size_t)s->run[r] * s->stride + d[0] + d[1];
        int any = 0;
        memset(pairs, 0, lm * lm * sizeof(double));
        for (v = s->run[r]; v < s->run[r + 1];) { /* pairs += W_v (a (x) b)(a (x) b)^T, lower triangle, */
            double sign[4];                          /* four vertices at a time (a quarter of the stores) */
            size_t pick[4], picked = 0;
            for (; picked < 4 && v < s->run[r + 1]; ++v)
                if (!w || w[v] != 0.0) pick[picked++] = v;
            if (!picked) break;
            any = 1;
            for (k = 0; k < 4; ++k) {
                int inside = k < picked;
                const double *a = s->weights + (inside ? pick[k] : pick[0]) * s->stride, *b = a + d[0];
                double wk = inside ? scale * (w ? w[pick[k]] : 1.0) : 0.0, root = sqrt(fabs(wk)); /* (past the picks: zeros) */
                sign[k] = wk < 0.0 ? -1.0 : 1.0;
                for (e = 0; e < (size_t)d[0]; ++e)
                    for (f = 0; f < (size_t)d[1]; ++f) ab[k][e * (size_t)d[1] + f] = root * a[e] * b[f];
            }
            for (e = 0; e < lm; ++e) {
                const double a0 = sign[0] * ab[0][e], a1 = sign[1] * ab[1][e], a2 = sign[2] * ab[2][e], a3 = sign[3] * ab[3][e];
                double *row = pairs + e * lm;
                for (f = 0; f + 4 <= e + 1; f += 4) /* four columns a round, written out: gcc -O2 packs them into vectors */
                    for (k = 0; k < 4; ++k)
                        row[f + k] += (a0 * ab[0][f + k] + a1 * ab[1][f + k]) + (a2 * ab[2][f + k] + a3 * ab[3][f + k]);
                for (; f <= e; ++f) row[f] += (a0 * ab[0][f] + a1 * ab[1][f]) + (a2 * ab[2][f] + a3 * ab[3][f]);
            }
        }
        if (!any) continue;
        for (e = 0; e < lm; ++e) /* matrix += pairs (x) c c^T: rows e n + k, columns f n + h, f <= e */
            for (f = 0; f <= e; ++f)
                for (k = 0; k < n; ++k) {
                    double *row = matrix + (e * n + k) * l + f * n, pk = pairs[e * lm + f] * c[k];
                    size_t end = f < e ? n : k + 1, i;
                    for (h = 0; h + 4 <= end; h += 4) /* (as above) */
                        for (i = 0; i < 4; ++i) row[h + i] += pk * c[h + i];
                    for (; h < end; ++h) row[h] += pk * c[h];
                }
    }
}

/* rhs (3 x L) = B^T W y + base, run by run (weights NULL: W = I; base NULL: 0). */
static void sqffd__fit_project(const sqffd__fit_system *s, const double *y, const double *weights, const double *base,
                               double (*SQFFD__RESTRICT sum)[3], double *SQFFD__RESTRICT rhs)
{
    const int *d = s->dims;
    size_t l = s->lattice, lm = (size_t)(d[0] * d[1]), n = (size_t)d[2], r, v, e, k, i, j;
    if (base) memcpy(rhs, base, 3 * l * sizeof(double));
    else memset(rhs, 0, 3 * l * sizeof(double));
    for (r = 0; r < s->runs; ++r) {
        const double *c = s->weights + (size_t)s->run[r] * s->stride + d[0] + d[1];
        memset(sum, 0, lm * sizeof *sum);
        for (v = s->run[r]; v < s->run[r + 1]; ++v) { /* sum += (a (x) b) W_v y_v */
            const double *a = s->weights + v * s->stride, *b = a + d[0], *yv = y + 3 * v;
            double wv = weights ? weights[v] : 1.0;
            for (i = 0; i < (size_t)d[0]; ++i) {
                double ay[3], aw = a[i] * wv;
                ay[0] = aw * yv[0]; ay[1] = aw * yv[1]; ay[2] = aw * yv[2];
                for (j = 0; j < (size_t)d[1]; ++j) {
                    double *t = sum[i * (size_t)d[1] + j];
                    t[0] += b[j] * ay[0]; t[1] += b[j] * ay[1]; t[2] += b[j] * ay[2];
                }
            }
        }
        for (e = 0; e < lm; ++e) /* rhs += sum (x) c */
            for (k = 0; k < n; ++k) {
                rhs[e * n + k] += c[k] * sum[e][0];
                rhs[l + e * n + k] += c[k] * sum[e][1];
                rhs[2 * l + e * n + k] += c[k] * sum[e][2];
            }
    }
}

/* x = B P for every model point, run by run (P in sqffd_ffd's layout). */
static void sqffd__fit_evaluate(const sqffd__fit_system *s, const double (*control)[3], double (*SQFFD__RESTRICT q)[4],
                                double *SQFFD__RESTRICT x)
{
    size_t r, v;
    for (r = 0; r < s->runs; ++r) {
        const double *c = s->weights + (size_t)s->run[r] * s->stride + s->dims[0] + s->dims[1];
        sqffd__ffd_sum_u(s->dims, control, c, q);
        for (v = s->run[r]; v < s->run[r + 1]; ++v) {
            const double *a = s->weights + v * s->stride;
            sqffd__ffd_sum_st(s->dims, (const double (*)[4])q, a, a + s->dims[0], x + 3 * v);
        }
    }
}

/* The springs' and the tether's energy at control points P with model points x
   (in the step's units: alpha M / L ||D (P - P0)||^2 + tether ||x - x0||^2). */
static double sqffd__fit_prior(const sqffd__fit_system *s, const double *control, const double *x)
{
    size_t l = s->lattice, p, q, c, v;
    double springs = 0.0, tether = 0.0;
    int axis;
    for (p = 0; p < l; ++p)
        for (axis = 0; axis < 3; ++axis)
            if (sqffd__fit_spring(s->dims, p, axis, &q))
                for (c = 0; c < 3; ++c) {
                    double d = control[3 * p + c] - control[3 * q + c];
                    if (s->regularization == SQFFD_REG_DISPLACEMENT) d -= s->rest_control[3 * p + c] - s->rest_control[3 * q + c];
                    springs += d * d;
                }
    if (s->tether > 0.0)
        for (v = 0; v < 3 * s->count; ++v) tether += (x[v] - s->rest[v]) * (x[v] - s->rest[v]);
    return s->spring * springs + s->tether * tether;
}

/* B's rows, the fixed part of the normal matrix and of the right-hand side,
   from the model's superquadric, box and grid. */
static sqffd_result sqffd__fit_prepare(const sqffd_model *model, double alpha, double tether,
                                       sqffd_regularization regularization, sqffd__fit_system *s)
{
    double run_u = 0.0;
    size_t l = s->lattice, m = s->count, v, p, q, c;
    int axis;
    /* alpha weighs the mean spring energy per control point against the mean
       squared residual per data point, whatever the grid and the lattice */
    s->spring = alpha * (double)m / (double)l;
    s->tether = tether;
    s->regularization = regularization;
    sqffd__fit_rings(s->grid, s->rings);
    s->runs = 0;
    sqffd__fit_sq_grid(&model->sq, s->grid, s->rest);
    for (v = 0; v < m; ++v) {
        double stu[3];
        if (!sqffd__finite3(s->rest + 3 * v)) return SQFFD_ERROR_NON_FINITE;
        sqffd__ffd_local(&model->ffd, s->rest + 3 * v, stu);
        if (v > 0 && fabs(stu[2] - run_u) <= SQFFD__FIT_SNAP) stu[2] = run_u;
        else { s->run[s->runs++] = (uint32_t)v; run_u = stu[2]; }
        sqffd__ffd_axis_weights(s->dims, stu, s->weights + v * s->stride);
    }
    s->run[s->runs] = (uint32_t)m;
    sqffd__ffd_regular(model->ffd.dims, model->ffd.origin, model->ffd.edges, s->rest_control); /* P0 */
    /* fixed = spring D^T D (the springs' graph Laplacian) + tether B^T B;
       rhs0 = fixed P0, less the springs' part for the paper's ||D P||^2 */
    memset(s->fixed, 0, l * l * sizeof(double));
    if (s->tether > 0.0) sqffd__fit_gram(s, NULL, s->tether, s->pairs, s->block, s->fixed);
    memset(s->rhs0, 0, 3 * l * sizeof(double));
    for (p = 0; p < l; ++p)
        for (q = 0; q <= p; ++q) {
            const double h = s->fixed[p * l + q];
            for (c = 0; c < 3; ++c) {
                s->rhs0[c * l + p] += h * s->rest_control[3 * q + c];
                if (q < p) s->rhs0[c * l + q] += h * s->rest_control[3 * p + c];
            }
        }
    sqffd__fit_add_springs(s->dims, s->spring, s->fixed, l, 0, 0);
    if (regularization == SQFFD_REG_DISPLACEMENT)
        for (p = 0; p < l; ++p)
            for (axis = 0; axis < 3; ++axis)
                if (sqffd__fit_spring(s->dims, p, axis, &q))
                    for (c = 0; c < 3; ++c) {
                        double d = s->spring * (s->rest_control[3 * p + c] - s->rest_control[3 * q + c]);
                        s->rhs0[c * l + p] += d;
                        s->rhs0[c * l + q] -= d;
                    }
    return SQFFD_OK;
}

/* Step 2: rhs (3 x L) <- argmin of the weighted problem, from its normal
   matrix fixed + B^T W B (W: weights) and right-hand side rhs. Cholesky, or
   where the matrix is singular (alpha = 0 and parts of the lattice no data
   reach) or the SVD solver is chosen, the pseudo-inverse's minimum-norm
   solution over the singular values above SQFFD__FIT_SVD_RCOND of the
   largest. */
static sqffd_result sqffd__fit_solve(const sqffd__fit_system *s, sqffd__fit_work *w)
{
    size_t l = s->lattice, c, r, k;
    double *rhs = w->rhs, *scratch = w->scratch;
    sqffd_result res = SQFFD_ERROR_NOT_POSITIVE_DEFINITE;
    memcpy(w->matrix, s->fixed, l * l * sizeof(double));
    sqffd__fit_gram(s, w->weights, 1.0, w->pairs, w->block, w->matrix);
    if (w->solver == SQFFD_SOLVER_CHOLESKY) res = sqffd_cholesky_factor(w->matrix, l);
    w->factored = res == SQFFD_OK;
    if (res == SQFFD_OK) {
        for (c = 0; c < 3; ++c) sqffd_cholesky_solve(w->matrix, l, rhs + c * l);
        return SQFFD_OK;
    }
    if (res != SQFFD_ERROR_NOT_POSITIVE_DEFINITE || !w->v) return res;
    memcpy(w->matrix, s->fixed, l * l * sizeof(double)); /* the factor overwrote it */
    sqffd__fit_gram(s, w->weights, 1.0, w->pairs, w->block, w->matrix);
    for (r = 0; r < l; ++r) /* the whole symmetric matrix */
        for (k = r + 1; k < l; ++k) w->matrix[r * l + k] = w->matrix[k * l + r];
    res = sqffd_svd(w->matrix, l, l, NULL, w->singular, w->v, w->svd_ws, w->svd_size);
    if (res != SQFFD_OK) return res;
    for (k = l; k-- > 0;) /* symmetric positive semi-definite: A = V S V^T, A^+ = V S^+ V^T */
        w->singular[k] = w->singular[k] > SQFFD__FIT_SVD_RCOND * w->singular[0] ? 1.0 / w->singular[k] : 0.0;
    for (c = 0; c < 3; ++c) {
        double *b = rhs + c * l;
        for (k = 0; k < l; ++k) scratch[k] = 0.0; /* y = S^+ V^T b */
        for (r = 0; r < l; ++r)
            for (k = 0; k < l; ++k) scratch[k] += w->v[r * l + k] * b[r];
        for (k = 0; k < l; ++k) scratch[k] *= w->singular[k];
        for (r = 0; r < l; ++r) { /* b = V y */
            double sum = 0.0;
            for (k = 0; k < l; ++k) sum += w->v[r * l + k] * scratch[k];
            b[r] = sum;
        }
    }
    return SQFFD_OK;
}

/* out (3 x L) = the springs' part of the fixed matrix times V (3 x L): the
   spring weight times the lattice's graph Laplacian. */
static void sqffd__fit_springs_times(const sqffd__fit_system *s, const double *v, double *out)
{
    size_t l = s->lattice, p, q, c;
    int axis;
    memset(out, 0, 3 * l * sizeof(double));
    for (p = 0; p < l; ++p)
        for (axis = 0; axis < 3; ++axis)
            if (sqffd__fit_spring(s->dims, p, axis, &q))
                for (c = 0; c < 3; ++c) {
                    double f = s->spring * (v[c * l + p] - v[c * l + q]);
                    out[c * l + p] += f;
                    out[c * l + q] -= f;
                }
}

/* The step's vectors are planar (all x, then all y, then all z: the
   solver's right-hand sides); control points are interleaved (x y z a point). */
static void sqffd__fit_interleave(const double *planar, size_t l, double *xyz)
{
    size_t p;
    int i;
    for (p = 0; p < l; ++p)
        for (i = 0; i < 3; ++i) xyz[3 * p + (size_t)i] = planar[(size_t)i * l + p];
}

static void sqffd__fit_planar(const double *xyz, size_t l, double *planar)
{
    size_t p;
    int i;
    for (p = 0; p < l; ++p)
        for (i = 0; i < 3; ++i) planar[(size_t)i * l + p] = xyz[3 * p + (size_t)i];
}

/* Step 2 with its move: the plain step G(P) into w->plain, G(P) - P into
   w->rhs (both in sqffd_ffd's layout) and B (G(P) - P) into bmove, from the
   current control points P, model points x = B P, W_v y_v in t and W_v in
   w->weights (both overwritten).
   Building and factoring the normal matrix A = springs + B^T (W + tether) B
   is most of a solve, and W changes little from one iteration to the next.
   So a factor made by an earlier iteration of the run serves as the
   preconditioner of SQFFD__FIT_CG_STEPS conjugate-gradient steps from P on
   the current A (each a product with B and one with B^T). They lower the
   step's quadratic below its value at P, which is all the energy bound asks
   of a step (majorisation-minimisation), though they stop short of its
   minimum; after steps that left more than SQFFD__FIT_CG_KEEP of the
   residual the next iteration makes a new factor. *direct tells which
   kind the step was. */
#define SQFFD__FIT_CG_STEPS 2
#define SQFFD__FIT_CG_KEEP 0.1

static sqffd_result sqffd__fit_step(const sqffd__fit_system *s, sqffd__fit_work *w, const double *control,
                                    const double *x, double *t, double *bmove, int *direct)
{
    size_t l = s->lattice, m = s->count, size = 3 * l, p, i, v;
    double *r = w->cg, *z = r + size, *d = z + size, *ad = d + size, *move = ad + size;
    double rz[3] = {0.0, 0.0, 0.0}, alpha[3], r0 = 0.0;
    int k;
    *direct = !w->factored;
    if (*direct) {
        sqffd_result res;
        sqffd__fit_project(s, t, NULL, s->rhs0, (double (*)[3])w->block, w->rhs);
        res = sqffd__fit_solve(s, w);
        if (res != SQFFD_OK) return res;
        sqffd__fit_interleave(w->rhs, l, w->plain);
    } else {
        /* the residual b - A P = B^T (W y - (W + tether) B P) + rhs0 - springs P */
        for (v = 0; v < m; ++v) {
            w->weights[v] += s->tether;
            for (i = 0; i < 3; ++i) t[3 * v + i] -= w->weights[v] * x[3 * v + i];
        }
        sqffd__fit_project(s, t, NULL, s->rhs0, (double (*)[3])w->block, r);
        sqffd__fit_planar(control, l, d);
        sqffd__fit_springs_times(s, d, ad);
        for (p = 0; p < size; ++p) {
            r[p] -= ad[p];
            r0 += r[p] * r[p];
            move[p] = 0.0;
        }
        memcpy(d, r, size * sizeof(double));
        memset(bmove, 0, 3 * m * sizeof(double));
        for (k = 0; k < SQFFD__FIT_CG_STEPS; ++k) {
            for (i = 0; i < 3; ++i) { /* z = M^-1 r; the next direction d */
                double *zi = z + i * l, *di = d + i * l, previous = rz[i];
                memcpy(zi, r + i * l, l * sizeof(double));
                sqffd_cholesky_solve(w->matrix, l, zi);
                rz[i] = sqffd__la_dot(r + i * l, zi, l);
                for (p = 0; p < l; ++p) di[p] = k == 0 ? zi[p] : zi[p] + (previous > 0.0 ? rz[i] / previous : 0.0) * di[p];
            }
            /* ad = A d: B d into t (free now), then B^T (W + tether) (B d) + springs d */
            sqffd__fit_interleave(d, l, w->plain);
            sqffd__fit_evaluate(s, (const double (*)[3])w->plain, (double (*)[4])w->block, t);
            sqffd__fit_project(s, t, w->weights, NULL, (double (*)[3])w->block, ad);
            sqffd__fit_springs_times(s, d, z);
            for (i = 0; i < 3; ++i) {
                double den = 0.0;
                for (p = i * l; p < (i + 1) * l; ++p) {
                    ad[p] += z[p];
                    den += d[p] * ad[p];
                }
                alpha[i] = den > 0.0 ? rz[i] / den : 0.0;
                for (p = i * l; p < (i + 1) * l; ++p) {
                    move[p] += alpha[i] * d[p];
                    r[p] -= alpha[i] * ad[p];
                }
            }
            for (v = 0; v < m; ++v)
                for (i = 0; i < 3; ++i) bmove[3 * v + i] += alpha[i] * t[3 * v + i];
        }
        w->factored = sqffd__la_dot(r, r, size) <= SQFFD__FIT_CG_KEEP * SQFFD__FIT_CG_KEEP * r0;
        sqffd__fit_interleave(move, l, w->plain);
        for (p = 0; p < size; ++p) w->plain[p] += control[p];
    }
    for (p = 0; p < size; ++p) {
        if (!isfinite(w->plain[p])) return SQFFD_ERROR_NON_FINITE;
        w->rhs[p] = w->plain[p] - control[p];
    }
    if (*direct) sqffd__fit_evaluate(s, (const double (*)[3])w->rhs, (double (*)[4])w->block, bmove);
    return SQFFD_OK;
}

/* ---- the fold-free step ---------------------------------------------------
   Under a floor (min_jacobian) the model may not fold where it lives: J, the
   lattice's Jacobian in the box's coordinates (1 for P0), stays at or above
   the run's floor over THE REGION, the cells of the box's
   SQFFD__FIT_REGION^3 partition that the superquadric's surface passes
   through (the edges of its mesh on sqffd__fit_region_grid, in pieces under
   a quarter of a cell) or whose centre lies inside it: the superquadric's
   solid, which the model's surface and interior map from, and a band of up
   to a cell around it. Outside it (the box's corners) nothing is fitted and
   nothing is held.
   THE STEP: Gauss-Newton on the energy with J held above the floor at
   samples of the region (the corners of its cells, and the points the
   certificate adds) by a penalty,
     E(P) + rho/2 sum_s max(0, margin - (J(X_s; P) - floor))^2.
   The data -> model term by its point-to-plane residuals (to first order a
   data point's distance changes only along the direction to its closest
   point, n: per model point a 3 x 3 weight sum w (n n^T + SQFFD__FIT_SLIDE
   I), so the step's matrix couples x, y and z), the model -> data term, the springs and the
   tether exactly: one dense 3L x 3L system. The penalty's samples enter the
   step through its dual: the step is A^-1 (b + sum mu_i g_i), the
   multipliers those of a small problem over the samples the step would
   sink (one factor of A, kept over a few steps while A and its damping
   stay near it: sqffd__fit_fold_factor). Levenberg-Marquardt damping lambda times
   the lattice's graph Laplacian (scaled to the data's point-to-point
   matrix) keeps the step smooth, so that J, cubic in P, stays near its
   linear model; a step that still sinks a sample under the floor is halved
   before it is measured. A step is kept when it lowers the energy, though
   its samples may end inside the margin (the certified floor is the
   constraint, the margin only steers the step). Else the control points go
   back. lambda falls after a step that lowered the penalised energy as
   predicted and rises after one that did not. rho is where a sample sunk
   by the whole margin costs twice the start's energy, and stays there: a
   penalty grown over the certified floor would steer the steps by the
   margin alone, each raising the energy, until the fit stalls.
   CERTIFIED: a step is kept only when its J is certified on every region
   cell by its Bernstein coefficients (J lies between them), halved up to
   SQFFD__FIT_CERT_DEPTH times where they dip below the floor; a cell still
   below it gives a new sample (a corner below the floor, or its lowest
   coefficient's point) and the step is taken again from the accepted model.
   So every accepted model is certified: the report's min_jacobian is its
   bound over the region (sqffd_model_jacobian_bound). */
#define SQFFD__FIT_REGION 8
#define SQFFD__FIT_REGION_CELLS (SQFFD__FIT_REGION * SQFFD__FIT_REGION * SQFFD__FIT_REGION)
#define SQFFD__FIT_REGION_NODES ((SQFFD__FIT_REGION + 1) * (SQFFD__FIT_REGION + 1) * (SQFFD__FIT_REGION + 1))
#define SQFFD__FIT_REGION_LEVELS 3 /* log2 SQFFD__FIT_REGION */
static const int sqffd__fit_region_grid[2] = {32, 64}; /* the superquadric's surface the region is marked from */
#define SQFFD__FIT_SAMPLES_ADDED 256 /* samples the certificate may add to a run */
#define SQFFD__FIT_CERT_DEPTH 4
#define SQFFD__FIT_CERT_FAILS 16 /* new samples one certificate gives at most */
#define SQFFD__FIT_MARGIN 0.1     /* the samples are held this far above the floor: room for J's dips between them
                                     (measured: 0.01-0.2; under it, more steps fail the certificate; bench/NOTES.md) */
#define SQFFD__FIT_SLIDE 0.3      /* of the data's point-to-point curvature in the step's matrix: the distance does not see
                                     a slide along the surface, and a step that leaves it free lets the model points drift
                                     (frame to frame: spurious motion; measured 0.1-0.3, bench/NOTES.md) */
#define SQFFD__FIT_LAMBDA_START 1.0 /* the first step's damping: its matrix's trace that of the data's point-to-point one */
#define SQFFD__FIT_FACTOR_AGE 4   /* a factor serves the steps of up to this many linearisations (sqffd__fit_fold_factor) */
#define SQFFD__FIT_FACTOR_SPAN 3.0 /* while it damps at least as much as wanted and at most this many times more: one of
                                      lambda's falls (/3); bench/NOTES.md */
#define SQFFD__FIT_SETTLED 10.0   /* converged: a step that lowers the penalised energy by under this x tolerance of it */
#define SQFFD__FIT_NEAR 10.0      /* samples within this many margins of the floor enter the step's model (a step that
                                     moves J further than that leaves its linear model, and is shortened anyway) */
#define SQFFD__FIT_ROUNDS 8       /* rounds of a step's candidate samples at most */
#define SQFFD__FIT_CANDIDATES 96  /* samples one step's penalty holds at most */
#define SQFFD__FIT_ROUND_BATCH 16 /* of them a round adds at most */
#define SQFFD__FIT_OFF_GRID 0xffffffffu /* a sample off the region's lattice (sqffd__fit_fold.node) */

struct sqffd__fit_fold {
    sqffd__jacobian_work at;   /* J's coefficients over the box */
    double goal;               /* min_jacobian: a certified model keeps J at or above it; the samples are held above
                                  it */
    double rho, lambda;        /* the penalty's weight (energy units), the damping */
    double factored;           /* the lambda f->factor holds */
    double factored_springs;   /* and its springs' weight, lambda x damping */
    int factor_age;            /* linearisations since f->factor's matrix (SQFFD__FIT_FACTOR_AGE or more: none) */
    unsigned char *region;     /* SQFFD__FIT_REGION_CELLS: the region's cells */
    unsigned char *coarse;     /* the coarser levels' (a cell meets the region where one of its children does) */
    double (*sample)[3];       /* stu of the samples */
    double *value;             /* J - goal at each, for the accepted model */
    double *trial;             /* and for the trial */
    unsigned char *active;     /* the step's candidates */
    uint32_t *node;            /* each sample's node of the region's lattice (SQFFD__FIT_OFF_GRID: a point the
                                  certificate added) */
    double (*cross)[9];        /* the accepted model's d1 x d2, d2 x d0, d0 x d1 at each (d_a = dX/dstu_a in the box's
                                  frame: J = d0 . (d1 x d2), and J's change along a step is sum_a step's d_a . cross_a) */
    double (*frames)[9];       /* SQFFD__FIT_REGION_NODES: d0 d1 d2 at every node of the lattice, for one field */
    double *contract;          /* the frames' partial sums, one axis at a time */
    size_t samples, capacity;
    double *tensor;            /* the certificate's coefficients, one tensor a level */
    double *surface;           /* the superquadric's points on the SQFFD__FIT_REGION_GRID (the region's seeds) */
    double (*fails)[3];        /* SQFFD__FIT_CERT_FAILS */
    size_t failed;
    double *hessian;           /* 3L x 3L lower triangle, packed (sqffd__packed_row), planar unknowns: the energy's
                                  Gauss-Newton matrix at the accepted model, without the penalty */
    double *factor;            /* 3L x 3L lower triangle, packed: the step's matrix's Cholesky factor */
    double *gradient;          /* 3L: minus the energy's gradient there, without the penalty */
    double *move;              /* 3L: the step */
    double *scratch;           /* 3L */
    double *base;              /* 3L: L^-1 gradient, L the factor of the step's matrix without the penalty */
    uint32_t *candidate;       /* SQFFD__FIT_CANDIDATES: the samples the step's penalty may hold */
    double *solved;            /* SQFFD__FIT_CANDIDATES x 3L: L^-1 g for each */
    double *gram;              /* SQFFD__FIT_CANDIDATES^2: their products, plus 1 / (M rho) on the diagonal */
    double *small;             /* SQFFD__FIT_CANDIDATES^2: the multipliers' solve */
    double *need, *multiplier, *z, *slope; /* SQFFD__FIT_CANDIDATES each: the multipliers' solve */
    unsigned char *free_set;   /* SQFFD__FIT_CANDIDATES */
    double damping;            /* the damping's matrix: this x the lattice's graph Laplacian */
    double *planes;            /* M x 6: the pass's sums of w n n^T (xx xy xz yy yz zz) */
};

/* sqffd__fit_fold_frames' scratch (not on the stack: the firmware's frames
   are small): the Bernstein values and slopes at the region's nodes, then
   the partial sums, axis 2 summed (value and slope), then axis 1 (three). */
static size_t sqffd__fit_contract_size(const int dims[3])
{
    size_t n = SQFFD__FIT_REGION + 1, l0 = (size_t)dims[0];
    return 6 * n * SQFFD_MAX_LATTICE + 3 * l0 * n * (2 * (size_t)dims[1] + 3 * n);
}

static void sqffd__fit_fold_layout(sqffd__arena *a, const int dims[3], size_t m, int with_floor, sqffd__fit_fold *f)
{
    size_t l = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2], size = 3 * l;
    int ej[3];
    sqffd__fit_fold measuring;
    if (!f) f = &measuring;
    sqffd__ffd_jacobian_layout(a, dims, &f->at);
    f->region = (unsigned char *)sqffd__arena_take(a, SQFFD__FIT_REGION_CELLS, 1);
    f->coarse = (unsigned char *)sqffd__arena_take(a, SQFFD__FIT_REGION_CELLS / 7 + 1, 1);
    f->fails = (double (*)[3])sqffd__arena_take(a, SQFFD__FIT_CERT_FAILS, 3 * sizeof(double));
    sqffd__jacobian_extent(dims, 3, ej);
    f->tensor = (double *)sqffd__arena_take(a, 3 * (SQFFD__FIT_REGION_LEVELS + SQFFD__FIT_CERT_DEPTH) *
                                                   sqffd__jacobian_count(ej), sizeof(double));
    f->surface = (double *)sqffd__arena_take(a, sqffd__fit_grid_count(sqffd__fit_region_grid), 3 * sizeof(double));
    f->capacity = 0;
    if (!with_floor) return; /* (the report's bound alone) */
    f->capacity = SQFFD__FIT_REGION_NODES + SQFFD__FIT_SAMPLES_ADDED;
    f->sample = (double (*)[3])sqffd__arena_take(a, f->capacity, 3 * sizeof(double));
    f->value = (double *)sqffd__arena_take(a, f->capacity, sizeof(double));
    f->trial = (double *)sqffd__arena_take(a, f->capacity, sizeof(double));
    f->active = (unsigned char *)sqffd__arena_take(a, f->capacity, 1);
    f->node = (uint32_t *)sqffd__arena_take(a, f->capacity, sizeof(uint32_t));
    f->cross = (double (*)[9])sqffd__arena_take(a, f->capacity, 9 * sizeof(double));
    f->frames = (double (*)[9])sqffd__arena_take(a, SQFFD__FIT_REGION_NODES, 9 * sizeof(double));
    f->contract = (double *)sqffd__arena_take(a, sqffd__fit_contract_size(dims), sizeof(double));
    f->hessian = (double *)sqffd__arena_take(a, sqffd__packed_row(size), sizeof(double));
    f->factor = (double *)sqffd__arena_take(a, sqffd__packed_row(size), sizeof(double));
    f->gradient = (double *)sqffd__arena_take(a, size, sizeof(double));
    f->move = (double *)sqffd__arena_take(a, size, sizeof(double));
    f->scratch = (double *)sqffd__arena_take(a, size, sizeof(double));
    f->base = (double *)sqffd__arena_take(a, size, sizeof(double));
    f->solved = (double *)sqffd__arena_take(a, SQFFD__FIT_CANDIDATES, size * sizeof(double));
    f->gram = (double *)sqffd__arena_take(a, SQFFD__FIT_CANDIDATES * SQFFD__FIT_CANDIDATES, sizeof(double));
    f->small = (double *)sqffd__arena_take(a, SQFFD__FIT_CANDIDATES * SQFFD__FIT_CANDIDATES, sizeof(double));
    f->candidate = (uint32_t *)sqffd__arena_take(a, SQFFD__FIT_CANDIDATES, sizeof(uint32_t));
    f->need = (double *)sqffd__arena_take(a, SQFFD__FIT_CANDIDATES, sizeof(double));
    f->multiplier = (double *)sqffd__arena_take(a, SQFFD__FIT_CANDIDATES, sizeof(double));
    f->z = (double *)sqffd__arena_take(a, SQFFD__FIT_CANDIDATES, sizeof(double));
    f->slope = (double *)sqffd__arena_take(a, SQFFD__FIT_CANDIDATES, sizeof(double));
    f->free_set = (unsigned char *)sqffd__arena_take(a, SQFFD__FIT_CANDIDATES, 1);
    f->planes = (double *)sqffd__arena_take(a, m, 6 * sizeof(double));
}

/* The region's cells for the model's superquadric and box (the same for
   every grid: the coarse stage's and the grid's), its coarser levels, and
   the samples at the corners of its cells. The superquadric's surface
   marks the cells it passes through: the edges of its mesh on
   sqffd__fit_region_grid, each in pieces under a quarter of a cell.
   0 (no region) when a point of that mesh is not finite in the box's
   coordinates (a superquadric or box too large to compute with). */
static int sqffd__fit_region(const sqffd_model *model, sqffd__fit_fold *f)
{
    const int r = SQFFD__FIT_REGION;
    size_t rows = (size_t)sqffd__fit_region_grid[0], cols = (size_t)sqffd__fit_region_grid[1], v, at;
    int i, j, k, di, dj, dk, level, size;
    size_t offset;
    const double *x = f->surface;
    memset(f->region, 0, SQFFD__FIT_REGION_CELLS);
    sqffd__fit_sq_grid(&model->sq, sqffd__fit_region_grid, f->surface);
    for (v = 0; v < rows * cols; ++v) /* the mesh's edges: to the next point in the row, the column, or the pole */
        for (k = 0; k < 3; ++k) {
            size_t other = k == 0 ? v - v % cols + (v + 1) % cols
                           : k == 1 ? (v + cols < rows * cols ? v + cols : rows * cols + 1)
                                    : (v < cols ? rows * cols : v);
            double from[3], to[3], reach = 0.0;
            int pieces, e;
            sqffd__ffd_local(&model->ffd, x + 3 * v, from);
            sqffd__ffd_local(&model->ffd, x + 3 * other, to);
            if (!sqffd__finite3(from) || !sqffd__finite3(to)) return 0;
            for (e = 0; e < 3; ++e) reach = fabs(to[e] - from[e]) > reach ? fabs(to[e] - from[e]) : reach;
            pieces = 1 + (int)(4.0 * r * (reach < 1.0 ? reach : 1.0));
            for (i = 0; i <= pieces; ++i) {
                int cell[3];
                for (e = 0; e < 3; ++e) {
                    double c = floor((from[e] + (to[e] - from[e]) * i / pieces) * r);
                    cell[e] = c < 0.0 ? 0 : c > r - 1 ? r - 1 : (int)c;
                }
                f->region[(cell[0] * r + cell[1]) * r + cell[2]] = 1;
            }
        }
    for (i = 0; i < r; ++i)
        for (j = 0; j < r; ++j)
            for (k = 0; k < r; ++k) {
                double centre[3], value;
                int e;
                for (e = 0; e < 3; ++e)
                    centre[e] = model->ffd.origin[e] + ((i + 0.5) * model->ffd.edges[e] + (j + 0.5) * model->ffd.edges[3 + e] +
                                                        (k + 0.5) * model->ffd.edges[6 + e]) / r;
                if (sqffd_sq_inside_outside(&model->sq, centre, &value) == SQFFD_OK && value <= 1.0)
                    f->region[(i * r + j) * r + k] = 1;
            }
    /* the coarser levels, finest first: level of size cells an axis at coarse[offset..] */
    memset(f->coarse, 0, SQFFD__FIT_REGION_CELLS / 7 + 1);
    for (offset = 0, size = r / 2, level = SQFFD__FIT_REGION_LEVELS - 1; level >= 0; --level, size /= 2) {
        int child = size * 2;
        const unsigned char *from = level == SQFFD__FIT_REGION_LEVELS - 1 ? f->region : f->coarse + offset - (size_t)(child * child * child);
        for (i = 0; i < child; ++i)
            for (j = 0; j < child; ++j)
                for (k = 0; k < child; ++k)
                    if (from[(i * child + j) * child + k]) f->coarse[offset + (size_t)(((i / 2) * size + j / 2) * size + k / 2)] = 1;
        offset += (size_t)(size * size * size);
    }
    f->samples = 0;
    for (i = 0; i <= r && f->capacity; ++i)
        for (j = 0; j <= r; ++j)
            for (k = 0; k <= r; ++k) {
                int near = 0;
                for (di = i > 0 ? i - 1 : 0; di <= (i < r ? i : r - 1) && !near; ++di)
                    for (dj = j > 0 ? j - 1 : 0; dj <= (j < r ? j : r - 1) && !near; ++dj)
                        for (dk = k > 0 ? k - 1 : 0; dk <= (k < r ? k : r - 1) && !near; ++dk)
                            near = f->region[(di * r + dj) * r + dk];
                if (!near) continue;
                at = f->samples++;
                f->node[at] = (uint32_t)((i * (r + 1) + j) * (r + 1) + k);
                f->sample[at][0] = (double)i / r;
                f->sample[at][1] = (double)j / r;
                f->sample[at][2] = (double)k / r;
            }
    return 1;
}

/* Whether the cell (cells an axis at its level, index) meets the region. */
static int sqffd__fit_region_meets(const sqffd__fit_fold *f, int cells, const int index[3])
{
    size_t offset = 0;
    int size = SQFFD__FIT_REGION / 2;
    if (cells >= SQFFD__FIT_REGION) {
        int shift = cells / SQFFD__FIT_REGION;
        return f->region[((index[0] / shift) * SQFFD__FIT_REGION + index[1] / shift) * SQFFD__FIT_REGION + index[2] / shift];
    }
    while (size > cells) {
        offset += (size_t)(size * size * size);
        size /= 2;
    }
    return f->coarse[offset + (size_t)((index[0] * cells + index[1]) * cells + index[2])];
}

/* 1-D Bernstein values b and derivatives db of degree d at t. */
/* d1 x d2, d2 x d0, d0 x d1 of a frame d (9) into cross (9); J = d0 . (d1 x d2). */
static double sqffd__fit_fold_crosses(const double *d, double *cross)
{
    sqffd__cross3(d + 3, d + 6, cross);
    sqffd__cross3(d + 6, d, cross + 3);
    sqffd__cross3(d, d + 3, cross + 6);
    return sqffd__dot3(d, cross);
}

static void sqffd__bernstein_derivatives(int d, double t, double *b, double *db)
{
    double low[SQFFD_MAX_LATTICE];
    int i;
    sqffd__ffd_bernstein(d, t, b);
    if (d == 0) { db[0] = 0.0; return; }
    sqffd__ffd_bernstein(d - 1, t, low);
    for (i = 0; i <= d; ++i) db[i] = (double)d * ((i > 0 ? low[i - 1] : 0.0) - (i < d ? low[i] : 0.0));
}

/* The frame d_a = inverse (d x / d stu_a), a = 0 1 2, at box point stu of a
   field over the lattice (control points, or a step: entry c of point p at
   field[p ps + c cs]) into d (9); with grad (3L, planar) J's gradient
   with respect to the control points, from the field's frame. J itself:
   d0 . (d1 x d2) (sqffd__fit_fold_crosses). */
static void sqffd__fit_fold_frame(const int dims[3], const double *field, size_t ps, size_t cs, const double inverse[9],
                                  const double stu[3], double *d, double *grad)
{
    double b[3][SQFFD_MAX_LATTICE], db[3][SQFFD_MAX_LATTICE], world[3][3], cross[9], m[3][3];
    size_t l = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2], p, c;
    int a, i, j, k;
    for (a = 0; a < 3; ++a) sqffd__bernstein_derivatives(dims[a] - 1, stu[a], b[a], db[a]);
    memset(world, 0, sizeof world); /* world[a]: d x / d stu_a */
    for (i = 0, p = 0; i < dims[0]; ++i)
        for (j = 0; j < dims[1]; ++j)
            for (k = 0; k < dims[2]; ++k, ++p) {
                double ds = db[0][i] * b[1][j] * b[2][k], dt = b[0][i] * db[1][j] * b[2][k], du = b[0][i] * b[1][j] * db[2][k];
                for (c = 0; c < 3; ++c) {
                    double q = field[p * ps + c * cs];
                    world[0][c] += ds * q;
                    world[1][c] += dt * q;
                    world[2][c] += du * q;
                }
            }
    for (a = 0; a < 3; ++a) sqffd__mat3_vec(inverse, world[a], d + 3 * a);
    if (!grad) return;
    sqffd__fit_fold_crosses(d, cross); /* dJ / dP_p = inverse^T (sum_a dB_p / d stu_a cross_a) */
    for (a = 0; a < 3; ++a) sqffd__mat3t_vec(inverse, cross + 3 * a, m[a]);
    for (i = 0, p = 0; i < dims[0]; ++i)
        for (j = 0; j < dims[1]; ++j)
            for (k = 0; k < dims[2]; ++k, ++p) {
                double ds = db[0][i] * b[1][j] * b[2][k], dt = b[0][i] * db[1][j] * b[2][k], du = b[0][i] * b[1][j] * db[2][k];
                for (c = 0; c < 3; ++c) grad[c * l + p] = ds * m[0][c] + dt * m[1][c] + du * m[2][c];
            }
}

/* J at box point stu for control points in sqffd_ffd's layout; with grad
   (3L, planar) its gradient with respect to them. */
static double sqffd__fit_fold_sample(const int dims[3], const double *control, const double inverse[9],
                                     const double stu[3], double *grad)
{
    double d[9], cross[9];
    sqffd__fit_fold_frame(dims, control, 3, 1, inverse, stu, d, grad);
    return sqffd__fit_fold_crosses(d, cross);
}

/* The frames of a field (as sqffd__fit_fold_frame's) at every node of the
   region's lattice (SQFFD__FIT_REGION + 1 an axis) into f->frames: one
   axis at a time, the lattice's sums shared by the nodes of a row (a few
   hundred thousand products on a 5 x 5 x 5 lattice, against that many for
   every few samples one at a time). */
static void sqffd__fit_fold_frames(const int dims[3], const double *field, size_t ps, size_t cs, const double inverse[9],
                                   sqffd__fit_fold *f)
{
    enum { n = SQFFD__FIT_REGION + 1 };
    typedef double sqffd__fit_node_basis[n][SQFFD_MAX_LATTICE]; /* [node][i] */
    sqffd__fit_node_basis *b = (sqffd__fit_node_basis *)f->contract, *db = b + 3; /* [axis]: values, slopes */
    size_t l0 = (size_t)dims[0], l1 = (size_t)dims[1], l2 = (size_t)dims[2], i, j, k, u, v, w, c;
    double *value2 = f->contract + 6 * n * SQFFD_MAX_LATTICE, *slope2 = value2 + l0 * l1 * n * 3; /* [i][j][w][c]: axis 2 */
    double *vv = slope2 + l0 * l1 * n * 3, *dv = vv + l0 * n * n * 3, *vd = dv + l0 * n * n * 3; /* [i][v][w][c] */
    int a;
    for (a = 0; a < 3; ++a)
        for (u = 0; u < n; ++u) sqffd__bernstein_derivatives(dims[a] - 1, (double)u / SQFFD__FIT_REGION, b[a][u], db[a][u]);
    for (i = 0; i < l0; ++i)
        for (j = 0; j < l1; ++j)
            for (w = 0; w < n; ++w)
                for (c = 0; c < 3; ++c) {
                    double sv = 0.0, sd = 0.0;
                    for (k = 0; k < l2; ++k) {
                        double q = field[((i * l1 + j) * l2 + k) * ps + c * cs];
                        sv += b[2][w][k] * q;
                        sd += db[2][w][k] * q;
                    }
                    value2[((i * l1 + j) * n + w) * 3 + c] = sv;
                    slope2[((i * l1 + j) * n + w) * 3 + c] = sd;
                }
    for (i = 0; i < l0; ++i)
        for (v = 0; v < n; ++v)
            for (w = 0; w < n; ++w)
                for (c = 0; c < 3; ++c) {
                    double s0 = 0.0, s1 = 0.0, s2 = 0.0;
                    for (j = 0; j < l1; ++j) {
                        size_t at = ((i * l1 + j) * n + w) * 3 + c;
                        s0 += b[1][v][j] * value2[at];
                        s1 += db[1][v][j] * value2[at];
                        s2 += b[1][v][j] * slope2[at];
                    }
                    vv[((i * n + v) * n + w) * 3 + c] = s0;
                    dv[((i * n + v) * n + w) * 3 + c] = s1;
                    vd[((i * n + v) * n + w) * 3 + c] = s2;
                }
    for (u = 0; u < n; ++u)
        for (v = 0; v < n; ++v)
            for (w = 0; w < n; ++w) {
                double world[3][3] = {{0.0}};
                for (i = 0; i < l0; ++i)
                    for (c = 0; c < 3; ++c) {
                        size_t at = ((i * n + v) * n + w) * 3 + c;
                        world[0][c] += db[0][u][i] * vv[at];
                        world[1][c] += b[0][u][i] * dv[at];
                        world[2][c] += b[0][u][i] * vd[at];
                    }
                for (a = 0; a < 3; ++a) sqffd__mat3_vec(inverse, world[a], f->frames[(u * n + v) * n + w] + 3 * a);
            }
}

/* Each sample's frame for a field: its node's from sqffd__fit_fold_frames
   (run first), or its own (a point the certificate added). */
static const double *sqffd__fit_fold_frame_of(const int dims[3], const sqffd__fit_fold *f, size_t i, const double *field,
                                              size_t ps, size_t cs, const double inverse[9], double *own)
{
    if (f->node[i] != SQFFD__FIT_OFF_GRID) return f->frames[f->node[i]];
    sqffd__fit_fold_frame(dims, field, ps, cs, inverse, f->sample[i], own, NULL);
    return own;
}

/* J - goal at every sample for these control points into out; the
   smallest. With cross, each sample's crosses too (the accepted model's). */
static double sqffd__fit_fold_values(const int dims[3], sqffd__fit_fold *f, const double *control,
                                     const double inverse[9], double *out, double (*cross)[9])
{
    double least = HUGE_VAL, own[9], scratch[9];
    size_t i;
    sqffd__fit_fold_frames(dims, control, 3, 1, inverse, f);
    for (i = 0; i < f->samples; ++i) {
        const double *d = sqffd__fit_fold_frame_of(dims, f, i, control, 3, 1, inverse, own);
        out[i] = sqffd__fit_fold_crosses(d, cross ? cross[i] : scratch) - f->goal;
        if (!(out[i] >= least)) least = out[i];
    }
    return least;
}

/* The tensor t (extents ext) split at the middle of axis `axis` (de
   Casteljau at 1/2) into its halves' tensors lo (which may be t: in place)
   and hi. The lines along the axis go eight at a time through a small
   table (their triangles side by side: the compiler packs them into
   vectors, two or more independent ones a step, and the table stays in
   registers or L1 instead of every level passing over the tensor). */
#define SQFFD__SPLIT_LANES 8
static void sqffd__bernstein_split(const double *t, const int ext[3], int axis, double *lo, double *hi)
{
    size_t slab = axis == 0 ? (size_t)(ext[1] * ext[2]) : axis == 1 ? (size_t)ext[2] : 1, n = (size_t)ext[axis];
    size_t lines = sqffd__jacobian_count(ext) / n, line, r, i, q;
    double w[3 * SQFFD_MAX_LATTICE][SQFFD__SPLIT_LANES];
    size_t start[SQFFD__SPLIT_LANES];
    for (line = 0; line < lines; line += SQFFD__SPLIT_LANES) {
        for (q = 0; q < SQFFD__SPLIT_LANES; ++q) { /* (a last short group repeats its last line) */
            size_t at = line + q < lines ? line + q : lines - 1;
            start[q] = at / slab * n * slab + at % slab;
        }
        for (i = 0; i < n; ++i)
            for (q = 0; q < SQFFD__SPLIT_LANES; ++q) w[i][q] = t[start[q] + i * slab];
        for (q = 0; q < SQFFD__SPLIT_LANES; ++q) lo[start[q]] = w[0][q];
        for (r = 1; r < n; ++r) { /* level r of the triangle: its first point is the left half's r-th */
            for (i = 0; i + r < n; ++i)
                for (q = 0; q < SQFFD__SPLIT_LANES; ++q) w[i][q] = 0.5 * (w[i][q] + w[i + 1][q]);
            for (q = 0; q < SQFFD__SPLIT_LANES; ++q) lo[start[q] + r * slab] = w[0][q];
        }
        for (i = 0; i < n; ++i) /* each level's last point: the right half */
            for (q = 0; q < SQFFD__SPLIT_LANES; ++q) hi[start[q] + i * slab] = w[i][q];
    }
}

/* The point just written to f->fails[f->failed] kept, unless it is one of
   those before it (cells that share a corner find it each). */
static void sqffd__fit_fold_failed(sqffd__fit_fold *f)
{
    const double *point = f->fails[f->failed];
    size_t i;
    for (i = 0; i < f->failed; ++i)
        if (f->fails[i][0] == point[0] && f->fails[i][1] == point[1] && f->fails[i][2] == point[2]) return;
    ++f->failed;
}

/* The smallest of t[0 .. count) (NaNs skipped; HUGE_VAL if none), in
   SQFFD__SPLIT_LANES partial minima that the compiler packs into vectors
   (a cell's minimum is most of the certificate's own time). */
static double sqffd__fit_least(const double *t, size_t count)
{
    double lane[SQFFD__SPLIT_LANES], least = HUGE_VAL;
    size_t i, q;
    for (q = 0; q < SQFFD__SPLIT_LANES; ++q) lane[q] = HUGE_VAL;
    for (i = 0; i + SQFFD__SPLIT_LANES <= count; i += SQFFD__SPLIT_LANES)
        for (q = 0; q < SQFFD__SPLIT_LANES; ++q) lane[q] = t[i + q] < lane[q] ? t[i + q] : lane[q];
    for (; i < count; ++i) least = t[i] < least ? t[i] : least;
    for (q = 0; q < SQFFD__SPLIT_LANES; ++q) least = lane[q] < least ? lane[q] : least;
    return least;
}

/* One cell of the certificate (level: halvings of the box; index: its
   place; t: its coefficients): 1 when it is settled, its smallest
   coefficient into *least: at or above target, or (a region cell or
   below) at or above the goal; or under the goal with a point of it added
   to f->fails: a corner below it (J itself there), a cell at the deepest
   level (its lowest coefficient's Greville point), or any once
   SQFFD__FIT_CERT_FAILS are found (the answer is known). 0: to be halved. */
static int sqffd__fit_fold_cell(const int ej[3], sqffd__fit_fold *f, double target, int level, const int index[3],
                                const double *t, double *least)
{
    size_t count = sqffd__jacobian_count(ej), lowest = 0;
    int a, corner, cells = 1 << level, g[3];
    *least = sqffd__fit_least(t, count);
    if (*least >= target || (level >= SQFFD__FIT_REGION_LEVELS && *least >= f->goal)) return 1;
    if (level < SQFFD__FIT_REGION_LEVELS || *least >= f->goal) return 0;
    if (f->failed >= SQFFD__FIT_CERT_FAILS) return 1;
    for (corner = 0; corner < 8; ++corner) {
        for (a = 0; a < 3; ++a) g[a] = (corner >> (2 - a)) & 1 ? ej[a] - 1 : 0;
        if (t[((size_t)g[0] * (size_t)ej[1] + (size_t)g[1]) * (size_t)ej[2] + (size_t)g[2]] < f->goal) {
            for (a = 0; a < 3; ++a) f->fails[f->failed][a] = (double)(index[a] + (g[a] ? 1 : 0)) / cells;
            sqffd__fit_fold_failed(f);
            return 1;
        }
    }
    if (level < SQFFD__FIT_REGION_LEVELS + SQFFD__FIT_CERT_DEPTH) return 0;
    while (t[lowest] != *least) ++lowest; /* (its first place) */
    g[2] = (int)(lowest % (size_t)ej[2]);
    g[1] = (int)(lowest / (size_t)ej[2] % (size_t)ej[1]);
    g[0] = (int)(lowest / ((size_t)ej[1] * (size_t)ej[2]));
    for (a = 0; a < 3; ++a) f->fails[f->failed][a] = (index[a] + (double)g[a] / (ej[a] - 1)) / cells;
    sqffd__fit_fold_failed(f);
    return 1;
}

/* The certified lower bound of J over the region for these control points:
   the smallest coefficient over the settled cells of a depth-first walk
   down from the box, halving where a cell is not settled (at least the
   floor: certified; below it, f->fails holds up to SQFFD__FIT_CERT_FAILS
   points where it may dip). A cell's children come from halving it along
   axis 2, one half along axis 1, one quarter along axis 0, each in place
   (the first half, quarter, eighth where the whole was: it is not needed
   again) with the second in the level's slot of f->tensor (no recursion:
   the firmware's stack is bounded). */
static double sqffd__fit_fold_certify(const int dims[3], sqffd__fit_fold *f, const double *control, const double inverse[9],
                                      double target)
{
    enum { levels = SQFFD__FIT_REGION_LEVELS + SQFFD__FIT_CERT_DEPTH };
    int ej[3], index[levels + 1][3], child[levels + 1], quad[levels + 1], pair[levels + 1], depth = 0, a;
    double *t[levels + 1];
    double near = 2.0, eps = sqffd__ffd_jacobian_derivatives(dims, control, inverse, &f->at), bound = HUGE_VAL, least;
    size_t count;
    near -= (1.0 + eps) * (1.0 + eps) * (1.0 + eps);
    f->failed = 0;
    if (near >= target) return near; /* (a lattice near the regular one: no coefficients needed) */
    sqffd__ffd_jacobian_products(dims, &f->at);
    sqffd__ffd_jacobian_coefficients(dims, &f->at);
    sqffd__jacobian_extent(dims, 3, ej);
    count = sqffd__jacobian_count(ej);
    memset(index[0], 0, sizeof index[0]);
    t[0] = f->at.coef;
    if (sqffd__fit_fold_cell(ej, f, target, 0, index[0], t[0], &least)) return least;
    child[0] = 0;
    quad[0] = pair[0] = -1;
    while (depth >= 0) {
        double *slot = f->tensor + (size_t)depth * 3 * count; /* the second half, quarter, eighth */
        int c = child[depth]++, sub[3];
        double *half, *quarter, *eighth; /* child c's: each first one where its whole was */
        if (c == 8) {
            --depth;
            continue;
        }
        for (a = 0; a < 3; ++a) sub[a] = 2 * index[depth][a] + ((c >> a) & 1);
        if (depth + 1 <= SQFFD__FIT_REGION_LEVELS && !sqffd__fit_region_meets(f, 1 << (depth + 1), sub)) continue;
        half = c / 4 ? slot : t[depth];
        quarter = c / 2 % 2 ? slot + count : half;
        eighth = c % 2 ? slot + 2 * count : quarter;
        /* the halvings this child needs, each once: axis 2, then axis 1 of its half, then axis 0 of its quarter */
        if (quad[depth] == -1) sqffd__bernstein_split(t[depth], ej, 2, t[depth], slot);
        if (quad[depth] != c / 4) {
            sqffd__bernstein_split(half, ej, 1, half, slot + count);
            quad[depth] = c / 4;
            pair[depth] = -1;
        }
        if (pair[depth] != c / 2) {
            sqffd__bernstein_split(quarter, ej, 0, quarter, slot + 2 * count);
            pair[depth] = c / 2;
        }
        if (sqffd__fit_fold_cell(ej, f, target, depth + 1, sub, eighth, &least)) {
            if (least < bound) bound = least;
            continue;
        }
        ++depth;
        memcpy(index[depth], sub, sizeof sub);
        t[depth] = eighth;
        child[depth] = 0;
        quad[depth] = pair[depth] = -1;
    }
    return bound;
}

SQFFD_DEF sqffd_result sqffd_model_jacobian_workspace_size(const int dims[3], size_t *size)
{
    sqffd__arena a;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    if (!dims || !sqffd__ffd_dims_valid(dims)) return SQFFD_ERROR_INVALID_ARGUMENT;
    sqffd__arena_measure(&a);
    sqffd__arena_take(&a, 1, sizeof(sqffd__fit_fold));
    sqffd__fit_fold_layout(&a, dims, 0, 0, NULL);
    return sqffd__arena_size(&a, size);
}

SQFFD_DEF sqffd_result sqffd_model_jacobian_bound(const sqffd_model *model, double floor, double *min, void *workspace,
                                                 size_t workspace_size)
{
    sqffd__arena a;
    sqffd__fit_fold *f;
    double bound;
    sqffd_result r;
    if (!model || !min || !isfinite(floor)) return SQFFD_ERROR_INVALID_ARGUMENT;
    if ((r = sqffd_model_validate(model)) != SQFFD_OK) return r;
    sqffd__arena_init(&a, workspace, workspace_size);
    f = (sqffd__fit_fold *)sqffd__arena_take(&a, 1, sizeof(sqffd__fit_fold));
    sqffd__fit_fold_layout(&a, model->ffd.dims, 0, 0, f);
    if (a.overflow) return sqffd__arena_error(&a);
    if (!sqffd__fit_region(model, f)) return SQFFD_ERROR_NON_FINITE;
    f->goal = floor;
    bound = sqffd__fit_fold_certify(model->ffd.dims, f, &model->ffd.control[0][0], model->ffd.inverse, floor);
    if (!isfinite(bound)) return SQFFD_ERROR_NON_FINITE;
    *min = bound;
    return SQFFD_OK;
}

/* y = A x for a symmetric n x n A given by its lower triangle (row-major:
   n x n, or packed: sqffd__packed_row). */
static void sqffd__fit_symmetric_times(const double *a, size_t n, int packed, const double *x, double *y)
{
    size_t i, j;
    for (i = 0; i < n; ++i) {
        const double *row = sqffd__la_row(a, n, packed, i);
        y[i] = sqffd__la_dot(row, x, i + 1);
        for (j = 0; j < i; ++j) y[j] += row[j] * x[i];
    }
}

/* matrix (3L x 3L lower, packed, planar unknowns) += the symmetric L x L block
   (lower triangle given) at block row c, column c2 (c >= c2). */
static void sqffd__fit_fold_scatter(size_t l, const double *block, size_t c, size_t c2, double *matrix)
{
    size_t p, q;
    for (p = 0; p < l; ++p) {
        double *row = matrix + sqffd__packed_row(c * l + p) + c2 * l;
        for (q = 0; q <= p; ++q) row[q] += block[p * l + q];
        if (c != c2)
            for (q = p + 1; q < l; ++q) row[q] += block[q * l + p];
    }
}

/* The penalty rho/2 sum max(0, margin - (J - floor))^2 over the samples
   (energy units) from their values. */
static double sqffd__fit_fold_penalty(const sqffd__fit_fold *f, const double *value)
{
    double sum = 0.0;
    size_t i;
    for (i = 0; i < f->samples; ++i) {
        double v = SQFFD__FIT_MARGIN - value[i];
        if (!(v <= 0.0)) {
            if (!(v < HUGE_VAL)) v = HUGE_VAL;
            sum += v * v;
        }
    }
    return 0.5 * f->rho * sum;
}

/* The step's matrix without the penalty, the energy's plus lambda x the
   damping, factored into f->factor; lambda grows tenfold until it factors
   (0 when it never does). The factor already made serves instead while
   its matrix is under SQFFD__FIT_FACTOR_AGE linearisations old and it
   damps at least as much as wanted, at most SQFFD__FIT_FACTOR_SPAN times
   more (a step taken again with new samples reuses it as it is): a
   positive definite matrix near the energy's curvature gives a descent
   step all the same, a shorter one where it damps more, never a bolder
   one, and the step is measured and certified like any other. */
static int sqffd__fit_fold_factor(const sqffd__fit_system *s, sqffd__fit_fold *f)
{
    size_t l = s->lattice, size = 3 * l, c;
    double wanted = f->lambda * f->damping;
    int tries;
    if (f->factor_age < SQFFD__FIT_FACTOR_AGE && f->factored_springs >= wanted &&
        f->factored_springs <= SQFFD__FIT_FACTOR_SPAN * wanted)
        return 1;
    f->factor_age = SQFFD__FIT_FACTOR_AGE;
    for (tries = 0; tries < 40; ++tries, f->lambda = f->lambda > 0.0 ? 10.0 * f->lambda : 1e-6) {
        memcpy(f->factor, f->hessian, sqffd__packed_row(size) * sizeof(double));
        for (c = 0; c < 3; ++c) sqffd__fit_add_springs(s->dims, f->lambda * f->damping, f->factor, size, 1, c * l);
        if (sqffd__la_cholesky(f->factor, size, 1) == SQFFD_OK) {
            f->factored = f->lambda;
            f->factored_springs = f->lambda * f->damping;
            f->factor_age = 0;
            return 1;
        }
    }
    return 0;
}

/* The decrease of the penalised energy's model by the step f->move (step
   units, the penalty's weight M rho): the energy's quadratic model, and the
   penalty's of the samples' linearised J. */
/* How far the step f->move sinks each near sample under the margin, by J's
   linear model (the step's frames against the accepted model's crosses),
   into f->trial (0 for the others). */
static void sqffd__fit_fold_sinking(const sqffd__fit_system *s, sqffd__fit_fold *f, const double inverse[9])
{
    double own[9];
    size_t i;
    sqffd__fit_fold_frames(s->dims, f->move, 1, s->lattice, inverse, f);
    for (i = 0; i < f->samples; ++i) {
        const double *d;
        f->trial[i] = 0.0;
        if (!(f->value[i] < SQFFD__FIT_NEAR * SQFFD__FIT_MARGIN)) continue;
        d = sqffd__fit_fold_frame_of(s->dims, f, i, f->move, 1, s->lattice, inverse, own);
        f->trial[i] = SQFFD__FIT_MARGIN - f->value[i] -
                      (sqffd__dot3(d, f->cross[i]) + sqffd__dot3(d + 3, f->cross[i] + 3) + sqffd__dot3(d + 6, f->cross[i] + 6));
    }
}

static double sqffd__fit_fold_predicted(const sqffd__fit_system *s, sqffd__fit_fold *f, const double inverse[9], double weight,
                                        size_t count)
{
    size_t size = 3 * s->lattice, k;
    double decrease = sqffd__la_dot(f->gradient, f->move, size);
    sqffd__fit_symmetric_times(f->hessian, size, 1, f->move, f->scratch);
    decrease -= 0.5 * sqffd__la_dot(f->move, f->scratch, size);
    sqffd__fit_fold_sinking(s, f, inverse);
    for (k = 0; k < count; ++k) { /* (the other samples are not short before the step nor after it) */
        double before = SQFFD__FIT_MARGIN - f->value[f->candidate[k]], after = f->trial[f->candidate[k]];
        decrease += 0.5 * weight * ((before > 0.0 ? before * before : 0.0) - (after > 0.0 ? after * after : 0.0));
    }
    return decrease;
}

/* The multipliers mu >= 0 minimising 1/2 mu^T H mu - need^T mu over the
   first k candidates (H = f->gram, positive definite), by Lawson and
   Hanson's active set: grow the free set by the steepest descent, solve on
   it, step back to the first multiplier that would turn negative. */
static void sqffd__fit_fold_multipliers(sqffd__fit_fold *f, size_t k)
{
    const size_t stride = SQFFD__FIT_CANDIDATES;
    size_t i, j, r, n, solves = 0;
    unsigned char map[SQFFD__FIT_CANDIDATES]; /* (SQFFD__FIT_CANDIDATES <= 256) */
    for (i = 0; i < k; ++i) {
        f->multiplier[i] = 0.0;
        f->free_set[i] = 0;
    }
    for (;;) {
        size_t enter = k;
        double most = 0.0;
        for (i = 0; i < k; ++i) { /* the slope H mu - need; the most negative one not free enters */
            f->slope[i] = sqffd__la_dot(f->gram + i * stride, f->multiplier, k) - f->need[i];
            if (!f->free_set[i] && f->slope[i] < most) { most = f->slope[i]; enter = i; }
        }
        if (enter == k) return;
        f->free_set[enter] = 1;
        for (;;) {
            double step = 1.0;
            if (++solves > 3 * k) return;
            for (n = 0, i = 0; i < k; ++i) if (f->free_set[i]) map[n++] = (unsigned char)i;
            for (r = 0; r < n; ++r) { /* z = H_FF^-1 need_F on the free set */
                for (j = 0; j <= r; ++j) f->small[r * n + j] = f->gram[map[r] * stride + map[j]];
                f->slope[r] = f->need[map[r]];
            }
            if (sqffd_cholesky_factor(f->small, n) != SQFFD_OK) { f->free_set[enter] = 0; return; }
            sqffd_cholesky_solve(f->small, n, f->slope);
            for (i = 0; i < k; ++i) f->z[i] = 0.0;
            for (r = 0; r < n; ++r) f->z[map[r]] = f->slope[r];
            for (r = 0; r < n; ++r) { /* the way from mu to z, up to the first multiplier that reaches 0 */
                i = map[r];
                if (f->z[i] <= 0.0) {
                    double t = f->multiplier[i] / (f->multiplier[i] - f->z[i]);
                    if (t < step) step = t;
                }
            }
            for (i = 0; i < k; ++i) f->multiplier[i] += step * (f->z[i] - f->multiplier[i]);
            if (step == 1.0) break;
            for (i = 0; i < k; ++i)
                if (f->free_set[i] && f->multiplier[i] <= 0.0) { f->free_set[i] = 0; f->multiplier[i] = 0.0; }
        }
    }
}

/* The step on the energy's model plus the penalty of the samples the step
   itself sinks under the margin (by their linearised J), into f->move
   (planar). With A the damped matrix and b its right-hand side, the step is
   A^-1 (b + sum mu_i g_i), the multipliers mu >= 0 those of the penalty's
   dual, min 1/2 mu^T (G A^-1 G^T + I / (M rho)) mu - (v - G A^-1 b)^T mu
   (v: the samples' shortfalls under the margin), over candidates: the
   samples short now or sunk by the step without them, then those the last
   solution sinks, most sunk first (at most SQFFD__FIT_ROUNDS rounds and
   SQFFD__FIT_CANDIDATES samples). Returns the predicted decrease (step
   units; -1: no damping factors the matrix). */
static double sqffd__fit_fold_step(const sqffd__fit_system *s, sqffd__fit_fold *f, const double *control,
                                   const double inverse[9], double weight)
{
    const size_t stride = SQFFD__FIT_CANDIDATES;
    size_t size = 3 * s->lattice, i, j, k = 0, done = 0, p;
    int round;
    if (!sqffd__fit_fold_factor(s, f)) return -1.0;
    memcpy(f->base, f->gradient, size * sizeof(double));
    sqffd__la_forward(f->factor, size, 1, f->base, 1);
    memcpy(f->move, f->base, size * sizeof(double));
    sqffd__la_backward(f->factor, size, 1, f->move);
    for (i = 0; i < f->samples; ++i) f->active[i] = 0;
    for (round = 0; round < SQFFD__FIT_ROUNDS; ++round) {
        sqffd__fit_fold_sinking(s, f, inverse);
        while (k < SQFFD__FIT_CANDIDATES && k - done < SQFFD__FIT_ROUND_BATCH) { /* the most sunk samples become candidates */
            size_t worst = f->samples;
            double most = 0.0;
            for (i = 0; i < f->samples; ++i)
                if (!f->active[i] && f->trial[i] > most) { most = f->trial[i]; worst = i; }
            if (worst == f->samples) break;
            f->active[worst] = 1;
            f->candidate[k++] = (uint32_t)worst;
        }
        if (k == done) break;
        for (i = done; i < k; ++i) /* the new candidates' g_i, then y_i = L^-1 g_i in their place */
            sqffd__fit_fold_sample(s->dims, control, inverse, f->sample[f->candidate[i]], f->solved + i * size);
        sqffd__la_forward(f->factor, size, 1, f->solved + done * size, k - done);
        for (i = done; i < k; ++i) { /* their products, their need */
            const double *y = f->solved + i * size;
            for (j = 0; j <= i; ++j)
                f->gram[i * stride + j] = f->gram[j * stride + i] = sqffd__la_dot(y, f->solved + j * size, size);
            f->gram[i * stride + i] += 1.0 / weight;
            f->need[i] = SQFFD__FIT_MARGIN - f->value[f->candidate[i]] - sqffd__la_dot(y, f->base, size);
        }
        done = k;
        sqffd__fit_fold_multipliers(f, k);
        memcpy(f->move, f->base, size * sizeof(double));
        for (i = 0; i < k; ++i)
            if (f->multiplier[i] > 0.0)
                for (p = 0; p < size; ++p) f->move[p] += f->multiplier[i] * f->solved[i * size + p];
        sqffd__la_backward(f->factor, size, 1, f->move);
    }
    return sqffd__fit_fold_predicted(s, f, inverse, weight, k);
}

/* ---- the iteration --------------------------------------------------------- */
/* The Welsch scale nu of robust mode: this many robust standard deviations
   (1.4826 x the median) of the starting model's errors. */
#define SQFFD__FIT_WELSCH 3.0

/* Robust mode: nu^2 from the starting model's distances (scratch: n doubles, reordered). */
static double sqffd__fit_welsch_nu2(double *distance, size_t n)
{
    double nu = SQFFD__FIT_WELSCH * 1.4826 * sqffd__sq_select(distance, n, n / 2);
    return nu * nu;
}

/* The model points the model -> data term holds: those of every
   hold_step-th row and column, and the poles. On the grid every other (a
   quarter of the grid, enough to hold a smooth surface at a quarter of the
   nearest-data queries); on the coarse grid, every point (as dense on the
   surface). */
static int sqffd__fit_holds(const sqffd__fit_system *s, size_t v)
{
    size_t cols = (size_t)s->grid[1], step = s->hold_step;
    return v >= (size_t)s->grid[0] * cols || ((v / cols) % step == 0 && (v % cols) % step == 0);
}

static size_t sqffd__fit_holding(const sqffd__fit_system *s)
{
    size_t step = s->hold_step;
    return (((size_t)s->grid[0] + step - 1) / step) * (((size_t)s->grid[1] + step - 1) / step) + 2;
}

/* The data point nearest to model point v at y, from its last query's
   SQFFD__FIT_DATA_KNN nearest: every other data point was at least `far`
   (the farthest of them) from where v was then, so at least far - (its
   move since) now; while the nearest of them is nearer than that, it is
   the nearest of all. Else a fresh query. */
static size_t sqffd__fit_nearest_data(const sqffd_kdtree *tree, sqffd__fit_work *w, const double y[3], size_t v)
{
    uint32_t *near = w->data_near + SQFFD__FIT_DATA_KNN * v;
    size_t found[SQFFD__FIT_DATA_KNN], count, k, best;
    double d2[SQFFD__FIT_DATA_KNN], best2;
    double limit = HUGE_VAL;
    if (near[0] != UINT32_MAX) {
        double reach = w->data_far[v] - sqrt(sqffd__dist2_3(y, w->data_at + 3 * v));
        best = near[0];
        best2 = limit = sqffd__kd_dist2(&tree->points, near[0], y);
        for (k = 1; k < SQFFD__FIT_DATA_KNN && near[k] != UINT32_MAX; ++k) {
            double e = sqffd__kd_dist2(&tree->points, near[k], y);
            if (e < best2) { best2 = e; best = near[k]; }
            limit = e > limit ? e : limit;
        }
        if (reach > 0.0 && best2 < reach * reach) return best;
        if (k < SQFFD__FIT_DATA_KNN) limit = HUGE_VAL; /* (fewer kept: no bound from them) */
    }
    /* the kept ones bound the new query: they are SQFFD__FIT_DATA_KNN points within `limit` */
    count = sqffd__kd_query(tree, y, limit * (1.0 + 1e-9), 0, found, d2, SQFFD__FIT_DATA_KNN);
    for (k = 0; k < SQFFD__FIT_DATA_KNN; ++k) near[k] = k < count ? (uint32_t)found[k] : UINT32_MAX;
    memcpy(w->data_at + 3 * v, y, 3 * sizeof(double));
    w->data_far[v] = count == SQFFD__FIT_DATA_KNN ? sqrt(d2[count - 1]) : HUGE_VAL; /* (fewer: all the data) */
    return count ? found[0] : 0;
}

/* The two-step loop from the model's current control points, with the
   system already prepared for its superquadric, box and grid (tracking
   reuses it frame after frame), in phases:
     begin    the starting model points, the searches without a warm start;
     scale    robust mode: the Welsch scale from the starting model;
   then per round
     measure  one pass over the data: the error, the energy of the current
              control points, step 1's sums;
     accept or roll back  a step that raised the energy: an extrapolation
              gives way to the plain step from the last accepted control
              points, whose energy cannot be higher; a plain step (only
              rounding makes it rise) to the accepted control points, and
              the loop ends on them;
     record   the accepted model's figures in the report;
     advance  step 1's targets, step 2's plain step, the next control
              points (the plain step over-relaxed, or itself once
              converged).
   The first pass is exact with SQFFD__FIT_EXACT_START in mode, the last
   with SQFFD__FIT_EXACT_END (else they are local answers); rep->sq_error
   receives the error of the starting model. */
#define SQFFD__FIT_EXACT_START 1
#define SQFFD__FIT_EXACT_END 2
#define SQFFD__FIT_EXACT (SQFFD__FIT_EXACT_START | SQFFD__FIT_EXACT_END)
#define SQFFD__FIT_COARSE 4 /* the coarse stage: progress as SQFFD_STAGE_COARSE, no measures over all points */
#define SQFFD__FIT_MEASURED 8 /* the caller measures the start's error over all points (sqffd__fit_run) */

/* How the current control points came about: it decides whether a rise of
   the energy rolls them back, to what, and how far the next step goes. */
typedef enum sqffd__fit_origin {
    SQFFD__FIT_FROM_START,    /* the model as given: never rolled back */
    SQFFD__FIT_FROM_EXTRAPOLATION, /* an over-relaxed step: rolled back to the plain step */
    SQFFD__FIT_FROM_PLAIN,    /* the plain step: rolled back to the accepted control points */
    SQFFD__FIT_FROM_ACCEPTED  /* the accepted ones, restored: measured once more, the last pass */
} sqffd__fit_origin;

/* The iteration's state between its phases. */
typedef struct sqffd__fit_iteration {
    const sqffd_points *points;    /* the data (the FFD subsample) */
    const sqffd_fit_options *o;
    const sqffd__fit_system *s;
    const sqffd_kdtree *data_tree; /* the model -> data term's (NULL: no such term) */
    sqffd__fit_work *w;
    sqffd_model *model;            /* its control points are the current ones */
    sqffd_fit_report *rep;
    int mode;
    double diagonal;
    size_t holding;                /* H: the model points the model -> data term holds */
    double *x, *next;              /* M x 3: B P of the current control points, and the spare (meanwhile the
                                      nearest data points of the holding model points, from measure to advance) */
    sqffd__fit_search search;      /* over x */
    sqffd__fit_step1 step1;        /* the pass's sums, into w->target and w->weights */
    sqffd__fit_origin origin;
    double accepted;               /* the energy of w->accepted */
    double omega;                  /* the over-relaxation of the last extrapolation */
    double *planes;                /* the fold-free step's point-to-plane sums (NULL: none) */
} sqffd__fit_iteration;

/* The control points changed: their model points into it->x, and the
   search told its mesh moved. */
static void sqffd__fit_control_changed(sqffd__fit_iteration *it)
{
    double *swap = it->x;
    sqffd__fit_evaluate(it->s, (const double (*)[3])it->model->ffd.control, (double (*)[4])it->w->block, it->next);
    sqffd__fit_moved(&it->search);
    it->x = it->next;
    it->next = swap;
}

/* The kind of the coming pass: exact as the first with
   SQFFD__FIT_EXACT_START in mode, final (exact, from the matched
   triangles) as the last with SQFFD__FIT_EXACT_END, else local answers. */
static void sqffd__fit_pass_kind(sqffd__fit_iteration *it, int last)
{
    it->search.final = last && (it->mode & SQFFD__FIT_EXACT_END);
    it->search.exact = (it->origin == SQFFD__FIT_FROM_START && (it->mode & SQFFD__FIT_EXACT_START)) || it->search.final;
}

/* Begin: the iteration's state for these arguments (sqffd__fit_iterate's),
   the model points of the starting control points, the search over them in
   the points' order, no warm start and no kept model -> data queries, no
   factor to reuse; the report's counts zeroed. */
static void sqffd__fit_begin(sqffd__fit_iteration *it, const sqffd_points *points, double diagonal,
                             const sqffd_fit_options *o, const sqffd__fit_system *s, const sqffd_kdtree *data_tree,
                             sqffd__fit_work *w, int mode, sqffd_model *model, sqffd_fit_report *rep)
{
    size_t i, v, n = points->count;
    SQFFD_ASSERT(w->target && w->x && w->next); /* (the arena's: never NULL here) */
    it->points = points;
    it->o = o;
    it->s = s;
    it->data_tree = data_tree;
    it->w = w;
    it->model = model;
    it->rep = rep;
    it->mode = mode;
    it->diagonal = diagonal;
    it->holding = sqffd__fit_holding(s);
    it->x = w->x;
    it->next = w->next;
    sqffd__fit_evaluate(s, (const double (*)[3])model->ffd.control, (double (*)[4])w->block, it->x);
    sqffd__fit_search_init(&it->search, it->x, s->grid, s->rings, w->tree_ws, w->tree_size, &w->bvh);
    it->search.triangle = w->triangle;
    it->search.matched = w->matched;
    sqffd__fit_ordered(points, w, &it->search); /* (before the warm start is cleared: its arrays are the scratch) */
    for (i = 0; i < n; ++i) {
        w->matched[i][0] = UINT32_MAX;
        w->triangle[i][0] = UINT32_MAX;
    }
    if (data_tree)
        for (v = 0; v < s->count; ++v) w->data_near[SQFFD__FIT_DATA_KNN * v] = UINT32_MAX;
    w->factored = 0;
    it->planes = NULL;
    it->step1.weights = w->weights;
    it->step1.nu2 = w->nu2;
    it->origin = SQFFD__FIT_FROM_START;
    it->accepted = HUGE_VAL;
    it->omega = SQFFD__FIT_RELAX;
    rep->iterations = 0;
    rep->converged = 0;
    rep->stop = SQFFD_FIT_CAPPED;
    rep->history_count = 0;
}

/* Scale (robust mode, the scale not yet known): the Welsch scale from a
   pass over the starting model, its distances only, of the first measure's
   kind. Where that is exact, the first measure then starts from its
   answers (nothing moved): mode loses SQFFD__FIT_EXACT_START. */
static sqffd_result sqffd__fit_scale(sqffd__fit_iteration *it)
{
    sqffd__fit_work *w = it->w;
    sqffd_distance_stats unused;
    sqffd_result res;
    sqffd__fit_pass_kind(it, it->o->max_iterations == 0);
    res = sqffd__fit_pass(it->points, &it->search, it->diagonal, w->distance, NULL, &unused);
    if (res != SQFFD_OK) return res;
    /* (0 for a start that fits exactly: plain squares) */
    it->step1.nu2 = w->nu2 = sqffd__fit_welsch_nu2(w->distance, it->points->count);
    it->mode &= ~SQFFD__FIT_EXACT_START;
    return SQFFD_OK;
}

/* Measure: one pass over the data against the current model points (the
   error into *stats; with sums, step 1's sums into w->target and
   w->weights), each holding model point's nearest data point (into
   it->next) for the model -> data term, and the current control points'
   energy (THE ENERGY). */
static sqffd_result sqffd__fit_measure(sqffd__fit_iteration *it, int last, double *energy, sqffd_distance_stats *stats)
{
    const sqffd__fit_system *s = it->s;
    sqffd__fit_work *w = it->w;
    size_t m = s->count, v;
    double reverse = 0.0;
    sqffd_result res;
    it->step1.sums = last ? NULL : w->target; /* (the last pass only measures) */
    it->step1.planes = last ? NULL : it->planes;
    if (it->step1.sums) {
        memset(w->target, 0, 3 * m * sizeof(double));
        memset(w->weights, 0, m * sizeof(double));
    }
    if (it->step1.planes) memset(it->planes, 0, 6 * m * sizeof(double));
    it->search.x = it->x;
    sqffd__fit_pass_kind(it, last);
    res = sqffd__fit_pass(it->points, &it->search, it->diagonal, NULL, &it->step1, stats);
    if (res != SQFFD_OK) return res;
    if (it->data_tree)
        for (v = 0; v < m; ++v)
            if (sqffd__fit_holds(s, v)) {
                double q[3];
                sqffd__points_get(&it->data_tree->points, sqffd__fit_nearest_data(it->data_tree, w, it->x + 3 * v, v), q);
                reverse += sqffd__dist2_3(q, it->x + 3 * v);
                memcpy(it->next + 3 * v, q, 3 * sizeof(double));
            }
    *energy = it->step1.energy / (double)it->points->count +
              sqffd__fit_prior(s, &it->model->ffd.control[0][0], it->x) / (double)m +
              it->o->model_to_data * reverse / (double)it->holding;
    return SQFFD_OK;
}

/* Accept or roll back the control points just measured at this energy.
   Accepted (1): they, their energy and the pass's matches become the
   accepted ones. Rolled back (0, a step that raised the energy): the
   control points are replaced (see sqffd__fit_origin) with the accepted
   matches, which bound their energy, and must be measured again. */
static int sqffd__fit_accept_or_roll_back(sqffd__fit_iteration *it, double energy)
{
    sqffd__fit_work *w = it->w;
    size_t size = 3 * it->s->lattice, n = it->points->count;
    double *control = &it->model->ffd.control[0][0];
    int extrapolated = it->origin == SQFFD__FIT_FROM_EXTRAPOLATION;
    if ((extrapolated || it->origin == SQFFD__FIT_FROM_PLAIN) && energy > it->accepted) {
        memcpy(control, extrapolated ? w->plain : w->accepted, size * sizeof(double));
        memcpy(w->matched, w->matched_accepted, n * sizeof *w->matched);
        it->origin = extrapolated ? SQFFD__FIT_FROM_PLAIN : SQFFD__FIT_FROM_ACCEPTED;
        sqffd__fit_control_changed(it);
        return 0;
    }
    it->accepted = energy;
    memcpy(w->accepted, control, size * sizeof(double));
    memcpy(w->matched_accepted, w->matched, n * sizeof *w->matched);
    return 1;
}

/* Record the accepted model in the report: its error and energy; the
   start's error, or an iteration's history entry and progress call (not
   for the accepted control points measured again). CANCELLED when the
   progress callback asks. */
static sqffd_result sqffd__fit_record(sqffd__fit_iteration *it, double energy, const sqffd_distance_stats *stats)
{
    sqffd_fit_report *rep = it->rep;
    const sqffd_fit_options *o = it->o;
    rep->error = *stats;
    rep->energy = energy;
    if (it->origin == SQFFD__FIT_FROM_START) rep->sq_error = *stats;
    else if (it->origin != SQFFD__FIT_FROM_ACCEPTED) {
        if (rep->iterations <= SQFFD_FIT_HISTORY) {
            rep->history[rep->history_count] = stats->rms_relative;
            rep->energy_history[rep->history_count++] = energy;
        }
        if (o->progress && o->progress(o->progress_user, it->mode & SQFFD__FIT_COARSE ? SQFFD_STAGE_COARSE : SQFFD_STAGE_FFD,
                                       rep->iterations, stats->rms_relative))
            return SQFFD_ERROR_CANCELLED;
    }
    return SQFFD_OK;
}

/* Step 1 from the pass's sums: per model point, W_v into w->weights and
   W_v y_v into w->target (each data point pulls the three corners of its
   closest triangle by its barycentric weights), in units where the W_v
   average 1; plus, at a holding model point, its nearest data point (in
   it->next) with weight model_to_data M / H. */
static void sqffd__fit_targets(sqffd__fit_iteration *it)
{
    const sqffd__fit_system *s = it->s;
    sqffd__fit_work *w = it->w;
    size_t m = s->count, v, p;
    double scale = (double)m / (double)it->points->count, hold = it->o->model_to_data * (double)m / (double)it->holding;
    double *t = w->target, *x = it->x;
    for (v = 0; v < m; ++v) {
        double wv = scale * w->weights[v];
        for (p = 0; p < 3; ++p) t[3 * v + p] = scale * t[3 * v + p] + wv * x[3 * v + p];
        if (it->data_tree && sqffd__fit_holds(s, v)) {
            wv += hold;
            for (p = 0; p < 3; ++p) t[3 * v + p] += hold * it->next[3 * v + p];
        }
        w->weights[v] = wv;
    }
}

/* Advance from the accepted control points: step 1's targets, step 2's
   plain step G(P) (w->plain, and G(P) - P in w->rhs), whose move B (G(P) -
   P) decides convergence (only a direct step's: a lagged one may stop
   short, so the next step is direct), then the next control points P +
   omega (G(P) - P) and their model points. omega (SQFFD__FIT_RELAX) grows
   after an accepted extrapolation; once converged the plain step itself is
   taken (an extrapolation would only overshoot). */
static sqffd_result sqffd__fit_advance(sqffd__fit_iteration *it)
{
    const sqffd__fit_system *s = it->s;
    sqffd__fit_work *w = it->w;
    sqffd_fit_report *rep = it->rep;
    size_t m = s->count, size = 3 * s->lattice, i;
    double *control = &it->model->ffd.control[0][0];
    double length; /* of the step along G(P) - P */
    int direct, extrapolate;
    sqffd_result res;
    sqffd__fit_targets(it);
    res = sqffd__fit_step(s, w, control, it->x, w->target, it->next, &direct); /* (B (G(P) - P) into it->next,
                                                                                 read by the targets before) */
    if (res != SQFFD_OK) return res;
    rep->step = sqrt(sqffd__la_dot(it->next, it->next, 3 * m) / (double)m) / it->diagonal;
    ++rep->iterations;
    rep->converged = rep->step <= it->o->tolerance && direct;
    if (rep->step <= it->o->tolerance && !direct) w->factored = 0;
    it->omega = it->origin == SQFFD__FIT_FROM_EXTRAPOLATION
                    ? (it->omega * SQFFD__FIT_RELAX_GROW < SQFFD__FIT_RELAX_MAX ? it->omega * SQFFD__FIT_RELAX_GROW
                                                                               : SQFFD__FIT_RELAX_MAX)
                    : SQFFD__FIT_RELAX;
    extrapolate = !rep->converged;
    length = extrapolate ? it->omega : 1.0;
    for (i = 0; i < size; ++i) control[i] += length * w->rhs[i];
    it->origin = extrapolate ? SQFFD__FIT_FROM_EXTRAPOLATION : SQFFD__FIT_FROM_PLAIN;
    sqffd__fit_control_changed(it);
    return SQFFD_OK;
}

static sqffd_result sqffd__fit_iterate_fold_free(sqffd__fit_iteration *it);

static sqffd_result sqffd__fit_iterate(const sqffd_points *points, double diagonal, const sqffd_fit_options *o,
                                       const sqffd__fit_system *s, const sqffd_kdtree *data_tree, sqffd__fit_work *w,
                                       int mode, sqffd_model *model, sqffd_fit_report *rep)
{
    sqffd__fit_iteration it;
    sqffd_result res;
    sqffd__fit_begin(&it, points, diagonal, o, s, data_tree, w, mode, model, rep);
    if (w->distance && !(w->nu2 > 0.0)) {
        res = sqffd__fit_scale(&it);
        if (res != SQFFD_OK) return res;
    }
    if (o->min_jacobian > -HUGE_VAL) return sqffd__fit_iterate_fold_free(&it);
    for (;;) {
        double energy;
        sqffd_distance_stats stats;
        int last = rep->iterations == o->max_iterations || rep->converged || it.origin == SQFFD__FIT_FROM_ACCEPTED;
        res = sqffd__fit_measure(&it, 0, &energy, &stats);
        if (res != SQFFD_OK) return res;
        if (!sqffd__fit_accept_or_roll_back(&it, energy)) continue; /* rolled back: measure the replacement */
        if (last && (it.mode & SQFFD__FIT_EXACT_END) && !it.search.exact) /* the model a longer run passes through */
            res = sqffd__fit_measure(&it, 1, &energy, &stats);                  /* too, then measured exactly */
        if (res == SQFFD_OK) res = sqffd__fit_record(&it, energy, &stats);
        if (last) { /* the region's bound, refined where it folds */
            if (!sqffd__fit_region(model, w->fold)) return SQFFD_ERROR_NON_FINITE;
            w->fold->goal = -HUGE_VAL;
            rep->min_jacobian = sqffd__fit_fold_certify(s->dims, w->fold, &model->ffd.control[0][0], model->ffd.inverse, 0.0);
            rep->stop = rep->converged ? SQFFD_FIT_CONVERGED
                        : it.origin == SQFFD__FIT_FROM_ACCEPTED ? SQFFD_FIT_STALLED : SQFFD_FIT_CAPPED;
        }
        if (res != SQFFD_OK || last) return res;
        res = sqffd__fit_advance(&it);
        if (res != SQFFD_OK) return res;
    }
}

/* ---- the fold-free iteration ----------------------------------------------
   The fold-free step's loop (its section above): measure the start; then
   per iteration the damped step from the accepted model, measured by a
   pass; accepted when it lowers the energy and is certified (then
   linearised anew from that pass), else rolled back with more damping, or
   taken again with the certificate's failing points as samples. The fit
   ends on the last accepted model the certificate passed. A start that
   breaks the floor on the region is first drawn toward the regular
   lattice until certified (sqffd__fit_fold_untangle). */

/* The point-to-plane weights (M x 6) gathered onto every other model point
   of every other row (each takes its own, the next in its row, and those of
   the next row: B's rows vary little across a cell of the grid, so the
   step's matrix from them is the same to a few parts in a thousand, at a
   quarter of the cost); the poles keep theirs. */
static void sqffd__fit_fold_coarsen(const sqffd__fit_system *s, double *plane)
{
    size_t rows = (size_t)s->grid[0], cols = (size_t)s->grid[1], i, j, c;
    for (i = 0; i < rows; ++i)
        for (j = 0; j < cols; ++j) {
            double *to = plane + 6 * ((i - i % 2) * cols + (j - j % 2));
            double *from = plane + 6 * (i * cols + j);
            if (from == to) continue;
            for (c = 0; c < 6; ++c) {
                to[c] += from[c];
                from[c] = 0.0;
            }
        }
}

/* The energy's Gauss-Newton matrix and gradient at the current model from
   its pass (w->target, w->weights, f->planes; it->next: the holding model
   points' nearest data): f->hessian, f->gradient, f->damping, and the
   samples' J and crosses (J's linear model). */
static void sqffd__fit_fold_linearise(sqffd__fit_iteration *it)
{
    static const int entry[3][3] = {{0, 1, 2}, {1, 3, 4}, {2, 4, 5}}; /* f->planes' order */
    const sqffd__fit_system *s = it->s;
    sqffd__fit_work *w = it->w;
    sqffd__fit_fold *f = w->fold;
    size_t m = s->count, l = s->lattice, size = 3 * l, v, c, c2;
    double scale = (double)m / (double)it->points->count, trace = 0.0;
    double hold = it->o->model_to_data * (double)m / (double)it->holding;
    const double *control = &it->model->ffd.control[0][0];
    double *t = w->target, *plane = f->planes;
    for (v = 0; v < m; ++v) { /* minus the gradient per model point; the point-to-point and -to-plane weights */
        int held = it->data_tree && sqffd__fit_holds(s, v);
        double slide = SQFFD__FIT_SLIDE * scale * w->weights[v]; /* (of the data's point-to-point weight) */
        for (c = 0; c < 3; ++c) t[3 * v + c] = scale * t[3 * v + c] + (held ? hold * (it->next[3 * v + c] - it->x[3 * v + c]) : 0.0);
        w->weights[v] = scale * w->weights[v] + (held ? hold : 0.0);
        for (c = 0; c < 6; ++c) /* (xx yy zz: 0 3 5) */
            plane[6 * v + c] = scale * plane[6 * v + c] + (c == 0 || c == 3 || c == 5 ? slide + (held ? hold : 0.0) : 0.0);
    }
    /* the damping: the lattice's Laplacian, scaled to the trace of B^T W B (W: the point-to-point weights;
       B's row at v is a (x) b (x) c, its squared norm the product of theirs) */
    for (v = 0; v < m; ++v) {
        const double *a = s->weights + v * s->stride;
        double norms[3] = {0.0, 0.0, 0.0};
        size_t e, axis, from = 0;
        for (axis = 0; axis < 3; from += (size_t)s->dims[axis], ++axis)
            for (e = 0; e < (size_t)s->dims[axis]; ++e) norms[axis] += a[from + e] * a[from + e];
        trace += w->weights[v] * norms[0] * norms[1] * norms[2];
    }
    f->damping = trace / sqffd__fit_laplacian_trace(s->dims);
    sqffd__fit_fold_coarsen(s, plane);
    memset(f->hessian, 0, sqffd__packed_row(size) * sizeof(double));
    ++f->factor_age;
    for (c = 0; c < 3; ++c)
        for (c2 = 0; c2 <= c; ++c2) {
            for (v = 0; v < m; ++v) w->weights[v] = plane[6 * v + (size_t)entry[c][c2]];
            if (c == c2) memcpy(w->matrix, s->fixed, l * l * sizeof(double));
            else memset(w->matrix, 0, l * l * sizeof(double));
            sqffd__fit_gram(s, w->weights, 1.0, w->pairs, w->block, w->matrix);
            sqffd__fit_fold_scatter(l, w->matrix, c, c2, f->hessian);
        }
    sqffd__fit_project(s, t, NULL, s->rhs0, (double (*)[3])w->block, f->gradient); /* B^T t + rhs0 - fixed P */
    sqffd__fit_planar(control, l, f->move);
    for (c = 0; c < 3; ++c) {
        sqffd__fit_symmetric_times(s->fixed, l, 0, f->move + c * l, f->scratch);
        for (v = 0; v < l; ++v) f->gradient[c * l + v] -= f->scratch[v];
    }
    sqffd__fit_fold_values(s->dims, f, control, it->model->ffd.inverse, f->value, f->cross); /* (J's linear model) */
}

/* The control points back to the accepted ones, with their matches. */
static void sqffd__fit_fold_roll_back(sqffd__fit_iteration *it)
{
    memcpy(&it->model->ffd.control[0][0], it->w->accepted, 3 * it->s->lattice * sizeof(double));
    memcpy(it->w->matched, it->w->matched_accepted, it->points->count * sizeof *it->w->matched);
    sqffd__fit_control_changed(it);
}

/* The certificate's points as new samples (as many as there is room for). */
static void sqffd__fit_fold_add_samples(sqffd__fit_iteration *it, const double *control)
{
    sqffd__fit_fold *f = it->w->fold;
    size_t i;
    for (i = 0; i < f->failed && f->samples < f->capacity; ++i, ++f->samples) {
        double d[9];
        memcpy(f->sample[f->samples], f->fails[i], sizeof f->fails[i]);
        f->node[f->samples] = SQFFD__FIT_OFF_GRID;
        sqffd__fit_fold_frame(it->s->dims, control, 3, 1, it->model->ffd.inverse, f->fails[i], d, NULL);
        f->value[f->samples] = sqffd__fit_fold_crosses(d, f->cross[f->samples]) - f->goal;
    }
}

/* A start under the floor on its region (a folded model handed in) drawn
   toward the regular lattice P0, where J is 1 everywhere: P0 + s (P - P0)
   with the largest s in [0, 1] the certificate passes at the floor, found
   to 1/2^SQFFD__FIT_UNTANGLE by halving (s = 0 passes at any floor under 1;
   at exactly 1 the box's rounding decides), so every fit under the floor
   starts, and ends, certified.
   The model keeps as much of its deformation as the floor allows along
   that line; the fit then recovers the rest the floor allows. Returns the
   start's certified bound. */
#define SQFFD__FIT_UNTANGLE 10 /* halvings: the start within 1/1024 of the line's last certified point */
static double sqffd__fit_fold_untangle(sqffd__fit_iteration *it)
{
    const sqffd__fit_system *s = it->s;
    sqffd__fit_fold *f = it->w->fold;
    double *control = &it->model->ffd.control[0][0], *start = it->w->accepted, kept = 0.0, cut = 1.0;
    size_t size = 3 * s->lattice, v;
    int k;
    memcpy(start, control, size * sizeof(double));
    for (k = 0; k <= SQFFD__FIT_UNTANGLE; ++k) {
        double share = k < SQFFD__FIT_UNTANGLE ? 0.5 * (kept + cut) : kept; /* (last: the share kept) */
        for (v = 0; v < size; ++v) control[v] = (1.0 - share) * s->rest_control[v] + share * start[v]; /* (no overflow) */
        if (k == SQFFD__FIT_UNTANGLE) break;
        if (sqffd__fit_fold_certify(s->dims, f, control, it->model->ffd.inverse, f->goal) >= f->goal) kept = share;
        else cut = share;
    }
    sqffd__fit_control_changed(it);
    return sqffd__fit_fold_certify(s->dims, f, control, it->model->ffd.inverse, f->goal);
}

static sqffd_result sqffd__fit_iterate_fold_free(sqffd__fit_iteration *it)
{
    const sqffd__fit_system *s = it->s;
    const sqffd_fit_options *o = it->o;
    sqffd__fit_work *w = it->w;
    sqffd__fit_fold *f = w->fold;
    sqffd_fit_report *rep = it->rep;
    sqffd_model *model = it->model;
    double *control = &model->ffd.control[0][0], *swap;
    const double *inverse = model->ffd.inverse;
    size_t size = 3 * s->lattice, m = s->count, v;
    double energy, penalty, bound;
    sqffd_distance_stats stats, accepted_stats;
    int stalled = 0;
    sqffd_result res;
    if (!sqffd__fit_region(model, f)) return SQFFD_ERROR_NON_FINITE;
    f->goal = o->min_jacobian;
    bound = sqffd__fit_fold_certify(s->dims, f, control, inverse, o->min_jacobian);
    if (bound < o->min_jacobian && rep->iterations < o->max_iterations) bound = sqffd__fit_fold_untangle(it);
    it->planes = f->planes;
    res = sqffd__fit_measure(it, 0, &energy, &stats);
    if (res == SQFFD_OK) res = sqffd__fit_record(it, energy, &stats);
    if (res != SQFFD_OK) return res;
    f->factor_age = SQFFD__FIT_FACTOR_AGE;
    sqffd__fit_fold_linearise(it);
    f->rho = 2.0 * (energy > 0.0 ? energy : 1.0) / (SQFFD__FIT_MARGIN * SQFFD__FIT_MARGIN);
    penalty = sqffd__fit_fold_penalty(f, f->value);
    f->lambda = SQFFD__FIT_LAMBDA_START;
    it->accepted = energy;
    accepted_stats = stats;
    rep->min_jacobian = bound;
    memcpy(w->accepted, control, size * sizeof(double));
    memcpy(w->matched_accepted, w->matched, it->points->count * sizeof *w->matched);
    while (rep->iterations < o->max_iterations && !rep->converged && !stalled) {
        double predicted = sqffd__fit_fold_step(s, f, w->accepted, inverse, (double)m * f->rho), move = 0.0, tau;
        double trial_penalty;
        size_t p;
        int c;
        if (!(predicted > 0.0)) { /* no factor, or no descent in the step's model: damp more */
            f->lambda *= 8.0;
            stalled = !(f->lambda <= 1e12);
            continue;
        }
        if (predicted < SQFFD__FIT_SETTLED * o->tolerance * (it->accepted + penalty) * (double)m && f->factored <= 1.0) {
            if (f->factor_age > 0 || f->factored != f->lambda) { /* judged on this model's own matrix, not a kept one */
                f->factor_age = SQFFD__FIT_FACTOR_AGE;
                continue;
            }
            rep->converged = 1; /* the next step would lower the energy by under 10 x tolerance of it: not taken */
            break;
        }
        for (tau = 1.0;; tau *= 0.5) { /* shortened (no pass needed) while J's curvature sinks a sample under the floor */
            for (p = 0; p < s->lattice; ++p)
                for (c = 0; c < 3; ++c)
                    control[3 * p + (size_t)c] = w->accepted[3 * p + (size_t)c] + tau * f->move[(size_t)c * s->lattice + p];
            if (!(sqffd__fit_fold_values(s->dims, f, control, inverse, f->trial, NULL) < 0.0) || tau < 1e-3) break;
        }
        predicted *= tau * (2.0 - tau);
        sqffd__fit_control_changed(it); /* (it->next: the accepted model points) */
        for (v = 0; v < 3 * m; ++v) move += (it->x[v] - it->next[v]) * (it->x[v] - it->next[v]);
        it->origin = SQFFD__FIT_FROM_PLAIN;
        ++rep->iterations;
        res = sqffd__fit_measure(it, 0, &energy, &stats);
        if (res != SQFFD_OK) return res;
        trial_penalty = sqffd__fit_fold_penalty(f, f->trial);
        bound = energy < it->accepted ? sqffd__fit_fold_certify(s->dims, f, control, inverse, o->min_jacobian) : -HUGE_VAL;
        if (bound >= o->min_jacobian) { /* lower and certified: accepted (lambda rises when the penalised energy did not fall) */
            double gain = (it->accepted + penalty - energy - trial_penalty) * (double)m / predicted;
            f->lambda = tau < 1.0 || gain < 0.25 ? 2.0 * f->lambda : gain > 0.75 ? f->lambda / 3.0 : f->lambda;
            swap = f->value; f->value = f->trial; f->trial = swap;
            it->accepted = energy;
            accepted_stats = stats;
            rep->min_jacobian = bound;
            memcpy(w->accepted, control, size * sizeof(double));
            memcpy(w->matched_accepted, w->matched, it->points->count * sizeof *w->matched);
            rep->step = sqrt(move / (double)m) / it->diagonal;
            penalty = sqffd__fit_fold_penalty(f, f->value);
            rep->converged = tau == 1.0 && rep->step <= o->tolerance;
            sqffd__fit_fold_linearise(it);
        } else { /* rolled back: more damping, or the certificate's points as samples */
            sqffd__fit_fold_roll_back(it);
            if (bound > -HUGE_VAL && f->failed && f->samples < f->capacity) {
                sqffd__fit_fold_add_samples(it, w->accepted);
                penalty = sqffd__fit_fold_penalty(f, f->value);
            } else {
                f->lambda *= 8.0;
                stalled = !(f->lambda <= 1e12);
            }
        }
        res = sqffd__fit_record(it, it->accepted, &accepted_stats);
        if (res != SQFFD_OK) return res;
    }
    /* the accepted model, measured again where the last pass must be exact */
    it->origin = SQFFD__FIT_FROM_ACCEPTED;
    it->planes = NULL;
    SQFFD_ASSERT(control[0] == w->accepted[0]); /* (every path out of the loop leaves the accepted model current) */
    if ((it->mode & SQFFD__FIT_EXACT_END) && !it->search.exact) {
        res = sqffd__fit_measure(it, 1, &it->accepted, &accepted_stats);
        if (res == SQFFD_OK && rep->history_count > 0 && rep->iterations <= SQFFD_FIT_HISTORY) {
            rep->history[rep->history_count - 1] = accepted_stats.rms_relative; /* (the last entry is the model's) */
            rep->energy_history[rep->history_count - 1] = it->accepted;
        }
    }
    if (res == SQFFD_OK) res = sqffd__fit_record(it, it->accepted, &accepted_stats);
    rep->stop = rep->converged ? SQFFD_FIT_CONVERGED : stalled ? SQFFD_FIT_STALLED : SQFFD_FIT_CAPPED;
    return res;
}

/* ---- public entry points ------------------------------------------------- */

/* A frame's scratch after the system: stage 1's subsample and workspace when
   the frame gets the whole fit, then the iteration's. */
typedef struct sqffd__fit_frame {
    double *sample;      /* stage 1's subsample (NULL: all points) */
    void *sq_ws;
    size_t sq_size;
    sqffd_fit_report *report; /* where the report goes when the caller passes none (not on the stack: 1.4 KB) */
    sqffd__fit_work w;
    int coarse_grid[2];  /* the coarse stage (0 0: none) ... */
    sqffd_model *coarse_model; /* ... its model (not on the stack: 12 KB), system and scratch */
    sqffd__fit_system coarse;
    sqffd__fit_work coarse_w;
} sqffd__fit_frame;

/* The coarse stage's grid for these options, lattice and grid, or 0 (none):
   half the rows and columns, where that still meshes and leaves at least
   SQFFD__FIT_COARSE_SHARE model points a control point (else the fit is
   left to the springs: 16 x 32 has 514, a 5 x 5 x 5 lattice 125). */
#define SQFFD__FIT_COARSE_SHARE 4

static int sqffd__fit_coarse_grid(const sqffd_fit_options *o, const int dims[3], const int grid[2], int coarse[2])
{
    size_t l = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2];
    coarse[0] = grid[0] / 2;
    coarse[1] = grid[1] / 2;
    if (o->coarse_iterations > 0 && o->max_iterations > 1 && coarse[0] >= 2 && coarse[1] >= 3 &&
        sqffd__fit_grid_count(coarse) >= SQFFD__FIT_COARSE_SHARE * l)
        return 1;
    coarse[0] = coarse[1] = 0;
    return 0;
}

/* The coarse stage's options: its iterations (never all), its subsample. */
static sqffd_fit_options sqffd__fit_coarse_options(const sqffd_fit_options *o)
{
    sqffd_fit_options c = *o;
    c.max_iterations = o->coarse_iterations < o->max_iterations ? o->coarse_iterations : o->max_iterations - 1;
    c.ffd_max_points = sqffd__fit_cap(SQFFD_FIT_COARSE_POINTS, o->ffd_max_points);
    return c;
}

static void sqffd__fit_frame_layout(sqffd__arena *a, size_t n, const int dims[3], const int grid[2],
                                    const sqffd_fit_options *o, int whole, sqffd__fit_frame *f)
{
    sqffd__fit_fold *grid_fold, *coarse_fold;
    size_t mark = a->used;
    f->sample = NULL;
    f->sq_ws = NULL;
    f->sq_size = 0;
    if (whole) {
        size_t k = sqffd__fit_cap(n, o->sq_max_points);
        f->sample = k < n ? (double *)sqffd__arena_take(a, k, 3 * sizeof(double)) : NULL;
        if (sqffd_sq_fit_workspace_size(k, &o->sq, &f->sq_size) != SQFFD_OK) sqffd__arena_too_large(a);
        f->sq_ws = sqffd__arena_take(a, f->sq_size, 1);
    }
    /* The coarse stage's model and system over stage 1's memory, its scratch
       over the grid's: never live together (stage 1 and the guard end before
       the stage; each run sets up all it reads). */
    if (whole && sqffd__fit_coarse_grid(o, dims, grid, f->coarse_grid)) {
        sqffd__arena_rewind(a, &mark);
        f->coarse_model = (sqffd_model *)sqffd__arena_take(a, 1, sizeof(sqffd_model));
        sqffd__fit_system_layout(a, dims, f->coarse_grid, &f->coarse);
        f->coarse.hold_step = 1;
        sqffd__arena_past(a, mark);
    } else
        f->coarse_grid[0] = f->coarse_grid[1] = 0;
    f->report = (sqffd_fit_report *)sqffd__arena_take(a, 1, sizeof(sqffd_fit_report));
    /* (the fold-free steps' bookkeeping before the shared scratch: each stage keeps its own) */
    grid_fold = (sqffd__fit_fold *)sqffd__arena_take(a, 1, sizeof(sqffd__fit_fold));
    coarse_fold = f->coarse_grid[0] ? (sqffd__fit_fold *)sqffd__arena_take(a, 1, sizeof(sqffd__fit_fold)) : NULL;
    mark = a->used;
    sqffd__fit_work_layout(a, n, dims, grid, o, grid_fold, &f->w);
    if (f->coarse_grid[0]) {
        sqffd_fit_options c = sqffd__fit_coarse_options(o);
        sqffd__arena_rewind(a, &mark);
        sqffd__fit_work_layout(a, n, dims, f->coarse_grid, &c, coarse_fold, &f->coarse_w);
        sqffd__arena_past(a, mark);
    }
}

/* A prepared system kept in the caller's memory: its bookkeeping struct
   first, then its arrays (*state is NULL while measuring or out of room). */
static void sqffd__fit_state_layout(sqffd__arena *a, const int dims[3], const int grid[2], sqffd__fit_system **state)
{
    sqffd__fit_system scratch;
    sqffd__fit_system *s = (sqffd__fit_system *)sqffd__arena_take(a, 1, sizeof(sqffd__fit_system));
    sqffd__fit_system_layout(a, dims, grid, s ? s : &scratch);
    *state = a->overflow ? NULL : s;
}

/* The checks every fit makes of its data: enough points, finite, not all in one place. */
static sqffd_result sqffd__fit_check_data(const sqffd_points *points, double *diagonal)
{
    sqffd_result res = sqffd__points_check(points);
    size_t i;
    double p[3];
    if (res != SQFFD_OK) return res;
    if (points->count < SQFFD__FIT_MIN_POINTS) return SQFFD_ERROR_TOO_FEW_POINTS;
    res = sqffd__fit_diagonal(points, diagonal);
    if (res != SQFFD_OK) return res;
    if (*diagonal > 0.0)
        for (i = 0; i < points->count; ++i) {
            sqffd__points_get(points, i, p);
            if (!(fabs(p[0]) <= SQFFD__MAX_DATA && fabs(p[1]) <= SQFFD__MAX_DATA && fabs(p[2]) <= SQFFD__MAX_DATA))
                return SQFFD_ERROR_NON_FINITE;
        }
    return *diagonal > 0.0 ? SQFFD_OK : SQFFD_ERROR_DEGENERATE;
}

/* The options sqffd_fit reads beyond the FFD stage's. */
static sqffd_result sqffd__fit_check_whole_options(const sqffd_fit_options *o)
{
    sqffd_result res;
    if (!sqffd__ffd_dims_valid(o->lattice)) return SQFFD_ERROR_INVALID_ARGUMENT;
    res = sqffd__fit_grid_check(o->grid);
    if (res == SQFFD_OK) res = sqffd__fit_check_options(o);
    if (res == SQFFD_OK && (!(o->box_margin >= 0.0) || !isfinite(o->box_margin) || !sqffd__sq_options_valid(&o->sq)))
        res = SQFFD_ERROR_INVALID_ARGUMENT;
    return res;
}

SQFFD_DEF sqffd_result sqffd_fit_workspace_size(size_t n, const sqffd_fit_options *options, size_t *size)
{
    sqffd_fit_options defaults = sqffd_fit_options_default();
    const sqffd_fit_options *o = options ? options : &defaults;
    sqffd__arena a;
    sqffd__fit_system s;
    sqffd__fit_frame f;
    sqffd_result r;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    if (n == 0) return SQFFD_ERROR_INVALID_ARGUMENT;
    r = sqffd__fit_check_whole_options(o);
    if (r != SQFFD_OK) return r;
    sqffd__arena_measure(&a);
    sqffd__fit_system_layout(&a, o->lattice, o->grid, &s);
    sqffd__fit_frame_layout(&a, n, o->lattice, o->grid, o, 1, &f);
    return sqffd__arena_size(&a, size);
}

SQFFD_DEF sqffd_result sqffd_fit_ffd_workspace_size(size_t n, const sqffd_model *model, const sqffd_fit_options *options,
                                                    size_t *size)
{
    sqffd_fit_options defaults = sqffd_fit_options_default();
    const sqffd_fit_options *o = options ? options : &defaults;
    sqffd__arena a;
    sqffd__fit_system s;
    sqffd__fit_frame f;
    sqffd_result r;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    if (!model || n == 0) return SQFFD_ERROR_INVALID_ARGUMENT;
    r = sqffd_model_validate(model);
    if (r == SQFFD_OK) r = sqffd__fit_check_options(o);
    if (r != SQFFD_OK) return r;
    sqffd__arena_measure(&a);
    sqffd__fit_system_layout(&a, model->ffd.dims, model->grid, &s);
    sqffd__fit_frame_layout(&a, n, model->ffd.dims, model->grid, o, 0, &f);
    return sqffd__arena_size(&a, size);
}

/* The error of the model over all n points (the iterations may run on a
   subsample). */
static sqffd_result sqffd__fit_error(const sqffd_points *points, double diagonal, const sqffd__fit_system *s,
                                     sqffd__fit_work *w, const sqffd_model *model, sqffd_distance_stats *stats)
{
    sqffd__fit_search search;
    sqffd__fit_evaluate(s, model->ffd.control, (double (*)[4])w->block, w->x);
    sqffd__fit_search_init(&search, w->x, s->grid, s->rings, w->tree_ws, w->tree_size, &w->bvh);
    sqffd__fit_ordered(points, w, &search);
    return sqffd__fit_pass(points, &search, diagonal, NULL, NULL, stats);
}

/* Stage 2 with the system prepared (tracking prepares once for frame 0's
   superquadric, box and grid, then runs this per frame from the previous
   frame's control points): take the subsample, build the data tree when
   there is a model -> data term, iterate (mode: see sqffd__fit_iterate); on
   a subsample, the start and final errors over all points (not in the
   coarse stage). */
static sqffd_result sqffd__fit_run(const sqffd_points *points, double diagonal, const sqffd_fit_options *o,
                                   const sqffd__fit_system *s, sqffd__fit_work *w, int mode, sqffd_model *model,
                                   sqffd_fit_report *rep)
{
    sqffd_kdtree data_tree;
    sqffd_distance_stats start;
    sqffd_points data = w->sample ? sqffd_points_packed(w->sample, w->sample_count) : *points;
    sqffd_result res = SQFFD_OK;
    int measure = w->sample && !(mode & SQFFD__FIT_COARSE), measure_start = measure && !(mode & SQFFD__FIT_MEASURED);
    if (w->sample) sqffd__subsample(points, w->sample_count, w->sample);
    if (measure_start) res = sqffd__fit_error(points, diagonal, s, w, model, &start);
    if (res == SQFFD_OK && o->model_to_data > 0.0) {
        if (w->data) sqffd__subsample(&data, w->data_count, w->data);
        res = sqffd_kdtree_build_view(&data_tree, w->data ? sqffd_points_packed(w->data, w->data_count) : data,
                                      w->data_ws, w->data_size);
    }
    if (res == SQFFD_OK)
        res = sqffd__fit_iterate(&data, diagonal, o, s, o->model_to_data > 0.0 ? &data_tree : NULL, w, mode, model,
                                 rep);
    if (res == SQFFD_OK && measure_start) rep->sq_error = start;
    if (res == SQFFD_OK && measure) res = sqffd__fit_error(points, diagonal, s, w, model, &rep->error);
    return res;
}

/* Stage 2 with the coarse stage first: the starting model's error over
   all points on the grid (the report's
   sq_error), the coarse iterations on a copy of the model on the coarse
   grid (its own system and subsample; the same alpha per control point and
   model -> data per model point, so the same energy on a coarser mesh),
   then the grid's from where they ended, with the coarse stage's Welsch
   scale (that of the superquadric) in robust mode. The grid's stage starts
   with an exact pass: the local answers of a cold start are poor where the
   model is already close (on the phantom, 2.7x the exact error), and the
   iterations would follow them. */
static sqffd_result sqffd__fit_coarse_first(const sqffd_points *points, double diagonal, const sqffd_fit_options *o,
                                            sqffd__fit_system *s, sqffd__fit_frame *f, sqffd_model *model,
                                            sqffd_fit_report *rep)
{
    sqffd_fit_options c = sqffd__fit_coarse_options(o), fine = *o;
    sqffd_model *coarse = f->coarse_model;
    sqffd_distance_stats start;
    sqffd_result res = sqffd__fit_error(points, diagonal, s, &f->w, model, &start);
    *coarse = *model;
    coarse->grid[0] = f->coarse_grid[0];
    coarse->grid[1] = f->coarse_grid[1];
    if (res == SQFFD_OK) res = sqffd__fit_prepare(coarse, o->alpha, o->tether, o->regularization, &f->coarse);
    if (res == SQFFD_OK) res = sqffd__fit_run(points, diagonal, &c, &f->coarse, &f->coarse_w, SQFFD__FIT_COARSE, coarse, rep);
    if (res != SQFFD_OK) return res;
    rep->coarse_iterations = rep->iterations;
    memcpy(model->ffd.control, coarse->ffd.control, sizeof model->ffd.control);
    f->w.nu2 = f->coarse_w.nu2;
    fine.max_iterations = o->max_iterations - rep->coarse_iterations;
    res = sqffd__fit_run(points, diagonal, &fine, s, &f->w,
                         SQFFD__FIT_EXACT | SQFFD__FIT_MEASURED, model, rep);
    rep->sq_error = start;
    return res;
}

SQFFD_DEF sqffd_result sqffd_fit_ffd(const double *points, size_t n, const sqffd_fit_options *options, sqffd_model *model,
                                     sqffd_fit_report *report, void *workspace, size_t workspace_size)
{
    return sqffd_fit_ffd_view(sqffd_points_packed(points, n), options, model, report, workspace, workspace_size);
}

SQFFD_DEF sqffd_result sqffd_fit_ffd_view(sqffd_points points, const sqffd_fit_options *options, sqffd_model *model,
                                          sqffd_fit_report *report, void *workspace, size_t workspace_size)
{
    sqffd__arena a;
    sqffd__fit_system s;
    sqffd__fit_frame f;
    sqffd_fit_report *rep;
    sqffd_fit_options defaults = sqffd_fit_options_default();
    double diagonal = 0.0;
    sqffd_result res;
    if (!options) options = &defaults;
    if (!points.xyz || !model) return SQFFD_ERROR_INVALID_ARGUMENT;
    res = sqffd_model_validate(model);
    if (res == SQFFD_OK) res = sqffd__fit_check_options(options);
    if (res == SQFFD_OK) res = sqffd__fit_check_data(&points, &diagonal);
    if (res != SQFFD_OK) return res;
    sqffd__arena_init(&a, workspace, workspace_size);
    sqffd__fit_system_layout(&a, model->ffd.dims, model->grid, &s);
    sqffd__fit_frame_layout(&a, points.count, model->ffd.dims, model->grid, options, 0, &f);
    if (a.overflow) return sqffd__arena_error(&a);
    rep = report ? report : f.report;
    memset(rep, 0, sizeof *rep);
    res = sqffd__fit_prepare(model, options->alpha, options->tether, options->regularization, &s);
    return res == SQFFD_OK ? sqffd__fit_run(&points, diagonal, options, &s, &f.w, SQFFD__FIT_EXACT, model, rep) : res;
}

/* Stage 1's guard by the error itself: the superquadric's error (its grid
   mesh, the identity lattice) on an even subsample of at most
   SQFFD__FIT_GUARD of the stage's points (in w->target): the RMS, in robust
   mode the third quartile (outliers do not count). */
#define SQFFD__FIT_GUARD 512

static sqffd_result sqffd__fit_sq_error(const sqffd_superquadric *sq, const sqffd_points *points, double diagonal,
                                        int robust, sqffd__fit_system *s, sqffd__fit_work *w, double *error)
{
    size_t n = points->count;
    sqffd__fit_search search;
    sqffd_distance_stats stats;
    size_t m = sqffd__fit_grid_count(s->grid), v;
    sqffd_result res;
    sqffd__fit_sq_grid(sq, s->grid, w->x);
    for (v = 0; v < m; ++v)
        if (!sqffd__finite3(w->x + 3 * v)) return SQFFD_ERROR_NON_FINITE;
    sqffd__fit_search_init(&search, w->x, s->grid, s->rings, w->tree_ws, w->tree_size, &w->bvh);
    res = sqffd__fit_pass(points, &search, diagonal, robust ? w->next : NULL, NULL, &stats);
    if (res == SQFFD_OK) *error = robust ? sqffd__sq_select(w->next, n, n * 3 / 4) : stats.rms;
    return res;
}

/* The fitted superquadric, or the best start where that is nearer the data
   (by the error, on the guard subsample): stage 1's cost is no distance, and
   on shapes that are no superquadric it can end farther than it began. */
static sqffd_result sqffd__fit_guard(const sqffd_points *points, double diagonal, int robust, sqffd__fit_system *s,
                                     sqffd__fit_work *w, sqffd_superquadric *sq, sqffd_sq_fit_report *rep)
{
    size_t m = sqffd__fit_grid_count(s->grid), n = points->count, k = n < SQFFD__FIT_GUARD ? n : SQFFD__FIT_GUARD;
    double fitted, start;
    sqffd_points guard;
    sqffd_result res;
    k = k < m ? k : m; /* (the subsample lives in the model-sized target) */
    sqffd__subsample(points, k, w->target);
    guard = sqffd_points_packed(w->target, k);
    sqffd__fit_rings(s->grid, s->rings);
    res = sqffd__fit_sq_error(sq, &guard, diagonal, robust, s, w, &fitted);
    if (res == SQFFD_OK) res = sqffd__fit_sq_error(&rep->best_start, &guard, diagonal, robust, s, w, &start);
    if (res == SQFFD_OK && start < fitted) {
        *sq = rep->best_start;
        rep->fallback = 1;
    }
    return res;
}

/* The whole fit into a laid-out system and frame: stage 1 (guarded), the
   model around it, the system prepared for it, stage 2. */
static sqffd_result sqffd__fit_whole(const sqffd_points *points, double diagonal, const sqffd_fit_options *o,
                                     sqffd__fit_system *s, sqffd__fit_frame *f, sqffd_model *model, sqffd_fit_report *rep)
{
    sqffd_sq_fit_options sq_options = o->sq;
    sqffd_superquadric sq;
    size_t k = sqffd__fit_cap(points->count, o->sq_max_points);
    sqffd_points stage1 = f->sample ? sqffd_points_packed(f->sample, k) : *points;
    sqffd_result res;
    if (f->sample) sqffd__subsample(points, k, f->sample);
    if (!sq_options.progress) {
        sq_options.progress = o->progress;
        sq_options.progress_user = o->progress_user;
    }
    res = sqffd_sq_fit_view(stage1, &sq_options, &sq, &rep->sq, f->sq_ws, f->sq_size);
    if (res == SQFFD_OK) res = sqffd__fit_guard(&stage1, diagonal, sq_options.robust, s, &f->w, &sq, &rep->sq);
    if (res == SQFFD_OK) res = sqffd_model_init(model, &sq, o);
    if (res == SQFFD_OK) res = sqffd__fit_prepare(model, o->alpha, o->tether, o->regularization, s);
    if (res != SQFFD_OK) return res;
    return f->coarse_grid[0] ? sqffd__fit_coarse_first(points, diagonal, o, s, f, model, rep)
                             : sqffd__fit_run(points, diagonal, o, s, &f->w, SQFFD__FIT_EXACT, model, rep);
}

SQFFD_DEF sqffd_result sqffd_fit(const double *points, size_t n, const sqffd_fit_options *options,
                                 sqffd_model *model, sqffd_fit_report *report,
                                 void *workspace, size_t workspace_size)
{
    return sqffd_fit_view(sqffd_points_packed(points, n), options, model, report, workspace, workspace_size);
}

SQFFD_DEF sqffd_result sqffd_fit_view(sqffd_points points, const sqffd_fit_options *options, sqffd_model *model,
                                      sqffd_fit_report *report, void *workspace, size_t workspace_size)
{
    sqffd__arena a;
    sqffd__fit_system s;
    sqffd__fit_frame f;
    sqffd_fit_report *rep;
    sqffd_fit_options defaults = sqffd_fit_options_default();
    double diagonal = 0.0;
    sqffd_result res;
    if (!options) options = &defaults;
    if (!points.xyz || !model) return SQFFD_ERROR_INVALID_ARGUMENT;
    res = sqffd__fit_check_whole_options(options);
    if (res == SQFFD_OK) res = sqffd__fit_check_data(&points, &diagonal);
    if (res != SQFFD_OK) return res;
    sqffd__arena_init(&a, workspace, workspace_size);
    sqffd__fit_system_layout(&a, options->lattice, options->grid, &s);
    sqffd__fit_frame_layout(&a, points.count, options->lattice, options->grid, options, 1, &f);
    if (a.overflow) return sqffd__arena_error(&a);
    rep = report ? report : f.report;
    memset(rep, 0, sizeof *rep);
    return sqffd__fit_whole(&points, diagonal, options, &s, &f, model, rep);
}

/* ======================================================================
   Layer 6: tracking and motion
   ====================================================================== */

/* ---- the prepared system ------------------------------------------------- */

SQFFD_DEF sqffd_result sqffd_ffd_system_size(const sqffd_model *model, size_t *size)
{
    sqffd__arena a;
    sqffd__fit_system *state;
    sqffd_result r;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    if (!model) return SQFFD_ERROR_INVALID_ARGUMENT;
    r = sqffd_model_validate(model);
    if (r != SQFFD_OK) return r;
    sqffd__arena_measure(&a);
    sqffd__fit_state_layout(&a, model->ffd.dims, model->grid, &state);
    return sqffd__arena_size(&a, size);
}

SQFFD_DEF sqffd_result sqffd_ffd_system_init(sqffd_ffd_system *system, const sqffd_model *model,
                                             const sqffd_fit_options *options, void *memory, size_t memory_size)
{
    sqffd_fit_options defaults = sqffd_fit_options_default();
    const sqffd_fit_options *o = options ? options : &defaults;
    sqffd__arena a;
    sqffd__fit_system *state;
    sqffd_result res;
    if (!system || !model) return SQFFD_ERROR_INVALID_ARGUMENT;
    memset(system, 0, sizeof *system);
    res = sqffd_model_validate(model);
    if (res == SQFFD_OK) res = sqffd__fit_check_options(o);
    if (res != SQFFD_OK) return res;
    sqffd__arena_init(&a, memory, memory_size);
    sqffd__fit_state_layout(&a, model->ffd.dims, model->grid, &state);
    if (!state) return sqffd__arena_error(&a);
    res = sqffd__fit_prepare(model, o->alpha, o->tether, o->regularization, state);
    if (res != SQFFD_OK) return res;
    system->sq = model->sq;
    memcpy(system->dims, model->ffd.dims, sizeof system->dims);
    memcpy(system->origin, model->ffd.origin, sizeof system->origin);
    memcpy(system->edges, model->ffd.edges, sizeof system->edges);
    system->grid[0] = model->grid[0];
    system->grid[1] = model->grid[1];
    system->alpha = o->alpha;
    system->tether = o->tether;
    system->regularization = o->regularization;
    system->state = state;
    return SQFFD_OK;
}

static int sqffd__same(const double *a, const double *b, size_t count)
{
    size_t i;
    for (i = 0; i < count; ++i)
        if (!(a[i] == b[i])) return 0;
    return 1;
}

/* Whether the model has this superquadric, lattice, box and grid (a
   prepared system's, or another frame's of a sequence). */
static int sqffd__fit_same_frame(const sqffd_superquadric *a, const int dims[3], const double origin[3],
                                 const double edges[9], const int grid[2], const sqffd_model *model)
{
    const sqffd_superquadric *b = &model->sq;
    return sqffd__same(a->size, b->size, 3) && sqffd__same(a->shape, b->shape, 2) &&
           sqffd__same(a->taper, b->taper, 2) && sqffd__same(a->rotation, b->rotation, 9) &&
           sqffd__same(a->center, b->center, 3) && sqffd__same(origin, model->ffd.origin, 3) &&
           sqffd__same(edges, model->ffd.edges, 9) && dims[0] == model->ffd.dims[0] &&
           dims[1] == model->ffd.dims[1] && dims[2] == model->ffd.dims[2] && grid[0] == model->grid[0] &&
           grid[1] == model->grid[1];
}

/* The options of a run against a system: the caller's (or the defaults)
   with the system's alpha, tether and regularization. */
static sqffd_fit_options sqffd__fit_system_options(const sqffd_ffd_system *system, const sqffd_fit_options *options)
{
    sqffd_fit_options o = options ? *options : sqffd_fit_options_default();
    o.alpha = system->alpha;
    o.tether = system->tether;
    o.regularization = system->regularization;
    return o;
}

SQFFD_DEF sqffd_result sqffd_fit_prepared_workspace_size(size_t n, const sqffd_ffd_system *system,
                                                         const sqffd_fit_options *options, size_t *size)
{
    sqffd__arena a;
    sqffd__fit_frame f;
    sqffd_fit_options o;
    sqffd_result r;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    if (!system || !system->state || n == 0) return SQFFD_ERROR_INVALID_ARGUMENT;
    o = sqffd__fit_system_options(system, options);
    r = sqffd__fit_check_options(&o);
    if (r != SQFFD_OK) return r;
    sqffd__arena_measure(&a);
    sqffd__fit_frame_layout(&a, n, system->dims, system->grid, &o, 0, &f);
    return sqffd__arena_size(&a, size);
}

SQFFD_DEF sqffd_result sqffd_fit_prepared(const sqffd_ffd_system *system, const double *points, size_t n,
                                          const sqffd_fit_options *options, sqffd_model *model,
                                          sqffd_fit_report *report, void *workspace, size_t workspace_size)
{
    return sqffd_fit_prepared_view(system, sqffd_points_packed(points, n), options, model, report, workspace,
                                   workspace_size);
}

/* The FFD stage against a system, from the model's control points, with
   the system's options merged in; mode as sqffd__fit_run's (a tracking
   frame's: no exact first pass). */
static sqffd_result sqffd__fit_prepared(const sqffd_ffd_system *system, const sqffd_points *points,
                                        const sqffd_fit_options *options, int mode, sqffd_model *model,
                                        sqffd_fit_report *report, void *workspace, size_t workspace_size)
{
    sqffd__arena a;
    sqffd__fit_frame f;
    sqffd_fit_options o;
    sqffd_fit_report *rep;
    double diagonal = 0.0;
    sqffd_result res;
    if (!system || !system->state || !model ||
        !sqffd__fit_same_frame(&system->sq, system->dims, system->origin, system->edges, system->grid, model))
        return SQFFD_ERROR_INVALID_ARGUMENT;
    o = sqffd__fit_system_options(system, options);
    res = sqffd__fit_check_options(&o);
    if (res == SQFFD_OK) res = sqffd__fit_check_data(points, &diagonal);
    if (res != SQFFD_OK) return res;
    sqffd__arena_init(&a, workspace, workspace_size);
    sqffd__fit_frame_layout(&a, points->count, system->dims, system->grid, &o, 0, &f);
    if (a.overflow) return sqffd__arena_error(&a);
    rep = report ? report : f.report;
    memset(rep, 0, sizeof *rep);
    return sqffd__fit_run(points, diagonal, &o, (const sqffd__fit_system *)system->state, &f.w, mode, model, rep);
}

SQFFD_DEF sqffd_result sqffd_fit_prepared_view(const sqffd_ffd_system *system, sqffd_points points,
                                               const sqffd_fit_options *options, sqffd_model *model,
                                               sqffd_fit_report *report, void *workspace, size_t workspace_size)
{
    return sqffd__fit_prepared(system, &points, options, SQFFD__FIT_EXACT, model, report, workspace, workspace_size);
}

/* ---- tracking ------------------------------------------------------------ */

SQFFD_DEF sqffd_track_options sqffd_track_options_default(void)
{
    sqffd_track_options o;
    memset(&o, 0, sizeof o);
    o.fit = sqffd_fit_options_default();
    o.fit.max_iterations = 100;
    o.fit.coarse_iterations = 0; /* (frame 0 converges on the grid: the later frames measure motion, not the rest
                                    of its convergence) */
    o.fit.alpha = 1e-3; /* stiffer springs than a lone fit's: the parts a frame's data do not reach follow the
                           reached ones, and the lattice keeps room above the Jacobian floor for the motion */
    o.fit.model_to_data = 0.0; /* (nothing pulls an unreached part onto the nearest data) */
    o.frame_iterations = 100;
    return o;
}

/* One arena for the sequence: the system first (it stays), then the
   largest frame's scratch (frame 0's with stage 1's). The frames' counts
   come from counts or, when it is NULL, from views (both NULL: INVALID_ARGUMENT). */
static sqffd_result sqffd__track_workspace_size(const size_t *counts, const sqffd_points *views, size_t frame_count,
                                                const sqffd_track_options *options, size_t *size)
{
    sqffd_track_options defaults = sqffd_track_options_default();
    const sqffd_track_options *opt = options ? options : &defaults;
    sqffd__arena a, frame;
    sqffd__fit_system *state;
    sqffd__fit_frame f;
    size_t t, need = 0;
    sqffd_result r;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    if ((!counts && !views) || frame_count == 0 || opt->frame_iterations < 0) return SQFFD_ERROR_INVALID_ARGUMENT;
    r = sqffd__fit_check_whole_options(&opt->fit);
    if (r != SQFFD_OK) return r;
    sqffd__arena_measure(&a);
    sqffd__fit_state_layout(&a, opt->fit.lattice, opt->fit.grid, &state);
    for (t = 0; t < frame_count; ++t) {
        size_t frame_size, n = counts ? counts[t] : views[t].count;
        if (n == 0) return SQFFD_ERROR_INVALID_ARGUMENT;
        frame = a;
        sqffd__fit_frame_layout(&frame, n, opt->fit.lattice, opt->fit.grid, &opt->fit, t == 0, &f);
        r = sqffd__arena_size(&frame, &frame_size);
        if (r != SQFFD_OK) return r;
        need = frame_size > need ? frame_size : need;
    }
    *size = need;
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_fit_check_data_view(sqffd_points points)
{
    double diagonal;
    sqffd_result r = sqffd__fit_check_data(&points, &diagonal);
    return r == SQFFD_OK ? sqffd__sq_check_data(&points) : r;
}

SQFFD_DEF sqffd_result sqffd_fit_check_data(const double *points, size_t n)
{
    return sqffd_fit_check_data_view(sqffd_points_packed(points, n));
}

SQFFD_DEF sqffd_result sqffd_track_workspace_size(const size_t *counts, size_t frame_count,
                                                  const sqffd_track_options *options, size_t *size)
{
    return sqffd__track_workspace_size(counts, NULL, frame_count, options, size);
}

SQFFD_DEF sqffd_result sqffd_track_view_workspace_size(const sqffd_points *frames, size_t frame_count,
                                                       const sqffd_track_options *options, size_t *size)
{
    return sqffd__track_workspace_size(NULL, frames, frame_count, options, size);
}

/* The sequence from packed frames (frames, counts) or from views. */
static sqffd_result sqffd__track(const double *const *frames, const size_t *counts, const sqffd_points *views,
                                 size_t frame_count, const sqffd_track_options *options, sqffd_model *models,
                                 sqffd_fit_report *reports, size_t *frames_done, void *workspace, size_t workspace_size)
{
    sqffd_track_options defaults = sqffd_track_options_default();
    const sqffd_track_options *opt = options ? options : &defaults;
    sqffd_fit_options o = opt->fit;
    sqffd__arena a, frame;
    sqffd__fit_system *state;
    sqffd__fit_frame f;
    double previous = 0.0;
    size_t t = 0;
    sqffd_result res = SQFFD_ERROR_INVALID_ARGUMENT;
    if (frames_done) *frames_done = 0;
    if ((!views && (!frames || !counts)) || !models || frame_count == 0 || opt->frame_iterations < 0) return res;
    o.progress = opt->progress;
    o.progress_user = opt->progress_user;
    res = sqffd__fit_check_whole_options(&o);
    if (res != SQFFD_OK) return res;
    for (t = 0; t < frame_count; ++t) { /* every frame's data before any fit */
        res = sqffd_fit_check_data_view(views ? views[t] : sqffd_points_packed(frames[t], counts[t]));
        if (res != SQFFD_OK) {
            if (frames_done) *frames_done = t;
            return res;
        }
    }
    sqffd__arena_init(&a, workspace, workspace_size);
    sqffd__fit_state_layout(&a, o.lattice, o.grid, &state);
    if (!state) return sqffd__arena_error(&a);
    for (t = 0; t < frame_count; ++t) {
        sqffd_fit_report *rep;
        sqffd_points points = views ? views[t] : sqffd_points_packed(frames[t], counts[t]);
        double diagonal = 0.0;
        if (opt->progress && opt->progress(opt->progress_user, SQFFD_STAGE_FRAME, (int)(t < INT32_MAX ? t : INT32_MAX), previous)) {
            res = SQFFD_ERROR_CANCELLED;
            break;
        }
        res = sqffd__fit_check_data(&points, &diagonal);
        if (res != SQFFD_OK) break;
        frame = a; /* every frame's scratch starts after the system */
        o.max_iterations = t == 0 ? opt->fit.max_iterations : opt->frame_iterations;
        sqffd__fit_frame_layout(&frame, points.count, o.lattice, o.grid, &o, t == 0, &f);
        if (frame.overflow) { res = sqffd__arena_error(&frame); break; }
        rep = reports ? reports + t : f.report;
        memset(rep, 0, sizeof *rep);
        if (t == 0) res = sqffd__fit_whole(&points, diagonal, &o, state, &f, models, rep);
        else {
            models[t] = models[t - 1];
            res = sqffd__fit_run(&points, diagonal, &o, state, &f.w, SQFFD__FIT_EXACT_END, models + t, rep);
        }
        if (res != SQFFD_OK) break;
        previous = rep->error.rms_relative;
    }
    if (frames_done) *frames_done = t;
    return res;
}

SQFFD_DEF sqffd_result sqffd_track(const double *const *frames, const size_t *counts, size_t frame_count,
                                   const sqffd_track_options *options, sqffd_model *models,
                                   sqffd_fit_report *reports, size_t *frames_done,
                                   void *workspace, size_t workspace_size)
{
    return sqffd__track(frames, counts, NULL, frame_count, options, models, reports, frames_done, workspace,
                        workspace_size);
}

SQFFD_DEF sqffd_result sqffd_track_view(const sqffd_points *frames, size_t frame_count,
                                        const sqffd_track_options *options, sqffd_model *models,
                                        sqffd_fit_report *reports, size_t *frames_done, void *workspace,
                                        size_t workspace_size)
{
    return sqffd__track(NULL, NULL, frames, frame_count, options, models, reports, frames_done, workspace,
                        workspace_size);
}

/* A later frame's options: the fit's, capped at frame_iterations, with the track's progress. */
static sqffd_fit_options sqffd__track_frame_options(const sqffd_track_options *opt)
{
    sqffd_fit_options o = opt->fit;
    o.max_iterations = opt->frame_iterations;
    o.progress = opt->progress;
    o.progress_user = opt->progress_user;
    return o;
}

SQFFD_DEF sqffd_result sqffd_track_frame_workspace_size(size_t n, const sqffd_track_options *options, size_t *size)
{
    sqffd_track_options defaults = sqffd_track_options_default();
    const sqffd_track_options *opt = options ? options : &defaults;
    sqffd_fit_options o = sqffd__track_frame_options(opt);
    sqffd__arena a;
    sqffd__fit_frame f;
    sqffd_result r;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    if (n == 0 || opt->frame_iterations < 0) return SQFFD_ERROR_INVALID_ARGUMENT;
    r = sqffd__fit_check_whole_options(&o);
    if (r != SQFFD_OK) return r;
    sqffd__arena_measure(&a);
    sqffd__fit_frame_layout(&a, n, o.lattice, o.grid, &o, 0, &f);
    return sqffd__arena_size(&a, size);
}

SQFFD_DEF sqffd_result sqffd_track_frame_view(const sqffd_ffd_system *system, sqffd_points points,
                                              const sqffd_track_options *options, sqffd_model *model,
                                              sqffd_fit_report *report, void *workspace, size_t workspace_size)
{
    sqffd_track_options defaults = sqffd_track_options_default();
    const sqffd_track_options *opt = options ? options : &defaults;
    sqffd_fit_options o = sqffd__track_frame_options(opt);
    sqffd_result r = opt->frame_iterations < 0 ? SQFFD_ERROR_INVALID_ARGUMENT : sqffd_fit_check_data_view(points);
    if (r != SQFFD_OK) return r;
    return sqffd__fit_prepared(system, &points, &o, SQFFD__FIT_EXACT_END, model, report, workspace, workspace_size);
}

SQFFD_DEF sqffd_result sqffd_track_frame(const sqffd_ffd_system *system, const double *points, size_t n,
                                         const sqffd_track_options *options, sqffd_model *model,
                                         sqffd_fit_report *report, void *workspace, size_t workspace_size)
{
    return sqffd_track_frame_view(system, sqffd_points_packed(points, n), options, model, report, workspace,
                                  workspace_size);
}

/* ---- motion -------------------------------------------------------------- */

#define SQFFD__MOTION_BANDS 10      /* levels along the axis the low-motion rule compares within */
#define SQFFD__MOTION_END 0.2       /* the outer share of the length whose width tells the apex */
#define SQFFD__MOTION_VALVE 0.70710678118654752 /* cos 45 degrees: a base-facing normal within it is the valve plane */

SQFFD_DEF sqffd_motion_options sqffd_motion_options_default(void)
{
    sqffd_motion_options o;
    memset(&o, 0, sizeof o);
    o.ed_frame = 0;
    o.low_motion_fraction = 0.5;
    o.hypokinetic_share = 0.5;
    o.apex_fraction = 0.1;
    return o;
}

/* The closed volume of the grid mesh over points x (divergence theorem). */
static double sqffd__fit_volume(const int grid[2], const double *x)
{
    uint32_t r, c, cell[2][3];
    double volume = 0.0, e[3];
    int k, count;
    for (r = 0; r <= (uint32_t)grid[0]; ++r)
        for (c = 0; c < (uint32_t)grid[1]; ++c)
            for (count = sqffd__fit_cell(grid, r, c, cell), k = 0; k < count; ++k) {
                sqffd__cross3(x + 3 * (size_t)cell[k][1], x + 3 * (size_t)cell[k][2], e);
                volume += sqffd__dot3(x + 3 * (size_t)cell[k][0], e);
            }
    return volume / 6.0;
}

/* ---- short-axis stacks ----------------------------------------------------- */

#define SQFFD__STACK_TOLERANCE 1e-6 /* of the points' diagonal: a point off its plane by more is no stack's */
#define SQFFD__MOTION_SECTIONS 64   /* intervals of a slab volume's Simpson's rule */
#define SQFFD__STACK_SLICE 0.25     /* of the spacing: a point within it of a plane is that slice's */

/* v ascending (insertion: at most SQFFD_STACK_PLANES values). */
static void sqffd__stack_sort(double *v, size_t n)
{
    size_t i, k;
    for (i = 1; i < n; ++i)
        for (k = i; k > 0 && v[k] < v[k - 1]; --k) {
            double t = v[k];
            v[k] = v[k - 1];
            v[k - 1] = t;
        }
}

SQFFD_DEF sqffd_result sqffd_stack_detect(const double *points, size_t n, sqffd_stack *stack, int *found)
{
    return sqffd_stack_detect_view(sqffd_points_packed(points, n), stack, found);
}

SQFFD_DEF sqffd_result sqffd_stack_detect_view(sqffd_points points, sqffd_stack *stack, int *found)
{
    double cov[9] = {0}, values[3], vectors[9], prev[3], p[3], mean = 0.0, diagonal, gaps[SQFFD_STACK_PLANES];
    sqffd_stack s;
    size_t n = points.count, i, k;
    int a, b;
    sqffd_result r;
    if (!stack || !found) return SQFFD_ERROR_INVALID_ARGUMENT;
    *found = 0;
    if ((r = sqffd__points_check(&points)) != SQFFD_OK) return r;
    if (n < 8) return SQFFD_OK;
    if ((r = sqffd__fit_diagonal(&points, &diagonal)) != SQFFD_OK) return r;
    for (i = 0; i < n; ++i) { /* the steps' mean square */
        sqffd__points_get(&points, i, p);
        if (i) mean += sqffd__dist2_3(p, prev) / (double)(n - 1);
        memcpy(prev, p, sizeof p);
    }
    for (i = 1; i < n; ++i) { /* the steps within slices: their normal is the axis */
        double d[3], q[3];
        sqffd__points_get(&points, i - 1, q);
        sqffd__points_get(&points, i, p);
        sqffd__sub3(p, q, d);
        if (sqffd__dot3(d, d) > 4.0 * mean) continue;
        for (a = 0; a < 3; ++a)
            for (b = 0; b < 3; ++b) cov[3 * a + b] += d[a] * d[b];
    }
    sqffd_sym3_eigen(cov, values, vectors);
    if (!(values[0] <= 1e-9 * values[1])) return SQFFD_OK; /* the steps are not planar */
    for (a = 0; a < 3; ++a) s.axis[a] = vectors[3 * a];
    s.planes = 0;
    for (i = 0; i < n; ++i) { /* the planes: the points' positions along the axis, within the tolerance */
        double at;
        sqffd__points_get(&points, i, p);
        at = sqffd__dot3(p, s.axis);
        for (k = 0; k < s.planes && !(fabs(at - s.level[k]) <= SQFFD__STACK_TOLERANCE * diagonal); ++k) {}
        if (k < s.planes) continue;
        if (s.planes == SQFFD_STACK_PLANES) return SQFFD_OK;
        s.level[s.planes++] = at;
    }
    if (s.planes < 3) return SQFFD_OK;
    sqffd__stack_sort(s.level, s.planes);
    for (i = 1; i < s.planes; ++i) gaps[i - 1] = s.level[i] - s.level[i - 1];
    sqffd__stack_sort(gaps, s.planes - 1);
    s.spacing = gaps[(s.planes - 1) / 2];
    *stack = s;
    *found = 1;
    return SQFFD_OK;
}

/* The signed area of the grid mesh's section by the plane axis . x = at
   (positive for an outward-facing closed mesh): each crossing triangle adds
   its segment, oriented along axis x its normal, as a triangle with the
   plane's point at * axis. */
static double sqffd__motion_section(const int grid[2], const double *x, const double axis[3], double at)
{
    uint32_t r, c, cell[2][3];
    double area = 0.0, o[3];
    int k, e, count;
    for (e = 0; e < 3; ++e) o[e] = at * axis[e];
    for (r = 0; r <= (uint32_t)grid[0]; ++r)
        for (c = 0; c < (uint32_t)grid[1]; ++c)
            for (count = sqffd__fit_cell(grid, r, c, cell), k = 0; k < count; ++k) {
                const double *v[3];
                double d[3], seg[2][3], n[3], u[3], w[3], s[3];
                int found = 0;
                for (e = 0; e < 3; ++e) {
                    v[e] = x + 3 * (size_t)cell[k][e];
                    d[e] = sqffd__dot3(v[e], axis) - at;
                }
                if ((d[0] > 0.0) == (d[1] > 0.0) && (d[1] > 0.0) == (d[2] > 0.0)) continue;
                for (e = 0; e < 3 && found < 2; ++e) {
                    const double *p = v[e], *q = v[(e + 1) % 3];
                    double dp = d[e], dq = d[(e + 1) % 3], t;
                    int i;
                    if ((dp > 0.0) == (dq > 0.0)) continue;
                    t = dp / (dp - dq);
                    for (i = 0; i < 3; ++i) seg[found][i] = p[i] + t * (q[i] - p[i]) - o[i];
                    ++found;
                }
                if (found < 2) continue;
                sqffd__sub3(v[1], v[0], u);
                sqffd__sub3(v[2], v[0], w);
                sqffd__cross3(u, w, n);
                sqffd__cross3(axis, n, u); /* the segment's direction */
                sqffd__sub3(seg[1], seg[0], w);
                sqffd__cross3(seg[0], seg[1], s);
                area += 0.5 * (sqffd__dot3(w, u) >= 0.0 ? 1.0 : -1.0) * sqffd__dot3(s, axis);
            }
    return area;
}

/* Frame t's volume: the closed mesh's, or with stacks between its stack's
   outer planes moved out by half the spacing. */
static double sqffd__motion_volume(const sqffd_motion_options *o, size_t t, const int grid[2], const double *x)
{
    const sqffd_stack *s;
    double lo, hi, sum = 0.0;
    int i;
    if (!o->stacks) return sqffd__fit_volume(grid, x);
    s = o->stacks + t;
    lo = s->level[0] - 0.5 * s->spacing;
    hi = s->level[s->planes - 1] + 0.5 * s->spacing;
    for (i = 0; i <= SQFFD__MOTION_SECTIONS; ++i) /* Simpson's rule: weights 1 4 2 4 ... 4 1 */
        sum += (i == 0 || i == SQFFD__MOTION_SECTIONS ? 1.0 : i % 2 ? 4.0 : 2.0) *
               sqffd__motion_section(grid, x, s->axis, lo + (hi - lo) * (double)i / SQFFD__MOTION_SECTIONS);
    return sum * (hi - lo) / (3.0 * SQFFD__MOTION_SECTIONS);
}

/* A stack handed in: 3.. planes ascending, finite, a unit axis, a positive spacing. */
static int sqffd__stack_valid(const sqffd_stack *s)
{
    size_t k;
    if (s->planes < 3 || s->planes > SQFFD_STACK_PLANES || !sqffd__finite3(s->axis) ||
        !(fabs(sqffd__dot3(s->axis, s->axis) - 1.0) <= 1e-9) || !(s->spacing > 0.0) || !isfinite(s->spacing))
        return 0;
    for (k = 0; k < s->planes; ++k)
        if (!isfinite(s->level[k]) || (k && !(s->level[k] > s->level[k - 1]))) return 0;
    return 1;
}

/* Two unit vectors across a unit axis, and across each other. */
static void sqffd__stack_basis(const double axis[3], double e[2][3])
{
    double length;
    int c = fabs(axis[0]) <= fabs(axis[1]) && fabs(axis[0]) <= fabs(axis[2]) ? 0 : fabs(axis[1]) <= fabs(axis[2]) ? 1 : 2;
    e[1][0] = e[1][1] = e[1][2] = 0.0;
    e[1][c] = 1.0; /* the coordinate axis most across the axis: e0 = axis x it, e1 = axis x e0 */
    sqffd__cross3(axis, e[1], e[0]);
    length = sqrt(sqffd__dot3(e[0], e[0])); /* at least sqrt(2/3) */
    for (c = 0; c < 3; ++c) e[0][c] /= length;
    sqffd__cross3(axis, e[0], e[1]);
}

/* A polygon edge a -> b's part of the signed area and of its first
   moments: the triangle (origin, a, b). */
static void sqffd__stack_edge(const double a[2], const double b[2], double *area, double moment[2])
{
    double t = 0.5 * (a[0] * b[1] - a[1] * b[0]);
    *area += t;
    moment[0] += t * (a[0] + b[0]) / 3.0;
    moment[1] += t * (a[1] + b[1]) / 3.0;
}

/* Plane k's contour centroid in the in-plane basis (e0, e1): the area
   centroid of its closed runs of consecutive points, each run's area taken
   positive whatever its drawing direction; their points' mean where they
   enclose nothing. 0 if the plane holds no point, -1 at a point not finite. */
static int sqffd__stack_centroid(const sqffd_points *points, const double axis[3], const double e[2][3], double level,
                                 double tolerance, double centroid[2])
{
    double run_area = 0.0, run_moment[2] = {0.0, 0.0}, area = 0.0, moment[2] = {0.0, 0.0}, sum[2] = {0.0, 0.0};
    double first[2] = {0.0, 0.0}, prev[2] = {0.0, 0.0}, p[3], q[2];
    size_t i, run = 0, count = 0;
    int c;
    for (i = 0; i <= points->count; ++i) {
        int on = 0;
        if (i < points->count) {
            sqffd__points_get(points, i, p);
            if (!sqffd__finite3(p)) return -1;
            on = fabs(sqffd__dot3(p, axis) - level) <= tolerance;
        }
        if (on) {
            for (c = 0; c < 2; ++c) q[c] = sqffd__dot3(p, e[c]);
            for (c = 0; c < 2; ++c) sum[c] += q[c];
            ++count;
        }
        if (run && !on) { /* the run ends: close it back to its first point */
            sqffd__stack_edge(prev, first, &run_area, run_moment);
            if (run_area < 0.0) {
                run_area = -run_area;
                run_moment[0] = -run_moment[0];
                run_moment[1] = -run_moment[1];
            }
            area += run_area;
            for (c = 0; c < 2; ++c) moment[c] += run_moment[c];
            run_area = run_moment[0] = run_moment[1] = 0.0;
            run = 0;
        }
        if (!on) continue;
        if (run) {
            sqffd__stack_edge(prev, q, &run_area, run_moment);
        } else {
            first[0] = q[0];
            first[1] = q[1];
        }
        prev[0] = q[0];
        prev[1] = q[1];
        ++run;
    }
    if (count == 0) return 0;
    for (c = 0; c < 2; ++c) centroid[c] = area > 0.0 ? moment[c] / area : sum[c] / (double)count;
    return 1;
}

/* Frame t's part of sqffd_stack_shifts: its centroids against its quadratic
   centreline, each difference added into its slice's sum in s->shift and
   counted in count. */
static sqffd_result sqffd__stack_frame_shifts(const sqffd_points *points, const sqffd_stack *st, const double e[2][3],
                                              sqffd_slice_shifts *s, uint32_t *count)
{
    double centroid[SQFFD_STACK_PLANES][2], normal[9], line[2][3], sign = sqffd__dot3(st->axis, s->axis) > 0.0 ? 1.0 : -1.0;
    double mid = 0.5 * (st->level[0] + st->level[st->planes - 1]), half = 0.5 * (st->level[st->planes - 1] - st->level[0]);
    unsigned char held[SQFFD_STACK_PLANES];
    size_t used = 0, k, j;
    int degree, a, b, c;
    memset(normal, 0, sizeof normal);
    memset(line, 0, sizeof line);
    for (k = 0; k < st->planes; ++k) {
        int got = sqffd__stack_centroid(points, st->axis, e, st->level[k], s->tolerance, centroid[k]);
        if (got < 0) return SQFFD_ERROR_NON_FINITE;
        held[k] = (unsigned char)got;
        used += held[k];
    }
    if (used == 0) return SQFFD_OK;
    degree = used >= 4 ? 2 : (int)used - 1;
    for (k = 0; k < st->planes; ++k) { /* the normal equations, in the level scaled to [-1, 1] */
        double x = (st->level[k] - mid) / half, power[3];
        if (!held[k]) continue;
        power[0] = 1.0;
        power[1] = x;
        power[2] = x * x;
        for (a = 0; a <= degree; ++a) {
            for (b = 0; b <= degree; ++b) normal[(degree + 1) * a + b] += power[a] * power[b];
            for (c = 0; c < 2; ++c) line[c][a] += power[a] * centroid[k][c];
        }
    }
    if (sqffd_cholesky_factor(normal, (size_t)degree + 1) != SQFFD_OK) return SQFFD_ERROR_NON_FINITE;
    for (c = 0; c < 2; ++c) sqffd_cholesky_solve(normal, (size_t)degree + 1, line[c]);
    for (k = 0; k < st->planes; ++k) { /* the centreline less the centroid, into its slice's sum */
        double x = (st->level[k] - mid) / half, power = 1.0, at[2] = {0.0, 0.0};
        if (!held[k]) continue;
        for (a = 0; a <= degree; ++a, power *= x)
            for (c = 0; c < 2; ++c) at[c] += line[c][a] * power;
        for (j = 0; !(fabs(sign * st->level[k] - s->level[j]) <= s->tolerance); ++j) {}
        for (c = 0; c < 3; ++c) s->shift[j][c] += (at[0] - centroid[k][0]) * e[0][c] + (at[1] - centroid[k][1]) * e[1][c];
        ++count[j];
    }
    return SQFFD_OK;
}

/* sqffd_stack_shifts over packed frames (views NULL) or sqffd_stack_shifts_view. */
static sqffd_result sqffd__stack_shifts(const double *const *packed, const size_t *counts, const sqffd_points *views,
                                        const sqffd_stack *stacks, size_t frame_count, sqffd_slice_shifts *shifts)
{
    double e[2][3], spacing = HUGE_VAL;
    uint32_t count[SQFFD_STACK_PLANES];
    sqffd_slice_shifts *s = shifts;
    size_t t, k, j;
    sqffd_result r = SQFFD_OK;
    int c;
    if ((!views && (!packed || !counts)) || !stacks || !shifts || frame_count == 0) return SQFFD_ERROR_INVALID_ARGUMENT;
    memset(s, 0, sizeof *s);
    for (t = 0; t < frame_count; ++t) {
        sqffd_points frame = views ? views[t] : sqffd_points_packed(packed[t], counts[t]);
        if (!sqffd__stack_valid(stacks + t) || !(fabs(sqffd__dot3(stacks[t].axis, stacks[0].axis)) >= 1.0 - 1e-6))
            return SQFFD_ERROR_INVALID_ARGUMENT;
        if ((r = sqffd__points_check(&frame)) != SQFFD_OK) return r;
        if (stacks[t].spacing < spacing) spacing = stacks[t].spacing;
    }
    memcpy(s->axis, stacks[0].axis, sizeof s->axis);
    s->tolerance = SQFFD__STACK_SLICE * spacing;
    sqffd__stack_basis(s->axis, e);
    for (t = 0; t < frame_count; ++t) { /* the distinct levels, ascending */
        const sqffd_stack *st = stacks + t;
        double sign = sqffd__dot3(st->axis, s->axis) > 0.0 ? 1.0 : -1.0;
        for (k = 0; k < st->planes; ++k) {
            double level = sign * st->level[k];
            for (j = 0; j < s->slices && !(fabs(level - s->level[j]) <= s->tolerance); ++j) {}
            if (j < s->slices) continue;
            if (s->slices == SQFFD_STACK_PLANES) {
                memset(s, 0, sizeof *s);
                return SQFFD_ERROR_INVALID_ARGUMENT;
            }
            for (j = s->slices++; j > 0 && s->level[j - 1] > level; --j) s->level[j] = s->level[j - 1];
            s->level[j] = level;
        }
    }
    memset(count, 0, sizeof count);
    for (t = 0; t < frame_count && r == SQFFD_OK; ++t) {
        sqffd_points frame = views ? views[t] : sqffd_points_packed(packed[t], counts[t]);
        r = sqffd__stack_frame_shifts(&frame, stacks + t, (const double(*)[3])e, s, count);
    }
    for (j = 0; j < s->slices && r == SQFFD_OK; ++j)
        for (c = 0; c < 3; ++c) {
            if (count[j]) s->shift[j][c] /= (double)count[j];
            if (!isfinite(s->shift[j][c])) r = SQFFD_ERROR_NON_FINITE;
        }
    if (r != SQFFD_OK) memset(s, 0, sizeof *s);
    return r;
}

SQFFD_DEF sqffd_result sqffd_stack_shifts(const double *const *frames, const size_t *counts, const sqffd_stack *stacks,
                                          size_t frame_count, sqffd_slice_shifts *shifts)
{
    return sqffd__stack_shifts(frames, counts, NULL, stacks, frame_count, shifts);
}

SQFFD_DEF sqffd_result sqffd_stack_shifts_view(const sqffd_points *frames, const sqffd_stack *stacks, size_t frame_count,
                                               sqffd_slice_shifts *shifts)
{
    return sqffd__stack_shifts(NULL, NULL, frames, stacks, frame_count, shifts);
}

SQFFD_DEF sqffd_result sqffd_stack_shifts_apply(const sqffd_slice_shifts *shifts, double *points, size_t n,
                                                size_t *moved)
{
    size_t i, j, count = 0;
    int c, pass;
    if (moved) *moved = 0;
    if (!shifts || (!points && n > 0) || shifts->slices > SQFFD_STACK_PLANES) return SQFFD_ERROR_INVALID_ARGUMENT;
    for (pass = 0; pass < 2; ++pass) /* every point checked before any moves */
        for (i = 0; i < n; ++i) {
            double *p = points + 3 * i, level, q[3];
            if (!sqffd__finite3(p)) return SQFFD_ERROR_NON_FINITE;
            level = sqffd__dot3(p, shifts->axis);
            for (j = 0; j < shifts->slices && !(fabs(level - shifts->level[j]) <= shifts->tolerance); ++j) {}
            if (j == shifts->slices) continue;
            for (c = 0; c < 3; ++c) q[c] = p[c] + shifts->shift[j][c];
            if (!sqffd__finite3(q)) return SQFFD_ERROR_NON_FINITE;
            if (pass) memcpy(p, q, sizeof q);
            count += (size_t)pass;
        }
    if (moved) *moved = count;
    return SQFFD_OK;
}

/* The lids of sqffd_stack_lids_view (a valid stack and view): *total of
   them, written to out unless it is NULL. */
static sqffd_result sqffd__stack_lids(const sqffd_points *points, const sqffd_stack *stack, double *out, size_t *total)
{
    double e[2][3];
    size_t i, j;
    int end, ring, c;
    *total = 0;
    sqffd__stack_basis(stack->axis, e);
    for (end = 0; end < 2; ++end) {
        double level = stack->level[end ? stack->planes - 1 : 0], centre[2], p[3], tolerance = SQFFD__STACK_SLICE * stack->spacing;
        double lid = level + (end ? 0.5 : -0.5) * stack->spacing;
        int got = sqffd__stack_centroid(points, stack->axis, (const double(*)[3])e, level, tolerance, centre);
        if (got < 0) return SQFFD_ERROR_NON_FINITE;
        if (!got) continue;
        for (i = 0, j = 0; i < points->count; ++i) {
            sqffd__points_get(points, i, p);
            if (!(fabs(sqffd__dot3(p, stack->axis) - level) <= tolerance)) continue;
            for (ring = -1; ring < SQFFD_STACK_LID_RINGS; ++ring) {
                double t = (double)(ring + 1) / (SQFFD_STACK_LID_RINGS + 1), q[3]; /* of the way to the centre */
                if (ring >= 0 && j % (size_t)(ring + 2)) continue;
                for (c = 0; c < 3; ++c)
                    q[c] = lid * stack->axis[c] +
                           (1.0 - t) * (sqffd__dot3(p, e[0]) * e[0][c] + sqffd__dot3(p, e[1]) * e[1][c]) +
                           t * (centre[0] * e[0][c] + centre[1] * e[1][c]);
                if (!sqffd__finite3(q)) return SQFFD_ERROR_NON_FINITE; /* (coordinates too large to compute with) */
                if (out) memcpy(out + 3 * *total, q, sizeof q);
                ++*total;
            }
            ++j; /* (the contour's points so far) */
        }
    }
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_stack_lids_view(sqffd_points points, const sqffd_stack *stack, double *out, size_t capacity,
                                             size_t *count)
{
    size_t total;
    sqffd_result r;
    if (!count || !stack || !sqffd__stack_valid(stack) || (capacity && !out)) return SQFFD_ERROR_INVALID_ARGUMENT;
    if ((r = sqffd__points_check(&points)) != SQFFD_OK) return r;
    /* counted (and every lid point checked) before anything is written */
    if ((r = sqffd__stack_lids(&points, stack, NULL, &total)) != SQFFD_OK) return r;
    *count = total;
    if (capacity == 0) return SQFFD_OK;
    if (total > capacity) return SQFFD_ERROR_OUTPUT_TOO_SMALL;
    return sqffd__stack_lids(&points, stack, out, &total);
}

SQFFD_DEF sqffd_result sqffd_stack_lids(const double *points, size_t n, const sqffd_stack *stack, double *out,
                                        size_t capacity, size_t *count)
{
    return sqffd_stack_lids_view(sqffd_points_packed(points, n), stack, out, capacity, count);
}

typedef struct sqffd__motion_work {
    double *ed, *es, *x;     /* M x 3: the ED, ES and current frame's mesh vertices */
    double *area;            /* M: a third of the ED area of the triangles around each vertex */
    double *normal;          /* M x 3: their area-weighted normal */
    double *level;           /* M: f, from the apex (0) to the base (1) */
    double *moved;           /* M: the displacement */
    double *inward;          /* M: the excursion */
    double *scratch;         /* M: medians */
    unsigned char *segment;  /* M */
    sqffd_motion_report *report; /* built here, copied out on success (not on the stack: 0.8 KB) */
} sqffd__motion_work;

static void sqffd__motion_layout(sqffd__arena *a, size_t m, sqffd__motion_work *w)
{
    w->ed = (double *)sqffd__arena_take(a, m, 3 * sizeof(double));
    w->es = (double *)sqffd__arena_take(a, m, 3 * sizeof(double));
    w->x = (double *)sqffd__arena_take(a, m, 3 * sizeof(double));
    w->area = (double *)sqffd__arena_take(a, m, sizeof(double));
    w->normal = (double *)sqffd__arena_take(a, m, 3 * sizeof(double));
    w->level = (double *)sqffd__arena_take(a, m, sizeof(double));
    w->moved = (double *)sqffd__arena_take(a, m, sizeof(double));
    w->inward = (double *)sqffd__arena_take(a, m, sizeof(double));
    w->scratch = (double *)sqffd__arena_take(a, m, sizeof(double));
    w->segment = (unsigned char *)sqffd__arena_take(a, m, 1);
    w->report = (sqffd_motion_report *)sqffd__arena_take(a, 1, sizeof(sqffd_motion_report));
}

SQFFD_DEF sqffd_result sqffd_motion_workspace_size(const sqffd_model *models, size_t frame_count, size_t *size)
{
    sqffd__arena a;
    sqffd__motion_work w;
    sqffd_result r;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    if (!models || frame_count == 0) return SQFFD_ERROR_INVALID_ARGUMENT;
    r = sqffd_model_validate(models);
    if (r != SQFFD_OK) return r;
    sqffd__arena_measure(&a);
    sqffd__motion_layout(&a, sqffd__fit_grid_count(models->grid), &w);
    return sqffd__arena_size(&a, size);
}

/* A unit vector along v (0 if v is zero, not finite, or tiny against `scale`). */
static int sqffd__unit3(const double v[3], double scale, double out[3])
{
    double len = sqrt(sqffd__dot3(v, v));
    if (!isfinite(len) || !(len > 1e-9 * scale)) return 0;
    out[0] = v[0] / len; out[1] = v[1] / len; out[2] = v[2] / len;
    return 1;
}

/* The ED mesh's vertex areas and normals. */
static void sqffd__motion_areas(const int grid[2], const double *x, double *area, double *normal)
{
    uint32_t r, c, cell[2][3];
    size_t m = sqffd__fit_grid_count(grid), v;
    int k, count, i;
    memset(area, 0, m * sizeof(double));
    memset(normal, 0, 3 * m * sizeof(double));
    for (r = 0; r <= (uint32_t)grid[0]; ++r)
        for (c = 0; c < (uint32_t)grid[1]; ++c)
            for (count = sqffd__fit_cell(grid, r, c, cell), k = 0; k < count; ++k) {
                double e1[3], e2[3], n[3], third;
                sqffd__sub3(x + 3 * (size_t)cell[k][1], x + 3 * (size_t)cell[k][0], e1);
                sqffd__sub3(x + 3 * (size_t)cell[k][2], x + 3 * (size_t)cell[k][0], e2);
                sqffd__cross3(e1, e2, n);
                third = sqrt(sqffd__dot3(n, n)) / 6.0;
                for (i = 0; i < 3; ++i) {
                    v = cell[k][i];
                    area[v] += third;
                    normal[3 * v] += n[0]; normal[3 * v + 1] += n[1]; normal[3 * v + 2] += n[2];
                }
            }
}

/* The long axis, base -> apex: the given direction, or the superquadric's
   longest axis turned toward the end where the model is narrower. */
static int sqffd__motion_axis(const sqffd_model *model, const sqffd_motion_options *o, const sqffd__motion_work *w,
                              size_t m, const double centre[3], double scale, double axis[3])
{
    double low = HUGE_VAL, high = -HUGE_VAL, width[2] = {0.0, 0.0}, weight[2] = {0.0, 0.0};
    size_t v;
    int k, longest = 0;
    if (o->apex_direction[0] != 0.0 || o->apex_direction[1] != 0.0 || o->apex_direction[2] != 0.0)
        return sqffd__unit3(o->apex_direction, sqrt(sqffd__dot3(o->apex_direction, o->apex_direction)), axis);
    for (k = 1; k < 3; ++k)
        if (model->sq.size[k] > model->sq.size[longest]) longest = k;
    for (k = 0; k < 3; ++k) axis[k] = model->sq.rotation[3 * k + longest];
    for (v = 0; v < m; ++v) {
        double d[3], t;
        sqffd__sub3(w->ed + 3 * v, centre, d);
        t = sqffd__dot3(d, axis);
        low = t < low ? t : low;
        high = t > high ? t : high;
    }
    for (v = 0; v < m; ++v) { /* the mean distance from the axis at each end */
        double d[3], t, r2;
        sqffd__sub3(w->ed + 3 * v, centre, d);
        t = sqffd__dot3(d, axis);
        r2 = sqffd__dot3(d, d) - t * t;
        k = t > high - SQFFD__MOTION_END * (high - low) ? 1 : t < low + SQFFD__MOTION_END * (high - low) ? 0 : -1;
        if (k < 0) continue;
        width[k] += w->area[v] * sqrt(r2 > 0.0 ? r2 : 0.0);
        weight[k] += w->area[v];
    }
    if (!(high - low > 1e-9 * scale)) return 0;
    if (width[1] * weight[0] > width[0] * weight[1]) /* the high end is the wider: the apex is the low one */
        for (k = 0; k < 3; ++k) axis[k] = -axis[k];
    return 1;
}

/* The AHA segment (1-17) of a wall point at level f and angle phi (radians,
   from anterior toward the septum, in [0, 2 pi)). */
static unsigned char sqffd__motion_segment(double f, double phi, double apex_fraction)
{
    const double turn = 2.0 * SQFFD__FIT_PI;
    double g = (f - apex_fraction) / (1.0 - apex_fraction);
    int sectors = g < 1.0 / 3.0 ? 4 : 6, first = g < 1.0 / 3.0 ? 13 : g < 2.0 / 3.0 ? 7 : 1, k;
    if (f < apex_fraction) return 17;
    k = (int)floor((phi + 0.5 * turn / sectors) / (turn / sectors)) % sectors;
    return (unsigned char)(first + k);
}

/* The segment (0: valve plane) of a vertex x with unit outward normal n (or
   0) in the report's frame, on a mesh whose point farthest along the axis
   is at `top`, `length` long along it, area centroid `centre`; *level: f. */
static unsigned char sqffd__motion_place(const sqffd_motion_report *rep, double top, double length, const double centre[3],
                                         const double x[3], const double n[3], double *level)
{
    double d[3], phi, f = (top - sqffd__dot3(x, rep->axis)) / length;
    *level = f < 0.0 ? 0.0 : f > 1.0 ? 1.0 : f;
    if (*level > 0.5 && -sqffd__dot3(n, rep->axis) > SQFFD__MOTION_VALVE) return 0;
    sqffd__sub3(x, centre, d);
    phi = atan2(sqffd__dot3(d, rep->septum), sqffd__dot3(d, rep->anterior));
    if (phi < 0.0) phi += 2.0 * SQFFD__FIT_PI;
    return sqffd__motion_segment(*level, phi, rep->apex_fraction);
}

SQFFD_DEF sqffd_result sqffd_motion(const sqffd_model *models, size_t frame_count, const sqffd_motion_options *options,
                                    const sqffd_motion_outputs *outputs, sqffd_motion_report *report,
                                    void *workspace, size_t workspace_size)
{
    sqffd_motion_outputs none;
    const sqffd_motion_outputs *out;
    sqffd_motion_options defaults = sqffd_motion_options_default();
    const sqffd_motion_options *o = options ? options : &defaults;
    sqffd_motion_report *rep;
    sqffd__motion_work w;
    sqffd__arena a;
    const sqffd_model *ed;
    double centre[3] = {0.0, 0.0, 0.0}, total = 0.0, scale = 0.0, top = -HUGE_VAL, bottom = HUGE_VAL, septum[3];
    double least = HUGE_VAL, band_median[SQFFD__MOTION_BANDS], wall_area[SQFFD_SEGMENTS], sum[SQFFD_SEGMENTS], low[SQFFD_SEGMENTS];
    double inward[SQFFD_SEGMENTS];
    size_t m, t, v, wall = 0;
    int k, b;
    if (!models || frame_count == 0 || o->ed_frame >= frame_count) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (!(o->low_motion_fraction >= 0.0) || !isfinite(o->low_motion_fraction) || !(o->hypokinetic_share >= 0.0) ||
        !(o->hypokinetic_share <= 1.0) || !(o->apex_fraction >= 0.0) || !(o->apex_fraction < 1.0))
        return SQFFD_ERROR_INVALID_ARGUMENT;
    for (t = 0; t < frame_count; ++t) {
        sqffd_result r = sqffd_model_validate(models + t);
        if (r != SQFFD_OK) return r;
        if (o->stacks && !sqffd__stack_valid(o->stacks + t)) return SQFFD_ERROR_INVALID_ARGUMENT;
        if (t && !sqffd__fit_same_frame(&models->sq, models->ffd.dims, models->ffd.origin, models->ffd.edges,
                                        models->grid, models + t))
            return SQFFD_ERROR_INVALID_ARGUMENT;
    }
    memset(&none, 0, sizeof none);
    out = outputs ? outputs : &none;
    m = sqffd__fit_grid_count(models->grid);
    sqffd__arena_init(&a, workspace, workspace_size);
    sqffd__motion_layout(&a, m, &w);
    if (a.overflow) return sqffd__arena_error(&a);
    rep = w.report;
    memset(rep, 0, sizeof *rep);
    /* every frame's mesh and volume; ES is the least */
    for (t = 0; t < frame_count; ++t) {
        double volume;
        if (!sqffd__fit_surface(models + t, models->grid, w.x)) return SQFFD_ERROR_NON_FINITE;
        volume = sqffd__motion_volume(o, t, models->grid, w.x);
        if (out->volumes) out->volumes[t] = volume;
        if (out->trajectories) memcpy(out->trajectories + 3 * m * t, w.x, 3 * m * sizeof(double));
        if (t == o->ed_frame) memcpy(w.ed, w.x, 3 * m * sizeof(double));
        if (volume < least) {
            least = volume;
            rep->es_frame = t;
            memcpy(w.es, w.x, 3 * m * sizeof(double));
        }
    }
    ed = models + o->ed_frame;
    rep->ed_frame = o->ed_frame;
    rep->edv = sqffd__motion_volume(o, o->ed_frame, models->grid, w.ed);
    rep->esv = least;
    if (!(rep->edv > 0.0)) return SQFFD_ERROR_DEGENERATE;
    rep->ejection_fraction = (rep->edv - rep->esv) / rep->edv;
    /* the ED geometry: areas, normals, the centre, the axis and the levels */
    sqffd__motion_areas(models->grid, w.ed, w.area, w.normal);
    for (v = 0; v < m; ++v) {
        for (k = 0; k < 3; ++k) centre[k] += w.area[v] * w.ed[3 * v + (size_t)k];
        total += w.area[v];
    }
    if (!(total > 0.0)) return SQFFD_ERROR_DEGENERATE;
    for (k = 0; k < 3; ++k) centre[k] /= total;
    scale = sqrt(total);
    if (!sqffd__motion_axis(ed, o, &w, m, centre, scale, rep->axis))
        return o->apex_direction[0] != 0.0 || o->apex_direction[1] != 0.0 || o->apex_direction[2] != 0.0
                   ? SQFFD_ERROR_INVALID_ARGUMENT : SQFFD_ERROR_DEGENERATE;
    for (v = 0; v < m; ++v) {
        double t2 = sqffd__dot3(w.ed + 3 * v, rep->axis);
        if (t2 > top) { top = t2; memcpy(rep->apex, w.ed + 3 * v, sizeof rep->apex); }
        bottom = t2 < bottom ? t2 : bottom;
    }
    rep->length = top - bottom;
    if (!(rep->length > 1e-9 * scale)) return SQFFD_ERROR_DEGENERATE;
    /* the septum, across the axis, and anterior = septum x axis */
    if (o->septum_direction[0] != 0.0 || o->septum_direction[1] != 0.0 || o->septum_direction[2] != 0.0)
        memcpy(septum, o->septum_direction, sizeof septum);
    else { /* the superquadric's first local axis other than the one nearest the long axis */
        int along = 0, first;
        for (k = 1; k < 3; ++k)
            if (fabs(ed->sq.rotation[3 * 0 + k] * rep->axis[0] + ed->sq.rotation[3 * 1 + k] * rep->axis[1] +
                     ed->sq.rotation[3 * 2 + k] * rep->axis[2]) >
                fabs(ed->sq.rotation[3 * 0 + along] * rep->axis[0] + ed->sq.rotation[3 * 1 + along] * rep->axis[1] +
                     ed->sq.rotation[3 * 2 + along] * rep->axis[2]))
                along = k;
        first = along == 0 ? 1 : 0;
        for (k = 0; k < 3; ++k) septum[k] = ed->sq.rotation[3 * k + first];
    }
    {
        double along = sqffd__dot3(septum, rep->axis), across[3], length = sqrt(sqffd__dot3(septum, septum));
        for (k = 0; k < 3; ++k) across[k] = septum[k] - along * rep->axis[k];
        if (!isfinite(length) || !sqffd__unit3(across, length * 1e3, rep->septum)) return SQFFD_ERROR_INVALID_ARGUMENT;
    }
    sqffd__cross3(rep->septum, rep->axis, rep->anterior);
    /* per vertex: level, segment (0: valve plane), displacement */
    rep->apex_fraction = o->apex_fraction;
    for (v = 0; v < m; ++v) {
        double d[3], n[3];
        sqffd__sub3(w.es + 3 * v, w.ed + 3 * v, d);
        w.moved[v] = sqrt(sqffd__dot3(d, d));
        if (!sqffd__unit3(w.normal + 3 * v, 0.0, n)) n[0] = n[1] = n[2] = 0.0;
        w.inward[v] = -sqffd__dot3(d, n);
        w.segment[v] = sqffd__motion_place(rep, top, rep->length, centre, w.ed + 3 * v, n, &w.level[v]);
        if (w.segment[v]) w.scratch[wall++] = w.inward[v];
    }
    if (wall == 0) return SQFFD_ERROR_DEGENERATE;
    rep->median_excursion = sqffd__sq_select(w.scratch, wall, wall / 2);
    for (b = 0; b < SQFFD__MOTION_BANDS; ++b) { /* the wall's median excursion at each level */
        size_t count = 0;
        for (v = 0; v < m; ++v)
            if (w.segment[v] && (int)(w.level[v] * SQFFD__MOTION_BANDS) - (w.level[v] >= 1.0) == b)
                w.scratch[count++] = w.inward[v];
        band_median[b] = count ? sqffd__sq_select(w.scratch, count, count / 2) : 0.0;
    }
    memset(wall_area, 0, sizeof wall_area);
    memset(sum, 0, sizeof sum);
    memset(low, 0, sizeof low);
    memset(inward, 0, sizeof inward);
    for (v = 0; v < m; ++v) {
        int band = (int)(w.level[v] * SQFFD__MOTION_BANDS) - (w.level[v] >= 1.0), slow;
        slow = w.segment[v] && w.inward[v] < o->low_motion_fraction * band_median[band];
        if (out->low_motion) out->low_motion[v] = (unsigned char)slow;
        if (!w.segment[v]) continue;
        k = w.segment[v] - 1;
        wall_area[k] += w.area[v];
        sum[k] += w.area[v] * w.moved[v];
        inward[k] += w.area[v] * w.inward[v];
        if (slow) low[k] += w.area[v];
    }
    for (k = 0; k < SQFFD_SEGMENTS; ++k) {
        sqffd_segment_motion *sg = rep->segments + k;
        sg->area = wall_area[k];
        sg->mean_displacement = wall_area[k] > 0.0 ? sum[k] / wall_area[k] : 0.0;
        sg->mean_excursion = wall_area[k] > 0.0 ? inward[k] / wall_area[k] : 0.0;
        sg->low_motion_share = wall_area[k] > 0.0 ? low[k] / wall_area[k] : 0.0;
        sg->hypokinetic = wall_area[k] > 0.0 && sg->low_motion_share >= o->hypokinetic_share;
    }
    if (out->displacement) memcpy(out->displacement, w.moved, m * sizeof(double));
    if (out->excursion) memcpy(out->excursion, w.inward, m * sizeof(double));
    if (out->segment) memcpy(out->segment, w.segment, m);
    if (report) *report = *rep;
    return SQFFD_OK;
}

/* ---- the heart wall -------------------------------------------------------- */

SQFFD_DEF sqffd_wall_options sqffd_wall_options_default(void)
{
    sqffd_wall_options o;
    memset(&o, 0, sizeof o);
    o.dysfunctional_thickening = 0.2;
    return o;
}

typedef struct sqffd__wall_work {
    double *ed, *es;         /* M x 3: the endocardium's ED and ES vertices (ed: each frame's first, for its volume) */
    double *area[2];         /* M: vertex areas at ED and ES (each weighs its frame's means) */
    double *normal;          /* M x 3: ED, then ES normals */
    double *thickness[2];    /* M: at ED and ES */
    double *thickening;      /* M */
    unsigned char *segment_es; /* M: the ES segments, assigned on the ES mesh */
    double (*centre)[4];     /* SQFFD_STACK_PLANES: the endocardium's centre at each plane (sqffd__wall_centres) */
    double *epi;             /* E x 3: the epicardium's vertices */
    sqffd__fit_bvh tree[2];  /* the trees over the epicardium's and the endocardium's grid meshes (sqffd__wall_ray) */
    double *myocardium;      /* frame_count */
    sqffd_wall_report *report;
} sqffd__wall_work;

static void sqffd__wall_layout(sqffd__arena *a, const sqffd_model *endo, const sqffd_model *epi, size_t frames,
                               sqffd__wall_work *w)
{
    size_t m = sqffd__fit_grid_count(endo->grid), e = sqffd__fit_grid_count(epi->grid);
    w->ed = (double *)sqffd__arena_take(a, m, 3 * sizeof(double));
    w->es = (double *)sqffd__arena_take(a, m, 3 * sizeof(double));
    w->area[0] = (double *)sqffd__arena_take(a, m, sizeof(double));
    w->area[1] = (double *)sqffd__arena_take(a, m, sizeof(double));
    w->normal = (double *)sqffd__arena_take(a, m, 3 * sizeof(double));
    w->thickness[0] = (double *)sqffd__arena_take(a, m, sizeof(double));
    w->thickness[1] = (double *)sqffd__arena_take(a, m, sizeof(double));
    w->thickening = (double *)sqffd__arena_take(a, m, sizeof(double));
    w->segment_es = (unsigned char *)sqffd__arena_take(a, m, 1);
    w->centre = (double (*)[4])sqffd__arena_take(a, SQFFD_STACK_PLANES, 4 * sizeof(double));
    w->epi = (double *)sqffd__arena_take(a, e, 3 * sizeof(double));
    sqffd__fit_bvh_layout(a, epi->grid, &w->tree[0]);
    sqffd__fit_bvh_layout(a, endo->grid, &w->tree[1]);
    w->myocardium = (double *)sqffd__arena_take(a, frames, sizeof(double));
    w->report = (sqffd_wall_report *)sqffd__arena_take(a, 1, sizeof(sqffd_wall_report));
}

SQFFD_DEF sqffd_result sqffd_wall_workspace_size(const sqffd_model *endo, const sqffd_model *epi, size_t frame_count,
                                                 size_t *size)
{
    sqffd__arena a;
    sqffd__wall_work w;
    sqffd_result r;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    if (!endo || !epi || frame_count == 0) return SQFFD_ERROR_INVALID_ARGUMENT;
    if ((r = sqffd_model_validate(endo)) != SQFFD_OK || (r = sqffd_model_validate(epi)) != SQFFD_OK) return r;
    sqffd__arena_measure(&a);
    sqffd__wall_layout(&a, endo, epi, frame_count, &w);
    return sqffd__arena_size(&a, size);
}

/* The crossing of triangle (a, b, c) by the ray from o along d (Moller &
   Trumbore's test, u and v in [0, 1] widened by SQFFD__WALL_EDGE: a ray
   through an edge that two triangles share, which rounding may put just
   outside both, meets one): its distance along d (negative behind o),
   HUGE_VAL if none or if the ray runs along the triangle's plane. */
#define SQFFD__WALL_EDGE 1e-9
static double sqffd__wall_cross(const double *a, const double *b, const double *c, const double o[3], const double d[3])
{
    double e1[3], e2[3], p[3], s[3], q[3], det, u, v;
    sqffd__sub3(o, a, s);
    sqffd__sub3(b, a, e1);
    sqffd__sub3(c, a, e2);
    sqffd__cross3(d, e2, p);
    det = sqffd__dot3(e1, p);
    if (det == 0.0) return HUGE_VAL;
    u = sqffd__dot3(s, p) / det;
    if (!(u >= -SQFFD__WALL_EDGE && u <= 1.0 + SQFFD__WALL_EDGE)) return HUGE_VAL;
    sqffd__cross3(s, e1, q);
    v = sqffd__dot3(d, q) / det;
    if (!(v >= -SQFFD__WALL_EDGE && u + v <= 1.0 + SQFFD__WALL_EDGE)) return HUGE_VAL;
    return sqffd__dot3(e2, q) / det;
}

/* The stretch [near, far] of the ray o + t d, t >= 0, inside each of a
   node's four child boxes grown by pad on every side (near > far: it
   misses the box), from inv = 1 / d per axis (finite: no 0 x inf), written
   out so that the compiler packs the four into vectors. */
static void sqffd__wall_slabs(const sqffd__fit_bvh_node *node, const double o[3], const double inv[3], double pad,
                              double near[SQFFD__FIT_BVH_WIDTH], double far[SQFFD__FIT_BVH_WIDTH])
{
    int c, k;
    for (k = 0; k < SQFFD__FIT_BVH_WIDTH; ++k) {
        near[k] = 0.0;
        far[k] = HUGE_VAL;
    }
    for (c = 0; c < 3; ++c)
        SQFFD__KEEP_LOOP
        for (k = 0; k < SQFFD__FIT_BVH_WIDTH; ++k) {
            double t1 = (node->low[c][k] - pad - o[c]) * inv[c], t2 = (node->high[c][k] + pad - o[c]) * inv[c];
            double lo = t1 < t2 ? t1 : t2, hi = t1 < t2 ? t2 : t1;
            near[k] = lo > near[k] ? lo : near[k];
            far[k] = hi < far[k] ? hi : far[k];
        }
}

/* The nearest crossing, closer than reach, of the grid mesh x (tree h over
   grid's cells, its boxes measured over x: sqffd__fit_bvh_boxes) by the ray
   from o along unit d: its distance along d (reach if none) and the
   crossed triangle's corners in tri (0 0 0 if none). The triangles with corner skip (o
   itself, a vertex of this mesh; UINT32_MAX: none) are not looked at. The
   answer is the brute force's over the mesh's triangles as sqffd_model_mesh
   lists them (the grid cells', cell by cell): the nearest, the first listed
   of equal ones. The walk visits the boxes the ray meets, nearest first,
   and skips those it enters beyond the best so far; the boxes are grown by
   a billionth of the coordinates' scale, so that a crossing whose rounding
   puts it on a triangle's edge just outside the triangle's box (a ray
   that meets an edge) is not skipped. */
static double sqffd__wall_ray(const sqffd__fit_bvh *h, const int grid[2], const double *x, const double o[3],
                              const double d[3], uint32_t skip, double reach, uint32_t tri[3])
{
    uint32_t stack[SQFFD__FIT_BVH_STACK], columns = (uint32_t)grid[1], k;
    double nears[SQFFD__FIT_BVH_STACK], inv[3], scale = 0.0, best = reach;
    size_t best_key = 0; /* the best triangle's place in the list: 2 x cell + its triangle */
    int top = 0, c;
    tri[0] = tri[1] = tri[2] = 0;
    for (c = 0; c < 3; ++c) {
        inv[c] = 1.0 / d[c];
        if (!(fabs(inv[c]) < 1e300)) inv[c] = copysign(1e300, d[c]); /* (conservative: a longer stretch) */
        scale = fmax(scale, fabs(o[c]));
        for (k = 0; k < h->nodes->count; ++k)
            scale = fmax(scale, fmax(fabs(h->nodes->low[c][k]), fabs(h->nodes->high[c][k])));
    }
    stack[top] = 0;
    nears[top++] = 0.0;
    while (top > 0) {
        const sqffd__fit_bvh_node *node;
        double near[SQFFD__FIT_BVH_WIDTH], far[SQFFD__FIT_BVH_WIDTH];
        --top;
        if (!(nears[top] < best)) continue; /* (the best may have improved since it was pushed) */
        node = h->nodes + stack[top];
        sqffd__wall_slabs(node, o, inv, 1e-9 * scale, near, far);
        if (node->bottom) {
            for (k = 0; k < node->count; ++k) {
                uint32_t cell[2][3];
                int t, count;
                if (!(near[k] <= far[k] && near[k] < best)) continue;
                count = sqffd__fit_cell(grid, node->child[k] / columns, node->child[k] % columns, cell);
                for (t = 0; t < count; ++t) {
                    size_t key = 2 * (size_t)node->child[k] + (size_t)t;
                    double at;
                    if (cell[t][0] == skip || cell[t][1] == skip || cell[t][2] == skip) continue;
                    at = sqffd__wall_cross(x + 3 * (size_t)cell[t][0], x + 3 * (size_t)cell[t][1], x + 3 * (size_t)cell[t][2], o, d);
                    if (!(at > 0.0 && (at < best || (at == best && key < best_key)))) continue;
                    best = at;
                    best_key = key;
                    memcpy(tri, cell[t], sizeof cell[t]);
                }
            }
        } else { /* the children the ray meets in reach, farthest first (so the nearest is visited next) */
            int first = top;
            for (k = 0; k < node->count; ++k)
                if (near[k] <= far[k] && near[k] < best) sqffd__fit_bvh_push(stack, nears, &top, first, near[k], node->child[k]);
        }
    }
    return best;
}

/* The segments of the endocardial mesh x (M vertices, areas and normals
   from sqffd__motion_areas) in the motion report's frame, with this mesh's
   own levels and centre, as sqffd_motion places the ED mesh's: 0 if the
   mesh is flat along the axis. */
static int sqffd__wall_segments(const sqffd_motion_report *motion, size_t m, const double *x, const double *area,
                                const double *normal, unsigned char *segment)
{
    double centre[3] = {0.0, 0.0, 0.0}, total = 0.0, top = -HUGE_VAL, bottom = HUGE_VAL, level;
    size_t v;
    int k;
    for (v = 0; v < m; ++v) {
        double at = sqffd__dot3(x + 3 * v, motion->axis);
        for (k = 0; k < 3; ++k) centre[k] += area[v] * x[3 * v + (size_t)k];
        total += area[v];
        top = at > top ? at : top;
        bottom = at < bottom ? at : bottom;
    }
    if (!(total > 0.0) || !(top - bottom > 1e-9 * sqrt(total))) return 0;
    for (k = 0; k < 3; ++k) centre[k] /= total;
    for (v = 0; v < m; ++v) {
        double n[3];
        if (!sqffd__unit3(normal + 3 * v, 0.0, n)) n[0] = n[1] = n[2] = 0.0;
        segment[v] = sqffd__motion_place(motion, top, top - bottom, centre, x + 3 * v, n, &level);
    }
    return 1;
}

/* Whether the motion report's segment frame can place the ES segments: its
   axis, septum and anterior unit vectors (within 1e-6), apex_fraction in
   [0, 1) as sqffd_motion's options (a NaN there would make a segment
   number out of range). */
static int sqffd__wall_frame_valid(const sqffd_motion_report *motion)
{
    const double *unit[3];
    int k;
    unit[0] = motion->axis;
    unit[1] = motion->septum;
    unit[2] = motion->anterior;
    for (k = 0; k < 3; ++k)
        if (!sqffd__finite3(unit[k]) || !(fabs(sqffd__dot3(unit[k], unit[k]) - 1.0) <= 1e-6)) return 0;
    return motion->apex_fraction >= 0.0 && motion->apex_fraction < 1.0;
}

/* The plane of stack around level: hi, the first plane at or above it
   (1..planes-1), and level's place between plane hi-1 (0) and hi (1); -1
   outside the outer planes. */
static double sqffd__wall_between(const sqffd_stack *stack, double level, size_t *hi)
{
    const double *at = stack->level;
    *hi = 1;
    if (!(level >= at[0] && level <= at[stack->planes - 1])) return -1.0;
    for (*hi = 1; *hi + 1 < stack->planes && at[*hi] < level; ++*hi) continue;
    return (level - at[*hi - 1]) / (at[*hi] - at[*hi - 1]);
}

/* The endocardium's centre at each plane of stack: the mean of the
   vertices x between the outer planes, each weighted by its area and
   shared between the two planes around it as it lies between them (a
   plane's cross-section's centre, from the rows of vertices near it), into
   w->centre (x y z, then the weight: 0 for a plane no vertex lies next
   to). */
static void sqffd__wall_centres(const sqffd_stack *stack, size_t m, const double *x, const double *area, sqffd__wall_work *w)
{
    size_t v, p, hi;
    int k;
    memset(w->centre, 0, stack->planes * sizeof *w->centre);
    for (v = 0; v < m; ++v) {
        double u = sqffd__wall_between(stack, sqffd__dot3(stack->axis, x + 3 * v), &hi), share[2];
        if (u < 0.0) continue;
        share[0] = (1.0 - u) * area[v];
        share[1] = u * area[v];
        for (p = 0; p < 2; ++p) {
            for (k = 0; k < 3; ++k) w->centre[hi - 1 + p][k] += share[p] * x[3 * v + (size_t)k];
            w->centre[hi - 1 + p][3] += share[p];
        }
    }
    for (p = 0; p < stack->planes; ++p)
        for (k = 0; k < 3; ++k)
            if (w->centre[p][3] > 0.0) w->centre[p][k] /= w->centre[p][3];
}

/* Frame t's wall thickness (endo vertices x, their areas and normals in
   w->normal, epicardium model epi) into thickness: along the endocardium's
   outward normal; with frame t's stack, in its planes along the ray from
   the endocardium's centre at the vertex's level (sqffd__wall_centres,
   between its planes) through the vertex, only between the outer planes.
   NaN off the wall (segment 0), without a crossing, or where the crossing
   is on the epicardium's valve plane (a triangle facing the base, as
   sqffd_motion's valve rule: the ray leaves through the base, where the
   wall is cut, not across it). */
static void sqffd__wall_thickness(const sqffd_model *endo, const sqffd_model *epi, const double *x, const double *area,
                                  const unsigned char *segment, const double axis[3], const sqffd_stack *stack,
                                  sqffd__wall_work *w, double *thickness)
{
    size_t m = sqffd__fit_grid_count(endo->grid), v, hi;
    int k;
    sqffd__fit_surface(epi, epi->grid, w->epi);
    sqffd__fit_bvh_boxes(&w->tree[0], epi->grid, w->epi);
    sqffd__fit_bvh_boxes(&w->tree[1], endo->grid, x);
    if (stack) sqffd__wall_centres(stack, m, x, area, w);
    for (v = 0; v < m; ++v) {
        double n[3], e1[3], e2[3], face[3], d;
        uint32_t t[3], other[3];
        thickness[v] = NAN;
        if (!segment[v] || !sqffd__unit3(w->normal + 3 * v, 0.0, n)) continue;
        if (stack) {
            double u = sqffd__wall_between(stack, sqffd__dot3(stack->axis, x + 3 * v), &hi), along;
            const double *below, *above;
            if (u < 0.0) continue;
            below = w->centre[hi - 1];
            above = w->centre[hi];
            if (!(below[3] > 0.0)) u = 1.0; /* (a plane no vertex lies next to: its neighbour's centre) */
            if (!(above[3] > 0.0)) u = 0.0;
            for (k = 0; k < 3; ++k) n[k] = x[3 * v + (size_t)k] - ((1.0 - u) * below[k] + u * above[k]);
            along = sqffd__dot3(stack->axis, n);
            for (k = 0; k < 3; ++k) n[k] -= along * stack->axis[k];
            if (!sqffd__unit3(n, sqrt(area[v]), n)) continue; /* (on the centre line: no direction) */
        }
        d = sqffd__wall_ray(&w->tree[0], epi->grid, w->epi, x + 3 * v, n, UINT32_MAX, HUGE_VAL, t);
        if (!(d < HUGE_VAL)) continue;
        /* a ray that meets the endocardium again first crosses the cavity, not the wall */
        if (sqffd__wall_ray(&w->tree[1], endo->grid, x, x + 3 * v, n, (uint32_t)v, d, other) < d) continue;
        sqffd__sub3(w->epi + 3 * (size_t)t[1], w->epi + 3 * (size_t)t[0], e1);
        sqffd__sub3(w->epi + 3 * (size_t)t[2], w->epi + 3 * (size_t)t[0], e2);
        sqffd__cross3(e1, e2, face);
        if (-sqffd__dot3(face, axis) > SQFFD__MOTION_VALVE * sqrt(sqffd__dot3(face, face))) continue;
        thickness[v] = d;
    }
}

SQFFD_DEF sqffd_result sqffd_wall(const sqffd_model *endo, const sqffd_model *epi, size_t frame_count,
                                  const sqffd_motion_report *motion, const unsigned char *segment,
                                  const sqffd_wall_options *options, const sqffd_wall_outputs *outputs,
                                  sqffd_wall_report *report, void *workspace, size_t workspace_size)
{
    sqffd_wall_options defaults = sqffd_wall_options_default();
    const sqffd_wall_options *o = options ? options : &defaults;
    sqffd_motion_options volumes = sqffd_motion_options_default();
    sqffd_wall_report *rep;
    sqffd__wall_work w;
    sqffd__arena a;
    double sum[SQFFD_SEGMENTS + 1][4], total[4] = {0.0, 0.0, 0.0, 0.0}; /* [c]: area x thickness, [2 + c]: area at ED, ES */
    size_t m, t, v;
    int k, c;
    if (!endo || !epi || !motion || !segment || frame_count == 0 || motion->ed_frame >= frame_count ||
        motion->es_frame >= frame_count || !sqffd__wall_frame_valid(motion) || !(o->dysfunctional_thickening > -1.0) ||
        !isfinite(o->dysfunctional_thickening))
        return SQFFD_ERROR_INVALID_ARGUMENT;
    for (t = 0; t < frame_count; ++t) {
        sqffd_result r;
        if ((r = sqffd_model_validate(endo + t)) != SQFFD_OK || (r = sqffd_model_validate(epi + t)) != SQFFD_OK) return r;
        if ((o->stacks && !sqffd__stack_valid(o->stacks + t)) || (o->endo_stacks && !sqffd__stack_valid(o->endo_stacks + t)))
            return SQFFD_ERROR_INVALID_ARGUMENT;
        if (t && (!sqffd__fit_same_frame(&endo->sq, endo->ffd.dims, endo->ffd.origin, endo->ffd.edges, endo->grid, endo + t) ||
                  !sqffd__fit_same_frame(&epi->sq, epi->ffd.dims, epi->ffd.origin, epi->ffd.edges, epi->grid, epi + t)))
            return SQFFD_ERROR_INVALID_ARGUMENT;
    }
    m = sqffd__fit_grid_count(endo->grid);
    for (v = 0; v < m; ++v)
        if (segment[v] > SQFFD_SEGMENTS) return SQFFD_ERROR_INVALID_ARGUMENT;
    sqffd__arena_init(&a, workspace, workspace_size);
    sqffd__wall_layout(&a, endo, epi, frame_count, &w);
    if (a.overflow) return sqffd__arena_error(&a);
    rep = w.report;
    memset(rep, 0, sizeof *rep);
    sqffd__fit_bvh_build(epi->grid, w.tree[0].nodes);
    sqffd__fit_bvh_build(endo->grid, w.tree[1].nodes);
    volumes.stacks = o->stacks;
    for (t = 0; t < frame_count; ++t) { /* the myocardium: the volume between the two surfaces */
        if (!sqffd__fit_surface(endo + t, endo->grid, w.ed) || !sqffd__fit_surface(epi + t, epi->grid, w.epi))
            return SQFFD_ERROR_NON_FINITE;
        w.myocardium[t] = sqffd__motion_volume(&volumes, t, epi->grid, w.epi) - sqffd__motion_volume(&volumes, t, endo->grid, w.ed);
    }
    rep->myocardium_ed = w.myocardium[motion->ed_frame];
    rep->myocardium_es = w.myocardium[motion->es_frame];
    /* the thickness at ED (the motion's segments) and at ES (its own, placed on the ES mesh) */
    sqffd__fit_surface(endo + motion->ed_frame, endo->grid, w.ed);
    sqffd__motion_areas(endo->grid, w.ed, w.area[0], w.normal);
    sqffd__wall_thickness(endo, epi + motion->ed_frame, w.ed, w.area[0], segment, motion->axis, o->endo_stacks ? o->endo_stacks + motion->ed_frame : NULL,
                          &w, w.thickness[0]);
    sqffd__fit_surface(endo + motion->es_frame, endo->grid, w.es);
    sqffd__motion_areas(endo->grid, w.es, w.area[1], w.normal);
    if (!sqffd__wall_segments(motion, m, w.es, w.area[1], w.normal, w.segment_es)) return SQFFD_ERROR_DEGENERATE;
    sqffd__wall_thickness(endo, epi + motion->es_frame, w.es, w.area[1], w.segment_es, motion->axis, o->endo_stacks ? o->endo_stacks + motion->es_frame : NULL,
                          &w, w.thickness[1]);
    memset(sum, 0, sizeof sum);
    for (v = 0; v < m; ++v) {
        const unsigned char frame_segment[2] = {segment[v], w.segment_es[v]};
        w.thickening[v] = w.thickness[1][v] / w.thickness[0][v] - 1.0; /* (NaN where either is) */
        for (c = 0; c < 2; ++c) /* each frame's means: over its own segments' vertices that it measured */
            if (w.thickness[c][v] > 0.0) {
                sum[frame_segment[c]][c] += w.area[c][v] * w.thickness[c][v];
                sum[frame_segment[c]][2 + c] += w.area[c][v];
            }
        if (!segment[v]) continue;
        if (!isfinite(w.thickening[v])) { /* (a zero ED thickness too: the surfaces touch) */
            w.thickening[v] = NAN;
            ++rep->unmeasured;
            continue;
        }
        ++rep->measured;
    }
    if (rep->measured == 0) return SQFFD_ERROR_DEGENERATE;
    for (k = 0; k < SQFFD_SEGMENTS; ++k) {
        sqffd_segment_wall *g = rep->segments + k;
        const double *s = sum[k + 1];
        for (c = 0; c < 4; ++c) total[c] += s[c];
        if (!(s[2] > 0.0 && s[3] > 0.0)) { /* no vertex of it measured in a frame (or no area): none */
            g->thickening = NAN;
            continue;
        }
        g->thickness_ed = s[0] / s[2];
        g->thickness_es = s[1] / s[3];
        g->thickening = g->thickness_es / g->thickness_ed - 1.0;
        g->dysfunctional = g->thickening < o->dysfunctional_thickening;
    }
    if (!(total[2] > 0.0 && total[3] > 0.0)) return SQFFD_ERROR_DEGENERATE;
    rep->thickness_ed = total[0] / total[2];
    rep->thickness_es = total[1] / total[3];
    rep->thickening = rep->thickness_es / rep->thickness_ed - 1.0;
    if (outputs) {
        if (outputs->myocardium) memcpy(outputs->myocardium, w.myocardium, frame_count * sizeof(double));
        if (outputs->thickness_ed) memcpy(outputs->thickness_ed, w.thickness[0], m * sizeof(double));
        if (outputs->thickness_es) memcpy(outputs->thickness_es, w.thickness[1], m * sizeof(double));
        if (outputs->thickening) memcpy(outputs->thickening, w.thickening, m * sizeof(double));
    }
    if (report) *report = *rep;
    return SQFFD_OK;
}

/* ======================================================================
   Layer 7: volumes to points
   ====================================================================== */

SQFFD_DEF sqffd_result sqffd_points_subsample_view(sqffd_points points, size_t k, double *out)
{
    sqffd_result r;
    if (k > points.count || (k > 0 && !out)) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (k == 0) return SQFFD_OK;
    r = sqffd__points_check(&points);
    if (r == SQFFD_OK) sqffd__subsample(&points, k, out);
    return r;
}

SQFFD_DEF sqffd_result sqffd_points_subsample(const double *points, size_t n, size_t k, double *out)
{
    return sqffd_points_subsample_view(sqffd_points_packed(points, n), k, out);
}

static size_t sqffd__vol_type_size(sqffd_voxel_type type)
{
    switch (type) {
    case SQFFD_VOXEL_U8: case SQFFD_VOXEL_I8: return 1;
    case SQFFD_VOXEL_U16: case SQFFD_VOXEL_I16: return 2;
    case SQFFD_VOXEL_I32: case SQFFD_VOXEL_F32: return 4;
    case SQFFD_VOXEL_F64: return 8;
    }
    return 0;
}

/* The checks every function of the layer makes of its view; *voxels = the count. */
static sqffd_result sqffd__vol_check(const sqffd_volume *v, size_t *voxels)
{
    int a;
    if (!v || !v->data || sqffd__vol_type_size(v->type) == 0) return SQFFD_ERROR_INVALID_ARGUMENT;
    *voxels = 1;
    for (a = 0; a < 3; ++a) {
        if (v->dims[a] == 0 || v->strides[a] == 0) return SQFFD_ERROR_INVALID_ARGUMENT;
        if (v->dims[a] > (size_t)-1 / *voxels) return SQFFD_ERROR_TOO_LARGE;
        *voxels *= v->dims[a];
    }
    for (a = 0; a < 12; ++a)
        if (!isfinite(v->affine[a])) return SQFFD_ERROR_NON_FINITE;
    if (!isfinite(v->scale) || !isfinite(v->offset)) return SQFFD_ERROR_NON_FINITE;
    for (a = 0; a < 3; ++a) { /* every voxel's world coordinates, and each term of them, stay far from overflow */
        double reach = fabs(v->affine[4 * a + 3]);
        int c;
        for (c = 0; c < 3; ++c) reach += fabs(v->affine[4 * a + c]) * (double)(v->dims[c] - 1);
        if (!(reach <= 1e300)) return SQFFD_ERROR_NON_FINITE;
    }
    return SQFFD_OK;
}

/* Voxels i0 .. i0 + count of row (j, k), scaled, into out. */
static void sqffd__vol_row(const sqffd_volume *v, size_t i0, size_t j, size_t k, size_t count, double *out)
{
    const double scale = v->scale != 0.0 ? v->scale : 1.0, offset = v->offset;
    const ptrdiff_t si = v->strides[0];
    const char *row = (const char *)v->data + (ptrdiff_t)i0 * si + (ptrdiff_t)j * v->strides[1] + (ptrdiff_t)k * v->strides[2];
    size_t i;
#define SQFFD__VOL_ROW(T) \
    for (i = 0; i < count; ++i) { T x; memcpy(&x, row + (ptrdiff_t)i * si, sizeof x); out[i] = scale * (double)x + offset; }
    switch (v->type) {
    case SQFFD_VOXEL_U8: SQFFD__VOL_ROW(uint8_t) break;
    case SQFFD_VOXEL_I8: SQFFD__VOL_ROW(int8_t) break;
    case SQFFD_VOXEL_U16: SQFFD__VOL_ROW(uint16_t) break;
    case SQFFD_VOXEL_I16: SQFFD__VOL_ROW(int16_t) break;
    case SQFFD_VOXEL_I32: SQFFD__VOL_ROW(int32_t) break;
    case SQFFD_VOXEL_F32: SQFFD__VOL_ROW(float) break;
    case SQFFD_VOXEL_F64: SQFFD__VOL_ROW(double) break;
    }
#undef SQFFD__VOL_ROW
}

/* Slice k's scaled values, i fastest: out[i + dims[0] j]. */
static void sqffd__vol_slice(const sqffd_volume *v, size_t k, double *out)
{
    size_t j;
    for (j = 0; j < v->dims[1]; ++j) sqffd__vol_row(v, 0, j, k, v->dims[0], out + j * v->dims[0]);
}

/* Runs body with `value` bound to each voxel's scaled value, a chunk of a
   row at a time (the range and the histogram need no workspace). */
#define SQFFD__VOL_CHUNK 64
#define SQFFD__VOL_EACH(v, value, body)                                                              \
    do {                                                                                             \
        double chunk_[SQFFD__VOL_CHUNK];                                                             \
        size_t i_, j_, k_, c_, n_;                                                                   \
        for (k_ = 0; k_ < (v)->dims[2]; ++k_)                                                        \
            for (j_ = 0; j_ < (v)->dims[1]; ++j_)                                                    \
                for (i_ = 0; i_ < (v)->dims[0]; i_ += n_) {                                          \
                    n_ = (v)->dims[0] - i_ < SQFFD__VOL_CHUNK ? (v)->dims[0] - i_ : SQFFD__VOL_CHUNK;  \
                    sqffd__vol_row((v), i_, j_, k_, n_, chunk_);                                     \
                    for (c_ = 0; c_ < n_; ++c_) {                                                    \
                        const double value = chunk_[c_];                                             \
                        body                                                                         \
                    }                                                                                \
                }                                                                                    \
    } while (0)

SQFFD_DEF sqffd_result sqffd_volume_range(const sqffd_volume *volume, double *min, double *max)
{
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    size_t voxels;
    sqffd_result res = sqffd__vol_check(volume, &voxels);
    if (res != SQFFD_OK) return res;
    if (!min || !max) return SQFFD_ERROR_INVALID_ARGUMENT;
    SQFFD__VOL_EACH(volume, x, {
        if (isfinite(x)) {
            lo = x < lo ? x : lo;
            hi = x > hi ? x : hi;
        }
    });
    if (!(lo <= hi)) return SQFFD_ERROR_DEGENERATE;
    *min = lo;
    *max = hi;
    return SQFFD_OK;
}

#define SQFFD__VOL_BINS 256

SQFFD_DEF sqffd_result sqffd_volume_otsu(const sqffd_volume *volume, double *threshold)
{
    uint32_t hist[SQFFD__VOL_BINS];
    double lo = 0.0, hi = 0.0, span, cut, total = 0.0, sum = 0.0, below = 0.0, below_sum = 0.0, best = -1.0;
    size_t first = 0, last = 0;
    int b, halved;
    sqffd_result res = sqffd_volume_range(volume, &lo, &hi);
    if (res != SQFFD_OK) return res;
    if (!threshold) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (!(hi > lo)) return SQFFD_ERROR_DEGENERATE;
    memset(hist, 0, sizeof hist);
    span = hi - lo;
    halved = !isfinite(span); /* a range wider than DBL_MAX: in halves (not always: half a denormal is 0) */
    if (halved) span = 0.5 * hi - 0.5 * lo;
    SQFFD__VOL_EACH(volume, x, {
        if (isfinite(x)) {
            double f = (halved ? 0.5 * x - 0.5 * lo : x - lo) / span * SQFFD__VOL_BINS;
            b = !(f >= 0.0) ? 0 : f >= SQFFD__VOL_BINS ? SQFFD__VOL_BINS - 1 : (int)f;
            if (hist[b] < UINT32_MAX) ++hist[b]; /* (beyond 2^32 - 1 voxels in a bin it saturates) */
        }
    });
    for (b = 0; b < SQFFD__VOL_BINS; ++b) {
        total += hist[b];
        sum += hist[b] * (b + 0.5);
    }
    /* cut after bin b: between-class variance w0 w1 (m0 - m1)^2, in bin units */
    for (b = 0; b + 1 < SQFFD__VOL_BINS; ++b) {
        double above, m0, m1, between;
        below += hist[b];
        below_sum += hist[b] * (b + 0.5);
        above = total - below;
        if (below == 0.0 || above == 0.0) continue;
        m0 = below_sum / below;
        m1 = (sum - below_sum) / above;
        between = below * above * (m0 - m1) * (m0 - m1);
        if (between > best * (1.0 + 1e-12)) { best = between; first = last = (size_t)b; }
        else if (between >= best * (1.0 - 1e-12)) last = (size_t)b;
    }
    if (best < 0.0) return SQFFD_ERROR_DEGENERATE; /* one value only */
    cut = (0.5 * (double)(first + last) + 1.0) / SQFFD__VOL_BINS; /* of the range */
    *threshold = halved ? lo + span * cut + span * cut : lo + span * cut;
    return SQFFD_OK;
}

SQFFD_DEF sqffd_iso_options sqffd_iso_options_default(void)
{
    sqffd_iso_options o;
    memset(&o, 0, sizeof o);
    o.level = 0.0;
    o.largest_component = 0;
    o.labelled = 0;
    o.label = o.label2 = 0.0;
    return o;
}

#define SQFFD__ISO_ROOT 0x80000000u

typedef struct sqffd__iso_work {
    double *slice[2];        /* slices k and k + 1 */
    unsigned char *flag[2];  /* and their voxels' inside flags (8 bytes of padding: read a word at a time) */
    uint32_t *parent;        /* largest_component: union-find over the voxels; once counted, a root holds
                                SQFFD__ISO_ROOT | its voxel count and every other voxel its root */
} sqffd__iso_work;

static void sqffd__iso_layout(sqffd__arena *a, const sqffd_volume *v, size_t voxels, int components, sqffd__iso_work *w)
{
    size_t plane = v->dims[0] * v->dims[1];
    w->slice[0] = (double *)sqffd__arena_take(a, plane, sizeof(double));
    w->slice[1] = (double *)sqffd__arena_take(a, plane, sizeof(double));
    w->flag[0] = (unsigned char *)sqffd__arena_take(a, plane + 8, 1);
    w->flag[1] = (unsigned char *)sqffd__arena_take(a, plane + 8, 1);
    w->parent = NULL;
    if (components) {
        if (voxels > 0x7FFFFFFFu) sqffd__arena_too_large(a); /* (the top bit marks the roots) */
        w->parent = (uint32_t *)sqffd__arena_take(a, voxels, sizeof(uint32_t));
    }
}

/* The level the crossings are at: a label map's values become 1 (the
   label) and 0 (any other), crossed at 0.5. */
static double sqffd__iso_level(const sqffd_iso_options *o)
{
    return o->labelled ? 0.5 : o->level;
}

/* Slice k into slice and flag buffer b (a label map's as 1 and 0). */
static void sqffd__iso_slice(const sqffd_volume *v, size_t k, const sqffd_iso_options *o, sqffd__iso_work *w, int b)
{
    size_t at, plane = v->dims[0] * v->dims[1];
    double level = sqffd__iso_level(o);
    sqffd__vol_slice(v, k, w->slice[b]);
    if (o->labelled)
        for (at = 0; at < plane; ++at)
            w->slice[b][at] = w->slice[b][at] == o->label || (o->labelled == 2 && w->slice[b][at] == o->label2) ? 1.0 : 0.0;
    for (at = 0; at < plane; ++at) w->flag[b][at] = (unsigned char)(w->slice[b][at] >= level);
    memset(w->flag[b] + plane, 0, 8);
}

SQFFD_DEF sqffd_result sqffd_iso_workspace_size(const sqffd_volume *volume, const sqffd_iso_options *options, size_t *size)
{
    sqffd__arena a;
    sqffd__iso_work w;
    size_t voxels;
    sqffd_result r;
    if (!size) return SQFFD_ERROR_INVALID_ARGUMENT;
    *size = 0;
    r = sqffd__vol_check(volume, &voxels);
    if (r != SQFFD_OK) return r;
    sqffd__arena_measure(&a);
    sqffd__iso_layout(&a, volume, voxels, options ? options->largest_component : 0, &w);
    return sqffd__arena_size(&a, size);
}

static uint32_t sqffd__iso_root(uint32_t *parent, uint32_t x)
{
    while (parent[x] != x) {
        parent[x] = parent[parent[x]]; /* path halving */
        x = parent[x];
    }
    return x;
}

static void sqffd__iso_union(uint32_t *parent, uint32_t a, uint32_t b)
{
    a = sqffd__iso_root(parent, a);
    b = sqffd__iso_root(parent, b);
    if (a != b) parent[a > b ? a : b] = a < b ? a : b; /* the smaller index is the root: deterministic */
}

/* The root of the largest 6-connected inside component (by voxel count), or
   UINT32_MAX when nothing is inside. */
static uint32_t sqffd__iso_largest(const sqffd_volume *v, const sqffd_iso_options *o, sqffd__iso_work *w)
{
    const uint32_t none = UINT32_MAX; /* an outside voxel's parent */
    size_t nx = v->dims[0], ny = v->dims[1], plane = nx * ny, voxels = plane * v->dims[2], i, j, k, x;
    uint32_t best = none;
    for (k = 0; k < v->dims[2]; ++k) {
        const int b = (int)(k & 1);
        const unsigned char *f, *back = w->flag[b ^ 1];
        sqffd__iso_slice(v, k, o, w, b);
        f = w->flag[b];
        for (j = 0; j < ny; ++j)
            for (i = 0; i < nx; ++i) {
                size_t at = i + nx * j;
                int left;
                x = at + plane * k;
                if (!f[at]) {
                    w->parent[x] = none;
                    continue;
                }
                /* a voxel joins the run on its left; the one above (behind) is already joined
                   through its left neighbour when both left ones are inside */
                left = i > 0 && f[at - 1];
                w->parent[x] = left ? w->parent[x - 1] : (uint32_t)x;
                if (j > 0 && f[at - nx] && !(left && f[at - nx - 1])) sqffd__iso_union(w->parent, (uint32_t)x, (uint32_t)(x - nx));
                if (k > 0 && back[at] && !(left && back[at - 1])) sqffd__iso_union(w->parent, (uint32_t)x, (uint32_t)(x - plane));
            }
    }
    /* a root is its component's smallest voxel (unions keep the smaller), so in voxel order it comes
       first: it becomes a counter, and each later voxel points straight at it (its chain's voxels,
       all smaller, already do: at most two steps) */
    for (x = 0; x < voxels; ++x) {
        uint32_t r = w->parent[x], count;
        if (r == none) continue;
        if (r == (uint32_t)x) {
            w->parent[x] = SQFFD__ISO_ROOT | 1u;
            r = (uint32_t)x;
        } else {
            while (!(w->parent[r] & SQFFD__ISO_ROOT)) r = w->parent[r];
            w->parent[x] = r;
            ++w->parent[r];
        }
        count = w->parent[r] & ~SQFFD__ISO_ROOT;
        if (best == none || count > (w->parent[best] & ~SQFFD__ISO_ROOT)) best = r;
    }
    return best;
}

/* The crossings of sqffd_iso_points (slices read into w again), the first
   `capacity` written; returns their count. */
static size_t sqffd__iso_scan(const sqffd_volume *v, const sqffd_iso_options *o, sqffd__iso_work *w, uint32_t keep,
                              const double axis[3][3], double *points, double *normals, size_t capacity)
{
    size_t nx, ny, plane, i, j, k, found = 0;
    int d, r;
    double level = sqffd__iso_level(o);
    nx = v->dims[0];
    ny = v->dims[1];
    plane = nx * ny;
    sqffd__iso_slice(v, 0, o, w, 0);
    for (k = 0; k < v->dims[2]; ++k) {
        const double *cur = w->slice[k & 1], *up = w->slice[(k + 1) & 1];
        const unsigned char *fc = w->flag[k & 1], *fu = w->flag[(k + 1) & 1];
        int inner_k = k + 1 < v->dims[2];
        if (inner_k) sqffd__iso_slice(v, k + 1, o, w, (int)((k + 1) & 1));
        for (j = 0; j < ny; ++j)
            for (i = 0; i < nx; ++i) {
                size_t at = i + nx * j;
                const double here = cur[at];
                if (inner_k && j + 1 < ny && i + 9 <= nx && (i & 7) == 0) {
                    /* eight voxels whose three forward neighbours are all alike: no crossing, skipped at once */
                    uint64_t a8, b8, c8, d8;
                    memcpy(&a8, fc + at, 8);
                    memcpy(&b8, fc + at + 1, 8);
                    memcpy(&c8, fc + at + nx, 8);
                    memcpy(&d8, fu + at, 8);
                    if (((a8 ^ b8) | (a8 ^ c8) | (a8 ^ d8)) == 0) {
                        i += 7;
                        continue;
                    }
                }
                for (d = 0; d < 3; ++d) {
                    double there, t, p[3];
                    int inside;
                    size_t in_at;
                    if (d == 0 ? i + 1 >= nx : d == 1 ? j + 1 >= ny : !inner_k) continue;
                    there = d == 0 ? cur[at + 1] : d == 1 ? cur[at + nx] : up[at];
                    inside = here >= level;
                    if (inside == (there >= level) || !isfinite(here) || !isfinite(there)) continue;
                    if (o->largest_component) {
                        in_at = inside ? at + plane * k
                                       : (d == 0 ? at + 1 : d == 1 ? at + nx : at) + plane * (k + (d == 2 ? 1u : 0u));
                        if ((w->parent[in_at] & SQFFD__ISO_ROOT ? (uint32_t)in_at : w->parent[in_at]) != keep) continue;
                    }
                    if (found < capacity) {
                        double *out = points + 3 * found;
                        t = isfinite(there - here) ? (level - here) / (there - here) /* (|level - here| <= it) */
                                                   : (0.5 * level - 0.5 * here) / (0.5 * there - 0.5 * here);
                        p[0] = (double)i + (d == 0 ? t : 0.0);
                        p[1] = (double)j + (d == 1 ? t : 0.0);
                        p[2] = (double)k + (d == 2 ? t : 0.0);
                        for (r = 0; r < 3; ++r)
                            out[r] = v->affine[4 * r] * p[0] + v->affine[4 * r + 1] * p[1] + v->affine[4 * r + 2] * p[2] +
                                     v->affine[4 * r + 3];
                        if (normals)
                            for (r = 0; r < 3; ++r) normals[3 * found + (size_t)r] = inside ? axis[d][r] : -axis[d][r];
                    }
                    ++found;
                }
            }
    }
    return found;
}

SQFFD_DEF sqffd_result sqffd_iso_points(const sqffd_volume *volume, const sqffd_iso_options *options, double *points,
                                        double *normals, size_t capacity, size_t *count,
                                        void *workspace, size_t workspace_size)
{
    sqffd_iso_options defaults = sqffd_iso_options_default();
    const sqffd_iso_options *o = options ? options : &defaults;
    const sqffd_volume *v = volume;
    sqffd__arena a;
    sqffd__iso_work w;
    double axis[3][3];
    size_t voxels, found;
    uint32_t keep = UINT32_MAX;
    int d, r;
    sqffd_result res = sqffd__vol_check(volume, &voxels);
    if (res != SQFFD_OK) return res;
    if (!count || (capacity && !points) || !isfinite(o->labelled ? o->label : o->level) ||
        (o->labelled == 2 && !isfinite(o->label2)))
        return SQFFD_ERROR_INVALID_ARGUMENT;
    sqffd__arena_init(&a, workspace, workspace_size);
    sqffd__iso_layout(&a, v, voxels, o->largest_component, &w);
    if (a.overflow) return sqffd__arena_error(&a);
    for (d = 0; d < 3; ++d) { /* the world direction of each voxel axis (scaled first: no under/overflow) */
        double len = 0.0, big = 0.0;
        for (r = 0; r < 3; ++r) big = fabs(v->affine[4 * r + d]) > big ? fabs(v->affine[4 * r + d]) : big;
        for (r = 0; r < 3; ++r) axis[d][r] = big > 0.0 ? v->affine[4 * r + d] / big : 0.0;
        for (r = 0; r < 3; ++r) len += axis[d][r] * axis[d][r];
        len = sqrt(len);
        for (r = 0; r < 3; ++r) axis[d][r] = len > 0.0 ? axis[d][r] / len : 0.0;
    }
    if (o->largest_component) {
        keep = sqffd__iso_largest(v, o, &w);
        if (keep == UINT32_MAX) {
            *count = 0;
            return SQFFD_OK;
        }
    }
    found = sqffd__iso_scan(v, o, &w, keep, (const double(*)[3])axis, NULL, NULL, 0); /* counted before anything is written */
    *count = found;
    if (capacity == 0) return SQFFD_OK;
    if (found > capacity) return SQFFD_ERROR_OUTPUT_TOO_SMALL;
    sqffd__iso_scan(v, o, &w, keep, (const double(*)[3])axis, points, normals, capacity);
    return SQFFD_OK;
}

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

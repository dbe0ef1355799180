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
SQFFD_DEF sqffd_result sqffd_cholesky_factor(double *a, int n);

/* Solves L L^T x = b in place (b becomes x), L from sqffd_cholesky_factor. */
SQFFD_DEF void sqffd_cholesky_solve(const double *l, int n, double *b);

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
SQFFD_DEF size_t sqffd_svd_workspace_size(int m, int n);
SQFFD_DEF sqffd_result sqffd_svd(const double *a, int m, int n, double *u, double *s, double *v,
                                 void *workspace, size_t workspace_size);

/* Least-squares / pseudo-inverse solve x = V diag(1/s_i) U^T b over the
   singular values s_i > rcond * s_0 (all others are treated as zero), from
   the output of sqffd_svd (u and v required). b has m entries, x has n,
   scratch has n doubles. Returns the numerical rank used (0: x = 0). */
SQFFD_DEF int sqffd_svd_solve(const double *u, const double *s, const double *v, int m, int n,
                              double rcond, const double *b, double *x, double *scratch);

/* Linear conjugate gradient for a symmetric positive definite system A x = b,
   A given as a mat-vec callback (y = A x, y never aliases x). */
typedef void (*sqffd_matvec_fn)(void *user, const double *x, double *y);
typedef struct sqffd_cg_options {
    int max_iterations;            /* 0 (default) = 2 n */
    double tolerance;              /* stop when ||r|| <= tolerance * ||b||, default 1e-10 */
    const double *jacobi_diagonal; /* diagonal of A for the Jacobi preconditioner, NULL = none (default) */
} sqffd_cg_options;
SQFFD_DEF sqffd_cg_options sqffd_cg_options_default(void);
SQFFD_DEF size_t sqffd_cg_workspace_size(int n);
/* x: in the starting guess, out the solution. options NULL = defaults.
   iterations and relative_residual (true ||b - A x|| / ||b||, one extra
   mat-vec) may be NULL. Results: SQFFD_ERROR_INVALID_ARGUMENT (NULL pointers,
   n < 1, negative options), SQFFD_ERROR_NON_FINITE (b, x or a mat-vec result),
   SQFFD_ERROR_NOT_POSITIVE_DEFINITE (p^T A p <= 0, or a preconditioner
   diagonal entry <= 0), SQFFD_ERROR_NO_CONVERGENCE (limit reached; x holds
   the last iterate), SQFFD_ERROR_WORKSPACE_TOO_SMALL. */
SQFFD_DEF sqffd_result sqffd_cg_solve(int n, sqffd_matvec_fn matvec, void *user, const double *b, double *x,
                                      const sqffd_cg_options *options, int *iterations, double *relative_residual,
                                      void *workspace, size_t workspace_size);

/* Nonlinear conjugate gradient (Polak-Ribiere+, restarted every n steps or
   when the direction stops descending) with a bracketing weak-Wolfe line
   search along the projected path x(t) = project(x + t d).
   f returns f(x) and writes the gradient. project (may be NULL) clamps x into
   a feasible set (e.g. a box) in place; it is applied to the start point too.
   Stops with SQFFD_OK when the projected gradient step is small,
   ||project(x - g) - x||_inf <= tolerance * (1 + |f|), or when no step can
   decrease f any more at machine precision; SQFFD_ERROR_NO_CONVERGENCE after
   max_iterations (x, fx: the last accepted point, usable). progress (may be NULL) is called once per iteration with stage
   SQFFD_STAGE_SUPERQUADRIC and error = f; non-zero cancels
   (SQFFD_ERROR_CANCELLED, x = the last accepted point). iterations and fx may be NULL.
   Other results: SQFFD_ERROR_INVALID_ARGUMENT (NULL f/x, n < 1,
   max_iterations < 1, tolerance < 0), SQFFD_ERROR_NON_FINITE (x or f/gradient
   at the start point), SQFFD_ERROR_WORKSPACE_TOO_SMALL. */
typedef double (*sqffd_objective_fn)(void *user, const double *x, double *gradient);
typedef void (*sqffd_project_fn)(void *user, double *x);
SQFFD_DEF size_t sqffd_ncg_workspace_size(int n);
SQFFD_DEF sqffd_result sqffd_ncg_minimize(int n, sqffd_objective_fn f, sqffd_project_fn project, void *user, double *x,
                                          int max_iterations, double tolerance, int *iterations, double *fx,
                                          sqffd_progress_fn progress, void *progress_user,
                                          void *workspace, size_t workspace_size);

/* ======================================================================
   Layer 5: model fit (superquadric + FFD, the paper's two-step algorithm)
   ====================================================================== */

/* The global shape model: 13 superquadric numbers plus the control lattice.
   Model point (eta, omega) = FFD(superquadric point (eta, omega)).
   The model's grid (n_eta x n_omega) places its model points and its mesh:
   vertex i * n_omega + j is (eta_i, omega_j) with eta_i = -pi/2 + (i + 1) pi /
   (n_eta + 1) (rows strictly between the poles, evenly spaced with them) and
   omega_j = -pi + 2 pi j / n_omega; then the south pole (eta = -pi/2) and the
   north pole (eta = pi/2): n_eta n_omega + 2 vertices, 2 n_eta n_omega
   triangles (quads split along their (i, j)-(i+1, j+1) diagonal, fans at the
   poles, outward-facing for a proper superquadric).

   THE ERROR (used everywhere: report, history, progress, distances): for each
   data point, its Euclidean distance to the model's triangle mesh on the
   model's grid, taken as the exact distance to the nearest of the triangles
   around the mesh vertex nearest to the point; the RMS of these over the
   points, and relative = that RMS divided by the diagonal of the data's
   axis-aligned bounding box. */
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
    SQFFD_SOLVER_CHOLESKY = 0,  /* Cholesky factor of the normal matrix B^T B + a D^T D, built and factored once (default; needs alpha > 0 where B alone is rank-deficient) */
    SQFFD_SOLVER_SVD = 1        /* SVD of the stacked [B; sqrt(a) D], once, as in the paper: pseudo-inverse solution, singular values below 1e-10 of the largest dropped (rank-deficient B is fine, alpha may be 0) */
} sqffd_solver;

typedef struct sqffd_fit_options {
    sqffd_sq_fit_options sq;     /* stage 1 (its progress defaults to the one below) */
    int lattice[3];              /* control points per axis, 2..SQFFD_MAX_LATTICE (default 5 x 5 x 5) */
    double box_margin;           /* box = the tapered superquadric's local bounding box, axes along its axes, grown by this fraction per side (default 0.1) */
    int grid[2];                 /* model-point grid n_eta x n_omega (default 32 x 64: 2,050 model points) */
    double alpha;                /* regularisation weight >= 0 (default 1e-5); the solver uses a = alpha M / L (M model points, L control points), i.e. alpha weighs the mean spring energy per control point against the mean squared residual per model point */
    sqffd_regularization regularization;
    sqffd_solver solver;
    int max_iterations;          /* two-step iterations (default 30) */
    double tolerance;            /* stop when RMS ||X_{n+1} - X_n|| / diagonal <= this (default 1e-4; 0 = always max_iterations) */
    int symmetric;               /* non-zero: also pull model points toward their closest data points (X^a halfway between step 1's target and the closest data point; builds a tree over the data) */
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

typedef struct sqffd_fit_report {
    sqffd_sq_fit_report sq;        /* stage 1 (sqffd_fit only) */
    sqffd_distance_stats sq_error; /* data -> starting model: the superquadric alone for sqffd_fit */
    sqffd_distance_stats error;    /* data -> final model ("the error") */
    int iterations;                /* two-step iterations done */
    int converged;                 /* the tolerance was reached */
    double step;                   /* RMS move of the model points in the last iteration / diagonal */
    int history_count;
    double history[SQFFD_FIT_HISTORY]; /* relative RMS error after iteration 1, 2, ... (over the FFD subsample) */
} sqffd_fit_report;

SQFFD_DEF sqffd_fit_options sqffd_fit_options_default(void);
SQFFD_DEF size_t sqffd_fit_workspace_size(size_t n, const sqffd_fit_options *options);
/* Fit the model to n points (x y z each): the superquadric fit, a box around
   it with the regular lattice P0, model points X0 = B P0 on the grid, then the
   two-step iteration: (1) each data point's closest point on the model
   surface (the mesh of the model points: nearest model point by kd-tree, then
   the triangles around it, as for the error; searched afresh only where the
   model's moves since the previous iteration could have changed the answer,
   which gives the same answer); its displacement to the data
   point is spread over that triangle's three model points with the
   barycentric weights and averaged per model point; model points no data
   point reached are filled by interpolation over the mesh (breadth-first from
   the reached ones, then neighbour averaging; wraps in omega, the poles are
   mesh vertices); X^a = X + displacement; (2) control points minimising
   ||B P - X^a||^2 + a ||D (P - P0)||^2 (or ||D P||^2), X = B P.
   report may be NULL. Results: INVALID_ARGUMENT (NULL, lattice out of range,
   grid too coarse to mesh, alpha < 0 or NaN, bad options), TOO_LARGE (grid),
   NON_FINITE, TOO_FEW_POINTS, DEGENERATE, WORKSPACE_TOO_SMALL, CANCELLED,
   NOT_POSITIVE_DEFINITE (Cholesky with alpha = 0 on a rank-deficient B), and
   whatever sqffd_sq_fit rejects. */
SQFFD_DEF sqffd_result sqffd_fit(const double *points, size_t n, const sqffd_fit_options *options,
                                 sqffd_model *model, sqffd_fit_report *report,
                                 void *workspace, size_t workspace_size);

/* A model around a given superquadric: the box, the regular lattice P0
   (options->lattice, box_margin) and the grid (options->grid); the model
   surface is then the superquadric itself. */
SQFFD_DEF sqffd_result sqffd_model_init(sqffd_model *model, const sqffd_superquadric *sq, const sqffd_fit_options *options);
/* Stage 2 alone: the two-step iteration starting from the model as given (its
   superquadric, box, grid and current control points; the springs' rest
   state P0 is its box's regular lattice). options' lattice, grid, box_margin
   and sq are not used. report->sq_error is the starting model's error. */
SQFFD_DEF size_t sqffd_fit_ffd_workspace_size(size_t n, const sqffd_model *model, const sqffd_fit_options *options);
SQFFD_DEF sqffd_result sqffd_fit_ffd(const double *points, size_t n, const sqffd_fit_options *options, sqffd_model *model,
                                     sqffd_fit_report *report, void *workspace, size_t workspace_size);

/* The model surface point at (eta, omega). */
SQFFD_DEF void sqffd_model_point(const sqffd_model *model, double eta, double omega, double point[3]);
/* Triangle mesh of the model surface on an n_eta x n_omega grid laid out as
   above (closed, poles included): n_eta n_omega + 2 vertices (x y z each),
   2 n_eta n_omega triangles (3 uint32 indices each). INVALID_ARGUMENT when
   n_eta < 2 or n_omega < 3, TOO_LARGE beyond 65,536 per axis or 2^32 vertices.
   vertices or triangles may be NULL. */
SQFFD_DEF sqffd_result sqffd_model_mesh_size(int n_eta, int n_omega, size_t *vertex_count, size_t *triangle_count);
SQFFD_DEF sqffd_result sqffd_model_mesh(const sqffd_model *model, int n_eta, int n_omega, double *vertices, uint32_t *triangles);
/* Data-to-model distance of each point ("the error"; per_point may be NULL)
   and statistics, on the model's grid mesh. */
SQFFD_DEF size_t sqffd_model_distances_workspace_size(size_t n, const sqffd_model *model);
SQFFD_DEF sqffd_result sqffd_model_distances(const sqffd_model *model, const double *points, size_t n,
                                             double *per_point, sqffd_distance_stats *stats,
                                             void *workspace, size_t workspace_size);
/* Model-to-data: for each vertex of the model's grid mesh, the distance to
   the nearest data point (per_vertex may be NULL), statistics relative to the
   data's diagonal. Shows whether parts of the model wander off where there is
   no data. The workspace holds a tree over the data. */
SQFFD_DEF size_t sqffd_model_reverse_distances_workspace_size(size_t n, const sqffd_model *model);
SQFFD_DEF sqffd_result sqffd_model_reverse_distances(const sqffd_model *model, const double *points, size_t n,
                                                     double *per_vertex, sqffd_distance_stats *stats,
                                                     void *workspace, size_t workspace_size);

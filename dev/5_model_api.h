/* ======================================================================
   Layer 5: model fit (superquadric + FFD, the paper's two-step algorithm)
   ====================================================================== */

/* The global shape model: 13 superquadric numbers plus the control lattice.
   Model point (eta, omega) = FFD(superquadric point (eta, omega)). */
typedef struct sqffd_model {
    sqffd_superquadric sq;
    sqffd_ffd ffd;
    int grid[2]; /* n_eta, n_omega of the model-point grid used by the fit */
} sqffd_model;

typedef enum sqffd_regularization {
    SQFFD_REG_DISPLACEMENT = 0, /* alpha ||D (P - P0)||^2: springs on the control-point displacements; keeps the box regular without shrinking it (default) */
    SQFFD_REG_POSITION = 1      /* alpha ||D P||^2: the paper's zero-length springs between lattice neighbours (also shrinks the box) */
} sqffd_regularization;

typedef enum sqffd_solver {
    SQFFD_SOLVER_CHOLESKY = 0,  /* Cholesky factor of the normal matrix, built and factored once (default) */
    SQFFD_SOLVER_SVD = 1        /* SVD, as in the paper (pseudo-inverse, rank-deficient B is fine) */
} sqffd_solver;

typedef struct sqffd_fit_options {
    sqffd_sq_fit_options sq;     /* stage 1 */
    int lattice[3];              /* control points per axis (default 5 x 5 x 5) */
    double box_margin;           /* box = superquadric's bounding box grown by this fraction per side */
    int grid[2];                 /* model-point grid n_eta x n_omega */
    double alpha;                /* regularisation weight (scaled so it does not depend on the number of model points) */
    sqffd_regularization regularization;
    sqffd_solver solver;
    int max_iterations;          /* two-step iterations (default 30) */
    double tolerance;            /* stop when RMS ||X_{n+1} - X_n|| / diagonal falls below this */
    int symmetric;               /* non-zero: also pull model points toward their closest data points */
    sqffd_progress_fn progress;
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
    sqffd_sq_fit_report sq;        /* stage 1 */
    sqffd_distance_stats sq_error; /* data -> superquadric-only model */
    sqffd_distance_stats error;    /* data -> final model ("the error") */
    int iterations;
    int converged;
    int history_count;
    double history[SQFFD_FIT_HISTORY]; /* relative RMS error after each iteration */
} sqffd_fit_report;

SQFFD_DEF sqffd_fit_options sqffd_fit_options_default(void);
SQFFD_DEF size_t sqffd_fit_workspace_size(size_t n, const sqffd_fit_options *options);
/* Fit the model to n points. report may be NULL. */
SQFFD_DEF sqffd_result sqffd_fit(const double *points, size_t n, const sqffd_fit_options *options,
                                 sqffd_model *model, sqffd_fit_report *report,
                                 void *workspace, size_t workspace_size);
/* The model surface point at (eta, omega). */
SQFFD_DEF void sqffd_model_point(const sqffd_model *model, double eta, double omega, double point[3]);
/* Triangle mesh of the model surface on an n_eta x n_omega grid (closed, poles included). */
SQFFD_DEF sqffd_result sqffd_model_mesh_size(int n_eta, int n_omega, size_t *vertex_count, size_t *triangle_count);
SQFFD_DEF sqffd_result sqffd_model_mesh(const sqffd_model *model, int n_eta, int n_omega, double *vertices, uint32_t *triangles);
/* Data-to-model distance of each point (per_point may be NULL) and statistics. */
SQFFD_DEF size_t sqffd_model_distances_workspace_size(size_t n, const sqffd_model *model);
SQFFD_DEF sqffd_result sqffd_model_distances(const sqffd_model *model, const double *points, size_t n,
                                             double *per_point, sqffd_distance_stats *stats,
                                             void *workspace, size_t workspace_size);

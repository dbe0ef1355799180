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

/* Inside-outside function F (tapering undone first): < 1 inside, 1 on the
   surface, > 1 outside. */
SQFFD_DEF double sqffd_sq_inside_outside(const sqffd_superquadric *sq, const double point[3]);
/* Radial distance: |p - c| |1 - F^(-e1/2)| measured in the untapered local
   frame along the ray from the centre (an approximation of the Euclidean
   distance that is exact for spheres). */
SQFFD_DEF double sqffd_sq_radial_distance(const sqffd_superquadric *sq, const double point[3]);
/* World surface point and outward unit normal at (eta, omega); normal may be NULL. */
SQFFD_DEF void sqffd_sq_point(const sqffd_superquadric *sq, double eta, double omega, double point[3], double normal[3]);
/* Regular grid: n_eta rows from eta = -pi/2 to pi/2 (poles included), n_omega
   columns from omega = -pi (included) to pi (excluded); row-major, point
   (i, j) at index i * n_omega + j. normals may be NULL. */
SQFFD_DEF sqffd_result sqffd_sq_sample_grid(const sqffd_superquadric *sq, int n_eta, int n_omega, double *points, double *normals);
/* Near-equal-distance sampling (Pilu & Fisher): points spaced about `spacing`
   apart along both parametric directions, so flat and pointy shapes are
   covered evenly. Returns how many points the sampling has; writes at most
   `capacity` (call with capacity 0 to count). */
SQFFD_DEF size_t sqffd_sq_sample_uniform(const sqffd_superquadric *sq, double spacing, double *points, size_t capacity);
/* Enclosed volume (closed form with the beta function; tapering multiplies it by a known factor). */
SQFFD_DEF double sqffd_sq_volume(const sqffd_superquadric *sq);
/* Deterministic volumetric intersection-over-union of two superquadrics,
   estimated on a resolution^3 grid over the union of their bounding boxes. */
SQFFD_DEF double sqffd_sq_iou(const sqffd_superquadric *a, const sqffd_superquadric *b, int resolution);

typedef enum sqffd_sq_cost {
    SQFFD_SQ_COST_SOLINA = 0, /* sqrt(a1 a2 a3) (F^e1 - 1): the paper's equation (1) family (default) */
    SQFFD_SQ_COST_RADIAL = 1  /* radial distance */
} sqffd_sq_cost;

typedef enum sqffd_sq_optimizer {
    SQFFD_SQ_OPTIMIZER_LM = 0, /* Levenberg-Marquardt, analytic Jacobian (default) */
    SQFFD_SQ_OPTIMIZER_CG = 1  /* the paper's conjugate-gradient descent */
} sqffd_sq_optimizer;

typedef struct sqffd_sq_fit_options {
    sqffd_sq_cost cost;
    sqffd_sq_optimizer optimizer;
    int taper;                 /* non-zero: fit Kx, Ky (13 parameters); 0: 11 parameters, K = 0 */
    double shape_min, shape_max; /* bounds on e1, e2 (default 0.1, 1.9) */
    double taper_max;          /* |K| bound (default 0.95) */
    int max_iterations;        /* per start */
    double tolerance;          /* relative cost decrease that counts as converged */
    int robust;                /* non-zero: outlier-robust mode (Gaussian + uniform mixture weights) */
    int robust_rounds;         /* outer re-weighting rounds in robust mode */
    sqffd_progress_fn progress;
    void *progress_user;
} sqffd_sq_fit_options;

typedef struct sqffd_sq_fit_report {
    int iterations;       /* total optimiser iterations over all starts and rounds */
    double cost;          /* final cost of the winning start */
    double rms_radial;    /* RMS radial distance of the (inlier-weighted) points */
    int start;            /* which start won (0 = moments-of-inertia axes as found) */
    int converged;
    double inlier_fraction; /* robust mode: sum of weights / n; 1 otherwise */
} sqffd_sq_fit_report;

/* Fewest points sqffd_sq_fit accepts (one per parameter). */
#define SQFFD_SQ_FIT_MIN_POINTS 13

SQFFD_DEF sqffd_sq_fit_options sqffd_sq_fit_options_default(void);
SQFFD_DEF size_t sqffd_sq_fit_workspace_size(size_t n, const sqffd_sq_fit_options *options);
/* Fit a superquadric to n points (x y z each). report may be NULL.
   TOO_FEW_POINTS below the minimum, NON_FINITE, DEGENERATE (coincident,
   collinear or coplanar), INVALID_ARGUMENT (bad options), WORKSPACE_TOO_SMALL,
   CANCELLED. */
SQFFD_DEF sqffd_result sqffd_sq_fit(const double *points, size_t n, const sqffd_sq_fit_options *options,
                                    sqffd_superquadric *sq, sqffd_sq_fit_report *report,
                                    void *workspace, size_t workspace_size);

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
   surface, > 1 outside. Computed in logarithms; may be +inf far away. */
SQFFD_DEF double sqffd_sq_inside_outside(const sqffd_superquadric *sq, const double point[3]);
/* Radial distance: |u| |1 - F^(-e1/2)|, u the point in the untapered local
   frame: the distance along the ray from the centre (an approximation of the
   Euclidean distance that is exact for spheres). */
SQFFD_DEF double sqffd_sq_radial_distance(const sqffd_superquadric *sq, const double point[3]);
/* World surface point and outward unit normal at (eta, omega); normal may be
   NULL. The normal is analytic (finite at the poles and for small e). */
SQFFD_DEF void sqffd_sq_point(const sqffd_superquadric *sq, double eta, double omega, double point[3], double normal[3]);
/* Regular grid: n_eta rows from eta = -pi/2 to pi/2 (poles included), n_omega
   columns from omega = -pi (included) to pi (excluded); row-major, point
   (i, j) at index i * n_omega + j. normals may be NULL. INVALID_ARGUMENT for
   NULL sq/points, n_eta < 2 or n_omega < 1; TOO_LARGE if 3 n_eta n_omega
   doubles do not fit a size_t. */
SQFFD_DEF sqffd_result sqffd_sq_sample_grid(const sqffd_superquadric *sq, int n_eta, int n_omega, double *points, double *normals);
/* Near-equal-distance sampling (after Pilu & Fisher): rows of constant eta
   about `spacing` apart (measured on the longest of eight meridians), each
   row walked in omega with steps of about `spacing` (each step searched so
   its chord is the spacing within 10%), so flat and pointy shapes are
   covered evenly. Like Pilu & Fisher's product sampling, a shape much
   longer in x or y than its meridians are elsewhere gets its rows closer
   than `spacing` where the meridians are short. Returns how many points the
   sampling has and writes at most `capacity` of them (points may be NULL
   with capacity 0 to count). Returns 0 for an invalid superquadric, a
   spacing that is not positive and finite, or one so small that the count
   could pass ~1e8. */
SQFFD_DEF size_t sqffd_sq_sample_uniform(const sqffd_superquadric *sq, double spacing, double *points, size_t capacity);
/* Enclosed volume: a1 a2 a3 e1 e2 B(e2/2, e2/2) [B(e1/2, e1+1) + Kx Ky B(3 e1/2, e1+1)]
   (the untapered 2 a1 a2 a3 e1 e2 B(e1/2+1, e1) B(e2/2, e2/2), plus the
   tapering's term from the second moment of the cross-sections in z). */
SQFFD_DEF double sqffd_sq_volume(const sqffd_superquadric *sq);
/* Deterministic volumetric intersection-over-union of two superquadrics,
   counted at the cell centres of a resolution^3 grid over the union of
   their bounding boxes (48-64 resolve ~0.5%). -1 for NULL, an invalid
   superquadric or resolution < 1. */
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
    sqffd_sq_cost cost;           /* residual of the plain fit (default SOLINA) */
    sqffd_sq_optimizer optimizer; /* default LM */
    int taper;                 /* non-zero (default): fit Kx, Ky (13 parameters); 0: 11 parameters, K = 0 */
    double shape_min, shape_max; /* bounds on e1, e2 (default 0.1, 1.9; 0.01 <= min <= max <= 4) */
    double taper_max;          /* |K| bound (default 0.95, < 1) */
    int max_iterations;        /* per optimiser run (default 100; the CG gets 4 times as many) */
    double tolerance;          /* relative cost decrease that counts as converged (default 1e-5) */
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
} sqffd_sq_fit_report;

/* Fewest points sqffd_sq_fit accepts (one per parameter). */
#define SQFFD_SQ_FIT_MIN_POINTS 13

SQFFD_DEF sqffd_sq_fit_options sqffd_sq_fit_options_default(void);
/* Bytes of workspace a fit of n points needs with these options (NULL =
   defaults); 0 when that size cannot be represented. */
SQFFD_DEF size_t sqffd_sq_fit_workspace_size(size_t n, const sqffd_sq_fit_options *options);
/* Fit a superquadric to n points (x y z each); options NULL = defaults,
   report may be NULL. The data are normalised (centroid, RMS radius); the
   starts come from the moments of inertia (each principal axis as the local
   z, several (e1, e2) seeds, axes turned 45 degrees where two eigenvalues
   are close), are screened on a small subsample, the best run to
   convergence on a larger one, then on all points. Robust mode starts from
   the points that are not isolated (a nearest-neighbour density test),
   ranks the best starts on them, and alternates EM re-weighting with
   weighted fits of the radial distance (on the larger subsample, then on
   all points). A fit whose RMS radial distance exceeds 5% of its mean size
   (data that are no superquadric) is kept within the data's box enlarged by
   25%; a close fit may reach past it (a partial view). Deterministic.
   Results: INVALID_ARGUMENT (NULL points/sq, bad options), TOO_FEW_POINTS
   (n < SQFFD_SQ_FIT_MIN_POINTS), WORKSPACE_TOO_SMALL (also a NULL workspace),
   NON_FINITE, DEGENERATE (coincident, collinear or coplanar: smallest
   covariance eigenvalue <= 1e-10 of the largest), CANCELLED. On failure
   *sq and *report are not written. */
SQFFD_DEF sqffd_result sqffd_sq_fit(const double *points, size_t n, const sqffd_sq_fit_options *options,
                                    sqffd_superquadric *sq, sqffd_sq_fit_report *report,
                                    void *workspace, size_t workspace_size);

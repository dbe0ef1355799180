/* ======================================================================
   Layer 5: model fit (superquadric + FFD, the paper's two-step algorithm)
   ====================================================================== */

#define SQFFD__FIT_PI 3.14159265358979323846
#define SQFFD__FIT_MAX_GRID 65536     /* per grid axis */
#define SQFFD__FIT_MIN_POINTS 4       /* sqffd_fit_ffd; sqffd_fit defers to the superquadric fit */
#define SQFFD__FIT_FILL_SWEEPS 8      /* smoothing sweeps over the unreached model points */
#define SQFFD__FIT_MAX_WALK 8         /* fan-to-fan moves of the closest-point search */
#define SQFFD__FIT_SVD_RCOND 1e-10    /* singular values below this fraction of the largest are dropped */
#define SQFFD__FIT_BLOCK 32           /* rows of B per block while forming B^T B */
#define SQFFD__FIT_TILE 64            /* columns of B per tile while forming B^T B */
#define SQFFD__FIT_PAD 8              /* the block's row stride is L + 8: a power-of-two L would map its rows onto one cache set */

/* ---- the (eta, omega) grid and its closed mesh ----------------------------
   Vertex i * n_omega + j is (eta_i, omega_j) with eta_i = -pi/2 + (i + 1) pi /
   (n_eta + 1) (rows strictly between the poles, evenly spaced with them) and
   omega_j = -pi + 2 pi j / n_omega; then the south pole (eta = -pi/2), then
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

static void sqffd__fit_grid_angles(const int grid[2], size_t v, double *eta, double *omega)
{
    size_t rows = (size_t)grid[0] * (size_t)grid[1];
    if (v >= rows) {
        *eta = v == rows ? -0.5 * SQFFD__FIT_PI : 0.5 * SQFFD__FIT_PI;
        *omega = 0.0;
        return;
    }
    *eta = -0.5 * SQFFD__FIT_PI + SQFFD__FIT_PI * (double)(v / (size_t)grid[1] + 1) / (double)(grid[0] + 1);
    *omega = -SQFFD__FIT_PI + 2.0 * SQFFD__FIT_PI * (double)(v % (size_t)grid[1]) / (double)grid[1];
}

/* The mesh neighbours of a vertex in cyclic order: the triangles around v are
   (v, ring k, ring k+1 mod count). A pole's ring is its whole adjacent row. */
typedef struct sqffd__fit_ring {
    size_t count;
    size_t base;    /* pole: first vertex of the adjacent row */
    int pole;
    size_t v[6];    /* other vertices */
} sqffd__fit_ring;

static void sqffd__fit_ring_of(const int grid[2], size_t v, sqffd__fit_ring *r)
{
    size_t ne = (size_t)grid[1], rows = (size_t)grid[0] * ne;
    size_t south = rows, north = rows + 1, i, j, jp, jm, c, cand[6];
    r->count = 0;
    r->pole = v >= rows;
    if (r->pole) {
        r->base = v == south ? 0 : rows - ne;
        r->count = ne;
        return;
    }
    i = v / ne; j = v - i * ne; jp = j + 1 < ne ? j + 1 : 0; jm = j > 0 ? j - 1 : ne - 1;
    cand[0] = i * ne + jp;
    cand[1] = i + 1 < (size_t)grid[0] ? (i + 1) * ne + jp : north;
    cand[2] = i + 1 < (size_t)grid[0] ? (i + 1) * ne + j : north;
    cand[3] = i * ne + jm;
    cand[4] = i > 0 ? (i - 1) * ne + jm : south;
    cand[5] = i > 0 ? (i - 1) * ne + j : south;
    for (c = 0; c < 6; ++c) /* a pole appears twice in a row next to it */
        if (r->count == 0 || cand[c] != r->v[r->count - 1]) r->v[r->count++] = cand[c];
    r->base = 0;
}

static size_t sqffd__fit_ring_at(const sqffd__fit_ring *r, size_t k)
{
    return r->pole ? r->base + k : r->v[k];
}

/* Closest point to p on the triangle (v, v + ea, v + eb), from ap = p - v and
   the dot products pa = ea.ap, pb = eb.ap, aa = ea.ea, bb = eb.eb,
   ab = ea.eb (a fan shares most of them): its barycentric weights w (of v,
   a, b; w[0] is exactly 0 on the edge ab and its ends), by the Voronoi
   regions of the vertices, edges and face (Ericson, Real-Time Collision
   Detection, 5.1.5), and its squared distance. A flat triangle falls back on
   its nearest vertex, a zero-length edge on its end. */
static double sqffd__fit_triangle(const double ap[3], const double ea[3], const double eb[3], double pa, double pb,
                                  double aa, double bb, double ab, double w[3])
{
    double d3 = pa - aa, d4 = pb - ab, d5 = pa - ab, d6 = pb - bb;
    double vc = pa * d4 - d3 * pb, vb = d5 * pb - pa * d6, va = d3 * d6 - d5 * d4, sum, r[3];
    int k;
    w[0] = w[1] = w[2] = 0.0;
    if (pa <= 0.0 && pb <= 0.0) w[0] = 1.0;                               /* vertex v */
    else if (d3 >= 0.0 && d4 <= d3) w[1] = 1.0;                           /* vertex a */
    else if (d6 >= 0.0 && d5 <= d6) w[2] = 1.0;                           /* vertex b */
    else if (vc <= 0.0 && pa >= 0.0 && d3 <= 0.0) {                       /* edge va */
        w[1] = aa > 0.0 ? pa / aa : 0.0; w[0] = 1.0 - w[1];
    } else if (vb <= 0.0 && pb >= 0.0 && d6 <= 0.0) {                     /* edge vb */
        w[2] = bb > 0.0 ? pb / bb : 0.0; w[0] = 1.0 - w[2];
    } else if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0) {           /* edge ab */
        double len2 = (d4 - d3) + (d5 - d6); /* |eb - ea|^2 */
        w[2] = len2 > 0.0 ? (d4 - d3) / len2 : 0.0; w[1] = 1.0 - w[2];
    } else if ((sum = va + vb + vc) > 0.0) {                              /* face */
        double inv = 1.0 / sum;
        w[1] = vb * inv; w[2] = vc * inv; w[0] = va * inv;
    } else {                                                              /* flat */
        double da = aa - 2.0 * pa, db = bb - 2.0 * pb; /* |p - a|^2 - |p - v|^2, same for b */
        w[da < 0.0 && da <= db ? 1 : db < 0.0 ? 2 : 0] = 1.0;
    }
    for (k = 0; k < 3; ++k) r[k] = ap[k] - w[1] * ea[k] - w[2] * eb[k];
    return sqffd__dot3(r, r);
}

/* The closest point to q on the fan of triangles around vertex v of the mesh
   whose vertices are x: its squared distance, triangle (tri[0] = v) and
   barycentric weights. */
static double sqffd__fit_fan_closest(const double *x, const int grid[2], size_t v, const double q[3], size_t tri[3],
                                     double w[3])
{
    sqffd__fit_ring r;
    double best = HUGE_VAL, ap[3], e[2][3], pe[2], ee[2], first[3], first_pe, first_ee, tw[3];
    size_t k, a0;
    sqffd__fit_ring_of(grid, v, &r);
    sqffd__sub3(q, x + 3 * v, ap);
    a0 = sqffd__fit_ring_at(&r, 0);
    sqffd__sub3(x + 3 * a0, x + 3 * v, first);
    first_pe = sqffd__dot3(first, ap);
    first_ee = sqffd__dot3(first, first);
    memcpy(e[0], first, sizeof first);
    pe[0] = first_pe; ee[0] = first_ee;
    for (k = 0; k < r.count; ++k) { /* triangle (v, ring k, ring k+1): e[k & 1] is ring k's edge */
        int c = (int)(k & 1), n = 1 - c;
        size_t b = sqffd__fit_ring_at(&r, k + 1 < r.count ? k + 1 : 0);
        double d;
        if (k + 1 < r.count) {
            sqffd__sub3(x + 3 * b, x + 3 * v, e[n]);
            pe[n] = sqffd__dot3(e[n], ap);
            ee[n] = sqffd__dot3(e[n], e[n]);
        } else {
            memcpy(e[n], first, sizeof first);
            pe[n] = first_pe; ee[n] = first_ee;
        }
        d = sqffd__fit_triangle(ap, e[c], e[n], pe[c], pe[n], ee[c], ee[n], sqffd__dot3(e[c], e[n]), tw);
        if (d < best) {
            best = d;
            tri[0] = v; tri[1] = sqffd__fit_ring_at(&r, k); tri[2] = b;
            memcpy(w, tw, sizeof tw);
        }
    }
    return best;
}

/* "The error" of one point q whose nearest mesh vertex is v: the closest
   point on the fan around v; while that lies on the fan's outer rim (v's
   weight 0), the fan around the rim vertex nearer to it is searched too (at
   most SQFFD__FIT_MAX_WALK moves, never getting farther). */
static double sqffd__fit_mesh_closest(const double *x, const int grid[2], size_t v, const double q[3], size_t tri[3],
                                      double w[3])
{
    double best = sqffd__fit_fan_closest(x, grid, v, q, tri, w);
    int step;
    for (step = 0; step < SQFFD__FIT_MAX_WALK && w[0] == 0.0; ++step) {
        size_t t2[3];
        double w2[3], d = sqffd__fit_fan_closest(x, grid, w[1] >= w[2] ? tri[1] : tri[2], q, t2, w2);
        if (!(d < best)) break;
        best = d;
        memcpy(tri, t2, sizeof t2);
        memcpy(w, w2, sizeof w2);
    }
    return best;
}

/* ---- statistics ---------------------------------------------------------- */

/* Diagonal of the points' bounding box; NON_FINITE for NaN/Inf. */
static sqffd_result sqffd__fit_diagonal(const double *points, size_t n, double *diagonal)
{
    double lo[3], hi[3], d2 = 0.0;
    size_t i;
    int a;
    for (a = 0; a < 3; ++a) { lo[a] = HUGE_VAL; hi[a] = -HUGE_VAL; }
    for (i = 0; i < n; ++i) {
        const double *p = points + 3 * i;
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

/* One pass over the data against the mesh with vertices x (tree built over
   x): each point's distance to the mesh (the error) into the statistics and
   per_point (may be NULL). With sums/weights (step 1 of the fit) each point's
   displacement to it from its closest mesh point is also spread over that
   triangle's vertices with the barycentric weights. */
static void sqffd__fit_pass(const double *points, size_t n, const double *x, const int grid[2], const sqffd_kdtree *tree,
                            double diagonal, double *per_point, double *sums, double *weights, sqffd_distance_stats *stats)
{
    double sum = 0.0, sum2 = 0.0, max = 0.0, w[3];
    size_t i, tri[3];
    int k;
    for (i = 0; i < n; ++i) {
        const double *q = points + 3 * i;
        size_t v = sqffd_kdtree_nearest(tree, q, NULL);
        double d2 = sqffd__fit_mesh_closest(x, grid, v, q, tri, w), d = sqrt(d2);
        sum += d; sum2 += d2;
        if (d > max) max = d;
        if (per_point) per_point[i] = d;
        if (sums) {
            double c[3], dq[3];
            const double *a = x + 3 * tri[0], *b = x + 3 * tri[1], *e = x + 3 * tri[2];
            for (k = 0; k < 3; ++k) {
                c[k] = w[0] * a[k] + w[1] * b[k] + w[2] * e[k];
                dq[k] = q[k] - c[k];
            }
            for (k = 0; k < 3; ++k) {
                double *s = sums + 3 * tri[k];
                s[0] += w[k] * dq[0]; s[1] += w[k] * dq[1]; s[2] += w[k] * dq[2];
                weights[tri[k]] += w[k];
            }
        }
    }
    sqffd__fit_stats(sum, sum2, max, n, diagonal, stats);
}

/* ---- model geometry ------------------------------------------------------ */

SQFFD_DEF void sqffd_model_point(const sqffd_model *model, double eta, double omega, double point[3])
{
    double p[3];
    sqffd_sq_point(&model->sq, eta, omega, p, NULL);
    sqffd_ffd_deform(&model->ffd, p, point);
}

/* The model's surface at every vertex of a grid. */
static void sqffd__fit_surface(const sqffd_model *model, const int grid[2], double *x)
{
    size_t v, count = sqffd__fit_grid_count(grid);
    for (v = 0; v < count; ++v) {
        double eta, omega;
        sqffd__fit_grid_angles(grid, v, &eta, &omega);
        sqffd_model_point(model, eta, omega, x + 3 * v);
    }
}

static int sqffd__fit_model_valid(const sqffd_model *model)
{
    return sqffd__ffd_dims_valid(model->ffd.dims) && sqffd__fit_grid_check(model->grid) == SQFFD_OK;
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
    size_t ne, rows, i, j, t = 0;
    sqffd_result r;
    if (!model || !sqffd__ffd_dims_valid(model->ffd.dims)) return SQFFD_ERROR_INVALID_ARGUMENT;
    grid[0] = n_eta; grid[1] = n_omega;
    r = sqffd__fit_grid_check(grid);
    if (r != SQFFD_OK) return r;
    if (vertices) sqffd__fit_surface(model, grid, vertices);
    if (!triangles) return SQFFD_OK;
    ne = (size_t)n_omega; rows = (size_t)n_eta * ne;
    for (j = 0; j < ne; ++j) { /* south cap: (S, (0, j+1), (0, j)) */
        triangles[t++] = (uint32_t)rows;
        triangles[t++] = (uint32_t)((j + 1) % ne);
        triangles[t++] = (uint32_t)j;
    }
    for (i = 0; i + 1 < (size_t)n_eta; ++i)
        for (j = 0; j < ne; ++j) {
            uint32_t a = (uint32_t)(i * ne + j), b = (uint32_t)(i * ne + (j + 1) % ne);
            uint32_t c = (uint32_t)((i + 1) * ne + (j + 1) % ne), d = (uint32_t)((i + 1) * ne + j);
            triangles[t++] = a; triangles[t++] = b; triangles[t++] = c;
            triangles[t++] = a; triangles[t++] = c; triangles[t++] = d;
        }
    for (j = 0; j < ne; ++j) { /* north cap: ((n-1, j), (n-1, j+1), N) */
        triangles[t++] = (uint32_t)(rows - ne + j);
        triangles[t++] = (uint32_t)(rows - ne + (j + 1) % ne);
        triangles[t++] = (uint32_t)(rows + 1);
    }
    return SQFFD_OK;
}

/* ---- distances ----------------------------------------------------------- */

static void sqffd__fit_distances_layout(sqffd__arena *a, size_t n_tree, size_t vertices, double **x, void **tree_ws, size_t *tree_size)
{
    *x = (double *)sqffd__arena_take(a, vertices, 3 * sizeof(double));
    *tree_size = sqffd_kdtree_workspace_size(n_tree);
    if (*tree_size == 0) a->overflow = 1;
    *tree_ws = sqffd__arena_take(a, *tree_size, 1);
}

static size_t sqffd__fit_distances_size(size_t n, const sqffd_model *model, int reverse)
{
    sqffd__arena a;
    double *x;
    void *tree_ws;
    size_t tree_size, m;
    if (!model || !sqffd__fit_model_valid(model) || n == 0) return 0;
    m = sqffd__fit_grid_count(model->grid);
    sqffd__arena_init(&a, NULL, 0);
    sqffd__fit_distances_layout(&a, reverse ? n : m, m, &x, &tree_ws, &tree_size);
    return sqffd__arena_required(&a);
}

SQFFD_DEF size_t sqffd_model_distances_workspace_size(size_t n, const sqffd_model *model)
{
    return sqffd__fit_distances_size(n, model, 0);
}

SQFFD_DEF size_t sqffd_model_reverse_distances_workspace_size(size_t n, const sqffd_model *model)
{
    return sqffd__fit_distances_size(n, model, 1);
}

/* Shared by both directions: validates, lays out, samples the model mesh and
   builds the tree over the mesh vertices (forward) or the data (reverse). */
static sqffd_result sqffd__fit_distances_setup(const sqffd_model *model, const double *points, size_t n, int reverse,
                                              void *workspace, size_t workspace_size, double **x, sqffd_kdtree *tree,
                                              double *diagonal)
{
    sqffd__arena a;
    void *tree_ws;
    size_t tree_size, m;
    sqffd_result r;
    if (!model || !points || !workspace || !sqffd__fit_model_valid(model)) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (n == 0) return SQFFD_ERROR_TOO_FEW_POINTS;
    r = sqffd__fit_diagonal(points, n, diagonal);
    if (r != SQFFD_OK) return r;
    m = sqffd__fit_grid_count(model->grid);
    sqffd__arena_init(&a, workspace, workspace_size);
    sqffd__fit_distances_layout(&a, reverse ? n : m, m, x, &tree_ws, &tree_size);
    if (a.overflow) return SQFFD_ERROR_WORKSPACE_TOO_SMALL;
    sqffd__fit_surface(model, model->grid, *x);
    return sqffd_kdtree_build(tree, reverse ? points : *x, reverse ? n : m, tree_ws, tree_size);
}

SQFFD_DEF sqffd_result sqffd_model_distances(const sqffd_model *model, const double *points, size_t n,
                                             double *per_point, sqffd_distance_stats *stats,
                                             void *workspace, size_t workspace_size)
{
    sqffd_kdtree tree;
    sqffd_distance_stats s;
    double *x = NULL, diagonal = 0.0;
    sqffd_result r = sqffd__fit_distances_setup(model, points, n, 0, workspace, workspace_size, &x, &tree, &diagonal);
    if (r != SQFFD_OK) return r;
    sqffd__fit_pass(points, n, x, model->grid, &tree, diagonal, per_point, NULL, NULL, &s);
    if (stats) *stats = s;
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_model_reverse_distances(const sqffd_model *model, const double *points, size_t n,
                                                     double *per_vertex, sqffd_distance_stats *stats,
                                                     void *workspace, size_t workspace_size)
{
    sqffd_kdtree tree;
    double *x = NULL, diagonal = 0.0, sum = 0.0, sum2 = 0.0, max = 0.0;
    size_t v, m;
    sqffd_result r = sqffd__fit_distances_setup(model, points, n, 1, workspace, workspace_size, &x, &tree, &diagonal);
    if (r != SQFFD_OK) return r;
    m = sqffd__fit_grid_count(model->grid);
    for (v = 0; v < m; ++v) {
        double d2, d;
        if (!sqffd__finite3(x + 3 * v)) return SQFFD_ERROR_NON_FINITE;
        sqffd_kdtree_nearest(&tree, x + 3 * v, &d2);
        d = sqrt(d2);
        sum += d; sum2 += d2;
        if (d > max) max = d;
        if (per_vertex) per_vertex[v] = d;
    }
    if (stats) sqffd__fit_stats(sum, sum2, max, m, diagonal, stats);
    return SQFFD_OK;
}

/* ---- options and the box ------------------------------------------------- */

SQFFD_DEF sqffd_fit_options sqffd_fit_options_default(void)
{
    sqffd_fit_options o;
    memset(&o, 0, sizeof o);
    o.sq = sqffd_sq_fit_options_default();
    o.lattice[0] = o.lattice[1] = o.lattice[2] = 5;
    o.box_margin = 0.1;
    o.grid[0] = 32;
    o.grid[1] = 64;
    o.alpha = 1e-5;
    o.regularization = SQFFD_REG_DISPLACEMENT;
    o.solver = SQFFD_SOLVER_CHOLESKY;
    o.max_iterations = 30;
    o.tolerance = 1e-4;
    o.symmetric = 0;
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
    if (!(o->alpha >= 0.0) || !isfinite(o->alpha)) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (!(o->tolerance >= 0.0) || !isfinite(o->tolerance)) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (o->max_iterations < 0) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (o->regularization != SQFFD_REG_DISPLACEMENT && o->regularization != SQFFD_REG_POSITION)
        return SQFFD_ERROR_INVALID_ARGUMENT;
    if (o->solver != SQFFD_SOLVER_CHOLESKY && o->solver != SQFFD_SOLVER_SVD) return SQFFD_ERROR_INVALID_ARGUMENT;
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_model_init(sqffd_model *model, const sqffd_superquadric *sq, const sqffd_fit_options *options)
{
    sqffd_superquadric shape;
    double half[3], origin[3], edges[9], m;
    int a, r;
    sqffd_result res;
    if (!model || !sq || !options || !sqffd__ffd_dims_valid(options->lattice)) return SQFFD_ERROR_INVALID_ARGUMENT;
    res = sqffd__fit_grid_check(options->grid);
    if (res != SQFFD_OK) return res;
    m = options->box_margin;
    if (!(m >= 0.0) || !isfinite(m)) return SQFFD_ERROR_INVALID_ARGUMENT;
    for (a = 0; a < 3; ++a)
        if (!(sq->size[a] > 0.0)) return isfinite(sq->size[a]) ? SQFFD_ERROR_INVALID_ARGUMENT : SQFFD_ERROR_NON_FINITE;
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

/* ---- the fixed part of the least-squares problem --------------------------
   B (model points x control points) never changes during a fit, nor between
   the frames of a sequence that keep the superquadric and the box, so the
   normal matrix B^T B + a D^T D is built and factored once. B's row at a
   model point is the tensor product of three 1-D Bernstein vectors; only
   those l + m + n numbers are stored per point. */
typedef struct sqffd__fit_system {
    int dims[3];
    int grid[2];
    size_t lattice;      /* L = l m n control points */
    size_t count;        /* M model points */
    size_t stride;       /* l + m + n */
    sqffd_solver solver;
    double *weights;     /* M x stride */
    double *matrix;      /* L x L: Cholesky factor, or V of the stacked system's SVD */
    double *inverse_s2;  /* SVD: 1 / s_k^2 for the kept singular values, 0 for the dropped */
    double *rhs0;        /* 3 x L: a D^T D P0 (displacement springs), zero for the paper's springs */
    double *stacked;     /* SVD, while preparing: [B; sqrt(a) D] */
    void *svd_ws;
    size_t svd_size;
} sqffd__fit_system;

/* The iteration's scratch: model-sized, plus the optional subsample and data tree. */
typedef struct sqffd__fit_work {
    double *x, *next;    /* M x 3: current and next model points */
    double *target;      /* M x 3: sums of data points, then displacements, then X^a */
    double *weights;     /* M: summed barycentric weights of the data points per model point */
    uint32_t *order;     /* M: breadth-first order of the fill */
    unsigned char *state;/* M */
    double *rhs;         /* 3 x L, then the new control points */
    double *scratch;     /* L */
    double *block;       /* SQFFD__FIT_BLOCK rows of B, row stride L + SQFFD__FIT_PAD */
    void *tree_ws;       /* tree over the model points */
    size_t tree_size;
    void *data_ws;       /* tree over the data (symmetric option) */
    size_t data_size;
    double *sample;      /* the FFD subsample (NULL: all points) */
    size_t sample_count;
} sqffd__fit_work;

/* At most cap of n points (cap 0: all of them). */
static size_t sqffd__fit_cap(size_t n, size_t cap)
{
    return cap && n > cap ? cap : n;
}

/* An even deterministic subsample of k of the n points: point i n / k,
   computed without overflow. */
static void sqffd__fit_subsample(const double *points, size_t n, size_t k, double *out)
{
    size_t i;
    for (i = 0; i < k; ++i) memcpy(out + 3 * i, points + 3 * (i * (n / k) + i * (n % k) / k), 3 * sizeof(double));
}

static size_t sqffd__fit_spring_count(const int d[3])
{
    return (size_t)((d[0] - 1) * d[1] * d[2] + d[0] * (d[1] - 1) * d[2] + d[0] * d[1] * (d[2] - 1));
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

static void sqffd__fit_layout(sqffd__arena *a, size_t n, const int dims[3], const int grid[2], const sqffd_fit_options *o,
                              sqffd__fit_system *s, sqffd__fit_work *w)
{
    size_t m = sqffd__fit_grid_count(grid), l = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2];
    memset(s, 0, sizeof *s);
    memset(w, 0, sizeof *w);
    s->dims[0] = dims[0]; s->dims[1] = dims[1]; s->dims[2] = dims[2];
    s->grid[0] = grid[0]; s->grid[1] = grid[1];
    s->lattice = l;
    s->count = m;
    s->stride = (size_t)(dims[0] + dims[1] + dims[2]);
    s->solver = o->solver;
    s->weights = (double *)sqffd__arena_take(a, m, s->stride * sizeof(double));
    s->matrix = (double *)sqffd__arena_take(a, l * l, sizeof(double));
    s->inverse_s2 = (double *)sqffd__arena_take(a, l, sizeof(double));
    s->rhs0 = (double *)sqffd__arena_take(a, 3 * l, sizeof(double));
    if (o->solver == SQFFD_SOLVER_SVD) {
        size_t rows = m + sqffd__fit_spring_count(dims);
        if (rows > 0x7fffffff) a->overflow = 1;
        else {
            s->stacked = (double *)sqffd__arena_take(a, rows, l * sizeof(double));
            s->svd_size = sqffd_svd_workspace_size((int)rows, (int)l);
            if (s->svd_size == 0) a->overflow = 1;
            s->svd_ws = sqffd__arena_take(a, s->svd_size, 1);
        }
    }
    w->x = (double *)sqffd__arena_take(a, m, 3 * sizeof(double));
    w->next = (double *)sqffd__arena_take(a, m, 3 * sizeof(double));
    w->target = (double *)sqffd__arena_take(a, m, 3 * sizeof(double));
    w->weights = (double *)sqffd__arena_take(a, m, sizeof(double));
    w->order = (uint32_t *)sqffd__arena_take(a, m, sizeof(uint32_t));
    w->state = (unsigned char *)sqffd__arena_take(a, m, 1);
    w->rhs = (double *)sqffd__arena_take(a, 3 * l, sizeof(double));
    w->scratch = (double *)sqffd__arena_take(a, l, sizeof(double));
    w->block = (double *)sqffd__arena_take(a, SQFFD__FIT_BLOCK, (l + SQFFD__FIT_PAD) * sizeof(double));
    w->tree_size = sqffd_kdtree_workspace_size(m);
    w->tree_ws = sqffd__arena_take(a, w->tree_size, 1);
    w->sample_count = sqffd__fit_cap(n, o->ffd_max_points);
    if (w->sample_count < n) w->sample = (double *)sqffd__arena_take(a, w->sample_count, 3 * sizeof(double));
    if (o->symmetric) {
        w->data_size = sqffd_kdtree_workspace_size(w->sample_count);
        if (w->data_size == 0) a->overflow = 1;
        w->data_ws = sqffd__arena_take(a, w->data_size, 1);
    }
}

/* row[0..count) += sum_k w[k] block[k][0..count) over the rows of a block of
   B (row stride ld): part of a row of B^T B (w = a column of the block) or of
   B^T X (w = a coordinate of the block's points). Eight columns at a time in
   registers, so the row is read and written once per block. */
static void sqffd__fit_rank_update(double *row, size_t count, const double *block, size_t rows, size_t ld, const double *w)
{
    size_t c = 0, k;
    for (; c + 8 <= count; c += 8) {
        double a[8];
        int j;
        for (j = 0; j < 8; ++j) a[j] = row[c + (size_t)j];
        for (k = 0; k < rows; ++k) {
            const double *b = block + k * ld + c;
            for (j = 0; j < 8; ++j) a[j] += w[k] * b[j];
        }
        for (j = 0; j < 8; ++j) row[c + (size_t)j] = a[j];
    }
    for (; c < count; ++c) {
        double a = row[c];
        for (k = 0; k < rows; ++k) a += w[k] * block[k * ld + c];
        row[c] = a;
    }
}

/* Rows v, v+1, ... of B (at most SQFFD__FIT_BLOCK, row stride L +
   SQFFD__FIT_PAD) into block; returns how many. */
static size_t sqffd__fit_block(const sqffd__fit_system *s, size_t v, double *block)
{
    size_t rows = s->count - v < SQFFD__FIT_BLOCK ? s->count - v : SQFFD__FIT_BLOCK, k;
    for (k = 0; k < rows; ++k)
        sqffd__ffd_expand(s->dims, s->weights + (v + k) * s->stride, block + k * (s->lattice + SQFFD__FIT_PAD));
    return rows;
}

/* B's rows, the regularisation's right-hand side and the factor, from the
   model's superquadric, box and grid. */
static sqffd_result sqffd__fit_prepare(const sqffd_model *model, const sqffd_fit_options *o, sqffd__fit_system *s,
                                       double *block)
{
    sqffd_ffd regular; /* P0 */
    double alpha, root;
    size_t l = s->lattice, m = s->count, ld = l + SQFFD__FIT_PAD, v, p, q, r, c, k;
    int axis;
    sqffd_result res = sqffd_ffd_init(&regular, model->ffd.dims, model->ffd.origin, model->ffd.edges);
    if (res != SQFFD_OK) return res;
    /* alpha weighs the mean spring energy per control point against the mean
       squared residual per model point, whatever the grid and the lattice */
    alpha = o->alpha * (double)m / (double)l;
    root = sqrt(alpha);
    for (v = 0; v < m; ++v) {
        double eta, omega, pt[3], stu[3];
        sqffd__fit_grid_angles(s->grid, v, &eta, &omega);
        sqffd_sq_point(&model->sq, eta, omega, pt, NULL);
        if (!sqffd__finite3(pt)) return SQFFD_ERROR_NON_FINITE;
        sqffd_ffd_local(&model->ffd, pt, stu);
        sqffd__ffd_axis_weights(s->dims, stu, s->weights + v * s->stride);
    }
    memset(s->rhs0, 0, 3 * l * sizeof(double));
    if (o->regularization == SQFFD_REG_DISPLACEMENT)
        for (p = 0; p < l; ++p)
            for (axis = 0; axis < 3; ++axis)
                if (sqffd__fit_spring(s->dims, p, axis, &q))
                    for (c = 0; c < 3; ++c) {
                        double d = alpha * (regular.control[p][c] - regular.control[q][c]);
                        s->rhs0[c * l + p] += d;
                        s->rhs0[c * l + q] -= d;
                    }
    if (s->solver == SQFFD_SOLVER_CHOLESKY) {
        memset(s->matrix, 0, l * l * sizeof(double));
        for (v = 0; v < m; v += SQFFD__FIT_BLOCK) { /* lower triangle of B^T B, a block of B's rows at a time */
            size_t rows = sqffd__fit_block(s, v, block);
            for (c = 0; c < l; c += SQFFD__FIT_TILE) /* column tiles of the block stay in the L1 cache */
                for (r = c; r < l; ++r) {
                    double w[SQFFD__FIT_BLOCK];
                    size_t end = r + 1 < c + SQFFD__FIT_TILE ? r + 1 : c + SQFFD__FIT_TILE;
                    for (k = 0; k < rows; ++k) w[k] = block[k * ld + r];
                    sqffd__fit_rank_update(s->matrix + r * l + c, end - c, block + c, rows, ld, w);
                }
        }
        for (p = 0; p < l; ++p) /* + alpha D^T D: the springs' graph Laplacian */
            for (axis = 0; axis < 3; ++axis)
                if (sqffd__fit_spring(s->dims, p, axis, &q)) {
                    s->matrix[p * l + p] += alpha;
                    s->matrix[q * l + q] += alpha;
                    s->matrix[q * l + p] -= alpha; /* q > p: lower triangle */
                }
        return sqffd_cholesky_factor(s->matrix, (int)l);
    }
    /* SVD of the stacked system K = [B; sqrt(a) D]; its pseudo-inverse
       solution K^+ b equals V diag(1 / s^2) V^T K^T b over the kept singular
       values, and K^T b is the same right-hand side as the normal equations',
       so U (model-sized) is never formed. */
    r = m;
    for (v = 0; v < m; ++v) sqffd__ffd_expand(s->dims, s->weights + v * s->stride, s->stacked + v * l);
    for (p = 0; p < l; ++p)
        for (axis = 0; axis < 3; ++axis)
            if (sqffd__fit_spring(s->dims, p, axis, &q)) {
                double *row = s->stacked + r++ * l;
                memset(row, 0, l * sizeof(double));
                row[p] = root;
                row[q] = -root;
            }
    res = sqffd_svd(s->stacked, (int)r, (int)l, NULL, s->inverse_s2, s->matrix, s->svd_ws, s->svd_size);
    if (res != SQFFD_OK) return res;
    for (c = l; c-- > 0;) {
        double sv = s->inverse_s2[c];
        s->inverse_s2[c] = sv > SQFFD__FIT_SVD_RCOND * s->inverse_s2[0] ? 1.0 / (sv * sv) : 0.0;
    }
    return SQFFD_OK;
}

/* ---- the two-step iteration ---------------------------------------------- */

/* Displacements of the model points no data point reached (weight 0),
   interpolated over the mesh: first in breadth-first order from the reached
   points (each takes the mean of its already known neighbours), then a few
   Gauss-Seidel sweeps of neighbour averaging (a discrete harmonic fill). */
static void sqffd__fit_fill(const int grid[2], size_t m, const double *weights, double *disp, uint32_t *order,
                            unsigned char *state)
{
    size_t head = 0, tail = 0, first, v, k, t;
    int sweep;
    sqffd__fit_ring r;
    for (v = 0; v < m; ++v) { /* 2 = known, 1 = queued, 0 = not yet seen */
        state[v] = weights[v] > 0.0 ? 2 : 0;
        if (state[v]) order[tail++] = (uint32_t)v;
    }
    first = tail;
    if (first == 0 || first == m) return;
    while (head < tail) {
        sqffd__fit_ring_of(grid, order[head++], &r);
        for (k = 0; k < r.count; ++k) {
            size_t w = sqffd__fit_ring_at(&r, k);
            if (state[w] == 0) { state[w] = 1; order[tail++] = (uint32_t)w; }
        }
    }
    for (sweep = 0; sweep <= SQFFD__FIT_FILL_SWEEPS; ++sweep)
        for (t = first; t < tail; ++t) {
            double sum[3] = {0.0, 0.0, 0.0};
            size_t used = 0;
            v = order[t];
            sqffd__fit_ring_of(grid, v, &r);
            for (k = 0; k < r.count; ++k) {
                size_t w = sqffd__fit_ring_at(&r, k);
                if (state[w] != 2) continue;
                sum[0] += disp[3 * w]; sum[1] += disp[3 * w + 1]; sum[2] += disp[3 * w + 2];
                used++;
            }
            disp[3 * v] = sum[0] / (double)used;
            disp[3 * v + 1] = sum[1] / (double)used;
            disp[3 * v + 2] = sum[2] / (double)used;
            state[v] = 2;
        }
}

/* rhs (3 x L) = B^T x + rhs0, a block of B's rows at a time. */
static void sqffd__fit_project(const sqffd__fit_system *s, const double *x, double *block, double *rhs)
{
    size_t l = s->lattice, v, k, c;
    memcpy(rhs, s->rhs0, 3 * l * sizeof(double));
    for (v = 0; v < s->count; v += SQFFD__FIT_BLOCK) {
        size_t rows = sqffd__fit_block(s, v, block);
        for (c = 0; c < 3; ++c) {
            double w[SQFFD__FIT_BLOCK];
            for (k = 0; k < rows; ++k) w[k] = x[3 * (v + k) + c];
            sqffd__fit_rank_update(rhs + c * l, l, block, rows, l + SQFFD__FIT_PAD, w);
        }
    }
}

/* rhs (3 x L) <- the normal equations' solution, coordinate by coordinate. */
static void sqffd__fit_solve(const sqffd__fit_system *s, double *rhs, double *scratch)
{
    size_t l = s->lattice, c, r, k;
    for (c = 0; c < 3; ++c) {
        double *b = rhs + c * l;
        if (s->solver == SQFFD_SOLVER_CHOLESKY) {
            sqffd_cholesky_solve(s->matrix, (int)l, b);
            continue;
        }
        for (k = 0; k < l; ++k) scratch[k] = 0.0; /* y = diag(1/s^2) V^T b */
        for (r = 0; r < l; ++r) {
            const double *vr = s->matrix + r * l;
            for (k = 0; k < l; ++k) scratch[k] += vr[k] * b[r];
        }
        for (k = 0; k < l; ++k) scratch[k] *= s->inverse_s2[k];
        for (r = 0; r < l; ++r) { /* b = V y */
            const double *vr = s->matrix + r * l;
            double sum = 0.0;
            for (k = 0; k < l; ++k) sum += vr[k] * scratch[k];
            b[r] = sum;
        }
    }
}

/* x = B P for every model point. */
static void sqffd__fit_evaluate(const sqffd__fit_system *s, const sqffd_ffd *ffd, double *x)
{
    size_t v;
    for (v = 0; v < s->count; ++v)
        sqffd__ffd_apply(s->dims, (const double (*)[3])ffd->control, s->weights + v * s->stride, x + 3 * v);
}

/* The paper's two-step loop from the model's current control points, with
   the system already prepared for its superquadric, box and grid (tracking
   reuses it frame after frame). Each round: one pass over the data (error of
   the current model, and step 1's sums), then step 1's displacement field,
   step 2's solve and the new model points. rep->sq_error receives the error
   of the starting model. */
static sqffd_result sqffd__fit_iterate(const double *points, size_t n, double diagonal, const sqffd_fit_options *o,
                                       const sqffd__fit_system *s, const sqffd_kdtree *data_tree, sqffd__fit_work *w,
                                       sqffd_model *model, sqffd_fit_report *rep)
{
    size_t m = s->count, l = s->lattice, v, p;
    double *x = w->x, *next = w->next, *t = w->target;
    int it;
    sqffd__fit_evaluate(s, &model->ffd, x);
    rep->iterations = 0;
    rep->converged = 0;
    rep->history_count = 0;
    for (it = 0;; ++it) {
        sqffd_kdtree tree;
        double step2 = 0.0;
        sqffd_result res = sqffd_kdtree_build(&tree, x, m, w->tree_ws, w->tree_size);
        if (res != SQFFD_OK) return res;
        memset(t, 0, 3 * m * sizeof(double));
        memset(w->weights, 0, m * sizeof(double));
        sqffd__fit_pass(points, n, x, s->grid, &tree, diagonal, NULL, t, w->weights, &rep->error);
        if (it == 0) rep->sq_error = rep->error;
        else {
            if (it <= SQFFD_FIT_HISTORY) rep->history[rep->history_count++] = rep->error.rms_relative;
            if (o->progress && o->progress(o->progress_user, SQFFD_STAGE_FFD, it, rep->error.rms_relative))
                return SQFFD_ERROR_CANCELLED;
        }
        if (it == o->max_iterations || rep->converged) break;
        /* step 1: X^a = X + each model point's weighted mean displacement (each data
           point pulls the three corners of its closest mesh triangle by their
           barycentric weights), interpolated where no data point pulled */
        for (v = 0; v < m; ++v)
            if (w->weights[v] > 0.0)
                for (p = 0; p < 3; ++p) t[3 * v + p] /= w->weights[v];
        sqffd__fit_fill(s->grid, m, w->weights, t, w->order, w->state);
        for (v = 0; v < 3 * m; ++v) t[v] += x[v];
        if (data_tree)  /* symmetric: halfway to the model point's closest data point */
            for (v = 0; v < m; ++v) {
                const double *q = points + 3 * sqffd_kdtree_nearest(data_tree, x + 3 * v, NULL);
                for (p = 0; p < 3; ++p) t[3 * v + p] = 0.5 * (t[3 * v + p] + q[p]);
            }
        /* step 2: P = argmin ||B P - X^a||^2 + alpha ||D (P - P0)||^2 (or ||D P||^2) */
        sqffd__fit_project(s, t, w->block, w->rhs);
        sqffd__fit_solve(s, w->rhs, w->scratch);
        for (p = 0; p < l; ++p) {
            model->ffd.control[p][0] = w->rhs[p];
            model->ffd.control[p][1] = w->rhs[l + p];
            model->ffd.control[p][2] = w->rhs[2 * l + p];
            if (!sqffd__finite3(model->ffd.control[p])) return SQFFD_ERROR_NON_FINITE;
        }
        sqffd__fit_evaluate(s, &model->ffd, next);
        for (v = 0; v < 3 * m; ++v) step2 += (next[v] - x[v]) * (next[v] - x[v]);
        t = x; x = next; next = t; t = w->target;
        rep->iterations = it + 1;
        rep->step = sqrt(step2 / (double)m) / diagonal;
        rep->converged = rep->step <= o->tolerance;
    }
    return SQFFD_OK;
}

/* ---- public entry points ------------------------------------------------- */

static void sqffd__fit_whole_layout(sqffd__arena *a, size_t n, const sqffd_fit_options *o, double **sample, void **sq_ws,
                                    size_t *sq_size, sqffd__fit_system *s, sqffd__fit_work *w)
{
    size_t k = sqffd__fit_cap(n, o->sq_max_points);
    *sample = k < n ? (double *)sqffd__arena_take(a, k, 3 * sizeof(double)) : NULL;
    *sq_size = sqffd_sq_fit_workspace_size(k, &o->sq);
    if (*sq_size == 0) a->overflow = 1;
    *sq_ws = sqffd__arena_take(a, *sq_size, 1);
    sqffd__fit_layout(a, n, o->lattice, o->grid, o, s, w);
}

SQFFD_DEF size_t sqffd_fit_workspace_size(size_t n, const sqffd_fit_options *options)
{
    sqffd__arena a;
    sqffd__fit_system s;
    sqffd__fit_work w;
    double *sample;
    void *sq_ws;
    size_t sq_size;
    if (!options || n == 0 || !sqffd__ffd_dims_valid(options->lattice) || sqffd__fit_grid_check(options->grid) != SQFFD_OK)
        return 0;
    sqffd__arena_init(&a, NULL, 0);
    sqffd__fit_whole_layout(&a, n, options, &sample, &sq_ws, &sq_size, &s, &w);
    return sqffd__arena_required(&a);
}

SQFFD_DEF size_t sqffd_fit_ffd_workspace_size(size_t n, const sqffd_model *model, const sqffd_fit_options *options)
{
    sqffd__arena a;
    sqffd__fit_system s;
    sqffd__fit_work w;
    if (!model || !options || n == 0 || !sqffd__fit_model_valid(model)) return 0;
    sqffd__arena_init(&a, NULL, 0);
    sqffd__fit_layout(&a, n, model->ffd.dims, model->grid, options, &s, &w);
    return sqffd__arena_required(&a);
}

/* The error of the model over all n points (the iterations may run on a
   subsample). */
static sqffd_result sqffd__fit_error(const double *points, size_t n, double diagonal, const sqffd__fit_system *s,
                                     const sqffd__fit_work *w, const sqffd_model *model, sqffd_distance_stats *stats)
{
    sqffd_kdtree tree;
    sqffd_result res;
    sqffd__fit_evaluate(s, &model->ffd, w->x);
    res = sqffd_kdtree_build(&tree, w->x, s->count, w->tree_ws, w->tree_size);
    if (res == SQFFD_OK) sqffd__fit_pass(points, n, w->x, s->grid, &tree, diagonal, NULL, NULL, NULL, stats);
    return res;
}

/* Stage 2 with the system prepared (tracking prepares once for frame 0's
   superquadric, box and grid, then runs this per frame from the previous
   frame's control points): take the subsample, build the data tree when
   symmetric, iterate; the start and final errors over all points. */
static sqffd_result sqffd__fit_run(const double *points, size_t n, double diagonal, const sqffd_fit_options *o,
                                   const sqffd__fit_system *s, sqffd__fit_work *w, sqffd_model *model,
                                   sqffd_fit_report *rep)
{
    sqffd_kdtree data_tree;
    sqffd_distance_stats start;
    const double *data = w->sample ? w->sample : points;
    sqffd_result res = SQFFD_OK;
    if (w->sample) {
        sqffd__fit_subsample(points, n, w->sample_count, w->sample);
        res = sqffd__fit_error(points, n, diagonal, s, w, model, &start);
    }
    if (res == SQFFD_OK && o->symmetric) res = sqffd_kdtree_build(&data_tree, data, w->sample_count, w->data_ws, w->data_size);
    if (res == SQFFD_OK)
        res = sqffd__fit_iterate(data, w->sample_count, diagonal, o, s, o->symmetric ? &data_tree : NULL, w, model, rep);
    if (res == SQFFD_OK && w->sample) {
        rep->sq_error = start;
        res = sqffd__fit_error(points, n, diagonal, s, w, model, &rep->error);
    }
    return res;
}

SQFFD_DEF sqffd_result sqffd_fit_ffd(const double *points, size_t n, const sqffd_fit_options *options, sqffd_model *model,
                                     sqffd_fit_report *report, void *workspace, size_t workspace_size)
{
    sqffd__arena a;
    sqffd__fit_system s;
    sqffd__fit_work w;
    sqffd_fit_report local;
    double diagonal;
    sqffd_result res;
    if (!points || !options || !model || !workspace || !sqffd__fit_model_valid(model)) return SQFFD_ERROR_INVALID_ARGUMENT;
    res = sqffd__fit_check_options(options);
    if (res != SQFFD_OK) return res;
    if (n < SQFFD__FIT_MIN_POINTS) return SQFFD_ERROR_TOO_FEW_POINTS;
    res = sqffd__fit_diagonal(points, n, &diagonal);
    if (res != SQFFD_OK) return res;
    if (!(diagonal > 0.0)) return SQFFD_ERROR_DEGENERATE;
    sqffd__arena_init(&a, workspace, workspace_size);
    sqffd__fit_layout(&a, n, model->ffd.dims, model->grid, options, &s, &w);
    if (a.overflow) return SQFFD_ERROR_WORKSPACE_TOO_SMALL;
    memset(&local, 0, sizeof local);
    res = sqffd__fit_prepare(model, options, &s, w.block);
    if (res == SQFFD_OK) res = sqffd__fit_run(points, n, diagonal, options, &s, &w, model, &local);
    if (report) *report = local;
    return res;
}

SQFFD_DEF sqffd_result sqffd_fit(const double *points, size_t n, const sqffd_fit_options *options,
                                 sqffd_model *model, sqffd_fit_report *report,
                                 void *workspace, size_t workspace_size)
{
    sqffd__arena a;
    sqffd__fit_system s;
    sqffd__fit_work w;
    sqffd_fit_report local;
    sqffd_sq_fit_options sq_options;
    sqffd_superquadric sq;
    double *sample, diagonal;
    void *sq_ws;
    size_t sq_size, k;
    sqffd_result res;
    if (!points || !options || !model || !workspace || !sqffd__ffd_dims_valid(options->lattice))
        return SQFFD_ERROR_INVALID_ARGUMENT;
    res = sqffd__fit_grid_check(options->grid);
    if (res == SQFFD_OK) res = sqffd__fit_check_options(options);
    if (res != SQFFD_OK) return res;
    if (!(options->box_margin >= 0.0) || !isfinite(options->box_margin)) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (n < SQFFD__FIT_MIN_POINTS) return SQFFD_ERROR_TOO_FEW_POINTS;
    res = sqffd__fit_diagonal(points, n, &diagonal);
    if (res != SQFFD_OK) return res;
    if (!(diagonal > 0.0)) return SQFFD_ERROR_DEGENERATE;
    sqffd__arena_init(&a, workspace, workspace_size);
    sqffd__fit_whole_layout(&a, n, options, &sample, &sq_ws, &sq_size, &s, &w);
    if (a.overflow) return SQFFD_ERROR_WORKSPACE_TOO_SMALL;
    memset(&local, 0, sizeof local);
    /* stage 1: the superquadric */
    k = sqffd__fit_cap(n, options->sq_max_points);
    if (sample) sqffd__fit_subsample(points, n, k, sample);
    sq_options = options->sq;
    if (!sq_options.progress) {
        sq_options.progress = options->progress;
        sq_options.progress_user = options->progress_user;
    }
    res = sqffd_sq_fit(sample ? sample : points, k, &sq_options, &sq, &local.sq, sq_ws, sq_size);
    if (res == SQFFD_OK) res = sqffd_model_init(model, &sq, options);
    /* stage 2: the FFD */
    if (res == SQFFD_OK) res = sqffd__fit_prepare(model, options, &s, w.block);
    if (res == SQFFD_OK) res = sqffd__fit_run(points, n, diagonal, options, &s, &w, model, &local);
    if (report) *report = local;
    return res;
}

/* ======================================================================
   Layer 5: model fit (superquadric + FFD, the paper's two-step algorithm)
   ====================================================================== */

#define SQFFD__FIT_PI 3.14159265358979323846
#define SQFFD__FIT_MAX_GRID 65536     /* per grid axis */
#define SQFFD__FIT_MIN_POINTS 4       /* sqffd_fit_ffd; sqffd_fit defers to the superquadric fit */
#define SQFFD__FIT_FILL_SWEEPS 8      /* smoothing sweeps over the unreached model points */
#define SQFFD__FIT_MAX_WALK 8         /* fan-to-fan moves of the closest-point search */
#define SQFFD__FIT_SVD_RCOND 1e-10    /* singular values below this fraction of the largest are dropped */
#define SQFFD__FIT_SNAP 1e-14         /* u this close to its run's first is that u (rounding: the runs' B rows factor) */

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
    i = (size_t)((uint32_t)v / (uint32_t)ne); /* the grid check keeps vertex numbers below 2^32: a faster division */
    j = v - i * ne; jp = j + 1 < ne ? j + 1 : 0; jm = j > 0 ? j - 1 : ne - 1;
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

/* Closest point to q on the triangle (v, v + ea, v + eb), from ap = q - v:
   its barycentric weights w (of v, a, b; w[0] is exactly 0 on the edge ab
   and its ends), by the Voronoi regions of the vertices, edges and face
   (Ericson, Real-Time Collision Detection, 5.1.5), and its squared distance.
   A flat triangle falls back on its nearest vertex, a zero-length edge on
   its end. */
static double sqffd__fit_triangle(const double ap[3], const double ea[3], const double eb[3], double w[3])
{
    double pa = sqffd__dot3(ea, ap), pb = sqffd__dot3(eb, ap);
    double aa = sqffd__dot3(ea, ea), bb = sqffd__dot3(eb, eb), ab = sqffd__dot3(ea, eb);
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
        double da = aa - 2.0 * pa, db = bb - 2.0 * pb; /* |q - a|^2 - |q - v|^2, same for b */
        w[da < 0.0 && da <= db ? 1 : db < 0.0 ? 2 : 0] = 1.0;
    }
    for (k = 0; k < 3; ++k) r[k] = ap[k] - w[1] * ea[k] - w[2] * eb[k];
    return sqffd__dot3(r, r);
}

/* The mesh triangle tri (corner tri[0] first, as in a fan around it) against
   q: the closest point's squared distance and barycentric weights. The fan
   search and the warm start's re-measurement of one triangle both come
   here, so they agree to the bit. */
static double sqffd__fit_corner_triangle(const double *x, const size_t tri[3], const double q[3], double w[3])
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
   barycentric weights (the first of equally close triangles), and the
   squared distance of the runner-up triangle (*second >= the result). */
static double sqffd__fit_fan_closest(const double *x, const int grid[2], size_t v, const double q[3], size_t tri[3],
                                     double w[3], double *second)
{
    sqffd__fit_ring r;
    double best = HUGE_VAL, tw[3];
    size_t k, t[3];
    sqffd__fit_ring_of(grid, v, &r);
    *second = HUGE_VAL;
    t[0] = v;
    for (k = 0; k < r.count; ++k) {
        double d;
        t[1] = sqffd__fit_ring_at(&r, k);
        t[2] = sqffd__fit_ring_at(&r, k + 1 < r.count ? k + 1 : 0);
        d = sqffd__fit_corner_triangle(x, t, q, tw);
        if (d < best) {
            *second = best;
            best = d;
            memcpy(tri, t, sizeof t);
            memcpy(w, tw, sizeof tw);
        } else if (d < *second) {
            *second = d;
        }
    }
    return best;
}

/* "The error" of q from the closest point (best, tri, w) on the fan of its
   nearest mesh vertex: while that lies on the fan's outer rim (v's weight
   0), the fan around the rim vertex nearer to it is searched too (at most
   SQFFD__FIT_MAX_WALK moves, never getting farther). */
static double sqffd__fit_walk(const double *x, const int grid[2], const double q[3], double best, size_t tri[3], double w[3])
{
    int step;
    for (step = 0; step < SQFFD__FIT_MAX_WALK && w[0] == 0.0; ++step) {
        size_t t2[3];
        double w2[3], second, d = sqffd__fit_fan_closest(x, grid, w[1] >= w[2] ? tri[1] : tri[2], q, t2, w2, &second);
        if (!(d < best)) break;
        best = d;
        memcpy(tri, t2, sizeof t2);
        memcpy(w, w2, sizeof w2);
    }
    return best;
}

/* ---- the closest-point search, with a warm start -------------------------
   A data point's answer (its nearest mesh vertex, and the closest triangle of
   that vertex's fan) rarely changes between two iterations, whose model
   points move little, and a distance to a vertex or to a triangle changes by
   at most the largest move of the vertices involved. So each point keeps
   three bounds, each less the moves summed since it was taken:
   - the gap between its nearest and runner-up vertex: while twice the moves
     stay below it, the nearest vertex is the same;
   - a lower bound on the distance to every vertex outside the anchor's
     closed ring (anchor: the nearest vertex at its last tree query): while
     the nearest vertex of that ring is nearer, it is the nearest of all;
   - the gap between the fan's closest and runner-up triangles (moves of the
     fan's own vertices): while twice those stay below it, only that triangle
     is measured again.
   Only when the first two fail is the tree asked; it is kept over a snapshot
   of the vertices and asked with their drift since as slack, and rebuilt when
   that leaves the answer open. Every way the answer is the one a fresh
   search gives (ties aside, which any search breaks arbitrarily). */
#define SQFFD__FIT_KNN 4 /* neighbours a tree query fetches (measured: fewer repeat queries vs dearer ones) */

typedef struct sqffd__fit_search {
    const double *x;         /* mesh vertices (the model points) */
    int grid[2];
    sqffd_kdtree tree;       /* over snapshot (NULL: x itself), once built */
    void *tree_ws;
    size_t tree_size;
    int built;
    double *snapshot;        /* x when the tree was built (the warm start keeps the tree while it can) */
    double drift;            /* the vertices' largest moves summed since */
    /* the warm start (anchor NULL: none), per data point */
    uint32_t *anchor;        /* the nearest vertex at the last tree query */
    double *outside;         /* lower bound on the distance to any vertex outside the anchor's closed ring */
    double *vertex_slack;    /* the gap between the nearest vertex and the runner-up less twice the largest moves since */
    uint32_t (*triangle)[3]; /* the closest triangle of the last fan search (its corner 0: the fan's vertex) */
    double *triangle_slack;  /* that fan's gap less twice its largest moves since (< 0: search the fan) */
    double moved;            /* largest vertex move since the previous pass */
    double *fan_moved;       /* per mesh vertex: largest move of its fan's vertices since the previous pass */
    double margin;           /* allowance for rounding in the distances */
} sqffd__fit_search;

/* Whether vertex u is in the closed ring (v and its ring r). */
static int sqffd__fit_in_ring(const sqffd__fit_ring *r, size_t v, size_t u)
{
    size_t k;
    if (u == v) return 1;
    if (r->pole) return u >= r->base && u < r->base + r->count;
    for (k = 0; k < r->count; ++k)
        if (r->v[k] == u) return 1;
    return 0;
}

/* The nearest mesh vertex to data point i at q. */
static sqffd_result sqffd__fit_nearest_vertex(sqffd__fit_search *s, size_t i, const double q[3], size_t *nearest)
{
    size_t near[SQFFD__FIT_KNN], k, count;
    double d2[SQFFD__FIT_KNN], d[SQFFD__FIT_KNN];
    sqffd__fit_ring r;
    if (s->anchor) {
        s->outside[i] -= s->moved;
        s->vertex_slack[i] -= 2.0 * s->moved;
        if (s->vertex_slack[i] > s->margin) { /* still the last pass's nearest vertex */
            *nearest = s->triangle[i][0];
            return SQFFD_OK;
        }
        if (s->outside[i] > s->margin) { /* the nearest of the anchor's closed ring, if nearer than the rest */
            size_t v = s->anchor[i];
            double best = sqffd__dist2_3(q, s->x + 3 * v), second = HUGE_VAL;
            sqffd__fit_ring_of(s->grid, v, &r);
            *nearest = v;
            for (k = 0; k < r.count; ++k) {
                size_t u = sqffd__fit_ring_at(&r, k);
                double du = sqffd__dist2_3(q, s->x + 3 * u);
                if (du < best) { second = best; best = du; *nearest = u; }
                else if (du < second) second = du;
            }
            best = sqrt(best);
            if (best < s->outside[i] - s->margin) {
                second = sqrt(second);
                s->vertex_slack[i] = (second < s->outside[i] ? second : s->outside[i]) - best;
                return SQFFD_OK;
            }
        }
    }
    for (;;) { /* a tree query, from a tree built over the vertices as they were `drift` ago */
        size_t b = 0;
        double rest, second = HUGE_VAL;
        if (!s->built) {
            size_t m = sqffd__fit_grid_count(s->grid);
            const double *at = s->snapshot ? (const double *)memcpy(s->snapshot, s->x, 3 * m * sizeof(double)) : s->x;
            sqffd_result res = sqffd_kdtree_build(&s->tree, at, m, s->tree_ws, s->tree_size);
            if (res != SQFFD_OK) return res;
            s->built = 1;
            s->drift = 0.0;
        }
        count = sqffd_kdtree_knn(&s->tree, q, s->anchor ? SQFFD__FIT_KNN : 1, near, d2);
        if (count == 0) return SQFFD_ERROR_NON_FINITE;
        rest = count == (s->anchor ? SQFFD__FIT_KNN : 1) ? sqrt(d2[count - 1]) - s->drift : HUGE_VAL; /* the vertices not returned */
        for (k = 0; k < count; ++k) { /* the returned ones as they are now */
            d[k] = sqrt(s->drift != 0.0 ? sqffd__dist2_3(q, s->x + 3 * near[k]) : d2[k]);
            if (d[k] < d[b]) { second = d[b]; b = k; }
            else if (k > 0 && d[k] < second) second = d[k];
        }
        if (s->drift != 0.0 && !(d[b] < rest - s->margin)) { /* too stale to tell: rebuild */
            s->built = 0;
            continue;
        }
        *nearest = near[b];
        if (s->anchor) {
            s->anchor[i] = (uint32_t)near[b];
            s->vertex_slack[i] = (second < rest ? second : rest) - d[b];
            s->outside[i] = rest;
            sqffd__fit_ring_of(s->grid, near[b], &r);
            for (k = 0; k < count; ++k)
                if (d[k] < s->outside[i] && !sqffd__fit_in_ring(&r, near[b], near[k])) s->outside[i] = d[k];
        }
        return SQFFD_OK;
    }
}

/* The closest point on the mesh to data point i at q ("the error"): squared
   distance, triangle and barycentric weights. */
static sqffd_result sqffd__fit_closest(sqffd__fit_search *s, size_t i, const double q[3], double *dist2, size_t tri[3],
                                       double w[3])
{
    size_t v, k;
    double second, d;
    sqffd_result res = sqffd__fit_nearest_vertex(s, i, q, &v);
    if (res != SQFFD_OK) return res;
    if (s->anchor && s->triangle[i][0] == v && s->triangle_slack[i] - 2.0 * s->fan_moved[v] > s->margin) {
        for (k = 0; k < 3; ++k) tri[k] = s->triangle[i][k];
        d = sqffd__fit_corner_triangle(s->x, tri, q, w);
        if (w[0] != 0.0) { /* (else the full search would walk on) */
            s->triangle_slack[i] -= 2.0 * s->fan_moved[v];
            *dist2 = d;
            return SQFFD_OK;
        }
    }
    d = sqffd__fit_fan_closest(s->x, s->grid, v, q, tri, w, &second);
    if (s->anchor) {
        for (k = 0; k < 3; ++k) s->triangle[i][k] = (uint32_t)tri[k];
        s->triangle_slack[i] = w[0] == 0.0 ? -1.0 : sqrt(second) - sqrt(d);
    }
    *dist2 = sqffd__fit_walk(s->x, s->grid, q, d, tri, w);
    return SQFFD_OK;
}

/* The moves from x to next into the search's warm start (largest overall and
   per fan); returns the sum of their squares. */
static double sqffd__fit_moves(sqffd__fit_search *s, const double *x, const double *next)
{
    size_t v, k, m = sqffd__fit_grid_count(s->grid);
    double sum2 = 0.0, max2 = 0.0;
    for (v = 0; v < m; ++v) {
        sqffd__fit_ring r;
        double move2 = sqffd__dist2_3(next + 3 * v, x + 3 * v), fan2 = move2;
        sum2 += move2;
        max2 = move2 > max2 ? move2 : max2;
        sqffd__fit_ring_of(s->grid, v, &r);
        for (k = 0; k < r.count; ++k) {
            size_t u = sqffd__fit_ring_at(&r, k);
            double d2 = sqffd__dist2_3(next + 3 * u, x + 3 * u);
            fan2 = d2 > fan2 ? d2 : fan2;
        }
        s->fan_moved[v] = sqrt(fan2);
    }
    s->moved = sqrt(max2);
    s->drift += s->moved;
    return sum2;
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

/* A search over the mesh with vertices x (tree workspace given, built on
   first need), without a warm start. */
static void sqffd__fit_search_init(sqffd__fit_search *s, const double *x, const int grid[2], void *tree_ws, size_t tree_size)
{
    memset(s, 0, sizeof *s);
    s->x = x;
    s->grid[0] = grid[0];
    s->grid[1] = grid[1];
    s->tree_ws = tree_ws;
    s->tree_size = tree_size;
}

/* One pass over the data against the search's mesh: each point's distance
   to the mesh (the error) into the statistics and per_point (may be NULL).
   With sums/weights (step 1 of the fit) each point's displacement to it from
   its closest mesh point is also spread over that triangle's vertices with
   the barycentric weights. */
static sqffd_result sqffd__fit_pass(const double *points, size_t n, sqffd__fit_search *search, double diagonal,
                                    double *per_point, double *sums, double *weights, sqffd_distance_stats *stats)
{
    const double *x = search->x;
    double sum = 0.0, sum2 = 0.0, max = 0.0, w[3];
    size_t i, tri[3];
    int k;
    for (i = 0; i < n; ++i) {
        const double *q = points + 3 * i;
        double d2, d;
        sqffd_result res = sqffd__fit_closest(search, i, q, &d2, tri, w);
        if (res != SQFFD_OK) return res;
        d = sqrt(d2);
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
    return SQFFD_OK;
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

/* Shared by both directions: validates, lays out and samples the model mesh;
   the tree's workspace is for the mesh vertices (forward) or the data
   (reverse). */
static sqffd_result sqffd__fit_distances_setup(const sqffd_model *model, const double *points, size_t n, int reverse,
                                              void *workspace, size_t workspace_size, double **x, void **tree_ws,
                                              size_t *tree_size, double *diagonal)
{
    sqffd__arena a;
    size_t m;
    sqffd_result r;
    if (!model || !points || !workspace || !sqffd__fit_model_valid(model)) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (n == 0) return SQFFD_ERROR_TOO_FEW_POINTS;
    r = sqffd__fit_diagonal(points, n, diagonal);
    if (r != SQFFD_OK) return r;
    m = sqffd__fit_grid_count(model->grid);
    sqffd__arena_init(&a, workspace, workspace_size);
    sqffd__fit_distances_layout(&a, reverse ? n : m, m, x, tree_ws, tree_size);
    if (a.overflow) return SQFFD_ERROR_WORKSPACE_TOO_SMALL;
    sqffd__fit_surface(model, model->grid, *x);
    return SQFFD_OK;
}

SQFFD_DEF sqffd_result sqffd_model_distances(const sqffd_model *model, const double *points, size_t n,
                                             double *per_point, sqffd_distance_stats *stats,
                                             void *workspace, size_t workspace_size)
{
    sqffd__fit_search search;
    sqffd_distance_stats s;
    double *x = NULL, diagonal = 0.0;
    void *tree_ws = NULL;
    size_t tree_size = 0;
    sqffd_result r = sqffd__fit_distances_setup(model, points, n, 0, workspace, workspace_size, &x, &tree_ws, &tree_size,
                                                &diagonal);
    if (r != SQFFD_OK) return r;
    sqffd__fit_search_init(&search, x, model->grid, tree_ws, tree_size);
    r = sqffd__fit_pass(points, n, &search, diagonal, per_point, NULL, NULL, &s);
    if (r == SQFFD_OK && stats) *stats = s;
    return r;
}

SQFFD_DEF sqffd_result sqffd_model_reverse_distances(const sqffd_model *model, const double *points, size_t n,
                                                     double *per_vertex, sqffd_distance_stats *stats,
                                                     void *workspace, size_t workspace_size)
{
    sqffd_kdtree tree;
    double *x = NULL, diagonal = 0.0, sum = 0.0, sum2 = 0.0, max = 0.0;
    void *tree_ws = NULL;
    size_t v, m, tree_size = 0;
    sqffd_result r = sqffd__fit_distances_setup(model, points, n, 1, workspace, workspace_size, &x, &tree_ws, &tree_size,
                                                &diagonal);
    if (r == SQFFD_OK) r = sqffd_kdtree_build(&tree, points, n, tree_ws, tree_size);
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
   model point is the tensor product a (x) b (x) c of three 1-D Bernstein
   vectors (in s, t, u); only those l + m + n numbers are stored per point.

   Runs: the model points of one grid row share eta, and when the box is
   aligned with the superquadric's axes (as sqffd_model_init makes it) their
   u, which then depends on eta alone, agrees to rounding; prepare makes it
   agree exactly (SQFFD__FIT_SNAP), so over a run of consecutive points with
   the same c, B's products factor:
     (B P)_v   = sum_ij a_i b_j (sum_k c_k P_ijk), the inner sums once per run;
     B^T y     = sum over runs of (sum_v (a (x) b) y_v) (x) c;
     B^T B     = sum over runs of (sum_v (a (x) b)(a (x) b)^T) (x) c c^T.
   That cuts the first two's cost about n-fold and B^T B's about n^2-fold. For
   another box the runs are single points and the same code does the plain
   products. */
typedef struct sqffd__fit_system {
    int dims[3];
    int grid[2];
    size_t lattice;      /* L = l m n control points */
    size_t count;        /* M model points */
    size_t stride;       /* l + m + n */
    sqffd_solver solver;
    double *weights;     /* M x stride */
    uint32_t *run;       /* runs + 1: the first point of each run, then M */
    size_t runs;
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
    double *pairs;       /* (l m)^2: a run's sum of (a (x) b)(a (x) b)^T while preparing */
    void *tree_ws;       /* tree over the model points */
    size_t tree_size;
    double *snapshot;    /* M x 3: the model points the tree was built over */
    uint32_t *anchor, (*triangle)[3]; /* per FFD data point: the closest-point search's warm start */
    double *outside, *vertex_slack, *triangle_slack;
    double *fan_moved;   /* M */
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
    s->run = (uint32_t *)sqffd__arena_take(a, m + 1, sizeof(uint32_t));
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
    w->pairs = (double *)sqffd__arena_take(a, (size_t)(dims[0] * dims[1] * dims[0] * dims[1]), sizeof(double));
    w->tree_size = sqffd_kdtree_workspace_size(m);
    w->tree_ws = sqffd__arena_take(a, w->tree_size, 1);
    w->sample_count = sqffd__fit_cap(n, o->ffd_max_points);
    if (w->sample_count < n) w->sample = (double *)sqffd__arena_take(a, w->sample_count, 3 * sizeof(double));
    w->snapshot = (double *)sqffd__arena_take(a, m, 3 * sizeof(double));
    w->anchor = (uint32_t *)sqffd__arena_take(a, w->sample_count, sizeof(uint32_t));
    w->outside = (double *)sqffd__arena_take(a, w->sample_count, sizeof(double));
    w->vertex_slack = (double *)sqffd__arena_take(a, w->sample_count, sizeof(double));
    w->triangle = (uint32_t (*)[3])sqffd__arena_take(a, w->sample_count, 3 * sizeof(uint32_t));
    w->triangle_slack = (double *)sqffd__arena_take(a, w->sample_count, sizeof(double));
    w->fan_moved = (double *)sqffd__arena_take(a, m, sizeof(double));
    if (o->symmetric) {
        w->data_size = sqffd_kdtree_workspace_size(w->sample_count);
        if (w->data_size == 0) a->overflow = 1;
        w->data_ws = sqffd__arena_take(a, w->data_size, 1);
    }
}

/* The lower triangle of B^T B into matrix (L x L, zeroed), run by run. */
static void sqffd__fit_gram(const sqffd__fit_system *s, double *pairs, double *matrix)
{
    const int *d = s->dims;
    size_t l = s->lattice, lm = (size_t)(d[0] * d[1]), n = (size_t)d[2], r, v, e, f, k, h;
    for (r = 0; r < s->runs; ++r) {
        const double *c = s->weights + (size_t)s->run[r] * s->stride + d[0] + d[1];
        memset(pairs, 0, lm * lm * sizeof(double));
        for (v = s->run[r]; v < s->run[r + 1]; ++v) { /* pairs += (a (x) b)(a (x) b)^T, lower triangle */
            const double *a = s->weights + v * s->stride, *b = a + d[0];
            double ab[SQFFD_MAX_LATTICE * SQFFD_MAX_LATTICE];
            for (e = 0; e < lm; ++e) ab[e] = a[e / (size_t)d[1]] * b[e % (size_t)d[1]];
            for (e = 0; e < lm; ++e)
                for (f = 0; f <= e; ++f) pairs[e * lm + f] += ab[e] * ab[f];
        }
        for (e = 0; e < lm; ++e) /* matrix += pairs (x) c c^T: rows e n + k, columns f n + h, f <= e */
            for (f = 0; f <= e; ++f)
                for (k = 0; k < n; ++k) {
                    double *row = matrix + (e * n + k) * l + f * n, pk = pairs[e * lm + f] * c[k];
                    size_t end = f < e ? n : k + 1;
                    for (h = 0; h < end; ++h) row[h] += pk * c[h];
                }
    }
}

/* B's rows, the regularisation's right-hand side and the factor, from the
   model's superquadric, box and grid. */
static sqffd_result sqffd__fit_prepare(const sqffd_model *model, const sqffd_fit_options *o, sqffd__fit_system *s,
                                       double *pairs)
{
    sqffd_ffd regular; /* P0 */
    double alpha, root, run_u = 0.0;
    size_t l = s->lattice, m = s->count, v, p, q, r, c;
    int axis;
    sqffd_result res = sqffd_ffd_init(&regular, model->ffd.dims, model->ffd.origin, model->ffd.edges);
    if (res != SQFFD_OK) return res;
    /* alpha weighs the mean spring energy per control point against the mean
       squared residual per model point, whatever the grid and the lattice */
    alpha = o->alpha * (double)m / (double)l;
    root = sqrt(alpha);
    s->runs = 0;
    for (v = 0; v < m; ++v) {
        double eta, omega, pt[3], stu[3];
        sqffd__fit_grid_angles(s->grid, v, &eta, &omega);
        sqffd_sq_point(&model->sq, eta, omega, pt, NULL);
        if (!sqffd__finite3(pt)) return SQFFD_ERROR_NON_FINITE;
        sqffd_ffd_local(&model->ffd, pt, stu);
        if (v > 0 && fabs(stu[2] - run_u) <= SQFFD__FIT_SNAP) stu[2] = run_u;
        else { s->run[s->runs++] = (uint32_t)v; run_u = stu[2]; }
        sqffd__ffd_axis_weights(s->dims, stu, s->weights + v * s->stride);
    }
    s->run[s->runs] = (uint32_t)m;
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
        sqffd__fit_gram(s, pairs, s->matrix);
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
            double sum[3] = {0.0, 0.0, 0.0}, inverse;
            size_t used = 0;
            v = order[t];
            sqffd__fit_ring_of(grid, v, &r);
            for (k = 0; k < r.count; ++k) {
                size_t w = sqffd__fit_ring_at(&r, k);
                if (state[w] != 2) continue;
                sum[0] += disp[3 * w]; sum[1] += disp[3 * w + 1]; sum[2] += disp[3 * w + 2];
                used++;
            }
            inverse = 1.0 / (double)used;
            disp[3 * v] = sum[0] * inverse;
            disp[3 * v + 1] = sum[1] * inverse;
            disp[3 * v + 2] = sum[2] * inverse;
            state[v] = 2;
        }
}

/* rhs (3 x L) = B^T y + rhs0, run by run. */
static void sqffd__fit_project(const sqffd__fit_system *s, const double *y, double *rhs)
{
    const int *d = s->dims;
    size_t l = s->lattice, lm = (size_t)(d[0] * d[1]), n = (size_t)d[2], r, v, e, k, i, j;
    memcpy(rhs, s->rhs0, 3 * l * sizeof(double));
    for (r = 0; r < s->runs; ++r) {
        const double *c = s->weights + (size_t)s->run[r] * s->stride + d[0] + d[1];
        double sum[SQFFD_MAX_LATTICE * SQFFD_MAX_LATTICE][3];
        memset(sum, 0, sizeof sum);
        for (v = s->run[r]; v < s->run[r + 1]; ++v) { /* sum += (a (x) b) y_v */
            const double *a = s->weights + v * s->stride, *b = a + d[0], *yv = y + 3 * v;
            for (i = 0; i < (size_t)d[0]; ++i) {
                double ay[3];
                ay[0] = a[i] * yv[0]; ay[1] = a[i] * yv[1]; ay[2] = a[i] * yv[2];
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

/* x = B P for every model point, run by run. */
static void sqffd__fit_evaluate(const sqffd__fit_system *s, const sqffd_ffd *ffd, double *x)
{
    double q[SQFFD_MAX_LATTICE * SQFFD_MAX_LATTICE][3];
    size_t r, v;
    for (r = 0; r < s->runs; ++r) {
        const double *c = s->weights + (size_t)s->run[r] * s->stride + s->dims[0] + s->dims[1];
        sqffd__ffd_sum_u(s->dims, (const double (*)[3])ffd->control, c, q);
        for (v = s->run[r]; v < s->run[r + 1]; ++v) {
            const double *a = s->weights + v * s->stride;
            sqffd__ffd_sum_st(s->dims, (const double (*)[3])q, a, a + s->dims[0], x + 3 * v);
        }
    }
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
    size_t m = s->count, l = s->lattice, v, p, i;
    double *x = w->x, *next = w->next, *t = w->target, magnitude = 0.0;
    sqffd__fit_search search;
    int it;
    sqffd__fit_evaluate(s, &model->ffd, x);
    sqffd__fit_search_init(&search, x, s->grid, w->tree_ws, w->tree_size);
    search.triangle = w->triangle;
    search.snapshot = w->snapshot;
    search.anchor = w->anchor;
    search.outside = w->outside;
    search.vertex_slack = w->vertex_slack;
    search.triangle_slack = w->triangle_slack;
    search.fan_moved = w->fan_moved;
    for (i = 0; i < n; ++i) { /* no warm start yet */
        w->anchor[i] = 0;
        w->outside[i] = w->vertex_slack[i] = -HUGE_VAL;
        w->triangle[i][0] = UINT32_MAX;
        for (p = 0; p < 3; ++p) magnitude = fabs(points[3 * i + p]) > magnitude ? fabs(points[3 * i + p]) : magnitude;
    }
    search.margin = 1e-10 * (magnitude + diagonal); /* far above the rounding of distances between such points */
    rep->iterations = 0;
    rep->converged = 0;
    rep->history_count = 0;
    for (it = 0;; ++it) {
        double step2;
        sqffd_result res;
        memset(t, 0, 3 * m * sizeof(double));
        memset(w->weights, 0, m * sizeof(double));
        search.x = x;
        res = sqffd__fit_pass(points, n, &search, diagonal, NULL, t, w->weights, &rep->error);
        if (res != SQFFD_OK) return res;
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
        sqffd__fit_project(s, t, w->rhs);
        sqffd__fit_solve(s, w->rhs, w->scratch);
        for (p = 0; p < l; ++p) {
            model->ffd.control[p][0] = w->rhs[p];
            model->ffd.control[p][1] = w->rhs[l + p];
            model->ffd.control[p][2] = w->rhs[2 * l + p];
            if (!sqffd__finite3(model->ffd.control[p])) return SQFFD_ERROR_NON_FINITE;
        }
        sqffd__fit_evaluate(s, &model->ffd, next);
        step2 = sqffd__fit_moves(&search, x, next);
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
    sqffd__fit_search search;
    sqffd__fit_evaluate(s, &model->ffd, w->x);
    sqffd__fit_search_init(&search, w->x, s->grid, w->tree_ws, w->tree_size);
    return sqffd__fit_pass(points, n, &search, diagonal, NULL, NULL, NULL, stats);
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
    res = sqffd__fit_prepare(model, options, &s, w.pairs);
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
    if (res == SQFFD_OK) res = sqffd__fit_prepare(model, options, &s, w.pairs);
    if (res == SQFFD_OK) res = sqffd__fit_run(points, n, diagonal, options, &s, &w, model, &local);
    if (report) *report = local;
    return res;
}

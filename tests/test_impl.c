/* Invariants of internal parts that the public functions cannot reach one
   by one (white-box). The internals are static, so this file holds its own
   private copy of the implementation (SQFFD_STATIC); the test binary's
   shared one is the core object (tests/check_header.c), which every other
   test file reaches through the header alone, so linkage is exercised. */
#define SQFFD_STATIC
#define SQFFD_IMPLEMENTATION
#if defined(__GNUC__)
#pragma GCC diagnostic ignored "-Wunused-function"
#endif
#include "test.h"
#include <stdlib.h>

/* The exact passes' tree over the mesh triangles: every cell is the child
   of exactly one bottom node, children come after their parent, each child
   box holds its cell's or node's vertices and unused slots are empty; and
   the walk from a poor first answer (the mesh's first triangle) finds the
   brute-force closest distance over all triangles (random jittered meshes,
   points in and around them). Grids from the smallest to 65,536 rows or
   columns (the deepest trees the grid limits allow along one side; the
   build asserts its stack bound). */
static void test_internal_triangle_tree(void)
{
    static const int grids[][2] = {{2, 3}, {3, 4}, {5, 6}, {9, 17}, {32, 64}, {33, 65}, {100, 7}, {2, 65536}, {65536, 3}};
    size_t g;
    srand(7);
    for (g = 0; g < sizeof grids / sizeof grids[0]; g++) {
        size_t m = sqffd__fit_grid_count(grids[g]), v, i, cells = ((size_t)grids[g][0] + 1) * (size_t)grids[g][1];
        double *x = (double *)malloc(3 * m * sizeof *x);
        unsigned char *seen = (unsigned char *)calloc(cells, 1);
        sqffd__fit_bvh h;
        sqffd__fit_search s;
        uint32_t k, j;
        int c, trial, bad_cells = 0, bad_boxes = 0;
        h.count = sqffd__fit_bvh_build(grids[g], NULL);
        h.nodes = (sqffd__fit_bvh_node *)malloc(h.count * sizeof *h.nodes);
        CHECK(sqffd__fit_bvh_build(grids[g], h.nodes) == h.count);
        for (v = 0; v < m; v++) { /* a sphere on the grid, its points jittered */
            size_t cells_in_rows = (size_t)grids[g][0] * (size_t)grids[g][1];
            double eta = v < cells_in_rows ? -1.5 + 3.0 * (double)(v / (size_t)grids[g][1] + 1) / (grids[g][0] + 1)
                                           : v == cells_in_rows ? -1.5707963267948966 : 1.5707963267948966;
            double omega = v < cells_in_rows ? 6.283185307179586 * (double)(v % (size_t)grids[g][1]) / grids[g][1] : 0.0;
            x[3 * v] = cos(eta) * cos(omega) + 0.2 * (double)rand() / RAND_MAX;
            x[3 * v + 1] = cos(eta) * sin(omega) + 0.2 * (double)rand() / RAND_MAX;
            x[3 * v + 2] = sin(eta) + 0.2 * (double)rand() / RAND_MAX;
        }
        sqffd__fit_bvh_boxes(&h, grids[g], x);
        for (i = 0; i < h.count; i++) {
            const sqffd__fit_bvh_node *node = h.nodes + i;
            CHECK(node->count >= 1 && node->count <= SQFFD__FIT_BVH_WIDTH);
            for (k = 0; k < SQFFD__FIT_BVH_WIDTH; k++) {
                double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
                if (k < node->count && node->bottom) {
                    uint32_t tri[2][3], col = node->child[k] % (uint32_t)grids[g][1];
                    int t, n, count = sqffd__fit_cell(grids[g], node->child[k] / (uint32_t)grids[g][1], col, tri);
                    bad_cells += node->child[k] >= cells || seen[node->child[k]]++;
                    for (t = 0; t < count; t++)
                        for (n = 0; n < 3; n++)
                            for (c = 0; c < 3; c++) {
                                double p = x[3 * tri[t][n] + (size_t)c];
                                lo[c] = p < lo[c] ? p : lo[c];
                                hi[c] = p > hi[c] ? p : hi[c];
                            }
                } else if (k < node->count) {
                    const sqffd__fit_bvh_node *child = h.nodes + node->child[k];
                    CHECK(node->child[k] > i && node->child[k] < h.count);
                    for (c = 0; c < 3; c++)
                        for (j = 0; j < child->count; j++) {
                            lo[c] = child->low[c][j] < lo[c] ? child->low[c][j] : lo[c];
                            hi[c] = child->high[c][j] > hi[c] ? child->high[c][j] : hi[c];
                        }
                }
                for (c = 0; c < 3; c++) bad_boxes += node->low[c][k] != lo[c] || node->high[c][k] != hi[c];
            }
        }
        for (i = 0; i < cells; i++) bad_cells += seen[i] != 1;
        CHECK_MSG(bad_cells == 0, "grid %d x %d: %d cells not in exactly one bottom node", grids[g][0], grids[g][1],
                  bad_cells);
        CHECK_MSG(bad_boxes == 0, "grid %d x %d: %d box sides not those of the children", grids[g][0], grids[g][1],
                  bad_boxes);
        memset(&s, 0, sizeof s);
        s.x = x;
        s.count = m;
        s.bvh = &h;
        s.bvh_current = 1;
        s.grid[0] = grids[g][0];
        s.grid[1] = grids[g][1];
        for (trial = 0; trial < (m > 5000 ? 3 : 40); trial++) {
            uint32_t cell[2][3], r, col;
            size_t tri[3], t3[3];
            double q[3], w[3], tw[3], best2, brute = HUGE_VAL;
            for (c = 0; c < 3; c++) q[c] = 3.0 * (double)rand() / RAND_MAX - 1.5;
            sqffd__fit_cell(grids[g], 0, 0, cell);
            tri[0] = cell[0][0]; tri[1] = cell[0][1]; tri[2] = cell[0][2];
            best2 = sqffd__fit_corner_triangle(x, tri, q, w);
            sqffd__fit_certify(&s, q, &best2, tri, w);
            for (r = 0; r <= (uint32_t)grids[g][0]; r++)
                for (col = 0; col < (uint32_t)grids[g][1]; col++) {
                    int t, count = sqffd__fit_cell(grids[g], r, col, cell);
                    for (t = 0; t < count; t++) {
                        double d;
                        t3[0] = cell[t][0]; t3[1] = cell[t][1]; t3[2] = cell[t][2];
                        d = sqffd__fit_corner_triangle(x, t3, q, tw);
                        brute = d < brute ? d : brute;
                    }
                }
            CHECK_MSG(best2 == brute, "grid %d x %d: the walk's %.17g, brute force %.17g", grids[g][0], grids[g][1],
                      best2, brute);
            CHECK(sqffd__fit_corner_triangle(x, tri, q, tw) == best2);
        }
        free(h.nodes);
        free(seen);
        free(x);
    }
}

/* e^T A e for A = springs + B^T (W + tether) B, e in sqffd_ffd's layout:
   the step's quadratic's excess over its minimum is half this of X - G. */
static double lagged_a_norm2(const sqffd__fit_system *s, const double *weights, const double *e, double *bx,
                             double (*block)[4], double *by_coord, double *springs)
{
    size_t l = s->lattice, v, p, i;
    double sum = 0.0;
    sqffd__fit_evaluate(s, (const double (*)[3])e, block, bx);
    for (v = 0; v < s->count; v++)
        for (i = 0; i < 3; i++) sum += (weights[v] + s->tether) * bx[3 * v + i] * bx[3 * v + i];
    for (p = 0; p < l; p++)
        for (i = 0; i < 3; i++) by_coord[i * l + p] = e[3 * p + i];
    sqffd__fit_springs_times(s, by_coord, springs);
    for (p = 0; p < 3 * l; p++) sum += by_coord[p] * springs[p];
    return sum;
}

/* A step's inputs: W_v into the work's weights, W_v y_v into target. */
static void lagged_load(size_t m, const double *weights, const double *y, double *work_weights, double *target)
{
    size_t v, c;
    memcpy(work_weights, weights, m * sizeof(double));
    for (v = 0; v < m; v++)
        for (c = 0; c < 3; c++) target[3 * v + c] = weights[v] * y[3 * v + c];
}

/* The Cholesky factor and the forward solves work in tiles (two rows
   against four columns or right-hand sides) and the factor in blocks of
   SQFFD__LA_BLOCK rows, yet promise the plain row by row algorithm's
   results to the bit, each dot summed in sqffd__la_dot's order: checked
   against that algorithm written out here, for sizes of every remainder
   mod 4 (odd and even: a last row alone) and of several blocks with a part
   one last, row-major and packed, and 1-9 right-hand sides; and a matrix
   that is not positive definite only at its last pivot (on either row of
   a pair) is refused. */
static void test_internal_cholesky_tiles(void)
{
    static const size_t sizes[] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 17, 37, 64, 83, 150};
    size_t t;
    srand(11);
    for (t = 0; t < sizeof sizes / sizeof sizes[0]; t++) {
        size_t n = sizes[t], i, j, k, c;
        double *a = (double *)malloc(n * n * sizeof *a), *l = (double *)malloc(n * n * sizeof *l);
        double *p = (double *)malloc(n * (n + 1) / 2 * sizeof *p), *b = (double *)malloc(9 * n * sizeof *b);
        double *y = (double *)malloc(9 * n * sizeof *y);
        int packed;
        for (i = 0; i < n * n; i++) l[i] = 2.0 * (double)rand() / RAND_MAX - 1.0;
        for (i = 0; i < n; i++) /* A = M M^T + n I, M (in l meanwhile) uniform in [-1, 1] */
            for (j = 0; j <= i; j++) {
                double sum = i == j ? (double)n : 0.0;
                for (k = 0; k < n; k++) sum += l[i * n + k] * l[j * n + k];
                a[i * n + j] = a[j * n + i] = sum;
            }
        memcpy(l, a, n * n * sizeof *l); /* the reference: row by row, one dot an entry */
        for (i = 0; i < n; i++)
            for (j = 0; j <= i; j++) {
                double sum = l[i * n + j] - sqffd__la_dot(l + i * n, l + j * n, j);
                l[i * n + j] = j < i ? sum / l[j * n + j] : sqrt(sum);
            }
        for (packed = 0; packed <= 1; packed++) {
            double *m = packed ? p : (double *)malloc(n * n * sizeof *m);
            for (i = 0; i < n; i++)
                for (j = 0; j <= i; j++) sqffd__la_row(m, n, packed, i)[j] = a[i * n + j];
            CHECK_RESULT(sqffd__la_cholesky(m, n, packed), SQFFD_OK);
            for (i = 0; i < n; i++)
                for (j = 0; j <= i; j++) CHECK(sqffd__la_row(m, n, packed, i)[j] == l[i * n + j]);
            for (k = 1; k <= 9; k++) { /* k right-hand sides against the reference's forward solve */
                for (i = 0; i < k * n; i++) b[i] = y[i] = 2.0 * (double)rand() / RAND_MAX - 1.0;
                sqffd__la_forward(m, n, packed, b, k);
                for (c = 0; c < k; c++)
                    for (i = 0; i < n; i++) {
                        double *yc = y + c * n;
                        yc[i] = (yc[i] - sqffd__la_dot(l + i * n, yc, i)) / l[i * n + i];
                    }
                for (i = 0; i < k * n; i++) CHECK(b[i] == y[i]);
            }
            for (i = 0; i < n; i++) /* the last pivot made -1: refused */
                for (j = 0; j <= i; j++) sqffd__la_row(m, n, packed, i)[j] = a[i * n + j];
            sqffd__la_row(m, n, packed, n - 1)[n - 1] -= l[(n - 1) * n + n - 1] * l[(n - 1) * n + n - 1] + 1.0;
            CHECK_RESULT(sqffd__la_cholesky(m, n, packed), SQFFD_ERROR_NOT_POSITIVE_DEFINITE);
            if (!packed) free(m);
        }
        free(a); free(l); free(p); free(b); free(y);
    }
}

/* The step's lagged factor (sqffd__fit_step): with the factor of one set of
   weights, the conjugate-gradient steps on a system whose weights changed
   by up to +-40% (and a tether, so the fixed part is dense) land near the
   direct solve's G: within 5% of |P - G| in A's norm (the quadratic's
   excess over its minimum), and B (X - P) is the move they report. */
static void test_internal_lagged_step(void)
{
    static const int dims[3] = {5, 5, 5}, grid[2] = {16, 32};
    sqffd_fit_options o = sqffd_fit_options_default();
    sqffd_superquadric sq;
    sqffd_model model;
    sqffd__fit_system s;
    sqffd__fit_work w;
    sqffd__arena a;
    size_t size, m, l, v, p, trial;
    int direct;
    void *memory;
    sqffd__fit_fold fold;
    double *start, *exact, *weights, *changed, *targets, *bx, *by_coord, *springs, *target;
    memset(&sq, 0, sizeof sq);
    sq.size[0] = 1.0; sq.size[1] = 0.7; sq.size[2] = 1.5;
    sq.shape[0] = 0.8; sq.shape[1] = 1.2;
    sq.taper[0] = 0.2;
    sq.rotation[0] = sq.rotation[4] = sq.rotation[8] = 1.0;
    o.grid[0] = grid[0];
    o.grid[1] = grid[1];
    CHECK_RESULT(sqffd_model_init(&model, &sq, &o), SQFFD_OK);
    sqffd__arena_measure(&a);
    sqffd__fit_system_layout(&a, dims, grid, &s);
    sqffd__fit_work_layout(&a, 100, dims, grid, &o, &fold, &w);
    size = a.used + 64;
    memory = malloc(size);
    sqffd__arena_init(&a, memory, size);
    sqffd__fit_system_layout(&a, dims, grid, &s);
    sqffd__fit_work_layout(&a, 100, dims, grid, &o, &fold, &w);
    CHECK(!a.overflow);
    m = s.count;
    l = s.lattice;
    start = (double *)malloc(3 * l * sizeof(double));
    exact = (double *)malloc(3 * l * sizeof(double));
    weights = (double *)malloc(m * sizeof(double));
    changed = (double *)malloc(m * sizeof(double));
    targets = (double *)malloc(3 * m * sizeof(double));
    target = (double *)malloc(3 * m * sizeof(double));
    bx = (double *)malloc(3 * m * sizeof(double));
    by_coord = (double *)malloc(3 * l * sizeof(double));
    springs = (double *)malloc(3 * l * sizeof(double));
    srand(11);
    CHECK_RESULT(sqffd__fit_prepare(&model, 1e-3, 0.05, SQFFD_REG_DISPLACEMENT, &s), SQFFD_OK);
    for (p = 0; p < 3 * l; p++) /* a start off the rest lattice */
        start[p] = (&model.ffd.control[0][0])[p] + 0.05 * ((double)rand() / RAND_MAX - 0.5);
    for (v = 0; v < m; v++) {
        weights[v] = 0.2 + 2.0 * (double)rand() / RAND_MAX;
        for (p = 0; p < 3; p++) targets[3 * v + p] = s.rest[3 * v + p] * 1.1 + 0.02 * ((double)rand() / RAND_MAX - 0.5);
    }
    for (trial = 0; trial < 6; trial++) {
        double excess_start, excess_lagged, move_error = 0.0, move2 = 0.0;
        sqffd__fit_evaluate(&s, (const double (*)[3])start, (double (*)[4])w.block, w.x);
        for (v = 0; v < m; v++) changed[v] = weights[v] * (0.6 + 0.8 * (double)rand() / RAND_MAX);
        /* G: the direct step on the changed weights */
        lagged_load(m, changed, targets, w.weights, target);
        w.factored = 0;
        CHECK_RESULT(sqffd__fit_step(&s, &w, start, w.x, target, w.next, &direct), SQFFD_OK);
        CHECK(w.factored && direct);
        memcpy(exact, w.plain, 3 * l * sizeof(double));
        /* the factor of the weights before, then the lagged step on the changed ones */
        memcpy(w.weights, weights, m * sizeof(double));
        CHECK_RESULT(sqffd__fit_solve(&s, &w), SQFFD_OK);
        lagged_load(m, changed, targets, w.weights, target);
        CHECK_RESULT(sqffd__fit_step(&s, &w, start, w.x, target, w.next, &direct), SQFFD_OK);
        CHECK(!direct);
        for (p = 0; p < 3 * l; p++) by_coord[p] = start[p] - exact[p];
        excess_start = lagged_a_norm2(&s, changed, by_coord, bx, (double (*)[4])w.block, springs, target);
        for (p = 0; p < 3 * l; p++) by_coord[p] = w.plain[p] - exact[p];
        excess_lagged = lagged_a_norm2(&s, changed, by_coord, bx, (double (*)[4])w.block, springs, target);
        CHECK_MSG(excess_lagged <= 0.05 * 0.05 * excess_start, "trial %zu: %.3g of the start's distance to G", trial,
                  sqrt(excess_lagged / excess_start));
        sqffd__fit_evaluate(&s, (const double (*)[3])w.rhs, (double (*)[4])w.block, bx);
        for (v = 0; v < 3 * m; v++) {
            move_error += (bx[v] - w.next[v]) * (bx[v] - w.next[v]);
            move2 += bx[v] * bx[v];
        }
        CHECK_MSG(move_error <= 1e-24 * move2, "trial %zu: reported move off by %.3g", trial, sqrt(move_error / move2));
        memcpy(start, w.plain, 3 * l * sizeof(double));
        memcpy(weights, changed, m * sizeof(double));
    }
    free(start); free(exact); free(weights); free(changed); free(targets); free(target); free(bx); free(by_coord); free(springs);
    free(memory);
}

/* The passes' visiting order (sqffd__fit_order): a permutation of the
   points, their Morton keys (recomputed here bit by bit) never falling
   along it, equal keys in the points' own order; all points in one place
   keep theirs. */
static void test_internal_pass_order(void)
{
    static const size_t counts[] = {1, 2, 7, 1000, 4099};
    size_t t, i;
    srand(5);
    for (t = 0; t < sizeof counts / sizeof counts[0]; t++) {
        size_t n = counts[t];
        double *p = (double *)malloc(3 * n * sizeof(double)), lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL},
               hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
        uint32_t *order = (uint32_t *)malloc(4 * n * sizeof(uint32_t)), *seen = (uint32_t *)calloc(n, sizeof(uint32_t));
        unsigned long long previous = 0;
        int bad_order = 0, bad_key = 0, c, b;
        sqffd_points view = sqffd_points_packed(p, n);
        for (i = 0; i < 3 * n; i++) p[i] = (double)(rand() % 50) * 0.37 - 4.0 * (double)(i % 3); /* (ties) */
        for (i = 0; i < n; i++)
            for (c = 0; c < 3; c++) {
                lo[c] = p[3 * i + c] < lo[c] ? p[3 * i + c] : lo[c];
                hi[c] = p[3 * i + c] > hi[c] ? p[3 * i + c] : hi[c];
            }
        sqffd__fit_order(&view, order, order + n, order + 2 * n, order + 3 * n);
        for (i = 0; i < n; i++) {
            unsigned long long key = 0;
            uint32_t k = order[i];
            if (k >= n || seen[k]++) {
                bad_order++;
                continue;
            }
            for (b = 9; b >= 0; b--) /* x's bit lowest in each triple, as the library lays them */
                for (c = 2; c >= 0; c--) {
                    double f = hi[c] > lo[c] ? (p[3 * k + (size_t)c] - lo[c]) * (1023.0 / (hi[c] - lo[c])) : 0.0;
                    unsigned cell = f < 1023.0 ? (unsigned)f : 1023u;
                    key = key << 1 | ((cell >> b) & 1u);
                }
            if (i > 0 && (key < previous || (key == previous && order[i] < order[i - 1]))) bad_key++;
            previous = key;
        }
        CHECK_MSG(bad_order == 0, "%zu points: %d indices repeated or out of range", n, bad_order);
        CHECK_MSG(bad_key == 0, "%zu points: %d out of Morton order", n, bad_key);
        for (i = 0; i < 3 * n; i++) p[i] = 2.5; /* one place: the points' own order */
        sqffd__fit_order(&view, order, order + n, order + 2 * n, order + 3 * n);
        for (i = 0; i < n; i++) bad_order += order[i] != (uint32_t)i;
        CHECK_MSG(bad_order == 0, "%zu points in one place: %d moved", n, bad_order);
        free(p); free(order); free(seen);
    }
}

/* J at a point and its gradient (sqffd__fit_fold_sample): at the box's
   corners J is its Bernstein form's corner coefficient (exact there), and
   the gradient matches central differences, on a folded random lattice of
   4 x 5 x 3 in a skewed box. */
static void test_internal_jacobian_sample(void)
{
    const int dims[3] = {4, 5, 3};
    const double origin[3] = {1.0, 2.0, 3.0}, edges[9] = {10.0, 1.0, 0.0, 0.0, 8.0, 2.0, 1.0, 0.0, 12.0};
    sqffd_ffd f;
    sqffd__arena a;
    sqffd__jacobian_work w;
    void *memory;
    double grad[3 * 60], *control = &f.control[0][0], worst = 0.0, scale = 0.0, corner_off = 0.0;
    int ej[3], corner, k;
    size_t p, size;
    int c;
    CHECK_RESULT(sqffd_ffd_init(&f, dims, origin, edges), SQFFD_OK);
    srand(13);
    for (p = 0; p < 3 * 60; p++) control[p] += 3.0 * ((double)rand() / RAND_MAX - 0.5);
    sqffd__arena_measure(&a);
    sqffd__ffd_jacobian_layout(&a, dims, &w);
    size = a.used + 64;
    memory = malloc(size);
    sqffd__arena_init(&a, memory, size);
    sqffd__ffd_jacobian_layout(&a, dims, &w);
    CHECK(!a.overflow);
    sqffd__ffd_jacobian_min(dims, control, f.inverse, &w, HUGE_VAL);
    sqffd__jacobian_extent(dims, 3, ej);
    for (corner = 0; corner < 8; corner++) {
        double stu[3];
        size_t g[3];
        for (k = 0; k < 3; k++) {
            stu[k] = (corner >> k) & 1 ? 1.0 : 0.0;
            g[k] = (corner >> k) & 1 ? (size_t)ej[k] - 1 : 0;
        }
        corner_off = fmax(corner_off, fabs(sqffd__fit_fold_sample(dims, control, f.inverse, stu, NULL) -
                                           w.coef[(g[0] * (size_t)ej[1] + g[1]) * (size_t)ej[2] + g[2]]));
    }
    CHECK_MSG(corner_off <= 1e-12, "J at a corner off its coefficient by %g", corner_off);
    for (k = 0; k < 20; k++) {
        double stu[3];
        for (c = 0; c < 3; c++) stu[c] = (double)rand() / RAND_MAX;
        sqffd__fit_fold_sample(dims, control, f.inverse, stu, grad);
        for (p = 0; p < 60; p += 3)
            for (c = 0; c < 3; c++) {
                double keep = control[3 * p + (size_t)c], up, down;
                control[3 * p + (size_t)c] = keep + 1e-5;
                up = sqffd__fit_fold_sample(dims, control, f.inverse, stu, NULL);
                control[3 * p + (size_t)c] = keep - 1e-5;
                down = sqffd__fit_fold_sample(dims, control, f.inverse, stu, NULL);
                control[3 * p + (size_t)c] = keep;
                worst = fmax(worst, fabs((up - down) / 2e-5 - grad[(size_t)c * 60 + p]));
                scale = fmax(scale, fabs(grad[(size_t)c * 60 + p]));
            }
    }
    CHECK_MSG(scale > 0.0 && worst <= 1e-7 * scale, "gradient off its differences by %g (largest %g)", worst, scale);
    free(memory);
}

/* The frames on the region's node lattice (sqffd__fit_fold_frames, one axis
   at a time) against each node's own (sqffd__fit_fold_frame, a sum over the
   lattice), for control points (interleaved) and for a step (planar), on a
   folded random 4 x 5 x 3 lattice in a skewed box; and J's change along the
   step from the crosses against J's own difference. */
static void test_internal_jacobian_frames(void)
{
    const int dims[3] = {4, 5, 3};
    const double origin[3] = {1.0, 2.0, 3.0}, edges[9] = {10.0, 1.0, 0.0, 0.0, 8.0, 2.0, 1.0, 0.0, 12.0};
    const size_t l = 60, n = SQFFD__FIT_REGION + 1;
    sqffd_ffd f;
    sqffd__arena a;
    sqffd__fit_fold fold;
    void *memory;
    double step[3 * 60], *control = &f.control[0][0], worst[2] = {0.0, 0.0}, scale[2] = {0.0, 0.0}, change = 0.0;
    size_t p, node;
    int c, layout;
    CHECK_RESULT(sqffd_ffd_init(&f, dims, origin, edges), SQFFD_OK);
    srand(17);
    for (p = 0; p < 3 * l; p++) control[p] += 3.0 * ((double)rand() / RAND_MAX - 0.5);
    for (p = 0; p < 3 * l; p++) step[p] = 1e-6 * ((double)rand() / RAND_MAX - 0.5);
    sqffd__arena_measure(&a);
    sqffd__fit_fold_layout(&a, dims, 1, 1, NULL);
    memory = malloc(a.used + 64);
    sqffd__arena_init(&a, memory, a.used + 64);
    sqffd__fit_fold_layout(&a, dims, 1, 1, &fold);
    CHECK(!a.overflow);
    for (layout = 0; layout < 2; layout++) {
        const double *field = layout ? step : control;
        size_t ps = layout ? 1 : 3, cs = layout ? l : 1;
        sqffd__fit_fold_frames(dims, field, ps, cs, f.inverse, &fold);
        for (node = 0; node < n * n * n; node++) {
            double stu[3], d[9];
            stu[0] = (double)(node / (n * n)) / SQFFD__FIT_REGION;
            stu[1] = (double)(node / n % n) / SQFFD__FIT_REGION;
            stu[2] = (double)(node % n) / SQFFD__FIT_REGION;
            sqffd__fit_fold_frame(dims, field, ps, cs, f.inverse, stu, d, NULL);
            for (c = 0; c < 9; c++) {
                worst[layout] = fmax(worst[layout], fabs(fold.frames[node][c] - d[c]));
                scale[layout] = fmax(scale[layout], fabs(d[c]));
            }
        }
    }
    for (layout = 0; layout < 2; layout++)
        CHECK_MSG(scale[layout] > 0.0 && worst[layout] <= 1e-12 * scale[layout], "%s frames off by %g (largest %g)",
                  layout ? "a step's" : "control points'", worst[layout], scale[layout]);
    for (node = 0; node < n * n * n; node += 7) { /* J's change along the step: linear in it, to its square */
        double stu[3], d[9], cross[9], moved[3 * 60], before, after, linear;
        stu[0] = (double)(node / (n * n)) / SQFFD__FIT_REGION;
        stu[1] = (double)(node / n % n) / SQFFD__FIT_REGION;
        stu[2] = (double)(node % n) / SQFFD__FIT_REGION;
        before = sqffd__fit_fold_sample(dims, control, f.inverse, stu, NULL);
        sqffd__fit_fold_frame(dims, control, 3, 1, f.inverse, stu, d, NULL);
        CHECK(fabs(sqffd__fit_fold_crosses(d, cross) - before) <= 1e-12 * fmax(1.0, fabs(before)));
        for (p = 0; p < l; p++)
            for (c = 0; c < 3; c++) moved[3 * p + (size_t)c] = control[3 * p + (size_t)c] + step[(size_t)c * l + p];
        after = sqffd__fit_fold_sample(dims, moved, f.inverse, stu, NULL);
        sqffd__fit_fold_frame(dims, step, 1, l, f.inverse, stu, d, NULL);
        linear = sqffd__dot3(d, cross) + sqffd__dot3(d + 3, cross + 3) + sqffd__dot3(d + 6, cross + 6);
        change = fmax(change, fabs((after - before) - linear));
    }
    CHECK_MSG(change <= 1e-9, "J's change along a step off its linear model by %g", change);
    free(memory);
}

/* The region's certificate (sqffd__fit_fold_certify) against brute force:
   J at 20,000 random points of the region's cells is never below the bound
   it certifies; a lattice that folds inside the region gets a bound under
   the floor, and distinct points where it dips; one that folds only
   outside it (the box's corners) is certified, though its whole-box bound
   is negative. */
static void test_internal_certificate(void)
{
    static const int dims[3] = {5, 5, 5};
    sqffd_fit_options o = sqffd_fit_options_default();
    sqffd_superquadric sq;
    sqffd_model model;
    sqffd__fit_fold fold;
    sqffd__arena a;
    void *memory;
    size_t size, p;
    int trial, k;
    memset(&sq, 0, sizeof sq);
    sq.size[0] = 1.0; sq.size[1] = 0.7; sq.size[2] = 1.5;
    sq.shape[0] = 0.8; sq.shape[1] = 1.2;
    sq.rotation[0] = sq.rotation[4] = sq.rotation[8] = 1.0;
    CHECK_RESULT(sqffd_model_init(&model, &sq, &o), SQFFD_OK);
    sqffd__arena_measure(&a);
    sqffd__fit_fold_layout(&a, dims, 1, 1, &fold);
    size = a.used + 64;
    memory = malloc(size);
    sqffd__arena_init(&a, memory, size);
    sqffd__fit_fold_layout(&a, dims, 1, 1, &fold);
    CHECK(!a.overflow);
    CHECK(sqffd__fit_region(&model, &fold));
    srand(17);
    for (trial = 0; trial < 6; trial++) {
        sqffd_model m = model;
        double *control = &m.ffd.control[0][0], bound, least = HUGE_VAL, box;
        int cells = 0;
        for (k = 0; k < SQFFD__FIT_REGION_CELLS; k++) cells += fold.region[k];
        CHECK(cells > 0 && cells < SQFFD__FIT_REGION_CELLS);
        if (trial < 5) /* random lattices, folding more and more */
            for (p = 0; p < 3 * 125; p++) control[p] += 0.6 * trial * ((double)rand() / RAND_MAX - 0.5);
        else { /* the corner control point (0, 0, 0) pushed through the box: a fold there alone */
            for (k = 0; k < 3; k++) control[k] += 0.3 * (model.ffd.edges[k] + model.ffd.edges[3 + k] + model.ffd.edges[6 + k]);
        }
        fold.goal = 0.02;
        bound = sqffd__fit_fold_certify(dims, &fold, control, m.ffd.inverse, 0.02);
        for (k = 0; k < 20000; k++) { /* a random point of a random region cell */
            double stu[3], j;
            int cell, c;
            do cell = rand() % SQFFD__FIT_REGION_CELLS; while (!fold.region[cell]);
            stu[0] = (cell / 64 + (double)rand() / RAND_MAX) / 8.0;
            stu[1] = (cell / 8 % 8 + (double)rand() / RAND_MAX) / 8.0;
            stu[2] = (cell % 8 + (double)rand() / RAND_MAX) / 8.0;
            j = sqffd__fit_fold_sample(dims, control, m.ffd.inverse, stu, NULL);
            least = j < least ? j : least;
            (void)c;
        }
        box = sqffd__ffd_jacobian_min(dims, control, m.ffd.inverse, &fold.at, HUGE_VAL);
        printf("    lattice %d: certified %.4f, sampled minimum %.4f, whole box %.4f\n", trial, bound, least, box);
        CHECK_MSG(least >= bound - 1e-12, "J %g sampled below the certified bound %g", least, bound);
        if (least < 0.02) CHECK_MSG(bound < 0.02, "J %g sampled under the floor, yet certified (%g)", least, bound);
        if (bound < 0.02) { /* the points it gives the step as new samples: some, each once */
            size_t i, j;
            CHECK(fold.failed > 0);
            for (i = 0; i < fold.failed; i++)
                for (j = 0; j < i; j++)
                    CHECK_MSG(memcmp(fold.fails[i], fold.fails[j], sizeof fold.fails[i]) != 0, "lattice %d: point %zu of the "
                              "certificate's repeats point %zu", trial, i, j);
        }
        if (trial == 5) {
            CHECK_MSG(box < 0.0, "the corner's push did not fold the box (%g)", box);
            CHECK_MSG(bound >= 0.02, "a fold outside the region not certified (%g)", bound);
        }
    }
    free(memory);
}

/* The heart wall's ray query (sqffd__wall_ray, a walk of the tree over the
   grid mesh) against the brute force over sqffd_model_mesh's triangle list
   (the nearest crossing closer than the reach, the first listed of equal
   ones, no triangle with the skipped corner): the same distance, bit for
   bit, and the same triangle, on deformed models' meshes (random lattices,
   boxy and tapered). Rays from random points along random and axis-aligned
   directions, rays aimed at a vertex or an edge's midpoint (crossings on
   shared edges: equal distances on two or more triangles), and rays from
   mesh vertices with that vertex skipped and a reach (random, or exactly
   the nearest crossing's distance: that one not counted). */
static void test_internal_wall_rays(void)
{
    static const int grids[][2] = {{2, 3}, {7, 5}, {16, 32}, {31, 40}};
    sqffd_fit_options o = sqffd_fit_options_default();
    sqffd_superquadric sq;
    size_t g;
    int ties = 0, hits = 0, cut = 0;
    memset(&sq, 0, sizeof sq);
    sq.size[0] = 30.0; sq.size[1] = 22.0; sq.size[2] = 45.0;
    sq.shape[0] = 0.5; sq.shape[1] = 1.3;
    sq.taper[0] = 0.3; sq.taper[1] = -0.2;
    sq.rotation[0] = sq.rotation[4] = sq.rotation[8] = 1.0;
    sq.center[0] = 100.0; sq.center[1] = -40.0; sq.center[2] = 7.0;
    srand(35);
    for (g = 0; g < sizeof grids / sizeof grids[0]; g++) {
        sqffd_model model;
        sqffd__fit_bvh h;
        size_t m = 0, triangles = 0, p, i;
        double *x, *control = &model.ffd.control[0][0];
        uint32_t *tri;
        int trial, c, bad = 0;
        o.grid[0] = grids[g][0];
        o.grid[1] = grids[g][1];
        CHECK_RESULT(sqffd_model_init(&model, &sq, &o), SQFFD_OK);
        for (p = 0; p < sizeof model.ffd.control / sizeof(double); p++) control[p] += 16.0 * ((double)rand() / RAND_MAX - 0.5);
        CHECK_RESULT(sqffd_model_mesh_size(grids[g][0], grids[g][1], &m, &triangles), SQFFD_OK);
        x = (double *)malloc(3 * m * sizeof *x);
        tri = (uint32_t *)malloc(3 * triangles * sizeof *tri);
        CHECK_RESULT(sqffd_model_mesh(&model, grids[g][0], grids[g][1], x, tri), SQFFD_OK);
        h.count = sqffd__fit_bvh_build(grids[g], NULL);
        h.nodes = (sqffd__fit_bvh_node *)malloc(h.count * sizeof *h.nodes);
        sqffd__fit_bvh_build(grids[g], h.nodes);
        sqffd__fit_bvh_boxes(&h, grids[g], x);
        for (trial = 0; trial < 600; trial++) {
            double o3[3], d[3], aim[3], len, reach = HUGE_VAL, t, brute = HUGE_VAL, second = HUGE_VAL;
            uint32_t skip = UINT32_MAX, corners[3] = {0, 0, 0};
            size_t hit = 0, u = (size_t)rand() % m, w = (size_t)rand() % triangles;
            int kind = trial % 6;
            for (c = 0; c < 3; c++) o3[c] = sq.center[c] + 120.0 * ((double)rand() / RAND_MAX - 0.5);
            if (kind >= 4) { /* from vertex u, skipping it */
                skip = (uint32_t)u;
                memcpy(o3, x + 3 * u, sizeof o3);
            }
            for (c = 0; c < 3; c++) d[c] = (double)rand() / RAND_MAX - 0.5;
            if (kind == 1) { /* along an axis (two zero components) */
                d[0] = d[1] = d[2] = 0.0;
                d[trial / 6 % 3] = trial / 18 % 2 ? 1.0 : -1.0;
            } else if (kind == 2 || kind == 3 || kind == 5) { /* at a vertex, or an edge's midpoint */
                const double *a = x + 3 * (size_t)tri[3 * w], *b = x + 3 * (size_t)tri[3 * w + 1];
                for (c = 0; c < 3; c++) aim[c] = kind == 3 ? 0.5 * (a[c] + b[c]) : a[c];
                if (kind == 5 && tri[3 * w] == skip) continue;
                sqffd__sub3(aim, o3, d);
            }
            len = sqrt(sqffd__dot3(d, d));
            if (!(len > 0.0)) continue;
            for (c = 0; c < 3; c++) d[c] /= len;
            for (p = 0; p < 2; p++) { /* the brute force: without a reach, then with it */
                if (p == 1 && kind >= 4) /* a random reach, or exactly the nearest crossing's */
                    reach = rand() % 3 == 0 && brute < HUGE_VAL ? brute : 100.0 * (double)rand() / RAND_MAX;
                else if (p == 1) break;
                brute = reach;
                second = HUGE_VAL;
                for (i = 0; i < triangles; i++) {
                    double at;
                    if (tri[3 * i] == skip || tri[3 * i + 1] == skip || tri[3 * i + 2] == skip) continue;
                    at = sqffd__wall_cross(x + 3 * (size_t)tri[3 * i], x + 3 * (size_t)tri[3 * i + 1],
                                           x + 3 * (size_t)tri[3 * i + 2], o3, d);
                    if (at > 0.0 && at < brute) {
                        second = brute;
                        brute = at;
                        hit = i;
                    } else if (at > 0.0 && at == brute)
                        second = at;
                }
            }
            t = sqffd__wall_ray(&h, grids[g], x, o3, d, skip, reach, corners);
            hits += brute < reach;
            ties += brute < reach && second == brute;
            cut += reach < HUGE_VAL;
            if (t == brute && (!(brute < reach) || (corners[0] == tri[3 * hit] && corners[1] == tri[3 * hit + 1] &&
                                                    corners[2] == tri[3 * hit + 2])))
                continue;
            if (++bad <= 5)
                CHECK_MSG(0, "grid %d x %d, ray %d (kind %d): the walk's %.17g (%u %u %u), brute force %.17g (triangle %u %u %u)",
                          grids[g][0], grids[g][1], trial, kind, t, corners[0], corners[1], corners[2], brute,
                          tri[3 * hit], tri[3 * hit + 1], tri[3 * hit + 2]);
        }
        CHECK_MSG(bad == 0, "grid %d x %d: %d rays differ", grids[g][0], grids[g][1], bad);
        free(h.nodes);
        free(tri);
        free(x);
    }
    printf("    %d crossings (%d on equal distances), %d rays with a reach\n", hits, ties, cut);
    CHECK(hits > 800 && ties > 10 && cut > 200);
}

void suite_internal(void)
{
    RUN_TEST(test_internal_jacobian_sample);
    RUN_TEST(test_internal_jacobian_frames);
    RUN_TEST(test_internal_certificate);
    RUN_TEST(test_internal_triangle_tree);
    RUN_TEST(test_internal_wall_rays);
    RUN_TEST(test_internal_cholesky_tiles);
    RUN_TEST(test_internal_lagged_step);
    RUN_TEST(test_internal_pass_order);
}

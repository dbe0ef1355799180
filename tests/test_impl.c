/* The one translation unit of the test binary that holds the implementation;
   every test file includes sqffd.h without it, so linkage is exercised.
   It also checks invariants of internal parts that the public functions
   cannot reach one by one (white-box). */
#define SQFFD_IMPLEMENTATION
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
            double eta, omega;
            sqffd__fit_grid_angles(grids[g], v, &eta, &omega);
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

void suite_internal(void)
{
    RUN_TEST(test_internal_triangle_tree);
}

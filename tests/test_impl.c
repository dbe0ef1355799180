/* The one translation unit of the test binary that holds the implementation;
   every test file includes sqffd.h without it, so linkage is exercised.
   It also checks invariants of internal parts that the public functions
   cannot reach one by one (white-box). */
#define SQFFD_IMPLEMENTATION
#include "test.h"
#include <stdlib.h>

/* The closest-point search's blocks: a vertex's closed ring lies in its
   block's hood, the hood relation is symmetric, each block's hood move is the
   largest of its hood's (brute force), and the far bound is below the
   distance to every vertex outside the hood (brute force, random meshes). */
static void test_internal_blocks(void)
{
    static const int grids[][2] = {{2, 3}, {3, 4}, {5, 6}, {8, 8}, {9, 17}, {32, 64}, {33, 65}, {100, 7}};
    size_t g;
    srand(7);
    for (g = 0; g < sizeof grids / sizeof grids[0]; g++) {
        size_t m = sqffd__fit_grid_count(grids[g]), v, k;
        sqffd__fit_ring *rings = (sqffd__fit_ring *)malloc(m * sizeof *rings);
        double *x = (double *)malloc(3 * m * sizeof *x), block_moved[SQFFD__FIT_MAX_BLOCKS];
        double hood_moved[SQFFD__FIT_MAX_BLOCKS], box[SQFFD__FIT_MAX_BLOCKS][6], separation[SQFFD__FIT_MAX_BLOCKS];
        sqffd__fit_search s;
        int a, c, count, trial, positive = 0;
        memset(&s, 0, sizeof s);
        s.blocks.of = (unsigned char *)malloc(m);
        sqffd__fit_rings(grids[g], rings);
        sqffd__fit_block_table(grids[g], &s.blocks);
        count = s.blocks.rows * s.blocks.cols + 2;
        for (v = 0; v < m; v++)
            for (k = 0; k < rings[v].count; k++)
                CHECK_MSG(sqffd__fit_in_hood(&s.blocks, s.blocks.of[v], s.blocks.of[sqffd__fit_ring_at(rings + v, k)]),
                          "grid %d x %d: vertex %zu's neighbour %zu outside its hood", grids[g][0], grids[g][1], v,
                          sqffd__fit_ring_at(rings + v, k));
        for (a = 0; a < count; a++)
            for (c = 0; c < count; c++)
                CHECK(sqffd__fit_in_hood(&s.blocks, a, c) == sqffd__fit_in_hood(&s.blocks, c, a));
        for (trial = 0; trial < 20; trial++) {
            for (c = 0; c < count; c++) block_moved[c] = (double)rand() / RAND_MAX;
            sqffd__fit_hood_moves(&s.blocks, block_moved, hood_moved);
            for (a = 0; a < count; a++) {
                double expect = 0.0;
                for (c = 0; c < count; c++)
                    if (sqffd__fit_in_hood(&s.blocks, a, c) && block_moved[c] > expect) expect = block_moved[c];
                CHECK(hood_moved[a] == expect);
            }
        }
        s.x = x;
        s.count = m;
        s.box = box;
        s.separation = separation;
        for (trial = 0; trial < 20; trial++) {
            for (v = 0; v < m; v++) { /* a sphere on the grid, its points jittered */
                double eta, omega;
                sqffd__fit_grid_angles(grids[g], v, &eta, &omega);
                x[3 * v] = cos(eta) * cos(omega) + 0.1 * (double)rand() / RAND_MAX;
                x[3 * v + 1] = cos(eta) * sin(omega) + 0.1 * (double)rand() / RAND_MAX;
                x[3 * v + 2] = sin(eta) + 0.1 * (double)rand() / RAND_MAX;
            }
            s.boxes_current = 0;
            for (k = 0; k < 50; k++) {
                double q[3], far, nearest = HUGE_VAL;
                a = s.blocks.of[(size_t)rand() % m];
                for (c = 0; c < 3; c++) q[c] = 2.4 * (double)rand() / RAND_MAX - 1.2;
                far = sqffd__fit_far(&s, q, a);
                for (v = 0; v < m; v++)
                    if (!sqffd__fit_in_hood(&s.blocks, a, s.blocks.of[v])) {
                        double d = sqrt(sqffd__dist2_3(q, x + 3 * v));
                        nearest = d < nearest ? d : nearest;
                    }
                positive += far > 0.0;
                CHECK_MSG(far <= nearest, "grid %d x %d: far bound %g above the nearest vertex outside the hood %g",
                          grids[g][0], grids[g][1], far, nearest);
            }
        }
        CHECK_MSG(positive > 0, "grid %d x %d: no far bound above 0", grids[g][0], grids[g][1]);
        free(s.blocks.of);
        free(x);
        free(rings);
    }
}

void suite_internal(void)
{
    RUN_TEST(test_internal_blocks);
}

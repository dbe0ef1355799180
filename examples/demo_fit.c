/* The smallest complete use of sqffd: fit the model to points, read the
   report, evaluate the surface and mesh it. The points are a dented egg made
   here, so the demo needs no file. Build: cc -O2 demo_fit.c -lm */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"

/* n points on an egg (radii 3, 2, 4, wider at the bottom) with a dent. */
static void make_points(double *points, int rows, int cols)
{
    const double pi = 3.14159265358979323846;
    int i, j;
    for (i = 0; i < rows; i++)
        for (j = 0; j < cols; j++) {
            double eta = -pi / 2 + pi * (i + 0.5) / rows, omega = 2 * pi * j / cols;
            double z = 4 * sin(eta), widen = 1.0 - 0.15 * z / 4;
            double dent = 1.0 - 0.25 * exp(-((eta - 0.3) * (eta - 0.3) + (omega - 1.0) * (omega - 1.0)) / 0.1);
            double *p = points + 3 * (i * cols + j);
            p[0] = 3 * cos(eta) * cos(omega) * widen * dent;
            p[1] = 2 * cos(eta) * sin(omega) * widen * dent;
            p[2] = z * dent;
        }
}

int main(void)
{
    enum { ROWS = 60, COLS = 100, N = ROWS * COLS, MESH_ETA = 16, MESH_OMEGA = 32 };
    double *points = (double *)malloc(3 * sizeof(double) * N);
    sqffd_fit_options opt = sqffd_fit_options_default(); /* 5x5x5 lattice, 33 iterations (25 coarse) */
    sqffd_model model;                                   /* 13 numbers + the lattice: a plain struct */
    sqffd_fit_report rep;
    size_t size, vertex_count, triangle_count;
    void *workspace;
    double *vertices, top[3];
    uint32_t *triangles;
    sqffd_result r;

    if (!points) return 1;
    make_points(points, ROWS, COLS);

    r = sqffd_fit_workspace_size(N, &opt, &size); /* the library never allocates: you do */
    if (r != SQFFD_OK) {
        fprintf(stderr, "fit workspace: %s\n", sqffd_result_string(r));
        return 1;
    }
    workspace = malloc(size);
    if (!workspace) return 1;
    r = sqffd_fit(points, N, &opt, &model, &rep, workspace, size);
    if (r != SQFFD_OK) {
        fprintf(stderr, "fit: %s\n", sqffd_result_string(r));
        return 1;
    }
    printf("superquadric: size %.3f %.3f %.3f, shape %.3f %.3f, taper %.3f %.3f\n", model.sq.size[0],
           model.sq.size[1], model.sq.size[2], model.sq.shape[0], model.sq.shape[1], model.sq.taper[0],
           model.sq.taper[1]);
    printf("error (RMS distance / diagonal): superquadric %.4f%%, after %d + %d FFD iterations %.4f%%\n",
           100 * rep.sq_error.rms_relative, rep.coarse_iterations, rep.iterations, 100 * rep.error.rms_relative);

    if (sqffd_model_point(&model, 1.5707963267948966, 0.0, top) != SQFFD_OK) return 1; /* eta = pi/2: the end of the local z axis */
    printf("model point (pi/2, 0) at %.3f %.3f %.3f\n", top[0], top[1], top[2]);

    if (sqffd_model_mesh_size(MESH_ETA, MESH_OMEGA, &vertex_count, &triangle_count) != SQFFD_OK) return 1;
    vertices = (double *)malloc(3 * sizeof(double) * vertex_count);
    triangles = (uint32_t *)malloc(3 * sizeof(uint32_t) * triangle_count);
    if (!vertices || !triangles) return 1;
    if (sqffd_model_mesh(&model, MESH_ETA, MESH_OMEGA, vertices, triangles) != SQFFD_OK) return 1;
    printf("mesh: %zu vertices, %zu triangles\n", vertex_count, triangle_count);

    free(vertices);
    free(triangles);
    free(workspace);
    free(points);
    /* a fit that gained nothing over the superquadric would be a bug */
    return rep.error.rms_relative < rep.sq_error.rms_relative ? 0 : 1;
}

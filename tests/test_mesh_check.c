/* The fold checker of tests/mesh_check.h against shapes whose answer is
   known: spheres and a torus (winding numbers 0, 1 and 2 where they are by
   construction; no crossing), the same with a vertex pushed through or
   overlapping (crossings, the sweep's count equal to every pair tested),
   flat fans (neighbours are no crossing; a fan that wraps over itself is),
   a fitted model (no fold) and one whose lattice is pushed through itself. */
#include "test.h"
#include "mesh_check.h"
#include <stdlib.h>
#include <string.h>

/* A growing mesh. */
typedef struct mesh {
    double v[3 * 4096];
    uint32_t t[3 * 8192];
    size_t nv, nt;
} mesh;

static uint32_t add_vertex(mesh *m, double x, double y, double z)
{
    m->v[3 * m->nv] = x;
    m->v[3 * m->nv + 1] = y;
    m->v[3 * m->nv + 2] = z;
    return (uint32_t)m->nv++;
}

static void add_triangle(mesh *m, uint32_t a, uint32_t b, uint32_t c)
{
    m->t[3 * m->nt] = a;
    m->t[3 * m->nt + 1] = b;
    m->t[3 * m->nt + 2] = c;
    m->nt++;
}

/* A UV sphere laid out as sqffd_model_mesh lays out its grid: rows - 1
   rings of cols vertices, then the south and north poles (one vertex each,
   fans of cols triangles); triangles face outward. The columns start at
   angle `turn` (so that no edge lies on a coordinate plane). */
static void add_sphere(mesh *m, const double c[3], double r, int rows, int cols, double turn)
{
    uint32_t first = (uint32_t)m->nv, south, north;
    int i, j;
    for (i = 1; i < rows; i++)
        for (j = 0; j < cols; j++) {
            double polar = SYNTH_PI * i / rows, phi = turn + 2.0 * SYNTH_PI * j / cols;
            add_vertex(m, c[0] + r * sin(polar) * cos(phi), c[1] + r * sin(polar) * sin(phi), c[2] - r * cos(polar));
        }
    south = add_vertex(m, c[0], c[1], c[2] - r);
    north = add_vertex(m, c[0], c[1], c[2] + r);
#define AT(i, j) (first + (uint32_t)(((i) - 1) * cols + ((j) % cols)))
    for (j = 0; j < cols; j++) {
        for (i = 1; i + 1 < rows; i++) {
            add_triangle(m, AT(i, j), AT(i, j + 1), AT(i + 1, j + 1));
            add_triangle(m, AT(i, j), AT(i + 1, j + 1), AT(i + 1, j));
        }
        add_triangle(m, south, AT(1, j + 1), AT(1, j));
        add_triangle(m, AT(rows - 1, j), AT(rows - 1, j + 1), north);
    }
#undef AT
}

/* A torus around the z axis (radii big and small), facing outward. */
static void add_torus(mesh *m, double big, double small, int around, int tube)
{
    uint32_t first = (uint32_t)m->nv;
    int i, j;
    for (i = 0; i < around; i++)
        for (j = 0; j < tube; j++) {
            double u = 2.0 * SYNTH_PI * (i + 0.3) / around, w = 2.0 * SYNTH_PI * (j + 0.1) / tube;
            add_vertex(m, (big + small * cos(w)) * cos(u), (big + small * cos(w)) * sin(u), small * sin(w));
        }
#define AT(i, j) (first + (uint32_t)(((i) % around) * tube + ((j) % tube)))
    for (i = 0; i < around; i++)
        for (j = 0; j < tube; j++) {
            add_triangle(m, AT(i, j), AT(i + 1, j), AT(i + 1, j + 1));
            add_triangle(m, AT(i, j), AT(i + 1, j + 1), AT(i, j + 1));
        }
#undef AT
}

/* The crossing pairs by testing every pair: the sweep's ground truth. */
static long brute_crossings(const mesh *m)
{
    meshcheck__tri *t = (meshcheck__tri *)test_malloc(m->nt * sizeof *t);
    double lo[3], hi[3], eps;
    size_t i, j, n = 0;
    long found = 0;
    synth_bounds(m->v, m->nv, lo, hi);
    eps = MESHCHECK_EPS * sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                               (hi[2] - lo[2]) * (hi[2] - lo[2]));
    for (i = 0; i < m->nt; i++)
        n += (size_t)meshcheck__tri_init(&t[n], m->v + 3 * m->t[3 * i], m->v + 3 * m->t[3 * i + 1], m->v + 3 * m->t[3 * i + 2]);
    for (i = 0; i < n; i++)
        for (j = i + 1; j < n; j++) found += meshcheck__pair_crosses(&t[i], &t[j], eps);
    free(t);
    return found;
}

static long crossings(const mesh *m)
{
    return meshcheck_self_intersections(m->v, m->nv, m->t, m->nt, 0, NULL);
}

static double winding(const mesh *m, double x, double y, double z)
{
    const double q[3] = {x, y, z};
    return meshcheck_winding(m->v, m->nv, m->t, m->nt, q);
}

/* THE COLUMN COUNT equals the solid angles' sum, rounded, at `samples`
   random points of the mesh's box (grown by a tenth); returns how many
   points it checked away from the surface (|w - round(w)| < 1e-6). */
static size_t columns_match(const double *v, size_t nv, const uint32_t *t, size_t nt, size_t samples)
{
    meshcheck__columns c;
    synth_rng r = synth_rng_seed(5);
    double lo[3], hi[3];
    size_t i, checked = 0;
    synth_bounds(v, nv, lo, hi);
    CHECK(meshcheck__columns_build(&c, v, nv, t, nt));
    for (i = 0; i < samples; i++) {
        double q[3], w;
        int k;
        for (k = 0; k < 3; k++) q[k] = synth_range(&r, lo[k] - 0.1 * (hi[k] - lo[k]), hi[k] + 0.1 * (hi[k] - lo[k]));
        w = meshcheck_winding(v, nv, t, nt, q);
        if (fabs(w - (double)lround(w)) > 1e-6) continue;
        checked++;
        CHECK_MSG(meshcheck__column_winding(&c, q) == lround(w), "at %g %g %g: %ld, solid angles %g", q[0], q[1], q[2],
                  meshcheck__column_winding(&c, q), w);
    }
    free(c.start);
    free(c.list);
    return checked;
}

static mesh *new_mesh(void)
{
    mesh *m = (mesh *)test_malloc(sizeof *m);
    m->nv = m->nt = 0;
    return m;
}

/* A sphere: no crossing; winding 1 inside (near the surface too), 0 outside. */
static void test_mesh_check_sphere(void)
{
    const double c[3] = {0.3, -0.2, 0.1};
    mesh *m = new_mesh();
    add_sphere(m, c, 2.0, 24, 48, 0.05);
    CHECK(crossings(m) == 0);
    CHECK(brute_crossings(m) == 0);
    CHECK_NEAR(winding(m, 0.3, -0.2, 0.1), 1.0, 1e-9);
    CHECK_NEAR(winding(m, 1.5, 0.5, 0.9), 1.0, 1e-9);
    CHECK_NEAR(winding(m, 0.3, -0.2, 2.0), 1.0, 1e-9); /* just below the north pole */
    CHECK_NEAR(winding(m, 3.0, 0.0, 0.0), 0.0, 1e-9);
    CHECK_NEAR(winding(m, 0.3, -0.2, 2.2), 0.0, 1e-9);
    CHECK_NEAR(winding(m, -40.0, 7.0, 3.0), 0.0, 1e-9);
    CHECK(meshcheck_folded_share(m->v, m->nv, m->t, m->nt, 200, 1) == 0.0);
    free(m);
}

/* A vertex pushed from one side of the sphere through the other: its fan
   crosses the far side; the sweep finds the pairs every pair test finds. */
static void test_mesh_check_pushed_vertex(void)
{
    const double c[3] = {0.0, 0.0, 0.0};
    mesh *m = new_mesh();
    uint32_t pairs[2 * 4];
    size_t v = 11 * 32 + 5; /* ring 12 of 24, column 5 */
    long n, i;
    int k;
    add_sphere(m, c, 1.0, 24, 32, 0.05);
    for (k = 0; k < 3; k++) m->v[3 * v + (size_t)k] *= -1.3;
    n = meshcheck_self_intersections(m->v, m->nv, m->t, m->nt, 4, pairs);
    CHECK_MSG(n >= 6, "%ld crossing pairs", n); /* the six triangles at the vertex each cross the far side */
    CHECK(n == brute_crossings(m));
    for (i = 0; i < (n < 4 ? n : 4); i++) {
        CHECK(pairs[2 * i] < pairs[2 * i + 1] && pairs[2 * i + 1] < m->nt);
        /* one triangle of each pair has the pushed vertex */
        CHECK((m->t[3 * pairs[2 * i]] == v || m->t[3 * pairs[2 * i] + 1] == v || m->t[3 * pairs[2 * i] + 2] == v) !=
              (m->t[3 * pairs[2 * i + 1]] == v || m->t[3 * pairs[2 * i + 1] + 1] == v || m->t[3 * pairs[2 * i + 1] + 2] == v));
    }
    CHECK(meshcheck_self_intersections(m->v, m->nv, m->t, m->nt, 0, NULL) == n);
    m->t[7] = (uint32_t)m->nv; /* an index out of range */
    CHECK(crossings(m) == -1);
    free(m);
}

/* Two spheres apart: none; overlapping: the crossing circle, and the lens
   between them wound twice. */
static void test_mesh_check_two_spheres(void)
{
    const double a[3] = {0.0, 0.0, 0.0}, b[3] = {2.5, 0.1, 0.0}, near[3] = {1.4, 0.1, 0.0};
    mesh *m = new_mesh();
    long n;
    add_sphere(m, a, 1.0, 16, 32, 0.05);
    add_sphere(m, b, 1.0, 16, 32, 0.1);
    CHECK(crossings(m) == 0);
    CHECK_NEAR(winding(m, 0.0, 0.0, 0.0), 1.0, 1e-9);
    CHECK_NEAR(winding(m, 2.5, 0.1, 0.0), 1.0, 1e-9);
    CHECK_NEAR(winding(m, 1.25, 0.05, 0.0), 0.0, 1e-9);
    m->nv = m->nt = 0;
    add_sphere(m, a, 1.0, 16, 32, 0.05);
    add_sphere(m, near, 1.0, 16, 32, 0.1);
    n = crossings(m);
    CHECK_MSG(n >= 32, "%ld crossing pairs", n); /* the circle passes through at least a ring of triangles */
    CHECK(n == brute_crossings(m));
    CHECK_NEAR(winding(m, 0.7, 0.05, 0.0), 2.0, 1e-9);
    CHECK_NEAR(winding(m, -0.5, 0.0, 0.0), 1.0, 1e-9);
    CHECK(meshcheck_folded_share(m->v, m->nv, m->t, m->nt, 400, 1) > 0.0);
    CHECK(columns_match(m->v, m->nv, m->t, m->nt, 500) >= 495);
    free(m);
}

/* A torus: no crossing; 1 in the tube, 0 in the hole and outside. */
static void test_mesh_check_torus(void)
{
    mesh *m = new_mesh();
    add_torus(m, 2.0, 0.6, 48, 24);
    CHECK(crossings(m) == 0);
    CHECK(brute_crossings(m) == 0);
    CHECK_NEAR(winding(m, 2.0, 0.0, 0.0), 1.0, 1e-9);
    CHECK_NEAR(winding(m, 0.0, -2.3, 0.3), 1.0, 1e-9);
    CHECK_NEAR(winding(m, 0.0, 0.0, 0.0), 0.0, 1e-9);
    CHECK_NEAR(winding(m, 1.0, 0.2, 0.0), 0.0, 1e-9);
    CHECK_NEAR(winding(m, 2.0, 0.0, 0.8), 0.0, 1e-9);
    CHECK(columns_match(m->v, m->nv, m->t, m->nt, 500) >= 495);
    free(m);
}

/* Flat fans: neighbours sharing edges, and triangles sharing only the
   centre, in one plane, are no crossing; a fan that winds 1.5 turns
   overlaps itself; two triangles folded over their shared edge overlap. */
static void test_mesh_check_flat_fan(void)
{
    mesh *m = new_mesh();
    uint32_t centre = add_vertex(m, 0.2, 0.1, 0.5);
    int j, spokes = 12;
    for (j = 0; j <= spokes; j++) {
        double phi = 2.0 * SYNTH_PI * j / spokes;
        add_vertex(m, 0.2 + cos(phi), 0.1 + sin(phi), 0.5);
    }
    for (j = 0; j < spokes; j++) add_triangle(m, centre, (uint32_t)(1 + j), (uint32_t)(1 + (j + 1) % spokes));
    CHECK(crossings(m) == 0);
    /* the same fan with its last spoke a duplicate of the first (coincident vertices, other indices) */
    m->nt = 0;
    for (j = 0; j < spokes; j++) add_triangle(m, centre, (uint32_t)(1 + j), (uint32_t)(2 + j));
    CHECK(crossings(m) == 0);
    CHECK(brute_crossings(m) == 0);
    /* 1.5 turns: the last half turn lies on the first */
    m->nv = 1;
    m->nt = 0;
    for (j = 0; j <= 18; j++) {
        double phi = 2.0 * SYNTH_PI * j / spokes;
        add_vertex(m, 0.2 + cos(phi) * (1.0 + 0.01 * j), 0.1 + sin(phi) * (1.0 + 0.01 * j), 0.5);
    }
    for (j = 0; j < 18; j++) add_triangle(m, centre, (uint32_t)(1 + j), (uint32_t)(2 + j));
    CHECK_MSG(crossings(m) > 0, "%ld", crossings(m));
    CHECK(crossings(m) == brute_crossings(m));
    /* folded over a shared edge (d on c's side of a-b), and unfolded */
    m->nv = m->nt = 0;
    add_vertex(m, 0.0, 0.0, 0.0);
    add_vertex(m, 1.0, 0.0, 0.0);
    add_vertex(m, 0.3, 1.0, 0.0);
    add_vertex(m, 0.6, 0.8, 0.0);
    add_triangle(m, 0, 1, 2);
    add_triangle(m, 1, 0, 3);
    CHECK(crossings(m) == 1);
    m->v[10] = -0.8;
    CHECK(crossings(m) == 0);
    /* a triangle listed twice */
    add_triangle(m, 0, 1, 2);
    CHECK(crossings(m) == 1);
    free(m);
}

/* A fitted ellipsoid's model: no crossing, every sample wound once. Its
   lattice with one face pushed into the shape (still a valid model) folds:
   by the winding numbers alone, then, pushed further, by both measures. */
static void test_mesh_check_model(void)
{
    sqffd_superquadric sq;
    sqffd_model m, bent;
    meshcheck_folds f;
    synth_rng r = synth_rng_seed(33);
    double *pts = (double *)test_malloc(3 * 2000 * sizeof *pts);
    int k;
    memset(&sq, 0, sizeof sq);
    sq.size[0] = 3.0; sq.size[1] = 2.0; sq.size[2] = 1.5;
    sq.shape[0] = sq.shape[1] = 1.0;
    sq.rotation[0] = sq.rotation[4] = sq.rotation[8] = 1.0;
    sq.center[0] = 1.0;
    CHECK(synth_sq_surface(&r, &sq, 2000, 0.005, pts) == 2000);
    CHECK_RESULT(test_fit(pts, 2000, NULL, &m, NULL), SQFFD_OK);
    CHECK_RESULT(meshcheck_model_folds(&m, 1500, 32, 64, &f), SQFFD_OK);
    CHECK(f.samples == 1500);
    CHECK(f.crossings == 0);
    CHECK_MSG(f.winding_failures == 0, "%d failures, worst %ld", f.winding_failures, f.worst_winding);
    CHECK(f.worst_winding == 1);
    /* the middle control point of the box's last face in u pushed back through the shape, past its first face */
    /* the box's last face in u (all its control points) moved by -s U: x -> x - s U u^4, which
       folds where 1 - 4 s u^3 < 0. s = 0.5: u > 0.79, inside the shape (it reaches u = 0.91), but
       its tip comes back only to u = 0.91 - 0.5 0.91^4 = 0.57, inside the fold: the surface stays
       embedded and only the winding numbers see the fold. s = 1.5: the tip lands at -0.12,
       past the far tip (u = 0.09): the surface passes through itself. */
    for (k = 0; k < 2; k++) {
        double s = k ? 1.5 : 0.5;
        int i, j, c;
        bent = m;
        for (i = 0; i < m.ffd.dims[0]; i++)
            for (j = 0; j < m.ffd.dims[1]; j++)
                for (c = 0; c < 3; c++)
                    bent.ffd.control[(i * m.ffd.dims[1] + j) * m.ffd.dims[2] + m.ffd.dims[2] - 1][c] -= s * m.ffd.edges[6 + c];
        CHECK_RESULT(sqffd_model_validate(&bent), SQFFD_OK);
        CHECK_RESULT(meshcheck_model_folds(&bent, 1500, 32, 64, &f), SQFFD_OK);
        CHECK_MSG(k ? f.crossings > 0 : f.crossings == 0, "s = %g: %ld crossings", s, f.crossings);
        CHECK_MSG(f.winding_failures > 0, "s = %g: %d failures", s, f.winding_failures);
        {   /* the column count on the folded mesh, wound -1 to 2 times */
            size_t nv, nt;
            double *v;
            uint32_t *t;
            CHECK_RESULT(sqffd_model_mesh_size(32, 64, &nv, &nt), SQFFD_OK);
            v = (double *)test_malloc(3 * nv * sizeof *v);
            t = (uint32_t *)test_malloc(3 * nt * sizeof *t);
            CHECK_RESULT(sqffd_model_mesh(&bent, 32, 64, v, t), SQFFD_OK);
            CHECK(columns_match(v, nv, t, nt, 300) >= 290);
            free(v);
            free(t);
        }
    }
    /* bad input */
    CHECK_RESULT(meshcheck_model_folds(&m, 10, 1, 64, &f), SQFFD_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(meshcheck_model_folds(&m, -1, 32, 64, &f), SQFFD_ERROR_INVALID_ARGUMENT);
    bent.sq.size[0] = -1.0;
    CHECK_RESULT(meshcheck_model_folds(&bent, 10, 32, 64, &f), SQFFD_ERROR_INVALID_MODEL);
    free(pts);
}

void suite_mesh_check(void)
{
    RUN_TEST(test_mesh_check_sphere);
    RUN_TEST(test_mesh_check_pushed_vertex);
    RUN_TEST(test_mesh_check_two_spheres);
    RUN_TEST(test_mesh_check_torus);
    RUN_TEST(test_mesh_check_flat_fan);
    RUN_TEST(test_mesh_check_model);
}

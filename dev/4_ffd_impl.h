/* ======================================================================
   Layer 4: free-form deformation (Bernstein lattice)
   ====================================================================== */

/* The degree+1 Bernstein polynomials B_i^degree(s), i = 0..degree, by the
   de Casteljau recurrence (each step splits every value into (1-s) and s
   parts): the weights sum to 1 up to rounding for any s, and at s = 0 or 1
   they are exactly one unit vector. */
static void sqffd__ffd_bernstein(int degree, double s, double *b)
{
    int d, i;
    double r = 1.0 - s;
    b[0] = 1.0;
    for (d = 1; d <= degree; ++d) {
        b[d] = s * b[d - 1];
        for (i = d - 1; i > 0; --i) b[i] = r * b[i] + s * b[i - 1];
        b[0] *= r;
    }
}

/* The three 1-D weight vectors of (s, t, u): w[0..l), w[l..l+m), w[l+m..l+m+n).
   B's row at (s, t, u) is their tensor product; the model fit stores these
   l+m+n numbers per point instead of the l*m*n products. */
static void sqffd__ffd_axis_weights(const int dims[3], const double stu[3], double *w)
{
    sqffd__ffd_bernstein(dims[0] - 1, stu[0], w);
    sqffd__ffd_bernstein(dims[1] - 1, stu[1], w + dims[0]);
    sqffd__ffd_bernstein(dims[2] - 1, stu[2], w + dims[0] + dims[1]);
}

/* q_ij = sum_k wu_k P_ijk for every (i, j) (l*m entries): the first of the
   sums in sum_ijk ws_i wt_j wu_k P_ijk. The model fit shares it between the
   points with the same u. */
static void sqffd__ffd_sum_u(const int dims[3], const double (*control)[3], const double *wu, double (*q)[3])
{
    int ij, k;
    for (ij = 0; ij < dims[0] * dims[1]; ++ij) {
        const double (*p)[3] = control + (size_t)ij * (size_t)dims[2];
        double x = 0.0, y = 0.0, z = 0.0;
        for (k = 0; k < dims[2]; ++k) {
            x += wu[k] * p[k][0];
            y += wu[k] * p[k][1];
            z += wu[k] * p[k][2];
        }
        q[ij][0] = x; q[ij][1] = y; q[ij][2] = z;
    }
}

/* sum_ij ws_i wt_j q_ij: the rest of the sums. */
static void sqffd__ffd_sum_st(const int dims[3], const double (*q)[3], const double *ws, const double *wt, double out[3])
{
    double x = 0.0, y = 0.0, z = 0.0;
    int i, j;
    for (i = 0; i < dims[0]; ++i) {
        const double (*qi)[3] = q + i * dims[1];
        double xi = 0.0, yi = 0.0, zi = 0.0;
        for (j = 0; j < dims[1]; ++j) {
            xi += wt[j] * qi[j][0]; yi += wt[j] * qi[j][1]; zi += wt[j] * qi[j][2];
        }
        x += ws[i] * xi; y += ws[i] * yi; z += ws[i] * zi;
    }
    out[0] = x; out[1] = y; out[2] = z;
}

static int sqffd__ffd_dims_valid(const int dims[3])
{
    int a;
    for (a = 0; a < 3; ++a)
        if (dims[a] < 2 || dims[a] > SQFFD_MAX_LATTICE) return 0;
    return 1;
}

SQFFD_DEF sqffd_result sqffd_ffd_init(sqffd_ffd *ffd, const int dims[3], const double origin[3], const double edges[9])
{
    double det, scale;
    int a, i, j, k;
    if (!ffd || !dims || !origin || !edges || !sqffd__ffd_dims_valid(dims)) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (!sqffd__finite3(origin) || !sqffd__finite3(edges) || !sqffd__finite3(edges + 3) || !sqffd__finite3(edges + 6))
        return SQFFD_ERROR_NON_FINITE;
    memset(ffd, 0, sizeof *ffd);
    /* Sederberg & Parry's local coordinates: s = (T x U).(X - X0) / (T x U).S
       and cyclically, so the rows of `inverse` are T x U, U x S, S x T over
       the determinant S.(T x U). */
    sqffd__cross3(edges + 3, edges + 6, ffd->inverse);
    sqffd__cross3(edges + 6, edges, ffd->inverse + 3);
    sqffd__cross3(edges, edges + 3, ffd->inverse + 6);
    det = sqffd__dot3(edges, ffd->inverse);
    scale = sqrt(sqffd__dot3(edges, edges) * sqffd__dot3(edges + 3, edges + 3) * sqffd__dot3(edges + 6, edges + 6));
    if (!(fabs(det) > 1e-12 * scale) || !isfinite(det)) return SQFFD_ERROR_DEGENERATE;
    for (a = 0; a < 9; ++a) ffd->inverse[a] /= det;
    for (a = 0; a < 3; ++a) ffd->dims[a] = dims[a];
    memcpy(ffd->origin, origin, sizeof ffd->origin);
    memcpy(ffd->edges, edges, sizeof ffd->edges);
    for (i = 0; i < dims[0]; ++i)
        for (j = 0; j < dims[1]; ++j)
            for (k = 0; k < dims[2]; ++k) {
                double s = (double)i / (double)(dims[0] - 1);
                double t = (double)j / (double)(dims[1] - 1);
                double u = (double)k / (double)(dims[2] - 1);
                double *p = ffd->control[(i * dims[1] + j) * dims[2] + k];
                for (a = 0; a < 3; ++a) p[a] = origin[a] + s * edges[a] + t * edges[3 + a] + u * edges[6 + a];
            }
    return SQFFD_OK;
}

SQFFD_DEF void sqffd_ffd_local(const sqffd_ffd *ffd, const double point[3], double stu[3])
{
    double d[3];
    sqffd__sub3(point, ffd->origin, d);
    sqffd__mat3_vec(ffd->inverse, d, stu);
}

SQFFD_DEF void sqffd_ffd_eval(const sqffd_ffd *ffd, const double stu[3], double out[3])
{
    double w[3 * SQFFD_MAX_LATTICE], q[SQFFD_MAX_LATTICE * SQFFD_MAX_LATTICE][3];
    const int *d = ffd->dims;
    SQFFD_ASSERT(sqffd__ffd_dims_valid(d));
    sqffd__ffd_axis_weights(d, stu, w);
    sqffd__ffd_sum_u(d, (const double (*)[3])ffd->control, w + d[0] + d[1], q);
    sqffd__ffd_sum_st(d, (const double (*)[3])q, w, w + d[0], out);
}

SQFFD_DEF void sqffd_ffd_deform(const sqffd_ffd *ffd, const double point[3], double out[3])
{
    double stu[3];
    sqffd_ffd_local(ffd, point, stu);
    sqffd_ffd_eval(ffd, stu, out);
}

/* The l*m*n products of the three 1-D weight vectors, in control-point order. */
static void sqffd__ffd_expand(const int dims[3], const double *w, double *weights)
{
    const double *ws = w, *wt = w + dims[0], *wu = w + dims[0] + dims[1];
    int i, j, k;
    for (i = 0; i < dims[0]; ++i)
        for (j = 0; j < dims[1]; ++j) {
            double wij = ws[i] * wt[j];
            for (k = 0; k < dims[2]; ++k) *weights++ = wij * wu[k];
        }
}

SQFFD_DEF void sqffd_ffd_weights(const int dims[3], const double stu[3], double *weights)
{
    double w[3 * SQFFD_MAX_LATTICE];
    SQFFD_ASSERT(sqffd__ffd_dims_valid(dims));
    sqffd__ffd_axis_weights(dims, stu, w);
    sqffd__ffd_expand(dims, w, weights);
}

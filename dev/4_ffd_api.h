/* ======================================================================
   Layer 4: free-form deformation (Bernstein lattice)
   ====================================================================== */

#ifndef SQFFD_MAX_LATTICE
#define SQFFD_MAX_LATTICE 8 /* control points per axis at most; bounds sqffd_ffd's size */
#endif

/* A box (origin + three edge vectors, not necessarily orthogonal) holding an
   l x m x n lattice of control points (Sederberg & Parry); a point with local
   coordinates (s, t, u) maps to
     sum_ijk B_i^{l-1}(s) B_j^{m-1}(t) B_k^{n-1}(u) P_ijk,
   B_i^d(s) = C(d, i) s^i (1 - s)^(d - i). Points outside the box (s, t, u
   outside [0, 1]) follow the same polynomial (no clamping), so the map is
   smooth everywhere; far outside, rounding grows like (|s| + |1 - s|)^degree
   (the weights alternate in sign). The weights come from de Casteljau's
   recurrence: on a face (s = 0 or 1) only that face's control points act,
   and a corner lands exactly on its corner control point. */
typedef struct sqffd_ffd {
    int dims[3];       /* l, m, n: control points per axis, 2..SQFFD_MAX_LATTICE */
    double origin[3];  /* the box corner at (s, t, u) = (0, 0, 0) */
    double edges[9];   /* row-major: rows are the edge vectors S, T, U */
    double inverse[9]; /* set by sqffd_ffd_init: rows T x U, U x S, S x T over det, so stu = inverse (p - origin) */
    double control[SQFFD_MAX_LATTICE * SQFFD_MAX_LATTICE * SQFFD_MAX_LATTICE][3]; /* P_ijk at (i * m + j) * n + k */
} sqffd_ffd;

/* The regular lattice P0: P_ijk = origin + i/(l-1) S + j/(m-1) T + k/(n-1) U,
   which maps every point to itself (linear precision of Bernstein polynomials).
   INVALID_ARGUMENT for NULL or dims out of range, NON_FINITE, DEGENERATE for a
   flat box (|det| <= 1e-12 |S| |T| |U|). */
SQFFD_DEF sqffd_result sqffd_ffd_init(sqffd_ffd *ffd, const int dims[3], const double origin[3], const double edges[9]);
/* Local (s, t, u) of a world point. */
SQFFD_DEF void sqffd_ffd_local(const sqffd_ffd *ffd, const double point[3], double stu[3]);
/* The deformed position of local coordinates (s, t, u). */
SQFFD_DEF void sqffd_ffd_eval(const sqffd_ffd *ffd, const double stu[3], double out[3]);
/* Forward deformation of a world point: eval(local(point)). */
SQFFD_DEF void sqffd_ffd_deform(const sqffd_ffd *ffd, const double point[3], double out[3]);
/* One row of the matrix B: the l*m*n Bernstein products at (s, t, u), in control-point order. */
SQFFD_DEF void sqffd_ffd_weights(const int dims[3], const double stu[3], double *weights);

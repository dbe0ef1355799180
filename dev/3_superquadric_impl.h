/* ======================================================================
   Layer 3: superquadric with global tapering
   ====================================================================== */

#define SQFFD__SQ_PI 3.14159265358979323846
/* Magnitudes below this count as 0 before a logarithm (keeps logs finite). */
#define SQFFD__SQ_TINY 1e-300
/* Floor of the tapering factors 1 + K z / a3: they are >= 1 - |K| > 0 on the
   shape itself; only points far beyond the poles reach the floor. */
#define SQFFD__SQ_MIN_TAPER 1e-3

/* ---- geometry ----------------------------------------------------------- */

/* sign(v) |v|^e, 0 for v = 0 */
static double sqffd__sq_spow(double v, double e)
{
    if (v == 0.0) return 0.0;
    return v > 0.0 ? pow(v, e) : -pow(-v, e);
}

/* log(e^a + e^b) and the shares frac[0] = e^a / (e^a + e^b), frac[1] = e^b / (...),
   each computed directly so that a vanishing share is exactly 0. */
static double sqffd__sq_logsum(double a, double b, double frac[2])
{
    double hi = a > b ? a : b, t = exp(-fabs(a - b)); /* e^(lo - hi) */
    double s = 1.0 + t;
    frac[0] = a > b ? 1.0 / s : t / s;
    frac[1] = a > b ? t / s : 1.0 / s;
    return hi + log1p(t);
}

static double sqffd__sq_log_abs(double v)
{
    double m = fabs(v);
    return log(m > SQFFD__SQ_TINY ? m : SQFFD__SQ_TINY);
}

/* Tapered local coordinates q = R^T (p - c). */
static void sqffd__sq_to_local(const sqffd_superquadric *sq, const double p[3], double q[3])
{
    double d[3];
    sqffd__sub3(p, sq->center, d);
    sqffd__mat3t_vec(sq->rotation, d, q);
}

/* The tapering factors 1 + K z / a3 at local height z (floored). */
static void sqffd__sq_taper_factors(const sqffd_superquadric *sq, double z, double f[2])
{
    int k;
    for (k = 0; k < 2; k++) {
        f[k] = 1.0 + sq->taper[k] * z / sq->size[2];
        if (f[k] < SQFFD__SQ_MIN_TAPER) f[k] = SQFFD__SQ_MIN_TAPER;
    }
}

/* Untapered local coordinates of a world point. */
static void sqffd__sq_untapered(const sqffd_superquadric *sq, const double p[3], double u[3])
{
    double f[2];
    sqffd__sq_to_local(sq, p, u);
    sqffd__sq_taper_factors(sq, u[2], f);
    u[0] /= f[0];
    u[1] /= f[1];
}

/* log F at untapered local coordinates u (log_size = ln a1, ln a2, ln a3),
   computed in logarithms so that far points and small exponents neither
   overflow nor underflow:
   F = (|x/a1|^(2/e2) + |y/a2|^(2/e2))^(e2/e1) + |z/a3|^(2/e1) = G + H,
   G = A^(e2/e1), A = U + V. If parts is not NULL it receives what the
   derivatives need (SQFFD__SQ_PART_* indices). */
#define SQFFD__SQ_PART_LU 0    /* ln U */
#define SQFFD__SQ_PART_LV 1    /* ln V */
#define SQFFD__SQ_PART_LA 2    /* ln A */
#define SQFFD__SQ_PART_LG 3    /* ln G */
#define SQFFD__SQ_PART_LH 4    /* ln H */
#define SQFFD__SQ_PART_FU 5    /* U / A (then V / A) */
#define SQFFD__SQ_PART_FG 7    /* G / F (then H / F) */
#define SQFFD__SQ_PARTS 9
static double sqffd__sq_log_f(const double u[3], const double log_size[3], double e1, double e2, double *parts)
{
    double lu = (2.0 / e2) * (sqffd__sq_log_abs(u[0]) - log_size[0]);
    double lv = (2.0 / e2) * (sqffd__sq_log_abs(u[1]) - log_size[1]);
    double lh = (2.0 / e1) * (sqffd__sq_log_abs(u[2]) - log_size[2]);
    double frac_u[2], frac_g[2], la, lg, lf;
    la = sqffd__sq_logsum(lu, lv, frac_u);
    lg = (e2 / e1) * la;
    lf = sqffd__sq_logsum(lg, lh, frac_g);
    if (parts) {
        parts[SQFFD__SQ_PART_LU] = lu; parts[SQFFD__SQ_PART_LV] = lv; parts[SQFFD__SQ_PART_LA] = la;
        parts[SQFFD__SQ_PART_LG] = lg; parts[SQFFD__SQ_PART_LH] = lh;
        parts[SQFFD__SQ_PART_FU] = frac_u[0]; parts[SQFFD__SQ_PART_FU + 1] = frac_u[1];
        parts[SQFFD__SQ_PART_FG] = frac_g[0]; parts[SQFFD__SQ_PART_FG + 1] = frac_g[1];
    }
    return lf;
}

static double sqffd__sq_log_f_at(const sqffd_superquadric *sq, const double u[3])
{
    double log_size[3];
    log_size[0] = log(sq->size[0]); log_size[1] = log(sq->size[1]); log_size[2] = log(sq->size[2]);
    return sqffd__sq_log_f(u, log_size, sq->shape[0], sq->shape[1], NULL);
}

SQFFD_DEF double sqffd_sq_inside_outside(const sqffd_superquadric *sq, const double point[3])
{
    double u[3];
    SQFFD_ASSERT(sq && point);
    sqffd__sq_untapered(sq, point, u);
    return exp(sqffd__sq_log_f_at(sq, u));
}

SQFFD_DEF double sqffd_sq_radial_distance(const sqffd_superquadric *sq, const double point[3])
{
    double u[3], lf;
    SQFFD_ASSERT(sq && point);
    sqffd__sq_untapered(sq, point, u);
    lf = sqffd__sq_log_f_at(sq, u);
    return sqrt(sqffd__dot3(u, u)) * fabs(1.0 - exp(-0.5 * sq->shape[0] * lf));
}

/* Untapered local surface point at (eta, omega). */
static void sqffd__sq_local_point(const sqffd_superquadric *sq, double eta, double omega, double s[3])
{
    double ce = sqffd__sq_spow(cos(eta), sq->shape[0]);
    s[0] = sq->size[0] * ce * sqffd__sq_spow(cos(omega), sq->shape[1]);
    s[1] = sq->size[1] * ce * sqffd__sq_spow(sin(omega), sq->shape[1]);
    s[2] = sq->size[2] * sqffd__sq_spow(sin(eta), sq->shape[0]);
}

/* Apply the tapering to an untapered local point (in place). */
static void sqffd__sq_taper(const sqffd_superquadric *sq, double s[3])
{
    double f[2];
    sqffd__sq_taper_factors(sq, s[2], f);
    s[0] *= f[0];
    s[1] *= f[1];
}

SQFFD_DEF void sqffd_sq_point(const sqffd_superquadric *sq, double eta, double omega, double point[3], double normal[3])
{
    double s[3], q[3];
    SQFFD_ASSERT(sq && point);
    sqffd__sq_local_point(sq, eta, omega, s);
    q[0] = s[0]; q[1] = s[1]; q[2] = s[2];
    sqffd__sq_taper(sq, q);
    sqffd__mat3_vec(sq->rotation, q, point);
    point[0] += sq->center[0]; point[1] += sq->center[1]; point[2] += sq->center[2];
    if (normal) {
        /* Untapered normal: the direction of grad F, which on the surface is
           (C^(2-e1) C^(2-e2) / a1, C^(2-e1) S^(2-e2) / a2, S^(2-e1) / a3);
           the exponents are positive, so it is finite at the poles too.
           The tapering X = fx x, Y = fy y has the Jacobian
           J = [fx 0 Kx x/a3; 0 fy Ky y/a3; 0 0 1]; normals map by J^-T,
           here scaled by fx fy > 0 to avoid divisions. */
        double e1 = sq->shape[0], e2 = sq->shape[1], f[2], n[3], len;
        double ce = sqffd__sq_spow(cos(eta), 2.0 - e1);
        n[0] = ce * sqffd__sq_spow(cos(omega), 2.0 - e2) / sq->size[0];
        n[1] = ce * sqffd__sq_spow(sin(omega), 2.0 - e2) / sq->size[1];
        n[2] = sqffd__sq_spow(sin(eta), 2.0 - e1) / sq->size[2];
        sqffd__sq_taper_factors(sq, s[2], f);
        q[0] = n[0] * f[1];
        q[1] = n[1] * f[0];
        q[2] = n[2] * f[0] * f[1] - (sq->taper[0] * s[0] * n[0] * f[1] + sq->taper[1] * s[1] * n[1] * f[0]) / sq->size[2];
        sqffd__mat3_vec(sq->rotation, q, normal);
        len = sqrt(sqffd__dot3(normal, normal));
        if (len > 0.0) { normal[0] /= len; normal[1] /= len; normal[2] /= len; }
    }
}

SQFFD_DEF sqffd_result sqffd_sq_sample_grid(const sqffd_superquadric *sq, int n_eta, int n_omega, double *points, double *normals)
{
    int i, j;
    if (!sq || !points || n_eta < 2 || n_omega < 1) return SQFFD_ERROR_INVALID_ARGUMENT;
    if ((size_t)n_eta > ((size_t)-1 / 3 / sizeof(double)) / (size_t)n_omega) return SQFFD_ERROR_TOO_LARGE;
    for (i = 0; i < n_eta; i++) {
        double eta = -0.5 * SQFFD__SQ_PI + SQFFD__SQ_PI * (double)i / (double)(n_eta - 1);
        for (j = 0; j < n_omega; j++) {
            double omega = -SQFFD__SQ_PI + 2.0 * SQFFD__SQ_PI * (double)j / (double)n_omega;
            size_t k = 3 * ((size_t)i * (size_t)n_omega + (size_t)j);
            sqffd_sq_point(sq, eta, omega, points + k, normals ? normals + k : NULL);
        }
    }
    return SQFFD_OK;
}

/* ---- near-equal-distance sampling ----
   Pilu & Fisher step the parameter by spacing / |dP/dt|; near the points
   where the signed powers are singular (|dP/dt| infinite for e < 1) that
   formula needs special cases, so each step here instead solves for the
   parameter increment whose chord is `spacing` (bisection on the logarithm
   of the increment: the increments span many orders of magnitude when e is
   small). Rows of constant eta are spaced by the largest chord over eight
   meridians, then each row is walked in omega, one quadrant at a time (a
   quadrant is a convex arc, so its chord grows monotonically). */

/* Chord between parameters t0 and t1: along omega at eta = fixed, or along
   eta as the largest over eight meridians (fixed unused). Tapered local
   coordinates: the rigid motion does not change lengths. */
static double sqffd__sq_chord(const sqffd_superquadric *sq, int along_omega, double fixed, double t0, double t1)
{
    double p0[3], p1[3], best = 0.0;
    int k;
    if (along_omega) {
        sqffd__sq_local_point(sq, fixed, t0, p0); sqffd__sq_taper(sq, p0);
        sqffd__sq_local_point(sq, fixed, t1, p1); sqffd__sq_taper(sq, p1);
        return sqrt(sqffd__dist2_3(p0, p1));
    }
    for (k = 0; k < 8; k++) {
        double omega = -SQFFD__SQ_PI + 0.25 * SQFFD__SQ_PI * (double)k, d;
        sqffd__sq_local_point(sq, t0, omega, p0); sqffd__sq_taper(sq, p0);
        sqffd__sq_local_point(sq, t1, omega, p1); sqffd__sq_taper(sq, p1);
        d = sqffd__dist2_3(p0, p1);
        if (d > best) best = d;
    }
    return sqrt(best);
}

/* Next parameter after t on the arc towards t_end (t < t_end): a chord of
   about `spacing`; the last two steps share the remainder evenly; t_end when
   the remainder is at most one spacing. */
static double sqffd__sq_next(const sqffd_superquadric *sq, int along_omega, double fixed, double t, double t_end,
                             double spacing)
{
    double rest = sqffd__sq_chord(sq, along_omega, fixed, t, t_end), target = spacing;
    double lo, hi = t_end - t, next;
    int it;
    if (rest <= spacing) return t_end;
    if (rest < 2.0 * spacing) target = 0.5 * rest;
    lo = hi * 1e-18;
    for (it = 0; it < 40; it++) { /* geometric bisection: chord(lo) < target <= chord(hi) */
        double mid = sqrt(lo * hi), c = sqffd__sq_chord(sq, along_omega, fixed, t, t + mid);
        if (c < target) lo = mid; else hi = mid;
        if (hi < lo * 1.0001) break;
    }
    next = t + hi;
    return next > t ? next : t_end; /* no representable progress: finish the arc */
}

/* Emit the samples of one row (constant eta). Returns the new count. */
static size_t sqffd__sq_sample_row(const sqffd_superquadric *sq, double eta, double spacing, double *points,
                                   size_t capacity, size_t count)
{
    double ring = 0.0;
    int quadrant;
    for (quadrant = 0; quadrant < 4; quadrant++) {
        double t0 = -SQFFD__SQ_PI + 0.5 * SQFFD__SQ_PI * (double)quadrant;
        ring += sqffd__sq_chord(sq, 1, eta, t0, t0 + 0.5 * SQFFD__SQ_PI);
    }
    for (quadrant = 0; quadrant < 4; quadrant++) {
        double t = -SQFFD__SQ_PI + 0.5 * SQFFD__SQ_PI * (double)quadrant, t_end = t + 0.5 * SQFFD__SQ_PI;
        while (t < t_end) {
            if (count < capacity) sqffd_sq_point(sq, eta, t, points + 3 * count, NULL);
            count++;
            if (ring < spacing) return count; /* a ring smaller than the spacing (a pole): one point */
            t = sqffd__sq_next(sq, 1, eta, t, t_end, spacing);
        }
    }
    return count;
}

/* Rough area bound of the tapered shape: the box around it. */
static double sqffd__sq_box_area(const sqffd_superquadric *sq)
{
    double x = sq->size[0] * (1.0 + fabs(sq->taper[0])), y = sq->size[1] * (1.0 + fabs(sq->taper[1]));
    double z = sq->size[2];
    return 8.0 * (x * y + y * z + z * x);
}

static int sqffd__sq_valid(const sqffd_superquadric *sq)
{
    int k;
    for (k = 0; k < 3; k++)
        if (!(sq->size[k] > 0.0) || !isfinite(sq->size[k]) || !isfinite(sq->center[k])) return 0;
    for (k = 0; k < 2; k++)
        if (!(sq->shape[k] > 0.0) || !(sq->shape[k] <= 4.0) || !(fabs(sq->taper[k]) < 1.0)) return 0;
    for (k = 0; k < 9; k++)
        if (!isfinite(sq->rotation[k])) return 0;
    return 1;
}

SQFFD_DEF size_t sqffd_sq_sample_uniform(const sqffd_superquadric *sq, double spacing, double *points, size_t capacity)
{
    size_t count = 0;
    int half;
    if (!sq || !sqffd__sq_valid(sq) || !(spacing > 0.0) || !isfinite(spacing)) return 0;
    if (!points) capacity = 0;
    /* refuse samplings beyond ~1e8 points rather than run for hours */
    if (sqffd__sq_box_area(sq) / (spacing * spacing) > 1e8) return 0;
    for (half = 0; half < 2; half++) { /* eta in [-pi/2, 0), then [0, pi/2) */
        double t = -0.5 * SQFFD__SQ_PI + 0.5 * SQFFD__SQ_PI * (double)half, t_end = t + 0.5 * SQFFD__SQ_PI;
        while (t < t_end) {
            count = sqffd__sq_sample_row(sq, t, spacing, points, capacity, count);
            t = sqffd__sq_next(sq, 0, 0.0, t, t_end, spacing);
        }
    }
    return sqffd__sq_sample_row(sq, 0.5 * SQFFD__SQ_PI, spacing, points, capacity, count);
}

/* ---- volume and IoU ----
   Cross-section of the untapered shape at height z = a3 t:
   area a1 a2 e2 B(e2/2, e2/2) (1 - |t|^(2/e1))^e1, and
   int_0^1 t^k (1 - t^(2/e1))^e1 dt = (e1/2) B((k+1) e1/2, e1 + 1).
   Tapering scales the section by (1 + Kx t)(1 + Ky t); the odd term
   vanishes by symmetry, so
   V = a1 a2 a3 e1 e2 B(e2/2, e2/2) [B(e1/2, e1+1) + Kx Ky B(3 e1/2, e1+1)]
   (B(e1/2, e1+1) = 2 B(e1/2+1, e1): the textbook form). */
static double sqffd__sq_beta(double x, double y)
{
    return tgamma(x) * tgamma(y) / tgamma(x + y);
}

SQFFD_DEF double sqffd_sq_volume(const sqffd_superquadric *sq)
{
    double e1, e2;
    SQFFD_ASSERT(sq);
    e1 = sq->shape[0]; e2 = sq->shape[1];
    return sq->size[0] * sq->size[1] * sq->size[2] * e1 * e2 * sqffd__sq_beta(0.5 * e2, 0.5 * e2) *
           (sqffd__sq_beta(0.5 * e1, e1 + 1.0) + sq->taper[0] * sq->taper[1] * sqffd__sq_beta(1.5 * e1, e1 + 1.0));
}

/* World axis-aligned box around the tapered shape. */
static void sqffd__sq_bounds(const sqffd_superquadric *sq, double lo[3], double hi[3])
{
    double ext[3];
    int i;
    ext[0] = sq->size[0] * (1.0 + fabs(sq->taper[0]));
    ext[1] = sq->size[1] * (1.0 + fabs(sq->taper[1]));
    ext[2] = sq->size[2];
    for (i = 0; i < 3; i++) {
        double h = fabs(sq->rotation[3 * i]) * ext[0] + fabs(sq->rotation[3 * i + 1]) * ext[1] +
                   fabs(sq->rotation[3 * i + 2]) * ext[2];
        lo[i] = sq->center[i] - h;
        hi[i] = sq->center[i] + h;
    }
}

/* Inside test at a world point, cheap rejection by the local box first. */
static int sqffd__sq_contains(const sqffd_superquadric *sq, const double p[3])
{
    double q[3], f[2], x, y, z, e1 = sq->shape[0], e2 = sq->shape[1];
    sqffd__sq_to_local(sq, p, q);
    z = fabs(q[2]) / sq->size[2];
    if (z > 1.0) return 0;
    sqffd__sq_taper_factors(sq, q[2], f);
    x = fabs(q[0]) / (f[0] * sq->size[0]);
    y = fabs(q[1]) / (f[1] * sq->size[1]);
    if (x > 1.0 || y > 1.0) return 0;
    return pow(pow(x, 2.0 / e2) + pow(y, 2.0 / e2), e2 / e1) + pow(z, 2.0 / e1) <= 1.0;
}

SQFFD_DEF double sqffd_sq_iou(const sqffd_superquadric *a, const sqffd_superquadric *b, int resolution)
{
    double lo[3], hi[3], lo_b[3], hi_b[3], step[3];
    size_t in_a = 0, in_b = 0, in_both = 0;
    int i, j, k;
    if (!a || !b || resolution < 1 || !sqffd__sq_valid(a) || !sqffd__sq_valid(b)) return -1.0;
    sqffd__sq_bounds(a, lo, hi);
    sqffd__sq_bounds(b, lo_b, hi_b);
    for (i = 0; i < 3; i++) {
        if (lo_b[i] < lo[i]) lo[i] = lo_b[i];
        if (hi_b[i] > hi[i]) hi[i] = hi_b[i];
        step[i] = (hi[i] - lo[i]) / (double)resolution;
    }
    for (i = 0; i < resolution; i++)
        for (j = 0; j < resolution; j++)
            for (k = 0; k < resolution; k++) {
                double p[3];
                int ia, ib;
                p[0] = lo[0] + ((double)i + 0.5) * step[0];
                p[1] = lo[1] + ((double)j + 0.5) * step[1];
                p[2] = lo[2] + ((double)k + 0.5) * step[2];
                ia = sqffd__sq_contains(a, p);
                ib = sqffd__sq_contains(b, p);
                in_a += (size_t)ia;
                in_b += (size_t)ib;
                in_both += (size_t)(ia & ib);
            }
    if (in_a + in_b == 0) return 0.0;
    return (double)in_both / (double)(in_a + in_b - in_both);
}

/* ---- fit ------------------------------------------------------------------
   The data are centred on their centroid and scaled to unit RMS radius; the
   fit runs in those coordinates and is mapped back at the end.
   Parameters (SQFFD__SQ_P_*): a rotation increment w around the current
   rotation (R_new = R exp([w]x), derivatives at w = 0), the centre, the log
   sizes (sizes stay positive), e1, e2, Kx, Ky (last, so the 11-parameter
   model is the leading block). */
#define SQFFD__SQ_P_ROT 0
#define SQFFD__SQ_P_CENTER 3
#define SQFFD__SQ_P_LOGSIZE 6
#define SQFFD__SQ_P_E1 9
#define SQFFD__SQ_P_E2 10
#define SQFFD__SQ_P_TAPER 11
#define SQFFD__SQ_NPAR 13
/* TEMP knobs */
#ifndef SQFFD__SQ_SCREEN
#define SQFFD__SQ_SCREEN 64   /* subsample every start is screened on */
#endif
#ifndef SQFFD__SQ_POLISH
#define SQFFD__SQ_POLISH 384   /* subsample the best starts converge on */
#endif
#ifndef SQFFD__SQ_START_ITERATIONS
#define SQFFD__SQ_START_ITERATIONS 6
#endif
#ifndef SQFFD__SQ_KEEP
#define SQFFD__SQ_KEEP 2
#endif
#ifndef SQFFD__SQ_CLOSE_RATIO
#define SQFFD__SQ_CLOSE_RATIO 0.7
#endif
#define SQFFD__SQ_HISTOGRAM 512   /* bins per axis for the robust initial sizes */
#define SQFFD__SQ_SIZE_QUANTILE 0.95
#define SQFFD__SQ_BOX_MARGIN 1.25 /* the fit stays within the data's box enlarged this much */
#define SQFFD__SQ_MIN_STEP 1e-10   /* parameter steps below this (normalised units) end the iteration */
#define SQFFD__SQ_EXACT 1e-24      /* mean squared residual counted as an exact fit */
#define SQFFD__SQ_FLAT_RATIO 1e-10 /* covariance eigenvalue ratio below which data are flat */

/* Per-evaluation constants of the residual. */
typedef struct sqffd__sq_eval {
    const sqffd_superquadric *sq;
    double log_size[3];
    double volume_scale; /* sqrt(a1 a2 a3) */
    int cost;
} sqffd__sq_eval;

static void sqffd__sq_eval_init(sqffd__sq_eval *ev, const sqffd_superquadric *sq, int cost)
{
    int k;
    ev->sq = sq;
    for (k = 0; k < 3; k++) ev->log_size[k] = log(sq->size[k]);
    ev->volume_scale = sqrt(sq->size[0] * sq->size[1] * sq->size[2]);
    ev->cost = cost;
}

/* Residual of one point, and (grad not NULL) its derivatives with respect to
   the 13 parameters. Chain: world p -> tapered local q = R^T (p - c) ->
   untapered u = (q0 / fx, q1 / fy, q2) -> ln F(u) -> residual. */
static double sqffd__sq_residual(const sqffd__sq_eval *ev, const double p[3], double *grad)
{
    const sqffd_superquadric *sq = ev->sq;
    double e1 = sq->shape[0], e2 = sq->shape[1], a3 = sq->size[2];
    double q[3], f[2], u[3], parts[SQFFD__SQ_PARTS], lf, r, kf, extra_e1, extra_size, t[3], gq[3], h[3];
    int k, clamped[2];
    sqffd__sq_to_local(sq, p, q);
    for (k = 0; k < 2; k++) {
        f[k] = 1.0 + sq->taper[k] * q[2] / a3;
        clamped[k] = f[k] < SQFFD__SQ_MIN_TAPER;
        if (clamped[k]) f[k] = SQFFD__SQ_MIN_TAPER;
        u[k] = q[k] / f[k];
    }
    u[2] = q[2];
    lf = sqffd__sq_log_f(u, ev->log_size, e1, e2, grad ? parts : NULL);
    if (ev->cost == SQFFD_SQ_COST_SOLINA) { /* sqrt(a1 a2 a3) (F^e1 - 1) */
        double pw = exp(e1 * lf < 700.0 ? e1 * lf : 700.0);
        r = ev->volume_scale * (pw - 1.0);
        if (!grad) return r;
        kf = ev->volume_scale * pw * e1; /* d r / d ln F */
        extra_e1 = ev->volume_scale * pw * lf;
        extra_size = 0.5 * r; /* from d sqrt(a1 a2 a3) / d ln a_i */
        t[0] = t[1] = t[2] = 0.0;
    } else { /* |u| (1 - F^(-e1/2)) */
        double rho = sqrt(sqffd__dot3(u, u)), qm = exp(-0.5 * e1 * lf);
        r = rho * (1.0 - qm);
        if (!grad) return r;
        kf = 0.5 * rho * qm * e1;
        extra_e1 = 0.5 * rho * qm * lf;
        extra_size = 0.0;
        for (k = 0; k < 3; k++) t[k] = rho > 0.0 ? (1.0 - qm) * u[k] / rho : 0.0;
    }
    /* h_k = d ln F / d ln|u_k| */
    h[0] = (2.0 / e1) * parts[SQFFD__SQ_PART_FG] * parts[SQFFD__SQ_PART_FU];
    h[1] = (2.0 / e1) * parts[SQFFD__SQ_PART_FG] * parts[SQFFD__SQ_PART_FU + 1];
    h[2] = (2.0 / e1) * parts[SQFFD__SQ_PART_FG + 1];
    for (k = 0; k < 3; k++) /* t = d r / d u; h_k / u_k -> 0 as u_k -> 0 (exponents 2/e > 1) */
        t[k] += fabs(u[k]) > SQFFD__SQ_TINY ? kf * h[k] / u[k] : 0.0;
    /* through the tapering: dx/dX = 1/fx, dx/dZ = -x Kx / (a3 fx),
       dx/dKx = -x Z / (a3 fx), dx/d ln a3 = x Kx Z / (a3 fx) */
    gq[0] = t[0] / f[0];
    gq[1] = t[1] / f[1];
    gq[2] = t[2];
    grad[SQFFD__SQ_P_LOGSIZE] = grad[SQFFD__SQ_P_LOGSIZE + 1] = grad[SQFFD__SQ_P_LOGSIZE + 2] = 0.0;
    for (k = 0; k < 2; k++) {
        double s = clamped[k] ? 0.0 : t[k] * u[k] / (a3 * f[k]);
        gq[2] -= s * sq->taper[k];
        grad[SQFFD__SQ_P_TAPER + k] = -s * q[2];
        grad[SQFFD__SQ_P_LOGSIZE + 2] += s * sq->taper[k] * q[2];
    }
    sqffd__cross3(gq, q, grad + SQFFD__SQ_P_ROT); /* dq/dw = [q]x */
    sqffd__mat3_vec(sq->rotation, gq, grad + SQFFD__SQ_P_CENTER);
    for (k = 0; k < 3; k++) {
        grad[SQFFD__SQ_P_CENTER + k] = -grad[SQFFD__SQ_P_CENTER + k];
        grad[SQFFD__SQ_P_LOGSIZE + k] += extra_size - kf * h[k];
    }
    grad[SQFFD__SQ_P_E1] = extra_e1 - kf / e1 * (parts[SQFFD__SQ_PART_FG] * parts[SQFFD__SQ_PART_LG] +
                                                  parts[SQFFD__SQ_PART_FG + 1] * parts[SQFFD__SQ_PART_LH]);
    grad[SQFFD__SQ_P_E2] = kf / e1 * parts[SQFFD__SQ_PART_FG] *
                           (parts[SQFFD__SQ_PART_LA] - parts[SQFFD__SQ_PART_FU] * parts[SQFFD__SQ_PART_LU] -
                            parts[SQFFD__SQ_PART_FU + 1] * parts[SQFFD__SQ_PART_LV]);
    return r;
}

/* State shared by the stages of one fit. */
typedef struct sqffd__sq_fit {
    const sqffd_sq_fit_options *opt;
    int npar;             /* 13, or 11 without tapering */
    int cost;             /* residual in use (sqffd_sq_cost) */
    double box_volume;
    double box_mid[3];    /* normalised data box: centre and half-extents */
    double box_half[3];
    double size_min;
    int iterations;       /* optimiser iterations so far */
    sqffd_result status;  /* SQFFD_ERROR_CANCELLED once the callback asked */
} sqffd__sq_fit;

/* Weighted cost sum w r^2 over m points (weights NULL = 1); with jtj (npar x
   npar, upper triangle) and jtr also the Gauss-Newton normal equations. */
static double sqffd__sq_accumulate(const sqffd__sq_fit *fit, const sqffd_superquadric *sq, const double *pts,
                                   const double *weights, size_t m, double *jtj, double *jtr)
{
    sqffd__sq_eval ev;
    double cost = 0.0, g[SQFFD__SQ_NPAR];
    int np = fit->npar, i, j;
    size_t k;
    sqffd__sq_eval_init(&ev, sq, fit->cost);
    if (jtj) {
        memset(jtj, 0, sizeof(double) * SQFFD__SQ_NPAR * SQFFD__SQ_NPAR);
        memset(jtr, 0, sizeof(double) * SQFFD__SQ_NPAR);
    }
    for (k = 0; k < m; k++) {
        double w = weights ? weights[k] : 1.0, r;
        if (w <= 0.0) continue;
        r = sqffd__sq_residual(&ev, pts + 3 * k, jtj ? g : NULL);
        cost += w * r * r;
        if (!jtj) continue;
        for (i = 0; i < np; i++) {
            double wg = w * g[i];
            jtr[i] += wg * r;
            for (j = i; j < np; j++) jtj[i * SQFFD__SQ_NPAR + j] += wg * g[j];
        }
    }
    return cost;
}

/* R <- R exp([w]x) (Rodrigues). */
static void sqffd__sq_rotate(double rot[9], const double w[3])
{
    double th2 = sqffd__dot3(w, w), th = sqrt(th2), s, c, e[9], out[9];
    int i, j;
    if (th < 1e-8) { s = 1.0 - th2 / 6.0; c = 0.5 - th2 / 24.0; }
    else { s = sin(th) / th; c = (1.0 - cos(th)) / th2; }
    /* exp = I + s [w]x + c [w]x^2, [w]x^2 = w w^T - |w|^2 I */
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) e[3 * i + j] = c * w[i] * w[j] + (i == j ? 1.0 - c * th2 : 0.0);
    e[1] -= s * w[2]; e[2] += s * w[1];
    e[3] += s * w[2]; e[5] -= s * w[0];
    e[6] -= s * w[1]; e[7] += s * w[0];
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++)
            out[3 * i + j] = rot[3 * i] * e[j] + rot[3 * i + 1] * e[3 + j] + rot[3 * i + 2] * e[6 + j];
    memcpy(rot, out, sizeof out);
}

/* Clamp into the feasible set: e and K within their bounds, the centre in
   the data's box, each size at most the margin times the box's half-extent
   along that local axis (this is what stops the runaway on non-superquadric
   data). */
static void sqffd__sq_project(const sqffd__sq_fit *fit, sqffd_superquadric *sq)
{
    const sqffd_sq_fit_options *o = fit->opt;
    int k;
    for (k = 0; k < 2; k++) {
        if (sq->shape[k] < o->shape_min) sq->shape[k] = o->shape_min;
        if (sq->shape[k] > o->shape_max) sq->shape[k] = o->shape_max;
        if (fit->npar < SQFFD__SQ_NPAR) sq->taper[k] = 0.0;
        if (sq->taper[k] > o->taper_max) sq->taper[k] = o->taper_max;
        if (sq->taper[k] < -o->taper_max) sq->taper[k] = -o->taper_max;
    }
    for (k = 0; k < 3; k++) {
        double lo = fit->box_mid[k] - fit->box_half[k], hi = fit->box_mid[k] + fit->box_half[k];
        double reach = SQFFD__SQ_BOX_MARGIN * (fabs(sq->rotation[k]) * fit->box_half[0] +
                                               fabs(sq->rotation[3 + k]) * fit->box_half[1] +
                                               fabs(sq->rotation[6 + k]) * fit->box_half[2]);
        if (sq->center[k] < lo) sq->center[k] = lo;
        if (sq->center[k] > hi) sq->center[k] = hi;
        if (reach < fit->size_min) reach = fit->size_min;
        if (sq->size[k] > reach) sq->size[k] = reach;
        if (sq->size[k] < fit->size_min) sq->size[k] = fit->size_min;
    }
}

/* sq <- project(sq + delta) */
static void sqffd__sq_step(const sqffd__sq_fit *fit, sqffd_superquadric *sq, const double *delta)
{
    int k;
    sqffd__sq_rotate(sq->rotation, delta + SQFFD__SQ_P_ROT);
    for (k = 0; k < 3; k++) {
        sq->center[k] += delta[SQFFD__SQ_P_CENTER + k];
        sq->size[k] *= exp(delta[SQFFD__SQ_P_LOGSIZE + k]);
    }
    sq->shape[0] += delta[SQFFD__SQ_P_E1];
    sq->shape[1] += delta[SQFFD__SQ_P_E2];
    if (fit->npar == SQFFD__SQ_NPAR) {
        sq->taper[0] += delta[SQFFD__SQ_P_TAPER];
        sq->taper[1] += delta[SQFFD__SQ_P_TAPER + 1];
    }
    sqffd__sq_project(fit, sq);
}

/* One optimiser iteration done: count it, report it, honour a cancel. */
static int sqffd__sq_tick(sqffd__sq_fit *fit, double cost)
{
    fit->iterations++;
    if (fit->opt->progress &&
        fit->opt->progress(fit->opt->progress_user, SQFFD_STAGE_SUPERQUADRIC, fit->iterations, cost)) {
        fit->status = SQFFD_ERROR_CANCELLED;
        return 0;
    }
    return 1;
}

/* Levenberg-Marquardt (Marquardt's diagonal scaling) with projection onto
   the bounds. Returns non-zero when converged; *cost gets the final cost. */
static int sqffd__sq_lm(sqffd__sq_fit *fit, sqffd_superquadric *sq, const double *pts, const double *weights,
                        size_t m, int max_iterations, double *cost)
{
    double jtj[SQFFD__SQ_NPAR * SQFFD__SQ_NPAR], jtr[SQFFD__SQ_NPAR];
    double tjtj[SQFFD__SQ_NPAR * SQFFD__SQ_NPAR], tjtr[SQFFD__SQ_NPAR];
    double a[SQFFD__SQ_NPAR * SQFFD__SQ_NPAR], delta[SQFFD__SQ_NPAR], lambda = 1e-3, step;
    int np = fit->npar, it, i, j;
    double c0 = sqffd__sq_accumulate(fit, sq, pts, weights, m, jtj, jtr);
    for (it = 0; it < max_iterations; it++) {
        sqffd_superquadric trial = *sq;
        double c1;
        for (i = 0; i < np; i++) {
            for (j = 0; j < np; j++)
                a[i * np + j] = i <= j ? jtj[i * SQFFD__SQ_NPAR + j] : jtj[j * SQFFD__SQ_NPAR + i];
            a[i * np + i] += lambda * jtj[i * SQFFD__SQ_NPAR + i] + 1e-12 * (1.0 + c0);
            delta[i] = -jtr[i];
        }
        for (i = np; i < SQFFD__SQ_NPAR; i++) delta[i] = 0.0;
        if (sqffd_cholesky_factor(a, np) != SQFFD_OK) {
            lambda *= 10.0;
            if (!sqffd__sq_tick(fit, c0)) break;
            continue;
        }
        sqffd_cholesky_solve(a, np, delta);
        step = 0.0;
        for (i = 0; i < np; i++) step = fabs(delta[i]) > step ? fabs(delta[i]) : step;
        sqffd__sq_step(fit, &trial, delta);
        c1 = sqffd__sq_accumulate(fit, &trial, pts, weights, m, tjtj, tjtr);
        if (!sqffd__sq_tick(fit, c1 < c0 ? c1 : c0)) break;
        if (c1 < c0) {
            double gain = (c0 - c1) / c0;
            *sq = trial;
            memcpy(jtj, tjtj, sizeof jtj);
            memcpy(jtr, tjtr, sizeof jtr);
            c0 = c1;
            lambda = lambda * 0.2 > 1e-9 ? lambda * 0.2 : 1e-9;
            if (gain < fit->opt->tolerance || step < SQFFD__SQ_MIN_STEP || c0 < SQFFD__SQ_EXACT * (double)m) {
                *cost = c0;
                return 1;
            }
        } else {
            lambda *= 10.0;
            /* no descent even along a tiny step: a (constrained) minimum */
            if (lambda > 1e6 || step < SQFFD__SQ_MIN_STEP) { *cost = c0; return 1; }
        }
    }
    *cost = c0;
    return 0;
}

/* Workspace blocks of one fit. */
typedef struct sqffd__sq_work {
    double *points;  /* 3n normalised points */
    double *weights; /* n robust weights (robust mode only) */
    double *screen;  /* 3 * min(n, SQFFD__SQ_SCREEN) subsample */
    double *polish;  /* 3 * min(n, SQFFD__SQ_POLISH) subsample */
    double *hist;    /* 3 * SQFFD__SQ_HISTOGRAM */
    void *ncg;       /* CG optimiser scratch */
    size_t ncg_size;
} sqffd__sq_work;

static void sqffd__sq_fit_layout(sqffd__arena *a, size_t n, const sqffd_sq_fit_options *o, sqffd__sq_work *w)
{
    w->points = (double *)sqffd__arena_take(a, n, 3 * sizeof(double));
    w->weights = o->robust ? (double *)sqffd__arena_take(a, n, sizeof(double)) : NULL;
    w->screen = (double *)sqffd__arena_take(a, n < SQFFD__SQ_SCREEN ? n : SQFFD__SQ_SCREEN, 3 * sizeof(double));
    w->polish = (double *)sqffd__arena_take(a, n < SQFFD__SQ_POLISH ? n : SQFFD__SQ_POLISH, 3 * sizeof(double));
    w->hist = (double *)sqffd__arena_take(a, 3 * SQFFD__SQ_HISTOGRAM, sizeof(double));
    w->ncg_size = o->optimizer == SQFFD_SQ_OPTIMIZER_CG ? sqffd_ncg_workspace_size(SQFFD__SQ_NPAR) : 0;
    w->ncg = w->ncg_size ? sqffd__arena_take(a, w->ncg_size, 1) : NULL;
}

SQFFD_DEF sqffd_sq_fit_options sqffd_sq_fit_options_default(void)
{
    sqffd_sq_fit_options o;
    memset(&o, 0, sizeof o);
    o.cost = SQFFD_SQ_COST_SOLINA;
    o.optimizer = SQFFD_SQ_OPTIMIZER_LM;
    o.taper = 1;
    o.shape_min = 0.1;
    o.shape_max = 1.9;
    o.taper_max = 0.95;
    o.max_iterations = 100;
    o.tolerance = 1e-7;
    o.robust = 0;
    o.robust_rounds = 6;
    o.progress = NULL;
    o.progress_user = NULL;
    return o;
}

static int sqffd__sq_options_valid(const sqffd_sq_fit_options *o)
{
    return (o->cost == SQFFD_SQ_COST_SOLINA || o->cost == SQFFD_SQ_COST_RADIAL) &&
           (o->optimizer == SQFFD_SQ_OPTIMIZER_LM || o->optimizer == SQFFD_SQ_OPTIMIZER_CG) &&
           o->shape_min >= 0.01 && o->shape_min <= o->shape_max && o->shape_max <= 4.0 &&
           o->taper_max >= 0.0 && o->taper_max < 1.0 && o->max_iterations >= 1 &&
           o->tolerance >= 0.0 && isfinite(o->tolerance) && (!o->robust || o->robust_rounds >= 1);
}

SQFFD_DEF size_t sqffd_sq_fit_workspace_size(size_t n, const sqffd_sq_fit_options *options)
{
    sqffd_sq_fit_options defaults = sqffd_sq_fit_options_default();
    sqffd__arena a;
    sqffd__sq_work w;
    sqffd__arena_init(&a, NULL, 0);
    sqffd__sq_fit_layout(&a, n, options ? options : &defaults, &w);
    return sqffd__arena_required(&a);
}

/* Approximate surface area (Thomsen's ellipsoid formula): only the density
   of the inlier model of the robust mode needs it. */
static double sqffd__sq_area(const sqffd_superquadric *sq)
{
    const double p = 1.6075;
    double x = pow(sq->size[0], p), y = pow(sq->size[1], p), z = pow(sq->size[2], p);
    return 4.0 * SQFFD__SQ_PI * pow((x * y + y * z + z * x) / 3.0, 1.0 / p);
}

/* Robust mode, one EM step on the mixture "Gaussian in the radial distance
   around the surface (its density spread over the area) + uniform over the
   data box": E-step (weights from the current sigma^2 and inlier prior),
   then the mixture's M-step (new sigma^2 and prior). Returns the negative
   log-likelihood of the data before the update. */
typedef struct sqffd__sq_mixture {
    double sigma2; /* variance of the inlier distances; 0 = not yet estimated */
    double prior;  /* inlier fraction */
} sqffd__sq_mixture;

static double sqffd__sq_reweight(const sqffd_superquadric *sq, const double *pts, size_t m, double box_volume,
                                 double *weights, sqffd__sq_mixture *mix)
{
    double norm, outlier, sum_w = 0.0, sum_wd2 = 0.0, nll = 0.0;
    sqffd__sq_eval ev;
    size_t k;
    sqffd__sq_eval_init(&ev, sq, SQFFD_SQ_COST_RADIAL);
    if (!(mix->sigma2 > 0.0)) { /* first call: all points as inliers */
        for (k = 0; k < m; k++) {
            double d = sqffd__sq_residual(&ev, pts + 3 * k, NULL);
            sum_wd2 += d * d;
        }
        mix->sigma2 = sum_wd2 / (double)m;
        mix->prior = 0.5;
        sum_wd2 = 0.0;
    }
    if (mix->sigma2 < 1e-12) mix->sigma2 = 1e-12;
    norm = mix->prior / (sqrt(2.0 * SQFFD__SQ_PI * mix->sigma2) * sqffd__sq_area(sq));
    outlier = (1.0 - mix->prior) / box_volume;
    for (k = 0; k < m; k++) {
        double d = sqffd__sq_residual(&ev, pts + 3 * k, NULL), d2 = d * d;
        double inlier = norm * exp(-0.5 * d2 / mix->sigma2), w;
        w = inlier / (inlier + outlier);
        nll -= log(inlier + outlier);
        weights[k] = w;
        sum_w += w;
        sum_wd2 += w * d2;
    }
    mix->prior = sum_w / (double)m;
    if (mix->prior < 0.05) mix->prior = 0.05;
    if (mix->prior > 0.999) mix->prior = 0.999;
    if (sum_w > 0.0) mix->sigma2 = sum_wd2 / sum_w;
    return nll;
}

/* Weighted mean of the squared radial distance (weights NULL = 1). */
static double sqffd__sq_mean_d2(const sqffd_superquadric *sq, const double *pts, const double *weights, size_t m)
{
    double sum = 0.0, sum_w = 0.0;
    size_t k;
    for (k = 0; k < m; k++) {
        double w = weights ? weights[k] : 1.0, d = sqffd_sq_radial_distance(sq, pts + 3 * k);
        sum += w * d * d;
        sum_w += w;
    }
    return sum_w > 0.0 ? sum / sum_w : 0.0;
}

/* m of the n points, evenly spread over the input order (deterministic). */
static void sqffd__sq_subsample(const double *pts, size_t n, double *out, size_t m)
{
    size_t i;
    for (i = 0; i < m; i++) memcpy(out + 3 * i, pts + 3 * (i * n / m), 3 * sizeof(double));
}

/* Normalise: centroid, then scale to unit RMS radius (dividing by the
   largest offset first so that squares cannot overflow). Returns 0 when all
   points coincide. */
static int sqffd__sq_normalize(const double *points, size_t n, double *out, double centroid[3], double *scale)
{
    double big = 0.0, sum2 = 0.0;
    size_t i;
    int k;
    for (k = 0; k < 3; k++) {
        double s = 0.0;
        for (i = 0; i < n; i++) s += points[3 * i + (size_t)k];
        centroid[k] = s / (double)n;
    }
    for (i = 0; i < 3 * n; i++) {
        double d = fabs(points[i] - centroid[i % 3]);
        if (d > big) big = d;
    }
    if (!(big > 0.0) || !isfinite(big)) return 0;
    for (i = 0; i < 3 * n; i++) {
        out[i] = (points[i] - centroid[i % 3]) / big;
        sum2 += out[i] * out[i];
    }
    *scale = big * sqrt(sum2 / (double)n);
    for (i = 0; i < 3 * n; i++) out[i] *= big / *scale;
    return 1;
}

/* Robust initial half-sizes along the columns of axes: the
   SQFFD__SQ_SIZE_QUANTILE quantile of |projection| (a fixed histogram, no
   sort), divided by the quantile (exact for a sphere sampled evenly). */
static void sqffd__sq_initial_sizes(const double *pts, size_t n, const double axes[9], double *hist, double size[3])
{
    double top[3] = {0.0, 0.0, 0.0}, proj[3];
    size_t i;
    int k, b;
    memset(hist, 0, sizeof(double) * 3 * SQFFD__SQ_HISTOGRAM);
    for (i = 0; i < n; i++) {
        sqffd__mat3t_vec(axes, pts + 3 * i, proj);
        for (k = 0; k < 3; k++)
            if (fabs(proj[k]) > top[k]) top[k] = fabs(proj[k]);
    }
    for (i = 0; i < n; i++) {
        sqffd__mat3t_vec(axes, pts + 3 * i, proj);
        for (k = 0; k < 3; k++) {
            b = (int)(fabs(proj[k]) / top[k] * SQFFD__SQ_HISTOGRAM);
            hist[k * SQFFD__SQ_HISTOGRAM + (b < SQFFD__SQ_HISTOGRAM ? b : SQFFD__SQ_HISTOGRAM - 1)] += 1.0;
        }
    }
    for (k = 0; k < 3; k++) {
        double need = SQFFD__SQ_SIZE_QUANTILE * (double)n, seen = 0.0;
        for (b = 0; b < SQFFD__SQ_HISTOGRAM - 1; b++) {
            seen += hist[k * SQFFD__SQ_HISTOGRAM + b];
            if (seen >= need) break;
        }
        size[k] = top[k] * ((double)b + 1.0) / SQFFD__SQ_HISTOGRAM / SQFFD__SQ_SIZE_QUANTILE;
        if (size[k] > top[k]) size[k] = top[k];
    }
}

#ifndef SQFFD__SQ_ROBUST_COST
#define SQFFD__SQ_ROBUST_COST SQFFD_SQ_COST_RADIAL
#endif
#ifndef SQFFD__SQ_FULL_ROUNDS
#define SQFFD__SQ_FULL_ROUNDS 2
#endif
#ifndef SQFFD__SQ_ROUND_ITERATIONS
#define SQFFD__SQ_ROUND_ITERATIONS 5
#endif
/* Refine a candidate on m points: plain LM to convergence, or in robust mode
   `rounds` EM rounds (reweight, then a few weighted LM iterations of the
   mixture's residual, the radial distance). Returns the score candidates
   are compared by: the cost, or the mixture's negative log-likelihood. */
static double sqffd__sq_refine(sqffd__sq_fit *fit, sqffd_superquadric *sq, const double *pts, size_t m,
                               double *weights, sqffd__sq_mixture *mix, int rounds, int *converged)
{
    double cost = 0.0, nll = 0.0;
    int r;
    if (!fit->opt->robust) {
        *converged = sqffd__sq_lm(fit, sq, pts, NULL, m, fit->opt->max_iterations, &cost);
        return cost;
    }
    fit->cost = SQFFD__SQ_ROBUST_COST;
    for (r = 0; r < rounds && fit->status == SQFFD_OK; r++) {
        nll = sqffd__sq_reweight(sq, pts, m, fit->box_volume, weights, mix);
        *converged = sqffd__sq_lm(fit, sq, pts, weights, m, r + 1 < rounds ? SQFFD__SQ_ROUND_ITERATIONS : fit->opt->max_iterations, &cost);
    }
    nll = sqffd__sq_reweight(sq, pts, m, fit->box_volume, weights, mix);
    fit->cost = (int)fit->opt->cost;
    return nll;
}

SQFFD_DEF sqffd_result sqffd_sq_fit(const double *points, size_t n, const sqffd_sq_fit_options *options,
                                    sqffd_superquadric *sq, sqffd_sq_fit_report *report,
                                    void *workspace, size_t workspace_size)
{
#ifndef SQFFD__SQ_SEEDS
#define SQFFD__SQ_SEEDS {1.0, 1.0}, {1.7, 0.3}, {0.3, 1.7}
#endif
    static const double shape_seeds[][2] = {SQFFD__SQ_SEEDS};
    const int n_seeds = (int)(sizeof shape_seeds / sizeof shape_seeds[0]);
    sqffd_superquadric kept[SQFFD__SQ_KEEP];
    double kept_cost[SQFFD__SQ_KEEP];
    sqffd__sq_mixture kept_mix[SQFFD__SQ_KEEP], mix;
    int kept_id[SQFFD__SQ_KEEP], n_kept, basis;
    size_t m_screen = n < SQFFD__SQ_SCREEN ? n : SQFFD__SQ_SCREEN, m_polish = n < SQFFD__SQ_POLISH ? n : SQFFD__SQ_POLISH;
    sqffd_sq_fit_options defaults = sqffd_sq_fit_options_default();
    const sqffd_sq_fit_options *o = options ? options : &defaults;
    sqffd__arena arena;
    sqffd__sq_work w;
    sqffd__sq_fit fit;
    sqffd_superquadric best, cur;
    double centroid[3], scale, cov[9], values[3], axes[9], best_cost = 0.0, cost;
    size_t i;
    int k, s, best_start = 0, converged = 0;
    if (!points || !sq || !sqffd__sq_options_valid(o)) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (n < SQFFD_SQ_FIT_MIN_POINTS) return SQFFD_ERROR_TOO_FEW_POINTS;
    if (!workspace) return SQFFD_ERROR_WORKSPACE_TOO_SMALL;
    sqffd__arena_init(&arena, workspace, workspace_size);
    sqffd__sq_fit_layout(&arena, n, o, &w);
    if (arena.overflow) return SQFFD_ERROR_WORKSPACE_TOO_SMALL;
    for (i = 0; i < n; i++)
        if (!sqffd__finite3(points + 3 * i)) return SQFFD_ERROR_NON_FINITE;
    if (!sqffd__sq_normalize(points, n, w.points, centroid, &scale)) return SQFFD_ERROR_DEGENERATE;

    memset(&fit, 0, sizeof fit);
    fit.opt = o;
    fit.npar = o->taper ? SQFFD__SQ_NPAR : SQFFD__SQ_P_TAPER;
    fit.cost = (int)o->cost;
    fit.status = SQFFD_OK;
    fit.size_min = 1e-3;
    memset(cov, 0, sizeof cov);
    for (k = 0; k < 3; k++) fit.box_mid[k] = fit.box_half[k] = w.points[k];
    for (i = 0; i < n; i++) {
        const double *p = w.points + 3 * i;
        for (k = 0; k < 9; k++) cov[k] += p[k / 3] * p[k % 3];
        for (k = 0; k < 3; k++) { /* box_mid/box_half hold min/max for now */
            if (p[k] < fit.box_mid[k]) fit.box_mid[k] = p[k];
            if (p[k] > fit.box_half[k]) fit.box_half[k] = p[k];
        }
    }
    for (k = 0; k < 3; k++) {
        double lo = fit.box_mid[k], hi = fit.box_half[k];
        fit.box_mid[k] = 0.5 * (lo + hi);
        fit.box_half[k] = 0.5 * (hi - lo);
    }
    fit.box_volume = 8.0 * fit.box_half[0] * fit.box_half[1] * fit.box_half[2];
    sqffd_sym3_eigen(cov, values, axes);
    if (!(values[0] > SQFFD__SQ_FLAT_RATIO * values[2])) return SQFFD_ERROR_DEGENERATE;

    /* Starts: each principal axis as the local z, times the shape seeds;
       when two eigenvalues are close their axes are arbitrary within their
       plane, so that basis is also tried turned by 45 degrees in it. Every
       start gets a few iterations on a small subsample (screen), the best
       few run to convergence on a larger one (polish), and the winner on all
       points. */
    sqffd__sq_subsample(w.points, n, w.screen, m_screen);
    sqffd__sq_subsample(w.points, n, w.polish, m_polish);
    n_kept = 0;
    for (basis = 0; basis < 3 && fit.status == SQFFD_OK; basis++) {
        double b_axes[9], b_size[3];
        memcpy(b_axes, axes, sizeof b_axes);
        if (basis > 0) {
            int fixed_axis = basis == 1 ? 2 : 0; /* basis 1: eigenvalues 0, 1 close; basis 2: 1, 2 close */
            double ratio = basis == 1 ? values[0] / values[1] : values[1] / values[2], turn[3] = {0.0, 0.0, 0.0};
            if (ratio < SQFFD__SQ_CLOSE_RATIO) continue;
            turn[fixed_axis] = 0.25 * SQFFD__SQ_PI;
            sqffd__sq_rotate(b_axes, turn);
        }
        sqffd__sq_initial_sizes(w.points, n, b_axes, w.hist, b_size);
#ifndef SQFFD__SQ_BASIS_SEEDS
#define SQFFD__SQ_BASIS_SEEDS 1
#endif
        for (s = 0; s < 3 * (basis ? SQFFD__SQ_BASIS_SEEDS : n_seeds) && fit.status == SQFFD_OK; s++) {
            int perm = s % 3, j, slot;
            memset(&cur, 0, sizeof cur);
            for (j = 0; j < 3; j++) { /* cyclic column permutation: still a rotation */
                int col = (j + perm) % 3;
                cur.rotation[j] = b_axes[col];
                cur.rotation[3 + j] = b_axes[3 + col];
                cur.rotation[6 + j] = b_axes[6 + col];
                cur.size[j] = b_size[col];
            }
            cur.shape[0] = shape_seeds[s / 3][0];
            cur.shape[1] = shape_seeds[s / 3][1];
            sqffd__sq_project(&fit, &cur);
            sqffd__sq_lm(&fit, &cur, w.screen, NULL, m_screen, SQFFD__SQ_START_ITERATIONS, &cost);
#ifdef SQFFD__SQ_DEBUG
            SQFFD__SQ_DEBUG(basis * 100 + s, &cur, cost);
#endif
            /* keep the SQFFD__SQ_KEEP cheapest, sorted */
            for (slot = n_kept; slot > 0 && cost < kept_cost[slot - 1]; slot--) {
                if (slot < SQFFD__SQ_KEEP) { kept[slot] = kept[slot - 1]; kept_cost[slot] = kept_cost[slot - 1]; kept_id[slot] = kept_id[slot - 1]; }
            }
            if (slot < SQFFD__SQ_KEEP) {
                kept[slot] = cur; kept_cost[slot] = cost; kept_id[slot] = basis * 3 * n_seeds + s;
                if (n_kept < SQFFD__SQ_KEEP) n_kept++;
            }
        }
    }
    for (k = 0; k < n_kept && fit.status == SQFFD_OK; k++) {
        kept_mix[k].sigma2 = 0.0;
        kept_mix[k].prior = 0.5;
        if (m_polish > m_screen || o->robust)
            kept_cost[k] = sqffd__sq_refine(&fit, &kept[k], w.polish, m_polish, w.weights, &kept_mix[k], o->robust_rounds, &converged);
#ifdef SQFFD__SQ_DEBUG
        SQFFD__SQ_DEBUG(1000 + fit.iterations, &kept[k], kept_cost[k]);
#endif
        if (k == 0 || kept_cost[k] < best_cost) { best = kept[k]; best_cost = kept_cost[k]; best_start = kept_id[k]; mix = kept_mix[k]; }
    }

    /* the winner on all points */
    if (fit.status == SQFFD_OK && (m_polish < n || o->robust))
        best_cost = sqffd__sq_refine(&fit, &best, w.points, n, w.weights, &mix, SQFFD__SQ_FULL_ROUNDS, &converged);
#ifdef SQFFD__SQ_DEBUG
    SQFFD__SQ_DEBUG(2000 + fit.iterations, &best, best_cost);
#endif
    if (fit.status != SQFFD_OK) return fit.status;

    if (report) {
        const double *weights = o->robust ? w.weights : NULL;
        double sum_w = 0.0, final = sqffd__sq_accumulate(&fit, &best, w.points, weights, n, NULL, NULL);
        for (i = 0; i < n; i++) sum_w += weights ? weights[i] : 1.0;
        report->iterations = fit.iterations;
        report->cost = final * (o->cost == SQFFD_SQ_COST_SOLINA ? scale * scale * scale : scale * scale);
        report->rms_radial = scale * sqrt(sqffd__sq_mean_d2(&best, w.points, weights, n));
        report->start = best_start;
        report->converged = converged;
        report->inlier_fraction = sum_w / (double)n;
    }
    *sq = best;
    for (k = 0; k < 3; k++) {
        sq->size[k] *= scale;
        sq->center[k] = centroid[k] + scale * best.center[k];
    }
    return SQFFD_OK;
}

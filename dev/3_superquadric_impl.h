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
    return hi + log(s);
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
typedef struct sqffd__sq_exponents {
    double two_e1, two_e2, ratio; /* 2/e1, 2/e2, e2/e1 */
} sqffd__sq_exponents;

static sqffd__sq_exponents sqffd__sq_exponents_of(const sqffd_superquadric *sq)
{
    sqffd__sq_exponents x;
    x.two_e1 = 2.0 / sq->shape[0];
    x.two_e2 = 2.0 / sq->shape[1];
    x.ratio = sq->shape[1] / sq->shape[0];
    return x;
}

static double sqffd__sq_log_f(const double u[3], const double log_size[3], const sqffd__sq_exponents *x, double *parts)
{
    double lu = x->two_e2 * (sqffd__sq_log_abs(u[0]) - log_size[0]);
    double lv = x->two_e2 * (sqffd__sq_log_abs(u[1]) - log_size[1]);
    double lh = x->two_e1 * (sqffd__sq_log_abs(u[2]) - log_size[2]);
    double frac_u[2], frac_g[2], la, lg, lf;
    la = sqffd__sq_logsum(lu, lv, frac_u);
    lg = x->ratio * la;
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
    sqffd__sq_exponents x = sqffd__sq_exponents_of(sq);
    log_size[0] = log(sq->size[0]); log_size[1] = log(sq->size[1]); log_size[2] = log(sq->size[2]);
    return sqffd__sq_log_f(u, log_size, &x, NULL);
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
   formula needs special cases, so each step here instead searches for the
   parameter increment whose chord is `spacing`. Rows of constant eta are
   spaced by the largest chord over eight meridians, then each row is walked
   in omega, one quadrant at a time (a quadrant is a convex arc, so its chord
   grows monotonically). Tapered local coordinates: the rigid motion does not
   change lengths. */
#define SQFFD__SQ_MERIDIANS 8

/* An arc being walked: along omega at eta = fixed (one curve), or along eta
   (eight meridians at once); start holds the curve points at the current
   parameter. */
typedef struct sqffd__sq_arc {
    const sqffd_superquadric *sq;
    int along_omega;
    double fixed;
    double start[SQFFD__SQ_MERIDIANS][3];
    double end[SQFFD__SQ_MERIDIANS][3]; /* the curve points at t_end */
} sqffd__sq_arc;

static int sqffd__sq_arc_curves(const sqffd__sq_arc *arc)
{
    return arc->along_omega ? 1 : SQFFD__SQ_MERIDIANS;
}

static void sqffd__sq_arc_point(const sqffd__sq_arc *arc, int curve, double t, double p[3])
{
    if (arc->along_omega) sqffd__sq_local_point(arc->sq, arc->fixed, t, p);
    else sqffd__sq_local_point(arc->sq, t, -SQFFD__SQ_PI + 2.0 * SQFFD__SQ_PI * curve / SQFFD__SQ_MERIDIANS, p);
    sqffd__sq_taper(arc->sq, p);
}

/* Longest chord from the start points to parameter t (to the end points
   when to_end). */
static double sqffd__sq_arc_chord(const sqffd__sq_arc *arc, double t, int to_end)
{
    double best = 0.0, p[3];
    int k;
    for (k = 0; k < sqffd__sq_arc_curves(arc); k++) {
        double d;
        if (to_end) memcpy(p, arc->end[k], sizeof p);
        else sqffd__sq_arc_point(arc, k, t, p);
        d = sqffd__dist2_3(arc->start[k], p);
        if (d > best) best = d;
    }
    return sqrt(best);
}

/* Begin walking the arc towards t_end. */
static void sqffd__sq_arc_begin(sqffd__sq_arc *arc, double t_end)
{
    int k;
    for (k = 0; k < sqffd__sq_arc_curves(arc); k++) sqffd__sq_arc_point(arc, k, t_end, arc->end[k]);
}

/* Next parameter after t on the arc towards t_end (t < t_end): a chord of
   `spacing` within 10%; the last two steps share the remainder evenly;
   t_end when the remainder is at most one spacing. *guess carries the
   previous increment: a safeguarded secant search from it (near the
   singular points the increments span many orders of magnitude when e is
   small, so the bracket shrinks geometrically when the secant step fails). */
static double sqffd__sq_next(sqffd__sq_arc *arc, double t, double t_end, double spacing, double *guess)
{
    double rest, target = spacing, lo = 0.0, hi = t_end - t, d = *guess;
    int it, k;
    for (k = 0; k < sqffd__sq_arc_curves(arc); k++) sqffd__sq_arc_point(arc, k, t, arc->start[k]);
    rest = sqffd__sq_arc_chord(arc, t_end, 1);
    if (rest <= spacing) return t_end;
    if (rest < 2.0 * spacing) target = 0.5 * rest;
    if (!(d > 0.0 && d < hi)) d = 0.5 * hi;
    for (it = 0; it < 100; it++) { /* chord(lo) < target < chord(hi) */
        double c = sqffd__sq_arc_chord(arc, t + d, 0), next;
        if (fabs(c - target) <= 0.1 * target && t + d > t) break;
        if (c < target) lo = d; else hi = d;
        next = c > 0.0 ? d * target / c : 4.0 * d; /* secant through the origin */
        if (!(next > lo && next < hi)) next = lo > 0.0 ? sqrt(lo * hi) : 0.125 * hi;
        d = next;
    }
    if (it == 100) d = hi;
    *guess = d;
    return t + d > t ? t + d : t_end; /* no representable progress: finish the arc */
}

/* Emit the samples of one row (constant eta). Returns the new count. */
static size_t sqffd__sq_sample_row(const sqffd_superquadric *sq, double eta, double spacing, double *points,
                                   size_t capacity, size_t count)
{
    sqffd__sq_arc arc;
    double ring = 0.0, p[3];
    int quadrant;
    arc.sq = sq;
    arc.along_omega = 1;
    arc.fixed = eta;
    sqffd__sq_arc_point(&arc, 0, -SQFFD__SQ_PI, arc.start[0]);
    for (quadrant = 1; quadrant <= 4; quadrant++) { /* the ring's perimeter, roughly */
        sqffd__sq_arc_point(&arc, 0, -SQFFD__SQ_PI + 0.5 * SQFFD__SQ_PI * quadrant, p);
        ring += sqrt(sqffd__dist2_3(arc.start[0], p));
        memcpy(arc.start[0], p, sizeof p);
    }
    for (quadrant = 0; quadrant < 4; quadrant++) {
        double t = -SQFFD__SQ_PI + 0.5 * SQFFD__SQ_PI * quadrant, t_end = t + 0.5 * SQFFD__SQ_PI, guess = 0.0;
        sqffd__sq_arc_begin(&arc, t_end);
        while (t < t_end) {
            if (count < capacity) sqffd_sq_point(sq, eta, t, points + 3 * count, NULL);
            count++;
            if (ring < spacing) return count; /* a ring smaller than the spacing (a pole): one point */
            t = sqffd__sq_next(&arc, t, t_end, spacing, &guess);
        }
    }
    return count;
}

/* Upper bound of the samples sqffd_sq_sample_uniform makes: rows of
   constant eta at most (meridian length) / spacing, each with at most
   (ring perimeter) / spacing points; a convex arc is no longer than the
   two legs of its bounding rectangle. */
static double sqffd__sq_sample_bound(const sqffd_superquadric *sq, double spacing)
{
    double x = sq->size[0] * (1.0 + fabs(sq->taper[0])), y = sq->size[1] * (1.0 + fabs(sq->taper[1]));
    double r = x > y ? x : y, z = sq->size[2];
    return (2.0 * (2.0 * (r + z)) / spacing + 2.0) * (4.0 * (x + y) / spacing + 4.0);
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
    sqffd__sq_arc arc;
    size_t count = 0;
    int half;
    arc.sq = sq;
    arc.along_omega = 0;
    arc.fixed = 0.0;
    if (!sq || !sqffd__sq_valid(sq) || !(spacing > 0.0) || !isfinite(spacing)) return 0;
    if (!points) capacity = 0;
    /* refuse samplings beyond ~1e8 points rather than run for minutes */
    if (sqffd__sq_sample_bound(sq, spacing) > 1e8) return 0;
    for (half = 0; half < 2; half++) { /* eta in [-pi/2, 0), then [0, pi/2) */
        double t = -0.5 * SQFFD__SQ_PI + 0.5 * SQFFD__SQ_PI * half, t_end = t + 0.5 * SQFFD__SQ_PI, guess = 0.0;
        sqffd__sq_arc_begin(&arc, t_end);
        while (t < t_end) {
            count = sqffd__sq_sample_row(sq, t, spacing, points, capacity, count);
            t = sqffd__sq_next(&arc, t, t_end, spacing, &guess);
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
/* Row stride of J^T W J: padded to 16 so that the per-point row update has a
   fixed length and vectorises (the padding columns stay 0). */
#define SQFFD__SQ_ROW 16
/* The starts and how much work each gets (measured on issue 3's random
   shapes: fewer or smaller cost accuracy, more cost time). */
#define SQFFD__SQ_SCREEN 48            /* subsample every start is screened on */
#define SQFFD__SQ_START_ITERATIONS 4   /* LM iterations per start on it */
#define SQFFD__SQ_KEEP 2               /* best starts run to convergence (robust mode: ranked) ... */
#define SQFFD__SQ_POLISH 384           /* ... on this subsample */
#define SQFFD__SQ_CLEAR_WIN 1e-2       /* a start this much costlier than the best is not polished */
#define SQFFD__SQ_CLOSE_RATIO 0.7      /* eigenvalues or sizes this close count as ambiguous axes */
#define SQFFD__SQ_HISTOGRAM 512        /* bins per axis for the robust initial sizes */
#define SQFFD__SQ_SIZE_QUANTILE 0.95
#define SQFFD__SQ_BOX_MARGIN 1.25      /* the fit stays within the data's box enlarged this much */
#define SQFFD__SQ_MIN_STEP 1e-10       /* parameter steps below this (normalised units) end the LM */
#define SQFFD__SQ_EXACT 1e-24          /* mean squared residual counted as an exact fit */
#define SQFFD__SQ_TURNED_SEEDS 3        /* shape seeds tried on a turned basis */
#define SQFFD__SQ_CLOSE_FIT 0.05   /* RMS radial distance / mean size of a fit allowed past the data's box */
#define SQFFD__SQ_FLAT_RATIO 1e-10 /* covariance eigenvalue ratio below which data are flat */

/* Per-evaluation constants of the residual. */
typedef struct sqffd__sq_eval {
    const sqffd_superquadric *sq;
    sqffd__sq_exponents x;
    double log_size[3];
    double volume_scale;  /* sqrt(a1 a2 a3) */
    double taper_over_a3[2]; /* Kx / a3, Ky / a3 */
    double e1, inv_e1;
    int cost;
} sqffd__sq_eval;

static void sqffd__sq_eval_init(sqffd__sq_eval *ev, const sqffd_superquadric *sq, int cost)
{
    int k;
    ev->sq = sq;
    ev->x = sqffd__sq_exponents_of(sq);
    for (k = 0; k < 3; k++) ev->log_size[k] = log(sq->size[k]);
    ev->volume_scale = sqrt(sq->size[0] * sq->size[1] * sq->size[2]);
    ev->taper_over_a3[0] = sq->taper[0] / sq->size[2];
    ev->taper_over_a3[1] = sq->taper[1] / sq->size[2];
    ev->e1 = sq->shape[0];
    ev->inv_e1 = 1.0 / sq->shape[0];
    ev->cost = cost;
}

/* Residual of one point, and (grad not NULL) its derivatives with respect to
   the 13 parameters. Chain: world p -> tapered local q = R^T (p - c) ->
   untapered u = (q0 / fx, q1 / fy, q2) -> ln F(u) -> residual. */
static double sqffd__sq_residual(const sqffd__sq_eval *ev, const double p[3], double *grad)
{
    const sqffd_superquadric *sq = ev->sq;
    double e1 = ev->e1;
    double q[3], f[2], inv_f[2], u[3], parts[SQFFD__SQ_PARTS], lf, r, kf, extra_e1, extra_size, t[3], gq[3], h[3];
    int k, clamped[2];
    sqffd__sq_to_local(sq, p, q);
    for (k = 0; k < 2; k++) {
        f[k] = 1.0 + ev->taper_over_a3[k] * q[2];
        clamped[k] = f[k] < SQFFD__SQ_MIN_TAPER;
        if (clamped[k]) f[k] = SQFFD__SQ_MIN_TAPER;
        inv_f[k] = 1.0 / f[k];
        u[k] = q[k] * inv_f[k];
    }
    u[2] = q[2];
    lf = sqffd__sq_log_f(u, ev->log_size, &ev->x, grad ? parts : NULL);
    if (ev->cost == SQFFD_SQ_COST_SOLINA) { /* sqrt(a1 a2 a3) (F^e1 - 1) */
        double pw = exp(e1 * lf < 700.0 ? e1 * lf : 700.0);
        r = ev->volume_scale * (pw - 1.0);
        if (!grad) return r;
        kf = ev->volume_scale * pw * e1; /* d r / d ln F */
        extra_e1 = ev->volume_scale * pw * lf;
        extra_size = 0.5 * r; /* from d sqrt(a1 a2 a3) / d ln a_i */
        t[0] = t[1] = t[2] = 0.0;
    } else { /* |u| (1 - F^(-e1/2)) */
        double rho = sqrt(sqffd__dot3(u, u)), qm = exp(-0.5 * e1 * lf), along = rho > 0.0 ? (1.0 - qm) / rho : 0.0;
        r = rho * (1.0 - qm);
        if (!grad) return r;
        kf = 0.5 * rho * qm * e1;
        extra_e1 = 0.5 * rho * qm * lf;
        extra_size = 0.0;
        for (k = 0; k < 3; k++) t[k] = along * u[k];
    }
    /* h_k = d ln F / d ln|u_k| */
    h[0] = ev->x.two_e1 * parts[SQFFD__SQ_PART_FG] * parts[SQFFD__SQ_PART_FU];
    h[1] = ev->x.two_e1 * parts[SQFFD__SQ_PART_FG] * parts[SQFFD__SQ_PART_FU + 1];
    h[2] = ev->x.two_e1 * parts[SQFFD__SQ_PART_FG + 1];
    for (k = 0; k < 3; k++) /* t = d r / d u; h_k / u_k -> 0 as u_k -> 0 (exponents 2/e > 1) */
        t[k] += fabs(u[k]) > SQFFD__SQ_TINY ? kf * h[k] / u[k] : 0.0;
    /* through the tapering: dx/dX = 1/fx, dx/dZ = -x Kx / (a3 fx),
       dx/dKx = -x Z / (a3 fx), dx/d ln a3 = x Kx Z / (a3 fx) */
    gq[0] = t[0] * inv_f[0];
    gq[1] = t[1] * inv_f[1];
    gq[2] = t[2];
    grad[SQFFD__SQ_P_LOGSIZE] = grad[SQFFD__SQ_P_LOGSIZE + 1] = grad[SQFFD__SQ_P_LOGSIZE + 2] = 0.0;
    for (k = 0; k < 2; k++) {
        double s = clamped[k] ? 0.0 : t[k] * u[k] * inv_f[k]; /* times 1/a3 below */
        gq[2] -= s * ev->taper_over_a3[k];
        grad[SQFFD__SQ_P_TAPER + k] = -s * q[2] / sq->size[2];
        grad[SQFFD__SQ_P_LOGSIZE + 2] += s * ev->taper_over_a3[k] * q[2];
    }
    sqffd__cross3(gq, q, grad + SQFFD__SQ_P_ROT); /* dq/dw = [q]x */
    sqffd__mat3_vec(sq->rotation, gq, grad + SQFFD__SQ_P_CENTER);
    for (k = 0; k < 3; k++) {
        grad[SQFFD__SQ_P_CENTER + k] = -grad[SQFFD__SQ_P_CENTER + k];
        grad[SQFFD__SQ_P_LOGSIZE + k] += extra_size - kf * h[k];
    }
    grad[SQFFD__SQ_P_E1] = extra_e1 - kf * ev->inv_e1 * (parts[SQFFD__SQ_PART_FG] * parts[SQFFD__SQ_PART_LG] +
                                                         parts[SQFFD__SQ_PART_FG + 1] * parts[SQFFD__SQ_PART_LH]);
    grad[SQFFD__SQ_P_E2] = kf * ev->inv_e1 * parts[SQFFD__SQ_PART_FG] *
                           (parts[SQFFD__SQ_PART_LA] - parts[SQFFD__SQ_PART_FU] * parts[SQFFD__SQ_PART_LU] -
                            parts[SQFFD__SQ_PART_FU + 1] * parts[SQFFD__SQ_PART_LV]);
    return r;
}

/* ---- robust mode's mixture ----
   "Gaussian in the radial distance around the surface (its density spread
   over the area) + uniform over the data box". An E-step gives each point
   its inlier probability from the current sigma^2 and prior; the M-step
   then re-estimates both from those weights. */
typedef struct sqffd__sq_mixture {
    double sigma2;   /* variance of the inlier distances */
    double prior;    /* inlier fraction */
    double *weights; /* the points' inlier probabilities (the E-step's output) */
    double peak, outlier, sum_w, sum_wd2; /* one E-step's densities and sums */
} sqffd__sq_mixture;

/* Approximate surface area (Thomsen's ellipsoid formula): only the density
   of the inlier model needs it. */
static double sqffd__sq_area(const sqffd_superquadric *sq)
{
    const double p = 1.6075;
    double x = pow(sq->size[0], p), y = pow(sq->size[1], p), z = pow(sq->size[2], p);
    return 4.0 * SQFFD__SQ_PI * pow((x * y + y * z + z * x) / 3.0, 1.0 / p);
}

static void sqffd__sq_estep_begin(sqffd__sq_mixture *mix, const sqffd_superquadric *sq, double box_volume)
{
    if (mix->sigma2 < 1e-12) mix->sigma2 = 1e-12;
    mix->peak = mix->prior / (sqrt(2.0 * SQFFD__SQ_PI * mix->sigma2) * sqffd__sq_area(sq));
    mix->outlier = (1.0 - mix->prior) / box_volume;
    mix->sum_w = mix->sum_wd2 = 0.0;
}

/* The E-step for point k at radial distance d: its weight, also summed for the M-step. */
static double sqffd__sq_estep_point(sqffd__sq_mixture *mix, size_t k, double d)
{
    double d2 = d * d, inlier = mix->peak * exp(-0.5 * d2 / mix->sigma2);
    double w = inlier / (inlier + mix->outlier);
    mix->weights[k] = w;
    mix->sum_w += w;
    mix->sum_wd2 += w * d2;
    return w;
}

/* The M-step after an E-step over m points. */
static void sqffd__sq_mstep(sqffd__sq_mixture *mix, size_t m)
{
    mix->prior = mix->sum_w / (double)m;
    if (mix->prior < 0.05) mix->prior = 0.05;
    if (mix->prior > 0.999) mix->prior = 0.999;
    if (mix->sum_w > 0.0) mix->sigma2 = mix->sum_wd2 / mix->sum_w;
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
    void *ncg_work;       /* CG optimiser scratch */
    size_t ncg_size;
    sqffd_result status;  /* SQFFD_ERROR_CANCELLED once the callback asked */
    sqffd__sq_mixture *estep; /* robust mode: the next sqffd__sq_accumulate starts with this E-step
                                 (cost must be the radial distance, the mixture's own residual) */
} sqffd__sq_fit;

/* Weighted cost sum w r^2 over m points (weights NULL = 1); with jtr also
   J^T W r, and with jtj too the first npar rows of J^T W J (the Gauss-Newton
   normal equations; row stride SQFFD__SQ_ROW). With fit->estep set (robust
   mode) the weights come from an E-step at sq on the way, then the M-step:
   the optimiser's first evaluation does the E-step without a pass of its own. */
static double sqffd__sq_accumulate(sqffd__sq_fit *fit, const sqffd_superquadric *sq, const double *pts,
                                   const double *weights, size_t m, double *jtj, double *jtr)
{
    sqffd__sq_mixture *mix = fit->estep;
    sqffd__sq_eval ev;
    double cost = 0.0, g[SQFFD__SQ_ROW];
    int np = fit->npar, i, j;
    size_t k;
    sqffd__sq_eval_init(&ev, sq, fit->cost);
    memset(g, 0, sizeof g);
    if (jtj) memset(jtj, 0, sizeof(double) * SQFFD__SQ_NPAR * SQFFD__SQ_ROW);
    if (jtr) memset(jtr, 0, sizeof(double) * SQFFD__SQ_NPAR);
    fit->estep = NULL;
    if (mix) sqffd__sq_estep_begin(mix, sq, fit->box_volume);
    for (k = 0; k < m; k++) {
        double w = weights && !mix ? weights[k] : 1.0, r;
        if (w <= 0.0) continue;
        r = sqffd__sq_residual(&ev, pts + 3 * k, jtr ? g : NULL);
        if (mix) w = sqffd__sq_estep_point(mix, k, r);
        cost += w * r * r;
        if (!jtr) continue;
        for (i = 0; i < np; i++) {
            double wg = w * g[i];
            jtr[i] += wg * r;
            if (jtj)
                for (j = 0; j < SQFFD__SQ_ROW; j++) jtj[i * SQFFD__SQ_ROW + j] += wg * g[j];
        }
    }
    if (mix) sqffd__sq_mstep(mix, m);
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
   the data's box, each size at most SQFFD__SQ_BOX_MARGIN times the box's
   half-extent along that local axis (this stops the runaway of the F-based
   cost on data that are no superquadric; sqffd__sq_contain finishes the job). */
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

/* ||(x, y)||_q for x, y >= 0, scaled so that a large q cannot overflow. */
static double sqffd__sq_qnorm(double x, double y, double q)
{
    double m = x > y ? x : y;
    if (m <= 0.0) return 0.0;
    return m * pow(pow(x / m, q) + pow(y / m, q), 1.0 / q);
}

/* How far the shape reaches from its centre along +dir (a world unit
   vector). Each cross-section at height z = a3 S^e1 (S = sin eta, signed
   power) is a superellipse with half-axes fx a1 C^e1, fy a2 C^e1, whose
   support is the dual norm with q = 2/(2 - e2) (e2 > 2 shapes lie inside
   the e2 = 2 ones); the reach is the largest over SQFFD__SQ_REACH_ROWS
   heights. */
#define SQFFD__SQ_REACH_ROWS 256
static double sqffd__sq_reach(const sqffd_superquadric *sq, const double dir[3])
{
    double v[3], best = -HUGE_VAL, q = 2.0 / (2.0 - (sq->shape[1] < 1.99 ? sq->shape[1] : 1.99));
    int i;
    sqffd__mat3t_vec(sq->rotation, dir, v);
    for (i = 0; i <= SQFFD__SQ_REACH_ROWS; i++) {
        double eta = -0.5 * SQFFD__SQ_PI + SQFFD__SQ_PI * i / SQFFD__SQ_REACH_ROWS, f[2], h;
        double c = sqffd__sq_spow(cos(eta), sq->shape[0]), z = sq->size[2] * sqffd__sq_spow(sin(eta), sq->shape[0]);
        sqffd__sq_taper_factors(sq, z, f);
        h = c * sqffd__sq_qnorm(f[0] * sq->size[0] * fabs(v[0]), f[1] * sq->size[1] * fabs(v[1]), q) + v[2] * z;
        if (h > best) best = h;
    }
    return best;
}

/* The last guard against a runaway: when the fitted shape reaches out of
   the data's box enlarged by SQFFD__SQ_BOX_MARGIN, shrink it about its
   centre (all sizes by one factor: the shape scales, K is scale-free) until
   it fits. The per-size bounds of the projection leave a rotated or
   off-centre shape room to stick out; this closes it. */
static void sqffd__sq_contain(const sqffd__sq_fit *fit, sqffd_superquadric *sq)
{
    double shrink = 1.0;
    int k, side;
    for (k = 0; k < 3; k++)
        for (side = -1; side <= 1; side += 2) {
            double dir[3] = {0.0, 0.0, 0.0}, reach, room;
            dir[k] = (double)side;
            reach = 1.001 * sqffd__sq_reach(sq, dir); /* the rows sample the reach from below */
            room = SQFFD__SQ_BOX_MARGIN * fit->box_half[k] - side * (sq->center[k] - fit->box_mid[k]);
            if (reach > 0.0 && reach * shrink > room) shrink = room / reach;
        }
    for (k = 0; k < 3; k++) sq->size[k] *= shrink;
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
    double jtj[SQFFD__SQ_NPAR * SQFFD__SQ_ROW], jtr[SQFFD__SQ_NPAR];
    double tjtj[SQFFD__SQ_NPAR * SQFFD__SQ_ROW], tjtr[SQFFD__SQ_NPAR];
    double a[SQFFD__SQ_NPAR * SQFFD__SQ_NPAR], delta[SQFFD__SQ_NPAR], lambda = 1e-3, step;
    int np = fit->npar, it, i, j;
    double c0 = sqffd__sq_accumulate(fit, sq, pts, weights, m, jtj, jtr);
    if (c0 < SQFFD__SQ_EXACT * (double)m) { *cost = c0; return 1; }
    for (it = 0; it < max_iterations; it++) {
        sqffd_superquadric trial = *sq;
        int last = it + 1 == max_iterations; /* no use for the trial's Jacobian */
        double c1;
        for (i = 0; i < np; i++) {
            for (j = 0; j < np; j++)
                a[i * np + j] = i <= j ? jtj[i * SQFFD__SQ_ROW + j] : jtj[j * SQFFD__SQ_ROW + i];
            a[i * np + i] += lambda * jtj[i * SQFFD__SQ_ROW + i] + 1e-12 * (1.0 + c0);
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
        c1 = sqffd__sq_accumulate(fit, &trial, pts, weights, m, last ? NULL : tjtj, last ? NULL : tjtr);
        if (!sqffd__sq_tick(fit, c1 < c0 ? c1 : c0)) break;
        if (c1 < c0) {
            double gain = (c0 - c1) / c0;
            *sq = trial;
            if (!last) {
                memcpy(jtj, tjtj, sizeof jtj);
                memcpy(jtr, tjtr, sizeof jtr);
            }
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

/* ---- the paper's optimiser, nonlinear conjugate gradients ----
   Parameters x = (w, centre, log sizes, e1, e2, Kx, Ky) with R = R0 exp([w]x).
   The gradient is 2 J^T r from the same analytic Jacobian as the LM; its
   rotation part (taken at the current R) maps to w through the transposed
   right Jacobian of the exponential map,
   J_r(w)^T g = g + a w x g + b w x (w x g), a = (1 - cos t)/t^2, b = (t - sin t)/t^3. */
typedef struct sqffd__sq_cg {
    sqffd__sq_fit *fit;
    const sqffd_superquadric *base; /* R0 */
    const double *pts, *weights;
    size_t m;
} sqffd__sq_cg;

static void sqffd__sq_cg_model(const sqffd__sq_cg *cg, const double *x, sqffd_superquadric *sq)
{
    int k;
    *sq = *cg->base;
    sqffd__sq_rotate(sq->rotation, x + SQFFD__SQ_P_ROT);
    for (k = 0; k < 3; k++) {
        sq->center[k] = x[SQFFD__SQ_P_CENTER + k];
        sq->size[k] = exp(x[SQFFD__SQ_P_LOGSIZE + k]);
    }
    sq->shape[0] = x[SQFFD__SQ_P_E1];
    sq->shape[1] = x[SQFFD__SQ_P_E2];
    if (cg->fit->npar == SQFFD__SQ_NPAR) {
        sq->taper[0] = x[SQFFD__SQ_P_TAPER];
        sq->taper[1] = x[SQFFD__SQ_P_TAPER + 1];
    }
}

/* The non-rotation parameters of sq into x (x[0..2] untouched). */
static void sqffd__sq_cg_params(const sqffd__sq_fit *fit, const sqffd_superquadric *sq, double *x)
{
    int k;
    for (k = 0; k < 3; k++) {
        x[SQFFD__SQ_P_CENTER + k] = sq->center[k];
        x[SQFFD__SQ_P_LOGSIZE + k] = log(sq->size[k]);
    }
    x[SQFFD__SQ_P_E1] = sq->shape[0];
    x[SQFFD__SQ_P_E2] = sq->shape[1];
    if (fit->npar == SQFFD__SQ_NPAR) {
        x[SQFFD__SQ_P_TAPER] = sq->taper[0];
        x[SQFFD__SQ_P_TAPER + 1] = sq->taper[1];
    }
}

static double sqffd__sq_cg_objective(void *user, const double *x, double *gradient)
{
    const sqffd__sq_cg *cg = (const sqffd__sq_cg *)user;
    sqffd_superquadric sq;
    double jtr[SQFFD__SQ_NPAR], g[3], wg[3], wwg[3], cost, t2, a, b;
    int k;
    sqffd__sq_cg_model(cg, x, &sq);
    cost = sqffd__sq_accumulate(cg->fit, &sq, cg->pts, cg->weights, cg->m, NULL, jtr);
    for (k = 0; k < cg->fit->npar; k++) gradient[k] = 2.0 * jtr[k];
    t2 = sqffd__dot3(x, x);
    if (t2 < 1e-8) { a = 0.5 - t2 / 24.0; b = 1.0 / 6.0 - t2 / 120.0; }
    else {
        double t = sqrt(t2);
        a = (1.0 - cos(t)) / t2;
        b = (t - sin(t)) / (t2 * t);
    }
    memcpy(g, gradient + SQFFD__SQ_P_ROT, sizeof g);
    sqffd__cross3(x, g, wg);
    sqffd__cross3(x, wg, wwg);
    for (k = 0; k < 3; k++) gradient[SQFFD__SQ_P_ROT + k] = g[k] + a * wg[k] + b * wwg[k];
    return cost;
}

static void sqffd__sq_cg_project(void *user, double *x)
{
    const sqffd__sq_cg *cg = (const sqffd__sq_cg *)user;
    sqffd_superquadric sq;
    sqffd__sq_cg_model(cg, x, &sq);
    sqffd__sq_project(cg->fit, &sq);
    sqffd__sq_cg_params(cg->fit, &sq, x);
}

static int sqffd__sq_cg_progress(void *user, int stage, int iteration, double error)
{
    (void)stage;
    (void)iteration;
    return !sqffd__sq_tick((sqffd__sq_fit *)user, error);
}

static int sqffd__sq_cg_minimize(sqffd__sq_fit *fit, sqffd_superquadric *sq, const double *pts, const double *weights,
                                 size_t m, int max_iterations, double *cost)
{
    sqffd__sq_cg cg;
    sqffd_superquadric base = *sq;
    double x[SQFFD__SQ_NPAR], gradient[SQFFD__SQ_NPAR], f0;
    sqffd_result r;
    cg.fit = fit;
    cg.base = &base;
    cg.pts = pts;
    cg.weights = weights;
    cg.m = m;
    x[0] = x[1] = x[2] = 0.0;
    sqffd__sq_cg_params(fit, sq, x);
    f0 = sqffd__sq_cg_objective(&cg, x, gradient);
    r = sqffd_ncg_minimize(fit->npar, sqffd__sq_cg_objective, sqffd__sq_cg_project, &cg, x, max_iterations,
                           fit->opt->tolerance * (f0 > 1.0 ? f0 : 1.0), NULL, cost, sqffd__sq_cg_progress, fit,
                           fit->ncg_work, fit->ncg_size);
    sqffd__sq_cg_model(&cg, x, sq);
    if (r == SQFFD_ERROR_CANCELLED) fit->status = SQFFD_ERROR_CANCELLED;
    return r == SQFFD_OK;
}

/* The configured optimiser; the CG needs more, cheaper iterations. */
#define SQFFD__SQ_CG_FACTOR 4
static int sqffd__sq_optimize(sqffd__sq_fit *fit, sqffd_superquadric *sq, const double *pts, const double *weights,
                              size_t m, int max_iterations, double *cost)
{
    if (fit->opt->optimizer == SQFFD_SQ_OPTIMIZER_CG)
        return sqffd__sq_cg_minimize(fit, sq, pts, weights, m, SQFFD__SQ_CG_FACTOR * max_iterations, cost);
    return sqffd__sq_lm(fit, sq, pts, weights, m, max_iterations, cost);
}

/* Workspace blocks of one fit. */
typedef struct sqffd__sq_work {
    double *points;  /* 3n normalised points */
    double *weights; /* n robust weights (robust mode only) */
    double *screen;  /* 3 * min(n, SQFFD__SQ_SCREEN) subsample */
    double *polish;  /* 3 * min(n, SQFFD__SQ_POLISH) subsample */
    double *dense;   /* robust mode: the polish points that are not isolated */
    void *tree;      /* robust mode: kd-tree over the polish points */
    size_t tree_size;
    double *hist;    /* 3 * SQFFD__SQ_HISTOGRAM */
    void *ncg;       /* CG optimiser scratch */
    size_t ncg_size;
} sqffd__sq_work;

static void sqffd__sq_fit_layout(sqffd__arena *a, size_t n, const sqffd_sq_fit_options *o, sqffd__sq_work *w)
{
    w->points = (double *)sqffd__arena_take(a, n, 3 * sizeof(double));
    /* robust weights; also the 2 * min(n, SQFFD__SQ_POLISH) scratch of the density filter */
    w->weights = o->robust ? (double *)sqffd__arena_take(a, n > 2 * SQFFD__SQ_POLISH ? n : 2 * SQFFD__SQ_POLISH, sizeof(double)) : NULL;
    w->screen = (double *)sqffd__arena_take(a, n < SQFFD__SQ_SCREEN ? n : SQFFD__SQ_SCREEN, 3 * sizeof(double));
    w->polish = (double *)sqffd__arena_take(a, n < SQFFD__SQ_POLISH ? n : SQFFD__SQ_POLISH, 3 * sizeof(double));
    w->dense = o->robust ? (double *)sqffd__arena_take(a, n < SQFFD__SQ_POLISH ? n : SQFFD__SQ_POLISH, 3 * sizeof(double)) : NULL;
    w->tree_size = o->robust ? sqffd_kdtree_workspace_size(n < SQFFD__SQ_POLISH ? n : SQFFD__SQ_POLISH) : 0;
    w->tree = w->tree_size ? sqffd__arena_take(a, w->tree_size, 1) : NULL;
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
    o.tolerance = 1e-5;
    o.robust = 0;
    o.robust_rounds = 4;
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

/* An EM step (E, then M) at sq over m points in a pass of its own. */
static void sqffd__sq_reweight(sqffd__sq_mixture *mix, const sqffd_superquadric *sq, const double *pts, size_t m,
                               double box_volume)
{
    sqffd__sq_eval ev;
    size_t k;
    sqffd__sq_eval_init(&ev, sq, SQFFD_SQ_COST_RADIAL);
    sqffd__sq_estep_begin(mix, sq, box_volume);
    for (k = 0; k < m; k++) sqffd__sq_estep_point(mix, k, sqffd__sq_residual(&ev, pts + 3 * k, NULL));
    sqffd__sq_mstep(mix, m);
}

/* Weighted mean of the squared radial distance (weights NULL = 1). */
static double sqffd__sq_mean_d2(const sqffd_superquadric *sq, const double *pts, const double *weights, size_t m)
{
    double sum = 0.0, sum_w = 0.0;
    sqffd__sq_eval ev;
    size_t k;
    sqffd__sq_eval_init(&ev, sq, SQFFD_SQ_COST_RADIAL);
    for (k = 0; k < m; k++) {
        double w = weights ? weights[k] : 1.0, d = sqffd__sq_residual(&ev, pts + 3 * k, NULL);
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

/* Robust initial half-sizes along the columns of axes, about centre: the
   SQFFD__SQ_SIZE_QUANTILE quantile of |projection| (a fixed histogram, no
   sort), divided by the quantile (exact for a sphere sampled evenly). */
static void sqffd__sq_initial_sizes(const double *pts, size_t n, const double centre[3], const double axes[9],
                                    double *hist, double size[3])
{
    double top[3] = {0.0, 0.0, 0.0}, proj[3], d[3];
    size_t i;
    int k, b;
    memset(hist, 0, sizeof(double) * 3 * SQFFD__SQ_HISTOGRAM);
    for (i = 0; i < n; i++) {
        sqffd__sub3(pts + 3 * i, centre, d);
        sqffd__mat3t_vec(axes, d, proj);
        for (k = 0; k < 3; k++)
            if (fabs(proj[k]) > top[k]) top[k] = fabs(proj[k]);
    }
    for (i = 0; i < n; i++) {
        sqffd__sub3(pts + 3 * i, centre, d);
        sqffd__mat3t_vec(axes, d, proj);
        for (k = 0; k < 3; k++) {
            b = top[k] > 0.0 ? (int)(fabs(proj[k]) / top[k] * SQFFD__SQ_HISTOGRAM) : 0;
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

/* Centroid and covariance (row-major 3x3) of m points. */
static void sqffd__sq_moments(const double *pts, size_t m, double centre[3], double cov[9])
{
    size_t i;
    int k;
    memset(cov, 0, 9 * sizeof(double));
    centre[0] = centre[1] = centre[2] = 0.0;
    for (i = 0; i < m; i++)
        for (k = 0; k < 3; k++) centre[k] += pts[3 * i + (size_t)k] / (double)m;
    for (i = 0; i < m; i++) {
        double d[3];
        sqffd__sub3(pts + 3 * i, centre, d);
        for (k = 0; k < 9; k++) cov[k] += d[k / 3] * d[k % 3] / (double)m;
    }
}

static void sqffd__sq_swap(double *a, size_t i, size_t j)
{
    double t = a[i];
    a[i] = a[j];
    a[j] = t;
}

/* The k-th smallest of a[0..n-1] (quickselect, median-of-three pivot,
   Lomuto partition; reorders a). */
static double sqffd__sq_select(double *a, size_t n, size_t k)
{
    size_t lo = 0, hi = n - 1;
    while (hi > lo) {
        size_t mid = lo + (hi - lo) / 2, store = lo, i;
        if (a[mid] < a[lo]) sqffd__sq_swap(a, lo, mid);
        if (a[hi] < a[lo]) sqffd__sq_swap(a, lo, hi);
        if (a[mid] < a[hi]) sqffd__sq_swap(a, mid, hi); /* a[hi]: the median of the three */
        for (i = lo; i < hi; i++)
            if (a[i] < a[hi]) sqffd__sq_swap(a, i, store++);
        sqffd__sq_swap(a, store, hi);
        if (k == store) break;
        if (k < store) hi = store - 1;
        else lo = store + 1;
    }
    return a[k];
}

/* Robust mode's start set: of every other point, those whose
   SQFFD__SQ_NEIGHBOURS-th nearest neighbour among all m (a kd-tree over
   them) is at most 1.2 times the median such distance. Outliers away from
   the surface are isolated and drop out; so do some surface points, which
   the starts can spare. dist: m doubles of scratch. Returns the count
   written to out (0 if the tree cannot be built). */
#define SQFFD__SQ_NEIGHBOURS 6
static size_t sqffd__sq_dense_points(const double *pts, size_t m, double *out, double *dist, void *tree_work,
                                     size_t tree_size)
{
    sqffd_kdtree tree;
    size_t i, kept = 0, half = (m + 1) / 2, index[SQFFD__SQ_NEIGHBOURS + 1];
    double d2[SQFFD__SQ_NEIGHBOURS + 1], limit;
    if (sqffd_kdtree_build(&tree, pts, m, tree_work, tree_size) != SQFFD_OK) return 0;
    for (i = 0; i < half; i++) { /* the point itself is the first of the k + 1 nearest */
        size_t found = sqffd_kdtree_knn(&tree, pts + 6 * i, SQFFD__SQ_NEIGHBOURS + 1, index, d2);
        dist[i] = dist[half + i] = d2[found - 1];
    }
    limit = 1.44 * sqffd__sq_select(dist + half, half, half / 2); /* squared: 1.2 times the median distance */
    for (i = 0; i < half; i++)
        if (dist[i] <= limit) memcpy(out + 3 * kept++, pts + 6 * i, 3 * sizeof(double));
    return kept;
}

/* Robust variance of the radial distances of m points: (1.4826 median |d|)^2.
   scratch: m doubles. */
static double sqffd__sq_robust_d2(const sqffd_superquadric *sq, const double *pts, size_t m, double *scratch)
{
    double mad;
    size_t k;
    sqffd__sq_eval ev;
    sqffd__sq_eval_init(&ev, sq, SQFFD_SQ_COST_RADIAL);
    for (k = 0; k < m; k++) scratch[k] = fabs(sqffd__sq_residual(&ev, pts + 3 * k, NULL));
    mad = 1.4826 * sqffd__sq_select(scratch, m, m / 2);
    return mad * mad;
}

#define SQFFD__SQ_ROBUST_COST SQFFD_SQ_COST_RADIAL /* the mixture's own residual */
/* Optimiser iterations per EM round but the last (the CG's get multiplied by
   SQFFD__SQ_CG_FACTOR too): one LM step lets the weights follow; the CG's
   steps do less (measured on issue 3's shapes). */
#define SQFFD__SQ_ROUND_ITERATIONS(o) ((o)->optimizer == SQFFD_SQ_OPTIMIZER_CG ? 3 : 1)
#define SQFFD__SQ_FULL_ROUNDS 1      /* EM rounds on all points after the polish subsample */
/* Field by field: the core may not call memcmp. */
static int sqffd__sq_equal(const sqffd_superquadric *a, const sqffd_superquadric *b)
{
    int k;
    for (k = 0; k < 9; k++)
        if (a->rotation[k] != b->rotation[k]) return 0;
    for (k = 0; k < 3; k++)
        if (a->size[k] != b->size[k] || a->center[k] != b->center[k]) return 0;
    for (k = 0; k < 2; k++)
        if (a->shape[k] != b->shape[k] || a->taper[k] != b->taper[k]) return 0;
    return 1;
}

/* Robust mode: `rounds` EM rounds on m points, each an E-step and M-step
   (fused into the optimiser's first evaluation), then a few weighted LM
   iterations of the mixture's own residual, the radial distance; the last
   round runs the LM to convergence. Returns non-zero when that moved sq
   (else the last E-step's weights are those at the result). */
static int sqffd__sq_em(sqffd__sq_fit *fit, sqffd_superquadric *sq, const double *pts, size_t m,
                        sqffd__sq_mixture *mix, int rounds, int *converged)
{
    sqffd_superquadric at_estep = *sq;
    double cost;
    int r;
    fit->cost = SQFFD__SQ_ROBUST_COST;
    for (r = 0; r < rounds && fit->status == SQFFD_OK; r++) {
        at_estep = *sq;
        fit->estep = mix;
        *converged = sqffd__sq_optimize(fit, sq, pts, mix->weights, m,
                                        r + 1 < rounds ? SQFFD__SQ_ROUND_ITERATIONS(fit->opt) : fit->opt->max_iterations, &cost);
    }
    fit->cost = (int)fit->opt->cost;
    return !sqffd__sq_equal(&at_estep, sq);
}

/* Keep the SQFFD__SQ_KEEP cheapest starts, sorted by cost. */
typedef struct sqffd__sq_shortlist {
    sqffd_superquadric sq[SQFFD__SQ_KEEP];
    double cost[SQFFD__SQ_KEEP];
    int id[SQFFD__SQ_KEEP];
    int count;
} sqffd__sq_shortlist;

static void sqffd__sq_shortlist_add(sqffd__sq_shortlist *list, const sqffd_superquadric *sq, double cost, int id)
{
    int slot;
    for (slot = list->count; slot > 0 && cost < list->cost[slot - 1]; slot--)
        if (slot < SQFFD__SQ_KEEP) {
            list->sq[slot] = list->sq[slot - 1];
            list->cost[slot] = list->cost[slot - 1];
            list->id[slot] = list->id[slot - 1];
        }
    if (slot >= SQFFD__SQ_KEEP) return;
    list->sq[slot] = *sq;
    list->cost[slot] = cost;
    list->id[slot] = id;
    if (list->count < SQFFD__SQ_KEEP) list->count++;
}

/* Starts: each principal axis of the start set as the local z, times the
   shape seeds; when two eigenvalues are close their axes are arbitrary
   within their plane, so that basis is also tried turned by 45 degrees in
   it. Each start gets a few LM iterations on the screening subsample. */
static void sqffd__sq_screen(sqffd__sq_fit *fit, const double *pts, size_t m, const double *screen, size_t m_screen,
                             double *hist, sqffd__sq_shortlist *list)
{
    /* (e1, e2) seeds: round, then the pairs a start cannot get to from there */
    static const double shape_seeds[][2] = {{1.0, 1.0}, {1.7, 0.3}, {0.3, 1.7}, {1.7, 1.7}};
    const int n_seeds = (int)(sizeof shape_seeds / sizeof shape_seeds[0]);
    double centre[3], cov[9], values[3], axes[9];
    int basis, s, id = 0;
    sqffd__sq_moments(pts, m, centre, cov);
    sqffd_sym3_eigen(cov, values, axes);
    list->count = 0;
    for (basis = 0; basis < 3 && fit->status == SQFFD_OK; basis++) {
        double b_axes[9], b_size[3];
        memcpy(b_axes, axes, sizeof b_axes);
        if (basis > 0) { /* basis 1: eigenvalues 0 and 1 close, turn about axis 2; basis 2: 1 and 2, about 0 */
            double ratio = basis == 1 ? values[0] / values[1] : values[1] / values[2], turn[3] = {0.0, 0.0, 0.0};
            if (!(ratio >= SQFFD__SQ_CLOSE_RATIO)) continue;
            turn[basis == 1 ? 2 : 0] = 0.25 * SQFFD__SQ_PI;
            sqffd__sq_rotate(b_axes, turn);
        }
        sqffd__sq_initial_sizes(pts, m, centre, b_axes, hist, b_size);
        for (s = 0; s < 3 * (basis ? SQFFD__SQ_TURNED_SEEDS : n_seeds) && fit->status == SQFFD_OK; s++, id++) {
            sqffd_superquadric cur;
            double cost;
            int j;
            memset(&cur, 0, sizeof cur);
            for (j = 0; j < 3; j++) { /* cyclic column permutation: still a rotation */
                int col = (j + s) % 3;
                cur.rotation[j] = b_axes[col];
                cur.rotation[3 + j] = b_axes[3 + col];
                cur.rotation[6 + j] = b_axes[6 + col];
                cur.size[j] = b_size[col];
                cur.center[j] = centre[j];
            }
            cur.shape[0] = shape_seeds[s / 3][0];
            cur.shape[1] = shape_seeds[s / 3][1];
            sqffd__sq_project(fit, &cur);
            sqffd__sq_optimize(fit, &cur, screen, NULL, m_screen, SQFFD__SQ_START_ITERATIONS, &cost);
            sqffd__sq_shortlist_add(list, &cur, cost, id);
            if (cost < SQFFD__SQ_EXACT * (double)m_screen) return; /* exact: no start can do better */
        }
    }
}

/* The twin of a fit whose a1 and a2 are close: turned 45 degrees about its
   z, with e2 -> 2 - e2 (a square cross-section and a diamond are the same
   shape turned, and the LM cannot get from one to the other). Sizes scale
   by 2^((1 - e2)/2): sqrt 2 from square to diamond, 1 for a circle.
   Returns 0 when a1 and a2 differ too much for a twin. */
static int sqffd__sq_twin(const sqffd__sq_fit *fit, const sqffd_superquadric *sq, sqffd_superquadric *twin)
{
    double lo = sq->size[0] < sq->size[1] ? sq->size[0] : sq->size[1];
    double hi = sq->size[0] < sq->size[1] ? sq->size[1] : sq->size[0];
    double turn[3] = {0.0, 0.0, 0.25 * SQFFD__SQ_PI};
    if (lo < SQFFD__SQ_CLOSE_RATIO * hi) return 0;
    *twin = *sq;
    sqffd__sq_rotate(twin->rotation, turn);
    twin->size[0] = twin->size[1] = 0.5 * (lo + hi) * pow(2.0, 0.5 * (1.0 - sq->shape[1]));
    twin->shape[1] = 2.0 - sq->shape[1];
    twin->taper[0] = twin->taper[1] = 0.5 * (sq->taper[0] + sq->taper[1]);
    sqffd__sq_project(fit, twin);
    return 1;
}

/* Point sets of one fit. */
typedef struct sqffd__sq_sets {
    const double *polish;  /* an even subsample of all points */
    size_t m_polish;
    const double *start;   /* the points the starts came from (robust mode: the dense polish points) */
    size_t m_start;
} sqffd__sq_sets;

/* Run a candidate to convergence on the polish points. Robust mode only
   ranks it by its cost on the start set (the polish points without the
   isolated ones): the EM rounds that follow do the fitting. Returns its cost. */
static double sqffd__sq_polish(sqffd__sq_fit *fit, sqffd_superquadric *sq, const sqffd__sq_sets *sets, int *converged)
{
    double cost;
    if (fit->opt->robust) {
        *converged = 0;
        return sqffd__sq_accumulate(fit, sq, sets->start, NULL, sets->m_start, NULL, NULL);
    }
    *converged = sqffd__sq_optimize(fit, sq, sets->polish, NULL, sets->m_polish, fit->opt->max_iterations, &cost);
    return cost;
}

SQFFD_DEF sqffd_result sqffd_sq_fit(const double *points, size_t n, const sqffd_sq_fit_options *options,
                                    sqffd_superquadric *sq, sqffd_sq_fit_report *report,
                                    void *workspace, size_t workspace_size)
{
    sqffd_sq_fit_options defaults = sqffd_sq_fit_options_default();
    const sqffd_sq_fit_options *o = options ? options : &defaults;
    size_t m_polish = n < SQFFD__SQ_POLISH ? n : SQFFD__SQ_POLISH, m_start, m_screen, i;
    sqffd__sq_shortlist list;
    sqffd__sq_sets sets;
    sqffd__arena arena;
    sqffd__sq_work w;
    sqffd__sq_fit fit;
    sqffd_superquadric best, twin;
    sqffd__sq_mixture mix; /* robust mode's mixture */
    double centroid[3], scale, centre[3], cov[9], values[3], axes[9], best_cost = 0.0;
    const double *start_pts, *weights;
    double rms;
    int k, best_start = 0, converged = 0;
    if (!points || !sq || !sqffd__sq_options_valid(o)) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (n < SQFFD_SQ_FIT_MIN_POINTS) return SQFFD_ERROR_TOO_FEW_POINTS;
    if (!workspace) return SQFFD_ERROR_WORKSPACE_TOO_SMALL;
    sqffd__arena_init(&arena, workspace, workspace_size);
    sqffd__sq_fit_layout(&arena, n, o, &w);
    if (arena.overflow) return SQFFD_ERROR_WORKSPACE_TOO_SMALL;
    for (i = 0; i < n; i++)
        if (!sqffd__finite3(points + 3 * i)) return SQFFD_ERROR_NON_FINITE;
    if (!sqffd__sq_normalize(points, n, w.points, centroid, &scale)) return SQFFD_ERROR_DEGENERATE;
    sqffd__sq_moments(w.points, n, centre, cov);
    sqffd_sym3_eigen(cov, values, axes);
    if (!(values[0] > SQFFD__SQ_FLAT_RATIO * values[2])) return SQFFD_ERROR_DEGENERATE; /* coplanar or collinear */

    memset(&fit, 0, sizeof fit);
    fit.opt = o;
    fit.npar = o->taper ? SQFFD__SQ_NPAR : SQFFD__SQ_P_TAPER;
    fit.cost = (int)o->cost;
    fit.status = SQFFD_OK;
    fit.size_min = 1e-3;
    fit.ncg_work = w.ncg;
    fit.ncg_size = w.ncg_size;
    for (k = 0; k < 3; k++) {
        double lo = w.points[k], hi = w.points[k];
        for (i = 1; i < n; i++) {
            double v = w.points[3 * i + (size_t)k];
            if (v < lo) lo = v;
            if (v > hi) hi = v;
        }
        fit.box_mid[k] = 0.5 * (lo + hi);
        fit.box_half[k] = 0.5 * (hi - lo);
    }
    fit.box_volume = 8.0 * fit.box_half[0] * fit.box_half[1] * fit.box_half[2];

    /* The starts come from all points, or in robust mode from the polish
       subsample without its isolated points. Every start is screened on a
       small subsample, the best few run to convergence on a larger one
       (polish), and the winner on all points. */
    sqffd__sq_subsample(w.points, n, w.polish, m_polish);
    start_pts = w.points;
    m_start = n;
    if (o->robust) {
        m_start = sqffd__sq_dense_points(w.polish, m_polish, w.dense, w.weights, w.tree, w.tree_size);
        start_pts = w.dense;
        if (m_start < SQFFD_SQ_FIT_MIN_POINTS) { start_pts = w.polish; m_start = m_polish; }
    }
    m_screen = m_start < SQFFD__SQ_SCREEN ? m_start : SQFFD__SQ_SCREEN;
    sqffd__sq_subsample(start_pts, m_start, w.screen, m_screen);
    sqffd__sq_screen(&fit, start_pts, m_start, w.screen, m_screen, w.hist, &list);

    sets.polish = w.polish;
    sets.m_polish = m_polish;
    sets.start = start_pts;
    sets.m_start = m_start;
    for (k = 0; k < list.count && fit.status == SQFFD_OK; k++) {
        double cost = list.cost[k];
        int polished = 0;
        if (k > 0 && (list.cost[0] < SQFFD__SQ_CLEAR_WIN * list.cost[k] || best_cost < SQFFD__SQ_EXACT * (double)m_polish))
            break; /* the rest are far behind, or the best is exact */
        if (m_polish > m_screen || o->robust) cost = sqffd__sq_polish(&fit, &list.sq[k], &sets, &polished);
        if (k == 0 || cost < best_cost) {
            best = list.sq[k];
            best_cost = cost;
            best_start = list.id[k];
            converged = polished;
        }
    }
    if (fit.status == SQFFD_OK && sqffd__sq_twin(&fit, &best, &twin)) {
        int twin_converged;
        double cost = sqffd__sq_polish(&fit, &twin, &sets, &twin_converged);
        if (cost < best_cost) {
            best = twin;
            best_cost = cost;
            converged = twin_converged;
        }
    }
    if (o->robust && fit.status == SQFFD_OK) {
        /* EM from the fit's robust spread on the start set: on the polish
           subsample, then on all points */
        int moved;
        mix.sigma2 = sqffd__sq_robust_d2(&best, start_pts, m_start, w.weights);
        mix.prior = (double)m_start / (double)m_polish;
        mix.weights = w.weights;
        moved = sqffd__sq_em(&fit, &best, w.polish, m_polish, &mix, o->robust_rounds, &converged);
        if (m_polish < n) moved = sqffd__sq_em(&fit, &best, w.points, n, &mix, SQFFD__SQ_FULL_ROUNDS, &converged);
        if (moved) sqffd__sq_reweight(&mix, &best, w.points, n, fit.box_volume); /* the weights at the result */
    } else if (fit.status == SQFFD_OK && m_polish < n) {
        converged = sqffd__sq_optimize(&fit, &best, w.points, NULL, n, o->max_iterations, &best_cost);
    }
    if (fit.status != SQFFD_OK) return fit.status;

    /* A fit that describes the data closely may reach past their box (a
       partial view: the data show part of the shape); any other is kept
       within the box enlarged by the margin. */
    weights = o->robust ? w.weights : NULL;
    /* robust mode: the last EM step's sigma^2 is this weighted mean already */
    rms = sqrt(o->robust ? mix.sigma2 : sqffd__sq_mean_d2(&best, w.points, weights, n));
    if (rms > SQFFD__SQ_CLOSE_FIT * (best.size[0] + best.size[1] + best.size[2]) / 3.0) {
        sqffd__sq_contain(&fit, &best);
        rms = sqrt(sqffd__sq_mean_d2(&best, w.points, weights, n));
    }
    if (report) {
        double sum_w = 0.0, final = sqffd__sq_accumulate(&fit, &best, w.points, weights, n, NULL, NULL);
        for (i = 0; i < n; i++) sum_w += weights ? weights[i] : 1.0;
        report->iterations = fit.iterations;
        report->cost = final * (o->cost == SQFFD_SQ_COST_SOLINA ? scale * scale * scale : scale * scale);
        report->rms_radial = scale * rms;
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

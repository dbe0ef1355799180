/* The heart wall on real hearts: the endocardial and epicardial contours of
   ../shared/data/cardiac (pig cine MRI, ED and ES short-axis stacks, first
   contouring, slice spacing 20 units; see its README), each surface tracked
   as `sqffd track` tracks a stack (closed by its lids, default options),
   then sqffd_wall with the endocardium's frame and both surfaces' stacks
   (the epicardium's for the myocardium's slab, the endocardium's for the
   thickness radially in the slices' planes, as the contours' below):
   - mass: the ED and ES myocardial volume against Simpson's (myocardium.csv:
     the myocardial area sums x the spacing), as ratios; and the same from
     the contours as thick-slice label maps (label_maps.h: cavity 3,
     myocardium 2 inside the epicardial contours), tracked as `sqffd track
     --label 3 --myocardium-label 2` tracks them (closed volumes);
   - thickening: the contours' own, measured here: per slice holding both
     contours, rays from the endocardial contour's area centroid every 2
     degrees, the thickness the ray's last crossing of the epicardial
     contour less its last crossing of the endocardial one, pooled into six
     60-degree sectors (from the image's +x axis); a sector's thickening is
     its mean ES thickness over its mean ED thickness less 1, over all its
     slices; global: the same over all sectors. The library's sectors pool
     each frame's measured wall vertices by their angle in that frame about
     that frame's centroid of them, in the same six bins, weighted by that
     frame's vertex areas, as sqffd_wall pools its segments (the data give
     no septum, so the AHA segments are sectors from a superquadric axis;
     the bins are the image's);
   - infarcted against control pigs (Mann-Whitney AUC, 1: every infarcted
     exam scores above every control): the library's share of dysfunctional
     segments (thickening < 20 %), the contours' share of slice sectors
     thickening less than 20 %, and each global thickening (lower: infarct);
   - time: a two-frame endo + epi track and the wall analysis against the
     endo-only track and motion analysis. */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include "../examples/sqffd_io.h"
#include "../examples/sqffd_synth.h"
#include "bench.h"
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include "label_maps.h"

#define CARDIAC_DIR "../shared/data/cardiac"
#define MAX_EXAMS 32
#define SECTORS 6
#define RAY_STEP 2 /* degrees */

typedef struct exam {
    char name[16];
    int infarcted;
    double simpson_myo[2]; /* area sums x 20 */
    double mass_ratio[2], label_mass_ratio[2], wall_thickening, contour_thickening, dysfunctional_share, contour_share;
    double sector[SECTORS], contour_sector[SECTORS];
    double endo_ms, wall_ms;
} exam;

static int read_surface(const char *exam_name, const char *file, double **points, size_t *count)
{
    char path[256], err[256];
    unsigned char *data;
    size_t size;
    int failed;
    snprintf(path, sizeof path, CARDIAC_DIR "/%s/obs0_rep0/%s.xyz", exam_name, file);
    if (sqffd_io_load_file(path, &data, &size, err, sizeof err)) return -1;
    failed = sqffd_io_read_points(data, size, path, points, count, err, sizeof err);
    free(data);
    return failed ? -1 : 0;
}

/* The last crossing (largest t) of the ray c + t (cos a, sin a) with slice
   z's closed contour (consecutive points at that z); 0 if none. */
static double ray_contour(const double *p, size_t n, double z, const double c[2], double a)
{
    double best = 0.0, d[2] = {cos(a), sin(a)};
    size_t i, first = n, last = n;
    for (i = 0; i < n; i++)
        if (p[3 * i + 2] == z) {
            if (first == n) first = i;
            last = i;
        }
    for (i = first; first < n && i <= last; i++) {
        const double *u = p + 3 * i, *v = p + 3 * (i == last ? first : i + 1);
        double e[2] = {v[0] - u[0], v[1] - u[1]}, w[2] = {u[0] - c[0], u[1] - c[1]}, det = d[0] * e[1] - d[1] * e[0], t, s;
        if (det == 0.0) continue;
        t = (w[0] * e[1] - w[1] * e[0]) / det;
        s = (w[0] * d[1] - w[1] * d[0]) / det;
        if (s >= 0.0 && s <= 1.0 && t > best) best = t;
    }
    return best;
}

/* Slice z's contour area centroid (shoelace); 0 if the slice is empty. */
static int contour_centroid(const double *p, size_t n, double z, double c[2])
{
    double area = 0.0, m[2] = {0.0, 0.0};
    size_t i, first = n, last = n;
    for (i = 0; i < n; i++)
        if (p[3 * i + 2] == z) {
            if (first == n) first = i;
            last = i;
        }
    if (first == n) return 0;
    for (i = first; i <= last; i++) {
        const double *u = p + 3 * i, *v = p + 3 * (i == last ? first : i + 1);
        double t = u[0] * v[1] - u[1] * v[0];
        area += t;
        m[0] += t * (u[0] + v[0]);
        m[1] += t * (u[1] + v[1]);
    }
    c[0] = m[0] / (3.0 * area);
    c[1] = m[1] / (3.0 * area);
    return 1;
}

/* The contours' wall thickness of one frame: sums[k] over slice sectors k,
   and per slice sector its mean into slice_sector[][k] (NaN where absent). */
static void contour_thickness(const double *endo, size_t ne, const double *epi, size_t np, double sums[SECTORS][2],
                              double slice_sector[64][SECTORS])
{
    size_t i;
    int s = 0, k, a;
    double z = NAN;
    for (i = 0; i < ne && s < 64; i++) {
        double c[2];
        if (endo[3 * i + 2] == z) continue;
        z = endo[3 * i + 2];
        for (k = 0; k < SECTORS; k++) slice_sector[s][k] = NAN;
        if (contour_centroid(endo, ne, z, c) && ray_contour(epi, np, z, c, 0.0) > 0.0)
            for (k = 0; k < SECTORS; k++) {
                double sum = 0.0;
                int rays = 0;
                for (a = 0; a < 60; a += RAY_STEP) {
                    double angle = (60.0 * k + a + 0.5 * RAY_STEP) * 3.14159265358979323846 / 180.0;
                    double r_endo = ray_contour(endo, ne, z, c, angle), r_epi = ray_contour(epi, np, z, c, angle);
                    if (r_endo > 0.0 && r_epi > r_endo) {
                        sum += r_epi - r_endo;
                        rays++;
                    }
                }
                if (!rays) continue;
                slice_sector[s][k] = sum / rays;
                sums[k][0] += sum / rays;
                sums[k][1] += 1.0;
            }
        s++;
    }
}

/* One frame's wall thickness pooled into the six sectors (sums[k]: area x
   thickness, area): its measured vertices x (thickness not NaN) by their
   angle about their centroid, weighted by their areas on the model's mesh. */
static int frame_sectors(const sqffd_model *model, const double *x, const double *thickness, double sums[SECTORS][2])
{
    size_t m = 0, nt = 0, i, v;
    uint32_t *tri;
    double *area, centre[2] = {0.0, 0.0}, count = 0.0;
    int c;
    sqffd_model_mesh_size(model->grid[0], model->grid[1], &m, &nt);
    tri = (uint32_t *)malloc(3 * nt * sizeof *tri);
    area = (double *)calloc(m, sizeof *area);
    if (!tri || !area || sqffd_model_mesh(model, model->grid[0], model->grid[1], NULL, tri) != SQFFD_OK) {
        free(tri);
        free(area);
        return -1;
    }
    for (i = 0; i < nt; i++) { /* a third of each triangle's area to each of its vertices */
        const double *a = x + 3 * tri[3 * i], *b = x + 3 * tri[3 * i + 1], *d = x + 3 * tri[3 * i + 2];
        double e1[3], e2[3], n[3];
        for (c = 0; c < 3; c++) { e1[c] = b[c] - a[c]; e2[c] = d[c] - a[c]; }
        n[0] = e1[1] * e2[2] - e1[2] * e2[1];
        n[1] = e1[2] * e2[0] - e1[0] * e2[2];
        n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        for (c = 0; c < 3; c++) area[tri[3 * i + c]] += sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) / 6.0;
    }
    for (v = 0; v < m; v++)
        if (!isnan(thickness[v])) {
            centre[0] += x[3 * v];
            centre[1] += x[3 * v + 1];
            count += 1.0;
        }
    for (v = 0; v < m; v++) {
        double a;
        if (isnan(thickness[v])) continue;
        a = atan2(x[3 * v + 1] - centre[1] / count, x[3 * v] - centre[0] / count) * 180.0 / 3.14159265358979323846;
        c = (int)((a < 0.0 ? a + 360.0 : a) / 60.0) % SECTORS;
        sums[c][0] += area[v] * thickness[v];
        sums[c][1] += area[v];
    }
    free(tri);
    free(area);
    return 0;
}

/* A surface's two frames tracked as the CLI does (stacks, lids; stacks
   NULL: as they are, as label maps' surfaces); stacks out. */
static int track_surface(double *points[2], size_t counts[2], sqffd_stack stacks[2], sqffd_model models[2])
{
    sqffd_track_options o = sqffd_track_options_default();
    size_t size, done, n, k;
    void *work;
    int found, failed;
    for (k = 0; k < 2 && stacks; k++) {
        double *grown;
        if (sqffd_stack_detect(points[k], counts[k], &stacks[k], &found) != SQFFD_OK || !found) return -1;
        if (sqffd_stack_lids(points[k], counts[k], &stacks[k], NULL, 0, &n) != SQFFD_OK) return -1;
        if (!(grown = (double *)realloc(points[k], 3 * (counts[k] + n) * sizeof(double)))) return -1;
        points[k] = grown;
        if (sqffd_stack_lids(points[k], counts[k], &stacks[k], points[k] + 3 * counts[k], n, &n) != SQFFD_OK) return -1;
        counts[k] += n;
    }
    if (sqffd_track_workspace_size(counts, 2, &o, &size) != SQFFD_OK || !(work = malloc(size))) return -1;
    failed = sqffd_track((const double *const *)points, counts, 2, &o, models, NULL, &done, work, size) != SQFFD_OK;
    free(work);
    return failed ? -1 : 0;
}

/* The same contours as label maps (cavity 3, myocardium 2 inside the
   epicardial contours), their label-3 surface and the surface of labels 2
   and 3 together tracked, as `sqffd track --label 3 --myocardium-label 2`
   does: the myocardium's closed volumes at ED and ES against Simpson's. */
static int label_mass(exam *e, double *const raw[4], const size_t raw_counts[4])
{
    double *cavity[2] = {NULL, NULL}, *outer[2] = {NULL, NULL};
    size_t counts[2][2], size = 0;
    sqffd_model endo[2], epi[2];
    sqffd_motion_report motion;
    sqffd_motion_outputs mout;
    sqffd_wall_report wall;
    unsigned char *segment = NULL;
    void *work = NULL;
    int k, status = -1;
    if (label_map_frames(raw, raw_counts, raw + 2, raw_counts + 2, 20.0, cavity, counts[0], outer, counts[1]) ||
        track_surface(cavity, counts[0], NULL, endo) || track_surface(outer, counts[1], NULL, epi))
        goto done;
    sqffd_model_mesh_size(endo->grid[0], endo->grid[1], &size, NULL);
    memset(&mout, 0, sizeof mout);
    if (!(mout.segment = segment = (unsigned char *)malloc(size)) ||
        sqffd_motion_workspace_size(endo, 2, &size) != SQFFD_OK || !(work = malloc(size)) ||
        sqffd_motion(endo, 2, NULL, &mout, &motion, work, size) != SQFFD_OK)
        goto done;
    free(work);
    if (sqffd_wall_workspace_size(endo, epi, 2, &size) != SQFFD_OK || !(work = malloc(size)) ||
        sqffd_wall(endo, epi, 2, &motion, segment, NULL, NULL, &wall, work, size) != SQFFD_OK)
        goto done;
    for (k = 0; k < 2; k++) e->label_mass_ratio[k] = (k ? wall.myocardium_es : wall.myocardium_ed) / e->simpson_myo[k];
    status = 0;
done:
    for (k = 0; k < 2; k++) {
        free(cavity[k]);
        free(outer[k]);
    }
    free(segment);
    free(work);
    return status;
}

static int run(exam *e)
{
    static const char *const files[4] = {"ed", "es", "ed_epi", "es_epi"};
    double *raw[4] = {NULL, NULL, NULL, NULL}, *points[4] = {NULL, NULL, NULL, NULL}, sums[2][SECTORS][2];
    double slices[2][64][SECTORS], lib[2][SECTORS][2], start;
    size_t raw_counts[4], counts[4], m, size, v, f;
    sqffd_stack stacks[4];
    sqffd_model endo[2], epi[2];
    sqffd_motion_options mo = sqffd_motion_options_default();
    sqffd_motion_outputs mout;
    sqffd_motion_report motion;
    sqffd_wall_options wo = sqffd_wall_options_default();
    sqffd_wall_outputs wout;
    sqffd_wall_report wall;
    unsigned char *segment = NULL;
    double *ted = NULL, *tes = NULL, *traj = NULL;
    void *work = NULL;
    int k, status = -1, flagged = 0, thin = 0, total = 0;
    for (k = 0; k < 4; k++) {
        if (read_surface(e->name, files[k], &raw[k], &raw_counts[k])) goto done;
        counts[k] = raw_counts[k];
        if (!(points[k] = (double *)malloc(3 * counts[k] * sizeof(double)))) goto done;
        memcpy(points[k], raw[k], 3 * counts[k] * sizeof(double));
    }
    /* the contours' thickening */
    memset(sums, 0, sizeof sums);
    for (k = 0; k < 2; k++) contour_thickness(raw[k], raw_counts[k], raw[k + 2], raw_counts[k + 2], sums[k], slices[k]);
    {
        double ed = 0.0, es = 0.0;
        for (k = 0; k < SECTORS; k++) {
            e->contour_sector[k] = (sums[1][k][0] / sums[1][k][1]) / (sums[0][k][0] / sums[0][k][1]) - 1.0;
            ed += sums[0][k][0] / sums[0][k][1];
            es += sums[1][k][0] / sums[1][k][1];
        }
        e->contour_thickening = es / ed - 1.0;
    }
    if (label_mass(e, raw, raw_counts)) goto done;
    start = bench_now();
    if (track_surface(points, counts, stacks, endo)) goto done;
    mo.stacks = stacks;
    sqffd_model_mesh_size(endo->grid[0], endo->grid[1], &m, NULL);
    segment = (unsigned char *)malloc(m);
    traj = (double *)malloc(6 * m * sizeof(double));
    if (!segment || !traj || sqffd_motion_workspace_size(endo, 2, &size) != SQFFD_OK || !(work = malloc(size))) goto done;
    memset(&mout, 0, sizeof mout);
    mout.segment = segment;
    mout.trajectories = traj;
    if (sqffd_motion(endo, 2, &mo, &mout, &motion, work, size) != SQFFD_OK) goto done;
    e->endo_ms = 1e3 * (bench_now() - start);
    free(work);
    work = NULL;
    if (track_surface(points + 2, counts + 2, stacks + 2, epi)) goto done;
    ted = (double *)malloc(m * sizeof(double));
    tes = (double *)malloc(m * sizeof(double));
    wo.stacks = stacks + 2;
    wo.endo_stacks = stacks;
    memset(&wout, 0, sizeof wout);
    wout.thickness_ed = ted;
    wout.thickness_es = tes;
    if (!ted || !tes || sqffd_wall_workspace_size(endo, epi, 2, &size) != SQFFD_OK || !(work = malloc(size)) ||
        sqffd_wall(endo, epi, 2, &motion, segment, &wo, &wout, &wall, work, size) != SQFFD_OK)
        goto done;
    e->wall_ms = 1e3 * (bench_now() - start);
    for (k = 0; k < 2; k++) e->mass_ratio[k] = (k ? wall.myocardium_es : wall.myocardium_ed) / e->simpson_myo[k];
    e->wall_thickening = wall.thickening;
    for (k = 0; k < SQFFD_SEGMENTS; k++) {
        flagged += wall.segments[k].dysfunctional;
        total += wall.segments[k].thickness_ed > 0.0;
    }
    e->dysfunctional_share = (double)flagged / total;
    /* the library's six sectors: each frame's own measured vertices, by their angle then */
    memset(lib, 0, sizeof lib);
    if (frame_sectors(endo + motion.ed_frame, traj + 3 * m * motion.ed_frame, ted, lib[0]) ||
        frame_sectors(endo + motion.es_frame, traj + 3 * m * motion.es_frame, tes, lib[1]))
        goto done;
    for (k = 0; k < SECTORS; k++) e->sector[k] = (lib[1][k][0] / lib[1][k][1]) / (lib[0][k][0] / lib[0][k][1]) - 1.0;
    /* the contours' share of slice sectors thickening < 20 %: ED and ES slices paired by rank from the
       first slice (the files list them in the same order) */
    {
        int slices_of[2] = {0, 0}, pairs = 0, i;
        for (f = 0; f < 2; f++) {
            double last = NAN;
            for (v = 0; v < raw_counts[f]; v++)
                if (raw[f][3 * v + 2] != last) {
                    last = raw[f][3 * v + 2];
                    slices_of[f]++;
                }
        }
        for (i = 0; i < slices_of[0] && i < slices_of[1] && i < 64; i++)
            for (k = 0; k < SECTORS; k++) {
                double a = slices[0][i][k], b = slices[1][i][k];
                if (isnan(a) || isnan(b)) continue;
                thin += b / a - 1.0 < 0.2;
                pairs++;
            }
        e->contour_share = pairs ? (double)thin / pairs : NAN;
    }
    status = 0;
done:
    for (k = 0; k < 4; k++) {
        free(raw[k]);
        free(points[k]);
    }
    free(segment);
    free(traj);
    free(ted);
    free(tes);
    free(work);
    return status;
}

/* Mann-Whitney AUC of score: infarcted above control. */
static double auc(const exam *e, int n, const double *score)
{
    double wins = 0.0, pairs = 0.0;
    int i, j;
    for (i = 0; i < n; i++)
        for (j = 0; j < n; j++)
            if (e[i].infarcted && !e[j].infarcted) {
                wins += score[i] > score[j] ? 1.0 : score[i] == score[j] ? 0.5 : 0.0;
                pairs += 1.0;
            }
    return wins / pairs;
}

static double pearson(const double *a, const double *b, int n)
{
    double ma = 0.0, mb = 0.0, sab = 0.0, saa = 0.0, sbb = 0.0;
    int i;
    for (i = 0; i < n; i++) { ma += a[i] / n; mb += b[i] / n; }
    for (i = 0; i < n; i++) {
        sab += (a[i] - ma) * (b[i] - mb);
        saa += (a[i] - ma) * (a[i] - ma);
        sbb += (b[i] - mb) * (b[i] - mb);
    }
    return sab / sqrt(saa * sbb);
}

int main(void)
{
    exam exams[MAX_EXAMS];
    char line[256], name[16], observer[16];
    double ed, es, ratios[MAX_EXAMS], label_ratios[MAX_EXAMS], a[MAX_EXAMS * SECTORS], b[MAX_EXAMS * SECTORS], score[2][MAX_EXAMS];
    double diff = 0.0, endo_ms[MAX_EXAMS], wall_ms[MAX_EXAMS];
    struct stat st;
    FILE *f;
    int n = 0, i, k, pairs = 0;
    if (stat(CARDIAC_DIR, &st) != 0 || !(f = fopen(CARDIAC_DIR "/myocardium.csv", "r"))) {
        printf("bench_wall: %s absent (see its README): skipped\n", CARDIAC_DIR);
        return 0;
    }
    if (!fgets(line, sizeof line, f)) line[0] = 0;
    while (n < MAX_EXAMS && fgets(line, sizeof line, f))
        if (sscanf(line, "%15[^,],%15[^,],%lf,%lf", name, observer, &ed, &es) == 4 && strcmp(observer, "obs0_rep0") == 0) {
            memset(&exams[n], 0, sizeof exams[n]);
            snprintf(exams[n].name, sizeof exams[n].name, "%s", name);
            /* the README's groups: pig c1 (A32 A33 A35 A44) is the control */
            exams[n].infarcted = !(strcmp(name, "A32") == 0 || strcmp(name, "A33") == 0 || strcmp(name, "A35") == 0 ||
                                   strcmp(name, "A44") == 0);
            exams[n].simpson_myo[0] = 20.0 * ed;
            exams[n].simpson_myo[1] = 20.0 * es;
            n++;
        }
    fclose(f);
    printf("bench_wall: endo + epi tracked, sqffd_wall, on %d exams (obs0_rep0, spacing 20)\n", n);
    printf("  exam  group   mass ED  mass ES  model  label maps mass  thickening %%   dysfunctional  contours <20%%   endo ms  endo+epi ms\n"
           "                /Simpson /Simpson  ES/ED  ED/Simp ES/Simp  model contours  segments       slice sectors\n");
    for (i = 0; i < n; i++) {
        exam *e = exams + i;
        if (run(e)) {
            printf("  %s: failed\n", e->name);
            return 1;
        }
        printf("  %-5s %-7s %7.3f  %7.3f  %5.3f  %7.3f %7.3f  %6.1f %7.1f   %10.0f %%  %12.0f %%  %8.0f  %11.0f\n", e->name,
               e->infarcted ? "infarct" : "control", e->mass_ratio[0], e->mass_ratio[1],
               e->mass_ratio[1] * e->simpson_myo[1] / (e->mass_ratio[0] * e->simpson_myo[0]), e->label_mass_ratio[0],
               e->label_mass_ratio[1], 100.0 * e->wall_thickening,
               100.0 * e->contour_thickening, 100.0 * e->dysfunctional_share, 100.0 * e->contour_share, e->endo_ms,
               e->wall_ms);
        ratios[i] = e->mass_ratio[0];
        label_ratios[i] = e->label_mass_ratio[0];
        diff += fabs(e->wall_thickening - e->contour_thickening) / n;
        for (k = 0; k < SECTORS; k++, pairs++) {
            a[pairs] = e->sector[k];
            b[pairs] = e->contour_sector[k];
        }
        score[0][i] = e->dysfunctional_share;
        score[1][i] = e->contour_share;
        endo_ms[i] = e->endo_ms;
        wall_ms[i] = e->wall_ms;
    }
    {
        double lo = ratios[0], hi = ratios[0];
        for (i = 1; i < n; i++) { lo = fmin(lo, ratios[i]); hi = fmax(hi, ratios[i]); }
        printf("  mass (ED) / Simpson's: median %.3f, range %.3f - %.3f\n", bench_median(ratios, n), lo, hi);
        for (lo = hi = label_ratios[0], i = 1; i < n; i++) {
            lo = fmin(lo, label_ratios[i]);
            hi = fmax(hi, label_ratios[i]);
        }
        printf("  label maps' mass (ED) / Simpson's: median %.3f, range %.3f - %.3f\n", bench_median(label_ratios, n), lo,
               hi);
    }
    printf("  global thickening: mean |model - contours| %.2f points\n", 100.0 * diff);
    printf("  per sector (6 x %d exams): r = %.2f\n", n, pearson(a, b, pairs));
    for (i = 0; i < n; i++) a[i] = -exams[i].wall_thickening, b[i] = -exams[i].contour_thickening;
    printf("  infarcted vs control AUC: dysfunctional segments %.2f, contours' slice sectors < 20%% %.2f, "
           "global thickening %.2f (contours' %.2f)\n", auc(exams, n, score[0]), auc(exams, n, score[1]),
           auc(exams, n, a), auc(exams, n, b));
    printf("  time: endo + epi %.0f ms against endo only %.0f ms (medians): %.2fx\n", bench_median(wall_ms, n),
           bench_median(endo_ms, n), bench_median(wall_ms, n) / bench_median(endo_ms, n));
    return 0;
}

/* phantom_truth.h - scores a tracked phantom sequence against the phantom's
   truth (examples/sqffd_phantom.h), for the tests and the tracking bench.

   Every vertex of the end-diastolic model mesh is matched to its nearest
   material point of the phantom at ED (phantom_lv_locate), which gives its
   true label (wall, hypokinetic zone, valve plane) and its true ED -> ES
   motion. Measured over the vertices the library calls wall (segment > 0)
   and the phantom calls wall or zone, each weighted by its area (a third of
   its triangles'):
   - dice: 2 |flagged and zone| / (|flagged| + |zone|);
   - excursion_ratio: the model's mean inward excursion on the normal wall
     (label wall, not flagged by the truth) over the truth's, both along the
     model's ED normal; displacement_ratio the same for the whole motion;
   - per AHA segment, the share of its area the true zone covers;
   - ef_error: the library's ejection fraction less the phantom's true one. */
#ifndef SQFFD_PHANTOM_TRUTH_H
#define SQFFD_PHANTOM_TRUTH_H

#include "../sqffd.h"
#include "../examples/sqffd_phantom.h"
#include <stdlib.h>
#include <string.h>

typedef struct phantom_score {
    double dice;
    double zone_share;               /* of the wall's area in the true zone */
    double excursion_ratio, displacement_ratio;
    double coverage[SQFFD_SEGMENTS]; /* of segment k + 1 by the true zone */
    int hypokinetic[SQFFD_SEGMENTS]; /* the library's flag */
    double ef, true_ef, ef_error;    /* fractions */
    int zone_vertices, lid_in_wall;  /* vertices in the true zone; valve-plane vertices the library calls wall */
    int lid_vertices;                /* the valve-plane vertices */
} phantom_score;

/* Returns 0, or -1 when the motion analysis fails or memory runs out. */
static int phantom_score_track(const phantom_lv *p, const sqffd_model *models, size_t frames,
                               const sqffd_motion_options *options, phantom_score *score)
{
    size_t m = 0, nt = 0, v, k, size;
    double *traj, *area, *normal, *displacement, *excursion;
    double zone_and_flag = 0.0, zone = 0.0, flag = 0.0, model_exc = 0.0, true_exc = 0.0, model_disp = 0.0;
    double true_disp = 0.0, wall = 0.0, segment_area[SQFFD_SEGMENTS], segment_zone[SQFFD_SEGMENTS];
    unsigned char *low, *segment;
    uint32_t *tri;
    void *work;
    sqffd_motion_outputs out;
    sqffd_motion_report rep;
    int c, status = -1;
    memset(score, 0, sizeof *score);
    sqffd_model_mesh_size(models->grid[0], models->grid[1], &m, &nt);
    traj = (double *)malloc(3 * m * frames * sizeof(double));
    area = (double *)calloc(m, sizeof(double));
    normal = (double *)calloc(3 * m, sizeof(double));
    displacement = (double *)malloc(m * sizeof(double));
    excursion = (double *)malloc(m * sizeof(double));
    low = (unsigned char *)malloc(m);
    segment = (unsigned char *)malloc(m);
    tri = (uint32_t *)malloc(3 * nt * sizeof(uint32_t));
    work = sqffd_motion_workspace_size(models, frames, &size) == SQFFD_OK ? malloc(size) : NULL;
    memset(&out, 0, sizeof out);
    out.trajectories = traj;
    out.displacement = displacement;
    out.excursion = excursion;
    out.low_motion = low;
    out.segment = segment;
    if (!traj || !area || !normal || !displacement || !excursion || !low || !segment || !tri || !work ||
        sqffd_motion(models, frames, options, &out, &rep, work, size) != SQFFD_OK)
        goto done;
    sqffd_model_mesh(models, models->grid[0], models->grid[1], NULL, tri);
    for (k = 0; k < nt; k++) { /* the ED mesh's vertex areas and normals */
        const double *a = traj + 3 * (rep.ed_frame * m + tri[3 * k]), *b = traj + 3 * (rep.ed_frame * m + tri[3 * k + 1]);
        const double *d = traj + 3 * (rep.ed_frame * m + tri[3 * k + 2]);
        double e1[3], e2[3], n[3], third;
        for (c = 0; c < 3; c++) { e1[c] = b[c] - a[c]; e2[c] = d[c] - a[c]; }
        n[0] = e1[1] * e2[2] - e1[2] * e2[1];
        n[1] = e1[2] * e2[0] - e1[0] * e2[2];
        n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        third = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) / 6.0;
        for (c = 0; c < 3; c++) {
            area[tri[3 * k + c]] += third;
            normal[3 * tri[3 * k + c]] += n[0];
            normal[3 * tri[3 * k + c] + 1] += n[1];
            normal[3 * tri[3 * k + c] + 2] += n[2];
        }
    }
    memset(segment_area, 0, sizeof segment_area);
    memset(segment_zone, 0, sizeof segment_zone);
    for (v = 0; v < m; v++) {
        const double *x = traj + 3 * (rep.ed_frame * m + v);
        double move[3], *n = normal + 3 * v, len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        int label = phantom_lv_locate_motion(p, x, move), in_zone = label == PHANTOM_ZONE;
        if (label == PHANTOM_LID) {
            score->lid_vertices++;
            score->lid_in_wall += segment[v] != 0;
            continue;
        }
        if (!segment[v]) continue;
        segment_area[segment[v] - 1] += area[v];
        wall += area[v];
        if (in_zone) {
            segment_zone[segment[v] - 1] += area[v];
            score->zone_vertices++;
            zone += area[v];
            if (low[v]) zone_and_flag += area[v];
        }
        if (low[v]) flag += area[v];
        if (!in_zone && len > 0.0) {
            model_exc += area[v] * excursion[v];
            true_exc -= area[v] * (move[0] * n[0] + move[1] * n[1] + move[2] * n[2]) / len;
            model_disp += area[v] * displacement[v];
            true_disp += area[v] * sqrt(move[0] * move[0] + move[1] * move[1] + move[2] * move[2]);
        }
    }
    score->zone_share = wall > 0.0 ? zone / wall : 0.0;
    score->dice = zone + flag > 0.0 ? 2.0 * zone_and_flag / (zone + flag) : 0.0;
    score->excursion_ratio = true_exc > 0.0 ? model_exc / true_exc : 0.0;
    score->displacement_ratio = true_disp > 0.0 ? model_disp / true_disp : 0.0;
    for (k = 0; k < SQFFD_SEGMENTS; k++) {
        score->coverage[k] = segment_area[k] > 0.0 ? segment_zone[k] / segment_area[k] : 0.0;
        score->hypokinetic[k] = rep.segments[k].hypokinetic;
    }
    score->ef = rep.ejection_fraction;
    score->true_ef = phantom_lv_ejection_fraction(p, (int)frames);
    score->ef_error = score->ef - score->true_ef;
    status = 0;
done:
    free(traj);
    free(area);
    free(normal);
    free(displacement);
    free(excursion);
    free(low);
    free(segment);
    free(tri);
    free(work);
    return status;
}

#endif

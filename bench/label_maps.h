/* Short-axis contour stacks as thick-slice label maps, as a segmentation
   gives them (ACDC's labels: 3 the left-ventricle cavity, 2 the
   myocardium), and the surfaces `sqffd track --label 3` (and
   `--myocardium-label 2`) tracks in them; shared by bench_cardiac and
   bench_wall. Include after sqffd.h (with its implementation),
   examples/sqffd_synth.h and <string.h>. */
#ifndef SQFFD_BENCH_LABEL_MAPS_H
#define SQFFD_BENCH_LABEL_MAPS_H

#define LABEL_PIXEL 4.0   /* contour units */
#define LABEL_RING 2      /* pixels of myocardium (label 2) around the cavity (3) without epicardial contours */
#define LABEL_POINTS 6000 /* a surface evenly sampled down to this, as the CLI's volumes */

/* The surface of a label map's region (labelled: sqffd_iso_options'; the
   largest component) evenly sampled to LABEL_POINTS, into *points
   (malloc'd). */
static int label_surface(const sqffd_volume *v, int labelled, double label, double label2, double **points,
                         size_t *count)
{
    sqffd_iso_options o = sqffd_iso_options_default();
    size_t size = 0, n = 0;
    double *all = NULL;
    void *ws = NULL;
    int ok;
    *points = NULL;
    o.labelled = labelled;
    o.label = label;
    o.label2 = label2;
    o.largest_component = 1;
    ok = sqffd_iso_workspace_size(v, &o, &size) == SQFFD_OK && (ws = malloc(size)) &&
         sqffd_iso_points(v, &o, NULL, NULL, 0, &n, ws, size) == SQFFD_OK && n &&
         (all = (double *)malloc(3 * n * sizeof *all)) && sqffd_iso_points(v, &o, all, NULL, n, &n, ws, size) == SQFFD_OK;
    *count = n < LABEL_POINTS ? n : LABEL_POINTS;
    if (ok && (*points = (double *)malloc(3 * *count * sizeof(double))))
        ok = sqffd_points_subsample(all, n, *count, *points) == SQFFD_OK;
    free(all);
    free(ws);
    return ok && *points ? 0 : -1;
}

/* Both frames rasterised into one label-map geometry (a pixel margin and an
   empty slice beyond the data): the cavity (3) inside each frame's
   endocardial contours; around it, without epicardial contours (epi NULL),
   a ring of LABEL_RING pixels of myocardium (2), else the myocardium inside
   the epicardial contours, outside the cavity. Each frame's label-3 surface
   into cavity[k]; with epi, the surface of labels 2 and 3 together (the
   epicardium, `--myocardium-label 2`) into wall[k] (malloc'd). */
static int label_map_frames(double *const endo[2], const size_t endo_counts[2], double *const epi[2],
                            const size_t epi_counts[2], double spacing, double *cavity[2], size_t cavity_counts[2],
                            double *wall[2], size_t wall_counts[2])
{
    double lo[3], hi[3], origin[3];
    size_t dims[3], k, i;
    int first = 1, status = 0;
    for (k = 0; k < 4; k++) {
        double *const p = k < 2 ? endo[k] : epi ? epi[k - 2] : NULL;
        for (i = 0; p && i < (k < 2 ? endo_counts[k] : epi_counts[k - 2]); i++, first = 0) {
            int a;
            for (a = 0; a < 3; a++) {
                double x = p[3 * i + (size_t)a];
                lo[a] = !first && lo[a] < x ? lo[a] : x;
                hi[a] = !first && hi[a] > x ? hi[a] : x;
            }
        }
    }
    for (k = 0; k < 3; k++) {
        double step = k < 2 ? LABEL_PIXEL : spacing;
        origin[k] = lo[k] - (k < 2 ? 4.0 * LABEL_PIXEL : spacing);
        dims[k] = (size_t)((hi[k] - origin[k]) / step + (k < 2 ? 5.0 : 2.5));
    }
    for (k = 0; k < 2; k++) {
        cavity[k] = NULL;
        if (epi) wall[k] = NULL;
    }
    for (k = 0; k < 2 && !status; k++) {
        size_t voxels = dims[0] * dims[1] * dims[2];
        unsigned char *labels = (unsigned char *)malloc(voxels), *inner = epi ? (unsigned char *)malloc(voxels) : NULL;
        sqffd_volume v;
        if (!labels || (epi && !inner)) {
            free(labels);
            free(inner);
            return -1;
        }
        if (epi) {
            synth_rasterise_stack(epi[k], epi_counts[k], origin, LABEL_PIXEL, spacing, dims, 2, 0, 0, labels);
            synth_rasterise_stack(endo[k], endo_counts[k], origin, LABEL_PIXEL, spacing, dims, 3, 0, 0, inner);
            for (i = 0; i < voxels; i++)
                if (inner[i] == 3) labels[i] = 3;
        } else
            synth_rasterise_stack(endo[k], endo_counts[k], origin, LABEL_PIXEL, spacing, dims, 3, 2, LABEL_RING, labels);
        v = synth_label_volume(labels, dims, origin, LABEL_PIXEL, spacing);
        status = label_surface(&v, 1, 3.0, 0.0, &cavity[k], &cavity_counts[k]);
        if (!status && epi) status = label_surface(&v, 2, 3.0, 2.0, &wall[k], &wall_counts[k]);
        free(labels);
        free(inner);
    }
    return status;
}

#endif

/* What the snippets of README.md and sqffd.h take as given (make snippets:
   tests/snippets.sh wraps them into functions that include this): the
   headers, and the names a snippet uses without declaring them. Only
   compiled (-fsyntax-only), never linked. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include "../sqffd.h"

/* points */
extern const double *points, *pts;
extern size_t n;
extern const void *scan; /* a scanner's records */
/* the model in use */
extern double eta, omega, *vertices, *per_point;
extern uint32_t *triangles;
extern sqffd_distance_stats stats;
extern void *ws2;
extern size_t size2;
/* tracking and motion */
extern const double *const *frame_points;
extern const size_t *counts;
extern size_t frames;
extern sqffd_model *models;
extern sqffd_fit_report *reports;
extern void *tws, *mws;
extern double *volumes, *displacement, *excursion;
extern unsigned char *low_motion, *segment;
/* kd-tree queries */
extern const double query[3];
extern size_t nearest;
extern double dist2;

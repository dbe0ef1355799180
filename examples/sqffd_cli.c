/* sqffd - command-line tool for sqffd.h: git-style subcommands.

     sqffd fit INPUT -o OUT.ply [options]   fit a superquadric + FFD model to a point file
     sqffd help [COMMAND]                   usage of the tool or of one command

   Exit status: 0 success, 1 bad input or failed fit (message "FILE: what is
   wrong" on stderr), 2 usage error (message and a short usage on stderr).
   Build: make (-> build/sqffd). */
#define _POSIX_C_SOURCE 200809L
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include "sqffd_io.h"
#include "sqffd_phantom.h"
#include "sqffd_image.h"
#include "sqffd_export.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <math.h>
#include <sys/stat.h>
#include <unistd.h>

#define EXIT_BAD_INPUT 1
#define EXIT_USAGE 2

/* ---- the command table ------------------------------------------------- */

typedef struct cli_command {
    const char *name;
    const char *summary;
    const char *synopsis;             /* one line: the short usage */
    void (*details)(FILE *f);         /* the options, for --help; may be NULL */
    int (*run)(int argc, char **argv); /* argv[0] is the command name */
} cli_command;

static int cmd_fit(int argc, char **argv);
static void fit_details(FILE *f);
static int cmd_track(int argc, char **argv);
static void track_details(FILE *f);
static int cmd_phantom(int argc, char **argv);
static void phantom_details(FILE *f);
static int cmd_info(int argc, char **argv);
static int cmd_demo(int argc, char **argv);
static int cmd_help(int argc, char **argv);

static const cli_command commands[] = {
    {"fit", "fit a superquadric + free-form deformation model to a point file",
     "sqffd fit INPUT -o OUT.ply [--iso V|auto|--label N] [--sample N] [--slice-shifts] [--lattice N|LxMxN] [--alpha A] [--model-to-data W] "
     "[--min-jacobian J|none] "
     "[--iterations K] [--coarse-iterations K] [--robust] [--no-taper] [--vtk] [--json FILE] [--svg FILE] [--quiet]",
     fit_details,
     cmd_fit},
    {"track", "track a model through a sequence of point files: motion, volumes, ejection fraction, 17 segments",
     "sqffd track FRAME... -o DIR [--ed N] [--septum X,Y,Z] [--apex X,Y,Z] [--low-motion F] [--frame-iterations K] "
     "[--volume auto|closed|slices] "
     "[input and model options of fit] [--ascii] [--quiet]",
     track_details,
     cmd_track},
    {"phantom", "write a synthetic beating left ventricle as point files that 'sqffd track' reads",
     "sqffd phantom -o DIR [--frames N] [--points N] [--noise S] [--low-motion U,THETA,RADIUS,FACTOR] [--seed N]",
     phantom_details,
     cmd_phantom},
    {"info", "what a file holds: a volume's dims, spacing, type, value range and affine; a point file's format, count and box",
     "sqffd info FILE", NULL, cmd_info},
    {"demo", "the paper end to end on a beating phantom: fit, Table 1, Fig. 3, tracking, EF, 17 segments, SVGs",
     "sqffd demo [-o DIR] [--quiet]", NULL, cmd_demo},
    {"help", "show the usage of sqffd or of one command", "sqffd help [COMMAND]", NULL, cmd_help},
};
#define COMMAND_COUNT (sizeof commands / sizeof commands[0])

static const cli_command *find_command(const char *name)
{
    size_t i;
    for (i = 0; i < COMMAND_COUNT; i++)
        if (strcmp(commands[i].name, name) == 0) return &commands[i];
    return NULL;
}

static void print_overview(FILE *f)
{
    size_t i;
    fprintf(f, "usage: sqffd COMMAND [ARGS]   (sqffd %s)\n\ncommands:\n", SQFFD_VERSION_STRING);
    for (i = 0; i < COMMAND_COUNT; i++) fprintf(f, "  %-8s %s\n", commands[i].name, commands[i].summary);
    fprintf(f, "\n'sqffd COMMAND --help' shows a command's options; 'sqffd --version' the version.\n"
               "Exit status: 0 success, 1 bad input or failed fit, 2 usage error.\n");
}

static void print_command_help(FILE *f, const cli_command *c)
{
    fprintf(f, "usage: %s\n\n%s.\n", c->synopsis, c->summary);
    if (c->details) {
        fputc('\n', f);
        c->details(f);
    }
}

/* A usage error: the message, the command's short usage, exit status 2. */
#if defined(__GNUC__)
static int usage_error(const cli_command *c, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
#endif
static int usage_error(const cli_command *c, const char *fmt, ...)
{
    va_list ap;
    fputs("sqffd: ", stderr);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fprintf(stderr, "\nusage: %s\n(see 'sqffd %s --help')\n", c ? c->synopsis : "sqffd COMMAND [ARGS]",
            c ? c->name : "help");
    return EXIT_USAGE;
}

/* ---- strict number parsing --------------------------------------------- */

/* A whole decimal integer in [lo, hi]; 0 on success. */
static int parse_int(const char *s, long lo, long hi, long *out)
{
    char *end;
    long v;
    if (*s < '0' || *s > '9') return 1; /* no sign, no blanks */
    errno = 0;
    v = strtol(s, &end, 10);
    if (errno || *end || v < lo || v > hi) return 1;
    *out = v;
    return 0;
}

/* A whole finite number >= 0; 0 on success. */
static int parse_nonnegative(const char *s, double *out)
{
    char *end;
    double v;
    if (!*s || *s == ' ' || *s == '\t') return 1;
    errno = 0;
    v = strtod(s, &end);
    if (errno || *end || !(v >= 0.0) || v > 1e300) return 1;
    *out = v;
    return 0;
}

/* "X,Y,Z" (count numbers, any sign) into v; 0 on success. */
static int parse_numbers(const char *s, int count, double *v)
{
    char *end;
    int k;
    for (k = 0; k < count; k++) {
        if (!*s || *s == ' ' || *s == '\t') return 1;
        errno = 0;
        v[k] = strtod(s, &end);
        if (errno || end == s || !isfinite(v[k])) return 1;
        if (k + 1 < count && *end != ',') return 1;
        s = end + (k + 1 < count);
    }
    return *end != '\0';
}

/* "N" (all axes) or "AxBxC" with `parts` numbers, each in [lo, hi]; 0 on success. */
static int parse_dims(const char *s, int parts, long lo, long hi, int *dims)
{
    char buf[64], *piece, *x;
    int k = 0;
    long v;
    if (strlen(s) >= sizeof buf) return 1;
    strcpy(buf, s);
    for (piece = buf;; piece = x + 1) {
        x = strpbrk(piece, "xX");
        if (x) *x = '\0';
        if (k == parts || parse_int(piece, lo, hi, &v)) return 1;
        dims[k++] = (int)v;
        if (!x) break;
    }
    if (k == 1)
        for (; k < parts; k++) dims[k] = dims[0];
    return k == parts ? 0 : 1;
}

static double seconds_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* ---- the option scanner shared by the commands --------------------------

   Arguments are positional or options: "--name value", "--name=value", or a
   flag "--name"; "--" ends the options. */
typedef struct arg_scan {
    int argc, i, options_done;
    char **argv;
    char name[32];        /* the option at hand */
    const char *value;    /* its inline value (--name=value), else NULL */
} arg_scan;

/* The next argument: 1 positional (in *positional), 2 an option (in s->name),
   0 at the end; -1 for an option name too long to be one. */
static int scan_next(arg_scan *s, const char **positional)
{
    const char *arg, *eq;
    for (;;) {
        if (++s->i >= s->argc) return 0;
        arg = s->argv[s->i];
        if (s->options_done || arg[0] != '-' || arg[1] == '\0') { *positional = arg; return 1; }
        if (strcmp(arg, "--") == 0) { s->options_done = 1; continue; }
        eq = strchr(arg, '=');
        s->value = NULL;
        if (eq && (size_t)(eq - arg) < sizeof s->name) {
            memcpy(s->name, arg, (size_t)(eq - arg));
            s->name[eq - arg] = '\0';
            s->value = eq + 1;
        } else if (strlen(arg) < sizeof s->name) {
            strcpy(s->name, arg);
        } else {
            *positional = arg;
            return -1;
        }
        return 2;
    }
}

/* The option's value: inline, or the next argument; NULL after a usage message. */
static const char *scan_value(arg_scan *s, const cli_command *c)
{
    if (s->value) return s->value;
    if (s->i + 1 == s->argc) {
        usage_error(c, "%s: option '%s' needs a value", c->name, s->name);
        return NULL;
    }
    return s->argv[++s->i];
}

/* A flag must not have a value; 0 when it has none, else a usage error's status. */
static int scan_flag(const arg_scan *s, const cli_command *c)
{
    return s->value ? usage_error(c, "%s: option '%s' takes no value", c->name, s->name) : 0;
}

/* The options fit and track share (the model's); 1 when name is one of them
   (*status: 0, or a usage error's), 0 when it is not. */
static int scan_model_option(arg_scan *s, const cli_command *c, sqffd_fit_options *o, int *status)
{
    const char *v;
    long n;
#define IS(x) (strcmp(s->name, x) == 0)
    *status = 0;
    if (IS("--robust") || IS("--no-taper")) {
        *status = scan_flag(s, c);
        if (IS("--robust")) o->sq.robust = 1; else o->sq.taper = 0;
        return 1;
    }
    if (!(IS("--lattice") || IS("--alpha") || IS("--model-to-data") || IS("--min-jacobian") || IS("--iterations") ||
          IS("--coarse-iterations")))
        return 0;
    v = scan_value(s, c);
    if (!v) *status = EXIT_USAGE;
    else if (IS("--lattice")) {
        if (parse_dims(v, 3, 2, SQFFD_MAX_LATTICE, o->lattice))
            *status = usage_error(c, "%s: --lattice takes N or LxMxN, each 2..%d, not '%s'", c->name, SQFFD_MAX_LATTICE, v);
    } else if (IS("--alpha")) {
        if (parse_nonnegative(v, &o->alpha))
            *status = usage_error(c, "%s: --alpha takes a finite number >= 0, not '%s'", c->name, v);
    } else if (IS("--model-to-data")) {
        if (parse_nonnegative(v, &o->model_to_data))
            *status = usage_error(c, "%s: --model-to-data takes a finite number >= 0, not '%s'", c->name, v);
    } else if (IS("--min-jacobian")) {
        if (strcmp(v, "none") == 0) o->min_jacobian = -HUGE_VAL;
        else if (parse_numbers(v, 1, &o->min_jacobian) || o->min_jacobian > 1.0)
            *status = usage_error(c, "%s: --min-jacobian takes a number <= 1 or 'none', not '%s'", c->name, v);
    } else if (parse_int(v, 0, 10000, &n)) {
        *status = usage_error(c, "%s: %s takes a whole number 0..10000, not '%s'", c->name, s->name, v);
    } else if (IS("--iterations")) {
        o->max_iterations = (int)n;
    } else {
        o->coarse_iterations = (int)n;
    }
#undef IS
    return 1;
}

/* The model options' help lines, shared by fit and track (d: the command's defaults). */
static void model_option_details(FILE *f, const sqffd_fit_options *d, const char *iterations_note)
{
    fprintf(f,
            "  --lattice N|LxMxN      FFD control points per axis, 2..%d (default %dx%dx%d)\n"
            "  --alpha A              spring weight of the energy, >= 0 (default %g)\n"
            "  --model-to-data W      weight of the model -> data term, >= 0 (default %g;\n"
            "                         0: the data -> model distances alone)\n"
            "  --min-jacobian J       no step leaves the lattice's Jacobian bound below J, <= 1\n"
            "                         (default %g: the model cannot fold; 'none': no bound)\n"
            "  --iterations K         FFD iterations at most, 0..10000 (default %d; %s)\n"
            "  --coarse-iterations K  of those, at most K first on a coarse grid (half the rows and\n"
            "                         columns, %d points at most), 0..10000 (default %d; 0: none)\n"
            "  --robust               outlier-robust fit in both stages\n"
            "  --no-taper             superquadric without tapering (11 parameters, not 13)\n",
            SQFFD_MAX_LATTICE, d->lattice[0], d->lattice[1], d->lattice[2], d->alpha, d->model_to_data,
            d->min_jacobian, d->max_iterations, iterations_note, SQFFD_FIT_COARSE_POINTS, d->coarse_iterations);
}

/* ---- inputs: point files and volumes ------------------------------------ */

/* How a volume becomes points (fit and track share these options). */
typedef struct input_args {
    int iso_auto;         /* Otsu's threshold (the default) */
    double iso;           /* else this level */
    int label_set;        /* a label map: the surface of the voxels of this label */
    double label;
    size_t sample;        /* at most this many points (0: all); volumes default to VOLUME_SAMPLE */
    int sample_set;
    int all_components;   /* keep the specks: every component of the iso-surface */
    int slice_shifts;     /* short-axis stacks: each slice moved onto the stack's centreline first */
    int no_lids;          /* short-axis stacks: not closed by lids beyond their outer slices */
} input_args;

#define VOLUME_SAMPLE 6000 /* points a volume gives by default: about what the paper fitted */

static void input_args_default(input_args *a)
{
    memset(a, 0, sizeof *a);
    a->iso_auto = 1;
}

/* What one input gave, for the reports. */
typedef struct input_summary {
    int volume;
    char format[16];
    size_t frames;        /* a volume's 4th dimension */
    double level;         /* the iso level used */
    size_t crossings;     /* iso-surface points before the sample */
    size_t points;        /* kept */
    size_t dropped_nan;   /* points left out of a PCD file for NaN coordinates */
} input_summary;

/* The input options fit and track share; 1 when name is one of them (*status: 0 or a usage error's). */
static int scan_input_option(arg_scan *s, const cli_command *c, input_args *in, int *status)
{
    const char *v;
    long n;
    *status = 0;
    if (strcmp(s->name, "--all-components") == 0 || strcmp(s->name, "--slice-shifts") == 0 ||
        strcmp(s->name, "--no-lids") == 0) {
        *status = scan_flag(s, c);
        if (strcmp(s->name, "--all-components") == 0) in->all_components = 1;
        else if (strcmp(s->name, "--slice-shifts") == 0) in->slice_shifts = 1;
        else in->no_lids = 1;
        return 1;
    }
    if (strcmp(s->name, "--iso") != 0 && strcmp(s->name, "--label") != 0 && strcmp(s->name, "--sample") != 0) return 0;
    if (!(v = scan_value(s, c))) {
        *status = EXIT_USAGE;
    } else if (strcmp(s->name, "--iso") == 0) {
        char *end;
        in->iso_auto = strcmp(v, "auto") == 0;
        if (!in->iso_auto) {
            errno = 0;
            in->iso = strtod(v, &end);
            if (!*v || *end || errno || !isfinite(in->iso))
                *status = usage_error(c, "%s: --iso takes a number or 'auto', not '%s'", c->name, v);
        }
        if (!*status && in->label_set) *status = usage_error(c, "%s: --iso and --label exclude each other", c->name);
    } else if (strcmp(s->name, "--label") == 0) {
        if (parse_numbers(v, 1, &in->label))
            *status = usage_error(c, "%s: --label takes a voxel value (a label map's label), not '%s'", c->name, v);
        else if (!in->iso_auto) *status = usage_error(c, "%s: --iso and --label exclude each other", c->name);
        in->label_set = 1;
    } else if (parse_int(v, 20, 100000000L, &n)) {
        *status = usage_error(c, "%s: --sample takes a point count 20..100000000, not '%s'", c->name, v);
    } else {
        in->sample = (size_t)n;
        in->sample_set = 1;
    }
    return 1;
}

static void input_option_details(FILE *f)
{
    fprintf(f,
            "  --iso V|auto           volumes: the iso level (default auto: Otsu's threshold)\n"
            "  --label N              label maps (segmentations): the surface of the voxels labelled N\n"
            "                         (crossings at the voxel edges' midpoints), instead of --iso\n"
            "  --sample N             keep N points evenly spread (volumes: default %d; point files: all)\n"
            "  --all-components       volumes: keep every piece of the iso-surface (default: the\n"
            "                         largest connected one, so specks and noise are dropped)\n"
            "  --slice-shifts         short-axis stacks (contours listed slice by slice): correct\n"
            "                         breath-hold misregistration first, each slice moved in-plane\n"
            "                         onto the stack's smooth centreline (one shift a slice, the same\n"
            "                         in every frame), and report the shifts\n"
            "  --no-lids              short-axis stacks: leave their ends open (default: each frame's\n"
            "                         outer contours filled in half a spacing beyond its outer\n"
            "                         slices, where Simpson's method ends, so the model closes there)\n",
            VOLUME_SAMPLE);
}

/* How many of the frames, from the first, are short-axis stacks whose
   planes are parallel to the first's (frame_count: all); their stacks in
   stacks. */
static size_t find_stacks(double *const *frames, const size_t *counts, size_t frame_count, sqffd_stack *stacks)
{
    size_t t;
    int found = 1;
    for (t = 0; t < frame_count; t++) {
        const double *axis = stacks[0].axis, *here = stacks[t].axis;
        if (sqffd_points_stack(sqffd_points_packed(frames[t], counts[t]), &stacks[t], &found) != SQFFD_OK || !found ||
            fabs(axis[0] * here[0] + axis[1] * here[1] + axis[2] * here[2]) < 0.999)
            break;
    }
    return t;
}

/* Each frame's stack closed by its lids (sqffd_stack_lids), appended to its
   points; *added: how many in all. 0, or 1 with a message in err. */
static int add_lids(double **frames, size_t *counts, size_t frame_count, const sqffd_stack *stacks, size_t *added,
                    char *err, size_t err_size)
{
    size_t t, n;
    *added = 0;
    for (t = 0; t < frame_count; t++) {
        sqffd_points view = sqffd_points_packed(frames[t], counts[t]);
        double *grown;
        sqffd_result r = sqffd_stack_lids(view, &stacks[t], NULL, 0, &n);
        grown = r == SQFFD_OK ? (double *)realloc(frames[t], 3 * (counts[t] + n) * sizeof(double)) : NULL;
        if (grown) {
            frames[t] = grown;
            view = sqffd_points_packed(frames[t], counts[t]);
            r = sqffd_stack_lids(view, &stacks[t], frames[t] + 3 * counts[t], n, &n);
        }
        if (r != SQFFD_OK || !grown) {
            snprintf(err, err_size, "sqffd: the stack's lids: %s", grown ? sqffd_result_string(r) : "out of memory");
            return 1;
        }
        counts[t] += n;
        *added += n;
    }
    return 0;
}

/* --slice-shifts on the frames' stacks: one shift a slice
   (sqffd_stack_shifts), each frame's points moved; 0, or 1 with a message
   in err. */
static int correct_slices(const char *name, double *const *frames, const size_t *counts, size_t frame_count,
                          const sqffd_stack *stacks, sqffd_slice_shifts *shifts, char *err, size_t err_size)
{
    sqffd_points *views = (sqffd_points *)calloc(frame_count, sizeof *views);
    sqffd_result r = views ? SQFFD_OK : SQFFD_ERROR_TOO_LARGE;
    size_t t;
    for (t = 0; views && t < frame_count; t++) views[t] = sqffd_points_packed(frames[t], counts[t]);
    if (r == SQFFD_OK) r = sqffd_stack_shifts(views, stacks, frame_count, shifts);
    for (t = 0; t < frame_count && r == SQFFD_OK; t++) r = sqffd_slice_shifts_apply(shifts, frames[t], counts[t], NULL);
    free(views);
    if (r == SQFFD_OK) return 0;
    snprintf(err, err_size, "%s: --slice-shifts: %s%s", name, views ? sqffd_result_string(r) : "out of memory",
             r == SQFFD_ERROR_INVALID_ARGUMENT ? " (more levels over the frames than a stack holds)" : "");
    return 1;
}

/* The frames as short-axis stacks, before a fit or a track: *found when
   every frame is one, their planes parallel (their stacks in stacks); then
   --slice-shifts (which needs them) moves their slices, and unless
   --no-lids each frame's lids are appended (*lids: how many). 0, or 1 with
   a message in err. */
static int prepare_stacks(const input_args *in, const char *const *names, double **frames, size_t *counts,
                          size_t frame_count, sqffd_stack *stacks, int *found, sqffd_slice_shifts *shifts,
                          size_t *lids, char *err, size_t err_size)
{
    size_t stacked = find_stacks(frames, counts, frame_count, stacks);
    *found = stacked == frame_count;
    *lids = 0;
    if (in->slice_shifts && !*found) {
        snprintf(err, err_size, "%s: --slice-shifts: not a short-axis stack (points on 3 to %d parallel planes, listed "
                 "slice by slice)%s", names[stacked], SQFFD_STACK_PLANES, stacked ? ", or not the first frame's planes" : "");
        return 1;
    }
    if (in->slice_shifts && correct_slices(names[0], frames, counts, frame_count, stacks, shifts, err, err_size)) return 1;
    return *found && !in->no_lids && add_lids(frames, counts, frame_count, stacks, lids, err, err_size);
}

/* The shifts --slice-shifts applied, one line a slice. */
static void print_slice_shifts(const sqffd_slice_shifts *s)
{
    size_t k;
    double sum2 = 0.0;
    for (k = 0; k < s->slices; k++)
        sum2 += s->shift[k][0] * s->shift[k][0] + s->shift[k][1] * s->shift[k][1] + s->shift[k][2] * s->shift[k][2];
    printf("  slice shifts     %lu slices along %.4g %.4g %.4g, RMS %.4g (added to each slice's points)\n",
           (unsigned long)s->slices, s->axis[0], s->axis[1], s->axis[2], sqrt(sum2 / (double)s->slices));
    for (k = 0; k < s->slices; k++)
        printf("    level %10.4g  shift %10.4g %10.4g %10.4g\n", s->level[k], s->shift[k][0], s->shift[k][1],
               s->shift[k][2]);
}

/* Whether path is a volume (by its first bytes, then its name). */
static int is_volume(const char *path)
{
    unsigned char head[512];
    size_t got = 0;
    FILE *f = fopen(path, "rb");
    if (f) {
        got = fread(head, 1, sizeof head, f);
        fclose(f);
    }
    return sqffd_image_is_volume_file(path, head, got);
}

/* Frame t of a read volume as points: the iso-surface, sampled. */
static int volume_points(const sqffd_image *image, size_t t, const char *name, const input_args *in, double **points,
                         size_t *count, input_summary *sum, char *err, size_t err_size)
{
    sqffd_volume frame = sqffd_image_frame(image, t);
    sqffd_iso_options o = sqffd_iso_options_default();
    size_t size, n = 0, keep;
    void *work;
    double *all;
    sqffd_result r = SQFFD_OK;
    *points = NULL;
    o.largest_component = !in->all_components;
    o.level = in->iso;
    o.labelled = in->label_set;
    o.label = in->label;
    if (in->iso_auto && !in->label_set) r = sqffd_volume_otsu(&frame, &o.level);
    if (r != SQFFD_OK) {
        snprintf(err, err_size, "%s: no automatic iso level: %s (give --iso V)", name, sqffd_result_string(r));
        return 1;
    }
    r = sqffd_iso_workspace_size(&frame, &o, &size);
    work = r == SQFFD_OK ? malloc(size) : NULL;
    /* every component's crossings bound the largest one's: counted without the labelling, filled with it */
    o.largest_component = 0;
    if (r == SQFFD_OK) r = work ? sqffd_iso_points(&frame, &o, NULL, NULL, 0, &n, work, size) : SQFFD_ERROR_TOO_LARGE;
    o.largest_component = !in->all_components;
    all = r == SQFFD_OK && n ? (double *)malloc(3 * n * sizeof *all) : NULL;
    if (all) r = sqffd_iso_points(&frame, &o, all, NULL, n, &n, work, size);
    free(work);
    if (r != SQFFD_OK || !all) {
        free(all);
        if (r != SQFFD_OK) snprintf(err, err_size, "%s: iso-surface: %s", name, sqffd_result_string(r));
        else if (n == 0 && in->label_set) snprintf(err, err_size, "%s: no voxel is labelled %g (see 'sqffd info')", name, o.label);
        else if (n == 0) snprintf(err, err_size, "%s: no voxel crosses the iso level %g (values range over the image: see 'sqffd info')", name, o.level);
        else snprintf(err, err_size, "%s: out of memory for %lu iso-surface points", name, (unsigned long)n);
        return 1;
    }
    keep = in->sample_set ? in->sample : VOLUME_SAMPLE;
    keep = keep && keep < n ? keep : n;
    if (keep < n) {
        double *kept = (double *)malloc(3 * keep * sizeof *kept);
        if (!kept) {
            free(all);
            snprintf(err, err_size, "%s: out of memory", name);
            return 1;
        }
        r = sqffd_points_subsample(all, n, keep, kept);
        free(all);
        if (r != SQFFD_OK) {
            free(kept);
            snprintf(err, err_size, "%s: subsample: %s", name, sqffd_result_string(r));
            return 1;
        }
        all = kept;
    }
    *points = all;
    *count = keep;
    sum->level = o.level;
    sum->crossings = n;
    sum->points = keep;
    return 0;
}

/* Reads one input: a point file (frames = 1) or a volume, all of whose
   frames (first_only: frame 0) become point sets. frames[*frame_count]
   and counts are malloc'd. */
static int read_input(const char *path, const input_args *in, int first_only, double ***frames, size_t **counts,
                      size_t *frame_count, input_summary *sum, char *err, size_t err_size)
{
    sqffd_image image;
    size_t t, n;
    memset(sum, 0, sizeof *sum);
    *frame_count = 0;
    *frames = NULL;
    *counts = NULL;
    if (!is_volume(path)) {
        double *points = NULL;
        sqffd_io_info info;
        if (sqffd_io_read_file_info(path, &points, &n, &info, err, err_size)) return 1;
        sum->dropped_nan = info.dropped_nan;
        if (in->sample_set && in->sample < n) {
            double *kept = (double *)malloc(3 * in->sample * sizeof *kept);
            sqffd_result r;
            if (!kept) { free(points); snprintf(err, err_size, "%s: out of memory", path); return 1; }
            r = sqffd_points_subsample(points, n, in->sample, kept);
            free(points);
            if (r != SQFFD_OK) {
                free(kept);
                snprintf(err, err_size, "%s: subsample: %s", path, sqffd_result_string(r));
                return 1;
            }
            points = kept;
            n = in->sample;
        }
        *frames = (double **)malloc(sizeof **frames);
        *counts = (size_t *)malloc(sizeof **counts);
        if (!*frames || !*counts) { free(points); snprintf(err, err_size, "%s: out of memory", path); return 1; }
        (*frames)[0] = points;
        (*counts)[0] = n;
        *frame_count = 1;
        sum->points = n;
        sum->frames = 1;
        return 0;
    }
    if (sqffd_image_read_file(path, &image, err, err_size)) return 1;
    sum->volume = 1;
    sum->frames = image.frames;
    snprintf(sum->format, sizeof sum->format, "%s", image.format);
    n = first_only ? 1 : image.frames;
    *frames = (double **)calloc(n, sizeof **frames);
    *counts = (size_t *)calloc(n, sizeof **counts);
    if (!*frames || !*counts) {
        sqffd_image_free(&image);
        snprintf(err, err_size, "%s: out of memory", path);
        return 1;
    }
    for (t = 0; t < n; t++) {
        if (volume_points(&image, t, path, in, &(*frames)[t], &(*counts)[t], sum, err, err_size)) {
            sqffd_image_free(&image);
            *frame_count = t;
            return 1;
        }
        *frame_count = t + 1;
    }
    sqffd_image_free(&image);
    return 0;
}

static void free_frames(double **frames, size_t *counts, size_t frame_count)
{
    size_t t;
    if (frames)
        for (t = 0; t < frame_count; t++) free(frames[t]);
    free(frames);
    free(counts);
}

/* Progress on stderr once a fit or a tracking has taken more than a second. */
typedef struct track_progress {
    double start;
    size_t frames;        /* 0: a single fit (its iterations are shown) */
    int terminal;         /* stderr is a terminal */
    int shown;            /* a rewriting line is on it */
} track_progress;

static int track_progress_report(void *user, int stage, int iteration, double error)
{
    track_progress *p = (track_progress *)user;
    if (seconds_now() - p->start <= 1.0) return 0;
    /* a line that rewrites itself on a terminal, plain lines into a file or a pipe */
    if (p->frames && stage == SQFFD_STAGE_FRAME)
        fprintf(stderr, p->terminal ? "\rsqffd track: frame %d of %lu" : "sqffd track: frame %d of %lu\n", iteration + 1,
                (unsigned long)p->frames);
    else if (!p->frames && (stage == SQFFD_STAGE_FFD || stage == SQFFD_STAGE_COARSE))
        fprintf(stderr, p->terminal ? "\rsqffd fit: %s iteration %d, error %.4f %%" : "sqffd fit: %s iteration %d, error %.4f %%\n",
                stage == SQFFD_STAGE_COARSE ? "coarse" : "FFD", iteration, 100.0 * error);
    else
        return 0;
    p->shown = p->terminal;
    return 0;
}

/* ---- sqffd fit --------------------------------------------------------- */

typedef struct fit_args {
    const char *input, *output, *points_output;
    sqffd_fit_options options;
    input_args in;
    const char *json_output, *svg_output;
    int mesh[2];
    int ascii, quiet, vtk;
} fit_args;

/* Parses fit's arguments into a; returns 0, or an exit status after a message. */
static int fit_parse(int argc, char **argv, fit_args *a, int *help)
{
    const cli_command *c = find_command("fit");
    arg_scan s;
    const char *arg, *v;
    int kind, status;
    memset(a, 0, sizeof *a);
    memset(&s, 0, sizeof s);
    s.argc = argc;
    s.argv = argv;
    a->options = sqffd_fit_options_default();
    input_args_default(&a->in);
    a->mesh[0] = 64;
    a->mesh[1] = 128;
    *help = 0;
    while ((kind = scan_next(&s, &arg)) != 0) {
#define IS(x) (strcmp(s.name, x) == 0)
        if (kind < 0) return usage_error(c, "fit: unknown option '%s'", arg);
        if (kind == 1) {
            if (a->input) return usage_error(c, "fit: one INPUT only, '%s' is a second", arg);
            a->input = arg;
            continue;
        }
        if (scan_model_option(&s, c, &a->options, &status) || scan_input_option(&s, c, &a->in, &status)) {
            if (status) return status;
            continue;
        }
        if (IS("--help") || IS("-h") || IS("--quiet") || IS("--ascii") || IS("--vtk")) {
            if ((status = scan_flag(&s, c)) != 0) return status;
            if (IS("--help") || IS("-h")) { *help = 1; return 0; }
            if (IS("--quiet")) a->quiet = 1;
            if (IS("--ascii")) a->ascii = 1;
            if (IS("--vtk")) a->vtk = 1;
            continue;
        }
        if (!(IS("-o") || IS("--output") || IS("--points") || IS("--mesh") || IS("--json") || IS("--svg")))
            return usage_error(c, "fit: unknown option '%s'", s.argv[s.i]);
        if (!(v = scan_value(&s, c))) return EXIT_USAGE;
        if (IS("-o") || IS("--output")) a->output = v;
        else if (IS("--points")) a->points_output = v;
        else if (IS("--json")) a->json_output = v;
        else if (IS("--svg")) a->svg_output = v;
        else if (parse_dims(v, 2, 4, 1024, a->mesh))
            return usage_error(c, "fit: --mesh takes N or ExO, each 4..1024, not '%s'", v);
#undef IS
    }
    if (!a->input) return usage_error(c, "fit: no INPUT file");
    if (!a->output) return usage_error(c, "fit: no output file (-o OUT.ply)");
    return 0;
}

static void fit_details(FILE *f)
{
    sqffd_fit_options d = sqffd_fit_options_default();
    fprintf(f,
            "INPUT is a point file: PLY (ascii, binary little or big endian; vertex x y z read,\n"
            "other properties and elements skipped), PCD (ascii, binary, binary_compressed; points\n"
            "with NaN coordinates, PCL's invalid depth, dropped and counted), OFF, OBJ vertices,\n"
            "legacy VTK POINTS (POLYDATA, UNSTRUCTURED_GRID, STRUCTURED_GRID; ASCII or BINARY), STL\n"
            "(ASCII or binary; the triangles' vertices, each shared vertex once), or XYZ (x y z per\n"
            "line, extra columns ignored, '#' comments), any of them gzip-compressed (.gz); or a\n"
            "volume: NIfTI-1 (.nii, .nii.gz, .hdr/.img), MetaImage (.mha, .mhd), NRRD (.nrrd, .nhdr)\n"
            "or legacy VTK STRUCTURED_POINTS (.vtk), whose iso-surface gives the points (a 4-D\n"
            "volume: its first frame).\n"
            "The format is found from the content, then the extension.\n"
            "\n"
            "  -o, --output OUT.ply   the model surface as a triangle mesh (required), with a\n"
            "                         per-vertex float 'error': the distance from that model\n"
            "                         vertex to the nearest data point\n");
    input_option_details(f);
    model_option_details(f, &d, "0: the superquadric alone");
    fprintf(f,
            "  --mesh N|ExO           output mesh grid, eta x omega, 4..1024 (default 64x128)\n"
            "  --points FILE.ply      also write the data points, each with a float 'error':\n"
            "                         its distance to the model surface\n"
            "  --vtk                  write the mesh as legacy VTK polydata (ParaView) instead of PLY\n"
            "  --json FILE            also write the model as JSON (every number to rebuild it)\n"
            "  --svg FILE             also write the error per iteration as an SVG plot\n"
            "  --ascii                write ascii PLY (or VTK) instead of binary\n"
            "  --quiet                print nothing on success\n"
            "\n"
            "The error in the report is the RMS distance from the data points to the model\n"
            "surface, relative to the diagonal of the data's bounding box.\n");
}

static void print_vec3(const char *label, const double *v)
{
    printf("  %-16s %.6g %.6g %.6g\n", label, v[0], v[1], v[2]);
}

static void fit_report(const fit_args *a, const input_summary *in, size_t n, const sqffd_model *model,
                       const sqffd_fit_report *r, size_t mesh_vertices, size_t mesh_triangles,
                       const sqffd_distance_stats *model_to_data, const double t[4])
{
    const sqffd_superquadric *sq = &model->sq;
    const sqffd_ffd *ffd = &model->ffd;
    printf("sqffd fit %s\n", a->input);
    if (in->volume) {
        printf("  volume           %s, %lu frame%s%s\n", in->format, (unsigned long)in->frames, in->frames == 1 ? "" : "s",
               in->frames > 1 ? " (frame 0 fitted)" : "");
        char surface[64];
        if (a->in.label_set) snprintf(surface, sizeof surface, "label %g", a->in.label);
        else snprintf(surface, sizeof surface, "level %g%s", in->level, a->in.iso_auto ? " (Otsu)" : "");
        printf("  iso-surface      %s, %lu crossing points%s, %lu kept\n", surface, (unsigned long)in->crossings,
               a->in.all_components ? "" : " of the largest component", (unsigned long)n);
    } else {
        printf("  points read      %lu\n", (unsigned long)n);
        if (in->dropped_nan)
            printf("  dropped          %lu points with NaN coordinates (invalid depth)\n", (unsigned long)in->dropped_nan);
    }
    printf("  superquadric%s\n", r->sq.fallback ? "     the best start (the optimised fit ended farther from the data)" : "");
    print_vec3("    size", sq->size);
    printf("  %-16s e1 %.4g  e2 %.4g\n", "    shape", sq->shape[0], sq->shape[1]);
    printf("  %-16s Kx %.4g  Ky %.4g\n", "    taper", sq->taper[0], sq->taper[1]);
    print_vec3("    centre", sq->center);
    printf("  %-16s (row-major; its columns are the local x, y, z axes)\n", "    rotation");
    print_vec3("", sq->rotation);
    print_vec3("", sq->rotation + 3);
    print_vec3("", sq->rotation + 6);
    printf("  error            relative RMS data-to-model distance (bounding-box diagonal %.6g)\n",
           r->error.diagonal);
    printf("    superquadric   %.4f %%   (max %.4f %%)\n", 100.0 * r->sq_error.rms_relative,
           100.0 * r->sq_error.max_relative);
    printf("    after FFD      %.4f %%   (max %.4f %%)   lattice %dx%dx%d, alpha %g\n",
           100.0 * r->error.rms_relative, 100.0 * r->error.max_relative, ffd->dims[0], ffd->dims[1], ffd->dims[2],
           a->options.alpha);
    printf("    jacobian       %.4f   (the lattice's smallest Bernstein bound: > 0, no fold)\n", r->min_jacobian);
    if (r->coarse_iterations > 0) printf("  iterations       %d coarse + %d", r->coarse_iterations, r->iterations);
    else printf("  iterations       %d", r->iterations);
    printf("%s\n", r->iterations == 0 ? " (the superquadric alone)" : r->converged ? " (converged)" : " (iteration cap)");
    printf("  model mesh       %s: %lu vertices, %lu triangles; model-to-data RMS %.4f %%, max %.4f %%\n",
           a->output, (unsigned long)mesh_vertices, (unsigned long)mesh_triangles,
           100.0 * model_to_data->rms_relative, 100.0 * model_to_data->max_relative);
    if (a->points_output) printf("  data points      %s (with their distance to the model)\n", a->points_output);
    if (a->json_output) printf("  model            %s (JSON: every number to rebuild it)\n", a->json_output);
    if (a->svg_output) printf("  plot             %s (the error per iteration)\n", a->svg_output);
    printf("  time             %.1f ms (read %.1f, fit %.1f, mesh and write %.1f)\n", 1e3 * (t[3] - t[0]),
           1e3 * (t[1] - t[0]), 1e3 * (t[2] - t[1]), 1e3 * (t[3] - t[2]));
}

/* Model-to-data distances at the vertices of the written mesh: the library's
   measure, on a copy of the model whose grid is the mesh's (the vertices come
   in sqffd_model_mesh's order). */
static sqffd_result mesh_to_data(const sqffd_model *model, const int mesh[2], const double *points, size_t n,
                                 double *per_vertex, sqffd_distance_stats *stats)
{
    sqffd_model shown = *model;
    size_t size;
    void *work;
    sqffd_result r;
    shown.grid[0] = mesh[0];
    shown.grid[1] = mesh[1];
    r = sqffd_model_reverse_distances_workspace_size(n, &shown, &size);
    if (r != SQFFD_OK) return r;
    work = malloc(size);
    r = work ? sqffd_model_reverse_distances(&shown, points, n, per_vertex, stats, work, size) : SQFFD_ERROR_TOO_LARGE;
    free(work);
    return r;
}

static int cmd_fit(int argc, char **argv)
{
    fit_args a;
    sqffd_model model;
    sqffd_fit_report report;
    sqffd_result r;
    double **frames = NULL, *points, *vertices = NULL, *vertex_error = NULL, *point_error = NULL, t[4];
    sqffd_distance_stats mesh_stats;
    input_summary input;
    track_progress progress;
    uint32_t *triangles = NULL;
    void *work = NULL;
    size_t *counts = NULL, frame_count = 0, n, work_size, nv = 0, nt = 0;
    char err[512];
    int help, status = EXIT_BAD_INPUT;
    sqffd_io_scalar scalar;
    sqffd_slice_shifts shifts;
    sqffd_stack stack;
    size_t lids = 0;
    int is_stack;

    status = fit_parse(argc, argv, &a, &help);
    if (status) return status;
    if (help) {
        print_command_help(stdout, find_command("fit"));
        return 0;
    }
    status = EXIT_BAD_INPUT;
    t[0] = seconds_now();
    if (read_input(a.input, &a.in, 1, &frames, &counts, &frame_count, &input, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        goto done;
    }
    if (prepare_stacks(&a.in, &a.input, frames, counts, 1, &stack, &is_stack, &shifts, &lids, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        goto done;
    }
    points = frames[0];
    n = counts[0];
    t[1] = seconds_now();

    r = sqffd_fit_workspace_size(n, &a.options, &work_size);
    if (r == SQFFD_ERROR_TOO_LARGE) {
        fprintf(stderr, "%s: %lu points: too many for the fit\n", a.input, (unsigned long)n);
        goto done;
    }
    if (r != SQFFD_OK) {
        fprintf(stderr, "%s: cannot size the fit: %s\n", a.input, sqffd_result_string(r));
        goto done;
    }
    work = malloc(work_size);
    if (!work) {
        fprintf(stderr, "%s: out of memory (the fit needs %lu bytes)\n", a.input, (unsigned long)work_size);
        goto done;
    }
    progress.start = t[0];
    progress.frames = 0;
    progress.terminal = isatty(fileno(stderr));
    progress.shown = 0;
    if (!a.quiet) {
        a.options.progress = track_progress_report;
        a.options.progress_user = &progress;
    }
    r = sqffd_fit(points, n, &a.options, &model, &report, work, work_size);
    if (progress.shown) fputc('\n', stderr);
    if (r != SQFFD_OK) {
        fprintf(stderr, "%s: fit failed: %s\n", a.input, sqffd_result_string(r));
        goto done;
    }
    t[2] = seconds_now();

    if (sqffd_model_mesh_size(a.mesh[0], a.mesh[1], &nv, &nt) != SQFFD_OK) {
        fprintf(stderr, "sqffd: mesh grid %dx%d refused by the library\n", a.mesh[0], a.mesh[1]);
        goto done;
    }
    vertices = (double *)malloc(3 * nv * sizeof *vertices);
    vertex_error = (double *)malloc(nv * sizeof *vertex_error);
    triangles = (uint32_t *)malloc(3 * nt * sizeof *triangles);
    if (!vertices || !vertex_error || !triangles ||
        sqffd_model_mesh(&model, a.mesh[0], a.mesh[1], vertices, triangles) != SQFFD_OK) {
        fprintf(stderr, "%s: could not build the model mesh (out of memory?)\n", a.output);
        goto done;
    }
    r = mesh_to_data(&model, a.mesh, points, n, vertex_error, &mesh_stats);
    if (r != SQFFD_OK) {
        fprintf(stderr, "%s: could not measure the mesh's distances to the data: %s\n", a.output,
                sqffd_result_string(r));
        goto done;
    }
    scalar.name = "error";
    scalar.values = vertex_error;
    if (a.vtk ? sqffd_export_vtk(a.output, "sqffd model", vertices, nv, triangles, nt, &scalar, 1,
                                 a.ascii ? SQFFD_EXPORT_VTK_ASCII : 0, err, sizeof err)
              : sqffd_io_write_ply(a.output, vertices, nv, triangles, nt, &scalar, 1, a.ascii, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        goto done;
    }
    if (a.points_output) {
        size_t dsize;
        void *dwork;
        sqffd_distance_stats stats;
        r = sqffd_model_distances_workspace_size(n, &model, &dsize);
        dwork = r == SQFFD_OK ? malloc(dsize) : NULL;
        point_error = (double *)malloc(n * sizeof *point_error);
        if (r == SQFFD_OK)
            r = dwork && point_error ? sqffd_model_distances(&model, points, n, point_error, &stats, dwork, dsize)
                                     : SQFFD_ERROR_INVALID_ARGUMENT;
        free(dwork);
        if (r != SQFFD_OK) {
            fprintf(stderr, "%s: could not measure the point distances: %s\n", a.points_output,
                    sqffd_result_string(r));
            goto done;
        }
        scalar.values = point_error;
        if (sqffd_io_write_ply(a.points_output, points, n, NULL, 0, &scalar, 1, a.ascii, err, sizeof err)) {
            fprintf(stderr, "%s\n", err);
            goto done;
        }
    }
    if ((a.json_output && sqffd_export_model_json(a.json_output, &model, &report, err, sizeof err)) ||
        (a.svg_output && sqffd_export_svg_history(a.svg_output, &report, a.input, err, sizeof err))) {
        fprintf(stderr, "%s\n", err);
        goto done;
    }
    t[3] = seconds_now();
    if (!a.quiet) fit_report(&a, &input, n, &model, &report, nv, nt, &mesh_stats, t);
    if (!a.quiet && lids)
        printf("  lids             %lu of the points close the stack half a spacing beyond its outer slices (--no-lids: "
               "none)\n", (unsigned long)lids);
    if (!a.quiet && a.in.slice_shifts) print_slice_shifts(&shifts);
    status = 0;
done:
    free_frames(frames, counts, frame_count);
    free(work);
    free(vertices);
    free(vertex_error);
    free(triangles);
    free(point_error);
    return status;
}

/* ---- sqffd track ------------------------------------------------------- */

static const char *const segment_names[SQFFD_SEGMENTS] = {
    "basal anterior", "basal anteroseptal", "basal inferoseptal", "basal inferior", "basal inferolateral",
    "basal anterolateral", "mid anterior", "mid anteroseptal", "mid inferoseptal", "mid inferior",
    "mid inferolateral", "mid anterolateral", "apical anterior", "apical septal", "apical inferior",
    "apical lateral", "apex"};

enum { VOLUME_AUTO, VOLUME_CLOSED, VOLUME_SLICES };

typedef struct track_args {
    const char **inputs;         /* the FRAME arguments */
    size_t input_count;
    const char **frames;         /* each frame's input */
    size_t frame_count;
    input_args in;
    const char *output;
    sqffd_track_options options;
    sqffd_motion_options motion;
    int volume;                  /* VOLUME_AUTO, VOLUME_CLOSED or VOLUME_SLICES */
    sqffd_stack *stacks;         /* the frames' short-axis stacks, when the volumes are the slices' */
    sqffd_slice_shifts shifts;   /* --slice-shifts: what was applied */
    size_t lids;                 /* points the stacks' lids added, over all frames */
    int ascii, quiet;
    size_t dropped_nan, dropped_frames; /* PCD points dropped for NaN coordinates, and the frames that had some */
} track_args;

static int track_parse(int argc, char **argv, track_args *a, int *help)
{
    const cli_command *c = find_command("track");
    arg_scan s;
    const char *arg, *v;
    int kind, status;
    long n;
    memset(&s, 0, sizeof s);
    s.argc = argc;
    s.argv = argv;
    a->options = sqffd_track_options_default();
    a->motion = sqffd_motion_options_default();
    input_args_default(&a->in);
    *help = 0;
    while ((kind = scan_next(&s, &arg)) != 0) {
#define IS(x) (strcmp(s.name, x) == 0)
        if (kind < 0) return usage_error(c, "track: unknown option '%s'", arg);
        if (kind == 1) {
            a->inputs[a->input_count++] = arg;
            continue;
        }
        if (scan_model_option(&s, c, &a->options.fit, &status) || scan_input_option(&s, c, &a->in, &status)) {
            if (status) return status;
            continue;
        }
        if (IS("--help") || IS("-h") || IS("--quiet") || IS("--ascii")) {
            if ((status = scan_flag(&s, c)) != 0) return status;
            if (IS("--help") || IS("-h")) { *help = 1; return 0; }
            if (IS("--quiet")) a->quiet = 1;
            if (IS("--ascii")) a->ascii = 1;
            continue;
        }
        if (!(IS("-o") || IS("--output") || IS("--ed") || IS("--septum") || IS("--apex") || IS("--low-motion") ||
              IS("--frame-iterations") || IS("--volume")))
            return usage_error(c, "track: unknown option '%s'", s.argv[s.i]);
        if (!(v = scan_value(&s, c))) return EXIT_USAGE;
        if (IS("-o") || IS("--output")) a->output = v;
        else if (IS("--ed")) {
            if (parse_int(v, 0, 1000000, &n)) return usage_error(c, "track: --ed takes a frame number, not '%s'", v);
            a->motion.ed_frame = (size_t)n;
        } else if (IS("--septum") || IS("--apex")) {
            if (parse_numbers(v, 3, IS("--septum") ? a->motion.septum_direction : a->motion.apex_direction))
                return usage_error(c, "track: %s takes a direction X,Y,Z, not '%s'", s.name, v);
        } else if (IS("--volume")) {
            a->volume = strcmp(v, "auto") == 0 ? VOLUME_AUTO : strcmp(v, "closed") == 0 ? VOLUME_CLOSED
                      : strcmp(v, "slices") == 0 ? VOLUME_SLICES : -1;
            if (a->volume < 0) return usage_error(c, "track: --volume takes auto, closed or slices, not '%s'", v);
        } else if (IS("--low-motion")) {
            if (parse_nonnegative(v, &a->motion.low_motion_fraction) || a->motion.low_motion_fraction > 1.0)
                return usage_error(c, "track: --low-motion takes a fraction 0..1, not '%s'", v);
        } else {
            if (parse_int(v, 0, 10000, &n))
                return usage_error(c, "track: --frame-iterations takes a whole number 0..10000, not '%s'", v);
            a->options.frame_iterations = (int)n;
        }
#undef IS
    }
    if (a->input_count == 0) return usage_error(c, "track: no FRAME input");
    if (!a->output) return usage_error(c, "track: no output folder (-o DIR)");
    return 0;
}

static void track_details(FILE *f)
{
    sqffd_track_options d = sqffd_track_options_default();
    sqffd_motion_options m = sqffd_motion_options_default();
    fprintf(f,
            "Each FRAME is a point file or a volume (as 'sqffd fit' reads), in time order; a 4-D\n"
            "volume gives all its frames (time is its 4th axis).\n"
            "Frame 0 gets the whole fit; every later frame starts from the previous frame's model\n"
            "and keeps frame 0's superquadric and box, so each model vertex is the same material\n"
            "point in every frame.\n"
            "\n"
            "  -o, --output DIR       output folder (made if absent), written there:\n"
            "                           frame_NN.ply   each frame's model mesh\n"
            "                           motion.ply     the end-diastolic mesh with per-vertex floats\n"
            "                                          'displacement' (ED to ES), 'excursion' (its inward\n"
            "                                          part along the normal), 'low_motion' (0 or 1)\n"
            "                                          and 'segment' (1-17; 0: valve plane, not wall)\n"
            "                           segments.csv   per AHA segment: mean displacement and\n"
            "                                          excursion, low-motion share, flag\n"
            "                           volumes.csv    per frame: model volume, error\n"
            "  --ed N                 the end-diastolic frame (default %lu); end-systole is the\n"
            "                         frame of least model volume\n"
            "  --septum X,Y,Z         direction of the septum (default: a superquadric axis; the\n"
            "                         points do not tell it, give it for a real heart)\n"
            "  --apex X,Y,Z           direction base -> apex (default: the long axis, toward its\n"
            "                         narrower end)\n"
            "  --low-motion F         a vertex is low-motion below F x the median excursion\n"
            "                         of the wall at its level (default %g); a segment is\n"
            "                         hypokinetic when at least %g of its area is\n"
            "  --frame-iterations K   FFD iterations of the frames after the first (default %d)\n"
            "  --volume auto|closed|slices\n"
            "                         the frames' volumes (EF): 'closed', the closed models'; 'slices',\n"
            "                         the models' between each frame's outer short-axis slices, each\n"
            "                         moved out by half the spacing, where Simpson's method puts its\n"
            "                         discs (point files on 3 or more parallel planes, slice by\n"
            "                         slice); 'auto' (default): slices for such stacks, else closed\n",
            (unsigned long)m.ed_frame, m.low_motion_fraction, m.hypokinetic_share, d.frame_iterations);
    input_option_details(f);
    model_option_details(f, &d.fit, "frame 0");
    fprintf(f,
            "  --ascii                write ascii PLY instead of binary little endian\n"
            "  --quiet                print nothing on success\n");
}

/* DIR/NAME into path; 0 on success. */
static int join_path(char *path, size_t size, const char *dir, const char *name)
{
    int len = snprintf(path, size, "%s/%s", dir, name);
    return len < 0 || (size_t)len >= size;
}

static int make_folder(const char *dir)
{
    struct stat st;
    if (stat(dir, &st) == 0) return S_ISDIR(st.st_mode) ? 0 : 1;
    return mkdir(dir, 0777) != 0;
}

static void track_report(const track_args *a, const size_t *counts, const sqffd_fit_report *reports,
                         const double *volumes, const sqffd_motion_report *m, double seconds)
{
    size_t t;
    int k;
    printf("sqffd track: %lu frames -> %s\n", (unsigned long)a->frame_count, a->output);
    if (a->dropped_nan)
        printf("  dropped          %lu points with NaN coordinates (invalid depth) in %lu frame%s\n",
               (unsigned long)a->dropped_nan, (unsigned long)a->dropped_frames, a->dropped_frames == 1 ? "" : "s");
    printf("  frame  points      error %%  iterations  jacobian  volume\n");
    for (t = 0; t < a->frame_count; t++)
        printf("  %5lu  %8lu  %9.4f  %10d  %8.3f  %.6g%s\n", (unsigned long)t, (unsigned long)counts[t],
               100.0 * reports[t].error.rms_relative, reports[t].iterations, reports[t].min_jacobian, volumes[t],
               t == m->ed_frame ? "  ED" : t == m->es_frame ? "  ES" : "");
    if (a->motion.stacks)
        printf("  volumes          between each frame's outer short-axis slices +- half the spacing (%.4g)\n",
               a->motion.stacks[m->ed_frame].spacing);
    if (a->in.slice_shifts) print_slice_shifts(&a->shifts);
    if (a->lids)
        printf("  lids             %lu points close each frame's stack half a spacing beyond its outer slices "
               "(--no-lids: none)\n", (unsigned long)a->lids);
    printf("  end-diastolic volume   %.6g (frame %lu)\n", m->edv, (unsigned long)m->ed_frame);
    printf("  end-systolic volume    %.6g (frame %lu)\n", m->esv, (unsigned long)m->es_frame);
    printf("  ejection fraction  %.1f %%\n", 100.0 * m->ejection_fraction);
    printf("  long axis (base -> apex) %.4g %.4g %.4g, length %.4g; septum %.4g %.4g %.4g\n", m->axis[0], m->axis[1],
           m->axis[2], m->length, m->septum[0], m->septum[1], m->septum[2]);
    printf("  median wall excursion ED -> ES  %.4g (inward along the normal)\n", m->median_excursion);
    printf("  segment                  displacement  excursion  low-motion area  hypokinetic\n");
    for (k = 0; k < SQFFD_SEGMENTS; k++)
        printf("  %2d %-22s %12.4g  %9.4g  %13.0f %%  %s\n", k + 1, segment_names[k], m->segments[k].mean_displacement,
               m->segments[k].mean_excursion, 100.0 * m->segments[k].low_motion_share,
               m->segments[k].hypokinetic ? "yes" : "no");
    printf("  time             %.1f ms\n", 1e3 * seconds);
}

/* The outputs of track: the frames' meshes, motion.ply, the two tables. */
static int track_write(const track_args *a, const sqffd_model *models, const sqffd_fit_report *reports,
                       const sqffd_motion_outputs *out, size_t nv, const sqffd_motion_report *m)
{
    char path[4096], name[64], err[512];
    size_t nt = 2 * (nv - 2), t, v;
    uint32_t *triangles = NULL;
    double *flags = NULL, *segments = NULL;
    sqffd_io_scalar scalars[4];
    FILE *f;
    int k, status = EXIT_BAD_INPUT;
    triangles = (uint32_t *)malloc(3 * nt * sizeof *triangles);
    flags = (double *)malloc(nv * sizeof *flags);
    segments = (double *)malloc(nv * sizeof *segments);
    if (!triangles || !flags || !segments) {
        fprintf(stderr, "%s: out of memory\n", a->output);
        goto done;
    }
    sqffd_model_mesh(models, models->grid[0], models->grid[1], NULL, triangles);
    for (t = 0; t < a->frame_count; t++) {
        snprintf(name, sizeof name, "frame_%02lu.ply", (unsigned long)t);
        if (join_path(path, sizeof path, a->output, name) ||
            sqffd_io_write_ply(path, out->trajectories + 3 * nv * t, nv, triangles, nt, NULL, 0, a->ascii, err, sizeof err)) {
            fprintf(stderr, "%s\n", join_path(path, sizeof path, a->output, name) ? "output path too long" : err);
            goto done;
        }
    }
    for (v = 0; v < nv; v++) {
        flags[v] = out->low_motion[v];
        segments[v] = out->segment[v];
    }
    scalars[0].name = "displacement"; scalars[0].values = out->displacement;
    scalars[1].name = "excursion"; scalars[1].values = out->excursion;
    scalars[2].name = "low_motion"; scalars[2].values = flags;
    scalars[3].name = "segment"; scalars[3].values = segments;
    if (join_path(path, sizeof path, a->output, "motion.ply") ||
        sqffd_io_write_ply(path, out->trajectories + 3 * nv * m->ed_frame, nv, triangles, nt, scalars, 4, a->ascii, err,
                           sizeof err)) {
        fprintf(stderr, "%s\n", err);
        goto done;
    }
    if (join_path(path, sizeof path, a->output, "segments.csv") || !(f = fopen(path, "w"))) {
        fprintf(stderr, "%s: cannot write: %s\n", path, strerror(errno));
        goto done;
    }
    fprintf(f, "segment,name,area,mean_displacement,mean_excursion,low_motion_share,hypokinetic\n");
    for (k = 0; k < SQFFD_SEGMENTS; k++)
        fprintf(f, "%d,%s,%.9g,%.9g,%.9g,%.6f,%d\n", k + 1, segment_names[k], m->segments[k].area,
                m->segments[k].mean_displacement, m->segments[k].mean_excursion, m->segments[k].low_motion_share,
                m->segments[k].hypokinetic);
    if (fclose(f)) goto done;
    if (join_path(path, sizeof path, a->output, "volumes.csv") || !(f = fopen(path, "w"))) {
        fprintf(stderr, "%s: cannot write: %s\n", path, strerror(errno));
        goto done;
    }
    fprintf(f, "frame,file,volume,error_relative,iterations\n");
    for (t = 0; t < a->frame_count; t++)
        fprintf(f, "%lu,%s,%.9g,%.9g,%d\n", (unsigned long)t, a->frames[t], out->volumes[t], reports[t].error.rms_relative,
                reports[t].iterations);
    if (fclose(f)) goto done;
    status = 0;
done:
    free(triangles);
    free(flags);
    free(segments);
    return status;
}

/* What track_run leaves for the reports and the extra outputs. */
typedef struct track_result {
    sqffd_model *models;
    sqffd_fit_report *reports;
    sqffd_motion_outputs out;
    sqffd_motion_report motion;
    size_t vertices;      /* per frame's mesh */
    double seconds;
} track_result;

static void track_result_free(track_result *r)
{
    free(r->models);
    free(r->reports);
    free(r->out.volumes);
    free(r->out.trajectories);
    free(r->out.displacement);
    free(r->out.excursion);
    free(r->out.low_motion);
    free(r->out.segment);
    memset(r, 0, sizeof *r);
}

/* Tracks the frames, measures the motion and writes the outputs into
   a->output; 0, or an exit status after a message. */
/* The frames as short-axis stacks, before the tracking (prepare_stacks):
   a->stacks when every frame is one, the volumes between their slices
   unless --volume closed; 0, or an exit status after a message (also
   --volume slices on frames that are no stacks). */
static int track_stacks(track_args *a, double **points, size_t *counts)
{
    char err[512];
    int found = 0;
    a->stacks = (sqffd_stack *)calloc(a->frame_count, sizeof *a->stacks);
    if (!a->stacks) {
        fprintf(stderr, "sqffd track: out of memory\n");
        return EXIT_BAD_INPUT;
    }
    if (prepare_stacks(&a->in, a->frames, points, counts, a->frame_count, a->stacks, &found, &a->shifts, &a->lids, err,
                       sizeof err)) {
        fprintf(stderr, "%s\n", err);
        return EXIT_BAD_INPUT;
    }
    if (found) {
        if (a->volume != VOLUME_CLOSED) a->motion.stacks = a->stacks;
        return 0;
    }
    free(a->stacks);
    a->stacks = NULL;
    if (a->volume != VOLUME_SLICES) return 0;
    fprintf(stderr, "sqffd track: --volume slices: the frames are not short-axis stacks (points on 3 or more "
                    "parallel planes, slice by slice) with the same planes' normal\n");
    return EXIT_BAD_INPUT;
}

static int track_run(track_args *a, double **points, size_t *counts, track_result *res)
{
    track_progress progress;
    size_t work_size, done = 0, nv = 0, frames = a->frame_count;
    void *work = NULL;
    sqffd_result r;
    int status = EXIT_BAD_INPUT;
    double start;
    memset(res, 0, sizeof *res);
    if (make_folder(a->output)) {
        fprintf(stderr, "%s: cannot make the output folder (or it is a file)\n", a->output);
        return status;
    }
    res->models = (sqffd_model *)malloc(frames * sizeof *res->models);
    res->reports = (sqffd_fit_report *)malloc(frames * sizeof *res->reports);
    res->out.volumes = (double *)malloc(frames * sizeof(double));
    r = sqffd_track_workspace_size(counts, frames, &a->options, &work_size);
    if (r != SQFFD_OK) {
        fprintf(stderr, "sqffd track: cannot size the tracking: %s\n", sqffd_result_string(r));
        goto done;
    }
    work = malloc(work_size);
    if (!work || !res->models || !res->reports || !res->out.volumes) {
        fprintf(stderr, "sqffd track: out of memory (the tracking needs %lu bytes)\n", (unsigned long)work_size);
        goto done;
    }
    start = seconds_now();
    progress.start = start;
    progress.frames = frames;
    progress.terminal = isatty(fileno(stderr));
    progress.shown = 0;
    a->options.progress = a->quiet ? NULL : track_progress_report;
    a->options.progress_user = &progress;
    r = sqffd_track((const double *const *)points, counts, frames, &a->options, res->models, res->reports, &done, work,
                    work_size);
    if (progress.shown) fputc('\n', stderr);
    if (r != SQFFD_OK) {
        fprintf(stderr, "%s: tracking failed at frame %lu: %s\n", a->frames[done], (unsigned long)done,
                sqffd_result_string(r));
        goto done;
    }
    free(work);
    work = NULL;
    r = sqffd_motion_workspace_size(res->models, frames, &work_size);
    if (r != SQFFD_OK) {
        fprintf(stderr, "sqffd track: cannot size the motion analysis: %s\n", sqffd_result_string(r));
        goto done;
    }
    work = malloc(work_size);
    sqffd_model_mesh_size(res->models->grid[0], res->models->grid[1], &nv, NULL);
    res->vertices = nv;
    res->out.trajectories = (double *)malloc(3 * nv * frames * sizeof(double));
    res->out.displacement = (double *)malloc(nv * sizeof(double));
    res->out.excursion = (double *)malloc(nv * sizeof(double));
    res->out.low_motion = (unsigned char *)malloc(nv);
    res->out.segment = (unsigned char *)malloc(nv);
    if (!work || !res->out.trajectories || !res->out.displacement || !res->out.excursion || !res->out.low_motion ||
        !res->out.segment) {
        fprintf(stderr, "sqffd track: out of memory\n");
        goto done;
    }
    r = sqffd_motion(res->models, frames, &a->motion, &res->out, &res->motion, work, work_size);
    if (r != SQFFD_OK) {
        fprintf(stderr, "sqffd track: the motion analysis failed: %s\n", sqffd_result_string(r));
        goto done;
    }
    status = track_write(a, res->models, res->reports, &res->out, nv, &res->motion);
    res->seconds = seconds_now() - start;
done:
    free(work);
    return status;
}

static int cmd_track(int argc, char **argv)
{
    track_args a;
    track_result res;
    double **points = NULL;
    size_t *counts = NULL, i, t;
    char err[512];
    int help, status;

    memset(&a, 0, sizeof a);
    memset(&res, 0, sizeof res);
    a.inputs = (const char **)calloc((size_t)argc, sizeof *a.inputs);
    if (!a.inputs) return EXIT_BAD_INPUT;
    status = track_parse(argc, argv, &a, &help);
    if (status || help) {
        if (help) print_command_help(stdout, find_command("track"));
        free((void *)a.inputs);
        return status;
    }
    status = EXIT_BAD_INPUT;
    for (i = 0; i < a.input_count; i++) { /* every frame of every input, in order */
        double **got = NULL;
        size_t *got_counts = NULL, got_count = 0, total = a.frame_count;
        input_summary sum;
        int failed = read_input(a.inputs[i], &a.in, 0, &got, &got_counts, &got_count, &sum, err, sizeof err);
        double **grown = failed ? NULL : (double **)realloc(points, (total + got_count) * sizeof *points);
        size_t *grown_counts = grown ? (size_t *)realloc(counts, (total + got_count) * sizeof *counts) : NULL;
        const char **grown_frames = grown_counts ? (const char **)realloc((void *)a.frames, (total + got_count) * sizeof *a.frames) : NULL;
        if (grown) points = grown;
        if (grown_counts) counts = grown_counts;
        if (grown_frames) a.frames = grown_frames;
        if (!grown_frames) {
            if (failed) fprintf(stderr, "%s\n", err);
            else fprintf(stderr, "sqffd track: out of memory\n");
            free_frames(got, got_counts, got_count);
            goto done;
        }
        for (t = 0; t < got_count; t++) {
            points[total + t] = got[t];
            counts[total + t] = got_counts[t];
            a.frames[total + t] = a.inputs[i];
        }
        a.frame_count = total + got_count;
        a.dropped_nan += sum.dropped_nan;
        a.dropped_frames += sum.dropped_nan > 0;
        free(got);
        free(got_counts);
    }
    if (a.frame_count < 2) {
        status = usage_error(find_command("track"), "track: %lu frame: at least two are needed (several point files or "
                             "volumes, or one 4-D volume)", (unsigned long)a.frame_count);
        goto done;
    }
    if (a.motion.ed_frame >= a.frame_count) {
        status = usage_error(find_command("track"), "track: --ed %lu: there are %lu frames",
                             (unsigned long)a.motion.ed_frame, (unsigned long)a.frame_count);
        goto done;
    }
    if ((status = track_stacks(&a, points, counts)) != 0) goto done;
    status = track_run(&a, points, counts, &res);
    if (status == 0 && !a.quiet) track_report(&a, counts, res.reports, res.out.volumes, &res.motion, res.seconds);
done:
    free_frames(points, counts, a.frame_count);
    track_result_free(&res);
    free(a.stacks);
    free((void *)a.frames);
    free((void *)a.inputs);
    return status;
}

/* ---- sqffd phantom ----------------------------------------------------- */

/* The phantom's anatomy, by the convention of examples/sqffd_phantom.h: the
   long axis along z with the apex down, the septum toward -x. */
static const double phantom_septum[3] = {-1.0, 0.0, 0.0};

static void phantom_details(FILE *f)
{
    phantom_lv p = phantom_lv_default();
    fprintf(f,
            "A synthetic left ventricle (examples/sqffd_phantom.h: a closed cavity, apex down\n"
            "along -z, a lid at the base for the valve plane) beating through one cycle, end-\n"
            "diastole at frame 0, end-systole mid-way; each frame's points are drawn afresh, with\n"
            "Gaussian noise. Written to DIR (made if absent):\n"
            "  points_NN.ply   each frame's points, with a float 'label': 0 wall, 1 the\n"
            "                  hypokinetic zone, 2 the valve plane (the truth)\n"
            "  truth.csv       per frame: phase and true volume\n"
            "The report gives the true EDV, ESV and ejection fraction and the 'sqffd track'\n"
            "command to run (its septum is -x).\n"
            "\n"
            "  -o, --output DIR       output folder (required)\n"
            "  --frames N             frames over the cycle, 2..1000 (default 16)\n"
            "  --points N             points per frame, 20..10000000 (default 6000)\n"
            "  --noise S              noise standard deviation as a fraction of the ventricle's\n"
            "                         bounding-box diagonal (default 0.01)\n"
            "  --low-motion U,THETA,RADIUS,FACTOR\n"
            "                         the hypokinetic zone: centre (u 0..1 from apex to base,\n"
            "                         theta in radians), angular radius, motion factor 0..1\n"
            "                         (default %g,%g,%g,%g; factor 1: none)\n"
            "  --seed N               random seed (default 1)\n"
            "  --quiet                print nothing on success\n",
            p.low_motion[0], p.low_motion[1], p.low_motion[2], p.low_motion_factor);
}

static int cmd_phantom(int argc, char **argv)
{
    const cli_command *c = find_command("phantom");
    phantom_lv p = phantom_lv_default();
    arg_scan s;
    const char *arg, *v, *output = NULL;
    long frames = 16, count = 6000, seed = 1, k, i;
    double noise = 0.01, zone[4], *points = NULL, *labels = NULL;
    unsigned char *label = NULL;
    char path[4096], name[64], err[512];
    sqffd_io_scalar scalar;
    FILE *f;
    int kind, quiet = 0, status;
    memset(&s, 0, sizeof s);
    s.argc = argc;
    s.argv = argv;
    while ((kind = scan_next(&s, &arg)) != 0) {
#define IS(x) (strcmp(s.name, x) == 0)
        if (kind < 0) return usage_error(c, "phantom: unknown option '%s'", arg);
        if (kind == 1) return usage_error(c, "phantom: no positional arguments, '%s' is one", arg);
        if (IS("--help") || IS("-h") || IS("--quiet")) {
            if ((status = scan_flag(&s, c)) != 0) return status;
            if (IS("--quiet")) { quiet = 1; continue; }
            print_command_help(stdout, c);
            return 0;
        }
        if (!(IS("-o") || IS("--output") || IS("--frames") || IS("--points") || IS("--noise") || IS("--low-motion") ||
              IS("--seed")))
            return usage_error(c, "phantom: unknown option '%s'", s.argv[s.i]);
        if (!(v = scan_value(&s, c))) return EXIT_USAGE;
        if (IS("-o") || IS("--output")) output = v;
        else if (IS("--frames")) {
            if (parse_int(v, 2, 1000, &frames)) return usage_error(c, "phantom: --frames takes 2..1000, not '%s'", v);
        } else if (IS("--points")) {
            if (parse_int(v, 20, 10000000, &count))
                return usage_error(c, "phantom: --points takes 20..10000000, not '%s'", v);
        } else if (IS("--noise")) {
            if (parse_nonnegative(v, &noise) || noise > 0.5)
                return usage_error(c, "phantom: --noise takes a fraction 0..0.5, not '%s'", v);
        } else if (IS("--seed")) {
            if (parse_int(v, 0, 2000000000L, &seed)) return usage_error(c, "phantom: --seed takes a whole number, not '%s'", v);
        } else {
            if (parse_numbers(v, 4, zone) || zone[0] < 0.0 || zone[0] > 1.0 || zone[2] < 0.0 || zone[2] > 3.2 ||
                zone[3] < 0.0 || zone[3] > 1.0)
                return usage_error(c, "phantom: --low-motion takes U,THETA,RADIUS,FACTOR (u and factor 0..1, "
                                      "radius 0..3.2), not '%s'", v);
            p.low_motion[0] = zone[0]; p.low_motion[1] = zone[1]; p.low_motion[2] = zone[2];
            p.low_motion_factor = zone[3];
        }
#undef IS
    }
    if (!output) return usage_error(c, "phantom: no output folder (-o DIR)");
    status = EXIT_BAD_INPUT;
    if (make_folder(output)) {
        fprintf(stderr, "%s: cannot make the output folder (or it is a file)\n", output);
        return status;
    }
    points = (double *)malloc(3 * (size_t)count * sizeof *points);
    labels = (double *)malloc((size_t)count * sizeof *labels);
    label = (unsigned char *)malloc((size_t)count);
    if (!points || !labels || !label || join_path(path, sizeof path, output, "truth.csv") || !(f = fopen(path, "w"))) {
        fprintf(stderr, "%s: cannot write truth.csv\n", output);
        goto done;
    }
    fprintf(f, "frame,phase,volume\n");
    for (k = 0; k < frames; k++) {
        double phase = (double)k / (double)frames;
        fprintf(f, "%ld,%.9g,%.9g\n", k, phase, phantom_lv_volume(&p, phase));
        phantom_lv_frame(&p, phase, (size_t)count, noise, (uint64_t)seed * 1000003u + (uint64_t)k, points, label);
        for (i = 0; i < count; i++) labels[i] = label[i];
        scalar.name = "label";
        scalar.values = labels;
        snprintf(name, sizeof name, "points_%02ld.ply", k);
        if (join_path(path, sizeof path, output, name) ||
            sqffd_io_write_ply(path, points, (size_t)count, NULL, 0, &scalar, 1, 0, err, sizeof err)) {
            fprintf(stderr, "%s\n", err);
            fclose(f);
            goto done;
        }
    }
    if (fclose(f)) goto done;
    if (!quiet) {
        double edv = phantom_lv_volume(&p, 0.0), ef = phantom_lv_ejection_fraction(&p, (int)frames);
        printf("sqffd phantom: %ld frames of %ld points (noise %g of the %.4g diagonal) -> %s\n", frames, count, noise,
               phantom_lv_scale(&p), output);
        printf("  true end-diastolic volume  %.6g\n", edv);
        printf("  true end-systolic volume   %.6g\n", edv * (1.0 - ef));
        printf("  true ejection fraction  %.1f %%\n", 100.0 * ef);
        printf("  track it: sqffd track %s/points_*.ply -o OUT --septum %g,%g,%g\n", output, phantom_septum[0],
               phantom_septum[1], phantom_septum[2]);
    }
    status = 0;
done:
    free(points);
    free(labels);
    free(label);
    return status;
}

/* ---- sqffd info -------------------------------------------------------- */

static int cmd_info(int argc, char **argv)
{
    const cli_command *c = find_command("info");
    char err[512];
    size_t i;
    if (argc == 2 && (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0)) {
        print_command_help(stdout, c);
        return 0;
    }
    if (argc != 2) return usage_error(c, "info: one FILE");
    if (is_volume(argv[1])) {
        sqffd_image image;
        const sqffd_volume *v = &image.volume;
        double lo = 0.0, hi = 0.0;
        sqffd_result r;
        int row;
        if (sqffd_image_read_file(argv[1], &image, err, sizeof err)) {
            fprintf(stderr, "%s\n", err);
            return EXIT_BAD_INPUT;
        }
        r = sqffd_volume_range(v, &lo, &hi);
        printf("%s\n", argv[1]);
        printf("  format      %s, %s-endian\n", image.format, image.big_endian ? "big" : "little");
        printf("  dims        %lu x %lu x %lu", (unsigned long)v->dims[0], (unsigned long)v->dims[1], (unsigned long)v->dims[2]);
        printf(", %lu frame%s", (unsigned long)image.frames, image.frames == 1 ? "" : "s");
        if (image.frames > 1 && image.time_step > 0.0) printf(" (%g apart)", image.time_step);
        printf("\n  voxels      %s", image.stored_type);
        if ((v->scale != 0.0 && v->scale != 1.0) || v->offset != 0.0) printf(", scaled: value = %g x stored + %g", v->scale != 0.0 ? v->scale : 1.0, v->offset);
        printf("\n  spacing     %g x %g x %g\n", image.spacing[0], image.spacing[1], image.spacing[2]);
        if (r == SQFFD_OK) printf("  values      %g .. %g (frame 0)\n", lo, hi);
        else printf("  values      %s\n", sqffd_result_string(r));
        printf("  affine      voxel (i, j, k) centre -> world, from the %s\n", image.affine_source);
        for (row = 0; row < 4; row++)
            printf("              %12.6g %12.6g %12.6g %12.6g\n", v->affine[4 * row], v->affine[4 * row + 1],
                   v->affine[4 * row + 2], v->affine[4 * row + 3]);
        sqffd_image_free(&image);
    } else {
        double *points = NULL, lo[3], hi[3];
        size_t n = 0;
        sqffd_io_info io;
        const sqffd_io_pcd_header *pcd = &io.pcd;
        int k;
        if (sqffd_io_read_file_info(argv[1], &points, &n, &io, err, sizeof err)) {
            fprintf(stderr, "%s\n", err);
            return EXIT_BAD_INPUT;
        }
        for (k = 0; k < 3; k++) lo[k] = hi[k] = points[k];
        for (i = 0; i < n; i++)
            for (k = 0; k < 3; k++) {
                lo[k] = points[3 * i + k] < lo[k] ? points[3 * i + k] : lo[k];
                hi[k] = points[3 * i + k] > hi[k] ? points[3 * i + k] : hi[k];
            }
        printf("%s\n  format      %s", argv[1], sqffd_io_format_name(io.format));
        if (io.format == SQFFD_IO_PCD) printf("%s%s, %s", pcd->version[0] ? " " : "", pcd->version, pcd->encoding);
        if (io.format == SQFFD_IO_VTK) printf("%s%s %s", io.vtk_version[0] ? " " : "", io.vtk_version, io.vtk_dataset);
        if (io.format == SQFFD_IO_VTK || io.format == SQFFD_IO_STL) printf(", %s", io.binary ? "binary" : "ASCII");
        printf("%s\n", io.gzip ? ", gzip-compressed" : "");
        if (io.format == SQFFD_IO_STL)
            printf("  triangles   %lu (%lu vertices, %lu distinct: the points)\n", (unsigned long)io.stl_triangles,
                   3 * (unsigned long)io.stl_triangles, (unsigned long)n);
        if (io.format == SQFFD_IO_PCD) {
            printf("  fields      %s\n", pcd->fields);
            printf("  layout      %llu x %llu (%s)\n", (unsigned long long)pcd->width, (unsigned long long)pcd->height,
                   pcd->height > 1 ? "organised" : "unorganised");
            printf("  viewpoint   origin %g %g %g, orientation (w x y z) %g %g %g %g, not applied to the points\n",
                   pcd->viewpoint[0], pcd->viewpoint[1], pcd->viewpoint[2], pcd->viewpoint[3], pcd->viewpoint[4],
                   pcd->viewpoint[5], pcd->viewpoint[6]);
        }
        printf("  points      %lu\n", (unsigned long)n);
        if (io.dropped_nan)
            printf("  dropped     %lu points with NaN coordinates (invalid depth)\n", (unsigned long)io.dropped_nan);
        printf("  box         %g %g %g .. %g %g %g\n", lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
        printf("  diagonal    %g\n", sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                          (hi[2] - lo[2]) * (hi[2] - lo[2])));
        free(points);
    }
    return 0;
}

/* ---- sqffd demo -------------------------------------------------------- */

#define DEMO_FRAMES 16
#define DEMO_POINTS 6000

/* The paper's Table 1: the error after the FFD stage as the spring weight alpha grows. */
static int demo_table1(const double *points, size_t n, const sqffd_model *start, double alpha[4], double error[4])
{
    sqffd_fit_options o = sqffd_fit_options_default();
    size_t size;
    void *work;
    int k;
    if (sqffd_fit_ffd_workspace_size(n, start, &o, &size) != SQFFD_OK) return 1;
    work = malloc(size);
    if (!work) return 1;
    for (k = 0; k < 4; k++) {
        sqffd_model m = *start;
        sqffd_fit_report rep;
        alpha[k] = pow(10.0, k - 4.0);
        o.alpha = alpha[k];
        if (sqffd_fit_ffd(points, n, &o, &m, &rep, work, size) != SQFFD_OK) {
            free(work);
            return 1;
        }
        error[k] = rep.error.rms_relative;
    }
    free(work);
    return 0;
}

static int cmd_demo(int argc, char **argv)
{
    const cli_command *c = find_command("demo");
    phantom_lv p = phantom_lv_default();
    track_args a;
    track_result res;
    sqffd_model start;
    double *points[DEMO_FRAMES], alpha[4], table[4], t0 = seconds_now();
    size_t counts[DEMO_FRAMES], t;
    const char *frames[DEMO_FRAMES];
    char path[4096], err[512];
    int k, status = EXIT_BAD_INPUT;
    static const char *const written[] = {"frame_00.ply ... frame_15.ply", "motion.ply", "segments.csv",
                                          "volumes.csv", "model.json", "fig3_error.svg", "table1_alpha.svg",
                                          "volumes.svg", "bullseye.svg"};
    memset(&a, 0, sizeof a);
    a.output = "sqffd_demo";
    for (k = 1; k < argc; k++) {
        if (strcmp(argv[k], "--help") == 0 || strcmp(argv[k], "-h") == 0) {
            print_command_help(stdout, c);
            return 0;
        }
        if (strcmp(argv[k], "--quiet") == 0) a.quiet = 1;
        else if ((strcmp(argv[k], "-o") == 0 || strcmp(argv[k], "--output") == 0) && k + 1 < argc) a.output = argv[++k];
        else return usage_error(c, "demo: unknown argument '%s'", argv[k]);
    }
    a.options = sqffd_track_options_default();
    a.motion = sqffd_motion_options_default();
    memcpy(a.motion.septum_direction, phantom_septum, sizeof phantom_septum);
    a.frames = frames;
    a.frame_count = DEMO_FRAMES;
    memset(&res, 0, sizeof res);
    for (t = 0; t < DEMO_FRAMES; t++) {
        points[t] = (double *)malloc(3 * DEMO_POINTS * sizeof(double));
        counts[t] = DEMO_POINTS;
        frames[t] = "phantom";
        if (points[t]) phantom_lv_frame(&p, (double)t / DEMO_FRAMES, DEMO_POINTS, 0.01, 2026 + t, points[t], NULL);
        else { fprintf(stderr, "sqffd demo: out of memory\n"); goto done; }
    }
    if (!a.quiet)
        printf("sqffd demo: a beating left ventricle (examples/sqffd_phantom.h): %d frames x %d points, 1%% noise,\n"
               "a hypokinetic zone on the anterolateral wall at 20%% of normal motion; true EF %.1f %%\n\n",
               DEMO_FRAMES, DEMO_POINTS, 100.0 * phantom_lv_ejection_fraction(&p, DEMO_FRAMES));
    status = track_run(&a, points, counts, &res);
    if (status) goto done;
    status = EXIT_BAD_INPUT;
    /* Table 1 from frame 0's superquadric (the FFD stage again at each alpha) */
    start = res.models[0];
    sqffd_model_init(&start, &res.models[0].sq, &a.options.fit);
    if (demo_table1(points[0], counts[0], &start, alpha, table)) {
        fprintf(stderr, "sqffd demo: the alpha table failed\n");
        goto done;
    }
    if ((join_path(path, sizeof path, a.output, "model.json") == 0 &&
         sqffd_export_model_json(path, &res.models[0], &res.reports[0], err, sizeof err) == 0 &&
         join_path(path, sizeof path, a.output, "fig3_error.svg") == 0 &&
         sqffd_export_svg_history(path, &res.reports[0], "Frame 0: the error per FFD iteration (Fig. 3)", err, sizeof err) == 0 &&
         join_path(path, sizeof path, a.output, "table1_alpha.svg") == 0 &&
         sqffd_export_svg_alpha(path, alpha, table, 4, "Frame 0: the error against alpha (Table 1)", err, sizeof err) == 0 &&
         join_path(path, sizeof path, a.output, "volumes.svg") == 0 &&
         sqffd_export_svg_volumes(path, res.out.volumes, DEMO_FRAMES, &res.motion, "mm^3", "Model volume over the cycle",
                                  err, sizeof err) == 0 &&
         join_path(path, sizeof path, a.output, "bullseye.svg") == 0 &&
         sqffd_export_svg_bullseye(path, &res.motion, 1, "Inward excursion, ED to ES (17 segments)", "mm", err,
                                   sizeof err) == 0) == 0) {
        fprintf(stderr, "%s\n", err);
        goto done;
    }
    if (!a.quiet) {
        const sqffd_fit_report *r0 = &res.reports[0];
        printf("Fig. 3 (frame 0): the error per FFD iteration, %% of the diagonal\n  iteration");
        for (k = 0; k < r0->history_count && k < 30; k += 3) printf(" %6d", k + 1);
        printf("\n  error    ");
        for (k = 0; k < r0->history_count && k < 30; k += 3) printf(" %6.3f", 100.0 * r0->history[k]);
        printf("\n  superquadric alone %.3f %%, after %d iterations %.3f %%\n\n", 100.0 * r0->sq_error.rms_relative,
               r0->iterations, 100.0 * r0->error.rms_relative);
        printf("Table 1 (frame 0): the error after the FFD stage against alpha\n");
        for (k = 0; k < 4; k++) printf("  alpha %-8g  %.3f %%\n", alpha[k], 100.0 * table[k]);
        printf("\n");
        track_report(&a, counts, res.reports, res.out.volumes, &res.motion, res.seconds);
        printf("\nwritten to %s/:\n", a.output);
        for (k = 0; k < (int)(sizeof written / sizeof written[0]); k++) printf("  %s\n", written[k]);
        printf("total %.1f s\n", seconds_now() - t0);
    }
    status = 0;
done:
    for (t = 0; t < DEMO_FRAMES; t++) free(points[t]);
    track_result_free(&res);
    return status;
}

/* ---- sqffd help -------------------------------------------------------- */

static int cmd_help(int argc, char **argv)
{
    const cli_command *c;
    if (argc < 2 || strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0) {
        print_overview(stdout);
        return 0;
    }
    c = find_command(argv[1]);
    if (!c || argc > 2) return usage_error(find_command("help"), "help: unknown command '%s'", argv[1]);
    print_command_help(stdout, c);
    return 0;
}

int main(int argc, char **argv)
{
    const cli_command *c;
    if (argc < 2) {
        fprintf(stderr, "sqffd: no command\n");
        print_overview(stderr);
        return EXIT_USAGE;
    }
    if (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0) {
        print_overview(stdout);
        return 0;
    }
    if (strcmp(argv[1], "--version") == 0) {
        printf("sqffd %s\n", SQFFD_VERSION_STRING);
        return 0;
    }
    c = find_command(argv[1]);
    if (!c) {
        fprintf(stderr, "sqffd: unknown command '%s'\n", argv[1]);
        print_overview(stderr);
        return EXIT_USAGE;
    }
    return c->run(argc - 1, argv + 1);
}

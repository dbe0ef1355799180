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

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <math.h>
#include <sys/stat.h>

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
static int cmd_help(int argc, char **argv);

static const cli_command commands[] = {
    {"fit", "fit a superquadric + free-form deformation model to a point file",
     "sqffd fit INPUT -o OUT.ply [--lattice N|LxMxN] [--alpha A] [--model-to-data W] [--iterations K] [--robust] [--no-taper] [--quiet]",
     fit_details,
     cmd_fit},
    {"track", "track a model through a sequence of point files: motion, volumes, ejection fraction, 17 segments",
     "sqffd track FRAME... -o DIR [--ed N] [--septum X,Y,Z] [--apex X,Y,Z] [--low-motion F] [--frame-iterations K] "
     "[model options of fit] [--ascii] [--quiet]",
     track_details,
     cmd_track},
    {"phantom", "write a synthetic beating left ventricle as point files that 'sqffd track' reads",
     "sqffd phantom -o DIR [--frames N] [--points N] [--noise S] [--low-motion U,THETA,RADIUS,FACTOR] [--seed N]",
     phantom_details,
     cmd_phantom},
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
    if (!(IS("--lattice") || IS("--alpha") || IS("--model-to-data") || IS("--iterations"))) return 0;
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
    } else if (parse_int(v, 0, 10000, &n)) {
        *status = usage_error(c, "%s: --iterations takes a whole number 0..10000, not '%s'", c->name, v);
    } else {
        o->max_iterations = (int)n;
    }
#undef IS
    return 1;
}

/* The model options' help lines, shared by fit and track. */
static void model_option_details(FILE *f, const char *iterations_note)
{
    sqffd_fit_options d = sqffd_fit_options_default();
    fprintf(f,
            "  --lattice N|LxMxN      FFD control points per axis, 2..%d (default %dx%dx%d)\n"
            "  --alpha A              spring weight of the energy, >= 0 (default %g)\n"
            "  --model-to-data W      weight of the model -> data term, >= 0 (default %g;\n"
            "                         0: the data -> model distances alone)\n"
            "  --iterations K         FFD iterations at most, 0..10000 (default %d; %s)\n"
            "  --robust               outlier-robust fit in both stages\n"
            "  --no-taper             superquadric without tapering (11 parameters, not 13)\n",
            SQFFD_MAX_LATTICE, d.lattice[0], d.lattice[1], d.lattice[2], d.alpha, d.model_to_data, d.max_iterations,
            iterations_note);
}

/* ---- sqffd fit --------------------------------------------------------- */

typedef struct fit_args {
    const char *input, *output, *points_output;
    sqffd_fit_options options;
    int mesh[2];
    int ascii, quiet;
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
        if (scan_model_option(&s, c, &a->options, &status)) {
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
        if (!(IS("-o") || IS("--output") || IS("--points") || IS("--mesh")))
            return usage_error(c, "fit: unknown option '%s'", s.argv[s.i]);
        if (!(v = scan_value(&s, c))) return EXIT_USAGE;
        if (IS("-o") || IS("--output")) a->output = v;
        else if (IS("--points")) a->points_output = v;
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
    fprintf(f,
            "INPUT is a point file: PLY (ascii, binary little or big endian; vertex x y z read,\n"
            "other properties and elements skipped), OFF, or XYZ (x y z per line, extra columns\n"
            "ignored, '#' comments). The format is found from the content, then the extension.\n"
            "\n"
            "  -o, --output OUT.ply   the model surface as a triangle mesh (required), with a\n"
            "                         per-vertex float 'error': the distance from that model\n"
            "                         vertex to the nearest data point\n");
    model_option_details(f, "0: the superquadric alone");
    fprintf(f,
            "  --mesh N|ExO           output mesh grid, eta x omega, 4..1024 (default 64x128)\n"
            "  --points FILE.ply      also write the data points, each with a float 'error':\n"
            "                         its distance to the model surface\n"
            "  --ascii                write ascii PLY instead of binary little endian\n"
            "  --quiet                print nothing on success\n"
            "\n"
            "The error in the report is the RMS distance from the data points to the model\n"
            "surface, relative to the diagonal of the data's bounding box.\n");
}

static void print_vec3(const char *label, const double *v)
{
    printf("  %-16s %.6g %.6g %.6g\n", label, v[0], v[1], v[2]);
}

static void fit_report(const fit_args *a, size_t n, const sqffd_model *model, const sqffd_fit_report *r,
                       size_t mesh_vertices, size_t mesh_triangles, const sqffd_distance_stats *model_to_data,
                       const double t[4])
{
    const sqffd_superquadric *sq = &model->sq;
    const sqffd_ffd *ffd = &model->ffd;
    printf("sqffd fit %s\n", a->input);
    printf("  points read      %lu\n", (unsigned long)n);
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
    printf("  iterations       %d%s\n", r->iterations,
           r->iterations == 0 ? " (the superquadric alone)" : r->converged ? " (converged)" : " (iteration cap)");
    printf("  model mesh       %s: %lu vertices, %lu triangles; model-to-data RMS %.4f %%, max %.4f %%\n",
           a->output, (unsigned long)mesh_vertices, (unsigned long)mesh_triangles,
           100.0 * model_to_data->rms_relative, 100.0 * model_to_data->max_relative);
    if (a->points_output) printf("  data points      %s (with their distance to the model)\n", a->points_output);
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
    size = sqffd_model_reverse_distances_workspace_size(n, &shown);
    work = size ? malloc(size) : NULL;
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
    double *points = NULL, *vertices = NULL, *vertex_error = NULL, *point_error = NULL, t[4];
    sqffd_distance_stats mesh_stats;
    uint32_t *triangles = NULL;
    void *work = NULL;
    size_t n, work_size, nv = 0, nt = 0;
    char err[512];
    int help, status = EXIT_BAD_INPUT;
    sqffd_io_scalar scalar;

    status = fit_parse(argc, argv, &a, &help);
    if (status) return status;
    if (help) {
        print_command_help(stdout, find_command("fit"));
        return 0;
    }
    status = EXIT_BAD_INPUT;
    t[0] = seconds_now();
    if (sqffd_io_read_file(a.input, &points, &n, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        return EXIT_BAD_INPUT;
    }
    t[1] = seconds_now();

    work_size = sqffd_fit_workspace_size(n, &a.options);
    if (work_size == 0) {
        fprintf(stderr, "%s: %lu points: too many for the fit\n", a.input, (unsigned long)n);
        goto done;
    }
    work = malloc(work_size);
    if (!work) {
        fprintf(stderr, "%s: out of memory (the fit needs %lu bytes)\n", a.input, (unsigned long)work_size);
        goto done;
    }
    r = sqffd_fit(points, n, &a.options, &model, &report, work, work_size);
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
    if (sqffd_io_write_ply(a.output, vertices, nv, triangles, nt, &scalar, 1, a.ascii, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        goto done;
    }
    if (a.points_output) {
        size_t dsize = sqffd_model_distances_workspace_size(n, &model);
        void *dwork = dsize ? malloc(dsize) : NULL;
        sqffd_distance_stats stats;
        point_error = (double *)malloc(n * sizeof *point_error);
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
    t[3] = seconds_now();
    if (!a.quiet) fit_report(&a, n, &model, &report, nv, nt, &mesh_stats, t);
    status = 0;
done:
    free(points);
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

typedef struct track_args {
    const char **frames;
    size_t frame_count;
    const char *output;
    sqffd_track_options options;
    sqffd_motion_options motion;
    int ascii, quiet;
} track_args;

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
    *help = 0;
    while ((kind = scan_next(&s, &arg)) != 0) {
#define IS(x) (strcmp(s.name, x) == 0)
        if (kind < 0) return usage_error(c, "track: unknown option '%s'", arg);
        if (kind == 1) {
            a->frames[a->frame_count++] = arg;
            continue;
        }
        if (scan_model_option(&s, c, &a->options.fit, &status)) {
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
              IS("--frame-iterations")))
            return usage_error(c, "track: unknown option '%s'", s.argv[s.i]);
        if (!(v = scan_value(&s, c))) return EXIT_USAGE;
        if (IS("-o") || IS("--output")) a->output = v;
        else if (IS("--ed")) {
            if (parse_int(v, 0, 1000000, &n)) return usage_error(c, "track: --ed takes a frame number, not '%s'", v);
            a->motion.ed_frame = (size_t)n;
        } else if (IS("--septum") || IS("--apex")) {
            if (parse_numbers(v, 3, IS("--septum") ? a->motion.septum_direction : a->motion.apex_direction))
                return usage_error(c, "track: %s takes a direction X,Y,Z, not '%s'", s.name, v);
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
    if (a->frame_count < 2) return usage_error(c, "track: at least two FRAME files, in time order");
    if (!a->output) return usage_error(c, "track: no output folder (-o DIR)");
    if (a->motion.ed_frame >= a->frame_count)
        return usage_error(c, "track: --ed %lu: there are %lu frames", (unsigned long)a->motion.ed_frame,
                           (unsigned long)a->frame_count);
    return 0;
}

static void track_details(FILE *f)
{
    sqffd_track_options d = sqffd_track_options_default();
    sqffd_motion_options m = sqffd_motion_options_default();
    fprintf(f,
            "Each FRAME is a point file (as 'sqffd fit' reads), one per time step, in time order.\n"
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
            "  --frame-iterations K   FFD iterations of the frames after the first (default %d)\n",
            (unsigned long)m.ed_frame, m.low_motion_fraction, m.hypokinetic_share, d.frame_iterations);
    model_option_details(f, "frame 0");
    fprintf(f,
            "  --ascii                write ascii PLY instead of binary little endian\n"
            "  --quiet                print nothing on success\n");
}

/* Progress on stderr once the tracking has taken more than a second. */
typedef struct track_progress {
    double start;
    size_t frames;
    int shown;
} track_progress;

static int track_progress_report(void *user, int stage, int iteration, double error)
{
    track_progress *p = (track_progress *)user;
    (void)error;
    if (stage == SQFFD_STAGE_FRAME && seconds_now() - p->start > 1.0) {
        fprintf(stderr, "\rsqffd track: frame %d of %lu", iteration + 1, (unsigned long)p->frames);
        p->shown = 1;
    }
    return 0;
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
    printf("  frame  points      error %%  iterations  volume\n");
    for (t = 0; t < a->frame_count; t++)
        printf("  %5lu  %8lu  %9.4f  %10d  %.6g%s\n", (unsigned long)t, (unsigned long)counts[t],
               100.0 * reports[t].error.rms_relative, reports[t].iterations, volumes[t],
               t == m->ed_frame ? "  ED" : t == m->es_frame ? "  ES" : "");
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

static int cmd_track(int argc, char **argv)
{
    track_args a;
    track_progress progress;
    sqffd_motion_report motion;
    sqffd_motion_outputs outputs;
    sqffd_result r;
    double **points = NULL, *volumes = NULL, *trajectories = NULL, *displacement = NULL, *excursion = NULL, start;
    size_t *counts = NULL, t, done = 0, work_size, nv = 0;
    sqffd_model *models = NULL;
    sqffd_fit_report *reports = NULL;
    unsigned char *low_motion = NULL, *segment = NULL;
    void *work = NULL;
    char err[512];
    int help, status;

    memset(&a, 0, sizeof a);
    a.frames = (const char **)calloc((size_t)argc, sizeof *a.frames);
    if (!a.frames) return EXIT_BAD_INPUT;
    status = track_parse(argc, argv, &a, &help);
    if (status || help) {
        if (help) print_command_help(stdout, find_command("track"));
        free((void *)a.frames);
        return status;
    }
    status = EXIT_BAD_INPUT;
    points = (double **)calloc(a.frame_count, sizeof *points);
    counts = (size_t *)calloc(a.frame_count, sizeof *counts);
    models = (sqffd_model *)malloc(a.frame_count * sizeof *models);
    reports = (sqffd_fit_report *)malloc(a.frame_count * sizeof *reports);
    volumes = (double *)malloc(a.frame_count * sizeof *volumes);
    if (!points || !counts || !models || !reports || !volumes) {
        fprintf(stderr, "sqffd track: out of memory\n");
        goto done;
    }
    for (t = 0; t < a.frame_count; t++)
        if (sqffd_io_read_file(a.frames[t], &points[t], &counts[t], err, sizeof err)) {
            fprintf(stderr, "%s\n", err);
            goto done;
        }
    if (make_folder(a.output)) {
        fprintf(stderr, "%s: cannot make the output folder (or it is a file)\n", a.output);
        goto done;
    }
    work_size = sqffd_track_workspace_size(counts, a.frame_count, &a.options);
    work = work_size ? malloc(work_size) : NULL;
    if (!work) {
        fprintf(stderr, "sqffd track: out of memory (the tracking needs %lu bytes)\n", (unsigned long)work_size);
        goto done;
    }
    start = seconds_now();
    progress.start = start;
    progress.frames = a.frame_count;
    progress.shown = 0;
    a.options.progress = track_progress_report;
    a.options.progress_user = &progress;
    r = sqffd_track((const double *const *)points, counts, a.frame_count, &a.options, models, reports, &done, work,
                    work_size);
    if (progress.shown) fputc('\n', stderr);
    if (r != SQFFD_OK) {
        fprintf(stderr, "%s: tracking failed at frame %lu: %s\n", a.frames[done], (unsigned long)done,
                sqffd_result_string(r));
        goto done;
    }
    free(work);
    work_size = sqffd_motion_workspace_size(models, a.frame_count);
    work = work_size ? malloc(work_size) : NULL;
    sqffd_model_mesh_size(models->grid[0], models->grid[1], &nv, NULL);
    trajectories = (double *)malloc(3 * nv * a.frame_count * sizeof *trajectories);
    displacement = (double *)malloc(nv * sizeof *displacement);
    excursion = (double *)malloc(nv * sizeof *excursion);
    low_motion = (unsigned char *)malloc(nv);
    segment = (unsigned char *)malloc(nv);
    if (!work || !trajectories || !displacement || !excursion || !low_motion || !segment) {
        fprintf(stderr, "sqffd track: out of memory\n");
        goto done;
    }
    memset(&outputs, 0, sizeof outputs);
    outputs.volumes = volumes;
    outputs.trajectories = trajectories;
    outputs.displacement = displacement;
    outputs.excursion = excursion;
    outputs.low_motion = low_motion;
    outputs.segment = segment;
    r = sqffd_motion(models, a.frame_count, &a.motion, &outputs, &motion, work, work_size);
    if (r != SQFFD_OK) {
        fprintf(stderr, "sqffd track: the motion analysis failed: %s\n", sqffd_result_string(r));
        goto done;
    }
    status = track_write(&a, models, reports, &outputs, nv, &motion);
    if (status == 0 && !a.quiet) track_report(&a, counts, reports, volumes, &motion, seconds_now() - start);
done:
    if (points)
        for (t = 0; t < a.frame_count; t++) free(points[t]);
    free(points);
    free(counts);
    free(models);
    free(reports);
    free(volumes);
    free(trajectories);
    free(displacement);
    free(excursion);
    free(low_motion);
    free(segment);
    free(work);
    free((void *)a.frames);
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

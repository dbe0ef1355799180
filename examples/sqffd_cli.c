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

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

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
static int cmd_help(int argc, char **argv);

static const cli_command commands[] = {
    {"fit", "fit a superquadric + free-form deformation model to a point file",
     "sqffd fit INPUT -o OUT.ply [--lattice N|LxMxN] [--alpha A] [--model-to-data W] [--iterations K] [--robust] [--no-taper] [--quiet]",
     fit_details,
     cmd_fit},
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
    int i, options_done = 0;
    memset(a, 0, sizeof *a);
    a->options = sqffd_fit_options_default();
    a->mesh[0] = 64;
    a->mesh[1] = 128;
    *help = 0;
    for (i = 1; i < argc; i++) {
        const char *arg = argv[i], *value = NULL, *eq;
        char name[32];
        long v;
        if (options_done || arg[0] != '-' || arg[1] == '\0') {
            if (a->input) return usage_error(c, "fit: one INPUT only, '%s' is a second", arg);
            a->input = arg;
            continue;
        }
        if (strcmp(arg, "--") == 0) { options_done = 1; continue; }
        /* --name=value or --name value */
        eq = strchr(arg, '=');
        if (eq && (size_t)(eq - arg) < sizeof name) {
            memcpy(name, arg, (size_t)(eq - arg));
            name[eq - arg] = '\0';
            value = eq + 1;
        } else if (strlen(arg) < sizeof name) {
            strcpy(name, arg);
        } else {
            return usage_error(c, "fit: unknown option '%s'", arg);
        }
#define IS(s) (strcmp(name, s) == 0)
        if (IS("--help") || IS("-h") || IS("--robust") || IS("--no-taper") || IS("--quiet") || IS("--ascii")) {
            if (value) return usage_error(c, "fit: option '%s' takes no value", name);
            if (IS("--help") || IS("-h")) { *help = 1; return 0; }
            if (IS("--robust")) a->options.sq.robust = 1;
            if (IS("--no-taper")) a->options.sq.taper = 0;
            if (IS("--quiet")) a->quiet = 1;
            if (IS("--ascii")) a->ascii = 1;
            continue;
        }
        if (!(IS("-o") || IS("--output") || IS("--points") || IS("--lattice") || IS("--mesh") || IS("--alpha") ||
              IS("--model-to-data") || IS("--iterations")))
            return usage_error(c, "fit: unknown option '%s'", arg);
        if (!value) {
            if (i + 1 == argc) return usage_error(c, "fit: option '%s' needs a value", name);
            value = argv[++i];
        }
        if (IS("-o") || IS("--output")) {
            a->output = value;
        } else if (IS("--points")) {
            a->points_output = value;
        } else if (IS("--lattice")) {
            if (parse_dims(value, 3, 2, SQFFD_MAX_LATTICE, a->options.lattice))
                return usage_error(c, "fit: --lattice takes N or LxMxN, each 2..%d, not '%s'", SQFFD_MAX_LATTICE, value);
        } else if (IS("--mesh")) {
            if (parse_dims(value, 2, 4, 1024, a->mesh))
                return usage_error(c, "fit: --mesh takes N or ExO, each 4..1024, not '%s'", value);
        } else if (IS("--alpha")) {
            if (parse_nonnegative(value, &a->options.alpha))
                return usage_error(c, "fit: --alpha takes a finite number >= 0, not '%s'", value);
        } else if (IS("--model-to-data")) {
            if (parse_nonnegative(value, &a->options.model_to_data))
                return usage_error(c, "fit: --model-to-data takes a finite number >= 0, not '%s'", value);
        } else { /* --iterations */
            if (parse_int(value, 0, 10000, &v))
                return usage_error(c, "fit: --iterations takes a whole number 0..10000, not '%s'", value);
            a->options.max_iterations = (int)v;
        }
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
            "other properties and elements skipped), OFF, or XYZ (x y z per line, extra columns\n"
            "ignored, '#' comments). The format is found from the content, then the extension.\n"
            "\n"
            "  -o, --output OUT.ply   the model surface as a triangle mesh (required), with a\n"
            "                         per-vertex float 'error': the distance from that model\n"
            "                         vertex to the nearest data point\n"
            "  --lattice N|LxMxN      FFD control points per axis, 2..%d (default %dx%dx%d)\n"
            "  --alpha A              spring weight of the energy, >= 0 (default %g)\n"
            "  --model-to-data W      weight of the model -> data term, >= 0 (default %g;\n"
            "                         0: the data -> model distances alone)\n"
            "  --iterations K         FFD iterations at most, 0..10000 (default %d; 0: the superquadric alone)\n"
            "  --robust               outlier-robust fit in both stages\n"
            "  --no-taper             superquadric without tapering (11 parameters, not 13)\n"
            "  --mesh N|ExO           output mesh grid, eta x omega, 4..1024 (default 64x128)\n"
            "  --points FILE.ply      also write the data points, each with a float 'error':\n"
            "                         its distance to the model surface\n"
            "  --ascii                write ascii PLY instead of binary little endian\n"
            "  --quiet                print nothing on success\n"
            "\n"
            "The error in the report is the RMS distance from the data points to the model\n"
            "surface, relative to the diagonal of the data's bounding box.\n",
            SQFFD_MAX_LATTICE, d.lattice[0], d.lattice[1], d.lattice[2], d.alpha, d.model_to_data, d.max_iterations);
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

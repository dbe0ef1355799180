/* sqffd - command-line tool for sqffd.h: git-style subcommands.

     sqffd fit INPUT -o OUT.ply [options]   fit a superquadric + FFD model to a point file
     sqffd help [COMMAND]                   usage of the tool or of one command

   Exit status: 0 success, 1 bad input or failed fit (message "FILE: what is
   wrong" on stderr) or a report lost (standard output not written), 2 usage
   error (message and a short usage on stderr).
   Build: make (-> build/sqffd). */
#define _POSIX_C_SOURCE 200809L
#define _XOPEN_SOURCE 700 /* realpath */
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
#include <dirent.h>
#include <signal.h>
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
     "sqffd fit INPUT -o OUT.ply [--iso V|auto|--label N] [--all-components] [--sample N] [--slice-shifts] [--no-lids] "
     "[--lattice N|LxMxN] [--alpha A] [--model-to-data W] [--min-jacobian J|none] [--iterations K] [--coarse-iterations K] "
     "[--robust] [--no-taper] [--mesh N] [--vtk] [--ascii] [--points FILE] [--json FILE] [--svg FILE] [--quiet]",
     fit_details,
     cmd_fit},
    {"track", "track a model through a sequence of point files: motion, volumes, ejection fraction, 17 segments",
     "sqffd track FRAME... -o DIR [--ed N] [--septum X,Y,Z] [--apex X,Y,Z] [--low-motion F] [--frame-iterations K] "
     "[--volume auto|closed|slices] [--mm-per-unit F] [--json FILE] [--epi FILE,FILE,...|--myocardium-label N] "
     "[input and model options of fit] [--ascii] [--quiet]",
     track_details,
     cmd_track},
    {"phantom", "write a synthetic beating left ventricle as point files that 'sqffd track' reads",
     "sqffd phantom -o DIR [--frames N] [--points N] [--noise S] [--low-motion U,THETA,RADIUS,FACTOR] [--seed N] [--epi] [--quiet]",
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
               "Exit status: 0 success, 1 bad input, a failed fit or a failed write (also of the\n"
               "report to standard output), 2 usage error.\n");
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

/* ---- the numeric options' ranges: one table ------------------------------

   Every value inside a range works (a fit runs without error on real
   shapes at either end); outside it, a usage error names the option and
   its range. */
typedef struct number_range {
    const char *command;  /* the command whose option it is; NULL: any that takes it */
    const char *name;
    double lo, hi;
    int whole;            /* a whole number */
    const char *word;     /* a word it takes instead of a number, or NULL */
} number_range;

static const number_range number_ranges[] = {
    /* the model's (fit, track) */
    {NULL, "--lattice", 2, SQFFD_MAX_LATTICE, 1, NULL},
    /* the library's ranges (sqffd.h: SQFFD_FIT_ALPHA_MAX, SQFFD_FIT_MODEL_TO_DATA_MAX) */
    {NULL, "--alpha", 0, SQFFD_FIT_ALPHA_MAX, 0, NULL},
    {NULL, "--model-to-data", 0, SQFFD_FIT_MODEL_TO_DATA_MAX, 0, NULL},
    {NULL, "--min-jacobian", -1e6, 1, 0, "none"},
    {NULL, "--iterations", 0, 10000, 1, NULL},
    {NULL, "--coarse-iterations", 0, 10000, 1, NULL},
    /* inputs (fit, track) */
    {NULL, "--sample", 20, 100000000, 1, NULL},
    {"fit", "--mesh", 4, 1024, 1, NULL},
    {"track", "--ed", 0, 1000000, 1, NULL},
    {"track", "--low-motion", 0, 1, 0, NULL},
    {"track", "--frame-iterations", 0, 10000, 1, NULL},
    {"phantom", "--frames", 2, 1000, 1, NULL},
    {"phantom", "--points", 20, 10000000, 1, NULL},
    {"phantom", "--noise", 0, 0.5, 0, NULL},
    {"phantom", "--seed", 0, 2000000000, 1, NULL},
};

static const number_range *find_range(const char *command, const char *name)
{
    size_t i;
    for (i = 0; i < sizeof number_ranges / sizeof number_ranges[0]; i++)
        if (strcmp(number_ranges[i].name, name) == 0 &&
            (!number_ranges[i].command || strcmp(number_ranges[i].command, command) == 0))
            return &number_ranges[i];
    return NULL; /* (every caller names an option of the table) */
}

/* Option `name`'s range (of command `command`) as the messages and the
   help write it, "[2, 8]", "[0, 1e12]", into text. */
typedef char range_text_buffer[96];
static const char *range_text(const char *command, const char *name, range_text_buffer text)
{
    const number_range *r = find_range(command, name);
    char lo[32], hi[32], *e;
    snprintf(lo, sizeof lo, "%g", r->lo);
    snprintf(hi, sizeof hi, "%g", r->hi);
    for (e = lo; e; e = e == lo ? hi : NULL) { /* 1e+12 -> 1e12, 1e-09 -> 1e-9 */
        char *x = strchr(e, 'e');
        if (!x) continue;
        x++;
        if (*x == '+') memmove(x, x + 1, strlen(x));
        else if (*x == '-') x++;
        while (*x == '0' && x[1]) memmove(x, x + 1, strlen(x));
    }
    snprintf(text, sizeof(range_text_buffer), "[%s, %s]", lo, hi);
    return text;
}

/* Option `name` of command c with value v: a number in its range into
   *out; 0, or a usage error's status after the message. */
static int option_number(const cli_command *c, const char *name, const char *v, double *out)
{
    const number_range *r = find_range(c->name, name);
    range_text_buffer text;
    double x = 0.0;
    long n;
    char *end;
    int bad;
    if (r->whole) {
        bad = parse_int(v, (long)r->lo, (long)r->hi, &n);
        x = (double)n;
    } else {
        errno = 0;
        x = strtod(v, &end);
        bad = !*v || *v == ' ' || *v == '\t' || *end || errno || !(x >= r->lo) ||
              !(x <= r->hi);
    }
    if (bad)
        return usage_error(c, "%s: %s must be %s%s%s%s%s, not '%s'", c->name, name,
                           r->whole ? "a whole number in " : "in ", range_text(c->name, name, text),
                           r->word ? " or '" : "", r->word ? r->word : "", r->word ? "'" : "", v);
    *out = x;
    return 0;
}

/* Option `name` of command c: "N" (all axes) or "AxBxC" of `parts` whole
   numbers in its range into dims; 0, or a usage error's status. */
static int option_dims(const cli_command *c, const char *name, const char *v, int parts, int *dims)
{
    const number_range *r = find_range(c->name, name);
    range_text_buffer text;
    if (!parse_dims(v, parts, (long)r->lo, (long)r->hi, dims)) return 0;
    return usage_error(c, "%s: %s must be N or %s, each a whole number in %s, not '%s'", c->name, name,
                       parts == 3 ? "LxMxN" : "ExO", range_text(c->name, name, text), v);
}

static double seconds_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* ---- outputs: checked before the work, written whole or not at all --------

   Every file the commands write goes through an output set. output_add
   checks a path before any work: it is none of the inputs and no other
   output (the same file: device and inode, so a link is caught too), and
   its folder takes a new file, for the file's temporary is created there
   at once ("FOLDER/.NAME.XXXXXX"). The writers fill the temporaries one
   at a time (output_open); output_commit closes the last and, only when
   every one was written whole, renames each over its target (a symbolic
   link's target: the link is kept). Any failure before that, and output_abort, remove every
   temporary: a failed run leaves the targets as they were. (The renames
   themselves, one per file in the target's own folder, are not undone if
   a later one fails.) A target that exists and is no regular file
   (/dev/null, a FIFO) is written in place. */

typedef struct output_file {
    char *path;          /* as given (for messages and output_stream) */
    char *target;        /* the file renamed over: path, or the file a symbolic link names */
    char *temp;          /* the temporary beside it; NULL when written in place */
    struct stat folder;  /* the target's folder */
    struct stat file;    /* the target, when it exists (exists) */
    int exists;
} output_file;

typedef struct output_set {
    output_file *file;
    size_t count;
    FILE *open;                 /* the one being written (output_open), or NULL */
    size_t open_index;
    const char *const *inputs;  /* the run's inputs: no output may be one of them */
    size_t input_count;
    const char *folder;         /* a folder output_folder made (removed again if the run fails and it is empty) */
} output_set;

static int same_file(const struct stat *a, const struct stat *b)
{
    return a->st_dev == b->st_dev && a->st_ino == b->st_ino;
}

/* The input that is the same file as st, or NULL. */
static const char *output_input_clash(const output_set *set, const struct stat *st)
{
    struct stat in;
    size_t i;
    for (i = 0; i < set->input_count; i++)
        if (stat(set->inputs[i], &in) == 0 && same_file(&in, st)) return set->inputs[i];
    return NULL;
}

/* The name of path after its last '/'. */
static const char *base_name(const char *path)
{
    const char *slash = strrchr(path, '/');
    return slash ? slash + 1 : path;
}

/* Whether outputs a and b are the same file: the same name in the same
   folder, or one file under two names (hard links). */
static int output_same(const output_file *a, const output_file *b)
{
    return (same_file(&a->folder, &b->folder) && strcmp(base_name(a->target), base_name(b->target)) == 0) ||
           (a->exists && b->exists && same_file(&a->file, &b->file));
}

/* Adds path to the set: the checks above, then its temporary; 0, or 1
   after a message on stderr. */
/* An interrupted run (SIGINT, SIGTERM, SIGHUP) leaves no temporary behind:
   the handler removes those of the live output set, then dies of the
   signal. The set's own functions run with those signals blocked, so the
   handler never sees it half changed. */
static output_set *volatile live_outputs;
static int guard_depth;

static void output_guard(int enter)
{
    sigset_t s;
    sigemptyset(&s);
    sigaddset(&s, SIGINT);
    sigaddset(&s, SIGTERM);
    sigaddset(&s, SIGHUP);
    if (enter ? guard_depth++ == 0 : --guard_depth == 0) sigprocmask(enter ? SIG_BLOCK : SIG_UNBLOCK, &s, NULL);
}

static void output_interrupted(int sig)
{
    output_set *set = live_outputs;
    size_t i;
    if (set) {
        for (i = 0; i < set->count; i++)
            if (set->file[i].temp) unlink(set->file[i].temp);
        if (set->folder) rmdir(set->folder);
    }
    signal(sig, SIG_DFL);
    raise(sig);
}

static void output_watch(output_set *set)
{
    static const int signals[] = {SIGINT, SIGTERM, SIGHUP};
    struct sigaction sa;
    size_t i;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = output_interrupted;
    sigemptyset(&sa.sa_mask);
    for (i = 0; i < sizeof signals / sizeof signals[0]; i++) {
        struct sigaction old;
        if (sigaction(signals[i], NULL, &old) == 0 && old.sa_handler != SIG_IGN) /* (nohup's stays ignored) */
            sigaction(signals[i], &sa, NULL);
    }
    live_outputs = set;
}

static int output_add_guarded(output_set *set, const char *path);

static int output_add(output_set *set, const char *path)
{
    int r;
    output_guard(1);
    if (live_outputs != set) output_watch(set);
    r = output_add_guarded(set, path);
    output_guard(0);
    return r;
}

static int output_add_guarded(output_set *set, const char *path)
{
    output_file *grown, *o;
    struct stat link;
    const char *clash;
    size_t i, len;
    int fd;
    grown = (output_file *)realloc(set->file, (set->count + 1) * sizeof *set->file);
    if (!grown) { fprintf(stderr, "%s: out of memory\n", path); return 1; }
    set->file = grown;
    o = &set->file[set->count++]; /* (output_abort frees what it holds) */
    memset(o, 0, sizeof *o);
    o->exists = stat(path, &o->file) == 0;
    o->path = strdup(path);
    o->target = o->exists && lstat(path, &link) == 0 && S_ISLNK(link.st_mode) ? realpath(path, NULL) : strdup(path);
    if (!o->path || !o->target) { fprintf(stderr, "%s: out of memory\n", path); return 1; }
    if (o->exists && S_ISDIR(o->file.st_mode)) { fprintf(stderr, "%s: cannot create: it is a folder\n", path); return 1; }
    if (o->exists && !S_ISREG(o->file.st_mode)) return 0; /* a device or a FIFO (/dev/null): written in place */
    if (o->exists && (clash = output_input_clash(set, &o->file)) != NULL) {
        fprintf(stderr, "sqffd: the output %s is the input %s (the same file): give another output\n", path, clash);
        return 1;
    }
    /* the temporary, FOLDER/.NAME.XXXXXX, made now: the folder exists and takes a file */
    len = (size_t)(base_name(o->target) - o->target); /* the folder's part, its '/' included */
    o->temp = (char *)malloc(strlen(o->target) + 10);
    if (!o->temp) { fprintf(stderr, "%s: out of memory\n", path); return 1; }
    sprintf(o->temp, "%.*s", (int)(len ? len : 1), len ? o->target : ".");
    errno = 0;
    fd = -1;
    if (stat(o->temp, &o->folder) == 0) {
        sprintf(o->temp, "%.*s.%s.XXXXXX", (int)len, o->target, base_name(o->target));
        fd = mkstemp(o->temp);
    }
    if (fd < 0) {
        fprintf(stderr, "%s: cannot create: %s\n", path, errno ? strerror(errno) : "unknown error");
        free(o->temp);
        o->temp = NULL;
        return 1;
    }
    for (i = 0; i + 1 < set->count; i++)
        if (output_same(&set->file[i], o)) {
            fprintf(stderr, "sqffd: the outputs %s and %s are the same file: give each its own\n", set->file[i].path, path);
            close(fd);
            return 1;
        }
    if (!o->exists) { /* the mode a new file gets (mkstemp's is 0600); else the target's */
        mode_t mask = umask(0);
        umask(mask);
        o->file.st_mode = 0666 & ~mask;
    }
    errno = 0;
    if (fchmod(fd, o->file.st_mode & 07777) != 0 || close(fd) != 0) {
        fprintf(stderr, "%s: cannot create: %s\n", path, errno ? strerror(errno) : "unknown error");
        return 1;
    }
    return 0;
}

/* DIR/NAME into path (4096 bytes); 0 on success. */
static int join_path(char *path, const char *dir, const char *name)
{
    int len = snprintf(path, 4096, "%s/%s", dir, name);
    return len < 0 || len >= 4096;
}

/* DIR/NAME added to the set; 0, or 1 after a message. */
static int output_add_in(output_set *set, const char *dir, const char *name)
{
    char path[4096];
    if (join_path(path, dir, name)) {
        fprintf(stderr, "%s: output path too long\n", dir);
        return 1;
    }
    return output_add(set, path);
}

/* Closes the stream being written; 0, or 1 with a message in err. */
static int output_close(output_set *set, char *err, size_t err_size)
{
    FILE *f = set->open;
    int failed;
    if (!f) return 0;
    set->open = NULL;
    errno = 0;
    failed = fflush(f) != 0 || ferror(f);
    failed |= fclose(f) != 0;
    if (failed)
        snprintf(err, err_size, "%s: write error: %s", set->file[set->open_index].path,
                 errno ? strerror(errno) : "unknown error");
    return failed;
}

/* The stream to write the output added as path (the last one closed);
   NULL with a message in err. */
static FILE *output_open(output_set *set, const char *path, char *err, size_t err_size)
{
    size_t i;
    if (output_close(set, err, err_size)) return NULL;
    for (i = 0; i < set->count && strcmp(set->file[i].path, path) != 0; i++) continue;
    errno = 0;
    if (i < set->count && (set->open = fopen(set->file[i].temp ? set->file[i].temp : set->file[i].target, "wb")) != NULL) {
        set->open_index = i;
        return set->open;
    }
    snprintf(err, err_size, "%s: cannot write: %s", path,
             i == set->count ? "not an output (a bug)" : errno ? strerror(errno) : "unknown error");
    return NULL;
}

/* Removes every temporary, and the folder output_folder made if it is empty. */
static void output_abort(output_set *set)
{
    size_t i;
    output_guard(1);
    if (set->open) fclose(set->open);
    set->open = NULL;
    for (i = 0; i < set->count; i++) {
        if (set->file[i].temp) unlink(set->file[i].temp);
        free(set->file[i].path);
        free(set->file[i].target);
        free(set->file[i].temp);
    }
    if (set->folder) rmdir(set->folder);
    free(set->file);
    set->file = NULL;
    set->count = 0;
    set->folder = NULL;
    if (live_outputs == set) live_outputs = NULL;
    output_guard(0);
}

/* Closes the last output written; when all were written whole, renames
   each over its target. 0, or 1 after a message (the targets untouched,
   the temporaries removed). */
static int output_commit(output_set *set)
{
    char err[512];
    size_t i;
    int status;
    output_guard(1);
    status = output_close(set, err, sizeof err);
    if (status) fprintf(stderr, "%s\n", err);
    for (i = 0; i < set->count && !status; i++) {
        output_file *o = &set->file[i];
        if (o->temp && rename(o->temp, o->target) != 0) {
            fprintf(stderr, "%s: cannot replace: %s\n", o->path, strerror(errno));
            status = 1;
        }
        if (!status) { free(o->temp); o->temp = NULL; }
    }
    if (!status) set->folder = NULL; /* (kept) */
    output_abort(set);
    output_guard(0);
    return status;
}

/* The numbered outputs of a command in a folder: PREFIX NN SUFFIX, NN as
   "%02lu" writes it (frame_00.ply ... frame_123.ply); 1 and the number in
   *k when name is one. */
static int numbered_name(const char *name, const char *prefix, const char *suffix, unsigned long *k)
{
    size_t lp = strlen(prefix), ls = strlen(suffix), len = strlen(name);
    char canonical[64];
    if (len <= lp + ls || len - lp - ls > 20 || strncmp(name, prefix, lp) != 0 || strcmp(name + len - ls, suffix) != 0 ||
        name[lp] < '0' || name[lp] > '9')
        return 0;
    *k = strtoul(name + lp, NULL, 10);
    snprintf(canonical, sizeof canonical, "%s%02lu%s", prefix, *k, suffix);
    return strcmp(canonical, name) == 0;
}

/* A command's output folder: made if absent; none of the files in it that
   bear the command's numbered names (each is written or removed by the
   run: output_prune) may be an input. 0, or 1 after a message. */
static int output_folder(output_set *set, const char *dir, const char *prefix, const char *suffix)
{
    struct stat st;
    DIR *d;
    struct dirent *e;
    unsigned long k;
    char path[4096];
    const char *clash = NULL;
    if (stat(dir, &st) != 0) {
        if (mkdir(dir, 0777) != 0) {
            fprintf(stderr, "%s: cannot make the output folder: %s\n", dir, strerror(errno));
            return 1;
        }
        output_guard(1);
        set->folder = dir;
        if (live_outputs != set) output_watch(set);
        output_guard(0);
        return 0;
    }
    if (!S_ISDIR(st.st_mode)) {
        fprintf(stderr, "%s: cannot make the output folder: a file of that name exists\n", dir);
        return 1;
    }
    if (!(d = opendir(dir))) {
        fprintf(stderr, "%s: cannot read the output folder: %s\n", dir, strerror(errno));
        return 1;
    }
    while (!clash && (e = readdir(d)) != NULL)
        if (numbered_name(e->d_name, prefix, suffix, &k) &&
            (size_t)snprintf(path, sizeof path, "%s/%s", dir, e->d_name) < sizeof path && stat(path, &st) == 0)
            clash = output_input_clash(set, &st);
    closedir(d);
    if (clash)
        fprintf(stderr, "sqffd: the input %s is the output folder's %s, which this run replaces or removes: give "
                        "another output folder\n", clash, base_name(path));
    return clash != NULL;
}

/* After a run wrote count numbered files into dir: removes the ones an
   earlier, longer run left (numbers count and up; no other file). */
static void output_prune(const char *dir, const char *prefix, const char *suffix, size_t count)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    unsigned long k;
    char path[4096];
    if (!d) return;
    while ((e = readdir(d)) != NULL)
        if (numbered_name(e->d_name, prefix, suffix, &k) && k >= count &&
            (size_t)snprintf(path, sizeof path, "%s/%s", dir, e->d_name) < sizeof path)
            unlink(path);
    closedir(d);
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
    double n = 0.0;
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
    else if (IS("--lattice")) *status = option_dims(c, s->name, v, 3, o->lattice);
    else if (IS("--min-jacobian") && strcmp(v, "none") == 0) o->min_jacobian = -HUGE_VAL;
    else if ((*status = option_number(c, s->name, v, &n)) != 0) return 1;
    else if (IS("--alpha")) o->alpha = n;
    else if (IS("--model-to-data")) o->model_to_data = n;
    else if (IS("--min-jacobian")) o->min_jacobian = n;
    else if (IS("--iterations")) o->max_iterations = (int)n;
    else o->coarse_iterations = (int)n;
#undef IS
    return 1;
}

/* The model options' help lines, shared by fit and track (d: the command's defaults). */
static void model_option_details(FILE *f, const sqffd_fit_options *d, const char *iterations_note)
{
    range_text_buffer r[6];
    fprintf(f,
            "  --lattice N|LxMxN      FFD control points per axis, %s (default %dx%dx%d)\n"
            "  --alpha A              spring weight of the energy, %s (default %g)\n"
            "  --model-to-data W      weight of the model -> data term, %s (default %g;\n"
            "                         0: the data -> model distances alone)\n"
            "  --min-jacobian J       the model's Jacobian on its region (the superquadric's solid and\n"
            "                         a band around it) stays at or above J, %s\n"
            "                         (default %g: the model cannot fold where it lives; 'none': no floor)\n"
            "  --iterations K         FFD iterations at most, %s (default %d;\n"
            "                         %s)\n"
            "  --coarse-iterations K  of those, at most K first on a coarse grid (half the rows and\n"
            "                         columns, %d points at most), %s (default %d; 0: none)\n"
            "  --robust               outlier-robust fit in both stages\n"
            "  --no-taper             superquadric without tapering (11 parameters, not 13)\n",
            range_text("fit", "--lattice", r[0]), d->lattice[0], d->lattice[1], d->lattice[2],
            range_text("fit", "--alpha", r[1]), d->alpha, range_text("fit", "--model-to-data", r[2]), d->model_to_data,
            range_text("fit", "--min-jacobian", r[3]), d->min_jacobian, range_text("fit", "--iterations", r[4]),
            d->max_iterations, iterations_note, SQFFD_FIT_COARSE_POINTS, range_text("fit", "--coarse-iterations", r[5]),
            d->coarse_iterations);
}

/* ---- inputs: point files and volumes ------------------------------------ */

/* How a volume becomes points (fit and track share these options). */
typedef struct input_args {
    int iso_auto;         /* Otsu's threshold (the default) */
    double iso;           /* else this level */
    int iso_set;          /* --iso was given (auto or a level) */
    int label_set;        /* a label map: the surface of the voxels of this label */
    double label;
    int label2_set;       /* ... and of this one together (track --myocardium-label: the epicardium) */
    double label2;
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
    double n = 0.0;
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
        in->iso_set = 1;
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
    } else if ((*status = option_number(c, s->name, v, &n)) == 0) {
        in->sample = (size_t)n;
        in->sample_set = 1;
    }
    return 1;
}

static void input_option_details(FILE *f)
{
    range_text_buffer r;
    fprintf(f,
            "  --iso V|auto           volumes: the iso level (default auto: Otsu's threshold)\n"
            "  --label N              label maps (segmentations): the surface of the voxels labelled N\n"
            "                         (crossings at the voxel edges' midpoints), instead of --iso\n"
            "  --sample N             keep N points evenly spread, %s (volumes: default %d;\n"
            "                         point files: all)\n"
            "  --all-components       volumes: keep every piece of the iso-surface (default: the\n"
            "                         largest connected one, so specks and noise are dropped)\n"
            "  --slice-shifts         short-axis stacks (contours listed slice by slice): correct\n"
            "                         breath-hold misregistration first, each slice moved in-plane\n"
            "                         onto the stack's smooth centreline (one shift a slice, the same\n"
            "                         in every frame), and report the shifts\n"
            "  --no-lids              short-axis stacks: leave their ends open (default: each frame's\n"
            "                         outer contours filled in half a spacing beyond its outer\n"
            "                         slices, where Simpson's method ends, so the model closes there)\n",
            range_text("fit", "--sample", r), VOLUME_SAMPLE);
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
        if (sqffd_stack_detect(frames[t], counts[t], &stacks[t], &found) != SQFFD_OK || !found ||
            fabs(axis[0] * here[0] + axis[1] * here[1] + axis[2] * here[2]) < 0.999)
            break;
    }
    return t;
}

/* Each frame's stack closed by its lids (sqffd_stack_lids), appended to its
   points; added[t]: how many frame t got. 0, or 1 with a message in err. */
static int add_lids(double **frames, size_t *counts, size_t frame_count, const sqffd_stack *stacks, size_t *added,
                    char *err, size_t err_size)
{
    size_t t, n;
    for (t = 0; t < frame_count; t++) {
        double *grown;
        sqffd_result r = sqffd_stack_lids(frames[t], counts[t], &stacks[t], NULL, 0, &n);
        grown = r == SQFFD_OK ? (double *)realloc(frames[t], 3 * (counts[t] + n) * sizeof(double)) : NULL;
        if (grown) {
            frames[t] = grown;
            r = sqffd_stack_lids(frames[t], counts[t], &stacks[t], frames[t] + 3 * counts[t], n, &n);
        }
        if (r != SQFFD_OK || !grown) {
            snprintf(err, err_size, "sqffd: the stack's lids: %s", grown ? sqffd_result_string(r) : "out of memory");
            return 1;
        }
        counts[t] += n;
        added[t] = n;
    }
    return 0;
}

/* --slice-shifts on the frames' stacks: one shift a slice
   (sqffd_stack_shifts), each frame's points moved; 0, or 1 with a message
   in err. */
static int correct_slices(const char *name, double *const *frames, const size_t *counts, size_t frame_count,
                          const sqffd_stack *stacks, sqffd_slice_shifts *shifts, char *err, size_t err_size)
{
    sqffd_result r = sqffd_stack_shifts((const double *const *)frames, counts, stacks, frame_count, shifts);
    size_t t;
    for (t = 0; t < frame_count && r == SQFFD_OK; t++) r = sqffd_stack_shifts_apply(shifts, frames[t], counts[t], NULL);
    if (r == SQFFD_OK) return 0;
    snprintf(err, err_size, "%s: --slice-shifts: %s%s", name, sqffd_result_string(r),
             r == SQFFD_ERROR_INVALID_ARGUMENT ? " (more levels over the frames than a stack holds)" : "");
    return 1;
}

/* The frames as short-axis stacks, before a fit or a track: *found when
   every frame is one, their planes parallel (their stacks in stacks); then
   --slice-shifts (which needs them) moves their slices, and unless
   --no-lids each frame's lids are appended (lids[t]: how many frame t got,
   else 0). 0, or 1 with a message in err. */
static int prepare_stacks(const input_args *in, const char *const *names, double **frames, size_t *counts,
                          size_t frame_count, sqffd_stack *stacks, int *found, sqffd_slice_shifts *shifts,
                          size_t *lids, char *err, size_t err_size)
{
    size_t stacked = find_stacks(frames, counts, frame_count, stacks);
    *found = stacked == frame_count;
    memset(lids, 0, frame_count * sizeof *lids);
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
    o.labelled = in->label2_set ? 2 : in->label_set;
    o.label = in->label;
    o.label2 = in->label2;
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
        const char *volume_only = in->iso_set ? "--iso" : in->label_set ? "--label" : in->all_components ? "--all-components" : NULL;
        if (volume_only) {
            snprintf(err, err_size, "%s: a point file, and %s applies to volumes only (their iso-surface)", path, volume_only);
            return 1;
        }
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
        else if ((status = option_dims(c, s.name, v, 2, a->mesh)) != 0)
            return status;
#undef IS
    }
    if (!a->input) return usage_error(c, "fit: no INPUT file");
    if (!a->output) return usage_error(c, "fit: no output file (-o OUT.ply)");
    return 0;
}

static void fit_details(FILE *f)
{
    sqffd_fit_options d = sqffd_fit_options_default();
    range_text_buffer r;
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
            "  --mesh N|ExO           output mesh grid, eta x omega, each %s (default 64x128)\n"
            "  --points FILE.ply      also write the data points, each with a float 'error':\n"
            "                         its distance to the model surface\n"
            "  --vtk                  write the mesh as legacy VTK polydata (ParaView) instead of PLY\n"
            "  --json FILE            also write the model as JSON (every number to rebuild it)\n"
            "  --svg FILE             also write the error per iteration as an SVG plot\n"
            "  --ascii                write ascii PLY (or VTK) instead of binary\n"
            "  --quiet                print nothing on success\n"
            "\n"
            "The error in the report is the RMS distance from the data points to the model\n"
            "surface, relative to the diagonal of the data's bounding box.\n"
            "Every output is checked before the fit (none may be the input or another output)\n"
            "and written whole or not at all: each to a temporary file beside it, all renamed\n"
            "over their names only once every one is written.\n",
            range_text("fit", "--mesh", r));
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
    printf("    jacobian       %.4f   (its certified lower bound on the model's region: %s)\n", r->min_jacobian,
           r->min_jacobian > 0.0 ? "> 0, no fold" : "<= 0, the model may fold");
    if (r->coarse_iterations > 0) printf("  iterations       %d coarse + %d", r->coarse_iterations, r->iterations);
    else printf("  iterations       %d", r->iterations);
    printf("%s\n", r->iterations == 0                ? " (the superquadric alone)"
                  : r->stop == SQFFD_FIT_CONVERGED ? " (converged)"
                  : r->stop == SQFFD_FIT_STALLED   ? " (stalled: no further progress)"
                                                   : " (iteration cap: not converged)");
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
    output_set out;
    FILE *f;
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
    memset(&out, 0, sizeof out);
    out.inputs = &a.input;
    out.input_count = 1;
    if (output_add(&out, a.output) || (a.points_output && output_add(&out, a.points_output)) ||
        (a.json_output && output_add(&out, a.json_output)) || (a.svg_output && output_add(&out, a.svg_output)))
        goto done;
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
    if (n < SQFFD_SQ_FIT_MIN_POINTS) {
        fprintf(stderr, "%s: %lu points; at least %d are needed\n", a.input, (unsigned long)n, SQFFD_SQ_FIT_MIN_POINTS);
        goto done;
    }

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
    if (!(f = output_open(&out, a.output, err, sizeof err)) ||
        (a.vtk ? sqffd_export_vtk_stream(f, a.output, "sqffd model", vertices, nv, triangles, nt, &scalar, 1,
                                         a.ascii ? SQFFD_EXPORT_VTK_ASCII : 0, err, sizeof err)
               : sqffd_io_write_ply_stream(f, a.output, vertices, nv, triangles, nt, &scalar, 1, a.ascii, err, sizeof err))) {
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
        if (!(f = output_open(&out, a.points_output, err, sizeof err)) ||
            sqffd_io_write_ply_stream(f, a.points_output, points, n, NULL, 0, &scalar, 1, a.ascii, err, sizeof err)) {
            fprintf(stderr, "%s\n", err);
            goto done;
        }
    }
    if ((a.json_output && (!(f = output_open(&out, a.json_output, err, sizeof err)) ||
                           sqffd_export_model_json_stream(f, a.json_output, &model, &report, err, sizeof err))) ||
        (a.svg_output && (!(f = output_open(&out, a.svg_output, err, sizeof err)) ||
                          sqffd_export_svg_history_stream(f, a.svg_output, &report, a.input, err, sizeof err)))) {
        fprintf(stderr, "%s\n", err);
        goto done;
    }
    if (output_commit(&out)) goto done;
    t[3] = seconds_now();
    if (!a.quiet) fit_report(&a, &input, n, &model, &report, nv, nt, &mesh_stats, t);
    if (!a.quiet && lids)
        printf("  lids             %lu of the points close the stack half a spacing beyond its outer slices (--no-lids: "
               "none)\n", (unsigned long)lids);
    if (!a.quiet && a.in.slice_shifts) print_slice_shifts(&shifts);
    status = 0;
done:
    output_abort(&out);
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
    size_t *lids;                /* per frame: the points its stack's lids added (NULL: none) */
    int ascii, quiet;
    size_t dropped_nan, dropped_frames; /* PCD points dropped for NaN coordinates, and the frames that had some */
    int ed_given;                /* --ed: else ED is the frame of largest volume */
    double mm_per_unit;          /* --mm-per-unit (default 1): the report's numbers are the model's times it */
    int unit;                    /* UNIT_GIVEN, UNIT_ASSUMED (a point file without --mm-per-unit), UNIT_VOLUMES */
    const char *json_output;     /* --json FILE */
    output_set out;              /* the files written into output (track_outputs) */
    /* the heart wall: --epi or --myocardium-label */
    int wall;
    char *epi_list;              /* --epi's value, split at its commas into ... */
    const char **epi_inputs;     /* ... the epicardial inputs */
    size_t epi_input_count;
    int myocardium_set;          /* --myocardium-label: the epicardium from the FRAME label maps */
    double myocardium_label;
    double **epi_points;         /* the epicardial frames (as many as the frames), their counts and inputs */
    size_t *epi_counts;
    const char **epi_frames;
    size_t epi_frame_count;
    sqffd_stack *epi_stacks;     /* as stacks and lids, for the epicardium */
    size_t *epi_lids;
    sqffd_wall_options wall_options;
} track_args;

/* The myocardium's density (g/ml): mass = density x volume. */
#define MYOCARDIUM_DENSITY 1.05

enum { UNIT_VOLUMES, UNIT_ASSUMED, UNIT_GIVEN };
static const char *const unit_sources[] = {"volume files (mm)", "assumed", "given"};

/* A septum direction at least this many degrees off the long axis: only its
   part across the axis counts, and nearer the axis that part is less than
   half of it and turns by cot(angle) degrees (over 1.7) for a degree of the
   axis. */
#define TRACK_SEPTUM_MIN_DEGREES 30.0

/* A frame the model could not follow: its relative RMS error above both
   TRACK_ERROR_RATIO x the median of the other frames' and TRACK_ERROR_FLOOR.
   The error is relative to the frame's own bounding-box diagonal, so the
   rule holds for any shape at any scale. The frames of one sequence are one
   object: on the real hearts (ED and ES of 11 exams, 3 contourings each,
   tracked in either order) the larger error is at most 1.99 x the smaller,
   and every error is below 2.2 %; a model that lost its frame (a sphere,
   then the same sphere shrunk 20,000 times) is at 31,730 % against 0.013 %.
   The floor keeps sequences of small errors (0.1 % against 0.5 %, both
   close fits) from failing on the ratio. */
#define TRACK_ERROR_RATIO 4.0
#define TRACK_ERROR_FLOOR 0.05

static void track_args_default(track_args *a)
{
    memset(a, 0, sizeof *a);
    a->options = sqffd_track_options_default();
    a->motion = sqffd_motion_options_default();
    a->wall_options = sqffd_wall_options_default();
    input_args_default(&a->in);
    a->mm_per_unit = 1.0;
}

/* --epi's value: FILE,FILE,... into a->epi_inputs; 0, or a usage error's status. */
static int parse_epi(track_args *a, const char *v)
{
    char *p;
    size_t n = 1;
    free(a->epi_list);
    free((void *)a->epi_inputs);
    a->epi_inputs = NULL;
    a->epi_input_count = 0;
    for (p = (char *)v; *p; p++) n += *p == ',';
    a->epi_list = strdup(v);
    a->epi_inputs = (const char **)malloc(n * sizeof *a->epi_inputs);
    if (!a->epi_list || !a->epi_inputs) {
        fprintf(stderr, "sqffd track: out of memory\n");
        return EXIT_BAD_INPUT;
    }
    for (p = a->epi_list;; p++) {
        char *comma = strchr(p, ',');
        if (comma) *comma = '\0';
        if (!*p)
            return usage_error(find_command("track"), "track: --epi takes FILE,FILE,... (an epicardial frame for each "
                               "frame, in the same order), not '%s'", v);
        a->epi_inputs[a->epi_input_count++] = p;
        if (!comma) return 0;
        p = comma;
    }
}

/* The angle in degrees between two directions of non-zero length (each
   divided by its largest component first, so that no square overflows). */
static double angle_degrees(const double *u, const double *v)
{
    double a[3], b[3], su = 0.0, sv = 0.0, dot = 0.0, uu = 0.0, vv = 0.0, c;
    int k;
    for (k = 0; k < 3; k++) {
        su = fabs(u[k]) > su ? fabs(u[k]) : su;
        sv = fabs(v[k]) > sv ? fabs(v[k]) : sv;
    }
    for (k = 0; k < 3; k++) {
        a[k] = u[k] / su;
        b[k] = v[k] / sv;
        dot += a[k] * b[k];
        uu += a[k] * a[k];
        vv += b[k] * b[k];
    }
    c = dot / sqrt(uu * vv);
    return acos(c > 1.0 ? 1.0 : c < -1.0 ? -1.0 : c) * 180.0 / 3.14159265358979323846;
}

/* The septum against a long axis (either way along it): 0 when at least
   TRACK_SEPTUM_MIN_DEGREES off, else a usage error's status after a
   message naming the option; what: the axis's name. */
static int septum_check(const track_args *a, const double *axis, const char *what)
{
    const double *s = a->motion.septum_direction;
    double angle = angle_degrees(s, axis);
    angle = angle > 90.0 ? 180.0 - angle : angle;
    if (!(s[0] != 0.0 || s[1] != 0.0 || s[2] != 0.0) || angle >= TRACK_SEPTUM_MIN_DEGREES) return 0;
    return usage_error(find_command("track"), "track: --septum %g,%g,%g is %.1f degrees from %s (%.4g %.4g %.4g): "
                       "a septum direction must be at least %g degrees off the long axis (only its part across the "
                       "axis counts)", s[0], s[1], s[2], angle, what, axis[0], axis[1], axis[2],
                       TRACK_SEPTUM_MIN_DEGREES);
}

static int track_parse(int argc, char **argv, track_args *a, int *help)
{
    const cli_command *c = find_command("track");
    arg_scan s;
    const char *arg, *v;
    int kind, status;
    double n = 0.0;
    memset(&s, 0, sizeof s);
    s.argc = argc;
    s.argv = argv;
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
              IS("--frame-iterations") || IS("--volume") || IS("--mm-per-unit") || IS("--json") || IS("--epi") ||
              IS("--myocardium-label")))
            return usage_error(c, "track: unknown option '%s'", s.argv[s.i]);
        if (!(v = scan_value(&s, c))) return EXIT_USAGE;
        if (IS("-o") || IS("--output")) a->output = v;
        else if (IS("--ed")) {
            if ((status = option_number(c, s.name, v, &n)) != 0) return status;
            a->motion.ed_frame = (size_t)n;
            a->ed_given = 1;
        } else if (IS("--septum") || IS("--apex")) {
            double *d = IS("--septum") ? a->motion.septum_direction : a->motion.apex_direction;
            if (parse_numbers(v, 3, d))
                return usage_error(c, "track: %s takes a direction X,Y,Z of finite numbers, not '%s'", s.name, v);
            if (d[0] == 0.0 && d[1] == 0.0 && d[2] == 0.0)
                return usage_error(c, "track: %s %s: a direction needs a non-zero length", s.name, v);
        } else if (IS("--mm-per-unit")) {
            if (parse_numbers(v, 1, &a->mm_per_unit) || !(a->mm_per_unit > 0.0))
                return usage_error(c, "track: --mm-per-unit takes a finite number > 0 (millimetres per unit of the "
                                   "point files), not '%s'", v);
            a->unit = UNIT_GIVEN;
        } else if (IS("--json")) {
            a->json_output = v;
        } else if (IS("--epi")) {
            if ((status = parse_epi(a, v)) != 0) return status;
        } else if (IS("--myocardium-label")) {
            if (parse_numbers(v, 1, &a->myocardium_label))
                return usage_error(c, "track: --myocardium-label takes a voxel value (the myocardium's label), not '%s'", v);
            a->myocardium_set = 1;
        } else if (IS("--volume")) {
            a->volume = strcmp(v, "auto") == 0 ? VOLUME_AUTO : strcmp(v, "closed") == 0 ? VOLUME_CLOSED
                      : strcmp(v, "slices") == 0 ? VOLUME_SLICES : -1;
            if (a->volume < 0) return usage_error(c, "track: --volume takes auto, closed or slices, not '%s'", v);
        } else if (IS("--low-motion")) {
            if ((status = option_number(c, s.name, v, &a->motion.low_motion_fraction)) != 0) return status;
        } else {
            if ((status = option_number(c, s.name, v, &n)) != 0) return status;
            a->options.frame_iterations = (int)n;
        }
#undef IS
    }
    if (a->input_count == 0) return usage_error(c, "track: no FRAME input");
    if (!a->output) return usage_error(c, "track: no output folder (-o DIR)");
    if (a->myocardium_set && !a->in.label_set)
        return usage_error(c, "track: --myocardium-label needs --label (the cavity's label in the same label maps)");
    if (a->myocardium_set && a->epi_input_count)
        return usage_error(c, "track: --epi and --myocardium-label exclude each other (the epicardium from its own "
                           "frames, or from the FRAME label maps)");
    if (a->myocardium_set && a->myocardium_label == a->in.label)
        return usage_error(c, "track: --myocardium-label %g is the cavity's --label", a->myocardium_label);
    a->wall = a->epi_input_count > 0 || a->myocardium_set;
    if (a->motion.apex_direction[0] != 0.0 || a->motion.apex_direction[1] != 0.0 || a->motion.apex_direction[2] != 0.0)
        return septum_check(a, a->motion.apex_direction, "--apex");
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
            "                           segments.csv   per AHA segment: area (mm^2), mean displacement and\n"
            "                                          excursion (mm), low-motion share, flag\n"
            "                           volumes.csv    per frame: model volume (ml), error, iterations\n"
            "                         with --epi or --myocardium-label, the heart wall too:\n"
            "                           epi_frame_NN.ply  each frame's epicardial model mesh\n"
            "                           motion.ply     also 'thickness_ed' (the wall thickness at ED)\n"
            "                                          and 'thickening' (ES / ED thickness - 1), NaN\n"
            "                                          where not measured (valve plane; no epicardium\n"
            "                                          along the normal)\n"
            "                           segments.csv   also thickness_ed_mm, thickness_es_mm,\n"
            "                                          thickening_percent, dysfunctional (0 or 1; empty\n"
            "                                          where no vertex was measured)\n"
            "                           thickening.svg the 17-segment bull's-eye of thickening\n"
            "                         (the meshes in the input's units, as its points; the report,\n"
            "                         the CSV files and --json in mm and ml)\n"
            "                         a reused DIR: the frame_NN.ply and epi_frame_NN.ply of an\n"
            "                         earlier run with more frames are removed (no other file)\n"
            "  --epi FILE,FILE,...    the epicardium (the wall's outer border): one file for each\n"
            "                         frame, in the same order, tracked as the frames are (same\n"
            "                         options, stacks closed by lids alike); measured in the\n"
            "                         endocardium's segment frame (its long axis, septum, levels):\n"
            "                         LV mass (%g g/ml x the volume between the surfaces, between\n"
            "                         the epicardium's outer slices for stacks), wall thickness along\n"
            "                         each endocardial vertex's normal (for stacks: in the slices'\n"
            "                         planes, radially from the cavity's centre, between the outer\n"
            "                         slices), thickening per segment; a\n"
            "                         segment thickening less than %g %% is dysfunctional\n"
            "  --myocardium-label N   label maps (with --label, the cavity's): the epicardium is the\n"
            "                         border of labels N and --label together (ACDC: --label 3\n"
            "                         --myocardium-label 2), from the same FRAME volumes\n",
            MYOCARDIUM_DENSITY, 100.0 * sqffd_wall_options_default().dysfunctional_thickening);
    fprintf(f,
            "  --ed N                 the end-diastolic frame (default: the frame of largest model\n"
            "                         volume; the report says when N is not it); end-systole is the\n"
            "                         frame of least model volume\n"
            "  --septum X,Y,Z         direction of the septum, at least %g degrees off the long axis\n"
            "                         (default: a superquadric axis; the points do not tell it,\n"
            "                         give it for a real heart)\n"
            "  --apex X,Y,Z           direction base -> apex (default: the long axis, toward its\n"
            "                         narrower end)\n"
            "  --low-motion F         a vertex is low-motion below F x the median excursion\n"
            "                         of the wall at its level (default %g); a segment is\n"
            "                         hypokinetic when at least %g of its area is\n"
            "  --mm-per-unit F        millimetres per unit of the point files, > 0 (default 1: the\n"
            "                         report says the unit was assumed to be mm); volumes (NIfTI,\n"
            "                         MetaImage, NRRD) are in mm already and take no scale\n"
            "  --json FILE            also write the report as JSON: units, per frame points, lid\n"
            "                         points, volume, error, iterations and stop reason; EDV, ESV,\n"
            "                         EF; per segment area, excursion, share and flag\n"
            "  --frame-iterations K   FFD iterations of the frames after the first (default %d)\n"
            "  --volume auto|closed|slices\n"
            "                         the frames' volumes (EF): 'closed', the closed models'; 'slices',\n"
            "                         the models' between each frame's outer short-axis slices, each\n"
            "                         moved out by half the spacing, where Simpson's method puts its\n"
            "                         discs (point files on 3 or more parallel planes, slice by\n"
            "                         slice); 'auto' (default): slices for such stacks, else closed\n",
            TRACK_SEPTUM_MIN_DEGREES, m.low_motion_fraction, m.hypokinetic_share, d.frame_iterations);
    input_option_details(f);
    model_option_details(f, &d.fit, "frame 0");
    fprintf(f,
            "  --ascii                write ascii PLY instead of binary little endian\n"
            "  --quiet                print nothing on success\n"
            "\n"
            "Every frame must hold what a lone fit needs (%d points or more, finite, not all on\n"
            "a plane or a line). A frame the model could not follow fails the track (exit 1, no\n"
            "EF): one whose relative RMS error is above both %g x the median of the other\n"
            "frames' and %g %% of its data's bounding-box diagonal.\n",
            SQFFD_SQ_FIT_MIN_POINTS, TRACK_ERROR_RATIO, 100.0 * TRACK_ERROR_FLOOR);
}

/* The files track writes into a->output (frame_NN.ply a frame, motion.ply
   and the two tables; with the wall, epi_frame_NN.ply a frame and
   thickening.svg) added to a->out, before the tracking; 0, or 1 after a
   message. */
static int track_outputs(track_args *a)
{
    char name[64];
    size_t t;
    for (t = 0; t < a->frame_count; t++) {
        snprintf(name, sizeof name, "frame_%02lu.ply", (unsigned long)t);
        if (output_add_in(&a->out, a->output, name)) return 1;
        snprintf(name, sizeof name, "epi_frame_%02lu.ply", (unsigned long)t);
        if (a->wall && output_add_in(&a->out, a->output, name)) return 1;
    }
    return output_add_in(&a->out, a->output, "motion.ply") || output_add_in(&a->out, a->output, "segments.csv") ||
           output_add_in(&a->out, a->output, "volumes.csv") ||
           (a->wall && output_add_in(&a->out, a->output, "thickening.svg"));
}

/* What track_run leaves for the reports and the extra outputs. */
typedef struct track_result {
    sqffd_model *models;
    sqffd_fit_report *reports;
    sqffd_motion_outputs out;
    sqffd_motion_report motion;
    sqffd_model *epi_models;       /* the wall (a->wall) */
    sqffd_fit_report *epi_reports;
    sqffd_wall_outputs wall_out;
    sqffd_wall_report wall;
    size_t vertices;      /* per frame's mesh */
    size_t largest;       /* the frame of largest volume */
    double seconds;
} track_result;

/* Why a frame's iterations ended (the report's stop), as the report and the JSON name it. */
static const char *stop_reason(const sqffd_fit_report *r)
{
    return r->stop == SQFFD_FIT_CONVERGED ? "converged" : r->stop == SQFFD_FIT_STALLED ? "no progress" : "capped";
}

/* A volume in the model's units as ml, a length as mm, an area as mm^2. */
static double to_ml(const track_args *a, double v) { return v * (a->mm_per_unit * a->mm_per_unit * a->mm_per_unit) / 1000.0; }
static double to_mm(const track_args *a, double d) { return d * a->mm_per_unit; }
static double to_mm2(const track_args *a, double s) { return s * (a->mm_per_unit * a->mm_per_unit); }

/* A share in percent to one decimal, cut (never rounded up to a threshold
   it is below: 0.4996 shows 49.9, so the hypokinetic flag can be checked
   by eye). */
static double share_shown(double share) { return floor(1000.0 * share) / 10.0; }

static size_t lid_points(const track_args *a, size_t t) { return a->lids ? a->lids[t] : 0; }
static size_t epi_lid_points(const track_args *a, size_t t) { return a->epi_lids ? a->epi_lids[t] : 0; }

/* Whether segment k's wall was measured (the library leaves its means 0 where no vertex was). */
static int wall_measured(const sqffd_wall_report *w, int k) { return w->segments[k].thickness_ed > 0.0; }

/* A myocardial volume in the model's units as a mass in g. */
static double to_g(const track_args *a, double v) { return MYOCARDIUM_DENSITY * to_ml(a, v); }

/* The wall's part of the report (track_report). */
static void track_report_wall(const track_args *a, const track_result *res)
{
    const sqffd_wall_report *w = &res->wall;
    size_t t;
    int k;
    printf("  epicardium frame  points  lid points   error %%  error mm  iterations  myocardium ml\n");
    for (t = 0; t < a->frame_count; t++) {
        const sqffd_fit_report *r = res->epi_reports + t;
        printf("  %16lu  %6lu  %10lu  %8.4f  %8.4g  %10d  %13.6g%s\n", (unsigned long)t,
               (unsigned long)(a->epi_counts[t] - epi_lid_points(a, t)), (unsigned long)epi_lid_points(a, t),
               100.0 * r->error.rms_relative, to_mm(a, r->error.rms), r->coarse_iterations + r->iterations,
               to_ml(a, res->wall_out.myocardium[t]),
               t == res->motion.ed_frame ? "  ED" : t == res->motion.es_frame ? "  ES" : "");
    }
    printf("  myocardium       the volume between the epicardium and the endocardium%s\n",
           a->wall_options.stacks ? ", both between each frame's outer epicardial slices +- half the spacing" : "");
    printf("  LV mass          ED %.4g g, ES %.4g g (%g g/ml x the myocardium)\n", to_g(a, w->myocardium_ed),
           to_g(a, w->myocardium_es), MYOCARDIUM_DENSITY);
    if (a->wall_options.stacks)
        printf("                   one myocardium weighed twice: the LV mass is the ED figure; at ES the heart has\n"
               "                   shortened into the slab between the outer slices, which then holds more wall\n"
               "                   (Simpson's method shows the same), so ES reads higher by that, not by growth\n");
    else
        printf("                   one myocardium weighed twice: the LV mass is the ED figure; the closed surfaces\n"
               "                   hold the whole wall in both frames, so ED and ES differ by the models' error\n");
    printf("  wall thickness   ED %.4g mm, ES %.4g mm: global thickening %.1f %% (%s to the epicardium;\n"
           "                   %lu wall vertices measured, %lu not)\n",
           to_mm(a, w->thickness_ed), to_mm(a, w->thickness_es), 100.0 * w->thickening,
           a->wall_options.endo_stacks ? "in the slices' planes, radially from the cavity's centre,\n"
                                         "                   between the outer slices,"
                                       : "along each endocardial vertex's normal",
           (unsigned long)w->measured, (unsigned long)w->unmeasured);
    printf("  segment                  thickness ED mm  ES mm  thickening %%  dysfunctional (thickening < %g %%)\n",
           100.0 * a->wall_options.dysfunctional_thickening);
    for (k = 0; k < SQFFD_SEGMENTS; k++) {
        const sqffd_segment_wall *g = w->segments + k;
        if (wall_measured(w, k))
            printf("  %2d %-22s %15.4g  %5.4g  %12.1f  %s\n", k + 1, segment_names[k], to_mm(a, g->thickness_ed),
                   to_mm(a, g->thickness_es), 100.0 * g->thickening, g->dysfunctional ? "yes" : "no");
        else
            printf("  %2d %-22s %15s  %5s  %12s  -  (no vertex measured)\n", k + 1, segment_names[k], "-", "-", "-");
    }
}

static void track_report(const track_args *a, const size_t *counts, const track_result *res)
{
    const sqffd_fit_report *reports = res->reports;
    const sqffd_motion_report *m = &res->motion;
    const double *volumes = res->out.volumes, *s = a->motion.septum_direction;
    size_t t;
    int k;
    char iterations[32];
    printf("sqffd track: %lu frames -> %s\n", (unsigned long)a->frame_count, a->output);
    if (a->unit == UNIT_ASSUMED)
        printf("  units            the point files' unit assumed to be mm (give --mm-per-unit F for another)\n");
    else if (a->unit == UNIT_GIVEN)
        printf("  units            %.6g mm per unit of the point files (--mm-per-unit)\n", a->mm_per_unit);
    else
        printf("  units            mm (the volume files')\n");
    if (a->dropped_nan)
        printf("  dropped          %lu points with NaN coordinates (invalid depth) in %lu frame%s\n",
               (unsigned long)a->dropped_nan, (unsigned long)a->dropped_frames, a->dropped_frames == 1 ? "" : "s");
    printf("  frame    points  lid points   error %%  error mm  iterations  jacobian   volume ml\n");
    for (t = 0; t < a->frame_count; t++) {
        snprintf(iterations, sizeof iterations, "%d%s", reports[t].coarse_iterations + reports[t].iterations,
                 reports[t].stop == SQFFD_FIT_CAPPED ? " (cap)" : "");
        printf("  %5lu  %8lu  %10lu  %8.4f  %8.4g  %10s  %8.3f  %10.6g%s\n", (unsigned long)t,
               (unsigned long)(counts[t] - lid_points(a, t)), (unsigned long)lid_points(a, t),
               100.0 * reports[t].error.rms_relative, to_mm(a, reports[t].error.rms), iterations,
               reports[t].min_jacobian, to_ml(a, volumes[t]),
               t == m->ed_frame ? "  ED" : t == m->es_frame ? "  ES" : "");
    }
    printf("  error            RMS distance from the frame's points to its model (%% of their bounding-box "
           "diagonal, and mm)\n");
    if (a->motion.stacks)
        printf("  volumes          between each frame's outer short-axis slices +- half the spacing (%.4g mm)\n",
               to_mm(a, a->motion.stacks[m->ed_frame].spacing));
    if (a->in.slice_shifts) print_slice_shifts(&a->shifts);
    if (a->lids)
        printf("  lid points       made up to close each frame's stack half a spacing beyond its outer slices "
               "(--no-lids: none)\n");
    printf("  end-diastolic volume   %.6g ml (frame %lu, %s)\n", to_ml(a, m->edv), (unsigned long)m->ed_frame,
           a->ed_given ? "--ed" : "the largest volume");
    if (m->ed_frame != res->largest)
        printf("  note             --ed %lu is not the frame of largest volume: frame %lu holds %.6g ml\n",
               (unsigned long)m->ed_frame, (unsigned long)res->largest, to_ml(a, volumes[res->largest]));
    printf("  end-systolic volume    %.6g ml (frame %lu, the smallest volume)\n", to_ml(a, m->esv),
           (unsigned long)m->es_frame);
    printf("  ejection fraction  %.1f %%\n", 100.0 * m->ejection_fraction);
    printf("  long axis (base -> apex) %.4g %.4g %.4g, length %.4g mm (%s)\n", m->axis[0], m->axis[1], m->axis[2],
           to_mm(a, m->length), a->motion.apex_direction[0] != 0.0 || a->motion.apex_direction[1] != 0.0 ||
           a->motion.apex_direction[2] != 0.0 ? "--apex" : "the model's longest axis, toward its narrower end");
    if (s[0] != 0.0 || s[1] != 0.0 || s[2] != 0.0)
        printf("  septum           %.4g %.4g %.4g (--septum, its part across the long axis)\n", m->septum[0],
               m->septum[1], m->septum[2]);
    else
        printf("  septum           not given (--septum X,Y,Z): the ED superquadric's first axis across the long axis\n"
               "                   (%.4g %.4g %.4g) stands in for it, so the segment names below are sectors counted\n"
               "                   from that axis, not anatomy\n", m->septum[0], m->septum[1], m->septum[2]);
    printf("  median wall excursion ED -> ES  %.4g mm (%s along the normal)\n", to_mm(a, m->median_excursion),
           m->median_excursion >= 0.0 ? "inward" : "negative: outward");
    printf("  segment                  area mm^2  displacement mm  excursion mm  low-motion area  hypokinetic (area >= %g %%)\n",
           100.0 * a->motion.hypokinetic_share);
    for (k = 0; k < SQFFD_SEGMENTS; k++)
        printf("  %2d %-22s %9.4g  %15.4g  %12.4g  %13.1f %%  %s\n", k + 1, segment_names[k],
               to_mm2(a, m->segments[k].area), to_mm(a, m->segments[k].mean_displacement),
               to_mm(a, m->segments[k].mean_excursion), share_shown(m->segments[k].low_motion_share),
               m->segments[k].hypokinetic ? "yes" : "no");
    printf("  low-motion area  the share of the segment's ED area moving inward less than %g x the median\n"
           "                   excursion of the wall at its level (cut to 0.1 %%, never rounded up)\n",
           a->motion.low_motion_fraction);
    if (a->wall) track_report_wall(a, res);
    if (a->json_output) printf("  summary          %s (JSON)\n", a->json_output);
    printf("  time             %.1f ms\n", 1e3 * res->seconds);
}

/* Writes the frames' meshes (trajectories: frame t's nv vertices at
   [3 nv t]) as PREFIX_NN.ply into a->output; 0, or 1 after a message. */
static int write_frame_meshes(track_args *a, const char *prefix, const double *trajectories, const uint32_t *triangles,
                              size_t nv, size_t nt)
{
    char path[4096], name[64], err[512];
    size_t t;
    FILE *f;
    for (t = 0; t < a->frame_count; t++) {
        snprintf(name, sizeof name, "%s_%02lu.ply", prefix, (unsigned long)t);
        join_path(path, a->output, name); /* (track_outputs checked its length) */
        if (!(f = output_open(&a->out, path, err, sizeof err)) ||
            sqffd_io_write_ply_stream(f, path, trajectories + 3 * nv * t, nv, triangles, nt, NULL, 0, a->ascii, err,
                                      sizeof err)) {
            fprintf(stderr, "%s\n", err);
            return 1;
        }
    }
    return 0;
}

/* The outputs of track into a->out (track_outputs): the frames' meshes,
   motion.ply, the two tables; with the wall, the epicardium's meshes, its
   columns and scalars, the thickening bull's-eye. */
static int track_write(track_args *a, const track_result *res)
{
    const sqffd_motion_outputs *out = &res->out;
    const sqffd_motion_report *m = &res->motion;
    const sqffd_wall_report *w = &res->wall;
    char path[4096], err[512], subtitle[160];
    size_t nv = res->vertices, nt = 2 * (nv - 2), t, v;
    uint32_t *triangles = NULL;
    double *flags = NULL, *segments = NULL, *x = NULL;
    sqffd_io_scalar scalars[6];
    sqffd_export_segments eye;
    FILE *f;
    int k, status = EXIT_BAD_INPUT;
    triangles = (uint32_t *)malloc(3 * nt * sizeof *triangles);
    flags = (double *)malloc(nv * sizeof *flags);
    segments = (double *)malloc(nv * sizeof *segments);
    x = a->wall ? (double *)malloc(3 * nv * a->frame_count * sizeof *x) : NULL;
    if ((a->wall && !x) || !triangles || !flags || !segments) {
        fprintf(stderr, "%s: out of memory\n", a->output);
        goto done;
    }
    /* (both sequences on the track options' grid: one mesh connectivity) */
    sqffd_model_mesh(res->models, res->models->grid[0], res->models->grid[1], NULL, triangles);
    for (t = 0; a->wall && t < a->frame_count; t++)
        sqffd_model_mesh(res->epi_models + t, res->models->grid[0], res->models->grid[1], x + 3 * nv * t, NULL);
    if (write_frame_meshes(a, "frame", out->trajectories, triangles, nv, nt) ||
        (a->wall && write_frame_meshes(a, "epi_frame", x, triangles, nv, nt)))
        goto done;
    for (v = 0; v < nv; v++) {
        flags[v] = out->low_motion[v];
        segments[v] = out->segment[v];
    }
    scalars[0].name = "displacement"; scalars[0].values = out->displacement;
    scalars[1].name = "excursion"; scalars[1].values = out->excursion;
    scalars[2].name = "low_motion"; scalars[2].values = flags;
    scalars[3].name = "segment"; scalars[3].values = segments;
    scalars[4].name = "thickness_ed"; scalars[4].values = res->wall_out.thickness_ed;
    scalars[5].name = "thickening"; scalars[5].values = res->wall_out.thickening;
    join_path(path, a->output, "motion.ply");
    if (!(f = output_open(&a->out, path, err, sizeof err)) ||
        sqffd_io_write_ply_stream(f, path, out->trajectories + 3 * nv * m->ed_frame, nv, triangles, nt, scalars,
                                  a->wall ? 6 : 4, a->ascii, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        goto done;
    }
    join_path(path, a->output, "segments.csv");
    if (!(f = output_open(&a->out, path, err, sizeof err))) {
        fprintf(stderr, "%s\n", err);
        goto done;
    }
    fprintf(f, "segment,name,area_mm2,mean_displacement_mm,mean_excursion_mm,low_motion_share,hypokinetic%s\n",
            a->wall ? ",thickness_ed_mm,thickness_es_mm,thickening_percent,dysfunctional" : "");
    for (k = 0; k < SQFFD_SEGMENTS; k++) {
        const sqffd_segment_wall *g = w->segments + k;
        fprintf(f, "%d,%s,%.9g,%.9g,%.9g,%.9g,%d", k + 1, segment_names[k], to_mm2(a, m->segments[k].area),
                to_mm(a, m->segments[k].mean_displacement), to_mm(a, m->segments[k].mean_excursion),
                m->segments[k].low_motion_share, m->segments[k].hypokinetic);
        if (a->wall && wall_measured(w, k))
            fprintf(f, ",%.9g,%.9g,%.9g,%d", to_mm(a, g->thickness_ed), to_mm(a, g->thickness_es), 100.0 * g->thickening,
                    g->dysfunctional);
        fputs(a->wall && !wall_measured(w, k) ? ",,,,\n" : "\n", f);
    }
    join_path(path, a->output, "volumes.csv");
    if (!(f = output_open(&a->out, path, err, sizeof err))) {
        fprintf(stderr, "%s\n", err);
        goto done;
    }
    fprintf(f, "frame,file,volume_ml,error_relative,iterations,error_mm,stop\n");
    for (t = 0; t < a->frame_count; t++)
        fprintf(f, "%lu,%s,%.9g,%.9g,%d,%.9g,%s\n", (unsigned long)t, a->frames[t], to_ml(a, out->volumes[t]),
                res->reports[t].error.rms_relative, res->reports[t].coarse_iterations + res->reports[t].iterations,
                to_mm(a, res->reports[t].error.rms), stop_reason(res->reports + t));
    if (a->wall) { /* the thickening bull's-eye: unmeasured segments show 0, unflagged */
        for (k = 0; k < SQFFD_SEGMENTS; k++) {
            eye.value[k] = wall_measured(w, k) ? 100.0 * w->segments[k].thickening : 0.0;
            eye.flag[k] = wall_measured(w, k) && w->segments[k].dysfunctional;
        }
        eye.measure = "thickening";
        eye.flag_name = "dysfunctional";
        snprintf(subtitle, sizeof subtitle, "global thickening %.1f%%   mass ED %.4g g, ES %.4g g   (dysfunctional: "
                 "thickening < %g%%)", 100.0 * w->thickening, MYOCARDIUM_DENSITY * to_ml(a, w->myocardium_ed),
                 MYOCARDIUM_DENSITY * to_ml(a, w->myocardium_es), 100.0 * a->wall_options.dysfunctional_thickening);
        eye.subtitle = subtitle;
        join_path(path, a->output, "thickening.svg");
        if (!(f = output_open(&a->out, path, err, sizeof err)) ||
            sqffd_export_svg_segments_stream(f, path, &eye, "Wall thickening per segment, ED to ES", "%", err,
                                             sizeof err)) {
            fprintf(stderr, "%s\n", err);
            goto done;
        }
    }
    status = 0; /* (write errors show in output_commit) */
done:
    free(triangles);
    free(flags);
    free(segments);
    free(x);
    return status;
}

static void track_result_free(track_result *r)
{
    free(r->models);
    free(r->reports);
    free(r->epi_models);
    free(r->epi_reports);
    free(r->wall_out.myocardium);
    free(r->wall_out.thickness_ed);
    free(r->wall_out.thickness_es);
    free(r->wall_out.thickening);
    free(r->out.volumes);
    free(r->out.trajectories);
    free(r->out.displacement);
    free(r->out.excursion);
    free(r->out.low_motion);
    free(r->out.segment);
    memset(r, 0, sizeof *r);
}

/* The epicardial frames prepared as the endocardial ones (track_stacks):
   --slice-shifts moves their slices by the endocardium's shifts (one
   breath-hold a slice holds both contours; a slice of the epicardium
   alone, beyond the cavity's, stays), then their lids; the myocardium is
   measured between the epicardium's slices when the cavity's volumes are
   its slices'. 0, or an exit status after a message. */
static int track_epi_stacks(track_args *a)
{
    input_args in = a->in;
    char err[512];
    size_t t;
    int found = 0;
    a->epi_stacks = (sqffd_stack *)calloc(a->frame_count, sizeof *a->epi_stacks);
    a->epi_lids = (size_t *)calloc(a->frame_count, sizeof *a->epi_lids);
    if (!a->epi_stacks || !a->epi_lids) {
        fprintf(stderr, "sqffd track: out of memory\n");
        return EXIT_BAD_INPUT;
    }
    for (t = 0; t < a->frame_count && in.slice_shifts; t++)
        if (sqffd_stack_shifts_apply(&a->shifts, a->epi_points[t], a->epi_counts[t], NULL) != SQFFD_OK) {
            fprintf(stderr, "%s: --slice-shifts: a shifted point is not finite\n", a->epi_frames[t]);
            return EXIT_BAD_INPUT;
        }
    in.slice_shifts = 0;
    in.no_lids |= !a->lids; /* lids only where the cavity got them */
    if (prepare_stacks(&in, a->epi_frames, a->epi_points, a->epi_counts, a->frame_count, a->epi_stacks, &found, NULL,
                       a->epi_lids, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        return EXIT_BAD_INPUT;
    }
    if (found && a->motion.stacks) {
        a->wall_options.stacks = a->epi_stacks;
        return 0;
    }
    if (a->motion.stacks) {
        fprintf(stderr, "sqffd track: the cavity's volumes are its slices' (short-axis stacks), but the epicardial "
                        "frames are no stacks with the same planes' normal: give --volume closed for closed volumes\n");
        return EXIT_BAD_INPUT;
    }
    if (!found) {
        free(a->epi_lids);
        a->epi_lids = NULL;
    }
    free(a->epi_stacks);
    a->epi_stacks = NULL;
    return 0;
}

/* The frames as short-axis stacks, before the tracking (prepare_stacks):
   a->stacks when every frame is one, the volumes between their slices
   unless --volume closed; 0, or an exit status after a message (also
   --volume slices on frames that are no stacks). */
static int track_stacks(track_args *a, double **points, size_t *counts)
{
    char err[512];
    int found = 0;
    a->stacks = (sqffd_stack *)calloc(a->frame_count, sizeof *a->stacks);
    a->lids = (size_t *)calloc(a->frame_count, sizeof *a->lids);
    if (!a->stacks || !a->lids) {
        fprintf(stderr, "sqffd track: out of memory\n");
        return EXIT_BAD_INPUT;
    }
    if (prepare_stacks(&a->in, a->frames, points, counts, a->frame_count, a->stacks, &found, &a->shifts, a->lids, err,
                       sizeof err)) {
        fprintf(stderr, "%s\n", err);
        return EXIT_BAD_INPUT;
    }
    if (found) {
        if (a->volume != VOLUME_CLOSED) a->motion.stacks = a->stacks;
        a->wall_options.endo_stacks = a->stacks; /* the thickness as the slices show it */
        return a->wall ? track_epi_stacks(a) : 0;
    }
    free(a->stacks);
    a->stacks = NULL;
    free(a->lids);
    a->lids = NULL;
    if (a->volume != VOLUME_SLICES) return a->wall ? track_epi_stacks(a) : 0;
    fprintf(stderr, "sqffd track: --volume slices: the frames are not short-axis stacks (points on 3 or more "
                    "parallel planes, slice by slice) with the same planes' normal\n");
    return EXIT_BAD_INPUT;
}

static int compare_doubles(const void *x, const void *y)
{
    double u = *(const double *)x, v = *(const double *)y;
    return u < v ? -1 : u > v;
}

/* The frames the model could not follow (TRACK_ERROR_RATIO, _FLOOR): 0
   when none, else 1 after a message naming each (names: their inputs). */
static int unfollowed_frames(const track_args *a, const char *const *names, const sqffd_fit_report *reports)
{
    size_t t, u, n, frames = a->frame_count, failed = 0;
    double *others = (double *)malloc(frames * sizeof *others), median;
    if (!others) {
        fprintf(stderr, "sqffd track: out of memory\n");
        return 1;
    }
    for (t = 0; t < frames; t++) {
        for (u = n = 0; u < frames; u++)
            if (u != t) others[n++] = reports[u].error.rms_relative;
        qsort(others, n, sizeof *others, compare_doubles);
        median = n % 2 ? others[n / 2] : 0.5 * (others[n / 2 - 1] + others[n / 2]);
        if (!(reports[t].error.rms_relative <= TRACK_ERROR_RATIO * median ||
              reports[t].error.rms_relative <= TRACK_ERROR_FLOOR)) {
            fprintf(stderr, "%s (frame %lu): the model did not follow this frame: relative RMS error %.4g %% against "
                    "a median of %.4g %% over the other frames (a frame fails above both %g x that median and %g %%): "
                    "no volume or EF from this sequence\n", names[t], (unsigned long)t,
                    100.0 * reports[t].error.rms_relative, 100.0 * median, TRACK_ERROR_RATIO, 100.0 * TRACK_ERROR_FLOOR);
            failed++;
        }
    }
    free(others);
    return failed > 0;
}

/* Tracks one sequence (names: each frame's input) into models and reports,
   and checks that the model followed every frame; 0, or 1 after a message. */
static int track_sequence(track_args *a, const char *const *names, double **points, size_t *counts,
                          sqffd_model *models, sqffd_fit_report *reports, double start)
{
    track_progress progress;
    size_t work_size, done = 0;
    void *work;
    sqffd_result r = sqffd_track_workspace_size(counts, a->frame_count, &a->options, &work_size);
    if (r != SQFFD_OK) {
        fprintf(stderr, "sqffd track: cannot size the tracking: %s\n", sqffd_result_string(r));
        return 1;
    }
    if (!(work = malloc(work_size))) {
        fprintf(stderr, "sqffd track: out of memory (the tracking needs %lu bytes)\n", (unsigned long)work_size);
        return 1;
    }
    progress.start = start;
    progress.frames = a->frame_count;
    progress.terminal = isatty(fileno(stderr));
    progress.shown = 0;
    a->options.progress = a->quiet ? NULL : track_progress_report;
    a->options.progress_user = &progress;
    r = sqffd_track((const double *const *)points, counts, a->frame_count, &a->options, models, reports, &done, work,
                    work_size);
    free(work);
    if (progress.shown) fputc('\n', stderr);
    if (r != SQFFD_OK) {
        fprintf(stderr, "%s: tracking failed at frame %lu: %s\n", names[done], (unsigned long)done,
                sqffd_result_string(r));
        return 1;
    }
    return unfollowed_frames(a, names, reports);
}

/* The heart wall (sqffd_wall) in the endocardium's segment frame: its
   motion report and segments; NaN written as the one quiet NaN (an ascii
   PLY's "nan", never "-nan"). 0, or 1 after a message. */
static int track_wall(track_args *a, track_result *res)
{
    size_t size = 0, v, m = res->vertices;
    void *work = NULL;
    sqffd_wall_outputs *o = &res->wall_out;
    sqffd_result r = sqffd_wall_workspace_size(res->models, res->epi_models, a->frame_count, &size);
    o->myocardium = (double *)malloc(a->frame_count * sizeof(double));
    o->thickness_ed = (double *)malloc(m * sizeof(double));
    o->thickness_es = (double *)malloc(m * sizeof(double));
    o->thickening = (double *)malloc(m * sizeof(double));
    if (r == SQFFD_OK && (!(work = malloc(size)) || !o->myocardium || !o->thickness_ed || !o->thickness_es ||
                          !o->thickening)) {
        fprintf(stderr, "sqffd track: out of memory\n");
        free(work);
        return 1;
    }
    if (r == SQFFD_OK)
        r = sqffd_wall(res->models, res->epi_models, a->frame_count, &res->motion, res->out.segment, &a->wall_options, o,
                       &res->wall, work, size);
    free(work);
    if (r != SQFFD_OK) {
        fprintf(stderr, "sqffd track: the wall analysis failed: %s%s\n", sqffd_result_string(r),
                r == SQFFD_ERROR_DEGENERATE ? " (no endocardial normal crosses the epicardium: is --epi the wall's "
                                              "outer border, of the same frames?)" : "");
        return 1;
    }
    for (v = 0; v < m; v++) {
        if (isnan(o->thickness_ed[v])) o->thickness_ed[v] = NAN;
        if (isnan(o->thickening[v])) o->thickening[v] = NAN;
    }
    return 0;
}

/* Tracks the frames (and the epicardium's), measures the motion (and the
   wall) and writes the outputs into a->output; 0, or an exit status after
   a message. */
static int track_run(track_args *a, double **points, size_t *counts, track_result *res)
{
    size_t work_size, nv = 0, frames = a->frame_count, t;
    void *work = NULL;
    sqffd_result r;
    int status = EXIT_BAD_INPUT;
    double start;
    memset(res, 0, sizeof *res);
    res->models = (sqffd_model *)malloc(frames * sizeof *res->models);
    res->reports = (sqffd_fit_report *)malloc(frames * sizeof *res->reports);
    res->out.volumes = (double *)malloc(frames * sizeof(double));
    if (a->wall) {
        res->epi_models = (sqffd_model *)malloc(frames * sizeof *res->epi_models);
        res->epi_reports = (sqffd_fit_report *)malloc(frames * sizeof *res->epi_reports);
    }
    if (!res->models || !res->reports || !res->out.volumes || (a->wall && (!res->epi_models || !res->epi_reports))) {
        fprintf(stderr, "sqffd track: out of memory\n");
        goto done;
    }
    start = seconds_now();
    if (track_sequence(a, a->frames, points, counts, res->models, res->reports, start) ||
        (a->wall && track_sequence(a, a->epi_frames, a->epi_points, a->epi_counts, res->epi_models, res->epi_reports,
                                   start)))
        goto done;
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
    for (t = 1; r == SQFFD_OK && t < frames; t++)
        if (res->out.volumes[t] > res->out.volumes[res->largest]) res->largest = t;
    if (r == SQFFD_OK && !a->ed_given && res->largest != a->motion.ed_frame) { /* ED: the largest volume */
        a->motion.ed_frame = res->largest;
        r = sqffd_motion(res->models, frames, &a->motion, &res->out, &res->motion, work, work_size);
    }
    if (r == SQFFD_ERROR_INVALID_ARGUMENT) { /* a septum exactly along the long axis found: that axis, to say so */
        sqffd_motion_options o = a->motion;
        memset(o.septum_direction, 0, sizeof o.septum_direction);
        if (sqffd_motion(res->models, frames, &o, NULL, &res->motion, work, work_size) == SQFFD_OK &&
            (status = septum_check(a, res->motion.axis, "the long axis found")) != 0)
            goto done;
    }
    if (r != SQFFD_OK) {
        fprintf(stderr, "sqffd track: the motion analysis failed: %s\n", sqffd_result_string(r));
        goto done;
    }
    /* the long axis found: a septum along it would name no sectors (a given --apex was checked before) */
    if ((status = septum_check(a, res->motion.axis, "the long axis found")) != 0) goto done;
    status = EXIT_BAD_INPUT;
    if (a->wall && track_wall(a, res)) goto done;
    status = track_write(a, res);
    res->seconds = seconds_now() - start;
done:
    free(work);
    return status;
}

/* Writes key (the text before the value: ", \"name\": ") and the number v (null if not finite). */
static void json_number_field(FILE *f, const char *key, double v)
{
    fputs(key, f);
    sqffd_export_json_number(f, v);
}

/* The report as JSON ("format": "sqffd-track", "version": 1): what
   track_report prints, in mm and ml; numbers as %.17g, null where not
   finite. 0, or 1 with a message in err. */
static int track_json(track_args *a, const size_t *counts, const track_result *res, char *err, size_t err_size)
{
    const sqffd_motion_report *m = &res->motion;
    const double *sd = a->motion.septum_direction;
    FILE *f;
    size_t t;
    int k;
    if (!(f = output_open(&a->out, a->json_output, err, err_size))) return 1;
    fprintf(f, "{\n  \"format\": \"sqffd-track\",\n  \"version\": 1,\n  \"library_version\": \"%s\",\n  \"inputs\": [",
            SQFFD_VERSION_STRING);
    for (t = 0; t < a->input_count; t++) {
        fputs(t ? ", " : "", f);
        sqffd_export_json_string(f, a->inputs[t]);
    }
    fputs("],\n  \"units\": {\"mm_per_unit\": ", f);
    sqffd_export_json_number(f, a->mm_per_unit);
    fprintf(f, ", \"mm_per_unit_source\": \"%s\", \"volume\": \"ml\", \"length\": \"mm\", \"area\": \"mm2\"},\n"
               "  \"frames\": [\n", unit_sources[a->unit]);
    for (t = 0; t < a->frame_count; t++) {
        const sqffd_fit_report *r = res->reports + t;
        fputs("    {\"file\": ", f);
        sqffd_export_json_string(f, a->frames[t]);
        fprintf(f, ", \"points\": %lu, \"lid_points\": %lu, \"volume_ml\": ", (unsigned long)(counts[t] - lid_points(a, t)),
                (unsigned long)lid_points(a, t));
        sqffd_export_json_number(f, to_ml(a, res->out.volumes[t]));
        fputs(", \"error_relative\": ", f);
        sqffd_export_json_number(f, r->error.rms_relative);
        fputs(", \"error_mm\": ", f);
        sqffd_export_json_number(f, to_mm(a, r->error.rms));
        fprintf(f, ", \"iterations\": %d, \"stop\": \"%s\"", r->coarse_iterations + r->iterations, stop_reason(r));
        if (a->wall) {
            const sqffd_fit_report *e = res->epi_reports + t;
            fputs(", \"epi_file\": ", f);
            sqffd_export_json_string(f, a->epi_frames[t]);
            fprintf(f, ", \"epi_points\": %lu, \"epi_lid_points\": %lu", (unsigned long)(a->epi_counts[t] - epi_lid_points(a, t)),
                    (unsigned long)epi_lid_points(a, t));
            json_number_field(f, ", \"epi_error_relative\": ", e->error.rms_relative);
            json_number_field(f, ", \"epi_error_mm\": ", to_mm(a, e->error.rms));
            json_number_field(f, ", \"myocardium_ml\": ", to_ml(a, res->wall_out.myocardium[t]));
        }
        fprintf(f, "}%s\n", t + 1 < a->frame_count ? "," : "");
    }
    fputs("  ],\n  \"edv_ml\": ", f);
    sqffd_export_json_number(f, to_ml(a, m->edv));
    fputs(",\n  \"esv_ml\": ", f);
    sqffd_export_json_number(f, to_ml(a, m->esv));
    fputs(",\n  \"ef_percent\": ", f);
    sqffd_export_json_number(f, 100.0 * m->ejection_fraction);
    fprintf(f, ",\n  \"ed_index\": %lu,\n  \"ed_given\": %s,\n  \"largest_volume_index\": %lu,\n  \"es_index\": %lu,\n"
               "  \"septum_given\": %s,\n  \"septum\": ", (unsigned long)m->ed_frame, a->ed_given ? "true" : "false",
            (unsigned long)res->largest, (unsigned long)m->es_frame,
            sd[0] != 0.0 || sd[1] != 0.0 || sd[2] != 0.0 ? "true" : "false");
    for (k = 0; k < 3; k++) {
        fputs(k ? ", " : "[", f);
        sqffd_export_json_number(f, m->septum[k]);
    }
    fputs("],\n  \"long_axis\": ", f);
    for (k = 0; k < 3; k++) {
        fputs(k ? ", " : "[", f);
        sqffd_export_json_number(f, m->axis[k]);
    }
    fputs("],\n  \"median_excursion_mm\": ", f);
    sqffd_export_json_number(f, to_mm(a, m->median_excursion));
    if (a->wall) {
        const sqffd_wall_report *w = &res->wall;
        json_number_field(f, ",\n  \"mass_ed_g\": ", to_g(a, w->myocardium_ed));
        json_number_field(f, ",\n  \"mass_es_g\": ", to_g(a, w->myocardium_es));
        json_number_field(f, ",\n  \"thickness_ed_mm\": ", to_mm(a, w->thickness_ed));
        json_number_field(f, ",\n  \"thickness_es_mm\": ", to_mm(a, w->thickness_es));
        json_number_field(f, ",\n  \"thickening_percent\": ", 100.0 * w->thickening);
        fprintf(f, ",\n  \"wall_vertices_measured\": %lu,\n  \"wall_vertices_unmeasured\": %lu,\n"
                   "  \"dysfunctional_thickening_percent\": %.17g", (unsigned long)w->measured,
                (unsigned long)w->unmeasured, 100.0 * a->wall_options.dysfunctional_thickening);
    }
    fprintf(f, ",\n  \"hypokinetic_share\": %.17g,\n  \"segments\": [\n", a->motion.hypokinetic_share);
    for (k = 0; k < SQFFD_SEGMENTS; k++) {
        const sqffd_segment_motion *g = m->segments + k;
        fprintf(f, "    {\"index\": %d, \"name\": \"%s\", \"area_mm2\": ", k + 1, segment_names[k]);
        sqffd_export_json_number(f, to_mm2(a, g->area));
        fputs(", \"displacement_mm\": ", f);
        sqffd_export_json_number(f, to_mm(a, g->mean_displacement));
        fputs(", \"excursion_mm\": ", f);
        sqffd_export_json_number(f, to_mm(a, g->mean_excursion));
        fputs(", \"share\": ", f);
        sqffd_export_json_number(f, g->low_motion_share);
        fprintf(f, ", \"hypokinetic\": %s", g->hypokinetic ? "true" : "false");
        if (a->wall) { /* null where no vertex was measured */
            const sqffd_segment_wall *s = res->wall.segments + k;
            int measured = wall_measured(&res->wall, k);
            json_number_field(f, ", \"thickness_ed_mm\": ", measured ? to_mm(a, s->thickness_ed) : NAN);
            json_number_field(f, ", \"thickness_es_mm\": ", measured ? to_mm(a, s->thickness_es) : NAN);
            json_number_field(f, ", \"thickening_percent\": ", measured ? 100.0 * s->thickening : NAN);
            fprintf(f, ", \"dysfunctional\": %s", measured ? s->dysfunctional ? "true" : "false" : "null");
        }
        fprintf(f, "}%s\n", k + 1 < SQFFD_SEGMENTS ? "," : "");
    }
    fputs("  ]\n}\n", f);
    return sqffd_export__flush(f, a->json_output, err, err_size);
}

/* Every frame holds what a lone fit needs (sqffd_fit_check_data); 0, or 1
   after a message naming the first frame that does not (names: the
   frames' inputs, what: "frame" or "epicardial frame"). */
static int check_frames(const track_args *a, const char *const *names, const char *what, double *const *points,
                        const size_t *counts)
{
    size_t t;
    for (t = 0; t < a->frame_count; t++) {
        sqffd_result r = sqffd_fit_check_data(points[t], counts[t]);
        if (r == SQFFD_OK) continue;
        if (r == SQFFD_ERROR_TOO_FEW_POINTS)
            fprintf(stderr, "%s (%s %lu): %lu points: a frame needs at least %d, as a lone fit does\n", names[t], what,
                    (unsigned long)t, (unsigned long)counts[t], SQFFD_SQ_FIT_MIN_POINTS);
        else if (r == SQFFD_ERROR_DEGENERATE)
            fprintf(stderr, "%s (%s %lu): the points are all in one place, on a line or on a plane: they enclose "
                    "no volume to fit\n", names[t], what, (unsigned long)t);
        else if (r == SQFFD_ERROR_NON_FINITE)
            fprintf(stderr, "%s (%s %lu): a coordinate is not finite or beyond +-1e100\n", names[t], what,
                    (unsigned long)t);
        else
            fprintf(stderr, "%s (%s %lu): %s\n", names[t], what, (unsigned long)t, sqffd_result_string(r));
        return 1;
    }
    return 0;
}

/* Every frame of every input, in order (in: how volumes become points),
   appended to *points, *counts and *names (each frame's input), their
   number in *frame_count; the units and the dropped points noted in a. 0,
   or an exit status after a message. */
static int read_frames(track_args *a, const char *const *inputs, size_t input_count, const input_args *in,
                       double ***points, size_t **counts, const char ***names, size_t *frame_count)
{
    char err[512];
    size_t i, t;
    for (i = 0; i < input_count; i++) {
        double **got = NULL;
        size_t *got_counts = NULL, got_count = 0, total = *frame_count;
        input_summary sum;
        int failed = read_input(inputs[i], in, 0, &got, &got_counts, &got_count, &sum, err, sizeof err);
        double **grown = failed ? NULL : (double **)realloc(*points, (total + got_count) * sizeof **points);
        size_t *grown_counts = grown ? (size_t *)realloc(*counts, (total + got_count) * sizeof **counts) : NULL;
        const char **grown_names = grown_counts ? (const char **)realloc((void *)*names, (total + got_count) * sizeof **names) : NULL;
        if (grown) *points = grown;
        if (grown_counts) *counts = grown_counts;
        if (grown_names) *names = grown_names;
        if (!grown_names) {
            if (failed) fprintf(stderr, "%s\n", err);
            else fprintf(stderr, "sqffd track: out of memory\n");
            free_frames(got, got_counts, got_count);
            return EXIT_BAD_INPUT;
        }
        for (t = 0; t < got_count; t++) {
            (*points)[total + t] = got[t];
            (*counts)[total + t] = got_counts[t];
            (*names)[total + t] = inputs[i];
        }
        *frame_count = total + got_count;
        free(got);
        free(got_counts);
        if (sum.volume && a->unit == UNIT_GIVEN)
            return usage_error(find_command("track"), "track: --mm-per-unit: %s is a volume (%s), whose coordinates "
                               "are in mm already", inputs[i], sum.format);
        if (!sum.volume && a->unit == UNIT_VOLUMES) a->unit = UNIT_ASSUMED;
        a->dropped_nan += sum.dropped_nan;
        a->dropped_frames += sum.dropped_nan > 0;
    }
    return 0;
}

/* The epicardial frames (--epi's files, or with --myocardium-label the
   FRAME label maps' border of both labels), as many as the frames; 0, or
   an exit status after a message. */
static int read_epi_frames(track_args *a)
{
    input_args in = a->in;
    int status;
    if (a->myocardium_set) {
        in.label2_set = 1;
        in.label2 = a->myocardium_label;
    }
    status = read_frames(a, a->myocardium_set ? a->inputs : a->epi_inputs,
                         a->myocardium_set ? a->input_count : a->epi_input_count, &in, &a->epi_points, &a->epi_counts,
                         &a->epi_frames, &a->epi_frame_count);
    if (status == 0 && a->epi_frame_count != a->frame_count)
        return usage_error(find_command("track"), "track: --epi gives %lu epicardial frame%s, the FRAME inputs %lu "
                           "frames: one epicardial frame for each frame, in the same order",
                           (unsigned long)a->epi_frame_count, a->epi_frame_count == 1 ? "" : "s",
                           (unsigned long)a->frame_count);
    return status;
}

static int cmd_track(int argc, char **argv)
{
    track_args a;
    track_result res;
    double **points = NULL;
    size_t *counts = NULL;
    char err[512];
    int help, status;

    track_args_default(&a);
    memset(&res, 0, sizeof res);
    a.inputs = (const char **)calloc((size_t)argc, sizeof *a.inputs);
    if (!a.inputs) return EXIT_BAD_INPUT;
    status = track_parse(argc, argv, &a, &help);
    if (status || help) {
        if (help) print_command_help(stdout, find_command("track"));
        goto done;
    }
    status = EXIT_BAD_INPUT;
    if (a.epi_input_count) { /* the run's inputs: the frames', then the epicardium's (no output may be one) */
        const char **all = (const char **)realloc((void *)a.inputs, (a.input_count + a.epi_input_count) * sizeof *all);
        if (!all) goto done;
        a.inputs = all;
        memcpy((void *)(a.inputs + a.input_count), a.epi_inputs, a.epi_input_count * sizeof *all);
    }
    a.out.inputs = a.inputs;
    a.out.input_count = a.input_count + a.epi_input_count;
    if (output_folder(&a.out, a.output, "frame_", ".ply") || output_folder(&a.out, a.output, "epi_frame_", ".ply") ||
        (status = read_frames(&a, a.inputs, a.input_count, &a.in, &points, &counts, &a.frames, &a.frame_count)) != 0)
        goto done;
    status = EXIT_BAD_INPUT;
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
    if (a.wall && (status = read_epi_frames(&a)) != 0) goto done;
    status = EXIT_BAD_INPUT;
    if (track_outputs(&a) || (a.json_output && output_add(&a.out, a.json_output))) goto done;
    if (check_frames(&a, a.frames, "frame", points, counts) ||
        (a.wall && check_frames(&a, a.epi_frames, "epicardial frame", a.epi_points, a.epi_counts)) ||
        (status = track_stacks(&a, points, counts)) != 0)
        goto done;
    status = track_run(&a, points, counts, &res);
    if (status == 0 && a.json_output && track_json(&a, counts, &res, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        status = EXIT_BAD_INPUT;
    }
    if (status == 0 && output_commit(&a.out)) status = EXIT_BAD_INPUT;
    if (status == 0) {
        output_prune(a.output, "frame_", ".ply", a.frame_count);
        output_prune(a.output, "epi_frame_", ".ply", a.wall ? a.frame_count : 0);
    }
    if (status == 0 && !a.quiet) track_report(&a, counts, &res);
done:
    output_abort(&a.out);
    free_frames(points, counts, a.frame_count);
    free_frames(a.epi_points, a.epi_counts, a.epi_frame_count);
    track_result_free(&res);
    free(a.stacks);
    free(a.lids);
    free(a.epi_stacks);
    free(a.epi_lids);
    free((void *)a.frames);
    free((void *)a.epi_frames);
    free((void *)a.epi_inputs);
    free(a.epi_list);
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
    range_text_buffer r[4];
    fprintf(f,
            "A synthetic left ventricle (examples/sqffd_phantom.h: a closed cavity, apex down\n"
            "along -z, a lid at the base for the valve plane) beating through one cycle, end-\n"
            "diastole at frame 0, end-systole mid-way; each frame's points are drawn afresh, with\n"
            "Gaussian noise. Written to DIR (made if absent):\n"
            "  points_NN.ply   each frame's points, with a float 'label': 0 wall, 1 the\n"
            "                  hypokinetic zone, 2 the valve plane (the truth)\n"
            "  truth.csv       per frame: phase and true volume (with --epi: and myocardium)\n"
            "  epi_points_NN.ply  with --epi: each frame's epicardial points (the wall's outer\n"
            "                  border, %g mm thick at ED, thickening %g %% where the wall moves\n"
            "                  normally, a fifth of that on the zone's plateau), labelled alike\n"
            "The report gives the true EDV, ESV and ejection fraction (with --epi: the true LV\n"
            "mass at ED and ES, %g g/ml x the myocardium) and the 'sqffd track' command to run\n"
            "(its septum is -x).\n"
            "\n"
            "  -o, --output DIR       output folder (required)\n"
            "  --frames N             frames over the cycle, %s (default 16)\n"
            "  --points N             points per frame, %s (default 6000)\n"
            "  --noise S              noise standard deviation as a fraction of the ventricle's\n"
            "                         bounding-box diagonal, %s (default 0.01)\n"
            "  --low-motion U,THETA,RADIUS,FACTOR\n"
            "                         the hypokinetic zone: centre (u 0..1 from apex to base,\n"
            "                         theta in radians), angular radius, motion factor 0..1\n"
            "                         (default %g,%g,%g,%g; factor 1: none)\n"
            "  --seed N               random seed, %s (default 1)\n"
            "  --epi                  also write the epicardium's frames\n"
            "  --quiet                print nothing on success\n"
            "A reused DIR: the points_NN.ply and epi_points_NN.ply of an earlier run with more\n"
            "frames are removed (no other file).\n",
            p.wall_thickness, 100.0 * p.wall_thickening, MYOCARDIUM_DENSITY,
            range_text("phantom", "--frames", r[0]), range_text("phantom", "--points", r[1]),
            range_text("phantom", "--noise", r[2]), p.low_motion[0], p.low_motion[1], p.low_motion[2], p.low_motion_factor,
            range_text("phantom", "--seed", r[3]));
}

static int cmd_phantom(int argc, char **argv)
{
    const cli_command *c = find_command("phantom");
    phantom_lv p = phantom_lv_default(), outer;
    arg_scan s;
    const char *arg, *v, *output = NULL;
    long frames = 16, count = 6000, seed = 1, k, i, es = 0;
    double noise = 0.01, zone[4], *points = NULL, *labels = NULL, n = 0.0, least = 0.0;
    unsigned char *label = NULL;
    char path[4096], name[64], err[512];
    sqffd_io_scalar scalar;
    output_set out;
    FILE *f;
    int kind, quiet = 0, epi = 0, status, surface;
    memset(&s, 0, sizeof s);
    s.argc = argc;
    s.argv = argv;
    while ((kind = scan_next(&s, &arg)) != 0) {
#define IS(x) (strcmp(s.name, x) == 0)
        if (kind < 0) return usage_error(c, "phantom: unknown option '%s'", arg);
        if (kind == 1) return usage_error(c, "phantom: no positional arguments, '%s' is one", arg);
        if (IS("--help") || IS("-h") || IS("--quiet") || IS("--epi")) {
            if ((status = scan_flag(&s, c)) != 0) return status;
            if (IS("--quiet")) { quiet = 1; continue; }
            if (IS("--epi")) { epi = 1; continue; }
            print_command_help(stdout, c);
            return 0;
        }
        if (!(IS("-o") || IS("--output") || IS("--frames") || IS("--points") || IS("--noise") || IS("--low-motion") ||
              IS("--seed")))
            return usage_error(c, "phantom: unknown option '%s'", s.argv[s.i]);
        if (!(v = scan_value(&s, c))) return EXIT_USAGE;
        if (IS("-o") || IS("--output")) output = v;
        else if (!IS("--low-motion")) {
            if ((status = option_number(c, s.name, v, &n)) != 0) return status;
            if (IS("--frames")) frames = (long)n;
            else if (IS("--points")) count = (long)n;
            else if (IS("--noise")) noise = n;
            else seed = (long)n;
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
    memset(&out, 0, sizeof out);
    if (output_folder(&out, output, "points_", ".ply") || output_folder(&out, output, "epi_points_", ".ply") ||
        output_add_in(&out, output, "truth.csv"))
        goto done;
    for (k = 0; k < frames; k++) {
        snprintf(name, sizeof name, "points_%02ld.ply", k);
        if (output_add_in(&out, output, name)) goto done;
        snprintf(name, sizeof name, "epi_points_%02ld.ply", k);
        if (epi && output_add_in(&out, output, name)) goto done;
    }
    outer = p;
    outer.epicardium = 1;
    points = (double *)malloc(3 * (size_t)count * sizeof *points);
    labels = (double *)malloc((size_t)count * sizeof *labels);
    label = (unsigned char *)malloc((size_t)count);
    if (!points || !labels || !label) {
        fprintf(stderr, "sqffd phantom: out of memory\n");
        goto done;
    }
    join_path(path, output, "truth.csv");
    if (!(f = output_open(&out, path, err, sizeof err))) {
        fprintf(stderr, "%s\n", err);
        goto done;
    }
    fprintf(f, "frame,phase,volume%s\n", epi ? ",myocardium" : "");
    for (k = 0; k < frames; k++) {
        double volume = phantom_lv_volume(&p, (double)k / (double)frames);
        fprintf(f, "%ld,%.9g,%.9g", k, (double)k / (double)frames, volume);
        if (epi) fprintf(f, ",%.9g", phantom_lv_myocardium(&p, (double)k / (double)frames));
        fputc('\n', f);
        if (k == 0 || volume < least) { /* ES: the least volume */
            least = volume;
            es = k;
        }
    }
    for (k = 0; k < frames; k++)
        for (surface = 0; surface <= epi; surface++) { /* the cavity's points, then the epicardium's (own seeds) */
            phantom_lv_frame(surface ? &outer : &p, (double)k / (double)frames, (size_t)count, noise,
                             (uint64_t)seed * 1000003u + (uint64_t)k + (surface ? 500009u : 0u), points, label);
            for (i = 0; i < count; i++) labels[i] = label[i];
            scalar.name = "label";
            scalar.values = labels;
            snprintf(name, sizeof name, "%spoints_%02ld.ply", surface ? "epi_" : "", k);
            join_path(path, output, name);
            if (!(f = output_open(&out, path, err, sizeof err)) ||
                sqffd_io_write_ply_stream(f, path, points, (size_t)count, NULL, 0, &scalar, 1, 0, err, sizeof err)) {
                fprintf(stderr, "%s\n", err);
                goto done;
            }
        }
    if (output_commit(&out)) goto done;
    output_prune(output, "points_", ".ply", (size_t)frames);
    output_prune(output, "epi_points_", ".ply", epi ? (size_t)frames : 0);
    if (!quiet) {
        double edv = phantom_lv_volume(&p, 0.0), ef = phantom_lv_ejection_fraction(&p, (int)frames);
        printf("sqffd phantom: %ld frames of %ld points (noise %g of the %.4g diagonal) -> %s\n", frames, count, noise,
               phantom_lv_scale(&p), output);
        printf("  true end-diastolic volume  %.6g\n", edv);
        printf("  true end-systolic volume   %.6g\n", edv * (1.0 - ef));
        printf("  true ejection fraction  %.1f %%\n", 100.0 * ef);
        if (epi)
            printf("  true LV mass  ED %.6g g, ES %.6g g (frame %ld; %g g/ml x the myocardium, the closed epicardium\n"
                   "                less the closed cavity; mm)\n", MYOCARDIUM_DENSITY * phantom_lv_myocardium(&p, 0.0) / 1000.0,
                   MYOCARDIUM_DENSITY * phantom_lv_myocardium(&p, (double)es / (double)frames) / 1000.0, es,
                   MYOCARDIUM_DENSITY);
        printf("  track it: sqffd track %s/points_*.ply%s%s%s -o OUT --septum %g,%g,%g\n", output,
               epi ? " --epi $(ls " : "", epi ? output : "", epi ? "/epi_points_*.ply | paste -sd, -)" : "",
               phantom_septum[0], phantom_septum[1], phantom_septum[2]);
    }
    status = 0;
done:
    output_abort(&out);
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
    double *points[DEMO_FRAMES] = {NULL}, alpha[4], table[4], t0 = seconds_now();
    size_t counts[DEMO_FRAMES], t;
    const char *frames[DEMO_FRAMES];
    char path[4096], err[512];
    FILE *f = NULL;
    int k, status = EXIT_BAD_INPUT;
    static const char *const written[] = {"frame_00.ply ... frame_15.ply", "motion.ply", "segments.csv",
                                          "volumes.csv", "model.json", "fig3_error.svg", "table1_alpha.svg",
                                          "volumes.svg", "bullseye.svg"};
    enum { DEMO_TRACK_FILES = 4, DEMO_FILES = sizeof written / sizeof written[0] }; /* written[4...]: the demo's own */
    track_args_default(&a);
    a.unit = UNIT_GIVEN; /* the phantom is in mm */
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
    memcpy(a.motion.septum_direction, phantom_septum, sizeof phantom_septum);
    a.frames = frames;
    a.frame_count = DEMO_FRAMES;
    memset(&res, 0, sizeof res);
    if (output_folder(&a.out, a.output, "frame_", ".ply") || track_outputs(&a)) goto done;
    for (k = DEMO_TRACK_FILES; k < DEMO_FILES; k++)
        if (output_add_in(&a.out, a.output, written[k])) goto done;
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
    for (k = DEMO_TRACK_FILES; k < DEMO_FILES; k++) { /* in written[]'s order */
        int failed;
        join_path(path, a.output, written[k]);
        if (!(f = output_open(&a.out, path, err, sizeof err))) failed = 1;
        else if (k == DEMO_TRACK_FILES) failed = sqffd_export_model_json_stream(f, path, &res.models[0], &res.reports[0], err, sizeof err);
        else if (k == DEMO_TRACK_FILES + 1)
            failed = sqffd_export_svg_history_stream(f, path, &res.reports[0], "Frame 0: the error per FFD iteration (Fig. 3)",
                                                     err, sizeof err);
        else if (k == DEMO_TRACK_FILES + 2)
            failed = sqffd_export_svg_alpha_stream(f, path, alpha, table, 4, "Frame 0: the error against alpha (Table 1)", err,
                                                   sizeof err);
        else if (k == DEMO_TRACK_FILES + 3)
            failed = sqffd_export_svg_volumes_stream(f, path, res.out.volumes, DEMO_FRAMES, &res.motion, "mm^3",
                                                     "Model volume over the cycle", err, sizeof err);
        else
            failed = sqffd_export_svg_bullseye_stream(f, path, &res.motion, 1, "Inward excursion, ED to ES (17 segments)",
                                                      "mm", err, sizeof err);
        if (failed) {
            fprintf(stderr, "%s\n", err);
            goto done;
        }
    }
    if (output_commit(&a.out)) goto done;
    output_prune(a.output, "frame_", ".ply", DEMO_FRAMES);
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
        track_report(&a, counts, &res);
        printf("\nwritten to %s/:\n", a.output);
        for (k = 0; k < (int)(sizeof written / sizeof written[0]); k++) printf("  %s\n", written[k]);
        printf("total %.1f s\n", seconds_now() - t0);
    }
    status = 0;
done:
    output_abort(&a.out);
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

static int run(int argc, char **argv)
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

/* A report that did not reach standard output (a full disk, a closed pipe)
   is a failure: exit status 1 (the output files, already in place, stay). */
int main(int argc, char **argv)
{
    int status = run(argc, argv), failed;
    errno = 0;
    failed = fflush(stdout) != 0 || ferror(stdout);
    failed |= fclose(stdout) != 0;
    if (!failed) return status;
    fprintf(stderr, "sqffd: standard output: write error: %s\n", errno ? strerror(errno) : "unknown error");
    return status ? status : EXIT_BAD_INPUT;
}

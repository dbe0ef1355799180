/* stack_bound: worst-case stack of a program's call graph, from the .ci files
   gcc writes with -fcallgraph-info=su (GCC 10 or later; VCG format):

     node: { title: "t.c:f" label: "f\nt.c:3:12\n96 bytes (static)" }
     node: { title: "sin" label: "sin\n/usr/include/.../mathcalls.h:64:1" shape : ellipse }
     node: { title: "__indirect_call" label: "Indirect Call Placeholder" shape : ellipse }
     edge: { sourcename: "t.c:f" targetname: "sin" label: "t.c:4:9" }

   A function's frame is its "N bytes"; the stack of a call path is the sum of
   its frames; a root's worst case is the largest over every path from it.
   It reports the largest frame, every frame over --frame-limit, each root's
   worst case with its deepest chain (and, when that is over --stack-limit,
   the other branches off it that are over too), recursion (any cycle: fails), unbounded
   dynamic frames (alloca, VLA: fails; "dynamic,bounded" frames are counted at
   their bound), calls through function pointers (mapped to their callees with
   --indirect, otherwise counted as a user callback of --callback-bytes and
   listed), and functions outside the graph (libm, libc: counted 0 unless
   --frame gives them a size). Exit status: 0 all limits hold, 1 a limit is
   broken, 2 usage or input error.

   Build: cc -O2 -std=c99 -o stack_bound tests/stack_bound.c
   Plain C99, no dependencies. Run with -h for the options. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SB_UNBOUNDED (-1L)

enum { DYN_STATIC = 0, DYN_BOUNDED = 1, DYN_UNBOUNDED = 2 };

typedef struct {
    char *title;     /* the graph's key: "file:name" for static functions */
    char *name;      /* label's first line: the symbol, with clone suffixes */
    char *loc;       /* file:line:col of the definition (file's base name) */
    long frame;      /* bytes; -1 when the graph has no frame (external) */
    int dynamic;     /* DYN_* */
    int external;    /* no frame: defined elsewhere (libm, libc, ...) */
    int is_static;   /* title carries the file: not externally visible */
    int *out;        /* callees (node indices) */
    int nout, capout;
    int indirect;    /* number of calls through a pointer */
    char *indirect_site; /* the first such call's location */
    int incoming;
    /* analysis */
    int color;       /* 0 white, 1 on stack, 2 done */
    long worst;      /* worst-case stack from here, SB_UNBOUNDED on recursion */
    int best;        /* the deepest callee (-1 none, -2 the user callback) */
    int best_indirect; /* best is reached through a pointer */
    int scc, low, index, onstack;
    int inchain;     /* printing a chain: already in it */
} sb_node;

typedef struct {
    char *caller;
    char **callees;
    int ncallees;
    int user;  /* "user" in the list: an opaque user callback too */
    int used;
} sb_map;

typedef struct {
    char *name;
    long bytes;
    int used;
} sb_frame;

static sb_node *nodes;
static int nnodes, capnodes;
static sb_map *maps;
static int nmaps;
static sb_frame *frames;
static int nframes;
static long callback_bytes = 0;
static int verbose = 0;
static int brief = 0;

static void *xrealloc(void *p, size_t n)
{
    void *q = realloc(p, n ? n : 1);
    if (!q) {
        fprintf(stderr, "stack_bound: out of memory\n");
        exit(2);
    }
    return q;
}

static char *xstrdup(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = (char *)xrealloc(NULL, n);
    memcpy(d, s, n);
    return d;
}

static char *xstrndup(const char *s, size_t n)
{
    char *d = (char *)xrealloc(NULL, n + 1);
    memcpy(d, s, n);
    d[n] = '\0';
    return d;
}

/* ---- the graph */

static int find_title(const char *title)
{
    int i;
    for (i = 0; i < nnodes; i++)
        if (strcmp(nodes[i].title, title) == 0) return i;
    return -1;
}

static int add_node(const char *title)
{
    int i = find_title(title);
    sb_node *n;
    if (i >= 0) return i;
    if (nnodes == capnodes) {
        capnodes = capnodes ? 2 * capnodes : 256;
        nodes = (sb_node *)xrealloc(nodes, (size_t)capnodes * sizeof *nodes);
    }
    n = &nodes[nnodes];
    memset(n, 0, sizeof *n);
    n->title = xstrdup(title);
    n->name = xstrdup(title);
    n->loc = xstrdup("");
    n->frame = -1;
    n->external = 1;
    n->best = -1;
    n->scc = -1;
    n->index = -1;
    return nnodes++;
}

static void add_edge(int from, int to)
{
    sb_node *n = &nodes[from];
    if (n->nout == n->capout) {
        n->capout = n->capout ? 2 * n->capout : 8;
        n->out = (int *)xrealloc(n->out, (size_t)n->capout * sizeof *n->out);
    }
    n->out[n->nout++] = to;
    nodes[to].incoming++;
}

/* the symbol without gcc's clone suffixes (.part.0, .constprop.0, .isra.0, .cold) */
static size_t base_len(const char *name)
{
    const char *dot = strchr(name, '.');
    return dot ? (size_t)(dot - name) : strlen(name);
}

static int name_matches(const char *name, const char *want)
{
    size_t n = base_len(name);
    if (strcmp(name, want) == 0) return 1;
    return strlen(want) == n && strncmp(name, want, n) == 0;
}

/* A file's base name, for short locations. */
static const char *short_path(const char *p)
{
    const char *s = strrchr(p, '/');
    return s ? s + 1 : p;
}

/* ---- parsing */

/* The value of key: "..." inside [begin, end); NULL when absent. Escapes:
   \n becomes '\n', \" and \\ their character. */
static char *get_value(const char *begin, const char *end, const char *key)
{
    size_t klen = strlen(key);
    const char *p = begin;
    while (p < end) {
        const char *k = strstr(p, key);
        if (!k || k >= end) return NULL;
        if ((k == begin || k[-1] == ' ' || k[-1] == '{') && k + klen < end && k[klen] == ':') {
            const char *q = k + klen + 1, *s;
            char *out, *o;
            while (q < end && *q == ' ') q++;
            if (q >= end || *q != '"') return NULL;
            s = ++q;
            while (q < end && *q != '"') q += (*q == '\\' && q + 1 < end) ? 2 : 1;
            out = o = (char *)xrealloc(NULL, (size_t)(q - s) + 1);
            for (; s < q; s++) {
                if (*s == '\\' && s + 1 < q) {
                    s++;
                    *o++ = *s == 'n' ? '\n' : *s;
                } else
                    *o++ = *s;
            }
            *o = '\0';
            return out;
        }
        p = k + klen;
    }
    return NULL;
}

/* A record's closing brace: the first '}' outside quotes. */
static const char *record_end(const char *p)
{
    int quoted = 0;
    for (; *p; p++) {
        if (quoted && *p == '\\' && p[1]) p++;
        else if (*p == '"') quoted = !quoted;
        else if (!quoted && *p == '}') return p;
    }
    return NULL;
}

static void set_node(int i, const char *label)
{
    sb_node *n = &nodes[i];
    const char *l1 = strchr(label, '\n'), *l2, *bytes;
    if (!l1) return; /* "Indirect Call Placeholder" and the like */
    l2 = strchr(l1 + 1, '\n');
    if (!l2) return; /* declared here, defined elsewhere: the title is its name */
    bytes = strstr(l2 + 1, " bytes");
    if (!bytes) return;
    free(n->name);
    n->name = xstrndup(label, (size_t)(l1 - label));
    {
        char *loc = xstrndup(l1 + 1, (size_t)(l2 - l1 - 1));
        free(n->loc);
        n->loc = xstrdup(short_path(loc));
        free(loc);
    }
    n->frame = strtol(l2 + 1, NULL, 10);
    n->external = 0;
    n->dynamic = strstr(bytes, "dynamic,bounded") ? DYN_BOUNDED : strstr(bytes, "dynamic") ? DYN_UNBOUNDED : DYN_STATIC;
}

static int parse_file(const char *path, int *edges)
{
    FILE *f = fopen(path, "rb");
    char *text;
    long size;
    const char *p;
    int count = 0;
    if (!f) {
        fprintf(stderr, "stack_bound: cannot open %s\n", path);
        return -1;
    }
    fseek(f, 0, SEEK_END);
    size = ftell(f);
    fseek(f, 0, SEEK_SET);
    if (size < 0) {
        fclose(f);
        return -1;
    }
    text = (char *)xrealloc(NULL, (size_t)size + 1);
    if (fread(text, 1, (size_t)size, f) != (size_t)size) {
        fclose(f);
        free(text);
        fprintf(stderr, "stack_bound: cannot read %s\n", path);
        return -1;
    }
    text[size] = '\0';
    fclose(f);
    if (!strstr(text, "graph:")) {
        fprintf(stderr, "stack_bound: %s is no VCG call graph (compile with -fcallgraph-info=su)\n", path);
        free(text);
        return -1;
    }
    p = text;
    for (;;) {
        const char *n = strstr(p, "node:"), *e = strstr(p, "edge:"), *r, *end;
        int is_node;
        if (!n && !e) break;
        is_node = n && (!e || n < e);
        r = is_node ? n : e;
        end = record_end(r);
        if (!end) break;
        if (is_node) {
            char *title = get_value(r, end, "title"), *label = get_value(r, end, "label");
            if (title) {
                int i = add_node(title);
                /* a definition wins over a declaration met in another file */
                if (label && nodes[i].external) set_node(i, label);
                nodes[i].is_static = strchr(title, ':') != NULL;
            }
            free(title);
            free(label);
        } else {
            char *src = get_value(r, end, "sourcename"), *dst = get_value(r, end, "targetname");
            char *lab = get_value(r, end, "label");
            if (src && dst) {
                int a = add_node(src);
                if (strcmp(dst, "__indirect_call") == 0) {
                    nodes[a].indirect++;
                    if (!nodes[a].indirect_site) nodes[a].indirect_site = xstrdup(lab ? short_path(lab) : "?");
                } else
                    add_edge(a, add_node(dst));
                count++;
            }
            free(src);
            free(dst);
            free(lab);
        }
        p = end + 1;
    }
    free(text);
    *edges += count;
    return 0;
}

/* ---- recursion: Tarjan's strongly connected components */

static int tarjan_index, *tarjan_stack, tarjan_top, nscc;

static int map_for(int i);

/* Callees of i, including the mapped targets of its indirect calls. */
static int callee_count(int i)
{
    int m = nodes[i].indirect ? map_for(i) : -1;
    return nodes[i].nout + (m >= 0 ? maps[m].ncallees : 0);
}

static int callee_at(int i, int k, int *via_pointer)
{
    int m;
    if (k < nodes[i].nout) {
        *via_pointer = 0;
        return nodes[i].out[k];
    }
    m = map_for(i);
    *via_pointer = 1;
    {
        const char *want = maps[m].callees[k - nodes[i].nout];
        int j, found = -1;
        for (j = 0; j < nnodes; j++)
            if (!nodes[j].external && strcmp(nodes[j].name, want) == 0) return j;
        for (j = 0; j < nnodes; j++)
            if (!nodes[j].external && name_matches(nodes[j].name, want)) {
                /* the deepest clone */
                if (found < 0 || nodes[j].frame > nodes[found].frame) found = j;
            }
        return found;
    }
}

static void strongconnect(int v)
{
    int k, w, via, count = callee_count(v);
    nodes[v].index = nodes[v].low = tarjan_index++;
    tarjan_stack[tarjan_top++] = v;
    nodes[v].onstack = 1;
    for (k = 0; k < count; k++) {
        w = callee_at(v, k, &via);
        if (w < 0) continue;
        if (nodes[w].index < 0) {
            strongconnect(w);
            if (nodes[w].low < nodes[v].low) nodes[v].low = nodes[w].low;
        } else if (nodes[w].onstack && nodes[w].index < nodes[v].low)
            nodes[v].low = nodes[w].index;
    }
    if (nodes[v].low == nodes[v].index) {
        do {
            w = tarjan_stack[--tarjan_top];
            nodes[w].onstack = 0;
            nodes[w].scc = nscc;
        } while (w != v);
        nscc++;
    }
}

static int self_call(int v)
{
    int k, via, count = callee_count(v);
    for (k = 0; k < count; k++)
        if (callee_at(v, k, &via) == v) return 1;
    return 0;
}

/* ---- indirect calls */

static int map_for(int i)
{
    int m;
    for (m = 0; m < nmaps; m++)
        if (name_matches(nodes[i].name, maps[m].caller)) return m;
    return -1;
}

/* ---- worst case */

static long ext_frame(int i)
{
    int k;
    for (k = 0; k < nframes; k++)
        if (name_matches(nodes[i].name, frames[k].name) || strcmp(nodes[i].title, frames[k].name) == 0) {
            frames[k].used = 1;
            return frames[k].bytes;
        }
    return 0;
}

static long own_frame(int i)
{
    return nodes[i].external ? ext_frame(i) : nodes[i].frame;
}

static long worst(int v)
{
    sb_node *n = &nodes[v];
    int k, via, count;
    long deepest = 0;
    if (n->color == 2) return n->worst;
    if (n->color == 1) return SB_UNBOUNDED; /* recursion: reported by the SCC pass */
    n->color = 1;
    n->best = -1;
    count = callee_count(v);
    for (k = 0; k < count; k++) {
        int w = callee_at(v, k, &via);
        long d;
        if (w < 0) continue;
        d = worst(w);
        if (d == SB_UNBOUNDED) {
            deepest = SB_UNBOUNDED;
            n->best = w;
            n->best_indirect = via;
            break;
        }
        if (n->best == -1 || d > deepest) {
            deepest = d;
            n->best = w;
            n->best_indirect = via;
        }
    }
    if (deepest != SB_UNBOUNDED && n->indirect) {
        int m = map_for(v);
        if ((m < 0 || maps[m].user) && callback_bytes > deepest) {
            deepest = callback_bytes;
            n->best = -2;
            n->best_indirect = 1;
        } else if ((m < 0 || maps[m].user) && n->best == -1)
            n->best = -2;
    }
    n->worst = deepest == SB_UNBOUNDED ? SB_UNBOUNDED : own_frame(v) + deepest;
    n->color = 2;
    return n->worst;
}

static void print_chain(int v)
{
    long total = 0;
    int via = 0, i, first = 1, pointers = 0;
    for (i = 0; i < nnodes; i++) nodes[i].inchain = 0;
    if (brief) printf("       ");
    while (v >= 0) {
        long f = own_frame(v);
        pointers += via;
        if (nodes[v].inchain) {
            if (brief) printf(" > %s%s again: recursion", via ? "*" : "", nodes[v].name);
            else printf("                       %s%s again: recursion\n", via ? "(via pointer) " : "", nodes[v].name);
            break;
        }
        nodes[v].inchain = 1;
        total += f;
        if (brief)
            printf("%s%s%s %ld", first ? "" : " > ", via ? "*" : "", nodes[v].name, f);
        else
            printf("      %7ld %7ld  %s%s%s%s%s\n", f, total, via ? "(via pointer) " : "", nodes[v].name,
                   nodes[v].loc[0] ? "  " : "", nodes[v].loc,
                   nodes[v].external ? (f ? "  (external, --frame)" : "  (external, not counted)") : "");
        first = 0;
        via = nodes[v].best_indirect;
        if (nodes[v].best == -2) {
            total += callback_bytes;
            pointers++;
            if (brief) printf(" > *<user callback> %ld", callback_bytes);
            else printf("      %7ld %7ld  (via pointer) <user callback, --callback-bytes>\n", callback_bytes, total);
            break;
        }
        v = nodes[v].best;
    }
    if (brief) printf("%s\n", pointers ? "   (*: through a function pointer)" : "");
}

/* Branches off a root's deepest chain that are over the limit themselves:
   for each function on the chain (while the chain up to it is within the
   limit), each other callee whose path is over. The deepest chain alone
   hides them until it is fixed. */
typedef struct {
    int at;     /* position on the chain */
    int callee;
    long total;
} sb_branch;

static int by_total(const void *a, const void *b)
{
    const sb_branch *x = (const sb_branch *)a, *y = (const sb_branch *)b;
    if (x->total != y->total) return x->total < y->total ? 1 : -1;
    return x->at - y->at;
}

static void print_branches(int root, long limit, int most)
{
    int chain[256], len = 0, i, k, n = 0, cap = 64, via;
    long prefix[256];
    sb_branch *b = (sb_branch *)xrealloc(NULL, (size_t)cap * sizeof *b);
    for (i = 0; i < nnodes; i++) nodes[i].inchain = 0;
    for (i = root; i >= 0 && len < 256 && !nodes[i].inchain; i = nodes[i].best) {
        nodes[i].inchain = 1;
        prefix[len] = (len ? prefix[len - 1] : 0) + own_frame(i);
        chain[len++] = i;
    }
    for (i = 0; i < len && prefix[i] <= limit; i++) { /* past that, every branch is over */
        int v = chain[i], count = callee_count(v);
        for (k = 0; k < count; k++) {
            int w = callee_at(v, k, &via), j, seen = 0;
            if (w < 0 || w == nodes[v].best || nodes[w].worst == SB_UNBOUNDED) continue;
            if (prefix[i] + nodes[w].worst <= limit) continue;
            for (j = 0; j < n; j++) seen |= b[j].at == i && b[j].callee == w;
            if (seen) continue;
            if (n == cap) b = (sb_branch *)xrealloc(b, (size_t)(cap *= 2) * sizeof *b);
            b[n].at = i;
            b[n].callee = w;
            b[n].total = prefix[i] + nodes[w].worst;
            n++;
        }
    }
    qsort(b, (size_t)n, sizeof *b, by_total);
    if (n) printf("       also over %ld bytes, branching off that chain%s:\n", limit, n > most ? " (the deepest)" : "");
    for (k = 0; k < n && k < most; k++) {
        int w = b[k].callee;
        printf("       %7ld: ", b[k].total);
        for (i = 0; i <= b[k].at; i++) printf("%s > ", nodes[chain[i]].name);
        /* the branch's own deepest chain */
        for (i = 0; w >= 0 && i < 256; i++, w = nodes[w].best) {
            printf("%s%s %ld", i ? " > " : "[", nodes[w].name, own_frame(w));
            if (nodes[w].best == -2) {
                printf(" > <user callback>");
                break;
            }
        }
        printf("]\n");
    }
    free(b);
}

static int find_root(const char *want)
{
    int i, found = -1;
    for (i = 0; i < nnodes; i++)
        if (!nodes[i].external && strcmp(nodes[i].name, want) == 0) return i;
    for (i = 0; i < nnodes; i++)
        if (!nodes[i].external && name_matches(nodes[i].name, want) && (found < 0 || nodes[i].frame > nodes[found].frame))
            found = i;
    return found;
}

static void usage(void)
{
    printf("usage: stack_bound [options] FILE.ci...\n"
           "  --root NAME            a root function (repeatable; default: sqffd_fit and sqffd_track)\n"
           "  --stack-limit N        each root's worst case must be <= N bytes (default 8192)\n"
           "  --frame-limit N        every frame must be <= N bytes (default 2048)\n"
           "  --public PREFIX        also report every externally visible function named PREFIX*\n"
           "                         (the largest worst case, not a limit unless --public-limit)\n"
           "  --public-limit N       fail when a public function's worst case exceeds N\n"
           "  --indirect CALLER=CALLEE[,CALLEE...]\n"
           "                         calls through a pointer in CALLER (or its clones) reach these\n"
           "                         functions; the name `user` adds an opaque user callback\n"
           "  --callback-bytes N     stack assumed for a user callback (unmapped indirect call;\n"
           "                         default 0: the caller's own callback stack comes on top)\n"
           "  --frame NAME=N         frame of a function outside the graph (libm, libc; default 0)\n"
           "  --title TEXT           heading of the report\n"
           "  -v                     every frame, and every public function's chain\n"
           "  --brief                a short report: chains on one line, no external list\n"
           "exit status: 0 within the limits, 1 a limit broken (frame, stack, recursion,\n"
           "unbounded dynamic frame), 2 usage or input error\n");
}

static long parse_long(const char *s, const char *opt)
{
    char *end;
    long v = strtol(s, &end, 10);
    if (*s == '\0' || *end != '\0' || v < 0) {
        fprintf(stderr, "stack_bound: %s wants a non-negative number, got '%s'\n", opt, s);
        exit(2);
    }
    return v;
}

static int by_frame(const void *a, const void *b)
{
    const sb_node *x = &nodes[*(const int *)a], *y = &nodes[*(const int *)b];
    if (x->frame != y->frame) return x->frame < y->frame ? 1 : -1;
    return strcmp(x->name, y->name);
}

static int by_worst(const void *a, const void *b)
{
    const sb_node *x = &nodes[*(const int *)a], *y = &nodes[*(const int *)b];
    long wx = x->worst == SB_UNBOUNDED ? 0x7fffffffL : x->worst, wy = y->worst == SB_UNBOUNDED ? 0x7fffffffL : y->worst;
    if (wx != wy) return wx < wy ? 1 : -1;
    return strcmp(x->name, y->name);
}

int main(int argc, char **argv)
{
    const char *roots[64], *files[256], *public_prefix = NULL, *title = NULL;
    int nroots = 0, nfiles = 0, a, i, k, failures = 0, edges = 0, defined = 0;
    long frame_limit = 2048, stack_limit = 8192, public_limit = -1;
    int *order;

    for (a = 1; a < argc; a++) {
        const char *o = argv[a];
        const char *v = a + 1 < argc ? argv[a + 1] : NULL;
        if (strcmp(o, "-h") == 0 || strcmp(o, "--help") == 0) {
            usage();
            return 0;
        } else if (strcmp(o, "-v") == 0) {
            verbose = 1;
        } else if (strcmp(o, "--brief") == 0) {
            brief = 1;
        } else if (o[0] == '-' && o[1] == '-') {
            if (!v) {
                fprintf(stderr, "stack_bound: %s needs a value\n", o);
                return 2;
            }
            a++;
            if (strcmp(o, "--root") == 0) {
                if (nroots == 64) return 2;
                roots[nroots++] = v;
            } else if (strcmp(o, "--stack-limit") == 0) {
                stack_limit = parse_long(v, o);
            } else if (strcmp(o, "--frame-limit") == 0) {
                frame_limit = parse_long(v, o);
            } else if (strcmp(o, "--public") == 0) {
                public_prefix = v;
            } else if (strcmp(o, "--public-limit") == 0) {
                public_limit = parse_long(v, o);
            } else if (strcmp(o, "--callback-bytes") == 0) {
                callback_bytes = parse_long(v, o);
            } else if (strcmp(o, "--title") == 0) {
                title = v;
            } else if (strcmp(o, "--indirect") == 0 || strcmp(o, "--frame") == 0) {
                const char *eq = strchr(v, '=');
                if (!eq || eq == v || !eq[1]) {
                    fprintf(stderr, "stack_bound: %s wants NAME=VALUE, got '%s'\n", o, v);
                    return 2;
                }
                if (o[2] == 'f') {
                    frames = (sb_frame *)xrealloc(frames, (size_t)(nframes + 1) * sizeof *frames);
                    frames[nframes].name = xstrndup(v, (size_t)(eq - v));
                    frames[nframes].bytes = parse_long(eq + 1, o);
                    frames[nframes].used = 0;
                    nframes++;
                } else {
                    sb_map *m;
                    const char *p = eq + 1;
                    maps = (sb_map *)xrealloc(maps, (size_t)(nmaps + 1) * sizeof *maps);
                    m = &maps[nmaps++];
                    memset(m, 0, sizeof *m);
                    m->caller = xstrndup(v, (size_t)(eq - v));
                    while (*p) {
                        const char *c = strchr(p, ',');
                        size_t n = c ? (size_t)(c - p) : strlen(p);
                        if (n == 4 && strncmp(p, "user", 4) == 0)
                            m->user = 1;
                        else if (n) {
                            m->callees = (char **)xrealloc(m->callees, (size_t)(m->ncallees + 1) * sizeof *m->callees);
                            m->callees[m->ncallees++] = xstrndup(p, n);
                        }
                        p += n + (c ? 1 : 0);
                    }
                }
            } else {
                fprintf(stderr, "stack_bound: unknown option %s (-h lists them)\n", o);
                return 2;
            }
        } else {
            if (nfiles == 256) return 2;
            files[nfiles++] = o;
        }
    }
    if (!nfiles) {
        usage();
        return 2;
    }
    if (!nroots) {
        roots[nroots++] = "sqffd_fit";
        roots[nroots++] = "sqffd_track";
    }
    for (i = 0; i < nfiles; i++)
        if (parse_file(files[i], &edges) != 0) return 2;
    for (i = 0; i < nnodes; i++) defined += !nodes[i].external;
    if (!defined) {
        fprintf(stderr, "stack_bound: no function with a frame in the input (compile with -fcallgraph-info=su)\n");
        return 2;
    }

    printf("== %s: %d function%s with a frame, %d calls\n", title ? title : "stack bound", defined,
           defined == 1 ? "" : "s", edges);

    /* Indirect-call mappings must name real functions, or the graph changed.
       A callee that is missing while its caller still calls through a
       pointer fails (renamed: the bound could miss it); missing while no
       such call is left, it was inlined away: a warning. */
    for (k = 0; k < nmaps; k++) {
        int j, c, hit = 0, calls = 0;
        for (j = 0; j < nnodes; j++)
            if (name_matches(nodes[j].name, maps[k].caller)) {
                hit = 1;
                calls += nodes[j].indirect;
            }
        if (!hit) printf("warning: --indirect %s: no such function in the graph\n", maps[k].caller);
        for (c = 0; c < maps[k].ncallees; c++) {
            hit = 0;
            for (j = 0; j < nnodes; j++)
                if (!nodes[j].external && name_matches(nodes[j].name, maps[k].callees[c])) hit = 1;
            if (!hit && calls) {
                printf("FAIL --indirect %s=...%s: %s calls through a pointer but no function %s is in the graph "
                       "(renamed?): update the mapping\n",
                       maps[k].caller, maps[k].callees[c], maps[k].caller, maps[k].callees[c]);
                failures++;
            } else if (!hit)
                printf("warning: --indirect %s=...%s: no such function in the graph\n", maps[k].caller,
                       maps[k].callees[c]);
        }
    }

    /* frames */
    order = (int *)xrealloc(NULL, (size_t)nnodes * sizeof *order);
    {
        int n = 0, over = 0, dyn_bounded = 0;
        for (i = 0; i < nnodes; i++)
            if (!nodes[i].external) order[n++] = i;
        qsort(order, (size_t)n, sizeof *order, by_frame);
        printf("largest frame: %s %ld bytes (%s)", nodes[order[0]].name, nodes[order[0]].frame, nodes[order[0]].loc);
        for (i = 1; i < n && i < 6; i++) printf("%s %s %ld", i == 1 ? "; next:" : ",", nodes[order[i]].name, nodes[order[i]].frame);
        printf("\n");
        for (i = 0; i < n; i++) {
            sb_node *f = &nodes[order[i]];
            dyn_bounded += f->dynamic == DYN_BOUNDED;
            if (f->frame > frame_limit || f->dynamic == DYN_UNBOUNDED) {
                if (!over++) printf("frames over %ld bytes or unbounded:\n", frame_limit);
                printf("  FAIL %7ld  %-40s %s%s\n", f->frame, f->name, f->loc,
                       f->dynamic == DYN_UNBOUNDED ? "  DYNAMIC (alloca/VLA): unbounded"
                       : f->dynamic == DYN_BOUNDED  ? "  (dynamic,bounded)"
                                                   : "");
                failures++;
            }
        }
        if (verbose) {
            printf("every frame:\n");
            for (i = 0; i < n; i++)
                printf("       %7ld  %-40s %s%s\n", nodes[order[i]].frame, nodes[order[i]].name, nodes[order[i]].loc,
                       nodes[order[i]].dynamic == DYN_UNBOUNDED ? "  DYNAMIC"
                       : nodes[order[i]].dynamic == DYN_BOUNDED ? "  (dynamic,bounded)" : "");
        }
        if (!over) printf("frames: all <= %ld bytes, none unbounded\n", frame_limit);
        if (dyn_bounded)
            printf("note: %d frame%s \"dynamic,bounded\" (pushed call arguments or bounded alloca): counted at "
                   "the bound gcc reports\n",
                   dyn_bounded, dyn_bounded == 1 ? " is" : "s are");
    }

    /* recursion */
    tarjan_stack = (int *)xrealloc(NULL, (size_t)nnodes * sizeof *tarjan_stack);
    for (i = 0; i < nnodes; i++)
        if (nodes[i].index < 0) strongconnect(i);
    {
        int s, cycles = 0;
        for (s = 0; s < nscc; s++) {
            int members = 0, first = -1;
            for (i = 0; i < nnodes; i++)
                if (nodes[i].scc == s) {
                    members++;
                    if (first < 0) first = i;
                }
            if (members > 1 || self_call(first)) {
                cycles++;
                failures++;
                printf("FAIL recursion:");
                for (i = 0; i < nnodes; i++)
                    if (nodes[i].scc == s) printf(" %s (%s)", nodes[i].name, nodes[i].loc);
                printf("%s\n", members == 1 ? " calls itself" : " call each other");
            }
        }
        if (!cycles) printf("recursion: none\n");
    }

    /* indirect calls */
    {
        int unmapped = 0;
        for (i = 0; i < nnodes; i++)
            if (nodes[i].indirect) {
                int m = map_for(i);
                if (m >= 0) {
                    maps[m].used = 1;
                    if (verbose) printf("indirect: %s (%s) -> mapped\n", nodes[i].name, nodes[i].indirect_site);
                }
                if (m < 0 || maps[m].user) unmapped++;
            }
        if (unmapped) {
            printf("calls through a pointer left to the user's callbacks (counted as %ld bytes each, --callback-bytes):",
                   callback_bytes);
            for (i = 0; i < nnodes; i++)
                if (nodes[i].indirect) {
                    int m = map_for(i);
                    if (m < 0 || maps[m].user) printf(" %s (%s)", nodes[i].name, nodes[i].indirect_site);
                }
            printf("\n");
        }
        for (i = 0; i < nnodes; i++) /* static, defined, never called directly: probably through a pointer */
            if (!nodes[i].external && nodes[i].is_static && nodes[i].incoming == 0) {
                int m, c, named = 0;
                for (m = 0; m < nmaps; m++)
                    for (c = 0; c < maps[m].ncallees; c++)
                        if (name_matches(nodes[i].name, maps[m].callees[c])) named = 1;
                if (!named)
                    printf("warning: static %s (%s, %ld bytes) has no direct caller: if it is called through a "
                           "pointer, name it in --indirect\n",
                           nodes[i].name, nodes[i].loc, nodes[i].frame);
            }
    }

    /* roots */
    if (!brief) printf("worst-case stack per root (limit %ld bytes):\n", stack_limit);
    for (k = 0; k < nroots; k++) {
        int r = find_root(roots[k]);
        long w;
        if (r < 0) {
            printf("  FAIL %-24s not in the call graph\n", roots[k]);
            failures++;
            continue;
        }
        w = worst(r);
        if (w == SB_UNBOUNDED) {
            printf("  FAIL %-24s unbounded (recursion)\n", roots[k]);
            failures++;
        } else {
            int bad = w > stack_limit;
            if (brief) printf("  %-4s %-24s %7ld bytes (limit %ld), deepest chain (frames):\n", bad ? "FAIL" : "ok", roots[k], w, stack_limit);
            else printf("  %-4s %-24s %7ld bytes, deepest chain (frame, running total):\n", bad ? "FAIL" : "ok", roots[k], w);
            failures += bad;
        }
        print_chain(r);
        if (w != SB_UNBOUNDED && w > stack_limit) print_branches(r, stack_limit, verbose ? 1000 : 8);
    }

    if (public_prefix) {
        int n = 0, shown;
        size_t plen = strlen(public_prefix);
        for (i = 0; i < nnodes; i++)
            if (!nodes[i].external && !nodes[i].is_static && strncmp(nodes[i].name, public_prefix, plen) == 0 &&
                strchr(nodes[i].name, '.') == NULL) {
                worst(i);
                order[n++] = i;
            }
        qsort(order, (size_t)n, sizeof *order, by_worst);
        if (brief) printf("public %s* functions: %d; the largest worst case:\n", public_prefix, n);
        else printf("public %s* functions: %d; the largest worst cases%s:\n", public_prefix, n,
               public_limit >= 0 ? " (with --public-limit)" : "");
        for (shown = 0; shown < n && (verbose || shown < (brief ? 1 : 5)); shown++) {
            sb_node *f = &nodes[order[shown]];
            int bad = public_limit >= 0 && (f->worst == SB_UNBOUNDED || f->worst > public_limit);
            if (f->worst == SB_UNBOUNDED)
                printf("  %-4s %-32s unbounded (recursion)\n", bad ? "FAIL" : "", f->name);
            else
                printf("  %-4s %-32s %7ld bytes\n", bad ? "FAIL" : "", f->name, f->worst);
            if (verbose) print_chain(order[shown]);
            failures += bad;
        }
        if (public_limit >= 0)
            for (; shown < n; shown++) {
                sb_node *f = &nodes[order[shown]];
                failures += f->worst == SB_UNBOUNDED || f->worst > public_limit;
            }
    }

    /* functions outside the graph */
    {
        int any = 0;
        for (i = 0; i < nnodes; i++)
            if (nodes[i].external && nodes[i].incoming) {
                long f = ext_frame(i);
                if (brief) break;
                if (!any++) printf("outside the graph (libc/libm; frame counted as given by --frame, else 0):");
                if (f) printf(" %s=%ld", nodes[i].name, f);
                else printf(" %s", nodes[i].name);
            }
        if (any) printf("\n");
        for (k = 0; k < nframes; k++)
            if (!frames[k].used) printf("note: --frame %s: not called\n", frames[k].name);
    }

    if (failures)
        printf("stack_bound: FAIL, %d limit%s broken\n", failures, failures == 1 ? "" : "s");
    else
        printf("stack_bound: ok\n");
    free(order);
    return failures ? 1 : 0;
}

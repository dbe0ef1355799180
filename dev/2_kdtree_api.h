/* ======================================================================
   Layer 2: kd-tree
   ====================================================================== */

/* A static 3-D kd-tree over caller points (x y z doubles, 3 per point,
   contiguous). It is built into caller memory (sqffd_kdtree_workspace_size())
   over a permutation of point indices: the points are NOT copied, so they must
   stay alive and unchanged while the tree is used. Memory: 4 bytes per point
   for the permutation plus at most one 24-byte node per 2.5 points (under
   14 bytes per point in all). The fields are readable but belong to the
   library. A built tree is read-only: any number of threads may query it.

   Splits: the widest side of a node's tight bounding box is cut at its middle
   (so the cut always lies inside the data), each child keeps at least 5 points
   (leaves hold 5 to 10, except the root leaf of a tiny set and leaves of
   identical points, which may be any size), and where those cuts would make
   the tree deeper than SQFFD_KDTREE_MAX_DEPTH allows the node is split at its
   median instead, so degenerate spacing (e.g. exponential) keeps O(log n)
   depth. Every node stores the gap around its cut (the low child's largest
   and the high child's smallest coordinate on the cut axis). Queries walk the
   tree without recursion (a stack of SQFFD_KDTREE_MAX_DEPTH entries), nearest
   side first, and skip a subtree when the sum of the squared per-axis offsets
   from the query to the gaps crossed on the way there (incremental distance)
   exceeds the current answer; that sum is added in the same order as a
   point's distance, so it never exceeds the computed distance of any point
   in the subtree and no point is missed by rounding.

       size_t size = sqffd_kdtree_workspace_size(n);
       void *memory = malloc(size);
       sqffd_kdtree tree;
       if (sqffd_kdtree_build(&tree, points, n, memory, size) == SQFFD_OK)
           nearest = sqffd_kdtree_nearest(&tree, query, &dist2);

   Query contract shared by nearest / knn / radius:
   - distances are squared Euclidean, computed in double (points farther apart
     than ~1e154 overflow to +inf; results stay defined);
   - a query with a NaN or infinite coordinate (or a NULL or zeroed tree)
     finds nothing: nearest returns 0 with *dist2 = NaN, knn and radius
     return 0;
   - equal distances are ordered arbitrarily but deterministically (the same
     tree and query always give the same answer). */

#define SQFFD_KDTREE_MAX_DEPTH 64 /* bound on the leaf depth (and the query stack) */

/* One node, 24 bytes. Nodes are stored depth-first: an inner node's low child
   is the next node. */
typedef struct sqffd_kdtree_node {
    union {
        struct { double low, high; } split;   /* inner: gap around the cut on `axis` */
        struct { uint32_t begin, end; } leaf; /* leaf: its points are index[begin..end) */
    } u;
    uint32_t high_child; /* inner: node number of the high child; leaf: 0 */
    uint32_t axis;       /* inner: cut axis 0, 1 or 2; leaf: SQFFD_KDTREE_LEAF */
} sqffd_kdtree_node;

#define SQFFD_KDTREE_LEAF 3u

typedef struct sqffd_kdtree {
    const double *points;    /* the caller's points (not copied) */
    size_t count;            /* number of points */
    uint32_t *index;         /* permutation of 0..count-1; every leaf's points are one range */
    sqffd_kdtree_node *nodes;/* node 0 is the root */
    size_t node_count;       /* nodes used: 1 if count <= 10, else at most 2 (count / 5) - 1 */
    double bbox[2][3];       /* bounding box of all points: [0] = min corner, [1] = max corner */
} sqffd_kdtree;

/* Workspace bytes sqffd_kdtree_build() needs for n points (the tree lives in
   it). 0 if n is 0 or beyond what the tree can index (n > UINT32_MAX). */
SQFFD_DEF size_t sqffd_kdtree_workspace_size(size_t n);

/* Builds the tree over points[0 .. 3n) into the workspace (any alignment).
   Returns SQFFD_ERROR_INVALID_ARGUMENT (tree, points or workspace NULL, or
   n == 0), SQFFD_ERROR_NON_FINITE (a NaN or infinite coordinate),
   SQFFD_ERROR_TOO_LARGE (n > UINT32_MAX) or SQFFD_ERROR_WORKSPACE_TOO_SMALL;
   on error *tree is zeroed. Deterministic: the same points give the same tree. */
SQFFD_DEF sqffd_result sqffd_kdtree_build(sqffd_kdtree *tree, const double *points, size_t n,
                                          void *workspace, size_t workspace_size);

/* Index (into the caller's points) of the point nearest to query; its squared
   distance goes to *dist2 when dist2 is not NULL. */
SQFFD_DEF size_t sqffd_kdtree_nearest(const sqffd_kdtree *tree, const double query[3], double *dist2);

/* The k nearest points, by increasing distance: writes min(k, n) indices and
   squared distances (both arrays have room for k) and returns min(k, n);
   0 if k == 0 or an argument is NULL. */
SQFFD_DEF size_t sqffd_kdtree_knn(const sqffd_kdtree *tree, const double query[3], size_t k,
                                  size_t *indices, double *dist2);

/* Points within `radius` of query (distance <= radius): returns how many there
   are, and writes the min(that, capacity) nearest of them by increasing
   distance to indices and dist2 (both with room for capacity). capacity 0
   only counts (the arrays may then be NULL). A negative or NaN radius finds
   nothing. */
SQFFD_DEF size_t sqffd_kdtree_radius(const sqffd_kdtree *tree, const double query[3], double radius,
                                     size_t *indices, double *dist2, size_t capacity);
